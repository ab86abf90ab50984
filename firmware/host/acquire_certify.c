/* acquire_certify.c -- see acquire_certify.h. */
#include "firmware/host/acquire_certify.h"

#include <string.h>

#include "firmware/nav/acquire/acquire_internal.h"

void mfns_certify_frame(const mfns_rig_t *rig, const mfns_beacon_map_t *map, const mfns_beacon_index_t *idx,
                        const mfns_pose_t *pose, mfns_obs_frame_t *frame, mfns_pose_assoc_t *truth)
{
    memset(frame, 0, sizeof *frame);
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        for (int i = 0; i < MFNS_MAX_OBS_PER_CAMERA; i++) {
            truth->beacon[c][i] = MFNS_POSE_NO_BEACON;
        }
        const mfns_camera_t *cam = &rig->cam[c];
        const mfns_v3_t ck = mfns_v3_add(mfns_pose_position_w(pose), mfns_m3_tmul_v3(pose->C_w_b, cam->r_bk_b));
        bool taken[MFNS_MAX_BEACONS] = {false};
        /* nearest first: at most MAX_OBS passes over the map */
        for (int slot = 0; slot < MFNS_MAX_OBS_PER_CAMERA; slot++) {
            int best = -1;
            float best_z = 0.0f, bu = 0.0f, bv = 0.0f, bx = 0.0f, by = 0.0f;
            for (int b = 0; b < map->count; b++) {
                if (taken[b]) {
                    continue;
                }
                const mfns_v3_t pk = mfns_cam_world_to_camera(cam, pose, map->beacon[b].p_w);
                float uv[2];
                if (pk.z < MFNS_CAM_MIN_DEPTH_MM ||
                    mfns_cam_project(cam, pose, map->beacon[b].p_w, uv, NULL) != MFNS_PROJ_OK ||
                    !mfns_cam_in_image(&cam->k, uv[0], uv[1]) ||
                    !mfns_bidx_emits_toward(&idx->geom[b], map->beacon[b].p_w, ck)) {
                    taken[b] = true; /* never visible from this pose */
                    continue;
                }
                if (best < 0 || pk.z < best_z) {
                    best = b;
                    best_z = pk.z;
                    bu = uv[0];
                    bv = uv[1];
                    bx = pk.x / pk.z;
                    by = pk.y / pk.z;
                }
            }
            if (best < 0) {
                break;
            }
            taken[best] = true;
            mfns_obs_t *o = &frame->obs[c][frame->count[c]];
            o->u = bu;
            o->v = bv;
            o->x = bx;
            o->y = by;
            truth->beacon[c][frame->count[c]] = (int16_t)best;
            frame->count[c]++;
        }
    }
}

/* A candidate that gives any inlier blob another beacon than the truth. */
static bool is_rival(const mfns_obs_frame_t *frame, const mfns_pose_assoc_t *truth, const mfns_pose_solution_t *s)
{
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        for (int i = 0; i < frame->count[c]; i++) {
            if (s->inlier[c][i] && s->assoc.beacon[c][i] != truth->beacon[c][i]) {
                return true;
            }
        }
    }
    return false;
}

mfns_bidx_status_t mfns_certify(mfns_acq_t *acq, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                const mfns_beacon_index_t *idx, const mfns_pose_config_t *cfg,
                                const mfns_pose_t *poses, uint32_t n, uint32_t budget_per_pose,
                                mfns_obs_frame_t *frame, mfns_certify_result_t *res)
{
    if (acq == NULL || frame == NULL || rig == NULL || map == NULL || idx == NULL || cfg == NULL || res == NULL ||
        (poses == NULL && n > 0) || idx->count != map->count || budget_per_pose == 0) {
        return MFNS_BIDX_E_ARG;
    }
    memset(res, 0, sizeof *res);
    res->samples = n;
    for (uint32_t s = 0; s < n; s++) {
        mfns_pose_assoc_t truth;
        mfns_certify_frame(rig, map, idx, &poses[s], frame, &truth);
        const int nb = frame->count[0] + frame->count[1] + frame->count[2];
        if (nb < (int)MFNS_ACQ_MIN_BLOBS) {
            continue;
        }
        res->usable++;
        if (!mfns_acq_prepare(acq, rig, map, idx, frame, cfg, budget_per_pose, true)) {
            return MFNS_BIDX_E_ARG;
        }
        mfns_acq_search(acq);
        int best_rival = -1;
        bool truth_seen = false;
        for (int i = 0; i < acq->ncand; i++) {
            const mfns_acq_cand_t *cd = &acq->cand[i];
            if (!is_rival(frame, &truth, &cd->sol)) {
                truth_seen = true;
                continue;
            }
            if (!mfns_acq_acceptable(acq, cd)) {
                continue;
            }
            if (cd->inliers > res->rival_by_missing[cd->missing]) {
                res->rival_by_missing[cd->missing] = cd->inliers;
            }
            if (best_rival < 0 || cd->inliers > acq->cand[best_rival].inliers) {
                best_rival = i;
            }
        }
        res->truth_found += truth_seen ? 1u : 0u;
        const uint16_t rin = best_rival >= 0 ? acq->cand[best_rival].inliers : 0u;
        res->rival_hist[rin > MFNS_BIDX_MAX_CERT ? MFNS_BIDX_MAX_CERT : rin]++;
        if (best_rival >= 0 && (int)rin >= nb) {
            res->ambiguous++;
        }
        if (best_rival >= 0 && rin > res->max_rival) {
            res->max_rival = rin;
            mfns_certify_case_t *w = &res->worst;
            memset(w, 0, sizeof *w);
            w->sample = s;
            w->rival_inliers = rin;
            w->rival_missing = acq->cand[best_rival].missing;
            const mfns_pose_solution_t *rs = &acq->cand[best_rival].sol;
            uint16_t k = 0;
            for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
                for (int i = 0; i < frame->count[c] && k < MFNS_CERTIFY_MAX_BLOBS; i++, k++) {
                    w->truth_id[k] = map->beacon[truth.beacon[c][i]].id;
                    w->rival_id[k] = rs->inlier[c][i] && rs->assoc.beacon[c][i] >= 0
                                         ? (int32_t)map->beacon[rs->assoc.beacon[c][i]].id
                                         : -1;
                }
            }
            w->n_blobs = k;
        }
    }
    mfns_certify_finish(res, idx);
    return MFNS_BIDX_OK;
}

void mfns_certify_finish(mfns_certify_result_t *res, const mfns_beacon_index_t *idx)
{
    uint32_t need = MFNS_BIDX_MIN_CERT;
    res->cert_capped = 0;
    for (uint32_t m = 0; m <= MFNS_BIDX_MAX_MISSING; m++) {
        if (m > idx->max_missing) {
            res->cert_inliers[m] = 0;
            continue;
        }
        const uint32_t r = (uint32_t)res->rival_by_missing[m] + 1u;
        need = r > need ? r : need;
        if (need > MFNS_BIDX_MAX_CERT) {
            res->cert_capped = 1u;
        }
        res->cert_inliers[m] = (uint8_t)(need > MFNS_BIDX_MAX_CERT ? MFNS_BIDX_MAX_CERT : need);
    }
}

void mfns_certify_accumulate(mfns_certify_result_t *total, const mfns_certify_result_t *part, uint32_t first_sample)
{
    total->samples += part->samples;
    total->usable += part->usable;
    total->truth_found += part->truth_found;
    total->ambiguous += part->ambiguous;
    for (uint32_t i = 0; i <= MFNS_BIDX_MAX_CERT; i++) {
        total->rival_hist[i] += part->rival_hist[i];
    }
    for (uint32_t m = 0; m <= MFNS_BIDX_MAX_MISSING; m++) {
        if (part->rival_by_missing[m] > total->rival_by_missing[m]) {
            total->rival_by_missing[m] = part->rival_by_missing[m];
        }
    }
    if (part->max_rival > total->max_rival) {
        total->max_rival = part->max_rival;
        total->worst = part->worst;
        total->worst.sample += first_sample;
    }
}

void mfns_certify_apply(mfns_beacon_index_t *idx, const mfns_certify_result_t *res)
{
    for (uint32_t m = 0; m <= MFNS_BIDX_MAX_MISSING; m++) {
        idx->cert_inliers[m] = res->cert_inliers[m];
    }
    idx->analysis_samples = res->samples;
    idx->analysis_max_rival = res->max_rival;
}
