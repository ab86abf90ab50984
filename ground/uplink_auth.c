/* uplink_auth.c -- see uplink_auth.h. */
#ifndef _DEFAULT_SOURCE
#define _DEFAULT_SOURCE /* O_CLOEXEC, O_NOFOLLOW, fsync under -std=c11 */
#endif

#include "ground/uplink_auth.h"
#include "ground/tc_sign.h"

#include <errno.h>
#include <fcntl.h>
#include <libgen.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#define STATE_MAX 128 /* bytes of the ground's state file */

/* "max_epoch E\nepoch E\nnext_count C\n". 0 (absent: all 0), -1 damaged. */
static int state_read(uplink_auth_t *a, char *err, size_t err_size)
{
    const int fd = open(a->state_path, O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK);
    if (fd < 0) {
        if (errno == ENOENT) {
            return 0;
        }
        (void)snprintf(err, err_size, "%s: %s", a->state_path, strerror(errno));
        return -1;
    }
    char buf[STATE_MAX + 1];
    struct stat st;
    ssize_t n = -1;
    if (fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && st.st_size <= STATE_MAX) {
        n = read(fd, buf, STATE_MAX);
    }
    (void)close(fd);
    unsigned long long v[3] = {0, 0, 0};
    static const char *const names[3] = {"max_epoch ", "epoch ", "next_count "};
    bool ok = n > 0;
    if (ok) {
        buf[n] = '\0';
    }
    const char *s = buf;
    for (int i = 0; i < 3 && ok; i++) {
        const size_t nl = strlen(names[i]);
        char *end = NULL;
        errno = 0;
        ok = strncmp(s, names[i], nl) == 0 && s[nl] >= '0' && s[nl] <= '9';
        v[i] = ok ? strtoull(s + nl, &end, 10) : 0u;
        ok = ok && errno == 0 && end != NULL && *end == '\n' && v[i] <= UINT32_MAX;
        s = ok ? end + 1 : s;
    }
    const unsigned long long me = v[0], e = v[1], c = v[2];
    if (!ok || *s != '\0' || e > me) {
        (void)snprintf(err, err_size, "%s: damaged (want 'max_epoch E', 'epoch E', 'next_count C'); never reset: "
                                      "restore it or give the board a new key", a->state_path);
        return -1;
    }
    a->max_epoch = (uint32_t)me;
    a->epoch = (uint32_t)e;
    a->next_count = c == 0u ? 1u : (uint32_t)c;
    return 0;
}

/* Atomic: a temporary file, fsync, rename, fsync of the directory. 0 or -1. */
static int state_write(uplink_auth_t *a, uint32_t epoch, uint32_t next_count)
{
    if (a->state_path == NULL) {
        return 0; /* --tc-epoch without --tc-state: the operator keeps the counts */
    }
    char tmp[4096];
    char text[STATE_MAX];
    const uint32_t me = epoch > a->max_epoch ? epoch : a->max_epoch;
    const int len = snprintf(text, sizeof text, "max_epoch %u\nepoch %u\nnext_count %u\n", me, epoch, next_count);
    if (snprintf(tmp, sizeof tmp, "%s.tmp", a->state_path) >= (int)sizeof tmp) {
        return -1;
    }
    const int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC | O_NOFOLLOW, 0600);
    if (fd < 0) {
        return -1;
    }
    const bool ok = write(fd, text, (size_t)len) == (ssize_t)len && fsync(fd) == 0;
    if (close(fd) != 0 || !ok || rename(tmp, a->state_path) != 0) {
        (void)unlink(tmp);
        return -1;
    }
    char dir[4096];
    (void)snprintf(dir, sizeof dir, "%s", a->state_path);
    const int dfd = open(dirname(dir), O_RDONLY | O_CLOEXEC);
    if (dfd >= 0) {
        (void)fsync(dfd);
        (void)close(dfd);
    }
    a->max_epoch = me;
    return 0;
}

static void say_state_failed(uplink_auth_t *a)
{
    if (!a->state_failed_said) {
        a->state_failed_said = true;
        fprintf(stderr, "mfns-ground: --tc-state %s cannot be written (%s): nothing is signed until it can\n",
                a->state_path, strerror(errno));
    }
}

int uplink_auth_open(uplink_auth_t *a, const char *key_path, uint32_t epoch, const char *state_path, char *err,
                     size_t err_size)
{
    memset(a, 0, sizeof *a);
    if (key_path == NULL) {
        return 0;
    }
    a->state_path = state_path;
    a->next_count = 1u;
    if (state_path != NULL && state_read(a, err, err_size) != 0) {
        return -1;
    }
    tc_auth_key_t keys[TC_AUTH_MAX_KEYS];
    unsigned n = 0;
    if (tc_auth_read_keys(key_path, keys, TC_AUTH_MAX_KEYS, &n, err, err_size) != 0) {
        return -1;
    }
    a->on = true;
    a->key = keys[0]; /* the first key signs (docs/uplink.md: rotation) */
    tc_auth_wipe(keys, sizeof keys);
    if (epoch != 0u) { /* --tc-epoch: the operator vouches for it */
        if (epoch != a->epoch) {
            a->next_count = 1u;
        }
        a->epoch = epoch;
        a->epoch_known = true;
    }
    return 0;
}

bool uplink_auth_ready(const uplink_auth_t *a)
{
    return !a->on || (a->epoch_known && !a->resync_due);
}

tc_status_t uplink_auth_frame(uplink_auth_t *a, const tc_cmd_t *cmd, uint16_t seq, uint8_t *out, size_t cap,
                              size_t *out_len)
{
    if (!a->on) {
        return tc_frame_encode(cmd, seq, out, cap, out_len);
    }
    if (!a->epoch_known || a->next_count == 0u || a->next_count > TC_AUTH_COUNT_MAX) {
        return TC_E_STATE; /* not yet (or the epoch's counts used up: a re-synchronisation first) */
    }
    /* the count is on disk before the frame leaves: a crash never signs it twice */
    if (state_write(a, a->epoch, a->next_count + 1u) != 0) {
        say_state_failed(a);
        return TC_E_STATE;
    }
    const uint64_t arsn = (uint64_t)a->epoch << 32 | a->next_count;
    const tc_status_t st = tc_sign_frame(&a->key, cmd, seq, arsn, out, cap, out_len);
    if (st == TC_OK) {
        a->next_count++;
    }
    return st;
}

tc_status_t uplink_auth_resync_frame(uplink_auth_t *a, uint16_t seq, uint64_t now_ms, uint8_t *out, size_t cap,
                                     size_t *out_len)
{
    if (!a->on || !a->resync_due) {
        return TC_E_STATE;
    }
    if (a->resync_sent && a->resync_sent_nonce == a->resync_nonce && now_ms - a->resync_sent_ms < UPLINK_AUTH_RESYNC_RETRY_MS) {
        return TC_E_STATE; /* one is on its way */
    }
    /* the new epoch: above everything this ground ever gave, the board's floor, and UTC seconds
     * (a ground whose own state was lost still never goes back) */
    uint64_t e = (uint64_t)a->max_epoch + 1u;
    e = (uint64_t)a->resync_floor + 1u > e ? (uint64_t)a->resync_floor + 1u : e;
    const time_t now = time(NULL);
    if (now > (time_t)UPLINK_AUTH_UTC_PLAUSIBLE && (uint64_t)now > e && (uint64_t)now <= UINT32_MAX) {
        e = (uint64_t)now;
    }
    if (e > UINT32_MAX) {
        fprintf(stderr, "mfns-ground: command epochs used up: give the board a new key (docs/uplink.md)\n");
        return TC_E_STATE;
    }
    const uint32_t epoch = (uint32_t)e;
    if (state_write(a, epoch, 2u) != 0) { /* persisted before it leaves */
        say_state_failed(a);
        return TC_E_STATE;
    }
    tc_cmd_t c;
    memset(&c, 0, sizeof c);
    c.opcode = TC_OP_NOOP;
    uint8_t pkt[TC_MAX_SEC_PACKET];
    size_t n = 0;
    tc_status_t st = tc_sec_packet_encode(&c, seq, a->key.id, (uint64_t)epoch << 32 | 1u, pkt, sizeof pkt, &n);
    if (st == TC_OK && tc_auth_resync_mac(a->key.key, a->resync_nonce, pkt, n, pkt + n) != 0) {
        st = TC_E_NULL;
    }
    if (st == TC_OK) {
        st = tc_packet_frame(pkt, n + TC_SEC_MAC_LEN, out, cap, out_len);
    }
    if (st != TC_OK) {
        return st;
    }
    a->epoch = epoch;
    a->next_count = 2u;
    a->epoch_known = true;
    a->resync_due = false;
    a->resync_sent = true;
    a->resync_sent_nonce = a->resync_nonce;
    a->resync_sent_ms = now_ms;
    a->n_resync++;
    a->epoch_changes++;
    fprintf(stderr, "mfns-ground: uplink re-synchronisation: epoch %u for the board's challenge %016llx\n", epoch,
            (unsigned long long)a->resync_nonce);
    return TC_OK;
}

void uplink_auth_housekeeping(uplink_auth_t *a, const tlm_hk_t *hk, uint64_t now_ms)
{
    if (!a->on) {
        return; /* plain uplink */
    }
    tc_auth_report_t r;
    memset(&r, 0, sizeof r);
    r.spi = hk->tc_report_spi;
    r.epoch = hk->tc_epoch;
    r.count_last = hk->tc_arsn_last;
    r.nonce = (uint64_t)hk->tc_nonce_hi << 32 | hk->tc_nonce_lo;
    r.state = hk->tc_state;
    const uint32_t m[4] = {hk->tc_report_mac0, hk->tc_report_mac1, hk->tc_report_mac2, hk->tc_report_mac3};
    for (unsigned i = 0; i < 4u; i++) {
        r.mac[4u * i] = (uint8_t)(m[i] >> 24);
        r.mac[4u * i + 1u] = (uint8_t)(m[i] >> 16);
        r.mac[4u * i + 2u] = (uint8_t)(m[i] >> 8);
        r.mac[4u * i + 3u] = (uint8_t)m[i];
    }
    if (!tc_auth_report_verify(&a->key, &r)) {
        a->n_reports_ignored++; /* forged, garbled, or another key's turn: believed not at all */
        if (!a->ignored_said && r.spi == a->key.id) {
            a->ignored_said = true;
            fprintf(stderr, "mfns-ground: a housekeeping uplink report that does not verify under key %u: "
                            "ignored (forged or damaged)\n", a->key.id);
        }
        return;
    }
    a->n_reports_ok++;
    if (a->state_path == NULL) {
        return; /* --tc-epoch without --tc-state: the operator's epoch, no re-synchronisation */
    }
    const bool low = (r.state & TC_AUTH_ST_COUNT_LOW) != 0u || a->next_count > TC_AUTH_COUNT_LOW;
    if ((r.state & TC_AUTH_ST_RESYNC_NEEDED) != 0u || low || !a->epoch_known || r.epoch != a->epoch) {
        if (r.nonce == 0u) {
            return; /* the board has no challenge yet (no entropy): wait */
        }
        if (!(a->resync_sent && r.nonce == a->resync_sent_nonce && now_ms - a->resync_sent_ms < UPLINK_AUTH_RESYNC_RETRY_MS)) {
            a->resync_due = true;
            a->resync_nonce = r.nonce;
            a->resync_floor = r.epoch;
        }
        return;
    }
    if (r.count_last >= a->next_count) {
        a->next_count = r.count_last + 1u; /* the board saw a later count (another ground with this state) */
    }
}

void uplink_auth_close(uplink_auth_t *a)
{
    tc_auth_wipe(a, sizeof *a);
}
