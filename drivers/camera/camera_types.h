/* camera_types.h -- the camera driver's vocabulary: sizes, error codes, pixel
 * formats, settings, frames, statistics and the opaque handle type, with the
 * pure functions that name them. A leaf of drivers/camera: the front
 * (camera.h/.c) and every backend (camera_backend.h, camera_v4l2*,
 * camera_replay.c, camera_libcamera.cpp) include it, so a backend never needs
 * the front's header and the front's includes of the backends make no circle
 * (issue 41). The flight program includes camera.h, which includes this.
 * C and C++ (camera_libcamera.cpp). */
#ifndef MFNS_DRIVERS_CAMERA_TYPES_H
#define MFNS_DRIVERS_CAMERA_TYPES_H

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
 * the camera data health checks (firmware/frames/frame_health.h) compare a
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
    float gain_db;            /* sensor gain in effect, dB; NaN if unknown (V4L2 and libcamera
                                 report their own gain units, not dB: unknown there) */
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
    uint32_t own_seq_streams; /* V4L2 streams whose driver numbered no frame (all 0): counted by the backend */
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

const char *mfns_cam_strerror(mfns_cam_err_t e);
const char *mfns_cam_pixfmt_name(mfns_cam_pixfmt_t f);
/* Bytes per pixel (1 or 2); 0 for MFNS_CAM_PIX_ANY or an invalid value. */
uint32_t mfns_cam_pixfmt_bytes(mfns_cam_pixfmt_t f);

#ifdef __cplusplus
}
#endif

#endif
