/* nav_cmd.c -- see nav_cmd.h. */
#include "nav_cmd.h"

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
    if (!seq_is_newer(c, cmd->seq)) {
        reject(c, cmd, TC_E_SEQUENCE, ops);
        return;
    }
    int32_t arg1 = 0;
    tc_status_t st = TC_OK;
    switch (cmd->opcode) {
    case TC_OP_NOOP: break;
    case TC_OP_RESET_COUNTERS:
        /* cFS style: the counters read 0 afterwards; this command is not counted */
        if (ops->reset_counters != NULL) {
            ops->reset_counters(ops->ctx);
        }
        nav_cmd_reset_counters(c);
        break;
    case TC_OP_SET_MODE: st = ops->set_mode != NULL ? ops->set_mode(ops->ctx, cmd->u.mode, &arg1) : TC_E_STATE; break;
    case TC_OP_SET_POSE_HINT:
        st = ops->set_pose_hint != NULL ? ops->set_pose_hint(ops->ctx, &cmd->u.pose, &arg1) : TC_E_STATE;
        break;
    case TC_OP_CAMERA_ENABLE:
    case TC_OP_CAMERA_DISABLE:
        st = ops->camera_enable != NULL
                 ? ops->camera_enable(ops->ctx, cmd->u.camera, cmd->opcode == TC_OP_CAMERA_ENABLE, &arg1)
                 : TC_E_STATE;
        break;
    case TC_OP_TABLE_LOAD:
        st = ops->table_load != NULL ? ops->table_load(ops->ctx, cmd->u.path, &arg1) : TC_E_STATE;
        break;
    default: st = TC_E_OPCODE; break; /* the decoder refuses these; kept for safety */
    }
    if (st != TC_OK) {
        reject(c, cmd, st, ops);
        return;
    }
    c->have_last = true;
    c->seq_last = cmd->seq;
    c->last_status = TC_OK;
    if (cmd->opcode != TC_OP_RESET_COUNTERS) {
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
