/* bench_filter.c -- time of the navigation filter bank per cycle (make
 * bench-filter; issue 42's "cycle time inside the budget").
 *
 * The bank (firmware/nav/filter/filter_bank.h) on the paper's rig with
 * 4 + 3 + 3 and 6 + 4 + 2 beacons in view (10 and 12 beacon hypotheses:
 * MFNS_BANK_MAX_BEACON_HYP is 12, so the second is the bank's widest), the
 * robot swaying +-50 mm along x and +-3 deg in yaw over 10 s (up to 31 mm/s,
 * 20 mm/s^2: inside the motion bound), 0.1 px noise, cameras 7 ms apart:
 * per cycle three mfns_bank_observe_frame calls and one mfns_bank_evaluate.
 * Reported: median, 99th percentile and worst time per cycle over 400
 * cycles after 20 of warm-up, and the bank's own work count (filter updates
 * + propagations + separations), the figure to scale by the flight CPU's
 * speed against this machine's. */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "firmware/nav/filter/filter_bank.h"
#include "tests/unit/support/pose_testlib.h"

#pragma GCC diagnostic ignored "-Wdouble-promotion"

#define CYCLES 400
#define WARMUP 20
#define PERIOD_US 54000
/* the sway: amplitude along x (mm) and in yaw (rad), angular frequency (rad/s) */
static const double amp_mm = 50.0, amp_rad = 3.0 * 3.14159265358979 / 180.0, omega = 2.0 * 3.14159265358979 / 10.0;

static double now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e6 + (double)ts.tv_nsec * 1e-3;
}

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static mfns_filter_bank_t g_bank;
static double g_t[CYCLES];

static void run(const char *name, const int per_cam[3], uint64_t seed)
{
    mfns_rng_t rng;
    mfns_rng_seed(&rng, seed);
    const mfns_rig_t rig = pt_paper_rig();
    static const double eye[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    static const double r0[3] = {0, 0, 0};
    pt_dpose_t truth = pt_pose(eye, r0);
    const mfns_beacon_map_t map = pt_dense_map(&rig, &truth, per_cam, 900, 1400, &rng);
    mfns_filter_settings_t fs;
    mfns_filter_settings_default(&fs);
    mfns_integrity_settings_t is;
    mfns_integrity_settings_default(&is);
    float cov[6][6] = {{0}};
    for (int i = 0; i < 3; i++) {
        cov[i][i] = 0.25f;
        cov[3 + i][3 + i] = 1e-7f;
    }
    const mfns_pose_t p0 = pt_to_float(&truth);
    const float v0 = (float)(amp_mm * omega); /* the truth's at t = 0 */
    if (mfns_bank_init(&g_bank, &p0, (const float(*)[6])cov, mfns_v3(v0, 0, 0), 500.0f, mfns_v3(0, 0, 0), 0.5f, 0) !=
        MFNS_FILTER_OK) {
        printf("bench_filter: bank init failed\n");
        exit(1);
    }
    unsigned long work = 0, work_max = 0;
    int usable = 0;
    for (int k = 1; k <= CYCLES + WARMUP; k++) {
        mfns_filter_obs_t fo[MFNS_NUM_CAMERAS][MFNS_MAX_OBS_PER_CAMERA];
        int16_t beacon[MFNS_NUM_CAMERAS][MFNS_MAX_OBS_PER_CAMERA];
        int n[MFNS_NUM_CAMERAS] = {0};
        for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
            /* the truth at camera c's capture time, 7 ms apart */
            const double t_s = ((double)k * PERIOD_US + 7000.0 * c) * 1e-6;
            const double yaw = amp_rad * sin(omega * t_s), cy = cos(yaw), sy = sin(yaw);
            const double c_w_b[3][3] = {{cy, sy, 0}, {-sy, cy, 0}, {0, 0, 1}};
            const double r[3] = {amp_mm * sin(omega * t_s), 0.0, 0.0};
            const pt_dpose_t at = pt_pose(c_w_b, r);
            mfns_obs_frame_t frame;
            mfns_pose_assoc_t assoc;
            (void)pt_make_frame(&rig, &map, &at, 0.1, &rng, &frame, &assoc);
            for (int i = 0; i < frame.count[c] && n[c] < MFNS_MAX_OBS_PER_CAMERA; i++) {
                const int16_t b = assoc.beacon[c][i];
                if (b < 0) {
                    continue;
                }
                mfns_filter_obs_t *o = &fo[c][n[c]];
                o->t_us = (int64_t)k * PERIOD_US + 7000 * c;
                o->cam = (uint8_t)c;
                o->u = frame.obs[c][i].u;
                o->v = frame.obs[c][i].v;
                memcpy(o->cov_px2, frame.obs[c][i].cov_px2, sizeof o->cov_px2);
                o->p_w = map.beacon[b].p_w;
                o->sigma_mm = map.beacon[b].sigma_mm;
                beacon[c][n[c]] = b;
                n[c]++;
            }
        }
        const double t0 = now_us();
        for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
            (void)mfns_bank_observe_frame(&g_bank, &fs, &rig, 0.1f, n[c], beacon[c], fo[c]);
        }
        mfns_bank_output_t out;
        const mfns_filter_status_t st =
            mfns_bank_evaluate(&g_bank, &fs, &is, NULL, (int64_t)k * PERIOD_US + 14000, &out);
        const double t1 = now_us();
        if (st != MFNS_FILTER_OK || out.restart) {
            printf("bench_filter: %s: the bank stopped at cycle %d (status %d)\n", name, k, (int)st);
            exit(1);
        }
        if (k > WARMUP) {
            g_t[k - WARMUP - 1] = t1 - t0;
            work += out.work;
            work_max = out.work > work_max ? out.work : work_max;
            usable += out.usable ? 1 : 0;
        }
    }
    qsort(g_t, CYCLES, sizeof g_t[0], cmp_double);
    printf("%-22s %8.1f %8.1f %8.1f   %7.0f %7lu   %d/%d\n", name, g_t[CYCLES / 2], g_t[(CYCLES * 99) / 100 - 1],
           g_t[CYCLES - 1], (double)work / CYCLES, work_max, usable, CYCLES);
}

int main(void)
{
    printf("filter bank per cycle (3 frames + evaluate), %d cycles, us on this machine\n", CYCLES);
    printf("%-22s %8s %8s %8s   %7s %7s   %s\n", "beacons in view", "median", "p99", "worst", "work", "max",
           "usable");
    static const int a[3] = {4, 3, 3}, b[3] = {6, 4, 2};
    run("4+3+3 (13 hyp)", a, 1);
    run("6+4+2 (15 hyp)", b, 2);
    return 0;
}
