/* replay_index.c -- see replay_index.h. */
#include "drivers/camera/replay_index.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_FIELDS 8 /* fields cut per row; more only matters as "not 6" */

uint32_t mfns_replay_count_rows(const char *text, size_t len)
{
    uint32_t lines = 0;
    for (size_t i = 0; i < len && lines <= MFNS_REPLAY_MAX_ROWS; i++) {
        if (text[i] == '\n') {
            lines++;
        }
    }
    return lines + 1u; /* a last line without newline */
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
    /* plain decimal only: strtod would also take hex, "inf" and leading spaces */
    if (*s == '\0' || strpbrk(s, "xXiInN ") != NULL) {
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

static bool is_camera(const char *s)
{
    return (s[0] == 'x' || s[0] == 'y' || s[0] == 'z') && s[1] == '\0';
}

/* Validates one row (NUL-terminated, no line end) into r. */
static void parse_row(char *line, size_t max_file_len, mfns_replay_row_t *r)
{
    char *fld[MAX_FIELDS];
    int k = 0;
    fld[k++] = line;
    for (char *p = line; *p && k < MAX_FIELDS; p++) {
        if (*p == ',') {
            *p = '\0';
            fld[k++] = p + 1;
        }
    }
    const bool extra = k == MAX_FIELDS && strchr(fld[MAX_FIELDS - 1], ',') != NULL;
    if (k >= 3 && is_camera(fld[2])) {
        r->camera = fld[2][0]; /* attributable even when another field is bad */
    }
    if (k != 6 || extra) {
        r->status = MFNS_ROW_FIELDS;
        return;
    }
    double t_s = 0.0, exposure = 0.0, gain = 0.0;
    if (!parse_u32(fld[0], &r->frame)) {
        r->status = MFNS_ROW_FRAME;
        r->field = fld[0];
    } else if (!parse_real(fld[1], &t_s) || t_s < 0.0 || t_s > 1e9) {
        r->status = MFNS_ROW_TIME;
        r->field = fld[1];
    } else if (!is_camera(fld[2])) {
        r->status = MFNS_ROW_CAMERA;
        r->field = fld[2];
    } else if (!safe_relative(fld[3]) || strlen(fld[3]) > max_file_len) {
        r->status = MFNS_ROW_FILE;
        r->field = fld[3];
    } else if (!parse_real(fld[4], &exposure) || exposure < 0.0 || exposure > 2147483647.0) {
        r->status = MFNS_ROW_EXPOSURE;
        r->field = fld[4];
    } else if (!parse_real(fld[5], &gain) || fabs(gain) > MFNS_REPLAY_GAIN_DB_MAX) {
        r->status = MFNS_ROW_GAIN;
        r->field = fld[5];
    } else {
        r->status = MFNS_ROW_OK;
        r->t_s = t_s;
        r->exposure_us = (int32_t)lround(exposure);
        r->gain_db = (float)gain;
        r->file = fld[3];
    }
}

bool mfns_replay_index_parse(char *text, size_t len, size_t max_file_len, mfns_replay_row_t *rows, uint32_t cap,
                             uint32_t *n_rows, char *why, size_t why_size)
{
    *n_rows = 0;
    text[len] = '\0';
    /* per camera x, y, z: the last good row, for the order check */
    bool have_prev[3] = {false, false, false};
    uint32_t prev_frame[3] = {0, 0, 0};
    double prev_t[3] = {0.0, 0.0, 0.0};
    size_t pos = 0;
    uint32_t line_no = 0;
    /* One pass per line: bounded by the number of line ends in len bytes. */
    for (size_t guard = 0; guard <= len && pos < len; guard++) {
        char *line = text + pos;
        char *nl = memchr(line, '\n', len - pos);
        size_t ll = nl ? (size_t)(nl - line) : len - pos;
        pos += ll + (nl ? 1u : 0u);
        line_no++;
        if (nl) {
            *nl = '\0';
        }
        if (ll > 0 && line[ll - 1] == '\r') {
            line[--ll] = '\0';
        }
        const bool has_nul = memchr(line, '\0', ll) != NULL;
        if (line_no == 1) {
            if (has_nul || strcmp(line, MFNS_REPLAY_CSV_HEADER) != 0) {
                (void)snprintf(why, why_size, "frames.csv: header is not \"%s\"", MFNS_REPLAY_CSV_HEADER);
                return false;
            }
            continue;
        }
        if (*n_rows >= cap) {
            (void)snprintf(why, why_size, "frames.csv: more than %u rows", cap);
            return false;
        }
        mfns_replay_row_t *r = &rows[(*n_rows)++];
        memset(r, 0, sizeof *r);
        r->line = line_no;
        r->field = "";
        if (has_nul) {
            r->status = MFNS_ROW_NUL;
        } else if (ll > MFNS_REPLAY_LINE_MAX) {
            r->status = MFNS_ROW_LONG;
        } else {
            parse_row(line, max_file_len, r);
        }
        if (r->status != MFNS_ROW_OK || r->camera == '\0') {
            continue;
        }
        const int c = r->camera - 'x';
        if (have_prev[c] && (r->frame <= prev_frame[c] || r->t_s < prev_t[c])) {
            r->status = MFNS_ROW_ORDER;
            r->prev_frame = prev_frame[c];
            r->prev_t_s = prev_t[c];
            continue;
        }
        have_prev[c] = true;
        prev_frame[c] = r->frame;
        prev_t[c] = r->t_s;
    }
    if (line_no == 0) {
        (void)snprintf(why, why_size, "frames.csv: header is not \"%s\"", MFNS_REPLAY_CSV_HEADER);
        return false;
    }
    return true;
}

void mfns_replay_row_message(const mfns_replay_row_t *r, char *out, size_t n)
{
    const unsigned ln = r->line;
    switch ((mfns_replay_row_status_t)r->status) {
    case MFNS_ROW_OK: (void)snprintf(out, n, "frames.csv line %u: ok", ln); break;
    case MFNS_ROW_FIELDS: (void)snprintf(out, n, "frames.csv line %u: expected 6 comma-separated fields", ln); break;
    case MFNS_ROW_FRAME:
        (void)snprintf(out, n, "frames.csv line %u: frame '%.20s' is not an index", ln, r->field);
        break;
    case MFNS_ROW_TIME:
        (void)snprintf(out, n, "frames.csv line %u: t_s '%.20s' is not a time in seconds", ln, r->field);
        break;
    case MFNS_ROW_CAMERA:
        (void)snprintf(out, n, "frames.csv line %u: camera '%.20s' is not x, y or z", ln, r->field);
        break;
    case MFNS_ROW_FILE:
        (void)snprintf(out, n, "frames.csv line %u: file '%.40s' is not a relative path inside the folder", ln,
                       r->field);
        break;
    case MFNS_ROW_EXPOSURE:
        (void)snprintf(out, n, "frames.csv line %u: exposure_us '%.20s' is not a duration", ln, r->field);
        break;
    case MFNS_ROW_GAIN:
        (void)snprintf(out, n, "frames.csv line %u: gain_db '%.20s' is not a number within +-%.0f dB", ln, r->field,
                       MFNS_REPLAY_GAIN_DB_MAX);
        break;
    case MFNS_ROW_ORDER:
        (void)snprintf(out, n, "frames.csv line %u: camera %c frame %u at %.6f s does not follow frame %u at %.6f s",
                       ln, r->camera, r->frame, r->t_s, r->prev_frame, r->prev_t_s);
        break;
    case MFNS_ROW_LONG:
        (void)snprintf(out, n, "frames.csv line %u: longer than %u characters", ln, MFNS_REPLAY_LINE_MAX);
        break;
    case MFNS_ROW_NUL: (void)snprintf(out, n, "frames.csv line %u: contains a NUL byte", ln); break;
    default: (void)snprintf(out, n, "frames.csv line %u: bad row", ln); break;
    }
}
