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

static int read_epoch(const char *path, uint32_t *epoch, char *err, size_t err_size)
{
    const int fd = open(path, O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK);
    if (fd < 0) {
        if (errno == ENOENT) {
            *epoch = 0; /* first boot with this state directory */
            return 0;
        }
        (void)snprintf(err, err_size, "%s: %s", path, strerror(errno));
        return -1;
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
        return -1;
    }
    buf[n] = '\0';
    char *end = NULL;
    errno = 0;
    const unsigned long long v = strncmp(buf, "epoch ", 6) == 0 ? strtoull(buf + 6, &end, 10) : 0ull;
    if (end == NULL || end == buf + 6 || errno != 0 || (*end != '\n' && *end != '\0') || v > UINT32_MAX) {
        (void)snprintf(err, err_size, "%s: does not read 'epoch N' (refused: never reset, see docs/uplink.md)",
                       path);
        return -1;
    }
    *epoch = (uint32_t)v;
    return 0;
}

int tc_state_next_epoch(const char *dir, uint32_t *epoch, char *err, size_t err_size)
{
    char path[512];
    char tmp[520];
    if (snprintf(path, sizeof path, "%s/%s", dir, TC_STATE_FILE) >= (int)sizeof path ||
        snprintf(tmp, sizeof tmp, "%s.tmp", path) >= (int)sizeof tmp) {
        (void)snprintf(err, err_size, "state directory path too long");
        return -1;
    }
    uint32_t last = 0;
    if (read_epoch(path, &last, err, err_size) != 0) {
        return -1;
    }
    if (last == UINT32_MAX) {
        (void)snprintf(err, err_size, "%s: epoch counter exhausted (new keys needed, docs/uplink.md)", path);
        return -1;
    }
    const uint32_t next = last + 1u;
    char text[STATE_MAX];
    const int len = snprintf(text, sizeof text, "epoch %u\n", next);
    const int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC | O_NOFOLLOW, 0600);
    if (fd < 0) {
        (void)snprintf(err, err_size, "%s: %s", tmp, strerror(errno));
        return -1;
    }
    const bool ok = write(fd, text, (size_t)len) == (ssize_t)len && fsync(fd) == 0;
    const int saved = errno;
    if (close(fd) != 0 || !ok || rename(tmp, path) != 0) {
        (void)snprintf(err, err_size, "%s: cannot write: %s", path, strerror(ok ? errno : saved));
        (void)unlink(tmp);
        return -1;
    }
    const int dfd = open(dir, O_RDONLY | O_CLOEXEC);
    if (dfd >= 0) {
        (void)fsync(dfd); /* the rename itself reaches the disk */
        (void)close(dfd);
    }
    *epoch = next;
    return 0;
}
