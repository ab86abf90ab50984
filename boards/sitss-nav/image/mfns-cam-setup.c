/* mfns-cam-setup -- the image's camera bring-up (docs/operations.md "The
 * image"): puts a V4L2 capture node in the format the flight program flies,
 * as a board's bring-up configures its sensors before the service starts
 * (media-ctl/v4l2-ctl on a real board; busybox has neither, so this is the
 * one ioctl they would make). The flight driver (drivers/camera/camera_v4l2*)
 * then sets the table's size and checks the format; it keeps a monochrome
 * format the device already has and refuses a colour one.
 *
 * Usage: mfns-cam-setup DEVICE WIDTH HEIGHT   (VIDIOC_S_FMT, GREY, progressive)
 * Exit 0 when the device took exactly that format, 1 otherwise (one line on
 * stderr naming what it gave instead). */
#define _DEFAULT_SOURCE /* O_CLOEXEC, struct timespec for videodev2.h under -std=c11 */
#define _POSIX_C_SOURCE 200809L

#include <errno.h>
#include <fcntl.h>
#include <time.h>
#include <linux/videodev2.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <unistd.h>

#define MAX_SIDE 8192u /* larger than any sensor of the board */

static int parse_side(const char *s, __u32 *out)
{
    char *end = NULL;
    const unsigned long v = strtoul(s, &end, 10);
    if (end == s || *end != '\0' || v == 0u || v > MAX_SIDE) {
        return -1;
    }
    *out = (__u32)v;
    return 0;
}

int main(int argc, char **argv)
{
    __u32 w = 0, h = 0;
    if (argc != 4 || parse_side(argv[2], &w) != 0 || parse_side(argv[3], &h) != 0) {
        fprintf(stderr, "usage: mfns-cam-setup DEVICE WIDTH HEIGHT (1..%u)\n", MAX_SIDE);
        return 2;
    }
    const int fd = open(argv[1], O_RDWR | O_CLOEXEC);
    if (fd < 0) {
        fprintf(stderr, "mfns-cam-setup: %s: %s\n", argv[1], strerror(errno));
        return 1;
    }
    struct v4l2_format f;
    memset(&f, 0, sizeof f);
    f.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    f.fmt.pix.width = w;
    f.fmt.pix.height = h;
    f.fmt.pix.pixelformat = V4L2_PIX_FMT_GREY;
    f.fmt.pix.field = V4L2_FIELD_NONE;
    int rc = 0;
    if (ioctl(fd, VIDIOC_S_FMT, &f) != 0) {
        fprintf(stderr, "mfns-cam-setup: %s: VIDIOC_S_FMT: %s\n", argv[1], strerror(errno));
        rc = 1;
    } else if (f.fmt.pix.width != w || f.fmt.pix.height != h || f.fmt.pix.pixelformat != V4L2_PIX_FMT_GREY ||
               f.fmt.pix.field != V4L2_FIELD_NONE) {
        fprintf(stderr, "mfns-cam-setup: %s: asked GREY %ux%u progressive, got %.4s %ux%u field %u\n", argv[1], w, h,
                (const char *)&f.fmt.pix.pixelformat, f.fmt.pix.width, f.fmt.pix.height, f.fmt.pix.field);
        rc = 1;
    }
    (void)close(fd);
    return rc;
}
