/* Tests of the telemetry transport's fd backend over real pseudo-terminals
 * and FIFOs this test creates (never a real serial port: /dev/ttyS0 is the
 * machine console): raw 8-bit transparency, frames through the drop-oldest
 * queue, non-blocking behaviour when the port is full, a vanishing peer and
 * its reconnect at the bounded retry cadence, files and EOF. */
#define _DEFAULT_SOURCE /* openpty, mkdtemp under -std=c11 */

#include "tests/unit/support/testutil.h"

#include <fcntl.h>
#include <pty.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "firmware/tlm/tlm_decoder.h"
#include "tests/unit/support/tlm_test_samples.h"
#include "firmware/tlm/tlm_txq.h"
#include "firmware/linux/txq_drain.h"
#include "drivers/uart/uart.h"

static tlm_txq_t g_q;

typedef struct {
    int master;
    char slave_path[64];
} pty_t;

static void open_pty(pty_t *p)
{
    int slave = -1;
    assert_int_equal(openpty(&p->master, &slave, p->slave_path, NULL, NULL), 0);
    /* The transport opens the slave by path; our descriptor is not needed. */
    close(slave);
}

/* Read whatever is available on r (bounded by tries x 10 ms) into the decoder. */
static uint32_t read_decode(mfns_uart_t *r, tlm_decoder_t *d, tlm_packet_t *got, uint32_t max, int tries)
{
    uint32_t n = 0;
    for (int t = 0; t < tries; t++) {
        uint8_t buf[1024];
        size_t m = 0;
        const int rc = mfns_uart_read(r, buf, sizeof buf, &m, 10, mfns_uart_now_ms());
        assert_true(rc == MFNS_UART_OK);
        for (size_t k = 0; k < m; k++) {
            tlm_packet_t p;
            if (tlm_decoder_push(d, buf[k], &p) == 1 && n < max) {
                got[n++] = p;
            }
        }
        if (m == 0) {
            break;
        }
    }
    return n;
}

static void test_pty_is_8bit_transparent(void **state)
{
    (void)state;
    pty_t p;
    open_pty(&p);
    mfns_uart_t w, r;
    assert_int_equal(mfns_uart_open_path(&w, p.slave_path, 921600, MFNS_UART_WRITE), MFNS_UART_OK);
    assert_true(w.is_tty);
    assert_int_equal(mfns_uart_attach_fd(&r, p.master, true, MFNS_UART_READ), MFNS_UART_OK);
    /* every byte value, including CR, LF, XON/XOFF, ^C, ^D, DEL and 0xFF */
    uint8_t all[256];
    for (int i = 0; i < 256; i++) {
        all[i] = (uint8_t)i;
    }
    size_t wn = 0;
    assert_int_equal(mfns_uart_write(&w, all, sizeof all, &wn, mfns_uart_now_ms()), MFNS_UART_OK);
    assert_int_equal(wn, sizeof all);
    uint8_t back[512];
    size_t total = 0;
    for (int t = 0; t < 100 && total < sizeof all; t++) {
        size_t m = 0;
        assert_int_equal(mfns_uart_read(&r, back + total, sizeof back - total, &m, 20, mfns_uart_now_ms()),
                         MFNS_UART_OK);
        total += m;
    }
    assert_int_equal(total, sizeof all);
    assert_memory_equal(back, all, sizeof all);
    mfns_uart_close(&w);
    mfns_uart_close(&r);
}

static void test_frames_over_pty(void **state)
{
    (void)state;
    pty_t p;
    open_pty(&p);
    mfns_uart_t w, r;
    assert_int_equal(mfns_uart_open_path(&w, p.slave_path, 115200, MFNS_UART_WRITE), MFNS_UART_OK);
    assert_int_equal(mfns_uart_attach_fd(&r, p.master, true, MFNS_UART_READ), MFNS_UART_OK);
    tlm_txq_init(&g_q);
    tlm_encoder_t enc;
    tlm_encoder_init(&enc);
    tlm_decoder_t d;
    tlm_decoder_init(&d);
    enum { N = 400 };
    static tlm_packet_t sent[N], got[N];
    uint32_t ngot = 0;
    for (uint32_t i = 0; i < N; i++) {
        tlm_test_sample(&sent[i], (tlm_type_t)(i % TLM_NUM_TYPES), i);
        uint8_t f[TLM_MAX_WIRE];
        size_t n = 0;
        assert_int_equal(tlm_frame_encode(&enc, &sent[i], f, sizeof f, &n), TLM_OK);
        assert_int_equal(tlm_txq_push(&g_q, f, n), TLM_OK);
        assert_int_equal(txq_drain(&g_q, &w, mfns_uart_now_ms()), MFNS_UART_OK);
        if (i % 16 == 15) {
            ngot += read_decode(&r, &d, got + ngot, N - ngot, 4);
        }
    }
    for (int t = 0; t < 200 && ngot < N; t++) {
        assert_int_equal(txq_drain(&g_q, &w, mfns_uart_now_ms()), MFNS_UART_OK);
        ngot += read_decode(&r, &d, got + ngot, N - ngot, 4);
    }
    assert_int_equal(g_q.dropped, 0);
    assert_int_equal(ngot, N);
    for (uint32_t i = 0; i < N; i++) {
        assert_true(tlm_test_packets_equal(&sent[i], &got[i]));
    }
    assert_int_equal(d.stats.crc_errors + d.stats.truncated + d.stats.oversize + d.stats.seq_gaps, 0);
    assert_int_equal(w.stats.bytes_written, r.stats.bytes_read);
    mfns_uart_close(&w);
    mfns_uart_close(&r);
}

static void test_full_port_never_blocks_and_drops_oldest(void **state)
{
    (void)state;
    pty_t p;
    open_pty(&p);
    mfns_uart_t w, r;
    assert_int_equal(mfns_uart_open_path(&w, p.slave_path, 921600, MFNS_UART_WRITE), MFNS_UART_OK);
    assert_int_equal(mfns_uart_attach_fd(&r, p.master, true, MFNS_UART_READ), MFNS_UART_OK);
    tlm_txq_init(&g_q);
    tlm_encoder_t enc;
    tlm_encoder_init(&enc);
    /* nobody reads: the pty fills, writes come back short, the queue drops oldest */
    enum { N = 6000 };
    for (uint32_t i = 0; i < N; i++) {
        tlm_packet_t pk;
        tlm_test_sample(&pk, TLM_TYPE_NAV, i);
        uint8_t f[TLM_MAX_WIRE];
        size_t n = 0;
        assert_int_equal(tlm_frame_encode(&enc, &pk, f, sizeof f, &n), TLM_OK);
        assert_int_equal(tlm_txq_push(&g_q, f, n), TLM_OK);
        assert_int_equal(txq_drain(&g_q, &w, mfns_uart_now_ms()), MFNS_UART_OK);
    }
    assert_true(w.stats.short_writes > 0);
    assert_true(g_q.dropped > 0);
    /* now drain: every frame that arrives is whole and the newest one arrives */
    tlm_decoder_t d;
    tlm_decoder_init(&d);
    static tlm_packet_t got[N];
    uint32_t ngot = 0;
    /* Done when the queue is empty and every byte written has been read: the
     * pty hands written bytes to the master side from a kernel work item, so
     * the last frame can still be in flight when the queue empties (under
     * ASan on a loaded 2-core CI machine 2 runs in 20 lost the last frame to a
     * single 10 ms read). Bounded: 2000 rounds of at most 8 x 10 ms reads. */
    for (int t = 0; t < 2000 && (tlm_txq_frames(&g_q) > 0 || r.stats.bytes_read < w.stats.bytes_written); t++) {
        assert_int_equal(txq_drain(&g_q, &w, mfns_uart_now_ms()), MFNS_UART_OK);
        ngot += read_decode(&r, &d, got + ngot, N - ngot, 8);
    }
    assert_int_equal(tlm_txq_frames(&g_q), 0);
    assert_int_equal(r.stats.bytes_read, w.stats.bytes_written);
    assert_int_equal(ngot + g_q.dropped, N);
    assert_int_equal(d.stats.crc_errors + d.stats.truncated + d.stats.oversize, 0);
    assert_int_equal(got[ngot - 1].u.nav.cycle, N - 1);
    assert_int_equal(d.stats.seq_lost, g_q.dropped);
    mfns_uart_close(&w);
    mfns_uart_close(&r);
}

static void test_fifo_reader_vanishes_and_returns(void **state)
{
    (void)state;
    char dir[] = "/tmp/mfns-uart-XXXXXX";
    assert_non_null(mkdtemp(dir));
    char path[96];
    snprintf(path, sizeof path, "%s/tlm.fifo", dir);
    assert_int_equal(mkfifo(path, 0600), 0);
    int rd = open(path, O_RDONLY | O_NONBLOCK);
    assert_true(rd >= 0);
    mfns_uart_t w, r;
    assert_int_equal(mfns_uart_open_path(&w, path, 0, MFNS_UART_WRITE), MFNS_UART_OK);
    assert_int_equal(mfns_uart_set_retry(&w, 100, 1000), MFNS_UART_OK);
    assert_int_equal(mfns_uart_attach_fd(&r, rd, false, MFNS_UART_READ), MFNS_UART_OK);
    tlm_txq_init(&g_q);
    tlm_encoder_t enc;
    tlm_encoder_init(&enc);
    tlm_decoder_t d;
    tlm_decoder_init(&d);
    static tlm_packet_t got[64];
    uint8_t f[TLM_MAX_WIRE];
    size_t n = 0;
    tlm_packet_t pk;
    uint64_t now = 1000000; /* simulated clock for the cadence */
    for (uint32_t i = 0; i < 5; i++) {
        tlm_test_sample(&pk, TLM_TYPE_NAV, i);
        assert_int_equal(tlm_frame_encode(&enc, &pk, f, sizeof f, &n), TLM_OK);
        assert_int_equal(tlm_txq_push(&g_q, f, n), TLM_OK);
        assert_int_equal(txq_drain(&g_q, &w, now), MFNS_UART_OK);
    }
    assert_int_equal(read_decode(&r, &d, got, 64, 4), 5);
    /* the reader goes away: the next write fails with EPIPE (not SIGPIPE) */
    close(rd);
    tlm_test_sample(&pk, TLM_TYPE_NAV, 5);
    assert_int_equal(tlm_frame_encode(&enc, &pk, f, sizeof f, &n), TLM_OK);
    assert_int_equal(tlm_txq_push(&g_q, f, n), TLM_OK);
    assert_int_equal(txq_drain(&g_q, &w, now), MFNS_UART_ERR_GONE);
    assert_int_equal(w.stats.disconnects, 1);
    assert_false(w.connected);
    /* 10 s without a reader, pumping every 10 ms: re-open attempts at 0.1,
     * 0.3, 0.7, 1.5 s, then every 1 s (back-off 100 ms doubling to 1 s) ->
     * 12 attempts in 10 s, not 1000 */
    for (int t = 1; t <= 1000; t++) {
        now += 10;
        tlm_test_sample(&pk, TLM_TYPE_NAV, 5u + (uint32_t)t);
        assert_int_equal(tlm_frame_encode(&enc, &pk, f, sizeof f, &n), TLM_OK);
        assert_int_equal(tlm_txq_push(&g_q, f, n), TLM_OK);
        assert_int_equal(txq_drain(&g_q, &w, now), MFNS_UART_ERR_CLOSED);
    }
    assert_true(w.stats.open_failures >= 11 && w.stats.open_failures <= 13);
    assert_true(g_q.dropped > 0); /* 1000 frames do not fit: oldest dropped */
    /* the reader comes back: the next due attempt reconnects and the newest frames flow */
    rd = open(path, O_RDONLY | O_NONBLOCK);
    assert_true(rd >= 0);
    assert_int_equal(mfns_uart_attach_fd(&r, rd, true, MFNS_UART_READ), MFNS_UART_OK);
    now += 1000;
    assert_int_equal(mfns_uart_service(&w, now), MFNS_UART_OK);
    assert_int_equal(w.stats.reconnects, 1);
    tlm_decoder_init(&d);
    static tlm_packet_t got2[TLM_TXQ_FRAMES + 8];
    uint32_t ngot = 0;
    for (int t = 0; t < 100 && tlm_txq_frames(&g_q) > 0; t++) {
        assert_int_equal(txq_drain(&g_q, &w, now), MFNS_UART_OK);
        ngot += read_decode(&r, &d, got2 + ngot, TLM_TXQ_FRAMES + 8 - ngot, 4);
    }
    ngot += read_decode(&r, &d, got2 + ngot, TLM_TXQ_FRAMES + 8 - ngot, 4);
    assert_true(ngot > 10);
    assert_int_equal(got2[ngot - 1].u.nav.cycle, 1005);
    assert_int_equal(d.stats.crc_errors + d.stats.truncated, 0);
    mfns_uart_close(&w);
    mfns_uart_close(&r);
    unlink(path);
    rmdir(dir);
}

static void test_missing_port_retries_at_bounded_cadence(void **state)
{
    (void)state;
    mfns_uart_t u;
    assert_int_equal(mfns_uart_open_path(&u, "/nonexistent/mfns-tty", 921600, MFNS_UART_WRITE),
                     MFNS_UART_ERR_OPEN);
    assert_int_equal(u.stats.open_failures, 1);
    const uint64_t t0 = mfns_uart_now_ms();
    for (int t = 0; t < 1000; t++) {
        assert_int_equal(mfns_uart_service(&u, t0 + (uint64_t)t * 10u), MFNS_UART_ERR_CLOSED);
    }
    /* default 200 ms doubling to 2 s: attempts near 0.2, 0.6, 1.4, 3.0, 5.0, 7.0, 9.0 s, plus the first */
    assert_true(u.stats.open_failures >= 7 && u.stats.open_failures <= 9);
    assert_int_equal(u.retry_ms, MFNS_UART_RETRY_MAX_MS);
    mfns_uart_close(&u);
    /* auto: a pty and /dev/null are not serial ports -> fd backend */
    pty_t a;
    open_pty(&a);
    mfns_uart_t au;
    assert_int_equal(mfns_uart_open_auto(&au, a.slave_path, 921600, MFNS_UART_WRITE), MFNS_UART_OK);
    assert_int_equal(au.kind, MFNS_UART_FD);
    assert_true(au.is_tty);
    mfns_uart_close(&au);
    close(a.master);
    assert_int_equal(mfns_uart_open_auto(&au, "/dev/null", 921600, MFNS_UART_WRITE), MFNS_UART_OK);
    assert_int_equal(au.kind, MFNS_UART_FD);
    assert_false(au.is_tty);
    size_t wn = 0;
    const uint8_t z[3] = {1, 2, 3};
    assert_int_equal(mfns_uart_write(&au, z, 3, &wn, 0), MFNS_UART_OK);
    assert_int_equal(wn, 3);
    mfns_uart_close(&au);
    /* libserialport refuses what is not a serial port (e.g. a pty) */
    pty_t p;
    open_pty(&p);
    mfns_uart_t s;
    assert_int_equal(mfns_uart_open_serial(&s, p.slave_path, 921600, MFNS_UART_RW), MFNS_UART_ERR_OPEN);
    mfns_uart_close(&s);
    close(p.master);
}

static void test_file_reads_to_eof_and_arguments(void **state)
{
    (void)state;
    char path[] = "/tmp/mfns-uart-file-XXXXXX";
    const int fd = mkstemp(path);
    assert_true(fd >= 0);
    const uint8_t data[5] = {1, 2, 0, 3, 4};
    assert_int_equal(write(fd, data, sizeof data), (ssize_t)sizeof data);
    close(fd);
    mfns_uart_t u;
    assert_int_equal(mfns_uart_open_path(&u, path, 0, MFNS_UART_READ), MFNS_UART_OK);
    assert_false(u.reopenable);
    uint8_t buf[16];
    size_t m = 0;
    assert_int_equal(mfns_uart_read(&u, buf, sizeof buf, &m, 10, 0), MFNS_UART_OK);
    assert_int_equal(m, 5);
    assert_memory_equal(buf, data, 5);
    assert_int_equal(mfns_uart_read(&u, buf, sizeof buf, &m, 10, 0), MFNS_UART_EOF);
    assert_int_equal(mfns_uart_read(&u, buf, sizeof buf, &m, 10, 0), MFNS_UART_EOF);
    /* wrong direction, NULLs, bad baud */
    size_t w = 0;
    assert_int_equal(mfns_uart_write(&u, data, 1, &w, 0), MFNS_UART_ERR_ARG);
    mfns_uart_close(&u);
    unlink(path);
    assert_int_equal(mfns_uart_open_path(NULL, path, 0, MFNS_UART_READ), MFNS_UART_ERR_ARG);
    assert_int_equal(mfns_uart_open_path(&u, "", 0, MFNS_UART_READ), MFNS_UART_ERR_ARG);
    assert_int_equal(mfns_uart_open_serial(&u, "/dev/ttyUSB9", 0, MFNS_UART_RW), MFNS_UART_ERR_ARG);
    assert_int_equal(mfns_uart_attach_fd(&u, -1, false, MFNS_UART_READ), MFNS_UART_ERR_ARG);
    pty_t p;
    open_pty(&p);
    /* a baud rate the tty layer does not have */
    assert_int_equal(mfns_uart_open_path(&u, p.slave_path, 12345, MFNS_UART_WRITE), MFNS_UART_ERR_CONFIG);
    mfns_uart_close(&u);
    close(p.master);
    for (int e = MFNS_UART_EOF; e <= MFNS_UART_OK; e++) {
        for (int f = e + 1; f <= MFNS_UART_OK; f++) {
            assert_string_not_equal(mfns_uart_strerror(e), mfns_uart_strerror(f));
        }
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pty_is_8bit_transparent),
        cmocka_unit_test(test_frames_over_pty),
        cmocka_unit_test(test_full_port_never_blocks_and_drops_oldest),
        cmocka_unit_test(test_fifo_reader_vanishes_and_returns),
        cmocka_unit_test(test_missing_port_retries_at_bounded_cadence),
        cmocka_unit_test(test_file_reads_to_eof_and_arguments),
    };
    return cmocka_run_group_tests_name("tlm_uart", tests, NULL, NULL);
}
