/* nav_app.h -- the flight program mfns-nav: cameras -> navigation cycle ->
 * telemetry, on Linux. The whole program's state is one nav_app_t that the
 * caller owns (main.c); its rooms:
 *
 *   main.c            options, then nav_app_run
 *   nav_opts.h        the command line
 *   nav_app.h (here)  start-up, shutdown, the exit code, the state
 *   nav_loop.h        the loop and one cycle
 *   nav_cams.h        cameras: open, gather, synchronise, health
 *   nav_tlm.h         every packet sent, the transmit queue and its link
 *   nav_tc_in.h       command input: uplink bytes to the dispatch
 *   nav_cmd_dispatch.h  sequence guard, table dispatch, one event per command
 *   nav_cmds.h        what each command does
 * and their helpers: cam_sync.h (which frames a cycle fuses, camera health
 * rules), cycle_stats.h (cycle timing), caltable_file.h (a table from a
 * file), txq_drain.h (the transmit queue into the link).
 *
 * Start-up (the only phase that may fail hard): open the telemetry link and
 * the command input, load and validate the calibration table (from the
 * state dir's store when there is one, falling back to the previous table:
 * nav_tablestore.h), bind the navigator, open the three cameras, apply
 * --init-pose; the self-test reports each step as an event (nav_selftest.h).
 * A table that fails validation (and no previous one that passes) is refused
 * with its error and a TABLE_REFUSED event: navigating on a wrong table would
 * produce poses marked valid that are not. Run by hand the program then stops
 * (exit 2: the operator at the shell reads why at once). Under a supervisor
 * (NOTIFY_SOCKET: systemd, the image's mfns-supervise) it does not exit, which
 * would only restart-loop it: it waits (mode WAIT_TABLE; docs/operations.md
 * "First run"): READY=1 with STATUS= saying why, the watchdog pinged, one
 * journal line per new reason, housekeeping each second, the TABLE_REFUSED
 * event again each time the link comes up, commands taken (NOOP,
 * RESET_COUNTERS, TABLE_LOAD; nav_cmds_ops_waiting), the configured table
 * tried again every NAV_APP_WAIT_RETRY_US; a table that validates (that file,
 * or a TABLE_LOAD) and the start-up goes on. The loop sleeps
 * NAV_APP_WAIT_TICK_US a turn: no busy wait.
 * A camera that does not open is reported and the others run; with none the
 * program stops.
 *
 * The telemetry link may be absent at start (a FIFO without a reader, an
 * adapter not plugged in): it is retried like a link lost later. Write errors
 * are counted, reported on stderr and give exit code 3.
 *
 * The loop ends at the end of replayed data, after max_cycles, on SIGINT or
 * SIGTERM, or when every (non-replay) camera is gone for good; then a final
 * housekeeping packet, the queue drained for up to 2 s, and (unless --quiet)
 * a summary on stderr.
 */
#ifndef MFNS_NAV_APP_H
#define MFNS_NAV_APP_H

#define NAV_APP_WAIT_TICK_US 200000u   /* waiting for a table: one turn (commands, link, watchdog) */
#define NAV_APP_WAIT_RETRY_US 2000000u /* ... and the configured table tried again this often */

#include <stdbool.h>
#include <stdint.h>

#include "firmware/nav/table/caltable.h"
#include "firmware/app/cycle_stats.h"
#include "firmware/app/nav_cams.h"
#include "firmware/nav/cycle/nav_cycle.h"
#include "firmware/app/nav_fixlog.h"
#include "firmware/app/nav_opts.h"
#include "firmware/app/nav_selftest.h"
#include "firmware/app/nav_tc_in.h"
#include "firmware/app/nav_service.h"
#include "firmware/app/nav_time.h"
#include "firmware/app/nav_tlm.h"

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
} nav_app_t;

/* Runs the program on app (any contents: it is reset first; nothing is
 * allocated after start-up, the camera backends allocate their buffers when
 * opened); returns the process exit code (0 ok, 2 start-up failure, 3
 * telemetry write errors: the record on the link is incomplete). */
int nav_app_run(nav_app_t *app, const nav_opts_t *o);

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

#endif /* MFNS_NAV_APP_H */
