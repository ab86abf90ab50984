/* Unit tests of firmware/nav/caltable (and firmware/app/caltable_file): the
 * Python-built default table (build/gen/default.mfnstbl) loads with exactly
 * the values Python wrote (build/gen/caltable_values.txt); the C projection of
 * the loaded cameras matches OpenCV's projectPoints; the table's grids and the
 * iterative inverse match Python's exact inverse; and every validation
 * failure is provoked with a table crafted from the good one (patched bytes,
 * CRC fixed up when the check under test comes after the CRC). */
#define _DEFAULT_SOURCE /* mkdtemp, mkfifo under -std=c11 */
#include "tests/unit/support/testutil.h"

#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "firmware/nav/table/caltable.h"
#include "firmware/nav/filter/nav_filter.h"
#include "firmware/app/caltable_file.h"
#include "math/undistort.h"

static uint8_t g_good[MFNS_CALTABLE_MAX_BYTES]; /* the default table as built */
static size_t g_good_len;
static uint8_t g_bad[MFNS_CALTABLE_MAX_BYTES + 64]; /* crafted copies */
static mfns_caltable_t g_table;                  /* loaded good table */
static mfns_caltable_t g_out;                    /* target of failing loads */
static mfns_caltable_t g_sentinel;               /* what g_out must still hold after a failure */

static void gen_path(char *dst, size_t n, const char *name)
{
    const int w = snprintf(dst, n, "%s/%s", mfns_test_gen_dir(), name);
    assert_true(w > 0 && (size_t)w < n);
}

static int setup(void **state)
{
    (void)state;
    g_good_len = mfns_test_read_gen("default.mfnstbl", g_good, sizeof g_good);
    if (g_good_len == 0) {
        return -1;
    }
    uint32_t off = 0;
    const mfns_caltable_status_t st = mfns_caltable_load(g_good, g_good_len, &g_table, &off);
    if (st != MFNS_CALTABLE_OK) {
        fprintf(stderr, "default table refused: %s (offset %u)\n", mfns_caltable_strerror(st), off);
        return -1;
    }
    return 0;
}

/* ---- value comparison against Python ----------------------------------- */

typedef struct {
    char *p;
    size_t left;
    int lines;
} textbuf_t;

/* Terminate the line snprintf just wrote at t->p (w characters). */
static void commit(textbuf_t *t, int w)
{
    assert_true(w > 0 && (size_t)w + 1 < t->left);
    t->p[w] = '\n';
    t->p += w + 1;
    t->left -= (size_t)w + 1;
    t->lines++;
}
#define add(t, ...) commit((t), snprintf((t)->p, (t)->left, __VA_ARGS__))

/* Numbers of one text line (after an optional word prefix); returns how many. */
static int read_numbers(FILE *f, const char *prefix, double *out, int max)
{
    char line[1024];
    if (fgets(line, sizeof line, f) == NULL) {
        return 0;
    }
    char *p = line;
    if (prefix != NULL) {
        const size_t n = strlen(prefix);
        if (strncmp(line, prefix, n) != 0) {
            return -1;
        }
        p += n;
    }
    int k = 0;
    while (k < max) {
        char *end;
        const double v = strtod(p, &end);
        if (end == p) {
            break;
        }
        out[k++] = v;
        p = end;
    }
    return k;
}

#define G9(x) ((double)(x))

static void render_table(const mfns_caltable_t *t, textbuf_t *o)
{
    add(o, "version %u", (unsigned)t->format_version);
    add(o, "size_bytes %u", (unsigned)t->size_bytes);
    add(o, "crc32 %u", (unsigned)t->crc32);
    add(o, "pixel_sigma_px %.9g", G9(t->pixel_sigma_px));
    const mfns_centroid_settings_t *c = &t->centroid;
    add(o, "centroid.threshold_dn %u", (unsigned)c->threshold_dn);
    add(o, "centroid.min_area_px %u", (unsigned)c->min_area_px);
    add(o, "centroid.max_area_px %u", (unsigned)c->max_area_px);
    add(o, "centroid.roi_half_size_px %u", (unsigned)c->roi_half_size_px);
    add(o, "centroid.saturation_dn %u", (unsigned)c->saturation_dn);
    add(o, "centroid.gain_dn_per_e_q12 %u", (unsigned)c->gain_dn_per_e_q12);
    add(o, "centroid.threshold_k_sigma %.9g", G9(c->threshold_k_sigma));
    add(o, "centroid.max_elongation %.9g", G9(c->max_elongation));
    const mfns_solver_settings_t *s = &t->solver;
    add(o, "solver.max_iterations %u", (unsigned)s->max_iterations);
    add(o, "solver.step_tol %.9g", G9(s->step_tol));
    add(o, "solver.grad_tol %.9g", G9(s->grad_tol));
    add(o, "solver.huber_k %.9g", G9(s->huber_k));
    add(o, "solver.outlier_gate_sigma %.9g", G9(s->outlier_gate_sigma));
    add(o, "solver.max_residual_rms_sigma %.9g", G9(s->max_residual_rms_sigma));
    add(o, "solver.track_gate_px %.9g", G9(s->track_gate_px));
    add(o, "solver.min_rcond %.9g", G9(s->min_rcond));
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        const mfns_camera_t *cam = &t->rig.cam[k];
        const mfns_undist_grid_t *g = &t->grid[k];
        add(o, "cam%d.width %u", k, (unsigned)cam->k.width);
        add(o, "cam%d.height %u", k, (unsigned)cam->k.height);
        add(o, "cam%d.fx %.9g", k, G9(cam->k.fx));
        add(o, "cam%d.fy %.9g", k, G9(cam->k.fy));
        add(o, "cam%d.cx %.9g", k, G9(cam->k.cx));
        add(o, "cam%d.cy %.9g", k, G9(cam->k.cy));
        add(o, "cam%d.skew %.9g", k, G9(cam->k.skew));
        for (int i = 0; i < 5; i++) {
            add(o, "cam%d.dist%d %.9g", k, i, G9(cam->k.dist[i]));
        }
        for (int r = 0; r < 3; r++) {
            for (int q = 0; q < 3; q++) {
                add(o, "cam%d.C%d%d %.9g", k, r, q, G9(cam->C_k_b.m[r][q]));
            }
        }
        add(o, "cam%d.r0 %.9g", k, G9(cam->r_bk_b.x));
        add(o, "cam%d.r1 %.9g", k, G9(cam->r_bk_b.y));
        add(o, "cam%d.r2 %.9g", k, G9(cam->r_bk_b.z));
        add(o, "cam%d.grid.nx %u", k, (unsigned)g->nx);
        add(o, "cam%d.grid.ny %u", k, (unsigned)g->ny);
        add(o, "cam%d.grid.origin_u_q8 %d", k, (int)g->origin_u_q8);
        add(o, "cam%d.grid.origin_v_q8 %d", k, (int)g->origin_v_q8);
        add(o, "cam%d.grid.step_u_q8 %d", k, (int)g->step_u_q8);
        add(o, "cam%d.grid.step_v_q8 %d", k, (int)g->step_v_q8);
        const int n = g->nx * g->ny;
        long long su = 0, sv = 0;
        for (int i = 0; i < n; i++) {
            su += g->node[i][0];
            sv += g->node[i][1];
        }
        add(o, "cam%d.grid.sum_u %lld", k, su);
        add(o, "cam%d.grid.sum_v %lld", k, sv);
        for (int i = 0; i < n; i += 509) {
            add(o, "cam%d.grid.node%d %d %d", k, i, (int)g->node[i][0], (int)g->node[i][1]);
        }
    }
    add(o, "beacons.count %u", (unsigned)t->beacons.count);
    for (int i = 0; i < t->beacons.count; i++) {
        const mfns_beacon_t *b = &t->beacons.beacon[i];
        add(o, "beacon%d %u %.9g %.9g %.9g %.9g", i, (unsigned)b->id, G9(b->p_w.x), G9(b->p_w.y), G9(b->p_w.z),
            G9(b->sigma_mm));
    }
    const mfns_beacon_index_t *ix = &t->index;
    add(o, "index.k_nbr %u", (unsigned)ix->k_nbr);
    add(o, "index.max_missing %u max_unexplained %u", (unsigned)ix->max_missing, (unsigned)ix->max_unexplained);
    add(o, "index.budget_units %u", (unsigned)ix->budget_units);
    char cert[32] = "";
    for (uint32_t m = 0; m <= ix->max_missing; m++) {
        const size_t u = strlen(cert);
        const int w = snprintf(cert + u, sizeof cert - u, m == 0 ? "%u" : " %u", (unsigned)ix->cert_inliers[m]);
        assert_true(w > 0 && (size_t)w < sizeof cert - u);
    }
    add(o, "index.cert %s", cert);
    add(o, "index.workspace %.9g %.9g %.9g %.9g %.9g %.9g", G9(ix->ws_min_w.x), G9(ix->ws_min_w.y),
        G9(ix->ws_min_w.z), G9(ix->ws_max_w.x), G9(ix->ws_max_w.y), G9(ix->ws_max_w.z));
}

static void test_python_table_loads_with_identical_values(void **state)
{
    (void)state;
    static char mine[64 * 1024], theirs[64 * 1024];
    textbuf_t o = {mine, sizeof mine, 0};
    render_table(&g_table, &o);
    *o.p = '\0';
    char path[512];
    gen_path(path, sizeof path, "caltable_values.txt");
    FILE *f = fopen(path, "r");
    assert_non_null(f);
    const size_t n = fread(theirs, 1, sizeof theirs - 1, f);
    assert_int_equal(fclose(f), 0);
    theirs[n] = '\0';
    /* line by line, so a failure names the value */
    const char *a = mine, *b = theirs;
    int line = 0;
    while (*a != '\0' || *b != '\0') {
        const char *ea = strchr(a, '\n'), *eb = strchr(b, '\n');
        assert_non_null(ea);
        assert_non_null(eb);
        line++;
        if ((ea - a) != (eb - b) || memcmp(a, b, (size_t)(ea - a)) != 0) {
            fail_msg("line %d: C has \"%.*s\", Python wrote \"%.*s\"", line, (int)(ea - a), a, (int)(eb - b), b);
        }
        a = ea + 1;
        b = eb + 1;
    }
    assert_int_equal(line, o.lines);
    assert_true(line > 150);
    assert_int_equal(g_table.beacons.count, 10);
    assert_int_equal(g_table.size_bytes, g_good_len);
}

/* ---- projection vs OpenCV ------------------------------------------------ */

static void test_projection_matches_opencv(void **state)
{
    (void)state;
    char path[512];
    gen_path(path, sizeof path, "caltable_projections.txt");
    FILE *f = fopen(path, "r");
    assert_non_null(f);
    double p[12];
    assert_int_equal(read_numbers(f, "pose", p, 12), 12);
    mfns_pose_t pose;
    for (int i = 0; i < 9; i++) {
        pose.C_w_b.m[i / 3][i % 3] = (float)p[i];
    }
    pose.r_bw_b = mfns_v3((float)p[9], (float)p[10], (float)p[11]);
    int n = 0, per_cam[3] = {0, 0, 0};
    double worst = 0.0, row[6];
    while (read_numbers(f, NULL, row, 6) == 6) {
        const int cam = (int)row[0];
        const double u = row[4], v = row[5];
        if (cam < 0 || cam > 2) {
            fail_msg("bad camera index %d in the vectors", cam);
            return;
        }
        float uv[2];
        const mfns_v3_t pw = mfns_v3((float)row[1], (float)row[2], (float)row[3]);
        assert_int_equal(mfns_cam_project(&g_table.rig.cam[cam], &pose, pw, uv, NULL), MFNS_PROJ_OK);
        const double e = fmax(fabs((double)uv[0] - u), fabs((double)uv[1] - v));
        worst = e > worst ? e : worst;
        assert_near(uv[0], u, 1e-3);
        assert_near(uv[1], v, 1e-3);
        per_cam[cam]++;
        n++;
    }
    assert_int_equal(fclose(f), 0);
    print_message("C projection vs OpenCV projectPoints: worst %.2e px over %d points\n", worst, n);
    assert_true(per_cam[0] >= 50 && per_cam[1] >= 50 && per_cam[2] >= 50);
}

/* ---- undistortion vs Python's exact inverse ------------------------------ */

static void test_undistortion_matches_python(void **state)
{
    (void)state;
    char path[512];
    gen_path(path, sizeof path, "caltable_undistort.txt");
    FILE *f = fopen(path, "r");
    assert_non_null(f);
    int n = 0;
    double worst_a = 0.0, worst_b = 0.0, row[5];
    while (read_numbers(f, NULL, row, 5) == 5) {
        const int cam = (int)row[0];
        const float u = (float)row[1], v = (float)row[2];
        const double ui = row[3], vi = row[4];
        if (cam < 0 || cam > 2) {
            fail_msg("bad camera index %d in the vectors", cam);
            return;
        }
        const mfns_intrinsics_t *k = &g_table.rig.cam[cam].k;
        float x, y;
        assert_int_equal(mfns_undistort_iter(k, u, v, MFNS_UNDIST_DEFAULT_ITER, &x, &y, NULL), MFNS_UNDIST_OK);
        const double ea = hypot((double)k->fx * (double)x + (double)k->skew * (double)y + (double)k->cx - ui,
                                (double)k->fy * (double)y + (double)k->cy - vi);
        worst_a = ea > worst_a ? ea : worst_a;
        /* (b) sees the pixel in q8: compare with the exact value moved by the
         * input rounding (the ideal map has slope ~1, <= 1/512 px shift) */
        q16_16_t uq, vq;
        const px_q8_t u8 = mfns_px_q8_from_float(u), v8 = mfns_px_q8_from_float(v);
        assert_int_equal(mfns_undistort_grid_px(&g_table.grid[cam], u8, v8, &uq, &vq), MFNS_UNDIST_OK);
        const double du8 = (double)u8 / 256.0 - (double)u, dv8 = (double)v8 / 256.0 - (double)v;
        const double eb = hypot((double)uq / 65536.0 - (ui + du8), (double)vq / 65536.0 - (vi + dv8));
        worst_b = eb > worst_b ? eb : worst_b;
        n++;
    }
    assert_int_equal(fclose(f), 0);
    print_message("vs Python exact inverse: (a) worst %.2e px, (b) worst %.4f px over %d points\n", worst_a, worst_b,
                  n);
    assert_int_equal(n, 600);
    assert_true(worst_a <= 1e-4);
    assert_true(worst_b <= 0.01 + 1e-3); /* 1e-3: slope != 1 of the ideal map over the q8 shift */
}

/* The table's grids (built by Python) over the whole image, all cameras,
 * against the C iterative inverse. */
static void test_table_grids_whole_image(void **state)
{
    (void)state;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        const mfns_intrinsics_t *k = &g_table.rig.cam[c].k;
        double worst = 0.0;
        for (int32_t vq = -128; vq < 256 * k->height - 128; vq += 733) {
            for (int32_t uq = -128; uq < 256 * k->width - 128; uq += 733) {
                float x, y;
                assert_int_equal(mfns_undistort_grid(&g_table.grid[c], k, uq, vq, &x, &y), MFNS_UNDIST_OK);
                float xe, ye;
                assert_int_equal(mfns_undistort_iter(k, (float)uq / 256.0f, (float)vq / 256.0f,
                                                     MFNS_UNDIST_DEFAULT_ITER, &xe, &ye, NULL),
                                 MFNS_UNDIST_OK);
                const double e = hypot((double)k->fx * ((double)x - (double)xe), (double)k->fy * ((double)y - (double)ye));
                worst = e > worst ? e : worst;
            }
        }
        print_message("camera %d: table grid worst error %.4f px\n", c, worst);
        assert_true(worst <= 0.01);
    }
}

/* ---- crafted bad tables --------------------------------------------------- */

static void put_u16(uint8_t *b, uint32_t o, uint16_t v)
{
    b[o] = (uint8_t)(v & 0xFFu);
    b[o + 1] = (uint8_t)(v >> 8);
}

static void put_u32(uint8_t *b, uint32_t o, uint32_t v)
{
    for (int i = 0; i < 4; i++) {
        b[o + (uint32_t)i] = (uint8_t)(v >> (8 * i));
    }
}

static void put_f32(uint8_t *b, uint32_t o, float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    put_u32(b, o, u);
}

static uint32_t get_u32(const uint8_t *b, uint32_t o)
{
    return (uint32_t)b[o] | ((uint32_t)b[o + 1] << 8) | ((uint32_t)b[o + 2] << 16) | ((uint32_t)b[o + 3] << 24);
}

static float get_f32(const uint8_t *b, uint32_t o)
{
    const uint32_t u = get_u32(b, o);
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

static void fresh(void) { memcpy(g_bad, g_good, g_good_len); }

static void fix_crc(size_t len)
{
    const uint32_t total = get_u32(g_bad, 8);
    const uint32_t n = total <= len ? total : (uint32_t)len;
    put_u32(g_bad, 12, mfns_crc32(0, g_bad + 16, n - 16));
}

/* Offsets of the generated layout (caltable_layout_gen.h), shorter. */
#define GLB(f) (MFNS_CALTABLE_HEADER_SIZE + MFNS_CALTABLE_OFF_GLOBALS_##f)
#define CAM(f) MFNS_CALTABLE_OFF_CAMERA_##f
#define BCN(f) MFNS_CALTABLE_OFF_BEACON_##f
#define IDX(f) MFNS_CALTABLE_OFF_INDEX_##f
#define GEO(f) MFNS_CALTABLE_OFF_INDEX_GEOM_##f

static uint32_t cam_off(int k)
{
    uint32_t o = MFNS_CALTABLE_HEADER_SIZE + MFNS_CALTABLE_GLOBALS_SIZE;
    for (int i = 0; i < k; i++) {
        o += MFNS_CALTABLE_CAMERA_FIXED_SIZE + MFNS_CALTABLE_NODE_SIZE * (uint32_t)(g_table.grid[i].nx * g_table.grid[i].ny);
    }
    return o;
}

static uint32_t beacon_off(int i) { return cam_off(3) + MFNS_CALTABLE_BEACON_SIZE * (uint32_t)i; }

/* Load g_bad[0..len) into a sentinel-filled g_out: must fail with want (and
 * at want_off unless want_off is UINT32_MAX) and leave g_out untouched. */
static void expect(size_t len, mfns_caltable_status_t want, uint32_t want_off, int line)
{
    uint32_t off = 0xDEADBEEFu;
    const mfns_caltable_status_t st = mfns_caltable_load(g_bad, len, &g_out, &off);
    if (st != want) {
        fail_msg("line %d: status %d (%s), expected %d (%s)", line, (int)st, mfns_caltable_strerror(st), (int)want,
                 mfns_caltable_strerror(want));
    }
    if (want_off != UINT32_MAX && off != want_off) {
        fail_msg("line %d: error offset %u, expected %u", line, off, want_off);
    }
    if (memcmp((const unsigned char *)&g_out, (const unsigned char *)&g_sentinel, sizeof g_out) != 0) {
        fail_msg("line %d: a failed load modified the output table", line);
    }
}
#define EXPECT(len, st, off) expect((len), (st), (off), __LINE__)
#define ANY UINT32_MAX

static int bad_setup(void **state)
{
    (void)state;
    memset(&g_sentinel, 0xA5, sizeof g_sentinel);
    memcpy(&g_out, &g_sentinel, sizeof g_out);
    return 0;
}

static void test_bad_header(void **state)
{
    (void)state;
    const size_t len = g_good_len;
    fresh();
    EXPECT(10, MFNS_CALTABLE_E_TRUNCATED, 10);
    EXPECT(len - 1, MFNS_CALTABLE_E_TRUNCATED, ANY);
    g_bad[0] = 'X';
    EXPECT(len, MFNS_CALTABLE_E_MAGIC, 0);
    fresh();
    put_u16(g_bad, 4, MFNS_CALTABLE_VERSION + 1);
    EXPECT(len, MFNS_CALTABLE_E_VERSION_NEWER, 4);
    put_u16(g_bad, 4, 0xFFFF);
    EXPECT(len, MFNS_CALTABLE_E_VERSION_NEWER, 4);
    put_u16(g_bad, 4, 0);
    EXPECT(len, MFNS_CALTABLE_E_VERSION_BAD, 4);
    fresh();
    put_u16(g_bad, 6, 20);
    EXPECT(len, MFNS_CALTABLE_E_HEADER_SIZE, 6);
    fresh();
    put_u32(g_bad, 8, MFNS_CALTABLE_MAX_BYTES + 1);
    EXPECT(sizeof g_bad, MFNS_CALTABLE_E_SIZE, 8);
    put_u32(g_bad, 8, 40);
    EXPECT(len, MFNS_CALTABLE_E_SIZE, 8);
    /* bad CRC: one flipped bit anywhere in the body */
    fresh();
    g_bad[len / 2] ^= 0x10;
    EXPECT(len, MFNS_CALTABLE_E_CRC, 12);
    fresh();
    g_bad[len - 1] ^= 0x01;
    EXPECT(len, MFNS_CALTABLE_E_CRC, 12);
    fresh();
    g_bad[13] ^= 0x01; /* the stored CRC itself */
    EXPECT(len, MFNS_CALTABLE_E_CRC, 12);
    EXPECT(len, MFNS_CALTABLE_E_CRC, 12);
    assert_int_equal(mfns_caltable_load(NULL, len, &g_out, NULL), MFNS_CALTABLE_E_ARG);
    assert_int_equal(mfns_caltable_load(g_good, len, NULL, NULL), MFNS_CALTABLE_E_ARG);
}

static void test_bad_counts_and_settings(void **state)
{
    (void)state;
    const size_t len = g_good_len;
    struct {
        uint32_t off;
        int kind; /* 0 u16, 1 f32 */
        float value;
        mfns_caltable_status_t want;
    } cases[] = {
        {GLB(CAMERA_COUNT), 0, 2, MFNS_CALTABLE_E_CAMERA_COUNT},
        {GLB(CAMERA_COUNT), 0, 4, MFNS_CALTABLE_E_CAMERA_COUNT},
        {GLB(BEACON_COUNT), 0, 0, MFNS_CALTABLE_E_BEACON_COUNT},
        {GLB(BEACON_COUNT), 0, MFNS_MAX_BEACONS + 1, MFNS_CALTABLE_E_BEACON_COUNT},
        {GLB(PIXEL_SIGMA_PX), 1, NAN, MFNS_CALTABLE_E_NOT_FINITE},
        {GLB(PIXEL_SIGMA_PX), 1, 0.0f, MFNS_CALTABLE_E_PIXEL_SIGMA},
        {GLB(PIXEL_SIGMA_PX), 1, 11.0f, MFNS_CALTABLE_E_PIXEL_SIGMA},
        {GLB(CENTROID_MIN_AREA_PX), 0, 0, MFNS_CALTABLE_E_CENTROID_SETTINGS},     /* min_area 0 */
        {GLB(CENTROID_MAX_AREA_PX), 0, 1, MFNS_CALTABLE_E_CENTROID_SETTINGS},     /* max_area < min_area */
        {GLB(CENTROID_ROI_HALF_SIZE_PX), 0, 0, MFNS_CALTABLE_E_CENTROID_SETTINGS},     /* roi 0 */
        /* centroid.gain_dn_per_e_q12, any u16 (0 = no shot-noise term) */
        {GLB(CENTROID_THRESHOLD_K_SIGMA), 1, 0.0f, MFNS_CALTABLE_E_CENTROID_SETTINGS}, /* no threshold rule */
        {GLB(CENTROID_THRESHOLD_K_SIGMA), 1, INFINITY, MFNS_CALTABLE_E_NOT_FINITE},
        {GLB(CENTROID_MAX_ELONGATION), 1, 0.5f, MFNS_CALTABLE_E_CENTROID_SETTINGS}, /* elongation < 1 */
        {GLB(SOLVER_MAX_ITERATIONS), 0, 0, MFNS_CALTABLE_E_SOLVER_SETTINGS},           /* max_iterations */
        {GLB(SOLVER_MAX_ITERATIONS), 0, 1001, MFNS_CALTABLE_E_SOLVER_SETTINGS},
        {GLB(SOLVER_RESERVED), 0, 1, MFNS_CALTABLE_E_RESERVED},              /* version 1's max_hypotheses */
        {GLB(SOLVER_STEP_TOL), 1, 0.0f, MFNS_CALTABLE_E_SOLVER_SETTINGS},    /* step_tol */
        {GLB(SOLVER_GRAD_TOL), 1, -1e-6f, MFNS_CALTABLE_E_SOLVER_SETTINGS},  /* grad_tol */
        {GLB(SOLVER_HUBER_K), 1, NAN, MFNS_CALTABLE_E_NOT_FINITE},         /* huber_k */
        {GLB(SOLVER_OUTLIER_GATE_SIGMA), 1, -3.0f, MFNS_CALTABLE_E_SOLVER_SETTINGS},  /* outlier gate */
        {GLB(SOLVER_MAX_RESIDUAL_RMS_SIGMA), 1, 0.0f, MFNS_CALTABLE_E_SOLVER_SETTINGS},   /* max rms */
        {GLB(SOLVER_TRACK_GATE_PX), 1, 5000.0f, MFNS_CALTABLE_E_SOLVER_SETTINGS},/* track gate */
        {GLB(SOLVER_MIN_RCOND), 1, 1.5f, MFNS_CALTABLE_E_SOLVER_SETTINGS},   /* min_rcond */
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        fresh();
        if (cases[i].kind == 0) {
            put_u16(g_bad, cases[i].off, (uint16_t)cases[i].value);
        } else {
            put_f32(g_bad, cases[i].off, cases[i].value);
        }
        fix_crc(len);
        EXPECT(len, cases[i].want, cases[i].off);
    }
}

static void test_bad_cameras(void **state)
{
    (void)state;
    const size_t len = g_good_len;
    for (int k = 0; k < 3; k++) {
        const uint32_t o = cam_off(k);
        fresh();
        put_u16(g_bad, o, (uint16_t)((k + 1) % 3)); /* id */
        fix_crc(len);
        EXPECT(len, MFNS_CALTABLE_E_CAMERA_ID, o);
        fresh();
        put_u16(g_bad, o + CAM(RESERVED), 7);
        fix_crc(len);
        EXPECT(len, MFNS_CALTABLE_E_RESERVED, o + CAM(RESERVED));
        fresh();
        put_u16(g_bad, o + CAM(HEIGHT), 0);
        fix_crc(len);
        EXPECT(len, MFNS_CALTABLE_E_IMAGE_SIZE, o + CAM(WIDTH));
        /* NaN in every float of the record, one at a time */
        for (uint32_t f = 0; f < (CAM(GRID_NX) - CAM(FX)) / 4u; f++) {
            fresh();
            put_f32(g_bad, o + CAM(FX) + 4 * f, NAN);
            fix_crc(len);
            EXPECT(len, MFNS_CALTABLE_E_NOT_FINITE, o + CAM(FX) + 4 * f);
        }
        fresh();
        put_f32(g_bad, o + CAM(R_BK_B) + 4, -INFINITY);
        fix_crc(len);
        EXPECT(len, MFNS_CALTABLE_E_NOT_FINITE, o + CAM(R_BK_B) + 4);
        fresh();
        put_f32(g_bad, o + CAM(FX), -1599.0f);
        fix_crc(len);
        EXPECT(len, MFNS_CALTABLE_E_FOCAL, o + CAM(FX));
        fresh();
        put_f32(g_bad, o + CAM(FY), 0.0f);
        fix_crc(len);
        EXPECT(len, MFNS_CALTABLE_E_FOCAL, o + CAM(FY));
        fresh();
        put_f32(g_bad, o + CAM(CX), 1280.0f); /* cx just outside [-0.5, 1279.5] */
        fix_crc(len);
        EXPECT(len, MFNS_CALTABLE_E_PRINCIPAL_POINT, o + CAM(CX));
        fresh();
        put_f32(g_bad, o + CAM(CY), -1.0f);
        fix_crc(len);
        EXPECT(len, MFNS_CALTABLE_E_PRINCIPAL_POINT, o + CAM(CY));
        fresh();
        put_f32(g_bad, o + CAM(DIST) + 4, 5000.0f); /* k2 */
        fix_crc(len);
        EXPECT(len, MFNS_CALTABLE_E_LENS, o + CAM(DIST) + 4);
        /* rotation: off by 2e-5 in one entry (twice the tolerance), and a reflection */
        fresh();
        put_f32(g_bad, o + CAM(C_K_B) + 4 * 4, get_f32(g_bad, o + CAM(C_K_B) + 4 * 4) + 2e-5f);
        fix_crc(len);
        EXPECT(len, MFNS_CALTABLE_E_ROTATION, o + CAM(C_K_B));
        fresh();
        for (uint32_t c = 0; c < 3; c++) {
            put_f32(g_bad, o + CAM(C_K_B) + 4 * c, -get_f32(g_bad, o + CAM(C_K_B) + 4 * c));
        }
        fix_crc(len);
        EXPECT(len, MFNS_CALTABLE_E_ROTATION, o + CAM(C_K_B));
        fresh();
        put_f32(g_bad, o + CAM(R_BK_B) + 8, 2e4f);
        fix_crc(len);
        EXPECT(len, MFNS_CALTABLE_E_EXTRINSICS, o + CAM(R_BK_B) + 8);
    }
}

static void test_bad_grids(void **state)
{
    (void)state;
    const size_t len = g_good_len;
    for (int k = 0; k < 3; k++) {
        const uint32_t o = cam_off(k);
        const mfns_undist_grid_t *g = &g_table.grid[k];
        fresh();
        put_u16(g_bad, o + CAM(GRID_NX), 1);
        fix_crc(len);
        EXPECT(len, MFNS_CALTABLE_E_GRID_DIMS, o + CAM(GRID_NX));
        fresh();
        put_u16(g_bad, o + CAM(GRID_NY), (uint16_t)(MFNS_MAX_GRID_NODES / g->nx + 1)); /* oversize node count */
        fix_crc(len);
        EXPECT(len, MFNS_CALTABLE_E_GRID_DIMS, o + CAM(GRID_NX));
        /* one more column than stored: the nodes no longer line up (the last
         * camera's then read beacon and index bytes as nodes) */
        fresh();
        put_u16(g_bad, o + CAM(GRID_NX), (uint16_t)(g->nx + 1));
        fix_crc(len);
        EXPECT(len, MFNS_CALTABLE_E_GRID_VALUES, ANY);
        /* one row fewer: too short to cover the image */
        fresh();
        put_u16(g_bad, o + CAM(GRID_NY), (uint16_t)(g->ny - 1));
        fix_crc(len);
        EXPECT(len, MFNS_CALTABLE_E_GRID_COVERAGE, o + CAM(GRID_ORIGIN_V_Q8));
        fresh();
        put_u32(g_bad, o + CAM(GRID_STEP_U_Q8), 0);
        fix_crc(len);
        EXPECT(len, MFNS_CALTABLE_E_GRID_STEP, o + CAM(GRID_STEP_U_Q8));
        fresh();
        put_u32(g_bad, o + CAM(GRID_STEP_V_Q8), 70000);
        fix_crc(len);
        EXPECT(len, MFNS_CALTABLE_E_GRID_STEP, o + CAM(GRID_STEP_V_Q8));
        fresh();
        put_u32(g_bad, o + CAM(GRID_ORIGIN_U_Q8), 0); /* origin at pixel 0: the first half pixel is uncovered */
        fix_crc(len);
        EXPECT(len, MFNS_CALTABLE_E_GRID_COVERAGE, o + CAM(GRID_ORIGIN_U_Q8));
        fresh();
        put_u32(g_bad, o + CAM(GRID_STEP_V_Q8), (uint32_t)(g->step_v_q8 - 8)); /* short of the last row */
        fix_crc(len);
        EXPECT(len, MFNS_CALTABLE_E_GRID_COVERAGE, o + CAM(GRID_ORIGIN_V_Q8));
        /* one node's value off by 0.05 px (u) / 0.02 px (v) */
        const uint32_t node = o + MFNS_CALTABLE_CAMERA_FIXED_SIZE + MFNS_CALTABLE_NODE_SIZE * 1234u;
        fresh();
        put_u32(g_bad, node, get_u32(g_bad, node) + 3277u);
        fix_crc(len);
        EXPECT(len, MFNS_CALTABLE_E_GRID_VALUES, node);
        fresh();
        put_u32(g_bad, node + MFNS_CALTABLE_OFF_NODE_V_Q16, get_u32(g_bad, node + MFNS_CALTABLE_OFF_NODE_V_Q16) - 1311u);
        fix_crc(len);
        EXPECT(len, MFNS_CALTABLE_E_GRID_VALUES, node);
        /* within the tolerance: 0.005 px is accepted (the check is not exact equality) */
        fresh();
        put_u32(g_bad, node, get_u32(g_bad, node) + 328u);
        fix_crc(len);
        assert_int_equal(mfns_caltable_load(g_bad, len, &g_out, NULL), MFNS_CALTABLE_OK);
        memcpy(&g_out, &g_sentinel, sizeof g_out);
    }
    /* a grid from another camera's lens: swap the nodes of X into Z */
    fresh();
    const uint32_t nbytes = MFNS_CALTABLE_NODE_SIZE * (uint32_t)(g_table.grid[0].nx * g_table.grid[0].ny);
    memcpy(g_bad + cam_off(2) + MFNS_CALTABLE_CAMERA_FIXED_SIZE, g_good + cam_off(0) + MFNS_CALTABLE_CAMERA_FIXED_SIZE, nbytes);
    fix_crc(len);
    EXPECT(len, MFNS_CALTABLE_E_GRID_VALUES, ANY);
}

static void test_bad_beacons_and_size(void **state)
{
    (void)state;
    const size_t len = g_good_len;
    fresh();
    put_f32(g_bad, beacon_off(3) + BCN(SIGMA_MM), 0.0f);
    fix_crc(len);
    EXPECT(len, MFNS_CALTABLE_E_BEACON_VALUE, beacon_off(3) + BCN(SIGMA_MM));
    fresh();
    put_f32(g_bad, beacon_off(3) + BCN(P_W), 2e7f);
    fix_crc(len);
    EXPECT(len, MFNS_CALTABLE_E_BEACON_VALUE, beacon_off(3) + BCN(P_W));
    fresh();
    put_f32(g_bad, beacon_off(9) + BCN(P_W) + 8, NAN);
    fix_crc(len);
    EXPECT(len, MFNS_CALTABLE_E_NOT_FINITE, beacon_off(9) + BCN(P_W) + 8);
    fresh();
    put_u16(g_bad, beacon_off(9) + BCN(RESERVED), 1);
    fix_crc(len);
    EXPECT(len, MFNS_CALTABLE_E_RESERVED, beacon_off(9) + BCN(RESERVED));
    fresh();
    put_u16(g_bad, beacon_off(7), 2); /* same id as beacon 2 */
    fix_crc(len);
    EXPECT(len, MFNS_CALTABLE_E_BEACON_DUPLICATE, beacon_off(7));
    /* counts that disagree with the records: one beacon more than stored
     * (the calibration-covariance and map-datum headers are read as beacon
     * 10: its sigma_mm is the datum's centre z, 0),
     * one fewer (beacon 9 is read as the calibration-covariance header: its
     * count is 9 = the id), and trailing bytes covered by total_size and the
     * CRC (the index section is then too long) */
    fresh();
    put_u16(g_bad, GLB(BEACON_COUNT), 11);
    fix_crc(len);
    EXPECT(len, MFNS_CALTABLE_E_BEACON_VALUE, beacon_off(10) + BCN(SIGMA_MM));
    put_u16(g_bad, GLB(BEACON_COUNT), 9);
    fix_crc(len);
    EXPECT(len, MFNS_CALTABLE_E_CALIB_COV_COUNT, beacon_off(9));
    fresh();
    memset(g_bad + len, 0, 8);
    put_u32(g_bad, 8, (uint32_t)len + 8);
    fix_crc(len + 8);
    EXPECT(len + 8, MFNS_CALTABLE_E_SIZE_MISMATCH,
           beacon_off(10) + MFNS_CALTABLE_COV_HEADER_SIZE + MFNS_CALTABLE_DATUM_HEADER_SIZE +
               MFNS_CALTABLE_INTEGRITY_SIZE + MFNS_CALTABLE_MOTION_SIZE);
    /* a longer buffer than total_size is fine (a file read into a big buffer) */
    fresh();
    assert_int_equal(mfns_caltable_load(g_bad, len + 8, &g_out, NULL), MFNS_CALTABLE_OK);
    memcpy(&g_out, &g_sentinel, sizeof g_out);
}

/* Every check of the map-index section (docs/caltable.md "Map index"). */
static void test_bad_index(void **state)
{
    (void)state;
    const size_t len = g_good_len;
    /* the default table has no calibration covariance and no map datum: a 4-
     * and a 16-byte section, then the integrity settings and the motion bound */
    const uint32_t ix = beacon_off(g_table.beacons.count) + MFNS_CALTABLE_COV_HEADER_SIZE +
                        MFNS_CALTABLE_DATUM_HEADER_SIZE + MFNS_CALTABLE_INTEGRITY_SIZE + MFNS_CALTABLE_MOTION_SIZE;
    const uint32_t n = g_table.index.count, k = g_table.index.k_nbr;
    const uint32_t geom = ix + MFNS_CALTABLE_INDEX_HEADER_SIZE, nbr = geom + MFNS_CALTABLE_INDEX_GEOM_SIZE * n;
    const uint32_t pairs = nbr + n * (1u + k);
    assert_int_equal(MFNS_BIDX_SECTION_SIZE(n, k), len - ix);
    const struct {
        uint32_t off;
        int kind; /* 0: u8, 1: f32, 2: u16, 3: u32 */
        float value;
        mfns_caltable_status_t want;
    } cases[] = {
        {ix + IDX(BEACONS), 2, 9, MFNS_CALTABLE_E_INDEX_COUNT},
        {ix + IDX(K_NBR), 0, 0, MFNS_CALTABLE_E_INDEX_COUNT},
        {ix + IDX(K_NBR), 0, MFNS_BIDX_MAX_NBR + 1, MFNS_CALTABLE_E_INDEX_COUNT},
        {ix + IDX(MAX_MISSING), 0, MFNS_BIDX_MAX_MISSING + 1, MFNS_CALTABLE_E_INDEX_POLICY},
        {ix + IDX(MAX_UNEXPLAINED), 0, MFNS_BIDX_MAX_CERT + 1, MFNS_CALTABLE_E_INDEX_POLICY},
        {ix + IDX(RESERVED), 0, 1, MFNS_CALTABLE_E_RESERVED},
        {ix + IDX(BUDGET_UNITS), 3, 0, MFNS_CALTABLE_E_INDEX_POLICY},
        {ix + IDX(WS_MIN_W), 1, 1e6f, MFNS_CALTABLE_E_INDEX_WORKSPACE}, /* min x above max x */
        {ix + IDX(WS_MIN_W) + 4, 1, NAN, MFNS_CALTABLE_E_NOT_FINITE},
        {ix + IDX(CERT_INLIERS), 0, MFNS_BIDX_MIN_CERT - 1, MFNS_CALTABLE_E_INDEX_POLICY},
        {ix + IDX(CERT_INLIERS), 0, MFNS_BIDX_MAX_CERT + 1, MFNS_CALTABLE_E_INDEX_POLICY},
        {ix + IDX(CERT_INLIERS) + 3, 0, 4, MFNS_CALTABLE_E_INDEX_POLICY}, /* beyond max_missing: 0 */
        {geom + MFNS_CALTABLE_INDEX_GEOM_SIZE * 2 + GEO(AXIS_W), 1, 0.5f, MFNS_CALTABLE_E_INDEX_GEOMETRY},      /* axis not unit */
        {geom + MFNS_CALTABLE_INDEX_GEOM_SIZE * 2 + GEO(COS_HALF_ANGLE), 1, 1.5f, MFNS_CALTABLE_E_INDEX_GEOMETRY}, /* cosine */
        {geom + MFNS_CALTABLE_INDEX_GEOM_SIZE * 2 + GEO(RANGE_MIN_MM), 1, 1e9f, MFNS_CALTABLE_E_INDEX_GEOMETRY}, /* range min above max */
        {geom + MFNS_CALTABLE_INDEX_GEOM_SIZE * 2 + GEO(RANGE_MAX_MM), 1, INFINITY, MFNS_CALTABLE_E_NOT_FINITE},
        {nbr, 0, (float)k + 1, MFNS_CALTABLE_E_INDEX_NEIGHBOUR},          /* count */
        {nbr + 1, 0, (float)n, MFNS_CALTABLE_E_INDEX_NEIGHBOUR},          /* index out of the map */
        {nbr + 1, 0, 0, MFNS_CALTABLE_E_INDEX_NEIGHBOUR},                 /* itself (beacon 0) */
        {pairs, 0, 200, MFNS_CALTABLE_E_INDEX_PAIR},                      /* lo above hi */
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        fresh();
        const uint32_t o = cases[i].off;
        if (cases[i].kind == 0) {
            g_bad[o] = (uint8_t)cases[i].value;
        } else if (cases[i].kind == 1) {
            put_f32(g_bad, o, cases[i].value);
        } else if (cases[i].kind == 2) {
            put_u16(g_bad, o, (uint16_t)cases[i].value);
        } else {
            put_u32(g_bad, o, (uint32_t)cases[i].value);
        }
        if (o == pairs) {
            g_bad[o + 1] = 10; /* hi 10 < lo 200: reversed, not the empty marker */
        }
        fix_crc(len);
        expect(len, cases[i].want, o, (int)(1000 + i));
    }
    /* a repeated neighbour, and a non-zero unused entry */
    fresh();
    assert_true(g_table.index.nbr_count[0] >= 2);
    g_bad[nbr + 2] = g_bad[nbr + 1];
    fix_crc(len);
    EXPECT(len, MFNS_CALTABLE_E_INDEX_NEIGHBOUR, nbr + 2);
    if (g_table.index.nbr_count[0] < k) {
        fresh();
        g_bad[nbr + 1 + k - 1] = 1;
        fix_crc(len);
        EXPECT(len, MFNS_CALTABLE_E_INDEX_NEIGHBOUR, nbr + k);
    }
    /* the loaded index carries the builder's figures */
    assert_int_equal(g_table.index.count, g_table.beacons.count);
    assert_true(g_table.index.cert_inliers[0] >= MFNS_BIDX_MIN_CERT);
    assert_true(g_table.index.budget_units > 0);
}

/* Tables of format versions 1 (no map index) and 2 (no calibration
 * covariance, pixel sigma meant as the whole noise) are refused as too old. */
static void test_old_version(void **state)
{
    (void)state;
    fresh();
    put_u16(g_bad, 4, 1);
    EXPECT(g_good_len, MFNS_CALTABLE_E_VERSION_OLD, 4);
    put_u16(g_bad, 4, 2);
    EXPECT(g_good_len, MFNS_CALTABLE_E_VERSION_OLD, 4);
    put_u16(g_bad, 4, 3); /* version 3: no integrity settings: rebuild */
    EXPECT(g_good_len, MFNS_CALTABLE_E_VERSION_OLD, 4);
    put_u16(g_bad, 4, 4); /* version 4: no map datum: rebuild */
    EXPECT(g_good_len, MFNS_CALTABLE_E_VERSION_OLD, 4);
    put_u16(g_bad, 4, 5); /* version 5: no motion bound: rebuild */
    EXPECT(g_good_len, MFNS_CALTABLE_E_VERSION_OLD, 4);
}

/* The integrity settings section (docs/caltable.md "Integrity settings"):
 * the defaults load, and each field outside its range is refused at its
 * offset. */
static void test_integrity_section(void **state)
{
    (void)state;
    mfns_integrity_settings_t d;
    mfns_integrity_settings_default(&d);
    assert_true(g_table.integrity.alert_limit_pos_mm == d.alert_limit_pos_mm &&
                g_table.integrity.alert_limit_att_deg == d.alert_limit_att_deg && g_table.integrity.p_fa == d.p_fa &&
                g_table.integrity.p_md == d.p_md && g_table.integrity.hold_cycles == d.hold_cycles &&
                g_table.integrity.require_camera_monitor == d.require_camera_monitor);
    const uint32_t o =
        beacon_off(g_table.beacons.count) + MFNS_CALTABLE_COV_HEADER_SIZE + MFNS_CALTABLE_DATUM_HEADER_SIZE;
    const struct {
        uint32_t off;
        int kind; /* 0: u8, 1: f32, 2: u16 */
        float value;
        mfns_caltable_status_t want;
    } cases[] = {
        {MFNS_CALTABLE_OFF_INTEGRITY_ALERT_LIMIT_POS_MM, 1, 0.0f, MFNS_CALTABLE_E_INTEGRITY_SETTINGS},
        {MFNS_CALTABLE_OFF_INTEGRITY_ALERT_LIMIT_POS_MM, 1, NAN, MFNS_CALTABLE_E_NOT_FINITE},
        {MFNS_CALTABLE_OFF_INTEGRITY_ALERT_LIMIT_ATT_DEG, 1, 181.0f, MFNS_CALTABLE_E_INTEGRITY_SETTINGS},
        {MFNS_CALTABLE_OFF_INTEGRITY_P_FA, 1, 0.5f, MFNS_CALTABLE_E_INTEGRITY_SETTINGS},
        {MFNS_CALTABLE_OFF_INTEGRITY_P_FA, 1, 0.0f, MFNS_CALTABLE_E_INTEGRITY_SETTINGS},
        {MFNS_CALTABLE_OFF_INTEGRITY_P_MD, 1, -1e-3f, MFNS_CALTABLE_E_INTEGRITY_SETTINGS},
        {MFNS_CALTABLE_OFF_INTEGRITY_HOLD_CYCLES, 2, 10001.0f, MFNS_CALTABLE_E_INTEGRITY_SETTINGS},
        {MFNS_CALTABLE_OFF_INTEGRITY_REQUIRE_CAMERA_MONITOR, 0, 2.0f, MFNS_CALTABLE_E_INTEGRITY_SETTINGS},
        {MFNS_CALTABLE_OFF_INTEGRITY_MONITOR_ONLY, 0, 2.0f, MFNS_CALTABLE_E_INTEGRITY_SETTINGS},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        fresh();
        if (cases[i].kind == 1) {
            put_f32(g_bad, o + cases[i].off, cases[i].value);
        } else if (cases[i].kind == 2) {
            put_u16(g_bad, o + cases[i].off, (uint16_t)cases[i].value);
        } else {
            g_bad[o + cases[i].off] = (uint8_t)cases[i].value;
        }
        fix_crc(g_good_len);
        EXPECT(g_good_len, cases[i].want, o + cases[i].off);
    }
    /* the strict camera rule is a valid setting */
    fresh();
    g_bad[o + MFNS_CALTABLE_OFF_INTEGRITY_REQUIRE_CAMERA_MONITOR] = 1;
    fix_crc(g_good_len);
    assert_int_equal(mfns_caltable_load(g_bad, g_good_len, &g_out, NULL), MFNS_CALTABLE_OK);
    assert_int_equal(g_out.integrity.require_camera_monitor, 1);
    memcpy(&g_out, &g_sentinel, sizeof g_out);
}

/* The motion bound (docs/caltable.md "Motion bound"): the defaults load and
 * are valid filter settings; each field outside its range is refused at its
 * offset, the reserved u16 too, and a coast beyond the bound time (a cross-
 * field rule: beyond T the bound's bias outgrows the process noise) at
 * max_coast_s; a bound of the operator's own is loaded as written. */
static void test_motion_section(void **state)
{
    (void)state;
    mfns_filter_settings_t d;
    mfns_filter_settings_default(&d);
    assert_true(mfns_filter_settings_valid(&d));
    const mfns_filter_settings_t *m = &g_table.motion;
    assert_true(m->accel_bound_mm_s2 == d.accel_bound_mm_s2 && m->alpha_bound_rad_s2 == d.alpha_bound_rad_s2 &&
                m->bound_time_s == d.bound_time_s && m->max_coast_s == d.max_coast_s && m->gate_p == d.gate_p &&
                m->gate_reject_run == d.gate_reject_run && m->aug_rot_rad == d.aug_rot_rad &&
                m->aug_dt_s == d.aug_dt_s);
    const uint32_t o = beacon_off(g_table.beacons.count) + MFNS_CALTABLE_COV_HEADER_SIZE +
                       MFNS_CALTABLE_DATUM_HEADER_SIZE + MFNS_CALTABLE_INTEGRITY_SIZE;
    const struct {
        uint32_t off;
        int kind; /* 1: f32, 2: u16 */
        float value;
        mfns_caltable_status_t want;
    } cases[] = {
        {MFNS_CALTABLE_OFF_MOTION_ACCEL_BOUND_MM_S2, 1, 0.0f, MFNS_CALTABLE_E_MOTION_SETTINGS},
        {MFNS_CALTABLE_OFF_MOTION_ACCEL_BOUND_MM_S2, 1, -100.0f, MFNS_CALTABLE_E_MOTION_SETTINGS},
        {MFNS_CALTABLE_OFF_MOTION_ACCEL_BOUND_MM_S2, 1, INFINITY, MFNS_CALTABLE_E_NOT_FINITE},
        {MFNS_CALTABLE_OFF_MOTION_ALPHA_BOUND_RAD_S2, 1, NAN, MFNS_CALTABLE_E_NOT_FINITE},
        {MFNS_CALTABLE_OFF_MOTION_ALPHA_BOUND_RAD_S2, 1, 1001.0f, MFNS_CALTABLE_E_MOTION_SETTINGS},
        {MFNS_CALTABLE_OFF_MOTION_BOUND_TIME_S, 1, 0.0f, MFNS_CALTABLE_E_MOTION_SETTINGS},
        {MFNS_CALTABLE_OFF_MOTION_BOUND_TIME_S, 1, 0.1f, MFNS_CALTABLE_E_MOTION_SETTINGS}, /* below the coast 0.2 */
        {MFNS_CALTABLE_OFF_MOTION_MAX_COAST_S, 1, 0.3f, MFNS_CALTABLE_E_MOTION_SETTINGS},  /* beyond T 0.2 */
        {MFNS_CALTABLE_OFF_MOTION_MAX_COAST_S, 1, 11.0f, MFNS_CALTABLE_E_MOTION_SETTINGS},
        {MFNS_CALTABLE_OFF_MOTION_GATE_P, 1, 0.5f, MFNS_CALTABLE_E_MOTION_SETTINGS},
        {MFNS_CALTABLE_OFF_MOTION_GATE_P, 1, 0.0f, MFNS_CALTABLE_E_MOTION_SETTINGS},
        {MFNS_CALTABLE_OFF_MOTION_GATE_REJECT_RUN, 2, 0.0f, MFNS_CALTABLE_E_MOTION_SETTINGS},
        {MFNS_CALTABLE_OFF_MOTION_GATE_REJECT_RUN, 2, 1001.0f, MFNS_CALTABLE_E_MOTION_SETTINGS},
        {MFNS_CALTABLE_OFF_MOTION_RESERVED, 2, 1.0f, MFNS_CALTABLE_E_RESERVED},
        {MFNS_CALTABLE_OFF_MOTION_AUG_ROT_RAD, 1, 0.0f, MFNS_CALTABLE_E_MOTION_SETTINGS},
        {MFNS_CALTABLE_OFF_MOTION_AUG_ROT_RAD, 1, 0.6f, MFNS_CALTABLE_E_MOTION_SETTINGS},
        {MFNS_CALTABLE_OFF_MOTION_AUG_DT_S, 1, -0.06f, MFNS_CALTABLE_E_MOTION_SETTINGS},
        {MFNS_CALTABLE_OFF_MOTION_AUG_DT_S, 1, 2.0f, MFNS_CALTABLE_E_MOTION_SETTINGS},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        fresh();
        if (cases[i].kind == 1) {
            put_f32(g_bad, o + cases[i].off, cases[i].value);
        } else {
            put_u16(g_bad, o + cases[i].off, (uint16_t)cases[i].value);
        }
        fix_crc(g_good_len);
        /* the cross-field rule names max_coast_s, whichever of the two moved */
        const uint32_t at = cases[i].off == MFNS_CALTABLE_OFF_MOTION_BOUND_TIME_S && cases[i].value > 0.0f
                                ? MFNS_CALTABLE_OFF_MOTION_MAX_COAST_S
                                : cases[i].off;
        EXPECT(g_good_len, cases[i].want, o + at);
    }
    /* a turntable's bound (omega^2 r beyond a free flyer's), a longer coast
     * under a longer T: loaded as written and valid for the filter */
    fresh();
    put_f32(g_bad, o + MFNS_CALTABLE_OFF_MOTION_ACCEL_BOUND_MM_S2, 60.0f);
    put_f32(g_bad, o + MFNS_CALTABLE_OFF_MOTION_BOUND_TIME_S, 0.5f);
    put_f32(g_bad, o + MFNS_CALTABLE_OFF_MOTION_MAX_COAST_S, 0.5f);
    put_u16(g_bad, o + MFNS_CALTABLE_OFF_MOTION_GATE_REJECT_RUN, 5);
    fix_crc(g_good_len);
    assert_int_equal(mfns_caltable_load(g_bad, g_good_len, &g_out, NULL), MFNS_CALTABLE_OK);
    assert_true(g_out.motion.accel_bound_mm_s2 == 60.0f && g_out.motion.bound_time_s == 0.5f &&
                g_out.motion.max_coast_s == 0.5f && g_out.motion.gate_reject_run == 5 &&
                g_out.motion.alpha_bound_rad_s2 == d.alpha_bound_rad_s2);
    assert_true(mfns_filter_settings_valid(&g_out.motion));
    memcpy(&g_out, &g_sentinel, sizeof g_out);
}

/* ---- the calibration-covariance section -------------------------------- */

#define NCP MFNS_CALIB_PARAMS
#define COV_TRI (NCP * (NCP + 1) / 2)

static uint32_t cov_off(void) { return beacon_off(g_table.beacons.count); }

/* Byte offset of element (i, j), i <= j, of the stored upper triangle. */
static uint32_t cov_elem(int i, int j)
{
    const int e = i * NCP - i * (i - 1) / 2 + (j - i);
    return cov_off() + MFNS_CALTABLE_COV_HEADER_SIZE + 4u * (uint32_t)e;
}

/* g_bad = the default table with the covariance c in its section (sizes and
 * CRC fixed); returns the table's length. */
static size_t with_cov(const double c[NCP][NCP])
{
    const uint32_t at = cov_off();
    const uint32_t rest = (uint32_t)g_good_len - at - MFNS_CALTABLE_COV_HEADER_SIZE; /* the index */
    memcpy(g_bad, g_good, at);
    put_u16(g_bad, at, NCP);
    put_u16(g_bad, at + 2, 0);
    for (int i = 0; i < NCP; i++) {
        for (int j = i; j < NCP; j++) {
            put_f32(g_bad, cov_elem(i, j), (float)c[i][j]);
        }
    }
    const uint32_t ix = at + MFNS_CALTABLE_COV_HEADER_SIZE + 4u * COV_TRI;
    memcpy(g_bad + ix, g_good + at + MFNS_CALTABLE_COV_HEADER_SIZE, rest);
    const size_t len = ix + rest;
    put_u32(g_bad, 8, (uint32_t)len);
    fix_crc(len);
    return len;
}

/* A covariance of realistic scales (px^2, unitless, rad^2, mm^2), correlated
 * within each camera and across cameras, positive definite by construction
 * (B B^T + diag). */
static void sample_cov(double c[NCP][NCP])
{
    static const double sd[MFNS_CALIB_PARAMS_PER_CAMERA] = {2.0, 2.0, 1.0, 1.0, 1e-3, 1e-3, 1e-4, 1e-4, 1e-3,
                                                            5e-4, 5e-4, 5e-4, 0.5, 0.5, 0.5};
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 77);
    double b[NCP][4];
    for (int i = 0; i < NCP; i++) {
        for (int k = 0; k < 4; k++) {
            b[i][k] = mfns_rng_range(&rng, -0.5, 0.5) * sd[i % MFNS_CALIB_PARAMS_PER_CAMERA];
        }
    }
    for (int i = 0; i < NCP; i++) {
        for (int j = 0; j < NCP; j++) {
            double v = 0.0;
            for (int k = 0; k < 4; k++) {
                v += b[i][k] * b[j][k];
            }
            const double s = sd[i % MFNS_CALIB_PARAMS_PER_CAMERA];
            c[i][j] = v + (i == j ? 0.5 * s * s : 0.0);
        }
    }
}

static void test_calib_cov_section(void **state)
{
    (void)state;
    static double c[NCP][NCP];
    static mfns_caltable_t t;
    /* the default table (no covariance in its calibration) has none */
    assert_int_equal(g_table.calib_cov.present, 0);
    sample_cov(c);
    size_t len = with_cov(c);
    uint32_t off = 0;
    assert_int_equal(mfns_caltable_load(g_bad, len, &t, &off), MFNS_CALTABLE_OK);
    assert_int_equal(t.calib_cov.present, 1);
    for (int i = 0; i < NCP; i++) {
        for (int j = 0; j < NCP; j++) {
            assert_true(t.calib_cov.cov[i][j] == (float)c[i < j ? i : j][i < j ? j : i]);
        }
    }
    assert_true(t.index.count == g_table.index.count); /* the index after it is read too */
    /* semi-definite (two parameters perfectly correlated, one known exactly) is accepted */
    for (int j = 0; j < NCP; j++) {
        c[1][j] = c[0][j];
        c[j][1] = c[j][0];
        c[20][j] = 0.0;
        c[j][20] = 0.0;
    }
    c[1][1] = c[0][0];
    len = with_cov(c);
    assert_int_equal(mfns_caltable_load(g_bad, len, &t, &off), MFNS_CALTABLE_OK);
    sample_cov(c);
    /* each check: count, reserved, finite, negative variance, covariance of
     * an exact parameter, correlation above 1, and an indefinite triple
     * whose pairwise correlations are each below 1 */
    len = with_cov(c);
    put_u16(g_bad, cov_off(), 44);
    fix_crc(len);
    EXPECT(len, MFNS_CALTABLE_E_CALIB_COV_COUNT, cov_off());
    len = with_cov(c);
    put_u16(g_bad, cov_off() + MFNS_CALTABLE_OFF_CALIB_COV_RESERVED, 1);
    fix_crc(len);
    EXPECT(len, MFNS_CALTABLE_E_RESERVED, cov_off() + MFNS_CALTABLE_OFF_CALIB_COV_RESERVED);
    len = with_cov(c);
    put_f32(g_bad, cov_elem(3, 17), NAN);
    fix_crc(len);
    EXPECT(len, MFNS_CALTABLE_E_NOT_FINITE, cov_elem(3, 17));
    len = with_cov(c);
    put_f32(g_bad, cov_elem(12, 12), -1e-3f);
    fix_crc(len);
    EXPECT(len, MFNS_CALTABLE_E_CALIB_COV_PSD, cov_elem(12, 12));
    len = with_cov(c);
    put_f32(g_bad, cov_elem(5, 5), 0.0f);
    fix_crc(len);
    EXPECT(len, MFNS_CALTABLE_E_CALIB_COV_PSD, cov_elem(0, 5));
    len = with_cov(c);
    put_f32(g_bad, cov_elem(2, 30), (float)(1.01 * sqrt(c[2][2] * c[30][30])));
    fix_crc(len);
    EXPECT(len, MFNS_CALTABLE_E_CALIB_COV_PSD, cov_elem(30, 30));
    for (int i = 0; i < NCP; i++) {
        for (int j = 0; j < NCP; j++) {
            c[i][j] = i == j ? 1.0 : 0.0;
        }
    }
    c[0][1] = c[1][0] = 0.9; /* corr(0,1) = corr(0,2) = 0.9, corr(1,2) = -0.9 */
    c[0][2] = c[2][0] = 0.9;
    c[1][2] = c[2][1] = -0.9;
    len = with_cov(c);
    EXPECT(len, MFNS_CALTABLE_E_CALIB_COV_PSD, cov_elem(2, 2));
    /* a count of 45 with the section cut short */
    fresh();
    put_u16(g_bad, cov_off(), NCP);
    fix_crc(g_good_len);
    EXPECT(g_good_len, MFNS_CALTABLE_E_SIZE_MISMATCH, cov_off());
}

/* The map datum section (docs/caltable.md "Map datum covariance"), after the
 * calibration covariance (none in the default table). */
#define ND MFNS_MAP_DATUM_PARAMS

static uint32_t datum_off(void) { return cov_off() + MFNS_CALTABLE_COV_HEADER_SIZE; }

static uint32_t datum_elem(int i, int j)
{
    const int e = i * ND - i * (i - 1) / 2 + (j - i);
    return datum_off() + MFNS_CALTABLE_DATUM_HEADER_SIZE + 4u * (uint32_t)e;
}

/* g_bad = the default table with the datum (c, centre) in its section. */
static size_t with_datum(const double c[ND][ND], const float centre[3])
{
    const uint32_t at = datum_off();
    const uint32_t rest = (uint32_t)g_good_len - at - MFNS_CALTABLE_DATUM_HEADER_SIZE;
    memcpy(g_bad, g_good, at);
    put_u16(g_bad, at, ND);
    put_u16(g_bad, at + 2, 0);
    for (int i = 0; i < 3; i++) {
        put_f32(g_bad, at + MFNS_CALTABLE_OFF_MAP_DATUM_C_W + 4u * (uint32_t)i, centre[i]);
    }
    for (int i = 0; i < ND; i++) {
        for (int j = i; j < ND; j++) {
            put_f32(g_bad, datum_elem(i, j), (float)c[i][j]);
        }
    }
    const uint32_t ix = at + MFNS_CALTABLE_DATUM_HEADER_SIZE + 4u * (ND * (ND + 1) / 2);
    memcpy(g_bad + ix, g_good + at + MFNS_CALTABLE_DATUM_HEADER_SIZE, rest);
    const size_t len = ix + rest;
    put_u32(g_bad, 8, (uint32_t)len);
    fix_crc(len);
    return len;
}

/* A refined map's datum: 0.05 mm shifts, 0.003 deg turns, a shift-turn correlation. */
static void sample_datum(double c[ND][ND])
{
    static const double sd[ND] = {0.05, 0.06, 0.04, 5e-5, 4e-5, 6e-5};
    for (int i = 0; i < ND; i++) {
        for (int j = 0; j < ND; j++) {
            c[i][j] = i == j ? sd[i] * sd[i] : 0.0;
        }
    }
    c[0][4] = c[4][0] = 0.5 * sd[0] * sd[4];
    c[1][2] = c[2][1] = -0.3 * sd[1] * sd[2];
}

static void test_map_datum_section(void **state)
{
    (void)state;
    static mfns_caltable_t t;
    double c[ND][ND];
    const float centre[3] = {1200.0f, -350.5f, 40.25f};
    assert_int_equal(g_table.datum.present, 0); /* the default table has none */
    sample_datum(c);
    size_t len = with_datum(c, centre);
    uint32_t off = 0;
    assert_int_equal(mfns_caltable_load(g_bad, len, &t, &off), MFNS_CALTABLE_OK);
    assert_int_equal(t.datum.present, 1);
    assert_true(t.datum.c_w.x == centre[0] && t.datum.c_w.y == centre[1] && t.datum.c_w.z == centre[2]);
    for (int i = 0; i < ND; i++) {
        for (int j = 0; j < ND; j++) {
            assert_true(t.datum.cov[i][j] == (float)c[i < j ? i : j][i < j ? j : i]);
        }
    }
    assert_true(t.integrity.p_fa == g_table.integrity.p_fa); /* the sections after it are read */
    assert_true(t.index.count == g_table.index.count);
    /* each check: count, reserved, centre (range, and set without a datum),
     * finite, negative variance, a correlation above 1 */
    len = with_datum(c, centre);
    put_u16(g_bad, datum_off(), 5);
    fix_crc(len);
    EXPECT(len, MFNS_CALTABLE_E_MAP_DATUM_COUNT, datum_off());
    len = with_datum(c, centre);
    put_u16(g_bad, datum_off() + MFNS_CALTABLE_OFF_MAP_DATUM_RESERVED, 1);
    fix_crc(len);
    EXPECT(len, MFNS_CALTABLE_E_RESERVED, datum_off() + MFNS_CALTABLE_OFF_MAP_DATUM_RESERVED);
    const float far[3] = {0.0f, 2e7f, 0.0f};
    len = with_datum(c, far);
    EXPECT(len, MFNS_CALTABLE_E_MAP_DATUM_CENTRE, datum_off() + MFNS_CALTABLE_OFF_MAP_DATUM_C_W + 4u);
    len = with_datum(c, centre);
    put_f32(g_bad, datum_off() + MFNS_CALTABLE_OFF_MAP_DATUM_C_W + 8u, NAN);
    fix_crc(len);
    EXPECT(len, MFNS_CALTABLE_E_NOT_FINITE, datum_off() + MFNS_CALTABLE_OFF_MAP_DATUM_C_W + 8u);
    len = with_datum(c, centre);
    put_f32(g_bad, datum_elem(2, 5), INFINITY);
    fix_crc(len);
    EXPECT(len, MFNS_CALTABLE_E_NOT_FINITE, datum_elem(2, 5));
    len = with_datum(c, centre);
    put_f32(g_bad, datum_elem(3, 3), -1e-9f);
    fix_crc(len);
    EXPECT(len, MFNS_CALTABLE_E_MAP_DATUM_PSD, datum_elem(3, 3));
    len = with_datum(c, centre);
    put_f32(g_bad, datum_elem(0, 4), (float)(1.05 * sqrt(c[0][0] * c[4][4])));
    fix_crc(len);
    EXPECT(len, MFNS_CALTABLE_E_MAP_DATUM_PSD, datum_elem(4, 4));
    /* no datum names no centre; a count of 6 with the section cut short */
    fresh();
    put_f32(g_bad, datum_off() + MFNS_CALTABLE_OFF_MAP_DATUM_C_W, 1.0f);
    fix_crc(g_good_len);
    EXPECT(g_good_len, MFNS_CALTABLE_E_MAP_DATUM_CENTRE, datum_off() + MFNS_CALTABLE_OFF_MAP_DATUM_C_W);
    fresh();
    put_u16(g_bad, datum_off(), ND);
    put_u32(g_bad, 8, datum_off() + MFNS_CALTABLE_DATUM_HEADER_SIZE + 8u);
    fix_crc(g_good_len);
    EXPECT(g_good_len, MFNS_CALTABLE_E_SIZE_MISMATCH, datum_off());
}

/* A failed load leaves the previous table in service; a good one replaces it. */
static void test_failed_load_keeps_previous_table(void **state)
{
    (void)state;
    static mfns_caltable_t t;
    assert_int_equal(mfns_caltable_load(g_good, g_good_len, &t, NULL), MFNS_CALTABLE_OK);
    fresh();
    put_f32(g_bad, cam_off(1) + 8, NAN);
    fix_crc(g_good_len);
    assert_int_equal(mfns_caltable_load(g_bad, g_good_len, &t, NULL), MFNS_CALTABLE_E_NOT_FINITE);
    assert_true(t.rig.cam[1].k.fx == g_table.rig.cam[1].k.fx);
    assert_true(t.grid[2].node == (const q16_16_t(*)[2])t.grid_node[2]);
    q16_16_t a, b;
    assert_int_equal(mfns_undistort_grid_px(&t.grid[2], 100 * 256, 100 * 256, &a, &b), MFNS_UNDIST_OK);
}

static void test_strerror_and_crc(void **state)
{
    (void)state;
    for (int i = 0; i < MFNS_CALTABLE_STATUS_COUNT; i++) {
        const char *m = mfns_caltable_strerror((mfns_caltable_status_t)i);
        assert_non_null(m);
        assert_null(strchr(m, '\n'));
        for (int j = 0; j < i; j++) {
            assert_string_not_equal(m, mfns_caltable_strerror((mfns_caltable_status_t)j));
        }
    }
    assert_non_null(mfns_caltable_strerror(MFNS_CALTABLE_STATUS_COUNT));
    /* the CRC-32/ISO-HDLC check value, and continuation */
    const uint8_t s[] = "123456789";
    assert_int_equal(mfns_crc32(0, s, 9), 0xCBF43926u);
    assert_int_equal(mfns_crc32(mfns_crc32(0, s, 4), s + 4, 5), 0xCBF43926u);
    assert_int_equal(mfns_crc32(0, s, 0), 0u);
}

static void test_file_loader(void **state)
{
    (void)state;
    static uint8_t buf[MFNS_CALTABLE_MAX_BYTES];
    char path[512];
    gen_path(path, sizeof path, "default.mfnstbl");
    uint32_t off = 0;
    assert_int_equal(mfns_caltable_load_file(path, buf, sizeof buf, &g_out, &off), MFNS_CALTABLE_OK);
    assert_true(g_out.crc32 == g_table.crc32);
    assert_true(g_out.rig.cam[2].k.fy == g_table.rig.cam[2].k.fy);
    memcpy(&g_out, &g_sentinel, sizeof g_out);
    assert_int_equal(mfns_caltable_load_file(path, buf, g_good_len - 1, &g_out, NULL), MFNS_CALTABLE_E_FILE_TOO_BIG);
    assert_int_equal(mfns_caltable_load_file("/nonexistent/mfns.tbl", buf, sizeof buf, &g_out, NULL),
                     MFNS_CALTABLE_E_FILE_OPEN);
    /* a directory, and a FIFO with no writer: refused at once, never waited on
     * (a TABLE_LOAD of a FIFO used to block the whole cycle) */
    assert_int_equal(mfns_caltable_load_file(mfns_test_gen_dir(), buf, sizeof buf, &g_out, NULL),
                     MFNS_CALTABLE_E_FILE_NOT_REGULAR);
    char dir[] = "/tmp/mfns-caltable-XXXXXX";
    assert_non_null(mkdtemp(dir));
    char fifo[64];
    (void)snprintf(fifo, sizeof fifo, "%s/table.fifo", dir);
    assert_int_equal(mkfifo(fifo, 0600), 0);
    assert_int_equal(mfns_caltable_load_file(fifo, buf, sizeof buf, &g_out, NULL), MFNS_CALTABLE_E_FILE_NOT_REGULAR);
    assert_int_equal(unlink(fifo), 0);
    assert_int_equal(rmdir(dir), 0);
    gen_path(path, sizeof path, "caltable_values.txt"); /* a file that is not a table */
    assert_int_equal(mfns_caltable_load_file(path, buf, sizeof buf, &g_out, NULL), MFNS_CALTABLE_E_MAGIC);
    assert_int_equal(mfns_caltable_load_file(NULL, buf, sizeof buf, &g_out, NULL), MFNS_CALTABLE_E_ARG);
    assert_memory_equal(&g_out, &g_sentinel, sizeof g_out);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_python_table_loads_with_identical_values),
        cmocka_unit_test(test_projection_matches_opencv),
        cmocka_unit_test(test_undistortion_matches_python),
        cmocka_unit_test(test_table_grids_whole_image),
        cmocka_unit_test_setup(test_bad_header, bad_setup),
        cmocka_unit_test_setup(test_bad_counts_and_settings, bad_setup),
        cmocka_unit_test_setup(test_bad_cameras, bad_setup),
        cmocka_unit_test_setup(test_bad_grids, bad_setup),
        cmocka_unit_test_setup(test_bad_beacons_and_size, bad_setup),
        cmocka_unit_test_setup(test_bad_index, bad_setup),
        cmocka_unit_test_setup(test_old_version, bad_setup),
        cmocka_unit_test_setup(test_integrity_section, bad_setup),
        cmocka_unit_test_setup(test_motion_section, bad_setup),
        cmocka_unit_test_setup(test_calib_cov_section, bad_setup),
        cmocka_unit_test_setup(test_map_datum_section, bad_setup),
        cmocka_unit_test(test_failed_load_keeps_previous_table),
        cmocka_unit_test(test_strerror_and_crc),
        cmocka_unit_test_setup(test_file_loader, bad_setup),
    };
    return cmocka_run_group_tests_name("caltable", tests, setup, NULL);
}
