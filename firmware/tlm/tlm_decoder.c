/* tlm_decoder.c -- streaming COBS/CRC/CCSDS decoder (see tlm_decoder.h). */
#include "firmware/tlm/tlm_decoder.h"

#include <string.h>

#include "firmware/tlm/crc16.h"

void tlm_decoder_init(tlm_decoder_t *d)
{
    if (d != NULL) {
        memset(d, 0, sizeof *d);
    }
}

void tlm_decoder_reset_frame(tlm_decoder_t *d)
{
    if (d == NULL) {
        return;
    }
    d->len = 0;
    d->code_left = 0;
    d->in_frame = false;
    d->pending_zero = false;
    d->discarding = false;
}

static int drop(tlm_decoder_t *d, int err)
{
    switch (err) {
    case TLM_ERR_CRC: d->stats.crc_errors++; break;
    case TLM_ERR_COBS:
    case TLM_ERR_RUNT: d->stats.truncated++; break;
    case TLM_ERR_OVERSIZE: d->stats.oversize++; break;
    default: d->stats.bad_packets++; break;
    }
    d->lost_sync = true;
    d->last_error = err;
    return err;
}

static bool missing_bit(const uint32_t *m, uint16_t seq)
{
    return (m[seq >> 5] >> (seq & 31u) & 1u) != 0u;
}

static void set_missing(uint32_t *m, uint16_t seq, bool on)
{
    const uint32_t bit = 1u << (seq & 31u);
    m[seq >> 5] = on ? (m[seq >> 5] | bit) : (m[seq >> 5] & ~bit);
}

/* Sequence accounting per packet type (tlm_decoder.h: lost, late, back). Work per packet
 * bounded by the forward jump, at most TLM_CCSDS_SEQ_HALF - 1 bits set. */
static void count_sequence(tlm_decoder_t *d, const tlm_packet_t *p)
{
    tlm_apid_stats_t *s = &d->stats.type[p->type];
    uint32_t *m = d->seq_missing[p->type];
    const uint16_t seq = (uint16_t)(p->seq & TLM_CCSDS_SEQ_MASK);
    if (!s->seen) {
        s->high_seq = seq;
    } else {
        const uint16_t expected = (uint16_t)((s->last_seq + 1u) & TLM_CCSDS_SEQ_MASK);
        if (seq != expected) {
            s->gaps++;
            d->stats.seq_gaps++;
        }
        /* Modulo 2^14 a count can only be read one way: a jump of less than half the
         * modulus forward of the highest count is that many skipped; half or more is a
         * count behind it (never ~16,000 lost: 490 shuffled frames once read as 4,095,661) */
        const uint32_t ahead = (uint32_t)((seq - s->high_seq) & TLM_CCSDS_SEQ_MASK);
        if (ahead != 0u && ahead < TLM_CCSDS_SEQ_HALF) {
            for (uint32_t i = 1u; i < ahead; i++) {
                set_missing(m, (uint16_t)((s->high_seq + i) & TLM_CCSDS_SEQ_MASK), true);
            }
            set_missing(m, seq, false);
            s->lost += ahead - 1u;
            d->stats.seq_lost += ahead - 1u;
            s->high_seq = seq;
            s->run_len = 0;
        } else if (missing_bit(m, seq) && s->lost > 0u) {
            set_missing(m, seq, false); /* skipped before, here now: reordered, not lost */
            s->lost--;
            d->stats.seq_lost--;
            s->late++;
            d->stats.seq_late++;
            s->run_len = 0;
        } else if (s->run_len != 0u && seq == ((s->run_seq + 1u) & TLM_CCSDS_SEQ_MASK)) {
            s->run_seq = seq; /* the counts after a back arrival, in order: a restart if it goes on */
            if (++s->run_len >= TLM_DECODER_RESTART_RUN) {
                memset(m, 0, sizeof d->seq_missing[0]); /* the sender restarted: read on from here */
                s->high_seq = seq;
                s->run_len = 0;
            }
        } else {
            s->back++;
            d->stats.seq_back++;
            s->run_seq = seq;
            s->run_len = 1;
        }
    }
    s->seen = 1;
    s->last_seq = seq;
    s->packets++;
}

/* A complete frame (delimiter seen): check, parse, count. */
static int finish_frame(tlm_decoder_t *d, tlm_packet_t *out)
{
    if (d->code_left != 0u) {
        return drop(d, TLM_ERR_COBS);
    }
    const size_t n = d->len; /* the pending zero of the last block is not data */
    if (n < TLM_CCSDS_HDR_LEN + 2u) {
        return drop(d, TLM_ERR_RUNT);
    }
    const uint16_t crc_rx = tlm_get_u16(d->buf + n - 2u);
    if (tlm_crc16(d->buf, n - 2u) != crc_rx) {
        return drop(d, TLM_ERR_CRC);
    }
    tlm_packet_t p;
    const int rc = tlm_packet_decode(d->buf, n - 2u, &p);
    if (rc != TLM_OK) {
        return drop(d, rc);
    }
    d->stats.frames_ok++;
    if (d->lost_sync) {
        d->stats.resyncs++;
        d->lost_sync = false;
    }
    count_sequence(d, &p);
    *out = p;
    return 1;
}

int tlm_decoder_push(tlm_decoder_t *d, uint8_t byte, tlm_packet_t *out)
{
    if (d == NULL || out == NULL) {
        return TLM_ERR_NULL;
    }
    d->stats.bytes++;
    if (byte == 0u) {
        int rc = 0;
        if (d->discarding) {
            rc = 0; /* already counted as oversize when it overflowed */
        } else if (d->in_frame) {
            rc = finish_frame(d, out);
        }
        tlm_decoder_reset_frame(d);
        return rc;
    }
    if (d->discarding) {
        d->stats.bytes_discarded++;
        return 0;
    }
    d->in_frame = true;
    if (d->code_left == 0u) {
        /* A code byte: starts a block. The previous block's implied zero is
         * data now that we know another block follows. */
        if (d->pending_zero) {
            if (d->len >= TLM_MAX_FRAME) {
                d->discarding = true;
                return drop(d, TLM_ERR_OVERSIZE);
            }
            d->buf[d->len++] = 0u;
        }
        d->code_left = (uint8_t)(byte - 1u);
        d->pending_zero = (byte != 0xFFu);
        return 0;
    }
    if (d->len >= TLM_MAX_FRAME) {
        d->discarding = true;
        return drop(d, TLM_ERR_OVERSIZE);
    }
    d->buf[d->len++] = byte;
    d->code_left--;
    return 0;
}

int tlm_decoder_finish(tlm_decoder_t *d)
{
    if (d == NULL) {
        return 0;
    }
    /* a frame still being discarded (oversize) was already counted */
    const int cut = d->in_frame && !d->discarding;
    if (cut) {
        d->stats.truncated++;
        d->lost_sync = true;
        d->last_error = TLM_ERR_COBS; /* a block cut short, as by an early delimiter */
    }
    tlm_decoder_reset_frame(d);
    return cut;
}
