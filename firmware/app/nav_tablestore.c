/* nav_tablestore.c -- see nav_tablestore.h. */
#define _DEFAULT_SOURCE /* fsync, O_CLOEXEC, O_DIRECTORY under -std=c11 */

#include "firmware/app/nav_tablestore.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "firmware/app/caltable_file.h"

#define WRITE_TRIES 64 /* partial writes of one table before it counts as an I/O error */

/* dir/name into out; false when it does not fit. */
static bool join(char *out, size_t n, const char *dir, const char *name)
{
    const int w = snprintf(out, n, "%s/%s", dir, name);
    return w > 0 && (size_t)w < n;
}

static bool exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

/* fsync of the directory, so the renames in it are on the medium. */
static int sync_dir(const char *dir)
{
    const int fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) {
        return errno;
    }
    const int rc = fsync(fd) != 0 ? errno : 0;
    if (close(fd) != 0 && rc == 0) {
        return errno;
    }
    return rc;
}

/* bytes into path (created 0644, truncated) and fsync'd. 0 or errno. */
static int write_file(const char *path, const uint8_t *bytes, size_t len)
{
    const int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC | O_NOCTTY, 0644);
    if (fd < 0) {
        return errno;
    }
    int rc = 0;
    size_t done = 0;
    for (int i = 0; i < WRITE_TRIES && done < len; i++) {
        const ssize_t w = write(fd, bytes + done, len - done);
        if (w < 0) {
            if (errno == EINTR) {
                continue;
            }
            rc = errno;
            break;
        }
        done += (size_t)w;
    }
    if (rc == 0 && done < len) {
        rc = EIO;
    }
    if (rc == 0 && fsync(fd) != 0) {
        rc = errno;
    }
    if (close(fd) != 0 && rc == 0) {
        rc = errno;
    }
    return rc;
}

int nav_tablestore_commit(const char *state_dir, const uint8_t *bytes, size_t len)
{
    char tmp[NAV_TABLESTORE_PATH_MAX], act[NAV_TABLESTORE_PATH_MAX], prev[NAV_TABLESTORE_PATH_MAX];
    if (state_dir == NULL || bytes == NULL || len == 0 || !join(tmp, sizeof tmp, state_dir, NAV_TABLESTORE_TMP) ||
        !join(act, sizeof act, state_dir, NAV_TABLESTORE_ACTIVE) ||
        !join(prev, sizeof prev, state_dir, NAV_TABLESTORE_PREV)) {
        return ENAMETOOLONG;
    }
    int rc = write_file(tmp, bytes, len);
    if (rc != 0) {
        (void)unlink(tmp); /* a partial file is never renamed into place */
        return rc;
    }
    if (exists(act) && rename(act, prev) != 0) {
        rc = errno;
        (void)unlink(tmp);
        return rc;
    }
    if (rename(tmp, act) != 0) {
        return errno; /* the old one is the previous now: the start-up runs it */
    }
    return sync_dir(state_dir);
}

/* Whether the file at path holds exactly bytes[0..len) (read in chunks, bounded).
 * 1 same, 0 different, -1 unreadable; *size its size. */
static int same_bytes(const char *path, const uint8_t *bytes, size_t len, long *size)
{
    *size = -1;
    const int fd = open(path, O_RDONLY | O_CLOEXEC | O_NONBLOCK);
    if (fd < 0) {
        return -1;
    }
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        (void)close(fd);
        return -1;
    }
    *size = (long)st.st_size;
    int same = (size_t)st.st_size == len ? 1 : 0;
    uint8_t chunk[4096];
    size_t off = 0;
    for (size_t guard = 0; same == 1 && off < len && guard <= MFNS_CALTABLE_MAX_BYTES / sizeof chunk + 1u; guard++) {
        const ssize_t n = read(fd, chunk, sizeof chunk);
        if (n <= 0 || (size_t)n > len - off || memcmp(chunk, bytes + off, (size_t)n) != 0) {
            same = n < 0 ? -1 : 0;
            break;
        }
        off += (size_t)n;
    }
    (void)close(fd);
    return same;
}

/* Loads path into *out; the status. */
static mfns_caltable_status_t load(const char *path, uint8_t *buf, size_t buf_size, mfns_caltable_t *out,
                                   uint32_t *off)
{
    return mfns_caltable_load_file(path, buf, buf_size, out, off);
}

mfns_caltable_status_t nav_tablestore_load_start(const char *state_dir, const char *initial_path, uint8_t *buf,
                                                 size_t buf_size, mfns_caltable_t *out, nav_ts_start_t *info)
{
    memset(info, 0, sizeof *info);
    char act[NAV_TABLESTORE_PATH_MAX], prev[NAV_TABLESTORE_PATH_MAX], bad[NAV_TABLESTORE_PATH_MAX];
    const bool store = state_dir != NULL && join(act, sizeof act, state_dir, NAV_TABLESTORE_ACTIVE) &&
                       join(prev, sizeof prev, state_dir, NAV_TABLESTORE_PREV) &&
                       join(bad, sizeof bad, state_dir, NAV_TABLESTORE_BAD);
    bool tried = false;
    if (store && exists(act)) {
        tried = true;
        info->first_status = load(act, buf, buf_size, out, &info->first_err_offset);
        if (info->first_status == MFNS_CALTABLE_OK) {
            info->source = NAV_TS_SRC_ACTIVE;
            (void)snprintf(info->path, sizeof info->path, "%s", act);
            if (initial_path != NULL) {
                /* issue 45: a --table that differs from the stored one is said, never silently overridden */
                info->initial_differs = same_bytes(initial_path, buf, out->size_bytes, &info->initial_size) != 1;
            }
            return MFNS_CALTABLE_OK;
        }
        info->rolled_back = true;
        uint32_t off = 0;
        if (exists(prev) && load(prev, buf, buf_size, out, &off) == MFNS_CALTABLE_OK) {
            /* the previous one becomes active; the refused one is kept aside */
            if (rename(act, bad) != 0 || rename(prev, act) != 0) {
                info->store_errno = errno;
            } else {
                info->store_errno = sync_dir(state_dir);
            }
            info->source = NAV_TS_SRC_PREV;
            (void)snprintf(info->path, sizeof info->path, "%s", info->store_errno == 0 ? act : prev);
            return MFNS_CALTABLE_OK;
        }
    } else if (store && exists(prev)) {
        /* a cut between the commit's two renames: the previous is the newest whole table */
        uint32_t off = 0;
        if (load(prev, buf, buf_size, out, &off) == MFNS_CALTABLE_OK) {
            info->source = NAV_TS_SRC_PREV;
            info->store_errno = rename(prev, act) != 0 ? errno : sync_dir(state_dir);
            (void)snprintf(info->path, sizeof info->path, "%s", info->store_errno == 0 ? act : prev);
            return MFNS_CALTABLE_OK;
        }
    }
    /* the initial table */
    uint32_t off = 0;
    const mfns_caltable_status_t st =
        initial_path != NULL ? load(initial_path, buf, buf_size, out, &off) : MFNS_CALTABLE_E_FILE_OPEN;
    if (!tried) {
        info->first_status = st;
        info->first_err_offset = off;
    }
    info->source = NAV_TS_SRC_INITIAL;
    (void)snprintf(info->path, sizeof info->path, "%s", initial_path != NULL ? initial_path : "(none)");
    if (st == MFNS_CALTABLE_OK && store) {
        /* copied in, so the next TABLE_LOAD keeps it as the previous one */
        info->store_errno = nav_tablestore_commit(state_dir, buf, out->size_bytes);
    }
    return st;
}
