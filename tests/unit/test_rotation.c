/* Unit tests of math/rotation: Eq. 9, Euler round trips (with the singular
 * case), small-angle matrix, exp/log. */
#include "tests/unit/support/testutil.h"

#include "math/rotation.h"

#define DEG (MFNS_PI / 180.0)

static void assert_m3_near(mfns_m3_t a, const double e[3][3], double tol)
{
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            assert_near(a.m[i][j], e[i][j], tol);
        }
    }
}

static void test_eq9_entries_for_chosen_angles(void **state)
{
    (void)state;
    /* roll 30, pitch 45, yaw 60 deg; values from Eq. 9 evaluated in double by hand:
     * r11 = c60 c45 + s60 s45 s30 = 0.35355 + 0.30619 */
    const double e[3][3] = {{0.6597396084, 0.75, -0.0473671727},
                            {-0.4355957404, 0.4330127019, 0.789149131},
                            {0.6123724357, -0.5, 0.6123724357}};
    const mfns_m3_t c = mfns_euler213_to_m3((mfns_euler_t){(float)(30 * DEG), (float)(45 * DEG), (float)(60 * DEG)});
    assert_m3_near(c, e, 2e-7);
    /* Same as the product of the frame rotations R3 R1 R2. */
    const mfns_m3_t p = mfns_m3_mul(mfns_rot_r3((float)(60 * DEG)),
                                    mfns_m3_mul(mfns_rot_r1((float)(30 * DEG)), mfns_rot_r2((float)(45 * DEG))));
    assert_m3_near(p, e, 3e-7);
    /* Pure yaw 30 deg: R3 as printed in the paper. */
    const mfns_m3_t y = mfns_euler213_to_m3((mfns_euler_t){0, 0, (float)(30 * DEG)});
    const double ey[3][3] = {{0.8660254038, 0.5, 0}, {-0.5, 0.8660254038, 0}, {0, 0, 1}};
    assert_m3_near(y, ey, 1e-7);
}

static void test_euler_round_trip_grid(void **state)
{
    (void)state;
    int n = 0;
    for (int r = -89; r <= 89; r += 7) {
        for (int p = -179; p <= 180; p += 11) {
            for (int y = -179; y <= 180; y += 13) {
                const mfns_euler_t in = {(float)(r * DEG), (float)(p * DEG), (float)(y * DEG)};
                mfns_euler_t out;
                assert_true(mfns_m3_to_euler213(mfns_euler213_to_m3(in), &out));
                /* Tolerance grows as 1/cos(roll) toward the singularity. */
                const double tol = 2e-6 / cos(r * DEG);
                assert_near(out.roll, in.roll, tol);
                assert_near(remainder((double)out.pitch - (double)in.pitch, 2 * MFNS_PI), 0.0, tol);
                assert_near(remainder((double)out.yaw - (double)in.yaw, 2 * MFNS_PI), 0.0, tol);
                n++;
            }
        }
    }
    assert_true(n > 2000);
}

static void test_euler_near_singular(void **state)
{
    (void)state;
    /* Camera Y's mount in Table 3 has roll 90.1636 deg: near, not at, the lock. */
    const mfns_euler_t in = {(float)(89.8364 * DEG), (float)(-0.5501 * DEG), (float)(0.1925 * DEG)};
    mfns_euler_t out;
    assert_true(mfns_m3_to_euler213(mfns_euler213_to_m3(in), &out));
    assert_near(out.roll, in.roll, 1e-5);
    assert_near(out.pitch, in.pitch, 2e-4); /* ~1e-7 / cos(roll) = 3.5e-5 rad expected */
    assert_near(out.yaw, in.yaw, 2e-4);
}

static void test_euler_singular_reproduces_matrix(void **state)
{
    (void)state;
    const float rolls[2] = {(float)(90 * DEG), (float)(-90 * DEG)};
    for (int k = 0; k < 2; k++) {
        const mfns_m3_t c = mfns_euler213_to_m3((mfns_euler_t){rolls[k], (float)(20 * DEG), (float)(50 * DEG)});
        mfns_euler_t out;
        assert_false(mfns_m3_to_euler213(c, &out)); /* reported as singular */
        assert_near(out.pitch, 0.0, 0.0);
        assert_near(out.roll, rolls[k], 1e-3);
        /* The angles returned still give the same rotation. */
        const mfns_m3_t back = mfns_euler213_to_m3(out);
        assert_true(mfns_rot_angle_between(back, c) < 1e-3f);
        /* yaw carries yaw - pitch (roll +90) or yaw + pitch (roll -90) */
        assert_near(out.yaw, k == 0 ? 30 * DEG : 70 * DEG, 1e-3);
    }
}

static void test_small_angle_matches_first_order(void **state)
{
    (void)state;
    const mfns_v3_t a = mfns_v3(1e-3f, -2e-3f, 1.5e-3f);
    const mfns_m3_t s = mfns_rot_small_angle(a);
    const double e[3][3] = {{1, 1.5e-3, 2e-3}, {-1.5e-3, 1, 1e-3}, {-2e-3, -1e-3, 1}};
    assert_m3_near(s, e, 1e-9); /* exact up to the float rounding of the inputs */
    /* Frame rotation by small angles: R1(a)R2(b)R3(g) = I - skew(a,b,g) + O(2);
     * the frame rotation is exp(-a), so compare with exp of the negated vector. */
    const mfns_m3_t x = mfns_rot_exp(mfns_v3(-a.x, -a.y, -a.z));
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            assert_near(x.m[i][j], s.m[i][j], 5e-6); /* second order: |a|^2/2 ~ 4e-6 */
        }
    }
}

static void test_exp_log_round_trip(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 7);
    for (int i = 0; i < 2000; i++) {
        /* magnitudes from 1e-7 to just below pi, including the series regions */
        const double mag = (i % 4 == 0) ? pow(10.0, mfns_rng_range(&rng, -7, -3))
                                        : mfns_rng_range(&rng, 0.0, MFNS_PI - 1e-3);
        mfns_v3_t ax = mfns_v3((float)mfns_rng_normal(&rng), (float)mfns_rng_normal(&rng),
                               (float)mfns_rng_normal(&rng));
        assert_true(mfns_v3_normalize(ax, &ax));
        const mfns_v3_t w = mfns_v3_scale(ax, (float)mag);
        const mfns_m3_t r = mfns_rot_exp(w);
        assert_true(mfns_m3_is_rotation(r, 2e-6f));
        const mfns_v3_t back = mfns_rot_log(r);
        const double tol = 2e-6 + 2e-6 * mag;
        assert_near(back.x, w.x, tol);
        assert_near(back.y, w.y, tol);
        assert_near(back.z, w.z, tol);
    }
}

static void test_log_near_pi(void **state)
{
    (void)state;
    const mfns_v3_t axes[3] = {mfns_v3(0, 0, 1), mfns_v3(0.6f, 0.8f, 0), mfns_v3(-0.48f, 0.6f, 0.64f)};
    for (int k = 0; k < 3; k++) {
        const float th = 3.14159f - 1e-4f;
        const mfns_v3_t w = mfns_v3_scale(axes[k], th);
        const mfns_v3_t back = mfns_rot_log(mfns_rot_exp(w));
        assert_near(mfns_v3_norm(back), th, 1e-4);
        assert_near(mfns_v3_dot(back, axes[k]) / mfns_v3_norm(back), 1.0, 1e-4);
    }
}

static void test_exp_is_active_rotation(void **state)
{
    (void)state;
    /* 90 deg about z takes x to y; exp(w) v ~ v + w x v. */
    const mfns_v3_t y = mfns_m3_mul_v3(mfns_rot_exp(mfns_v3(0, 0, (float)(MFNS_PI / 2))), mfns_v3(1, 0, 0));
    assert_near(y.x, 0, 1e-7);
    assert_near(y.y, 1, 1e-7);
    /* frame rotation R3(a) is the active rotation by -a */
    const mfns_m3_t r3 = mfns_rot_r3(0.3f);
    assert_true(mfns_rot_angle_between(r3, mfns_rot_exp(mfns_v3(0, 0, -0.3f))) < 1e-6f);
}

static void test_float_against_double_reference(void **state)
{
    (void)state;
    /* Table 3's C_x^b angles: float Eq. 9 vs a double evaluation, to 1e-7 per entry. */
    const double f = -0.5788 * DEG, t = -90.3523 * DEG, p = 0.0395 * DEG;
    const double e[3][3] = {
        {cos(p) * cos(t) + sin(p) * sin(t) * sin(f), sin(p) * cos(f), -cos(p) * sin(t) + sin(p) * cos(t) * sin(f)},
        {-sin(p) * cos(t) + cos(p) * sin(t) * sin(f), cos(p) * cos(f), sin(p) * sin(t) + cos(p) * cos(t) * sin(f)},
        {cos(f) * sin(t), -sin(f), cos(t) * cos(f)}};
    const mfns_m3_t c = mfns_euler213_to_m3((mfns_euler_t){(float)f, (float)t, (float)p});
    assert_m3_near(c, e, 2e-7);
}

/* q v q* (Hamilton) for the unit quaternion q = (w, x, y, z). */
static mfns_v3_t quat_rotate(const float q[4], mfns_v3_t v)
{
    const mfns_v3_t u = mfns_v3(q[1], q[2], q[3]);
    const float w = q[0];
    /* v + 2 w (u x v) + 2 u x (u x v) */
    const mfns_v3_t t = mfns_v3_scale(mfns_v3_cross(u, v), 2.0f);
    return mfns_v3_add(mfns_v3_add(v, mfns_v3_scale(t, w)), mfns_v3_cross(u, t));
}

static void test_quat_rotates_as_the_matrix(void **state)
{
    (void)state;
    /* Rotations over the whole group, the four Shepperd branches included:
     * angles up to pi about axes near each coordinate axis and in general
     * directions. The quaternion must be unit, have w >= 0 and rotate the
     * basis vectors as R does. */
    uint32_t seed = 12345u;
    for (int n = 0; n < 4000; n++) {
        float ax[3];
        for (int i = 0; i < 3; i++) {
            seed = seed * 1664525u + 1013904223u;
            ax[i] = (float)(seed >> 8) / 16777216.0f - 0.5f;
        }
        if (n % 4 != 0) { /* near a coordinate axis: the x, y, z branches */
            ax[(n % 4) - 1] += 4.0f;
        }
        seed = seed * 1664525u + 1013904223u;
        const float ang = (float)MFNS_PI * (float)(seed >> 8) / 16777216.0f;
        const float nrm = sqrtf(ax[0] * ax[0] + ax[1] * ax[1] + ax[2] * ax[2]);
        const mfns_m3_t r = mfns_rot_exp(mfns_v3(ax[0] / nrm * ang, ax[1] / nrm * ang, ax[2] / nrm * ang));
        float q[4];
        mfns_m3_to_quat(r, q);
        assert_near(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3], 1.0, 1e-6);
        assert_true(q[0] >= 0.0f);
        for (int c = 0; c < 3; c++) {
            float e[3] = {0.0f, 0.0f, 0.0f};
            e[c] = 1.0f;
            const mfns_v3_t v = quat_rotate(q, mfns_v3(e[0], e[1], e[2]));
            assert_near(v.x, r.m[0][c], 2e-6);
            assert_near(v.y, r.m[1][c], 2e-6);
            assert_near(v.z, r.m[2][c], 2e-6);
        }
    }
    /* identity and a half turn about z: (1,0,0,0) and (0,0,0,1) */
    float q[4];
    mfns_m3_to_quat(mfns_m3_identity(), q);
    assert_near(q[0], 1.0, 1e-7);
    mfns_m3_to_quat(mfns_rot_exp(mfns_v3(0.0f, 0.0f, (float)MFNS_PI)), q);
    assert_near(fabsf(q[3]), 1.0, 1e-6);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_eq9_entries_for_chosen_angles),
        cmocka_unit_test(test_euler_round_trip_grid),
        cmocka_unit_test(test_euler_near_singular),
        cmocka_unit_test(test_euler_singular_reproduces_matrix),
        cmocka_unit_test(test_small_angle_matches_first_order),
        cmocka_unit_test(test_exp_log_round_trip),
        cmocka_unit_test(test_log_near_pi),
        cmocka_unit_test(test_exp_is_active_rotation),
        cmocka_unit_test(test_float_against_double_reference),
        cmocka_unit_test(test_quat_rotates_as_the_matrix),
    };
    return cmocka_run_group_tests_name("rotation", tests, NULL, NULL);
}
