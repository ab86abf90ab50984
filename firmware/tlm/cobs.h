/* cobs.h -- Consistent Overhead Byte Stuffing (Cheshire & Baker 1999), the
 * framing of the telemetry link. An encoded block contains no 0x00 byte, so
 * 0x00 on the wire always means "end of frame": a receiver that lost sync
 * (garbage, dropped bytes) is back in step at the next 0x00. Overhead is one
 * byte per started 254 bytes of data (+1 for the delimiter), never more.
 *
 * These are the one-shot buffer functions (encoder side and tests); the
 * receiver decodes byte by byte in tlm_decoder.c with the same rules.
 */
#ifndef MFNS_TLM_COBS_H
#define MFNS_TLM_COBS_H

#include <stddef.h>
#include <stdint.h>

/* Worst-case encoded size of n data bytes, without the 0x00 delimiter. */
#define TLM_COBS_MAX_ENCODED(n) ((n) + ((n) / 254u) + 1u)

/* Encode n bytes of in into out (capacity cap, no delimiter written).
 * *out_len gets the encoded length. TLM_ERR_BUFFER if cap is too small
 * (out then holds garbage), TLM_ERR_NULL for NULL pointers (in may be NULL
 * when n == 0). in and out must not overlap. */
int tlm_cobs_encode(const uint8_t *in, size_t n, uint8_t *out, size_t cap, size_t *out_len);

/* Decode one encoded block (without its delimiter). TLM_ERR_COBS when a 0x00
 * appears inside or a block code runs past the end (a truncated frame),
 * TLM_ERR_BUFFER when the result would exceed cap. */
int tlm_cobs_decode(const uint8_t *in, size_t n, uint8_t *out, size_t cap, size_t *out_len);

#endif /* MFNS_TLM_COBS_H */
