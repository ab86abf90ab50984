/* bench_centroid.c -- speed of firmware/nav/centroid on a 1280x1024 8-bit
 * frame with 10 beacon spots and realistic noise (make bench; not a test).
 *
 *   bench_centroid OUTDIR [--once]
 *
 * Writes OUTDIR/centroid_frame.pgm (the frame, for the OpenCV comparison) and
 * OUTDIR/centroid_c.txt (key value lines: timings, threshold, centroids).
 * --once runs a single full-frame centroiding in bench_centroid_once() and
 * nothing else timed, for callgrind --toggle-collect=bench_centroid_once.
 */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "firmware/nav/centroid/centroid.h"

#define W 1280
#define H 1024
#define NSPOTS 10

static uint8_t g_frame[(size_t)W * H];
static uint8_t g_copy[(size_t)W * H];
static mfns_centroid_work_t g_work;
static mfns_centroid_result_t g_res;

static uint64_t g_rng = 0x9E3779B97F4A7C15ull;
static double uniform(void)
{
    g_rng ^= g_rng >> 12;
    g_rng ^= g_rng << 25;
    g_rng ^= g_rng >> 27;
    return (double)((g_rng * 2685821657736338717ull) >> 11) * (1.0 / 9007199254740992.0);
}
static double normal(void)
{
    const double u = uniform() + 1e-300, v = uniform();
    return sqrt(-2.0 * log(u)) * cos(2.0 * 3.14159265358979323846 * v);
}

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Background 12 DN, read noise 1.5 DN, shot noise at 4 e-/DN; spots Gaussian
 * sigma 1-2.5 px with peaks 120-220 DN, pixel-integrated. */
static void make_frame(double truth[NSPOTS][2])
{
    static double mu[(size_t)W * H];
    for (size_t i = 0; i < (size_t)W * H; i++) {
        mu[i] = 12.0;
    }
    for (int k = 0; k < NSPOTS; k++) {
        const int col = k % 5, row = k / 5;
        const double x0 = 80 + 270 * col + 40 * uniform(), y0 = 150 + 600 * row + 40 * uniform();
        const double s = 1.0 + 1.5 * uniform(), peak = 120 + 100 * uniform();
        truth[k][0] = x0;
        truth[k][1] = y0;
        const double amp = peak * 2.0 * 3.14159265358979323846 * s * s;
        for (int y = (int)y0 - 12; y <= (int)y0 + 12; y++) {
            for (int x = (int)x0 - 12; x <= (int)x0 + 12; x++) {
                const double ex = 0.5 * (erf((x + 0.5 - x0) / (s * sqrt(2.0))) - erf((x - 0.5 - x0) / (s * sqrt(2.0))));
                const double ey = 0.5 * (erf((y + 0.5 - y0) / (s * sqrt(2.0))) - erf((y - 0.5 - y0) / (s * sqrt(2.0))));
                mu[(size_t)y * W + (size_t)x] += amp * ex * ey;
            }
        }
    }
    for (size_t i = 0; i < (size_t)W * H; i++) {
        double v = mu[i] + sqrt(0.25 * mu[i]) * normal() + 1.5 * normal();
        v = floor(v + 0.5);
        g_frame[i] = (uint8_t)(v < 0 ? 0 : (v > 255 ? 255 : v));
    }
}

static const mfns_frame_t g_f = {g_frame, W, H, W, MFNS_PIXFMT_GREY};

__attribute__((noinline)) int bench_centroid_once(const mfns_centroid_settings_t *set);
__attribute__((noinline)) int bench_centroid_once(const mfns_centroid_settings_t *set)
{
    mfns_centroid_bg_t bg;
    if (mfns_centroid_background(&g_f, NULL, 0, &g_work, &bg) != MFNS_CENTROID_OK) {
        return -1;
    }
    return (int)mfns_centroid_detect(&g_f, set, &bg, NULL, 0, &g_work, &g_res);
}

static int bench_rois(const mfns_centroid_settings_t *set, const mfns_roi_t *rois, uint16_t n)
{
    mfns_centroid_bg_t bg;
    if (mfns_centroid_background(&g_f, rois, n, &g_work, &bg) != MFNS_CENTROID_OK) {
        return -1;
    }
    return (int)mfns_centroid_detect(&g_f, set, &bg, rois, n, &g_work, &g_res);
}

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

#define REPS 41
/* median seconds per call over REPS runs of `inner` calls each */
#define TIME_MEDIAN(result, inner, stmt)                                                                 \
    do {                                                                                                 \
        double t_[REPS];                                                                                 \
        for (int r_ = 0; r_ < REPS; r_++) {                                                              \
            const double t0_ = now_s();                                                                  \
            for (int i_ = 0; i_ < (inner); i_++) {                                                       \
                stmt;                                                                                    \
            }                                                                                            \
            t_[r_] = (now_s() - t0_) / (inner);                                                          \
        }                                                                                                \
        qsort(t_, REPS, sizeof t_[0], cmp_double);                                                       \
        (result) = t_[REPS / 2];                                                                         \
    } while (0)

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: %s OUTDIR [--once]\n", argv[0]);
        return 2;
    }
    const char *out = argv[1];
    const int once = argc > 2 && strcmp(argv[2], "--once") == 0;
    double truth[NSPOTS][2];
    make_frame(truth);
    mfns_centroid_settings_t set; /* the flight settings (nav_defaults_gen.c) */
    mfns_centroid_settings_default(&set);
    if (once) {
        return bench_centroid_once(&set) == MFNS_CENTROID_OK ? 0 : 1;
    }
    char path[512];
    snprintf(path, sizeof path, "%s/centroid_frame.pgm", out);
    FILE *fp = fopen(path, "wb");
    if (fp == NULL) {
        perror(path);
        return 1;
    }
    fprintf(fp, "P5\n%d %d\n255\n", W, H);
    if (fwrite(g_frame, 1, sizeof g_frame, fp) != sizeof g_frame || fclose(fp) != 0) {
        perror(path);
        return 1;
    }

    int st = bench_centroid_once(&set);
    if (st != MFNS_CENTROID_OK || g_res.n_accepted != NSPOTS) {
        fprintf(stderr, "bench_centroid: status %d, %u blobs accepted (want %d)\n", st, g_res.n_accepted, NSPOTS);
        return 1;
    }
    double max_err = 0.0;
    for (int k = 0; k < NSPOTS; k++) {
        double best = 1e9;
        for (int b = 0; b < g_res.n_accepted; b++) {
            const double du = g_res.blob[b].u_q8 / 256.0 - truth[k][0], dv = g_res.blob[b].v_q8 / 256.0 - truth[k][1];
            best = fmin(best, sqrt(du * du + dv * dv));
        }
        max_err = fmax(max_err, best);
    }
    const uint32_t threshold = g_res.threshold_dn;
    float uv[NSPOTS][2];
    for (int k = 0; k < NSPOTS; k++) {
        uv[k][0] = (float)truth[k][0] + 1.3f;
        uv[k][1] = (float)truth[k][1] - 0.8f;
    }
    mfns_roi_t rois[MFNS_CENTROID_MAX_ROIS];
    uint16_t n_rois = 0;
    if (mfns_centroid_make_rois((const float(*)[2])uv, NSPOTS, set.roi_half_size_px, W, H, rois,
                                MFNS_CENTROID_MAX_ROIS, &n_rois) != MFNS_CENTROID_OK ||
        bench_rois(&set, rois, n_rois) != MFNS_CENTROID_OK || g_res.n_accepted != NSPOTS) {
        fprintf(stderr, "bench_centroid: ROI mode failed\n");
        return 1;
    }
    uint32_t roi_px = 0;
    for (int r = 0; r < n_rois; r++) {
        roi_px += (uint32_t)(rois[r].x1 - rois[r].x0) * (uint32_t)(rois[r].y1 - rois[r].y0);
    }

    double t_full, t_detect, t_bg, t_roi, t_roi_detect, t_memcpy;
    volatile int sink = 0;
    mfns_centroid_bg_t bg;
    TIME_MEDIAN(t_full, 10, sink += bench_centroid_once(&set));
    TIME_MEDIAN(t_bg, 10, sink += (int)mfns_centroid_background(&g_f, NULL, 0, &g_work, &bg));
    TIME_MEDIAN(t_detect, 10, sink += (int)mfns_centroid_detect(&g_f, &set, &bg, NULL, 0, &g_work, &g_res));
    TIME_MEDIAN(t_roi, 200, sink += bench_rois(&set, rois, n_rois));
    TIME_MEDIAN(t_roi_detect, 200, sink += (int)mfns_centroid_detect(&g_f, &set, &bg, rois, n_rois, &g_work, &g_res));
    TIME_MEDIAN(t_memcpy, 10, memcpy(g_copy, g_frame, sizeof g_frame); sink += g_copy[(size_t)sink & 1023u]);
    (void)sink;

    const double bytes = (double)W * H, mb = bytes / 1e6;
    printf("centroid bench: %dx%d GREY, %d spots, threshold %u DN, max |centroid - truth| %.3f px\n", W, H, NSPOTS,
           threshold, max_err);
    printf("  full frame (background + detect): %8.3f ms  %8.1f MB/s  %6.3f ns/px\n", 1e3 * t_full, mb / t_full,
           1e9 * t_full / bytes);
    printf("    background estimate only      : %8.3f ms\n", 1e3 * t_bg);
    printf("    detect only                   : %8.3f ms  %8.1f MB/s\n", 1e3 * t_detect, mb / t_detect);
    printf("  ROI mode (%d windows, %u px)   : %8.3f ms  %8.1f frame-MB/s (%.1f x full frame)\n", n_rois, roi_px,
           1e3 * t_roi, mb / t_roi, t_full / t_roi);
 printf("    detect only, background reused  : %8.3f ms  %8.1f frame-MB/s\n", 1e3 * t_roi_detect,
           mb / t_roi_detect);
    printf("  memcpy of the frame             : %8.3f ms  %8.1f MB/s\n", 1e3 * t_memcpy, mb / t_memcpy);
    printf("  ours / memcpy bandwidth (full frame): %.2f  (target >= 0.50: %s)\n", t_memcpy / t_full,
           t_memcpy / t_full >= 0.5 ? "met" : "NOT met");

    snprintf(path, sizeof path, "%s/centroid_c.txt", out);
    fp = fopen(path, "w");
    if (fp == NULL) {
        perror(path);
        return 1;
    }
    fprintf(fp, "width %d\nheight %d\nthreshold_dn %u\nt_full_s %.9g\nt_detect_s %.9g\nt_roi_s %.9g\nt_memcpy_s %.9g\n",
            W, H, threshold, t_full, t_detect, t_roi, t_memcpy);
    if (fclose(fp) != 0) {
        perror(path);
        return 1;
    }
    return 0;
}
