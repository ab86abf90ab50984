/* Unit tests of the flight command dispatch (firmware/app/nav_cmd_dispatch.h)
 * with a table of recording fake actions: every opcode reaches its action and answers
 * CMD_ACCEPTED with the documented arguments; every rejection (frame faults,
 * replayed and out-of-order sequence counts, an action refusing) answers
 * CMD_REJECTED with its code and touches nothing; the per-cycle bound; the
 * counters and RESET_COUNTERS. */
#include "tests/unit/support/testutil.h"

#include <string.h>

#include "firmware/tlm/cobs.h"
#include "firmware/tlm/crc16.h"
#include "firmware/app/nav_app.h"
#include "firmware/app/nav_cmd_dispatch.h"
#include "firmware/app/nav_cmds.h"

typedef struct {
    int code, sev, subject;
    int32_t a0, a1;
} ev_t;

static struct {
    ev_t ev[256];
    int n_ev;
    int calls_mode, calls_pose, calls_cam, calls_table, calls_reset;
    uint8_t mode, cam;
    bool enable;
    tc_pose_hint_t pose;
    char path[TC_PATH_MAX];
    tc_status_t refuse; /* what the actions answer */
} g;

static tc_status_t f_noop(void *ctx, const tc_cmd_t *cmd, int32_t *arg1)
{
    (void)ctx;
    (void)cmd;
    (void)arg1;
    return TC_OK;
}
static tc_status_t f_mode(void *ctx, const tc_cmd_t *cmd, int32_t *arg1)
{
    (void)ctx;
    g.calls_mode++;
    g.mode = cmd->u.mode;
    *arg1 = cmd->u.mode;
    return g.refuse;
}
static tc_status_t f_pose(void *ctx, const tc_cmd_t *cmd, int32_t *arg1)
{
    (void)ctx;
    (void)arg1;
    g.calls_pose++;
    g.pose = cmd->u.pose;
    return g.refuse;
}
static tc_status_t f_cam(void *ctx, const tc_cmd_t *cmd, int32_t *arg1)
{
    (void)ctx;
    const bool en = cmd->opcode == TC_OP_CAMERA_ENABLE;
    g.calls_cam++;
    g.cam = cmd->u.camera;
    g.enable = en;
    *arg1 = en ? 7 : 3;
    return g.refuse;
}
static tc_status_t f_table(void *ctx, const tc_cmd_t *cmd, int32_t *arg1)
{
    (void)ctx;
    g.calls_table++;
    (void)snprintf(g.path, sizeof g.path, "%s", cmd->u.path);
    *arg1 = 0x1234;
    return g.refuse;
}
static tc_status_t f_reset(void *ctx, const tc_cmd_t *cmd, int32_t *arg1)
{
    (void)ctx;
    (void)cmd;
    (void)arg1;
    g.calls_reset++;
    return TC_OK;
}
static void f_event(void *ctx, tlm_event_code_t code, tlm_severity_t sev, uint8_t subject, int32_t a0, int32_t a1)
{
    (void)ctx;
    assert_true(g.n_ev < 256);
    g.ev[g.n_ev++] = (ev_t){(int)code, (int)sev, subject, a0, a1};
}

/* The program's table shape (firmware/app/nav_cmds.c) with recording fakes. */
static const nav_cmd_fn_t k_table[] = {
    [TC_OP_NOOP] = f_noop,           [TC_OP_RESET_COUNTERS] = f_reset, [TC_OP_SET_MODE] = f_mode,
    [TC_OP_SET_POSE_HINT] = f_pose,  [TC_OP_CAMERA_ENABLE] = f_cam,    [TC_OP_CAMERA_DISABLE] = f_cam,
    [TC_OP_TABLE_LOAD] = f_table,
};
static const nav_cmd_ops_t k_ops = {NULL, k_table, sizeof k_table / sizeof k_table[0], f_event, NULL};
static const nav_cmd_fn_t k_no_actions[sizeof k_table / sizeof k_table[0]]; /* all NULL */

static int setup(void **state)
{
    (void)state;
    memset(&g, 0, sizeof g);
    return 0;
}

static size_t wire(uint8_t op, uint16_t seq, uint8_t *out)
{
    tc_cmd_t c;
    memset(&c, 0, sizeof c);
    c.opcode = op;
    switch (op) {
    case TC_OP_SET_MODE: c.u.mode = TLM_MODE_TRACK; break;
    case TC_OP_CAMERA_DISABLE:
    case TC_OP_CAMERA_ENABLE: c.u.camera = 1; break;
    case TC_OP_SET_POSE_HINT:
        c.u.pose.pos_um[0] = 480741;
        c.u.pose.att_udeg[2] = -168279078;
        break;
    case TC_OP_TABLE_LOAD: (void)snprintf(c.u.path, sizeof c.u.path, "/t.mfnstbl"); break;
    default: break;
    }
    size_t n = 0;
    assert_int_equal(tc_frame_encode(&c, seq, out, TC_MAX_WIRE, &n), TC_OK);
    return n;
}

/* Feed one command frame; returns the one event it produced. */
static ev_t one(nav_cmd_t *c, uint8_t op, uint16_t seq)
{
    uint8_t w[TC_MAX_WIRE];
    const size_t n = wire(op, seq, w);
    const int before = g.n_ev;
    unsigned h = 0;
    assert_int_equal(nav_cmd_feed(c, w, n, NAV_CMD_MAX_PER_CYCLE, &k_ops, &h), n);
    assert_int_equal(h, 1);
    assert_int_equal(g.n_ev, before + 1);
    return g.ev[g.n_ev - 1];
}

static void test_every_opcode_accepted(void **state)
{
    (void)state;
    nav_cmd_t c;
    nav_cmd_init(&c);
    ev_t e = one(&c, TC_OP_NOOP, 10);
    assert_int_equal(e.code, TLM_EVT_CMD_ACCEPTED);
    assert_int_equal(e.subject, TC_OP_NOOP);
    assert_int_equal(e.a0, 10);
    assert_int_equal(e.a1, 0);
    e = one(&c, TC_OP_SET_MODE, 11);
    assert_int_equal(e.code, TLM_EVT_CMD_ACCEPTED);
    assert_int_equal(g.calls_mode, 1);
    assert_int_equal(g.mode, TLM_MODE_TRACK);
    assert_int_equal(e.a1, TLM_MODE_TRACK);
    e = one(&c, TC_OP_SET_POSE_HINT, 12);
    assert_int_equal(e.code, TLM_EVT_CMD_ACCEPTED);
    assert_int_equal(g.calls_pose, 1);
    assert_int_equal(g.pose.pos_um[0], 480741);
    assert_int_equal(g.pose.att_udeg[2], -168279078);
    e = one(&c, TC_OP_CAMERA_DISABLE, 13);
    assert_int_equal(g.cam, 1);
    assert_false(g.enable);
    assert_int_equal(e.a1, 3);
    e = one(&c, TC_OP_CAMERA_ENABLE, 14);
    assert_true(g.enable);
    assert_int_equal(e.a1, 7);
    e = one(&c, TC_OP_TABLE_LOAD, 15);
    assert_int_equal(e.code, TLM_EVT_CMD_ACCEPTED);
    assert_string_equal(g.path, "/t.mfnstbl");
    assert_int_equal(e.a1, 0x1234);
    assert_int_equal(c.n_accepted, 6);
    assert_int_equal(c.n_rejected, 0);
    assert_int_equal(c.seq_last, 15);
    e = one(&c, TC_OP_RESET_COUNTERS, 16);
    assert_int_equal(e.code, TLM_EVT_CMD_ACCEPTED);
    assert_int_equal(g.calls_reset, 1);
    assert_int_equal(c.n_accepted, 0); /* cFS style: reads 0 after the reset */
    assert_int_equal(c.seq_last, 16);
}

static void test_sequence_guard(void **state)
{
    (void)state;
    nav_cmd_t c;
    nav_cmd_init(&c);
    assert_int_equal(one(&c, TC_OP_NOOP, 16380).code, TLM_EVT_CMD_ACCEPTED); /* any count first */
    ev_t e = one(&c, TC_OP_NOOP, 16380);                                     /* replayed */
    assert_int_equal(e.code, TLM_EVT_CMD_REJECTED);
    assert_int_equal(e.a1, TC_E_SEQUENCE);
    assert_int_equal(e.a0, 16380);
    assert_int_equal(e.subject, TC_OP_NOOP);
    assert_int_equal(one(&c, TC_OP_NOOP, 16379).a1, TC_E_SEQUENCE); /* older */
    assert_int_equal(one(&c, TC_OP_NOOP, 2).code, TLM_EVT_CMD_ACCEPTED); /* newer across the wrap */
    assert_int_equal(one(&c, TC_OP_NOOP, 16383).a1, TC_E_SEQUENCE);   /* older across the wrap */
    assert_int_equal(one(&c, TC_OP_NOOP, (uint16_t)(2 + NAV_CMD_SEQ_WINDOW + 1)).a1, TC_E_SEQUENCE);
    assert_int_equal(one(&c, TC_OP_NOOP, (uint16_t)(2 + NAV_CMD_SEQ_WINDOW)).code, TLM_EVT_CMD_ACCEPTED);
    assert_int_equal(c.n_accepted, 3);
    assert_int_equal(c.n_rejected, 4);
    /* a replayed action never reaches its action */
    g.calls_mode = 0;
    assert_int_equal(one(&c, TC_OP_SET_MODE, 8200).code, TLM_EVT_CMD_ACCEPTED);
    assert_int_equal(one(&c, TC_OP_SET_MODE, 8200).a1, TC_E_SEQUENCE);
    assert_int_equal(g.calls_mode, 1);
    /* a new session (an accepted re-synchronisation): any count again, then the guard as before */
    nav_cmd_new_session(&c);
    assert_int_equal(one(&c, TC_OP_NOOP, 1).code, TLM_EVT_CMD_ACCEPTED);
    assert_int_equal(one(&c, TC_OP_NOOP, 1).a1, TC_E_SEQUENCE);
    nav_cmd_new_session(NULL); /* no crash */
}

static void test_action_refusal_keeps_the_reference(void **state)
{
    (void)state;
    nav_cmd_t c;
    nav_cmd_init(&c);
    assert_int_equal(one(&c, TC_OP_NOOP, 1).code, TLM_EVT_CMD_ACCEPTED);
    g.refuse = TC_E_STATE;
    ev_t e = one(&c, TC_OP_SET_MODE, 2);
    assert_int_equal(e.code, TLM_EVT_CMD_REJECTED);
    assert_int_equal(e.a1, TC_E_STATE);
    g.refuse = TC_E_TABLE;
    assert_int_equal(one(&c, TC_OP_TABLE_LOAD, 3).a1, TC_E_TABLE);
    g.refuse = TC_OK;
    /* the refused counts did not move the reference: 2 may be sent again */
    assert_int_equal(one(&c, TC_OP_SET_MODE, 2).code, TLM_EVT_CMD_ACCEPTED);
    assert_int_equal(c.seq_last, 2);
    assert_int_equal(c.n_rejected, 2);
}

static void test_frame_faults_rejected(void **state)
{
    (void)state;
    nav_cmd_t c;
    nav_cmd_init(&c);
    uint8_t w[TC_MAX_WIRE];
    size_t n = wire(TC_OP_SET_MODE, 4, w);
    w[3] ^= 0x01u; /* a payload byte: CRC */
    unsigned h = 0;
    (void)nav_cmd_feed(&c, w, n, 4, &k_ops, &h);
    assert_int_equal(h, 1);
    assert_int_equal(g.ev[0].code, TLM_EVT_CMD_REJECTED);
    assert_int_equal(g.ev[0].a1, TC_E_CRC);
    assert_int_equal(g.ev[0].subject, 0); /* nothing trusted from a bad frame */
    assert_int_equal(g.ev[0].a0, -1);
    assert_int_equal(g.calls_mode, 0);
    /* garbage without delimiters: one rejection (the overflow), then skipped
     * to the next delimiter; never a crash, never an action */
    uint8_t junk[1000];
    for (size_t i = 0; i < sizeof junk; i++) {
        junk[i] = (uint8_t)(0x41u + i % 7u);
    }
    size_t off = 0;
    for (int cycle = 0; cycle < 20 && off < sizeof junk; cycle++) {
        off += nav_cmd_feed(&c, junk + off, sizeof junk - off, NAV_CMD_MAX_PER_CYCLE, &k_ops, &h);
        assert_true(h <= NAV_CMD_MAX_PER_CYCLE);
    }
    assert_int_equal(off, sizeof junk);
    assert_int_equal(g.n_ev, 2);
    assert_int_equal(g.ev[1].code, TLM_EVT_CMD_REJECTED);
    assert_int_equal(g.ev[1].a1, TC_E_OVERSIZE);
    assert_int_equal(g.calls_mode + g.calls_pose + g.calls_cam + g.calls_table + g.calls_reset, 0);
    /* and after a delimiter the link works again */
    const uint8_t z = 0;
    (void)nav_cmd_feed(&c, &z, 1, 4, &k_ops, &h);
    assert_int_equal(one(&c, TC_OP_NOOP, 5).code, TLM_EVT_CMD_ACCEPTED);
    /* garbage with delimiters: one rejection per frame, bounded per cycle */
    for (size_t i = 0; i < sizeof junk; i += 10) {
        junk[i] = 0;
    }
    g.n_ev = 0;
    off = 0;
    int cycles = 0;
    for (; cycles < 1000 && off < sizeof junk; cycles++) {
        off += nav_cmd_feed(&c, junk + off, sizeof junk - off, NAV_CMD_MAX_PER_CYCLE, &k_ops, &h);
    }
    assert_int_equal(g.n_ev, 99); /* runs of 9 bytes, each ended by the next zero (the last one is open) */
    assert_true(cycles >= 99 / (int)NAV_CMD_MAX_PER_CYCLE);
    for (int i = 0; i < g.n_ev; i++) {
        assert_int_equal(g.ev[i].code, TLM_EVT_CMD_REJECTED);
        assert_true(g.ev[i].a1 == TC_E_RUNT || g.ev[i].a1 == TC_E_FRAME);
    }
    assert_int_equal(g.calls_mode + g.calls_pose + g.calls_cam + g.calls_table + g.calls_reset, 0);
    /* a header-readable packet with a bad argument reports its seq and opcode */
    n = wire(TC_OP_CAMERA_ENABLE, 6, w);
    uint8_t pkt[TC_MAX_FRAME];
    size_t pn = 0;
    assert_int_equal(tlm_cobs_decode(w, n - 1u, pkt, sizeof pkt, &pn), TLM_OK);
    pkt[8] = 9; /* camera 9 */
    tlm_put_u16(pkt + pn - 2u, tlm_crc16(pkt, pn - 2u));
    size_t en = 0;
    assert_int_equal(tlm_cobs_encode(pkt, pn, w, sizeof w, &en), TLM_OK);
    w[en] = 0;
    (void)nav_cmd_feed(&c, &z, 1, 4, &k_ops, &h); /* ends the garbage's last, unterminated run */
    g.n_ev = 0;
    (void)nav_cmd_feed(&c, w, en + 1u, 4, &k_ops, &h);
    assert_int_equal(g.n_ev, 1);
    assert_int_equal(g.ev[0].a1, TC_E_ARG);
    assert_int_equal(g.ev[0].subject, TC_OP_CAMERA_ENABLE);
    assert_int_equal(g.ev[0].a0, 6);
    assert_int_equal(g.calls_cam, 0);
}

static void test_bound_per_cycle(void **state)
{
    (void)state;
    nav_cmd_t c;
    nav_cmd_init(&c);
    uint8_t buf[10 * TC_MAX_WIRE];
    size_t n = 0;
    for (uint16_t s = 0; s < 10; s++) {
        n += wire(TC_OP_NOOP, s, buf + n);
    }
    size_t off = 0;
    unsigned h = 0;
    off += nav_cmd_feed(&c, buf, n, NAV_CMD_MAX_PER_CYCLE, &k_ops, &h);
    assert_int_equal(h, NAV_CMD_MAX_PER_CYCLE);
    assert_true(off < n);
    assert_int_equal(g.n_ev, 4);
    off += nav_cmd_feed(&c, buf + off, n - off, NAV_CMD_MAX_PER_CYCLE, &k_ops, &h);
    off += nav_cmd_feed(&c, buf + off, n - off, NAV_CMD_MAX_PER_CYCLE, &k_ops, &h);
    assert_int_equal(off, n);
    assert_int_equal(g.n_ev, 10);
    assert_int_equal(c.n_accepted, 10); /* nothing lost between cycles */
    for (int i = 0; i < 10; i++) {
        assert_int_equal(g.ev[i].a0, i);
    }
}

static void test_null_safety(void **state)
{
    (void)state;
    nav_cmd_t c;
    nav_cmd_init(&c);
    unsigned h = 9;
    assert_int_equal(nav_cmd_feed(&c, NULL, 5, 4, &k_ops, &h), 0);
    assert_int_equal(h, 0);
    nav_cmd_handle(&c, NULL, TC_OK, &k_ops);
    assert_int_equal(g.ev[0].code, TLM_EVT_CMD_REJECTED);
    assert_int_equal(g.ev[0].a1, TC_E_NULL);
    const nav_cmd_ops_t bare = {NULL, k_no_actions, sizeof k_no_actions / sizeof k_no_actions[0], f_event, NULL};
    tc_cmd_t cmd;
    memset(&cmd, 0, sizeof cmd);
    cmd.opcode = TC_OP_SET_MODE;
    cmd.u.mode = TLM_MODE_ACQUIRE;
    cmd.have_seq = cmd.have_opcode = true;
    nav_cmd_handle(&c, &cmd, TC_OK, &bare); /* no action: refused, not a crash */
    assert_int_equal(g.ev[1].a1, TC_E_STATE);
}

static void test_opcode_outside_table(void **state)
{
    (void)state;
    nav_cmd_t c;
    nav_cmd_init(&c);
    tc_cmd_t cmd;
    memset(&cmd, 0, sizeof cmd);
    cmd.have_seq = cmd.have_opcode = true;
    cmd.seq = 5;
    cmd.opcode = (uint8_t)(sizeof k_table / sizeof k_table[0]); /* one past the table */
    nav_cmd_handle(&c, &cmd, TC_OK, &k_ops);
    cmd.opcode = 0; /* no opcode 0 */
    nav_cmd_handle(&c, &cmd, TC_OK, &k_ops);
    assert_int_equal(g.n_ev, 2);
    assert_int_equal(g.ev[0].code, TLM_EVT_CMD_REJECTED);
    assert_int_equal(g.ev[0].a1, TC_E_OPCODE);
    assert_int_equal(g.ev[1].a1, TC_E_OPCODE);
    assert_int_equal(c.n_rejected, 2);
    assert_false(c.have_last);
}

/* The program's own table (nav_cmds.c): an action for every opcode the
 * dictionary has, and CAMERA_DISABLE/ENABLE acting on the program's state. */
static nav_app_t g_app;

static void test_program_table(void **state)
{
    (void)state;
    memset(&g_app, 0, sizeof g_app);
    nav_tlm_init(&g_app.tlm);
    nav_cams_init(&g_app.cams, MFNS_SYNC_WINDOW_US_DEFAULT);
    const nav_cmd_ops_t ops = nav_cmds_ops(&g_app);
    assert_ptr_equal(ops.ctx, &g_app);
    assert_int_equal(ops.table_len, (size_t)TC_OP_MAX + 1u);
    for (unsigned op = 1; op <= TC_OP_MAX; op++) {
        assert_non_null(ops.table[op]);
    }
    tc_cmd_t cmd;
    memset(&cmd, 0, sizeof cmd);
    cmd.opcode = TC_OP_CAMERA_DISABLE;
    cmd.u.camera = 1;
    int32_t arg1 = -1;
    assert_int_equal(ops.table[TC_OP_CAMERA_DISABLE](ops.ctx, &cmd, &arg1), TC_OK);
    assert_false(g_app.cams.cam[1].enabled);
    assert_int_equal(arg1, 5);
    cmd.opcode = TC_OP_CAMERA_ENABLE;
    assert_int_equal(ops.table[TC_OP_CAMERA_ENABLE](ops.ctx, &cmd, &arg1), TC_OK);
    assert_int_equal(arg1, 7);
    cmd.u.camera = MFNS_NUM_CAMERAS;
    assert_int_equal(ops.table[TC_OP_CAMERA_ENABLE](ops.ctx, &cmd, &arg1), TC_E_ARG);
    g_app.cams.errors = 9;
    assert_int_equal(ops.table[TC_OP_RESET_COUNTERS](ops.ctx, &cmd, &arg1), TC_OK);
    assert_int_equal(g_app.cams.errors, 0);
    assert_int_equal(ops.table[TC_OP_NOOP](ops.ctx, &cmd, &arg1), TC_OK);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_every_opcode_accepted, setup),
        cmocka_unit_test_setup(test_sequence_guard, setup),
        cmocka_unit_test_setup(test_action_refusal_keeps_the_reference, setup),
        cmocka_unit_test_setup(test_frame_faults_rejected, setup),
        cmocka_unit_test_setup(test_bound_per_cycle, setup),
        cmocka_unit_test_setup(test_null_safety, setup),
        cmocka_unit_test_setup(test_opcode_outside_table, setup),
        cmocka_unit_test_setup(test_program_table, setup),
    };
    return cmocka_run_group_tests_name("nav_cmd", tests, NULL, NULL);
}
