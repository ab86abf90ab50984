/* Unit tests of beacon identification (acquisition, tracking) on the paper's
 * rig and beacon map: right on random poses with >= 4 beacons in view, never
 * a wrong identification reported as a fix, spurious blobs rejected, too few
 * beacons and ambiguity reported. (The 1000-pose statistics run in pytest
 * through ctypes: tests/host/test_pose_flight.py.) */
#include <string.h>

#include "pose_testlib.h"

/* Test code computes in double from the float model on purpose. */
#pragma GCC diagnostic ignored "-Wdouble-promotion"

#define DEG (MFNS_PI / 180.0)

static mfns_pose_config_t config(double sigma)
{
    mfns_pose_config_t cfg;
    mfns_pose_config_default(&cfg);
    cfg.sigma_px = (float)sigma;
    cfg.max_range_mm = 2500.0f; /* the paper's frame is about 1 x 1 x 1.5 m */
    return cfg;
}

/* True when every inlier of the solution carries the true beacon. */
static bool assoc_right(const mfns_pose_solution_t *sol, const mfns_obs_frame_t *frame, const mfns_pose_assoc_t *truth)
{
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        for (int i = 0; i < frame->count[c]; i++) {
            if (sol->inlier[c][i] && sol->assoc.beacon[c][i] != truth->beacon[c][i]) {
                return false;
            }
        }
    }
    return true;
}

static void test_acquire_random_poses(void **state)
{
    (void)state;
    const mfns_rig_t rig = pt_paper_rig();
    const mfns_beacon_map_t map = pt_paper_map();
    const mfns_pose_config_t cfg = config(0.3);
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 501);
    int right = 0, trials = 60, max_hyp = 0;
    for (int t = 0; t < trials; t++) {
        pt_dpose_t truth;
        assert_true(pt_random_visible_pose(&rig, &map, 150, 4, 1000000, &rng, &truth) >= 4);
        mfns_obs_frame_t frame;
        mfns_pose_assoc_t tassoc;
        const int n = pt_make_frame(&rig, &map, &truth, 0.3, &rng, &frame, &tassoc);
        mfns_pose_solution_t sol;
        const mfns_pose_status_t st = mfns_pose_acquire(&rig, &map, &frame, &cfg, &sol);
        max_hyp = sol.hypotheses > max_hyp ? sol.hypotheses : max_hyp;
        assert_true(sol.hypotheses <= cfg.s.max_hypotheses);
        if (st == MFNS_POSE_NO_FIX) {
            continue;
        }
        /* a fix is never a wrong identification */
        assert_true(assoc_right(&sol, &frame, &tassoc));
        assert_int_equal(sol.beacons_used, n);
        const pt_dpose_t est = pt_from_float(&sol.pose);
        assert_true(pt_pos_err(&est, &truth) < 5.0);
        assert_true(pt_rot_err(est.C, truth.C) < 0.2 * DEG);
        right++;
    }
    print_message("acquired %d / %d random poses with >= 4 beacons in view (max %d hypotheses)\n", right, trials,
                  max_hyp);
    assert_true(right >= trials - 1);
}

static void test_spurious_blobs_rejected(void **state)
{
    (void)state;
    const mfns_rig_t rig = pt_paper_rig();
    const mfns_beacon_map_t map = pt_paper_map();
    const mfns_pose_config_t cfg = config(0.1);
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 502);
    int right = 0, trials = 12;
    for (int t = 0; t < trials; t++) {
        pt_dpose_t truth;
        assert_true(pt_random_visible_pose(&rig, &map, 150, 4, 1000000, &rng, &truth) >= 4);
        mfns_obs_frame_t frame;
        mfns_pose_assoc_t tassoc;
        const int n = pt_make_frame(&rig, &map, &truth, 0.1, &rng, &frame, &tassoc);
        /* a reflection in one camera (two every fourth trial) */
        pt_add_spurious(&rig, t % 3, &rng, &frame, &tassoc);
        if (t % 4 == 0) {
            pt_add_spurious(&rig, (t + 1) % 3, &rng, &frame, &tassoc);
        }
        mfns_pose_solution_t sol;
        const mfns_pose_status_t st = mfns_pose_acquire(&rig, &map, &frame, &cfg, &sol);
        if (st == MFNS_POSE_NO_FIX) {
            continue;
        }
        assert_true(assoc_right(&sol, &frame, &tassoc));
        assert_int_equal(sol.beacons_used, n);
        /* the reflections carry no beacon */
        for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
            for (int i = 0; i < frame.count[c]; i++) {
                if (tassoc.beacon[c][i] == MFNS_POSE_NO_BEACON) {
                    assert_int_equal(sol.inlier[c][i], 0);
                }
            }
        }
        right++;
    }
    print_message("with reflections: %d / %d acquired\n", right, trials);
    assert_true(right >= trials - 1);
}

/* Regression: a frame recorded from the 1000-pose statistics (seed 2 of a
 * 20,000-pose sweep, sigma 0.3 px, four beacons in view). The right minimal
 * pose of the first blob triple predicted the fourth beacon 16 px off (its
 * geometry amplifies the noise ~50x), the tracking gate dropped it, and a
 * wrong pose 400 mm away that fits all four blobs at 0.42 px RMS was reported
 * as a unique fix. Either the right identification or no fix is acceptable. */
static void test_recorded_near_ambiguous_frame(void **state)
{
    (void)state;
    const mfns_rig_t rig = pt_paper_rig();
    const mfns_beacon_map_t map = pt_paper_map();
    const mfns_pose_config_t cfg = config(0.3);
    static const float obs[4][4] = {{903.105426f, 363.764402f, 0.169908079f, -0.0994497338f},
                                    {502.471894f, 248.971333f, -0.0733044977f, -0.160835456f},
                                    {854.441387f, 146.100465f, 0.127789894f, -0.240418007f},
                                    {200.222102f, 275.398157f, -0.281823907f, -0.160300068f}};
    static const int cam_of[4] = {0, 1, 2, 2}, beacon_of[4] = {4, 9, 6, 7};
    mfns_obs_frame_t frame;
    memset(&frame, 0, sizeof frame);
    mfns_pose_assoc_t truth;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        for (int i = 0; i < MFNS_MAX_OBS_PER_CAMERA; i++) {
            truth.beacon[c][i] = MFNS_POSE_NO_BEACON;
        }
    }
    for (int k = 0; k < 4; k++) {
        const int c = cam_of[k], i = frame.count[c]++;
        frame.obs[c][i] = (mfns_obs_t){obs[k][0], obs[k][1], obs[k][2], obs[k][3]};
        truth.beacon[c][i] = (int16_t)beacon_of[k];
    }
    mfns_pose_solution_t sol;
    const mfns_pose_status_t st = mfns_pose_acquire(&rig, &map, &frame, &cfg, &sol);
    print_message("recorded frame: status %d reason %d, %u beacons, %.3f px RMS, r_bw_b (%.1f, %.1f, %.1f) mm\n",
                  (int)st, (int)sol.reason, sol.beacons_used, sol.residual_rms_px, sol.pose.r_bw_b.x,
                  sol.pose.r_bw_b.y, sol.pose.r_bw_b.z);
    if (st != MFNS_POSE_NO_FIX) {
        assert_true(assoc_right(&sol, &frame, &truth));
        assert_int_equal(sol.beacons_used, 4);
        /* truth: r_bw_b = (-25.5, -126.3, 118.3) mm */
        assert_true(fabs(sol.pose.r_bw_b.x + 25.52) < 10.0 && fabs(sol.pose.r_bw_b.y + 126.30) < 10.0 &&
                    fabs(sol.pose.r_bw_b.z - 118.33) < 10.0);
    }
}

static void test_too_few_and_minimal(void **state)
{
    (void)state;
    const mfns_rig_t rig = pt_paper_rig();
    const mfns_beacon_map_t map = pt_paper_map();
    const mfns_pose_config_t cfg = config(0.1);
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 503);
    /* turntable at yaw 0: beacon 8 in X, 9 in Z -> two beacons */
    const double eye[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    const double zero[3] = {0, 0, 0};
    pt_dpose_t truth = pt_pose(eye, zero);
    mfns_obs_frame_t frame;
    mfns_pose_assoc_t tassoc;
    assert_int_equal(pt_make_frame(&rig, &map, &truth, 0.1, &rng, &frame, &tassoc), 2);
    mfns_pose_solution_t sol;
    assert_int_equal(mfns_pose_acquire(&rig, &map, &frame, &cfg, &sol), MFNS_POSE_NO_FIX);
    assert_int_equal(sol.reason, MFNS_POSE_R_TOO_FEW);
    assert_int_equal(mfns_pose_solve(&rig, &map, &frame, NULL, &cfg, &sol), MFNS_POSE_NO_FIX);
    assert_int_equal(sol.reason, MFNS_POSE_R_TOO_FEW);
    /* three beacons (yaw 20): the minimal case. Acquisition must not guess:
     * either a verified unique pose (visibility rules the others out) or
     * AMBIGUOUS / NOT_IDENTIFIED. */
    int fixes = 0, ambiguous = 0;
    for (int yaw = 20; yaw <= 60; yaw += 10) {
        const double w[3] = {0, 0, -yaw * DEG};
        double c[3][3];
        pt_rot_exp(w, c);
        truth = pt_pose(c, zero);
        if (pt_make_frame(&rig, &map, &truth, 0.1, &rng, &frame, &tassoc) != 3) {
            continue;
        }
        const mfns_pose_status_t st = mfns_pose_acquire(&rig, &map, &frame, &cfg, &sol);
        if (st == MFNS_POSE_NO_FIX) {
            assert_true(sol.reason == MFNS_POSE_R_AMBIGUOUS || sol.reason == MFNS_POSE_R_NOT_IDENTIFIED);
            ambiguous++;
        } else {
            assert_int_equal(st, MFNS_POSE_DEGRADED);
            assert_int_equal(sol.reason, MFNS_POSE_R_MINIMAL);
            assert_true(assoc_right(&sol, &frame, &tassoc));
            fixes++;
        }
        /* tracking from the previous pose handles the minimal case */
        const double w2[3] = {0, 0, -(yaw - 0.3) * DEG}; /* 0.3 deg ~ 8 px: inside the 15 px gate */
        double c2[3][3];
        pt_rot_exp(w2, c2);
        const pt_dpose_t prev = pt_pose(c2, zero);
        const mfns_pose_t prev_f = pt_to_float(&prev);
        const mfns_pose_status_t st2 = mfns_pose_solve(&rig, &map, &frame, &prev_f, &cfg, &sol);
        assert_int_equal(st2, MFNS_POSE_DEGRADED);
        assert_int_equal(sol.reason, MFNS_POSE_R_MINIMAL);
        assert_true(assoc_right(&sol, &frame, &tassoc));
        const pt_dpose_t est = pt_from_float(&sol.pose);
        assert_true(pt_pos_err(&est, &truth) < 5.0);
    }
    print_message("three beacons in view: %d unique fixes, %d reported ambiguous\n", fixes, ambiguous);
    assert_true(fixes + ambiguous >= 3);
}

static void test_tracking(void **state)
{
    (void)state;
    const mfns_rig_t rig = pt_paper_rig();
    const mfns_beacon_map_t map = pt_paper_map();
    const mfns_pose_config_t cfg = config(0.1);
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 504);
    for (int t = 0; t < 50; t++) {
        pt_dpose_t truth;
        assert_true(pt_random_visible_pose(&rig, &map, 150, 4, 1000000, &rng, &truth) >= 4);
        mfns_obs_frame_t frame;
        mfns_pose_assoc_t tassoc;
        (void)pt_make_frame(&rig, &map, &truth, 0.1, &rng, &frame, &tassoc);
        pt_add_spurious(&rig, t % 3, &rng, &frame, &tassoc);
        /* the previous solution: up to 0.2 deg and 1 mm per axis off (a frame
         * at 18.6 fps; predictions stay well inside the 15 px gate) */
        pt_dpose_t prev;
        pt_random_rotation(&rng, 0.2 * DEG, truth.C, prev.C);
        for (int i = 0; i < 3; i++) {
            prev.r[i] = truth.r[i] + mfns_rng_range(&rng, -1, 1);
        }
        const mfns_pose_t prev_f = pt_to_float(&prev);
        mfns_pose_solution_t sol;
        const mfns_pose_status_t st = mfns_pose_track(&rig, &map, &frame, &prev_f, &cfg, &sol);
        assert_true(st != MFNS_POSE_NO_FIX);
        assert_true(assoc_right(&sol, &frame, &tassoc));
        assert_int_equal(sol.hypotheses, 0);
        const pt_dpose_t est = pt_from_float(&sol.pose);
        assert_true(pt_pos_err(&est, &truth) < 5.0);
    }
    /* a prior far off: tracking loses the beacons, solve() falls back to acquisition */
    pt_dpose_t truth;
    assert_true(pt_random_visible_pose(&rig, &map, 150, 4, 1000000, &rng, &truth) >= 4);
    mfns_obs_frame_t frame;
    mfns_pose_assoc_t tassoc;
    (void)pt_make_frame(&rig, &map, &truth, 0.1, &rng, &frame, &tassoc);
    pt_dpose_t far;
    pt_random_rotation(&rng, 0.0, truth.C, far.C);
    const double w[3] = {0.0, 0.0, 60 * DEG};
    double r[3][3];
    pt_rot_exp(w, r);
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            far.C[i][j] = r[i][0] * truth.C[0][j] + r[i][1] * truth.C[1][j] + r[i][2] * truth.C[2][j];
        }
        far.r[i] = truth.r[i];
    }
    const mfns_pose_t far_f = pt_to_float(&far);
    mfns_pose_solution_t sol;
    assert_int_equal(mfns_pose_track(&rig, &map, &frame, &far_f, &cfg, &sol), MFNS_POSE_NO_FIX);
    const mfns_pose_status_t st = mfns_pose_solve(&rig, &map, &frame, &far_f, &cfg, &sol);
    assert_true(st != MFNS_POSE_NO_FIX);
    assert_true(sol.hypotheses > 0);
    assert_true(assoc_right(&sol, &frame, &tassoc));
}

static void test_hypothesis_bound(void **state)
{
    (void)state;
    const mfns_rig_t rig = pt_paper_rig();
    const mfns_beacon_map_t map = pt_paper_map();
    mfns_pose_config_t cfg = config(0.1);
    cfg.s.max_hypotheses = 50;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 505);
    pt_dpose_t truth;
    assert_true(pt_random_visible_pose(&rig, &map, 150, 4, 1000000, &rng, &truth) >= 4);
    mfns_obs_frame_t frame;
    mfns_pose_assoc_t tassoc;
    (void)pt_make_frame(&rig, &map, &truth, 0.1, &rng, &frame, &tassoc);
    mfns_pose_solution_t sol;
    /* the bound stops the search before uniqueness is known: no fix, never a guess */
    assert_int_equal(mfns_pose_acquire(&rig, &map, &frame, &cfg, &sol), MFNS_POSE_NO_FIX);
    assert_true(sol.reason == MFNS_POSE_R_NOT_IDENTIFIED || sol.reason == MFNS_POSE_R_AMBIGUOUS);
    assert_true(sol.hypotheses <= 50);
    /* bad input */
    assert_int_equal(mfns_pose_acquire(&rig, &map, NULL, &cfg, &sol), MFNS_POSE_NO_FIX);
    assert_int_equal(sol.reason, MFNS_POSE_R_BAD_ARG);
    frame.obs[0][0].x = NAN;
    frame.count[0] = frame.count[0] > 0 ? frame.count[0] : 1;
    assert_int_equal(mfns_pose_acquire(&rig, &map, &frame, &cfg, &sol), MFNS_POSE_NO_FIX);
    assert_int_equal(sol.reason, MFNS_POSE_R_BAD_ARG);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_acquire_random_poses),
        cmocka_unit_test(test_recorded_near_ambiguous_frame),
        cmocka_unit_test(test_spurious_blobs_rejected),
        cmocka_unit_test(test_too_few_and_minimal),
        cmocka_unit_test(test_tracking),
        cmocka_unit_test(test_hypothesis_bound),
    };
    return cmocka_run_group_tests_name("pose_ident", tests, NULL, NULL);
}
