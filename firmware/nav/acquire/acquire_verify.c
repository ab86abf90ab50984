/* acquire_verify.c -- the acquisition's checks of a hypothesis pose
 * (acquire.h, step 3) and its list of candidates (acquire_internal.h). */
#include <math.h>
#include <string.h>

#include "firmware/nav/acquire/acquire_internal.h"

/* The verification blobs are the anchor's nearest neighbours in the image,
 * where the minimal pose's prediction error is smallest: they are checked
 * with half the minimal gate (a false hypothesis then passes ~4x less often;
 * measured, the right one still passes, docs/pose.md). */
#define QUICK_GATE_FACTOR 2.0f

/* Predicted beacons closer than this to the image border are not counted as
 * missing (a spot cut by the border may be refused by the centroider). */
#define MISSING_EDGE_PX 8.0f

/* Upper 1e-5 quantiles of chi-square with k = 1..16 degrees of freedom. */
static const float chi2_q[16] = {19.51f, 23.03f, 25.90f, 28.47f, 30.86f, 33.11f, 35.26f, 37.33f,
                                 39.34f, 41.30f, 43.21f, 45.08f, 46.91f, 48.72f, 50.49f, 52.24f};

static float chi2_quantile(int dof)
{
    if (dof <= 16) {
        return chi2_q[dof - 1];
    }
    /* Wilson-Hilferty, z = 4.265 (1e-5) */
    const float a = 2.0f / (9.0f * (float)dof);
    const float b = 1.0f - a + 4.265f * sqrtf(a);
    return (float)dof * b * b * b;
}

/* The chi-square of sol's inliers: sum of r_i^T R_i^-1 r_i, R_i the
 * observation's covariance of the ML solve (mfns_pose_obs_cov: centroid,
 * floor, and the beacon's survey error seen at its range), and the inlier
 * whose term is largest (*wc, *wi; -1 none) with that term. False when a
 * projection or a covariance fails. */
static bool chi2_terms(const mfns_acq_t *q, const mfns_pose_solution_t *sol, float *chi2, float *worst, int *wc,
                       int *wi)
{
    *chi2 = 0.0f;
    *worst = 0.0f;
    *wc = -1;
    *wi = -1;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        for (int i = 0; i < q->frame->count[c]; i++) {
            const int16_t b = sol->assoc.beacon[c][i];
            if (b == MFNS_POSE_NO_BEACON || !sol->inlier[c][i]) {
                continue;
            }
            const mfns_camera_t *cam = &q->rig->cam[c];
            const mfns_obs_t *o = &q->frame->obs[c][i];
            float uv[2], rc[3], w[3];
            if (mfns_cam_project(cam, &sol->pose, q->map->beacon[b].p_w, uv, NULL) != MFNS_PROJ_OK ||
                !mfns_pose_obs_cov(cam, &sol->pose, q->map->beacon[b].p_w, o->cov_px2, q->map->beacon[b].sigma_mm,
                                   q->cfg->sigma_px, rc) ||
                !mfns_pose_whitener(rc, w)) {
                return false;
            }
            const float du = uv[0] - o->u, dv = uv[1] - o->v;
            const float e0 = w[0] * du, e1 = w[1] * du + w[2] * dv;
            const float t = e0 * e0 + e1 * e1;
            *chi2 += t;
            if (t > *worst) {
                *worst = t;
                *wc = c;
                *wi = i;
            }
        }
    }
    return true;
}

/* The residuals of the inliers are plausible under the noise: their
 * chi-square (chi2_terms) below the quantile with 2n - 6 degrees of
 * freedom at 1e-5. A right pose fails once in 1e5; a rival correspondence
 * that fits "nearly" is rejected. */
bool mfns_acq_chi2_consistent(const mfns_acq_t *q, const mfns_pose_solution_t *sol)
{
    const int dof = 2 * (int)sol->beacons_used - 6;
    if (dof <= 0) {
        return true;
    }
    float chi2, worst;
    int wc, wi;
    return chi2_terms(q, sol, &chi2, &worst, &wc, &wi) && chi2 <= chi2_quantile(dof);
}

/* One knocked beacon (moved off its surveyed place by a few mm, inside the
 * solver's outlier gate) makes the right candidate fail the chi-square test
 * and the acquisition lose every view that holds it (tests/bench/
 * bench_moved_beacon.py, module map, one visible beacon moved 5 / 20 / 50 mm:
 * 78 / 51 / 107 of 200 views identified in one call without this, 149 / 115 /
 * 112 with it, 166 unmoved either way, 0 wrong). When the chi-square fails
 * only because of one observation -- the others alone pass at 2 (n - 1) - 6
 * degrees of freedom -- the candidate is solved once more without it, and
 * kept when that solve is consistent and physical. Its blob is then
 * unexplained and its beacon counted missing: the certificate (max_missing,
 * max_unexplained, cert_inliers[missing]) decides as for any candidate, and
 * the map analysis runs this same check, so a rival that one dropped
 * observation lets through is counted against the certificate too. A wrong
 * hypothesis fails on many observations and is not re-solved (one more
 * solve at most per candidate; its work is counted). The moved beacon is
 * then FDE's to exclude and the beacon watch's to report once tracking. */
static bool without_worst(mfns_acq_t *q, mfns_acq_cand_t *cd, mfns_pose_meas_t m[MFNS_POSE_MAX_MEAS])
{
    float chi2, worst;
    int wc, wi;
    const int dof = 2 * ((int)cd->sol.beacons_used - 1) - 6;
    if ((int)cd->sol.beacons_used - 1 < (int)MFNS_ACQ_MIN_BLOBS || dof <= 0 ||
        !chi2_terms(q, &cd->sol, &chi2, &worst, &wc, &wi) || wc < 0 || chi2 - worst > chi2_quantile(dof)) {
        return false;
    }
    q->progress.units += MFNS_ACQ_VERIFY_UNITS;
    mfns_pose_solution_t s2;
    memset(&s2, 0, sizeof s2);
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        for (int i = 0; i < MFNS_MAX_OBS_PER_CAMERA; i++) {
            const bool keep = i < q->frame->count[c] && cd->sol.inlier[c][i] != 0U && !(c == wc && i == wi);
            s2.assoc.beacon[c][i] = keep ? cd->sol.assoc.beacon[c][i] : MFNS_POSE_NO_BEACON;
        }
    }
    const int n = mfns_pose_gather(q->map, q->frame, &s2.assoc, m);
    if (!mfns_acq_solve_checked(q, m, n, &cd->sol.pose, MFNS_ACQ_MIN_BLOBS, &s2)) {
        return false;
    }
    cd->sol = s2;
    return true;
}

bool mfns_acq_solve_checked(mfns_acq_t *q, mfns_pose_meas_t *m, int n, const mfns_pose_t *pose, uint32_t min_used,
                            mfns_pose_solution_t *sol)
{
    return n >= 0 && mfns_pose_refine_meas(q->rig, m, n, pose, q->cfg, sol) != MFNS_POSE_NO_FIX &&
           sol->beacons_used >= min_used && mfns_acq_chi2_consistent(q, sol) && mfns_acq_physical(q, sol);
}

mfns_v3_t mfns_acq_cam_centre_w(const mfns_acq_t *q, const mfns_pose_t *pose, int c)
{
    return mfns_v3_add(mfns_pose_position_w(pose), mfns_m3_tmul_v3_at(&pose->C_w_b, q->rig->cam[c].r_bk_b));
}

bool mfns_acq_faces(const mfns_acq_t *q, int b, mfns_v3_t p_w)
{
    return mfns_bidx_emits_toward(&q->idx->geom[b], q->map->beacon[b].p_w, p_w);
}

/* Beacons predicted inside an image (away from its border), in front of the
 * camera and facing it, that no inlier of the solution accounts for. */
int mfns_acq_count_missing(mfns_acq_t *q, const mfns_pose_solution_t *sol)
{
    const mfns_beacon_map_t *map = q->map;
    bool used[MFNS_MAX_BEACONS] = {false};
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        for (int i = 0; i < q->frame->count[c]; i++) {
            const int16_t b = sol->assoc.beacon[c][i];
            if (b >= 0 && b < map->count && sol->inlier[c][i]) {
                used[b] = true;
            }
        }
    }
    /* camera centres in the world: r_wb_w + C_b_w r_bk_b; a full list kept the
     * brightest and a dark camera saw nothing, so neither can miss a beacon */
    mfns_v3_t ck[MFNS_NUM_CAMERAS];
    bool looks[MFNS_NUM_CAMERAS];
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        ck[c] = mfns_acq_cam_centre_w(q, &sol->pose, c);
        looks[c] = q->frame->count[c] < MFNS_MAX_OBS_PER_CAMERA && q->frame->dark[c] == 0U;
    }
    int missing = 0;
    const float m = MISSING_EDGE_PX;
    for (int b = 0; b < map->count; b++) {
        for (int c = 0; c < MFNS_NUM_CAMERAS && !used[b]; c++) {
            const mfns_camera_t *cam = &q->rig->cam[c];
            float uv[2];
            if (!looks[c] || mfns_cam_project(cam, &sol->pose, map->beacon[b].p_w, uv, NULL) != MFNS_PROJ_OK) {
                continue;
            }
            if (uv[0] < m - 0.5f || uv[1] < m - 0.5f || uv[0] > (float)cam->k.width - 0.5f - m ||
                uv[1] > (float)cam->k.height - 0.5f - m || !mfns_acq_faces(q, b, ck[c])) {
                continue;
            }
            missing++;
            break;
        }
    }
    q->progress.units += (uint32_t)map->count / 8u; /* ~0.1 us per beacon: three projections */
    return missing;
}

/* A pose the rig can physically have: the body origin inside the table's
 * workspace (workspace_watch.h mfns_ws_beyond: widened by MFNS_WS_TOL_MM plus
 * MFNS_WS_TOL_SIGMA of the solution's own position sigma, so that a right
 * pose is never refused for its noise), and every inlier's LED facing the camera that sees it. The
 * truth always passes (the workspace is the contract of the table); a wrong
 * correspondence often fits the blobs only from behind a wall or through an
 * LED's back, and without this check such a rival would make a view
 * ambiguous or spend the certificate. */
bool mfns_acq_physical(const mfns_acq_t *q, const mfns_pose_solution_t *sol)
{
    uint8_t beyond = 0U;
    (void)mfns_ws_beyond(q->idx, sol, &beyond, NULL); /* the flight's workspace watch makes the same test */
    if (beyond != 0U) {
        return false;
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        const mfns_v3_t ck = mfns_acq_cam_centre_w(q, &sol->pose, c);
        for (int i = 0; i < q->frame->count[c]; i++) {
            const int16_t b = sol->assoc.beacon[c][i];
            if (b >= 0 && b < q->map->count && sol->inlier[c][i] && !mfns_acq_faces(q, b, ck)) {
                return false;
            }
        }
    }
    return true;
}

static bool same_assoc(const mfns_acq_t *q, const mfns_pose_solution_t *a, const mfns_pose_solution_t *b)
{
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        for (int i = 0; i < q->frame->count[c]; i++) {
            const int16_t ba = a->inlier[c][i] ? a->assoc.beacon[c][i] : MFNS_POSE_NO_BEACON;
            const int16_t bb = b->inlier[c][i] ? b->assoc.beacon[c][i] : MFNS_POSE_NO_BEACON;
            if (ba != bb) {
                return false;
            }
        }
    }
    return true;
}

/* Every inlier correspondence of a is one of b's. */
static bool assoc_within(const mfns_acq_t *q, const mfns_pose_solution_t *a, const mfns_pose_solution_t *b)
{
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        for (int i = 0; i < q->frame->count[c]; i++) {
            if (a->inlier[c][i] && (!b->inlier[c][i] || a->assoc.beacon[c][i] != b->assoc.beacon[c][i])) {
                return false;
            }
        }
    }
    return true;
}

/* A candidate explaining four of five blobs and one explaining all five with
 * the same four beacons on the same blobs are one identification (the fifth
 * blob is a beacon, not a reflection): counting them as two would refuse a
 * right fix; any other difference is a second identification. */
int mfns_acq_identifications(const mfns_acq_t *q, int *keep)
{
    int n = 0;
    *keep = -1;
    for (int i = 0; i < q->ncand; i++) {
        if (!mfns_acq_acceptable(q, &q->cand[i])) {
            continue;
        }
        bool part = false;
        for (int j = 0; j < q->ncand && !part; j++) {
            part = j != i && mfns_acq_acceptable(q, &q->cand[j]) && q->cand[j].inliers > q->cand[i].inliers &&
                   assoc_within(q, &q->cand[i].sol, &q->cand[j].sol);
        }
        if (!part) {
            n++;
            if (*keep < 0 || q->cand[i].inliers > q->cand[*keep].inliers) {
                *keep = i;
            }
        }
    }
    return n;
}

bool mfns_acq_acceptable(const mfns_acq_t *q, const mfns_acq_cand_t *cd)
{
    return cd->missing <= q->idx->max_missing && q->nb - (int)cd->inliers <= (int)q->idx->max_unexplained;
}

static bool better(const mfns_acq_cand_t *a, const mfns_acq_cand_t *b)
{
    return a->inliers > b->inliers || (a->inliers == b->inliers && a->missing < b->missing);
}

void mfns_acq_add_candidate(mfns_acq_t *q, const mfns_acq_cand_t *cd)
{
    for (int i = 0; i < q->ncand; i++) {
        if (same_assoc(q, &q->cand[i].sol, &cd->sol)) {
            return;
        }
    }
    int slot = q->ncand;
    if (q->ncand < MFNS_ACQ_MAX_CAND) {
        q->ncand++;
    } else {
        int worst = 0;
        for (int i = 1; i < q->ncand; i++) {
            if (better(&q->cand[worst], &q->cand[i])) {
                worst = i;
            }
        }
        if (!better(cd, &q->cand[worst])) {
            return;
        }
        slot = worst;
    }
    q->cand[slot] = *cd;
    q->best = 0;
    for (int i = 1; i < q->ncand; i++) {
        if (better(&q->cand[i], &q->cand[q->best])) {
            q->best = i;
        }
    }
    q->progress.best_inliers = q->cand[q->best].inliers;
    q->progress.best_missing = q->cand[q->best].missing;
    const bool reaches = mfns_acq_acceptable(q, cd) && cd->inliers >= q->idx->cert_inliers[cd->missing];
    if (q->exhaustive) { /* only the completion enumerates exhaustively */
        if (reaches) {
            /* (five blobs) a pose explaining all five within the certificate:
             * certified as the bands certify it (the map analysis found no
             * wrong one that reaches it), whatever explains fewer */
            q->certified = slot;
            return;
        }
        /* two identifications that explain every blob (of five: at least
         * four): the completion's answer is AMBIGUOUS whatever else it finds,
         * so it ends here */
        int keep;
        q->settled = mfns_acq_identifications(q, &keep) >= 2;
    }
    if (!q->analysis && mfns_acq_acceptable(q, cd)) {
        if (reaches) {
            q->certified = slot;
        } else if ((int)cd->inliers == q->nb && (q->nb == MFNS_ACQ_MIN_BLOBS || mfns_acq_leave_one_out(q))) {
            /* every blob explained, yet too few for the certificate: only
             * the completion can certify it, so the bands stop here (a
             * candidate leaving one of five blobs out does not stop them: a
             * pose explaining all five would be certified at once) */
            q->to_complete = true;
        }
    }
}

/* Does a beacon land within the quick gate of blob v (normalized
 * coordinates, no distortion)? In the anchor's image only the beacons near
 * a, b or c can (their neighbour lists); in another camera's, any. */
static bool beacon_hits(mfns_acq_t *q, const mfns_pose_t *pose, int v, int anchor_cam, const int abc[3])
{
    const mfns_acq_blob_t *bv = &q->blobs[v];
    const mfns_camera_t *cam = &q->rig->cam[bv->cam];
    mfns_m3_t m;
    mfns_m3_transpose_at(&cam->C_k_b, &m);
    mfns_m3_mul_at(&m, &pose->C_w_b, &m);
    const mfns_v3_t t = mfns_m3_tmul_v3_at(&cam->C_k_b, mfns_v3_sub(pose->r_bw_b, cam->r_bk_b));
    const mfns_obs_t *o = &q->frame->obs[bv->cam][bv->idx];
    const bool local = bv->cam == anchor_cam && !q->exhaustive;
    /* another camera looks ~90 deg away: the minimal pose's rotation error
     * has a long lever there, so it gets the full minimal gate */
    const float g = bv->cam == anchor_cam ? QUICK_GATE_FACTOR * q->gate_n[bv->cam] / MFNS_ACQ_MINIMAL_GATE_FACTOR
                                          : q->gate_n[bv->cam];
    const int lists = local ? 3 : 1;
    for (int l = 0; l < lists; l++) {
        const int a = abc[l];
        const int n = local ? q->idx->nbr_count[a] : q->map->count;
        q->progress.units += local ? 0u : (uint32_t)n / 64u;
        for (int r = 0; r < n; r++) {
            const int b = local ? q->idx->nbr[a][r] : r;
            if (b == abc[0] || b == abc[1] || b == abc[2]) {
                continue;
            }
            const mfns_v3_t p = mfns_v3_add(mfns_m3_mul_v3_at(&m, q->map->beacon[b].p_w), t);
            if (p.z < MFNS_CAM_MIN_DEPTH_MM) {
                continue;
            }
            const float dx = p.x / p.z - o->x, dy = p.y / p.z - o->y;
            if (dx * dx + dy * dy <= g * g) {
                return true;
            }
        }
    }
    return false;
}

/* Cheap check of a hypothesis pose on the anchor's verification blobs: one
 * of them must be explained by a beacon, and in the anchor's image at most
 * max_unexplained may be left (in another camera, where the minimal pose
 * predicts worst, any may). A verification blob may be the reflection a
 * certified fix is allowed to leave: requiring every one in the anchor's image
 * lost every anchor of a view of 1 + 1 + 5 blobs with a reflection among the
 * five (measured), the reflection being among the nearest of each blob. */
bool mfns_acq_quick_check(mfns_acq_t *q, const mfns_pose_t *pose, const mfns_acq_anchor_t *an, const int abc[3])
{
    q->progress.units++;
    const int cam = q->blobs[an->i].cam;
    int tried = 0, hit = 0, missed_here = 0;
    for (int w = 0; w < 2; w++) {
        if (an->v[w] < 0) {
            continue;
        }
        const bool h = beacon_hits(q, pose, an->v[w], cam, abc);
        if (!h && q->blobs[an->v[w]].cam == cam && ++missed_here > (int)q->idx->max_unexplained) {
            return false;
        }
        tried++;
        hit += h ? 1 : 0;
    }
    return tried == 0 || hit > 0;
}

/* Associate again from the refined pose, with the tracking gate and then a
 * wider one, keeping a re-solve that explains more blobs and stays
 * consistent and physical. */
void mfns_acq_extend(mfns_acq_t *q, mfns_acq_cand_t *cd, mfns_pose_meas_t m[MFNS_POSE_MAX_MEAS])
{
    for (int round = 0; round < 2; round++) {
        const float gate = q->cfg->s.track_gate_px * (round == 0 ? 1.0f : MFNS_ACQ_MINIMAL_GATE_FACTOR);
        mfns_pose_assoc_t again;
        if (mfns_pose_associate(q->rig, q->map, q->frame, &cd->sol.pose, gate, &again) <= cd->sol.beacons_used) {
            continue;
        }
        q->progress.units += MFNS_ACQ_VERIFY_UNITS + (uint32_t)q->map->count / 8u;
        mfns_pose_solution_t s2;
        memset(&s2, 0, sizeof s2);
        s2.assoc = again;
        const int n2 = mfns_pose_gather(q->map, q->frame, &again, m);
        if (mfns_acq_solve_checked(q, m, n2, &cd->sol.pose, cd->sol.beacons_used + 1u, &s2)) {
            cd->sol = s2;
        }
    }
}

/* Associate in pixels, refine, associate again; the candidate or false. */
bool mfns_acq_full_verify(mfns_acq_t *q, const mfns_pose_t *pose, mfns_acq_cand_t *cd)
{
    /* an association projects every beacon into every camera: ~0.1 us per beacon */
    q->progress.units += MFNS_ACQ_VERIFY_UNITS + (uint32_t)q->map->count / 8u;
    q->progress.verified++;
    memset(cd, 0, sizeof *cd);
    if (mfns_pose_associate(q->rig, q->map, q->frame, pose, MFNS_ACQ_MINIMAL_GATE_FACTOR * q->cfg->s.track_gate_px,
                            &cd->sol.assoc) < (int)MFNS_ACQ_MIN_BLOBS) {
        return false;
    }
    mfns_pose_meas_t m[MFNS_POSE_MAX_MEAS];
    const int n = mfns_pose_gather(q->map, q->frame, &cd->sol.assoc, m);
    if (n < 0 || mfns_pose_refine_meas(q->rig, m, n, pose, q->cfg, &cd->sol) == MFNS_POSE_NO_FIX) {
        return false;
    }
    /* The minimal pose predicts the other beacons only roughly (m is free
     * again: the extension's scratch, one array on the stack, not two). */
    mfns_acq_extend(q, cd, m);
    if (cd->sol.beacons_used < MFNS_ACQ_MIN_BLOBS) {
        return false;
    }
    if (mfns_acq_chi2_consistent(q, &cd->sol)) {
        if (!mfns_acq_physical(q, &cd->sol)) {
            return false;
        }
    } else if (!without_worst(q, cd, m)) {
        return false;
    }
    cd->inliers = (uint8_t)(cd->sol.beacons_used > 255u ? 255u : cd->sol.beacons_used);
    const int miss = mfns_acq_count_missing(q, &cd->sol);
    cd->missing = (uint8_t)(miss > 255 ? 255 : miss);
    return true;
}
