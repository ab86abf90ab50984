/* test_workspace_watch.c -- the tracked pose against the table's workspace
 * box (firmware/nav/acquire/workspace_watch.h) on its own: the box test per axis
 * with its widening (fixed part and 6 sigma), NaN beyond; the watch's
 * transitions: a tracked pose beyond the box is reported once (left), an
 * acquisition's pose, a lost track or a pose that does not carry the track
 * leave the state alone, a tracked pose inside ends it (reentered, with the
 * cycles outside); acquisitions are refused exactly while OUTSIDE. */
#include <math.h>
#include <string.h>

#include "tests/unit/support/testutil.h"
#include "firmware/nav/acquire/workspace_watch.h"

static mfns_beacon_index_t idx; /* large: static; only the box is read */

static void set_box(void)
{
    memset(&idx, 0, sizeof idx);
    idx.ws_min_w = mfns_v3(-800.0f, -300.0f, -300.0f);
    idx.ws_max_w = mfns_v3(800.0f, 300.0f, 300.0f);
}

/* A solution at body origin p (world, mm), identity attitude, sigma s mm per axis. */
static mfns_pose_solution_t at(float x, float y, float z, float s)
{
    mfns_pose_solution_t sol;
    mfns_pose_solution_clear(&sol, MFNS_POSE_R_NONE);
    sol.status = MFNS_POSE_OK;
    sol.pose = mfns_pose_from_position(mfns_m3_identity(), mfns_v3(x, y, z));
    for (int a = 0; a < 3; a++) {
        sol.sigma_pos_mm[a] = s;
    }
    return sol;
}

static void test_the_box_test_widens_by_20_mm_and_6_sigma(void **state)
{
    (void)state;
    /* a fixed part and at least 3 sigma: a right pose is not called outside for its noise */
    assert_true(MFNS_WS_TOL_MM > 0.0f && MFNS_WS_TOL_SIGMA >= 3.0f);
    set_box();
    uint8_t axes = 0xFFU;
    float tol = -1.0f;
    mfns_pose_solution_t s = at(0.0f, 0.0f, 0.0f, 0.1f);
    assert_true(mfns_ws_beyond(&idx, &s, &axes, &tol) == 0.0f);
    assert_int_equal(axes, 0);
    /* on the widened edge: inside; 1 mm past it: beyond by 1 mm on x only */
    s = at(800.0f + 20.0f + 6.0f * 0.5f, 0.0f, 0.0f, 0.5f);
    assert_true(mfns_ws_beyond(&idx, &s, &axes, NULL) == 0.0f);
    assert_int_equal(axes, 0);
    s = at(800.0f + 24.0f, 0.0f, 0.0f, 0.5f);
    assert_near(mfns_ws_beyond(&idx, &s, &axes, &tol), 1.0, 1e-3);
    assert_int_equal(axes, 1);
    assert_near(tol, 23.0, 1e-4);
    /* the pose's own sigma widens the box: 10 mm sigma, 60 mm more */
    s = at(800.0f + 60.0f, 0.0f, 0.0f, 10.0f);
    assert_true(mfns_ws_beyond(&idx, &s, &axes, NULL) == 0.0f);
    /* below the box on y and z: both axes, the larger excess */
    s = at(0.0f, -400.0f, -350.0f, 0.0f);
    assert_near(mfns_ws_beyond(&idx, &s, &axes, &tol), 80.0, 1e-3);
    assert_int_equal(axes, 2 | 4);
    assert_near(tol, 20.0, 1e-6);
    /* not finite: beyond, infinitely */
    s = at(NAN, 0.0f, 0.0f, 0.1f); /* the body origin comes through C_w_b: NaN on every axis */
    assert_true(isinf(mfns_ws_beyond(&idx, &s, &axes, NULL)));
    assert_int_equal(axes, 7);
    s = at(0.0f, 0.0f, 0.0f, 0.1f);
    s.sigma_pos_mm[2] = NAN;
    assert_true(mfns_ws_beyond(&idx, &s, &axes, NULL) > 0.0f);
    assert_int_equal(axes, 4);
}

static void test_the_watch_reports_leaving_once_and_refuses_until_back(void **state)
{
    (void)state;
    set_box();
    mfns_ws_watch_t w;
    mfns_ws_report_t r;
    mfns_ws_watch_init(&w);
    assert_false(mfns_ws_watch_refuses(&w));
    const mfns_pose_solution_t in = at(100.0f, 0.0f, 0.0f, 0.2f), out = at(0.0f, 0.0f, 500.0f, 0.2f);
    mfns_ws_watch_update(&w, &idx, &in, true, true, &r);
    assert_false(r.left || r.reentered);
    assert_int_equal(w.state, MFNS_WS_INSIDE);
    /* an acquisition's pose or one that does not carry the track moves nothing */
    mfns_ws_watch_update(&w, &idx, &out, true, false, &r);
    assert_false(r.left);
    mfns_ws_watch_update(&w, &idx, &out, false, true, &r);
    assert_false(r.left);
    assert_int_equal(w.state, MFNS_WS_INSIDE);
    /* the track leaves: reported once, acquisitions refused */
    mfns_ws_watch_update(&w, &idx, &out, true, true, &r);
    assert_true(r.left);
    assert_int_equal(r.axes, 4);
    assert_near(r.beyond_mm, 500.0 - 300.0 - 20.0 - 1.2, 1e-3);
    assert_int_equal(w.state, MFNS_WS_OUTSIDE);
    assert_true(mfns_ws_watch_refuses(&w));
    mfns_ws_watch_update(&w, &idx, &out, true, true, &r);
    assert_false(r.left);
    /* lost (no pose carries the track) and an acquisition inside: still outside */
    for (int i = 0; i < 5; i++) {
        mfns_ws_watch_update(&w, &idx, &in, false, false, &r);
        assert_false(r.reentered);
    }
    mfns_ws_watch_update(&w, &idx, &in, true, false, &r);
    assert_false(r.reentered);
    assert_true(mfns_ws_watch_refuses(&w));
    /* a tracked pose inside (the track back, or one from an operator's pose) */
    mfns_ws_watch_update(&w, &idx, &in, true, true, &r);
    assert_true(r.reentered);
    assert_int_equal(r.cycles_outside, 8);
    assert_int_equal(w.state, MFNS_WS_INSIDE);
    assert_false(mfns_ws_watch_refuses(&w));
    mfns_ws_watch_update(&w, &idx, &in, true, true, &r);
    assert_false(r.reentered || r.left);
    assert_true(strlen(mfns_ws_state_str(MFNS_WS_OUTSIDE)) > 0U);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_the_box_test_widens_by_20_mm_and_6_sigma),
        cmocka_unit_test(test_the_watch_reports_leaving_once_and_refuses_until_back),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
