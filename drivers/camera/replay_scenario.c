/* replay_scenario.c -- see replay_scenario.h. A small validating JSON scanner
 * (RFC 8259 syntax, iterative with an explicit depth stack: every loop is
 * bounded by the input length) that remembers the raw text of the two
 * top-level members it needs. */
#include "drivers/camera/replay_scenario.h"

#include <stdint.h>
#include <stdio.h>
#include <string.h>

typedef struct {
    const char *s;
    size_t n, p;
    char *why;
    size_t why_size;
} scan_t;

static bool fail(scan_t *t, const char *what)
{
    (void)snprintf(t->why, t->why_size, "scenario.json: %s at byte %zu", what, t->p);
    return false;
}

static void skip_ws(scan_t *t)
{
    while (t->p < t->n && (t->s[t->p] == ' ' || t->s[t->p] == '\t' || t->s[t->p] == '\n' || t->s[t->p] == '\r')) {
        t->p++;
    }
}

static bool is_hex(char c)
{
    return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F');
}

/* A string starting at the opening quote; [*b, *e) is its raw content. */
static bool scan_string(scan_t *t, size_t *b, size_t *e)
{
    t->p++; /* the opening quote */
    *b = t->p;
    while (t->p < t->n) {
        const unsigned char c = (unsigned char)t->s[t->p];
        if (c == '"') {
            *e = t->p;
            t->p++;
            return true;
        }
        if (c < 0x20u) {
            return fail(t, "control character in a string");
        }
        if (c == '\\') {
            if (t->p + 1u >= t->n) {
                break;
            }
            const char x = t->s[t->p + 1u];
            if (x == 'u') {
                if (t->p + 5u >= t->n || !is_hex(t->s[t->p + 2u]) || !is_hex(t->s[t->p + 3u]) ||
                    !is_hex(t->s[t->p + 4u]) || !is_hex(t->s[t->p + 5u])) {
                    return fail(t, "bad \\u escape");
                }
                t->p += 6u;
                continue;
            }
            if (strchr("\"\\/bfnrt", x) == NULL || x == '\0') {
                return fail(t, "bad escape");
            }
            t->p += 2u;
            continue;
        }
        t->p++;
    }
    return fail(t, "unterminated string");
}

static bool digits(scan_t *t)
{
    const size_t start = t->p;
    while (t->p < t->n && t->s[t->p] >= '0' && t->s[t->p] <= '9') {
        t->p++;
    }
    return t->p > start;
}

/* A number; *integer tells whether it is an integer literal (no fraction or exponent). */
static bool scan_number(scan_t *t, bool *integer)
{
    *integer = true;
    if (t->s[t->p] == '-') {
        t->p++;
    }
    if (t->p < t->n && t->s[t->p] == '0') {
        t->p++;
    } else if (!digits(t)) {
        return fail(t, "bad number");
    }
    if (t->p < t->n && t->s[t->p] == '.') {
        *integer = false;
        t->p++;
        if (!digits(t)) {
            return fail(t, "bad number");
        }
    }
    if (t->p < t->n && (t->s[t->p] == 'e' || t->s[t->p] == 'E')) {
        *integer = false;
        t->p++;
        if (t->p < t->n && (t->s[t->p] == '+' || t->s[t->p] == '-')) {
            t->p++;
        }
        if (!digits(t)) {
            return fail(t, "bad number");
        }
    }
    return true;
}

static bool scan_word(scan_t *t, const char *w)
{
    const size_t len = strlen(w);
    if (t->n - t->p < len || memcmp(t->s + t->p, w, len) != 0) {
        return fail(t, "unexpected character");
    }
    t->p += len;
    return true;
}

typedef enum { V_OTHER = 0, V_STRING, V_INTEGER, V_NUMBER } vkind_t;

typedef struct {
    int seen;
    vkind_t kind;
    size_t b, e; /* raw text of the value (string content without quotes) */
} member_t;

/* What the scanner expects next. */
typedef enum { X_KEY_OR_CLOSE, X_KEY, X_VALUE_OR_CLOSE, X_VALUE, X_COMMA_OR_CLOSE } expect_t;

bool mfns_replay_scenario_check(const char *json, size_t n, char *why, size_t why_size)
{
    scan_t t = {json, n, 0, why, why_size};
    char stack[MFNS_REPLAY_JSON_MAX_DEPTH]; /* '{' or '[' per open container */
    size_t depth = 0;
    member_t fmt = {0}, ver = {0};
    member_t *target = NULL; /* top-level member whose value comes next */
    expect_t x = X_VALUE;
    skip_ws(&t);
    if (t.p >= n || json[t.p] != '{') {
        return fail(&t, "not a JSON object");
    }
    /* Each pass consumes at least one byte (or fails): bounded by n. */
    for (size_t guard = 0; guard <= n + 1u; guard++) {
        skip_ws(&t);
        if (depth == 0 && x == X_COMMA_OR_CLOSE) {
            if (t.p != n) {
                return fail(&t, "text after the top-level object");
            }
            break;
        }
        if (t.p >= n) {
            return fail(&t, "unexpected end of text");
        }
        const char c = json[t.p];
        const char open = depth > 0 ? stack[depth - 1u] : '\0';
        if ((x == X_KEY_OR_CLOSE && c == '}') || (x == X_VALUE_OR_CLOSE && c == ']') ||
            (x == X_COMMA_OR_CLOSE && ((c == '}' && open == '{') || (c == ']' && open == '[')))) {
            depth--;
            t.p++;
            x = X_COMMA_OR_CLOSE;
            continue;
        }
        if (x == X_COMMA_OR_CLOSE) {
            if (c != ',') {
                return fail(&t, open == '{' ? "expected ',' or '}'" : "expected ',' or ']'");
            }
            t.p++;
            x = open == '{' ? X_KEY : X_VALUE;
            continue;
        }
        if (x == X_KEY_OR_CLOSE || x == X_KEY) {
            if (c != '"') {
                return fail(&t, "expected a key");
            }
            size_t kb = 0, ke = 0;
            if (!scan_string(&t, &kb, &ke)) {
                return false;
            }
            target = NULL;
            if (depth == 1) {
                const size_t kl = ke - kb;
                if (kl == 6 && memcmp(json + kb, "format", 6) == 0) {
                    target = &fmt;
                } else if (kl == 7 && memcmp(json + kb, "version", 7) == 0) {
                    target = &ver;
                }
                if (target && target->seen) {
                    return fail(&t, "duplicated top-level key");
                }
            }
            skip_ws(&t);
            if (t.p >= n || json[t.p] != ':') {
                return fail(&t, "expected ':'");
            }
            t.p++;
            x = X_VALUE;
            continue;
        }
        /* a value */
        member_t *m = target;
        target = NULL;
        if (c == '{' || c == '[') {
            if (depth >= MFNS_REPLAY_JSON_MAX_DEPTH) {
                return fail(&t, "nested deeper than 64 levels");
            }
            stack[depth++] = c;
            t.p++;
            x = c == '{' ? X_KEY_OR_CLOSE : X_VALUE_OR_CLOSE;
            if (m) {
                m->seen = 1;
                m->kind = V_OTHER;
            }
            continue;
        }
        vkind_t kind = V_OTHER;
        const size_t vb = t.p;
        size_t sb = 0, se = 0;
        bool ok = true;
        if (c == '"') {
            ok = scan_string(&t, &sb, &se);
            kind = V_STRING;
        } else if (c == '-' || (c >= '0' && c <= '9')) {
            bool integer = false;
            ok = scan_number(&t, &integer);
            kind = integer ? V_INTEGER : V_NUMBER;
            sb = vb;
            se = t.p;
        } else if (c == 't') {
            ok = scan_word(&t, "true");
        } else if (c == 'f') {
            ok = scan_word(&t, "false");
        } else if (c == 'n') {
            ok = scan_word(&t, "null");
        } else {
            return fail(&t, "unexpected character");
        }
        if (!ok) {
            return false;
        }
        if (m) {
            m->seen = 1;
            m->kind = kind;
            m->b = sb;
            m->e = se;
        }
        x = X_COMMA_OR_CLOSE;
    }
    if (!(depth == 0 && x == X_COMMA_OR_CLOSE)) {
        return fail(&t, "unexpected end of text");
    }
    if (!(fmt.seen && fmt.kind == V_STRING && fmt.e - fmt.b == 15 && memcmp(json + fmt.b, "mfns-nav-frames", 15) == 0)) {
        (void)snprintf(why, why_size, "scenario.json: top-level \"format\" is not \"mfns-nav-frames\"");
        return false;
    }
    if (!ver.seen || ver.kind != V_INTEGER) {
        (void)snprintf(why, why_size, "scenario.json: top-level \"version\" is %s, want an integer",
                       !ver.seen ? "missing" : (ver.kind == V_NUMBER ? "not a whole number" : "not a number"));
        return false;
    }
    /* An integer literal: at most a sign and digits; compare without overflow. */
    const char *v = json + ver.b;
    const size_t vl = ver.e - ver.b;
    long value = 0;
    bool big = false;
    for (size_t i = (v[0] == '-') ? 1u : 0u; i < vl; i++) {
        if (value > 1000000L) {
            big = true;
            break;
        }
        value = value * 10 + (v[i] - '0');
    }
    if (v[0] == '-' || value < 1) {
        (void)snprintf(why, why_size, "scenario.json: version %.*s is not a positive integer", (int)(vl > 20 ? 20 : vl),
                       v);
        return false;
    }
    if (big || value > MFNS_REPLAY_SCENARIO_VERSION) {
        (void)snprintf(why, why_size, "scenario.json: version %.*s is newer than the %d this reader knows",
                       (int)(vl > 20 ? 20 : vl), v, MFNS_REPLAY_SCENARIO_VERSION);
        return false;
    }
    return true;
}
