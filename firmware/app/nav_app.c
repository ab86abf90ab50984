/* nav_app.c -- see nav_app.h. */
#define _DEFAULT_SOURCE /* getopt_long, clock_gettime, sigaction under -std=c11 */

#include "nav_app.h"

#include <errno.h>
#include <fcntl.h>
#include <getopt.h>
#include <limits.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "cam_sync.h"
#include "caltable_file.h"
#include "mfns_version.h"
#include "cycle_stats.h"
#include "nav_cmd.h"
#include "nav_cycle.h"
#include "nav_tlm.h"
#include "txq_drain.h"
#include "uart.h"

#ifndef MFNS_BOARD_NAME
#define MFNS_BOARD_NAME "unknown"
#endif
#ifndef MFNS_BOARD_BAUD
#define MFNS_BOARD_BAUD 115200
#endif
#ifndef MFNS_BOARD_CAM_X
#define MFNS_BOARD_CAM_X "/dev/video0"
#define MFNS_BOARD_CAM_Y "/dev/video1"
#define MFNS_BOARD_CAM_Z "/dev/video2"
#endif

#define NAV_APP_VERSION MFNS_VERSION_CODE /* the one version (mk/version.sh) */
#define FLUSH_TRIES 200          /* x 10 ms: telemetry drain at exit */
#define STALE_TRIES 4            /* dequeues per camera and cycle to catch up past stale frames */
#define FAULT_LINES 5            /* stderr lines per camera and kind of fault; the rest in telemetry */

static const char k_letter[MFNS_NUM_CAMERAS] = {'x', 'y', 'z'};

/* One camera as the program sees it. */
typedef struct {
    mfns_cam_t *cam;            /* NULL while closed (a re-open failed) */
    cam_health_t health;
    mfns_cam_frame_t held;      /* a frame ahead of the cycle, kept for a later one */
    bool have_held;
    bool used;                  /* a frame of this camera is fused this cycle */
    bool ended_reported;
    mfns_cam_err_t last_err;
    uint64_t last_used_us;      /* frame time of its last fused frame */
    uint32_t last_seq;
    uint32_t n_stale, n_ahead, n_rejected, n_timeouts, n_lost, n_recovered, n_reopens;
    uint32_t lines_stale, lines_ahead, lines_rejected;
} cam_slot_t;

/* Everything the program holds, in static storage: nothing allocates after
 * start-up (the camera backends allocate their buffers when opened). */
static struct {
    uint8_t table_buf[MFNS_CALTABLE_MAX_BYTES];
    /* Two table slots: TABLE_LOAD validates into the spare one and swaps
     * between cycles (cFS-style); a refused table never touches the live one. */
    mfns_caltable_t tables[2];
    int table_cur;           /* the slot the navigator uses */
    mfns_pose_mode_t solver;
    mfns_nav_t nav;
    mfns_nav_output_t out;
    nav_tlm_t tlm;
    mfns_uart_t uart;
    mfns_cycle_stats_t stats;
    cam_slot_t cs[MFNS_NUM_CAMERAS];
    cam_sync_t sync;
    uint64_t lost_at_ms[MFNS_NUM_CAMERAS];
    uint64_t cam_errors;
    uint32_t tlm_write_errors;
    bool tlm_write_error_printed;
    bool tlm_in_error;    /* the last pump failed with a write error */
    uint32_t cycle_now;
    uint32_t n_fix, n_degraded, n_no_fix; /* FIX, DEGRADED, NO_FIX as in the nav packets sent */
    uint64_t last_t_us;                   /* the last cycle's time: the flight clock */
    uint32_t n_acquire, acq_units_max; /* acquisition cycles; most work in the HK interval */
    mfns_acq_progress_t acq_last;      /* the last acquisition's progress */
    /* uplink (nav_cmd.h, docs/uplink.md) */
    nav_cmd_t cmd;
    mfns_uart_t tc_uart;               /* --tc-tty / --tc-file (--uplink reads app.uart) */
    uint8_t tc_rx[256];                /* bytes read and not yet fed to the handler */
    size_t tc_len, tc_off;
    bool tc_eof, tc_error_printed;
    bool standby;                      /* SET_MODE standby: frames flow, the navigator does not run */
    bool cam_enabled[MFNS_NUM_CAMERAS];
} app;

#define TABLE (app.tables[app.table_cur])

static uint8_t tlm_mode_now(void);
static uint8_t cams_enabled_mask(void);

static volatile sig_atomic_t stop_requested;

static void on_signal(int sig)
{
    (void)sig;
    stop_requested = 1;
}

static uint64_t now_us(void)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_MONOTONIC, &ts) != 0) {
        return 0;
    }
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

static void usage(FILE *f)
{
    fprintf(f,
            "usage: mfns-nav --table FILE (--replay DIR | --v4l2 | --libcamera) [options]\n"
            "\n"
            "The MFNS flight program: camera frames -> beacon centroids -> pose -> telemetry.\n"
            "\n"
            "  --table FILE        calibration table (mfns table build; docs/caltable.md)\n"
            "  --replay DIR        cameras replay an `mfns sim nav` folder (docs/nav-frames.md)\n"
            "  --realtime          replay at the recorded frame rate (default: as fast as possible)\n"
            "  --v4l2              V4L2 cameras (board defaults %s %s %s)\n"
            "  --libcamera         libcamera cameras (first three, or --cam-x/y/z ids)\n"
            "  --cam-x/--cam-y/--cam-z PATH   device or camera id per camera\n"
            "  --timeout-ms N      frame wait per camera and cycle (default 200)\n"
            "  --sync-window-ms N  frames fused in one cycle lie within N ms (default %u)\n"
            "  --serial PORT       telemetry on a real UART via libserialport\n"
            "  --tty PATH          telemetry on a tty, pseudo-terminal or FIFO\n"
            "  --file PATH         telemetry recorded to a file (created/truncated)\n"
            "                      (--tlm-serial, --tlm-tty, --tlm-file: the same, older spelling)\n"
            "  --baud N            UART baud rate (default %d, board %s)\n"
            "  --tc-tty PATH       telecommands from a tty, pseudo-terminal or FIFO (docs/uplink.md)\n"
            "  --tc-file PATH      telecommand frames recorded in a file, read to its end\n"
            "  --uplink            telecommands on the telemetry link itself (--tty/--serial, read-write)\n"
            "  --max-cycles N      stop after N cycles\n"
            "  --init-pose X,Y,Z,ROLL,PITCH,YAW   start tracking from this pose (mm, deg;\n"
            "                      e.g. the docking port); falls back to acquisition if wrong\n"
            "                      (for replays; in operation the ground sends SET_POSE_HINT)\n"
            "  --paper             use the paper's Eq. 3 Newton solver (baseline) instead of ML\n"
            "  -v, --verbose       one line per cycle on stderr\n"
            "  -q, --quiet         no summary line at the end (errors still go to stderr)\n"
            "  -h, --help, --version\n"
            "Exit status: 0 ok, 2 bad usage or input (table, cameras, telemetry target),\n"
            "3 telemetry incomplete (write errors).\n",
            MFNS_BOARD_CAM_X, MFNS_BOARD_CAM_Y, MFNS_BOARD_CAM_Z, MFNS_SYNC_WINDOW_US_DEFAULT / 1000u, MFNS_BOARD_BAUD,
            MFNS_BOARD_NAME);
}

static bool parse_u32(const char *s, uint32_t lo, uint32_t hi, uint32_t *v)
{
    char *end = NULL;
    errno = 0;
    const unsigned long x = strtoul(s, &end, 10);
    if (errno != 0 || end == s || *end != '\0' || s[0] == '-' || x < lo || x > hi) {
        return false;
    }
    *v = (uint32_t)x;
    return true;
}

static bool parse_pose(const char *s, float v[6])
{
    const char *p = s;
    for (int i = 0; i < 6; i++) {
        char *end = NULL;
        errno = 0;
        const double x = strtod(p, &end);
        if (errno != 0 || end == p || !(x > -1e6 && x < 1e6)) {
            return false;
        }
        v[i] = (float)x;
        if (i < 5) {
            if (*end != ',') {
                return false;
            }
            p = end + 1;
        } else if (*end != '\0') {
            return false;
        }
    }
    return true;
}

int nav_app_parse_args(int argc, char **argv, nav_app_opts_t *o, FILE *out, FILE *err)
{
    enum { O_TABLE = 256, O_REPLAY, O_REALTIME, O_V4L2, O_LIBCAMERA, O_CAMX, O_CAMY, O_CAMZ, O_TIMEOUT,
           O_SERIAL, O_TTY, O_FILE, O_BAUD, O_MAX, O_PAPER, O_VERBOSE, O_HELP, O_VERSION, O_INIT, O_QUIET,
           O_SYNC_WINDOW, O_TC_TTY, O_TC_FILE, O_UPLINK };
    static const struct option opts[] = {
        {"table", required_argument, NULL, O_TABLE},     {"replay", required_argument, NULL, O_REPLAY},
        {"realtime", no_argument, NULL, O_REALTIME},     {"v4l2", no_argument, NULL, O_V4L2},
        {"libcamera", no_argument, NULL, O_LIBCAMERA},   {"cam-x", required_argument, NULL, O_CAMX},
        {"cam-y", required_argument, NULL, O_CAMY},      {"cam-z", required_argument, NULL, O_CAMZ},
        {"timeout-ms", required_argument, NULL, O_TIMEOUT}, {"tlm-serial", required_argument, NULL, O_SERIAL},
        {"tlm-tty", required_argument, NULL, O_TTY},     {"tlm-file", required_argument, NULL, O_FILE},
        {"baud", required_argument, NULL, O_BAUD},       {"max-cycles", required_argument, NULL, O_MAX},
        {"paper", no_argument, NULL, O_PAPER},           {"verbose", no_argument, NULL, O_VERBOSE},
        {"init-pose", required_argument, NULL, O_INIT},  {"help", no_argument, NULL, O_HELP},
        {"version", no_argument, NULL, O_VERSION},       {"quiet", no_argument, NULL, O_QUIET},
        {"sync-window-ms", required_argument, NULL, O_SYNC_WINDOW},
        /* the transport spelling shared with mfns-ground and mfns-tlm-gen (README) */
        {"serial", required_argument, NULL, O_SERIAL},   {"tty", required_argument, NULL, O_TTY},
        {"file", required_argument, NULL, O_FILE},
        {"tc-tty", required_argument, NULL, O_TC_TTY}, {"tc-file", required_argument, NULL, O_TC_FILE},
        {"uplink", no_argument, NULL, O_UPLINK},
        {NULL, 0, NULL, 0},
    };
    memset(o, 0, sizeof *o);
    o->backend = MFNS_CAM_BACKEND_COUNT_;
    o->frame_timeout_ms = 200;
    o->sync_window_us = MFNS_SYNC_WINDOW_US_DEFAULT;
    o->baud = MFNS_BOARD_BAUD;
    o->solver = MFNS_POSE_MODE_ML;
    const char *cam_override[3] = {NULL, NULL, NULL};
    optind = 1;
    opterr = 0;
    for (int guard = 0; guard < argc + 1; guard++) {
        const int c = getopt_long(argc, argv, "hqv", opts, NULL);
        if (c == -1) {
            break;
        }
        uint32_t v = 0;
        switch (c) {
        case O_TABLE:
            o->table_path = optarg;
            break;
        case O_REPLAY:
            o->backend = MFNS_CAM_BACKEND_REPLAY;
            o->cam_path[0] = o->cam_path[1] = o->cam_path[2] = optarg;
            break;
        case O_REALTIME:
            o->realtime = true;
            break;
        case O_V4L2:
            o->backend = MFNS_CAM_BACKEND_V4L2;
            o->cam_path[0] = MFNS_BOARD_CAM_X;
            o->cam_path[1] = MFNS_BOARD_CAM_Y;
            o->cam_path[2] = MFNS_BOARD_CAM_Z;
            break;
        case O_LIBCAMERA:
            o->backend = MFNS_CAM_BACKEND_LIBCAMERA;
            o->cam_path[0] = o->cam_path[1] = o->cam_path[2] = "";
            break;
        case O_CAMX:
        case O_CAMY:
        case O_CAMZ:
            cam_override[c - O_CAMX] = optarg;
            break;
        case O_TIMEOUT:
            if (!parse_u32(optarg, 1, MFNS_CAM_MAX_TIMEOUT_MS, &v)) {
                fprintf(err, "mfns-nav: --timeout-ms wants 1..%d, got '%s'\n", MFNS_CAM_MAX_TIMEOUT_MS, optarg);
                return -1;
            }
            o->frame_timeout_ms = (int)v;
            break;
        case O_SYNC_WINDOW:
            if (!parse_u32(optarg, 1, MFNS_SYNC_WINDOW_US_MAX / 1000u, &v)) {
                fprintf(err, "mfns-nav: --sync-window-ms wants 1..%u, got '%s'\n", MFNS_SYNC_WINDOW_US_MAX / 1000u,
                        optarg);
                return -1;
            }
            o->sync_window_us = v * 1000u;
            break;
        case O_SERIAL:
        case O_TTY:
        case O_FILE:
            if (o->tlm_kind != NAV_TLM_NONE) {
                fprintf(err, "mfns-nav: give one telemetry output (--serial, --tty or --file)\n");
                return -1;
            }
            o->tlm_kind = c == O_SERIAL ? NAV_TLM_SERIAL : (c == O_TTY ? NAV_TLM_PATH : NAV_TLM_FILE);
            o->tlm_target = optarg;
            break;
        case O_TC_TTY:
        case O_TC_FILE:
        case O_UPLINK:
            if (o->tc_kind != NAV_TC_NONE) {
                fprintf(err, "mfns-nav: give one telecommand input (--tc-tty, --tc-file or --uplink)\n");
                return -1;
            }
            o->tc_kind = c == O_TC_TTY ? NAV_TC_PATH : (c == O_TC_FILE ? NAV_TC_FILE : NAV_TC_LINK);
            o->tc_target = c == O_UPLINK ? NULL : optarg;
            break;
        case O_BAUD:
            if (!parse_u32(optarg, 1200, 4000000, &o->baud)) {
                fprintf(err, "mfns-nav: --baud wants 1200..4000000, got '%s'\n", optarg);
                return -1;
            }
            break;
        case O_MAX:
            if (!parse_u32(optarg, 1, UINT32_MAX - 1, &o->max_cycles)) {
                fprintf(err, "mfns-nav: --max-cycles wants a positive number, got '%s'\n", optarg);
                return -1;
            }
            break;
        case O_INIT:
            if (!parse_pose(optarg, o->init_pose)) {
                fprintf(err, "mfns-nav: --init-pose wants six numbers X,Y,Z,ROLL,PITCH,YAW, got '%s'\n", optarg);
                return -1;
            }
            o->have_init_pose = true;
            break;
        case O_PAPER:
            o->solver = MFNS_POSE_MODE_PAPER;
            break;
        case O_VERBOSE:
        case 'v':
            o->verbose = true;
            break;
        case O_QUIET:
        case 'q':
            o->quiet = true;
            break;
        case 'h':
        case O_HELP:
            usage(out);
            return 1;
        case O_VERSION:
            fprintf(out, "mfns-nav %s (board %s)\n", MFNS_VERSION_STR, MFNS_BOARD_NAME);
            return 1;
        default:
            fprintf(err, "mfns-nav: unknown or incomplete option '%s' (see --help)\n", argv[optind - 1]);
            return -1;
        }
    }
    if (optind < argc) {
        fprintf(err, "mfns-nav: unexpected argument '%s' (see --help)\n", argv[optind]);
        return -1;
    }
    if (o->table_path == NULL) {
        fprintf(err, "mfns-nav: --table FILE is required (see --help)\n");
        return -1;
    }
    if (o->backend == MFNS_CAM_BACKEND_COUNT_) {
        fprintf(err, "mfns-nav: choose the cameras: --replay DIR, --v4l2 or --libcamera (see --help)\n");
        return -1;
    }
    if (o->tc_kind == NAV_TC_LINK && o->tlm_kind != NAV_TLM_SERIAL && o->tlm_kind != NAV_TLM_PATH) {
        fprintf(err, "mfns-nav: --uplink reads commands from the telemetry link: give --serial or --tty\n");
        return -1;
    }
    for (int k = 0; k < 3; k++) {
        if (cam_override[k] != NULL) {
            if (o->backend == MFNS_CAM_BACKEND_REPLAY) {
                fprintf(err, "mfns-nav: --cam-x/y/z do not apply to --replay\n");
                return -1;
            }
            o->cam_path[k] = cam_override[k];
        }
    }
    return 0;
}

static void send_event(uint32_t cycle, uint64_t t_us, tlm_event_code_t code, tlm_severity_t sev, uint8_t subject,
                       int32_t a0, int32_t a1)
{
    (void)nav_tlm_event(&app.tlm, cycle, t_us, code, sev, subject, a0, a1); /* failures counted in tlm */
}

/* Opens the telemetry output. A port or FIFO that is absent (no reader yet,
 * adapter not plugged) is not fatal: the transport re-opens it at its retry
 * cadence, exactly as after a link lost later; frames wait in the queue. */
static int open_tlm(const nav_app_opts_t *o)
{
    int rc = MFNS_UART_OK;
    struct stat st;
    if (o->tc_kind == NAV_TC_LINK && o->tlm_kind == NAV_TLM_PATH && stat(o->tlm_target, &st) == 0 &&
        S_ISFIFO(st.st_mode)) {
        /* a FIFO carries one direction: read-write would read our own telemetry back */
        fprintf(stderr, "mfns-nav: --uplink needs a tty; for a FIFO give the commands their own: --tc-tty PATH\n");
        return -1;
    }
    switch (o->tlm_kind) {
    case NAV_TLM_NONE:
        return 0;
    case NAV_TLM_SERIAL:
        rc = mfns_uart_open_serial(&app.uart, o->tlm_target, o->baud,
                                   o->tc_kind == NAV_TC_LINK ? MFNS_UART_RW : MFNS_UART_WRITE);
        break;
    case NAV_TLM_PATH:
        rc = mfns_uart_open_path(&app.uart, o->tlm_target, o->baud,
                                 o->tc_kind == NAV_TC_LINK ? MFNS_UART_RW : MFNS_UART_WRITE);
        break;
    case NAV_TLM_FILE: {
        const int fd = open(o->tlm_target, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
        if (fd < 0) {
            fprintf(stderr, "mfns-nav: cannot create telemetry file %s: %s\n", o->tlm_target, strerror(errno));
            return -1;
        }
        rc = mfns_uart_attach_fd(&app.uart, fd, true, MFNS_UART_WRITE);
        break;
    }
    }
    if (rc == MFNS_UART_ERR_OPEN && o->tlm_kind != NAV_TLM_FILE) {
        fprintf(stderr, "mfns-nav: telemetry %s not available yet (%s): retrying every %u..%u ms\n", o->tlm_target,
                strerror(app.uart.last_errno), app.uart.retry_min_ms, app.uart.retry_max_ms);
        return 0;
    }
    if (rc != MFNS_UART_OK) {
        fprintf(stderr, "mfns-nav: telemetry %s: %s\n", o->tlm_target, mfns_uart_strerror(rc));
        return -1;
    }
    return 0;
}

static void pump_tlm(const nav_app_opts_t *o)
{
    if (o->tlm_kind != NAV_TLM_NONE) {
        /* link loss: frames wait, oldest dropped; a write error is counted and reported */
        const int rc = txq_drain(&app.tlm.q, &app.uart, now_us() / 1000u);
        if (rc == MFNS_UART_ERR_IO) {
            app.tlm_write_errors++;
            if (!app.tlm_in_error) { /* reaches the ground if the link comes back */
                app.tlm_in_error = true;
                send_event(app.cycle_now, 0, TLM_EVT_TLM_WRITE_ERROR, TLM_SEV_ERROR, 0, app.uart.last_errno,
                           (int32_t)app.tlm_write_errors);
            }
            if (!app.tlm_write_error_printed) {
                app.tlm_write_error_printed = true;
                fprintf(stderr, "mfns-nav: telemetry write to %s failed: %s (counting; frames wait in the queue)\n",
                        o->tlm_target, strerror(app.uart.last_errno));
            }
        } else if (rc == MFNS_UART_OK) {
            app.tlm_in_error = false;
        }
    } else {
        /* no link: discard, as a disconnected UART would */
        const uint8_t *d = NULL;
        for (int i = 0; i < (int)TLM_TXQ_FRAMES && tlm_txq_peek(&app.tlm.q, &d) > 0; i++) {
            tlm_txq_consume(&app.tlm.q, tlm_txq_peek(&app.tlm.q, &d));
        }
    }
}

/* Opens and starts camera k; with resume (a re-open), a replay camera goes
 * on after frame time after_us instead of from its first frame. */
static mfns_cam_err_t open_camera(const nav_app_opts_t *o, int k, bool resume, uint64_t after_us, char *msg,
                                  size_t msg_size)
{
    mfns_cam_settings_t s = mfns_cam_default_settings(o->backend, o->cam_path[k]);
    s.replay_camera = k_letter[k];
    s.replay_realtime = o->realtime;
    s.replay_resume = resume;
    s.replay_resume_after_ns = after_us * 1000u;
    s.recover_attempts = 20;
    s.width = TABLE.rig.cam[k].k.width;
    s.height = TABLE.rig.cam[k].k.height;
    cam_slot_t *c = &app.cs[k];
    mfns_cam_err_t e = mfns_cam_open(&s, &c->cam, msg, msg_size);
    if (e != MFNS_CAM_OK) {
        return e;
    }
    e = mfns_cam_start(c->cam);
    if (e != MFNS_CAM_OK) {
        (void)snprintf(msg, msg_size, "start: %s", mfns_cam_message(c->cam));
        mfns_cam_close(c->cam);
        c->cam = NULL;
    }
    return e;
}

static int open_cameras(const nav_app_opts_t *o)
{
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        cam_health_init(&app.cs[k].health);
        char msg[MFNS_CAM_MSG_LEN];
        const mfns_cam_err_t e = open_camera(o, k, false, 0, msg, sizeof msg);
        if (e != MFNS_CAM_OK) {
            fprintf(stderr, "mfns-nav: camera %c: %s: %s\n", k_letter[k], mfns_cam_strerror(e), msg);
            return -1;
        }
    }
    return 0;
}

static bool to_nav_frame(const mfns_cam_frame_t *f, mfns_frame_t *nf)
{
    mfns_pixfmt_t fmt;
    switch (f->pixfmt) {
    case MFNS_CAM_PIX_GREY:
        fmt = MFNS_PIXFMT_GREY;
        break;
    case MFNS_CAM_PIX_Y10:
        fmt = MFNS_PIXFMT_Y10;
        break;
    case MFNS_CAM_PIX_Y12:
        fmt = MFNS_PIXFMT_Y12;
        break;
    case MFNS_CAM_PIX_Y16:
        fmt = MFNS_PIXFMT_Y16;
        break;
    default:
        return false;
    }
    if (f->width > UINT16_MAX || f->height > UINT16_MAX || (uint64_t)f->stride * f->height > f->bytesused) {
        return false; /* short payload: never centroid past the data */
    }
    *nf = (mfns_frame_t){f->data, (uint16_t)f->width, (uint16_t)f->height, f->stride, fmt};
    return true;
}

/* Camera events raised by the driver since the last cycle, into telemetry. */
static void camera_events(uint32_t cycle, uint64_t t_us)
{
    const uint64_t ms = now_us() / 1000u;
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        cam_slot_t *c = &app.cs[k];
        const uint32_t ev = c->cam ? mfns_cam_take_events(c->cam) : 0u;
        if ((ev & MFNS_CAM_EV_LOST) != 0U) {
            app.lost_at_ms[k] = ms;
            send_event(cycle, t_us, TLM_EVT_CAMERA_LOST, TLM_SEV_WARNING, (uint8_t)k, MFNS_CAM_E_LOST, 0);
        }
        if ((ev & MFNS_CAM_EV_RECOVERED) != 0U) {
            send_event(cycle, t_us, TLM_EVT_CAMERA_RECOVERED, TLM_SEV_INFO, (uint8_t)k,
                       (int32_t)(ms - app.lost_at_ms[k]), 0);
        }
        if ((ev & MFNS_CAM_EV_RECOVERY_FAILED) != 0U) {
            c->health.state = CAM_HEALTH_OFF;
            send_event(cycle, t_us, TLM_EVT_CAMERA_LOST, TLM_SEV_ERROR, (uint8_t)k, MFNS_CAM_E_NO_DEVICE, 0);
        }
    }
}

static uint8_t cam_state(const cam_slot_t *c)
{
    switch (c->health.state) {
    case CAM_HEALTH_LOST: return TLM_CAM_LOST;
    case CAM_HEALTH_OFF: return TLM_CAM_OFF;
    case CAM_HEALTH_ENDED: return TLM_CAM_ENDED;
    case CAM_HEALTH_UP: break;
    }
    return c->used ? TLM_CAM_OK : TLM_CAM_SKIPPED;
}

static void camera_packets(uint32_t cycle, uint64_t t_us, const mfns_cam_frame_t fr[3])
{
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        const cam_slot_t *cs = &app.cs[k];
        tlm_packet_t p;
        memset(&p, 0, sizeof p);
        p.type = TLM_TYPE_CAMERA;
        p.time = tlm_time_from_us(t_us);
        tlm_camera_t *c = &p.u.camera;
        mfns_cam_stats_t st;
        memset(&st, 0, sizeof st);
        if (cs->cam) {
            (void)mfns_cam_get_stats(cs->cam, &st); /* zeros on failure are the honest answer */
        }
        c->cycle = cycle;
        c->camera = (uint8_t)k;
        c->state = cam_state(cs);
        c->blobs = (uint8_t)(app.out.cam[k].blobs > 255 ? 255 : app.out.cam[k].blobs);
        c->beacons_identified = (uint8_t)app.out.cam[k].identified;
        c->exposure_us = cs->used && fr[k].exposure_us > 0 ? (uint32_t)fr[k].exposure_us : 0;
        c->frame_seq = cs->used ? fr[k].sequence : 0;
        c->frames_dropped = (uint32_t)(st.dropped > UINT32_MAX ? UINT32_MAX : st.dropped);
        (void)nav_tlm_send(&app.tlm, &p);
    }
}

/* n_cycles: cycles run so far (the one of index `cycle` included). */
static void housekeeping(uint32_t cycle, uint32_t n_cycles, uint64_t t_us, uint32_t table_crc)
{
    tlm_packet_t p;
    memset(&p, 0, sizeof p);
    p.type = TLM_TYPE_HK;
    p.time = tlm_time_from_us(t_us);
    tlm_hk_t *h = &p.u.hk;
    h->cycle = cycle;
    h->mode = tlm_mode_now();
    h->cpu_load_permille = (uint16_t)(10.0f * mfns_cycle_stats_cpu_load_pct(&app.stats));
    h->cycle_p50_us = mfns_cycle_stats_percentile(&app.stats, 50.0f);
    h->cycle_p95_us = mfns_cycle_stats_percentile(&app.stats, 95.0f);
    h->cycle_p99_us = mfns_cycle_stats_percentile(&app.stats, 99.0f);
    h->cycle_max_us = app.stats.max_us;
    h->n_cycles = n_cycles;
    h->n_fix = app.n_fix;
    h->n_degraded = app.n_degraded;
    h->n_no_fix = app.n_no_fix;
    h->cams_enabled = cams_enabled_mask(); /* CAMERA_DISABLE clears bits */
    h->n_cmd_accepted = app.cmd.n_accepted;
    h->n_cmd_rejected = app.cmd.n_rejected;
    h->cmd_seq_last = app.cmd.seq_last;
    h->n_tlm_dropped = app.tlm.q.dropped;
    h->n_cam_errors = (uint32_t)(app.cam_errors > UINT32_MAX ? UINT32_MAX : app.cam_errors);
    h->table_crc32 = table_crc;
    h->n_acquire = app.n_acquire;
    h->acq_units_max = app.acq_units_max;
    h->acq_units_last = app.acq_last.units;
    h->acq_band_last = app.acq_last.band;
    h->acq_best_last = app.acq_last.best_inliers;
    app.acq_units_max = 0; /* per report interval */
    (void)nav_tlm_send(&app.tlm, &p);
    if (app.tlm.q.dropped != app.tlm.last_dropped_reported) {
        send_event(cycle, t_us, TLM_EVT_TLM_DROPPED, TLM_SEV_WARNING, 0,
                   (int32_t)(app.tlm.q.dropped - app.tlm.last_dropped_reported), 0);
        app.tlm.last_dropped_reported = app.tlm.q.dropped;
    }
    mfns_cycle_stats_reset(&app.stats);
}

static void close_all(const nav_app_opts_t *o)
{
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        mfns_cam_close(app.cs[k].cam);
        app.cs[k].cam = NULL;
    }
    if (o->tlm_kind != NAV_TLM_NONE) {
        for (int i = 0; i < FLUSH_TRIES && tlm_txq_frames(&app.tlm.q) > 0; i++) {
            pump_tlm(o);
            if (tlm_txq_frames(&app.tlm.q) > 0) {
                (void)usleep(10000);
            }
        }
        mfns_uart_close(&app.uart);
    }
    mfns_uart_close(&app.tc_uart);
}

/* One stderr line per fault, the first FAULT_LINES of each kind per camera. */
static void fault_line(uint32_t *printed, int k, const char *line)
{
    if (*printed >= FAULT_LINES + 1u) {
        return;
    }
    if (++*printed > FAULT_LINES) {
        fprintf(stderr, "mfns-nav: camera %c: further faults of this kind in telemetry only\n", k_letter[k]);
        return;
    }
    fprintf(stderr, "mfns-nav: camera %c: %s\n", k_letter[k], line);
}

/* The frame of camera k for this cycle, into fr: the one held from an earlier
 * cycle, or a fresh one; stale frames are given back and the camera asked
 * again (bounded) so it catches up. Returns true with a frame. */
static bool gather(const nav_app_opts_t *o, int k, uint32_t cycle, uint64_t prog_us, mfns_cam_frame_t *fr, bool *ended)
{
    cam_slot_t *c = &app.cs[k];
    if (c->have_held) {
        *fr = c->held;
        c->have_held = false;
        return true;
    }
    if (!c->cam || c->health.state == CAM_HEALTH_ENDED) {
        return false;
    }
    /* a camera already down is asked without waiting: it never stalls the others */
    const bool down = c->health.state != CAM_HEALTH_UP;
    for (int attempt = 0; attempt < STALE_TRIES; attempt++) {
        /* after a stale frame the fresh one may still be on its way: wait for it as usual */
        const mfns_cam_err_t e = mfns_cam_dequeue(c->cam, fr, down ? 0 : o->frame_timeout_ms);
        if (e == MFNS_CAM_OK) {
            const uint64_t t = fr->timestamp_ns / 1000u;
            if (!cam_sync_is_stale(&app.sync, t)) {
                return true;
            }
            c->n_stale++;
            const int32_t off = cam_sync_offset_us(t, app.sync.last_us);
            send_event(cycle, prog_us, TLM_EVT_CAMERA_STALE, TLM_SEV_WARNING, (uint8_t)k, off, (int32_t)fr->sequence);
            char line[192];
            (void)snprintf(line, sizeof line,
                           "cycle %u: frame %u at %.6f s is stale (%.1f ms after the last cycle's %.6f s): dropped",
                           cycle, fr->sequence, (double)t * 1e-6, (double)off * 1e-3, (double)app.sync.last_us * 1e-6);
            fault_line(&c->lines_stale, k, line);
            (void)mfns_cam_requeue(c->cam, fr);
            continue;
        }
        c->last_err = e;
        if (e == MFNS_CAM_E_END) {
            *ended = true;
        } else if (e == MFNS_CAM_E_DATA) {
            c->n_rejected++;
            app.cam_errors++;
            send_event(cycle, prog_us, TLM_EVT_FRAME_REJECTED, TLM_SEV_WARNING, (uint8_t)k, (int32_t)e,
                       (int32_t)c->n_rejected);
            char line[256];
            (void)snprintf(line, sizeof line, "cycle %u: frame rejected: %s", cycle, mfns_cam_message(c->cam));
            fault_line(&c->lines_rejected, k, line);
        } else {
            app.cam_errors++; /* timeout, device lost or recovering, I/O: no frame this cycle */
            if (e == MFNS_CAM_E_TIMEOUT) {
                c->n_timeouts++;
            }
            if (e == MFNS_CAM_E_NO_DEVICE) {
                c->health.state = CAM_HEALTH_OFF;
            }
            if (o->verbose) {
                fprintf(stderr, "mfns-nav: cycle %u camera %c: %s: %s\n", cycle, k_letter[k], mfns_cam_strerror(e),
                        mfns_cam_message(c->cam));
            }
        }
        return false;
    }
    return false;
}

/* Health transitions after a cycle: LOST after MFNS_CAM_LOST_CYCLES cycles
 * without a fused frame, periodic re-open while down, RECOVERED on the next
 * fused frame. Each transition: an event and one stderr line. */
static void camera_health(const nav_app_opts_t *o, uint32_t cycle, uint64_t t_us)
{
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        cam_slot_t *c = &app.cs[k];
        if (!app.cam_enabled[k]) {
            continue; /* disabled by command: neither LOST nor re-opened */
        }
        const cam_health_event_t ev = cam_health_update(&c->health, c->used);
        if (ev == CAM_HEALTH_EV_LOST) {
            c->n_lost++;
            send_event(cycle, t_us, TLM_EVT_CAMERA_LOST, TLM_SEV_WARNING, (uint8_t)k, (int32_t)c->last_err,
                       (int32_t)c->health.missed);
            fprintf(stderr, "mfns-nav: camera %c lost: no valid frame for %u cycles (cycle %u; last: %s)\n", k_letter[k],
                    c->health.missed, cycle, mfns_cam_strerror(c->last_err));
        } else if (ev == CAM_HEALTH_EV_RECOVERED) {
            c->n_recovered++;
            const uint64_t outage_us = t_us - c->last_used_us;
            send_event(cycle, t_us, TLM_EVT_CAMERA_RECOVERED, TLM_SEV_INFO, (uint8_t)k,
                       (int32_t)(outage_us / 1000u > INT32_MAX ? INT32_MAX : outage_us / 1000u),
                       (int32_t)c->health.outage);
            fprintf(stderr, "mfns-nav: camera %c recovered at cycle %u after %u cycles (%.1f ms of frame time)\n",
                    k_letter[k], cycle, c->health.outage, (double)outage_us * 1e-3);
        }
        if (c->used) {
            c->last_used_us = t_us;
        }
        if (cam_health_reopen_due(&c->health)) {
            c->n_reopens++;
            mfns_cam_close(c->cam);
            c->cam = NULL;
            c->have_held = false;
            char msg[MFNS_CAM_MSG_LEN];
            const mfns_cam_err_t e = open_camera(o, k, true, t_us, msg, sizeof msg);
            if (e != MFNS_CAM_OK) {
                c->last_err = e;
                if (o->verbose) {
                    fprintf(stderr, "mfns-nav: camera %c: re-open: %s: %s\n", k_letter[k], mfns_cam_strerror(e), msg);
                }
            }
        }
    }
}

/* A camera whose recorded frames ended while others go on: reported once. */
static void camera_ended(uint32_t cycle, uint64_t t_us, int k)
{
    cam_slot_t *c = &app.cs[k];
    c->health.state = CAM_HEALTH_ENDED;
    if (c->ended_reported) {
        return;
    }
    c->ended_reported = true;
    app.cam_errors++;
    mfns_cam_stats_t st;
    memset(&st, 0, sizeof st);
    (void)mfns_cam_get_stats(c->cam, &st);
    send_event(cycle, t_us, TLM_EVT_CAMERA_ENDED, TLM_SEV_WARNING, (uint8_t)k, (int32_t)c->last_seq,
               (int32_t)(st.frames > INT32_MAX ? INT32_MAX : st.frames));
    fprintf(stderr, "mfns-nav: camera %c: recorded frames ended at cycle %u (last frame %u) while other cameras go on\n",
            k_letter[k], cycle, c->last_seq);
}

static void print_summary(const char *why, uint32_t cycle, uint32_t lost_frames, uint32_t produced)
{
    fprintf(stderr,
            "mfns-nav: stopped (%s) after %u cycles: %u fix, %u degraded, %u no fix, %u telemetry frames dropped\n",
            why, cycle, app.n_fix, app.n_degraded, app.n_no_fix, lost_frames);
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        const cam_slot_t *c = &app.cs[k];
        if (c->n_stale + c->n_ahead + c->n_rejected + c->n_timeouts + c->n_lost + (c->ended_reported ? 1u : 0u) > 0) {
            fprintf(stderr,
                    "mfns-nav: camera %c faults: %u rejected, %u stale, %u out of step, %u timeouts, %u lost, "
                    "%u recovered, %u re-opens%s\n",
                    k_letter[k], c->n_rejected, c->n_stale, c->n_ahead, c->n_timeouts, c->n_lost, c->n_recovered,
                    c->n_reopens, c->ended_reported ? ", frames ended early" : "");
        }
    }
    if (app.cmd.rx.frames > 0) {
        fprintf(stderr, "mfns-nav: commands: %u accepted, %u rejected (since boot or RESET_COUNTERS)\n",
                app.cmd.n_accepted, app.cmd.n_rejected);
    }
    if (app.tlm_write_errors > 0 || lost_frames > 0) {
        fprintf(stderr, "mfns-nav: telemetry: %u frames produced, %u sent, %u lost (%u write errors)\n", produced,
                app.tlm.q.sent, lost_frames, app.tlm_write_errors);
    }
}

/* ---- telecommands (nav_cmd.h, docs/uplink.md) ---- */

/* The pose of x, y, z (mm) and 2-1-3 Euler roll, pitch, yaw (deg), as a
 * navigator prior: --init-pose and SET_POSE_HINT share it. */
static mfns_nav_status_t set_prior_from(float x, float y, float z, float roll_deg, float pitch_deg, float yaw_deg)
{
    const float d2r = 0.017453292519943295f;
    const mfns_euler_t e = {roll_deg * d2r, pitch_deg * d2r, yaw_deg * d2r};
    const mfns_pose_t p0 = mfns_pose_from_position(mfns_euler213_to_m3(e), mfns_v3(x, y, z));
    return mfns_nav_set_prior(&app.nav, &p0);
}

static uint8_t cams_enabled_mask(void)
{
    unsigned m = 0;
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        m |= app.cam_enabled[k] ? (1u << k) : 0u;
    }
    return (uint8_t)m;
}

static uint8_t tlm_mode_now(void)
{
    return app.standby ? (uint8_t)TLM_MODE_STANDBY : nav_tlm_mode(app.nav.mode);
}

static void cmd_event(void *ctx, tlm_event_code_t code, tlm_severity_t sev, uint8_t subject, int32_t a0, int32_t a1)
{
    (void)ctx;
    send_event(app.cycle_now, app.last_t_us, code, sev, subject, a0, a1);
    if (code == TLM_EVT_CMD_ACCEPTED) {
        fprintf(stderr, "mfns-nav: cycle %u: command %s (seq %d) accepted\n", app.cycle_now, tc_opcode_name(subject),
                (int)a0);
    } else {
        fprintf(stderr, "mfns-nav: cycle %u: command %s (seq %d) rejected: %s\n", app.cycle_now,
                subject != 0u ? tc_opcode_name(subject) : "-", (int)a0, tc_strerror((int)a1));
    }
}

static tc_status_t cmd_set_mode(void *ctx, uint8_t mode, int32_t *arg1)
{
    (void)ctx;
    const uint8_t before = tlm_mode_now();
    if (mode == TLM_MODE_TRACK && !app.nav.have_prior) {
        return TC_E_STATE; /* nothing to track from: send SET_POSE_HINT first */
    }
    if (mode == TLM_MODE_STANDBY) {
        app.standby = true;
    } else if (mode == TLM_MODE_ACQUIRE) {
        app.standby = false;
        mfns_nav_lose_track(&app.nav);
    } else if (mode == TLM_MODE_TRACK) {
        const mfns_pose_t prior = app.nav.prior;
        if (mfns_nav_set_prior(&app.nav, &prior) != MFNS_NAV_OK) {
            return TC_E_STATE;
        }
        app.standby = false;
    } else {
        return TC_E_ARG;
    }
    *arg1 = mode;
    const uint8_t after = tlm_mode_now();
    if (after != before) {
        send_event(app.cycle_now, app.last_t_us, TLM_EVT_MODE_CHANGE, TLM_SEV_INFO, 0, before, after);
    }
    return TC_OK;
}

static tc_status_t cmd_set_pose_hint(void *ctx, const tc_pose_hint_t *h, int32_t *arg1)
{
    (void)ctx;
    (void)arg1;
    /* a prior for the next cycles, verified there like any other: never a fix by itself */
    const mfns_nav_status_t st =
        set_prior_from((float)h->pos_um[0] * 1e-3f, (float)h->pos_um[1] * 1e-3f, (float)h->pos_um[2] * 1e-3f,
                       (float)h->att_udeg[0] * 1e-6f, (float)h->att_udeg[1] * 1e-6f, (float)h->att_udeg[2] * 1e-6f);
    return st == MFNS_NAV_OK ? TC_OK : TC_E_ARG;
}

static tc_status_t cmd_camera_enable(void *ctx, uint8_t k, bool enable, int32_t *arg1)
{
    (void)ctx;
    if (k >= MFNS_NUM_CAMERAS) {
        return TC_E_ARG;
    }
    app.cam_enabled[k] = enable;
    *arg1 = cams_enabled_mask();
    return TC_OK;
}

/* TABLE_LOAD: read and validate completely into the spare slot, then bind the
 * navigator to it (between cycles, so no cycle ever sees half a table). The
 * old table keeps running on any failure. */
static tc_status_t cmd_table_load(void *ctx, const char *path, int32_t *arg1)
{
    (void)ctx;
    const int spare = 1 - app.table_cur;
    mfns_caltable_t *nt = &app.tables[spare];
    uint32_t off = 0;
    mfns_caltable_status_t ts = mfns_caltable_load_file(path, app.table_buf, sizeof app.table_buf, nt, &off);
    if (ts == MFNS_CALTABLE_OK) {
        for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
            if (nt->rig.cam[k].k.width != TABLE.rig.cam[k].k.width ||
                nt->rig.cam[k].k.height != TABLE.rig.cam[k].k.height) {
                ts = MFNS_CALTABLE_E_IMAGE_SIZE; /* the cameras are open at the old size */
            }
        }
    }
    const bool had_prior = app.nav.have_prior;
    const mfns_pose_t prior = app.nav.prior;
    if (ts == MFNS_CALTABLE_OK && mfns_nav_init(&app.nav, nt, app.solver) != MFNS_NAV_OK) {
        ts = MFNS_CALTABLE_E_SOLVER_SETTINGS;
        if (mfns_nav_init(&app.nav, &TABLE, app.solver) != MFNS_NAV_OK) {
            fprintf(stderr, "mfns-nav: re-binding the old table failed\n"); /* it was bound before: cannot happen */
        }
    }
    if (ts != MFNS_CALTABLE_OK) {
        fprintf(stderr, "mfns-nav: TABLE_LOAD %s refused: %s (at byte %u); the old table (crc %08x) stays\n", path,
                mfns_caltable_strerror(ts), off, TABLE.crc32);
        send_event(app.cycle_now, app.last_t_us, TLM_EVT_TABLE_REFUSED, TLM_SEV_ERROR, 0, (int32_t)ts, 0);
        if (had_prior) {
            (void)mfns_nav_set_prior(&app.nav, &prior);
        }
        return TC_E_TABLE;
    }
    app.table_cur = spare;
    if (had_prior) {
        (void)mfns_nav_set_prior(&app.nav, &prior); /* confirmed by the new table's beacons, or dropped */
    }
    send_event(app.cycle_now, app.last_t_us, TLM_EVT_TABLE_LOADED, TLM_SEV_INFO, 0, TABLE.format_version,
               (int32_t)TABLE.crc32);
    *arg1 = (int32_t)TABLE.crc32;
    return TC_OK;
}

static void cmd_reset_counters(void *ctx)
{
    (void)ctx;
    app.cam_errors = 0;
}

static const nav_cmd_ops_t k_cmd_ops = {NULL,           cmd_set_mode,       cmd_set_pose_hint, cmd_camera_enable,
                                        cmd_table_load, cmd_reset_counters, cmd_event};

static int open_tc(const nav_app_opts_t *o)
{
    nav_cmd_init(&app.cmd);
    memset(&app.tc_uart, 0, sizeof app.tc_uart);
    app.tc_uart.fd = -1;
    if (o->tc_kind == NAV_TC_NONE || o->tc_kind == NAV_TC_LINK) {
        return 0;
    }
    const int rc = mfns_uart_open_path(&app.tc_uart, o->tc_target, o->baud, MFNS_UART_READ);
    if (rc == MFNS_UART_ERR_OPEN && o->tc_kind == NAV_TC_PATH) {
        fprintf(stderr, "mfns-nav: telecommands %s not available yet (%s): retrying\n", o->tc_target,
                strerror(app.tc_uart.last_errno));
        return 0;
    }
    if (rc != MFNS_UART_OK) {
        fprintf(stderr, "mfns-nav: telecommands %s: %s\n", o->tc_target, mfns_uart_strerror(rc));
        return -1;
    }
    return 0;
}

/* Between cycles: read what the uplink has now (never waits) and handle at
 * most NAV_CMD_MAX_PER_CYCLE commands; the rest waits for the next cycle. */
static void poll_commands(const nav_app_opts_t *o)
{
    if (o->tc_kind == NAV_TC_NONE) {
        return;
    }
    mfns_uart_t *u = o->tc_kind == NAV_TC_LINK ? &app.uart : &app.tc_uart;
    unsigned left = NAV_CMD_MAX_PER_CYCLE;
    for (int round = 0; round < 4 && left > 0u; round++) {
        if (app.tc_off == app.tc_len) {
            if (app.tc_eof) {
                return;
            }
            size_t got = 0;
            const int rc = mfns_uart_read(u, app.tc_rx, sizeof app.tc_rx, &got, 0, now_us() / 1000u);
            if (rc == MFNS_UART_EOF) {
                app.tc_eof = true; /* a recorded command file ended */
            } else if ((rc == MFNS_UART_ERR_IO || rc == MFNS_UART_ERR_ARG) && !app.tc_error_printed) {
                app.tc_error_printed = true;
                fprintf(stderr, "mfns-nav: telecommand read failed: %s\n", mfns_uart_strerror(rc));
            }
            if (got == 0u) {
                return;
            }
            app.tc_len = got;
            app.tc_off = 0;
        }
        unsigned handled = 0;
        app.tc_off += nav_cmd_feed(&app.cmd, app.tc_rx + app.tc_off, app.tc_len - app.tc_off, left, &k_cmd_ops,
                                   &handled);
        left -= handled;
    }
}

int nav_app_run(const nav_app_opts_t *o)
{
    memset(&app, 0, sizeof app);
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    if (sigaction(SIGINT, &sa, NULL) != 0 || sigaction(SIGTERM, &sa, NULL) != 0) {
        fprintf(stderr, "mfns-nav: cannot install signal handlers: %s\n", strerror(errno));
        return 2;
    }
    nav_tlm_init(&app.tlm);
    mfns_cycle_stats_reset(&app.stats);
    app.solver = o->solver;
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        app.cam_enabled[k] = true;
    }
    cam_sync_init(&app.sync, o->sync_window_us);
    if (open_tlm(o) != 0 || open_tc(o) != 0) {
        mfns_uart_close(&app.uart);
        return 2;
    }
    const uint64_t t0 = now_us();
    send_event(0, 0, TLM_EVT_BOOT, TLM_SEV_INFO, 0, NAV_APP_VERSION, 0);

    uint32_t err_off = 0;
    const mfns_caltable_status_t ts =
        mfns_caltable_load_file(o->table_path, app.table_buf, sizeof app.table_buf, &TABLE, &err_off);
    if (ts != MFNS_CALTABLE_OK) {
        fprintf(stderr, "mfns-nav: calibration table %s refused: %s (at byte %u)\n", o->table_path,
                mfns_caltable_strerror(ts), err_off);
        send_event(0, 0, TLM_EVT_TABLE_REFUSED, TLM_SEV_ERROR, 0, (int32_t)ts, 0);
        close_all(o);
        return 2;
    }
    send_event(0, 0, TLM_EVT_TABLE_LOADED, TLM_SEV_INFO, 0, TABLE.format_version, (int32_t)TABLE.crc32);
    if (mfns_nav_init(&app.nav, &TABLE, o->solver) != MFNS_NAV_OK || open_cameras(o) != 0) {
        close_all(o);
        return 2;
    }
    if (o->have_init_pose) {
        if (set_prior_from(o->init_pose[0], o->init_pose[1], o->init_pose[2], o->init_pose[3], o->init_pose[4],
                           o->init_pose[5]) != MFNS_NAV_OK) {
            fprintf(stderr, "mfns-nav: --init-pose refused\n");
            close_all(o);
            return 2;
        }
    }
    pump_tlm(o);

    const uint32_t max_cycles = o->max_cycles > 0 ? o->max_cycles : UINT32_MAX - 1;
    uint64_t last_hk_us = 0, prev_start = now_us();
    uint32_t cycle = 0;
    const char *why = "data ended";
    for (cycle = 0; cycle < max_cycles; cycle++) {
        if (stop_requested) {
            why = "signal";
            break;
        }
        app.cycle_now = cycle;
        poll_commands(o); /* between cycles: the previous cycle's telemetry is out */
        mfns_cam_frame_t fr[MFNS_NUM_CAMERAS];
        memset(fr, 0, sizeof fr);
        bool have[MFNS_NUM_CAMERAS] = {false, false, false};
        bool ended[MFNS_NUM_CAMERAS] = {false, false, false};
        uint64_t t_frame[MFNS_NUM_CAMERAS] = {0, 0, 0};
        const uint64_t prog_us = now_us() - t0;
        int active = 0;
        for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
            app.cs[k].used = false;
            have[k] = gather(o, k, cycle, app.sync.have_last ? app.sync.last_us : prog_us, &fr[k], &ended[k]);
            t_frame[k] = fr[k].timestamp_ns / 1000u;
            if (have[k] && !app.cam_enabled[k]) {
                /* CAMERA_DISABLE: its frames keep flowing (no driver backlog) but are not fused */
                if (mfns_cam_requeue(app.cs[k].cam, &fr[k]) != MFNS_CAM_OK) {
                    app.cam_errors++;
                }
                have[k] = false;
            }
            if (app.cs[k].health.state != CAM_HEALTH_ENDED && !ended[k]) {
                active++;
            }
        }
        if (active == 0) { /* every camera's data ended (a held frame would have kept it active) */
            break;
        }
        for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
            if (ended[k]) {
                camera_ended(cycle, app.sync.have_last ? app.sync.last_us : prog_us, k);
            }
        }
        const uint64_t start = now_us();
        cam_sync_verdict_t verdict[MFNS_NUM_CAMERAS];
        uint64_t t_us = 0;
        if (!cam_sync_cycle(&app.sync, have, t_frame, MFNS_NUM_CAMERAS, verdict, &t_us)) {
            t_us = start - t0; /* no camera delivered: stamp with the program's clock */
        }
        mfns_frame_t nf[MFNS_NUM_CAMERAS];
        const mfns_frame_t *frames[MFNS_NUM_CAMERAS] = {NULL, NULL, NULL};
        for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
            cam_slot_t *c = &app.cs[k];
            if (verdict[k] == CAM_SYNC_AHEAD) {
                /* out of step: left out of this cycle, kept for the one it belongs to */
                c->held = fr[k];
                c->have_held = true;
                c->n_ahead++;
                const int32_t off = cam_sync_offset_us(t_frame[k], t_us);
                send_event(cycle, t_us, TLM_EVT_CAMERA_OUT_OF_STEP, TLM_SEV_WARNING, (uint8_t)k, off,
                           (int32_t)fr[k].sequence);
                char line[192];
                (void)snprintf(line, sizeof line,
                               "cycle %u: frame %u at %.6f s is %.1f ms ahead of the cycle's %.6f s (out of step): "
                               "held for a later cycle",
                               cycle, fr[k].sequence, (double)t_frame[k] * 1e-6, (double)off * 1e-3,
                               (double)t_us * 1e-6);
                fault_line(&c->lines_ahead, k, line);
            } else if (verdict[k] == CAM_SYNC_USE) {
                c->last_seq = fr[k].sequence;
                if (to_nav_frame(&fr[k], &nf[k])) {
                    frames[k] = &nf[k];
                    c->used = true;
                } else {
                    c->last_err = MFNS_CAM_E_DATA;
                    app.cam_errors++;
                }
            }
        }
        const mfns_nav_mode_t before = app.nav.mode;
        mfns_nav_status_t ns = MFNS_NAV_OK;
        if (app.standby) {
            /* SET_MODE standby: cameras keep delivering, the navigator does not run */
            memset(&app.out, 0, sizeof app.out);
            app.out.sol.status = MFNS_POSE_NO_FIX;
            app.out.mode = app.out.next_mode = app.nav.mode;
        } else {
            ns = mfns_nav_cycle(&app.nav, frames, &app.out);
        }
        for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
            if (verdict[k] == CAM_SYNC_USE && mfns_cam_requeue(app.cs[k].cam, &fr[k]) != MFNS_CAM_OK) {
                app.cam_errors++;
            }
        }
        if (ns != MFNS_NAV_OK) {
            fprintf(stderr, "mfns-nav: cycle %u: %s\n", cycle, mfns_nav_strerror(ns));
            app.out.sol.status = MFNS_POSE_NO_FIX;
        }
        if (app.out.acquired) {
            app.n_acquire++;
            app.acq_last = app.out.acq;
            app.acq_units_max = app.out.acq.units > app.acq_units_max ? app.out.acq.units : app.acq_units_max;
        }
        tlm_packet_t p;
        nav_tlm_nav_packet(&app.out, cycle, t_us, &p);
        if (app.standby) {
            p.u.nav.mode = TLM_MODE_STANDBY;
        }
        /* counted from the packet itself, so the log, housekeeping and
         * nav.csv say the same (a pose the packet refuses is NO_FIX) */
        if (p.u.nav.status == TLM_NAV_FIX) {
            app.n_fix++;
        } else if (p.u.nav.status == TLM_NAV_DEGRADED) {
            app.n_degraded++;
        } else {
            app.n_no_fix++;
        }
        app.last_t_us = t_us;
        (void)nav_tlm_send(&app.tlm, &p);
        camera_events(cycle, t_us);
        camera_health(o, cycle, t_us); /* first: the packets carry the state after this cycle */
        camera_packets(cycle, t_us, fr);
        if (app.out.mode_changed) {
            send_event(cycle, t_us, TLM_EVT_MODE_CHANGE, TLM_SEV_INFO, (uint8_t)app.out.sol.reason,
                       nav_tlm_mode(before), nav_tlm_mode(app.out.next_mode));
        }
        const uint64_t end = now_us();
        mfns_cycle_stats_add(&app.stats, (uint32_t)(end - start), (uint32_t)(start - prev_start));
        prev_start = start;
        if (t_us - last_hk_us >= 1000000u || cycle == 0) {
            housekeeping(cycle, cycle + 1u, t_us, TABLE.crc32);
            last_hk_us = t_us;
        }
        pump_tlm(o);
        if (o->verbose) {
            const mfns_pose_solution_t *s = &app.out.sol;
            fprintf(stderr, "cycle %u %s %s (%s) used %u blobs %u/%u/%u pos %.2f %.2f %.2f mm att %.3f %.3f %.3f deg rms %.3f px\n", cycle,
                    mfns_nav_mode_str(app.out.mode), mfns_pose_status_str(s->status), mfns_pose_strerror(s->reason),
                    s->beacons_used, app.out.cam[0].observations, app.out.cam[1].observations, app.out.cam[2].observations,
                    (double)s->r_wb_w.x, (double)s->r_wb_w.y, (double)s->r_wb_w.z, (double)s->euler_deg.roll,
                    (double)s->euler_deg.pitch, (double)s->euler_deg.yaw, (double)s->residual_rms_px);
            if (app.out.acquired) {
                fprintf(stderr, "  acquisition: %u work units, band %u, best %u inliers%s%s\n", app.out.acq.units,
                        app.out.acq.band, app.out.acq.best_inliers,
                        app.out.acq_source == MFNS_ACQ_SRC_CARRIED ? ", fix from a search carried over cycles" : "",
                        app.out.acq_carry_age > 0u ? ", a search carried on" : "");
            }
        }
        bool all_off = true;
        for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
            all_off = all_off && (app.cs[k].health.state == CAM_HEALTH_OFF || app.cs[k].health.state == CAM_HEALTH_ENDED);
        }
        if (all_off && o->backend != MFNS_CAM_BACKEND_REPLAY) {
            why = "every camera is gone";
            cycle++;
            break;
        }
    }
    if (cycle >= max_cycles) {
        why = "cycle limit";
    }
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        if (app.cs[k].have_held) {
            (void)mfns_cam_requeue(app.cs[k].cam, &app.cs[k].held);
            app.cs[k].have_held = false;
        }
    }
    /* The final report: stamped with the flight clock (the last cycle's
     * time, so time never runs backwards on the ground) and counting the
     * cycles that ran (cycle is their number here on every exit path). */
    housekeeping(cycle > 0u ? cycle - 1u : 0u, cycle, app.last_t_us, TABLE.crc32);
    close_all(o);
    /* Exact: every frame produced was sent, dropped by the queue, or is still
     * queued (never sent) now. */
    const uint32_t lost = app.tlm.q.dropped + (uint32_t)tlm_txq_frames(&app.tlm.q);
    const uint32_t produced = app.tlm.q.sent + lost;
    if (!o->quiet) {
        print_summary(why, cycle, o->tlm_kind == NAV_TLM_NONE ? app.tlm.q.dropped : lost, produced);
    }
    if (app.tlm_write_errors > 0) {
        fprintf(stderr, "mfns-nav: telemetry incomplete: %u write errors (exit 3)\n", app.tlm_write_errors);
        return 3;
    }
    return 0;
}
