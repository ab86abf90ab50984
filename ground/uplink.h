/* uplink.h -- mfns-ground's command side (docs/uplink.md): telecommands
 * from the command line (--cmd), a command file or stdin (--cmd-file), and
 * a ground system over UDP (--udp-tc, udp_forward.h), encoded with the
 * portable codec (firmware/tlm/tc_packets.h) and sent up a tty/FIFO
 * (--tc-tty), into a file (--tc-file) or on the telemetry link itself
 * (--uplink), while ground_run keeps receiving. Also owns the forwarders
 * of decoded telemetry (--udp-forward, --tcp-forward: tcp_forward.h).
 *
 * The ground station is the one sender on the uplink, so it owns the
 * sequence count: every command gets the next count (starting at
 * --tc-seq-start, default 0), except one from the ground system's UDP TC
 * link (Yamcs numbers its commands and matches the flight's answer on that
 * number), which keeps its count when that is newer than the last one sent;
 * the counter then continues after it. With --tc-key it also signs every
 * one (uplink_auth.h). Every command sent is logged in
 * OUT/commands.csv (utc, seq, opcode, source, text).
 *
 * Command grammar (one per line; '#' starts a comment; names are
 * case-insensitive):
 *   NOOP
 *   RESET_COUNTERS
 *   SET_MODE standby|acquire|track
 *   SET_POSE_HINT X Y Z ROLL PITCH YAW     mm and deg (r_wb_w, 2-1-3 of C_w_b)
 *   CAMERA_ENABLE x|y|z|0|1|2
 *   CAMERA_DISABLE x|y|z|0|1|2
 *   TABLE_LOAD PATH                        a path on the board, < 64 characters
 *   WAIT SECONDS                           (ground only) pause the command file
 *
 * --upload FILE sends a file (a calibration table) with the UPLOAD_*
 * commands (upload.h) once the uplink is ready, and ends the run when the
 * board has answered UPLOAD_END (or refused the upload): exit 0 when the
 * table was stored and loaded, 1 when refused (the reason named) or never
 * answered.
 */
#ifndef MFNS_GROUND_UPLINK_H
#define MFNS_GROUND_UPLINK_H

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "ground/ground.h"
#include "firmware/tlm/tc_packets.h"
#include "firmware/tlm/tlm_txq.h"
#include "ground/tcp_forward.h"
#include "ground/udp_forward.h"
#include "ground/upload.h"
#include "ground/uplink_auth.h"

#define UPLINK_MAX_CLI 32   /* --cmd options */
#define UPLINK_LINE_MAX 256 /* a command line, bytes */

typedef enum { UPLINK_OUT_NONE = 0, UPLINK_OUT_TTY, UPLINK_OUT_FILE, UPLINK_OUT_LINK } uplink_out_t;

typedef struct {
    uplink_out_t out;
    const char *out_path;              /* --tc-tty / --tc-file */
    const char *cli[UPLINK_MAX_CLI];   /* --cmd, in order */
    int n_cli;
    const char *cmd_file;              /* --cmd-file PATH or "-" */
    uint16_t seq_start;
    const char *udp_forward;           /* HOST:PORT or NULL */
    const char *tcp_forward;           /* --tcp-forward HOST:PORT (listen) or NULL */
    const char *udp_tc;                /* HOST:PORT or NULL */
    const char *tc_socket;             /* --tc-socket PATH: Unix datagram socket, mode 0600, or NULL */
    const char *tc_key;                /* --tc-key FILE: sign every command (uplink_auth.h) */
    uint32_t tc_epoch;                 /* --tc-epoch N, 0 = learn from housekeeping */
    uint32_t tc_count_start;           /* --tc-count-start N, 0 = default (1) */
    const char *tc_state;              /* --tc-state FILE: the ground's epoch and count, persisted (uplink_auth.h) */
    bool udp_allow_remote;
    const char *out_dir;               /* for commands.csv (from ground_opts_t) */
    bool quiet;                        /* -q (from ground_opts_t): no counters at exit, errors only */
    uint32_t baud;
    const char *upload;                /* --upload FILE or NULL */
} uplink_opts_t;

/* One parsed line. */
typedef enum { UPLINK_LINE_EMPTY = 0, UPLINK_LINE_CMD, UPLINK_LINE_WAIT } uplink_line_kind_t;

/* Parse one line of the grammar. Returns 0 with *kind (and *cmd or
 * *wait_s), or -1 with a message in err. The command's arguments are
 * validated as the flight side will (tc_packet_encode). */
int uplink_parse_line(const char *line, uplink_line_kind_t *kind, tc_cmd_t *cmd, double *wait_s, char *err,
                      size_t err_size);

typedef struct {
    uplink_opts_t o;
    ground_hooks_t hooks;
    mfns_uart_t tc;          /* UPLINK_OUT_TTY / _FILE */
    tlm_txq_t q;             /* TC frames waiting for the link (drop-oldest, never blocks) */
    uint16_t next_seq;
    int next_cli;
    int cmd_fd;              /* -1: none or ended */
    char line[UPLINK_LINE_MAX + 1];
    size_t line_len;
    bool line_too_long;
    unsigned long line_no;
    uint64_t wait_until_ms;
    FILE *log;
    bool log_failed;
    udp_forward_t fwd;
    tcp_forward_t tcp;       /* --tcp-forward: 2 MB queue, so uplink_t is static (main.c) */
    udp_tc_in_t tcin;
    udp_tc_in_t sockin;      /* --tc-socket */
    uplink_auth_t auth;
    uint32_t n_sent, n_errors;
    ground_upload_t upl;     /* --upload */
    uint8_t upl_buf[UPLOAD_FILE_MAX];
} uplink_t;

/* Parse and remove uplink options from argv (the rest is left in rest[],
 * rest[0] = argv[0], *n_rest entries). 0 ok, -1 usage error (message on err). */
int uplink_parse_args(int argc, char **argv, uplink_opts_t *o, char **rest, int *n_rest, FILE *err);
void uplink_usage(FILE *f);
bool uplink_wanted(const uplink_opts_t *o);

/* Opens outputs and sockets; fills up->hooks for ground_opts_t.hooks.
 * 0 ok, -1 with a message on stderr. */
int uplink_open(uplink_t *up, const uplink_opts_t *o);
/* Closes; returns 0, or 1 when a command could not be parsed or sent. */
int uplink_close(uplink_t *up);

#endif /* MFNS_GROUND_UPLINK_H */
