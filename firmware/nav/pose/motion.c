/* motion.c -- the constant-velocity motion model (motion.h). */
#include "firmware/nav/pose/motion.h"
#include "math/core_inline.h"

#include "math/linalg.h"

/* Iterations and tolerance of the re-orthonormalisation of a motion product:
 * two products of rotations are orthonormal to float rounding, so one or two
 * iterations settle it; 4 bounds the work. */
#define MOTION_ORTHO_ITERS 4
#define MOTION_ORTHO_TOL 1e-6f

void mfns_motion_predict_cv(const mfns_pose_t *pose, const mfns_pose_t *prev, bool have_prev, mfns_pose_t *pred)
{
    if (have_prev) {
        mfns_m3_t c;
        mfns_m3_transpose_at(&prev->C_w_b, &c);
        mfns_m3_mul_at(&pose->C_w_b, &c, &c); /* dC */
        mfns_m3_mul_at(&c, &pose->C_w_b, &c);
        if (mfns_m3_reorthonormalize_at(&c, MOTION_ORTHO_ITERS, MOTION_ORTHO_TOL, &c)) {
            const mfns_v3_t p1 = mfns_pose_position_w(pose), p0 = mfns_pose_position_w(prev);
            *pred = mfns_pose_from_position_at(&c, mfns_v3_add(p1, mfns_v3_sub(p1, p0)));
            return;
        }
    }
    *pred = *pose;
}

/* out of line on a size build: four calls, each two 48-byte copies inline */
MFNS_OUT_OF_LINE
void mfns_motion_advance(mfns_pose_t *pose, mfns_pose_t *prev, const mfns_pose_t *next)
{
    *prev = *pose;
    *pose = *next;
}

mfns_pose_t mfns_motion_step_back(const mfns_pose_t *now, const mfns_pose_t *last, const mfns_pose_t *prev)
{
    /* dC = C_last C_prev^T undone: C_now' = dC^T C_now */
    mfns_m3_t c;
    mfns_m3_transpose_at(&prev->C_w_b, &c);
    mfns_m3_mul_at(&last->C_w_b, &c, &c); /* dC */
    mfns_m3_transpose_at(&c, &c);
    mfns_m3_mul_at(&c, &now->C_w_b, &c);
    if (!mfns_m3_reorthonormalize_at(&c, MOTION_ORTHO_ITERS, MOTION_ORTHO_TOL, &c)) {
        c = now->C_w_b;
    }
    const mfns_v3_t step = mfns_v3_sub(mfns_pose_position_w(last), mfns_pose_position_w(prev));
    return mfns_pose_from_position_at(&c, mfns_v3_sub(mfns_pose_position_w(now), step));
}
