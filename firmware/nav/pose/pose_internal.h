/* pose_internal.h -- what the pose modules share among themselves (not part
 * of the flight API, which is pose.h and pose_init.h). */
#ifndef MFNS_POSE_INTERNAL_H
#define MFNS_POSE_INTERNAL_H

#include "firmware/nav/pose/pose.h"
#include "math/spd.h"

#define MFNS_POSE_MAX_MEAS (MFNS_NUM_CAMERAS * MFNS_MAX_OBS_PER_CAMERA)

/* One associated observation as the solvers see it. */
typedef struct {
    uint8_t cam, idx;
    int16_t beacon;
    float u, v; /* measured pixel */
    float x, y; /* undistorted normalized */
    mfns_v3_t p_w;
    float cov_px2[3]; /* the centroid's covariance (mfns_obs_t; zero = unknown) */
    float sigma_mm;   /* the beacon's survey 1-sigma */
    float w[3];       /* whitener of R (mfns_pose_whitener), set by mfns_pose_weigh */
    uint8_t active; /* 0 once gated out as an outlier */
} mfns_pose_meas_t;

/* One measurement from observation i of camera c assigned to beacon b (the
 * caller has checked the indices); weights unit until mfns_pose_weigh. */
void mfns_pose_meas_set(const mfns_beacon_map_t *map, const mfns_obs_frame_t *frame, int c, int i, int b,
                        mfns_pose_meas_t *m);

/* Each active measurement's whitener from its covariance at pose
 * (mfns_pose_obs_cov); a beacon behind the camera keeps the floor's. The
 * weights are held fixed within one LM run (a fixed cost), re-evaluated at
 * the solution before the outlier gate and the covariance. */
void mfns_pose_weigh(const mfns_rig_t *rig, mfns_pose_meas_t *m, int n, const mfns_pose_t *pose,
                     const mfns_pose_config_t *cfg);

/* Check frame/assoc/map and gather the assigned observations into m.
 * Returns the count, or -1 on bad input. */
int mfns_pose_gather(const mfns_beacon_map_t *map, const mfns_obs_frame_t *frame,
                     const mfns_pose_assoc_t *assoc, mfns_pose_meas_t m[MFNS_POSE_MAX_MEAS]);

/* Bounded Levenberg-Marquardt on the pixel reprojection error (Huber IRLS
 * when robust). Updates *pose; returns MFNS_POSE_R_NONE when converged. */
mfns_pose_reason_t mfns_pose_lm(const mfns_rig_t *rig, const mfns_pose_meas_t *m, int n,
                                const mfns_pose_config_t *cfg, int max_iter, mfns_pose_t *pose,
                                int *iterations);

/* h's upper triangle from its lower one: the normal equations are
 * accumulated for j <= i only (linearize, mfns_pose_info_matrix). */
void mfns_pose_mirror_lower(float h[6][6]);

/* One Newton step of both iterations: solves a d = -g by Cholesky (a is the
 * 6x6 normal matrix, damped or not, rotation first, translation in mm), and
 * gives the step's norms: *step_rot_rad, *step_tr_m (mm scaled to m, so one
 * tolerance serves both). False when a is not positive definite at
 * min_rcond (the caller's SINGULAR). */
bool mfns_pose_newton_step(float a[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N], const float g[6], float min_rcond,
                           float d[6], float *step_rot_rad, float *step_tr_m);

/* The paper's Newton (Gauss-Newton) iteration on Eq. 3's algebraic residual
 * x*Zc - Xc, y*Zc - Yc in the camera frame (mm), undamped, unweighted. */
mfns_pose_reason_t mfns_pose_paper_newton(const mfns_rig_t *rig, const mfns_pose_meas_t *m, int n,
                                          const mfns_pose_config_t *cfg, int max_iter,
                                          mfns_pose_t *pose, int *iterations);

/* Pixel residual (predicted - measured) of one observation; false when the
 * beacon is behind the camera. jac may be NULL. */
bool mfns_pose_residual(const mfns_rig_t *rig, const mfns_pose_meas_t *m, const mfns_pose_t *pose,
                        float r[2], float jac[2][6]);

/* Whitened residual e = L^-1 r (r = predicted - measured, R = L L^T, the
 * whitener m->w) and, when jac is not NULL, the whitened Jacobian L^-1 J. */
bool mfns_pose_wresidual(const mfns_rig_t *rig, const mfns_pose_meas_t *m, const mfns_pose_t *pose,
                         float e[2], float jac[2][6]);

/* d(u, v) / d(calibration parameters of cam) (nav_settings.h order, the
 * error conventions of mfns_calib_cov_t) of the beacon at p_w seen from
 * pose; false when it is behind the camera. */
bool mfns_pose_calib_jacobian(const mfns_camera_t *cam, const mfns_pose_t *pose, mfns_v3_t p_w,
                              float jc[2][MFNS_CALIB_PARAMS_PER_CAMERA]);

/* J^T R^-1 J over the active observations and, when b is not NULL, B =
 * J^T R^-1 J_c (J_c = d pixel / d calibration parameters, nav_settings.h
 * order; a camera's observation fills only its camera's columns). */
void mfns_pose_info_matrix(const mfns_rig_t *rig, const mfns_pose_meas_t *m, int n,
                           const mfns_pose_t *pose, float h[6][6], float b[6][MFNS_CALIB_PARAMS]);

/* The map datum's term of the increment's covariance at pose, G Sigma_d G^T,
 * added to cov (6x6, symmetric). A rigid motion (dt, dth about c_w) of the map
 * moves the fix rigidly with it: dtheta = -C_w_b dth and dt_inc = -C_w_b (dt +
 * c_w x dth) (C_w_b' = exp(dtheta) C_w_b, r_bw_b' = r_bw_b + dt_inc), so that
 * r_wb_w moves by dt + dth x (r_wb_w - c_w) and the attitude by dth, whatever
 * the observations. Nothing when datum is NULL or not present. */
void mfns_pose_add_datum_term(const mfns_pose_t *pose, const mfns_map_datum_t *datum, float cov[6][6]);

/* Covariance (J^T R^-1 J)^-1 (+ A Sigma_c A^T with A = (J^T R^-1 J)^-1 B when
 * b and calib are not NULL and calib is present, + the map datum's term when
 * datum is present) into out->cov, out->cov_ros and the 1-sigma per output
 * axis (r_wb_w, Euler angles), at out->pose. Returns MFNS_POSE_R_SINGULAR when
 * h is rank-deficient or below min_rcond (out->cov then zero). */
mfns_pose_reason_t mfns_pose_covariance(const float h[6][6], const float b[6][MFNS_CALIB_PARAMS],
                                        const mfns_calib_cov_t *calib, const mfns_map_datum_t *datum,
                                        float min_rcond, mfns_pose_solution_t *out);

/* Full refinement on gathered measurements (used by refine, track and acquire). */
mfns_pose_status_t mfns_pose_refine_meas(const mfns_rig_t *rig, mfns_pose_meas_t *m, int n,
                                         const mfns_pose_t *init, const mfns_pose_config_t *cfg,
                                         mfns_pose_solution_t *out);

/* Greedy one-to-one association of blobs with the beacons predicted by pred,
 * closest pairs first, within gate (px). Returns the number associated. */
int mfns_pose_associate(const mfns_rig_t *rig, const mfns_beacon_map_t *map, const mfns_obs_frame_t *frame,
                        const mfns_pose_t *pred, float gate, mfns_pose_assoc_t *assoc);


#endif /* MFNS_POSE_INTERNAL_H */
