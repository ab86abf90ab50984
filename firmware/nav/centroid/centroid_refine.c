/* centroid_refine.c -- profile refinement of flat-topped (defocused) blobs
 * (centroid_internal.h; docs/centroiding.md, step 7). */
#include <math.h>

#include "firmware/nav/centroid/centroid.h"
#include "firmware/nav/centroid/centroid_internal.h"
#include "math/units.h"

/* The centre of mass weights every pixel by its offset from the centre, so
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
    const bool wide = mfns_centroid_format_bits(f->format) > 8u;
    float sw = 0.0f, sq = 0.0f, sqq = 0.0f;
    for (uint32_t y = a->y_min; y <= a->y_max; y++) {
        const uint8_t *row = mfns_centroid_row(f, y);
        const float dy = (float)y - v0;
        for (uint32_t x = a->x_min; x <= a->x_max; x++) {
            const uint32_t v = mfns_centroid_pixel(row, x, wide);
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

/* One axis of the refinement window, [*lo, *hi]: the blob's extent [b0, b1]
 * grown by 2 px, cut to the region's [r0, r1) and to centre +- half. */
static void window_axis(uint32_t r0, uint32_t r1, uint16_t b0, uint16_t b1, float centre, float half, int32_t *lo,
                        int32_t *hi)
{
    *lo = (int32_t)fmaxf(fmaxf((float)r0, (float)b0 - 2.0f), floorf(centre - half));
    *hi = (int32_t)fminf(fminf((float)r1 - 1.0f, (float)b1 + 2.0f), ceilf(centre + half));
}

/* One Newton step (du, dv) of the estimating equation above from (u0, v0) for
 * the blurred disk (R, s) of flux `flux` DN; var(r) is taken as f(r) + c (shot
 * noise, with c DN of background noise expressed as signal). The window: the
 * bounding box grown by 2 px, cut to where a(r) is defined and to the region
 * (frame or window) the blob was found in. false when the step is not a
 * finite sub-pixel move (the caller keeps the moment centroid). */
static bool refine_step(const mfns_frame_t *f, const mfns_centroid_region_t *rg, const mfns_centroid_acc_t *a, float b,
                        float c, const mfns_centroid_noise_t *nm, float flux, float R, float s, float u0, float v0,
                        float *du, float *dv, float cov[3])
{
    /* a(r) tabulated on n + 1 nodes r_k = r_lo + k h over [r_lo, r_hi]: outside,
     * the edge derivative is below e^-10 of its peak */
    float tab[MFNS_CENTROID_REFINE_BINS + 1u];
    const float r_lo = fmaxf(0.0f, R - 4.5f * s), r_hi = R + 4.5f * s + 1.0f;
    const float h = fmaxf(0.125f, (r_hi - r_lo) / (float)MFNS_CENTROID_REFINE_BINS);
    uint32_t n = (uint32_t)ceilf((r_hi - r_lo) / h);
    n = n < 1u ? 1u : (n > MFNS_CENTROID_REFINE_BINS ? MFNS_CENTROID_REFINE_BINS : n);
    const float inv_2s2 = 0.5f / (s * s), Rs2 = R / (s * s), norm = 1.0f / (MFNS_PI_F * s * s * s * s);
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
    int32_t x0, x1, y0, y1;
    window_axis(rg->x0, rg->x1, a->x_min, a->x_max, u0, half, &x0, &x1);
    window_axis(rg->y0, rg->y1, a->y_min, a->y_max, v0, half, &y0, &y1);
    if (x1 < x0 || y1 < y0 || x1 - x0 >= MFNS_CENTROID_REFINE_MAX_SIDE || y1 - y0 >= MFNS_CENTROID_REFINE_MAX_SIDE) {
        return false;
    }
    const bool wide = mfns_centroid_format_bits(f->format) > 8u;
    const float inv_h = 1.0f / h, r_lo2 = r_lo * r_lo, r_hi2 = r_hi * r_hi;
    const float fl = nm->floor_dn2, gain = nm->gain_dn_per_e;
    double gx = 0.0, gy = 0.0, hxx = 0.0, hyy = 0.0, hxy = 0.0, vxx = 0.0, vyy = 0.0, vxy = 0.0;
    for (int32_t y = y0; y <= y1; y++) {
        const uint8_t *row = mfns_centroid_row(f, (uint32_t)y);
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
            const float d = (float)mfns_centroid_pixel(row, (uint32_t)x, wide) - b;
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
void mfns_centroid_refine_blob(const mfns_frame_t *f, const mfns_centroid_region_t *rg, const mfns_centroid_acc_t *a,
                               uint32_t T, int64_t l_q8, int64_t b_q8, int64_t t_q8, const mfns_centroid_noise_t *nm,
                               float m2, mfns_blob_t *o)
{
    /* Pre-gate without touching the frame again (after the full-frame scan the
     * blob's rows are out of cache): flatness pi (peak - b) E r^2 / flux is
     * ~1 for a Gaussian and 1/2 for a uniform disk. */
    const float b = (float)b_q8 / (float)MFNS_CENTROID_DN_Q8_ONE;
    const float peak = (float)a->peak - b;
    if (!(MFNS_PI_F * peak * m2 <= MFNS_CENTROID_FLAT_PHI * o->flux_dn)) {
        return;
    }
    const float u0 = mfns_px_q8_to_float(o->u_q8), v0 = mfns_px_q8_to_float(o->v_q8);
    float R, s;
    const float level = (float)l_q8 / (float)MFNS_CENTROID_DN_Q8_ONE;
    if (!blob_shape(f, a, T, level, u0, v0, &R, &s) || !(R >= MFNS_CENTROID_FLAT_RATIO * s) ||
        !(R >= MFNS_CENTROID_REFINE_MIN_RADIUS)) {
        return;
    }
    /* var(r) ~ f(r) + c: the threshold step as the noise floor (>= 1 DN) */
    const float c = fmaxf((float)t_q8 / (float)MFNS_CENTROID_DN_Q8_ONE, 1.0f);
    float du, dv, cov[3];
    if (!refine_step(f, rg, a, b, c, nm, fmaxf(o->flux_dn, 0.0f), R, s, u0, v0, &du, &dv, cov)) {
        return;
    }
    px_q8_t qu, qv;
    if (!mfns_px_q8_from_float_checked(du, &qu) || !mfns_px_q8_from_float_checked(dv, &qv)) {
        return;
    }
    /* |qu|, |qv| <= 256 and the centroid < 2^20: no overflow */
    const px_q8_t u = o->u_q8 + qu, v = o->v_q8 + qv;
    if (u < (px_q8_t)a->x_min * MFNS_PX_Q8_ONE || u > (px_q8_t)a->x_max * MFNS_PX_Q8_ONE ||
        v < (px_q8_t)a->y_min * MFNS_PX_Q8_ONE || v > (px_q8_t)a->y_max * MFNS_PX_Q8_ONE) {
        return;
    }
    o->u_q8 = u;
    o->v_q8 = v;
    o->cov_px2[0] = cov[0]; /* the refined estimator's covariance replaces the moment centroid's */
    o->cov_px2[1] = cov[1];
    o->cov_px2[2] = cov[2];
}
