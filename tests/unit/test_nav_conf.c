/* Unit tests of the flight program's configuration (firmware/app/nav_conf,
 * nav_opts --config), the V4L2 camera identity lookup through a fake seam
 * (drivers/camera/camera_v4l2_ident.c) and the self-test's clock flags. */
#define _DEFAULT_SOURCE /* mkstemp under -std=c11 */
#include "tests/unit/support/testutil.h"

#include <errno.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "drivers/camera/camera_v4l2.h"
#include "firmware/app/nav_conf.h"
#include "firmware/app/nav_opts.h"
#include "firmware/app/nav_selftest.h"

/* The board's default for camera z (its board.mk); nav_opts.c falls back to
 * this one where no board defines it (a clang-tidy pass over the file). */
#ifndef MFNS_BOARD_CAM_Z
#define MFNS_BOARD_CAM_Z "/dev/video2"
#endif

static nav_config_t g_cfg; /* large: static */

static int parse(const char *text, char *err, size_t n)
{
    return nav_config_parse(text, strlen(text), &g_cfg, err, n);
}

static void test_parse_ok(void **state)
{
    (void)state;
    char err[NAV_CONFIG_ERR_LEN] = "";
    const char *text = "# the board\n"
                       "\n"
                       "cameras = v4l2\n"
                       "  cam_x=bus_info:platform:vivid-000  \r\n"
                       "cam_y = /dev/v4l/by-path/platform-cam1-video-index0\n"
                       "\tbaud\t=\t921600\n"
                       "uplink = yes\n"
                       "mlock = off\n"
                       "table = /var/lib/mfns/t.mfnstbl"; /* no final newline */
    assert_int_equal(parse(text, err, sizeof err), 0);
    assert_true(g_cfg.set[NAV_CFG_CAMERAS]);
    assert_string_equal(g_cfg.value[NAV_CFG_CAM_X], "bus_info:platform:vivid-000");
    assert_int_equal(g_cfg.line[NAV_CFG_CAM_X], 4);
    assert_int_equal(g_cfg.number[NAV_CFG_BAUD], 921600);
    assert_int_equal(g_cfg.number[NAV_CFG_UPLINK], 1);
    assert_true(g_cfg.set[NAV_CFG_MLOCK]);
    assert_int_equal(g_cfg.number[NAV_CFG_MLOCK], 0);
    assert_string_equal(g_cfg.value[NAV_CFG_TABLE], "/var/lib/mfns/t.mfnstbl");
    assert_false(g_cfg.set[NAV_CFG_CAM_Z]);
    assert_false(g_cfg.set[NAV_CFG_UART]);
    /* an empty file is a configuration with nothing set */
    assert_int_equal(nav_config_parse("", 0, &g_cfg, err, sizeof err), 0);
    assert_false(g_cfg.set[NAV_CFG_CAMERAS]);
    /* inline comments (issue 45: the comment became part of the value) */
    assert_int_equal(parse("baud = 115200  # the bench\ntc_insecure = no\t# never yes on the board\n"
                           "table = /data/run#2/t.mfnstbl # a '#' inside a word stays\n",
                           err, sizeof err),
                     0);
    assert_int_equal(g_cfg.number[NAV_CFG_BAUD], 115200);
    assert_int_equal(g_cfg.number[NAV_CFG_TC_INSECURE], 0);
    assert_string_equal(g_cfg.value[NAV_CFG_TABLE], "/data/run#2/t.mfnstbl");
    assert_int_not_equal(parse("baud = # nothing before the comment\n", err, sizeof err), 0);
    assert_non_null(strstr(err, "no value"));
}

/* security keys only from a file owned by root or the user, not group/world-writable (issue 45) */
static void test_config_trust(void **state)
{
    (void)state;
    char err[NAV_CONFIG_ERR_LEN + 64] = "";
    assert_int_equal(parse("tc_insecure = yes\n", err, sizeof err), 0);
    g_cfg.have_stat = true;
    g_cfg.file_uid = 0;
    g_cfg.file_mode = 0644;
    assert_int_equal(nav_config_check_trust(&g_cfg, 1000u, err, sizeof err), 0); /* root's */
    g_cfg.file_uid = 1000;
    assert_int_equal(nav_config_check_trust(&g_cfg, 1000u, err, sizeof err), 0); /* the user's */
    g_cfg.file_uid = 1001;
    assert_int_equal(nav_config_check_trust(&g_cfg, 1000u, err, sizeof err), -1); /* another user's */
    assert_non_null(strstr(err, "tc_insecure"));
    const uint32_t loose[] = {0664u, 0646u, 0666u, 0620u, 0602u};
    g_cfg.file_uid = 0;
    for (size_t i = 0; i < sizeof loose / sizeof loose[0]; i++) {
        g_cfg.file_mode = loose[i];
        assert_int_equal(nav_config_check_trust(&g_cfg, 0u, err, sizeof err), -1);
    }
    /* no security key: any file */
    assert_int_equal(parse("baud = 9600\n", err, sizeof err), 0);
    g_cfg.have_stat = true;
    g_cfg.file_mode = 0666u;
    g_cfg.file_uid = 4242u;
    assert_int_equal(nav_config_check_trust(&g_cfg, 0u, err, sizeof err), 0);
    const char *guarded[] = {"tc_key = /k\n", "state_dir = /s\n", "uplink = yes\n"};
    for (size_t i = 0; i < sizeof guarded / sizeof guarded[0]; i++) {
        assert_int_equal(parse(guarded[i], err, sizeof err), 0);
        g_cfg.have_stat = true;
        g_cfg.file_mode = 0666u;
        assert_int_equal(nav_config_check_trust(&g_cfg, 0u, err, sizeof err), -1);
    }
}

/* each error names the line and the key */
static void test_errors_name_line_and_key(void **state)
{
    (void)state;
    static const struct {
        const char *text;
        const char *needle;
    } cases[] = {
        {"cameras = v4l2\nbaud = fast\n", "line 2: key 'baud': wants a number 1200..4000000, got 'fast'"},
        {"baud = 100\n", "line 1: key 'baud': wants a number 1200..4000000, got '100'"},
        {"baud = 99999999999999999999\n", "line 1: key 'baud'"},
        {"baud = -1200\n", "line 1: key 'baud'"},
        {"\n\ncameraz = v4l2\n", "line 3: unknown key 'cameraz'"},
        {"cameras = usb\n", "line 1: key 'cameras': wants v4l2 or libcamera, got 'usb'"},
        {"table = relative/t.mfnstbl\n", "line 1: key 'table': wants an absolute path"},
        {"uplink = maybe\n", "line 1: key 'uplink': wants yes or no, got 'maybe'"},
        {"cam_x = a\n# x\ncam_x = b\n", "line 3: key 'cam_x' given twice (first on line 1)"},
        {"cam_x\n", "line 1: not 'key = value' (no '=')"},
        {" = v\n", "line 1: no key before '='"},
        {"cam_x =   \n", "line 1: key 'cam_x': no value"},
        {"cam_x = a\x01b\n", "line 1: key 'cam_x': a control character"},
        {"timeout_ms = 0\n", "line 1: key 'timeout_ms'"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char err[NAV_CONFIG_ERR_LEN] = "";
        assert_int_equal(parse(cases[i].text, err, sizeof err), -1);
        if (strstr(err, cases[i].needle) == NULL) {
            fail_msg("case %zu: '%s' does not contain '%s'", i, err, cases[i].needle);
        }
    }
}

static void test_bounds(void **state)
{
    (void)state;
    char err[NAV_CONFIG_ERR_LEN] = "";
    /* a line of exactly the maximum is read; one more is refused by its length */
    char line[NAV_CONFIG_LINE_MAX + 2];
    memset(line, 'a', sizeof line);
    static const char key[] = "cam_x = ";
    for (size_t i = 0; i + 1u < sizeof key; i++) {
        line[i] = key[i];
    }
    assert_int_equal(nav_config_parse(line, NAV_CONFIG_LINE_MAX, &g_cfg, err, sizeof err), 0);
    assert_int_equal(strlen(g_cfg.value[NAV_CFG_CAM_X]), NAV_CONFIG_LINE_MAX - 8u);
    assert_int_equal(nav_config_parse(line, NAV_CONFIG_LINE_MAX + 1u, &g_cfg, err, sizeof err), -1);
    assert_non_null(strstr(err, "line 1: longer than"));
    /* a NUL inside a value is refused, never truncated silently */
    assert_int_equal(nav_config_parse("cam_x = a\0b\n", 12, &g_cfg, err, sizeof err), -1);
    assert_non_null(strstr(err, "NUL"));
    /* more than a configuration */
    static char big[NAV_CONFIG_MAX_BYTES + 1];
    memset(big, '\n', sizeof big);
    assert_int_equal(nav_config_parse(big, sizeof big, &g_cfg, err, sizeof err), -1);
    assert_int_equal(nav_config_parse(big, sizeof big - 1u, &g_cfg, err, sizeof err), 0);
    /* a message buffer of one byte is never overrun */
    char tiny[1] = {'x'};
    assert_int_equal(parse("nope = 1\n", tiny, sizeof tiny), -1);
    assert_int_equal(tiny[0], '\0');
}

static void write_tmp(char *path, const char *text)
{
    const int fd = mkstemp(path);
    assert_true(fd >= 0);
    assert_int_equal(write(fd, text, strlen(text)), (ssize_t)strlen(text));
    assert_int_equal(close(fd), 0);
}

static nav_opts_t g_o;

static int opts(char **argv, int argc, char *err_text, size_t n)
{
    FILE *err = fmemopen(err_text, n, "w");
    assert_non_null(err);
    const int rc = nav_opts_parse(argc, argv, &g_o, stdout, err);
    assert_int_equal(fclose(err), 0);
    return rc;
}

static void test_file_then_command_line(void **state)
{
    (void)state;
    char path[] = "/tmp/mfns-conf-XXXXXX";
    write_tmp(path, "cameras = v4l2\n"
                    "cam_x = bus_info:platform:vivid-000\n"
                    "cam_y = card:cam-y\n"
                    "uart = /dev/ttyAMA0\n"
                    "baud = 115200\n"
                    "uplink = yes\n"
                    "tc_insecure = yes\n"
                    "table = /var/lib/mfns/t.mfnstbl\n"
                    "state_dir = /var/lib/mfns\n"
                    "budget_units = 4000\n");
    char errs[512] = "";
    char *a1[] = {"mfns-nav", "--config", path};
    assert_int_equal(opts(a1, 3, errs, sizeof errs), 0);
    assert_int_equal(g_o.backend, MFNS_CAM_BACKEND_V4L2);
    assert_string_equal(g_o.cam_path[0], "bus_info:platform:vivid-000");
    assert_string_equal(g_o.cam_path[1], "card:cam-y");
    assert_string_equal(g_o.cam_path[2], MFNS_BOARD_CAM_Z); /* the board's default: not in the file */
    assert_int_equal(g_o.tlm_kind, NAV_TLM_SERIAL);
    assert_string_equal(g_o.tlm_target, "/dev/ttyAMA0");
    assert_int_equal(g_o.baud, 115200);
    assert_int_equal(g_o.tc_kind, NAV_TC_LINK);
    assert_true(g_o.tc_insecure);
    assert_string_equal(g_o.table_path, "/var/lib/mfns/t.mfnstbl");
    assert_string_equal(g_o.state_dir, "/var/lib/mfns");
    assert_int_equal(g_o.budget_units, 4000);

    /* the command line overrides the file, key by key, wherever --config stands */
    char *a2[] = {"mfns-nav", "--tty", "/dev/pts/9", "--baud", "9600",
                  "--replay", "/tmp/frames", "--config", path, "--table", "/tmp/t2.mfnstbl"};
    assert_int_equal(opts(a2, 11, errs, sizeof errs), 0);
    assert_int_equal(g_o.tlm_kind, NAV_TLM_PATH); /* not "give one telemetry output" */
    assert_string_equal(g_o.tlm_target, "/dev/pts/9");
    assert_int_equal(g_o.baud, 9600);
    assert_string_equal(g_o.table_path, "/tmp/t2.mfnstbl");
    /* a replay on the line: the file's cameras do not apply */
    assert_int_equal(g_o.backend, MFNS_CAM_BACKEND_REPLAY);
    assert_string_equal(g_o.cam_path[0], "/tmp/frames");
    /* one camera named on the line, the others from the file; --tc-key replaces tc_insecure */
    char *a3[] = {"mfns-nav", "--config", path, "--cam-y", "/dev/v4l/by-id/y", "--tc-key", "/etc/mfns/k"};
    assert_int_equal(opts(a3, 7, errs, sizeof errs), 0);
    assert_string_equal(g_o.cam_path[0], "bus_info:platform:vivid-000");
    assert_string_equal(g_o.cam_path[1], "/dev/v4l/by-id/y");
    assert_false(g_o.tc_insecure);
    assert_string_equal(g_o.tc_key_path, "/etc/mfns/k");
    (void)unlink(path);
}

static void test_config_errors_reach_the_user(void **state)
{
    (void)state;
    char path[] = "/tmp/mfns-conf-XXXXXX";
    write_tmp(path, "cameras = v4l2\n# ok\nstate_dir = var/lib\n");
    char errs[512] = "";
    char *a1[] = {"mfns-nav", "--config", path};
    assert_int_equal(opts(a1, 3, errs, sizeof errs), -1);
    assert_non_null(strstr(errs, path));
    assert_non_null(strstr(errs, "line 3: key 'state_dir'"));
    (void)unlink(path);
    char *a2[] = {"mfns-nav", "--config", "/nonexistent/mfns-nav.conf"};
    assert_int_equal(opts(a2, 3, errs, sizeof errs), -1);
    assert_non_null(strstr(errs, "/nonexistent/mfns-nav.conf: cannot open: No such file or directory"));
    char *a3[] = {"mfns-nav", "--config", "/tmp"};
    assert_int_equal(opts(a3, 3, errs, sizeof errs), -1);
    assert_non_null(strstr(errs, "not a regular file"));
    char path2[] = "/tmp/mfns-conf-XXXXXX";
    write_tmp(path2, "uart = /dev/ttyAMA0\ntty = /dev/pts/1\n");
    char *a4[] = {"mfns-nav", "--config", path2};
    assert_int_equal(opts(a4, 3, errs, sizeof errs), -1);
    assert_non_null(strstr(errs, ":2: key 'tty': excludes 'uart' (line 1)"));
    (void)unlink(path2);
}

/* ---- camera identity through a fake seam --------------------------------- */

typedef struct {
    const char *card, *bus;
    uint32_t caps;
} fake_node_t;

/* /dev/video0..4: vivid-like instances (a capture and an output node each)
 * and a second capture node sharing a card name */
static const fake_node_t k_nodes[] = {
    {"vivid", "platform:vivid-000", V4L2_CAP_VIDEO_CAPTURE},
    {"vivid", "platform:vivid-000", V4L2_CAP_VIDEO_OUTPUT},
    {"vivid", "platform:vivid-001", V4L2_CAP_VIDEO_CAPTURE_MPLANE},
    {"vivid", "platform:vivid-001", V4L2_CAP_VIDEO_OUTPUT},
    {"cam-z", "usb-0000:01:00.0-1", V4L2_CAP_VIDEO_CAPTURE},
};
#define N_NODES (int)(sizeof k_nodes / sizeof k_nodes[0])

static int f_open(void *ctx, const char *path, int flags)
{
    (void)ctx;
    (void)flags;
    static const char prefix[] = "/dev/video";
    char *end = NULL;
    const long n = strncmp(path, prefix, sizeof prefix - 1u) == 0 ? strtol(path + sizeof prefix - 1u, &end, 10) : -1;
    if (end == NULL || *end != '\0' || n < 0 || n >= N_NODES) {
        errno = ENOENT;
        return -1;
    }
    return 100 + (int)n;
}
static int f_close(void *ctx, int fd)
{
    (void)ctx;
    (void)fd;
    return 0;
}
static int f_ioctl(void *ctx, int fd, unsigned long request, void *arg)
{
    (void)ctx;
    if (request != VIDIOC_QUERYCAP) {
        errno = ENOTTY;
        return -1;
    }
    const fake_node_t *n = &k_nodes[fd - 100];
    struct v4l2_capability *cap = arg;
    (void)snprintf((char *)cap->card, sizeof cap->card, "%s", n->card);
    (void)snprintf((char *)cap->bus_info, sizeof cap->bus_info, "%s", n->bus);
    cap->capabilities = n->caps | V4L2_CAP_DEVICE_CAPS;
    cap->device_caps = n->caps;
    return 0;
}
static const mfns_cam_sys_t k_fake = {NULL, f_open, f_close, f_ioctl, NULL, NULL, NULL, NULL};

static void test_identity_lookup(void **state)
{
    (void)state;
    char path[64], msg[256];
    assert_int_equal(mfns_cam_v4l2_resolve("bus_info:platform:vivid-000", &k_fake, path, sizeof path, msg, sizeof msg),
                     0);
    assert_string_equal(path, "/dev/video0"); /* the capture node, not the output one */
    assert_int_equal(mfns_cam_v4l2_resolve("bus_info:platform:vivid-001", &k_fake, path, sizeof path, msg, sizeof msg),
                     0);
    assert_string_equal(path, "/dev/video2"); /* multi-planar capture counts */
    assert_int_equal(mfns_cam_v4l2_resolve("card:cam-z", &k_fake, path, sizeof path, msg, sizeof msg), 0);
    assert_string_equal(path, "/dev/video4");
    /* ambiguous: two capture nodes named vivid */
    assert_int_equal(mfns_cam_v4l2_resolve("card:vivid", &k_fake, path, sizeof path, msg, sizeof msg), -1);
    assert_non_null(strstr(msg, "matches 2 capture nodes"));
    /* absent */
    assert_int_equal(mfns_cam_v4l2_resolve("bus_info:platform:vivid-002", &k_fake, path, sizeof path, msg, sizeof msg),
                     -1);
    assert_non_null(strstr(msg, "no capture node"));
    assert_int_equal(mfns_cam_v4l2_resolve("card:", &k_fake, path, sizeof path, msg, sizeof msg), -1);
    /* a path is used as given, without asking any device */
    assert_int_equal(mfns_cam_v4l2_resolve("/dev/v4l/by-path/platform-x", &k_fake, path, sizeof path, msg, sizeof msg),
                     0);
    assert_string_equal(path, "/dev/v4l/by-path/platform-x");
    char small[8];
    assert_int_equal(mfns_cam_v4l2_resolve("/dev/v4l/by-path/platform-x", &k_fake, small, sizeof small, msg, sizeof msg),
                     -1);
}

static void test_clock_flags(void **state)
{
    (void)state;
    const int64_t now = 1796256000; /* 2026-12 */
    assert_int_equal(nav_selftest_clock_flags(now, true, 10, 20),
                     NAV_SELFTEST_CLK_UTC_SET | NAV_SELFTEST_CLK_UTC_SYNCED | NAV_SELFTEST_CLK_MONO_OK);
    assert_int_equal(nav_selftest_clock_flags(now, false, 10, 20), NAV_SELFTEST_CLK_UTC_SET | NAV_SELFTEST_CLK_MONO_OK);
    /* a board that booted in 1970: not set, and "synchronised" means nothing then */
    assert_int_equal(nav_selftest_clock_flags(12, true, 10, 20), NAV_SELFTEST_CLK_MONO_OK);
    assert_int_equal(nav_selftest_clock_flags(NAV_SELFTEST_UTC_MIN_S - 1, false, 10, 20), NAV_SELFTEST_CLK_MONO_OK);
    /* a monotonic clock that stands still */
    assert_int_equal(nav_selftest_clock_flags(now, false, 20, 20), NAV_SELFTEST_CLK_UTC_SET);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_parse_ok),
        cmocka_unit_test(test_config_trust),
        cmocka_unit_test(test_errors_name_line_and_key),
        cmocka_unit_test(test_bounds),
        cmocka_unit_test(test_file_then_command_line),
        cmocka_unit_test(test_config_errors_reach_the_user),
        cmocka_unit_test(test_identity_lookup),
        cmocka_unit_test(test_clock_flags),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
