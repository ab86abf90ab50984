/* nav_tc_in.c -- see nav_tc_in.h. */
#include "firmware/app/nav_tc_in.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "firmware/app/tc_state.h"

/* The uplink state (tc_state.h) into tc->auth: never fatal. A live input
 * always waits for the ground's re-synchronisation, the stored epoch a floor;
 * a recorded file (--tc-file) counts locally, and with a state fault refuses
 * every command (nobody can re-synchronise a file). */
static void open_state(nav_tc_in_t *tc, const nav_opts_t *o)
{
    char err[384];
    uint32_t floor = 0;
    int e = 0;
    tc_state_fault_t f = tc_state_read(o->state_dir, &floor, &e, err, sizeof err);
    if (f == TC_STATE_OK || f == TC_STATE_MISSING) {
        const int w = tc_state_probe_write(o->state_dir);
        if (w != 0 && !(f == TC_STATE_MISSING && e != ENOENT)) {
            f = TC_STATE_UNWRITABLE; /* read-only, full, or a file where the directory should be */
            e = w;
            (void)snprintf(err, sizeof err, "%s: cannot write: %s", o->state_dir, strerror(w));
        }
    }
    if (f == TC_STATE_MISSING && e == ENOTDIR) {
        f = TC_STATE_UNWRITABLE;
    }
    tc->state_fault = f;
    tc->state_errno = e;
    static const uint8_t bits[] = {0u, TC_AUTH_ST_STATE_MISSING, TC_AUTH_ST_STATE_DAMAGED, TC_AUTH_ST_STATE_RO};
    const uint8_t sb = bits[f];
    if (o->tc_kind == NAV_TC_FILE) {
        uint32_t epoch = 0;
        if ((f == TC_STATE_OK || (f == TC_STATE_MISSING && e == ENOENT)) &&
            tc_state_next_epoch(o->state_dir, &epoch, err, sizeof err) == 0) {
            tc->auth.epoch = epoch; /* the local counter: a recorded file cannot re-synchronise */
            tc->auth.need_resync = false;
            tc->state_fault = TC_STATE_OK;
            tc->state_errno = 0;
            return;
        }
        tc->state_fault = f == TC_STATE_OK || f == TC_STATE_MISSING ? TC_STATE_UNWRITABLE : f;
        tc_auth_require_resync(&tc->auth, floor, f == TC_STATE_OK || f == TC_STATE_MISSING ? (uint8_t)TC_AUTH_ST_STATE_RO : sb);
        fprintf(stderr, "mfns-nav: --state-dir %s: every command of the file refused (AUTH_RESYNC_NEEDED); navigating\n",
                err);
        return;
    }
    tc_auth_require_resync(&tc->auth, floor, sb);
    if (f != TC_STATE_OK && !(f == TC_STATE_MISSING && e == ENOENT)) {
        fprintf(stderr,
                "mfns-nav: --state-dir %s: the uplink waits for the ground's re-synchronisation as always; the "
                "epoch it sets cannot be kept; navigating\n",
                err);
    }
}

/* Keys and epoch, or insecure mode (nav_opts_parse made sure one is given
 * whenever there is a command input). */
static int open_auth(nav_tc_in_t *tc, const nav_opts_t *o)
{
    if (o->tc_insecure) {
        tc_auth_init(&tc->auth, NULL, 0, 0);
        fprintf(stderr, "mfns-nav: WARNING: %s: telecommands are NOT authenticated; anyone who can "
                        "write to the uplink commands this board\n",
                o->tc_insecure_from_config ? "tc_insecure = yes in the configuration" : "--tc-insecure");
        return 0;
    }
    tc_auth_key_t keys[TC_AUTH_MAX_KEYS];
    unsigned n = 0;
    char err[384];
    if (tc_auth_read_keys(o->tc_key_path, keys, TC_AUTH_MAX_KEYS, &n, err, sizeof err) != 0) {
        fprintf(stderr, "mfns-nav: --tc-key %s\n", err);
        return -1;
    }
    tc_auth_init(&tc->auth, keys, n, 0); /* no epoch yet */
    tc_auth_wipe(keys, sizeof keys); /* the copy in tc->auth is the one kept */
    open_state(tc, o);
    return 0;
}

int nav_tc_in_open(nav_tc_in_t *tc, const nav_opts_t *o)
{
    memset(tc, 0, sizeof *tc);
    tc->kind = o->tc_kind;
    nav_cmd_init(&tc->cmd);
    tc->uart.fd = -1;
    if (o->tc_kind == NAV_TC_NONE) {
        return 0;
    }
    if (open_auth(tc, o) != 0) {
        return -1;
    }
    if (o->tc_kind == NAV_TC_LINK) {
        return 0;
    }
    const int rc = mfns_uart_open_path(&tc->uart, o->tc_target, o->baud, MFNS_UART_READ);
    if (rc == MFNS_UART_ERR_OPEN && o->tc_kind == NAV_TC_PATH) {
        fprintf(stderr, "mfns-nav: telecommands %s not available yet (%s): retrying\n", o->tc_target,
                strerror(tc->uart.last_errno));
        return 0;
    }
    if (rc != MFNS_UART_OK) {
        fprintf(stderr, "mfns-nav: telecommands %s: %s\n", o->tc_target, mfns_uart_strerror(rc));
        return -1;
    }
    return 0;
}

void nav_tc_in_poll(nav_tc_in_t *tc, mfns_uart_t *link, const nav_cmd_ops_t *ops, uint64_t now_ms)
{
    if (tc->kind == NAV_TC_NONE) {
        return;
    }
    mfns_uart_t *u = tc->kind == NAV_TC_LINK ? link : &tc->uart;
    unsigned left = NAV_CMD_MAX_PER_CYCLE;
    for (int round = 0; round < NAV_TC_IN_READS && left > 0u; round++) {
        if (tc->off == tc->len) {
            if (tc->eof) {
                return;
            }
            size_t got = 0;
            const int rc = mfns_uart_read(u, tc->rx, sizeof tc->rx, &got, 0, now_ms);
            if (rc == MFNS_UART_EOF) {
                tc->eof = true; /* a recorded command file ended */
            } else if ((rc == MFNS_UART_ERR_IO || rc == MFNS_UART_ERR_ARG) && !tc->error_printed) {
                tc->error_printed = true;
                fprintf(stderr, "mfns-nav: telecommand read failed: %s\n", mfns_uart_strerror(rc));
            }
            /* CLOSED/GONE: the transport re-opens at its cadence; nothing to read now */
            if (got == 0u) {
                return;
            }
            tc->len = got;
            tc->off = 0;
        }
        unsigned handled = 0;
        tc->off += nav_cmd_feed(&tc->cmd, tc->rx + tc->off, tc->len - tc->off, left, ops, &handled);
        left -= handled;
    }
}

void nav_tc_in_close(nav_tc_in_t *tc)
{
    tc_auth_clear(&tc->auth);
    mfns_uart_close(&tc->uart);
}
