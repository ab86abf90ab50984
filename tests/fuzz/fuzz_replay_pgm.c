/* libFuzzer target for the replay PGM reader (drivers/camera/replay_pgm.c):
 * header parse, pixel size, and the 16-bit big-endian -> native conversion
 * with its maxval check.
 * Invariants: an accepted header lies inside the bytes scanned, has a
 * documented maxval and a size within the limit; converted samples never
 * exceed maxval. Build: mk/fuzz.mk. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "drivers/camera/replay_pgm.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check(int cond)
{
    if (!cond) {
        abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    uint8_t *buf = malloc(size ? size : 1); /* exact size for ASan */
    check(buf != NULL);
    memcpy(buf, data, size);
    mfns_pgm_header_t hd;
    char why[192];
    /* a small dimension limit so accepted headers describe frames the input can hold */
    if (mfns_pgm_parse_header(buf, size, 256u, &hd, why, sizeof why)) {
        check(hd.data_off <= MFNS_PGM_HDR_MAX && hd.data_off <= size);
        check(hd.width >= 1 && hd.width <= 256 && hd.height >= 1 && hd.height <= 256);
        check(hd.maxval == 255 || hd.maxval == 1023 || hd.maxval == 4095 || hd.maxval == 65535);
        const size_t bytes = mfns_pgm_pixel_bytes(&hd);
        check(bytes == (size_t)hd.width * hd.height * (hd.maxval > 255 ? 2u : 1u));
        if (hd.maxval > 255 && size - hd.data_off >= bytes) {
            size_t bad = 0;
            uint8_t *px = buf + hd.data_off;
            if (mfns_pgm_to_native(px, bytes, hd.maxval, &bad)) {
                for (size_t i = 0; i < bytes / 2; i++) {
                    uint16_t v;
                    memcpy(&v, px + 2 * i, 2);
                    check(v <= hd.maxval);
                }
            } else {
                check(bad < bytes / 2);
            }
        }
    } else {
        check(strlen(why) > 0);
    }
    free(buf);
    return 0;
}
