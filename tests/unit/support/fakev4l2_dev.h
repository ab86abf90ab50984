/* fakev4l2_dev.h -- a simulated V4L2 capture device behind the camera
 * backend's syscall seam (drivers/camera/camera_v4l2.h), for tests.
 *
 * It answers the ioctls a capture driver answers (QUERYCAP, G/S_FMT single-
 * and multi-planar, REQBUFS, QUERYBUF, QBUF, DQBUF, STREAMON/OFF, QUERYCTRL,
 * G/S_CTRL, G/S_PARM), hands out real memory through mmap, and injects the
 * faults a real device shows: EINTR, EAGAIN, a stalled stream (poll times
 * out), error-flagged and short buffers, sequence gaps, mmap failure, fewer
 * buffers than asked, and unplugging (ENODEV) with a later return. It records
 * every ioctl in order so a test can check the whole sequence. */
#ifndef MFNS_FAKEV4L2_DEV_H
#define MFNS_FAKEV4L2_DEV_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "drivers/camera/camera_v4l2.h"

#define FAKEV4L2_MAX_BUFS 32
#define FAKEV4L2_MAX_ALLOCS 128
#define FAKEV4L2_TRACE_LEN 512

typedef struct {
    uint8_t *mem;
    size_t length;
    uint32_t offset; /* mmap cookie */
    int mapped;
} fakev4l2_alloc_t;

typedef struct {
    /* Fields are grouped by size (8-byte, 4-byte, 1-byte) to keep padding out;
     * the comments say which group a field belongs to in use. */
    /* --- 8-byte fields --- */
    unsigned long eintr_request; /* fault: EINTR only for this request (0 = any) */
    long slept_ms;               /* record: poll(NULL, 0, t) sleeps asked for */
    int64_t arrival_delay_ns;    /* now_ns() answers the last frame's stamp plus this */
    int64_t last_stamp_ns;       /* state: the last frame's stamp */
    fakev4l2_alloc_t allocs[FAKEV4L2_MAX_ALLOCS];
    unsigned long trace[FAKEV4L2_TRACE_LEN]; /* record: every ioctl request in order */
    /* --- device description (set before opening) --- */
    uint32_t formats[4];    /* supported fourccs; [0] is the default */
    uint32_t nformats;
    uint32_t max_w, max_h;  /* S_FMT clamps to these; G_FMT starts here */
    uint32_t stride_pad;    /* bytesperline = width * bpp + stride_pad */
    uint32_t max_buffers;   /* REQBUFS grants at most this */
    int32_t exp_min, exp_max, gain_min, gain_max;
    float max_fps;          /* S_PARM caps the rate here */
    /* --- faults (each counter is consumed as it fires) --- */
    int eintr_next;             /* next N matching ioctls fail with EINTR */
    int eintr_poll_next;        /* next N polls fail with EINTR */
    int eagain_next;            /* next N DQBUFs say EAGAIN although a frame is ready */
    int eio_next;               /* next N DQBUFs fail with EIO */
    int error_flag_next;        /* next N frames carry V4L2_BUF_FLAG_ERROR */
    int short_next;             /* next N frames have bytesused below a full image */
    uint32_t seq_skip_next;     /* sequence jumps by this before the next frame */
    bool no_seq;                /* every frame says sequence 0 (a driver that numbers none: v4l2loopback 0.12) */
    uint32_t ts_flags;          /* timestamp flags of every frame (init: MONOTONIC | SRC_EOF) */
    int mmap_fail_at;           /* 0-based mmap call that fails with ENOMEM; -1 none */
    int unplug_at_dqbuf;        /* the DQBUF call (1-based count) at which it vanishes; 0 none */
    int replug_after_opens;     /* while unplugged: opens that fail before it is back; -1 never */
    int qbuf_enodev_next;       /* next N QBUFs fail with ENODEV and unplug */
    /* --- state --- */
    int live_fd;
    int open_fds;
    int next_fd;
    uint32_t fourcc, w, h, stride, sizeimage;
    uint32_t nbuf;
    int buf_alloc[FAKEV4L2_MAX_BUFS]; /* index into allocs */
    uint32_t qorder[FAKEV4L2_MAX_BUFS];
    uint32_t nqueued;
    uint32_t seq;
    int32_t exposure, exposure_auto, gain;
    uint32_t tpf_num, tpf_den;
    int nallocs;
    /* --- records --- */
    int ntrace;
    int opens, failed_opens, mmaps, munmaps, bad_munmaps, live_mappings, dqbufs, polls;
    int last_poll_timeout;
    uint32_t last_bytesused;
    /* --- 1-byte fields --- */
    bool mplane;            /* description: multi-planar API only */
    bool no_streaming;      /* description: capabilities without V4L2_CAP_STREAMING */
    bool not_capture;       /* description: neither capture capability */
    bool has_exposure, has_exposure_auto, has_gain, has_timeperframe;
    bool stalled;           /* fault: no frames at all: DQBUF EAGAIN, poll times out */
    bool unplugged;         /* state */
    bool streaming;         /* state */
    bool queued[FAKEV4L2_MAX_BUFS];
} fakev4l2_dev_t;

/* A healthy single-planar GREY device, 64x48, 8 buffers, all controls. */
void fakev4l2_init(fakev4l2_dev_t *d);
/* Frees every buffer the device ever allocated (call at test end). */
void fakev4l2_free(fakev4l2_dev_t *d);
/* The seam that routes the backend's syscalls to d. */
mfns_cam_sys_t fakev4l2_sys(fakev4l2_dev_t *d);
/* Number of times request was issued. */
int fakev4l2_count(const fakev4l2_dev_t *d, unsigned long request);
/* Index in the trace of the first occurrence of request at or after from; -1 if none. */
int fakev4l2_find(const fakev4l2_dev_t *d, unsigned long request, int from);
/* The device vanishes now (its fds die: ioctls ENODEV); the next replug_after_opens
 * opens fail with ENOENT, the one after succeeds (-1: it never returns). */
void fakev4l2_unplug(fakev4l2_dev_t *d, int replug_after_opens);

#endif
