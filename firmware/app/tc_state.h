/* tc_state.h -- the flight side's persisted uplink state: the last command
 * epoch (tc_auth.h), in STATE_DIR/tc_epoch (--state-dir).
 *
 * Writes are atomic (a temporary file, fsync, rename over the old one, fsync
 * of the directory): a power cut leaves the old or the new epoch, never a
 * torn one. Start-up only, and after a re-synchronisation; never per command
 * and never in the cycle.
 *
 * Two uses (docs/uplink.md 1a "Epochs that never repeat"):
 * - a live uplink: the stored epoch is only a FLOOR (a re-synchronisation's
 *   epoch must exceed it); the epoch itself comes from the ground, so a lost,
 *   damaged, restored or read-only state costs nothing in safety. A fault is
 *   classified (tc_state_probe) and reported, never fatal.
 * - a recorded command file (--tc-file, no dialogue with a ground):
 *   tc_state_next_epoch, the local counter (+1 at every start). It cannot
 *   tell a restored backup from the real state: that mode is for the bench.
 * A file that does not parse is never read as 0 (that would make old
 * commands valid again): it is "damaged".
 */
#ifndef MFNS_APP_TC_STATE_H
#define MFNS_APP_TC_STATE_H

#include <stddef.h>
#include <stdint.h>

#define TC_STATE_FILE "tc_epoch"

typedef enum {
    TC_STATE_OK = 0,
    TC_STATE_MISSING = 1,     /* no file (a first start, or a wiped directory), or no directory */
    TC_STATE_DAMAGED = 2,     /* not a regular small file reading 'epoch N' */
    TC_STATE_UNWRITABLE = 3,  /* read-only, full, or the path is not a directory */
} tc_state_fault_t;

/* Reads the stored epoch (0 when missing or damaged). Returns the fault;
 * *err_no the errno that said so (0 none); one line in err. */
tc_state_fault_t tc_state_read(const char *dir, uint32_t *epoch, int *err_no, char *err, size_t err_size);
/* Writes epoch atomically. 0, or the errno (one line in err). */
int tc_state_write(const char *dir, uint32_t epoch, char *err, size_t err_size);
/* Whether dir takes a write now (a temporary file created, synced, removed). 0 or the errno. */
int tc_state_probe_write(const char *dir);

/* Recorded-file mode: read, +1, write (a missing file in a usable directory is
 * epoch 0; any other fault refuses). 0, or -1 with one line in err. */
int tc_state_next_epoch(const char *dir, uint32_t *epoch, char *err, size_t err_size);

#endif /* MFNS_APP_TC_STATE_H */
