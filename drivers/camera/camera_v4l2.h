/* camera_v4l2.h -- the syscall seam of the V4L2 backend. Every system call the
 * backend makes goes through one of these, so tests can put a simulated device
 * behind it (tests/unit/support/fakev4l2_dev.h). Each function behaves like
 * the syscall it replaces: -1 (MAP_FAILED for mmap) with errno set on failure. */
#ifndef MFNS_DRIVERS_CAMERA_V4L2_H
#define MFNS_DRIVERS_CAMERA_V4L2_H

#include <poll.h>
#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

struct mfns_cam_sys {
    void *ctx; /* passed to every call */
    int (*open)(void *ctx, const char *path, int flags);
    int (*close)(void *ctx, int fd);
    int (*ioctl)(void *ctx, int fd, unsigned long request, void *arg);
    void *(*mmap)(void *ctx, size_t length, int prot, int flags, int fd, off_t offset);
    int (*munmap)(void *ctx, void *addr, size_t length);
    /* With nfds == 0 this is the backend's only way to sleep (waiting out a
     * timeout while a lost device is absent), so a fake can skip the wait. */
    int (*poll)(void *ctx, struct pollfd *fds, nfds_t nfds, int timeout_ms);
    /* CLOCK_MONOTONIC in ns: a frame's arrival time (at dequeue). */
    int64_t (*now_ns)(void *ctx);
};
typedef struct mfns_cam_sys mfns_cam_sys_t;

/* The real syscalls (what settings.sys == NULL selects). */
extern const mfns_cam_sys_t mfns_cam_sys_linux;

/* V4L2 control values used for the exposure setting: V4L2_CID_EXPOSURE_ABSOLUTE
 * counts 100 us units (videodev2 API), so exposure_us is rounded to that. */
#define MFNS_CAM_V4L2_EXPOSURE_UNIT_US 100

/* Most EINTR retries of one ioctl before it counts as an I/O error. */
#define MFNS_CAM_V4L2_MAX_EINTR 16
/* Most DQBUF attempts in one dequeue call (error frames, EAGAIN, EIO). */
#define MFNS_CAM_V4L2_MAX_DQ_TRIES 64

/* ---- a camera by stable identity (docs/operations.md "Configuration") ----
 * /dev/videoN numbering follows probe order and may change between boots, so
 * the board names its cameras by something that does not:
 *   "/dev/v4l/by-path/..." or "/dev/v4l/by-id/..." (udev's links), or any
 *       other path: used as given;
 *   "bus_info:TEXT"  the capture node whose VIDIOC_QUERYCAP bus_info is TEXT;
 *   "card:TEXT"      the capture node whose card name is TEXT.
 * A match is searched among /dev/video0 .. /dev/video<MFNS_CAM_V4L2_MAX_NODES-1>
 * through the seam (sys; NULL: the real syscalls), each opened, asked
 * VIDIOC_QUERYCAP and closed; only nodes whose device_caps (or capabilities)
 * include VIDEO_CAPTURE or VIDEO_CAPTURE_MPLANE count (vivid's output, VBI,
 * radio nodes share the capture node's bus_info). Exactly one node must match.
 * Returns 0 with the device path in path; -1 (nothing matches, or more than
 * one does, or the identity does not fit path_size) with the reason in msg.
 * Misses: a node that cannot be opened (busy, no permission) is skipped, so a
 * camera held by another program reads as absent; msg says how many failed. */
#define MFNS_CAM_V4L2_MAX_NODES 64
int mfns_cam_v4l2_resolve(const char *ident, const mfns_cam_sys_t *sys, char *path, size_t path_size, char *msg,
                          size_t msg_size);

#endif
