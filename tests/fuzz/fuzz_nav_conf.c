/* libFuzzer target for the flight program's configuration reader
 * nav_config_parse (firmware/app/nav_conf.c, docs/operations.md
 * "Configuration").
 * Invariants: the reader never reads outside the input (ASan), never
 * overruns the message buffer, accepts nothing longer than
 * NAV_CONFIG_MAX_BYTES, and on success every key it set holds a
 * NUL-terminated value shorter than a line with no control character, and a
 * number in its range; on failure the message names a line.
 * Build: clang -fsanitize=fuzzer,address,undefined (mk/fuzz.mk). */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "firmware/app/nav_conf.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check(int cond)
{
    if (!cond) {
        abort();
    }
}

static nav_config_t g_cfg;

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char err[NAV_CONFIG_ERR_LEN];
    memset(err, 0x55, sizeof err);
    const int rc = nav_config_parse((const char *)data, size, &g_cfg, err, sizeof err);
    if (rc != 0) {
        check(memchr(err, '\0', sizeof err) != NULL);
        check(size > NAV_CONFIG_MAX_BYTES || strncmp(err, "line ", 5) == 0);
        return 0;
    }
    check(size <= NAV_CONFIG_MAX_BYTES);
    for (int k = 0; k < (int)NAV_CFG_KEY_COUNT; k++) {
        if (!g_cfg.set[k]) {
            continue;
        }
        const size_t n = strnlen(g_cfg.value[k], NAV_CONFIG_VALUE_MAX);
        check(n > 0 && n <= NAV_CONFIG_LINE_MAX);
        for (size_t i = 0; i < n; i++) {
            check((unsigned char)g_cfg.value[k][i] >= 0x20u && g_cfg.value[k][i] != 0x7f);
        }
        check(g_cfg.line[k] >= 1u);
    }
    if (g_cfg.set[NAV_CFG_BAUD]) {
        check(g_cfg.number[NAV_CFG_BAUD] >= 1200u && g_cfg.number[NAV_CFG_BAUD] <= 4000000u);
    }
    return 0;
}
