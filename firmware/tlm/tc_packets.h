/* tc_packets.h -- the MFNS telecommands (uplink): CCSDS TC packets in the
 * same framing and check as the telemetry (COBS over packet + CRC-16/CCITT-
 * FALSE, 0x00 delimiter; docs/telemetry.md 1-2). Portable: the ground station
 * encodes with it, the flight program decodes and validates with it.
 * Layouts, opcodes and rejection codes: docs/uplink.md. The XTCE dictionary
 * contract/mfns_tc.xml is the master: the opcodes, rejection codes, argument
 * lengths, layouts and ranges are generated from it by contract/gen_contracts.py
 * (tc_codes_gen.h, tc_packets_gen.c).
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
 * side (firmware/app/nav_cmd_dispatch.h) accepts only counts newer than the last one.
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

#include "firmware/tlm/ccsds.h"
#include "firmware/tlm/cobs.h"

#include "firmware/tlm/generated/tc_codes_gen.h" /* TC_APID, tc_opcode_t, TC_OPCODE_LIST, tc_status_t, ranges, tc_args_t */

#define TC_SEC_HDR_LEN 2u            /* opcode + reserved */
#define TC_HDR_LEN (TLM_CCSDS_PRI_LEN + TC_SEC_HDR_LEN)
#define TC_MAX_PACKET (TC_HDR_LEN + TC_MAX_ARGS)

/* Secured packet (SDLS style, docs/uplink.md 1a; sizes generated from the
 * dictionary's tc_spi_t, tc_arsn_t, tc_mac_t):
 *   0   6  CCSDS primary header (data length covers everything below)
 *   6   2  SPI: the key id, TC_SPI_MIN..TC_SPI_MAX (so byte 6 is 0)
 *   8   8  ARSN: anti-replay sequence number, boot epoch << 32 | count
 *   16  2+n opcode, reserved, arguments (as a plain packet)
 *   ..  16 MAC over every byte before it (computed outside this codec)
 * A plain packet has its opcode (>= 1) at byte 6, a secured one 0 there:
 * that byte tells them apart. The codec frames and parses; it computes and
 * checks no MAC (the portable core has no cryptography): firmware/app/
 * tc_auth.h does. */
#define TC_SEC_PREFIX_LEN (TC_SEC_SPI_LEN + TC_SEC_ARSN_LEN) /* the security header */
#define TC_SEC_OVERHEAD (TC_SEC_PREFIX_LEN + TC_SEC_MAC_LEN) /* bytes a secured packet adds */
#define TC_SEC_SPI_OFF TLM_CCSDS_PRI_LEN
#define TC_SEC_ARSN_OFF (TC_SEC_SPI_OFF + TC_SEC_SPI_LEN)
#define TC_MAX_SEC_PACKET (TC_MAX_PACKET + TC_SEC_OVERHEAD)
#define TC_MAX_AUTH (TC_MAX_SEC_PACKET - TC_SEC_MAC_LEN) /* bytes the MAC covers, at most */
#define TC_MAX_FRAME (TC_MAX_SEC_PACKET + 2u) /* packet + CRC-16 */
#define TC_MAX_WIRE (TLM_COBS_MAX_ENCODED(TC_MAX_FRAME) + 1u)
_Static_assert(TC_SPI_MAX <= 0xFFu, "SPI high byte 0: byte 6 tells a secured packet from a plain one");
_Static_assert(TC_SPI_MIN >= 1u, "SPI 0 is 'no security' (SDLS reserves it)");
_Static_assert(TC_SEC_ARSN_LEN == 8u, "ARSN is a 64-bit epoch << 32 | count");

/* The security header and trailer of a received secured packet. */
typedef struct {
    bool present;                   /* the packet was secured (byte 6 == 0) */
    uint16_t spi;                   /* key id as received (0 or > TC_SPI_MAX: not a key) */
    uint64_t arsn;                  /* anti-replay sequence number */
    uint8_t mac[TC_SEC_MAC_LEN];    /* the MAC as received */
    uint16_t auth_len;              /* bytes of auth the MAC covers */
    uint8_t auth[TC_MAX_AUTH];      /* the packet up to the MAC (header, security header, data) */
} tc_sec_t;

typedef struct {
    uint16_t seq;     /* CCSDS sequence count (valid when have_seq) */
    uint8_t opcode;   /* tc_opcode_t (valid when have_opcode) */
    bool have_seq;    /* the header was readable: seq is the sender's */
    bool have_opcode; /* the opcode byte was readable */
    tc_args_t u;      /* the arguments (tc_codes_gen.h: the XTCE arguments' c_field) */
    tc_sec_t sec;     /* security header and trailer (sec.present: secured packet) */
} tc_cmd_t;

/* Argument bytes of an opcode; -1 for an unknown opcode. */
int tc_arg_len(uint8_t opcode);
/* Arguments (XTCE arguments, as typed by a ground operator) of an opcode; -1 if unknown. */
int tc_arg_count(uint8_t opcode);
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

/* The secured packet of cmd without its MAC: primary header (length
 * counting the MAC), SPI, ARSN, opcode, reserved, arguments. *auth_len gets
 * the bytes written (what the MAC covers); the caller appends
 * TC_SEC_MAC_LEN bytes of MAC at out + *auth_len (cap must leave room:
 * TC_MAX_SEC_PACKET suffices). spi must be TC_SPI_MIN..TC_SPI_MAX. */
tc_status_t tc_sec_packet_encode(const tc_cmd_t *cmd, uint16_t seq, uint16_t spi, uint64_t arsn, uint8_t *out,
                                 size_t cap, size_t *auth_len);
/* Either form: a plain packet (byte 6 >= 1) as tc_packet_decode; a secured
 * one (byte 6 == 0) parsed into out->sec (present, spi, arsn, mac, auth)
 * and its command validated as tc_packet_decode does. TC_E_RUNT when
 * shorter than a secured header + trailer. */
tc_status_t tc_any_packet_decode(const uint8_t *in, size_t len, tc_cmd_t *out);
/* A packet (plain or secured, MAC included) as a wire frame: COBS(packet ||
 * CRC16) then 0x00. */
tc_status_t tc_packet_frame(const uint8_t *pkt, size_t n, uint8_t *out, size_t cap, size_t *out_len);

/* Streaming receiver of TC frames, byte at a time, bounded buffer, no heap.
 * Frames carry plain or secured packets (tc_any_packet_decode).
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

/* For the generated tc_packets_gen.c: every argument of c->opcode in range
 * (TC_OK, TC_E_ARG; TC_E_OPCODE for an unknown opcode); the argument bytes at
 * a (tc_arg_len bytes) from c->u and back; a NUL-padded string field of cap
 * bytes holds 1..cap-1 printable ASCII characters and zeros after them. */
tc_status_t tc_args_check(const tc_cmd_t *c);
void tc_args_pack(const tc_cmd_t *c, uint8_t *a);
void tc_args_unpack(const uint8_t *a, tc_cmd_t *c);
bool tc_string_valid(const char *s, size_t cap);

#endif /* MFNS_TLM_TC_PACKETS_H */
