/* camera_types.c -- the names of the camera driver's codes and formats
 * (camera_types.h): pure functions, no handle, no OS. */
#include "drivers/camera/camera_types.h"

/* The invariants camera_types.h states (C only: the header is also C++'s). */
_Static_assert(MFNS_CAM_E_COUNT_ == 20, "camera error codes are numbered in telemetry: append, never renumber");
_Static_assert(MFNS_CAM_MIN_BUFFERS <= MFNS_CAM_DEFAULT_BUFFERS && MFNS_CAM_DEFAULT_BUFFERS <= MFNS_CAM_MAX_BUFFERS,
               "the default buffer count must be a valid one");
_Static_assert((uint64_t)MFNS_CAM_MAX_DIM * MFNS_CAM_MAX_DIM * 2u <= UINT32_MAX,
               "a frame of MFNS_CAM_MAX_DIM^2 16-bit pixels must fit the uint32_t byte counts");

static const char *const g_err_names[MFNS_CAM_E_COUNT_] = {
    [MFNS_CAM_OK] = "ok",
    [MFNS_CAM_E_ARG] = "invalid argument",
    [MFNS_CAM_E_NO_SLOT] = "no free camera handle",
    [MFNS_CAM_E_BACKEND] = "camera backend not built into this program",
    [MFNS_CAM_E_OPEN] = "cannot open camera",
    [MFNS_CAM_E_NOT_CAPTURE] = "not a streaming video capture device",
    [MFNS_CAM_E_FORMAT] = "pixel format or size not supported",
    [MFNS_CAM_E_CONTROL] = "camera control unsupported or out of range",
    [MFNS_CAM_E_BUFFERS] = "too few capture buffers",
    [MFNS_CAM_E_MMAP] = "cannot map capture buffer",
    [MFNS_CAM_E_STREAM] = "cannot start or stop streaming",
    [MFNS_CAM_E_STATE] = "call not valid in this state",
    [MFNS_CAM_E_BUSY] = "all buffers held by the caller",
    [MFNS_CAM_E_TIMEOUT] = "timed out waiting for a frame",
    [MFNS_CAM_E_IO] = "camera I/O error",
    [MFNS_CAM_E_LOST] = "camera lost, recovering",
    [MFNS_CAM_E_NO_DEVICE] = "camera lost, recovery failed",
    [MFNS_CAM_E_NO_CAMERA] = "no such camera",
    [MFNS_CAM_E_END] = "end of recorded frames",
    [MFNS_CAM_E_DATA] = "malformed recorded frames",
};
_Static_assert(sizeof g_err_names / sizeof g_err_names[0] == MFNS_CAM_E_COUNT_, "one name per camera error code");

const char *mfns_cam_strerror(mfns_cam_err_t e)
{
    if ((unsigned)e >= (unsigned)MFNS_CAM_E_COUNT_) {
        return "unknown camera error";
    }
    return g_err_names[e];
}

const char *mfns_cam_pixfmt_name(mfns_cam_pixfmt_t f)
{
    switch (f) {
    case MFNS_CAM_PIX_ANY: return "ANY";
    case MFNS_CAM_PIX_GREY: return "GREY";
    case MFNS_CAM_PIX_Y10: return "Y10";
    case MFNS_CAM_PIX_Y12: return "Y12";
    case MFNS_CAM_PIX_Y16: return "Y16";
    case MFNS_CAM_PIX_COUNT_: break;
    }
    return "invalid";
}

uint32_t mfns_cam_pixfmt_bytes(mfns_cam_pixfmt_t f)
{
    switch (f) {
    case MFNS_CAM_PIX_GREY: return 1;
    case MFNS_CAM_PIX_Y10:
    case MFNS_CAM_PIX_Y12:
    case MFNS_CAM_PIX_Y16: return 2;
    case MFNS_CAM_PIX_ANY:
    case MFNS_CAM_PIX_COUNT_: break;
    }
    return 0;
}

