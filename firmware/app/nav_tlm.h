/* nav_tlm.h -- the flight program's telemetry room: the drop-oldest transmit
 * queue every packet mfns-nav sends waits in, the link they leave by
 * (drivers/uart, which only moves bytes; the queue is emptied into it by
 * txq_drain.h), and the packets of the navigator's output (nav packet,
 * integrity events). Each other packet is built by the room that owns its
 * data and queued here: CAMERA by nav_cams.h, housekeeping by
 * nav_app_state.h. This room includes neither (issue 41: no circle).
 *
 * Packets (docs/telemetry.md): the navigation solution of every cycle (a
 * NO_FIX solution carries zeros in every pose field: a stale or unconverged
 * pose never reaches the ground), one diagnostics packet per camera and
 * cycle, housekeeping once per second of frame time and at the end, events
 * as they happen. Each is encoded into one wire frame and queued; a full
 * queue drops its oldest frames (counted; the next housekeeping is followed
 * by a TLM_DROPPED event), so sending never blocks the loop.
 *
 * The link: --serial (libserialport), --tty (tty, pty or FIFO) or --file
 * (created or truncated). A port or FIFO absent at start is not fatal: the
 * transport re-opens it at its retry cadence, exactly as after a link lost
 * later; frames wait in the queue. With no link the queue is emptied each
 * cycle as a disconnected UART would. Write errors are counted, reported
 * once on stderr and once as a TLM_WRITE_ERROR event (again after the link
 * recovered); nav_tlm_t.write_errors > 0 makes the program exit 3.
 */
#ifndef MFNS_NAV_TLM_H
#define MFNS_NAV_TLM_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/nav/cycle/nav_cycle.h"
#include "firmware/app/nav_opts.h"
#include "firmware/tlm/tlm_packets.h"
#include "firmware/tlm/tlm_txq.h"
#include "drivers/uart/uart.h"

_Static_assert(MFNS_NUM_CAMERAS <= 8, "cams_used and cams_enabled are one bit per camera in a u8");

typedef struct {
    tlm_encoder_t enc;
    tlm_txq_t q;
    uint32_t encode_errors;
    uint32_t last_dropped_reported;
    /* the link */
    nav_tlm_kind_t kind;
    const char *target;         /* its name for messages (the option's argument) */
    mfns_uart_t uart;           /* also the uplink's input with --uplink */
    uint32_t write_errors;
    bool write_error_printed;
    bool in_error;              /* the last drain failed with a write error */
} nav_tlm_t;

void nav_tlm_init(nav_tlm_t *t);
/* Opens the link o asks for (nothing for NAV_TLM_NONE). 0, or -1 after one
 * stderr line: a file that cannot be created, a port that refuses its
 * configuration, --uplink on a FIFO. */
int nav_tlm_open(nav_tlm_t *t, const nav_opts_t *o);
/* Moves what the link takes now from the queue (never waits); write errors
 * as above, the event stamped with cycle. */
void nav_tlm_drain(nav_tlm_t *t, uint32_t cycle, uint64_t now_ms);
/* At exit: drains for up to 2 s while frames are queued, then closes the link. */
void nav_tlm_flush_and_close(nav_tlm_t *t, uint32_t cycle);

/* Encode and queue one packet; returns 0 or a TLM_ERR_* code (counted). */
int nav_tlm_send(nav_tlm_t *t, tlm_packet_t *p);
/* Queue an event. */
int nav_tlm_event(nav_tlm_t *t, uint32_t cycle, uint64_t t_us, tlm_event_code_t code, tlm_severity_t sev,
                  uint8_t subject, int32_t arg0, int32_t arg1);
/* The navigation solution packet of a cycle (see above for NO_FIX). */
void nav_tlm_nav_packet(const mfns_nav_output_t *o, uint32_t cycle, uint64_t t_us, tlm_packet_t *p);
/* The integrity events of a cycle's output (BEACON_EXCLUDED, CAMERA_EXCLUDED
 * once per exclusion episode, *_READMITTED), beacon subjects as survey ids. */
void nav_tlm_integrity_events(nav_tlm_t *t, const mfns_nav_output_t *o, const mfns_beacon_map_t *map,
                              uint16_t hold_cycles, uint32_t cycle, uint64_t t_us);
/* Telemetry mode of a navigation mode (ACQUIRE/TRACK). */
uint8_t nav_tlm_mode(mfns_nav_mode_t m);

#endif /* MFNS_NAV_TLM_H */
