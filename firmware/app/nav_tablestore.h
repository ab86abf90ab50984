/* nav_tablestore.h -- the calibration table kept in a persistent place, with
 * the previous one for rollback (docs/operations.md "Table update and
 * rollback"). Used when the program has a state dir (--state-dir or the
 * configuration's state_dir); without one nothing is persisted (replays,
 * benches: today's behaviour).
 *
 * In the state dir:
 *   table.mfnstbl       the active table: the last TABLE_LOAD that validated
 *                       (or the initial --table, copied in on the first start)
 *   table.prev.mfnstbl  the one it replaced
 *   table.bad.mfnstbl   an active table that failed validation at start,
 *                       kept for the ground to inspect
 *   table.tmp           transient (a write in progress)
 *
 * Writing (nav_tablestore_commit) is atomic: the bytes go to table.tmp, are
 * fsync'd, the active file is renamed to table.prev.mfnstbl, table.tmp to
 * table.mfnstbl, and the directory is fsync'd. A power cut at any point leaves
 * either the old active table, or (between the two renames) no active table
 * but the old one as previous: the start-up below then runs the previous one.
 *
 * Start-up (nav_tablestore_load_start): the active table if it validates;
 * otherwise the previous one (the active is moved to table.bad.mfnstbl and
 * the previous becomes active: a rollback, reported as TABLE_ROLLBACK by the
 * caller); otherwise the initial table (--table), copied in as active.
 * When the store's table runs and the --table file is not byte for byte the
 * same, info says so (initial_differs): the caller reports it (stderr and
 * TABLE_ARG_OVERRIDDEN), the stored table still runs (a TABLE_LOAD of the
 * file switches).
 * Misses: the store trusts its directory; a table that validates but is wrong
 * for the rig (a valid table of another board) is not caught here.
 */
#ifndef MFNS_NAV_TABLESTORE_H
#define MFNS_NAV_TABLESTORE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "firmware/nav/table/caltable.h"

#define NAV_TABLESTORE_ACTIVE "table.mfnstbl"
#define NAV_TABLESTORE_PREV "table.prev.mfnstbl"
#define NAV_TABLESTORE_BAD "table.bad.mfnstbl"
#define NAV_TABLESTORE_TMP "table.tmp"
#define NAV_TABLESTORE_PATH_MAX 512u

typedef enum {
    NAV_TS_SRC_INITIAL = 0, /* the --table file (no store, or nothing in it validated) */
    NAV_TS_SRC_ACTIVE,      /* the store's active table */
    NAV_TS_SRC_PREV,        /* the store's previous table: a rollback */
} nav_ts_source_t;

typedef struct {
    nav_ts_source_t source;
    bool rolled_back;                     /* the active table was refused: something older runs */
    mfns_caltable_status_t first_status;  /* the first table tried (the store's active, or --table) */
    uint32_t first_err_offset;
    int store_errno;                      /* copying the initial table into the store failed (0 ok) */
    char path[NAV_TABLESTORE_PATH_MAX];   /* the file the running table came from */
    bool initial_differs;                 /* the store's table runs and the --table file is not the same bytes */
    long initial_size;                    /* that file's size (-1: unreadable) */
} nav_ts_start_t;

/* Loads the table to run at start into *out (buf: the caller's table buffer,
 * MFNS_CALTABLE_MAX_BYTES). state_dir NULL: initial_path only. Returns the
 * status of the table that runs (MFNS_CALTABLE_OK), or of the last one tried
 * when none validates; *info says which and why. */
mfns_caltable_status_t nav_tablestore_load_start(const char *state_dir, const char *initial_path, uint8_t *buf,
                                                 size_t buf_size, mfns_caltable_t *out, nav_ts_start_t *info);

/* Stores bytes[0..len) (a table already validated) as the active table, the
 * active one becoming the previous. 0, or the errno of the step that failed
 * (the store then still holds a table that validates: the old active, or the
 * old one as previous). */
int nav_tablestore_commit(const char *state_dir, const uint8_t *bytes, size_t len);

#endif /* MFNS_NAV_TABLESTORE_H */
