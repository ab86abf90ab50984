/* nav_upload.h -- receiving a file (a calibration table) over the
 * authenticated uplink in segments (issue 44 item 5; docs/uplink.md
 * "File upload"). The receiver only: it is fed already authenticated,
 * sequence-checked commands' decoded arguments by the command actions and
 * knows nothing of frames or keys.
 *
 * The exchange (ground -> board):
 *   START  size, crc32 of the whole file, name   opens an upload
 *   DATA   offset, 1..NAV_UPLOAD_SEG_MAX bytes   one segment
 *   END                                          size and CRC checked
 *   ABORT                                        drops the upload
 * After every call nav_upload_next() is the next expected offset: the board
 * reports it (the command's CMD_ACCEPTED / CMD_REJECTED arg, housekeeping)
 * and the ground resumes from it.
 *
 * Segments: in order (offset == next) are appended; a duplicate (entirely
 * below next, e.g. a segment re-sent after a lost answer) is accepted and
 * changes nothing when its bytes equal the received ones, refused
 * (NAV_UP_E_CONFLICT, upload kept) when they differ; one overlapping next
 * appends its new tail (same check on the overlap); one past next (a gap:
 * a lost segment) is refused with NAV_UP_E_GAP and the upload is kept, so
 * the ground goes back to next (go-back-N). Past the declared size:
 * NAV_UP_E_OVERRUN.
 *
 * Resume and abandon: a START with the same size, CRC and name as the open
 * upload resumes it (next is kept); a different START abandons the open
 * upload and begins again; ABORT abandons it; nav_upload_tick() abandons it
 * after timeout_ms without a command (NAV_UP_E_TIMEOUT, reported once).
 *
 * Bounded: one call copies at most NAV_UPLOAD_SEG_MAX bytes and sums the CRC
 * over them (the running CRC covers the bytes in order, so END costs O(1));
 * the dispatch handles at most NAV_CMD_MAX_PER_CYCLE commands per cycle, so
 * an upload costs a cycle at most 4 segments. No heap: the caller gives the
 * receive buffer (cap bytes, at most MFNS_CALTABLE_MAX_BYTES is the use).
 *
 * After END (NAV_UPLOAD_COMPLETE) the caller validates the bytes with the
 * table loader (nav_upload_validate), stores them atomically
 * (nav_upload_store: temp, fsync, rename, fsync of the directory) and
 * loads them by the TABLE_LOAD path; the upload is then closed.
 * Misses: the CRC-32 guards against corruption, not against an attacker
 * (the uplink's HMAC does that per command); an upload survives no restart
 * of the program (the receive buffer is RAM).
 */
#ifndef MFNS_NAV_UPLOAD_H
#define MFNS_NAV_UPLOAD_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "firmware/nav/table/caltable.h"

#define NAV_UPLOAD_SEG_MAX 200u          /* bytes of file per DATA segment */
#define NAV_UPLOAD_NAME_MAX 32u          /* name buffer incl. NUL: [A-Za-z0-9._-], 1..31, no leading '.' */
#define NAV_UPLOAD_TIMEOUT_MS 600000u    /* default: an upload idle 10 min is abandoned */
#define NAV_UPLOAD_FILE "upload.mfnstbl" /* stored in the state dir, then loaded */
#define NAV_UPLOAD_TMP "upload.tmp"
_Static_assert(NAV_UPLOAD_SEG_MAX > 0u && NAV_UPLOAD_SEG_MAX <= 255u, "a segment's length fits one byte");

typedef enum {
    NAV_UP_OK = 0,
    NAV_UP_DUPLICATE,   /* accepted, nothing changed (a re-sent segment) */
    NAV_UP_RESUMED,     /* START of the open upload: next kept */
    NAV_UP_E_STATE,     /* DATA / END / ABORT with no upload open */
    NAV_UP_E_SIZE,      /* declared size 0 or past the receive buffer */
    NAV_UP_E_NAME,      /* empty, too long, or a character outside [A-Za-z0-9._-] */
    NAV_UP_E_LENGTH,    /* segment of 0 or more than NAV_UPLOAD_SEG_MAX bytes */
    NAV_UP_E_GAP,       /* offset past the next expected (a segment lost): send from next */
    NAV_UP_E_OVERRUN,   /* segment ends past the declared size */
    NAV_UP_E_CONFLICT,  /* re-sent bytes differ from the ones received */
    NAV_UP_E_INCOMPLETE,/* END before every byte arrived */
    NAV_UP_E_CRC,       /* END: the CRC-32 of the file differs from START's (upload dropped) */
    NAV_UP_E_TIMEOUT,   /* abandoned: no command for timeout_ms */
    NAV_UP_E_TABLE,     /* the table loader refused the bytes (upload dropped) */
    NAV_UP_E_STORE,     /* writing the file failed */
    NAV_UP_STATUS_COUNT
} nav_upload_status_t;

typedef enum {
    NAV_UPLOAD_IDLE = 0,
    NAV_UPLOAD_RECEIVING,
    NAV_UPLOAD_COMPLETE, /* size and CRC checked: validate, store and load */
} nav_upload_state_t;

typedef struct {
    uint8_t *buf;        /* the caller's receive buffer */
    uint32_t cap;        /* its size */
    uint32_t timeout_ms; /* idle time before abandoning */
    nav_upload_state_t state;
    uint32_t size;       /* declared */
    uint32_t crc_decl;   /* declared */
    uint32_t crc_run;    /* over buf[0..next) */
    uint32_t next;       /* next expected offset */
    uint32_t last_ms;    /* time of the last command that touched the upload */
    char name[NAV_UPLOAD_NAME_MAX];
    uint32_t n_abandoned; /* timeouts, aborts and replaced uploads */
} nav_upload_t;

/* buf/cap: the receive buffer; timeout_ms 0 takes NAV_UPLOAD_TIMEOUT_MS. */
void nav_upload_init(nav_upload_t *u, uint8_t *buf, uint32_t cap, uint32_t timeout_ms);

nav_upload_status_t nav_upload_start(nav_upload_t *u, uint32_t size, uint32_t crc32, const char *name,
                                     uint32_t now_ms);
nav_upload_status_t nav_upload_data(nav_upload_t *u, uint32_t offset, const uint8_t *bytes, size_t n,
                                    uint32_t now_ms);
/* Checks every byte arrived and the CRC; a CRC mismatch drops the upload. */
nav_upload_status_t nav_upload_end(nav_upload_t *u, uint32_t now_ms);
nav_upload_status_t nav_upload_abort(nav_upload_t *u);
/* Once per cycle: NAV_UP_E_TIMEOUT when it abandoned an upload now, else NAV_UP_OK. */
nav_upload_status_t nav_upload_tick(nav_upload_t *u, uint32_t now_ms);

/* After END: the table loader over the bytes (into *out); a refusal drops
 * the upload (NAV_UP_E_TABLE, *table_status the loader's reason). */
nav_upload_status_t nav_upload_validate(nav_upload_t *u, mfns_caltable_t *out, mfns_caltable_status_t *table_status);
/* After a validation: writes dir/NAV_UPLOAD_FILE atomically (dir/NAV_UPLOAD_TMP,
 * fsync, rename, fsync of dir) and puts its path into path (path_len bytes).
 * Returns 0 or the errno; the upload is closed either way. */
int nav_upload_store(nav_upload_t *u, const char *dir, char *path, size_t path_len);

uint32_t nav_upload_next(const nav_upload_t *u);
const char *nav_upload_strerror(nav_upload_status_t s);

#endif /* MFNS_NAV_UPLOAD_H */
