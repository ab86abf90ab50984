/* camera_v4l2.c -- V4L2 capture backend: single- or multi-planar devices,
 * memory-mapped streaming, GREY/Y10/Y12/Y16, exposure/gain/frame-rate
 * controls, and recovery from a device that vanishes (ENODEV) and returns.
 *
 * Discipline follows the kernel's capture example (Documentation/userspace-api/
 * media/v4l/capture.c): every ioctl retried on EINTR, a non-blocking fd with
 * EAGAIN answered by poll() with a timeout, every dequeued buffer requeued
 * (error-flagged ones immediately), and the payload size taken from bytesused.
 * All syscalls go through the mfns_cam_sys_t seam (camera_v4l2.h).
 *
 * This file: streaming (queue, stream on/off, dequeue), loss and recovery,
 * and the backend operations; configuring the device is camera_v4l2_config.c,
 * the syscall seam camera_v4l2_sys.c (camera_v4l2_internal.h joins them). */
#ifndef _DEFAULT_SOURCE
#define _DEFAULT_SOURCE 1
#endif
#include "drivers/camera/camera_v4l2.h"

#include <errno.h>
#include <linux/videodev2.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "drivers/camera/camera_backend.h"
#include "drivers/camera/camera_v4l2_internal.h"

/* Buffer indices from the driver are below VIDEO_MAX_FRAME; the handle's
 * table holds MFNS_CAM_MAX_BUFFERS of them. */
_Static_assert(MFNS_CAM_MAX_BUFFERS <= VIDEO_MAX_FRAME, "more buffers than V4L2 can give");

/* ---- streaming ------------------------------------------------------------ */
static mfns_cam_err_t queue_buffer(mfns_cam_t *h, uint32_t i)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    struct v4l2_buffer b;
    struct v4l2_plane planes[VIDEO_MAX_PLANES];
    mfns_cam_v4l2_buffer_init(v, &b, planes, i, 1u);
    if (mfns_cam_v4l2_xioctl(h, VIDIOC_QBUF, &b) != 0) {
        return mfns_cam_fail(h, errno == ENODEV ? MFNS_CAM_E_LOST : MFNS_CAM_E_IO, "VIDIOC_QBUF(%u) failed: %s", i,
                             strerror(errno));
    }
    return MFNS_CAM_OK;
}

static mfns_cam_err_t stream_on(mfns_cam_t *h)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    mfns_cam_v4l2_clear_held(v);
    v->dq_count = 0;
    v->own_seq = false;
    for (uint32_t i = 0; i < v->nbuf; i++) {
        const mfns_cam_err_t e = queue_buffer(h, i);
        if (e != MFNS_CAM_OK) {
            return e;
        }
    }
    int type = (int)v->buf_type;
    if (mfns_cam_v4l2_xioctl(h, VIDIOC_STREAMON, &type) != 0) {
        return mfns_cam_fail(h, errno == ENODEV ? MFNS_CAM_E_LOST : MFNS_CAM_E_STREAM,
                             "VIDIOC_STREAMON failed: %s", strerror(errno));
    }
    return MFNS_CAM_OK;
}

/* ---- loss and recovery ---------------------------------------------------- */
static void mark_lost(mfns_cam_t *h)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    if (v->lost) {
        return;
    }
    v->lost = true;
    v->attempts_left = h->s.recover_attempts;
    h->stats.losses++;
    h->events |= MFNS_CAM_EV_LOST;
    /* The fd is dead: drop it and every mapping the caller does not hold. */
    mfns_cam_v4l2_unmap_all(h, true);
    v->nbuf = 0;
    mfns_cam_v4l2_close_fd(h);
}

static uint32_t held_count(const mfns_cam_v4l2_t *v)
{
    uint32_t n = 0;
    for (uint32_t i = 0; i < MFNS_CAM_MAX_BUFFERS; i++) {
        n += v->buf[i].held ? 1u : 0u;
    }
    return n;
}

static void wait_ms(mfns_cam_t *h, int64_t ms)
{
    if (ms > 0) {
        const mfns_cam_sys_t *sys = mfns_cam_v4l2_sys(h);
        (void)sys->poll(sys->ctx, NULL, 0, (int)ms);
    }
}

static mfns_cam_err_t capture(mfns_cam_t *h, mfns_cam_frame_t *f, int64_t deadline_ns);

/* One reopen attempt per call: bounded work per dequeue, and a caller's loop
 * paced by its own timeout while the device is absent. */
static mfns_cam_err_t recover(mfns_cam_t *h, mfns_cam_frame_t *f, int64_t deadline_ns)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    const uint32_t held = held_count(v);
    if (held > 0) {
        return mfns_cam_fail(h, MFNS_CAM_E_LOST, "%s lost: requeue the %u held frame(s) to let recovery start",
                             h->path, held);
    }
    if (v->attempts_left == 0) {
        v->failed = true;
        h->events |= MFNS_CAM_EV_RECOVERY_FAILED;
        return mfns_cam_fail(h, MFNS_CAM_E_NO_DEVICE, "%s lost; no reopen attempts %s", h->path,
                             h->s.recover_attempts ? "left" : "configured");
    }
    v->attempts_left--;
    h->stats.reopen_attempts++;
    mfns_cam_err_t e = mfns_cam_v4l2_configure(h);
    if (e == MFNS_CAM_OK) {
        e = stream_on(h);
    }
    if (e == MFNS_CAM_OK) {
        v->lost = false;
        h->stats.recoveries++;
        h->events |= MFNS_CAM_EV_RECOVERED;
        h->generation++;
        mfns_cam_seq_reset(h);
        return capture(h, f, deadline_ns);
    }
    char why[MFNS_CAM_MSG_LEN];
    (void)snprintf(why, sizeof why, "%s", h->msg);
    mfns_cam_v4l2_teardown(h);
    const uint32_t attempt = h->s.recover_attempts - v->attempts_left;
    if (v->attempts_left == 0) {
        v->failed = true;
        h->events |= MFNS_CAM_EV_RECOVERY_FAILED;
        return mfns_cam_fail(h, MFNS_CAM_E_NO_DEVICE, "%s lost; reopen attempt %u/%u failed, giving up: %.120s",
                             h->path, attempt, h->s.recover_attempts, why);
    }
    wait_ms(h, (deadline_ns - mfns_cam_now_ns()) / 1000000);
    return mfns_cam_fail(h, MFNS_CAM_E_LOST, "%s lost; reopen attempt %u/%u failed: %.120s", h->path, attempt,
                         h->s.recover_attempts, why);
}

/* ---- capture -------------------------------------------------------------- */
/* What the buffer's timestamp is (flags of VIDIOC_DQBUF): only a
 * CLOCK_MONOTONIC capture stamp can be compared with the arrival time. */
static mfns_cam_ts_source_t ts_source(uint32_t flags)
{
    switch (flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) {
    case V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC:
        return (flags & V4L2_BUF_FLAG_TSTAMP_SRC_MASK) == V4L2_BUF_FLAG_TSTAMP_SRC_SOE ? MFNS_CAM_TS_MONOTONIC_SOE
                                                                                        : MFNS_CAM_TS_MONOTONIC_EOF;
    case V4L2_BUF_FLAG_TIMESTAMP_COPY: return MFNS_CAM_TS_COPY;
    default: return MFNS_CAM_TS_UNKNOWN;
    }
}

static mfns_cam_err_t capture(mfns_cam_t *h, mfns_cam_frame_t *f, int64_t deadline_ns)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    const mfns_cam_sys_t *sys = mfns_cam_v4l2_sys(h);
    if (held_count(v) >= v->nbuf) {
        return mfns_cam_fail(h, MFNS_CAM_E_BUSY, "all %u buffers are held by the caller", v->nbuf);
    }
    /* The arrival is known only for a frame that came while we waited for it:
     * one already queued when we asked arrived at some unknown earlier time
     * (the program was behind), and its dequeue time says nothing. */
    bool waited = false;
    for (int tries = 0; tries < MFNS_CAM_V4L2_MAX_DQ_TRIES; tries++) {
        struct v4l2_buffer b;
        struct v4l2_plane planes[VIDEO_MAX_PLANES];
        mfns_cam_v4l2_buffer_init(v, &b, planes, 0u, VIDEO_MAX_PLANES);
        if (mfns_cam_v4l2_xioctl(h, VIDIOC_DQBUF, &b) == 0) {
            const uint32_t i = b.index;
            if (i >= v->nbuf || !v->buf[i].start || v->buf[i].held) {
                return mfns_cam_fail(h, MFNS_CAM_E_IO, "VIDIOC_DQBUF returned buffer %u (not queued)", i);
            }
            if (v->dq_count == 1u && b.sequence == 0u && !v->own_seq) {
                /* the stream's second frame numbered 0 again: a driver that does not number its
                 * frames; they are counted here (a frame the driver drops is then not seen as a
                 * gap but as a late stamp, and a frozen number cannot happen) */
                v->own_seq = true;
                h->stats.own_seq_streams++;
            }
            if (v->own_seq) {
                b.sequence = v->dq_count;
            }
            v->dq_count++; /* errored frames too: the sequence bookkeeping below sees one numbering */
            uint32_t off = 0, used = b.bytesused;
            if (mfns_cam_v4l2_is_mplane(v)) {
                off = planes[0].data_offset;
                used = planes[0].bytesused >= off ? planes[0].bytesused - off : 0;
            }
            const bool bad = (b.flags & V4L2_BUF_FLAG_ERROR) || used < v->min_bytes || (size_t)off + used > v->buf[i].length;
            if (bad) {
                /* Damaged frame: back to the driver at once, never to the caller. */
                mfns_cam_seq_errored(h, b.sequence);
                const mfns_cam_err_t e = queue_buffer(h, i);
                if (e == MFNS_CAM_E_LOST) {
                    mark_lost(h);
                    return recover(h, f, deadline_ns);
                }
                if (e != MFNS_CAM_OK) {
                    return e;
                }
                continue;
            }
            v->buf[i].held = true;
            f->data = (const uint8_t *)v->buf[i].start + off;
            f->bytesused = used;
            f->pixfmt = h->info.pixfmt;
            f->width = h->info.width;
            f->height = h->info.height;
            f->stride = h->info.stride;
            f->timestamp_ns = (uint64_t)b.timestamp.tv_sec * 1000000000u + (uint64_t)b.timestamp.tv_usec * 1000u;
            f->sequence = b.sequence;
            f->dropped_before = mfns_cam_seq_delivered(h, b.sequence);
            f->ts_source = ts_source(b.flags);
            const int64_t now = waited ? sys->now_ns(sys->ctx) : 0;
            f->arrival_ns = now > 0 ? (uint64_t)now : 0u;
            f->exposure_us = v->exposure_us;
            f->gain_db = NAN; /* V4L2's gain control has the device's own units */
            f->buf_index = i;
            return MFNS_CAM_OK;
        }
        const int err = errno;
        if (err == ENODEV || err == ENXIO) {
            mark_lost(h);
            return recover(h, f, deadline_ns);
        }
        if (err == EIO) {
            h->stats.error_frames++; /* transient per the V4L2 spec (e.g. signal loss): try again */
            continue;
        }
        if (err != EAGAIN) {
            return mfns_cam_fail(h, MFNS_CAM_E_IO, "VIDIOC_DQBUF failed: %s", strerror(err));
        }
        const int64_t left_ms = (deadline_ns - mfns_cam_now_ns()) / 1000000;
        if (left_ms <= 0) {
            return mfns_cam_fail(h, MFNS_CAM_E_TIMEOUT, "no frame from %s in time", h->path);
        }
        struct pollfd pfd = {v->fd, POLLIN, 0};
        const int r = sys->poll(sys->ctx, &pfd, 1, (int)left_ms);
        if (r < 0) {
            if (errno == EINTR) {
                h->stats.eintr_retries++;
                continue;
            }
            return mfns_cam_fail(h, MFNS_CAM_E_IO, "poll failed: %s", strerror(errno));
        }
        if (r == 0) {
            return mfns_cam_fail(h, MFNS_CAM_E_TIMEOUT, "no frame from %s within %lld ms", h->path,
                                 (long long)left_ms);
        }
        /* POLLIN, or POLLERR/POLLHUP: the next DQBUF says which (ENODEV -> lost). */
        waited = true;
    }
    return mfns_cam_fail(h, MFNS_CAM_E_IO, "no good frame from %s in %d attempts (%llu damaged so far)", h->path,
                         MFNS_CAM_V4L2_MAX_DQ_TRIES, (unsigned long long)h->stats.error_frames);
}

/* ---- backend operations ----------------------------------------------------- */
static mfns_cam_err_t v4l2_open(mfns_cam_t *h)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    v->fd = -1;
    v->exposure_us = -1;
    v->gain = -1;
    const mfns_cam_err_t e = mfns_cam_v4l2_configure(h);
    if (e == MFNS_CAM_E_LOST) {
        return mfns_cam_fail(h, MFNS_CAM_E_OPEN, "%s vanished while opening: %.150s", h->path, h->msg);
    }
    return e;
}

static mfns_cam_err_t v4l2_start(mfns_cam_t *h)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    if (v->fd < 0) { /* lost earlier: one fresh attempt */
        mfns_cam_err_t e = mfns_cam_v4l2_configure(h);
        if (e != MFNS_CAM_OK) {
            mfns_cam_v4l2_teardown(h);
            return e == MFNS_CAM_E_LOST ? MFNS_CAM_E_NO_DEVICE : e;
        }
        v->lost = false;
        v->failed = false;
    }
    const mfns_cam_err_t e = stream_on(h);
    if (e == MFNS_CAM_E_LOST) {
        mark_lost(h);
        return MFNS_CAM_E_LOST;
    }
    return e;
}

static mfns_cam_err_t v4l2_dequeue(mfns_cam_t *h, mfns_cam_frame_t *f, int timeout_ms)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    const int64_t deadline = mfns_cam_now_ns() + (int64_t)timeout_ms * 1000000;
    if (v->failed) {
        return mfns_cam_fail(h, MFNS_CAM_E_NO_DEVICE, "%s lost and recovery exhausted; reopen the handle", h->path);
    }
    if (v->lost) {
        return recover(h, f, deadline);
    }
    return capture(h, f, deadline);
}

static mfns_cam_err_t v4l2_requeue(mfns_cam_t *h, const mfns_cam_frame_t *f)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    const uint32_t i = f->buf_index;
    if (!v->buf[i].held) {
        return mfns_cam_fail(h, MFNS_CAM_E_ARG, "requeue: buffer %u is not held by the caller", i);
    }
    v->buf[i].held = false;
    if (v->lost || v->failed) {
        const mfns_cam_sys_t *sys = mfns_cam_v4l2_sys(h);
        if (v->buf[i].start) {
            (void)sys->munmap(sys->ctx, v->buf[i].start, v->buf[i].length);
            v->buf[i].start = NULL;
            v->buf[i].length = 0;
        }
        return MFNS_CAM_OK;
    }
    const mfns_cam_err_t e = queue_buffer(h, i);
    if (e == MFNS_CAM_E_LOST) {
        mark_lost(h);
    }
    return e;
}

static mfns_cam_err_t v4l2_stop(mfns_cam_t *h)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    mfns_cam_v4l2_clear_held(v); /* STREAMOFF takes every buffer back */
    if (v->fd < 0) {
        mfns_cam_v4l2_unmap_all(h, false);
        return MFNS_CAM_OK;
    }
    int type = (int)v->buf_type;
    if (mfns_cam_v4l2_xioctl(h, VIDIOC_STREAMOFF, &type) != 0) {
        if (errno == ENODEV) {
            mark_lost(h);
            return MFNS_CAM_OK; /* stopped anyway */
        }
        return mfns_cam_fail(h, MFNS_CAM_E_STREAM, "VIDIOC_STREAMOFF failed: %s", strerror(errno));
    }
    return MFNS_CAM_OK;
}

static void v4l2_close(mfns_cam_t *h)
{
    mfns_cam_v4l2_teardown(h);
}

static mfns_cam_err_t v4l2_set_controls(mfns_cam_t *h, int32_t exposure_us, int32_t gain)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    if (v->fd < 0) {
        return mfns_cam_fail(h, v->failed ? MFNS_CAM_E_NO_DEVICE : MFNS_CAM_E_LOST, "set_controls: %s is lost",
                             h->path);
    }
    const mfns_cam_err_t e = mfns_cam_v4l2_apply_controls(h, exposure_us, gain);
    if (e == MFNS_CAM_OK) {
        /* remembered so a recovery restores them */
        if (exposure_us >= 0) {
            h->s.exposure_us = exposure_us;
        }
        if (gain >= 0) {
            h->s.gain = gain;
        }
    }
    return e;
}

const mfns_cam_backend_ops_t mfns_cam_v4l2_ops = {v4l2_open,  v4l2_start, v4l2_dequeue,     v4l2_requeue,
                                                  v4l2_stop, v4l2_close, v4l2_set_controls};
