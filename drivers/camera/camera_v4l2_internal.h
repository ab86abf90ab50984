/* camera_v4l2_internal.h -- what the V4L2 backend's files share among
 * themselves; private to drivers/camera/camera_v4l2*.c. The backend's
 * contract is camera.h (through mfns_cam_v4l2_ops, camera_backend.h) and the
 * syscall seam camera_v4l2.h.
 *   camera_v4l2_sys.c     the real syscalls, the seam of a handle, the ioctl wrapper
 *   camera_v4l2_config.c  open, capabilities, format, rate, controls, buffers; teardown
 *   camera_v4l2.c         streaming, dequeue, loss and recovery, the backend operations
 */
#ifndef MFNS_DRIVERS_CAMERA_V4L2_INTERNAL_H
#define MFNS_DRIVERS_CAMERA_V4L2_INTERNAL_H

#include <linux/videodev2.h>
#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "drivers/camera/camera_backend.h"
#include "drivers/camera/camera_v4l2.h"

/* ---- the seam (camera_v4l2_sys.c) ---------------------------------------- */

/* The handle's syscalls: settings.sys, or the real ones when NULL. */
const mfns_cam_sys_t *mfns_cam_v4l2_sys(const mfns_cam_t *h);

/* ioctl on the handle's fd, retried on EINTR up to MFNS_CAM_V4L2_MAX_EINTR
 * times (counted in stats.eintr_retries); -1 with errno as the syscall. */
int mfns_cam_v4l2_xioctl(mfns_cam_t *h, unsigned long request, void *arg);

static inline bool mfns_cam_v4l2_is_mplane(const mfns_cam_v4l2_t *v)
{
    return v->buf_type == V4L2_BUF_TYPE_VIDEO_CAPTURE_MPLANE;
}

/* A zeroed mmap buffer descriptor of the handle's type for buffer `index`;
 * on a multi-planar device it points at `planes` (zeroed, VIDEO_MAX_PLANES
 * of them) and announces n_planes of them. */
static inline void mfns_cam_v4l2_buffer_init(const mfns_cam_v4l2_t *v, struct v4l2_buffer *b,
                                             struct v4l2_plane planes[VIDEO_MAX_PLANES], uint32_t index,
                                             uint32_t n_planes)
{
    memset(b, 0, sizeof *b);
    memset(planes, 0, VIDEO_MAX_PLANES * sizeof planes[0]);
    b->type = v->buf_type;
    b->memory = V4L2_MEMORY_MMAP;
    b->index = index;
    if (mfns_cam_v4l2_is_mplane(v)) {
        b->m.planes = planes;
        b->length = n_planes;
    }
}

/* ---- configuring and releasing (camera_v4l2_config.c) -------------------- */

/* open .. mmap: capabilities, format (checked against what the driver
 * granted), frame rate, controls, buffers. On an error the caller tears down;
 * MFNS_CAM_E_LOST when the device vanished meanwhile. */
mfns_cam_err_t mfns_cam_v4l2_configure(mfns_cam_t *h);

/* Exposure (rounded to MFNS_CAM_V4L2_EXPOSURE_UNIT_US; manual mode first) and
 * gain; a negative value leaves that control alone. */
mfns_cam_err_t mfns_cam_v4l2_apply_controls(mfns_cam_t *h, int32_t exposure_us, int32_t gain);

/* Marks every buffer as not held by the caller. */
void mfns_cam_v4l2_clear_held(mfns_cam_v4l2_t *v);
/* Unmaps every buffer (except the caller's held ones when keep_held). */
void mfns_cam_v4l2_unmap_all(mfns_cam_t *h, bool keep_held);
/* Closes the fd if open. */
void mfns_cam_v4l2_close_fd(mfns_cam_t *h);
/* Undoes a partial or full configure: mappings, driver buffers, fd. */
void mfns_cam_v4l2_teardown(mfns_cam_t *h);

#endif
