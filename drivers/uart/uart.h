/* uart.h -- the telemetry transport (Linux): one interface, two backends.
 *
 *   serial  libserialport, for real UARTs (8N1, no flow control, at the
 *           board's MFNS_BOARD_BAUD). libserialport cannot open ptys.
 *   fd      a POSIX file descriptor: a tty by path (pseudo-terminals; set to
 *           raw mode and the baud rate), a FIFO, a regular file, or an fd
 *           the caller already has (stdin, an openpty() master).
 *
 * Bytes only: the transport knows nothing of packets, frames or queues.
 * Writes never block: mfns_uart_write() takes what the port accepts now,
 * says how many bytes that was (possibly 0) and returns. Callers keep what
 * is not yet written; the flight program queues frames in a tlm_txq_t (drop
 * oldest) and empties it with txq_drain() (firmware/linux/txq_drain.h).
 *
 * Reconnect: when a port opened by path vanishes (USB adapter unplugged,
 * EIO/ENODEV/ENXIO, pty or FIFO peer gone), the transport closes it, counts a
 * disconnect and re-opens it from write/read calls no more often than the
 * retry cadence: retry_min_ms, doubling per failure up to retry_max_ms.
 * Time is passed in (now_ms, any monotonic millisecond clock such as
 * mfns_uart_now_ms()) so the cadence is testable.
 *
 * Opening for writing sets SIGPIPE to ignored (a vanished FIFO reader must
 * give EPIPE, not kill the flight program).
 */
#ifndef MFNS_UART_H
#define MFNS_UART_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef enum {
    MFNS_UART_OK = 0,
    MFNS_UART_ERR_ARG = -1,     /* bad argument (NULL, path too long, baud 0, wrong direction) */
    MFNS_UART_ERR_OPEN = -2,    /* the port could not be opened (missing, busy, permission) */
    MFNS_UART_ERR_CONFIG = -3,  /* 8N1/baud/raw-mode configuration refused */
    MFNS_UART_ERR_GONE = -4,    /* the port vanished; re-open attempts follow at the retry cadence */
    MFNS_UART_ERR_IO = -5,      /* other read/write error */
    MFNS_UART_ERR_CLOSED = -6,  /* not connected now (waiting for the next re-open attempt) */
    MFNS_UART_EOF = -7,         /* end of a file, or a pipe whose writer closed (not re-openable) */
} mfns_uart_err_t;

typedef enum { MFNS_UART_SERIAL = 0, MFNS_UART_FD = 1 } mfns_uart_kind_t;
typedef enum { MFNS_UART_READ = 1, MFNS_UART_WRITE = 2, MFNS_UART_RW = 3 } mfns_uart_dir_t;

typedef struct {
    uint64_t bytes_written;
    uint64_t bytes_read;
    uint32_t short_writes;  /* the port took fewer bytes than offered (full) */
    uint32_t disconnects;   /* times the port vanished */
    uint32_t reconnects;    /* successful re-opens after a disconnect */
    uint32_t open_failures; /* failed (re-)open attempts */
} mfns_uart_stats_t;

#define MFNS_UART_PATH_MAX 128
#define MFNS_UART_RETRY_MIN_MS 200u
#define MFNS_UART_RETRY_MAX_MS 2000u

typedef struct {
    mfns_uart_kind_t kind;
    mfns_uart_dir_t dir;
    char path[MFNS_UART_PATH_MAX]; /* empty for an attached fd */
    uint32_t baud;
    int fd;                        /* fd backend: the descriptor, -1 when closed */
    bool owns_fd;
    bool reopenable;               /* opened by path and not a regular file */
    bool is_tty;
    void *sp;                      /* serial backend: struct sp_port * */
    bool connected;
    uint64_t next_retry_ms;
    uint32_t retry_ms;             /* current back-off */
    uint32_t retry_min_ms;
    uint32_t retry_max_ms;
    int last_errno;                /* errno of the last failure, for messages */
    mfns_uart_stats_t stats;
} mfns_uart_t;

/* libserialport port at baud, 8N1, no flow control, non-blocking writes. */
int mfns_uart_open_serial(mfns_uart_t *u, const char *port, uint32_t baud, mfns_uart_dir_t dir);
/* A path: a tty (raw mode, baud applied with cfsetspeed; a pty ignores it),
 * a FIFO or a regular file. O_NONBLOCK, O_NOCTTY. A FIFO opened for reading
 * is opened read-write so it survives writers coming and going. */
int mfns_uart_open_path(mfns_uart_t *u, const char *path, uint32_t baud, mfns_uart_dir_t dir);
/* The flight program's choice: libserialport when path names a serial port
 * libserialport knows (a real UART such as MFNS_BOARD_UART), otherwise the fd
 * backend (pseudo-terminals of the host-sim board, FIFOs, files). When the
 * path does not exist yet the fd backend is used, which re-opens it (as a
 * raw tty) once it appears. */
int mfns_uart_open_auto(mfns_uart_t *u, const char *path, uint32_t baud, mfns_uart_dir_t dir);
/* An open descriptor (not closed by mfns_uart_close unless owns). Set to
 * non-blocking; raw mode if it is a tty. Never re-opened. */
int mfns_uart_attach_fd(mfns_uart_t *u, int fd, bool owns, mfns_uart_dir_t dir);

/* Write what the port takes now; never blocks. *written gets the bytes
 * taken (0..n; fewer than n when the port is full, counted in short_writes).
 * Re-opens first if disconnected and due. Returns MFNS_UART_OK, or
 * ERR_ARG, ERR_CLOSED (not connected: nothing written), ERR_GONE (the port
 * vanished: closed, re-open attempts follow), ERR_IO (other write error;
 * last_errno says which). */
int mfns_uart_write(mfns_uart_t *u, const uint8_t *data, size_t n, size_t *written, uint64_t now_ms);
/* Wait up to timeout_ms for input and read what is there (*got may be 0 on
 * timeout). While disconnected it waits (bounded by timeout_ms) and
 * re-opens when due. MFNS_UART_EOF at the end of a file or pipe. */
int mfns_uart_read(mfns_uart_t *u, uint8_t *buf, size_t cap, size_t *got, int timeout_ms, uint64_t now_ms);
/* Re-open now if disconnected and the retry is due; OK when connected. */
int mfns_uart_service(mfns_uart_t *u, uint64_t now_ms);
void mfns_uart_close(mfns_uart_t *u);

/* Set the re-open cadence (ms); min >= 1, max >= min. */
int mfns_uart_set_retry(mfns_uart_t *u, uint32_t min_ms, uint32_t max_ms);

const char *mfns_uart_strerror(int err);
/* CLOCK_MONOTONIC in milliseconds. */
uint64_t mfns_uart_now_ms(void);

/* Backend entry points (uart_serial.c), used by uart.c only. */
int mfns_uart_serial_connect(mfns_uart_t *u);
void mfns_uart_serial_disconnect(mfns_uart_t *u);
int mfns_uart_serial_write(mfns_uart_t *u, const uint8_t *data, size_t n, size_t *written);
int mfns_uart_serial_read(mfns_uart_t *u, uint8_t *buf, size_t cap, size_t *got, int timeout_ms);
bool mfns_uart_serial_exists(const char *path);

#endif /* MFNS_UART_H */
