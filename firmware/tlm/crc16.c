/* crc16.c -- CRC-16/CCITT-FALSE (see crc16.h). */
#include "firmware/tlm/crc16.h"

uint16_t tlm_crc16_update(uint16_t crc, const uint8_t *data, size_t len)
{
    if (data == NULL) {
        return crc;
    }
    for (size_t i = 0; i < len; i++) {
        crc = (uint16_t)(crc ^ (uint16_t)((uint16_t)data[i] << 8));
        for (int b = 0; b < 8; b++) {
            const uint16_t top = (uint16_t)(crc & 0x8000u);
            crc = (uint16_t)(crc << 1);
            if (top != 0u) {
                crc = (uint16_t)(crc ^ 0x1021u);
            }
        }
    }
    return crc;
}

uint16_t tlm_crc16(const uint8_t *data, size_t len)
{
    return tlm_crc16_update(TLM_CRC16_INIT, data, len);
}
