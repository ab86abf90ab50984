/* caltable_sections.c -- the loader's variable sections (caltable_internal.h):
 * the calibration covariance, the map datum, the integrity settings and the map index. Offsets and ranges are the
 * generated ones (caltable_layout_gen.h); the order of the checks is the
 * loader's contract (the first failure is the one reported). */
#include <math.h>

#include "firmware/nav/table/caltable_internal.h"

#define I_OFF(f) MFNS_CALTABLE_OFF_INTEGRITY_##f
#define I_ID(f) MFNS_CALTABLE_F_INTEGRITY_##f
#define M_OFF(f) MFNS_CALTABLE_OFF_MOTION_##f
#define M_ID(f) MFNS_CALTABLE_F_MOTION_##f
#define X_OFF(f) MFNS_CALTABLE_OFF_INDEX_##f
#define X_ID(f) MFNS_CALTABLE_F_INDEX_##f
#define XG_OFF(f) MFNS_CALTABLE_OFF_INDEX_GEOM_##f

/* The covariance sections (docs/caltable.md "Calibration covariance", "Map
 * datum covariance"): a count, then the upper triangle row-major of an n x n
 * covariance as f32. Accepted: every value finite and the matrix positive
 * semi-definite, tested on its correlation form (unit diagonal: the units differ
 * by 1e10) by a Cholesky factorisation that takes pivots below
 * MFNS_CALTABLE_COV_PSD_TOL as zero and refuses one below
 * -MFNS_CALTABLE_COV_PSD_TOL. The factor is a packed triangle on the stack (4.1 KB
 * at the calibration's 45 parameters, the largest). */
#define CALIB_TRI ((uint32_t)MFNS_CALIB_PARAMS * (MFNS_CALIB_PARAMS + 1u) / 2u)
#define DATUM_TRI ((uint32_t)MFNS_MAP_DATUM_PARAMS * (MFNS_MAP_DATUM_PARAMS + 1u) / 2u)
_Static_assert(CALIB_TRI * sizeof(float) < 4200u, "the packed factor stays a 4.1 KB stack array");
_Static_assert(MFNS_MAP_DATUM_PARAMS <= MFNS_CALIB_PARAMS, "the datum's factor fits the calibration's arrays");

static uint32_t tri_upper(uint32_t n, uint32_t i, uint32_t j) /* (i, j), i <= j, in a stored upper triangle */
{
    return i * n - i * (i - 1u) / 2u + (j - i);
}

/* The correlation form of the n x n covariance stored at body, lower triangle
 * packed by rows (l[i (i + 1) / 2 + j]), factorised in place; false (status
 * st) at the first element that makes it not positive semi-definite. */
static bool check_psd(mfns_ct_parser_t *p, uint32_t body, uint32_t n, mfns_caltable_status_t st)
{
    const uint8_t *b = p->b;
    float sd[MFNS_CALIB_PARAMS];
    for (uint32_t i = 0; i < n; i++) {
        const float d = mfns_ct_f32(b, body + 4u * tri_upper(n, i, i));
        if (!(d >= 0.0f)) {
            return mfns_ct_fail(p, st, body + 4u * tri_upper(n, i, i));
        }
        sd[i] = sqrtf(d);
    }
    float l[CALIB_TRI];
    for (uint32_t i = 0; i < n; i++) {
        for (uint32_t j = 0; j <= i; j++) {
            const uint32_t off = body + 4u * tri_upper(n, j, i);
            const float s = mfns_ct_f32(b, off);
            float c;
            if (sd[i] > 0.0f && sd[j] > 0.0f) {
                c = s / (sd[i] * sd[j]);
            } else if (s == 0.0f) {
                c = 0.0f; /* a parameter known exactly: no correlation */
            } else {
                return mfns_ct_fail(p, st, off);
            }
            l[i * (i + 1u) / 2u + j] = c;
        }
    }
    for (uint32_t i = 0; i < n; i++) {
        for (uint32_t j = 0; j <= i; j++) {
            float s = l[i * (i + 1u) / 2u + j];
            for (uint32_t k = 0; k < j; k++) {
                s -= l[i * (i + 1u) / 2u + k] * l[j * (j + 1u) / 2u + k];
            }
            if (i == j) {
                if (s < -MFNS_CALTABLE_COV_PSD_TOL) {
                    return mfns_ct_fail(p, st, body + 4u * tri_upper(n, i, i));
                }
                l[i * (i + 1u) / 2u + i] = s > MFNS_CALTABLE_COV_PSD_TOL ? sqrtf(s) : 0.0f;
            } else {
                const float ljj = l[j * (j + 1u) / 2u + j];
                if (ljj > 0.0f) {
                    l[i * (i + 1u) / 2u + j] = s / ljj;
                } else if (fabsf(s) <= sqrtf(MFNS_CALTABLE_COV_PSD_TOL)) {
                    l[i * (i + 1u) / 2u + j] = 0.0f; /* a null direction stays null */
                } else {
                    return mfns_ct_fail(p, st, body + 4u * tri_upper(n, j, i));
                }
            }
        }
    }
    return true;
}

/* The n x n matrix of the checked triangle at body into dst (symmetric). */
static void read_tri(const uint8_t *b, uint32_t body, uint32_t n, float *dst)
{
    for (uint32_t i = 0; i < n; i++) {
        for (uint32_t j = i; j < n; j++) {
            const float v = mfns_ct_f32(b, body + 4u * tri_upper(n, i, j));
            dst[i * n + j] = v;
            dst[j * n + i] = v;
        }
    }
}

bool mfns_ct_parse_calib_cov(mfns_ct_parser_t *p, uint32_t *pos, mfns_calib_cov_t *dst)
{
    const uint8_t *b = p->b;
    const uint32_t o = *pos;
    if (p->size - o < MFNS_CALTABLE_COV_HEADER_SIZE) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_SIZE_MISMATCH, o);
    }
    const uint16_t n = mfns_ct_u16(b, o + MFNS_CALTABLE_OFF_CALIB_COV_COUNT);
    if (n != 0u && n != MFNS_CALIB_PARAMS) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_CALIB_COV_COUNT, o + MFNS_CALTABLE_OFF_CALIB_COV_COUNT);
    }
    if (!mfns_ct_field(p, o, MFNS_CALTABLE_F_CALIB_COV_RESERVED)) {
        return false;
    }
    const uint32_t body = o + MFNS_CALTABLE_COV_HEADER_SIZE;
    if (n == 0u) {
        if (dst != NULL) {
            memset(dst, 0, sizeof *dst);
        }
        *pos = body;
        return true;
    }
    if ((p->size - body) / 4u < CALIB_TRI) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_SIZE_MISMATCH, o);
    }
    if (!mfns_ct_f32s(p, body, CALIB_TRI, NULL) ||
        !check_psd(p, body, MFNS_CALIB_PARAMS, MFNS_CALTABLE_E_CALIB_COV_PSD)) {
        return false;
    }
    if (dst != NULL) {
        dst->present = 1u;
        read_tri(b, body, MFNS_CALIB_PARAMS, &dst->cov[0][0]);
    }
    *pos = body + 4u * CALIB_TRI;
    return true;
}

bool mfns_ct_parse_map_datum(mfns_ct_parser_t *p, uint32_t *pos, mfns_map_datum_t *dst)
{
    enum {
        COUNT = MFNS_CALTABLE_OFF_MAP_DATUM_COUNT,
        CW = MFNS_CALTABLE_OFF_MAP_DATUM_C_W,
    };
    const uint8_t *b = p->b;
    const uint32_t o = *pos;
    if (p->size - o < MFNS_CALTABLE_DATUM_HEADER_SIZE) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_SIZE_MISMATCH, o);
    }
    const uint16_t n = mfns_ct_u16(b, o + COUNT);
    if (n != 0u && n != MFNS_MAP_DATUM_PARAMS) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_MAP_DATUM_COUNT, o + COUNT);
    }
    if (!mfns_ct_field(p, o, MFNS_CALTABLE_F_MAP_DATUM_RESERVED)) {
        return false;
    }
    float c[3];
    if (!mfns_ct_f32s(p, o + CW, 3u, c)) {
        return false;
    }
    for (int i = 0; i < 3; i++) {
        /* the generated range, per coordinate; no datum names no centre */
        if (!mfns_caltable_in_range(&mfns_caltable_fields[MFNS_CALTABLE_F_MAP_DATUM_C_W], c[i]) ||
            (n == 0u && c[i] != 0.0f)) {
            return mfns_ct_fail(p, MFNS_CALTABLE_E_MAP_DATUM_CENTRE, o + CW + 4u * (uint32_t)i);
        }
    }
    const uint32_t body = o + MFNS_CALTABLE_DATUM_HEADER_SIZE;
    if (n == 0u) {
        if (dst != NULL) {
            memset(dst, 0, sizeof *dst);
        }
        *pos = body;
        return true;
    }
    if ((p->size - body) / 4u < DATUM_TRI) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_SIZE_MISMATCH, o);
    }
    if (!mfns_ct_f32s(p, body, DATUM_TRI, NULL) ||
        !check_psd(p, body, MFNS_MAP_DATUM_PARAMS, MFNS_CALTABLE_E_MAP_DATUM_PSD)) {
        return false;
    }
    if (dst != NULL) {
        dst->present = 1u;
        dst->c_w = mfns_v3(c[0], c[1], c[2]);
        read_tri(b, body, MFNS_MAP_DATUM_PARAMS, &dst->cov[0][0]);
    }
    *pos = body + 4u * DATUM_TRI;
    return true;
}

/* The map index's header at pos: counts, policy, certificate, budget and
 * workspace (ws receives min x y z, max x y z). */
static bool index_header(mfns_ct_parser_t *p, uint32_t pos, uint16_t nbeacon, float ws[6])
{
    const uint8_t *b = p->b;
    const uint8_t miss = b[pos + X_OFF(MAX_MISSING)];
    if (mfns_ct_u16(b, pos + X_OFF(BEACONS)) != nbeacon) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_INDEX_COUNT, pos + X_OFF(BEACONS));
    }
    /* k_nbr, max_missing, max_unexplained, reserved */
    if (!mfns_ct_fields(p, pos, X_ID(K_NBR), X_ID(RESERVED), NULL)) {
        return false;
    }
    /* the certificate: 4..16 inliers per allowed missing count, not fewer for
     * more missing beacons; 0 beyond the allowance */
    const uint32_t cert = pos + X_OFF(CERT_INLIERS);
    for (uint32_t m = 0; m <= MFNS_BIDX_MAX_MISSING; m++) {
        const uint8_t c = b[cert + m];
        const bool ok = m <= miss ? (c >= MFNS_BIDX_MIN_CERT && c <= MFNS_BIDX_MAX_CERT &&
                                     (m == 0 || c >= b[cert + m - 1u]))
                                  : c == 0;
        if (!ok) {
            return mfns_ct_fail(p, MFNS_CALTABLE_E_INDEX_POLICY, cert + m);
        }
    }
    if (!mfns_ct_field(p, pos, X_ID(BUDGET_UNITS))) {
        return false;
    }
    if (!mfns_ct_f32s(p, pos + X_OFF(WS_MIN_W), 6u, ws)) {
        return false;
    }
    for (uint32_t i = 0; i < 3u; i++) {
        if (!(ws[i] < ws[3 + i]) || !mfns_caltable_in_range(&mfns_caltable_fields[X_ID(WS_MIN_W)], ws[i]) ||
            !mfns_caltable_in_range(&mfns_caltable_fields[X_ID(WS_MAX_W)], ws[3 + i])) {
            return mfns_ct_fail(p, MFNS_CALTABLE_E_INDEX_WORKSPACE, pos + X_OFF(WS_MIN_W) + 4u * i);
        }
    }
    return true;
}
_Static_assert(MFNS_CALTABLE_OFF_INDEX_WS_MAX_W == MFNS_CALTABLE_OFF_INDEX_WS_MIN_W + 12u, "workspace: 6 floats");


/* The integrity settings at *pos (docs/caltable.md "Integrity settings"): four
 * f32 (alert limits, P_fa, P_md), u16 hold, u8 require_camera_monitor, u8
 * monitor_only; each in its generated range (status INTEGRITY_SETTINGS).
 * Advances *pos past the section. */
bool mfns_ct_parse_integrity(mfns_ct_parser_t *p, uint32_t *pos, mfns_integrity_settings_t *dst)
{
    const uint8_t *b = p->b;
    const uint32_t o = *pos;
    if (p->size - o < MFNS_CALTABLE_INTEGRITY_SIZE) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_SIZE_MISMATCH, o);
    }
    float v[I_ID(MONITOR_ONLY) - I_ID(ALERT_LIMIT_POS_MM) + 1]; /* the record's fields in order */
    if (!mfns_ct_fields(p, o, I_ID(ALERT_LIMIT_POS_MM), I_ID(MONITOR_ONLY), v)) {
        return false;
    }
    if (dst != NULL) {
        dst->alert_limit_pos_mm = v[0];
        dst->alert_limit_att_deg = v[1];
        dst->p_fa = v[2];
        dst->p_md = v[3];
        dst->hold_cycles = mfns_ct_u16(b, o + I_OFF(HOLD_CYCLES));
        dst->require_camera_monitor = b[o + I_OFF(REQUIRE_CAMERA_MONITOR)];
        dst->monitor_only = b[o + I_OFF(MONITOR_ONLY)];
    }
    *pos = o + MFNS_CALTABLE_INTEGRITY_SIZE;
    return true;
}

/* The motion bound at *pos (docs/caltable.md "Motion bound"): five f32, the
 * u16 reject run, the reserved u16, two f32; each in its generated range
 * (status MOTION_SETTINGS), and by hand max_coast_s <= bound_time_s (beyond T
 * the bound's bias outgrows the process noise: nav_filter.h). Advances *pos
 * past the section. */
bool mfns_ct_parse_motion(mfns_ct_parser_t *p, uint32_t *pos, mfns_filter_settings_t *dst)
{
    const uint32_t o = *pos;
    if (p->size - o < MFNS_CALTABLE_MOTION_SIZE) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_SIZE_MISMATCH, o);
    }
    float v[M_ID(AUG_DT_S) - M_ID(ACCEL_BOUND_MM_S2) + 1]; /* the record's fields in order */
    if (!mfns_ct_fields(p, o, M_ID(ACCEL_BOUND_MM_S2), M_ID(AUG_DT_S), v)) {
        return false;
    }
    enum { A = 0, ALPHA, T, COAST, GATE, RUN, RESERVED, ROT, DT };
    _Static_assert(M_ID(AUG_DT_S) - M_ID(ACCEL_BOUND_MM_S2) == DT && M_ID(RESERVED) - M_ID(ACCEL_BOUND_MM_S2) == RESERVED,
                   "the motion bound's fields in the order read here");
    if (!(v[COAST] <= v[T])) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_MOTION_SETTINGS, o + M_OFF(MAX_COAST_S));
    }
    if (dst != NULL) {
        dst->accel_bound_mm_s2 = v[A];
        dst->alpha_bound_rad_s2 = v[ALPHA];
        dst->bound_time_s = v[T];
        dst->max_coast_s = v[COAST];
        dst->gate_p = v[GATE];
        dst->gate_reject_run = mfns_ct_u16(p->b, o + M_OFF(GATE_REJECT_RUN));
        dst->aug_rot_rad = v[ROT];
        dst->aug_dt_s = v[DT];
    }
    *pos = o + MFNS_CALTABLE_MOTION_SIZE;
    return true;
}

/* The map-index section at pos (beacon_index.h; docs/caltable.md "Map
 * index"), which must end exactly at total_size. */
bool mfns_ct_parse_index(mfns_ct_parser_t *p, uint32_t pos, uint16_t nbeacon, mfns_beacon_index_t *dst)
{
    const uint8_t *b = p->b;
    if (p->size - pos < MFNS_CALTABLE_INDEX_HEADER_SIZE) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_SIZE_MISMATCH, pos);
    }
    float ws[6];
    if (!index_header(p, pos, nbeacon, ws)) {
        return false;
    }
    const uint16_t n = nbeacon;
    const uint8_t k = b[pos + X_OFF(K_NBR)];
    if (p->size - pos != MFNS_BIDX_SECTION_SIZE(n, k)) {
        return mfns_ct_fail(p, MFNS_CALTABLE_E_SIZE_MISMATCH, pos);
    }
    uint32_t o = pos + MFNS_CALTABLE_INDEX_HEADER_SIZE;
    for (uint32_t i = 0; i < n; i++, o += MFNS_CALTABLE_INDEX_GEOM_SIZE) {
        float g[6];
        if (!mfns_ct_f32s(p, o, 6u, g)) {
            return false;
        }
        const float an = sqrtf(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
        if (!(an == 0.0f || fabsf(an - 1.0f) <= 1e-3f)) {
            return mfns_ct_fail(p, MFNS_CALTABLE_E_INDEX_GEOMETRY, o + XG_OFF(AXIS_W));
        }
        if (!mfns_ct_field(p, o, MFNS_CALTABLE_F_INDEX_GEOM_COS_HALF_ANGLE)) {
            return false;
        }
        if (!(mfns_caltable_in_range(&mfns_caltable_fields[MFNS_CALTABLE_F_INDEX_GEOM_RANGE_MIN_MM], g[4]) &&
              g[4] < g[5] && mfns_caltable_in_range(&mfns_caltable_fields[MFNS_CALTABLE_F_INDEX_GEOM_RANGE_MAX_MM], g[5]))) {
            return mfns_ct_fail(p, MFNS_CALTABLE_E_INDEX_GEOMETRY, o + XG_OFF(RANGE_MIN_MM));
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
            return mfns_ct_fail(p, MFNS_CALTABLE_E_INDEX_NEIGHBOUR, o);
        }
        for (uint32_t r = 0; r < k; r++) {
            const uint8_t e = b[o + 1u + r];
            bool bad = r < cnt ? (e >= n || e == i) : e != 0; /* unused entries are 0 */
            for (uint32_t q = 0; q < r && r < cnt && !bad; q++) {
                bad = b[o + 1u + q] == e;
            }
            if (bad) {
                return mfns_ct_fail(p, MFNS_CALTABLE_E_INDEX_NEIGHBOUR, o + 1u + r);
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
            return mfns_ct_fail(p, MFNS_CALTABLE_E_INDEX_PAIR, o);
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
            dst->cert_inliers[m] = b[pos + X_OFF(CERT_INLIERS) + m];
        }
        dst->max_missing = b[pos + X_OFF(MAX_MISSING)];
        dst->max_unexplained = b[pos + X_OFF(MAX_UNEXPLAINED)];
        dst->analysis_max_rival = mfns_ct_u16(b, pos + X_OFF(ANALYSIS_MAX_RIVAL));
        dst->budget_units = mfns_ct_u32(b, pos + X_OFF(BUDGET_UNITS));
        dst->ws_min_w = mfns_v3(ws[0], ws[1], ws[2]);
        dst->ws_max_w = mfns_v3(ws[3], ws[4], ws[5]);
        dst->analysis_samples = mfns_ct_u32(b, pos + X_OFF(ANALYSIS_SAMPLES));
    }
    return true;
}
