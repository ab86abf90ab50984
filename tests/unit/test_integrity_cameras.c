/* test_integrity_cameras.c -- cameras inconsistent with the fix
 * (firmware/nav/integrity/integrity_cameras.h) on their own: clean fixes report
 * nothing; a camera whose spots are none of them used while beacons are
 * predicted in its image is reported once its missed predictions reach 20
 * (ceil(20 / n) fixes with n predicted per fix), once, and shows the state
 * while the episode lasts (also a camera without a spot where beacons are
 * predicted); two cameras without inliers against a fix from the third are a
 * pair disagreement (DISAGREES, naming the third), never INCONSISTENT;
 * cycles without a known pose, a dark camera or one with nothing predicted
 * in view count nothing;
 * ten fixes with an inlier end the episode; the miss run the time-offset
 * monitor verifies a returning camera after; a fix from one camera that
 * another camera's image contradicts. */
#include <math.h>
#include <string.h>

#include "firmware/nav/integrity/integrity_cameras.h"
#include "tests/unit/support/pose_testlib.h"
#include "tests/unit/support/testutil.h"

typedef struct {
    mfns_rig_t rig;
    mfns_beacon_map_t map;
    pt_dpose_t truth;
    mfns_obs_frame_t frame;
    mfns_pose_assoc_t assoc;
    mfns_pose_solution_t sol;
    mfns_camera_watch_t w;
} scene_t;

static scene_t sc; /* large: static */

static void make_scene(uint64_t seed, const int per_cam[3])
{
    mfns_rng_t rng;
    mfns_rng_seed(&rng, seed);
    sc.rig = pt_paper_rig();
    sc.truth = pt_random_pose(&rng, 200);
    sc.map = pt_dense_map(&sc.rig, &sc.truth, per_cam, 500, 1500, &rng);
    (void)pt_make_frame(&sc.rig, &sc.map, &sc.truth, 0.1, &rng, &sc.frame, &sc.assoc);
    const mfns_pose_config_t cfg = pt_config(0.1);
    const mfns_pose_t t = pt_to_float(&sc.truth);
    assert_true(mfns_pose_refine(&sc.rig, &sc.map, &sc.frame, &sc.assoc, &t, &cfg, &sc.sol) != MFNS_POSE_NO_FIX);
    mfns_camera_watch_reset(&sc.w);
}

/* Camera c's spots stay in the frame, none associated (stale by more than
 * the association gate): the fix is the other cameras'. */
static void unassociate(int c)
{
    for (int i = 0; i < MFNS_MAX_OBS_PER_CAMERA; i++) {
        sc.sol.assoc.beacon[c][i] = MFNS_POSE_NO_BEACON;
        sc.sol.inlier[c][i] = 0U;
    }
}

static void test_clean_reports_nothing(void **state)
{
    (void)state;
    const int per_cam[3] = {5, 5, 5};
    for (uint64_t seed = 1; seed <= 5; seed++) {
        make_scene(seed, per_cam);
        mfns_camera_watch_report_t rep;
        for (int k = 0; k < 3 * MFNS_CAMERA_INCONSISTENT_EVIDENCE; k++) {
            mfns_camera_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &sc.sol, true, NULL, &rep);
            assert_int_equal(rep.inconsistent, -1);
            for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
                assert_int_equal(rep.state[c], 0);
                assert_int_equal(sc.w.evidence[c], 0);
            }
        }
    }
}

static void test_unused_camera_reported_once_on_its_evidence(void **state)
{
    (void)state;
    const int per_cam[3] = {5, 5, 5};
    make_scene(9, per_cam);
    const mfns_pose_solution_t clean = sc.sol;
    unassociate(1);
    mfns_camera_watch_report_t rep;
    /* the beacons the fix predicts in camera 1's image: the evidence per fix */
    uint16_t n = 0;
    for (int b = 0; b < (int)sc.map.count; b++) {
        float uv[2];
        n = (uint16_t)(n + (mfns_cam_project(&sc.rig.cam[1], &sc.sol.pose, sc.map.beacon[b].p_w, uv, NULL) ==
                                    MFNS_PROJ_OK &&
                                mfns_cam_in_image(&sc.rig.cam[1].k, uv[0], uv[1])
                            ? 1
                            : 0));
    }
    assert_true(n >= 3);
    const int per = n > 0 ? (int)n : 1; /* n >= 3 (asserted); the analysers do not know assert ends the test */
    const int expect = (MFNS_CAMERA_INCONSISTENT_EVIDENCE + per - 1) / per;
    int reports = 0, at = -1;
    for (int k = 1; k <= 3 * MFNS_CAMERA_INCONSISTENT_EVIDENCE; k++) {
        /* every other cycle without a known pose: counts nothing */
        mfns_camera_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &sc.sol, false, NULL, &rep);
        assert_int_equal(rep.inconsistent, -1);
        mfns_camera_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &sc.sol, true, NULL, &rep);
        if (rep.inconsistent >= 0) {
            assert_int_equal(rep.inconsistent, 1);
            assert_int_equal(rep.fixes, expect);
            assert_int_equal(rep.evidence, expect * n);
            reports++;
            at = k;
        }
        assert_int_equal(rep.state[0], 0);
        assert_int_equal(rep.state[2], 0);
        assert_int_equal(rep.state[1], at > 0 ? 1 : 0);
    }
    assert_int_equal(reports, 1);
    assert_int_equal(at, expect);
    /* an inlier again: the state clears at once, the episode after 10 fixes */
    for (int k = 0; k < MFNS_CAMERA_CONSISTENT_FIXES; k++) {
        mfns_camera_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &clean, true, NULL, &rep);
        assert_int_equal(rep.inconsistent, -1);
        assert_int_equal(rep.state[1], 0);
    }
    at = -1;
    for (int k = 1; k <= expect; k++) {
        mfns_camera_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &sc.sol, true, NULL, &rep);
        at = rep.inconsistent == 1 && at < 0 ? k : at;
    }
    assert_int_equal(at, expect); /* a new episode, reported again */
}

static void test_nothing_to_tell_counts_nothing(void **state)
{
    (void)state;
    const int per_cam[3] = {5, 5, 5};
    make_scene(21, per_cam);
    unassociate(2);
    mfns_camera_watch_report_t rep;
    /* camera 2 dark (no image), then without spots: no evidence */
    sc.frame.dark[2] = 1U;
    for (int k = 0; k < 2 * MFNS_CAMERA_INCONSISTENT_EVIDENCE; k++) {
        mfns_camera_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &sc.sol, true, NULL, &rep);
        assert_int_equal(rep.inconsistent, -1);
    }
    assert_int_equal(sc.w.evidence[2], 0);
    /* an image without a spot where beacons are predicted: evidence (a
     * stale camera's spots outside the tracking windows) */
    sc.frame.dark[2] = 0U;
    sc.frame.count[2] = 0;
    int at = -1;
    for (int k = 1; k <= MFNS_CAMERA_INCONSISTENT_EVIDENCE; k++) {
        mfns_camera_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &sc.sol, true, NULL, &rep);
        at = rep.inconsistent == 2 && at < 0 ? k : at;
    }
    assert_true(at > 0);
    /* a camera with only spurious spots and no beacon in its view: nothing predicted */
    const int none_in_z[3] = {5, 5, 0};
    make_scene(22, none_in_z);
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 5);
    sc.frame.count[2] = 0;
    for (int s = 0; s < 4; s++) {
        pt_add_spurious(&sc.rig, 2, &rng, &sc.frame, &sc.assoc);
    }
    unassociate(2);
    assert_true(sc.frame.count[2] > 0);
    for (int k = 0; k < 2 * MFNS_CAMERA_INCONSISTENT_EVIDENCE; k++) {
        mfns_camera_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &sc.sol, true, NULL, &rep);
        assert_int_equal(rep.inconsistent, -1);
    }
    assert_int_equal(sc.w.evidence[2], 0);
    /* bad input: a clear no-report, never a crash */
    mfns_camera_watch_update(NULL, &sc.rig, &sc.map, &sc.frame, &sc.sol, true, NULL, &rep);
    assert_int_equal(rep.inconsistent, -1);
    mfns_camera_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &sc.sol, true, NULL, NULL);
}

/* Two cameras unused, the fix from the third alone: each disagrees with it,
 * and nothing says which side is wrong: DISAGREES naming camera 0, never
 * INCONSISTENT. */
static void test_pair_disagreement_names_both(void **state)
{
    (void)state;
    const int per_cam[3] = {5, 5, 5};
    make_scene(31, per_cam);
    unassociate(1);
    unassociate(2);
    mfns_camera_watch_report_t rep;
    int seen[MFNS_NUM_CAMERAS] = {0, 0, 0};
    for (int k = 0; k < 3 * MFNS_CAMERA_INCONSISTENT_EVIDENCE; k++) {
        mfns_camera_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &sc.sol, true, NULL, &rep);
        assert_int_equal(rep.inconsistent, -1);
        if (rep.disagrees >= 0) {
            assert_int_equal(rep.disagrees_with, 0);
            assert_true(rep.pair_evidence >= MFNS_CAMERA_INCONSISTENT_EVIDENCE);
            seen[rep.disagrees]++;
        }
    }
    assert_int_equal(seen[0], 0);
    assert_int_equal(seen[1], 1);
    assert_int_equal(seen[2], 1);
    assert_int_equal(rep.state[1], 2);
    assert_int_equal(rep.state[2], 2);
    assert_int_equal(rep.state[0], 0);
}

/* A camera held out by FDE or the time-offset monitor is missing from the
 * output fix for their reasons: with an inlier in the solver's fix it counts
 * as consistent (never INCONSISTENT for being held). */
static void test_held_camera_is_not_inconsistent(void **state)
{
    (void)state;
    const int per_cam[3] = {5, 5, 5};
    make_scene(41, per_cam);
    unassociate(1); /* the output fix without camera 1 */
    const uint8_t solver_inlier[MFNS_NUM_CAMERAS] = {1U, 1U, 1U};
    mfns_camera_watch_report_t rep;
    for (int k = 0; k < 3 * MFNS_CAMERA_INCONSISTENT_EVIDENCE; k++) {
        mfns_camera_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &sc.sol, true, solver_inlier, &rep);
        assert_int_equal(rep.inconsistent, -1);
        assert_int_equal(rep.disagrees, -1);
        assert_int_equal(rep.state[1], 0);
    }
    assert_int_equal(sc.w.evidence[1], 0);
}

/* The miss run: consecutive counted cycles with an image and predicted
 * beacons but no inlier; an inlier (in the output or the solver's fix) ends
 * it, cycles without a pose or image leave it alone. */
static void test_miss_run_counts_the_gap(void **state)
{
    (void)state;
    const int per_cam[3] = {5, 5, 5};
    make_scene(51, per_cam);
    const mfns_pose_solution_t clean = sc.sol;
    unassociate(2);
    mfns_camera_watch_report_t rep;
    for (int k = 1; k <= 5; k++) {
        mfns_camera_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &sc.sol, true, NULL, &rep);
        assert_int_equal(sc.w.miss_run[2], k);
        assert_int_equal(sc.w.miss_run[0], 0);
    }
    mfns_camera_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &sc.sol, false, NULL, &rep);
    assert_int_equal(sc.w.miss_run[2], 5); /* no pose: nothing to tell */
    sc.frame.dark[2] = 1U;
    mfns_camera_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &sc.sol, true, NULL, &rep);
    assert_int_equal(sc.w.miss_run[2], 5); /* no image: the outage is the lag monitor's dark run */
    sc.frame.dark[2] = 0U;
    const uint8_t solver_inlier[MFNS_NUM_CAMERAS] = {1U, 1U, 1U};
    mfns_camera_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &sc.sol, true, solver_inlier, &rep);
    assert_int_equal(sc.w.miss_run[2], 0); /* an inlier in the solver's fix ends it */
    mfns_camera_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &sc.sol, true, NULL, &rep);
    assert_int_equal(sc.w.miss_run[2], 1);
    mfns_camera_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &clean, true, NULL, &rep);
    assert_int_equal(sc.w.miss_run[2], 0);
    for (int k = 0; k < 300; k++) { /* capped, never wraps */
        mfns_camera_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &sc.sol, true, NULL, &rep);
    }
    assert_int_equal(sc.w.miss_run[2], UINT8_MAX);
}

/* A fix from one camera is contradicted by another camera that gave an
 * image in which the fix predicts a beacon and has no inlier; not by a dark
 * camera, one with nothing predicted (or only within the margin of its
 * edge), nor when two cameras have inliers. */
static void test_one_camera_fix_contradicted(void **state)
{
    (void)state;
    const int per_cam[3] = {5, 5, 5};
    make_scene(61, per_cam);
    assert_int_equal(mfns_camera_watch_contradicting(&sc.rig, &sc.map, &sc.frame, &sc.sol, 0.0f, NULL), -1);
    unassociate(1);
    /* two cameras with inliers: the watch's INCONSISTENT case, not this one */
    assert_int_equal(mfns_camera_watch_contradicting(&sc.rig, &sc.map, &sc.frame, &sc.sol, 0.0f, NULL), -1);
    unassociate(2);
    assert_int_equal(mfns_camera_watch_contradicting(&sc.rig, &sc.map, &sc.frame, &sc.sol, 0.0f, NULL), 1);
    sc.frame.dark[1] = 1U;
    assert_int_equal(mfns_camera_watch_contradicting(&sc.rig, &sc.map, &sc.frame, &sc.sol, 0.0f, NULL), 2);
    sc.frame.dark[2] = 1U;
    assert_int_equal(mfns_camera_watch_contradicting(&sc.rig, &sc.map, &sc.frame, &sc.sol, 0.0f, NULL), -1);
    sc.frame.dark[1] = 0U;
    sc.frame.dark[2] = 0U;
    /* a camera held only to verify its lag, its spots in the solver's fix: not a contradiction */
    const uint8_t verifying1[MFNS_NUM_CAMERAS] = {0U, 1U, 0U};
    assert_int_equal(mfns_camera_watch_contradicting(&sc.rig, &sc.map, &sc.frame, &sc.sol, 0.0f, verifying1), 2);
    const uint8_t verifying12[MFNS_NUM_CAMERAS] = {0U, 1U, 1U};
    assert_int_equal(mfns_camera_watch_contradicting(&sc.rig, &sc.map, &sc.frame, &sc.sol, 0.0f, verifying12), -1);
    /* a margin wider than half the image leaves no beacon inside it */
    const float half = 0.5f * (float)(sc.rig.cam[1].k.width > sc.rig.cam[1].k.height ? sc.rig.cam[1].k.width
                                                                                       : sc.rig.cam[1].k.height);
    assert_int_equal(mfns_camera_watch_contradicting(&sc.rig, &sc.map, &sc.frame, &sc.sol, half, NULL), -1);
    /* nothing predicted in the other cameras: nothing contradicts */
    const int only_x[3] = {6, 0, 0};
    make_scene(62, only_x);
    assert_int_equal(mfns_camera_watch_contradicting(&sc.rig, &sc.map, &sc.frame, &sc.sol, 0.0f, NULL), -1);
    /* not a fix, NULLs */
    mfns_pose_solution_t nofix = sc.sol;
    nofix.status = MFNS_POSE_NO_FIX;
    assert_int_equal(mfns_camera_watch_contradicting(&sc.rig, &sc.map, &sc.frame, &nofix, 0.0f, NULL), -1);
    assert_int_equal(mfns_camera_watch_contradicting(NULL, &sc.map, &sc.frame, &sc.sol, 0.0f, NULL), -1);
    assert_int_equal(mfns_camera_watch_contradicting(&sc.rig, &sc.map, &sc.frame, NULL, 0.0f, NULL), -1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_clean_reports_nothing),
        cmocka_unit_test(test_unused_camera_reported_once_on_its_evidence),
        cmocka_unit_test(test_nothing_to_tell_counts_nothing),
        cmocka_unit_test(test_pair_disagreement_names_both),
        cmocka_unit_test(test_held_camera_is_not_inconsistent),
        cmocka_unit_test(test_miss_run_counts_the_gap),
        cmocka_unit_test(test_one_camera_fix_contradicted),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
