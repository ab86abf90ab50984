/* Unit tests of the replay camera backend on small frame folders in the
 * docs/nav-frames.md layout, written by the test into a mkdtemp directory:
 * 8- and 16-bit PGM, camera selection, timestamps and pacing, drops from
 * frame-index gaps, end of data, and refusal of each kind of malformed input. */
#define _XOPEN_SOURCE 700
#ifndef _DEFAULT_SOURCE
#define _DEFAULT_SOURCE 1
#endif
#include "tests/unit/support/testutil.h"

#include <fcntl.h>
#include <ftw.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "drivers/camera/camera.h"

#define W 8
#define H 6

static char g_dir[64];
static mfns_cam_t *g_cam;

static void write_file(const char *rel, const void *data, size_t n)
{
    char path[256];
    (void)snprintf(path, sizeof path, "%s/%s", g_dir, rel);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, n, f), n);
    assert_int_equal(fclose(f), 0);
}

static void write_text(const char *rel, const char *text)
{
    write_file(rel, text, strlen(text));
}

/* Pixel value of (frame, camera, pixel i), below maxval. */
static uint32_t pix(uint32_t frame, int cam, size_t i, uint32_t maxval)
{
    return (uint32_t)(frame * 7u + (uint32_t)cam * 3u + (uint32_t)i * 13u) % (maxval + 1u);
}

/* A PGM exactly as docs/nav-frames.md has it; extra_bytes < 0 truncates. */
static void write_pgm_ex(const char *rel, uint32_t w, uint32_t h, uint32_t maxval, uint32_t frame, int cam,
                         int extra_bytes)
{
    static uint8_t buf[64 + 2 * 64 * 64 + 16];
    int n = snprintf((char *)buf, 64, "P5\n%u %u\n%u\n", w, h, maxval);
    const size_t bpp = maxval > 255 ? 2 : 1;
    for (size_t i = 0; i < (size_t)w * h; i++) {
        const uint32_t v = pix(frame, cam, i, maxval);
        if (bpp == 2) {
            buf[n++] = (uint8_t)(v >> 8); /* big-endian, as PGM requires */
            buf[n++] = (uint8_t)(v & 0xffu);
        } else {
            buf[n++] = (uint8_t)v;
        }
    }
    const int total = n + extra_bytes;
    write_file(rel, buf, (size_t)total);
}

static void write_pgm(const char *rel, uint32_t maxval, uint32_t frame, int cam)
{
    write_pgm_ex(rel, W, H, maxval, frame, cam, 0);
}

static const char SCENARIO[] = "{\"format\": \"mfns-nav-frames\", \"version\": 1, \"scenario\": \"turntable\", "
                               "\"rate_hz\": 18.6, \"n_frames\": 4, \"width\": 8, \"height\": 6, \"maxval\": 255}\n";

/* n frames for all three cameras, frame-major rows, t = 0.05 s * frame. */
static void write_folder(int n, uint32_t maxval)
{
    write_text("scenario.json", SCENARIO);
    char csv[4096];
    size_t len = (size_t)snprintf(csv, sizeof csv, "frame,t_s,camera,file,exposure_us,gain_db\n");
    const char cams[3] = {'x', 'y', 'z'};
    for (int f = 0; f < n; f++) {
        for (int c = 0; c < 3; c++) {
            char rel[64];
            (void)snprintf(rel, sizeof rel, "cam_%c/%06d.pgm", cams[c], f);
            write_pgm(rel, maxval, (uint32_t)f, c);
            len += (size_t)snprintf(csv + len, sizeof csv - len, "%d,%.6f,%c,%s,%d,%.1f\n", f, 0.05 * f, cams[c],
                                    rel, 1000 + f, 6.0);
            assert_true(len < sizeof csv);
        }
    }
    write_text("frames.csv", csv);
}

static int rm_entry(const char *path, const struct stat *sb, int flag, struct FTW *ftw)
{
    (void)sb;
    (void)flag;
    (void)ftw;
    return remove(path);
}

static int setup(void **state)
{
    (void)state;
    (void)snprintf(g_dir, sizeof g_dir, "/tmp/mfns_replay_XXXXXX");
    if (!mkdtemp(g_dir)) {
        return -1;
    }
    char sub[128];
    const char *cams = "xyz";
    for (int c = 0; c < 3; c++) {
        (void)snprintf(sub, sizeof sub, "%s/cam_%c", g_dir, cams[c]);
        if (mkdir(sub, 0700) != 0) {
            return -1;
        }
    }
    g_cam = NULL;
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    mfns_cam_close(g_cam);
    g_cam = NULL;
    return nftw(g_dir, rm_entry, 8, FTW_DEPTH | FTW_PHYS);
}

static mfns_cam_settings_t settings(char camera)
{
    mfns_cam_settings_t s = mfns_cam_default_settings(MFNS_CAM_BACKEND_REPLAY, g_dir);
    s.replay_camera = camera;
    s.buffer_count = 2;
    return s;
}

static mfns_cam_err_t open_cam(char camera, char *msg)
{
    const mfns_cam_settings_t s = settings(camera);
    return mfns_cam_open(&s, &g_cam, msg, MFNS_CAM_MSG_LEN);
}

static void check_pixels(const mfns_cam_frame_t *f, int cam, uint32_t maxval)
{
    for (size_t i = 0; i < (size_t)W * H; i++) {
        uint32_t v;
        if (maxval > 255) {
            uint16_t w16;
            memcpy(&w16, (const uint8_t *)f->data + 2 * i, 2); /* native word */
            v = w16;
        } else {
            v = ((const uint8_t *)f->data)[i];
        }
        assert_int_equal(v, pix(f->sequence, cam, i, maxval));
    }
}

static bool has(const char *msg, const char *needle)
{
    if (!strstr(msg, needle)) {
        print_error("message \"%s\" lacks \"%s\"\n", msg, needle);
        return false;
    }
    return true;
}

static void test_replay_8bit_camera_y(void **state)
{
    (void)state;
    char msg[MFNS_CAM_MSG_LEN];
    write_folder(4, 255);
    assert_int_equal(open_cam('y', msg), MFNS_CAM_OK);
    mfns_cam_info_t info;
    assert_int_equal(mfns_cam_get_info(g_cam, &info), MFNS_CAM_OK);
    assert_int_equal(info.width, W);
    assert_int_equal(info.height, H);
    assert_int_equal(info.stride, W);
    assert_int_equal(info.pixfmt, MFNS_CAM_PIX_GREY);
    assert_string_equal(info.card, "cam_y");
    assert_int_equal(mfns_cam_start(g_cam), MFNS_CAM_OK);
    mfns_cam_frame_t f;
    for (uint32_t k = 0; k < 4; k++) {
        assert_int_equal(mfns_cam_dequeue(g_cam, &f, 100), MFNS_CAM_OK);
        assert_int_equal(f.sequence, k);
        assert_int_equal(f.bytesused, W * H);
        assert_int_equal(f.width, W);
        assert_int_equal(f.pixfmt, MFNS_CAM_PIX_GREY);
        assert_int_equal(f.timestamp_ns, (uint64_t)k * 50000000u);
        assert_int_equal(f.exposure_us, 1000 + (int)k);
        assert_float_equal(f.gain_db, 6.0f, 0.0f); /* the row's gain, carried to the frame */
        assert_int_equal(f.dropped_before, 0);
        assert_int_equal(f.ts_source, MFNS_CAM_TS_RECORDED);
        assert_int_equal(f.arrival_ns, 0u); /* as fast as asked: no arrival clock */
        check_pixels(&f, 1, 255);
        assert_int_equal(mfns_cam_requeue(g_cam, &f), MFNS_CAM_OK);
    }
    assert_int_equal(mfns_cam_dequeue(g_cam, &f, 100), MFNS_CAM_E_END);
    assert_int_equal(mfns_cam_dequeue(g_cam, &f, 100), MFNS_CAM_E_END);
    assert_true(has(mfns_cam_message(g_cam), "end of frames"));
    /* start again replays from the first frame */
    assert_int_equal(mfns_cam_stop(g_cam), MFNS_CAM_OK);
    assert_int_equal(mfns_cam_start(g_cam), MFNS_CAM_OK);
    assert_int_equal(mfns_cam_dequeue(g_cam, &f, 100), MFNS_CAM_OK);
    assert_int_equal(f.sequence, 0);
    check_pixels(&f, 1, 255);
    mfns_cam_stats_t st;
    assert_int_equal(mfns_cam_get_stats(g_cam, &st), MFNS_CAM_OK);
    assert_int_equal(st.frames, 5);
    assert_int_equal(st.dropped, 0);
    /* replay has no controls to set */
    assert_int_equal(mfns_cam_set_controls(g_cam, 100, -1), MFNS_CAM_E_CONTROL);
}

static void test_replay_16bit_formats(void **state)
{
    (void)state;
    char msg[MFNS_CAM_MSG_LEN];
    static const uint32_t maxvals[] = {1023, 4095, 65535};
    static const mfns_cam_pixfmt_t fmts[] = {MFNS_CAM_PIX_Y10, MFNS_CAM_PIX_Y12, MFNS_CAM_PIX_Y16};
    for (int i = 0; i < 3; i++) {
        write_folder(2, maxvals[i]);
        assert_int_equal(open_cam('z', msg), MFNS_CAM_OK);
        assert_int_equal(mfns_cam_start(g_cam), MFNS_CAM_OK);
        mfns_cam_frame_t f;
        for (int k = 0; k < 2; k++) {
            assert_int_equal(mfns_cam_dequeue(g_cam, &f, 100), MFNS_CAM_OK);
            assert_int_equal(f.pixfmt, fmts[i]);
            assert_int_equal(f.stride, 2 * W);
            assert_int_equal(f.bytesused, 2 * W * H);
            check_pixels(&f, 2, maxvals[i]);
            assert_int_equal(mfns_cam_requeue(g_cam, &f), MFNS_CAM_OK);
        }
        assert_int_equal(mfns_cam_dequeue(g_cam, &f, 100), MFNS_CAM_E_END);
        mfns_cam_close(g_cam);
        g_cam = NULL;
    }
}

static double now_s(void)
{
    struct timespec ts;
    (void)clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static void test_replay_paces_to_timestamps(void **state)
{
    (void)state;
    char msg[MFNS_CAM_MSG_LEN];
    write_text("scenario.json", SCENARIO);
    write_pgm("cam_x/000000.pgm", 255, 0, 0);
    write_pgm("cam_x/000001.pgm", 255, 1, 0);
    write_text("frames.csv", "frame,t_s,camera,file,exposure_us,gain_db\n"
                             "0,10.0,x,cam_x/000000.pgm,500,0\n"
                             "1,10.2,x,cam_x/000001.pgm,500,0\n");
    mfns_cam_settings_t s = settings('x');
    s.replay_realtime = true;
    assert_int_equal(mfns_cam_open(&s, &g_cam, msg, sizeof msg), MFNS_CAM_OK);
    assert_int_equal(mfns_cam_start(g_cam), MFNS_CAM_OK);
    mfns_cam_frame_t f;
    const double t0 = now_s();
    assert_int_equal(mfns_cam_dequeue(g_cam, &f, 100), MFNS_CAM_OK); /* first frame at once */
    assert_int_equal(f.timestamp_ns, 10000000000u);
    assert_int_equal(f.arrival_ns, 0u); /* not waited for: its arrival is unknown */
    assert_int_equal(mfns_cam_requeue(g_cam, &f), MFNS_CAM_OK);
    /* next one is due 200 ms later: a 10 ms wait times out, the frame stays */
    const double t1 = now_s();
    assert_int_equal(mfns_cam_dequeue(g_cam, &f, 10), MFNS_CAM_E_TIMEOUT);
    assert_true(now_s() - t1 >= 0.0095); /* the timeout was waited out, not returned at once */
    assert_int_equal(mfns_cam_dequeue(g_cam, &f, 1000), MFNS_CAM_OK);
    const double dt = now_s() - t0;
    assert_int_equal(f.sequence, 1);
    assert_int_equal(f.timestamp_ns, 10200000000u);
    assert_true(dt >= 0.199); /* slept to the recorded time */
    /* waited for: its arrival on the recording's time base, at or just after its stamp */
    assert_true(f.arrival_ns >= f.timestamp_ns && f.arrival_ns < f.timestamp_ns + 100000000u);
    mfns_cam_stats_t st;
    assert_int_equal(mfns_cam_get_stats(g_cam, &st), MFNS_CAM_OK);
    assert_int_equal(st.timeouts, 1);
}

static void test_replay_gaps_and_buffers(void **state)
{
    (void)state;
    char msg[MFNS_CAM_MSG_LEN];
    write_text("scenario.json", SCENARIO);
    write_pgm("cam_x/000000.pgm", 255, 0, 0);
    write_pgm("cam_x/000001.pgm", 255, 1, 0);
    write_pgm("cam_x/000004.pgm", 255, 4, 0);
    /* CRLF line ends are accepted; frames 2 and 3 are missing for camera x */
    write_text("frames.csv", "frame,t_s,camera,file,exposure_us,gain_db\r\n"
                             "0,0.0,x,cam_x/000000.pgm,500,0\r\n"
                             "1,0.05,x,cam_x/000001.pgm,500,0\r\n"
                             "4,0.2,x,cam_x/000004.pgm,500,0");
    assert_int_equal(open_cam('x', msg), MFNS_CAM_OK);
    assert_int_equal(mfns_cam_start(g_cam), MFNS_CAM_OK);
    mfns_cam_frame_t a, b, c;
    assert_int_equal(mfns_cam_dequeue(g_cam, &a, 100), MFNS_CAM_OK);
    assert_int_equal(mfns_cam_dequeue(g_cam, &b, 100), MFNS_CAM_OK);
    /* two buffers, both held */
    assert_int_equal(mfns_cam_dequeue(g_cam, &c, 100), MFNS_CAM_E_BUSY);
    check_pixels(&a, 0, 255); /* a held frame is not overwritten */
    assert_int_equal(mfns_cam_requeue(g_cam, &a), MFNS_CAM_OK);
    assert_int_equal(mfns_cam_requeue(g_cam, &a), MFNS_CAM_E_ARG);
    assert_int_equal(mfns_cam_dequeue(g_cam, &c, 100), MFNS_CAM_OK);
    assert_int_equal(c.sequence, 4);
    assert_int_equal(c.dropped_before, 2);
    check_pixels(&c, 0, 255);
    check_pixels(&b, 0, 255);
    mfns_cam_stats_t st;
    assert_int_equal(mfns_cam_get_stats(g_cam, &st), MFNS_CAM_OK);
    assert_int_equal(st.dropped, 2);
}

static void test_replay_settings_mismatch(void **state)
{
    (void)state;
    char msg[MFNS_CAM_MSG_LEN];
    write_folder(1, 255);
    mfns_cam_settings_t s = settings('x');
    s.width = 1280;
    s.height = 1024;
    assert_int_equal(mfns_cam_open(&s, &g_cam, msg, sizeof msg), MFNS_CAM_E_FORMAT);
    assert_true(has(msg, "recorded frames are GREY 8x6"));
    s = settings('x');
    s.pixfmt = MFNS_CAM_PIX_Y16;
    assert_int_equal(mfns_cam_open(&s, &g_cam, msg, sizeof msg), MFNS_CAM_E_FORMAT);
    s = settings('q');
    assert_int_equal(mfns_cam_open(&s, &g_cam, msg, sizeof msg), MFNS_CAM_E_ARG);
    s = settings('x');
    s.path = "/nonexistent/mfns/folder";
    assert_int_equal(mfns_cam_open(&s, &g_cam, msg, sizeof msg), MFNS_CAM_E_OPEN);
    assert_null(g_cam);
}

/* Open (and if it opens, one of the next dequeues) must fail with E_DATA naming why. */
static void expect_bad(const char *csv, const char *needle)
{
    char msg[MFNS_CAM_MSG_LEN];
    write_text("frames.csv", csv);
    mfns_cam_err_t e = open_cam('x', msg);
    if (e == MFNS_CAM_OK) {
        mfns_cam_frame_t f;
        assert_int_equal(mfns_cam_start(g_cam), MFNS_CAM_OK);
        for (int k = 0; k < 4 && e == MFNS_CAM_OK; k++) {
            e = mfns_cam_dequeue(g_cam, &f, 100);
            if (e == MFNS_CAM_OK) {
                assert_int_equal(mfns_cam_requeue(g_cam, &f), MFNS_CAM_OK);
            }
        }
        (void)snprintf(msg, sizeof msg, "%s", mfns_cam_message(g_cam));
        mfns_cam_close(g_cam);
        g_cam = NULL;
    }
    if (e != MFNS_CAM_E_DATA) {
        print_error("case \"%s\": got %s (%s)\n", needle, mfns_cam_strerror(e), msg);
    }
    assert_int_equal(e, MFNS_CAM_E_DATA);
    assert_true(has(msg, needle));
}

#define HDR "frame,t_s,camera,file,exposure_us,gain_db\n"
#define ROW0 "0,0.0,x,cam_x/000000.pgm,500,0\n"

static void test_replay_malformed_csv(void **state)
{
    (void)state;
    write_folder(1, 255);
    expect_bad("frame,t,camera,file,exposure_us,gain_db\n" ROW0, "header");
    expect_bad("", "header");
    expect_bad(HDR "0,0.0,x,cam_x/000000.pgm,500\n", "line 2: expected 6");
    expect_bad(HDR "0,0.0,x,cam_x/000000.pgm,500,0,7\n", "line 2: expected 6");
    expect_bad(HDR "-1,0.0,x,cam_x/000000.pgm,500,0\n", "not an index");
    expect_bad(HDR "0,abc,x,cam_x/000000.pgm,500,0\n", "t_s");
    expect_bad(HDR "0,nan,x,cam_x/000000.pgm,500,0\n", "t_s");
    expect_bad(HDR "0,0.0,w,cam_x/000000.pgm,500,0\n", "not x, y or z");
    expect_bad(HDR "0,0.0,x,../cam_x/000000.pgm,500,0\n", "relative path");
    expect_bad(HDR "0,0.0,x,/etc/passwd,500,0\n", "relative path");
    expect_bad(HDR "0,0.0,x,cam_x/000000.pgm,-5,0\n", "exposure_us");
    expect_bad(HDR "0,0.0,x,cam_x/000000.pgm,500,loud\n", "gain_db");
    expect_bad(HDR "0,0.0,x,cam_x/000000.pgm,500,1e300\n", "within +-200 dB"); /* no float holds its factor */
    expect_bad(HDR "0,0.0,x,cam_x/000000.pgm,500,-201\n", "gain_db");
    expect_bad(HDR "0,0.0,y,cam_y/000000.pgm,500,0\n", "no frames for camera x");
    expect_bad(HDR ROW0 "0,0.1,x,cam_x/000000.pgm,500,0\n", "does not follow");
    expect_bad(HDR "0,0.0,x,cam_x/000000.pgm,500,0\n1,0.0,x,cam_x/000099.pgm,500,0\n", "000099.pgm: cannot open");
    char longline[700];
    memset(longline, 'a', sizeof longline);
    memcpy(longline, HDR, strlen(HDR));
    longline[sizeof longline - 1] = '\0';
    expect_bad(longline, "longer than");
}

static void test_replay_malformed_scenario(void **state)
{
    (void)state;
    write_folder(1, 255);
    char msg[MFNS_CAM_MSG_LEN];
    write_text("scenario.json", "{\"format\": \"mfns-nav-frames\", \"version\": 2}");
    assert_int_equal(open_cam('x', msg), MFNS_CAM_E_DATA);
    assert_true(has(msg, "version 2 is newer"));
    write_text("scenario.json", "{\"format\": \"something-else\", \"version\": 1}");
    assert_int_equal(open_cam('x', msg), MFNS_CAM_E_DATA);
    assert_true(has(msg, "format"));
    write_text("scenario.json", "{\"format\": \"mfns-nav-frames\"}");
    assert_int_equal(open_cam('x', msg), MFNS_CAM_E_DATA);
    assert_true(has(msg, "version"));
    char path[128];
    (void)snprintf(path, sizeof path, "%s/scenario.json", g_dir);
    assert_int_equal(unlink(path), 0);
    assert_int_equal(open_cam('x', msg), MFNS_CAM_E_DATA);
    assert_true(has(msg, "scenario.json"));
}

static void test_replay_malformed_pgm(void **state)
{
    (void)state;
    write_folder(2, 255);
    const char *csv = HDR ROW0 "1,0.05,x,cam_x/000001.pgm,500,0\n";
    /* header faults are found when the first frame is probed at open */
    write_text("cam_x/000000.pgm", "P5\n# made by hand\n8 6\n255\n");
    expect_bad(csv, "comments");
    write_text("cam_x/000000.pgm", "P2\n8 6\n255\n1 2 3");
    expect_bad(csv, "P5");
    write_text("cam_x/000000.pgm", "P5\n8 x6\n255\n");
    expect_bad(csv, "malformed PGM header");
    write_pgm_ex("cam_x/000000.pgm", W, H, 1000, 0, 0, 0);
    expect_bad(csv, "maxval 1000");
    write_pgm_ex("cam_x/000000.pgm", 0, H, 255, 0, 0, 0);
    expect_bad(csv, "outside");
    /* pixel faults are found when the frame is read */
    write_pgm("cam_x/000000.pgm", 255, 0, 0);
    write_pgm_ex("cam_x/000001.pgm", W, H, 255, 1, 0, -5);
    expect_bad(HDR "0,0.05,x,cam_x/000001.pgm,500,0\n", "truncated");
    write_pgm_ex("cam_x/000001.pgm", W, H, 255, 1, 0, 3);
    expect_bad(HDR "0,0.05,x,cam_x/000001.pgm,500,0\n", "bytes after the pixel data");
    write_pgm_ex("cam_x/000001.pgm", W, H + 1, 255, 1, 0, 0);
    expect_bad(csv, "differs from the first frame");
    /* a 10-bit sample above maxval */
    static const uint8_t bad16[] = "P5\n2 1\n1023\n\x03\xff\x07\xd0";
    write_file("cam_x/000000.pgm", bad16, sizeof bad16 - 1);
    expect_bad(HDR ROW0, "above maxval 1023");
}

/* Pixel bytes right after the header that look like header syntax ('#',
 * whitespace, digits) are pixels, not a comment or a field. */
static void test_replay_pixels_that_look_like_header(void **state)
{
    (void)state;
    char msg[MFNS_CAM_MSG_LEN];
    write_text("scenario.json", SCENARIO);
    static const uint8_t pgm[] = "P5\n4 1\n255\n#\n 7";
    write_file("cam_x/000000.pgm", pgm, sizeof pgm - 1);
    write_text("frames.csv", HDR ROW0);
    assert_int_equal(open_cam('x', msg), MFNS_CAM_OK);
    assert_int_equal(mfns_cam_start(g_cam), MFNS_CAM_OK);
    mfns_cam_frame_t f;
    assert_int_equal(mfns_cam_dequeue(g_cam, &f, 100), MFNS_CAM_OK);
    assert_int_equal(f.width, 4);
    assert_int_equal(f.bytesused, 4);
    assert_memory_equal(f.data, "#\n 7", 4);
}

static void test_replay_bad_frame_is_skipped(void **state)
{
    (void)state;
    char msg[MFNS_CAM_MSG_LEN];
    write_folder(3, 255);
    write_pgm_ex("cam_x/000001.pgm", W, H, 255, 1, 0, -1);
    assert_int_equal(open_cam('x', msg), MFNS_CAM_OK);
    assert_int_equal(mfns_cam_start(g_cam), MFNS_CAM_OK);
    mfns_cam_frame_t f;
    assert_int_equal(mfns_cam_dequeue(g_cam, &f, 100), MFNS_CAM_OK);
    assert_int_equal(mfns_cam_requeue(g_cam, &f), MFNS_CAM_OK);
    assert_int_equal(mfns_cam_dequeue(g_cam, &f, 100), MFNS_CAM_E_DATA);
    /* the caller may go on: the next frame is good and the gap is visible */
    assert_int_equal(mfns_cam_dequeue(g_cam, &f, 100), MFNS_CAM_OK);
    assert_int_equal(f.sequence, 2);
    assert_int_equal(f.dropped_before, 1);
    check_pixels(&f, 0, 255);
}

/* Cameras of one folder share one parse of frames.csv: a row nobody can claim
 * costs camera y one frame and nothing else; a resumed camera goes on after
 * the given time; a frame file that blocks obeys the dequeue timeout. */
static void test_replay_shared_rows_resume_and_blocking_file(void **state)
{
    (void)state;
    char msg[MFNS_CAM_MSG_LEN];
    write_folder(3, 255);
    write_text("frames.csv", HDR "0,0.0,x,cam_x/000000.pgm,500,0\n0,0.0,y,cam_y/000000.pgm,500,0\n"
                             "1,0.05,x,cam_x/000001.pgm,500,0\n1,0.05,w,cam_y/000001.pgm,500,0\n"
                             "2,0.1,x,cam_x/000002.pgm,500,0\n2,0.1,y,cam_y/000002.pgm,500,0\n");
    assert_int_equal(open_cam('x', msg), MFNS_CAM_OK);
    mfns_cam_t *y = NULL;
    mfns_cam_settings_t s = settings('y');
    assert_int_equal(mfns_cam_open(&s, &y, msg, sizeof msg), MFNS_CAM_OK);
    assert_int_equal(mfns_cam_start(g_cam), MFNS_CAM_OK);
    assert_int_equal(mfns_cam_start(y), MFNS_CAM_OK);
    mfns_cam_frame_t f;
    for (uint32_t i = 0; i < 3; i++) {
        assert_int_equal(mfns_cam_dequeue(g_cam, &f, 100), MFNS_CAM_OK);
        assert_int_equal(f.sequence, i);
        assert_int_equal(mfns_cam_requeue(g_cam, &f), MFNS_CAM_OK);
    }
    assert_int_equal(mfns_cam_dequeue(y, &f, 100), MFNS_CAM_OK);
    assert_int_equal(f.sequence, 0);
    assert_int_equal(mfns_cam_requeue(y, &f), MFNS_CAM_OK);
    assert_int_equal(mfns_cam_dequeue(y, &f, 100), MFNS_CAM_OK);
    assert_int_equal(f.sequence, 2);
    assert_int_equal(f.dropped_before, 1);
    assert_int_equal(mfns_cam_requeue(y, &f), MFNS_CAM_OK);
    assert_int_equal(mfns_cam_dequeue(y, &f, 100), MFNS_CAM_E_END);
    mfns_cam_close(y);
    y = NULL;
    /* resume after 0.05 s: the next frame is frame 2 */
    mfns_cam_close(g_cam);
    g_cam = NULL;
    s = settings('x');
    s.replay_resume = true;
    s.replay_resume_after_ns = 50000000u;
    assert_int_equal(mfns_cam_open(&s, &g_cam, msg, sizeof msg), MFNS_CAM_OK);
    assert_int_equal(mfns_cam_start(g_cam), MFNS_CAM_OK);
    assert_int_equal(mfns_cam_dequeue(g_cam, &f, 100), MFNS_CAM_OK);
    assert_int_equal(f.sequence, 2);
    assert_int_equal(mfns_cam_requeue(g_cam, &f), MFNS_CAM_OK);
    /* frame 1 of camera x as a FIFO whose writer never writes: a timeout, not a hang */
    mfns_cam_close(g_cam);
    g_cam = NULL;
    char fifo[128];
    (void)snprintf(fifo, sizeof fifo, "%s/cam_x/000001.pgm", g_dir);
    assert_int_equal(unlink(fifo), 0);
    assert_int_equal(mkfifo(fifo, 0600), 0);
    const int wfd = open(fifo, O_RDWR | O_NONBLOCK);
    assert_true(wfd >= 0);
    assert_int_equal(open_cam('x', msg), MFNS_CAM_OK);
    assert_int_equal(mfns_cam_start(g_cam), MFNS_CAM_OK);
    assert_int_equal(mfns_cam_dequeue(g_cam, &f, 100), MFNS_CAM_OK);
    assert_int_equal(mfns_cam_requeue(g_cam, &f), MFNS_CAM_OK);
    struct timespec t0, t1;
    assert_int_equal(clock_gettime(CLOCK_MONOTONIC, &t0), 0);
    assert_int_equal(mfns_cam_dequeue(g_cam, &f, 50), MFNS_CAM_E_TIMEOUT);
    assert_int_equal(clock_gettime(CLOCK_MONOTONIC, &t1), 0);
    const double dt = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
    assert_true(dt >= 0.04 && dt < 2.0);
    assert_int_equal(mfns_cam_dequeue(g_cam, &f, 100), MFNS_CAM_OK); /* the next frame is fine */
    assert_int_equal(f.sequence, 2);
    assert_int_equal(close(wfd), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_replay_8bit_camera_y, setup, teardown),
        cmocka_unit_test_setup_teardown(test_replay_shared_rows_resume_and_blocking_file, setup, teardown),
        cmocka_unit_test_setup_teardown(test_replay_16bit_formats, setup, teardown),
        cmocka_unit_test_setup_teardown(test_replay_paces_to_timestamps, setup, teardown),
        cmocka_unit_test_setup_teardown(test_replay_gaps_and_buffers, setup, teardown),
        cmocka_unit_test_setup_teardown(test_replay_settings_mismatch, setup, teardown),
        cmocka_unit_test_setup_teardown(test_replay_malformed_csv, setup, teardown),
        cmocka_unit_test_setup_teardown(test_replay_malformed_scenario, setup, teardown),
        cmocka_unit_test_setup_teardown(test_replay_malformed_pgm, setup, teardown),
        cmocka_unit_test_setup_teardown(test_replay_pixels_that_look_like_header, setup, teardown),
        cmocka_unit_test_setup_teardown(test_replay_bad_frame_is_skipped, setup, teardown),
    };
    return cmocka_run_group_tests_name("camera_replay", tests, NULL, NULL);
}
