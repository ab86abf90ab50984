/* Unit tests of authenticated telecommands (docs/uplink.md 1a, 3a): the
 * security header and trailer in the portable codec (tc_packets.h:
 * serialise, parse, every length fault, plain and secured told apart), the
 * MAC check and anti-replay of tc_auth.h (a good command accepted; missing,
 * unknown key, wrong MAC, replayed, older and stale-epoch commands each
 * refused with its own code and counted), the dispatch calling it first
 * (nav_cmd_dispatch.h), key files (permissions, owner, format) and the
 * persisted boot epoch (tc_state.h). Keys are made here, never read from
 * the repository. Also measures the cost of one verify. */
#define _DEFAULT_SOURCE /* mkdtemp, mkfifo */
#include "tests/unit/support/testutil.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "firmware/app/nav_cmd_dispatch.h"
#include "firmware/linux/tc_auth.h"
#include "firmware/tlm/tc_packets.h"
#include "ground/tc_sign.h"
#include "firmware/app/tc_state.h"

static const tc_auth_key_t k_key1 = {
    1u, {0x10, 0x32, 0x54, 0x76, 0x98, 0xba, 0xdc, 0xfe, 0x01, 0x23, 0x45, 0x67, 0x89, 0xab, 0xcd, 0xef,
         0xf0, 0xe1, 0xd2, 0xc3, 0xb4, 0xa5, 0x96, 0x87, 0x78, 0x69, 0x5a, 0x4b, 0x3c, 0x2d, 0x1e, 0x0f}};
static const tc_auth_key_t k_key2 = {
    2u, {0xaa, 0x55, 0xaa, 0x55, 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08, 0x09, 0x0a, 0x0b, 0x0c,
         0x0d, 0x0e, 0x0f, 0x10, 0x11, 0x12, 0x13, 0x14, 0x15, 0x16, 0x17, 0x18, 0x19, 0x1a, 0x1b, 0x1c}};

static tc_cmd_t noop(void)
{
    tc_cmd_t c;
    memset(&c, 0, sizeof c);
    c.opcode = TC_OP_NOOP;
    return c;
}

/* A signed frame of cmd, deframed back into *out (status returned). */
static tc_status_t sign_and_receive(const tc_auth_key_t *k, const tc_cmd_t *cmd, uint16_t seq, uint64_t arsn,
                                    tc_cmd_t *out)
{
    uint8_t w[TC_MAX_WIRE];
    size_t n = 0;
    assert_int_equal(tc_sign_frame(k, cmd, seq, arsn, w, sizeof w, &n), TC_OK);
    tc_deframer_t d;
    tc_deframer_init(&d);
    tc_status_t st = TC_E_NULL;
    int frames = 0;
    for (size_t i = 0; i < n; i++) {
        frames += tc_deframer_push(&d, w[i], out, &st) ? 1 : 0;
    }
    assert_int_equal(frames, 1);
    return st;
}

static void test_security_header_layout(void **state)
{
    (void)state;
    tc_cmd_t c = noop();
    c.opcode = TC_OP_SET_MODE;
    c.u.mode = TLM_MODE_STANDBY;
    uint8_t p[TC_MAX_SEC_PACKET];
    size_t n = 0;
    const uint64_t arsn = (uint64_t)7u << 32 | 0x01020304u;
    assert_int_equal(tc_sec_packet_encode(&c, 5, 9, arsn, p, sizeof p, &n), TC_OK);
    assert_int_equal(n, TC_HDR_LEN + 1u + TC_SEC_PREFIX_LEN); /* 8 + 1 + 10 */
    const uint8_t want[] = {0x19, 0x81, 0xC0, 0x05, 0x00, (uint8_t)(n + TC_SEC_MAC_LEN - 7u), /* primary */
                            0x00, 0x09,                                                       /* SPI 9 */
                            0, 0, 0, 7, 1, 2, 3, 4,                                           /* ARSN */
                            TC_OP_SET_MODE, 0x00, TLM_MODE_STANDBY};
    assert_int_equal(sizeof want, n);
    assert_memory_equal(p, want, n);
    memset(p + n, 0xA5, TC_SEC_MAC_LEN);
    tc_cmd_t out;
    assert_int_equal(tc_any_packet_decode(p, n + TC_SEC_MAC_LEN, &out), TC_OK);
    assert_true(out.sec.present);
    assert_int_equal(out.sec.spi, 9);
    assert_true(out.sec.arsn == arsn);
    assert_int_equal(out.sec.auth_len, n);
    assert_memory_equal(out.sec.auth, p, n);
    assert_int_equal(out.sec.mac[0], 0xA5);
    assert_int_equal(out.opcode, TC_OP_SET_MODE);
    assert_int_equal(out.u.mode, TLM_MODE_STANDBY);
    assert_int_equal(out.seq, 5);

    /* a plain packet still decodes, marked not secured */
    uint8_t q[TC_MAX_PACKET];
    size_t qn = 0;
    assert_int_equal(tc_packet_encode(&c, 5, q, sizeof q, &qn), TC_OK);
    assert_int_equal(tc_any_packet_decode(q, qn, &out), TC_OK);
    assert_false(out.sec.present);

    /* faults: cut (runt), a byte short (length), the length field off, an
     * argument out of range under the header, SPI out of range on encode */
    assert_int_equal(tc_any_packet_decode(p, TC_HDR_LEN + TC_SEC_OVERHEAD - 1u, &out), TC_E_RUNT);
    assert_int_equal(tc_any_packet_decode(p, n + TC_SEC_MAC_LEN - 1u, &out), TC_E_LENGTH);
    p[5]++;
    assert_int_equal(tc_any_packet_decode(p, n + TC_SEC_MAC_LEN, &out), TC_E_LENGTH);
    p[5]--;
    p[18] = 3; /* SET_MODE 3: not a mode */
    assert_int_equal(tc_any_packet_decode(p, n + TC_SEC_MAC_LEN, &out), TC_E_ARG);
    assert_true(out.sec.present); /* the header was read, for the event */
    p[5] = 0;                     /* data length smaller than the security bytes */
    assert_int_equal(tc_any_packet_decode(p, n + TC_SEC_MAC_LEN, &out), TC_E_LENGTH);
    assert_int_equal(tc_sec_packet_encode(&c, 5, 0, arsn, p, sizeof p, &n), TC_E_HEADER);
    assert_int_equal(tc_sec_packet_encode(&c, 5, TC_SPI_MAX + 1u, arsn, p, sizeof p, &n), TC_E_HEADER);
    assert_int_equal(tc_sec_packet_encode(&c, 5, 1, arsn, p, TC_HDR_LEN + 5u, &n), TC_E_NULL);
    uint8_t big[TC_MAX_SEC_PACKET + 8u] = {0x19, 0x81, 0xC0, 0x00, 0x00, 0x00, 0x00};
    assert_int_equal(tc_any_packet_decode(big, sizeof big, &out), TC_E_OVERSIZE);
}

static void test_every_opcode_signed_round_trip(void **state)
{
    (void)state;
    for (unsigned opn = 1; opn <= (unsigned)TC_OP_MAX; opn++) {
        const uint8_t op = (uint8_t)opn;
        tc_cmd_t c = noop();
        c.opcode = op;
        if (op == TC_OP_SET_MODE) {
            c.u.mode = TLM_MODE_ACQUIRE;
        } else if (op == TC_OP_TABLE_LOAD) {
            (void)snprintf(c.u.path, sizeof c.u.path, "t.mfnstbl");
        } else if (op == TC_OP_UPLOAD_START) {
            c.u.upload_start.size = 1u;
            (void)snprintf(c.u.upload_start.name, sizeof c.u.upload_start.name, "t.mfnstbl");
        } else if (op == TC_OP_UPLOAD_DATA) {
            c.u.upload_data.len = 1u;
        }
        tc_cmd_t out;
        const uint64_t arsn = (uint64_t)3u << 32 | op;
        assert_int_equal(sign_and_receive(&k_key2, &c, op, arsn, &out), TC_OK);
        assert_true(out.sec.present);
        assert_int_equal(out.opcode, op);
        assert_int_equal(out.sec.spi, 2);
        tc_auth_t a;
        tc_auth_init(&a, &k_key2, 1, 3);
        assert_int_equal(tc_auth_check(&a, &out), TC_OK);
    }
}

static void test_auth_codes(void **state)
{
    (void)state;
    const tc_auth_key_t keys[2] = {k_key1, k_key2};
    tc_auth_t a;
    tc_auth_init(&a, keys, 2, 5);
    const tc_cmd_t c = noop();
    tc_cmd_t r;
    const uint64_t e5 = (uint64_t)5u << 32;

    assert_int_equal(sign_and_receive(&k_key1, &c, 0, e5 | 1u, &r), TC_OK);
    assert_int_equal(tc_auth_check(&a, &r), TC_OK); /* good */
    assert_int_equal(tc_auth_check(&a, &r), TC_E_AUTH_REPLAY); /* the same again */
    assert_int_equal(sign_and_receive(&k_key2, &c, 1, e5 | 3u, &r), TC_OK);
    assert_int_equal(tc_auth_check(&a, &r), TC_OK); /* the second key (rotation), a gap is fine */
    assert_int_equal(sign_and_receive(&k_key1, &c, 2, e5 | 2u, &r), TC_OK);
    assert_int_equal(tc_auth_check(&a, &r), TC_E_AUTH_REPLAY); /* older than the last */
    assert_int_equal(sign_and_receive(&k_key1, &c, 2, e5 | 0u, &r), TC_OK);
    assert_int_equal(tc_auth_check(&a, &r), TC_E_AUTH_REPLAY); /* count 0 is never valid */
    assert_int_equal(sign_and_receive(&k_key1, &c, 2, ((uint64_t)4u << 32) | 100u, &r), TC_OK);
    assert_int_equal(tc_auth_check(&a, &r), TC_E_AUTH_STALE_EPOCH); /* before the last reboot */
    assert_int_equal(sign_and_receive(&k_key1, &c, 2, ((uint64_t)6u << 32) | 100u, &r), TC_OK);
    assert_int_equal(tc_auth_check(&a, &r), TC_E_AUTH_STALE_EPOCH); /* not this boot's either */

    tc_auth_key_t k9 = k_key1;
    k9.id = 9;
    assert_int_equal(sign_and_receive(&k9, &c, 3, e5 | 10u, &r), TC_OK);
    assert_int_equal(tc_auth_check(&a, &r), TC_E_AUTH_KEY_UNKNOWN);
    tc_auth_key_t wrong = k_key1;
    wrong.key[31] ^= 1u;
    assert_int_equal(sign_and_receive(&wrong, &c, 3, e5 | 10u, &r), TC_OK);
    assert_int_equal(tc_auth_check(&a, &r), TC_E_AUTH_BAD_MAC); /* right id, wrong key */
    assert_int_equal(sign_and_receive(&k_key1, &c, 3, e5 | 10u, &r), TC_OK);
    tc_cmd_t t = r;
    t.sec.mac[0] ^= 0x80u;
    assert_int_equal(tc_auth_check(&a, &t), TC_E_AUTH_BAD_MAC); /* MAC altered */
    t = r;
    t.sec.auth[8 + 7] ^= 1u; /* ARSN altered after signing (count 10 -> 11) */
    t.sec.arsn ^= 1u;
    assert_int_equal(tc_auth_check(&a, &t), TC_E_AUTH_BAD_MAC);
    t = r;
    t.sec.spi = 0;
    assert_int_equal(tc_auth_check(&a, &t), TC_E_AUTH_MISSING);
    t = r;
    t.sec.present = false;
    assert_int_equal(tc_auth_check(&a, &t), TC_E_AUTH_MISSING); /* plain */
    assert_int_equal(tc_auth_check(&a, &r), TC_OK); /* the untouched one still passes */

    assert_int_equal(a.n_ok, 3);
    assert_int_equal(a.n_rej[TC_E_AUTH_MISSING - TC_E_AUTH_MISSING], 2);
    assert_int_equal(a.n_rej[TC_E_AUTH_KEY_UNKNOWN - TC_E_AUTH_MISSING], 1);
    assert_int_equal(a.n_rej[TC_E_AUTH_BAD_MAC - TC_E_AUTH_MISSING], 3);
    assert_int_equal(a.n_rej[TC_E_AUTH_REPLAY - TC_E_AUTH_MISSING], 3);
    assert_int_equal(a.n_rej[TC_E_AUTH_STALE_EPOCH - TC_E_AUTH_MISSING], 2);
    assert_int_equal(a.count_last, 10);

    /* insecure: plain passes, a secured one has no key to be checked with */
    tc_auth_t in;
    tc_auth_init(&in, NULL, 0, 0);
    assert_true(in.insecure);
    assert_int_equal(tc_auth_check(&in, &t), TC_OK);
    assert_int_equal(tc_auth_check(&in, &r), TC_E_AUTH_KEY_UNKNOWN);
    assert_int_equal(tc_auth_check(NULL, &r), TC_E_NULL);
    tc_auth_clear(&a);
    assert_int_equal(a.n_keys, 0);
    assert_int_equal(a.keys[0].key[0], 0);
}

/* The dispatch: authentication first, its code in CMD_REJECTED, nothing acts,
 * the sequence reference does not move. */
static int g_calls;
static int32_t g_last_arg1;
static tc_status_t f_noop(void *ctx, const tc_cmd_t *cmd, int32_t *arg1)
{
    (void)ctx;
    (void)cmd;
    (void)arg1;
    g_calls++;
    return TC_OK;
}
static void f_event(void *ctx, tlm_event_code_t code, tlm_severity_t sev, uint8_t subject, int32_t arg0,
                    int32_t arg1)
{
    (void)ctx;
    (void)code;
    (void)sev;
    (void)subject;
    (void)arg0;
    g_last_arg1 = arg1;
}
static tc_status_t f_auth(void *ctx, const tc_cmd_t *cmd)
{
    return tc_auth_check(ctx, cmd);
}

static void test_dispatch_authenticates_first(void **state)
{
    (void)state;
    static const nav_cmd_fn_t table[TC_OP_MAX + 1] = {[TC_OP_NOOP] = f_noop};
    tc_auth_t a;
    tc_auth_init(&a, &k_key1, 1, 2);
    const nav_cmd_ops_t ops = {&a, table, TC_OP_MAX + 1u, f_event, f_auth};
    nav_cmd_t c;
    nav_cmd_init(&c);
    const tc_cmd_t cmd = noop();
    tc_cmd_t r;
    g_calls = 0;
    assert_int_equal(sign_and_receive(&k_key1, &cmd, 9, (uint64_t)1u << 32 | 1u, &r), TC_OK);
    nav_cmd_handle(&c, &r, TC_OK, &ops);
    assert_int_equal(g_last_arg1, TC_E_AUTH_STALE_EPOCH);
    assert_int_equal(g_calls, 0);
    assert_false(c.have_last);
    assert_int_equal(c.n_rejected, 1);
    assert_int_equal(sign_and_receive(&k_key1, &cmd, 9, (uint64_t)2u << 32 | 1u, &r), TC_OK);
    nav_cmd_handle(&c, &r, TC_OK, &ops);
    assert_int_equal(g_calls, 1);
    assert_int_equal(c.n_accepted, 1);
    assert_int_equal(c.seq_last, 9);
    nav_cmd_handle(&c, &r, TC_OK, &ops); /* replay: refused by the ARSN before the sequence guard */
    assert_int_equal(g_last_arg1, TC_E_AUTH_REPLAY);
    assert_int_equal(g_calls, 1);
}

/* ---- key files and the state directory (real files in a temporary directory) ---- */

static char g_dir[64];

static int setup_dir(void **state)
{
    (void)state;
    (void)snprintf(g_dir, sizeof g_dir, "/tmp/mfns-tc-auth-XXXXXX");
    return mkdtemp(g_dir) == NULL ? -1 : 0;
}

/* Removes what the tests made: files, one level of directories, the directory. */
static int remove_tree(const char *dir, int depth)
{
    DIR *d = opendir(dir);
    if (d == NULL) {
        return -1;
    }
    for (struct dirent *e = readdir(d); e != NULL; e = readdir(d)) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0) {
            continue;
        }
        char p[512];
        if (snprintf(p, sizeof p, "%s/%.255s", dir, e->d_name) >= (int)sizeof p) {
            continue;
        }
        struct stat st;
        if (lstat(p, &st) == 0 && S_ISDIR(st.st_mode) && depth > 0) {
            (void)remove_tree(p, depth - 1);
        } else {
            (void)unlink(p);
        }
    }
    (void)closedir(d);
    return rmdir(dir);
}

static int teardown_dir(void **state)
{
    (void)state;
    return remove_tree(g_dir, 1) == 0 ? 0 : -1;
}

static const char *write_file(const char *name, const char *text, mode_t mode)
{
    static char path[128];
    (void)snprintf(path, sizeof path, "%s/%s", g_dir, name);
    (void)unlink(path);
    const int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, 0600);
    assert_true(fd >= 0);
    assert_int_equal(write(fd, text, strlen(text)), (ssize_t)strlen(text));
    assert_int_equal(close(fd), 0);
    assert_int_equal(chmod(path, mode), 0);
    return path;
}

#define HEX1 "00112233445566778899aabbccddeeff00112233445566778899aabbccddeeff"

static void test_key_files(void **state)
{
    (void)state;
    tc_auth_key_t keys[TC_AUTH_MAX_KEYS];
    unsigned n = 9;
    char err[512];
    const char *p = write_file("k", "# board key\n1 " HEX1 "\n\n  2\t" HEX1 "  # next\n", 0600);
    assert_int_equal(tc_auth_read_keys(p, keys, TC_AUTH_MAX_KEYS, &n, err, sizeof err), 0);
    assert_int_equal(n, 2);
    assert_int_equal(keys[0].id, 1);
    assert_int_equal(keys[1].id, 2);
    assert_int_equal(keys[0].key[1], 0x11);
    assert_int_equal(keys[1].key[31], 0xff);
    assert_int_equal(chmod(p, 0400), 0);
    assert_int_equal(tc_auth_read_keys(p, keys, TC_AUTH_MAX_KEYS, &n, err, sizeof err), 0);

    const mode_t bad_modes[] = {0644, 0640, 0604, 0660, 0700, 0606};
    for (size_t i = 0; i < sizeof bad_modes / sizeof bad_modes[0]; i++) {
        assert_int_equal(chmod(p, bad_modes[i]), 0);
        assert_int_equal(tc_auth_read_keys(p, keys, TC_AUTH_MAX_KEYS, &n, err, sizeof err), -1);
        assert_non_null(strstr(err, "must be mode 0600 or 0400"));
        assert_int_equal(n, 0);
    }
    const char *bad[] = {
        "1 " HEX1 "0\n",                        /* 65 digits */
        "1 " HEX1 "\n1 " HEX1 "\n",             /* id twice */
        "0 " HEX1 "\n",                         /* SPI 0 */
        "256 " HEX1 "\n",                       /* SPI too large */
        "1 0011\n",                             /* short */
        "1 zz112233445566778899aabbccddeeff00112233445566778899aabbccddeeff\n",
        "# nothing\n",                          /* no key */
        "1 " HEX1 "\n2 " HEX1 "\n3 " HEX1 "\n4 " HEX1 "\n5 " HEX1 "\n", /* too many */
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        p = write_file("k", bad[i], 0600);
        assert_int_equal(tc_auth_read_keys(p, keys, TC_AUTH_MAX_KEYS, &n, err, sizeof err), -1);
        assert_int_equal(n, 0);
    }
    /* not a regular file (a FIFO never blocks the open), missing, a symlink */
    char fifo[128];
    (void)snprintf(fifo, sizeof fifo, "%s/fifo", g_dir);
    assert_int_equal(mkfifo(fifo, 0600), 0);
    assert_int_equal(tc_auth_read_keys(fifo, keys, TC_AUTH_MAX_KEYS, &n, err, sizeof err), -1);
    assert_non_null(strstr(err, "not a regular file"));
    assert_int_equal(tc_auth_read_keys(g_dir, keys, TC_AUTH_MAX_KEYS, &n, err, sizeof err), -1);
    char missing[128];
    (void)snprintf(missing, sizeof missing, "%s/none", g_dir);
    assert_int_equal(tc_auth_read_keys(missing, keys, TC_AUTH_MAX_KEYS, &n, err, sizeof err), -1);
    p = write_file("k", "1 " HEX1 "\n", 0600);
    char link[128];
    (void)snprintf(link, sizeof link, "%s/link", g_dir);
    assert_int_equal(symlink(p, link), 0);
    assert_int_equal(tc_auth_read_keys(link, keys, TC_AUTH_MAX_KEYS, &n, err, sizeof err), -1);
}

static void test_state_epoch(void **state)
{
    (void)state;
    char dir[96];
    (void)snprintf(dir, sizeof dir, "%s/state", g_dir);
    assert_int_equal(mkdir(dir, 0700), 0);
    char err[256];
    uint32_t e = 0;
    for (uint32_t want = 1; want <= 3; want++) {
        assert_int_equal(tc_state_next_epoch(dir, &e, err, sizeof err), 0);
        assert_int_equal(e, want);
    }
    char path[160];
    (void)snprintf(path, sizeof path, "%s/%s", dir, TC_STATE_FILE);
    struct stat st;
    assert_int_equal(stat(path, &st), 0);
    assert_int_equal(st.st_mode & 0777, 0600);
    char tmp[170];
    (void)snprintf(tmp, sizeof tmp, "%s.tmp", path);
    assert_int_not_equal(access(tmp, F_OK), 0); /* renamed away */
    /* a torn or edited file is refused, never reset to 0 */
    const char *bad[] = {"epoch \n", "epoch x\n", "garbage", "epoch 99999999999\n", ""};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        FILE *f = fopen(path, "w");
        assert_non_null(f);
        (void)fputs(bad[i], f);
        assert_int_equal(fclose(f), 0);
        assert_int_equal(tc_state_next_epoch(dir, &e, err, sizeof err), -1);
    }
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    (void)fputs("epoch 4294967295\n", f);
    assert_int_equal(fclose(f), 0);
    assert_int_equal(tc_state_next_epoch(dir, &e, err, sizeof err), -1); /* exhausted */
    char nodir[128];
    (void)snprintf(nodir, sizeof nodir, "%s/absent", g_dir);
    assert_int_equal(tc_state_next_epoch(nodir, &e, err, sizeof err), -1);
}

/* A re-synchronisation frame (the ground's half, as ground/uplink_auth.c builds it): a NOOP
 * for epoch << 32 | count, MACed with the challenge. */
static tc_status_t resync_receive(const tc_auth_key_t *k, uint64_t nonce, uint16_t seq, uint64_t arsn, tc_cmd_t *out)
{
    const tc_cmd_t c = noop();
    uint8_t pkt[TC_MAX_SEC_PACKET];
    size_t n = 0;
    assert_int_equal(tc_sec_packet_encode(&c, seq, k->id, arsn, pkt, sizeof pkt, &n), TC_OK);
    assert_int_equal(tc_auth_resync_mac(k->key, nonce, pkt, n, pkt + n), 0);
    uint8_t w[TC_MAX_WIRE];
    size_t wn = 0;
    assert_int_equal(tc_packet_frame(pkt, n + TC_SEC_MAC_LEN, w, sizeof w, &wn), TC_OK);
    tc_deframer_t d;
    tc_deframer_init(&d);
    tc_status_t st = TC_E_NULL;
    for (size_t i = 0; i < wn; i++) {
        (void)tc_deframer_push(&d, w[i], out, &st);
    }
    return st;
}

/* Epochs from the ground (issue 45): nothing passes before a re-synchronisation bound to the
 * challenge; a recorded one (another challenge) or one not above the floor is refused; the
 * challenge is spent by use; the count space keeps a margin that cannot wedge the uplink. */
static void test_resync_and_count_exhaustion(void **state)
{
    (void)state;
    tc_auth_t a;
    tc_auth_init(&a, &k_key1, 1, 0);
    tc_auth_require_resync(&a, 40u, TC_AUTH_ST_STATE_MISSING);
    assert_true(a.need_resync && a.nonce_valid && a.nonce != 0u);
    assert_int_equal(tc_auth_state_bits(&a), TC_AUTH_ST_RESYNC_NEEDED | TC_AUTH_ST_STATE_MISSING);
    const tc_cmd_t c = noop();
    tc_cmd_t r;
    const uint64_t n0 = a.nonce;
    /* an ordinary signed command: refused until the re-synchronisation */
    assert_int_equal(sign_and_receive(&k_key1, &c, 0, ((uint64_t)41u << 32) | 1u, &r), TC_OK);
    assert_int_equal(tc_auth_check(&a, &r), TC_E_AUTH_RESYNC_NEEDED);
    /* bound to another boot's challenge (a recording): no MAC verifies */
    assert_int_equal(resync_receive(&k_key1, n0 ^ 1u, 0, ((uint64_t)41u << 32) | 1u, &r), TC_OK);
    assert_int_equal(tc_auth_check(&a, &r), TC_E_AUTH_BAD_MAC);
    /* not above the floor */
    assert_int_equal(resync_receive(&k_key1, n0, 0, ((uint64_t)40u << 32) | 1u, &r), TC_OK);
    assert_int_equal(tc_auth_check(&a, &r), TC_E_AUTH_STALE_EPOCH);
    assert_true(a.need_resync);
    /* the genuine one */
    assert_int_equal(resync_receive(&k_key1, n0, 0, ((uint64_t)41u << 32) | 1u, &r), TC_OK);
    assert_int_equal(tc_auth_check(&a, &r), TC_OK);
    assert_true(!a.need_resync && a.resynced && a.epoch == 41u && a.count_last == 1u && a.n_resync == 1u);
    assert_true(a.nonce != n0); /* spent */
    assert_int_equal(tc_auth_check(&a, &r), TC_E_AUTH_BAD_MAC); /* the same again: its challenge is gone */
    const uint64_t e41 = (uint64_t)41u << 32;
    assert_int_equal(sign_and_receive(&k_key1, &c, 1, e41 | 2u, &r), TC_OK);
    assert_int_equal(tc_auth_check(&a, &r), TC_OK);
    /* a validly signed 0xFFFFFFFF, and one inside the margin: refused, nothing used up */
    assert_int_equal(sign_and_receive(&k_key1, &c, 2, e41 | 0xFFFFFFFFu, &r), TC_OK);
    assert_int_equal(tc_auth_check(&a, &r), TC_E_AUTH_COUNT_EXHAUSTED);
    assert_int_equal(sign_and_receive(&k_key1, &c, 2, e41 | (TC_AUTH_COUNT_MAX + 1u), &r), TC_OK);
    assert_int_equal(tc_auth_check(&a, &r), TC_E_AUTH_COUNT_EXHAUSTED);
    assert_int_equal(a.count_last, 2u);
    assert_int_equal(sign_and_receive(&k_key1, &c, 2, e41 | 3u, &r), TC_OK);
    assert_int_equal(tc_auth_check(&a, &r), TC_OK); /* not wedged */
    assert_int_equal(sign_and_receive(&k_key1, &c, 3, e41 | TC_AUTH_COUNT_MAX, &r), TC_OK);
    assert_int_equal(tc_auth_check(&a, &r), TC_OK);
    assert_true((tc_auth_state_bits(&a) & TC_AUTH_ST_COUNT_LOW) != 0u); /* the ground re-synchronises */
    /* a new epoch with the new challenge: the way on */
    assert_int_equal(resync_receive(&k_key1, a.nonce, 4, ((uint64_t)42u << 32) | 1u, &r), TC_OK);
    assert_int_equal(tc_auth_check(&a, &r), TC_OK);
    assert_true(a.epoch == 42u && a.count_last == 1u && (tc_auth_state_bits(&a) & TC_AUTH_ST_COUNT_LOW) == 0u);
    assert_int_equal(a.n_rej[TC_E_AUTH_COUNT_EXHAUSTED - TC_E_AUTH_MISSING], 2);
    assert_int_equal(a.n_rej[TC_E_AUTH_RESYNC_NEEDED - TC_E_AUTH_MISSING], 1);
    tc_auth_clear(&a);
}

/* The uplink report: MACed under each key in turn; any field changed fails; another key's
 * turn does not verify under this one; domain separated from a command MAC. */
static void test_uplink_report(void **state)
{
    (void)state;
    const tc_auth_key_t keys[2] = {k_key1, k_key2};
    tc_auth_t a;
    tc_auth_init(&a, keys, 2, 0);
    tc_auth_report_t r1, r2;
    tc_auth_report(&a, &r1);
    tc_auth_report(&a, &r2);
    assert_int_equal(r1.spi, 1);
    assert_int_equal(r2.spi, 2);
    assert_true(tc_auth_report_verify(&k_key1, &r1));
    assert_false(tc_auth_report_verify(&k_key1, &r2)); /* key 2's turn */
    assert_true(tc_auth_report_verify(&k_key2, &r2));
    assert_true((r1.state & TC_AUTH_ST_RESYNC_NEEDED) != 0u && r1.nonce == a.nonce);
    tc_auth_report_t f = r1;
    f.count_last = 0xFFFFFFFFu;
    assert_false(tc_auth_report_verify(&k_key1, &f));
    f = r1;
    f.epoch ^= 1u;
    assert_false(tc_auth_report_verify(&k_key1, &f));
    f = r1;
    f.nonce ^= 1u;
    assert_false(tc_auth_report_verify(&k_key1, &f));
    f = r1;
    f.state = 0;
    assert_false(tc_auth_report_verify(&k_key1, &f));
    f = r1;
    f.spi = 0;
    assert_false(tc_auth_report_verify(&k_key1, &f));
    /* insecure: no MAC, spi 0, the INSECURE bit */
    tc_auth_t in;
    tc_auth_init(&in, NULL, 0, 0);
    tc_auth_report(&in, &f);
    assert_true(f.spi == 0u && (f.state & TC_AUTH_ST_INSECURE) != 0u);
    tc_auth_clear(&a);
}

/* The live uplink's state: classified, never fatal, never read as 0 when damaged. */
static void test_state_classified(void **state)
{
    (void)state;
    char dir[96];
    (void)snprintf(dir, sizeof dir, "%s/st2", g_dir);
    char err[256];
    uint32_t e = 7;
    int en = 0;
    assert_int_equal(tc_state_read(dir, &e, &en, err, sizeof err), TC_STATE_MISSING); /* no directory */
    assert_int_equal(e, 0u);
    assert_int_equal(mkdir(dir, 0700), 0);
    assert_int_equal(tc_state_read(dir, &e, &en, err, sizeof err), TC_STATE_MISSING);
    assert_int_equal(en, ENOENT);
    assert_int_equal(tc_state_probe_write(dir), 0);
    assert_int_equal(tc_state_write(dir, 77u, err, sizeof err), 0);
    assert_int_equal(tc_state_read(dir, &e, &en, err, sizeof err), TC_STATE_OK);
    assert_int_equal(e, 77u);
    char path[160];
    (void)snprintf(path, sizeof path, "%s/%s", dir, TC_STATE_FILE);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    (void)fputs("epoch banana\n", f);
    assert_int_equal(fclose(f), 0);
    assert_int_equal(tc_state_read(dir, &e, &en, err, sizeof err), TC_STATE_DAMAGED);
    assert_int_equal(e, 0u);
    /* a file where the directory should be */
    char notdir[128];
    (void)snprintf(notdir, sizeof notdir, "%s/afile", g_dir);
    f = fopen(notdir, "w");
    assert_non_null(f);
    assert_int_equal(fclose(f), 0);
    assert_int_equal(tc_state_read(notdir, &e, &en, err, sizeof err), TC_STATE_UNWRITABLE);
    assert_int_not_equal(tc_state_probe_write(notdir), 0);
    assert_int_not_equal(tc_state_write(notdir, 5u, err, sizeof err), 0);
}

/* The cost of one verify (deframed command in hand): printed for docs/uplink.md. */
static void test_verify_cost(void **state)
{
    (void)state;
    tc_auth_t a;
    tc_auth_init(&a, &k_key1, 1, 1);
    tc_cmd_t c = noop();
    c.opcode = TC_OP_TABLE_LOAD;
    (void)snprintf(c.u.path, sizeof c.u.path, "/data/tables/next.mfnstbl");
    tc_cmd_t r;
    enum { N = 20000 };
    assert_int_equal(sign_and_receive(&k_key1, &c, 0, (uint64_t)1u << 32 | 1u, &r), TC_OK);
    struct timespec t0, t1;
    (void)clock_gettime(CLOCK_MONOTONIC, &t0);
    for (uint32_t i = 0; i < N; i++) {
        a.count_last = 0; /* the same command verified again and again */
        assert_int_equal(tc_auth_check(&a, &r), TC_OK);
    }
    (void)clock_gettime(CLOCK_MONOTONIC, &t1);
    const double ns = ((double)(t1.tv_sec - t0.tv_sec) * 1e9 + (double)(t1.tv_nsec - t0.tv_nsec)) / N;
    print_message("tc_auth: %.0f ns per verify (HMAC-SHA-256 over %u bytes); %u bytes added per command\n", ns,
                  (unsigned)r.sec.auth_len, (unsigned)TC_SEC_OVERHEAD);
    assert_true(ns < 1e6); /* far below a 53.8-ms cycle even for 4 commands */
}

int main(void)
{
    if (!tc_auth_available()) {
        print_message("tc_auth: built without libcrypto: skipped\n");
        return 0;
    }
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_security_header_layout),
        cmocka_unit_test(test_every_opcode_signed_round_trip),
        cmocka_unit_test(test_auth_codes),
        cmocka_unit_test(test_dispatch_authenticates_first),
        cmocka_unit_test(test_key_files),
        cmocka_unit_test(test_state_epoch),
        cmocka_unit_test(test_resync_and_count_exhaustion),
        cmocka_unit_test(test_uplink_report),
        cmocka_unit_test(test_state_classified),
        cmocka_unit_test(test_verify_cost),
    };
    return cmocka_run_group_tests_name("tc_auth", tests, setup_dir, teardown_dir);
}
