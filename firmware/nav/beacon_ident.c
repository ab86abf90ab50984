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

typedef struct {
    const mfns_rig_t *rig;
    const mfns_beacon_map_t *map;
    const mfns_obs_frame_t *frame;
    const mfns_pose_config_t *cfg;
    blob_t blobs[MFNS_POSE_MAX_MEAS];
    int16_t frame_cam_blob[MFNS_NUM_CAMERAS][MFNS_MAX_OBS_PER_CAMERA]; /* blob index of each obs */
    int nb;
    float gate_n[MFNS_NUM_CAMERAS];
    float lo, hi;
    cand_t cand[MAX_CAND];
    int ncand;
    int best;           /* index of the best candidate, -1 none */
    bool overflow;      /* more distinct candidates than MAX_CAND were seen */
    bool complete;      /* a triple of the best's inliers was enumerated */
    bool minimal_rival; /* nb == 3: two consistent poses already seen */
    bool budget_out;
    uint32_t hyp;
} acq_t;

/* Quick verification of a hypothesis pose: does at least one blob outside
 * the triple have a beacon within gate (normalized coordinates, no
 * distortion)? The camera transform of the map is computed once per camera
 * and only for cameras that hold such blobs; the first match ends the test. */
static bool quick_verify(const acq_t *q, const mfns_pose_t *pose, const int tri[3])
{
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        const int nb = q->frame->count[c];
        bool need = false;
        for (int i = 0; i < nb && !need; i++) {
            need = !(q->frame_cam_blob[c][i] == tri[0] || q->frame_cam_blob[c][i] == tri[1] ||
                     q->frame_cam_blob[c][i] == tri[2]);
        }
        if (!need) {
            continue;
        }
        const mfns_camera_t *cam = &q->rig->cam[c];
        const mfns_m3_t m = mfns_m3_mul(mfns_m3_transpose(cam->C_k_b), pose->C_w_b);
        const mfns_v3_t t = mfns_m3_tmul_v3(cam->C_k_b, mfns_v3_sub(pose->r_bw_b, cam->r_bk_b));
        float bx[MFNS_MAX_BEACONS], by[MFNS_MAX_BEACONS];
        int nv = 0;
        for (int b = 0; b < q->map->count; b++) {
            const mfns_v3_t p = mfns_v3_add(mfns_m3_mul_v3(m, q->map->beacon[b].p_w), t);
            if (p.z >= MFNS_CAM_MIN_DEPTH_MM) {
                bx[nv] = p.x / p.z;
                by[nv] = p.y / p.z;
                nv++;
            }
        }
        const float g2 = q->gate_n[c] * q->gate_n[c];
        for (int i = 0; i < nb; i++) {
            const int bi = q->frame_cam_blob[c][i];
            if (bi == tri[0] || bi == tri[1] || bi == tri[2]) {
                continue;
            }
            for (int k = 0; k < nv; k++) {
                const float dx = bx[k] - q->frame->obs[c][i].x, dy = by[k] - q->frame->obs[c][i].y;
                if (dx * dx + dy * dy <= g2) {
                    return true;
                }
            }
        }
    }
    return false;
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
/* A pose from three rays carries their noise amplified by the geometry
 * (tens of times near the "danger cylinder"): measured, a right minimal pose
 * at 0.3 px noise predicted a fourth beacon 16 px off, the tracking gate
 * dropped it, and a wrong pose that fitted all four blobs at 1.4 sigma was
 * reported unique. The verification therefore associates the minimal pose
 * within this multiple of the tracking gate; the refined pose is then
 * associated again with the tracking gate itself. */
#define MINIMAL_GATE_FACTOR 4.0f


static void add_candidate(acq_t *q, const cand_t *cd)
{
    for (int i = 0; i < q->ncand; i++) {
        if (same_assoc(&q->cand[i].sol, &cd->sol, q->frame) &&
            (q->nb > 3 || same_pose(&q->cand[i].sol.pose, &cd->sol.pose))) {
            return;
        }
    }
    if (q->ncand < MAX_CAND) {
        q->cand[q->ncand++] = *cd;
    } else {
        q->overflow = true;
        int worst = 0;
        for (int i = 1; i < q->ncand; i++) {
            if (q->cand[i].score < q->cand[worst].score ||
                (q->cand[i].score == q->cand[worst].score && q->cand[i].missing > q->cand[worst].missing)) {
                worst = i;
            }
        }
        if (cd->score > q->cand[worst].score ||
            (cd->score == q->cand[worst].score && cd->missing < q->cand[worst].missing)) {
            q->cand[worst] = *cd;
        }
    }
    q->best = 0;
    int consistent = 0;
    for (int i = 0; i < q->ncand; i++) {
        const cand_t *a = &q->cand[i], *b = &q->cand[q->best];
        if (a->score > b->score || (a->score == b->score && a->missing < b->missing)) {
            q->best = i;
        }
        consistent += a->missing == 0 ? 1 : 0;
    }
    if (q->nb == 3 && consistent >= 2) {
        q->minimal_rival = true;
    }
}

/* Upper 1e-5 quantiles of chi-square with k = 1..16 degrees of freedom. */
static const float chi2_q[16] = {19.51f, 23.03f, 25.90f, 28.47f, 30.86f, 33.11f, 35.26f, 37.33f,
                                 39.34f, 41.30f, 43.21f, 45.08f, 46.91f, 48.72f, 50.49f, 52.24f};

/* A candidate explains its blobs only if its residual is plausible under
 * the pixel noise: sum of (r/sigma)^2 below the chi-square quantile with
 * 2n - 6 degrees of freedom at 1e-5 (a right pose fails once in 1e5; a rival
 * correspondence that fits "nearly" is rejected instead of making the
 * answer ambiguous). Beyond the table: Wilson-Hilferty, z = 4.265. */
static bool chi2_consistent(const mfns_pose_solution_t *sol, float sigma)
{
    const int dof = 2 * (int)sol->beacons_used - 6;
    if (dof <= 0) {
        return true;
    }
    const float chi2 = 2.0f * (float)sol->beacons_used * (sol->residual_rms_px / sigma) * (sol->residual_rms_px / sigma);
    float q;
    if (dof <= 16) {
        q = chi2_q[dof - 1];
    } else {
        const float a = 2.0f / (9.0f * (float)dof);
        const float b = 1.0f - a + 4.265f * sqrtf(a);
        q = (float)dof * b * b * b;
    }
    return chi2 <= q;
}

/* Verify one gP3P pose: associate in pixels, refine, score. */
static void verify(acq_t *q, const mfns_pose_t *pose, const int tri[3])
{
    if (q->nb > 3 && !quick_verify(q, pose, tri)) {
        return;
    }
    cand_t cd;
    memset(&cd, 0, sizeof(cd));
    const int need = q->nb > 3 ? 4 : 3;
    if (mfns_pose_associate(q->rig, q->map, q->frame, pose, MINIMAL_GATE_FACTOR * q->cfg->s.track_gate_px,
                            &cd.sol.assoc) < need) {
        return;
    }
    mfns_pose_meas_t m[MFNS_POSE_MAX_MEAS];
    const int n = mfns_pose_gather(q->map, q->frame, &cd.sol.assoc, m);
    if (n < 0 || mfns_pose_refine_meas(q->rig, m, n, pose, q->cfg, &cd.sol) == MFNS_POSE_NO_FIX) {
        return;
    }
    /* The minimal pose predicts the other beacons only roughly (noise on
     * three blobs, amplified by their geometry): associate again from the
     * refined pose, with the tracking gate and then a wider one, and keep a
     * re-solve that explains more blobs and still passes the chi-square test. */
    for (int round = 0; round < 2; round++) {
        const float gate = q->cfg->s.track_gate_px * (round == 0 ? 1.0f : 4.0f);
        mfns_pose_assoc_t again;
        if (mfns_pose_associate(q->rig, q->map, q->frame, &cd.sol.pose, gate, &again) <= cd.sol.beacons_used) {
            continue;
        }
        cand_t cd2;
        memset(&cd2, 0, sizeof(cd2));
        cd2.sol.assoc = again;
        const int n2 = mfns_pose_gather(q->map, q->frame, &again, m);
        if (n2 >= 0 && mfns_pose_refine_meas(q->rig, m, n2, &cd.sol.pose, q->cfg, &cd2.sol) != MFNS_POSE_NO_FIX &&
            cd2.sol.beacons_used > cd.sol.beacons_used && chi2_consistent(&cd2.sol, q->cfg->sigma_px)) {
            cd = cd2;
        }
    }
    /* with four or more blobs a fix needs a redundant (checked) solve */
    if (q->nb > 3 && cd.sol.beacons_used < 4) {
        return;
    }
    if (!chi2_consistent(&cd.sol, q->cfg->sigma_px)) {
        return;
    }
    cd.score = cd.sol.beacons_used;
    cd.missing = count_missing(q->rig, q->map, q->frame, &cd.sol);
    add_candidate(q, &cd);
}

/* Every ordered beacon triple for the blob triple (i, j, k), pruned by the
 * reachable pair distances. */
static void try_triple(acq_t *q, int i, int j, int k)
{
    const blob_t *t[3] = {&q->blobs[i], &q->blobs[j], &q->blobs[k]};
    const int tri[3] = {i, j, k};
    static const float slack = 1.001f;
    const float d12max = ray_pair_dmax(t[0], t[1], q->lo, q->hi) * slack;
    const float d13max = ray_pair_dmax(t[0], t[2], q->lo, q->hi) * slack;
    const float d23max = ray_pair_dmax(t[1], t[2], q->lo, q->hi) * slack;
    const mfns_v3_t rc[3] = {t[0]->c, t[1]->c, t[2]->c};
    const mfns_v3_t rd[3] = {t[0]->d, t[1]->d, t[2]->d};
    const mfns_beacon_map_t *map = q->map;
    for (int a = 0; a < map->count; a++) {
        for (int b = 0; b < map->count; b++) {
            if (b == a || mfns_v3_norm(mfns_v3_sub(map->beacon[a].p_w, map->beacon[b].p_w)) > d12max) {
                continue;
            }
            for (int c = 0; c < map->count; c++) {
                if (c == a || c == b || mfns_v3_norm(mfns_v3_sub(map->beacon[a].p_w, map->beacon[c].p_w)) > d13max ||
                    mfns_v3_norm(mfns_v3_sub(map->beacon[b].p_w, map->beacon[c].p_w)) > d23max) {
                    continue;
                }
                if (q->hyp >= q->cfg->s.max_hypotheses) {
                    q->budget_out = true;
                    return;
                }
                q->hyp++;
                const mfns_v3_t xw[3] = {map->beacon[a].p_w, map->beacon[b].p_w, map->beacon[c].p_w};
                mfns_pose_t sols[MFNS_GP3P_MAX_SOLUTIONS];
                const int ns = mfns_gp3p(rc, rd, xw, q->lo, q->hi, sols);
                for (int s = 0; s < ns; s++) {
                    verify(q, &sols[s], tri);
                }
                if (q->minimal_rival) {
                    return;
                }
            }
        }
    }
    if (q->best >= 0 && (q->nb == 3 || q->cand[q->best].score >= 4) && triple_in_inliers(t, &q->cand[q->best].sol)) {
        q->complete = true;
    }
}

static bool search_over(const acq_t *q) { return q->complete || q->budget_out || q->minimal_rival; }

/* The triple tried first, chosen for the conditioning of its minimal pose
 * (a pose from three rays bunched together predicts the other beacons
 * poorly, the quick verification then misses the right hypothesis and the
 * search has to go on to a second triple): the pair with the widest angle
 * in the camera with the most blobs, and the blob of another camera with the
 * widest smallest angle to both; with one camera, its widest third blob. */
static void first_triple(const acq_t *q, int tri[3])
{
    int cm = 0;
    for (int c = 1; c < MFNS_NUM_CAMERAS; c++) {
        if (q->frame->count[c] > q->frame->count[cm]) {
            cm = c;
        }
    }
    tri[0] = 0;
    tri[1] = 1;
    tri[2] = 2;
    const int n = q->frame->count[cm];
    if (n < 2) {
        return;
    }
    float best = 2.0f;
    for (int i = 0; i < n; i++) {
        for (int j = i + 1; j < n; j++) {
            const int bi = q->frame_cam_blob[cm][i], bj = q->frame_cam_blob[cm][j];
            const float cs = mfns_v3_dot(q->blobs[bi].d, q->blobs[bj].d);
            if (cs < best) {
                best = cs;
                tri[0] = bi;
                tri[1] = bj;
            }
        }
    }
    /* third: smallest largest cosine to the pair, other cameras first */
    int third = -1;
    float best3 = 2.0f;
    for (int pass = 0; pass < 2 && third < 0; pass++) {
        for (int b = 0; b < q->nb; b++) {
            if (b == tri[0] || b == tri[1] || (pass == 0) == (q->blobs[b].cam == cm)) {
                continue;
            }
            const float c0 = mfns_v3_dot(q->blobs[b].d, q->blobs[tri[0]].d);
            const float c1 = mfns_v3_dot(q->blobs[b].d, q->blobs[tri[1]].d);
            const float cs = c0 > c1 ? c0 : c1;
            if (cs < best3) {
                best3 = cs;
                third = b;
            }
        }
    }
    tri[2] = third;
    /* ascending, as the lexicographic loop expects */
    for (int a = 0; a < 2; a++) {
        for (int b = 0; b < 2 - a; b++) {
            if (tri[b] > tri[b + 1]) {
                const int x = tri[b];
                tri[b] = tri[b + 1];
                tri[b + 1] = x;
            }
        }
    }
}

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
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        if (frame->count[c] > MFNS_MAX_OBS_PER_CAMERA) {
            return out->status;
        }
    }
    /* the search state is large (candidates hold full solutions): static, so
     * the stack stays small on the target; the core is single-threaded */
    static acq_t q;
    memset(&q, 0, sizeof(q));
    q.rig = rig;
    q.map = map;
    q.frame = frame;
    q.cfg = cfg;
    q.best = -1;
    /* round-robin over cameras */
    for (int i = 0; i < MFNS_MAX_OBS_PER_CAMERA; i++) {
        for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
            if (i < frame->count[c]) {
                const mfns_obs_t *o = &frame->obs[c][i];
                if (!isfinite(o->u) || !isfinite(o->v) || !isfinite(o->x) || !isfinite(o->y)) {
                    return out->status;
                }
                q.blobs[q.nb].cam = (uint8_t)c;
                q.blobs[q.nb].idx = (uint8_t)i;
                q.frame_cam_blob[c][i] = (int16_t)q.nb;
                mfns_pose_ray(&rig->cam[c], o->x, o->y, &q.blobs[q.nb].c, &q.blobs[q.nb].d);
                q.nb++;
            }
        }
    }
    if (q.nb < 3 || map->count < 3) {
        out->reason = MFNS_POSE_R_TOO_FEW;
        return out->status;
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        q.gate_n[c] = MINIMAL_GATE_FACTOR * cfg->s.track_gate_px / rig->cam[c].k.fx;
    }
    q.lo = MIN_RANGE_MM;
    q.hi = cfg->max_range_mm;

    int first[3];
    first_triple(&q, first);
    try_triple(&q, first[0], first[1], first[2]);
    for (int i = 0; i < q.nb - 2 && !search_over(&q); i++) {
        for (int j = i + 1; j < q.nb - 1 && !search_over(&q); j++) {
            for (int k = j + 1; k < q.nb && !search_over(&q); k++) {
                if (i != first[0] || j != first[1] || k != first[2]) {
                    try_triple(&q, i, j, k);
                }
            }
        }
    }
    const uint16_t hyp16 = (uint16_t)(q.hyp > 0xFFFFu ? 0xFFFFu : q.hyp);
    mfns_pose_reason_t reason = MFNS_POSE_R_NONE;
    if (q.best < 0) {
        reason = MFNS_POSE_R_NOT_IDENTIFIED;
    } else {
        int rivals = 0;
        for (int i = 0; i < q.ncand; i++) {
            if (i != q.best && q.cand[i].score == q.cand[q.best].score &&
                q.cand[i].missing == q.cand[q.best].missing) {
                rivals++;
            }
        }
        if (rivals > 0 || q.minimal_rival || (q.overflow && q.cand[q.best].score <= 3)) {
            reason = MFNS_POSE_R_AMBIGUOUS;
        } else if (!q.complete) {
            /* the bound stopped the search before uniqueness was established */
            reason = MFNS_POSE_R_NOT_IDENTIFIED;
        }
    }
    if (reason != MFNS_POSE_R_NONE) {
        mfns_pose_solution_clear(out, reason);
    } else {
        *out = q.cand[q.best].sol;
    }
    out->hypotheses = hyp16;
    return out->status;
}
