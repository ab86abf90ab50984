/* ccsds.h -- CCSDS Space Packet primary header (CCSDS 133.0-B-2) and the
 * CUC time code of the secondary header (CCSDS 301.0-B-4), big-endian on the
 * wire. See docs/telemetry.md for the bit layout.
 *
 * Primary header, 6 bytes:
 *   bits 0-2 version (0), bit 3 type (0 = telemetry), bit 4 secondary header
 *   flag, bits 5-15 APID; bits 16-17 sequence flags (3 = unsegmented),
 *   bits 18-31 sequence count (14 bits); bits 32-47 packet data length
 *   = (bytes after the primary header) - 1.
 * Secondary header, 6 bytes: CUC with an implicit P-field (4 coarse octets of
 * seconds, 2 fine octets of 2^-16 s) since the flight program's epoch.
 */
#ifndef MFNS_TLM_CCSDS_H
#define MFNS_TLM_CCSDS_H

#include <stdint.h>

#define TLM_CCSDS_PRI_LEN 6u
#define TLM_CCSDS_SEC_LEN 6u
#define TLM_CCSDS_HDR_LEN (TLM_CCSDS_PRI_LEN + TLM_CCSDS_SEC_LEN)
#define TLM_CCSDS_APID_MAX 0x7FFu
#define TLM_CCSDS_APID_IDLE 0x7FFu /* reserved by CCSDS for idle packets */
#define TLM_CCSDS_SEQ_MASK 0x3FFFu
#define TLM_CCSDS_SEQ_HALF 0x2000u /* half the modulus: a jump this far or more is backwards */
_Static_assert(2u * TLM_CCSDS_SEQ_HALF == TLM_CCSDS_SEQ_MASK + 1u, "half of the 2^14 sequence modulus");
#define TLM_CCSDS_SEQ_UNSEGMENTED 3u

typedef struct {
    uint8_t version;   /* 3 bits; 0 for CCSDS version 1 packets */
    uint8_t type;      /* 1 bit; 0 = telemetry */
    uint8_t sec_hdr;   /* 1 bit; 1 = secondary header present */
    uint16_t apid;     /* 11 bits */
    uint8_t seq_flags; /* 2 bits; 3 = unsegmented user data */
    uint16_t seq;      /* 14 bits, per APID, wraps 16383 -> 0 */
    uint16_t data_len; /* packet data field length minus one */
} tlm_ccsds_hdr_t;

/* CUC 4+2: coarse whole seconds, fine in units of 2^-16 s (15.26 us). */
typedef struct {
    uint32_t coarse_s;
    uint16_t fine;
} tlm_time_t;

/* TLM_ERR_ARG when a field exceeds its bit width, TLM_ERR_NULL for NULL. */
int tlm_ccsds_pack(const tlm_ccsds_hdr_t *h, uint8_t out[TLM_CCSDS_PRI_LEN]);
/* Every bit pattern unpacks; the caller validates (tlm_packet_decode does). */
int tlm_ccsds_unpack(const uint8_t in[TLM_CCSDS_PRI_LEN], tlm_ccsds_hdr_t *h);

int tlm_time_pack(const tlm_time_t *t, uint8_t out[TLM_CCSDS_SEC_LEN]);
int tlm_time_unpack(const uint8_t in[TLM_CCSDS_SEC_LEN], tlm_time_t *t);
/* Microseconds since the epoch -> CUC, fine part rounded down. Seconds wrap
 * modulo 2^32 (136 years). */
tlm_time_t tlm_time_from_us(uint64_t us);

/* Big-endian field helpers shared by the packet codec. */
void tlm_put_u16(uint8_t *p, uint16_t v);
void tlm_put_u32(uint8_t *p, uint32_t v);
uint16_t tlm_get_u16(const uint8_t *p);
uint32_t tlm_get_u32(const uint8_t *p);
/* IEEE-754 binary32 from its big-endian wire bytes (bit copy, no rounding; the
 * encoder, tlm_payload_pack, copies a float's bits as it copies a u32's). */
float tlm_get_f32(const uint8_t *p);

#endif /* MFNS_TLM_CCSDS_H */
