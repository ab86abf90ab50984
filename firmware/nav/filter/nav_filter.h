/* nav_filter.h -- the navigation filter (issue 42): an error-state Kalman
 * filter over the body's pose and velocity, propagated with a constant-
 * velocity model whose process noise overbounds the robot's unmodelled
 * acceleration, updated observation by observation from beacon image
 * positions at each frame's own capture time. Portable core: no heap, no OS,
 * caller-owned state (mfns_filter_t, 784 B on x86-64), bounded work per call.
 *
 * State (nominal): C_w_b (world -> body, camera.h), r_wb_w (mm, world), v_w
 * (mm/s, world), w_w (rad/s, world: C_b_w' = exp([w_w dt]x) C_b_w), the time
 * t_us of the state (microseconds, the capture clock of the frames).
 *
 * Error state x (12, "truth = estimate (+) x"), index order:
 *   0-2  phi_w  attitude, C_b_w(true) = exp([phi_w]x) C_b_w(est)   (rad)
 *   3-5  dr_w   r_wb_w(true) - r_wb_w(est)                         (mm)
 *   6-8  dv_w   linear velocity error                               (mm/s)
 *   9-11 dw_w   angular velocity error (world axes)                 (rad/s)
 *   12-14 db     pointing bias of camera aug_cam (rad, body axes)     } only in a
 *   15   dtau    time offset of camera aug_cam (s)                   } camera hypothesis
 * (filter_bank.h); otherwise rows and columns 12-15 stay zero.
 * The pose block (0-5) has the attitude first; pose.h's cov_ros has position
 * first (mfns_filter_init and mfns_filter_pose_cov_ros reorder).
 *
 * Propagation over dt (s), per axis a double integrator driven by white
 * acceleration (the continuous white-noise acceleration model):
 *   phi += dt w,  r += dt v                (F = I + dt E, E: v -> r, w -> phi)
 *   P <- F P F^T + Q,  Q per axis = q [[dt^3/3, dt^2/2], [dt^2/2, dt]]
 *   q_lin = a_max^2 T (mm^2/s^3),  q_ang = alpha_max^2 T (rad^2/s^3)
 * with T = bound_time_s. Why this overbounds the motion bound a_max: an
 * acceleration of at most a_max acting over a span tau <= T moves the
 * position at most a_max tau^2 / 2 off the constant-velocity path; the model's
 * 1-sigma over that span is sqrt(q tau^3 / 3) = a_max tau sqrt(T tau / 3), so
 * the worst deterministic deviation is 0.87 sqrt(tau / T) sigma <= 0.87 sigma
 * for every tau <= T (velocity: a_max tau against a_max sqrt(T tau), <= 1
 * sigma). Beyond T without measurements (a coast longer than T) the bias
 * grows faster than the modelled sigma; coasts are limited to max_coast_s <= T
 * (settings check), and the innovation gate below watches the assumption.
 * The rotation's second-order term (phi x w dt) is neglected: at 0.5 rad/s
 * and 54 ms it is 3 % of an attitude error of 1e-4 rad, far below its sigma.
 *
 * Defaults (the table's motion bound, docs/caltable.md; argued from an
 * Astrobee-class free flyer's propulsion: the fans give at most ~0.1 m/s^2
 * commanded linear acceleration at full thrust, the "quick" flight mode's
 * limits are below 0.05 m/s^2 and 0.2 rad/s^2; the controller's unmodelled
 * part is smaller than the commanded acceleration itself, which the filter
 * does not know: so the whole worst-case commanded acceleration is the bound):
 *   accel_bound_mm_s2 100 (0.1 m/s^2, full thrust), alpha_bound_rad_s2 0.25
 *   (~14 deg/s^2, above Astrobee's 0.2 rad/s^2 limit), bound_time_s 0.2
 *   (coasts of up to 0.2 s, almost four frames, are overbounded),
 *   max_coast_s 0.2. A robot whose motion these do not bound (a turntable:
 *   omega^2 r) needs its own in its table.
 * A collision or a burst beyond these is what the gate below is for.
 *
 * Update from one observation: the beacon p_w (map, survey sigma_mm) seen by
 * camera cam at pixel (u, v) (measured, distorted: the ML solve's
 * measurement, pose.h) with the blob's covariance cov_px2. Its noise R is
 * pose.c's, mfns_pose_obs_cov: the blob's covariance + sigma_px^2 I + the
 * survey error projected into the image. Linearised with mfns_cam_project's
 * Jacobian d(u, v)/d(increment) at the prediction, chained to the error
 * state above: H = [J_th (-C) + J_t [r_bw_b]x C,  -J_t C,  0,  0]. Standard
 * 2-D update K = P H^T S^-1, S = H P H^T + R, P <- (I - K H) P (I - K H)^T +
 * K R K^T (Joseph form, rank-2 shaped: O(N^2); symmetrised),
 * then the error injected into the nominal state (rotation on the manifold).
 *
 * Innovation gate (the motion bound's monitor): NIS = y^T S^-1 y against the
 * chi-square(2) quantile -2 ln(gate_p) (exact for 2 degrees of freedom). A
 * gated observation is not applied. gate_reject_run consecutive gated
 * observations (none accepted between them) from at least two cameras set
 * motion_exceeded: a single faulty beacon between healthy ones never does,
 * nor does one faulty camera (its own observations only: the filter bank
 * names it), a robot that left the motion bound makes every observation of
 * every camera fail. A robot seen by one camera alone that breaks the bound
 * is not told from a fault of that camera: every observation is gated, the
 * filter coasts and max_coast_s ends it (E_TIME). The caller then restarts from
 * acquisition (mfns_filter_init from a certified snapshot fix).
 *
 * Map datum: it is a rigid motion of the whole map, common to every
 * observation at every time: it is not in the filter's R or P (where it would
 * be averaged down as if independent) but added once to the output
 * covariance (mfns_filter_pose_cov_ros), as pose.c adds it to a fix's.
 *
 * What it misses (say so in reports):
 *   - the survey error of one beacon is a bias in time, treated here as white
 *     per observation (pose.c's R): a beacon seen for many frames is averaged
 *     as if its survey error fell; the fault hypotheses (filter_bank.h) bound
 *     a beacon that is wrong, the per-beacon survey sigma at ~0.4 mm is below
 *     the pixel noise's effect at the depths flown, but NEES with survey error
 *     present is not chi-square: a consider state per beacon would fix it;
 *   - the calibration's covariance is not a term of P (pose.c's A Sigma_c
 *     A^T): a camera that moved is the camera hypothesis's job;
 *   - acceleration beyond the bound that stays below the gate for a few
 *     frames (a soft push): the gate is per observation, a slow excess
 *     shows as a growing separation in the bank before it trips the gate.
 *
 * Work per call: propagate O(16 x 6) multiply-adds; update one projection,
 * O(16^2 x 2) (an augmented camera's observation: a second projection of
 * the same point for J_c); no loop without a constant bound. Float throughout: the
 * covariance spans 1e-9 rad^2 to 1e4 (mm/s)^2 but every update keeps P
 * symmetric and its diagonal non-negative (clamped, counted in
 * clamp_events, which the tests assert stays 0); time is int64 microseconds
 * (a float second loses milliseconds after a day of uptime).
 */
#ifndef MFNS_NAV_FILTER_H
#define MFNS_NAV_FILTER_H

#include <stdbool.h>
#include <stdint.h>

#include "math/lens.h"
#include "firmware/nav/settings/nav_settings.h"

/* 12 states of the body: attitude, position, velocity, angular rate; 12 x
 * 12 floats of covariance. A camera hypothesis (filter_bank.h) also carries
 * its camera's MFNS_FILTER_MAX_AUG fault parameters, as nominal values only
 * (no states: mfns_filter_update_invariant eliminates them from each of the
 * camera's frames); the observation Jacobian has their columns after the
 * states' (MFNS_FILTER_JAC_N). */
#define MFNS_FILTER_BASE_N 12
#define MFNS_FILTER_MAX_AUG 4
#define MFNS_FILTER_N MFNS_FILTER_BASE_N
#define MFNS_FILTER_JAC_N (MFNS_FILTER_N + MFNS_FILTER_MAX_AUG)
#define MFNS_FILTER_ATT 0
#define MFNS_FILTER_POS 3
#define MFNS_FILTER_VEL 6
#define MFNS_FILTER_OMEGA 9
/* the Jacobian columns of camera aug_cam's pointing bias (rad, body axes:
 * C_k_b(true) = exp([b]x) C_k_b(table)) and time offset (s: its frame
 * stamped t was captured at t - tau) */
#define MFNS_FILTER_AUG_ROT 12
#define MFNS_FILTER_AUG_DT 15
#define MFNS_FILTER_NO_AUG 0xFFU
/* The settings (mfns_filter_settings_t, nav_settings.h) are the table's motion
 * bound (docs/caltable.md "Motion bound"): the acceleration bounds, T, the
 * coast, the gate (P 1e-5 by default: chi-square(2) NIS 23.0) and its reject
 * run, and the scales of a camera's fault parameters (1 deg of pointing, 60 ms
 * of timing), which regularise the fit of the linearisation point in
 * mfns_filter_update_invariant and nothing else (each frame's fault
 * parameters are eliminated, so the hypothesis assumes nothing about the
 * fault's size or profile). Defaults and their reasons: contract/caltable_layout.toml,
 * mfns_filter_settings_default (generated). */
/* re-orthonormalise the attitude after every injection: at most this many
 * iterations (linalg.h) */
#define MFNS_FILTER_ORTHO_ITERS 4
/* cycles of the windowed NIS test (mfns_filter_end_cycle): 8 frames = 0.43 s */
#define MFNS_FILTER_NIS_WINDOW 8

typedef enum {
    MFNS_FILTER_OK = 0,      /* applied */
    MFNS_FILTER_GATED,       /* observation inconsistent with the prediction: not applied */
    MFNS_FILTER_E_ARG,       /* NULL, not initialised, bad settings, non-finite input */
    MFNS_FILTER_E_TIME,      /* a time before the state's or a step beyond max_coast_s */
    MFNS_FILTER_E_GEOM,      /* beacon behind the camera, or S not positive definite */
} mfns_filter_status_t;

typedef struct {
    mfns_m3_t C_w_b;
    mfns_v3_t r_wb_w; /* mm */
    mfns_v3_t v_w;    /* mm/s */
    mfns_v3_t w_w;    /* rad/s */
    float P[MFNS_FILTER_N][MFNS_FILTER_N];
    int64_t t_us;
    int64_t t_meas_us;      /* time of the last applied observation (or of init) */
    uint32_t updates;       /* observations applied since init */
    uint32_t gated;         /* observations gated out since init */
    uint32_t clamp_events;  /* negative diagonals clamped (numerical trouble: should stay 0) */
    uint16_t reject_run;    /* consecutive gated observations */
    uint8_t reject_cams;    /* cameras of those (bit per camera) */
    uint8_t motion_exceeded; /* sticky until the next init */
    /* the cycle-window NIS test (mfns_filter_end_cycle) */
    float cyc_nis;
    uint16_t cyc_dof;
    float win_nis[MFNS_FILTER_NIS_WINDOW];
    uint16_t win_dof[MFNS_FILTER_NIS_WINDOW];
    uint8_t win_pos, win_fill;
    uint8_t initialised;
    /* a camera hypothesis's camera (MFNS_FILTER_NO_AUG: none) and the
     * fault parameters its last frame was fitted with (the linearisation
     * point of mfns_filter_update_invariant, and how every later prediction
     * of that camera by this filter is made): pointing bias (rad, body
     * axes), time offset (s), and the linear and angular velocity the time
     * offset's column was taken at (the prediction at that frame) */
    uint8_t aug_cam;
    mfns_v3_t aug_rot;
    float aug_dt_s;
    mfns_v3_t aug_v_w, aug_w_w;
} mfns_filter_t;

/* One observation as the filter takes it. */
typedef struct {
    int64_t t_us;     /* capture time of its frame */
    uint8_t cam;      /* 0..MFNS_NUM_CAMERAS-1 */
    float u, v;       /* measured (distorted) pixel */
    float cov_px2[3]; /* blob covariance (pose.h mfns_obs_t), all zero = unknown */
    mfns_v3_t p_w;    /* the beacon's surveyed position (mm) */
    float sigma_mm;   /* its survey 1-sigma */
} mfns_filter_obs_t;

/* What one update did (diagnostics and the bank's tests). */
typedef struct {
    float nis;        /* y^T S^-1 y of the observation */
    float innov_px[2];
} mfns_filter_update_info_t;

bool mfns_filter_settings_valid(const mfns_filter_settings_t *s);

/* The chi-square(2) threshold of the gate: -2 ln(gate_p). */
float mfns_filter_gate_nis(const mfns_filter_settings_t *s);

/* Start from a certified snapshot fix: pose, its 6x6 covariance in pose.h's
 * cov_ros order (x, y, z mm; rx, ry, rz rad, world) WITHOUT the map datum term
 * (solve it with a config whose datum is NULL: the filter adds the datum at
 * its output), a velocity prior v_w / w_w with 1-sigma per axis sigma_v_mm_s /
 * sigma_w_rad_s (uncorrelated with the pose), at capture time t_us. */
mfns_filter_status_t mfns_filter_init(mfns_filter_t *f, const mfns_pose_t *pose, const float cov_ros[6][6],
                                      mfns_v3_t v_w, float sigma_v_mm_s, mfns_v3_t w_w, float sigma_w_rad_s,
                                      int64_t t_us);

/* Move the state to t_us: t_us >= the state's time and at most max_coast_s
 * after the last applied observation (a longer coast is E_TIME: restart). */
mfns_filter_status_t mfns_filter_propagate(mfns_filter_t *f, const mfns_filter_settings_t *s, int64_t t_us);

/* Propagate to the observation's time, gate it and apply it. rig holds the
 * camera, sigma_px is the table's unmodelled pixel floor (pose.h). info may
 * be NULL. GATED leaves the state propagated but not updated. */
mfns_filter_status_t mfns_filter_update(mfns_filter_t *f, const mfns_filter_settings_t *s, const mfns_rig_t *rig,
                                        float sigma_px, const mfns_filter_obs_t *obs,
                                        mfns_filter_update_info_t *info);

/* The same without the gate: the observation is applied whatever its NIS
 * (which still enters the cycle's sums). For the subset filters of a bank
 * (filter_bank.h): the full filter's gate decides for all of them, so that
 * every filter takes the same data but its hypothesis's. */
mfns_filter_status_t mfns_filter_update_ungated(mfns_filter_t *f, const mfns_filter_settings_t *s,
                                                const mfns_rig_t *rig, float sigma_px, const mfns_filter_obs_t *obs,
                                                mfns_filter_update_info_t *info);

/* Innovation test only, state untouched (for re-admitting an excluded beacon
 * or camera): the NIS of obs against the state predicted to its time.
 * E_* as for update; OK with *nis set. */
mfns_filter_status_t mfns_filter_test(const mfns_filter_t *f, const mfns_filter_settings_t *s,
                                      const mfns_rig_t *rig, float sigma_px, const mfns_filter_obs_t *obs,
                                      float *nis);

/* Close a cycle for the windowed consistency test of the motion bound: the
 * sum of the NIS of every observation of the last MFNS_FILTER_NIS_WINDOW
 * cycles (a gated one counted at the gate's value) against chi-square of
 * their degrees of freedom at gate_p (Wilson-Hilferty, z = Q^-1(gate_p)).
 * The sequential NIS of a cycle sum to the joint NIS of its observations
 * against the prediction, so the window is a proper chi-square test; it sees
 * a sustained excess the per-observation gate lets through (the filter
 * follows it, but too surprised too often). Sets motion_exceeded and
 * returns true when it fails. A fault of one beacon or camera inflates it
 * too: the bank excludes those first and resets the window
 * (mfns_filter_reset_window); one it has not caught ends as a restart, which
 * costs availability, never integrity. */
bool mfns_filter_end_cycle(mfns_filter_t *f, const mfns_filter_settings_t *s);
void mfns_filter_reset_window(mfns_filter_t *f);

/* Upper chi-square quantile of dof degrees of freedom at tail probability p
 * (Wilson-Hilferty; relative error < 1 % for dof >= 4 at p >= 1e-7). */
float mfns_filter_chi2_quantile(float dof, float p);

/* Make f a camera hypothesis of camera cam (filter_bank.h): cam's frames are
 * then taken by mfns_filter_update_invariant, and every prediction of cam by
 * f (mfns_filter_test, mfns_filter_update) goes through the fault
 * parameters its last frame was fitted with (nominal zero until then):
 *   z = h(x(t - tau); C_k_b = exp([b]x) C_k_b) ~ h(x(t)) - tau (H_phi w + H_r v)
 *   d z / d b   = J_c C_k_b'^T [p_b - r_bk_b]x       (J_c = d(u,v)/d p_k)
 *   d z / d tau = -(H_phi w_w + H_r v_w)            (the beacon's image velocity)
 * with w_w, v_w the velocity predicted at the frame (aug_v_w, aug_w_w: the
 * frame is linearised once). cam out of range: E_ARG. */
mfns_filter_status_t mfns_filter_augment(mfns_filter_t *f, int cam);

/* No camera hypothesis any more: the fault parameters' nominal dropped. */
void mfns_filter_strip_aug(mfns_filter_t *f);

/* Camera cam's frame (n observations of one capture time, cam = f's
 * augmented camera: mfns_filter_augment) taken with the camera's fault
 * parameters ELIMINATED, the update of a camera hypothesis (filter_bank.h):
 *   1. the pointing bias b and the time offset tau that fit the frame best
 *      at the predicted body state (MFNS_FILTER_INV_FIT_ITERS Gauss-Newton
 *      steps from the last frame's, regularised by the settings' aug_rot_rad
 *      and aug_dt_s, which only this linearisation point depends on) are
 *      the linearisation point;
 *   2. the whitened residuals and pose Jacobians of the frame are rotated
 *      (Householder) onto the orthogonal complement of the fault
 *      parameters' columns: what no value of b and tau can change (the
 *      beacons' relative geometry, 2n - 4 numbers; 2n - 3 on a robot at rest,
 *      whose timing column has no effect: a column whose remaining weight is
 *      below MFNS_FILTER_INV_COL_EPS per rad or s is left);
 *   3. those rows update the body states, one scalar at a time (unit noise).
 * Within the linearisation the result does not depend on the camera's
 * pointing or timing at all, whatever the fault's size or time profile: a
 * flat prior, not the finite one of the sequential augmented update, so the
 * bank may bound a camera hypothesis by its observed separation. What it
 * misses: the second order of a fault beyond the fit (a time offset of many
 * periods on a turning robot, the motion over it not constant-velocity).
 * At most MFNS_FILTER_INV_MAX_OBS observations are used (the rest dropped:
 * less information, never a fault in). One or two beacons (4 or fewer
 * numbers) leave nothing: OK with info->rows 0, the state only propagated.
 * The residual sum of squares of the rows enters the cycle's NIS sums.
 * E_ARG on bad input or a camera that is not f's augmented one, E_TIME as
 * propagate, E_GEOM on a beacon behind the camera or a degenerate fit. */
#define MFNS_FILTER_INV_MAX_OBS 16
#define MFNS_FILTER_INV_COLS 7 /* residual + the 6 pose columns */
#define MFNS_FILTER_INV_FIT_ITERS 2
#define MFNS_FILTER_INV_COL_EPS 1e-3f
typedef struct {
    uint16_t rows;      /* rows applied (2n less the parameters eliminated) */
    uint8_t eliminated; /* fault parameters eliminated (4; 3 at rest; timing-free: 1, 0 at rest) */
    float nis;          /* their residual sum of squares */
    /* timing-free only (0 from the invariant update): the camera's time
     * offset read from the frame at the predicted state, s (the frame
     * stamped t shows the scene of t - tau_s), and its 1-sigma from the
     * frame's noise and the state's covariance; INFINITY when the frame
     * has no image motion to read it from (a robot at rest) */
    float tau_s;
    float tau_sigma_s;
    /* timing-free with tau_bound_s > 0: the covariance the offset's term
     * added to P (zero otherwise); the bank adds the full filter's to every
     * subset that takes the frame (mfns_filter_add_cov) */
    float added_cov[MFNS_FILTER_N][MFNS_FILTER_N];
} mfns_filter_invariant_info_t;
mfns_filter_status_t mfns_filter_update_invariant(mfns_filter_t *f, const mfns_filter_settings_t *s,
                                                  const mfns_rig_t *rig, float sigma_px, int n,
                                                  const mfns_filter_obs_t obs[], mfns_filter_invariant_info_t *info);

/* Camera obs[0].cam's frame with its TIME OFFSET alone eliminated, its
 * pointing held at the mount: the update of any filter that takes the frame
 * of a camera whose clock is in doubt (filter_bank.h "timing in doubt": a
 * dropped or held frame, a clock step, a late or frozen frame). As
 * mfns_filter_update_invariant with one fault column (2n - 1 rows, 2n at
 * rest), fitted from zero at every frame; f need not be that camera's
 * hypothesis (its own camera hypothesis, if any, is left as it was). What
 * it leaves: the frame's information along the image motion of the robot's
 * current velocity (one number), which is all a clock can move. What it
 * misses: as the invariant update, and a pointing fault of the camera (the
 * camera's own hypothesis covers that). info->tau_s and tau_sigma_s read
 * the camera's clock against the predicted state, for the bank's test of
 * the doubt. ref (NULL: f itself) is the filter whose velocity gives the
 * eliminated direction (the time offset's column, the image motion of that
 * velocity): the filters of a bank that take one frame must eliminate the
 * same direction, so that each takes the same linear functionals of the
 * frame and a subset's covariance stays at or above the full filter's
 * (filter_bank.h: with each filter's own velocity, a beacon's subset came
 * out 5 % more certain than the full filter on one axis and its separation
 * test failed on 0.04 mm). Errors as mfns_filter_update_invariant (no
 * augmented camera needed; E_ARG also for an uninitialised ref).
 * tau_bound_s (0: none; at most MFNS_FILTER_CONSIDER_TAU_MAX_S) bounds the
 * camera's offset |tau|: the eliminated direction is the image motion of
 * ref's velocity, and a frame tau late keeps tau times that velocity's
 * error in every row, which the rows then put into the state (a camera a
 * period stale after a dropped frame on a robot whose velocity is known to
 * ~10 mm/s: ~0.5 mm a frame, against a position sigma of 0.3 mm; grown
 * campaign, module seed 5: usable fixes with NEES up to 190, 14 sigma along
 * the thinnest direction, within 3.4 sigma per axis). With tau_bound_s > 0
 * the covariance takes that term: P <- P + tau_bound_s^2 M Sz M^T, M the
 * rows' gain on the velocity error, Sz the predicted velocity covariance.
 * What it misses: the term's correlation with the state's own error (left
 * out: bounded for either sign of tau it added about three times P at every
 * frame and left nothing usable; nav_filter.c consider_*), so P is the
 * term's as if independent, not a bound; an offset beyond tau_bound_s (the
 * caller's frame checks drop a camera out of step: half a period); the
 * second order of the motion over tau. Measured (grown campaign, module
 * seed 5, camera x a period stale after a dropped frame): 14 misleading
 * fixes -> 0, 86 usable -> 80. */
/* a bound beyond 1 s is no clock the frame checks would have let through */
#define MFNS_FILTER_CONSIDER_TAU_MAX_S 1.0f
mfns_filter_status_t mfns_filter_update_timing_free(mfns_filter_t *f, const mfns_filter_settings_t *s,
                                                    const mfns_rig_t *rig, float sigma_px, int n,
                                                    const mfns_filter_obs_t obs[], const mfns_filter_t *ref,
                                                    float tau_bound_s, mfns_filter_invariant_info_t *info);

/* P <- P + add (add symmetric positive semi-definite: the caller's; a
 * term common to several filters, filter_bank.c). False and f untouched on
 * NULL, an uninitialised filter or a non-finite or negative diagonal. */
bool mfns_filter_add_cov(mfns_filter_t *f, const float add[MFNS_FILTER_N][MFNS_FILTER_N]);

/* The observation Jacobian at the state f for obs (rows 2, columns
 * MFNS_FILTER_JAC_N: the N states', then, for f's camera hypothesis's
 * camera, the fault parameters' at MFNS_FILTER_AUG_*; zero otherwise) and
 * the prediction; exposed for tests (finite differences). The time offset's
 * column uses the velocity held for the frame (aug_v_w, aug_w_w). False
 * when the beacon is behind the camera. */
bool mfns_filter_obs_jacobian_full(const mfns_filter_t *f, const mfns_rig_t *rig, const mfns_filter_obs_t *obs,
                                   float uv[2], float h[2][MFNS_FILTER_JAC_N]);

/* The pose of the state. */
mfns_pose_t mfns_filter_pose(const mfns_filter_t *f);

/* The pose covariance in cov_ros order (x, y, z mm; rx, ry, rz rad) with the
 * map datum's term added once (datum NULL or not present: none). */
void mfns_filter_pose_cov_ros(const mfns_filter_t *f, const mfns_map_datum_t *datum, float cov_ros[6][6]);

/* The datum term alone in the filter's pose order (phi_w 0-2, r_wb_w 3-5). */
void mfns_filter_datum_cov(const mfns_pose_t *pose, const mfns_map_datum_t *datum, float d[6][6]);

/* The measurement Jacobian of an observation at the state (2 x 6, pose
 * block; exposed for tests). False when the beacon is behind the camera. */
bool mfns_filter_obs_jacobian(const mfns_camera_t *cam, const mfns_pose_t *pose, mfns_v3_t p_w, float uv[2],
                              float h[2][6]);

const char *mfns_filter_strerror(mfns_filter_status_t s);

#endif /* MFNS_NAV_FILTER_H */
