/* uart_serial.c -- libserialport backend of the transport (see uart.h):
 * real UARTs only (libserialport cannot open pseudo-terminals). */
#define _DEFAULT_SOURCE

#include <errno.h>
#include <libserialport.h>
#include <unistd.h>

#include "drivers/uart/uart.h"

static int fail_code(mfns_uart_t *u, enum sp_return r, int gone_default)
{
    if (r == SP_ERR_FAIL) {
        u->last_errno = sp_last_error_code();
        const int e = u->last_errno;
        if (e == EIO || e == ENODEV || e == ENXIO || e == ENOENT || e == EBADF) {
            return MFNS_UART_ERR_GONE;
        }
    }
    return gone_default;
}

int mfns_uart_serial_connect(mfns_uart_t *u)
{
    struct sp_port *p = NULL;
    if (sp_get_port_by_name(u->path, &p) != SP_OK) {
        return MFNS_UART_ERR_OPEN;
    }
    const enum sp_mode mode = u->dir == MFNS_UART_READ    ? SP_MODE_READ
                              : u->dir == MFNS_UART_WRITE ? SP_MODE_WRITE
                                                          : SP_MODE_READ_WRITE;
    if (sp_open(p, mode) != SP_OK) {
        u->last_errno = sp_last_error_code();
        sp_free_port(p);
        return MFNS_UART_ERR_OPEN;
    }
    if (u->baud > 0x7FFFFFFFu || sp_set_baudrate(p, (int)u->baud) != SP_OK || sp_set_bits(p, 8) != SP_OK ||
        sp_set_parity(p, SP_PARITY_NONE) != SP_OK || sp_set_stopbits(p, 1) != SP_OK ||
        sp_set_flowcontrol(p, SP_FLOWCONTROL_NONE) != SP_OK) {
        (void)sp_close(p);
        sp_free_port(p);
        return MFNS_UART_ERR_CONFIG;
    }
    u->sp = p;
    u->is_tty = true;
    return MFNS_UART_OK;
}

void mfns_uart_serial_disconnect(mfns_uart_t *u)
{
    struct sp_port *p = (struct sp_port *)u->sp;
    if (p != NULL) {
        (void)sp_close(p);
        sp_free_port(p);
        u->sp = NULL;
    }
}

int mfns_uart_serial_write(mfns_uart_t *u, const uint8_t *data, size_t n, size_t *written)
{
    *written = 0;
    const enum sp_return r = sp_nonblocking_write((struct sp_port *)u->sp, data, n);
    if (r >= 0) {
        *written = (size_t)r;
        return MFNS_UART_OK;
    }
    /* Any other failure of a real UART is treated as a vanished port: the
     * re-open either brings it back or keeps failing at the cadence. */
    return fail_code(u, r, MFNS_UART_ERR_GONE);
}

int mfns_uart_serial_read(mfns_uart_t *u, uint8_t *buf, size_t cap, size_t *got, int timeout_ms)
{
    *got = 0;
    /* libserialport reads timeout 0 as "wait forever": poll instead. */
    const enum sp_return r = timeout_ms > 0
                                 ? sp_blocking_read_next((struct sp_port *)u->sp, buf, cap, (unsigned)timeout_ms)
                                 : sp_nonblocking_read((struct sp_port *)u->sp, buf, cap);
    if (r > 0) {
        *got = (size_t)r;
        return MFNS_UART_OK;
    }
    if (r == 0) {
        /* Timeout, or an unplugged USB adapter whose node is gone. */
        return access(u->path, F_OK) == 0 ? MFNS_UART_OK : MFNS_UART_ERR_GONE;
    }
    return fail_code(u, r, MFNS_UART_ERR_GONE);
}

bool mfns_uart_serial_exists(const char *path)
{
    struct sp_port *p = NULL;
    if (sp_get_port_by_name(path, &p) != SP_OK) {
        return false;
    }
    sp_free_port(p);
    return true;
}
