/* uplink_auth.h -- mfns-ground's signing of telecommands (docs/uplink.md 1a):
 * with --tc-key FILE every command it sends, whatever its source (--cmd,
 * --cmd-file, --udp-tc, --tc-socket), leaves as a secured packet signed with
 * the first key of FILE (firmware/linux/tc_auth.h), its ARSN = epoch << 32 |
 * count, the count +1 per command.
 *
 * The ground trusts only what is authenticated. It learns the board's state
 * from the uplink report in housekeeping (hk_tc_*: epoch, last count,
 * challenge, state bits) only when the report's MAC verifies under its key
 * (tc_auth_report_verify); anything else -- forged, garbled, another key's
 * turn -- is ignored and counted, so forged housekeeping cannot steer what it
 * signs (a forged count of 4294967295 changes nothing).
 *
 * The epoch is the ground's to give: when the board asks (state bit
 * RESYNC_NEEDED: every start), reports another epoch than the one the ground
 * gave, or nears the end of its counts, the ground sends a
 * RE-SYNCHRONISATION (a NOOP MACed with the board's challenge, tc_auth.h)
 * for a new epoch = max(largest epoch it ever gave + 1, the board's floor +
 * 1, UTC seconds now), and persists it BEFORE the frame leaves (--tc-state
 * FILE: written atomically, the count too, before every signed command), so
 * an epoch or a count is never signed twice, whatever happens to the board.
 * Until then commands wait in their sources.
 *
 * --tc-epoch N signs for a known epoch without waiting (a command file
 * prepared offline): the operator vouches for N. Without --tc-key commands
 * leave plain, as before.
 */
#ifndef MFNS_GROUND_UPLINK_AUTH_H
#define MFNS_GROUND_UPLINK_AUTH_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "firmware/linux/tc_auth.h"
#include "firmware/tlm/tlm_packets.h"

#define UPLINK_AUTH_RESYNC_RETRY_MS 2000u /* a re-synchronisation unanswered this long is sent again */
#define UPLINK_AUTH_UTC_PLAUSIBLE 1577836800u /* 2020-01-01: a clock before it is not used as an epoch floor */

typedef struct {
    bool on;                 /* --tc-key given */
    tc_auth_key_t key;       /* the signing key (first of the file) */
    bool epoch_known;        /* commands may be signed now */
    uint32_t epoch;
    uint32_t next_count;     /* ARSN low 32 bits of the next command (>= 1) */
    uint32_t epoch_changes;  /* epochs given by re-synchronisation */
    const char *state_path;  /* --tc-state FILE, or NULL (only with --tc-epoch) */
    uint32_t max_epoch;      /* the largest epoch ever given or signed for (persisted) */
    bool resync_due;         /* a verified report asks for one: hook_poll sends it */
    uint64_t resync_nonce;   /* the challenge of that report */
    uint32_t resync_floor;   /* the board's floor in it */
    bool resync_sent;        /* one went up for resync_sent_nonce */
    uint64_t resync_sent_nonce;
    uint64_t resync_sent_ms;
    uint32_t n_resync;       /* re-synchronisations sent */
    uint32_t n_reports_ok, n_reports_ignored;
    bool ignored_said;
    bool state_failed_said;
} uplink_auth_t;

/* key_path NULL: off (plain commands). epoch 0: wait for the board's report.
 * state_path: --tc-state (needed when epoch is 0). 0, or -1 with one line in err. */
int uplink_auth_open(uplink_auth_t *a, const char *key_path, uint32_t epoch, const char *state_path, char *err,
                     size_t err_size);
/* true when commands may leave now (off, or the epoch is known). */
bool uplink_auth_ready(const uplink_auth_t *a);
/* The wire frame of cmd with sequence count seq: signed when on (the ARSN
 * count persisted and advanced), plain otherwise. */
tc_status_t uplink_auth_frame(uplink_auth_t *a, const tc_cmd_t *cmd, uint16_t seq, uint8_t *out, size_t cap,
                              size_t *out_len);
/* When a re-synchronisation is due: its frame (a NOOP bound to the board's
 * challenge, new epoch persisted first) with sequence count seq; TC_OK, or
 * TC_E_STATE when none is due (or the state cannot be written). */
tc_status_t uplink_auth_resync_frame(uplink_auth_t *a, uint16_t seq, uint64_t now_ms, uint8_t *out, size_t cap,
                                     size_t *out_len);
/* A housekeeping packet arrived: believe its uplink report only if it verifies. */
void uplink_auth_housekeeping(uplink_auth_t *a, const tlm_hk_t *hk, uint64_t now_ms);
void uplink_auth_close(uplink_auth_t *a);

#endif /* MFNS_GROUND_UPLINK_AUTH_H */
