/* ground.h -- the ground station mfns-ground: reads the telemetry byte
 * stream from a serial port (libserialport), a tty/pty/FIFO or a recorded
 * file, decodes it (firmware/tlm), writes CSV + JSON Lines per packet type
 * (ground_out.h), shows a live one-line status on stderr when it is a
 * terminal, and prints the link counters at exit. main.c is argument
 * parsing around ground_run().
 */
#ifndef MFNS_GROUND_H
#define MFNS_GROUND_H

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "firmware/tlm/tlm_decoder.h"
#include "drivers/uart/uart.h"

/* --baud default: the board's UART rate. */
#ifdef MFNS_BOARD_BAUD
#define GROUND_DEFAULT_BAUD MFNS_BOARD_BAUD
#else
#define GROUND_DEFAULT_BAUD 921600
#endif

typedef enum { GROUND_SRC_NONE = 0, GROUND_SRC_SERIAL, GROUND_SRC_TTY, GROUND_SRC_FILE } ground_src_t;

/* Hooks for the uplink and the UDP forwarder (ground/uplink.h), called from
 * ground_run's loop: poll every iteration (<= 100 ms apart), packet for each
 * decoded packet, finish before the source closes; done (nullable) ends the
 * run when it says true (--upload answered). src is the source link
 * (commands go up on it with --uplink). */
typedef struct {
    void *ctx;
    void (*poll)(void *ctx, mfns_uart_t *src, uint64_t now_ms);
    void (*packet)(void *ctx, const tlm_packet_t *p);
    void (*finish)(void *ctx, mfns_uart_t *src);
    bool (*done)(void *ctx);
} ground_hooks_t;

typedef struct {
    ground_src_t src;
    const char *path;         /* port, tty path, file path or "-" for stdin */
    uint32_t baud;            /* serial/tty baud rate */
    const char *out_dir;      /* output folder */
    const char *record;       /* optional: copy of the raw received bytes (replay with --file) */
    double max_seconds;       /* 0 = unbounded */
    unsigned long max_frames; /* stop after this many good frames; 0 = unbounded */
    double pace;              /* --file: packets released at pace x their flight-time spacing; 0 = at once */
    int status;               /* live status line: -1 auto (stderr is a tty), 0 off, 1 on */
    int quiet;                /* no link counters at exit */
    int source_rw;            /* open the source read-write (commands on the same tty: --uplink) */
    const ground_hooks_t *hooks; /* nullable: set by main.c (uplink, UDP) */
} ground_opts_t;

/* 0 ok, 1 when --help or --version was printed (exit 0), -1 usage error (message on err). */
int ground_parse_args(int argc, char **argv, ground_opts_t *o, FILE *err);
void ground_usage(FILE *f);
/* Exit code when the run ended without a single valid frame. */
#define GROUND_EXIT_NO_FRAME 3

/* Runs until EOF (files), the limits, or SIGINT/SIGTERM. Returns the process
 * exit code: 0 normal end, 1 source or output could not be opened/written,
 * GROUND_EXIT_NO_FRAME when no valid frame was decoded.
 * stats_out (may be NULL) gets the final decoder counters. */
int ground_run(const ground_opts_t *o, tlm_decoder_stats_t *stats_out);

#endif /* MFNS_GROUND_H */
