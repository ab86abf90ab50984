/* nav_tc_in.h -- the flight program's command input: uplink bytes read
 * without waiting, between cycles, and fed to the command dispatch
 * (nav_cmd_dispatch.h), which deframes them and calls the commands.
 *
 * The input (docs/uplink.md) is one of: none; a tty, pty or FIFO by path
 * (--tc-tty: absent at start is not fatal, it is re-opened at the
 * transport's retry cadence); a file of recorded frames (--tc-file, read to
 * its end, then no more reads); or the telemetry link itself (--uplink, the
 * link nav_tlm.h opened read-write).
 *
 * Per cycle at most NAV_CMD_MAX_PER_CYCLE commands are handled; bytes not
 * yet fed wait in nav_tc_in_t.rx for the next cycle, and at most
 * NAV_TC_IN_READS reads are made. A read error is reported once on stderr.
 */
#ifndef MFNS_NAV_TC_IN_H
#define MFNS_NAV_TC_IN_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "firmware/app/nav_cmd_dispatch.h"
#include "firmware/linux/tc_auth.h"
#include "firmware/app/tc_state.h"
#include "firmware/app/nav_opts.h"
#include "drivers/uart/uart.h"

#define NAV_TC_IN_RX_BYTES 256u /* bytes read at once */
#define NAV_TC_IN_READS 4       /* read-and-feed rounds per cycle */

typedef struct {
    nav_tc_kind_t kind;
    nav_cmd_t cmd;                   /* deframer, sequence guard, counters */
    tc_auth_t auth;                  /* keys, boot epoch, anti-replay reference (tc_auth.h) */
    mfns_uart_t uart;                /* --tc-tty / --tc-file (--uplink reads the telemetry link) */
    uint8_t rx[NAV_TC_IN_RX_BYTES];  /* bytes read and not yet fed to the dispatch */
    size_t len, off;
    bool eof;                        /* a recorded command file ended */
    bool error_printed;
    tc_state_fault_t state_fault;    /* the uplink state at start (tc_state.h) */
    int state_errno;
} nav_tc_in_t;

/* Opens the input o names, with its authentication: the keys of
 * --tc-key and the uplink state in --state-dir (tc_state.h: a live input
 * waits for the ground's re-synchronisation, a recorded file counts
 * locally), or insecure mode (--tc-insecure, a warning line). A state fault
 * is recorded (state_fault) and never fails the start. 0, or -1 after one
 * stderr line (keys refused, input not openable). */
int nav_tc_in_open(nav_tc_in_t *tc, const nav_opts_t *o);
/* Between cycles: reads what the input has now (never waits) and handles
 * at most NAV_CMD_MAX_PER_CYCLE commands through ops. link is the telemetry
 * link (read with --uplink); now_ms the program's monotonic clock. */
void nav_tc_in_poll(nav_tc_in_t *tc, mfns_uart_t *link, const nav_cmd_ops_t *ops, uint64_t now_ms);
void nav_tc_in_close(nav_tc_in_t *tc);

#endif /* MFNS_NAV_TC_IN_H */
