/* pose.h -- the body pose from beacon observations of the three cameras
 * (docs/system.md §3, §6): beacon identification, initialization with no guess,
 * the maximum-likelihood refinement on the reprojection error, its
 * covariance, and the paper's Eq. 3 Newton solve as a selectable baseline.
 *
 * Input per camera: observations carrying both the measured (distorted)
 * pixel (u, v), which the ML refinement fits, and the undistorted normalized
 * coordinates (x, y), which give the bearing rays used by identification and
 * initialization (and by paper mode, which fits Eq. 3 in those coordinates).
 *
 * Entry points:
 *   mfns_pose_track    tracking from a predicted pose: gate blobs against
 *                      the predicted beacons, refine.
 *   mfns_pose_refine   refinement with known correspondences (warm start).
 * Acquisition with no prior is acquire.h; the policy of which to run in a
 * cycle (track, else acquire) belongs to the navigation cycle (nav_cycle.h).
 *
 * Every call fills a mfns_pose_solution_t whose status is OK, DEGRADED or
 * NO_FIX with a reason. Only OK and DEGRADED carry a usable pose; a NO_FIX
 * solution never holds a stale pose marked valid (its pose is the last
 * iterate, for diagnostics only). Time is bounded by the iteration cap of
 * the settings; nothing allocates.
 */
#ifndef MFNS_POSE_H
#define MFNS_POSE_H

#include <stdbool.h>
#include <stdint.h>

#include "math/lens.h"
#include "firmware/nav/settings/nav_settings.h"
#include "math/rotation.h"

/* One corrected beacon observation. */
typedef struct {
    float u, v; /* measured (distorted) pixel, pixel-centre convention */
    float x, y; /* undistorted normalized coordinates of the same blob */
    /* Covariance of the measured (u, v) from the blob's photometry (px^2):
     * [0] var u, [1] cov uv, [2] var v. All zero = not known: the solver
     * then has only the table's pixel_sigma_px (mfns_pose_obs_cov). */
    float cov_px2[3];
} mfns_obs_t;

/* The observations of one frame set (one image per camera). */
typedef struct {
    uint16_t count[MFNS_NUM_CAMERAS];
    mfns_obs_t obs[MFNS_NUM_CAMERAS][MFNS_MAX_OBS_PER_CAMERA];
    /* 1: camera k gave no image this cycle (dead, timed out, refused): no
     * beacon can be missing from it. 0 (zero-initialised): it looked. */
    uint8_t dark[MFNS_NUM_CAMERAS];
} mfns_obs_frame_t;

#define MFNS_POSE_NO_BEACON (-1)

/* Blob-to-beacon correspondence: map index per observation or MFNS_POSE_NO_BEACON. */
typedef struct {
    int16_t beacon[MFNS_NUM_CAMERAS][MFNS_MAX_OBS_PER_CAMERA];
} mfns_pose_assoc_t;

typedef enum {
    MFNS_POSE_OK = 0,
    MFNS_POSE_DEGRADED, /* usable pose, weaker than nominal: see reason */
    MFNS_POSE_NO_FIX,   /* no pose: see reason */
} mfns_pose_status_t;

/* Why a solution is not a full fix: mfns_pose_reason_t, MFNS_POSE_R_NONE = 0,
 * DEGRADED reasons (the pose is usable) CAMERA_UNUSED, OUTLIERS, MINIMAL, then
 * NO_FIX reasons. The numbers are wire codes (the nav packet's reason), so the
 * enum is generated from the telemetry dictionary contract/mfns_tm.xml
 * (nav_reason_t) with explicit, never reused numbers; docs/telemetry.md lists them. */
#include "firmware/nav/generated/nav_codes_gen.h"

typedef enum {
    MFNS_POSE_MODE_ML = 0,    /* reprojection error in pixels, robust, on the manifold */
    MFNS_POSE_MODE_PAPER = 1, /* the paper's Newton iteration on Eq. 3's algebraic form */
} mfns_pose_mode_t;

typedef struct {
    mfns_solver_settings_t s; /* from the calibration table */
    /* The table's pixel_sigma_px: the 1-sigma of the pixel error that no
     * observation's own covariance describes (unmodelled: the grid's residual,
     * calibration residuals in the image), added in quadrature to every
     * observation; when the centroider gives no covariance it is the whole
     * pixel noise (mfns_pose_obs_cov). */
    float sigma_px;
    mfns_pose_mode_t mode;
    /* The calibration's uncertainty (the table's, nav_settings.h) or NULL:
     * NULL or not present gives no calibration term in the covariance. */
    const mfns_calib_cov_t *calib_cov;
    /* The map's shared error (the table's, nav_settings.h) or NULL: NULL or not
     * present gives no datum term (each beacon's sigma_mm is its whole error). */
    const mfns_map_datum_t *datum;
} mfns_pose_config_t;

typedef struct {
    mfns_pose_status_t status;
    mfns_pose_reason_t reason;
    mfns_pose_t pose;            /* C_w_b (the rotation matrix) and r_bw_b */
    mfns_v3_t r_wb_w;            /* body position in the world (mm) */
    mfns_euler_t euler_deg;      /* 2-1-3 Euler angles of C_w_b (deg) */
    float q_b_w[4];              /* the body's orientation in the world as a unit quaternion
                                    (w, x, y, z), Hamilton, of C_b_w = C_w_b^T (rotates body
                                    vectors into the world; mfns_m3_to_quat), w >= 0 */
    /* Covariance of the increment (dtheta rad, dt mm): (J^T R^-1 J)^-1 with
     * R_i each observation's covariance (mfns_pose_obs_cov), plus the
     * calibration term A Sigma_c A^T, A = (J^T R^-1 J)^-1 J^T R^-1 J_c, when
     * the configuration carries a calibration covariance, plus the map datum's
     * rigid motion when it carries one (docs/pose.md). */
    float cov[6][6];
    /* The pose covariance for a fusion filter, in ROS PoseWithCovariance
     * order (x, y, z, rx, ry, rz): of the position error r_wb_w(est) -
     * r_wb_w(true) (mm) and of the attitude error phi_w (rad) about the
     * world's fixed axes, C_b_w(est) = exp(phi_w) C_b_w(true). Units mm^2,
     * mm rad, rad^2. */
    float cov_ros[6][6];
    float sigma_pos_mm[3];       /* 1-sigma of r_wb_w per world axis */
    float sigma_euler_deg[3];    /* 1-sigma of roll, pitch, yaw */
    uint16_t beacons_used;       /* inlier observations in the final solve */
    uint16_t outliers;           /* observations gated out */
    uint16_t cameras_used;       /* cameras with at least one inlier */
    uint16_t iterations;         /* refinement iterations (all rounds) */
    uint16_t hypotheses;         /* identification hypotheses tried (acquire; saturates) */
    float residual_rms_px;       /* inlier RMS per coordinate (px) */
    float residual_rms_sigma;    /* whitened inlier RMS per coordinate, |L_i^-1 r_i| with
                                    R_i = L_i L_i^T (1 = as the covariances predict) */
    mfns_pose_assoc_t assoc;     /* the correspondence used */
    uint8_t inlier[MFNS_NUM_CAMERAS][MFNS_MAX_OBS_PER_CAMERA];
} mfns_pose_solution_t;

/* The covariance R (px^2: [0] var u, [1] cov uv, [2] var v) of one
 * observation of the beacon at p_w (survey 1-sigma sigma_mm, isotropic) in
 * camera cam at pose: the centroid's cov_px2 (all zero = unknown) +
 * sigma_px^2 I (the unmodelled floor, pose.h mfns_pose_config_t) + the survey
 * error projected into the image, sigma_mm^2 J_p J_p^T with J_p = d(u, v) /
 * d p_w (distortion included). The one definition of an observation's
 * variance: the ML solve's weights and covariance, its outlier gate and
 * residual check, and the acquisition's verification use it. False when the
 * beacon is behind the camera, is predicted more than MFNS_POSE_COV_MARGIN_PX
 * outside the image (where the lens model, and so J_p, does not hold), or R
 * is not positive definite; the solve then weights it with the floor alone. */
#define MFNS_POSE_COV_MARGIN_PX 64.0f
bool mfns_pose_obs_cov(const mfns_camera_t *cam, const mfns_pose_t *pose, mfns_v3_t p_w, const float cov_px2[3],
                       float sigma_mm, float sigma_px, float r_px2[3]);

/* Whitening of a 2x2 covariance R = L L^T: w = (1/l00, -l10/(l00 l11),
 * 1/l11), the lower triangle of L^-1 (e = L^-1 r has unit covariance: e0 =
 * w0 r0, e1 = w1 r0 + w2 r1). False when R is not positive definite. */
bool mfns_pose_whitener(const float r_px2[3], float w[3]);

/* Defaults: the solver settings of mfns_solver_settings_default (the ones
 * tables carry by default), sigma 0.1 px, ML mode. The flight code takes the
 * table's values. */
void mfns_pose_config_default(mfns_pose_config_t *cfg);

/* Refine from init with the correspondence assoc (unassigned observations are
 * ignored). Robust Huber IRLS + Levenberg-Marquardt, then the outlier gate and
 * one re-solve without the gated observations; covariance at the solution. */
mfns_pose_status_t mfns_pose_refine(const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                    const mfns_obs_frame_t *frame, const mfns_pose_assoc_t *assoc,
                                    const mfns_pose_t *init, const mfns_pose_config_t *cfg,
                                    mfns_pose_solution_t *out);

/* Tracking: associate each blob with the predicted beacon within
 * track_gate_px (one-to-one, nearest first), then refine from predicted. */
mfns_pose_status_t mfns_pose_track(const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                   const mfns_obs_frame_t *frame, const mfns_pose_t *predicted,
                                   const mfns_pose_config_t *cfg, mfns_pose_solution_t *out);

/* Clear a solution to NO_FIX with a reason, keeping nothing stale. */
void mfns_pose_solution_clear(mfns_pose_solution_t *out, mfns_pose_reason_t reason);

const char *mfns_pose_status_str(mfns_pose_status_t s);

/* mfns_pose_strerror: nav_codes_gen.h (generated from the contract). */

#endif /* MFNS_POSE_H */
