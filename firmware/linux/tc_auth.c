/* tc_auth.c -- see tc_auth.h. */
#define _DEFAULT_SOURCE /* O_NOFOLLOW, O_CLOEXEC under -std=c11 */

#include "firmware/linux/tc_auth.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>

#ifdef MFNS_HAVE_LIBCRYPTO
#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>
#endif

#define SHA256_BYTES 32u
_Static_assert(TC_SEC_MAC_LEN * 2u >= SHA256_BYTES, "RFC 2104: truncate to no less than half the hash");
_Static_assert(TC_SEC_MAC_LEN <= SHA256_BYTES, "a truncation of the hash");

bool tc_auth_available(void)
{
#ifdef MFNS_HAVE_LIBCRYPTO
    return true;
#else
    return false;
#endif
}

void tc_auth_wipe(void *p, size_t n)
{
#ifdef MFNS_HAVE_LIBCRYPTO
    OPENSSL_cleanse(p, n);
#else
    volatile uint8_t *v = p; /* not optimised away */
    for (size_t i = 0; i < n; i++) {
        v[i] = 0u;
    }
#endif
}

int tc_auth_mac(const uint8_t key[TC_AUTH_KEY_BYTES], const uint8_t *data, size_t n, uint8_t mac[TC_SEC_MAC_LEN])
{
#ifdef MFNS_HAVE_LIBCRYPTO
    uint8_t full[EVP_MAX_MD_SIZE];
    unsigned int len = 0;
    if (key == NULL || data == NULL || mac == NULL ||
        HMAC(EVP_sha256(), key, (int)TC_AUTH_KEY_BYTES, data, n, full, &len) == NULL || len != SHA256_BYTES) {
        return -1;
    }
    memcpy(mac, full, TC_SEC_MAC_LEN);
    tc_auth_wipe(full, sizeof full);
    return 0;
#else
    (void)key;
    (void)data;
    (void)n;
    (void)mac;
    return -1;
#endif
}

static bool mac_equal(const uint8_t *a, const uint8_t *b)
{
#ifdef MFNS_HAVE_LIBCRYPTO
    return CRYPTO_memcmp(a, b, TC_SEC_MAC_LEN) == 0; /* constant time */
#else
    (void)a;
    (void)b;
    return false;
#endif
}

static int hexval(char c)
{
    if (c >= '0' && c <= '9') {
        return c - '0';
    }
    if (c >= 'a' && c <= 'f') {
        return c - 'a' + 10;
    }
    if (c >= 'A' && c <= 'F') {
        return c - 'A' + 10;
    }
    return -1;
}

/* One "ID HEX" line (NUL-terminated, comment already cut). 1 a key, 0 blank, -1 malformed. */
static int parse_line(char *line, tc_auth_key_t *k)
{
    char *p = line;
    while (*p == ' ' || *p == '\t' || *p == '\r') {
        p++;
    }
    if (*p == '\0') {
        return 0;
    }
    unsigned id = 0;
    int digits = 0;
    for (; *p >= '0' && *p <= '9' && digits < 4; p++, digits++) {
        id = id * 10u + (unsigned)(*p - '0');
    }
    if (digits == 0 || digits > 3 || id < TC_SPI_MIN || id > TC_SPI_MAX || (*p != ' ' && *p != '\t')) {
        return -1;
    }
    while (*p == ' ' || *p == '\t') {
        p++;
    }
    for (unsigned i = 0; i < TC_AUTH_KEY_BYTES; i++) {
        const int hi = hexval(p[2u * i]);
        const int lo = hi < 0 ? -1 : hexval(p[2u * i + 1u]);
        if (lo < 0) {
            return -1;
        }
        k->key[i] = (uint8_t)(hi * 16 + lo);
    }
    p += 2u * TC_AUTH_KEY_BYTES;
    while (*p == ' ' || *p == '\t' || *p == '\r') {
        p++;
    }
    if (*p != '\0') {
        return -1;
    }
    k->id = (uint8_t)id;
    return 1;
}

static int parse_keys(char *text, tc_auth_key_t *keys, unsigned max, unsigned *n, char *err, size_t err_size)
{
    unsigned line_no = 0;
    char *save = NULL;
    for (char *line = strtok_r(text, "\n", &save); line != NULL; line = strtok_r(NULL, "\n", &save)) {
        line_no++;
        char *hash = strchr(line, '#');
        if (hash != NULL) {
            *hash = '\0';
        }
        tc_auth_key_t k;
        const int r = parse_line(line, &k);
        if (r < 0) {
            (void)snprintf(err, err_size, "line %u: want 'ID HEX' (ID %u..%u, %u hex digits)", line_no, TC_SPI_MIN,
                           TC_SPI_MAX, 2u * TC_AUTH_KEY_BYTES);
            tc_auth_wipe(&k, sizeof k);
            return -1;
        }
        if (r == 0) {
            continue;
        }
        for (unsigned j = 0; j < *n; j++) {
            if (keys[j].id == k.id) {
                (void)snprintf(err, err_size, "line %u: key id %u given twice", line_no, k.id);
                tc_auth_wipe(&k, sizeof k);
                return -1;
            }
        }
        if (*n >= max) {
            (void)snprintf(err, err_size, "more than %u keys", max);
            tc_auth_wipe(&k, sizeof k);
            return -1;
        }
        keys[(*n)++] = k;
        tc_auth_wipe(&k, sizeof k);
    }
    if (*n == 0u) {
        (void)snprintf(err, err_size, "no key in it");
        return -1;
    }
    return 0;
}

int tc_auth_read_keys(const char *path, tc_auth_key_t *keys, unsigned max, unsigned *n, char *err, size_t err_size)
{
    *n = 0;
    if (!tc_auth_available()) {
        (void)snprintf(err, err_size, "%s: this build has no libcrypto (install libssl-dev for the target)", path);
        return -1;
    }
    /* O_NONBLOCK: a FIFO given as the key file never blocks the open */
    const int fd = open(path, O_RDONLY | O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK);
    if (fd < 0) {
        (void)snprintf(err, err_size, "%s: %s", path, strerror(errno));
        return -1;
    }
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        (void)snprintf(err, err_size, "%s: not a regular file", path);
        (void)close(fd);
        return -1;
    }
    const unsigned mode = (unsigned)st.st_mode & 07777u;
    if (st.st_uid != geteuid() || (mode != 0600u && mode != 0400u)) {
        (void)snprintf(err, err_size,
                       "%s: refused: mode %04o owner uid %u; a key file must be mode 0600 or 0400 and owned by uid %u "
                       "(chmod 600 %s)",
                       path, mode, (unsigned)st.st_uid, (unsigned)geteuid(), path);
        (void)close(fd);
        return -1;
    }
    char text[TC_AUTH_FILE_MAX + 1];
    size_t len = 0;
    for (int guard = 0; guard < TC_AUTH_FILE_MAX + 1 && len <= TC_AUTH_FILE_MAX; guard++) {
        const ssize_t r = read(fd, text + len, TC_AUTH_FILE_MAX + 1 - len);
        if (r <= 0) {
            break;
        }
        len += (size_t)r;
    }
    (void)close(fd);
    if (len > TC_AUTH_FILE_MAX) {
        (void)snprintf(err, err_size, "%s: longer than %d bytes", path, TC_AUTH_FILE_MAX);
        tc_auth_wipe(text, sizeof text);
        return -1;
    }
    text[len] = '\0';
    char msg[160];
    const int rc = parse_keys(text, keys, max, n, msg, sizeof msg);
    tc_auth_wipe(text, sizeof text);
    if (rc != 0) {
        tc_auth_wipe(keys, sizeof *keys * max);
        *n = 0;
        (void)snprintf(err, err_size, "%s: %s", path, msg);
    }
    return rc;
}

void tc_auth_init(tc_auth_t *a, const tc_auth_key_t *keys, unsigned n, uint32_t epoch)
{
    memset(a, 0, sizeof *a);
    a->n_keys = n > TC_AUTH_MAX_KEYS ? TC_AUTH_MAX_KEYS : n;
    if (keys != NULL && a->n_keys > 0u) {
        memcpy(a->keys, keys, sizeof *keys * a->n_keys);
    } else {
        a->n_keys = 0;
    }
    a->insecure = a->n_keys == 0u;
    a->epoch = epoch;
    if (!a->insecure && epoch == 0u) {
        tc_auth_require_resync(a, 0u, 0u);
    }
}

void tc_auth_clear(tc_auth_t *a)
{
    tc_auth_wipe(a->keys, sizeof a->keys);
    a->n_keys = 0;
}


static tc_status_t refuse(tc_auth_t *a, tc_status_t why)
{
    a->n_rej[why - TC_E_AUTH_MISSING]++;
    return why;
}

/* Big-endian put (the report message). */
static size_t put_be(uint8_t *b, uint64_t v, unsigned bytes)
{
    for (unsigned i = 0; i < bytes; i++) {
        b[i] = (uint8_t)(v >> (8u * (bytes - 1u - i)));
    }
    return bytes;
}

int tc_auth_resync_mac(const uint8_t key[TC_AUTH_KEY_BYTES], uint64_t nonce, const uint8_t *data, size_t n,
                       uint8_t mac[TC_SEC_MAC_LEN])
{
    uint8_t msg[sizeof TC_AUTH_RESYNC_DOMAIN - 1u + 8u + TC_MAX_SEC_PACKET];
    const size_t dl = sizeof TC_AUTH_RESYNC_DOMAIN - 1u;
    if (data == NULL || n > TC_MAX_SEC_PACKET) {
        return -1;
    }
    memcpy(msg, TC_AUTH_RESYNC_DOMAIN, dl);
    (void)put_be(msg + dl, nonce, 8u);
    memcpy(msg + dl + 8u, data, n);
    return tc_auth_mac(key, msg, dl + 8u + n, mac);
}

static size_t report_msg(const tc_auth_report_t *r, uint8_t msg[TC_AUTH_REPORT_MSG_LEN])
{
    size_t k = sizeof TC_AUTH_REPORT_DOMAIN - 1u;
    memcpy(msg, TC_AUTH_REPORT_DOMAIN, k);
    k += put_be(msg + k, r->spi, 1u);
    k += put_be(msg + k, r->epoch, 4u);
    k += put_be(msg + k, r->count_last, 4u);
    k += put_be(msg + k, r->nonce, 8u);
    k += put_be(msg + k, r->state, 1u);
    return k;
}

int tc_auth_report_mac(const uint8_t key[TC_AUTH_KEY_BYTES], const tc_auth_report_t *r, uint8_t mac[TC_SEC_MAC_LEN])
{
    uint8_t msg[TC_AUTH_REPORT_MSG_LEN];
    const size_t n = report_msg(r, msg);
    return tc_auth_mac(key, msg, n, mac);
}

bool tc_auth_report_verify(const tc_auth_key_t *key, const tc_auth_report_t *r)
{
    uint8_t mac[TC_SEC_MAC_LEN];
    if (key == NULL || r == NULL || r->spi == 0u || r->spi != key->id || tc_auth_report_mac(key->key, r, mac) != 0) {
        return false;
    }
    const bool ok = mac_equal(mac, r->mac);
    tc_auth_wipe(mac, sizeof mac);
    return ok;
}

bool tc_auth_new_nonce(tc_auth_t *a)
{
    uint64_t v = 0;
    /* never blocks the start: without entropy yet, retried at the next report */
    const ssize_t got = getrandom(&v, sizeof v, GRND_NONBLOCK);
    a->nonce_valid = got == (ssize_t)sizeof v;
    a->nonce = a->nonce_valid ? v : 0u;
    return a->nonce_valid;
}

void tc_auth_require_resync(tc_auth_t *a, uint32_t floor_epoch, uint8_t state_bits)
{
    a->epoch = 0;
    a->count_last = 0;
    a->need_resync = !a->insecure;
    a->floor_epoch = floor_epoch;
    a->state_bits = state_bits;
    if (a->need_resync) {
        (void)tc_auth_new_nonce(a);
    }
}

uint8_t tc_auth_state_bits(const tc_auth_t *a)
{
    uint8_t b = a->state_bits;
    b |= a->need_resync ? (uint8_t)TC_AUTH_ST_RESYNC_NEEDED : 0u;
    b |= a->insecure ? (uint8_t)TC_AUTH_ST_INSECURE : 0u;
    b |= a->count_last > TC_AUTH_COUNT_LOW ? (uint8_t)TC_AUTH_ST_COUNT_LOW : 0u;
    return b;
}

void tc_auth_report(tc_auth_t *a, tc_auth_report_t *r)
{
    memset(r, 0, sizeof *r);
    if (a->need_resync && !a->nonce_valid) {
        (void)tc_auth_new_nonce(a); /* entropy may have arrived since start */
    }
    r->epoch = a->epoch != 0u ? a->epoch : a->floor_epoch; /* resync needed: the floor a new one must exceed */
    r->count_last = a->count_last;
    r->nonce = a->nonce;
    r->state = tc_auth_state_bits(a);
    if (a->n_keys == 0u) {
        return; /* insecure: nothing to MAC with (spi 0 says so) */
    }
    const tc_auth_key_t *k = &a->keys[a->report_turn % a->n_keys];
    a->report_turn = (a->report_turn + 1u) % a->n_keys;
    r->spi = k->id;
    if (tc_auth_report_mac(k->key, r, r->mac) != 0) {
        r->spi = 0; /* no MAC: the ground believes nothing of it */
        memset(r->mac, 0, sizeof r->mac);
    }
}

/* A re-synchronisation (tc_auth.h): the MAC bound to the challenge verified. */
static tc_status_t resync(tc_auth_t *a, const tc_cmd_t *cmd)
{
    const uint32_t epoch = (uint32_t)(cmd->sec.arsn >> 32);
    const uint32_t count = (uint32_t)(cmd->sec.arsn & 0xFFFFFFFFu);
    if (cmd->opcode != TC_OP_NOOP || epoch <= a->floor_epoch || epoch <= a->epoch) {
        return refuse(a, TC_E_AUTH_STALE_EPOCH); /* not fresher than what the board has seen */
    }
    if (count == 0u || count > TC_AUTH_COUNT_MAX) {
        return refuse(a, TC_E_AUTH_COUNT_EXHAUSTED);
    }
    a->epoch = epoch;
    a->floor_epoch = epoch;
    a->count_last = count;
    a->need_resync = false;
    a->resynced = true;
    a->n_resync++;
    a->n_ok++;
    (void)tc_auth_new_nonce(a); /* the challenge is spent */
    return TC_OK;
}

tc_status_t tc_auth_check(tc_auth_t *a, const tc_cmd_t *cmd)
{
    if (a == NULL || cmd == NULL) {
        return TC_E_NULL;
    }
    const tc_sec_t *s = &cmd->sec;
    if (a->insecure) {
        if (s->present) {
            return refuse(a, TC_E_AUTH_KEY_UNKNOWN); /* no key to verify it with */
        }
        a->n_ok++;
        return TC_OK;
    }
    if (!s->present || s->spi == 0u) {
        return refuse(a, TC_E_AUTH_MISSING);
    }
    const tc_auth_key_t *k = NULL;
    for (unsigned i = 0; i < a->n_keys && k == NULL; i++) {
        k = a->keys[i].id == s->spi ? &a->keys[i] : NULL;
    }
    if (k == NULL) {
        return refuse(a, TC_E_AUTH_KEY_UNKNOWN);
    }
    uint8_t mac[TC_SEC_MAC_LEN];
    if (s->auth_len > sizeof s->auth || tc_auth_mac(k->key, s->auth, s->auth_len, mac) != 0) {
        return refuse(a, TC_E_AUTH_BAD_MAC);
    }
    if (!mac_equal(mac, s->mac)) {
        /* not an ordinary command: a re-synchronisation bound to the challenge? */
        if (a->nonce_valid && tc_auth_resync_mac(k->key, a->nonce, s->auth, s->auth_len, mac) == 0 &&
            mac_equal(mac, s->mac)) {
            return resync(a, cmd);
        }
        return refuse(a, TC_E_AUTH_BAD_MAC);
    }
    if (a->need_resync) {
        return refuse(a, TC_E_AUTH_RESYNC_NEEDED);
    }
    if ((uint32_t)(s->arsn >> 32) != a->epoch) {
        return refuse(a, TC_E_AUTH_STALE_EPOCH);
    }
    const uint32_t count = (uint32_t)(s->arsn & 0xFFFFFFFFu);
    if (count > TC_AUTH_COUNT_MAX) {
        return refuse(a, TC_E_AUTH_COUNT_EXHAUSTED); /* nothing used up: the uplink stays usable */
    }
    if (count == 0u || count <= a->count_last) {
        return refuse(a, TC_E_AUTH_REPLAY);
    }
    a->count_last = count;
    a->n_ok++;
    return TC_OK;
}
