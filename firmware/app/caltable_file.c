/* caltable_file.c -- see caltable_file.h. */
#define _DEFAULT_SOURCE /* fdopen, O_CLOEXEC under -std=c11 */

#include "firmware/app/caltable_file.h"

#include <fcntl.h>
#include <stdio.h>
#include <sys/stat.h>
#include <unistd.h>

mfns_caltable_status_t mfns_caltable_load_file(const char *path, uint8_t *buf, size_t buf_size,
                                               mfns_caltable_t *out, uint32_t *err_offset)
{
    if (path == NULL || buf == NULL || out == NULL) {
        return MFNS_CALTABLE_E_ARG;
    }
    /* O_NONBLOCK: opening a FIFO for reading would otherwise wait for a
     * writer and stop the cycle (TABLE_LOAD runs between cycles); anything
     * but a regular file is refused before a byte is read. */
    const int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    if (fd < 0) {
        return MFNS_CALTABLE_E_FILE_OPEN;
    }
    struct stat st_file;
    if (fstat(fd, &st_file) != 0) {
        (void)close(fd); /* the stat failure is the error reported */
        return MFNS_CALTABLE_E_FILE_READ;
    }
    if (!S_ISREG(st_file.st_mode)) {
        (void)close(fd); /* refused: nothing was read */
        return MFNS_CALTABLE_E_FILE_NOT_REGULAR;
    }
    if (st_file.st_size < 0 || (uint64_t)st_file.st_size > (uint64_t)buf_size) {
        (void)close(fd); /* a huge file is refused by its size, before a byte is read */
        return MFNS_CALTABLE_E_FILE_TOO_BIG;
    }
    FILE *f = fdopen(fd, "rb");
    if (f == NULL) {
        (void)close(fd); /* fdopen failed: the fd is still ours */
        return MFNS_CALTABLE_E_FILE_OPEN;
    }
    /* fread until EOF, bounded by the buffer; one byte more than fits means too
     * big (a file that grows after the fstat: at most buf_size + 1 bytes are read) */
    size_t len = 0;
    mfns_caltable_status_t st = MFNS_CALTABLE_OK;
    for (;;) {
        if (len == buf_size) {
            unsigned char extra;
            if (fread(&extra, 1, 1, f) == 1) {
                st = MFNS_CALTABLE_E_FILE_TOO_BIG;
            } else if (ferror(f)) {
                st = MFNS_CALTABLE_E_FILE_READ;
            }
            break;
        }
        const size_t n = fread(buf + len, 1, buf_size - len, f);
        len += n;
        if (n == 0) {
            if (ferror(f)) {
                st = MFNS_CALTABLE_E_FILE_READ;
            }
            break;
        }
    }
    if (fclose(f) != 0 && st == MFNS_CALTABLE_OK) {
        st = MFNS_CALTABLE_E_FILE_READ;
    }
    if (st != MFNS_CALTABLE_OK) {
        return st;
    }
    return mfns_caltable_load(buf, len, out, err_offset);
}
