/* nav_opts.c -- see nav_opts.h. */
#define _DEFAULT_SOURCE /* getopt_long under -std=c11 */

#include "firmware/app/nav_opts.h"

#include <errno.h>
#include <getopt.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "firmware/app/cam_sync.h"
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
            "       mfns-nav --config FILE [options]\n"
            "\n"
            "The MFNS flight program: camera frames -> beacon centroids -> pose -> telemetry.\n"
            "\n"
            "  --config FILE       key = value configuration (the board's " NAV_CONFIG_DEFAULT_PATH ");\n"
            "                      options given here override its keys (docs/operations.md)\n"
            "  --table FILE        calibration table (mfns table build; docs/caltable.md); with a\n"
            "                      state dir, the initial one: the store's table wins (docs/operations.md)\n"
            "  --replay DIR        cameras replay an `mfns sim nav` folder (docs/nav-frames.md)\n"
            "  --realtime          replay at the recorded frame rate (default: as fast as possible)\n"
            "  --v4l2              V4L2 cameras (board defaults %s %s %s)\n"
            "  --libcamera         libcamera cameras (first three, or --cam-x/y/z ids)\n"
            "  --cam-x/--cam-y/--cam-z ID     device path (/dev/v4l/by-path/...), bus_info:TEXT or\n"
            "                      card:TEXT (V4L2 VIDIOC_QUERYCAP), or a libcamera id, per camera\n"
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
            "  --state-dir DIR     persistent state: the anti-replay boot epoch, and the table store\n"
            "                      (the last TABLE_LOAD that validated, and the one before)\n"
            "  --budget-units N    acquisition work units per cycle (default: measured at start-up\n"
            "                      to fit the frame period; docs/budgets.md)\n"
            "  --nav-filter MS     run the navigation filter bank (issue 42; off by default) with\n"
            "                      the frame period MS: a usable filtered fix replaces the snapshot's\n"
            "                      (docs/pose.md \"Navigation filter\")\n"
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
            "  --fixlog-rotate KB,FILES  rotate the fix log at KB kB per file, keep FILES files\n"
            "                      (default 8192,16; small values are for tests)\n"
            "  -h, --help, --version\n"
            "Exit status: 0 ok, 2 bad usage or input (table, cameras, telemetry target),\n"
            "3 telemetry incomplete (write errors, or a link that never opened: nothing sent).\n",
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

/* --config FILE or --config=FILE anywhere on the line (the last one wins,
 * as getopt would); NULL when absent. A --config without its FILE is left to
 * getopt's error. */
static const char *find_config(int argc, char **argv)
{
    static const char eq[] = "--config=";
    const char *path = NULL;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--") == 0) {
            break;
        }
        if (strcmp(argv[i], "--config") == 0 && i + 1 < argc) {
            path = argv[++i];
        } else if (strncmp(argv[i], eq, sizeof eq - 1u) == 0) {
            path = argv[i] + sizeof eq - 1u;
        }
    }
    return path;
}

/* Where each setting came from, so the line replaces the file's (never
 * "give one telemetry output" for a --tty over the file's uart). */
typedef struct {
    bool tlm, tc, key, insecure;
    const char *cam[MFNS_NUM_CAMERAS];
} from_file_t;

/* The file's keys into o (defaults for the command line). 0, or -1 with the message. */
static int apply_config(nav_opts_t *o, from_file_t *ff, FILE *err)
{
    const nav_config_t *c = &o->cfg;
    const char *p = o->config_path;
    if (c->set[NAV_CFG_UART] && c->set[NAV_CFG_TTY]) {
        fprintf(err, "mfns-nav: %s:%u: key 'tty': excludes 'uart' (line %u): give one telemetry output\n", p,
                c->line[NAV_CFG_TTY], c->line[NAV_CFG_UART]);
        return -1;
    }
    if (c->set[NAV_CFG_TC_KEY] && c->set[NAV_CFG_TC_INSECURE] && c->number[NAV_CFG_TC_INSECURE] != 0u) {
        fprintf(err, "mfns-nav: %s:%u: key 'tc_insecure': excludes 'tc_key' (line %u)\n", p,
                c->line[NAV_CFG_TC_INSECURE], c->line[NAV_CFG_TC_KEY]);
        return -1;
    }
    if (c->set[NAV_CFG_CAMERAS]) {
        const bool v4l2 = strcmp(c->value[NAV_CFG_CAMERAS], "v4l2") == 0;
        o->backend = v4l2 ? MFNS_CAM_BACKEND_V4L2 : MFNS_CAM_BACKEND_LIBCAMERA;
        o->cam_path[0] = v4l2 ? MFNS_BOARD_CAM_X : "";
        o->cam_path[1] = v4l2 ? MFNS_BOARD_CAM_Y : "";
        o->cam_path[2] = v4l2 ? MFNS_BOARD_CAM_Z : "";
    }
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        const nav_config_key_t key = (nav_config_key_t)(NAV_CFG_CAM_X + k);
        ff->cam[k] = c->set[key] ? c->value[key] : NULL;
    }
    if (c->set[NAV_CFG_UART] || c->set[NAV_CFG_TTY]) {
        o->tlm_kind = c->set[NAV_CFG_UART] ? NAV_TLM_SERIAL : NAV_TLM_PATH;
        o->tlm_target = c->set[NAV_CFG_UART] ? c->value[NAV_CFG_UART] : c->value[NAV_CFG_TTY];
        ff->tlm = true;
    }
    if (c->set[NAV_CFG_BAUD]) {
        o->baud = c->number[NAV_CFG_BAUD];
    }
    if (c->set[NAV_CFG_UPLINK] && c->number[NAV_CFG_UPLINK] != 0u) {
        o->tc_kind = NAV_TC_LINK;
        ff->tc = true;
    }
    if (c->set[NAV_CFG_TC_KEY]) {
        o->tc_key_path = c->value[NAV_CFG_TC_KEY];
        ff->key = true;
    }
    if (c->set[NAV_CFG_TC_INSECURE]) {
        o->tc_insecure = c->number[NAV_CFG_TC_INSECURE] != 0u;
        o->tc_insecure_from_config = o->tc_insecure;
        ff->insecure = true;
    }
    if (c->set[NAV_CFG_TABLE]) {
        o->table_path = c->value[NAV_CFG_TABLE];
    }
    if (c->set[NAV_CFG_STATE_DIR]) {
        o->state_dir = c->value[NAV_CFG_STATE_DIR];
    }
    if (c->set[NAV_CFG_TIMEOUT_MS]) {
        if (c->number[NAV_CFG_TIMEOUT_MS] > (uint32_t)MFNS_CAM_MAX_TIMEOUT_MS) {
            fprintf(err, "mfns-nav: %s:%u: key 'timeout_ms': wants 1..%d\n", p, c->line[NAV_CFG_TIMEOUT_MS],
                    MFNS_CAM_MAX_TIMEOUT_MS);
            return -1;
        }
        o->frame_timeout_ms = (int)c->number[NAV_CFG_TIMEOUT_MS];
    }
    if (c->set[NAV_CFG_MLOCK]) {
        o->mlock = c->number[NAV_CFG_MLOCK] != 0u;
    }
    if (c->set[NAV_CFG_BUDGET_UNITS]) {
        o->budget_units = c->number[NAV_CFG_BUDGET_UNITS];
    }
    return 0;
}

int nav_opts_parse(int argc, char **argv, nav_opts_t *o, FILE *out, FILE *err)
{
    enum { O_TABLE = 256, O_REPLAY, O_REALTIME, O_V4L2, O_LIBCAMERA, O_CAMX, O_CAMY, O_CAMZ, O_TIMEOUT,
           O_SERIAL, O_TTY, O_FILE, O_BAUD, O_MAX, O_PAPER, O_VERBOSE, O_HELP, O_VERSION, O_INIT, O_QUIET,
           O_SYNC_WINDOW, O_TC_TTY, O_TC_FILE, O_UPLINK, O_MLOCK, O_LAST_EXIT, O_TC_KEY, O_STATE_DIR,
           O_TC_INSECURE, O_FIXLOG, O_CONFIG, O_BUDGET,
           O_FIXLOG_ROTATE, O_NAV_FILTER };
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
        {"fixlog-rotate", required_argument, NULL, O_FIXLOG_ROTATE},
        {"config", required_argument, NULL, O_CONFIG}, {"budget-units", required_argument, NULL, O_BUDGET},
        {"nav-filter", required_argument, NULL, O_NAV_FILTER},
        {NULL, 0, NULL, 0},
    };
    memset(o, 0, sizeof *o);
    o->backend = MFNS_CAM_BACKEND_COUNT_;
    o->frame_timeout_ms = 200;
    o->sync_window_us = MFNS_SYNC_WINDOW_US_DEFAULT;
    o->baud = MFNS_BOARD_BAUD;
    o->solver = MFNS_POSE_MODE_ML;
    const char *cam_override[MFNS_NUM_CAMERAS] = {NULL, NULL, NULL};
    from_file_t ff;
    memset(&ff, 0, sizeof ff);
    o->config_path = find_config(argc, argv);
    if (o->config_path != NULL) {
        char msg[NAV_CONFIG_ERR_LEN + 64];
        if (nav_config_load(o->config_path, &o->cfg, msg, sizeof msg) != 0) {
            fprintf(err, "mfns-nav: configuration %s\n", msg);
            return -1;
        }
        if (nav_config_check_trust(&o->cfg, (uint32_t)geteuid(), msg, sizeof msg) != 0) {
            fprintf(err, "mfns-nav: configuration %s:%s\n", o->config_path, msg + 4); /* "line N: ..." -> ":N: ..." */
            return -1;
        }
        if (apply_config(o, &ff, err) != 0) {
            return -1;
        }
    }
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
            ff.cam[0] = ff.cam[1] = ff.cam[2] = NULL; /* the file's cameras are not a replay's */
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
            if (ff.tlm) { /* the line replaces the file's output */
                o->tlm_kind = NAV_TLM_NONE;
                ff.tlm = false;
            }
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
            if (ff.tc) {
                o->tc_kind = NAV_TC_NONE;
                ff.tc = false;
            }
            if (o->tc_kind != NAV_TC_NONE) {
                fprintf(err, "mfns-nav: give one telecommand input (--tc-tty, --tc-file or --uplink)\n");
                return -1;
            }
            o->tc_kind = c == O_TC_TTY ? NAV_TC_PATH : (c == O_TC_FILE ? NAV_TC_FILE : NAV_TC_LINK);
            o->tc_target = c == O_UPLINK ? NULL : optarg;
            break;
        case O_TC_KEY:
            o->tc_key_path = optarg;
            if (ff.insecure) {
                o->tc_insecure = false;
                o->tc_insecure_from_config = false;
            }
            break;
        case O_STATE_DIR:
            o->state_dir = optarg;
            break;
        case O_TC_INSECURE:
            o->tc_insecure = true;
            o->tc_insecure_from_config = false;
            if (ff.key) {
                o->tc_key_path = NULL;
            }
            break;
        case O_CONFIG:
            break; /* read before the loop (find_config) */
        case O_NAV_FILTER:
            if (!parse_u32(optarg, 1, 1000, &o->nav_filter_period_ms)) {
                fprintf(err, "mfns-nav: --nav-filter wants a frame period of 1..1000 ms, got '%s'\n", optarg);
                return -1;
            }
            break;
        case O_BUDGET:
            if (!parse_u32(optarg, 100, 1000000, &o->budget_units)) {
                fprintf(err, "mfns-nav: --budget-units wants 100..1000000, got '%s'\n", optarg);
                return -1;
            }
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
        case O_FIXLOG_ROTATE: {
            char kb[16] = {0};
            const char *comma = strchr(optarg, ',');
            const size_t n = comma != NULL ? (size_t)(comma - optarg) : 0u;
            if (comma == NULL || n == 0u || n >= sizeof kb) {
                fprintf(err, "mfns-nav: --fixlog-rotate wants KB,FILES, got '%s'\n", optarg);
                return -1;
            }
            memcpy(kb, optarg, n);
            if (!parse_u32(kb, 1, 1024u * 1024u, &o->fixlog_file_kb) ||
                !parse_u32(comma + 1, 1, 1000000, &o->fixlog_files)) {
                fprintf(err, "mfns-nav: --fixlog-rotate wants KB,FILES (1..1048576, 1..1000000), got '%s'\n",
                        optarg);
                return -1;
            }
            break;
        }
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
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        if (cam_override[k] == NULL && ff.cam[k] != NULL && o->backend != MFNS_CAM_BACKEND_REPLAY) {
            cam_override[k] = ff.cam[k]; /* the file's camera, unless the line names one */
        }
    }
    if (o->table_path == NULL) {
        fprintf(err, "mfns-nav: --table FILE (or the configuration's 'table') is required (see --help)\n");
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
