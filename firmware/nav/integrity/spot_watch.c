/* spot_watch.c -- what each camera's spots did since its last frame (spot_watch.h). */
#include "firmware/nav/integrity/spot_watch.h"

#include <math.h>
#include <string.h>

#include "math/fixed.h"

void mfns_spot_init(mfns_spot_watch_t *w)
{
    if (w != NULL) {
        memset(w, 0, sizeof(*w));
        for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
            w->jump_px[c] = -1.0f;
        }
    }
}

static bool usable_blob(const mfns_blob_t *b)
{
    return b->reasons == 0U && !b->saturated && isfinite(b->flux_dn) && b->flux_dn > 0.0f;
}

/* How many of (u[j], v[j]) for j < n lie within MFNS_SPOT_MATCH_PX of (x, y);
 * *nearest the closest one's index. */
static unsigned within(const float *u, const float *v, unsigned n, float x, float y, unsigned *nearest)
{
    const float r2 = MFNS_SPOT_MATCH_PX * MFNS_SPOT_MATCH_PX;
    unsigned count = 0U;
    float best = r2;
    for (unsigned j = 0U; j < n; j++) {
        const float du = u[j] - x, dv = v[j] - y;
        const float d2 = du * du + dv * dv;
        if (d2 <= r2) {
            count++;
            if (d2 <= best) {
                best = d2;
                *nearest = j;
            }
        }
    }
    return count;
}

/* The spots' common shift since the last frame: each pairing of one of the
 * MFNS_SPOT_VOTE_SPOTS brightest spots with one of the last frame's proposes
 * a shift (at most MFNS_SPOT_MAX_SHIFT_PX), and the one that brings the
 * most of those spots onto a last-frame spot wins. False when no shift
 * brings MFNS_SPOT_MIN_MATCHED spots together, or another shift (farther
 * than twice the match radius) brings as many: the frames are not compared. */
static bool common_shift(const float *pu, const float *pv, unsigned n_prev, const float *u, const float *v,
                         unsigned n, float *su, float *sv)
{
    const unsigned nc = n < MFNS_SPOT_VOTE_SPOTS ? n : MFNS_SPOT_VOTE_SPOTS;
    const unsigned np = n_prev < MFNS_SPOT_VOTE_SPOTS ? n_prev : MFNS_SPOT_VOTE_SPOTS;
    const float far2 = 4.0f * MFNS_SPOT_MATCH_PX * MFNS_SPOT_MATCH_PX;
    unsigned best = 0U;
    bool tie = false;
    for (unsigned a = 0U; a < nc; a++) {
        for (unsigned b = 0U; b < np; b++) {
            const float ou = u[a] - pu[b], ov = v[a] - pv[b];
            if (ou * ou + ov * ov > MFNS_SPOT_MAX_SHIFT_PX * MFNS_SPOT_MAX_SHIFT_PX) {
                continue;
            }
            unsigned support = 0U;
            for (unsigned i = 0U; i < nc; i++) {
                unsigned j = 0U;
                support += within(pu, pv, np, u[i] - ou, v[i] - ov, &j) > 0U ? 1U : 0U;
            }
            const float du = ou - *su, dv = ov - *sv;
            if (support > best) {
                tie = false;
                best = support;
                *su = ou;
                *sv = ov;
            } else if (support == best && du * du + dv * dv > far2) {
                tie = true;
            }
        }
    }
    return best >= MFNS_SPOT_MIN_MATCHED && !tie;
}

/* This frame's usable spots, the brightest MFNS_SPOT_MAX_BLOBS of them:
 * at most MFNS_SPOT_MAX_BLOBS passes over the result's accepted blobs. */
static unsigned brightest(const mfns_centroid_result_t *r, float u[MFNS_SPOT_MAX_BLOBS], float v[MFNS_SPOT_MAX_BLOBS],
                          float flux[MFNS_SPOT_MAX_BLOBS])
{
    bool taken[MFNS_MAX_BLOBS_PER_CAMERA] = {false};
    const unsigned n_acc = r->n_accepted < MFNS_MAX_BLOBS_PER_CAMERA ? r->n_accepted : MFNS_MAX_BLOBS_PER_CAMERA;
    unsigned n = 0U;
    for (unsigned pass = 0U; pass < MFNS_SPOT_MAX_BLOBS; pass++) {
        int best = -1;
        for (unsigned i = 0U; i < n_acc; i++) {
            if (!taken[i] && usable_blob(&r->blob[i]) &&
                (best < 0 || r->blob[i].flux_dn > r->blob[(unsigned)best].flux_dn)) {
                best = (int)i;
            }
        }
        if (best < 0) {
            break;
        }
        const mfns_blob_t *b = &r->blob[(unsigned)best];
        taken[best] = true;
        u[n] = mfns_px_q8_to_float(b->u_q8);
        v[n] = mfns_px_q8_to_float(b->v_q8);
        flux[n] = b->flux_dn;
        n++;
    }
    return n;
}

static float median_sorted(float *x, unsigned n)
{
    for (unsigned i = 1U; i < n; i++) { /* insertion sort: n <= MFNS_SPOT_MAX_BLOBS */
        const float key = x[i];
        unsigned j = i;
        while (j > 0U && x[j - 1U] > key) {
            x[j] = x[j - 1U];
            j--;
        }
        x[j] = key;
    }
    return (n % 2U) != 0U ? x[n / 2U] : 0.5f * (x[n / 2U - 1U] + x[n / 2U]);
}

/* Is any of this frame's spots within the match radius of where one of the
 * last frame's should be. */
static bool any_in_place(const float *pu, const float *pv, unsigned n_prev, const float *u, const float *v, unsigned n)
{
    for (unsigned i = 0U; i < n; i++) {
        unsigned j = 0U;
        if (within(pu, pv, n_prev, u[i], v[i], &j) > 0U) {
            return true;
        }
    }
    return false;
}

/* The camera's jump: the median over the spots matched in three frames of
 * how far each one's motion changed (< 0: fewer than MFNS_SPOT_MIN_MATCHED).
 * The median of the lengths, not of the vectors: a mount turned about the
 * optical axis moves its spots in every direction (a vector median near 0),
 * each of them by its radius times the angle. */
static float jump_of(const float *au, const float *av, unsigned m)
{
    if (m < MFNS_SPOT_MIN_MATCHED) {
        return -1.0f;
    }
    float len[MFNS_SPOT_MAX_BLOBS];
    for (unsigned i = 0U; i < m; i++) {
        len[i] = sqrtf(au[i] * au[i] + av[i] * av[i]);
    }
    return median_sorted(len, m);
}

/* The response's verdict on the matched pairs' flux ratios: -1, 0, +1. */
static int8_t step_side(float *ratio, unsigned m, float *med)
{
    *med = 0.0f;
    if (m < MFNS_SPOT_MIN_MATCHED) {
        return 0;
    }
    unsigned down = 0U, up = 0U;
    for (unsigned i = 0U; i < m; i++) {
        down += ratio[i] < MFNS_SPOT_STEP_RATIO ? 1U : 0U;
        up += ratio[i] > 1.0f / MFNS_SPOT_STEP_RATIO ? 1U : 0U;
    }
    *med = median_sorted(ratio, m);
    /* three in four on the same side: one spot's own change is not the camera's */
    if (*med < MFNS_SPOT_STEP_RATIO && 4U * down >= 3U * m) {
        return -1;
    }
    if (*med > 1.0f / MFNS_SPOT_STEP_RATIO && 4U * up >= 3U * m) {
        return 1;
    }
    return 0;
}

mfns_spot_status_t mfns_spot_observe(mfns_spot_watch_t *w, int cam, const mfns_centroid_result_t *r,
                                     float response)
{
    if (w == NULL || r == NULL || cam < 0 || cam >= MFNS_NUM_CAMERAS || r->n_accepted > r->n_blobs ||
        r->n_blobs > MFNS_MAX_BLOBS_PER_CAMERA || !isfinite(response) || response < 0.0f) {
        return MFNS_SPOT_E_ARG;
    }
    float u[MFNS_SPOT_MAX_BLOBS], v[MFNS_SPOT_MAX_BLOBS], flux[MFNS_SPOT_MAX_BLOBS];
    float du[MFNS_SPOT_MAX_BLOBS] = {0.0f}, dv[MFNS_SPOT_MAX_BLOBS] = {0.0f}; /* a spot not matched has none */
    uint8_t moved[MFNS_SPOT_MAX_BLOBS] = {0};
    const unsigned n = brightest(r, u, v, flux);
    /* the reported response's change (1 when either is unknown) */
    const float resp_prev = w->response[cam];
    const float expect = (resp_prev > 0.0f && response > 0.0f) ? response / resp_prev : 1.0f;
    const bool consecutive = w->last_cycle[cam] != 0U; /* the remembered motion is one frame's */
    float ratio[MFNS_SPOT_MAX_BLOBS], au[MFNS_SPOT_MAX_BLOBS], av[MFNS_SPOT_MAX_BLOBS];
    unsigned m = 0U, ma = 0U;
    const unsigned n_prev = w->n[cam];
    /* where each remembered spot should be now: moved on by its own motion
     * when that is one frame's (a smooth turn or roll, parallax), else where
     * it was; the common shift is then what the camera did beyond it */
    float pu[MFNS_SPOT_MAX_BLOBS], pv[MFNS_SPOT_MAX_BLOBS];
    unsigned with_motion = 0U;
    for (unsigned j = 0U; j < n_prev; j++) {
        const bool own = consecutive && w->moved[cam][j] != 0U;
        pu[j] = w->u[cam][j] + (own ? w->du[cam][j] : 0.0f);
        pv[j] = w->v[cam][j] + (own ? w->dv[cam][j] : 0.0f);
        with_motion += own ? 1U : 0U;
    }
    float su = 0.0f, sv = 0.0f;
    const bool shifted = common_shift(pu, pv, n_prev, u, v, n, &su, &sv);
    for (unsigned i = 0U; shifted && i < n; i++) {
        unsigned j = 0U, back = 0U;
        if (within(pu, pv, n_prev, u[i] - su, v[i] - sv, &j) != 1U ||
            within(u, v, n, pu[j] + su, pv[j] + sv, &back) != 1U) {
            continue; /* no spot, or an ambiguous one, either way */
        }
        ratio[m++] = flux[i] / (w->flux_dn[cam][j] * expect);
        du[i] = u[i] - w->u[cam][j];
        dv[i] = v[i] - w->v[cam][j];
        moved[i] = 1U;
        if (consecutive && w->moved[cam][j] != 0U) {
            au[ma] = u[i] - pu[j]; /* the change of its motion */
            av[ma] = v[i] - pv[j];
            ma++;
        }
    }
    w->matched[cam] = (uint8_t)m;
    w->side[cam] = step_side(ratio, m, &w->ratio[cam]);
    w->jump_px[cam] = jump_of(au, av, ma);
    if (!shifted && with_motion >= MFNS_SPOT_MIN_MATCHED && n >= 1U && !any_in_place(pu, pv, n_prev, u, v, n)) {
        /* spots that moved smoothly, and now not one spot is where one of
         * them should be, nor does a common change of their motion bring two
         * back: they jumped, but not together (a mount turned about its
         * optical axis, a stream swapped), or all but one left the image */
        w->jump_px[cam] = MFNS_SPOT_UNMATCHED_JUMP_PX;
    }
    w->seen[cam] = 1U;
    for (unsigned i = 0U; i < n; i++) {
        w->u[cam][i] = u[i];
        w->v[cam][i] = v[i];
        w->flux_dn[cam][i] = flux[i];
        w->moved[cam][i] = moved[i];
        w->du[cam][i] = du[i];
        w->dv[cam][i] = dv[i];
    }
    w->n[cam] = (uint8_t)n;
    w->response[cam] = response;
    return MFNS_SPOT_OK;
}

void mfns_spot_evaluate(mfns_spot_watch_t *w, mfns_spot_report_t *rep)
{
    if (rep == NULL) {
        return;
    }
    memset(rep, 0, sizeof(*rep));
    rep->camera = -1;
    rep->jump_camera = -1;
    if (w == NULL) {
        return;
    }
    int stepped = -1;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        if (w->side[c] != 0) {
            rep->common++;
            stepped = c;
        }
        if (w->jump_px[c] > MFNS_SPOT_JUMP_PX) {
            rep->jump_mask = (uint8_t)(rep->jump_mask | (1U << (unsigned)c));
        }
        rep->jump_px = fmaxf(rep->jump_px, w->jump_px[c]);
    }
    if (rep->common == 1U) {
        rep->camera = (int8_t)stepped;
        rep->ratio = w->ratio[stepped];
        rep->matched = w->matched[stepped];
        rep->common = 0U;
    }
    /* a single camera jumped, and another camera's spots were tested smooth */
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        if (rep->jump_mask != (1U << (unsigned)c)) {
            continue;
        }
        float others = -1.0f;
        for (int o = 0; o < MFNS_NUM_CAMERAS; o++) {
            others = o != c ? fmaxf(others, w->jump_px[o]) : others;
        }
        if (others >= 0.0f) {
            rep->jump_camera = (int8_t)c;
            rep->others_px = others;
            rep->jump_new = w->jump_hold[c] == 0U;
        }
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        const bool jumped = (rep->jump_mask & (1U << (unsigned)c)) != 0U;
        w->jump_hold[c] = jumped ? (uint8_t)MFNS_SPOT_EPISODE_CYCLES
                                 : (uint8_t)(w->jump_hold[c] > 0U ? w->jump_hold[c] - 1U : 0U);
        if (w->jump_hold[c] + 1U >= MFNS_SPOT_EPISODE_CYCLES) {
            rep->recent_mask = (uint8_t)(rep->recent_mask | (1U << (unsigned)c));
        }
        w->last_cycle[c] = w->seen[c];
        w->seen[c] = 0U;
        w->side[c] = 0;
        w->matched[c] = 0;
        w->ratio[c] = 0.0f;
        w->jump_px[c] = -1.0f;
    }
}
