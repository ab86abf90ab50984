/* nav_tlm.c -- see nav_tlm.h. */
#define _DEFAULT_SOURCE /* usleep under -std=c11 */

#include "firmware/app/nav_tlm.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "math/units.h"
#include "firmware/linux/txq_drain.h"

#define FLUSH_TRIES 200 /* x 10 ms: telemetry drain at exit */
#define FLUSH_WAIT_US 10000u
#define EVT_CENTI_PER_MM 100.0f /* WORKSPACE_LEFT carries mm as counts of 0.01 mm */

void nav_tlm_init(nav_tlm_t *t)
{
    memset(t, 0, sizeof *t);
    tlm_encoder_init(&t->enc);
    tlm_txq_init(&t->q);
}

int nav_tlm_send(nav_tlm_t *t, tlm_packet_t *p)
{
    uint8_t wire[TLM_MAX_WIRE];
    size_t n = 0;
    int rc = tlm_frame_encode(&t->enc, p, wire, sizeof wire, &n);
    if (rc == TLM_OK) {
        rc = tlm_txq_push(&t->q, wire, n); /* drop-oldest: a full queue is counted there */
    }
    if (rc != TLM_OK) {
        t->encode_errors++;
    }
    return rc;
}

uint8_t nav_tlm_mode(mfns_nav_mode_t m)
{
    return (uint8_t)(m == MFNS_NAV_MODE_TRACK ? TLM_MODE_TRACK : TLM_MODE_ACQUIRE);
}

void nav_tlm_nav_packet(const mfns_nav_output_t *o, uint32_t cycle, uint64_t t_us, tlm_packet_t *p)
{
    memset(p, 0, sizeof *p);
    p->type = TLM_TYPE_NAV;
    p->time = tlm_time_from_us(t_us);
    tlm_nav_t *n = &p->u.nav;
    const mfns_pose_solution_t *s = &o->sol;
    n->cycle = cycle;
    n->mode = nav_tlm_mode(o->mode);
    n->reason = (uint8_t)s->reason;
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        if (o->cam[k].identified > 0) {
            n->cams_used = (uint8_t)(n->cams_used | (1u << k));
        }
    }
    n->iterations = (uint8_t)(s->iterations > 255 ? 255 : s->iterations);
    /* protection levels on every packet (a NO_FIX refused for its PL shows
     * it); none (not evaluated, infinite) saturates to the maximum */
    bool pl_ok = true;
    n->pl_pos_um = tlm_scale_u32(o->integrity.pl_pos_mm, TLM_SCALE_MM_FROM_UM_U32, &pl_ok);
    n->pl_pos_um = pl_ok ? n->pl_pos_um : UINT32_MAX;
    pl_ok = true;
    n->pl_att_udeg = tlm_scale_u32(o->integrity.pl_att_deg, TLM_SCALE_DEG_FROM_UDEG_U32, &pl_ok);
    n->pl_att_udeg = pl_ok ? n->pl_att_udeg : UINT32_MAX;
    if (s->status == MFNS_POSE_NO_FIX) {
        n->status = TLM_NAV_NO_FIX;
        return; /* pose fields stay zero */
    }
    bool ok = true;
    n->status = (uint8_t)(s->status == MFNS_POSE_OK ? TLM_NAV_FIX : TLM_NAV_DEGRADED);
    n->beacons_used = (uint8_t)(s->beacons_used > 255 ? 255 : s->beacons_used);
    n->residual_rms_mpx = tlm_scale_u16(s->residual_rms_px, TLM_SCALE_PX_FROM_MPX_U16, &ok);
    const float pos[3] = {s->r_wb_w.x, s->r_wb_w.y, s->r_wb_w.z};
    const float att[3] = {s->euler_deg.roll, s->euler_deg.pitch, s->euler_deg.yaw};
    for (int i = 0; i < 3; i++) {
        n->pos_um[i] = tlm_scale_i32(pos[i], TLM_SCALE_MM_FROM_UM_I32, &ok);
        n->att_udeg[i] = tlm_scale_i32(att[i], TLM_SCALE_DEG_FROM_UDEG_I32, &ok);
        n->sigma_pos_um[i] = tlm_scale_u32(s->sigma_pos_mm[i], TLM_SCALE_MM_FROM_UM_U32, &ok);
        n->sigma_att_udeg[i] = tlm_scale_u32(s->sigma_euler_deg[i], TLM_SCALE_DEG_FROM_UDEG_U32, &ok);
    }
    for (int i = 0; i < 4; i++) {
        n->q_q30[i] = tlm_scale_i32(s->q_b_w[i], TLM_SCALE_Q30_I32, &ok);
    }
    /* cov_ros is in mm and rad; the interface units are mm and degrees
     * (docs/conventions.md): scale each index that is an angle once. */
    const float rad2deg = MFNS_DEG_PER_RAD_F;
    unsigned k = 0;
    for (unsigned r = 0; r < TLM_NAV_COV_DIM; r++) {
        for (unsigned c = r; c < TLM_NAV_COV_DIM; c++) {
            const float v = s->cov_ros[r][c] * (r >= 3u ? rad2deg : 1.0f) * (c >= 3u ? rad2deg : 1.0f);
            ok = ok && isfinite(v);
            n->cov[k++] = v;
        }
    }
    if (!ok) {
        /* a value beyond the wire range (e.g. a position > 2 km) or a
         * covariance that is not finite: never send such a pose as valid */
        memset(n->pos_um, 0, sizeof n->pos_um);
        memset(n->att_udeg, 0, sizeof n->att_udeg);
        memset(n->sigma_pos_um, 0, sizeof n->sigma_pos_um);
        memset(n->sigma_att_udeg, 0, sizeof n->sigma_att_udeg);
        memset(n->q_q30, 0, sizeof n->q_q30);
        memset(n->cov, 0, sizeof n->cov);
        n->status = TLM_NAV_NO_FIX;
    }
}

/* An event argument from a scaled float: INT32_MAX when it does not fit the
 * wire's i32 (beyond +-2e9) or is not a number. */
static int32_t event_arg(float v)
{
    return fabsf(v) < 2.0e9f ? (int32_t)v : INT32_MAX;
}

void nav_tlm_integrity_events(nav_tlm_t *t, const mfns_nav_output_t *o, const mfns_beacon_map_t *map,
                              uint16_t hold_cycles, uint32_t cycle, uint64_t t_us)
{
    const mfns_integrity_result_t *r = &o->integrity;
    const float ns = r->detect_norm_sep * 100.0f;
    const int32_t sep = event_arg(ns);
    if (r->new_beacon_exclusion && r->excluded_beacon >= 0 && r->excluded_beacon < (int)map->count) {
        const uint16_t id = map->beacon[r->excluded_beacon].id;
        (void)nav_tlm_event(t, cycle, t_us, TLM_EVT_BEACON_EXCLUDED, TLM_SEV_WARNING, (uint8_t)(id > 255u ? 255u : id),
                            sep, id);
    }
    if (r->new_camera_exclusion && r->excluded_camera >= 0) {
        (void)nav_tlm_event(t, cycle, t_us, TLM_EVT_CAMERA_EXCLUDED, TLM_SEV_WARNING, (uint8_t)r->excluded_camera,
                            sep, hold_cycles);
    }
    if (r->readmitted_beacon >= 0 && r->readmitted_beacon < (int)map->count) {
        const uint16_t id = map->beacon[r->readmitted_beacon].id;
        (void)nav_tlm_event(t, cycle, t_us, TLM_EVT_BEACON_READMITTED, TLM_SEV_INFO, (uint8_t)(id > 255u ? 255u : id),
                            0, id);
    }
    if (o->lag_new_camera >= 0 && o->lag_new_camera < MFNS_NUM_CAMERAS) {
        const unsigned c = (unsigned)(uint8_t)o->lag_new_camera; /* checked non-negative above */
        const float lag = o->lag.lag_cycles[c] * 1000.0f, z = o->lag.z[c] * 100.0f;
        (void)nav_tlm_event(t, cycle, t_us, TLM_EVT_CAMERA_LAG, TLM_SEV_WARNING, (uint8_t)c,
                            event_arg(lag), event_arg(z));
    }
    const mfns_spot_report_t *rs = &o->spots;
    if (rs->camera >= 0 && rs->camera < MFNS_NUM_CAMERAS) {
        (void)nav_tlm_event(t, cycle, t_us, TLM_EVT_CAMERA_RESPONSE_STEP, TLM_SEV_WARNING, (uint8_t)rs->camera,
                            event_arg(rs->ratio * 1000.0f), rs->matched);
    }
    if (rs->jump_new && rs->jump_camera >= 0 && rs->jump_camera < MFNS_NUM_CAMERAS) {
        (void)nav_tlm_event(t, cycle, t_us, TLM_EVT_CAMERA_SPOTS_JUMPED, TLM_SEV_WARNING, (uint8_t)rs->jump_camera,
                            event_arg(rs->jump_px * 100.0f), event_arg(rs->others_px * 100.0f));
    }
    const mfns_beacon_watch_report_t *bw = &o->beacons;
    if (bw->missing >= 0 && bw->missing < (int)map->count) {
        const uint16_t id = map->beacon[bw->missing].id;
        (void)nav_tlm_event(t, cycle, t_us, TLM_EVT_BEACON_MISSING, TLM_SEV_WARNING, (uint8_t)(id > 255u ? 255u : id),
                            bw->missing_fixes, id);
    }
    if (bw->rejected >= 0 && bw->rejected < (int)map->count) {
        const uint16_t id = map->beacon[bw->rejected].id;
        (void)nav_tlm_event(t, cycle, t_us, TLM_EVT_BEACON_REJECTED, TLM_SEV_WARNING, (uint8_t)(id > 255u ? 255u : id),
                            bw->rejected_count, id);
    }
    const mfns_camera_watch_report_t *cw = &o->cameras;
    if (cw->inconsistent >= 0 && cw->inconsistent < MFNS_NUM_CAMERAS) {
        (void)nav_tlm_event(t, cycle, t_us, TLM_EVT_CAMERA_INCONSISTENT, TLM_SEV_WARNING, (uint8_t)cw->inconsistent,
                            cw->evidence, cw->fixes);
    }
    if (cw->disagrees >= 0 && cw->disagrees < MFNS_NUM_CAMERAS) {
        (void)nav_tlm_event(t, cycle, t_us, TLM_EVT_CAMERAS_DISAGREE, TLM_SEV_WARNING, (uint8_t)cw->disagrees,
                            cw->pair_evidence, cw->disagrees_with);
    }
    if (o->ws.left) {
        const float beyond = o->ws.beyond_mm * EVT_CENTI_PER_MM, tol = o->ws.tol_mm * EVT_CENTI_PER_MM;
        (void)nav_tlm_event(t, cycle, t_us, TLM_EVT_WORKSPACE_LEFT, TLM_SEV_WARNING, o->ws.axes,
                            event_arg(beyond), event_arg(tol));
    }
    if (o->ws.reentered) {
        (void)nav_tlm_event(t, cycle, t_us, TLM_EVT_WORKSPACE_REENTERED, TLM_SEV_INFO, 0,
                            o->ws.cycles_outside < (uint32_t)INT32_MAX ? (int32_t)o->ws.cycles_outside : INT32_MAX, 0);
    }
    if (r->readmitted_camera >= 0) {
        (void)nav_tlm_event(t, cycle, t_us, TLM_EVT_CAMERA_READMITTED, TLM_SEV_INFO, (uint8_t)r->readmitted_camera, 0,
                            0);
    }
    if (o->filt.motion_exceeded) {
        /* the robot left the motion bound: the filter restarted (nav_filter_cycle.h) */
        (void)nav_tlm_event(t, cycle, t_us, TLM_EVT_MOTION_EXCEEDED, TLM_SEV_WARNING, 0,
                            event_arg(o->filt.motion_sep * 100.0f), o->filt.motion_by_snapshot ? 1 : 0);
    }
}

int nav_tlm_event(nav_tlm_t *t, uint32_t cycle, uint64_t t_us, tlm_event_code_t code, tlm_severity_t sev,
                  uint8_t subject, int32_t arg0, int32_t arg1)
{
    tlm_packet_t p;
    memset(&p, 0, sizeof p);
    p.type = TLM_TYPE_EVENT;
    p.time = tlm_time_from_us(t_us);
    p.u.event.cycle = cycle;
    p.u.event.code = (uint16_t)code;
    p.u.event.severity = (uint8_t)sev;
    p.u.event.subject = subject;
    p.u.event.arg0 = arg0;
    p.u.event.arg1 = arg1;
    return nav_tlm_send(t, &p);
}

/* Opens the telemetry output. A port or FIFO that is absent (no reader yet,
 * adapter not plugged) is not fatal: the transport re-opens it at its retry
 * cadence, exactly as after a link lost later; frames wait in the queue. */
int nav_tlm_open(nav_tlm_t *t, const nav_opts_t *o)
{
    t->kind = o->tlm_kind;
    t->target = o->tlm_target;
    int rc = MFNS_UART_OK;
    struct stat st;
    if (o->tc_kind == NAV_TC_LINK && o->tlm_kind == NAV_TLM_PATH && stat(o->tlm_target, &st) == 0 &&
        S_ISFIFO(st.st_mode)) {
        /* a FIFO carries one direction: read-write would read our own telemetry back */
        fprintf(stderr, "mfns-nav: --uplink needs a tty; for a FIFO give the commands their own: --tc-tty PATH\n");
        return -1;
    }
    switch (o->tlm_kind) {
    case NAV_TLM_NONE:
        return 0;
    case NAV_TLM_SERIAL:
        rc = mfns_uart_open_serial(&t->uart, o->tlm_target, o->baud,
                                   o->tc_kind == NAV_TC_LINK ? MFNS_UART_RW : MFNS_UART_WRITE);
        break;
    case NAV_TLM_PATH:
        rc = mfns_uart_open_path(&t->uart, o->tlm_target, o->baud,
                                 o->tc_kind == NAV_TC_LINK ? MFNS_UART_RW : MFNS_UART_WRITE);
        break;
    case NAV_TLM_FILE: {
        const int fd = open(o->tlm_target, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
        if (fd < 0) {
            fprintf(stderr, "mfns-nav: cannot create telemetry file %s: %s\n", o->tlm_target, strerror(errno));
            return -1;
        }
        rc = mfns_uart_attach_fd(&t->uart, fd, true, MFNS_UART_WRITE);
        break;
    }
    }
    if (rc == MFNS_UART_ERR_OPEN && o->tlm_kind != NAV_TLM_FILE) {
        fprintf(stderr, "mfns-nav: telemetry %s not available yet (%s): retrying every %u..%u ms\n", o->tlm_target,
                strerror(t->uart.last_errno), t->uart.retry_min_ms, t->uart.retry_max_ms);
        return 0;
    }
    if (rc != MFNS_UART_OK) {
        fprintf(stderr, "mfns-nav: telemetry %s: %s\n", o->tlm_target, mfns_uart_strerror(rc));
        return -1;
    }
    return 0;
}

void nav_tlm_drain(nav_tlm_t *t, uint32_t cycle, uint64_t now_ms)
{
    if (t->kind == NAV_TLM_NONE) {
        /* no link: discard, as a disconnected UART would */
        const uint8_t *d = NULL;
        for (int i = 0; i < (int)TLM_TXQ_FRAMES && tlm_txq_peek(&t->q, &d) > 0; i++) {
            tlm_txq_consume(&t->q, tlm_txq_peek(&t->q, &d));
        }
        return;
    }
    /* link loss: frames wait, oldest dropped; a write error is counted and reported */
    const int rc = txq_drain(&t->q, &t->uart, now_ms);
    if (rc == MFNS_UART_ERR_IO) {
        t->write_errors++;
        if (!t->in_error) { /* reaches the ground if the link comes back */
            t->in_error = true;
            (void)nav_tlm_event(t, cycle, 0, TLM_EVT_TLM_WRITE_ERROR, TLM_SEV_ERROR, 0, t->uart.last_errno,
                                (int32_t)t->write_errors); /* failures counted in encode_errors */
        }
        if (!t->write_error_printed) {
            t->write_error_printed = true;
            fprintf(stderr, "mfns-nav: telemetry write to %s failed: %s (counting; frames wait in the queue)\n",
                    t->target, strerror(t->uart.last_errno));
        }
    } else if (rc == MFNS_UART_OK) {
        t->in_error = false;
    }
}

void nav_tlm_flush_and_close(nav_tlm_t *t, uint32_t cycle)
{
    if (t->kind == NAV_TLM_NONE) {
        return;
    }
    for (int i = 0; i < FLUSH_TRIES && tlm_txq_frames(&t->q) > 0; i++) {
        nav_tlm_drain(t, cycle, mfns_uart_now_ms());
        if (tlm_txq_frames(&t->q) > 0) {
            (void)usleep(FLUSH_WAIT_US); /* a wait cut short by a signal only shortens it: tries stay bounded */
        }
    }
    mfns_uart_close(&t->uart);
}
