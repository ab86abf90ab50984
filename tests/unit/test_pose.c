/* Unit tests of the pose refinement (firmware/nav/pose/pose.h): exact recovery,
 * agreement of the float solver with the double reference, convergence from
 * far, the covariance against Monte Carlo on the paper's geometry, and every
 * status / reason the refinement can return. */
#include <string.h>

#include "tests/unit/support/pose_testlib.h"

/* Test code computes in double from the float model on purpose: promotion is intended. */
#pragma GCC diagnostic ignored "-Wdouble-promotion"

#define DEG (MFNS_PI / 180.0)

/* The truth perturbed by exactly `angle` rad about a random axis and
 * `dist` mm in a random direction. */
static pt_dpose_t perturbed(const pt_dpose_t *truth, double angle, double dist, mfns_rng_t *rng)
{
    pt_dpose_t p;
    pt_random_rotation(rng, 0.0, truth->C, p.C); /* copy */
    double ax[3], n;
    do {
        for (int i = 0; i < 3; i++) {
            ax[i] = mfns_rng_range(rng, -1, 1);
        }
        n = sqrt(ax[0] * ax[0] + ax[1] * ax[1] + ax[2] * ax[2]);
    } while (n < 0.1 || n > 1.0);
    const double w[3] = {ax[0] / n * angle, ax[1] / n * angle, ax[2] / n * angle};
    double r[3][3];
    pt_rot_exp(w, r);
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            p.C[i][j] = r[i][0] * truth->C[0][j] + r[i][1] * truth->C[1][j] + r[i][2] * truth->C[2][j];
        }
    }
    double pos[3];
    pt_position_w(truth, pos);
    do {
        for (int i = 0; i < 3; i++) {
            ax[i] = mfns_rng_range(rng, -1, 1);
        }
        n = sqrt(ax[0] * ax[0] + ax[1] * ax[1] + ax[2] * ax[2]);
    } while (n < 0.1 || n > 1.0);
    for (int i = 0; i < 3; i++) {
        pos[i] += ax[i] / n * dist;
    }
    return pt_pose(p.C, pos);
}

static void test_exact_recovery_noise_free(void **state)
{
    (void)state;
    const mfns_rig_t rig = pt_paper_rig();
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 101);
    double worst_pos = 0, worst_rot = 0;
    for (int t = 0; t < 200; t++) {
        const pt_dpose_t truth = pt_random_pose(&rng, 500);
        const int per_cam[3] = {1 + t % 3, 1 + (t / 3) % 3, 1 + (t / 9) % 3};
        const mfns_beacon_map_t map = pt_dense_map(&rig, &truth, per_cam, 400, 1500, &rng);
        mfns_obs_frame_t frame;
        mfns_pose_assoc_t assoc;
        const int n = pt_make_frame(&rig, &map, &truth, 0.0, &rng, &frame, &assoc);
        assert_int_equal(n, map.count);
        const pt_dpose_t init = perturbed(&truth, 5 * DEG, 50, &rng);
        const mfns_pose_t init_f = pt_to_float(&init);
        const mfns_pose_config_t cfg = pt_config(0.1);
        mfns_pose_solution_t sol;
        const mfns_pose_status_t st = mfns_pose_refine(&rig, &map, &frame, &assoc, &init_f, &cfg, &sol);
        assert_int_equal(st, n == 3 ? MFNS_POSE_NO_FIX : MFNS_POSE_OK); /* 3: MINIMAL, pose kept */
        const pt_dpose_t est = pt_from_float(&sol.pose);
        worst_pos = fmax(worst_pos, pt_pos_err(&est, &truth));
        worst_rot = fmax(worst_rot, pt_rot_err(est.C, truth.C));
        assert_int_equal(sol.beacons_used, n);
        assert_true(sol.residual_rms_px < 2e-3f);
        assert_true(sol.iterations >= 1 && sol.iterations <= cfg.s.max_iterations);
        /* the output fields agree with the pose */
        double pos[3];
        pt_position_w(&truth, pos);
        assert_near(sol.r_wb_w.x, pos[0], 0.01);
        assert_near(sol.r_wb_w.y, pos[1], 0.01);
        assert_near(sol.r_wb_w.z, pos[2], 0.01);
        const mfns_m3_t ce = mfns_euler213_to_m3((mfns_euler_t){(float)(sol.euler_deg.roll * DEG),
                                                                 (float)(sol.euler_deg.pitch * DEG),
                                                                 (float)(sol.euler_deg.yaw * DEG)});
        assert_true(mfns_rot_angle_between(ce, sol.pose.C_w_b) < 1e-5f);
    }
    print_message("exact recovery: worst position %.2e mm, worst attitude %.2e deg\n", worst_pos, worst_rot / DEG);
    assert_true(worst_pos < 0.01);
    assert_true(worst_rot < 1e-4 * DEG);
}

static void test_float_agrees_with_double_reference(void **state)
{
    (void)state;
    const mfns_rig_t rig = pt_paper_rig();
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 102);
    double worst_pos = 0, worst_rot = 0;
    for (int t = 0; t < 200; t++) {
        const pt_dpose_t truth = pt_random_pose(&rng, 500);
        const int per_cam[3] = {2 + t % 3, 1 + (t / 3) % 3, 2};
        const mfns_beacon_map_t map = pt_dense_map(&rig, &truth, per_cam, 400, 1500, &rng);
        mfns_obs_frame_t frame;
        mfns_pose_assoc_t assoc;
        (void)pt_make_frame(&rig, &map, &truth, 0.3, &rng, &frame, &assoc);
        pt_dpose_t ref = truth;
        assert_true(pt_ref_refine(&rig, &map, &frame, &assoc, &ref) > 0);
        const pt_dpose_t init = perturbed(&truth, 3 * DEG, 30, &rng);
        const mfns_pose_t init_f = pt_to_float(&init);
        const mfns_pose_config_t cfg = pt_config(0.3);
        mfns_pose_solution_t sol;
        assert_int_equal(mfns_pose_refine(&rig, &map, &frame, &assoc, &init_f, &cfg, &sol), MFNS_POSE_OK);
        const pt_dpose_t est = pt_from_float(&sol.pose);
        worst_pos = fmax(worst_pos, pt_pos_err(&est, &ref));
        worst_rot = fmax(worst_rot, pt_rot_err(est.C, ref.C));
    }
    print_message("float vs double reference: worst %.2e mm, %.2e deg\n", worst_pos, worst_rot / DEG);
    assert_true(worst_pos <= 0.01);
    assert_true(worst_rot <= 1e-4 * DEG);
}

static void test_converges_from_far(void **state)
{
    (void)state;
    const mfns_rig_t rig = pt_paper_rig();
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 103);
    int ok = 0, trials = 200;
    for (int t = 0; t < trials; t++) {
        const pt_dpose_t truth = pt_random_pose(&rng, 300);
        const int per_cam[3] = {2, 2, 2};
        const mfns_beacon_map_t map = pt_dense_map(&rig, &truth, per_cam, 500, 1500, &rng);
        mfns_obs_frame_t frame;
        mfns_pose_assoc_t assoc;
        (void)pt_make_frame(&rig, &map, &truth, 0.1, &rng, &frame, &assoc);
        /* at least 30 deg and 200 mm off */
        const pt_dpose_t init = perturbed(&truth, mfns_rng_range(&rng, 30, 35) * DEG, mfns_rng_range(&rng, 200, 250), &rng);
        assert_true(pt_rot_err(init.C, truth.C) >= 30 * DEG - 1e-9);
        assert_true(pt_pos_err(&init, &truth) >= 200 - 1e-6);
        const mfns_pose_t init_f = pt_to_float(&init);
        const mfns_pose_config_t cfg = pt_config(0.1);
        mfns_pose_solution_t sol;
        const mfns_pose_status_t st = mfns_pose_refine(&rig, &map, &frame, &assoc, &init_f, &cfg, &sol);
        const pt_dpose_t est = pt_from_float(&sol.pose);
        if (st == MFNS_POSE_OK) {
            /* converged to the truth, not elsewhere */
            assert_true(pt_pos_err(&est, &truth) < 2.0);
            assert_true(pt_rot_err(est.C, truth.C) < 0.05 * DEG);
            ok++;
        } else {
            /* never a wrong pose marked valid */
            assert_int_equal(st, MFNS_POSE_NO_FIX);
        }
    }
    print_message("converged from >= 30 deg, >= 200 mm: %d / %d\n", ok, trials);
    assert_true(ok >= trials * 98 / 100);
}

/* Whiten the sample second moment m2 with the predicted covariance pred:
 * W = L^-1 m2 L^-T (pred = L L^T) is the identity when pred is right. Gives
 * the worst |W_ii - 1| and |W_ij| and the mean NEES trace(W). */
static void whiten(const float pred[6][6], const double m2[6][6], double *diag_off_by, double *offdiag,
                   double *mean_nees)
{
    /* whiten with the predicted covariance: L^-1 e has identity covariance */
    double c[6][6], l[6][6] = {{0}};
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < 6; j++) {
            c[i][j] = pred[i][j];
        }
    }
    for (int j = 0; j < 6; j++) {
        double d = c[j][j];
        for (int k = 0; k < j; k++) {
            d -= l[j][k] * l[j][k];
        }
        assert_true(d > 0);
        l[j][j] = sqrt(d);
        for (int i = j + 1; i < 6; i++) {
            double v = c[i][j];
            for (int k = 0; k < j; k++) {
                v -= l[i][k] * l[j][k];
            }
            l[i][j] = v / l[j][j];
        }
    }
    /* W = L^-1 S L^-T with S the sample second moment (mean is ~0) */
    double s[6][6], li[6][6] = {{0}};
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < 6; j++) {
            s[i][j] = m2[i][j];
        }
    }
    for (int j = 0; j < 6; j++) {
        li[j][j] = 1.0 / l[j][j];
        for (int i = j + 1; i < 6; i++) {
            double v = 0;
            for (int k = j; k < i; k++) {
                v -= l[i][k] * li[k][j];
            }
            li[i][j] = v / l[i][i];
        }
    }
    double worst_diag = 0, worst_off = 0, tr = 0;
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < 6; j++) {
            double w = 0;
            for (int a = 0; a < 6; a++) {
                for (int b = 0; b < 6; b++) {
                    w += li[i][a] * s[a][b] * li[j][b];
                }
            }
            if (i == j) {
                tr += w;
                worst_diag = fmax(worst_diag, fabs(w - 1.0));
            } else {
                worst_off = fmax(worst_off, fabs(w));
            }
        }
    }
    *diag_off_by = worst_diag;
    *offdiag = worst_off;
    *mean_nees = tr;
}

/* Monte Carlo of the ML solve at one pose: the sample covariance of the
 * increment error against the predicted sigma^2 (J^T J)^-1. */
static void monte_carlo(const mfns_rig_t *rig, const mfns_beacon_map_t *map, const pt_dpose_t *truth, double sigma,
                        int trials, mfns_rng_t *rng)
{
    const mfns_pose_config_t cfg = pt_config(sigma);
    mfns_obs_frame_t frame;
    mfns_pose_assoc_t assoc;
    const int n = pt_make_frame(rig, map, truth, 0.0, rng, &frame, &assoc);
    assert_true(n >= 3);
    const mfns_pose_t truth_f = pt_to_float(truth);
    mfns_pose_solution_t ref;
    assert_true(mfns_pose_refine(rig, map, &frame, &assoc, &truth_f, &cfg, &ref) != MFNS_POSE_NO_FIX);
    double sum[6] = {0}, sum2[6][6] = {{0}}, sum2r[6][6] = {{0}};
    double pos_s2[3] = {0}, eul_s2[3] = {0};
    int used = 0;
    for (int t = 0; t < trials; t++) {
        (void)pt_make_frame(rig, map, truth, sigma, rng, &frame, &assoc);
        mfns_pose_solution_t sol;
        if (mfns_pose_refine(rig, map, &frame, &assoc, &truth_f, &cfg, &sol) == MFNS_POSE_NO_FIX) {
            continue;
        }
        const pt_dpose_t est = pt_from_float(&sol.pose);
        /* increment error: C_est = exp(dtheta) C_true, r_est = r_true + dt */
        double m[3][3];
        for (int i = 0; i < 3; i++) {
            for (int j = 0; j < 3; j++) {
                m[i][j] = est.C[i][0] * truth->C[j][0] + est.C[i][1] * truth->C[j][1] + est.C[i][2] * truth->C[j][2];
            }
        }
        const double e[6] = {0.5 * (m[2][1] - m[1][2]), 0.5 * (m[0][2] - m[2][0]), 0.5 * (m[1][0] - m[0][1]),
                             est.r[0] - truth->r[0],     est.r[1] - truth->r[1],     est.r[2] - truth->r[2]};
        for (int i = 0; i < 6; i++) {
            sum[i] += e[i];
            for (int j = 0; j < 6; j++) {
                sum2[i][j] += e[i] * e[j];
            }
        }
        double pe[3], pt[3];
        pt_position_w(&est, pe);
        pt_position_w(truth, pt);
        for (int i = 0; i < 3; i++) {
            pos_s2[i] += (pe[i] - pt[i]) * (pe[i] - pt[i]);
        }
        /* ROS order: the errors est - true: position, then phi_w with
         * C_b_w(est) = exp(phi_w) C_b_w(true) */
        double mr[3][3];
        for (int i = 0; i < 3; i++) {
            for (int j = 0; j < 3; j++) {
                mr[i][j] = est.C[0][i] * truth->C[0][j] + est.C[1][i] * truth->C[1][j] + est.C[2][i] * truth->C[2][j];
            }
        }
        const double er[6] = {pe[0] - pt[0],
                              pe[1] - pt[1],
                              pe[2] - pt[2],
                              0.5 * (mr[2][1] - mr[1][2]),
                              0.5 * (mr[0][2] - mr[2][0]),
                              0.5 * (mr[1][0] - mr[0][1])};
        for (int i = 0; i < 6; i++) {
            for (int j = 0; j < 6; j++) {
                sum2r[i][j] += er[i] * er[j];
            }
        }
        mfns_euler_t ee;
        (void)mfns_m3_to_euler213(sol.pose.C_w_b, &ee);
        const double de[3] = {ee.roll - ref.euler_deg.roll * DEG, ee.pitch - ref.euler_deg.pitch * DEG,
                              ee.yaw - ref.euler_deg.yaw * DEG};
        for (int i = 0; i < 3; i++) {
            eul_s2[i] += de[i] * de[i];
        }
        used++;
    }
    assert_true(used >= trials * 99 / 100);
    double m2[6][6], m2r[6][6];
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < 6; j++) {
            m2[i][j] = sum2[i][j] / used;
            m2r[i][j] = sum2r[i][j] / used;
        }
    }
    double worst_diag, worst_off, nees, worst_diag_r, worst_off_r, nees_r;
    whiten(ref.cov, m2, &worst_diag, &worst_off, &nees);
    /* the ROS-order covariance of (r_wb_w, phi_w) describes the same errors */
    whiten(ref.cov_ros, m2r, &worst_diag_r, &worst_off_r, &nees_r);
    print_message("  ROS-order covariance: whitened |diag-1| %.3f, |offdiag| %.3f, mean NEES %.2f (6 expected)\n",
                  worst_diag_r, worst_off_r, nees_r);
    assert_true(worst_diag_r < 0.15);
    assert_true(worst_off_r < 0.15);
    assert_true(fabs(nees_r - 6.0) < 0.6);
    assert_true(fabs(nees - nees_r) < 1e-3 * nees);
    for (int i = 0; i < 3; i++) {
        assert_true(fabs(ref.cov_ros[i][i] - (double)ref.sigma_pos_mm[i] * ref.sigma_pos_mm[i]) <=
                    1e-4 * ref.cov_ros[i][i] + 1e-12);
    }
    double worst_axis = 0;
    for (int i = 0; i < 3; i++) {
        worst_axis = fmax(worst_axis, fabs(pos_s2[i] / used / ((double)ref.sigma_pos_mm[i] * ref.sigma_pos_mm[i]) - 1.0));
        const double se = ref.sigma_euler_deg[i] * DEG;
        worst_axis = fmax(worst_axis, fabs(eul_s2[i] / used / (se * se) - 1.0));
    }
    print_message("  n=%d sigma=%.1f px: predicted 1-sigma pos %.3f %.3f %.3f mm, euler %.4f %.4f %.4f deg; "
                  "whitened |diag-1| %.3f, |offdiag| %.3f, per-axis variance ratio off by %.3f\n",
                  n, sigma, ref.sigma_pos_mm[0], ref.sigma_pos_mm[1], ref.sigma_pos_mm[2], ref.sigma_euler_deg[0],
                  ref.sigma_euler_deg[1], ref.sigma_euler_deg[2], worst_diag, worst_off, worst_axis);
    assert_true(worst_diag < 0.15);
    assert_true(worst_off < 0.15);
    assert_true(worst_axis < 0.15);
    (void)sum;
}

static void test_covariance_monte_carlo_paper_geometry(void **state)
{
    (void)state;
    const mfns_rig_t rig = pt_paper_rig();
    mfns_beacon_map_t map = pt_paper_map();
    /* pixel noise only here: the map's survey error is modelled (and tested) below */
    for (int b = 0; b < map.count; b++) {
        map.beacon[b].sigma_mm = 0.0f;
    }
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 104);
    /* The paper's turntable poses with four beacons in view (yaw 30 and 260
     * deg, docs/system.md §6), and two closer poses with more beacons in view. */
    const double yaws[2] = {30, 260};
    for (int k = 0; k < 2; k++) {
        const double w[3] = {0, 0, -yaws[k] * DEG};
        double c[3][3];
        pt_rot_exp(w, c);
        const double zero[3] = {0, 0, 0};
        const pt_dpose_t truth = pt_pose(c, zero);
        monte_carlo(&rig, &map, &truth, 0.1, 1000, &rng);
        monte_carlo(&rig, &map, &truth, 0.3, 1000, &rng);
    }
    for (int k = 0; k < 2; k++) {
        pt_dpose_t truth;
        assert_true(pt_random_visible_pose(&rig, &map, 150, 5, 200000, &rng, &truth) >= 5);
        monte_carlo(&rig, &map, &truth, 0.1, 1000, &rng);
        monte_carlo(&rig, &map, &truth, 0.3, 1000, &rng);
    }
}

/* ---- per-observation covariance, survey and calibration terms (issue 12) */

/* The ROS-order error (r_wb_w mm, phi_w rad) of est against truth (pose.h). */
static void ros_error(const pt_dpose_t *est, const pt_dpose_t *truth, double er[6])
{
    double pe[3], pt[3], mr[3][3];
    pt_position_w(est, pe);
    pt_position_w(truth, pt);
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            mr[i][j] = est->C[0][i] * truth->C[0][j] + est->C[1][i] * truth->C[1][j] + est->C[2][i] * truth->C[2][j];
        }
    }
    er[0] = pe[0] - pt[0];
    er[1] = pe[1] - pt[1];
    er[2] = pe[2] - pt[2];
    er[3] = 0.5 * (mr[2][1] - mr[1][2]);
    er[4] = 0.5 * (mr[0][2] - mr[2][0]);
    er[5] = 0.5 * (mr[1][0] - mr[0][1]);
}

/* Cholesky (lower) of an n x n SPD matrix in double; false when not SPD. */
static bool dchol(int n, const double *a, double *l)
{
    for (int i = 0; i < n * n; i++) {
        l[i] = 0.0;
    }
    for (int j = 0; j < n; j++) {
        double d = a[j * n + j];
        for (int k = 0; k < j; k++) {
            d -= l[j * n + k] * l[j * n + k];
        }
        if (!(d > 0.0)) {
            return false;
        }
        l[j * n + j] = sqrt(d);
        for (int i = j + 1; i < n; i++) {
            double v = a[i * n + j];
            for (int k = 0; k < j; k++) {
                v -= l[i * n + k] * l[j * n + k];
            }
            l[i * n + j] = v / l[j * n + j];
        }
    }
    return true;
}

/* e^T P^-1 e with P the solution's ROS covariance. */
static double nees6(const float p[6][6], const double e[6])
{
    double a[36], l[36];
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < 6; j++) {
            a[i * 6 + j] = p[i][j];
        }
    }
    assert_true(dchol(6, a, l));
    double y[6] = {0}, s = 0.0;
    for (int i = 0; i < 6; i++) {
        double v = e[i];
        for (int k = 0; k < i; k++) {
            v -= l[i * 6 + k] * y[k];
        }
        y[i] = v / l[i * 6 + i];
        s += y[i] * y[i];
    }
    return s;
}

/* A pose with a dense map around it: nine beacons per camera, 0.5-1.5 m. */
static void dense_scene(uint64_t seed, pt_dpose_t *truth, mfns_beacon_map_t *map)
{
    const mfns_rig_t rig = pt_paper_rig();
    mfns_rng_t rng;
    mfns_rng_seed(&rng, seed);
    *truth = pt_random_pose(&rng, 200);
    const int per_cam[3] = {3, 3, 3};
    *map = pt_dense_map(&rig, truth, per_cam, 500, 1500, &rng);
}

/* Heteroscedastic, correlated centroid noise: each observation its own 2x2
 * covariance (sigmas 0.03-0.5 px, correlation -0.8..0.8) in cov_px2; the
 * weighted solve's ROS covariance whitens the errors (mean NEES 6), and its
 * errors are smaller than those of the solve that ignores the per-blob
 * covariances (one table-wide sigma, the code before issue 12). */
static void test_heteroscedastic_noise_nees(void **state)
{
    (void)state;
    const mfns_rig_t rig = pt_paper_rig();
    pt_dpose_t truth;
    mfns_beacon_map_t map;
    dense_scene(901, &truth, &map);
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 902);
    mfns_obs_frame_t clean;
    mfns_pose_assoc_t assoc;
    const int n = pt_make_frame(&rig, &map, &truth, 0.0, &rng, &clean, &assoc);
    assert_true(n >= 8);
    /* fixed per-observation covariances */
    double lc[MFNS_NUM_CAMERAS][MFNS_MAX_OBS_PER_CAMERA][3];
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        for (int i = 0; i < clean.count[c]; i++) {
            const double su = exp(mfns_rng_range(&rng, log(0.03), log(0.5)));
            const double sv = exp(mfns_rng_range(&rng, log(0.03), log(0.5)));
            const double rho = mfns_rng_range(&rng, -0.8, 0.8);
            mfns_obs_t *o = &clean.obs[c][i];
            o->cov_px2[0] = (float)(su * su);
            o->cov_px2[1] = (float)(rho * su * sv);
            o->cov_px2[2] = (float)(sv * sv);
            lc[c][i][0] = su; /* L = [[su, 0], [rho sv, sv sqrt(1 - rho^2)]] */
            lc[c][i][1] = rho * sv;
            lc[c][i][2] = sv * sqrt(1.0 - rho * rho);
        }
    }
    mfns_pose_config_t cfg = pt_config(1e-3); /* a negligible floor: R = the centroid's */
    mfns_pose_config_t flat = pt_config(0.25); /* the old solve: one sigma, covariances ignored */
    const mfns_pose_t t0 = pt_to_float(&truth);
    const int trials = 600;
    double nees = 0.0, e2w = 0.0, e2f = 0.0, rw2 = 0.0;
    int used = 0;
    for (int t = 0; t < trials; t++) {
        mfns_obs_frame_t f = clean, g;
        for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
            for (int i = 0; i < f.count[c]; i++) {
                const double z0 = mfns_rng_normal(&rng), z1 = mfns_rng_normal(&rng);
                f.obs[c][i].u += (float)(lc[c][i][0] * z0);
                f.obs[c][i].v += (float)(lc[c][i][1] * z0 + lc[c][i][2] * z1);
            }
        }
        g = f;
        for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
            for (int i = 0; i < g.count[c]; i++) {
                g.obs[c][i].cov_px2[0] = g.obs[c][i].cov_px2[1] = g.obs[c][i].cov_px2[2] = 0.0f;
            }
        }
        mfns_pose_solution_t sw, sf;
        if (mfns_pose_refine(&rig, &map, &f, &assoc, &t0, &cfg, &sw) == MFNS_POSE_NO_FIX ||
            mfns_pose_refine(&rig, &map, &g, &assoc, &t0, &flat, &sf) == MFNS_POSE_NO_FIX) {
            continue;
        }
        const pt_dpose_t ew = pt_from_float(&sw.pose), ef = pt_from_float(&sf.pose);
        double er[6], ef6[6];
        ros_error(&ew, &truth, er);
        ros_error(&ef, &truth, ef6);
        nees += nees6(sw.cov_ros, er);
        e2w += er[0] * er[0] + er[1] * er[1] + er[2] * er[2];
        e2f += ef6[0] * ef6[0] + ef6[1] * ef6[1] + ef6[2] * ef6[2];
        rw2 += (double)sw.residual_rms_sigma * sw.residual_rms_sigma;
        used++;
    }
    assert_true(used >= trials * 99 / 100);
    nees /= used;
    print_message("  heteroscedastic: n=%d mean NEES %.2f (6 expected), RMS position error weighted %.4f mm vs "
                  "one sigma %.4f mm, whitened residual mean square %.3f ((2n-6)/2n = %.3f expected)\n",
                  n, nees, sqrt(e2w / used), sqrt(e2f / used), rw2 / used, (2.0 * n - 6.0) / (2.0 * n));
    assert_true(fabs(nees - 6.0) < 0.6);
    assert_true(e2w < 0.9 * e2f);
    assert_true(fabs(rw2 / used - (2.0 * n - 6.0) / (2.0 * n)) < 0.1);
}

/* Homoscedastic data: a per-blob covariance sigma^2 I (floor negligible)
 * gives the same pose and covariance as the table's sigma alone: the
 * estimator is the one before issue 12 on such data. */
/* A centroid covariance that is not one (negative variance, |cov uv| above
 * sqrt(var u var v), not finite) is bad input, never weighted. */
static void test_bad_centroid_covariance(void **state)
{
    (void)state;
    const mfns_rig_t rig = pt_paper_rig();
    pt_dpose_t truth;
    mfns_beacon_map_t map;
    dense_scene(941, &truth, &map);
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 942);
    mfns_obs_frame_t f;
    mfns_pose_assoc_t assoc;
    (void)pt_make_frame(&rig, &map, &truth, 0.1, &rng, &f, &assoc);
    const mfns_pose_config_t cfg = pt_config(0.1);
    const mfns_pose_t t0 = pt_to_float(&truth);
    const float bad[4][3] = {{-0.01f, 0.0f, 0.01f}, {0.01f, 0.0f, -0.01f}, {0.01f, 0.011f, 0.01f}, {NAN, 0.0f, 0.01f}};
    mfns_pose_solution_t sol;
    for (int k = 0; k < 4; k++) {
        mfns_obs_frame_t g = f;
        for (int j = 0; j < 3; j++) {
            g.obs[1][0].cov_px2[j] = bad[k][j];
        }
        assert_int_equal(mfns_pose_refine(&rig, &map, &g, &assoc, &t0, &cfg, &sol), MFNS_POSE_NO_FIX);
        assert_int_equal(sol.reason, MFNS_POSE_R_BAD_ARG);
        assert_int_equal(mfns_pose_track(&rig, &map, &g, &t0, &cfg, &sol), MFNS_POSE_NO_FIX);
        assert_int_equal(sol.reason, MFNS_POSE_R_BAD_ARG);
    }
    /* the edge: exactly correlated (rank 1) is a covariance; the floor keeps R definite */
    mfns_obs_frame_t g = f;
    g.obs[1][0].cov_px2[0] = g.obs[1][0].cov_px2[1] = g.obs[1][0].cov_px2[2] = 0.01f;
    assert_int_not_equal(mfns_pose_refine(&rig, &map, &g, &assoc, &t0, &cfg, &sol), MFNS_POSE_NO_FIX);
}

static void test_homoscedastic_unchanged(void **state)
{
    (void)state;
    const mfns_rig_t rig = pt_paper_rig();
    pt_dpose_t truth;
    mfns_beacon_map_t map;
    dense_scene(911, &truth, &map);
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 912);
    const mfns_pose_config_t table = pt_config(0.2), blob = pt_config(1e-4);
    const mfns_pose_t t0 = pt_to_float(&truth);
    for (int t = 0; t < 50; t++) {
        mfns_obs_frame_t f, g;
        mfns_pose_assoc_t assoc;
        (void)pt_make_frame(&rig, &map, &truth, 0.2, &rng, &f, &assoc);
        g = f;
        for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
            for (int i = 0; i < g.count[c]; i++) {
                g.obs[c][i].cov_px2[0] = g.obs[c][i].cov_px2[2] = 0.04f;
            }
        }
        mfns_pose_solution_t a, b;
        assert_int_not_equal(mfns_pose_refine(&rig, &map, &f, &assoc, &t0, &table, &a), MFNS_POSE_NO_FIX);
        assert_int_not_equal(mfns_pose_refine(&rig, &map, &g, &assoc, &t0, &blob, &b), MFNS_POSE_NO_FIX);
        const pt_dpose_t ea = pt_from_float(&a.pose), eb = pt_from_float(&b.pose);
        assert_true(pt_pos_err(&ea, &eb) < 1e-3 * (a.sigma_pos_mm[0] + a.sigma_pos_mm[1] + a.sigma_pos_mm[2]) + 1e-4);
        for (int i = 0; i < 3; i++) {
            assert_true(fabsf(a.sigma_pos_mm[i] - b.sigma_pos_mm[i]) < 1e-3f * a.sigma_pos_mm[i]);
        }
        assert_true(fabsf(a.residual_rms_sigma - b.residual_rms_sigma) < 1e-3f * a.residual_rms_sigma + 1e-6f);
    }
}

/* Beacons displaced by their survey sigma (a new survey error every trial):
 * the mean NEES is 6 only with the survey term in R. */
static void test_survey_error_nees(void **state)
{
    (void)state;
    const mfns_rig_t rig = pt_paper_rig();
    pt_dpose_t truth;
    mfns_beacon_map_t map;
    dense_scene(921, &truth, &map);
    const float sigma_b = 0.4f;
    for (int b = 0; b < map.count; b++) {
        map.beacon[b].sigma_mm = sigma_b;
    }
    mfns_beacon_map_t blind = map; /* the same map claiming an exact survey */
    for (int b = 0; b < blind.count; b++) {
        blind.beacon[b].sigma_mm = 0.0f;
    }
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 922);
    const mfns_pose_config_t cfg = pt_config(0.1);
    /* the blind solve sees residuals of ~10 of its sigmas: plain least
     * squares (no Huber, no gate) so that it converges like the other */
    mfns_pose_config_t cfg_blind = pt_config(0.1);
    cfg_blind.s.huber_k = 0.0f;
    cfg_blind.s.outlier_gate_sigma = 0.0f;
    cfg_blind.s.max_iterations = 100;
    const mfns_pose_t t0 = pt_to_float(&truth);
    const int trials = 600;
    double nees = 0.0, nees_blind = 0.0;
    int used = 0;
    for (int t = 0; t < trials; t++) {
        mfns_beacon_map_t real = map;
        for (int b = 0; b < real.count; b++) {
            real.beacon[b].p_w.x += (float)(sigma_b * mfns_rng_normal(&rng));
            real.beacon[b].p_w.y += (float)(sigma_b * mfns_rng_normal(&rng));
            real.beacon[b].p_w.z += (float)(sigma_b * mfns_rng_normal(&rng));
        }
        mfns_obs_frame_t f;
        mfns_pose_assoc_t assoc;
        (void)pt_make_frame(&rig, &real, &truth, 0.1, &rng, &f, &assoc);
        mfns_pose_solution_t s, sb;
        if (mfns_pose_refine(&rig, &map, &f, &assoc, &t0, &cfg, &s) == MFNS_POSE_NO_FIX ||
            mfns_pose_refine(&rig, &blind, &f, &assoc, &t0, &cfg_blind, &sb) == MFNS_POSE_NO_FIX) {
            continue;
        }
        const pt_dpose_t e = pt_from_float(&s.pose), eb = pt_from_float(&sb.pose);
        double er[6];
        ros_error(&e, &truth, er);
        nees += nees6(s.cov_ros, er);
        ros_error(&eb, &truth, er);
        nees_blind += nees6(sb.cov_ros, er);
        used++;
    }
    assert_true(used >= trials * 99 / 100);
    nees /= used;
    nees_blind /= used;
    print_message("  survey error 0.4 mm: mean NEES %.2f with the survey term, %.2f without (6 expected)\n", nees,
                  nees_blind);
    assert_true(fabs(nees - 6.0) < 0.7);
    assert_true(nees_blind > 12.0);
}

/* The rig perturbed by a draw from a known calibration covariance (a new
 * draw every trial; the solver keeps the nominal rig, which is the estimate:
 * truth = estimate - error): mean NEES 6 only with the calibration term. */
static void test_calibration_error_nees(void **state)
{
    (void)state;
    const mfns_rig_t rig = pt_paper_rig();
    pt_dpose_t truth;
    mfns_beacon_map_t map;
    dense_scene(931, &truth, &map);
    static const double sd[MFNS_CALIB_PARAMS_PER_CAMERA] = {0.8,  0.8,  0.5,  0.5,  3e-4, 3e-4, 3e-5, 3e-5,
                                                            3e-4, 2e-4, 2e-4, 2e-4, 0.2,  0.2,  0.2};
    static double cov[MFNS_CALIB_PARAMS * MFNS_CALIB_PARAMS], l[MFNS_CALIB_PARAMS * MFNS_CALIB_PARAMS];
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 932);
    const int np = MFNS_CALIB_PARAMS;
    /* correlated within and across cameras: 0.6 diag + rank-3 part */
    double b[MFNS_CALIB_PARAMS][3];
    for (int i = 0; i < np; i++) {
        for (int k = 0; k < 3; k++) {
            b[i][k] = mfns_rng_range(&rng, -0.6, 0.6) * sd[i % MFNS_CALIB_PARAMS_PER_CAMERA];
        }
    }
    static mfns_calib_cov_t cc;
    cc.present = 1;
    for (int i = 0; i < np; i++) {
        for (int j = 0; j < np; j++) {
            const double s = sd[i % MFNS_CALIB_PARAMS_PER_CAMERA];
            cov[i * np + j] = b[i][0] * b[j][0] + b[i][1] * b[j][1] + b[i][2] * b[j][2] + (i == j ? 0.6 * s * s : 0.0);
            cc.cov[i][j] = (float)cov[i * np + j];
        }
    }
    assert_true(dchol(np, cov, l));
    mfns_pose_config_t with = pt_config(0.1), without = pt_config(0.1);
    with.calib_cov = &cc;
    const mfns_pose_t t0 = pt_to_float(&truth);
    const int trials = 600;
    double nees = 0.0, nees_without = 0.0, ratio = 0.0;
    int used = 0;
    for (int t = 0; t < trials; t++) {
        double z[MFNS_CALIB_PARAMS], d[MFNS_CALIB_PARAMS];
        for (int i = 0; i < np; i++) {
            z[i] = mfns_rng_normal(&rng);
        }
        for (int i = 0; i < np; i++) {
            d[i] = 0.0;
            for (int k = 0; k <= i; k++) {
                d[i] += l[i * np + k] * z[k];
            }
        }
        mfns_rig_t real = rig; /* truth = estimate - error */
        for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
            const double *e = &d[c * MFNS_CALIB_PARAMS_PER_CAMERA];
            mfns_camera_t *k = &real.cam[c];
            k->k.fx -= (float)e[MFNS_CALIB_FX];
            k->k.fy -= (float)e[MFNS_CALIB_FY];
            k->k.cx -= (float)e[MFNS_CALIB_CX];
            k->k.cy -= (float)e[MFNS_CALIB_CY];
            for (int q = 0; q < 5; q++) {
                k->k.dist[q] -= (float)e[MFNS_CALIB_K1 + q];
            }
            /* C_k_b(est) = exp([theta]) C_k_b(true): C_true = exp(-[theta]) C_est */
            const double w[3] = {-e[MFNS_CALIB_THETA_X], -e[MFNS_CALIB_THETA_Y], -e[MFNS_CALIB_THETA_Z]};
            double rm[3][3];
            pt_rot_exp(w, rm);
            mfns_m3_t cn;
            for (int i = 0; i < 3; i++) {
                for (int j = 0; j < 3; j++) {
                    cn.m[i][j] = (float)(rm[i][0] * rig.cam[c].C_k_b.m[0][j] + rm[i][1] * rig.cam[c].C_k_b.m[1][j] +
                                         rm[i][2] * rig.cam[c].C_k_b.m[2][j]);
                }
            }
            k->C_k_b = cn;
            k->r_bk_b.x -= (float)e[MFNS_CALIB_R_X];
            k->r_bk_b.y -= (float)e[MFNS_CALIB_R_Y];
            k->r_bk_b.z -= (float)e[MFNS_CALIB_R_Z];
        }
        mfns_obs_frame_t f;
        mfns_pose_assoc_t assoc;
        (void)pt_make_frame(&real, &map, &truth, 0.1, &rng, &f, &assoc);
        mfns_pose_solution_t s, s0;
        if (mfns_pose_refine(&rig, &map, &f, &assoc, &t0, &with, &s) == MFNS_POSE_NO_FIX ||
            mfns_pose_refine(&rig, &map, &f, &assoc, &t0, &without, &s0) == MFNS_POSE_NO_FIX) {
            continue;
        }
        const pt_dpose_t e = pt_from_float(&s.pose);
        double er[6];
        ros_error(&e, &truth, er);
        nees += nees6(s.cov_ros, er);
        nees_without += nees6(s0.cov_ros, er);
        ratio += (double)(s.sigma_pos_mm[0] / s0.sigma_pos_mm[0]);
        /* the calibration term changes the covariance only, not the pose */
        const pt_dpose_t e0 = pt_from_float(&s0.pose);
        assert_true(pt_pos_err(&e, &e0) == 0.0 && pt_rot_err(e.C, e0.C) == 0.0);
        used++;
    }
    assert_true(used >= trials * 95 / 100);
    nees /= used;
    nees_without /= used;
    print_message("  calibration error: mean NEES %.2f with the calibration term, %.2f without (6 expected); "
                  "sigma_x grows %.1fx\n", nees, nees_without, ratio / used);
    assert_true(fabs(nees - 6.0) < 0.9);
    assert_true(nees_without > 12.0);
    assert_true(ratio / used > 1.5);
}

/* The map datum (nav_settings.h mfns_map_datum_t): the table's map is the true one
 * moved rigidly, p(table) = R(dth) (p - c) + c + dt, drawn from Sigma_d every
 * trial. The fix moves with the map: with the datum term the mean NEES is 6,
 * without it far above; the term changes the covariance only, and by exactly
 * [I, -[r_wb_w - c]x; 0, I] Sigma_d [..]^T in ROS order (position, world
 * rotation), checked in double. */
static void test_map_datum_term(void **state)
{
    (void)state;
    const mfns_rig_t rig = pt_paper_rig();
    pt_dpose_t truth;
    mfns_beacon_map_t map;
    dense_scene(941, &truth, &map);
    static const double sd[6] = {0.4, 0.3, 0.5, 4e-4, 3e-4, 5e-4}; /* mm, rad */
    double cov[36], l[36];
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < 6; j++) {
            cov[i * 6 + j] = i == j ? sd[i] * sd[i] : 0.0;
        }
    }
    cov[0 * 6 + 5] = cov[5 * 6 + 0] = 0.6 * sd[0] * sd[5]; /* a shift correlated with a turn */
    cov[1 * 6 + 2] = cov[2 * 6 + 1] = -0.4 * sd[1] * sd[2];
    assert_true(dchol(6, cov, l));
    static mfns_map_datum_t datum;
    datum.present = 1;
    const double c[3] = {800.0, -1200.0, 300.0};
    datum.c_w = mfns_v3((float)c[0], (float)c[1], (float)c[2]);
    for (int i = 0; i < 6; i++) {
        for (int j = 0; j < 6; j++) {
            datum.cov[i][j] = (float)cov[i * 6 + j];
        }
    }
    mfns_pose_config_t with = pt_config(0.1), without = pt_config(0.1);
    with.datum = &datum;
    const mfns_pose_t t0 = pt_to_float(&truth);
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 942);
    const int trials = 500;
    double nees = 0.0, nees_without = 0.0;
    int used = 0;
    for (int t = 0; t < trials; t++) {
        double z[6], d[6];
        for (int i = 0; i < 6; i++) {
            z[i] = mfns_rng_normal(&rng);
        }
        for (int i = 0; i < 6; i++) {
            d[i] = 0.0;
            for (int k = 0; k <= i; k++) {
                d[i] += l[i * 6 + k] * z[k];
            }
        }
        double rm[3][3];
        pt_rot_exp(&d[3], rm);
        static mfns_beacon_map_t moved;
        moved = map;
        for (int b = 0; b < map.count; b++) {
            const mfns_v3_t p = map.beacon[b].p_w;
            const double q[3] = {p.x - c[0], p.y - c[1], p.z - c[2]};
            double o[3];
            for (int i = 0; i < 3; i++) {
                o[i] = rm[i][0] * q[0] + rm[i][1] * q[1] + rm[i][2] * q[2] + c[i] + d[i];
            }
            moved.beacon[b].p_w = mfns_v3((float)o[0], (float)o[1], (float)o[2]);
        }
        mfns_obs_frame_t f;
        mfns_pose_assoc_t assoc;
        (void)pt_make_frame(&rig, &map, &truth, 0.1, &rng, &f, &assoc); /* seen from the true map */
        mfns_pose_solution_t s, s0;
        if (mfns_pose_refine(&rig, &moved, &f, &assoc, &t0, &with, &s) == MFNS_POSE_NO_FIX ||
            mfns_pose_refine(&rig, &moved, &f, &assoc, &t0, &without, &s0) == MFNS_POSE_NO_FIX) {
            continue;
        }
        const pt_dpose_t e = pt_from_float(&s.pose), e0 = pt_from_float(&s0.pose);
        assert_true(pt_pos_err(&e, &e0) == 0.0 && pt_rot_err(e.C, e0.C) == 0.0);
        double er[6];
        ros_error(&e, &truth, er);
        nees += nees6(s.cov_ros, er);
        nees_without += nees6(s0.cov_ros, er);
        if (t == 0) {
            /* the term itself: G_ros Sigma_d G_ros^T with G_ros = [I, -[r - c]x; 0, I] */
            double r[3], g[6][6];
            pt_position_w(&e, r);
            const double v[3] = {r[0] - c[0], r[1] - c[1], r[2] - c[2]};
            const double sk[3][3] = {{0.0, -v[2], v[1]}, {v[2], 0.0, -v[0]}, {-v[1], v[0], 0.0}};
            for (int i = 0; i < 6; i++) {
                for (int j = 0; j < 6; j++) {
                    g[i][j] = (i == j) ? 1.0 : 0.0;
                    if (i < 3 && j >= 3) {
                        g[i][j] = -sk[i][j - 3];
                    }
                }
            }
            for (int i = 0; i < 6; i++) {
                for (int j = 0; j < 6; j++) {
                    double want = 0.0;
                    for (int p = 0; p < 6; p++) {
                        for (int q = 0; q < 6; q++) {
                            want += g[i][p] * cov[p * 6 + q] * g[j][q];
                        }
                    }
                    const double got = (double)s.cov_ros[i][j] - (double)s0.cov_ros[i][j];
                    const double scale = sqrt((double)s.cov_ros[i][i] * (double)s.cov_ros[j][j]);
                    assert_true(fabs(got - want) <= 2e-4 * scale + 1e-12);
                }
            }
        }
        used++;
    }
    assert_true(used >= trials * 95 / 100);
    nees /= used;
    nees_without /= used;
    print_message("  map datum: mean NEES %.2f with the datum term, %.2f without (6 expected)\n", nees,
                  nees_without);
    assert_true(fabs(nees - 6.0) < 0.9);
    assert_true(nees_without > 30.0);
}

static void frame_for(const mfns_rig_t *rig, const int per_cam[3], double sigma, uint64_t seed, pt_dpose_t *truth,
                      mfns_beacon_map_t *map, mfns_obs_frame_t *frame, mfns_pose_assoc_t *assoc)
{
    mfns_rng_t rng;
    mfns_rng_seed(&rng, seed);
    *truth = pt_random_pose(&rng, 200);
    *map = pt_dense_map(rig, truth, per_cam, 500, 1500, &rng);
    (void)pt_make_frame(rig, map, truth, sigma, &rng, frame, assoc);
}

static void test_status_codes(void **state)
{
    (void)state;
    const mfns_rig_t rig = pt_paper_rig();
    pt_dpose_t truth;
    mfns_beacon_map_t map;
    mfns_obs_frame_t frame;
    mfns_pose_assoc_t assoc;
    mfns_pose_solution_t sol;
    mfns_pose_config_t cfg = pt_config(0.1);
    const int all[3] = {2, 2, 2};
    frame_for(&rig, all, 0.1, 201, &truth, &map, &frame, &assoc);
    const mfns_pose_t tf = pt_to_float(&truth);

    assert_int_equal(mfns_pose_refine(&rig, &map, &frame, &assoc, &tf, &cfg, &sol), MFNS_POSE_OK);
    assert_int_equal(sol.reason, MFNS_POSE_R_NONE);
    assert_int_equal(sol.cameras_used, 3);
    assert_true(sol.sigma_pos_mm[0] > 0 && sol.sigma_euler_deg[2] > 0);

    /* bad arguments: NULLs, counts above the maxima, bad index, NaN */
    assert_int_equal(mfns_pose_refine(NULL, &map, &frame, &assoc, &tf, &cfg, &sol), MFNS_POSE_NO_FIX);
    assert_int_equal(sol.reason, MFNS_POSE_R_BAD_ARG);
    assert_int_equal(mfns_pose_refine(&rig, &map, &frame, &assoc, &tf, &cfg, NULL), MFNS_POSE_NO_FIX);
    mfns_obs_frame_t bad = frame;
    bad.count[1] = MFNS_MAX_OBS_PER_CAMERA + 1;
    assert_int_equal(mfns_pose_refine(&rig, &map, &bad, &assoc, &tf, &cfg, &sol), MFNS_POSE_NO_FIX);
    assert_int_equal(sol.reason, MFNS_POSE_R_BAD_ARG);
    bad = frame;
    bad.obs[0][0].u = NAN;
    assert_int_equal(mfns_pose_refine(&rig, &map, &bad, &assoc, &tf, &cfg, &sol), MFNS_POSE_NO_FIX);
    assert_int_equal(sol.reason, MFNS_POSE_R_BAD_ARG);
    mfns_pose_assoc_t badassoc = assoc;
    badassoc.beacon[2][0] = (int16_t)map.count;
    assert_int_equal(mfns_pose_refine(&rig, &map, &frame, &badassoc, &tf, &cfg, &sol), MFNS_POSE_NO_FIX);
    assert_int_equal(sol.reason, MFNS_POSE_R_BAD_ARG);
    mfns_pose_config_t badcfg = cfg;
    badcfg.sigma_px = 0.0f;
    assert_int_equal(mfns_pose_refine(&rig, &map, &frame, &assoc, &tf, &badcfg, &sol), MFNS_POSE_NO_FIX);
    assert_int_equal(sol.reason, MFNS_POSE_R_BAD_ARG);
    mfns_pose_t badpose = tf;
    badpose.C_w_b.m[0][0] = 3.0f;
    assert_int_equal(mfns_pose_refine(&rig, &map, &frame, &assoc, &badpose, &cfg, &sol), MFNS_POSE_NO_FIX);
    assert_int_equal(sol.reason, MFNS_POSE_R_BAD_ARG);

    /* too few beacons: two */
    mfns_pose_assoc_t two = assoc;
    for (int c = 0; c < 3; c++) {
        for (int i = 0; i < MFNS_MAX_OBS_PER_CAMERA; i++) {
            two.beacon[c][i] = (c == 0 && i < 2) ? assoc.beacon[c][i] : MFNS_POSE_NO_BEACON;
        }
    }
    assert_int_equal(mfns_pose_refine(&rig, &map, &frame, &two, &tf, &cfg, &sol), MFNS_POSE_NO_FIX);
    assert_int_equal(sol.reason, MFNS_POSE_R_TOO_FEW);
    /* the same beacon twice does not count twice */
    two.beacon[1][0] = assoc.beacon[0][0];
    assert_int_equal(mfns_pose_refine(&rig, &map, &frame, &two, &tf, &cfg, &sol), MFNS_POSE_NO_FIX);
    assert_int_equal(sol.reason, MFNS_POSE_R_TOO_FEW);

    /* minimal: exactly three beacons gives a pose, never usable (issue 23:
     * no redundancy to check a fault): NO_FIX MINIMAL, the pose kept */
    const int three[3] = {1, 1, 1};
    frame_for(&rig, three, 0.0, 202, &truth, &map, &frame, &assoc);
    const mfns_pose_t t3 = pt_to_float(&truth);
    assert_int_equal(mfns_pose_refine(&rig, &map, &frame, &assoc, &t3, &cfg, &sol), MFNS_POSE_NO_FIX);
    assert_int_equal(sol.reason, MFNS_POSE_R_MINIMAL);
    assert_true(sol.beacons_used == 3 && sol.sigma_pos_mm[0] > 0.0f);

    /* a camera with nothing: DEGRADED */
    const int two_cams[3] = {3, 0, 2};
    frame_for(&rig, two_cams, 0.1, 203, &truth, &map, &frame, &assoc);
    const mfns_pose_t t2 = pt_to_float(&truth);
    assert_int_equal(mfns_pose_refine(&rig, &map, &frame, &assoc, &t2, &cfg, &sol), MFNS_POSE_DEGRADED);
    assert_int_equal(sol.reason, MFNS_POSE_R_CAMERA_UNUSED);
    assert_int_equal(sol.cameras_used, 2);

    /* an outlier (a reflection taken for a beacon): gated, marked, DEGRADED, pose still good */
    const int many[3] = {3, 3, 3};
    frame_for(&rig, many, 0.1, 204, &truth, &map, &frame, &assoc);
    frame.obs[1][1].u += 25.0f;
    frame.obs[1][1].v -= 10.0f;
    const mfns_pose_t t9 = pt_to_float(&truth);
    assert_int_equal(mfns_pose_refine(&rig, &map, &frame, &assoc, &t9, &cfg, &sol), MFNS_POSE_DEGRADED);
    assert_int_equal(sol.reason, MFNS_POSE_R_OUTLIERS);
    assert_int_equal(sol.outliers, 1);
    assert_int_equal(sol.inlier[1][1], 0);
    assert_int_equal(sol.inlier[1][0], 1);
    assert_int_equal(sol.beacons_used, 8);
    const pt_dpose_t est = pt_from_float(&sol.pose);
    assert_true(pt_pos_err(&est, &truth) < 5 * sol.sigma_pos_mm[0] + 5 * sol.sigma_pos_mm[1] + 5 * sol.sigma_pos_mm[2]);

    /* residual too high: noise far above the table's sigma, gate off */
    frame_for(&rig, many, 3.0, 205, &truth, &map, &frame, &assoc);
    cfg = pt_config(0.1);
    cfg.s.outlier_gate_sigma = 0.0f;
    cfg.s.max_residual_rms_sigma = 10.0f; /* 1 px at 0.1 px (the dense map has no survey error) */
    cfg.s.max_iterations = 50; /* converge at 3 px of noise: the residual must decide */
    const mfns_pose_t t10 = pt_to_float(&truth);
    assert_int_equal(mfns_pose_refine(&rig, &map, &frame, &assoc, &t10, &cfg, &sol), MFNS_POSE_NO_FIX);
    assert_int_equal(sol.reason, MFNS_POSE_R_RESIDUAL_HIGH);
    assert_true(sol.residual_rms_sigma > 10.0f);
    assert_true(fabsf(sol.residual_rms_sigma - sol.residual_rms_px / 0.1f) < 1e-3f * sol.residual_rms_sigma);

    /* not converged: one iteration from 30 deg away */
    frame_for(&rig, many, 0.1, 206, &truth, &map, &frame, &assoc);
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 207);
    const pt_dpose_t far = perturbed(&truth, 30 * DEG, 200, &rng);
    const mfns_pose_t ff = pt_to_float(&far);
    cfg = pt_config(0.1);
    cfg.s.max_iterations = 1;
    assert_int_equal(mfns_pose_refine(&rig, &map, &frame, &assoc, &ff, &cfg, &sol), MFNS_POSE_NO_FIX);
    assert_int_equal(sol.reason, MFNS_POSE_R_NOT_CONVERGED);
    assert_int_equal(sol.iterations, 1);
}

static void test_singular_geometry_is_reported(void **state)
{
    (void)state;
    const mfns_rig_t rig = pt_paper_rig();
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 301);
    const pt_dpose_t truth = pt_random_pose(&rng, 100);
    /* four beacons on one line through camera Z's field of view: rotation
     * about that line (with the matching translation) is unobservable */
    const int zonly[3] = {0, 0, 2};
    mfns_beacon_map_t map = pt_dense_map(&rig, &truth, zonly, 600, 1200, &rng);
    const mfns_v3_t a = map.beacon[0].p_w, d = mfns_v3_sub(map.beacon[1].p_w, map.beacon[0].p_w);
    map.count = 4;
    for (int i = 0; i < 4; i++) {
        map.beacon[i].p_w = mfns_v3_add(a, mfns_v3_scale(d, (float)i / 3.0f));
    }
    mfns_obs_frame_t frame;
    mfns_pose_assoc_t assoc;
    assert_int_equal(pt_make_frame(&rig, &map, &truth, 0.0, &rng, &frame, &assoc), 4);
    const mfns_pose_t tf = pt_to_float(&truth);
    mfns_pose_config_t cfg = pt_config(0.1);
    mfns_pose_solution_t sol;
    assert_int_equal(mfns_pose_refine(&rig, &map, &frame, &assoc, &tf, &cfg, &sol), MFNS_POSE_NO_FIX);
    assert_int_equal(sol.reason, MFNS_POSE_R_SINGULAR);
    for (int i = 0; i < 6; i++) {
        assert_true(sol.cov[i][i] == 0.0f); /* never a made-up covariance */
    }
}

static void test_paper_mode(void **state)
{
    (void)state;
    const mfns_rig_t rig = pt_paper_rig();
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 401);
    double ml_s2 = 0, paper_s2 = 0;
    for (int t = 0; t < 100; t++) {
        const pt_dpose_t truth = pt_random_pose(&rng, 300);
        const int per_cam[3] = {2, 1, 2};
        const mfns_beacon_map_t map = pt_dense_map(&rig, &truth, per_cam, 400, 1500, &rng);
        mfns_obs_frame_t frame;
        mfns_pose_assoc_t assoc;
        (void)pt_make_frame(&rig, &map, &truth, 0.0, &rng, &frame, &assoc);
        const pt_dpose_t init = perturbed(&truth, 3 * DEG, 30, &rng);
        const mfns_pose_t init_f = pt_to_float(&init);
        mfns_pose_config_t cfg = pt_config(0.3);
        cfg.mode = MFNS_POSE_MODE_PAPER;
        mfns_pose_solution_t sol;
        /* noise-free: the algebraic and the ML error share the exact solution */
        assert_int_equal(mfns_pose_refine(&rig, &map, &frame, &assoc, &init_f, &cfg, &sol), MFNS_POSE_OK);
        pt_dpose_t est = pt_from_float(&sol.pose);
        assert_true(pt_pos_err(&est, &truth) < 0.01);
        /* noisy: both converge; ML is the better estimator on average */
        (void)pt_make_frame(&rig, &map, &truth, 0.3, &rng, &frame, &assoc);
        assert_int_equal(mfns_pose_refine(&rig, &map, &frame, &assoc, &init_f, &cfg, &sol), MFNS_POSE_OK);
        est = pt_from_float(&sol.pose);
        paper_s2 += pt_pos_err(&est, &truth) * pt_pos_err(&est, &truth);
        cfg.mode = MFNS_POSE_MODE_ML;
        assert_int_equal(mfns_pose_refine(&rig, &map, &frame, &assoc, &init_f, &cfg, &sol), MFNS_POSE_OK);
        est = pt_from_float(&sol.pose);
        ml_s2 += pt_pos_err(&est, &truth) * pt_pos_err(&est, &truth);
    }
    print_message("position RMS error at 0.3 px: ML %.3f mm, paper mode %.3f mm\n", sqrt(ml_s2 / 100),
                  sqrt(paper_s2 / 100));
    assert_true(ml_s2 <= paper_s2 * 1.05);
}

static void test_strerror_every_code(void **state)
{
    (void)state;
    for (int r = MFNS_POSE_R_NONE; r <= MFNS_POSE_R_TRACK_LOST; r++) {
        const char *s = mfns_pose_strerror((mfns_pose_reason_t)r);
        assert_non_null(s);
        assert_true(strlen(s) > 1);
        assert_true(strcmp(s, "unknown pose reason") != 0);
        for (int q = MFNS_POSE_R_NONE; q < r; q++) {
            assert_true(strcmp(s, mfns_pose_strerror((mfns_pose_reason_t)q)) != 0);
        }
    }
    assert_string_equal(mfns_pose_strerror((mfns_pose_reason_t)99), "unknown pose reason");
    assert_string_equal(mfns_pose_status_str(MFNS_POSE_OK), "ok");
    assert_string_equal(mfns_pose_status_str(MFNS_POSE_DEGRADED), "degraded");
    assert_string_equal(mfns_pose_status_str(MFNS_POSE_NO_FIX), "no fix");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_exact_recovery_noise_free),
        cmocka_unit_test(test_float_agrees_with_double_reference),
        cmocka_unit_test(test_converges_from_far),
        cmocka_unit_test(test_covariance_monte_carlo_paper_geometry),
        cmocka_unit_test(test_heteroscedastic_noise_nees),
        cmocka_unit_test(test_homoscedastic_unchanged),
        cmocka_unit_test(test_bad_centroid_covariance),
        cmocka_unit_test(test_survey_error_nees),
        cmocka_unit_test(test_calibration_error_nees),
        cmocka_unit_test(test_map_datum_term),
        cmocka_unit_test(test_status_codes),
        cmocka_unit_test(test_singular_geometry_is_reported),
        cmocka_unit_test(test_paper_mode),
        cmocka_unit_test(test_strerror_every_code),
    };
    return cmocka_run_group_tests_name("pose", tests, NULL, NULL);
}
