/* nav_tc_in.c -- see nav_tc_in.h. */
#include "nav_tc_in.h"

#include <stdio.h>
#include <string.h>

int nav_tc_in_open(nav_tc_in_t *tc, const nav_opts_t *o)
{
    memset(tc, 0, sizeof *tc);
    tc->kind = o->tc_kind;
    nav_cmd_init(&tc->cmd);
    tc->uart.fd = -1;
    if (o->tc_kind == NAV_TC_NONE || o->tc_kind == NAV_TC_LINK) {
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
    mfns_uart_close(&tc->uart);
}
