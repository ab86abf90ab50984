/* uart.c -- transport common layer (connection state, retry cadence) and the
 * POSIX file-descriptor backend. See uart.h. */
#define _DEFAULT_SOURCE /* cfmakeraw, cfsetspeed under -std=c11 */

#include "drivers/uart/uart.h"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <string.h>
#include <sys/stat.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

uint64_t mfns_uart_now_ms(void)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_MONOTONIC, &ts) != 0) {
        return 0;
    }
    return (uint64_t)ts.tv_sec * 1000u + (uint64_t)ts.tv_nsec / 1000000u;
}

const char *mfns_uart_strerror(int err)
{
    switch (err) {
    case MFNS_UART_OK: return "ok";
    case MFNS_UART_ERR_ARG: return "uart: bad argument";
    case MFNS_UART_ERR_OPEN: return "uart: cannot open the port";
    case MFNS_UART_ERR_CONFIG: return "uart: port refused the 8N1/baud/raw configuration";
    case MFNS_UART_ERR_GONE: return "uart: the port vanished (will re-open)";
    case MFNS_UART_ERR_IO: return "uart: read/write error";
    case MFNS_UART_ERR_CLOSED: return "uart: not connected (waiting to re-open)";
    case MFNS_UART_EOF: return "uart: end of input";
    default: return "uart: unknown error";
    }
}

static bool errno_means_gone(int e)
{
    return e == EIO || e == ENODEV || e == ENXIO || e == EPIPE || e == EBADF || e == ENOENT;
}

static speed_t baud_constant(uint32_t baud)
{
    switch (baud) {
    case 9600: return B9600;
    case 19200: return B19200;
    case 38400: return B38400;
    case 57600: return B57600;
    case 115200: return B115200;
    case 230400: return B230400;
    case 460800: return B460800;
    case 921600: return B921600;
    case 1000000: return B1000000;
    case 1500000: return B1500000;
    case 2000000: return B2000000;
    case 3000000: return B3000000;
    default: return (speed_t)0;
    }
}

/* Raw 8N1, no flow control, no echo, no line editing or CR/LF mapping:
 * telemetry bytes pass unchanged. */
static int make_raw(int fd, uint32_t baud)
{
    struct termios t;
    if (tcgetattr(fd, &t) != 0) {
        return MFNS_UART_ERR_CONFIG;
    }
    cfmakeraw(&t);
    t.c_cflag &= (tcflag_t)~(CSTOPB | PARENB | CRTSCTS);
    t.c_cflag |= CLOCAL | CREAD | CS8;
    t.c_iflag &= (tcflag_t)~(IXON | IXOFF | IXANY);
    t.c_cc[VMIN] = 0;
    t.c_cc[VTIME] = 0;
    if (baud != 0u) {
        const speed_t s = baud_constant(baud);
        if (s == (speed_t)0 || cfsetispeed(&t, s) != 0 || cfsetospeed(&t, s) != 0) {
            return MFNS_UART_ERR_CONFIG;
        }
    }
    if (tcsetattr(fd, TCSANOW, &t) != 0) {
        return MFNS_UART_ERR_CONFIG;
    }
    return MFNS_UART_OK;
}

static int set_nonblock(int fd)
{
    const int fl = fcntl(fd, F_GETFL);
    if (fl < 0 || fcntl(fd, F_SETFL, fl | O_NONBLOCK) != 0) {
        return MFNS_UART_ERR_CONFIG;
    }
    return MFNS_UART_OK;
}

static int fd_connect(mfns_uart_t *u)
{
    int acc = u->dir == MFNS_UART_READ ? O_RDONLY : (u->dir == MFNS_UART_WRITE ? O_WRONLY : O_RDWR);
    struct stat pre;
    if (u->dir == MFNS_UART_READ && stat(u->path, &pre) == 0 && S_ISFIFO(pre.st_mode)) {
        /* A FIFO reader that also holds it open for writing never sees EOF
         * between writers, and writers can always open it (Linux). */
        acc = O_RDWR;
    }
    const int fd = open(u->path, acc | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
    if (fd < 0) {
        u->last_errno = errno;
        return MFNS_UART_ERR_OPEN;
    }
    struct stat st;
    if (fstat(fd, &st) != 0) {
        u->last_errno = errno;
        close(fd);
        return MFNS_UART_ERR_OPEN;
    }
    u->reopenable = !S_ISREG(st.st_mode);
    u->is_tty = isatty(fd) != 0;
    if (u->is_tty) {
        const int rc = make_raw(fd, u->baud);
        if (rc != MFNS_UART_OK) {
            u->last_errno = errno;
            close(fd);
            return rc;
        }
    }
    u->fd = fd;
    u->owns_fd = true;
    return MFNS_UART_OK;
}

static void backend_disconnect(mfns_uart_t *u)
{
    if (u->kind == MFNS_UART_SERIAL) {
        mfns_uart_serial_disconnect(u);
    } else if (u->fd >= 0) {
        if (u->owns_fd) {
            close(u->fd);
        }
        u->fd = -1;
    }
    u->connected = false;
}

static int backend_connect(mfns_uart_t *u)
{
    return u->kind == MFNS_UART_SERIAL ? mfns_uart_serial_connect(u) : fd_connect(u);
}

static void init_common(mfns_uart_t *u, mfns_uart_kind_t kind, uint32_t baud, mfns_uart_dir_t dir)
{
    memset(u, 0, sizeof *u);
    u->kind = kind;
    u->dir = dir;
    u->baud = baud;
    u->fd = -1;
    u->retry_min_ms = MFNS_UART_RETRY_MIN_MS;
    u->retry_max_ms = MFNS_UART_RETRY_MAX_MS;
    u->retry_ms = u->retry_min_ms;
    if (dir & MFNS_UART_WRITE) {
        (void)signal(SIGPIPE, SIG_IGN);
    }
}

static int open_by_path(mfns_uart_t *u, mfns_uart_kind_t kind, const char *path, uint32_t baud,
                        mfns_uart_dir_t dir)
{
    if (u == NULL || path == NULL || dir < MFNS_UART_READ || dir > MFNS_UART_RW ||
        strlen(path) >= MFNS_UART_PATH_MAX || path[0] == '\0') {
        return MFNS_UART_ERR_ARG;
    }
    init_common(u, kind, baud, dir);
    memcpy(u->path, path, strlen(path) + 1u);
    u->reopenable = true;
    const int rc = backend_connect(u);
    if (rc != MFNS_UART_OK) {
        /* Still usable: write/read/service retry at the cadence. */
        u->next_retry_ms = mfns_uart_now_ms() + u->retry_ms;
        u->stats.open_failures++;
        return rc;
    }
    u->connected = true;
    return MFNS_UART_OK;
}

int mfns_uart_open_serial(mfns_uart_t *u, const char *port, uint32_t baud, mfns_uart_dir_t dir)
{
    if (baud == 0u) {
        return MFNS_UART_ERR_ARG;
    }
    return open_by_path(u, MFNS_UART_SERIAL, port, baud, dir);
}

int mfns_uart_open_path(mfns_uart_t *u, const char *path, uint32_t baud, mfns_uart_dir_t dir)
{
    return open_by_path(u, MFNS_UART_FD, path, baud, dir);
}

int mfns_uart_open_auto(mfns_uart_t *u, const char *path, uint32_t baud, mfns_uart_dir_t dir)
{
    if (path != NULL && baud != 0u && mfns_uart_serial_exists(path)) {
        return mfns_uart_open_serial(u, path, baud, dir);
    }
    return mfns_uart_open_path(u, path, baud, dir);
}

int mfns_uart_attach_fd(mfns_uart_t *u, int fd, bool owns, mfns_uart_dir_t dir)
{
    if (u == NULL || fd < 0 || dir < MFNS_UART_READ || dir > MFNS_UART_RW) {
        return MFNS_UART_ERR_ARG;
    }
    init_common(u, MFNS_UART_FD, 0u, dir);
    u->is_tty = isatty(fd) != 0;
    if (set_nonblock(fd) != MFNS_UART_OK || (u->is_tty && make_raw(fd, 0u) != MFNS_UART_OK)) {
        u->last_errno = errno;
        return MFNS_UART_ERR_CONFIG;
    }
    u->fd = fd;
    u->owns_fd = owns;
    u->reopenable = false;
    u->connected = true;
    return MFNS_UART_OK;
}

int mfns_uart_set_retry(mfns_uart_t *u, uint32_t min_ms, uint32_t max_ms)
{
    if (u == NULL || min_ms == 0u || max_ms < min_ms) {
        return MFNS_UART_ERR_ARG;
    }
    u->retry_min_ms = min_ms;
    u->retry_max_ms = max_ms;
    u->retry_ms = min_ms;
    return MFNS_UART_OK;
}

static void mark_lost(mfns_uart_t *u, uint64_t now_ms)
{
    backend_disconnect(u);
    u->stats.disconnects++;
    u->retry_ms = u->retry_min_ms;
    u->next_retry_ms = now_ms + u->retry_ms;
}

int mfns_uart_service(mfns_uart_t *u, uint64_t now_ms)
{
    if (u == NULL) {
        return MFNS_UART_ERR_ARG;
    }
    if (u->connected) {
        return MFNS_UART_OK;
    }
    if (!u->reopenable || u->path[0] == '\0') {
        return MFNS_UART_ERR_CLOSED;
    }
    if (now_ms < u->next_retry_ms) {
        return MFNS_UART_ERR_CLOSED;
    }
    if (backend_connect(u) != MFNS_UART_OK) {
        u->stats.open_failures++;
        /* Back-off doubles up to the maximum: a missing port costs a few
         * open() calls per second at most, never a busy loop. */
        u->retry_ms = (u->retry_ms > u->retry_max_ms / 2u) ? u->retry_max_ms : u->retry_ms * 2u;
        u->next_retry_ms = now_ms + u->retry_ms;
        return MFNS_UART_ERR_CLOSED;
    }
    u->connected = true;
    u->stats.reconnects++;
    u->retry_ms = u->retry_min_ms;
    return MFNS_UART_OK;
}

static int fd_write(mfns_uart_t *u, const uint8_t *data, size_t n, size_t *written)
{
    *written = 0;
    for (int attempt = 0; attempt < 3; attempt++) { /* EINTR retries, bounded */
        const ssize_t w = write(u->fd, data, n);
        if (w >= 0) {
            *written = (size_t)w;
            return MFNS_UART_OK;
        }
        if (errno == EAGAIN || errno == EWOULDBLOCK) {
            return MFNS_UART_OK;
        }
        if (errno != EINTR) {
            u->last_errno = errno;
            return errno_means_gone(errno) ? MFNS_UART_ERR_GONE : MFNS_UART_ERR_IO;
        }
    }
    return MFNS_UART_OK;
}

int mfns_uart_write(mfns_uart_t *u, const uint8_t *data, size_t n, size_t *written, uint64_t now_ms)
{
    if (u == NULL || written == NULL || (data == NULL && n > 0u) || !(u->dir & MFNS_UART_WRITE)) {
        return MFNS_UART_ERR_ARG;
    }
    *written = 0;
    const int s = mfns_uart_service(u, now_ms);
    if (s != MFNS_UART_OK) {
        return s;
    }
    if (n == 0u) {
        return MFNS_UART_OK;
    }
    const int rc = u->kind == MFNS_UART_SERIAL ? mfns_uart_serial_write(u, data, n, written)
                                               : fd_write(u, data, n, written);
    if (rc == MFNS_UART_ERR_GONE) {
        mark_lost(u, now_ms);
        return rc;
    }
    u->stats.bytes_written += *written;
    if (rc == MFNS_UART_OK && *written < n) {
        u->stats.short_writes++;
    }
    return rc;
}

static int fd_read(mfns_uart_t *u, uint8_t *buf, size_t cap, size_t *got, int timeout_ms)
{
    struct pollfd pfd = {u->fd, POLLIN, 0};
    const int pr = poll(&pfd, 1, timeout_ms);
    if (pr < 0) {
        return errno == EINTR ? MFNS_UART_OK : MFNS_UART_ERR_IO;
    }
    if (pr == 0) {
        return MFNS_UART_OK;
    }
    if (pfd.revents & POLLNVAL) {
        return MFNS_UART_ERR_GONE;
    }
    const ssize_t r = read(u->fd, buf, cap);
    if (r > 0) {
        *got = (size_t)r;
        return MFNS_UART_OK;
    }
    if (r == 0) {
        /* A tty or FIFO that reads 0 has lost its peer: wait for it to come
         * back. A regular file or an attached pipe has ended. */
        return u->reopenable ? MFNS_UART_ERR_GONE : MFNS_UART_EOF;
    }
    if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) {
        return MFNS_UART_OK;
    }
    u->last_errno = errno;
    if (errno_means_gone(errno)) {
        return u->reopenable ? MFNS_UART_ERR_GONE : MFNS_UART_EOF;
    }
    return MFNS_UART_ERR_IO;
}

int mfns_uart_read(mfns_uart_t *u, uint8_t *buf, size_t cap, size_t *got, int timeout_ms, uint64_t now_ms)
{
    if (u == NULL || buf == NULL || got == NULL || cap == 0u || timeout_ms < 0 || !(u->dir & MFNS_UART_READ)) {
        return MFNS_UART_ERR_ARG;
    }
    *got = 0;
    const int s = mfns_uart_service(u, now_ms);
    if (s != MFNS_UART_OK) {
        if (!u->reopenable) {
            return MFNS_UART_EOF;
        }
        /* Sleep until the next attempt or the timeout, whichever is first. */
        uint64_t wait = u->next_retry_ms > now_ms ? u->next_retry_ms - now_ms : 0u;
        if (wait > (uint64_t)timeout_ms) {
            wait = (uint64_t)timeout_ms;
        }
        (void)poll(NULL, 0, (int)wait);
        return s;
    }
    const int rc = u->kind == MFNS_UART_SERIAL ? mfns_uart_serial_read(u, buf, cap, got, timeout_ms)
                                               : fd_read(u, buf, cap, got, timeout_ms);
    if (rc == MFNS_UART_ERR_GONE) {
        mark_lost(u, now_ms);
        return rc;
    }
    if (rc == MFNS_UART_EOF) {
        backend_disconnect(u);
        u->reopenable = false;
        return rc;
    }
    u->stats.bytes_read += *got;
    return rc;
}

void mfns_uart_close(mfns_uart_t *u)
{
    if (u == NULL) {
        return;
    }
    backend_disconnect(u);
    u->reopenable = false;
}
