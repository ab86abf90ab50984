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

#include <stddef.h>
#include <stdint.h>

#include "drivers/camera/camera_types.h" /* the types, codes and their names */

#ifdef __cplusplus
extern "C" {
#endif

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

/* Detail of the handle's last failure ("" if none); never NULL. */
const char *mfns_cam_message(const mfns_cam_t *h);

#ifdef __cplusplus
}
#endif

#endif
