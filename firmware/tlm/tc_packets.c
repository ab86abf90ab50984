/* tc_packets.c -- telecommand codec and receiver (see tc_packets.h): the
 * CCSDS header, framing and CRC; the argument layouts, ranges and names are
 * generated from the XTCE (tc_packets_gen.c). */
#include "firmware/tlm/tc_packets.h"

#include <string.h>

#include "math/core_inline.h"
#include "firmware/tlm/crc16.h"
#include "firmware/tlm/tlm_err.h"
#include "firmware/tlm/tlm_packets.h"

#define TC_SEQ_FLAGS TLM_CCSDS_SEQ_UNSEGMENTED

/* non-empty printable ASCII, NUL-terminated inside the field, zeros after:
 * exactly one byte pattern per string */
bool tc_string_valid(const char *s, size_t cap)
{
    size_t n = 0;
    while (n < cap && s[n] != '\0') {
        const unsigned char ch = (unsigned char)s[n];
        if (ch < 0x20u || ch > 0x7Eu) {
            return false;
        }
        n++;
    }
    if (n == 0u || n >= cap) {
        return false;
    }
    for (size_t i = n; i < cap; i++) {
        if (s[i] != '\0') {
            return false;
        }
    }
    return true;
}

tc_status_t tc_packet_encode(const tc_cmd_t *cmd, uint16_t seq, uint8_t *out, size_t cap, size_t *out_len)
{
    if (cmd == NULL || out == NULL || out_len == NULL) {
        return TC_E_NULL;
    }
    const int alen = tc_arg_len(cmd->opcode);
    if (alen < 0) {
        return TC_E_OPCODE;
    }
    if (seq > TLM_CCSDS_SEQ_MASK) {
        return TC_E_HEADER;
    }
    const tc_status_t st = tc_args_check(cmd);
    if (st != TC_OK) {
        return st;
    }
    const size_t total = TC_HDR_LEN + (size_t)alen;
    if (cap < total) {
        return TC_E_NULL;
    }
    const tlm_ccsds_hdr_t h = {0u, 1u, 1u, (uint16_t)TC_APID, TC_SEQ_FLAGS, seq,
                               (uint16_t)(total - TLM_CCSDS_PRI_LEN - 1u)};
    if (tlm_ccsds_pack(&h, out) != TLM_OK) {
        return TC_E_HEADER;
    }
    out[6] = cmd->opcode;
    out[7] = 0u;
    tc_args_pack(cmd, out + TC_HDR_LEN);
    *out_len = total;
    return TC_OK;
}

/* The primary header at in (every bit pattern unpacks) into *h, its sequence
 * count into out; true when it is a telecommand's (version 0, type TC,
 * secondary header, unsegmented). */
MFNS_OUT_OF_LINE
static bool tc_primary_header(const uint8_t *in, tlm_ccsds_hdr_t *h, tc_cmd_t *out)
{
    (void)tlm_ccsds_unpack(in, h);
    out->seq = h->seq;
    out->have_seq = true;
    return h->version == 0u && h->type == 1u && h->sec_hdr == 1u && h->seq_flags == TC_SEQ_FLAGS;
}

tc_status_t tc_packet_decode(const uint8_t *in, size_t len, tc_cmd_t *out)
{
    if (out == NULL) {
        return TC_E_NULL;
    }
    memset(out, 0, sizeof *out);
    if (in == NULL) {
        return TC_E_NULL;
    }
    if (len < TC_HDR_LEN) {
        return TC_E_RUNT;
    }
    tlm_ccsds_hdr_t h;
    if (!tc_primary_header(in, &h, out)) {
        return TC_E_HEADER;
    }
    if ((size_t)h.data_len + TLM_CCSDS_PRI_LEN + 1u != len) {
        return TC_E_LENGTH;
    }
    if (h.apid != TC_APID) {
        return TC_E_APID;
    }
    out->opcode = in[6];
    out->have_opcode = true;
    const int alen = tc_arg_len(in[6]);
    if (alen < 0 || in[7] != 0u) {
        return TC_E_OPCODE;
    }
    if (len != TC_HDR_LEN + (size_t)alen) {
        return TC_E_ARG_LEN;
    }
    tc_args_unpack(in + TC_HDR_LEN, out);
    const tc_status_t st = tc_args_check(out);
    if (st != TC_OK) {
        memset(&out->u, 0, sizeof out->u); /* nothing half-valid */
    }
    return st;
}

tc_status_t tc_packet_frame(const uint8_t *pkt, size_t n, uint8_t *out, size_t cap, size_t *out_len)
{
    if (pkt == NULL || out == NULL || out_len == NULL || n > TC_MAX_SEC_PACKET) {
        return TC_E_NULL;
    }
    uint8_t frame[TC_MAX_FRAME];
    memcpy(frame, pkt, n);
    tlm_put_u16(frame + n, tlm_crc16(frame, n));
    size_t enc = 0;
    if (cap < 1u || tlm_cobs_encode(frame, n + 2u, out, cap - 1u, &enc) != TLM_OK) {
        return TC_E_NULL;
    }
    out[enc] = 0u;
    *out_len = enc + 1u;
    return TC_OK;
}

tc_status_t tc_frame_encode(const tc_cmd_t *cmd, uint16_t seq, uint8_t *out, size_t cap, size_t *out_len)
{
    if (out == NULL || out_len == NULL) {
        return TC_E_NULL;
    }
    uint8_t pkt[TC_MAX_PACKET];
    size_t n = 0;
    const tc_status_t st = tc_packet_encode(cmd, seq, pkt, sizeof pkt, &n);
    if (st != TC_OK) {
        return st;
    }
    return tc_packet_frame(pkt, n, out, cap, out_len);
}

static void put_u64(uint8_t *p, uint64_t v)
{
    for (unsigned i = 0; i < 8u; i++) {
        p[i] = (uint8_t)(v >> (56u - 8u * i));
    }
}

static uint64_t get_u64(const uint8_t *p)
{
    uint64_t v = 0;
    for (unsigned i = 0; i < 8u; i++) {
        v = (v << 8) | p[i];
    }
    return v;
}

tc_status_t tc_sec_packet_encode(const tc_cmd_t *cmd, uint16_t seq, uint16_t spi, uint64_t arsn, uint8_t *out,
                                 size_t cap, size_t *auth_len)
{
    if (out == NULL || auth_len == NULL) {
        return TC_E_NULL;
    }
    if (spi < TC_SPI_MIN || spi > TC_SPI_MAX) {
        return TC_E_HEADER;
    }
    uint8_t plain[TC_MAX_PACKET];
    size_t n = 0;
    const tc_status_t st = tc_packet_encode(cmd, seq, plain, sizeof plain, &n);
    if (st != TC_OK) {
        return st;
    }
    if (cap < n + TC_SEC_OVERHEAD) {
        return TC_E_NULL;
    }
    memcpy(out, plain, TLM_CCSDS_PRI_LEN);
    tlm_put_u16(out + 4, (uint16_t)(n + TC_SEC_OVERHEAD - TLM_CCSDS_PRI_LEN - 1u));
    tlm_put_u16(out + TC_SEC_SPI_OFF, spi);
    put_u64(out + TC_SEC_ARSN_OFF, arsn);
    memcpy(out + TLM_CCSDS_PRI_LEN + TC_SEC_PREFIX_LEN, plain + TLM_CCSDS_PRI_LEN, n - TLM_CCSDS_PRI_LEN);
    *auth_len = n + TC_SEC_PREFIX_LEN;
    return TC_OK;
}

tc_status_t tc_any_packet_decode(const uint8_t *in, size_t len, tc_cmd_t *out)
{
    if (in == NULL || len <= TLM_CCSDS_PRI_LEN || in[TC_SEC_SPI_OFF] != 0u) {
        return tc_packet_decode(in, len, out); /* plain (or too short to tell: its own RUNT) */
    }
    if (out == NULL) {
        return TC_E_NULL;
    }
    memset(out, 0, sizeof *out);
    tlm_ccsds_hdr_t h; /* the primary header first: a TM frame is HEADER, as when plain */
    if (!tc_primary_header(in, &h, out)) {
        return TC_E_HEADER;
    }
    if (len < TC_HDR_LEN + TC_SEC_OVERHEAD) {
        return TC_E_RUNT;
    }
    if (len > TC_MAX_SEC_PACKET) {
        return TC_E_OVERSIZE;
    }
    /* the command as a plain packet: primary header with the length less
     * the security bytes, then opcode, reserved, arguments */
    uint8_t plain[TC_MAX_PACKET + TC_SEC_OVERHEAD];
    const size_t pn = len - TC_SEC_OVERHEAD;
    memcpy(plain, in, TLM_CCSDS_PRI_LEN);
    const uint16_t dlen = tlm_get_u16(in + 4);
    tlm_put_u16(plain + 4, (uint16_t)(dlen >= TC_SEC_OVERHEAD ? dlen - TC_SEC_OVERHEAD : 0xFFFFu));
    memcpy(plain + TLM_CCSDS_PRI_LEN, in + TLM_CCSDS_PRI_LEN + TC_SEC_PREFIX_LEN, pn - TLM_CCSDS_PRI_LEN);
    const tc_status_t st = tc_packet_decode(plain, pn, out);
    tc_sec_t *s = &out->sec;
    s->present = true;
    s->spi = tlm_get_u16(in + TC_SEC_SPI_OFF);
    s->arsn = get_u64(in + TC_SEC_ARSN_OFF);
    s->auth_len = (uint16_t)(len - TC_SEC_MAC_LEN);
    memcpy(s->auth, in, s->auth_len);
    memcpy(s->mac, in + s->auth_len, TC_SEC_MAC_LEN);
    return st;
}

void tc_deframer_init(tc_deframer_t *d)
{
    if (d != NULL) {
        memset(d, 0, sizeof *d);
    }
}

/* A frame's COBS bytes are complete (delimiter seen): decode, check, parse. */
static tc_status_t finish(const tc_deframer_t *d, tc_cmd_t *out)
{
    uint8_t frame[TC_MAX_FRAME];
    size_t n = 0;
    const int rc = tlm_cobs_decode(d->buf, d->len, frame, sizeof frame, &n);
    if (rc == TLM_ERR_BUFFER) {
        return TC_E_OVERSIZE;
    }
    if (rc != TLM_OK) {
        return TC_E_FRAME;
    }
    if (n < TC_HDR_LEN + 2u) {
        return TC_E_RUNT;
    }
    if (tlm_crc16(frame, n - 2u) != tlm_get_u16(frame + n - 2u)) {
        return TC_E_CRC;
    }
    return tc_any_packet_decode(frame, n - 2u, out);
}

bool tc_deframer_push(tc_deframer_t *d, uint8_t byte, tc_cmd_t *out, tc_status_t *status)
{
    if (d == NULL || out == NULL || status == NULL) {
        return false;
    }
    d->bytes++;
    if (byte == 0u) {
        const bool had = d->len > 0u && !d->discarding;
        const bool was_discarding = d->discarding;
        d->discarding = false;
        if (!had) {
            d->len = 0;
            (void)was_discarding; /* an oversize frame was reported when it overflowed */
            return false;          /* idle fill between frames */
        }
        memset(out, 0, sizeof *out);
        *status = finish(d, out);
        d->len = 0;
        d->frames++;
        return true;
    }
    if (d->discarding) {
        return false;
    }
    if (d->len >= sizeof d->buf) {
        d->discarding = true;
        d->len = 0;
        d->frames++;
        memset(out, 0, sizeof *out);
        *status = TC_E_OVERSIZE;
        return true;
    }
    d->buf[d->len++] = byte;
    return false;
}
