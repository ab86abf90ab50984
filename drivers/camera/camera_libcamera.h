/* camera_libcamera.h -- C-callable shim over the libcamera backend
 * (camera_libcamera.cpp, C++17). Compiled only where pkg-config finds
 * libcamera (the Makefile then defines MFNS_HAVE_LIBCAMERA=1 for C files);
 * camera.c builds the backend's ops table from these functions, so the flight
 * program selects libcamera with settings.backend = MFNS_CAM_BACKEND_LIBCAMERA
 * and never calls them directly.
 *
 * Semantics are those of camera.h. libcamera specifics:
 *   - settings.path is a libcamera camera id; "" takes the first camera.
 *     No camera (or no camera with that id) gives MFNS_CAM_E_NO_CAMERA.
 *   - a Raw stream is configured (Viewfinder where the pipeline has no Raw
 *     role), formats GREY/Y10/Y12 map to libcamera R8/R10/R12; libcamera
 *     0.0.3 has no 16-bit mono format, so Y16 gives MFNS_CAM_E_FORMAT.
 *   - exposure_us sets ExposureTime, gain sets AnalogueGain = gain / 100,
 *     frame_rate_hz sets FrameDurationLimits; a control the camera lacks gives
 *     MFNS_CAM_E_CONTROL.
 *   - libcamera allocates internally while streaming (requests, signals);
 *     the backend itself allocates only at open.
 *   - one CameraManager per process (a libcamera rule) is shared by all
 *     libcamera handles and stopped when the last one closes. */
#ifndef MFNS_DRIVERS_CAMERA_LIBCAMERA_H
#define MFNS_DRIVERS_CAMERA_LIBCAMERA_H

#include "drivers/camera/camera_types.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Cameras libcamera can see (starts a CameraManager if none runs); -1 when
 * the CameraManager cannot start. */
int mfns_lcam_camera_count(void);

mfns_cam_err_t mfns_lcam_open(mfns_cam_t *h);
mfns_cam_err_t mfns_lcam_start(mfns_cam_t *h);
mfns_cam_err_t mfns_lcam_dequeue(mfns_cam_t *h, mfns_cam_frame_t *f, int timeout_ms);
mfns_cam_err_t mfns_lcam_requeue(mfns_cam_t *h, const mfns_cam_frame_t *f);
mfns_cam_err_t mfns_lcam_stop(mfns_cam_t *h);
void mfns_lcam_close(mfns_cam_t *h);
mfns_cam_err_t mfns_lcam_set_controls(mfns_cam_t *h, int32_t exposure_us, int32_t gain);

#ifdef __cplusplus
}
#endif

#endif
