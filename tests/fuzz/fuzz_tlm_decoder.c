/* libFuzzer target for the telemetry decoder (firmware/tlm).
 *
 * The first input byte picks a mode:
 *   even  the rest is a raw byte stream pushed into the streaming decoder
 *         (and, split at 0x00, into the one-shot COBS/packet decoders);
 *   odd   the rest builds packets (type + field bytes) that are encoded into
 *         valid frames, then corrupted at input-chosen positions, so the
 *         fuzzer reaches deep decoder states past the CRC.
 * Invariants checked (abort on violation, which libFuzzer reports):
 *   - every decoded packet re-encodes to a packet that decodes identically;
 *   - counters are consistent (good + dropped frames <= delimiters seen);
 *   - an uncorrupted stream decodes completely with no errors.
 * Build: clang -fsanitize=fuzzer,address,undefined (mk/telemetry.mk).
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "firmware/tlm/cobs.h"
#include "firmware/tlm/crc16.h"
#include "firmware/tlm/tlm_decoder.h"
#include "firmware/tlm/tlm_packets.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check(int cond)
{
    if (!cond) {
        abort();
    }
}

static void check_roundtrip(const tlm_packet_t *p)
{
    uint8_t buf[TLM_MAX_PACKET];
    size_t n = 0;
    check(tlm_packet_encode(p, p->seq, buf, sizeof buf, &n) == TLM_OK);
    tlm_packet_t q;
    check(tlm_packet_decode(buf, n, &q) == TLM_OK);
    uint8_t buf2[TLM_MAX_PACKET];
    size_t n2 = 0;
    check(tlm_packet_encode(&q, q.seq, buf2, sizeof buf2, &n2) == TLM_OK);
    check(n == n2 && memcmp(buf, buf2, n) == 0);
}

static uint32_t push_all(tlm_decoder_t *d, const uint8_t *b, size_t n)
{
    uint32_t good = 0;
    for (size_t i = 0; i < n; i++) {
        tlm_packet_t p;
        const int rc = tlm_decoder_push(d, b[i], &p);
        check(rc <= 1);
        if (rc == 1) {
            good++;
            check_roundtrip(&p);
        }
    }
    return good;
}

static void raw_mode(const uint8_t *data, size_t size)
{
    tlm_decoder_t d;
    tlm_decoder_init(&d);
    const uint32_t good = push_all(&d, data, size);
    uint32_t delims = 0;
    for (size_t i = 0; i < size; i++) {
        delims += data[i] == 0;
    }
    const tlm_decoder_stats_t *s = &d.stats;
    check(s->frames_ok == good);
    check(s->frames_ok + s->crc_errors + s->truncated + s->bad_packets <= delims);
    check(s->oversize <= size / TLM_MAX_FRAME + 1u);
    check(s->bytes == size);

    /* the one-shot decoders on each 0x00-separated piece */
    size_t start = 0;
    for (size_t i = 0; i <= size; i++) {
        if (i == size || data[i] == 0) {
            uint8_t out[TLM_MAX_FRAME];
            size_t n = 0;
            if (tlm_cobs_decode(data + start, i - start, out, sizeof out, &n) == TLM_OK && n >= 2) {
                tlm_packet_t p;
                if (tlm_packet_decode(out, n - 2, &p) == TLM_OK) {
                    check_roundtrip(&p);
                }
            }
            start = i + 1;
        }
    }
}

static void structured_mode(const uint8_t *data, size_t size)
{
    static uint8_t stream[64 * TLM_MAX_WIRE];
    size_t n = 0;
    size_t pos = 0;
    uint32_t frames = 0;
    tlm_encoder_t enc;
    tlm_encoder_init(&enc);
    /* each packet consumes 1 + sizeof(union) bytes of input */
    while (pos + 1u + sizeof(((tlm_packet_t *)0)->u) + 6u <= size && frames < 64u) {
        tlm_packet_t p;
        memset(&p, 0, sizeof p);
        p.type = (tlm_type_t)(data[pos] % TLM_NUM_TYPES);
        pos++;
        memcpy(&p.time.coarse_s, data + pos, 4u);
        memcpy(&p.time.fine, data + pos + 4u, 2u);
        pos += 6u;
        memcpy(&p.u, data + pos, sizeof p.u);
        pos += sizeof p.u;
        /* keep enumerations mostly valid so most packets encode */
        switch (p.type) {
        case TLM_TYPE_NAV:
            p.u.nav.status %= TLM_NAV_STATUS_COUNT;
            p.u.nav.mode %= TLM_MODE_COUNT;
            p.u.nav.cams_used &= 7u;
            break;
        case TLM_TYPE_CAMERA:
            p.u.camera.camera %= TLM_NUM_CAMERAS;
            p.u.camera.state %= TLM_CAM_STATE_COUNT;
            break;
        case TLM_TYPE_HK:
            p.u.hk.mode %= TLM_MODE_COUNT;
            p.u.hk.cpu_load_permille %= 1001u;
            p.u.hk.cams_enabled &= 7u;
            break;
        default:
            p.u.event.code = (uint16_t)(1u + p.u.event.code % (TLM_EVT_CODE_COUNT - 1u));
            p.u.event.severity %= TLM_SEV_COUNT;
            break;
        }
        size_t len = 0;
        if (tlm_frame_encode(&enc, &p, stream + n, sizeof stream - n, &len) == TLM_OK) {
            n += len;
            frames++;
        }
    }
    /* clean pass: everything decodes */
    tlm_decoder_t d;
    tlm_decoder_init(&d);
    check(push_all(&d, stream, n) == frames);
    check(d.stats.crc_errors + d.stats.truncated + d.stats.oversize + d.stats.bad_packets == 0);
    check(d.stats.seq_gaps == 0);
    /* corrupted pass: the remaining input bytes are (position, xor) pairs */
    for (; pos + 3u <= size && n > 0u; pos += 3u) {
        const size_t at = ((size_t)data[pos] << 8 | data[pos + 1u]) % n;
        stream[at] ^= data[pos + 2u];
    }
    tlm_decoder_init(&d);
    const uint32_t good = push_all(&d, stream, n);
    check(good <= frames);
    /* and it is back in sync right after */
    tlm_packet_t p;
    memset(&p, 0, sizeof p);
    p.type = TLM_TYPE_EVENT;
    p.u.event.code = TLM_EVT_BOOT;
    uint8_t f[TLM_MAX_WIRE + 1];
    size_t fl = 0;
    f[0] = 0;
    check(tlm_frame_encode(&enc, &p, f + 1, sizeof f - 1, &fl) == TLM_OK);
    check(push_all(&d, f, fl + 1) == 1);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size == 0) {
        return 0;
    }
    if (data[0] & 1u) {
        structured_mode(data + 1, size - 1);
    } else {
        raw_mode(data + 1, size - 1);
    }
    return 0;
}
