/* pose_testlib.h -- shared by the pose tests and the pose benchmark: the
 * paper's rig (docs/system.md §7 Tables 2-3) and beacon map (Table 4), synthetic
 * observations computed in double, and a double-precision reference
 * Gauss-Newton on the reprojection error (the float solver is checked
 * against it). */
#ifndef MFNS_POSE_TESTLIB_H
#define MFNS_POSE_TESTLIB_H

#include "firmware/nav/map/beacon_index.h"
#include "firmware/nav/pose/pose.h"
#include "tests/unit/support/testutil.h"

typedef struct {
    double C[3][3]; /* C_w_b */
    double r[3];    /* r_bw_b (mm) */
} pt_dpose_t;

mfns_rig_t pt_paper_rig(void);
mfns_beacon_map_t pt_paper_map(void);

void pt_rot_exp(const double w[3], double r[3][3]);
/* Pose from C_w_b and the body position r_wb_w. */
pt_dpose_t pt_pose(const double c[3][3], const double r_wb_w[3]);
/* Random attitude (uniform axis, angle up to max_angle rad) about c0. */
void pt_random_rotation(mfns_rng_t *rng, double max_angle, const double c0[3][3], double out[3][3]);
mfns_pose_t pt_to_float(const pt_dpose_t *p);
pt_dpose_t pt_from_float(const mfns_pose_t *p);
void pt_position_w(const pt_dpose_t *p, double r_wb_w[3]);

/* Double projection of a world point; false when behind or outside the image. */
bool pt_project(const mfns_camera_t *cam, const pt_dpose_t *pose, const double p_w[3], double uv[2]);
/* Pixel -> undistorted normalized, double Newton. */
void pt_undistort(const mfns_intrinsics_t *k, double u, double v, double *x, double *y);

/* Every beacon visible at pose, with Gaussian pixel noise sigma on (u, v) and
 * (x, y) from the noisy pixel; truth receives the correspondence. Returns the
 * number of observations. */
int pt_make_frame(const mfns_rig_t *rig, const mfns_beacon_map_t *map, const pt_dpose_t *pose, double sigma,
                  mfns_rng_t *rng, mfns_obs_frame_t *frame, mfns_pose_assoc_t *truth);
/* Adds a spurious blob (reflection) at a random pixel of camera cam. */
void pt_add_spurious(const mfns_rig_t *rig, int cam, mfns_rng_t *rng, mfns_obs_frame_t *frame,
                     mfns_pose_assoc_t *truth);

/* Reference Gauss-Newton in double on the pixel error, from *pose (updated).
 * Returns the iterations used or -1 when it did not converge. */
int pt_ref_refine(const mfns_rig_t *rig, const mfns_beacon_map_t *map, const mfns_obs_frame_t *frame,
                  const mfns_pose_assoc_t *assoc, pt_dpose_t *pose);
/* Rotation angle between two attitudes (rad) and position distance (mm). */
double pt_rot_err(const double a[3][3], const double b[3][3]);
double pt_pos_err(const pt_dpose_t *a, const pt_dpose_t *b);


/* A map made for a pose: per_cam[c] beacons in camera c's field of view
 * (inside the image with a margin) at depths depth_lo..depth_hi mm. */
mfns_beacon_map_t pt_dense_map(const mfns_rig_t *rig, const pt_dpose_t *pose, const int per_cam[3], double depth_lo,
                               double depth_hi, mfns_rng_t *rng);
/* A random pose (uniform attitude, position within +-pos_range mm per axis)
 * at which at least min_visible beacons of the map are visible; tries at
 * most max_tries poses, returns the visible count (0 when none found). */
/* A pose of uniformly random attitude and position in [-pos_range, pos_range] mm per axis. */
pt_dpose_t pt_random_pose(mfns_rng_t *rng, double pos_range);
/* The solver's default configuration with the pixel sigma sigma. */
mfns_pose_config_t pt_config(double sigma);

int pt_random_visible_pose(const mfns_rig_t *rig, const mfns_beacon_map_t *map, double pos_range, int min_visible,
                           int max_tries, mfns_rng_t *rng, pt_dpose_t *pose);

/* In *idx the index of map over body positions within +-range_mm of the
 * origin per axis, default parameters but the certificate cert (asserts it
 * builds). */
void pt_build_index(const mfns_rig_t *rig, const mfns_beacon_map_t *map, double range_mm, uint8_t cert,
                    mfns_beacon_index_t *idx);

/* A self-similar map: pt_dense_map's cluster of per_cam beacons at the
 * identity pose (900-1400 mm deep) and its copy 1500 mm along x, out of view
 * of the first, every beacon at 0.4 mm survey sigma; and in *idx its index
 * over both places (default parameters; asserts it builds). */
mfns_beacon_map_t pt_twin_map(const mfns_rig_t *rig, const int per_cam[3], mfns_rng_t *rng, mfns_beacon_index_t *idx);

/* True when every inlier of sol carries the beacon truth gives its observation. */
bool pt_assoc_right(const mfns_pose_solution_t *sol, const mfns_obs_frame_t *frame, const mfns_pose_assoc_t *truth);
#endif
