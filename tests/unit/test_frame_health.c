/* Unit tests of camera data health (firmware/frames/frame_health.h): each
 * detector on its own with the fault injected and clean, no false alarm over
 * long clean runs with stamp jitter of the stated bound (+-FH_JITTER_FRAC of
 * a period) and dropped frames, period learning at 18.6 Hz and 2 Hz,
 * probation and recovery, clock re-alignment confirmed by the cross-check,
 * and the digest (a changed pixel in a sampled row, stride padding). */
#include "tests/unit/support/testutil.h"

#include <string.h>

#include "firmware/frames/frame_health.h"

#define P18_US (1e6 / 18.6) /* 53763 us */
#define P2_US 500000.0

/* A simulated rig of three cameras on one frame index. */
typedef struct {
    fh_monitor_t m;
    mfns_rng_t rng;
    double period_us;
    double jitter_frac;  /* uniform +- this fraction of the period per stamp */
    int64_t offset_us[3];   /* clock offset injected per camera */
    int32_t seq_offset[3];  /* sequence offset injected per camera */
    bool frozen[3];
    uint64_t frozen_digest[3];
    fh_event_t obs[3], cross[3];
} rig_t;

static void rig_init(rig_t *r, double period_us, double jitter_frac, uint64_t seed)
{
    memset(r, 0, sizeof *r);
    fh_init(&r->m, 3);
    mfns_rng_seed(&r->rng, seed);
    r->period_us = period_us;
    r->jitter_frac = jitter_frac;
}

static fh_frame_t rig_frame(rig_t *r, unsigned k, uint32_t f)
{
    fh_frame_t fr;
    memset(&fr, 0, sizeof fr);
    const double jit = r->jitter_frac * r->period_us * mfns_rng_range(&r->rng, -1.0, 1.0);
    fr.sequence = f + (uint32_t)r->seq_offset[k];
    fr.capture_us = (uint64_t)(int64_t)(10e6 + f * r->period_us + jit) + (uint64_t)r->offset_us[k];
    fr.ts_source = FH_TS_RECORDED;
    fr.digest = r->frozen[k] ? r->frozen_digest[k] : ((uint64_t)f << 8) + k + 1u;
    fr.digest_valid = true;
    return fr;
}

/* One cycle: frame f of each camera in have (NULL: all three). */
static void rig_cycle(rig_t *r, uint32_t f, const bool *have)
{
    fh_begin_cycle(&r->m);
    for (unsigned k = 0; k < 3; k++) {
        r->obs[k] = (fh_event_t){FH_EV_NONE, 0, 0};
        if (!have || have[k]) {
            const fh_frame_t fr = rig_frame(r, k, f);
            r->obs[k] = fh_observe(&r->m, k, &fr);
        }
    }
    fh_cross_check(&r->m, r->cross);
}

static bool rig_quiet(const rig_t *r)
{
    for (unsigned k = 0; k < 3; k++) {
        if (r->obs[k].kind != FH_EV_NONE || r->cross[k].kind != FH_EV_NONE) {
            return false;
        }
    }
    return true;
}

/* ---- clean: no false alarm ---------------------------------------------- */

static void clean_run(double period_us, uint64_t seed)
{
    rig_t r;
    rig_init(&r, period_us, FH_JITTER_FRAC, seed);
    uint32_t f = 0;
    for (int cycle = 0; cycle < 5000; cycle++) {
        bool have[3] = {true, true, true};
        /* dropped frames: now and then a camera misses a cycle (its next sequence jumps by 2) */
        for (unsigned k = 0; k < 3; k++) {
            have[k] = mfns_rng_uniform(&r.rng) > 0.03;
        }
        /* and now and then every camera drops a few frames at once */
        if (mfns_rng_uniform(&r.rng) < 0.01) {
            f += 5u;
        }
        rig_cycle(&r, f, have);
        if (!rig_quiet(&r)) {
            print_error("cycle %d: events %d %d %d / %d %d %d\n", cycle, r.obs[0].kind, r.obs[1].kind, r.obs[2].kind,
                        r.cross[0].kind, r.cross[1].kind, r.cross[2].kind);
        }
        assert_true(rig_quiet(&r));
        for (unsigned k = 0; k < 3; k++) {
            assert_true(fh_usable(&r.m, k));
        }
        f++;
    }
    for (unsigned k = 0; k < 3; k++) {
        assert_true(r.m.cam[k].period_known);
        assert_near(r.m.cam[k].period_us, period_us, period_us * 1e-3);
        assert_int_equal(fh_correction_us(&r.m, k), 0);
    }
}

static void test_clean_long_run_18hz(void **state)
{
    (void)state;
    clean_run(P18_US, 1);
}

static void test_clean_long_run_2hz(void **state)
{
    (void)state;
    clean_run(P2_US, 2);
}

/* ---- period learning ---------------------------------------------------- */

static void learn(double period_us)
{
    rig_t r;
    rig_init(&r, period_us, 0.02, 3);
    for (uint32_t f = 0; f < FH_LEARN_STEPS; f++) {
        rig_cycle(&r, f, NULL);
        assert_false(r.m.cam[0].period_known);
    }
    rig_cycle(&r, FH_LEARN_STEPS, NULL);
    assert_true(r.m.cam[0].period_known);
    assert_near(r.m.cam[0].period_us, period_us, period_us * 0.01);
}

static void test_period_learned_18hz(void **state)
{
    (void)state;
    learn(P18_US);
}

static void test_period_learned_2hz(void **state)
{
    (void)state;
    learn(P2_US);
}

static void test_jump_during_learning_restarts_it(void **state)
{
    (void)state;
    rig_t r;
    rig_init(&r, P18_US, 0.0, 4);
    for (uint32_t f = 0; f < 4; f++) {
        rig_cycle(&r, f, NULL);
    }
    r.offset_us[1] = 5000000; /* +5 s while camera y is still learning */
    rig_cycle(&r, 4, NULL);
    assert_true(rig_quiet(&r)); /* nothing to judge the step against yet */
    for (uint32_t f = 5; f < 4 + FH_LEARN_STEPS; f++) {
        rig_cycle(&r, f, NULL);
        assert_false(r.m.cam[1].period_known); /* learning began again at the step */
    }
    assert_true(r.m.cam[0].period_known);
    rig_cycle(&r, 4 + FH_LEARN_STEPS, NULL);
    assert_true(r.m.cam[1].period_known);
    assert_near(r.m.cam[1].period_us, P18_US, 1.0);
}

/* ---- FROZEN ------------------------------------------------------------- */

static void test_frozen_content_left_out_then_probation(void **state)
{
    (void)state;
    rig_t r;
    rig_init(&r, P18_US, 0.05, 5);
    for (uint32_t f = 0; f < 30; f++) {
        rig_cycle(&r, f, NULL);
    }
    r.frozen[2] = true;
    r.frozen_digest[2] = 0x1234u;
    rig_cycle(&r, 30, NULL); /* the first frozen frame differs from frame 29: not yet */
    assert_true(rig_quiet(&r));
    rig_cycle(&r, 31, NULL); /* the same content again */
    assert_int_equal(r.obs[2].kind, FH_EV_FROZEN);
    assert_int_equal(r.obs[2].arg0, 0);
    assert_int_equal(fh_state(&r.m, 2), FH_FROZEN);
    assert_false(fh_usable(&r.m, 2));
    assert_true(fh_usable(&r.m, 0) && fh_usable(&r.m, 1));
    for (uint32_t f = 32; f < 80; f++) {
        rig_cycle(&r, f, NULL);
        assert_true(rig_quiet(&r)); /* one event on entering the state */
        assert_int_equal(fh_state(&r.m, 2), FH_FROZEN);
    }
    r.frozen[2] = false;
    for (uint32_t f = 80; f < 80 + FH_PROBATION_FRAMES - 1u; f++) {
        rig_cycle(&r, f, NULL);
        assert_int_equal(fh_state(&r.m, 2), FH_PROBATION);
        assert_false(fh_usable(&r.m, 2));
    }
    rig_cycle(&r, 80 + FH_PROBATION_FRAMES - 1u, NULL);
    assert_int_equal(r.obs[2].kind, FH_EV_HEALTHY);
    assert_int_equal(r.obs[2].arg0, FH_PROBATION_FRAMES);
    assert_true(fh_usable(&r.m, 2));
}

static void test_frozen_sequence(void **state)
{
    (void)state;
    fh_monitor_t m;
    fh_init(&m, 1);
    fh_frame_t f = {.sequence = 7, .capture_us = 1000, .digest = 1, .digest_valid = true};
    assert_int_equal(fh_observe(&m, 0, &f).kind, FH_EV_NONE);
    f.capture_us += 53763;
    f.digest = 2; /* new content, but the driver's counter did not move */
    const fh_event_t ev = fh_observe(&m, 0, &f);
    assert_int_equal(ev.kind, FH_EV_FROZEN);
    assert_int_equal(ev.arg0, 1);
    assert_false(fh_usable(&m, 0));
    /* a probation frame that repeats the content again restarts the count */
    f.sequence = 8;
    f.capture_us += 53763;
    f.digest = 3;
    assert_int_equal(fh_observe(&m, 0, &f).kind, FH_EV_NONE);
    assert_int_equal(fh_state(&m, 0), FH_PROBATION);
    f.sequence = 9;
    f.capture_us += 53763;
    assert_int_equal(fh_observe(&m, 0, &f).kind, FH_EV_FROZEN);
    assert_int_equal(m.cam[0].clean_run, 0);
}

/* ---- CLOCK_FAULT and re-alignment --------------------------------------- */

static void clock_step(int64_t step_us, bool confirm_with_others)
{
    rig_t r;
    rig_init(&r, P18_US, 0.05, 6);
    const bool only_y[3] = {false, true, false};
    for (uint32_t f = 0; f < 40; f++) {
        rig_cycle(&r, f, NULL);
    }
    r.offset_us[1] = step_us;
    rig_cycle(&r, 40, confirm_with_others ? NULL : only_y);
    assert_int_equal(r.obs[1].kind, FH_EV_CLOCK_JUMP);
    assert_near((double)r.obs[1].arg0, (double)step_us, 0.3 * P18_US);
    assert_int_equal(fh_state(&r.m, 1), FH_CLOCK_FAULT);
    assert_false(fh_usable(&r.m, 1));
    /* its stamps are corrected by the measured step */
    assert_near((double)fh_correction_us(&r.m, 1), (double)-step_us, 0.3 * P18_US);
    uint32_t f = 41;
    for (; f < 41 + FH_PROBATION_FRAMES - 1u; f++) {
        rig_cycle(&r, f, confirm_with_others ? NULL : only_y);
        assert_int_equal(fh_state(&r.m, 1), FH_PROBATION);
    }
    for (; f < 80; f++) {
        rig_cycle(&r, f, confirm_with_others ? NULL : only_y);
        if (f == 41 + FH_PROBATION_FRAMES - 1u && confirm_with_others) {
            assert_int_equal(r.obs[1].kind == FH_EV_HEALTHY || r.cross[1].kind == FH_EV_HEALTHY, true);
        }
    }
    if (confirm_with_others) {
        assert_true(fh_usable(&r.m, 1));
        /* the corrected stamp is the frame's capture time again */
        assert_near((double)r.m.cam[1].t_us, 10e6 + 79 * P18_US, 0.3 * P18_US);
    } else {
        /* nothing healthy to confirm the re-alignment against: left out */
        assert_int_equal(fh_state(&r.m, 1), FH_PROBATION);
        assert_false(fh_usable(&r.m, 1));
    }
}

static void test_clock_step_ahead_realigned_when_confirmed(void **state)
{
    (void)state;
    clock_step(5000000, true);
}

static void test_clock_step_back_realigned_when_confirmed(void **state)
{
    (void)state;
    clock_step(-1000000, true);
}

static void test_clock_step_without_reference_stays_out(void **state)
{
    (void)state;
    clock_step(5000000, false);
}

/* Every clock steps at once (+5 s): no healthy camera is left, each camera's
 * own measured correction is confirmed by the others' and all come back. */
static void test_all_clocks_step_confirm_each_other(void **state)
{
    (void)state;
    rig_t r;
    rig_init(&r, P18_US, 0.05, 11);
    for (uint32_t f = 0; f < 40; f++) {
        rig_cycle(&r, f, NULL);
    }
    for (unsigned k = 0; k < 3; k++) {
        r.offset_us[k] = 5000000;
    }
    rig_cycle(&r, 40, NULL);
    for (unsigned k = 0; k < 3; k++) {
        assert_int_equal(r.obs[k].kind, FH_EV_CLOCK_JUMP);
        assert_false(fh_usable(&r.m, k));
    }
    for (uint32_t f = 41; f < 41 + FH_PROBATION_FRAMES; f++) {
        rig_cycle(&r, f, NULL);
    }
    for (unsigned k = 0; k < 3; k++) {
        assert_true(fh_usable(&r.m, k));
        assert_near((double)fh_correction_us(&r.m, k), -5e6, 0.3 * P18_US);
    }
}

static void test_small_step_below_tolerance_passes(void **state)
{
    (void)state;
    rig_t r;
    rig_init(&r, P18_US, 0.0, 7);
    for (uint32_t f = 0; f < 40; f++) {
        rig_cycle(&r, f, NULL);
    }
    r.offset_us[0] = (int64_t)(0.25 * P18_US); /* the cadence check's stated miss: below 0.3 period */
    rig_cycle(&r, 40, NULL);
    assert_int_equal(r.obs[0].kind, FH_EV_NONE);
    /* the cross-check's drift test sees it against the other two (exact stamps: the 1 ms floor): fused, in doubt */
    assert_int_equal(r.cross[0].kind, FH_EV_CLOCK_DRIFT);
    assert_near((double)r.cross[0].arg0, 0.25 * P18_US, 2.0);
    assert_int_equal(r.cross[1].kind, FH_EV_NONE);
    assert_int_equal(r.cross[2].kind, FH_EV_NONE);
    assert_true(fh_usable(&r.m, 0) && fh_drift_suspect(&r.m, 0));
    assert_false(fh_drift_suspect(&r.m, 1) || fh_drift_suspect(&r.m, 2));
    r.offset_us[0] = (int64_t)(0.25 * P18_US + 0.4 * P18_US); /* a further 0.4 period: caught */
    rig_cycle(&r, 41, NULL);
    assert_int_equal(r.obs[0].kind, FH_EV_CLOCK_JUMP);
}

/* ---- clock drift against the other cameras ------------------------------ */

/* Camera `cam`'s clock runs fast by drift_us a frame from frame 20: its stamp
 * of frame f is t_f + drift_us (f - 19). Returns the first frame with the
 * CLOCK_DRIFT event (0 none) and the first one left out (0 none). */
static void drift_run(double jitter_frac, double drift_us, unsigned cam, uint32_t *first_drift, uint32_t *first_out,
                      bool *blame_ok)
{
    rig_t r;
    rig_init(&r, P18_US, jitter_frac, 11);
    *first_drift = *first_out = 0;
    *blame_ok = true;
    for (uint32_t f = 0; f < 200; f++) {
        r.offset_us[cam] = f >= 20u ? (int64_t)(drift_us * (double)(f - 19u)) : 0;
        rig_cycle(&r, f, NULL);
        for (unsigned k = 0; k < 3; k++) {
            if (k != cam && (r.cross[k].kind != FH_EV_NONE || !fh_usable(&r.m, k) || fh_drift_suspect(&r.m, k))) {
                *blame_ok = false; /* a healthy camera named */
            }
        }
        if (*first_drift == 0u && r.cross[cam].kind == FH_EV_CLOCK_DRIFT) {
            *first_drift = f;
            assert_int_not_equal(r.cross[cam].arg1, (int64_t)cam);
            assert_true(fh_drift_suspect(&r.m, cam));
            assert_true(fh_usable(&r.m, cam)); /* in doubt, still fused */
        }
        if (*first_out == 0u && !fh_usable(&r.m, cam)) {
            *first_out = f;
        }
    }
}

static void test_clock_drift_in_doubt_then_left_out(void **state)
{
    (void)state;
    /* stamps without jitter (a simulator, or a clock of microseconds): the
     * floor, 1 ms, is the test; 2, 1 and 0.5 ms a frame */
    const double drift_ms[3] = {2.0, 1.0, 0.5};
    for (int i = 0; i < 3; i++) {
        uint32_t fd = 0, fo = 0;
        bool ok = false;
        drift_run(0.0, drift_ms[i] * 1000.0, 1, &fd, &fo, &ok);
        assert_true(ok);
        /* the pairs learned before the onset (cycle 8 + FH_PHASE_LEARN): named once the offset passes 1 ms */
        assert_true(8u + FH_PHASE_LEARN < 20u);
        assert_in_range(fd, 20, 23);
        /* and left out before the offset reaches 0.6 period: the reference no longer follows it */
        assert_true(fo > fd);
        assert_true((double)(fo - 19u) * drift_ms[i] * 1000.0 <= 0.6 * P18_US);
    }
    /* stamps with the stated jitter bound (+-10 % of a period each): the
     * learned rms sets the test; a 2 ms drift is named within a few frames of
     * the two stamps' spread */
    uint32_t fd = 0, fo = 0;
    bool ok = false;
    drift_run((double)FH_JITTER_FRAC, 2000.0, 2, &fd, &fo, &ok);
    assert_true(ok);
    assert_true(fd > 0u && fo > 0u);
    assert_true((double)(fo - 19u) * 2000.0 <= 0.6 * P18_US + 2.0 * (double)FH_JITTER_FRAC * P18_US);
    /* a drift of 100 ppm (5.4 us a frame) is followed: no event, no doubt */
    drift_run(0.0, 1e-4 * P18_US, 0, &fd, &fo, &ok);
    assert_true(ok);
    assert_int_equal(fd, 0);
    assert_int_equal(fo, 0);
}

static void test_stamp_backwards_while_learning(void **state)
{
    (void)state;
    fh_monitor_t m;
    fh_init(&m, 1);
    fh_frame_t f = {.sequence = 0, .capture_us = 5000000, .digest = 1, .digest_valid = true};
    assert_int_equal(fh_observe(&m, 0, &f).kind, FH_EV_NONE);
    f.sequence = 1;
    f.capture_us = 4000000;
    f.digest = 2;
    assert_int_equal(fh_observe(&m, 0, &f).kind, FH_EV_CLOCK_JUMP);
    assert_true(m.cam[0].corr_unknown); /* no period to measure the step by: never re-aligned */
}

/* ---- LATE and the arrival clock ----------------------------------------- */

static void test_late_and_future_stamps(void **state)
{
    (void)state;
    fh_monitor_t m;
    fh_init(&m, 1);
    fh_frame_t f = {.ts_source = FH_TS_CAPTURE_EOF, .arrival_valid = true, .digest_valid = true};
    uint32_t s = 0;
    for (; s < 20; s++) {
        f.sequence = s;
        f.capture_us = 1000000u + s * 53763u;
        f.arrival_us = f.capture_us + 3000u; /* 3 ms pipeline */
        f.digest = s + 1u;
        assert_int_equal(fh_observe(&m, 0, &f).kind, FH_EV_NONE);
    }
    /* stamped on arrival's clock but two periods old */
    f.sequence = s;
    f.capture_us = 1000000u + s * 53763u;
    f.arrival_us = f.capture_us + 2u * 53763u;
    f.digest = 99;
    fh_event_t ev = fh_observe(&m, 0, &f);
    assert_int_equal(ev.kind, FH_EV_LATE);
    assert_int_equal(ev.arg0, 2 * 53763);
    assert_int_equal(fh_state(&m, 0), FH_LATE);
    /* a copied stamp says nothing about capture: no arrival check */
    fh_init(&m, 1);
    f.ts_source = FH_TS_COPY;
    assert_int_equal(fh_observe(&m, 0, &f).kind, FH_EV_NONE);
    /* a stamp later than the frame's arrival */
    fh_init(&m, 1);
    f.ts_source = FH_TS_CAPTURE_SOE;
    f.arrival_us = f.capture_us - 1000u;
    ev = fh_observe(&m, 0, &f);
    assert_int_equal(ev.kind, FH_EV_CLOCK_JUMP);
    assert_false(fh_usable(&m, 0));
    /* no arrival clock: no check */
    fh_init(&m, 1);
    f.arrival_valid = false;
    assert_int_equal(fh_observe(&m, 0, &f).kind, FH_EV_NONE);
}

/* ---- sequence cross-check ----------------------------------------------- */

/* y joins late and its clock steps while it is still learning (the cadence
 * check cannot see it): the cross-check against x and z does. */
static void cross(bool three)
{
    rig_t r;
    rig_init(&r, P18_US, 0.05, 8);
    bool have[3] = {true, false, three};
    for (uint32_t f = 0; f < 30; f++) {
        rig_cycle(&r, f, have);
    }
    have[1] = true;
    for (uint32_t f = 30; f < 33; f++) {
        rig_cycle(&r, f, have);
        assert_true(rig_quiet(&r));
    }
    r.offset_us[1] = 5000000;
    uint32_t f = 33;
    for (; f < 34 + FH_LEARN_STEPS; f++) { /* learning starts again after the step */
        rig_cycle(&r, f, have);
        if (!rig_quiet(&r)) {
            break;
        }
    }
    assert_int_equal(f, 33 + FH_LEARN_STEPS); /* as soon as y's period is learned again */
    assert_int_equal(r.cross[1].kind, FH_EV_SEQ_MISMATCH);
    assert_near((double)r.cross[1].arg0, 5e6 / P18_US, 1.0); /* 93 frames */
    assert_false(fh_usable(&r.m, 1));
    if (three) {
        /* the odd one out: x and z agree and go on */
        assert_int_equal(r.cross[0].kind, FH_EV_NONE);
        assert_int_equal(r.cross[2].kind, FH_EV_NONE);
        assert_true(fh_usable(&r.m, 0) && fh_usable(&r.m, 2));
        for (f++; f < 100; f++) {
            rig_cycle(&r, f, have);
            assert_false(fh_usable(&r.m, 1)); /* it never agrees again */
            assert_true(fh_usable(&r.m, 0) && fh_usable(&r.m, 2));
        }
    } else {
        /* two cameras that disagree: both suspect */
        assert_int_equal(r.cross[0].kind, FH_EV_SEQ_MISMATCH);
        assert_false(fh_usable(&r.m, 0));
    }
}

static void test_cross_check_odd_one_out(void **state)
{
    (void)state;
    cross(true);
}

static void test_cross_check_two_cameras_both_suspect(void **state)
{
    (void)state;
    cross(false);
}

static void test_sequence_backwards_and_reopen(void **state)
{
    (void)state;
    rig_t r;
    rig_init(&r, P18_US, 0.0, 9);
    for (uint32_t f = 0; f < 20; f++) {
        rig_cycle(&r, f, NULL);
    }
    /* a device re-opened restarts its counter: not a fault, learned again */
    fh_reopened(&r.m, 0, false);
    r.seq_offset[0] = -21;
    rig_cycle(&r, 21, NULL);
    assert_true(rig_quiet(&r));
    assert_true(r.m.pair[0].valid); /* learned again at once: x and y fused in step */
    assert_int_equal(r.m.pair[0].ds_ref, 21);
    /* the same without a re-open: the sequence went backwards */
    r.seq_offset[2] = -10;
    rig_cycle(&r, 22, NULL);
    assert_int_equal(r.obs[2].kind, FH_EV_SEQ_MISMATCH);
    assert_int_equal(fh_state(&r.m, 2), FH_OUT_OF_STEP);
    /* replay goes on with its frame numbers: a step across the gap is judged */
    rig_t q;
    rig_init(&q, P18_US, 0.0, 10);
    for (uint32_t f = 0; f < 20; f++) {
        rig_cycle(&q, f, NULL);
    }
    fh_reopened(&q.m, 1, true);
    q.offset_us[1] = -1000000;
    const bool no_y[3] = {true, false, true};
    for (uint32_t f = 20; f < 40; f++) {
        rig_cycle(&q, f, no_y);
    }
    rig_cycle(&q, 40, NULL);
    assert_int_equal(q.obs[1].kind, FH_EV_CLOCK_JUMP);
    assert_near((double)q.obs[1].arg0, -1e6, 100.0);
}

/* ---- digest ------------------------------------------------------------- */

static void test_digest_sees_a_pixel_ignores_padding(void **state)
{
    (void)state;
    enum { W = 40, H = 33, STRIDE = 48 };
    static uint8_t a[STRIDE * H], b[STRIDE * H];
    for (size_t i = 0; i < sizeof a; i++) {
        a[i] = (uint8_t)(i * 7u);
    }
    memcpy(b, a, sizeof b);
    mfns_frame_t fa = {a, W, H, STRIDE, MFNS_PIXFMT_GREY};
    mfns_frame_t fb = {b, W, H, STRIDE, MFNS_PIXFMT_GREY};
    assert_true(fh_digest(&fa, NULL) == fh_digest(&fb, NULL));
    /* padding past the image bytes of every row: never read */
    for (unsigned r = 0; r < H; r++) {
        for (unsigned c = W; c < STRIDE; c++) {
            b[r * STRIDE + c] ^= 0xffu;
        }
    }
    assert_true(fh_digest(&fa, NULL) == fh_digest(&fb, NULL));
    /* one pixel of a sampled row */
    b[FH_DIGEST_ROW_STEP * STRIDE + 17] ^= 1u;
    assert_true(fh_digest(&fa, NULL) != fh_digest(&fb, NULL));
    b[FH_DIGEST_ROW_STEP * STRIDE + 17] ^= 1u;
    /* the last row is always sampled */
    b[(H - 1) * STRIDE + W - 1] ^= 1u;
    assert_true(fh_digest(&fa, NULL) != fh_digest(&fb, NULL));
    b[(H - 1) * STRIDE + W - 1] ^= 1u;
    /* a row between samples: the stated miss */
    b[1 * STRIDE + 3] ^= 1u;
    assert_true(fh_digest(&fa, NULL) == fh_digest(&fb, NULL));
    /* 16-bit: both bytes of a pixel count */
    static uint16_t w16[W * H];
    for (size_t i = 0; i < W * H; i++) {
        w16[i] = (uint16_t)(i & 0x3ffu);
    }
    mfns_frame_t f16 = {w16, W, H, W * 2u, MFNS_PIXFMT_Y10};
    const uint64_t d16 = fh_digest(&f16, NULL);
    w16[W - 1] ^= 0x100u; /* high byte of the last pixel of row 0 */
    assert_true(fh_digest(&f16, NULL) != d16);
    /* a uniform frame is flat; one different pixel in a sampled row is not */
    static uint8_t u[STRIDE * H];
    memset(u, 6, sizeof u);
    mfns_frame_t fu = {u, W, H, STRIDE, MFNS_PIXFMT_GREY};
    bool flat = false;
    (void)fh_digest(&fu, &flat);
    assert_true(flat);
    u[(H - 1) * STRIDE] = 7;
    (void)fh_digest(&fu, &flat);
    assert_false(flat);
    (void)fh_digest(&fa, &flat);
    assert_false(flat);
    /* bad frames: 0, never a read */
    mfns_frame_t bad = {NULL, W, H, STRIDE, MFNS_PIXFMT_GREY};
    assert_true(fh_digest(&bad, NULL) == 0u);
    bad.data = a;
    bad.stride_bytes = W - 1u;
    assert_true(fh_digest(&bad, NULL) == 0u);
}

static void test_bad_arguments(void **state)
{
    (void)state;
    fh_monitor_t m;
    fh_init(&m, 9); /* clamped */
    assert_int_equal(m.n, FH_MAX_CAMERAS);
    fh_frame_t f = {.sequence = 1};
    assert_int_equal(fh_observe(&m, 5, &f).kind, FH_EV_NONE);
    assert_int_equal(fh_observe(&m, 0, NULL).kind, FH_EV_NONE);
    assert_false(fh_usable(&m, 5));
    assert_string_equal(fh_state_name(FH_OUT_OF_STEP), "OUT_OF_STEP");
    assert_string_equal(fh_state_name(FH_STATE_COUNT), "?");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_clean_long_run_18hz),
        cmocka_unit_test(test_clean_long_run_2hz),
        cmocka_unit_test(test_period_learned_18hz),
        cmocka_unit_test(test_period_learned_2hz),
        cmocka_unit_test(test_jump_during_learning_restarts_it),
        cmocka_unit_test(test_frozen_content_left_out_then_probation),
        cmocka_unit_test(test_frozen_sequence),
        cmocka_unit_test(test_clock_step_ahead_realigned_when_confirmed),
        cmocka_unit_test(test_clock_step_back_realigned_when_confirmed),
        cmocka_unit_test(test_clock_step_without_reference_stays_out),
        cmocka_unit_test(test_all_clocks_step_confirm_each_other),
        cmocka_unit_test(test_small_step_below_tolerance_passes),
        cmocka_unit_test(test_clock_drift_in_doubt_then_left_out),
        cmocka_unit_test(test_stamp_backwards_while_learning),
        cmocka_unit_test(test_late_and_future_stamps),
        cmocka_unit_test(test_cross_check_odd_one_out),
        cmocka_unit_test(test_cross_check_two_cameras_both_suspect),
        cmocka_unit_test(test_sequence_backwards_and_reopen),
        cmocka_unit_test(test_digest_sees_a_pixel_ignores_padding),
        cmocka_unit_test(test_bad_arguments),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
