/* camera_backend.h -- private to drivers/camera: the handle layout and the
 * table of operations each backend provides. The flight program uses
 * camera.h only. */
#ifndef MFNS_DRIVERS_CAMERA_BACKEND_H
#define MFNS_DRIVERS_CAMERA_BACKEND_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "drivers/camera/camera_types.h"

#ifdef __cplusplus
extern "C" {
#endif

#define MFNS_CAM_PATH_LEN 256u

typedef struct {
    mfns_cam_err_t (*open)(mfns_cam_t *h); /* h->s and h->path are set */
    mfns_cam_err_t (*start)(mfns_cam_t *h);
    mfns_cam_err_t (*dequeue)(mfns_cam_t *h, mfns_cam_frame_t *f, int timeout_ms);
    mfns_cam_err_t (*requeue)(mfns_cam_t *h, const mfns_cam_frame_t *f);
    mfns_cam_err_t (*stop)(mfns_cam_t *h);
    void (*close)(mfns_cam_t *h); /* releases everything, whatever the state */
    mfns_cam_err_t (*set_controls)(mfns_cam_t *h, int32_t exposure_us, int32_t gain);
} mfns_cam_backend_ops_t;

extern const mfns_cam_backend_ops_t mfns_cam_v4l2_ops;
extern const mfns_cam_backend_ops_t mfns_cam_replay_ops;
#if defined(MFNS_HAVE_LIBCAMERA)
extern const mfns_cam_backend_ops_t mfns_cam_libcamera_ops;
#endif

typedef struct {
    int fd;                 /* -1 while closed or lost */
    uint32_t buf_type;      /* V4L2_BUF_TYPE_VIDEO_CAPTURE or ..._MPLANE */
    uint32_t fourcc;
    uint32_t nbuf;
    uint32_t min_bytes;     /* a frame shorter than this is truncated */
    /* One struct per buffer, not parallel arrays: gcc 12 for aarch64
     * miscompiled a loop over parallel arrays here (ivopts rewrote the
     * addresses so that pure-const analysis thought the loop had no effect
     * and deleted the call: the buffers were never unmapped). */
    struct {
        void *start;
        size_t length;
        bool held;
    } buf[MFNS_CAM_MAX_BUFFERS];
    bool lost;              /* device vanished; reopen pending */
    uint32_t attempts_left; /* reopen attempts left for this loss */
    bool failed;            /* recovery exhausted */
    bool want_stream;       /* streaming was requested (restart after recovery) */
    int32_t exposure_us;    /* last value set, -1 unknown */
    int32_t gain;
    /* Frame numbers: V4L2 says buffer.sequence counts the frames from 0 at
     * STREAMON; a driver that leaves it 0 on every buffer (v4l2loopback 0.12)
     * is found at the second frame of a stream (0 twice) and from then on its
     * frames are numbered by this count of dequeued ones (own_seq). */
    uint32_t dq_count;      /* frames dequeued since STREAMON */
    bool own_seq;
} mfns_cam_v4l2_t;

struct mfns_replay_folder; /* camera_replay.c: one parsed frames.csv per folder, shared */

typedef struct {
    struct mfns_replay_folder *folder;
    uint32_t cursor;     /* next row of the shared table to look at */
    uint32_t row;        /* the row being delivered (valid while have_row) */
    bool have_row;
    bool end;
    uint32_t maxval;
    size_t frame_bytes;
    uint8_t *mem; /* nbuf * frame_bytes, allocated at open */
    uint32_t nbuf;
    bool held[MFNS_CAM_MAX_BUFFERS];
    bool t0_set;
    int64_t t0_ns;
    double t_first;
} mfns_cam_replay_t;

struct mfns_cam {
    const mfns_cam_backend_ops_t *ops;
    mfns_cam_stats_t stats;
    mfns_cam_settings_t s;
    union {
        mfns_cam_v4l2_t v4l2;
        mfns_cam_replay_t replay;
        void *lcam; /* camera_libcamera.cpp state */
    } b;
    uint32_t events;
    uint32_t last_seq;
    uint32_t missing; /* errored frames since the last delivered one */
    uint32_t generation;
    mfns_cam_info_t info;
    bool streaming;
    bool have_seq;
    char msg[MFNS_CAM_MSG_LEN];
    char path[MFNS_CAM_PATH_LEN]; /* s.path points here */
};

/* Records the handle's one-line failure detail; returns e for tail calls. */
mfns_cam_err_t mfns_cam_fail(mfns_cam_t *h, mfns_cam_err_t e, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
/* Sequence bookkeeping shared by the backends. Delivered frame: returns the
 * frames missing before it (gaps + errored ones) and counts gaps as drops.
 * Errored frame: moves the baseline, counts it. Reset: new stream. */
uint32_t mfns_cam_seq_delivered(mfns_cam_t *h, uint32_t seq);
void mfns_cam_seq_errored(mfns_cam_t *h, uint32_t seq);
void mfns_cam_seq_reset(mfns_cam_t *h);
/* CLOCK_MONOTONIC in ns. */
int64_t mfns_cam_now_ns(void);

#ifdef __cplusplus
}
#endif

#endif
