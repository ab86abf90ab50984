/* replay_index.h -- frames.csv of a frame folder (docs/nav-frames.md), parsed
 * once per folder into one row table that the three replay cameras share.
 *
 * Every row is validated here, once: a bad row is kept in the table with its
 * status and line number, attributed to the camera its third field names
 * (when that field is x, y or z), so it costs exactly that camera that one
 * frame; a row whose camera cannot be told costs nobody a turn (its camera
 * shows a gap in the frame sequence). The cameras can therefore never fall
 * out of step over a bad row. Order is checked per camera: frame indices
 * strictly increase and times do not go back.
 *
 * Pure (no I/O, no heap): the caller provides the text (changed in place:
 * fields are cut at their commas) and the row storage; the fuzzer
 * (tests/fuzz/fuzz_replay_csv.c) calls it on anything. */
#ifndef MFNS_REPLAY_INDEX_H
#define MFNS_REPLAY_INDEX_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define MFNS_REPLAY_CSV_HEADER "frame,t_s,camera,file,exposure_us,gain_db"
#define MFNS_REPLAY_GAIN_DB_MAX 200.0 /* dB: beyond any sensor's gain, and a float holds its factor */
#define MFNS_REPLAY_LINE_MAX 511u           /* longest row accepted, characters */
#define MFNS_REPLAY_CSV_MAX (32u << 20)     /* frames.csv bytes: ~10 h of three cameras */
#define MFNS_REPLAY_MAX_ROWS (1u << 20)     /* rows (bounds the table) */

typedef enum {
    MFNS_ROW_OK = 0,
    MFNS_ROW_FIELDS,   /* not 6 comma-separated fields */
    MFNS_ROW_FRAME,    /* frame is not an index */
    MFNS_ROW_TIME,     /* t_s is not a time */
    MFNS_ROW_CAMERA,   /* camera is not x, y or z */
    MFNS_ROW_FILE,     /* file is not a relative path inside the folder */
    MFNS_ROW_EXPOSURE, /* exposure_us is not a duration */
    MFNS_ROW_GAIN,     /* gain_db is not a number within +-MFNS_REPLAY_GAIN_DB_MAX */
    MFNS_ROW_ORDER,    /* frame/time does not follow the camera's previous row (duplicate, reordered) */
    MFNS_ROW_LONG,     /* longer than MFNS_REPLAY_LINE_MAX */
    MFNS_ROW_NUL       /* a NUL byte in the row */
} mfns_replay_row_status_t;

typedef struct {
    const char *file;  /* OK rows: NUL-terminated, inside the text */
    const char *field; /* bad rows: the offending field (NUL-terminated), or "" */
    double t_s;        /* double: seconds over a long run need sub-microsecond steps */
    double prev_t_s;   /* MFNS_ROW_ORDER: the row it fails to follow */
    uint32_t frame, prev_frame;
    uint32_t line;     /* 1-based line number in frames.csv */
    int32_t exposure_us;
    float gain_db;     /* the row's gain_db */
    char camera;       /* 'x', 'y', 'z', or '\0' when the row cannot be attributed */
    uint8_t status;    /* mfns_replay_row_status_t */
} mfns_replay_row_t;

/* Rows a text of len bytes can produce (its lines, bounded): size the table with it. */
uint32_t mfns_replay_count_rows(const char *text, size_t len);

/* Parses text[0..len) (text[len] must be writable; it becomes '\0'). Rows in
 * file order into rows[0..cap). max_file_len bounds the file field (the
 * folder path must still fit). false when the file itself is unusable
 * (header, too many rows); why says why. */
bool mfns_replay_index_parse(char *text, size_t len, size_t max_file_len, mfns_replay_row_t *rows, uint32_t cap,
                             uint32_t *n_rows, char *why, size_t why_size);

/* One-line description of a bad row ("frames.csv line 7: ..."). */
void mfns_replay_row_message(const mfns_replay_row_t *r, char *out, size_t n);

#endif
