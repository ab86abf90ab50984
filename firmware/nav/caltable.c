/* caltable.c -- see caltable.h; the byte layout is docs/caltable.md. */
#include "caltable.h"

#include <math.h>
#include <string.h>

/* ---- CRC-32/ISO-HDLC, 4 bits at a time: a 64-byte table instead of 1 KiB. */
static const uint32_t crc_nibble[16] = {
    0x00000000u, 0x1DB71064u, 0x3B6E20C8u, 0x26D930ACu, 0x76DC4190u, 0x6B6B51F4u, 0x4DB26158u, 0x5005713Cu,
    0xEDB88320u, 0xF00F9344u, 0xD6D6A3E8u, 0xCB61B38Cu, 0x9B64C2B0u, 0x86D3D2D4u, 0xA00AE278u, 0xBDBDF21Cu,
};

uint32_t mfns_crc32(uint32_t crc, const uint8_t *p, size_t n)
{
    uint32_t c = ~crc;
    for (size_t i = 0; i < n; i++) {
        c ^= p[i];
        c = (c >> 4) ^ crc_nibble[c & 0xFu];
        c = (c >> 4) ^ crc_nibble[c & 0xFu];
    }
    return ~c;
}

const char *mfns_caltable_strerror(mfns_caltable_status_t s)
{
    switch (s) {
    case MFNS_CALTABLE_OK: return "calibration table ok";
    case MFNS_CALTABLE_E_ARG: return "calibration table: NULL argument";
    case MFNS_CALTABLE_E_TRUNCATED: return "calibration table truncated (shorter than its header or total size)";
    case MFNS_CALTABLE_E_MAGIC: return "not a calibration table (bad magic, expected \"MFTB\")";
    case MFNS_CALTABLE_E_VERSION_NEWER: return "calibration table format is newer than this loader (refused)";
    case MFNS_CALTABLE_E_VERSION_BAD: return "calibration table format version 0 is invalid";
    case MFNS_CALTABLE_E_HEADER_SIZE: return "calibration table header size is not 16";
    case MFNS_CALTABLE_E_SIZE: return "calibration table total size out of range for this build";
    case MFNS_CALTABLE_E_CRC: return "calibration table body CRC-32 mismatch (corrupt)";
    case MFNS_CALTABLE_E_CAMERA_COUNT: return "calibration table camera count is not 3";
    case MFNS_CALTABLE_E_BEACON_COUNT: return "calibration table beacon count is 0 or above MFNS_MAX_BEACONS";
    case MFNS_CALTABLE_E_RESERVED: return "calibration table reserved field is not zero";
    case MFNS_CALTABLE_E_NOT_FINITE: return "calibration table holds a NaN or infinite number";
    case MFNS_CALTABLE_E_PIXEL_SIGMA: return "calibration table pixel noise sigma outside (0, 10] px";
    case MFNS_CALTABLE_E_CENTROID_SETTINGS: return "calibration table centroid setting out of range";
    case MFNS_CALTABLE_E_SOLVER_SETTINGS: return "calibration table solver setting out of range";
    case MFNS_CALTABLE_E_CAMERA_ID: return "calibration table camera id does not match its position";
    case MFNS_CALTABLE_E_IMAGE_SIZE: return "calibration table camera image size is zero";
    case MFNS_CALTABLE_E_FOCAL: return "calibration table focal length not positive or absurd";
    case MFNS_CALTABLE_E_PRINCIPAL_POINT: return "calibration table principal point outside the image";
    case MFNS_CALTABLE_E_LENS: return "calibration table skew or distortion coefficient absurd";
    case MFNS_CALTABLE_E_ROTATION: return "calibration table camera rotation C_k_b not orthonormal to 1e-5";
    case MFNS_CALTABLE_E_EXTRINSICS: return "calibration table camera offset r_bk_b absurd (> 10 m)";
    case MFNS_CALTABLE_E_GRID_DIMS: return "calibration table grid dimensions < 2 or above MFNS_MAX_GRID_NODES";
    case MFNS_CALTABLE_E_GRID_STEP: return "calibration table grid step outside 1..255 px";
    case MFNS_CALTABLE_E_GRID_COVERAGE: return "calibration table grid does not cover the whole image";
    case MFNS_CALTABLE_E_GRID_VALUES: return "calibration table grid node disagrees with the lens model";
    case MFNS_CALTABLE_E_SIZE_MISMATCH: return "calibration table contents do not match its total size";
    case MFNS_CALTABLE_E_BEACON_VALUE: return "calibration table beacon sigma not positive or position absurd";
    case MFNS_CALTABLE_E_BEACON_DUPLICATE: return "calibration table has two beacons with the same id";
    case MFNS_CALTABLE_E_FILE_OPEN: return "calibration table file cannot be opened";
    case MFNS_CALTABLE_E_FILE_READ: return "calibration table file read error";
    case MFNS_CALTABLE_E_FILE_TOO_BIG: return "calibration table file larger than the load buffer";
    case MFNS_CALTABLE_E_VERSION_OLD: return "calibration table format is older than this loader supports: rebuild it with mfns table build";
    case MFNS_CALTABLE_E_INDEX_COUNT: return "calibration table map index: beacon count differs from the map or neighbour capacity out of range";
    case MFNS_CALTABLE_E_INDEX_POLICY: return "calibration table map index: certificate, missing-beacon allowance or work budget out of range";
    case MFNS_CALTABLE_E_INDEX_WORKSPACE: return "calibration table map index: workspace box empty";
    case MFNS_CALTABLE_E_INDEX_GEOMETRY: return "calibration table map index: beacon emission cone or range interval invalid";
    case MFNS_CALTABLE_E_INDEX_NEIGHBOUR: return "calibration table map index: bad neighbour list (count, index, self or repeated)";
    case MFNS_CALTABLE_E_INDEX_PAIR: return "calibration table map index: pair angle interval reversed";
    default: break;
    }
    return "calibration table: unknown status";
}

/* ---- little-endian readers; the caller has checked the bounds. */
static uint16_t rd_u16(const uint8_t *b, uint32_t o) { return (uint16_t)(b[o] | (uint16_t)(b[o + 1] << 8)); }

static uint32_t rd_u32(const uint8_t *b, uint32_t o)
{
    return (uint32_t)b[o] | ((uint32_t)b[o + 1] << 8) | ((uint32_t)b[o + 2] << 16) | ((uint32_t)b[o + 3] << 24);
}

static int32_t rd_i32(const uint8_t *b, uint32_t o)
{
    const uint32_t u = rd_u32(b, o);
    int32_t i;
    memcpy(&i, &u, sizeof i); /* two's complement reinterpretation, no implementation-defined cast */
    return i;
}

static float rd_f32(const uint8_t *b, uint32_t o)
{
    const uint32_t u = rd_u32(b, o);
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

/* Parsing state: the first failure sticks (status and offset). */
typedef struct {
    const uint8_t *b;
    uint32_t size;
    mfns_caltable_status_t st;
    uint32_t err_off;
} parser_t;

static bool fail(parser_t *p, mfns_caltable_status_t st, uint32_t off)
{
    if (p->st == MFNS_CALTABLE_OK) {
        p->st = st;
        p->err_off = off;
    }
    return false;
}

/* A finite float at offset o (else E_NOT_FINITE). */
static bool f32_at(parser_t *p, uint32_t o, float *out)
{
    const float f = rd_f32(p->b, o);
    if (!isfinite(f)) {
        return fail(p, MFNS_CALTABLE_E_NOT_FINITE, o);
    }
    *out = f;
    return true;
}

static bool in_range(float v, float lo_excl, float hi_incl) { return v > lo_excl && v <= hi_incl; }

#define G_COUNTS 16u
#define G_SIGMA 20u
#define G_CENTROID 24u
#define G_SOLVER 44u
#define G_CAMERAS 76u

static bool parse_globals(parser_t *p, uint16_t *ncam, uint16_t *nbeacon, float *sigma,
                          mfns_centroid_settings_t *c, mfns_solver_settings_t *s)
{
    const uint8_t *b = p->b;
    *ncam = rd_u16(b, G_COUNTS);
    *nbeacon = rd_u16(b, G_COUNTS + 2);
    if (*ncam != MFNS_NUM_CAMERAS) {
        return fail(p, MFNS_CALTABLE_E_CAMERA_COUNT, G_COUNTS);
    }
    if (*nbeacon == 0 || *nbeacon > MFNS_MAX_BEACONS) {
        return fail(p, MFNS_CALTABLE_E_BEACON_COUNT, G_COUNTS + 2);
    }
    if (!f32_at(p, G_SIGMA, sigma)) {
        return false;
    }
    if (!in_range(*sigma, 0.0f, 10.0f)) {
        return fail(p, MFNS_CALTABLE_E_PIXEL_SIGMA, G_SIGMA);
    }

    const uint32_t o = G_CENTROID;
    c->threshold_dn = rd_u16(b, o);
    c->min_area_px = rd_u16(b, o + 2);
    c->max_area_px = rd_u16(b, o + 4);
    c->roi_half_size_px = rd_u16(b, o + 6);
    c->saturation_dn = rd_u16(b, o + 8);
    c->gain_dn_per_e_q12 = rd_u16(b, o + 10); /* any value: 0 = no shot-noise term */
    if (!f32_at(p, o + 12, &c->threshold_k_sigma) || !f32_at(p, o + 16, &c->max_elongation)) {
        return false;
    }
    if (!(c->threshold_k_sigma >= 0.0f && c->threshold_k_sigma <= 100.0f)) {
        return fail(p, MFNS_CALTABLE_E_CENTROID_SETTINGS, o + 12);
    }
    if (c->threshold_dn == 0 && !(c->threshold_k_sigma > 0.0f)) {
        return fail(p, MFNS_CALTABLE_E_CENTROID_SETTINGS, o + 12); /* no threshold rule at all */
    }
    if (c->min_area_px == 0) {
        return fail(p, MFNS_CALTABLE_E_CENTROID_SETTINGS, o + 2);
    }
    if (c->max_area_px < c->min_area_px) {
        return fail(p, MFNS_CALTABLE_E_CENTROID_SETTINGS, o + 4);
    }
    if (c->roi_half_size_px == 0) {
        return fail(p, MFNS_CALTABLE_E_CENTROID_SETTINGS, o + 6);
    }
    if (!(c->max_elongation >= 1.0f && c->max_elongation <= 100.0f)) {
        return fail(p, MFNS_CALTABLE_E_CENTROID_SETTINGS, o + 16);
    }

    const uint32_t q = G_SOLVER;
    s->max_iterations = rd_u16(b, q);
    if (s->max_iterations == 0 || s->max_iterations > 1000) {
        return fail(p, MFNS_CALTABLE_E_SOLVER_SETTINGS, q);
    }
    if (rd_u16(b, q + 2) != 0) {
        return fail(p, MFNS_CALTABLE_E_RESERVED, q + 2); /* version 1's max_hypotheses */
    }
    float *const f[7] = {&s->step_tol,           &s->grad_tol,      &s->huber_k,  &s->outlier_gate_sigma,
                         &s->max_residual_rms_px, &s->track_gate_px, &s->min_rcond};
    /* ranges are (lo, hi]: tolerances below 1, gains and gates positive and bounded */
    static const float lo[7] = {0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f};
    static const float hi[7] = {1.0f, 1.0f, 1000.0f, 100000.0f, 1000.0f, 4096.0f, 0.999f};
    for (uint32_t i = 0; i < 7u; i++) {
        if (!f32_at(p, q + 4 + 4 * i, f[i])) {
            return false;
        }
        if (!in_range(*f[i], lo[i], hi[i])) {
            return fail(p, MFNS_CALTABLE_E_SOLVER_SETTINGS, q + 4 + 4 * i);
        }
    }
    return true;
}

/* Every grid node, re-distorted with the camera's own model, must land on its
 * pixel: this catches grids built for another lens, swapped axes, and
 * corrupted values that a valid CRC would still carry (a wrong source). */
static bool check_grid_values(parser_t *p, const mfns_intrinsics_t *k, const mfns_undist_grid_t *g,
                              uint32_t nodes_off)
{
    const q16_16_t cxq = mfns_q16_from_float(k->cx), cyq = mfns_q16_from_float(k->cy);
    for (uint32_t j = 0; j < g->ny; j++) {
        for (uint32_t i = 0; i < g->nx; i++) {
            const uint32_t o = nodes_off + (j * g->nx + i) * MFNS_CALTABLE_NODE_SIZE;
            const int32_t uq = rd_i32(p->b, o), vq = rd_i32(p->b, o + 4);
            const float du = (float)((int64_t)uq - cxq) * (1.0f / 65536.0f);
            const float dv = (float)((int64_t)vq - cyq) * (1.0f / 65536.0f);
            const float y = dv / k->fy;
            const float x = (du - k->skew * y) / k->fx;
            float xd, yd, u, v;
            mfns_cam_distort(k, x, y, &xd, &yd, NULL);
            mfns_cam_distorted_to_pixel(k, xd, yd, &u, &v);
            const float eu = (float)((double)u - ((double)g->origin_u_q8 + (double)i * (double)g->step_u_q8) / 256.0);
            const float ev = (float)((double)v - ((double)g->origin_v_q8 + (double)j * (double)g->step_v_q8) / 256.0);
            if (!(fabsf(eu) <= MFNS_CALTABLE_GRID_TOL_PX && fabsf(ev) <= MFNS_CALTABLE_GRID_TOL_PX)) {
                return fail(p, MFNS_CALTABLE_E_GRID_VALUES, o);
            }
        }
    }
    return true;
}

/* One camera record at *pos. On success advances *pos; when dst_nodes is not
 * NULL copies the nodes there (cam and g are always filled). */
static bool parse_camera(parser_t *p, uint32_t *pos, uint16_t index, mfns_camera_t *cam, mfns_undist_grid_t *g,
                         q16_16_t (*dst_nodes)[2])
{
    const uint8_t *b = p->b;
    const uint32_t o = *pos;
    if (p->size - o < MFNS_CALTABLE_CAMERA_FIXED_SIZE) {
        return fail(p, MFNS_CALTABLE_E_SIZE_MISMATCH, o);
    }
    if (rd_u16(b, o) != index) {
        return fail(p, MFNS_CALTABLE_E_CAMERA_ID, o);
    }
    mfns_intrinsics_t *k = &cam->k;
    k->width = rd_u16(b, o + 2);
    k->height = rd_u16(b, o + 4);
    if (rd_u16(b, o + 6) != 0) {
        return fail(p, MFNS_CALTABLE_E_RESERVED, o + 6);
    }
    if (k->width == 0 || k->height == 0) {
        return fail(p, MFNS_CALTABLE_E_IMAGE_SIZE, o + 2);
    }
    /* every float of the record first, so NaN has one status wherever it is */
    float v[22];
    for (uint32_t i = 0; i < 22u; i++) {
        if (!f32_at(p, o + 8 + 4 * i, &v[i])) {
            return false;
        }
    }
    k->fx = v[0];
    k->fy = v[1];
    k->cx = v[2];
    k->cy = v[3];
    k->skew = v[4];
    for (int i = 0; i < 5; i++) {
        k->dist[i] = v[5 + i];
    }
    for (int r = 0; r < 3; r++) {
        for (int c = 0; c < 3; c++) {
            cam->C_k_b.m[r][c] = v[10 + 3 * r + c];
        }
    }
    cam->r_bk_b = mfns_v3(v[19], v[20], v[21]);
    if (!in_range(k->fx, 0.0f, 1e6f)) {
        return fail(p, MFNS_CALTABLE_E_FOCAL, o + 8);
    }
    if (!in_range(k->fy, 0.0f, 1e6f)) {
        return fail(p, MFNS_CALTABLE_E_FOCAL, o + 12);
    }
    if (!(k->cx >= -0.5f && k->cx <= (float)k->width - 0.5f)) {
        return fail(p, MFNS_CALTABLE_E_PRINCIPAL_POINT, o + 16);
    }
    if (!(k->cy >= -0.5f && k->cy <= (float)k->height - 0.5f)) {
        return fail(p, MFNS_CALTABLE_E_PRINCIPAL_POINT, o + 20);
    }
    if (!(fabsf(k->skew) <= k->fx)) {
        return fail(p, MFNS_CALTABLE_E_LENS, o + 24);
    }
    for (uint32_t i = 0; i < 5u; i++) {
        if (!(fabsf(k->dist[i]) <= 1000.0f)) {
            return fail(p, MFNS_CALTABLE_E_LENS, o + 28 + 4 * i);
        }
    }
    if (!mfns_m3_is_rotation(cam->C_k_b, MFNS_CALTABLE_ROT_TOL)) {
        return fail(p, MFNS_CALTABLE_E_ROTATION, o + 48);
    }
    for (uint32_t i = 0; i < 3u; i++) {
        if (!(fabsf(v[19 + i]) <= 10000.0f)) {
            return fail(p, MFNS_CALTABLE_E_EXTRINSICS, o + 84 + 4 * i);
        }
    }
    g->nx = rd_u16(b, o + 96);
    g->ny = rd_u16(b, o + 98);
    g->origin_u_q8 = rd_i32(b, o + 100);
    g->origin_v_q8 = rd_i32(b, o + 104);
    g->step_u_q8 = rd_i32(b, o + 108);
    g->step_v_q8 = rd_i32(b, o + 112);
    const uint32_t nodes = (uint32_t)g->nx * g->ny;
    if (g->nx < 2 || g->ny < 2 || nodes > MFNS_MAX_GRID_NODES) {
        return fail(p, MFNS_CALTABLE_E_GRID_DIMS, o + 96);
    }
    const uint32_t nodes_off = o + MFNS_CALTABLE_CAMERA_FIXED_SIZE;
    if ((p->size - nodes_off) / MFNS_CALTABLE_NODE_SIZE < nodes) {
        return fail(p, MFNS_CALTABLE_E_SIZE_MISMATCH, o + 96);
    }
    if (g->step_u_q8 < MFNS_UNDIST_GRID_MIN_STEP_Q8 || g->step_u_q8 > MFNS_UNDIST_GRID_MAX_STEP_Q8) {
        return fail(p, MFNS_CALTABLE_E_GRID_STEP, o + 108);
    }
    if (g->step_v_q8 < MFNS_UNDIST_GRID_MIN_STEP_Q8 || g->step_v_q8 > MFNS_UNDIST_GRID_MAX_STEP_Q8) {
        return fail(p, MFNS_CALTABLE_E_GRID_STEP, o + 112);
    }
    /* the nodes must span [-0.5, W-0.5] x [-0.5, H-0.5] (q8: -128 .. 256 W - 128) */
    const int64_t end_u = (int64_t)g->origin_u_q8 + (int64_t)(g->nx - 1) * g->step_u_q8;
    const int64_t end_v = (int64_t)g->origin_v_q8 + (int64_t)(g->ny - 1) * g->step_v_q8;
    if (g->origin_u_q8 > -128 || end_u < 256 * (int64_t)k->width - 128) {
        return fail(p, MFNS_CALTABLE_E_GRID_COVERAGE, o + 100);
    }
    if (g->origin_v_q8 > -128 || end_v < 256 * (int64_t)k->height - 128) {
        return fail(p, MFNS_CALTABLE_E_GRID_COVERAGE, o + 104);
    }
    if (!check_grid_values(p, k, g, nodes_off)) {
        return false;
    }
    if (dst_nodes != NULL) {
        for (uint32_t n = 0; n < nodes; n++) {
            dst_nodes[n][0] = rd_i32(b, nodes_off + n * MFNS_CALTABLE_NODE_SIZE);
            dst_nodes[n][1] = rd_i32(b, nodes_off + n * MFNS_CALTABLE_NODE_SIZE + 4);
        }
    }
    g->node = (const q16_16_t(*)[2])dst_nodes;
    *pos = nodes_off + nodes * MFNS_CALTABLE_NODE_SIZE;
    return true;
}

static bool parse_beacons(parser_t *p, uint32_t pos, uint16_t n, mfns_beacon_map_t *dst)
{
    const uint8_t *b = p->b;
    if ((p->size - pos) / MFNS_CALTABLE_BEACON_SIZE < n) {
        return fail(p, MFNS_CALTABLE_E_SIZE_MISMATCH, pos);
    }
    for (uint32_t i = 0; i < n; i++) {
        const uint32_t o = pos + i * MFNS_CALTABLE_BEACON_SIZE;
        mfns_beacon_t bc;
        bc.id = rd_u16(b, o);
        if (rd_u16(b, o + 2) != 0) {
            return fail(p, MFNS_CALTABLE_E_RESERVED, o + 2);
        }
        if (!f32_at(p, o + 4, &bc.p_w.x) || !f32_at(p, o + 8, &bc.p_w.y) || !f32_at(p, o + 12, &bc.p_w.z) ||
            !f32_at(p, o + 16, &bc.sigma_mm)) {
            return false;
        }
        if (!(fabsf(bc.p_w.x) <= 1e7f && fabsf(bc.p_w.y) <= 1e7f && fabsf(bc.p_w.z) <= 1e7f)) {
            return fail(p, MFNS_CALTABLE_E_BEACON_VALUE, o + 4);
        }
        if (!in_range(bc.sigma_mm, 0.0f, 10000.0f)) {
            return fail(p, MFNS_CALTABLE_E_BEACON_VALUE, o + 16);
        }
        for (uint32_t j = 0; j < i; j++) {
            if (rd_u16(b, pos + j * MFNS_CALTABLE_BEACON_SIZE) == bc.id) {
                return fail(p, MFNS_CALTABLE_E_BEACON_DUPLICATE, o);
            }
        }
        if (dst != NULL) {
            dst->beacon[i] = bc;
        }
    }
    if (dst != NULL) {
        dst->count = n;
    }
    return true;
}

/* The map-index section at pos (beacon_index.h; docs/caltable.md "Map
 * index"), which must end exactly at total_size. */
static bool parse_index(parser_t *p, uint32_t pos, uint16_t nbeacon, mfns_beacon_index_t *dst)
{
    const uint8_t *b = p->b;
    if (p->size - pos < MFNS_BIDX_HEADER_SIZE) {
        return fail(p, MFNS_CALTABLE_E_SIZE_MISMATCH, pos);
    }
    const uint16_t n = rd_u16(b, pos);
    const uint8_t k = b[pos + 2u], miss = b[pos + 3u], unexpl = b[pos + 4u];
    if (n != nbeacon) {
        return fail(p, MFNS_CALTABLE_E_INDEX_COUNT, pos);
    }
    if (k == 0 || k > MFNS_BIDX_MAX_NBR) {
        return fail(p, MFNS_CALTABLE_E_INDEX_COUNT, pos + 2u);
    }
    if (miss > MFNS_BIDX_MAX_MISSING) {
        return fail(p, MFNS_CALTABLE_E_INDEX_POLICY, pos + 3u);
    }
    if (unexpl > MFNS_BIDX_MAX_CERT) {
        return fail(p, MFNS_CALTABLE_E_INDEX_POLICY, pos + 4u);
    }
    if (b[pos + 5u] != 0) {
        return fail(p, MFNS_CALTABLE_E_RESERVED, pos + 5u);
    }
    /* the certificate: 4..16 inliers per allowed missing count, not fewer for
     * more missing beacons; 0 beyond the allowance */
    for (uint32_t m = 0; m <= MFNS_BIDX_MAX_MISSING; m++) {
        const uint8_t c = b[pos + 40u + m];
        const bool ok = m <= miss ? (c >= MFNS_BIDX_MIN_CERT && c <= MFNS_BIDX_MAX_CERT &&
                                     (m == 0 || c >= b[pos + 40u + m - 1u]))
                                  : c == 0;
        if (!ok) {
            return fail(p, MFNS_CALTABLE_E_INDEX_POLICY, pos + 40u + m);
        }
    }
    const uint32_t budget = rd_u32(b, pos + 8u);
    if (budget == 0) {
        return fail(p, MFNS_CALTABLE_E_INDEX_POLICY, pos + 8u);
    }
    float ws[6];
    for (uint32_t i = 0; i < 6u; i++) {
        if (!f32_at(p, pos + 12u + 4u * i, &ws[i])) {
            return false;
        }
    }
    for (uint32_t i = 0; i < 3u; i++) {
        if (!(ws[i] < ws[3 + i]) || !(fabsf(ws[i]) <= 1e7f) || !(fabsf(ws[3 + i]) <= 1e7f)) {
            return fail(p, MFNS_CALTABLE_E_INDEX_WORKSPACE, pos + 12u + 4u * i);
        }
    }
    if (p->size - pos != MFNS_BIDX_SECTION_SIZE(n, k)) {
        return fail(p, MFNS_CALTABLE_E_SIZE_MISMATCH, pos);
    }
    uint32_t o = pos + MFNS_BIDX_HEADER_SIZE;
    for (uint32_t i = 0; i < n; i++, o += MFNS_BIDX_GEOM_SIZE) {
        float g[6];
        for (uint32_t j = 0; j < 6u; j++) {
            if (!f32_at(p, o + 4u * j, &g[j])) {
                return false;
            }
        }
        const float an = sqrtf(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
        if (!(an == 0.0f || fabsf(an - 1.0f) <= 1e-3f)) {
            return fail(p, MFNS_CALTABLE_E_INDEX_GEOMETRY, o);
        }
        if (!(g[3] >= -1.0f && g[3] <= 1.0f)) {
            return fail(p, MFNS_CALTABLE_E_INDEX_GEOMETRY, o + 12u);
        }
        if (!(g[4] > 0.0f && g[4] < g[5] && g[5] <= 1e8f)) {
            return fail(p, MFNS_CALTABLE_E_INDEX_GEOMETRY, o + 16u);
        }
        if (dst != NULL) {
            mfns_beacon_geom_t *d = &dst->geom[i];
            d->emit.axis_w = mfns_v3(g[0], g[1], g[2]);
            d->emit.cos_half_angle = g[3];
            d->range_min_mm = g[4];
            d->range_max_mm = g[5];
        }
    }
    for (uint32_t i = 0; i < n; i++, o += 1u + k) {
        const uint8_t cnt = b[o];
        if (cnt > k) {
            return fail(p, MFNS_CALTABLE_E_INDEX_NEIGHBOUR, o);
        }
        for (uint32_t r = 0; r < k; r++) {
            const uint8_t e = b[o + 1u + r];
            bool bad = r < cnt ? (e >= n || e == i) : e != 0; /* unused entries are 0 */
            for (uint32_t q = 0; q < r && r < cnt && !bad; q++) {
                bad = b[o + 1u + q] == e;
            }
            if (bad) {
                return fail(p, MFNS_CALTABLE_E_INDEX_NEIGHBOUR, o + 1u + r);
            }
            if (dst != NULL && r < cnt) {
                dst->nbr[i][r] = e;
            }
        }
        if (dst != NULL) {
            dst->nbr_count[i] = cnt;
        }
    }
    const uint32_t pairs = (uint32_t)n * (n - 1u) / 2u;
    for (uint32_t s = 0; s < pairs; s++, o += 2u) {
        const uint8_t lo = b[o], hi = b[o + 1u];
        /* an interval, or the empty one (never seen together) */
        if (lo > hi && !(lo == MFNS_BIDX_ANGLE_CODES && hi == 0)) {
            return fail(p, MFNS_CALTABLE_E_INDEX_PAIR, o);
        }
        if (dst != NULL) {
            dst->pair_lo[s] = lo;
            dst->pair_hi[s] = hi;
        }
    }
    if (dst != NULL) {
        dst->count = n;
        dst->k_nbr = k;
        for (uint32_t m = 0; m <= MFNS_BIDX_MAX_MISSING; m++) {
            dst->cert_inliers[m] = b[pos + 40u + m];
        }
        dst->max_missing = miss;
        dst->max_unexplained = unexpl;
        dst->analysis_max_rival = rd_u16(b, pos + 6u);
        dst->budget_units = budget;
        dst->ws_min_w = mfns_v3(ws[0], ws[1], ws[2]);
        dst->ws_max_w = mfns_v3(ws[3], ws[4], ws[5]);
        dst->analysis_samples = rd_u32(b, pos + 36u);
    }
    return true;
}

/* The whole body after the header checks. dst == NULL: validate only. */
static bool parse_body(parser_t *p, mfns_caltable_t *dst)
{
    uint16_t ncam, nbeacon;
    float sigma;
    mfns_centroid_settings_t cs;
    mfns_solver_settings_t ss;
    if (!parse_globals(p, &ncam, &nbeacon, &sigma, &cs, &ss)) {
        return false;
    }
    uint32_t pos = G_CAMERAS;
    for (uint16_t k = 0; k < MFNS_NUM_CAMERAS; k++) {
        mfns_camera_t cam;
        mfns_undist_grid_t g;
        if (!parse_camera(p, &pos, k, &cam, &g, dst != NULL ? dst->grid_node[k] : NULL)) {
            return false;
        }
        if (dst != NULL) {
            dst->rig.cam[k] = cam;
            dst->grid[k] = g;
        }
    }
    if (!parse_beacons(p, pos, nbeacon, dst != NULL ? &dst->beacons : NULL)) {
        return false;
    }
    if (!parse_index(p, pos + (uint32_t)nbeacon * MFNS_CALTABLE_BEACON_SIZE, nbeacon,
                     dst != NULL ? &dst->index : NULL)) {
        return false;
    }
    if (dst != NULL) {
        dst->centroid = cs;
        dst->solver = ss;
        dst->pixel_sigma_px = sigma;
    }
    return true;
}

mfns_caltable_status_t mfns_caltable_load(const uint8_t *buf, size_t len, mfns_caltable_t *out,
                                          uint32_t *err_offset)
{
    parser_t p = {buf, 0, MFNS_CALTABLE_OK, 0};
    if (buf == NULL || out == NULL) {
        (void)fail(&p, MFNS_CALTABLE_E_ARG, 0);
    } else if (len < MFNS_CALTABLE_HEADER_SIZE) {
        (void)fail(&p, MFNS_CALTABLE_E_TRUNCATED, (uint32_t)len);
    } else if (memcmp(buf, MFNS_CALTABLE_MAGIC, 4) != 0) {
        (void)fail(&p, MFNS_CALTABLE_E_MAGIC, 0);
    } else if (rd_u16(buf, 4) == 0) {
        (void)fail(&p, MFNS_CALTABLE_E_VERSION_BAD, 4);
    } else if (rd_u16(buf, 4) > MFNS_CALTABLE_VERSION) {
        (void)fail(&p, MFNS_CALTABLE_E_VERSION_NEWER, 4);
    } else if (rd_u16(buf, 4) < MFNS_CALTABLE_MIN_VERSION) {
        (void)fail(&p, MFNS_CALTABLE_E_VERSION_OLD, 4);
    } else if (rd_u16(buf, 6) != MFNS_CALTABLE_HEADER_SIZE) {
        (void)fail(&p, MFNS_CALTABLE_E_HEADER_SIZE, 6);
    } else {
        const uint32_t total = rd_u32(buf, 8);
        if (total < MFNS_CALTABLE_HEADER_SIZE + MFNS_CALTABLE_GLOBALS_SIZE || total > MFNS_CALTABLE_MAX_BYTES) {
            (void)fail(&p, MFNS_CALTABLE_E_SIZE, 8);
        } else if (total > len) {
            (void)fail(&p, MFNS_CALTABLE_E_TRUNCATED, (uint32_t)(len < UINT32_MAX ? len : UINT32_MAX));
        } else if (mfns_crc32(0, buf + MFNS_CALTABLE_HEADER_SIZE, total - MFNS_CALTABLE_HEADER_SIZE) !=
                   rd_u32(buf, 12)) {
            (void)fail(&p, MFNS_CALTABLE_E_CRC, 12);
        } else {
            p.size = total;
            /* validate everything first; write only a table known to be good */
            if (parse_body(&p, NULL)) {
                if (!parse_body(&p, out)) {
                    memset(out, 0, sizeof *out); /* unreachable: same checks as the first pass */
                } else {
                    out->format_version = rd_u16(buf, 4);
                    out->size_bytes = total;
                    out->crc32 = rd_u32(buf, 12);
                }
            }
        }
    }
    if (p.st != MFNS_CALTABLE_OK && err_offset != NULL) {
        *err_offset = p.err_off;
    }
    return p.st;
}
