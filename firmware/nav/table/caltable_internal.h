/* caltable_internal.h -- what the loader's files share (caltable.c: header,
 * CRC and the two passes; caltable_records.c: globals, cameras, beacons;
 * caltable_sections.c: calibration covariance and map index). Not part of the
 * contract: callers use caltable.h. Offsets and ranges come from
 * caltable_layout_gen.h, generated from caltable_layout.toml. */
#ifndef MFNS_CALTABLE_INTERNAL_H
#define MFNS_CALTABLE_INTERNAL_H

#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "firmware/nav/table/caltable.h"

/* The loader reads the map-index section the beacon index writes: one layout. */
_Static_assert(MFNS_CALTABLE_INDEX_HEADER_SIZE == MFNS_BIDX_HEADER_SIZE, "map index header: caltable vs beacon_index");
_Static_assert(MFNS_CALTABLE_INDEX_GEOM_SIZE == MFNS_BIDX_GEOM_SIZE, "map index geometry: caltable vs beacon_index");
/* A node is the grid's {u', v'} pair of Q16.16 values. */
_Static_assert(MFNS_CALTABLE_NODE_SIZE == sizeof(q16_16_t[2]), "a grid node is two q16_16_t");

/* v within the generated range f (caltable_layout_gen.h mfns_caltable_field_t). */
static inline bool mfns_caltable_in_range(const mfns_caltable_field_t *f, float v)
{
    const bool lo_ok = (f->flags & MFNS_CALTABLE_LO_OPEN) != 0u ? v > f->lo : v >= f->lo;
    const bool hi_ok = (f->flags & MFNS_CALTABLE_HI_OPEN) != 0u ? v < f->hi : v <= f->hi;
    return lo_ok && hi_ok;
}

/* ---- little-endian readers; the caller has checked the bounds. */
static inline uint16_t mfns_ct_u16(const uint8_t *b, uint32_t o)
{
    return (uint16_t)(b[o] | (uint16_t)(b[o + 1] << 8));
}

static inline uint32_t mfns_ct_u32(const uint8_t *b, uint32_t o)
{
    return (uint32_t)b[o] | ((uint32_t)b[o + 1] << 8) | ((uint32_t)b[o + 2] << 16) | ((uint32_t)b[o + 3] << 24);
}

static inline int32_t mfns_ct_i32(const uint8_t *b, uint32_t o)
{
    const uint32_t u = mfns_ct_u32(b, o);
    int32_t i;
    memcpy(&i, &u, sizeof i); /* two's complement reinterpretation, no implementation-defined cast */
    return i;
}

static inline float mfns_ct_f32(const uint8_t *b, uint32_t o)
{
    const uint32_t u = mfns_ct_u32(b, o);
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
} mfns_ct_parser_t;

/* Record the failure st at offset off (unless one is already recorded);
 * returns false so that a check can `return mfns_ct_fail(...)`. */
bool mfns_ct_fail(mfns_ct_parser_t *p, mfns_caltable_status_t st, uint32_t off);

/* n finite floats at offset o into v[0 .. n - 1] (v NULL: checked only); else
 * E_NOT_FINITE at the first that is not. */
bool mfns_ct_f32s(mfns_ct_parser_t *p, uint32_t o, uint32_t n, float *v);

/* Fields first .. last of the record at base (the ids follow the record's
 * order), in that order: each read as its stored type (an f32 must be finite,
 * else E_NOT_FINITE) and checked against its generated range
 * (caltable_layout_gen.c: outside it, the field's status at its offset);
 * false at the first failure. Their values, as float, into
 * v[0 .. last - first] when v is not NULL. One call instead of a read and a
 * check per field: the loader has some thirty of them. */
bool mfns_ct_fields(mfns_ct_parser_t *p, uint32_t base, mfns_caltable_field_id_t first,
                    mfns_caltable_field_id_t last, float *v);

/* Field id of the record at base, read and checked as by mfns_ct_fields. */
static inline bool mfns_ct_field(mfns_ct_parser_t *p, uint32_t base, mfns_caltable_field_id_t id)
{
    return mfns_ct_fields(p, base, id, id, NULL);
}

/* Offset of field id in the record at base. */
static inline uint32_t mfns_ct_at(uint32_t base, mfns_caltable_field_id_t id)
{
    return base + mfns_caltable_fields[id].offset;
}

/* The sections, in file order; dst == NULL validates only. */
bool mfns_ct_parse_globals(mfns_ct_parser_t *p, uint16_t *nbeacon, float *sigma, mfns_centroid_settings_t *c,
                           mfns_solver_settings_t *s);
/* Camera record `index` at *pos, advanced past its nodes on success; the
 * nodes are copied to dst_nodes when it is not NULL (cam and g always filled). */
bool mfns_ct_parse_camera(mfns_ct_parser_t *p, uint32_t *pos, uint16_t index, mfns_camera_t *cam,
                          mfns_undist_grid_t *g, q16_16_t (*dst_nodes)[2]);
bool mfns_ct_parse_beacons(mfns_ct_parser_t *p, uint32_t pos, uint16_t n, mfns_beacon_map_t *dst);
bool mfns_ct_parse_calib_cov(mfns_ct_parser_t *p, uint32_t *pos, mfns_calib_cov_t *dst);
/* The map datum section at *pos (advanced past it on success). */
bool mfns_ct_parse_map_datum(mfns_ct_parser_t *p, uint32_t *pos, mfns_map_datum_t *dst);
bool mfns_ct_parse_integrity(mfns_ct_parser_t *p, uint32_t *pos, mfns_integrity_settings_t *dst);
bool mfns_ct_parse_motion(mfns_ct_parser_t *p, uint32_t *pos, mfns_filter_settings_t *dst);
bool mfns_ct_parse_index(mfns_ct_parser_t *p, uint32_t pos, uint16_t nbeacon, mfns_beacon_index_t *dst);

#endif /* MFNS_CALTABLE_INTERNAL_H */
