/* replay_pgm.c -- see replay_pgm.h. */
#include "drivers/camera/replay_pgm.h"

#include <stdio.h>
#include <string.h>

static bool pgm_ws(uint8_t c)
{
    return c == ' ' || c == '\n' || c == '\t' || c == '\r';
}

/* Skips whitespace before a header field; a '#' there starts a comment,
 * which docs/nav-frames.md rules out. */
static bool skip_ws(const uint8_t *buf, size_t n, size_t *p, bool *comment)
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

/* One decimal field (at most 6 digits) followed by whitespace; advances *p. */
static bool pgm_num(const uint8_t *buf, size_t n, size_t *p, uint32_t *out)
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

bool mfns_pgm_parse_header(const uint8_t *buf, size_t n, uint32_t max_dim, mfns_pgm_header_t *hd, char *why,
                           size_t why_size)
{
    memset(hd, 0, sizeof *hd);
    if (n > MFNS_PGM_HDR_MAX) {
        n = MFNS_PGM_HDR_MAX; /* only the header is scanned: pixels may be anything, '#' included */
    }
    if (n < 3 || buf[0] != 'P' || buf[1] != '5' || !pgm_ws(buf[2])) {
        (void)snprintf(why, why_size, "not a binary PGM (magic P5 missing)");
        return false;
    }
    size_t p = 3;
    bool comment = false;
    bool ok = skip_ws(buf, n, &p, &comment) && pgm_num(buf, n, &p, &hd->width);
    ok = ok && skip_ws(buf, n, &p, &comment) && pgm_num(buf, n, &p, &hd->height);
    ok = ok && skip_ws(buf, n, &p, &comment) && pgm_num(buf, n, &p, &hd->maxval);
    if (comment) {
        (void)snprintf(why, why_size, "PGM header comments are not allowed (docs/nav-frames.md)");
        return false;
    }
    if (!ok) {
        (void)snprintf(why, why_size, "malformed PGM header (want \"P5\\n<W> <H>\\n<maxval>\\n\")");
        return false;
    }
    hd->data_off = p + 1; /* exactly one whitespace byte after maxval */
    if (hd->width == 0 || hd->height == 0 || hd->width > max_dim || hd->height > max_dim) {
        (void)snprintf(why, why_size, "size %ux%u outside 1..%u", hd->width, hd->height, max_dim);
        return false;
    }
    if (hd->maxval != 255 && hd->maxval != 1023 && hd->maxval != 4095 && hd->maxval != 65535) {
        (void)snprintf(why, why_size, "maxval %u is not 255, 1023, 4095 or 65535", hd->maxval);
        return false;
    }
    return true;
}

size_t mfns_pgm_pixel_bytes(const mfns_pgm_header_t *hd)
{
    if (hd->width == 0 || hd->height == 0 || hd->maxval == 0) {
        return 0;
    }
    return (size_t)hd->width * hd->height * (hd->maxval > 255u ? 2u : 1u);
}

bool mfns_pgm_to_native(uint8_t *data, size_t bytes, uint32_t maxval, size_t *bad_index)
{
    const size_t n = bytes / 2u;
    for (size_t i = 0; i < n; i++) {
        const uint16_t v = (uint16_t)(((uint16_t)data[2 * i] << 8) | data[2 * i + 1]);
        if (v > maxval) {
            *bad_index = i;
            return false;
        }
        memcpy(data + 2 * i, &v, sizeof v);
    }
    return true;
}
