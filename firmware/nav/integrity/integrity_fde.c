/* integrity_fde.c -- exclusion and its memory (integrity.h, second part):
 * held-out beacons and cameras, one new exclusion per cycle, re-admission
 * after the hold when the item's own test passes again. */
#include <math.h>
#include <string.h>

#include "math/core_inline.h"
#include "firmware/nav/integrity/integrity.h"

void mfns_integrity_memory_reset(mfns_integrity_memory_t *mem)
{
    memset(mem, 0, sizeof *mem);
    mfns_camera_watch_reset(&mem->camwatch);
    for (int i = 0; i < MFNS_INTEGRITY_MAX_HELD_BEACONS; i++) {
        mem->beacon[i] = -1;
        mem->beacon_hold[i] = 0;
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        mem->cam_hold[c] = 0;
        mem->cam_held[c] = 0;
        mem->cam_lag[c] = 0;
        mem->lag_verify[c] = 0;
        mem->lag_pos[c] = 0;
        for (int i = 0; i < MFNS_INTEGRITY_LAG_WINDOW; i++) {
            mem->lag_num[c][i] = 0.0f;
            mem->lag_den[c][i] = 0.0f;
        }
    }
}

uint8_t mfns_integrity_hold_lagging(mfns_integrity_memory_t *mem, int cam, uint8_t why, uint16_t cycles)
{
    if (mem == NULL || cam < 0 || cam >= MFNS_NUM_CAMERAS) {
        return 0U;
    }
    const uint8_t before = mem->cam_lag[cam];
    mem->cam_held[cam] = 1U;
    mem->cam_lag[cam] = why;
    mem->cam_hold[cam] = cycles > 0U ? cycles : 1U;
    return before;
}

static bool usable(const mfns_pose_solution_t *s)
{
    return s->status == MFNS_POSE_OK || s->status == MFNS_POSE_DEGRADED;
}

static bool beacon_held(const mfns_integrity_memory_t *mem, int b)
{
    for (int i = 0; i < MFNS_INTEGRITY_MAX_HELD_BEACONS; i++) {
        if (mem->beacon[i] >= 0 && mem->beacon[i] == b) {
            return true;
        }
    }
    return false;
}

/* sol's assoc without the inliers of the held items (and of extra, when
 * not NULL). Returns the number of inlier observations removed. Out of line
 * on a size build: LTO inlines it at both calls otherwise (34 B more). */
MFNS_OUT_OF_LINE
static int assoc_without(const mfns_integrity_memory_t *mem, const mfns_integrity_hyp_t *extra,
                         const mfns_pose_solution_t *sol, const mfns_obs_frame_t *frame, mfns_pose_assoc_t *a)
{
    *a = sol->assoc;
    int removed = 0;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        for (int i = 0; i < frame->count[c] && i < MFNS_MAX_OBS_PER_CAMERA; i++) {
            const int16_t b = a->beacon[c][i];
            if (b == MFNS_POSE_NO_BEACON) {
                continue;
            }
            const bool out = (mem != NULL && (mem->cam_held[c] != 0U || beacon_held(mem, b))) ||
                             (extra != NULL && ((extra->kind == MFNS_INTEGRITY_HYP_BEACON && extra->id == b) ||
                                                (extra->kind == MFNS_INTEGRITY_HYP_CAMERA && extra->id == c)));
            if (out) {
                removed += sol->inlier[c][i] != 0U ? 1 : 0;
                a->beacon[c][i] = MFNS_POSE_NO_BEACON;
            }
        }
    }
    return removed;
}

/* from re-solved from its pose with assoc a, into out (another solution:
 * mfns_pose_refine clears out before it reads the start pose), with from's
 * count of hypotheses. */
static void resolve(const mfns_rig_t *rig, const mfns_beacon_map_t *map, const mfns_obs_frame_t *frame,
                    const mfns_pose_config_t *cfg, const mfns_pose_assoc_t *a, const mfns_pose_solution_t *from,
                    mfns_pose_solution_t *out)
{
    (void)mfns_pose_refine(rig, map, frame, a, &from->pose, cfg, out); /* status in out */
    out->hypotheses = from->hypotheses;
}

/* Mark sol NO_FIX with reason, keeping its pose for diagnostics. */
static void refuse(mfns_pose_solution_t *sol, mfns_pose_reason_t reason)
{
    sol->status = MFNS_POSE_NO_FIX;
    sol->reason = reason;
}

static void held_report(const mfns_integrity_memory_t *mem, mfns_integrity_result_t *res)
{
    for (int i = 0; i < MFNS_INTEGRITY_MAX_HELD_BEACONS && res->excluded_beacon < 0; i++) {
        if (mem->beacon[i] >= 0) {
            res->excluded_beacon = mem->beacon[i];
        }
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS && res->excluded_camera < 0; c++) {
        if (mem->cam_held[c] != 0U) {
            res->excluded_camera = (int8_t)c;
        }
    }
}

/* Whether probe has an inlier in full. */
static bool present_in(const mfns_pose_solution_t *full, const mfns_obs_frame_t *frame,
                       const mfns_integrity_hyp_t *probe)
{
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        for (int k = 0; k < frame->count[c] && k < MFNS_MAX_OBS_PER_CAMERA; k++) {
            const int16_t b = full->assoc.beacon[c][k];
            if (full->inlier[c][k] != 0U && b != MFNS_POSE_NO_BEACON &&
                (probe->kind == MFNS_INTEGRITY_HYP_BEACON ? b == probe->id : c == probe->id)) {
                return true;
            }
        }
    }
    return false;
}

/* The re-admission test of a held item on full (the fix with every item):
 * true when it is seen and its separation passes; not seen this cycle,
 * there is nothing to test it against and it stays held. */
static bool passes_again(const mfns_rig_t *rig, const mfns_beacon_map_t *map, const mfns_obs_frame_t *frame,
                         const mfns_pose_config_t *cfg, const mfns_integrity_settings_t *set,
                         const mfns_pose_solution_t *full, const mfns_integrity_hyp_t *probe)
{
    mfns_integrity_eval_t ev;
    return usable(full) && present_in(full, frame, probe) &&
           mfns_integrity_evaluate(rig, map, frame, full, cfg, set, probe, &ev) == MFNS_INTEGRITY_OK &&
           ev.probe_norm_sep <= 1.0f;
}

/* Count the holds down; the first item whose hold has run out is tested
 * (passes_again): re-admitted when it passes, else held again. At most one
 * test per cycle. */
static void readmit(mfns_integrity_memory_t *mem, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                    const mfns_obs_frame_t *frame, const mfns_pose_config_t *cfg,
                    const mfns_integrity_settings_t *set, const mfns_pose_solution_t *full,
                    mfns_integrity_result_t *res)
{
    bool tested = false;
    for (int i = 0; i < MFNS_INTEGRITY_MAX_HELD_BEACONS; i++) {
        if (mem->beacon[i] < 0) {
            continue;
        }
        if (mem->beacon_hold[i] > 0U) {
            mem->beacon_hold[i]--;
        } else if (!tested) {
            tested = true;
            const mfns_integrity_hyp_t probe = {.kind = (uint8_t)MFNS_INTEGRITY_HYP_BEACON, .id = mem->beacon[i]};
            if (passes_again(rig, map, frame, cfg, set, full, &probe)) {
                res->readmitted_beacon = mem->beacon[i];
                mem->beacon[i] = -1;
            } else {
                mem->beacon_hold[i] = set->hold_cycles;
            }
        }
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        if (mem->cam_held[c] == 0U || mem->cam_lag[c] != 0U) {
            continue; /* a lag hold is the time-offset monitor's to release */
        }
        if (mem->cam_hold[c] > 0U) {
            mem->cam_hold[c]--;
        } else if (!tested) {
            tested = true;
            const mfns_integrity_hyp_t probe = {.kind = (uint8_t)MFNS_INTEGRITY_HYP_CAMERA, .id = (int16_t)c};
            if (passes_again(rig, map, frame, cfg, set, full, &probe)) {
                res->readmitted_camera = (int8_t)c;
                mem->cam_held[c] = 0U;
                mem->cam_lag[c] = 0U;
            } else {
                mem->cam_hold[c] = set->hold_cycles;
            }
        }
    }
}

/* Put hyp in the memory; true when it was not held (a new episode). */
static bool hold(mfns_integrity_memory_t *mem, const mfns_integrity_hyp_t *hyp, uint16_t cycles)
{
    if (hyp->kind == MFNS_INTEGRITY_HYP_CAMERA && hyp->id >= 0 && hyp->id < MFNS_NUM_CAMERAS) {
        const bool fresh = mem->cam_held[hyp->id] == 0U;
        mem->cam_held[hyp->id] = 1U;
        mem->cam_hold[hyp->id] = cycles;
        return fresh;
    }
    int slot = -1;
    for (int i = 0; i < MFNS_INTEGRITY_MAX_HELD_BEACONS; i++) {
        if (mem->beacon[i] == hyp->id) {
            mem->beacon_hold[i] = cycles;
            return false;
        }
        if (slot < 0 && mem->beacon[i] < 0) {
            slot = i;
        }
    }
    if (slot < 0) {
        /* full: the one closest to re-admission gives way (bounded memory) */
        slot = 0;
        for (int i = 1; i < MFNS_INTEGRITY_MAX_HELD_BEACONS; i++) {
            slot = mem->beacon_hold[i] < mem->beacon_hold[slot] ? i : slot;
        }
    }
    mem->beacon[slot] = hyp->id;
    mem->beacon_hold[slot] = cycles;
    return true;
}

static bool beacons_monitored(const mfns_integrity_eval_t *ev)
{
    return ev->unmonitorable == ev->unmonitorable_cameras;
}

/* Verdict on an evaluated fix: true when usable; the PL it certified (or
 * failed on) into res. */
static bool verdict(const mfns_integrity_eval_t *ev, const mfns_integrity_settings_t *set, mfns_pose_solution_t *sol,
                    mfns_integrity_result_t *res)
{
    res->tests_passed = ev->tests_passed;
    res->max_norm_sep = ev->max_norm_sep;
    res->hypotheses = (uint16_t)(ev->hypotheses - ev->unmonitorable);
    res->unmonitorable = ev->unmonitorable;
    res->pl_pos_mm = ev->pl_pos_mm;
    res->pl_att_deg = ev->pl_att_deg;
    res->camera_unmonitored = false;
    if (!beacons_monitored(ev)) {
        refuse(sol, MFNS_POSE_R_UNMONITORED);
        return false;
    }
    if (!ev->tests_passed) {
        refuse(sol, MFNS_POSE_R_FAULT_DETECTED);
        return false;
    }
    if (ev->pl_pos_mm <= set->alert_limit_pos_mm && ev->pl_att_deg <= set->alert_limit_att_deg) {
        return true; /* every single fault bounded */
    }
    if (set->require_camera_monitor != 0U) {
        refuse(sol, ev->unmonitorable_cameras > 0U ? MFNS_POSE_R_UNMONITORED : MFNS_POSE_R_PL_EXCEEDS_AL);
        return false;
    }
    /* camera faults unbounded: certify against beacon faults alone */
    res->pl_pos_mm = ev->pl_beacon_pos_mm;
    res->pl_att_deg = ev->pl_beacon_att_deg;
    if (!(ev->pl_beacon_pos_mm <= set->alert_limit_pos_mm) || !(ev->pl_beacon_att_deg <= set->alert_limit_att_deg)) {
        refuse(sol, MFNS_POSE_R_PL_EXCEEDS_AL);
        return false;
    }
    res->camera_unmonitored = true;
    return true;
}

/* A usable fix's final status: EXCLUDED while something is held out of it,
 * else CAMERA_UNMONITORED when only beacon faults are bounded, else the
 * solver's own. */
static void mark_usable(bool excluded, const mfns_integrity_result_t *res, mfns_pose_solution_t *sol)
{
    if (excluded) {
        sol->status = MFNS_POSE_DEGRADED;
        sol->reason = MFNS_POSE_R_EXCLUDED;
    } else if (res->camera_unmonitored) {
        sol->status = MFNS_POSE_DEGRADED;
        sol->reason = MFNS_POSE_R_CAMERA_UNMONITORED;
    }
}

bool mfns_integrity_fde(mfns_integrity_memory_t *mem, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                        const mfns_obs_frame_t *frame, const mfns_pose_config_t *cfg,
                        const mfns_integrity_settings_t *set, mfns_pose_solution_t *sol,
                        mfns_integrity_result_t *res)
{
    memset(res, 0, sizeof *res);
    res->excluded_beacon = -1;
    res->excluded_camera = -1;
    res->readmitted_beacon = -1;
    res->readmitted_camera = -1;
    res->pl_pos_mm = INFINITY;
    res->pl_att_deg = INFINITY;
    if (mem == NULL || sol == NULL || !usable(sol) || rig == NULL || map == NULL || frame == NULL || cfg == NULL ||
        !mfns_integrity_settings_valid(set)) {
        return false;
    }
    res->evaluated = true;
    /* 1. held items out (the fix with them is kept for the re-admission test) */
    mfns_pose_assoc_t a;
    const bool held_out = assoc_without(mem, NULL, sol, frame, &a) > 0;
    if (held_out) {
        const mfns_pose_solution_t full = *sol;
        resolve(rig, map, frame, cfg, &a, &full, sol);
        readmit(mem, rig, map, frame, cfg, set, &full, res);
    } else {
        readmit(mem, rig, map, frame, cfg, set, sol, res); /* counts the holds down */
    }
    if (!usable(sol)) {
        held_report(mem, res);
        return false;
    }
    /* 2. evaluate */
    mfns_integrity_eval_t ev;
    if (mfns_integrity_evaluate(rig, map, frame, sol, cfg, set, NULL, &ev) != MFNS_INTEGRITY_OK) {
        refuse(sol, MFNS_POSE_R_SINGULAR);
        held_report(mem, res);
        return false;
    }
    (void)verdict(&ev, set, &(mfns_pose_solution_t){0}, res); /* the numbers; the verdict comes below */
    res->detect_norm_sep = ev.max_norm_sep;
    /* 3. one new exclusion when a test failed */
    if (!ev.tests_passed) {
        const mfns_integrity_hyp_t bad = ev.worst;
        mfns_pose_solution_t red;
        if (assoc_without(NULL, &bad, sol, frame, &a) > 0) {
            resolve(rig, map, frame, cfg, &a, sol, &red);
            mfns_integrity_eval_t ev2;
            if (usable(&red) &&
                mfns_integrity_evaluate(rig, map, frame, &red, cfg, set, NULL, &ev2) == MFNS_INTEGRITY_OK) {
                if (beacons_monitored(&ev2) && ev2.tests_passed) {
                    /* the rest agree: the item is at fault, whatever the PL */
                    const bool fresh = hold(mem, &bad, set->hold_cycles);
                    if (bad.kind == MFNS_INTEGRITY_HYP_CAMERA) {
                        res->new_camera_exclusion = fresh;
                    } else {
                        res->new_beacon_exclusion = fresh;
                    }
                }
                *sol = red;
                const bool ok = verdict(&ev2, set, sol, res);
                held_report(mem, res);
                if (ok) {
                    mark_usable(true, res, sol);
                }
                return ok;
            }
        }
        refuse(sol, MFNS_POSE_R_FAULT_DETECTED);
        held_report(mem, res);
        return false;
    }
    held_report(mem, res);
    if (!verdict(&ev, set, sol, res)) {
        return false;
    }
    mark_usable(held_out, res, sol);
    return true;
}
