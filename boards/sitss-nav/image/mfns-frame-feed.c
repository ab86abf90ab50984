/* mfns-frame-feed -- the board test's camera rig (docs/operations.md "The
 * image"): one trigger for the three cameras. Rendered LED frames (8-bit PGM,
 * `mfns sim nav`) are written into v4l2loopback devices, one per camera, all of
 * them at each tick of one CLOCK_MONOTONIC timer, every buffer stamped with that
 * tick. mfns-nav reads the devices' capture side through the kernel's V4L2 path
 * and sees the cameras exposed at the same instant with the same stamp, as the
 * flight board's hardware trigger will make them (vivid cannot: its three
 * instances run free and stamp each frame when their kernel thread wakes, in
 * jiffies, which TCG delays by up to half a 60 Hz period).
 *
 * The frames go forward and back (0 .. n-1 .. 1, round and round), so the
 * looped flight has no jump back to its start. Before the feeding goes to the
 * background, one frame is captured from each device and compared with what
 * was written ("rig: DEV carries the frames: SHARE" on stderr).
 *
 * Never part of a flight configuration: rcS starts it only when the board
 * test's frames disk is attached.
 *
 * Usage: mfns-frame-feed PERIOD_US N DEV_1 .. DEV_N FRAME.pgm...
 *   the frames camera by camera, the same number for each (1..MAX_FRAMES);
 *   returns once streaming, a background process feeds until killed. */
#define _DEFAULT_SOURCE /* O_CLOEXEC, MAP_SHARED, clock_nanosleep under -std=c11 */

#include <errno.h>
#include <sched.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>

#include <linux/videodev2.h>

#define WIDTH 1280u
#define HEIGHT 1024u
#define FRAME_BYTES ((size_t)WIDTH * HEIGHT)
#define MAX_CAMS 3
#define MAX_FRAMES 16
#define NUM_BUFS 4u            /* the device's ring: a reader holding a frame has 3 periods before it is rewritten */
#define PERIOD_US_MIN 1000L
#define PERIOD_US_MAX 1000000L
#define NS_PER_US 1000L
#define NS_PER_S 1000000000L
#define RIG_RT_PRIO 60         /* above the flight program's SCHED_FIFO 50 */
#define LATE_PERIODS 2         /* behind by more: the ticks restart from now (no burst of stale stamps) */

typedef struct {
    const char *dev;
    int fd;
    unsigned char *map[NUM_BUFS];
    unsigned nbuf;
} rig_cam_t;

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

/* The output side: GREY WIDTH x HEIGHT, NUM_BUFS mmap buffers, streaming. */
static int open_output(rig_cam_t *c)
{
    c->fd = open(c->dev, O_RDWR | O_CLOEXEC);
    if (c->fd < 0) {
        return fail("open", c->dev);
    }
    struct v4l2_format f;
    memset(&f, 0, sizeof f);
    f.type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
    f.fmt.pix.width = WIDTH;
    f.fmt.pix.height = HEIGHT;
    f.fmt.pix.pixelformat = V4L2_PIX_FMT_GREY;
    f.fmt.pix.field = V4L2_FIELD_NONE;
    f.fmt.pix.bytesperline = WIDTH;
    f.fmt.pix.sizeimage = (unsigned)FRAME_BYTES;
    if (ioctl(c->fd, VIDIOC_S_FMT, &f) != 0) {
        return fail("VIDIOC_S_FMT (output)", c->dev);
    }
    if (f.fmt.pix.width != WIDTH || f.fmt.pix.height != HEIGHT || f.fmt.pix.pixelformat != V4L2_PIX_FMT_GREY) {
        fprintf(stderr, "mfns-frame-feed: %s: format %ux%u is not GREY %ux%u\n", c->dev, f.fmt.pix.width,
                f.fmt.pix.height, WIDTH, HEIGHT);
        return 1;
    }
    struct v4l2_requestbuffers rb = {.count = NUM_BUFS, .type = V4L2_BUF_TYPE_VIDEO_OUTPUT,
                                     .memory = V4L2_MEMORY_MMAP};
    if (ioctl(c->fd, VIDIOC_REQBUFS, &rb) != 0 || rb.count < 2u) {
        return fail("VIDIOC_REQBUFS (output)", c->dev);
    }
    c->nbuf = rb.count < NUM_BUFS ? rb.count : NUM_BUFS;
    for (unsigned i = 0; i < c->nbuf; i++) {
        struct v4l2_buffer b = {.index = i, .type = V4L2_BUF_TYPE_VIDEO_OUTPUT, .memory = V4L2_MEMORY_MMAP};
        if (ioctl(c->fd, VIDIOC_QUERYBUF, &b) != 0 || b.length < FRAME_BYTES) {
            return fail("VIDIOC_QUERYBUF (output)", c->dev);
        }
        c->map[i] = mmap(NULL, b.length, PROT_READ | PROT_WRITE, MAP_SHARED, c->fd, b.m.offset);
        if (c->map[i] == MAP_FAILED) {
            return fail("mmap (output)", c->dev);
        }
    }
    enum v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
    return ioctl(c->fd, VIDIOC_STREAMON, &type) == 0 ? 0 : fail("VIDIOC_STREAMON (output)", c->dev);
}

/* One frame into buffer `slot` of camera c, stamped t. */
static int write_frame(rig_cam_t *c, unsigned slot, const unsigned char *frame, const struct timespec *t)
{
    memcpy(c->map[slot], frame, FRAME_BYTES);
    struct v4l2_buffer b = {.index = slot, .type = V4L2_BUF_TYPE_VIDEO_OUTPUT, .memory = V4L2_MEMORY_MMAP};
    b.bytesused = (unsigned)FRAME_BYTES;
    b.field = V4L2_FIELD_NONE;
    b.timestamp.tv_sec = t->tv_sec;
    b.timestamp.tv_usec = t->tv_nsec / NS_PER_US;
    if (ioctl(c->fd, VIDIOC_QBUF, &b) != 0) {
        return fail("VIDIOC_QBUF (output)", c->dev);
    }
    struct v4l2_buffer d = {.type = V4L2_BUF_TYPE_VIDEO_OUTPUT, .memory = V4L2_MEMORY_MMAP};
    return ioctl(c->fd, VIDIOC_DQBUF, &d) == 0 ? 0 : fail("VIDIOC_DQBUF (output)", c->dev);
}

/* Does the device hand over what was written? One frame from its capture side
 * (a second opener, before the flight program owns it; non-blocking: the frame
 * written before is there or the check says it is not) against `frame`. */
static void check_capture(const rig_cam_t *c, const unsigned char *frame)
{
    const int cap = open(c->dev, O_RDWR | O_NONBLOCK | O_CLOEXEC);
    struct v4l2_requestbuffers rb = {.count = NUM_BUFS, .type = V4L2_BUF_TYPE_VIDEO_CAPTURE, .memory = V4L2_MEMORY_MMAP};
    unsigned char *map[NUM_BUFS] = {NULL};
    size_t len[NUM_BUFS] = {0};
    const char *step = cap < 0 ? "open" : ioctl(cap, VIDIOC_REQBUFS, &rb) != 0 || rb.count < 1u ? "VIDIOC_REQBUFS" : NULL;
    const unsigned nb = step == NULL ? (rb.count < NUM_BUFS ? rb.count : NUM_BUFS) : 0u;
    for (unsigned i = 0; i < nb && step == NULL; i++) { /* v4l2loopback hands over mapped buffers only */
        struct v4l2_buffer b = {.index = i, .type = V4L2_BUF_TYPE_VIDEO_CAPTURE, .memory = V4L2_MEMORY_MMAP};
        if (ioctl(cap, VIDIOC_QUERYBUF, &b) != 0) {
            step = "VIDIOC_QUERYBUF";
        } else if ((map[i] = mmap(NULL, b.length, PROT_READ, MAP_SHARED, cap, b.m.offset)) == MAP_FAILED) {
            map[i] = NULL;
            step = "mmap";
        } else if (ioctl(cap, VIDIOC_QBUF, &b) != 0) {
            step = "VIDIOC_QBUF";
        }
        len[i] = b.length;
    }
    enum v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    struct v4l2_buffer d = {.type = V4L2_BUF_TYPE_VIDEO_CAPTURE, .memory = V4L2_MEMORY_MMAP};
    if (step == NULL) {
        step = ioctl(cap, VIDIOC_STREAMON, &type) != 0 ? "VIDIOC_STREAMON"
               : ioctl(cap, VIDIOC_DQBUF, &d) != 0 || d.index >= nb || map[d.index] == NULL ? "VIDIOC_DQBUF"
                                                                                              : NULL;
    }
    size_t same = 0;
    if (step != NULL) {
        (void)fail(step, c->dev);
    } else {
        for (size_t i = 0; i < FRAME_BYTES && d.bytesused >= FRAME_BYTES; i++) {
            same += map[d.index][i] == frame[i];
        }
    }
    for (unsigned i = 0; i < nb; i++) {
        if (map[i] != NULL) {
            (void)munmap(map[i], len[i]);
        }
    }
    const double share = (double)same / (double)FRAME_BYTES;
    fprintf(stderr, "mfns-frame-feed: rig: %s %s the frames: %.4f of a captured frame's bytes equal the written one's\n",
            c->dev, share > 0.99 ? "carries" : "does NOT carry", share);
    if (cap >= 0) {
        (void)close(cap); /* its buffers go with it: the flight program sets its own */
    }
}

/* Frame index of tick k: forward and back over n frames. */
static int pingpong(unsigned long k, int n)
{
    if (n <= 1) {
        return 0;
    }
    const unsigned long span = 2ul * (unsigned long)(n - 1);
    const int p = (int)(k % span);
    return p < n ? p : (int)span - p;
}

static void add_ns(struct timespec *t, long ns)
{
    t->tv_nsec += ns;
    while (t->tv_nsec >= NS_PER_S) {
        t->tv_nsec -= NS_PER_S;
        t->tv_sec++;
    }
}

int main(int argc, char **argv)
{
    char *end = NULL;
    const long period_us = argc > 2 ? strtol(argv[1], &end, 10) : 0;
    const long ncam = argc > 2 ? strtol(argv[2], NULL, 10) : 0;
    const long nfiles = argc - 3 - ncam;
    if (argc < 5 || end == argv[1] || *end != '\0' || period_us < PERIOD_US_MIN || period_us > PERIOD_US_MAX ||
        ncam < 1 || ncam > MAX_CAMS || nfiles < ncam || nfiles % ncam != 0 || nfiles / ncam > MAX_FRAMES) {
        fprintf(stderr, "usage: mfns-frame-feed PERIOD_US N DEV_1..DEV_N FRAME.pgm... (period %ld..%ld us, N 1..%d, "
                        "the same 1..%d frames per camera, camera by camera)\n",
                PERIOD_US_MIN, PERIOD_US_MAX, MAX_CAMS, MAX_FRAMES);
        return 2;
    }
    const int n = (int)(nfiles / ncam);
    /* the whole stimulus, loaded once before streaming (a test tool, not flight code) */
    unsigned char *frames = calloc((size_t)nfiles, FRAME_BYTES);
    if (frames == NULL) {
        fprintf(stderr, "mfns-frame-feed: no memory for %ld frames\n", nfiles);
        return 1;
    }
    for (long i = 0; i < nfiles; i++) {
        if (read_pgm(argv[3 + ncam + i], frames + FRAME_BYTES * (size_t)i) != 0) {
            free(frames);
            return 1;
        }
    }
    rig_cam_t cams[MAX_CAMS];
    memset(cams, 0, sizeof cams);
    struct timespec t;
    (void)clock_gettime(CLOCK_MONOTONIC, &t);
    for (int c = 0; c < ncam; c++) {
        cams[c].dev = argv[3 + c];
        if (open_output(&cams[c]) != 0 ||
            write_frame(&cams[c], 0, frames + FRAME_BYTES * (size_t)(c * n), &t) != 0) {
            free(frames);
            return 1;
        }
    }
    for (int c = 0; c < ncam; c++) {
        check_capture(&cams[c], frames + FRAME_BYTES * (size_t)(c * n));
    }
    fprintf(stderr, "mfns-frame-feed: rig: %ld cameras, %d frames each forward and back, one stamp for all every %ld us\n",
            ncam, n, period_us);
    const pid_t pid = fork();
    if (pid != 0) {
        free(frames); /* the parent's copy: the feeding goes on in the child */
        return pid < 0 ? fail("fork", "rig") : 0;
    }
    /* the trigger keeps time whatever the flight program (SCHED_FIFO 50) does, as a hardware one */
    const struct sched_param sp = {.sched_priority = RIG_RT_PRIO};
    if (sched_setscheduler(0, SCHED_FIFO, &sp) != 0) {
        (void)fail("sched_setscheduler SCHED_FIFO", "rig");
    }
    (void)clock_gettime(CLOCK_MONOTONIC, &t);
    for (unsigned long k = 1;; k++) { /* until killed: the board test's stimulus */
        add_ns(&t, period_us * NS_PER_US);
        while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &t, NULL) == EINTR) {
        }
        struct timespec now;
        (void)clock_gettime(CLOCK_MONOTONIC, &now);
        const long long late_ns = (long long)(now.tv_sec - t.tv_sec) * NS_PER_S + (now.tv_nsec - t.tv_nsec);
        if (late_ns > (long long)LATE_PERIODS * period_us * NS_PER_US) {
            t = now; /* far behind (the guest was busy): this tick is now */
        }
        const int idx = pingpong(k, n);
        for (int c = 0; c < ncam; c++) {
            if (write_frame(&cams[c], (unsigned)(k % cams[c].nbuf), frames + FRAME_BYTES * (size_t)(c * n + idx),
                            &t) != 0) {
                free(frames);
                return 1;
            }
        }
    }
}
