/* test_integrity_beacons.c -- beacons missing or rejected
 * (firmware/nav/integrity/integrity_beacons.h) on their own: clean fixes report
 * nothing; a dead LED is reported MISSING after exactly 20 fixes, once; a
 * beacon gated out or held by FDE is reported REJECTED after 10; cycles
 * without a known pose count nothing; an episode ends after 10 clean uses. */
#include <math.h>
#include <string.h>

#include "firmware/nav/integrity/integrity_beacons.h"
#include "tests/unit/support/pose_testlib.h"
#include "tests/unit/support/testutil.h"

typedef struct {
    mfns_rig_t rig;
    mfns_beacon_map_t map;
    pt_dpose_t truth;
    mfns_obs_frame_t frame;
    mfns_pose_assoc_t assoc;
    mfns_pose_solution_t sol;
    mfns_beacon_watch_t w;
} scene_t;

static scene_t sc; /* large: static */

static void make_scene(uint64_t seed)
{
    mfns_rng_t rng;
    mfns_rng_seed(&rng, seed);
    sc.rig = pt_paper_rig();
    sc.truth = pt_random_pose(&rng, 200);
    const int per_cam[3] = {5, 5, 5};
    sc.map = pt_dense_map(&sc.rig, &sc.truth, per_cam, 500, 1500, &rng);
    (void)pt_make_frame(&sc.rig, &sc.map, &sc.truth, 0.1, &rng, &sc.frame, &sc.assoc);
    const mfns_pose_config_t cfg = pt_config(0.1);
    const mfns_pose_t t = pt_to_float(&sc.truth);
    assert_true(mfns_pose_refine(&sc.rig, &sc.map, &sc.frame, &sc.assoc, &t, &cfg, &sc.sol) != MFNS_POSE_NO_FIX);
    mfns_beacon_watch_reset(&sc.w);
}

/* The map index of camera 1's first observation, and that observation. */
static int16_t victim(int *cam, int *idx)
{
    *cam = 1;
    *idx = 0;
    const int16_t b = sc.sol.assoc.beacon[1][0];
    assert_true(b >= 0 && sc.sol.inlier[1][0] != 0U);
    return b;
}

static void test_clean_reports_nothing(void **state)
{
    (void)state;
    for (uint64_t seed = 1; seed <= 5; seed++) {
        make_scene(seed);
        mfns_beacon_watch_report_t rep;
        for (int k = 0; k < 3 * MFNS_BEACON_MISSING_FIXES; k++) {
            mfns_beacon_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &sc.sol, true, NULL, 0, &rep);
            assert_int_equal(rep.missing, -1);
            assert_int_equal(rep.rejected, -1);
        }
    }
}

static void test_dead_led_missing_after_20_once(void **state)
{
    (void)state;
    make_scene(9);
    int c, i;
    const int16_t b = victim(&c, &i);
    sc.sol.assoc.beacon[c][i] = MFNS_POSE_NO_BEACON; /* its spot gone: nothing associated */
    sc.sol.inlier[c][i] = 0U;
    mfns_beacon_watch_report_t rep;
    int reports = 0, at = -1;
    for (int k = 1; k <= 3 * MFNS_BEACON_MISSING_FIXES; k++) {
        /* every other cycle without a known pose: counts nothing */
        mfns_beacon_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &sc.sol, false, NULL, 0, &rep);
        assert_int_equal(rep.missing, -1);
        mfns_beacon_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &sc.sol, true, NULL, 0, &rep);
        assert_int_equal(rep.rejected, -1);
        if (rep.missing >= 0) {
            assert_int_equal(rep.missing, b);
            assert_int_equal(rep.missing_fixes, MFNS_BEACON_MISSING_FIXES);
            reports++;
            at = k;
        }
    }
    assert_int_equal(reports, 1);
    assert_int_equal(at, MFNS_BEACON_MISSING_FIXES);
    /* a camera without an image sees nothing: not missing from it */
    mfns_beacon_watch_reset(&sc.w);
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        sc.frame.dark[k] = 1U;
    }
    for (int k = 0; k < 2 * MFNS_BEACON_MISSING_FIXES; k++) {
        mfns_beacon_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &sc.sol, true, NULL, 0, &rep);
        assert_int_equal(rep.missing, -1);
    }
}

static void test_gated_or_held_rejected_after_10(void **state)
{
    (void)state;
    for (int held_by_fde = 0; held_by_fde <= 1; held_by_fde++) {
        make_scene(13);
        int c, i;
        const int16_t b = victim(&c, &i);
        const mfns_pose_solution_t clean = sc.sol;
        int16_t held[4] = {-1, -1, -1, -1};
        if (held_by_fde) {
            sc.sol.assoc.beacon[c][i] = MFNS_POSE_NO_BEACON; /* FDE took it out of the fix */
            held[2] = b;
        }
        sc.sol.inlier[c][i] = 0U; /* gated (or out) */
        mfns_beacon_watch_report_t rep;
        int at = -1;
        for (int k = 1; k <= 2 * MFNS_BEACON_REJECT_COUNT; k++) {
            mfns_beacon_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &sc.sol, true, held, 4, &rep);
            assert_int_equal(rep.missing, -1); /* held or gated is never "missing" */
            if (rep.rejected >= 0) {
                assert_int_equal(rep.rejected, b);
                assert_int_equal(at, -1);
                at = k;
            }
        }
        assert_int_equal(at, MFNS_BEACON_REJECT_COUNT);
        /* used again for a while: the episode ends, a new one is reported again */
        for (int k = 0; k < MFNS_BEACON_CLEAR_FIXES; k++) {
            mfns_beacon_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &clean, true, NULL, 0, &rep);
            assert_int_equal(rep.rejected, -1);
        }
        at = -1;
        for (int k = 1; k <= MFNS_BEACON_REJECT_COUNT; k++) {
            mfns_beacon_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, &sc.sol, true, held, 4, &rep);
            at = rep.rejected == b && at < 0 ? k : at;
        }
        assert_int_equal(at, MFNS_BEACON_REJECT_COUNT);
    }
}

static void test_alternating_use_is_not_rejected(void **state)
{
    (void)state;
    make_scene(17);
    int c, i;
    (void)victim(&c, &i);
    mfns_pose_solution_t gated = sc.sol;
    gated.inlier[c][i] = 0U;
    mfns_beacon_watch_report_t rep;
    for (int k = 0; k < 20 * MFNS_BEACON_REJECT_COUNT; k++) {
        mfns_beacon_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, (k % 2) ? &gated : &sc.sol, true, NULL, 0, &rep);
        assert_int_equal(rep.rejected, -1);
    }
    /* bad input: nothing reported, no crash */
    mfns_beacon_watch_update(NULL, &sc.rig, &sc.map, &sc.frame, &sc.sol, true, NULL, 0, &rep);
    assert_int_equal(rep.missing, -1);
    mfns_beacon_watch_update(&sc.w, &sc.rig, &sc.map, &sc.frame, NULL, true, NULL, 0, &rep);
    assert_int_equal(rep.rejected, -1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_clean_reports_nothing),
        cmocka_unit_test(test_dead_led_missing_after_20_once),
        cmocka_unit_test(test_gated_or_held_rejected_after_10),
        cmocka_unit_test(test_alternating_use_is_not_rejected),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
