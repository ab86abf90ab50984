/* centroid.c -- beacon centroiding (centroid.h, docs/centroiding.md): the
 * statuses, the input checks and mfns_centroid_detect, the pipeline that runs
 * the other centroid*.c files' steps in order (centroid_internal.h lists them). */
#include "firmware/nav/centroid/centroid.h"
#include "math/core_text.h"

#include <math.h>
#include <string.h>

#include "firmware/nav/centroid/centroid_internal.h"

const char *mfns_centroid_strerror(mfns_centroid_status_t s)
{
    switch (s) {
    case MFNS_CENTROID_OK:
        return MFNS_MSG("ok");
    case MFNS_CENTROID_TABLE_FULL:
        return MFNS_MSG("more blobs than the blob/label tables hold: result incomplete");
    case MFNS_CENTROID_ERR_NULL:
        return MFNS_MSG("a required pointer is NULL");
    case MFNS_CENTROID_ERR_SIZE:
        return MFNS_MSG("frame width or height is 0 or larger than MFNS_CENTROID_MAX_DIM");
    case MFNS_CENTROID_ERR_STRIDE:
        return MFNS_MSG("frame stride smaller than a row or not a whole number of pixels");
    case MFNS_CENTROID_ERR_FORMAT:
        return MFNS_MSG("unsupported pixel format (GREY, Y10, Y12, Y16 only)");
    case MFNS_CENTROID_ERR_SETTINGS:
        return MFNS_MSG("centroid settings out of range");
    case MFNS_CENTROID_ERR_ROI:
        return MFNS_MSG("window empty, outside the frame, overlapping another, or too many windows");
    case MFNS_CENTROID_ERR_BACKGROUND:
        return MFNS_MSG("background or noise estimate not finite, negative or beyond the pixel format");
    default:
        return MFNS_MSG("unknown centroid status");
    }
}

const char *mfns_blob_reason_name(uint16_t reason_bit)
{
    switch (reason_bit) {
    case MFNS_BLOB_TOO_SMALL:
        return MFNS_MSG("too small");
    case MFNS_BLOB_TOO_LARGE:
        return MFNS_MSG("too large");
    case MFNS_BLOB_SATURATED:
        return MFNS_MSG("saturated");
    case MFNS_BLOB_IMAGE_BORDER:
        return MFNS_MSG("touches image border");
    case MFNS_BLOB_ROI_BORDER:
        return MFNS_MSG("touches window border");
    case MFNS_BLOB_ELONGATED:
        return MFNS_MSG("elongated");
    case MFNS_BLOB_TABLE_FULL:
        return MFNS_MSG("incomplete: label table full");
    default:
        return MFNS_MSG("?");
    }
}

/* ------------------------------------------------------------------------ */
/* Input checks */

static mfns_centroid_status_t check_frame(const mfns_frame_t *f)
{
    if (f == NULL || f->data == NULL) {
        return MFNS_CENTROID_ERR_NULL;
    }
    const unsigned bits = mfns_centroid_format_bits(f->format);
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

mfns_centroid_status_t mfns_centroid_check_inputs(const mfns_frame_t *f, const mfns_roi_t *rois, uint16_t n_rois)
{
    const mfns_centroid_status_t st = check_frame(f);
    return st != MFNS_CENTROID_OK ? st : check_rois(f, rois, n_rois);
}

uint16_t mfns_centroid_regions(const mfns_frame_t *f, const mfns_roi_t *rois, uint16_t n_rois,
                               mfns_centroid_region_t *reg)
{
    if (n_rois == 0u) {
        reg[0] = (mfns_centroid_region_t){0u, 0u, f->width, f->height};
        return 1u;
    }
    for (uint16_t i = 0; i < n_rois; i++) {
        reg[i] = (mfns_centroid_region_t){rois[i].x0, rois[i].y0, rois[i].x1, rois[i].y1};
    }
    return n_rois;
}

/* ------------------------------------------------------------------------ */
/* The pipeline: threshold, label, per-blob results, refinement */

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
    mfns_centroid_status_t st = mfns_centroid_check_inputs(frame, rois, n_rois);
    if (st != MFNS_CENTROID_OK) {
        return st;
    }
    st = check_settings(settings);
    if (st != MFNS_CENTROID_OK) {
        return st;
    }
    const uint32_t maxval = (1u << mfns_centroid_format_bits(frame->format)) - 1u;
    if (!(isfinite(bg->background_dn) && isfinite(bg->noise_dn) && bg->background_dn >= 0.0f &&
          bg->noise_dn >= 0.0f && bg->background_dn <= (float)maxval && bg->noise_dn <= (float)maxval)) {
        return MFNS_CENTROID_ERR_BACKGROUND;
    }
    const uint32_t sat = settings->saturation_dn != 0u ? settings->saturation_dn : maxval;
    const float t = settings->threshold_dn > 0u ? (float)settings->threshold_dn
                                                : settings->threshold_k_sigma * bg->noise_dn;
    /* both < 2^24 (checked above): exact integer Q8 arithmetic below */
    const int64_t b_q8 = (int64_t)lroundf(bg->background_dn * (float)MFNS_CENTROID_DN_Q8_ONE);
    const int64_t t_q8 = (int64_t)lroundf(fminf(t, 131072.0f) * (float)MFNS_CENTROID_DN_Q8_ONE);
    const uint32_t T = (uint32_t)((b_q8 + t_q8) / MFNS_CENTROID_DN_Q8_ONE + 1); /* 256 T > b_q8 + t_q8 */
    const int64_t l_q8 = b_q8 + (int64_t)lroundf(MFNS_CENTROID_WEIGHT_LEVEL * (float)t_q8);
    out->threshold_dn = T;
    out->bg = *bg;
    const mfns_centroid_noise_t nm = {fmaxf(bg->noise_dn * bg->noise_dn, MFNS_CENTROID_QUANT_VAR_DN2),
                                      (float)settings->gain_dn_per_e_q12 / MFNS_GAIN_Q12_ONE};

    mfns_centroid_region_t reg[MFNS_CENTROID_MAX_ROIS];
    const uint16_t n_reg = mfns_centroid_regions(frame, rois, n_rois, reg);
    mfns_centroid_labels_t ls = {work, 0u, 0u};
    if (T <= maxval) {
        for (uint16_t r = 0; r < n_reg; r++) {
            const uint8_t roi = n_rois == 0u ? (uint8_t)MFNS_CENTROID_FULL_FRAME : (uint8_t)r;
            mfns_centroid_label_region(&ls, frame, &reg[r], T, roi);
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
            mfns_centroid_finish_blob(&work->acc[l], l_q8, b_q8, &nm, settings, sat, frame, rois, n_rois, &b, &m2);
            if ((pass == 0) != (b.reasons == 0u)) {
                continue;
            }
            if (out->n_blobs >= MFNS_MAX_BLOBS_PER_CAMERA) {
                ls.n_lost++;
                continue;
            }
            if (pass == 0) {
                const mfns_centroid_region_t *rg = &reg[n_rois == 0u ? 0u : work->acc[l].roi];
                mfns_centroid_refine_blob(frame, rg, &work->acc[l], T, l_q8, b_q8, t_q8, &nm, m2, &b);
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
