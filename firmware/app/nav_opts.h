/* nav_opts.h -- the command line of mfns-nav: what it may be told and how
 * (README "Command-line grammar", `mfns-nav --help`).
 *
 * nav_opts_parse fills a nav_opts_t from argv, applying the board's defaults
 * (MFNS_BOARD_CAM_X/Y/Z, MFNS_BOARD_BAUD, MFNS_BOARD_NAME from boards/<b>/)
 * and refusing, with one line on err, every combination the program cannot
 * run: no table, no cameras, two telemetry outputs or two command inputs,
 * a command input with neither --tc-key (and --state-dir) nor --tc-insecure,
 * --uplink without a link it can read, --cam-x/y/z with --replay, numbers
 * out of range. --help writes the usage, --help-man the man page (roff, which
 * mk/install.sh installs) and --version the one version (mk/version.sh) on
 * out. The options, their ranges, help texts and configuration keys are one
 * table, nav_opts_table.h. The strings in nav_opts_t point into argv, or into
 * o->cfg.
 *
 * --config FILE (nav_conf.h; the board's /etc/mfns/mfns-nav.conf) is read
 * first, wherever it stands on the line, and gives every value the command
 * line does not: an option given on the line replaces the file's key (a
 * --tty replaces the file's uart, a --replay its cameras and cam_x/y/z,
 * --tc-insecure its tc_key). No file is read without --config.
 */
#ifndef MFNS_NAV_OPTS_H
#define MFNS_NAV_OPTS_H

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "drivers/camera/camera.h"
#include "firmware/app/nav_conf.h"
#include "firmware/nav/pose/pose.h"

_Static_assert(MFNS_NUM_CAMERAS == 3, "the options name three cameras: --cam-x, --cam-y, --cam-z");

typedef enum { NAV_TLM_NONE = 0, NAV_TLM_SERIAL, NAV_TLM_PATH, NAV_TLM_FILE } nav_tlm_kind_t;
/* Where telecommands come from (docs/uplink.md): none, a tty/pty/FIFO by path
 * (--tc-tty), a file of recorded frames read to its end (--tc-file), or the
 * telemetry link itself, opened read-write (--uplink; a tty or serial port). */
typedef enum { NAV_TC_NONE = 0, NAV_TC_PATH, NAV_TC_FILE, NAV_TC_LINK } nav_tc_kind_t;

typedef struct {
    const char *table_path;
    mfns_cam_backend_t backend;
    const char *cam_path[MFNS_NUM_CAMERAS]; /* V4L2 devices / libcamera ids; replay: all the same folder */
    bool realtime;             /* replay paced to the recorded timestamps */
    int frame_timeout_ms;
    uint32_t sync_window_us;   /* frames fused in one cycle lie within this (cam_sync.h) */
    nav_tlm_kind_t tlm_kind;
    const char *tlm_target;    /* serial port, tty/FIFO path, or output file */
    nav_tc_kind_t tc_kind;     /* telecommand input */
    const char *tc_target;     /* its path (NAV_TC_PATH, NAV_TC_FILE) */
    const char *tc_key_path;   /* --tc-key: the board's keys (tc_auth.h) */
    const char *state_dir;     /* --state-dir: the persisted boot epoch (tc_state.h) */
    bool tc_insecure;          /* --tc-insecure: commands without authentication */
    bool tc_insecure_from_config; /* ... set by the configuration file's tc_insecure (reported so) */
    uint32_t baud;
    uint32_t max_cycles;       /* 0 = until the data ends or a signal */
    mfns_pose_mode_t solver;
    bool verbose;              /* one line per cycle on stderr */
    bool quiet;                /* no summary line at the end */
    bool have_init_pose;       /* --init-pose: track from this pose at start */
    float init_pose[6];        /* x, y, z mm; roll, pitch, yaw deg (r_wb_w, 2-1-3 of C_w_b) */
    bool mlock;                /* --mlock: lock all memory after start-up (nav_service.h) */
    const char *last_exit;     /* --last-exit FILE: how the previous run ended (nav_service.h), or NULL */
    const char *fixlog_dir;    /* --fixlog DIR: the fix record's on-board log (nav_fixlog.h), or NULL */
    uint32_t fixlog_file_kb;   /* --fixlog-rotate KB,FILES: rotation (0, 0: nav_fixlog.h's defaults) */
    uint32_t fixlog_files;
    uint32_t budget_units;     /* --budget-units: acquisition work per cycle; 0 = measured at start (nav_selftest.h) */
    uint32_t nav_filter_period_ms; /* --nav-filter MS: the navigation filter on with this frame period; 0 off */
    const char *config_path;   /* --config FILE, or NULL */
    nav_config_t cfg;          /* its contents (strings above may point here) */
} nav_opts_t;

/* 0 ok, 1 when --help/--version was printed (exit 0), -1 usage error (message on err). */
int nav_opts_parse(int argc, char **argv, nav_opts_t *o, FILE *out, FILE *err);

#endif /* MFNS_NAV_OPTS_H */
