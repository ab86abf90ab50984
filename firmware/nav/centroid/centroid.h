/* centroid.h -- beacon centroiding: a camera frame in, sub-pixel beacon image
 * positions out (docs/centroiding.md). Portable core: no OS, no heap, no stdio.
 *
 * Use:
 *   static mfns_centroid_work_t work;          caller-owned scratch (static storage)
 *   static mfns_centroid_result_t result;
 *   mfns_centroid_bg_t bg;
 *   st = mfns_centroid_background(&frame, NULL, 0, &work, &bg);         whole frame
 *   st = mfns_centroid_detect(&frame, &settings, &bg, NULL, 0, &work, &result);
 * Tracking: build windows around predicted positions with mfns_centroid_make_rois
 * and pass them to both calls; only the windows are read.
 *
 * Pixel coordinates follow docs/conventions.md: integer coordinates are pixel
 * centres (OpenCV's convention); the centroid is the weighted mean of the
 * pixel-centre coordinates of the blob's pixels, weight = value - (background +
 * MFNS_CENTROID_WEIGHT_LEVEL x threshold step), in px_q8_t (1/256 px);
 * flat-topped (defocused) blobs then get one Newton step of a symmetric-profile
 * likelihood score (MFNS_CENTROID_FLAT_RATIO below, docs/centroiding.md step 7).
 *
 * Covariance: every accepted blob's cov_px2 is the covariance of its (u, v),
 * first-order propagation of the pixel noise through the estimator that made
 * it (the moment centroid, or the refinement's estimating equation), with the
 * pixel variance var(I) = max(bg.noise_dn^2, 1/12) + K (I - background),
 * K = settings.gain_dn_per_e_q12 / MFNS_GAIN_Q12_ONE (DN per electron; 0 = no
 * shot-noise term), plus the px_q8_t rounding. Rejected blobs have all zeros.
 * It is the noise of the centroid, not its systematic error (pixel-phase
 * S-curve, model mismatch); it is as good as bg.noise_dn and K are.
 * docs/centroiding.md "Centroid covariance": derivation, limits, cost.
 *
 * Bounds: width and height <= MFNS_CENTROID_MAX_DIM; at most
 * MFNS_CENTROID_MAX_LABELS provisional components per call, at most
 * MFNS_MAX_BLOBS_PER_CAMERA blobs reported; at most MFNS_CENTROID_MAX_ROIS
 * windows. Every loop is bounded by the frame (or window) size and these
 * constants. A frame with more blobs than the tables hold returns
 * MFNS_CENTROID_TABLE_FULL with the blobs that fit and the count of the rest;
 * the tables never overflow.
 */
#ifndef MFNS_CENTROID_H
#define MFNS_CENTROID_H

#include <stdbool.h>
#include <stdint.h>

#include "math/fixed.h"
#include "firmware/nav/settings/nav_settings.h"

/* Largest frame side. 4096 keeps a coordinate in 12 bits, which the moment
 * bounds below rely on. */
#define MFNS_CENTROID_MAX_DIM 4096
/* Provisional component labels per call (components that later merge each
 * used one). 4x the reported table leaves room for U-shaped merges. */
#define MFNS_CENTROID_MAX_LABELS (4 * MFNS_MAX_BLOBS_PER_CAMERA)
/* Runs per row: at most one run per two pixels. */
#define MFNS_CENTROID_MAX_RUNS ((MFNS_CENTROID_MAX_DIM + 1) / 2)
#define MFNS_CENTROID_MAX_ROIS 32
/* Moments are accumulated for at most this many pixels per blob; a larger blob
 * is always TOO_LARGE (max_area_px is 16-bit) and gets no moment centroid. */
#define MFNS_CENTROID_MOMENT_AREA_CAP 65535u
/* Pixel weights are value - (background + WEIGHT_LEVEL * threshold step):
 * a pixel that just crosses the threshold enters with a small weight, so the
 * sub-pixel phase and noise moving pixels in and out of the blob hardly move
 * the centroid (the truncation "S-curve"). 0 = plain background subtraction.
 * Chosen from the Monte Carlo of tests/unit/test_centroid.c (docs/centroiding.md). */
#define MFNS_CENTROID_WEIGHT_LEVEL 0.75f
/* Profile refinement (docs/centroiding.md, step 7): an accepted blob whose
 * fitted blurred-disk shape has radius R >= FLAT_RATIO x edge blur s (a flat
 * top) gets its centre re-estimated by one Newton step of the symmetric-profile
 * likelihood score, with the profile weight tabulated on at most REFINE_BINS
 * radial intervals, over a window of at most REFINE_MAX_SIDE px a side (larger
 * blobs keep the moment centroid). REFINE_MIN_BLUR bounds s from below (the
 * pixel itself blurs by 1/12 px^2 per axis). */
#define MFNS_CENTROID_FLAT_RATIO 3.0f
#define MFNS_CENTROID_FLAT_PHI 0.75f
#define MFNS_CENTROID_REFINE_BINS 128u
#define MFNS_CENTROID_REFINE_MAX_SIDE 96
#define MFNS_CENTROID_REFINE_MIN_BLUR 0.3f
#define MFNS_CENTROID_REFINE_MIN_RADIUS 1.75f
/* Centroid covariance (docs/centroiding.md, "Centroid covariance"): the pixel
 * noise floor is at least the rounding of the pixel to whole DN, 1/12 DN^2
 * (a background estimate of 0, e.g. a caller's noise-free frame, still leaves
 * it), and the reported centroid carries its own rounding to px_q8_t,
 * 1/12 LSB^2 per axis. */
#define MFNS_CENTROID_QUANT_VAR_DN2 (1.0f / 12.0f)
#define MFNS_CENTROID_Q8_VAR_PX2 (1.0 / (12.0 * (double)MFNS_PX_Q8_ONE * (double)MFNS_PX_Q8_ONE))
/* Background estimate: at most this many sampled pixels, two passes. */
#define MFNS_CENTROID_BG_MAX_SAMPLES 8192u
#define MFNS_CENTROID_HIST_BINS 1024u

typedef enum {
    MFNS_CENTROID_OK = 0,
    MFNS_CENTROID_TABLE_FULL = 1,     /* result valid but incomplete: more blobs than the tables hold */
    MFNS_CENTROID_ERR_NULL = -1,      /* a required pointer is NULL */
    MFNS_CENTROID_ERR_SIZE = -2,      /* width or height 0 or > MFNS_CENTROID_MAX_DIM */
    MFNS_CENTROID_ERR_STRIDE = -3,    /* stride smaller than a row, or not a whole number of 16-bit words */
    MFNS_CENTROID_ERR_FORMAT = -4,    /* unsupported pixel format */
    MFNS_CENTROID_ERR_SETTINGS = -5,  /* settings out of range (k_sigma, areas, elongation) */
    MFNS_CENTROID_ERR_ROI = -6,       /* a window empty, outside the frame, overlapping another, or too many */
    MFNS_CENTROID_ERR_BACKGROUND = -7 /* background/noise not finite, negative, or beyond the format */
} mfns_centroid_status_t;

const char *mfns_centroid_strerror(mfns_centroid_status_t s);

typedef enum {
    MFNS_PIXFMT_GREY = 0, /* 8-bit, one byte per pixel */
    MFNS_PIXFMT_Y10 = 1,  /* 10-bit in the low bits of 16-bit words (V4L2 Y10), native byte order */
    MFNS_PIXFMT_Y12 = 2,  /* 12-bit in 16-bit words (V4L2 Y12) */
    MFNS_PIXFMT_Y16 = 3   /* 16-bit words (V4L2 Y16) */
} mfns_pixfmt_t;

/* One frame as the camera delivers it. Rows may be padded (stride >= width *
 * bytes per pixel); 16-bit frames need an even stride. */
typedef struct {
    const void *data;
    uint16_t width, height;
    uint32_t stride_bytes;
    mfns_pixfmt_t format;
} mfns_frame_t;

/* A window [x0, x1) x [y0, y1) in pixels. Windows of one call must not overlap
 * (mfns_centroid_make_rois merges overlapping ones). */
typedef struct {
    uint16_t x0, y0, x1, y1;
} mfns_roi_t;

/* Background level and noise of a frame (DN). */
typedef struct {
    float background_dn; /* median of the sampled pixels */
    float noise_dn;      /* 1.4826 x their median absolute deviation */
    uint32_t n_samples;
} mfns_centroid_bg_t;

/* Rejection reasons, a bit set per blob; 0 = accepted. */
#define MFNS_BLOB_TOO_SMALL 0x01u    /* area < min_area_px (noise, hot pixel) */
#define MFNS_BLOB_TOO_LARGE 0x02u    /* area > max_area_px (glare, reflection) */
#define MFNS_BLOB_SATURATED 0x04u    /* a pixel at or above the saturation level */
#define MFNS_BLOB_IMAGE_BORDER 0x08u /* touches the image edge: part of the spot may be cut */
#define MFNS_BLOB_ROI_BORDER 0x10u   /* touches a window edge that is not the image edge */
#define MFNS_BLOB_ELONGATED 0x20u    /* second-moment eigenvalue ratio > max_elongation */
#define MFNS_BLOB_TABLE_FULL 0x40u   /* joined pixels that found no free label: incomplete */

/* Name of one reason bit ("too small", ...), "?" for anything else. */
const char *mfns_blob_reason_name(uint16_t reason_bit);

typedef struct {
    px_q8_t u_q8, v_q8;     /* centroid (column, row), Q23.8 px; the bounding-box centre when
                               the blob exceeds MFNS_CENTROID_MOMENT_AREA_CAP (then TOO_LARGE) */
    uint32_t area_px;       /* pixels above threshold (8-connected) */
    float flux_dn;          /* sum of (pixel - background) over the blob */
    uint16_t peak_dn;       /* largest pixel value */
    uint16_t x_min, y_min, x_max, y_max; /* bounding box, inclusive */
    float elongation;       /* lambda_max / lambda_min of the second moments (>= 1) */
    bool saturated;         /* peak >= saturation level */
    uint16_t reasons;       /* MFNS_BLOB_* bits; 0 = accepted */
    uint8_t roi;            /* window index, MFNS_CENTROID_FULL_FRAME for a full-frame call */
    float cov_px2[3];       /* covariance of (u, v) predicted from the photometry (px^2):
                               var u, cov uv, var v; positive definite for every accepted
                               blob, all zero for a rejected one (header comment) */
} mfns_blob_t;
#define MFNS_CENTROID_FULL_FRAME 0xFFu

typedef struct {
    uint16_t n_blobs;    /* entries of blob[]: accepted ones first, then rejected */
    uint16_t n_accepted; /* blob[0 .. n_accepted) have reasons == 0 */
    uint32_t n_lost;     /* blobs (or pixel runs) that fitted in no table; > 0 iff TABLE_FULL */
    uint32_t threshold_dn; /* a pixel belongs to a blob when value >= threshold_dn (may exceed
                              the format's maximum: then no pixel does) */
    mfns_centroid_bg_t bg;
    mfns_blob_t blob[MFNS_MAX_BLOBS_PER_CAMERA];
} mfns_centroid_result_t;

/* Scratch of one call: the caller provides it as static storage (~60 KB).
 * Its contents are meaningless between calls. */
typedef struct {
    uint16_t x0, x1; /* inclusive */
    uint16_t label;
} mfns_centroid_run_t;

typedef struct {
    /* Accumulator widths, for a blob of at most N = 2^16 pixels
     * (MFNS_CENTROID_MOMENT_AREA_CAP), values I < 2^16 and coordinates x, y < 2^12:
     *   s_i            <= N I          < 2^32
     *   s_ix, s_iy     <= N I x        < 2^44
     *   s_ixx, s_iyy, s_ixy <= N I x^2 < 2^56   -> uint64_t, with 2^8 to spare
     *   s_x, s_y       <= N x          < 2^28
     *   s_xx, s_yy, s_xy <= N x^2      < 2^40   -> uint64_t
     * The background-subtracted Q8 sums formed from them (256 s_ix - b_q8 s_x
     * with b_q8 < 2^24) stay below 2^53, within int64_t. */
    union {
        struct {
            uint64_t s_i, s_ix, s_iy, s_ixx, s_iyy, s_ixy;
            uint64_t s_x, s_y, s_xx, s_yy, s_xy;
        };
        uint64_t sums[11]; /* the same eleven sums as one array: merging two blobs adds them in a loop */
    };
    uint32_t area; /* all pixels, saturating; may exceed the moment cap */
    uint32_t moment_area;
    uint16_t peak;
    uint16_t x_min, y_min, x_max, y_max;
    uint8_t roi;
    bool incomplete;
    bool moments_capped;
} mfns_centroid_acc_t;

typedef struct {
    mfns_centroid_run_t runs[2][MFNS_CENTROID_MAX_RUNS];
    uint16_t parent[MFNS_CENTROID_MAX_LABELS];
    mfns_centroid_acc_t acc[MFNS_CENTROID_MAX_LABELS];
    uint32_t hist[4 * MFNS_CENTROID_HIST_BINS];
} mfns_centroid_work_t;

/* Settings: the calibration table's (mfns_caltable_t.centroid). The default
 * set, which every table built with defaults carries, is
 * mfns_centroid_settings_default (nav_settings.h, nav_defaults_gen.c): the one set. */

/* Median and MAD of at most MFNS_CENTROID_BG_MAX_SAMPLES pixels on a regular
 * grid over the frame (rois == NULL, n_rois == 0) or over the windows.
 * Two histogram passes of MFNS_CENTROID_HIST_BINS bins; values inside a bin are
 * taken as uniform, so the estimates are not quantised to whole DN. */
mfns_centroid_status_t mfns_centroid_background(const mfns_frame_t *frame, const mfns_roi_t *rois, uint16_t n_rois,
                                                mfns_centroid_work_t *work, mfns_centroid_bg_t *bg);

/* Threshold, 8-connected components in one pass, moments, centroids and
 * rejections, over the frame (rois == NULL, n_rois == 0) or the windows.
 * threshold = background + (settings->threshold_dn if > 0, else k_sigma * noise);
 * a pixel belongs to a blob when its value exceeds it. On an error *out is
 * zeroed (n_blobs = 0). */
mfns_centroid_status_t mfns_centroid_detect(const mfns_frame_t *frame, const mfns_centroid_settings_t *settings,
                                            const mfns_centroid_bg_t *bg, const mfns_roi_t *rois, uint16_t n_rois,
                                            mfns_centroid_work_t *work, mfns_centroid_result_t *out);

/* Windows of half size `half_size_px` around each predicted (u, v) (pixel
 * centres, px), clipped to the frame; overlapping windows are merged into their
 * bounding box until none overlap. Predictions outside the frame or not finite
 * are skipped. *n_rois <= max_rois (<= MFNS_CENTROID_MAX_ROIS); ERR_ROI when
 * more windows are needed than fit. */
mfns_centroid_status_t mfns_centroid_make_rois(const float (*uv)[2], uint16_t n_pred, uint16_t half_size_px,
                                               uint16_t width, uint16_t height, mfns_roi_t *rois, uint16_t max_rois,
                                               uint16_t *n_rois);

#endif /* MFNS_CENTROID_H */
