/* test_filter_bank.c -- integrity over time (firmware/nav/filter/filter_bank.h)
 * on a simulated robot (support/filter_sim.h): the paper's rig, 4 + 3 + 3
 * beacons, 18.5 Hz, the cameras captured 7 ms apart, pixel noise 0.1 px.
 *  - clean: usable in (nearly) every cycle, nothing excluded, the error of
 *    every usable cycle inside its PL, bounded work;
 *  - one beacon, step (gated) and small step and slow ramp (inside the gate):
 *    excluded with the right beacon named, the PL bounding the error before;
 *  - one camera pointing 0.3 deg off, and one camera a frame (54 ms) late on
 *    a moving robot: the camera named; a camera with ten of the twelve
 *    beacons late after a dropped frame: named, bounded;
 *  - a readmission after a clean hold;
 *  - a slow pointing ramp (0.005 deg per cycle) on each camera;
 *  - two cameras seeing beacons (the module's seed-2 geometry): the camera
 *    hypotheses' PL bounded, a pointing step and ramp detected. */
#include <string.h>

#include "tests/unit/support/filter_sim.h"
#include "firmware/nav/filter/filter_bank.h"
#include "tests/unit/support/testutil.h"

#pragma GCC diagnostic ignored "-Wdouble-promotion"

#define FRAME_US 54000
#define CAM_STAGGER_US 7000
#define SIGMA_PX 0.1
#define MAX_OBS 48
#define CYCLES 120
#define FAULT_CYCLE 40
static const int PER_CAM[3] = {4, 3, 3};

typedef enum {
    F_NONE = 0,
    F_BEACON_STEP,  /* arg px on u of beacon fault_id from FAULT_CYCLE */
    F_BEACON_RAMP,  /* arg px per cycle */
    F_CAM_POINTING, /* arg deg about the camera's x axis, camera fault_id */
    F_CAM_LAG,      /* camera fault_id one frame late */
    F_BEACON_PULSE, /* arg px for 10 cycles, then healthy (readmission) */
    F_COLLISION,    /* arg mm/s^2 along x for one frame period from FAULT_CYCLE */
    F_CAM_RAMP,     /* arg deg per cycle about the camera's x axis, camera fault_id */
    F_CAM_DROP_LAG, /* camera fault_id drops its frame at FAULT_CYCLE, then delivers each one a frame late */
    F_CAM_DROP,     /* camera fault_id drops its frame at FAULT_CYCLE, then is healthy */
    F_CAM_JOLT,     /* every observation of camera fault_id arg px off in u at FAULT_CYCLE only */
} fault_t;

typedef struct {
    fault_t kind;
    int id;
    double arg;
    double speed_mm_s, rate_rad_s;
    uint64_t seed;
    int cycles; /* 0: CYCLES */
    const int *per_cam; /* beacons per camera, NULL: PER_CAM */
    bool doubt_on_drop; /* the dropped frame puts the camera's clock in doubt, as the flight program does */
} scenario_t;

typedef struct {
    int usable, evaluated;
    int first_detect;      /* cycle of the first exclusion, -1 none */
    int detect_kind, detect_id;
    int wrong_subject;     /* exclusions naming anything else */
    int bound_violations;  /* usable cycles with an error beyond the PL */
    int bound_violations_before; /* of them, before the detection */
    double worst_ratio;    /* max error / PL over usable cycles */
    int sigma_violations;  /* usable cycles with an error beyond 5 sigma of the output covariance on some axis */
    double worst_sigma;    /* max error / sigma over usable cycles */
    double max_pl_pos, max_pl_att;
    double max_pl_beacon_pos; /* over the beacon hypotheses alone (what the cameras cost: max_pl_pos) */
    double max_sigma_pos;     /* the output's largest position sigma (mm) */
    double max_pl_any_pos;    /* the largest finite-hypothesis PL, usable or not (mm) */
    uint32_t max_work, work_bound_violations;
    int readmitted_cycle;
    int restarts;
    int restart_cycle, restart_reason;
    int trusted_cycle; /* the doubt on a camera's clock cleared, -1 never */
    int suspect_cycles, first_suspect, suspect_cam; /* FRAME_SUSPECT refusals, the first's cycle and camera */
    int gated_at_fault; /* the fault cycle's frame of camera fault_id was gated (not taken) */
} result_t;

/* The caller's checks find camera cam's frame suspect in cycles [from, from + n). */
typedef struct {
    int from, n, cam;
} told_t;

static void run_told(const scenario_t *sc, const told_t *told, result_t *res)
{
    memset(res, 0, sizeof(*res));
    res->first_detect = -1;
    res->readmitted_cycle = -1;
    res->trusted_cycle = -1;
    res->first_suspect = -1;
    res->suspect_cam = -1;
    mfns_rng_t rng, orng;
    mfns_rng_seed(&rng, sc->seed);
    mfns_rng_seed(&orng, sc->seed + 100);
    const mfns_rig_t rig = pt_paper_rig();
    fs_truth_t x;
    memset(&x, 0, sizeof x);
    for (int i = 0; i < 3; i++) {
        x.C_w_b[i][i] = 1.0;
    }
    const pt_dpose_t p0 = fs_truth_pose(&x);
    const mfns_beacon_map_t map = pt_dense_map(&rig, &p0, sc->per_cam != NULL ? sc->per_cam : PER_CAM, 900, 1400, &rng);
    x.v_w[0] = sc->speed_mm_s;
    x.w_w[2] = sc->rate_rad_s;
    mfns_rig_t bad_rig = rig;
    if (sc->kind == F_CAM_POINTING) {
        const double a = sc->arg * MFNS_PI / 180.0;
        const mfns_m3_t r = mfns_rot_exp(mfns_v3((float)a, 0.0f, 0.0f));
        bad_rig.cam[sc->id].C_k_b = mfns_m3_mul(rig.cam[sc->id].C_k_b, r);
    }
    mfns_filter_settings_t fs;
    mfns_filter_settings_default(&fs);
    mfns_integrity_settings_t is;
    mfns_integrity_settings_default(&is);
    static mfns_filter_bank_t bank; /* 11 KB: static, as the flight code places it */
    {
        mfns_filter_t f;
        fs_init_filter(&f, &x, 3e-4, 0.3, 20.0, 0.01, 0, &rng);
        float cov[6][6];
        mfns_filter_pose_cov_ros(&f, NULL, cov);
        const mfns_pose_t pose = mfns_filter_pose(&f);
        assert_int_equal(mfns_bank_init(&bank, &pose, (const float(*)[6])cov, f.v_w, 20.0f, f.w_w, 0.01f, 0),
                         MFNS_FILTER_OK);
    }
    int64_t tt = 0;
    fs_truth_t late[MFNS_NUM_CAMERAS]; /* each camera's truth a frame ago */
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        late[c] = x;
    }
    const int cycles = sc->cycles > 0 ? sc->cycles : CYCLES;
    for (int k = 1; k <= cycles; k++) {
        const int64_t t = (int64_t)k * FRAME_US;
        const bool on = k >= FAULT_CYCLE;
        if (sc->kind == F_CAM_RAMP && on) {
            const double a = sc->arg * (k - FAULT_CYCLE + 1) * MFNS_PI / 180.0;
            const mfns_m3_t r = mfns_rot_exp(mfns_v3((float)a, 0.0f, 0.0f));
            bad_rig.cam[sc->id].C_k_b = mfns_m3_mul(rig.cam[sc->id].C_k_b, r);
        }
        int nobs = 0;
        for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
            const int64_t tc = t + c * CAM_STAGGER_US;
            const double a_col[3] = {sc->arg, 0.0, 0.0};
            const bool collide = sc->kind == F_COLLISION && k == FAULT_CYCLE;
            fs_truth_advance(&x, (double)(tc - tt) * 1e-6, 0.0, 0.0, collide ? a_col : NULL, NULL);
            tt = tc;
            mfns_filter_obs_t obs[MAX_OBS];
            int16_t beacon[MAX_OBS];
            const bool drop =
                (sc->kind == F_CAM_DROP_LAG || sc->kind == F_CAM_DROP) && c == sc->id && k == FAULT_CYCLE;
            if (drop && sc->doubt_on_drop) {
                assert_int_equal(mfns_bank_doubt_timing(&bank, c, (float)(FRAME_US * 1e-6)), MFNS_FILTER_OK);
            }
            const bool lag = on && (sc->kind == F_CAM_LAG || sc->kind == F_CAM_DROP_LAG) && c == sc->id;
            const mfns_rig_t *r =
                (on && (sc->kind == F_CAM_POINTING || sc->kind == F_CAM_RAMP) && c == sc->id) ? &bad_rig : &rig;
            const int n =
                drop ? 0 : fs_observe(r, &map, lag ? &late[c] : &x, c, SIGMA_PX, &orng, tc, obs, beacon, MAX_OBS);
            late[c] = x;
            for (int i = 0; i < n; i++) {
                obs[i].p_w = map.beacon[beacon[i]].p_w; /* the map's, not the camera's */
                obs[i].cam = (uint8_t)c;
                if (beacon[i] == sc->id && on) {
                    /* a step (or a pulse while it lasts) of arg px, or a ramp of arg px per cycle */
                    const bool step = sc->kind == F_BEACON_STEP || (sc->kind == F_BEACON_PULSE && k < FAULT_CYCLE + 10);
                    const double ramp = sc->kind == F_BEACON_RAMP ? sc->arg * (k - FAULT_CYCLE + 1) : 0.0;
                    obs[i].u += (float)((step ? sc->arg : 0.0) + ramp);
                }
                if (sc->kind == F_CAM_JOLT && c == sc->id && k == FAULT_CYCLE) {
                    obs[i].u += (float)sc->arg;
                }
            }
            const mfns_filter_status_t st = mfns_bank_observe_frame(&bank, &fs, &rig, (float)SIGMA_PX, n, beacon, obs);
            if (c == sc->id && k == FAULT_CYCLE && st == MFNS_FILTER_GATED) {
                res->gated_at_fault = 1;
            }
            /* E_TIME: the full filter coasted too long (evaluate then asks for a restart) */
            assert_true(st == MFNS_FILTER_OK || st == MFNS_FILTER_GATED || st == MFNS_FILTER_E_TIME);
            nobs += n;
        }
        if (told != NULL && k >= told->from && k < told->from + told->n) {
            assert_int_equal(mfns_bank_suspect_frame(&bank, told->cam), MFNS_FILTER_OK);
        }
        mfns_bank_output_t out;
        assert_int_equal(mfns_bank_evaluate(&bank, &fs, &is, NULL, t + 2 * CAM_STAGGER_US, &out), MFNS_FILTER_OK);
        res->evaluated++;
        const uint32_t bound = (uint32_t)nobs * (2U + MFNS_BANK_MAX_HYP) + 1U + 3U * MFNS_BANK_MAX_HYP;
        res->max_work = out.work > res->max_work ? out.work : res->max_work;
        res->work_bound_violations += out.work > bound ? 1U : 0U;
        if (out.restart) {
            res->restarts++;
            res->restart_cycle = k;
            res->restart_reason = (int)out.reason;
            assert_false(out.usable);
            break;
        }
        if (out.detected_kind != MFNS_BANK_HYP_NONE) {
            const bool right = (int)out.detected_kind == (sc->kind == F_CAM_POINTING || sc->kind == F_CAM_LAG ||
                                                                  sc->kind == F_CAM_RAMP || sc->kind == F_CAM_DROP_LAG
                                                              ? MFNS_BANK_HYP_CAMERA
                                                              : MFNS_BANK_HYP_BEACON) &&
                               out.detected_id == sc->id && sc->kind != F_NONE && on;
            if (res->first_detect < 0) {
                res->first_detect = k;
                res->detect_kind = out.detected_kind;
                res->detect_id = out.detected_id;
            }
            res->wrong_subject += right ? 0 : 1;
        }
        if (out.readmitted_beacon >= 0 || out.readmitted_camera >= 0) {
            res->readmitted_cycle = k;
        }
        if (out.timing_trusted >= 0 && res->trusted_cycle < 0) {
            res->trusted_cycle = k;
        }
        if (out.reason == MFNS_POSE_R_FRAME_SUSPECT) {
            assert_false(out.usable);
            assert_true(out.suspect_camera >= 0 && out.suspect_camera < MFNS_NUM_CAMERAS);
            res->suspect_cycles++;
            if (res->first_suspect < 0) {
                res->first_suspect = k;
                res->suspect_cam = (int)(uint8_t)out.suspect_camera; /* in range: asserted above */
            }
        }
        if (out.usable) {
            res->usable++;
            mfns_filter_t probe = bank.full; /* the output pose against the truth */
            double e[6];
            fs_pose_error(&probe, &x, e);
            double ratio = 0.0;
            for (int j = 0; j < 3; j++) {
                ratio = fmax(ratio, fabs(e[3 + j]) / out.pl_pos_mm);
                ratio = fmax(ratio, fabs(e[j]) * 180.0 / MFNS_PI / out.pl_att_deg);
            }
            res->worst_ratio = fmax(res->worst_ratio, ratio);
            double zmax = 0.0; /* cov_ros: position first, then attitude; e: attitude first */
            for (int j = 0; j < 3; j++) {
                zmax = fmax(zmax, fabs(e[3 + j]) / sqrt(fmax(out.cov_ros[j][j], 1e-30)));
                zmax = fmax(zmax, fabs(e[j]) / sqrt(fmax(out.cov_ros[3 + j][3 + j], 1e-30)));
            }
            res->worst_sigma = fmax(res->worst_sigma, zmax);
            res->sigma_violations += zmax > 5.0 ? 1 : 0;
            if (ratio > 1.0) {
                res->bound_violations++;
                res->bound_violations_before += res->first_detect < 0 ? 1 : 0;
            }
            res->max_pl_pos = fmax(res->max_pl_pos, out.pl_pos_mm);
            res->max_pl_att = fmax(res->max_pl_att, out.pl_att_deg);
        }
        if (out.status != MFNS_POSE_NO_FIX || out.reason == MFNS_POSE_R_PL_EXCEEDS_AL) {
            res->max_pl_beacon_pos = fmax(res->max_pl_beacon_pos, out.pl_beacon_pos_mm);
            for (int j = 0; j < 3; j++) {
                res->max_sigma_pos = fmax(res->max_sigma_pos, sqrt(fmax(out.cov_ros[j][j], 0.0)));
            }
            res->max_pl_any_pos = fmax(res->max_pl_any_pos, out.pl_pos_mm);
        }
    }
}

static void run(const scenario_t *sc, result_t *res)
{
    run_told(sc, NULL, res);
}

static void report(const char *name, const result_t *r)
{
    print_message("%-22s usable %3d/%3d detect@%3d kind %d id %2d wrong %d viol %d (before %d) worst err/PL %.2f "
                  "PL max %.2f mm %.3f deg work max %u readmit@%d restarts %d\n",
                  name, r->usable, r->evaluated, r->first_detect, r->detect_kind, r->detect_id, r->wrong_subject,
                  r->bound_violations, r->bound_violations_before, r->worst_ratio, r->max_pl_pos, r->max_pl_att,
                  r->max_work, r->readmitted_cycle, r->restarts);
}

static void test_clean_runs(void **state)
{
    (void)state;
    for (uint64_t seed = 1; seed <= 4; seed++) {
        const scenario_t sc = {F_NONE, -1, 0.0, seed % 2 ? 30.0 : 0.0, seed % 2 ? 0.02 : 0.0, seed, 0, NULL, false};
        result_t r;
        run(&sc, &r);
        report("clean", &r);
        assert_int_equal(r.restarts, 0);
        assert_int_equal(r.first_detect, -1);
        assert_int_equal(r.bound_violations, 0);
        assert_int_equal(r.work_bound_violations, 0);
        assert_true(r.usable * 1000 >= r.evaluated * 995); /* >= 99.5 % */
        assert_int_equal(r.suspect_cycles, 0);
    }
}

/* The frame test alone (filter_bank.h MFNS_BANK_FRAME_SUSPECT_P): camera
 * 0's frame of one cycle with every observation 1.5 px off in u (a jolt of
 * its mount for one frame) on the 4 + 3 + 3 scene, each observation inside
 * the gate: the frame is taken, the cycle refused as FRAME_SUSPECT, nothing
 * excluded, no usable fix beyond 5 sigma or its PL, and usable again after
 * it. The camera the refusal names is the most unlikely frame's (camera 1
 * here): a frame taken earlier in the cycle pulls the filter and the later
 * frames bear it. A shift the noise explains (0.1 px) is never refused.
 * What it misses, measured on the same scene: camera 2's frame 1.0 px off
 * (the cycle's last) stays under the test's point and its fix is beyond 5
 * sigma of the posterior (the test weighs the shift against the
 * prediction, the 5 sigma against the fix: a frame that dominates the fix
 * moves it by many of its sigmas with a modest NIS). */
static void test_frame_suspect(void **state)
{
    (void)state;
    const scenario_t sc = {F_CAM_JOLT, 0, 1.5, 30.0, 0.02, 60, 60, NULL, false};
    result_t r;
    run(&sc, &r);
    report("one-frame jolt 1.5 px", &r);
    print_message("  FRAME_SUSPECT %d cycles, first @%d camera %d, frame gated %d\n", r.suspect_cycles, r.first_suspect,
                  r.suspect_cam, r.gated_at_fault);
    assert_int_equal(r.gated_at_fault, 0); /* every observation passed the gate: the frame was taken */
    assert_int_equal(r.first_suspect, FAULT_CYCLE);
    assert_int_equal(r.suspect_cycles, 1);
    assert_int_equal(r.first_detect, -1);
    assert_int_equal(r.restarts, 0);
    assert_int_equal(r.bound_violations, 0);
    assert_int_equal(r.sigma_violations, 0);
    assert_int_equal(r.usable, r.evaluated - 1);
    for (int cam = 0; cam < MFNS_NUM_CAMERAS; cam++) {
        const scenario_t small = {F_CAM_JOLT, cam, 0.1, 30.0, 0.02, 60 + (uint64_t)cam, 60, NULL, false};
        run(&small, &r);
        assert_int_equal(r.suspect_cycles, 0);
        assert_int_equal(r.usable, r.evaluated);
    }
}

static void expect_detected(const char *name, const scenario_t *sc, int within)
{
    result_t r;
    run(sc, &r);
    report(name, &r);
    assert_int_equal(r.restarts, 0);
    assert_true(r.first_detect >= FAULT_CYCLE && r.first_detect <= FAULT_CYCLE + within);
    assert_int_equal(r.wrong_subject, 0);
    assert_int_equal(r.bound_violations, 0);
    assert_int_equal(r.work_bound_violations, 0);
}

static void test_beacon_step_gated(void **state)
{
    (void)state;
    const scenario_t sc = {F_BEACON_STEP, 2, 1.0, 30.0, 0.02, 7, 0, NULL, false};
    expect_detected("beacon step 1 px", &sc, 2);
}

/* A step too small to detect (0.4 px: 4 sigma of one pixel coordinate, on
 * one of ten beacons): it need not be found, but the PL must bound its
 * effect in every usable cycle, and nothing else may be blamed. */
static void test_beacon_small_step_bounded(void **state)
{
    (void)state;
    for (uint64_t seed = 8; seed < 12; seed++) {
        const scenario_t sc = {F_BEACON_STEP, (int)seed - 3, 0.4, 30.0, 0.02, seed, 0, NULL, false};
        result_t r;
        run(&sc, &r);
        report("beacon step 0.4 px", &r);
        assert_int_equal(r.restarts, 0);
        assert_int_equal(r.wrong_subject, 0);
        assert_int_equal(r.bound_violations, 0);
        assert_true(r.usable * 100 >= r.evaluated * 95);
    }
}

static void test_beacon_slow_ramp(void **state)
{
    (void)state;
    const scenario_t sc = {F_BEACON_RAMP, 1, 0.02, 30.0, 0.02, 9, 0, NULL, false};
    expect_detected("beacon ramp .02 px/cyc", &sc, 40);
}

static void test_camera_pointing_step(void **state)
{
    (void)state;
    for (int cam = 0; cam < MFNS_NUM_CAMERAS; cam++) {
        const scenario_t sc = {F_CAM_POINTING, cam, 0.3, 30.0, 0.02, 10 + (uint64_t)cam, 0, NULL, false};
        expect_detected("camera 0.3 deg", &sc, 2);
    }
}

static void test_camera_one_frame_late(void **state)
{
    (void)state;
    for (int cam = 0; cam < MFNS_NUM_CAMERAS; cam++) {
        /* 100 mm/s and 0.05 rad/s (5.4 mm and 2.7 mrad a frame): the robot
         * leaves the 10-beacon map after ~4 s, so 75 cycles */
        const scenario_t sc = {F_CAM_LAG, cam, 0.0, 100.0, 0.05, 20 + (uint64_t)cam, 75, NULL, false};
        expect_detected("camera 54 ms late", &sc, 10);
    }
}

/* A camera that dominates the fix (ten beacons against one in each other
 * camera) drops a frame and from then on delivers each frame a period late
 * (the grown campaign's stale camera; 80 mm/s: 4.3 mm a period). The late
 * frame pulls the full filter with it (its one-beacon neighbours cannot hold
 * it), so what bounds it is the camera's own hypothesis, whose time offset
 * must take the lag. Before the offset's column was held for the frame
 * (nav_filter.h mfns_filter_augment), the frame's first updates read the lag
 * as a deceleration (80 -> 26 mm/s in the camera's hypothesis filter), the
 * offset stayed at 0.5 ms, and a usable fix was 3.4 x beyond its PL (22.9 sigma) one cycle after the drop.
 * Now: the camera named within two cycles, no usable fix beyond its PL.
 * Until 7 Dec 2026 (session 23) a usable fix beyond 5 sigma came before the
 * naming (22.9 and 32.7 sigma on seeds 40 and 42): the first late frame
 * passed the gate observation by observation and moved the full filter.
 * The frame test (filter_bank.h MFNS_BANK_FRAME_SUSPECT_P) refuses that
 * cycle: worst usable fix now 1.9 / 1.5 / 2.2 sigma, asserted. */
static void test_dominant_camera_late(void **state)
{
    (void)state;
    static const int DOMINANT[3] = {10, 1, 1};
    for (uint64_t seed = 0; seed < 3; seed++) {
        const scenario_t sc = {F_CAM_DROP_LAG, 0, 0.0, 80.0, 0.03, 40 + seed, 100, DOMINANT, false};
        result_t r;
        run(&sc, &r);
        report("dominant camera late", &r);
        print_message("  usable beyond 5 sigma %d (worst %.1f sigma)\n", r.sigma_violations, r.worst_sigma);
        assert_true(r.first_detect >= FAULT_CYCLE && r.first_detect <= FAULT_CYCLE + 2);
        assert_int_equal(r.detect_kind, MFNS_BANK_HYP_CAMERA);
        assert_int_equal(r.detect_id, 0);
        assert_int_equal(r.bound_violations, 0);
        assert_int_equal(r.sigma_violations, 0);
    }
}

/* The same camera with its clock in doubt from the dropped frame (the
 * flight program's frame checks see the drop: mfns_bank_doubt_timing):
 * every filter takes its frames with the time offset eliminated, so the
 * late frames do not pull the full filter by a period of motion, and the
 * offset times the reference velocity's error (the direction eliminated is
 * the image motion of the estimated velocity; ten beacons in the late
 * camera and one in each other leave the velocity poorly known) enters
 * every filter's covariance, the same term in each (nav_filter.h
 * tau_bound_s, filter_bank.c). Asserted: no usable fix beyond its PL or
 * beyond 5 sigma, no healthy beacon or camera blamed, and more usable
 * cycles than without the doubt (measured: 55 / 52 / 97 of 100, worst 1.9
 * / 1.5 / 2.2 sigma, nothing excluded; without the doubt 40 / 33 / 37, the
 * camera excluded. Before the offset's term: usable fixes beyond 5 sigma
 * 1 / 0 / 0, worst 11.0 sigma, and a healthy beacon blamed in every run). */
static void test_dominant_camera_late_doubted(void **state)
{
    (void)state;
    static const int DOMINANT[3] = {10, 1, 1};
    for (uint64_t seed = 0; seed < 3; seed++) {
        const scenario_t sc = {F_CAM_DROP_LAG, 0, 0.0, 80.0, 0.03, 40 + seed, 100, DOMINANT, true};
        scenario_t sc0 = sc;
        sc0.doubt_on_drop = false;
        result_t r, r0;
        run(&sc, &r);
        run(&sc0, &r0);
        report("dominant late, doubted", &r);
        print_message("  usable beyond 5 sigma %d (worst %.1f sigma; without the doubt %d, %.1f), doubt cleared @%d\n",
                      r.sigma_violations, r.worst_sigma, r0.sigma_violations, r0.worst_sigma, r.trusted_cycle);
        assert_int_equal(r.bound_violations, 0);
        assert_int_equal(r.sigma_violations, 0);
        assert_int_equal(r.wrong_subject, 0);
        assert_true(r.usable > r0.usable);
        assert_int_equal(r.trusted_cycle, -1); /* a period late reads dirty or without power: never cleared */
        assert_int_equal(r0.bound_violations, 0);
        assert_int_equal(r0.sigma_violations, 0);
    }
}

/* A dropped frame and nothing else, on the 4 + 3 + 3 scene moving at 100
 * mm/s: the doubt the drop raised clears once the camera's clock has read
 * clean with power for the table's hold (19 cycles), and no fix is misled. */
static void test_dropped_frame_doubt_clears(void **state)
{
    (void)state;
    for (int cam = 0; cam < MFNS_NUM_CAMERAS; cam++) {
        const scenario_t sc = {F_CAM_DROP, cam, 0.0, 100.0, 0.05, 60 + (uint64_t)cam, 100, NULL, true};
        result_t r;
        run(&sc, &r);
        report("dropped frame, doubted", &r);
        print_message("  doubt cleared @%d, usable beyond 5 sigma %d\n", r.trusted_cycle, r.sigma_violations);
        assert_true(r.trusted_cycle >= FAULT_CYCLE + 19 && r.trusted_cycle <= FAULT_CYCLE + 40);
        assert_int_equal(r.sigma_violations, 0);
        assert_int_equal(r.bound_violations, 0);
        assert_int_equal(r.first_detect, -1);
        assert_true(r.usable >= 95);
    }
}

static void test_doubt_bad_input(void **state)
{
    (void)state;
    static mfns_filter_bank_t b;
    memset(&b, 0, sizeof b);
    assert_int_equal(mfns_bank_doubt_timing(&b, 0, 0.054f), MFNS_FILTER_E_ARG); /* not initialised */
    const mfns_pose_t pose = {mfns_m3_identity(), mfns_v3(0.0f, 0.0f, 0.0f)};
    float cov[6][6];
    memset(cov, 0, sizeof cov);
    for (int i = 0; i < 6; i++) {
        cov[i][i] = i < 3 ? 1.0f : 1e-6f;
    }
    assert_int_equal(mfns_bank_init(&b, &pose, (const float(*)[6])cov, mfns_v3(0.0f, 0.0f, 0.0f), 10.0f,
                                    mfns_v3(0.0f, 0.0f, 0.0f), 0.01f, 0),
                     MFNS_FILTER_OK);
    assert_int_equal(mfns_bank_doubt_timing(NULL, 0, 0.054f), MFNS_FILTER_E_ARG);
    assert_int_equal(mfns_bank_doubt_timing(&b, -1, 0.054f), MFNS_FILTER_E_ARG);
    assert_int_equal(mfns_bank_doubt_timing(&b, MFNS_NUM_CAMERAS, 0.054f), MFNS_FILTER_E_ARG);
    assert_int_equal(mfns_bank_doubt_timing(&b, 1, 0.0f), MFNS_FILTER_E_ARG);
    assert_int_equal(mfns_bank_doubt_timing(&b, 1, NAN), MFNS_FILTER_E_ARG);
    assert_int_equal(mfns_bank_doubt_timing(&b, 1, INFINITY), MFNS_FILTER_E_ARG);
    /* the offset it resolves is the timing-free update's bound (nav_filter.h) */
    assert_int_equal(mfns_bank_doubt_timing(&b, 1, 1.5f * MFNS_FILTER_CONSIDER_TAU_MAX_S), MFNS_FILTER_E_ARG);
    assert_int_equal(b.timing_doubt[1], 0);
    assert_int_equal(mfns_bank_doubt_timing(&b, 1, 0.054f), MFNS_FILTER_OK);
    assert_int_equal(b.timing_doubt[1], 1);
}

static void test_beacon_readmitted_after_clean_hold(void **state)
{
    (void)state;
    const scenario_t sc = {F_BEACON_PULSE, 3, 1.0, 30.0, 0.02, 31, 0, NULL, false};
    result_t r;
    run(&sc, &r);
    report("beacon pulse 10 cyc", &r);
    mfns_integrity_settings_t is;
    mfns_integrity_settings_default(&is);
    assert_true(r.first_detect >= FAULT_CYCLE && r.first_detect <= FAULT_CYCLE + 2);
    assert_int_equal(r.detect_id, 3);
    /* the fault ends at FAULT_CYCLE + 10; readmitted after hold_cycles clean cycles */
    assert_true(r.readmitted_cycle >= FAULT_CYCLE + 10 + (int)is.hold_cycles - 1);
    assert_true(r.readmitted_cycle <= FAULT_CYCLE + 10 + (int)is.hold_cycles + 5);
    assert_int_equal(r.bound_violations, 0);
}

/* A frame the caller's checks find suspect (mfns_bank_suspect_frame): its
 * cycle is refused as FRAME_SUSPECT naming the camera, and it does not count
 * towards a held beacon's re-admission: the beacon pulse above, with camera
 * 2's frame told suspect in five cycles of the clean hold, is re-admitted
 * five cycles later than without. Told nothing: the bank's own verdict. */
static void test_told_suspect_frame(void **state)
{
    (void)state;
    const scenario_t sc = {F_BEACON_PULSE, 3, 1.0, 30.0, 0.02, 31, 0, NULL, false};
    result_t plain, told;
    run(&sc, &plain);
    const told_t tell = {FAULT_CYCLE + 12, 5, 2};
    run_told(&sc, &tell, &told);
    report("pulse, 5 told suspect", &told);
    assert_true(plain.readmitted_cycle > tell.from + tell.n); /* the told cycles fall inside the hold */
    assert_int_equal(told.suspect_cycles, tell.n);
    assert_int_equal(told.first_suspect, tell.from);
    assert_int_equal(told.suspect_cam, tell.cam);
    assert_int_equal(told.usable, plain.usable - tell.n);
    assert_int_equal(told.readmitted_cycle, plain.readmitted_cycle + tell.n);
    assert_int_equal(told.bound_violations, 0);
    static mfns_filter_bank_t b;
    memset(&b, 0, sizeof b);
    assert_int_equal(mfns_bank_suspect_frame(NULL, 0), MFNS_FILTER_E_ARG);
    assert_int_equal(mfns_bank_suspect_frame(&b, -1), MFNS_FILTER_E_ARG);
    assert_int_equal(mfns_bank_suspect_frame(&b, MFNS_NUM_CAMERAS), MFNS_FILTER_E_ARG);
}

/* A collision: 5 m/s^2 over one frame (0.27 m/s of velocity change, 50x
 * the bound): restart with MOTION_EXCEEDED within two cycles, nothing
 * blamed, no usable cycle beyond its PL before. */
static void assert_collision_restarts(const scenario_t *sc, const char *label)
{
    result_t r;
    run(sc, &r);
    report(label, &r);
    print_message("  restart at cycle %d reason %d\n", r.restart_cycle, r.restart_reason);
    assert_int_equal(r.restarts, 1);
    assert_true(r.restart_cycle >= FAULT_CYCLE && r.restart_cycle <= FAULT_CYCLE + 2);
    assert_int_equal(r.restart_reason, MFNS_POSE_R_MOTION_EXCEEDED);
    assert_int_equal(r.wrong_subject, 0);
    assert_int_equal(r.bound_violations, 0);
}

static void test_collision_restarts(void **state)
{
    (void)state;
    const scenario_t sc = {F_COLLISION, -1, 5000.0, 30.0, 0.02, 41, 0, NULL, false};
    assert_collision_restarts(&sc, "collision 5 m/s^2");
}

/* A hard hit (20 m/s^2 over one frame, 1 m/s) seen by one dominant camera
 * (10 beacons) and two cameras of one beacon each (the module's sparse
 * views, grown campaign seed 5): the dominant camera's frame fails as a
 * whole and the others' single beacons fail too, which no single camera or
 * beacon fault does: MOTION_EXCEEDED at the onset. Before the bank counted
 * a one-beacon camera whose observation failed (only frames of two or more
 * failing observations counted), the first seed flew one usable fix 2.85 x
 * beyond its PL and restarted a cycle late; the campaign's 15 deg/s yaw
 * step on seed 5 had camera x excluded instead. */
static void test_collision_dominant_camera(void **state)
{
    (void)state;
    static const int DOMINANT[3] = {10, 1, 1};
    for (uint64_t seed = 0; seed < 3; seed++) {
        const scenario_t sc = {F_COLLISION, -1, 20000.0, 30.0, 0.02, 51 + seed, 0, DOMINANT, false};
        assert_collision_restarts(&sc, "collision, dominant");
    }
}

/* A camera's mount turning slowly, 0.005 deg per cycle (0.09 deg/s): inside
 * one frame's residuals for many cycles. The camera's hypothesis filter
 * follows it in its pointing bias, the full filter is pulled: named from
 * the separation, no usable error beyond its PL before. */
static void test_camera_pointing_ramp(void **state)
{
    (void)state;
    for (int cam = 0; cam < MFNS_NUM_CAMERAS; cam++) {
        const scenario_t sc = {F_CAM_RAMP, cam, 0.005, 30.0, 0.02, 50 + (uint64_t)cam, 0, NULL, false};
        expect_detected("camera ramp .005 deg/c", &sc, 60);
    }
}

/* The module's seed-2 geometry: two cameras see beacons, 2-4 each, the
 * third none. Dropping a camera left the other's 2-3 beacons and the motion
 * model (PL 120-320 mm on the module replay); the camera hypothesis keeps
 * what its camera's frames say whatever its pointing and timing (3 beacons:
 * 2 numbers a frame): the camera hypotheses' PL stays bounded, nothing is
 * blamed, the error stays inside its PL. */
static const int TWO_CAM[2][3] = {{3, 3, 0}, {4, 2, 0}};

static void test_two_camera_scene_bounded(void **state)
{
    (void)state;
    for (int g = 0; g < 2; g++) {
        for (uint64_t seed = 60; seed < 62; seed++) {
            const scenario_t sc = {F_NONE, -1, 0.0, 30.0, 0.02, seed + 10U * (uint64_t)g, 0, TWO_CAM[g], false};
            result_t r;
            run(&sc, &r);
            report("two cameras clean", &r);
            print_message("  PL max %.2f mm (beacon hypotheses alone %.2f mm), sigma_pos max %.3f mm\n",
                          r.max_pl_any_pos, r.max_pl_beacon_pos, r.max_sigma_pos);
            assert_int_equal(r.restarts, 0);
            assert_int_equal(r.first_detect, -1);
            assert_int_equal(r.bound_violations, 0);
            assert_true(isfinite(r.max_pl_any_pos));
            /* measured: PL max 3.3 / 3.2 / 16.4 / 18.4 mm, usable 120 / 120
             * / 120 / 107 of 120 (sigma_pos <= 0.3 mm; at P_md 1e-5, 87 of
             * 120 in the last). The camera
             * hypotheses take their frames with pointing and timing
             * eliminated (mfns_filter_update_invariant): the 2-beacon
             * camera's frame (4 numbers) then tells its hypothesis nothing,
             * which the earlier per-frame prior (1 deg, 60 ms) did not admit
             * (118 of 120 there, with a prior a stale or frozen frame
             * exceeds). The camera-dropping bank gave 120-320 mm on the
             * module's replay. */
            assert_true(r.max_pl_any_pos <= 40.0);
            assert_true(r.usable * 100 >= r.evaluated * 85);
        }
    }
}

/* A pointing step and a slow pointing ramp on one of the two cameras of
 * that geometry: detected (the step named), no usable error beyond its PL. (A one-frame lag on
 * a 3-beacon camera of this geometry is NOT yet handled: on seed 90 the
 * separation of beacon 1's hypothesis fails first, beacon 1 is excluded and
 * one usable cycle is beyond its PL (1.30); docs/pose.md.) */
static void test_two_camera_scene_faults(void **state)
{
    (void)state;
    for (int cam = 0; cam < 2; cam++) {
        /* the first exclusion names the camera at onset; after it one camera
         * of 3 beacons is left and the bank restarts from the diffuse prior
         * (filter_bank.c restart_diffuse): nothing is certifiable (PL
         * beyond the alert limit, not usable), later exclusions in that
         * state may name other subjects and the bank may coast out
         * (measured on camera 0: beacon 3 and camera 1 excluded, a restart
         * at cycle 63 when nothing was left to take) -- only the first
         * exclusion, a restart after it and the bound are asserted */
        const scenario_t step = {F_CAM_POINTING, cam, 0.3, 30.0, 0.02, 80 + (uint64_t)cam, 0, TWO_CAM[0], false};
        result_t rs;
        run(&step, &rs);
        report("2 cams: 0.3 deg", &rs);
        assert_true(rs.restarts == 0 || rs.restart_cycle > rs.first_detect);
        assert_true(rs.first_detect >= FAULT_CYCLE && rs.first_detect <= FAULT_CYCLE + 2);
        assert_int_equal(rs.detect_kind, MFNS_BANK_HYP_CAMERA);
        assert_int_equal(rs.detect_id, cam);
        assert_int_equal(rs.bound_violations, 0);
        /* a slow ramp of one of two cameras is a change of their relative
         * pointing: either camera's hypothesis explains it (the motion model
         * alone could tell them apart, and its bound allows the rotation):
         * measured with the per-frame prior, camera 0's ramp named camera 1
         * at +16 cycles and camera 1's named camera 0 at +11; with the
         * fault parameters eliminated camera 0's names camera 0 at +16 and
         * camera 1's still camera 0 at +11 -- a known defect (docs/pose.md);
         * what is asserted is the detection and the bound */
        const scenario_t ramp = {F_CAM_RAMP, cam, 0.005, 30.0, 0.02, 85 + (uint64_t)cam, 0, TWO_CAM[0], false};
        result_t r;
        run(&ramp, &r);
        report("2 cams: .005 deg/cycle", &r);
        assert_int_equal(r.restarts, 0);
        assert_true(r.first_detect >= FAULT_CYCLE && r.first_detect <= FAULT_CYCLE + 60);
        assert_int_equal(r.detect_kind, MFNS_BANK_HYP_CAMERA);
        assert_int_equal(r.bound_violations, 0);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_clean_runs),
        cmocka_unit_test(test_frame_suspect),
        cmocka_unit_test(test_beacon_step_gated),
        cmocka_unit_test(test_beacon_small_step_bounded),
        cmocka_unit_test(test_beacon_slow_ramp),
        cmocka_unit_test(test_camera_pointing_step),
        cmocka_unit_test(test_camera_one_frame_late),
        cmocka_unit_test(test_dominant_camera_late),
        cmocka_unit_test(test_dominant_camera_late_doubted),
        cmocka_unit_test(test_dropped_frame_doubt_clears),
        cmocka_unit_test(test_doubt_bad_input),
        cmocka_unit_test(test_beacon_readmitted_after_clean_hold),
        cmocka_unit_test(test_told_suspect_frame),
        cmocka_unit_test(test_collision_restarts),
        cmocka_unit_test(test_collision_dominant_camera),
        cmocka_unit_test(test_camera_pointing_ramp),
        cmocka_unit_test(test_two_camera_scene_bounded),
        cmocka_unit_test(test_two_camera_scene_faults),
    };
    return cmocka_run_group_tests_name("filter_bank", tests, NULL, NULL);
}
