/* Unit tests of the telemetry codec: CRC-16/CCITT-FALSE, COBS, CCSDS headers,
 * CUC time, every packet type's round trip and its refusal rules. */
#include "tests/unit/support/testutil.h"

#include <math.h>
#include <string.h>

#include "firmware/tlm/ccsds.h"
#include "firmware/tlm/cobs.h"
#include "firmware/tlm/crc16.h"
#include "firmware/tlm/tlm_packets.h"
#include "tests/unit/support/tlm_test_samples.h"

static void test_crc16_check_value(void **state)
{
    (void)state;
    const uint8_t check[] = "123456789";
    assert_int_equal(tlm_crc16(check, 9), 0x29B1);
    /* incremental == one shot */
    uint16_t c = tlm_crc16_update(TLM_CRC16_INIT, check, 4);
    c = tlm_crc16_update(c, check + 4, 5);
    assert_int_equal(c, 0x29B1);
    assert_int_equal(tlm_crc16(NULL, 0), 0xFFFF);
    /* a single-bit change is always detected */
    uint8_t m[10];
    memcpy(m, check, sizeof m); /* includes the terminating NUL */
    for (int bit = 0; bit < 72; bit++) {
        m[bit / 8] ^= (uint8_t)(1u << (bit % 8));
        assert_int_not_equal(tlm_crc16(m, 9), 0x29B1);
        m[bit / 8] ^= (uint8_t)(1u << (bit % 8));
    }
}

static void cobs_roundtrip(const uint8_t *in, size_t n)
{
    uint8_t enc[700], dec[700];
    size_t el = 0, dl = 0;
    assert_true(n <= 600);
    assert_int_equal(tlm_cobs_encode(in, n, enc, sizeof enc, &el), TLM_OK);
    assert_true(el <= TLM_COBS_MAX_ENCODED(n));
    assert_true(el >= n + 1);
    for (size_t i = 0; i < el; i++) {
        assert_int_not_equal(enc[i], 0);
    }
    assert_int_equal(tlm_cobs_decode(enc, el, dec, sizeof dec, &dl), TLM_OK);
    assert_int_equal(dl, n);
    if (n > 0) {
        assert_memory_equal(dec, in, n);
    }
}

static void test_cobs_known_vectors(void **state)
{
    (void)state;
    /* Vectors of the COBS paper / Wikipedia. */
    struct {
        uint8_t in[4];
        size_t n;
        uint8_t out[6];
        size_t m;
    } v[] = {
        {{0}, 0, {0x01}, 1},
        {{0x00}, 1, {0x01, 0x01}, 2},
        {{0x00, 0x00}, 2, {0x01, 0x01, 0x01}, 3},
        {{0x11, 0x22, 0x00, 0x33}, 4, {0x03, 0x11, 0x22, 0x02, 0x33}, 5},
        {{0x11, 0x22, 0x33, 0x44}, 4, {0x05, 0x11, 0x22, 0x33, 0x44}, 5},
        {{0x11, 0x00, 0x00, 0x00}, 4, {0x02, 0x11, 0x01, 0x01, 0x01}, 5},
    };
    for (size_t k = 0; k < sizeof v / sizeof v[0]; k++) {
        uint8_t out[8];
        size_t m = 0;
        assert_int_equal(tlm_cobs_encode(v[k].in, v[k].n, out, sizeof out, &m), TLM_OK);
        assert_int_equal(m, v[k].m);
        assert_memory_equal(out, v[k].out, m);
        cobs_roundtrip(v[k].in, v[k].n);
    }
}

static void test_cobs_long_runs_254_255(void **state)
{
    (void)state;
    uint8_t in[600];
    for (size_t i = 0; i < sizeof in; i++) {
        in[i] = (uint8_t)(1u + i % 255u);
    }
    /* 254 non-zero bytes: one full block (code 0xFF) and nothing implied. */
    uint8_t enc[700];
    size_t m = 0;
    assert_int_equal(tlm_cobs_encode(in, 254, enc, sizeof enc, &m), TLM_OK);
    assert_int_equal(enc[0], 0xFF);
    assert_int_equal(m, 256); /* 0xFF + 254 + trailing code 0x01 */
    assert_int_equal(enc[255], 0x01);
    /* 255 non-zero bytes: full block + a block of one. */
    assert_int_equal(tlm_cobs_encode(in, 255, enc, sizeof enc, &m), TLM_OK);
    assert_int_equal(m, 257);
    assert_int_equal(enc[0], 0xFF);
    assert_int_equal(enc[255], 0x02);
    for (size_t n = 250; n <= 260; n++) {
        cobs_roundtrip(in, n);
    }
    cobs_roundtrip(in, 600);
    /* a zero right after a full block, and at every position near it */
    for (size_t z = 250; z < 260; z++) {
        uint8_t t[520];
        memcpy(t, in, sizeof t);
        t[z] = 0;
        cobs_roundtrip(t, 520);
        cobs_roundtrip(t, z + 1);
    }
    /* all zeros */
    uint8_t zeros[300] = {0};
    cobs_roundtrip(zeros, sizeof zeros);
    /* random */
    mfns_rng_t r;
    mfns_rng_seed(&r, 5);
    for (int k = 0; k < 200; k++) {
        uint8_t t[600];
        const size_t n = (size_t)(mfns_rng_uniform(&r) * 600);
        for (size_t i = 0; i < n; i++) {
            t[i] = (uint8_t)(mfns_rng_uniform(&r) < 0.1 ? 0 : mfns_rng_uniform(&r) * 256);
        }
        cobs_roundtrip(t, n);
    }
}

static void test_cobs_errors(void **state)
{
    (void)state;
    uint8_t out[16];
    size_t m = 0;
    const uint8_t data[5] = {1, 2, 3, 4, 5};
    assert_int_equal(tlm_cobs_encode(data, 5, out, 5, &m), TLM_ERR_BUFFER);
    assert_int_equal(tlm_cobs_encode(NULL, 5, out, 16, &m), TLM_ERR_NULL);
    /* block code runs past the end: truncated */
    const uint8_t trunc[3] = {0x05, 0x11, 0x22};
    assert_int_equal(tlm_cobs_decode(trunc, 3, out, sizeof out, &m), TLM_ERR_COBS);
    /* a zero inside the encoded block */
    const uint8_t zero_in[3] = {0x03, 0x00, 0x22};
    assert_int_equal(tlm_cobs_decode(zero_in, 3, out, sizeof out, &m), TLM_ERR_COBS);
    const uint8_t zero_code[2] = {0x00, 0x01};
    assert_int_equal(tlm_cobs_decode(zero_code, 2, out, sizeof out, &m), TLM_ERR_COBS);
    /* output too small */
    const uint8_t ok[5] = {0x05, 1, 2, 3, 4};
    assert_int_equal(tlm_cobs_decode(ok, 5, out, 3, &m), TLM_ERR_BUFFER);
}

static void test_ccsds_header_bits(void **state)
{
    (void)state;
    const tlm_ccsds_hdr_t h = {0, 0, 1, 0x101, 3, 0x1234, 71};
    uint8_t b[6];
    assert_int_equal(tlm_ccsds_pack(&h, b), TLM_OK);
    /* 000 0 1 00100000001 | 11 01001000110100 | 71 */
    const uint8_t want[6] = {0x09, 0x01, 0xD2, 0x34, 0x00, 0x47};
    assert_memory_equal(b, want, 6);
    tlm_ccsds_hdr_t g;
    assert_int_equal(tlm_ccsds_unpack(b, &g), TLM_OK);
    assert_int_equal(g.version, 0);
    assert_int_equal(g.type, 0);
    assert_int_equal(g.sec_hdr, 1);
    assert_int_equal(g.apid, 0x101);
    assert_int_equal(g.seq_flags, 3);
    assert_int_equal(g.seq, 0x1234);
    assert_int_equal(g.data_len, 71);
    /* every field at its maximum */
    const tlm_ccsds_hdr_t mx = {7, 1, 1, 0x7FF, 3, 0x3FFF, 0xFFFF};
    assert_int_equal(tlm_ccsds_pack(&mx, b), TLM_OK);
    const uint8_t ones[6] = {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF};
    assert_memory_equal(b, ones, 6);
    /* out-of-width fields refused */
    tlm_ccsds_hdr_t bad = h;
    bad.apid = 0x800;
    assert_int_equal(tlm_ccsds_pack(&bad, b), TLM_ERR_ARG);
    bad = h;
    bad.seq = 0x4000;
    assert_int_equal(tlm_ccsds_pack(&bad, b), TLM_ERR_ARG);
    bad = h;
    bad.version = 8;
    assert_int_equal(tlm_ccsds_pack(&bad, b), TLM_ERR_ARG);
    assert_int_equal(tlm_ccsds_pack(NULL, b), TLM_ERR_NULL);
}

static void test_cuc_time(void **state)
{
    (void)state;
    const tlm_time_t t = {0x01020304u, 0x0506u};
    uint8_t b[6];
    assert_int_equal(tlm_time_pack(&t, b), TLM_OK);
    const uint8_t want[6] = {1, 2, 3, 4, 5, 6};
    assert_memory_equal(b, want, 6);
    tlm_time_t g;
    assert_int_equal(tlm_time_unpack(b, &g), TLM_OK);
    assert_int_equal(g.coarse_s, t.coarse_s);
    assert_int_equal(g.fine, t.fine);
    tlm_time_t u = tlm_time_from_us(2500000u);
    assert_int_equal(u.coarse_s, 2);
    assert_int_equal(u.fine, 32768);
    u = tlm_time_from_us(999999u);
    assert_int_equal(u.coarse_s, 0);
    assert_int_equal(u.fine, 65535);
    u = tlm_time_from_us(53763u); /* one 18.6 Hz cycle: 0.053763 s * 65536 = 3523.4 */
    assert_int_equal(u.fine, 3523);
}

static void test_every_packet_type_roundtrip(void **state)
{
    (void)state;
    for (int t = 0; t < (int)TLM_NUM_TYPES; t++) {
        for (uint32_t i = 0; i < 300; i += 7) {
            tlm_packet_t p, q;
            tlm_test_sample(&p, (tlm_type_t)t, i * 977u);
            uint8_t buf[TLM_MAX_PACKET];
            size_t n = 0;
            const uint16_t seq = (uint16_t)(i * 55u & 0x3FFF);
            assert_int_equal(tlm_packet_encode(&p, seq, buf, sizeof buf, &n), TLM_OK);
            assert_int_equal(n, TLM_CCSDS_HDR_LEN + tlm_payload_len((tlm_type_t)t));
            tlm_ccsds_hdr_t h;
            assert_int_equal(tlm_ccsds_unpack(buf, &h), TLM_OK);
            assert_int_equal(h.apid, tlm_type_apid((tlm_type_t)t));
            assert_int_equal(h.data_len + 7u, n);
            assert_int_equal(tlm_packet_decode(buf, n, &q), TLM_OK);
            p.seq = seq;
            assert_true(tlm_test_packets_equal(&p, &q));
        }
    }
}

static void test_nav_payload_layout(void **state)
{
    (void)state;
    tlm_packet_t p;
    memset(&p, 0, sizeof p);
    p.type = TLM_TYPE_NAV;
    p.time = (tlm_time_t){7u, 0x8000u};
    p.u.nav.cycle = 0x0A0B0C0Du;
    p.u.nav.status = TLM_NAV_FIX;
    p.u.nav.reason = 0;
    p.u.nav.mode = TLM_MODE_TRACK;
    p.u.nav.beacons_used = 4;
    p.u.nav.cams_used = 5;
    p.u.nav.iterations = 6;
    p.u.nav.residual_rms_mpx = 0x0102;
    p.u.nav.pos_um[0] = -1; /* FF FF FF FF */
    p.u.nav.att_udeg[2] = 180000000; /* 0x0ABA9500 */
    p.u.nav.sigma_att_udeg[2] = 0x11223344u;
    p.u.nav.q_q30[0] = 1 << 30;   /* 1.0: 40 00 00 00 */
    p.u.nav.q_q30[3] = -(1 << 29); /* -0.5: E0 00 00 00 */
    p.u.nav.cov[0] = 1.0f;        /* binary32 3F 80 00 00 */
    p.u.nav.cov[20] = -2.5f;      /* C0 20 00 00 */
    p.u.nav.pl_pos_um = 0x01020304u;
    p.u.nav.pl_att_udeg = 0xFFFFFFFFu; /* none */
    uint8_t b[TLM_MAX_PACKET];
    size_t n = 0;
    assert_int_equal(tlm_packet_encode(&p, 3, b, sizeof b, &n), TLM_OK);
    assert_int_equal(n, 180); /* 12 header + 168 payload (pl_pos_um, pl_att_udeg at 160, 164) */
    const uint8_t hdr[12] = {0x09, 0x01, 0xC0, 0x03, 0x00, 173, 0, 0, 0, 7, 0x80, 0x00};
    assert_memory_equal(b, hdr, 12);
    const uint8_t *pl = b + 12;
    const uint8_t head[12] = {0x0A, 0x0B, 0x0C, 0x0D, 1, 0, 2, 4, 5, 6, 0x01, 0x02};
    assert_memory_equal(pl, head, 12);
    const uint8_t x[4] = {0xFF, 0xFF, 0xFF, 0xFF};
    assert_memory_equal(pl + 12, x, 4);
    const uint8_t yaw[4] = {0x0A, 0xBA, 0x95, 0x00};
    assert_memory_equal(pl + 32, yaw, 4);
    const uint8_t syaw[4] = {0x11, 0x22, 0x33, 0x44};
    assert_memory_equal(pl + 56, syaw, 4);
    const uint8_t qw[4] = {0x40, 0x00, 0x00, 0x00}, qz[4] = {0xE0, 0x00, 0x00, 0x00};
    assert_memory_equal(pl + 60, qw, 4);
    assert_memory_equal(pl + 72, qz, 4);
    const uint8_t cxx[4] = {0x3F, 0x80, 0x00, 0x00}, crzrz[4] = {0xC0, 0x20, 0x00, 0x00};
    assert_memory_equal(pl + 76, cxx, 4);
    assert_memory_equal(pl + 156, crzrz, 4);
    const uint8_t plp[4] = {0x01, 0x02, 0x03, 0x04}, pla[4] = {0xFF, 0xFF, 0xFF, 0xFF};
    assert_memory_equal(pl + 160, plp, 4);
    assert_memory_equal(pl + 164, pla, 4);
    tlm_packet_t q;
    assert_int_equal(tlm_packet_decode(b, n, &q), TLM_OK);
    assert_true(q.u.nav.cov[20] == -2.5f && q.u.nav.q_q30[3] == -(1 << 29));
    /* a covariance that is not finite is refused both ways: never a pose
     * with a meaningless covariance */
    p.u.nav.cov[7] = NAN;
    assert_int_equal(tlm_packet_encode(&p, 3, b, sizeof b, &n), TLM_ERR_PAYLOAD);
    p.u.nav.cov[7] = 0.0f;
    assert_int_equal(tlm_packet_encode(&p, 3, b, sizeof b, &n), TLM_OK);
    const uint8_t inf[4] = {0x7F, 0x80, 0x00, 0x00};
    memcpy(b + 12 + 76 + 4 * 7, inf, 4);
    assert_int_equal(tlm_packet_decode(b, n, &q), TLM_ERR_PAYLOAD);
}

static void test_hk_payload_layout(void **state)
{
    (void)state;
    tlm_packet_t p;
    memset(&p, 0, sizeof p);
    p.type = TLM_TYPE_HK;
    p.u.hk.mode = TLM_MODE_STANDBY;
    p.u.hk.n_degraded = 0x01020304u;
    p.u.hk.n_cmd_accepted = 0x05060708u;
    p.u.hk.n_cmd_rejected = 0x090A0B0Cu;
    p.u.hk.cmd_seq_last = 0x0D0Eu;
    p.u.hk.cams_enabled = 0x05u;
    uint8_t b[TLM_MAX_PACKET];
    size_t n = 0;
    assert_int_equal(tlm_packet_encode(&p, 0, b, sizeof b, &n), TLM_OK);
    /* the payload length is the dictionary's (generated); the fields of version 2
     * stand at their offsets whatever a newer dictionary appends */
    assert_int_equal(n, TLM_CCSDS_HDR_LEN + TLM_HK_PAYLOAD_LEN);
    assert_true(TLM_HK_PAYLOAD_LEN >= 76u);
    const uint8_t tail[15] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 5};
    assert_memory_equal(b + 12 + 61, tail, 15);
    assert_int_equal(b[12 + 4], 4); /* STANDBY */
    p.u.hk.cams_enabled = 8;        /* only three cameras */
    assert_int_equal(tlm_packet_encode(&p, 0, b, sizeof b, &n), TLM_ERR_PAYLOAD);
}

static void test_packet_refusals(void **state)
{
    (void)state;
    tlm_packet_t p, q;
    uint8_t b[TLM_MAX_PACKET + 8];
    size_t n = 0;
    tlm_test_sample(&p, TLM_TYPE_CAMERA, 1);
    p.u.camera.camera = 3;
    assert_int_equal(tlm_packet_encode(&p, 0, b, sizeof b, &n), TLM_ERR_PAYLOAD);
    tlm_test_sample(&p, TLM_TYPE_NAV, 1);
    p.u.nav.status = 9;
    assert_int_equal(tlm_packet_encode(&p, 0, b, sizeof b, &n), TLM_ERR_PAYLOAD);
    tlm_test_sample(&p, TLM_TYPE_EVENT, 1);
    p.u.event.code = 0;
    assert_int_equal(tlm_packet_encode(&p, 0, b, sizeof b, &n), TLM_ERR_PAYLOAD);
    tlm_test_sample(&p, TLM_TYPE_HK, 1);
    p.u.hk.cpu_load_permille = 1001;
    assert_int_equal(tlm_packet_encode(&p, 0, b, sizeof b, &n), TLM_ERR_PAYLOAD);
    tlm_test_sample(&p, TLM_TYPE_HK, 1);
    assert_int_equal(tlm_packet_encode(&p, 0x4000, b, sizeof b, &n), TLM_ERR_ARG);
    assert_int_equal(tlm_packet_encode(&p, 0, b, 20, &n), TLM_ERR_BUFFER);
    p.type = TLM_NUM_TYPES;
    assert_int_equal(tlm_packet_encode(&p, 0, b, sizeof b, &n), TLM_ERR_ARG);

    /* decoder side: each header rule */
    tlm_test_sample(&p, TLM_TYPE_EVENT, 2);
    assert_int_equal(tlm_packet_encode(&p, 5, b, sizeof b, &n), TLM_OK);
    assert_int_equal(tlm_packet_decode(b, n, &q), TLM_OK);
    assert_int_equal(tlm_packet_decode(b, 11, &q), TLM_ERR_RUNT);
    assert_int_equal(tlm_packet_decode(b, n - 1, &q), TLM_ERR_LENGTH);
    uint8_t c[TLM_MAX_PACKET + 8];
    memcpy(c, b, n);
    c[0] |= 0x20; /* version 1 */
    assert_int_equal(tlm_packet_decode(c, n, &q), TLM_ERR_HEADER);
    memcpy(c, b, n);
    c[0] |= 0x10; /* telecommand */
    assert_int_equal(tlm_packet_decode(c, n, &q), TLM_ERR_HEADER);
    memcpy(c, b, n);
    c[0] &= (uint8_t)~0x08; /* no secondary header */
    assert_int_equal(tlm_packet_decode(c, n, &q), TLM_ERR_HEADER);
    memcpy(c, b, n);
    c[2] &= 0x3F; /* segmented */
    assert_int_equal(tlm_packet_decode(c, n, &q), TLM_ERR_HEADER);
    memcpy(c, b, n);
    c[1] = 0x99; /* APID 0x199 */
    assert_int_equal(tlm_packet_decode(c, n, &q), TLM_ERR_APID);
    assert_int_equal(q.type, 0);
    /* an event packet's length with the camera APID */
    memcpy(c, b, n);
    c[1] = 0x02;
    assert_int_equal(tlm_packet_decode(c, n, &q), TLM_ERR_PAYLOAD);
    /* event code out of range */
    memcpy(c, b, n);
    c[12 + 4] = 0x7F;
    assert_int_equal(tlm_packet_decode(c, n, &q), TLM_ERR_PAYLOAD);
    assert_int_equal(q.u.event.code, 0); /* zeroed, nothing half-valid left */
}

static void test_frame_encode_sequence_counters(void **state)
{
    (void)state;
    tlm_encoder_t enc;
    tlm_encoder_init(&enc);
    uint8_t f[TLM_MAX_WIRE];
    size_t n = 0;
    tlm_packet_t p;
    for (uint32_t i = 0; i < 5; i++) {
        tlm_test_sample(&p, TLM_TYPE_NAV, i);
        assert_int_equal(tlm_frame_encode(&enc, &p, f, sizeof f, &n), TLM_OK);
        assert_int_equal(p.seq, i);
        assert_int_equal(f[n - 1], 0);
        for (size_t k = 0; k + 1 < n; k++) {
            assert_int_not_equal(f[k], 0);
        }
        assert_true(n <= TLM_MAX_WIRE);
    }
    /* the camera counter is independent of the nav counter */
    tlm_test_sample(&p, TLM_TYPE_CAMERA, 0);
    assert_int_equal(tlm_frame_encode(&enc, &p, f, sizeof f, &n), TLM_OK);
    assert_int_equal(p.seq, 0);
    /* a refused packet does not consume a count */
    tlm_test_sample(&p, TLM_TYPE_NAV, 9);
    p.u.nav.mode = 77;
    assert_int_not_equal(tlm_frame_encode(&enc, &p, f, sizeof f, &n), TLM_OK);
    assert_int_equal(enc.next_seq[TLM_TYPE_NAV], 5);
    /* too-small output refused, counter unchanged */
    tlm_test_sample(&p, TLM_TYPE_NAV, 9);
    assert_int_equal(tlm_frame_encode(&enc, &p, f, 40, &n), TLM_ERR_BUFFER);
    assert_int_equal(enc.next_seq[TLM_TYPE_NAV], 5);
    /* wrap at 2^14 */
    enc.next_seq[TLM_TYPE_HK] = 0x3FFF;
    tlm_test_sample(&p, TLM_TYPE_HK, 1);
    assert_int_equal(tlm_frame_encode(&enc, &p, f, sizeof f, &n), TLM_OK);
    assert_int_equal(p.seq, 0x3FFF);
    assert_int_equal(tlm_frame_encode(&enc, &p, f, sizeof f, &n), TLM_OK);
    assert_int_equal(p.seq, 0);
    /* frame = COBS(packet || CRC) 0x00 */
    uint8_t d[TLM_MAX_FRAME + 4];
    size_t dl = 0;
    assert_int_equal(tlm_cobs_decode(f, n - 1, d, sizeof d, &dl), TLM_OK);
    assert_int_equal(dl, 12 + TLM_HK_PAYLOAD_LEN + 2);
    assert_int_equal(tlm_get_u16(d + dl - 2), tlm_crc16(d, dl - 2));
}

static void test_scale_helpers(void **state)
{
    (void)state;
    bool ok = true;
    assert_int_equal(tlm_scale_i32(1.2345f, 1000.0f, &ok), 1235);
    assert_true(ok);
    assert_int_equal(tlm_scale_i32(-1.2345f, 1000.0f, &ok), -1235);
    assert_true(ok);
    assert_int_equal(tlm_scale_i32(1e10f, 1000.0f, &ok), 2147483520);
    assert_false(ok);
    ok = true;
    assert_int_equal(tlm_scale_i32(-1e10f, 1000.0f, &ok), INT32_MIN);
    assert_false(ok);
    ok = true;
    assert_int_equal(tlm_scale_i32(NAN, 1000.0f, &ok), 0);
    assert_false(ok);
    ok = true;
    assert_int_equal(tlm_scale_u16(65.535f, 1000.0f, &ok), 65535);
    assert_true(ok);
    assert_int_equal(tlm_scale_u16(70.0f, 1000.0f, &ok), 65535);
    assert_false(ok);
    ok = true;
    assert_int_equal(tlm_scale_u16(-0.0001f, 1000.0f, &ok), 0);
    assert_true(ok);
    assert_int_equal(tlm_scale_u32(-3.0f, 1.0f, &ok), 0);
    assert_false(ok);
    assert_int_equal(tlm_scale_u32(0.1504f, 1e6f, NULL), 150400);
}

static void test_names_and_strerror(void **state)
{
    (void)state;
    assert_string_equal(tlm_type_name(TLM_TYPE_HK), "housekeeping");
    assert_string_equal(tlm_nav_status_name(TLM_NAV_FIX), "FIX");
    assert_string_equal(tlm_nav_status_name(200), "?");
    assert_string_equal(tlm_event_name(TLM_EVT_TABLE_REFUSED), "TABLE_REFUSED");
    assert_string_equal(tlm_event_name(0), "?");
    assert_string_equal(tlm_mode_name(TLM_MODE_SAFE), "SAFE");
    assert_string_equal(tlm_cam_state_name(TLM_CAM_LOST), "LOST");
    assert_int_equal(tlm_apid_type(0x7FF), TLM_ERR_APID);
    /* every code has its own message */
    for (int e = TLM_ERR_EMPTY; e <= TLM_OK; e++) {
        for (int f = e + 1; f <= TLM_OK; f++) {
            assert_string_not_equal(tlm_strerror(e), tlm_strerror(f));
        }
    }
    assert_string_equal(tlm_strerror(-999), "unknown telemetry error");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_crc16_check_value),
        cmocka_unit_test(test_cobs_known_vectors),
        cmocka_unit_test(test_cobs_long_runs_254_255),
        cmocka_unit_test(test_cobs_errors),
        cmocka_unit_test(test_ccsds_header_bits),
        cmocka_unit_test(test_cuc_time),
        cmocka_unit_test(test_every_packet_type_roundtrip),
        cmocka_unit_test(test_nav_payload_layout),
        cmocka_unit_test(test_hk_payload_layout),
        cmocka_unit_test(test_packet_refusals),
        cmocka_unit_test(test_frame_encode_sequence_counters),
        cmocka_unit_test(test_scale_helpers),
        cmocka_unit_test(test_names_and_strerror),
    };
    return cmocka_run_group_tests_name("tlm_codec", tests, NULL, NULL);
}
