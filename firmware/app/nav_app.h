/* nav_app.h -- the flight program mfns-nav: cameras -> navigation cycle ->
 * telemetry, on Linux. The whole program's state is one nav_app_t that the
 * caller owns (main.c); its rooms:
 *
 *   main.c            options, then nav_app_run
 *   nav_opts.h        the command line
 *   nav_app.h (here)  start-up, shutdown, the exit code
 *   nav_loop.h        the loop and one cycle
 *   nav_cmds.h        what each command does
 *   nav_selftest.h    the start-up self-test
 *   nav_app_state.h   the state the rooms share, its accessors, housekeeping
 *   nav_cams.h        cameras: open, gather, synchronise, health, CAMERA packets
 *   nav_tc_in.h       command input: uplink bytes to the dispatch
 *   nav_cmd_dispatch.h  sequence guard, table dispatch, one event per command
 *   nav_tlm.h         the transmit queue and its link, nav packet, events
 * (each includes only rooms below it in this list, main.c excepted:
 * nav_app_state.h draws the layering), and their helpers: the frame policies
 * of firmware/frames/ (cam_sync.h: which frames a cycle fuses, camera health
 * rules; frame_health.h: camera data health; cycle_stats.h: cycle timing),
 * caltable_file.h (a table from a file), txq_drain.h (the transmit queue into
 * the link).
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

#include "firmware/app/nav_app_state.h"
#include "firmware/app/nav_opts.h"

/* Runs the program on app (any contents: it is reset first; nothing is
 * allocated after start-up, the camera backends allocate their buffers when
 * opened); returns the process exit code (0 ok, 2 start-up failure, 3
 * telemetry write errors: the record on the link is incomplete). */
int nav_app_run(nav_app_t *app, const nav_opts_t *o);

#endif /* MFNS_NAV_APP_H */
