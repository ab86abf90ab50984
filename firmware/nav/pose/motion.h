/* motion.h -- the constant-velocity motion model, the one the navigator
 * predicts with (nav_cycle.c), the acquisition's catch-up carries a search
 * forward with (acquire_cycle.c), and the time-offset monitor undoes
 * (integrity_lag.c).
 *
 * The motion of the last cycle is the increment between two consecutive
 * poses, prev (the older) and pose: in attitude the world->body increment
 * dC = C_pose C_prev^T (C_w_b), in position the step of the body origin in
 * the world frame r_wb_w(pose) - r_wb_w(prev). Predicting applies it once
 * more; stepping back undoes it once, so that
 * mfns_motion_step_back(predicted, pose, prev) is pose again (to float
 * rounding). A product that is no rotation (mfns_m3_reorthonormalize_at
 * fails: non-finite or far from orthonormal input) is never used: the
 * attitude is then left as it was.
 *
 * Pure functions of their arguments: no state, no OS calls, bounded work
 * (one 3x3 re-orthonormalisation of at most 4 iterations).
 */
#ifndef MFNS_MOTION_H
#define MFNS_MOTION_H

#include <stdbool.h>

#include "math/lens.h"

/* The prediction of the next frame's pose into *pred: the motion from prev
 * to pose applied once more; pose itself when there is no motion
 * (!have_prev) or the product is no rotation. pred must not be pose or
 * prev. */
void mfns_motion_predict_cv(const mfns_pose_t *pose, const mfns_pose_t *prev, bool have_prev, mfns_pose_t *pred);

/* The model moves on by a frame: *prev takes *pose, and *pose takes *next (a
 * fix, or the prediction coasted to). next must not be prev. */
void mfns_motion_advance(mfns_pose_t *pose, mfns_pose_t *prev, const mfns_pose_t *next);

/* now moved back by one cycle of motion: the motion from prev to last (two
 * consecutive poses, prev the older) undone on now. When the attitude
 * product is no rotation only the position step is undone. */
mfns_pose_t mfns_motion_step_back(const mfns_pose_t *now, const mfns_pose_t *last, const mfns_pose_t *prev);

#endif /* MFNS_MOTION_H */
