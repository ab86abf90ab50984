/* Unit tests of math/lens: projection against hand values, the analytic
 * Jacobians against central finite differences in double-checked steps. */
#include "tests/unit/support/testutil.h"

#include "math/lens.h"
#include "math/rotation.h"

#define DEG (MFNS_PI / 180.0)

/* Camera Z of docs/system.md §7, Tables 2/3. */
static mfns_camera_t camera_z(void)
{
    mfns_camera_t c;
    c.k = (mfns_intrinsics_t){1611.21596f, 1610.79607f, 649.51210f, 531.29472f, 0.0f,
                              {-0.10481f, 0.15881f, -0.00137f, 0.00184f, 0.0f}, 1280, 1024};
    c.C_k_b = mfns_euler213_to_m3((mfns_euler_t){(float)(-0.1076 * DEG), (float)(-0.7211 * DEG),
                                                 (float)(1.1690 * DEG)});
    c.r_bk_b = mfns_v3(34.1604f, 30.8251f, 119.7096f);
    return c;
}

static void test_pinhole_hand_values(void **state)
{
    (void)state;
    mfns_intrinsics_t k = {1600, 1600, 640, 512, 0, {0, 0, 0, 0, 0}, 1280, 1024};
    float uv[2];
    assert_int_equal(mfns_cam_project_c(&k, mfns_v3(100, -50, 1000), uv, NULL), MFNS_PROJ_OK);
    assert_near(uv[0], 800, 1e-4);
    assert_near(uv[1], 432, 1e-4);
    assert_int_equal(mfns_cam_project_c(&k, mfns_v3(0, 0, -10), uv, NULL), MFNS_PROJ_BEHIND);
    assert_int_equal(mfns_cam_project_c(&k, mfns_v3(0, 0, NAN), uv, NULL), MFNS_PROJ_BEHIND);
    /* with distortion k1 = -0.1 at x = 0.1: xd = 0.1 (1 - 0.1 * 0.01) = 0.0999 */
    k.dist[0] = -0.1f;
    assert_int_equal(mfns_cam_project_c(&k, mfns_v3(100, 0, 1000), uv, NULL), MFNS_PROJ_OK);
    assert_near(uv[0], 640 + 1600 * 0.0999, 1e-3);
    /* skew: u = fx xd + skew yd + cx */
    k.dist[0] = 0;
    k.skew = 2.0f;
    assert_int_equal(mfns_cam_project_c(&k, mfns_v3(0, 100, 1000), uv, NULL), MFNS_PROJ_OK);
    assert_near(uv[0], 640 + 2.0 * 0.1, 1e-4);
    /* pixel_to_distorted inverts distorted_to_pixel */
    float xd, yd;
    mfns_cam_pixel_to_distorted(&k, 900.0f, 100.0f, &xd, &yd);
    float u, v;
    mfns_cam_distorted_to_pixel(&k, xd, yd, &u, &v);
    assert_near(u, 900, 1e-4);
    assert_near(v, 100, 1e-4);
}

static void test_in_image_bounds_follow_pixel_centre_convention(void **state)
{
    (void)state;
    const mfns_intrinsics_t k = {1600, 1600, 640, 512, 0, {0}, 1280, 1024};
    assert_true(mfns_cam_in_image(&k, -0.5f, -0.5f));
    assert_false(mfns_cam_in_image(&k, -0.51f, 0));
    assert_true(mfns_cam_in_image(&k, 1279.49f, 1023.49f));
    assert_false(mfns_cam_in_image(&k, 1279.5f, 0));
    assert_false(mfns_cam_in_image(&k, NAN, 0));
}

static void test_distortion_jacobian_fd(void **state)
{
    (void)state;
    const mfns_camera_t c = camera_z();
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 11);
    for (int i = 0; i < 200; i++) {
        const float x = (float)mfns_rng_range(&rng, -0.45, 0.45), y = (float)mfns_rng_range(&rng, -0.35, 0.35);
        float xd, yd, j[2][2];
        mfns_cam_distort(&c.k, x, y, &xd, &yd, j);
        const float h = 1e-3f;
        float a, b, cc, d;
        mfns_cam_distort(&c.k, x + h, y, &a, &b, NULL);
        mfns_cam_distort(&c.k, x - h, y, &cc, &d, NULL);
        assert_near(j[0][0], (a - cc) / (2 * h), 2e-3);
        assert_near(j[1][0], (b - d) / (2 * h), 2e-3);
        mfns_cam_distort(&c.k, x, y + h, &a, &b, NULL);
        mfns_cam_distort(&c.k, x, y - h, &cc, &d, NULL);
        assert_near(j[0][1], (a - cc) / (2 * h), 2e-3);
        assert_near(j[1][1], (b - d) / (2 * h), 2e-3);
    }
}

static void test_pose_jacobian_fd(void **state)
{
    (void)state;
    const mfns_camera_t c = camera_z();
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 12);
    int checked = 0;
    for (int i = 0; i < 300; i++) {
        const mfns_euler_t e = {(float)mfns_rng_range(&rng, -0.2, 0.2), (float)mfns_rng_range(&rng, -0.2, 0.2),
                                (float)mfns_rng_range(&rng, -3.1, 3.1)};
        const mfns_pose_t pose = mfns_pose_from_position(
            mfns_euler213_to_m3(e), mfns_v3((float)mfns_rng_range(&rng, -100, 100),
                                            (float)mfns_rng_range(&rng, -100, 100), (float)mfns_rng_range(&rng, -50, 50)));
        /* a point in front of camera Z, about 600 mm away */
        const mfns_v3_t pc = mfns_v3((float)mfns_rng_range(&rng, -200, 200), (float)mfns_rng_range(&rng, -150, 150),
                                     (float)mfns_rng_range(&rng, 400, 900));
        /* back to the world: p_b = C_k_b pc + r_bk_b; p_w = C_w_b^T (p_b - r_bw_b) */
        const mfns_v3_t pb = mfns_v3_add(mfns_m3_mul_v3(c.C_k_b, pc), c.r_bk_b);
        const mfns_v3_t pw = mfns_m3_tmul_v3(pose.C_w_b, mfns_v3_sub(pb, pose.r_bw_b));
        float uv[2], j[2][6];
        assert_int_equal(mfns_cam_project(&c, &pose, pw, uv, j), MFNS_PROJ_OK);
        for (int k = 0; k < 6; k++) {
            const float h = k < 3 ? 1e-4f : 5e-2f; /* rad, mm: both ~0.1-0.2 px */
            float dp[6] = {0}, dm[6] = {0};
            dp[k] = h;
            dm[k] = -h;
            const mfns_pose_t pp = mfns_pose_apply(&pose, dp), pm = mfns_pose_apply(&pose, dm);
            float up[2], um[2];
            assert_int_equal(mfns_cam_project(&c, &pp, pw, up, NULL), MFNS_PROJ_OK);
            assert_int_equal(mfns_cam_project(&c, &pm, pw, um, NULL), MFNS_PROJ_OK);
            for (int r = 0; r < 2; r++) {
                const double fd = ((double)up[r] - (double)um[r]) / (2.0 * (double)h);
                /* float pixels carry ~6e-5 px of rounding: tolerance 1e-3 relative + rounding/h */
                assert_near(j[r][k], fd, 1e-3 * fabs(fd) + 2e-4 / (double)h + 1e-3);
            }
        }
        checked++;
    }
    assert_int_equal(checked, 300);
}

static void test_pose_position_round_trip(void **state)
{
    (void)state;
    const mfns_m3_t c = mfns_euler213_to_m3((mfns_euler_t){0.1f, -0.3f, 1.2f});
    const mfns_pose_t p = mfns_pose_from_position(c, mfns_v3(33.84f, -128.94f, 576.91f));
    const mfns_v3_t r = mfns_pose_position_w(&p);
    assert_near(r.x, 33.84, 1e-4);
    assert_near(r.y, -128.94, 1e-4);
    assert_near(r.z, 576.91, 1e-4);
    /* the world origin seen from the body is r_bw_b */
    const mfns_camera_t cam = camera_z();
    const mfns_v3_t pc = mfns_cam_world_to_camera(&cam, &p, mfns_v3(0, 0, 0));
    const mfns_v3_t expect = mfns_m3_tmul_v3(cam.C_k_b, mfns_v3_sub(p.r_bw_b, cam.r_bk_b));
    assert_near(pc.x, expect.x, 1e-4);
    assert_near(pc.z, expect.z, 1e-4);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pinhole_hand_values),
        cmocka_unit_test(test_in_image_bounds_follow_pixel_centre_convention),
        cmocka_unit_test(test_distortion_jacobian_fd),
        cmocka_unit_test(test_pose_jacobian_fd),
        cmocka_unit_test(test_pose_position_round_trip),
    };
    return cmocka_run_group_tests_name("camera", tests, NULL, NULL);
}
