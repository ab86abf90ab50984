/* udp_forward.h -- mfns-ground's UDP side for a ground system such as Yamcs
 * (docs/uplink.md "Yamcs"):
 *   udp_forward_t  every decoded telemetry packet, as its CCSDS bytes (one
 *                  datagram each, re-encoded by the portable codec with the
 *                  sequence count it arrived with: byte-identical), to
 *                  HOST:PORT;
 *   udp_tc_in_t    CCSDS TC packets received as datagrams on HOST:PORT (the
 *                  ground system's TC link), validated with tc_packet_decode
 *                  before they are sent up. A cFS checksum in byte 7 (Yamcs'
 *                  CfsCommandPostprocessor; the reserved byte of our layout)
 *                  is checked and cleared first: a wrong one is refused (CRC).
 * Both are loopback-only unless allow_remote: the ground system runs on the
 * same machine, and a command socket open to a network is a hazard.
 * Non-blocking; a datagram nobody receives is counted, never waited on.
 */
#ifndef MFNS_GROUND_UDP_FORWARD_H
#define MFNS_GROUND_UDP_FORWARD_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "firmware/tlm/tc_packets.h"
#include "firmware/tlm/tlm_packets.h"

typedef struct {
    int fd; /* -1 when off */
    uint32_t sent, errors;
} udp_forward_t;

typedef struct {
    int fd; /* -1 when off */
    uint32_t received, refused;
} udp_tc_in_t;

/* "HOST:PORT" (IPv4 dotted quad or "localhost") into a sockaddr_in-ready
 * address and port. -1 with a message in err when malformed, or when not
 * loopback (127.0.0.0/8) and !allow_remote. */
int udp_parse_endpoint(const char *s, bool allow_remote, uint32_t *addr_be, uint16_t *port, char *err,
                       size_t err_size);

/* A non-blocking, close-on-exec IPv4 socket of type (SOCK_DGRAM or
 * SOCK_STREAM) for endpoint (udp_parse_endpoint's rules), its address in *sa
 * for the caller's bind or connect: the fd, or -1 with a message in err. One
 * set-up for the UDP forwarder, the UDP telecommand input and the TCP
 * forwarder. */
struct sockaddr_in;
int inet_endpoint_socket(const char *endpoint, bool allow_remote, int type, struct sockaddr_in *sa, char *err,
                         size_t err_size);

int udp_forward_open(udp_forward_t *f, const char *endpoint, bool allow_remote, char *err, size_t err_size);
/* Sends one packet; 0 sent, -1 not (counted). */
int udp_forward_packet(udp_forward_t *f, const tlm_packet_t *p);
void udp_forward_close(udp_forward_t *f);

int udp_tc_open(udp_tc_in_t *t, const char *endpoint, bool allow_remote, char *err, size_t err_size);
/* One waiting datagram, if any: 1 with a valid command in *cmd, 0 none
 * waiting, -1 a datagram refused (*status says why). Never blocks. */
int udp_tc_poll(udp_tc_in_t *t, tc_cmd_t *cmd, tc_status_t *status);
void udp_tc_close(udp_tc_in_t *t);

/* The same intake on a Unix datagram socket at path (--tc-socket): created
 * with mode 0600 (only this user's processes may send; the operator may
 * chmod/chgrp it to widen that), refused when path exists and is not a
 * socket; a stale socket is replaced. Removed again by udp_tc_close_unix. */
int udp_tc_open_unix(udp_tc_in_t *t, const char *path, char *err, size_t err_size);
void udp_tc_close_unix(udp_tc_in_t *t, const char *path);

#endif /* MFNS_GROUND_UDP_FORWARD_H */
