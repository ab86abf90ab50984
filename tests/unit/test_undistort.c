/* Unit tests of math/undistort: (a) the iterative inverse and (b) the
 * fixed-point correction grid, for the three cameras of docs/system.md §7, Table 2
 * over the whole 1280x1024 image, plus their error paths. The reference is
 * the forward model in double (re-distortion), independent of both forms. */
#include "tests/unit/support/testutil.h"

#include <stdlib.h>
#include <string.h>

#include "math/lens.h"
#include "firmware/host/undist_grid_build.h"

/* Table 2 of the paper: X, Y, Z. */
static const mfns_intrinsics_t k_paper[3] = {
    {1599.26136f, 1599.93302f, 632.61591f, 522.17870f, 0.0f, {-0.13013f, 0.28701f, -0.00040f, -0.00004f, 0.0f}, 1280, 1024},
    {1605.35286f, 1603.54359f, 619.71227f, 505.99361f, 0.0f, {-0.11276f, 0.01776f, -0.00031f, 0.00057f, 0.0f}, 1280, 1024},
    {1611.21596f, 1610.79607f, 649.51210f, 531.29472f, 0.0f, {-0.10481f, 0.15881f, -0.00137f, 0.00184f, 0.0f}, 1280, 1024},
};

/* Default grid of the table (docs/distortion-grid.md): 93 x 75 nodes. */
#define GNX 93
#define GNY 75
static q16_16_t g_nodes[3][GNX * GNY][2];

/* Forward model in double: undistorted normalized -> pixel. */
static void project_d(const mfns_intrinsics_t *k, double x, double y, double *u, double *v)
{
    const double k1 = (double)k->dist[0], k2 = (double)k->dist[1], p1 = (double)k->dist[2];
    const double p2 = (double)k->dist[3], k3 = (double)k->dist[4];
    const double r2 = x * x + y * y;
    const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    const double xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
    const double yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
    *u = (double)k->fx * xd + (double)k->skew * yd + (double)k->cx;
    *v = (double)k->fy * yd + (double)k->cy;
}

/* (a) over the whole image, every 4 px plus the image's last row/column:
 * re-distorting the result must give the input pixel to 1e-4 px. */
static void test_iterative_accuracy_whole_image(void **state)
{
    (void)state;
    for (int c = 0; c < 3; c++) {
        const mfns_intrinsics_t *k = &k_paper[c];
        double worst = 0.0;
        int max_it = 0, n = 0;
        for (int iv = 0; iv <= 256; iv++) {
            const float v = fminf(-0.5f + 4.0f * (float)iv, 1023.49f);
            for (int iu = 0; iu <= 320; iu++) {
                const float u = fminf(-0.5f + 4.0f * (float)iu, 1279.49f);
                float x = NAN, y = NAN;
                int it = -1;
                assert_int_equal(mfns_undistort_iter(k, u, v, MFNS_UNDIST_DEFAULT_ITER, &x, &y, &it), MFNS_UNDIST_OK);
                double ub, vb;
                project_d(k, (double)x, (double)y, &ub, &vb);
                const double e = hypot(ub - (double)u, vb - (double)v);
                worst = e > worst ? e : worst;
                max_it = it > max_it ? it : max_it;
                n++;
            }
        }
        print_message("camera %d: (a) worst re-distortion error %.2e px over %d points, max %d updates\n", c, worst,
                      n, max_it);
        assert_true(n > 80000);
        assert_true(worst <= 1e-4);
        assert_true(max_it <= MFNS_UNDIST_DEFAULT_ITER);
    }
}

static void test_iterative_error_paths(void **state)
{
    (void)state;
    const mfns_intrinsics_t *k = &k_paper[0];
    float x = 123.0f, y = 456.0f;
    int it = -1;
    /* one update is not enough in the corner: reported, outputs untouched */
    assert_int_equal(mfns_undistort_iter(k, -0.5f, -0.5f, 1, &x, &y, &it), MFNS_UNDIST_NOT_CONVERGED);
    assert_true(x == 123.0f && y == 456.0f);
    /* the cap is part of the API */
    assert_int_equal(mfns_undistort_iter(k, 10, 10, 0, &x, &y, NULL), MFNS_UNDIST_BAD_INPUT);
    assert_int_equal(mfns_undistort_iter(k, 10, 10, MFNS_UNDIST_MAX_ITER + 1, &x, &y, NULL), MFNS_UNDIST_BAD_INPUT);
    assert_int_equal(mfns_undistort_iter(k, NAN, 10, 5, &x, &y, NULL), MFNS_UNDIST_BAD_INPUT);
    assert_int_equal(mfns_undistort_iter(k, 10, INFINITY, 5, &x, &y, NULL), MFNS_UNDIST_BAD_INPUT);
    assert_int_equal(mfns_undistort_iter(NULL, 10, 10, 5, &x, &y, NULL), MFNS_UNDIST_BAD_INPUT);
    assert_int_equal(mfns_undistort_iter(k, 10, 10, 5, NULL, &y, NULL), MFNS_UNDIST_BAD_INPUT);
    /* a lens that folds over (strong barrel): the corner has no inverse */
    mfns_intrinsics_t bad = *k;
    bad.dist[0] = -1.5f;
    bad.dist[1] = 0.0f;
    const mfns_undist_status_t s = mfns_undistort_iter(&bad, -0.5f, -0.5f, MFNS_UNDIST_MAX_ITER, &x, &y, NULL);
    assert_true(s == MFNS_UNDIST_NOT_CONVERGED || s == MFNS_UNDIST_SINGULAR);
    assert_true(x == 123.0f && y == 456.0f);
    /* the principal point is its own inverse in zero updates */
    assert_int_equal(mfns_undistort_iter(k, k->cx, k->cy, 1, &x, &y, &it), MFNS_UNDIST_OK);
    assert_int_equal(it, 0);
    assert_near(x, 0.0, 1e-9);
    assert_near(y, 0.0, 1e-9);
    /* every status has a one-line message */
    for (int i = 0; i <= MFNS_UNDIST_BAD_GRID + 1; i++) {
        const char *m = mfns_undist_strerror((mfns_undist_status_t)i);
        assert_non_null(m);
        assert_null(strchr(m, '\n'));
    }
}

static int g_setup(void **state)
{
    (void)state;
    for (int c = 0; c < 3; c++) {
        mfns_undist_grid_t g;
        if (mfns_undist_grid_build(&k_paper[c], GNX, GNY, g_nodes[c], GNX * GNY, &g) != MFNS_UNDIST_OK) {
            return -1;
        }
    }
    return 0;
}

static mfns_undist_grid_t grid_of(int c)
{
    mfns_undist_grid_t g;
    /* rebuilding is deterministic; it also fills the header */
    assert_int_equal(mfns_undist_grid_build(&k_paper[c], GNX, GNY, g_nodes[c], GNX * GNY, &g), MFNS_UNDIST_OK);
    return g;
}

/* (b) over the whole image, on a 2.3 px lattice (incommensurate with the
 * ~13.9 px node spacing, so every phase inside a cell is visited): the grid
 * must agree with the exact inverse of the same q8 pixel to 0.01 px. */
static void test_grid_accuracy_whole_image(void **state)
{
    (void)state;
    for (int c = 0; c < 3; c++) {
        const mfns_intrinsics_t *k = &k_paper[c];
        const mfns_undist_grid_t g = grid_of(c);
        assert_int_equal(g.nx, GNX);
        assert_int_equal(g.step_u_q8, (1280 * 256 + GNX - 2) / (GNX - 1));
        double worst = 0.0, worst_norm = 0.0;
        int n = 0;
        for (int32_t vq = -128; vq < 1023 * 256 + 128; vq += 589) {
            for (int32_t uq = -128; uq < 1279 * 256 + 128; uq += 589) {
                q16_16_t uu, vu;
                assert_int_equal(mfns_undistort_grid_px(&g, uq, vq, &uu, &vu), MFNS_UNDIST_OK);
                float x, y;
                assert_int_equal(mfns_undistort_iter(k, (float)uq / 256.0f, (float)vq / 256.0f,
                                                     MFNS_UNDIST_DEFAULT_ITER, &x, &y, NULL),
                                 MFNS_UNDIST_OK);
                const double ue = (double)k->fx * (double)x + (double)k->cx;
                const double ve = (double)k->fy * (double)y + (double)k->cy;
                const double e = hypot((double)uu / 65536.0 - ue, (double)vu / 65536.0 - ve);
                worst = e > worst ? e : worst;
                float xn, yn;
                assert_int_equal(mfns_undistort_grid(&g, k, uq, vq, &xn, &yn), MFNS_UNDIST_OK);
                const double en = hypot((double)k->fx * ((double)xn - (double)x), (double)k->fy * ((double)yn - (double)y));
                worst_norm = en > worst_norm ? en : worst_norm;
                n++;
            }
        }
        print_message("camera %d: (b) 93x75 grid worst error %.4f px (normalized output %.4f px) over %d points\n", c,
                      worst, worst_norm, n);
        assert_true(n > 240000);
        assert_true(worst <= 0.01);
        assert_true(worst_norm <= 0.01);
        /* the interpolation is not trivially exact: a coarse grid must fail the bound */
        assert_true(worst > 1e-4);
    }
}

/* Nodes reproduce their own values exactly; a distortion-free lens gives the
 * identity; the far edge is inside, one q8 step beyond is outside. */
static void test_grid_nodes_edges_and_outside(void **state)
{
    (void)state;
    const mfns_undist_grid_t g = grid_of(1);
    q16_16_t uu, vu;
    for (uint32_t j = 0; j < GNY; j += 7) {
        for (uint32_t i = 0; i < GNX; i += 5) {
            const px_q8_t uq = g.origin_u_q8 + (px_q8_t)i * g.step_u_q8;
            const px_q8_t vq = g.origin_v_q8 + (px_q8_t)j * g.step_v_q8;
            assert_int_equal(mfns_undistort_grid_px(&g, uq, vq, &uu, &vu), MFNS_UNDIST_OK);
            assert_int_equal(uu, g.node[j * GNX + i][0]);
            assert_int_equal(vu, g.node[j * GNX + i][1]);
        }
    }
    const px_q8_t end_u = g.origin_u_q8 + (GNX - 1) * g.step_u_q8;
    const px_q8_t end_v = g.origin_v_q8 + (GNY - 1) * g.step_v_q8;
    assert_int_equal(mfns_undistort_grid_px(&g, end_u, end_v, &uu, &vu), MFNS_UNDIST_OK);
    assert_int_equal(uu, g.node[GNX * GNY - 1][0]);
    uu = 77;
    assert_int_equal(mfns_undistort_grid_px(&g, end_u + 1, 0, &uu, &vu), MFNS_UNDIST_OUTSIDE);
    assert_int_equal(mfns_undistort_grid_px(&g, 0, end_v + 1, &uu, &vu), MFNS_UNDIST_OUTSIDE);
    assert_int_equal(mfns_undistort_grid_px(&g, -129, 0, &uu, &vu), MFNS_UNDIST_OUTSIDE);
    assert_int_equal(mfns_undistort_grid_px(&g, 0, -129, &uu, &vu), MFNS_UNDIST_OUTSIDE);
    assert_int_equal(mfns_undistort_grid_px(&g, INT32_MIN, INT32_MAX, &uu, &vu), MFNS_UNDIST_OUTSIDE);
    assert_int_equal(mfns_undistort_grid_px(&g, INT32_MAX, 0, &uu, &vu), MFNS_UNDIST_OUTSIDE);
    assert_int_equal(uu, 77); /* untouched */
    /* the grid covers the image: the first and last pixel edges are inside */
    assert_true(end_u >= 1280 * 256 - 128 && end_v >= 1024 * 256 - 128);

    /* zero distortion: the grid is the identity to the Q16.16 rounding */
    static q16_16_t id_nodes[9 * 9][2];
    mfns_intrinsics_t k0 = k_paper[2];
    memset(k0.dist, 0, sizeof k0.dist);
    mfns_undist_grid_t g0;
    assert_int_equal(mfns_undist_grid_build(&k0, 9, 9, id_nodes, 81, &g0), MFNS_UNDIST_OK);
    for (int32_t q = -128; q < 1023 * 256; q += 1777) {
        assert_int_equal(mfns_undistort_grid_px(&g0, q, q, &uu, &vu), MFNS_UNDIST_OK);
        /* weights are Q16.16: the rounding of a weight moves the result by up
         * to step/2^17 px, i.e. step_px/2 LSB (80 LSB = 0.0012 px for this
         * coarse 160 px grid) */
        const int tol = g0.step_u_q8 / 512 + 2;
        assert_true(abs(uu - q * 256) <= tol && abs(vu - q * 256) <= tol);
    }
}

static void test_grid_bad_headers(void **state)
{
    (void)state;
    mfns_undist_grid_t g = grid_of(0);
    q16_16_t uu, vu;
    mfns_undist_grid_t b = g;
    b.nx = 1;
    assert_int_equal(mfns_undistort_grid_px(&b, 0, 0, &uu, &vu), MFNS_UNDIST_BAD_GRID);
    b = g;
    b.step_v_q8 = 0;
    assert_int_equal(mfns_undistort_grid_px(&b, 0, 0, &uu, &vu), MFNS_UNDIST_BAD_GRID);
    b = g;
    b.step_u_q8 = MFNS_UNDIST_GRID_MAX_STEP_Q8 + 1;
    assert_int_equal(mfns_undistort_grid_px(&b, 0, 0, &uu, &vu), MFNS_UNDIST_BAD_GRID);
    b = g;
    b.node = NULL;
    assert_int_equal(mfns_undistort_grid_px(&b, 0, 0, &uu, &vu), MFNS_UNDIST_BAD_GRID);
    assert_int_equal(mfns_undistort_grid_px(NULL, 0, 0, &uu, &vu), MFNS_UNDIST_BAD_GRID);
    assert_int_equal(mfns_undistort_grid_px(&g, 0, 0, NULL, &vu), MFNS_UNDIST_BAD_INPUT);
    float x, y;
    assert_int_equal(mfns_undistort_grid(&g, NULL, 0, 0, &x, &y), MFNS_UNDIST_BAD_INPUT);
    /* builder: too many nodes for the storage, too few per axis */
    assert_int_equal(mfns_undist_grid_build(&k_paper[0], GNX, GNY, g_nodes[0], GNX * GNY - 1, &b),
                     MFNS_UNDIST_BAD_INPUT);
    assert_int_equal(mfns_undist_grid_build(&k_paper[0], 1, GNY, g_nodes[0], GNX * GNY, &b), MFNS_UNDIST_BAD_INPUT);
    /* 1280 px over 3 nodes is a 640 px step: beyond the 32-bit weight range */
    assert_int_equal(mfns_undist_grid_build(&k_paper[0], 3, 3, g_nodes[0], GNX * GNY, &b), MFNS_UNDIST_BAD_INPUT);
}

/* The builder's spacing, which the table tools size their grids with: the
 * ceiling of 256 W / (n - 1), in [1, 256) px, and what a built grid holds. */
static void test_grid_step(void **state)
{
    (void)state;
    px_q8_t s = -1;
    assert_true(mfns_undist_grid_step(1280, 76, &s));
    assert_int_equal(s, 4370); /* 327680 / 75 = 4369.07: rounded up, so 76 nodes reach the far edge */
    /* 1024 px over 4 cells is 256 px: one LSB beyond the 32-bit weight range; 5 cells fit */
    assert_false(mfns_undist_grid_step(1024, 5, &s));
    assert_int_equal(s, 4370); /* untouched on refusal */
    assert_true(mfns_undist_grid_step(1024, 6, &s));
    assert_int_equal(s, 52429);
    /* the 1 px floor: 1000 px over 1003 cells is still 256 after the ceiling, 1004 cells not */
    assert_true(mfns_undist_grid_step(1000, 1004, &s));
    assert_int_equal(s, MFNS_UNDIST_GRID_MIN_STEP_Q8);
    assert_false(mfns_undist_grid_step(1000, 1005, &s));
    assert_true(mfns_undist_grid_step(1, 2, &s));
    assert_int_equal(s, MFNS_PX_Q8_ONE);
    assert_false(mfns_undist_grid_step(1280, 1, &s));
    assert_false(mfns_undist_grid_step(1280, 0, &s));
    assert_false(mfns_undist_grid_step(1280, 76, NULL));
    /* a built grid holds this spacing and starts at the image corner */
    const mfns_undist_grid_t g = grid_of(0);
    assert_true(mfns_undist_grid_step(k_paper[0].width, GNX, &s));
    assert_int_equal(g.step_u_q8, s);
    assert_true(mfns_undist_grid_step(k_paper[0].height, GNY, &s));
    assert_int_equal(g.step_v_q8, s);
    assert_int_equal(g.origin_u_q8, MFNS_UNDIST_GRID_ORIGIN_Q8);
    assert_int_equal(g.origin_v_q8, MFNS_UNDIST_GRID_ORIGIN_Q8);
    assert_int_equal(MFNS_UNDIST_GRID_ORIGIN_Q8, -128);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_iterative_accuracy_whole_image),
        cmocka_unit_test(test_iterative_error_paths),
        cmocka_unit_test(test_grid_accuracy_whole_image),
        cmocka_unit_test(test_grid_nodes_edges_and_outside),
        cmocka_unit_test(test_grid_bad_headers),
        cmocka_unit_test(test_grid_step),
    };
    return cmocka_run_group_tests_name("undistort", tests, g_setup, NULL);
}
