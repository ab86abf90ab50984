/* mfns-frame-feed -- the board test's camera stimulus (docs/operations.md "The
 * image"): streams rendered LED frames (8-bit PGM, `mfns sim nav`) into a vivid
 * instance's video output, which vivid's output-to-capture loop ("Loop Video")
 * hands to its capture node, where mfns-nav reads them through the kernel's
 * V4L2 driver. Never part of a flight configuration: rcS starts it only when
 * the board test's frames disk is attached.
 *
 * The loop carries frames only when the HDMI output and the HDMI input have the
 * same DV timings, format and field; so both get the DMT timings of the frame
 * size (1280 x 1024 p60, the paper's cameras) and GREY, progressive; vivid's
 * on-screen text (counters drawn over the top rows) is switched off. The
 * output then "displays" one buffer per frame period and gives it back; the
 * frames are queued in order, round and round.
 *
 * Usage: mfns-frame-feed CAPTURE OUTPUT FRAME.pgm...   (returns once streaming;
 * a background process feeds until killed) */
#define _DEFAULT_SOURCE /* O_CLOEXEC, MAP_SHARED, struct timespec under -std=c11 */

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>

#include <linux/v4l2-dv-timings.h>
#include <linux/videodev2.h>

#define WIDTH 1280u
#define HEIGHT 1024u
#define FRAME_BYTES ((size_t)WIDTH * HEIGHT)
#define MAX_FRAMES 16
#define NUM_BUFS 4u
#define OSD_NONE 2 /* vivid's "OSD Text Mode" menu: 0 all, 1 counters only, 2 none (text over the frame) */
#define CHECK_FRAMES 6     /* captured to check the loop */
#define CTRL_SCAN_MAX 512 /* controls enumerated to find "Loop Video" */

static int fail(const char *what, const char *dev)
{
    fprintf(stderr, "mfns-frame-feed: %s: %s: %s\n", dev, what, strerror(errno));
    return 1;
}

/* The next whitespace-separated number of a PGM header; -1 when there is none. */
static long pgm_number(FILE *f)
{
    char tok[16];
    size_t n = 0;
    int c = fgetc(f);
    while (c == ' ' || c == '\n' || c == '\r' || c == '\t') {
        c = fgetc(f);
    }
    while (c >= '0' && c <= '9' && n + 1u < sizeof tok) {
        tok[n++] = (char)c;
        c = fgetc(f);
    }
    tok[n] = '\0';
    return n > 0u ? strtol(tok, NULL, 10) : -1; /* c: the one whitespace byte before the pixels */
}

/* An 8-bit binary PGM of WIDTH x HEIGHT into buf (the header `mfns sim nav` writes). */
static int read_pgm(const char *path, unsigned char *buf)
{
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        fprintf(stderr, "mfns-frame-feed: %s: %s\n", path, strerror(errno));
        return -1;
    }
    const int c0 = fgetc(f);
    const int c1 = fgetc(f);
    const int magic = c0 == 'P' && c1 == '5';
    const long w = magic ? pgm_number(f) : -1;
    const long h = magic ? pgm_number(f) : -1;
    const long maxval = magic ? pgm_number(f) : -1;
    const int ok =
        w == (long)WIDTH && h == (long)HEIGHT && maxval == 255 && fread(buf, 1, FRAME_BYTES, f) == FRAME_BYTES;
    (void)fclose(f);
    if (!ok) {
        fprintf(stderr, "mfns-frame-feed: %s: not an 8-bit %ux%u PGM\n", path, WIDTH, HEIGHT);
        return -1;
    }
    return 0;
}

static int set_node(int fd, const char *dev, enum v4l2_buf_type type)
{
    struct v4l2_dv_timings t = V4L2_DV_BT_DMT_1280X1024P60;
    if (ioctl(fd, VIDIOC_S_DV_TIMINGS, &t) != 0) {
        return fail("VIDIOC_S_DV_TIMINGS 1280x1024p60", dev);
    }
    struct v4l2_format f;
    memset(&f, 0, sizeof f);
    f.type = type;
    f.fmt.pix.width = WIDTH;
    f.fmt.pix.height = HEIGHT;
    f.fmt.pix.pixelformat = V4L2_PIX_FMT_GREY;
    f.fmt.pix.field = V4L2_FIELD_NONE;
    if (ioctl(fd, VIDIOC_S_FMT, &f) != 0) {
        return fail("VIDIOC_S_FMT", dev);
    }
    if (f.fmt.pix.width != WIDTH || f.fmt.pix.height != HEIGHT || f.fmt.pix.pixelformat != V4L2_PIX_FMT_GREY ||
        f.fmt.pix.bytesperline != WIDTH) {
        fprintf(stderr, "mfns-frame-feed: %s: format %ux%u stride %u is not GREY %ux%u\n", dev, f.fmt.pix.width,
                f.fmt.pix.height, f.fmt.pix.bytesperline, WIDTH, HEIGHT);
        return 1;
    }
    return 0;
}

/* A vivid control on the capture node, found by name (vivid's ids are private). */
static int set_ctrl(int fd, const char *dev, const char *name, int value)
{
    struct v4l2_queryctrl q;
    memset(&q, 0, sizeof q);
    q.id = V4L2_CTRL_FLAG_NEXT_CTRL;
    for (int i = 0; i < CTRL_SCAN_MAX && ioctl(fd, VIDIOC_QUERYCTRL, &q) == 0; i++) {
        if (strcmp((const char *)q.name, name) == 0) {
            struct v4l2_control c = {.id = q.id, .value = value};
            return ioctl(fd, VIDIOC_S_CTRL, &c) == 0 ? 0 : fail(name, dev);
        }
        q.id |= V4L2_CTRL_FLAG_NEXT_CTRL;
    }
    fprintf(stderr, "mfns-frame-feed: %s: no \"%s\" control (not vivid?)\n", dev, name);
    return 1;
}

/* Does the loop carry the frames? One frame from the capture node (before the
 * flight program owns it) against the frames fed: the share of equal bytes in
 * the best match, on stderr ("loop carries the frames: ..." or "does NOT"). */
static void check_loop(int cap, const char *dev, const unsigned char *frames, int nframes)
{
    struct v4l2_requestbuffers rb = {.count = 2, .type = V4L2_BUF_TYPE_VIDEO_CAPTURE, .memory = V4L2_MEMORY_MMAP};
    if (ioctl(cap, VIDIOC_REQBUFS, &rb) != 0 || rb.count < 1u) {
        (void)fail("check: VIDIOC_REQBUFS", dev);
        return;
    }
    unsigned char *map[2] = {NULL, NULL};
    size_t len[2] = {0, 0};
    for (unsigned i = 0; i < rb.count && i < 2u; i++) {
        struct v4l2_buffer b = {.index = i, .type = V4L2_BUF_TYPE_VIDEO_CAPTURE, .memory = V4L2_MEMORY_MMAP};
        if (ioctl(cap, VIDIOC_QUERYBUF, &b) != 0) {
            (void)fail("check: VIDIOC_QUERYBUF", dev);
            return;
        }
        len[i] = b.length;
        map[i] = mmap(NULL, b.length, PROT_READ, MAP_SHARED, cap, b.m.offset);
        if (map[i] == MAP_FAILED || ioctl(cap, VIDIOC_QBUF, &b) != 0) {
            (void)fail("check: mmap/VIDIOC_QBUF", dev);
            return;
        }
    }
    enum v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    size_t best = 0;
    if (ioctl(cap, VIDIOC_STREAMON, &type) != 0) {
        (void)fail("check: VIDIOC_STREAMON", dev);
    }
    /* a few frames: the first may predate the output's first displayed frame */
    for (int n = 0; n < CHECK_FRAMES && best < FRAME_BYTES; n++) {
        struct v4l2_buffer b = {.type = V4L2_BUF_TYPE_VIDEO_CAPTURE, .memory = V4L2_MEMORY_MMAP};
        if (ioctl(cap, VIDIOC_DQBUF, &b) != 0 || b.index >= 2u) {
            (void)fail("check: VIDIOC_DQBUF", dev);
            break;
        }
        for (int k = 0; k < nframes && b.bytesused >= FRAME_BYTES; k++) {
            const unsigned char *f = frames + FRAME_BYTES * (size_t)k;
            size_t same = 0;
            for (size_t i = 0; i < FRAME_BYTES; i++) {
                same += map[b.index][i] == f[i];
            }
            best = same > best ? same : best;
        }
        (void)ioctl(cap, VIDIOC_QBUF, &b); /* back for the next one; a failure ends at the next DQBUF */
    }
    const double share = (double)best / (double)FRAME_BYTES;
    fprintf(stderr, "mfns-frame-feed: %s: loop %s the frames: %.4f of a captured frame's bytes equal a fed frame's\n",
            dev, share > 0.99 ? "carries" : "does NOT carry", share);
    (void)ioctl(cap, VIDIOC_STREAMOFF, &type);
    for (unsigned i = 0; i < 2u; i++) {
        if (map[i] != NULL && map[i] != MAP_FAILED) {
            (void)munmap(map[i], len[i]);
        }
    }
    struct v4l2_requestbuffers none = {.count = 0, .type = V4L2_BUF_TYPE_VIDEO_CAPTURE, .memory = V4L2_MEMORY_MMAP};
    (void)ioctl(cap, VIDIOC_REQBUFS, &none); /* free: the flight program sets its own */
}

int main(int argc, char **argv)
{
    if (argc < 4 || argc - 3 > MAX_FRAMES) {
        fprintf(stderr, "usage: mfns-frame-feed CAPTURE OUTPUT FRAME.pgm... (1..%d frames)\n", MAX_FRAMES);
        return 2;
    }
    static unsigned char frames[FRAME_BYTES * MAX_FRAMES]; /* a test tool's whole stimulus, loaded once */
    const int nframes = argc - 3;
    for (int i = 0; i < nframes; i++) {
        if (read_pgm(argv[3 + i], frames + FRAME_BYTES * (size_t)i) != 0) {
            return 1;
        }
    }
    const int cap = open(argv[1], O_RDWR | O_CLOEXEC);
    const int out = open(argv[2], O_RDWR | O_CLOEXEC);
    if (cap < 0 || out < 0) {
        return fail("open", cap < 0 ? argv[1] : argv[2]);
    }
    if (set_node(out, argv[2], V4L2_BUF_TYPE_VIDEO_OUTPUT) != 0 ||
        set_node(cap, argv[1], V4L2_BUF_TYPE_VIDEO_CAPTURE) != 0 || set_ctrl(cap, argv[1], "Loop Video", 1) != 0 ||
        set_ctrl(cap, argv[1], "OSD Text Mode", OSD_NONE) != 0) {
        return 1;
    }
    struct v4l2_requestbuffers rb = {.count = NUM_BUFS, .type = V4L2_BUF_TYPE_VIDEO_OUTPUT,
                                     .memory = V4L2_MEMORY_MMAP};
    if (ioctl(out, VIDIOC_REQBUFS, &rb) != 0 || rb.count < 2u) {
        return fail("VIDIOC_REQBUFS", argv[2]);
    }
    unsigned char *map[NUM_BUFS] = {NULL};
    int next = 0;
    for (unsigned i = 0; i < rb.count && i < NUM_BUFS; i++) {
        struct v4l2_buffer b = {.index = i, .type = V4L2_BUF_TYPE_VIDEO_OUTPUT, .memory = V4L2_MEMORY_MMAP};
        if (ioctl(out, VIDIOC_QUERYBUF, &b) != 0 || b.length < FRAME_BYTES) {
            return fail("VIDIOC_QUERYBUF", argv[2]);
        }
        map[i] = mmap(NULL, b.length, PROT_READ | PROT_WRITE, MAP_SHARED, out, b.m.offset);
        if (map[i] == MAP_FAILED) {
            return fail("mmap", argv[2]);
        }
        memcpy(map[i], frames + FRAME_BYTES * (size_t)next, FRAME_BYTES);
        next = (next + 1) % nframes;
        b.bytesused = (unsigned)FRAME_BYTES;
        b.field = V4L2_FIELD_NONE;
        if (ioctl(out, VIDIOC_QBUF, &b) != 0) {
            return fail("VIDIOC_QBUF", argv[2]);
        }
    }
    enum v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
    if (ioctl(out, VIDIOC_STREAMON, &type) != 0) {
        return fail("VIDIOC_STREAMON", argv[2]);
    }
    fprintf(stderr, "mfns-frame-feed: %s -> %s: %d frames, looped\n", argv[2], argv[1], nframes);
    check_loop(cap, argv[1], frames, nframes);
    /* set up: the caller (rcS) goes on, the feeding goes on in the background */
    const pid_t pid = fork();
    if (pid < 0) {
        return fail("fork", argv[2]);
    }
    if (pid > 0) {
        return 0;
    }
    for (;;) { /* until killed: the board test's stimulus */
        struct v4l2_buffer b = {.type = V4L2_BUF_TYPE_VIDEO_OUTPUT, .memory = V4L2_MEMORY_MMAP};
        if (ioctl(out, VIDIOC_DQBUF, &b) != 0) {
            if (errno == EINTR || errno == EAGAIN) {
                continue;
            }
            return fail("VIDIOC_DQBUF", argv[2]);
        }
        memcpy(map[b.index], frames + FRAME_BYTES * (size_t)next, FRAME_BYTES);
        next = (next + 1) % nframes;
        b.bytesused = (unsigned)FRAME_BYTES;
        b.field = V4L2_FIELD_NONE;
        if (ioctl(out, VIDIOC_QBUF, &b) != 0) {
            return fail("VIDIOC_QBUF", argv[2]);
        }
    }
}
