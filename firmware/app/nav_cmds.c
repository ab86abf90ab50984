/* nav_cmds.c -- see nav_cmds.h. */
#include "nav_cmds.h"

#include <stdio.h>
#include <string.h>

#include "caltable_file.h"
#include "math/units.h"
#include "nav_app.h"
#include "nav_tablestore.h"

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

/* TABLE_LOAD: read and validate completely into the spare slot, then bind the
 * navigator to it (between cycles, so no cycle ever sees half a table). The
 * old table keeps running on any failure. */
static tc_status_t cmd_TABLE_LOAD(void *ctx, const tc_cmd_t *cmd, int32_t *arg1)
{
    nav_app_t *app = ctx;
    const char *path = cmd->u.path;
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
    if (ts == MFNS_CALTABLE_OK && mfns_nav_init(&app->nav, nt, app->solver) != MFNS_NAV_OK) {
        ts = MFNS_CALTABLE_E_SOLVER_SETTINGS;
        if (mfns_nav_init(&app->nav, cur, app->solver) != MFNS_NAV_OK) {
            fprintf(stderr, "mfns-nav: re-binding the old table failed\n"); /* it was bound before: cannot happen */
        }
    }
    (void)mfns_nav_enable_filter(&app->nav, app->nav_filter_period_us); /* a bind turns it off */
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
    if (had_prior) {
        (void)mfns_nav_set_prior(&app->nav, &prior); /* confirmed by the new table's beacons, or dropped */
    }
    send_event(app, TLM_EVT_TABLE_LOADED, TLM_SEV_INFO, 0, nt->format_version, (int32_t)nt->crc32);
    if (app->state_dir != NULL) {
        /* persisted (atomically) so a restart runs it; the old one is kept as the previous */
        const int err = nav_tablestore_commit(app->state_dir, app->table_buf, nt->size_bytes);
        if (err != 0) {
            fprintf(stderr, "mfns-nav: TABLE_LOAD %s runs but was not stored in %s: %s (a restart runs the old one)\n",
                    path, app->state_dir, strerror(err));
        }
        send_event(app, TLM_EVT_TABLE_STORED, err == 0 ? TLM_SEV_INFO : TLM_SEV_ERROR, (uint8_t)(err == 0 ? 0 : 1), err,
                   (int32_t)nt->crc32);
    }
    *arg1 = (int32_t)nt->crc32;
    return TC_OK;
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
    return tc_auth_check(&app->tc.auth, cmd);
}

nav_cmd_ops_t nav_cmds_ops(struct nav_app *app)
{
    return (nav_cmd_ops_t){app, k_cmds, sizeof k_cmds / sizeof k_cmds[0], cmd_event, cmd_auth};
}
