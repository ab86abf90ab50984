/* tlm_txq.h -- bounded transmit queue of wire frames that drops the OLDEST
 * telemetry when full. The navigation loop pushes frames and never waits for
 * the UART: when the link is slow or gone, old frames are thrown away
 * (counted) so the ground always receives the freshest solution. Storage is
 * inside the struct (declare it static); no heap.
 *
 * Frames leave whole: a frame of which some bytes were already written is
 * never dropped (that would corrupt the frame after it on the wire); when
 * room is needed, the oldest frame not yet started is dropped instead.
 */
#ifndef MFNS_TLM_TXQ_H
#define MFNS_TLM_TXQ_H

#include <stddef.h>
#include <stdint.h>

#include "firmware/tlm/tlm_packets.h"

/* 8192: ~27 cycles of nav + three camera packets (298 B each since the
 * protection levels), ~1.4 s of telemetry at the full rate, 89 ms at 921600
 * baud; it was 4096 until the packets grew (issue 23/24), when a link that
 * comes up within half a second began to lose frames. */
#define TLM_TXQ_BYTES 8192u
#define TLM_TXQ_FRAMES 128u /* frame-length slots (power of two) */
/* A queued frame's longest: telemetry (TLM_MAX_WIRE) and the ground's
 * telecommands (TC_MAX_WIRE, an UPLOAD_DATA segment: asserted in ground/uplink.c). */
#define TLM_TXQ_MAX_WIRE 512u

typedef struct {
    uint8_t data[TLM_TXQ_BYTES];
    uint16_t frame_len[TLM_TXQ_FRAMES]; /* unsent bytes of each queued frame, oldest at head_frame */
    uint32_t head;         /* ring index of the first unsent byte */
    uint32_t used;         /* bytes queued */
    uint32_t head_frame;   /* slot of the oldest frame */
    uint32_t frames;       /* frames queued */
    uint8_t head_started;  /* some bytes of the head frame are on the wire */
    uint32_t pushed;       /* frames accepted */
    uint32_t sent;         /* frames completely handed to the transport */
    uint32_t dropped;      /* frames dropped to make room (oldest first) */
    uint32_t dropped_bytes;
} tlm_txq_t;

void tlm_txq_init(tlm_txq_t *q);

/* Queue one frame (copied). Drops the oldest unstarted frames to make room.
 * TLM_ERR_ARG for len 0 or len > TLM_TXQ_MAX_WIRE; TLM_ERR_BUFFER when it cannot
 * fit even after dropping (only a started head frame left): the new frame is
 * then the one dropped, counted in dropped. */
int tlm_txq_push(tlm_txq_t *q, const uint8_t *frame, size_t len);

/* The next contiguous bytes to write (up to the ring wrap); 0 when empty. */
size_t tlm_txq_peek(const tlm_txq_t *q, const uint8_t **data);
/* n bytes of the peeked data were written (n <= the peeked length). */
void tlm_txq_consume(tlm_txq_t *q, size_t n);

/* The link was lost in the middle of the head frame: drop the rest of it
 * (counted in dropped) so the new connection starts on a frame boundary. */
void tlm_txq_discard_partial(tlm_txq_t *q);

size_t tlm_txq_bytes(const tlm_txq_t *q);
size_t tlm_txq_frames(const tlm_txq_t *q);

#endif /* MFNS_TLM_TXQ_H */
