/* cycle_stats.h -- navigation-cycle timing for housekeeping telemetry:
 * percentiles of the cycle time over a reporting window and the CPU load
 * (busy time / wall time), in constant memory and constant time per sample.
 *
 * Cycle times are binned into a fixed log-spaced histogram (MFNS_CYCLE_BINS
 * bins, 5 % wide, from 10 us to ~10 s), so a percentile is exact to one bin
 * width (+-2.5 %) whatever the number of samples; samples beyond the range go
 * to the first or last bin and are counted as out of range.
 */
#ifndef MFNS_CYCLE_STATS_H
#define MFNS_CYCLE_STATS_H

#include <stdint.h>

#define MFNS_CYCLE_BINS 288

typedef struct {
    uint32_t bins[MFNS_CYCLE_BINS];
    uint32_t count;
    uint32_t out_of_range;
    uint64_t busy_us;  /* sum of cycle (processing) times */
    uint64_t wall_us;  /* sum of cycle periods (processing + waiting) */
    uint32_t max_us;
} mfns_cycle_stats_t;

void mfns_cycle_stats_reset(mfns_cycle_stats_t *s);
/* One cycle: busy_us spent processing, period_us since the previous cycle start. */
void mfns_cycle_stats_add(mfns_cycle_stats_t *s, uint32_t busy_us, uint32_t period_us);
/* The p-th percentile (0 < p <= 100) of busy time in us; 0 when empty. */
uint32_t mfns_cycle_stats_percentile(const mfns_cycle_stats_t *s, float p);
/* Busy / wall in percent (0..100); 0 when no wall time yet. */
float mfns_cycle_stats_cpu_load_pct(const mfns_cycle_stats_t *s);

#endif /* MFNS_CYCLE_STATS_H */
