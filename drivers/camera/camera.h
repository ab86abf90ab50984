/* camera.h -- the one camera interface the flight program uses, whatever
 * delivers the frames: a V4L2 device, libcamera, or a replayed `mfns sim nav`
 * frame folder (docs/cameras.md).
 *
 * Include it as "drivers/camera/camera.h": math/lens.h (the imaging model)
 * has the same base name and comes first on the include path.
 *
 * Life cycle:  open -> start -> { dequeue -> use -> requeue }* -> stop -> close
 *   - open allocates everything (handle from a fixed pool, driver buffers via
 *     mmap, replay buffers); nothing allocates afterwards, so the navigation
 *     loop never touches the heap.
 *   - a dequeued frame's pixels stay valid and unchanged until it is requeued
 *     (or the handle is stopped/closed); the driver cannot reuse the buffer
 *     before then, so hold frames only as long as needed.
 *   - one handle is used by one thread at a time; different handles may be
 *     used concurrently (open/close of the pool is thread-safe).
 *
 * Errors: every call returns an mfns_cam_err_t; mfns_cam_strerror() names the
 * code and mfns_cam_message() gives the one-line detail of the handle's last
 * failure (which ioctl, which file and line, which control). A frame is only
 * filled on MFNS_CAM_OK: a frame that arrived damaged (driver error flag,
 * short payload) is requeued internally, counted, and never handed out.
 */
#ifndef MFNS_DRIVERS_CAMERA_H
#define MFNS_DRIVERS_CAMERA_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Sizes of the static storage (every loop over buffers is bounded by these). */
#define MFNS_CAM_MAX_HANDLES 6u  /* three flight cameras + spares for tests/tools */
#define MFNS_CAM_MAX_BUFFERS 16u /* per handle */
#define MFNS_CAM_MIN_BUFFERS 2u  /* fewer cannot stream without losing every other frame */
#define MFNS_CAM_DEFAULT_BUFFERS 4u /* settings.buffer_count = 0 asks for this many */
#define MFNS_CAM_MAX_DIM 8192u   /* width/height limit accepted from any source */
#define MFNS_CAM_MAX_TIMEOUT_MS 60000
#define MFNS_CAM_MSG_LEN 192u

/* Error codes. The numbers are part of the telemetry contract (CAMERA_LOST
 * event, arg0: docs/telemetry.md, docs/cameras.md "Errors"): explicit, never
 * renumbered; a new code takes the next number. */
typedef enum {
    MFNS_CAM_OK = 0,
    MFNS_CAM_E_ARG = 1,         /* bad argument or settings value */
    MFNS_CAM_E_NO_SLOT = 2,     /* all MFNS_CAM_MAX_HANDLES handles in use */
    MFNS_CAM_E_BACKEND = 3,     /* backend not built into this program (e.g. libcamera) */
    MFNS_CAM_E_OPEN = 4,        /* device/folder could not be opened */
    MFNS_CAM_E_NOT_CAPTURE = 5, /* device is not a streaming video-capture device */
    MFNS_CAM_E_FORMAT = 6,      /* requested pixel format / size not offered */
    MFNS_CAM_E_CONTROL = 7,     /* exposure, gain or frame rate unsupported or out of range */
    MFNS_CAM_E_BUFFERS = 8,     /* driver gave fewer than MFNS_CAM_MIN_BUFFERS buffers */
    MFNS_CAM_E_MMAP = 9,        /* mapping a driver buffer failed */
    MFNS_CAM_E_STREAM = 10,     /* STREAMON/STREAMOFF or backend start/stop failed */
    MFNS_CAM_E_STATE = 11,      /* call not valid in the handle's state */
    MFNS_CAM_E_BUSY = 12,       /* every buffer is held by the caller: requeue first */
    MFNS_CAM_E_TIMEOUT = 13,    /* no good frame within the timeout */
    MFNS_CAM_E_IO = 14,         /* unexpected syscall failure (errno in the message) */
    MFNS_CAM_E_LOST = 15,       /* device vanished; recovery is in progress (call again) */
    MFNS_CAM_E_NO_DEVICE = 16,  /* device vanished and recovery attempts are exhausted */
    MFNS_CAM_E_NO_CAMERA = 17,  /* libcamera: no such camera on this system */
    MFNS_CAM_E_END = 18,        /* replay: no more frames (not an error of the data) */
    MFNS_CAM_E_DATA = 19,       /* replay: malformed frames.csv, scenario.json or PGM */
    MFNS_CAM_E_COUNT_ = 20      /* number of codes (camera.c checks its name table against it) */
} mfns_cam_err_t;

typedef enum {
    MFNS_CAM_BACKEND_V4L2 = 0,
    MFNS_CAM_BACKEND_LIBCAMERA = 1,
    MFNS_CAM_BACKEND_REPLAY = 2,
    MFNS_CAM_BACKEND_COUNT_ = 3
} mfns_cam_backend_t;

/* Monochrome formats only (the MFNS cameras are mono). 16-bit formats are
 * native-endian 16-bit words with the value in the low bits (V4L2 Y10/Y12
 * layout); replay converts PGM's big-endian samples to this. */
typedef enum {
    MFNS_CAM_PIX_ANY = 0,  /* open: accept what the source gives (replay, or device default) */
    MFNS_CAM_PIX_GREY = 1, /* 8 bit */
    MFNS_CAM_PIX_Y10 = 2,  /* 10 bit in 16 */
    MFNS_CAM_PIX_Y12 = 3,  /* 12 bit in 16 */
    MFNS_CAM_PIX_Y16 = 4,  /* 16 bit */
    MFNS_CAM_PIX_COUNT_ = 5
} mfns_cam_pixfmt_t;

struct mfns_cam_sys; /* V4L2 syscall seam, drivers/camera/camera_v4l2.h */

typedef struct {
    mfns_cam_backend_t backend;
    /* V4L2: device node ("/dev/video0"). libcamera: camera id, or "" for the
     * first camera. Replay: the `mfns sim nav` output folder. */
    const char *path;
    uint32_t width, height;   /* 0 = the source's current/recorded size */
    mfns_cam_pixfmt_t pixfmt; /* MFNS_CAM_PIX_ANY = the source's */
    uint32_t buffer_count;    /* MFNS_CAM_MIN_BUFFERS..MFNS_CAM_MAX_BUFFERS; 0 = MFNS_CAM_DEFAULT_BUFFERS */
    int32_t exposure_us;      /* < 0: leave the device's setting */
    int32_t gain;             /* V4L2_CID_GAIN device units / libcamera gain x100; < 0: leave */
    float frame_rate_hz;      /* 0: leave the device's rate */
    /* Device loss: reopen attempts per loss before giving up (one attempt per
     * dequeue call). 0 = no recovery. */
    uint32_t recover_attempts;
    /* Replay only: camera 'x', 'y' or 'z'; pace to the recorded timestamps
     * (true) or deliver as fast as asked (false). */
    char replay_camera;
    bool replay_realtime;
    /* Replay only: when set, start() skips the rows recorded at or before
     * replay_resume_after_ns, so a camera re-opened by the program carries on
     * at the program's time instead of replaying from the first frame. */
    bool replay_resume;
    uint64_t replay_resume_after_ns;
    /* V4L2 only: syscall seam; NULL = the real syscalls. Tests substitute a
     * simulated device here. Must outlive the handle. */
    const struct mfns_cam_sys *sys;
} mfns_cam_settings_t;

/* Where a frame's timestamp_ns comes from (V4L2 buffer flags
 * V4L2_BUF_FLAG_TIMESTAMP_MASK and V4L2_BUF_FLAG_TSTAMP_SRC_MASK, portable):
 * the camera data health checks (firmware/nav/frames/frame_health.h) compare a
 * capture stamp with the frame's arrival only when both are on one clock. */
typedef enum {
    MFNS_CAM_TS_UNKNOWN = 0,     /* V4L2 TIMESTAMP_UNKNOWN (or no statement) */
    MFNS_CAM_TS_MONOTONIC_SOE,   /* CLOCK_MONOTONIC, start of exposure */
    MFNS_CAM_TS_MONOTONIC_EOF,   /* CLOCK_MONOTONIC, end of frame (last pixel) */
    MFNS_CAM_TS_COPY,            /* V4L2 TIMESTAMP_COPY: copied from an output buffer, not a capture time */
    MFNS_CAM_TS_RECORDED         /* replay: the recorded capture time (frames.csv t_s) */
} mfns_cam_ts_source_t;

typedef struct {
    const void *data;         /* first pixel of row 0 */
    size_t bytesused;         /* valid bytes at data (the driver's bytesused) */
    mfns_cam_pixfmt_t pixfmt;
    uint32_t width, height;
    uint32_t stride;          /* bytes from one row to the next (>= width * bytes/pixel) */
    uint64_t timestamp_ns;    /* V4L2/libcamera: capture time, CLOCK_MONOTONIC;
                                 replay: the recorded t_s (frames.csv row) */
    uint32_t sequence;        /* driver frame counter (replay: the row's frame index) */
    uint32_t dropped_before;  /* frames missing between the previous frame and this one */
    uint64_t arrival_ns;      /* when the frame was dequeued, on timestamp_ns's time base
                                 (V4L2/libcamera: CLOCK_MONOTONIC; replay: only when
                                 paced, the recording's time base); 0 = unknown */
    mfns_cam_ts_source_t ts_source; /* what timestamp_ns is */
    int32_t exposure_us;      /* exposure in effect, -1 if unknown */
    /* for requeue; do not change */
    uint32_t buf_index;
    uint32_t generation;
} mfns_cam_frame_t;

typedef struct {
    uint64_t frames;          /* delivered to the caller */
    uint64_t dropped;         /* sequence-number gaps (frames never delivered by the driver) */
    uint64_t error_frames;    /* arrived flagged as errored or short: requeued unseen */
    uint64_t timeouts;
    uint32_t eintr_retries;
    uint32_t losses;          /* times the device vanished */
    uint32_t recoveries;      /* times it came back and streams again */
    uint32_t reopen_attempts; /* total, successful or not */
} mfns_cam_stats_t;

typedef struct {
    mfns_cam_backend_t backend;
    uint32_t width, height, stride;
    mfns_cam_pixfmt_t pixfmt;
    uint32_t buffer_count;    /* as granted by the driver (may be below the request) */
    bool multiplanar;         /* V4L2: the device uses the multi-planar API */
    char driver[32];          /* V4L2 driver / libcamera id / "replay" */
    char card[32];            /* V4L2 card name / replay camera letter */
} mfns_cam_info_t;

/* Events for telemetry ("camera lost or recovered"), collected by
 * mfns_cam_take_events. */
#define MFNS_CAM_EV_LOST 0x1u            /* device vanished */
#define MFNS_CAM_EV_RECOVERED 0x2u       /* reopened, reconfigured and streaming again */
#define MFNS_CAM_EV_RECOVERY_FAILED 0x4u /* attempts exhausted: MFNS_CAM_E_NO_DEVICE from now */

typedef struct mfns_cam mfns_cam_t;

/* Settings with every field at its "leave as is" default and the given
 * backend/path (caller then sets what it needs). */
mfns_cam_settings_t mfns_cam_default_settings(mfns_cam_backend_t backend, const char *path);

/* Opens and configures (format, buffers, controls) but does not stream.
 * *out is NULL on failure; msg (may be NULL) gets the one-line reason. */
mfns_cam_err_t mfns_cam_open(const mfns_cam_settings_t *s, mfns_cam_t **out, char *msg, size_t msg_size);
mfns_cam_err_t mfns_cam_start(mfns_cam_t *h);
/* Waits at most timeout_ms (0..MFNS_CAM_MAX_TIMEOUT_MS; 0 = only if ready). */
mfns_cam_err_t mfns_cam_dequeue(mfns_cam_t *h, mfns_cam_frame_t *frame, int timeout_ms);
mfns_cam_err_t mfns_cam_requeue(mfns_cam_t *h, const mfns_cam_frame_t *frame);
/* Stops streaming; frames still held become stale (requeue is then a no-op). */
mfns_cam_err_t mfns_cam_stop(mfns_cam_t *h);
/* Always releases the handle (stops first if needed); NULL is a no-op. */
void mfns_cam_close(mfns_cam_t *h);

/* Changes exposure/gain while open (< 0 leaves that control alone). */
mfns_cam_err_t mfns_cam_set_controls(mfns_cam_t *h, int32_t exposure_us, int32_t gain);

mfns_cam_err_t mfns_cam_get_info(const mfns_cam_t *h, mfns_cam_info_t *info);
mfns_cam_err_t mfns_cam_get_stats(const mfns_cam_t *h, mfns_cam_stats_t *stats);
/* Returns and clears the MFNS_CAM_EV_* bits raised since the last call. */
uint32_t mfns_cam_take_events(mfns_cam_t *h);

const char *mfns_cam_strerror(mfns_cam_err_t e);
/* Detail of the handle's last failure ("" if none); never NULL. */
const char *mfns_cam_message(const mfns_cam_t *h);
const char *mfns_cam_pixfmt_name(mfns_cam_pixfmt_t f);
/* Bytes per pixel (1 or 2); 0 for MFNS_CAM_PIX_ANY or an invalid value. */
uint32_t mfns_cam_pixfmt_bytes(mfns_cam_pixfmt_t f);

#ifdef __cplusplus
}
#endif

#endif
