/* nav_cmds.c -- see nav_cmds.h. */
#include "firmware/app/nav_cmds.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "firmware/app/caltable_file.h"
#include "math/units.h"
#include "firmware/app/nav_app_state.h"
#include "firmware/app/nav_cmds_upload.h"
#include "firmware/app/nav_tablestore.h"
#include "firmware/app/tc_state.h"

static void send_event(nav_app_t *app, tlm_event_code_t code, tlm_severity_t sev, uint8_t subject, int32_t a0,
                       int32_t a1)
{
    (void)nav_tlm_event(&app->tlm, app->cycle_now, app->last_t_us, code, sev, subject, a0,
                        a1); /* failures counted in tlm */
}

/* The dispatch's events: into telemetry, and one stderr line per command. */
static void cmd_event(void *ctx, tlm_event_code_t code, tlm_severity_t sev, uint8_t subject, int32_t a0, int32_t a1)
{
    nav_app_t *app = ctx;
    send_event(app, code, sev, subject, a0, a1);
    if (code == TLM_EVT_CMD_ACCEPTED) {
        fprintf(stderr, "mfns-nav: cycle %u: command %s (seq %d) accepted\n", app->cycle_now, tc_opcode_name(subject),
                (int)a0);
    } else {
        fprintf(stderr, "mfns-nav: cycle %u: command %s (seq %d) rejected: %s\n", app->cycle_now,
                subject != 0u ? tc_opcode_name(subject) : "-", (int)a0, tc_strerror((int)a1));
    }
}

static tc_status_t cmd_NOOP(void *ctx, const tc_cmd_t *cmd, int32_t *arg1)
{
    (void)ctx;
    (void)cmd;
    (void)arg1;
    return TC_OK;
}

static tc_status_t cmd_RESET_COUNTERS(void *ctx, const tc_cmd_t *cmd, int32_t *arg1)
{
    nav_app_t *app = ctx;
    (void)cmd;
    (void)arg1;
    app->cams.errors = 0;
    return TC_OK;
}

static tc_status_t cmd_SET_MODE(void *ctx, const tc_cmd_t *cmd, int32_t *arg1)
{
    nav_app_t *app = ctx;
    const uint8_t mode = cmd->u.mode;
    const uint8_t before = nav_app_tlm_mode(app);
    if (mode == TLM_MODE_TRACK && !app->nav.have_prior) {
        return TC_E_STATE; /* nothing to track from: send SET_POSE_HINT first */
    }
    if (mode == TLM_MODE_STANDBY) {
        app->standby = true;
    } else if (mode == TLM_MODE_ACQUIRE) {
        app->standby = false;
        mfns_nav_lose_track(&app->nav);
    } else if (mode == TLM_MODE_TRACK) {
        const mfns_pose_t prior = app->nav.prior;
        if (mfns_nav_set_prior(&app->nav, &prior) != MFNS_NAV_OK) {
            return TC_E_STATE;
        }
        app->standby = false;
    } else {
        return TC_E_ARG;
    }
    *arg1 = mode;
    const uint8_t after = nav_app_tlm_mode(app);
    if (after != before) {
        send_event(app, TLM_EVT_MODE_CHANGE, TLM_SEV_INFO, 0, before, after);
    }
    return TC_OK;
}

static tc_status_t cmd_SET_POSE_HINT(void *ctx, const tc_cmd_t *cmd, int32_t *arg1)
{
    nav_app_t *app = ctx;
    const tc_pose_hint_t *h = &cmd->u.pose;
    (void)arg1;
    /* a prior for the next cycles, verified there like any other: never a fix by itself;
     * wire units (um, udeg) to mm and deg as the product of the reciprocal, as flown */
    const float mm_per_um = 1.0f / MFNS_UM_PER_MM_F;
    const float deg_per_udeg = 1.0f / MFNS_UDEG_PER_DEG_F;
    const mfns_nav_status_t st = nav_app_set_prior(
        app, (float)h->pos_um[0] * mm_per_um, (float)h->pos_um[1] * mm_per_um, (float)h->pos_um[2] * mm_per_um,
        (float)h->att_udeg[0] * deg_per_udeg, (float)h->att_udeg[1] * deg_per_udeg, (float)h->att_udeg[2] * deg_per_udeg);
    return st == MFNS_NAV_OK ? TC_OK : TC_E_ARG;
}

static tc_status_t camera_enable(nav_app_t *app, uint8_t k, bool enable, int32_t *arg1)
{
    if (k >= MFNS_NUM_CAMERAS) {
        return TC_E_ARG;
    }
    app->cams.cam[k].enabled = enable;
    *arg1 = nav_cams_enabled_mask(&app->cams);
    return TC_OK;
}

static tc_status_t cmd_CAMERA_ENABLE(void *ctx, const tc_cmd_t *cmd, int32_t *arg1)
{
    return camera_enable(ctx, cmd->u.camera, true, arg1);
}

static tc_status_t cmd_CAMERA_DISABLE(void *ctx, const tc_cmd_t *cmd, int32_t *arg1)
{
    return camera_enable(ctx, cmd->u.camera, false, arg1);
}

/* TABLE_LOAD while waiting for a first table (nav_app.h WAIT_TABLE): no
 * navigator and no camera yet, so nothing to compare or swap: the table is
 * validated into the current slot, stored (so a restart runs it) and the
 * start-up goes on with it (nav_app.c; it sends TABLE_LOADED). */
static tc_status_t table_load_first(nav_app_t *app, const char *path, int32_t *arg1)
{
    mfns_caltable_t *t = &app->tables[app->table_cur];
    uint32_t off = 0;
    const mfns_caltable_status_t ts = mfns_caltable_load_file(path, app->table_buf, sizeof app->table_buf, t, &off);
    if (ts != MFNS_CALTABLE_OK) {
        fprintf(stderr, "mfns-nav: TABLE_LOAD %s refused: %s (at byte %u); still waiting for a table\n", path,
                mfns_caltable_strerror(ts), off);
        send_event(app, TLM_EVT_TABLE_REFUSED, TLM_SEV_ERROR, 0, (int32_t)ts, 0);
        memset(t, 0, sizeof *t); /* housekeeping says no table (crc 0) */
        return TC_E_TABLE;
    }
    if (app->state_dir != NULL) {
        const int err = nav_tablestore_commit(app->state_dir, app->table_buf, t->size_bytes);
        if (err != 0) {
            fprintf(stderr, "mfns-nav: TABLE_LOAD %s runs but was not stored in %s: %s (a restart waits again)\n", path,
                    app->state_dir, strerror(err));
        }
        send_event(app, TLM_EVT_TABLE_STORED, err == 0 ? TLM_SEV_INFO : TLM_SEV_ERROR, (uint8_t)(err == 0 ? 0 : 1), err,
                   (int32_t)t->crc32);
    }
    app->waiting_table = false; /* the start-up goes on with this table */
    *arg1 = (int32_t)t->crc32;
    return TC_OK;
}

/* TABLE_LOAD: read and validate completely into the spare slot, then bind the
 * navigator to it (between cycles, so no cycle ever sees half a table). The
 * old table keeps running on any failure. */
static tc_status_t table_load(nav_app_t *app, const char *path, int32_t *arg1)
{
    if (app->waiting_table) {
        return table_load_first(app, path, arg1);
    }
    const mfns_caltable_t *cur = nav_app_table(app);
    const int spare = 1 - app->table_cur;
    mfns_caltable_t *nt = &app->tables[spare];
    uint32_t off = 0;
    mfns_caltable_status_t ts = mfns_caltable_load_file(path, app->table_buf, sizeof app->table_buf, nt, &off);
    if (ts == MFNS_CALTABLE_OK) {
        for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
            if (nt->rig.cam[k].k.width != cur->rig.cam[k].k.width ||
                nt->rig.cam[k].k.height != cur->rig.cam[k].k.height) {
                ts = MFNS_CALTABLE_E_IMAGE_SIZE; /* the cameras are open at the old size */
            }
        }
    }
    const bool had_prior = app->nav.have_prior;
    const mfns_pose_t prior = app->nav.prior;
    if (ts == MFNS_CALTABLE_OK) {
        nav_app_apply_budget(app, nt); /* the board's budget holds for any table */
    }
    if (ts == MFNS_CALTABLE_OK && nt->crc32 == cur->crc32 && nt->size_bytes == cur->size_bytes) {
        /* the running table again (issue 45): nothing to re-bind, so the navigator keeps its
         * track and its camera and beacon monitors (a re-bind cost ~10 cycles of fixes and
         * raised false CAMERAS_DISAGREE / BEACON_MISSING); answered and stored as any load */
        send_event(app, TLM_EVT_TABLE_LOADED, TLM_SEV_INFO, 0, nt->format_version, (int32_t)nt->crc32);
        fprintf(stderr, "mfns-nav: TABLE_LOAD %s: the running table (crc %08x): kept, the track goes on\n", path,
                nt->crc32);
        *arg1 = (int32_t)nt->crc32;
        return TC_OK;
    }
    bool kept = false; /* a compatible table (same rig and beacons, other settings): the core re-binds */
    if (ts == MFNS_CALTABLE_OK && mfns_nav_rebind(&app->nav, nt, &kept) == MFNS_NAV_OK && kept) {
        fprintf(stderr, "mfns-nav: TABLE_LOAD %s: the same rig and beacons (crc %08x -> %08x): re-bound, the "
                "track goes on\n", path, cur->crc32, nt->crc32);
    } else if (ts == MFNS_CALTABLE_OK && mfns_nav_init(&app->nav, nt, app->solver) != MFNS_NAV_OK) {
        ts = MFNS_CALTABLE_E_SOLVER_SETTINGS;
        if (mfns_nav_init(&app->nav, cur, app->solver) != MFNS_NAV_OK) {
            fprintf(stderr, "mfns-nav: re-binding the old table failed\n"); /* it was bound before: cannot happen */
        }
    }
    if (!kept) {
        (void)mfns_nav_enable_filter(&app->nav, app->nav_filter_period_us); /* a bind turns it off */
    }
    if (ts != MFNS_CALTABLE_OK) {
        fprintf(stderr, "mfns-nav: TABLE_LOAD %s refused: %s (at byte %u); the old table (crc %08x) stays\n", path,
                mfns_caltable_strerror(ts), off, cur->crc32);
        send_event(app, TLM_EVT_TABLE_REFUSED, TLM_SEV_ERROR, 0, (int32_t)ts, 0);
        if (had_prior) {
            (void)mfns_nav_set_prior(&app->nav, &prior); /* refused: the track goes on from the old table */
        }
        return TC_E_TABLE;
    }
    app->table_cur = spare;
    if (had_prior && !kept) {
        (void)mfns_nav_set_prior(&app->nav, &prior); /* confirmed by the new table's beacons, or dropped */
    }
    send_event(app, TLM_EVT_TABLE_LOADED, TLM_SEV_INFO, 0, nt->format_version, (int32_t)nt->crc32);
    if (app->state_dir != NULL) {
        /* persisted (atomically) so a restart runs it; the old one is kept as the previous */
        const int err = nav_tablestore_commit(app->state_dir, app->table_buf, nt->size_bytes);
        if (err != 0) {
            fprintf(stderr, "mfns-nav: TABLE_LOAD %s runs but was not stored in %s: %s (a restart runs the old one)\n",
                    path, app->state_dir, strerror(err));
            app->n_storage_errors++; /* housekeeping n_storage_errors */
        }
        send_event(app, TLM_EVT_TABLE_STORED, err == 0 ? TLM_SEV_INFO : TLM_SEV_ERROR, (uint8_t)(err == 0 ? 0 : 1), err,
                   (int32_t)nt->crc32);
    }
    *arg1 = (int32_t)nt->crc32;
    return TC_OK;
}

static tc_status_t cmd_TABLE_LOAD(void *ctx, const tc_cmd_t *cmd, int32_t *arg1)
{
    return table_load(ctx, cmd->u.path, arg1);
}

/* UPLOAD_END: the received file checked and stored (nav_cmds_upload.h), then
 * loaded as TABLE_LOAD loads a file (a refused one leaves the old table flying). */
static tc_status_t cmd_UPLOAD_END(void *ctx, const tc_cmd_t *cmd, int32_t *arg1)
{
    (void)cmd;
    char path[512];
    const tc_status_t st = nav_cmds_upload_end(ctx, path, sizeof path);
    if (st != TC_OK) {
        return st;
    }
    const tc_status_t lst = table_load(ctx, path, arg1);
    /* The stored upload was only the load's input: loaded, the table store holds its own
     * copy (table.mfnstbl); refused (a table the running cameras cannot fly, settings the
     * solver refuses), it must not stay behind looking like a pending table. */
    if (unlink(path) != 0) {
        ((nav_app_t *)ctx)->n_storage_errors++; /* housekeeping n_storage_errors */
        fprintf(stderr, "mfns-nav: upload %s not removed after its load: %s\n", path, strerror(errno));
    }
    return lst;
}

/* Indexed by the opcode, generated from the dictionary: TC_OPCODE_LIST
 * (tc_codes_gen.h, from mfns_tc.xml) names every command, and each must
 * have its cmd_<NAME> above, so a command added to the dictionary does not
 * build until its action is written here (cFS sample_app's dispatch table,
 * generated). An opcode without an entry is refused by the dispatch. */
#define NAV_CMD_ENTRY(NAME, opcode, arg_bytes, arg_count) [TC_OP_##NAME] = cmd_##NAME,
static const nav_cmd_fn_t k_cmds[] = {TC_OPCODE_LIST(NAV_CMD_ENTRY)};
#undef NAV_CMD_ENTRY
_Static_assert(sizeof k_cmds / sizeof k_cmds[0] == (size_t)TC_OP_MAX + 1u,
               "one entry per opcode up to the dictionary's last (a new opcode needs its command here)");

/* Every command is authenticated first (tc_auth.h; insecure mode passes plain ones). */
static tc_status_t cmd_auth(void *ctx, const tc_cmd_t *cmd)
{
    nav_app_t *app = ctx;
    tc_auth_t *a = &app->tc.auth;
    const tc_status_t st = tc_auth_check(a, cmd);
    if (st == TC_OK && a->resynced) {
        /* a re-synchronisation: keep the new epoch as the floor of the next
         * start (best effort: the ground's record keeps epochs fresh anyway) */
        a->resynced = false;
        nav_cmd_new_session(&app->tc.cmd); /* the sequence guard starts with the session */
        char err[384];
        const int e = app->state_dir != NULL ? tc_state_write(app->state_dir, a->epoch, err, sizeof err) : EROFS;
        if (e == 0) {
            a->state_bits = 0u;
        } else {
            a->state_bits |= (uint8_t)TC_AUTH_ST_STATE_RO;
            app->n_storage_errors++;
            fprintf(stderr, "mfns-nav: uplink epoch %u not stored: %s\n", a->epoch,
                    app->state_dir != NULL ? err : "no --state-dir");
        }
        send_event(app, TLM_EVT_TC_RESYNC, e == 0 ? TLM_SEV_INFO : TLM_SEV_WARNING, (uint8_t)(e == 0 ? 0u : 1u),
                   (int32_t)a->epoch, e);
        fprintf(stderr, "mfns-nav: cycle %u: uplink re-synchronised to epoch %u\n", app->cycle_now, a->epoch);
    }
    return st;
}

nav_cmd_ops_t nav_cmds_ops(struct nav_app *app)
{
    return (nav_cmd_ops_t){app, k_cmds, sizeof k_cmds / sizeof k_cmds[0], cmd_event, cmd_auth};
}

/* Waiting for a table there is no navigator and no camera: NOOP,
 * RESET_COUNTERS, TABLE_LOAD and the upload of a table run, every other
 * command is refused with TC_E_STATE (a SET_POSE_HINT would touch a navigator
 * never initialised). */
static tc_status_t cmd_waiting(void *ctx, const tc_cmd_t *cmd, int32_t *arg1)
{
    switch (cmd->opcode) {
    case TC_OP_NOOP:
    case TC_OP_RESET_COUNTERS:
    case TC_OP_TABLE_LOAD:
    case TC_OP_UPLOAD_START:
    case TC_OP_UPLOAD_DATA:
    case TC_OP_UPLOAD_END:
    case TC_OP_UPLOAD_ABORT:
        return k_cmds[cmd->opcode](ctx, cmd, arg1);
    default:
        return TC_E_STATE;
    }
}
#define NAV_WAIT_ENTRY(NAME, opcode, arg_bytes, arg_count) [TC_OP_##NAME] = cmd_waiting,
static const nav_cmd_fn_t k_cmds_waiting[] = {TC_OPCODE_LIST(NAV_WAIT_ENTRY)};
#undef NAV_WAIT_ENTRY
_Static_assert(sizeof k_cmds_waiting / sizeof k_cmds_waiting[0] == sizeof k_cmds / sizeof k_cmds[0],
               "the waiting table covers every opcode");

nav_cmd_ops_t nav_cmds_ops_waiting(struct nav_app *app)
{
    return (nav_cmd_ops_t){app, k_cmds_waiting, sizeof k_cmds_waiting / sizeof k_cmds_waiting[0], cmd_event, cmd_auth};
}
