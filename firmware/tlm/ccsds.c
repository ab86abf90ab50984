/* ccsds.c -- CCSDS primary header and CUC time (see ccsds.h). */
#include "firmware/tlm/ccsds.h"

#include <stddef.h>
#include <string.h>

#include "firmware/tlm/tlm_err.h"

void tlm_put_u16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)(v >> 8);
    p[1] = (uint8_t)v;
}

void tlm_put_u32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)(v >> 24);
    p[1] = (uint8_t)(v >> 16);
    p[2] = (uint8_t)(v >> 8);
    p[3] = (uint8_t)v;
}

uint16_t tlm_get_u16(const uint8_t *p)
{
    return (uint16_t)(((uint16_t)p[0] << 8) | p[1]);
}

uint32_t tlm_get_u32(const uint8_t *p)
{
    return ((uint32_t)p[0] << 24) | ((uint32_t)p[1] << 16) | ((uint32_t)p[2] << 8) | (uint32_t)p[3];
}

/* the bit pattern: binary32 on every target we build for */
float tlm_get_f32(const uint8_t *p)
{
    const uint32_t u = tlm_get_u32(p);
    float v;
    memcpy(&v, &u, sizeof v);
    return v;
}

int tlm_ccsds_pack(const tlm_ccsds_hdr_t *h, uint8_t out[TLM_CCSDS_PRI_LEN])
{
    if (h == NULL || out == NULL) {
        return TLM_ERR_NULL;
    }
    if (h->version > 7u || h->type > 1u || h->sec_hdr > 1u || h->apid > TLM_CCSDS_APID_MAX ||
        h->seq_flags > 3u || h->seq > TLM_CCSDS_SEQ_MASK) {
        return TLM_ERR_ARG;
    }
    const uint16_t w0 = (uint16_t)(((unsigned)h->version << 13) | ((unsigned)h->type << 12) |
                                   ((unsigned)h->sec_hdr << 11) | h->apid);
    const uint16_t w1 = (uint16_t)(((unsigned)h->seq_flags << 14) | h->seq);
    tlm_put_u16(out, w0);
    tlm_put_u16(out + 2, w1);
    tlm_put_u16(out + 4, h->data_len);
    return TLM_OK;
}

int tlm_ccsds_unpack(const uint8_t in[TLM_CCSDS_PRI_LEN], tlm_ccsds_hdr_t *h)
{
    if (h == NULL || in == NULL) {
        return TLM_ERR_NULL;
    }
    const uint16_t w0 = tlm_get_u16(in);
    const uint16_t w1 = tlm_get_u16(in + 2);
    h->version = (uint8_t)(w0 >> 13);
    h->type = (uint8_t)((w0 >> 12) & 1u);
    h->sec_hdr = (uint8_t)((w0 >> 11) & 1u);
    h->apid = (uint16_t)(w0 & TLM_CCSDS_APID_MAX);
    h->seq_flags = (uint8_t)(w1 >> 14);
    h->seq = (uint16_t)(w1 & TLM_CCSDS_SEQ_MASK);
    h->data_len = tlm_get_u16(in + 4);
    return TLM_OK;
}

int tlm_time_pack(const tlm_time_t *t, uint8_t out[TLM_CCSDS_SEC_LEN])
{
    if (t == NULL || out == NULL) {
        return TLM_ERR_NULL;
    }
    tlm_put_u32(out, t->coarse_s);
    tlm_put_u16(out + 4, t->fine);
    return TLM_OK;
}

int tlm_time_unpack(const uint8_t in[TLM_CCSDS_SEC_LEN], tlm_time_t *t)
{
    if (t == NULL || in == NULL) {
        return TLM_ERR_NULL;
    }
    t->coarse_s = tlm_get_u32(in);
    t->fine = tlm_get_u16(in + 4);
    return TLM_OK;
}

tlm_time_t tlm_time_from_us(uint64_t us)
{
    tlm_time_t t;
    t.coarse_s = (uint32_t)(us / 1000000u);
    /* (us mod 1e6) * 65536 < 2^36: no overflow in 64 bits. */
    t.fine = (uint16_t)(((us % 1000000u) << 16) / 1000000u);
    return t;
}
