/* acquire_complete.c -- the completion of a 4-blob frame (acquire.h, step 4):
 * one anchor enumerated exhaustively, every minimal pose checked soundly
 * against every fourth beacon (acquire_internal.h). */
#include <math.h>
#include <string.h>

#include "firmware/nav/acquire/acquire_internal.h"
#include "math/spd.h"

/* The same test on a minimal pose, in sigmas of its propagated position
 * (sqrt of the chi-square(1) 1e-6 quantile is 4.9). */
#define MINIMAL_WS_SIGMA 6.0f

/* The completion's check must not lose a right rival to its minimal pose's
 * noise: the 4th blob is matched against every beacon with the gate of the
 * minimal pose's own propagated uncertainty, r^T (J P J^T + s^2 I)^-1 r below
 * the chi-square(2) quantile at 1e-6, with P the covariance of the pose from
 * the three anchor blobs (first order). A near-singular triple gives a huge
 * gate (every beacon is tried): slower, never unsound. */
#define SOUND_GATE_CHI2 27.63f

/* The observation's covariance R (px^2, mfns_pose_obs_cov: the one the ML
 * solve weights with) of measurement m at pose. */
static bool obs_cov(const mfns_acq_t *q, const mfns_pose_meas_t *m, const mfns_pose_t *pose, float r[3])
{
    return mfns_pose_obs_cov(&q->rig->cam[m->cam], pose, m->p_w, m->cov_px2, m->sigma_mm, q->cfg->sigma_px, r);
}

static void fill_meas(const mfns_acq_t *q, int blob, int beacon, mfns_pose_meas_t *m)
{
    const mfns_acq_blob_t *bl = &q->blobs[blob];
    mfns_pose_meas_set(q->map, q->frame, bl->cam, bl->idx, beacon, m);
}

/* Can the minimal pose be a noisy copy of a physical one? Its body origin
 * p = -C_w_b^T r_bw_b moves by dp = -C_w_b^T (dt + [r_bw_b]x dtheta) under the
 * increment (dtheta, dt), so axis m has the variance g_m^T P g_m with
 * g_m = (c_m x r_bw_b, c_m), c_m the m-th column of C_w_b and P the minimal
 * pose's covariance. A pose whose origin lies outside the workspace (with the
 * tolerance of mfns_acq_physical()) by more than MINIMAL_WS_SIGMA of that sigma on
 * some axis is not the truth's minimal pose (first order, like the gate of
 * the fourth blob), and every candidate grown from it would fail mfns_acq_physical(). */
static bool minimal_in_workspace(const mfns_acq_t *q, const mfns_pose_t *pose,
                                 const float cov[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N])
{
    const mfns_v3_t p = mfns_pose_position_w(pose);
    const float pw[3] = {p.x, p.y, p.z};
    const float lo[3] = {q->idx->ws_min_w.x, q->idx->ws_min_w.y, q->idx->ws_min_w.z};
    const float hi[3] = {q->idx->ws_max_w.x, q->idx->ws_max_w.y, q->idx->ws_max_w.z};
    for (int m = 0; m < 3; m++) {
        const float out = pw[m] < lo[m] ? lo[m] - pw[m] : (pw[m] > hi[m] ? pw[m] - hi[m] : 0.0f);
        if (out <= MFNS_WS_TOL_MM) {
            continue;
        }
        const mfns_v3_t cm = {pose->C_w_b.m[0][m], pose->C_w_b.m[1][m], pose->C_w_b.m[2][m]};
        const mfns_v3_t cr = mfns_v3_cross(cm, pose->r_bw_b);
        const float g[6] = {cr.x, cr.y, cr.z, cm.x, cm.y, cm.z};
        float var = 0.0f;
        for (int i = 0; i < 6; i++) {
            for (int j = 0; j < 6; j++) {
                var += g[i] * cov[i][j] * g[j];
            }
        }
        const float tol = MFNS_WS_TOL_MM + MINIMAL_WS_SIGMA * sqrtf(var > 0.0f ? var : 0.0f);
        if (out > tol) {
            return false;
        }
    }
    return true;
}

/* Sound verification of one minimal pose in the completion: the anchor's
 * three correspondences and, for the remaining blob, every beacon within the
 * propagated gate are refined together and scored like any candidate. */
void mfns_acq_sound_verify(mfns_acq_t *q, const mfns_pose_t *pose, const mfns_acq_anchor_t *an, const int abc[3])
{
    /* Charges here are measured, like every unit (acquire.h): with a minimal
     * pose's covariance, the map's pair look-ups and a residual per 4 beacons
     * left, a completion costs 0.7-1.1 us per unit on the benchmark host, as
     * the bands do (it was 0.3 us with a unit per residual, docs/pose.md). */
    q->progress.units += 1u + (uint32_t)q->map->count / 64u; /* the covariance of the three */
    uint32_t n_res = 0u;
    const int tri[3] = {an->i, an->j, an->k};
    /* the anchor's three and one fourth beacon, then the extension's scratch */
    mfns_pose_meas_t m[MFNS_ACQ_MIN_BLOBS + MFNS_POSE_MAX_MEAS];
    float h[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N] = {{0.0f}};
    for (int t = 0; t < 3; t++) {
        fill_meas(q, tri[t], abc[t], &m[t]);
        float r[2], jac[2][6], rc[3];
        if (!obs_cov(q, &m[t], pose, rc) || !mfns_pose_whitener(rc, m[t].w) ||
            !mfns_pose_wresidual(q->rig, &m[t], pose, r, jac)) {
            return;
        }
        for (int i = 0; i < 6; i++) { /* J^T R^-1 J from the whitened Jacobian */
            for (int j = 0; j <= i; j++) {
                h[i][j] += jac[0][i] * jac[0][j] + jac[1][i] * jac[1][j];
            }
        }
    }
    mfns_chol_t f;
    float cov[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N];
    const bool have_cov = mfns_chol_factor(h, 6, 1e-12f, &f) == MFNS_SPD_OK;
    if (have_cov) {
        mfns_chol_inverse(&f, cov);
        if (!minimal_in_workspace(q, pose, cov)) {
            return; /* no pose near this one is physical: no fourth beacon to try */
        }
    }
    int l = -1; /* the remaining blob (of five, the one the hypothesis does not leave out) */
    for (int b = 0; b < q->nb && l < 0; b++) {
        l = (b != tri[0] && b != tri[1] && b != tri[2] && b != q->skip) ? b : -1;
    }
    if (l < 0) {
        return;
    }
    /* the fourth beacon must admit its angles to the three, like any pair
     * of the enumeration (the same tables the hypotheses were pruned with) */
    float tl[3], pl[3];
    for (int t = 0; t < 3; t++) {
        tl[t] = mfns_acq_ray_angle(&q->blobs[tri[t]], &q->blobs[l]);
        pl[t] = mfns_acq_parallax_pad(&q->blobs[tri[t]], &q->blobs[l]);
    }
    for (int d = 0; d < q->map->count && !mfns_acq_stop(q); d++) {
        if (d == abc[0] || d == abc[1] || d == abc[2]) {
            continue;
        }
        bool admitted = true;
        for (int t = 0; t < 3 && admitted; t++) {
            admitted = mfns_bidx_pair_admits(q->idx, (uint32_t)abc[t], (uint32_t)d, tl[t], pl[t]);
        }
        if (!admitted) {
            continue;
        }
        fill_meas(q, l, d, &m[3]);
        float r[2], jac[2][6];
        n_res++; /* a residual with its Jacobian and the gate: ~0.3 us */
        if ((n_res & 3u) == 0u) {
            q->progress.units++;
        }
        if (!mfns_pose_residual(q->rig, &m[3], pose, r, jac)) {
            continue;
        }
        if (have_cov) {
            /* S = J P J^T + s^2 I (2 x 2) */
            float jp[2][6];
            for (int a = 0; a < 2; a++) {
                for (int j = 0; j < 6; j++) {
                    jp[a][j] = 0.0f;
                    for (int k = 0; k < 6; k++) {
                        jp[a][j] += jac[a][k] * cov[k][j];
                    }
                }
            }
            float rc[3];
            if (!obs_cov(q, &m[3], pose, rc)) {
                continue;
            }
            float s00 = rc[0], s01 = rc[1], s11 = rc[2];
            for (int k = 0; k < 6; k++) {
                s00 += jp[0][k] * jac[0][k];
                s01 += jp[0][k] * jac[1][k];
                s11 += jp[1][k] * jac[1][k];
            }
            const float det = s00 * s11 - s01 * s01;
            if (det > 0.0f) {
                const float md = (s11 * r[0] * r[0] - 2.0f * s01 * r[0] * r[1] + s00 * r[1] * r[1]) / det;
                if (md > SOUND_GATE_CHI2) {
                    continue;
                }
            }
        }
        /* refine the four correspondences and score like any candidate */
        q->progress.units += MFNS_ACQ_VERIFY_UNITS;
        q->progress.verified++;
        mfns_acq_cand_t cd;
        memset(&cd, 0, sizeof cd);
        for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
            for (int i = 0; i < MFNS_MAX_OBS_PER_CAMERA; i++) {
                cd.sol.assoc.beacon[c][i] = MFNS_POSE_NO_BEACON;
            }
        }
        for (int t = 0; t < 4; t++) {
            cd.sol.assoc.beacon[m[t].cam][m[t].idx] = m[t].beacon;
            m[t].active = 1;
        }
        if (!mfns_acq_solve_checked(q, m, 4, pose, MFNS_ACQ_MIN_BLOBS, &cd.sol)) {
            continue;
        }
        if (q->skip >= 0) {
            /* the blob left out may be a beacon after all: a pose explaining
             * all five is then one identification with the bands' */
            mfns_acq_extend(q, &cd, &m[MFNS_ACQ_MIN_BLOBS]);
        }
        cd.inliers = (uint8_t)cd.sol.beacons_used;
        const int miss = mfns_acq_count_missing(q, &cd.sol);
        cd.missing = (uint8_t)(miss > 255 ? 255 : miss);
        mfns_acq_add_candidate(q, &cd);
    }
}

/* The anchor the completion exhausts: one whose three blobs share an image
 * (its pair look-ups prune), else the first; -1 none. */
static int completion_anchor(const mfns_acq_t *q)
{
    int an = -1;
    for (int a = 0; a < q->na; a++) {
        if (q->anchor[a].k >= 0 && (an < 0 || (q->anchor[an].cross && !q->anchor[a].cross))) {
            an = a;
        }
    }
    return an;
}

/* The anchor of the hypothesis that leaves blob skip out: of the other four
 * blobs, the triple with the most pairs in one image (their look-ups prune
 * hardest: no parallax pad), the first such; three of one image on a line
 * last. */
static void loo_anchor(const mfns_acq_t *q, int skip, mfns_acq_anchor_t *an)
{
    int rest[MFNS_ACQ_MIN_BLOBS], n = 0;
    for (int b = 0; b < q->nb && n < (int)MFNS_ACQ_MIN_BLOBS; b++) {
        if (b != skip) {
            rest[n++] = b;
        }
    }
    int best = 0, best_same = -2; /* every triple scores at least -1: one is chosen */
    for (int out = 0; out < n; out++) { /* the triple without rest[out] */
        int t[3] = {0, 0, 0}, m = 0;
        for (int k = 0; k < n; k++) {
            if (k != out && m < 3) {
                t[m++] = rest[k];
            }
        }
        int same = (q->blobs[t[0]].cam == q->blobs[t[1]].cam) + (q->blobs[t[0]].cam == q->blobs[t[2]].cam) +
                   (q->blobs[t[1]].cam == q->blobs[t[2]].cam);
        if (same == 3 && mfns_acq_flat_triangle(q, t[0], t[1], t[2])) {
            same = -1; /* on one line in one image: its gP3P may miss the truth */
        }
        if (same > best_same) {
            best_same = same;
            best = out;
        }
    }
    int m = 0;
    int16_t t[3] = {-1, -1, -1};
    for (int k = 0; k < n; k++) {
        if (k != best && m < 3) {
            t[m++] = (int16_t)rest[k];
        }
    }
    an->i = t[0];
    an->j = t[1];
    an->k = t[2];
    an->v[0] = -1;
    an->v[1] = -1;
    an->cross = q->blobs[t[2]].cam != q->blobs[t[0]].cam;
}

bool mfns_acq_leave_one_out(const mfns_acq_t *q)
{
    return q->nb == MFNS_ACQ_LOO_BLOBS && q->idx->max_unexplained >= 1u;
}

/* After the bands of a 4-blob frame without a certified pose (the sound
 * check covers one blob beyond the anchor's three), the completion runs,
 * whether or not the bands found an explanation of every blob: it finds
 * every such explanation itself, so a truth the neighbour lists cannot
 * reach is found there too (measured: 6 of 300 module four-blob views
 * searched without a budget had no full explanation after the bands). */
bool mfns_acq_completion_applies(const mfns_acq_t *q)
{
    if (q->analysis || q->certified >= 0) {
        return false;
    }
    return (completion_anchor(q) >= 0 && q->nb == MFNS_ACQ_MIN_BLOBS) || mfns_acq_leave_one_out(q);
}

/* The exhaustive enumeration of the completion, from the cursor: one anchor
 * of a 4-blob frame, or, of a 5-blob frame, one per hypothesis of a blob
 * left out (the cursor's skip, then the next). */
static void exhaust_all(mfns_acq_t *q)
{
    if (!mfns_acq_leave_one_out(q)) {
        mfns_acq_exhaust(q, &q->anchor[completion_anchor(q)]);
        return;
    }
    while ((int)q->cur.skip < q->nb && !mfns_acq_stop(q)) {
        mfns_acq_anchor_t an;
        loo_anchor(q, q->cur.skip, &an);
        q->skip = q->cur.skip;
        mfns_acq_exhaust(q, &an);
        if (!mfns_acq_stop(q)) {
            q->cur.skip++; /* this hypothesis is done; the loops start afresh */
        }
    }
    q->skip = -1;
}

/* The completion, from the cursor: exhaust one anchor, collecting every
 * candidate (never stopping on the first); then a best candidate that
 * explains every blob is unique if no other candidate does. */
void mfns_acq_run_completion(mfns_acq_t *q)
{
    q->analysis = true; /* collect, never stop on the first */
    q->exhaustive = true;
    q->to_complete = false;
    q->paused = false;
    exhaust_all(q);
    q->exhaustive = false;
    q->analysis = false;
    if (q->certified >= 0) { /* five blobs: one explained all five within the certificate */
        q->progress.completed = true;
        q->cur.phase = MFNS_ACQ_PHASE_DONE;
        return;
    }
    if (q->progress.budget_out) {
        return; /* the cursor holds the place */
    }
    /* unique: no other pose explains every blob within the allowances (a
     * rival with more missing beacons could be the truth with a beacon
     * hidden, so it is not ruled out by being less likely) */
    int keep;
    const int full = mfns_acq_identifications(q, &keep);
    q->progress.rivals = (uint8_t)(full > 0 ? full - 1 : 0);
    if (full == 1) {
        q->certified = keep;
        q->progress.completed = true;
    }
    q->cur.phase = MFNS_ACQ_PHASE_DONE;
}
