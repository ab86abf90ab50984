/* centroid_internal.h -- what the centroider's own files share among
 * themselves; not part of the flight API, which is centroid.h. Only
 * firmware/nav/centroid*.c include it.
 *
 * The files, one job each (docs/centroiding.md gives the steps):
 *   centroid.c             statuses, input checks, mfns_centroid_detect (the pipeline)
 *   centroid_background.c  background level and noise: median and MAD of a sample grid
 *   centroid_label.c       threshold scan and 8-connected labelling (blob growth, moments sums)
 *   centroid_blob.c        per-blob results: moment centroid, shape, covariance, rejection
 *   centroid_refine.c      profile refinement of flat-topped (defocused) blobs
 *   centroid_rois.c        tracking windows around predicted positions
 * The default settings are not here: nav_defaults_gen.c holds the one set the
 * calibration table carries (mfns_centroid_settings_default, nav_settings.h).
 */
#ifndef MFNS_CENTROID_INTERNAL_H
#define MFNS_CENTROID_INTERNAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "firmware/nav/centroid/centroid.h"
#include "math/fixed.h"

/* Levels in DN (background, threshold step, weight level) are carried as Q8
 * DN, the scale of px_q8_t (fixed.h): the moment sums divided by the Q8
 * weight give the centroid in px_q8_t directly. */
#define MFNS_CENTROID_DN_Q8_ONE ((int64_t)MFNS_PX_Q8_ONE)

/* A run that found no free label (centroid_label.c). */
#define MFNS_CENTROID_LABEL_DROPPED 0xFFFFu

/* ------------------------------------------------------------------------ */
/* The invariants the comments of centroid.h state, checked by the compiler. */

/* "4096 keeps a coordinate in 12 bits, which the moment bounds rely on" */
_Static_assert(MFNS_CENTROID_MAX_DIM <= (1 << 12), "frame coordinates must fit in 12 bits (moment bounds)");
/* coordinates are stored in uint16_t (runs, bounding boxes, windows) */
_Static_assert(MFNS_CENTROID_MAX_DIM <= UINT16_MAX, "frame coordinates are uint16_t");
/* "a larger blob is always TOO_LARGE (max_area_px is 16-bit)"; N <= 2^16 in the widths */
_Static_assert(MFNS_CENTROID_MOMENT_AREA_CAP <= UINT16_MAX, "moment area cap above max_area_px's range");
/* the accumulator widths: N I x^2 < 2^16 * 2^16 * 2^24 = 2^56 within uint64_t, with 2^8 to spare */
_Static_assert((uint64_t)MFNS_CENTROID_MOMENT_AREA_CAP * UINT16_MAX * MFNS_CENTROID_MAX_DIM * MFNS_CENTROID_MAX_DIM <
                   (1ull << 56),
               "second-moment sums would exceed 2^56");
/* the accumulator's named sums and its sums[] array are the same storage */
_Static_assert(offsetof(mfns_centroid_acc_t, s_xy) == offsetof(mfns_centroid_acc_t, sums) + 10u * sizeof(uint64_t) &&
                   sizeof(((mfns_centroid_acc_t *)0)->sums) == 11u * sizeof(uint64_t),
               "acc.sums must alias s_i .. s_xy exactly");
/* labels are uint16_t and MFNS_CENTROID_LABEL_DROPPED is never a real one */
_Static_assert(MFNS_CENTROID_MAX_LABELS < MFNS_CENTROID_LABEL_DROPPED, "labels must fit below LABEL_DROPPED");
/* "at most one run per two pixels" */
_Static_assert(2 * MFNS_CENTROID_MAX_RUNS >= MFNS_CENTROID_MAX_DIM, "run table smaller than a row's runs");
/* a window index is a uint8_t below MFNS_CENTROID_FULL_FRAME */
_Static_assert(MFNS_CENTROID_MAX_ROIS < MFNS_CENTROID_FULL_FRAME, "window indices must stay below FULL_FRAME");
/* n_blobs / n_accepted are uint16_t */
_Static_assert(MFNS_MAX_BLOBS_PER_CAMERA <= UINT16_MAX, "blob counts are uint16_t");
/* the background's four interleaved sub-histograms of HIST_BINS bins each */
_Static_assert(sizeof(((mfns_centroid_work_t *)0)->hist) ==
                   4u * MFNS_CENTROID_HIST_BINS * sizeof(((mfns_centroid_work_t *)0)->hist[0]),
               "work.hist holds four sub-histograms");
/* the background's pass 1 puts a format's whole range (<= 16 bits) in HIST_BINS = 2^10 bins */
_Static_assert(MFNS_CENTROID_HIST_BINS == 1024u, "pass 1 bins are 2^(bits - 10) DN wide");

/* ------------------------------------------------------------------------ */
/* Frame access (inline: the scans call them per pixel). */

static inline unsigned mfns_centroid_format_bits(mfns_pixfmt_t f)
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

static inline const uint8_t *mfns_centroid_row(const mfns_frame_t *f, uint32_t y)
{
    return (const uint8_t *)f->data + (size_t)y * f->stride_bytes;
}

static inline uint32_t mfns_centroid_pixel(const uint8_t *row, uint32_t x, bool wide)
{
    if (wide) {
        uint16_t v;
        memcpy(&v, row + 2u * x, sizeof v);
        return v;
    }
    return row[x];
}

/* A region to scan, [x0, x1) x [y0, y1): the whole frame or one window. */
typedef struct {
    uint32_t x0, y0, x1, y1;
} mfns_centroid_region_t;

/* Input checks (centroid.c): the frame (pointer, format, size, stride), then
 * the windows (count, inside the frame, none overlapping). */
mfns_centroid_status_t mfns_centroid_check_inputs(const mfns_frame_t *f, const mfns_roi_t *rois, uint16_t n_rois);

/* The regions of a call: the frame (n_rois == 0) or the windows; reg holds
 * MFNS_CENTROID_MAX_ROIS. Returns their count (centroid.c). */
uint16_t mfns_centroid_regions(const mfns_frame_t *f, const mfns_roi_t *rois, uint16_t n_rois,
                               mfns_centroid_region_t *reg);

/* ------------------------------------------------------------------------ */
/* Labelling (centroid_label.c): union-find over provisional labels, the
 * accumulators at the roots (work->acc), work->parent the forest. */

typedef struct {
    mfns_centroid_work_t *w;
    uint32_t n_labels; /* provisional labels used, <= MFNS_CENTROID_MAX_LABELS */
    uint32_t n_lost;   /* runs and blobs that found no room */
} mfns_centroid_labels_t;

/* One region in one pass: scan each row for runs of pixels >= T, label them
 * against the previous row's runs; roi is the region's window index (or
 * MFNS_CENTROID_FULL_FRAME). */
void mfns_centroid_label_region(mfns_centroid_labels_t *ls, const mfns_frame_t *f, const mfns_centroid_region_t *rg,
                                uint32_t T, uint8_t roi);

/* ------------------------------------------------------------------------ */
/* Per-blob results (centroid_blob.c, centroid_refine.c). */

/* Pixel noise model of the covariance (docs/centroiding.md, "Centroid
 * covariance"): var(I_i) = floor_dn2 + gain (I_i - b), the background noise
 * (which holds the read noise, the background's shot noise and the 1/12 DN^2
 * of rounding) plus the shot noise of the spot's own signal. */
typedef struct {
    float floor_dn2; /* max(noise_dn^2, MFNS_CENTROID_QUANT_VAR_DN2) */
    float gain_dn_per_e;
} mfns_centroid_noise_t;

/* The blob of accumulator a: moment centroid, flux, shape, rejection reasons
 * and (accepted blobs only, zero otherwise) the moment centroid's covariance.
 * l_q8: the weight level (pixel weight = value - level), b_q8 the background,
 * both Q8 DN with l_q8 >= b_q8 and 256 T > l_q8; sat the saturation level.
 * *m2 = E r^2 of the pixel centres about the centroid (0 without moments),
 * the refinement's pre-gate. */
void mfns_centroid_finish_blob(const mfns_centroid_acc_t *a, int64_t l_q8, int64_t b_q8,
                               const mfns_centroid_noise_t *nm, const mfns_centroid_settings_t *s, uint32_t sat,
                               const mfns_frame_t *f, const mfns_roi_t *rois, uint16_t n_rois, mfns_blob_t *o,
                               float *m2);

/* Replace the moment centroid (and covariance) of the accepted blob o by the
 * profile-refined one when the blob is flat-topped and the step succeeds
 * (docs/centroiding.md step 7); rg is the region the blob was found in,
 * t_q8 the threshold step (Q8 DN). Lives in its own file, so it is never
 * inlined into mfns_centroid_detect: inlined it changed the code generated
 * for the frame scan (measured: ~25 % slower). */
void mfns_centroid_refine_blob(const mfns_frame_t *f, const mfns_centroid_region_t *rg, const mfns_centroid_acc_t *a,
                               uint32_t T, int64_t l_q8, int64_t b_q8, int64_t t_q8, const mfns_centroid_noise_t *nm,
                               float m2, mfns_blob_t *o);

#endif /* MFNS_CENTROID_INTERNAL_H */
