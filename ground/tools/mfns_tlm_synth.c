/* mfns-tlm-gen: writes the synthetic telemetry stream of tlm_synth.h, so
 * the link and mfns-ground can be exercised without the flight program.
 *
 *   mfns-tlm-gen --cycles N [--file FILE|-]         frames to a file/stdout (--out: older spelling)
 *   mfns-tlm-gen --cycles N --tty PATH [--baud B]   through the transport (pty, FIFO, tty)
 *   mfns-tlm-gen --cycles N --fd FD                 through the transport on an open fd
 *   --rate HZ   pace the cycles (default 0: as fast as the port takes them)
 *
 * In transport mode it waits for queue space instead of dropping, so the
 * receiver gets every frame (the drop-oldest policy is tested elsewhere).
 */
#define _DEFAULT_SOURCE

#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ground/tlm_synth.h"
#include "mfns_version.h"
#include "firmware/tlm/tlm_txq.h"
#include "firmware/linux/txq_drain.h"
#include "drivers/uart/uart.h"

static tlm_txq_t g_q;

static int usage(int rc)
{
    fprintf(rc ? stderr : stdout,
            "usage: mfns-tlm-gen --cycles N [--file FILE|- | --tty PATH [--baud B] | --fd FD] [--rate HZ]\n"
            "Synthetic MFNS telemetry (ground/tlm_synth.h): per 18.6 Hz cycle one nav and three\n"
            "camera packets, housekeeping every 19th cycle, BOOT and TABLE_LOADED events first.\n"
            "  --cycles N        cycles to generate (0..100000000)\n"
            "  --file FILE|-     frames to a file, '-' stdout (default; --out: older spelling)\n"
            "  --tty PATH        through the transport to a tty, pty or FIFO\n"
            "  --fd FD           through the transport on an open file descriptor\n"
            "  --baud N          baud rate for --tty (default 921600)\n"
            "  --rate HZ         pace the cycles (default 0: as fast as the output takes them)\n"
            "  -q, --quiet, -v, --verbose   accepted for the common grammar; it prints only errors\n"
            "  -h, --help, --version\n"
            "Exit status: 0 ok, 1 the output failed, 2 bad usage.\n");
    return rc;
}

/* A whole decimal number in [lo, hi], or -1 (the caller prints usage). */
static int parse_num(const char *s, double lo, double hi, double *v)
{
    char *end = NULL;
    const double x = strtod(s, &end);
    if (end == s || *end != '\0' || !(x >= lo && x <= hi)) {
        return -1;
    }
    *v = x;
    return 0;
}

static int drain(mfns_uart_t *u, size_t keep_below, int timeout_ms)
{
    for (int t = 0; t < timeout_ms && tlm_txq_bytes(&g_q) > keep_below; t++) {
        const int rc = txq_drain(&g_q, u, mfns_uart_now_ms());
        if (rc != MFNS_UART_OK) {
            fprintf(stderr, "mfns-tlm-gen: %s\n", mfns_uart_strerror(rc));
            return -1;
        }
        if (tlm_txq_bytes(&g_q) > keep_below) {
            (void)poll(NULL, 0, 1);
        }
    }
    return tlm_txq_bytes(&g_q) > keep_below ? -1 : 0;
}

int main(int argc, char **argv)
{
    long cycles = -1, fd = -1;
    double rate = 0;
    unsigned long baud = 921600;
    const char *out = "-", *tty = NULL;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            return usage(0);
        }
        if (strcmp(a, "--version") == 0) {
            printf("mfns-tlm-gen %s\n", MFNS_VERSION_STR);
            return 0;
        }
        if (strcmp(a, "--quiet") == 0 || strcmp(a, "-q") == 0 || strcmp(a, "--verbose") == 0 ||
            strcmp(a, "-v") == 0) {
            continue;
        }
        if (i + 1 >= argc) {
            fprintf(stderr, "mfns-tlm-gen: %s: unknown option or missing value (see --help)\n", a);
            return 2;
        }
        const char *v = argv[++i];
        double x = 0;
        int bad = 0;
        if (strcmp(a, "--cycles") == 0) {
            bad = parse_num(v, 0, 100000000.0, &x);
            cycles = (long)x;
        } else if (strcmp(a, "--file") == 0 || strcmp(a, "--out") == 0) {
            out = v;
        } else if (strcmp(a, "--tty") == 0) {
            tty = v;
        } else if (strcmp(a, "--fd") == 0) {
            bad = parse_num(v, 0, 1000000.0, &x);
            fd = (long)x;
        } else if (strcmp(a, "--baud") == 0) {
            bad = parse_num(v, 1200, 4000000.0, &x);
            baud = (unsigned long)x;
        } else if (strcmp(a, "--rate") == 0) {
            bad = parse_num(v, 0, 1e6, &x);
            rate = x;
        } else {
            fprintf(stderr, "mfns-tlm-gen: %s: unknown option (see --help)\n", a);
            return 2;
        }
        if (bad != 0 || ((a[2] == 'c' || a[2] == 'f' || a[2] == 'b') && x != (double)(long)x)) {
            fprintf(stderr, "mfns-tlm-gen: %s: bad value '%s' (see --help)\n", a, v);
            return 2;
        }
    }
    if (cycles < 0) {
        fprintf(stderr, "mfns-tlm-gen: --cycles N is required (see --help)\n");
        return 2;
    }
    mfns_uart_t u;
    FILE *f = NULL;
    const int transport = tty != NULL || fd >= 0;
    if (tty != NULL) {
        int rc = mfns_uart_open_path(&u, tty, (uint32_t)baud, MFNS_UART_WRITE);
        /* A FIFO without a reader yet, a pty not yet there: the transport
         * re-opens at its cadence; give the receiver 5 s to appear. */
        const uint64_t give_up = mfns_uart_now_ms() + 5000u;
        while (rc == MFNS_UART_ERR_OPEN && u.reopenable && mfns_uart_now_ms() < give_up) {
            (void)poll(NULL, 0, 20);
            rc = mfns_uart_service(&u, mfns_uart_now_ms()) == MFNS_UART_OK ? MFNS_UART_OK : MFNS_UART_ERR_OPEN;
        }
        if (rc != MFNS_UART_OK) {
            fprintf(stderr, "mfns-tlm-gen: %s: %s\n", tty, mfns_uart_strerror(rc));
            return 1;
        }
    } else if (fd >= 0) {
        const int rc = mfns_uart_attach_fd(&u, (int)fd, false, MFNS_UART_WRITE);
        if (rc != MFNS_UART_OK) {
            fprintf(stderr, "mfns-tlm-gen: fd %ld: %s\n", fd, mfns_uart_strerror(rc));
            return 1;
        }
    } else {
        f = strcmp(out, "-") == 0 ? stdout : fopen(out, "wb");
        if (f == NULL) {
            fprintf(stderr, "mfns-tlm-gen: cannot write %s\n", out);
            return 1;
        }
    }
    tlm_txq_init(&g_q);
    tlm_encoder_t enc;
    tlm_encoder_init(&enc);
    const uint64_t t0 = mfns_uart_now_ms();
    int rc = 0;
    for (long i = 0; i < cycles && rc == 0; i++) {
        if (rate > 0) {
            const uint64_t due = t0 + (uint64_t)((double)i * 1000.0 / rate);
            const uint64_t now = mfns_uart_now_ms();
            if (due > now) {
                (void)poll(NULL, 0, (int)(due - now));
            }
        }
        tlm_packet_t pk[GROUND_GEN_MAX_PER_CYCLE];
        const size_t n = ground_gen_cycle((uint32_t)i, pk);
        for (size_t k = 0; k < n && rc == 0; k++) {
            uint8_t frame[TLM_MAX_WIRE];
            size_t len = 0;
            if (tlm_frame_encode(&enc, &pk[k], frame, sizeof frame, &len) != TLM_OK) {
                fprintf(stderr, "mfns-tlm-gen: encoding failed\n");
                rc = 1;
            } else if (transport) {
                if (drain(&u, TLM_TXQ_BYTES - TLM_MAX_WIRE, 10000) != 0 || tlm_txq_push(&g_q, frame, len) != TLM_OK) {
                    rc = 1;
                }
            } else if (fwrite(frame, 1, len, f) != len) {
                fprintf(stderr, "mfns-tlm-gen: write failed\n");
                rc = 1;
            }
        }
        if (transport && rc == 0) {
            (void)txq_drain(&g_q, &u, mfns_uart_now_ms());
        }
    }
    if (transport) {
        if (rc == 0 && drain(&u, 0, 10000) != 0) {
            rc = 1;
        }
        mfns_uart_close(&u);
    } else {
        const int bad = (f == stdout) ? fflush(f) : fclose(f);
        if (bad != 0) {
            rc = 1;
        }
    }
    return rc;
}
