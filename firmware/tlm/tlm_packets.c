/* tlm_packets.c -- packet structs <-> CCSDS packets <-> wire frames. */
#include "tlm_packets.h"

#include <math.h>
#include <string.h>

#include "crc16.h"

static const uint16_t k_apid[TLM_NUM_TYPES] = {TLM_APID_NAV, TLM_APID_CAMERA, TLM_APID_HK, TLM_APID_EVENT};
static const uint8_t k_payload_len[TLM_NUM_TYPES] = {TLM_NAV_PAYLOAD_LEN, TLM_CAMERA_PAYLOAD_LEN,
                                                      TLM_HK_PAYLOAD_LEN, TLM_EVENT_PAYLOAD_LEN};
static const char *const k_type_name[TLM_NUM_TYPES] = {"nav", "camera", "housekeeping", "event"};
static const char *const k_status_name[TLM_NAV_STATUS_COUNT] = {"NO_FIX", "FIX", "DEGRADED"};
static const char *const k_mode_name[TLM_MODE_COUNT] = {"BOOT", "ACQUIRE", "TRACK", "SAFE", "STANDBY"};
static const char *const k_cam_state_name[TLM_CAM_STATE_COUNT] = {"OK", "LOST", "OFF", "SKIPPED", "ENDED"};
static const char *const k_event_name[TLM_EVT_CODE_COUNT] = {
    "?", "BOOT", "TABLE_LOADED", "TABLE_REFUSED", "CAMERA_LOST", "CAMERA_RECOVERED", "MODE_CHANGE",
    "TLM_DROPPED", "CAMERA_STALE", "CAMERA_OUT_OF_STEP", "FRAME_REJECTED", "CAMERA_ENDED", "TLM_WRITE_ERROR",
    "CMD_ACCEPTED", "CMD_REJECTED"};
static const char *const k_severity_name[TLM_SEV_COUNT] = {"INFO", "WARNING", "ERROR"};

const char *tlm_strerror(int err)
{
    switch (err) {
    case TLM_OK: return "ok";
    case TLM_ERR_NULL: return "telemetry: NULL argument";
    case TLM_ERR_BUFFER: return "telemetry: output buffer too small";
    case TLM_ERR_COBS: return "telemetry: truncated frame (COBS block runs past the delimiter)";
    case TLM_ERR_CRC: return "telemetry: frame CRC mismatch";
    case TLM_ERR_OVERSIZE: return "telemetry: oversize frame (no delimiter within the maximum frame length)";
    case TLM_ERR_RUNT: return "telemetry: truncated frame (shorter than header and CRC)";
    case TLM_ERR_HEADER: return "telemetry: bad CCSDS primary header (version, type or flags)";
    case TLM_ERR_LENGTH: return "telemetry: CCSDS packet length disagrees with the frame";
    case TLM_ERR_APID: return "telemetry: unknown APID";
    case TLM_ERR_PAYLOAD: return "telemetry: payload size or field out of range for its packet type";
    case TLM_ERR_ARG: return "telemetry: argument out of range";
    case TLM_ERR_EMPTY: return "telemetry: transmit queue empty";
    default: return "unknown telemetry error";
    }
}

void tlm_encoder_init(tlm_encoder_t *enc)
{
    if (enc != NULL) {
        memset(enc, 0, sizeof *enc);
    }
}

uint16_t tlm_type_apid(tlm_type_t type)
{
    return ((unsigned)type < TLM_NUM_TYPES) ? k_apid[type] : 0u;
}

int tlm_apid_type(uint16_t apid)
{
    for (int t = 0; t < (int)TLM_NUM_TYPES; t++) {
        if (k_apid[t] == apid) {
            return t;
        }
    }
    return TLM_ERR_APID;
}

size_t tlm_payload_len(tlm_type_t type)
{
    return ((unsigned)type < TLM_NUM_TYPES) ? k_payload_len[type] : 0u;
}

const char *tlm_type_name(tlm_type_t type)
{
    return ((unsigned)type < TLM_NUM_TYPES) ? k_type_name[type] : "?";
}

const char *tlm_nav_status_name(uint8_t status)
{
    return status < TLM_NAV_STATUS_COUNT ? k_status_name[status] : "?";
}

const char *tlm_mode_name(uint8_t mode)
{
    return mode < TLM_MODE_COUNT ? k_mode_name[mode] : "?";
}

const char *tlm_cam_state_name(uint8_t state)
{
    return state < TLM_CAM_STATE_COUNT ? k_cam_state_name[state] : "?";
}

const char *tlm_event_name(uint16_t code)
{
    return (code > 0u && code < TLM_EVT_CODE_COUNT) ? k_event_name[code] : "?";
}

const char *tlm_severity_name(uint8_t severity)
{
    return severity < TLM_SEV_COUNT ? k_severity_name[severity] : "?";
}

void tlm_put_f32(uint8_t *p, float v)
{
    uint32_t u;
    memcpy(&u, &v, sizeof u); /* the bit pattern: binary32 on every target we build for */
    tlm_put_u32(p, u);
}

float tlm_get_f32(const uint8_t *p)
{
    const uint32_t u = tlm_get_u32(p);
    float v;
    memcpy(&v, &u, sizeof v);
    return v;
}

static bool cov_finite(const float *c)
{
    for (unsigned i = 0; i < TLM_NAV_COV_N; i++) {
        if (!isfinite(c[i])) {
            return false;
        }
    }
    return true;
}

/* Field-range rules shared by encoder and decoder, so neither side accepts
 * what the other would refuse. */
static bool payload_valid(const tlm_packet_t *p)
{
    switch (p->type) {
    case TLM_TYPE_NAV:
        return p->u.nav.status < TLM_NAV_STATUS_COUNT && p->u.nav.mode < TLM_MODE_COUNT &&
               p->u.nav.cams_used < 8u && cov_finite(p->u.nav.cov);
    case TLM_TYPE_CAMERA:
        return p->u.camera.camera < TLM_NUM_CAMERAS && p->u.camera.state < TLM_CAM_STATE_COUNT;
    case TLM_TYPE_HK:
        return p->u.hk.mode < TLM_MODE_COUNT && p->u.hk.cpu_load_permille <= 1000u && p->u.hk.cams_enabled < 8u;
    case TLM_TYPE_EVENT:
        return p->u.event.code > 0u && p->u.event.code < TLM_EVT_CODE_COUNT &&
               p->u.event.severity < TLM_SEV_COUNT;
    default:
        return false;
    }
}

static void put_i32(uint8_t *b, int32_t v)
{
    tlm_put_u32(b, (uint32_t)v);
}

static int32_t get_i32(const uint8_t *b)
{
    /* Two's complement reinterpretation without implementation-defined casts. */
    const uint32_t u = tlm_get_u32(b);
    return (u & 0x80000000u) ? (int32_t)(-(int64_t)(~u) - 1) : (int32_t)u;
}

static void pack_payload(const tlm_packet_t *p, uint8_t *b)
{
    switch (p->type) {
    case TLM_TYPE_NAV: {
        const tlm_nav_t *n = &p->u.nav;
        tlm_put_u32(b, n->cycle);
        b[4] = n->status;
        b[5] = n->reason;
        b[6] = n->mode;
        b[7] = n->beacons_used;
        b[8] = n->cams_used;
        b[9] = n->iterations;
        tlm_put_u16(b + 10, n->residual_rms_mpx);
        for (int i = 0; i < 3; i++) {
            put_i32(b + 12 + 4 * i, n->pos_um[i]);
            put_i32(b + 24 + 4 * i, n->att_udeg[i]);
            tlm_put_u32(b + 36 + 4 * i, n->sigma_pos_um[i]);
            tlm_put_u32(b + 48 + 4 * i, n->sigma_att_udeg[i]);
        }
        for (int i = 0; i < 4; i++) {
            put_i32(b + 60 + 4 * i, n->q_q30[i]);
        }
        for (unsigned i = 0; i < TLM_NAV_COV_N; i++) {
            tlm_put_f32(b + 76 + 4u * i, n->cov[i]);
        }
        break;
    }
    case TLM_TYPE_CAMERA: {
        const tlm_camera_t *c = &p->u.camera;
        tlm_put_u32(b, c->cycle);
        b[4] = c->camera;
        b[5] = c->state;
        b[6] = c->blobs;
        b[7] = c->beacons_identified;
        tlm_put_u32(b + 8, c->exposure_us);
        tlm_put_u16(b + 12, (uint16_t)c->gain_cdb);
        tlm_put_u32(b + 14, c->frame_seq);
        tlm_put_u32(b + 18, c->frames_dropped);
        break;
    }
    case TLM_TYPE_HK: {
        const tlm_hk_t *h = &p->u.hk;
        tlm_put_u32(b, h->cycle);
        b[4] = h->mode;
        tlm_put_u16(b + 5, h->cpu_load_permille);
        const uint32_t v[10] = {h->cycle_p50_us, h->cycle_p95_us, h->cycle_p99_us, h->cycle_max_us,
                                h->n_cycles,     h->n_fix,        h->n_no_fix,   h->n_tlm_dropped,
                                h->n_cam_errors, h->table_crc32};
        for (int i = 0; i < 10; i++) {
            tlm_put_u32(b + 7 + 4 * i, v[i]);
        }
        tlm_put_u32(b + 47, h->n_acquire);
        tlm_put_u32(b + 51, h->acq_units_max);
        tlm_put_u32(b + 55, h->acq_units_last);
        b[59] = h->acq_band_last;
        b[60] = h->acq_best_last;
        tlm_put_u32(b + 61, h->n_degraded);
        tlm_put_u32(b + 65, h->n_cmd_accepted);
        tlm_put_u32(b + 69, h->n_cmd_rejected);
        tlm_put_u16(b + 73, h->cmd_seq_last);
        b[75] = h->cams_enabled;
        break;
    }
    case TLM_TYPE_EVENT: {
        const tlm_event_t *e = &p->u.event;
        tlm_put_u32(b, e->cycle);
        tlm_put_u16(b + 4, e->code);
        b[6] = e->severity;
        b[7] = e->subject;
        put_i32(b + 8, e->arg0);
        put_i32(b + 12, e->arg1);
        break;
    }
    default:
        break;
    }
}

static void unpack_payload(const uint8_t *b, tlm_packet_t *p)
{
    switch (p->type) {
    case TLM_TYPE_NAV: {
        tlm_nav_t *n = &p->u.nav;
        n->cycle = tlm_get_u32(b);
        n->status = b[4];
        n->reason = b[5];
        n->mode = b[6];
        n->beacons_used = b[7];
        n->cams_used = b[8];
        n->iterations = b[9];
        n->residual_rms_mpx = tlm_get_u16(b + 10);
        for (int i = 0; i < 3; i++) {
            n->pos_um[i] = get_i32(b + 12 + 4 * i);
            n->att_udeg[i] = get_i32(b + 24 + 4 * i);
            n->sigma_pos_um[i] = tlm_get_u32(b + 36 + 4 * i);
            n->sigma_att_udeg[i] = tlm_get_u32(b + 48 + 4 * i);
        }
        for (int i = 0; i < 4; i++) {
            n->q_q30[i] = get_i32(b + 60 + 4 * i);
        }
        for (unsigned i = 0; i < TLM_NAV_COV_N; i++) {
            n->cov[i] = tlm_get_f32(b + 76 + 4u * i);
        }
        break;
    }
    case TLM_TYPE_CAMERA: {
        tlm_camera_t *c = &p->u.camera;
        c->cycle = tlm_get_u32(b);
        c->camera = b[4];
        c->state = b[5];
        c->blobs = b[6];
        c->beacons_identified = b[7];
        c->exposure_us = tlm_get_u32(b + 8);
        const uint16_t g = tlm_get_u16(b + 12);
        c->gain_cdb = (g & 0x8000u) ? (int16_t)(-(int32_t)(uint16_t)~g - 1) : (int16_t)g;
        c->frame_seq = tlm_get_u32(b + 14);
        c->frames_dropped = tlm_get_u32(b + 18);
        break;
    }
    case TLM_TYPE_HK: {
        tlm_hk_t *h = &p->u.hk;
        h->cycle = tlm_get_u32(b);
        h->mode = b[4];
        h->cpu_load_permille = tlm_get_u16(b + 5);
        uint32_t *const v[10] = {&h->cycle_p50_us, &h->cycle_p95_us, &h->cycle_p99_us, &h->cycle_max_us,
                                 &h->n_cycles,     &h->n_fix,        &h->n_no_fix,   &h->n_tlm_dropped,
                                 &h->n_cam_errors, &h->table_crc32};
        for (int i = 0; i < 10; i++) {
            *v[i] = tlm_get_u32(b + 7 + 4 * i);
        }
        h->n_acquire = tlm_get_u32(b + 47);
        h->acq_units_max = tlm_get_u32(b + 51);
        h->acq_units_last = tlm_get_u32(b + 55);
        h->acq_band_last = b[59];
        h->acq_best_last = b[60];
        h->n_degraded = tlm_get_u32(b + 61);
        h->n_cmd_accepted = tlm_get_u32(b + 65);
        h->n_cmd_rejected = tlm_get_u32(b + 69);
        h->cmd_seq_last = tlm_get_u16(b + 73);
        h->cams_enabled = b[75];
        break;
    }
    case TLM_TYPE_EVENT: {
        tlm_event_t *e = &p->u.event;
        e->cycle = tlm_get_u32(b);
        e->code = tlm_get_u16(b + 4);
        e->severity = b[6];
        e->subject = b[7];
        e->arg0 = get_i32(b + 8);
        e->arg1 = get_i32(b + 12);
        break;
    }
    default:
        break;
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
    if (!payload_valid(pkt)) {
        return TLM_ERR_PAYLOAD;
    }
    const size_t plen = k_payload_len[pkt->type];
    const size_t total = TLM_CCSDS_HDR_LEN + plen;
    if (cap < total) {
        return TLM_ERR_BUFFER;
    }
    const tlm_ccsds_hdr_t h = {0u, 0u, 1u, k_apid[pkt->type], TLM_CCSDS_SEQ_UNSEGMENTED, seq,
                               (uint16_t)(TLM_CCSDS_SEC_LEN + plen - 1u)};
    int rc = tlm_ccsds_pack(&h, out);
    if (rc == TLM_OK) {
        rc = tlm_time_pack(&pkt->time, out + TLM_CCSDS_PRI_LEN);
    }
    if (rc != TLM_OK) {
        return rc;
    }
    pack_payload(pkt, out + TLM_CCSDS_HDR_LEN);
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
    if (len != TLM_CCSDS_HDR_LEN + k_payload_len[type]) {
        return TLM_ERR_PAYLOAD;
    }
    out->type = (tlm_type_t)type;
    out->seq = h.seq;
    rc = tlm_time_unpack(in + TLM_CCSDS_PRI_LEN, &out->time);
    if (rc != TLM_OK) {
        memset(out, 0, sizeof *out);
        return rc;
    }
    unpack_payload(in + TLM_CCSDS_HDR_LEN, out);
    if (!payload_valid(out)) {
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
