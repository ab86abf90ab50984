/* nav_cmd_dispatch.h -- the flight program's command dispatch: TC frames in
 * (firmware/tlm/tc_packets.h), the sequence guard, one call through a table
 * indexed by opcode, one event out per command. The program's commands
 * themselves are in nav_cmds.h; the dispatch is kept apart so that every
 * rejection is unit-tested with a table of fakes (tests/unit/test_nav_cmd.c).
 *
 * Every frame that ends (a delimiter after data, or an overflow) is one
 * command: it gets exactly one CMD_ACCEPTED or CMD_REJECTED event
 * (docs/uplink.md):
 *   CMD_ACCEPTED  subject = opcode, arg0 = sequence count, arg1 per opcode
 *   CMD_REJECTED  subject = opcode or 0 (unreadable), arg0 = sequence count or
 *                 -1 (unreadable), arg1 = tc_status_t (the reason)
 *
 * Authentication (ops->auth, tc_auth.h) comes first: a command that fails
 * it is CMD_REJECTED with its AUTH_* code and nothing else happens.
 *
 * Sequence guard (replay protection): the first command after boot may have
 * any count; later ones are accepted only when their count is newer than the
 * last accepted one, i.e. (seq - last) mod 2^14 in 1..8191. A replayed or
 * older count is TC_E_SEQUENCE. A command refused for its contents or the
 * state does not move the reference, so it can be sent again once fixed.
 *
 * The table: table[opcode] (tc_opcode_t) is the command's function; an
 * opcode of 0 or past the table is TC_E_OPCODE (the decoder refuses those
 * first), a NULL entry TC_E_STATE (this program has no action for it).
 * RESET_COUNTERS also zeroes the dispatch's own counters and is not counted.
 *
 * Bounded: nav_cmd_feed stops after max_cmds commands, so a flood of frames
 * (or garbage) costs a cycle at most that many calls; the bytes left are fed
 * on the next cycle. Nothing here blocks or allocates.
 */
#ifndef MFNS_NAV_CMD_DISPATCH_H
#define MFNS_NAV_CMD_DISPATCH_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "firmware/tlm/ccsds.h"
#include "firmware/tlm/tc_packets.h"
#include "firmware/tlm/tlm_packets.h"

#define NAV_CMD_MAX_PER_CYCLE 4u /* commands handled between two cycles */
#define NAV_CMD_SEQ_WINDOW 8191u /* counts ahead of the last accepted that are "newer" */
_Static_assert(NAV_CMD_SEQ_WINDOW == TLM_CCSDS_SEQ_MASK / 2u,
               "newer = (seq - last) mod 2^14 in 1..8191: half the sequence space ahead");

/* One command's action: TC_OK, or the tc_status_t to refuse with
 * (TC_E_STATE, TC_E_ARG, TC_E_TABLE, ...); may set *arg1 (the CMD_ACCEPTED
 * event's arg1). cmd holds the decoded arguments (cmd->u per opcode). */
typedef tc_status_t (*nav_cmd_fn_t)(void *ctx, const tc_cmd_t *cmd, int32_t *arg1);
/* Authentication of a decoded command (firmware/linux/tc_auth.h): TC_OK or
 * an AUTH_* code. Called before the sequence guard and the action, so an
 * unauthenticated command neither acts nor moves the sequence reference. */
typedef tc_status_t (*nav_cmd_auth_fn_t)(void *ctx, const tc_cmd_t *cmd);
/* How the dispatch's events leave (the program: telemetry and one stderr line). */
typedef void (*nav_cmd_event_fn_t)(void *ctx, tlm_event_code_t code, tlm_severity_t sev, uint8_t subject,
                                   int32_t arg0, int32_t arg1);

typedef struct {
    void *ctx;                  /* passed to every call */
    const nav_cmd_fn_t *table;  /* indexed by opcode */
    size_t table_len;           /* entries in table */
    nav_cmd_event_fn_t event;   /* required */
    nav_cmd_auth_fn_t auth;     /* NULL: no authentication (unit tests of the dispatch alone) */
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
 * sequence, calls the opcode's function, and sends its event. Exposed for
 * tests. */
void nav_cmd_handle(nav_cmd_t *c, const tc_cmd_t *cmd, tc_status_t status, const nav_cmd_ops_t *ops);

/* RESET_COUNTERS' effect on the dispatch's own counters. */
void nav_cmd_reset_counters(nav_cmd_t *c);

/* A new uplink session: an authenticated re-synchronisation to a fresh epoch
 * (tc_auth.h) was just accepted. The sequence guard starts again, as at boot:
 * a new ground process numbers its packets from its own start (measured on the
 * emulated board: an upload after the first ground's commands was refused
 * SEQUENCE), and replay within the new epoch is the anti-replay count's to
 * refuse. An old re-synchronisation replayed fails authentication, so it
 * cannot reset the guard. */
void nav_cmd_new_session(nav_cmd_t *c);

#endif /* MFNS_NAV_CMD_DISPATCH_H */
