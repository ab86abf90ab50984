/* nav_app.h -- the flight program mfns-nav: cameras -> navigation cycle ->
 * telemetry, on Linux. main.c is argument parsing around nav_app_run().
 *
 * Start-up (the only phase that may fail hard): load and validate the
 * calibration table, open the three cameras and the telemetry link. A table
 * that fails validation is refused with its error and the program stops after
 * sending a TABLE_REFUSED event: navigating on a wrong table would produce
 * poses marked valid that are not.
 *
 * The telemetry link may be absent at start (a FIFO without a reader, an
 * adapter not plugged in): it is retried like a link lost later. Write errors
 * are counted, reported on stderr and give exit code 3.
 *
 * The loop: one cycle per frame set. Each camera is dequeued with a timeout
 * (none for a camera already LOST, so it never stalls the others). A cycle
 * fuses only frames within sync_window_us of each other (cam_sync.h): an
 * out-of-step frame is held for the cycle it belongs to, a stale one dropped.
 * A camera that times out, is rejected, lost or recovering contributes no
 * frame that cycle; after MFNS_CAM_LOST_CYCLES such cycles it is LOST (event,
 * one stderr line), re-opened every MFNS_CAM_REOPEN_CYCLES, and RECOVERED on
 * its next fused frame; a replay camera whose rows end early is ENDED.
 * Telemetry per cycle: the nav solution and one diagnostics packet per
 * camera; housekeeping once per second of frame time; events as they happen.
 * The transmit queue drops the oldest frames rather than ever blocking the
 * loop.
 *
 * Telecommands (nav_cmd.h) are read without blocking and acted on between
 * cycles, at most NAV_CMD_MAX_PER_CYCLE per cycle, each answered by a
 * CMD_ACCEPTED or CMD_REJECTED event.
 *
 * The loop ends at the end of replayed data, after max_cycles, on SIGINT or
 * SIGTERM, or when every (non-replay) camera is gone for good.
 */
#ifndef MFNS_NAV_APP_H
#define MFNS_NAV_APP_H

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "drivers/camera/camera.h"
#include "pose.h"

typedef enum { NAV_TLM_NONE = 0, NAV_TLM_SERIAL, NAV_TLM_PATH, NAV_TLM_FILE } nav_tlm_kind_t;
/* Where telecommands come from (docs/uplink.md): none, a tty/pty/FIFO by path
 * (--tc-tty), a file of recorded frames read to its end (--tc-file), or the
 * telemetry link itself, opened read-write (--uplink; a tty or serial port). */
typedef enum { NAV_TC_NONE = 0, NAV_TC_PATH, NAV_TC_FILE, NAV_TC_LINK } nav_tc_kind_t;

typedef struct {
    const char *table_path;
    mfns_cam_backend_t backend;
    const char *cam_path[3];   /* V4L2 devices / libcamera ids; replay: all the same folder */
    bool realtime;             /* replay paced to the recorded timestamps */
    int frame_timeout_ms;
    uint32_t sync_window_us;   /* frames fused in one cycle lie within this (cam_sync.h) */
    nav_tlm_kind_t tlm_kind;
    const char *tlm_target;    /* serial port, tty/FIFO path, or output file */
    nav_tc_kind_t tc_kind;     /* telecommand input */
    const char *tc_target;     /* its path (NAV_TC_PATH, NAV_TC_FILE) */
    uint32_t baud;
    uint32_t max_cycles;       /* 0 = until the data ends or a signal */
    mfns_pose_mode_t solver;
    bool verbose;              /* one line per cycle on stderr */
    bool quiet;                /* no summary line at the end */
    bool have_init_pose;       /* --init-pose: track from this pose at start */
    float init_pose[6];        /* x, y, z mm; roll, pitch, yaw deg (r_wb_w, 2-1-3 of C_w_b) */
} nav_app_opts_t;

/* 0 ok, 1 when --help/--version was printed (exit 0), -1 usage error (message on err). */
int nav_app_parse_args(int argc, char **argv, nav_app_opts_t *o, FILE *out, FILE *err);
/* Runs the program; returns the process exit code (0 ok, 2 start-up failure,
 * 3 telemetry write errors: the record on the link is incomplete). */
int nav_app_run(const nav_app_opts_t *o);

#endif /* MFNS_NAV_APP_H */
