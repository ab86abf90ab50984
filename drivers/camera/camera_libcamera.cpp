// camera_libcamera.cpp -- libcamera backend behind camera.h (see
// camera_libcamera.h). Built only where pkg-config finds libcamera.
//
// Completed requests arrive on libcamera's thread; they go into a fixed ring
// (one slot per request) guarded by a mutex, and dequeue waits on a condition
// variable with the caller's timeout. No exception crosses into C: every
// entry point catches and turns it into an error code.
#include "drivers/camera/camera_libcamera.h"

#include <sys/mman.h>

#include <cerrno>
#include <cmath>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <libcamera/libcamera.h>

#include "drivers/camera/camera_backend.h"

using namespace libcamera;

namespace {

std::mutex g_cm_mutex;
int g_cm_users = 0;
std::unique_ptr<CameraManager> g_cm;

CameraManager *cm_acquire()
{
    std::lock_guard<std::mutex> lock(g_cm_mutex);
    if (!g_cm) {
        auto cm = std::make_unique<CameraManager>();
        if (cm->start() != 0) {
            return nullptr;
        }
        g_cm = std::move(cm);
    }
    g_cm_users++;
    return g_cm.get();
}

void cm_release()
{
    std::lock_guard<std::mutex> lock(g_cm_mutex);
    if (g_cm_users > 0 && --g_cm_users == 0) {
        g_cm->stop();
        g_cm.reset();
    }
}

struct Mapping {
    void *base = MAP_FAILED;
    size_t len = 0;
    const uint8_t *data = nullptr;
};

struct Lcam {
    CameraManager *cm = nullptr;
    std::shared_ptr<Camera> cam;
    bool acquired = false;
    bool configured = false;
    bool started = false;
    std::unique_ptr<CameraConfiguration> config;
    Stream *stream = nullptr;
    std::unique_ptr<FrameBufferAllocator> alloc;
    std::vector<std::unique_ptr<Request>> requests;
    Mapping maps[MFNS_CAM_MAX_BUFFERS];
    bool held[MFNS_CAM_MAX_BUFFERS] = {};
    ControlList controls;  // applied at start
    ControlList pending;   // set while streaming: sent with the next requeued request
    bool has_pending = false;
    int32_t exposure_us = -1;

    std::mutex m;
    std::condition_variable cv;
    Request *ring[MFNS_CAM_MAX_BUFFERS] = {};
    unsigned head = 0, count = 0;

    void completed(Request *r)
    {
        if (r->status() == Request::RequestCancelled) {
            return; // stop() cancels pending requests: nothing to deliver
        }
        {
            std::lock_guard<std::mutex> lock(m);
            if (count < MFNS_CAM_MAX_BUFFERS) {
                ring[(head + count) % MFNS_CAM_MAX_BUFFERS] = r;
                count++;
            }
        }
        cv.notify_one();
    }
};

Lcam *lc(mfns_cam_t *h)
{
    return static_cast<Lcam *>(h->b.lcam);
}

PixelFormat to_lc(mfns_cam_pixfmt_t f)
{
    switch (f) {
    case MFNS_CAM_PIX_GREY: return formats::R8;
    case MFNS_CAM_PIX_Y10: return formats::R10;
    case MFNS_CAM_PIX_Y12: return formats::R12;
    default: break;
    }
    return PixelFormat();
}

mfns_cam_pixfmt_t from_lc(const PixelFormat &p)
{
    if (p == formats::R8) {
        return MFNS_CAM_PIX_GREY;
    }
    if (p == formats::R10) {
        return MFNS_CAM_PIX_Y10;
    }
    if (p == formats::R12) {
        return MFNS_CAM_PIX_Y12;
    }
    return MFNS_CAM_PIX_ANY;
}

mfns_cam_err_t build_controls(mfns_cam_t *h, Lcam *c, int32_t exposure_us, int32_t gain, float rate_hz)
{
    const ControlInfoMap &info = c->cam->controls();
    if (exposure_us >= 0) {
        auto it = info.find(&controls::ExposureTime);
        if (it == info.end()) {
            return mfns_cam_fail(h, MFNS_CAM_E_CONTROL, "exposure: camera %s has no ExposureTime control", h->path);
        }
        const int32_t lo = it->second.min().get<int32_t>(), hi = it->second.max().get<int32_t>();
        if (exposure_us < lo || exposure_us > hi) {
            return mfns_cam_fail(h, MFNS_CAM_E_CONTROL, "exposure: %d us outside camera range [%d, %d]", exposure_us,
                                 lo, hi);
        }
        c->controls.set(controls::ExposureTime, exposure_us);
        c->exposure_us = exposure_us;
    }
    if (gain >= 0) {
        auto it = info.find(&controls::AnalogueGain);
        if (it == info.end()) {
            return mfns_cam_fail(h, MFNS_CAM_E_CONTROL, "gain: camera %s has no AnalogueGain control", h->path);
        }
        c->controls.set(controls::AnalogueGain, static_cast<float>(gain) / 100.0f);
    }
    if (rate_hz > 0.0f) {
        auto it = info.find(&controls::FrameDurationLimits);
        if (it == info.end()) {
            return mfns_cam_fail(h, MFNS_CAM_E_CONTROL, "frame rate: camera %s has no FrameDurationLimits control",
                                 h->path);
        }
        const int64_t d = static_cast<int64_t>(1e6f / rate_hz + 0.5f);
        c->controls.set(controls::FrameDurationLimits, Span<const int64_t, 2>({d, d}));
    }
    return MFNS_CAM_OK;
}

mfns_cam_err_t open_impl(mfns_cam_t *h)
{
    auto *c = new Lcam();
    h->b.lcam = c;
    c->cm = cm_acquire();
    if (!c->cm) {
        return mfns_cam_fail(h, MFNS_CAM_E_OPEN, "libcamera: CameraManager failed to start");
    }
    const auto cams = c->cm->cameras();
    if (h->path[0] == '\0') {
        if (cams.empty()) {
            return mfns_cam_fail(h, MFNS_CAM_E_NO_CAMERA, "libcamera: no cameras on this system");
        }
        c->cam = cams.front();
    } else {
        c->cam = c->cm->get(h->path);
        if (!c->cam) {
            return mfns_cam_fail(h, MFNS_CAM_E_NO_CAMERA, "libcamera: no camera '%s' (%zu camera(s) present)", h->path,
                                 cams.size());
        }
    }
    if (c->cam->acquire() != 0) {
        return mfns_cam_fail(h, MFNS_CAM_E_OPEN, "libcamera: camera %s is in use", c->cam->id().c_str());
    }
    c->acquired = true;
    c->config = c->cam->generateConfiguration({StreamRole::Raw});
    if (!c->config || c->config->empty()) {
        c->config = c->cam->generateConfiguration({StreamRole::Viewfinder});
    }
    if (!c->config || c->config->empty()) {
        return mfns_cam_fail(h, MFNS_CAM_E_FORMAT, "libcamera: camera %s offers no Raw or Viewfinder stream",
                             c->cam->id().c_str());
    }
    StreamConfiguration &sc = c->config->at(0);
    if (h->s.pixfmt == MFNS_CAM_PIX_Y16) {
        return mfns_cam_fail(h, MFNS_CAM_E_FORMAT, "libcamera 0.0.3 has no 16-bit mono format (use Y10/Y12)");
    }
    if (h->s.pixfmt != MFNS_CAM_PIX_ANY) {
        sc.pixelFormat = to_lc(h->s.pixfmt);
    }
    if (h->s.width && h->s.height) {
        sc.size = Size(h->s.width, h->s.height);
    }
    sc.bufferCount = h->s.buffer_count;
    const PixelFormat want_fmt = sc.pixelFormat;
    const Size want_size = sc.size;
    if (c->config->validate() == CameraConfiguration::Invalid) {
        return mfns_cam_fail(h, MFNS_CAM_E_FORMAT, "libcamera: configuration %s %s invalid",
                             want_fmt.toString().c_str(), want_size.toString().c_str());
    }
    const mfns_cam_pixfmt_t pf = from_lc(sc.pixelFormat);
    if (sc.pixelFormat != want_fmt || sc.size != want_size || pf == MFNS_CAM_PIX_ANY) {
        return mfns_cam_fail(h, MFNS_CAM_E_FORMAT, "libcamera: asked %s %s, camera offers %s %s",
                             want_fmt.toString().c_str(), want_size.toString().c_str(),
                             sc.pixelFormat.toString().c_str(), sc.size.toString().c_str());
    }
    if (c->cam->configure(c->config.get()) != 0) {
        return mfns_cam_fail(h, MFNS_CAM_E_FORMAT, "libcamera: configure failed");
    }
    c->configured = true;
    c->stream = sc.stream();
    mfns_cam_err_t e = build_controls(h, c, h->s.exposure_us, h->s.gain, h->s.frame_rate_hz);
    if (e != MFNS_CAM_OK) {
        return e;
    }
    c->alloc = std::make_unique<FrameBufferAllocator>(c->cam);
    const int n = c->alloc->allocate(c->stream);
    if (n < static_cast<int>(MFNS_CAM_MIN_BUFFERS)) {
        return mfns_cam_fail(h, MFNS_CAM_E_BUFFERS, "libcamera: allocated %d buffers, need %u", n,
                             MFNS_CAM_MIN_BUFFERS);
    }
    const auto &bufs = c->alloc->buffers(c->stream);
    const size_t nb = bufs.size() < MFNS_CAM_MAX_BUFFERS ? bufs.size() : MFNS_CAM_MAX_BUFFERS;
    for (size_t i = 0; i < nb; i++) {
        FrameBuffer *fb = bufs[i].get();
        const FrameBuffer::Plane &pl = fb->planes()[0];
        const size_t len = static_cast<size_t>(pl.offset) + pl.length;
        void *p = mmap(nullptr, len, PROT_READ, MAP_SHARED, pl.fd.get(), 0);
        if (p == MAP_FAILED) {
            return mfns_cam_fail(h, MFNS_CAM_E_MMAP, "libcamera: mmap of buffer %zu failed: %s", i, strerror(errno));
        }
        c->maps[i].base = p;
        c->maps[i].len = len;
        c->maps[i].data = static_cast<const uint8_t *>(p) + pl.offset;
        std::unique_ptr<Request> rq = c->cam->createRequest(i);
        if (!rq || rq->addBuffer(c->stream, fb) != 0) {
            return mfns_cam_fail(h, MFNS_CAM_E_BUFFERS, "libcamera: cannot build request %zu", i);
        }
        c->requests.push_back(std::move(rq));
    }
    c->cam->requestCompleted.connect(c, &Lcam::completed);
    h->info.width = sc.size.width;
    h->info.height = sc.size.height;
    h->info.stride = sc.stride;
    h->info.pixfmt = pf;
    h->info.buffer_count = static_cast<uint32_t>(nb);
    (void)snprintf(h->info.driver, sizeof h->info.driver, "libcamera");
    (void)snprintf(h->info.card, sizeof h->info.card, "%.31s", c->cam->id().c_str());
    return MFNS_CAM_OK;
}

mfns_cam_err_t start_impl(mfns_cam_t *h)
{
    Lcam *c = lc(h);
    {
        std::lock_guard<std::mutex> lock(c->m);
        c->head = c->count = 0;
    }
    for (bool &b : c->held) {
        b = false;
    }
    if (c->cam->start(&c->controls) != 0) {
        return mfns_cam_fail(h, MFNS_CAM_E_STREAM, "libcamera: start failed");
    }
    c->started = true;
    for (auto &rq : c->requests) {
        rq->reuse(Request::ReuseBuffers); // after a stop the requests are completed/cancelled
        if (c->cam->queueRequest(rq.get()) != 0) {
            return mfns_cam_fail(h, MFNS_CAM_E_STREAM, "libcamera: queueRequest failed");
        }
    }
    return MFNS_CAM_OK;
}

mfns_cam_err_t requeue_request(mfns_cam_t *h, Lcam *c, Request *r)
{
    r->reuse(Request::ReuseBuffers);
    if (c->has_pending) {
        r->controls().merge(c->pending);
        c->has_pending = false;
    }
    if (c->cam->queueRequest(r) != 0) {
        return mfns_cam_fail(h, MFNS_CAM_E_IO, "libcamera: queueRequest failed");
    }
    return MFNS_CAM_OK;
}

mfns_cam_err_t dequeue_impl(mfns_cam_t *h, mfns_cam_frame_t *f, int timeout_ms)
{
    Lcam *c = lc(h);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
    for (unsigned tries = 0; tries < 4u * MFNS_CAM_MAX_BUFFERS; tries++) {
        Request *r = nullptr;
        {
            std::unique_lock<std::mutex> lock(c->m);
            if (!c->cv.wait_until(lock, deadline, [c] { return c->count > 0; })) {
                return mfns_cam_fail(h, MFNS_CAM_E_TIMEOUT, "libcamera: no frame within %d ms", timeout_ms);
            }
            r = c->ring[c->head];
            c->head = (c->head + 1) % MFNS_CAM_MAX_BUFFERS;
            c->count--;
        }
        const uint64_t idx = r->cookie();
        FrameBuffer *fb = r->buffers().begin()->second;
        const FrameMetadata &md = fb->metadata();
        const size_t used = md.planes().empty() ? 0 : md.planes()[0].bytesused;
        const size_t need = static_cast<size_t>(h->info.stride) * (h->info.height - 1u) +
                            static_cast<size_t>(h->info.width) * mfns_cam_pixfmt_bytes(h->info.pixfmt);
        if (idx >= MFNS_CAM_MAX_BUFFERS || r->status() != Request::RequestComplete ||
            md.status != FrameMetadata::FrameSuccess || used < need) {
            mfns_cam_seq_errored(h, md.sequence);
            const mfns_cam_err_t e = requeue_request(h, c, r);
            if (e != MFNS_CAM_OK) {
                return e;
            }
            continue;
        }
        c->held[idx] = true;
        f->data = c->maps[idx].data;
        f->bytesused = used;
        f->pixfmt = h->info.pixfmt;
        f->width = h->info.width;
        f->height = h->info.height;
        f->stride = h->info.stride;
        f->timestamp_ns = md.timestamp;
        f->sequence = md.sequence;
        f->dropped_before = mfns_cam_seq_delivered(h, md.sequence);
        /* libcamera's timestamp is the sensor's CLOCK_MONOTONIC capture time;
         * it does not say start of exposure or end of frame. The completion
         * queue does not say when a request completed: arrival unknown. */
        f->ts_source = MFNS_CAM_TS_MONOTONIC_EOF;
        f->arrival_ns = 0;
        f->exposure_us = c->exposure_us;
        f->gain_db = NAN; /* AnalogueGain is a factor the driver may not have applied yet: unknown */
        f->buf_index = static_cast<uint32_t>(idx);
        return MFNS_CAM_OK;
    }
    return mfns_cam_fail(h, MFNS_CAM_E_IO, "libcamera: no good frame in %u completed requests",
                         4u * MFNS_CAM_MAX_BUFFERS);
}

} // namespace

extern "C" {

int mfns_lcam_camera_count(void)
{
    try {
        CameraManager *cm = cm_acquire();
        if (!cm) {
            return -1;
        }
        const int n = static_cast<int>(cm->cameras().size());
        cm_release();
        return n;
    } catch (...) {
        return -1;
    }
}

mfns_cam_err_t mfns_lcam_open(mfns_cam_t *h)
{
    try {
        return open_impl(h);
    } catch (const std::exception &ex) {
        return mfns_cam_fail(h, MFNS_CAM_E_OPEN, "libcamera: %s", ex.what());
    }
}

mfns_cam_err_t mfns_lcam_start(mfns_cam_t *h)
{
    try {
        return start_impl(h);
    } catch (const std::exception &ex) {
        return mfns_cam_fail(h, MFNS_CAM_E_STREAM, "libcamera: %s", ex.what());
    }
}

mfns_cam_err_t mfns_lcam_dequeue(mfns_cam_t *h, mfns_cam_frame_t *f, int timeout_ms)
{
    try {
        Lcam *c = lc(h);
        unsigned held = 0;
        for (bool b : c->held) {
            held += b ? 1u : 0u;
        }
        if (held >= h->info.buffer_count) {
            return mfns_cam_fail(h, MFNS_CAM_E_BUSY, "all %u buffers are held by the caller", held);
        }
        return dequeue_impl(h, f, timeout_ms);
    } catch (const std::exception &ex) {
        return mfns_cam_fail(h, MFNS_CAM_E_IO, "libcamera: %s", ex.what());
    }
}

mfns_cam_err_t mfns_lcam_requeue(mfns_cam_t *h, const mfns_cam_frame_t *f)
{
    try {
        Lcam *c = lc(h);
        const uint32_t i = f->buf_index;
        if (i >= c->requests.size() || !c->held[i]) {
            return mfns_cam_fail(h, MFNS_CAM_E_ARG, "requeue: buffer %u is not held by the caller", i);
        }
        c->held[i] = false;
        return requeue_request(h, c, c->requests[i].get());
    } catch (const std::exception &ex) {
        return mfns_cam_fail(h, MFNS_CAM_E_IO, "libcamera: %s", ex.what());
    }
}

mfns_cam_err_t mfns_lcam_stop(mfns_cam_t *h)
{
    try {
        Lcam *c = lc(h);
        if (c->started) {
            c->started = false;
            if (c->cam->stop() != 0) {
                return mfns_cam_fail(h, MFNS_CAM_E_STREAM, "libcamera: stop failed");
            }
        }
        std::lock_guard<std::mutex> lock(c->m);
        c->head = c->count = 0;
        return MFNS_CAM_OK;
    } catch (const std::exception &ex) {
        return mfns_cam_fail(h, MFNS_CAM_E_STREAM, "libcamera: %s", ex.what());
    }
}

void mfns_lcam_close(mfns_cam_t *h)
{
    Lcam *c = lc(h);
    if (!c) {
        return;
    }
    try {
        if (c->started) {
            (void)c->cam->stop();
            c->started = false;
        }
        if (c->cam && c->configured) {
            c->cam->requestCompleted.disconnect(c, &Lcam::completed);
        }
        for (Mapping &mp : c->maps) {
            if (mp.base != MAP_FAILED) {
                (void)munmap(mp.base, mp.len);
                mp.base = MAP_FAILED;
            }
        }
        c->requests.clear();
        if (c->alloc && c->stream) {
            (void)c->alloc->free(c->stream);
        }
        c->alloc.reset();
        if (c->acquired) {
            (void)c->cam->release();
        }
        c->cam.reset();
        if (c->cm) {
            cm_release();
        }
    } catch (...) {
        // closing must not throw into C; what could not be released is lost
    }
    delete c;
    h->b.lcam = nullptr;
}

mfns_cam_err_t mfns_lcam_set_controls(mfns_cam_t *h, int32_t exposure_us, int32_t gain)
{
    try {
        Lcam *c = lc(h);
        const mfns_cam_err_t e = build_controls(h, c, exposure_us, gain, 0.0f);
        if (e != MFNS_CAM_OK) {
            return e;
        }
        // libcamera controls travel with requests: the next requeue carries them
        c->pending = c->controls;
        c->has_pending = true;
        return MFNS_CAM_OK;
    } catch (const std::exception &ex) {
        return mfns_cam_fail(h, MFNS_CAM_E_CONTROL, "libcamera: %s", ex.what());
    }
}

} // extern "C"
