/* beacon_monitor.c -- see beacon_monitor.h. */
#include "firmware/nav/integrity/beacon_monitor.h"

#include <math.h>
#include <string.h>

_Static_assert(MFNS_BMON_MIN_FIXES < UINT16_MAX, "fix counters saturate above the reporting threshold");

void mfns_bmon_reset(mfns_bmon_t *mon)
{
    if (mon == NULL) {
        return;
    }
    memset(mon, 0, sizeof *mon);
    for (int b = 0; b < MFNS_MAX_BEACONS; b++) {
        mon->sigma_scale[b] = 1.0f;
    }
}

/* Whitened residual of one inlier at the fix's pose: L^-1 (projected - measured). */
static bool whitened(const mfns_camera_t *cam, const mfns_pose_t *pose, const mfns_beacon_t *b,
                     const mfns_obs_t *o, float sigma_px, float z[2])
{
    float uv[2], r_px2[3], w[3];
    if (mfns_cam_project(cam, pose, b->p_w, uv, NULL) != MFNS_PROJ_OK ||
        !mfns_pose_obs_cov(cam, pose, b->p_w, o->cov_px2, b->sigma_mm, sigma_px, r_px2) ||
        !mfns_pose_whitener(r_px2, w)) {
        return false;
    }
    const float du = uv[0] - o->u, dv = uv[1] - o->v;
    z[0] = w[0] * du;
    z[1] = w[1] * du + w[2] * dv;
    return isfinite(z[0]) && isfinite(z[1]);
}

static void ewma(float m[2], const float z[2], bool first)
{
    const float a = first ? 1.0f : MFNS_BMON_ALPHA;
    m[0] += a * (z[0] - m[0]);
    m[1] += a * (z[1] - m[1]);
}

/* A beacon's residual into its mean; reports the worst beacon over the level. */
static void beacon_update(mfns_bmon_t *mon, int16_t b, const float z[2], mfns_bmon_report_t *rep)
{
    ewma(mon->m[b], z, mon->n[b] == 0u);
    if (mon->n[b] < UINT16_MAX) {
        mon->n[b]++;
    }
    const float chi = mon->m[b][0] * mon->m[b][0] + mon->m[b][1] * mon->m[b][1];
    if (mon->flagged[b] == 0U && mon->n[b] >= MFNS_BMON_MIN_FIXES && chi > MFNS_BMON_CHI2_2 && chi > rep->beacon_chi2) {
        rep->new_beacon = b;
        rep->beacon_chi2 = chi;
    }
}

/* An outlier's residual enters its beacon's mean clipped to MFNS_BMON_CLIP:
 * one wild association moves the mean by at most CLIP * ALPHA. */
static void clip(float z[2])
{
    const float n2 = z[0] * z[0] + z[1] * z[1];
    if (n2 > MFNS_BMON_CLIP * MFNS_BMON_CLIP) {
        const float s = MFNS_BMON_CLIP / sqrtf(n2);
        z[0] *= s;
        z[1] *= s;
    }
}

static bool is_inlier_somewhere(const mfns_obs_frame_t *frame, const mfns_pose_solution_t *sol, int16_t b)
{
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        for (uint16_t i = 0; i < frame->count[k] && i < MFNS_MAX_OBS_PER_CAMERA; i++) {
            if (sol->assoc.beacon[k][i] == b && sol->inlier[k][i] != 0U) {
                return true;
            }
        }
    }
    return false;
}

/* A beacon integrity holds out (its associations removed from the fix): the
 * unassociated blob nearest its projection at the fix's pose within gate_px,
 * per camera, into its mean (clipped). */
static void held_update(mfns_bmon_t *mon, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                        const mfns_obs_frame_t *frame, const mfns_pose_solution_t *sol, float sigma_px, float gate_px,
                        int16_t b, mfns_bmon_report_t *rep)
{
    if (b < 0 || (uint16_t)b >= map->count || is_inlier_somewhere(frame, sol, b)) {
        return;
    }
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        float uv[2];
        if (mfns_cam_project(&rig->cam[k], &sol->pose, map->beacon[b].p_w, uv, NULL) != MFNS_PROJ_OK) {
            continue;
        }
        int best = -1;
        float best_d2 = gate_px * gate_px;
        for (uint16_t i = 0; i < frame->count[k] && i < MFNS_MAX_OBS_PER_CAMERA; i++) {
            const float du = frame->obs[k][i].u - uv[0], dv = frame->obs[k][i].v - uv[1];
            const float d2 = du * du + dv * dv;
            if (sol->assoc.beacon[k][i] == MFNS_POSE_NO_BEACON && d2 < best_d2) {
                best = (int)i;
                best_d2 = d2;
            }
        }
        float z[2];
        if (best >= 0 && whitened(&rig->cam[k], &sol->pose, &map->beacon[b], &frame->obs[k][best], sigma_px, z)) {
            clip(z);
            beacon_update(mon, b, z, rep);
        }
    }
}

bool mfns_bmon_update(mfns_bmon_t *mon, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                      const mfns_obs_frame_t *frame, const mfns_pose_solution_t *sol, float sigma_px, float gate_px,
                      const int16_t *held, int n_held, mfns_bmon_report_t *rep)
{
    if (mon == NULL || rig == NULL || map == NULL || frame == NULL || sol == NULL || rep == NULL ||
        (held == NULL && n_held > 0)) {
        return false;
    }
    rep->new_beacon = -1;
    rep->new_camera = -1;
    rep->beacon_chi2 = 0.0f;
    rep->camera_chi2 = 0.0f;
    if (sol->status != MFNS_POSE_OK && sol->status != MFNS_POSE_DEGRADED) {
        return true;
    }
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        float sum[2] = {0.0f, 0.0f};
        uint16_t n = 0;
        for (uint16_t i = 0; i < frame->count[k] && i < MFNS_MAX_OBS_PER_CAMERA; i++) {
            const int16_t b = sol->assoc.beacon[k][i];
            float z[2];
            if (b < 0 || (uint16_t)b >= map->count ||
                !whitened(&rig->cam[k], &sol->pose, &map->beacon[b], &frame->obs[k][i], sigma_px, z)) {
                continue;
            }
            if (sol->inlier[k][i] == 0U) { /* gated by the solver: the beacon's, not the camera's */
                clip(z);
                beacon_update(mon, b, z, rep);
                continue;
            }
            beacon_update(mon, b, z, rep);
            sum[0] += z[0];
            sum[1] += z[1];
            n++;
        }
        if (n == 0u) {
            continue;
        }
        const float mean[2] = {sum[0] / (float)n, sum[1] / (float)n};
        const bool first = mon->cn[k] == 0u;
        ewma(mon->c[k], mean, first);
        mon->c_n[k] += (first ? 1.0f : MFNS_BMON_ALPHA) * ((float)n - mon->c_n[k]);
        if (mon->cn[k] < UINT16_MAX) {
            mon->cn[k]++;
        }
        const float chi = mon->c_n[k] * (mon->c[k][0] * mon->c[k][0] + mon->c[k][1] * mon->c[k][1]);
        if (mon->cam_flagged[k] == 0U && mon->cn[k] >= MFNS_BMON_MIN_FIXES && chi > MFNS_BMON_CHI2_2 &&
            chi > rep->camera_chi2) {
            rep->new_camera = (int8_t)k;
            rep->camera_chi2 = chi;
        }
    }
    for (int h = 0; h < n_held && gate_px > 0.0f; h++) {
        held_update(mon, rig, map, frame, sol, sigma_px, gate_px, held[h], rep);
    }
    if (rep->new_beacon >= 0) {
        const int16_t b = rep->new_beacon;
        mon->flagged[b] = 1U;
        mon->sigma_scale[b] = 1.0f + sqrtf(rep->beacon_chi2);
        mon->n_flagged++;
    }
    if (rep->new_camera >= 0) {
        mon->cam_flagged[rep->new_camera] = 1U;
    }
    return true;
}
