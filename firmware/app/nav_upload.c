/* nav_upload.c -- see nav_upload.h. */
#ifndef _DEFAULT_SOURCE
#define _DEFAULT_SOURCE /* fsync, O_CLOEXEC, O_DIRECTORY under -std=c11 (the fuzz build defines it) */
#endif

#include "firmware/app/nav_upload.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

void nav_upload_init(nav_upload_t *u, uint8_t *buf, uint32_t cap, uint32_t timeout_ms)
{
    memset(u, 0, sizeof *u);
    u->buf = buf;
    u->cap = buf != NULL ? cap : 0u;
    u->timeout_ms = timeout_ms != 0u ? timeout_ms : NAV_UPLOAD_TIMEOUT_MS;
}

static void drop(nav_upload_t *u)
{
    u->state = NAV_UPLOAD_IDLE;
    u->size = 0;
    u->crc_decl = 0;
    u->crc_run = 0;
    u->next = 0;
    u->name[0] = '\0';
}

static bool name_ok(const char *name)
{
    if (name == NULL || name[0] == '\0' || name[0] == '.') {
        return false;
    }
    for (size_t i = 0; i < NAV_UPLOAD_NAME_MAX; i++) {
        const char c = name[i];
        if (c == '\0') {
            return true;
        }
        const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' ||
                        c == '_' || c == '-';
        if (!ok) {
            return false;
        }
    }
    return false; /* no NUL within NAV_UPLOAD_NAME_MAX: too long */
}

nav_upload_status_t nav_upload_start(nav_upload_t *u, uint32_t size, uint32_t crc32, const char *name,
                                     uint32_t now_ms)
{
    if (size == 0u || size > u->cap) {
        return NAV_UP_E_SIZE;
    }
    if (!name_ok(name)) {
        return NAV_UP_E_NAME;
    }
    if (u->state == NAV_UPLOAD_RECEIVING && u->size == size && u->crc_decl == crc32 &&
        strcmp(u->name, name) == 0) {
        u->last_ms = now_ms;
        return NAV_UP_RESUMED;
    }
    if (u->state != NAV_UPLOAD_IDLE) {
        u->n_abandoned++; /* a new upload replaces the open one */
    }
    drop(u);
    u->state = NAV_UPLOAD_RECEIVING;
    u->size = size;
    u->crc_decl = crc32;
    (void)snprintf(u->name, sizeof u->name, "%s", name);
    u->last_ms = now_ms;
    return NAV_UP_OK;
}

nav_upload_status_t nav_upload_data(nav_upload_t *u, uint32_t offset, const uint8_t *bytes, size_t n,
                                    uint32_t now_ms)
{
    if (u->state != NAV_UPLOAD_RECEIVING) {
        return NAV_UP_E_STATE;
    }
    if (bytes == NULL || n == 0u || n > NAV_UPLOAD_SEG_MAX) {
        return NAV_UP_E_LENGTH;
    }
    u->last_ms = now_ms; /* a live link, whatever the segment's fate */
    if (offset > u->next) {
        return NAV_UP_E_GAP;
    }
    const uint32_t len = (uint32_t)n; /* <= NAV_UPLOAD_SEG_MAX */
    if (offset > u->size || len > u->size - offset) {
        return NAV_UP_E_OVERRUN;
    }
    /* the part already received must be the same bytes */
    const uint32_t old = u->next - offset < len ? u->next - offset : len;
    if (old > 0u && memcmp(u->buf + offset, bytes, old) != 0) {
        return NAV_UP_E_CONFLICT;
    }
    if (old == len) {
        return NAV_UP_DUPLICATE;
    }
    const uint32_t fresh = len - old;
    memcpy(u->buf + u->next, bytes + old, fresh);
    u->crc_run = mfns_crc32(u->crc_run, u->buf + u->next, fresh);
    u->next += fresh;
    return NAV_UP_OK;
}

nav_upload_status_t nav_upload_end(nav_upload_t *u, uint32_t now_ms)
{
    if (u->state == NAV_UPLOAD_COMPLETE) {
        return NAV_UP_DUPLICATE; /* END re-sent */
    }
    if (u->state != NAV_UPLOAD_RECEIVING) {
        return NAV_UP_E_STATE;
    }
    u->last_ms = now_ms;
    if (u->next != u->size) {
        return NAV_UP_E_INCOMPLETE;
    }
    if (u->crc_run != u->crc_decl) {
        drop(u); /* every byte arrived in order and the sum differs: the file itself is not the declared one */
        return NAV_UP_E_CRC;
    }
    u->state = NAV_UPLOAD_COMPLETE;
    return NAV_UP_OK;
}

nav_upload_status_t nav_upload_abort(nav_upload_t *u)
{
    if (u->state == NAV_UPLOAD_IDLE) {
        return NAV_UP_E_STATE;
    }
    u->n_abandoned++;
    drop(u);
    return NAV_UP_OK;
}

nav_upload_status_t nav_upload_tick(nav_upload_t *u, uint32_t now_ms)
{
    if (u->state == NAV_UPLOAD_IDLE || (uint32_t)(now_ms - u->last_ms) < u->timeout_ms) {
        return NAV_UP_OK; /* unsigned difference: a wrap of the millisecond clock is harmless */
    }
    u->n_abandoned++;
    drop(u);
    return NAV_UP_E_TIMEOUT;
}

nav_upload_status_t nav_upload_validate(nav_upload_t *u, mfns_caltable_t *out, mfns_caltable_status_t *table_status)
{
    if (u->state != NAV_UPLOAD_COMPLETE) {
        return NAV_UP_E_STATE;
    }
    uint32_t off = 0;
    const mfns_caltable_status_t ts = mfns_caltable_load(u->buf, u->size, out, &off);
    if (table_status != NULL) {
        *table_status = ts;
    }
    if (ts != MFNS_CALTABLE_OK) {
        drop(u);
        return NAV_UP_E_TABLE;
    }
    return NAV_UP_OK;
}

static int write_all(int fd, const uint8_t *p, size_t n)
{
    size_t done = 0;
    while (done < n) { /* bounded: every pass writes >= 1 byte or returns */
        const ssize_t w = write(fd, p + done, n - done);
        if (w < 0 && errno == EINTR) {
            continue;
        }
        if (w <= 0) {
            return w < 0 ? errno : EIO;
        }
        done += (size_t)w;
    }
    return 0;
}

int nav_upload_store(nav_upload_t *u, const char *dir, char *path, size_t path_len)
{
    if (u->state != NAV_UPLOAD_COMPLETE || dir == NULL || path == NULL) {
        drop(u);
        return EINVAL;
    }
    char tmp[512];
    const int nt = snprintf(tmp, sizeof tmp, "%s/%s", dir, NAV_UPLOAD_TMP);
    const int np = snprintf(path, path_len, "%s/%s", dir, NAV_UPLOAD_FILE);
    if (nt < 0 || (size_t)nt >= sizeof tmp || np < 0 || (size_t)np >= path_len) {
        drop(u);
        return ENAMETOOLONG;
    }
    int err = 0;
    const int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) {
        err = errno;
    } else {
        err = write_all(fd, u->buf, u->size);
        if (err == 0 && fsync(fd) != 0) {
            err = errno;
        }
        if (close(fd) != 0 && err == 0) {
            err = errno;
        }
        if (err == 0 && rename(tmp, path) != 0) {
            err = errno;
        }
        if (err != 0) {
            (void)unlink(tmp);
        }
    }
    if (err == 0) {
        const int dfd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
        if (dfd < 0 || fsync(dfd) != 0) {
            err = errno;
        }
        if (dfd >= 0) {
            (void)close(dfd);
        }
    }
    drop(u);
    return err;
}

uint32_t nav_upload_next(const nav_upload_t *u)
{
    return u->next;
}

const char *nav_upload_strerror(nav_upload_status_t s)
{
    static const char *const k_msg[NAV_UP_STATUS_COUNT] = {
        [NAV_UP_OK] = "ok",
        [NAV_UP_DUPLICATE] = "duplicate (already received)",
        [NAV_UP_RESUMED] = "the open upload resumed",
        [NAV_UP_E_STATE] = "no upload open",
        [NAV_UP_E_SIZE] = "declared size 0 or larger than the receive buffer",
        [NAV_UP_E_NAME] = "bad name (1..31 of [A-Za-z0-9._-], no leading '.')",
        [NAV_UP_E_LENGTH] = "segment length 0 or over the maximum",
        [NAV_UP_E_GAP] = "segment past the next expected offset",
        [NAV_UP_E_OVERRUN] = "segment past the declared size",
        [NAV_UP_E_CONFLICT] = "re-sent bytes differ from the received ones",
        [NAV_UP_E_INCOMPLETE] = "end before every byte arrived",
        [NAV_UP_E_CRC] = "CRC-32 of the file differs from the declared one",
        [NAV_UP_E_TIMEOUT] = "upload abandoned: no segment within the timeout",
        [NAV_UP_E_TABLE] = "the table loader refused the file",
        [NAV_UP_E_STORE] = "storing the file failed",
    };
    return (unsigned)s < (unsigned)NAV_UP_STATUS_COUNT && k_msg[s] != NULL ? k_msg[s] : "unknown upload status";
}
