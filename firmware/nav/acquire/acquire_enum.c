/* acquire_enum.c -- the acquisition's enumeration (acquire.h, step 2): the
 * bands along the neighbour lists, the exhaustive enumeration of the
 * completion, and one hypothesis each (acquire_internal.h). Loop indices are
 * the resumable cursor. */
#include <math.h>

#include "firmware/nav/acquire/acquire_internal.h"
#include "firmware/nav/pose/pose_init.h"

#define BAND_WS_TOL_MM 300.0f /* band_plausible below */

/* The shape pass (first in each rank range of the schedule, SCHED in acquire.c): a
 * same-image triple whose pair angles, as shares of their sum, differ from
 * the beacons' pair distances, as shares of theirs, by more than this on any
 * pair is left to the full pass of that range. A heuristic order, never a filter (the full passes try every
 * triple the shape pass did not): measured on 3,000 module poses, the true
 * triple of three blobs in one image passes 90 % of the time and a random
 * beacon triple 19 % (at 0.05: 73 % and 5 %; at 0.2: 99 % and 61 %). */
#define SHAPE_TOL 0.1f

/* In the bands, a minimal pose whose body origin lies more than
 * BAND_WS_TOL_MM outside the workspace, or that sees one of its three beacons
 * from behind its LED, is dropped before any check of the blobs. A heuristic
 * (the bands only order the search; a right minimal pose that
 * ill-conditioning throws that far is left to another anchor or to the
 * completion, which uses the sound test, minimal_in_workspace). Measured on
 * 1,000 module views: the median work of views of 7+ blobs fell from 550 to
 * 188 units and the right fixes rose from 811 to 829. Not charged: a few
 * dozen flops against the ~1 us of a unit, within the solve's. */
static bool band_plausible(mfns_acq_t *q, const mfns_pose_t *pose, const mfns_acq_anchor_t *an, const int abc[3])
{
    const mfns_v3_t p = mfns_pose_position_w(pose);
    const float pw[3] = {p.x, p.y, p.z};
    const float lo[3] = {q->idx->ws_min_w.x, q->idx->ws_min_w.y, q->idx->ws_min_w.z};
    const float hi[3] = {q->idx->ws_max_w.x, q->idx->ws_max_w.y, q->idx->ws_max_w.z};
    for (int m = 0; m < 3; m++) {
        if (!(pw[m] >= lo[m] - BAND_WS_TOL_MM && pw[m] <= hi[m] + BAND_WS_TOL_MM)) {
            return false;
        }
    }
    const int tri[3] = {an->i, an->j, an->k};
    for (int t = 0; t < 3; t++) {
        if (!mfns_acq_faces(q, abc[t], mfns_acq_cam_centre_w(q, pose, q->blobs[tri[t]].cam))) {
            return false;
        }
    }
    return true;
}

/* One hypothesis at loop indices (a, r1, r2) of its enumeration: they are
 * the cursor, so that a hypothesis the budget refuses is the first one the
 * next call tries. */
static void hypothesis(mfns_acq_t *q, const mfns_acq_anchor_t *an, int a, int b, int c, int r1, int r2)
{
    if (q->progress.units + 1u > q->budget) {
        q->progress.budget_out = true;
        q->cur.a = (int16_t)a;
        q->cur.r1 = (int16_t)r1;
        q->cur.r2 = (int16_t)r2;
        q->cur.resume = 1u;
        return;
    }
    q->progress.units++;
    q->progress.hypotheses++;
    const mfns_acq_blob_t *t[3] = {&q->blobs[an->i], &q->blobs[an->j], &q->blobs[an->k]};
    const mfns_v3_t *const rc[3] = {&t[0]->c, &t[1]->c, &t[2]->c};
    const mfns_v3_t *const rd[3] = {&t[0]->d, &t[1]->d, &t[2]->d};
    const mfns_v3_t *const xw[3] = {&q->map->beacon[a].p_w, &q->map->beacon[b].p_w, &q->map->beacon[c].p_w};
    const mfns_beacon_geom_t *gc = &q->idx->geom[c];
    mfns_pose_t sols[MFNS_GP3P_MAX_SOLUTIONS];
    const int ns = mfns_gp3p_at(rc, rd, xw, gc->range_min_mm, gc->range_max_mm, sols);
    const int abc[3] = {a, b, c};
    for (int s = 0; s < ns && !mfns_acq_stop(q); s++) {
        if (q->exhaustive) {
            mfns_acq_sound_verify(q, &sols[s], an, abc);
            continue;
        }
        if (!band_plausible(q, &sols[s], an, abc) || !mfns_acq_quick_check(q, &sols[s], an, abc)) {
            continue;
        }
        mfns_acq_cand_t cd;
        if (mfns_acq_full_verify(q, &sols[s], &cd)) {
            mfns_acq_add_candidate(q, &cd);
        }
    }
}

/* Where a resumed enumeration starts: the cursor's loop indices once, then
 * 0 (loops written as for (x = start(..)); the start applies only while
 * every outer index is still at the cursor's). */
typedef struct {
    int a, r1, r2;
    bool on; /* still on the cursor's path */
} resume_t;

static resume_t resume_point(mfns_acq_t *q)
{
    resume_t r = {0, 0, 0, false};
    if (q->cur.resume != 0u) {
        r.a = q->cur.a;
        r.r1 = q->cur.r1;
        r.r2 = q->cur.r2;
        r.on = true;
        q->cur.resume = 0u;
    }
    return r;
}

/* Does the triple (a, b, c) have the shape of the measured triangle t[3]
 * (angles i-j, i-k, j-k), within SHAPE_TOL (see there)? */
static bool shape_matches(const mfns_acq_t *q, const float t[3], int a, int b, int c)
{
    const mfns_beacon_t *bm = q->map->beacon;
    const float d[3] = {mfns_v3_norm(mfns_v3_sub(bm[a].p_w, bm[b].p_w)), mfns_v3_norm(mfns_v3_sub(bm[a].p_w, bm[c].p_w)),
                        mfns_v3_norm(mfns_v3_sub(bm[b].p_w, bm[c].p_w))};
    const float sd = d[0] + d[1] + d[2], st = t[0] + t[1] + t[2];
    if (!(sd > 0.0f) || !(st > 0.0f)) {
        return false;
    }
    for (int m = 0; m < 3; m++) {
        if (fabsf(t[m] / st - d[m] / sd) > SHAPE_TOL) {
            return false;
        }
    }
    return true;
}

static bool band_tries(const mfns_acq_t *q, mfns_acq_band_mode_t mode, const float tri[3], int a, int b, int c, int rb,
                       int rc)
{
    if (mode.shape_only) {
        return shape_matches(q, tri, a, b, c);
    }
    return rb >= mode.shape_done || rc >= mode.shape_done || !shape_matches(q, tri, a, b, c);
}

/* The measured angles of the anchor's pairs (i-j, i-k, j-k) and their
 * parallax pads. */
static void anchor_angles(const mfns_acq_t *q, const mfns_acq_anchor_t *an, float t[3], float pad[3])
{
    const mfns_acq_blob_t *bi = &q->blobs[an->i], *bj = &q->blobs[an->j], *bk = &q->blobs[an->k];
    t[0] = mfns_acq_ray_angle(bi, bj);
    t[1] = mfns_acq_ray_angle(bi, bk);
    t[2] = mfns_acq_ray_angle(bj, bk);
    pad[0] = mfns_acq_parallax_pad(bi, bj);
    pad[1] = mfns_acq_parallax_pad(bi, bk);
    pad[2] = mfns_acq_parallax_pad(bj, bk);
}

/* Every beacon c from c0 on that admits its angles to a and b (another
 * camera's third blob, or the exhaustive enumeration): hypotheses (a, b, c)
 * with the cursor's ranks (r1, c). */
static void any_third(mfns_acq_t *q, const mfns_acq_anchor_t *an, int a, int b, int r1, int c0, const float t[3],
                      const float pad[3])
{
    const mfns_beacon_index_t *ix = q->idx;
    for (int c = c0; c < ix->count && !mfns_acq_stop(q); c++) {
        if (c != a && c != b && mfns_bidx_pair_admits(ix, (uint32_t)a, (uint32_t)c, t[1], pad[1]) &&
            mfns_bidx_pair_admits(ix, (uint32_t)b, (uint32_t)c, t[2], pad[2])) {
            hypothesis(q, an, a, b, c, r1, c);
        }
    }
}

/* Band [w0, w1) of one anchor: hypotheses whose ranks (rb, rc) reach it. */
void mfns_acq_band(mfns_acq_t *q, const mfns_acq_anchor_t *an, int w0, int w1, mfns_acq_band_mode_t mode)
{
    const mfns_beacon_index_t *ix = q->idx;
    float tri[3], pad[3];
    anchor_angles(q, an, tri, pad);
    const float tij = tri[0], tik = tri[1], tjk = tri[2];
    resume_t rs = resume_point(q);
    for (int a = rs.a; a < ix->count && !mfns_acq_stop(q); a++) {
        const int na = ix->nbr_count[a];
        const bool on_a = rs.on && a == rs.a;
        for (int rb = on_a ? rs.r1 : 0; rb < na && rb < w1 && !mfns_acq_stop(q); rb++) {
            const bool on_b = on_a && rb == rs.r1;
            const int b = ix->nbr[a][rb];
            if (!mfns_bidx_pair_admits(ix, (uint32_t)a, (uint32_t)b, tij, 0.0f)) {
                continue;
            }
            if (an->cross) {
                if (rb >= w0) {
                    any_third(q, an, a, b, rb, on_b ? rs.r2 : 0, tri, pad);
                }
                continue;
            }
            for (int rc = on_b ? rs.r2 : 0; rc < na && rc < w1 && !mfns_acq_stop(q); rc++) {
                if (rb < w0 && rc < w0) {
                    continue; /* an earlier band's */
                }
                const int c = ix->nbr[a][rc];
                if (c != b && mfns_bidx_pair_admits(ix, (uint32_t)a, (uint32_t)c, tik, 0.0f) &&
                    mfns_bidx_pair_admits(ix, (uint32_t)b, (uint32_t)c, tjk, 0.0f) &&
                    band_tries(q, mode, tri, a, b, c, rb, rc)) {
                    hypothesis(q, an, a, b, c, rb, rc);
                }
            }
        }
    }
}

/* Every admissible ordered beacon triple for the anchor's blobs (not only
 * the neighbour bands): the completion that certifies a candidate which
 * explains every blob of a frame with too few blobs for the certificate.
 * A rival that also explains every blob explains the anchor's three, so it
 * is among these hypotheses. */
void mfns_acq_exhaust(mfns_acq_t *q, const mfns_acq_anchor_t *an)
{
    const mfns_beacon_index_t *ix = q->idx;
    float t[3], pad[3];
    anchor_angles(q, an, t, pad);
    resume_t rs = resume_point(q);
    for (int a = rs.a; a < ix->count && !mfns_acq_stop(q); a++) {
        const bool on_a = rs.on && a == rs.a;
        for (int b = on_a ? rs.r1 : 0; b < ix->count && !mfns_acq_stop(q); b++) {
            const bool on_b = on_a && b == rs.r1;
            if (mfns_bidx_pair_admits(ix, (uint32_t)a, (uint32_t)b, t[0], pad[0])) {
                any_third(q, an, a, b, b, on_b ? rs.r2 : 0, t, pad);
            }
        }
    }
}
