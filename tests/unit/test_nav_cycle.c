/* End-to-end test of firmware/nav/nav_cycle: frames rendered here from a known
 * pose go through centroiding, the table's distortion grid, identification
 * and the pose solve; the pose must come back, in ACQUIRE and TRACK modes, and
 * bad cycles must never leave a pose marked valid. Uses the default table
 * built by the Python generator (build/gen/default.mfnstbl) with its beacon
 * map replaced by beacons placed in view of all three cameras. */
#include "tests/unit/support/testutil.h"

#include <string.h>

#include "firmware/nav/map/beacon_index.h"
#include "firmware/app/caltable_file.h"
#include "firmware/nav/cycle/nav_cycle.h"
#include "firmware/host/beacon_index_build.h"

#define W 1280
#define H 1024
#define PER_CAM 4

static uint8_t table_buf[MFNS_CALTABLE_MAX_BYTES];
static mfns_caltable_t table;
static mfns_nav_t nav;
static mfns_nav_output_t out;
static uint8_t img[MFNS_NUM_CAMERAS][H][W];
static mfns_pose_t truth;

static double phi(double x) { return 0.5 * erfc(-x / sqrt(2.0)); }

/* Pixel-integrated Gaussian spot of total flux `flux` DN at (u, v). */
static void render_spot(uint8_t (*im)[W], double u, double v, double sigma, double flux)
{
    for (int y = (int)v - 7; y <= (int)v + 7; y++) {
        for (int x = (int)u - 7; x <= (int)u + 7; x++) {
            if (x < 0 || y < 0 || x >= W || y >= H) {
                continue;
            }
            const double fx = phi((x + 0.5 - u) / sigma) - phi((x - 0.5 - u) / sigma);
            const double fy = phi((y + 0.5 - v) / sigma) - phi((y - 0.5 - v) / sigma);
            const double val = im[y][x] + flux * fx * fy;
            im[y][x] = (uint8_t)(val > 255.0 ? 255.0 : val + 0.5);
        }
    }
}

static void render_background(mfns_rng_t *rng)
{
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        for (int y = 0; y < H; y++) {
            for (int x = 0; x < W; x++) {
                img[k][y][x] = (uint8_t)(12.0 + 1.5 * mfns_rng_normal(rng) + 0.5);
            }
        }
    }
}

static void render_beacons(void)
{
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        for (uint16_t b = 0; b < table.beacons.count; b++) {
            float uv[2];
            if (mfns_cam_project(&table.rig.cam[k], &truth, table.beacons.beacon[b].p_w, uv, NULL) == MFNS_PROJ_OK &&
                uv[0] > 10 && uv[1] > 10 && uv[0] < W - 10 && uv[1] < H - 10) {
                render_spot(img[k], uv[0], uv[1], 1.2, 1500.0);
            }
        }
    }
}

static int setup(void **state)
{
    (void)state;
    char path[512];
    snprintf(path, sizeof path, "%s/default.mfnstbl", mfns_test_gen_dir());
    uint32_t off = 0;
    const mfns_caltable_status_t st = mfns_caltable_load_file(path, table_buf, sizeof table_buf, &table, &off);
    if (st != MFNS_CALTABLE_OK) {
        print_error("cannot load %s: %s\n", path, mfns_caltable_strerror(st));
        return -1;
    }
    truth = mfns_pose_from_position(mfns_euler213_to_m3((mfns_euler_t){0.02f, -0.03f, 0.5236f}),
                                    mfns_v3(20.0f, -10.0f, 5.0f));
    /* Beacons about 1 m in front of each camera, spread over its image. */
    const float pc[PER_CAM][3] = {{-200, -150, 1000}, {180, -120, 1100}, {-150, 170, 950}, {220, 160, 1200}};
    table.beacons.count = 0;
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        for (int i = 0; i < PER_CAM; i++) {
            const mfns_camera_t *c = &table.rig.cam[k];
            const mfns_v3_t pb = mfns_v3_add(mfns_m3_mul_v3(c->C_k_b, mfns_v3(pc[i][0], pc[i][1], pc[i][2])), c->r_bk_b);
            mfns_beacon_t *b = &table.beacons.beacon[table.beacons.count++];
            b->id = (uint16_t)(100 + k * PER_CAM + i);
            b->p_w = mfns_m3_tmul_v3(truth.C_w_b, mfns_v3_sub(pb, truth.r_bw_b));
            b->sigma_mm = 0.3f;
        }
    }
    /* the map changed: its index too, over a workspace around the truth */
    mfns_bidx_params_t par;
    mfns_bidx_params_default(&par);
    const mfns_v3_t r = mfns_pose_position_w(&truth);
    const mfns_v3_t d = mfns_v3(300.0f, 300.0f, 300.0f);
    if (mfns_bidx_build(&table.rig, &table.beacons, NULL, mfns_v3_sub(r, d), mfns_v3_add(r, d), &par, &table.index) !=
        MFNS_BIDX_OK) {
        print_error("cannot build the map index\n");
        return -1;
    }
    return 0;
}

static mfns_frame_t frame_of(int k)
{
    return (mfns_frame_t){img[k], W, H, W, MFNS_PIXFMT_GREY};
}

static void dump(void)
{
    print_message("sol status %d reason %s used %u hyp %u rms %.3f iters %u\n", out.sol.status,
                  mfns_pose_strerror(out.sol.reason), out.sol.beacons_used, out.sol.hypotheses,
                  (double)out.sol.residual_rms_px, out.sol.iterations);
    for (int k = 0; k < 3; k++) {
        print_message(" cam %d state %d blobs %u acc %u obs %u id %u undist_fail %u bg %.1f noise %.2f\n", k,
                      out.cam[k].state, out.cam[k].blobs, out.cam[k].accepted, out.cam[k].observations,
                      out.cam[k].identified, out.cam[k].undistort_failures, (double)out.cam[k].background_dn,
                      (double)out.cam[k].noise_dn);
    }
}

static void assert_pose_close(const mfns_pose_solution_t *s)
{
    const mfns_v3_t r = mfns_pose_position_w(&truth);
    assert_near(s->r_wb_w.x, r.x, 0.5);
    assert_near(s->r_wb_w.y, r.y, 0.5);
    assert_near(s->r_wb_w.z, r.z, 0.5);
    assert_true(mfns_rot_angle_between(s->pose.C_w_b, truth.C_w_b) < (float)(0.02 * MFNS_PI / 180.0));
}

/* The first two fixes after a gap (start-up, re-acquisition) on two or more
 * cameras: no motion is known yet to test the cameras for a lag
 * (integrity_lag.h), so each is NO_FIX LAG_UNTESTED, right, and carries the
 * track (next mode TRACK, no coasting). */
static void assert_lag_untested(void)
{
    assert_int_equal(out.sol.status, MFNS_POSE_NO_FIX);
    assert_int_equal(out.sol.reason, MFNS_POSE_R_LAG_UNTESTED);
    assert_true(out.sol.beacons_used > 0u);
    assert_pose_close(&out.sol);
    assert_int_equal(out.next_mode, MFNS_NAV_MODE_TRACK);
    assert_int_equal(out.coasting, 0);
}

static void test_acquire_then_track(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 99);
    render_background(&rng);
    render_beacons();
    const mfns_frame_t f0 = frame_of(0), f1 = frame_of(1), f2 = frame_of(2);
    const mfns_frame_t *const frames[3] = {&f0, &f1, &f2};
    assert_int_equal(mfns_nav_init(&nav, &table, MFNS_POSE_MODE_ML), MFNS_NAV_OK);

    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    if (out.sol.status != MFNS_POSE_OK) {
        dump(); /* diagnostics for the failure below */
    }
    assert_int_equal(out.mode, MFNS_NAV_MODE_ACQUIRE);
    assert_lag_untested(); /* the first fix: no motion yet */
    for (int k = 0; k < 3; k++) {
        assert_int_equal(out.cam[k].state, MFNS_NAV_CAM_OK);
        assert_int_equal(out.cam[k].accepted, PER_CAM);
        assert_int_equal(out.cam[k].identified, PER_CAM);
        assert_int_equal(out.cam[k].rois, 0);
    }
    assert_int_equal(out.next_mode, MFNS_NAV_MODE_TRACK);
    assert_true(out.mode_changed);

    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.mode, MFNS_NAV_MODE_TRACK);
    assert_false(out.reacquired);
    assert_lag_untested(); /* the second: one step of motion, none to test against */
    for (int k = 0; k < 3; k++) {
        assert_true(out.cam[k].rois > 0); /* only windows were read */
        assert_int_equal(out.cam[k].identified, PER_CAM);
    }
    assert_false(out.mode_changed);
    /* the third fix is tested against the first two's motion: usable */
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.mode, MFNS_NAV_MODE_TRACK);
    assert_int_equal(out.sol.status, MFNS_POSE_OK);
    assert_pose_close(&out.sol);
}

/* A budget far too small for one cycle: the navigator's acquisition carries
 * its search over the next cycles (acquire_cycle.h) and gets the fix from it,
 * verified on the current frames, with no fix reported before; then it
 * tracks. */
static void test_search_carried_over_cycles(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 97);
    render_background(&rng);
    render_beacons();
    const mfns_frame_t f0 = frame_of(0), f1 = frame_of(1), f2 = frame_of(2);
    const mfns_frame_t *const frames[3] = {&f0, &f1, &f2};
    assert_int_equal(mfns_nav_init(&nav, &table, MFNS_POSE_MODE_ML), MFNS_NAV_OK);
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_lag_untested();
    const uint32_t need = out.acq.units_total, saved = table.index.budget_units;
    assert_true(need >= 10u);
    /* a fifth of the search a cycle, and room for three catch-up steps (the
     * carried identification is tracked through the frames since its own) */
    table.index.budget_units = need / 5u + 3u * MFNS_ACQ_CATCHUP_STEP_UNITS;
    assert_int_equal(mfns_nav_init(&nav, &table, MFNS_POSE_MODE_ML), MFNS_NAV_OK);
    int cycles = 0;
    bool carried_seen = false;
    for (; cycles < 40; cycles++) {
        assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
        assert_int_equal(out.mode, MFNS_NAV_MODE_ACQUIRE);
        assert_true(out.acquired);
        assert_true(out.acq.units <= table.index.budget_units + 4u * MFNS_ACQ_VERIFY_UNITS + 64u);
        carried_seen = carried_seen || out.acq_carry_age > 0u;
        if (out.sol.status != MFNS_POSE_NO_FIX || out.sol.reason == MFNS_POSE_R_LAG_UNTESTED) {
            break;
        }
    }
    table.index.budget_units = saved;
    print_message("fix after %d cycles at %u units a cycle (one cycle needs %u)\n", cycles + 1,
                  need / 5u + 3u * MFNS_ACQ_CATCHUP_STEP_UNITS, need);
    assert_true(cycles >= 2);
    assert_true(carried_seen);
    assert_lag_untested(); /* the first fix after the search: no motion yet */
    assert_int_equal(out.acq_source, MFNS_ACQ_SRC_CARRIED);
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.mode, MFNS_NAV_MODE_TRACK);
    assert_lag_untested();
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.mode, MFNS_NAV_MODE_TRACK);
    assert_int_equal(out.sol.status, MFNS_POSE_OK);
}

static void test_dead_camera_is_reported_and_others_still_solve(void **state)
{
    (void)state;
    const mfns_frame_t f0 = frame_of(0), f2 = frame_of(2);
    const mfns_frame_t *const frames[3] = {&f0, NULL, &f2};
    assert_int_equal(mfns_nav_init(&nav, &table, MFNS_POSE_MODE_ML), MFNS_NAV_OK);
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.cam[1].state, MFNS_NAV_CAM_NO_FRAME);
    assert_int_equal(out.cam[1].observations, 0);
    if (out.sol.status == MFNS_POSE_NO_FIX) {
        dump();
        print_message("acq units %u hyp %u band %u anchors %u best %u/%u budget_out %d finished %d\n", out.acq.units,
                      out.acq.hypotheses, out.acq.band, out.acq.anchors, out.acq.best_inliers, out.acq.best_missing,
                      out.acq.budget_out, out.acq.finished);
    }
    /* 8 beacons in two cameras: a lag between them is possible, and the
     * first two fixes have no motion to test it: held, carrying the track */
    assert_lag_untested();
    assert_int_equal(out.sol.cameras_used, 2);
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_lag_untested();
    /* then a usable pose, flagged as not nominal */
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.sol.status, MFNS_POSE_DEGRADED);
    assert_int_equal(out.sol.cameras_used, 2);
    assert_pose_close(&out.sol);
}

static void test_no_beacons_gives_no_fix_and_drops_the_prior(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 5);
    const mfns_frame_t f0 = frame_of(0), f1 = frame_of(1), f2 = frame_of(2);
    const mfns_frame_t *const frames[3] = {&f0, &f1, &f2};
    assert_int_equal(mfns_nav_init(&nav, &table, MFNS_POSE_MODE_ML), MFNS_NAV_OK);
    render_background(&rng);
    render_beacons();
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_lag_untested();
    /* the LEDs go dark: tracking fails, the retry on whole frames fails too */
    render_background(&rng);
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_true(out.reacquired);
    assert_int_equal(out.sol.status, MFNS_POSE_NO_FIX);
    assert_int_equal(out.sol.reason, MFNS_POSE_R_TOO_FEW);
    /* the prediction coasts (a search prior only, never output as a fix) ... */
    assert_int_equal(out.coasting, 1);
    assert_int_equal(out.next_mode, MFNS_NAV_MODE_TRACK);
    for (int i = 2; i <= MFNS_NAV_MAX_COAST; i++) {
        assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
        assert_int_equal(out.sol.status, MFNS_POSE_NO_FIX);
        assert_int_equal(out.coasting, i);
    }
    /* ... for a bounded number of cycles, then the prior is dropped */
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.sol.status, MFNS_POSE_NO_FIX);
    assert_int_equal(out.coasting, 0);
    assert_int_equal(out.next_mode, MFNS_NAV_MODE_ACQUIRE);
    assert_false(nav.have_prior);
    /* every camera dead */
    const mfns_frame_t *const none[3] = {NULL, NULL, NULL};
    assert_int_equal(mfns_nav_cycle(&nav, none, &out), MFNS_NAV_OK);
    assert_int_equal(out.sol.status, MFNS_POSE_NO_FIX);
    for (int k = 0; k < 3; k++) {
        assert_int_equal(out.cam[k].state, MFNS_NAV_CAM_NO_FRAME);
    }
    /* the LEDs come back: acquisition again; the gap restarted the motion,
     * so two fixes are held before one is usable */
    render_beacons();
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.mode, MFNS_NAV_MODE_ACQUIRE);
    assert_lag_untested();
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.mode, MFNS_NAV_MODE_TRACK);
    assert_lag_untested();
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.sol.status, MFNS_POSE_OK);
    assert_pose_close(&out.sol);
}

/* A gap of one cycle in a running track (the LEDs dark once): the motion
 * restarts, the two fixes after it are NO_FIX LAG_UNTESTED and carry the
 * track, the third is usable again (the case of fault_acceptance --seed 11:
 * a camera two periods stale, re-acquired after a gap, was usable on those
 * two fixes before the lag was found). */
static void test_gap_holds_two_fixes_untested(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 31);
    const mfns_frame_t f0 = frame_of(0), f1 = frame_of(1), f2 = frame_of(2);
    const mfns_frame_t *const frames[3] = {&f0, &f1, &f2};
    assert_int_equal(mfns_nav_init(&nav, &table, MFNS_POSE_MODE_ML), MFNS_NAV_OK);
    render_background(&rng);
    render_beacons();
    for (int i = 0; i < 2; i++) {
        assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
        assert_lag_untested();
    }
    for (int i = 0; i < 3; i++) {
        assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
        assert_int_equal(out.sol.status, MFNS_POSE_OK);
    }
    render_background(&rng); /* one cycle dark */
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.sol.status, MFNS_POSE_NO_FIX);
    assert_true(out.sol.reason != MFNS_POSE_R_LAG_UNTESTED);
    render_beacons();
    for (int i = 0; i < 2; i++) {
        assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
        assert_lag_untested();
        assert_int_equal(out.sol.cameras_used, 3);
    }
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.sol.status, MFNS_POSE_OK);
    assert_pose_close(&out.sol);
}

static void test_tracking_from_a_given_pose(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 21);
    render_background(&rng);
    render_beacons();
    const mfns_frame_t f0 = frame_of(0), f1 = frame_of(1), f2 = frame_of(2);
    const mfns_frame_t *const frames[3] = {&f0, &f1, &f2};
    assert_int_equal(mfns_nav_init(&nav, &table, MFNS_POSE_MODE_ML), MFNS_NAV_OK);
    /* a hint 5 mm and ~0.3 deg off: tracked, not acquired */
    float d[6] = {0.003f, -0.002f, 0.004f, 5.0f, 0.0f, 0.0f};
    const mfns_pose_t hint = mfns_pose_apply(&truth, d);
    assert_int_equal(mfns_nav_set_prior(&nav, &hint), MFNS_NAV_OK);
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.mode, MFNS_NAV_MODE_TRACK);
    assert_false(out.reacquired);
    assert_lag_untested(); /* a hint is no motion: the first fix is held */
    /* a hint far off (180 deg): the beacons do not confirm it and the pose
     * comes from acquisition instead (inside the solver or by the cycle's retry) */
    float far[6] = {0.0f, 0.0f, 3.14159f, 0.0f, 0.0f, 0.0f};
    const mfns_pose_t wrong = mfns_pose_apply(&truth, far);
    assert_int_equal(mfns_nav_set_prior(&nav, &wrong), MFNS_NAV_OK);
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    /* windows around wrongly predicted beacons may miss a camera's beacons
     * this cycle (DEGRADED), but the pose is right and is never a guess ... */
    assert_true(out.sol.status == MFNS_POSE_OK || out.sol.status == MFNS_POSE_DEGRADED ||
                out.sol.reason == MFNS_POSE_R_LAG_UNTESTED);
    assert_pose_close(&out.sol);
    /* ... and the next cycle tracks from it with every camera */
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.mode, MFNS_NAV_MODE_TRACK);
    assert_int_equal(out.sol.status, MFNS_POSE_OK);
    assert_pose_close(&out.sol);
    /* not a rotation, or not finite: refused */
    mfns_pose_t bad = truth;
    bad.C_w_b.m[0][0] = 2.0f;
    assert_int_equal(mfns_nav_set_prior(&nav, &bad), MFNS_NAV_E_ARG);
    bad = truth;
    bad.r_bw_b.x = NAN;
    assert_int_equal(mfns_nav_set_prior(&nav, &bad), MFNS_NAV_E_ARG);
}

/* The robot leaves the table's workspace box (workspace_watch.h). Moving the
 * box away from the still robot stands for the robot moving out of it: the
 * tracked fixes stay usable and the exit is reported once; the track lost
 * out there, an acquisition -- even a right one, with the box back around
 * the robot -- is refused (OUTSIDE_WORKSPACE) and carries nothing, cycle
 * after cycle; an operator's pose, tracked inside, ends it; a new table too. */
static void test_leaving_the_workspace(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 17);
    const mfns_frame_t f0 = frame_of(0), f1 = frame_of(1), f2 = frame_of(2);
    const mfns_frame_t *const frames[3] = {&f0, &f1, &f2};
    const mfns_v3_t lo = table.index.ws_min_w, hi = table.index.ws_max_w;
    assert_int_equal(mfns_nav_init(&nav, &table, MFNS_POSE_MODE_ML), MFNS_NAV_OK);
    render_background(&rng);
    render_beacons();
    for (int i = 0; i < 3; i++) {
        assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
        assert_int_equal(out.ws_state, MFNS_WS_INSIDE);
        assert_false(out.ws.left);
    }
    assert_int_equal(out.sol.status, MFNS_POSE_OK);
    /* the box 1 m further along x: the tracked pose is 400 mm beyond it */
    table.index.ws_min_w.x += 1000.0f;
    table.index.ws_max_w.x += 1000.0f;
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.mode, MFNS_NAV_MODE_TRACK);
    assert_int_equal(out.sol.status, MFNS_POSE_OK); /* tracking does not rely on the box */
    assert_pose_close(&out.sol);
    assert_true(out.ws.left);
    assert_int_equal(out.ws.axes, 1);
    assert_near(out.ws.beyond_mm, 1000.0 - 300.0 - (double)out.ws.tol_mm, 1.0);
    assert_int_equal(out.ws_state, MFNS_WS_OUTSIDE);
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.sol.status, MFNS_POSE_OK);
    assert_false(out.ws.left); /* once */
    /* the LEDs go dark until the track is dropped */
    render_background(&rng);
    for (int i = 0; i <= MFNS_NAV_MAX_COAST; i++) {
        assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
        assert_int_equal(out.ws_state, MFNS_WS_OUTSIDE);
    }
    assert_int_equal(out.next_mode, MFNS_NAV_MODE_ACQUIRE);
    /* the box back around the robot, the LEDs back: the acquisition finds the
     * pose, but the robot was last seen outside: refused, nothing carried */
    table.index.ws_min_w = lo;
    table.index.ws_max_w = hi;
    render_beacons();
    for (int i = 0; i < 3; i++) {
        assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
        assert_true(out.acquired);
        assert_int_equal(out.sol.status, MFNS_POSE_NO_FIX);
        assert_int_equal(out.sol.reason, MFNS_POSE_R_OUTSIDE_WORKSPACE);
        assert_int_equal(out.sol.beacons_used, 0);
        assert_int_equal(out.next_mode, MFNS_NAV_MODE_ACQUIRE);
        assert_int_equal(out.ws_state, MFNS_WS_OUTSIDE);
        assert_false(out.ws.reentered);
    }
    /* the operator's pose, tracked inside the box: the state ends */
    float d[6] = {0.002f, 0.0f, -0.002f, 3.0f, -2.0f, 0.0f};
    const mfns_pose_t hint = mfns_pose_apply(&truth, d);
    assert_int_equal(mfns_nav_set_prior(&nav, &hint), MFNS_NAV_OK);
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_false(out.acquired);
    assert_lag_untested();
    assert_true(out.ws.reentered);
    assert_true(out.ws.cycles_outside >= (uint32_t)MFNS_NAV_MAX_COAST + 4U);
    assert_int_equal(out.ws_state, MFNS_WS_INSIDE);
    /* a new table (init) takes its box as declared */
    table.index.ws_min_w.x += 1000.0f;
    table.index.ws_max_w.x += 1000.0f;
    for (int i = 0; i < 3; i++) {
        assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    }
    assert_int_equal(out.ws_state, MFNS_WS_OUTSIDE);
    table.index.ws_min_w = lo;
    table.index.ws_max_w = hi;
    assert_int_equal(mfns_nav_init(&nav, &table, MFNS_POSE_MODE_ML), MFNS_NAV_OK);
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.ws_state, MFNS_WS_INSIDE);
    assert_lag_untested();
}

/* Three beacons in view: a pose without redundancy is usable only while
 * tracking and only when it agrees with the prediction (issue 17: a wrong
 * identification of three blobs cannot be caught in the frame). */
static void render_first_beacons(int n, mfns_rng_t *rng)
{
    render_background(rng);
    for (int b = 0; b < n; b++) {
        float uv[2];
        if (mfns_cam_project(&table.rig.cam[0], &truth, table.beacons.beacon[b].p_w, uv, NULL) == MFNS_PROJ_OK) {
            render_spot(img[0], uv[0], uv[1], 1.2, 1500.0);
        }
    }
}

static void test_three_beacons_track_but_never_usable(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 77);
    render_first_beacons(3, &rng); /* three of camera x's beacons */
    const mfns_frame_t f0 = frame_of(0), f1 = frame_of(1), f2 = frame_of(2);
    const mfns_frame_t *const frames[3] = {&f0, &f1, &f2};
    /* no prior: acquisition never answers three blobs */
    assert_int_equal(mfns_nav_init(&nav, &table, MFNS_POSE_MODE_ML), MFNS_NAV_OK);
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.sol.status, MFNS_POSE_NO_FIX);
    assert_int_equal(out.sol.reason, MFNS_POSE_R_BELOW_CERTIFICATE);
    /* tracking from a prior 0.5 mm off: the minimal pose agrees: it carries
     * the track on (next mode TRACK) but is never usable (issue 23: three
     * beacons leave no redundancy to check a fault) */
    mfns_pose_t near = truth;
    near.r_bw_b.x += 0.5f;
    assert_int_equal(mfns_nav_set_prior(&nav, &near), MFNS_NAV_OK);
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.sol.status, MFNS_POSE_NO_FIX);
    assert_int_equal(out.sol.reason, MFNS_POSE_R_MINIMAL);
    assert_int_equal(out.next_mode, MFNS_NAV_MODE_TRACK);
    assert_int_equal(out.coasting, 0);
    assert_false(out.integrity.evaluated);
    assert_pose_close(&out.sol);
    /* a prior 40 mm off along camera x's axis (its images move little: still
     * inside the tracking windows and gate): the three blobs give the true
     * pose, which disagrees with the prediction by far more than both
     * uncertainties: refused, never reported as usable */
    mfns_pose_t far = truth;
    far.r_bw_b.x += 40.0f;
    assert_int_equal(mfns_nav_set_prior(&nav, &far), MFNS_NAV_OK);
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.sol.status, MFNS_POSE_NO_FIX);
    assert_int_equal(out.sol.reason, MFNS_POSE_R_MINIMAL_UNCONFIRMED);
}

/* A table re-loaded while tracking (issue 45): the same system with other settings and
 * sigmas is re-bound keeping the track (the next cycle tracks, no re-acquisition) and
 * its sigmas and motion bound count; a moved beacon or a changed rig is refused (nav untouched) so the
 * caller binds afresh. */
static mfns_caltable_t table2;
static void test_rebind_keeps_the_track_of_the_same_system(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 99);
    render_background(&rng);
    render_beacons();
    const mfns_frame_t f0 = frame_of(0), f1 = frame_of(1), f2 = frame_of(2);
    const mfns_frame_t *const frames[3] = {&f0, &f1, &f2};
    assert_int_equal(mfns_nav_init(&nav, &table, MFNS_POSE_MODE_ML), MFNS_NAV_OK);
    for (int c = 0; c < 3; c++) {
        assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    }
    assert_int_equal(out.next_mode, MFNS_NAV_MODE_TRACK);
    bool kept = false;

    table2 = table; /* a moved beacon: another system */
    table2.beacons.beacon[0].p_w.x += 1.0f;
    const mfns_pose_t prior = nav.prior;
    assert_int_equal(mfns_nav_rebind(&nav, &table2, &kept), MFNS_NAV_OK);
    assert_false(kept);
    assert_ptr_equal(nav.table, &table); /* untouched */
    table2 = table; /* a turned camera: another system */
    table2.rig.cam[1].C_k_b.m[0][1] += 1e-6f;
    assert_int_equal(mfns_nav_rebind(&nav, &table2, &kept), MFNS_NAV_OK);
    assert_false(kept);
    assert_memory_equal(&nav.prior, &prior, sizeof prior);

    table2 = table; /* the same system, looser beacons and another pixel sigma */
    for (uint32_t b = 0; b < table2.beacons.count; b++) {
        table2.beacons.beacon[b].sigma_mm *= 2.0f;
    }
    table2.pixel_sigma_px *= 1.5f;
    table2.motion.accel_bound_mm_s2 = 0.5f * table.motion.accel_bound_mm_s2; /* an uploaded motion bound */
    assert_int_equal(mfns_nav_rebind(&nav, &table2, &kept), MFNS_NAV_OK);
    assert_true(kept);
    assert_true(nav.table->motion.accel_bound_mm_s2 == table2.motion.accel_bound_mm_s2); /* the filter's next cycle */
    assert_ptr_equal(nav.table, &table2);
    assert_true(nav.map.beacon[0].sigma_mm == table2.beacons.beacon[0].sigma_mm);
    assert_true(nav.pose_cfg.sigma_px == table2.pixel_sigma_px);
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.mode, MFNS_NAV_MODE_TRACK); /* the track went on */
    assert_false(out.acquired);
    assert_int_equal(out.sol.status, MFNS_POSE_OK);
    assert_pose_close(&out.sol);

    assert_int_equal(mfns_nav_rebind(NULL, &table2, &kept), MFNS_NAV_E_ARG);
    assert_int_equal(mfns_nav_rebind(&nav, NULL, &kept), MFNS_NAV_E_ARG);
    assert_int_equal(mfns_nav_rebind(&nav, &table2, NULL), MFNS_NAV_E_ARG);
}

/* A fresh navigator with the filter on (54 ms), the scene rendered from
 * seed, flown on the same frames until the filter's output is used (within
 * 30 cycles; the frames never move, so no camera's spots jump): the cycle
 * it was first used. */
static int fly_until_filter_used(uint64_t seed, const mfns_frame_t *const frames[3])
{
    mfns_rng_t rng;
    mfns_rng_seed(&rng, seed);
    assert_int_equal(mfns_nav_init(&nav, &table, MFNS_POSE_MODE_ML), MFNS_NAV_OK);
    assert_int_equal(mfns_nav_enable_filter(&nav, 54000), MFNS_NAV_OK);
    render_background(&rng);
    render_beacons();
    int used_at = -1;
    for (int i = 0; i < 30 && used_at < 0; i++) {
        assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
        assert_int_equal(out.spots.jump_mask, 0);
        used_at = out.filt.used ? i : -1;
    }
    assert_true(used_at >= 0);
    return used_at;
}

/* The filter on, a static robot seen by all three cameras: once the
 * filter's output is used, a cycle in which the time-offset monitor holds a
 * camera as lagging (integrity_lag.h cam_lag 1, set here as the monitor
 * would) refuses the filter's fix, NO_FIX FRAME_SUSPECT naming that camera
 * (nav_filter_cycle.h mfns_navf_suspect_frame), and a camera held only to
 * verify it after an outage (cam_lag 2) refuses nothing. */
static void test_lagging_camera_refuses_the_filter_fix(void **state)
{
    (void)state;
    const mfns_frame_t f0 = frame_of(0), f1 = frame_of(1), f2 = frame_of(2);
    const mfns_frame_t *const frames[3] = {&f0, &f1, &f2};
    const int used_at = fly_until_filter_used(41, frames);
    /* held to verify after an outage, as the monitor holds it: no suspicion */
    (void)mfns_integrity_hold_lagging(&nav.integ_mem, 2, 2U, table.integrity.hold_cycles);
    nav.integ_mem.lag_verify[2] = MFNS_INTEGRITY_LAG_VERIFY;
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(nav.integ_mem.cam_lag[2], 2);
    assert_true(out.filt.ran);
    assert_true(out.filt.used);
    /* held as lagging (a lag episode, as the monitor holds it) */
    (void)mfns_integrity_hold_lagging(&nav.integ_mem, 1, 1U, table.integrity.hold_cycles);
    nav.integ_mem.lag_verify[1] = MFNS_INTEGRITY_LAG_WINDOW;
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(nav.integ_mem.cam_lag[1], 1);
    assert_true(out.filt.ran);
    assert_false(out.filt.used);
    assert_int_equal(out.filt.out.reason, MFNS_POSE_R_FRAME_SUSPECT);
    assert_int_equal(out.filt.out.suspect_camera, 1);
    assert_true(out.sol.status == MFNS_POSE_NO_FIX);
    print_message("filter used from cycle %d; a camera held as lagging refused its cycle\n", used_at);
}

/* Every DN of camera k's image times factor (background too), as a lost gain register does. */
static void scale_image(int k, double factor)
{
    for (int y = 0; y < H; y++) {
        for (int x = 0; x < W; x++) {
            img[k][y][x] = (uint8_t)(img[k][y][x] * factor + 0.5);
        }
    }
}

/* The response watch in the cycle (spot_watch.h): camera 1's image
 * halved while tracking is named in that cycle (CAMERA_RESPONSE_STEP's
 * source), ratio about 0.5, and not in the next; camera 2's exposure halved
 * and reported (mfns_nav_set_frame_response) names nothing; bad responses
 * are refused and nothing is taken. */
static void test_response_step_names_the_camera(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 43);
    const mfns_frame_t f0 = frame_of(0), f1 = frame_of(1), f2 = frame_of(2);
    const mfns_frame_t *const frames[3] = {&f0, &f1, &f2};
    assert_int_equal(mfns_nav_init(&nav, &table, MFNS_POSE_MODE_ML), MFNS_NAV_OK);
    render_background(&rng);
    render_beacons();
    const float same[3] = {1000.0f, 1000.0f, 1000.0f}, halved[3] = {1000.0f, 1000.0f, 500.0f};
    for (int i = 0; i < 3; i++) {
        assert_int_equal(mfns_nav_set_frame_response(&nav, same), MFNS_NAV_OK);
        assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
        assert_int_equal(out.spots.camera, -1);
    }
    scale_image(1, 0.5);
    assert_int_equal(mfns_nav_set_frame_response(&nav, same), MFNS_NAV_OK); /* the metadata says unchanged */
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    print_message("camera 1 halved: named %d, ratio %.3f over %u spots\n", out.spots.camera,
                  (double)out.spots.ratio, out.spots.matched);
    assert_int_equal(out.spots.camera, 1);
    assert_true(out.spots.ratio > 0.4f && out.spots.ratio < 0.6f);
    assert_int_equal(out.spots.matched, PER_CAM);
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK); /* nothing set: unknown, unchanged */
    assert_int_equal(out.spots.camera, -1);
    assert_int_equal(mfns_nav_set_frame_response(&nav, same), MFNS_NAV_OK);
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    scale_image(2, 0.5);
    assert_int_equal(mfns_nav_set_frame_response(&nav, halved), MFNS_NAV_OK); /* commanded and reported */
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.spots.camera, -1);
    assert_int_equal(out.spots.common, 0);
    const float bad[3][3] = {{NAN, 1.0f, 1.0f}, {1.0f, -1.0f, 1.0f}, {1.0f, 1.0f, INFINITY}};
    for (int i = 0; i < 3; i++) {
        assert_int_equal(mfns_nav_set_frame_response(&nav, bad[i]), MFNS_NAV_E_ARG);
        assert_float_equal(nav.frame_response[0], 0.0f, 0.0f); /* nothing taken */
    }
    assert_int_equal(mfns_nav_set_frame_response(&nav, NULL), MFNS_NAV_E_ARG);
    assert_int_equal(mfns_nav_set_frame_response(NULL, same), MFNS_NAV_E_ARG);
}

/* Camera k's image moved by dx columns (a knocked mount), the background filling in. */
static void shift_image(int k, int dx)
{
    for (int y = 0; y < H; y++) {
        memmove(&img[k][y][dx], &img[k][y][0], (size_t)(W - dx));
        for (int x = 0; x < dx; x++) {
            img[k][y][x] = 12;
        }
    }
}

/* The spot watch's jump in the cycle (spot_watch.h): with the filter's
 * output used, camera 1's image moved 4 px in one frame (a mount knocked
 * 0.15 deg) makes its spots jump; the filter's fix of that cycle is refused,
 * FRAME_SUSPECT naming camera 1 (nav_cycle.c suspect_camera), and
 * CAMERA_SPOTS_JUMPED's source names it as a new episode. */
static void test_spots_jump_refuses_the_filter_fix(void **state)
{
    (void)state;
    const mfns_frame_t f0 = frame_of(0), f1 = frame_of(1), f2 = frame_of(2);
    const mfns_frame_t *const frames[3] = {&f0, &f1, &f2};
    (void)fly_until_filter_used(47, frames);
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_true(out.filt.used);
    shift_image(1, 4);
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    print_message("camera 1 moved 4 px: jump %.2f px (others %.2f), filter ran %d used %d reason %d camera %d\n",
                  (double)out.spots.jump_px, (double)out.spots.others_px, out.filt.ran, out.filt.used,
                  (int)out.filt.out.reason, out.filt.out.suspect_camera);
    assert_int_equal(out.spots.jump_camera, 1);
    assert_true(out.spots.jump_new);
    assert_true(out.filt.ran);
    assert_false(out.filt.used);
    assert_int_equal(out.filt.out.reason, MFNS_POSE_R_FRAME_SUSPECT);
    assert_int_equal(out.filt.out.suspect_camera, 1);
    /* the next cycle, the spots still where they jumped to: no jump, but the
     * filter took the jumped frame, so this cycle is refused too */
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.spots.jump_mask, 1U << 1); /* its motion back to the robot's (none) */
    assert_false(out.filt.used);
    for (int i = 0; i < 2; i++) {
        assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    }
    assert_int_equal(out.spots.jump_mask, 0);
    assert_int_equal(out.spots.recent_mask, 0);
}

static void test_bad_frame_and_bad_arguments(void **state)
{
    (void)state;
    mfns_frame_t bad = frame_of(0);
    bad.stride_bytes = 100; /* shorter than a row */
    const mfns_frame_t f1 = frame_of(1), f2 = frame_of(2);
    const mfns_frame_t *const frames[3] = {&bad, &f1, &f2};
    assert_int_equal(mfns_nav_init(&nav, &table, MFNS_POSE_MODE_ML), MFNS_NAV_OK);
    assert_int_equal(mfns_nav_cycle(&nav, frames, &out), MFNS_NAV_OK);
    assert_int_equal(out.cam[0].state, MFNS_NAV_CAM_FRAME_ERROR);
    assert_int_equal(out.cam[0].centroid_status, MFNS_CENTROID_ERR_STRIDE);
    assert_int_equal(out.cam[0].observations, 0);

    static mfns_nav_t zeroed;
    memset(&zeroed, 0, sizeof zeroed);
    assert_int_equal(mfns_nav_cycle(&zeroed, frames, &out), MFNS_NAV_E_ARG);
    assert_int_equal(mfns_nav_cycle(&nav, NULL, &out), MFNS_NAV_E_ARG);
    assert_int_equal(mfns_nav_init(NULL, &table, MFNS_POSE_MODE_ML), MFNS_NAV_E_ARG);
    assert_string_not_equal(mfns_nav_strerror(MFNS_NAV_E_ARG), mfns_nav_strerror(MFNS_NAV_OK));
    /* a camera's clock in doubt: the camera must exist; with the filter off it changes nothing */
    assert_int_equal(mfns_nav_doubt_timing(NULL, 0), MFNS_NAV_E_ARG);
    assert_int_equal(mfns_nav_doubt_timing(&nav, -1), MFNS_NAV_E_ARG);
    assert_int_equal(mfns_nav_doubt_timing(&nav, MFNS_NUM_CAMERAS), MFNS_NAV_E_ARG);
    assert_int_equal(mfns_nav_doubt_timing(&nav, 2), MFNS_NAV_OK);
    assert_int_equal(nav.filt.timing_doubt, 0);
    assert_int_equal(mfns_nav_enable_filter(&nav, 54000), MFNS_NAV_OK);
    assert_int_equal(mfns_nav_doubt_timing(&nav, 2), MFNS_NAV_OK);
    assert_int_equal(nav.filt.timing_doubt, 4);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_acquire_then_track),
        cmocka_unit_test(test_search_carried_over_cycles),
        cmocka_unit_test(test_dead_camera_is_reported_and_others_still_solve),
        cmocka_unit_test(test_no_beacons_gives_no_fix_and_drops_the_prior),
        cmocka_unit_test(test_gap_holds_two_fixes_untested),
        cmocka_unit_test(test_tracking_from_a_given_pose),
        cmocka_unit_test(test_leaving_the_workspace),
        cmocka_unit_test(test_three_beacons_track_but_never_usable),
        cmocka_unit_test(test_rebind_keeps_the_track_of_the_same_system),
        cmocka_unit_test(test_lagging_camera_refuses_the_filter_fix),
        cmocka_unit_test(test_response_step_names_the_camera),
        cmocka_unit_test(test_spots_jump_refuses_the_filter_fix),
        cmocka_unit_test(test_bad_frame_and_bad_arguments),
    };
    return cmocka_run_group_tests_name("nav_cycle", tests, setup, NULL);
}
