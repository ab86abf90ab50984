/* libFuzzer target for authenticated telecommands: the security header and
 * trailer (firmware/tlm/tc_packets.h tc_any_packet_decode), the MAC and
 * anti-replay check (firmware/linux/tc_auth.h, OpenSSL's HMAC) and the flight
 * dispatch that calls it first (nav_cmd_dispatch.h), with two keys loaded
 * (ids 1 and 2) and boot epoch 7.
 *
 * The first input byte picks a mode:
 *   0  the rest is a raw uplink byte stream (deframer, decoder, auth, dispatch);
 *   1  the rest is one packet, framed with a valid CRC (reaches the security
 *      header parser and the MAC check past the CRC);
 *   2  the rest is one packet without its MAC, signed here with key 1 (or,
 *      when its SPI byte is 2, key 2) and framed: reaches the epoch and
 *      replay checks and the command decoder behind a valid MAC; sent twice,
 *      the second copy must be refused.
 * Invariants (abort on violation):
 *   - every frame gives exactly one event;
 *   - an action runs only for a command whose MAC verified under a loaded key,
 *     with this epoch and a count newer than every earlier accepted one;
 *   - no command passes twice (mode 2's copy is AUTH_REPLAY or refused earlier);
 *   - no count in the reserved top of the space passes (AUTH_COUNT_EXHAUSTED).
 * Build: clang -fsanitize=fuzzer,address,undefined with -lcrypto (mk/uplink.mk).
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "firmware/app/nav_cmd_dispatch.h"
#include "firmware/linux/tc_auth.h"
#include "firmware/tlm/tc_packets.h"
#include "ground/tc_sign.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#define EPOCH 7u

static void check(int cond)
{
    if (!cond) {
        abort();
    }
}

static const tc_auth_key_t k_keys[2] = {
    {1u, {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28,
          29, 30, 31, 32}},
    {2u, {0xF0, 0xE0, 0xD0, 0xC0, 0xB0, 0xA0, 0x90, 0x80, 0x70, 0x60, 0x50, 0x40, 0x30, 0x20, 0x10, 0x00, 0x0F,
          0x0E, 0x0D, 0x0C, 0x0B, 0x0A, 0x09, 0x08, 0x07, 0x06, 0x05, 0x04, 0x03, 0x02, 0x01, 0x00}},
};

static struct {
    tc_auth_t auth;
    unsigned events, accepted, passed;
    uint32_t last_count;
} g;

static tc_status_t a_any(void *ctx, const tc_cmd_t *cmd, int32_t *arg1)
{
    (void)ctx;
    (void)arg1;
    check(cmd->sec.present && (cmd->sec.spi == 1u || cmd->sec.spi == 2u));
    check((uint32_t)(cmd->sec.arsn >> 32) == EPOCH);
    return TC_OK;
}

static void a_event(void *ctx, tlm_event_code_t code, tlm_severity_t sev, uint8_t subject, int32_t arg0,
                    int32_t arg1)
{
    (void)ctx;
    (void)sev;
    (void)subject;
    (void)arg0;
    g.events++;
    if (code == TLM_EVT_CMD_ACCEPTED) {
        g.accepted++;
    } else {
        check(code == TLM_EVT_CMD_REJECTED && arg1 > 0 && arg1 <= TC_STATUS_MAX);
    }
}

static tc_status_t a_auth(void *ctx, const tc_cmd_t *cmd)
{
    (void)ctx;
    const tc_status_t st = tc_auth_check(&g.auth, cmd);
    if (st == TC_OK) {
        const uint32_t count = (uint32_t)(cmd->sec.arsn & 0xFFFFFFFFu);
        check(count > g.last_count); /* strictly newer than everything that passed */
        check(count <= TC_AUTH_COUNT_MAX); /* the reserved top never passes (issue 45) */
        g.last_count = count;
        uint8_t mac[TC_SEC_MAC_LEN];
        const tc_auth_key_t *k = cmd->sec.spi == 1u ? &k_keys[0] : &k_keys[1];
        check(tc_auth_mac(k->key, cmd->sec.auth, cmd->sec.auth_len, mac) == 0);
        check(memcmp(mac, cmd->sec.mac, sizeof mac) == 0);
        g.passed++;
    }
    return st;
}

#define ENTRY(NAME, opcode, bytes, count) [TC_OP_##NAME] = a_any,
static const nav_cmd_fn_t k_table[] = {TC_OPCODE_LIST(ENTRY)};
#undef ENTRY
static const nav_cmd_ops_t k_ops = {NULL, k_table, sizeof k_table / sizeof k_table[0], a_event, a_auth};

static uint32_t run_stream(nav_cmd_t *h, const uint8_t *p, size_t n)
{
    const uint32_t before = h->rx.frames;
    size_t off = 0;
    for (int guard = 0; off < n && guard < 100000; guard++) {
        unsigned done = 0;
        off += nav_cmd_feed(h, p + off, n - off, NAV_CMD_MAX_PER_CYCLE, &k_ops, &done);
    }
    return h->rx.frames - before;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1u) {
        return 0;
    }
    memset(&g, 0, sizeof g);
    tc_auth_init(&g.auth, k_keys, 2, EPOCH);
    nav_cmd_t h;
    nav_cmd_init(&h);
    const uint8_t mode = data[0] % 3u;
    const uint8_t *in = data + 1;
    const size_t n = size - 1u;
    uint8_t wire[2u * TC_MAX_WIRE];
    if (mode == 0u) {
        const uint32_t frames = run_stream(&h, in, n);
        check(g.events == frames);
        return 0;
    }
    if (n > TC_MAX_SEC_PACKET) {
        return 0;
    }
    uint8_t pkt[TC_MAX_SEC_PACKET + TC_SEC_MAC_LEN];
    memcpy(pkt, in, n);
    size_t pn = n;
    if (mode == 2u) {
        if (n + TC_SEC_MAC_LEN > TC_MAX_SEC_PACKET) {
            return 0;
        }
        const tc_auth_key_t *k = (n > 7u && in[7] == 2u) ? &k_keys[1] : &k_keys[0];
        check(tc_auth_mac(k->key, pkt, n, pkt + n) == 0);
        pn = n + TC_SEC_MAC_LEN;
    }
    size_t wn = 0;
    if (tc_packet_frame(pkt, pn, wire, TC_MAX_WIRE, &wn) != TC_OK) {
        return 0;
    }
    memcpy(wire + wn, wire, wn); /* the same frame twice */
    const uint32_t frames = run_stream(&h, wire, 2u * wn);
    check(g.events == frames);
    check(g.passed <= 1u); /* never twice */
    return 0;
}
