/* Unit tests of firmware/frames/cycle_stats: percentiles within one bin, CPU load. */
#include "tests/unit/support/testutil.h"

#include "firmware/frames/cycle_stats.h"

static mfns_cycle_stats_t stats;

static void test_percentiles_of_uniform_samples(void **state)
{
    (void)state;
    mfns_cycle_stats_reset(&stats);
    /* 1000 .. 10999 us, uniformly: p50 ~ 6000, p99 ~ 10900 */
    for (uint32_t i = 0; i < 10000; i++) {
        mfns_cycle_stats_add(&stats, 1000 + i, 53763);
    }
    assert_int_equal(stats.count, 10000);
    assert_near(mfns_cycle_stats_percentile(&stats, 50.0f), 6000, 6000 * 0.05);
    assert_near(mfns_cycle_stats_percentile(&stats, 99.0f), 10900, 10900 * 0.05);
    assert_true(mfns_cycle_stats_percentile(&stats, 100.0f) <= 10999);
    assert_int_equal(stats.max_us, 10999);
    /* busy 6 ms of each 53.8 ms period (18.6 Hz) -> ~11 % */
    assert_near(mfns_cycle_stats_cpu_load_pct(&stats), 100.0 * 5999.5 / 53763.0, 0.01);
}

static void test_empty_and_out_of_range(void **state)
{
    (void)state;
    mfns_cycle_stats_reset(&stats);
    assert_int_equal(mfns_cycle_stats_percentile(&stats, 50.0f), 0);
    assert_near(mfns_cycle_stats_cpu_load_pct(&stats), 0.0, 0.0);
    mfns_cycle_stats_add(&stats, 2, 2);
    mfns_cycle_stats_add(&stats, 4000000000u, 4000000000u);
    assert_int_equal(stats.out_of_range, 2);
    assert_int_equal(mfns_cycle_stats_percentile(&stats, 100.0f), 4000000000u);
    /* a period shorter than the busy time counts the busy time as wall time */
    mfns_cycle_stats_reset(&stats);
    mfns_cycle_stats_add(&stats, 100, 50);
    assert_near(mfns_cycle_stats_cpu_load_pct(&stats), 100.0, 1e-6);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_percentiles_of_uniform_samples),
        cmocka_unit_test(test_empty_and_out_of_range),
    };
    return cmocka_run_group_tests_name("cycle_stats", tests, NULL, NULL);
}
