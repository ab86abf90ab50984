/* libFuzzer target for the telecommand receiver: the TC deframer and
 * decoder (firmware/tlm/tc_packets.h) and the flight command handler behind
 * them (firmware/app/nav_cmd_dispatch.h), with actions that check what they get.
 *
 * The first input byte picks a mode:
 *   even  the rest is a raw byte stream fed to the handler NAV_CMD_MAX_PER_CYCLE
 *         commands at a time, as the flight program does per cycle (and, split
 *         at 0x00, to the one-shot packet decoder);
 *   odd   the rest builds commands (opcode, sequence count, argument bytes)
 *         that are encoded into valid frames, then corrupted at input-chosen
 *         positions, so the fuzzer reaches the handler past the CRC.
 * Invariants (abort on violation, which libFuzzer reports):
 *   - every frame that ends gives exactly one event (accepted or rejected);
 *   - an action only ever sees valid arguments (mode 1/2/4, camera < 3,
 *     a NUL-terminated printable path), and only for an accepted sequence;
 *   - a decoded command re-encodes to the same packet bytes;
 *   - an uncorrupted stream of commands is handled completely: all valid
 *     commands with newer counts accepted.
 * Build: clang -fsanitize=fuzzer,address,undefined (mk/uplink.mk).
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "firmware/tlm/cobs.h"
#include "firmware/tlm/crc16.h"
#include "firmware/app/nav_cmd_dispatch.h"
#include "firmware/tlm/tc_packets.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check(int cond)
{
    if (!cond) {
        abort();
    }
}

static struct {
    unsigned events, accepted, rejected, actions;
} g;

static tc_status_t a_mode(void *c, uint8_t m, int32_t *a1)
{
    (void)c;
    (void)a1;
    check(m == TLM_MODE_ACQUIRE || m == TLM_MODE_TRACK || m == TLM_MODE_STANDBY);
    g.actions++;
    return (m == TLM_MODE_TRACK) ? TC_E_STATE : TC_OK; /* exercise a refusing action */
}
static tc_status_t a_pose(void *c, const tc_pose_hint_t *h, int32_t *a1)
{
    (void)c;
    (void)a1;
    for (int i = 0; i < 3; i++) {
        check(h->pos_um[i] >= -TC_POS_UM_MAX && h->pos_um[i] <= TC_POS_UM_MAX);
    }
    check(h->att_udeg[1] >= -TC_PITCH_UDEG_MAX && h->att_udeg[1] <= TC_PITCH_UDEG_MAX);
    g.actions++;
    return TC_OK;
}
static tc_status_t a_cam(void *c, uint8_t k, bool en, int32_t *a1)
{
    (void)c;
    (void)en;
    (void)a1;
    check(k < 3u);
    g.actions++;
    return TC_OK;
}
static tc_status_t a_table(void *c, const char *p, int32_t *a1)
{
    (void)c;
    (void)a1;
    const size_t n = strnlen(p, TC_PATH_MAX);
    check(n > 0u && n < TC_PATH_MAX);
    for (size_t i = 0; i < n; i++) {
        check(p[i] >= 0x20 && p[i] <= 0x7E);
    }
    g.actions++;
    return (p[0] == 'x') ? TC_E_TABLE : TC_OK;
}
static void a_reset(void *c)
{
    (void)c;
    g.actions++;
}
static void a_event(void *c, tlm_event_code_t code, tlm_severity_t sev, uint8_t subject, int32_t a0, int32_t a1)
{
    (void)c;
    (void)sev;
    (void)subject;
    (void)a0;
    check(code == TLM_EVT_CMD_ACCEPTED || code == TLM_EVT_CMD_REJECTED);
    if (code == TLM_EVT_CMD_ACCEPTED) {
        g.accepted++;
    } else {
        check(a1 > 0 && a1 <= TC_STATUS_MAX);
        g.rejected++;
    }
    g.events++;
}

/* The dispatch's table (indexed by opcode) over the checking actions above. */
static tc_status_t t_noop(void *c, const tc_cmd_t *cmd, int32_t *a1)
{
    (void)c;
    (void)cmd;
    (void)a1;
    return TC_OK;
}
static tc_status_t t_mode(void *c, const tc_cmd_t *cmd, int32_t *a1)
{
    return a_mode(c, cmd->u.mode, a1);
}
static tc_status_t t_pose(void *c, const tc_cmd_t *cmd, int32_t *a1)
{
    return a_pose(c, &cmd->u.pose, a1);
}
static tc_status_t t_cam(void *c, const tc_cmd_t *cmd, int32_t *a1)
{
    return a_cam(c, cmd->u.camera, cmd->opcode == TC_OP_CAMERA_ENABLE, a1);
}
static tc_status_t t_table(void *c, const tc_cmd_t *cmd, int32_t *a1)
{
    return a_table(c, cmd->u.path, a1);
}
static tc_status_t t_reset(void *c, const tc_cmd_t *cmd, int32_t *a1)
{
    (void)cmd;
    (void)a1;
    a_reset(c);
    return TC_OK;
}
static const nav_cmd_fn_t k_table[] = {
    [TC_OP_NOOP] = t_noop,          [TC_OP_RESET_COUNTERS] = t_reset, [TC_OP_SET_MODE] = t_mode,
    [TC_OP_SET_POSE_HINT] = t_pose, [TC_OP_CAMERA_ENABLE] = t_cam,    [TC_OP_CAMERA_DISABLE] = t_cam,
    [TC_OP_TABLE_LOAD] = t_table,
    /* the upload's actions (nav_cmds_upload.h) are the receiver's, fuzzed by fuzz_nav_upload.c:
     * here the codec and the dispatch */
    [TC_OP_UPLOAD_START] = t_noop,  [TC_OP_UPLOAD_DATA] = t_noop,     [TC_OP_UPLOAD_END] = t_noop,
    [TC_OP_UPLOAD_ABORT] = t_noop,
};
_Static_assert(sizeof k_table / sizeof k_table[0] == (size_t)TC_OP_MAX + 1u, "an entry for every opcode");
static const nav_cmd_ops_t k_ops = {NULL, k_table, sizeof k_table / sizeof k_table[0], a_event, NULL};

static void check_oneshot(const uint8_t *pkt, size_t n)
{
    tc_cmd_t c;
    if (tc_packet_decode(pkt, n, &c) != TC_OK) {
        return;
    }
    uint8_t again[TC_MAX_PACKET];
    size_t m = 0;
    check(tc_packet_encode(&c, c.seq, again, sizeof again, &m) == TC_OK);
    check(m == n && memcmp(again, pkt, n) == 0);
}

/* Feed a stream as the flight program does; returns frames completed. */
static uint32_t run_stream(nav_cmd_t *h, const uint8_t *b, size_t n)
{
    size_t off = 0;
    for (size_t guard = 0; guard <= n && off < n; guard++) {
        unsigned done = 0;
        const size_t used = nav_cmd_feed(h, b + off, n - off, NAV_CMD_MAX_PER_CYCLE, &k_ops, &done);
        check(done <= NAV_CMD_MAX_PER_CYCLE);
        check(used > 0u); /* progress every call */
        off += used;
    }
    check(off == n);
    return h->rx.frames;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static nav_cmd_t h;
    memset(&g, 0, sizeof g);
    nav_cmd_init(&h);
    if (size == 0) {
        return 0;
    }
    const uint8_t mode = data[0];
    data++;
    size--;
    if ((mode & 1u) == 0u) {
        const uint32_t frames = run_stream(&h, data, size);
        check(g.events == frames);
        check(g.accepted >= h.n_accepted); /* RESET_COUNTERS may have zeroed it */
        check(g.accepted + g.rejected == g.events);
        /* one-shot decoder on each 0x00-separated block */
        size_t start = 0;
        for (size_t i = 0; i <= size; i++) {
            if (i == size || data[i] == 0u) {
                uint8_t pkt[TC_MAX_FRAME];
                size_t pn = 0;
                if (i > start && tlm_cobs_decode(data + start, i - start, pkt, sizeof pkt, &pn) == TLM_OK && pn >= 2u) {
                    check_oneshot(pkt, pn - 2u);
                }
                start = i + 1u;
            }
        }
        return 0;
    }
    /* odd: commands from the input, 4 bytes of header each + argument bytes */
    static uint8_t stream[64 * TC_MAX_WIRE];
    size_t sn = 0, i = 0;
    unsigned n_valid = 0, n_newer = 0, n_corrupt = 0;
    uint16_t last = 0;
    bool have_last = false;
    while (i + 4u <= size && sn + TC_MAX_WIRE <= sizeof stream) {
        tc_cmd_t c;
        memset(&c, 0, sizeof c);
        c.opcode = (uint8_t)(1u + data[i] % TC_OP_MAX);
        const uint16_t seq = (uint16_t)(((unsigned)data[i + 1] << 8 | data[i + 2]) & TLM_CCSDS_SEQ_MASK);
        const uint8_t corrupt = data[i + 3];
        i += 4u;
        const size_t alen = (size_t)tc_arg_len(c.opcode);
        uint8_t args[TC_MAX_ARGS];
        memset(args, 0, sizeof args);
        for (size_t k = 0; k < alen && i < size; k++) {
            args[k] = data[i++];
        }
        switch (c.opcode) {
        case TC_OP_SET_MODE: c.u.mode = (uint8_t)(args[0] % 5u); break;
        case TC_OP_CAMERA_ENABLE:
        case TC_OP_CAMERA_DISABLE: c.u.camera = (uint8_t)(args[0] % 4u); break;
        case TC_OP_SET_POSE_HINT:
            for (int k = 0; k < 3; k++) {
                memcpy(&c.u.pose.pos_um[k], args + 4 * k, 4);
                memcpy(&c.u.pose.att_udeg[k], args + 12 + 4 * k, 4);
                c.u.pose.pos_um[k] %= TC_POS_UM_MAX;
                c.u.pose.att_udeg[k] %= (k == 1 ? TC_PITCH_UDEG_MAX : TC_ROLL_YAW_UDEG_MAX);
            }
            break;
        case TC_OP_TABLE_LOAD:
            for (size_t k = 0; k + 1u < TC_PATH_MAX && args[k] != 0u; k++) {
                c.u.path[k] = (char)(0x20u + args[k] % 95u);
            }
            break;
        case TC_OP_UPLOAD_START:
            memcpy(&c.u.upload_start.size, args, 4);
            memcpy(&c.u.upload_start.crc32, args + 4, 4);
            for (size_t k = 0; k + 1u < TC_UPLOAD_NAME_MAX && args[8u + k] != 0u; k++) {
                c.u.upload_start.name[k] = (char)(0x20u + args[8u + k] % 95u);
            }
            break;
        case TC_OP_UPLOAD_DATA:
            memcpy(&c.u.upload_data.offset, args, 4);
            c.u.upload_data.len = (uint8_t)(args[4] % (TC_UPLOAD_LEN_MAX + 1u)); /* 0: the encoder refuses */
            memcpy(c.u.upload_data.bytes, args + 5, TC_UPLOAD_SEG_LEN);
            break;
        default: break;
        }
        size_t fn = 0;
        if (tc_frame_encode(&c, seq, stream + sn, TC_MAX_WIRE, &fn) != TC_OK) {
            continue; /* refused by the encoder (e.g. mode 0, camera 3, empty path) */
        }
        if (corrupt & 0x80u) {
            stream[sn + (corrupt & 0x7Fu) % fn] ^= (uint8_t)(1u + (corrupt >> 3));
            n_corrupt++;
        } else {
            n_valid++;
            const bool newer = !have_last || (((uint32_t)(seq - last) & TLM_CCSDS_SEQ_MASK) - 1u) < NAV_CMD_SEQ_WINDOW;
            const bool refused = (c.opcode == TC_OP_SET_MODE && c.u.mode == TLM_MODE_TRACK) ||
                                 (c.opcode == TC_OP_TABLE_LOAD && c.u.path[0] == 'x');
            if (newer && !refused) {
                n_newer++;
                last = seq;
                have_last = true;
            }
        }
        sn += fn;
    }
    const uint32_t frames = run_stream(&h, stream, sn);
    check(g.events == frames);
    /* a clean stream is handled exactly (a corruption may merge or split frames) */
    if (n_corrupt == 0u) {
        check(frames == n_valid);
        check(g.accepted == n_newer);
        check(g.rejected == n_valid - n_newer);
    }
    return 0;
}
