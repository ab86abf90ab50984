/* tcp_forward.h -- mfns-ground's lossless forward of decoded telemetry to a
 * ground system (docs/operators.md "Feed it"): --tcp-forward HOST:PORT listens
 * there and sends every decoded packet, as its CCSDS bytes (the same bytes as
 * --udp-forward's datagrams), as one byte stream to the client that connected:
 * Yamcs' TcpTmDataLink (ground/yamcs/etc, link tm_tcp) connects to it and cuts
 * the stream into packets by their CCSDS length.
 *
 * Why: UDP has no flow control; a receiver that waits for the CPU drops what its
 * socket buffer cannot hold, and the sender never knows (a loaded machine lost
 * packets that way). Over TCP a slow receiver slows the stream instead: packets
 * wait in the kernel's buffers and then in this queue (TCP_FWD_QUEUE_BYTES, a
 * static ring), and are counted as dropped only when the queue is full. Packets
 * wait there too until the first client connects (Yamcs retries every 10 s).
 *
 * Never blocks: the socket is non-blocking; a client that goes away is closed and
 * the next one accepted (the packet it was cut in is skipped, so the stream
 * restarts on a packet boundary). One client at a time. Loopback only unless
 * allow_remote. What it misses: a receiver that accepts the bytes and then loses
 * them (count them at the receiver: the tests compare Yamcs' archive).
 */
#ifndef MFNS_GROUND_TCP_FORWARD_H
#define MFNS_GROUND_TCP_FORWARD_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "firmware/tlm/tlm_packets.h"

/* About three minutes of the demo's telemetry (~50 packets/s of <= 200 bytes). */
#define TCP_FWD_QUEUE_BYTES (2u * 1024u * 1024u)
_Static_assert(TCP_FWD_QUEUE_BYTES >= 16u * TLM_MAX_PACKET, "the queue holds several packets");

typedef struct {
    int lfd;                        /* listening socket, -1 when off */
    int cfd;                        /* the client, -1 when none */
    uint8_t q[TCP_FWD_QUEUE_BYTES]; /* ring of whole packets */
    size_t head, len;               /* oldest byte, bytes queued */
    size_t partial;                 /* bytes of the oldest packet already sent */
    uint32_t queued, sent, dropped, clients;
} tcp_forward_t;

/* Listens on endpoint ("HOST:PORT", udp_parse_endpoint's rules). 0, or -1
 * with a message in err. */
int tcp_forward_open(tcp_forward_t *f, const char *endpoint, bool allow_remote, char *err, size_t err_size);
/* Queues one packet and sends what the client takes now. 0 queued, -1 dropped
 * (queue full, or not encodable). */
int tcp_forward_packet(tcp_forward_t *f, const tlm_packet_t *p);
/* Accepts a client when none is connected and sends what it takes now. */
void tcp_forward_poll(tcp_forward_t *f);
/* Sends what is left for up to max_ms (bounded), then closes. Returns the
 * packets left unsent. */
uint32_t tcp_forward_close(tcp_forward_t *f, unsigned max_ms);

#endif /* MFNS_GROUND_TCP_FORWARD_H */
