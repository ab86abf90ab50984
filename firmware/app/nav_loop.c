/* nav_loop.c -- see nav_loop.h. */
#include "firmware/app/nav_loop.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "math/units.h"
#include "firmware/app/nav_cmds.h"
#include "firmware/app/nav_cmds_upload.h"

_Static_assert(NAV_LOOP_HK_PERIOD_US == MFNS_US_PER_S, "housekeeping once per second of frame time");

typedef enum { CYCLE_GO_ON = 0, CYCLE_DATA_ENDED, CYCLE_CAMERAS_GONE } cycle_end_t;

static uint64_t now_ms(void)
{
    return nav_app_now_us() / 1000u;
}

void nav_loop_housekeeping(nav_app_t *app, uint32_t cycle, uint32_t n_cycles, uint64_t t_us)
{
    nav_app_housekeeping(app, cycle, n_cycles, t_us);
    app->count.acq_units_max = 0; /* per report interval */
    mfns_cycle_stats_reset(&app->stats);
    app->frame_period_min_us = 0;
}

/* Between cycles: the commands that came in. */
static void take_commands(nav_app_t *app)
{
    const nav_cmd_ops_t ops = nav_cmds_ops(app);
    const uint64_t t_ms = now_ms();
    nav_cmds_upload_tick(app, t_ms); /* an upload idle past its timeout abandoned */
    nav_tc_in_poll(&app->tc, &app->tlm.uart, &ops, t_ms);
}

/* A frame's photometric response as its metadata reports it (the response
 * watch, spot_watch.h): exposure x linear gain, the gain 0 dB when not
 * known; 0 (unknown) without an exposure. */
static float frame_response(const mfns_cam_frame_t *f)
{
    if (f->exposure_us <= 0) {
        return 0.0f;
    }
    const float gain = isfinite(f->gain_db) ? powf(10.0f, f->gain_db / MFNS_DB_PER_AMPLITUDE_DECADE) : 1.0f;
    const float r = (float)f->exposure_us * gain;
    return isfinite(r) ? r : 0.0f;
}

/* The navigator on this cycle's frames (or, in STANDBY, an empty NO_FIX
 * output), the frames back to their drivers, the acquisition counters. */
static void navigate(nav_app_t *app, uint32_t cycle, const mfns_frame_t *frames[MFNS_NUM_CAMERAS])
{
    mfns_nav_status_t ns = MFNS_NAV_OK;
    if (app->standby) {
        /* SET_MODE standby: cameras keep delivering, the navigator does not run */
        memset(&app->out, 0, sizeof app->out);
        app->out.sol.status = MFNS_POSE_NO_FIX;
        app->out.mode = app->out.next_mode = app->nav.mode;
    } else {
        /* each frame's own capture stamp for the filter (nav_filter_cycle.h) */
        int64_t t_cap[MFNS_NUM_CAMERAS];
        for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
            t_cap[k] = frames[k] != NULL ? (int64_t)(app->cams.cam[k].frame.timestamp_ns / 1000u) : 0;
        }
        (void)mfns_nav_set_frame_times(&app->nav, t_cap); /* app->nav is initialised: cannot fail */
        float response[MFNS_NUM_CAMERAS];
        for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
            response[k] = frames[k] != NULL ? frame_response(&app->cams.cam[k].frame) : 0.0f;
        }
        if (mfns_nav_set_frame_response(&app->nav, response) != MFNS_NAV_OK) {
            fprintf(stderr, "mfns-nav: cycle %u: the frames' exposure and gain are not usable: taken as unknown\n",
                    cycle);
        }
        for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
            if (app->cams.cam[k].timing_doubt) {
                (void)mfns_nav_doubt_timing(&app->nav, k); /* k in range: cannot fail */
                app->cams.cam[k].timing_doubt = false;
            }
        }
        ns = mfns_nav_cycle(&app->nav, frames, &app->out);
    }
    nav_cams_give_back_used(&app->cams);
    if (ns != MFNS_NAV_OK) {
        fprintf(stderr, "mfns-nav: cycle %u: %s\n", cycle, mfns_nav_strerror(ns));
        app->out.sol.status = MFNS_POSE_NO_FIX;
    }
    if (app->out.acquired) {
        nav_counts_t *n = &app->count;
        n->n_acquire++;
        n->acq_last = app->out.acq;
        n->acq_units_max = app->out.acq.units > n->acq_units_max ? app->out.acq.units : n->acq_units_max;
    }
}

/* The fix record of a usable fix (nav_fixlog.h): every one into the
 * on-board log, one per NAV_LOOP_FIX_DOWNLINK_PERIOD_US down the link (its
 * pose is the nav packet just sent). */
static void send_fix_record(nav_app_t *app, const tlm_packet_t *nav_pkt, uint32_t cycle, uint64_t t_us)
{
    if (nav_pkt->u.nav.status == TLM_NAV_NO_FIX || app->standby) {
        return;
    }
    const mfns_caltable_t *t = app->nav.table;
    const unsigned n = nav_fixlog_packets(&app->out, &app->nav.obs, &t->rig, &t->beacons, t->solver.track_gate_px,
                                          cycle, t_us, app->fix_pkts, NAV_FIXLOG_MAX_ASSOC);
    (void)nav_fixlog_record(&app->fixlog, nav_pkt, app->fix_pkts, n); /* dropped ones are counted */
    if (n > 0u && (!app->fix_down_sent || t_us - app->last_fix_down_us >= NAV_LOOP_FIX_DOWNLINK_PERIOD_US)) {
        for (unsigned i = 0; i < n; i++) {
            (void)nav_tlm_send(&app->tlm, &app->fix_pkts[i]); /* failures counted in tlm */
        }
        app->last_fix_down_us = t_us;
        app->fix_down_sent = true;
    }
}

/* The self-survey monitor's findings (beacon_monitor.h): one event each (the
 * navigator itself down-weights a biased beacon in its live map, nav_cycle.h). */
static void survey_monitor(nav_app_t *app, uint32_t cycle, uint64_t t_us)
{
    const mfns_bmon_report_t *r = &app->out.bmon;
    if (r->beacon_chi2 > 0.0f && r->new_beacon >= 0 && (uint32_t)r->new_beacon < app->nav.map.count) {
        const mfns_beacon_t *b = &app->nav.map.beacon[r->new_beacon];
        (void)nav_tlm_event(&app->tlm, cycle, t_us, TLM_EVT_BEACON_BIASED, TLM_SEV_WARNING,
                            (uint8_t)(b->id > 254u ? 255u : b->id), (int32_t)(r->beacon_chi2 * 100.0f),
                            (int32_t)b->id); /* failures counted in tlm */
    }
    if (r->camera_chi2 > 0.0f && r->new_camera >= 0) {
        (void)nav_tlm_event(&app->tlm, cycle, t_us, TLM_EVT_CAMERA_BIASED, TLM_SEV_WARNING, (uint8_t)r->new_camera,
                            (int32_t)(r->camera_chi2 * 100.0f), 0);
    }
}

/* The cycle's nav packet, counted by the status it carries. */
static void send_solution(nav_app_t *app, uint32_t cycle, uint64_t t_us)
{
    tlm_packet_t p;
    /* a fix of the navigation filter is stamped with the instant it is for
     * (the latest frame's capture, nav_filter_cycle.h), the rest with the
     * cycle's time (never later than that instant: the cycle's time is its
     * earliest frames') */
    const int64_t t_filt = app->out.filt.used ? app->out.filt.t_us : 0;
    t_us = t_filt > 0 && (uint64_t)t_filt > t_us ? (uint64_t)t_filt : t_us;
    nav_tlm_nav_packet(&app->out, cycle, t_us, &p);
    if (app->standby) {
        p.u.nav.mode = TLM_MODE_STANDBY;
    }
    /* counted from the packet itself, so the log, housekeeping and
     * nav.csv say the same (a pose the packet refuses is NO_FIX) */
    if (p.u.nav.status == TLM_NAV_FIX) {
        app->count.n_fix++;
    } else if (p.u.nav.status == TLM_NAV_DEGRADED) {
        app->count.n_degraded++;
    } else {
        app->count.n_no_fix++;
    }
    app->last_t_us = t_us;
    (void)nav_tlm_send(&app->tlm, &p); /* failures counted in tlm */
    if (!app->standby) {
        /* In STANDBY the navigator did not run and app->out is zeroed: its "none"
         * indices (-1) read as beacon or camera 0, which raised 5 WARNINGs and 2
         * INFOs every cycle (issue 46). No findings without a navigation. */
        nav_tlm_integrity_events(&app->tlm, &app->out, &app->nav.table->beacons, app->nav.integ_set.hold_cycles,
                                 cycle, t_us);
    }
    send_fix_record(app, &p, cycle, t_us);
    if (!app->standby) {
        survey_monitor(app, cycle, t_us);
    }
}

static void print_cycle(const nav_app_t *app, uint32_t cycle)
{
    const mfns_nav_output_t *out = &app->out;
    const mfns_pose_solution_t *s = &out->sol;
    fprintf(stderr,
            "cycle %u %s %s (%s) used %u blobs %u/%u/%u pos %.2f %.2f %.2f mm att %.3f %.3f %.3f deg rms %.3f px\n",
            cycle, mfns_nav_mode_str(out->mode), mfns_pose_status_str(s->status), mfns_pose_strerror(s->reason),
            s->beacons_used, out->cam[0].observations, out->cam[1].observations, out->cam[2].observations,
            (double)s->r_wb_w.x, (double)s->r_wb_w.y, (double)s->r_wb_w.z, (double)s->euler_deg.roll,
            (double)s->euler_deg.pitch, (double)s->euler_deg.yaw, (double)s->residual_rms_px);
    if (out->acquired) {
        fprintf(stderr, "  acquisition: %u work units, band %u, best %u inliers%s%s\n", out->acq.units, out->acq.band,
                out->acq.best_inliers,
                out->acq_source == MFNS_ACQ_SRC_CARRIED ? ", fix from a search carried over cycles" : "",
                out->acq_carry_age > 0u ? ", a search carried on" : "");
    }
    if (app->nav.filt.on && (out->filt.ran || out->filt.started)) {
        const mfns_bank_output_t *f = &out->filt.out;
        fprintf(stderr,
                "  filter: %s%s%s%s %s (%s) PL %.2f mm %.3f deg (beacons %.2f mm %.3f deg) hyp %u unmonitorable %u"
                " own-assoc %u snapshot-sep %.2f clocks in doubt %c%c%c%s\n",
                out->filt.started ? "started" : "ran", out->filt.used ? ", flown" : "",
                f->restart ? ", restart" : "", out->filt.motion_exceeded ? ", motion exceeded" : "",
                mfns_pose_status_str(f->status), mfns_pose_strerror(f->reason), (double)f->pl_pos_mm,
                (double)f->pl_att_deg, (double)f->pl_beacon_pos_mm, (double)f->pl_beacon_att_deg, f->hypotheses,
                f->unmonitorable, app->nav.filt.own_assoc, (double)out->filt.motion_sep,
                (app->nav.filt.timing_doubt & 1U) != 0U ? 'x' : '-', (app->nav.filt.timing_doubt & 2U) != 0U ? 'y' : '-',
                (app->nav.filt.timing_doubt & 4U) != 0U ? 'z' : '-',
                f->timing_trusted >= 0 ? " (one cleared)" : "");
    }
}

static cycle_end_t run_cycle(nav_app_t *app, const nav_opts_t *o, uint32_t cycle)
{
    app->cycle_now = cycle;
    take_commands(app); /* between cycles: the previous cycle's telemetry is out */
    nav_cams_t *cams = &app->cams;
    const uint64_t prog_us = app->clock_monotonic ? nav_app_now_us() : nav_app_now_us() - app->t0_us;
    const uint64_t event_t_us = cams->sync.have_last ? cams->sync.last_us : prog_us;
    if (nav_cams_gather(cams, &app->tlm, o, cycle, event_t_us) == 0) {
        return CYCLE_DATA_ENDED; /* every camera's data ended (a held frame would have kept it active) */
    }
    nav_cams_report_ended(cams, &app->tlm, cycle, event_t_us);
    const uint64_t start = nav_app_now_us();
    const mfns_frame_t *frames[MFNS_NUM_CAMERAS];
    /* a cycle no camera delivered to is stamped with the flight clock's own
     * domain: CLOCK_MONOTONIC live (the cameras' stamps), time since start in a replay */
    const uint64_t clock_t_us = app->clock_monotonic ? start : start - app->t0_us;
    const uint64_t t_us = nav_cams_synchronise(cams, &app->tlm, cycle, clock_t_us, frames);
    nav_app_note_frame_time(app, frames, t_us); /* the frame period, for the cycle margin */
    const mfns_nav_mode_t before = app->nav.mode;
    navigate(app, cycle, frames);
    send_solution(app, cycle, t_us);
    nav_cams_driver_events(cams, &app->tlm, cycle, t_us, now_ms());
    nav_cams_update_health(cams, &app->tlm, o, cycle, t_us); /* first: the packets carry the state after this cycle */
    nav_cams_packets(cams, &app->tlm, &app->out, cycle, t_us);
    if (app->out.mode_changed) {
        (void)nav_tlm_event(&app->tlm, cycle, t_us, TLM_EVT_MODE_CHANGE, TLM_SEV_INFO, (uint8_t)app->out.sol.reason,
                            nav_tlm_mode(before), nav_tlm_mode(app->out.next_mode)); /* failures counted in tlm */
    }
    nav_app_watch_clock(app, cycle, t_us); /* a UTC step: reported, housekeeping below re-correlates */
    const uint64_t end = nav_app_now_us();
    mfns_cycle_stats_add(&app->stats, (uint32_t)(end - start), (uint32_t)(start - app->prev_start_us));
    app->prev_start_us = start;
    if (t_us - app->last_hk_us >= NAV_LOOP_HK_PERIOD_US || cycle == 0 || app->hk_now) {
        app->hk_now = false;
        nav_loop_housekeeping(app, cycle, cycle + 1u, t_us);
        app->last_hk_us = t_us;
    }
    nav_tlm_drain(&app->tlm, app->cycle_now, now_ms());
    nav_app_note_latency(app, start); /* frame stamp -> the nav packet out of the queue */
    nav_service_alive(&app->service, nav_app_now_us()); /* the supervisor's watchdog: the loop runs */
    if (o->verbose) {
        print_cycle(app, cycle);
    }
    if (nav_cams_all_gone(cams) && o->backend != MFNS_CAM_BACKEND_REPLAY) {
        return CYCLE_CAMERAS_GONE;
    }
    return CYCLE_GO_ON;
}

const char *nav_loop_run(nav_app_t *app, const nav_opts_t *o, const volatile sig_atomic_t *stop, uint32_t *cycles)
{
    const uint32_t max_cycles = o->max_cycles > 0 ? o->max_cycles : UINT32_MAX - 1;
    app->last_hk_us = 0;
    app->prev_start_us = nav_app_now_us();
    uint32_t cycle = 0;
    const char *why = "data ended";
    for (cycle = 0; cycle < max_cycles; cycle++) {
        if (*stop) {
            why = "signal";
            break;
        }
        const cycle_end_t end = run_cycle(app, o, cycle);
        if (end == CYCLE_DATA_ENDED) {
            break;
        }
        if (end == CYCLE_CAMERAS_GONE) {
            why = "every camera is gone";
            cycle++;
            break;
        }
    }
    if (cycle >= max_cycles) {
        why = "cycle limit";
    }
    *cycles = cycle;
    return why;
}
