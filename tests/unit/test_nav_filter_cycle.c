/* test_nav_filter_cycle.c -- the filter bank inside the navigation cycle
 * (firmware/nav/filter/nav_filter_cycle.h): off, nothing changes (the
 * solution and integrity result are left bit for bit); on, it starts from a
 * usable snapshot fix (or one bounded beyond the alert limit), takes the
 * solver's associations and its own where the solver has none and, once its
 * PL is within the alert limits, reports its own pose, covariance and PL. */
#include <string.h>

#include "firmware/nav/filter/nav_filter_cycle.h"
#include "tests/unit/support/pose_testlib.h"
#include "tests/unit/support/testutil.h"

#pragma GCC diagnostic ignored "-Wdouble-promotion"

#define CYCLES 40
static const int PER_CAM[3] = {4, 3, 3};

static mfns_caltable_t table; /* large: static */

static void setup(mfns_rng_t *rng, pt_dpose_t *truth)
{
    memset(&table, 0, sizeof table);
    table.rig = pt_paper_rig();
    static const double eye[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    static const double r0[3] = {0, 0, 0};
    *truth = pt_pose(eye, r0);
    table.beacons = pt_dense_map(&table.rig, truth, PER_CAM, 900, 1400, rng);
    mfns_integrity_settings_default(&table.integrity);
    mfns_filter_settings_default(&table.motion);
}

/* A snapshot "fix" at the truth with its frame's associations. */
static void snapshot(const pt_dpose_t *truth, mfns_rng_t *rng, mfns_obs_frame_t *frame, mfns_pose_solution_t *sol,
                     mfns_integrity_result_t *integ)
{
    mfns_pose_solution_clear(sol, MFNS_POSE_R_NONE);
    mfns_pose_assoc_t assoc;
    assert_true(pt_make_frame(&table.rig, &table.beacons, truth, 0.1, rng, frame, &assoc) >= 8);
    sol->assoc = assoc;
    sol->status = MFNS_POSE_DEGRADED;
    sol->reason = MFNS_POSE_R_CAMERA_UNMONITORED;
    sol->pose = pt_to_float(truth);
    for (int i = 0; i < 3; i++) {
        sol->cov_ros[i][i] = 0.25f;        /* 0.5 mm */
        sol->cov_ros[3 + i][3 + i] = 1e-7f; /* 0.3 mrad */
    }
    memset(integ, 0, sizeof(*integ));
    integ->pl_pos_mm = 19.0f;
}

/* A usable output's position within its PL of the truth, on every axis. */
static void assert_within_pl(const pt_dpose_t *truth, const mfns_pose_solution_t *sol,
                             const mfns_integrity_result_t *integ)
{
    double r[3];
    pt_position_w(truth, r);
    assert_true(fabs(sol->r_wb_w.x - r[0]) <= integ->pl_pos_mm);
    assert_true(fabs(sol->r_wb_w.y - r[1]) <= integ->pl_pos_mm);
    assert_true(fabs(sol->r_wb_w.z - r[2]) <= integ->pl_pos_mm);
}

static void test_off_changes_nothing(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 1);
    pt_dpose_t truth;
    setup(&rng, &truth);
    static mfns_navf_t nf;
    memset(&nf, 0, sizeof nf); /* as mfns_nav_init leaves it: off */
    for (int k = 0; k < 5; k++) {
        mfns_obs_frame_t frame;
        mfns_pose_solution_t sol, before;
        mfns_integrity_result_t integ, integ_before;
        snapshot(&truth, &rng, &frame, &sol, &integ);
        before = sol;
        integ_before = integ;
        mfns_navf_report_t rep;
        mfns_navf_step(&nf, &table, &table.integrity, &frame, 0.1f, &sol, &integ, &rep);
        assert_memory_equal(&sol, &before, sizeof sol);
        assert_memory_equal(&integ, &integ_before, sizeof integ);
        assert_false(rep.ran || rep.used || rep.started);
    }
}

static void test_on_starts_and_takes_over(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 2);
    pt_dpose_t truth;
    setup(&rng, &truth);
    static mfns_navf_t nf;
    mfns_navf_enable(&nf, 54000);
    int used = 0, first_used = -1;
    for (int k = 0; k < CYCLES; k++) {
        mfns_obs_frame_t frame;
        mfns_pose_solution_t sol;
        mfns_integrity_result_t integ;
        snapshot(&truth, &rng, &frame, &sol, &integ);
        mfns_navf_report_t rep;
        mfns_navf_step(&nf, &table, &table.integrity, &frame, 0.1f, &sol, &integ, &rep);
        if (k == 0) {
            /* started, and the start cycle's own frames taken at once: with
             * 10 beacons over three cameras the bank certifies them itself */
            assert_true(rep.started);
        }
        assert_true(rep.ran);
        assert_false(rep.out.restart);
        if (rep.used) {
            used++;
            first_used = first_used < 0 ? k : first_used;
            assert_true(sol.status == MFNS_POSE_OK || sol.status == MFNS_POSE_DEGRADED);
            assert_true(integ.pl_pos_mm <= table.integrity.alert_limit_pos_mm);
            assert_near(integ.pl_pos_mm, rep.out.pl_pos_mm, 1e-6);
            /* its pose, within its PL of the truth */
            double r[3];
            pt_position_w(&truth, r);
            const double est[3] = {sol.r_wb_w.x, sol.r_wb_w.y, sol.r_wb_w.z};
            for (int i = 0; i < 3; i++) {
                assert_true(fabs(est[i] - r[i]) <= integ.pl_pos_mm);
                assert_true(sol.sigma_pos_mm[i] > 0.0f);
            }
        }
    }
    print_message("filter in the cycle: first used at cycle %d, used in %d of %d\n", first_used, used, CYCLES);
    assert_true(first_used >= 0 && first_used <= 10);
    assert_true(used >= CYCLES - 10);
    /* off again: nothing */
    mfns_navf_enable(&nf, 0);
    mfns_obs_frame_t frame;
    mfns_pose_solution_t sol;
    mfns_integrity_result_t integ;
    snapshot(&truth, &rng, &frame, &sol, &integ);
    mfns_navf_report_t rep;
    mfns_navf_step(&nf, &table, &table.integrity, &frame, 0.1f, &sol, &integ, &rep);
    assert_false(rep.ran);
}

/* A camera's clock in doubt (mfns_navf_doubt_timing): off, nothing is held;
 * on, a doubt raised before the bank starts is the started bank's, and it
 * holds while the readings cannot clear it (a robot at rest shows no clock:
 * no power), the bank still flying on the camera's timing-free frames; a
 * camera out of range is ignored. */
static void test_timing_doubt(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 12);
    pt_dpose_t truth;
    setup(&rng, &truth);
    static mfns_navf_t nf;
    mfns_navf_enable(&nf, 0);
    mfns_navf_doubt_timing(&nf, 1);
    assert_int_equal(nf.timing_doubt, 0); /* off: nothing */
    mfns_navf_enable(&nf, 54000);
    mfns_navf_doubt_timing(&nf, -1);
    mfns_navf_doubt_timing(&nf, MFNS_NUM_CAMERAS);
    assert_int_equal(nf.timing_doubt, 0);
    mfns_navf_doubt_timing(&nf, 1);
    assert_int_equal(nf.timing_doubt, 2);
    int used = 0;
    for (int k = 0; k < CYCLES; k++) {
        mfns_obs_frame_t frame;
        mfns_pose_solution_t sol;
        mfns_integrity_result_t integ;
        snapshot(&truth, &rng, &frame, &sol, &integ);
        mfns_navf_report_t rep;
        mfns_navf_step(&nf, &table, &table.integrity, &frame, 0.1f, &sol, &integ, &rep);
        assert_true(rep.ran);
        assert_int_equal(nf.bank.timing_doubt[1], 1);
        assert_int_equal(nf.bank.timing_doubt[0] + nf.bank.timing_doubt[2], 0);
        assert_int_equal(rep.out.timing_doubt_mask, 2);
        assert_int_equal(rep.out.timing_trusted, -1);
        used += rep.used ? 1 : 0;
        if (rep.used) {
            assert_within_pl(&truth, &sol, &integ);
        }
    }
    print_message("camera y's clock in doubt at rest: used in %d of %d\n", used, CYCLES);
    assert_true(used >= CYCLES - 10);
    assert_int_equal(nf.timing_doubt, 2);
}

/* A frame the snapshot's checks find lagging (mfns_navf_suspect_frame):
 * off, nothing; on, the step it precedes is refused, NO_FIX FRAME_SUSPECT
 * naming the camera, no clock is put in doubt, and the following steps are
 * usable again (the suspicion is one cycle's); a camera out of range is
 * ignored. */
static void test_suspect_frame_refuses_its_cycle(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 13);
    pt_dpose_t truth;
    setup(&rng, &truth);
    static mfns_navf_t nf;
    mfns_navf_enable(&nf, 0);
    mfns_navf_suspect_frame(&nf, 2);
    assert_int_equal(nf.suspect_cam, -1); /* off: nothing */
    mfns_navf_enable(&nf, 54000);
    assert_int_equal(nf.suspect_cam, -1);
    mfns_navf_suspect_frame(&nf, -1);
    mfns_navf_suspect_frame(&nf, MFNS_NUM_CAMERAS);
    assert_int_equal(nf.suspect_cam, -1);
    assert_int_equal(nf.timing_doubt, 0);
    const int suspect_at = 20;
    int used_after = 0;
    bool used_before = false;
    for (int k = 0; k < CYCLES; k++) {
        mfns_obs_frame_t frame;
        mfns_pose_solution_t sol;
        mfns_integrity_result_t integ;
        snapshot(&truth, &rng, &frame, &sol, &integ);
        if (k == suspect_at) {
            mfns_navf_suspect_frame(&nf, 2);
        }
        mfns_navf_report_t rep;
        mfns_navf_step(&nf, &table, &table.integrity, &frame, 0.1f, &sol, &integ, &rep);
        assert_true(rep.ran);
        assert_int_equal(nf.suspect_cam, -1); /* consumed by the step */
        if (k == suspect_at - 1) {
            used_before = rep.used; /* the step before was usable: the refusal is the suspicion's */
        }
        if (k == suspect_at) {
            assert_false(rep.used);
            assert_false(rep.out.usable);
            assert_int_equal(rep.out.status, MFNS_POSE_NO_FIX);
            assert_int_equal(rep.out.reason, MFNS_POSE_R_FRAME_SUSPECT);
            assert_int_equal(rep.out.suspect_camera, 2);
            assert_int_equal(sol.status == MFNS_POSE_OK || sol.status == MFNS_POSE_DEGRADED, 0);
        }
        assert_int_equal(nf.timing_doubt, 0);
        assert_int_equal(nf.bank.timing_doubt[2], 0);
        if (k > suspect_at && rep.used) {
            used_after++;
            assert_within_pl(&truth, &sol, &integ);
        }
    }
    print_message("suspect frame at cycle %d: refused; used in %d of the %d after\n", suspect_at, used_after,
                  CYCLES - suspect_at - 1);
    assert_true(used_before);
    assert_true(used_after >= CYCLES - suspect_at - 1 - 2);
}

/* The filter's motion bound is the bound table's (docs/caltable.md "Motion
 * bound"), read every cycle: the same frames under a tighter acceleration
 * bound leave a smaller covariance and PL (less process noise), a re-bound
 * table's bound takes effect at the next cycle, and a table whose bound is
 * not valid filter settings (which the loader never lets through) stops the
 * bank instead of running it on garbage. */
/* 20 cycles on the same frames (seed 6) under a linear acceleration bound of
 * accel_mm_s2; from cycle broken_from on (-1: never) the table's bound is
 * made invalid (a coast beyond T). The last cycle's sigma x and PL. */
static float run_with_accel(float accel_mm_s2, int broken_from, float *sigma_mm)
{
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 6);
    pt_dpose_t truth;
    setup(&rng, &truth);
    table.motion.accel_bound_mm_s2 = accel_mm_s2;
    static mfns_navf_t nf;
    mfns_navf_enable(&nf, 54000);
    float pl = -1.0f;
    for (int k = 0; k < 20; k++) {
        mfns_obs_frame_t frame;
        mfns_pose_solution_t sol;
        mfns_integrity_result_t integ;
        snapshot(&truth, &rng, &frame, &sol, &integ);
        if (k == broken_from) {
            table.motion.max_coast_s = 2.0f * table.motion.bound_time_s; /* the loader's cross-field rule */
        }
        mfns_navf_report_t rep;
        mfns_navf_step(&nf, &table, &table.integrity, &frame, 0.1f, &sol, &integ, &rep);
        /* a bound that is not valid settings: the bank does not run, the
         * snapshot's verdict stands (nothing used), no crash */
        assert_true(broken_from < 0 || k < broken_from ? rep.ran : !rep.ran && !rep.used);
        pl = rep.out.pl_pos_mm;
        *sigma_mm = sqrtf(rep.out.cov_ros[0][0]);
    }
    return pl;
}

static void test_motion_bound_from_table(void **state)
{
    (void)state;
    float sig_default = 0.0f, sig_tight = 0.0f, sig_broken = 0.0f;
    const float pl_default = run_with_accel(MFNS_CALTABLE_DEFAULT_MOTION_ACCEL_BOUND_MM_S2, -1, &sig_default);
    const float pl_tight = run_with_accel(1.0f, -1, &sig_tight);
    print_message("motion bound 100 -> 1 mm/s^2: sigma x %.3f -> %.3f mm, PL %.2f -> %.2f mm\n", sig_default,
                  sig_tight, pl_default, pl_tight);
    assert_true(sig_tight < 0.9f * sig_default);
    assert_true(pl_tight < pl_default);
    (void)run_with_accel(MFNS_CALTABLE_DEFAULT_MOTION_ACCEL_BOUND_MM_S2, 2, &sig_broken);
}

/* The motion monitor against the snapshot (nav_filter_cycle.h), alone: a
 * certified snapshot fix (FIX, cameras bounded) that stands 3 mm off the
 * filter along y while the frames agree with the filter (the snapshot is what
 * a robot that jumped would give, sigma 0.5 mm) is beyond the separation's
 * threshold (K 4.9 x at most 0.5 mm): one cycle is no verdict, the second is
 * MOTION_EXCEEDED with the bank restarted from the snapshot, reported once
 * for the episode. The same offset on a snapshot fix that bounds beacon
 * faults only (CAMERA_UNMONITORED) is no reference: nothing happens. */
static int run_offset_snapshots(bool cameras_bounded, int offset_from, bool *restarted_at_second)
{
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 8);
    pt_dpose_t truth;
    setup(&rng, &truth);
    static mfns_navf_t nf;
    mfns_navf_enable(&nf, 54000);
    int reports = 0;
    *restarted_at_second = false;
    for (int k = 0; k < offset_from + 4; k++) {
        mfns_obs_frame_t frame;
        mfns_pose_solution_t sol;
        mfns_integrity_result_t integ;
        snapshot(&truth, &rng, &frame, &sol, &integ);
        if (cameras_bounded) {
            sol.status = MFNS_POSE_OK;
            sol.reason = MFNS_POSE_R_NONE;
        }
        if (k >= offset_from && k < offset_from + 2) {
            /* the snapshot 3 mm off along world y; the frames as before */
            const mfns_v3_t r = mfns_pose_position_w(&sol.pose);
            sol.pose = mfns_pose_from_position(sol.pose.C_w_b, mfns_v3(r.x, r.y + 3.0f, r.z));
            sol.r_wb_w = mfns_pose_position_w(&sol.pose);
        }
        mfns_navf_report_t rep;
        mfns_navf_step(&nf, &table, &table.integrity, &frame, 0.1f, &sol, &integ, &rep);
        if (k < offset_from) {
            assert_false(rep.motion_exceeded);
            assert_true(rep.motion_sep < 1.0f);
        }
        if (k == offset_from) {
            assert_false(rep.motion_exceeded); /* one cycle: no verdict yet */
            assert_false(rep.started);
            if (cameras_bounded) {
                assert_true(rep.motion_sep > 1.0f);
            }
        }
        if (k == offset_from + 1) {
            *restarted_at_second =
                rep.motion_exceeded && rep.motion_by_snapshot && rep.started && rep.motion_sep > 1.0f;
        }
        reports += rep.motion_exceeded ? 1 : 0;
    }
    return reports;
}

static void test_motion_monitor_against_snapshot(void **state)
{
    (void)state;
    bool restarted = false;
    assert_int_equal(run_offset_snapshots(true, 15, &restarted), 1);
    assert_true(restarted);
    assert_int_equal(run_offset_snapshots(false, 15, &restarted), 0);
    assert_false(restarted);
}

/* Capture times (mfns_navf_set_frame_times): each camera's frame enters at
 * its own stamp, cameras in time order whatever their index, the cycle is
 * evaluated at the latest stamp, a start takes the earliest; a frame stamped
 * before the bank's state (a stale stamp) is not fed and is counted. */
static void test_capture_times(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 3);
    pt_dpose_t truth;
    setup(&rng, &truth);
    static mfns_navf_t nf;
    mfns_navf_enable(&nf, 54000);
    const int64_t base = 5000000; /* a capture clock that does not start at 0 */
    int used = 0;
    for (int k = 0; k < 20; k++) {
        mfns_obs_frame_t frame;
        mfns_pose_solution_t sol;
        mfns_integrity_result_t integ;
        snapshot(&truth, &rng, &frame, &sol, &integ);
        /* camera 2 first, then 0, then 1 (7 ms apart); at k = 12 camera 1's
         * frame carries last cycle's stamp */
        int64_t t[MFNS_NUM_CAMERAS] = {base + k * 54000 + 7000, base + k * 54000 + 14000, base + k * 54000};
        if (k == 12) {
            t[1] = base + 11 * 54000 + 14000 - 54000;
        }
        mfns_navf_set_frame_times(&nf, t);
        mfns_navf_report_t rep;
        mfns_navf_step(&nf, &table, &table.integrity, &frame, 0.1f, &sol, &integ, &rep);
        if (k == 0) {
            /* started at the earliest frame of the fix, then its frames
             * taken in time order: the bank ends at the latest */
            assert_true(rep.started);
            assert_int_equal(nf.bank.full.t_us, base + 14000);
            assert_int_equal(rep.t_us, base + 14000); /* the instant its output is for */
            continue;
        }
        assert_true(rep.ran);
        assert_false(rep.out.restart);
        assert_int_equal(nf.bank.full.t_us, k == 12 ? base + k * 54000 + 7000 : base + k * 54000 + 14000);
        /* the report says the instant of the bank's output: the latest frame
         * fed, not the cycle's earliest (the fix's stamp, nav_loop.c) */
        assert_int_equal(rep.t_us, nf.bank.full.t_us);
        used += rep.used ? 1 : 0;
    }
    assert_int_equal(nf.stale_frames, 1);
    assert_true(used >= 10);
}

/* An exclusion ends the bank (nav_filter_cycle.h): the cycle that excludes
 * reports the subject in the integrity result (the flight program's
 * BEACON_EXCLUDED / CAMERA_EXCLUDED events), carries the snapshot's verdict,
 * restarts from the snapshot fix with the subject still held out; a usable
 * fix after the fault's onset is within its PL. */
static void test_exclusion_restarts_with_subject_held(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 4);
    pt_dpose_t truth;
    setup(&rng, &truth);
    static mfns_navf_t nf;
    mfns_navf_enable(&nf, 54000);
    int exclusions = 0, first_beacon_excl = -1, used_after = 0, wrong_named = 0;
    int16_t faulty = -1;
    for (int k = 0; k < CYCLES; k++) {
        mfns_obs_frame_t frame;
        mfns_pose_solution_t sol;
        mfns_integrity_result_t integ;
        snapshot(&truth, &rng, &frame, &sol, &integ);
        integ.excluded_beacon = -1;
        integ.excluded_camera = -1;
        if (k >= 15) {
            /* camera 0's first observation: a beacon 4 px off from cycle 15 on */
            frame.obs[0][0].u += 4.0f;
            faulty = sol.assoc.beacon[0][0];
        }
        const mfns_pose_solution_t snap = sol;
        mfns_navf_report_t rep;
        mfns_navf_step(&nf, &table, &table.integrity, &frame, 0.1f, &sol, &integ, &rep);
        if (rep.ran && rep.out.detected_kind != (uint8_t)MFNS_BANK_HYP_NONE) {
            exclusions++;
            const int16_t id = rep.out.detected_id;
            /* the result the events come from names the bank's subject.
             * Which subject the bank names is test_filter_bank's; here a
             * 4 px fault that passes its own gate once pulls the filter,
             * and the bank has named camera 0 and a healthy beacon of it
             * before the faulty one (a known miss of the attribution,
             * docs/pose.md): only the restart keeps those from flying on */
            if (rep.out.detected_kind == (uint8_t)MFNS_BANK_HYP_BEACON) {
                assert_true(integ.new_beacon_exclusion);
                assert_int_equal(integ.excluded_beacon, id);
                first_beacon_excl = id == faulty && first_beacon_excl < 0 ? k : first_beacon_excl;
                wrong_named += id != faulty ? 1 : 0;
            } else {
                assert_int_equal(rep.out.detected_kind, MFNS_BANK_HYP_CAMERA);
                assert_true(integ.new_camera_exclusion);
                assert_int_equal(integ.excluded_camera, id);
                wrong_named++;
            }
            /* restarted from this cycle's snapshot fix with the diffuse
             * prior, its frames taken (the subject's only tested): a usable
             * output then is the new bank's own, within its PL */
            assert_true(rep.started);
            if (!rep.used) {
                assert_memory_equal(&sol.pose, &snap.pose, sizeof sol.pose);
                assert_int_equal(sol.status, MFNS_POSE_NO_FIX); /* camera faults unbounded in it */
            } else {
                assert_within_pl(&truth, &sol, &integ);
            }
            assert_true(rep.out.detected_kind == (uint8_t)MFNS_BANK_HYP_BEACON
                            ? mfns_bank_beacon_excluded(&nf.bank, id)
                            : mfns_bank_camera_excluded(&nf.bank, id));
            continue;
        }
        if (k >= 15 && rep.used) {
            used_after++;
            assert_within_pl(&truth, &sol, &integ);
        }
    }
    print_message("%d exclusions (%d of another subject), the faulty beacon's at cycle %d (fault from 15), %d "
                  "usable cycles after the onset, each within its PL\n",
                  exclusions, wrong_named, first_beacon_excl, used_after);
    assert_true(exclusions >= 1); /* the fault was detected */
    assert_true(used_after >= 5);
}

/* The filter's own association (nav_filter_cycle.c own_associate): once the
 * bank runs, a cycle whose solver associated nothing (a frame the snapshot
 * cannot solve: TRACK_LOST) still feeds it, each observation given the one
 * beacon predicted within the gate. A second spot beside a beacon's (both
 * inside its gate) is ambiguous: neither is used; a spot far from every
 * prediction is not associated. */
static void test_own_association(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 5);
    pt_dpose_t truth;
    setup(&rng, &truth);
    table.solver.track_gate_px = 20.0f;
    static mfns_navf_t nf;
    mfns_navf_enable(&nf, 54000);
    int used_lost = 0;
    for (int k = 0; k < CYCLES; k++) {
        mfns_obs_frame_t frame;
        mfns_pose_solution_t sol;
        mfns_integrity_result_t integ;
        snapshot(&truth, &rng, &frame, &sol, &integ);
        const mfns_pose_assoc_t truth_assoc = sol.assoc;
        if (k < 12) {
            mfns_navf_report_t rep;
            mfns_navf_step(&nf, &table, &table.integrity, &frame, 0.1f, &sol, &integ, &rep);
            assert_int_equal(nf.own_assoc, 0U); /* the solver's associations: nothing left to add */
            continue;
        }
        /* the snapshot lost: no fix, no association */
        mfns_pose_solution_clear(&sol, MFNS_POSE_R_TRACK_LOST);
        memset(&integ, 0, sizeof integ);
        uint16_t n_extra = 0;
        if (k == 20) {
            /* camera 1: a spot 1.5 px beside its first beacon's (ambiguous) */
            const uint16_t n1 = frame.count[1];
            frame.obs[1][n1] = frame.obs[1][0];
            frame.obs[1][n1].u += 1.5f;
            frame.count[1] = (uint16_t)(n1 + 1U);
            /* camera 2: a spot far from every beacon */
            const uint16_t n2 = frame.count[2];
            frame.obs[2][n2] = frame.obs[2][0];
            frame.obs[2][n2].u += 300.0f;
            frame.count[2] = (uint16_t)(n2 + 1U);
            n_extra = 2;
        }
        uint32_t n_obs = 0;
        for (int c = 0; c < 3; c++) {
            n_obs += frame.count[c];
        }
        const uint32_t before = nf.own_assoc;
        mfns_navf_report_t rep;
        mfns_navf_step(&nf, &table, &table.integrity, &frame, 0.1f, &sol, &integ, &rep);
        assert_true(rep.ran);
        assert_false(rep.started);
        const uint32_t added = nf.own_assoc - before;
        if (k == 20) {
            /* every spot but the ambiguous pair and the far one */
            assert_int_equal(added, n_obs - n_extra - 1U);
        } else {
            assert_int_equal(added, n_obs); /* all of them, as the solver would have */
        }
        (void)truth_assoc;
        if (rep.used) {
            used_lost++;
            assert_within_pl(&truth, &sol, &integ);
        }
    }
    print_message("own association: %u observations associated by the bank, usable in %d of %d cycles the "
                  "snapshot lost\n",
                  nf.own_assoc, used_lost, CYCLES - 12);
    assert_true(used_lost >= CYCLES - 12 - 2);
}

/* The start (nav_filter_cycle.c start): from a usable fix, one whose tests
 * passed with a PL beyond the alert limit (NO_FIX PL_EXCEEDS_AL), whatever
 * that PL, or one whose cameras' timing was not tested yet (LAG_UNTESTED);
 * never from one whose tests failed, that is UNMONITORED or MINIMAL. The prior claims nothing of the fix (at least
 * MFNS_BANK_START_SIGMA_MM / _RAD on every axis), and the start cycle's own
 * frames are taken at once. */
static void test_start(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 6);
    pt_dpose_t truth;
    setup(&rng, &truth);
    static mfns_navf_t nf;
#define START_CASES 7
    const float pls[START_CASES] = {40.0f, 2000.0f, 40.0f, 40.0f, 19.0f, 12.0f, 12.0f};
    const mfns_pose_status_t status[START_CASES] = {MFNS_POSE_NO_FIX, MFNS_POSE_NO_FIX, MFNS_POSE_NO_FIX,
                                                    MFNS_POSE_NO_FIX, MFNS_POSE_OK,     MFNS_POSE_NO_FIX,
                                                    MFNS_POSE_NO_FIX};
    const mfns_pose_reason_t why[START_CASES] = {MFNS_POSE_R_PL_EXCEEDS_AL, MFNS_POSE_R_PL_EXCEEDS_AL,
                                                 MFNS_POSE_R_PL_EXCEEDS_AL, MFNS_POSE_R_UNMONITORED,
                                                 MFNS_POSE_R_NONE,          MFNS_POSE_R_LAG_UNTESTED,
                                                 MFNS_POSE_R_MINIMAL};
    const bool passed[START_CASES] = {true, true, false, true, true, true, true};
    const bool starts[START_CASES] = {true, true, false, false, true, true, false};
    for (int c = 0; c < START_CASES; c++) {
        mfns_navf_enable(&nf, 54000);
        mfns_obs_frame_t frame;
        mfns_pose_solution_t sol;
        mfns_integrity_result_t integ;
        snapshot(&truth, &rng, &frame, &sol, &integ);
        sol.status = status[c];
        sol.reason = why[c];
        integ.evaluated = true;
        integ.tests_passed = passed[c];
        integ.pl_pos_mm = pls[c];
        integ.pl_att_deg = 1.5f;
        uint32_t n_assoc = 0;
        for (int cam = 0; cam < MFNS_NUM_CAMERAS; cam++) {
            for (int i = 0; i < frame.count[cam]; i++) {
                n_assoc += sol.assoc.beacon[cam][i] >= 0 ? 1U : 0U;
            }
        }
        mfns_navf_report_t rep;
        mfns_navf_step(&nf, &table, &table.integrity, &frame, 0.1f, &sol, &integ, &rep);
        assert_int_equal(rep.started, starts[c]);
        if (!starts[c]) {
            assert_false(rep.ran);
            continue;
        }
        /* the start cycle's frames were taken: one update per beacon seen */
        assert_true(rep.ran);
        assert_true(n_assoc >= 8U);
        assert_int_equal(nf.bank.full.updates, n_assoc);
        /* the prior claimed nothing: after one frame the position is the
         * frame's, far inside the diffuse 100 mm, and the fix is still the
         * filter's own (its PL), not the snapshot's */
        assert_true(sqrtf(nf.bank.full.P[3][3]) < 0.1f * MFNS_BANK_START_SIGMA_MM);
        assert_true(rep.out.pl_pos_mm > 0.0f);
    }
    /* the diffuse prior: a bank started from a fix whose sigma is 0.5 mm
     * holds 100 mm before any observation */
    mfns_filter_bank_t bank;
    mfns_obs_frame_t frame;
    mfns_pose_solution_t sol;
    mfns_integrity_result_t integ;
    snapshot(&truth, &rng, &frame, &sol, &integ);
    mfns_navf_enable(&nf, 54000);
    memset(&frame.count, 0, sizeof frame.count); /* a fix whose frames the bank does not get */
    mfns_navf_report_t rep;
    mfns_navf_step(&nf, &table, &table.integrity, &frame, 0.1f, &sol, &integ, &rep);
    assert_true(rep.started);
    bank = nf.bank;
    assert_true(bank.full.P[3][3] >= MFNS_BANK_START_SIGMA_MM * MFNS_BANK_START_SIGMA_MM * 0.99f);
    assert_true(bank.full.P[0][0] >= MFNS_BANK_START_SIGMA_RAD * MFNS_BANK_START_SIGMA_RAD * 0.99f);
    assert_false(rep.used);
}

/* Where the bank cannot stand in for the snapshot (here: one camera in view,
 * so no camera hypothesis can be bounded), a snapshot fix that bounds no
 * camera fault is refused, whatever reason it carries: CAMERA_UNMONITORED, or
 * EXCLUDED with the result's camera_unmonitored flag (a fix that held
 * something out and certified the rest against beacon faults only). A fix
 * that bounds camera faults stands. */
static void test_snapshot_without_camera_bound_refused(void **state)
{
    (void)state;
    static const struct {
        mfns_pose_reason_t reason;
        bool flag;
        bool refused;
    } cases[] = {
        {MFNS_POSE_R_CAMERA_UNMONITORED, false, true},
        {MFNS_POSE_R_CAMERA_UNMONITORED, true, true},
        {MFNS_POSE_R_EXCLUDED, true, true},
        {MFNS_POSE_R_EXCLUDED, false, false},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        mfns_rng_t rng;
        mfns_rng_seed(&rng, 7);
        pt_dpose_t truth;
        setup(&rng, &truth);
        static mfns_navf_t nf;
        mfns_navf_enable(&nf, 54000);
        mfns_obs_frame_t frame;
        mfns_pose_solution_t sol;
        mfns_integrity_result_t integ;
        snapshot(&truth, &rng, &frame, &sol, &integ);
        for (int c = 1; c < MFNS_NUM_CAMERAS; c++) { /* camera 0 alone */
            frame.count[c] = 0;
            for (int j = 0; j < MFNS_MAX_OBS_PER_CAMERA; j++) {
                sol.assoc.beacon[c][j] = -1;
            }
        }
        sol.reason = cases[i].reason;
        integ.camera_unmonitored = cases[i].flag;
        mfns_navf_report_t rep;
        mfns_navf_step(&nf, &table, &table.integrity, &frame, 0.1f, &sol, &integ, &rep);
        assert_false(rep.used); /* the bank cannot bound camera 0 */
        if (cases[i].refused) {
            assert_int_equal(sol.status, MFNS_POSE_NO_FIX);
            assert_int_equal(sol.reason, MFNS_POSE_R_UNMONITORED);
        } else {
            assert_int_equal(sol.status, MFNS_POSE_DEGRADED);
            assert_int_equal(sol.reason, MFNS_POSE_R_EXCLUDED);
        }
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_off_changes_nothing),
        cmocka_unit_test(test_on_starts_and_takes_over),
        cmocka_unit_test(test_timing_doubt),
        cmocka_unit_test(test_suspect_frame_refuses_its_cycle),
        cmocka_unit_test(test_motion_bound_from_table),
        cmocka_unit_test(test_motion_monitor_against_snapshot),
        cmocka_unit_test(test_capture_times),
        cmocka_unit_test(test_exclusion_restarts_with_subject_held),
        cmocka_unit_test(test_own_association),
        cmocka_unit_test(test_start),
        cmocka_unit_test(test_snapshot_without_camera_bound_refused),
    };
    return cmocka_run_group_tests_name("nav_filter_cycle", tests, NULL, NULL);
}
