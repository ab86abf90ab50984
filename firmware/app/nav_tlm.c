/* nav_tlm.c -- see nav_tlm.h. */
#include "nav_tlm.h"

#include <math.h>
#include <string.h>

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
    if (s->status == MFNS_POSE_NO_FIX) {
        n->status = TLM_NAV_NO_FIX;
        return; /* pose fields stay zero */
    }
    bool ok = true;
    n->status = (uint8_t)(s->status == MFNS_POSE_OK ? TLM_NAV_FIX : TLM_NAV_DEGRADED);
    n->beacons_used = (uint8_t)(s->beacons_used > 255 ? 255 : s->beacons_used);
    n->residual_rms_mpx = tlm_scale_u16(s->residual_rms_px, 1000.0f, &ok);
    const float pos[3] = {s->r_wb_w.x, s->r_wb_w.y, s->r_wb_w.z};
    const float att[3] = {s->euler_deg.roll, s->euler_deg.pitch, s->euler_deg.yaw};
    for (int i = 0; i < 3; i++) {
        n->pos_um[i] = tlm_scale_i32(pos[i], 1000.0f, &ok);
        n->att_udeg[i] = tlm_scale_i32(att[i], 1e6f, &ok);
        n->sigma_pos_um[i] = tlm_scale_u32(s->sigma_pos_mm[i], 1000.0f, &ok);
        n->sigma_att_udeg[i] = tlm_scale_u32(s->sigma_euler_deg[i], 1e6f, &ok);
    }
    for (int i = 0; i < 4; i++) {
        n->q_q30[i] = tlm_scale_i32(s->q_b_w[i], TLM_Q30_SCALE, &ok);
    }
    /* cov_ros is in mm and rad; the interface units are mm and degrees
     * (docs/conventions.md): scale each index that is an angle once. */
    const float rad2deg = 57.29577951308232f;
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
