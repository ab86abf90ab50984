/* libFuzzer target for the scenario.json check (drivers/camera/replay_scenario.c).
 * Invariants: an accepted text is a JSON object holding "mfns-nav-frames"
 * and a version digit; a refusal always says why. Inputs are not
 * NUL-terminated (the scanner must respect the length). Build: mk/fuzz.mk. */
#define _GNU_SOURCE 1 /* memmem */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "drivers/camera/replay_scenario.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check(int cond)
{
    if (!cond) {
        abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char *json = malloc(size ? size : 1); /* exact size, no terminator */
    check(json != NULL);
    memcpy(json, data, size);
    char why[192];
    why[0] = '\0';
    if (mfns_replay_scenario_check(json, size, why, sizeof why)) {
        check(size >= 2);
        size_t i = 0;
        while (json[i] == ' ' || json[i] == '\t' || json[i] == '\n' || json[i] == '\r') {
            i++;
        }
        check(json[i] == '{');
        check(memmem(json, size, "mfns-nav-frames", 15) != NULL);
        check(memmem(json, size, "\"version\"", 9) != NULL);
    } else {
        check(strlen(why) > 0);
    }
    free(json);
    return 0;
}
