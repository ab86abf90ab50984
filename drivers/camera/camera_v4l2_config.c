/* camera_v4l2_config.c -- configuring a V4L2 device (camera_v4l2_internal.h):
 * open, capabilities, format negotiation, frame rate and exposure/gain
 * controls, buffer request and mmap; and the teardown that undoes any part
 * of it. Runs at open and at every recovery. */
#ifndef _DEFAULT_SOURCE
#define _DEFAULT_SOURCE 1
#endif
#include "drivers/camera/camera_v4l2.h"

#include <errno.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <stdio.h>
#include <string.h>
#include <sys/mman.h>

#include "drivers/camera/camera_backend.h"
#include "drivers/camera/camera_v4l2_internal.h"

/* ---- pixel formats ------------------------------------------------------- */
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

/* ---- buffers and fd: release ------------------------------------------ */
void mfns_cam_v4l2_clear_held(mfns_cam_v4l2_t *v)
{
    for (uint32_t i = 0; i < MFNS_CAM_MAX_BUFFERS; i++) {
        v->buf[i].held = false;
    }
}

void mfns_cam_v4l2_unmap_all(mfns_cam_t *h, bool keep_held)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    const mfns_cam_sys_t *sys = mfns_cam_v4l2_sys(h);
    for (uint32_t i = 0; i < MFNS_CAM_MAX_BUFFERS; i++) {
        if (v->buf[i].start && !(keep_held && v->buf[i].held)) {
            (void)sys->munmap(sys->ctx, v->buf[i].start, v->buf[i].length);
            v->buf[i].start = NULL;
            v->buf[i].length = 0;
        }
    }
}

void mfns_cam_v4l2_close_fd(mfns_cam_t *h)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    if (v->fd >= 0) {
        const mfns_cam_sys_t *sys = mfns_cam_v4l2_sys(h);
        (void)sys->close(sys->ctx, v->fd);
        v->fd = -1;
    }
}

/* Undoes a partial or full configure: mappings, driver buffers, fd. */
void mfns_cam_v4l2_teardown(mfns_cam_t *h)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    mfns_cam_v4l2_unmap_all(h, false);
    if (v->fd >= 0 && v->nbuf > 0) {
        struct v4l2_requestbuffers rb;
        memset(&rb, 0, sizeof rb);
        rb.count = 0;
        rb.type = v->buf_type;
        rb.memory = V4L2_MEMORY_MMAP;
        (void)mfns_cam_v4l2_xioctl(h, VIDIOC_REQBUFS, &rb); /* frees the driver's buffers; best effort */
    }
    v->nbuf = 0;
    mfns_cam_v4l2_clear_held(v);
    mfns_cam_v4l2_close_fd(h);
}

/* ---- controls ------------------------------------------------------------ */
static mfns_cam_err_t set_ctrl(mfns_cam_t *h, uint32_t id, const char *name, int32_t value)
{
    struct v4l2_queryctrl q;
    memset(&q, 0, sizeof q);
    q.id = id;
    if (mfns_cam_v4l2_xioctl(h, VIDIOC_QUERYCTRL, &q) != 0) {
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
    if (mfns_cam_v4l2_xioctl(h, VIDIOC_S_CTRL, &c) != 0) {
        return mfns_cam_fail(h, errno == ENODEV ? MFNS_CAM_E_LOST : MFNS_CAM_E_CONTROL,
                             "%s: VIDIOC_S_CTRL(%d) failed: %s", name, (int)value, strerror(errno));
    }
    return MFNS_CAM_OK;
}

mfns_cam_err_t mfns_cam_v4l2_apply_controls(mfns_cam_t *h, int32_t exposure_us, int32_t gain)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    if (exposure_us >= 0) {
        /* Manual mode first where the device has auto exposure; a device
         * without the auto control is manual already. */
        struct v4l2_queryctrl q;
        memset(&q, 0, sizeof q);
        q.id = V4L2_CID_EXPOSURE_AUTO;
        if (mfns_cam_v4l2_xioctl(h, VIDIOC_QUERYCTRL, &q) == 0 && !(q.flags & V4L2_CTRL_FLAG_DISABLED)) {
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
    if (mfns_cam_v4l2_xioctl(h, VIDIOC_G_PARM, &p) != 0 || !(p.parm.capture.capability & V4L2_CAP_TIMEPERFRAME)) {
        return mfns_cam_fail(h, MFNS_CAM_E_CONTROL, "frame rate: %s cannot set its frame interval", h->path);
    }
    p.parm.capture.timeperframe.numerator = 1000;
    p.parm.capture.timeperframe.denominator = (uint32_t)(hz * 1000.0f + 0.5f);
    if (mfns_cam_v4l2_xioctl(h, VIDIOC_S_PARM, &p) != 0) {
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
    if (mfns_cam_v4l2_xioctl(h, VIDIOC_G_FMT, &fmt) != 0) {
        return mfns_cam_fail(h, MFNS_CAM_E_FORMAT, "VIDIOC_G_FMT failed: %s", strerror(errno));
    }
    const bool mp = mfns_cam_v4l2_is_mplane(v);
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
    if (mfns_cam_v4l2_xioctl(h, VIDIOC_S_FMT, &fmt) != 0) {
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
    const mfns_cam_sys_t *sys = mfns_cam_v4l2_sys(h);
    struct v4l2_requestbuffers rb;
    memset(&rb, 0, sizeof rb);
    rb.count = h->s.buffer_count;
    rb.type = v->buf_type;
    rb.memory = V4L2_MEMORY_MMAP;
    if (mfns_cam_v4l2_xioctl(h, VIDIOC_REQBUFS, &rb) != 0) {
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
        mfns_cam_v4l2_buffer_init(v, &b, planes, i, VIDEO_MAX_PLANES);
        if (mfns_cam_v4l2_xioctl(h, VIDIOC_QUERYBUF, &b) != 0) {
            return mfns_cam_fail(h, errno == ENODEV ? MFNS_CAM_E_LOST : MFNS_CAM_E_BUFFERS,
                                 "VIDIOC_QUERYBUF(%u) failed: %s", i, strerror(errno));
        }
        const size_t len = mfns_cam_v4l2_is_mplane(v) ? planes[0].length : b.length;
        const off_t off = (off_t)(mfns_cam_v4l2_is_mplane(v) ? planes[0].m.mem_offset : b.m.offset);
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

mfns_cam_err_t mfns_cam_v4l2_configure(mfns_cam_t *h)
{
    mfns_cam_v4l2_t *v = &h->b.v4l2;
    const mfns_cam_sys_t *sys = mfns_cam_v4l2_sys(h);
    v->fd = sys->open(sys->ctx, h->path, O_RDWR | O_NONBLOCK | O_CLOEXEC);
    if (v->fd < 0) {
        v->fd = -1;
        return mfns_cam_fail(h, MFNS_CAM_E_OPEN, "open %s: %s", h->path, strerror(errno));
    }
    struct v4l2_capability cap;
    memset(&cap, 0, sizeof cap);
    if (mfns_cam_v4l2_xioctl(h, VIDIOC_QUERYCAP, &cap) != 0) {
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
    h->info.multiplanar = mfns_cam_v4l2_is_mplane(v);
    mfns_cam_err_t e = setup_format(h);
    if (e == MFNS_CAM_OK && h->s.frame_rate_hz > 0.0f) {
        e = set_rate(h, h->s.frame_rate_hz);
    }
    if (e == MFNS_CAM_OK) {
        e = mfns_cam_v4l2_apply_controls(h, h->s.exposure_us, h->s.gain);
    }
    if (e == MFNS_CAM_OK && h->s.exposure_us < 0) {
        /* not set by us: report the device's own value where it has one */
        struct v4l2_control c;
        memset(&c, 0, sizeof c);
        c.id = V4L2_CID_EXPOSURE_ABSOLUTE;
        v->exposure_us = mfns_cam_v4l2_xioctl(h, VIDIOC_G_CTRL, &c) == 0 && c.value >= 0 && c.value <= INT32_MAX / MFNS_CAM_V4L2_EXPOSURE_UNIT_US
                             ? c.value * MFNS_CAM_V4L2_EXPOSURE_UNIT_US
                             : -1;
    }
    if (e == MFNS_CAM_OK) {
        e = setup_buffers(h);
    }
    return e;
}
