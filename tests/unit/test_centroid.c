/* Unit tests of firmware/nav/centroid: accuracy against the Cramer-Rao bound
 * on synthetic frames (Gaussian and defocused-disk spots, shot + read noise,
 * 8- and 16-bit, padded stride), false blobs on pure noise, table overflow,
 * ROI mode against full frame, every rejection reason, the word-at-a-time
 * threshold scan against a per-pixel count, and malformed inputs. */
#include "tests/unit/support/testutil.h"

#include <stdlib.h>
#include <string.h>

#include "firmware/nav/centroid/centroid.h"
#include "tests/unit/support/centroid_synth.h"

static mfns_centroid_work_t g_work;
static mfns_centroid_result_t g_res;

/* The settings that fly: the defaults every calibration table built with
 * defaults carries (nav_defaults_gen.c). A test that needs other values sets them
 * after this call and says why. */
static mfns_centroid_settings_t flight_settings(void)
{
    mfns_centroid_settings_t s;
    mfns_centroid_settings_default(&s);
    return s;
}

#define FB_W 1280
#define FB_H 1024
#define PAD 40 /* bytes of row padding, filled with 0xFF: must never be read */
static uint8_t g_fb[(size_t)FB_H * (2 * FB_W + PAD)];
static double g_mu[(size_t)FB_W * FB_H];

typedef struct {
    mfns_pixfmt_t fmt;
    uint16_t w, h;
    double bg;    /* background (DN) */
    double read;  /* read noise (DN rms) */
    double gshot; /* shot-noise variance per DN of signal (DN/e-) */
} scene_t;

static uint32_t fmt_bits(mfns_pixfmt_t f)
{
    return f == MFNS_PIXFMT_GREY ? 8u : f == MFNS_PIXFMT_Y10 ? 10u : f == MFNS_PIXFMT_Y12 ? 12u : 16u;
}

static uint32_t bpp_of(mfns_pixfmt_t f)
{
    return f == MFNS_PIXFMT_GREY ? 1u : 2u;
}

static mfns_frame_t frame_of(const scene_t *sc)
{
    const mfns_frame_t f = {g_fb, sc->w, sc->h, (uint32_t)sc->w * bpp_of(sc->fmt) + PAD, sc->fmt};
    return f;
}

static void put_px(const mfns_frame_t *f, int x, int y, uint32_t v)
{
    uint8_t *row = g_fb + (size_t)y * f->stride_bytes;
    if (f->format == MFNS_PIXFMT_GREY) {
        row[x] = (uint8_t)v;
    } else {
        const uint16_t w = (uint16_t)v;
        memcpy(row + 2 * x, &w, 2);
    }
}

/* Start a scene: expected value = background everywhere, padding = 0xFF. */
static void scene_begin(const scene_t *sc)
{
    memset(g_fb, 0xFF, sizeof g_fb);
    for (size_t i = 0; i < (size_t)sc->w * sc->h; i++) {
        g_mu[i] = sc->bg;
    }
}

static void scene_add_spot(const scene_t *sc, const cs_spot_t *s, double amp)
{
    static double prof[CS_MAX_WINDOW * CS_MAX_WINDOW];
    const int h = cs_half_window(s), n = 2 * h + 1;
    const int ix0 = (int)lround(s->x0) - h, iy0 = (int)lround(s->y0) - h;
    cs_profile(s, ix0, iy0, n, prof);
    for (int j = 0; j < n; j++) {
        for (int i = 0; i < n; i++) {
            const int x = ix0 + i, y = iy0 + j;
            if (x >= 0 && y >= 0 && x < sc->w && y < sc->h) {
                g_mu[(size_t)y * sc->w + (size_t)x] += amp * prof[j * n + i];
            }
        }
    }
}

/* Quantise expectation + shot noise (Gaussian approximation of Poisson) + read noise. */
static void scene_render(const scene_t *sc, mfns_rng_t *rng, bool noise)
{
    const mfns_frame_t f = frame_of(sc);
    const double maxv = (double)((1u << fmt_bits(sc->fmt)) - 1u);
    for (int y = 0; y < sc->h; y++) {
        for (int x = 0; x < sc->w; x++) {
            const double mu = g_mu[(size_t)y * sc->w + (size_t)x];
            double v = mu;
            if (noise) {
                v += sqrt(sc->gshot * mu) * mfns_rng_normal(rng) + sc->read * mfns_rng_normal(rng);
            }
            v = floor(v + 0.5);
            v = v < 0 ? 0 : (v > maxv ? maxv : v);
            put_px(&f, x, y, (uint32_t)v);
        }
    }
}

/* Re-render the noise of the pixels [x0, x1) x [y0, y1) only (the rest of the
 * frame keeps its last rendering). */
static void scene_render_rect(const scene_t *sc, mfns_rng_t *rng, int x0, int y0, int x1, int y1)
{
    const mfns_frame_t f = frame_of(sc);
    const double maxv = (double)((1u << fmt_bits(sc->fmt)) - 1u);
    for (int y = y0 < 0 ? 0 : y0; y < y1 && y < sc->h; y++) {
        for (int x = x0 < 0 ? 0 : x0; x < x1 && x < sc->w; x++) {
            const double mu = g_mu[(size_t)y * sc->w + (size_t)x];
            /* shot + read noise as one normal: the same distribution as scene_render's two */
            double v = mu + sqrt(sc->gshot * mu + sc->read * sc->read) * mfns_rng_normal(rng);
            v = floor(v + 0.5);
            v = v < 0 ? 0 : (v > maxv ? maxv : v);
            put_px(&f, x, y, (uint32_t)v);
        }
    }
}

static mfns_centroid_status_t run_full(const mfns_frame_t *f, const mfns_centroid_settings_t *s)
{
    mfns_centroid_bg_t bg;
    const mfns_centroid_status_t st = mfns_centroid_background(f, NULL, 0, &g_work, &bg);
    if (st != MFNS_CENTROID_OK) {
        return st;
    }
    return mfns_centroid_detect(f, s, &bg, NULL, 0, &g_work, &g_res);
}

/* Index of the accepted blob within tol px of (x, y), -1 if none, -2 if several. */
static int match_blob(double x, double y, double tol)
{
    int found = -1;
    for (int k = 0; k < g_res.n_accepted; k++) {
        const double u = g_res.blob[k].u_q8 / 256.0, v = g_res.blob[k].v_q8 / 256.0;
        if (fabs(u - x) <= tol && fabs(v - y) <= tol) {
            found = found == -1 ? k : -2;
        }
    }
    return found;
}

/* ------------------------------------------------------------------------ */
/* Cramer-Rao bound of (x0, y0) for one spot: Fisher information of the
 * pixel-integrated model mu_i = b + A P_i(x0, y0) with independent pixel noise
 * of variance g mu_i + r^2 + 1/12 (shot, read, quantisation), parameters
 * (x0, y0, A), background known (the centroider estimates it from ~16k pixels):
 *   F = sum_i d_i d_i^T / var_i,  d_i = (A dP_i/dx0, A dP_i/dy0, P_i),
 *   CRB(x0) = (F^-1)_00.  Derivatives by central differences of the smooth model. */
static void crb_xy(const scene_t *sc, const cs_spot_t *s, double amp, double *vx, double *vy)
{
    static double p0[CS_MAX_WINDOW * CS_MAX_WINDOW], pxp[CS_MAX_WINDOW * CS_MAX_WINDOW],
        pxm[CS_MAX_WINDOW * CS_MAX_WINDOW], pyp[CS_MAX_WINDOW * CS_MAX_WINDOW], pym[CS_MAX_WINDOW * CS_MAX_WINDOW];
    const int h = cs_half_window(s), n = 2 * h + 1;
    const int ix0 = (int)lround(s->x0) - h, iy0 = (int)lround(s->y0) - h;
    const double e = 1e-4;
    cs_spot_t t = *s;
    cs_profile(&t, ix0, iy0, n, p0);
    t.x0 = s->x0 + e;
    cs_profile(&t, ix0, iy0, n, pxp);
    t.x0 = s->x0 - e;
    cs_profile(&t, ix0, iy0, n, pxm);
    t.x0 = s->x0;
    t.y0 = s->y0 + e;
    cs_profile(&t, ix0, iy0, n, pyp);
    t.y0 = s->y0 - e;
    cs_profile(&t, ix0, iy0, n, pym);
    double F[3][3] = {{0}};
    for (int i = 0; i < n * n; i++) {
        const double mu = sc->bg + amp * p0[i];
        const double var = sc->gshot * mu + sc->read * sc->read + 1.0 / 12.0;
        const double d[3] = {amp * (pxp[i] - pxm[i]) / (2 * e), amp * (pyp[i] - pym[i]) / (2 * e), p0[i]};
        for (int a = 0; a < 3; a++) {
            for (int b = 0; b < 3; b++) {
                F[a][b] += d[a] * d[b] / var;
            }
        }
    }
    const double det = F[0][0] * (F[1][1] * F[2][2] - F[1][2] * F[2][1]) -
                       F[0][1] * (F[1][0] * F[2][2] - F[1][2] * F[2][0]) +
                       F[0][2] * (F[1][0] * F[2][1] - F[1][1] * F[2][0]);
    *vx = (F[1][1] * F[2][2] - F[1][2] * F[2][1]) / det;
    *vy = (F[0][0] * F[2][2] - F[0][2] * F[2][0]) / det;
}

static double peak_fraction(cs_spot_t s)
{
    static double p[CS_MAX_WINDOW * CS_MAX_WINDOW];
    s.x0 = 0.0;
    s.y0 = 0.0;
    const int h = cs_half_window(&s), n = 2 * h + 1;
    cs_profile(&s, -h, -h, n, p);
    return p[h * n + h];
}

typedef struct {
    const char *name;
    scene_t sc;
    cs_spot_t spot; /* kind and size; position drawn per spot */
    double peak_dn; /* amplitude chosen so a centred spot peaks here */
    int frames;     /* 16 spots per frame */
    double max_ratio; /* RMS / CRB limit */
} mc_case_t;

/* Monte Carlo: bias and RMS error against the mean CRB; then the systematic
 * (noise-free) error over a grid of sub-pixel phases at the same threshold.
 * The flight settings, with threshold_k_sigma = k_sigma when k_sigma > 0. */
static bool run_mc_case(const mc_case_t *c, float k_sigma, uint64_t seed)
{
    mfns_rng_t rng;
    mfns_rng_seed(&rng, seed);
    const scene_t *sc = &c->sc;
    const mfns_frame_t f = frame_of(sc);
    mfns_centroid_settings_t set = flight_settings();
    if (k_sigma > 0.0f) {
        set.threshold_k_sigma = k_sigma;
    }
    const double amp = c->peak_dn / peak_fraction(c->spot);
    double se[2] = {0, 0}, se2 = 0, scrb = 0;
    int n = 0;
    uint32_t threshold = 0;
    for (int fr = 0; fr < c->frames; fr++) {
        cs_spot_t spots[16];
        scene_begin(sc);
        for (int k = 0; k < 16; k++) {
            spots[k] = c->spot;
            const int col = k % 4, row = k / 4;
            spots[k].x0 = 32 + 64 * col + mfns_rng_range(&rng, -0.5, 0.5);
            spots[k].y0 = 32 + 64 * row + mfns_rng_range(&rng, -0.5, 0.5);
            scene_add_spot(sc, &spots[k], amp);
        }
        scene_render(sc, &rng, true);
        assert_int_equal(run_full(&f, &set), MFNS_CENTROID_OK);
        assert_int_equal(g_res.n_accepted, 16); /* every spot, no false blob */
        threshold = g_res.threshold_dn;
        for (int k = 0; k < 16; k++) {
            const int b = match_blob(spots[k].x0, spots[k].y0, 1.5);
            assert_true(b >= 0);
            const double ex = g_res.blob[b].u_q8 / 256.0 - spots[k].x0;
            const double ey = g_res.blob[b].v_q8 / 256.0 - spots[k].y0;
            double vx, vy;
            crb_xy(sc, &spots[k], amp, &vx, &vy);
            se[0] += ex;
            se[1] += ey;
            se2 += ex * ex + ey * ey;
            scrb += vx + vy;
            n++;
        }
    }
    const double bias_x = se[0] / n, bias_y = se[1] / n;
    const double rms = sqrt(se2 / (2.0 * n)), crb = sqrt(scrb / (2.0 * n));
    /* noise-free systematic error at the same threshold (pixel-phase S-curve) */
    mfns_centroid_settings_t fixed = set;
    fixed.threshold_dn = (uint16_t)(threshold - (uint32_t)lround(sc->bg)); /* same cut above the background */
    double sys_max = 0.0;
    for (int fr = 0; fr < 4; fr++) {
        cs_spot_t spots[16];
        scene_begin(sc);
        for (int k = 0; k < 16; k++) {
            spots[k] = c->spot;
            const int col = k % 4, row = k / 4, phase_x = col + 4 * (fr % 2), phase_y = row + 4 * (fr / 2);
            spots[k].x0 = 32 + 64 * col - 0.5 + (phase_x + 0.5) / 8.0;
            spots[k].y0 = 32 + 64 * row - 0.5 + (phase_y + 0.5) / 8.0;
            scene_add_spot(sc, &spots[k], amp);
        }
        scene_render(sc, &rng, false);
        mfns_centroid_bg_t bg = {(float)sc->bg, 0.0f, 0u};
        assert_int_equal(mfns_centroid_detect(&f, &fixed, &bg, NULL, 0, &g_work, &g_res), MFNS_CENTROID_OK);
        assert_int_equal(g_res.n_accepted, 16);
        for (int k = 0; k < 16; k++) {
            const int b = match_blob(spots[k].x0, spots[k].y0, 1.0);
            assert_true(b >= 0);
            sys_max = fmax(sys_max, fabs(g_res.blob[b].u_q8 / 256.0 - spots[k].x0));
            sys_max = fmax(sys_max, fabs(g_res.blob[b].v_q8 / 256.0 - spots[k].y0));
        }
    }
    print_message("%-22s sigma %.2f  n %3d  bias (%+.4f, %+.4f) px  rms %.4f  crb %.4f  rms/crb %.3f  "
                  "systematic max %.4f px\n",
                  c->name, cs_spot_sigma(&c->spot), n, bias_x, bias_y, rms, crb, rms / crb, sys_max);
    return fabs(bias_x) <= 0.01 && fabs(bias_y) <= 0.01 && rms / crb <= c->max_ratio &&
           sys_max <= 0.01 + 1.0 / 512.0; /* + half an LSB of px_q8 */
}

/* Beacon frames: bright LEDs, short exposure, dark background (the regime
 * the flight cameras are set up for). 12-bit: background 20 DN, read noise
 * 2.5 DN, 1 e-/DN; 8-bit: background 4 DN, read noise 1 DN, 4 e-/DN. */
#define SC16 {MFNS_PIXFMT_Y12, 256, 256, 20.0, 2.5, 1.0}
#define SC8 {MFNS_PIXFMT_GREY, 256, 256, 4.0, 1.0, 0.25}
/* Bright background: 100 DN + 4 DN read noise under the same spots. */
#define SC16B {MFNS_PIXFMT_Y12, 256, 256, 100.0, 4.0, 1.0}
#define MC_FRAMES 12

static void test_accuracy_16bit(void **state)
{
    (void)state;
    const mc_case_t cases[] = {
        {"Y12 gauss", SC16, {CS_GAUSS, 0, 0, 0.7, 0, 0}, 3000, MC_FRAMES, 1.2},
        {"Y12 gauss", SC16, {CS_GAUSS, 0, 0, 1.0, 0, 0}, 3000, MC_FRAMES, 1.2},
        {"Y12 gauss", SC16, {CS_GAUSS, 0, 0, 1.5, 0, 0}, 3000, MC_FRAMES, 1.2},
        {"Y12 gauss", SC16, {CS_GAUSS, 0, 0, 2.0, 0, 0}, 3000, MC_FRAMES, 1.2},
        {"Y12 gauss", SC16, {CS_GAUSS, 0, 0, 3.0, 0, 0}, 3000, MC_FRAMES, 1.2},
        /* defocused disks (edge blur 0.5 px), sigma = R / 2 up to 3 px */
        {"Y12 disk R1.4", SC16, {CS_DISK, 0, 0, 0, 1.4, 0.5}, 3000, MC_FRAMES, 1.2},
        {"Y12 disk R2.0", SC16, {CS_DISK, 0, 0, 0, 2.0, 0.5}, 3000, MC_FRAMES, 1.2},
        {"Y12 disk R3.0", SC16, {CS_DISK, 0, 0, 0, 3.0, 0.5}, 3000, MC_FRAMES, 1.2},
        {"Y12 disk R4.0", SC16, {CS_DISK, 0, 0, 0, 4.0, 0.5}, 3000, MC_FRAMES, 1.2},
        {"Y12 disk R5.0", SC16, {CS_DISK, 0, 0, 0, 5.0, 0.5}, 3000, MC_FRAMES, 1.2},
        {"Y12 disk R6.0", SC16, {CS_DISK, 0, 0, 0, 6.0, 0.5}, 3000, MC_FRAMES, 1.2},
    };
    int failed = 0;
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        failed += !run_mc_case(&cases[i], 0.0f, 100 + i);
    }
    assert_int_equal(failed, 0);
}

static void test_accuracy_8bit(void **state)
{
    (void)state;
    const mc_case_t cases[] = {
        {"GREY gauss", SC8, {CS_GAUSS, 0, 0, 0.7, 0, 0}, 220, MC_FRAMES, 1.2},
        {"GREY gauss", SC8, {CS_GAUSS, 0, 0, 1.0, 0, 0}, 220, MC_FRAMES, 1.2},
        {"GREY gauss", SC8, {CS_GAUSS, 0, 0, 2.0, 0, 0}, 220, MC_FRAMES, 1.2},
        {"GREY gauss", SC8, {CS_GAUSS, 0, 0, 3.0, 0, 0}, 220, MC_FRAMES, 1.2},
        {"GREY disk R2.0", SC8, {CS_DISK, 0, 0, 0, 2.0, 0.5}, 220, MC_FRAMES, 1.2},
        {"GREY disk R3.0", SC8, {CS_DISK, 0, 0, 0, 3.0, 0.5}, 220, MC_FRAMES, 1.2},
        {"GREY disk R4.0", SC8, {CS_DISK, 0, 0, 0, 4.0, 0.5}, 220, MC_FRAMES, 1.2},
        {"GREY disk R6.0", SC8, {CS_DISK, 0, 0, 0, 6.0, 0.5}, 220, MC_FRAMES, 1.2},
    };
    /* At 5 sigma, not the flight settings' 6: MFNS_CENTROID_WEIGHT_LEVEL was
     * chosen from this Monte Carlo at 5 sigma, and at 6 sigma the 8-bit
     * 0.7 px Gaussian's noise-free pixel-phase error is 0.0195 px (measured),
     * beyond this test's 0.012 px bound (the 12-bit cases meet it at 6). */
    int failed = 0;
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        failed += !run_mc_case(&cases[i], 5.0f, 200 + i);
    }
    assert_int_equal(failed, 0);
}

static void test_accuracy_bright_background(void **state)
{
    (void)state;
    const mc_case_t cases[] = {
        {"Y12 bright-bg gauss", SC16B, {CS_GAUSS, 0, 0, 0.7, 0, 0}, 2500, 8, 1.2},
        {"Y12 bright-bg gauss", SC16B, {CS_GAUSS, 0, 0, 1.5, 0, 0}, 2500, 8, 1.2},
        {"Y12 bright-bg gauss", SC16B, {CS_GAUSS, 0, 0, 3.0, 0, 0}, 2500, 8, 1.2},
        {"Y12 bright-bg disk R3.0", SC16B, {CS_DISK, 0, 0, 0, 3.0, 0.5}, 2500, 8, 1.2},
        {"Y12 bright-bg disk R5.8", SC16B, {CS_DISK, 0, 0, 0, 5.8, 0.5}, 2500, 8, 1.2},
    };
    int failed = 0;
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        failed += !run_mc_case(&cases[i], 0.0f, 300 + i);
    }
    assert_int_equal(failed, 0);
}

/* ------------------------------------------------------------------------ */
/* Centroid covariance (cov_px2) against the scatter of repeated renderings.
 *
 * Per case: 16 spots at fixed sub-pixel positions (drawn once), the same
 * expectation rendered with fresh shot + read noise COV_FRAMES times. The
 * observed covariance is the pooled scatter of each spot's centroids about that
 * spot's own mean (16 (M - 1) degrees of freedom per axis: 752 at M = 48, so a
 * sigma is measured to 1/sqrt(2 * 752) = 2.6 %, and +-20 % is ~7 of those: the
 * test cannot pass by luck, and with fixed seeds it cannot flake). The mean of
 * the spot's fixed (systematic, pixel-phase) error is not noise and is left out.
 * Predicted = the mean of the blobs' cov_px2. Checked per axis, and along the
 * diagonals (u +- v)/sqrt 2, where the cov uv term decides; plus the mean
 * whitened squared error e^T C^-1 e (2 for two degrees of freedom). */
#define SC8G {MFNS_PIXFMT_GREY, 256, 256, 6.0, 1.0, 0.025}
#define COV_FRAMES 48
#define COV_SPOTS 16

typedef struct {
    const char *name;
    scene_t sc;
    cs_spot_t spot;   /* kind and size; ignored when ell_a > 0 */
    double peak_dn;   /* a centred spot peaks here */
    double ell_a, ell_b, ell_theta_deg; /* > 0: elliptical Gaussian, sigmas along its axes, rotation */
} cov_case_t;

/* Elliptical Gaussian (sigmas a, b along axes rotated by theta) integrated over
 * each pixel by an 8 x 8 midpoint rule; flux amp. */
static void scene_add_ellipse(const scene_t *sc, double x0, double y0, double a, double b, double theta, double amp)
{
    const double c = cos(theta), sn = sin(theta), pi = 3.14159265358979323846;
    const int h = (int)ceil(6.5 * fmax(a, b)) + 1;
    const int ix0 = (int)lround(x0) - h, iy0 = (int)lround(y0) - h;
    for (int y = iy0; y <= iy0 + 2 * h; y++) {
        for (int x = ix0; x <= ix0 + 2 * h; x++) {
            if (x < 0 || y < 0 || x >= sc->w || y >= sc->h) {
                continue;
            }
            double acc = 0.0;
            for (int j = 0; j < 8; j++) {
                for (int i = 0; i < 8; i++) {
                    const double dx = x - 0.5 + (i + 0.5) / 8.0 - x0, dy = y - 0.5 + (j + 0.5) / 8.0 - y0;
                    const double p = c * dx + sn * dy, q = -sn * dx + c * dy;
                    acc += exp(-0.5 * (p * p / (a * a) + q * q / (b * b)));
                }
            }
            g_mu[(size_t)y * sc->w + (size_t)x] += amp * acc / 64.0 / (2.0 * pi * a * b);
        }
    }
}

typedef struct {
    double ratio_u, ratio_v, ratio_p, ratio_m; /* predicted / observed sigma: u, v, (u+v)/sqrt2, (u-v)/sqrt2 */
    double rho_pred, rho_obs;                  /* correlation coefficients */
    double nees;                               /* mean e^T C^-1 e, 2 expected */
    double sigma_u;                            /* observed sigma u (px) */
    int refined;                               /* blobs whose covariance is the refined estimator's */
} cov_result_t;

static cov_result_t run_cov_case(const cov_case_t *c, uint64_t seed)
{
    static double eu[COV_SPOTS][COV_FRAMES], ev[COV_SPOTS][COV_FRAMES], pc[COV_SPOTS][COV_FRAMES][3];
    mfns_rng_t rng;
    mfns_rng_seed(&rng, seed);
    /* the case's scene on 512 x 512 px, spots 128 px apart: on the accuracy
     * tests' 256 x 256 the spots' pixels inflate the background noise estimate
     * by up to 10 % (docs/centroiding.md), here by ~2 % */
    scene_t big = c->sc;
    big.w = 512;
    big.h = 512;
    const scene_t *sc = &big;
    const mfns_frame_t f = frame_of(sc);
    mfns_centroid_settings_t set = flight_settings();
    set.gain_dn_per_e_q12 = (uint16_t)lround(sc->gshot * (double)MFNS_GAIN_Q12_ONE);
    double xs[COV_SPOTS], ys[COV_SPOTS];
    scene_begin(sc);
    const double pi = 3.14159265358979323846;
    for (int k = 0; k < COV_SPOTS; k++) {
        const int col = k % 4, row = k / 4;
        xs[k] = 64 + 128 * col + mfns_rng_range(&rng, -0.5, 0.5);
        ys[k] = 64 + 128 * row + mfns_rng_range(&rng, -0.5, 0.5);
        if (c->ell_a > 0.0) {
            scene_add_ellipse(sc, xs[k], ys[k], c->ell_a, c->ell_b, c->ell_theta_deg * pi / 180.0,
                              c->peak_dn * 2.0 * pi * c->ell_a * c->ell_b);
        } else {
            cs_spot_t s = c->spot;
            s.x0 = xs[k];
            s.y0 = ys[k];
            scene_add_spot(sc, &s, c->peak_dn / peak_fraction(c->spot));
        }
    }
    cov_result_t r;
    memset(&r, 0, sizeof r);
    /* the whole frame once, then fresh noise around each spot only: over the
     * window holding all but ~1e-9 of its flux, + 3 px (beyond it the frame is
     * background; the blob and the refinement window lie inside). The
     * background estimate sees fresh pixels in the windows, the same elsewhere. */
    const int half = 3 + (c->ell_a > 0.0 ? (int)ceil(6.5 * fmax(c->ell_a, c->ell_b)) + 1 : cs_half_window(&c->spot));
    scene_render(sc, &rng, true);
    for (int m = 0; m < COV_FRAMES; m++) {
        if (m > 0) {
            for (int k = 0; k < COV_SPOTS; k++) {
                const int cx = (int)lround(xs[k]), cy = (int)lround(ys[k]);
                scene_render_rect(sc, &rng, cx - half, cy - half, cx + half + 1, cy + half + 1);
            }
        }
        assert_int_equal(run_full(&f, &set), MFNS_CENTROID_OK);
        if (g_res.n_accepted != COV_SPOTS) {
            for (int k = 0; k < g_res.n_blobs; k++) {
                print_message("blob %d (%.2f, %.2f) area %u reasons 0x%x elong %.3f\n", k, g_res.blob[k].u_q8 / 256.0,
                              g_res.blob[k].v_q8 / 256.0, g_res.blob[k].area_px, g_res.blob[k].reasons,
                              (double)g_res.blob[k].elongation);
            }
        }
        assert_int_equal(g_res.n_accepted, COV_SPOTS);
        for (int k = 0; k < COV_SPOTS; k++) {
            const int b = match_blob(xs[k], ys[k], 1.5);
            assert_true(b >= 0);
            const mfns_blob_t *bl = &g_res.blob[b];
            eu[k][m] = bl->u_q8 / 256.0 - xs[k];
            ev[k][m] = bl->v_q8 / 256.0 - ys[k];
            for (int i = 0; i < 3; i++) {
                pc[k][m][i] = bl->cov_px2[i];
            }
            /* a covariance, positive definite, for every accepted blob */
            assert_true(bl->cov_px2[0] > 0.0f && bl->cov_px2[2] > 0.0f &&
                        bl->cov_px2[1] * bl->cov_px2[1] < bl->cov_px2[0] * bl->cov_px2[2]);
        }
    }
    double o[3] = {0, 0, 0}, p[3] = {0, 0, 0}, nees = 0.0;
    for (int k = 0; k < COV_SPOTS; k++) {
        double mu = 0.0, mv = 0.0;
        for (int m = 0; m < COV_FRAMES; m++) {
            mu += eu[k][m] / COV_FRAMES;
            mv += ev[k][m] / COV_FRAMES;
        }
        for (int m = 0; m < COV_FRAMES; m++) {
            const double du = eu[k][m] - mu, dv = ev[k][m] - mv;
            o[0] += du * du;
            o[1] += du * dv;
            o[2] += dv * dv;
            const double *C = pc[k][m], det = C[0] * C[2] - C[1] * C[1];
            nees += (C[2] * du * du - 2.0 * C[1] * du * dv + C[0] * dv * dv) / det;
            for (int i = 0; i < 3; i++) {
                p[i] += C[i];
            }
        }
    }
    const double dof = (double)COV_SPOTS * (COV_FRAMES - 1), n = (double)COV_SPOTS * COV_FRAMES;
    for (int i = 0; i < 3; i++) {
        o[i] /= dof;
        p[i] /= n;
    }
    r.ratio_u = sqrt(p[0] / o[0]);
    r.ratio_v = sqrt(p[2] / o[2]);
    r.ratio_p = sqrt((p[0] + p[2] + 2.0 * p[1]) / (o[0] + o[2] + 2.0 * o[1]));
    r.ratio_m = sqrt((p[0] + p[2] - 2.0 * p[1]) / (o[0] + o[2] - 2.0 * o[1]));
    r.rho_pred = p[1] / sqrt(p[0] * p[2]);
    r.rho_obs = o[1] / sqrt(o[0] * o[2]);
    r.nees = nees / dof; /* about each spot's sample mean: dof, not n */
    r.sigma_u = sqrt(o[0]);
    print_message("%-26s sigma %.2f  obs sigma (%.4f, %.4f) px  pred/obs u %.3f v %.3f  diag + %.3f - %.3f  "
                  "rho pred %+.3f obs %+.3f  whitened %.3f  noise_dn %.3f (true %.3f)\n",
                  c->name, c->ell_a > 0.0 ? c->ell_a : cs_spot_sigma(&c->spot), sqrt(o[0]), sqrt(o[2]), r.ratio_u,
                  r.ratio_v, r.ratio_p, r.ratio_m, r.rho_pred, r.rho_obs, r.nees / 2.0, (double)g_res.bg.noise_dn,
                  sqrt(sc->gshot * sc->bg + sc->read * sc->read + 1.0 / 12.0));
    return r;
}

static bool cov_within(const cov_result_t *r)
{
    const double lo = 0.8, hi = 1.2;
    return r->ratio_u >= lo && r->ratio_u <= hi && r->ratio_v >= lo && r->ratio_v <= hi && r->ratio_p >= lo &&
           r->ratio_p <= hi && r->ratio_m >= lo && r->ratio_m <= hi && fabs(r->rho_pred - r->rho_obs) <= 0.15 &&
           r->nees >= 2.0 * 0.8 && r->nees <= 2.0 * 1.25;
}

/* The spot sizes and brightnesses of the accuracy tests above: Gaussians keep
 * the moment centroid (and its covariance from the moment sums), disks of
 * R >= 2 go through the profile refinement (and get the sandwich covariance of
 * its estimating equation). */
static void test_covariance_matches_scatter(void **state)
{
    (void)state;
    const cov_case_t cases[] = {
        {"Y12 gauss", SC16, {CS_GAUSS, 0, 0, 0.7, 0, 0}, 3000, 0, 0, 0},
        {"Y12 gauss", SC16, {CS_GAUSS, 0, 0, 1.0, 0, 0}, 3000, 0, 0, 0},
        {"Y12 gauss", SC16, {CS_GAUSS, 0, 0, 1.5, 0, 0}, 3000, 0, 0, 0},
        {"Y12 gauss", SC16, {CS_GAUSS, 0, 0, 2.0, 0, 0}, 3000, 0, 0, 0},
        {"Y12 gauss", SC16, {CS_GAUSS, 0, 0, 3.0, 0, 0}, 3000, 0, 0, 0},
        {"Y12 disk R1.4", SC16, {CS_DISK, 0, 0, 0, 1.4, 0.5}, 3000, 0, 0, 0},
        {"Y12 disk R2.0", SC16, {CS_DISK, 0, 0, 0, 2.0, 0.5}, 3000, 0, 0, 0},
        {"Y12 disk R3.0", SC16, {CS_DISK, 0, 0, 0, 3.0, 0.5}, 3000, 0, 0, 0},
        {"Y12 disk R4.0", SC16, {CS_DISK, 0, 0, 0, 4.0, 0.5}, 3000, 0, 0, 0},
        {"Y12 disk R5.0", SC16, {CS_DISK, 0, 0, 0, 5.0, 0.5}, 3000, 0, 0, 0},
        {"Y12 disk R6.0", SC16, {CS_DISK, 0, 0, 0, 6.0, 0.5}, 3000, 0, 0, 0},
        {"GREY gauss", SC8, {CS_GAUSS, 0, 0, 0.7, 0, 0}, 220, 0, 0, 0},
        {"GREY gauss", SC8, {CS_GAUSS, 0, 0, 1.0, 0, 0}, 220, 0, 0, 0},
        {"GREY gauss", SC8, {CS_GAUSS, 0, 0, 2.0, 0, 0}, 220, 0, 0, 0},
        {"GREY gauss", SC8, {CS_GAUSS, 0, 0, 3.0, 0, 0}, 220, 0, 0, 0},
        /* disks at 200 DN, not 220: over 48 renderings of the same plateau a
         * pixel reaches 255 (4.7 sigma of shot noise) and the blob is SATURATED */
        {"GREY disk R2.0", SC8, {CS_DISK, 0, 0, 0, 2.0, 0.5}, 200, 0, 0, 0},
        {"GREY disk R3.0", SC8, {CS_DISK, 0, 0, 0, 3.0, 0.5}, 200, 0, 0, 0},
        {"GREY disk R4.0", SC8, {CS_DISK, 0, 0, 0, 4.0, 0.5}, 200, 0, 0, 0},
        {"GREY disk R6.0", SC8, {CS_DISK, 0, 0, 0, 6.0, 0.5}, 200, 0, 0, 0},
        {"Y12 bright-bg gauss", SC16B, {CS_GAUSS, 0, 0, 0.7, 0, 0}, 2500, 0, 0, 0},
        {"Y12 bright-bg gauss", SC16B, {CS_GAUSS, 0, 0, 1.5, 0, 0}, 2500, 0, 0, 0},
        {"Y12 bright-bg gauss", SC16B, {CS_GAUSS, 0, 0, 3.0, 0, 0}, 2500, 0, 0, 0},
        {"Y12 bright-bg disk R3.0", SC16B, {CS_DISK, 0, 0, 0, 3.0, 0.5}, 2500, 0, 0, 0},
        {"Y12 bright-bg disk R5.8", SC16B, {CS_DISK, 0, 0, 0, 5.8, 0.5}, 2500, 0, 0, 0},
        /* fainter spots: the background noise dominates, the threshold cuts more of the wings */
        {"Y12 faint gauss", SC16, {CS_GAUSS, 0, 0, 1.5, 0, 0}, 150, 0, 0, 0},
        {"Y12 faint disk R3.0", SC16, {CS_DISK, 0, 0, 0, 3.0, 0.5}, 150, 0, 0, 0},
        {"GREY faint gauss", SC8, {CS_GAUSS, 0, 0, 1.5, 0, 0}, 40, 0, 0, 0},
        /* a low-gain 8-bit sensor (40 e-/DN, the default gain): shot noise smaller
         * than the 4 e-/DN scenes', read noise 1 DN */
        {"GREY 40e/DN gauss", SC8G, {CS_GAUSS, 0, 0, 1.3, 0, 0}, 180, 0, 0, 0},
        {"GREY 40e/DN faint gauss", SC8G, {CS_GAUSS, 0, 0, 2.0, 0, 0}, 30, 0, 0, 0},
        {"GREY 40e/DN disk R3.0", SC8G, {CS_DISK, 0, 0, 0, 3.0, 0.5}, 180, 0, 0, 0},
    };
    int failed = 0;
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        const cov_result_t r = run_cov_case(&cases[i], 400 + i);
        failed += !cov_within(&r);
    }
    assert_int_equal(failed, 0);
}

/* An elongated, rotated spot (2.0 x 1.2 px at 30 deg: correlation ~0.4 of the
 * centroid errors): the cov uv term is what makes the diagonal directions
 * right; without it the predicted sigma along u + v and u - v would be equal,
 * while the observed differ by ~1.6x. */
static void test_covariance_elongated_spot(void **state)
{
    (void)state;
    const cov_case_t cases[] = {
        {"Y12 ellipse 2.0x1.2 30deg", SC16, {CS_GAUSS, 0, 0, 0, 0, 0}, 3000, 2.0, 1.2, 30.0},
        {"GREY ellipse 2.0x1.2 -50deg", SC8, {CS_GAUSS, 0, 0, 0, 0, 0}, 220, 2.0, 1.2, -50.0},
        {"Y12 bright-bg ell. 2.5x1.5 60deg", SC16B, {CS_GAUSS, 0, 0, 0, 0, 0}, 2500, 2.5, 1.5, 60.0},
    };
    int failed = 0;
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        const cov_result_t r = run_cov_case(&cases[i], 500 + i);
        failed += !cov_within(&r);
        /* the term matters: the observed correlation is far from 0 */
        failed += !(fabs(r.rho_obs) > 0.25);
    }
    assert_int_equal(failed, 0);
}

static void draw_square(const mfns_frame_t *f, int x, int y, int s, uint32_t v);

static bool cov_is_zero(const mfns_blob_t *b)
{
    return b->cov_px2[0] == 0.0f && b->cov_px2[1] == 0.0f && b->cov_px2[2] == 0.0f;
}

static bool cov_is_pd(const mfns_blob_t *b)
{
    return isfinite(b->cov_px2[0]) && isfinite(b->cov_px2[1]) && isfinite(b->cov_px2[2]) && b->cov_px2[0] > 0.0f &&
           b->cov_px2[2] > 0.0f && b->cov_px2[1] * b->cov_px2[1] < b->cov_px2[0] * b->cov_px2[2];
}

/* The contract of cov_px2 (centroid.h): every accepted blob has a positive
 * definite covariance, every rejected blob zeros; windows give the full
 * frame's covariance bit for bit (same background, same pixels); the model's
 * two terms scale as documented: without a gain, the covariance beyond the
 * px_q8 rounding is the noise floor's variance times a geometric sum (x4 when
 * the noise doubles), and the shot term of a bright spot is most of it. */
static void test_covariance_contract(void **state)
{
    (void)state;
    /* rejected blobs: the scene of test_rejection_reasons */
    const scene_t sc = {MFNS_PIXFMT_Y12, 512, 512, 100.0, 0, 0};
    const mfns_frame_t f = frame_of(&sc);
    const mfns_centroid_bg_t bg = {100.0f, 2.0f, 0u};
    mfns_centroid_settings_t set = flight_settings();
    scene_begin(&sc);
    const cs_spot_t good = {CS_GAUSS, 100.3, 100.6, 1.5, 0, 0}, big = {CS_GAUSS, 400.2, 60.1, 1.5, 0, 0};
    const cs_spot_t disk = {CS_DISK, 300.4, 420.7, 0, 4.0, 0.5}, edge = {CS_GAUSS, 1.0, 250.0, 1.2, 0, 0};
    scene_add_spot(&sc, &good, 2000 / peak_fraction(good));
    scene_add_spot(&sc, &disk, 2000 / peak_fraction(disk));
    scene_add_spot(&sc, &big, 9000 / peak_fraction(big)); /* saturated */
    scene_add_spot(&sc, &edge, 2000 / peak_fraction(edge));
    scene_render(&sc, NULL, false);
    put_px(&f, 30, 300, 3000);            /* too small */
    draw_square(&f, 150, 200, 70, 1000);  /* too large */
    draw_square(&f, 250, 250, 100, 1000); /* too large */
    for (int x = 200; x < 230; x++) {     /* elongated */
        put_px(&f, x, 400, 1500);
        put_px(&f, x, 401, 1500);
    }
    assert_int_equal(mfns_centroid_detect(&f, &set, &bg, NULL, 0, &g_work, &g_res), MFNS_CENTROID_OK);
    assert_int_equal(g_res.n_accepted, 2);
    assert_true(g_res.n_blobs >= 6);
    for (int k = 0; k < g_res.n_blobs; k++) {
        assert_true(k < g_res.n_accepted ? cov_is_pd(&g_res.blob[k]) : cov_is_zero(&g_res.blob[k]));
    }
    /* a window cutting the good spot: rejected (window border), zero */
    const mfns_roi_t cut = {102, 90, 130, 120};
    assert_int_equal(mfns_centroid_detect(&f, &set, &bg, &cut, 1, &g_work, &g_res), MFNS_CENTROID_OK);
    assert_int_equal(g_res.n_accepted, 0);
    assert_true(g_res.n_blobs == 1 && cov_is_zero(&g_res.blob[0]));

    /* windows against the full frame: bit-identical covariance (moment and refined) */
    static mfns_centroid_result_t full;
    assert_int_equal(mfns_centroid_detect(&f, &set, &bg, NULL, 0, &g_work, &full), MFNS_CENTROID_OK);
    const float uv[2][2] = {{100.0f, 101.0f}, {301.0f, 420.0f}};
    mfns_roi_t rois[MFNS_CENTROID_MAX_ROIS];
    uint16_t n_rois = 0;
    assert_int_equal(mfns_centroid_make_rois(uv, 2, 24, sc.w, sc.h, rois, MFNS_CENTROID_MAX_ROIS, &n_rois),
                     MFNS_CENTROID_OK);
    assert_int_equal(mfns_centroid_detect(&f, &set, &bg, rois, n_rois, &g_work, &g_res), MFNS_CENTROID_OK);
    assert_int_equal(g_res.n_accepted, 2);
    for (int k = 0; k < 2; k++) {
        const int m = match_blob(full.blob[k].u_q8 / 256.0, full.blob[k].v_q8 / 256.0, 0.0);
        assert_true(m >= 0);
        assert_memory_equal(g_res.blob[m].cov_px2, full.blob[k].cov_px2, sizeof full.blob[k].cov_px2);
    }

    /* the noise model's terms: no gain, a fixed threshold (same pixels, same weights) */
    set.threshold_dn = 40;
    set.gain_dn_per_e_q12 = 0;
    const mfns_centroid_bg_t bg1 = {100.0f, 1.5f, 0u}, bg2 = {100.0f, 3.0f, 0u};
    assert_int_equal(mfns_centroid_detect(&f, &set, &bg1, NULL, 0, &g_work, &full), MFNS_CENTROID_OK);
    assert_int_equal(mfns_centroid_detect(&f, &set, &bg2, NULL, 0, &g_work, &g_res), MFNS_CENTROID_OK);
    assert_int_equal(full.n_accepted, 2);
    assert_int_equal(g_res.n_accepted, 2);
    const double q8 = MFNS_CENTROID_Q8_VAR_PX2;
    for (int k = 0; k < 2; k++) {
        assert_int_equal(g_res.blob[k].u_q8, full.blob[k].u_q8);
        for (int i = 0; i < 3; i += 2) {
            const double r = ((double)g_res.blob[k].cov_px2[i] - q8) / ((double)full.blob[k].cov_px2[i] - q8);
            assert_near(r, 4.0, 4.0 * 1e-4);
        }
        assert_near((double)g_res.blob[k].cov_px2[1] / (double)full.blob[k].cov_px2[1], 4.0, 0.01);
    }
    /* with the gain (1 DN/e-: 2000 DN peak, shot variance up to 2000 DN^2 against
     * the floor's 2.25) the shot term dominates */
    set.gain_dn_per_e_q12 = (uint16_t)MFNS_GAIN_Q12_ONE;
    assert_int_equal(mfns_centroid_detect(&f, &set, &bg1, NULL, 0, &g_work, &g_res), MFNS_CENTROID_OK);
    for (int k = 0; k < 2; k++) {
        print_message("cov u: floor only %.3g px^2, with shot noise %.3g px^2\n", (double)full.blob[k].cov_px2[0],
                      (double)g_res.blob[k].cov_px2[0]);
        assert_true(g_res.blob[k].cov_px2[0] > 10.0f * full.blob[k].cov_px2[0]);
        assert_true(g_res.blob[k].cov_px2[2] > 10.0f * full.blob[k].cov_px2[2]);
    }
}

/* ------------------------------------------------------------------------ */

static void test_pure_noise_no_false_blob(void **state)
{
    (void)state;
    const scene_t scenes[] = {{MFNS_PIXFMT_GREY, FB_W, FB_H, 12.0, 1.5, 0.25},
                              {MFNS_PIXFMT_Y12, FB_W, FB_H, 100.0, 4.0, 1.0},
                              {MFNS_PIXFMT_Y16, FB_W, FB_H, 1600.0, 64.0, 16.0}};
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 7);
    const mfns_centroid_settings_t set = flight_settings();
    for (size_t i = 0; i < sizeof scenes / sizeof scenes[0]; i++) {
        const scene_t *sc = &scenes[i];
        scene_begin(sc);
        scene_render(sc, &rng, true);
        const mfns_frame_t f = frame_of(sc);
        mfns_centroid_bg_t bg;
        assert_int_equal(mfns_centroid_background(&f, NULL, 0, &g_work, &bg), MFNS_CENTROID_OK);
        const double sigma = sqrt(sc->gshot * sc->bg + sc->read * sc->read + 1.0 / 12.0);
        print_message("noise frame %u-bit: background %.2f (true %.1f), noise %.3f (true %.3f), %u samples\n",
                      fmt_bits(sc->fmt), (double)bg.background_dn, sc->bg, (double)bg.noise_dn, sigma, bg.n_samples);
        assert_near(bg.background_dn, sc->bg, 0.05 * sigma);
        assert_near(bg.noise_dn, sigma, 0.06 * sigma);
        assert_true(bg.n_samples > 6000u && bg.n_samples <= MFNS_CENTROID_BG_MAX_SAMPLES);
        assert_int_equal(mfns_centroid_detect(&f, &set, &bg, NULL, 0, &g_work, &g_res), MFNS_CENTROID_OK);
        assert_int_equal(g_res.n_accepted, 0);
    }
}

/* A bright square of side s with top-left (x, y). */
static void draw_square(const mfns_frame_t *f, int x, int y, int s, uint32_t v)
{
    for (int j = 0; j < s; j++) {
        for (int i = 0; i < s; i++) {
            put_px(f, x + i, y + j, v);
        }
    }
}

static void flat_frame(const scene_t *sc)
{
    scene_begin(sc);
    scene_render(sc, NULL, false);
}

static void test_table_overflow_reported(void **state)
{
    (void)state;
    const scene_t sc = {MFNS_PIXFMT_GREY, 1200, 64, 10.0, 0, 0};
    const mfns_frame_t f = frame_of(&sc);
    const mfns_centroid_settings_t set = flight_settings();
    const mfns_centroid_bg_t bg = {10.0f, 1.0f, 0u};
    /* 70 blobs: more than the 64-entry blob table, fewer than the labels */
    flat_frame(&sc);
    for (int k = 0; k < 70; k++) {
        draw_square(&f, 4 + 12 * k, 10, 3, 200);
    }
    draw_square(&f, 4, 40, 1, 200); /* and one rejected (too small) */
    assert_int_equal(mfns_centroid_detect(&f, &set, &bg, NULL, 0, &g_work, &g_res), MFNS_CENTROID_TABLE_FULL);
    assert_int_equal(g_res.n_blobs, MFNS_MAX_BLOBS_PER_CAMERA);
    assert_int_equal(g_res.n_accepted, MFNS_MAX_BLOBS_PER_CAMERA); /* accepted blobs come first */
    assert_int_equal(g_res.n_lost, 70 + 1 - MFNS_MAX_BLOBS_PER_CAMERA);
    /* exactly 64: no loss */
    flat_frame(&sc);
    for (int k = 0; k < MFNS_MAX_BLOBS_PER_CAMERA; k++) {
        draw_square(&f, 4 + 12 * k, 10, 3, 200);
    }
    assert_int_equal(mfns_centroid_detect(&f, &set, &bg, NULL, 0, &g_work, &g_res), MFNS_CENTROID_OK);
    assert_int_equal(g_res.n_accepted, MFNS_MAX_BLOBS_PER_CAMERA);
    assert_int_equal(g_res.n_lost, 0);
    for (int k = 0; k < MFNS_MAX_BLOBS_PER_CAMERA; k++) {
        assert_int_equal(g_res.blob[k].u_q8, (5 + 12 * k) * 256);
        assert_int_equal(g_res.blob[k].v_q8, 11 * 256);
    }

    /* Labels exhausted: blob X (a vertical bar) takes a label first; 255
     * single-row pairs use up the rest; then a blob Y appears with no label
     * left and later joins X: X is kept but marked incomplete. */
    flat_frame(&sc);
    for (int y = 2; y < 40; y++) {
        put_px(&f, 1100, y, 200);
        put_px(&f, 1101, y, 200);
        put_px(&f, 1102, y, 200);
    }
    for (int k = 0; k < MFNS_CENTROID_MAX_LABELS - 1; k++) {
        put_px(&f, 2 + 4 * k, 10, 200);
        put_px(&f, 3 + 4 * k, 10, 200);
    }
    for (int x = 1104; x <= 1110; x++) {
        put_px(&f, x, 20, 200); /* Y, separated from X by column 1103 */
    }
    for (int x = 1103; x <= 1110; x++) {
        put_px(&f, x, 22, 200); /* joins X (and touches Y's row 21 below) */
        put_px(&f, x, 21, 200);
    }
    for (int x = 1120; x <= 1122; x++) {
        put_px(&f, x, 30, 200); /* Z: entirely unlabelled */
    }
    assert_int_equal(mfns_centroid_detect(&f, &set, &bg, NULL, 0, &g_work, &g_res), MFNS_CENTROID_TABLE_FULL);
    assert_true(g_res.n_lost >= 2u);
    int with_x = -1;
    for (int k = 0; k < g_res.n_blobs; k++) {
        if (g_res.blob[k].x_min == 1100) {
            with_x = k;
        }
    }
    assert_true(with_x >= 0);
    if (with_x < 0) {
        return;
    }
    assert_true((g_res.blob[with_x].reasons & MFNS_BLOB_TABLE_FULL) != 0);
    assert_int_equal(g_res.blob[with_x].y_max, 39);
}

static void test_rejection_reasons(void **state)
{
    (void)state;
    const scene_t sc = {MFNS_PIXFMT_Y12, 512, 512, 100.0, 0, 0};
    const mfns_frame_t f = frame_of(&sc);
    const mfns_centroid_bg_t bg = {100.0f, 2.0f, 0u};
    const mfns_centroid_settings_t set = flight_settings();
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 3);
    scene_begin(&sc);
    const cs_spot_t good = {CS_GAUSS, 100.3, 100.6, 1.5, 0, 0}, big = {CS_GAUSS, 400.2, 60.1, 1.5, 0, 0};
    scene_add_spot(&sc, &good, 2000 / peak_fraction(good));
    scene_add_spot(&sc, &big, 9000 / peak_fraction(big)); /* saturates at 4095 */
    const cs_spot_t edge = {CS_GAUSS, 1.0, 250.0, 1.2, 0, 0};
    scene_add_spot(&sc, &edge, 2000 / peak_fraction(edge));
    scene_render(&sc, &rng, false);
    put_px(&f, 30, 300, 3000);           /* hot pixel: too small */
    draw_square(&f, 150, 200, 70, 1000); /* 4900 px > max_area_px: too large */
    draw_square(&f, 250, 250, 260, 1000); /* 67600 px: beyond the moment cap */
    for (int x = 200; x < 230; x++) {   /* a streak 30 x 2: elongated */
        put_px(&f, x, 400, 1500);
        put_px(&f, x, 401, 1500);
    }
    assert_int_equal(mfns_centroid_detect(&f, &set, &bg, NULL, 0, &g_work, &g_res), MFNS_CENTROID_OK);
    assert_int_equal(g_res.n_blobs, 7);
    assert_int_equal(g_res.n_accepted, 1);
    assert_true(fabs(g_res.blob[0].u_q8 / 256.0 - 100.3) < 0.01 && fabs(g_res.blob[0].v_q8 / 256.0 - 100.6) < 0.01);
    assert_true(g_res.blob[0].elongation < 1.05f);
    uint16_t seen = 0;
    for (int k = 1; k < g_res.n_blobs; k++) {
        const mfns_blob_t *b = &g_res.blob[k];
        seen |= b->reasons;
        assert_true(b->reasons != 0u);
        assert_string_not_equal(mfns_blob_reason_name(b->reasons & (uint16_t)(-b->reasons)), "?");
        if (b->x_min == 30 && b->y_min == 300) {
            assert_int_equal(b->reasons, MFNS_BLOB_TOO_SMALL);
        } else if (b->x_min == 150) {
            assert_int_equal(b->reasons, MFNS_BLOB_TOO_LARGE);
            assert_int_equal(b->area_px, 4900);
            assert_int_equal(b->u_q8, (150 * 256 + 69 * 128)); /* moments: centre of the square */
        } else if (b->x_min == 250) {
            assert_int_equal(b->reasons, MFNS_BLOB_TOO_LARGE);
            assert_int_equal(b->area_px, 260 * 260);
            assert_int_equal(b->u_q8, (250 + 509) * 128); /* no moments: bounding-box centre */
        } else if (b->x_min == 200) {
            assert_int_equal(b->reasons, MFNS_BLOB_ELONGATED);
            assert_true(b->elongation > 50.0f);
        } else if (b->x_min == 0) {
            assert_int_equal(b->reasons, MFNS_BLOB_IMAGE_BORDER);
        } else {
            assert_true(b->saturated);
            assert_int_equal(b->reasons, MFNS_BLOB_SATURATED);
            assert_int_equal(b->peak_dn, 4095);
        }
    }
    /* a saturation level from the settings */
    mfns_centroid_settings_t s2 = set;
    s2.saturation_dn = 1800;
    assert_int_equal(mfns_centroid_detect(&f, &s2, &bg, NULL, 0, &g_work, &g_res), MFNS_CENTROID_OK);
    assert_int_equal(g_res.n_accepted, 0);
    assert_true(g_res.blob[0].saturated);
    /* window border: a window cutting the good spot */
    const mfns_roi_t roi = {102, 90, 130, 120};
    assert_int_equal(mfns_centroid_detect(&f, &set, &bg, &roi, 1, &g_work, &g_res), MFNS_CENTROID_OK);
    assert_int_equal(g_res.n_blobs, 1);
    assert_true((g_res.blob[0].reasons & MFNS_BLOB_ROI_BORDER) != 0u); /* (cut: elongated too) */
    assert_int_equal(g_res.blob[0].roi, 0);
    seen |= g_res.blob[0].reasons;
    assert_int_equal(seen, MFNS_BLOB_TOO_SMALL | MFNS_BLOB_TOO_LARGE | MFNS_BLOB_SATURATED | MFNS_BLOB_IMAGE_BORDER |
                               MFNS_BLOB_ELONGATED | MFNS_BLOB_ROI_BORDER);
    /* (MFNS_BLOB_TABLE_FULL: test_table_overflow_reported) */
}

static void test_roi_matches_full_frame(void **state)
{
    (void)state;
    const scene_t sc = {MFNS_PIXFMT_GREY, FB_W, FB_H, 12.0, 1.5, 0.25};
    const mfns_frame_t f = frame_of(&sc);
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 21);
    scene_begin(&sc);
    float uv[12][2];
    for (int k = 0; k < 10; k++) {
        const int col = k % 5, row = k / 5;
        const cs_spot_t s = {k % 2 ? CS_GAUSS : CS_DISK, 100 + 240 * col + mfns_rng_range(&rng, -30, 30),
                             200 + 500 * row + mfns_rng_range(&rng, -30, 30), 1.5, 3.0, 0.5};
        scene_add_spot(&sc, &s, 170 / peak_fraction(s));
        uv[k][0] = (float)(s.x0 + mfns_rng_range(&rng, -3, 3)); /* a prediction, a few px off */
        uv[k][1] = (float)(s.y0 + mfns_rng_range(&rng, -3, 3));
    }
    /* two predictions close together share one window; one is off the frame */
    uv[10][0] = uv[0][0] + 10.0f;
    uv[10][1] = uv[0][1] - 5.0f;
    uv[11][0] = -30.0f;
    uv[11][1] = 100.0f;
    scene_render(&sc, &rng, true);
    const mfns_centroid_settings_t set = flight_settings();
    mfns_centroid_bg_t bg;
    assert_int_equal(mfns_centroid_background(&f, NULL, 0, &g_work, &bg), MFNS_CENTROID_OK);
    assert_int_equal(mfns_centroid_detect(&f, &set, &bg, NULL, 0, &g_work, &g_res), MFNS_CENTROID_OK);
    assert_int_equal(g_res.n_accepted, 10);
    static mfns_centroid_result_t full;
    full = g_res;
    mfns_roi_t rois[MFNS_CENTROID_MAX_ROIS];
    uint16_t n_rois = 0;
    assert_int_equal(mfns_centroid_make_rois((const float(*)[2])uv, 12, set.roi_half_size_px, FB_W, FB_H, rois,
                                             MFNS_CENTROID_MAX_ROIS, &n_rois),
                     MFNS_CENTROID_OK);
    assert_int_equal(n_rois, 10);
    /* same background: bit-identical centroids */
    assert_int_equal(mfns_centroid_detect(&f, &set, &bg, rois, n_rois, &g_work, &g_res), MFNS_CENTROID_OK);
    assert_int_equal(g_res.n_accepted, 10);
    for (int k = 0; k < 10; k++) {
        int found = 0;
        for (int m = 0; m < 10; m++) {
            if (g_res.blob[m].u_q8 == full.blob[k].u_q8 && g_res.blob[m].v_q8 == full.blob[k].v_q8 &&
                g_res.blob[m].area_px == full.blob[k].area_px) {
                found++;
                assert_true(g_res.blob[m].roi < n_rois);
            }
        }
        assert_int_equal(found, 1);
    }
    /* background estimated inside the windows only: a threshold 1 DN off moves
     * pixels near it in or out, so the same within 0.05 px */
    mfns_centroid_bg_t bg_roi;
    assert_int_equal(mfns_centroid_background(&f, rois, n_rois, &g_work, &bg_roi), MFNS_CENTROID_OK);
    assert_near(bg_roi.background_dn, bg.background_dn, 0.3);
    assert_int_equal(mfns_centroid_detect(&f, &set, &bg_roi, rois, n_rois, &g_work, &g_res), MFNS_CENTROID_OK);
    assert_int_equal(g_res.n_accepted, 10);
    for (int k = 0; k < 10; k++) {
        const double u = full.blob[k].u_q8 / 256.0, v = full.blob[k].v_q8 / 256.0;
        const int m = match_blob(u, v, 0.05);
        assert_true(m >= 0);
    }
    /* too many windows for the list */
    assert_int_equal(mfns_centroid_make_rois((const float(*)[2])uv, 10, 24, FB_W, FB_H, rois, 5, &n_rois),
                     MFNS_CENTROID_ERR_ROI);
}

/* The word-at-a-time scan must find exactly the pixels >= threshold, for every
 * threshold class (below/above half range), every format, odd widths and
 * row ends; checked by the total blob area against a per-pixel count. */
static void test_threshold_scan_exact(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 5);
    const mfns_pixfmt_t fmts[] = {MFNS_PIXFMT_GREY, MFNS_PIXFMT_Y10, MFNS_PIXFMT_Y12, MFNS_PIXFMT_Y16};
    mfns_centroid_settings_t set = flight_settings();
    set.min_area_px = 1;
    set.max_area_px = 65535;
    for (int trial = 0; trial < 48; trial++) {
        const mfns_pixfmt_t fmt = fmts[trial % 4];
        const uint32_t maxv = (1u << fmt_bits(fmt)) - 1u;
        const scene_t sc = {fmt, (uint16_t)(37 + trial * 3), (uint16_t)(20 + trial % 7), 0, 0, 0};
        const mfns_frame_t f = frame_of(&sc);
        flat_frame(&sc);
        const uint32_t T = 1u + (uint32_t)(mfns_rng_uniform(&rng) * maxv);
        /* below the threshold everywhere (many at T - 1), then a few runs above */
        for (int y = 0; y < sc.h; y++) {
            for (int x = 0; x < sc.w; x++) {
                const uint32_t v = mfns_rng_uniform(&rng) < 0.3 ? T - 1u : (uint32_t)(mfns_rng_uniform(&rng) * T);
                put_px(&f, x, y, v);
            }
        }
        for (int k = 0; k < 20; k++) {
            const int y = (int)(mfns_rng_uniform(&rng) * sc.h), len = 1 + (int)(mfns_rng_uniform(&rng) * 20);
            const int x0 = (int)(mfns_rng_uniform(&rng) * sc.w);
            for (int x = x0; x < x0 + len && x < sc.w; x++) {
                put_px(&f, x, y, T + (uint32_t)(mfns_rng_uniform(&rng) * (double)(maxv - T + 1u)));
            }
        }
        uint32_t expected = 0;
        for (int y = 0; y < sc.h; y++) {
            const uint8_t *row = g_fb + (size_t)y * f.stride_bytes;
            for (int x = 0; x < sc.w; x++) {
                uint16_t v16;
                memcpy(&v16, row + 2 * x, 2);
                const uint32_t v = fmt == MFNS_PIXFMT_GREY ? row[x] : v16;
                expected += v >= T;
            }
        }
        set.threshold_dn = (uint16_t)(T - 1u); /* background 0: pixels >= T belong */
        const mfns_centroid_bg_t bg = {0.0f, 0.0f, 0u};
        const mfns_centroid_status_t st = mfns_centroid_detect(&f, &set, &bg, NULL, 0, &g_work, &g_res);
        assert_true(st == MFNS_CENTROID_OK);
        assert_int_equal(g_res.threshold_dn, T);
        uint32_t area = 0;
        for (int k = 0; k < g_res.n_blobs; k++) {
            area += g_res.blob[k].area_px;
        }
        assert_int_equal(area, expected);
    }
}

/* Random frames of every format and density (sparse specks to a percolating
 * mass): whatever the content, the result keeps its invariants, nothing is
 * written out of bounds (the sanitizer suite runs this too), and without a
 * table overflow every pixel >= T lands in exactly one blob. */
static void test_random_frames_invariants(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 99);
    const mfns_pixfmt_t fmts[] = {MFNS_PIXFMT_GREY, MFNS_PIXFMT_Y10, MFNS_PIXFMT_Y12, MFNS_PIXFMT_Y16};
    const double density[] = {0.002, 0.02, 0.1, 0.3, 0.6};
    mfns_centroid_settings_t set = flight_settings();
    set.min_area_px = 2;
    set.max_area_px = 2000;
    int saw_full = 0, saw_ok = 0;
    for (int trial = 0; trial < 40; trial++) {
        const mfns_pixfmt_t fmt = fmts[trial % 4];
        const uint32_t maxv = (1u << fmt_bits(fmt)) - 1u;
        const scene_t sc = {fmt, (uint16_t)(50 + mfns_rng_uniform(&rng) * 250),
                            (uint16_t)(20 + mfns_rng_uniform(&rng) * 180), 0, 0, 0};
        const mfns_frame_t f = frame_of(&sc);
        const double p = density[trial % 5];
        const uint32_t T = maxv / 2u;
        uint32_t expected = 0;
        for (int y = 0; y < sc.h; y++) {
            for (int x = 0; x < sc.w; x++) {
                const uint32_t v = mfns_rng_uniform(&rng) < p ? T + (uint32_t)(mfns_rng_uniform(&rng) * (maxv - T))
                                                              : (uint32_t)(mfns_rng_uniform(&rng) * T);
                put_px(&f, x, y, v);
                expected += v >= T;
            }
        }
        set.threshold_dn = (uint16_t)(T - 1u);
        const mfns_centroid_bg_t bg = {0.0f, 0.0f, 0u};
        const mfns_centroid_status_t st = mfns_centroid_detect(&f, &set, &bg, NULL, 0, &g_work, &g_res);
        assert_true(st == MFNS_CENTROID_OK || st == MFNS_CENTROID_TABLE_FULL);
        assert_true((st == MFNS_CENTROID_TABLE_FULL) == (g_res.n_lost > 0u));
        assert_true(g_res.n_blobs <= MFNS_MAX_BLOBS_PER_CAMERA && g_res.n_accepted <= g_res.n_blobs);
        uint32_t area = 0;
        for (int k = 0; k < g_res.n_blobs; k++) {
            const mfns_blob_t *b = &g_res.blob[k];
            assert_true((k < g_res.n_accepted) == (b->reasons == 0u));
            assert_true(b->x_min <= b->x_max && b->x_max < sc.w && b->y_min <= b->y_max && b->y_max < sc.h);
            assert_true(b->area_px >= 1u &&
                        b->area_px <= (uint32_t)(b->x_max - b->x_min + 1) * (uint32_t)(b->y_max - b->y_min + 1));
            /* positive weights: the centroid is a convex combination of pixel centres */
            assert_true(b->u_q8 >= b->x_min * 256 && b->u_q8 <= b->x_max * 256);
            assert_true(b->v_q8 >= b->y_min * 256 && b->v_q8 <= b->y_max * 256);
            assert_true(b->peak_dn >= T && b->peak_dn <= maxv);
            assert_true(b->elongation >= 1.0f);
            assert_true(b->reasons == 0u ? cov_is_pd(b) : cov_is_zero(b));
            area += b->area_px;
        }
        if (st == MFNS_CENTROID_OK) {
            assert_int_equal(area, expected);
            saw_ok++;
        } else {
            saw_full++;
        }
    }
    assert_true(saw_ok > 0 && saw_full > 0);
}

static void test_formats_agree(void **state)
{
    (void)state;
    const mfns_pixfmt_t fmts[] = {MFNS_PIXFMT_GREY, MFNS_PIXFMT_Y10, MFNS_PIXFMT_Y12, MFNS_PIXFMT_Y16};
    const cs_spot_t s = {CS_GAUSS, 60.37, 41.81, 1.3, 0, 0};
    for (int i = 0; i < 4; i++) {
        const double scale = (double)(1u << (fmt_bits(fmts[i]) - 8u));
        const scene_t sc = {fmts[i], 120, 90, 10.0 * scale, 0, 0};
        scene_begin(&sc);
        scene_add_spot(&sc, &s, 200.0 * scale / peak_fraction(s));
        scene_render(&sc, NULL, false);
        const mfns_frame_t f = frame_of(&sc);
        mfns_centroid_settings_t set = flight_settings();
        set.threshold_dn = (uint16_t)(2.0 * scale);
        const mfns_centroid_bg_t bg = {(float)(10.0 * scale), 0.0f, 0u};
        assert_int_equal(mfns_centroid_detect(&f, &set, &bg, NULL, 0, &g_work, &g_res), MFNS_CENTROID_OK);
        assert_int_equal(g_res.n_accepted, 1);
        /* 8-bit rounding of the profile limits GREY to a few thousandths */
        assert_near(g_res.blob[0].u_q8 / 256.0, s.x0, 0.006);
        assert_near(g_res.blob[0].v_q8 / 256.0, s.y0, 0.006);
        assert_near(g_res.blob[0].flux_dn, 200.0 * scale / peak_fraction(s), 0.03 * 200.0 * scale / peak_fraction(s));
    }
}

static void test_malformed_inputs_refused(void **state)
{
    (void)state;
    const scene_t sc = {MFNS_PIXFMT_Y12, 64, 48, 100.0, 0, 0};
    flat_frame(&sc);
    const mfns_frame_t good = frame_of(&sc);
    const mfns_centroid_settings_t set = flight_settings();
    const mfns_centroid_bg_t bg = {100.0f, 2.0f, 0u};
    mfns_centroid_bg_t bgo;
    struct {
        mfns_frame_t f;
        mfns_centroid_status_t want;
    } bad[] = {
        {good, MFNS_CENTROID_ERR_NULL},   {good, MFNS_CENTROID_ERR_SIZE},   {good, MFNS_CENTROID_ERR_SIZE},
        {good, MFNS_CENTROID_ERR_SIZE},   {good, MFNS_CENTROID_ERR_STRIDE}, {good, MFNS_CENTROID_ERR_STRIDE},
        {good, MFNS_CENTROID_ERR_FORMAT},
    };
    bad[0].f.data = NULL;
    bad[1].f.width = 0;
    bad[2].f.height = 0;
    bad[3].f.width = MFNS_CENTROID_MAX_DIM + 1;
    bad[4].f.stride_bytes = 64 * 2 - 2; /* stride < width */
    bad[5].f.stride_bytes = 64 * 2 + 1; /* odd stride for 16-bit words */
    bad[6].f.format = (mfns_pixfmt_t)7;
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        g_res.n_blobs = 99;
        assert_int_equal(mfns_centroid_detect(&bad[i].f, &set, &bg, NULL, 0, &g_work, &g_res), bad[i].want);
        assert_int_equal(g_res.n_blobs, 0);
        assert_int_equal(mfns_centroid_background(&bad[i].f, NULL, 0, &g_work, &bgo), bad[i].want);
    }
    assert_int_equal(mfns_centroid_detect(NULL, &set, &bg, NULL, 0, &g_work, &g_res), MFNS_CENTROID_ERR_NULL);
    assert_int_equal(mfns_centroid_detect(&good, NULL, &bg, NULL, 0, &g_work, &g_res), MFNS_CENTROID_ERR_NULL);
    assert_int_equal(mfns_centroid_detect(&good, &set, NULL, NULL, 0, &g_work, &g_res), MFNS_CENTROID_ERR_NULL);
    assert_int_equal(mfns_centroid_detect(&good, &set, &bg, NULL, 0, NULL, &g_res), MFNS_CENTROID_ERR_NULL);
    assert_int_equal(mfns_centroid_detect(&good, &set, &bg, NULL, 0, &g_work, NULL), MFNS_CENTROID_ERR_NULL);
    assert_int_equal(mfns_centroid_detect(&good, &set, &bg, NULL, 2, &g_work, &g_res), MFNS_CENTROID_ERR_NULL);
    assert_int_equal(mfns_centroid_background(&good, NULL, 0, &g_work, NULL), MFNS_CENTROID_ERR_NULL);
    /* GREY with stride == width is fine; an 8-bit odd stride too */
    mfns_frame_t g8 = {g_fb, 63, 10, 63, MFNS_PIXFMT_GREY};
    assert_int_equal(mfns_centroid_background(&g8, NULL, 0, &g_work, &bgo), MFNS_CENTROID_OK);
    /* settings */
    mfns_centroid_settings_t s = set;
    s.threshold_k_sigma = NAN;
    assert_int_equal(mfns_centroid_detect(&good, &s, &bg, NULL, 0, &g_work, &g_res), MFNS_CENTROID_ERR_SETTINGS);
    s = set;
    s.min_area_px = 0;
    assert_int_equal(mfns_centroid_detect(&good, &s, &bg, NULL, 0, &g_work, &g_res), MFNS_CENTROID_ERR_SETTINGS);
    s = set;
    s.max_area_px = 2;
    assert_int_equal(mfns_centroid_detect(&good, &s, &bg, NULL, 0, &g_work, &g_res), MFNS_CENTROID_ERR_SETTINGS);
    s = set;
    s.max_elongation = 0.5f;
    assert_int_equal(mfns_centroid_detect(&good, &s, &bg, NULL, 0, &g_work, &g_res), MFNS_CENTROID_ERR_SETTINGS);
    /* background */
    mfns_centroid_bg_t b2 = {NAN, 1.0f, 0u};
    assert_int_equal(mfns_centroid_detect(&good, &set, &b2, NULL, 0, &g_work, &g_res), MFNS_CENTROID_ERR_BACKGROUND);
    b2 = (mfns_centroid_bg_t){5000.0f, 1.0f, 0u}; /* beyond 12 bits */
    assert_int_equal(mfns_centroid_detect(&good, &set, &b2, NULL, 0, &g_work, &g_res), MFNS_CENTROID_ERR_BACKGROUND);
    b2 = (mfns_centroid_bg_t){100.0f, -1.0f, 0u};
    assert_int_equal(mfns_centroid_detect(&good, &set, &b2, NULL, 0, &g_work, &g_res), MFNS_CENTROID_ERR_BACKGROUND);
    /* windows */
    const mfns_roi_t empty = {10, 10, 10, 20}, outside = {10, 10, 65, 20};
    const mfns_roi_t overlap[2] = {{0, 0, 20, 20}, {19, 19, 30, 30}};
    assert_int_equal(mfns_centroid_detect(&good, &set, &bg, &empty, 1, &g_work, &g_res), MFNS_CENTROID_ERR_ROI);
    assert_int_equal(mfns_centroid_detect(&good, &set, &bg, &outside, 1, &g_work, &g_res), MFNS_CENTROID_ERR_ROI);
    assert_int_equal(mfns_centroid_detect(&good, &set, &bg, overlap, 2, &g_work, &g_res), MFNS_CENTROID_ERR_ROI);
    assert_int_equal(mfns_centroid_background(&good, overlap, 2, &g_work, &bgo), MFNS_CENTROID_ERR_ROI);
    assert_int_equal(mfns_centroid_detect(&good, &set, &bg, overlap, MFNS_CENTROID_MAX_ROIS + 1, &g_work, &g_res),
                     MFNS_CENTROID_ERR_ROI);
    /* every status has its own message */
    const mfns_centroid_status_t all[] = {MFNS_CENTROID_OK,         MFNS_CENTROID_TABLE_FULL,   MFNS_CENTROID_ERR_NULL,
                                          MFNS_CENTROID_ERR_SIZE,   MFNS_CENTROID_ERR_STRIDE,   MFNS_CENTROID_ERR_FORMAT,
                                          MFNS_CENTROID_ERR_SETTINGS, MFNS_CENTROID_ERR_ROI, MFNS_CENTROID_ERR_BACKGROUND};
    const size_t na = sizeof all / sizeof all[0];
    for (size_t i = 0; i < na; i++) {
        for (size_t j = 0; j < i; j++) {
            assert_int_not_equal(all[i], all[j]);
            assert_string_not_equal(mfns_centroid_strerror(all[i]), mfns_centroid_strerror(all[j]));
        }
    }
    assert_string_equal(mfns_centroid_strerror((mfns_centroid_status_t)42), "unknown centroid status");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_malformed_inputs_refused),
        cmocka_unit_test(test_threshold_scan_exact),
        cmocka_unit_test(test_formats_agree),
        cmocka_unit_test(test_random_frames_invariants),
        cmocka_unit_test(test_rejection_reasons),
        cmocka_unit_test(test_table_overflow_reported),
        cmocka_unit_test(test_roi_matches_full_frame),
        cmocka_unit_test(test_pure_noise_no_false_blob),
        cmocka_unit_test(test_accuracy_16bit),
        cmocka_unit_test(test_accuracy_8bit),
        cmocka_unit_test(test_accuracy_bright_background),
        cmocka_unit_test(test_covariance_contract),
        cmocka_unit_test(test_covariance_matches_scatter),
        cmocka_unit_test(test_covariance_elongated_spot),
    };
    return cmocka_run_group_tests_name("centroid", tests, NULL, NULL);
}
