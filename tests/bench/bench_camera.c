/* bench_camera.c -- replay camera throughput: ms per 1280x1024 frame read as
 * fast as possible (8-bit GREY and 16-bit Y12), from a synthetic frame folder
 * (docs/nav-frames.md layout) written into a mkdtemp directory. The flight
 * loop needs a frame per camera every 53.8 ms (18.6 Hz), three cameras. */
#define _XOPEN_SOURCE 700
#ifndef _DEFAULT_SOURCE
#define _DEFAULT_SOURCE 1
#endif
#include <ftw.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#include "drivers/camera/camera.h"

#define W 1280u
#define H 1024u
#define N_FRAMES 40

static uint8_t g_px[2u * W * H];

static double now_s(void)
{
    struct timespec ts;
    (void)clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static int write_folder(const char *dir, unsigned maxval)
{
    char path[512];
    (void)snprintf(path, sizeof path, "%s/cam_x", dir);
    if (mkdir(path, 0700) != 0) {
        return -1;
    }
    (void)snprintf(path, sizeof path, "%s/scenario.json", dir);
    FILE *f = fopen(path, "w");
    if (!f) {
        return -1;
    }
    (void)fprintf(f, "{\"format\": \"mfns-nav-frames\", \"version\": 1}\n");
    if (fclose(f) != 0) {
        return -1;
    }
    (void)snprintf(path, sizeof path, "%s/frames.csv", dir);
    FILE *csv = fopen(path, "w");
    if (!csv) {
        return -1;
    }
    (void)fprintf(csv, "frame,t_s,camera,file,exposure_us,gain_db\n");
    const size_t bytes = (size_t)W * H * (maxval > 255 ? 2u : 1u);
    for (size_t i = 0; i < bytes; i++) {
        g_px[i] = (uint8_t)((i * 7u) & (maxval > 255 ? 0x0fu : 0xffu)); /* 16-bit samples stay below 4096 */
    }
    int rc = 0;
    for (int k = 0; k < N_FRAMES && rc == 0; k++) {
        (void)snprintf(path, sizeof path, "%s/cam_x/%06d.pgm", dir, k);
        FILE *p = fopen(path, "wb");
        if (!p) {
            rc = -1;
            break;
        }
        (void)fprintf(p, "P5\n%u %u\n%u\n", W, H, maxval);
        if (fwrite(g_px, 1, bytes, p) != bytes) {
            rc = -1;
        }
        if (fclose(p) != 0) {
            rc = -1;
        }
        (void)fprintf(csv, "%d,%.6f,x,cam_x/%06d.pgm,1000,0.0\n", k, k / 18.6, k);
    }
    if (fclose(csv) != 0) {
        rc = -1;
    }
    return rc;
}

static int rm_entry(const char *path, const struct stat *sb, int flag, struct FTW *ftw)
{
    (void)sb;
    (void)flag;
    (void)ftw;
    return remove(path);
}

static int run(unsigned maxval)
{
    char dir[] = "/tmp/mfns_bench_cam_XXXXXX";
    if (!mkdtemp(dir)) {
        perror("mkdtemp");
        return 1;
    }
    int rc = write_folder(dir, maxval);
    if (rc == 0) {
        mfns_cam_settings_t s = mfns_cam_default_settings(MFNS_CAM_BACKEND_REPLAY, dir);
        s.buffer_count = 2;
        mfns_cam_t *cam = NULL;
        char msg[MFNS_CAM_MSG_LEN];
        mfns_cam_err_t e = mfns_cam_open(&s, &cam, msg, sizeof msg);
        if (e == MFNS_CAM_OK) {
            e = mfns_cam_start(cam);
        }
        int n = 0;
        double best = 1e9;
        for (int rep = 0; rep < 3 && e == MFNS_CAM_OK; rep++) {
            const double t0 = now_s();
            n = 0;
            mfns_cam_frame_t f;
            while ((e = mfns_cam_dequeue(cam, &f, 1000)) == MFNS_CAM_OK) {
                n++;
                e = mfns_cam_requeue(cam, &f);
                if (e != MFNS_CAM_OK) {
                    break;
                }
            }
            const double dt = now_s() - t0;
            best = dt < best ? dt : best;
            if (e == MFNS_CAM_E_END && n == N_FRAMES) {
                e = mfns_cam_stop(cam);
                if (e == MFNS_CAM_OK) {
                    e = mfns_cam_start(cam);
                }
            }
        }
        if (e != MFNS_CAM_OK || n != N_FRAMES) {
            (void)fprintf(stderr, "bench-camera: %s: %s\n", mfns_cam_strerror(e),
                          cam ? mfns_cam_message(cam) : msg);
            rc = 1;
        } else {
            (void)printf("bench-camera: replay %ux%u maxval %u: %.3f ms/frame (%d frames, best of 3, page cache warm)\n",
                         W, H, maxval, best * 1e3 / N_FRAMES, N_FRAMES);
        }
        mfns_cam_close(cam);
    }
    if (nftw(dir, rm_entry, 8, FTW_DEPTH | FTW_PHYS) != 0) {
        rc = 1;
    }
    return rc;
}

int main(void)
{
    const int rc = run(255) | run(4095);
    return rc;
}
