/* replay_pgm.h -- the binary PGM frames of a frame folder (docs/nav-frames.md):
 * header exactly "P5<ws><W><ws><H><ws><maxval><one ws>", no comments, maxval
 * 255 (8-bit) or 1023/4095/65535 (16-bit big-endian samples). Pure functions
 * on memory (no I/O): the replay backend feeds them what it read and the
 * fuzzer (tests/fuzz/fuzz_replay_pgm.c) feeds them anything. */
#ifndef MFNS_REPLAY_PGM_H
#define MFNS_REPLAY_PGM_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define MFNS_PGM_HDR_MAX 64u /* bytes of the file that may hold the header */

typedef struct {
    uint32_t width, height, maxval;
    size_t data_off; /* first pixel byte */
} mfns_pgm_header_t;

/* Parses the header at the start of buf[0..n) (n may include pixel bytes:
 * they are never scanned). Sizes must be 1..max_dim. */
bool mfns_pgm_parse_header(const uint8_t *buf, size_t n, uint32_t max_dim, mfns_pgm_header_t *hd, char *why,
                           size_t why_size);

/* Pixel bytes of one frame: width * height * (1 or 2); 0 if the header is invalid. */
size_t mfns_pgm_pixel_bytes(const mfns_pgm_header_t *hd);

/* 16-bit samples (maxval > 255): big-endian -> native words in place, each
 * checked against maxval. false with *bad_index at the first sample above it. */
bool mfns_pgm_to_native(uint8_t *data, size_t bytes, uint32_t maxval, size_t *bad_index);

#endif
