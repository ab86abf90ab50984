/* camera_v4l2_sys.c -- the V4L2 backend's syscall seam (camera_v4l2.h): the
 * real syscalls behind mfns_cam_sys_linux, the seam a handle uses, and the
 * ioctl wrapper every V4L2 call of the backend goes through (retried on
 * EINTR, as the kernel's capture example does). */
#ifndef _DEFAULT_SOURCE
#define _DEFAULT_SOURCE 1
#endif
#include "drivers/camera/camera_v4l2.h"

#include <errno.h>
#include <fcntl.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include "drivers/camera/camera_backend.h"
#include "drivers/camera/camera_v4l2_internal.h"

/* ---- the real syscalls ------------------------------------------------- */
static int sys_open(void *ctx, const char *path, int flags)
{
    (void)ctx;
    return open(path, flags);
}
static int sys_close(void *ctx, int fd)
{
    (void)ctx;
    return close(fd);
}
static int sys_ioctl(void *ctx, int fd, unsigned long request, void *arg)
{
    (void)ctx;
    return ioctl(fd, request, arg);
}
static void *sys_mmap(void *ctx, size_t length, int prot, int flags, int fd, off_t offset)
{
    (void)ctx;
    return mmap(NULL, length, prot, flags, fd, offset);
}
static int sys_munmap(void *ctx, void *addr, size_t length)
{
    (void)ctx;
    return munmap(addr, length);
}
static int sys_poll(void *ctx, struct pollfd *fds, nfds_t nfds, int timeout_ms)
{
    (void)ctx;
    return poll(fds, nfds, timeout_ms);
}

static int64_t sys_now_ns(void *ctx)
{
    (void)ctx;
    return mfns_cam_now_ns();
}

const mfns_cam_sys_t mfns_cam_sys_linux = {NULL,      sys_open, sys_close, sys_ioctl, sys_mmap,
                                           sys_munmap, sys_poll, sys_now_ns};

const mfns_cam_sys_t *mfns_cam_v4l2_sys(const mfns_cam_t *h)
{
    return h->s.sys ? h->s.sys : &mfns_cam_sys_linux;
}

/* ---- the seam of a handle, and the ioctl wrapper ---------------------- */
int mfns_cam_v4l2_xioctl(mfns_cam_t *h, unsigned long request, void *arg)
{
    const mfns_cam_sys_t *sys = mfns_cam_v4l2_sys(h);
    for (int i = 0; i <= MFNS_CAM_V4L2_MAX_EINTR; i++) {
        const int r = sys->ioctl(sys->ctx, h->b.v4l2.fd, request, arg);
        if (r != -1 || errno != EINTR) {
            return r;
        }
        h->stats.eintr_retries++;
    }
    errno = EINTR;
    return -1;
}
