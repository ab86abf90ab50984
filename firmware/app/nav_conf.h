/* nav_conf.h -- the flight program's configuration file (docs/operations.md
 * "Configuration"): /etc/mfns/mfns-nav.conf on the board, read when mfns-nav
 * is given --config FILE; options on the command line override it key by key
 * (nav_opts.h).
 *
 * Format: one `key = value` per line; a line whose first non-blank character
 * is '#' is a comment, and so is the rest of a line from a '#' that follows a
 * blank (`baud = 115200  # the bench`: the value is 115200; a '#' inside a
 * word, `/data/run#2`, is part of it); blank lines are ignored; blanks around
 * the key, the '=' and the value are ignored. No quoting, no continuation
 * lines, no includes. Every key is known (a misspelt key is an
 * error, never silently ignored) and given at most once.
 *
 * The reader is bounded: at most NAV_CONFIG_MAX_BYTES of file,
 * NAV_CONFIG_LINE_MAX characters a line and NAV_CONFIG_VALUE_MAX - 1 of value;
 * it never allocates, never reads past len, and keeps nothing but the caller's
 * nav_config_t (tests/fuzz/fuzz_nav_conf.c). Each value is checked against
 * its key's type (path, yes/no, a number in range, one of a few words) here,
 * so every error names the file's line and the key:
 *   "line 7: key 'baud': wants a number 1200..4000000, got 'fast'".
 * Misses: a path is not checked to exist (the program's start-up reports that,
 * as the self-test, nav_selftest.h), and two keys that exclude each other
 * (uart and tty) are refused by nav_opts.
 */
#ifndef MFNS_NAV_CONF_H
#define MFNS_NAV_CONF_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "firmware/app/nav_opts_table.h"

#define NAV_CONFIG_DEFAULT_PATH "/etc/mfns/mfns-nav.conf"
#define NAV_CONFIG_MAX_BYTES 16384u /* a configuration is a few hundred bytes; more is not one */
#define NAV_CONFIG_LINE_MAX 255u    /* characters a line, without its newline */
#define NAV_CONFIG_VALUE_MAX 256u   /* bytes of a value with its NUL (PATH_MAX is not needed on the board) */
#define NAV_CONFIG_ERR_LEN 200u     /* an error message's buffer */

/* The keys, in the order of the documentation: the KEY rows of the options'
 * table (nav_opts_table.h), X(enum suffix, name, type, lo, hi, option). */
#define NAV_CONFIG_KEYS(X) NAV_OPTS(NAV_OPTS_SKIP, X)

typedef enum {
    NAV_CFG_T_TEXT, /* any printable text (a camera identity, nav_opts.h) */
    NAV_CFG_T_PATH, /* an absolute path */
    NAV_CFG_T_BOOL, /* yes / no (also true/false, on/off, 1/0) */
    NAV_CFG_T_U32,  /* a decimal number in lo..hi */
    NAV_CFG_T_WORD, /* `cameras`: v4l2 or libcamera */
} nav_config_type_t;

#define NAV_CONFIG_ENUM(NAME, name, type, lo, hi, opt) NAV_CFG_##NAME,
typedef enum { NAV_CONFIG_KEYS(NAV_CONFIG_ENUM) NAV_CFG_KEY_COUNT } nav_config_key_t;
#undef NAV_CONFIG_ENUM

typedef struct {
    bool set[NAV_CFG_KEY_COUNT];
    uint32_t line[NAV_CFG_KEY_COUNT];                     /* where each was given (1-based) */
    char value[NAV_CFG_KEY_COUNT][NAV_CONFIG_VALUE_MAX];  /* NUL-terminated, checked against its type */
    uint32_t number[NAV_CFG_KEY_COUNT];                   /* U32 keys: the value; BOOL keys: 0 or 1 */
    bool have_stat;                                       /* nav_config_load: the file's owner and mode below */
    uint32_t file_uid;
    uint32_t file_mode;                                   /* permission bits */
} nav_config_t;

/* Parses text[0..len) (need not be NUL-terminated) into *c (reset first).
 * 0 ok; -1 with a message "line N: key 'K': ..." (or "line N: ...") in err. */
int nav_config_parse(const char *text, size_t len, nav_config_t *c, char *err, size_t err_size);

/* Reads the file at path (a regular file, at most NAV_CONFIG_MAX_BYTES) and
 * parses it. 0 ok; -1 with "PATH: ..." or "PATH:N: key 'K': ..." in err. */
int nav_config_load(const char *path, nav_config_t *c, char *err, size_t err_size);

/* Security-relevant keys (tc_key, tc_insecure, state_dir, uplink) are only
 * taken from a file owned by root or by the user running the program and
 * writable by nobody else (no group or world write bit): otherwise anyone who
 * can write the file switches authentication off. 0 when c may be used (or
 * holds none of those keys), -1 with the reason in err. euid: the program's. */
int nav_config_check_trust(const nav_config_t *c, uint32_t euid, char *err, size_t err_size);

/* The key's name as written in the file ("cam_x"). */
const char *nav_config_key_name(nav_config_key_t k);

/* The long option the key stands for ("cam-x"; `cameras`: "v4l2", which
 * --libcamera shares), "?" for no key. */
const char *nav_config_key_option(nav_config_key_t k);

/* The key's type, and for NAV_CFG_T_U32 its range lo..hi (0, 0 otherwise;
 * NAV_CFG_T_TEXT for no key). */
nav_config_type_t nav_config_key_type(nav_config_key_t k);
uint32_t nav_config_key_lo(nav_config_key_t k);
uint32_t nav_config_key_hi(nav_config_key_t k);

#endif /* MFNS_NAV_CONF_H */
