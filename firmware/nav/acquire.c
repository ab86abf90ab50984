/* acquire.c -- see acquire.h. */
#include "acquire.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "pose_init.h"
#include "pose_internal.h"
#include "spd.h"

/* A pose from three rays carries their noise amplified by the geometry
 * (tens of times near the "danger cylinder"): measured, a right minimal pose
 * at 0.3 px noise predicted a fourth beacon 16 px off. The first association
 * therefore uses this multiple of the tracking gate; the refined pose is then
 * associated again with the tracking gate itself. */
#define MINIMAL_GATE_FACTOR 4.0f
/* The verification blobs are the anchor's nearest neighbours in the image,
 * where the minimal pose's prediction error is smallest: they are checked
 * with half the minimal gate (a false hypothesis then passes ~4x less often;
 * measured, the right one still passes, docs/pose.md). */
#define QUICK_GATE_FACTOR 2.0f
/* Predicted beacons closer than this to the image border are not counted as
 * missing (a spot cut by the border may be refused by the centroider). */
#define MISSING_EDGE_PX 8.0f
/* Cross-camera angles: the two rays start at different camera centres, so
 * their angle differs from the angle the pair subtends at one point by up to
 * the parallax of the baseline at the nearest range. */
#define MIN_PARALLAX_RANGE_MM 200.0f
#define BAND_WS_TOL_MM 300.0f
/* The band schedule (mfns_acq_search): same-image anchors to this rank,
 * then cross anchors to this one, then the rest of both. */
#define SCHED_SAME_FIRST 8u
#define SCHED_CROSS_FIRST 4u
/* The shape pass (first in each rank range of the schedule, SCHED below): a
 * same-image triple whose pair angles, as shares of their sum, differ from
 * the beacons' pair distances, as shares of theirs, by more than this on any
 * pair is left to the full pass of that range. A heuristic order, never a filter (the full passes try every
 * triple the shape pass did not): measured on 3,000 module poses, the true
 * triple of three blobs in one image passes 90 % of the time and a random
 * beacon triple 19 % (at 0.05: 73 % and 5 %; at 0.2: 99 % and 61 %). */
#define SHAPE_TOL 0.1f
/* Anchors of a pair alone in its image (a blob of another camera each). */
#define MAX_CROSS_PER_PAIR 2
/* Tolerance of the workspace test of a candidate (physical()). */
#define WORKSPACE_TOL_MM 20.0f
#define WORKSPACE_TOL_SIGMA 6.0f
/* The same test on a minimal pose, in sigmas of its propagated position
 * (sqrt of the chi-square(1) 1e-6 quantile is 4.9). */
#define MINIMAL_WS_SIGMA 6.0f

static float ray_angle(const mfns_acq_blob_t *a, const mfns_acq_blob_t *b)
{
    const float cs = mfns_v3_dot(a->d, b->d);
    return acosf(cs > 1.0f ? 1.0f : (cs < -1.0f ? -1.0f : cs));
}

static float parallax_pad(const mfns_acq_blob_t *a, const mfns_acq_blob_t *b)
{
    if (a->cam == b->cam) {
        return 0.0f;
    }
    const float base = mfns_v3_norm(mfns_v3_sub(a->c, b->c));
    const float s = base / MIN_PARALLAX_RANGE_MM;
    return s >= 1.0f ? 3.14159265f : asinf(s);
}

/* ------------------------------------------------------------ frame setup */

static bool setup(mfns_acq_t *q)
{
    q->nb = 0;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        for (int i = 0; i < MFNS_MAX_OBS_PER_CAMERA; i++) {
            q->cam_blob[c][i] = -1;
        }
        for (int i = 0; i < q->frame->count[c]; i++) {
            const mfns_obs_t *o = &q->frame->obs[c][i];
            if (!isfinite(o->u) || !isfinite(o->v) || !isfinite(o->x) || !isfinite(o->y)) {
                return false;
            }
            mfns_acq_blob_t *b = &q->blobs[q->nb];
            b->cam = (uint8_t)c;
            b->idx = (uint8_t)i;
            mfns_pose_ray(&q->rig->cam[c], o->x, o->y, &b->c, &b->d);
            q->cam_blob[c][i] = (int16_t)q->nb;
            q->nb++;
        }
        q->gate_n[c] = MINIMAL_GATE_FACTOR * q->cfg->s.track_gate_px / q->rig->cam[c].k.fx;
    }
    return true;
}

/* The blob of camera cam nearest (in angle) to blob i, other than those in
 * excl[0..ne), or -1. */
static int nearest_in_cam(const mfns_acq_t *q, int cam, int i, const int *excl, int ne)
{
    int best = -1;
    float bc = -2.0f;
    for (int m = 0; m < q->frame->count[cam]; m++) {
        const int b = q->cam_blob[cam][m];
        bool skip = b == i;
        for (int e = 0; e < ne; e++) {
            skip = skip || b == excl[e];
        }
        if (skip) {
            continue;
        }
        const float cs = mfns_v3_dot(q->blobs[i].d, q->blobs[b].d);
        if (cs > bc) {
            bc = cs;
            best = b;
        }
    }
    return best;
}

/* Anchors: each blob with its nearest neighbour in the same image, nearest
 * pairs first (insertion into a short sorted list). */
static void make_anchors(mfns_acq_t *q)
{
    /* the pairs: each blob with its nearest in the same image, nearest first */
    int16_t pi[MFNS_ACQ_MAX_ANCHORS], pj[MFNS_ACQ_MAX_ANCHORS];
    float ang[MFNS_ACQ_MAX_ANCHORS];
    int np = 0;
    for (int i = 0; i < q->nb; i++) {
        const int j = nearest_in_cam(q, q->blobs[i].cam, i, NULL, 0);
        bool dup = j < 0;
        for (int a = 0; a < np && !dup; a++) {
            dup = pi[a] == j && pj[a] == i;
        }
        if (dup) {
            continue;
        }
        const float t = ray_angle(&q->blobs[i], &q->blobs[j]);
        int pos = np;
        while (pos > 0 && ang[pos - 1] > t) {
            pos--;
        }
        if (pos >= MFNS_ACQ_MAX_ANCHORS) {
            continue;
        }
        const int last = np < MFNS_ACQ_MAX_ANCHORS ? np : MFNS_ACQ_MAX_ANCHORS - 1;
        for (int m = last; m > pos; m--) {
            pi[m] = pi[m - 1];
            pj[m] = pj[m - 1];
            ang[m] = ang[m - 1];
        }
        pi[pos] = (int16_t)i;
        pj[pos] = (int16_t)j;
        ang[pos] = t;
        np = np < MFNS_ACQ_MAX_ANCHORS ? np + 1 : np;
    }
    /* each pair with its third blob: the next nearest in its image (first,
     * for every pair), else (its image holds only the pair) up to
     * MAX_CROSS_PER_PAIR anchors with a blob of another camera each, one per
     * camera first, since one such triple may be ill-conditioned where another
     * is not. Capped per pair so that a pair of one real blob and a
     * reflection cannot take every anchor slot (measured: a view of 14 + 1 + 1
     * blobs with a reflection beside the lone blob of the third camera was
     * never identified, its six anchors all holding the reflection). */
    q->na = 0;
    for (int pass = 0; pass < 2; pass++) {
        for (int a = 0; a < np && q->na < MFNS_ACQ_MAX_ANCHORS; a++) {
            const int cam = q->blobs[pi[a]].cam;
            const int ex[2] = {pj[a], -1};
            const int k = nearest_in_cam(q, cam, pi[a], ex, 1);
            if ((pass == 0) != (k >= 0)) {
                continue;
            }
            int third[MAX_CROSS_PER_PAIR];
            int nt = 0;
            if (k >= 0) {
                third[nt++] = k;
            } else {
                /* the nearest blob of each other camera, then the next ones */
                for (int round = 0; round < MFNS_MAX_OBS_PER_CAMERA && nt < MAX_CROSS_PER_PAIR; round++) {
                    bool any = false;
                    for (int c = 0; c < MFNS_NUM_CAMERAS && nt < MAX_CROSS_PER_PAIR; c++) {
                        if (c == cam || round >= q->frame->count[c]) {
                            continue;
                        }
                        any = true;
                        third[nt++] = q->cam_blob[c][round];
                    }
                    if (!any) {
                        break;
                    }
                }
            }
            for (int t = 0; t < nt && q->na < MFNS_ACQ_MAX_ANCHORS; t++) {
                const int kk = third[t];
                mfns_acq_anchor_t *an = &q->anchor[q->na++];
                an->i = pi[a];
                an->j = pj[a];
                an->k = (int16_t)kk;
                an->cross = k < 0;
                int ex2[3] = {an->j, kk, -1};
                an->v[0] = (int16_t)(an->cross ? -1 : nearest_in_cam(q, cam, an->i, ex2, 2));
                ex2[2] = an->v[0];
                an->v[1] = (int16_t)(an->v[0] < 0 ? -1 : nearest_in_cam(q, cam, an->i, ex2, 3));
                /* too few in the anchor's image: blobs of the other cameras */
                for (int o = 0; o < q->nb && an->v[1] < 0; o++) {
                    if (o == an->i || o == an->j || o == an->k || o == an->v[0] || q->blobs[o].cam == cam) {
                        continue;
                    }
                    an->v[an->v[0] < 0 ? 0 : 1] = (int16_t)o;
                }
            }
        }
    }
    q->progress.anchors = (uint8_t)q->na;
}

/* ------------------------------------------------------------ verification */

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

/* The residuals of the inliers are plausible under the noise: sum of
 * r_i^T R_i^-1 r_i below the chi-square quantile with 2n - 6 degrees of
 * freedom at 1e-5, where R_i is the observation's covariance of the ML solve
 * (mfns_pose_obs_cov: centroid, floor, and the beacon's survey error seen at
 * its range). A right pose fails once in 1e5; a rival correspondence that
 * fits "nearly" is rejected. */
static bool chi2_consistent(const mfns_acq_t *q, const mfns_pose_solution_t *sol)
{
    const int dof = 2 * (int)sol->beacons_used - 6;
    if (dof <= 0) {
        return true;
    }
    float chi2 = 0.0f;
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
            chi2 += e0 * e0 + e1 * e1;
        }
    }
    return chi2 <= chi2_quantile(dof);
}

/* Beacons predicted inside an image (away from its border), in front of the
 * camera and facing it, that no inlier of the solution accounts for. */
static int count_missing(mfns_acq_t *q, const mfns_pose_solution_t *sol)
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
        ck[c] = mfns_v3_add(mfns_pose_position_w(&sol->pose), mfns_m3_tmul_v3(sol->pose.C_w_b, q->rig->cam[c].r_bk_b));
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
                uv[1] > (float)cam->k.height - 0.5f - m ||
                !mfns_bidx_emits_toward(&q->idx->geom[b], map->beacon[b].p_w, ck[c])) {
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
 * workspace (widened by WORKSPACE_TOL_MM plus WORKSPACE_TOL_SIGMA of the
 * solution's own position sigma, so that a right pose is never refused for
 * its noise), and every inlier's LED facing the camera that sees it. The
 * truth always passes (the workspace is the contract of the table); a wrong
 * correspondence often fits the blobs only from behind a wall or through an
 * LED's back, and without this check such a rival would make a view
 * ambiguous or spend the certificate. */
static bool physical(const mfns_acq_t *q, const mfns_pose_solution_t *sol)
{
    const mfns_v3_t p = mfns_pose_position_w(&sol->pose);
    const float pw[3] = {p.x, p.y, p.z};
    const float lo[3] = {q->idx->ws_min_w.x, q->idx->ws_min_w.y, q->idx->ws_min_w.z};
    const float hi[3] = {q->idx->ws_max_w.x, q->idx->ws_max_w.y, q->idx->ws_max_w.z};
    for (int a = 0; a < 3; a++) {
        const float tol = WORKSPACE_TOL_MM + WORKSPACE_TOL_SIGMA * sol->sigma_pos_mm[a];
        if (!(pw[a] >= lo[a] - tol && pw[a] <= hi[a] + tol)) {
            return false;
        }
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        const mfns_v3_t ck = mfns_v3_add(p, mfns_m3_tmul_v3(sol->pose.C_w_b, q->rig->cam[c].r_bk_b));
        for (int i = 0; i < q->frame->count[c]; i++) {
            const int16_t b = sol->assoc.beacon[c][i];
            if (b >= 0 && b < q->map->count && sol->inlier[c][i] &&
                !mfns_bidx_emits_toward(&q->idx->geom[b], q->map->beacon[b].p_w, ck)) {
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

bool mfns_acq_acceptable(const mfns_acq_t *q, const mfns_acq_cand_t *cd)
{
    return cd->missing <= q->idx->max_missing && q->nb - (int)cd->inliers <= (int)q->idx->max_unexplained;
}

static bool better(const mfns_acq_cand_t *a, const mfns_acq_cand_t *b)
{
    return a->inliers > b->inliers || (a->inliers == b->inliers && a->missing < b->missing);
}

static void add_candidate(mfns_acq_t *q, const mfns_acq_cand_t *cd)
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
    if (q->exhaustive) { /* only the completion enumerates exhaustively */
        /* two identifications that explain every blob: the completion's
         * answer is AMBIGUOUS whatever else it finds, so it ends here */
        int full = 0;
        for (int i = 0; i < q->ncand; i++) {
            full += ((int)q->cand[i].inliers == q->nb && q->cand[i].missing <= q->idx->max_missing) ? 1 : 0;
        }
        q->settled = full >= 2;
    }
    if (!q->analysis && mfns_acq_acceptable(q, cd)) {
        if (cd->inliers >= q->idx->cert_inliers[cd->missing]) {
            q->certified = slot;
        } else if ((int)cd->inliers == q->nb && q->nb == MFNS_ACQ_MIN_BLOBS) {
            /* every blob explained, yet too few for the certificate: only the
             * completion can certify it, so the bands stop here */
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
    const mfns_m3_t m = mfns_m3_mul(mfns_m3_transpose(cam->C_k_b), pose->C_w_b);
    const mfns_v3_t t = mfns_m3_tmul_v3(cam->C_k_b, mfns_v3_sub(pose->r_bw_b, cam->r_bk_b));
    const mfns_obs_t *o = &q->frame->obs[bv->cam][bv->idx];
    const bool local = bv->cam == anchor_cam && !q->exhaustive;
    /* another camera looks ~90 deg away: the minimal pose's rotation error
     * has a long lever there, so it gets the full minimal gate */
    const float g = bv->cam == anchor_cam ? QUICK_GATE_FACTOR * q->gate_n[bv->cam] / MINIMAL_GATE_FACTOR
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
            const mfns_v3_t p = mfns_v3_add(mfns_m3_mul_v3(m, q->map->beacon[b].p_w), t);
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
static bool quick_check(mfns_acq_t *q, const mfns_pose_t *pose, const mfns_acq_anchor_t *an, const int abc[3])
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

/* Associate in pixels, refine, associate again; the candidate or false. */
static bool full_verify(mfns_acq_t *q, const mfns_pose_t *pose, mfns_acq_cand_t *cd)
{
    /* an association projects every beacon into every camera: ~0.1 us per beacon */
    q->progress.units += MFNS_ACQ_VERIFY_UNITS + (uint32_t)q->map->count / 8u;
    q->progress.verified++;
    memset(cd, 0, sizeof *cd);
    if (mfns_pose_associate(q->rig, q->map, q->frame, pose, MINIMAL_GATE_FACTOR * q->cfg->s.track_gate_px,
                            &cd->sol.assoc) < (int)MFNS_ACQ_MIN_BLOBS) {
        return false;
    }
    mfns_pose_meas_t m[MFNS_POSE_MAX_MEAS];
    const int n = mfns_pose_gather(q->map, q->frame, &cd->sol.assoc, m);
    if (n < 0 || mfns_pose_refine_meas(q->rig, m, n, pose, q->cfg, &cd->sol) == MFNS_POSE_NO_FIX) {
        return false;
    }
    /* The minimal pose predicts the other beacons only roughly: associate
     * again from the refined pose, with the tracking gate and then a wider
     * one, keeping a re-solve that explains more blobs and stays consistent. */
    for (int round = 0; round < 2; round++) {
        const float gate = q->cfg->s.track_gate_px * (round == 0 ? 1.0f : MINIMAL_GATE_FACTOR);
        mfns_pose_assoc_t again;
        if (mfns_pose_associate(q->rig, q->map, q->frame, &cd->sol.pose, gate, &again) <= cd->sol.beacons_used) {
            continue;
        }
        q->progress.units += MFNS_ACQ_VERIFY_UNITS + (uint32_t)q->map->count / 8u;
        mfns_pose_solution_t s2;
        memset(&s2, 0, sizeof s2);
        s2.assoc = again;
        const int n2 = mfns_pose_gather(q->map, q->frame, &again, m);
        if (n2 >= 0 && mfns_pose_refine_meas(q->rig, m, n2, &cd->sol.pose, q->cfg, &s2) != MFNS_POSE_NO_FIX &&
            s2.beacons_used > cd->sol.beacons_used && chi2_consistent(q, &s2) && physical(q, &s2)) {
            cd->sol = s2;
        }
    }
    if (cd->sol.beacons_used < MFNS_ACQ_MIN_BLOBS || !chi2_consistent(q, &cd->sol) || !physical(q, &cd->sol)) {
        return false;
    }
    cd->inliers = (uint8_t)(cd->sol.beacons_used > 255u ? 255u : cd->sol.beacons_used);
    const int miss = count_missing(q, &cd->sol);
    cd->missing = (uint8_t)(miss > 255 ? 255 : miss);
    return true;
}

/* The completion's check must not lose a right rival to its minimal pose's
 * noise: the 4th blob is matched against every beacon with the gate of the
 * minimal pose's own propagated uncertainty, r^T (J P J^T + s^2 I)^-1 r below
 * the chi-square(2) quantile at 1e-6, with P the covariance of the pose from
 * the three anchor blobs (first order). A near-singular triple gives a huge
 * gate (every beacon is tried): slower, never unsound. */
#define SOUND_GATE_CHI2 27.63f

static bool stop(const mfns_acq_t *q)
{
    return q->certified >= 0 || q->to_complete || q->progress.budget_out || q->settled;
}


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
 * tolerance of physical()) by more than MINIMAL_WS_SIGMA of that sigma on
 * some axis is not the truth's minimal pose (first order, like the gate of
 * the fourth blob), and every candidate grown from it would fail physical(). */
static bool minimal_in_workspace(const mfns_acq_t *q, const mfns_pose_t *pose,
                                 const float cov[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N])
{
    const mfns_v3_t p = mfns_pose_position_w(pose);
    const float pw[3] = {p.x, p.y, p.z};
    const float lo[3] = {q->idx->ws_min_w.x, q->idx->ws_min_w.y, q->idx->ws_min_w.z};
    const float hi[3] = {q->idx->ws_max_w.x, q->idx->ws_max_w.y, q->idx->ws_max_w.z};
    for (int m = 0; m < 3; m++) {
        const float out = pw[m] < lo[m] ? lo[m] - pw[m] : (pw[m] > hi[m] ? pw[m] - hi[m] : 0.0f);
        if (out <= WORKSPACE_TOL_MM) {
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
        const float tol = WORKSPACE_TOL_MM + MINIMAL_WS_SIGMA * sqrtf(var > 0.0f ? var : 0.0f);
        if (out > tol) {
            return false;
        }
    }
    return true;
}

/* Sound verification of one minimal pose in the completion: the anchor's
 * three correspondences and, for the remaining blob, every beacon within the
 * propagated gate are refined together and scored like any candidate. */
static void sound_verify(mfns_acq_t *q, const mfns_pose_t *pose, const mfns_acq_anchor_t *an, const int abc[3])
{
    /* Charges here are measured, like every unit (acquire.h): with a minimal
     * pose's covariance, the map's pair look-ups and a residual per 4 beacons
     * left, a completion costs 0.7-1.1 us per unit on the benchmark host, as
     * the bands do (it was 0.3 us with a unit per residual, docs/pose.md). */
    q->progress.units += 1u + (uint32_t)q->map->count / 64u; /* the covariance of the three */
    uint32_t n_res = 0u;
    const int tri[3] = {an->i, an->j, an->k};
    mfns_pose_meas_t m[MFNS_POSE_MAX_MEAS];
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
    int l = -1; /* the remaining blob */
    for (int b = 0; b < q->nb && l < 0; b++) {
        l = (b != tri[0] && b != tri[1] && b != tri[2]) ? b : -1;
    }
    if (l < 0) {
        return;
    }
    /* the fourth beacon must admit its angles to the three, like any pair
     * of the enumeration (the same tables the hypotheses were pruned with) */
    float tl[3], pl[3];
    for (int t = 0; t < 3; t++) {
        tl[t] = ray_angle(&q->blobs[tri[t]], &q->blobs[l]);
        pl[t] = parallax_pad(&q->blobs[tri[t]], &q->blobs[l]);
    }
    for (int d = 0; d < q->map->count && !stop(q); d++) {
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
        if (mfns_pose_refine_meas(q->rig, m, 4, pose, q->cfg, &cd.sol) == MFNS_POSE_NO_FIX ||
            cd.sol.beacons_used < MFNS_ACQ_MIN_BLOBS || !chi2_consistent(q, &cd.sol) || !physical(q, &cd.sol)) {
            continue;
        }
        cd.inliers = (uint8_t)cd.sol.beacons_used;
        const int miss = count_missing(q, &cd.sol);
        cd.missing = (uint8_t)(miss > 255 ? 255 : miss);
        add_candidate(q, &cd);
    }
}

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
        const int c = q->blobs[tri[t]].cam;
        const mfns_v3_t ck = mfns_v3_add(p, mfns_m3_tmul_v3(pose->C_w_b, q->rig->cam[c].r_bk_b));
        if (!mfns_bidx_emits_toward(&q->idx->geom[abc[t]], q->map->beacon[abc[t]].p_w, ck)) {
            return false;
        }
    }
    return true;
}

/* ------------------------------------------------------------ enumeration */


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
    const mfns_v3_t rc[3] = {t[0]->c, t[1]->c, t[2]->c};
    const mfns_v3_t rd[3] = {t[0]->d, t[1]->d, t[2]->d};
    const mfns_v3_t xw[3] = {q->map->beacon[a].p_w, q->map->beacon[b].p_w, q->map->beacon[c].p_w};
    const mfns_beacon_geom_t *gc = &q->idx->geom[c];
    mfns_pose_t sols[MFNS_GP3P_MAX_SOLUTIONS];
    const int ns = mfns_gp3p(rc, rd, xw, gc->range_min_mm, gc->range_max_mm, sols);
    const int abc[3] = {a, b, c};
    for (int s = 0; s < ns && !stop(q); s++) {
        if (q->exhaustive) {
            sound_verify(q, &sols[s], an, abc);
            continue;
        }
        if (!band_plausible(q, &sols[s], an, abc) || !quick_check(q, &sols[s], an, abc)) {
            continue;
        }
        mfns_acq_cand_t cd;
        if (full_verify(q, &sols[s], &cd)) {
            add_candidate(q, &cd);
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
    const mfns_v3_t pa = q->map->beacon[a].p_w, pb = q->map->beacon[b].p_w, pc = q->map->beacon[c].p_w;
    const float d[3] = {mfns_v3_norm(mfns_v3_sub(pa, pb)), mfns_v3_norm(mfns_v3_sub(pa, pc)),
                        mfns_v3_norm(mfns_v3_sub(pb, pc))};
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

/* Which triples a band tries (same-image anchors; a cross anchor tries all):
 * every admissible one but those the shape pass had (shape-matching, both
 * ranks below shape_done), or only the shape-matching ones. */
typedef struct {
    bool shape_only;
    int shape_done;
} band_mode_t;

static bool band_tries(const mfns_acq_t *q, band_mode_t mode, const float tri[3], int a, int b, int c, int rb,
                       int rc)
{
    if (mode.shape_only) {
        return shape_matches(q, tri, a, b, c);
    }
    return rb >= mode.shape_done || rc >= mode.shape_done || !shape_matches(q, tri, a, b, c);
}

/* Band [w0, w1) of one anchor: hypotheses whose ranks (rb, rc) reach it. */
static void band(mfns_acq_t *q, const mfns_acq_anchor_t *an, int w0, int w1, band_mode_t mode)
{
    const mfns_beacon_index_t *ix = q->idx;
    const mfns_acq_blob_t *bi = &q->blobs[an->i], *bj = &q->blobs[an->j], *bk = &q->blobs[an->k];
    const float tij = ray_angle(bi, bj), tik = ray_angle(bi, bk), tjk = ray_angle(bj, bk);
    const float pik = parallax_pad(bi, bk), pjk = parallax_pad(bj, bk);
    const float tri[3] = {tij, tik, tjk};
    resume_t rs = resume_point(q);
    for (int a = rs.a; a < ix->count && !stop(q); a++) {
        const int na = ix->nbr_count[a];
        const bool on_a = rs.on && a == rs.a;
        for (int rb = on_a ? rs.r1 : 0; rb < na && rb < w1 && !stop(q); rb++) {
            const bool on_b = on_a && rb == rs.r1;
            const int b = ix->nbr[a][rb];
            if (!mfns_bidx_pair_admits(ix, (uint32_t)a, (uint32_t)b, tij, 0.0f)) {
                continue;
            }
            if (an->cross) {
                if (rb < w0) {
                    continue;
                }
                for (int c = on_b ? rs.r2 : 0; c < ix->count && !stop(q); c++) {
                    if (c != a && c != b && mfns_bidx_pair_admits(ix, (uint32_t)a, (uint32_t)c, tik, pik) &&
                        mfns_bidx_pair_admits(ix, (uint32_t)b, (uint32_t)c, tjk, pjk)) {
                        hypothesis(q, an, a, b, c, rb, c);
                    }
                }
                continue;
            }
            for (int rc = on_b ? rs.r2 : 0; rc < na && rc < w1 && !stop(q); rc++) {
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
static void exhaust(mfns_acq_t *q, const mfns_acq_anchor_t *an)
{
    const mfns_beacon_index_t *ix = q->idx;
    const mfns_acq_blob_t *bi = &q->blobs[an->i], *bj = &q->blobs[an->j], *bk = &q->blobs[an->k];
    const float tij = ray_angle(bi, bj), tik = ray_angle(bi, bk), tjk = ray_angle(bj, bk);
    const float pij = parallax_pad(bi, bj), pik = parallax_pad(bi, bk), pjk = parallax_pad(bj, bk);
    resume_t rs = resume_point(q);
    for (int a = rs.a; a < ix->count && !stop(q); a++) {
        const bool on_a = rs.on && a == rs.a;
        for (int b = on_a ? rs.r1 : 0; b < ix->count && !stop(q); b++) {
            const bool on_b = on_a && b == rs.r1;
            if (!mfns_bidx_pair_admits(ix, (uint32_t)a, (uint32_t)b, tij, pij)) {
                continue;
            }
            for (int c = on_b ? rs.r2 : 0; c < ix->count && !stop(q); c++) {
                if (c != a && c != b && mfns_bidx_pair_admits(ix, (uint32_t)a, (uint32_t)c, tik, pik) &&
                    mfns_bidx_pair_admits(ix, (uint32_t)b, (uint32_t)c, tjk, pjk)) {
                    hypothesis(q, an, a, b, c, b, c);
                }
            }
        }
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

/* After the bands of a 4-blob frame without a certified pose (the sound
 * check covers one blob beyond the anchor's three), the completion runs,
 * whether or not the bands found an explanation of every blob: it finds
 * every such explanation itself, so a truth the neighbour lists cannot
 * reach is found there too (measured: 6 of 300 module four-blob views
 * searched without a budget had no full explanation after the bands). */
static bool completion_applies(const mfns_acq_t *q)
{
    return !q->analysis && q->certified < 0 && completion_anchor(q) >= 0 && q->nb == MFNS_ACQ_MIN_BLOBS;
}

/* The completion, from the cursor: exhaust one anchor, collecting every
 * candidate (never stopping on the first); then a best candidate that
 * explains every blob is unique if no other candidate does. */
static void run_completion(mfns_acq_t *q)
{
    const int an = completion_anchor(q);
    q->analysis = true; /* collect, never stop on the first */
    q->exhaustive = true;
    q->to_complete = false;
    q->paused = false;
    exhaust(q, &q->anchor[an]);
    q->exhaustive = false;
    q->analysis = false;
    if (q->progress.budget_out) {
        return; /* the cursor holds the place */
    }
    /* unique: no other pose explains every blob within the allowances (a
     * rival with more missing beacons could be the truth with a beacon
     * hidden, so it is not ruled out by being less likely) */
    int keep = -1, full = 0;
    for (int i = 0; i < q->ncand; i++) {
        const mfns_acq_cand_t *c = &q->cand[i];
        if ((int)c->inliers == q->nb && c->missing <= q->idx->max_missing) {
            full++;
            keep = i;
        }
    }
    q->progress.rivals = (uint8_t)(full > 0 ? full - 1 : 0);
    if (full == 1) {
        q->certified = keep;
        q->progress.completed = true;
    }
    q->cur.phase = MFNS_ACQ_PHASE_DONE;
}

/* Cheap anchors first: a band of an anchor whose third blob is in the same
 * image costs N (w1^2 - w0^2) pair look-ups, one whose third is in another
 * camera N^2 (w1 - w0). In each rank range, the same-image anchors' triples
 * of the measured shape first (SHAPE_TOL: a fifth of the triples, nine
 * truths in ten), then their other triples, then the cross anchors' bands (a
 * same-image triple may be too ill-conditioned for its verification to find
 * the truth): to rank 8 (4 for cross anchors), then to the last rank
 * (measured on 1,000 module views without the shape pass: 829 right against
 * 824 with every same-image band first; docs/pose.md for the shape pass).
 * kind: 0 same image (the triples the shape pass left), 1 cross, 2 same
 * image, shape pass. */
#define KIND_SAME 0u
#define KIND_CROSS 1u
#define KIND_SHAPE 2u
static const struct {
    uint8_t kind, w_max;
} SCHED[] = {{KIND_SHAPE, SCHED_SAME_FIRST}, {KIND_SAME, SCHED_SAME_FIRST},   {KIND_CROSS, SCHED_CROSS_FIRST},
             {KIND_SHAPE, MFNS_BIDX_MAX_NBR}, {KIND_SAME, MFNS_BIDX_MAX_NBR}, {KIND_CROSS, MFNS_BIDX_MAX_NBR}};
#define SCHED_STEPS ((uint8_t)(sizeof SCHED / sizeof SCHED[0]))

/* The window after ranks [0, w0): doubling, capped at w_max. */
static uint8_t next_window(int w0, int w_max)
{
    const int w = w0 == 0 ? 1 : 2 * w0;
    return (uint8_t)(w < w_max ? w : w_max);
}

/* The bands, from the cursor: every step of the schedule, every window of
 * it, every anchor of its kind. */
static void run_bands(mfns_acq_t *q)
{
    mfns_acq_cursor_t *u = &q->cur;
    while (u->stage < SCHED_STEPS && !stop(q)) {
        const int kind = SCHED[u->stage].kind;
        const bool cross = kind == (int)KIND_CROSS;
        const band_mode_t mode = {kind == (int)KIND_SHAPE, cross ? 0 : (int)u->w_done[KIND_SHAPE]};
        const int w_max = SCHED[u->stage].w_max < q->idx->k_nbr ? SCHED[u->stage].w_max : q->idx->k_nbr;
        if (u->w == 0u) { /* the step starts after the windows its kind has done */
            u->w0 = u->w_done[kind];
            u->w = next_window(u->w0, w_max);
            u->anchor = 0u;
        }
        if ((int)u->w0 >= w_max) {
            u->w_done[kind] = u->w0;
            u->stage++;
            u->w = 0u;
            continue;
        }
        q->progress.band = u->w;
        while (u->anchor < q->na && !stop(q)) {
            const mfns_acq_anchor_t *an = &q->anchor[u->anchor];
            if (an->k >= 0 && an->cross == cross) {
                band(q, an, u->w0, u->w, mode);
            }
            if (!stop(q)) {
                u->anchor++;
            }
        }
        if (!stop(q)) { /* the window is done: the next one */
            u->w0 = u->w;
            u->w = next_window(u->w0, w_max);
            u->anchor = 0u;
        }
    }
}

/* Run the search from its cursor until it ends or the call's budget does. */
static void run(mfns_acq_t *q)
{
    if (q->cur.phase == MFNS_ACQ_PHASE_BANDS) {
        run_bands(q);
        if (q->progress.budget_out && !q->to_complete && q->certified < 0) {
            return;
        }
        q->progress.finished = true;
        q->cur.phase = completion_applies(q) ? MFNS_ACQ_PHASE_COMPLETE : MFNS_ACQ_PHASE_DONE;
        if (q->cur.phase == MFNS_ACQ_PHASE_COMPLETE && q->pause_before_completion) {
            q->paused = true; /* the caller decides whether this frame's completion runs */
            return;
        }
    }
    if (q->cur.phase == MFNS_ACQ_PHASE_COMPLETE) {
        run_completion(q);
    }
    q->progress.certified = q->certified >= 0;
}

/* No search: progress, cursor and candidates cleared. */
static void clear_search(mfns_acq_t *q)
{
    memset(&q->progress, 0, sizeof q->progress);
    memset(&q->cur, 0, sizeof q->cur);
    q->ncand = 0;
    q->best = -1;
    q->certified = -1;
    q->exhaustive = false;
    q->to_complete = false;
    q->settled = false;
    q->paused = false;
}

void mfns_acq_search(mfns_acq_t *q)
{
    clear_search(q);
    make_anchors(q);
    q->cur.phase = MFNS_ACQ_PHASE_BANDS;
    q->progress.calls = 1u;
    run(q);
    q->progress.units_total = q->progress.units;
}

static bool valid_inputs(const mfns_rig_t *rig, const mfns_beacon_map_t *map, const mfns_beacon_index_t *idx,
                         const mfns_obs_frame_t *frame, const mfns_pose_config_t *cfg)
{
    if (rig == NULL || map == NULL || idx == NULL || frame == NULL || cfg == NULL || map->count > MFNS_MAX_BEACONS ||
        idx->count != map->count || idx->k_nbr == 0 || idx->k_nbr > MFNS_BIDX_MAX_NBR ||
        !(cfg->sigma_px > 0.0f) || cfg->s.max_iterations == 0 || !(cfg->s.track_gate_px > 0.0f)) {
        return false;
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        if (frame->count[c] > MFNS_MAX_OBS_PER_CAMERA) {
            return false;
        }
    }
    return true;
}

bool mfns_acq_prepare(mfns_acq_t *acq, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                      const mfns_beacon_index_t *idx, const mfns_obs_frame_t *frame, const mfns_pose_config_t *cfg,
                      uint32_t budget_units, bool analysis)
{
    clear_search(acq);
    if (!valid_inputs(rig, map, idx, frame, cfg)) {
        return false;
    }
    acq->rig = rig;
    acq->map = map;
    acq->idx = idx;
    acq->frame_copy = *frame; /* a resumed search reads it after the caller's frame has moved on */
    acq->frame = &acq->frame_copy;
    acq->cfg = cfg;
    acq->budget = budget_units;
    acq->analysis = analysis;
    acq->pause_before_completion = false;
    return setup(acq);
}

/* The outcome of the search so far into out. */
static mfns_pose_status_t result(const mfns_acq_t *acq, mfns_pose_solution_t *out)
{
    const uint32_t hyp = acq->progress.hypotheses;
    if (acq->certified >= 0) {
        *out = acq->cand[acq->certified].sol;
    } else {
        mfns_pose_reason_t reason = acq->progress.rivals > 0 ? MFNS_POSE_R_AMBIGUOUS : MFNS_POSE_R_NOT_IDENTIFIED;
        for (int i = 0; i < acq->ncand && acq->best >= 0; i++) {
            if (i != acq->best && acq->cand[i].inliers == acq->cand[acq->best].inliers &&
                acq->cand[i].missing == acq->cand[acq->best].missing) {
                reason = MFNS_POSE_R_AMBIGUOUS;
            }
        }
        mfns_pose_solution_clear(out, reason);
    }
    out->hypotheses = (uint16_t)(hyp > 0xFFFFu ? 0xFFFFu : hyp);
    return out->status;
}

mfns_pose_status_t mfns_acquire(mfns_acq_t *acq, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                const mfns_beacon_index_t *idx, const mfns_obs_frame_t *frame,
                                const mfns_pose_config_t *cfg, uint32_t budget_units, mfns_pose_solution_t *out)
{
    return mfns_acq_start(acq, rig, map, idx, frame, cfg, budget_units, false, out);
}

mfns_pose_status_t mfns_acq_start(mfns_acq_t *acq, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                  const mfns_beacon_index_t *idx, const mfns_obs_frame_t *frame,
                                  const mfns_pose_config_t *cfg, uint32_t budget_units, bool pause_before_completion,
                                  mfns_pose_solution_t *out)
{
    if (out == NULL) {
        return MFNS_POSE_NO_FIX;
    }
    mfns_pose_solution_clear(out, MFNS_POSE_R_BAD_ARG);
    if (acq == NULL || !mfns_acq_prepare(acq, rig, map, idx, frame, cfg, budget_units, false)) {
        return out->status;
    }
    acq->pause_before_completion = pause_before_completion;
    if (acq->nb < 3 || map->count < 3) {
        out->reason = MFNS_POSE_R_TOO_FEW;
        return out->status;
    }
    if (acq->nb < (int)MFNS_ACQ_MIN_BLOBS) {
        /* no fix from three blobs can be certified: do not search */
        out->reason = MFNS_POSE_R_BELOW_CERTIFICATE;
        return out->status;
    }
    mfns_acq_search(acq);
    return result(acq, out);
}

bool mfns_acq_pending(const mfns_acq_t *acq)
{
    return acq != NULL && (acq->progress.budget_out || acq->paused) && acq->certified < 0 &&
           (acq->cur.phase == MFNS_ACQ_PHASE_BANDS || acq->cur.phase == MFNS_ACQ_PHASE_COMPLETE);
}

mfns_pose_status_t mfns_acq_resume(mfns_acq_t *acq, uint32_t budget_units, mfns_pose_solution_t *out)
{
    if (out == NULL) {
        return MFNS_POSE_NO_FIX;
    }
    mfns_pose_solution_clear(out, MFNS_POSE_R_BAD_ARG);
    if (!mfns_acq_pending(acq)) {
        return out->status;
    }
    acq->progress.units = 0u;
    acq->progress.budget_out = false;
    acq->progress.calls = (uint16_t)(acq->progress.calls < 0xFFFFu ? acq->progress.calls + 1u : 0xFFFFu);
    acq->budget = budget_units;
    acq->pause_before_completion = false; /* resumed: the completion runs */
    run(acq);
    acq->progress.units_total += acq->progress.units;
    return result(acq, out);
}

void mfns_acq_reset(mfns_acq_t *acq)
{
    if (acq != NULL) {
        clear_search(acq);
    }
}
