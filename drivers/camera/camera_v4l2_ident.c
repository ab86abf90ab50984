/* camera_v4l2_ident.c -- a V4L2 camera by stable identity (camera_v4l2.h,
 * mfns_cam_v4l2_resolve): identity lookup only, through the backend's seam. */
#ifndef _DEFAULT_SOURCE
#define _DEFAULT_SOURCE 1
#endif
#include <errno.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#include "drivers/camera/camera_v4l2.h"

#define BUS_PREFIX "bus_info:"
#define CARD_PREFIX "card:"

static bool starts_with(const char *s, const char *prefix)
{
    return strncmp(s, prefix, strlen(prefix)) == 0;
}

/* The NUL-bounded copy of a QUERYCAP text field (the kernel NUL-terminates,
 * a fake or a broken driver might not). */
static void cap_text(char *dst, const uint8_t *src, size_t n)
{
    size_t i = 0;
    for (; i + 1 < n && src[i] != 0u; i++) {
        dst[i] = (char)src[i];
    }
    dst[i] = '\0';
}

int mfns_cam_v4l2_resolve(const char *ident, const mfns_cam_sys_t *sys, char *path, size_t path_size, char *msg,
                          size_t msg_size)
{
    if (ident == NULL || path == NULL || path_size == 0 || msg == NULL || msg_size == 0) {
        return -1;
    }
    msg[0] = '\0';
    const bool by_bus = starts_with(ident, BUS_PREFIX);
    const bool by_card = starts_with(ident, CARD_PREFIX);
    if (!by_bus && !by_card) { /* a path: used as given */
        if (strlen(ident) >= path_size) {
            (void)snprintf(msg, msg_size, "camera path too long (%zu characters)", strlen(ident));
            return -1;
        }
        (void)snprintf(path, path_size, "%s", ident);
        return 0;
    }
    const char *want = ident + strlen(by_bus ? BUS_PREFIX : CARD_PREFIX);
    if (want[0] == '\0') {
        (void)snprintf(msg, msg_size, "'%s': nothing to match", ident);
        return -1;
    }
    if (sys == NULL) {
        sys = &mfns_cam_sys_linux;
    }
    int matches = 0, failed = 0;
    char found[32] = "";
    for (int n = 0; n < MFNS_CAM_V4L2_MAX_NODES; n++) {
        char node[32];
        (void)snprintf(node, sizeof node, "/dev/video%d", n);
        const int fd = sys->open(sys->ctx, node, O_RDWR | O_NONBLOCK | O_CLOEXEC);
        if (fd < 0) {
            failed += errno != ENOENT && errno != ENODEV && errno != ENXIO;
            continue;
        }
        struct v4l2_capability cap;
        memset(&cap, 0, sizeof cap);
        const int r = sys->ioctl(sys->ctx, fd, VIDIOC_QUERYCAP, &cap);
        (void)sys->close(sys->ctx, fd); /* only asked; a close error changes nothing we read */
        if (r != 0) {
            failed++;
            continue;
        }
        const uint32_t caps =
            (cap.capabilities & V4L2_CAP_DEVICE_CAPS) != 0u ? cap.device_caps : cap.capabilities;
        if ((caps & (V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_VIDEO_CAPTURE_MPLANE)) == 0u) {
            continue;
        }
        char text[sizeof cap.bus_info > sizeof cap.card ? sizeof cap.bus_info : sizeof cap.card];
        if (by_bus) {
            cap_text(text, cap.bus_info, sizeof cap.bus_info);
        } else {
            cap_text(text, cap.card, sizeof cap.card);
        }
        if (strcmp(text, want) == 0) {
            if (matches++ == 0) {
                (void)snprintf(found, sizeof found, "%s", node);
            }
        }
    }
    if (matches == 1) {
        if (strlen(found) >= path_size) {
            (void)snprintf(msg, msg_size, "'%s' is %s: longer than the path buffer", ident, found);
            return -1;
        }
        (void)snprintf(path, path_size, "%s", found);
        return 0;
    }
    if (matches > 1) {
        (void)snprintf(msg, msg_size, "'%s' matches %d capture nodes (first %s): name it by bus_info or by-path",
                       ident, matches, found);
    } else {
        (void)snprintf(msg, msg_size, "no capture node among /dev/video0..%d has %s '%s'%s", MFNS_CAM_V4L2_MAX_NODES - 1,
                       by_bus ? "bus_info" : "card", want, failed > 0 ? " (some nodes could not be asked)" : "");
    }
    return -1;
}
