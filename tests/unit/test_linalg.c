/* Unit tests of math/linalg: products, transposes, skew, orthonormality. */
#include "tests/unit/support/testutil.h"

#include "math/lens.h"
#include "math/linalg.h"
#include "math/rotation.h"

static void test_products_hand_checked(void **state)
{
    (void)state;
    const mfns_m3_t a = {{{1, 2, 3}, {4, 5, 6}, {7, 8, 10}}};
    const mfns_m3_t b = {{{2, 0, 1}, {1, 3, 0}, {0, 1, 4}}};
    const mfns_m3_t ab = mfns_m3_mul(a, b);
    /* by hand: row0 = (1*2+2*1, 2*3+3*1, 1+12) */
    const float expect[3][3] = {{4, 9, 13}, {13, 21, 28}, {22, 34, 47}};
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            assert_near(ab.m[i][j], expect[i][j], 0.0);
        }
    }
    assert_near(mfns_m3_det(a), -3.0, 1e-5);
    const mfns_v3_t v = mfns_m3_mul_v3(a, mfns_v3(1, -1, 2));
    assert_near(v.x, 5, 0);
    assert_near(v.y, 11, 0);
    assert_near(v.z, 19, 0);
    const mfns_v3_t w = mfns_m3_tmul_v3(a, mfns_v3(1, -1, 2));
    const mfns_v3_t w2 = mfns_m3_mul_v3(mfns_m3_transpose(a), mfns_v3(1, -1, 2));
    assert_near(w.x, w2.x, 0);
    assert_near(w.y, w2.y, 0);
    assert_near(w.z, 17, 0); /* column 3 of A: 3 - 6 + 20 */
}

static void test_cross_and_skew_agree(void **state)
{
    (void)state;
    const mfns_v3_t a = mfns_v3(0.3f, -1.2f, 2.0f), b = mfns_v3(-4.0f, 0.5f, 1.5f);
    const mfns_v3_t c1 = mfns_v3_cross(a, b);
    const mfns_v3_t c2 = mfns_m3_mul_v3(mfns_m3_skew(a), b);
    assert_near(c1.x, c2.x, 1e-6);
    assert_near(c1.y, c2.y, 1e-6);
    assert_near(c1.z, c2.z, 1e-6);
    assert_near(mfns_v3_dot(c1, a), 0.0, 1e-5);
    assert_near(mfns_v3_dot(c1, b), 0.0, 1e-5);
    /* e_x x e_y = e_z */
    const mfns_v3_t z = mfns_v3_cross(mfns_v3(1, 0, 0), mfns_v3(0, 1, 0));
    assert_near(z.z, 1.0, 0);
}

static void test_normalize_rejects_zero(void **state)
{
    (void)state;
    mfns_v3_t n;
    assert_false(mfns_v3_normalize(mfns_v3(0, 0, 0), &n));
    assert_near(n.x, 0, 0);
    assert_true(mfns_v3_normalize(mfns_v3(3, 0, 4), &n));
    assert_near(n.x, 0.6, 1e-7);
    assert_near(n.z, 0.8, 1e-7);
}

static void test_orthonormality_check(void **state)
{
    (void)state;
    const mfns_m3_t r = mfns_euler213_to_m3((mfns_euler_t){0.3f, -1.1f, 2.0f});
    assert_true(mfns_m3_orthonormality_error(r) < 1e-6f);
    assert_true(mfns_m3_is_rotation(r, 1e-5f));
    mfns_m3_t refl = r;
    for (int j = 0; j < 3; j++) {
        refl.m[0][j] = -refl.m[0][j];
    }
    assert_false(mfns_m3_is_rotation(refl, 1e-5f)); /* orthonormal but det -1 */
    mfns_m3_t bad = r;
    bad.m[1][1] += 1e-3f;
    assert_false(mfns_m3_is_rotation(bad, 1e-5f));
    bad.m[1][1] = NAN;
    assert_false(mfns_m3_is_rotation(bad, 1e-5f));
    assert_true(isinf(mfns_m3_orthonormality_error(bad)));
}

static void test_reorthonormalize_restores_rotation(void **state)
{
    (void)state;
    const mfns_m3_t r = mfns_euler213_to_m3((mfns_euler_t){-0.7f, 0.4f, -2.5f});
    mfns_m3_t drift = r;
    drift.m[0][1] += 2e-3f;
    drift.m[2][0] -= 1e-3f;
    drift.m[1][2] += 1.5e-3f;
    mfns_m3_t fixed;
    assert_true(mfns_m3_reorthonormalize(drift, 8, 2e-6f, &fixed));
    assert_true(mfns_m3_orthonormality_error(fixed) <= 2e-6f);
    /* and it stays close to the input (nearest rotation) */
    assert_true(mfns_rot_angle_between(fixed, r) < 3e-3f);
    /* a singular matrix cannot be made a rotation within the cap */
    const mfns_m3_t zero = {{{0}}};
    assert_false(mfns_m3_reorthonormalize(zero, 8, 1e-5f, &fixed));
}

/* The by-address products compute exactly what the by-value ones do, also
 * when the output is one of the inputs. */
static void test_by_address_same_as_by_value(void **state)
{
    (void)state;
    const mfns_m3_t a = {{{0.3f, -1.7f, 2.1f}, {4.4f, 0.05f, -6.2f}, {7.3f, 8.9f, 1e-3f}}};
    const mfns_m3_t b = {{{-2.2f, 0.7f, 1.9f}, {1.1f, 3.3f, -0.4f}, {0.6f, -1.5f, 4.8f}}};
    const mfns_v3_t v = mfns_v3(0.25f, -3.5f, 1.75f);
    const mfns_m3_t ab = mfns_m3_mul(a, b), at = mfns_m3_transpose(a);
    mfns_m3_t r;
    mfns_m3_mul_at(&a, &b, &r);
    assert_memory_equal(&r, &ab, sizeof r);
    r = a;
    mfns_m3_mul_at(&r, &b, &r);
    assert_memory_equal(&r, &ab, sizeof r);
    r = b;
    mfns_m3_mul_at(&a, &r, &r);
    assert_memory_equal(&r, &ab, sizeof r);
    const mfns_m3_t aa = mfns_m3_mul(a, a);
    r = a;
    mfns_m3_mul_at(&r, &r, &r);
    assert_memory_equal(&r, &aa, sizeof r);
    mfns_m3_transpose_at(&a, &r);
    assert_memory_equal(&r, &at, sizeof r);
    r = a;
    mfns_m3_transpose_at(&r, &r);
    assert_memory_equal(&r, &at, sizeof r);
    const mfns_v3_t w1 = mfns_m3_mul_v3(a, v), w2 = mfns_m3_mul_v3_at(&a, v);
    assert_memory_equal(&w1, &w2, sizeof w1);
    const mfns_v3_t t1 = mfns_m3_tmul_v3(a, v), t2 = mfns_m3_tmul_v3_at(&a, v);
    assert_memory_equal(&t1, &t2, sizeof t1);
    const mfns_m3_t as = mfns_m3_scale(a, -0.5f);
    r = a;
    mfns_m3_scale_at(&r, -0.5f, &r);
    assert_memory_equal(&r, &as, sizeof r);
    /* a rotation slightly off orthonormal */
    mfns_m3_t c = mfns_rot_exp(mfns_v3(0.4f, -1.1f, 0.7f));
    c.m[0][1] += 2e-4f;
    c.m[2][0] -= 1e-4f;
    mfns_m3_t f1, f2;
    const bool ok1 = mfns_m3_reorthonormalize(c, 4, 1e-6f, &f1);
    f2 = c;
    const bool ok2 = mfns_m3_reorthonormalize_at(&f2, 4, 1e-6f, &f2);
    assert_true(ok1 == ok2);
    assert_memory_equal(&f1, &f2, sizeof f1);
    assert_true(mfns_m3_is_rotation(f1, 1e-5f) == mfns_m3_is_rotation_at(&f1, 1e-5f));
    assert_true(mfns_m3_is_rotation(a, 1e-5f) == mfns_m3_is_rotation_at(&a, 1e-5f));
    mfns_euler_t e1, e2;
    assert_true(mfns_m3_to_euler213(c, &e1) == mfns_m3_to_euler213_at(&c, &e2));
    assert_memory_equal(&e1, &e2, sizeof e1);
    const float g1 = mfns_rot_angle_between(c, f1), g2 = mfns_rot_angle_between_at(&c, &f1);
    assert_memory_equal(&g1, &g2, sizeof g1);
    const mfns_pose_t p1 = mfns_pose_from_position(f1, v), p2 = mfns_pose_from_position_at(&f1, v);
    assert_memory_equal(&p1, &p2, sizeof p1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_products_hand_checked),
        cmocka_unit_test(test_cross_and_skew_agree),
        cmocka_unit_test(test_normalize_rejects_zero),
        cmocka_unit_test(test_orthonormality_check),
        cmocka_unit_test(test_reorthonormalize_restores_rotation),
        cmocka_unit_test(test_by_address_same_as_by_value),
    };
    return cmocka_run_group_tests_name("linalg", tests, NULL, NULL);
}
