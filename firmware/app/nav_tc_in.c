/* nav_tc_in.c -- see nav_tc_in.h. */
#include "firmware/app/nav_tc_in.h"

#include <stdio.h>
#include <string.h>

#include "firmware/app/tc_state.h"

/* Keys and epoch, or insecure mode (nav_opts_parse made sure one is given
 * whenever there is a command input). */
static int open_auth(nav_tc_in_t *tc, const nav_opts_t *o)
{
    if (o->tc_insecure) {
        tc_auth_init(&tc->auth, NULL, 0, 0);
        fprintf(stderr, "mfns-nav: WARNING: --tc-insecure: telecommands are NOT authenticated; anyone who can "
                        "write to the uplink commands this board\n");
        return 0;
    }
    tc_auth_key_t keys[TC_AUTH_MAX_KEYS];
    unsigned n = 0;
    char err[384];
    if (tc_auth_read_keys(o->tc_key_path, keys, TC_AUTH_MAX_KEYS, &n, err, sizeof err) != 0) {
        fprintf(stderr, "mfns-nav: --tc-key %s\n", err);
        return -1;
    }
    uint32_t epoch = 0;
    if (tc_state_next_epoch(o->state_dir, &epoch, err, sizeof err) != 0) {
        fprintf(stderr, "mfns-nav: --state-dir %s\n", err);
        tc_auth_wipe(keys, sizeof keys);
        return -1;
    }
    tc_auth_init(&tc->auth, keys, n, epoch);
    tc_auth_wipe(keys, sizeof keys); /* the copy in tc->auth is the one kept */
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
