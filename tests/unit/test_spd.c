/* Unit tests of math/spd: Cholesky solve, inverse, singular and
 * ill-conditioned systems, float against a double reference. */
#include "tests/unit/support/testutil.h"

#include <string.h>

#include "math/spd.h"

static void test_hand_checked_3x3(void **state)
{
    (void)state;
    /* A = [[4,2,0],[2,5,1],[0,1,3]], b = A (1,2,3)^T = (8, 15, 11). */
    float a[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N] = {{4, 2, 0}, {2, 5, 1}, {0, 1, 3}};
    mfns_chol_t f;
    assert_int_equal(mfns_chol_factor(a, 3, 1e-6f, &f), MFNS_SPD_OK);
    float b[MFNS_SPD_MAX_N] = {8, 15, 11}, x[MFNS_SPD_MAX_N];
    mfns_chol_solve(&f, b, x);
    assert_near(x[0], 1, 1e-6);
    assert_near(x[1], 2, 1e-6);
    assert_near(x[2], 3, 1e-6);
    /* A^-1 by hand (adjugate / det, det = 4*14 - 2*6 = 44): */
    const double inv_e[3][3] = {{14 / 44.0, -6 / 44.0, 2 / 44.0},
                                {-6 / 44.0, 12 / 44.0, -4 / 44.0},
                                {2 / 44.0, -4 / 44.0, 16 / 44.0}};
    float inv[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N];
    mfns_chol_inverse(&f, inv);
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            assert_near(inv[i][j], inv_e[i][j], 1e-7);
        }
    }
}

/* Double reference: plain Cholesky in double. */
static void ref_solve(double a[6][6], const double b[6], double x[6])
{
    double l[6][6] = {{0}};
    for (int j = 0; j < 6; j++) {
        double d = a[j][j];
        for (int k = 0; k < j; k++) {
            d -= l[j][k] * l[j][k];
        }
        l[j][j] = sqrt(d);
        for (int i = j + 1; i < 6; i++) {
            double v = a[i][j];
            for (int k = 0; k < j; k++) {
                v -= l[i][k] * l[j][k];
            }
            l[i][j] = v / l[j][j];
        }
    }
    double y[6] = {0};
    for (int i = 0; i < 6; i++) {
        double v = b[i];
        for (int k = 0; k < i; k++) {
            v -= l[i][k] * y[k];
        }
        y[i] = v / l[i][i];
    }
    for (int i = 5; i >= 0; i--) {
        double v = y[i];
        for (int k = i + 1; k < 6; k++) {
            v -= l[k][i] * x[k];
        }
        x[i] = v / l[i][i];
    }
}

static void test_pose_like_6x6_against_double(void **state)
{
    (void)state;
    /* J^T J of a random 20x6 Jacobian whose rotation columns are ~1000x the
     * translation columns, as in the pose solve (px/rad vs px/mm). */
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 42);
    for (int trial = 0; trial < 200; trial++) {
        double j[20][6];
        for (int r = 0; r < 20; r++) {
            for (int c = 0; c < 6; c++) {
                j[r][c] = mfns_rng_normal(&rng) * (c < 3 ? 1600.0 : 1.6);
            }
        }
        double ad[6][6] = {{0}}, bd[6], xd[6];
        float af[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N], bf[MFNS_SPD_MAX_N], xf[MFNS_SPD_MAX_N];
        for (int a = 0; a < 6; a++) {
            for (int b = 0; b < 6; b++) {
                for (int r = 0; r < 20; r++) {
                    ad[a][b] += j[r][a] * j[r][b];
                }
                af[a][b] = (float)ad[a][b];
            }
            bd[a] = mfns_rng_normal(&rng) * (a < 3 ? 1600.0 : 1.6);
            bf[a] = (float)bd[a];
        }
        /* reference from the float-rounded inputs, so only the solve is compared */
        for (int a = 0; a < 6; a++) {
            for (int b = 0; b < 6; b++) {
                ad[a][b] = af[a][b];
            }
            bd[a] = bf[a];
        }
        ref_solve(ad, bd, xd);
        mfns_chol_t f;
        assert_int_equal(mfns_chol_factor(af, 6, 1e-7f, &f), MFNS_SPD_OK);
        mfns_chol_solve(&f, bf, xf);
        /* Stated tolerance: relative 1e-4 of each component's scale (the
         * equilibrated condition number here is ~10, float eps 6e-8). */
        for (int a = 0; a < 6; a++) {
            const double scale = fabs(xd[a]) + 1e-3 * (a < 3 ? 1.0 / 1600.0 : 1.0 / 1.6);
            assert_near(xf[a], xd[a], 1e-4 * scale + 1e-4 * fabs(xd[a]));
        }
    }
}

static void test_singular_is_refused(void **state)
{
    (void)state;
    /* rank 2: third row = first + second */
    float a[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N] = {{2, 1, 3}, {1, 2, 3}, {3, 3, 6}};
    mfns_chol_t f;
    memset(&f, 0x5a, sizeof f);
    assert_int_equal(mfns_chol_factor(a, 3, 0.0f, &f), MFNS_SPD_NOT_POSITIVE);
    assert_int_equal(f.n, 0); /* cleared: cannot be used by mistake */
    /* indefinite */
    float b[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N] = {{1, 2}, {2, 1}};
    assert_int_equal(mfns_chol_factor(b, 2, 0.0f, &f), MFNS_SPD_NOT_POSITIVE);
    /* zero or NaN diagonal */
    float c[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N] = {{0, 0}, {0, 1}};
    assert_int_equal(mfns_chol_factor(c, 2, 0.0f, &f), MFNS_SPD_NOT_POSITIVE);
    c[0][0] = NAN;
    assert_int_equal(mfns_chol_factor(c, 2, 0.0f, &f), MFNS_SPD_NOT_POSITIVE);
    c[0][0] = 1;
    c[1][0] = INFINITY;
    assert_int_equal(mfns_chol_factor(c, 2, 0.0f, &f), MFNS_SPD_NOT_POSITIVE);
}

static void test_ill_conditioned_is_refused(void **state)
{
    (void)state;
    /* nearly collinear: eigenvalues ~2 and ~1e-6 after equilibration */
    float a[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N] = {{1, 0.999999f}, {0.999999f, 1}};
    mfns_chol_t f;
    assert_int_equal(mfns_chol_factor(a, 2, 1e-4f, &f), MFNS_SPD_ILL_CONDITIONED);
    assert_int_equal(f.n, 0);
    /* the same matrix is accepted with a looser limit, and rcond says why */
    assert_int_equal(mfns_chol_factor(a, 2, 0.0f, &f), MFNS_SPD_OK);
    assert_true(f.rcond < 1e-5f);
    /* units do not matter: a diagonal 1e12 : 1 system is perfectly conditioned */
    float d[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N] = {{1e6f, 0}, {0, 1e-6f}};
    assert_int_equal(mfns_chol_factor(d, 2, 0.5f, &f), MFNS_SPD_OK);
    assert_near(f.rcond, 1.0, 1e-6);
}

static void test_bad_arguments(void **state)
{
    (void)state;
    float a[MFNS_SPD_MAX_N][MFNS_SPD_MAX_N] = {{1}};
    mfns_chol_t f;
    assert_int_equal(mfns_chol_factor(a, 0, 0.0f, &f), MFNS_SPD_BAD_ARG);
    assert_int_equal(mfns_chol_factor(a, 7, 0.0f, &f), MFNS_SPD_BAD_ARG);
    assert_int_equal(mfns_chol_factor(NULL, 1, 0.0f, &f), MFNS_SPD_BAD_ARG);
    assert_int_equal(mfns_chol_factor(a, 1, 0.0f, NULL), MFNS_SPD_BAD_ARG);
    assert_non_null(mfns_spd_strerror(MFNS_SPD_ILL_CONDITIONED));
    assert_string_not_equal(mfns_spd_strerror(MFNS_SPD_OK), mfns_spd_strerror(MFNS_SPD_NOT_POSITIVE));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_hand_checked_3x3),
        cmocka_unit_test(test_pose_like_6x6_against_double),
        cmocka_unit_test(test_singular_is_refused),
        cmocka_unit_test(test_ill_conditioned_is_refused),
        cmocka_unit_test(test_bad_arguments),
    };
    return cmocka_run_group_tests_name("spd", tests, NULL, NULL);
}
