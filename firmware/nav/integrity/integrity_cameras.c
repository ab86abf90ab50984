/* integrity_cameras.c -- cameras inconsistent with the fix (integrity_cameras.h). */
#include "firmware/nav/integrity/integrity_cameras.h"
#include "math/core_inline.h"

#include <string.h>

_Static_assert(MFNS_CAMERA_INCONSISTENT_EVIDENCE > 0, "a positive evidence bound");
_Static_assert(MFNS_CAMERA_CONSISTENT_FIXES > 0 && MFNS_CAMERA_CONSISTENT_FIXES < 255, "fits its counter");

#define REPORTED_INCONSISTENT 1U
#define REPORTED_DISAGREES 2U

void mfns_camera_watch_reset(mfns_camera_watch_t *w)
{
    if (w != NULL) {
        memset(w, 0, sizeof *w);
        for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
            w->pair_with[c] = -1;
        }
    }
}

bool mfns_camera_has_inlier(const mfns_pose_solution_t *sol, const mfns_obs_frame_t *frame, int c)
{
    for (int i = 0; i < frame->count[c] && i < MFNS_MAX_OBS_PER_CAMERA; i++) {
        if (sol->assoc.beacon[c][i] != MFNS_POSE_NO_BEACON && sol->inlier[c][i] != 0U) {
            return true;
        }
    }
    return false;
}

/* The beacons pose predicts inside camera c's image, at least margin_px
 * from its edges, in front of it. */
static uint16_t predicted_in_view(const mfns_rig_t *rig, const mfns_beacon_map_t *map, const mfns_pose_t *pose,
                                  int c, float margin_px)
{
    const mfns_intrinsics_t *k = &rig->cam[c].k;
    uint16_t n = 0;
    for (int b = 0; b < (int)map->count && b < MFNS_MAX_BEACONS; b++) {
        float uv[2];
        if (mfns_cam_project(&rig->cam[c], pose, map->beacon[b].p_w, uv, NULL) == MFNS_PROJ_OK &&
            mfns_cam_in_image(k, uv[0], uv[1]) &&
            (margin_px <= 0.0f || (uv[0] >= margin_px && uv[1] >= margin_px &&
                                   uv[0] <= (float)k->width - 1.0f - margin_px &&
                                   uv[1] <= (float)k->height - 1.0f - margin_px))) {
            n++;
        }
    }
    return n;
}

MFNS_OUT_OF_LINE
static uint16_t add_sat(uint16_t a, uint16_t b)
{
    return (uint16_t)((uint32_t)a + b < UINT16_MAX ? a + b : UINT16_MAX);
}

/* The one other camera with an inlier in sol (-1: none), and how many there
 * are. Out of line on a size build: inlined, the LTO image of the camera
 * watch's loop is 86 B larger (measured). */
MFNS_OUT_OF_LINE
static int reference_cameras(const mfns_pose_solution_t *sol, const mfns_obs_frame_t *frame, int c, int *other)
{
    int n = 0;
    *other = -1;
    for (int o = 0; o < MFNS_NUM_CAMERAS; o++) {
        if (o != c && mfns_camera_has_inlier(sol, frame, o)) {
            n++;
            *other = o;
        }
    }
    return n;
}

static void evidence_against(mfns_camera_watch_t *w, const mfns_pose_solution_t *sol, const mfns_obs_frame_t *frame,
                             int c, uint16_t n)
{
    int other = -1;
    const int refs = reference_cameras(sol, frame, c, &other);
    w->consistent[c] = 0;
    if (refs >= 2) {
        w->evidence[c] = add_sat(w->evidence[c], n);
        w->fixes[c] = add_sat(w->fixes[c], 1U);
    } else if (refs == 1) {
        if (w->pair_with[c] != (int8_t)other) { /* another pair: its own evidence */
            w->pair_evidence[c] = 0;
            w->pair_fixes[c] = 0;
            w->pair_with[c] = (int8_t)other;
        }
        w->pair_evidence[c] = add_sat(w->pair_evidence[c], n);
        w->pair_fixes[c] = add_sat(w->pair_fixes[c], 1U);
    }
}

void mfns_camera_watch_update(mfns_camera_watch_t *w, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                              const mfns_obs_frame_t *frame, const mfns_pose_solution_t *sol, bool pose_known,
                              const uint8_t solver_inlier[MFNS_NUM_CAMERAS], mfns_camera_watch_report_t *rep)
{
    if (rep == NULL) {
        return;
    }
    memset(rep, 0, sizeof *rep);
    rep->inconsistent = -1;
    rep->disagrees = -1;
    rep->disagrees_with = -1;
    if (w == NULL || rig == NULL || map == NULL || frame == NULL || sol == NULL) {
        return;
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        const bool inlier =
            mfns_camera_has_inlier(sol, frame, c) || (solver_inlier != NULL && solver_inlier[c] != 0U);
        if (pose_known && inlier) {
            w->evidence[c] = 0;
            w->fixes[c] = 0;
            w->pair_evidence[c] = 0;
            w->pair_fixes[c] = 0;
            w->pair_with[c] = -1;
            w->consistent[c] = (uint8_t)(w->consistent[c] < UINT8_MAX ? w->consistent[c] + 1U : UINT8_MAX);
            w->miss_run[c] = 0U;
            if (w->consistent[c] >= MFNS_CAMERA_CONSISTENT_FIXES) {
                w->reported[c] = 0U; /* the episode is over: a new one is reported again */
            }
        } else if (pose_known && frame->dark[c] == 0U) {
            /* an image, none of its spots used (or none found in the
             * windows around the predicted beacons): as many chances to have
             * found one as beacons predicted in its image (none: no evidence) */
            const uint16_t n = predicted_in_view(rig, map, &sol->pose, c, 0.0f);
            if (n > 0U) {
                evidence_against(w, sol, frame, c, n);
                w->miss_run[c] = (uint8_t)(w->miss_run[c] < UINT8_MAX ? w->miss_run[c] + 1U : UINT8_MAX);
            }
        } /* no image, or no pose to predict from: nothing to tell */
        if (rep->inconsistent < 0 && (w->reported[c] & REPORTED_INCONSISTENT) == 0U &&
            w->evidence[c] >= MFNS_CAMERA_INCONSISTENT_EVIDENCE) {
            w->reported[c] = (uint8_t)(w->reported[c] | REPORTED_INCONSISTENT);
            rep->inconsistent = (int8_t)c;
            rep->evidence = w->evidence[c];
            rep->fixes = w->fixes[c];
        }
        if (rep->disagrees < 0 && (w->reported[c] & REPORTED_DISAGREES) == 0U &&
            w->pair_evidence[c] >= MFNS_CAMERA_INCONSISTENT_EVIDENCE) {
            w->reported[c] = (uint8_t)(w->reported[c] | REPORTED_DISAGREES);
            rep->disagrees = (int8_t)c;
            rep->disagrees_with = w->pair_with[c];
            rep->pair_evidence = w->pair_evidence[c];
            rep->pair_fixes = w->pair_fixes[c];
        }
        if (!inlier && (w->reported[c] & REPORTED_INCONSISTENT) != 0U) {
            rep->state[c] = 1U;
        } else if (!inlier && (w->reported[c] & REPORTED_DISAGREES) != 0U) {
            rep->state[c] = 2U;
        }
    }
}

int mfns_camera_watch_contradicting(const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                    const mfns_obs_frame_t *frame, const mfns_pose_solution_t *sol,
                                    float margin_px, const uint8_t verifying[MFNS_NUM_CAMERAS])
{
    if (rig == NULL || map == NULL || frame == NULL || sol == NULL ||
        (sol->status != MFNS_POSE_OK && sol->status != MFNS_POSE_DEGRADED)) {
        return -1;
    }
    int with = -1, cams = 0;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        if (mfns_camera_has_inlier(sol, frame, c)) {
            cams++;
            with = c;
        }
    }
    if (cams != 1) {
        return -1;
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        if (c != with && frame->dark[c] == 0U && (verifying == NULL || verifying[c] == 0U) &&
            predicted_in_view(rig, map, &sol->pose, c, margin_px) > 0U) {
            return c;
        }
    }
    return -1;
}
