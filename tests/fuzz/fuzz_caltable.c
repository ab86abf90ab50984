/* libFuzzer target for the calibration-table loader mfns_caltable_load
 * (firmware/nav/table/caltable.c, docs/caltable.md).
 *
 * The first input byte picks a mode:
 *   even  the rest is handed to the loader as it is (header and CRC checks);
 *   odd   the rest gets a consistent total_size and body CRC-32 written into
 *         its header first, so mutations reach the checks behind the CRC
 *         (counts, ranges, grids, rig geometry).
 * Invariants: the loader never reads outside the input (ASan), never accepts
 * a table whose header CRC or size disagrees with the bytes, and leaves *out
 * untouched on refusal.
 * Build: clang -fsanitize=fuzzer,address,undefined (mk/fuzz.mk). */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "firmware/nav/table/caltable.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check(int cond)
{
    if (!cond) {
        abort();
    }
}

static uint32_t get_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

static void put_u32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++) {
        p[i] = (uint8_t)(v >> (8 * i));
    }
}

static mfns_caltable_t g_table; /* large: static, as in the flight program */

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1 || size - 1 > MFNS_CALTABLE_MAX_BYTES + 64u) {
        return 0;
    }
    const size_t n = size - 1;
    uint8_t *buf = malloc(n ? n : 1); /* exact size: ASan catches any read past the end */
    check(buf != NULL);
    memcpy(buf, data + 1, n);
    if ((data[0] & 1u) && n >= 16) {
        put_u32(buf + 8, (uint32_t)n);
        put_u32(buf + 12, mfns_crc32(0, buf + 16, n - 16));
    }
    /* sentinels at both ends (a full memset per run would dominate the run time) */
    uint8_t *tp = (uint8_t *)&g_table;
    memset(tp, 0xA5, 256);
    memset(tp + sizeof g_table - 256, 0xA5, 256);
    uint32_t off = 0;
    const mfns_caltable_status_t st = mfns_caltable_load(buf, n, &g_table, &off);
    (void)mfns_caltable_strerror(st);
    if (st == MFNS_CALTABLE_OK) {
        check(n >= 16);
        const uint32_t total = get_u32(buf + 8);
        check(total <= n);
        check(get_u32(buf + 12) == mfns_crc32(0, buf + 16, total - 16));
    } else {
        for (size_t i = 0; i < 256; i++) {
            check(tp[i] == 0xA5 && tp[sizeof g_table - 256 + i] == 0xA5); /* refused: never partly copied */
        }
    }
    free(buf);
    return 0;
}
