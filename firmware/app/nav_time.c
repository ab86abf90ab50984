/* nav_time.c -- see nav_time.h. */
#define _DEFAULT_SOURCE /* ntp_adjtime, clock_gettime under -std=c11 */

#include "firmware/app/nav_time.h"

#include <string.h>
#include <sys/timex.h>
#include <time.h>

#include "math/units.h"
#include "firmware/tlm/generated/tlm_codes_gen.h"

nav_time_pair_t nav_time_correlate(int64_t utc_now_us, uint64_t mono_now_us, uint64_t t_flight_us, bool monotonic,
                                   bool synced)
{
    nav_time_pair_t p = {0u, 0u, (uint8_t)TLM_TIMEQ_NONE};
    if (utc_now_us < NAV_TIME_UTC_PLAUSIBLE_S * (int64_t)MFNS_US_PER_S) {
        return p; /* the clock was never set: the ground correlates at receipt */
    }
    int64_t utc_us = utc_now_us;
    if (monotonic) {
        /* a frame time in the future of now (it cannot be) pairs with now */
        const uint64_t age_us = mono_now_us > t_flight_us ? mono_now_us - t_flight_us : 0u;
        utc_us -= (int64_t)(age_us > (uint64_t)utc_us ? (uint64_t)utc_us : age_us);
    }
    const int64_t s = utc_us / (int64_t)MFNS_US_PER_S;
    if (s > (int64_t)UINT32_MAX) {
        return p; /* beyond 2106: not representable in the u32 field */
    }
    p.utc_s = (uint32_t)s;
    p.utc_us = (uint32_t)(utc_us - s * (int64_t)MFNS_US_PER_S);
    p.quality = (uint8_t)(synced ? TLM_TIMEQ_SYNCED : TLM_TIMEQ_SYSTEM);
    return p;
}

void nav_time_init(nav_time_t *t, bool monotonic)
{
    memset(t, 0, sizeof *t);
    t->monotonic = monotonic;
}

nav_time_pair_t nav_time_pair_now(nav_time_t *t, uint64_t t_flight_us)
{
    struct timespec rt, mt;
    if (clock_gettime(CLOCK_REALTIME, &rt) != 0 || clock_gettime(CLOCK_MONOTONIC, &mt) != 0) {
        return (nav_time_pair_t){0u, 0u, (uint8_t)TLM_TIMEQ_NONE};
    }
    const bool synced = nav_time_sync_now().synced;
    const int64_t utc_now_us = (int64_t)rt.tv_sec * (int64_t)MFNS_US_PER_S + (int64_t)rt.tv_nsec / 1000;
    const uint64_t mono_now_us = (uint64_t)mt.tv_sec * MFNS_US_PER_S + (uint64_t)mt.tv_nsec / 1000u;
    if (t->monotonic) {
        return nav_time_correlate(utc_now_us, mono_now_us, t_flight_us, true, synced);
    }
    nav_time_pair_t p = nav_time_correlate(utc_now_us, mono_now_us, t_flight_us, false, synced);
    if (p.quality == TLM_TIMEQ_NONE || t_flight_us > (uint64_t)INT64_MAX) {
        return p;
    }
    if (!t->anchored) {
        t->anchored = true;
        t->offset_us = utc_now_us - (int64_t)t_flight_us;
    }
    /* the anchor's UTC for this recorded time, same quality as now */
    const nav_time_pair_t q = nav_time_correlate((int64_t)t_flight_us + t->offset_us, 0u, 0u, false, synced);
    return q.quality == TLM_TIMEQ_NONE ? p : q;
}

nav_time_sync_t nav_time_sync_from(int state, int status, long esterror_us, long offset)
{
    nav_time_sync_t r = {false, NAV_TIME_ERROR_UNKNOWN_US, 0};
    if (state < 0 || state == TIME_ERROR || (status & STA_UNSYNC) != 0) {
        return r;
    }
    r.synced = true;
    r.error_us = esterror_us < 0 ? NAV_TIME_ERROR_UNKNOWN_US
                 : (unsigned long)esterror_us >= (unsigned long)UINT32_MAX ? UINT32_MAX - 1u
                                                                           : (uint32_t)esterror_us;
    const long off_us = (status & STA_NANO) != 0 ? offset / 1000L : offset;
    r.offset_us = off_us > (long)INT32_MAX ? INT32_MAX : off_us < -(long)INT32_MAX ? -INT32_MAX : (int32_t)off_us;
    return r;
}

nav_time_sync_t nav_time_sync_now(void)
{
    struct timex tx;
    memset(&tx, 0, sizeof tx); /* modes 0: read only */
    const int state = ntp_adjtime(&tx);
    return nav_time_sync_from(state, tx.status, tx.esterror, tx.offset);
}

int64_t nav_time_step_check(nav_time_t *t, int64_t utc_now_us, uint64_t mono_now_us)
{
    int64_t step = 0;
    if (t->have_last && mono_now_us >= t->last_mono_us) {
        const uint64_t d_mono = mono_now_us - t->last_mono_us;
        const int64_t d_utc = utc_now_us - t->last_utc_us;
        step = d_mono > (uint64_t)INT64_MAX ? 0 : d_utc - (int64_t)d_mono;
        if (step > NAV_TIME_STEP_THRESHOLD_US || step < -NAV_TIME_STEP_THRESHOLD_US) {
            t->n_steps++;
        } else {
            step = 0;
        }
    }
    t->have_last = true;
    t->last_utc_us = utc_now_us;
    t->last_mono_us = mono_now_us;
    return step;
}

int64_t nav_time_step_now(nav_time_t *t)
{
    struct timespec rt, mt;
    if (clock_gettime(CLOCK_REALTIME, &rt) != 0 || clock_gettime(CLOCK_MONOTONIC, &mt) != 0) {
        return 0;
    }
    const int64_t utc_now_us = (int64_t)rt.tv_sec * (int64_t)MFNS_US_PER_S + (int64_t)rt.tv_nsec / 1000;
    const uint64_t mono_now_us = (uint64_t)mt.tv_sec * MFNS_US_PER_S + (uint64_t)mt.tv_nsec / 1000u;
    return nav_time_step_check(t, utc_now_us, mono_now_us);
}
