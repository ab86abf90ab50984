/* time_corr.h -- the ground's UTC for every packet: the flight's time
 * correlation (housekeeping's hk_utc_s/us paired with its own flight time,
 * firmware/app/nav_time.h), else correlation at receipt.
 *
 * A packet's UTC is its flight time plus the offset of the latest
 * housekeeping pair whose quality is SYSTEM or SYNCED (source FLIGHT_SYSTEM or
 * FLIGHT_SYNCED). Before the first such pair, or when the board has no UTC
 * (quality NONE), the offset is fixed at the first packet received: its
 * receipt time minus its flight time (source GROUND_RECEIPT: off by the
 * link's latency and, for a recording read at full speed, by however fast it
 * is read). A flight clock that goes back (a reboot: the flight clock starts
 * again) drops the flight pair until the next housekeeping and re-anchors
 * the receipt correlation at that packet. Pure bookkeeping, unit-tested. */
#ifndef MFNS_TIME_CORR_H
#define MFNS_TIME_CORR_H

#include <stdint.h>

#include "firmware/tlm/tlm_packets.h"

typedef enum {
    TIME_SRC_GROUND_RECEIPT = 0,
    TIME_SRC_FLIGHT_SYSTEM,
    TIME_SRC_FLIGHT_SYNCED,
} time_src_t;

typedef struct {
    int have_flight;           /* a flight pair is in use */
    int64_t flight_offset_us;  /* UTC - flight time, from the latest pair */
    time_src_t flight_src;
    int have_receipt;
    int64_t receipt_offset_us; /* receipt UTC - flight time, at the anchor packet */
    uint64_t last_flight_us;   /* the last packet's flight time (a reboot goes back) */
} time_corr_t;

void time_corr_init(time_corr_t *c);
/* The packet's flight time in microseconds. */
uint64_t time_corr_flight_us(const tlm_packet_t *p);
/* Feed one packet (in arrival order) received at rx_utc_us; returns its UTC
 * (microseconds since 1970) and, in *src, where that came from. */
int64_t time_corr_packet(time_corr_t *c, const tlm_packet_t *p, int64_t rx_utc_us, time_src_t *src);
const char *time_corr_src_name(time_src_t s);

#endif /* MFNS_TIME_CORR_H */
