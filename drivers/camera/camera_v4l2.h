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

#endif
