/* rotation.h -- rotations in the project's conventions (docs/conventions.md,
 * docs/system.md §2): frame rotations R1/R2/R3, the paper's 2-1-3 Euler sequence,
 * the small-angle matrix, and the rotation-vector exp/log used for pose
 * updates on the manifold. Angles in radians.
 */
#ifndef MFNS_ROTATION_H
#define MFNS_ROTATION_H

#include "math/linalg.h"

/* Frame (passive) rotations of the paper:
 * R1(a) = [[1,0,0],[0,c,s],[0,-s,c]], R2(a) = [[c,0,-s],[0,1,0],[s,0,c]],
 * R3(a) = [[c,s,0],[-s,c,0],[0,0,1]]. The active rotation about x by a is R1(-a). */
mfns_m3_t mfns_rot_r1(float a);
mfns_m3_t mfns_rot_r2(float a);
mfns_m3_t mfns_rot_r3(float a);

/* 2-1-3 Euler angles: roll phi (about x), pitch theta (y), yaw psi (z). */
typedef struct {
    float roll, pitch, yaw;
} mfns_euler_t;

/* C = R3(yaw) R1(roll) R2(pitch) (Eq. 9). */
mfns_m3_t mfns_euler213_to_m3(mfns_euler_t e);

/* Inverse of mfns_euler213_to_m3, with roll in [-pi/2, pi/2] and pitch, yaw in
 * (-pi, pi].
 * Singular case: the sequence's middle angle is roll, so the gimbal lock is at
 * roll = +-90 deg, where pitch and yaw turn about the same axis and only their
 * sum (roll = -90) or difference (roll = +90) is defined. When
 * cos(roll) < MFNS_EULER_SINGULAR_COS the function sets pitch = 0, puts the
 * whole rotation into yaw (the returned angles still reproduce C) and returns
 * false. Near that case (cos(roll) a few times the threshold) float inputs
 * determine pitch and yaw to about 1e-7 / cos(roll) rad each. */
#define MFNS_EULER_SINGULAR_COS 1e-5f
bool mfns_m3_to_euler213(mfns_m3_t c, mfns_euler_t *e);
/* The same by address (no 36-byte copy per call; linalg.h's *_at). */
bool mfns_m3_to_euler213_at(const mfns_m3_t *c, mfns_euler_t *e);

/* Small-angle frame rotation (Eq. A2): C ~ I - skew(a), i.e.
 * [[1, g, -b], [-g, 1, a], [b, -a, 1]] for a = (alpha, beta, gamma).
 * First-order in the angles; not orthonormal. */
mfns_m3_t mfns_rot_small_angle(mfns_v3_t a);

/* Rotation-vector exponential (Rodrigues): the active rotation by |w| rad about
 * w/|w|; exp(w) v = v + w x v + O(|w|^2). Exact near zero (series used below
 * 1e-4 rad). */
mfns_m3_t mfns_rot_exp(mfns_v3_t w);

/* Rotation-vector logarithm: the w with |w| in [0, pi] and exp(w) = R.
 * Handles |w| near 0 (series) and large angles up to pi (axis from the
 * symmetric part, so the accuracy stays ~1e-6 rad up to pi). R should be a
 * rotation (mfns_m3_is_rotation); other inputs give the log of a nearby one. */
mfns_v3_t mfns_rot_log(mfns_m3_t r);

/* Unit quaternion q = (w, x, y, z), Hamilton convention, of the rotation R:
 * R v = q v q*, i.e. the quaternion that rotates vectors as R does (for
 * R = C_b_w: the body's orientation in the world, ROS geometry_msgs order
 * after moving w last). Shepperd's method: the largest of the four squared
 * components is taken from the diagonal, so no branch divides by a small
 * number. w >= 0 (the sign of a quaternion is free; this fixes it). */
void mfns_m3_to_quat(mfns_m3_t r, float q_wxyz[4]);

/* Angle of the rotation R_a^T R_b in rad, in [0, pi]: the attitude error. */
float mfns_rot_angle_between(mfns_m3_t ra, mfns_m3_t rb);
float mfns_rot_angle_between_at(const mfns_m3_t *ra, const mfns_m3_t *rb);

#endif /* MFNS_ROTATION_H */
