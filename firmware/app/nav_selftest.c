/* nav_selftest.c -- see nav_selftest.h. */
#define _DEFAULT_SOURCE /* clock_gettime, ntp_adjtime, nanosleep under -std=c11 */

#include "firmware/app/nav_selftest.h"

#include <stdio.h>
#include <string.h>
#include <sys/timex.h>
#include <time.h>

#include "firmware/app/nav_app_state.h"

static void event(struct nav_app *app, tlm_event_code_t code, tlm_severity_t sev, uint8_t subject, int32_t a0,
                  int32_t a1)
{
    /* start-up events: the flight clock now (0, the first frame's time, in a replay) */
    const uint64_t t_us = app->clock_monotonic ? nav_app_now_us() : 0u;
    (void)nav_tlm_event(&app->tlm, 0, t_us, code, sev, subject, a0, a1); /* failures counted in tlm */
}

static void count(struct nav_app *app, bool ok)
{
    app->selftest.checks++;
    app->selftest.failed = (uint8_t)(app->selftest.failed + (ok ? 0u : 1u));
}

void nav_selftest_table(struct nav_app *app, const nav_ts_start_t *ts, mfns_caltable_status_t st, uint32_t crc)
{
    const bool ok = st == MFNS_CALTABLE_OK;
    const uint8_t result = (uint8_t)(!ok ? 1 : ts->rolled_back ? 2 : 0);
    count(app, ok && !ts->rolled_back);
    event(app, TLM_EVT_SELFTEST_TABLE, ok && !ts->rolled_back ? TLM_SEV_INFO : ok ? TLM_SEV_WARNING : TLM_SEV_ERROR,
          result, (int32_t)ts->first_status, ok ? (int32_t)crc : 0);
    if (ok && ts->rolled_back) {
        fprintf(stderr, "mfns-nav: self-test: the stored table was refused (%s at byte %u): rolled back to the previous one, %s (crc %08x)\n",
                mfns_caltable_strerror(ts->first_status), ts->first_err_offset, ts->path, crc);
        event(app, TLM_EVT_TABLE_ROLLBACK, TLM_SEV_WARNING, 0, (int32_t)ts->first_status, (int32_t)crc);
    }
    if (ts->store_errno != 0) {
        fprintf(stderr, "mfns-nav: table store: %s (the table runs; the store is not updated)\n",
                strerror(ts->store_errno));
    }
}

void nav_selftest_uart(struct nav_app *app, const nav_opts_t *o)
{
    if (o->tlm_kind != NAV_TLM_SERIAL && o->tlm_kind != NAV_TLM_PATH) {
        event(app, TLM_EVT_SELFTEST_UART, TLM_SEV_INFO, NAV_ST_UART_NONE, 0, (int32_t)o->baud);
        return; /* a file or no link: nothing to check */
    }
    const bool ok = app->tlm.uart.connected;
    count(app, ok); /* the stderr line is nav_tlm_open's ("not available yet") */
    event(app, TLM_EVT_SELFTEST_UART, ok ? TLM_SEV_INFO : TLM_SEV_WARNING, ok ? NAV_ST_UART_OPEN : NAV_ST_UART_NOT_OPEN,
          ok ? 0 : app->tlm.uart.last_errno, (int32_t)o->baud);
}

uint32_t nav_selftest_clock_flags(int64_t utc_s, bool utc_synced, uint64_t mono0_ns, uint64_t mono1_ns)
{
    uint32_t f = 0;
    if (utc_s >= NAV_SELFTEST_UTC_MIN_S) {
        f |= NAV_SELFTEST_CLK_UTC_SET;
        if (utc_synced) {
            f |= NAV_SELFTEST_CLK_UTC_SYNCED; /* synchronised to a clock never set means nothing */
        }
    }
    if (mono1_ns > mono0_ns) {
        f |= NAV_SELFTEST_CLK_MONO_OK;
    }
    return f;
}

static uint64_t mono_ns(void)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_MONOTONIC, &ts) != 0) {
        return 0;
    }
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

void nav_selftest_clock(struct nav_app *app)
{
    const uint64_t m0 = mono_ns();
    const struct timespec pause = {0, 1000000}; /* 1 ms: the monotonic clock must move across it */
    (void)nanosleep(&pause, NULL);              /* interrupted: the check below still holds or fails honestly */
    const uint64_t m1 = mono_ns();
    struct timespec rt;
    const int64_t utc_s = clock_gettime(CLOCK_REALTIME, &rt) == 0 ? (int64_t)rt.tv_sec : 0;
    struct timex tx;
    memset(&tx, 0, sizeof tx);
    const int state = ntp_adjtime(&tx);
    const bool synced = state != TIME_ERROR && state >= 0 && (tx.status & STA_UNSYNC) == 0;
    const uint32_t f = nav_selftest_clock_flags(utc_s, synced, m0, m1);
    const bool ok = (f & (NAV_SELFTEST_CLK_UTC_SET | NAV_SELFTEST_CLK_MONO_OK)) ==
                    (NAV_SELFTEST_CLK_UTC_SET | NAV_SELFTEST_CLK_MONO_OK);
    count(app, ok);
    if (!ok) {
        fprintf(stderr, "mfns-nav: self-test: clock: %s%s\n",
                (f & NAV_SELFTEST_CLK_UTC_SET) ? "" : "UTC not set (before 2024: packets get ground-receipt time) ",
                (f & NAV_SELFTEST_CLK_MONO_OK) ? "" : "CLOCK_MONOTONIC does not advance");
    }
    event(app, TLM_EVT_SELFTEST_CLOCK, ok ? TLM_SEV_INFO : TLM_SEV_WARNING, (uint8_t)(ok ? 0 : 1), (int32_t)f,
          (int32_t)(utc_s & 0x7fffffff));
}

void nav_selftest_cameras(struct nav_app *app, const nav_opts_t *o)
{
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        nav_cam_t *c = &app->cams.cam[k];
        int result = NAV_ST_CAM_OK;
        mfns_cam_err_t e = c->open_err;
        if (c->cam == NULL) {
            result = NAV_ST_CAM_MISSING;
        } else if (o->backend == MFNS_CAM_BACKEND_REPLAY) {
            result = NAV_ST_CAM_NOT_STREAMED;
        } else {
            mfns_cam_frame_t fr;
            e = mfns_cam_dequeue(c->cam, &fr, NAV_SELFTEST_FRAME_MS);
            if (e == MFNS_CAM_OK) {
                e = mfns_cam_requeue(c->cam, &fr); /* given back: the loop starts on fresh frames */
            }
            if (e != MFNS_CAM_OK) {
                result = NAV_ST_CAM_NO_FRAME;
                fprintf(stderr, "mfns-nav: self-test: camera %c opened but gave no frame in %d ms: %s\n", c->letter,
                        NAV_SELFTEST_FRAME_MS, mfns_cam_strerror(e));
            }
        }
        const bool ok = result == NAV_ST_CAM_OK || result == NAV_ST_CAM_NOT_STREAMED;
        count(app, ok);
        if (ok) {
            app->selftest.cams_passed = (uint8_t)(app->selftest.cams_passed | (1u << k));
        }
        event(app, TLM_EVT_SELFTEST_CAMERA, ok ? TLM_SEV_INFO : TLM_SEV_ERROR, (uint8_t)k, result, (int32_t)e);
    }
}

void nav_selftest_done(struct nav_app *app)
{
    const nav_selftest_t *s = &app->selftest;
    /* no stderr line: each failed check has said its own (one line per cause) */
    event(app, TLM_EVT_SELFTEST_DONE, s->failed == 0u ? TLM_SEV_INFO : TLM_SEV_WARNING, s->failed, s->cams_passed,
          s->checks);
}
