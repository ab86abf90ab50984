/* ground_row.h -- one row of the ground station's CSV / JSON Lines output:
 * named, formatted values. ground_out.c fills the first columns (t_s, seq)
 * and the last (ground_utc); ground_row_fields, generated from the telemetry
 * dictionary (ground_cols_gen.c by contract/gen_contracts.py), fills each packet's. */
#ifndef MFNS_GROUND_ROW_H
#define MFNS_GROUND_ROW_H

#include <stdint.h>

#include "firmware/tlm/tlm_packets.h"

#define GROUND_ROW_MAX_COLS 64
#define GROUND_ROW_VAL_LEN 32

typedef struct {
    const char *name[GROUND_ROW_MAX_COLS];
    char val[GROUND_ROW_MAX_COLS][GROUND_ROW_VAL_LEN];
    int quoted[GROUND_ROW_MAX_COLS]; /* JSON string (names, hex) rather than number */
    int n;
} ground_row_t;

/* v / 10^decimals printed exactly (the wire integer of a fixed-point unit). */
void ground_row_num(ground_row_t *r, const char *name, long long v, int decimals);
/* A binary32 with 9 significant digits (the text gives back the same float). */
void ground_row_f32(ground_row_t *r, const char *name, float v);
/* A Q1.30 integer as v / 2^30 with 10 decimals (gives back the integer). */
void ground_row_q30(ground_row_t *r, const char *name, int32_t v);
void ground_row_str(ground_row_t *r, const char *name, const char *s);
void ground_row_hex32(ground_row_t *r, const char *name, uint32_t v); /* "0x%08lx", a JSON string */

/* The columns of p's packet type (generated). */
void ground_row_fields(const tlm_packet_t *p, ground_row_t *r);

#endif /* MFNS_GROUND_ROW_H */
