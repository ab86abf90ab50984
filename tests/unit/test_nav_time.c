/* test_nav_time.c -- the board's time quality behind its seams (nav_time.h,
 * issue 44 item 3): the kernel's synchronisation state from made-up adjtimex
 * readings, and the clock-step watch from made-up clock pairs (no real clock
 * is stepped). */
#define _DEFAULT_SOURCE /* STA_* and TIME_* from sys/timex.h */
#include "tests/unit/support/testutil.h"

#include <string.h>
#include <sys/timex.h>

#include "firmware/app/nav_time.h"

static const int64_t k_utc0 = 1765000000LL * 1000000LL; /* Dec 2025, us */

static void test_sync_state_from_adjtimex(void **state)
{
    (void)state;
    /* chrony locked: TIME_OK, STA_PLL, error 1.5 ms, offset 20 us */
    nav_time_sync_t s = nav_time_sync_from(TIME_OK, STA_PLL, 1500L, 20L);
    assert_true(s.synced);
    assert_int_equal(s.error_us, 1500u);
    assert_int_equal(s.offset_us, 20);
    /* STA_NANO: the offset is in ns */
    s = nav_time_sync_from(TIME_OK, STA_PLL | STA_NANO, 800L, -45000L);
    assert_true(s.synced);
    assert_int_equal(s.offset_us, -45);
    /* no daemon: STA_UNSYNC set (the kernel's default) */
    s = nav_time_sync_from(TIME_OK, STA_UNSYNC, 16000000L, 0L);
    assert_false(s.synced);
    assert_int_equal(s.error_us, NAV_TIME_ERROR_UNKNOWN_US);
    assert_int_equal(s.offset_us, 0);
    /* TIME_ERROR (the kernel's clock unsynchronised), or the call failed */
    s = nav_time_sync_from(TIME_ERROR, 0, 100L, 5L);
    assert_false(s.synced);
    s = nav_time_sync_from(-1, 0, 100L, 5L);
    assert_false(s.synced);
    /* a leap second pending is still synchronised */
    s = nav_time_sync_from(TIME_INS, STA_PLL | STA_INS, 100L, 1L);
    assert_true(s.synced);
    /* saturations: a huge error is not the 'unknown' marker; offsets clamp */
    s = nav_time_sync_from(TIME_OK, 0, 0x7fffffffffffL, 0x7fffffffffffL);
    assert_int_equal(s.error_us, NAV_TIME_ERROR_UNKNOWN_US - 1u);
    assert_int_equal(s.offset_us, INT32_MAX);
    s = nav_time_sync_from(TIME_OK, 0, -1L, -0x7fffffffffffL);
    assert_int_equal(s.error_us, NAV_TIME_ERROR_UNKNOWN_US);
    assert_int_equal(s.offset_us, -INT32_MAX);
}

static void test_step_watch(void **state)
{
    (void)state;
    nav_time_t t;
    nav_time_init(&t, true);
    uint64_t mono = 5000000u;
    int64_t utc = k_utc0;
    assert_int_equal(nav_time_step_check(&t, utc, mono), 0); /* primes */
    /* 100 cycles of 53.8 ms with a 500 ppm slew (the most a daemon slews): no step */
    for (int i = 0; i < 100; i++) {
        mono += 53800u;
        utc += 53800 + 27;
        assert_int_equal(nav_time_step_check(&t, utc, mono), 0);
    }
    assert_int_equal(t.n_steps, 0u);
    /* exactly the threshold: not a step; just above: a step */
    mono += 53800u;
    utc += 53800 + NAV_TIME_STEP_THRESHOLD_US;
    assert_int_equal(nav_time_step_check(&t, utc, mono), 0);
    mono += 53800u;
    utc += 53800 + NAV_TIME_STEP_THRESHOLD_US + 1;
    assert_int_equal(nav_time_step_check(&t, utc, mono), NAV_TIME_STEP_THRESHOLD_US + 1);
    assert_int_equal(t.n_steps, 1u);
    /* chrony's first step back by 3.2 s (an RTC-less board booted fast) */
    mono += 53800u;
    utc += 53800 - 3200000;
    assert_int_equal(nav_time_step_check(&t, utc, mono), -3200000);
    assert_int_equal(t.n_steps, 2u);
    /* the next cycle is measured from the stepped clock: no second report */
    mono += 53800u;
    utc += 53800;
    assert_int_equal(nav_time_step_check(&t, utc, mono), 0);
    /* a clock set from 1970 to now (a board without RTC): a step of decades */
    nav_time_init(&t, true);
    (void)nav_time_step_check(&t, 12 * 1000000LL, 12000000u);
    assert_int_equal(nav_time_step_check(&t, k_utc0, 12100000u), k_utc0 - 12 * 1000000LL - 100000);
    /* a monotonic reading behind the last (cannot happen): no step claimed, re-primed */
    assert_int_equal(nav_time_step_check(&t, k_utc0, 1000u), 0);
    assert_int_equal(t.n_steps, 1u);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sync_state_from_adjtimex),
        cmocka_unit_test(test_step_watch),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
