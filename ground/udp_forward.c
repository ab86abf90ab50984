/* udp_forward.c -- see udp_forward.h. */
#define _DEFAULT_SOURCE /* inet_pton, struct ip_mreq under -std=c11 */

#include "ground/udp_forward.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#define LOOPBACK_NET 0x7F000000u  /* 127.0.0.0/8 */
#define LOOPBACK_MASK 0xFF000000u
#define TC_CFS_CHECKSUM_BYTE 7u /* cFS command secondary header: function code (6), checksum (7) */

int udp_parse_endpoint(const char *s, bool allow_remote, uint32_t *addr_be, uint16_t *port, char *err,
                       size_t err_size)
{
    const char *colon = s != NULL ? strrchr(s, ':') : NULL;
    if (colon == NULL || colon == s || (size_t)(colon - s) >= 64u) {
        (void)snprintf(err, err_size, "'%s': expected HOST:PORT (e.g. 127.0.0.1:10015)", s ? s : "");
        return -1;
    }
    char host[64];
    memcpy(host, s, (size_t)(colon - s));
    host[colon - s] = '\0';
    char *end = NULL;
    errno = 0;
    const unsigned long p = strtoul(colon + 1, &end, 10);
    if (errno != 0 || end == colon + 1 || *end != '\0' || p == 0u || p > 65535u) {
        (void)snprintf(err, err_size, "'%s': port must be 1..65535", s);
        return -1;
    }
    struct in_addr a;
    if (strcmp(host, "localhost") == 0) {
        a.s_addr = htonl(0x7F000001u);
    } else if (inet_pton(AF_INET, host, &a) != 1) {
        (void)snprintf(err, err_size, "'%s': host must be an IPv4 address or localhost", s);
        return -1;
    }
    if (!allow_remote && (ntohl(a.s_addr) & LOOPBACK_MASK) != LOOPBACK_NET) {
        (void)snprintf(err, err_size, "'%s' is not a loopback address (127.x.x.x): refused; "
                       "--udp-allow-remote allows it", s);
        return -1;
    }
    *addr_be = a.s_addr;
    *port = (uint16_t)p;
    return 0;
}

int inet_endpoint_socket(const char *endpoint, bool allow_remote, int type, struct sockaddr_in *sa, char *err,
                         size_t err_size)
{
    uint32_t addr = 0;
    uint16_t port = 0;
    if (udp_parse_endpoint(endpoint, allow_remote, &addr, &port, err, err_size) != 0) {
        return -1;
    }
    const int fd = socket(AF_INET, type | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0) {
        (void)snprintf(err, err_size, "socket: %s", strerror(errno));
        return -1;
    }
    memset(sa, 0, sizeof *sa);
    sa->sin_family = AF_INET;
    sa->sin_port = htons(port);
    sa->sin_addr.s_addr = addr;
    return fd;
}

static int udp_socket(const char *endpoint, bool allow_remote, bool bind_it, char *err, size_t err_size)
{
    struct sockaddr_in sa;
    const int fd = inet_endpoint_socket(endpoint, allow_remote, SOCK_DGRAM, &sa, err, err_size);
    if (fd < 0) {
        return -1;
    }
    const int rc = bind_it ? bind(fd, (const struct sockaddr *)&sa, sizeof sa)
                           : connect(fd, (const struct sockaddr *)&sa, sizeof sa);
    if (rc != 0) {
        (void)snprintf(err, err_size, "%s %s: %s", bind_it ? "bind" : "connect", endpoint, strerror(errno));
        (void)close(fd);
        return -1;
    }
    return fd;
}

int udp_forward_open(udp_forward_t *f, const char *endpoint, bool allow_remote, char *err, size_t err_size)
{
    memset(f, 0, sizeof *f);
    f->fd = udp_socket(endpoint, allow_remote, false, err, err_size);
    return f->fd < 0 ? -1 : 0;
}

int udp_forward_packet(udp_forward_t *f, const tlm_packet_t *p)
{
    if (f == NULL || f->fd < 0 || p == NULL) {
        return -1;
    }
    uint8_t pkt[TLM_MAX_PACKET];
    size_t n = 0;
    /* the decoder kept the sequence count: the same bytes as on the link */
    if (tlm_packet_encode(p, p->seq, pkt, sizeof pkt, &n) != TLM_OK) {
        f->errors++;
        return -1;
    }
    /* ECONNREFUSED (nobody listening yet) or a full buffer: counted, never waited on */
    if (send(f->fd, pkt, n, MSG_DONTWAIT) != (ssize_t)n) {
        f->errors++;
        return -1;
    }
    f->sent++;
    return 0;
}

void udp_forward_close(udp_forward_t *f)
{
    if (f != NULL && f->fd >= 0) {
        (void)close(f->fd);
        f->fd = -1;
    }
}

int udp_tc_open(udp_tc_in_t *t, const char *endpoint, bool allow_remote, char *err, size_t err_size)
{
    memset(t, 0, sizeof *t);
    t->fd = udp_socket(endpoint, allow_remote, true, err, err_size);
    return t->fd < 0 ? -1 : 0;
}

/* Yamcs' CfsCommandPostprocessor (ground/yamcs/etc) numbers each command and puts the
 * cFS checksum in byte 7, where our packet has its reserved byte (the cFS function code is
 * byte 6: our opcode): 0xFF xor every byte of the packet, the checksum byte taken as 0. A
 * plain packet (byte 6, the opcode, not 0; a secured one has its SPI's high byte, 0, there)
 * whose byte 7 is not 0 must carry a right checksum: it is checked, then cleared (the
 * flight's frame has its own CRC-16 and wants the reserved byte 0). false: it is wrong. */
static bool cfs_checksum_clear(uint8_t *pkt, size_t n)
{
    if (n <= TC_CFS_CHECKSUM_BYTE || pkt[TC_CFS_CHECKSUM_BYTE - 1u] == 0u || pkt[TC_CFS_CHECKSUM_BYTE] == 0u) {
        return true; /* too short (the decoder says why), secured, or no checksum */
    }
    uint8_t x = 0xFFu;
    for (size_t i = 0; i < n; i++) {
        x ^= pkt[i];
    }
    if (x != 0u) {
        return false;
    }
    pkt[TC_CFS_CHECKSUM_BYTE] = 0u;
    return true;
}

int udp_tc_poll(udp_tc_in_t *t, tc_cmd_t *cmd, tc_status_t *status)
{
    if (t == NULL || t->fd < 0) {
        return 0;
    }
    uint8_t buf[TC_MAX_PACKET + 1u]; /* one byte more: an oversize datagram shows as too long */
    const ssize_t n = recv(t->fd, buf, sizeof buf, MSG_DONTWAIT);
    if (n < 0) {
        return 0; /* EAGAIN: nothing waiting (other errors: retried next poll) */
    }
    t->received++;
    if (!cfs_checksum_clear(buf, (size_t)n)) {
        t->refused++;
        *status = TC_E_CRC;
        return -1;
    }
    *status = tc_packet_decode(buf, (size_t)n, cmd);
    if (*status != TC_OK) {
        t->refused++;
        return -1;
    }
    return 1;
}

void udp_tc_close(udp_tc_in_t *t)
{
    if (t != NULL && t->fd >= 0) {
        (void)close(t->fd);
        t->fd = -1;
    }
}

int udp_tc_open_unix(udp_tc_in_t *t, const char *path, char *err, size_t err_size)
{
    memset(t, 0, sizeof *t);
    t->fd = -1;
    struct sockaddr_un sa;
    memset(&sa, 0, sizeof sa);
    sa.sun_family = AF_UNIX;
    if (strlen(path) >= sizeof sa.sun_path) {
        (void)snprintf(err, err_size, "%s: path longer than %zu bytes", path, sizeof sa.sun_path - 1u);
        return -1;
    }
    memcpy(sa.sun_path, path, strlen(path) + 1u);
    struct stat st;
    if (lstat(path, &st) == 0) {
        if (!S_ISSOCK(st.st_mode)) {
            (void)snprintf(err, err_size, "%s exists and is not a socket (not replaced)", path);
            return -1;
        }
        (void)unlink(path); /* a stale socket of an earlier run */
    }
    const int fd = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    if (fd < 0) {
        (void)snprintf(err, err_size, "socket: %s", strerror(errno));
        return -1;
    }
    /* created 0600 from the start (umask), so no other user can connect in the
     * window before a chmod */
    const mode_t old = umask(0177);
    const int rc = bind(fd, (const struct sockaddr *)&sa, sizeof sa);
    const int bind_errno = errno;
    (void)umask(old);
    if (rc != 0) {
        (void)snprintf(err, err_size, "%s: %s", path, strerror(bind_errno));
        (void)close(fd);
        return -1;
    }
    if (chmod(path, 0600) != 0) {
        (void)snprintf(err, err_size, "%s: chmod: %s", path, strerror(errno));
        (void)close(fd);
        (void)unlink(path);
        return -1;
    }
    t->fd = fd;
    return 0;
}

void udp_tc_close_unix(udp_tc_in_t *t, const char *path)
{
    if (t != NULL && t->fd >= 0) {
        udp_tc_close(t);
        if (path != NULL) {
            (void)unlink(path);
        }
    }
}
