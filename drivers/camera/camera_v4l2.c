/* camera_v4l2.c -- V4L2 capture backend: single- or multi-planar devices,
 * memory-mapped streaming, GREY/Y10/Y12/Y16, exposure/gain/frame-rate
 * controls, and recovery from a device that vanishes (ENODEV) and returns.
 *
 * Discipline follows the kernel's capture example (Documentation/userspace-api/
 * media/v4l/capture.c): every ioctl retried on EINTR, a non-blocking fd with
 * EAGAIN answered by poll() with a timeout, every dequeued buffer requeued
 * (error-flagged ones immediately), and the payload size taken from bytesused.
 * All syscalls go through the mfns_cam_sys_t seam (camera_v4l2.h). */
#ifndef _DEFAULT_SOURCE
#define _DEFAULT_SOURCE 1
#endif
#include "camera_v4l2.h"

#include <errno.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <stdio.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include "camera_backend.h"

/* ---- the real syscalls ------------------------------------------------- */
static int sys_open(void *ctx, const char *path, int flags)
{
    (void)ctx;
    return open(path, flags);
}
static int sys_close(void *ctx, int fd)
{
    (void)ctx;
    return close(fd);
}
static int sys_ioctl(void *ctx, int fd, unsigned long request, void *arg)
{
    (void)ctx;
    return ioctl(fd, request, arg);
}
static void *sys_mmap(void *ctx, size_t length, int prot, int flags, int fd, off_t offset)
{
    (void)ctx;
    return mmap(NULL, length, prot, flags, fd, offset);
}
static int sys_munmap(void *ctx, void *addr, size_t length)
{
    (void)ctx;
    return munmap(addr, length);
}
static int sys_poll(void *ctx, struct pollfd *fds, nfds_t nfds, int timeout_ms)
{
    (void)ctx;
    return poll(fds, nfds, timeout_ms);
}

const mfns_cam_sys_t mfns_cam_sys_linux = {NULL, sys_open, sys_close, sys_ioctl, sys_mmap, sys_munmap, sys_poll};

static const mfns_cam_sys_t *sys_of(const mfns_cam_t *h)
{
    return h->s.sys ? h->s.sys : &mfns_cam_sys_linux;
}

/* ---- helpers ------------------------------------------------------------ */
static int xioctl(mfns_cam_t *h, unsigned long request, void *arg)
{
    const mfns_cam_sys_t *sys = sys_of(h);
    for (int i = 0; i <= MFNS_CAM_V4L2_MAX_EINTR; i++) {
        const int r = sys->ioctl(sys->ctx, h->b.v4l2.fd, request, arg);
        if (r != -1 || errno != EINTR) {
            return r;
        }
        h->stats.eintr_retries++;
    }
    errno = EINTR;
    return -1;
}

static uint32_t to_fourcc(mfns_cam_pixfmt_t f)
{
    switch (f) {
    case MFNS_CAM_PIX_GREY: return V4L2_PIX_FMT_GREY;
    case MFNS_CAM_PIX_Y10: return V4L2_PIX_FMT_Y10;
    case MFNS_CAM_PIX_Y12: return V4L2_PIX_FMT_Y12;
    case MFNS_CAM_PIX_Y16: return V4L2_PIX_FMT_Y16;
    case MFNS_CAM_PIX_ANY:
    case MFNS_CAM_PIX_COUNT_: break;
    }
    return 0;
}

static mfns_cam_pixfmt_t from_fourcc(uint32_t fcc)
{
    switch (fcc) {
    case V4L2_PIX_FMT_GREY: return MFNS_CAM_PIX_GREY;
    case V4L2_PIX_FMT_Y10: return MFNS_CAM_PIX_Y10;
    case V4L2_PIX_FMT_Y12: return MFNS_CAM_PIX_Y12;
    case V4L2_PIX_FMT_Y16: return MFNS_CAM_PIX_Y16;
    default: break;
    }
    return MFNS_CAM_PIX_ANY;
}

/* Printable fourcc for messages ("GREY", "YUYV"). */
static void fourcc_str(uint32_t fcc, char out[5])
{
    for (int i = 0; i < 4; i++) {
        const char c = (char)((fcc >> (8 * i)) & 0xffu);
        out[i] = (c >= 32 && c < 127) ? c : '?';
    }
    out[4] = '\0';
}

static bool is_mplane(const mfns_cam_v4l2_t *v)
{
    return v->buf_type == V4L2_BUF_TYPE_VIDEO_CAPTURE_MPLANE;
}

static void clear_held(mfns_cam_v4l2_t *v)
{
    for (uint32_t i = 0; i < MFNS_CAM_MAX_BUFFERS; i++) {
        v->buf[i].held = false;
    }
}

static void unmap_all(mfns_cam_t *h, bool keep_held)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    const mfns_cam_sys_t *sys = sys_of(h);
    for (uint32_t i = 0; i < MFNS_CAM_MAX_BUFFERS; i++) {
        if (v->buf[i].start && !(keep_held && v->buf[i].held)) {
            (void)sys->munmap(sys->ctx, v->buf[i].start, v->buf[i].length);
            v->buf[i].start = NULL;
            v->buf[i].length = 0;
        }
    }
}

static void close_fd(mfns_cam_t *h)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    if (v->fd >= 0) {
        const mfns_cam_sys_t *sys = sys_of(h);
        (void)sys->close(sys->ctx, v->fd);
        v->fd = -1;
    }
}

/* Undoes a partial or full configure: mappings, driver buffers, fd. */
static void teardown(mfns_cam_t *h)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    unmap_all(h, false);
    if (v->fd >= 0 && v->nbuf > 0) {
        struct v4l2_requestbuffers rb;
        memset(&rb, 0, sizeof rb);
        rb.count = 0;
        rb.type = v->buf_type;
        rb.memory = V4L2_MEMORY_MMAP;
        (void)xioctl(h, VIDIOC_REQBUFS, &rb); /* frees the driver's buffers; best effort */
    }
    v->nbuf = 0;
    clear_held(v);
    close_fd(h);
}

/* ---- controls ------------------------------------------------------------ */
static mfns_cam_err_t set_ctrl(mfns_cam_t *h, uint32_t id, const char *name, int32_t value)
{
    struct v4l2_queryctrl q;
    memset(&q, 0, sizeof q);
    q.id = id;
    if (xioctl(h, VIDIOC_QUERYCTRL, &q) != 0) {
        if (errno == EINVAL) {
            return mfns_cam_fail(h, MFNS_CAM_E_CONTROL, "%s: device %s has no %s control (CID 0x%08x)",
                                 name, h->path, name, id);
        }
        return mfns_cam_fail(h, errno == ENODEV ? MFNS_CAM_E_LOST : MFNS_CAM_E_IO,
                             "%s: VIDIOC_QUERYCTRL failed: %s", name, strerror(errno));
    }
    if (q.flags & (V4L2_CTRL_FLAG_DISABLED | V4L2_CTRL_FLAG_READ_ONLY)) {
        return mfns_cam_fail(h, MFNS_CAM_E_CONTROL, "%s: control on %s is %s", name, h->path,
                             (q.flags & V4L2_CTRL_FLAG_DISABLED) ? "disabled" : "read-only");
    }
    if (value < q.minimum || value > q.maximum) {
        return mfns_cam_fail(h, MFNS_CAM_E_CONTROL, "%s: value %d outside device range [%d, %d]", name,
                             (int)value, (int)q.minimum, (int)q.maximum);
    }
    struct v4l2_control c;
    memset(&c, 0, sizeof c);
    c.id = id;
    c.value = value;
    if (xioctl(h, VIDIOC_S_CTRL, &c) != 0) {
        return mfns_cam_fail(h, errno == ENODEV ? MFNS_CAM_E_LOST : MFNS_CAM_E_CONTROL,
                             "%s: VIDIOC_S_CTRL(%d) failed: %s", name, (int)value, strerror(errno));
    }
    return MFNS_CAM_OK;
}

static mfns_cam_err_t apply_controls(mfns_cam_t *h, int32_t exposure_us, int32_t gain)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    if (exposure_us >= 0) {
        /* Manual mode first where the device has auto exposure; a device
         * without the auto control is manual already. */
        struct v4l2_queryctrl q;
        memset(&q, 0, sizeof q);
        q.id = V4L2_CID_EXPOSURE_AUTO;
        if (xioctl(h, VIDIOC_QUERYCTRL, &q) == 0 && !(q.flags & V4L2_CTRL_FLAG_DISABLED)) {
            const mfns_cam_err_t e = set_ctrl(h, V4L2_CID_EXPOSURE_AUTO, "exposure_auto", V4L2_EXPOSURE_MANUAL);
            if (e != MFNS_CAM_OK) {
                return e;
            }
        }
        const int32_t units = (exposure_us + MFNS_CAM_V4L2_EXPOSURE_UNIT_US / 2) / MFNS_CAM_V4L2_EXPOSURE_UNIT_US;
        const mfns_cam_err_t e = set_ctrl(h, V4L2_CID_EXPOSURE_ABSOLUTE, "exposure", units);
        if (e != MFNS_CAM_OK) {
            return e;
        }
        v->exposure_us = units * MFNS_CAM_V4L2_EXPOSURE_UNIT_US;
    }
    if (gain >= 0) {
        const mfns_cam_err_t e = set_ctrl(h, V4L2_CID_GAIN, "gain", gain);
        if (e != MFNS_CAM_OK) {
            return e;
        }
        v->gain = gain;
    }
    return MFNS_CAM_OK;
}

static mfns_cam_err_t set_rate(mfns_cam_t *h, float hz)
{
    struct v4l2_streamparm p;
    memset(&p, 0, sizeof p);
    p.type = h->b.v4l2.buf_type;
    if (xioctl(h, VIDIOC_G_PARM, &p) != 0 || !(p.parm.capture.capability & V4L2_CAP_TIMEPERFRAME)) {
        return mfns_cam_fail(h, MFNS_CAM_E_CONTROL, "frame rate: %s cannot set its frame interval", h->path);
    }
    p.parm.capture.timeperframe.numerator = 1000;
    p.parm.capture.timeperframe.denominator = (uint32_t)(hz * 1000.0f + 0.5f);
    if (xioctl(h, VIDIOC_S_PARM, &p) != 0) {
        return mfns_cam_fail(h, MFNS_CAM_E_CONTROL, "frame rate: VIDIOC_S_PARM failed: %s", strerror(errno));
    }
    const struct v4l2_fract t = p.parm.capture.timeperframe;
    const float got = t.numerator ? (float)t.denominator / (float)t.numerator : 0.0f;
    if (got < hz * 0.99f || got > hz * 1.01f) {
        return mfns_cam_fail(h, MFNS_CAM_E_CONTROL, "frame rate: asked %.3f Hz, device gives %.3f Hz", (double)hz,
                             (double)got);
    }
    return MFNS_CAM_OK;
}

/* ---- configure: open .. mmap (open and every recovery) --------------------- */
static mfns_cam_err_t setup_format(mfns_cam_t *h)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    struct v4l2_format fmt;
    memset(&fmt, 0, sizeof fmt);
    fmt.type = v->buf_type;
    if (xioctl(h, VIDIOC_G_FMT, &fmt) != 0) {
        return mfns_cam_fail(h, MFNS_CAM_E_FORMAT, "VIDIOC_G_FMT failed: %s", strerror(errno));
    }
    const bool mp = is_mplane(v);
    const uint32_t cur_w = mp ? fmt.fmt.pix_mp.width : fmt.fmt.pix.width;
    const uint32_t cur_h = mp ? fmt.fmt.pix_mp.height : fmt.fmt.pix.height;
    const uint32_t cur_fcc = mp ? fmt.fmt.pix_mp.pixelformat : fmt.fmt.pix.pixelformat;
    const uint32_t want_w = h->s.width ? h->s.width : cur_w;
    const uint32_t want_h = h->s.height ? h->s.height : cur_h;
    const uint32_t want_fcc = h->s.pixfmt != MFNS_CAM_PIX_ANY ? to_fourcc(h->s.pixfmt) : cur_fcc;
    char name[5];
    if (from_fourcc(want_fcc) == MFNS_CAM_PIX_ANY) {
        fourcc_str(want_fcc, name);
        return mfns_cam_fail(h, MFNS_CAM_E_FORMAT, "%s: current format %s is not GREY/Y10/Y12/Y16", h->path, name);
    }
    memset(&fmt, 0, sizeof fmt);
    fmt.type = v->buf_type;
    if (mp) {
        fmt.fmt.pix_mp.width = want_w;
        fmt.fmt.pix_mp.height = want_h;
        fmt.fmt.pix_mp.pixelformat = want_fcc;
        fmt.fmt.pix_mp.field = V4L2_FIELD_NONE;
        fmt.fmt.pix_mp.num_planes = 1;
    } else {
        fmt.fmt.pix.width = want_w;
        fmt.fmt.pix.height = want_h;
        fmt.fmt.pix.pixelformat = want_fcc;
        fmt.fmt.pix.field = V4L2_FIELD_NONE;
    }
    if (xioctl(h, VIDIOC_S_FMT, &fmt) != 0) {
        return mfns_cam_fail(h, errno == ENODEV ? MFNS_CAM_E_LOST : MFNS_CAM_E_FORMAT, "VIDIOC_S_FMT failed: %s",
                             strerror(errno));
    }
    /* Drivers adjust S_FMT to what they can do instead of failing: compare. */
    const uint32_t w = mp ? fmt.fmt.pix_mp.width : fmt.fmt.pix.width;
    const uint32_t hh = mp ? fmt.fmt.pix_mp.height : fmt.fmt.pix.height;
    const uint32_t fcc = mp ? fmt.fmt.pix_mp.pixelformat : fmt.fmt.pix.pixelformat;
    if (fcc != want_fcc || w != want_w || hh != want_h) {
        char got[5];
        fourcc_str(want_fcc, name);
        fourcc_str(fcc, got);
        return mfns_cam_fail(h, MFNS_CAM_E_FORMAT, "%s: asked %s %ux%u, device offers %s %ux%u", h->path, name,
                             want_w, want_h, got, w, hh);
    }
    if (mp && fmt.fmt.pix_mp.num_planes != 1) {
        return mfns_cam_fail(h, MFNS_CAM_E_FORMAT, "%s: %u planes for a mono format, expected 1", h->path,
                             (unsigned)fmt.fmt.pix_mp.num_planes);
    }
    if (w == 0 || hh == 0 || w > MFNS_CAM_MAX_DIM || hh > MFNS_CAM_MAX_DIM) {
        return mfns_cam_fail(h, MFNS_CAM_E_FORMAT, "%s: size %ux%u outside 1..%u", h->path, w, hh, MFNS_CAM_MAX_DIM);
    }
    const mfns_cam_pixfmt_t pf = from_fourcc(fcc);
    const uint32_t bpp = mfns_cam_pixfmt_bytes(pf);
    uint32_t stride = mp ? fmt.fmt.pix_mp.plane_fmt[0].bytesperline : fmt.fmt.pix.bytesperline;
    if (stride == 0) {
        stride = w * bpp;
    }
    if (stride < w * bpp) {
        return mfns_cam_fail(h, MFNS_CAM_E_FORMAT, "%s: bytesperline %u below width %u x %u bytes", h->path,
                             stride, w, bpp);
    }
    v->fourcc = fcc;
    v->min_bytes = stride * (hh - 1u) + w * bpp;
    h->info.width = w;
    h->info.height = hh;
    h->info.stride = stride;
    h->info.pixfmt = pf;
    return MFNS_CAM_OK;
}

static mfns_cam_err_t setup_buffers(mfns_cam_t *h)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    const mfns_cam_sys_t *sys = sys_of(h);
    struct v4l2_requestbuffers rb;
    memset(&rb, 0, sizeof rb);
    rb.count = h->s.buffer_count;
    rb.type = v->buf_type;
    rb.memory = V4L2_MEMORY_MMAP;
    if (xioctl(h, VIDIOC_REQBUFS, &rb) != 0) {
        return mfns_cam_fail(h, errno == ENODEV ? MFNS_CAM_E_LOST : MFNS_CAM_E_BUFFERS,
                             "VIDIOC_REQBUFS(%u, mmap) failed: %s", h->s.buffer_count, strerror(errno));
    }
    v->nbuf = rb.count < MFNS_CAM_MAX_BUFFERS ? rb.count : MFNS_CAM_MAX_BUFFERS;
    if (rb.count < MFNS_CAM_MIN_BUFFERS || rb.count > MFNS_CAM_MAX_BUFFERS) {
        return mfns_cam_fail(h, MFNS_CAM_E_BUFFERS, "%s: driver granted %u buffers (asked %u, need %u..%u)",
                             h->path, rb.count, h->s.buffer_count, MFNS_CAM_MIN_BUFFERS, MFNS_CAM_MAX_BUFFERS);
    }
    for (uint32_t i = 0; i < v->nbuf; i++) {
        struct v4l2_buffer b;
        struct v4l2_plane planes[VIDEO_MAX_PLANES];
        memset(&b, 0, sizeof b);
        memset(planes, 0, sizeof planes);
        b.type = v->buf_type;
        b.memory = V4L2_MEMORY_MMAP;
        b.index = i;
        if (is_mplane(v)) {
            b.m.planes = planes;
            b.length = VIDEO_MAX_PLANES;
        }
        if (xioctl(h, VIDIOC_QUERYBUF, &b) != 0) {
            return mfns_cam_fail(h, errno == ENODEV ? MFNS_CAM_E_LOST : MFNS_CAM_E_BUFFERS,
                                 "VIDIOC_QUERYBUF(%u) failed: %s", i, strerror(errno));
        }
        const size_t len = is_mplane(v) ? planes[0].length : b.length;
        const off_t off = (off_t)(is_mplane(v) ? planes[0].m.mem_offset : b.m.offset);
        if (len < v->min_bytes) {
            return mfns_cam_fail(h, MFNS_CAM_E_BUFFERS, "buffer %u is %zu bytes, a frame needs %u", i, len,
                                 v->min_bytes);
        }
        void *p = sys->mmap(sys->ctx, len, PROT_READ | PROT_WRITE, MAP_SHARED, v->fd, off);
        if (p == MAP_FAILED) {
            return mfns_cam_fail(h, MFNS_CAM_E_MMAP, "mmap of buffer %u (%zu bytes) failed: %s", i, len,
                                 strerror(errno));
        }
        v->buf[i].start = p;
        v->buf[i].length = len;
    }
    h->info.buffer_count = v->nbuf;
    return MFNS_CAM_OK;
}

static mfns_cam_err_t configure(mfns_cam_t *h)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    const mfns_cam_sys_t *sys = sys_of(h);
    v->fd = sys->open(sys->ctx, h->path, O_RDWR | O_NONBLOCK | O_CLOEXEC);
    if (v->fd < 0) {
        v->fd = -1;
        return mfns_cam_fail(h, MFNS_CAM_E_OPEN, "open %s: %s", h->path, strerror(errno));
    }
    struct v4l2_capability cap;
    memset(&cap, 0, sizeof cap);
    if (xioctl(h, VIDIOC_QUERYCAP, &cap) != 0) {
        return mfns_cam_fail(h, errno == ENODEV ? MFNS_CAM_E_LOST : MFNS_CAM_E_NOT_CAPTURE,
                             "%s: VIDIOC_QUERYCAP failed (not a V4L2 device?): %s", h->path, strerror(errno));
    }
    const uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
    if (caps & V4L2_CAP_VIDEO_CAPTURE) {
        v->buf_type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    } else if (caps & V4L2_CAP_VIDEO_CAPTURE_MPLANE) {
        v->buf_type = V4L2_BUF_TYPE_VIDEO_CAPTURE_MPLANE;
    } else {
        return mfns_cam_fail(h, MFNS_CAM_E_NOT_CAPTURE, "%s: not a video capture device (caps 0x%08x)", h->path,
                             caps);
    }
    if (!(caps & V4L2_CAP_STREAMING)) {
        return mfns_cam_fail(h, MFNS_CAM_E_NOT_CAPTURE, "%s: no streaming I/O (caps 0x%08x)", h->path, caps);
    }
    (void)snprintf(h->info.driver, sizeof h->info.driver, "%.31s", (const char *)cap.driver);
    (void)snprintf(h->info.card, sizeof h->info.card, "%.31s", (const char *)cap.card);
    h->info.multiplanar = is_mplane(v);
    mfns_cam_err_t e = setup_format(h);
    if (e == MFNS_CAM_OK && h->s.frame_rate_hz > 0.0f) {
        e = set_rate(h, h->s.frame_rate_hz);
    }
    if (e == MFNS_CAM_OK) {
        e = apply_controls(h, h->s.exposure_us, h->s.gain);
    }
    if (e == MFNS_CAM_OK && h->s.exposure_us < 0) {
        /* not set by us: report the device's own value where it has one */
        struct v4l2_control c;
        memset(&c, 0, sizeof c);
        c.id = V4L2_CID_EXPOSURE_ABSOLUTE;
        v->exposure_us = xioctl(h, VIDIOC_G_CTRL, &c) == 0 && c.value >= 0 && c.value <= INT32_MAX / 100
                             ? c.value * MFNS_CAM_V4L2_EXPOSURE_UNIT_US
                             : -1;
    }
    if (e == MFNS_CAM_OK) {
        e = setup_buffers(h);
    }
    return e;
}

static mfns_cam_err_t queue_buffer(mfns_cam_t *h, uint32_t i)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    struct v4l2_buffer b;
    struct v4l2_plane planes[VIDEO_MAX_PLANES];
    memset(&b, 0, sizeof b);
    memset(planes, 0, sizeof planes);
    b.type = v->buf_type;
    b.memory = V4L2_MEMORY_MMAP;
    b.index = i;
    if (is_mplane(v)) {
        b.m.planes = planes;
        b.length = 1;
    }
    if (xioctl(h, VIDIOC_QBUF, &b) != 0) {
        return mfns_cam_fail(h, errno == ENODEV ? MFNS_CAM_E_LOST : MFNS_CAM_E_IO, "VIDIOC_QBUF(%u) failed: %s", i,
                             strerror(errno));
    }
    return MFNS_CAM_OK;
}

static mfns_cam_err_t stream_on(mfns_cam_t *h)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    clear_held(v);
    for (uint32_t i = 0; i < v->nbuf; i++) {
        const mfns_cam_err_t e = queue_buffer(h, i);
        if (e != MFNS_CAM_OK) {
            return e;
        }
    }
    int type = (int)v->buf_type;
    if (xioctl(h, VIDIOC_STREAMON, &type) != 0) {
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
    unmap_all(h, true);
    v->nbuf = 0;
    close_fd(h);
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
        const mfns_cam_sys_t *sys = sys_of(h);
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
    mfns_cam_err_t e = configure(h);
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
    teardown(h);
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
static mfns_cam_err_t capture(mfns_cam_t *h, mfns_cam_frame_t *f, int64_t deadline_ns)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    const mfns_cam_sys_t *sys = sys_of(h);
    if (held_count(v) >= v->nbuf) {
        return mfns_cam_fail(h, MFNS_CAM_E_BUSY, "all %u buffers are held by the caller", v->nbuf);
    }
    for (int tries = 0; tries < MFNS_CAM_V4L2_MAX_DQ_TRIES; tries++) {
        struct v4l2_buffer b;
        struct v4l2_plane planes[VIDEO_MAX_PLANES];
        memset(&b, 0, sizeof b);
        memset(planes, 0, sizeof planes);
        b.type = v->buf_type;
        b.memory = V4L2_MEMORY_MMAP;
        if (is_mplane(v)) {
            b.m.planes = planes;
            b.length = VIDEO_MAX_PLANES;
        }
        if (xioctl(h, VIDIOC_DQBUF, &b) == 0) {
            const uint32_t i = b.index;
            if (i >= v->nbuf || !v->buf[i].start || v->buf[i].held) {
                return mfns_cam_fail(h, MFNS_CAM_E_IO, "VIDIOC_DQBUF returned buffer %u (not queued)", i);
            }
            uint32_t off = 0, used = b.bytesused;
            if (is_mplane(v)) {
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
            f->exposure_us = v->exposure_us;
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
    const mfns_cam_err_t e = configure(h);
    if (e == MFNS_CAM_E_LOST) {
        return mfns_cam_fail(h, MFNS_CAM_E_OPEN, "%s vanished while opening: %.150s", h->path, h->msg);
    }
    return e;
}

static mfns_cam_err_t v4l2_start(mfns_cam_t *h)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    if (v->fd < 0) { /* lost earlier: one fresh attempt */
        mfns_cam_err_t e = configure(h);
        if (e != MFNS_CAM_OK) {
            teardown(h);
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
        const mfns_cam_sys_t *sys = sys_of(h);
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
    clear_held(v); /* STREAMOFF takes every buffer back */
    if (v->fd < 0) {
        unmap_all(h, false);
        return MFNS_CAM_OK;
    }
    int type = (int)v->buf_type;
    if (xioctl(h, VIDIOC_STREAMOFF, &type) != 0) {
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
    teardown(h);
}

static mfns_cam_err_t v4l2_set_controls(mfns_cam_t *h, int32_t exposure_us, int32_t gain)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    if (v->fd < 0) {
        return mfns_cam_fail(h, v->failed ? MFNS_CAM_E_NO_DEVICE : MFNS_CAM_E_LOST, "set_controls: %s is lost",
                             h->path);
    }
    const mfns_cam_err_t e = apply_controls(h, exposure_us, gain);
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
