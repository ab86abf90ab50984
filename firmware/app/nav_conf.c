/* nav_conf.c -- see nav_conf.h. */
#ifndef _DEFAULT_SOURCE
#define _DEFAULT_SOURCE 1 /* O_CLOEXEC under -std=c11 */
#endif

#include "firmware/app/nav_conf.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

typedef struct {
    const char *name;
    nav_config_type_t type;
    uint32_t lo, hi;
    const char *option; /* the long option the key stands for */
} key_spec_t;

#define NAV_CONFIG_SPEC(NAME, name, type, lo, hi, opt) {name, type, lo, hi, opt},
static const key_spec_t k_spec[NAV_CFG_KEY_COUNT] = {NAV_CONFIG_KEYS(NAV_CONFIG_SPEC)};
#undef NAV_CONFIG_SPEC

_Static_assert(NAV_CONFIG_LINE_MAX < NAV_CONFIG_MAX_BYTES, "a line fits in a file");
_Static_assert(NAV_CONFIG_VALUE_MAX > NAV_CONFIG_LINE_MAX, "any value that fits on a line fits in its buffer");

const char *nav_config_key_name(nav_config_key_t k)
{
    return (unsigned)k < (unsigned)NAV_CFG_KEY_COUNT ? k_spec[k].name : "?";
}

const char *nav_config_key_option(nav_config_key_t k)
{
    return (unsigned)k < (unsigned)NAV_CFG_KEY_COUNT ? k_spec[k].option : "?";
}

nav_config_type_t nav_config_key_type(nav_config_key_t k)
{
    return (unsigned)k < (unsigned)NAV_CFG_KEY_COUNT ? k_spec[k].type : NAV_CFG_T_TEXT;
}

uint32_t nav_config_key_lo(nav_config_key_t k)
{
    return (unsigned)k < (unsigned)NAV_CFG_KEY_COUNT ? k_spec[k].lo : 0u;
}

uint32_t nav_config_key_hi(nav_config_key_t k)
{
    return (unsigned)k < (unsigned)NAV_CFG_KEY_COUNT ? k_spec[k].hi : 0u;
}

/* The message of an error into the caller's err (nullable, any size; never
 * overrun). A macro over snprintf, not a va_list function: every caller has
 * err and err_size in scope. */
#define FAIL(...)                                                                                                      \
    do {                                                                                                               \
        if (err != NULL && err_size > 0) {                                                                             \
            (void)snprintf(err, err_size, __VA_ARGS__);                                                                \
        }                                                                                                              \
    } while (0)

static bool is_blank(char ch)
{
    return ch == ' ' || ch == '\t' || ch == '\r';
}

/* A value shown in a message: at most 40 characters of it. */
#define SHOW_MAX 40

static bool parse_bool(const char *v, uint32_t *out)
{
    static const char *const yes[] = {"yes", "true", "on", "1"};
    static const char *const no[] = {"no", "false", "off", "0"};
    for (size_t i = 0; i < sizeof yes / sizeof yes[0]; i++) {
        if (strcmp(v, yes[i]) == 0) {
            *out = 1;
            return true;
        }
        if (strcmp(v, no[i]) == 0) {
            *out = 0;
            return true;
        }
    }
    return false;
}

/* Decimal, no sign, no blanks, at most 10 digits (so no overflow of uint64). */
static bool parse_u32(const char *v, uint32_t lo, uint32_t hi, uint32_t *out)
{
    uint64_t x = 0;
    size_t n = 0;
    for (; v[n] != '\0'; n++) {
        if (n >= 10 || v[n] < '0' || v[n] > '9') {
            return false;
        }
        x = x * 10u + (uint64_t)(v[n] - '0');
    }
    if (n == 0 || x < lo || x > hi) {
        return false;
    }
    *out = (uint32_t)x;
    return true;
}

/* Checks v against key k's type; 0 ok, else -1 and the message. */
static int check_value(nav_config_t *c, nav_config_key_t k, uint32_t line, char *err, size_t err_size)
{
    const key_spec_t *s = &k_spec[k];
    const char *v = c->value[k];
    for (size_t i = 0; v[i] != '\0'; i++) {
        const unsigned char ch = (unsigned char)v[i];
        if (ch < 0x20u || ch == 0x7fu) {
            FAIL("line %u: key '%s': a control character in the value", line, s->name);
            return -1;
        }
    }
    switch (s->type) {
    case NAV_CFG_T_TEXT:
        return 0;
    case NAV_CFG_T_PATH:
        if (v[0] != '/') {
            FAIL("line %u: key '%s': wants an absolute path, got '%.*s'", line, s->name, SHOW_MAX, v);
            return -1;
        }
        return 0;
    case NAV_CFG_T_BOOL:
        if (!parse_bool(v, &c->number[k])) {
            FAIL("line %u: key '%s': wants yes or no, got '%.*s'", line, s->name, SHOW_MAX, v);
            return -1;
        }
        return 0;
    case NAV_CFG_T_U32:
        if (!parse_u32(v, s->lo, s->hi, &c->number[k])) {
            FAIL("line %u: key '%s': wants a number %u..%u, got '%.*s'", line, s->name, s->lo, s->hi,
                 SHOW_MAX, v);
            return -1;
        }
        return 0;
    case NAV_CFG_T_WORD:
        if (strcmp(v, "v4l2") != 0 && strcmp(v, "libcamera") != 0) {
            FAIL("line %u: key '%s': wants v4l2 or libcamera, got '%.*s'", line, s->name, SHOW_MAX, v);
            return -1;
        }
        return 0;
    }
    return -1; /* every type is handled above */
}

/* One line: text[0..n) without its newline. 0 ok (also for blank/comment). */
static int parse_line(nav_config_t *c, const char *text, size_t n, uint32_t line, char *err, size_t err_size)
{
    size_t a = 0;
    while (a < n && is_blank(text[a])) {
        a++;
    }
    if (a == n || text[a] == '#') {
        return 0;
    }
    size_t eq = a;
    while (eq < n && text[eq] != '=') {
        eq++;
    }
    if (eq == n) {
        FAIL("line %u: not 'key = value' (no '=')", line);
        return -1;
    }
    size_t kend = eq;
    while (kend > a && is_blank(text[kend - 1])) {
        kend--;
    }
    if (kend == a) {
        FAIL("line %u: no key before '='", line);
        return -1;
    }
    int key = -1;
    for (int k = 0; k < (int)NAV_CFG_KEY_COUNT; k++) {
        const size_t kl = strlen(k_spec[k].name);
        if (kl == kend - a && memcmp(k_spec[k].name, text + a, kl) == 0) {
            key = k;
            break;
        }
    }
    if (key < 0) {
        char shown[SHOW_MAX + 1];
        size_t m = kend - a < SHOW_MAX ? kend - a : SHOW_MAX;
        for (size_t i = 0; i < m; i++) { /* never echo a control byte */
            const unsigned char ch = (unsigned char)text[a + i];
            shown[i] = ch >= 0x20u && ch < 0x7fu ? (char)ch : '?';
        }
        shown[m] = '\0';
        FAIL("line %u: unknown key '%s' (docs/operations.md lists the keys)", line, shown);
        return -1;
    }
    if (c->set[key]) {
        FAIL("line %u: key '%s' given twice (first on line %u)", line, k_spec[key].name, c->line[key]);
        return -1;
    }
    size_t v0 = eq + 1;
    while (v0 < n && is_blank(text[v0])) {
        v0++;
    }
    size_t v1 = n;
    for (size_t i = v0; i < n; i++) {
        if (text[i] == '#' && i > eq + 1u && is_blank(text[i - 1])) {
            v1 = i; /* an inline comment: '#' after a blank (a '#' inside a word stays part of it) */
            break;
        }
    }
    while (v1 > v0 && is_blank(text[v1 - 1])) {
        v1--;
    }
    if (v1 == v0) {
        FAIL("line %u: key '%s': no value", line, k_spec[key].name);
        return -1;
    }
    if (memchr(text + v0, '\0', v1 - v0) != NULL) {
        FAIL("line %u: key '%s': a NUL byte in the value", line, k_spec[key].name);
        return -1;
    }
    /* v1 - v0 <= n <= NAV_CONFIG_LINE_MAX < NAV_CONFIG_VALUE_MAX */
    memcpy(c->value[key], text + v0, v1 - v0);
    c->value[key][v1 - v0] = '\0';
    if (check_value(c, (nav_config_key_t)key, line, err, err_size) != 0) {
        return -1;
    }
    c->set[key] = true;
    c->line[key] = line;
    return 0;
}

int nav_config_parse(const char *text, size_t len, nav_config_t *c, char *err, size_t err_size)
{
    memset(c, 0, sizeof *c);
    if (text == NULL && len > 0) {
        FAIL("no text");
        return -1;
    }
    if (len > NAV_CONFIG_MAX_BYTES) {
        FAIL("%zu bytes: more than a configuration (at most %u)", len, NAV_CONFIG_MAX_BYTES);
        return -1;
    }
    size_t pos = 0;
    /* one pass over len bytes; each iteration consumes at least one byte or ends */
    for (uint32_t line = 1; pos < len; line++) {
        const char *nl = memchr(text + pos, '\n', len - pos);
        const size_t end = nl != NULL ? (size_t)(nl - text) : len;
        if (end - pos > NAV_CONFIG_LINE_MAX) {
            FAIL("line %u: longer than %u characters", line, NAV_CONFIG_LINE_MAX);
            return -1;
        }
        if (parse_line(c, text + pos, end - pos, line, err, err_size) != 0) {
            return -1;
        }
        pos = end + 1;
    }
    return 0;
}

int nav_config_load(const char *path, nav_config_t *c, char *err, size_t err_size)
{
    static char buf[NAV_CONFIG_MAX_BYTES + 1]; /* start-up only; one reader at a time */
    memset(c, 0, sizeof *c);
    const int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    if (fd < 0) {
        FAIL("%s: cannot open: %s", path, strerror(errno));
        return -1;
    }
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        (void)close(fd); /* refused before a byte is read */
        FAIL("%s: not a regular file", path);
        return -1;
    }
    size_t len = 0;
    int rc = 0;
    for (int guard = 0; guard <= (int)NAV_CONFIG_MAX_BYTES + 1; guard++) {
        const ssize_t n = read(fd, buf + len, sizeof buf - len);
        if (n < 0 && errno == EINTR) {
            continue;
        }
        if (n < 0) {
            FAIL("%s: read: %s", path, strerror(errno));
            rc = -1;
            break;
        }
        if (n == 0) {
            break;
        }
        len += (size_t)n;
        if (len > NAV_CONFIG_MAX_BYTES) {
            FAIL("%s: larger than %u bytes: not a configuration", path, NAV_CONFIG_MAX_BYTES);
            rc = -1;
            break;
        }
    }
    if (close(fd) != 0 && rc == 0) {
        FAIL("%s: close: %s", path, strerror(errno));
        rc = -1;
    }
    if (rc != 0) {
        return -1;
    }
    char msg[NAV_CONFIG_ERR_LEN];
    if (nav_config_parse(buf, len, c, msg, sizeof msg) != 0) {
        FAIL("%s: %s", path, msg);
        return -1;
    }
    c->have_stat = true; /* after the parse, which resets c */
    c->file_uid = (uint32_t)st.st_uid;
    c->file_mode = (uint32_t)st.st_mode & 07777u;
    return 0;
}

int nav_config_check_trust(const nav_config_t *c, uint32_t euid, char *err, size_t err_size)
{
    static const nav_config_key_t sec[] = {NAV_CFG_TC_KEY, NAV_CFG_TC_INSECURE, NAV_CFG_STATE_DIR, NAV_CFG_UPLINK};
    const nav_config_key_t *hit = NULL;
    for (size_t i = 0; i < sizeof sec / sizeof sec[0] && hit == NULL; i++) {
        hit = c->set[sec[i]] ? &sec[i] : NULL;
    }
    if (hit == NULL || !c->have_stat) {
        return 0; /* nothing security-relevant, or parsed from memory (tests, fuzzing) */
    }
    const bool owner_ok = c->file_uid == 0u || c->file_uid == euid;
    if (owner_ok && (c->file_mode & 022u) == 0u) {
        return 0;
    }
    FAIL("line %u: key '%s': refused from a file with mode %04o owned by uid %u: security settings are taken only "
         "from a file owned by root or uid %u and not group- or world-writable (chmod go-w)",
         c->line[*hit], nav_config_key_name(*hit), c->file_mode, c->file_uid, euid);
    return -1;
}
