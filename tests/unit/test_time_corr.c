/* Unit tests of the time correlation: the flight's pair (firmware/app/
 * nav_time.h) and the ground's UTC per packet (ground/time_corr.h). */
#include "tests/unit/support/testutil.h"

#include <stdlib.h>
#include <string.h>

#include "firmware/app/nav_time.h"
#include "ground/time_corr.h"
#include "firmware/tlm/generated/tlm_codes_gen.h"

#define US 1000000LL
/* tolerances of 16 us: the CUC fine unit is 2^-16 s = 15.26 us */
static const int64_t k_utc_now = 1796245281LL * US + 723817; /* 2026-12-02T21:01:21.723817Z */

static void test_flight_pair_monotonic_and_replay(void **state)
{
    (void)state;
    /* a frame captured 40 ms before now on the monotonic clock: UTC 40 ms ago */
    nav_time_pair_t p = nav_time_correlate(k_utc_now, 5000000u, 4960000u, true, false);
    assert_int_equal(p.quality, TLM_TIMEQ_SYSTEM);
    assert_int_equal((int64_t)p.utc_s * US + p.utc_us, k_utc_now - 40000);
    assert_true(p.utc_us < 1000000u);
    /* synchronised clock */
    p = nav_time_correlate(k_utc_now, 5000000u, 4960000u, true, true);
    assert_int_equal(p.quality, TLM_TIMEQ_SYNCED);
    /* a frame time ahead of now (impossible) pairs with now, never later */
    p = nav_time_correlate(k_utc_now, 5000000u, 6000000u, true, false);
    assert_int_equal((int64_t)p.utc_s * US + p.utc_us, k_utc_now);
    /* a replay's recorded time pairs with the moment it is flown */
    p = nav_time_correlate(k_utc_now, 5000000u, 123u, false, false);
    assert_int_equal((int64_t)p.utc_s * US + p.utc_us, k_utc_now);
    /* a clock never set (1970, or before 2020): no UTC at all */
    p = nav_time_correlate(12 * US, 5000000u, 4960000u, true, true);
    assert_int_equal(p.quality, TLM_TIMEQ_NONE);
    assert_int_equal(p.utc_s, 0u);
    p = nav_time_correlate((NAV_TIME_UTC_PLAUSIBLE_S - 1) * US, 0u, 0u, false, false);
    assert_int_equal(p.quality, TLM_TIMEQ_NONE);
    /* beyond the u32 seconds of the field */
    p = nav_time_correlate(((int64_t)UINT32_MAX + 10) * US, 0u, 0u, false, false);
    assert_int_equal(p.quality, TLM_TIMEQ_NONE);
    /* this board's clocks: plausible; a replay anchored at its first pair keeps
     * its offset (its UTC advances exactly as the recording's time, never back) */
    nav_time_t nt;
    nav_time_init(&nt, false);
    p = nav_time_pair_now(&nt, 1000000u);
    if (p.quality != TLM_TIMEQ_NONE) {
        assert_true(p.utc_s >= (uint32_t)NAV_TIME_UTC_PLAUSIBLE_S);
        const nav_time_pair_t later = nav_time_pair_now(&nt, 61000000u); /* 60 s of recording, flown at once */
        assert_int_equal(((int64_t)later.utc_s - (int64_t)p.utc_s) * US + (int64_t)later.utc_us - (int64_t)p.utc_us,
                         60 * US);
    }
    nav_time_init(&nt, true); /* live: pairs afresh, never later than now */
    p = nav_time_pair_now(&nt, 0u);
    assert_true(p.quality == TLM_TIMEQ_NONE || p.utc_s >= (uint32_t)NAV_TIME_UTC_PLAUSIBLE_S);
}

static tlm_packet_t packet(tlm_type_t type, uint64_t t_us)
{
    tlm_packet_t p;
    memset(&p, 0, sizeof p);
    p.type = type;
    p.time = tlm_time_from_us(t_us);
    return p;
}

static void test_ground_correlation(void **state)
{
    (void)state;
    time_corr_t c;
    time_corr_init(&c);
    time_src_t src;
    /* before any pair: at receipt, anchored at the first packet */
    tlm_packet_t nav = packet(TLM_TYPE_NAV, 2000000u);
    int64_t u = time_corr_packet(&c, &nav, k_utc_now, &src);
    assert_int_equal(src, TIME_SRC_GROUND_RECEIPT);
    assert_int_equal(u, k_utc_now);
    nav = packet(TLM_TYPE_NAV, 2053763u); /* 53.763 ms of flight time later, received late */
    u = time_corr_packet(&c, &nav, k_utc_now + 900000, &src);
    assert_true(llabs(u - (k_utc_now + 53763)) <= 16); /* the flight spacing, not the arrival's */
    /* a housekeeping pair with no UTC (NONE) changes nothing */
    tlm_packet_t hk = packet(TLM_TYPE_HK, 2100000u);
    (void)time_corr_packet(&c, &hk, k_utc_now + 950000, &src);
    assert_int_equal(src, TIME_SRC_GROUND_RECEIPT);
    /* a synchronised pair: every later packet is flight time + its offset */
    const int64_t utc_pair = 1800000000LL * US + 250000;
    hk.u.hk.utc_s = 1800000000u;
    hk.u.hk.utc_us = 250000u;
    hk.u.hk.time_quality = TLM_TIMEQ_SYNCED;
    u = time_corr_packet(&c, &hk, k_utc_now, &src);
    assert_int_equal(src, TIME_SRC_FLIGHT_SYNCED);
    assert_true(llabs(u - utc_pair) <= 16);
    nav = packet(TLM_TYPE_NAV, 3100000u);
    u = time_corr_packet(&c, &nav, k_utc_now + 5 * US, &src);
    assert_int_equal(src, TIME_SRC_FLIGHT_SYNCED);
    assert_true(llabs(u - (utc_pair + 1000000)) <= 16);
    assert_string_equal(time_corr_src_name(src), "FLIGHT_SYNCED");
    /* a malformed pair (microseconds >= 1e6) is ignored */
    hk.u.hk.utc_us = 1000000u;
    hk.u.hk.utc_s = 1u;
    (void)time_corr_packet(&c, &hk, k_utc_now, &src);
    assert_true(llabs(time_corr_packet(&c, &nav, k_utc_now, &src) - (utc_pair + 1000000)) <= 16);
    /* a reboot: the flight clock starts again, the old pair no longer holds */
    nav = packet(TLM_TYPE_NAV, 1000u);
    u = time_corr_packet(&c, &nav, k_utc_now + 60 * US, &src);
    assert_int_equal(src, TIME_SRC_GROUND_RECEIPT);
    assert_int_equal(u, k_utc_now + 60 * US);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_flight_pair_monotonic_and_replay),
        cmocka_unit_test(test_ground_correlation),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
