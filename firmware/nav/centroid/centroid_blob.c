/* centroid_blob.c -- per-blob results (centroid_internal.h): the moment
 * centroid, flux and shape from a blob's accumulated sums, its covariance
 * (docs/centroiding.md "Centroid covariance") and the rejection reasons. */
#include <math.h>
#include <string.h>

#include "firmware/nav/centroid/centroid.h"
#include "firmware/nav/centroid/centroid_internal.h"

void mfns_centroid_finish_blob(const mfns_centroid_acc_t *a, int64_t l_q8, int64_t b_q8,
                               const mfns_centroid_noise_t *nm, const mfns_centroid_settings_t *s, uint32_t sat,
                               const mfns_frame_t *f, const mfns_roi_t *rois, uint16_t n_rois, mfns_blob_t *o,
                               float *m2)
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
        const int64_t w = MFNS_CENTROID_DN_Q8_ONE * (int64_t)a->s_i - l_q8 * n;
        const int64_t mx = MFNS_CENTROID_DN_Q8_ONE * (int64_t)a->s_ix - l_q8 * (int64_t)a->s_x;
        const int64_t my = MFNS_CENTROID_DN_Q8_ONE * (int64_t)a->s_iy - l_q8 * (int64_t)a->s_y;
        have_moments = mfns_px_q8_from_ratio(mx, w, &o->u_q8) && mfns_px_q8_from_ratio(my, w, &o->v_q8);
        o->flux_dn = (float)(MFNS_CENTROID_DN_Q8_ONE * (int64_t)a->s_i - b_q8 * n) / (float)MFNS_CENTROID_DN_Q8_ONE;
        /* Shape: second moments about the bounding-box corner (exact in
         * integers), then double: the raw sums reach 2^56 and the background
         * subtraction cancels, which float's 24 bits would not survive. With
         * dx = s_x - ax n, sum (x - ax)^2 = s_xx - 2 ax s_x + ax^2 n is
         * s_xx - ax (s_x + dx) (and so on, fewer 64-bit products); every term
         * stays below 2^58, so the integers are exactly those of the plain form. */
        const int64_t ax = a->x_min, ay = a->y_min;
        const int64_t s_i = (int64_t)a->s_i, s_ix = (int64_t)a->s_ix, s_iy = (int64_t)a->s_iy;
        const int64_t s_x = (int64_t)a->s_x, s_y = (int64_t)a->s_y;
        const int64_t dix = s_ix - ax * s_i, diy = s_iy - ay * s_i, dx = s_x - ax * n, dy = s_y - ay * n;
        const double cixx = (double)((int64_t)a->s_ixx - ax * (s_ix + dix));
        const double ciyy = (double)((int64_t)a->s_iyy - ay * (s_iy + diy));
        const double cixy = (double)((int64_t)a->s_ixy - ax * s_iy - ay * dix);
        const double cix = (double)dix, ciy = (double)diy;
        const double cxx = (double)((int64_t)a->s_xx - ax * (s_x + dx));
        const double cyy = (double)((int64_t)a->s_yy - ay * (s_y + dy));
        const double cxy = (double)((int64_t)a->s_xy - ax * s_y - ay * dx);
        const double cx = (double)dx, cy = (double)dy;
        const double B = (double)l_q8 / (double)MFNS_CENTROID_DN_Q8_ONE, W = (double)w / (double)MFNS_CENTROID_DN_Q8_ONE;
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
        const double lb = (double)(l_q8 - b_q8) / (double)MFNS_CENTROID_DN_Q8_ONE;
        const double fl = (double)nm->floor_dn2, g = (double)nm->gain_dn_per_e;
        const double sxx = W * (mxx - 1.0 / 12.0) + lb * gxx, syy = W * (myy - 1.0 / 12.0) + lb * gyy;
        const double sxy = W * mxy + lb * gxy;
        const double inv_w2 = 1.0 / (W * W);
        cov[0] = (fl * gxx + g * sxx) * inv_w2 + MFNS_CENTROID_Q8_VAR_PX2;
        cov[1] = (fl * gxy + g * sxy) * inv_w2;
        cov[2] = (fl * gyy + g * syy) * inv_w2 + MFNS_CENTROID_Q8_VAR_PX2;
    }
    if (!have_moments) {
        /* no moment centroid for blobs beyond the cap: bounding-box centre */
        o->u_q8 = (px_q8_t)(((int32_t)a->x_min + (int32_t)a->x_max) * (MFNS_PX_Q8_ONE / 2));
        o->v_q8 = (px_q8_t)(((int32_t)a->y_min + (int32_t)a->y_max) * (MFNS_PX_Q8_ONE / 2));
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
