/* nav_cmds.h -- what each telecommand does in mfns-nav (docs/uplink.md):
 * one function per opcode, in a table indexed by tc_opcode_t that the
 * dispatch (nav_cmd_dispatch.h) calls after the sequence guard. Each runs
 * between cycles, so no cycle ever sees a command half done.
 *
 * One function cmd_<NAME> per opcode of the dictionary (TC_OPCODE_LIST):
 *
 *   NOOP            nothing; accepted
 *   RESET_COUNTERS  camera error count to 0 (the dispatch zeroes its own)
 *   SET_MODE        STANDBY (frames flow, the navigator does not run),
 *                   ACQUIRE (drop the track), TRACK (from the current prior;
 *                   TC_E_STATE without one); a MODE_CHANGE event on a change
 *   SET_POSE_HINT   a prior for the next cycles, verified there like any
 *                   other, never a fix by itself; TC_E_ARG when refused
 *   CAMERA_ENABLE / CAMERA_DISABLE
 *                   fuse / stop fusing a camera's frames; arg1 = the mask
 *   TABLE_LOAD      read and validate into the spare table slot, then bind
 *                   the navigator to it; on any failure the old table stays
 *                   (TABLE_REFUSED event, TC_E_TABLE); arg1 = the new crc
 *   UPLOAD_START / UPLOAD_DATA / UPLOAD_END / UPLOAD_ABORT
 *                   a table over the link (nav_cmds_upload.h): END loads the
 *                   stored file through the TABLE_LOAD path (table_load)
 *
 * Every command's outcome is also one stderr line (nav_cmds_ops' event).
 */
#ifndef MFNS_NAV_CMDS_H
#define MFNS_NAV_CMDS_H

#include "firmware/app/nav_cmd_dispatch.h"

struct nav_app; /* nav_app.h */

/* The dispatch's view of the program: the command table and the event
 * hook, acting on app. */
nav_cmd_ops_t nav_cmds_ops(struct nav_app *app);
/* The same while waiting for a first table (nav_app.h): NOOP, RESET_COUNTERS
 * and TABLE_LOAD (which then validates, stores and hands the table to the
 * start-up); every other command refused with TC_E_STATE. */
nav_cmd_ops_t nav_cmds_ops_waiting(struct nav_app *app);

#endif /* MFNS_NAV_CMDS_H */
