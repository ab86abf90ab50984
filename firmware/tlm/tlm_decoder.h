/* tlm_decoder.h -- the receiving end of the telemetry link: a streaming,
 * byte-at-a-time frame decoder with a bounded buffer (TLM_MAX_FRAME bytes,
 * no heap), for the ground station and for any on-board consumer.
 *
 * Robustness contract: any byte sequence is accepted. A frame that fails
 * (COBS structure, length, CRC, CCSDS header, payload) is dropped and
 * counted, and decoding restarts at the byte after the next 0x00 delimiter:
 * one corrupted frame never costs more than itself and, if its delimiter was
 * hit, the frame after it. A frame that outgrows the buffer is discarded up
 * to the next delimiter. Work per byte is bounded (no loops over the buffer
 * except the final CRC/parse, bounded by TLM_MAX_FRAME).
 */
#ifndef MFNS_TLM_DECODER_H
#define MFNS_TLM_DECODER_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/tlm/tlm_packets.h"

#define TLM_DECODER_RESTART_RUN 3u /* consecutive counts from a back arrival: a restarted sender */

typedef struct {
    uint32_t packets;  /* good packets of this type */
    uint32_t gaps;     /* sequence discontinuities (count != previous + 1 mod 2^14) */
    uint32_t lost;     /* counts skipped by a forward jump and not received since (a late one,
                        * arriving after a later count, is taken back: see late) */
    uint32_t back;     /* counts behind the highest read that were not missing: a repeat, a
                        * reordered packet the stream had not skipped, or a restarted sender */
    uint32_t late;     /* counts that arrived after a later one and had been counted lost:
                        * reordered, not lost (taken back from lost) */
    uint16_t last_seq; /* valid when seen */
    uint16_t high_seq; /* the highest count read since the sender last (re)started */
    uint16_t run_seq;  /* the last count of a run that began with a back arrival */
    uint8_t seen;
    uint8_t run_len;   /* counts in that run, 0 when none: TLM_DECODER_RESTART_RUN make a restart */
} tlm_apid_stats_t;

typedef struct {
    uint32_t bytes;           /* bytes pushed */
    uint32_t frames_ok;       /* good frames = decoded packets */
    uint32_t crc_errors;      /* CRC mismatch */
    uint32_t truncated;       /* COBS block cut by a delimiter, or shorter than header + CRC */
    uint32_t oversize;        /* no delimiter within TLM_MAX_FRAME decoded bytes */
    uint32_t bad_packets;     /* CRC good but CCSDS header, length, APID or payload refused */
    uint32_t resyncs;         /* good frame after one or more dropped frames (sync re-acquired) */
    uint32_t bytes_discarded; /* bytes skipped while hunting for a delimiter after an oversize */
    uint32_t seq_gaps;        /* sum of the per-type gaps */
    uint32_t seq_lost;        /* sum of the per-type lost */
    uint32_t seq_back;        /* sum of the per-type back */
    uint32_t seq_late;        /* sum of the per-type late */
    tlm_apid_stats_t type[TLM_NUM_TYPES];
} tlm_decoder_stats_t;

typedef struct {
    uint8_t buf[TLM_MAX_FRAME]; /* decoded bytes of the frame in progress */
    uint16_t len;
    uint8_t code_left;          /* data bytes left in the current COBS block */
    bool in_frame;              /* at least one byte of this frame seen */
    bool pending_zero;          /* the current block implies a 0x00 if another block follows */
    bool discarding;            /* oversize: skipping to the next delimiter */
    bool lost_sync;             /* a frame was dropped since the last good one */
    int last_error;             /* tlm_err_t of the last dropped frame */
    tlm_decoder_stats_t stats;
    /* One bit per sequence count and packet type: skipped by a forward jump and not yet
     * received (counted in lost). A count that arrives later clears its bit and is counted
     * late instead of lost, so a reordered or shuffled recording reads no loss; a jump of
     * half the modulus or more cannot be told from a count going back (2^14 counts: a
     * packet more than 8191 counts late reads as back, its slot stays lost). A back arrival
     * followed by the counts after it, TLM_DECODER_RESTART_RUN in a row, is a restarted
     * sender: the bits are cleared and the reading goes on from the new count (what was
     * missing before stays lost; a shuffle makes such a run with a chance of about 1/N^2
     * per back arrival, N the counts in play). */
    uint32_t seq_missing[TLM_NUM_TYPES][(TLM_CCSDS_SEQ_MASK + 1u) / 32u];
} tlm_decoder_t;

void tlm_decoder_init(tlm_decoder_t *d);

/* Feed one received byte.
 *   1  a packet was decoded into *out (only then is *out written)
 *   0  more bytes needed (also for idle delimiters between frames)
 *  <0  the frame ending at (or overflowing at) this byte was dropped; the
 *      value is its tlm_err_t, already counted in d->stats. Keep pushing. */
int tlm_decoder_push(tlm_decoder_t *d, uint8_t byte, tlm_packet_t *out);

/* End of the byte stream (end of a recorded file): a frame begun but not
 * ended by its delimiter is counted as truncated (returns 1), then forgotten. */
int tlm_decoder_finish(tlm_decoder_t *d);

/* Forget a partial frame (e.g. the link was re-opened). Statistics stay. */
void tlm_decoder_reset_frame(tlm_decoder_t *d);

#endif /* MFNS_TLM_DECODER_H */
