/* tc_packets.h -- the MFNS telecommands (uplink): CCSDS TC packets in the
 * same framing and check as the telemetry (COBS over packet + CRC-16/CCITT-
 * FALSE, 0x00 delimiter; docs/telemetry.md 1-2). Portable: the ground station
 * encodes with it, the flight program decodes and validates with it.
 * Layouts, opcodes and rejection codes: docs/uplink.md; the XTCE definition
 * ground/mdb/mfns_tc.xml is checked against this file by
 * tests/host/test_tc_xtce.py (a difference fails the test).
 *
 * Packet (all big-endian):
 *   0  6  CCSDS primary header: version 0, type 1 (telecommand), secondary
 *         header flag 1, APID TC_APID, sequence flags 3, 14-bit sequence
 *         count, data length = bytes after the primary header - 1
 *   6  1  opcode (tc_opcode_t); the cFS "function code" position
 *   7  1  reserved, 0 (cFS puts a checksum here; the frame CRC covers us)
 *   8  n  arguments, a fixed layout per opcode (tc_arg_len)
 *
 * Every command has a fixed length, so a ground system can build it from
 * its database alone. The sequence count is the replay guard: the flight
 * side (firmware/app/nav_cmd.h) accepts only counts newer than the last one.
 *
 * Decoding validates completely (header, length, APID, opcode, argument
 * length and every argument value) and fills nothing half-valid: on failure
 * only the header fields that were readable (seq, opcode) are kept, for the
 * rejection event. Status codes are tc_status_t: 0 OK, > 0 the reason, the
 * number that goes on the wire in CMD_REJECTED's arg1.
 */
#ifndef MFNS_TLM_TC_PACKETS_H
#define MFNS_TLM_TC_PACKETS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "ccsds.h"
#include "cobs.h"

#define TC_APID 0x181u               /* the MFNS command APID (telemetry uses 0x101..0x104) */
#define TC_SEC_HDR_LEN 2u            /* opcode + reserved */
#define TC_HDR_LEN (TLM_CCSDS_PRI_LEN + TC_SEC_HDR_LEN)
#define TC_PATH_MAX 64u              /* TABLE_LOAD path field: NUL-padded, at most 63 characters */
#define TC_MAX_ARGS TC_PATH_MAX      /* the largest argument block */
#define TC_MAX_PACKET (TC_HDR_LEN + TC_MAX_ARGS)
#define TC_MAX_FRAME (TC_MAX_PACKET + 2u) /* packet + CRC-16 */
#define TC_MAX_WIRE (TLM_COBS_MAX_ENCODED(TC_MAX_FRAME) + 1u)

/* Opcodes: explicit numbers, the wire values. */
typedef enum {
    TC_OP_NOOP = 1,           /* no arguments: answers CMD_ACCEPTED */
    TC_OP_RESET_COUNTERS = 2, /* no arguments: command counters and camera error count to 0 */
    TC_OP_SET_MODE = 3,       /* u8 mode: tlm_mode_t STANDBY (4), ACQUIRE (1) or TRACK (2) */
    TC_OP_SET_POSE_HINT = 4,  /* 3 x i32 pos_um (r_wb_w), 3 x i32 att_udeg (2-1-3 of C_w_b) */
    TC_OP_CAMERA_ENABLE = 5,  /* u8 camera 0..2 */
    TC_OP_CAMERA_DISABLE = 6, /* u8 camera 0..2 */
    TC_OP_TABLE_LOAD = 7,     /* char path[TC_PATH_MAX], NUL-padded */
    TC_OP_MAX = 7
} tc_opcode_t;

/* Why a command was refused: 0 OK, then explicit numbers (the wire values of
 * CMD_REJECTED arg1). 1-10 and 14 come from the codec, 11-13 from the flight side. */
typedef enum {
    TC_OK = 0,
    TC_E_FRAME = 1,     /* COBS structure broken (a frame cut short) */
    TC_E_OVERSIZE = 2,  /* no delimiter within TC_MAX_FRAME decoded bytes */
    TC_E_RUNT = 3,      /* shorter than the headers + CRC */
    TC_E_CRC = 4,       /* CRC-16 mismatch */
    TC_E_HEADER = 5,    /* version, type, secondary header flag or sequence flags wrong */
    TC_E_LENGTH = 6,    /* length field disagrees with the frame */
    TC_E_APID = 7,      /* not TC_APID */
    TC_E_OPCODE = 8,    /* unknown opcode, or the reserved byte not 0 */
    TC_E_ARG_LEN = 9,   /* argument bytes wrong for the opcode */
    TC_E_ARG = 10,      /* an argument out of range (mode, camera, pose, path) */
    TC_E_SEQUENCE = 11, /* sequence count replayed or older than the last accepted */
    TC_E_STATE = 12,    /* not possible now (e.g. TRACK with no pose to track from) */
    TC_E_TABLE = 13,    /* TABLE_LOAD: the table was refused (TABLE_REFUSED says why) */
    TC_E_NULL = 14,     /* programming error: a NULL pointer or too small a buffer */
    TC_STATUS_MAX = 14
} tc_status_t;

/* Pose limits of SET_POSE_HINT (the wire units of docs/telemetry.md 4.1). */
#define TC_POS_UM_MAX 1000000000   /* |x|, |y|, |z| <= 1 km */
#define TC_ROLL_YAW_UDEG_MAX 180000000
#define TC_PITCH_UDEG_MAX 90000000

typedef struct {
    int32_t pos_um[3];   /* r_wb_w, 0.001 mm */
    int32_t att_udeg[3]; /* roll, pitch, yaw of C_w_b (2-1-3), 1e-6 deg */
} tc_pose_hint_t;

typedef struct {
    uint16_t seq;     /* CCSDS sequence count (valid when have_seq) */
    uint8_t opcode;   /* tc_opcode_t (valid when have_opcode) */
    bool have_seq;    /* the header was readable: seq is the sender's */
    bool have_opcode; /* the opcode byte was readable */
    union {
        uint8_t mode;        /* SET_MODE: tlm_mode_t */
        uint8_t camera;      /* CAMERA_ENABLE / CAMERA_DISABLE */
        tc_pose_hint_t pose; /* SET_POSE_HINT */
        char path[TC_PATH_MAX]; /* TABLE_LOAD, NUL-terminated */
    } u;
} tc_cmd_t;

/* Argument bytes of an opcode; -1 for an unknown opcode. */
int tc_arg_len(uint8_t opcode);
const char *tc_opcode_name(uint8_t opcode);  /* "NOOP", ... "?" */
const char *tc_status_name(int status);      /* "OK", "FRAME", ... "?" */
const char *tc_strerror(int status);         /* one line of English, never NULL */

/* The CCSDS packet of cmd (opcode and arguments) with sequence count seq.
 * Validates the arguments exactly as the decoder does (a command the flight
 * side would refuse for its contents is never encoded). */
tc_status_t tc_packet_encode(const tc_cmd_t *cmd, uint16_t seq, uint8_t *out, size_t cap, size_t *out_len);
/* Parse and validate one CCSDS TC packet of exactly len bytes into *out. */
tc_status_t tc_packet_decode(const uint8_t *in, size_t len, tc_cmd_t *out);
/* The wire frame: COBS(packet || CRC16 big-endian) then 0x00. cap >= TC_MAX_WIRE suffices. */
tc_status_t tc_frame_encode(const tc_cmd_t *cmd, uint16_t seq, uint8_t *out, size_t cap, size_t *out_len);

/* Streaming receiver of TC frames, byte at a time, bounded buffer, no heap.
 * Consecutive 0x00 (idle fill) are ignored; a frame that outgrows the buffer
 * is reported once (TC_E_OVERSIZE) and skipped to the next delimiter. */
typedef struct {
    uint8_t buf[TLM_COBS_MAX_ENCODED(TC_MAX_FRAME)]; /* the COBS bytes of the frame in progress */
    uint16_t len;
    bool discarding;
    uint32_t frames;   /* frames completed (good and bad, oversize included) */
    uint32_t bytes;
} tc_deframer_t;

void tc_deframer_init(tc_deframer_t *d);
/* Feed one byte. Returns true when a frame ended (or overflowed) at this
 * byte: then *status says whether *out holds a valid command (TC_OK) or why
 * the frame was refused (out->have_seq/have_opcode tell what was readable). */
bool tc_deframer_push(tc_deframer_t *d, uint8_t byte, tc_cmd_t *out, tc_status_t *status);

#endif /* MFNS_TLM_TC_PACKETS_H */
