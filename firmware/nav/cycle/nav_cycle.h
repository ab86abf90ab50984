/* nav_cycle.h -- one navigation cycle of the flight pipeline, portable:
 * three camera frames in, a pose solution and per-camera diagnostics out.
 *
 *   frames -> centroid (full frame, or windows around predicted beacons)
 *          -> distortion correction (the table's grid, fixed point)
 *          -> identification + pose (firmware/nav/pose/pose.h)
 *
 * Modes: ACQUIRE (no usable prior: whole frames, identification by
 * hypothesis and verification) and TRACK (after a fix: windows of
 * roi_half_size_px around each beacon predicted from the last pose, gated
 * association). The prediction is the last pose, or, after two consecutive
 * fixes, the last pose moved on by the motion between them (constant
 * velocity and turn rate per cycle): a turning robot's beacons then stay
 * inside their windows. When too few beacons are seen for a fix, the
 * prediction coasts for at most MFNS_NAV_MAX_COAST cycles, so tracking resumes
 * as soon as beacons return; a coasted pose is only a search prior, never
 * output as a fix. A TRACK cycle that gives no fix is redone once, in the
 * same cycle, as ACQUIRE on whole frames (acquire_cycle.h, within the
 * table's work budget); after the coast the prior is dropped, so a stale pose
 * is never reused, and every ACQUIRE cycle searches its frame afresh while a
 * search its budget stopped goes on beside it for a bounded number of
 * cycles: the navigator recovers from a lost track by itself. This file is
 * the one owner of that policy (track-else-acquire); acquire_cycle.h owns how
 * acquisition spends its budget over cycles.
 *
 * Integrity (integrity.h): every fix the solver gives, tracked or
 * acquired, goes through fault detection and exclusion; only a fix whose
 * single-fault tests pass and whose protection levels are inside the alert
 * limits stays usable (OK or DEGRADED). A fix refused for want of
 * redundancy (MINIMAL: three beacons; UNMONITORED; PL_EXCEEDS_AL) still
 * moves the tracking prior on, as before, but is never output as usable; a
 * fix with a fault that could not be excluded (FAULT_DETECTED) does not: the
 * prediction coasts.
 *
 * Workspace (workspace_watch.h): the acquisition is certified for a robot
 * inside the table's workspace box only. A tracked pose beyond the box is
 * reported (the watch's state); while the robot was last tracked outside, an
 * acquisition's pose is refused (NO_FIX OUTSIDE_WORKSPACE) and does not
 * carry the track, until a tracked pose is inside again (the track coming
 * back, or one from mfns_nav_set_prior) or a table is bound (mfns_nav_init).
 *
 * A camera that delivers no frame (NULL: dead, timed out, being recovered)
 * contributes nothing and is reported as such; the solve goes on with the
 * others (the pose solver then reports DEGRADED or NO_FIX by itself).
 *
 * All storage is inside mfns_nav_t (about 1 MB with the centroid scratch):
 * place it in static storage. Nothing allocates; time is bounded by the frame
 * size, the blob and ROI tables and the solver's caps.
 */
#ifndef MFNS_NAV_CYCLE_H
#define MFNS_NAV_CYCLE_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/nav/acquire/acquire_cycle.h"
#include "firmware/nav/integrity/beacon_monitor.h"
#include "firmware/nav/table/caltable.h"
#include "firmware/nav/centroid/centroid.h"
#include "firmware/nav/integrity/integrity.h"
#include "firmware/nav/integrity/integrity_lag.h"
#include "firmware/nav/integrity/spot_watch.h"
#include "firmware/nav/pose/pose.h"
#include "firmware/nav/acquire/workspace_watch.h"
#include "firmware/nav/filter/nav_filter_cycle.h"

#define MFNS_NAV_MAX_COAST 10 /* cycles (0.54 s at 18.6 Hz) */

typedef enum {
    MFNS_NAV_MODE_ACQUIRE = 0,
    MFNS_NAV_MODE_TRACK = 1,
} mfns_nav_mode_t;

typedef enum {
    MFNS_NAV_OK = 0,      /* the cycle ran; the fix is in out->sol.status */
    MFNS_NAV_E_ARG,       /* NULL pointer or not initialised */
    MFNS_NAV_E_TABLE,     /* the table's settings were refused by a stage */
} mfns_nav_status_t;

typedef enum {
    MFNS_NAV_CAM_OK = 0,
    MFNS_NAV_CAM_NO_FRAME,    /* no frame this cycle */
    MFNS_NAV_CAM_FRAME_ERROR, /* the centroider refused the frame (size, stride, format) */
    MFNS_NAV_CAM_TABLE_FULL,  /* more blobs than the blob table holds: brightest kept */
} mfns_nav_cam_state_t;

typedef struct {
    mfns_nav_cam_state_t state;
    int16_t centroid_status;     /* mfns_centroid_status_t of the last call */
    uint16_t blobs;              /* blobs found (accepted + rejected) */
    uint16_t accepted;           /* blobs passing every check */
    uint16_t observations;       /* handed to the solver (brightest accepted, capped) */
    uint16_t identified;         /* observations matched to a beacon and kept as inliers */
    uint16_t undistort_failures; /* accepted blobs outside the correction grid */
    uint16_t rois;               /* windows read (0 = whole frame) */
    float background_dn;
    float noise_dn;
} mfns_nav_cam_diag_t;

typedef struct {
    mfns_pose_solution_t sol;
    mfns_nav_mode_t mode;      /* the mode that produced sol */
    mfns_nav_mode_t next_mode; /* the mode of the next cycle */
    bool mode_changed;         /* next_mode differs from the previous cycle's mode */
    bool reacquired;           /* TRACK failed and the cycle was redone as ACQUIRE */
    uint16_t coasting;         /* cycles the prediction has coasted without a fix (0 = none) */
    bool acquired;             /* the cycle ran acquisition (acq holds its progress) */
    mfns_acq_progress_t acq;   /* search progress of that acquisition (units: the cycle's total) */
    uint16_t acq_carry_age;    /* cycles a search has been carried over (0: none carried) */
    uint8_t acq_source;        /* mfns_acq_source_t: where a fix came from */
    mfns_nav_cam_diag_t cam[MFNS_NUM_CAMERAS];
    /* Fault detection and exclusion on the fix (integrity.h): protection
     * levels, the tests, what is held out; sol is the fix after it. */
    mfns_integrity_result_t integrity;
    mfns_bmon_report_t bmon; /* slow-bias monitor (beacon_monitor.h): beacon_chi2 > 0 when one was reported */
    /* The time-offset monitor on the solver's fix (integrity_lag.h), before
     * FDE; lag_new_camera: a camera found lagging that was not held for it
     * (report once), -1 none; cam_held: 0 in, 1 held out by FDE, 2 held out
     * for a lag, 3 held out until its lag is verified after an outage. */
    mfns_lag_eval_t lag;
    int8_t lag_new_camera;
    mfns_beacon_watch_report_t beacons; /* beacons newly found missing or rejected (integrity_beacons.h) */
    mfns_camera_watch_report_t cameras; /* cameras inconsistent with the fix (integrity_cameras.h) */
    uint8_t cam_held[MFNS_NUM_CAMERAS];
    /* The tracked pose against the table's workspace box (workspace_watch.h):
     * ws the transitions this cycle, ws_state the state after it. */
    mfns_ws_report_t ws;
    uint8_t ws_state; /* mfns_ws_state_t */
    /* The navigation filter (nav_filter_cycle.h; off unless mfns_nav_enable_filter):
     * what it did this cycle; when filt.used, sol and integrity are its. */
    mfns_navf_report_t filt;
    /* What each camera's spots did since its last frame (spot_watch.h): a
     * camera whose photometric response stepped alone against its reported
     * exposure and gain (spots.camera, -1 none), cameras whose spots jumped
     * (spots.jump_mask: the navigation filter's fix of the cycle refused). */
    mfns_spot_report_t spots;
} mfns_nav_output_t;

typedef struct {
    const mfns_caltable_t *table;
    mfns_pose_config_t pose_cfg;
    mfns_nav_mode_t mode;
    bool have_prior;
    mfns_pose_t prior;      /* last fix, coasted prediction or given pose */
    bool prior_is_fix;      /* prior came from this cycle's predecessor's fix */
    bool have_prev;
    mfns_pose_t prev;       /* the fix before it, in the cycle before */
    mfns_pose_t predicted;  /* prediction used by this cycle's TRACK */
    uint16_t coast;         /* consecutive TRACK cycles without a fix */
    uint32_t magic; /* set by init: guards against use of a zeroed struct */
    mfns_acq_cycle_t acq;   /* acquisition, with a search carried over cycles */
    mfns_integrity_settings_t integ_set; /* alert limits, P_fa, P_md, hold */
    mfns_integrity_memory_t integ_mem;   /* beacons and cameras held out by FDE */
    mfns_bmon_t bmon;                    /* slow residual bias per beacon and camera (beacon_monitor.h) */
    mfns_ws_watch_t wsw;                 /* the tracked pose against the table's workspace (workspace_watch.h) */
    mfns_navf_t filt;                    /* the navigation filter bank, off by default (nav_filter_cycle.h) */
    mfns_spot_watch_t spots;             /* each camera's spots, frame to frame (spot_watch.h) */
    float frame_response[MFNS_NUM_CAMERAS]; /* the next cycle's frames' reported response, 0 unknown */
    /* scratch, meaningless between cycles */
    mfns_centroid_work_t work;
    mfns_centroid_result_t cres;
    mfns_obs_frame_t obs;
    mfns_roi_t rois[MFNS_CENTROID_MAX_ROIS];
    float pred_uv[MFNS_MAX_BEACONS][2];
    /* The live map: the table's beacons as bound (the table itself is never written:
     * its CRC is what housekeeping reports), with a beacon the bias monitor reports
     * down-weighted, its sigma_mm scaled by mfns_bmon_t.sigma_scale, until a table is
     * bound again (a refined map starts a new monitor). Every stage reads this map.
     * Last in the struct: the other members keep their small offsets (Thumb-2 loads). */
    mfns_beacon_map_t map;
} mfns_nav_t;

/* Bind to a loaded, validated table (which must outlive nav) and start in
 * ACQUIRE. mode selects the solver (ML, or the paper's Eq. 3 baseline). */
mfns_nav_status_t mfns_nav_init(mfns_nav_t *nav, const mfns_caltable_t *table, mfns_pose_mode_t mode);

/* Re-bind a running navigator to another validated table (which must outlive nav)
 * without losing what it has learnt, when the new table describes the same system: the
 * same rig (every camera's intrinsics and mounting, value for value) and the same beacons
 * (count, ids and positions, value for value). Then the track, the prior and its motion, the
 * camera and beacon monitors, the bias monitor and the filter are kept; the settings,
 * the noise model, the sigmas, the map index, the workspace box, the calibration
 * covariance and the map datum are the new table's (a beacon the bias monitor has
 * down-weighted stays down-weighted in the live map). *kept says so. Otherwise nav is
 * left untouched and *kept is false: the caller binds afresh (mfns_nav_init), which a
 * changed map or rig needs (a refined map starts a new monitor). MFNS_NAV_E_ARG for a
 * NULL argument or an unbound nav. */
mfns_nav_status_t mfns_nav_rebind(mfns_nav_t *nav, const mfns_caltable_t *table, bool *kept);

/* Run one cycle. frames[k] is camera k's frame or NULL when it has none. */
mfns_nav_status_t mfns_nav_cycle(mfns_nav_t *nav, const mfns_frame_t *const frames[MFNS_NUM_CAMERAS],
                                 mfns_nav_output_t *out);

/* The navigation filter (firmware/nav/filter/nav_filter_cycle.h): on with
 * the frame period period_us (> 0), off with 0. Off after mfns_nav_init (a
 * table bound turns it off: enable it again after). Off, the cycle is the
 * snapshot navigator, bit for bit. */
mfns_nav_status_t mfns_nav_enable_filter(mfns_nav_t *nav, uint32_t period_us);

/* The next cycle's frames' reported photometric response (exposure x linear
 * gain as each frame's metadata says, any unit, one unit per camera; 0
 * unknown: taken as unchanged from the camera's last frame). The response
 * watch (spot_watch.h) divides each spot's flux ratio by its change, so
 * a commanded exposure or gain is not read as a fault; one that is not
 * reported is. Consumed by the next mfns_nav_cycle (not called: unknown).
 * E_ARG: NULL, not initialised, a value not finite or negative (nothing
 * taken). */
mfns_nav_status_t mfns_nav_set_frame_response(mfns_nav_t *nav, const float response[MFNS_NUM_CAMERAS]);

/* The next cycle's frames' capture times (microseconds, the cameras' clock
 * as stamped; t_us[k] of a camera without a frame is ignored): with the
 * filter on, each camera's observations enter it at its own frame's time
 * (nav_filter_cycle.h). Not called before a cycle: the frames of cycle k are
 * stamped k x period. Used by the next mfns_nav_cycle only. */
mfns_nav_status_t mfns_nav_set_frame_times(mfns_nav_t *nav, const int64_t t_us[MFNS_NUM_CAMERAS]);

/* Camera cam's clock is in doubt (the caller's frame checks saw a dropped
 * or held frame, a clock step, a late or frozen frame of it): with the
 * filter on, its frames enter the filter bank with their time offset
 * eliminated until the bank's readings of the camera's clock clear the
 * doubt (filter_bank.h mfns_bank_doubt_timing); off, nothing (the snapshot's
 * own time-offset monitor, integrity_lag.h, watches every camera).
 * MFNS_NAV_E_ARG for a camera out of range. */
mfns_nav_status_t mfns_nav_doubt_timing(mfns_nav_t *nav, int cam);

/* Start tracking from a known pose (e.g. the docking port the robot leaves
 * from, commanded from the ground): the next cycle tracks from it and falls
 * back to acquisition if the beacons do not confirm it. MFNS_NAV_E_ARG for a
 * pose whose rotation is not a rotation or whose numbers are not finite. */
mfns_nav_status_t mfns_nav_set_prior(mfns_nav_t *nav, const mfns_pose_t *pose);

/* Forget the prior: the next cycle acquires. */
void mfns_nav_lose_track(mfns_nav_t *nav);

const char *mfns_nav_strerror(mfns_nav_status_t s);
const char *mfns_nav_mode_str(mfns_nav_mode_t m);
const char *mfns_nav_cam_state_str(mfns_nav_cam_state_t s);

#endif /* MFNS_NAV_CYCLE_H */
