/* nav_cmds_upload.h -- the file-upload telecommands' actions in mfns-nav
 * (docs/uplink.md 5a): UPLOAD_START, UPLOAD_DATA, UPLOAD_END, UPLOAD_ABORT
 * feed the receiver (nav_upload.h) with the decoded arguments of commands the
 * dispatch has already authenticated (tc_auth) and sequence-checked, like
 * every other command; they sit in nav_cmds.c's opcode table.
 *
 * Answers: CMD_ACCEPTED arg1 is the next expected offset after START, DATA
 * (a re-sent segment and a resuming START included) and 0 after ABORT; after
 * END it is the new table's CRC-32 (as TABLE_LOAD). A refusal is CMD_REJECTED
 * with the upload's reason as its tc_status_t code (TC_E_UPLOAD_*, named by
 * the dictionary): GAP tells the ground to go back to the next expected
 * offset (the last CMD_ACCEPTED arg1 it saw, or a re-sent START's);
 * TC_E_TABLE when the table loader refuses the received file (the old table
 * flies on; TABLE_REFUSED event with the loader's reason).
 *
 * UPLOAD_END, after size and CRC-32 are right: the loader validates the
 * bytes in RAM, they are written atomically to STATE_DIR/upload.mfnstbl
 * (nav_upload_store) and that file is loaded by nav_cmds.c's TABLE_LOAD path (re-bind or swap between cycles, the table store's commit);
 * without --state-dir nothing is stored (TC_E_UPLOAD_STORE). Once the load has answered,
 * loaded or refused, upload.mfnstbl is removed (the table store keeps its own copy).
 */
#ifndef MFNS_NAV_CMDS_UPLOAD_H
#define MFNS_NAV_CMDS_UPLOAD_H

#include <stddef.h>
#include <stdint.h>

#include "firmware/tlm/tc_packets.h"

struct nav_app; /* nav_app_state.h */

tc_status_t cmd_UPLOAD_START(void *ctx, const tc_cmd_t *cmd, int32_t *arg1);
tc_status_t cmd_UPLOAD_DATA(void *ctx, const tc_cmd_t *cmd, int32_t *arg1);
/* UPLOAD_END up to the load: size and CRC checked, the table validated in
 * RAM, stored as STATE_DIR/upload.mfnstbl, whose path goes to path. TC_OK:
 * the caller (nav_cmds.c cmd_UPLOAD_END) loads path by the TABLE_LOAD path. */
tc_status_t nav_cmds_upload_end(struct nav_app *app, char *path, size_t path_len);
tc_status_t cmd_UPLOAD_ABORT(void *ctx, const tc_cmd_t *cmd, int32_t *arg1);

/* Once per cycle (and per tick while waiting for a table): an upload idle
 * past its timeout is abandoned, said once on stderr. */
void nav_cmds_upload_tick(struct nav_app *app, uint64_t now_ms);

/* The receiver's outcome as the command's answer code (TC_OK for OK,
 * DUPLICATE, RESUMED). */
tc_status_t nav_cmds_upload_status(int upload_status);

#endif /* MFNS_NAV_CMDS_UPLOAD_H */
