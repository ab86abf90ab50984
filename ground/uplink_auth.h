/* uplink_auth.h -- mfns-ground's signing of telecommands (docs/uplink.md 1a):
 * with --tc-key FILE every command it sends, whatever its source (--cmd,
 * --cmd-file, --udp-tc, --tc-socket), leaves as a secured packet signed with
 * the first key of FILE (firmware/linux/tc_auth.h), its ARSN = epoch << 32 |
 * count, the count +1 per command.
 *
 * The epoch is the board's boot epoch: given (--tc-epoch N, e.g. to prepare
 * a command file offline) or learned from housekeeping (hk tc_epoch,
 * tc_arsn_last: not secret). Until it is known, commands wait in their
 * sources (nothing is signed for a guessed epoch). Housekeeping always wins:
 * a new epoch (the board rebooted) is taken with its count, and a count the
 * board has seen beyond ours (another ground, a ground restart) moves ours
 * past it. Without --tc-key commands leave plain, as before.
 */
#ifndef MFNS_GROUND_UPLINK_AUTH_H
#define MFNS_GROUND_UPLINK_AUTH_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "firmware/linux/tc_auth.h"
#include "firmware/tlm/tlm_packets.h"

typedef struct {
    bool on;                 /* --tc-key given */
    tc_auth_key_t key;       /* the signing key (first of the file) */
    bool epoch_known;
    uint32_t epoch;
    uint32_t next_count;     /* ARSN low 32 bits of the next command (>= 1) */
    uint32_t epoch_changes;  /* epochs learned from housekeeping */
} uplink_auth_t;

/* key_path NULL: off (plain commands). epoch 0: learn it from housekeeping.
 * 0, or -1 with one line in err. */
int uplink_auth_open(uplink_auth_t *a, const char *key_path, uint32_t epoch, char *err, size_t err_size);
/* true when commands may leave now (off, or the epoch is known). */
bool uplink_auth_ready(const uplink_auth_t *a);
/* The wire frame of cmd with sequence count seq: signed when on (and the
 * ARSN count advanced), plain otherwise. */
tc_status_t uplink_auth_frame(uplink_auth_t *a, const tc_cmd_t *cmd, uint16_t seq, uint8_t *out, size_t cap,
                              size_t *out_len);
/* A housekeeping packet arrived: learn the epoch and the board's count. */
void uplink_auth_housekeeping(uplink_auth_t *a, const tlm_hk_t *hk);
void uplink_auth_close(uplink_auth_t *a);

#endif /* MFNS_GROUND_UPLINK_AUTH_H */
