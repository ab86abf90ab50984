/* Unit tests of math/fixed: conversions, rounding, saturation at the edges. */
#include "tests/unit/support/testutil.h"

#include "math/fixed.h"

static void test_q16_conversions_and_rounding(void **state)
{
    (void)state;
    assert_int_equal(mfns_q16_from_float(1.0f), 65536);
    assert_int_equal(mfns_q16_from_float(-1.5f), -98304);
    /* ties away from zero: 0.5 LSB */
    assert_int_equal(mfns_q16_from_float(0.5f / 65536.0f), 1);
    assert_int_equal(mfns_q16_from_float(-0.5f / 65536.0f), -1);
    assert_int_equal(mfns_q16_from_float(0.49f / 65536.0f), 0);
    assert_near(mfns_q16_to_float(98304), 1.5, 0);
    /* round trip error <= half an LSB over the range */
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 3);
    for (int i = 0; i < 10000; i++) {
        const float f = (float)mfns_rng_range(&rng, -200.0, 200.0);
        assert_near(mfns_q16_to_float(mfns_q16_from_float(f)), f, 0.5 / 65536.0 + 1e-7 * fabs((double)f));
    }
}

static void test_q16_saturation_at_edges(void **state)
{
    (void)state;
    q16_16_t q;
    assert_false(mfns_q16_from_float_checked(40000.0f, &q));
    assert_int_equal(q, INT32_MAX);
    assert_false(mfns_q16_from_float_checked(-40000.0f, &q));
    assert_int_equal(q, INT32_MIN);
    assert_false(mfns_q16_from_float_checked(NAN, &q));
    assert_int_equal(q, 0);
    assert_false(mfns_q16_from_float_checked(INFINITY, &q));
    assert_int_equal(q, INT32_MAX);
    assert_true(mfns_q16_from_float_checked(-32768.0f, &q));
    assert_int_equal(q, INT32_MIN); /* exactly representable lower limit */
    assert_int_equal(mfns_q16_add_sat(INT32_MAX, 1), INT32_MAX);
    assert_int_equal(mfns_q16_add_sat(INT32_MIN, -1), INT32_MIN);
    assert_int_equal(mfns_q16_sub_sat(INT32_MIN, 1), INT32_MIN);
    assert_int_equal(mfns_q16_sub_sat(INT32_MAX, -1), INT32_MAX);
    assert_int_equal(mfns_q16_add_sat(65536, 65536), 131072);
    /* 200 * 200 = 40000 > 32768 */
    assert_int_equal(mfns_q16_mul_sat(200 * 65536, 200 * 65536), INT32_MAX);
    assert_int_equal(mfns_q16_mul_sat(200 * 65536, -200 * 65536), INT32_MIN);
    assert_int_equal(mfns_q16_mul_sat(INT32_MIN, INT32_MIN), INT32_MAX);
}

static void test_q16_mul_rounding(void **state)
{
    (void)state;
    assert_int_equal(mfns_q16_mul_sat(3 * 65536, 65536 / 2), 98304);       /* 3 * 0.5 */
    assert_int_equal(mfns_q16_mul_sat(-3 * 65536, 65536 / 2), -98304);
    /* 1 LSB * 0.5 = 0.5 LSB -> rounds away from zero */
    assert_int_equal(mfns_q16_mul_sat(1, 32768), 1);
    assert_int_equal(mfns_q16_mul_sat(-1, 32768), -1);
    assert_int_equal(mfns_q16_mul_sat(1, 32767), 0);
    /* against double */
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 5);
    for (int i = 0; i < 10000; i++) {
        const double a = mfns_rng_range(&rng, -150, 150), b = mfns_rng_range(&rng, -150, 150);
        const q16_16_t qa = mfns_q16_from_float((float)a), qb = mfns_q16_from_float((float)b);
        const double exact = ((double)qa / 65536.0) * ((double)qb / 65536.0);
        if (fabs(exact) < 32767) {
            assert_near(mfns_q16_to_float(mfns_q16_mul_sat(qa, qb)), exact, 0.5 / 65536.0 + 1e-9 + fabs(exact) * 6e-8);
        }
    }
}

static void test_q16_lerp(void **state)
{
    (void)state;
    const q16_16_t a = mfns_q16_from_float(-2.0f), b = mfns_q16_from_float(6.0f);
    assert_int_equal(mfns_q16_lerp(a, b, 0), a);
    assert_int_equal(mfns_q16_lerp(a, b, MFNS_Q16_16_ONE), b);
    assert_int_equal(mfns_q16_lerp(a, b, MFNS_Q16_16_ONE / 4), 0);
    /* extreme endpoints do not overflow */
    assert_int_equal(mfns_q16_lerp(INT32_MIN, INT32_MAX, MFNS_Q16_16_ONE), INT32_MAX);
}

static void test_px_q8(void **state)
{
    (void)state;
    assert_int_equal(mfns_px_q8_from_float(639.5f), 639 * 256 + 128);
    assert_near(mfns_px_q8_to_float(256 * 1279 + 255), 1279.99609375, 0);
    px_q8_t p;
    assert_false(mfns_px_q8_from_float_checked(1e8f, &p));
    assert_int_equal(p, INT32_MAX);
    assert_false(mfns_px_q8_from_float_checked(NAN, &p));
    assert_int_equal(mfns_px_q8_add_sat(INT32_MAX - 10, 100), INT32_MAX);
    /* ratio: 1000/3 = 333.333 -> 85333.33 -> 85333 */
    assert_true(mfns_px_q8_from_ratio(1000, 3, &p));
    assert_int_equal(p, 85333);
    /* ties away from zero: 1/512 px = 0.5 LSB */
    assert_true(mfns_px_q8_from_ratio(1, 512, &p));
    assert_int_equal(p, 1);
    assert_true(mfns_px_q8_from_ratio(-1, 512, &p));
    assert_int_equal(p, -1);
    assert_true(mfns_px_q8_from_ratio(-1000, 3, &p));
    assert_int_equal(p, -85333);
    /* large moments of a big bright blob: sum(x*I) ~ 1279 * 65535 * 4096 */
    const int64_t den = (int64_t)65535 * 4096;
    assert_true(mfns_px_q8_from_ratio(den * 1279 + den / 2, den, &p));
    assert_int_equal(p, 1279 * 256 + 128);
    assert_false(mfns_px_q8_from_ratio(5, 0, &p));
    assert_false(mfns_px_q8_from_ratio(5, -1, &p));
    assert_false(mfns_px_q8_from_ratio(INT64_MAX, 1, &p));
    assert_int_equal(p, INT32_MAX);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_q16_conversions_and_rounding),
        cmocka_unit_test(test_q16_saturation_at_edges),
        cmocka_unit_test(test_q16_mul_rounding),
        cmocka_unit_test(test_q16_lerp),
        cmocka_unit_test(test_px_q8),
    };
    return cmocka_run_group_tests_name("fixed", tests, NULL, NULL);
}
