/* caltable.c -- see caltable.h; the byte layout is docs/caltable.md, generated
 * with caltable_layout_gen.h from caltable_layout.toml. This file: the CRC,
 * the messages, the header checks and the validate-then-commit of the body;
 * caltable_records.c and caltable_sections.c parse the body's parts. */
#include "firmware/nav/table/caltable.h"
#include "math/core_inline.h"
#include "math/core_text.h"

#include <math.h>
#include <string.h>

#include "firmware/nav/table/caltable_internal.h"
#include "firmware/nav/generated/caltable_consts_gen.h" /* the definition's constants held to these headers */

/* ---- CRC-32/ISO-HDLC, 4 bits at a time: a 64-byte table instead of 1 KiB. */
static const uint32_t crc_nibble[16] = {
    0x00000000u, 0x1DB71064u, 0x3B6E20C8u, 0x26D930ACu, 0x76DC4190u, 0x6B6B51F4u, 0x4DB26158u, 0x5005713Cu,
    0xEDB88320u, 0xF00F9344u, 0xD6D6A3E8u, 0xCB61B38Cu, 0x9B64C2B0u, 0x86D3D2D4u, 0xA00AE278u, 0xBDBDF21Cu,
};

_Static_assert(sizeof crc_nibble == 64u, "the nibble table is 64 bytes");
/* total_size is a u32 and offsets are uint32_t: the largest table must fit. */
_Static_assert((uint64_t)MFNS_CALTABLE_MAX_BYTES < (uint64_t)UINT32_MAX, "tables are addressed in 32 bits");
/* the calibration-covariance section with its 45 parameters: 4,144 bytes (docs/caltable.md) */
_Static_assert(MFNS_CALTABLE_COV_MAX_SIZE == 4144u, "covariance section size");

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
    /* the generated table has one message per value 0 .. STATUS_COUNT - 1;
     * without messages (core_text.h) each is "", and there is no table */
    if ((unsigned)s < (unsigned)MFNS_CALTABLE_STATUS_COUNT) {
#if MFNS_CORE_MESSAGES
        return mfns_caltable_status_text[s];
#else
        return "";
#endif
    }
    return MFNS_MSG("calibration table: unknown status");
}

MFNS_OUT_OF_LINE
bool mfns_ct_fail(mfns_ct_parser_t *p, mfns_caltable_status_t st, uint32_t off)
{
    if (p->st == MFNS_CALTABLE_OK) {
        p->st = st;
        p->err_off = off;
    }
    return false;
}

bool mfns_ct_f32s(mfns_ct_parser_t *p, uint32_t o, uint32_t n, float *v)
{
    for (uint32_t i = 0; i < n; i++) {
        const uint32_t at = o + 4u * i;
        const float f = mfns_ct_f32(p->b, at);
        if (!isfinite(f)) {
            return mfns_ct_fail(p, MFNS_CALTABLE_E_NOT_FINITE, at);
        }
        if (v != NULL) {
            v[i] = f;
        }
    }
    return true;
}

/* Field id's generated range on value v of the record at base: false with
 * the field's status at its offset when v is outside. */
static bool check_range(mfns_ct_parser_t *p, uint32_t base, mfns_caltable_field_id_t id, float v)
{
    const mfns_caltable_field_t *f = &mfns_caltable_fields[id];
    if (!mfns_caltable_in_range(f, v)) {
        return mfns_ct_fail(p, (mfns_caltable_status_t)f->status, base + f->offset);
    }
    return true;
}

/* Field f of the record at base, read as its stored type, as a float
 * (exact for every integer of a table: the ranges are below 2^24). */
static bool field_value(mfns_ct_parser_t *p, uint32_t base, const mfns_caltable_field_t *f, float *v)
{
    const uint32_t at = base + f->offset;
    switch (f->type) {
    case MFNS_CALTABLE_T_U8:
        *v = (float)p->b[at];
        return true;
    case MFNS_CALTABLE_T_U16:
        *v = (float)mfns_ct_u16(p->b, at);
        return true;
    case MFNS_CALTABLE_T_U32:
        *v = (float)mfns_ct_u32(p->b, at);
        return true;
    case MFNS_CALTABLE_T_I32:
        *v = (float)mfns_ct_i32(p->b, at);
        return true;
    default: /* MFNS_CALTABLE_T_F32 */
        return mfns_ct_f32s(p, at, 1u, v);
    }
}

bool mfns_ct_fields(mfns_ct_parser_t *p, uint32_t base, mfns_caltable_field_id_t first,
                    mfns_caltable_field_id_t last, float *v)
{
    for (uint32_t id = first; id <= last; id++) {
        float x;
        if (!field_value(p, base, &mfns_caltable_fields[id], &x) ||
            !check_range(p, base, (mfns_caltable_field_id_t)id, x)) {
            return false;
        }
        if (v != NULL) {
            v[id - first] = x;
        }
    }
    return true;
}

/* The whole body after the header checks. dst == NULL: validate only. */
static bool parse_body(mfns_ct_parser_t *p, mfns_caltable_t *dst)
{
    uint16_t nbeacon;
    float sigma;
    mfns_centroid_settings_t cs;
    mfns_solver_settings_t ss;
    if (!mfns_ct_parse_globals(p, &nbeacon, &sigma, &cs, &ss)) {
        return false;
    }
    uint32_t pos = MFNS_CALTABLE_HEADER_SIZE + MFNS_CALTABLE_GLOBALS_SIZE; /* the first camera record */
    for (uint16_t k = 0; k < MFNS_NUM_CAMERAS; k++) {
        mfns_camera_t cam;
        mfns_undist_grid_t g;
        if (!mfns_ct_parse_camera(p, &pos, k, &cam, &g, dst != NULL ? dst->grid_node[k] : NULL)) {
            return false;
        }
        if (dst != NULL) {
            dst->rig.cam[k] = cam;
            dst->grid[k] = g;
        }
    }
    if (!mfns_ct_parse_beacons(p, pos, nbeacon, dst != NULL ? &dst->beacons : NULL)) {
        return false;
    }
    pos += (uint32_t)nbeacon * MFNS_CALTABLE_BEACON_SIZE;
    if (!mfns_ct_parse_calib_cov(p, &pos, dst != NULL ? &dst->calib_cov : NULL)) {
        return false;
    }
    if (!mfns_ct_parse_map_datum(p, &pos, dst != NULL ? &dst->datum : NULL)) {
        return false;
    }
    if (!mfns_ct_parse_integrity(p, &pos, dst != NULL ? &dst->integrity : NULL)) {
        return false;
    }
    if (!mfns_ct_parse_motion(p, &pos, dst != NULL ? &dst->motion : NULL)) {
        return false;
    }
    if (!mfns_ct_parse_index(p, pos, nbeacon, dst != NULL ? &dst->index : NULL)) {
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
    enum {
        VER = MFNS_CALTABLE_OFF_HEADER_VERSION,
        HSIZE = MFNS_CALTABLE_OFF_HEADER_HEADER_SIZE,
        TOTAL = MFNS_CALTABLE_OFF_HEADER_TOTAL_SIZE,
        CRC = MFNS_CALTABLE_OFF_HEADER_CRC32,
    };
    mfns_ct_parser_t p = {buf, 0, MFNS_CALTABLE_OK, 0};
    if (buf == NULL || out == NULL) {
        (void)mfns_ct_fail(&p, MFNS_CALTABLE_E_ARG, 0);
    } else if (len < MFNS_CALTABLE_HEADER_SIZE) {
        (void)mfns_ct_fail(&p, MFNS_CALTABLE_E_TRUNCATED, (uint32_t)len);
    } else if (memcmp(buf + MFNS_CALTABLE_OFF_HEADER_MAGIC, MFNS_CALTABLE_MAGIC, 4) != 0) {
        (void)mfns_ct_fail(&p, MFNS_CALTABLE_E_MAGIC, MFNS_CALTABLE_OFF_HEADER_MAGIC);
    } else if (mfns_ct_u16(buf, VER) == 0) {
        (void)mfns_ct_fail(&p, MFNS_CALTABLE_E_VERSION_BAD, VER);
    } else if (mfns_ct_u16(buf, VER) > MFNS_CALTABLE_VERSION) {
        (void)mfns_ct_fail(&p, MFNS_CALTABLE_E_VERSION_NEWER, VER);
    } else if (mfns_ct_u16(buf, VER) < MFNS_CALTABLE_MIN_VERSION) {
        (void)mfns_ct_fail(&p, MFNS_CALTABLE_E_VERSION_OLD, VER);
    } else if (mfns_ct_u16(buf, HSIZE) != MFNS_CALTABLE_HEADER_SIZE) {
        (void)mfns_ct_fail(&p, MFNS_CALTABLE_E_HEADER_SIZE, HSIZE);
    } else {
        const uint32_t total = mfns_ct_u32(buf, TOTAL);
        if (total < MFNS_CALTABLE_HEADER_SIZE + MFNS_CALTABLE_GLOBALS_SIZE || total > MFNS_CALTABLE_MAX_BYTES) {
            (void)mfns_ct_fail(&p, MFNS_CALTABLE_E_SIZE, TOTAL);
        } else if (total > len) {
            (void)mfns_ct_fail(&p, MFNS_CALTABLE_E_TRUNCATED, (uint32_t)(len < UINT32_MAX ? len : UINT32_MAX));
        } else if (mfns_crc32(0, buf + MFNS_CALTABLE_HEADER_SIZE, total - MFNS_CALTABLE_HEADER_SIZE) !=
                   mfns_ct_u32(buf, CRC)) {
            (void)mfns_ct_fail(&p, MFNS_CALTABLE_E_CRC, CRC);
        } else {
            p.size = total;
            /* validate everything first; write only a table known to be good */
            if (parse_body(&p, NULL)) {
                if (!parse_body(&p, out)) {
                    memset(out, 0, sizeof *out); /* unreachable: same checks as the first pass */
                } else {
                    out->format_version = mfns_ct_u16(buf, VER);
                    out->size_bytes = total;
                    out->crc32 = mfns_ct_u32(buf, CRC);
                }
            }
        }
    }
    if (p.st != MFNS_CALTABLE_OK && err_offset != NULL) {
        *err_offset = p.err_off;
    }
    return p.st;
}
