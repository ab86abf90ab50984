/* nav_app_state.c -- see nav_app_state.h. */
#define _DEFAULT_SOURCE /* clock_gettime under -std=c11 */

#include "firmware/app/nav_app_state.h"

#include <stdio.h>
#include <string.h>
#include <time.h>

#include "math/units.h"
#include "firmware/linux/tc_auth.h"

uint64_t nav_app_now_us(void)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_MONOTONIC, &ts) != 0) {
        return 0;
    }
    return (uint64_t)ts.tv_sec * MFNS_US_PER_S + (uint64_t)ts.tv_nsec / 1000u;
}

const mfns_caltable_t *nav_app_table(const nav_app_t *app)
{
    return &app->tables[app->table_cur];
}

uint8_t nav_app_tlm_mode(const nav_app_t *app)
{
    if (app->waiting_table) {
        return (uint8_t)TLM_MODE_WAIT_TABLE;
    }
    return app->standby ? (uint8_t)TLM_MODE_STANDBY : nav_tlm_mode(app->nav.mode);
}

mfns_nav_status_t nav_app_set_prior(nav_app_t *app, float x, float y, float z, float roll_deg, float pitch_deg,
                                    float yaw_deg)
{
    const float d2r = MFNS_RAD_PER_DEG_F;
    const mfns_euler_t e = {roll_deg * d2r, pitch_deg * d2r, yaw_deg * d2r};
    const mfns_pose_t p0 = mfns_pose_from_position(mfns_euler213_to_m3(e), mfns_v3(x, y, z));
    return mfns_nav_set_prior(&app->nav, &p0);
}

void nav_app_apply_budget(nav_app_t *app, mfns_caltable_t *t)
{
    if (app->budget_units != 0u) {
        t->index.budget_units = app->budget_units; /* the board's, over the table's (docs/budgets.md) */
    }
}

void nav_app_note_frame_time(nav_app_t *app, const mfns_frame_t *const frames[], uint64_t t_us)
{
    bool fused = false;
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        fused = fused || frames[k] != NULL;
    }
    if (!fused) {
        return;
    }
    if (app->last_fused_t_us != 0u && t_us > app->last_fused_t_us) {
        const uint64_t step = t_us - app->last_fused_t_us;
        const uint32_t s32 = step > UINT32_MAX ? UINT32_MAX : (uint32_t)step;
        if (app->frame_period_min_us == 0u || s32 < app->frame_period_min_us) {
            app->frame_period_min_us = s32;
        }
    }
    app->last_fused_t_us = t_us;
}

void nav_app_note_latency(nav_app_t *app, uint64_t gathered_us)
{
    if (app->tlm.kind == NAV_TLM_NONE || tlm_txq_frames(&app->tlm.q) != 0u) {
        return; /* no link, or something of this cycle is still queued: not out yet */
    }
    uint64_t arrival_max_ns = 0, stamp_min_ns = UINT64_MAX;
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        const nav_cam_t *c = &app->cams.cam[k];
        if (c->used && c->frame.arrival_ns != 0u) {
            arrival_max_ns = c->frame.arrival_ns > arrival_max_ns ? c->frame.arrival_ns : arrival_max_ns;
            stamp_min_ns = c->frame.timestamp_ns < stamp_min_ns ? c->frame.timestamp_ns : stamp_min_ns;
        }
    }
    if (arrival_max_ns == 0u || arrival_max_ns < stamp_min_ns) {
        return; /* no arrival time (an unpaced replay), or stamps not on the arrival's clock */
    }
    const uint64_t now = nav_app_now_us();
    const uint64_t lat_us = (now - gathered_us) + (arrival_max_ns - stamp_min_ns) / 1000u;
    mfns_cycle_stats_add(&app->latency, lat_us > UINT32_MAX ? UINT32_MAX : (uint32_t)lat_us, 0u);
}

void nav_app_watch_clock(nav_app_t *app, uint32_t cycle, uint64_t t_us)
{
    /* live and in a replay alike: it is this board's UTC that stepped (a
     * replay's packet times are its recording's and do not move; its UTC
     * pairs keep their anchor) */
    const int64_t step_us = nav_time_step_now(&app->time);
    if (step_us == 0) {
        return;
    }
    /* to the nearest ms: the two clocks are read one after the other, so a
     * 5 s step measures a few µs either side of 5 000 000 µs */
    const int64_t step_ms = (step_us >= 0 ? step_us + 500 : step_us - 500) / 1000;
    const int32_t s32 = step_ms > INT32_MAX ? INT32_MAX : step_ms < -INT32_MAX ? -INT32_MAX : (int32_t)step_ms;
    const nav_time_sync_t sync = nav_time_sync_now();
    const uint8_t q = (uint8_t)(sync.synced ? TLM_TIMEQ_SYNCED : TLM_TIMEQ_SYSTEM);
    fprintf(stderr,
            "mfns-nav: the board's UTC stepped by %+lld ms against the flight clock (step %u; %s): the flight clock is "
            "unaffected, the next housekeeping carries the new UTC\n",
            (long long)step_ms, app->time.n_steps, sync.synced ? "synchronised" : "not synchronised");
    (void)nav_tlm_event(&app->tlm, cycle, t_us, TLM_EVT_CLOCK_STEP, TLM_SEV_WARNING, q, s32,
                        (int32_t)app->time.n_steps); /* failures counted in tlm */
    app->hk_now = true; /* housekeeping this cycle: the ground re-correlates at once */
}

_Static_assert((int)TLM_WS_INSIDE == (int)MFNS_WS_INSIDE && (int)TLM_WS_OUTSIDE == (int)MFNS_WS_OUTSIDE,
               "the housekeeping's workspace_t extends the core's watch states");

/* The workspace watch's state as housekeeping carries it: outside with no
 * track is LOST_OUTSIDE, the state in which acquisitions are refused. */
static uint8_t hk_workspace(const mfns_nav_t *nav)
{
    if (nav->wsw.state == (uint8_t)MFNS_WS_INSIDE) {
        return (uint8_t)TLM_WS_INSIDE;
    }
    return (uint8_t)(nav->mode == MFNS_NAV_MODE_TRACK ? TLM_WS_OUTSIDE : TLM_WS_LOST_OUTSIDE);
}

void nav_app_housekeeping(nav_app_t *app, uint32_t cycle, uint32_t n_cycles, uint64_t t_us)
{
    nav_tlm_t *t = &app->tlm;
    tlm_packet_t p;
    memset(&p, 0, sizeof p);
    p.type = TLM_TYPE_HK;
    p.time = tlm_time_from_us(t_us);
    tlm_hk_t *h = &p.u.hk;
    h->cycle = cycle;
    h->mode = nav_app_tlm_mode(app);
    h->cpu_load_permille = (uint16_t)(TLM_SCALE_PCT_FROM_PERMILLE_U16 * mfns_cycle_stats_cpu_load_pct(&app->stats));
    h->cycle_p50_us = mfns_cycle_stats_percentile(&app->stats, 50.0f);
    h->cycle_p95_us = mfns_cycle_stats_percentile(&app->stats, 95.0f);
    h->cycle_p99_us = mfns_cycle_stats_percentile(&app->stats, 99.0f);
    h->cycle_max_us = app->stats.max_us;
    h->n_cycles = n_cycles;
    h->n_fix = app->count.n_fix;
    h->n_degraded = app->count.n_degraded;
    h->n_no_fix = app->count.n_no_fix;
    h->cams_enabled = nav_cams_enabled_mask(&app->cams); /* CAMERA_DISABLE clears bits */
    h->n_cmd_accepted = app->tc.cmd.n_accepted;
    h->n_cmd_rejected = app->tc.cmd.n_rejected;
    h->cmd_seq_last = app->tc.cmd.seq_last;
    h->tc_epoch = app->tc.auth.epoch;           /* not secret: the ground signs with it */
    h->tc_arsn_last = app->tc.auth.count_last;
    if (app->tc.kind != NAV_TC_NONE) {
        /* the uplink report, MACed (tc_auth.h): the only thing the ground believes */
        tc_auth_report_t r;
        tc_auth_report(&app->tc.auth, &r);
        h->tc_epoch = r.epoch;
        h->tc_arsn_last = r.count_last;
        h->tc_state = r.state;
        h->tc_nonce_hi = (uint32_t)(r.nonce >> 32);
        h->tc_nonce_lo = (uint32_t)(r.nonce & 0xFFFFFFFFu);
        h->tc_report_spi = r.spi;
        h->tc_report_mac0 = (uint32_t)r.mac[0] << 24 | (uint32_t)r.mac[1] << 16 | (uint32_t)r.mac[2] << 8 | r.mac[3];
        h->tc_report_mac1 = (uint32_t)r.mac[4] << 24 | (uint32_t)r.mac[5] << 16 | (uint32_t)r.mac[6] << 8 | r.mac[7];
        h->tc_report_mac2 = (uint32_t)r.mac[8] << 24 | (uint32_t)r.mac[9] << 16 | (uint32_t)r.mac[10] << 8 | r.mac[11];
        h->tc_report_mac3 =
            (uint32_t)r.mac[12] << 24 | (uint32_t)r.mac[13] << 16 | (uint32_t)r.mac[14] << 8 | r.mac[15];
    }
    h->n_fixlog_errors = atomic_load(&app->fixlog.lost_records) + atomic_load(&app->fixlog.dropped_records);
    h->n_storage_errors = app->n_storage_errors;
    h->n_beacons_biased = app->nav.bmon.n_flagged;
    h->workspace = hk_workspace(&app->nav);
    /* the cycle margin (issue 24 item 6): the frame period less the longest cycle of the interval */
    h->frame_period_us = app->frame_period_min_us;
    h->cycle_margin_us = app->frame_period_min_us == 0u
                             ? 0
                             : (int32_t)((int64_t)app->frame_period_min_us - (int64_t)app->stats.max_us);
    h->n_tlm_dropped = t->q.dropped;
    h->n_cam_errors = (uint32_t)(app->cams.errors > UINT32_MAX ? UINT32_MAX : app->cams.errors);
    h->table_crc32 = nav_app_table(app)->crc32;
    h->n_acquire = app->count.n_acquire;
    h->acq_units_max = app->count.acq_units_max;
    h->acq_units_last = app->count.acq_last.units;
    h->acq_band_last = app->count.acq_last.band;
    h->acq_best_last = app->count.acq_last.best_inliers;
    const nav_time_pair_t utc = nav_time_pair_now(&app->time, t_us); /* CCSDS-style time correlation */
    h->utc_s = utc.utc_s;
    h->utc_us = utc.utc_us;
    h->time_quality = utc.quality;
    const nav_time_sync_t sync = nav_time_sync_now(); /* the kernel's bound on that UTC */
    h->time_error_us = sync.error_us;
    h->time_offset_us = sync.offset_us;
    (void)nav_tlm_send(t, &p); /* failures counted in encode_errors */
    const uint32_t lost = atomic_load(&app->fixlog.lost_records);
    if (lost != app->fixlog_lost_reported && app->fixlog_lost_reported == 0u) {
        /* once: the log's disk refuses (full, read-only); the count goes on in housekeeping */
        (void)nav_tlm_event(t, cycle, t_us, TLM_EVT_STORAGE_FAULT, TLM_SEV_WARNING, 1u, 0, (int32_t)lost);
    }
    app->fixlog_lost_reported = lost;
    if (t->q.dropped != t->last_dropped_reported) {
        (void)nav_tlm_event(t, cycle, t_us, TLM_EVT_TLM_DROPPED, TLM_SEV_WARNING, 0,
                            (int32_t)(t->q.dropped - t->last_dropped_reported), 0);
        t->last_dropped_reported = t->q.dropped;
    }
}
