/* beacon_ident.c -- acquisition: which blob is which beacon, with no prior.
 *
 * Hypothesize and verify across cameras. Blobs are ordered round-robin over
 * the cameras (so the first triple spans as many cameras as possible, the
 * best-conditioned case for the generalized P3P), and for a blob triple every
 * ordered beacon triple is a hypothesis; pairs whose beacon distance cannot be
 * reached by the two rays within max_range are pruned before solving. Each
 * gP3P pose is scored cheaply in undistorted normalized coordinates (blobs
 * with a beacon within the tracking gate); a pose explaining at least four
 * blobs is associated in pixels and refined (ML), and its inliers are its
 * final score. The search over a triple is exhaustive, so once a triple made
 * only of the best candidate's inliers has been enumerated, every pose that
 * explains those blobs has been seen: a second candidate with a different
 * correspondence, the same score and no more missing beacons is a rival and
 * the answer is AMBIGUOUS. The number of gP3P solves is bounded by
 * settings.max_hypotheses; an unfinished search is never reported as a fix.
 *
 * Limitation (documented, tested): a rival that explains an equally large but
 * different set of blobs (possible only with spurious blobs) is searched
 * for only within the triples enumerated before the stop.
 */
#include <math.h>
#include <stddef.h>
#include <string.h>

#include "pose.h"
#include "pose_init.h"
#include "pose_internal.h"

#define MAX_CAND 8

typedef struct {
    uint8_t cam, idx;
    mfns_v3_t c, d;
} blob_t;

typedef struct {
    mfns_pose_solution_t sol;
    int score;   /* inliers */
    int missing; /* beacons predicted in view with no blob */
} cand_t;

/* Blobs with a beacon within gate in normalized coordinates. */
static int coarse_score(const mfns_rig_t *rig, const mfns_beacon_map_t *map, const mfns_obs_frame_t *frame,
                        const mfns_pose_t *pose, const float gate_n[MFNS_NUM_CAMERAS])
{
    int score = 0;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        const int nb = frame->count[c];
        if (nb == 0) {
            continue;
        }
        /* body-to-camera in one matrix: p_c = C_k_b^T (C_w_b p_w + r_bw_b - r_bk_b) */
        const mfns_m3_t m = mfns_m3_mul(mfns_m3_transpose(rig->cam[c].C_k_b), pose->C_w_b);
        const mfns_v3_t t = mfns_m3_tmul_v3(rig->cam[c].C_k_b, mfns_v3_sub(pose->r_bw_b, rig->cam[c].r_bk_b));
        float bx[MFNS_MAX_BEACONS], by[MFNS_MAX_BEACONS];
        int nv = 0;
        for (int b = 0; b < map->count; b++) {
            const mfns_v3_t p = mfns_v3_add(mfns_m3_mul_v3(m, map->beacon[b].p_w), t);
            if (p.z >= MFNS_CAM_MIN_DEPTH_MM) {
                bx[nv] = p.x / p.z;
                by[nv] = p.y / p.z;
                nv++;
            }
        }
        const float g2 = gate_n[c] * gate_n[c];
        for (int i = 0; i < nb; i++) {
            for (int k = 0; k < nv; k++) {
                const float dx = bx[k] - frame->obs[c][i].x, dy = by[k] - frame->obs[c][i].y;
                if (dx * dx + dy * dy <= g2) {
                    score++;
                    break;
                }
            }
        }
    }
    return score;
}

/* Beacons predicted inside an image that no blob of the association accounts for. */
static int count_missing(const mfns_rig_t *rig, const mfns_beacon_map_t *map, const mfns_obs_frame_t *frame,
                         const mfns_pose_solution_t *sol)
{
    int missing = 0;
    for (int b = 0; b < map->count; b++) {
        bool used = false;
        for (int c = 0; c < MFNS_NUM_CAMERAS && !used; c++) {
            for (int i = 0; i < frame->count[c]; i++) {
                if (sol->assoc.beacon[c][i] == b) {
                    used = true;
                    break;
                }
            }
        }
        if (used) {
            continue;
        }
        for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
            float uv[2];
            if (mfns_cam_project(&rig->cam[c], &sol->pose, map->beacon[b].p_w, uv, NULL) == MFNS_PROJ_OK &&
                mfns_cam_in_image(&rig->cam[c].k, uv[0], uv[1])) {
                missing++;
                break;
            }
        }
    }
    return missing;
}

static bool same_assoc(const mfns_pose_solution_t *a, const mfns_pose_solution_t *b, const mfns_obs_frame_t *frame)
{
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        for (int i = 0; i < frame->count[c]; i++) {
            const int16_t ba = a->inlier[c][i] ? a->assoc.beacon[c][i] : MFNS_POSE_NO_BEACON;
            const int16_t bb = b->inlier[c][i] ? b->assoc.beacon[c][i] : MFNS_POSE_NO_BEACON;
            if (ba != bb) {
                return false;
            }
        }
    }
    return true;
}

static bool same_pose(const mfns_pose_t *a, const mfns_pose_t *b)
{
    return mfns_v3_norm(mfns_v3_sub(a->r_bw_b, b->r_bw_b)) < 1.0f &&
           mfns_rot_angle_between(a->C_w_b, b->C_w_b) < 1e-3f;
}

/* Largest distance two points on the rays can have with depths in [lo, hi]
 * (distance is convex in the depths, so a corner attains it). */
static float ray_pair_dmax(const blob_t *a, const blob_t *b, float lo, float hi)
{
    float dmax = 0.0f;
    const float l[2] = {lo, hi};
    for (int i = 0; i < 2; i++) {
        for (int j = 0; j < 2; j++) {
            const mfns_v3_t pa = mfns_v3_add(a->c, mfns_v3_scale(a->d, l[i]));
            const mfns_v3_t pb = mfns_v3_add(b->c, mfns_v3_scale(b->d, l[j]));
            dmax = fmaxf(dmax, mfns_v3_norm(mfns_v3_sub(pa, pb)));
        }
    }
    return dmax;
}

static bool triple_in_inliers(const blob_t *t[3], const mfns_pose_solution_t *sol)
{
    for (int i = 0; i < 3; i++) {
        if (!sol->inlier[t[i]->cam][t[i]->idx]) {
            return false;
        }
    }
    return true;
}

#define MIN_RANGE_MM 10.0f

mfns_pose_status_t mfns_pose_acquire(const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                     const mfns_obs_frame_t *frame, const mfns_pose_config_t *cfg,
                                     mfns_pose_solution_t *out)
{
    if (out == NULL) {
        return MFNS_POSE_NO_FIX;
    }
    mfns_pose_solution_clear(out, MFNS_POSE_R_BAD_ARG);
    if (rig == NULL || map == NULL || frame == NULL || cfg == NULL || map->count > MFNS_MAX_BEACONS ||
        !(cfg->max_range_mm > MIN_RANGE_MM) || !(cfg->sigma_px > 0.0f) || cfg->s.max_iterations == 0) {
        return out->status;
    }
    blob_t blobs[MFNS_POSE_MAX_MEAS];
    int nb = 0;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        if (frame->count[c] > MFNS_MAX_OBS_PER_CAMERA) {
            return out->status;
        }
    }
    /* round-robin over cameras */
    for (int i = 0; i < MFNS_MAX_OBS_PER_CAMERA; i++) {
        for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
            if (i < frame->count[c]) {
                const mfns_obs_t *o = &frame->obs[c][i];
                if (!isfinite(o->u) || !isfinite(o->v) || !isfinite(o->x) || !isfinite(o->y)) {
                    return out->status;
                }
                blobs[nb].cam = (uint8_t)c;
                blobs[nb].idx = (uint8_t)i;
                mfns_pose_ray(&rig->cam[c], o->x, o->y, &blobs[nb].c, &blobs[nb].d);
                nb++;
            }
        }
    }
    if (nb < 3 || map->count < 3) {
        out->reason = MFNS_POSE_R_TOO_FEW;
        return out->status;
    }
    float gate_n[MFNS_NUM_CAMERAS];
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        gate_n[c] = cfg->s.track_gate_px / rig->cam[c].k.fx;
    }
    const float lo = MIN_RANGE_MM, hi = cfg->max_range_mm;
    static const float slack = 1.001f;

    cand_t cand[MAX_CAND];
    int ncand = 0;
    int best = -1;                /* index of the best candidate */
    bool overflow = false;        /* more distinct candidates than MAX_CAND */
    bool complete = false;        /* a triple of the best's inliers was enumerated */
    bool minimal_rival = false;   /* nb == 3: two consistent poses already seen */
    uint32_t hyp = 0;
    const uint32_t max_hyp = cfg->s.max_hypotheses;
    bool budget_out = false;

    for (int i = 0; i < nb - 2 && !complete && !budget_out && !minimal_rival; i++) {
        for (int j = i + 1; j < nb - 1 && !complete && !budget_out && !minimal_rival; j++) {
            for (int k = j + 1; k < nb && !complete && !budget_out && !minimal_rival; k++) {
                const blob_t *t[3] = {&blobs[i], &blobs[j], &blobs[k]};
                const float d12max = ray_pair_dmax(t[0], t[1], lo, hi) * slack;
                const float d13max = ray_pair_dmax(t[0], t[2], lo, hi) * slack;
                const float d23max = ray_pair_dmax(t[1], t[2], lo, hi) * slack;
                const mfns_v3_t rc[3] = {t[0]->c, t[1]->c, t[2]->c};
                const mfns_v3_t rd[3] = {t[0]->d, t[1]->d, t[2]->d};
                bool triple_done = true;
                for (int a = 0; a < map->count && triple_done; a++) {
                    for (int b = 0; b < map->count && triple_done; b++) {
                        if (b == a ||
                            mfns_v3_norm(mfns_v3_sub(map->beacon[a].p_w, map->beacon[b].p_w)) > d12max) {
                            continue;
                        }
                        for (int c3 = 0; c3 < map->count; c3++) {
                            if (c3 == a || c3 == b ||
                                mfns_v3_norm(mfns_v3_sub(map->beacon[a].p_w, map->beacon[c3].p_w)) > d13max ||
                                mfns_v3_norm(mfns_v3_sub(map->beacon[b].p_w, map->beacon[c3].p_w)) > d23max) {
                                continue;
                            }
                            if (hyp >= max_hyp) {
                                budget_out = true;
                                triple_done = false;
                                break;
                            }
                            hyp++;
                            const mfns_v3_t xw[3] = {map->beacon[a].p_w, map->beacon[b].p_w, map->beacon[c3].p_w};
                            mfns_pose_t sols[MFNS_GP3P_MAX_SOLUTIONS];
                            const int ns = mfns_gp3p(rc, rd, xw, lo, hi, sols);
                            for (int s = 0; s < ns; s++) {
                                const int sc = coarse_score(rig, map, frame, &sols[s], gate_n);
                                if (sc < 3 || (nb > 3 && sc < 4)) {
                                    continue;
                                }
                                cand_t cd;
                                memset(&cd, 0, sizeof(cd));
                                if (nb == 3) {
                                    /* minimal: the gP3P pose is exact for these blobs */
                                    if (mfns_pose_associate(rig, map, frame, &sols[s], cfg->s.track_gate_px,
                                                            &cd.sol.assoc) < 3) {
                                        continue;
                                    }
                                } else if (mfns_pose_associate(rig, map, frame, &sols[s], cfg->s.track_gate_px,
                                                               &cd.sol.assoc) < 4) {
                                    continue;
                                }
                                mfns_pose_meas_t m[MFNS_POSE_MAX_MEAS];
                                const int n = mfns_pose_gather(map, frame, &cd.sol.assoc, m);
                                if (n < 0 || mfns_pose_refine_meas(rig, m, n, &sols[s], cfg, &cd.sol) ==
                                                 MFNS_POSE_NO_FIX) {
                                    continue;
                                }
                                cd.score = cd.sol.beacons_used;
                                cd.missing = count_missing(rig, map, frame, &cd.sol);
                                bool dup = false;
                                for (int q = 0; q < ncand; q++) {
                                    if (same_assoc(&cand[q].sol, &cd.sol, frame) &&
                                        (nb > 3 || same_pose(&cand[q].sol.pose, &cd.sol.pose))) {
                                        dup = true;
                                        break;
                                    }
                                }
                                if (dup) {
                                    continue;
                                }
                                if (ncand < MAX_CAND) {
                                    cand[ncand++] = cd;
                                } else {
                                    overflow = true;
                                    /* replace the worst if this one is better */
                                    int worst = 0;
                                    for (int q = 1; q < ncand; q++) {
                                        if (cand[q].score < cand[worst].score ||
                                            (cand[q].score == cand[worst].score &&
                                             cand[q].missing > cand[worst].missing)) {
                                            worst = q;
                                        }
                                    }
                                    if (cd.score > cand[worst].score ||
                                        (cd.score == cand[worst].score && cd.missing < cand[worst].missing)) {
                                        cand[worst] = cd;
                                    }
                                }
                                best = 0;
                                for (int q = 1; q < ncand; q++) {
                                    if (cand[q].score > cand[best].score ||
                                        (cand[q].score == cand[best].score && cand[q].missing < cand[best].missing)) {
                                        best = q;
                                    }
                                }
                                if (nb == 3) {
                                    int consistent = 0;
                                    for (int q = 0; q < ncand; q++) {
                                        consistent += cand[q].missing == 0 ? 1 : 0;
                                    }
                                    if (consistent >= 2) {
                                        minimal_rival = true;
                                    }
                                }
                            }
                        }
                    }
                }
                if (triple_done && best >= 0 && triple_in_inliers(t, &cand[best].sol)) {
                    complete = true;
                }
            }
        }
    }
    const uint16_t hyp16 = (uint16_t)(hyp > 0xFFFFu ? 0xFFFFu : hyp);
    if (best < 0) {
        mfns_pose_solution_clear(out, budget_out ? MFNS_POSE_R_NOT_IDENTIFIED : MFNS_POSE_R_NOT_IDENTIFIED);
        out->hypotheses = hyp16;
        return out->status;
    }
    int rivals = 0;
    for (int q = 0; q < ncand; q++) {
        if (q != best && cand[q].score == cand[best].score && cand[q].missing == cand[best].missing) {
            rivals++;
        }
    }
    if (rivals > 0 || minimal_rival || (overflow && cand[best].score <= 3)) {
        mfns_pose_solution_clear(out, MFNS_POSE_R_AMBIGUOUS);
        out->hypotheses = hyp16;
        return out->status;
    }
    if (!complete) {
        mfns_pose_solution_clear(out, MFNS_POSE_R_NOT_IDENTIFIED);
        out->hypotheses = hyp16;
        return out->status;
    }
    *out = cand[best].sol;
    out->hypotheses = hyp16;
    return out->status;
}
