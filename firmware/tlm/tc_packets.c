/* tc_packets.c -- telecommand codec and receiver (see tc_packets.h). */
#include "tc_packets.h"

#include <string.h>

#include "crc16.h"
#include "tlm_err.h"
#include "tlm_packets.h"

#define TC_SEQ_FLAGS TLM_CCSDS_SEQ_UNSEGMENTED

int tc_arg_len(uint8_t opcode)
{
    switch (opcode) {
    case TC_OP_NOOP:
    case TC_OP_RESET_COUNTERS: return 0;
    case TC_OP_SET_MODE:
    case TC_OP_CAMERA_ENABLE:
    case TC_OP_CAMERA_DISABLE: return 1;
    case TC_OP_SET_POSE_HINT: return 24;
    case TC_OP_TABLE_LOAD: return (int)TC_PATH_MAX;
    default: return -1;
    }
}

const char *tc_opcode_name(uint8_t opcode)
{
    switch (opcode) {
    case TC_OP_NOOP: return "NOOP";
    case TC_OP_RESET_COUNTERS: return "RESET_COUNTERS";
    case TC_OP_SET_MODE: return "SET_MODE";
    case TC_OP_SET_POSE_HINT: return "SET_POSE_HINT";
    case TC_OP_CAMERA_ENABLE: return "CAMERA_ENABLE";
    case TC_OP_CAMERA_DISABLE: return "CAMERA_DISABLE";
    case TC_OP_TABLE_LOAD: return "TABLE_LOAD";
    default: return "?";
    }
}

const char *tc_status_name(int status)
{
    switch (status) {
    case TC_OK: return "OK";
    case TC_E_FRAME: return "FRAME";
    case TC_E_OVERSIZE: return "OVERSIZE";
    case TC_E_RUNT: return "RUNT";
    case TC_E_CRC: return "CRC";
    case TC_E_HEADER: return "HEADER";
    case TC_E_LENGTH: return "LENGTH";
    case TC_E_APID: return "APID";
    case TC_E_OPCODE: return "OPCODE";
    case TC_E_ARG_LEN: return "ARG_LEN";
    case TC_E_ARG: return "ARG";
    case TC_E_SEQUENCE: return "SEQUENCE";
    case TC_E_STATE: return "STATE";
    case TC_E_TABLE: return "TABLE";
    case TC_E_NULL: return "NULL";
    default: return "?";
    }
}

const char *tc_strerror(int status)
{
    switch (status) {
    case TC_OK: return "ok";
    case TC_E_FRAME: return "command frame broken (COBS structure, cut short)";
    case TC_E_OVERSIZE: return "command frame too long (no delimiter)";
    case TC_E_RUNT: return "command frame shorter than its headers";
    case TC_E_CRC: return "command frame CRC-16 mismatch";
    case TC_E_HEADER: return "command CCSDS header: version, type, flags";
    case TC_E_LENGTH: return "command length field disagrees with the frame";
    case TC_E_APID: return "not the MFNS command APID";
    case TC_E_OPCODE: return "unknown opcode (or reserved byte not zero)";
    case TC_E_ARG_LEN: return "argument length wrong for the opcode";
    case TC_E_ARG: return "argument out of range";
    case TC_E_SEQUENCE: return "sequence count replayed or out of order";
    case TC_E_STATE: return "command not possible in the current state";
    case TC_E_TABLE: return "calibration table refused (old table kept)";
    case TC_E_NULL: return "NULL pointer or buffer too small";
    default: return "unknown command status";
    }
}

static bool in_range(int32_t v, int32_t lim)
{
    return v >= -lim && v <= lim;
}

/* The argument values both ends agree on (the encoder refuses what the
 * decoder would). */
static tc_status_t check_args(const tc_cmd_t *c)
{
    switch (c->opcode) {
    case TC_OP_NOOP:
    case TC_OP_RESET_COUNTERS: return TC_OK;
    case TC_OP_SET_MODE:
        return c->u.mode == TLM_MODE_STANDBY || c->u.mode == TLM_MODE_ACQUIRE || c->u.mode == TLM_MODE_TRACK ? TC_OK
                                                                                                           : TC_E_ARG;
    case TC_OP_CAMERA_ENABLE:
    case TC_OP_CAMERA_DISABLE: return c->u.camera < TLM_NUM_CAMERAS ? TC_OK : TC_E_ARG;
    case TC_OP_SET_POSE_HINT: {
        const tc_pose_hint_t *p = &c->u.pose;
        for (int i = 0; i < 3; i++) {
            if (!in_range(p->pos_um[i], TC_POS_UM_MAX)) {
                return TC_E_ARG;
            }
        }
        return in_range(p->att_udeg[0], TC_ROLL_YAW_UDEG_MAX) && in_range(p->att_udeg[1], TC_PITCH_UDEG_MAX) &&
                       in_range(p->att_udeg[2], TC_ROLL_YAW_UDEG_MAX)
                   ? TC_OK
                   : TC_E_ARG;
    }
    case TC_OP_TABLE_LOAD: {
        /* non-empty printable ASCII, NUL-terminated inside the field, zeros after:
         * exactly one byte pattern per path */
        size_t n = 0;
        while (n < TC_PATH_MAX && c->u.path[n] != '\0') {
            const unsigned char ch = (unsigned char)c->u.path[n];
            if (ch < 0x20u || ch > 0x7Eu) {
                return TC_E_ARG;
            }
            n++;
        }
        if (n == 0u || n >= TC_PATH_MAX) {
            return TC_E_ARG;
        }
        for (size_t i = n; i < TC_PATH_MAX; i++) {
            if (c->u.path[i] != '\0') {
                return TC_E_ARG;
            }
        }
        return TC_OK;
    }
    default: return TC_E_OPCODE;
    }
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
    const tc_status_t st = check_args(cmd);
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
    uint8_t *a = out + TC_HDR_LEN;
    out[6] = cmd->opcode;
    out[7] = 0u;
    switch (cmd->opcode) {
    case TC_OP_SET_MODE: a[0] = cmd->u.mode; break;
    case TC_OP_CAMERA_ENABLE:
    case TC_OP_CAMERA_DISABLE: a[0] = cmd->u.camera; break;
    case TC_OP_SET_POSE_HINT:
        for (int i = 0; i < 3; i++) {
            tlm_put_u32(a + 4 * i, (uint32_t)cmd->u.pose.pos_um[i]);
            tlm_put_u32(a + 12 + 4 * i, (uint32_t)cmd->u.pose.att_udeg[i]);
        }
        break;
    case TC_OP_TABLE_LOAD: memcpy(a, cmd->u.path, TC_PATH_MAX); break;
    default: break; /* no arguments */
    }
    *out_len = total;
    return TC_OK;
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
    (void)tlm_ccsds_unpack(in, &h); /* every bit pattern unpacks */
    out->seq = h.seq;
    out->have_seq = true;
    if (h.version != 0u || h.type != 1u || h.sec_hdr != 1u || h.seq_flags != TC_SEQ_FLAGS) {
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
    const uint8_t *a = in + TC_HDR_LEN;
    switch (out->opcode) {
    case TC_OP_SET_MODE: out->u.mode = a[0]; break;
    case TC_OP_CAMERA_ENABLE:
    case TC_OP_CAMERA_DISABLE: out->u.camera = a[0]; break;
    case TC_OP_SET_POSE_HINT:
        for (int i = 0; i < 3; i++) {
            out->u.pose.pos_um[i] = (int32_t)tlm_get_u32(a + 4 * i);
            out->u.pose.att_udeg[i] = (int32_t)tlm_get_u32(a + 12 + 4 * i);
        }
        break;
    case TC_OP_TABLE_LOAD: memcpy(out->u.path, a, TC_PATH_MAX); break;
    default: break;
    }
    const tc_status_t st = check_args(out);
    if (st != TC_OK) {
        memset(&out->u, 0, sizeof out->u); /* nothing half-valid */
    }
    return st;
}

tc_status_t tc_frame_encode(const tc_cmd_t *cmd, uint16_t seq, uint8_t *out, size_t cap, size_t *out_len)
{
    if (out == NULL || out_len == NULL) {
        return TC_E_NULL;
    }
    uint8_t frame[TC_MAX_FRAME];
    size_t n = 0;
    const tc_status_t st = tc_packet_encode(cmd, seq, frame, sizeof frame - 2u, &n);
    if (st != TC_OK) {
        return st;
    }
    tlm_put_u16(frame + n, tlm_crc16(frame, n));
    n += 2u;
    size_t enc = 0;
    if (cap < 1u || tlm_cobs_encode(frame, n, out, cap - 1u, &enc) != TLM_OK) {
        return TC_E_NULL;
    }
    out[enc] = 0u;
    *out_len = enc + 1u;
    return TC_OK;
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
    return tc_packet_decode(frame, n - 2u, out);
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
