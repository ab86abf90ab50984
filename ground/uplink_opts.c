/* uplink_opts.c -- mfns-ground's uplink options (uplink.h): usage, parsing
 * and the checks made before anything runs. Kept apart from uplink.c (the
 * running side). */
#define _DEFAULT_SOURCE

#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "ground/uplink.h"

void uplink_usage(FILE *f)
{
    fprintf(f,
            "uplink (telecommands, docs/uplink.md):\n"
            "  --cmd TEXT        send one command (repeatable, in order), e.g. --cmd 'SET_MODE acquire'\n"
            "  --cmd-file PATH   commands, one per line, read while receiving ('-' = stdin)\n"
            "  --tc-tty PATH     send commands to a tty, pseudo-terminal or FIFO\n"
            "  --tc-file PATH    write the command frames to a file (created/truncated)\n"
            "  --uplink          send commands on the --tty/--serial source itself (read-write)\n"
            "  --tc-seq-start N  first sequence count (0..16383, default 0)\n"
            "  --tc-key FILE     sign every command with the first key of FILE ('ID HEX', mode 0600/0400)\n"
            "  --tc-state FILE   the ground's own uplink state (largest epoch given, next count), written\n"
            "                    atomically before every signed command; needed to re-synchronise the\n"
            "                    board (it learns the board's state only from authenticated reports)\n"
            "  --tc-epoch N      sign for this epoch without waiting (a command file prepared offline;\n"
            "                    default: re-synchronise the board to a fresh epoch, with --tc-state)\n"
            "  --tc-count-start N  first anti-replay count with --tc-epoch (default 1)\n"
            "  --tc-socket PATH  receive CCSDS TC packets on a Unix datagram socket created mode 0600\n"
            "  --upload FILE     send FILE (a calibration table) with UPLOAD_START/DATA/END once the uplink is\n"
            "                    ready; the run ends when the board answered: exit 0 stored and loaded,\n"
            "                    1 refused (the reason named) or never answered (docs/uplink.md 5a)\n"
            "  grammar: NOOP | RESET_COUNTERS | SET_MODE standby|acquire|track |\n"
            "           SET_POSE_HINT X Y Z ROLL PITCH YAW (mm, deg) | CAMERA_ENABLE x|y|z |\n"
            "           CAMERA_DISABLE x|y|z | TABLE_LOAD PATH | WAIT SECONDS ; '#' comments\n"
            "ground system (UDP, loopback only unless --udp-allow-remote):\n"
            "  --udp-forward HOST:PORT  every decoded packet (CCSDS bytes) as a datagram\n"
            "  --tcp-forward HOST:PORT  listen there; every decoded packet (CCSDS bytes) to the client\n"
            "                           as a stream, lossless (e.g. Yamcs' TcpTmDataLink, link tm_tcp)\n"
            "  --udp-tc HOST:PORT       receive CCSDS TC packets (e.g. Yamcs' TC link) and send them up\n"
            "  --udp-allow-remote       allow a non-loopback HOST\n");
}

/* A decimal option value in lo..hi; false after one line on err. */
static bool opt_u32(const char *name, const char *v, uint32_t lo, uint32_t hi, uint32_t *out, FILE *err)
{
    char *end = NULL;
    errno = 0;
    const unsigned long long x = strtoull(v, &end, 10);
    if (errno != 0 || end == v || *end != '\0' || v[0] == '-' || x < lo || x > hi) {
        fprintf(err, "mfns-ground: %s wants %u..%u, got '%s'\n", name, lo, hi, v);
        return false;
    }
    *out = (uint32_t)x;
    return true;
}

int uplink_parse_args(int argc, char **argv, uplink_opts_t *o, char **rest, int *n_rest, FILE *err)
{
    memset(o, 0, sizeof *o);
    int nr = 0;
    rest[nr++] = argv[0];
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const bool has_val = i + 1 < argc;
        const char *needs[] = {"--cmd",          "--cmd-file", "--tc-tty", "--tc-file",
                               "--tc-seq-start", "--udp-forward", "--udp-tc", "--tc-key", "--tc-epoch",
                               "--tc-socket", "--tc-count-start", "--tcp-forward", "--tc-state", "--upload"};
        bool mine_val = false;
        for (size_t k = 0; k < sizeof needs / sizeof needs[0]; k++) {
            mine_val = mine_val || strcmp(a, needs[k]) == 0;
        }
        if (strcmp(a, "--uplink") == 0 || strcmp(a, "--udp-allow-remote") == 0) {
            if (a[2] == 'u' && a[3] == 'p') {
                if (o->out != UPLINK_OUT_NONE) {
                    fprintf(err, "mfns-ground: give one of --tc-tty, --tc-file, --uplink\n");
                    return -1;
                }
                o->out = UPLINK_OUT_LINK;
            } else {
                o->udp_allow_remote = true;
            }
            continue;
        }
        if (!mine_val) {
            rest[nr++] = argv[i];
            continue;
        }
        if (!has_val) {
            fprintf(err, "mfns-ground: %s: missing value (see --help)\n", a);
            return -1;
        }
        const char *v = argv[++i];
        if (strcmp(a, "--cmd") == 0) {
            if (o->n_cli >= UPLINK_MAX_CLI) {
                fprintf(err, "mfns-ground: at most %d --cmd (use --cmd-file)\n", UPLINK_MAX_CLI);
                return -1;
            }
            o->cli[o->n_cli++] = v;
        } else if (strcmp(a, "--cmd-file") == 0) {
            o->cmd_file = v;
        } else if (strcmp(a, "--tc-tty") == 0 || strcmp(a, "--tc-file") == 0) {
            if (o->out != UPLINK_OUT_NONE) {
                fprintf(err, "mfns-ground: give one of --tc-tty, --tc-file, --uplink\n");
                return -1;
            }
            o->out = a[5] == 't' ? UPLINK_OUT_TTY : UPLINK_OUT_FILE;
            o->out_path = v;
        } else if (strcmp(a, "--tc-seq-start") == 0) {
            uint32_t s = 0;
            if (!opt_u32(a, v, 0u, TLM_CCSDS_SEQ_MASK, &s, err)) {
                return -1;
            }
            o->seq_start = (uint16_t)s;
        } else if (strcmp(a, "--udp-forward") == 0) {
            o->udp_forward = v;
        } else if (strcmp(a, "--tcp-forward") == 0) {
            o->tcp_forward = v;
        } else if (strcmp(a, "--tc-key") == 0) {
            o->tc_key = v;
        } else if (strcmp(a, "--tc-state") == 0) {
            o->tc_state = v;
        } else if (strcmp(a, "--upload") == 0) {
            o->upload = v;
        } else if (strcmp(a, "--tc-socket") == 0) {
            o->tc_socket = v;
        } else if (strcmp(a, "--tc-count-start") == 0 || strcmp(a, "--tc-epoch") == 0) {
            if (!opt_u32(a, v, 1u, UINT32_MAX, a[5] == 'c' ? &o->tc_count_start : &o->tc_epoch, err)) {
                return -1;
            }
        } else {
            o->udp_tc = v;
        }
    }
    rest[nr] = NULL;
    *n_rest = nr;
    /* every command line is checked before anything runs */
    for (int k = 0; k < o->n_cli; k++) {
        uplink_line_kind_t kind;
        tc_cmd_t c;
        double w = 0;
        char msg[192];
        if (uplink_parse_line(o->cli[k], &kind, &c, &w, msg, sizeof msg) != 0) {
            fprintf(err, "mfns-ground: --cmd '%s': %s\n", o->cli[k], msg);
            return -1;
        }
        if (kind != UPLINK_LINE_CMD) {
            fprintf(err, "mfns-ground: --cmd '%s': not a command (WAIT belongs in a --cmd-file)\n", o->cli[k]);
            return -1;
        }
    }
    if ((o->tc_epoch != 0u || o->tc_count_start != 0u) && o->tc_key == NULL) {
        fprintf(err, "mfns-ground: --tc-epoch signs for an epoch: give --tc-key FILE too\n");
        return -1;
    }
    if (o->tc_state != NULL && o->tc_key == NULL) {
        fprintf(err, "mfns-ground: --tc-state keeps the signing state: give --tc-key FILE too\n");
        return -1;
    }
    if (o->tc_key != NULL && o->tc_epoch == 0u && o->tc_state == NULL) {
        fprintf(err, "mfns-ground: --tc-key without --tc-epoch needs --tc-state FILE: the ground gives the board "
                     "its epochs and must remember them (docs/uplink.md 1a)\n");
        return -1;
    }
    if ((o->n_cli > 0 || o->cmd_file != NULL || o->udp_tc != NULL || o->tc_socket != NULL || o->upload != NULL) &&
        o->out == UPLINK_OUT_NONE) {
        fprintf(err, "mfns-ground: commands need a way up: --tc-tty PATH, --tc-file PATH or --uplink\n");
        return -1;
    }
    char msg[192];
    uint32_t addr;
    uint16_t port;
    if (o->udp_forward != NULL && udp_parse_endpoint(o->udp_forward, o->udp_allow_remote, &addr, &port, msg,
                                                     sizeof msg) != 0) {
        fprintf(err, "mfns-ground: --udp-forward %s\n", msg);
        return -1;
    }
    if (o->tcp_forward != NULL && udp_parse_endpoint(o->tcp_forward, o->udp_allow_remote, &addr, &port, msg,
                                                     sizeof msg) != 0) {
        fprintf(err, "mfns-ground: --tcp-forward %s\n", msg);
        return -1;
    }
    if (o->udp_tc != NULL && udp_parse_endpoint(o->udp_tc, o->udp_allow_remote, &addr, &port, msg, sizeof msg) != 0) {
        fprintf(err, "mfns-ground: --udp-tc %s\n", msg);
        return -1;
    }
    return 0;
}

bool uplink_wanted(const uplink_opts_t *o)
{
    return o->out != UPLINK_OUT_NONE || o->upload != NULL || o->udp_forward != NULL || o->tcp_forward != NULL;
}

