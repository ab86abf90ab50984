/* tc_auth.h -- telecommand authentication (docs/uplink.md 1a, 3a): keys,
 * the MAC, and the anti-replay check. Linux side only (OpenSSL's libcrypto:
 * HMAC-SHA-256, CRYPTO_memcmp); the portable codec (firmware/tlm/
 * tc_packets.h) only frames and parses the security header and trailer.
 * Used by mfns-nav (verify) and mfns-ground (sign).
 *
 * MAC: HMAC-SHA-256 keyed by the SPI's 32-byte key over every byte of the
 * secured packet before the MAC (primary header, security header, opcode,
 * reserved, arguments), truncated to its first TC_SEC_MAC_LEN (16) bytes
 * (RFC 2104 section 5 allows truncation to >= half the hash).
 *
 * Key file (--tc-key FILE, both programs): lines "ID HEX" -- ID the key id
 * (SPI) 1..255, HEX 64 hex digits (32 bytes); '#' comments and blank lines
 * ignored; at most TC_AUTH_MAX_KEYS keys, ids distinct. It must be a regular
 * file owned by the user running the program with mode 0600 or 0400, else it
 * is refused (nothing is read from it). More than one key: rotation
 * (docs/uplink.md); the ground signs with the first key of its file.
 *
 * Anti-replay: ARSN = epoch << 32 | count. The flight side accepts a secured
 * command only when its epoch is this boot's (tc_state.h: persisted, +1 at
 * every start) and its count is newer than the last verified one of this
 * boot (count 0 is never valid, so housekeeping's 0 means "none yet").
 * The reference moves when the MAC verifies, whatever the command's fate
 * afterwards (a signed command is usable once).
 *
 * Order of checks, each with its code (tc_status_t, counted in n_rej):
 *   no security header or SPI 0 -> AUTH_MISSING; SPI without a key ->
 *   AUTH_KEY_UNKNOWN; MAC -> AUTH_BAD_MAC; epoch -> AUTH_STALE_EPOCH;
 *   count -> AUTH_REPLAY. Insecure mode (--tc-insecure, no keys): a plain
 *   packet passes, a secured one is AUTH_KEY_UNKNOWN.
 *
 * What it misses: a stolen key (anyone with it commands the board); a
 * denial of service (garbage is rejected, but costs its verify); the
 * commands are not encrypted (anyone on the link reads them).
 */
#ifndef MFNS_APP_TC_AUTH_H
#define MFNS_APP_TC_AUTH_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "firmware/tlm/tc_packets.h"

#define TC_AUTH_MAX_KEYS 4u      /* keys loaded at once (rotation needs 2) */
#define TC_AUTH_KEY_BYTES 32u    /* HMAC-SHA-256 key: the hash's output size */
#define TC_AUTH_FILE_MAX 4096    /* a key file is read up to this, longer is refused */
#define TC_AUTH_N_CODES 5u       /* AUTH_MISSING .. AUTH_STALE_EPOCH */
_Static_assert(TC_E_AUTH_STALE_EPOCH - TC_E_AUTH_MISSING + 1 == (int)TC_AUTH_N_CODES, "auth codes contiguous");

typedef struct {
    uint8_t id;                        /* SPI */
    uint8_t key[TC_AUTH_KEY_BYTES];
} tc_auth_key_t;

typedef struct {
    tc_auth_key_t keys[TC_AUTH_MAX_KEYS];
    unsigned n_keys;
    bool insecure;          /* no keys: plain commands pass (--tc-insecure) */
    uint32_t epoch;         /* this boot's epoch (tc_state.h) */
    uint32_t count_last;    /* low 32 bits of the last verified ARSN (0: none) */
    uint32_t n_ok;          /* verified (or passed in insecure mode) */
    uint32_t n_rej[TC_AUTH_N_CODES]; /* by code, index code - TC_E_AUTH_MISSING */
} tc_auth_t;

/* true when this build has libcrypto (the aarch64 build may not: then no key loads). */
bool tc_auth_available(void);

/* Read a key file (format and permissions above) into keys[0..*n). 0, or -1
 * with one line in err. The file's bytes are wiped from memory after use. */
int tc_auth_read_keys(const char *path, tc_auth_key_t *keys, unsigned max, unsigned *n, char *err, size_t err_size);

/* The truncated HMAC of data[0..n) under key. 0, -1 when libcrypto failed or is absent. */
int tc_auth_mac(const uint8_t key[TC_AUTH_KEY_BYTES], const uint8_t *data, size_t n, uint8_t mac[TC_SEC_MAC_LEN]);

/* Flight side: keys (n > 0) and the boot epoch; or insecure (keys NULL, n 0). */
void tc_auth_init(tc_auth_t *a, const tc_auth_key_t *keys, unsigned n, uint32_t epoch);
/* Checks a decoded command (cmd->sec); TC_OK or an AUTH_* code, counted. */
tc_status_t tc_auth_check(tc_auth_t *a, const tc_cmd_t *cmd);
/* Wipes the keys. */
void tc_auth_clear(tc_auth_t *a);
/* Zeroes n bytes at p in a way the compiler keeps (key material on the stack). */
void tc_auth_wipe(void *p, size_t n);

/* The ground's half, signing a command, is ground/tc_sign.h: it never flies. */

#endif /* MFNS_APP_TC_AUTH_H */
