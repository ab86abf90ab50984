/* crc16.h -- CRC-16/CCITT-FALSE, the per-frame check of the telemetry link.
 * Polynomial 0x1021, initial value 0xFFFF, no reflection, no final XOR;
 * check value 0x29B1 for the ASCII bytes "123456789". Table-free (bitwise) so
 * the core stays small on the Cortex-M7; at 1.4 kB/s of telemetry it costs
 * nothing measurable.
 */
#ifndef MFNS_TLM_CRC16_H
#define MFNS_TLM_CRC16_H

#include <stddef.h>
#include <stdint.h>

#define TLM_CRC16_INIT 0xFFFFu

/* Continue a CRC over len more bytes (data may be NULL only when len == 0). */
uint16_t tlm_crc16_update(uint16_t crc, const uint8_t *data, size_t len);
/* CRC of one buffer: tlm_crc16_update(TLM_CRC16_INIT, data, len). */
uint16_t tlm_crc16(const uint8_t *data, size_t len);

#endif /* MFNS_TLM_CRC16_H */
