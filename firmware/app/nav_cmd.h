/* nav_cmd.h -- the flight program's command handler: TC frames in
 * (firmware/tlm/tc_packets.h), one event out per command, actions through
 * the program's hooks. Kept apart from nav_app.c so that every opcode and
 * every rejection is unit-tested without cameras (tests/unit/test_nav_cmd.c).
 *
 * Every frame that ends (a delimiter after data, or an overflow) is one
 * command: it gets exactly one CMD_ACCEPTED or CMD_REJECTED event
 * (docs/uplink.md):
 *   CMD_ACCEPTED  subject = opcode, arg0 = sequence count, arg1 per opcode
 *   CMD_REJECTED  subject = opcode or 0 (unreadable), arg0 = sequence count or
 *                 -1 (unreadable), arg1 = tc_status_t (the reason)
 *
 * Sequence guard (replay protection): the first command after boot may have
 * any count; later ones are accepted only when their count is newer than the
 * last accepted one, i.e. (seq - last) mod 2^14 in 1..8191. A replayed or
 * older count is TC_E_SEQUENCE. A command refused for its contents or the
 * state does not move the reference, so it can be sent again once fixed.
 *
 * Bounded: nav_cmd_feed stops after max_cmds commands, so a flood of frames
 * (or garbage) costs a cycle at most that many handler calls; the bytes left
 * are fed on the next cycle. Nothing here blocks or allocates.
 */
#ifndef MFNS_NAV_CMD_H
#define MFNS_NAV_CMD_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "tc_packets.h"
#include "tlm_packets.h"

#define NAV_CMD_MAX_PER_CYCLE 4u /* commands handled between two cycles */
#define NAV_CMD_SEQ_WINDOW 8191u /* counts ahead of the last accepted that are "newer" */

/* What the program does for a command. Each action returns TC_OK or the
 * tc_status_t to refuse with (TC_E_STATE, TC_E_TABLE, ...) and may set
 * *arg1 (the event's arg1 on acceptance). */
typedef struct {
    void *ctx;
    tc_status_t (*set_mode)(void *ctx, uint8_t mode, int32_t *arg1);
    tc_status_t (*set_pose_hint)(void *ctx, const tc_pose_hint_t *hint, int32_t *arg1);
    tc_status_t (*camera_enable)(void *ctx, uint8_t camera, bool enable, int32_t *arg1);
    tc_status_t (*table_load)(void *ctx, const char *path, int32_t *arg1);
    void (*reset_counters)(void *ctx);
    void (*event)(void *ctx, tlm_event_code_t code, tlm_severity_t sev, uint8_t subject, int32_t arg0, int32_t arg1);
} nav_cmd_ops_t;

typedef struct {
    tc_deframer_t rx;
    bool have_last;     /* a command was accepted since boot */
    uint16_t seq_last;  /* its sequence count */
    uint32_t n_accepted;
    uint32_t n_rejected;
    tc_status_t last_status; /* of the last command */
} nav_cmd_t;

void nav_cmd_init(nav_cmd_t *c);

/* Feed up to n received bytes; handles at most max_cmds commands. Returns
 * the number of bytes consumed (< n when it stopped at max_cmds); *handled
 * (nullable) gets the commands handled. */
size_t nav_cmd_feed(nav_cmd_t *c, const uint8_t *data, size_t n, unsigned max_cmds, const nav_cmd_ops_t *ops,
                    unsigned *handled);

/* One decoded frame's outcome (status from the deframer): checks the
 * sequence, acts, and sends its event. Exposed for tests. */
void nav_cmd_handle(nav_cmd_t *c, const tc_cmd_t *cmd, tc_status_t status, const nav_cmd_ops_t *ops);

/* RESET_COUNTERS' effect on the handler's own counters. */
void nav_cmd_reset_counters(nav_cmd_t *c);

#endif /* MFNS_NAV_CMD_H */
