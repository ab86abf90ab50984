/* beacon_index_build.c -- the ground side of beacon_index.h: the offline
 * build of the map index (`mfns table build`, through the shared library)
 * and its serialisation into the table section. Bounded loops, no heap.
 * Host-only (firmware/host): the flight image only looks the index up
 * (firmware/nav/map/beacon_index.c). */
#include <math.h>
#include <string.h>

#include "firmware/host/beacon_index_build.h"
#include "math/undistort.h"
#include "math/units.h"

#define FACE_GRID 16u       /* samples per side of each face of the camera-centre box */
#define VOLUME_GRID 6u      /* samples per axis inside it (emission-cone tests only) */
#define POLISH_ITERS 40u    /* pattern-search steps per extreme */
#define EMIT_UNIT_TOL 1e-3f

uint32_t mfns_bidx_section_size(uint32_t n, uint32_t k) { return MFNS_BIDX_SECTION_SIZE(n, k); }

/* The undistorted ray of a pixel of camera k (camera frame, unit). */
static bool pixel_ray(const mfns_intrinsics_t *k, float u, float v, mfns_v3_t *ray)
{
    float x, y;
    int it;
    if (mfns_undistort_iter(k, u, v, MFNS_UNDIST_DEFAULT_ITER, &x, &y, &it) != MFNS_UNDIST_OK) {
        return false;
    }
    return mfns_v3_normalize(mfns_v3(x, y, 1.0f), ray);
}

float mfns_bidx_rig_fov_diag_rad(const mfns_rig_t *rig)
{
    float widest = 0.0f;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        const mfns_intrinsics_t *k = &rig->cam[c].k;
        const float w = (float)k->width - 0.5f, h = (float)k->height - 0.5f;
        mfns_v3_t r[4];
        const float corner[4][2] = {{-0.5f, -0.5f}, {w, h}, {w, -0.5f}, {-0.5f, h}};
        bool ok = true;
        for (int i = 0; i < 4; i++) {
            ok = ok && pixel_ray(k, corner[i][0], corner[i][1], &r[i]);
        }
        if (!ok) {
            return MFNS_PI_F; /* a lens the inverse cannot follow to the corners: no FOV pruning */
        }
        for (int i = 0; i < 4; i += 2) {
            const float cs = fmaxf(-1.0f, fminf(1.0f, mfns_v3_dot(r[i], r[i + 1])));
            widest = fmaxf(widest, acosf(cs));
        }
    }
    return widest;
}

static float clampf(float v, float lo, float hi) { return v < lo ? lo : (v > hi ? hi : v); }

/* Cosine of the angle that a and b subtend at x (1 when x is on a beacon). */
static float subtended_cos(mfns_v3_t a, mfns_v3_t b, mfns_v3_t x)
{
    const mfns_v3_t va = mfns_v3_sub(a, x), vb = mfns_v3_sub(b, x);
    const float na = mfns_v3_norm(va), nb = mfns_v3_norm(vb);
    if (na <= 0.0f || nb <= 0.0f) {
        return 1.0f;
    }
    return clampf(mfns_v3_dot(va, vb) / (na * nb), -1.0f, 1.0f);
}

typedef struct {
    mfns_v3_t lo, hi;
} box_t;

/* Point of face f (0..5: axis f/2, side f%2) at face coordinates (s, t) in [0, 1]. */
static mfns_v3_t face_point(const box_t *bx, uint32_t f, float s, float t)
{
    const float lo[3] = {bx->lo.x, bx->lo.y, bx->lo.z}, hi[3] = {bx->hi.x, bx->hi.y, bx->hi.z};
    float p[3];
    const uint32_t ax = f / 2u, u = (ax + 1u) % 3u, v = (ax + 2u) % 3u;
    p[ax] = (f % 2u) != 0u ? hi[ax] : lo[ax];
    p[u] = lo[u] + s * (hi[u] - lo[u]);
    p[v] = lo[v] + t * (hi[v] - lo[v]);
    return mfns_v3(p[0], p[1], p[2]);
}

/* Does the ray o + t d, t in [t0, t1], meet the box? (slab test) */
static bool segment_meets_box(const box_t *bx, mfns_v3_t o, mfns_v3_t d, float t0, float t1)
{
    const float oo[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z};
    const float lo[3] = {bx->lo.x, bx->lo.y, bx->lo.z}, hi[3] = {bx->hi.x, bx->hi.y, bx->hi.z};
    for (int i = 0; i < 3; i++) {
        if (fabsf(dd[i]) < 1e-12f) {
            if (oo[i] < lo[i] || oo[i] > hi[i]) {
                return false;
            }
            continue;
        }
        float ta = (lo[i] - oo[i]) / dd[i], tb = (hi[i] - oo[i]) / dd[i];
        if (ta > tb) {
            const float x = ta;
            ta = tb;
            tb = x;
        }
        t0 = fmaxf(t0, ta);
        t1 = fminf(t1, tb);
        if (t0 > t1) {
            return false;
        }
    }
    return true;
}

/* Extreme (sign +1: largest cosine = smallest angle; -1: smallest cosine)
 * of the subtended cosine over the box faces: face grid, then a bounded
 * pattern search from the best sample. */
static float face_extreme(const box_t *bx, mfns_v3_t a, mfns_v3_t b, float sign)
{
    float best = -2.0f;
    uint32_t bf = 0;
    float bs = 0.0f, bt = 0.0f;
    const float step0 = 1.0f / (float)(FACE_GRID - 1u);
    for (uint32_t f = 0; f < 6u; f++) {
        for (uint32_t i = 0; i < FACE_GRID; i++) {
            for (uint32_t j = 0; j < FACE_GRID; j++) {
                const float s = (float)i * step0, t = (float)j * step0;
                const float v = sign * subtended_cos(a, b, face_point(bx, f, s, t));
                if (v > best) {
                    best = v;
                    bf = f;
                    bs = s;
                    bt = t;
                }
            }
        }
    }
    float step = step0;
    for (uint32_t it = 0; it < POLISH_ITERS && step > 1e-4f; it++) {
        bool moved = false;
        static const float dirs[4][2] = {{1.0f, 0.0f}, {-1.0f, 0.0f}, {0.0f, 1.0f}, {0.0f, -1.0f}};
        for (int d = 0; d < 4; d++) {
            const float s = clampf(bs + dirs[d][0] * step, 0.0f, 1.0f), t = clampf(bt + dirs[d][1] * step, 0.0f, 1.0f);
            const float v = sign * subtended_cos(a, b, face_point(bx, bf, s, t));
            if (v > best) {
                best = v;
                bs = s;
                bt = t;
                moved = true;
            }
        }
        if (!moved) {
            step *= 0.5f;
        }
    }
    return sign * best;
}

/* Some sample point of the box from which both beacons emit toward it? */
static bool covisible(const box_t *bx, const mfns_beacon_geom_t *ga, mfns_v3_t a, const mfns_beacon_geom_t *gb,
                      mfns_v3_t b)
{
    if (mfns_v3_norm(ga->emit.axis_w) == 0.0f && mfns_v3_norm(gb->emit.axis_w) == 0.0f) {
        return true;
    }
    const float st = 1.0f / (float)(VOLUME_GRID - 1u);
    for (uint32_t i = 0; i < VOLUME_GRID; i++) {
        for (uint32_t j = 0; j < VOLUME_GRID; j++) {
            for (uint32_t k = 0; k < VOLUME_GRID; k++) {
                const mfns_v3_t x = mfns_v3(bx->lo.x + (float)i * st * (bx->hi.x - bx->lo.x),
                                            bx->lo.y + (float)j * st * (bx->hi.y - bx->lo.y),
                                            bx->lo.z + (float)k * st * (bx->hi.z - bx->lo.z));
                if (mfns_bidx_emits_toward(ga, a, x) && mfns_bidx_emits_toward(gb, b, x)) {
                    return true;
                }
            }
        }
    }
    return false;
}

static uint8_t angle_code_floor(float rad)
{
    const float q = floorf(rad / MFNS_BIDX_ANGLE_LSB_RAD);
    return (uint8_t)clampf(q, 0.0f, (float)MFNS_BIDX_ANGLE_CODES);
}

static uint8_t angle_code_ceil(float rad)
{
    const float q = ceilf(rad / MFNS_BIDX_ANGLE_LSB_RAD);
    return (uint8_t)clampf(q, 0.0f, (float)MFNS_BIDX_ANGLE_CODES);
}

static bool valid_emit(const mfns_beacon_emit_t *e)
{
    const float n = mfns_v3_norm(e->axis_w);
    return isfinite(n) && (n == 0.0f || fabsf(n - 1.0f) <= EMIT_UNIT_TOL) && e->cos_half_angle >= -1.0f &&
           e->cos_half_angle <= 1.0f;
}

static void pair_interval(const box_t *bx, mfns_v3_t a, mfns_v3_t b, float *lo_rad, float *hi_rad)
{
    const mfns_v3_t d = mfns_v3_sub(b, a);
    /* on the segment the angle is pi; on the line beyond either end it is 0 */
    *hi_rad = segment_meets_box(bx, a, d, 0.0f, 1.0f) ? MFNS_PI_F : acosf(face_extreme(bx, a, b, -1.0f));
    const bool beyond = segment_meets_box(bx, b, d, 0.0f, 1e30f) ||
                        segment_meets_box(bx, a, mfns_v3_scale(d, -1.0f), 0.0f, 1e30f);
    *lo_rad = beyond ? 0.0f : acosf(face_extreme(bx, a, b, 1.0f));
}

mfns_bidx_status_t mfns_bidx_build(const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                   const mfns_beacon_emit_t *emit, mfns_v3_t ws_min_w, mfns_v3_t ws_max_w,
                                   const mfns_bidx_params_t *par, mfns_beacon_index_t *out)
{
    if (rig == NULL || map == NULL || par == NULL || out == NULL || map->count == 0 ||
        map->count > MFNS_MAX_BEACONS || par->k_nbr == 0 || par->k_nbr > MFNS_BIDX_MAX_NBR ||
        par->cert_inliers < MFNS_BIDX_MIN_CERT || par->cert_inliers > MFNS_BIDX_MAX_CERT || par->budget_units == 0 ||
        par->max_missing > MFNS_BIDX_MAX_MISSING || par->max_unexplained > MFNS_BIDX_MAX_CERT) {
        return MFNS_BIDX_E_ARG;
    }
    const float wmin[3] = {ws_min_w.x, ws_min_w.y, ws_min_w.z}, wmax[3] = {ws_max_w.x, ws_max_w.y, ws_max_w.z};
    for (int i = 0; i < 3; i++) {
        if (!isfinite(wmin[i]) || !isfinite(wmax[i]) || !(wmin[i] < wmax[i])) {
            return MFNS_BIDX_E_WORKSPACE;
        }
    }
    if (emit != NULL) {
        for (uint32_t i = 0; i < map->count; i++) {
            if (!valid_emit(&emit[i])) {
                return MFNS_BIDX_E_EMIT;
            }
        }
    }
    memset(out, 0, sizeof *out);
    const uint32_t n = map->count;
    out->count = map->count;
    out->k_nbr = par->k_nbr;
    for (uint32_t m = 0; m <= par->max_missing; m++) {
        out->cert_inliers[m] = par->cert_inliers;
    }
    out->max_missing = par->max_missing;
    out->max_unexplained = par->max_unexplained;
    out->budget_units = par->budget_units;
    out->ws_min_w = ws_min_w;
    out->ws_max_w = ws_max_w;

    /* camera centres: the workspace grown by the largest camera offset */
    float grow = 0.0f;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        grow = fmaxf(grow, mfns_v3_norm(rig->cam[c].r_bk_b));
    }
    const box_t bx = {mfns_v3(wmin[0] - grow, wmin[1] - grow, wmin[2] - grow),
                      mfns_v3(wmax[0] + grow, wmax[1] + grow, wmax[2] + grow)};
    for (uint32_t i = 0; i < n; i++) {
        mfns_beacon_geom_t *g = &out->geom[i];
        if (emit != NULL) {
            g->emit = emit[i];
        } else {
            g->emit.axis_w = mfns_v3(0.0f, 0.0f, 0.0f);
            g->emit.cos_half_angle = -1.0f;
        }
        const mfns_v3_t p = map->beacon[i].p_w;
        const mfns_v3_t near = mfns_v3(clampf(p.x, bx.lo.x, bx.hi.x), clampf(p.y, bx.lo.y, bx.hi.y),
                                       clampf(p.z, bx.lo.z, bx.hi.z));
        const mfns_v3_t far = mfns_v3(fabsf(p.x - bx.lo.x) > fabsf(p.x - bx.hi.x) ? bx.lo.x : bx.hi.x,
                                      fabsf(p.y - bx.lo.y) > fabsf(p.y - bx.hi.y) ? bx.lo.y : bx.hi.y,
                                      fabsf(p.z - bx.lo.z) > fabsf(p.z - bx.hi.z) ? bx.lo.z : bx.hi.z);
        g->range_min_mm = fmaxf(mfns_v3_norm(mfns_v3_sub(p, near)), MFNS_CAM_MIN_DEPTH_MM);
        g->range_max_mm = fmaxf(mfns_v3_norm(mfns_v3_sub(p, far)), g->range_min_mm + 1.0f);
    }
    for (uint32_t a = 0; a + 1u < n; a++) {
        for (uint32_t b = a + 1u; b < n; b++) {
            const uint32_t s = mfns_bidx_pair_slot(n, a, b);
            const mfns_v3_t pa = map->beacon[a].p_w, pb = map->beacon[b].p_w;
            if (!covisible(&bx, &out->geom[a], pa, &out->geom[b], pb)) {
                out->pair_lo[s] = (uint8_t)MFNS_BIDX_ANGLE_CODES; /* empty: never seen together */
                out->pair_hi[s] = 0;
                continue;
            }
            float lo, hi;
            pair_interval(&bx, pa, pb, &lo, &hi);
            out->pair_lo[s] = angle_code_floor(lo - MFNS_BIDX_ANGLE_PAD_RAD);
            out->pair_hi[s] = angle_code_ceil(hi + MFNS_BIDX_ANGLE_PAD_RAD);
        }
    }
    /* neighbour lists: co-visible in one image, nearest first (selection:
     * k passes over n candidates) */
    const float fov = mfns_bidx_rig_fov_diag_rad(rig) + MFNS_BIDX_ANGLE_PAD_RAD;
    for (uint32_t a = 0; a < n; a++) {
        float last = -1.0f;
        uint32_t last_b = 0;
        uint8_t cnt = 0;
        for (uint32_t r = 0; r < out->k_nbr; r++) {
            float best = INFINITY;
            int32_t bb = -1;
            for (uint32_t b = 0; b < n; b++) {
                if (b == a) {
                    continue;
                }
                const uint32_t s = mfns_bidx_pair_slot(n, a, b);
                if (out->pair_lo[s] > out->pair_hi[s] || (float)out->pair_lo[s] * MFNS_BIDX_ANGLE_LSB_RAD > fov) {
                    continue;
                }
                const float d = mfns_v3_norm(mfns_v3_sub(map->beacon[a].p_w, map->beacon[b].p_w));
                /* strictly after the last one taken, ties broken by index */
                const bool after = d > last || (d == last && b > last_b);
                if (after && (d < best || (d == best && (int32_t)b < bb))) {
                    best = d;
                    bb = (int32_t)b;
                }
            }
            if (bb < 0) {
                break;
            }
            out->nbr[a][cnt++] = (uint8_t)bb;
            last = best;
            last_b = (uint32_t)bb;
        }
        out->nbr_count[a] = cnt;
    }
    return MFNS_BIDX_OK;
}

static void wr_u16(uint8_t *b, uint32_t o, uint16_t v)
{
    b[o] = (uint8_t)(v & 0xFFu);
    b[o + 1u] = (uint8_t)(v >> 8);
}

static void wr_u32(uint8_t *b, uint32_t o, uint32_t v)
{
    for (uint32_t i = 0; i < 4u; i++) {
        b[o + i] = (uint8_t)((v >> (8u * i)) & 0xFFu);
    }
}

static void wr_f32(uint8_t *b, uint32_t o, float f)
{
    uint32_t v;
    memcpy(&v, &f, sizeof v);
    wr_u32(b, o, v);
}

mfns_bidx_status_t mfns_bidx_encode(const mfns_beacon_index_t *idx, uint8_t *buf, uint32_t cap, uint32_t *written)
{
    if (idx == NULL || buf == NULL || written == NULL || idx->count == 0 || idx->count > MFNS_MAX_BEACONS ||
        idx->k_nbr == 0 || idx->k_nbr > MFNS_BIDX_MAX_NBR) {
        return MFNS_BIDX_E_ARG;
    }
    const uint32_t n = idx->count, k = idx->k_nbr;
    const uint32_t size = MFNS_BIDX_SECTION_SIZE(n, k);
    if (cap < size) {
        return MFNS_BIDX_E_SPACE;
    }
    memset(buf, 0, size);
    wr_u16(buf, 0, idx->count);
    buf[2] = idx->k_nbr;
    buf[3] = idx->max_missing;
    buf[4] = idx->max_unexplained;
    buf[5] = 0; /* reserved */
    wr_u16(buf, 6, idx->analysis_max_rival);
    wr_u32(buf, 8, idx->budget_units);
    wr_f32(buf, 12, idx->ws_min_w.x);
    wr_f32(buf, 16, idx->ws_min_w.y);
    wr_f32(buf, 20, idx->ws_min_w.z);
    wr_f32(buf, 24, idx->ws_max_w.x);
    wr_f32(buf, 28, idx->ws_max_w.y);
    wr_f32(buf, 32, idx->ws_max_w.z);
    wr_u32(buf, 36, idx->analysis_samples);
    for (uint32_t m = 0; m <= MFNS_BIDX_MAX_MISSING; m++) {
        buf[40u + m] = idx->cert_inliers[m];
    }
    uint32_t o = MFNS_BIDX_HEADER_SIZE;
    for (uint32_t i = 0; i < n; i++, o += MFNS_BIDX_GEOM_SIZE) {
        const mfns_beacon_geom_t *g = &idx->geom[i];
        wr_f32(buf, o, g->emit.axis_w.x);
        wr_f32(buf, o + 4u, g->emit.axis_w.y);
        wr_f32(buf, o + 8u, g->emit.axis_w.z);
        wr_f32(buf, o + 12u, g->emit.cos_half_angle);
        wr_f32(buf, o + 16u, g->range_min_mm);
        wr_f32(buf, o + 20u, g->range_max_mm);
    }
    for (uint32_t i = 0; i < n; i++, o += 1u + k) {
        buf[o] = idx->nbr_count[i];
        for (uint32_t r = 0; r < idx->nbr_count[i] && r < k; r++) {
            buf[o + 1u + r] = idx->nbr[i][r];
        }
    }
    const uint32_t pairs = n * (n - 1u) / 2u;
    for (uint32_t s = 0; s < pairs; s++, o += 2u) {
        buf[o] = idx->pair_lo[s];
        buf[o + 1u] = idx->pair_hi[s];
    }
    *written = o;
    return MFNS_BIDX_OK;
}
