/* Unit tests of the blob ring (blob_ring.h) and of the catch-up of a carried
 * search (acquire_cycle.h) on the paper's rig and map: the ring returns the
 * frame of a cycle or nothing (never another's), across its wrap and the
 * uint32 wrap of its numbers; a 4-blob view whose search takes several
 * cycles is identified on a robot that moved meanwhile further than one
 * tracking gate, and the fix is verified on the current frame; a jump
 * between two stored frames beyond the gate is refused, never a wrong fix. */
#include <math.h>
#include <string.h>

#include "firmware/nav/acquire/acquire.h"
#include "firmware/nav/acquire/acquire_cycle.h"
#include "firmware/nav/acquire/blob_ring.h"
#include "tests/unit/support/pose_testlib.h"
#include "firmware/host/beacon_index_build.h"

/* Test code computes in double from the float model on purpose. */
#pragma GCC diagnostic ignored "-Wdouble-promotion"

#define POS_RANGE_MM 150.0
#define MAX_CYCLES 60

static mfns_blob_ring_t g_ring;
static mfns_beacon_index_t g_idx;
static mfns_acq_t g_acq;
static mfns_acq_cycle_t g_cyc;
static mfns_obs_frame_t g_frames[MAX_CYCLES];
static mfns_pose_assoc_t g_truth[MAX_CYCLES];
static pt_dpose_t g_path[MAX_CYCLES];

/* A frame that says which cycle it is. */
static void mark(mfns_obs_frame_t *f, uint32_t seq)
{
    memset(f, 0, sizeof *f);
    f->count[0] = 1u;
    f->obs[0][0].u = (float)(seq % 1000000u);
}

static void test_ring_wraps(void **state)
{
    (void)state;
    mfns_blob_ring_reset(&g_ring);
    mfns_obs_frame_t f;
    assert_null(mfns_blob_ring_get(&g_ring, 0u)); /* nothing yet */
    const uint32_t n = 3u * MFNS_BLOB_RING_LEN + 5u;
    for (uint32_t s = 0u; s < n; s++) {
        mark(&f, s);
        if (s == n - 3u) {
            assert_int_equal(mfns_blob_ring_skip(&g_ring), s); /* a cycle without a frame */
        } else {
            assert_int_equal(mfns_blob_ring_push(&g_ring, &f), s);
        }
    }
    assert_int_equal(mfns_blob_ring_newest(&g_ring), n - 1u);
    for (uint32_t s = 0u; s < n + 2u; s++) {
        const mfns_obs_frame_t *g = mfns_blob_ring_get(&g_ring, s);
        const bool held = s < n && n - s <= MFNS_BLOB_RING_LEN && s != n - 3u;
        if (!held) {
            assert_null(g);
            continue;
        }
        assert_non_null(g);
        assert_float_equal(g->obs[0][0].u, (float)s, 0.0f);
    }
    /* across the wrap of the numbers: never another cycle's frame */
    mfns_blob_ring_reset(&g_ring);
    g_ring.next = UINT32_MAX - 5u;
    for (uint32_t k = 0u; k < 2u * MFNS_BLOB_RING_LEN; k++) {
        const uint32_t s = g_ring.next;
        mark(&f, s);
        assert_int_equal(mfns_blob_ring_push(&g_ring, &f), s);
        for (uint32_t b = 0u; b < MFNS_BLOB_RING_LEN + 2u; b++) {
            const mfns_obs_frame_t *g = mfns_blob_ring_get(&g_ring, s - b);
            if (g != NULL) {
                assert_float_equal(g->obs[0][0].u, (float)((s - b) % 1000000u), 0.0f);
            }
        }
        assert_non_null(mfns_blob_ring_get(&g_ring, s)); /* the newest is always held */
    }
    /* bad input */
    assert_null(mfns_blob_ring_get(NULL, 0u));
    assert_int_equal(mfns_blob_ring_push(NULL, &f), 0u);
}

/* pose moved on by k steps of a constant twist: w rad about the body's own
 * axes and v mm in the world per step. */
static pt_dpose_t moved(const pt_dpose_t *p0, const double w[3], const double v[3], int k)
{
    double wk[3] = {w[0] * k, w[1] * k, w[2] * k}, r[3][3], c[3][3], pos[3];
    pt_rot_exp(wk, r);
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            c[i][j] = 0.0;
            for (int m = 0; m < 3; m++) {
                c[i][j] += r[i][m] * p0->C[m][j];
            }
        }
    }
    pt_position_w(p0, pos);
    for (int i = 0; i < 3; i++) {
        pos[i] += v[i] * k;
    }
    return pt_pose(c, pos);
}

/* A path from a 4-blob pose whose one-call search completes with need units,
 * moving by a constant twist, with at least 4 beacons in view all along.
 * jump_at >= 0: from that frame on the body is turned by jump_rad more about
 * its z axis. Returns need (0: none found). */
static uint32_t make_path(const mfns_rig_t *rig, const mfns_beacon_map_t *map, const mfns_pose_config_t *cfg,
                          mfns_rng_t *rng, double step_rad, double step_mm, int jump_at, double jump_rad)
{
    for (int t = 0; t < 4000; t++) {
        pt_dpose_t p0;
        assert_true(pt_random_visible_pose(rig, map, POS_RANGE_MM, 4, 1000000, rng, &p0) >= 4);
        if (pt_make_frame(rig, map, &p0, 0.3, rng, &g_frames[0], &g_truth[0]) != 4) {
            continue;
        }
        mfns_pose_solution_t sol;
        if (mfns_acquire(&g_acq, rig, map, &g_idx, &g_frames[0], cfg, 10000000u, &sol) == MFNS_POSE_NO_FIX ||
            !g_acq.progress.completed || g_acq.progress.units_total < 300u) {
            continue;
        }
        const uint32_t need = g_acq.progress.units_total;
        const double ax = mfns_rng_uniform(rng) - 0.5, ay = mfns_rng_uniform(rng) - 0.5, az = mfns_rng_uniform(rng) - 0.5;
        const double an = sqrt(ax * ax + ay * ay + az * az) + 1e-12;
        const double w[3] = {step_rad * ax / an, step_rad * ay / an, step_rad * az / an};
        const double v[3] = {step_mm * (mfns_rng_uniform(rng) - 0.5), step_mm * (mfns_rng_uniform(rng) - 0.5),
                             step_mm * (mfns_rng_uniform(rng) - 0.5)};
        bool ok = true;
        for (int k = 0; k < MAX_CYCLES && ok; k++) {
            g_path[k] = moved(&p0, w, v, k);
            if (jump_at >= 0 && k >= jump_at) {
                const double wz[3] = {0.0, 0.0, jump_rad};
                const double none[3] = {0.0, 0.0, 0.0};
                g_path[k] = moved(&g_path[k], wz, none, 1);
            }
            ok = pt_make_frame(rig, map, &g_path[k], 0.3, rng, &g_frames[k], &g_truth[k]) >= 4;
        }
        if (ok) {
            return need;
        }
    }
    return 0u;
}

/* A 4-blob view whose search needs several cycles, on a robot turning about
 * 0.3 deg a frame: the carried search certifies frame k, the catch-up tracks
 * it through every stored frame, and the fix is right on the current frame,
 * although one tracking step from frame k's pose to the current frame fails
 * (the robot moved beyond the gate). */
static void test_catchup_after_motion(void **state)
{
    (void)state;
    const mfns_rig_t rig = pt_paper_rig();
    const mfns_beacon_map_t map = pt_paper_map();
    mfns_bidx_params_t par;
    mfns_bidx_params_default(&par);
    const float r = (float)POS_RANGE_MM;
    assert_int_equal(mfns_bidx_build(&rig, &map, NULL, mfns_v3(-r, -r, -r), mfns_v3(r, r, r), &par, &g_idx),
                     MFNS_BIDX_OK);
    const mfns_pose_config_t cfg = pt_config(0.3);
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 2701);
    int tried = 0, beyond_gate = 0;
    for (int run = 0; run < 40 && beyond_gate < 3; run++) {
        const uint32_t need = make_path(&rig, &map, &cfg, &rng, 0.3 * MFNS_PI / 180.0, 1.0, -1, 0.0);
        assert_true(need > 0u);
        const uint32_t budget = need / 8u;
        mfns_acq_cycle_reset(&g_cyc);
        mfns_acq_cycle_report_t rep;
        mfns_pose_solution_t out;
        int k = 0;
        bool fixed = false;
        for (; k < MAX_CYCLES && !fixed; k++) {
            fixed = mfns_acq_cycle_run(&g_cyc, &rig, &map, &g_idx, &g_frames[k], &cfg, budget, &out, &rep) !=
                    MFNS_POSE_NO_FIX;
            assert_true(rep.progress.units <= budget + 8u * MFNS_ACQ_VERIFY_UNITS);
        }
        assert_true(fixed);
        k--; /* the fix's frame */
        /* only a pose verified on the current frame: right, and near the truth there */
        assert_true(pt_assoc_right(&out, &g_frames[k], &g_truth[k]));
        assert_true(out.beacons_used >= MFNS_ACQ_MIN_BLOBS);
        const pt_dpose_t est = pt_from_float(&out.pose);
        assert_true(pt_pos_err(&est, &g_path[k]) < 5.0);
        tried++;
        if (rep.source != MFNS_ACQ_SRC_CARRIED || k < 3) {
            continue;
        }
        /* the old bridge: one tracking step from the first frame's pose */
        const mfns_pose_t first = pt_to_float(&g_path[0]);
        mfns_pose_solution_t one;
        (void)mfns_pose_track(&rig, &map, &g_frames[k], &first, &cfg, &one);
        const bool one_ok = (one.status == MFNS_POSE_OK || one.status == MFNS_POSE_DEGRADED) &&
                            one.beacons_used >= MFNS_ACQ_MIN_BLOBS && pt_assoc_right(&one, &g_frames[k], &g_truth[k]);
        print_message("catch-up: fix after %d cycles of %u units (one call %u); one step from frame 0: %s\n", k + 1,
                      budget, need, one_ok ? "verifies" : "fails");
        beyond_gate += one_ok ? 0 : 1;
    }
    print_message("catch-up: %d paths, %d of them beyond one gate\n", tried, beyond_gate);
    assert_true(beyond_gate >= 1);
}

/* The body jumps 6 deg about its z axis between two stored frames (beyond the
 * 20 px gate): the carried identification is not carried over the jump. No
 * fix is wrong; a fix from the carried search only after the refusal, from a
 * search of frames after the jump. */
static void test_catchup_refuses_a_jump(void **state)
{
    (void)state;
    const mfns_rig_t rig = pt_paper_rig();
    const mfns_beacon_map_t map = pt_paper_map();
    const mfns_pose_config_t cfg = pt_config(0.3);
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 2702);
    int refused_runs = 0;
    for (int run = 0; run < 20 && refused_runs < 2; run++) {
        const uint32_t need = make_path(&rig, &map, &cfg, &rng, 0.0, 0.0, 2, 6.0 * MFNS_PI / 180.0);
        assert_true(need > 0u);
        mfns_acq_cycle_reset(&g_cyc);
        mfns_acq_cycle_report_t rep;
        mfns_pose_solution_t out;
        bool refused = false;
        for (int k = 0; k < MAX_CYCLES; k++) {
            const mfns_pose_status_t st =
                mfns_acq_cycle_run(&g_cyc, &rig, &map, &g_idx, &g_frames[k], &cfg, need / 8u, &out, &rep);
            refused = refused || rep.bridge_refused;
            if (st != MFNS_POSE_NO_FIX) {
                assert_true(pt_assoc_right(&out, &g_frames[k], &g_truth[k]));
                assert_true(k >= 2); /* never the first frames' pose carried over the jump */
                break;
            }
        }
        refused_runs += refused ? 1 : 0;
    }
    assert_true(refused_runs >= 1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ring_wraps),
        cmocka_unit_test(test_catchup_after_motion),
        cmocka_unit_test(test_catchup_refuses_a_jump),
    };
    return cmocka_run_group_tests_name("catchup", tests, NULL, NULL);
}
