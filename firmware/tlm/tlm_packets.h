/* tlm_packets.h -- the MFNS telemetry packets and their encoding: one struct
 * per packet type in wire units, the CCSDS packet codec, and the wire-frame
 * encoder (CCSDS packet + CRC-16/CCITT-FALSE, COBS-stuffed, 0x00-terminated).
 * The flight program and the ground station share this code. Layouts, units
 * and codes: docs/telemetry.md.
 *
 * Fields are integers in named units so the wire is exact and the ground
 * prints exactly what was sent: _um = 0.001 mm, _udeg = 1e-6 deg,
 * _mpx = 0.001 px, _cdb = 0.01 dB, _us = microseconds, _permille = 0.1 %.
 * tlm_scale_i32/_u32/_u16 convert the flight code's floats with rounding
 * and saturation.
 */
#ifndef MFNS_TLM_PACKETS_H
#define MFNS_TLM_PACKETS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "firmware/tlm/ccsds.h"
#include "firmware/tlm/cobs.h"
#include "firmware/tlm/tlm_err.h"

/* Packet types, APIDs, payload lengths (bytes after the 12-byte CCSDS
 * headers), one struct per packet and the numbered codes: generated from the
 * mission database contract/mfns_tm.xml (XTCE) by contract/gen_contracts.py. */
#include "firmware/tlm/generated/tlm_packets_gen.h"

/* Attitude quaternion on the wire: Q1.30 signed (value * 2^30), so every
 * component of a unit quaternion, 1.0 included, fits an int32 with a
 * resolution of 9.3e-10. */
#define TLM_Q30_SCALE TLM_SCALE_Q30_I32 /* the dictionary's q30_i32 calibrator (tlm_codes_gen.h) */
/* The 6x6 pose covariance: its upper triangle, row-major (TLM_NAV_COV_N values). */
#define TLM_NAV_COV_DIM 6u
_Static_assert(TLM_NAV_COV_N == TLM_NAV_COV_DIM * (TLM_NAV_COV_DIM + 1u) / 2u, "covariance: the upper triangle");
#define TLM_MAX_PACKET (TLM_CCSDS_HDR_LEN + TLM_MAX_PAYLOAD)
/* Decoded frame = packet + 2 CRC bytes; the receiver's buffer bound. */
#define TLM_MAX_FRAME (TLM_MAX_PACKET + 2u)
/* Bytes on the wire for the largest frame: COBS worst case + 0x00 delimiter. */
#define TLM_MAX_WIRE (TLM_COBS_MAX_ENCODED(TLM_MAX_FRAME) + 1u)

/* Per-APID 14-bit sequence counters of one sender. */
typedef struct {
    uint16_t next_seq[TLM_NUM_TYPES];
} tlm_encoder_t;

void tlm_encoder_init(tlm_encoder_t *enc);

/* tlm_type_apid, tlm_apid_type, tlm_payload_len, tlm_type_name and the code
 * names (tlm_nav_status_name, tlm_mode_name, tlm_cam_state_name, tlm_event_name,
 * tlm_severity_name, tlm_camera_name): tlm_packets_gen.h. */

/* The CCSDS packet (headers + payload, no CRC, no framing) with sequence count
 * seq. TLM_ERR_PAYLOAD when a field is out of range (unknown enum value,
 * camera > 2, a covariance value not finite), TLM_ERR_ARG for a bad type or seq > 16383. */
int tlm_packet_encode(const tlm_packet_t *pkt, uint16_t seq, uint8_t *out, size_t cap, size_t *out_len);
/* Parse one CCSDS packet of exactly len bytes. On error *out is zeroed and
 * the code says why; on success every field (and struct padding) is set. */
int tlm_packet_decode(const uint8_t *in, size_t len, tlm_packet_t *out);

/* The wire frame of one packet: COBS(packet || CRC16 big-endian) then 0x00.
 * Takes the next sequence count of the packet's APID from enc, writes it to
 * pkt->seq and advances the counter only on success. cap >= TLM_MAX_WIRE
 * always suffices. */
int tlm_frame_encode(tlm_encoder_t *enc, tlm_packet_t *pkt, uint8_t *out, size_t cap, size_t *out_len);

/* value * scale rounded to nearest (ties away from zero) and saturated to the
 * type; NaN gives 0 with *ok (if given) cleared; saturation also clears *ok. */
int32_t tlm_scale_i32(float value, float scale, bool *ok);
uint32_t tlm_scale_u32(float value, float scale, bool *ok);
uint16_t tlm_scale_u16(float value, float scale, bool *ok);

#endif /* MFNS_TLM_PACKETS_H */
