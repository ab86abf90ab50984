/* nav_cmd_dispatch.c -- see nav_cmd_dispatch.h. */
#include "firmware/app/nav_cmd_dispatch.h"

#include <string.h>

void nav_cmd_init(nav_cmd_t *c)
{
    memset(c, 0, sizeof *c);
    tc_deframer_init(&c->rx);
}

void nav_cmd_reset_counters(nav_cmd_t *c)
{
    c->n_accepted = 0;
    c->n_rejected = 0;
}

void nav_cmd_new_session(nav_cmd_t *c)
{
    if (c != NULL) {
        c->have_last = false;
    }
}

static bool seq_is_newer(const nav_cmd_t *c, uint16_t seq)
{
    if (!c->have_last) {
        return true;
    }
    const uint32_t ahead = (uint32_t)(seq - c->seq_last) & TLM_CCSDS_SEQ_MASK;
    return ahead >= 1u && ahead <= NAV_CMD_SEQ_WINDOW;
}

static void reject(nav_cmd_t *c, const tc_cmd_t *cmd, tc_status_t why, const nav_cmd_ops_t *ops)
{
    c->n_rejected++;
    c->last_status = why;
    const uint8_t subject = cmd != NULL && cmd->have_opcode ? cmd->opcode : 0u;
    const int32_t seq = cmd != NULL && cmd->have_seq ? (int32_t)cmd->seq : -1;
    ops->event(ops->ctx, TLM_EVT_CMD_REJECTED, TLM_SEV_WARNING, subject, seq, (int32_t)why);
}

void nav_cmd_handle(nav_cmd_t *c, const tc_cmd_t *cmd, tc_status_t status, const nav_cmd_ops_t *ops)
{
    if (c == NULL || ops == NULL || ops->event == NULL) {
        return;
    }
    if (cmd == NULL || status != TC_OK) {
        reject(c, cmd, cmd == NULL ? TC_E_NULL : status, ops);
        return;
    }
    if (ops->auth != NULL) {
        const tc_status_t a = ops->auth(ops->ctx, cmd);
        if (a != TC_OK) {
            reject(c, cmd, a, ops);
            return;
        }
    }
    if (!seq_is_newer(c, cmd->seq)) {
        reject(c, cmd, TC_E_SEQUENCE, ops);
        return;
    }
    int32_t arg1 = 0;
    tc_status_t st = TC_OK;
    if (cmd->opcode == 0u || ops->table == NULL || cmd->opcode >= ops->table_len) {
        st = TC_E_OPCODE; /* the decoder refuses these; kept for safety */
    } else if (ops->table[cmd->opcode] == NULL) {
        st = TC_E_STATE; /* no action for it in this program */
    } else {
        st = ops->table[cmd->opcode](ops->ctx, cmd, &arg1);
    }
    if (st != TC_OK) {
        reject(c, cmd, st, ops);
        return;
    }
    c->have_last = true;
    c->seq_last = cmd->seq;
    c->last_status = TC_OK;
    if (cmd->opcode == TC_OP_RESET_COUNTERS) {
        nav_cmd_reset_counters(c); /* cFS style: the counters read 0 afterwards; this command is not counted */
    } else {
        c->n_accepted++;
    }
    ops->event(ops->ctx, TLM_EVT_CMD_ACCEPTED, TLM_SEV_INFO, cmd->opcode, (int32_t)cmd->seq, arg1);
}

size_t nav_cmd_feed(nav_cmd_t *c, const uint8_t *data, size_t n, unsigned max_cmds, const nav_cmd_ops_t *ops,
                    unsigned *handled)
{
    unsigned done = 0;
    size_t i = 0;
    if (c != NULL && data != NULL && ops != NULL) {
        for (; i < n && done < max_cmds; i++) {
            tc_cmd_t cmd;
            tc_status_t st = TC_OK;
            if (tc_deframer_push(&c->rx, data[i], &cmd, &st)) {
                nav_cmd_handle(c, &cmd, st, ops);
                done++;
            }
        }
    }
    if (handled != NULL) {
        *handled = done;
    }
    return i;
}
