/* caltable_file.h -- load the calibration table from a file (Linux): read the
 * whole file into the caller's static buffer (bounded by buf_size), then
 * validate and load it with mfns_caltable_load (firmware/nav/table/caltable.h).
 * On any failure *out is left untouched.
 */
#ifndef MFNS_CALTABLE_FILE_H
#define MFNS_CALTABLE_FILE_H

#include <stddef.h>
#include <stdint.h>

#include "firmware/nav/table/caltable.h"

/* Returns MFNS_CALTABLE_E_FILE_OPEN / _FILE_READ / _FILE_TOO_BIG for file
 * problems, MFNS_CALTABLE_E_FILE_NOT_REGULAR for a path that is not a regular
 * file (a FIFO, device or directory: never waited on, so a TABLE_LOAD cannot
 * stall the cycle), otherwise the loader's status. err_offset (nullable) as in
 * mfns_caltable_load. A buffer of MFNS_CALTABLE_MAX_BYTES holds any table this
 * build accepts. */
mfns_caltable_status_t mfns_caltable_load_file(const char *path, uint8_t *buf, size_t buf_size,
                                               mfns_caltable_t *out, uint32_t *err_offset);

#endif /* MFNS_CALTABLE_FILE_H */
