/* Unit tests of the drop-oldest transmit queue: order, wrap-around, dropping
 * the oldest whole frames when full, never dropping a frame already started,
 * and that what leaves the queue is always a decodable frame sequence. */
#include "tests/unit/support/testutil.h"

#include <string.h>

#include "firmware/tlm/tlm_decoder.h"
#include "tests/unit/support/tlm_test_samples.h"
#include "firmware/tlm/tlm_txq.h"

static tlm_txq_t g_q;

/* A frame of len bytes whose bytes all equal tag (no delimiter semantics needed here). */
static void push_tagged(tlm_txq_t *q, uint8_t tag, size_t len)
{
    uint8_t f[TLM_MAX_WIRE];
    assert_true(len <= sizeof f);
    memset(f, tag, len);
    assert_int_equal(tlm_txq_push(q, f, len), TLM_OK);
}

/* Drain up to max bytes (0 = all) into out; returns the count. */
static size_t drain(tlm_txq_t *q, uint8_t *out, size_t max)
{
    size_t total = 0;
    for (int guard = 0; guard < 100000; guard++) {
        const uint8_t *p = NULL;
        size_t n = tlm_txq_peek(q, &p);
        if (n == 0) {
            break;
        }
        if (max != 0 && n > max - total) {
            n = max - total;
        }
        memcpy(out + total, p, n);
        tlm_txq_consume(q, n);
        total += n;
        if (max != 0 && total == max) {
            break;
        }
    }
    return total;
}

static void test_fifo_order_and_wrap(void **state)
{
    (void)state;
    tlm_txq_init(&g_q);
    static uint8_t out[TLM_TXQ_BYTES * 2];
    /* many rounds of push 3 / drain so the ring wraps at every offset */
    for (int round = 0; round < 300; round++) {
        for (int k = 0; k < 3; k++) {
            push_tagged(&g_q, (uint8_t)(round * 3 + k + 1), 17u + (size_t)(round % 50) + (size_t)k);
        }
        const size_t n = drain(&g_q, out, 0);
        size_t pos = 0;
        for (int k = 0; k < 3; k++) {
            const size_t len = 17u + (size_t)(round % 50) + (size_t)k;
            for (size_t i = 0; i < len; i++) {
                assert_int_equal(out[pos + i], (uint8_t)(round * 3 + k + 1));
            }
            pos += len;
        }
        assert_int_equal(n, pos);
    }
    assert_int_equal(g_q.dropped, 0);
    assert_int_equal(g_q.sent, 900);
    assert_int_equal(tlm_txq_bytes(&g_q), 0);
    assert_int_equal(tlm_txq_frames(&g_q), 0);
}

static void test_drops_oldest_when_full(void **state)
{
    (void)state;
    tlm_txq_init(&g_q);
    /* 200 frames of 50 bytes mean = 10,000 bytes pushed, more than the bytes
     * and the frame slots hold; the queue holds the newest */
    _Static_assert(100u * 100u > TLM_TXQ_BYTES && 200u > TLM_TXQ_FRAMES, "the test overfills the queue");
    for (int i = 0; i < 100; i++) {
        push_tagged(&g_q, (uint8_t)(i + 1), 60);
        push_tagged(&g_q, (uint8_t)(i + 101), 40);
    }
    assert_true(tlm_txq_bytes(&g_q) <= TLM_TXQ_BYTES);
    assert_int_equal(g_q.pushed, 200);
    assert_int_equal(g_q.dropped + tlm_txq_frames(&g_q), 200);
    assert_true(g_q.dropped > 0);
    static uint8_t out[TLM_TXQ_BYTES];
    const size_t n = drain(&g_q, out, 0);
    /* the last frame out is the last frame pushed, and the first is not the first pushed */
    assert_int_equal(out[n - 1], 200);
    assert_int_not_equal(out[0], 1);
    /* contents form whole frames in push order */
    size_t pos = 0;
    int last_i = -1;
    while (pos < n) {
        const uint8_t tag = out[pos];
        const int i = tag > 100 ? tag - 101 : tag - 1;
        const size_t len = tag > 100 ? 40u : 60u;
        for (size_t k = 0; k < len; k++) {
            assert_int_equal(out[pos + k], tag);
        }
        assert_true(i >= last_i);
        last_i = i;
        pos += len;
    }
    assert_int_equal(pos, n);
    /* too many small frames: the frame-slot limit drops oldest too */
    tlm_txq_init(&g_q);
    for (int i = 0; i < (int)TLM_TXQ_FRAMES + 10; i++) {
        push_tagged(&g_q, (uint8_t)(i + 1), 2);
    }
    assert_int_equal(tlm_txq_frames(&g_q), TLM_TXQ_FRAMES);
    assert_int_equal(g_q.dropped, 10);
}

static void test_started_frame_is_never_dropped(void **state)
{
    (void)state;
    tlm_txq_init(&g_q);
    push_tagged(&g_q, 0xAA, 75);
    static uint8_t out[TLM_TXQ_BYTES * 2];
    /* 30 bytes of the head frame written, then the queue overflows */
    assert_int_equal(drain(&g_q, out, 30), 30);
    _Static_assert(150u * 70u > TLM_TXQ_BYTES, "the test overfills the queue");
    for (int i = 0; i < 150; i++) {
        push_tagged(&g_q, (uint8_t)(i + 1), 70);
    }
    assert_true(g_q.dropped > 0);
    const size_t n = drain(&g_q, out + 30, 0);
    /* the rest of the started frame comes first, intact */
    for (size_t k = 0; k < 75; k++) {
        assert_int_equal(out[k], 0xAA);
    }
    /* then whole 70-byte frames, ending with the newest */
    assert_int_equal((n - 45) % 70, 0);
    assert_int_equal(out[30 + n - 1], 150);
    for (size_t pos = 75; pos < 30 + n; pos += 70) {
        for (size_t k = 0; k < 70; k++) {
            assert_int_equal(out[pos + k], out[pos]);
        }
    }
    /* a frame larger than all the room left behind a started frame is refused and counted */
    tlm_txq_init(&g_q);
    uint8_t big[TLM_MAX_WIRE];
    memset(big, 7, sizeof big);
    assert_int_equal(tlm_txq_push(&g_q, big, sizeof big), TLM_OK);
    assert_int_equal(drain(&g_q, out, 1), 1);
    int refused = 0;
    for (int i = 0; i < 100; i++) {
        const int rc = tlm_txq_push(&g_q, big, sizeof big);
        assert_true(rc == TLM_OK || rc == TLM_ERR_BUFFER);
        refused += rc == TLM_ERR_BUFFER;
    }
    assert_int_equal(refused, 0); /* dropping unstarted frames always makes room */
}

static void test_queue_output_decodes(void **state)
{
    (void)state;
    /* real frames through an overflowing queue drained in odd-sized pieces */
    tlm_txq_init(&g_q);
    tlm_encoder_t enc;
    tlm_encoder_init(&enc);
    tlm_decoder_t d;
    tlm_decoder_init(&d);
    static uint8_t out[TLM_TXQ_BYTES * 2];
    uint32_t got = 0;
    for (uint32_t i = 0; i < 2000; i++) {
        tlm_packet_t p;
        tlm_test_sample(&p, (tlm_type_t)(i % TLM_NUM_TYPES), i);
        uint8_t f[TLM_MAX_WIRE];
        size_t n = 0;
        assert_int_equal(tlm_frame_encode(&enc, &p, f, sizeof f, &n), TLM_OK);
        assert_int_equal(tlm_txq_push(&g_q, f, n), TLM_OK);
        /* the "UART" takes 37 bytes per push: slower than the producer */
        const size_t m = drain(&g_q, out, 37);
        for (size_t k = 0; k < m; k++) {
            tlm_packet_t q;
            const int rc = tlm_decoder_push(&d, out[k], &q);
            assert_true(rc >= 0); /* whole frames only: never a broken frame */
            got += rc == 1;
        }
    }
    assert_true(g_q.dropped > 0);
    const size_t m = drain(&g_q, out, 0);
    for (size_t k = 0; k < m; k++) {
        tlm_packet_t q;
        got += tlm_decoder_push(&d, out[k], &q) == 1;
    }
    assert_int_equal(got + g_q.dropped, 2000);
    assert_int_equal(d.stats.seq_lost, g_q.dropped); /* each drop is a loss the ground sees */
}

static void test_discard_partial(void **state)
{
    (void)state;
    tlm_txq_init(&g_q);
    push_tagged(&g_q, 1, 50);
    push_tagged(&g_q, 2, 50);
    tlm_txq_discard_partial(&g_q); /* nothing started: no-op */
    assert_int_equal(tlm_txq_frames(&g_q), 2);
    static uint8_t out[200];
    assert_int_equal(drain(&g_q, out, 20), 20);
    tlm_txq_discard_partial(&g_q);
    assert_int_equal(tlm_txq_frames(&g_q), 1);
    assert_int_equal(g_q.dropped, 1);
    assert_int_equal(drain(&g_q, out, 0), 50);
    assert_int_equal(out[0], 2);
    assert_int_equal(out[49], 2);
}

static void test_arguments(void **state)
{
    (void)state;
    tlm_txq_init(&g_q);
    uint8_t f[TLM_TXQ_MAX_WIRE + 1]; /* one past the longest queued frame */
    memset(f, 1, sizeof f);
    assert_int_equal(tlm_txq_push(&g_q, f, 0), TLM_ERR_ARG);
    assert_int_equal(tlm_txq_push(&g_q, f, sizeof f), TLM_ERR_ARG);
    assert_int_equal(tlm_txq_push(NULL, f, 1), TLM_ERR_NULL);
    assert_int_equal(tlm_txq_push(&g_q, NULL, 1), TLM_ERR_NULL);
    const uint8_t *p = NULL;
    assert_int_equal(tlm_txq_peek(&g_q, &p), 0);
    tlm_txq_consume(&g_q, 10); /* more than queued: harmless */
    assert_int_equal(tlm_txq_bytes(&g_q), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fifo_order_and_wrap),
        cmocka_unit_test(test_drops_oldest_when_full),
        cmocka_unit_test(test_started_frame_is_never_dropped),
        cmocka_unit_test(test_queue_output_decodes),
        cmocka_unit_test(test_discard_partial),
        cmocka_unit_test(test_arguments),
    };
    return cmocka_run_group_tests_name("tlm_txq", tests, NULL, NULL);
}
