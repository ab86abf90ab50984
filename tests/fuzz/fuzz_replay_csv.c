/* libFuzzer target for the frames.csv parser (drivers/camera/replay_index.c).
 * Invariants: every row lies inside the text; a good row has a file name, a
 * camera and a finite time; good rows of one camera strictly increase in
 * frame index and never go back in time; every row has a message.
 * Build: mk/fuzz.mk. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "drivers/camera/replay_index.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check(int cond)
{
    if (!cond) {
        abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size > (1u << 20)) {
        return 0;
    }
    char *text = malloc(size + 1);
    check(text != NULL);
    memcpy(text, data, size);
    const uint32_t cap = mfns_replay_count_rows(text, size);
    check(cap >= 1 && cap <= size + 2u);
    mfns_replay_row_t *rows = malloc(sizeof *rows * cap);
    check(rows != NULL);
    uint32_t n = 0;
    char why[192];
    if (mfns_replay_index_parse(text, size, 200, rows, cap, &n, why, sizeof why)) {
        check(n < cap);
        int have[3] = {0, 0, 0};
        uint32_t prev_f[3] = {0, 0, 0};
        double prev_t[3] = {0, 0, 0};
        for (uint32_t i = 0; i < n; i++) {
            const mfns_replay_row_t *r = &rows[i];
            char msg[256];
            mfns_replay_row_message(r, msg, sizeof msg);
            check(msg[0] != '\0');
            check(r->line >= 2);
            if (r->status != MFNS_ROW_OK) {
                continue;
            }
            check(r->file >= text && r->file < text + size && strlen(r->file) <= 200);
            check(r->file[0] != '/' && r->camera >= 'x' && r->camera <= 'z' && isfinite(r->t_s));
            const int c = r->camera - 'x';
            check(!have[c] || (r->frame > prev_f[c] && r->t_s >= prev_t[c]));
            have[c] = 1;
            prev_f[c] = r->frame;
            prev_t[c] = r->t_s;
        }
    } else {
        check(strlen(why) > 0);
    }
    free(rows);
    free(text);
    return 0;
}
