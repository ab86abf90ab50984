/* Unit tests of mfns-ground's upload sender (ground/upload.h) against the
 * board's receiver (firmware/app/nav_upload.h) and its answer codes
 * (nav_cmds_upload_status), over a simulated link that loses commands and
 * answers and answers late: the file arrives byte for byte (go-back on GAP,
 * START again on silence); a segment corrupted on the way ends in
 * UPLOAD_CRC; a board that never answers ends the upload after its tries; a
 * second sender resumes the board's open upload from its next offset. */
#define _DEFAULT_SOURCE /* mkstemp under -std=c11 */
#include "tests/unit/support/testutil.h"

#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "firmware/app/nav_cmds_upload.h"
#include "firmware/app/nav_upload.h"
#include "ground/upload.h"

#define FILE_BYTES 12345u
#define MAX_PENDING 64u
#define STEP_MS 10u

static uint8_t g_file[FILE_BYTES];
static uint8_t g_rx[FILE_BYTES + 100u];
static uint8_t g_gbuf[UPLOAD_FILE_MAX];
static char g_path[64];

typedef struct {
    tlm_event_t ev;
    uint64_t due_ms;
} answer_t;

/* The link and the board. */
typedef struct {
    nav_upload_t board;
    answer_t pending[MAX_PENDING]; /* answers on their way down */
    unsigned n_pending;
    unsigned n_cmds;
    unsigned drop_cmd_every;   /* 0: none; else every n-th command lost on the way up */
    unsigned drop_answer_every;
    unsigned corrupt_cmd;      /* 1-based index of a DATA command whose first byte flips; 0 none */
    bool mute;                 /* the board answers nothing */
    uint64_t latency_ms;
} sim_t;

static sim_t g_sim;

static int setup(void **state)
{
    (void)state;
    for (unsigned i = 0; i < FILE_BYTES; i++) {
        g_file[i] = (uint8_t)((i * 2654435761u) >> 13); /* zeros included */
    }
    (void)snprintf(g_path, sizeof g_path, "/tmp/mfns-upl-XXXXXX");
    const int fd = mkstemp(g_path);
    assert_true(fd >= 0);
    assert_int_equal(write(fd, g_file, FILE_BYTES), (ssize_t)FILE_BYTES);
    assert_int_equal(close(fd), 0);
    memset(&g_sim, 0, sizeof g_sim);
    nav_upload_init(&g_sim.board, g_rx, sizeof g_rx, 0u);
    g_sim.latency_ms = 60u;
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    assert_int_equal(unlink(g_path), 0);
    return 0;
}

/* The board acting on one command (as nav_cmds_upload.c does, without the table load). */
static void board_cmd(sim_t *s, tc_cmd_t c, uint16_t seq, uint64_t now_ms)
{
    s->n_cmds++;
    if (s->drop_cmd_every != 0u && s->n_cmds % s->drop_cmd_every == 0u) {
        return; /* lost on the way up */
    }
    if (c.opcode == TC_OP_UPLOAD_DATA && s->n_cmds == s->corrupt_cmd) {
        c.u.upload_data.bytes[0] ^= 0x5Au; /* a bit error the frame CRC missed */
    }
    const uint32_t t = (uint32_t)now_ms;
    nav_upload_status_t st = NAV_UP_E_STATE;
    int32_t arg1 = 0;
    switch (c.opcode) {
    case TC_OP_UPLOAD_START:
        st = nav_upload_start(&s->board, c.u.upload_start.size, c.u.upload_start.crc32, c.u.upload_start.name, t);
        arg1 = (int32_t)nav_upload_next(&s->board);
        break;
    case TC_OP_UPLOAD_DATA:
        st = nav_upload_data(&s->board, c.u.upload_data.offset, c.u.upload_data.bytes, c.u.upload_data.len, t);
        arg1 = (int32_t)nav_upload_next(&s->board);
        break;
    case TC_OP_UPLOAD_END:
        st = nav_upload_end(&s->board, t);
        arg1 = 0x12345678;
        if (st == NAV_UP_OK) {
            assert_memory_equal(s->board.buf, g_file, FILE_BYTES); /* what the board would store */
            (void)nav_upload_abort(&s->board);                    /* closed, as the store does */
        }
        break;
    case TC_OP_UPLOAD_ABORT: st = nav_upload_abort(&s->board); break;
    default: fail_msg("opcode %u", c.opcode);
    }
    if (s->mute || (s->drop_answer_every != 0u && s->n_cmds % s->drop_answer_every == 1u)) {
        return;
    }
    const tc_status_t code = nav_cmds_upload_status((int)st);
    assert_true(s->n_pending < MAX_PENDING);
    answer_t *a = &s->pending[s->n_pending++];
    memset(a, 0, sizeof *a);
    a->ev.code = (uint16_t)(code == TC_OK ? TLM_EVT_CMD_ACCEPTED : TLM_EVT_CMD_REJECTED);
    a->ev.subject = c.opcode;
    a->ev.arg0 = seq;
    a->ev.arg1 = code == TC_OK ? arg1 : (int32_t)code;
    a->due_ms = now_ms + s->latency_ms;
}

/* Runs sender and link until the upload ends or max_ms passes; the final time. */
static uint64_t run(ground_upload_t *g, sim_t *s, uint64_t t0_ms, uint64_t max_ms, uint16_t *seq)
{
    uint64_t now = t0_ms;
    for (; now < t0_ms + max_ms && !ground_upload_finished(g); now += STEP_MS) {
        for (unsigned k = 0; k < 4u; k++) { /* the board's bound: 4 commands a cycle */
            tc_cmd_t c;
            if (!ground_upload_next(g, now, &c)) {
                break;
            }
            ground_upload_sent(g, &c, *seq, now);
            board_cmd(s, c, *seq, now);
            *seq = (uint16_t)((*seq + 1u) & 0x3FFFu);
        }
        unsigned keep = 0;
        for (unsigned i = 0; i < s->n_pending; i++) {
            if (s->pending[i].due_ms <= now) {
                ground_upload_event(g, &s->pending[i].ev, now);
            } else {
                s->pending[keep++] = s->pending[i];
            }
        }
        s->n_pending = keep;
    }
    return now;
}

static void open_upload(ground_upload_t *g)
{
    char err[256];
    assert_int_equal(ground_upload_open(g, g_path, g_gbuf, sizeof g_gbuf, err, sizeof err), 0);
    assert_int_equal(g->size, FILE_BYTES);
    assert_int_equal(g->crc32, mfns_crc32(0u, g_file, FILE_BYTES));
    assert_string_equal(g->name, strrchr(g_path, '/') + 1);
}

static void test_clean_link(void **state)
{
    (void)state;
    ground_upload_t g;
    open_upload(&g);
    uint16_t seq = 0;
    (void)run(&g, &g_sim, 1000u, 60000u, &seq);
    assert_int_equal(g.phase, UPLOAD_OK);
    assert_int_equal(g.table_crc, 0x12345678u);
    assert_int_equal(g.n_data, (FILE_BYTES + TC_UPLOAD_SEG_LEN - 1u) / TC_UPLOAD_SEG_LEN);
    assert_int_equal(g.n_gaps + g.n_resent + g.n_restarts, 0);
}

static void test_lossy_link(void **state)
{
    (void)state;
    g_sim.drop_cmd_every = 17u;   /* a lost segment: GAP behind it, go back */
    g_sim.drop_answer_every = 23u; /* a lost answer: covered by later ones, or START again */
    ground_upload_t g;
    open_upload(&g);
    uint16_t seq = 0;
    (void)run(&g, &g_sim, 1000u, 600000u, &seq);
    assert_int_equal(g.phase, UPLOAD_OK); /* board_cmd checked the bytes at END */
    assert_true(g.n_gaps > 0u);
    assert_true(g.n_resent > 0u);
}

static void test_corrupted_segment_is_crc(void **state)
{
    (void)state;
    g_sim.corrupt_cmd = 9u;
    ground_upload_t g;
    open_upload(&g);
    uint16_t seq = 0;
    (void)run(&g, &g_sim, 1000u, 60000u, &seq);
    assert_int_equal(g.phase, UPLOAD_FAILED);
    assert_int_equal(g.reject, TC_E_UPLOAD_CRC);
    assert_int_equal(g_sim.board.state, NAV_UPLOAD_IDLE); /* dropped: nothing to store */
}

static void test_mute_board_gives_up(void **state)
{
    (void)state;
    g_sim.mute = true;
    ground_upload_t g;
    open_upload(&g);
    uint16_t seq = 0;
    const uint64_t end = run(&g, &g_sim, 1000u, 600000u, &seq);
    assert_int_equal(g.phase, UPLOAD_FAILED);
    assert_int_equal(g.reject, 0);
    assert_true(end - 1000u >= (uint64_t)UPLOAD_TRIES * UPLOAD_ANSWER_MS);
    tc_cmd_t c;
    assert_false(ground_upload_abort(&g, end, &c)); /* finished: nothing to abort */
}

static void test_resume_and_abort(void **state)
{
    (void)state;
    ground_upload_t g;
    open_upload(&g);
    uint16_t seq = 0;
    (void)run(&g, &g_sim, 1000u, 400u, &seq); /* part of the file, then the ground stops */
    assert_false(ground_upload_finished(&g));
    const uint32_t had = nav_upload_next(&g_sim.board);
    assert_true(had > 0u && had < FILE_BYTES);
    g_sim.n_pending = 0; /* its answers never arrive */
    ground_upload_t g2; /* another run of mfns-ground: START resumes */
    open_upload(&g2);
    (void)run(&g2, &g_sim, 5000u, 60000u, &seq);
    assert_int_equal(g2.phase, UPLOAD_OK);
    /* only the rest went: the segments from the board's next offset */
    assert_true(g2.n_data <= (FILE_BYTES - had) / TC_UPLOAD_SEG_LEN + 1u);
    /* an interrupted one: the abort command, the board drops it */
    ground_upload_t g3;
    open_upload(&g3);
    (void)run(&g3, &g_sim, 70000u, 300u, &seq);
    tc_cmd_t c;
    assert_true(ground_upload_abort(&g3, 70300u, &c));
    assert_int_equal(c.opcode, TC_OP_UPLOAD_ABORT);
    assert_true(g3.aborted && ground_upload_finished(&g3));
    board_cmd(&g_sim, c, seq, 70300u);
    assert_int_equal(g_sim.board.state, NAV_UPLOAD_IDLE);
}

static void test_open_refusals(void **state)
{
    (void)state;
    ground_upload_t g;
    char err[256];
    assert_int_equal(ground_upload_open(&g, "/nonexistent/x.mfnstbl", g_gbuf, sizeof g_gbuf, err, sizeof err), -1);
    assert_non_null(strstr(err, "/nonexistent/x.mfnstbl"));
    assert_int_equal(ground_upload_open(&g, g_path, g_gbuf, 100u, err, sizeof err), -1); /* over the cap */
    assert_non_null(strstr(err, "larger"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_clean_link, setup, teardown),
        cmocka_unit_test_setup_teardown(test_lossy_link, setup, teardown),
        cmocka_unit_test_setup_teardown(test_corrupted_segment_is_crc, setup, teardown),
        cmocka_unit_test_setup_teardown(test_mute_board_gives_up, setup, teardown),
        cmocka_unit_test_setup_teardown(test_resume_and_abort, setup, teardown),
        cmocka_unit_test_setup_teardown(test_open_refusals, setup, teardown),
    };
    return cmocka_run_group_tests_name("ground_upload", tests, NULL, NULL);
}
