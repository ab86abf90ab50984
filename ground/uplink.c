/* uplink.c -- see uplink.h. */
#define _DEFAULT_SOURCE /* strcasecmp, strtok_r under -std=c11 */

#include "ground/uplink.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>
#include <unistd.h>

#include "firmware/linux/txq_drain.h"

_Static_assert(TC_MAX_WIRE <= TLM_TXQ_MAX_WIRE, "a command frame fits the uplink queue");

#define FLUSH_TRIES 100 /* x 10 ms: commands drained at exit */
#define TCP_CLOSE_MS 3000u /* what the TCP receiver still takes at exit, at most (bounded) */

/* ---- grammar ---- */

static int word_to_camera(const char *w, uint8_t *k)
{
    static const char *const names[3] = {"x", "y", "z"};
    for (uint8_t i = 0; i < 3u; i++) {
        if (strcasecmp(w, names[i]) == 0 || (w[0] == (char)('0' + i) && w[1] == '\0')) {
            *k = i;
            return 0;
        }
    }
    return -1;
}

/* value * scale rounded, within +-lim: the wire integer of a pose number. */
static int to_fixed(const char *w, double scale, int32_t lim, int32_t *out)
{
    char *end = NULL;
    errno = 0;
    const double v = strtod(w, &end);
    if (errno != 0 || end == w || *end != '\0' || !isfinite(v)) {
        return -1;
    }
    const double x = round(v * scale);
    if (!(x >= -(double)lim && x <= (double)lim)) {
        return -1;
    }
    *out = (int32_t)x;
    return 0;
}

int uplink_parse_line(const char *line, uplink_line_kind_t *kind, tc_cmd_t *cmd, double *wait_s, char *err,
                      size_t err_size)
{
    char buf[UPLINK_LINE_MAX + 1];
    if (strlen(line) > UPLINK_LINE_MAX) {
        (void)snprintf(err, err_size, "line longer than %d bytes", UPLINK_LINE_MAX);
        return -1;
    }
    (void)snprintf(buf, sizeof buf, "%s", line);
    char *hash = strchr(buf, '#');
    if (hash != NULL) {
        *hash = '\0';
    }
    char *w[8];
    int n = 0;
    char *save = NULL;
    for (char *t = strtok_r(buf, " \t\r\n,", &save); t != NULL; t = strtok_r(NULL, " \t\r\n,", &save)) {
        if (n == 8) {
            (void)snprintf(err, err_size, "too many words");
            return -1;
        }
        w[n++] = t;
    }
    memset(cmd, 0, sizeof *cmd);
    *kind = UPLINK_LINE_EMPTY;
    if (n == 0) {
        return 0;
    }
    const char *op = w[0];
    int want = -1; /* number of argument words */
    if (strcasecmp(op, "WAIT") == 0) {
        char *end = NULL;
        const double s = n == 2 ? strtod(w[1], &end) : -1.0;
        if (n != 2 || end == w[1] || *end != '\0' || !(s >= 0.0 && s <= 3600.0)) {
            (void)snprintf(err, err_size, "WAIT wants seconds 0..3600");
            return -1;
        }
        *kind = UPLINK_LINE_WAIT;
        *wait_s = s;
        return 0;
    }
    for (unsigned code = 1; code <= (unsigned)TC_OP_MAX; code++) {
        if (strcasecmp(op, tc_opcode_name((uint8_t)code)) == 0) {
            cmd->opcode = (uint8_t)code;
        }
    }
    want = tc_arg_count(cmd->opcode); /* one word per XTCE argument */
    if (want < 0) {
        (void)snprintf(err, err_size, "unknown command '%s'", op);
        return -1;
    }
    if (n - 1 != want) {
        (void)snprintf(err, err_size, "%s wants %d argument%s, got %d", tc_opcode_name(cmd->opcode), want,
                       want == 1 ? "" : "s", n - 1);
        return -1;
    }
    switch (cmd->opcode) {
    case TC_OP_SET_MODE:
        if (strcasecmp(w[1], "standby") == 0) {
            cmd->u.mode = TLM_MODE_STANDBY;
        } else if (strcasecmp(w[1], "acquire") == 0) {
            cmd->u.mode = TLM_MODE_ACQUIRE;
        } else if (strcasecmp(w[1], "track") == 0) {
            cmd->u.mode = TLM_MODE_TRACK;
        } else {
            (void)snprintf(err, err_size, "SET_MODE wants standby, acquire or track, got '%s'", w[1]);
            return -1;
        }
        break;
    case TC_OP_CAMERA_ENABLE:
    case TC_OP_CAMERA_DISABLE:
        if (word_to_camera(w[1], &cmd->u.camera) != 0) {
            (void)snprintf(err, err_size, "camera must be x, y, z or 0, 1, 2, got '%s'", w[1]);
            return -1;
        }
        break;
    case TC_OP_SET_POSE_HINT: {
        const int32_t lim[6] = {TC_POS_UM_MAX,        TC_POS_UM_MAX,     TC_POS_UM_MAX,
                                TC_ROLL_YAW_UDEG_MAX, TC_PITCH_UDEG_MAX, TC_ROLL_YAW_UDEG_MAX};
        for (int i = 0; i < 6; i++) {
            int32_t *dst = i < 3 ? &cmd->u.pose.pos_um[i] : &cmd->u.pose.att_udeg[i - 3];
            if (to_fixed(w[1 + i], i < 3 ? 1e3 : 1e6, lim[i], dst) != 0) {
                (void)snprintf(err, err_size,
                               "SET_POSE_HINT X Y Z ROLL PITCH YAW: '%s' is not a number in range (|mm| <= 1e6, "
                               "|roll|,|yaw| <= 180, |pitch| <= 90 deg)",
                               w[1 + i]);
                return -1;
            }
        }
        break;
    }
    case TC_OP_TABLE_LOAD:
        if (strlen(w[1]) >= TC_PATH_MAX) {
            (void)snprintf(err, err_size, "TABLE_LOAD path longer than %u characters", TC_PATH_MAX - 1u);
            return -1;
        }
        (void)snprintf(cmd->u.path, sizeof cmd->u.path, "%s", w[1]);
        break;
    default: break;
    }
    /* the codec's own checks (what the flight side would refuse is never sent) */
    uint8_t tmp[TC_MAX_PACKET];
    size_t len = 0;
    const tc_status_t st = tc_packet_encode(cmd, 0, tmp, sizeof tmp, &len);
    if (st != TC_OK) {
        (void)snprintf(err, err_size, "%s: %s", tc_opcode_name(cmd->opcode), tc_strerror(st));
        return -1;
    }
    *kind = UPLINK_LINE_CMD;
    return 0;
}

/* ---- running ---- */

static void utc_now(char *buf, size_t n)
{
    struct timespec ts;
    struct tm tm;
    if (clock_gettime(CLOCK_REALTIME, &ts) != 0 || gmtime_r(&ts.tv_sec, &tm) == NULL) {
        (void)snprintf(buf, n, "?");
        return;
    }
    char s[24];
    if (strftime(s, sizeof s, "%Y-%m-%dT%H:%M:%S", &tm) == 0) {
        s[0] = '\0';
    }
    (void)snprintf(buf, n, "%.19s.%06dZ", s, (int)(ts.tv_nsec / 1000L % 1000000L));
}

static void log_cmd(uplink_t *up, uint16_t seq, const tc_cmd_t *c, const char *source, const char *text)
{
    if (up->log == NULL && !up->log_failed) {
        char path[512];
        (void)snprintf(path, sizeof path, "%s/commands.csv", up->o.out_dir ? up->o.out_dir : ".");
        up->log = fopen(path, "w");
        if (up->log == NULL) {
            up->log_failed = true;
            fprintf(stderr, "mfns-ground: cannot write %s: %s\n", path, strerror(errno));
            return;
        }
        fprintf(up->log, "utc,seq,opcode,source,text\n");
    }
    if (up->log != NULL) {
        char t[48];
        utc_now(t, sizeof t);
        char clean[UPLINK_LINE_MAX + 1];
        size_t j = 0;
        for (size_t i = 0; text[i] != '\0' && j < UPLINK_LINE_MAX; i++) {
            clean[j++] = (text[i] == ',' || text[i] == '"' || text[i] == '\n' || text[i] == '\r') ? ' ' : text[i];
        }
        clean[j] = '\0';
        fprintf(up->log, "%s,%u,%s,%s,%s\n", t, seq, tc_opcode_name(c->opcode), source, clean);
        (void)fflush(up->log);
    }
}

/* The flight's sequence guard (firmware/app/nav_cmd_dispatch.c): a count is newer than the
 * last one when it is 1..half the count space ahead of it (modulo 2^14). */
#define UPLINK_SEQ_WINDOW (TLM_CCSDS_SEQ_MASK / 2u)

/* The count a command goes up with. A command of the ground system's TC link (Yamcs, which
 * numbers its commands and verifies each one on the flight's answer carrying that number,
 * contract/mfns_tc.xml) keeps its own count when that is newer than the last count sent, so
 * the flight's answer names the command Yamcs knows; every other source, and a Yamcs count
 * that is not newer (Yamcs restarted while the board ran on, or other sources went ahead),
 * gets the next count of the ground's one counter: the flight would refuse an older count. */
static uint16_t pick_seq(uplink_t *up, const tc_cmd_t *c, bool keep_senders)
{
    if (!keep_senders || !c->have_seq) {
        return up->next_seq;
    }
    const uint16_t last = (uint16_t)((up->next_seq - 1u) & TLM_CCSDS_SEQ_MASK);
    const uint32_t ahead = (uint32_t)(c->seq - last) & TLM_CCSDS_SEQ_MASK;
    if (ahead >= 1u && ahead <= UPLINK_SEQ_WINDOW) {
        return c->seq;
    }
    fprintf(stderr,
            "mfns-ground: the ground system's command %s has sequence count %u, not after the uplink's "
            "last (%u): sent as %u; the ground system cannot match the flight's answer to it (its "
            "verifiers time out)\n",
            tc_opcode_name(c->opcode), c->seq, last, up->next_seq);
    return up->next_seq;
}

/* Give c its sequence count (pick_seq) and queue its frame: the count, or -1 when not sent. */
static int send_cmd(uplink_t *up, const tc_cmd_t *c, const char *source, const char *text, bool keep_senders)
{
    uint8_t wire[TC_MAX_WIRE];
    size_t n = 0;
    const uint16_t seq = pick_seq(up, c, keep_senders);
    const tc_status_t st = uplink_auth_frame(&up->auth, c, seq, wire, sizeof wire, &n);
    if (st != TC_OK || tlm_txq_push(&up->q, wire, n) != TLM_OK) {
        up->n_errors++;
        fprintf(stderr, "mfns-ground: command '%s' not sent: %s\n", text, tc_strerror(st));
        return -1;
    }
    up->next_seq = (uint16_t)((seq + 1u) & TLM_CCSDS_SEQ_MASK);
    up->n_sent++;
    log_cmd(up, seq, c, source, text);
    return (int)seq;
}

static void handle_line(uplink_t *up, const char *line, const char *source, uint64_t now_ms)
{
    up->line_no++;
    uplink_line_kind_t kind;
    tc_cmd_t c;
    double w = 0;
    char msg[192];
    if (uplink_parse_line(line, &kind, &c, &w, msg, sizeof msg) != 0) {
        up->n_errors++;
        fprintf(stderr, "mfns-ground: %s line %lu: %s (not sent)\n", source, up->line_no, msg);
        return;
    }
    if (kind == UPLINK_LINE_WAIT) {
        up->wait_until_ms = now_ms + (uint64_t)llround(w * 1000.0);
    } else if (kind == UPLINK_LINE_CMD) {
        (void)send_cmd(up, &c, source, line, false);
    }
}

/* Lines of the command file/stdin available now; stops at a WAIT. */
static void read_cmd_file(uplink_t *up, uint64_t now_ms)
{
    for (int round = 0; round < 16 && up->cmd_fd >= 0 && now_ms >= up->wait_until_ms; round++) {
        char *nl = memchr(up->line, '\n', up->line_len);
        if (nl != NULL) {
            *nl = '\0';
            if (!up->line_too_long) {
                handle_line(up, up->line, "file", now_ms);
            } else {
                up->n_errors++;
                fprintf(stderr, "mfns-ground: command file: line longer than %d bytes (not sent)\n", UPLINK_LINE_MAX);
                up->line_too_long = false;
            }
            const size_t used = (size_t)(nl - up->line) + 1u;
            memmove(up->line, nl + 1, up->line_len - used);
            up->line_len -= used;
            continue;
        }
        if (up->line_len == UPLINK_LINE_MAX) { /* no newline in a full buffer: drop up to the next one */
            up->line_too_long = true;
            up->line_len = 0;
        }
        const ssize_t r = read(up->cmd_fd, up->line + up->line_len, UPLINK_LINE_MAX - up->line_len);
        if (r > 0) {
            up->line_len += (size_t)r;
            continue;
        }
        if (r == 0) { /* end: the last line may lack its newline */
            if (up->line_len > 0u && !up->line_too_long) {
                up->line[up->line_len] = '\0';
                handle_line(up, up->line, "file", now_ms);
            }
            up->line_len = 0;
            if (up->cmd_fd != STDIN_FILENO) {
                (void)close(up->cmd_fd);
            }
            up->cmd_fd = -1;
        }
        break; /* EAGAIN: nothing more now */
    }
}

static mfns_uart_t *out_link(uplink_t *up, mfns_uart_t *src)
{
    if (up->o.out == UPLINK_OUT_LINK) {
        return src;
    }
    return up->o.out == UPLINK_OUT_NONE ? NULL : &up->tc;
}

/* One Unix/UDP intake: at most 16 datagrams per poll. */
static void poll_intake(uplink_t *up, udp_tc_in_t *in, const char *source, bool keep_senders)
{
    for (int i = 0; i < 16; i++) {
        tc_cmd_t c;
        tc_status_t st = TC_OK;
        const int r = udp_tc_poll(in, &c, &st);
        if (r == 0) {
            break;
        }
        if (r < 0) {
            up->n_errors++;
            fprintf(stderr, "mfns-ground: %s command refused: %s (not sent)\n", source, tc_strerror(st));
            continue;
        }
        (void)send_cmd(up, &c, source, tc_opcode_name(c.opcode), keep_senders);
    }
}

/* --upload: the upload's next commands, while the queue has room (it drops the oldest). */
static void poll_upload(uplink_t *up, uint64_t now_ms)
{
    for (unsigned i = 0; up->o.upload != NULL && i < UPLOAD_WINDOW && tlm_txq_frames(&up->q) < UPLOAD_QUEUED_MAX;
         i++) {
        tc_cmd_t c;
        if (!ground_upload_next(&up->upl, now_ms, &c)) {
            break;
        }
        const int seq = send_cmd(up, &c, "upload", tc_opcode_name(c.opcode), false);
        if (seq < 0) {
            break; /* counted and said by send_cmd; tried again at the next poll */
        }
        ground_upload_sent(&up->upl, &c, (uint16_t)seq, now_ms);
    }
}

static bool hook_done(void *ctx)
{
    const uplink_t *up = ctx;
    return up->o.upload != NULL && ground_upload_finished(&up->upl) && tlm_txq_frames(&up->q) == 0u;
}

static void hook_poll(void *ctx, mfns_uart_t *src, uint64_t now_ms)
{
    uplink_t *up = ctx;
    mfns_uart_t *u = out_link(up, src);
    tcp_forward_poll(&up->tcp); /* a client connecting, a queue draining */
    if (up->auth.resync_due) { /* the board asked for an epoch: it goes first */
        uint8_t wire[TC_MAX_WIRE];
        size_t n = 0;
        /* before anything was sent, the one before the first count (the board takes any count
         * first): the sources' counts (--tc-seq-start, Yamcs' own) are left as they were */
        const bool first = up->n_sent == 0u;
        const uint16_t seq = first ? (uint16_t)((up->next_seq - 1u) & TLM_CCSDS_SEQ_MASK) : up->next_seq;
        if (uplink_auth_resync_frame(&up->auth, seq, now_ms, wire, sizeof wire, &n) == TC_OK) {
            if (tlm_txq_push(&up->q, wire, n) == TLM_OK) {
                tc_cmd_t c;
                memset(&c, 0, sizeof c);
                c.opcode = TC_OP_NOOP;
                log_cmd(up, seq, &c, "resync", "RESYNC");
                up->next_seq = first ? up->next_seq : (uint16_t)((up->next_seq + 1u) & TLM_CCSDS_SEQ_MASK);
                up->n_sent++;
            } else {
                up->n_errors++;
            }
        }
    }
    if (!uplink_auth_ready(&up->auth)) { /* signing: the board's epoch not known yet; commands wait */
        if (u != NULL && tlm_txq_frames(&up->q) > 0u) {
            (void)txq_drain(&up->q, u, now_ms);
        }
        return;
    }
    for (; up->next_cli < up->o.n_cli; up->next_cli++) {
        handle_line(up, up->o.cli[up->next_cli], "cli", now_ms);
    }
    read_cmd_file(up, now_ms);
    poll_intake(up, &up->tcin, "udp", true); /* Yamcs: its own counts (pick_seq) */
    poll_intake(up, &up->sockin, "socket", false);
    poll_upload(up, now_ms);
    if (u != NULL && tlm_txq_frames(&up->q) > 0u) {
        (void)txq_drain(&up->q, u, now_ms); /* a link not there yet: frames wait */
    }
}

static void hook_packet(void *ctx, const tlm_packet_t *p)
{
    uplink_t *up = ctx;
    if (p->type == TLM_TYPE_HK) {
        uplink_auth_housekeeping(&up->auth, &p->u.hk, mfns_uart_now_ms());
    }
    if (p->type == TLM_TYPE_EVENT && up->o.upload != NULL) {
        ground_upload_event(&up->upl, &p->u.event, mfns_uart_now_ms());
    }
    (void)udp_forward_packet(&up->fwd, p);
    (void)tcp_forward_packet(&up->tcp, p);
}

static void hook_finish(void *ctx, mfns_uart_t *src)
{
    uplink_t *up = ctx;
    hook_poll(ctx, src, mfns_uart_now_ms()); /* what the last packets made due (a recording's last report) */
    tc_cmd_t abort_cmd;
    if (up->o.upload != NULL && uplink_auth_ready(&up->auth) &&
        ground_upload_abort(&up->upl, mfns_uart_now_ms(), &abort_cmd)) {
        (void)send_cmd(up, &abort_cmd, "upload", "UPLOAD_ABORT", false); /* flushed below */
    }
    mfns_uart_t *u = out_link(up, src);
    for (int i = 0; u != NULL && i < FLUSH_TRIES && tlm_txq_frames(&up->q) > 0u; i++) {
        (void)txq_drain(&up->q, u, mfns_uart_now_ms());
        if (tlm_txq_frames(&up->q) > 0u) {
            (void)usleep(10000);
        }
    }
    if (tlm_txq_frames(&up->q) > 0u) {
        fprintf(stderr, "mfns-ground: %zu commands never went up (link not there)\n", tlm_txq_frames(&up->q));
        up->n_errors++;
    }
    if (!uplink_auth_ready(&up->auth) && (up->next_cli < up->o.n_cli || up->cmd_fd >= 0)) {
        fprintf(stderr, "mfns-ground: commands not sent: no authenticated uplink report from the board arrived "
                        "(%u housekeeping reports ignored as unauthenticated; give --tc-epoch N to sign for a "
                        "known epoch)\n", up->auth.n_reports_ignored);
        up->n_errors++;
    }
}

int uplink_open(uplink_t *up, const uplink_opts_t *o)
{
    memset(up, 0, sizeof *up);
    up->o = *o;
    up->next_seq = o->seq_start;
    up->cmd_fd = -1;
    up->fwd.fd = -1;
    up->tcp.lfd = -1;
    up->tcp.cfd = -1;
    up->tcin.fd = -1;
    up->sockin.fd = -1;
    up->tc.fd = -1;
    tlm_txq_init(&up->q);
    up->hooks = (ground_hooks_t){up, hook_poll, hook_packet, hook_finish, hook_done};
    char err[384];
    if (uplink_auth_open(&up->auth, o->tc_key, o->tc_epoch, o->tc_state, err, sizeof err) != 0) {
        fprintf(stderr, "mfns-ground: --tc-key %s\n", err);
        return -1;
    }
    /* --tc-count-start: never below a persisted count (with --tc-state) */
    if (o->tc_count_start != 0u && (o->tc_state == NULL || o->tc_count_start > up->auth.next_count)) {
        up->auth.next_count = o->tc_count_start;
    }
    if (o->out == UPLINK_OUT_TTY || o->out == UPLINK_OUT_FILE) {
        int rc;
        if (o->out == UPLINK_OUT_FILE) {
            const int fd = open(o->out_path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
            rc = fd < 0 ? MFNS_UART_ERR_OPEN : mfns_uart_attach_fd(&up->tc, fd, true, MFNS_UART_WRITE);
        } else {
            rc = mfns_uart_open_path(&up->tc, o->out_path, o->baud, MFNS_UART_WRITE);
            if (rc == MFNS_UART_ERR_OPEN) {
                rc = MFNS_UART_OK; /* a FIFO without its reader yet: re-opened at the retry cadence */
            }
        }
        if (rc != MFNS_UART_OK) {
            fprintf(stderr, "mfns-ground: command output %s: %s\n", o->out_path, mfns_uart_strerror(rc));
            return -1;
        }
    }
    if (o->upload != NULL &&
        ground_upload_open(&up->upl, o->upload, up->upl_buf, sizeof up->upl_buf, err, sizeof err) != 0) {
        fprintf(stderr, "mfns-ground: --upload %s\n", err);
        mfns_uart_close(&up->tc);
        return -1;
    }
    if (o->cmd_file != NULL) {
        up->cmd_fd = strcmp(o->cmd_file, "-") == 0 ? STDIN_FILENO : open(o->cmd_file, O_RDONLY | O_CLOEXEC);
        if (up->cmd_fd < 0) {
            fprintf(stderr, "mfns-ground: command file %s: %s\n", o->cmd_file, strerror(errno));
            mfns_uart_close(&up->tc);
            return -1;
        }
        const int fl = fcntl(up->cmd_fd, F_GETFL);
        if (fl >= 0) {
            (void)fcntl(up->cmd_fd, F_SETFL, fl | O_NONBLOCK); /* stdin: read what is there, never wait */
        }
    }
    if (o->udp_forward != NULL && udp_forward_open(&up->fwd, o->udp_forward, o->udp_allow_remote, err, sizeof err)) {
        fprintf(stderr, "mfns-ground: --udp-forward: %s\n", err);
        (void)uplink_close(up);
        return -1;
    }
    if (o->tcp_forward != NULL && tcp_forward_open(&up->tcp, o->tcp_forward, o->udp_allow_remote, err, sizeof err)) {
        fprintf(stderr, "mfns-ground: --tcp-forward: %s\n", err);
        (void)uplink_close(up);
        return -1;
    }
    if (o->udp_tc != NULL && udp_tc_open(&up->tcin, o->udp_tc, o->udp_allow_remote, err, sizeof err) != 0) {
        fprintf(stderr, "mfns-ground: --udp-tc: %s\n", err);
        (void)uplink_close(up);
        return -1;
    }
    if (o->tc_socket != NULL && udp_tc_open_unix(&up->sockin, o->tc_socket, err, sizeof err) != 0) {
        fprintf(stderr, "mfns-ground: --tc-socket: %s\n", err);
        (void)uplink_close(up);
        return -1;
    }
    return 0;
}

/* The upload's outcome, one line on stdout (a refusal also on stderr): true when it failed. */
static bool report_upload(const ground_upload_t *g)
{
    const double secs = g->t_done_ms > g->t_start_ms ? (double)(g->t_done_ms - g->t_start_ms) / 1000.0 : 0.0;
    const double rate = secs > 0.0 ? (double)g->size / secs : 0.0;
    if (g->phase == UPLOAD_OK) {
        printf("mfns-ground: upload %s: %u bytes (crc %08x) in %.2f s (%.0f B/s; %u segments, %u re-sent, %u gaps, "
               "%u restarts): stored and loaded, table crc %08x\n",
               g->name, g->size, g->crc32, secs, rate, g->n_data, g->n_resent, g->n_gaps, g->n_restarts, g->table_crc);
        return false;
    }
    char why[256];
    if (g->phase == UPLOAD_FAILED && g->reject != 0) {
        (void)snprintf(why, sizeof why, "refused: %s (%s)", tc_status_name(g->reject), tc_strerror(g->reject));
    } else if (g->aborted) {
        (void)snprintf(why, sizeof why, "interrupted at offset %u of %u: UPLOAD_ABORT sent (nothing stored)", g->acked,
                       g->size);
    } else if (g->phase == UPLOAD_FAILED) {
        (void)snprintf(why, sizeof why, "no answer from the board (%u tries of %u ms)", UPLOAD_TRIES, UPLOAD_ANSWER_MS);
    } else {
        (void)snprintf(why, sizeof why, "not finished (the run ended at offset %u of %u)", g->acked, g->size);
    }
    printf("mfns-ground: upload %s: %u bytes (crc %08x): %s\n", g->name, g->size, g->crc32, why);
    fprintf(stderr, "mfns-ground: upload %s %s\n", g->name, why);
    return true;
}

int uplink_close(uplink_t *up)
{
    if (up->cmd_fd >= 0 && up->cmd_fd != STDIN_FILENO) {
        (void)close(up->cmd_fd);
    }
    up->cmd_fd = -1;
    mfns_uart_close(&up->tc);
    if (up->log != NULL && fclose(up->log) != 0) {
        up->n_errors++;
    }
    up->log = NULL;
    const bool tcp_on = up->tcp.lfd >= 0;
    const uint32_t tcp_left = tcp_forward_close(&up->tcp, TCP_CLOSE_MS); /* what the receiver still takes */
    /* the counters; under -q only when something failed */
    if ((!up->o.quiet && (up->n_sent > 0u || up->fwd.fd >= 0 || tcp_on || up->tcin.fd >= 0 || up->sockin.fd >= 0)) ||
        up->n_errors > 0u || up->fwd.errors > 0u || up->tcp.dropped > 0u || tcp_left > 0u) {
        fprintf(stderr, "mfns-ground: uplink: %u commands sent, %u errors", up->n_sent, up->n_errors);
        if (up->fwd.fd >= 0) {
            /* UDP confirms nothing: what the receiver dropped is only seen there
             * (pace a recording with --pace so its socket buffer keeps up) */
            fprintf(stderr,
                    "; UDP forward: %u packets sent, %u refused by the socket (UDP confirms no delivery: "
                    "count at the receiver)",
                    up->fwd.sent, up->fwd.errors);
        }
        if (tcp_on) {
            fprintf(stderr, "; TCP forward: %u packets sent, %u dropped, %u never taken (%u clients)", up->tcp.sent,
                    up->tcp.dropped, tcp_left, up->tcp.clients);
        }
        if (up->tcin.fd >= 0) {
            fprintf(stderr, "; UDP commands: %u received, %u refused", up->tcin.received, up->tcin.refused);
        }
        if (up->sockin.fd >= 0) {
            fprintf(stderr, "; socket commands: %u received, %u refused", up->sockin.received, up->sockin.refused);
        }
        if (up->auth.on) {
            fprintf(stderr, "; signed for epoch %u up to count %u (%u re-synchronisations, %u uplink reports verified, "
                            "%u ignored)", up->auth.epoch, up->auth.next_count - 1u, up->auth.n_resync,
                    up->auth.n_reports_ok, up->auth.n_reports_ignored);
        }
        fputc('\n', stderr);
    }
    udp_forward_close(&up->fwd);
    udp_tc_close(&up->tcin);
    udp_tc_close_unix(&up->sockin, up->o.tc_socket);
    uplink_auth_close(&up->auth);
    const bool upload_failed = up->o.upload != NULL && report_upload(&up->upl);
    return up->n_errors > 0u || upload_failed ? 1 : 0;
}
