/* tc_state.c -- see tc_state.h. */
#define _DEFAULT_SOURCE /* O_CLOEXEC, O_NOFOLLOW, fsync under -std=c11 */

#include "firmware/app/tc_state.h"

#include <errno.h>
#include <stdbool.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define STATE_MAX 64 /* bytes of the file: "epoch N\n" */

static int paths(const char *dir, char *path, size_t np, char *tmp, size_t nt)
{
    if (dir == NULL || snprintf(path, np, "%s/%s", dir, TC_STATE_FILE) >= (int)np ||
        snprintf(tmp, nt, "%s.tmp", path) >= (int)nt) {
        return -1;
    }
    return 0;
}

tc_state_fault_t tc_state_read(const char *dir, uint32_t *epoch, int *err_no, char *err, size_t err_size)
{
    char path[512];
    char tmp[520];
    *epoch = 0;
    *err_no = 0;
    if (paths(dir, path, sizeof path, tmp, sizeof tmp) != 0) {
        (void)snprintf(err, err_size, "state directory path too long");
        *err_no = ENAMETOOLONG;
        return TC_STATE_DAMAGED;
    }
    const int fd = open(path, O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK);
    if (fd < 0) {
        *err_no = errno;
        (void)snprintf(err, err_size, "%s: %s", path, strerror(errno));
        return errno == ENOENT ? TC_STATE_MISSING : (errno == ENOTDIR ? TC_STATE_UNWRITABLE : TC_STATE_DAMAGED);
    }
    struct stat st;
    char buf[STATE_MAX + 1];
    ssize_t n = -1;
    if (fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && st.st_size <= STATE_MAX) {
        n = read(fd, buf, STATE_MAX);
    }
    (void)close(fd);
    if (n <= 0) {
        (void)snprintf(err, err_size, "%s: not a regular file of at most %d bytes", path, STATE_MAX);
        *err_no = EINVAL;
        return TC_STATE_DAMAGED;
    }
    buf[n] = '\0';
    char *end = NULL;
    errno = 0;
    const unsigned long long v = strncmp(buf, "epoch ", 6) == 0 ? strtoull(buf + 6, &end, 10) : 0ull;
    if (end == NULL || end == buf + 6 || errno != 0 || (*end != '\n' && *end != '\0') || v > UINT32_MAX) {
        (void)snprintf(err, err_size, "%s: does not read 'epoch N' (damaged: never read as 0, see docs/uplink.md)",
                       path);
        *err_no = EINVAL;
        return TC_STATE_DAMAGED;
    }
    *epoch = (uint32_t)v;
    return TC_STATE_OK;
}

static void sync_dir(const char *dir)
{
    const int dfd = open(dir, O_RDONLY | O_CLOEXEC);
    if (dfd >= 0) {
        (void)fsync(dfd); /* the rename itself reaches the disk */
        (void)close(dfd);
    }
}

int tc_state_write(const char *dir, uint32_t epoch, char *err, size_t err_size)
{
    char path[512];
    char tmp[520];
    if (paths(dir, path, sizeof path, tmp, sizeof tmp) != 0) {
        (void)snprintf(err, err_size, "state directory path too long");
        return ENAMETOOLONG;
    }
    char text[STATE_MAX];
    const int len = snprintf(text, sizeof text, "epoch %u\n", epoch);
    const int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC | O_NOFOLLOW, 0600);
    if (fd < 0) {
        const int e = errno;
        (void)snprintf(err, err_size, "%s: %s", tmp, strerror(e));
        return e;
    }
    const bool ok = write(fd, text, (size_t)len) == (ssize_t)len && fsync(fd) == 0;
    const int saved = ok ? 0 : (errno != 0 ? errno : ENOSPC);
    const bool closed = close(fd) == 0;
    int e = saved;
    if (e == 0 && !closed) {
        e = errno;
    }
    if (e == 0 && rename(tmp, path) != 0) {
        e = errno;
    }
    if (e != 0) {
        (void)snprintf(err, err_size, "%s: cannot write: %s", path, strerror(e));
        (void)unlink(tmp);
        return e;
    }
    sync_dir(dir);
    return 0;
}

int tc_state_probe_write(const char *dir)
{
    char path[512];
    char tmp[520];
    if (paths(dir, path, sizeof path, tmp, sizeof tmp) != 0) {
        return ENAMETOOLONG;
    }
    const int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC | O_NOFOLLOW, 0600);
    if (fd < 0) {
        return errno;
    }
    const bool ok = write(fd, "probe\n", 6u) == 6 && fsync(fd) == 0;
    const int e = ok ? 0 : (errno != 0 ? errno : ENOSPC);
    (void)close(fd);
    (void)unlink(tmp);
    return e;
}

int tc_state_next_epoch(const char *dir, uint32_t *epoch, char *err, size_t err_size)
{
    uint32_t last = 0;
    int e = 0;
    const tc_state_fault_t f = tc_state_read(dir, &last, &e, err, err_size);
    if (f != TC_STATE_OK && !(f == TC_STATE_MISSING && e == ENOENT && access(dir, W_OK) == 0)) {
        return -1; /* a missing file in a usable directory is a first start; anything else is refused */
    }
    if (last == UINT32_MAX) {
        (void)snprintf(err, err_size, "%s/%s: epoch counter exhausted (new keys needed, docs/uplink.md)", dir,
                       TC_STATE_FILE);
        return -1;
    }
    if (tc_state_write(dir, last + 1u, err, err_size) != 0) {
        return -1;
    }
    *epoch = last + 1u;
    return 0;
}
