/* libFuzzer target for mfns-ground's command inputs: the command grammar
 * (ground/uplink.h uplink_parse_line: --cmd, --cmd-file, stdin) and the
 * datagram intake of --udp-tc / --tc-socket (a CCSDS TC packet validated
 * with tc_packet_decode, then signed with uplink_auth_frame and sent up).
 *
 * The input is split at '\n' into lines for the grammar; the whole input is
 * also one datagram. Invariants (abort on violation):
 *   - a line that parses as a command encodes (the grammar validates what
 *     the flight side would), and its signed frame decodes back to the same
 *     opcode and arguments with a MAC that verifies;
 *   - a datagram the intake accepts re-encodes to the same packet bytes
 *     (with the count it carried) and its signed frame verifies too.
 * Build: clang -fsanitize=fuzzer,address,undefined with -lcrypto (mk/uplink.mk).
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "firmware/linux/tc_auth.h"
#include "firmware/tlm/tc_packets.h"
#include "ground/uplink.h"
#include "ground/uplink_auth.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check(int cond)
{
    if (!cond) {
        abort();
    }
}

static const tc_auth_key_t k_key = {
    3u, {9, 8, 7, 6, 5, 4, 3, 2, 1, 0, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0, 42, 43}};

/* Sign c as the ground does, receive it as the flight does: it must verify. */
static void sign_and_verify(const tc_cmd_t *c, uint32_t count)
{
    uplink_auth_t a;
    memset(&a, 0, sizeof a);
    a.on = true;
    a.key = k_key;
    a.epoch_known = true;
    a.epoch = 5u;
    a.next_count = count;
    uint8_t w[TC_MAX_WIRE];
    size_t n = 0;
    check(uplink_auth_frame(&a, c, 17u, w, sizeof w, &n) == TC_OK);
    tc_deframer_t d;
    tc_deframer_init(&d);
    tc_cmd_t r;
    tc_status_t st = TC_E_NULL;
    int frames = 0;
    for (size_t i = 0; i < n; i++) {
        frames += tc_deframer_push(&d, w[i], &r, &st) ? 1 : 0;
    }
    check(frames == 1 && st == TC_OK);
    uint8_t pa[TC_MAX_PACKET], pb[TC_MAX_PACKET]; /* same command: the same packet bytes */
    size_t an = 0, bn = 0;
    check(tc_packet_encode(&r, 17u, pa, sizeof pa, &an) == TC_OK);
    check(tc_packet_encode(c, 17u, pb, sizeof pb, &bn) == TC_OK);
    check(an == bn && memcmp(pa, pb, an) == 0);
    tc_auth_t v;
    tc_auth_init(&v, &k_key, 1, 5u);
    check(tc_auth_check(&v, &r) == TC_OK);
    check(tc_auth_check(&v, &r) == TC_E_AUTH_REPLAY);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char line[UPLINK_LINE_MAX + 1];
    size_t start = 0;
    for (size_t i = 0; i <= size; i++) {
        if (i < size && data[i] != '\n') {
            continue;
        }
        const size_t len = i - start;
        if (len <= UPLINK_LINE_MAX) {
            memcpy(line, data + start, len);
            line[len] = '\0';
            uplink_line_kind_t kind = UPLINK_LINE_EMPTY;
            tc_cmd_t c;
            double w = 0;
            char err[192];
            if (uplink_parse_line(line, &kind, &c, &w, err, sizeof err) == 0 && kind == UPLINK_LINE_CMD) {
                uint8_t p[TC_MAX_PACKET];
                size_t pn = 0;
                check(tc_packet_encode(&c, 0u, p, sizeof p, &pn) == TC_OK);
                sign_and_verify(&c, 1u + (uint32_t)len);
            }
        }
        start = i + 1u;
    }
    /* the datagram intake (udp_tc_poll's check) */
    if (size <= TC_MAX_PACKET + 1u) {
        tc_cmd_t c;
        if (tc_packet_decode(data, size, &c) == TC_OK) {
            uint8_t p[TC_MAX_PACKET];
            size_t pn = 0;
            check(tc_packet_encode(&c, c.seq, p, sizeof p, &pn) == TC_OK);
            check(pn == size && memcmp(p, data, size) == 0);
            sign_and_verify(&c, TC_AUTH_COUNT_MAX); /* the last usable count (issue 45: the top is reserved) */
            uplink_auth_t a;
            memset(&a, 0, sizeof a);
            a.on = true;
            a.key = k_key;
            a.epoch_known = true;
            a.epoch = 5u;
            a.next_count = TC_AUTH_COUNT_MAX + 1u;
            uint8_t w[TC_MAX_WIRE];
            size_t wn = 0;
            check(uplink_auth_frame(&a, &c, 17u, w, sizeof w, &wn) == TC_E_STATE); /* never signed */
        }
    }
    return 0;
}
