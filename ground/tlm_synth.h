/* tlm_synth.h -- a deterministic synthetic telemetry stream, so the link
 * and the ground station can be tested before (and independently of) the
 * flight program. Used by mfns-tlm-gen and the tests.
 *
 * Navigation cycle i (i = 0, 1, ...) at 18.6 Hz emits, in this order:
 *   - an EVENT BOOT when i == 0 and an EVENT TABLE_LOADED when i == 1;
 *   - a NAV packet; three CAMERA packets (camera 0, 1, 2);
 *   - a HK packet when i % 19 == 18 (about 1 Hz).
 * Time of cycle i: tlm_time_from_us(i * 53763). Field values are integer
 * formulas of i, written out in tlm_synth.c; tests/host/test_telemetry_link.py
 * re-implements the NAV formulas independently to check the CSV.
 */
#ifndef MFNS_TLM_SYNTH_H
#define MFNS_TLM_SYNTH_H

#include <stddef.h>
#include <stdint.h>

#include "firmware/tlm/tlm_packets.h"

#define GROUND_GEN_CYCLE_US 53763u /* 1 / 18.6 Hz */
#define GROUND_GEN_MAX_PER_CYCLE 6u

void ground_gen_nav(uint32_t i, tlm_packet_t *p);
void ground_gen_camera(uint32_t i, uint8_t camera, tlm_packet_t *p);
void ground_gen_hk(uint32_t i, tlm_packet_t *p);

/* All packets of cycle i in stream order; returns their count (<= GROUND_GEN_MAX_PER_CYCLE). */
size_t ground_gen_cycle(uint32_t i, tlm_packet_t out[GROUND_GEN_MAX_PER_CYCLE]);

#endif /* MFNS_TLM_SYNTH_H */
