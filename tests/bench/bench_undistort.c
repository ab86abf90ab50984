/* bench_undistort -- time per corrected point of the two distortion
 * corrections on the default calibration table: (a) the iterative inverse
 * with the default cap, (b) the fixed-point grid (to Q16.16 pixels, and to
 * float normalized coordinates). Usage: bench_undistort TABLE */
#define _POSIX_C_SOURCE 199309L
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "firmware/nav/table/caltable.h"
#include "firmware/app/caltable_file.h"
#include "math/undistort.h"

#define NPTS 4096
#define REPS_A 20
#define REPS_B 400

static uint8_t g_buf[MFNS_CALTABLE_MAX_BYTES];
static mfns_caltable_t g_table;
static float g_u[NPTS], g_v[NPTS];
static px_q8_t g_uq[NPTS], g_vq[NPTS];

static double now_ns(void)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_MONOTONIC, &ts) != 0) {
        return 0.0;
    }
    return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: %s TABLE\n", argv[0]);
        return 2;
    }
    uint32_t off = 0;
    const mfns_caltable_status_t st = mfns_caltable_load_file(argv[1], g_buf, sizeof g_buf, &g_table, &off);
    if (st != MFNS_CALTABLE_OK) {
        fprintf(stderr, "bench_undistort: %s: %s (offset %u)\n", argv[1], mfns_caltable_strerror(st), off);
        return 1;
    }
    uint64_t s = 0x9E3779B97F4A7C15u;
    for (int i = 0; i < NPTS; i++) {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        g_u[i] = (float)((double)(s % 1279000u) / 1000.0);
        g_v[i] = (float)((double)((s >> 24) % 1023000u) / 1000.0);
        g_uq[i] = mfns_px_q8_from_float(g_u[i]);
        g_vq[i] = mfns_px_q8_from_float(g_v[i]);
    }
    double sink = 0.0;
    long iters = 0, fails = 0;
    for (int cam = 0; cam < MFNS_NUM_CAMERAS; cam++) {
        const mfns_intrinsics_t *k = &g_table.rig.cam[cam].k;
        const mfns_undist_grid_t *g = &g_table.grid[cam];
        double t0 = now_ns();
        for (int r = 0; r < REPS_A; r++) {
            for (int i = 0; i < NPTS; i++) {
                float x, y;
                int it = 0;
                if (mfns_undistort_iter(k, g_u[i], g_v[i], MFNS_UNDIST_DEFAULT_ITER, &x, &y, &it) != MFNS_UNDIST_OK) {
                    fails++;
                }
                iters += it;
                sink += (double)x;
            }
        }
        const double ta = (now_ns() - t0) / (REPS_A * (double)NPTS);
        t0 = now_ns();
        for (int r = 0; r < REPS_B; r++) {
            for (int i = 0; i < NPTS; i++) {
                q16_16_t uu = 0, vu = 0;
                if (mfns_undistort_grid_px(g, g_uq[i], g_vq[i], &uu, &vu) != MFNS_UNDIST_OK) {
                    fails++;
                }
                sink += (double)(uu ^ vu);
            }
        }
        const double tb = (now_ns() - t0) / (REPS_B * (double)NPTS);
        t0 = now_ns();
        for (int r = 0; r < REPS_B; r++) {
            for (int i = 0; i < NPTS; i++) {
                float x = 0.0f, y = 0.0f;
                if (mfns_undistort_grid(g, k, g_uq[i], g_vq[i], &x, &y) != MFNS_UNDIST_OK) {
                    fails++;
                }
                sink += (double)y;
            }
        }
        const double tn = (now_ns() - t0) / (REPS_B * (double)NPTS);
        printf("bench-undistort: camera %d: (a) iterative %.1f ns/point, (b) grid -> Q16.16 px %.1f ns/point, "
               "(b) grid -> normalized %.1f ns/point\n",
               cam, ta, tb, tn);
    }
    printf("bench-undistort: mean Newton updates per point %.2f, failures %ld (checksum %.3g)\n",
           (double)iters / (MFNS_NUM_CAMERAS * REPS_A * (double)NPTS), fails, sink);
    return fails == 0 ? 0 : 1;
}
