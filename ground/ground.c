/* ground.c -- mfns-ground's main loop (see ground.h). */
#define _DEFAULT_SOURCE /* sigaction under -std=c11 */

#include "ground/ground.h"

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "ground/ground_out.h"
#include "mfns_version.h"
#include "drivers/uart/uart.h"

static volatile sig_atomic_t g_stop;

static void on_signal(int sig)
{
    (void)sig;
    g_stop = 1;
}

void ground_usage(FILE *f)
{
    fprintf(f,
            "usage: mfns-ground SOURCE [--out DIR] [options]\n"
            "Decode MFNS telemetry (CCSDS packets in COBS frames, docs/telemetry.md) into\n"
            "CSV and JSON Lines per packet type.\n"
            "\n"
            "SOURCE (one of):\n"
            "  --serial DEV      serial port through libserialport (e.g. /dev/ttyUSB0), 8N1\n"
            "                    (--port DEV: the same, older spelling)\n"
            "  --tty PATH        a tty, pseudo-terminal or FIFO by path (raw mode)\n"
            "  --file PATH       a recorded byte stream; '-' reads stdin; ends at EOF\n"
            "options:\n"
            "  --baud N          baud rate for --port/--tty (default %d)\n"
            "  --out DIR         output folder (default ground-out): nav.csv, nav.jsonl,\n"
            "                    camera.csv, housekeeping.csv, events.csv (+ .jsonl), stats.json\n"
            "  --record FILE     also save the raw received bytes (replay with --file)\n"
            "  --max-seconds S   stop after S seconds\n"
            "  --max-frames N    stop after N good frames\n"
            "  --pace X          with --file: release packets at X times the pace of their\n"
            "                    flight times (1 = as recorded, 10 = ten times faster);\n"
            "                    default: as fast as the file reads (a UDP receiver may\n"
            "                    then drop what its socket buffer cannot hold)\n"
            "  --status          always show the live status line (default: when stderr is a tty)\n"
            "  --no-status       never show it\n"
            "  -v, --verbose     the live status line even when stderr is not a tty (= --status)\n"
            "  -q, --quiet       neither the status line nor the link counters at exit\n"
            "  -h, --help, --version\n"
            "Exit status: 0 ok, 1 the source or the output failed, 2 bad usage,\n"
            "3 no valid frame was decoded (nothing or only garbage received).\n"
            "At exit the link counters are printed on stderr: good frames, CRC errors,\n"
            "truncated and oversize frames, bad packets, resyncs, sequence gaps.\n",
            GROUND_DEFAULT_BAUD);
}

static int parse_number(const char *s, double lo, double hi, double *out)
{
    char *end = NULL;
    errno = 0;
    const double v = strtod(s, &end);
    if (errno != 0 || end == s || *end != '\0' || !(v >= lo && v <= hi)) {
        return -1;
    }
    *out = v;
    return 0;
}

int ground_parse_args(int argc, char **argv, ground_opts_t *o, FILE *err)
{
    memset(o, 0, sizeof *o);
    o->baud = GROUND_DEFAULT_BAUD;
    o->out_dir = "ground-out";
    o->status = -1;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const int has_val = i + 1 < argc;
        double v = 0;
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            ground_usage(stdout);
            return 1;
        }
        if (strcmp(a, "--version") == 0) {
            printf("mfns-ground %s\n", MFNS_VERSION_STR);
            return 1;
        }
        if (strcmp(a, "--quiet") == 0 || strcmp(a, "-q") == 0) {
            o->quiet = 1;
            o->status = 0;
            continue;
        }
        if (strcmp(a, "--status") == 0 || strcmp(a, "--verbose") == 0 || strcmp(a, "-v") == 0) {
            o->status = 1;
            continue;
        }
        if (strcmp(a, "--no-status") == 0) {
            o->status = 0;
            continue;
        }
        if (!has_val) {
            fprintf(err, "mfns-ground: %s: unknown option or missing value (see --help)\n", a);
            return -1;
        }
        const char *val = argv[++i];
        if (strcmp(a, "--serial") == 0 || strcmp(a, "--port") == 0 || strcmp(a, "--tty") == 0 ||
            strcmp(a, "--file") == 0) {
            if (o->src != GROUND_SRC_NONE) {
                fprintf(err, "mfns-ground: give exactly one of --serial, --tty, --file\n");
                return -1;
            }
            o->src = a[2] == 't' ? GROUND_SRC_TTY : (a[2] == 'f' ? GROUND_SRC_FILE : GROUND_SRC_SERIAL);
            o->path = val;
        } else if (strcmp(a, "--baud") == 0) {
            if (parse_number(val, 1, 4000000, &v) != 0 || v != (double)(uint32_t)v) {
                fprintf(err, "mfns-ground: --baud: expected a positive integer, got '%s'\n", val);
                return -1;
            }
            o->baud = (uint32_t)v;
        } else if (strcmp(a, "--out") == 0) {
            o->out_dir = val;
        } else if (strcmp(a, "--record") == 0) {
            o->record = val;
        } else if (strcmp(a, "--max-seconds") == 0) {
            if (parse_number(val, 0.001, 1e9, &v) != 0) {
                fprintf(err, "mfns-ground: --max-seconds: expected a positive number, got '%s'\n", val);
                return -1;
            }
            o->max_seconds = v;
        } else if (strcmp(a, "--pace") == 0) {
            if (parse_number(val, 0.001, 1e6, &v) != 0) {
                fprintf(err, "mfns-ground: --pace: expected a speed factor in [0.001, 1e6], got '%s'\n", val);
                return -1;
            }
            o->pace = v;
        } else if (strcmp(a, "--max-frames") == 0) {
            if (parse_number(val, 1, 4e9, &v) != 0 || v != (double)(unsigned long)v) {
                fprintf(err, "mfns-ground: --max-frames: expected a positive integer, got '%s'\n", val);
                return -1;
            }
            o->max_frames = (unsigned long)v;
        } else {
            fprintf(err, "mfns-ground: %s: unknown option (see --help)\n", a);
            return -1;
        }
    }
    if (o->pace > 0 && o->src != GROUND_SRC_FILE) {
        fprintf(err, "mfns-ground: --pace paces a recording: give it with --file\n");
        return -1;
    }
    if (o->src == GROUND_SRC_NONE) {
        fprintf(err, "mfns-ground: no source: give --serial DEV, --tty PATH or --file PATH (see --help)\n");
        return -1;
    }
    return 0;
}

static void print_counters(FILE *f, const tlm_decoder_stats_t *s, double secs)
{
    fprintf(f,
            "mfns-ground: %.1f s, %lu bytes: frames_ok=%lu crc_errors=%lu truncated=%lu oversize=%lu "
            "bad_packets=%lu resyncs=%lu seq_gaps=%lu seq_lost=%lu seq_back=%lu seq_late=%lu (",
            secs, (unsigned long)s->bytes, (unsigned long)s->frames_ok, (unsigned long)s->crc_errors,
            (unsigned long)s->truncated, (unsigned long)s->oversize, (unsigned long)s->bad_packets,
            (unsigned long)s->resyncs, (unsigned long)s->seq_gaps, (unsigned long)s->seq_lost,
            (unsigned long)s->seq_back, (unsigned long)s->seq_late);
    /* every packet type of the dictionary, by its name there (a new packet is counted
     * here without an edit: the list was a hand copy that missed FIXOBS) */
    for (unsigned t = 0; t < TLM_NUM_TYPES; t++) {
        fprintf(f, "%s%s=%lu", t ? " " : "", tlm_type_name((tlm_type_t)t), (unsigned long)s->type[t].packets);
    }
    fprintf(f, ")\n");
}

static void print_status(const tlm_decoder_stats_t *s, const tlm_nav_t *nav, int have_nav, double secs,
                         int link_down)
{
    char x[24], y[24], z[24], yaw[24];
    ground_fmt_fixed(x, sizeof x, have_nav ? nav->pos_um[0] : 0, 3);
    ground_fmt_fixed(y, sizeof y, have_nav ? nav->pos_um[1] : 0, 3);
    ground_fmt_fixed(z, sizeof z, have_nav ? nav->pos_um[2] : 0, 3);
    ground_fmt_fixed(yaw, sizeof yaw, have_nav ? nav->att_udeg[2] : 0, 6);
    fprintf(stderr, "\r%7.1f s %s frames %lu crc %lu trunc %lu over %lu gaps %lu resync %lu | %s x %s y %s z %s yaw %s\033[K",
            secs, link_down ? "LINK DOWN" : "link ok", (unsigned long)s->frames_ok, (unsigned long)s->crc_errors,
            (unsigned long)s->truncated, (unsigned long)s->oversize, (unsigned long)s->seq_gaps,
            (unsigned long)s->resyncs, have_nav ? tlm_nav_status_name(nav->status) : "-", x, y, z, yaw);
}

/* The ground receive time: UTC microseconds (CLOCK_REALTIME), 0 if unknown. */
static int64_t utc_now_us(void)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_REALTIME, &ts) != 0) {
        return 0;
    }
    return (int64_t)ts.tv_sec * 1000000 + (int64_t)ts.tv_nsec / 1000;
}

/* Pacing of a recording (--pace): the wall time at which a packet of flight
 * time t_us is due, given the first packet's pair. Flight time that goes back
 * (a reboot, a shuffled file) re-anchors at once instead of waiting; a jump
 * forward waits at most GROUND_PACE_MAX_WAIT_S (so a gap of hours in a
 * recording does not hang the replay), then re-anchors too. */
#define GROUND_PACE_MAX_WAIT_S 5.0
typedef struct {
    int anchored;
    uint64_t t0_flight_us;
    uint64_t t0_wall_ms;
} pace_t;

static uint64_t packet_time_us(const tlm_packet_t *p)
{
    return (uint64_t)p->time.coarse_s * 1000000u + (((uint64_t)p->time.fine * 1000000u) >> 16);
}

static void pace_packet(pace_t *pc, double pace, const tlm_packet_t *p, volatile sig_atomic_t *stop)
{
    const uint64_t t = packet_time_us(p);
    const uint64_t now = mfns_uart_now_ms();
    if (!pc->anchored || t < pc->t0_flight_us) {
        *pc = (pace_t){1, t, now};
        return;
    }
    const double due_ms = (double)(t - pc->t0_flight_us) / 1000.0 / pace;
    const double waited_ms = (double)(now - pc->t0_wall_ms);
    double wait_ms = due_ms - waited_ms;
    if (wait_ms > GROUND_PACE_MAX_WAIT_S * 1000.0) {
        *pc = (pace_t){1, t, now}; /* a gap in the recording: go on from here */
        return;
    }
    /* sleep in slices so a signal ends the replay promptly */
    for (int i = 0; wait_ms > 0.0 && !*stop && i < 1000; i++) {
        const double slice = wait_ms < 50.0 ? wait_ms : 50.0;
        const struct timespec ts = {0, (long)(slice * 1e6)};
        (void)nanosleep(&ts, NULL); /* EINTR: the loop re-checks stop */
        wait_ms -= slice;
    }
}

static int open_source(const ground_opts_t *o, mfns_uart_t *u)
{
    memset(u, 0, sizeof *u);
    u->fd = -1;
    int rc;
    switch (o->src) {
    case GROUND_SRC_SERIAL:
        rc = mfns_uart_open_serial(u, o->path, o->baud, o->source_rw ? MFNS_UART_RW : MFNS_UART_READ);
        break;
    case GROUND_SRC_TTY:
        rc = mfns_uart_open_path(u, o->path, o->baud, o->source_rw ? MFNS_UART_RW : MFNS_UART_READ);
        break;
    case GROUND_SRC_FILE: {
        /* --file ends at the end of its input whatever it is (a file, a
         * pipe, /dev/null, a FIFO whose writer closed): attached, never
         * re-opened, so a read of 0 is the end. */
        const int fd = strcmp(o->path, "-") == 0 ? STDIN_FILENO : open(o->path, O_RDONLY | O_CLOEXEC | O_NOCTTY);
        if (fd < 0) {
            fprintf(stderr, "mfns-ground: %s: cannot open the recording: %s\n", o->path, strerror(errno));
            return MFNS_UART_ERR_OPEN;
        }
        rc = mfns_uart_attach_fd(u, fd, fd != STDIN_FILENO, MFNS_UART_READ);
        if (rc != MFNS_UART_OK && fd != STDIN_FILENO) {
            (void)close(fd); /* not attached: still ours */
        }
        break;
    }
    default: rc = MFNS_UART_ERR_ARG; break;
    }
    if (rc != MFNS_UART_OK) {
        fprintf(stderr, "mfns-ground: %s: %s%s%s\n", o->path, mfns_uart_strerror(rc), u->last_errno ? ": " : "",
                u->last_errno ? strerror(u->last_errno) : "");
        mfns_uart_close(u);
    }
    return rc;
}

int ground_run(const ground_opts_t *o, tlm_decoder_stats_t *stats_out)
{
    static tlm_decoder_t dec; /* static: 300 bytes of buffer + counters, no heap */
    tlm_decoder_init(&dec);
    ground_out_t out;
    char err[512];
    if (ground_out_open(&out, o->out_dir, err, sizeof err) != 0) {
        fprintf(stderr, "mfns-ground: %s\n", err);
        return 1;
    }
    FILE *rec = NULL;
    if (o->record != NULL && (rec = fopen(o->record, "wb")) == NULL) {
        fprintf(stderr, "mfns-ground: cannot write %s: %s\n", o->record, strerror(errno));
        (void)ground_out_close(&out);
        return 1;
    }
    mfns_uart_t u;
    if (open_source(o, &u) != MFNS_UART_OK) {
        (void)ground_out_close(&out);
        if (rec != NULL) {
            fclose(rec);
        }
        return 1;
    }
    g_stop = 0;
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    (void)sigaction(SIGINT, &sa, NULL);
    (void)sigaction(SIGTERM, &sa, NULL);

    /* -q is quiet: no status line unless --status asked for one */
    const int show = o->status < 0 ? (!o->quiet && isatty(STDERR_FILENO)) : o->status;
    const uint64_t t0 = mfns_uart_now_ms();
    uint64_t last_status = 0;
    tlm_nav_t last_nav;
    memset(&last_nav, 0, sizeof last_nav);
    int have_nav = 0, link_down = 0, rc_exit = 0, done = 0;
    pace_t pace = {0, 0, 0};
    while (!g_stop && !done) {
        const uint64_t now = mfns_uart_now_ms();
        const double secs = (double)(now - t0) / 1000.0;
        if (o->max_seconds > 0 && secs >= o->max_seconds) {
            break;
        }
        if (o->hooks != NULL && o->hooks->poll != NULL) {
            o->hooks->poll(o->hooks->ctx, &u, now); /* commands up, UDP commands in */
        }
        if (o->hooks != NULL && o->hooks->done != NULL && o->hooks->done(o->hooks->ctx)) {
            break; /* --upload answered */
        }
        uint8_t buf[4096];
        size_t got = 0;
        const int rc = mfns_uart_read(&u, buf, sizeof buf, &got, 100, now);
        const int64_t rx_utc_us = got > 0 ? utc_now_us() : 0; /* every packet of this read arrived by now */
        if (got > 0 && rec != NULL && fwrite(buf, 1, got, rec) != got) {
            fprintf(stderr, "mfns-ground: writing %s failed\n", o->record);
            rc_exit = 1;
            break;
        }
        for (size_t i = 0; i < got; i++) {
            tlm_packet_t p;
            if (tlm_decoder_push(&dec, buf[i], &p) == 1) {
                int64_t utc_us = rx_utc_us;
                if (o->pace > 0) {
                    pace_packet(&pace, o->pace, &p, &g_stop);
                    utc_us = utc_now_us(); /* released now: its receipt time */
                }
                int64_t pkt_utc_us = 0;
                if (ground_out_packet(&out, &p, utc_us, &pkt_utc_us) != 0) {
                    fprintf(stderr, "mfns-ground: writing to %s failed\n", o->out_dir);
                    rc_exit = 1;
                    done = 1;
                    break;
                }
                if (o->hooks != NULL && o->hooks->packet != NULL) {
                    /* forwarded with its time correlated to UTC (UNIX epoch: Yamcs
                     * shows it at its real time, docs/telemetry.md "Time") */
                    tlm_packet_t fwd = p;
                    fwd.time = tlm_time_from_us(pkt_utc_us > 0 ? (uint64_t)pkt_utc_us : 0u);
                    o->hooks->packet(o->hooks->ctx, &fwd);
                }
                if (p.type == TLM_TYPE_NAV) {
                    last_nav = p.u.nav;
                    have_nav = 1;
                }
                if (o->max_frames > 0 && dec.stats.frames_ok >= o->max_frames) {
                    done = 1;
                    break;
                }
            }
        }
        if (rc == MFNS_UART_EOF) {
            (void)tlm_decoder_finish(&dec); /* a frame cut by the end of the file is counted */
            break;
        }
        link_down = (rc == MFNS_UART_ERR_GONE || rc == MFNS_UART_ERR_CLOSED);
        if (rc == MFNS_UART_ERR_GONE) {
            tlm_decoder_reset_frame(&dec);
        } else if (rc == MFNS_UART_ERR_IO || rc == MFNS_UART_ERR_ARG) {
            fprintf(stderr, "\nmfns-ground: %s: %s\n", o->path, mfns_uart_strerror(rc));
            rc_exit = 1;
            break;
        }
        if (show && now - last_status >= 200u) {
            print_status(&dec.stats, &last_nav, have_nav, secs, link_down);
            last_status = now;
        }
    }
    const double secs = (double)(mfns_uart_now_ms() - t0) / 1000.0;
    if (show) {
        print_status(&dec.stats, &last_nav, have_nav, secs, link_down);
        fputc('\n', stderr);
    }
    if (o->hooks != NULL && o->hooks->finish != NULL) {
        o->hooks->finish(o->hooks->ctx, &u);
    }
    mfns_uart_close(&u);
    if (rec != NULL && fclose(rec) != 0) {
        rc_exit = 1;
    }
    if (ground_out_stats(&out, &dec.stats, secs) != 0 || ground_out_close(&out) != 0) {
        fprintf(stderr, "mfns-ground: writing to %s failed\n", o->out_dir);
        rc_exit = 1;
    }
    if (!o->quiet) {
        print_counters(stderr, &dec.stats, secs);
    }
    if (stats_out != NULL) {
        *stats_out = dec.stats;
    }
    if (rc_exit == 0 && dec.stats.frames_ok == 0) {
        fprintf(stderr, "mfns-ground: no valid frame decoded from %s (exit %d)\n", o->path, GROUND_EXIT_NO_FRAME);
        rc_exit = GROUND_EXIT_NO_FRAME;
    }
    return rc_exit;
}
