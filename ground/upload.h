/* upload.h -- mfns-ground --upload FILE: a file (a calibration table) sent
 * to the board over the authenticated uplink (docs/uplink.md 5a) as
 * UPLOAD_START, UPLOAD_DATA segments and UPLOAD_END, each an ordinary
 * command (signed, numbered, logged by uplink.c); the board's answers
 * (CMD_ACCEPTED / CMD_REJECTED events, matched by opcode and sequence count)
 * drive it. The flight side is firmware/app/nav_cmds_upload.h.
 *
 * The link: at most UPLOAD_WINDOW segments unanswered (the board handles 4
 * commands a cycle and keeps the rest of the bytes for the next cycles, so
 * the window paces the sender at the board's rate). CMD_ACCEPTED of a
 * segment carries the board's next expected offset; a segment refused with
 * UPLOAD_GAP (one before it was lost) sends again from the highest such
 * offset (go-back-N, once per loss: the refusals of the segments already in
 * flight behind it are ignored). No answer for UPLOAD_ANSWER_MS: START is
 * sent again, which resumes the board's open upload and answers its next
 * expected offset; UPLOAD_TRIES such rounds without progress end the upload.
 * Any other refusal ends it with that code, named (tc_status_name).
 * A run that ends before the answer to UPLOAD_END (Ctrl-C, --max-seconds,
 * the link gone) sends UPLOAD_ABORT: the board drops the upload, nothing is
 * stored (a ground that dies without it leaves the upload open on the board:
 * the same --upload resumes it, or the board abandons it after 10 min).
 */
#ifndef MFNS_GROUND_UPLOAD_H
#define MFNS_GROUND_UPLOAD_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "firmware/tlm/tc_packets.h"
#include "firmware/tlm/tlm_packets.h"

#define UPLOAD_FILE_MAX (1u << 20) /* bytes the ground reads; the board's own limit answers UPLOAD_SIZE */
#define UPLOAD_QUEUED_MAX 4u       /* frames waiting in the uplink queue before more are made (it drops the oldest) */
#define UPLOAD_WINDOW 12u          /* segments sent and not yet answered, at most */
#define UPLOAD_ANSWER_MS 3000u     /* no answer this long: ask the board where it is (START again) */
#define UPLOAD_TRIES 5u            /* such rounds without progress before giving up */

typedef enum { UPLOAD_OFF = 0, UPLOAD_START, UPLOAD_DATA, UPLOAD_END, UPLOAD_OK, UPLOAD_FAILED } upload_phase_t;

typedef struct {
    bool live;
    uint16_t seq;
    uint32_t offset;
    uint32_t gen; /* the go-back round it was sent in */
} upload_slot_t;

typedef struct {
    upload_phase_t phase;
    const char *path;
    uint8_t *buf;                   /* the file (caller's buffer of UPLOAD_FILE_MAX bytes) */
    uint32_t size, crc32;
    char name[TC_UPLOAD_NAME_MAX];
    uint32_t acked;                 /* the board's next expected offset, the highest reported */
    uint32_t send_off;              /* the next segment's offset */
    uint32_t sent_end;              /* the furthest byte sent so far (a segment below it is re-sent) */
    uint32_t gen;
    upload_slot_t slot[UPLOAD_WINDOW];
    unsigned n_inflight;
    bool ctl_wait;                  /* a START or END waits for its answer */
    uint16_t ctl_seq;
    uint64_t last_news_ms;          /* the last answer (or the first send) */
    uint64_t t_start_ms, t_done_ms;
    unsigned tries;
    int reject;                     /* the refusal's tc_status_t, 0: none (or no answer) */
    uint32_t table_crc;             /* UPLOAD_END's answer: the table now flying */
    uint32_t n_data, n_resent, n_gaps, n_restarts;
    bool aborted;                   /* the run ended first: UPLOAD_ABORT sent */
} ground_upload_t;

/* Reads path into buf (cap bytes), its CRC-32 and its name (the base name,
 * cut to 31 characters, other characters than [A-Za-z0-9._-] as '_').
 * 0, or -1 with a message in err. */
int ground_upload_open(ground_upload_t *g, const char *path, uint8_t *buf, size_t cap, char *err, size_t err_size);
/* The next command to send now (true, *cmd filled), or false. */
bool ground_upload_next(ground_upload_t *g, uint64_t now_ms, tc_cmd_t *cmd);
/* The command ground_upload_next gave went up with sequence count seq. */
void ground_upload_sent(ground_upload_t *g, const tc_cmd_t *cmd, uint16_t seq, uint64_t now_ms);
/* Every event packet received (others are ignored). */
void ground_upload_event(ground_upload_t *g, const tlm_event_t *e, uint64_t now_ms);
bool ground_upload_finished(const ground_upload_t *g);
/* The run ends unfinished: true with *cmd the UPLOAD_ABORT to send when
 * something was sent (then the upload counts as aborted). */
bool ground_upload_abort(ground_upload_t *g, uint64_t now_ms, tc_cmd_t *cmd);

#endif /* MFNS_GROUND_UPLOAD_H */
