/* fakev4l2_dev.c -- simulated V4L2 capture device (see fakev4l2_dev.h). */
#ifndef _DEFAULT_SOURCE
#define _DEFAULT_SOURCE 1
#endif
#include "tests/unit/support/fakev4l2_dev.h"

#include <errno.h>
#include <linux/videodev2.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

#define FAKE_OFFSET_STEP 0x100000u

void fakev4l2_init(fakev4l2_dev_t *d)
{
    memset(d, 0, sizeof *d);
    d->formats[0] = V4L2_PIX_FMT_GREY;
    d->formats[1] = V4L2_PIX_FMT_Y10;
    d->formats[2] = V4L2_PIX_FMT_Y12;
    d->formats[3] = V4L2_PIX_FMT_Y16;
    d->nformats = 4;
    d->max_w = 64;
    d->max_h = 48;
    d->max_buffers = 8;
    d->has_exposure = d->has_exposure_auto = d->has_gain = d->has_timeperframe = true;
    d->exp_min = 1;
    d->exp_max = 10000;
    d->gain_min = 0;
    d->gain_max = 480;
    d->max_fps = 60.0f;
    d->mmap_fail_at = -1;
    d->live_fd = -1;
    d->next_fd = 100;
    d->fourcc = V4L2_PIX_FMT_GREY;
    d->w = 64;
    d->h = 48;
    d->tpf_num = 1;
    d->tpf_den = 30;
    d->exposure_auto = 3; /* aperture priority, like a webcam out of the box */
    d->ts_flags = V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC | V4L2_BUF_FLAG_TSTAMP_SRC_EOF;
    d->arrival_delay_ns = 2000000; /* 2 ms from capture stamp to dequeue */
}

void fakev4l2_free(fakev4l2_dev_t *d)
{
    for (int i = 0; i < d->nallocs; i++) {
        free(d->allocs[i].mem);
        d->allocs[i].mem = NULL;
    }
    d->nallocs = 0;
}

int fakev4l2_count(const fakev4l2_dev_t *d, unsigned long request)
{
    int n = 0;
    for (int i = 0; i < d->ntrace; i++) {
        n += d->trace[i] == request;
    }
    return n;
}

int fakev4l2_find(const fakev4l2_dev_t *d, unsigned long request, int from)
{
    for (int i = from < 0 ? 0 : from; i < d->ntrace; i++) {
        if (d->trace[i] == request) {
            return i;
        }
    }
    return -1;
}

static void drop_device_state(fakev4l2_dev_t *d)
{
    d->streaming = false;
    d->nbuf = 0;
    d->nqueued = 0;
    memset(d->queued, 0, sizeof d->queued);
    d->seq = 0;
}

void fakev4l2_unplug(fakev4l2_dev_t *d, int replug_after_opens)
{
    d->unplugged = true;
    d->live_fd = -1;
    d->replug_after_opens = replug_after_opens;
    drop_device_state(d);
}

static uint32_t bpp_of(uint32_t fcc)
{
    return fcc == V4L2_PIX_FMT_GREY ? 1u : 2u;
}

static bool supported(const fakev4l2_dev_t *d, uint32_t fcc)
{
    for (uint32_t i = 0; i < d->nformats; i++) {
        if (d->formats[i] == fcc) {
            return true;
        }
    }
    return false;
}

static uint32_t buf_type(const fakev4l2_dev_t *d)
{
    return d->mplane ? V4L2_BUF_TYPE_VIDEO_CAPTURE_MPLANE : V4L2_BUF_TYPE_VIDEO_CAPTURE;
}

static void fill_format(const fakev4l2_dev_t *d, struct v4l2_format *f)
{
    memset(&f->fmt, 0, sizeof f->fmt);
    if (d->mplane) {
        f->fmt.pix_mp.width = d->w;
        f->fmt.pix_mp.height = d->h;
        f->fmt.pix_mp.pixelformat = d->fourcc;
        f->fmt.pix_mp.field = V4L2_FIELD_NONE;
        f->fmt.pix_mp.num_planes = 1;
        f->fmt.pix_mp.plane_fmt[0].bytesperline = d->stride;
        f->fmt.pix_mp.plane_fmt[0].sizeimage = d->sizeimage;
    } else {
        f->fmt.pix.width = d->w;
        f->fmt.pix.height = d->h;
        f->fmt.pix.pixelformat = d->fourcc;
        f->fmt.pix.field = V4L2_FIELD_NONE;
        f->fmt.pix.bytesperline = d->stride;
        f->fmt.pix.sizeimage = d->sizeimage;
    }
}

static void update_geometry(fakev4l2_dev_t *d)
{
    d->stride = d->w * bpp_of(d->fourcc) + d->stride_pad;
    d->sizeimage = d->stride * d->h;
}

static int fail(int e)
{
    errno = e;
    return -1;
}

static int do_fmt(fakev4l2_dev_t *d, unsigned long req, struct v4l2_format *f)
{
    if (f->type != buf_type(d)) {
        return fail(EINVAL);
    }
    if (req == VIDIOC_S_FMT) {
        if (d->nbuf > 0) {
            return fail(EBUSY);
        }
        const uint32_t w = d->mplane ? f->fmt.pix_mp.width : f->fmt.pix.width;
        const uint32_t h = d->mplane ? f->fmt.pix_mp.height : f->fmt.pix.height;
        const uint32_t fcc = d->mplane ? f->fmt.pix_mp.pixelformat : f->fmt.pix.pixelformat;
        /* like real drivers: adjust, do not fail */
        d->fourcc = supported(d, fcc) ? fcc : d->formats[0];
        d->w = (w == 0 || w > d->max_w) ? d->max_w : w;
        d->h = (h == 0 || h > d->max_h) ? d->max_h : h;
    }
    update_geometry(d);
    fill_format(d, f);
    return 0;
}

static int do_reqbufs(fakev4l2_dev_t *d, struct v4l2_requestbuffers *rb)
{
    if (rb->type != buf_type(d) || rb->memory != V4L2_MEMORY_MMAP) {
        return fail(EINVAL);
    }
    if (d->streaming) {
        return fail(EBUSY);
    }
    d->nbuf = 0;
    d->nqueued = 0;
    memset(d->queued, 0, sizeof d->queued);
    if (rb->count == 0) {
        return 0;
    }
    uint32_t n = rb->count < d->max_buffers ? rb->count : d->max_buffers;
    if (n > FAKEV4L2_MAX_BUFS) {
        n = FAKEV4L2_MAX_BUFS;
    }
    update_geometry(d);
    for (uint32_t i = 0; i < n; i++) {
        if (d->nallocs >= FAKEV4L2_MAX_ALLOCS) {
            return fail(ENOMEM);
        }
        fakev4l2_alloc_t *a = &d->allocs[d->nallocs];
        a->length = (d->sizeimage + 4095u) & ~(size_t)4095u; /* page-rounded like vb2 */
        a->mem = calloc(1, a->length);
        if (!a->mem) {
            return fail(ENOMEM);
        }
        a->offset = (uint32_t)d->nallocs * FAKE_OFFSET_STEP;
        a->mapped = 0;
        d->buf_alloc[i] = d->nallocs++;
    }
    d->nbuf = n;
    rb->count = n;
    return 0;
}

static int do_querybuf(fakev4l2_dev_t *d, struct v4l2_buffer *b)
{
    if (b->type != buf_type(d) || b->index >= d->nbuf) {
        return fail(EINVAL);
    }
    const fakev4l2_alloc_t *a = &d->allocs[d->buf_alloc[b->index]];
    if (d->mplane) {
        if (!b->m.planes || b->length < 1) {
            return fail(EINVAL);
        }
        b->length = 1;
        b->m.planes[0].length = (uint32_t)a->length;
        b->m.planes[0].m.mem_offset = a->offset;
    } else {
        b->length = (uint32_t)a->length;
        b->m.offset = a->offset;
    }
    return 0;
}

static int do_qbuf(fakev4l2_dev_t *d, const struct v4l2_buffer *b)
{
    if (d->qbuf_enodev_next > 0) {
        d->qbuf_enodev_next--;
        fakev4l2_unplug(d, d->replug_after_opens);
        return fail(ENODEV);
    }
    if (b->type != buf_type(d) || b->memory != V4L2_MEMORY_MMAP || b->index >= d->nbuf || d->queued[b->index]) {
        return fail(EINVAL);
    }
    if (d->mplane && (!b->m.planes || b->length < 1)) {
        return fail(EINVAL);
    }
    d->queued[b->index] = true;
    d->qorder[d->nqueued++] = b->index;
    return 0;
}

static int do_dqbuf(fakev4l2_dev_t *d, struct v4l2_buffer *b)
{
    d->dqbufs++;
    if (d->unplug_at_dqbuf > 0 && d->dqbufs == d->unplug_at_dqbuf) {
        fakev4l2_unplug(d, d->replug_after_opens);
        return fail(ENODEV);
    }
    if (b->type != buf_type(d) || !d->streaming) {
        return fail(EINVAL);
    }
    if (d->mplane && (!b->m.planes || b->length < 1)) {
        return fail(EINVAL);
    }
    if (d->eio_next > 0) {
        d->eio_next--;
        return fail(EIO);
    }
    if (d->eagain_next > 0) {
        d->eagain_next--;
        return fail(EAGAIN);
    }
    if (d->stalled || d->nqueued == 0) {
        return fail(EAGAIN);
    }
    const uint32_t idx = d->qorder[0];
    memmove(&d->qorder[0], &d->qorder[1], (d->nqueued - 1u) * sizeof d->qorder[0]);
    d->nqueued--;
    d->queued[idx] = false;
    d->seq += d->seq_skip_next;
    d->seq_skip_next = 0;
    const uint32_t seq = d->seq++;
    fakev4l2_alloc_t *a = &d->allocs[d->buf_alloc[idx]];
    /* pixels: row r, byte c = seq + r + c (so tests can check rows and stride) */
    for (uint32_t r = 0; r < d->h; r++) {
        for (uint32_t c = 0; c < d->stride; c++) {
            a->mem[(size_t)r * d->stride + c] = (uint8_t)(seq + r + c);
        }
    }
    uint32_t used = d->sizeimage;
    if (d->short_next > 0) {
        d->short_next--;
        used = d->sizeimage / 2u;
    }
    d->last_bytesused = used;
    b->index = idx;
    b->sequence = d->no_seq ? 0u : seq;
    b->flags = d->ts_flags;
    if (d->error_flag_next > 0) {
        d->error_flag_next--;
        b->flags |= V4L2_BUF_FLAG_ERROR;
    }
    b->field = V4L2_FIELD_NONE;
    b->timestamp.tv_sec = 1000 + seq / 10;
    b->timestamp.tv_usec = (seq % 10) * 53763;
    d->last_stamp_ns = (int64_t)b->timestamp.tv_sec * 1000000000 + (int64_t)b->timestamp.tv_usec * 1000;
    if (d->mplane) {
        b->length = 1;
        b->m.planes[0].bytesused = used;
        b->m.planes[0].data_offset = 0;
        b->m.planes[0].length = (uint32_t)a->length;
    } else {
        b->bytesused = used;
        b->length = (uint32_t)a->length;
    }
    return 0;
}

static int do_queryctrl(const fakev4l2_dev_t *d, struct v4l2_queryctrl *q)
{
    const uint32_t id = q->id;
    memset(q, 0, sizeof *q);
    q->id = id;
    q->type = V4L2_CTRL_TYPE_INTEGER;
    q->step = 1;
    if (id == V4L2_CID_EXPOSURE_ABSOLUTE && d->has_exposure) {
        q->minimum = d->exp_min;
        q->maximum = d->exp_max;
        return 0;
    }
    if (id == V4L2_CID_GAIN && d->has_gain) {
        q->minimum = d->gain_min;
        q->maximum = d->gain_max;
        return 0;
    }
    if (id == V4L2_CID_EXPOSURE_AUTO && d->has_exposure_auto) {
        q->type = V4L2_CTRL_TYPE_MENU;
        q->minimum = 0;
        q->maximum = 3;
        return 0;
    }
    return fail(EINVAL);
}

static int do_ctrl(fakev4l2_dev_t *d, unsigned long req, struct v4l2_control *c)
{
    int32_t *slot = NULL;
    if (c->id == V4L2_CID_EXPOSURE_ABSOLUTE && d->has_exposure) {
        slot = &d->exposure;
    } else if (c->id == V4L2_CID_GAIN && d->has_gain) {
        slot = &d->gain;
    } else if (c->id == V4L2_CID_EXPOSURE_AUTO && d->has_exposure_auto) {
        slot = &d->exposure_auto;
    }
    if (!slot) {
        return fail(EINVAL);
    }
    if (req == VIDIOC_G_CTRL) {
        c->value = *slot;
    } else {
        *slot = c->value;
    }
    return 0;
}

static int do_parm(fakev4l2_dev_t *d, unsigned long req, struct v4l2_streamparm *p)
{
    if (p->type != buf_type(d)) {
        return fail(EINVAL);
    }
    if (req == VIDIOC_S_PARM && d->has_timeperframe) {
        const struct v4l2_fract t = p->parm.capture.timeperframe;
        if (t.numerator == 0 || t.denominator == 0) {
            return fail(EINVAL);
        }
        const float fps = (float)t.denominator / (float)t.numerator;
        if (fps > d->max_fps) {
            d->tpf_num = 1000;
            d->tpf_den = (uint32_t)(d->max_fps * 1000.0f);
        } else {
            d->tpf_num = t.numerator;
            d->tpf_den = t.denominator;
        }
    }
    memset(&p->parm, 0, sizeof p->parm);
    p->parm.capture.capability = d->has_timeperframe ? V4L2_CAP_TIMEPERFRAME : 0u;
    p->parm.capture.timeperframe.numerator = d->tpf_num;
    p->parm.capture.timeperframe.denominator = d->tpf_den;
    return 0;
}

static int f_ioctl(void *ctx, int fd, unsigned long req, void *arg)
{
    fakev4l2_dev_t *d = ctx;
    if (d->ntrace < FAKEV4L2_TRACE_LEN) {
        d->trace[d->ntrace++] = req;
    }
    if (d->eintr_next > 0 && (d->eintr_request == 0 || d->eintr_request == req)) {
        d->eintr_next--;
        return fail(EINTR);
    }
    if (d->unplugged || fd != d->live_fd) {
        return fail(fd >= 100 && fd < d->next_fd ? ENODEV : EBADF);
    }
    switch (req) {
    case VIDIOC_QUERYCAP: {
        struct v4l2_capability *cap = arg;
        memset(cap, 0, sizeof *cap);
        memcpy(cap->driver, "fakev4l2", 9);
        memcpy(cap->card, "MFNS simulated camera", 22);
        uint32_t caps = 0;
        if (!d->not_capture) {
            caps |= d->mplane ? V4L2_CAP_VIDEO_CAPTURE_MPLANE : V4L2_CAP_VIDEO_CAPTURE;
        }
        if (!d->no_streaming) {
            caps |= V4L2_CAP_STREAMING;
        }
        cap->device_caps = caps;
        cap->capabilities = caps | V4L2_CAP_DEVICE_CAPS;
        return 0;
    }
    case VIDIOC_G_FMT:
    case VIDIOC_S_FMT: return do_fmt(d, req, arg);
    case VIDIOC_REQBUFS: return do_reqbufs(d, arg);
    case VIDIOC_QUERYBUF: return do_querybuf(d, arg);
    case VIDIOC_QBUF: return do_qbuf(d, arg);
    case VIDIOC_DQBUF: return do_dqbuf(d, arg);
    case VIDIOC_STREAMON:
    case VIDIOC_STREAMOFF: {
        const int *type = arg;
        if ((uint32_t)*type != buf_type(d)) {
            return fail(EINVAL);
        }
        if (req == VIDIOC_STREAMON) {
            if (d->nbuf == 0) {
                return fail(EINVAL);
            }
            d->streaming = true;
        } else {
            d->streaming = false;
            d->nqueued = 0;
            memset(d->queued, 0, sizeof d->queued);
        }
        return 0;
    }
    case VIDIOC_QUERYCTRL: return do_queryctrl(d, arg);
    case VIDIOC_G_CTRL:
    case VIDIOC_S_CTRL: return do_ctrl(d, req, arg);
    case VIDIOC_G_PARM:
    case VIDIOC_S_PARM: return do_parm(d, req, arg);
    default: break;
    }
    return fail(ENOTTY);
}

static int f_open(void *ctx, const char *path, int flags)
{
    fakev4l2_dev_t *d = ctx;
    (void)path;
    (void)flags;
    d->opens++;
    if (d->unplugged) {
        if (d->replug_after_opens != 0) {
            if (d->replug_after_opens > 0) {
                d->replug_after_opens--;
            }
            d->failed_opens++;
            return fail(ENOENT);
        }
        d->unplugged = false; /* back: this open succeeds */
    }
    d->live_fd = d->next_fd++;
    d->open_fds++;
    return d->live_fd;
}

static int f_close(void *ctx, int fd)
{
    fakev4l2_dev_t *d = ctx;
    if (fd < 100 || fd >= d->next_fd) {
        return fail(EBADF);
    }
    d->open_fds--;
    if (fd == d->live_fd) {
        /* last close frees the queue, like vb2 */
        d->live_fd = -1;
        drop_device_state(d);
    }
    return 0;
}

static void *f_mmap(void *ctx, size_t length, int prot, int flags, int fd, off_t offset)
{
    fakev4l2_dev_t *d = ctx;
    const int call = d->mmaps++;
    if (call == d->mmap_fail_at) {
        errno = ENOMEM;
        return MAP_FAILED;
    }
    if (d->unplugged || fd != d->live_fd || !(flags & MAP_SHARED) || !(prot & PROT_READ)) {
        errno = d->unplugged ? ENODEV : EINVAL;
        return MAP_FAILED;
    }
    for (uint32_t i = 0; i < d->nbuf; i++) {
        fakev4l2_alloc_t *a = &d->allocs[d->buf_alloc[i]];
        if ((off_t)a->offset == offset && length <= a->length) {
            a->mapped++;
            d->live_mappings++;
            return a->mem;
        }
    }
    errno = EINVAL;
    return MAP_FAILED;
}

static int f_munmap(void *ctx, void *addr, size_t length)
{
    fakev4l2_dev_t *d = ctx;
    d->munmaps++;
    for (int i = 0; i < d->nallocs; i++) {
        fakev4l2_alloc_t *a = &d->allocs[i];
        if (a->mem == addr && a->mapped > 0 && length <= a->length) {
            a->mapped--;
            d->live_mappings--;
            return 0;
        }
    }
    d->bad_munmaps++;
    return fail(EINVAL);
}

static int f_poll(void *ctx, struct pollfd *fds, nfds_t nfds, int timeout_ms)
{
    fakev4l2_dev_t *d = ctx;
    if (nfds == 0) {
        d->slept_ms += timeout_ms; /* a sleep: skipped, only recorded */
        return 0;
    }
    d->polls++;
    d->last_poll_timeout = timeout_ms;
    if (d->eintr_poll_next > 0) {
        d->eintr_poll_next--;
        return fail(EINTR);
    }
    fds[0].revents = 0;
    if (d->unplugged || fds[0].fd != d->live_fd) {
        fds[0].revents = POLLERR | POLLHUP;
        return 1;
    }
    if (d->stalled || !d->streaming || d->nqueued == 0) {
        return 0; /* timed out (without waiting) */
    }
    fds[0].revents = POLLIN;
    return 1;
}

/* Arrival: the last frame's stamp plus the configured delay. */
static int64_t f_now_ns(void *ctx)
{
    const fakev4l2_dev_t *d = ctx;
    return d->last_stamp_ns + d->arrival_delay_ns;
}

mfns_cam_sys_t fakev4l2_sys(fakev4l2_dev_t *d)
{
    mfns_cam_sys_t s = {d, f_open, f_close, f_ioctl, f_mmap, f_munmap, f_poll, f_now_ns};
    return s;
}
