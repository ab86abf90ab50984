/* nav_selftest.h -- the flight program's start-up self-test (docs/operations.md
 * "Self-test events"): each check is one event, sent after BOOT and before
 * the first housekeeping packet, and a failed check is also one stderr line.
 *
 *   SELFTEST_TABLE   the table loaded and its CRC checked (caltable.h), from
 *                    the store or --table (nav_tablestore.h); 2 = rolled back
 *   SELFTEST_UART    the telemetry link is open (a link not there yet is
 *                    retried like one lost later: a warning, not a stop)
 *   SELFTEST_CLOCK   CLOCK_MONOTONIC advances; UTC is set (after
 *                    NAV_SELFTEST_UTC_MIN_S) and whether it is synchronised
 *   SELFTEST_CAMERA  each camera opened and streamed one frame within
 *                    NAV_SELFTEST_FRAME_MS (that frame is given back unused);
 *                    a missing camera is reported and the others run
 *   SELFTEST_DONE    checks failed, cameras that passed
 *
 * A failed check does not stop the program by itself: only a table that does
 * not validate (nav_app.h) or no camera at all does. In a replay the cameras
 * are opened but not streamed ahead (their first frame belongs to cycle 0),
 * reported as result 3.
 * Misses: a camera that streams one frame and then stops is found by the
 * loop's health checks, not here; "UTC set" is a plausibility bound, not a
 * check against a reference.
 */
#ifndef MFNS_NAV_SELFTEST_H
#define MFNS_NAV_SELFTEST_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/nav/table/caltable.h"
#include "firmware/app/nav_opts.h"
#include "firmware/app/nav_tablestore.h"

#define NAV_SELFTEST_UTC_MIN_S 1704067200LL /* 2024-01-01T00:00:00Z: a clock before it was never set */
#define NAV_SELFTEST_FRAME_MS 1000          /* a camera's first frame: the longest frame period (2 Hz) x 2 */

/* SELFTEST_CLOCK arg0 bits */
#define NAV_SELFTEST_CLK_UTC_SET 0x1u
#define NAV_SELFTEST_CLK_UTC_SYNCED 0x2u
#define NAV_SELFTEST_CLK_MONO_OK 0x4u

/* SELFTEST_CAMERA arg0 */
enum { NAV_ST_CAM_OK = 0, NAV_ST_CAM_MISSING = 1, NAV_ST_CAM_NO_FRAME = 2, NAV_ST_CAM_NOT_STREAMED = 3 };
/* SELFTEST_UART subject */
enum { NAV_ST_UART_OPEN = 0, NAV_ST_UART_NOT_OPEN = 1, NAV_ST_UART_NONE = 2 };

/* Its tally, nav_selftest_t, is part of the program's state (nav_app_state.h). */

struct nav_app;

/* The table check, from the start-up's load (st: the status of the table
 * that runs, or of the last tried). Also sends TABLE_ROLLBACK on a rollback. */
void nav_selftest_table(struct nav_app *app, const nav_ts_start_t *ts, mfns_caltable_status_t st, uint32_t crc);
void nav_selftest_uart(struct nav_app *app, const nav_opts_t *o);
void nav_selftest_clock(struct nav_app *app);
void nav_selftest_cameras(struct nav_app *app, const nav_opts_t *o);
void nav_selftest_done(struct nav_app *app);

/* The clock flags from the clocks' readings (pure: tests feed any). */
uint32_t nav_selftest_clock_flags(int64_t utc_s, bool utc_synced, uint64_t mono0_ns, uint64_t mono1_ns);

#endif /* MFNS_NAV_SELFTEST_H */
