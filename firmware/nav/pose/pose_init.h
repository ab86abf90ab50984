/* pose_init.h -- initialization with no guess: a generalized (multi-camera)
 * three-point absolute pose solver.
 *
 * Each observation is a ray in the body frame, origin c (the camera centre
 * r_bk_b) and unit direction d (C_k_b [x y 1]^T normalized); the unknown
 * depths lambda_i put the beacon at c_i + lambda_i d_i = C_w_b X_i + r_bw_b.
 * Rigid motion preserves the three beacon distances, which gives three
 * quadratics in the depths; eliminating lambda_1 (resultant of two monic
 * quadratics) and then lambda_2 (remainder modulo the third) leaves one
 * polynomial of degree <= 8 in lambda_3 (built in closed form, ~150
 * multiply-adds) whose real roots in [min_range, max_range] (the third
 * depth's interval; the first two depths need only be positive) are isolated by
 * Descartes' rule of signs on its Bernstein coefficients with bisection
 * (de Casteljau, bounded depth and interval count) and found by a
 * safeguarded Newton iteration, then polished by Newton on the three
 * distance equations. The pose follows from the three body points by the
 * triad (exact for exact points). Up to 8 poses; bounded time (0.57 us per
 * call on the benchmark host, 2.6x faster than the derivative-cascade
 * isolation it replaced).
 *
 * A double root (the poses of the "danger cylinder") is reported once when f
 * is at rounding level there; a near-double pair that noise has turned
 * complex is missed. The caller verifies with other beacons anyway and treats
 * the minimal case as ambiguous unless verified.
 */
#ifndef MFNS_POSE_INIT_H
#define MFNS_POSE_INIT_H

#include "math/lens.h"

#define MFNS_GP3P_MAX_SOLUTIONS 8

/* Returns the number of poses written to out (0..8): out[0..n). The slot
 * after them may have been written too (a duplicate is solved in place). */
int mfns_gp3p(const mfns_v3_t c[3], const mfns_v3_t d[3], const mfns_v3_t x_w[3], float min_range_mm,
              float max_range_mm, mfns_pose_t out[MFNS_GP3P_MAX_SOLUTIONS]);
/* The same with each ray origin, direction and beacon by address: the
 * acquisition passes its blobs' rays and the map's beacons where they are,
 * without gathering nine vectors into arrays first (docs/budgets.md). */
int mfns_gp3p_at(const mfns_v3_t *const c[3], const mfns_v3_t *const d[3], const mfns_v3_t *const x_w[3],
                 float min_range_mm, float max_range_mm, mfns_pose_t out[MFNS_GP3P_MAX_SOLUTIONS]);

/* The body-frame ray of an undistorted normalized observation (x, y) in camera k. */
void mfns_pose_ray(const mfns_camera_t *cam, float x, float y, mfns_v3_t *origin, mfns_v3_t *dir);

#endif /* MFNS_POSE_INIT_H */
