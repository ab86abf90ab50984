/* cycle_stats.c -- see cycle_stats.h. */
#include "firmware/frames/cycle_stats.h"

#include <math.h>
#include <string.h>

#define MIN_US 10.0f
#define BIN_RATIO 1.05f /* 5 % per bin: 10 us * 1.05^288 ~ 12.6 s */

void mfns_cycle_stats_reset(mfns_cycle_stats_t *s) { memset(s, 0, sizeof *s); }

static uint32_t bin_of(uint32_t us, uint32_t *out_of_range)
{
    if ((float)us < MIN_US) {
        (*out_of_range)++;
        return 0;
    }
    const float b = logf((float)us / MIN_US) / logf(BIN_RATIO);
    if (!(b < (float)(MFNS_CYCLE_BINS - 1))) {
        (*out_of_range)++;
        return MFNS_CYCLE_BINS - 1;
    }
    return (uint32_t)b;
}

void mfns_cycle_stats_add(mfns_cycle_stats_t *s, uint32_t busy_us, uint32_t period_us)
{
    if (s->count == UINT32_MAX) {
        return; /* window full: the caller resets at each report */
    }
    s->bins[bin_of(busy_us, &s->out_of_range)]++;
    s->count++;
    s->busy_us += busy_us;
    s->wall_us += period_us > busy_us ? period_us : busy_us;
    if (busy_us > s->max_us) {
        s->max_us = busy_us;
    }
}

uint32_t mfns_cycle_stats_percentile(const mfns_cycle_stats_t *s, float p)
{
    if (s->count == 0 || !(p > 0.0f)) {
        return 0;
    }
    const float pc = p > 100.0f ? 100.0f : p;
    const uint32_t rank = (uint32_t)ceilf(pc / 100.0f * (float)s->count);
    uint32_t seen = 0;
    for (uint32_t b = 0; b < MFNS_CYCLE_BINS; b++) {
        seen += s->bins[b];
        if (seen >= rank) {
            if (b == MFNS_CYCLE_BINS - 1) {
                return s->max_us; /* the overflow bin has no upper edge */
            }
            /* bin centre (geometric), capped by the true maximum */
            const float centre = MIN_US * powf(BIN_RATIO, (float)b + 0.5f);
            const uint32_t v = (uint32_t)centre;
            return v < s->max_us ? v : s->max_us;
        }
    }
    return s->max_us;
}

float mfns_cycle_stats_cpu_load_pct(const mfns_cycle_stats_t *s)
{
    if (s->wall_us == 0) {
        return 0.0f;
    }
    return 100.0f * (float)((double)s->busy_us / (double)s->wall_us); /* double: 64-bit sums */
}
