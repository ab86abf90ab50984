/* nav_cams.h -- the flight program's cameras: open them, gather one frame
 * each per cycle, synchronise the set, watch their health, close them. One
 * nav_cam_t per camera holds everything the program knows of it.
 *
 * Gather: each camera is dequeued with a timeout (none for a camera already
 * down, so it never stalls the others); a frame held from an earlier cycle
 * comes first. A frame that belongs to a cycle already done (stale,
 * cam_sync.h) is given back and the camera asked again, at most
 * NAV_CAMS_STALE_TRIES times. A frame of a camera disabled by command is
 * given back unused (its driver never backs up).
 *
 * Synchronise: a cycle fuses only frames within the sync window of each
 * other (cam_sync.h); an out-of-step frame is held for the cycle it belongs
 * to. A fused frame is handed to the navigator as an mfns_frame_t and given
 * back to its driver once the navigator is done (nav_cams_give_back_used).
 *
 * Data health (firmware/frames/frame_health.h): every frame dequeued is
 * checked before synchronisation (frozen content or sequence, a stamp that
 * jumps against the camera's cadence or its arrival, a late frame) and the
 * cameras' sequence numbers are checked against each other; a camera the
 * monitor holds out contributes no frame (given back at once), so neither
 * the synchronisation nor the cycle's time nor the navigator ever sees it.
 * Its frames still flow (it is neither LOST nor re-opened for that); the
 * camera packet shows its health state; each transition is an event.
 * A stepped clock, once confirmed, is re-aligned: its stamps are corrected
 * before synchronisation.
 *
 * Link health: a camera that times out, is rejected, lost or recovering gives no
 * frame that cycle; after MFNS_CAM_LOST_CYCLES such cycles it is LOST (event,
 * one stderr line), re-opened every MFNS_CAM_REOPEN_CYCLES, and RECOVERED on
 * its next fused frame; a replay camera whose rows end early is ENDED.
 *
 * Every fault is an event in telemetry; the first NAV_CAMS_FAULT_LINES of
 * each kind per camera are also one stderr line each. All state is in the
 * caller's nav_cams_t; nothing blocks longer than the frame timeout.
 */
#ifndef MFNS_NAV_CAMS_H
#define MFNS_NAV_CAMS_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/frames/cam_sync.h"
#include "drivers/camera/camera.h"
#include "firmware/frames/frame_health.h"
#include "firmware/app/nav_opts.h"
#include "firmware/app/nav_tlm.h"

#define NAV_CAMS_STALE_TRIES 4 /* dequeues per camera and cycle to catch up past stale frames */
#define NAV_CAMS_FAULT_LINES 5 /* stderr lines per camera and kind of fault; the rest in telemetry */

/* One camera as the program sees it. */
typedef struct {
    mfns_cam_t *cam;            /* NULL while closed (a re-open failed) */
    char letter;                /* 'x', 'y', 'z': its name in messages */
    uint32_t width, height;     /* pixels, from the table: every (re-)open asks for them */
    bool enabled;               /* CAMERA_ENABLE / CAMERA_DISABLE */
    cam_health_t health;
    /* this cycle */
    mfns_cam_frame_t frame;     /* the frame gathered (valid when have) */
    bool have;                  /* a frame was gathered and may be fused */
    bool ended;                 /* its recorded frames ended this cycle */
    cam_sync_verdict_t verdict; /* what synchronisation made of the frame */
    mfns_frame_t nav_frame;     /* the frame as the navigator reads it (valid when used) */
    bool used;                  /* the frame is fused this cycle */
    bool held_out;              /* the data health monitor left its frame out this cycle */
    /* across cycles */
    mfns_cam_frame_t held;      /* a frame ahead of the cycle, kept for a later one */
    bool have_held;
    bool timing_doubt;          /* a frame of it was held, dropped, late, frozen or stepped since the last
                                   cycle: its clock is in doubt (navigate: mfns_nav_doubt_timing) */
    bool ended_reported;
    mfns_cam_err_t last_err;
    mfns_cam_err_t open_err;    /* at start-up: MFNS_CAM_OK, or why it did not open (the self-test reports it) */
    uint64_t last_used_us;      /* frame time of its last fused frame */
    uint64_t lost_at_ms;        /* program clock when the driver reported it lost */
    uint32_t last_seq;
    uint32_t n_stale, n_ahead, n_rejected, n_timeouts, n_lost, n_recovered, n_reopens;
    uint32_t lines_stale, lines_ahead, lines_rejected;
    uint32_t lines_health[FH_EV_HEALTHY + 1]; /* stderr lines per kind of health event */
    uint32_t n_held_out;        /* frames the health monitor left out */
    uint32_t driver_events;     /* MFNS_CAM_EV_* taken at dequeue, reported after the cycle */
    bool recovery_seen;         /* the health monitor was told of this cycle's driver recovery */
} nav_cam_t;

typedef struct nav_cams {
    nav_cam_t cam[MFNS_NUM_CAMERAS];
    cam_sync_t sync;
    fh_monitor_t health;        /* camera data health, every camera */
    uint64_t errors;            /* housekeeping n_cam_errors; RESET_COUNTERS zeroes it */
    uint64_t last_fused_clock_us; /* program clock of the last cycle that fused a frame */
} nav_cams_t;

/* Every camera enabled, none open; the sync window in microseconds. */
void nav_cams_init(nav_cams_t *cs, uint32_t sync_window_us);
/* Opens and starts the three cameras o names at the table's image sizes
 * (a V4L2 identity bus_info:/card: looked up, camera_v4l2.h). A live camera
 * that does not open is reported (one stderr line; open_err keeps why) and
 * left closed: the loop re-opens it like a lost one, the others run. 0; -1
 * when no camera opened, or a replay camera failed (an input error). */
int nav_cams_open(nav_cams_t *cs, const nav_opts_t *o, const mfns_caltable_t *table);
/* Gathers this cycle's frames (see above); events are stamped with
 * event_t_us. Returns the cameras whose data has not ended. */
int nav_cams_gather(nav_cams_t *cs, nav_tlm_t *tlm, const nav_opts_t *o, uint32_t cycle, uint64_t event_t_us);
/* Marks (once, with an event and a stderr line) the cameras whose recorded
 * frames ended this cycle while others go on. */
void nav_cams_report_ended(nav_cams_t *cs, nav_tlm_t *tlm, uint32_t cycle, uint64_t t_us);
/* Decides which gathered frames this cycle fuses, holds those ahead and
 * fills frames[k] (NULL for a camera without a fused frame). Returns the
 * cycle's time: the fused frames' reference time (a camera held out by the
 * health monitor never sets it); when no camera delivered, the last fused
 * cycle's time moved on by the program clock (clock_t_us) since, or
 * clock_t_us before any frame. */
uint64_t nav_cams_synchronise(nav_cams_t *cs, nav_tlm_t *tlm, uint32_t cycle, uint64_t clock_t_us,
                              const mfns_frame_t *frames[MFNS_NUM_CAMERAS]);
/* Gives the frames fused this cycle back to their drivers (after the navigator). */
void nav_cams_give_back_used(nav_cams_t *cs);
/* Events the drivers raised since the last cycle (lost, recovered, recovery
 * failed), into telemetry; now_ms is the program clock. */
void nav_cams_driver_events(nav_cams_t *cs, nav_tlm_t *tlm, uint32_t cycle, uint64_t t_us, uint64_t now_ms);
/* Health transitions after a cycle (see above), re-opening cameras that are due. */
void nav_cams_update_health(nav_cams_t *cs, nav_tlm_t *tlm, const nav_opts_t *o, uint32_t cycle, uint64_t t_us);
/* One CAMERA packet per camera into tlm: its state after this cycle's health
 * update, what the navigator found in its frame (out), the frame's exposure
 * and sequence when it was fused, the driver's drop count. */
void nav_cams_packets(const nav_cams_t *cs, nav_tlm_t *tlm, const mfns_nav_output_t *out, uint32_t cycle,
                      uint64_t t_us);
/* Every camera is off for good or has ended. */
bool nav_cams_all_gone(const nav_cams_t *cs);
/* Bit k set when camera k is enabled. */
uint8_t nav_cams_enabled_mask(const nav_cams_t *cs);
/* At the end of the loop: frames held for a later cycle back to their drivers. */
void nav_cams_release_held(nav_cams_t *cs);
/* Closes every camera (a camera never opened is skipped). */
void nav_cams_close(nav_cams_t *cs);
/* The summary's fault line of each camera that had any, on stderr. */
void nav_cams_print_faults(const nav_cams_t *cs);

#endif /* MFNS_NAV_CAMS_H */
