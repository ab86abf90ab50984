/* time_corr.c -- see time_corr.h. */
#include "ground/time_corr.h"

#include <string.h>

#include "firmware/tlm/generated/tlm_codes_gen.h"

/* a flight clock that goes back by more than this is a restart (telemetry of
 * one boot arrives in time order; a shuffle within a second is not a reboot) */
#define TIME_CORR_REBOOT_BACK_US 1000000u

void time_corr_init(time_corr_t *c)
{
    memset(c, 0, sizeof *c);
}

uint64_t time_corr_flight_us(const tlm_packet_t *p)
{
    return (uint64_t)p->time.coarse_s * 1000000u + (((uint64_t)p->time.fine * 1000000u + 32768u) >> 16);
}

int64_t time_corr_packet(time_corr_t *c, const tlm_packet_t *p, int64_t rx_utc_us, time_src_t *src)
{
    const uint64_t t = time_corr_flight_us(p);
    if (c->have_receipt && t + TIME_CORR_REBOOT_BACK_US < c->last_flight_us) {
        c->have_flight = 0; /* a new boot: its clock restarted */
        c->have_receipt = 0;
    }
    c->last_flight_us = t;
    if (!c->have_receipt) {
        c->have_receipt = 1;
        c->receipt_offset_us = rx_utc_us - (int64_t)t;
    }
    if (p->type == TLM_TYPE_HK && p->u.hk.time_quality != TLM_TIMEQ_NONE && p->u.hk.utc_us < 1000000u) {
        const int64_t utc = (int64_t)p->u.hk.utc_s * 1000000 + (int64_t)p->u.hk.utc_us;
        c->have_flight = 1;
        c->flight_offset_us = utc - (int64_t)t;
        c->flight_src = p->u.hk.time_quality == TLM_TIMEQ_SYNCED ? TIME_SRC_FLIGHT_SYNCED : TIME_SRC_FLIGHT_SYSTEM;
    }
    if (c->have_flight) {
        *src = c->flight_src;
        return (int64_t)t + c->flight_offset_us;
    }
    *src = TIME_SRC_GROUND_RECEIPT;
    return (int64_t)t + c->receipt_offset_us;
}

const char *time_corr_src_name(time_src_t s)
{
    switch (s) {
    case TIME_SRC_GROUND_RECEIPT: return "GROUND_RECEIPT";
    case TIME_SRC_FLIGHT_SYSTEM: return "FLIGHT_SYSTEM";
    case TIME_SRC_FLIGHT_SYNCED: return "FLIGHT_SYNCED";
    default: return "?";
    }
}
