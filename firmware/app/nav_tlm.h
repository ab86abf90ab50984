/* nav_tlm.h -- the flight program's telemetry side: turns navigation
 * results, camera state and counters into packets (firmware/tlm) and queues
 * their wire frames on the drop-oldest transmit queue. */
#ifndef MFNS_NAV_TLM_H
#define MFNS_NAV_TLM_H

#include <stdint.h>

#include "nav_cycle.h"
#include "tlm_packets.h"
#include "tlm_txq.h"

typedef struct {
    tlm_encoder_t enc;
    tlm_txq_t q;
    uint32_t encode_errors;
    uint32_t last_dropped_reported;
} nav_tlm_t;

void nav_tlm_init(nav_tlm_t *t);
/* Encode and queue one packet; returns 0 or a TLM_ERR_* code (counted). */
int nav_tlm_send(nav_tlm_t *t, tlm_packet_t *p);
/* The navigation solution packet of a cycle. A NO_FIX solution carries zeros
 * in every pose field: a stale or unconverged pose never reaches the ground. */
void nav_tlm_nav_packet(const mfns_nav_output_t *o, uint32_t cycle, uint64_t t_us, tlm_packet_t *p);
/* Telemetry mode of a navigation mode (ACQUIRE/TRACK). */
uint8_t nav_tlm_mode(mfns_nav_mode_t m);
/* Queue an event. */
int nav_tlm_event(nav_tlm_t *t, uint32_t cycle, uint64_t t_us, tlm_event_code_t code, tlm_severity_t sev,
                  uint8_t subject, int32_t arg0, int32_t arg1);

#endif /* MFNS_NAV_TLM_H */
