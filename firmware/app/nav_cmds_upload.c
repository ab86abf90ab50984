/* nav_cmds_upload.c -- see nav_cmds_upload.h. */
#include "firmware/app/nav_cmds_upload.h"

#include <stdio.h>
#include <string.h>

#include "firmware/app/nav_app_state.h"
#include "firmware/app/nav_upload.h"

/* The wire's segment and name are the receiver's: one size each. */
_Static_assert(TC_UPLOAD_SEG_LEN == NAV_UPLOAD_SEG_MAX, "UPLOAD_DATA carries one receiver segment");
_Static_assert(TC_UPLOAD_LEN_MAX == NAV_UPLOAD_SEG_MAX, "UPLOAD_DATA's length range is the receiver's");
_Static_assert(TC_UPLOAD_NAME_MAX == NAV_UPLOAD_NAME_MAX, "UPLOAD_START's name field is the receiver's");

tc_status_t nav_cmds_upload_status(int upload_status)
{
    switch (upload_status) {
    case NAV_UP_OK:
    case NAV_UP_DUPLICATE:
    case NAV_UP_RESUMED: return TC_OK;
    case NAV_UP_E_STATE:
    case NAV_UP_E_TIMEOUT: return TC_E_UPLOAD_STATE; /* abandoned: no upload open any more */
    case NAV_UP_E_SIZE: return TC_E_UPLOAD_SIZE;
    case NAV_UP_E_NAME: return TC_E_UPLOAD_NAME;
    case NAV_UP_E_LENGTH: return TC_E_ARG; /* the decoder passes only 1..TC_UPLOAD_LEN_MAX */
    case NAV_UP_E_GAP: return TC_E_UPLOAD_GAP;
    case NAV_UP_E_OVERRUN: return TC_E_UPLOAD_OVERRUN;
    case NAV_UP_E_CONFLICT: return TC_E_UPLOAD_CONFLICT;
    case NAV_UP_E_INCOMPLETE: return TC_E_UPLOAD_INCOMPLETE;
    case NAV_UP_E_CRC: return TC_E_UPLOAD_CRC;
    case NAV_UP_E_TABLE: return TC_E_TABLE;
    case NAV_UP_E_STORE: return TC_E_UPLOAD_STORE;
    default: return TC_E_UPLOAD_STATE;
    }
}

static uint32_t up_now_ms(void)
{
    return (uint32_t)(nav_app_now_us() / 1000u); /* the receiver's clock wraps (nav_upload_tick) */
}

/* One stderr line for a refusal the ground sees only as a code. */
static tc_status_t refused(const nav_app_t *app, const char *what, nav_upload_status_t s)
{
    const tc_status_t st = nav_cmds_upload_status((int)s);
    if (st != TC_OK && s != NAV_UP_E_GAP) { /* a gap is the link's normal go-back: not worth a line each */
        fprintf(stderr, "mfns-nav: cycle %u: %s: %s (next expected offset %u)\n", app->cycle_now, what,
                nav_upload_strerror(s), nav_upload_next(&app->upload));
    }
    return st;
}

tc_status_t cmd_UPLOAD_START(void *ctx, const tc_cmd_t *cmd, int32_t *arg1)
{
    nav_app_t *app = ctx;
    const tc_upload_start_t *a = &cmd->u.upload_start;
    char name[NAV_UPLOAD_NAME_MAX];
    memcpy(name, a->name, sizeof name);
    name[sizeof name - 1u] = '\0'; /* the decoder checked it: NUL-padded within the field */
    const nav_upload_status_t s = nav_upload_start(&app->upload, a->size, a->crc32, name, up_now_ms());
    if (s == NAV_UP_OK || s == NAV_UP_RESUMED) {
        fprintf(stderr, "mfns-nav: cycle %u: upload %s: %u bytes, crc %08x, %s at offset %u\n", app->cycle_now,
                name, a->size, a->crc32, s == NAV_UP_OK ? "opened" : "resumed", nav_upload_next(&app->upload));
    }
    *arg1 = (int32_t)nav_upload_next(&app->upload);
    return refused(app, "UPLOAD_START", s);
}

tc_status_t cmd_UPLOAD_DATA(void *ctx, const tc_cmd_t *cmd, int32_t *arg1)
{
    nav_app_t *app = ctx;
    const tc_upload_data_t *a = &cmd->u.upload_data;
    const nav_upload_status_t s = nav_upload_data(&app->upload, a->offset, a->bytes, a->len, up_now_ms());
    *arg1 = (int32_t)nav_upload_next(&app->upload);
    return refused(app, "UPLOAD_DATA", s);
}

tc_status_t nav_cmds_upload_end(nav_app_t *app, char *path, size_t path_len)
{
    nav_upload_t *u = &app->upload;
    const nav_upload_status_t s = nav_upload_end(u, up_now_ms());
    if (s != NAV_UP_OK) {
        return refused(app, "UPLOAD_END", s);
    }
    /* the loader over the bytes in RAM first (into the spare slot, which a load overwrites
     * anyway): a refused file is never written */
    mfns_caltable_status_t ts = MFNS_CALTABLE_OK;
    if (nav_upload_validate(u, &app->tables[1 - app->table_cur], &ts) != NAV_UP_OK) {
        fprintf(stderr, "mfns-nav: cycle %u: upload %s refused by the table loader: %s; the old table stays\n",
                app->cycle_now, u->name, mfns_caltable_strerror(ts));
        (void)nav_tlm_event(&app->tlm, app->cycle_now, app->last_t_us, TLM_EVT_TABLE_REFUSED, TLM_SEV_ERROR, 0,
                            (int32_t)ts, 0);
        return TC_E_TABLE;
    }
    if (app->state_dir == NULL) {
        (void)nav_upload_abort(u);
        fprintf(stderr, "mfns-nav: cycle %u: upload not stored: no --state-dir\n", app->cycle_now);
        return TC_E_UPLOAD_STORE;
    }
    const int err = nav_upload_store(u, app->state_dir, path, path_len);
    if (err != 0) {
        app->n_storage_errors++; /* housekeeping n_storage_errors */
        fprintf(stderr, "mfns-nav: cycle %u: upload not stored in %s: %s; the old table stays\n", app->cycle_now,
                app->state_dir, strerror(err));
        return TC_E_UPLOAD_STORE;
    }
    fprintf(stderr, "mfns-nav: cycle %u: upload complete and stored as %s: loading it\n", app->cycle_now, path);
    return TC_OK;
}

tc_status_t cmd_UPLOAD_ABORT(void *ctx, const tc_cmd_t *cmd, int32_t *arg1)
{
    nav_app_t *app = ctx;
    (void)cmd;
    *arg1 = 0;
    const nav_upload_status_t s = nav_upload_abort(&app->upload);
    if (s == NAV_UP_OK) {
        fprintf(stderr, "mfns-nav: cycle %u: upload aborted: nothing stored\n", app->cycle_now);
    }
    return refused(app, "UPLOAD_ABORT", s);
}

void nav_cmds_upload_tick(nav_app_t *app, uint64_t now_ms)
{
    if (nav_upload_tick(&app->upload, (uint32_t)now_ms) == NAV_UP_E_TIMEOUT) {
        fprintf(stderr, "mfns-nav: upload abandoned: no command for %u s (nothing stored)\n",
                app->upload.timeout_ms / 1000u);
    }
}
