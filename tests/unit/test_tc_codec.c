/* Unit tests of the telecommand codec (firmware/tlm/tc_packets.h): the
 * CCSDS TC header bits, every opcode's round trip through the wire frame,
 * each rejection code the decoder can give, the encoder refusing what the
 * decoder would refuse, and the streaming deframer on garbage, idle fill,
 * oversize frames and frames split at every byte. */
#include "tests/unit/support/testutil.h"

#include <string.h>

#include "firmware/tlm/cobs.h"
#include "firmware/tlm/crc16.h"
#include "firmware/tlm/tc_packets.h"
#include "firmware/tlm/tlm_packets.h"

/* One valid command per opcode. */
static tc_cmd_t sample(uint8_t op)
{
    tc_cmd_t c;
    memset(&c, 0, sizeof c);
    c.opcode = op;
    switch (op) {
    case TC_OP_SET_MODE: c.u.mode = TLM_MODE_STANDBY; break;
    case TC_OP_CAMERA_ENABLE: c.u.camera = 2; break;
    case TC_OP_CAMERA_DISABLE: c.u.camera = 1; break;
    case TC_OP_SET_POSE_HINT: {
        const tc_pose_hint_t p = {{480741, -276091, TC_POS_UM_MAX}, {-180000000, 90000000, 179999999}};
        c.u.pose = p;
        break;
    }
    case TC_OP_TABLE_LOAD: (void)snprintf(c.u.path, sizeof c.u.path, "/data/tables/next.mfnstbl"); break;
    case TC_OP_UPLOAD_START:
        c.u.upload_start.size = 106780u;
        c.u.upload_start.crc32 = 0x9A521E07u;
        (void)snprintf(c.u.upload_start.name, sizeof c.u.upload_start.name, "table2.mfnstbl");
        break;
    case TC_OP_UPLOAD_DATA: /* every byte value in the block, zeros included (COBS) */
        c.u.upload_data.offset = 0xFEDCBA98u;
        c.u.upload_data.len = (uint8_t)TC_UPLOAD_LEN_MAX;
        for (unsigned i = 0; i < TC_UPLOAD_SEG_LEN; i++) {
            c.u.upload_data.bytes[i] = (uint8_t)(i * 7u + 3u);
        }
        break;
    default: break;
    }
    return c;
}

/* The packet of a command, for tests that corrupt it. */
static size_t packet_of(const tc_cmd_t *c, uint16_t seq, uint8_t *out)
{
    size_t n = 0;
    assert_int_equal(tc_packet_encode(c, seq, out, TC_MAX_PACKET, &n), TC_OK);
    return n;
}

/* Frame raw packet bytes (CRC + COBS + delimiter) without the encoder's checks. */
static size_t frame_raw(const uint8_t *pkt, size_t n, uint8_t *out)
{
    uint8_t f[TC_MAX_FRAME + 64];
    memcpy(f, pkt, n);
    tlm_put_u16(f + n, tlm_crc16(pkt, n));
    size_t enc = 0;
    assert_int_equal(tlm_cobs_encode(f, n + 2u, out, 200, &enc), TLM_OK);
    out[enc] = 0;
    return enc + 1u;
}

/* Feed a whole byte stream; returns the number of frames that ended and the
 * last status/command. */
static int feed(tc_deframer_t *d, const uint8_t *b, size_t n, tc_cmd_t *last, tc_status_t *st)
{
    int frames = 0;
    for (size_t i = 0; i < n; i++) {
        tc_cmd_t c;
        tc_status_t s = TC_OK;
        if (tc_deframer_push(d, b[i], &c, &s)) {
            frames++;
            *last = c;
            *st = s;
        }
    }
    return frames;
}

static void test_header_bits(void **state)
{
    (void)state;
    const tc_cmd_t c = sample(TC_OP_NOOP);
    uint8_t p[TC_MAX_PACKET];
    const size_t n = packet_of(&c, 0x1234u, p);
    assert_int_equal(n, 8);
    /* version 0, type 1, sec hdr 1, APID 0x181; flags 3, seq 0x1234; length 1 */
    const uint8_t want[8] = {0x19, 0x81, 0xD2, 0x34, 0x00, 0x01, TC_OP_NOOP, 0x00};
    assert_memory_equal(p, want, sizeof want);
}

static void test_every_opcode_round_trips(void **state)
{
    (void)state;
    for (unsigned opu = 1; opu <= (unsigned)TC_OP_MAX; opu++) {
        const uint8_t op = (uint8_t)opu;
        const tc_cmd_t c = sample(op);
        uint8_t w[TC_MAX_WIRE];
        size_t n = 0;
        assert_int_equal(tc_frame_encode(&c, (uint16_t)(100u + op), w, sizeof w, &n), TC_OK);
        assert_int_equal(w[n - 1], 0);
        assert_true(memchr(w, 0, n - 1) == NULL);
        assert_int_equal(n, TC_HDR_LEN + (size_t)tc_arg_len(op) + 2u + 1u + 1u); /* + CRC, COBS, delimiter */
        tc_deframer_t d;
        tc_deframer_init(&d);
        tc_cmd_t got;
        tc_status_t st = TC_E_NULL;
        assert_int_equal(feed(&d, w, n, &got, &st), 1);
        assert_int_equal(st, TC_OK);
        assert_true(got.have_seq && got.have_opcode);
        assert_int_equal(got.seq, 100u + op);
        assert_int_equal(got.opcode, op);
        assert_memory_equal(&got.u, &c.u, sizeof c.u);
        assert_string_not_equal(tc_opcode_name(op), "?");
    }
    assert_string_equal(tc_opcode_name(0), "?");
    assert_string_equal(tc_opcode_name(TC_OP_MAX + 1), "?");
    assert_int_equal(tc_arg_len(0), -1);
    assert_int_equal(tc_arg_len(TC_OP_MAX + 1), -1);
}

static void test_decoder_rejections(void **state)
{
    (void)state;
    uint8_t p[TC_MAX_PACKET + 8];
    tc_cmd_t out;
    const tc_cmd_t mode = sample(TC_OP_SET_MODE);
    size_t n = packet_of(&mode, 7, p);
    assert_int_equal(tc_packet_decode(p, n, &out), TC_OK);

    assert_int_equal(tc_packet_decode(p, 5, &out), TC_E_RUNT);
    assert_false(out.have_seq);

    uint8_t q[TC_MAX_PACKET + 8];
    memcpy(q, p, n);
    q[0] = (uint8_t)(q[0] & ~0x10u); /* type 0: a telemetry packet */
    assert_int_equal(tc_packet_decode(q, n, &out), TC_E_HEADER);
    assert_true(out.have_seq);
    assert_int_equal(out.seq, 7);
    memcpy(q, p, n);
    q[0] = (uint8_t)(q[0] | 0x20u); /* version 1 */
    assert_int_equal(tc_packet_decode(q, n, &out), TC_E_HEADER);
    memcpy(q, p, n);
    q[0] = (uint8_t)(q[0] & ~0x08u); /* no secondary header */
    assert_int_equal(tc_packet_decode(q, n, &out), TC_E_HEADER);
    memcpy(q, p, n);
    q[2] = (uint8_t)(q[2] & 0x3Fu); /* sequence flags 0 (a segment) */
    assert_int_equal(tc_packet_decode(q, n, &out), TC_E_HEADER);

    memcpy(q, p, n);
    q[5]++; /* length field one too many */
    assert_int_equal(tc_packet_decode(q, n, &out), TC_E_LENGTH);

    memcpy(q, p, n);
    q[1] = 0x01; /* APID 0x101 */
    assert_int_equal(tc_packet_decode(q, n, &out), TC_E_APID);

    memcpy(q, p, n);
    q[6] = 0; /* opcode 0 */
    assert_int_equal(tc_packet_decode(q, n, &out), TC_E_OPCODE);
    q[6] = TC_OP_MAX + 1;
    assert_int_equal(tc_packet_decode(q, n, &out), TC_E_OPCODE);
    assert_true(out.have_opcode);
    memcpy(q, p, n);
    q[7] = 1; /* reserved byte */
    assert_int_equal(tc_packet_decode(q, n, &out), TC_E_OPCODE);

    memcpy(q, p, n);
    q[6] = TC_OP_NOOP; /* NOOP with one argument byte */
    assert_int_equal(tc_packet_decode(q, n, &out), TC_E_ARG_LEN);

    memcpy(q, p, n);
    q[8] = TLM_MODE_SAFE; /* SET_MODE may not command SAFE, BOOT or unknown modes */
    assert_int_equal(tc_packet_decode(q, n, &out), TC_E_ARG);
    assert_int_equal(out.u.mode, 0); /* nothing half-valid */
    q[8] = TLM_MODE_BOOT;
    assert_int_equal(tc_packet_decode(q, n, &out), TC_E_ARG);
    q[8] = 200;
    assert_int_equal(tc_packet_decode(q, n, &out), TC_E_ARG);

    const tc_cmd_t cam = sample(TC_OP_CAMERA_DISABLE);
    n = packet_of(&cam, 1, q);
    q[8] = 3;
    assert_int_equal(tc_packet_decode(q, n, &out), TC_E_ARG);

    const tc_cmd_t pose = sample(TC_OP_SET_POSE_HINT);
    n = packet_of(&pose, 1, q);
    tlm_put_u32(q + 8 + 12 + 4, (uint32_t)(TC_PITCH_UDEG_MAX + 1)); /* pitch beyond 90 deg */
    assert_int_equal(tc_packet_decode(q, n, &out), TC_E_ARG);
    n = packet_of(&pose, 1, q);
    tlm_put_u32(q + 8, (uint32_t)INT32_MIN); /* x far beyond 1 km */
    assert_int_equal(tc_packet_decode(q, n, &out), TC_E_ARG);

    const tc_cmd_t tab = sample(TC_OP_TABLE_LOAD);
    n = packet_of(&tab, 1, q);
    q[8 + 30] = 'x'; /* junk after the terminating NUL */
    assert_int_equal(tc_packet_decode(q, n, &out), TC_E_ARG);
    n = packet_of(&tab, 1, q);
    memset(q + 8, 'a', TC_PATH_MAX); /* no NUL inside the field */
    assert_int_equal(tc_packet_decode(q, n, &out), TC_E_ARG);
    n = packet_of(&tab, 1, q);
    q[8] = 0; /* empty path */
    memset(q + 8, 0, TC_PATH_MAX);
    assert_int_equal(tc_packet_decode(q, n, &out), TC_E_ARG);
    n = packet_of(&tab, 1, q);
    q[9] = '\n'; /* a control character */
    assert_int_equal(tc_packet_decode(q, n, &out), TC_E_ARG);

    assert_int_equal(tc_packet_decode(NULL, 8, &out), TC_E_NULL);
    assert_int_equal(tc_packet_decode(p, 8, NULL), TC_E_NULL);
}

static void test_encoder_refuses_what_decoder_would(void **state)
{
    (void)state;
    uint8_t p[TC_MAX_PACKET];
    size_t n = 0;
    tc_cmd_t c = sample(TC_OP_SET_MODE);
    c.u.mode = TLM_MODE_SAFE;
    assert_int_equal(tc_packet_encode(&c, 0, p, sizeof p, &n), TC_E_ARG);
    c = sample(TC_OP_CAMERA_ENABLE);
    c.u.camera = 3;
    assert_int_equal(tc_packet_encode(&c, 0, p, sizeof p, &n), TC_E_ARG);
    c = sample(TC_OP_SET_POSE_HINT);
    c.u.pose.att_udeg[0] = TC_ROLL_YAW_UDEG_MAX + 1;
    assert_int_equal(tc_packet_encode(&c, 0, p, sizeof p, &n), TC_E_ARG);
    c = sample(TC_OP_TABLE_LOAD);
    memset(c.u.path, 'p', sizeof c.u.path);
    assert_int_equal(tc_packet_encode(&c, 0, p, sizeof p, &n), TC_E_ARG);
    c = sample(TC_OP_NOOP);
    c.opcode = 0;
    assert_int_equal(tc_packet_encode(&c, 0, p, sizeof p, &n), TC_E_OPCODE);
    c.opcode = TC_OP_NOOP;
    assert_int_equal(tc_packet_encode(&c, 16384, p, sizeof p, &n), TC_E_HEADER);
    assert_int_equal(tc_packet_encode(&c, 0, p, 7, &n), TC_E_NULL); /* too small */
    c = sample(TC_OP_TABLE_LOAD);
    uint8_t w[TC_MAX_WIRE];
    assert_int_equal(tc_frame_encode(&c, 0, w, sizeof w, &n), TC_OK);
    assert_true(n <= TC_MAX_WIRE);
    assert_int_equal(tc_frame_encode(&c, 0, w, n - 1u, &n), TC_E_NULL);
    /* names and messages exist for every code */
    for (int s = 0; s <= TC_STATUS_MAX; s++) {
        assert_string_not_equal(tc_status_name(s), "?");
        assert_string_not_equal(tc_strerror(s), "unknown command status");
    }
    assert_string_equal(tc_status_name(TC_STATUS_MAX + 1), "?");
}

static void test_deframer_faults(void **state)
{
    (void)state;
    tc_deframer_t d;
    tc_deframer_init(&d);
    tc_cmd_t got;
    tc_status_t st = TC_OK;
    uint8_t w[TC_MAX_WIRE];
    size_t n = 0;
    const tc_cmd_t c = sample(TC_OP_SET_POSE_HINT);
    assert_int_equal(tc_frame_encode(&c, 9, w, sizeof w, &n), TC_OK);

    /* idle fill is not a frame */
    const uint8_t zeros[5] = {0, 0, 0, 0, 0};
    assert_int_equal(feed(&d, zeros, sizeof zeros, &got, &st), 0);

    /* a flipped bit: CRC (or, if it hits a COBS code byte, a broken frame) */
    for (size_t i = 0; i + 1u < n; i++) {
        uint8_t x[TC_MAX_WIRE];
        memcpy(x, w, n);
        x[i] ^= 0x10u;
        if (x[i] == 0) {
            continue; /* became a delimiter: a different fault, covered below */
        }
        assert_int_equal(feed(&d, x, n, &got, &st), 1);
        assert_true(st == TC_E_CRC || st == TC_E_FRAME || st == TC_E_RUNT || st == TC_E_OVERSIZE);
    }
    /* a frame cut short by an early delimiter, then the next frame is fine */
    uint8_t cut[2 * TC_MAX_WIRE];
    memcpy(cut, w, 10);
    cut[10] = 0;
    memcpy(cut + 11, w, n);
    assert_int_equal(feed(&d, cut, 11 + n, &got, &st), 2);
    assert_int_equal(st, TC_OK);
    assert_int_equal(got.seq, 9);

    /* a runt: a valid frame of a 3-byte packet */
    const uint8_t tiny[3] = {0x19, 0x81, 0xC0};
    uint8_t f[64];
    size_t fn = frame_raw(tiny, sizeof tiny, f);
    assert_int_equal(feed(&d, f, fn, &got, &st), 1);
    assert_int_equal(st, TC_E_RUNT);

    /* garbage without a delimiter: one oversize report, then back in step */
    uint8_t junk[300];
    for (size_t i = 0; i < sizeof junk; i++) {
        junk[i] = (uint8_t)(1u + (i * 37u) % 255u);
    }
    assert_int_equal(feed(&d, junk, sizeof junk, &got, &st), 1);
    assert_int_equal(st, TC_E_OVERSIZE);
    assert_int_equal(feed(&d, zeros, 1, &got, &st), 0); /* the delimiter ends the discarded frame quietly */
    assert_int_equal(feed(&d, w, n, &got, &st), 1);
    assert_int_equal(st, TC_OK);

    /* a TM frame on the uplink: refused by header */
    uint8_t tm[16] = {0x09, 0x04, 0xC0, 0x00, 0x00, 0x09};
    fn = frame_raw(tm, sizeof tm, f);
    assert_int_equal(feed(&d, f, fn, &got, &st), 1);
    assert_int_equal(st, TC_E_HEADER);
    assert_false(tc_deframer_push(NULL, 1, &got, &st));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_header_bits),
        cmocka_unit_test(test_every_opcode_round_trips),
        cmocka_unit_test(test_decoder_rejections),
        cmocka_unit_test(test_encoder_refuses_what_decoder_would),
        cmocka_unit_test(test_deframer_faults),
    };
    return cmocka_run_group_tests_name("tc_codec", tests, NULL, NULL);
}
