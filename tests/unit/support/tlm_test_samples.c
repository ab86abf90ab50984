/* tlm_test_samples.c -- see tlm_test_samples.h. */
#include "tests/unit/support/tlm_test_samples.h"

#include <string.h>

#include "tests/unit/support/testutil.h"

void tlm_test_sample(tlm_packet_t *p, tlm_type_t type, uint32_t i)
{
    memset(p, 0, sizeof *p);
    p->type = type;
    p->time.coarse_s = 1000u + i / 18u;
    p->time.fine = (uint16_t)(i * 3541u);
    switch (type) {
    case TLM_TYPE_NAV: {
        tlm_nav_t *n = &p->u.nav;
        n->cycle = i;
        n->status = (uint8_t)(i % TLM_NAV_STATUS_COUNT);
        n->reason = (uint8_t)(i % 7u);
        n->mode = (uint8_t)(i % TLM_MODE_COUNT);
        n->beacons_used = (uint8_t)(i % 11u);
        n->cams_used = (uint8_t)(i % 8u);
        n->iterations = (uint8_t)(i % 20u);
        n->residual_rms_mpx = (uint16_t)(i * 37u);
        for (int k = 0; k < 3; k++) {
            n->pos_um[k] = ((int32_t)((i * 1001u) % 1000000000u) - 500000 * (k + 1)) * (k == 1 ? -1 : 1);
            n->att_udeg[k] = (int32_t)((i * 12345u) % 360000000u) - 180000000 + k * 256;
            n->sigma_pos_um[k] = 1600u + i + (uint32_t)k * 0x100u;
            n->sigma_att_udeg[k] = 150000u + (uint32_t)k;
        }
        for (int k = 0; k < 4; k++) {
            n->q_q30[k] = (int32_t)((i * 2654435761u) >> (k + 1)) * (k % 2 ? -1 : 1);
        }
        for (uint32_t k = 0; k < TLM_NAV_COV_N; k++) {
            n->cov[k] = (float)((int32_t)(i * 7u + k * 13u) % 201 - 100) * 1.5e-4f;
        }
        n->pl_pos_um = 15000u + i;
        n->pl_att_udeg = 400000u + i * 3u;
        break;
    }
    case TLM_TYPE_CAMERA: {
        tlm_camera_t *c = &p->u.camera;
        c->cycle = i;
        c->camera = (uint8_t)(i % 3u);
        c->state = (uint8_t)(i % TLM_CAM_STATE_COUNT);
        c->blobs = (uint8_t)(i % 256u);
        c->beacons_identified = (uint8_t)(i % 5u);
        c->exposure_us = 2000u + i;
        c->gain_cdb = (int16_t)((int)(i % 1000u) - 500);
        c->frame_seq = i * 3u;
        c->frames_dropped = i / 50u;
        break;
    }
    case TLM_TYPE_HK: {
        tlm_hk_t *h = &p->u.hk;
        h->cycle = i;
        h->mode = (uint8_t)(i % TLM_MODE_COUNT);
        h->cpu_load_permille = (uint16_t)(i % 1001u);
        h->cycle_p50_us = 20000u + i;
        h->cycle_p95_us = 30000u + i;
        h->cycle_p99_us = 40000u + i;
        h->cycle_max_us = 53000u + i;
        h->n_cycles = i;
        h->n_fix = i / 2u;
        h->n_no_fix = i - i / 2u;
        h->n_tlm_dropped = i / 100u;
        h->n_cam_errors = 0x01000000u + i;
        h->table_crc32 = 0xDEADBEEFu ^ i;
        h->n_acquire = 0x02000000u + i;
        h->acq_units_max = 0x03000000u + i;
        h->acq_units_last = 0x04000000u + i;
        h->acq_band_last = (uint8_t)(1u << (i % 6u));
        h->acq_best_last = (uint8_t)(i % 255u);
        h->n_degraded = 0x05000000u + i;
        h->n_cmd_accepted = 0x06000000u + i;
        h->n_cmd_rejected = 0x07000000u + i;
        h->cmd_seq_last = (uint16_t)(i * 3u);
        h->cams_enabled = (uint8_t)(i % 8u);
        break;
    }
    case TLM_TYPE_FIXOBS: {
        tlm_fixobs_t *f = &p->u.fixobs;
        f->cycle = i;
        f->count = (uint8_t)(1u + i % 12u);
        f->index = (uint8_t)(i % f->count);
        f->camera = (uint8_t)(i % 3u);
        f->beacon_id = (uint16_t)(i * 7u);
        f->used = (uint8_t)(i % 2u);
        f->uv_px[0] = 12.25f + (float)i;
        f->uv_px[1] = 1000.5f - (float)i;
        f->cov_px2[0] = 0.01f;
        f->cov_px2[1] = -0.002f;
        f->cov_px2[2] = 0.015f;
        break;
    }
    case TLM_TYPE_EVENT:
    default: {
        tlm_event_t *e = &p->u.event;
        p->type = TLM_TYPE_EVENT;
        e->cycle = i;
        e->code = (uint16_t)(1u + i % (TLM_EVT_CODE_COUNT - 1u));
        /* the codes may have gaps (helpers own ranges): step to the next defined one */
        for (unsigned k = 0; k < TLM_EVT_CODE_COUNT && strcmp(tlm_event_name(e->code), "?") == 0; k++) {
            e->code = (uint16_t)(e->code % (TLM_EVT_CODE_COUNT - 1u) + 1u);
        }
        e->severity = (uint8_t)(i % TLM_SEV_COUNT);
        e->subject = (uint8_t)(i % 3u);
        e->arg0 = -(int32_t)i - 1;
        e->arg1 = (int32_t)(i * 65536u);
        break;
    }
    }
}

int tlm_test_packets_equal(const tlm_packet_t *a, const tlm_packet_t *b)
{
    if (a->type != b->type || a->seq != b->seq || a->time.coarse_s != b->time.coarse_s ||
        a->time.fine != b->time.fine) {
        return 0;
    }
    switch (a->type) {
    case TLM_TYPE_NAV: {
        const tlm_nav_t *x = &a->u.nav, *y = &b->u.nav;
        int eq = x->cycle == y->cycle && x->status == y->status && x->reason == y->reason &&
                 x->mode == y->mode && x->beacons_used == y->beacons_used && x->cams_used == y->cams_used &&
                 x->iterations == y->iterations && x->residual_rms_mpx == y->residual_rms_mpx &&
                 x->pl_pos_um == y->pl_pos_um && x->pl_att_udeg == y->pl_att_udeg;
        for (int k = 0; k < 3; k++) {
            eq = eq && x->pos_um[k] == y->pos_um[k] && x->att_udeg[k] == y->att_udeg[k] &&
                 x->sigma_pos_um[k] == y->sigma_pos_um[k] && x->sigma_att_udeg[k] == y->sigma_att_udeg[k];
        }
        for (int k = 0; k < 4; k++) {
            eq = eq && x->q_q30[k] == y->q_q30[k];
        }
        /* bit-exact: the wire carries the binary32 pattern */
        for (unsigned k = 0; k < TLM_NAV_COV_N; k++) {
            uint32_t bx, by;
            memcpy(&bx, &x->cov[k], sizeof bx);
            memcpy(&by, &y->cov[k], sizeof by);
            eq = eq && bx == by;
        }
        return eq;
    }
    case TLM_TYPE_CAMERA: {
        const tlm_camera_t *x = &a->u.camera, *y = &b->u.camera;
        return x->cycle == y->cycle && x->camera == y->camera && x->state == y->state && x->blobs == y->blobs &&
               x->beacons_identified == y->beacons_identified && x->exposure_us == y->exposure_us &&
               x->gain_cdb == y->gain_cdb && x->frame_seq == y->frame_seq &&
               x->frames_dropped == y->frames_dropped;
    }
    case TLM_TYPE_HK: {
        const tlm_hk_t *x = &a->u.hk, *y = &b->u.hk;
        return x->cycle == y->cycle && x->mode == y->mode && x->cpu_load_permille == y->cpu_load_permille &&
               x->cycle_p50_us == y->cycle_p50_us && x->cycle_p95_us == y->cycle_p95_us &&
               x->cycle_p99_us == y->cycle_p99_us && x->cycle_max_us == y->cycle_max_us &&
               x->n_cycles == y->n_cycles && x->n_fix == y->n_fix && x->n_no_fix == y->n_no_fix &&
               x->n_tlm_dropped == y->n_tlm_dropped && x->n_cam_errors == y->n_cam_errors &&
               x->table_crc32 == y->table_crc32 && x->n_acquire == y->n_acquire &&
               x->acq_units_max == y->acq_units_max && x->acq_units_last == y->acq_units_last &&
               x->acq_band_last == y->acq_band_last && x->acq_best_last == y->acq_best_last &&
               x->n_degraded == y->n_degraded && x->n_cmd_accepted == y->n_cmd_accepted &&
               x->n_cmd_rejected == y->n_cmd_rejected && x->cmd_seq_last == y->cmd_seq_last &&
               x->cams_enabled == y->cams_enabled;
    }
    case TLM_TYPE_EVENT: {
        const tlm_event_t *x = &a->u.event, *y = &b->u.event;
        return x->cycle == y->cycle && x->code == y->code && x->severity == y->severity &&
               x->subject == y->subject && x->arg0 == y->arg0 && x->arg1 == y->arg1;
    }
    case TLM_TYPE_FIXOBS: {
        const tlm_fixobs_t *x = &a->u.fixobs, *y = &b->u.fixobs;
        int eq = x->cycle == y->cycle && x->index == y->index && x->count == y->count && x->camera == y->camera &&
                 x->beacon_id == y->beacon_id && x->used == y->used;
        /* bit-exact: the wire carries the binary32 pattern */
        for (unsigned k = 0; k < TLM_FIXOBS_UV_PX_N + TLM_FIXOBS_COV_PX2_N; k++) {
            const float *fx = k < TLM_FIXOBS_UV_PX_N ? &x->uv_px[k] : &x->cov_px2[k - TLM_FIXOBS_UV_PX_N];
            const float *fy = k < TLM_FIXOBS_UV_PX_N ? &y->uv_px[k] : &y->cov_px2[k - TLM_FIXOBS_UV_PX_N];
            uint32_t bx, by;
            memcpy(&bx, fx, sizeof bx);
            memcpy(&by, fy, sizeof by);
            eq = eq && bx == by;
        }
        return eq;
    }
    default:
        return 0;
    }
}

size_t tlm_test_stream(tlm_encoder_t *enc, uint32_t n, uint8_t *out, size_t cap, tlm_packet_t *sent)
{
    static const tlm_type_t order[6] = {TLM_TYPE_NAV, TLM_TYPE_CAMERA, TLM_TYPE_CAMERA,
                                        TLM_TYPE_CAMERA, TLM_TYPE_HK, TLM_TYPE_EVENT};
    size_t pos = 0;
    for (uint32_t i = 0; i < n; i++) {
        tlm_packet_t p;
        tlm_test_sample(&p, order[i % 6u], i);
        size_t len = 0;
        assert_int_equal(tlm_frame_encode(enc, &p, out + pos, cap - pos, &len), TLM_OK);
        pos += len;
        if (sent != NULL) {
            sent[i] = p;
        }
    }
    return pos;
}
