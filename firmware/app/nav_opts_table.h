/* nav_opts_table.h -- the ONE table of mfns-nav's options and configuration
 * keys (issue 41 item 5). Every view is expanded from it:
 *   - the parser: getopt_long's table and each option's typed setter with its
 *     range and error message (nav_opts.c);
 *   - `mfns-nav --help` and the man page `mfns-nav --help-man` (roff, which
 *     mk/install.sh installs as mfns-nav.1; nav_opts.c);
 *   - the configuration keys of /etc/mfns/mfns-nav.conf: their names, types,
 *     ranges and the option each stands for (nav_conf.h's NAV_CONFIG_KEYS);
 *   - tests/unit/test_nav_opts.c checks that the views agree and
 *     tests/host/test_nav_opts_views.py that docs/operations.md's key table
 *     and the board's mfns-nav.conf name the same keys as the man page.
 *
 * Why an X-macro and not a data file plus generator: the table's consumers
 * are C only (the man page is printed by the program itself), the ranges are
 * C constants of other headers (cam_sync.h), and the setters are C functions;
 * a header the compiler reads keeps one source without a build step or a
 * generated file to keep in step.
 *
 * NAV_OPTS(OPT, KEY) lists
 *   OPT(ID, "long-name", 'c' short or 0, KIND, "METAVAR" or NULL, lo, hi,
 *       "wants" or NULL, setter, "help")
 *     KIND: NAV_OPT_FLAG (no argument), NAV_OPT_STR (an argument, the setter
 *     checks it), NAV_OPT_U32 (a decimal number in lo..hi, checked before the
 *     setter: "mfns-nav: --NAME wants WANTS, got 'ARG'", WANTS defaulting to
 *     "lo..hi"). help: lines separated by '\n'.
 *   KEY(ID, "key_name", nav_config_type_t, lo, hi, "option")
 *     a configuration key (in the order of docs/operations.md), the option
 *     it stands for; lo..hi for NAV_CFG_T_U32 keys, within the option's.
 * The setters (nav_opts.c) and the key types (nav_conf.h) are named where
 * the table is expanded; a view that needs only one kind of row
 * passes NAV_OPTS_SKIP for the other.
 */
#ifndef MFNS_NAV_OPTS_TABLE_H
#define MFNS_NAV_OPTS_TABLE_H

#define NAV_OPTS_SKIP(...)

/* An option's argument: none, text its setter checks, a number in lo..hi. */
typedef enum { NAV_OPT_FLAG, NAV_OPT_STR, NAV_OPT_U32 } nav_opt_kind_t;

#define NAV_OPT_TIMEOUT_MS_DEFAULT 200

/* clang-format off */
#define NAV_OPTS(OPT, KEY)                                                                                             \
    OPT(CONFIG, "config", 0, NAV_OPT_STR, "FILE", 0, 0, NULL, set_config,                                             \
        "key = value configuration (the board's " NAV_CONFIG_DEFAULT_PATH ");\n"                                       \
        "options given here override its keys (docs/operations.md)")                                                   \
    OPT(TABLE, "table", 0, NAV_OPT_STR, "FILE", 0, 0, NULL, set_table,                                                 \
        "calibration table (mfns table build; docs/caltable.md); with a\n"                                             \
        "state dir, the initial one: the store's table wins (docs/operations.md)")                                    \
    OPT(REPLAY, "replay", 0, NAV_OPT_STR, "DIR", 0, 0, NULL, set_replay,                                               \
        "cameras replay an `mfns sim nav` folder (docs/nav-frames.md)")                                               \
    OPT(REALTIME, "realtime", 0, NAV_OPT_FLAG, NULL, 0, 0, NULL, set_realtime,                                         \
        "replay at the recorded frame rate (default: as fast as possible)")                                           \
    OPT(V4L2, "v4l2", 0, NAV_OPT_FLAG, NULL, 0, 0, NULL, set_v4l2,                                                     \
        "V4L2 cameras (the board's defaults: see the end)")                                                            \
    OPT(LIBCAMERA, "libcamera", 0, NAV_OPT_FLAG, NULL, 0, 0, NULL, set_libcamera,                                      \
        "libcamera cameras (first three, or --cam-x/y/z ids)")                                                         \
    OPT(CAM_X, "cam-x", 0, NAV_OPT_STR, "ID", 0, 0, NULL, set_cam,                                                     \
        "camera x: device path (/dev/v4l/by-path/...), bus_info:TEXT or\n"                                             \
        "card:TEXT (V4L2 VIDIOC_QUERYCAP), or a libcamera id")                                                         \
    OPT(CAM_Y, "cam-y", 0, NAV_OPT_STR, "ID", 0, 0, NULL, set_cam, "camera y, as --cam-x")                             \
    OPT(CAM_Z, "cam-z", 0, NAV_OPT_STR, "ID", 0, 0, NULL, set_cam, "camera z, as --cam-x")                             \
    OPT(TIMEOUT, "timeout-ms", 0, NAV_OPT_U32, "N", 1, MFNS_CAM_MAX_TIMEOUT_MS, NULL, set_timeout,                     \
        "frame wait per camera and cycle (default 200)")                                                               \
    OPT(SYNC_WINDOW, "sync-window-ms", 0, NAV_OPT_U32, "N", 1, MFNS_SYNC_WINDOW_US_MAX / 1000u, NULL,                  \
        set_sync_window, "frames fused in one cycle lie within N ms (default: see the end)")                           \
    OPT(SERIAL, "serial", 0, NAV_OPT_STR, "PORT", 0, 0, NULL, set_tlm, "telemetry on a real UART via libserialport")  \
    OPT(TTY, "tty", 0, NAV_OPT_STR, "PATH", 0, 0, NULL, set_tlm, "telemetry on a tty, pseudo-terminal or FIFO")        \
    OPT(FILE, "file", 0, NAV_OPT_STR, "PATH", 0, 0, NULL, set_tlm, "telemetry recorded to a file (created/truncated)") \
    OPT(TLM_SERIAL, "tlm-serial", 0, NAV_OPT_STR, "PORT", 0, 0, NULL, set_tlm, "--serial, the older spelling")         \
    OPT(TLM_TTY, "tlm-tty", 0, NAV_OPT_STR, "PATH", 0, 0, NULL, set_tlm, "--tty, the older spelling")                  \
    OPT(TLM_FILE, "tlm-file", 0, NAV_OPT_STR, "PATH", 0, 0, NULL, set_tlm, "--file, the older spelling")               \
    OPT(BAUD, "baud", 0, NAV_OPT_U32, "N", 1200, 4000000, NULL, set_baud,                                              \
        "UART baud rate (default: the board's, see the end)")                                                          \
    OPT(TC_TTY, "tc-tty", 0, NAV_OPT_STR, "PATH", 0, 0, NULL, set_tc,                                                  \
        "telecommands from a tty, pseudo-terminal or FIFO (docs/uplink.md)")                                           \
    OPT(TC_FILE, "tc-file", 0, NAV_OPT_STR, "PATH", 0, 0, NULL, set_tc,                                                \
        "telecommand frames recorded in a file, read to its end")                                                      \
    OPT(UPLINK, "uplink", 0, NAV_OPT_FLAG, NULL, 0, 0, NULL, set_tc,                                                   \
        "telecommands on the telemetry link itself (--tty/--serial, read-write)")                                      \
    OPT(TC_KEY, "tc-key", 0, NAV_OPT_STR, "FILE", 0, 0, NULL, set_tc_key,                                              \
        "the board's command keys ('ID HEX' lines, mode 0600/0400, yours):\n"                                          \
        "every command must be signed (docs/uplink.md); needs --state-dir")                                            \
    OPT(STATE_DIR, "state-dir", 0, NAV_OPT_STR, "DIR", 0, 0, NULL, set_state_dir,                                      \
        "persistent state: the anti-replay boot epoch, and the table store\n"                                          \
        "(the last TABLE_LOAD that validated, and the one before)")                                                   \
    OPT(BUDGET, "budget-units", 0, NAV_OPT_U32, "N", 100, 1000000, NULL, set_budget,                                   \
        "acquisition work units per cycle (default: measured at start-up\n"                                            \
        "to fit the frame period; docs/budgets.md)")                                                                   \
    OPT(NAV_FILTER, "nav-filter", 0, NAV_OPT_U32, "MS", 1, 1000, "a frame period of 1..1000 ms", set_nav_filter,       \
        "run the navigation filter bank (issue 42; off by default) with\n"                                             \
        "the frame period MS: a usable filtered fix replaces the snapshot's\n"                                         \
        "(docs/pose.md \"Navigation filter\")")                                                                        \
    OPT(TC_INSECURE, "tc-insecure", 0, NAV_OPT_FLAG, NULL, 0, 0, NULL, set_tc_insecure,                                \
        "accept commands WITHOUT authentication (tests, bench; a warning)")                                            \
    OPT(MAX_CYCLES, "max-cycles", 0, NAV_OPT_U32, "N", 1, UINT32_MAX - 1u, "a positive number", set_max_cycles,       \
        "stop after N cycles")                                                                                         \
    OPT(INIT_POSE, "init-pose", 0, NAV_OPT_STR, "X,Y,Z,ROLL,PITCH,YAW", 0, 0, NULL, set_init_pose,                    \
        "start tracking from this pose (mm, deg;\n"                                                                    \
        "e.g. the docking port); falls back to acquisition if wrong\n"                                                 \
        "(for replays; in operation the ground sends SET_POSE_HINT)")                                                  \
    OPT(PAPER, "paper", 0, NAV_OPT_FLAG, NULL, 0, 0, NULL, set_paper,                                                  \
        "use the paper's Eq. 3 Newton solver (baseline) instead of ML")                                                \
    OPT(VERBOSE, "verbose", 'v', NAV_OPT_FLAG, NULL, 0, 0, NULL, set_verbose, "one line per cycle on stderr")          \
    OPT(QUIET, "quiet", 'q', NAV_OPT_FLAG, NULL, 0, 0, NULL, set_quiet,                                                \
        "no summary line at the end (errors still go to stderr)")                                                      \
    OPT(MLOCK, "mlock", 0, NAV_OPT_FLAG, NULL, 0, 0, NULL, set_mlock,                                                  \
        "lock all memory after start-up (a page fault never delays a cycle)")                                          \
    OPT(LAST_EXIT, "last-exit", 0, NAV_OPT_STR, "FILE", 0, 0, NULL, set_last_exit,                                     \
        "how the previous run ended, as the service unit records it\n"                                                 \
        "(carried by the BOOT event; docs/operations.md)")                                                             \
    OPT(FIXLOG, "fixlog", 0, NAV_OPT_STR, "DIR", 0, 0, NULL, set_fixlog,                                               \
        "record every usable fix (associations, pose) to a rotating\n"                                                 \
        "on-board log in DIR for the self-survey (docs/self_survey.md)")                                              \
    OPT(FIXLOG_ROTATE, "fixlog-rotate", 0, NAV_OPT_STR, "KB,FILES", 0, 0, NULL, set_fixlog_rotate,                    \
        "rotate the fix log at KB kB per file, keep FILES files\n"                                                     \
        "(default 8192,16; small values are for tests)")                                                               \
    OPT(HELP, "help", 'h', NAV_OPT_FLAG, NULL, 0, 0, NULL, set_help, "this help")                                      \
    OPT(HELP_MAN, "help-man", 0, NAV_OPT_FLAG, NULL, 0, 0, NULL, set_help, "this help as a man page (roff)")          \
    OPT(VERSION, "version", 0, NAV_OPT_FLAG, NULL, 0, 0, NULL, set_help, "the version and the board")                 \
    KEY(CAMERAS, "cameras", NAV_CFG_T_WORD, 0, 0, "v4l2")                                                              \
    KEY(CAM_X, "cam_x", NAV_CFG_T_TEXT, 0, 0, "cam-x")                                                                 \
    KEY(CAM_Y, "cam_y", NAV_CFG_T_TEXT, 0, 0, "cam-y")                                                                 \
    KEY(CAM_Z, "cam_z", NAV_CFG_T_TEXT, 0, 0, "cam-z")                                                                 \
    KEY(UART, "uart", NAV_CFG_T_PATH, 0, 0, "serial")                                                                  \
    KEY(TTY, "tty", NAV_CFG_T_PATH, 0, 0, "tty")                                                                       \
    KEY(BAUD, "baud", NAV_CFG_T_U32, 1200, 4000000, "baud")                                                            \
    KEY(UPLINK, "uplink", NAV_CFG_T_BOOL, 0, 0, "uplink")                                                              \
    KEY(TC_KEY, "tc_key", NAV_CFG_T_PATH, 0, 0, "tc-key")                                                              \
    KEY(TC_INSECURE, "tc_insecure", NAV_CFG_T_BOOL, 0, 0, "tc-insecure")                                               \
    KEY(TABLE, "table", NAV_CFG_T_PATH, 0, 0, "table")                                                                 \
    KEY(STATE_DIR, "state_dir", NAV_CFG_T_PATH, 0, 0, "state-dir")                                                     \
    KEY(TIMEOUT_MS, "timeout_ms", NAV_CFG_T_U32, 1, 5000, "timeout-ms")                                                \
    KEY(MLOCK, "mlock", NAV_CFG_T_BOOL, 0, 0, "mlock")                                                                 \
    KEY(BUDGET_UNITS, "budget_units", NAV_CFG_T_U32, 100, 1000000, "budget-units")
/* clang-format on */

#endif /* MFNS_NAV_OPTS_TABLE_H */
