/* centroid_background.c -- background level and noise of a frame
 * (mfns_centroid_background, centroid.h; docs/centroiding.md): median and
 * MAD from histograms of a sample grid. */
#include <math.h>
#include <string.h>

#include "firmware/nav/centroid/centroid.h"
#include "firmware/nav/centroid/centroid_internal.h"

/* The noise sigma of a Gaussian from its median absolute deviation,
 * 1 / Phi^-1(3/4) (centroid.h: noise_dn = 1.4826 x MAD). */
#define MAD_TO_SIGMA 1.4826f

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

/* One histogram pass over the sample grid: bins of 2^shift DN from lo. The
 * samples of a row are counted before the row is read, so the cap is checked
 * once per row. */
static void hist_pass(const mfns_frame_t *f, const mfns_centroid_region_t *reg, uint16_t n_reg, uint32_t step, uint32_t *h,
                      hist_desc_t *d)
{
    const bool wide = mfns_centroid_format_bits(f->format) > 8u;
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
            const uint8_t *row = mfns_centroid_row(f, y);
            uint32_t under = 0, over = 0;
            for (uint32_t i = 0, x = xs; i < cnt; i++, x += step) {
                const uint32_t v = wide ? mfns_centroid_pixel(row, x, true) : row[x];
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
    const mfns_centroid_status_t st = mfns_centroid_check_inputs(frame, rois, n_rois);
    if (st != MFNS_CENTROID_OK) {
        return st;
    }
    mfns_centroid_region_t reg[MFNS_CENTROID_MAX_ROIS];
    const uint16_t n_reg = mfns_centroid_regions(frame, rois, n_rois, reg);
    uint64_t pixels = 0;
    for (uint16_t r = 0; r < n_reg; r++) {
        pixels += (uint64_t)(reg[r].x1 - reg[r].x0) * (reg[r].y1 - reg[r].y0);
    }
    /* grid step: about MFNS_CENTROID_BG_MAX_SAMPLES samples in all */
    uint32_t step = 1u;
    while (step < MFNS_CENTROID_MAX_DIM && (uint64_t)step * step * MFNS_CENTROID_BG_MAX_SAMPLES < pixels) {
        step++;
    }
    const unsigned bits = mfns_centroid_format_bits(frame->format);
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
    bg->noise_dn = MAD_TO_SIGMA * mad;
    bg->n_samples = d.n;
    return MFNS_CENTROID_OK;
}
