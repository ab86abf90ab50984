/* beacon_index.c -- see beacon_index.h: the look-ups the acquisition makes
 * in flight. The index is built on the ground (firmware/host/beacon_index_build.c). */
#include "firmware/nav/map/beacon_index.h"
#include "math/core_text.h"

#define EMIT_PAD_COS 0.05f /* cone tests are widened by this (cosine units, ~3 deg at 90 deg) */

const char *mfns_bidx_strerror(mfns_bidx_status_t s)
{
    switch (s) {
    case MFNS_BIDX_OK:
        return MFNS_MSG("ok");
    case MFNS_BIDX_E_ARG:
        return MFNS_MSG("map index: null pointer, beacon count or parameter out of range");
    case MFNS_BIDX_E_WORKSPACE:
        return MFNS_MSG("map index: workspace box not finite or empty");
    case MFNS_BIDX_E_EMIT:
        return MFNS_MSG("map index: emission axis not unit (or zero) or half-angle cosine outside [-1, 1]");
    case MFNS_BIDX_E_SPACE:
        return MFNS_MSG("map index: output buffer too small");
    }
    return MFNS_MSG("map index: unknown status");
}

bool mfns_bidx_emits_toward(const mfns_beacon_geom_t *g, mfns_v3_t p_beacon_w, mfns_v3_t p_w)
{
    const mfns_v3_t d = mfns_v3_sub(p_w, p_beacon_w);
    const float n = mfns_v3_norm(g->emit.axis_w);
    if (n == 0.0f) {
        return true;
    }
    return mfns_v3_dot(d, g->emit.axis_w) >= (g->emit.cos_half_angle - EMIT_PAD_COS) * mfns_v3_norm(d);
}

bool mfns_bidx_pair_admits(const mfns_beacon_index_t *idx, uint32_t a, uint32_t b, float angle_rad, float pad_rad)
{
    if (a == b || a >= idx->count || b >= idx->count) {
        return false;
    }
    const uint32_t s = mfns_bidx_pair_slot(idx->count, a, b);
    if (idx->pair_lo[s] > idx->pair_hi[s]) {
        return false; /* never seen together, whatever the pad */
    }
    const float lo = (float)idx->pair_lo[s] * MFNS_BIDX_ANGLE_LSB_RAD;
    const float hi = (float)idx->pair_hi[s] * MFNS_BIDX_ANGLE_LSB_RAD;
    return angle_rad >= lo - pad_rad && angle_rad <= hi + pad_rad;
}
