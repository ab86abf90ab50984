/* response_watch.c -- a camera whose photometric response steps (response_watch.h). */
#include "firmware/nav/integrity/response_watch.h"

#include <math.h>
#include <string.h>

#include "math/fixed.h"

void mfns_resp_init(mfns_resp_watch_t *w)
{
    if (w != NULL) {
        memset(w, 0, sizeof(*w));
    }
}

static bool usable_blob(const mfns_blob_t *b)
{
    return b->reasons == 0U && !b->saturated && isfinite(b->flux_dn) && b->flux_dn > 0.0f;
}

/* How many of (u[j], v[j]) for j < n lie within MFNS_RESP_MATCH_PX of (x, y);
 * *nearest the closest one's index. */
static unsigned within(const float *u, const float *v, unsigned n, float x, float y, unsigned *nearest)
{
    const float r2 = MFNS_RESP_MATCH_PX * MFNS_RESP_MATCH_PX;
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
 * MFNS_RESP_VOTE_SPOTS brightest spots with one of the last frame's proposes
 * a shift (at most MFNS_RESP_MAX_SHIFT_PX), and the one that brings the
 * most of those spots onto a last-frame spot wins. False when no shift
 * brings MFNS_RESP_MIN_MATCHED spots together, or another shift (farther
 * than twice the match radius) brings as many: the frames are not compared. */
static bool common_shift(const float *pu, const float *pv, unsigned n_prev, const float *u, const float *v,
                         unsigned n, float *su, float *sv)
{
    const unsigned nc = n < MFNS_RESP_VOTE_SPOTS ? n : MFNS_RESP_VOTE_SPOTS;
    const unsigned np = n_prev < MFNS_RESP_VOTE_SPOTS ? n_prev : MFNS_RESP_VOTE_SPOTS;
    const float far2 = 4.0f * MFNS_RESP_MATCH_PX * MFNS_RESP_MATCH_PX;
    unsigned best = 0U;
    bool tie = false;
    for (unsigned a = 0U; a < nc; a++) {
        for (unsigned b = 0U; b < np; b++) {
            const float ou = u[a] - pu[b], ov = v[a] - pv[b];
            if (ou * ou + ov * ov > MFNS_RESP_MAX_SHIFT_PX * MFNS_RESP_MAX_SHIFT_PX) {
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
    return best >= MFNS_RESP_MIN_MATCHED && !tie;
}

/* This frame's usable spots, the brightest MFNS_RESP_MAX_BLOBS of them:
 * at most MFNS_RESP_MAX_BLOBS passes over the result's accepted blobs. */
static unsigned brightest(const mfns_centroid_result_t *r, float u[MFNS_RESP_MAX_BLOBS], float v[MFNS_RESP_MAX_BLOBS],
                          float flux[MFNS_RESP_MAX_BLOBS])
{
    bool taken[MFNS_MAX_BLOBS_PER_CAMERA] = {false};
    const unsigned n_acc = r->n_accepted < MFNS_MAX_BLOBS_PER_CAMERA ? r->n_accepted : MFNS_MAX_BLOBS_PER_CAMERA;
    unsigned n = 0U;
    for (unsigned pass = 0U; pass < MFNS_RESP_MAX_BLOBS; pass++) {
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
    for (unsigned i = 1U; i < n; i++) { /* insertion sort: n <= MFNS_RESP_MAX_BLOBS */
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

mfns_resp_status_t mfns_resp_observe(mfns_resp_watch_t *w, int cam, const mfns_centroid_result_t *r,
                                     float response)
{
    if (w == NULL || r == NULL || cam < 0 || cam >= MFNS_NUM_CAMERAS || r->n_accepted > r->n_blobs ||
        r->n_blobs > MFNS_MAX_BLOBS_PER_CAMERA || !isfinite(response) || response < 0.0f) {
        return MFNS_RESP_E_ARG;
    }
    float u[MFNS_RESP_MAX_BLOBS], v[MFNS_RESP_MAX_BLOBS], flux[MFNS_RESP_MAX_BLOBS];
    const unsigned n = brightest(r, u, v, flux);
    /* the reported response's change (1 when either is unknown) */
    const float resp_prev = w->response[cam];
    const float expect = (resp_prev > 0.0f && response > 0.0f) ? response / resp_prev : 1.0f;
    float ratio[MFNS_RESP_MAX_BLOBS];
    unsigned m = 0U;
    const unsigned n_prev = w->n[cam];
    float su = 0.0f, sv = 0.0f;
    const bool shifted = common_shift(w->u[cam], w->v[cam], n_prev, u, v, n, &su, &sv);
    for (unsigned i = 0U; shifted && i < n; i++) {
        unsigned j = 0U, back = 0U;
        if (within(w->u[cam], w->v[cam], n_prev, u[i] - su, v[i] - sv, &j) != 1U ||
            within(u, v, n, w->u[cam][j] + su, w->v[cam][j] + sv, &back) != 1U) {
            continue; /* no spot, or an ambiguous one, either way */
        }
        ratio[m++] = flux[i] / (w->flux_dn[cam][j] * expect);
    }
    w->matched[cam] = (uint8_t)m;
    w->ratio[cam] = 0.0f;
    w->side[cam] = 0;
    if (m >= MFNS_RESP_MIN_MATCHED) {
        unsigned down = 0U, up = 0U;
        for (unsigned i = 0U; i < m; i++) {
            down += ratio[i] < MFNS_RESP_STEP_RATIO ? 1U : 0U;
            up += ratio[i] > 1.0f / MFNS_RESP_STEP_RATIO ? 1U : 0U;
        }
        const float med = median_sorted(ratio, m);
        w->ratio[cam] = med;
        /* three in four on the same side: one spot's own change is not the camera's */
        if (med < MFNS_RESP_STEP_RATIO && 4U * down >= 3U * m) {
            w->side[cam] = -1;
        } else if (med > 1.0f / MFNS_RESP_STEP_RATIO && 4U * up >= 3U * m) {
            w->side[cam] = 1;
        }
    }
    memcpy(w->u[cam], u, n * sizeof u[0]);
    memcpy(w->v[cam], v, n * sizeof v[0]);
    memcpy(w->flux_dn[cam], flux, n * sizeof flux[0]);
    w->n[cam] = (uint8_t)n;
    w->response[cam] = response;
    return MFNS_RESP_OK;
}

void mfns_resp_evaluate(mfns_resp_watch_t *w, mfns_resp_report_t *rep)
{
    if (rep == NULL) {
        return;
    }
    memset(rep, 0, sizeof(*rep));
    rep->camera = -1;
    if (w == NULL) {
        return;
    }
    int stepped = -1;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        if (w->side[c] != 0) {
            rep->common++;
            stepped = c;
        }
    }
    if (rep->common == 1U) {
        rep->camera = (int8_t)stepped;
        rep->ratio = w->ratio[stepped];
        rep->matched = w->matched[stepped];
        rep->common = 0U;
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        w->side[c] = 0;
        w->matched[c] = 0;
        w->ratio[c] = 0.0f;
    }
}
