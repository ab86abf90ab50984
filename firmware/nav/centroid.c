/* centroid.c -- beacon centroiding (centroid.h, docs/centroiding.md). */
#include "centroid.h"

#include <math.h>
#include <string.h>

#define LABEL_DROPPED 0xFFFFu /* a run that found no free label */

/* The per-blob refinement stays out of line: inlined into the detect call it
 * changes the code generated for the frame scan (measured: ~25 % slower). */
#if defined(__GNUC__)
#define CENTROID_NOINLINE __attribute__((noinline))
#else
#define CENTROID_NOINLINE
#endif

const char *mfns_centroid_strerror(mfns_centroid_status_t s)
{
    switch (s) {
    case MFNS_CENTROID_OK:
        return "ok";
    case MFNS_CENTROID_TABLE_FULL:
        return "more blobs than the blob/label tables hold: result incomplete";
    case MFNS_CENTROID_ERR_NULL:
        return "a required pointer is NULL";
    case MFNS_CENTROID_ERR_SIZE:
        return "frame width or height is 0 or larger than MFNS_CENTROID_MAX_DIM";
    case MFNS_CENTROID_ERR_STRIDE:
        return "frame stride smaller than a row or not a whole number of pixels";
    case MFNS_CENTROID_ERR_FORMAT:
        return "unsupported pixel format (GREY, Y10, Y12, Y16 only)";
    case MFNS_CENTROID_ERR_SETTINGS:
        return "centroid settings out of range";
    case MFNS_CENTROID_ERR_ROI:
        return "window empty, outside the frame, overlapping another, or too many windows";
    case MFNS_CENTROID_ERR_BACKGROUND:
        return "background or noise estimate not finite, negative or beyond the pixel format";
    default:
        return "unknown centroid status";
    }
}

const char *mfns_blob_reason_name(uint16_t reason_bit)
{
    switch (reason_bit) {
    case MFNS_BLOB_TOO_SMALL:
        return "too small";
    case MFNS_BLOB_TOO_LARGE:
        return "too large";
    case MFNS_BLOB_SATURATED:
        return "saturated";
    case MFNS_BLOB_IMAGE_BORDER:
        return "touches image border";
    case MFNS_BLOB_ROI_BORDER:
        return "touches window border";
    case MFNS_BLOB_ELONGATED:
        return "elongated";
    case MFNS_BLOB_TABLE_FULL:
        return "incomplete: label table full";
    default:
        return "?";
    }
}

mfns_centroid_settings_t mfns_centroid_default_settings(void)
{
    mfns_centroid_settings_t s;
    s.threshold_dn = 0;
    s.threshold_k_sigma = 5.0f;
    s.min_area_px = 3;
    s.max_area_px = 4000;
    s.max_elongation = 4.0f;
    s.roi_half_size_px = 24;
    s.saturation_dn = 0;
    s.gain_dn_per_e_q12 = MFNS_CENTROID_DEFAULT_GAIN_Q12;
    return s;
}

/* ------------------------------------------------------------------------ */
/* Frame checks */

static unsigned format_bits(mfns_pixfmt_t f)
{
    switch (f) {
    case MFNS_PIXFMT_GREY:
        return 8u;
    case MFNS_PIXFMT_Y10:
        return 10u;
    case MFNS_PIXFMT_Y12:
        return 12u;
    case MFNS_PIXFMT_Y16:
        return 16u;
    default:
        return 0u;
    }
}

static mfns_centroid_status_t check_frame(const mfns_frame_t *f)
{
    if (f == NULL || f->data == NULL) {
        return MFNS_CENTROID_ERR_NULL;
    }
    const unsigned bits = format_bits(f->format);
    if (bits == 0u) {
        return MFNS_CENTROID_ERR_FORMAT;
    }
    if (f->width == 0u || f->height == 0u || f->width > MFNS_CENTROID_MAX_DIM || f->height > MFNS_CENTROID_MAX_DIM) {
        return MFNS_CENTROID_ERR_SIZE;
    }
    const uint32_t bpp = bits > 8u ? 2u : 1u;
    if (f->stride_bytes < (uint32_t)f->width * bpp || (f->stride_bytes % bpp) != 0u) {
        return MFNS_CENTROID_ERR_STRIDE;
    }
    return MFNS_CENTROID_OK;
}

static mfns_centroid_status_t check_rois(const mfns_frame_t *f, const mfns_roi_t *rois, uint16_t n)
{
    if (n == 0u) {
        return MFNS_CENTROID_OK;
    }
    if (rois == NULL) {
        return MFNS_CENTROID_ERR_NULL;
    }
    if (n > MFNS_CENTROID_MAX_ROIS) {
        return MFNS_CENTROID_ERR_ROI;
    }
    for (uint16_t i = 0; i < n; i++) {
        const mfns_roi_t *a = &rois[i];
        if (a->x0 >= a->x1 || a->y0 >= a->y1 || a->x1 > f->width || a->y1 > f->height) {
            return MFNS_CENTROID_ERR_ROI;
        }
        for (uint16_t j = 0; j < i; j++) {
            const mfns_roi_t *b = &rois[j];
            if (a->x0 < b->x1 && b->x0 < a->x1 && a->y0 < b->y1 && b->y0 < a->y1) {
                return MFNS_CENTROID_ERR_ROI;
            }
        }
    }
    return MFNS_CENTROID_OK;
}

static inline const uint8_t *row_ptr(const mfns_frame_t *f, uint32_t y)
{
    return (const uint8_t *)f->data + (size_t)y * f->stride_bytes;
}

static inline uint32_t pixel(const uint8_t *row, uint32_t x, bool wide)
{
    if (wide) {
        uint16_t v;
        memcpy(&v, row + 2u * x, sizeof v);
        return v;
    }
    return row[x];
}

/* ------------------------------------------------------------------------ */
/* Background: median and MAD from histograms of a sample grid. */

typedef struct {
    uint32_t lo;    /* value of bin 0 */
    uint32_t shift; /* bin width 2^shift DN */
    uint32_t under, over, n;
} hist_desc_t;

/* Fraction of samples <= x (x in DN, continuous): integer value v stands for
 * [v - 0.5, v + 0.5), uniform within a bin. h is cumulative. */
static float hist_cdf(const uint32_t *c, const hist_desc_t *d, float x)
{
    const float w = (float)(1u << d->shift);
    const float t = (x + 0.5f - (float)d->lo) / w;
    if (!(t > 0.0f)) {
        return (float)d->under;
    }
    if (t >= (float)MFNS_CENTROID_HIST_BINS) {
        return (float)(d->n - d->over);
    }
    const uint32_t k = (uint32_t)t;
    const float below = (float)d->under + (k > 0u ? (float)c[k - 1u] : 0.0f);
    const float in_bin = (float)c[k] - (k > 0u ? (float)c[k - 1u] : 0.0f);
    return below + in_bin * (t - (float)k);
}

/* Median and MAD from the cumulative histogram c. false when the median is
 * outside the histogram's range. */
static bool hist_median_mad(const uint32_t *c, const hist_desc_t *d, float *median, float *mad)
{
    const float half = 0.5f * (float)d->n;
    const float w = (float)(1u << d->shift);
    if ((float)d->under >= half || (float)(d->n - d->over) < half) {
        return false;
    }
    uint32_t k = 0;
    while (k < MFNS_CENTROID_HIST_BINS - 1u && (float)(d->under + c[k]) < half) {
        k++;
    }
    const float below = (float)d->under + (k > 0u ? (float)c[k - 1u] : 0.0f);
    const float in_bin = (float)c[k] - (k > 0u ? (float)c[k - 1u] : 0.0f);
    const float frac = in_bin > 0.0f ? (half - below) / in_bin : 0.5f;
    const float med = (float)d->lo - 0.5f + w * ((float)k + frac);
    /* MAD: smallest r with CDF(med + r) - CDF(med - r) >= n/2, by bisection
     * (the function is continuous and non-decreasing in r). */
    float lo = 0.0f, hi = w * (float)MFNS_CENTROID_HIST_BINS + 1.0f;
    for (int it = 0; it < 40; it++) {
        const float r = 0.5f * (lo + hi);
        if (hist_cdf(c, d, med + r) - hist_cdf(c, d, med - r) >= half) {
            hi = r;
        } else {
            lo = r;
        }
    }
    *median = med;
    *mad = 0.5f * (lo + hi);
    return true;
}

typedef struct {
    uint32_t x0, y0, x1, y1;
} region_t;

static uint16_t regions_of(const mfns_frame_t *f, const mfns_roi_t *rois, uint16_t n_rois, region_t *reg)
{
    if (n_rois == 0u) {
        reg[0] = (region_t){0u, 0u, f->width, f->height};
        return 1u;
    }
    for (uint16_t i = 0; i < n_rois; i++) {
        reg[i] = (region_t){rois[i].x0, rois[i].y0, rois[i].x1, rois[i].y1};
    }
    return n_rois;
}

/* One histogram pass over the sample grid: bins of 2^shift DN from lo. The
 * samples of a row are counted before the row is read, so the cap is checked
 * once per row. */
static void hist_pass(const mfns_frame_t *f, const region_t *reg, uint16_t n_reg, uint32_t step, uint32_t *h,
                      hist_desc_t *d)
{
    const bool wide = format_bits(f->format) > 8u;
    /* four interleaved sub-histograms: consecutive samples of a flat
     * background hit the same bin, and one counter would serialise them */
    memset(h, 0, 4u * MFNS_CENTROID_HIST_BINS * sizeof h[0]);
    d->under = d->over = d->n = 0u;
    for (uint16_t r = 0; r < n_reg; r++) {
        const uint32_t xs = reg[r].x0 + step / 2u;
        if (xs >= reg[r].x1) {
            continue;
        }
        const uint32_t per_row = (reg[r].x1 - xs + step - 1u) / step;
        for (uint32_t y = reg[r].y0 + step / 2u; y < reg[r].y1; y += step) {
            const uint32_t cnt = per_row < MFNS_CENTROID_BG_MAX_SAMPLES - d->n ? per_row : MFNS_CENTROID_BG_MAX_SAMPLES - d->n;
            if (cnt == 0u) {
                return;
            }
            const uint8_t *row = row_ptr(f, y);
            uint32_t under = 0, over = 0;
            for (uint32_t i = 0, x = xs; i < cnt; i++, x += step) {
                const uint32_t v = wide ? pixel(row, x, true) : row[x];
                if (v < d->lo) {
                    under++;
                    continue;
                }
                const uint32_t b = (v - d->lo) >> d->shift;
                if (b >= MFNS_CENTROID_HIST_BINS) {
                    over++;
                } else {
                    h[b + MFNS_CENTROID_HIST_BINS * (i & 3u)]++;
                }
            }
            d->n += cnt;
            d->under += under;
            d->over += over;
        }
    }
}

/* Merge the sub-histograms into h[0 .. BINS) and make it cumulative. */
static void cumulate(uint32_t *h)
{
    for (uint32_t k = 0; k < MFNS_CENTROID_HIST_BINS; k++) {
        h[k] += h[k + MFNS_CENTROID_HIST_BINS] + h[k + 2u * MFNS_CENTROID_HIST_BINS] +
                h[k + 3u * MFNS_CENTROID_HIST_BINS];
        if (k > 0u) {
            h[k] += h[k - 1u];
        }
    }
}

mfns_centroid_status_t mfns_centroid_background(const mfns_frame_t *frame, const mfns_roi_t *rois, uint16_t n_rois,
                                                mfns_centroid_work_t *work, mfns_centroid_bg_t *bg)
{
    if (bg != NULL) {
        *bg = (mfns_centroid_bg_t){0.0f, 0.0f, 0u};
    }
    if (work == NULL || bg == NULL) {
        return MFNS_CENTROID_ERR_NULL;
    }
    mfns_centroid_status_t st = check_frame(frame);
    if (st != MFNS_CENTROID_OK) {
        return st;
    }
    st = check_rois(frame, rois, n_rois);
    if (st != MFNS_CENTROID_OK) {
        return st;
    }
    region_t reg[MFNS_CENTROID_MAX_ROIS];
    const uint16_t n_reg = regions_of(frame, rois, n_rois, reg);
    uint64_t pixels = 0;
    for (uint16_t r = 0; r < n_reg; r++) {
        pixels += (uint64_t)(reg[r].x1 - reg[r].x0) * (reg[r].y1 - reg[r].y0);
    }
    /* grid step: about MFNS_CENTROID_BG_MAX_SAMPLES samples in all */
    uint32_t step = 1u;
    while (step < MFNS_CENTROID_MAX_DIM && (uint64_t)step * step * MFNS_CENTROID_BG_MAX_SAMPLES < pixels) {
        step++;
    }
    const unsigned bits = format_bits(frame->format);
    /* pass 1: the whole range of the format in 1024 bins */
    hist_desc_t d = {0u, bits > 10u ? bits - 10u : 0u, 0u, 0u, 0u};
    hist_pass(frame, reg, n_reg, step, work->hist, &d);
    cumulate(work->hist);
    float med, mad;
    if (d.n == 0u || !hist_median_mad(work->hist, &d, &med, &mad)) {
        return MFNS_CENTROID_ERR_BACKGROUND; /* cannot happen: regions are non-empty */
    }
    if (d.shift > 0u) {
        /* pass 2: 1024 finer bins over median +- 8 MAD (at least +- 2 coarse bins) */
        const float span = fmaxf(16.0f * mad, 4.0f * (float)(1u << d.shift));
        uint32_t shift = 0u;
        while (shift < d.shift && (float)(MFNS_CENTROID_HIST_BINS << shift) < span) {
            shift++;
        }
        const float lo = med - 0.5f * (float)(MFNS_CENTROID_HIST_BINS << shift);
        hist_desc_t d2 = {lo > 0.0f ? (uint32_t)lo : 0u, shift, 0u, 0u, 0u};
        hist_pass(frame, reg, n_reg, step, work->hist, &d2);
        cumulate(work->hist);
        float med2, mad2;
        if (hist_median_mad(work->hist, &d2, &med2, &mad2)) {
            med = med2;
            mad = mad2;
        }
    }
    bg->background_dn = med;
    bg->noise_dn = 1.4826f * mad;
    bg->n_samples = d.n;
    return MFNS_CENTROID_OK;
}

/* ------------------------------------------------------------------------ */
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

#define GE_LOW(w, L, H, c) (((((w) & (L)) + (c)) | (w)) & (H))
#define GE_HIGH(w, L, H, c) (((((w) & (L)) + (c)) & (w)) & (H))

/* First x in [x, end) with pixel >= T (or end), for the background-dominated
 * bulk of a frame. Two stages: the lane-wise maximum over a block of 256 bytes
 * (a plain loop that compilers turn into vector max instructions: SSE2 pmaxub
 * on x86-64, NEON umax on aarch64, a scalar loop on a Cortex-M) tested with the
 * word test, then, inside a block that holds a candidate, the exact 8-byte word
 * test, which stops within a word of the first pixel >= T. */
#define BLOCK_BYTES 256u

/* Lane-wise maximum over a block, 16 bytes wide: the inner loop is one vector
 * max per 16 bytes (compilers vectorize it at -O2), and the result is tested
 * with the word test above instead of a horizontal reduction (which cost as
 * much as the block's loads). */
static void block_max16_u8(const uint8_t *p, uint8_t m[16])
{
    memcpy(m, p, 16u);
    for (uint32_t i = 16u; i < BLOCK_BYTES; i += 16u) {
        for (uint32_t j = 0; j < 16u; j++) {
            m[j] = p[i + j] > m[j] ? p[i + j] : m[j];
        }
    }
}

static void block_max16_u16(const uint8_t *p, uint8_t m8[16])
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
    memcpy(m8, m, 16u);
}

#define DEFINE_FIND(name, GE, L, H, bpp, BLOCK_MAX16)                                                   \
    static uint32_t name(const uint8_t *row, uint32_t x, uint32_t end, uint64_t c)                     \
    {                                                                                                   \
        const uint32_t per_word = 8u / (bpp), per_block = BLOCK_BYTES / (bpp);                          \
        while (x + per_block <= end) {                                                                  \
            uint8_t m[16];                                                                              \
            BLOCK_MAX16(row + (size_t)x * (bpp), m);                                                    \
            const uint64_t w0 = load64(m), w1 = load64(m + 8);                                          \
            if ((GE(w0, L, H, c) | GE(w1, L, H, c)) != 0u) {                                            \
                break;                                                                                  \
            }                                                                                           \
            x += per_block;                                                                             \
        }                                                                                               \
        while (x + per_word <= end) {                                                                   \
            const uint64_t w = load64(row + (size_t)x * (bpp));                                         \
            if (GE(w, L, H, c) != 0u) {                                                                 \
                break;                                                                                  \
            }                                                                                           \
            x += per_word;                                                                              \
        }                                                                                               \
        return x;                                                                                       \
    }

DEFINE_FIND(find_u8_low, GE_LOW, L8, H8, 1u, block_max16_u8)
DEFINE_FIND(find_u8_high, GE_HIGH, L8, H8, 1u, block_max16_u8)
DEFINE_FIND(find_u16_low, GE_LOW, L16, H16, 2u, block_max16_u16)
DEFINE_FIND(find_u16_high, GE_HIGH, L16, H16, 2u, block_max16_u16)

typedef uint32_t (*find_fn_t)(const uint8_t *row, uint32_t x, uint32_t end, uint64_t c);

/* ------------------------------------------------------------------------ */
/* Labels: union-find over provisional labels, accumulators at the roots. */

typedef struct {
    mfns_centroid_work_t *w;
    uint32_t n_labels;
    uint32_t n_lost;
} label_state_t;

static uint16_t find_root(const label_state_t *ls, uint16_t l)
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
static uint16_t unite(label_state_t *ls, uint16_t a, uint16_t b)
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
        A->s_i += B->s_i;
        A->s_ix += B->s_ix;
        A->s_iy += B->s_iy;
        A->s_ixx += B->s_ixx;
        A->s_iyy += B->s_iyy;
        A->s_ixy += B->s_ixy;
        A->s_x += B->s_x;
        A->s_y += B->s_y;
        A->s_xx += B->s_xx;
        A->s_yy += B->s_yy;
        A->s_xy += B->s_xy;
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
static uint16_t label_run(label_state_t *ls, const mfns_centroid_run_t *prev, uint32_t np, uint32_t *j, uint32_t y,
                          uint32_t x0, uint32_t x1, const run_sums_t *rs, uint8_t roi)
{
    while (*j < np && (uint32_t)prev[*j].x1 + 1u < x0) {
        (*j)++;
    }
    uint16_t lbl = LABEL_DROPPED;
    bool touches_dropped = false;
    for (uint32_t k = *j; k < np && prev[k].x0 <= x1 + 1u; k++) {
        if (prev[k].label == LABEL_DROPPED) {
            touches_dropped = true;
            continue;
        }
        const uint16_t r = find_root(ls, prev[k].label);
        lbl = (lbl == LABEL_DROPPED) ? r : (r == lbl ? lbl : unite(ls, lbl, r));
    }
    if (lbl == LABEL_DROPPED) {
        if (touches_dropped || ls->n_labels >= MFNS_CENTROID_MAX_LABELS) {
            ls->n_lost++;
            return LABEL_DROPPED;
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
static void label_region(label_state_t *ls, const mfns_frame_t *f, const region_t *rg, uint32_t T, uint8_t roi)
{
    const bool wide = format_bits(f->format) > 8u;
    const uint32_t top = wide ? 0x8000u : 0x80u;
    const bool low = T < top;
    const uint64_t lanes = wide ? 0x0001000100010001ull : 0x0101010101010101ull;
    const uint64_t c = (uint64_t)(top - (T & (top - 1u))) * lanes;
    const find_fn_t find = wide ? (low ? find_u16_low : find_u16_high) : (low ? find_u8_low : find_u8_high);
    mfns_centroid_run_t *prev = ls->w->runs[0], *cur = ls->w->runs[1];
    uint32_t np = 0;
    for (uint32_t y = rg->y0; y < rg->y1; y++) {
        const uint8_t *row = row_ptr(f, y);
        uint32_t nc = 0, j = 0, x = rg->x0;
        while (x < rg->x1) {
            x = find(row, x, rg->x1, c);
            /* the word test found a candidate within the next word(s), or the tail */
            while (x < rg->x1 && pixel(row, x, wide) < T) {
                x++;
            }
            if (x >= rg->x1) {
                break;
            }
            const uint32_t x0 = x;
            run_sums_t rs = {0u, 0u, 0u, 0u};
            for (; x < rg->x1; x++) {
                const uint32_t v = pixel(row, x, wide);
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

/* ------------------------------------------------------------------------ */
/* Per-blob results */

/* Pixel noise model of the covariance (docs/centroiding.md, "Centroid
 * covariance"): var(I_i) = floor_dn2 + gain (I_i - b), the background noise
 * (which holds the read noise, the background's shot noise and the 1/12 DN^2
 * of rounding) plus the shot noise of the spot's own signal. */
typedef struct {
    float floor_dn2;   /* max(noise_dn^2, MFNS_CENTROID_QUANT_VAR_DN2) */
    float gain_dn_per_e;
} noise_model_t;

/* l_q8: the weight level (pixel weight = value - level), b_q8 the background,
 * both Q8 DN with l_q8 >= b_q8 and 256 T > l_q8. The covariance of the moment
 * centroid is filled for accepted blobs only (zero otherwise). */
static void finish_blob(const mfns_centroid_acc_t *a, int64_t l_q8, int64_t b_q8, const noise_model_t *nm,
                        const mfns_centroid_settings_t *s, uint32_t sat, const mfns_frame_t *f, const mfns_roi_t *rois,
                        uint16_t n_rois, mfns_blob_t *o, float *m2)
{
    double cov[3] = {0.0, 0.0, 0.0};
    memset(o, 0, sizeof *o);
    *m2 = 0.0f;
    o->area_px = a->area;
    o->peak_dn = a->peak;
    o->x_min = a->x_min;
    o->y_min = a->y_min;
    o->x_max = a->x_max;
    o->y_max = a->y_max;
    o->roi = a->roi;
    o->saturated = a->peak >= sat;
    uint16_t why = 0u;
    bool have_moments = !a->moments_capped;
    if (have_moments) {
        /* Q8 weighted sums; every pixel exceeds the level (256 T > l_q8), so w > 0. */
        const int64_t n = (int64_t)a->moment_area;
        const int64_t w = 256 * (int64_t)a->s_i - l_q8 * n;
        const int64_t mx = 256 * (int64_t)a->s_ix - l_q8 * (int64_t)a->s_x;
        const int64_t my = 256 * (int64_t)a->s_iy - l_q8 * (int64_t)a->s_y;
        have_moments = mfns_px_q8_from_ratio(mx, w, &o->u_q8) && mfns_px_q8_from_ratio(my, w, &o->v_q8);
        o->flux_dn = (float)(256 * (int64_t)a->s_i - b_q8 * n) / 256.0f;
        /* Shape: second moments about the bounding-box corner (exact in
         * integers), then double: the raw sums reach 2^56 and the background
         * subtraction cancels, which float's 24 bits would not survive. */
        const int64_t ax = a->x_min, ay = a->y_min;
        const int64_t s_i = (int64_t)a->s_i;
        const double cixx = (double)((int64_t)a->s_ixx - 2 * ax * (int64_t)a->s_ix + ax * ax * s_i);
        const double ciyy = (double)((int64_t)a->s_iyy - 2 * ay * (int64_t)a->s_iy + ay * ay * s_i);
        const double cixy =
            (double)((int64_t)a->s_ixy - ax * (int64_t)a->s_iy - ay * (int64_t)a->s_ix + ax * ay * s_i);
        const double cix = (double)((int64_t)a->s_ix - ax * s_i), ciy = (double)((int64_t)a->s_iy - ay * s_i);
        const double cxx = (double)((int64_t)a->s_xx - 2 * ax * (int64_t)a->s_x + ax * ax * n);
        const double cyy = (double)((int64_t)a->s_yy - 2 * ay * (int64_t)a->s_y + ay * ay * n);
        const double cxy = (double)((int64_t)a->s_xy - ax * (int64_t)a->s_y - ay * (int64_t)a->s_x + ax * ay * n);
        const double cx = (double)((int64_t)a->s_x - ax * n), cy = (double)((int64_t)a->s_y - ay * n);
        const double B = (double)l_q8 / 256.0, W = (double)w / 256.0;
        const double mu_x = (cix - B * cx) / W, mu_y = (ciy - B * cy) / W;
        /* + 1/12: each pixel is a unit square, not a point */
        const double mxx = (cixx - B * cxx) / W - mu_x * mu_x + 1.0 / 12.0;
        const double myy = (ciyy - B * cyy) / W - mu_y * mu_y + 1.0 / 12.0;
        const double mxy = (cixy - B * cxy) / W - mu_x * mu_y;
        const double tr = 0.5 * (mxx + myy);
        const double disc = sqrt(0.25 * (mxx - myy) * (mxx - myy) + mxy * mxy);
        const double lmin = tr - disc, lmax = tr + disc;
        o->elongation = lmin > 0.0 ? (float)(lmax / lmin) : INFINITY;
        *m2 = (float)(mxx + myy - 1.0 / 6.0); /* E r^2 of the pixel centres */
        /* Covariance, first-order in the pixel values (docs/centroiding.md):
         * du/dI_i = (x_i - u) / W, so Cov = sum (p_i - c)(p_i - c)^T var(I_i) / W^2
         * with var(I_i) = floor + gain (I_i - b). Sums about the centroid, from
         * the same accumulators: geometric G = sum (p - c)(p - c)^T, weighted
         * Q = sum (p - c)(p - c)^T (I - l) = W m (the moments above without the
         * unit square), and the signal sum Q + (l - b) G. */
        const double gxx = cxx - 2.0 * mu_x * cx + mu_x * mu_x * (double)n;
        const double gyy = cyy - 2.0 * mu_y * cy + mu_y * mu_y * (double)n;
        const double gxy = cxy - mu_x * cy - mu_y * cx + mu_x * mu_y * (double)n;
        const double lb = (double)(l_q8 - b_q8) / 256.0, fl = (double)nm->floor_dn2, g = (double)nm->gain_dn_per_e;
        const double sxx = W * (mxx - 1.0 / 12.0) + lb * gxx, syy = W * (myy - 1.0 / 12.0) + lb * gyy;
        const double sxy = W * mxy + lb * gxy;
        const double inv_w2 = 1.0 / (W * W);
        cov[0] = (fl * gxx + g * sxx) * inv_w2 + MFNS_CENTROID_Q8_VAR_PX2;
        cov[1] = (fl * gxy + g * sxy) * inv_w2;
        cov[2] = (fl * gyy + g * syy) * inv_w2 + MFNS_CENTROID_Q8_VAR_PX2;
    }
    if (!have_moments) {
        /* no moment centroid for blobs beyond the cap: bounding-box centre */
        o->u_q8 = (px_q8_t)(((int32_t)a->x_min + (int32_t)a->x_max) * 128);
        o->v_q8 = (px_q8_t)(((int32_t)a->y_min + (int32_t)a->y_max) * 128);
        o->elongation = 1.0f;
        why |= MFNS_BLOB_TOO_LARGE;
    }
    if (a->area < s->min_area_px) {
        why |= MFNS_BLOB_TOO_SMALL;
    }
    if (a->area > s->max_area_px) {
        why |= MFNS_BLOB_TOO_LARGE;
    }
    if (o->saturated) {
        why |= MFNS_BLOB_SATURATED;
    }
    if (a->x_min == 0u || a->y_min == 0u || a->x_max + 1u >= f->width || a->y_max + 1u >= f->height) {
        why |= MFNS_BLOB_IMAGE_BORDER;
    }
    if (n_rois > 0u && a->roi < n_rois) {
        const mfns_roi_t *r = &rois[a->roi];
        if ((a->x_min == r->x0 && r->x0 > 0u) || (a->y_min == r->y0 && r->y0 > 0u) ||
            (a->x_max + 1u == r->x1 && r->x1 < f->width) || (a->y_max + 1u == r->y1 && r->y1 < f->height)) {
            why |= MFNS_BLOB_ROI_BORDER;
        }
    }
    if (!(o->elongation <= s->max_elongation)) {
        why |= MFNS_BLOB_ELONGATED;
    }
    if (a->incomplete) {
        why |= MFNS_BLOB_TABLE_FULL;
    }
    o->reasons = why;
    if (why == 0u) {
        o->cov_px2[0] = (float)cov[0];
        o->cov_px2[1] = (float)cov[1];
        o->cov_px2[2] = (float)cov[2];
    }
}

/* ------------------------------------------------------------------------ */
/* Profile refinement of flat-topped blobs (docs/centroiding.md, step 7).
 *
 * The centre of mass weights every pixel by its offset from the centre, so
 * the plateau of a defocused disk adds shot noise that carries no position
 * information; the Fisher information sits in the steep edge. For a blob whose
 * shape says it has a plateau, the centre is re-estimated from the
 * estimating equation
 *     sum_i (I_i - b) a(r_i) (p_i - c) = 0,   r_i = |p_i - c|,
 * with a(r) = -f'(r) / (r var(r)): the maximum-likelihood score of a radially
 * symmetric spot f (its model term cancels by symmetry), here a blurred disk
 * fitted to the blob's second and fourth radial moments. The weights depend on
 * the pixel position only, so the estimator is linear in the pixel values and
 * unbiased for any symmetric spot whatever the fitted shape; the shape only
 * sets how close it gets to the bound. One Newton step from the moment
 * centroid. Float is the working type; the score and Hessian sums use double
 * because the score cancels to ~0 over up to MFNS_CENTROID_REFINE_MAX_SIDE^2
 * terms. */

/* e^-z I1(z) / z for z >= 0 (polynomials of Abramowitz & Stegun 9.8.3 and
 * 9.8.4, relative error < 3e-7); 1/2 at z = 0. */
static float i1e_over_z(float z)
{
    if (z <= 3.75f) {
        const float t = (z / 3.75f) * (z / 3.75f);
        const float p =
            0.5f + t * (0.87890594f +
                        t * (0.51498869f + t * (0.15084934f + t * (0.02658733f + t * (0.00301532f + t * 0.00032411f)))));
        return expf(-z) * p;
    }
    const float u = 3.75f / z;
    const float p =
        0.39894228f +
        u * (-0.03988024f +
             u * (-0.00362018f +
                  u * (0.00163801f +
                       u * (-0.01031555f + u * (0.02282967f + u * (-0.02895312f + u * (0.01787654f - u * 0.00420059f)))))));
    return p / (z * sqrtf(z));
}

/* Disk radius R and edge blur s of a blurred disk with the blob's radial
 * moments m2 = E r^2 and m4 = E r^4 about (u0, v0), weights value - level over
 * the pixels >= T of the bounding box. A disk of radius R blurred by a Gaussian
 * s has m2 = X + Y and m4 = 2 (X + Y)^2 - (2/3) X^2 with X = R^2 / 2, Y = 2 s^2
 * (a Gaussian: R = 0; a sharp disk: s = 0), so X = sqrt(1.5 (2 m2^2 - m4)).
 * The pixel-centre moments include the pixel's own 1/12 px^2 per axis, which
 * is what the weights must see. false when there is no positive weight. */
static bool blob_shape(const mfns_frame_t *f, const mfns_centroid_acc_t *a, uint32_t T, float level, float u0,
                       float v0, float *R, float *s)
{
    const bool wide = format_bits(f->format) > 8u;
    float sw = 0.0f, sq = 0.0f, sqq = 0.0f;
    for (uint32_t y = a->y_min; y <= a->y_max; y++) {
        const uint8_t *row = row_ptr(f, y);
        const float dy = (float)y - v0;
        for (uint32_t x = a->x_min; x <= a->x_max; x++) {
            const uint32_t v = pixel(row, x, wide);
            if (v < T) {
                continue;
            }
            const float w = (float)v - level, dx = (float)x - u0, q = dx * dx + dy * dy;
            sw += w;
            sq += w * q;
            sqq += w * q * q;
        }
    }
    if (!(sw > 0.0f)) {
        return false;
    }
    const float m2 = sq / sw, m4 = sqq / sw;
    const float smin = MFNS_CENTROID_REFINE_MIN_BLUR;
    float X = sqrtf(fmaxf(0.0f, 1.5f * (2.0f * m2 * m2 - m4)));
    X = fminf(X, m2 - 2.0f * smin * smin);
    if (!(X >= 0.0f)) {
        X = 0.0f;
    }
    *R = sqrtf(2.0f * X);
    *s = sqrtf(fmaxf(0.5f * (m2 - X), smin * smin));
    return isfinite(*R) && isfinite(*s);
}

/* One Newton step (du, dv) of the estimating equation above from (u0, v0) for
 * the blurred disk (R, s) of flux `flux` DN; var(r) is taken as f(r) + c (shot
 * noise, with c DN of background noise expressed as signal). The window: the
 * bounding box grown by 2 px, cut to where a(r) is defined and to the region
 * (frame or window) the blob was found in. false when the step is not a
 * finite sub-pixel move (the caller keeps the moment centroid). */
static bool refine_step(const mfns_frame_t *f, const region_t *rg, const mfns_centroid_acc_t *a, float b, float c,
                        const noise_model_t *nm, float flux, float R, float s, float u0, float v0, float *du, float *dv,
                        float cov[3])
{
    /* a(r) tabulated on n + 1 nodes r_k = r_lo + k h over [r_lo, r_hi]: outside,
     * the edge derivative is below e^-10 of its peak */
    float tab[MFNS_CENTROID_REFINE_BINS + 1u];
    const float r_lo = fmaxf(0.0f, R - 4.5f * s), r_hi = R + 4.5f * s + 1.0f;
    const float h = fmaxf(0.125f, (r_hi - r_lo) / (float)MFNS_CENTROID_REFINE_BINS);
    uint32_t n = (uint32_t)ceilf((r_hi - r_lo) / h);
    n = n < 1u ? 1u : (n > MFNS_CENTROID_REFINE_BINS ? MFNS_CENTROID_REFINE_BINS : n);
    const float inv_2s2 = 0.5f / (s * s), Rs2 = R / (s * s), norm = 1.0f / (3.14159265f * s * s * s * s);
    /* unit-flux blurred disk: -f'(r) = r k(r), k(r) = e^-((r-R)^2 / 2s^2) e^-z I1(z) / z / (pi s^4),
     * z = r R / s^2 (-> a Gaussian of sigma s as R -> 0); f(r) = int_r^inf -f' */
    for (uint32_t k = 0; k <= n; k++) {
        const float r = r_lo + (float)k * h, e = r - R;
        tab[k] = norm * expf(-e * e * inv_2s2) * i1e_over_z(r * Rs2);
    }
    float fr_out = 0.0f, g_next = 0.0f;
    for (uint32_t i = 0; i <= n; i++) {
        const uint32_t k = n - i;
        const float r = r_lo + (float)k * h, g = r * tab[k];
        fr_out += i == 0u ? 0.0f : 0.5f * h * (g + g_next);
        g_next = g;
        tab[k] = tab[k] / (flux * fr_out + c); /* a(r) = k(r) / var(r) */
    }
    const float half = r_hi;
    const int32_t x0 = (int32_t)fmaxf(fmaxf((float)rg->x0, (float)a->x_min - 2.0f), floorf(u0 - half));
    const int32_t x1 = (int32_t)fminf(fminf((float)rg->x1 - 1.0f, (float)a->x_max + 2.0f), ceilf(u0 + half));
    const int32_t y0 = (int32_t)fmaxf(fmaxf((float)rg->y0, (float)a->y_min - 2.0f), floorf(v0 - half));
    const int32_t y1 = (int32_t)fminf(fminf((float)rg->y1 - 1.0f, (float)a->y_max + 2.0f), ceilf(v0 + half));
    if (x1 < x0 || y1 < y0 || x1 - x0 >= MFNS_CENTROID_REFINE_MAX_SIDE || y1 - y0 >= MFNS_CENTROID_REFINE_MAX_SIDE) {
        return false;
    }
    const bool wide = format_bits(f->format) > 8u;
    const float inv_h = 1.0f / h, r_lo2 = r_lo * r_lo, r_hi2 = r_hi * r_hi;
    const float fl = nm->floor_dn2, gain = nm->gain_dn_per_e;
    double gx = 0.0, gy = 0.0, hxx = 0.0, hyy = 0.0, hxy = 0.0, vxx = 0.0, vyy = 0.0, vxy = 0.0;
    for (int32_t y = y0; y <= y1; y++) {
        const uint8_t *row = row_ptr(f, (uint32_t)y);
        const float dy = (float)y - v0;
        float rgx = 0.0f, rgy = 0.0f, rhxx = 0.0f, rhyy = 0.0f, rhxy = 0.0f, rvxx = 0.0f, rvyy = 0.0f, rvxy = 0.0f;
        for (int32_t x = x0; x <= x1; x++) {
            const float dx = (float)x - u0, q = dx * dx + dy * dy;
            if (q < r_lo2 || q >= r_hi2) {
                continue;
            }
            const float r = sqrtf(q), t = (r - r_lo) * inv_h;
            uint32_t k = (uint32_t)t;
            k = k < n ? k : n - 1u;
            const float slope = tab[k + 1u] - tab[k];
            const float w = tab[k] + slope * (t - (float)k);
            const float d = (float)pixel(row, (uint32_t)x, wide) - b;
            /* d a / d r divided by r (0 at the centre, where dx, dy -> 0 anyway) */
            const float ar_r = r > 1e-3f ? slope * inv_h / r : 0.0f;
            rgx += d * w * dx;
            rgy += d * w * dy;
            rhxx += d * (w + ar_r * dx * dx);
            rhyy += d * (w + ar_r * dy * dy);
            rhxy += d * ar_r * dx * dy;
            /* covariance: var(I) w^2 (p - c)(p - c)^T, var(I) = floor + gain (I - b)+ */
            const float vw = (fl + gain * fmaxf(d, 0.0f)) * w * w;
            rvxx += vw * dx * dx;
            rvyy += vw * dy * dy;
            rvxy += vw * dx * dy;
        }
        gx += (double)rgx;
        gy += (double)rgy;
        hxx += (double)rhxx;
        hyy += (double)rhyy;
        hxy += (double)rhxy;
        vxx += (double)rvxx;
        vyy += (double)rvyy;
        vxy += (double)rvxy;
    }
    const double det = hxx * hyy - hxy * hxy;
    if (!(det > 0.0 && hxx > 0.0)) {
        return false;
    }
    const double sx = (hyy * gx - hxy * gy) / det, sy = (hxx * gy - hxy * gx) / det;
    if (!(fabs(sx) <= 1.0 && fabs(sy) <= 1.0)) {
        return false;
    }
    /* Covariance of the root of the estimating equation, first order (the
     * sandwich of M-estimation): dc/dI_i = H^-1 a_i (p_i - c), so
     * Cov = H^-1 V H^-1 with V = sum var(I_i) a_i^2 (p_i - c)(p_i - c)^T. The
     * Newton step from the moment centroid lands within second order of the
     * root, so the moment centroid's own noise does not enter. */
    const double ixx = hyy / det, iyy = hxx / det, ixy = -hxy / det; /* H^-1 */
    const double axx = ixx * vxx + ixy * vxy, axy = ixx * vxy + ixy * vyy; /* A = H^-1 V */
    const double ayx = ixy * vxx + iyy * vxy, ayy = ixy * vxy + iyy * vyy;
    const double cxx = axx * ixx + axy * ixy, cyy = ayx * ixy + ayy * iyy;
    const double cxy = 0.5 * ((axx * ixy + axy * iyy) + (ayx * ixx + ayy * ixy)); /* symmetric */
    if (!(cxx > 0.0 && cyy > 0.0 && cxy * cxy < cxx * cyy && isfinite(cxx) && isfinite(cyy))) {
        return false;
    }
    *du = (float)sx;
    *dv = (float)sy;
    cov[0] = (float)cxx + (float)MFNS_CENTROID_Q8_VAR_PX2;
    cov[1] = (float)cxy;
    cov[2] = (float)cyy + (float)MFNS_CENTROID_Q8_VAR_PX2;
    return true;
}

/* Replace the moment centroid of an accepted blob by the refined one when the
 * blob is flat-topped (R >= MFNS_CENTROID_FLAT_RATIO s), large enough for its
 * shape to be measured (R >= MFNS_CENTROID_REFINE_MIN_RADIUS), and the step
 * succeeds. */
CENTROID_NOINLINE static void refine_blob(const mfns_frame_t *f, const region_t *rg, const mfns_centroid_acc_t *a, uint32_t T,
                        int64_t l_q8, int64_t b_q8, int64_t t_q8, const noise_model_t *nm, float m2, mfns_blob_t *o)
{
    /* Pre-gate without touching the frame again (after the full-frame scan the
     * blob's rows are out of cache): flatness pi (peak - b) E r^2 / flux is
     * ~1 for a Gaussian and 1/2 for a uniform disk. */
    const float peak = (float)a->peak - (float)b_q8 / 256.0f;
    if (!(3.14159265f * peak * m2 <= MFNS_CENTROID_FLAT_PHI * o->flux_dn)) {
        return;
    }
    const float u0 = mfns_px_q8_to_float(o->u_q8), v0 = mfns_px_q8_to_float(o->v_q8);
    float R, s;
    if (!blob_shape(f, a, T, (float)l_q8 / 256.0f, u0, v0, &R, &s) || !(R >= MFNS_CENTROID_FLAT_RATIO * s) ||
        !(R >= MFNS_CENTROID_REFINE_MIN_RADIUS)) {
        return;
    }
    /* var(r) ~ f(r) + c: the threshold step as the noise floor (>= 1 DN) */
    const float c = fmaxf((float)t_q8 / 256.0f, 1.0f);
    float du, dv, cov[3];
    if (!refine_step(f, rg, a, (float)b_q8 / 256.0f, c, nm, fmaxf(o->flux_dn, 0.0f), R, s, u0, v0, &du, &dv, cov)) {
        return;
    }
    px_q8_t qu, qv;
    if (!mfns_px_q8_from_float_checked(du, &qu) || !mfns_px_q8_from_float_checked(dv, &qv)) {
        return;
    }
    /* |qu|, |qv| <= 256 and the centroid < 2^20: no overflow */
    const px_q8_t u = o->u_q8 + qu, v = o->v_q8 + qv;
    if (u < (px_q8_t)a->x_min * 256 || u > (px_q8_t)a->x_max * 256 || v < (px_q8_t)a->y_min * 256 ||
        v > (px_q8_t)a->y_max * 256) {
        return;
    }
    o->u_q8 = u;
    o->v_q8 = v;
    o->cov_px2[0] = cov[0]; /* the refined estimator's covariance replaces the moment centroid's */
    o->cov_px2[1] = cov[1];
    o->cov_px2[2] = cov[2];
}

static mfns_centroid_status_t check_settings(const mfns_centroid_settings_t *s)
{
    if (s->threshold_dn == 0u && !(isfinite(s->threshold_k_sigma) && s->threshold_k_sigma > 0.0f &&
                                   s->threshold_k_sigma <= 1000.0f)) {
        return MFNS_CENTROID_ERR_SETTINGS;
    }
    if (s->min_area_px == 0u || s->max_area_px < s->min_area_px) {
        return MFNS_CENTROID_ERR_SETTINGS;
    }
    if (!(isfinite(s->max_elongation) && s->max_elongation >= 1.0f)) {
        return MFNS_CENTROID_ERR_SETTINGS;
    }
    return MFNS_CENTROID_OK;
}

mfns_centroid_status_t mfns_centroid_detect(const mfns_frame_t *frame, const mfns_centroid_settings_t *settings,
                                            const mfns_centroid_bg_t *bg, const mfns_roi_t *rois, uint16_t n_rois,
                                            mfns_centroid_work_t *work, mfns_centroid_result_t *out)
{
    if (out == NULL) {
        return MFNS_CENTROID_ERR_NULL;
    }
    out->n_blobs = 0u;
    out->n_accepted = 0u;
    out->n_lost = 0u;
    out->threshold_dn = 0u;
    out->bg = (mfns_centroid_bg_t){0.0f, 0.0f, 0u};
    if (settings == NULL || bg == NULL || work == NULL) {
        return MFNS_CENTROID_ERR_NULL;
    }
    mfns_centroid_status_t st = check_frame(frame);
    if (st != MFNS_CENTROID_OK) {
        return st;
    }
    st = check_rois(frame, rois, n_rois);
    if (st != MFNS_CENTROID_OK) {
        return st;
    }
    st = check_settings(settings);
    if (st != MFNS_CENTROID_OK) {
        return st;
    }
    const uint32_t maxval = (1u << format_bits(frame->format)) - 1u;
    if (!(isfinite(bg->background_dn) && isfinite(bg->noise_dn) && bg->background_dn >= 0.0f &&
          bg->noise_dn >= 0.0f && bg->background_dn <= (float)maxval && bg->noise_dn <= (float)maxval)) {
        return MFNS_CENTROID_ERR_BACKGROUND;
    }
    const uint32_t sat = settings->saturation_dn != 0u ? settings->saturation_dn : maxval;
    const float t = settings->threshold_dn > 0u ? (float)settings->threshold_dn
                                                : settings->threshold_k_sigma * bg->noise_dn;
    /* both < 2^24 (checked above): exact integer Q8 arithmetic below */
    const int64_t b_q8 = (int64_t)lroundf(bg->background_dn * 256.0f);
    const int64_t t_q8 = (int64_t)lroundf(fminf(t, 131072.0f) * 256.0f);
    const uint32_t T = (uint32_t)((b_q8 + t_q8) / 256 + 1); /* 256 T > b_q8 + t_q8 */
    const int64_t l_q8 = b_q8 + (int64_t)lroundf(MFNS_CENTROID_WEIGHT_LEVEL * (float)t_q8);
    out->threshold_dn = T;
    out->bg = *bg;
    const noise_model_t nm = {fmaxf(bg->noise_dn * bg->noise_dn, MFNS_CENTROID_QUANT_VAR_DN2),
                              (float)settings->gain_dn_per_e_q12 / MFNS_GAIN_Q12_ONE};

    region_t reg[MFNS_CENTROID_MAX_ROIS];
    const uint16_t n_reg = regions_of(frame, rois, n_rois, reg);
    label_state_t ls = {work, 0u, 0u};
    if (T <= maxval) {
        for (uint16_t r = 0; r < n_reg; r++) {
            label_region(&ls, frame, &reg[r], T, n_rois == 0u ? (uint8_t)MFNS_CENTROID_FULL_FRAME : (uint8_t)r);
        }
    }
    /* accepted blobs first, then rejected ones, while the table has room */
    for (int pass = 0; pass < 2; pass++) {
        for (uint32_t l = 0; l < ls.n_labels; l++) {
            if (work->parent[l] != l) {
                continue;
            }
            mfns_blob_t b;
            float m2;
            finish_blob(&work->acc[l], l_q8, b_q8, &nm, settings, sat, frame, rois, n_rois, &b, &m2);
            if ((pass == 0) != (b.reasons == 0u)) {
                continue;
            }
            if (out->n_blobs >= MFNS_MAX_BLOBS_PER_CAMERA) {
                ls.n_lost++;
                continue;
            }
            if (pass == 0) {
                refine_blob(frame, &reg[n_rois == 0u ? 0u : work->acc[l].roi], &work->acc[l], T, l_q8, b_q8, t_q8,
                            &nm, m2, &b);
            }
            out->blob[out->n_blobs++] = b;
            if (pass == 0) {
                out->n_accepted++;
            }
        }
    }
    out->n_lost = ls.n_lost;
    return ls.n_lost > 0u ? MFNS_CENTROID_TABLE_FULL : MFNS_CENTROID_OK;
}

/* ------------------------------------------------------------------------ */

static bool rois_touch(const mfns_roi_t *a, const mfns_roi_t *b)
{
    return a->x0 <= b->x1 && b->x0 <= a->x1 && a->y0 <= b->y1 && b->y0 <= a->y1;
}

mfns_centroid_status_t mfns_centroid_make_rois(const float (*uv)[2], uint16_t n_pred, uint16_t half_size_px,
                                               uint16_t width, uint16_t height, mfns_roi_t *rois, uint16_t max_rois,
                                               uint16_t *n_rois)
{
    if (n_rois != NULL) {
        *n_rois = 0u;
    }
    if ((uv == NULL && n_pred > 0u) || rois == NULL || n_rois == NULL) {
        return MFNS_CENTROID_ERR_NULL;
    }
    if (width == 0u || height == 0u || width > MFNS_CENTROID_MAX_DIM || height > MFNS_CENTROID_MAX_DIM) {
        return MFNS_CENTROID_ERR_SIZE;
    }
    if (max_rois > MFNS_CENTROID_MAX_ROIS) {
        max_rois = MFNS_CENTROID_MAX_ROIS;
    }
    uint16_t n = 0;
    for (uint16_t i = 0; i < n_pred; i++) {
        const float u = uv[i][0], v = uv[i][1];
        if (!(u >= -0.5f && v >= -0.5f && u < (float)width - 0.5f && v < (float)height - 0.5f)) {
            continue;
        }
        const int32_t cu = (int32_t)lroundf(u), cv = (int32_t)lroundf(v), h = half_size_px;
        mfns_roi_t r;
        r.x0 = (uint16_t)(cu - h > 0 ? cu - h : 0);
        r.y0 = (uint16_t)(cv - h > 0 ? cv - h : 0);
        r.x1 = (uint16_t)(cu + h + 1 < (int32_t)width ? cu + h + 1 : (int32_t)width);
        r.y1 = (uint16_t)(cv + h + 1 < (int32_t)height ? cv + h + 1 : (int32_t)height);
        /* absorb every window the new one touches; growth may reach more, so
         * repeat until none is left (each round removes one of <= MFNS_CENTROID_MAX_ROIS) */
        bool merged = true;
        for (uint16_t round = 0; merged && round <= MFNS_CENTROID_MAX_ROIS; round++) {
            merged = false;
            for (uint16_t k = 0; k < n; k++) {
                if (rois_touch(&r, &rois[k])) {
                    r.x0 = r.x0 < rois[k].x0 ? r.x0 : rois[k].x0;
                    r.y0 = r.y0 < rois[k].y0 ? r.y0 : rois[k].y0;
                    r.x1 = r.x1 > rois[k].x1 ? r.x1 : rois[k].x1;
                    r.y1 = r.y1 > rois[k].y1 ? r.y1 : rois[k].y1;
                    rois[k] = rois[n - 1u];
                    n--;
                    merged = true;
                    break;
                }
            }
        }
        if (n >= max_rois) {
            *n_rois = n;
            return MFNS_CENTROID_ERR_ROI;
        }
        rois[n++] = r;
    }
    *n_rois = n;
    return MFNS_CENTROID_OK;
}
