/* nav_app_state.h -- the state of the flight program mfns-nav (one nav_app_t,
 * owned by main.c), the accessors the rooms share, and the packet that
 * reports the whole state: housekeeping.
 *
 * The layering (issue 41, docs/system.md "The flight program's rooms"):
 *
 *   main.c -> nav_app (start-up, shutdown, the exit code)
 *          -> nav_loop (the loop, one cycle), nav_cmds (what each command does),
 *             nav_selftest (the start-up self-test)
 *          -> nav_app_state (here: the state, its accessors, housekeeping)
 *          -> nav_cams (cameras, and the CAMERA packets of their data),
 *             nav_tc_in, nav_fixlog, nav_time, nav_service (and the frame
 *             policies of firmware/frames/: cam_sync, frame_health, cycle_stats)
 *          -> nav_tlm (the transmit queue, its link, the nav packet and events)
 *
 * Every include points down this list: a room reads the state through this
 * header and never includes a room above it, so the program has no include
 * circle (mk/include_graph.py --check fails on one).
 */
#ifndef MFNS_NAV_APP_STATE_H
#define MFNS_NAV_APP_STATE_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/nav/table/caltable.h"
#include "firmware/frames/cycle_stats.h"
#include "firmware/app/nav_cams.h"
#include "firmware/nav/cycle/nav_cycle.h"
#include "firmware/app/nav_fixlog.h"
#include "firmware/app/nav_opts.h"
#include "firmware/app/nav_tc_in.h"
#include "firmware/app/nav_upload.h"
#include "firmware/app/nav_service.h"
#include "firmware/app/nav_time.h"
#include "firmware/app/nav_tlm.h"

/* The start-up self-test's tally (nav_selftest.h runs the checks). */
typedef struct {
    uint8_t checks;      /* run so far */
    uint8_t failed;      /* of them, failed */
    uint8_t cams_passed; /* bit k: camera k passed */
} nav_selftest_t;

#define NAV_APP_TABLE_SLOTS 2

/* Counted from the nav packets sent, so the log, housekeeping and nav.csv
 * say the same (a pose the packet refuses is NO_FIX). */
typedef struct {
    uint32_t n_fix, n_degraded, n_no_fix;
    uint32_t n_acquire;             /* acquisition cycles */
    uint32_t acq_units_max;         /* most work in the housekeeping interval */
    mfns_acq_progress_t acq_last;   /* the last acquisition's progress */
} nav_counts_t;

typedef struct nav_app {
    uint8_t table_buf[MFNS_CALTABLE_MAX_BYTES];
    /* Two table slots: TABLE_LOAD validates into the spare one and swaps
     * between cycles (cFS-style); a refused table never touches the live one. */
    mfns_caltable_t tables[NAV_APP_TABLE_SLOTS];
    int table_cur;                  /* the slot the navigator uses */
    mfns_pose_mode_t solver;
    mfns_nav_t nav;
    mfns_nav_output_t out;          /* the last cycle's */
    bool standby;                   /* SET_MODE standby: frames flow, the navigator does not run */
    bool waiting_table;             /* no table validated yet: WAIT_TABLE (supervised start-up only) */
    bool hk_now;                    /* housekeeping this cycle (a UTC step: nav_app_watch_clock) */
    nav_cams_t cams;
    nav_tlm_t tlm;
    nav_tc_in_t tc;
    nav_counts_t count;
    mfns_cycle_stats_t stats;       /* cycle timing over the housekeeping interval */
    uint32_t cycle_now;             /* the cycle running (or the last one) */
    uint32_t nav_filter_period_us; /* --nav-filter: 0 off; re-applied after every table bind */
    uint64_t last_t_us;             /* the last cycle's time: the flight clock */
    uint64_t t0_us;                 /* program clock at start-up */
    /* The flight clock is CLOCK_MONOTONIC (live cameras stamp with it; a
     * cycle without frames is stamped with it too), or, in a replay, the
     * recorded time (a cycle without frames: the program's time since start).
     * nav_time.h pairs it with UTC accordingly. */
    bool clock_monotonic;
    nav_time_t time;                /* its correlation to UTC (housekeeping) */
    nav_service_t service;          /* the supervisor: readiness, watchdog (nav_service.h) */
    uint64_t prev_start_us;         /* the previous cycle's start (cycle period) */
    uint64_t last_hk_us;            /* flight clock of the last housekeeping */
    /* The fix record (nav_fixlog.h): the on-board log (--fixlog) and the
     * downlink of one fix per NAV_LOOP_FIX_DOWNLINK_PERIOD_US. */
    nav_fixlog_t fixlog;
    tlm_packet_t fix_pkts[NAV_FIXLOG_MAX_ASSOC];
    uint64_t last_fix_down_us;
    bool fix_down_sent;
    nav_selftest_t selftest;        /* the start-up self-test's tally (nav_selftest.h) */
    const char *state_dir;          /* the table store's directory (nav_tablestore.h), or NULL */
    uint32_t budget_units;          /* acquisition budget set by the board (--budget-units), 0: the table's */
    mfns_cycle_stats_t latency;     /* frame stamp -> nav packet out of the queue, whole run (nav_app_note_latency) */
    uint64_t last_fused_t_us;       /* frame time of the last cycle that fused a frame (0: none yet) */
    uint32_t frame_period_min_us;   /* shortest step between fused cycles' frame times this HK interval (0: none) */
    uint32_t n_storage_errors;      /* failed writes of the uplink state and the table store (housekeeping) */
    uint32_t fixlog_lost_reported;  /* fix-log records lost, as last reported by STORAGE_FAULT */
    bool tlm_opened_at_start;       /* the telemetry link was open after start-up (the exit message) */
    bool fixlog_open_failed;        /* --fixlog given, its directory unusable: no log this run (STORAGE_FAULT) */
    /* A file (calibration table) coming over the uplink (nav_upload.h, the
     * UPLOAD_* commands of nav_cmds_upload.h): its receive buffer and state. */
    uint8_t upload_buf[MFNS_CALTABLE_MAX_BYTES];
    nav_upload_t upload;
} nav_app_t;

/* CLOCK_MONOTONIC in microseconds: the program's clock. */
uint64_t nav_app_now_us(void);
/* The table the navigator uses now. */
const mfns_caltable_t *nav_app_table(const nav_app_t *app);
/* The board's acquisition budget (--budget-units / budget_units) into a
 * table just loaded (start-up, TABLE_LOAD); none given: the table's stays. */
void nav_app_apply_budget(nav_app_t *app, mfns_caltable_t *t);
/* After a cycle's synchronisation: when it fused a frame, the step from the
 * previous fused cycle's frame time is a candidate for the frame period (the
 * shortest in the housekeeping interval: a frame dropped doubles a step,
 * never halves it). Housekeeping reports the period and the margin, period -
 * the longest cycle (nav_tlm.h). */
void nav_app_note_frame_time(nav_app_t *app, const mfns_frame_t *const frames[], uint64_t t_us);
/* After a cycle's drain: when its nav packet has left the transmit queue
 * (written to the link) and its frames carry an arrival time, one latency
 * sample: program clock now - gathered_us (the cycle's start, right after
 * the last frame was dequeued) + the latest arrival - the oldest fused frame's
 * stamp (both on the frames' time base: exact for live cameras, whose stamps
 * and arrivals are CLOCK_MONOTONIC; for a paced replay the arrival is its due
 * time). Reported by --verbose at the end (docs/budgets.md "Latency"). */
void nav_app_note_latency(nav_app_t *app, uint64_t gathered_us);
/* Telemetry mode now: STANDBY, or the navigator's ACQUIRE/TRACK. */
uint8_t nav_app_tlm_mode(const nav_app_t *app);
/* Once per cycle: a step of the board's UTC against the flight
 * clock (nav_time_step_now) is said on stderr, sent as CLOCK_STEP and forces
 * a housekeeping packet (the new time correlation) this cycle. */
void nav_app_watch_clock(nav_app_t *app, uint32_t cycle, uint64_t t_us);
/* The pose of x, y, z (mm) and 2-1-3 Euler roll, pitch, yaw (deg), as the
 * navigator's prior: --init-pose and SET_POSE_HINT share it. */
mfns_nav_status_t nav_app_set_prior(nav_app_t *app, float x, float y, float z, float roll_deg, float pitch_deg,
                                    float yaw_deg);

/* The housekeeping packet of app's counters (n_cycles: cycles run so far,
 * the one of index cycle included), then a TLM_DROPPED event when frames
 * were dropped since the last one (and, once, STORAGE_FAULT when the fix
 * log's disk refuses). Reads the counters (and moves app's time correlation
 * on: a replay anchors at its first pair); the caller starts the next report
 * interval (nav_loop_housekeeping). */
void nav_app_housekeeping(nav_app_t *app, uint32_t cycle, uint32_t n_cycles, uint64_t t_us);

#endif /* MFNS_NAV_APP_STATE_H */
