/* centroid_label.c -- threshold scan and labelling (centroid_internal.h):
 * runs of pixels >= T found a word at a time, joined into 8-connected blobs
 * by union-find over provisional labels in one pass, each blob's moment sums
 * accumulated at its root label as it grows (docs/centroiding.md). */
#include <string.h>

#include "firmware/nav/centroid/centroid.h"
#include "firmware/nav/centroid/centroid_internal.h"

/* Threshold scan: skip pixels below T a word (8 bytes) at a time.
 * Exact per-lane compare without carries between lanes (lanes of B bits,
 * H = top bit of each lane, L = the other bits): for T < 2^(B-1)
 *   v >= T  <=>  top(v) | top((v & L) + (2^(B-1) - T))
 * and for T >= 2^(B-1)
 *   v >= T  <=>  top(v) & top((v & L) + (2^(B-1) - (T - 2^(B-1)))).
 * (v & L) + c < 2^B, so no lane carries into the next. */
#define H8 0x8080808080808080ull
#define L8 0x7F7F7F7F7F7F7F7Full
#define H16 0x8000800080008000ull
#define L16 0x7FFF7FFF7FFF7FFFull

static inline uint64_t load64(const uint8_t *p)
{
    uint64_t w;
    memcpy(&w, p, sizeof w);
    return w;
}

/* The word test: the top bit of each lane whose pixel is >= T. c holds
 * 2^(B-1) - (T mod 2^(B-1)) in every lane; low: T < 2^(B-1) (the first form). */
static inline uint64_t word_ge(uint64_t w, uint64_t c, bool wide, bool low)
{
    const uint64_t h = wide ? H16 : H8, l = wide ? L16 : L8;
    const uint64_t s = (w & l) + c;
    return (low ? (s | w) : (s & w)) & h;
}

/* Blocks of 256 bytes for the first stage of the scan (find_candidate). */
#define BLOCK_BYTES 256u

/* Whether a block may hold a pixel >= T: its lane-wise maximum, 16 bytes
 * wide (the inner loop is one vector max per 16 bytes: compilers vectorize it
 * at -O2), tested with the word test instead of a horizontal reduction (which
 * cost as much as the block's loads). One function per width: the maximum
 * stays in a vector register only where no other path writes it. */
static bool block_may_hold_u8(const uint8_t *p, uint64_t c, bool low)
{
    uint8_t m[16];
    memcpy(m, p, 16u);
    for (uint32_t i = 16u; i < BLOCK_BYTES; i += 16u) {
        for (uint32_t j = 0; j < 16u; j++) {
            m[j] = p[i + j] > m[j] ? p[i + j] : m[j];
        }
    }
    return (word_ge(load64(m), c, false, low) | word_ge(load64(m + 8), c, false, low)) != 0u;
}

static bool block_may_hold_u16(const uint8_t *p, uint64_t c, bool low)
{
    uint16_t m[8];
    memcpy(m, p, 16u);
    for (uint32_t i = 16u; i < BLOCK_BYTES; i += 16u) {
        uint16_t v[8];
        memcpy(v, p + i, 16u);
        for (uint32_t j = 0; j < 8u; j++) {
            m[j] = v[j] > m[j] ? v[j] : m[j];
        }
    }
    uint64_t w[2];
    memcpy(w, m, 16u);
    return (word_ge(w[0], c, true, low) | word_ge(w[1], c, true, low)) != 0u;
}

/* First x in [x, end) with pixel >= T (or end), for the background-dominated
 * bulk of a frame. Two stages: the lane-wise maximum over a block (a plain
 * loop that compilers turn into vector max instructions: SSE2 pmaxub on
 * x86-64, NEON umax on aarch64, a scalar loop on a Cortex-M) tested with the
 * word test, then, inside a block that holds a candidate, the exact 8-byte word
 * test, which stops within a word of the first pixel >= T.
 * One function for the four scans (two widths, two forms of the word test):
 * mfns_centroid_label_region passes wide and low as constants, so a build for speed (-O2, the
 * host) inlines four specialised copies with a tight block loop (the form
 * chosen at run time inside the loop made the bench's scan ~30 % slower,
 * measured), and a build for size (-Os, the Cortex-M7 board) keeps one copy. */
static inline uint32_t find_candidate(const uint8_t *row, uint32_t x, uint32_t end, uint64_t c, bool wide, bool low)
{
    const uint32_t shift = wide ? 1u : 0u; /* log2 of the bytes per pixel */
    const uint32_t per_word = 8u >> shift, per_block = BLOCK_BYTES >> shift;
    while (x + per_block <= end) {
        const uint8_t *p = row + ((size_t)x << shift);
        if (wide ? block_may_hold_u16(p, c, low) : block_may_hold_u8(p, c, low)) {
            break;
        }
        x += per_block;
    }
    while (x + per_word <= end) {
        if (word_ge(load64(row + ((size_t)x << shift)), c, wide, low) != 0u) {
            break;
        }
        x += per_word;
    }
    return x;
}

/* ------------------------------------------------------------------------ */
/* Labels: union-find over provisional labels, accumulators at the roots
 * (mfns_centroid_labels_t, centroid_internal.h). */

static uint16_t find_root(const mfns_centroid_labels_t *ls, uint16_t l)
{
    uint16_t *parent = ls->w->parent;
    for (uint32_t i = 0; i < MFNS_CENTROID_MAX_LABELS && parent[l] != l; i++) {
        parent[l] = parent[parent[l]]; /* path halving */
        l = parent[l];
    }
    return l;
}

static uint32_t sat_add_u32(uint32_t a, uint32_t b)
{
    return (a > UINT32_MAX - b) ? UINT32_MAX : a + b;
}

/* Merge root b into root a (a < b keeps the older label as root). */
static uint16_t unite(mfns_centroid_labels_t *ls, uint16_t a, uint16_t b)
{
    if (a > b) {
        const uint16_t t = a;
        a = b;
        b = t;
    }
    mfns_centroid_acc_t *A = &ls->w->acc[a];
    const mfns_centroid_acc_t *B = &ls->w->acc[b];
    A->area = sat_add_u32(A->area, B->area);
    if (A->moments_capped || B->moments_capped || A->moment_area + B->moment_area > MFNS_CENTROID_MOMENT_AREA_CAP) {
        A->moments_capped = true;
    } else {
        A->moment_area += B->moment_area;
        for (size_t k = 0; k < sizeof A->sums / sizeof A->sums[0]; k++) {
            A->sums[k] += B->sums[k];
        }
    }
    A->peak = A->peak > B->peak ? A->peak : B->peak;
    A->x_min = A->x_min < B->x_min ? A->x_min : B->x_min;
    A->y_min = A->y_min < B->y_min ? A->y_min : B->y_min;
    A->x_max = A->x_max > B->x_max ? A->x_max : B->x_max;
    A->y_max = A->y_max > B->y_max ? A->y_max : B->y_max;
    A->incomplete = A->incomplete || B->incomplete;
    ls->w->parent[b] = a;
    return a;
}

typedef struct {
    uint32_t s_i;
    uint64_t s_ix, s_ixx;
    uint32_t peak;
} run_sums_t;

static void add_run(mfns_centroid_acc_t *a, uint32_t y, uint32_t x0, uint32_t x1, const run_sums_t *rs)
{
    const uint32_t len = x1 - x0 + 1u;
    a->area = sat_add_u32(a->area, len);
    if (rs->peak > a->peak) {
        a->peak = (uint16_t)rs->peak;
    }
    a->x_min = x0 < a->x_min ? (uint16_t)x0 : a->x_min;
    a->x_max = x1 > a->x_max ? (uint16_t)x1 : a->x_max;
    a->y_max = (uint16_t)y; /* rows arrive in order; y_min set at creation */
    if (a->moments_capped || a->moment_area + len > MFNS_CENTROID_MOMENT_AREA_CAP) {
        a->moments_capped = true;
        return;
    }
    a->moment_area += len;
    const uint64_t yy = (uint64_t)y * y;
    /* sum of x and x^2 over x0..x1 in closed form */
    const uint64_t sx = ((uint64_t)x0 + x1) * len / 2u;
    const uint64_t sxx_hi = (uint64_t)x1 * (x1 + 1u) * (2u * (uint64_t)x1 + 1u) / 6u;
    const uint64_t sxx_lo = x0 > 0u ? (uint64_t)(x0 - 1u) * x0 * (2u * (uint64_t)x0 - 1u) / 6u : 0u;
    a->s_i += rs->s_i;
    a->s_ix += rs->s_ix;
    a->s_iy += (uint64_t)y * rs->s_i;
    a->s_ixx += rs->s_ixx;
    a->s_iyy += yy * rs->s_i;
    a->s_ixy += (uint64_t)y * rs->s_ix;
    a->s_x += sx;
    a->s_y += (uint64_t)y * len;
    a->s_xx += sxx_hi - sxx_lo;
    a->s_yy += yy * len;
    a->s_xy += (uint64_t)y * sx;
}

/* Connect run [x0, x1] of row y to the previous row's runs (8-connectivity:
 * overlap after widening by one pixel) and return its label. *j is the first
 * previous run that may still touch this or a later run of the row. */
static uint16_t label_run(mfns_centroid_labels_t *ls, const mfns_centroid_run_t *prev, uint32_t np, uint32_t *j,
                          uint32_t y, uint32_t x0, uint32_t x1, const run_sums_t *rs, uint8_t roi)
{
    while (*j < np && (uint32_t)prev[*j].x1 + 1u < x0) {
        (*j)++;
    }
    uint16_t lbl = MFNS_CENTROID_LABEL_DROPPED;
    bool touches_dropped = false;
    for (uint32_t k = *j; k < np && prev[k].x0 <= x1 + 1u; k++) {
        if (prev[k].label == MFNS_CENTROID_LABEL_DROPPED) {
            touches_dropped = true;
            continue;
        }
        const uint16_t r = find_root(ls, prev[k].label);
        lbl = (lbl == MFNS_CENTROID_LABEL_DROPPED) ? r : (r == lbl ? lbl : unite(ls, lbl, r));
    }
    if (lbl == MFNS_CENTROID_LABEL_DROPPED) {
        if (touches_dropped || ls->n_labels >= MFNS_CENTROID_MAX_LABELS) {
            ls->n_lost++;
            return MFNS_CENTROID_LABEL_DROPPED;
        }
        lbl = (uint16_t)ls->n_labels++;
        mfns_centroid_acc_t *a = &ls->w->acc[lbl];
        memset(a, 0, sizeof *a);
        a->x_min = (uint16_t)x0;
        a->x_max = (uint16_t)x1;
        a->y_min = (uint16_t)y;
        a->y_max = (uint16_t)y;
        a->roi = roi;
        ls->w->parent[lbl] = lbl;
    }
    mfns_centroid_acc_t *a = &ls->w->acc[lbl];
    a->incomplete = a->incomplete || touches_dropped;
    add_run(a, y, x0, x1, rs);
    return lbl;
}

/* One region in one pass: scan each row for runs of pixels >= T, label them
 * against the previous row's runs. */
void mfns_centroid_label_region(mfns_centroid_labels_t *ls, const mfns_frame_t *f, const mfns_centroid_region_t *rg,
                                uint32_t T, uint8_t roi)
{
    const bool wide = mfns_centroid_format_bits(f->format) > 8u;
    const uint32_t top = wide ? 0x8000u : 0x80u;
    const bool low = T < top;
    const uint64_t lanes = wide ? 0x0001000100010001ull : 0x0101010101010101ull;
    const uint64_t c = (uint64_t)(top - (T & (top - 1u))) * lanes;
    mfns_centroid_run_t *prev = ls->w->runs[0], *cur = ls->w->runs[1];
    uint32_t np = 0;
    for (uint32_t y = rg->y0; y < rg->y1; y++) {
        const uint8_t *row = mfns_centroid_row(f, y);
        uint32_t nc = 0, j = 0, x = rg->x0;
        while (x < rg->x1) {
            /* constants at each call: find_candidate's comment says why */
            if (wide) {
                x = low ? find_candidate(row, x, rg->x1, c, true, true) : find_candidate(row, x, rg->x1, c, true, false);
            } else {
                x = low ? find_candidate(row, x, rg->x1, c, false, true) : find_candidate(row, x, rg->x1, c, false, false);
            }
            /* the word test found a candidate within the next word(s), or the tail */
            while (x < rg->x1 && mfns_centroid_pixel(row, x, wide) < T) {
                x++;
            }
            if (x >= rg->x1) {
                break;
            }
            const uint32_t x0 = x;
            run_sums_t rs = {0u, 0u, 0u, 0u};
            for (; x < rg->x1; x++) {
                const uint32_t v = mfns_centroid_pixel(row, x, wide);
                if (v < T) {
                    break;
                }
                rs.s_i += v;
                rs.s_ix += (uint64_t)v * x;
                rs.s_ixx += (uint64_t)v * x * x;
                rs.peak = v > rs.peak ? v : rs.peak;
            }
            const uint16_t lbl = label_run(ls, prev, np, &j, y, x0, x - 1u, &rs, roi);
            /* nc < MFNS_CENTROID_MAX_RUNS: runs are separated by a pixel */
            cur[nc++] = (mfns_centroid_run_t){(uint16_t)x0, (uint16_t)(x - 1u), lbl};
        }
        mfns_centroid_run_t *t = prev;
        prev = cur;
        cur = t;
        np = nc;
    }
}
