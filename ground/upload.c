/* upload.c -- see upload.h. */
#include "ground/upload.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "firmware/nav/table/caltable.h"

int ground_upload_open(ground_upload_t *g, const char *path, uint8_t *buf, size_t cap, char *err, size_t err_size)
{
    memset(g, 0, sizeof *g);
    g->path = path;
    g->buf = buf;
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        (void)snprintf(err, err_size, "%s: %s", path, strerror(errno));
        return -1;
    }
    const size_t n = fread(buf, 1, cap, f);
    const bool more = n == cap && fgetc(f) != EOF;
    const bool bad = ferror(f) != 0;
    if (fclose(f) != 0 || bad) {
        (void)snprintf(err, err_size, "%s: read failed", path);
        return -1;
    }
    if (n == 0u || more) {
        (void)snprintf(err, err_size, "%s: %s", path, n == 0u ? "empty" : "larger than the ground's limit");
        return -1;
    }
    g->size = (uint32_t)n;
    g->crc32 = mfns_crc32(0u, buf, n);
    const char *base = strrchr(path, '/');
    base = base != NULL ? base + 1 : path;
    size_t k = 0;
    for (; k < sizeof g->name - 1u && base[k] != '\0'; k++) {
        const char c = base[k];
        const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' ||
                        c == '_' || c == '-';
        g->name[k] = ok && !(k == 0u && c == '.') ? c : '_';
    }
    if (k == 0u) {
        g->name[k++] = '_';
    }
    g->name[k] = '\0';
    g->phase = UPLOAD_START;
    return 0;
}

static void fail(ground_upload_t *g, int reject, uint64_t now_ms)
{
    g->phase = UPLOAD_FAILED;
    g->reject = reject;
    g->t_done_ms = now_ms;
}

/* Everything in flight forgotten (its answers, if any come, match nothing). */
static void forget(ground_upload_t *g)
{
    memset(g->slot, 0, sizeof g->slot);
    g->n_inflight = 0;
    g->ctl_wait = false;
    g->gen++;
}

bool ground_upload_next(ground_upload_t *g, uint64_t now_ms, tc_cmd_t *cmd)
{
    if (g->phase == UPLOAD_OFF || g->phase == UPLOAD_OK || g->phase == UPLOAD_FAILED) {
        return false;
    }
    if ((g->ctl_wait || g->n_inflight > 0u) && now_ms - g->last_news_ms >= UPLOAD_ANSWER_MS) {
        /* answers lost (or the board busy): ask it where it is */
        if (++g->tries > UPLOAD_TRIES) {
            fail(g, 0, now_ms);
            return false;
        }
        forget(g);
        g->n_restarts++;
        g->phase = g->phase == UPLOAD_END && g->acked == g->size ? UPLOAD_END : UPLOAD_START;
    }
    memset(cmd, 0, sizeof *cmd);
    if (g->ctl_wait) {
        return false;
    }
    if (g->phase == UPLOAD_START) {
        cmd->opcode = TC_OP_UPLOAD_START;
        cmd->u.upload_start.size = g->size;
        cmd->u.upload_start.crc32 = g->crc32;
        memcpy(cmd->u.upload_start.name, g->name, sizeof g->name);
        return true;
    }
    if (g->phase == UPLOAD_END) {
        cmd->opcode = TC_OP_UPLOAD_END;
        return true;
    }
    /* UPLOAD_DATA */
    if (g->acked == g->size && g->n_inflight == 0u) {
        g->phase = UPLOAD_END;
        cmd->opcode = TC_OP_UPLOAD_END;
        return true;
    }
    if (g->n_inflight >= UPLOAD_WINDOW || g->send_off >= g->size) {
        return false;
    }
    const uint32_t left = g->size - g->send_off;
    const uint32_t n = left < TC_UPLOAD_SEG_LEN ? left : TC_UPLOAD_SEG_LEN;
    cmd->opcode = TC_OP_UPLOAD_DATA;
    cmd->u.upload_data.offset = g->send_off;
    cmd->u.upload_data.len = (uint8_t)n;
    memcpy(cmd->u.upload_data.bytes, g->buf + g->send_off, n);
    return true;
}

void ground_upload_sent(ground_upload_t *g, const tc_cmd_t *cmd, uint16_t seq, uint64_t now_ms)
{
    if (g->t_start_ms == 0u) {
        g->t_start_ms = now_ms;
    }
    if (!g->ctl_wait && g->n_inflight == 0u) {
        g->last_news_ms = now_ms; /* the answer clock starts with the first command outstanding */
    }
    if (cmd->opcode != TC_OP_UPLOAD_DATA) {
        g->ctl_wait = true;
        g->ctl_seq = seq;
        return;
    }
    for (unsigned i = 0; i < UPLOAD_WINDOW; i++) {
        if (!g->slot[i].live) {
            g->slot[i] = (upload_slot_t){true, seq, cmd->u.upload_data.offset, g->gen};
            g->n_inflight++;
            break;
        }
    }
    const uint32_t end = cmd->u.upload_data.offset + cmd->u.upload_data.len;
    if (cmd->u.upload_data.offset < g->sent_end) {
        g->n_resent++;
    }
    g->sent_end = end > g->sent_end ? end : g->sent_end;
    g->n_data++;
    g->send_off = end;
}

static void control_answer(ground_upload_t *g, const tlm_event_t *e, bool ok, uint64_t now_ms)
{
    g->ctl_wait = false;
    if (e->subject == TC_OP_UPLOAD_START) {
        if (!ok) {
            fail(g, e->arg1, now_ms);
            return;
        }
        g->acked = g->send_off = (uint32_t)e->arg1; /* a resumed upload: from the board's next offset */
        g->phase = UPLOAD_DATA;
        return;
    }
    if (ok) { /* UPLOAD_END */
        g->phase = UPLOAD_OK;
        g->table_crc = (uint32_t)e->arg1;
        g->t_done_ms = now_ms;
    } else if (e->arg1 == TC_E_UPLOAD_INCOMPLETE || e->arg1 == TC_E_UPLOAD_STATE) {
        g->phase = UPLOAD_START; /* the board lost bytes or the upload: ask it where it is */
        g->n_restarts++;
        if (++g->tries > UPLOAD_TRIES) {
            fail(g, e->arg1, now_ms);
        }
    } else {
        fail(g, e->arg1, now_ms);
    }
}

void ground_upload_event(ground_upload_t *g, const tlm_event_t *e, uint64_t now_ms)
{
    const bool ok = e->code == TLM_EVT_CMD_ACCEPTED;
    if ((!ok && e->code != TLM_EVT_CMD_REJECTED) || g->phase == UPLOAD_OFF || g->phase == UPLOAD_OK ||
        g->phase == UPLOAD_FAILED) {
        return;
    }
    const uint16_t seq = (uint16_t)e->arg0;
    if (e->subject == TC_OP_UPLOAD_START || e->subject == TC_OP_UPLOAD_END) {
        if (g->ctl_wait && seq == g->ctl_seq && e->arg0 >= 0) {
            g->last_news_ms = now_ms;
            control_answer(g, e, ok, now_ms);
        }
        return;
    }
    if (e->subject != TC_OP_UPLOAD_DATA || e->arg0 < 0) {
        return;
    }
    for (unsigned i = 0; i < UPLOAD_WINDOW; i++) {
        upload_slot_t *s = &g->slot[i];
        if (!s->live || s->seq != seq) {
            continue;
        }
        s->live = false;
        g->n_inflight--;
        g->last_news_ms = now_ms;
        if (ok) {
            if ((uint32_t)e->arg1 > g->acked) {
                g->acked = (uint32_t)e->arg1;
                g->tries = 0; /* progress */
            }
        } else if (e->arg1 == TC_E_UPLOAD_GAP) {
            if (s->gen == g->gen) { /* the first refusal of this round: back to the board's next */
                g->gen++;
                g->n_gaps++;
                g->send_off = g->acked;
            }
        } else if (e->arg1 == TC_E_UPLOAD_STATE) {
            forget(g); /* the board has no upload open (restarted, abandoned): begin again */
            g->phase = UPLOAD_START;
            g->n_restarts++;
            if (++g->tries > UPLOAD_TRIES) {
                fail(g, e->arg1, now_ms);
            }
        } else {
            fail(g, e->arg1, now_ms);
        }
        return;
    }
}

bool ground_upload_finished(const ground_upload_t *g)
{
    return g->phase == UPLOAD_OK || g->phase == UPLOAD_FAILED;
}

bool ground_upload_abort(ground_upload_t *g, uint64_t now_ms, tc_cmd_t *cmd)
{
    if (ground_upload_finished(g) || g->phase == UPLOAD_OFF || g->t_start_ms == 0u) {
        return false;
    }
    memset(cmd, 0, sizeof *cmd);
    cmd->opcode = TC_OP_UPLOAD_ABORT;
    fail(g, 0, now_ms);
    g->aborted = true;
    return true;
}
