/* txq_drain.h -- empties a transmit queue of whole frames (tlm_txq.h) into a
 * byte transport (drivers/uart/uart.h), without blocking. The transport only
 * moves bytes; which bytes go next, and what a lost link means for a frame
 * half on the wire, is decided here, on the queue's side.
 *
 * Used wherever a program sends queued frames: the flight program's
 * telemetry (nav_tlm.h), the ground station's uplink and mfns-tlm-gen.
 */
#ifndef MFNS_TXQ_DRAIN_H
#define MFNS_TXQ_DRAIN_H

#include <stdint.h>

#include "firmware/tlm/tlm_txq.h"
#include "drivers/uart/uart.h"

/* Move queued frames to the port until it is full or the queue is empty.
 * On a disconnect the rest of a half-sent frame is discarded (the queue
 * counts it) so the next connection starts on a frame boundary. Returns
 * MFNS_UART_OK, or MFNS_UART_ERR_ARG/CLOSED/GONE/IO from the transport
 * (frames then stay queued, dropping oldest as new ones arrive). */
int txq_drain(tlm_txq_t *q, mfns_uart_t *u, uint64_t now_ms);

#endif /* MFNS_TXQ_DRAIN_H */
