/* camera_replay.c -- replays one camera ('x', 'y' or 'z') of a frame folder
 * written by `mfns sim nav` (docs/nav-frames.md, version 1): frames.csv rows
 * `frame,t_s,camera,file,exposure_us,gain_db`, binary P5 PGM with maxval 255
 * (GREY) or 1023/4095/65535 (Y10/Y12/Y16, big-endian samples converted to
 * native 16-bit words). Paced to the recorded timestamps or as fast as asked.
 *
 * frames.csv is read and validated once per folder (replay_index.h) into a
 * row table shared by every camera of that folder, so a bad row costs one
 * frame of one camera and the cameras never drift apart over it.
 *
 * Everything is allocated at open (row table, frame buffers); dequeue reads
 * with plain read(2) into them, so replay, like a real camera, never
 * allocates while streaming. Frame files are opened non-blocking and read
 * against the dequeue deadline: a frame file that blocks (a FIFO with a slow
 * or absent writer) costs at most the timeout. Malformed input is refused
 * with the file and line in the message, never delivered as a frame. */
#ifndef _DEFAULT_SOURCE
#define _DEFAULT_SOURCE 1
#endif
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <poll.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "drivers/camera/camera_backend.h"
#include "drivers/camera/replay_index.h"
#include "drivers/camera/replay_pgm.h"
#include "drivers/camera/replay_scenario.h"

#define MAX_READ_TRIES 1024 /* EINTR retries and waits for one read */
#define READ_TIMED_OUT (-2)

/* One parsed frames.csv, shared by the handles replaying the same folder. */
struct mfns_replay_folder {
    char path[MFNS_CAM_PATH_LEN];
    char *text;
    mfns_replay_row_t *rows;
    uint32_t refs;
    uint32_t n_rows;
};

static struct mfns_replay_folder g_folders[MFNS_CAM_MAX_HANDLES];
static pthread_mutex_t g_folders_lock = PTHREAD_MUTEX_INITIALIZER;

/* ---- small I/O helpers --------------------------------------------------- */
static int64_t ms_left(int64_t deadline_ns)
{
    const int64_t left = deadline_ns - mfns_cam_now_ns();
    return left <= 0 ? 0 : (left + 999999) / 1000000;
}

/* Reads up to n bytes before deadline_ns (< 0: no deadline, regular files).
 * Returns bytes read (< n only at end of file), -1 on error (errno set) or
 * READ_TIMED_OUT. Each pass reads at least one byte or waits once. */
static ssize_t read_until(int fd, void *buf, size_t n, int64_t deadline_ns)
{
    size_t got = 0;
    for (size_t tries = 0; got < n && tries < n + MAX_READ_TRIES; tries++) {
        const ssize_t r = read(fd, (char *)buf + got, n - got);
        if (r > 0) {
            got += (size_t)r;
            continue;
        }
        if (r == 0) {
            break;
        }
        if (errno == EINTR) {
            continue;
        }
        if (errno != EAGAIN && errno != EWOULDBLOCK) {
            return -1;
        }
        const int64_t left = deadline_ns < 0 ? 0 : ms_left(deadline_ns);
        if (left == 0) {
            return READ_TIMED_OUT;
        }
        struct pollfd p = {fd, POLLIN, 0};
        const int pr = poll(&p, 1, (int)left);
        if (pr == 0) {
            return READ_TIMED_OUT;
        }
        if (pr < 0 && errno != EINTR) {
            return -1;
        }
    }
    return (ssize_t)got;
}

static void join_path(const char *dir, const char *name, char *out, size_t n)
{
    (void)snprintf(out, n, "%s/%s", dir, name);
}

/* A whole regular file of at most max bytes into a fresh buffer with one
 * spare byte (the parsers write a terminator there). NULL on failure. */
static char *slurp(mfns_cam_t *h, const char *name, size_t max, size_t *len, mfns_cam_err_t *e)
{
    char full[2u * MFNS_CAM_PATH_LEN];
    join_path(h->path, name, full, sizeof full);
    const int fd = open(full, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        *e = mfns_cam_fail(h, errno == ENOENT && access(h->path, F_OK) != 0 ? MFNS_CAM_E_OPEN : MFNS_CAM_E_DATA,
                           "%s: %s: %s", h->path, name, strerror(errno));
        return NULL;
    }
    struct stat st;
    char *buf = NULL;
    if (fstat(fd, &st) != 0) {
        *e = mfns_cam_fail(h, MFNS_CAM_E_DATA, "%s: %s", name, strerror(errno));
    } else if (!S_ISREG(st.st_mode)) {
        *e = mfns_cam_fail(h, MFNS_CAM_E_DATA, "%s: not a regular file", name);
    } else if ((uint64_t)st.st_size > max) {
        *e = mfns_cam_fail(h, MFNS_CAM_E_DATA, "%s: %lld bytes, above the %zu-byte limit", name,
                           (long long)st.st_size, max);
    } else {
        const size_t n = (size_t)st.st_size;
        buf = malloc(n + 1u); /* at open only */
        if (!buf) {
            *e = mfns_cam_fail(h, MFNS_CAM_E_BUFFERS, "%s: cannot allocate %zu bytes", name, n + 1u);
        } else {
            const ssize_t got = read_until(fd, buf, n, -1);
            if (got != (ssize_t)n) {
                *e = mfns_cam_fail(h, MFNS_CAM_E_DATA, "%s: read failed: %s", name,
                                   got < 0 ? strerror(errno) : "file changed while read");
                free(buf);
                buf = NULL;
            } else {
                buf[n] = '\0';
                *len = n;
            }
        }
    }
    (void)close(fd);
    return buf;
}

/* ---- the shared folder table ----------------------------------------------- */
static void folder_free(struct mfns_replay_folder *f)
{
    free(f->text);
    free(f->rows);
    memset(f, 0, sizeof *f);
}

static mfns_cam_err_t folder_load(mfns_cam_t *h, struct mfns_replay_folder *f)
{
    size_t len = 0;
    mfns_cam_err_t e = MFNS_CAM_OK;
    f->text = slurp(h, "frames.csv", MFNS_REPLAY_CSV_MAX, &len, &e);
    if (!f->text) {
        return e;
    }
    const uint32_t cap = mfns_replay_count_rows(f->text, len);
    if (cap > MFNS_REPLAY_MAX_ROWS + 1u) {
        return mfns_cam_fail(h, MFNS_CAM_E_DATA, "frames.csv: more than %u rows", MFNS_REPLAY_MAX_ROWS);
    }
    f->rows = calloc(cap, sizeof *f->rows);
    if (!f->rows) {
        return mfns_cam_fail(h, MFNS_CAM_E_BUFFERS, "frames.csv: cannot allocate %u rows", cap);
    }
    char why[MFNS_CAM_MSG_LEN];
    const size_t max_file = MFNS_CAM_PATH_LEN - 2u - strlen(h->path);
    if (!mfns_replay_index_parse(f->text, len, max_file, f->rows, cap, &f->n_rows, why, sizeof why)) {
        return mfns_cam_fail(h, MFNS_CAM_E_DATA, "%s", why);
    }
    return MFNS_CAM_OK;
}

/* The folder's table, parsed by the first handle that opens it. */
static mfns_cam_err_t folder_get(mfns_cam_t *h)
{
    mfns_cam_err_t e = MFNS_CAM_OK;
    (void)pthread_mutex_lock(&g_folders_lock);
    struct mfns_replay_folder *f = NULL, *free_slot = NULL;
    for (unsigned i = 0; i < MFNS_CAM_MAX_HANDLES; i++) {
        if (g_folders[i].refs > 0 && strcmp(g_folders[i].path, h->path) == 0) {
            f = &g_folders[i];
            break;
        }
        if (g_folders[i].refs == 0 && !free_slot) {
            free_slot = &g_folders[i];
        }
    }
    if (!f && free_slot) { /* always found: at most one folder per handle */
        f = free_slot;
        e = folder_load(h, f);
        if (e != MFNS_CAM_OK) {
            folder_free(f);
            f = NULL;
        } else {
            (void)snprintf(f->path, sizeof f->path, "%s", h->path);
        }
    }
    if (f) {
        f->refs++;
        h->b.replay.folder = f;
    } else if (e == MFNS_CAM_OK) {
        e = mfns_cam_fail(h, MFNS_CAM_E_NO_SLOT, "replay: no free folder slot");
    }
    (void)pthread_mutex_unlock(&g_folders_lock);
    return e;
}

static void folder_put(mfns_cam_t *h)
{
    struct mfns_replay_folder *f = h->b.replay.folder;
    if (!f) {
        return;
    }
    (void)pthread_mutex_lock(&g_folders_lock);
    if (--f->refs == 0) {
        folder_free(f);
    }
    (void)pthread_mutex_unlock(&g_folders_lock);
    h->b.replay.folder = NULL;
}

/* Next row of this camera (good or bad) at or after the cursor: OK with
 * r->row set, or E_END. */
static mfns_cam_err_t next_row(mfns_cam_t *h)
{
    mfns_cam_replay_t *r = &h->b.replay;
    const struct mfns_replay_folder *f = r->folder;
    for (; r->cursor < f->n_rows; r->cursor++) {
        if (f->rows[r->cursor].camera == h->s.replay_camera) {
            r->row = r->cursor++;
            r->have_row = true;
            return MFNS_CAM_OK;
        }
    }
    return MFNS_CAM_E_END;
}

/* ---- PGM ------------------------------------------------------------------ */
static mfns_cam_pixfmt_t pixfmt_of_maxval(uint32_t maxval)
{
    switch (maxval) {
    case 255: return MFNS_CAM_PIX_GREY;
    case 1023: return MFNS_CAM_PIX_Y10;
    case 4095: return MFNS_CAM_PIX_Y12;
    default: return MFNS_CAM_PIX_Y16;
    }
}

/* Reads a frame file: its header, and with dst its pixels converted to
 * native words after checking it against the geometry fixed at open. The
 * file is opened non-blocking and read against deadline_ns (< 0: none). */
static mfns_cam_err_t pgm_load(mfns_cam_t *h, const char *file, uint8_t *dst, mfns_pgm_header_t *hd,
                               int64_t deadline_ns)
{
    mfns_cam_replay_t *r = &h->b.replay;
    memset(hd, 0, sizeof *hd);
    char full[2u * MFNS_CAM_PATH_LEN];
    join_path(h->path, file, full, sizeof full);
    const int fd = open(full, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        return mfns_cam_fail(h, MFNS_CAM_E_DATA, "%.60s: cannot open: %s", file, strerror(errno));
    }
    uint8_t head[MFNS_PGM_HDR_MAX];
    mfns_cam_err_t e = MFNS_CAM_OK;
    char why[MFNS_CAM_MSG_LEN];
    /* Frames are far longer than the header: a short read here is a short file. */
    const ssize_t got = read_until(fd, head, sizeof head, deadline_ns);
    if (got == READ_TIMED_OUT) {
        e = mfns_cam_fail(h, MFNS_CAM_E_TIMEOUT, "%.60s: no data within the timeout", file);
    } else if (got < 0) {
        e = mfns_cam_fail(h, MFNS_CAM_E_DATA, "%.60s: read failed: %s", file, strerror(errno));
    } else if (!mfns_pgm_parse_header(head, (size_t)got, MFNS_CAM_MAX_DIM, hd, why, sizeof why)) {
        e = mfns_cam_fail(h, MFNS_CAM_E_DATA, "%.60s: %s", file, why);
    }
    if (e == MFNS_CAM_OK && dst) {
        const size_t have = (size_t)got > hd->data_off ? (size_t)got - hd->data_off : 0u;
        if (hd->width != h->info.width || hd->height != h->info.height || hd->maxval != r->maxval) {
            e = mfns_cam_fail(h, MFNS_CAM_E_DATA, "%.60s: %ux%u maxval %u differs from the first frame's %ux%u maxval %u",
                              file, hd->width, hd->height, hd->maxval, h->info.width, h->info.height, r->maxval);
        } else if (have > r->frame_bytes) {
            e = mfns_cam_fail(h, MFNS_CAM_E_DATA, "%.60s: bytes after the pixel data", file);
        } else {
            /* the pixel bytes read with the header, then the rest: no seek, so FIFOs work */
            memcpy(dst, head + hd->data_off, have);
            const ssize_t rest = read_until(fd, dst + have, r->frame_bytes - have, deadline_ns);
            uint8_t extra;
            if (rest == READ_TIMED_OUT) {
                e = mfns_cam_fail(h, MFNS_CAM_E_TIMEOUT, "%.60s: frame incomplete within the timeout", file);
            } else if (rest < 0) {
                e = mfns_cam_fail(h, MFNS_CAM_E_DATA, "%.60s: read failed: %s", file, strerror(errno));
            } else if (have + (size_t)rest != r->frame_bytes) {
                e = mfns_cam_fail(h, MFNS_CAM_E_DATA, "%.60s: truncated: %zu of %zu pixel bytes", file,
                                  have + (size_t)rest, r->frame_bytes);
            } else if (read_until(fd, &extra, 1, deadline_ns) > 0) {
                e = mfns_cam_fail(h, MFNS_CAM_E_DATA, "%.60s: bytes after the pixel data", file);
            }
        }
        size_t bad = 0;
        if (e == MFNS_CAM_OK && r->maxval > 255u && !mfns_pgm_to_native(dst, r->frame_bytes, r->maxval, &bad)) {
            uint16_t v;
            memcpy(&v, dst + 2 * bad, sizeof v);
            v = (uint16_t)((v >> 8) | (v << 8)); /* still big-endian there */
            e = mfns_cam_fail(h, MFNS_CAM_E_DATA, "%.60s: sample %zu is %u, above maxval %u", file, bad,
                              (unsigned)v, r->maxval);
        }
    }
    (void)close(fd);
    return e;
}

/* ---- scenario.json ------------------------------------------------------- */
static mfns_cam_err_t check_scenario(mfns_cam_t *h)
{
    size_t len = 0;
    mfns_cam_err_t e = MFNS_CAM_OK;
    char *json = slurp(h, "scenario.json", MFNS_REPLAY_SCENARIO_MAX, &len, &e);
    if (!json) {
        return e;
    }
    char why[MFNS_CAM_MSG_LEN];
    if (!mfns_replay_scenario_check(json, len, why, sizeof why)) {
        e = mfns_cam_fail(h, MFNS_CAM_E_DATA, "%s", why);
    }
    free(json);
    return e;
}

/* First good row of this camera; the message names the first bad row seen
 * (this camera's or one nobody can claim) when there is none. */
static mfns_cam_err_t first_good_row(mfns_cam_t *h)
{
    mfns_cam_replay_t *r = &h->b.replay;
    const struct mfns_replay_folder *f = r->folder;
    const mfns_replay_row_t *first_bad = NULL;
    for (uint32_t i = 0; i < f->n_rows; i++) {
        const mfns_replay_row_t *row = &f->rows[i];
        if (row->camera == h->s.replay_camera && row->status == MFNS_ROW_OK) {
            r->row = i;
            return MFNS_CAM_OK;
        }
        if (!first_bad && row->status != MFNS_ROW_OK && (row->camera == h->s.replay_camera || row->camera == '\0')) {
            first_bad = row;
        }
    }
    if (!first_bad) {
        return mfns_cam_fail(h, MFNS_CAM_E_DATA, "frames.csv: no frames for camera %c", h->s.replay_camera);
    }
    char why[MFNS_CAM_MSG_LEN];
    mfns_replay_row_message(first_bad, why, sizeof why);
    return mfns_cam_fail(h, MFNS_CAM_E_DATA, "no frames for camera %c; %s", h->s.replay_camera, why);
}

/* ---- backend operations ---------------------------------------------------- */
static mfns_cam_err_t replay_open(mfns_cam_t *h)
{
    mfns_cam_replay_t *r = &h->b.replay;
    mfns_cam_err_t e = check_scenario(h);
    if (e == MFNS_CAM_OK) {
        e = folder_get(h);
    }
    if (e == MFNS_CAM_OK) {
        e = first_good_row(h);
    }
    if (e != MFNS_CAM_OK) {
        return e;
    }
    mfns_pgm_header_t hd;
    e = pgm_load(h, r->folder->rows[r->row].file, NULL, &hd, mfns_cam_now_ns() + 1000000000);
    if (e != MFNS_CAM_OK) {
        return e;
    }
    const mfns_cam_pixfmt_t pf = pixfmt_of_maxval(hd.maxval);
    if ((h->s.width && h->s.width != hd.width) || (h->s.height && h->s.height != hd.height) ||
        (h->s.pixfmt != MFNS_CAM_PIX_ANY && h->s.pixfmt != pf)) {
        return mfns_cam_fail(h, MFNS_CAM_E_FORMAT, "replay %s: asked %s %ux%u, recorded frames are %s %ux%u", h->path,
                             mfns_cam_pixfmt_name(h->s.pixfmt), h->s.width, h->s.height, mfns_cam_pixfmt_name(pf),
                             hd.width, hd.height);
    }
    const uint32_t bpp = mfns_cam_pixfmt_bytes(pf);
    r->maxval = hd.maxval;
    r->frame_bytes = mfns_pgm_pixel_bytes(&hd);
    r->nbuf = h->s.buffer_count;
    r->mem = malloc(r->frame_bytes * r->nbuf); /* at open only: streaming never allocates */
    if (!r->mem) {
        return mfns_cam_fail(h, MFNS_CAM_E_BUFFERS, "replay: cannot allocate %u x %zu bytes", r->nbuf, r->frame_bytes);
    }
    h->info.width = hd.width;
    h->info.height = hd.height;
    h->info.stride = hd.width * bpp;
    h->info.pixfmt = pf;
    h->info.buffer_count = r->nbuf;
    h->info.multiplanar = false;
    (void)snprintf(h->info.driver, sizeof h->info.driver, "replay");
    (void)snprintf(h->info.card, sizeof h->info.card, "cam_%c", h->s.replay_camera);
    return MFNS_CAM_OK;
}

static mfns_cam_err_t replay_start(mfns_cam_t *h)
{
    mfns_cam_replay_t *r = &h->b.replay;
    memset(r->held, 0, sizeof r->held);
    r->cursor = 0; /* every start replays from the first frame ... */
    r->have_row = false;
    r->end = false;
    r->t0_set = false;
    if (h->s.replay_resume) { /* ... or from after the resume time */
        const struct mfns_replay_folder *f = r->folder;
        for (; r->cursor < f->n_rows; r->cursor++) {
            const mfns_replay_row_t *row = &f->rows[r->cursor];
            if (row->status == MFNS_ROW_OK && (uint64_t)llround(row->t_s * 1e9) > h->s.replay_resume_after_ns) {
                break;
            }
        }
    }
    return MFNS_CAM_OK;
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
    const int64_t deadline = mfns_cam_now_ns() + (int64_t)timeout_ms * 1000000;
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
    if (!r->have_row && next_row(h) == MFNS_CAM_E_END) {
        r->end = true;
        return mfns_cam_fail(h, MFNS_CAM_E_END, "replay %s camera %c: end of frames", h->path, h->s.replay_camera);
    }
    const mfns_replay_row_t *row = &r->folder->rows[r->row];
    uint64_t arrival_ns = 0;
    if (row->status != MFNS_ROW_OK) {
        r->have_row = false; /* a bad row is consumed: it costs this camera this one frame */
        char why[MFNS_CAM_MSG_LEN];
        mfns_replay_row_message(row, why, sizeof why);
        h->stats.error_frames++; /* the frame-index gap shows in the next frame's dropped_before */
        return mfns_cam_fail(h, MFNS_CAM_E_DATA, "%s", why);
    }
    if (h->s.replay_realtime) {
        const int64_t now = mfns_cam_now_ns();
        if (!r->t0_set) {
            r->t0_set = true;
            r->t0_ns = now;
            r->t_first = row->t_s;
        }
        const int64_t due = r->t0_ns + (int64_t)llround((row->t_s - r->t_first) * 1e9);
        if (due > deadline) {
            sleep_until(deadline);
            return mfns_cam_fail(h, MFNS_CAM_E_TIMEOUT, "replay: next frame due in %.3f s", (double)(due - now) * 1e-9);
        }
        if (due > now) {
            sleep_until(due);
            /* it came while we waited: its arrival on the recording's time base */
            const double s = r->t_first + (double)(mfns_cam_now_ns() - r->t0_ns) * 1e-9;
            arrival_ns = s > 0.0 ? (uint64_t)llround(s * 1e9) : 0u;
        }
    }
    uint8_t *dst = r->mem + (size_t)k * r->frame_bytes;
    mfns_pgm_header_t hd;
    r->have_row = false; /* a bad frame is consumed: the caller may go on to the next */
    const mfns_cam_err_t e = pgm_load(h, row->file, dst, &hd, deadline);
    if (e != MFNS_CAM_OK) {
        h->stats.error_frames++; /* the frame-index gap shows in the next frame's dropped_before */
        return e;
    }
    r->held[k] = true;
    f->data = dst;
    f->bytesused = r->frame_bytes;
    f->pixfmt = h->info.pixfmt;
    f->width = h->info.width;
    f->height = h->info.height;
    f->stride = h->info.stride;
    f->timestamp_ns = (uint64_t)llround(row->t_s * 1e9);
    f->sequence = row->frame;
    f->dropped_before = mfns_cam_seq_delivered(h, row->frame);
    f->ts_source = MFNS_CAM_TS_RECORDED;
    f->arrival_ns = arrival_ns; /* 0 unless paced and waited for */
    f->exposure_us = row->exposure_us;
    f->gain_db = row->gain_db;
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
    folder_put(h);
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
