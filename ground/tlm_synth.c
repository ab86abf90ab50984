/* tlm_synth.c -- the synthetic stream of tlm_synth.h. */
#include "ground/tlm_synth.h"

#include <string.h>

static void stamp(uint32_t i, tlm_packet_t *p, tlm_type_t type)
{
    memset(p, 0, sizeof *p);
    p->type = type;
    p->time = tlm_time_from_us((uint64_t)i * GROUND_GEN_CYCLE_US);
}

void ground_gen_nav(uint32_t i, tlm_packet_t *p)
{
    stamp(i, p, TLM_TYPE_NAV);
    tlm_nav_t *n = &p->u.nav;
    n->cycle = i;
    const int no_fix = (i % 10u) == 9u;
    n->status = no_fix ? TLM_NAV_NO_FIX : TLM_NAV_FIX;
    n->reason = no_fix ? 3u : 0u;
    n->mode = i == 0u ? TLM_MODE_ACQUIRE : TLM_MODE_TRACK;
    n->beacons_used = (uint8_t)(3u + i % 4u);
    n->cams_used = (uint8_t)(1u + i % 7u);
    n->iterations = (uint8_t)(2u + i % 5u);
    n->residual_rms_mpx = (uint16_t)(100u + (i * 37u) % 900u);
    n->pos_um[0] = (int32_t)((i * 7919u) % 20001u) - 10000;
    n->pos_um[1] = 15000 - (int32_t)((i * 104729u) % 30001u);
    n->pos_um[2] = 500000 + (int32_t)(i % 1000u);
    n->att_udeg[0] = (int32_t)((i * 37u) % 301u) * 1000 - 150000;
    n->att_udeg[1] = 150000 - (int32_t)((i * 53u) % 301u) * 1000;
    n->att_udeg[2] = (int32_t)((i * 1000000u) % 360000000u) - 180000000;
    for (int k = 0; k < 3; k++) {
        n->sigma_pos_um[k] = 1600u + (i + (uint32_t)k * 7u) % 100u;
        n->sigma_att_udeg[k] = 150000u + (i + (uint32_t)k * 11u) % 1000u;
    }
    if (no_fix) {
        return; /* as the flight program: no pose, no quaternion, no covariance */
    }
    /* a unit quaternion about a slowly turning axis (w >= 0), and a
     * covariance with every sign and a wide range of magnitudes */
    const float a = 0.001f * (float)(i % 1000u);
    n->q_q30[0] = tlm_scale_i32(0.8f, TLM_Q30_SCALE, NULL);
    n->q_q30[1] = tlm_scale_i32(0.6f * (1.0f - a), TLM_Q30_SCALE, NULL);
    n->q_q30[2] = tlm_scale_i32(-0.6f * a, TLM_Q30_SCALE, NULL);
    n->q_q30[3] = tlm_scale_i32(0.0f, TLM_Q30_SCALE, NULL);
    for (uint32_t k = 0; k < TLM_NAV_COV_N; k++) {
        const float mag = (k == 0u || k == 6u || k == 11u) ? 2.5e-3f : 1.0e-7f * (float)(k + 1u);
        n->cov[k] = ((i + k) % 3u == 0u ? -mag : mag) * (1.0f + 0.01f * (float)(i % 97u));
    }
}

void ground_gen_camera(uint32_t i, uint8_t camera, tlm_packet_t *p)
{
    stamp(i, p, TLM_TYPE_CAMERA);
    tlm_camera_t *c = &p->u.camera;
    c->cycle = i;
    c->camera = camera;
    c->state = TLM_CAM_OK;
    c->blobs = (uint8_t)((i + camera) % 6u);
    c->beacons_identified = (uint8_t)((i + camera) % 3u);
    c->exposure_us = 5000u + 100u * camera;
    c->gain_cdb = (int16_t)(600 + 50 * (int)camera);
    c->frame_seq = i;
    c->frames_dropped = i / 500u;
}

void ground_gen_hk(uint32_t i, tlm_packet_t *p)
{
    stamp(i, p, TLM_TYPE_HK);
    tlm_hk_t *h = &p->u.hk;
    h->cycle = i;
    h->mode = TLM_MODE_TRACK;
    h->cpu_load_permille = (uint16_t)(300u + i % 200u);
    h->cycle_p50_us = 21000u;
    h->cycle_p95_us = 29000u;
    h->cycle_p99_us = 33000u;
    h->cycle_max_us = 41000u + i % 1000u;
    h->n_cycles = i + 1u;
    h->n_fix = i + 1u - (i + 1u) / 10u;
    h->n_no_fix = (i + 1u) / 10u;
    h->n_tlm_dropped = 0;
    h->n_cam_errors = 0;
    h->table_crc32 = 0x1234ABCDu;
    h->n_acquire = 1u + i / 50u;
    h->acq_units_max = 1200u + i % 100u;
    h->acq_units_last = 900u;
    h->acq_band_last = 4;
    h->acq_best_last = 7;
    h->n_degraded = (i + 1u) / 7u;
    h->n_cmd_accepted = i / 100u;
    h->n_cmd_rejected = i / 300u;
    h->cmd_seq_last = (uint16_t)(i / 100u);
    h->cams_enabled = 0x7u;
}

size_t ground_gen_cycle(uint32_t i, tlm_packet_t out[GROUND_GEN_MAX_PER_CYCLE])
{
    size_t n = 0;
    if (i <= 1u) {
        tlm_packet_t *e = &out[n++];
        stamp(i, e, TLM_TYPE_EVENT);
        e->u.event.cycle = i;
        e->u.event.severity = TLM_SEV_INFO;
        if (i == 0u) {
            e->u.event.code = TLM_EVT_BOOT;
            e->u.event.arg0 = 1;
        } else {
            e->u.event.code = TLM_EVT_TABLE_LOADED;
            e->u.event.arg0 = 1;
            e->u.event.arg1 = 0x1234ABCD;
        }
    }
    ground_gen_nav(i, &out[n++]);
    for (uint8_t c = 0; c < TLM_NUM_CAMERAS; c++) {
        ground_gen_camera(i, c, &out[n++]);
    }
    if (i % 19u == 18u) {
        ground_gen_hk(i, &out[n++]);
    }
    return n;
}
