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
 * command only when its epoch is the current one and its count is newer than
 * the last verified one of this epoch (count 0 is never valid, so
 * housekeeping's 0 means "none yet") and at most TC_AUTH_COUNT_MAX (the last
 * TC_AUTH_COUNT_MARGIN counts of an epoch are never usable, so one validly
 * signed 0xFFFFFFFF cannot wedge the uplink: AUTH_COUNT_EXHAUSTED, nothing
 * used up). The reference moves when the MAC verifies, whatever the
 * command's fate afterwards (a signed command is usable once).
 *
 * Where the epoch comes from (docs/uplink.md 1a "Epochs that never repeat"):
 * on a live uplink the board never chooses it. It starts with none
 * (need_resync: every command refused AUTH_RESYNC_NEEDED) and a 64-bit random
 * challenge (getrandom); the ground answers with a RE-SYNCHRONISATION: a NOOP
 * whose ARSN carries the new epoch and whose MAC is HMAC(key,
 * TC_AUTH_RESYNC_DOMAIN || challenge || packet) -- bound to this boot's
 * challenge, so no recorded one is ever accepted again, and an epoch strictly
 * greater than the board's stored floor and than the current one. A new
 * challenge is drawn after each. The ground keeps the largest epoch it ever
 * assigned (its own persisted state), so an epoch is never reused whatever
 * happens to the board's state directory. A recorded command file
 * (--tc-file: no dialogue possible) keeps the local counter (tc_state.h).
 *
 * The uplink report (housekeeping, tc_auth_report_mac): the board MACs what
 * the ground must learn -- key id, epoch, last count, challenge, state bits --
 * under "MFNS-TM-UPLINK-v1" with its keys in turn; the ground believes
 * nothing else. Domain separation: a TC MAC input starts with a CCSDS TC
 * header (byte 0x18/0x19), the two domains with 'M' (0x4D), and the two
 * domain strings differ, so no MAC of one kind is valid as another.
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
#define TC_AUTH_N_CODES 7u       /* AUTH_MISSING .. AUTH_COUNT_EXHAUSTED */
_Static_assert(TC_E_AUTH_COUNT_EXHAUSTED - TC_E_AUTH_MISSING + 1 == (int)TC_AUTH_N_CODES, "auth codes contiguous");
#define TC_AUTH_COUNT_MARGIN 65536u                             /* counts at the top of an epoch never used */
#define TC_AUTH_COUNT_MAX (UINT32_MAX - TC_AUTH_COUNT_MARGIN)   /* the last usable count of an epoch */
#define TC_AUTH_COUNT_LOW (TC_AUTH_COUNT_MAX - (1u << 20))      /* beyond: the ground re-synchronises */
#define TC_AUTH_RESYNC_DOMAIN "MFNS-TC-RESYNC-v1"
#define TC_AUTH_REPORT_DOMAIN "MFNS-TM-UPLINK-v1"
#define TC_AUTH_REPORT_MSG_LEN (sizeof TC_AUTH_REPORT_DOMAIN - 1u + 1u + 4u + 4u + 8u + 1u)

/* hk_tc_state bits (contract/mfns_tm.xml hk_tc_state says the same) */
#define TC_AUTH_ST_RESYNC_NEEDED 0x01u  /* no fresh epoch: only a re-synchronisation is accepted */
#define TC_AUTH_ST_INSECURE 0x02u       /* authentication OFF (tc_insecure) */
#define TC_AUTH_ST_STATE_MISSING 0x04u  /* STATE_DIR/tc_epoch (or the directory) absent */
#define TC_AUTH_ST_STATE_DAMAGED 0x08u  /* present but unreadable or not 'epoch N' */
#define TC_AUTH_ST_STATE_RO 0x10u       /* cannot be written (read-only, full, not a directory) */
#define TC_AUTH_ST_COUNT_LOW 0x20u      /* the count passed TC_AUTH_COUNT_LOW */

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
    bool need_resync;       /* no fresh epoch yet: only a re-synchronisation passes */
    bool nonce_valid;       /* a challenge was drawn (getrandom succeeded) */
    uint64_t nonce;         /* the challenge a re-synchronisation must bind */
    uint32_t floor_epoch;   /* a new epoch must exceed it (the stored one; 0 unknown) */
    uint8_t state_bits;     /* TC_AUTH_ST_STATE_* (the uplink state's faults) */
    bool resynced;          /* set by a re-synchronisation, cleared by the caller */
    uint32_t n_resync;      /* re-synchronisations accepted */
    unsigned report_turn;   /* which key MACs the next report */
} tc_auth_t;

/* The uplink report as housekeeping carries it (tc_auth_report). */
typedef struct {
    uint8_t spi;            /* 0: no key (not authenticated) */
    uint32_t epoch, count_last;
    uint64_t nonce;
    uint8_t state;          /* TC_AUTH_ST_* */
    uint8_t mac[TC_SEC_MAC_LEN];
} tc_auth_report_t;

/* true when this build has libcrypto (the aarch64 build may not: then no key loads). */
bool tc_auth_available(void);

/* Read a key file (format and permissions above) into keys[0..*n). 0, or -1
 * with one line in err. The file's bytes are wiped from memory after use. */
int tc_auth_read_keys(const char *path, tc_auth_key_t *keys, unsigned max, unsigned *n, char *err, size_t err_size);

/* The truncated HMAC of data[0..n) under key. 0, -1 when libcrypto failed or is absent. */
int tc_auth_mac(const uint8_t key[TC_AUTH_KEY_BYTES], const uint8_t *data, size_t n, uint8_t mac[TC_SEC_MAC_LEN]);

/* Flight side: keys (n > 0) and the boot epoch; or insecure (keys NULL, n 0).
 * epoch 0 with keys: no epoch yet, a re-synchronisation is needed
 * (tc_auth_require_resync sets the floor and the state faults). */
void tc_auth_init(tc_auth_t *a, const tc_auth_key_t *keys, unsigned n, uint32_t epoch);
/* No epoch until the ground re-synchronises: a challenge is drawn; floor the
 * stored epoch (0 unknown), state_bits TC_AUTH_ST_STATE_* faults. */
void tc_auth_require_resync(tc_auth_t *a, uint32_t floor_epoch, uint8_t state_bits);
/* Draws a new challenge (getrandom, never blocking); false when none could be drawn. */
bool tc_auth_new_nonce(tc_auth_t *a);
/* The re-synchronisation MAC of a secured packet (ground: sign; board: check). 0 or -1. */
int tc_auth_resync_mac(const uint8_t key[TC_AUTH_KEY_BYTES], uint64_t nonce, const uint8_t *data, size_t n,
                       uint8_t mac[TC_SEC_MAC_LEN]);
/* The state bits now (TC_AUTH_ST_*). */
uint8_t tc_auth_state_bits(const tc_auth_t *a);
/* Board: the next uplink report, MACed with the next key in turn. */
void tc_auth_report(tc_auth_t *a, tc_auth_report_t *r);
/* The report's MAC over its fields (both sides). 0 or -1. */
int tc_auth_report_mac(const uint8_t key[TC_AUTH_KEY_BYTES], const tc_auth_report_t *r, uint8_t mac[TC_SEC_MAC_LEN]);
/* Ground: true when r's MAC verifies under key (and r->spi is its id). */
bool tc_auth_report_verify(const tc_auth_key_t *key, const tc_auth_report_t *r);
/* Checks a decoded command (cmd->sec); TC_OK or an AUTH_* code, counted. */
tc_status_t tc_auth_check(tc_auth_t *a, const tc_cmd_t *cmd);
/* Wipes the keys. */
void tc_auth_clear(tc_auth_t *a);
/* Zeroes n bytes at p in a way the compiler keeps (key material on the stack). */
void tc_auth_wipe(void *p, size_t n);

/* The ground's half, signing a command, is ground/tc_sign.h: it never flies. */

#endif /* MFNS_APP_TC_AUTH_H */
