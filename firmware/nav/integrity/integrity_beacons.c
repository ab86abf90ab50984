/* integrity_beacons.c -- beacons missing or rejected (integrity_beacons.h). */
#include "firmware/nav/integrity/integrity_beacons.h"

#include <string.h>

_Static_assert(MFNS_BEACON_MISSING_FIXES > 0, "a positive window");
_Static_assert(MFNS_BEACON_REJECT_COUNT > 0, "a positive count");
_Static_assert(MFNS_BEACON_CLEAR_FIXES > 0, "a positive window");

#define REPORTED_MISSING 1U
#define REPORTED_REJECTED 2U

void mfns_beacon_watch_reset(mfns_beacon_watch_t *w)
{
    if (w != NULL) {
        memset(w, 0, sizeof *w);
    }
}

typedef enum { SEEN_NONE = 0, SEEN_GATED, SEEN_USED } seen_t;

/* How beacon b appears in sol: used as an inlier, associated but gated, or not at all. */
static seen_t seen_in(const mfns_pose_solution_t *sol, const mfns_obs_frame_t *frame, int b)
{
    seen_t s = SEEN_NONE;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        for (int i = 0; i < frame->count[c] && i < MFNS_MAX_OBS_PER_CAMERA; i++) {
            if (sol->assoc.beacon[c][i] == b) {
                s = sol->inlier[c][i] != 0U ? SEEN_USED : (s == SEEN_NONE ? SEEN_GATED : s);
            }
        }
    }
    return s;
}

static bool in_view(const mfns_rig_t *rig, const mfns_obs_frame_t *frame, const mfns_pose_t *pose, mfns_v3_t p_w)
{
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        float uv[2];
        if (frame->dark[c] == 0U && mfns_cam_project(&rig->cam[c], pose, p_w, uv, NULL) == MFNS_PROJ_OK &&
            mfns_cam_in_image(&rig->cam[c].k, uv[0], uv[1])) {
            return true;
        }
    }
    return false;
}

static bool is_held(const int16_t *held, int n_held, int b)
{
    for (int i = 0; held != NULL && i < n_held; i++) {
        if (held[i] == b) {
            return true;
        }
    }
    return false;
}

static uint16_t inc(uint16_t v)
{
    return (uint16_t)(v < UINT16_MAX ? v + 1U : v);
}

void mfns_beacon_watch_update(mfns_beacon_watch_t *w, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                              const mfns_obs_frame_t *frame, const mfns_pose_solution_t *sol, bool pose_known,
                              const int16_t *held, int n_held, mfns_beacon_watch_report_t *rep)
{
    if (rep == NULL) {
        return;
    }
    rep->missing = -1;
    rep->rejected = -1;
    rep->missing_fixes = 0;
    rep->rejected_count = 0;
    if (w == NULL || rig == NULL || map == NULL || frame == NULL || sol == NULL || !pose_known) {
        return;
    }
    for (int b = 0; b < (int)map->count && b < MFNS_MAX_BEACONS; b++) {
        const seen_t s = seen_in(sol, frame, b);
        if (s == SEEN_USED) {
            w->unseen[b] = 0;
            w->rejected[b] = (uint16_t)(w->rejected[b] > 0U ? w->rejected[b] - 1U : 0U);
            w->used[b] = inc(w->used[b]);
            if (w->used[b] >= MFNS_BEACON_CLEAR_FIXES) {
                w->reported[b] = 0U; /* the episode is over: a new one is reported again */
                w->rejected[b] = 0U;
            }
            continue;
        }
        w->used[b] = 0;
        if (s == SEEN_GATED || is_held(held, n_held, b)) {
            w->unseen[b] = 0;
            w->rejected[b] = inc(w->rejected[b]);
        } else if (in_view(rig, frame, &sol->pose, map->beacon[b].p_w)) {
            w->unseen[b] = inc(w->unseen[b]);
        } /* out of view: nothing to tell */
        if (rep->missing < 0 && w->unseen[b] >= MFNS_BEACON_MISSING_FIXES &&
            (w->reported[b] & REPORTED_MISSING) == 0U) {
            w->reported[b] = (uint8_t)(w->reported[b] | REPORTED_MISSING);
            rep->missing = (int16_t)b;
            rep->missing_fixes = w->unseen[b];
        }
        if (rep->rejected < 0 && w->rejected[b] >= MFNS_BEACON_REJECT_COUNT &&
            (w->reported[b] & REPORTED_REJECTED) == 0U) {
            w->reported[b] = (uint8_t)(w->reported[b] | REPORTED_REJECTED);
            rep->rejected = (int16_t)b;
            rep->rejected_count = w->rejected[b];
        }
    }
}
