/* Unit tests of the streaming telemetry decoder: a clean stream, then each
 * fault injected on its own (random garbage, bit flips, truncated frames,
 * oversize frames, lost bytes, lost frames), checking that exactly the hit
 * frames are lost, that decoding resumes at the next frame, and that each
 * fault lands in its own counter. */
#include "tests/unit/support/testutil.h"

#include <string.h>

#include "firmware/tlm/crc16.h"
#include "firmware/tlm/tlm_decoder.h"
#include "tests/unit/support/tlm_test_samples.h"

#define NPKT 120
#define STREAM_CAP (NPKT * TLM_MAX_WIRE + 4096)

typedef struct {
    tlm_packet_t got[NPKT * 2];
    uint32_t n_got;
    int errors;
} sink_t;

static uint8_t g_stream[STREAM_CAP];
static uint8_t g_mut[STREAM_CAP * 2];
static tlm_packet_t g_sent[NPKT];
static sink_t g_sink;

static void feed(tlm_decoder_t *d, const uint8_t *b, size_t n, sink_t *s)
{
    for (size_t i = 0; i < n; i++) {
        tlm_packet_t p;
        const int rc = tlm_decoder_push(d, b[i], &p);
        if (rc == 1) {
            assert_true(s->n_got < NPKT * 2);
            s->got[s->n_got++] = p;
        } else if (rc < 0) {
            s->errors++;
        } else {
            assert_int_equal(rc, 0);
        }
    }
}

/* Every received packet must be one of the sent ones, in order; returns how
 * many of the sent were received. */
static uint32_t check_subsequence(const sink_t *s)
{
    uint32_t j = 0;
    for (uint32_t i = 0; i < s->n_got; i++) {
        while (j < NPKT && !tlm_test_packets_equal(&g_sent[j], &s->got[i])) {
            j++;
        }
        assert_true(j < NPKT); /* a received packet that was never sent: garbage marked valid */
        j++;
    }
    return s->n_got;
}

/* Byte offsets of each frame's end (its delimiter). */
static size_t frame_ends(const uint8_t *b, size_t n, size_t *ends, size_t cap)
{
    size_t k = 0;
    for (size_t i = 0; i < n && k < cap; i++) {
        if (b[i] == 0) {
            ends[k++] = i;
        }
    }
    return k;
}

static size_t make_stream(void)
{
    tlm_encoder_t enc;
    tlm_encoder_init(&enc);
    return tlm_test_stream(&enc, NPKT, g_stream, sizeof g_stream, g_sent);
}

static void test_clean_back_to_back(void **state)
{
    (void)state;
    const size_t n = make_stream();
    tlm_decoder_t d;
    tlm_decoder_init(&d);
    memset(&g_sink, 0, sizeof g_sink);
    feed(&d, g_stream, n, &g_sink);
    assert_int_equal(g_sink.n_got, NPKT);
    for (uint32_t i = 0; i < NPKT; i++) {
        assert_true(tlm_test_packets_equal(&g_sent[i], &g_sink.got[i]));
    }
    assert_int_equal(d.stats.frames_ok, NPKT);
    assert_int_equal(d.stats.crc_errors + d.stats.truncated + d.stats.oversize + d.stats.bad_packets, 0);
    assert_int_equal(d.stats.resyncs, 0);
    assert_int_equal(d.stats.seq_gaps, 0);
    assert_int_equal(d.stats.bytes, n);
    assert_int_equal(d.stats.type[TLM_TYPE_CAMERA].packets, NPKT / 2);
    assert_int_equal(d.stats.type[TLM_TYPE_NAV].packets, NPKT / 6);
    /* idle delimiters between frames are harmless */
    tlm_decoder_init(&d);
    memset(&g_sink, 0, sizeof g_sink);
    const uint8_t idle[5] = {0, 0, 0, 0, 0};
    feed(&d, idle, 5, &g_sink);
    feed(&d, g_stream, n, &g_sink);
    feed(&d, idle, 5, &g_sink);
    assert_int_equal(g_sink.n_got, NPKT);
    assert_int_equal(g_sink.errors, 0);
}

static void test_random_garbage_between_frames(void **state)
{
    (void)state;
    const size_t n = make_stream();
    size_t ends[NPKT] = {0};
    assert_int_equal(frame_ends(g_stream, n, ends, NPKT), NPKT);
    mfns_rng_t r;
    mfns_rng_seed(&r, 77);
    /* garbage (without 0x00, so it glues onto the next frame) after every 10th frame */
    size_t m = 0, start = 0;
    uint32_t hits = 0;
    for (size_t f = 0; f < NPKT; f++) {
        memcpy(g_mut + m, g_stream + start, ends[f] + 1 - start);
        m += ends[f] + 1 - start;
        start = ends[f] + 1;
        if (f % 10 == 5) {
            const size_t glen = 1 + (size_t)(mfns_rng_uniform(&r) * 40);
            for (size_t k = 0; k < glen; k++) {
                g_mut[m++] = (uint8_t)(1 + mfns_rng_uniform(&r) * 255);
            }
            hits++;
        }
    }
    tlm_decoder_t d;
    tlm_decoder_init(&d);
    memset(&g_sink, 0, sizeof g_sink);
    feed(&d, g_mut, m, &g_sink);
    /* each garbage burst costs exactly the frame it is glued to */
    assert_int_equal(check_subsequence(&g_sink), NPKT - hits);
    assert_int_equal(d.stats.frames_ok, NPKT - hits);
    assert_int_equal(d.stats.crc_errors + d.stats.truncated + d.stats.bad_packets + d.stats.oversize, hits);
    assert_int_equal(d.stats.resyncs, hits);
    assert_int_equal(d.stats.seq_gaps, hits);

    /* a long burst of fully random bytes (zeros included) before a clean stream */
    uint8_t junk[5000];
    for (size_t k = 0; k < sizeof junk; k++) {
        junk[k] = (uint8_t)(mfns_rng_uniform(&r) * 256);
    }
    tlm_decoder_init(&d);
    memset(&g_sink, 0, sizeof g_sink);
    feed(&d, junk, sizeof junk, &g_sink);
    const uint32_t before = g_sink.n_got;
    assert_int_equal(before, 0);
    const uint8_t delim = 0;
    feed(&d, &delim, 1, &g_sink); /* whatever junk was in progress ends here */
    feed(&d, g_stream, n, &g_sink);
    assert_int_equal(g_sink.n_got, NPKT);
    assert_true(d.stats.oversize > 0);
    assert_true(d.stats.bytes_discarded > 0);
    assert_int_equal(d.stats.resyncs, 1);
}

static void test_bit_flips(void **state)
{
    (void)state;
    const size_t n = make_stream();
    size_t ends[NPKT] = {0};
    assert_int_equal(frame_ends(g_stream, n, ends, NPKT), NPKT);
    mfns_rng_t r;
    mfns_rng_seed(&r, 3);
    for (int trial = 0; trial < 200; trial++) {
        memcpy(g_mut, g_stream, n);
        /* one bit flip inside frame f, not in its delimiter; f is followed by
         * and preceded by one of its type, so its loss shows as a sequence gap */
        const size_t f = 6 + (size_t)(mfns_rng_uniform(&r) * (NPKT - 12));
        const size_t lo = ends[f - 1] + 1, hi = ends[f];
        const size_t at = lo + (size_t)(mfns_rng_uniform(&r) * (double)(hi - lo));
        g_mut[at] ^= (uint8_t)(1u << (int)(mfns_rng_uniform(&r) * 8));
        tlm_decoder_t d;
        tlm_decoder_init(&d);
        memset(&g_sink, 0, sizeof g_sink);
        feed(&d, g_mut, n, &g_sink);
        /* A flip may turn a byte into 0x00, splitting the frame in two: both
         * halves are dropped, the next frame still arrives. Nothing else is lost. */
        assert_int_equal(check_subsequence(&g_sink), NPKT - 1);
        assert_int_equal(d.stats.frames_ok, NPKT - 1);
        assert_true(d.stats.crc_errors + d.stats.truncated + d.stats.bad_packets >= 1);
        assert_int_equal(d.stats.resyncs, 1);
        assert_int_equal(d.stats.seq_gaps, 1);
        assert_int_equal(d.stats.seq_lost, 1);
        assert_false(tlm_test_packets_equal(&g_sink.got[f], &g_sent[f]));
    }
}

static void test_crc_error_counted_as_crc(void **state)
{
    (void)state;
    tlm_packet_t p;
    tlm_test_sample(&p, TLM_TYPE_NAV, 1);
    uint8_t raw[TLM_MAX_FRAME];
    size_t n = 0;
    assert_int_equal(tlm_packet_encode(&p, 0, raw, sizeof raw, &n), TLM_OK);
    tlm_put_u16(raw + n, tlm_crc16(raw, n));
    raw[20] ^= 0x40u; /* corrupt after the CRC, before stuffing: only the CRC can tell */
    uint8_t f[TLM_MAX_WIRE];
    size_t fl = 0;
    assert_int_equal(tlm_cobs_encode(raw, n + 2, f, sizeof f, &fl), TLM_OK);
    f[fl++] = 0;
    tlm_decoder_t d;
    tlm_decoder_init(&d);
    int last = 0;
    for (size_t i = 0; i < fl; i++) {
        tlm_packet_t q;
        last = tlm_decoder_push(&d, f[i], &q);
    }
    assert_int_equal(last, TLM_ERR_CRC);
    assert_int_equal(d.stats.crc_errors, 1);
    assert_int_equal(d.last_error, TLM_ERR_CRC);
    /* the same frame with a correct CRC but a bad APID is a bad packet, not a CRC error */
    raw[20] ^= 0x40u;
    raw[1] = 0x55;
    tlm_put_u16(raw + n, tlm_crc16(raw, n));
    assert_int_equal(tlm_cobs_encode(raw, n + 2, f, sizeof f, &fl), TLM_OK);
    f[fl++] = 0;
    for (size_t i = 0; i < fl; i++) {
        tlm_packet_t q;
        last = tlm_decoder_push(&d, f[i], &q);
    }
    assert_int_equal(last, TLM_ERR_APID);
    assert_int_equal(d.stats.bad_packets, 1);
    assert_int_equal(d.stats.crc_errors, 1);
}

static void test_truncated_frames(void **state)
{
    (void)state;
    const size_t n = make_stream();
    size_t ends[NPKT] = {0};
    assert_int_equal(frame_ends(g_stream, n, ends, NPKT), NPKT);
    /* cut the tail off every 7th frame (keep its delimiter): the frame is lost, the next is not */
    size_t m = 0, start = 0;
    uint32_t hits = 0;
    for (size_t f = 0; f < NPKT; f++) {
        size_t len = ends[f] - start;
        if (f % 7 == 3) {
            len = len / 2 + (f % 3); /* various cut points */
            hits++;
        }
        memcpy(g_mut + m, g_stream + start, len);
        m += len;
        g_mut[m++] = 0;
        start = ends[f] + 1;
    }
    tlm_decoder_t d;
    tlm_decoder_init(&d);
    memset(&g_sink, 0, sizeof g_sink);
    feed(&d, g_mut, m, &g_sink);
    assert_int_equal(check_subsequence(&g_sink), NPKT - hits);
    assert_int_equal(d.stats.truncated + d.stats.crc_errors, hits);
    assert_true(d.stats.truncated > 0);
    assert_int_equal(d.stats.resyncs, hits);

    /* a frame whose delimiter is lost merges with the next: both lost, then in sync */
    memcpy(g_mut, g_stream, n);
    memmove(g_mut + ends[10], g_mut + ends[10] + 1, n - ends[10] - 1);
    tlm_decoder_init(&d);
    memset(&g_sink, 0, sizeof g_sink);
    feed(&d, g_mut, n - 1, &g_sink);
    assert_int_equal(check_subsequence(&g_sink), NPKT - 2);
    assert_int_equal(d.stats.resyncs, 1);
    assert_int_equal(d.stats.seq_gaps, 2); /* frame 10 and 11 have different types */

    /* tiny frames: a lone code byte, one byte of data */
    const uint8_t runt[6] = {0x01, 0x00, 0x02, 0x55, 0x00, 0x00};
    tlm_decoder_init(&d);
    memset(&g_sink, 0, sizeof g_sink);
    feed(&d, runt, sizeof runt, &g_sink);
    assert_int_equal(d.stats.truncated, 2);
    assert_int_equal(g_sink.n_got, 0);
}

static void test_oversize_frames(void **state)
{
    (void)state;
    const size_t n = make_stream();
    /* 1000 non-zero bytes, then the clean stream: one oversize, then everything */
    memset(g_mut, 0x5A, 1000);
    memcpy(g_mut + 1000, g_stream, n);
    tlm_decoder_t d;
    tlm_decoder_init(&d);
    memset(&g_sink, 0, sizeof g_sink);
    feed(&d, g_mut, 1000 + n, &g_sink);
    /* the garbage glues onto the first frame: oversize, first frame lost */
    assert_int_equal(d.stats.oversize, 1);
    assert_int_equal(check_subsequence(&g_sink), NPKT - 1);
    assert_true(d.stats.bytes_discarded > 900);
    assert_int_equal(d.stats.resyncs, 1);

    /* a valid COBS frame just one byte too long for the buffer */
    uint8_t big[TLM_MAX_FRAME + 1];
    for (size_t i = 0; i < sizeof big; i++) {
        big[i] = (uint8_t)(i + 1);
    }
    uint8_t enc[TLM_COBS_MAX_ENCODED(TLM_MAX_FRAME + 1) + 1];
    size_t el = 0;
    assert_int_equal(tlm_cobs_encode(big, sizeof big, enc, sizeof enc, &el), TLM_OK);
    enc[el++] = 0;
    tlm_decoder_init(&d);
    memset(&g_sink, 0, sizeof g_sink);
    feed(&d, enc, el, &g_sink);
    assert_int_equal(d.stats.oversize, 1);
    feed(&d, g_stream, n, &g_sink);
    assert_int_equal(g_sink.n_got, NPKT);
}

static void test_sequence_gaps(void **state)
{
    (void)state;
    const size_t n = make_stream();
    size_t ends[NPKT] = {0};
    assert_int_equal(frame_ends(g_stream, n, ends, NPKT), NPKT);
    /* drop whole frames: nav frames 12 and 18 (consecutive nav packets 2 and 3),
     * and camera frame 25: 2 gaps, 3 lost */
    size_t m = 0, start = 0;
    for (size_t f = 0; f < NPKT; f++) {
        const size_t len = ends[f] + 1 - start;
        if (f != 12 && f != 18 && f != 25) {
            memcpy(g_mut + m, g_stream + start, len);
            m += len;
        }
        start = ends[f] + 1;
    }
    tlm_decoder_t d;
    tlm_decoder_init(&d);
    memset(&g_sink, 0, sizeof g_sink);
    feed(&d, g_mut, m, &g_sink);
    assert_int_equal(g_sink.n_got, NPKT - 3);
    assert_int_equal(d.stats.seq_gaps, 2);
    assert_int_equal(d.stats.seq_lost, 3);
    assert_int_equal(d.stats.type[TLM_TYPE_NAV].gaps, 1);
    assert_int_equal(d.stats.type[TLM_TYPE_NAV].lost, 2);
    assert_int_equal(d.stats.type[TLM_TYPE_CAMERA].gaps, 1);
    assert_int_equal(d.stats.type[TLM_TYPE_CAMERA].lost, 1);
    /* no framing errors: a clean gap is not a resync */
    assert_int_equal(d.stats.resyncs, 0);

    /* the 14-bit wrap is not a gap */
    tlm_encoder_t enc;
    tlm_encoder_init(&enc);
    enc.next_seq[TLM_TYPE_NAV] = 0x3FFE;
    tlm_decoder_init(&d);
    for (uint32_t i = 0; i < 4; i++) {
        tlm_packet_t p, q;
        tlm_test_sample(&p, TLM_TYPE_NAV, i);
        uint8_t f[TLM_MAX_WIRE];
        size_t fl = 0;
        assert_int_equal(tlm_frame_encode(&enc, &p, f, sizeof f, &fl), TLM_OK);
        int got = 0;
        for (size_t k = 0; k < fl; k++) {
            got += tlm_decoder_push(&d, f[k], &q) == 1;
        }
        assert_int_equal(got, 1);
    }
    assert_int_equal(d.stats.seq_gaps, 0);
    assert_int_equal(d.stats.type[TLM_TYPE_NAV].last_seq, 1);

    /* counts that go back (a repeat, a reorder, a restarted sender) are counted as
     * back, never as ~16,000 lost: 5, 6, 7, then 3 (back), 4 (its next: not back
     * again, two in a row are no restart yet), 4 (repeat: back), 5 (its next), then
     * 8190 ahead of the highest, 7 (8182 skipped: lost, the largest forward reading)
     * and 0 after it (8190 behind, never skipped: back) */
    const uint16_t seqs[] = {5, 6, 7, 3, 4, 4, 5, 8190, 0};
    const uint32_t want_back[] = {0, 0, 0, 1, 1, 2, 2, 2, 3};
    const uint32_t want_lost[] = {0, 0, 0, 0, 0, 0, 0, 8182, 8182};
    tlm_decoder_init(&d);
    for (size_t i = 0; i < sizeof seqs / sizeof seqs[0]; i++) {
        enc.next_seq[TLM_TYPE_NAV] = seqs[i];
        tlm_packet_t p, q;
        tlm_test_sample(&p, TLM_TYPE_NAV, (uint32_t)i);
        uint8_t f[TLM_MAX_WIRE];
        size_t fl = 0;
        assert_int_equal(tlm_frame_encode(&enc, &p, f, sizeof f, &fl), TLM_OK);
        for (size_t k = 0; k < fl; k++) {
            (void)tlm_decoder_push(&d, f[k], &q);
        }
        assert_int_equal(d.stats.seq_back, want_back[i]);
        assert_int_equal(d.stats.seq_lost, want_lost[i]);
        assert_int_equal(d.stats.type[TLM_TYPE_NAV].back, want_back[i]);
    }
    assert_int_equal(d.stats.frames_ok, sizeof seqs / sizeof seqs[0]);
}

/* Reordered packets are late, not lost; a loss stays a loss; a restarted sender (a back
 * arrival and the counts after it in a row) is read on from its new count. */
static void feed_seq(tlm_decoder_t *d, tlm_encoder_t *enc, uint16_t seq)
{
    enc->next_seq[TLM_TYPE_NAV] = seq;
    tlm_packet_t p, q;
    tlm_test_sample(&p, TLM_TYPE_NAV, seq);
    uint8_t f[TLM_MAX_WIRE];
    size_t fl = 0;
    assert_int_equal(tlm_frame_encode(enc, &p, f, sizeof f, &fl), TLM_OK);
    for (size_t k = 0; k < fl; k++) {
        (void)tlm_decoder_push(d, f[k], &q);
    }
}

static tlm_decoder_t g_dec; /* the missing-count bits: 10 KB, static */
static void test_reorder_is_late_not_lost(void **state)
{
    (void)state;
    tlm_encoder_t enc;
    tlm_encoder_init(&enc);
    /* 0..29 with neighbours swapped and 10, 20 never sent */
    tlm_decoder_init(&g_dec);
    for (uint16_t i = 0; i < 30; i += 2) {
        if (i + 1 != 11 && i + 1 != 21) {
            feed_seq(&g_dec, &enc, (uint16_t)(i + 1));
        }
        if (i != 10 && i != 20) {
            feed_seq(&g_dec, &enc, i);
        }
    }
    assert_int_equal(g_dec.stats.seq_lost, 4); /* 10, 11, 20, 21 */
    assert_true(g_dec.stats.seq_late >= 10);
    assert_int_equal(g_dec.stats.seq_late, g_dec.stats.type[TLM_TYPE_NAV].late);
    assert_int_equal(g_dec.stats.type[TLM_TYPE_NAV].lost, 4);

    /* a full shuffle of 200 counts (seeded): nothing lost */
    uint16_t perm[200];
    for (uint16_t i = 0; i < 200; i++) {
        perm[i] = i;
    }
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 4);
    for (int i = 199; i > 0; i--) {
        const int j = (int)(mfns_rng_uniform(&rng) * (double)(i + 1)) % (i + 1);
        const uint16_t x = perm[i];
        perm[i] = perm[j];
        perm[j] = x;
    }
    tlm_decoder_init(&g_dec);
    for (int i = 0; i < 200; i++) {
        feed_seq(&g_dec, &enc, perm[i]);
    }
    assert_int_equal(g_dec.stats.frames_ok, 200);
    assert_int_equal(g_dec.stats.seq_lost, 0);

    /* a sender restarted: 0..99, then 0..49; then 60..69 (50..59 lost) */
    tlm_decoder_init(&g_dec);
    for (uint16_t i = 0; i < 100; i++) {
        feed_seq(&g_dec, &enc, i);
    }
    for (uint16_t i = 0; i < 50; i++) {
        feed_seq(&g_dec, &enc, i);
    }
    assert_int_equal(g_dec.stats.seq_back, 1); /* the restart, once */
    assert_int_equal(g_dec.stats.seq_lost, 0);
    for (uint16_t i = 60; i < 70; i++) {
        feed_seq(&g_dec, &enc, i);
    }
    assert_int_equal(g_dec.stats.seq_lost, 10);
}

static void test_random_fault_soak(void **state)
{
    (void)state;
    /* Mixed faults at random: every good packet must be a sent one, and the
     * decoder must recover after the last fault. */
    const size_t n = make_stream();
    mfns_rng_t r;
    mfns_rng_seed(&r, 2024);
    for (int trial = 0; trial < 50; trial++) {
        size_t m = 0;
        for (size_t i = 0; i < n && m < sizeof g_mut - 8; i++) {
            const double u = mfns_rng_uniform(&r);
            if (u < 0.002) {
                continue; /* lost byte */
            }
            uint8_t b = g_stream[i];
            if (u < 0.004) {
                b ^= (uint8_t)(1u << (int)(mfns_rng_uniform(&r) * 8));
            }
            g_mut[m++] = b;
            if (u > 0.998) {
                g_mut[m++] = (uint8_t)(mfns_rng_uniform(&r) * 256); /* inserted byte */
            }
        }
        tlm_decoder_t d;
        tlm_decoder_init(&d);
        memset(&g_sink, 0, sizeof g_sink);
        feed(&d, g_mut, m, &g_sink);
        check_subsequence(&g_sink);
        const uint32_t dropped = d.stats.crc_errors + d.stats.truncated + d.stats.oversize + d.stats.bad_packets;
        assert_true(g_sink.n_got + dropped >= NPKT / 2);
        /* afterwards a clean stream decodes completely */
        const uint8_t delim = 0;
        feed(&d, &delim, 1, &g_sink);
        const uint32_t before = g_sink.n_got;
        tlm_encoder_t enc;
        tlm_encoder_init(&enc);
        const size_t n2 = tlm_test_stream(&enc, 12, g_stream, sizeof g_stream, NULL);
        feed(&d, g_stream, n2, &g_sink);
        assert_int_equal(g_sink.n_got - before, 12);
        make_stream();
    }
}

static void test_null_arguments(void **state)
{
    (void)state;
    tlm_decoder_t d;
    tlm_packet_t p;
    tlm_decoder_init(&d);
    assert_int_equal(tlm_decoder_push(NULL, 1, &p), TLM_ERR_NULL);
    assert_int_equal(tlm_decoder_push(&d, 1, NULL), TLM_ERR_NULL);
    tlm_decoder_reset_frame(NULL);
    tlm_decoder_init(NULL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_clean_back_to_back),
        cmocka_unit_test(test_random_garbage_between_frames),
        cmocka_unit_test(test_bit_flips),
        cmocka_unit_test(test_crc_error_counted_as_crc),
        cmocka_unit_test(test_truncated_frames),
        cmocka_unit_test(test_oversize_frames),
        cmocka_unit_test(test_sequence_gaps),
        cmocka_unit_test(test_reorder_is_late_not_lost),
        cmocka_unit_test(test_random_fault_soak),
        cmocka_unit_test(test_null_arguments),
    };
    return cmocka_run_group_tests_name("tlm_decoder", tests, NULL, NULL);
}
