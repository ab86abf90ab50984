/* cobs.c -- COBS encode/decode of whole buffers (see cobs.h). */
#include "firmware/tlm/cobs.h"

#include "firmware/tlm/tlm_err.h"

int tlm_cobs_encode(const uint8_t *in, size_t n, uint8_t *out, size_t cap, size_t *out_len)
{
    if (out == NULL || out_len == NULL || (in == NULL && n > 0)) {
        return TLM_ERR_NULL;
    }
    if (cap < TLM_COBS_MAX_ENCODED(n)) {
        /* Checking the worst case up front keeps the loop free of bounds tests. */
        return TLM_ERR_BUFFER;
    }
    size_t code_at = 0; /* where the current block's code byte goes */
    size_t o = 1;
    uint8_t code = 1;
    for (size_t i = 0; i < n; i++) {
        if (in[i] == 0) {
            out[code_at] = code;
            code_at = o++;
            code = 1;
        } else {
            out[o++] = in[i];
            code++;
            if (code == 0xFF) {
                /* A full block of 254 data bytes: no implied zero follows it. */
                out[code_at] = code;
                code_at = o++;
                code = 1;
            }
        }
    }
    out[code_at] = code;
    *out_len = o;
    return TLM_OK;
}

int tlm_cobs_decode(const uint8_t *in, size_t n, uint8_t *out, size_t cap, size_t *out_len)
{
    if (out == NULL || out_len == NULL || (in == NULL && n > 0)) {
        return TLM_ERR_NULL;
    }
    size_t i = 0;
    size_t o = 0;
    while (i < n) {
        const uint8_t code = in[i++];
        if (code == 0) {
            return TLM_ERR_COBS;
        }
        const size_t run = (size_t)code - 1u;
        if (run > n - i) {
            return TLM_ERR_COBS;
        }
        if (run > cap - o) {
            return TLM_ERR_BUFFER;
        }
        for (size_t k = 0; k < run; k++) {
            if (in[i] == 0) {
                return TLM_ERR_COBS;
            }
            out[o++] = in[i++];
        }
        /* A block shorter than 254 implies a zero, except at the very end. */
        if (code != 0xFF && i < n) {
            if (o >= cap) {
                return TLM_ERR_BUFFER;
            }
            out[o++] = 0;
        }
    }
    *out_len = o;
    return TLM_OK;
}
