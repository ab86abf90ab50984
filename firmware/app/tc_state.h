/* tc_state.h -- the flight side's persisted uplink state: the boot epoch of
 * the anti-replay counter (tc_auth.h), in STATE_DIR/tc_epoch (--state-dir).
 *
 * Once at start-up, never in the cycle: read the last epoch (a missing file
 * is epoch 0), add one, and write it atomically (a temporary file, fsync,
 * rename over the old one, fsync of the directory), so that a power cut
 * leaves the old or the new epoch, never a torn one. A command signed for an
 * earlier boot then carries an old epoch and is refused (AUTH_STALE_EPOCH),
 * whatever its count. A file that does not parse is refused (never reset to
 * 0: that would make every old command valid again); so is a full counter.
 *
 * What it misses: a state directory restored from a backup, or one the
 * attacker can write, brings old epochs back (keep it 0700, on the board).
 */
#ifndef MFNS_APP_TC_STATE_H
#define MFNS_APP_TC_STATE_H

#include <stddef.h>
#include <stdint.h>

#define TC_STATE_FILE "tc_epoch"

/* Advance the epoch in dir: *epoch gets the new one (>= 1). 0, or -1 with
 * one line in err. */
int tc_state_next_epoch(const char *dir, uint32_t *epoch, char *err, size_t err_size);

#endif /* MFNS_APP_TC_STATE_H */
