/* tlm_test_samples.h -- deterministic telemetry packets for the tlm tests:
 * every field depends on (type, i) and uses its full range somewhere
 * (negative values, values with 0x00 bytes, large counters). */
#ifndef MFNS_TLM_TEST_SAMPLES_H
#define MFNS_TLM_TEST_SAMPLES_H

#include <stddef.h>
#include <stdint.h>

#include "firmware/tlm/tlm_packets.h"

void tlm_test_sample(tlm_packet_t *p, tlm_type_t type, uint32_t i);
/* Field-by-field equality (not memcmp: padding is not data). */
int tlm_test_packets_equal(const tlm_packet_t *a, const tlm_packet_t *b);
/* Encode n frames (types cycling NAV, CAMERA x3, HK, EVENT) back to back
 * into out; returns the byte count (asserts it fits). */
size_t tlm_test_stream(tlm_encoder_t *enc, uint32_t n, uint8_t *out, size_t cap, tlm_packet_t *sent);

#endif
