/* Unit tests of the cycle synchronisation and camera health rules
 * (firmware/frames/cam_sync.h): which frames one cycle fuses, stale and
 * out-of-step frames (ahead, and behind the majority), LOST after MFNS_CAM_LOST_CYCLES, re-open cadence,
 * recovery. */
#include "tests/unit/support/testutil.h"

#include "firmware/frames/cam_sync.h"

static void test_frames_within_window_are_fused(void **state)
{
    (void)state;
    cam_sync_t s;
    cam_sync_init(&s, 25000u);
    const bool have[3] = {true, true, true};
    const uint64_t t[3] = {1000000u, 1010000u, 1024999u}; /* free-running: up to 25 ms apart */
    cam_sync_verdict_t v[3];
    uint64_t ref = 0;
    assert_true(cam_sync_cycle(&s, have, t, 3, v, &ref));
    assert_int_equal(ref, 1000000u);
    for (int k = 0; k < 3; k++) {
        assert_int_equal(v[k], CAM_SYNC_USE);
    }
}

/* One cycle over three candidates: a cycle happens, at ref_us, with the
 * verdicts v0, v1, v2 (CAM_SYNC_NONE for a camera without a frame). */
static void expect_cycle(cam_sync_t *s, const bool have[3], const uint64_t t[3], uint64_t ref_us,
                         cam_sync_verdict_t v0, cam_sync_verdict_t v1, cam_sync_verdict_t v2)
{
    cam_sync_verdict_t v[3];
    uint64_t ref = 0;
    assert_true(cam_sync_cycle(s, have, t, 3, v, &ref));
    assert_int_equal(ref, ref_us);
    assert_int_equal(v[0], v0);
    assert_int_equal(v[1], v1);
    assert_int_equal(v[2], v2);
}

static void test_out_of_step_frame_is_held_and_stale_frame_refused(void **state)
{
    (void)state;
    cam_sync_t s;
    cam_sync_init(&s, 25000u);
    /* y skipped a frame: it brings frame f+1 to cycle f */
    bool have[3] = {true, true, true};
    uint64_t t[3] = {161290u, 215054u, 161290u};
    expect_cycle(&s, have, t, 161290u, CAM_SYNC_USE, CAM_SYNC_AHEAD, CAM_SYNC_USE);
    /* next cycle: the held frame joins the others' frame f+1 */
    t[0] = t[2] = 215054u;
    expect_cycle(&s, have, t, 215054u, CAM_SYNC_USE, CAM_SYNC_USE, CAM_SYNC_USE);
    /* a frame of the cycle just done, or older, is stale; the next one is not */
    assert_true(cam_sync_is_stale(&s, 215054u));
    assert_true(cam_sync_is_stale(&s, 215054u + 25000u));
    assert_true(cam_sync_is_stale(&s, 161290u));
    assert_false(cam_sync_is_stale(&s, 268817u));
    /* no candidates: no cycle time, nothing recorded */
    have[0] = have[1] = have[2] = false;
    cam_sync_verdict_t v[3];
    uint64_t ref = 0;
    assert_false(cam_sync_cycle(&s, have, t, 3, v, &ref));
    assert_int_equal(s.last_us, 215054u);
    assert_int_equal(v[1], CAM_SYNC_NONE);
}

/* Camera x's clock runs fast: its frame comes just beyond the window and is
 * held; the next cycle the held frame is older than y's and z's fresh frames
 * by most of a period. The majority (y, z) sets the time and x's frame is
 * BEHIND (given back), where the oldest frame would have set it and pushed
 * the two healthy cameras out of step. Two cameras that disagree: no
 * majority, the older sets the time as before. */
static void test_majority_sets_the_time(void **state)
{
    (void)state;
    cam_sync_t s;
    cam_sync_init(&s, 25000u);
    const bool have[3] = {true, true, true};
    uint64_t t[3] = {1053763u + 26000u, 1053763u, 1053763u};
    expect_cycle(&s, have, t, 1053763u, CAM_SYNC_AHEAD, CAM_SYNC_USE, CAM_SYNC_USE);
    /* next cycle: x's held frame with y's and z's next ones */
    t[1] = t[2] = 1107527u;
    expect_cycle(&s, have, t, 1107527u, CAM_SYNC_BEHIND, CAM_SYNC_USE, CAM_SYNC_USE);
    /* two cameras, 28 ms apart: the older sets the time */
    const bool two[3] = {true, true, false};
    t[0] = 1161290u;
    t[1] = 1161290u + 28000u;
    expect_cycle(&s, two, t, 1161290u, CAM_SYNC_USE, CAM_SYNC_AHEAD, CAM_SYNC_NONE);
    /* three spread over more than the window (0, 20, 40 ms): the oldest pair's time, the last ahead */
    t[0] = 1215054u;
    t[1] = 1215054u + 20000u;
    t[2] = 1215054u + 40000u;
    expect_cycle(&s, have, t, 1215054u, CAM_SYNC_USE, CAM_SYNC_USE, CAM_SYNC_AHEAD);
}

static void test_offsets_saturate(void **state)
{
    (void)state;
    assert_int_equal(cam_sync_offset_us(10, 4), 6);
    assert_int_equal(cam_sync_offset_us(4, 10), -6);
    assert_int_equal(cam_sync_offset_us(UINT64_MAX, 0), INT32_MAX);
    assert_int_equal(cam_sync_offset_us(0, UINT64_MAX), -INT32_MAX);
}

static void test_health_lost_reopen_recovered(void **state)
{
    (void)state;
    cam_health_t h;
    cam_health_init(&h);
    assert_int_equal(cam_health_update(&h, true), CAM_HEALTH_EV_NONE);
    for (uint32_t i = 1; i < MFNS_CAM_LOST_CYCLES; i++) {
        assert_int_equal(cam_health_update(&h, false), CAM_HEALTH_EV_NONE);
        assert_false(cam_health_reopen_due(&h)); /* never re-opened while UP */
    }
    assert_int_equal(cam_health_update(&h, false), CAM_HEALTH_EV_LOST);
    assert_int_equal(h.state, CAM_HEALTH_LOST);
    /* re-open due once every MFNS_CAM_REOPEN_CYCLES cycles while down */
    int due = 0;
    for (uint32_t i = 0; i < 3u * MFNS_CAM_REOPEN_CYCLES; i++) {
        assert_int_equal(cam_health_update(&h, false), CAM_HEALTH_EV_NONE); /* LOST is reported once */
        due += cam_health_reopen_due(&h) ? 1 : 0;
    }
    assert_int_equal(due, 3);
    assert_int_equal(cam_health_update(&h, true), CAM_HEALTH_EV_RECOVERED);
    assert_int_equal(h.outage, MFNS_CAM_LOST_CYCLES + 3u * MFNS_CAM_REOPEN_CYCLES);
    assert_int_equal(h.state, CAM_HEALTH_UP);
    assert_int_equal(cam_health_update(&h, true), CAM_HEALTH_EV_NONE);
    /* OFF (recovery exhausted in the driver) recovers the same way; ENDED never changes */
    h.state = CAM_HEALTH_OFF;
    assert_int_equal(cam_health_update(&h, true), CAM_HEALTH_EV_RECOVERED);
    h.state = CAM_HEALTH_ENDED;
    assert_int_equal(cam_health_update(&h, true), CAM_HEALTH_EV_NONE);
    assert_false(cam_health_reopen_due(&h));
    assert_int_equal(h.state, CAM_HEALTH_ENDED);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_frames_within_window_are_fused),
        cmocka_unit_test(test_out_of_step_frame_is_held_and_stale_frame_refused),
        cmocka_unit_test(test_majority_sets_the_time),
        cmocka_unit_test(test_offsets_saturate),
        cmocka_unit_test(test_health_lost_reopen_recovered),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
