/* txq_drain.c -- see txq_drain.h. */
#include "firmware/linux/txq_drain.h"

#include <stddef.h>

int txq_drain(tlm_txq_t *q, mfns_uart_t *u, uint64_t now_ms)
{
    if (u == NULL || q == NULL) {
        return MFNS_UART_ERR_ARG;
    }
    /* Bounded: each pass either writes at least one byte of a finite queue
     * or stops; at most the queue's size in passes. */
    for (uint32_t pass = 0; pass < TLM_TXQ_BYTES; pass++) {
        const uint8_t *p = NULL;
        const size_t n = tlm_txq_peek(q, &p);
        if (n == 0u) {
            return MFNS_UART_OK;
        }
        size_t w = 0;
        const int rc = mfns_uart_write(u, p, n, &w, now_ms);
        if (rc == MFNS_UART_ERR_GONE) {
            tlm_txq_discard_partial(q);
            return rc;
        }
        if (rc != MFNS_UART_OK) {
            return rc;
        }
        tlm_txq_consume(q, w);
        if (w < n) {
            return MFNS_UART_OK; /* port full: come back next cycle */
        }
    }
    return MFNS_UART_OK;
}
