/* caltable_file.c -- see caltable_file.h. */
#include "caltable_file.h"

#include <stdio.h>

mfns_caltable_status_t mfns_caltable_load_file(const char *path, uint8_t *buf, size_t buf_size,
                                               mfns_caltable_t *out, uint32_t *err_offset)
{
    if (path == NULL || buf == NULL || out == NULL) {
        return MFNS_CALTABLE_E_ARG;
    }
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        return MFNS_CALTABLE_E_FILE_OPEN;
    }
    /* fread until EOF, bounded by the buffer; one byte more than fits means too big */
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
