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
    struct timex tx;
    memset(&tx, 0, sizeof tx); /* modes 0: read only */
    const int state = ntp_adjtime(&tx);
    const bool synced = state != TIME_ERROR && state >= 0 && (tx.status & STA_UNSYNC) == 0;
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
