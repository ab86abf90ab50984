/* test_integrity.c -- fault detection and exclusion and the protection level
 * (firmware/nav/integrity/integrity.h): the quantile, a clean fix, a biased beacon, a
 * stale camera, fixes without redundancy, and the false-alarm rate and the
 * PL's bound over many fault-free noise draws. */
#include <math.h>
#include <string.h>

#include "firmware/nav/integrity/integrity.h"
#include "tests/unit/support/pose_testlib.h"
#include "tests/unit/support/testutil.h"
#include "math/units.h"

#define DEG (MFNS_PI / 180.0)

typedef struct {
    mfns_rig_t rig;
    mfns_beacon_map_t map;
    pt_dpose_t truth;
    mfns_obs_frame_t frame;
    mfns_pose_assoc_t assoc;
    mfns_pose_config_t cfg;
    mfns_pose_solution_t sol;
} scene_t;

static scene_t sc; /* large: static */

/* A scene with per_cam beacons per camera, noise sigma px, solved from the truth. */
static mfns_pose_status_t make_scene(const int per_cam[3], double sigma, uint64_t seed)
{
    mfns_rng_t rng;
    mfns_rng_seed(&rng, seed);
    sc.rig = pt_paper_rig();
    sc.truth = pt_random_pose(&rng, 200);
    sc.map = pt_dense_map(&sc.rig, &sc.truth, per_cam, 500, 1500, &rng);
    (void)pt_make_frame(&sc.rig, &sc.map, &sc.truth, sigma, &rng, &sc.frame, &sc.assoc);
    sc.cfg = pt_config(sigma);
    const mfns_pose_t t = pt_to_float(&sc.truth);
    return mfns_pose_refine(&sc.rig, &sc.map, &sc.frame, &sc.assoc, &t, &sc.cfg, &sc.sol);
}

/* Largest per-axis position error (mm) and attitude error (deg, about the
 * world axes) of s against the truth. */
static void errors(const mfns_pose_solution_t *s, double *pos_mm, double *att_deg)
{
    const pt_dpose_t est = pt_from_float(&s->pose);
    double a[3], b[3];
    pt_position_w(&est, a);
    pt_position_w(&sc.truth, b);
    *pos_mm = fmax(fabs(a[0] - b[0]), fmax(fabs(a[1] - b[1]), fabs(a[2] - b[2])));
    /* C_b_w(est) C_b_w(true)^T = exp(phi_w): small angles from the skew part */
    double m[3][3];
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            double v = 0.0;
            for (int k = 0; k < 3; k++) {
                v += est.C[k][i] * sc.truth.C[k][j];
            }
            m[i][j] = v;
        }
    }
    const double phi[3] = {0.5 * (m[2][1] - m[1][2]), 0.5 * (m[0][2] - m[2][0]), 0.5 * (m[1][0] - m[0][1])};
    *att_deg = fmax(fabs(phi[0]), fmax(fabs(phi[1]), fabs(phi[2]))) / DEG;
}

static void test_quantile_known_values(void **state)
{
    (void)state;
    /* upper-tail N(0,1) quantiles (tables; R qnorm(p, lower = FALSE)) */
    const struct {
        float p;
        double z;
    } v[] = {{0.5f, 0.0},         {0.25f, 0.6744898},  {0.025f, 1.959964}, {1e-3f, 3.090232},
             {1e-5f, 4.264891},   {1e-7f, 5.199338},   {1e-9f, 5.997807},  {1e-12f, 7.034484},
             {1e-20f, 9.262340},  {3e-30f, 11.368515}};
    for (size_t i = 0; i < sizeof v / sizeof v[0]; i++) {
        const float z = mfns_integrity_q_inv(v[i].p);
        assert_near(z, v[i].z, 2e-6 * fmax(1.0, v[i].z));
    }
    assert_true(isnan(mfns_integrity_q_inv(0.0f)));
    assert_true(isnan(mfns_integrity_q_inv(0.6f)));
    assert_true(isnan(mfns_integrity_q_inv(-1.0f)));
    assert_true(isnan(mfns_integrity_q_inv(NAN)));
    /* monotone over the tail the tests use */
    float prev = 0.0f;
    for (int e = 1; e <= 30; e++) {
        const float z = mfns_integrity_q_inv(powf(10.0f, (float)-e));
        assert_true(z > prev);
        prev = z;
    }
}

static void test_settings(void **state)
{
    (void)state;
    mfns_integrity_settings_t s;
    mfns_integrity_settings_default(&s);
    assert_true(mfns_integrity_settings_valid(&s));
    assert_true(s.alert_limit_pos_mm == 20.0f && s.alert_limit_att_deg == 1.0f);
    s.p_fa = 0.0f;
    assert_false(mfns_integrity_settings_valid(&s));
    mfns_integrity_settings_default(&s);
    s.p_md = 0.7f;
    assert_false(mfns_integrity_settings_valid(&s));
    assert_false(mfns_integrity_settings_valid(NULL));
}

static void test_clean_fix_passes_with_a_sensible_pl(void **state)
{
    (void)state;
    const int per_cam[3] = {5, 5, 5};
    assert_int_equal(make_scene(per_cam, 0.1, 11), MFNS_POSE_OK);
    mfns_integrity_settings_t set;
    mfns_integrity_settings_default(&set);
    set.require_camera_monitor = 1;
    mfns_integrity_eval_t ev;
    assert_int_equal(mfns_integrity_evaluate(&sc.rig, &sc.map, &sc.frame, &sc.sol, &sc.cfg, &set, NULL, &ev),
                     MFNS_INTEGRITY_OK);
    assert_true(ev.tests_passed);
    assert_int_equal(ev.hypotheses, 15 + 3);
    assert_int_equal(ev.unmonitorable, 0);
    assert_true(isfinite(ev.pl_pos_mm) && isfinite(ev.pl_att_deg));
    const float smax = fmaxf(sc.sol.sigma_pos_mm[0], fmaxf(sc.sol.sigma_pos_mm[1], sc.sol.sigma_pos_mm[2]));
    /* at least the fault-free bound, and within a small multiple of sigma:
     * K_fa + K_md ~ 8.5 with the subset sigma a few times the full one */
    assert_true(ev.pl_pos_mm >= 3.29f * 0.5f * smax);
    assert_true(ev.pl_pos_mm <= 40.0f * smax);
    assert_true(ev.pl_pos_mm <= set.alert_limit_pos_mm && ev.pl_att_deg <= set.alert_limit_att_deg);
    assert_true(ev.k_fa > 4.0f && ev.k_fa < 7.0f);
    assert_near(ev.k_md, 3.090232, 1e-4);

    mfns_integrity_memory_t mem;
    mfns_integrity_memory_reset(&mem);
    mfns_integrity_result_t res;
    assert_true(mfns_integrity_fde(&mem, &sc.rig, &sc.map, &sc.frame, &sc.cfg, &set, &sc.sol, &res));
    assert_true(res.evaluated && res.tests_passed);
    assert_int_equal(sc.sol.status, MFNS_POSE_OK);
    assert_int_equal(res.excluded_beacon, -1);
    assert_int_equal(res.excluded_camera, -1);
    double ep, ea;
    errors(&sc.sol, &ep, &ea);
    assert_true(ep <= (double)res.pl_pos_mm && ea <= (double)res.pl_att_deg);
}

/* The map datum (a rigid error of the whole map) moves the fix and every
 * subset solution alike: the separations and the tests are the same with and
 * without it, the protection level grows by at least its fault-free share
 * (K_ff times the datum's own 1-sigma on the axis) and by no more than the
 * datum's sigma times the sum of the largest factors. */
static void test_map_datum_widens_the_pl_not_the_tests(void **state)
{
    (void)state;
    const int per_cam[3] = {5, 5, 5};
    assert_int_equal(make_scene(per_cam, 0.1, 11), MFNS_POSE_OK);
    mfns_integrity_settings_t set;
    mfns_integrity_settings_default(&set);
    set.require_camera_monitor = 1;
    mfns_integrity_eval_t ev0, ev1;
    assert_int_equal(mfns_integrity_evaluate(&sc.rig, &sc.map, &sc.frame, &sc.sol, &sc.cfg, &set, NULL, &ev0),
                     MFNS_INTEGRITY_OK);
    static mfns_map_datum_t datum;
    memset(&datum, 0, sizeof datum);
    datum.present = 1;
    const float sd_mm = 2.0f; /* a shift only, 2 mm per axis: far above the fix's own sigma */
    for (int i = 0; i < 3; i++) {
        datum.cov[i][i] = sd_mm * sd_mm;
    }
    mfns_pose_config_t cfg = sc.cfg;
    cfg.datum = &datum;
    assert_int_equal(mfns_integrity_evaluate(&sc.rig, &sc.map, &sc.frame, &sc.sol, &cfg, &set, NULL, &ev1),
                     MFNS_INTEGRITY_OK);
    assert_true(ev1.tests_passed == ev0.tests_passed);
    assert_float_equal(ev1.max_norm_sep, ev0.max_norm_sep, 1e-5f * (1.0f + ev0.max_norm_sep));
    assert_int_equal(ev1.worst.kind, ev0.worst.kind);
    const float k_ff = mfns_integrity_q_inv(0.5f * set.p_md);
    assert_true(ev1.pl_pos_mm >= k_ff * sd_mm);
    assert_true(ev1.pl_pos_mm <= ev0.pl_pos_mm + (k_ff + ev1.k_md) * sd_mm);
    assert_float_equal(ev1.pl_att_deg, ev0.pl_att_deg, 1e-4f * ev0.pl_att_deg); /* a shift turns nothing */
}

static void test_biased_beacon_detected_and_excluded(void **state)
{
    (void)state;
    const int per_cam[3] = {5, 5, 5};
    for (uint64_t seed = 21; seed < 26; seed++) {
        (void)make_scene(per_cam, 0.1, seed);
        /* bias camera 1's first observation by 2 px (20 sigma: below the
         * solver's 30-sigma outlier gate, so only FDE can catch it) */
        const int16_t bad = sc.assoc.beacon[1][0];
        assert_true(bad >= 0);
        sc.frame.obs[1][0].u += 1.6f;
        sc.frame.obs[1][0].v -= 1.2f;
        const mfns_pose_t t = pt_to_float(&sc.truth);
        const mfns_pose_status_t st = mfns_pose_refine(&sc.rig, &sc.map, &sc.frame, &sc.assoc, &t, &sc.cfg, &sc.sol);
        assert_true(st == MFNS_POSE_OK || st == MFNS_POSE_DEGRADED);
        assert_int_equal(sc.sol.inlier[1][0], 1); /* the solver kept it */
        mfns_integrity_settings_t set;
        mfns_integrity_settings_default(&set);
        mfns_integrity_eval_t ev;
        assert_int_equal(mfns_integrity_evaluate(&sc.rig, &sc.map, &sc.frame, &sc.sol, &sc.cfg, &set, NULL, &ev),
                         MFNS_INTEGRITY_OK);
        assert_false(ev.tests_passed);
        mfns_integrity_memory_t mem;
        mfns_integrity_memory_reset(&mem);
        mfns_integrity_result_t res;
        const mfns_pose_solution_t before = sc.sol;
        assert_true(mfns_integrity_fde(&mem, &sc.rig, &sc.map, &sc.frame, &sc.cfg, &set, &sc.sol, &res));
        assert_int_equal(sc.sol.status, MFNS_POSE_DEGRADED);
        assert_int_equal(sc.sol.reason, MFNS_POSE_R_EXCLUDED);
        assert_int_equal(res.excluded_beacon, bad);
        assert_int_equal(res.excluded_camera, -1);
        assert_true(res.new_beacon_exclusion && res.detect_norm_sep > 1.0f && res.tests_passed);
        assert_int_equal(sc.sol.inlier[1][0], 0);
        double ep, ea, ep0, ea0;
        errors(&sc.sol, &ep, &ea);
        errors(&before, &ep0, &ea0);
        print_message("seed %d: error %.3f mm %.4f deg (with the bias %.3f mm %.4f deg), PL %.2f mm %.3f deg\n",
                      (int)seed, ep, ea, ep0, ea0, (double)res.pl_pos_mm, (double)res.pl_att_deg);
        assert_true(ep <= (double)res.pl_pos_mm && ea <= (double)res.pl_att_deg);
        const float smax = fmaxf(sc.sol.sigma_pos_mm[0], fmaxf(sc.sol.sigma_pos_mm[1], sc.sol.sigma_pos_mm[2]));
        assert_true(ep < 5.0 * (double)smax);
        /* the next cycle, same frame: still held out, not reported again */
        mfns_pose_solution_t again;
        assert_true(mfns_pose_refine(&sc.rig, &sc.map, &sc.frame, &sc.assoc, &t, &sc.cfg, &again) != MFNS_POSE_NO_FIX);
        assert_true(mfns_integrity_fde(&mem, &sc.rig, &sc.map, &sc.frame, &sc.cfg, &set, &again, &res));
        assert_int_equal(again.reason, MFNS_POSE_R_EXCLUDED);
        assert_int_equal(res.excluded_beacon, bad);
        assert_false(res.new_beacon_exclusion);
        /* after the hold with the bias gone, it is re-admitted */
        sc.frame.obs[1][0].u -= 1.6f;
        sc.frame.obs[1][0].v += 1.2f;
        bool back = false;
        for (int k = 0; k <= set.hold_cycles + 1 && !back; k++) {
            assert_true(mfns_pose_refine(&sc.rig, &sc.map, &sc.frame, &sc.assoc, &t, &sc.cfg, &again) !=
                        MFNS_POSE_NO_FIX);
            (void)mfns_integrity_fde(&mem, &sc.rig, &sc.map, &sc.frame, &sc.cfg, &set, &again, &res);
            back = res.readmitted_beacon == bad;
        }
        assert_true(back);
    }
}

/* Camera cam's observations replaced by those of a pose moved by dpos mm and
 * datt rad (a stale frame of a moving robot). */
static void stale_camera(int cam, double dpos, double datt, uint64_t seed)
{
    mfns_rng_t rng;
    mfns_rng_seed(&rng, seed);
    const double w[3] = {datt, -0.5 * datt, 0.3 * datt};
    double dc[3][3], c[3][3];
    pt_rot_exp(w, dc);
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            c[i][j] = dc[i][0] * sc.truth.C[0][j] + dc[i][1] * sc.truth.C[1][j] + dc[i][2] * sc.truth.C[2][j];
        }
    }
    double r[3];
    pt_position_w(&sc.truth, r);
    r[0] += dpos;
    r[1] -= 0.5 * dpos;
    const pt_dpose_t moved = pt_pose(c, r);
    mfns_obs_frame_t f;
    mfns_pose_assoc_t a;
    (void)pt_make_frame(&sc.rig, &sc.map, &moved, sc.cfg.sigma_px, &rng, &f, &a);
    sc.frame.count[cam] = f.count[cam];
    memcpy(sc.frame.obs[cam], f.obs[cam], sizeof f.obs[cam]);
    memcpy(sc.assoc.beacon[cam], a.beacon[cam], sizeof a.beacon[cam]);
}

static void test_stale_camera_detected_and_excluded(void **state)
{
    (void)state;
    const int per_cam[3] = {6, 6, 6};
    int detected = 0;
    for (uint64_t seed = 31; seed < 55; seed++) {
        /* a few mm and 0.2 deg (the solver itself often refuses those: its
         * LM does not converge on inconsistent cameras), and a smaller one */
        (void)make_scene(per_cam, 0.1, seed);
        const bool big = seed < 43;
        stale_camera(2, big ? 3.0 : 1.0, (big ? 0.2 : 0.05) * DEG, seed + 100);
        const mfns_pose_t t = pt_to_float(&sc.truth);
        const mfns_pose_status_t st = mfns_pose_refine(&sc.rig, &sc.map, &sc.frame, &sc.assoc, &t, &sc.cfg, &sc.sol);
        if (st == MFNS_POSE_NO_FIX) {
            print_message("seed %d: solver NO_FIX %d\n", (int)seed, sc.sol.reason);
            continue; /* the solver's own checks refused it: nothing to certify */
        }
        mfns_integrity_settings_t set;
        mfns_integrity_settings_default(&set);
        mfns_integrity_memory_t mem;
        mfns_integrity_memory_reset(&mem);
        mfns_integrity_result_t res;
        const mfns_pose_solution_t before = sc.sol;
        const bool ok = mfns_integrity_fde(&mem, &sc.rig, &sc.map, &sc.frame, &sc.cfg, &set, &sc.sol, &res);
        double ep0, ea0;
        errors(&before, &ep0, &ea0);
        print_message("seed %d: solver %s/%d err %.2f mm %.3f deg; fde %d reason %d sep %.1f excl cam %d beacon %d\n",
                      (int)seed, mfns_pose_status_str(before.status), before.reason, ep0, ea0, ok, sc.sol.reason,
                      (double)res.detect_norm_sep, res.excluded_camera, res.excluded_beacon);
        double ep, ea;
        errors(&sc.sol, &ep, &ea);
        if (ok) {
            /* whatever the verdict, a usable fix is inside its PL */
            assert_true(ep <= (double)res.pl_pos_mm && ea <= (double)res.pl_att_deg);
        }
        if (!big) {
            continue; /* a fault near the threshold may be missed or blamed on a beacon */
        }
        assert_true(res.detect_norm_sep > 1.0f); /* detected */
        if (ok) {
            assert_int_equal(res.excluded_camera, 2);
            assert_true(res.new_camera_exclusion);
            assert_int_equal(sc.sol.reason, MFNS_POSE_R_EXCLUDED);
            assert_true(ep < 1.0 && ea < 0.05);
        } else {
            assert_int_equal(sc.sol.status, MFNS_POSE_NO_FIX);
        }
        detected++;
    }
    assert_true(detected >= 3); /* every fix the solver gave was caught; count them */
}

static void test_three_beacons_never_usable(void **state)
{
    (void)state;
    const int per_cam[3] = {1, 1, 1};
    assert_int_equal(make_scene(per_cam, 0.1, 41), MFNS_POSE_NO_FIX);
    assert_int_equal(sc.sol.reason, MFNS_POSE_R_MINIMAL);
    mfns_integrity_settings_t set;
    mfns_integrity_settings_default(&set);
    mfns_integrity_memory_t mem;
    mfns_integrity_memory_reset(&mem);
    mfns_integrity_result_t res;
    assert_false(mfns_integrity_fde(&mem, &sc.rig, &sc.map, &sc.frame, &sc.cfg, &set, &sc.sol, &res));
    assert_false(res.evaluated);
    assert_int_equal(sc.sol.status, MFNS_POSE_NO_FIX);
    mfns_integrity_eval_t ev;
    assert_int_equal(mfns_integrity_evaluate(&sc.rig, &sc.map, &sc.frame, &sc.sol, &sc.cfg, &set, NULL, &ev),
                     MFNS_INTEGRITY_E_ARG);
    /* four beacons (2, 1, 1): a camera's removal leaves too few: no bound on
     * a camera fault; strict, never usable */
    const int four[3] = {2, 1, 1};
    assert_true(make_scene(four, 0.1, 42) != MFNS_POSE_NO_FIX);
    assert_int_equal(mfns_integrity_evaluate(&sc.rig, &sc.map, &sc.frame, &sc.sol, &sc.cfg, &set, NULL, &ev),
                     MFNS_INTEGRITY_OK);
    assert_true(ev.unmonitorable_cameras >= 1 && isinf(ev.pl_pos_mm));
    set.require_camera_monitor = 1;
    mfns_pose_solution_t s = sc.sol;
    assert_false(mfns_integrity_fde(&mem, &sc.rig, &sc.map, &sc.frame, &sc.cfg, &set, &s, &res));
    assert_int_equal(s.reason, MFNS_POSE_R_UNMONITORED);
    /* not strict: at best DEGRADED CAMERA_UNMONITORED, never a full fix */
    set.require_camera_monitor = 0;
    s = sc.sol;
    if (mfns_integrity_fde(&mem, &sc.rig, &sc.map, &sc.frame, &sc.cfg, &set, &s, &res)) {
        assert_int_equal(s.status, MFNS_POSE_DEGRADED);
        assert_int_equal(s.reason, MFNS_POSE_R_CAMERA_UNMONITORED);
    } else {
        assert_true(s.reason == MFNS_POSE_R_PL_EXCEEDS_AL || s.reason == MFNS_POSE_R_UNMONITORED);
    }
}

static void test_one_camera_is_not_usable_when_camera_faults_must_be_bounded(void **state)
{
    (void)state;
    const int per_cam[3] = {8, 0, 0};
    assert_true(make_scene(per_cam, 0.1, 51) != MFNS_POSE_NO_FIX);
    mfns_integrity_settings_t set;
    mfns_integrity_settings_default(&set);
    mfns_integrity_eval_t ev;
    assert_int_equal(mfns_integrity_evaluate(&sc.rig, &sc.map, &sc.frame, &sc.sol, &sc.cfg, &set, NULL, &ev),
                     MFNS_INTEGRITY_OK);
    assert_int_equal(ev.unmonitorable_cameras, 1);
    assert_int_equal(ev.unmonitored.kind, MFNS_INTEGRITY_HYP_CAMERA);
    assert_int_equal(ev.unmonitored.id, 0);
    set.require_camera_monitor = 1;
    mfns_integrity_memory_t mem;
    mfns_integrity_memory_reset(&mem);
    mfns_integrity_result_t res;
    assert_false(mfns_integrity_fde(&mem, &sc.rig, &sc.map, &sc.frame, &sc.cfg, &set, &sc.sol, &res));
    assert_int_equal(sc.sol.status, MFNS_POSE_NO_FIX);
    assert_int_equal(sc.sol.reason, MFNS_POSE_R_UNMONITORED);
}

/* Over many fault-free draws: the false-alarm rate is at most P_fa (the
 * split over hypotheses and axes is conservative: the tests are
 * correlated) and not absurdly below it, and the true error stays inside
 * the protection level. */
static void test_false_alarm_rate_and_pl_bound(void **state)
{
    (void)state;
    const int per_cam[3] = {4, 4, 4};
    const int n = 600;
    mfns_integrity_settings_t set;
    mfns_integrity_settings_default(&set);
    set.p_fa = 0.1f; /* large enough to count */
    set.require_camera_monitor = 1;
    int alarms = 0, outside = 0, evaluated = 0;
    for (int i = 0; i < n; i++) {
        if (make_scene(per_cam, 0.1, 1000u + (uint64_t)i) == MFNS_POSE_NO_FIX) {
            continue;
        }
        mfns_integrity_eval_t ev;
        if (mfns_integrity_evaluate(&sc.rig, &sc.map, &sc.frame, &sc.sol, &sc.cfg, &set, NULL, &ev) !=
                MFNS_INTEGRITY_OK ||
            ev.unmonitorable > 0U) {
            continue;
        }
        evaluated++;
        alarms += ev.tests_passed ? 0 : 1;
        double ep, ea;
        errors(&sc.sol, &ep, &ea);
        outside += (ep > (double)ev.pl_pos_mm || ea > (double)ev.pl_att_deg) ? 1 : 0;
    }
    const double rate = (double)alarms / (double)evaluated;
    print_message("false alarms %d of %d (%.4f, P_fa %.2f), true error outside the PL %d\n", alarms, evaluated, rate,
                  (double)set.p_fa, outside);
    assert_true(evaluated >= n * 9 / 10);
    const double sd = sqrt((double)set.p_fa * (1.0 - (double)set.p_fa) / (double)evaluated);
    assert_true(rate <= (double)set.p_fa + 3.0 * sd);
    assert_true(rate >= 0.1 * (double)set.p_fa);
    assert_true(outside <= 1); /* P_md 1e-3 on each of 6 axes, per fix */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_quantile_known_values),
        cmocka_unit_test(test_settings),
        cmocka_unit_test(test_clean_fix_passes_with_a_sensible_pl),
        cmocka_unit_test(test_map_datum_widens_the_pl_not_the_tests),
        cmocka_unit_test(test_biased_beacon_detected_and_excluded),
        cmocka_unit_test(test_stale_camera_detected_and_excluded),
        cmocka_unit_test(test_three_beacons_never_usable),
        cmocka_unit_test(test_one_camera_is_not_usable_when_camera_faults_must_be_bounded),
        cmocka_unit_test(test_false_alarm_rate_and_pl_bound),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
