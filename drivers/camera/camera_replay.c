/* camera_replay.c -- replays one camera ('x', 'y' or 'z') of a frame folder
 * written by `mfns sim nav` (docs/nav-frames.md, version 1): frames.csv rows
 * `frame,t_s,camera,file,exposure_us,gain_db`, binary P5 PGM with maxval 255
 * (GREY) or 1023/4095/65535 (Y10/Y12/Y16, big-endian samples converted to
 * native 16-bit words). Paced to the recorded timestamps or as fast as asked.
 *
 * Everything is allocated at open (frame buffers); dequeue reads with plain
 * read(2) into them, so replay, like a real camera, never allocates while
 * streaming. Malformed input is refused with the file and line in the
 * message, never delivered as a frame. */
#ifndef _DEFAULT_SOURCE
#define _DEFAULT_SOURCE 1
#endif
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "camera_backend.h"

#define CSV_HEADER "frame,t_s,camera,file,exposure_us,gain_db"
#define KNOWN_VERSION 1
#define MAX_SKIP_ROWS (1u << 20) /* rows of other cameras skipped in one search */
#define MAX_READ_TRIES 1024      /* EINTR retries plus short reads for one read */
#define SCENARIO_MAX 16384       /* scenario.json bytes inspected */
#define PGM_HDR_MAX 64

/* ---- small I/O helpers --------------------------------------------------- */
/* Reads up to n bytes; returns bytes read (< n only at end of file) or -1. */
static ssize_t read_full(int fd, void *buf, size_t n)
{
    size_t got = 0;
    for (int tries = 0; got < n && tries < MAX_READ_TRIES; tries++) {
        const ssize_t r = read(fd, (char *)buf + got, n - got);
        if (r < 0) {
            if (errno == EINTR) {
                continue;
            }
            return -1;
        }
        if (r == 0) {
            break;
        }
        got += (size_t)r;
    }
    return (ssize_t)got;
}

static void join_path(const mfns_cam_t *h, const char *name, char *out, size_t n)
{
    (void)snprintf(out, n, "%s/%s", h->path, name);
}

/* Reads one '\n'-terminated line of frames.csv (without "\n" or "\r\n").
 * 1 = line, 0 = end of file, -1 = error (message set). */
static int read_line(mfns_cam_t *h, char *line, size_t n)
{
    mfns_cam_replay_t *r = &h->b.replay;
    size_t len = 0;
    for (size_t guard = 0; guard < MFNS_CAM_LINE_LEN + 2u * MFNS_CAM_RBUF_LEN; guard++) {
        if (r->rpos == r->rlen) {
            if (r->csv_eof) {
                break;
            }
            const ssize_t got = read_full(r->csv_fd, r->rbuf, sizeof r->rbuf);
            if (got < 0) {
                (void)mfns_cam_fail(h, MFNS_CAM_E_DATA, "frames.csv: read failed: %s", strerror(errno));
                return -1;
            }
            r->rpos = 0;
            r->rlen = (size_t)got;
            if (got < (ssize_t)sizeof r->rbuf) {
                r->csv_eof = true;
            }
            if (got == 0) {
                break;
            }
        }
        const char c = r->rbuf[r->rpos++];
        if (c == '\n') {
            r->line_no++;
            if (len > 0 && line[len - 1] == '\r') {
                len--;
            }
            line[len] = '\0';
            return 1;
        }
        if (len + 1 >= n) {
            (void)mfns_cam_fail(h, MFNS_CAM_E_DATA, "frames.csv line %u: longer than %zu characters", r->line_no + 1u,
                          n - 1);
            return -1;
        }
        line[len++] = c;
    }
    if (len > 0) { /* last line without a newline */
        r->line_no++;
        line[len] = '\0';
        return 1;
    }
    return 0;
}

static bool parse_u32(const char *s, uint32_t *out)
{
    if (*s < '0' || *s > '9') {
        return false;
    }
    char *end;
    errno = 0;
    const unsigned long v = strtoul(s, &end, 10);
    if (errno != 0 || *end != '\0' || v > UINT32_MAX) {
        return false;
    }
    *out = (uint32_t)v;
    return true;
}

static bool parse_real(const char *s, double *out)
{
    if (*s == '\0') {
        return false;
    }
    char *end;
    errno = 0;
    const double v = strtod(s, &end);
    if (errno != 0 || *end != '\0' || !isfinite(v)) {
        return false;
    }
    *out = v;
    return true;
}

/* Splits line in place at commas into exactly n fields. */
static bool split_fields(char *line, char **fields, int n)
{
    int k = 0;
    fields[k++] = line;
    for (char *p = line; *p; p++) {
        if (*p == ',') {
            if (k == n) {
                return false;
            }
            *p = '\0';
            fields[k++] = p + 1;
        }
    }
    return k == n;
}

static bool safe_relative(const char *f)
{
    if (f[0] == '\0' || f[0] == '/') {
        return false;
    }
    for (const char *p = f; *p; p++) {
        if (p[0] == '.' && p[1] == '.' && (p == f || p[-1] == '/') && (p[2] == '/' || p[2] == '\0')) {
            return false;
        }
    }
    return true;
}

/* Next row of this camera into r->row. OK, E_END or E_DATA. */
static mfns_cam_err_t next_row(mfns_cam_t *h)
{
    mfns_cam_replay_t *r = &h->b.replay;
    char line[MFNS_CAM_LINE_LEN];
    for (uint32_t skipped = 0; skipped < MAX_SKIP_ROWS; skipped++) {
        const int got = read_line(h, line, sizeof line);
        if (got < 0) {
            return MFNS_CAM_E_DATA;
        }
        if (got == 0) {
            return MFNS_CAM_E_END;
        }
        const uint32_t ln = r->line_no;
        char *fld[6];
        if (!split_fields(line, fld, 6)) {
            return mfns_cam_fail(h, MFNS_CAM_E_DATA, "frames.csv line %u: expected 6 comma-separated fields", ln);
        }
        uint32_t frame;
        double t_s, exposure, gain;
        if (!parse_u32(fld[0], &frame)) {
            return mfns_cam_fail(h, MFNS_CAM_E_DATA, "frames.csv line %u: frame '%.20s' is not an index", ln, fld[0]);
        }
        if (!parse_real(fld[1], &t_s) || t_s < 0.0 || t_s > 1e9) {
            return mfns_cam_fail(h, MFNS_CAM_E_DATA, "frames.csv line %u: t_s '%.20s' is not a time in seconds", ln,
                                 fld[1]);
        }
        if (!((fld[2][0] == 'x' || fld[2][0] == 'y' || fld[2][0] == 'z') && fld[2][1] == '\0')) {
            return mfns_cam_fail(h, MFNS_CAM_E_DATA, "frames.csv line %u: camera '%.20s' is not x, y or z", ln,
                                 fld[2]);
        }
        if (!safe_relative(fld[3]) || strlen(fld[3]) + strlen(h->path) + 2u > MFNS_CAM_PATH_LEN) {
            return mfns_cam_fail(h, MFNS_CAM_E_DATA, "frames.csv line %u: file '%.40s' is not a relative path inside "
                                 "the folder", ln, fld[3]);
        }
        if (!parse_real(fld[4], &exposure) || exposure < 0.0 || exposure > 2147483647.0) {
            return mfns_cam_fail(h, MFNS_CAM_E_DATA, "frames.csv line %u: exposure_us '%.20s' is not a duration", ln,
                                 fld[4]);
        }
        if (!parse_real(fld[5], &gain)) {
            return mfns_cam_fail(h, MFNS_CAM_E_DATA, "frames.csv line %u: gain_db '%.20s' is not a number", ln,
                                 fld[5]);
        }
        if (fld[2][0] != h->s.replay_camera) {
            continue;
        }
        if (r->have_prev && (frame <= r->prev_frame || t_s < r->prev_t)) {
            return mfns_cam_fail(h, MFNS_CAM_E_DATA,
                                 "frames.csv line %u: camera %c frame %u at %.6f s does not follow frame %u at %.6f s",
                                 ln, h->s.replay_camera, frame, t_s, r->prev_frame, r->prev_t);
        }
        r->have_prev = true;
        r->prev_frame = frame;
        r->prev_t = t_s;
        r->row.frame = frame;
        r->row.t_s = t_s;
        r->row.exposure_us = (int32_t)lround(exposure);
        (void)snprintf(r->row.file, sizeof r->row.file, "%s", fld[3]);
        r->have_row = true;
        return MFNS_CAM_OK;
    }
    return mfns_cam_fail(h, MFNS_CAM_E_DATA, "frames.csv: no row for camera %c in %u rows", h->s.replay_camera,
                         MAX_SKIP_ROWS);
}

/* ---- PGM ------------------------------------------------------------------ */
typedef struct {
    uint32_t w, h, maxval;
    size_t data_off;
} pgm_hdr_t;

static bool pgm_ws(char c)
{
    return c == ' ' || c == '\n' || c == '\t' || c == '\r';
}

/* Skips whitespace before a header field; a '#' there starts a comment,
 * which docs/nav-frames.md rules out. */
static bool skip_ws(const char *buf, size_t n, size_t *p, bool *comment)
{
    while (*p < n && pgm_ws(buf[*p])) {
        (*p)++;
    }
    if (*p < n && buf[*p] == '#') {
        *comment = true;
        return false;
    }
    return true;
}

/* One decimal field followed by whitespace; advances *p. */
static bool pgm_num(const char *buf, size_t n, size_t *p, uint32_t *out)
{
    uint32_t v = 0;
    size_t digits = 0;
    while (*p < n && buf[*p] >= '0' && buf[*p] <= '9' && digits < 6) {
        v = v * 10u + (uint32_t)(buf[*p] - '0');
        (*p)++;
        digits++;
    }
    if (digits == 0 || *p >= n || !pgm_ws(buf[*p])) {
        return false;
    }
    *out = v;
    return true;
}

static mfns_cam_err_t pgm_header(mfns_cam_t *h, int fd, const char *file, pgm_hdr_t *hd)
{
    memset(hd, 0, sizeof *hd);
    char buf[PGM_HDR_MAX];
    const ssize_t got = read_full(fd, buf, sizeof buf);
    if (got < 0) {
        return mfns_cam_fail(h, MFNS_CAM_E_DATA, "%.60s: read failed: %s", file, strerror(errno));
    }
    const size_t n = (size_t)got;
    if (n < 3 || buf[0] != 'P' || buf[1] != '5' || !pgm_ws(buf[2])) {
        return mfns_cam_fail(h, MFNS_CAM_E_DATA, "%.60s: not a binary PGM (magic P5 missing)", file);
    }
    /* Only the header is scanned: pixel bytes may be anything, '#' included. */
    size_t p = 3;
    bool comment = false;
    bool ok = skip_ws(buf, n, &p, &comment) && pgm_num(buf, n, &p, &hd->w);
    ok = ok && skip_ws(buf, n, &p, &comment) && pgm_num(buf, n, &p, &hd->h);
    ok = ok && skip_ws(buf, n, &p, &comment) && pgm_num(buf, n, &p, &hd->maxval);
    if (comment) {
        return mfns_cam_fail(h, MFNS_CAM_E_DATA, "%.60s: PGM header comments are not allowed (docs/nav-frames.md)",
                             file);
    }
    if (!ok) {
        return mfns_cam_fail(h, MFNS_CAM_E_DATA, "%.60s: malformed PGM header (want \"P5\\n<W> <H>\\n<maxval>\\n\")",
                             file);
    }
    hd->data_off = p + 1; /* exactly one whitespace byte after maxval */
    if (hd->w == 0 || hd->h == 0 || hd->w > MFNS_CAM_MAX_DIM || hd->h > MFNS_CAM_MAX_DIM) {
        return mfns_cam_fail(h, MFNS_CAM_E_DATA, "%.60s: size %ux%u outside 1..%u", file, hd->w, hd->h,
                             MFNS_CAM_MAX_DIM);
    }
    if (hd->maxval != 255 && hd->maxval != 1023 && hd->maxval != 4095 && hd->maxval != 65535) {
        return mfns_cam_fail(h, MFNS_CAM_E_DATA, "%.60s: maxval %u is not 255, 1023, 4095 or 65535", file,
                             hd->maxval);
    }
    return MFNS_CAM_OK;
}

static mfns_cam_pixfmt_t pixfmt_of_maxval(uint32_t maxval)
{
    switch (maxval) {
    case 255: return MFNS_CAM_PIX_GREY;
    case 1023: return MFNS_CAM_PIX_Y10;
    case 4095: return MFNS_CAM_PIX_Y12;
    default: return MFNS_CAM_PIX_Y16;
    }
}

/* Reads the frame's header (and, with dst, its pixels converted to native
 * words) after checking it against the geometry fixed at open. */
static mfns_cam_err_t pgm_load(mfns_cam_t *h, const char *file, uint8_t *dst, pgm_hdr_t *hd)
{
    mfns_cam_replay_t *r = &h->b.replay;
    char full[2u * MFNS_CAM_PATH_LEN];
    join_path(h, file, full, sizeof full);
    const int fd = open(full, O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
        return mfns_cam_fail(h, MFNS_CAM_E_DATA, "%.60s: cannot open: %s", file, strerror(errno));
    }
    mfns_cam_err_t e = pgm_header(h, fd, file, hd);
    if (e == MFNS_CAM_OK && dst) {
        if (hd->w != h->info.width || hd->h != h->info.height || hd->maxval != r->maxval) {
            e = mfns_cam_fail(h, MFNS_CAM_E_DATA, "%.60s: %ux%u maxval %u differs from the first frame's %ux%u maxval %u",
                              file, hd->w, hd->h, hd->maxval, h->info.width, h->info.height, r->maxval);
        } else if (lseek(fd, (off_t)hd->data_off, SEEK_SET) < 0) {
            e = mfns_cam_fail(h, MFNS_CAM_E_DATA, "%.60s: seek failed: %s", file, strerror(errno));
        } else {
            const ssize_t got = read_full(fd, dst, r->frame_bytes);
            uint8_t extra;
            if (got < 0) {
                e = mfns_cam_fail(h, MFNS_CAM_E_DATA, "%.60s: read failed: %s", file, strerror(errno));
            } else if ((size_t)got != r->frame_bytes) {
                e = mfns_cam_fail(h, MFNS_CAM_E_DATA, "%.60s: truncated: %zd of %zu pixel bytes", file, got,
                                  r->frame_bytes);
            } else if (read_full(fd, &extra, 1) != 0) {
                e = mfns_cam_fail(h, MFNS_CAM_E_DATA, "%.60s: bytes after the pixel data", file);
            }
        }
        if (e == MFNS_CAM_OK && r->maxval > 255u) {
            /* big-endian PGM samples -> native 16-bit words, in place */
            const size_t n = r->frame_bytes / 2u;
            for (size_t i = 0; i < n; i++) {
                const uint16_t v = (uint16_t)(((uint16_t)dst[2 * i] << 8) | dst[2 * i + 1]);
                if (v > r->maxval) {
                    e = mfns_cam_fail(h, MFNS_CAM_E_DATA, "%.60s: sample %zu is %u, above maxval %u", file, i,
                                      (unsigned)v, r->maxval);
                    break;
                }
                memcpy(dst + 2 * i, &v, sizeof v);
            }
        }
    }
    (void)close(fd);
    return e;
}

/* ---- scenario.json (only format and version are checked) ----------------- */
static const char *json_value(const char *json, const char *key)
{
    const char *p = strstr(json, key);
    if (!p) {
        return NULL;
    }
    p += strlen(key);
    while (*p == ' ' || *p == '\t' || *p == '\n' || *p == '\r') {
        p++;
    }
    if (*p != ':') {
        return NULL;
    }
    p++;
    while (*p == ' ' || *p == '\t' || *p == '\n' || *p == '\r') {
        p++;
    }
    return p;
}

static mfns_cam_err_t check_scenario(mfns_cam_t *h)
{
    char full[2u * MFNS_CAM_PATH_LEN];
    join_path(h, "scenario.json", full, sizeof full);
    const int fd = open(full, O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
        return mfns_cam_fail(h, errno == ENOENT && access(h->path, F_OK) != 0 ? MFNS_CAM_E_OPEN : MFNS_CAM_E_DATA,
                             "%s: scenario.json: %s", h->path, strerror(errno));
    }
    static _Thread_local char json[SCENARIO_MAX + 1];
    const ssize_t got = read_full(fd, json, SCENARIO_MAX);
    (void)close(fd);
    if (got < 0) {
        return mfns_cam_fail(h, MFNS_CAM_E_DATA, "scenario.json: read failed: %s", strerror(errno));
    }
    json[got] = '\0';
    const char *fmt = json_value(json, "\"format\"");
    if (!fmt || strncmp(fmt, "\"mfns-nav-frames\"", 17) != 0) {
        return mfns_cam_fail(h, MFNS_CAM_E_DATA, "scenario.json: \"format\" is not \"mfns-nav-frames\"");
    }
    const char *ver = json_value(json, "\"version\"");
    char *end = NULL;
    const long v = ver ? strtol(ver, &end, 10) : -1;
    if (!ver || end == ver || v < 1) {
        return mfns_cam_fail(h, MFNS_CAM_E_DATA, "scenario.json: no integer \"version\"");
    }
    if (v > KNOWN_VERSION) {
        return mfns_cam_fail(h, MFNS_CAM_E_DATA, "scenario.json: version %ld is newer than the %d this reader knows", v,
                             KNOWN_VERSION);
    }
    return MFNS_CAM_OK;
}

/* Positions frames.csv after its header, before the first row. */
static mfns_cam_err_t rewind_csv(mfns_cam_t *h)
{
    mfns_cam_replay_t *r = &h->b.replay;
    if (lseek(r->csv_fd, 0, SEEK_SET) < 0) {
        return mfns_cam_fail(h, MFNS_CAM_E_DATA, "frames.csv: seek failed: %s", strerror(errno));
    }
    r->rpos = r->rlen = 0;
    r->csv_eof = false;
    r->line_no = 0;
    r->have_row = false;
    r->have_prev = false;
    r->end = false;
    r->t0_set = false;
    char line[MFNS_CAM_LINE_LEN];
    const int got = read_line(h, line, sizeof line);
    if (got < 0) {
        return MFNS_CAM_E_DATA;
    }
    if (got == 0 || strcmp(line, CSV_HEADER) != 0) {
        return mfns_cam_fail(h, MFNS_CAM_E_DATA, "frames.csv: header is not \"%s\"", CSV_HEADER);
    }
    return MFNS_CAM_OK;
}

/* ---- backend operations ---------------------------------------------------- */
static mfns_cam_err_t replay_open(mfns_cam_t *h)
{
    mfns_cam_replay_t *r = &h->b.replay;
    r->csv_fd = -1;
    mfns_cam_err_t e = check_scenario(h);
    if (e != MFNS_CAM_OK) {
        return e;
    }
    char full[2u * MFNS_CAM_PATH_LEN];
    join_path(h, "frames.csv", full, sizeof full);
    r->csv_fd = open(full, O_RDONLY | O_CLOEXEC);
    if (r->csv_fd < 0) {
        return mfns_cam_fail(h, MFNS_CAM_E_DATA, "%s: frames.csv: %s", h->path, strerror(errno));
    }
    e = rewind_csv(h);
    if (e != MFNS_CAM_OK) {
        return e;
    }
    e = next_row(h);
    if (e == MFNS_CAM_E_END) {
        return mfns_cam_fail(h, MFNS_CAM_E_DATA, "frames.csv: no frames for camera %c", h->s.replay_camera);
    }
    if (e != MFNS_CAM_OK) {
        return e;
    }
    pgm_hdr_t hd;
    e = pgm_load(h, r->row.file, NULL, &hd);
    if (e != MFNS_CAM_OK) {
        return e;
    }
    const mfns_cam_pixfmt_t pf = pixfmt_of_maxval(hd.maxval);
    if ((h->s.width && h->s.width != hd.w) || (h->s.height && h->s.height != hd.h) ||
        (h->s.pixfmt != MFNS_CAM_PIX_ANY && h->s.pixfmt != pf)) {
        return mfns_cam_fail(h, MFNS_CAM_E_FORMAT, "replay %s: asked %s %ux%u, recorded frames are %s %ux%u", h->path,
                             mfns_cam_pixfmt_name(h->s.pixfmt), h->s.width, h->s.height, mfns_cam_pixfmt_name(pf),
                             hd.w, hd.h);
    }
    const uint32_t bpp = mfns_cam_pixfmt_bytes(pf);
    r->maxval = hd.maxval;
    r->frame_bytes = (size_t)hd.w * hd.h * bpp;
    r->nbuf = h->s.buffer_count;
    r->mem = malloc(r->frame_bytes * r->nbuf); /* at open only: streaming never allocates */
    if (!r->mem) {
        return mfns_cam_fail(h, MFNS_CAM_E_BUFFERS, "replay: cannot allocate %u x %zu bytes", r->nbuf, r->frame_bytes);
    }
    h->info.width = hd.w;
    h->info.height = hd.h;
    h->info.stride = hd.w * bpp;
    h->info.pixfmt = pf;
    h->info.buffer_count = r->nbuf;
    h->info.multiplanar = false;
    (void)snprintf(h->info.driver, sizeof h->info.driver, "replay");
    (void)snprintf(h->info.card, sizeof h->info.card, "cam_%c", h->s.replay_camera);
    return MFNS_CAM_OK;
}

static mfns_cam_err_t replay_start(mfns_cam_t *h)
{
    memset(h->b.replay.held, 0, sizeof h->b.replay.held);
    return rewind_csv(h); /* every start replays from the first frame */
}

/* Sleeps until CLOCK_MONOTONIC reaches until_ns. */
static void sleep_until(int64_t until_ns)
{
    const struct timespec ts = {(time_t)(until_ns / 1000000000), (long)(until_ns % 1000000000)};
    for (int i = 0; i < MAX_READ_TRIES; i++) {
        if (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) != EINTR) {
            return;
        }
    }
}

static mfns_cam_err_t replay_dequeue(mfns_cam_t *h, mfns_cam_frame_t *f, int timeout_ms)
{
    mfns_cam_replay_t *r = &h->b.replay;
    if (r->end) {
        return mfns_cam_fail(h, MFNS_CAM_E_END, "replay %s camera %c: end of frames", h->path, h->s.replay_camera);
    }
    uint32_t k = 0;
    while (k < r->nbuf && r->held[k]) {
        k++;
    }
    if (k == r->nbuf) {
        return mfns_cam_fail(h, MFNS_CAM_E_BUSY, "all %u replay buffers are held by the caller", r->nbuf);
    }
    if (!r->have_row) {
        const mfns_cam_err_t e = next_row(h);
        if (e == MFNS_CAM_E_END) {
            r->end = true;
            return mfns_cam_fail(h, MFNS_CAM_E_END, "replay %s camera %c: end of frames", h->path,
                                 h->s.replay_camera);
        }
        if (e != MFNS_CAM_OK) {
            return e;
        }
    }
    if (h->s.replay_realtime) {
        const int64_t now = mfns_cam_now_ns();
        if (!r->t0_set) {
            r->t0_set = true;
            r->t0_ns = now;
            r->t_first = r->row.t_s;
        }
        const int64_t due = r->t0_ns + (int64_t)llround((r->row.t_s - r->t_first) * 1e9);
        if (due - now > (int64_t)timeout_ms * 1000000) {
            sleep_until(now + (int64_t)timeout_ms * 1000000);
            return mfns_cam_fail(h, MFNS_CAM_E_TIMEOUT, "replay: next frame due in %.3f s", (double)(due - now) * 1e-9);
        }
        sleep_until(due);
    }
    uint8_t *dst = r->mem + (size_t)k * r->frame_bytes;
    pgm_hdr_t hd;
    r->have_row = false; /* a bad frame is consumed: the caller may go on to the next */
    const mfns_cam_err_t e = pgm_load(h, r->row.file, dst, &hd);
    if (e != MFNS_CAM_OK) {
        return e;
    }
    r->held[k] = true;
    f->data = dst;
    f->bytesused = r->frame_bytes;
    f->pixfmt = h->info.pixfmt;
    f->width = h->info.width;
    f->height = h->info.height;
    f->stride = h->info.stride;
    f->timestamp_ns = (uint64_t)llround(r->row.t_s * 1e9);
    f->sequence = r->row.frame;
    f->dropped_before = mfns_cam_seq_delivered(h, r->row.frame);
    f->exposure_us = r->row.exposure_us;
    f->buf_index = k;
    return MFNS_CAM_OK;
}

static mfns_cam_err_t replay_requeue(mfns_cam_t *h, const mfns_cam_frame_t *f)
{
    mfns_cam_replay_t *r = &h->b.replay;
    if (f->buf_index >= r->nbuf || !r->held[f->buf_index]) {
        return mfns_cam_fail(h, MFNS_CAM_E_ARG, "requeue: buffer %u is not held by the caller", f->buf_index);
    }
    r->held[f->buf_index] = false;
    return MFNS_CAM_OK;
}

static mfns_cam_err_t replay_stop(mfns_cam_t *h)
{
    memset(h->b.replay.held, 0, sizeof h->b.replay.held);
    return MFNS_CAM_OK;
}

static void replay_close(mfns_cam_t *h)
{
    mfns_cam_replay_t *r = &h->b.replay;
    if (r->csv_fd >= 0) {
        (void)close(r->csv_fd);
        r->csv_fd = -1;
    }
    free(r->mem);
    r->mem = NULL;
}

static mfns_cam_err_t replay_set_controls(mfns_cam_t *h, int32_t exposure_us, int32_t gain)
{
    (void)exposure_us;
    (void)gain;
    return mfns_cam_fail(h, MFNS_CAM_E_CONTROL, "replay: exposure and gain are recorded in frames.csv, not settable");
}

const mfns_cam_backend_ops_t mfns_cam_replay_ops = {replay_open, replay_start, replay_dequeue, replay_requeue,
                                                    replay_stop, replay_close, replay_set_controls};
