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

static void count_sequence(tlm_decoder_t *d, const tlm_packet_t *p)
{
    tlm_apid_stats_t *s = &d->stats.type[p->type];
    if (s->seen) {
        const uint16_t expected = (uint16_t)((s->last_seq + 1u) & TLM_CCSDS_SEQ_MASK);
        if (p->seq != expected) {
            /* Modulo 2^14 a count can only be read one way: a jump of less
             * than half the modulus forward is that many packets lost; half
             * or more is a count that went back (a repeat, a reorder, a
             * restarted sender), counted as such and never as ~16,000 lost
             * (490 shuffled frames read as 4,095,661 lost before). */
            const uint32_t ahead = (uint32_t)((p->seq - expected) & TLM_CCSDS_SEQ_MASK);
            s->gaps++;
            d->stats.seq_gaps++;
            if (ahead < TLM_CCSDS_SEQ_HALF) {
                s->lost += ahead;
                d->stats.seq_lost += ahead;
            } else {
                s->back++;
                d->stats.seq_back++;
            }
        }
    }
    s->seen = 1;
    s->last_seq = p->seq;
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
