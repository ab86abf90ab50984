/* nav_opts.c -- see nav_opts.h. */
#define _DEFAULT_SOURCE /* getopt_long under -std=c11 */

#include "nav_opts.h"

#include <errno.h>
#include <getopt.h>
#include <stdlib.h>
#include <string.h>

#include "cam_sync.h"
#include "mfns_version.h"

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
            "  --tc-key FILE       the board's command keys ('ID HEX' lines, mode 0600/0400, yours):\n"
            "                      every command must be signed (docs/uplink.md); needs --state-dir\n"
            "  --state-dir DIR     where the boot epoch of the anti-replay counter is kept\n"
            "  --tc-insecure       accept commands WITHOUT authentication (tests, bench; a warning)\n"
            "  --max-cycles N      stop after N cycles\n"
            "  --init-pose X,Y,Z,ROLL,PITCH,YAW   start tracking from this pose (mm, deg;\n"
            "                      e.g. the docking port); falls back to acquisition if wrong\n"
            "                      (for replays; in operation the ground sends SET_POSE_HINT)\n"
            "  --paper             use the paper's Eq. 3 Newton solver (baseline) instead of ML\n"
            "  -v, --verbose       one line per cycle on stderr\n"
            "  -q, --quiet         no summary line at the end (errors still go to stderr)\n"
            "  --mlock             lock all memory after start-up (a page fault never delays a cycle)\n"
            "  --last-exit FILE    how the previous run ended, as the service unit records it\n"
            "                      (carried by the BOOT event; docs/operations.md)\n"
            "  --fixlog DIR        record every usable fix (associations, pose) to a rotating\n"
            "                      on-board log in DIR for the self-survey (docs/self_survey.md)\n"
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

int nav_opts_parse(int argc, char **argv, nav_opts_t *o, FILE *out, FILE *err)
{
    enum { O_TABLE = 256, O_REPLAY, O_REALTIME, O_V4L2, O_LIBCAMERA, O_CAMX, O_CAMY, O_CAMZ, O_TIMEOUT,
           O_SERIAL, O_TTY, O_FILE, O_BAUD, O_MAX, O_PAPER, O_VERBOSE, O_HELP, O_VERSION, O_INIT, O_QUIET,
           O_SYNC_WINDOW, O_TC_TTY, O_TC_FILE, O_UPLINK, O_MLOCK, O_LAST_EXIT, O_TC_KEY, O_STATE_DIR,
           O_TC_INSECURE, O_FIXLOG };
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
        {"mlock", no_argument, NULL, O_MLOCK}, {"last-exit", required_argument, NULL, O_LAST_EXIT},
        {"tc-key", required_argument, NULL, O_TC_KEY}, {"state-dir", required_argument, NULL, O_STATE_DIR},
        {"tc-insecure", no_argument, NULL, O_TC_INSECURE},
        {"fixlog", required_argument, NULL, O_FIXLOG},
        {NULL, 0, NULL, 0},
    };
    memset(o, 0, sizeof *o);
    o->backend = MFNS_CAM_BACKEND_COUNT_;
    o->frame_timeout_ms = 200;
    o->sync_window_us = MFNS_SYNC_WINDOW_US_DEFAULT;
    o->baud = MFNS_BOARD_BAUD;
    o->solver = MFNS_POSE_MODE_ML;
    const char *cam_override[MFNS_NUM_CAMERAS] = {NULL, NULL, NULL};
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
        case O_TC_KEY:
            o->tc_key_path = optarg;
            break;
        case O_STATE_DIR:
            o->state_dir = optarg;
            break;
        case O_TC_INSECURE:
            o->tc_insecure = true;
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
        case O_MLOCK: o->mlock = true; break;
        case O_LAST_EXIT: o->last_exit = optarg; break;
        case O_FIXLOG: o->fixlog_dir = optarg; break;
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
    if (o->tc_insecure && o->tc_key_path != NULL) {
        fprintf(err, "mfns-nav: --tc-key and --tc-insecure exclude each other\n");
        return -1;
    }
    if (o->tc_key_path != NULL && o->state_dir == NULL) {
        fprintf(err, "mfns-nav: --tc-key needs --state-dir DIR (the anti-replay boot epoch is kept there)\n");
        return -1;
    }
    if (o->tc_kind != NAV_TC_NONE && o->tc_key_path == NULL && !o->tc_insecure) {
        fprintf(err, "mfns-nav: a command input needs --tc-key FILE --state-dir DIR (signed commands), or "
                     "--tc-insecure to accept them without authentication (docs/uplink.md)\n");
        return -1;
    }
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
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
