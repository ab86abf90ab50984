/* tlm_packets.c -- packet structs <-> CCSDS packets <-> wire frames: the
 * CCSDS headers, framing and CRC. The payload layouts and their range checks
 * are generated from the XTCE (tlm_packets_gen.c). */
#include "firmware/tlm/tlm_packets.h"
#include "math/core_text.h"

#include <string.h>

#include "firmware/tlm/crc16.h"

const char *tlm_strerror(int err)
{
    switch (err) {
    case TLM_OK: return MFNS_MSG("ok");
    case TLM_ERR_NULL: return MFNS_MSG("telemetry: NULL argument");
    case TLM_ERR_BUFFER: return MFNS_MSG("telemetry: output buffer too small");
    case TLM_ERR_COBS: return MFNS_MSG("telemetry: truncated frame (COBS block runs past the delimiter)");
    case TLM_ERR_CRC: return MFNS_MSG("telemetry: frame CRC mismatch");
    case TLM_ERR_OVERSIZE: return MFNS_MSG("telemetry: oversize frame (no delimiter within the maximum frame length)");
    case TLM_ERR_RUNT: return MFNS_MSG("telemetry: truncated frame (shorter than header and CRC)");
    case TLM_ERR_HEADER: return MFNS_MSG("telemetry: bad CCSDS primary header (version, type or flags)");
    case TLM_ERR_LENGTH: return MFNS_MSG("telemetry: CCSDS packet length disagrees with the frame");
    case TLM_ERR_APID: return MFNS_MSG("telemetry: unknown APID");
    case TLM_ERR_PAYLOAD: return MFNS_MSG("telemetry: payload size or field out of range for its packet type");
    case TLM_ERR_ARG: return MFNS_MSG("telemetry: argument out of range");
    case TLM_ERR_EMPTY: return MFNS_MSG("telemetry: transmit queue empty");
    default: return MFNS_MSG("unknown telemetry error");
    }
}

void tlm_encoder_init(tlm_encoder_t *enc)
{
    if (enc != NULL) {
        memset(enc, 0, sizeof *enc);
    }
}

int tlm_packet_encode(const tlm_packet_t *pkt, uint16_t seq, uint8_t *out, size_t cap, size_t *out_len)
{
    if (pkt == NULL || out == NULL || out_len == NULL) {
        return TLM_ERR_NULL;
    }
    if ((unsigned)pkt->type >= TLM_NUM_TYPES || seq > TLM_CCSDS_SEQ_MASK) {
        return TLM_ERR_ARG;
    }
    if (!tlm_payload_valid(pkt)) {
        return TLM_ERR_PAYLOAD;
    }
    const size_t plen = tlm_payload_len(pkt->type);
    const size_t total = TLM_CCSDS_HDR_LEN + plen;
    if (cap < total) {
        return TLM_ERR_BUFFER;
    }
    const tlm_ccsds_hdr_t h = {0u, 0u, 1u, tlm_type_apid(pkt->type), TLM_CCSDS_SEQ_UNSEGMENTED, seq,
                               (uint16_t)(TLM_CCSDS_SEC_LEN + plen - 1u)};
    int rc = tlm_ccsds_pack(&h, out);
    if (rc == TLM_OK) {
        rc = tlm_time_pack(&pkt->time, out + TLM_CCSDS_PRI_LEN);
    }
    if (rc != TLM_OK) {
        return rc;
    }
    tlm_payload_pack(pkt, out + TLM_CCSDS_HDR_LEN);
    *out_len = total;
    return TLM_OK;
}

int tlm_packet_decode(const uint8_t *in, size_t len, tlm_packet_t *out)
{
    if (in == NULL || out == NULL) {
        return TLM_ERR_NULL;
    }
    memset(out, 0, sizeof *out);
    if (len < TLM_CCSDS_HDR_LEN) {
        return TLM_ERR_RUNT;
    }
    tlm_ccsds_hdr_t h;
    int rc = tlm_ccsds_unpack(in, &h);
    if (rc != TLM_OK) {
        return rc;
    }
    if (h.version != 0u || h.type != 0u || h.sec_hdr != 1u || h.seq_flags != TLM_CCSDS_SEQ_UNSEGMENTED) {
        return TLM_ERR_HEADER;
    }
    if ((size_t)h.data_len + 1u + TLM_CCSDS_PRI_LEN != len) {
        return TLM_ERR_LENGTH;
    }
    const int type = tlm_apid_type(h.apid);
    if (type < 0) {
        return type;
    }
    if (len != TLM_CCSDS_HDR_LEN + tlm_payload_len((tlm_type_t)type)) {
        return TLM_ERR_PAYLOAD;
    }
    out->type = (tlm_type_t)type;
    out->seq = h.seq;
    rc = tlm_time_unpack(in + TLM_CCSDS_PRI_LEN, &out->time);
    if (rc != TLM_OK) {
        memset(out, 0, sizeof *out);
        return rc;
    }
    tlm_payload_unpack(in + TLM_CCSDS_HDR_LEN, out);
    if (!tlm_payload_valid(out)) {
        memset(out, 0, sizeof *out);
        return TLM_ERR_PAYLOAD;
    }
    return TLM_OK;
}

int tlm_frame_encode(tlm_encoder_t *enc, tlm_packet_t *pkt, uint8_t *out, size_t cap, size_t *out_len)
{
    if (enc == NULL || pkt == NULL || out == NULL || out_len == NULL) {
        return TLM_ERR_NULL;
    }
    if ((unsigned)pkt->type >= TLM_NUM_TYPES) {
        return TLM_ERR_ARG;
    }
    uint8_t raw[TLM_MAX_FRAME];
    size_t n = 0;
    const uint16_t seq = (uint16_t)(enc->next_seq[pkt->type] & TLM_CCSDS_SEQ_MASK);
    int rc = tlm_packet_encode(pkt, seq, raw, sizeof raw - 2u, &n);
    if (rc != TLM_OK) {
        return rc;
    }
    tlm_put_u16(raw + n, tlm_crc16(raw, n));
    n += 2u;
    size_t enc_len = 0;
    if (cap < 1u) {
        return TLM_ERR_BUFFER;
    }
    rc = tlm_cobs_encode(raw, n, out, cap - 1u, &enc_len);
    if (rc != TLM_OK) {
        return rc;
    }
    out[enc_len] = 0x00u;
    *out_len = enc_len + 1u;
    pkt->seq = seq;
    enc->next_seq[pkt->type] = (uint16_t)((seq + 1u) & TLM_CCSDS_SEQ_MASK);
    return TLM_OK;
}

/* Shared rounding + saturation; lo/hi are the target type's limits. */
static int64_t scale_sat(float value, float scale, float lo, float hi, bool *ok)
{
    const float r = value * scale;
    if (r != r) { /* NaN */
        if (ok != NULL) {
            *ok = false;
        }
        return 0;
    }
    if (r >= hi + 0.5f) {
        if (ok != NULL) {
            *ok = false;
        }
        return (int64_t)hi;
    }
    if (r <= lo - 0.5f) {
        if (ok != NULL) {
            *ok = false;
        }
        return (int64_t)lo;
    }
    return (r >= 0.0f) ? (int64_t)(r + 0.5f) : -(int64_t)(-r + 0.5f);
}

int32_t tlm_scale_i32(float value, float scale, bool *ok)
{
    /* 2147483520 is the largest float below 2^31, so the bounds are exact. */
    const int64_t v = scale_sat(value, scale, -2147483648.0f, 2147483520.0f, ok);
    return (int32_t)v;
}

uint32_t tlm_scale_u32(float value, float scale, bool *ok)
{
    const int64_t v = scale_sat(value, scale, 0.0f, 4294967040.0f, ok);
    return (uint32_t)v;
}

uint16_t tlm_scale_u16(float value, float scale, bool *ok)
{
    const int64_t v = scale_sat(value, scale, 0.0f, 65535.0f, ok);
    return (uint16_t)v;
}
