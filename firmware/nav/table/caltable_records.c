/* caltable_records.c -- the loader's fixed records (caltable_internal.h):
 * globals (counts, pixel sigma, centroid and solver settings), the camera
 * records with their correction grids, the beacon records. Offsets and ranges
 * are the generated ones (caltable_layout_gen.h); the order of the checks is
 * the loader's contract (the first failure is the one reported). */
#include <math.h>

#include "firmware/nav/table/caltable_internal.h"

/* Field offsets and range ids, shorter. */
#define G_OFF(f) (MFNS_CALTABLE_HEADER_SIZE + MFNS_CALTABLE_OFF_GLOBALS_##f)
#define G_ID(f) MFNS_CALTABLE_F_GLOBALS_##f
#define C_OFF(f) MFNS_CALTABLE_OFF_CAMERA_##f
#define C_ID(f) MFNS_CALTABLE_F_CAMERA_##f
#define B_OFF(f) MFNS_CALTABLE_OFF_BEACON_##f
#define B_ID(f) MFNS_CALTABLE_F_BEACON_##f

/* The runs read or checked in one call: exactly these fields (a range added
 * to a field between two of them would join the run and must be looked at). */
_Static_assert(G_ID(PIXEL_SIGMA_PX) == G_ID(CAMERA_COUNT) + 2, "globals: the two counts, the pixel sigma");
_Static_assert(G_ID(SOLVER_MIN_RCOND) == G_ID(SOLVER_MAX_ITERATIONS) + 8, "globals: the solver's 9 fields");
_Static_assert(G_OFF(CENTROID_MAX_ELONGATION) == G_OFF(CENTROID_THRESHOLD_K_SIGMA) + 4u, "globals: centroid floats");
_Static_assert(B_OFF(SIGMA_MM) == B_OFF(P_W) + 12u, "beacon: p_w then sigma_mm, 4 floats");
_Static_assert(C_ID(FY) == C_ID(FX) + 1 && C_ID(GRID_STEP_V_Q8) == C_ID(GRID_STEP_U_Q8) + 1, "camera: pairs");

static bool in_range(mfns_caltable_field_id_t id, float v) { return mfns_caltable_in_range(&mfns_caltable_fields[id], v); }

bool mfns_ct_parse_globals(mfns_ct_parser_t *p, uint16_t *nbeacon, float *sigma, mfns_centroid_settings_t *c,
                           mfns_solver_settings_t *s)
{
    const uint8_t *b = p->b;
    const uint32_t g = MFNS_CALTABLE_HEADER_SIZE; /* the globals follow the header */
    float v[G_ID(PIXEL_SIGMA_PX) - G_ID(CAMERA_COUNT) + 1]; /* camera count, beacon count, pixel sigma */
    if (!mfns_ct_fields(p, g, G_ID(CAMERA_COUNT), G_ID(PIXEL_SIGMA_PX), v)) {
        return false;
    }
    *nbeacon = mfns_ct_u16(b, G_OFF(BEACON_COUNT));
    *sigma = v[G_ID(PIXEL_SIGMA_PX) - G_ID(CAMERA_COUNT)];

    c->threshold_dn = mfns_ct_u16(b, G_OFF(CENTROID_THRESHOLD_DN));
    c->min_area_px = mfns_ct_u16(b, G_OFF(CENTROID_MIN_AREA_PX));
    c->max_area_px = mfns_ct_u16(b, G_OFF(CENTROID_MAX_AREA_PX));
    c->roi_half_size_px = mfns_ct_u16(b, G_OFF(CENTROID_ROI_HALF_SIZE_PX));
    c->saturation_dn = mfns_ct_u16(b, G_OFF(CENTROID_SATURATION_DN));
    c->gain_dn_per_e_q12 = mfns_ct_u16(b, G_OFF(CENTROID_GAIN_DN_PER_E_Q12)); /* any value: 0 = no shot-noise term */
    float kv[2]; /* threshold_k_sigma, max_elongation: both finite before any range */
    if (!mfns_ct_f32s(p, G_OFF(CENTROID_THRESHOLD_K_SIGMA), 2u, kv)) {
        return false;
    }
    c->threshold_k_sigma = kv[0];
    c->max_elongation = kv[1];
    if (!mfns_ct_field(p, g, G_ID(CENTROID_THRESHOLD_K_SIGMA))) {
        return false;
    }
    if (c->threshold_dn == 0 && !(c->threshold_k_sigma > 0.0f)) {
        /* no threshold rule at all */
        return mfns_ct_fail(p, MFNS_CALTABLE_E_CENTROID_SETTINGS, G_OFF(CENTROID_THRESHOLD_K_SIGMA));
    }
    if (!mfns_ct_field(p, g, G_ID(CENTROID_MIN_AREA_PX))) {
        return false;
    }
    if (c->max_area_px < c->min_area_px) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_CENTROID_SETTINGS, G_OFF(CENTROID_MAX_AREA_PX));
    }
    if (!mfns_ct_field(p, g, G_ID(CENTROID_ROI_HALF_SIZE_PX)) ||
        !mfns_ct_field(p, g, G_ID(CENTROID_MAX_ELONGATION))) {
        return false;
    }

    /* max_iterations, the reserved u16 (version 1's max_hypotheses), then the floats */
    float sv[G_ID(SOLVER_MIN_RCOND) - G_ID(SOLVER_MAX_ITERATIONS) + 1];
    if (!mfns_ct_fields(p, g, G_ID(SOLVER_MAX_ITERATIONS), G_ID(SOLVER_MIN_RCOND), sv)) {
        return false;
    }
#define SV(f) sv[G_ID(SOLVER_##f) - G_ID(SOLVER_MAX_ITERATIONS)]
    s->max_iterations = mfns_ct_u16(b, G_OFF(SOLVER_MAX_ITERATIONS));
    s->step_tol = SV(STEP_TOL);
    s->grad_tol = SV(GRAD_TOL);
    s->huber_k = SV(HUBER_K);
    s->outlier_gate_sigma = SV(OUTLIER_GATE_SIGMA);
    s->max_residual_rms_sigma = SV(MAX_RESIDUAL_RMS_SIGMA);
    s->track_gate_px = SV(TRACK_GATE_PX);
    s->min_rcond = SV(MIN_RCOND);
#undef SV
    return true;
}

/* Every grid node, re-distorted with the camera's own model, must land on its
 * pixel: this catches grids built for another lens, swapped axes, and
 * corrupted values that a valid CRC would still carry (a wrong source). */
static bool check_grid_values(mfns_ct_parser_t *p, const mfns_intrinsics_t *k, const mfns_undist_grid_t *g,
                              uint32_t nodes_off)
{
    const q16_16_t cxq = mfns_q16_from_float(k->cx), cyq = mfns_q16_from_float(k->cy);
    for (uint32_t j = 0; j < g->ny; j++) {
        for (uint32_t i = 0; i < g->nx; i++) {
            const uint32_t o = nodes_off + (j * g->nx + i) * MFNS_CALTABLE_NODE_SIZE;
            const int32_t uq = mfns_ct_i32(p->b, o + MFNS_CALTABLE_OFF_NODE_U_Q16);
            const int32_t vq = mfns_ct_i32(p->b, o + MFNS_CALTABLE_OFF_NODE_V_Q16);
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
                return mfns_ct_fail(p, MFNS_CALTABLE_E_GRID_VALUES, o);
            }
        }
    }
    return true;
}

/* The camera record's floats, fx .. r_bk_b[2], all read (and checked finite)
 * first; CV(f) is field f's first value among them. */
#define CAM_FLOATS ((C_OFF(GRID_NX) - C_OFF(FX)) / 4u)
_Static_assert(CAM_FLOATS == 22u, "camera record: fx .. r_bk_b are 22 consecutive floats");
#define CV(f) ((C_OFF(f) - C_OFF(FX)) / 4u)

/* The intrinsics, extrinsics and grid header of the record at o. */
static bool camera_values(mfns_ct_parser_t *p, uint32_t o, mfns_camera_t *cam)
{
    mfns_intrinsics_t *k = &cam->k;
    /* every float of the record first, so NaN has one status wherever it is */
    float v[CAM_FLOATS];
    if (!mfns_ct_f32s(p, o + C_OFF(FX), CAM_FLOATS, v)) {
        return false;
    }
    k->fx = v[CV(FX)];
    k->fy = v[CV(FY)];
    k->cx = v[CV(CX)];
    k->cy = v[CV(CY)];
    k->skew = v[CV(SKEW)];
    for (uint32_t i = 0; i < 5u; i++) {
        k->dist[i] = v[CV(DIST) + i];
    }
    for (uint32_t r = 0; r < 3u; r++) {
        for (uint32_t c = 0; c < 3u; c++) {
            cam->C_k_b.m[r][c] = v[CV(C_K_B) + 3u * r + c];
        }
    }
    cam->r_bk_b = mfns_v3(v[CV(R_BK_B)], v[CV(R_BK_B) + 1u], v[CV(R_BK_B) + 2u]);
    if (!mfns_ct_fields(p, o, C_ID(FX), C_ID(FY), NULL)) {
        return false;
    }
    if (!(k->cx >= -0.5f && k->cx <= (float)k->width - 0.5f)) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_PRINCIPAL_POINT, o + C_OFF(CX));
    }
    if (!(k->cy >= -0.5f && k->cy <= (float)k->height - 0.5f)) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_PRINCIPAL_POINT, o + C_OFF(CY));
    }
    if (!(fabsf(k->skew) <= k->fx)) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_LENS, o + C_OFF(SKEW));
    }
    for (uint32_t i = 0; i < 5u; i++) {
        if (!mfns_ct_field(p, o + 4u * i, C_ID(DIST))) {
            return false;
        }
    }
    if (!mfns_m3_is_rotation_at(&cam->C_k_b, MFNS_CALTABLE_ROT_TOL)) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_ROTATION, o + C_OFF(C_K_B));
    }
    for (uint32_t i = 0; i < 3u; i++) {
        if (!mfns_ct_field(p, o + 4u * i, C_ID(R_BK_B))) {
            return false;
        }
    }
    return true;
}

bool mfns_ct_parse_camera(mfns_ct_parser_t *p, uint32_t *pos, uint16_t index, mfns_camera_t *cam,
                          mfns_undist_grid_t *g, q16_16_t (*dst_nodes)[2])
{
    const uint8_t *b = p->b;
    const uint32_t o = *pos;
    if (p->size - o < MFNS_CALTABLE_CAMERA_FIXED_SIZE) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_SIZE_MISMATCH, o);
    }
    if (mfns_ct_u16(b, o + C_OFF(CAMERA_ID)) != index) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_CAMERA_ID, o + C_OFF(CAMERA_ID));
    }
    mfns_intrinsics_t *k = &cam->k;
    k->width = mfns_ct_u16(b, o + C_OFF(WIDTH));
    k->height = mfns_ct_u16(b, o + C_OFF(HEIGHT));
    if (!mfns_ct_field(p, o, C_ID(RESERVED))) {
        return false;
    }
    if (!in_range(C_ID(WIDTH), (float)k->width) || !in_range(C_ID(HEIGHT), (float)k->height)) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_IMAGE_SIZE, o + C_OFF(WIDTH));
    }
    if (!camera_values(p, o, cam)) {
        return false;
    }
    g->nx = mfns_ct_u16(b, o + C_OFF(GRID_NX));
    g->ny = mfns_ct_u16(b, o + C_OFF(GRID_NY));
    g->origin_u_q8 = mfns_ct_i32(b, o + C_OFF(GRID_ORIGIN_U_Q8));
    g->origin_v_q8 = mfns_ct_i32(b, o + C_OFF(GRID_ORIGIN_V_Q8));
    g->step_u_q8 = mfns_ct_i32(b, o + C_OFF(GRID_STEP_U_Q8));
    g->step_v_q8 = mfns_ct_i32(b, o + C_OFF(GRID_STEP_V_Q8));
    const uint32_t nodes = (uint32_t)g->nx * g->ny;
    if (!in_range(C_ID(GRID_NX), (float)g->nx) || !in_range(C_ID(GRID_NY), (float)g->ny) ||
        nodes > MFNS_MAX_GRID_NODES) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_GRID_DIMS, o + C_OFF(GRID_NX));
    }
    const uint32_t nodes_off = o + MFNS_CALTABLE_CAMERA_FIXED_SIZE;
    if ((p->size - nodes_off) / MFNS_CALTABLE_NODE_SIZE < nodes) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_SIZE_MISMATCH, o + C_OFF(GRID_NX));
    }
    if (!mfns_ct_fields(p, o, C_ID(GRID_STEP_U_Q8), C_ID(GRID_STEP_V_Q8), NULL)) {
        return false;
    }
    /* the nodes must span [-0.5, W-0.5] x [-0.5, H-0.5] (q8: -128 .. 256 W - 128) */
    const int64_t end_u = (int64_t)g->origin_u_q8 + (int64_t)(g->nx - 1) * g->step_u_q8;
    const int64_t end_v = (int64_t)g->origin_v_q8 + (int64_t)(g->ny - 1) * g->step_v_q8;
    if (!in_range(C_ID(GRID_ORIGIN_U_Q8), (float)g->origin_u_q8) || end_u < 256 * (int64_t)k->width - 128) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_GRID_COVERAGE, o + C_OFF(GRID_ORIGIN_U_Q8));
    }
    if (!in_range(C_ID(GRID_ORIGIN_V_Q8), (float)g->origin_v_q8) || end_v < 256 * (int64_t)k->height - 128) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_GRID_COVERAGE, o + C_OFF(GRID_ORIGIN_V_Q8));
    }
    if (!check_grid_values(p, k, g, nodes_off)) {
        return false;
    }
    if (dst_nodes != NULL) {
        for (uint32_t n = 0; n < nodes; n++) {
            const uint32_t at = nodes_off + n * MFNS_CALTABLE_NODE_SIZE;
            dst_nodes[n][0] = mfns_ct_i32(b, at + MFNS_CALTABLE_OFF_NODE_U_Q16);
            dst_nodes[n][1] = mfns_ct_i32(b, at + MFNS_CALTABLE_OFF_NODE_V_Q16);
        }
    }
    g->node = (const q16_16_t(*)[2])dst_nodes;
    *pos = nodes_off + nodes * MFNS_CALTABLE_NODE_SIZE;
    return true;
}

bool mfns_ct_parse_beacons(mfns_ct_parser_t *p, uint32_t pos, uint16_t n, mfns_beacon_map_t *dst)
{
    const uint8_t *b = p->b;
    if ((p->size - pos) / MFNS_CALTABLE_BEACON_SIZE < n) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_SIZE_MISMATCH, pos);
    }
    for (uint32_t i = 0; i < n; i++) {
        const uint32_t o = pos + i * MFNS_CALTABLE_BEACON_SIZE;
        mfns_beacon_t bc;
        bc.id = mfns_ct_u16(b, o + B_OFF(ID));
        if (!mfns_ct_field(p, o, B_ID(RESERVED))) {
            return false;
        }
        float v[4]; /* p_w, sigma_mm */
        if (!mfns_ct_f32s(p, o + B_OFF(P_W), 4u, v)) {
            return false;
        }
        bc.p_w = mfns_v3(v[0], v[1], v[2]);
        bc.sigma_mm = v[3];
        if (!in_range(B_ID(P_W), bc.p_w.x) || !in_range(B_ID(P_W), bc.p_w.y) || !in_range(B_ID(P_W), bc.p_w.z)) {
            return mfns_ct_fail(p, MFNS_CALTABLE_E_BEACON_VALUE, o + B_OFF(P_W));
        }
        if (!mfns_ct_field(p, o, B_ID(SIGMA_MM))) {
            return false;
        }
        for (uint32_t j = 0; j < i; j++) {
            if (mfns_ct_u16(b, pos + j * MFNS_CALTABLE_BEACON_SIZE + B_OFF(ID)) == bc.id) {
                return mfns_ct_fail(p, MFNS_CALTABLE_E_BEACON_DUPLICATE, o + B_OFF(ID));
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
