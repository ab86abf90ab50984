/* ground_out.h -- the ground station's per-packet-type output files:
 * DIR/nav.csv, camera.csv, housekeeping.csv, events.csv (one header line,
 * one row per packet) and the same rows as JSON Lines (nav.jsonl, ...).
 * Columns are documented in docs/telemetry.md ("Ground station output").
 * Numbers are printed exactly from the wire integers (fixed decimals), so
 * the files hold exactly what was sent.
 */
#ifndef MFNS_GROUND_OUT_H
#define MFNS_GROUND_OUT_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "firmware/tlm/tlm_decoder.h"
#include "ground/time_corr.h"
#include "firmware/tlm/tlm_packets.h"

typedef struct {
    FILE *csv[TLM_NUM_TYPES];
    FILE *jsonl[TLM_NUM_TYPES];
    unsigned long rows[TLM_NUM_TYPES];
    char dir[256];
    time_corr_t corr; /* the UTC of each packet (columns utc, time_source) */
} ground_out_t;

/* Creates dir if needed (one level) and opens all files with headers.
 * 0, or -1 with a message in err. */
int ground_out_open(ground_out_t *o, const char *dir, char *err, size_t errlen);
/* Appends one row to the type's CSV and JSONL; rx_utc_us is the ground receive
 * time (CLOCK_REALTIME, microseconds since 1970, column ground_utc); the
 * packet's own UTC (time_corr.h: columns utc, time_source) goes to
 * *pkt_utc_us (nullable). 0 or -1 on a write error. */
int ground_out_packet(ground_out_t *o, const tlm_packet_t *p, int64_t rx_utc_us, int64_t *pkt_utc_us);
/* Writes DIR/stats.json from the decoder counters; 0 or -1. */
int ground_out_stats(const ground_out_t *o, const tlm_decoder_stats_t *s, double seconds);
/* Flushes and closes; 0 or -1 if any flush/close failed. */
int ground_out_close(ground_out_t *o);

/* v / 10^decimals as an exact decimal string ("-1234.567"). */
void ground_fmt_fixed(char *buf, size_t len, long long v, int decimals);
/* UTC microseconds since 1970 as ISO 8601 with microseconds:
 * 2026-12-01T23:19:33.123456Z. */
void ground_fmt_utc(char *buf, size_t len, int64_t utc_us);
/* CUC time as seconds with 6 decimals, rounded to the microsecond. */
void ground_fmt_time(char *buf, size_t len, const tlm_time_t *t);

#endif /* MFNS_GROUND_OUT_H */
