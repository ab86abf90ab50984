/* nav_loop.h -- mfns-nav's loop: one navigation cycle per frame set, until
 * the data ends, max_cycles, a stop request, or every (non-replay) camera is
 * gone for good.
 *
 * One cycle, in order: the commands that came in (nav_tc_in.h, at most
 * NAV_CMD_MAX_PER_CYCLE, between cycles so the previous cycle's telemetry
 * is out); gather a frame per camera and synchronise them (nav_cams.h); the
 * navigator (not in STANDBY); the nav packet; camera events, health and one
 * diagnostics packet per camera; MODE_CHANGE; housekeeping once per second
 * of frame time (and on cycle 0); drain the transmit queue; with --verbose
 * one line on stderr. The cycle's time is its frames' time (the flight
 * clock), or the program's clock when no camera delivered.
 */
#ifndef MFNS_NAV_LOOP_H
#define MFNS_NAV_LOOP_H

#include <signal.h>
#include <stdint.h>

#include "firmware/app/nav_app_state.h"

#define NAV_LOOP_HK_PERIOD_US 1000000u /* housekeeping: once per second of frame time */
#define NAV_LOOP_FIX_DOWNLINK_PERIOD_US 1000000u /* fix record: one fix per second down the link (docs/telemetry.md 5) */

/* Runs cycles until one of the ends above; *stop is polled before each
 * cycle. Returns why it ended ("data ended", "cycle limit", "signal",
 * "every camera is gone") and *cycles the cycles run. */
const char *nav_loop_run(nav_app_t *app, const nav_opts_t *o, const volatile sig_atomic_t *stop, uint32_t *cycles);

/* Sends housekeeping (nav_app_housekeeping) and starts the next report
 * interval (cycle timing and the most acquisition work). */
void nav_loop_housekeeping(nav_app_t *app, uint32_t cycle, uint32_t n_cycles, uint64_t t_us);

#endif /* MFNS_NAV_LOOP_H */
