/* tcp_forward.c -- see tcp_forward.h. */
#define _DEFAULT_SOURCE /* accept4 */
#define _GNU_SOURCE

#include "ground/tcp_forward.h"

#include <errno.h>
#include <netinet/in.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "ground/udp_forward.h"

#define CCSDS_LEN_OFFSET 4u /* the packet data length field: bytes after the primary header - 1 */
#define CCSDS_PRIMARY 6u
#define CLOSE_STEP_MS 10u

int tcp_forward_open(tcp_forward_t *f, const char *endpoint, bool allow_remote, char *err, size_t err_size)
{
    f->lfd = -1;
    f->cfd = -1;
    f->head = f->len = f->partial = 0;
    f->queued = f->sent = f->dropped = f->clients = 0;
    struct sockaddr_in sa;
    const int fd = inet_endpoint_socket(endpoint, allow_remote, SOCK_STREAM, &sa, err, err_size);
    if (fd < 0) {
        return -1;
    }
    const int one = 1; /* a restart re-binds at once (the last run's connection in TIME_WAIT) */
    (void)setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    if (bind(fd, (const struct sockaddr *)&sa, sizeof sa) != 0 || listen(fd, 1) != 0) {
        (void)snprintf(err, err_size, "listen on %s: %s", endpoint, strerror(errno));
        (void)close(fd);
        return -1;
    }
    f->lfd = fd;
    return 0;
}

static uint8_t at(const tcp_forward_t *f, size_t i)
{
    return f->q[(f->head + i) % TCP_FWD_QUEUE_BYTES];
}

/* Length of the oldest queued packet (the queue holds whole packets only). */
static size_t head_len(const tcp_forward_t *f)
{
    return CCSDS_PRIMARY + 1u + (((size_t)at(f, CCSDS_LEN_OFFSET) << 8) | at(f, CCSDS_LEN_OFFSET + 1u));
}

static void pop_head(tcp_forward_t *f, size_t n)
{
    f->head = (f->head + n) % TCP_FWD_QUEUE_BYTES;
    f->len -= n;
    f->partial = 0;
}

static void drop_client(tcp_forward_t *f)
{
    (void)close(f->cfd);
    f->cfd = -1;
    if (f->partial > 0u) { /* the receiver saw part of it: the next client starts on a boundary */
        pop_head(f, head_len(f));
        f->dropped++;
    }
}

void tcp_forward_poll(tcp_forward_t *f)
{
    if (f == NULL || f->lfd < 0) {
        return;
    }
    if (f->cfd < 0) {
        f->cfd = accept4(f->lfd, NULL, NULL, SOCK_NONBLOCK | SOCK_CLOEXEC);
        if (f->cfd < 0) {
            return; /* nobody yet: packets wait in the queue */
        }
        f->clients++;
    }
    /* bounded: at most every queued packet once */
    for (uint32_t k = 0; k < f->queued + 1u && f->len > 0u; k++) {
        const size_t n = head_len(f);
        uint8_t pkt[TLM_MAX_PACKET];
        for (size_t i = 0; i < n; i++) { /* the ring may wrap inside the packet */
            pkt[i] = at(f, i);
        }
        const ssize_t w = send(f->cfd, pkt + f->partial, n - f->partial, MSG_DONTWAIT | MSG_NOSIGNAL);
        if (w < 0) {
            if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) {
                drop_client(f); /* gone: the next one gets the rest */
            }
            return;
        }
        f->partial += (size_t)w;
        if (f->partial < n) {
            return; /* the kernel's buffer is full: the rest next time */
        }
        pop_head(f, n);
        f->sent++;
    }
}

int tcp_forward_packet(tcp_forward_t *f, const tlm_packet_t *p)
{
    if (f == NULL || f->lfd < 0 || p == NULL) {
        return -1;
    }
    uint8_t pkt[TLM_MAX_PACKET];
    size_t n = 0;
    /* the decoder kept the sequence count: the same bytes as on the link */
    if (tlm_packet_encode(p, p->seq, pkt, sizeof pkt, &n) != TLM_OK || n > TCP_FWD_QUEUE_BYTES - f->len) {
        f->dropped++;
        tcp_forward_poll(f);
        return -1;
    }
    for (size_t i = 0; i < n; i++) {
        f->q[(f->head + f->len + i) % TCP_FWD_QUEUE_BYTES] = pkt[i];
    }
    f->len += n;
    f->queued++;
    tcp_forward_poll(f);
    return 0;
}

uint32_t tcp_forward_close(tcp_forward_t *f, unsigned max_ms)
{
    if (f == NULL || f->lfd < 0) {
        return 0;
    }
    const struct timespec step = {0, (long)CLOSE_STEP_MS * 1000000L};
    for (unsigned t = 0; t < max_ms && f->len > 0u; t += CLOSE_STEP_MS) {
        tcp_forward_poll(f);
        if (f->len > 0u) {
            (void)nanosleep(&step, NULL);
        }
    }
    uint32_t left = 0;
    for (size_t off = 0; off < f->len; left++) { /* whole packets still queued */
        const size_t saved = f->head;
        f->head = (saved + off) % TCP_FWD_QUEUE_BYTES;
        const size_t n = head_len(f);
        f->head = saved;
        off += n;
    }
    if (f->cfd >= 0) {
        (void)close(f->cfd);
        f->cfd = -1;
    }
    (void)close(f->lfd);
    f->lfd = -1;
    return left;
}
