/* Unit tests of the V4L2 camera backend, end to end against the simulated
 * device behind the syscall seam (support/fakev4l2_dev.h): the whole ioctl
 * sequence for single- and multi-planar devices, every format, controls, and
 * each error path (EINTR, EAGAIN + poll timeout, error-flagged and short
 * buffers, sequence gaps, mmap failure, fewer buffers, unsupported format and
 * control, ENODEV with and without the device coming back). */
#ifndef _DEFAULT_SOURCE
#define _DEFAULT_SOURCE 1
#endif
#include "tests/unit/support/testutil.h"

#include <linux/videodev2.h>
#include <string.h>

#include "drivers/camera/camera.h"
#include "drivers/camera/camera_v4l2.h"
#include "tests/unit/support/fakev4l2_dev.h"

typedef struct {
    fakev4l2_dev_t dev;
    mfns_cam_sys_t sys;
    mfns_cam_settings_t s;
    mfns_cam_t *cam;
} fixture_t;

static fixture_t g_fx;

static int setup(void **state)
{
    fixture_t *fx = &g_fx;
    memset(fx, 0, sizeof *fx);
    fakev4l2_init(&fx->dev);
    fx->sys = fakev4l2_sys(&fx->dev);
    fx->s = mfns_cam_default_settings(MFNS_CAM_BACKEND_V4L2, "/dev/video0");
    fx->s.sys = &fx->sys;
    fx->s.width = 64;
    fx->s.height = 48;
    fx->s.pixfmt = MFNS_CAM_PIX_GREY;
    fx->s.buffer_count = 4;
    fx->s.exposure_us = 2000;
    fx->s.gain = 100;
    fx->s.frame_rate_hz = 18.6f;
    fx->s.recover_attempts = 5;
    *state = fx;
    return 0;
}

/* Whatever a test did, closing leaves no fd, mapping or bad munmap behind. */
static int teardown(void **state)
{
    fixture_t *fx = *state;
    mfns_cam_close(fx->cam);
    fx->cam = NULL;
    const int fds = fx->dev.open_fds, maps = fx->dev.live_mappings, bad = fx->dev.bad_munmaps;
    fakev4l2_free(&fx->dev);
    assert_int_equal(fds, 0);
    assert_int_equal(maps, 0);
    assert_int_equal(bad, 0);
    return 0;
}

static mfns_cam_err_t open_fx(fixture_t *fx, char *msg, size_t n)
{
    return mfns_cam_open(&fx->s, &fx->cam, msg, n);
}

static void open_start(fixture_t *fx)
{
    char msg[MFNS_CAM_MSG_LEN];
    assert_int_equal(open_fx(fx, msg, sizeof msg), MFNS_CAM_OK);
    assert_int_equal(mfns_cam_start(fx->cam), MFNS_CAM_OK);
}

/* Dequeues one frame, checks it against the simulated pixel pattern, requeues. */
static mfns_cam_frame_t cycle(fixture_t *fx)
{
    mfns_cam_frame_t f;
    const mfns_cam_err_t e = mfns_cam_dequeue(fx->cam, &f, 100);
    if (e != MFNS_CAM_OK) {
        print_error("dequeue: %s: %s\n", mfns_cam_strerror(e), mfns_cam_message(fx->cam));
    }
    assert_int_equal(e, MFNS_CAM_OK);
    const uint8_t *p = f.data;
    assert_int_equal(p[0], (uint8_t)f.sequence);
    assert_int_equal(p[f.stride], (uint8_t)(f.sequence + 1u));                 /* row 1 starts a stride later */
    assert_int_equal(p[(size_t)f.stride * (f.height - 1u) + 3u], (uint8_t)(f.sequence + f.height - 1u + 3u));
    assert_int_equal(mfns_cam_requeue(fx->cam, &f), MFNS_CAM_OK);
    return f;
}

static bool msg_has(const fixture_t *fx, const char *msg, const char *needle)
{
    (void)fx;
    if (strstr(msg, needle) == NULL) {
        print_error("message \"%s\" lacks \"%s\"\n", msg, needle);
        return false;
    }
    return true;
}

static void test_single_planar_full_sequence(void **state)
{
    fixture_t *fx = *state;
    open_start(fx);
    const fakev4l2_dev_t *d = &fx->dev;
    /* configuration order: caps, format, rate, controls, buffers, mappings, queue, stream */
    const int i_cap = fakev4l2_find(d, VIDIOC_QUERYCAP, 0);
    const int i_gfmt = fakev4l2_find(d, VIDIOC_G_FMT, i_cap);
    const int i_sfmt = fakev4l2_find(d, VIDIOC_S_FMT, i_gfmt);
    const int i_parm = fakev4l2_find(d, VIDIOC_S_PARM, i_sfmt);
    const int i_ctrl = fakev4l2_find(d, VIDIOC_S_CTRL, i_parm);
    const int i_req = fakev4l2_find(d, VIDIOC_REQBUFS, i_ctrl);
    const int i_qry = fakev4l2_find(d, VIDIOC_QUERYBUF, i_req);
    const int i_qbuf = fakev4l2_find(d, VIDIOC_QBUF, i_qry);
    const int i_on = fakev4l2_find(d, VIDIOC_STREAMON, i_qbuf);
    assert_int_equal(i_cap, 0);
    assert_true(i_gfmt > i_cap && i_sfmt > i_gfmt && i_parm > i_sfmt && i_ctrl > i_parm && i_req > i_ctrl &&
                i_qry > i_req && i_qbuf > i_qry && i_on > i_qbuf);
    assert_int_equal(fakev4l2_count(d, VIDIOC_QUERYBUF), 4);
    assert_int_equal(fakev4l2_count(d, VIDIOC_QBUF), 4);
    assert_int_equal(d->mmaps, 4);
    assert_int_equal(d->live_mappings, 4);
    assert_true(d->streaming);
    /* controls landed in device units: 2000 us = 20 x 100 us, manual exposure */
    assert_int_equal(d->exposure, 20);
    assert_int_equal(d->exposure_auto, V4L2_EXPOSURE_MANUAL);
    assert_int_equal(d->gain, 100);
    assert_int_equal(d->tpf_num, 1000);
    assert_int_equal(d->tpf_den, 18600);

    mfns_cam_info_t info;
    assert_int_equal(mfns_cam_get_info(fx->cam, &info), MFNS_CAM_OK);
    assert_int_equal(info.width, 64);
    assert_int_equal(info.height, 48);
    assert_int_equal(info.stride, 64);
    assert_int_equal(info.pixfmt, MFNS_CAM_PIX_GREY);
    assert_int_equal(info.buffer_count, 4);
    assert_false(info.multiplanar);
    assert_string_equal(info.driver, "fakev4l2");

    uint64_t last_ts = 0;
    for (uint32_t k = 0; k < 10; k++) {
        const mfns_cam_frame_t f = cycle(fx);
        assert_int_equal(f.sequence, k);
        assert_int_equal(f.dropped_before, 0);
        assert_int_equal(f.width, 64);
        assert_int_equal(f.height, 48);
        assert_int_equal(f.pixfmt, MFNS_CAM_PIX_GREY);
        assert_int_equal(f.bytesused, 64 * 48); /* bytesused, not the page-rounded buffer length */
        assert_int_equal(f.exposure_us, 2000);
        assert_true(f.timestamp_ns > last_ts);
        last_ts = f.timestamp_ns;
    }
    /* buffers circulate: 10 frames through 4 buffers means every one was requeued */
    assert_int_equal(fakev4l2_count(d, VIDIOC_QBUF), 14);
    assert_int_equal(mfns_cam_stop(fx->cam), MFNS_CAM_OK);
    assert_int_equal(fakev4l2_count(d, VIDIOC_STREAMOFF), 1);
    assert_false(d->streaming);
    mfns_cam_stats_t st;
    assert_int_equal(mfns_cam_get_stats(fx->cam, &st), MFNS_CAM_OK);
    assert_int_equal(st.frames, 10);
    assert_int_equal(st.dropped, 0);
    assert_int_equal(st.error_frames, 0);
    mfns_cam_close(fx->cam);
    fx->cam = NULL;
    /* close gives the buffers back (REQBUFS 0) and unmaps them */
    assert_int_equal(fakev4l2_count(d, VIDIOC_REQBUFS), 2);
    assert_int_equal(d->munmaps, 4);
}

static void test_multi_planar_all_formats(void **state)
{
    fixture_t *fx = *state;
    static const mfns_cam_pixfmt_t fmts[] = {MFNS_CAM_PIX_GREY, MFNS_CAM_PIX_Y10, MFNS_CAM_PIX_Y12, MFNS_CAM_PIX_Y16};
    static const uint32_t fourcc[] = {V4L2_PIX_FMT_GREY, V4L2_PIX_FMT_Y10, V4L2_PIX_FMT_Y12, V4L2_PIX_FMT_Y16};
    for (int mp = 0; mp < 2; mp++) {
        for (size_t i = 0; i < 4; i++) {
            fx->dev.mplane = mp != 0;
            fx->dev.stride_pad = 16; /* padded rows: stride must come from bytesperline */
            fx->s.pixfmt = fmts[i];
            open_start(fx);
            mfns_cam_info_t info;
            assert_int_equal(mfns_cam_get_info(fx->cam, &info), MFNS_CAM_OK);
            assert_int_equal(info.multiplanar, mp != 0);
            assert_int_equal(info.pixfmt, fmts[i]);
            assert_int_equal(fx->dev.fourcc, fourcc[i]);
            const uint32_t bpp = mfns_cam_pixfmt_bytes(fmts[i]);
            assert_int_equal(info.stride, 64 * bpp + 16);
            for (int k = 0; k < 3; k++) {
                const mfns_cam_frame_t f = cycle(fx);
                assert_int_equal(f.stride, 64 * bpp + 16);
                assert_int_equal(f.bytesused, (64 * bpp + 16) * 48);
                assert_int_equal(f.pixfmt, fmts[i]);
            }
            mfns_cam_close(fx->cam);
            fx->cam = NULL;
            assert_int_equal(fx->dev.live_mappings, 0);
            assert_int_equal(fx->dev.open_fds, 0);
        }
    }
    assert_true(fakev4l2_count(&fx->dev, VIDIOC_DQBUF) >= 24);
}

static void test_unsupported_format_and_size(void **state)
{
    fixture_t *fx = *state;
    char msg[MFNS_CAM_MSG_LEN];
    fx->dev.nformats = 1; /* GREY only: S_FMT silently falls back to it */
    fx->s.pixfmt = MFNS_CAM_PIX_Y12;
    assert_int_equal(open_fx(fx, msg, sizeof msg), MFNS_CAM_E_FORMAT);
    assert_null(fx->cam);
    assert_true(msg_has(fx, msg, "device offers GREY"));
    assert_int_equal(fx->dev.open_fds, 0);

    fx->s.pixfmt = MFNS_CAM_PIX_GREY;
    fx->s.width = 1280;
    fx->s.height = 1024;
    assert_int_equal(open_fx(fx, msg, sizeof msg), MFNS_CAM_E_FORMAT);
    assert_true(msg_has(fx, msg, "64x48"));

    /* a device whose only format is not mono */
    fx->dev.formats[0] = V4L2_PIX_FMT_YUYV;
    fx->dev.fourcc = V4L2_PIX_FMT_YUYV;
    fx->s.pixfmt = MFNS_CAM_PIX_ANY;
    fx->s.width = fx->s.height = 0;
    assert_int_equal(open_fx(fx, msg, sizeof msg), MFNS_CAM_E_FORMAT);
    assert_true(msg_has(fx, msg, "YUYV"));
    assert_int_equal(fx->dev.open_fds, 0);
    assert_int_equal(fx->dev.live_mappings, 0);
}

static void test_not_a_capture_device(void **state)
{
    fixture_t *fx = *state;
    char msg[MFNS_CAM_MSG_LEN];
    fx->dev.not_capture = true;
    assert_int_equal(open_fx(fx, msg, sizeof msg), MFNS_CAM_E_NOT_CAPTURE);
    fx->dev.not_capture = false;
    fx->dev.no_streaming = true;
    assert_int_equal(open_fx(fx, msg, sizeof msg), MFNS_CAM_E_NOT_CAPTURE);
    assert_true(msg_has(fx, msg, "streaming"));
    /* the device node does not exist */
    fx->dev.no_streaming = false;
    fakev4l2_unplug(&fx->dev, -1);
    assert_int_equal(open_fx(fx, msg, sizeof msg), MFNS_CAM_E_OPEN);
    assert_true(msg_has(fx, msg, "/dev/video0"));
}

static void test_unsupported_controls(void **state)
{
    fixture_t *fx = *state;
    char msg[MFNS_CAM_MSG_LEN];
    fx->dev.has_exposure = false;
    assert_int_equal(open_fx(fx, msg, sizeof msg), MFNS_CAM_E_CONTROL);
    assert_true(msg_has(fx, msg, "has no exposure control"));
    fx->dev.has_exposure = true;
    fx->dev.has_gain = false;
    assert_int_equal(open_fx(fx, msg, sizeof msg), MFNS_CAM_E_CONTROL);
    assert_true(msg_has(fx, msg, "has no gain control"));
    fx->dev.has_gain = true;
    fx->s.exposure_us = 2000000; /* 20000 units > 10000 */
    assert_int_equal(open_fx(fx, msg, sizeof msg), MFNS_CAM_E_CONTROL);
    assert_true(msg_has(fx, msg, "outside device range [1, 10000]"));
    fx->s.exposure_us = 2000;
    fx->dev.has_timeperframe = false;
    assert_int_equal(open_fx(fx, msg, sizeof msg), MFNS_CAM_E_CONTROL);
    assert_true(msg_has(fx, msg, "frame interval"));
    fx->dev.has_timeperframe = true;
    fx->s.frame_rate_hz = 100.0f; /* device caps at 60 */
    assert_int_equal(open_fx(fx, msg, sizeof msg), MFNS_CAM_E_CONTROL);
    assert_true(msg_has(fx, msg, "60.000 Hz"));
    assert_int_equal(fx->dev.open_fds, 0);
    /* controls that are not asked for need not exist */
    fx->s.frame_rate_hz = 0.0f;
    fx->s.exposure_us = -1;
    fx->s.gain = -1;
    fx->dev.has_exposure = fx->dev.has_gain = fx->dev.has_exposure_auto = false;
    fx->dev.ntrace = 0;
    open_start(fx);
    assert_int_equal(fakev4l2_count(&fx->dev, VIDIOC_S_CTRL), 0);
    const mfns_cam_frame_t f = cycle(fx);
    assert_int_equal(f.exposure_us, -1);
    mfns_cam_close(fx->cam);
    fx->cam = NULL;
    /* exposure not set: the frame reports the device's own value */
    fx->dev.has_exposure = true;
    fx->dev.exposure = 37;
    open_start(fx);
    assert_int_equal(cycle(fx).exposure_us, 3700);
    /* at run time: unsupported, then supported but out of range, then fine */
    assert_int_equal(mfns_cam_set_controls(fx->cam, -1, 50), MFNS_CAM_E_CONTROL);
    fx->dev.has_gain = true;
    assert_int_equal(mfns_cam_set_controls(fx->cam, -1, 1000), MFNS_CAM_E_CONTROL);
    assert_true(msg_has(fx, mfns_cam_message(fx->cam), "[0, 480]"));
    assert_int_equal(mfns_cam_set_controls(fx->cam, -1, 50), MFNS_CAM_OK);
    assert_int_equal(fx->dev.gain, 50);
}

static void test_eintr_is_retried(void **state)
{
    fixture_t *fx = *state;
    fx->dev.eintr_next = 2;
    fx->dev.eintr_request = VIDIOC_QUERYCAP;
    open_start(fx);
    assert_int_equal(fakev4l2_count(&fx->dev, VIDIOC_QUERYCAP), 3);
    fx->dev.eintr_next = 3;
    fx->dev.eintr_request = VIDIOC_DQBUF;
    const int before = fakev4l2_count(&fx->dev, VIDIOC_DQBUF);
    const mfns_cam_frame_t f = cycle(fx);
    assert_int_equal(f.sequence, 0);
    assert_int_equal(fakev4l2_count(&fx->dev, VIDIOC_DQBUF) - before, 4);
    /* poll interrupted too */
    fx->dev.eagain_next = 3;
    fx->dev.eintr_poll_next = 2;
    const int polls = fx->dev.polls;
    (void)cycle(fx);
    assert_int_equal(fx->dev.polls - polls, 3);
    mfns_cam_stats_t st;
    assert_int_equal(mfns_cam_get_stats(fx->cam, &st), MFNS_CAM_OK);
    assert_int_equal(st.eintr_retries, 2 + 3 + 2);
    /* an endless EINTR storm ends as an I/O error, not a hang */
    fx->dev.eintr_next = 1000;
    mfns_cam_frame_t g;
    assert_int_equal(mfns_cam_dequeue(fx->cam, &g, 100), MFNS_CAM_E_IO);
    assert_true(msg_has(fx, mfns_cam_message(fx->cam), "DQBUF"));
    fx->dev.eintr_next = 0;
    (void)cycle(fx);
}

static void test_eagain_polls_with_timeout(void **state)
{
    fixture_t *fx = *state;
    open_start(fx);
    mfns_cam_frame_t f;
    fx->dev.stalled = true;
    assert_int_equal(mfns_cam_dequeue(fx->cam, &f, 50), MFNS_CAM_E_TIMEOUT);
    assert_int_equal(fx->dev.polls, 1);
    assert_true(fx->dev.last_poll_timeout > 0 && fx->dev.last_poll_timeout <= 50);
    /* timeout 0: a single try, no waiting */
    assert_int_equal(mfns_cam_dequeue(fx->cam, &f, 0), MFNS_CAM_E_TIMEOUT);
    assert_int_equal(fx->dev.polls, 1);
    mfns_cam_stats_t st;
    assert_int_equal(mfns_cam_get_stats(fx->cam, &st), MFNS_CAM_OK);
    assert_int_equal(st.timeouts, 2);
    /* EAGAIN then poll says readable: the frame arrives */
    fx->dev.stalled = false;
    fx->dev.eagain_next = 1;
    f = cycle(fx);
    assert_int_equal(f.sequence, 0);
    assert_int_equal(fx->dev.polls, 2);
}

static void test_error_flagged_buffers_are_requeued(void **state)
{
    fixture_t *fx = *state;
    open_start(fx);
    fx->dev.error_flag_next = 2;
    const int qbufs = fakev4l2_count(&fx->dev, VIDIOC_QBUF);
    mfns_cam_frame_t f = cycle(fx);
    assert_int_equal(f.sequence, 2);       /* 0 and 1 were flagged: never delivered */
    assert_int_equal(f.dropped_before, 2); /* ...but reported as missing */
    assert_int_equal(fakev4l2_count(&fx->dev, VIDIOC_QBUF) - qbufs, 3);
    /* EIO from DQBUF is transient */
    fx->dev.eio_next = 1;
    f = cycle(fx);
    assert_int_equal(f.sequence, 3);
    /* every buffer still circulates: no leak from the requeued ones */
    for (int k = 0; k < 12; k++) {
        f = cycle(fx);
    }
    assert_int_equal(f.sequence, 15);
    mfns_cam_stats_t st;
    assert_int_equal(mfns_cam_get_stats(fx->cam, &st), MFNS_CAM_OK);
    assert_int_equal(st.error_frames, 3);
    assert_int_equal(st.dropped, 0);
    assert_int_equal(st.frames, 14);
    /* a device that only sends damaged frames gives an error, not a hang */
    fx->dev.error_flag_next = 1000;
    assert_int_equal(mfns_cam_dequeue(fx->cam, &f, 100), MFNS_CAM_E_IO);
}

static void test_bytesused_is_honoured(void **state)
{
    fixture_t *fx = *state;
    fx->dev.stride_pad = 8;
    open_start(fx);
    mfns_cam_frame_t f = cycle(fx);
    assert_int_equal(f.bytesused, fx->dev.last_bytesused);
    assert_int_equal(f.bytesused, 72 * 48);
    assert_true(f.bytesused < 4096); /* the buffer is page-rounded: length is not the payload */
    /* a short payload is a truncated image: requeued, never delivered */
    fx->dev.short_next = 1;
    f = cycle(fx);
    assert_int_equal(f.sequence, 2);
    assert_int_equal(f.dropped_before, 1);
    assert_int_equal(f.bytesused, 72 * 48);
    mfns_cam_stats_t st;
    assert_int_equal(mfns_cam_get_stats(fx->cam, &st), MFNS_CAM_OK);
    assert_int_equal(st.error_frames, 1);
}

/* The buffer's timestamp flags become the frame's ts_source and the seam's
 * clock at dequeue its arrival time (camera data health, frame_health.h). */
static void test_timestamp_source_and_arrival(void **state)
{
    fixture_t *fx = *state;
    open_start(fx);
    mfns_cam_frame_t f = cycle(fx); /* already queued when asked: its arrival is unknown */
    assert_int_equal(f.ts_source, MFNS_CAM_TS_MONOTONIC_EOF);
    assert_int_equal(f.arrival_ns, 0u);
    fx->dev.eagain_next = 1; /* waited for (poll): the fake's default 2 ms from stamp to dequeue */
    f = cycle(fx);
    assert_int_equal(f.ts_source, MFNS_CAM_TS_MONOTONIC_EOF);
    assert_int_equal(f.arrival_ns - f.timestamp_ns, 2000000u);
    fx->dev.ts_flags = V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC | V4L2_BUF_FLAG_TSTAMP_SRC_SOE;
    fx->dev.arrival_delay_ns = 90000000; /* 90 ms late */
    fx->dev.eagain_next = 1;
    f = cycle(fx);
    assert_int_equal(f.ts_source, MFNS_CAM_TS_MONOTONIC_SOE);
    assert_int_equal(f.arrival_ns - f.timestamp_ns, 90000000u);
    fx->dev.ts_flags = V4L2_BUF_FLAG_TIMESTAMP_COPY;
    f = cycle(fx);
    assert_int_equal(f.ts_source, MFNS_CAM_TS_COPY);
    fx->dev.ts_flags = V4L2_BUF_FLAG_TIMESTAMP_UNKNOWN;
    f = cycle(fx);
    assert_int_equal(f.ts_source, MFNS_CAM_TS_UNKNOWN);
}

static void test_sequence_gaps_count_as_drops(void **state)
{
    fixture_t *fx = *state;
    open_start(fx);
    (void)cycle(fx);
    fx->dev.seq_skip_next = 5;
    mfns_cam_frame_t f = cycle(fx);
    assert_int_equal(f.sequence, 6);
    assert_int_equal(f.dropped_before, 5);
    f = cycle(fx);
    assert_int_equal(f.dropped_before, 0);
    fx->dev.seq_skip_next = 1;
    f = cycle(fx);
    assert_int_equal(f.dropped_before, 1);
    mfns_cam_stats_t st;
    assert_int_equal(mfns_cam_get_stats(fx->cam, &st), MFNS_CAM_OK);
    assert_int_equal(st.dropped, 6);
    assert_int_equal(st.frames, 4);
}

/* A driver that leaves every buffer's sequence at 0: found at the stream's second frame,
 * whose number (and every later one) is then the backend's count of dequeued frames; a
 * new stream starts over (first frame 0, the finding made again). A driver that does
 * number its frames is left alone even when its first frame is 0. */
static void test_a_driver_without_frame_numbers_is_counted(void **state)
{
    fixture_t *fx = *state;
    fx->dev.no_seq = true;
    open_start(fx);
    for (uint32_t k = 0; k < 6; k++) {
        const mfns_cam_frame_t f = cycle(fx); /* cycle() checks the pixels: the device's own count is k */
        assert_int_equal(f.sequence, k);
        assert_int_equal(f.dropped_before, 0);
    }
    fx->dev.error_flag_next = 1; /* an errored frame keeps its place in the count: one missing, no gap */
    const mfns_cam_frame_t after = cycle(fx);
    assert_int_equal(after.sequence, 7);
    assert_int_equal(after.dropped_before, 1);
    mfns_cam_stats_t st;
    assert_int_equal(mfns_cam_get_stats(fx->cam, &st), MFNS_CAM_OK);
    assert_int_equal(st.own_seq_streams, 1);
    assert_int_equal(st.dropped, 0);
    assert_int_equal(st.error_frames, 1);
    assert_int_equal(mfns_cam_stop(fx->cam), MFNS_CAM_OK);
    fx->dev.no_seq = false; /* the same device, now numbering: left alone */
    fx->dev.seq = 0;
    assert_int_equal(mfns_cam_start(fx->cam), MFNS_CAM_OK);
    for (uint32_t k = 0; k < 3; k++) {
        assert_int_equal(cycle(fx).sequence, k);
    }
    assert_int_equal(mfns_cam_get_stats(fx->cam, &st), MFNS_CAM_OK);
    assert_int_equal(st.own_seq_streams, 1);
}

static void test_mmap_failure_unwinds(void **state)
{
    fixture_t *fx = *state;
    char msg[MFNS_CAM_MSG_LEN];
    fx->dev.mmap_fail_at = 2;
    assert_int_equal(open_fx(fx, msg, sizeof msg), MFNS_CAM_E_MMAP);
    assert_true(msg_has(fx, msg, "buffer 2"));
    assert_int_equal(fx->dev.munmaps, 2); /* the two mapped before it */
    assert_int_equal(fx->dev.live_mappings, 0);
    assert_int_equal(fx->dev.open_fds, 0);
}

static void test_reqbufs_fewer_buffers(void **state)
{
    fixture_t *fx = *state;
    char msg[MFNS_CAM_MSG_LEN];
    fx->dev.max_buffers = 3;
    fx->s.buffer_count = 6;
    open_start(fx);
    mfns_cam_info_t info;
    assert_int_equal(mfns_cam_get_info(fx->cam, &info), MFNS_CAM_OK);
    assert_int_equal(info.buffer_count, 3);
    assert_int_equal(fx->dev.mmaps, 3);
    mfns_cam_frame_t held[3], f;
    for (int k = 0; k < 3; k++) {
        assert_int_equal(mfns_cam_dequeue(fx->cam, &held[k], 100), MFNS_CAM_OK);
    }
    /* all three held by the caller: asking for more is refused at once */
    assert_int_equal(mfns_cam_dequeue(fx->cam, &f, 100), MFNS_CAM_E_BUSY);
    assert_int_equal(mfns_cam_requeue(fx->cam, &held[1]), MFNS_CAM_OK);
    assert_int_equal(mfns_cam_requeue(fx->cam, &held[1]), MFNS_CAM_E_ARG); /* twice */
    assert_int_equal(mfns_cam_dequeue(fx->cam, &f, 100), MFNS_CAM_OK);
    assert_int_equal(f.buf_index, held[1].buf_index);
    mfns_cam_close(fx->cam);
    fx->cam = NULL;
    /* one buffer is not enough to stream */
    fx->dev.max_buffers = 1;
    assert_int_equal(open_fx(fx, msg, sizeof msg), MFNS_CAM_E_BUFFERS);
    assert_true(msg_has(fx, msg, "granted 1"));
    assert_int_equal(fx->dev.live_mappings, 0);
}

static void test_enodev_then_device_returns(void **state)
{
    fixture_t *fx = *state;
    open_start(fx);
    for (int k = 0; k < 3; k++) {
        (void)cycle(fx);
    }
    assert_int_equal(mfns_cam_take_events(fx->cam), 0);
    /* unplugged; the first reopen fails, the second finds it back with its
     * controls reset (a replugged camera starts from defaults) */
    fakev4l2_unplug(&fx->dev, 1);
    fx->dev.exposure = fx->dev.gain = 0;
    const int qry = fakev4l2_count(&fx->dev, VIDIOC_QUERYCAP);
    mfns_cam_frame_t f;
    assert_int_equal(mfns_cam_dequeue(fx->cam, &f, 40), MFNS_CAM_E_LOST);
    assert_true(msg_has(fx, mfns_cam_message(fx->cam), "attempt 1/5"));
    assert_int_equal(mfns_cam_take_events(fx->cam), MFNS_CAM_EV_LOST);
    assert_true(fx->dev.slept_ms > 0 && fx->dev.slept_ms <= 40); /* waited out its timeout, no busy loop */
    assert_int_equal(fx->dev.open_fds, 0);                        /* dead fd closed */
    assert_int_equal(fx->dev.live_mappings, 0);
    f = cycle(fx);
    assert_int_equal(mfns_cam_take_events(fx->cam), MFNS_CAM_EV_RECOVERED);
    assert_int_equal(f.sequence, 0);       /* new stream: counter restarted */
    assert_int_equal(f.dropped_before, 0); /* ...which is not a drop */
    /* reconfigured from scratch: caps, format, controls, buffers */
    assert_int_equal(fakev4l2_count(&fx->dev, VIDIOC_QUERYCAP) - qry, 1);
    assert_int_equal(fx->dev.exposure, 20);
    assert_int_equal(fx->dev.gain, 100);
    assert_int_equal(fakev4l2_count(&fx->dev, VIDIOC_STREAMON), 2);
    for (int k = 0; k < 5; k++) {
        f = cycle(fx);
    }
    assert_int_equal(f.sequence, 5);
    mfns_cam_stats_t st;
    assert_int_equal(mfns_cam_get_stats(fx->cam, &st), MFNS_CAM_OK);
    assert_int_equal(st.losses, 1);
    assert_int_equal(st.recoveries, 1);
    assert_int_equal(st.reopen_attempts, 2);
    assert_int_equal(st.dropped, 0);
    assert_int_equal(fx->dev.open_fds, 1);
    assert_int_equal(fx->dev.live_mappings, 4);
}

static void test_enodev_with_a_held_frame(void **state)
{
    fixture_t *fx = *state;
    open_start(fx);
    mfns_cam_frame_t held, f;
    assert_int_equal(mfns_cam_dequeue(fx->cam, &held, 100), MFNS_CAM_OK);
    fakev4l2_unplug(&fx->dev, 0);
    assert_int_equal(mfns_cam_dequeue(fx->cam, &f, 100), MFNS_CAM_E_LOST);
    assert_true(msg_has(fx, mfns_cam_message(fx->cam), "requeue the 1 held frame"));
    /* the held frame stays readable until it is given back */
    const uint8_t *p = held.data;
    assert_int_equal(p[0], (uint8_t)held.sequence);
    assert_int_equal(fx->dev.live_mappings, 1);
    assert_int_equal(fx->dev.opens, 1); /* no reopen while a frame is held */
    assert_int_equal(mfns_cam_requeue(fx->cam, &held), MFNS_CAM_OK);
    assert_int_equal(fx->dev.live_mappings, 0);
    f = cycle(fx);
    assert_int_equal(f.sequence, 0);
    assert_int_equal(mfns_cam_take_events(fx->cam), MFNS_CAM_EV_LOST | MFNS_CAM_EV_RECOVERED);
}

static void test_enodev_on_requeue(void **state)
{
    fixture_t *fx = *state;
    open_start(fx);
    mfns_cam_frame_t f;
    assert_int_equal(mfns_cam_dequeue(fx->cam, &f, 100), MFNS_CAM_OK);
    fx->dev.qbuf_enodev_next = 1;
    fx->dev.replug_after_opens = 0;
    assert_int_equal(mfns_cam_requeue(fx->cam, &f), MFNS_CAM_E_LOST);
    f = cycle(fx);
    assert_int_equal(f.sequence, 0);
    mfns_cam_stats_t st;
    assert_int_equal(mfns_cam_get_stats(fx->cam, &st), MFNS_CAM_OK);
    assert_int_equal(st.losses, 1);
    assert_int_equal(st.recoveries, 1);
}

static void test_enodev_recovery_exhausted(void **state)
{
    fixture_t *fx = *state;
    fx->s.recover_attempts = 3;
    open_start(fx);
    (void)cycle(fx);
    fx->dev.unplug_at_dqbuf = fx->dev.dqbufs + 1;
    fx->dev.replug_after_opens = -1;
    mfns_cam_frame_t f;
    assert_int_equal(mfns_cam_dequeue(fx->cam, &f, 10), MFNS_CAM_E_LOST);
    assert_int_equal(mfns_cam_dequeue(fx->cam, &f, 10), MFNS_CAM_E_LOST);
    assert_int_equal(mfns_cam_take_events(fx->cam), MFNS_CAM_EV_LOST);
    assert_int_equal(mfns_cam_dequeue(fx->cam, &f, 10), MFNS_CAM_E_NO_DEVICE);
    assert_true(msg_has(fx, mfns_cam_message(fx->cam), "attempt 3/3"));
    assert_int_equal(mfns_cam_take_events(fx->cam), MFNS_CAM_EV_RECOVERY_FAILED);
    const int opens = fx->dev.opens;
    assert_int_equal(mfns_cam_dequeue(fx->cam, &f, 10), MFNS_CAM_E_NO_DEVICE);
    assert_int_equal(fx->dev.opens, opens); /* given up: no more attempts */
    mfns_cam_stats_t st;
    assert_int_equal(mfns_cam_get_stats(fx->cam, &st), MFNS_CAM_OK);
    assert_int_equal(st.reopen_attempts, 3);
    assert_int_equal(st.recoveries, 0);
    assert_int_equal(mfns_cam_set_controls(fx->cam, 1000, -1), MFNS_CAM_E_NO_DEVICE);
    mfns_cam_close(fx->cam);
    fx->cam = NULL;

    /* recovery switched off: the first loss is final */
    fakev4l2_free(&fx->dev);
    fakev4l2_init(&fx->dev);
    fx->s.recover_attempts = 0;
    open_start(fx);
    fakev4l2_unplug(&fx->dev, 0);
    assert_int_equal(mfns_cam_dequeue(fx->cam, &f, 10), MFNS_CAM_E_NO_DEVICE);
    assert_int_equal(mfns_cam_take_events(fx->cam), MFNS_CAM_EV_LOST | MFNS_CAM_EV_RECOVERY_FAILED);
    assert_int_equal(fx->dev.opens, 1);
}

static void test_api_misuse(void **state)
{
    fixture_t *fx = *state;
    char msg[MFNS_CAM_MSG_LEN];
    mfns_cam_frame_t f;
    mfns_cam_settings_t bad = fx->s;
    bad.buffer_count = 1;
    assert_int_equal(mfns_cam_open(&bad, &fx->cam, msg, sizeof msg), MFNS_CAM_E_ARG);
    assert_true(msg_has(fx, msg, "buffer_count"));
    bad = fx->s;
    bad.path = NULL;
    assert_int_equal(mfns_cam_open(&bad, &fx->cam, msg, sizeof msg), MFNS_CAM_E_ARG);
    bad = fx->s;
    bad.pixfmt = (mfns_cam_pixfmt_t)99;
    assert_int_equal(mfns_cam_open(&bad, &fx->cam, msg, sizeof msg), MFNS_CAM_E_ARG);
    assert_int_equal(mfns_cam_open(NULL, &fx->cam, NULL, 0), MFNS_CAM_E_ARG);
    assert_int_equal(fx->dev.opens, 0);

    assert_int_equal(open_fx(fx, msg, sizeof msg), MFNS_CAM_OK);
    assert_int_equal(mfns_cam_dequeue(fx->cam, &f, 10), MFNS_CAM_E_STATE);
    assert_int_equal(mfns_cam_start(fx->cam), MFNS_CAM_OK);
    assert_int_equal(mfns_cam_start(fx->cam), MFNS_CAM_E_STATE);
    assert_int_equal(mfns_cam_dequeue(fx->cam, &f, -1), MFNS_CAM_E_ARG);
    assert_int_equal(mfns_cam_dequeue(fx->cam, &f, MFNS_CAM_MAX_TIMEOUT_MS + 1), MFNS_CAM_E_ARG);
    assert_int_equal(mfns_cam_dequeue(fx->cam, &f, 10), MFNS_CAM_OK);
    /* after stop a held frame is stale: requeue is a harmless no-op */
    assert_int_equal(mfns_cam_stop(fx->cam), MFNS_CAM_OK);
    const int qbufs = fakev4l2_count(&fx->dev, VIDIOC_QBUF);
    assert_int_equal(mfns_cam_requeue(fx->cam, &f), MFNS_CAM_OK);
    assert_int_equal(fakev4l2_count(&fx->dev, VIDIOC_QBUF), qbufs);
    /* restart streams again from a fresh queue */
    assert_int_equal(mfns_cam_start(fx->cam), MFNS_CAM_OK);
    (void)cycle(fx);
    /* a pointer that is not a handle */
    mfns_cam_t *fake = (mfns_cam_t *)(void *)&f;
    assert_int_equal(mfns_cam_start(fake), MFNS_CAM_E_ARG);
    mfns_cam_close(NULL);
    /* an unknown backend is refused before any device access */
    mfns_cam_settings_t lc = mfns_cam_default_settings(MFNS_CAM_BACKEND_COUNT_, "");
    mfns_cam_t *other = fake;
    assert_int_equal(mfns_cam_open(&lc, &other, msg, sizeof msg), MFNS_CAM_E_ARG);
    assert_null(other);
}

static void test_handle_pool_is_fixed(void **state)
{
    (void)state;
    static fakev4l2_dev_t devs[MFNS_CAM_MAX_HANDLES + 1];
    static mfns_cam_sys_t sys[MFNS_CAM_MAX_HANDLES + 1];
    mfns_cam_t *h[MFNS_CAM_MAX_HANDLES + 1] = {NULL};
    char msg[MFNS_CAM_MSG_LEN];
    for (unsigned i = 0; i <= MFNS_CAM_MAX_HANDLES; i++) {
        fakev4l2_init(&devs[i]);
        sys[i] = fakev4l2_sys(&devs[i]);
        mfns_cam_settings_t s = mfns_cam_default_settings(MFNS_CAM_BACKEND_V4L2, "/dev/videoN");
        s.sys = &sys[i];
        const mfns_cam_err_t e = mfns_cam_open(&s, &h[i], msg, sizeof msg);
        assert_int_equal(e, i < MFNS_CAM_MAX_HANDLES ? MFNS_CAM_OK : MFNS_CAM_E_NO_SLOT);
    }
    assert_int_equal(devs[MFNS_CAM_MAX_HANDLES].opens, 0);
    mfns_cam_close(h[2]);
    h[2] = NULL;
    mfns_cam_settings_t s = mfns_cam_default_settings(MFNS_CAM_BACKEND_V4L2, "/dev/videoN");
    s.sys = &sys[MFNS_CAM_MAX_HANDLES];
    assert_int_equal(mfns_cam_open(&s, &h[2], msg, sizeof msg), MFNS_CAM_OK);
    for (unsigned i = 0; i <= MFNS_CAM_MAX_HANDLES; i++) {
        mfns_cam_close(h[i]);
    }
    for (unsigned i = 0; i <= MFNS_CAM_MAX_HANDLES; i++) {
        assert_int_equal(devs[i].open_fds, 0);
        assert_int_equal(devs[i].live_mappings, 0);
        fakev4l2_free(&devs[i]);
    }
}

/* The real syscalls (settings.sys == NULL) on nodes every machine has. */
static void test_real_syscalls_without_a_camera(void **state)
{
    (void)state;
    char msg[MFNS_CAM_MSG_LEN];
    mfns_cam_t *cam = NULL;
    mfns_cam_settings_t s = mfns_cam_default_settings(MFNS_CAM_BACKEND_V4L2, "/nonexistent/mfns/video9");
    assert_int_equal(mfns_cam_open(&s, &cam, msg, sizeof msg), MFNS_CAM_E_OPEN);
    assert_null(cam);
    assert_non_null(strstr(msg, "/nonexistent/mfns/video9"));
    s.path = "/dev/null"; /* opens, but answers VIDIOC_QUERYCAP with ENOTTY */
    assert_int_equal(mfns_cam_open(&s, &cam, msg, sizeof msg), MFNS_CAM_E_NOT_CAPTURE);
    assert_null(cam);
    assert_non_null(strstr(msg, "QUERYCAP"));
}

static void test_error_names_are_distinct(void **state)
{
    (void)state;
    for (int a = 0; a < MFNS_CAM_E_COUNT_; a++) {
        const char *sa = mfns_cam_strerror((mfns_cam_err_t)a);
        assert_non_null(sa);
        assert_true(strlen(sa) > 1);
        for (int b = 0; b < a; b++) {
            assert_string_not_equal(sa, mfns_cam_strerror((mfns_cam_err_t)b));
        }
    }
    assert_string_equal(mfns_cam_strerror((mfns_cam_err_t)1000), "unknown camera error");
    assert_string_equal(mfns_cam_pixfmt_name(MFNS_CAM_PIX_Y12), "Y12");
    assert_int_equal(mfns_cam_pixfmt_bytes(MFNS_CAM_PIX_Y10), 2);
    assert_int_equal(mfns_cam_pixfmt_bytes(MFNS_CAM_PIX_ANY), 0);
    assert_string_equal(mfns_cam_message(NULL), "");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_single_planar_full_sequence, setup, teardown),
        cmocka_unit_test_setup_teardown(test_multi_planar_all_formats, setup, teardown),
        cmocka_unit_test_setup_teardown(test_unsupported_format_and_size, setup, teardown),
        cmocka_unit_test_setup_teardown(test_not_a_capture_device, setup, teardown),
        cmocka_unit_test_setup_teardown(test_unsupported_controls, setup, teardown),
        cmocka_unit_test_setup_teardown(test_eintr_is_retried, setup, teardown),
        cmocka_unit_test_setup_teardown(test_eagain_polls_with_timeout, setup, teardown),
        cmocka_unit_test_setup_teardown(test_error_flagged_buffers_are_requeued, setup, teardown),
        cmocka_unit_test_setup_teardown(test_bytesused_is_honoured, setup, teardown),
        cmocka_unit_test_setup_teardown(test_sequence_gaps_count_as_drops, setup, teardown),
        cmocka_unit_test_setup_teardown(test_a_driver_without_frame_numbers_is_counted, setup, teardown),
        cmocka_unit_test_setup_teardown(test_timestamp_source_and_arrival, setup, teardown),
        cmocka_unit_test_setup_teardown(test_mmap_failure_unwinds, setup, teardown),
        cmocka_unit_test_setup_teardown(test_reqbufs_fewer_buffers, setup, teardown),
        cmocka_unit_test_setup_teardown(test_enodev_then_device_returns, setup, teardown),
        cmocka_unit_test_setup_teardown(test_enodev_with_a_held_frame, setup, teardown),
        cmocka_unit_test_setup_teardown(test_enodev_on_requeue, setup, teardown),
        cmocka_unit_test_setup_teardown(test_enodev_recovery_exhausted, setup, teardown),
        cmocka_unit_test_setup_teardown(test_api_misuse, setup, teardown),
        cmocka_unit_test(test_handle_pool_is_fixed),
        cmocka_unit_test(test_real_syscalls_without_a_camera),
        cmocka_unit_test(test_error_names_are_distinct),
    };
    return cmocka_run_group_tests_name("camera_v4l2", tests, NULL, NULL);
}
