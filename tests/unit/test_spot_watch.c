/* test_spot_watch.c -- what each camera's spots did since its last frame
 * (firmware/nav/integrity/spot_watch.h) on its own, on synthetic spots:
 * three cameras of 5 spots each drifting a pixel a frame (25 in a fast
 * turn), each flux with 5 %
 * noise (dim spots 15 %).
 *  - clean: 3000 cycles of a smooth sway, no camera named, nothing common,
 *    no jump;
 *  - jumps: a knocked mount, a frozen camera, a collision, a dropped frame
 *    (test_jumps);
 *  - a camera's gain halved (and doubled) from one frame: that camera named
 *    in that cycle only, its ratio near the step;
 *  - every camera halved together: common, no camera named;
 *  - one spot dimmed (a beacon, an occlusion): nothing;
 *  - an exposure change the caller reports: nothing; one it does not: named;
 *  - what it misses: a step in the frame the spots jump (a knock), a camera
 *    with one spot, a slow fade;
 *  - rejected and saturated blobs carry no ratio; bad input: E_ARG, memory
 *    untouched. */
#include <math.h>
#include <string.h>

#include "tests/unit/support/testutil.h"
#include "firmware/nav/integrity/spot_watch.h"

#pragma GCC diagnostic ignored "-Wdouble-promotion"

#define SPOTS 5

typedef struct {
    float u[MFNS_NUM_CAMERAS][SPOTS], v[MFNS_NUM_CAMERAS][SPOTS], flux[MFNS_NUM_CAMERAS][SPOTS];
    float gain[MFNS_NUM_CAMERAS];     /* the camera's true response factor */
    float reported[MFNS_NUM_CAMERAS]; /* what the caller reports (0 unknown) */
    float noise;                      /* relative flux noise of the bright spots */
    mfns_rng_t rng;
} scene_t;

static void scene_init(scene_t *s, uint64_t seed)
{
    memset(s, 0, sizeof *s);
    mfns_rng_seed(&s->rng, seed);
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        for (int i = 0; i < SPOTS; i++) {
            s->u[c][i] = (float)(100.0 + 180.0 * i + 40.0 * mfns_rng_uniform(&s->rng));
            s->v[c][i] = (float)(200.0 + 100.0 * mfns_rng_uniform(&s->rng));
            s->flux[c][i] = i == SPOTS - 1 ? 300.0f : (float)(2000.0 + 3000.0 * mfns_rng_uniform(&s->rng));
        }
        s->gain[c] = 1.0f;
    }
    s->noise = 0.05f;
}

/* Camera c's centroider result this frame: its spots moved by (du, dv). */
static void frame(scene_t *s, int c, float du, float dv, mfns_centroid_result_t *r)
{
    memset(r, 0, sizeof *r);
    for (int i = 0; i < SPOTS; i++) {
        s->u[c][i] += du;
        s->v[c][i] += dv;
        const double rel = i == SPOTS - 1 ? 3.0 * s->noise : s->noise; /* the dim one is noisier */
        mfns_blob_t *b = &r->blob[i];
        /* centroid noise 0.05 px on what is measured, not on where the spot is */
        b->u_q8 = mfns_px_q8_from_float(s->u[c][i] + (float)(0.05 * mfns_rng_normal(&s->rng)));
        b->v_q8 = mfns_px_q8_from_float(s->v[c][i] + (float)(0.05 * mfns_rng_normal(&s->rng)));
        b->flux_dn = (float)(s->flux[c][i] * s->gain[c] * (1.0 + rel * mfns_rng_normal(&s->rng)));
    }
    r->n_blobs = SPOTS;
    r->n_accepted = SPOTS;
}

/* One cycle of every camera; the report. */
static mfns_spot_report_t cycle(scene_t *s, mfns_spot_watch_t *w, float du)
{
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        mfns_centroid_result_t r;
        frame(s, c, du, 0.3f * du, &r);
        assert_int_equal(mfns_spot_observe(w, c, &r, s->reported[c]), MFNS_SPOT_OK);
    }
    mfns_spot_report_t rep;
    mfns_spot_evaluate(w, &rep);
    return rep;
}

static void test_clean_names_nothing(void **state)
{
    (void)state;
    scene_t s;
    scene_init(&s, 1);
    static mfns_spot_watch_t w;
    mfns_spot_init(&w);
    int named = 0, common = 0, jumps = 0;
    float worst = 0.0f;
    for (int k = 0; k < 3000; k++) {
        /* a smooth sway, slow then fast (25 px a frame at its peak): its
         * motion changes by at most 0.52 px a frame */
        const float px = k < 1500 ? 1.0f : 25.0f;
        const mfns_spot_report_t rep = cycle(&s, &w, px * sinf(2.0f * 3.14159265f * (float)k / 300.0f));
        named += rep.camera >= 0 ? 1 : 0;
        common += rep.common > 0U ? 1 : 0;
        jumps += rep.jump_mask != 0U ? 1 : 0;
        worst = fmaxf(worst, rep.jump_px);
        if (k > 0) {
            assert_int_equal(w.n[0], SPOTS);
        }
    }
    print_message("clean: largest change of the spots' motion %.2f px a frame\n", (double)worst);
    assert_int_equal(named, 0);
    assert_int_equal(common, 0);
    assert_int_equal(jumps, 0);
    assert_true(worst > 0.3f && worst < 1.0f); /* the sway's own, tested */
}

static void step_named_once(float factor, uint64_t seed, float px_per_frame)
{
    scene_t s;
    scene_init(&s, seed);
    static mfns_spot_watch_t w;
    mfns_spot_init(&w);
    int first = -1, named = 0;
    float ratio = 0.0f;
    for (int k = 0; k < 200; k++) {
        if (k == 100) {
            s.gain[1] = factor;
        }
        const mfns_spot_report_t rep = cycle(&s, &w, (k / 20) % 2 ? px_per_frame : -px_per_frame);
        if (rep.camera >= 0) {
            assert_int_equal(rep.camera, 1);
            assert_int_equal(rep.common, 0);
            named++;
            first = first < 0 ? k : first;
            ratio = rep.ratio;
            assert_true(rep.matched >= MFNS_SPOT_MIN_MATCHED);
        }
    }
    print_message("gain x%.2f, spots moving %.0f px a frame: named at cycle %d, ratio %.3f\n", (double)factor,
                  (double)px_per_frame, first, (double)ratio);
    assert_int_equal(first, 100);
    assert_int_equal(named, 1); /* a step: the next frames match the new level */
    assert_true(fabsf(ratio / factor - 1.0f) < 0.15f); /* two 5 % fluxes: a ratio within 7 %, the median of 5 */
}

static void test_gain_step_names_the_camera(void **state)
{
    (void)state;
    step_named_once(0.5f, 2, 1.0f);
    step_named_once(2.0f, 3, 1.0f);
    step_named_once(0.5f, 4, 25.0f); /* a fast turn: the spots' common shift matches them */
}

static void test_common_step_names_no_camera(void **state)
{
    (void)state;
    scene_t s;
    scene_init(&s, 4);
    static mfns_spot_watch_t w;
    mfns_spot_init(&w);
    for (int k = 0; k < 60; k++) {
        if (k == 30) {
            for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
                s.gain[c] = 0.5f; /* the LEDs' supply, not a camera */
            }
        }
        const mfns_spot_report_t rep = cycle(&s, &w, 1.0f);
        assert_int_equal(rep.camera, -1);
        assert_int_equal(rep.common, k == 30 ? MFNS_NUM_CAMERAS : 0);
    }
}

static void test_one_spot_dimmed_is_not_the_camera(void **state)
{
    (void)state;
    scene_t s;
    scene_init(&s, 5);
    static mfns_spot_watch_t w;
    mfns_spot_init(&w);
    for (int k = 0; k < 60; k++) {
        if (k == 30) {
            s.flux[0][1] *= 0.3f; /* one beacon of camera 0 dims (or is half occluded) */
        }
        const mfns_spot_report_t rep = cycle(&s, &w, 1.0f);
        assert_int_equal(rep.camera, -1);
    }
}

static void test_reported_exposure_change(void **state)
{
    (void)state;
    scene_t s;
    scene_init(&s, 6);
    static mfns_spot_watch_t w;
    mfns_spot_init(&w);
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        s.reported[c] = 2000.0f; /* exposure x gain, any unit */
    }
    for (int k = 0; k < 60; k++) {
        if (k == 30) {
            s.gain[2] = 0.5f; /* exposure halved, and reported */
            s.reported[2] = 1000.0f;
        }
        assert_int_equal(cycle(&s, &w, 1.0f).camera, -1);
    }
    /* the same change unreported (0: unknown) is read as the camera's step */
    s.reported[2] = 0.0f;
    (void)cycle(&s, &w, 1.0f);
    s.gain[2] = 0.25f;
    assert_int_equal(cycle(&s, &w, 1.0f).camera, 2);
}

static void test_what_it_misses(void **state)
{
    (void)state;
    scene_t s;
    scene_init(&s, 7);
    static mfns_spot_watch_t w;
    mfns_spot_init(&w);
    for (int k = 0; k < 10; k++) {
        (void)cycle(&s, &w, 1.0f);
    }
    /* a knock: the spots jump 10 px in the frame the gain halves: the
     * common shift matches them, the step is seen */
    s.gain[0] = 0.5f;
    for (int i = 0; i < SPOTS; i++) {
        s.u[0][i] += 10.0f;
    }
    mfns_spot_report_t rep = cycle(&s, &w, 1.0f);
    assert_int_equal(rep.camera, 0);
    /* a jump beyond MFNS_SPOT_MAX_SHIFT_PX with a step (a swapped stream): nothing matches */
    s.gain[0] = 0.25f;
    for (int i = 0; i < SPOTS; i++) {
        s.u[0][i] += 2.0f * MFNS_SPOT_MAX_SHIFT_PX;
    }
    rep = cycle(&s, &w, 1.0f);
    assert_int_equal(rep.camera, -1);
    assert_int_equal(w.n[0], SPOTS);
    rep = cycle(&s, &w, 1.0f); /* and the next frame matches the new level */
    assert_int_equal(rep.camera, -1);
    /* a slow fade: 3 % a frame down to a third, never a step */
    for (int k = 0; k < 40; k++) {
        s.gain[1] *= 0.97f;
        assert_int_equal(cycle(&s, &w, 1.0f).camera, -1);
    }
    assert_true(s.gain[1] < 0.35f);
    /* one spot: untested */
    mfns_centroid_result_t r;
    frame(&s, 2, 1.0f, 0.0f, &r);
    r.n_accepted = 1;
    r.n_blobs = 1;
    assert_int_equal(mfns_spot_observe(&w, 2, &r, 0.0f), MFNS_SPOT_OK);
    r.blob[0].flux_dn *= 0.2f;
    assert_int_equal(mfns_spot_observe(&w, 2, &r, 0.0f), MFNS_SPOT_OK);
    assert_int_equal(w.matched[2], 0); /* one spot proposes no common shift */
    mfns_spot_evaluate(&w, &rep);
    assert_int_equal(rep.camera, -1);
}

static void test_rejected_and_saturated_blobs_carry_no_ratio(void **state)
{
    (void)state;
    scene_t s;
    scene_init(&s, 8);
    static mfns_spot_watch_t w;
    mfns_spot_init(&w);
    mfns_centroid_result_t r;
    frame(&s, 0, 0.0f, 0.0f, &r);
    r.blob[0].saturated = true;
    r.blob[1].reasons = MFNS_BLOB_SATURATED;
    r.blob[2].flux_dn = NAN;
    assert_int_equal(mfns_spot_observe(&w, 0, &r, 0.0f), MFNS_SPOT_OK);
    assert_int_equal(w.n[0], SPOTS - 3);
    /* the brightest first */
    assert_true(w.flux_dn[0][0] >= w.flux_dn[0][1]);
}

/* One cycle in which camera c's spots move (du[c], dv[c]); cameras with
 * skip[c] give no frame. */
static mfns_spot_report_t cycle_each(scene_t *s, mfns_spot_watch_t *w, const float du[3], const float dv[3],
                                     const bool skip[3])
{
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        mfns_centroid_result_t r;
        frame(s, c, du[c], dv[c], &r);
        if (skip == NULL || !skip[c]) {
            assert_int_equal(mfns_spot_observe(w, c, &r, 0.0f), MFNS_SPOT_OK);
        }
    }
    mfns_spot_report_t rep;
    mfns_spot_evaluate(w, &rep);
    return rep;
}

/* The robot turning steadily, 4 px a frame in every camera:
 *  - camera 1's mount knocked 8.5 px (0.3 deg) in one frame: its spots
 *    jumped, it is named (others smooth), a new episode; the frame after
 *    (the motion back to the robot's) jumps again, in the same episode;
 *  - a knock of 1 px: nothing;
 *  - camera 2 frozen: its spots stop (a 4 px jump), then stay: one jump;
 *  - every camera jolted 10 px together (a collision): all in the mask,
 *    none named;
 *  - a camera without a frame for a cycle: its motion history starts
 *    again (no jump tested in its next frame, though the robot kept
 *    turning). */
static void test_jumps(void **state)
{
    (void)state;
    scene_t s;
    scene_init(&s, 11);
    static mfns_spot_watch_t w;
    mfns_spot_init(&w);
    float du[3] = {4.0f, 4.0f, 4.0f}, dv[3] = {-1.0f, -1.0f, -1.0f};
    mfns_spot_report_t rep;
    for (int k = 0; k < 10; k++) {
        rep = cycle_each(&s, &w, du, dv, NULL);
        assert_int_equal(rep.jump_mask, 0);
    }
    du[1] = 4.0f + 8.5f;
    rep = cycle_each(&s, &w, du, dv, NULL);
    print_message("knock 8.5 px: mask %u camera %d jump %.2f px, others %.2f\n", rep.jump_mask, rep.jump_camera,
                  (double)rep.jump_px, (double)rep.others_px);
    assert_int_equal(rep.jump_mask, 1U << 1);
    assert_int_equal(rep.jump_camera, 1);
    assert_true(rep.jump_new);
    assert_true(fabsf(rep.jump_px - 8.5f) < 0.3f && rep.others_px < 0.3f);
    du[1] = 4.0f;
    rep = cycle_each(&s, &w, du, dv, NULL);
    assert_int_equal(rep.jump_camera, 1); /* the motion back */
    assert_false(rep.jump_new);
    assert_int_equal(rep.recent_mask, 1U << 1);
    rep = cycle_each(&s, &w, du, dv, NULL);
    assert_int_equal(rep.jump_mask, 0);
    assert_int_equal(rep.recent_mask, 1U << 1); /* the cycle after its last jump */
    for (int k = 0; k < 25; k++) {
        rep = cycle_each(&s, &w, du, dv, NULL);
        assert_int_equal(rep.jump_mask, 0);
        assert_int_equal(rep.recent_mask, 0);
    }
    du[0] = 5.0f; /* a knock of 1 px */
    assert_int_equal(cycle_each(&s, &w, du, dv, NULL).jump_mask, 0);
    du[0] = 4.0f;
    assert_int_equal(cycle_each(&s, &w, du, dv, NULL).jump_mask, 0);
    du[2] = 0.0f; /* camera 2 frozen */
    dv[2] = 0.0f;
    rep = cycle_each(&s, &w, du, dv, NULL);
    assert_int_equal(rep.jump_camera, 2);
    assert_true(rep.jump_new);
    for (int k = 0; k < 5; k++) {
        assert_int_equal(cycle_each(&s, &w, du, dv, NULL).jump_mask, 0);
    }
    du[2] = 4.0f;
    dv[2] = -1.0f;
    (void)cycle_each(&s, &w, du, dv, NULL); /* it thaws: a jump too */
    (void)cycle_each(&s, &w, du, dv, NULL);
    const float jolt[3] = {14.0f, 14.0f, 14.0f};
    rep = cycle_each(&s, &w, jolt, dv, NULL);
    assert_int_equal(rep.jump_mask, 7U);
    assert_int_equal(rep.jump_camera, -1);
    (void)cycle_each(&s, &w, du, dv, NULL);
    (void)cycle_each(&s, &w, du, dv, NULL);
    const bool skip0[3] = {true, false, false};
    (void)cycle_each(&s, &w, du, dv, skip0);
    du[0] = 12.0f; /* moving on while it had no frame: its next frame tests no jump */
    rep = cycle_each(&s, &w, du, dv, NULL);
    assert_int_equal(rep.jump_mask, 0);
    assert_true(w.moved[0][0] != 0U); /* and it remembers this frame's motion */
    du[0] = 4.0f;
    (void)cycle_each(&s, &w, du, dv, NULL);
    assert_int_equal(cycle_each(&s, &w, du, dv, NULL).jump_mask, 0);
    /* camera 0's mount turned 1 deg about its optical axis (the image centre):
     * its spots move in different directions, each by its radius x 0.0175 */
    const double a = 1.0 * 3.14159265358979 / 180.0;
    for (int i = 0; i < SPOTS; i++) {
        const double x = s.u[0][i] - 640.0, y = s.v[0][i] - 512.0;
        s.u[0][i] = (float)(640.0 + x * cos(a) - y * sin(a));
        s.v[0][i] = (float)(512.0 + x * sin(a) + y * cos(a));
    }
    rep = cycle_each(&s, &w, du, dv, NULL);
    print_message("roll 1 deg: mask %u camera %d jump %.2f px\n", rep.jump_mask, rep.jump_camera, (double)rep.jump_px);
    assert_int_equal(rep.jump_camera, 0);
}

/* Camera 0 sees spots at (u[i], v[i]), i < n; one cycle. */
static mfns_spot_report_t two_spot_cycle(mfns_spot_watch_t *w, const float *u, const float *v, unsigned n)
{
    mfns_centroid_result_t r;
    memset(&r, 0, sizeof r);
    for (unsigned i = 0; i < n; i++) {
        r.blob[i].u_q8 = mfns_px_q8_from_float(u[i]);
        r.blob[i].v_q8 = mfns_px_q8_from_float(v[i]);
        r.blob[i].flux_dn = 2000.0f - 100.0f * (float)i;
    }
    r.n_blobs = (uint16_t)n;
    r.n_accepted = (uint16_t)n;
    assert_int_equal(mfns_spot_observe(w, 0, &r, 0.0f), MFNS_SPOT_OK);
    mfns_spot_report_t rep;
    mfns_spot_evaluate(w, &rep);
    return rep;
}

/* Two spots moving 2 px a frame: one of them leaving while the other goes on
 * is no jump; the last one moved 8 px off its path while the other left (the
 * mount turned about its optical axis, seed 3's camera y) is an unmatched
 * jump. */
static void test_the_last_spot_off_its_path(void **state)
{
    (void)state;
    static mfns_spot_watch_t w;
    for (int moved = 0; moved <= 1; moved++) {
        mfns_spot_init(&w);
        float u[2] = {100.0f, 400.0f}, v[2] = {100.0f, 300.0f};
        for (int k = 0; k < 4; k++) {
            u[0] += 2.0f;
            u[1] += 2.0f;
            assert_int_equal(two_spot_cycle(&w, u, v, 2).jump_mask, 0);
        }
        u[0] += 2.0f + (moved ? 8.0f : 0.0f);
        const mfns_spot_report_t rep = two_spot_cycle(&w, u, v, 1);
        assert_int_equal(rep.jump_mask, moved ? 1U : 0U);
        if (moved) {
            assert_float_equal(rep.jump_px, MFNS_SPOT_UNMATCHED_JUMP_PX, 0.0f);
        }
    }
}

static void test_bad_input(void **state)
{
    (void)state;
    scene_t s;
    scene_init(&s, 9);
    static mfns_spot_watch_t w;
    mfns_spot_init(&w);
    mfns_centroid_result_t r;
    frame(&s, 0, 0.0f, 0.0f, &r);
    assert_int_equal(mfns_spot_observe(&w, 0, &r, 1.0f), MFNS_SPOT_OK);
    static mfns_spot_watch_t before;
    before = w;
    assert_int_equal(mfns_spot_observe(NULL, 0, &r, 1.0f), MFNS_SPOT_E_ARG);
    assert_int_equal(mfns_spot_observe(&w, 0, NULL, 1.0f), MFNS_SPOT_E_ARG);
    assert_int_equal(mfns_spot_observe(&w, -1, &r, 1.0f), MFNS_SPOT_E_ARG);
    assert_int_equal(mfns_spot_observe(&w, MFNS_NUM_CAMERAS, &r, 1.0f), MFNS_SPOT_E_ARG);
    assert_int_equal(mfns_spot_observe(&w, 0, &r, NAN), MFNS_SPOT_E_ARG);
    assert_int_equal(mfns_spot_observe(&w, 0, &r, -1.0f), MFNS_SPOT_E_ARG);
    assert_int_equal(mfns_spot_observe(&w, 0, &r, INFINITY), MFNS_SPOT_E_ARG);
    r.n_accepted = (uint16_t)(r.n_blobs + 1U);
    assert_int_equal(mfns_spot_observe(&w, 0, &r, 1.0f), MFNS_SPOT_E_ARG);
    r.n_blobs = MFNS_MAX_BLOBS_PER_CAMERA + 1;
    assert_int_equal(mfns_spot_observe(&w, 0, &r, 1.0f), MFNS_SPOT_E_ARG);
    assert_memory_equal(&w, &before, sizeof w);
    mfns_spot_evaluate(&w, NULL); /* nothing to report into: no crash */
    mfns_spot_report_t rep;
    mfns_spot_evaluate(NULL, &rep);
    assert_int_equal(rep.camera, -1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_clean_names_nothing),
        cmocka_unit_test(test_gain_step_names_the_camera),
        cmocka_unit_test(test_common_step_names_no_camera),
        cmocka_unit_test(test_one_spot_dimmed_is_not_the_camera),
        cmocka_unit_test(test_reported_exposure_change),
        cmocka_unit_test(test_what_it_misses),
        cmocka_unit_test(test_rejected_and_saturated_blobs_carry_no_ratio),
        cmocka_unit_test(test_jumps),
        cmocka_unit_test(test_the_last_spot_off_its_path),
        cmocka_unit_test(test_bad_input),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
