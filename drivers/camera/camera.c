/* camera.c -- the front: handle pool, settings checks, state checks and the
 * dispatch to the backends. The bookkeeping the backends share is
 * camera_backend.c, the names of codes and formats camera_types.c. */
#ifndef _DEFAULT_SOURCE
#define _DEFAULT_SOURCE 1
#endif
#include "drivers/camera/camera.h"

#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "drivers/camera/camera_backend.h"
#if defined(MFNS_HAVE_LIBCAMERA)
#include "drivers/camera/camera_libcamera.h"

const mfns_cam_backend_ops_t mfns_cam_libcamera_ops = {mfns_lcam_open,    mfns_lcam_start, mfns_lcam_dequeue,
                                                       mfns_lcam_requeue, mfns_lcam_stop,  mfns_lcam_close,
                                                       mfns_lcam_set_controls};
#endif

static mfns_cam_t g_pool[MFNS_CAM_MAX_HANDLES];
static atomic_bool g_used[MFNS_CAM_MAX_HANDLES];

const char *mfns_cam_message(const mfns_cam_t *h)
{
    return h ? h->msg : "";
}

mfns_cam_settings_t mfns_cam_default_settings(mfns_cam_backend_t backend, const char *path)
{
    mfns_cam_settings_t s;
    memset(&s, 0, sizeof s);
    s.backend = backend;
    s.path = path;
    s.pixfmt = MFNS_CAM_PIX_ANY;
    s.buffer_count = MFNS_CAM_DEFAULT_BUFFERS;
    s.exposure_us = -1;
    s.gain = -1;
    s.frame_rate_hz = 0.0f;
    s.recover_attempts = 5;
    s.replay_camera = 'x';
    s.replay_realtime = false;
    s.sys = NULL;
    return s;
}

static mfns_cam_t *pool_take(void)
{
    for (unsigned i = 0; i < MFNS_CAM_MAX_HANDLES; i++) {
        bool expected = false;
        if (atomic_compare_exchange_strong(&g_used[i], &expected, true)) {
            memset(&g_pool[i], 0, sizeof g_pool[i]);
            return &g_pool[i];
        }
    }
    return NULL;
}

static void pool_give(mfns_cam_t *h)
{
    const size_t i = (size_t)(h - g_pool);
    memset(h, 0, sizeof *h);
    atomic_store(&g_used[i], false);
}

static bool is_pool_handle(const mfns_cam_t *h)
{
    for (unsigned i = 0; i < MFNS_CAM_MAX_HANDLES; i++) {
        if (h == &g_pool[i]) {
            return atomic_load(&g_used[i]);
        }
    }
    return false;
}

static void set_msg(char *msg, size_t msg_size, const char *text)
{
    if (msg && msg_size > 0) {
        (void)snprintf(msg, msg_size, "%s", text);
    }
}

static mfns_cam_err_t check_settings(const mfns_cam_settings_t *s, char *why, size_t n)
{
    if ((unsigned)s->backend >= (unsigned)MFNS_CAM_BACKEND_COUNT_) {
        (void)snprintf(why, n, "unknown backend %d", (int)s->backend);
        return MFNS_CAM_E_ARG;
    }
    if (!s->path) {
        (void)snprintf(why, n, "no path given");
        return MFNS_CAM_E_ARG;
    }
    if (strlen(s->path) >= MFNS_CAM_PATH_LEN) {
        (void)snprintf(why, n, "path longer than %u characters", MFNS_CAM_PATH_LEN - 1u);
        return MFNS_CAM_E_ARG;
    }
    if (s->width > MFNS_CAM_MAX_DIM || s->height > MFNS_CAM_MAX_DIM) {
        (void)snprintf(why, n, "size %ux%u above the %u limit", s->width, s->height, MFNS_CAM_MAX_DIM);
        return MFNS_CAM_E_ARG;
    }
    if ((unsigned)s->pixfmt >= (unsigned)MFNS_CAM_PIX_COUNT_) {
        (void)snprintf(why, n, "unknown pixel format %d", (int)s->pixfmt);
        return MFNS_CAM_E_ARG;
    }
    if (s->buffer_count != 0 &&
        (s->buffer_count < MFNS_CAM_MIN_BUFFERS || s->buffer_count > MFNS_CAM_MAX_BUFFERS)) {
        (void)snprintf(why, n, "buffer_count %u outside %u..%u", s->buffer_count, MFNS_CAM_MIN_BUFFERS,
                       MFNS_CAM_MAX_BUFFERS);
        return MFNS_CAM_E_ARG;
    }
    if (!(s->frame_rate_hz >= 0.0f && s->frame_rate_hz <= 1000.0f)) {
        (void)snprintf(why, n, "frame_rate_hz %g outside 0..1000", (double)s->frame_rate_hz);
        return MFNS_CAM_E_ARG;
    }
    if (s->recover_attempts > 1000u) {
        (void)snprintf(why, n, "recover_attempts %u above 1000", s->recover_attempts);
        return MFNS_CAM_E_ARG;
    }
    if (s->backend == MFNS_CAM_BACKEND_REPLAY && s->replay_camera != 'x' && s->replay_camera != 'y' &&
        s->replay_camera != 'z') {
        (void)snprintf(why, n, "replay_camera must be 'x', 'y' or 'z'");
        return MFNS_CAM_E_ARG;
    }
    return MFNS_CAM_OK;
}

static const mfns_cam_backend_ops_t *backend_ops(mfns_cam_backend_t b)
{
    switch (b) {
    case MFNS_CAM_BACKEND_V4L2: return &mfns_cam_v4l2_ops;
    case MFNS_CAM_BACKEND_REPLAY: return &mfns_cam_replay_ops;
    case MFNS_CAM_BACKEND_LIBCAMERA:
#if defined(MFNS_HAVE_LIBCAMERA)
        return &mfns_cam_libcamera_ops;
#else
        return NULL;
#endif
    case MFNS_CAM_BACKEND_COUNT_: break;
    }
    return NULL;
}

mfns_cam_err_t mfns_cam_open(const mfns_cam_settings_t *s, mfns_cam_t **out, char *msg, size_t msg_size)
{
    char why[MFNS_CAM_MSG_LEN];
    if (!out) {
        set_msg(msg, msg_size, "out pointer is NULL");
        return MFNS_CAM_E_ARG;
    }
    *out = NULL;
    if (!s) {
        set_msg(msg, msg_size, "settings pointer is NULL");
        return MFNS_CAM_E_ARG;
    }
    mfns_cam_err_t e = check_settings(s, why, sizeof why);
    if (e != MFNS_CAM_OK) {
        set_msg(msg, msg_size, why);
        return e;
    }
    const mfns_cam_backend_ops_t *ops = backend_ops(s->backend);
    if (!ops) {
        set_msg(msg, msg_size, "libcamera backend not built (libcamera was not found at build time)");
        return MFNS_CAM_E_BACKEND;
    }
    mfns_cam_t *h = pool_take();
    if (!h) {
        (void)snprintf(why, sizeof why, "all %u camera handles in use", MFNS_CAM_MAX_HANDLES);
        set_msg(msg, msg_size, why);
        return MFNS_CAM_E_NO_SLOT;
    }
    h->ops = ops;
    h->s = *s;
    (void)snprintf(h->path, sizeof h->path, "%s", s->path);
    h->s.path = h->path;
    if (h->s.buffer_count == 0) {
        h->s.buffer_count = MFNS_CAM_DEFAULT_BUFFERS;
    }
    h->info.backend = s->backend;
    h->generation = 1;
    e = ops->open(h);
    if (e != MFNS_CAM_OK) {
        set_msg(msg, msg_size, h->msg);
        ops->close(h);
        pool_give(h);
        return e;
    }
    h->msg[0] = '\0';
    set_msg(msg, msg_size, "");
    *out = h;
    return MFNS_CAM_OK;
}

mfns_cam_err_t mfns_cam_start(mfns_cam_t *h)
{
    if (!is_pool_handle(h)) {
        return MFNS_CAM_E_ARG;
    }
    if (h->streaming) {
        return mfns_cam_fail(h, MFNS_CAM_E_STATE, "start: already streaming");
    }
    mfns_cam_seq_reset(h);
    const mfns_cam_err_t e = h->ops->start(h);
    if (e == MFNS_CAM_OK) {
        h->streaming = true;
    }
    return e;
}

mfns_cam_err_t mfns_cam_dequeue(mfns_cam_t *h, mfns_cam_frame_t *frame, int timeout_ms)
{
    if (!is_pool_handle(h)) {
        return MFNS_CAM_E_ARG;
    }
    if (!frame || timeout_ms < 0 || timeout_ms > MFNS_CAM_MAX_TIMEOUT_MS) {
        return mfns_cam_fail(h, MFNS_CAM_E_ARG, "dequeue: NULL frame or timeout %d ms outside 0..%d",
                             timeout_ms, MFNS_CAM_MAX_TIMEOUT_MS);
    }
    if (!h->streaming) {
        return mfns_cam_fail(h, MFNS_CAM_E_STATE, "dequeue: not streaming (call mfns_cam_start)");
    }
    mfns_cam_frame_t f;
    memset(&f, 0, sizeof f);
    const mfns_cam_err_t e = h->ops->dequeue(h, &f, timeout_ms);
    if (e == MFNS_CAM_OK) {
        f.generation = h->generation;
        *frame = f;
    } else if (e == MFNS_CAM_E_TIMEOUT) {
        h->stats.timeouts++;
    }
    return e;
}

mfns_cam_err_t mfns_cam_requeue(mfns_cam_t *h, const mfns_cam_frame_t *frame)
{
    if (!is_pool_handle(h)) {
        return MFNS_CAM_E_ARG;
    }
    if (!frame || frame->buf_index >= MFNS_CAM_MAX_BUFFERS) {
        return mfns_cam_fail(h, MFNS_CAM_E_ARG, "requeue: NULL frame or bad buffer index");
    }
    if (frame->generation != h->generation || !h->streaming) {
        return MFNS_CAM_OK; /* stale: its stream was stopped or lost; nothing to give back */
    }
    return h->ops->requeue(h, frame);
}

mfns_cam_err_t mfns_cam_stop(mfns_cam_t *h)
{
    if (!is_pool_handle(h)) {
        return MFNS_CAM_E_ARG;
    }
    if (!h->streaming) {
        return MFNS_CAM_OK;
    }
    h->streaming = false;
    h->generation++; /* frames still held are stale now */
    return h->ops->stop(h);
}

void mfns_cam_close(mfns_cam_t *h)
{
    if (!is_pool_handle(h)) {
        return;
    }
    if (h->streaming) {
        (void)mfns_cam_stop(h);
    }
    h->ops->close(h);
    pool_give(h);
}

mfns_cam_err_t mfns_cam_set_controls(mfns_cam_t *h, int32_t exposure_us, int32_t gain)
{
    if (!is_pool_handle(h)) {
        return MFNS_CAM_E_ARG;
    }
    return h->ops->set_controls(h, exposure_us, gain);
}

mfns_cam_err_t mfns_cam_get_info(const mfns_cam_t *h, mfns_cam_info_t *info)
{
    if (!is_pool_handle(h) || !info) {
        return MFNS_CAM_E_ARG;
    }
    *info = h->info;
    return MFNS_CAM_OK;
}

mfns_cam_err_t mfns_cam_get_stats(const mfns_cam_t *h, mfns_cam_stats_t *stats)
{
    if (!is_pool_handle(h) || !stats) {
        return MFNS_CAM_E_ARG;
    }
    *stats = h->stats;
    return MFNS_CAM_OK;
}

uint32_t mfns_cam_take_events(mfns_cam_t *h)
{
    if (!is_pool_handle(h)) {
        return 0;
    }
    const uint32_t ev = h->events;
    h->events = 0;
    return ev;
}
