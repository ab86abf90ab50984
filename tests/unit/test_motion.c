/* test_motion.c -- the constant-velocity motion model (firmware/nav/pose/motion.h)
 * against double-precision truth: a constant-velocity, constant-turn
 * sequence is predicted one frame on; stepping back undoes a prediction; no
 * motion or a non-rotation predicts no motion; advance shifts the model. */
#include <math.h>
#include <string.h>

#include "firmware/nav/pose/motion.h"
#include "tests/unit/support/pose_testlib.h"
#include "tests/unit/support/testutil.h"
#include "math/units.h"

#define DRAWS 200
#define MAX_TURN_RAD 0.05 /* per frame: ~1 rad/s at 18.6 Hz, faster than the robot turns */
#define MAX_STEP_MM 50.0  /* per frame */
#define POS_RANGE_MM 2000.0
/* float rounding of positions up to 3.5 m (an ulp is 2.4e-4 mm there) through
 * the body-frame position and a dozen operations */
#define POS_TOL_MM 5e-3
#define ROT_TOL_RAD 2e-6

/* Truth: C_k = dC^k C_0 (dC the world->body increment, applied on the left as
 * the model does), r_wb_w(k) = r_0 + k v. */
typedef struct {
    pt_dpose_t p[3];
} seq_t;

static void mat_mul(const double a[3][3], const double b[3][3], double out[3][3])
{
    double t[3][3];
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            t[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    memcpy(out, t, sizeof t);
}

static seq_t draw(mfns_rng_t *rng)
{
    const double eye[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    double c[3][3], dc[3][3];
    pt_random_rotation(rng, MFNS_PI_D, eye, c);
    pt_random_rotation(rng, MAX_TURN_RAD, eye, dc);
    double r[3], v[3];
    for (int m = 0; m < 3; m++) {
        r[m] = mfns_rng_range(rng, -POS_RANGE_MM, POS_RANGE_MM);
        v[m] = mfns_rng_range(rng, -MAX_STEP_MM, MAX_STEP_MM) / sqrt(3.0);
    }
    seq_t s;
    for (int k = 0; k < 3; k++) {
        s.p[k] = pt_pose(c, r);
        mat_mul(dc, c, c);
        for (int m = 0; m < 3; m++) {
            r[m] += v[m];
        }
    }
    return s;
}

static void assert_pose_near(const mfns_pose_t *got, const pt_dpose_t *want)
{
    const pt_dpose_t g = pt_from_float(got);
    assert_true(pt_pos_err(&g, want) < POS_TOL_MM);
    assert_true(pt_rot_err(g.C, want->C) < ROT_TOL_RAD);
}

static void test_predicts_constant_velocity(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 27);
    for (int i = 0; i < DRAWS; i++) {
        const seq_t s = draw(&rng);
        const mfns_pose_t prev = pt_to_float(&s.p[0]), pose = pt_to_float(&s.p[1]);
        mfns_pose_t pred;
        mfns_motion_predict_cv(&pose, &prev, true, &pred);
        assert_pose_near(&pred, &s.p[2]);
    }
}

static void test_step_back_undoes_a_prediction(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 28);
    for (int i = 0; i < DRAWS; i++) {
        const seq_t s = draw(&rng);
        const mfns_pose_t prev = pt_to_float(&s.p[0]), pose = pt_to_float(&s.p[1]), now = pt_to_float(&s.p[2]);
        /* the truth one frame on, stepped back: the frame before */
        const mfns_pose_t back = mfns_motion_step_back(&now, &pose, &prev);
        assert_pose_near(&back, &s.p[1]);
        /* a prediction, stepped back: the pose it was predicted from */
        mfns_pose_t pred;
        mfns_motion_predict_cv(&pose, &prev, true, &pred);
        const mfns_pose_t again = mfns_motion_step_back(&pred, &pose, &prev);
        assert_pose_near(&again, &s.p[1]);
    }
}

static void test_no_motion_predicts_the_pose(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 29);
    const seq_t s = draw(&rng);
    const mfns_pose_t prev = pt_to_float(&s.p[0]), pose = pt_to_float(&s.p[1]);
    mfns_pose_t pred;
    mfns_motion_predict_cv(&pose, &prev, false, &pred);
    assert_memory_equal(&pred, &pose, sizeof pose);
    /* the same pose twice: no motion to apply */
    mfns_motion_predict_cv(&pose, &pose, true, &pred);
    assert_pose_near(&pred, &s.p[1]);
}

static void test_a_non_rotation_is_never_applied(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 30);
    const seq_t s = draw(&rng);
    const mfns_pose_t pose = pt_to_float(&s.p[1]), now = pt_to_float(&s.p[2]);
    mfns_pose_t bad = pt_to_float(&s.p[0]);
    bad.C_w_b.m[1][1] = NAN;
    mfns_pose_t pred;
    mfns_motion_predict_cv(&pose, &bad, true, &pred);
    assert_memory_equal(&pred, &pose, sizeof pose);
    /* stepping back keeps the attitude and undoes the position step only */
    mfns_pose_t zero = pt_to_float(&s.p[0]);
    memset(&zero.C_w_b, 0, sizeof zero.C_w_b);
    const mfns_pose_t back = mfns_motion_step_back(&now, &pose, &zero);
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            assert_true(isfinite(back.C_w_b.m[i][j]));
        }
    }
    const pt_dpose_t b = pt_from_float(&back);
    assert_true(pt_rot_err(b.C, s.p[2].C) < ROT_TOL_RAD);
}

static void test_advance_shifts_the_model(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 31);
    const seq_t s = draw(&rng);
    mfns_pose_t prev = pt_to_float(&s.p[0]), pose = pt_to_float(&s.p[1]);
    const mfns_pose_t next = pt_to_float(&s.p[2]), old_pose = pose;
    mfns_motion_advance(&pose, &prev, &next);
    assert_memory_equal(&prev, &old_pose, sizeof prev);
    assert_memory_equal(&pose, &next, sizeof pose);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_predicts_constant_velocity),
        cmocka_unit_test(test_step_back_undoes_a_prediction),
        cmocka_unit_test(test_no_motion_predicts_the_pose),
        cmocka_unit_test(test_a_non_rotation_is_never_applied),
        cmocka_unit_test(test_advance_shifts_the_model),
    };
    return cmocka_run_group_tests_name("motion", tests, NULL, NULL);
}
