/* nav_filter_cycle.h -- the navigation filter bank (filter_bank.h) inside the
 * navigation cycle (nav_cycle.c), behind a switch that is OFF by default:
 * with it off nothing here runs and the cycle is bit-identical to the
 * snapshot navigator.
 *
 * On: the bank starts from the first usable snapshot fix, or one refused
 * only for what the bank checks itself (NO_FIX PL_EXCEEDS_AL with its tests
 * passed; NO_FIX LAG_UNTESTED, the cameras' timing not testable yet, which
 * the bank's camera hypotheses carry): the fix's identification and pose as the linearisation
 * point, and a prior that claims nothing of it (per pose axis the larger of
 * the fix's own sigma, less the map datum term which the filter adds back at
 * its output, and MFNS_BANK_START_SIGMA_MM / _RAD (filter_bank.h); velocity 0 +-
 * MFNS_BANK_SIGMA_V0_MM_S, 0 +- MFNS_BANK_SIGMA_W0_RAD_S). The start cycle's
 * own frames are then taken at once. So every filter of the bank rests on
 * the observations it took, each hypothesis's subset on all but its own: a
 * fault in the fix the bank started from (a camera fault a DEGRADED
 * CAMERA_UNMONITORED fix does not bound) is bounded like one in any later
 * frame. It takes every observation the cycle's solver associated with a
 * beacon, camera by camera, and associates the others itself (own_associate
 * in the .c: the one beacon predicted from the full filter within its gate),
 * so a frame of one or two beacons, where the snapshot has no fix, still
 * feeds it. A cycle whose bank output is usable reports the filter's
 * pose, covariance, PL and status (the solution's counts, residuals and
 * associations stay the solver's); otherwise the snapshot's verdict stands
 * (each is a certified bound on its own). A bank that asks for a restart
 * (motion bound exceeded, coast too long) starts again from the next usable
 * snapshot fix.
 *
 * An exclusion (filter_bank.h) ends the bank too: it restarts from this
 * cycle's snapshot fix if that can start it (else the next one), with the
 * subject still held out (re-admission as before), and takes this cycle's
 * frames afresh. Why: an exclusion replaces the full filter by the excluded
 * hypothesis's subset and every other hypothesis restarts as a copy of it,
 * so their separations start at zero and the PL falls to about K_ff sigma at
 * once; a fault that was already in the filter (the subject named wrongly:
 * a beacon of a drifting or knocked camera gated first) is then bounded by
 * nothing (issue 42's grown campaign: camera y drifting 1 ms per frame,
 * beacon 36 excluded, the next fixes 2x beyond their PL). A start from the
 * diffuse prior carries nothing of the old filter: each hypothesis bounds
 * what it took since.
 *
 * The motion bound against the snapshot: the cycle's snapshot fix rests on
 * this cycle's frames alone, the full filter on the same observations and
 * every earlier one through the motion model. Under the bound and without a
 * fault the filter is the estimate on a superset of the data, so the
 * snapshot minus the filter has covariance P_s - P_f (the solution
 * separation of the subset "this frame only", whose hypothesis is "the
 * motion model is wrong"). Per pose axis the separation is tested against
 * K sqrt(max(P_s - P_f, P_s / 4)), K = Q^-1(P_fa / 12) (two-sided, six
 * axes; the floor keeps a filter barely better than the snapshot from
 * testing on a difference of two near-equal variances), and
 * MFNS_NAVF_MOTION_RUN consecutive cycles beyond it mean the robot left the
 * bound (a collision, a hard burst): the bank restarts from the snapshot fix
 * and the cycle reports motion_exceeded. The reference is only a snapshot
 * fix that bounds every single fault itself (usable, cameras monitored): one
 * a camera fault could have moved would restart the filter on a fault.
 * Misses: an excess the filter follows within a cycle (a soft push, whose
 * separation and error both stay small); a snapshot too weak to show it
 * (P_s large: one or two cameras of few beacons); a cycle without a usable
 * snapshot fix. Conservative where the model is: the snapshot's calibration
 * term (not in P_f) and a beacon's survey error (a bias common to both,
 * white in P_f) make P_s - P_f larger than the separation's true variance.
 *
 * Time: each camera's observations enter the bank at their frame's capture
 * time when the caller gave them (mfns_navf_set_frame_times before the
 * cycle; the flight program passes the frames' stamps), cameras in the order
 * of their times; the cycle is evaluated at the latest of them and a start
 * takes the earliest (the snapshot fix treats the cycle's frames as one
 * instant: their spread, 14 ms on the rig, is inside the velocity prior's
 * effect). A frame stamped before the bank's state (a stale frame with its
 * old stamp) is not fed (counted in stale_frames): the bank cannot go back in
 * time; the camera's timing hypothesis covers a stamp that lies. Without
 * times, every camera's frame of cycle k is stamped k x period_us (the
 * caller's frame period), as before.
 *
 * A camera's clock in doubt (mfns_navf_doubt_timing; the flight program
 * raises it when its frame checks see a frame of the camera dropped, held,
 * late, frozen or stepped, firmware/app/nav_cams.c): every filter of the
 * bank takes the camera's frames with their time offset eliminated until
 * the camera's clock reads clean for the table's hold_cycles, each reading
 * able to see a period's lag (filter_bank.h mfns_bank_doubt_timing). The
 * doubt outlives a restart of the bank (nf->timing_doubt): a camera stale
 * since a dropped frame is stale in the next bank too.
 *
 * A camera's frame the snapshot's checks find lagging this cycle
 * (mfns_navf_suspect_frame; the cycle passes integrity_lag.h's new lagging
 * camera, or one it holds as lagging): the filter's output of that cycle is
 * refused, NO_FIX FRAME_SUSPECT with the camera as out.suspect_camera (the
 * bank took the frame, and a frame that moves the snapshot fix by a lag
 * moves the filter too). The bank refuses it (mfns_bank_suspect_frame), so
 * the refused cycle does not count towards a held subject's re-admission. The snapshot weighs the whole frame against the
 * other cameras' of the same instant, the bank weighs it against a
 * prediction the motion bound leaves loose: on the grown campaign the
 * time-offset monitor named a frozen camera (fresh noise) or a knocked one
 * in the very cycle whose filter fix was then 5-28 sigma off (within its
 * PL). The camera's clock is not put in doubt by it: the monitor reads a
 * knocked mount as a lag too, and a knocked camera's frames taken
 * timing-free left usable fixes beyond 5 sigma later in the run (grown
 * campaign seed 3, camera y 0.3 deg: 4, none without the doubt).
 * Misses: what the snapshot's monitor misses (integrity_lag.h); cost: its
 * false alarms and its holds, a refused cycle each.
 */
#ifndef MFNS_NAV_FILTER_CYCLE_H
#define MFNS_NAV_FILTER_CYCLE_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/nav/table/caltable.h"
#include "firmware/nav/filter/filter_bank.h"
#include "firmware/nav/integrity/integrity.h"
#include "firmware/nav/pose/pose.h"

/* The motion monitor against the snapshot (above): cycles in a row beyond
 * the threshold before the bank restarts (two: a collision keeps the
 * separation for several frames while the filter catches up, a lone
 * excursion of a fault the snapshot's tests let through does not), and the
 * floor of the separation's variance as a fraction of the snapshot's. */
#define MFNS_NAVF_MOTION_RUN 2U
#define MFNS_NAVF_MOTION_FLOOR 0.25f

typedef struct {
    bool on;
    bool running;
    uint32_t period_us;
    int64_t t_us;
    int64_t cap_us[MFNS_NUM_CAMERAS]; /* this cycle's capture times (have_cap) */
    bool have_cap;
    uint32_t stale_frames; /* frames stamped before the bank's state: not fed */
    uint32_t own_assoc;    /* observations the bank associated itself (the solver had none for them) */
    bool carry_excl;       /* the next start keeps the bank's exclusions (it follows one) */
    uint8_t snap_sep_run;  /* consecutive cycles the snapshot fix was beyond the filter's (motion monitor) */
    bool motion_latched;   /* a motion restart reported, no usable filter output since (one report per episode) */
    uint8_t timing_doubt;  /* bit c: camera c's clock in doubt (mfns_navf_doubt_timing), across restarts */
    int8_t suspect_cam;    /* the snapshot's checks find this camera's frame lagging this cycle (-1 none) */
    mfns_filter_bank_t bank;
} mfns_navf_t;

/* What the cycle output carries. */
typedef struct {
    bool ran;          /* the bank was evaluated this cycle */
    bool used;         /* its output replaced the snapshot's (usable) */
    bool started;      /* it (re)started from this cycle's snapshot fix */
    /* the robot left the table's motion bound this cycle: the bank's gate or
     * window, or the snapshot fix beyond the filter (motion_sep >= 1, the
     * largest normalised separation of the monitor below); the bank
     * restarted from the snapshot. Set at the first such restart of an
     * episode (report it: MOTION_EXCEEDED), which ends at the next usable
     * filter output. */
    bool motion_exceeded;
    bool motion_by_snapshot; /* that restart was the snapshot monitor's (else the bank's gate or window) */
    float motion_sep;
    /* the instant the bank's output is for (when ran), us on the frames'
     * time base: the latest of the cycle's frame stamps. The flight program
     * stamps a fix the filter made with it: the cycle's own time is its
     * earliest frames' (cam_sync.h), and cameras a few ms apart would
     * otherwise have their fix labelled that many ms early (a pose 1 mm off
     * at 80 mm/s on the rig's 14 ms spread, or a drifting clock's offset
     * carried into every fix). */
    int64_t t_us;
    mfns_bank_output_t out;
} mfns_navf_report_t;

/* Switch on (period_us > 0: the frame period) or off (period_us = 0). */
void mfns_navf_enable(mfns_navf_t *nf, uint32_t period_us);

/* The coming cycle's capture times (consumed by the next mfns_navf_step). */
void mfns_navf_set_frame_times(mfns_navf_t *nf, const int64_t t_us[MFNS_NUM_CAMERAS]);

/* Camera cam's clock is in doubt from its next frame (filter_bank.h
 * mfns_bank_doubt_timing): the running bank takes the camera's frames
 * timing-free until its readings clear the doubt, and every bank started
 * before then inherits it (a stale camera stays stale across a restart).
 * Off or cam out of range: nothing. */
void mfns_navf_doubt_timing(mfns_navf_t *nf, int cam);

/* The snapshot's checks find camera cam's frame of the coming
 * mfns_navf_step lagging (above): that step's output is refused (NO_FIX
 * FRAME_SUSPECT, out.suspect_camera = cam). Consumed by the next step. Off
 * or cam out of range (-1: none): nothing. */
void mfns_navf_suspect_frame(mfns_navf_t *nf, int cam);

/* One cycle, after the snapshot's integrity: sol and integ in/out. */
void mfns_navf_step(mfns_navf_t *nf, const mfns_caltable_t *t, const mfns_integrity_settings_t *is,
                    const mfns_obs_frame_t *obs, float sigma_px, mfns_pose_solution_t *sol,
                    mfns_integrity_result_t *integ, mfns_navf_report_t *rep);

#endif /* MFNS_NAV_FILTER_CYCLE_H */
