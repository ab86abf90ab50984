/* filter_bank.c -- solution separation over time (filter_bank.h). */
#include "firmware/nav/filter/filter_bank.h"

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <string.h>

#include "firmware/nav/integrity/integrity.h"
#include "math/rotation.h"
#include "math/units.h"

#define NO_BEACON (-1)

_Static_assert(MFNS_BANK_MAX_BEACON_HYP <= 255, "slot index fits a u8");
_Static_assert(MFNS_BANK_AXES == MFNS_INTEGRITY_AXES, "the snapshot's axes: 3 position, 3 attitude");

static void clear_cycle(mfns_filter_bank_t *b)
{
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        b->cam_gated[c] = 0;
        b->cam_passed[c] = 0;
        b->frame_rejected[c] = 0;
        b->cam_dirty[c] = 0;
        b->cam_tested[c] = 0;
        b->cam_held_nis[c] = 0.0f;
        b->cam_held_dof[c] = 0;
        b->frame_nis[c] = 0.0f;
        b->frame_dof[c] = 0;
        b->timing_read[c] = 0;
    }
    for (int i = 0; i < MFNS_BANK_MAX_BEACON_HYP; i++) {
        b->slot_seen[i] = 0;
        b->slot_gated[i] = 0;
        b->slot_passed[i] = 0;
    }
    for (int i = 0; i < MFNS_BANK_MAX_EXCLUDED_BEACONS; i++) {
        b->excl_beacon_dirty[i] = 0;
        b->excl_beacon_tested[i] = 0;
    }
    b->work = 0;
    b->told_suspect = -1;
    b->det_kind = MFNS_BANK_HYP_NONE;
    b->det_id = NO_BEACON;
    b->det_by_gate = 0;
}

mfns_filter_status_t mfns_bank_init(mfns_filter_bank_t *b, const mfns_pose_t *pose, const float cov_ros[6][6],
                                    mfns_v3_t v_w, float sigma_v_mm_s, mfns_v3_t w_w, float sigma_w_rad_s,
                                    int64_t t_us)
{
    if (b == NULL) {
        return MFNS_FILTER_E_ARG;
    }
    memset(b, 0, sizeof(*b));
    const mfns_filter_status_t st =
        mfns_filter_init(&b->full, pose, cov_ros, v_w, sigma_v_mm_s, w_w, sigma_w_rad_s, t_us);
    if (st != MFNS_FILTER_OK) {
        return st;
    }
    for (int j = 0; j < MFNS_BANK_AXES; j++) {
        b->var_floor[j] = MFNS_BANK_VAR_FLOOR_EPS * FLT_EPSILON * b->full.P[j][j];
    }
    for (int k = 0; k < MFNS_BANK_CAM_HYP; k++) {
        b->sub[k] = b->full;
        (void)mfns_filter_augment(&b->sub[k], k); /* k < MFNS_NUM_CAMERAS: cannot fail */
    }
    for (int i = 0; i < MFNS_BANK_MAX_BEACON_HYP; i++) {
        b->slot_beacon[i] = NO_BEACON;
    }
    for (int i = 0; i < MFNS_BANK_MAX_EXCLUDED_BEACONS; i++) {
        b->excl_beacon[i] = NO_BEACON;
    }
    clear_cycle(b);
    b->initialised = 1;
    return MFNS_FILTER_OK;
}

void mfns_bank_diffuse_prior(const float var_ros[6], float prior[6][6])
{
    for (int i = 0; i < 6; i++) {
        const float floor_sigma = i < 3 ? MFNS_BANK_START_SIGMA_MM : MFNS_BANK_START_SIGMA_RAD;
        for (int j = 0; j < 6; j++) {
            prior[i][j] = 0.0f;
        }
        prior[i][i] = fmaxf(var_ros[i], floor_sigma * floor_sigma);
    }
}

void mfns_bank_keep_exclusions(mfns_filter_bank_t *b, const int16_t excl_beacon[MFNS_BANK_MAX_EXCLUDED_BEACONS],
                               const uint8_t cam_excluded[MFNS_NUM_CAMERAS])
{
    if (b == NULL || excl_beacon == NULL || cam_excluded == NULL || b->initialised == 0U) {
        return;
    }
    for (int i = 0; i < MFNS_BANK_MAX_EXCLUDED_BEACONS; i++) {
        b->excl_beacon[i] = excl_beacon[i];
        b->excl_beacon_clean[i] = 0;
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        b->cam_excluded[c] = cam_excluded[c] != 0U ? 1U : 0U;
        b->cam_clean[c] = 0;
    }
}

static void start_hypothesis(mfns_filter_bank_t *b, int k)
{
    b->sub[k] = b->full;
    if (k < MFNS_BANK_CAM_HYP) {
        (void)mfns_filter_augment(&b->sub[k], k); /* camera k's fault parameters free */
    }
    mfns_filter_reset_window(&b->sub[k]);
    b->cons_nis[k] = 0.0f;
    b->cons_dof[k] = 0.0f;
}

static void restart_hypotheses(mfns_filter_bank_t *b)
{
    for (int k = 0; k < MFNS_BANK_MAX_HYP; k++) {
        if (k < MFNS_BANK_CAM_HYP || b->slot_beacon[k - MFNS_BANK_CAM_HYP] != NO_BEACON) {
            start_hypothesis(b, k);
        }
    }
}

/* The excess of a subset's innovations over their expectation (sigmas). */
static float consistency_z(const mfns_filter_bank_t *b, int k)
{
    const float dof = b->cons_dof[k];
    return dof > 0.0f ? (b->cons_nis[k] - dof) / sqrtf(2.0f * dof) : 0.0f;
}

static int excl_index(const mfns_filter_bank_t *b, int16_t beacon)
{
    for (int i = 0; i < MFNS_BANK_MAX_EXCLUDED_BEACONS; i++) {
        if (b->excl_beacon[i] == beacon && beacon != NO_BEACON) {
            return i;
        }
    }
    return -1;
}

bool mfns_bank_beacon_excluded(const mfns_filter_bank_t *b, int16_t beacon)
{
    return b != NULL && excl_index(b, beacon) >= 0;
}

bool mfns_bank_camera_excluded(const mfns_filter_bank_t *b, int cam)
{
    return b != NULL && cam >= 0 && cam < MFNS_NUM_CAMERAS && b->cam_excluded[cam] != 0U;
}

static int slot_of(const mfns_filter_bank_t *b, int16_t beacon)
{
    for (int i = 0; i < MFNS_BANK_MAX_BEACON_HYP; i++) {
        if (b->slot_beacon[i] == beacon) {
            return i;
        }
    }
    return -1;
}

/* The largest relative variance b's data still holds in the full filter:
 * max_j (P_k - P_0)_jj / P_0_jj over the pose axes. */
static float residual_influence(const mfns_filter_t *full, const mfns_filter_t *sub)
{
    float m = 0.0f;
    for (int j = 0; j < MFNS_BANK_AXES; j++) {
        const float p0 = full->P[j][j];
        const float d = sub->P[j][j] - p0;
        m = fmaxf(m, p0 > 0.0f ? d / p0 : INFINITY);
    }
    return m;
}

/* A slot for a beacon seen for the first time (since its last eviction):
 * a free one, else one whose beacon is out of view this cycle and whose
 * effect has decayed; -1 when none. */
static int new_slot(mfns_filter_bank_t *b)
{
    for (int i = 0; i < MFNS_BANK_MAX_BEACON_HYP; i++) {
        if (b->slot_beacon[i] == NO_BEACON) {
            return i;
        }
    }
    for (int i = 0; i < MFNS_BANK_MAX_BEACON_HYP; i++) {
        if (b->slot_seen[i] == 0U &&
            residual_influence(&b->full, &b->sub[MFNS_BANK_CAM_HYP + i]) <= MFNS_BANK_EVICT_RATIO) {
            return i;
        }
    }
    return -1;
}

/* An excluded beacon or camera's observation: tested against the full
 * filter, never applied. */
static mfns_filter_status_t test_held(mfns_filter_bank_t *b, const mfns_filter_settings_t *fs,
                                      const mfns_rig_t *rig, float sigma_px, const mfns_filter_obs_t *obs,
                                      int excl, bool cam_held)
{
    float nis = 0.0f;
    const mfns_filter_status_t st = mfns_filter_test(&b->full, fs, rig, sigma_px, obs, &nis);
    b->work++;
    if (st == MFNS_FILTER_E_ARG) {
        return st;
    }
    const bool clean = st == MFNS_FILTER_OK && nis <= -2.0f * logf(MFNS_BANK_READMIT_P);
    if (cam_held) {
        /* a camera is judged on its whole frame: sum of NIS against chi-square(2n) */
        b->cam_held_nis[obs->cam] += st == MFNS_FILTER_OK ? nis : INFINITY;
        b->cam_held_dof[obs->cam] = (uint16_t)(b->cam_held_dof[obs->cam] + 2U);
    }
    if (excl >= 0) {
        b->excl_beacon_tested[excl] = 1;
        b->excl_beacon_dirty[excl] = (uint8_t)(b->excl_beacon_dirty[excl] | (clean ? 0U : 1U));
    }
    if (cam_held) {
        b->cam_tested[obs->cam] = 1;
    }
    return MFNS_FILTER_OK;
}

static bool exclude(mfns_filter_bank_t *b, int k);

/* The beacon slot of an observation about to be used, started just before
 * its first update; -1 when no slot is free (counted). */
static int use_slot(mfns_filter_bank_t *b, int16_t beacon)
{
    int slot = slot_of(b, beacon);
    if (slot < 0) {
        slot = new_slot(b);
        if (slot < 0) {
            b->unmonitored_obs++; /* no hypothesis would cover it: nobody uses it */
            return -1;
        }
        b->slot_beacon[slot] = beacon;
        b->slot_gate_run[slot] = 0;
        start_hypothesis(b, MFNS_BANK_CAM_HYP + slot);
    }
    b->slot_seen[slot] = 1;
    return slot;
}

/* One observation to the full filter and every subset but its beacon's and
 * its camera's (which takes the frame at its end, mfns_bank_observe_frame);
 * *applied: the full filter took it. */
static mfns_filter_status_t observe_one(mfns_filter_bank_t *b, const mfns_filter_settings_t *fs,
                                        const mfns_rig_t *rig, float sigma_px, int16_t beacon,
                                        const mfns_filter_obs_t *obs, bool *applied)
{
    *applied = false;
    const int excl = excl_index(b, beacon);
    const bool cam_held = b->cam_excluded[obs->cam] != 0U;
    if (excl >= 0 || cam_held) {
        return test_held(b, fs, rig, sigma_px, obs, excl, cam_held);
    }
    const int slot = use_slot(b, beacon);
    if (slot < 0) {
        return MFNS_FILTER_OK;
    }
    mfns_filter_update_info_t info;
    const mfns_filter_status_t st = mfns_filter_update(&b->full, fs, rig, sigma_px, obs, &info);
    b->work++;
    if (st == MFNS_FILTER_GATED) {
        b->cam_gated[obs->cam]++;
        b->slot_gated[slot] = 1;
    } else if (st == MFNS_FILTER_OK) {
        b->cam_passed[obs->cam]++;
        b->slot_passed[slot] = 1;
        b->frame_nis[obs->cam] += info.nis;
        b->frame_dof[obs->cam] = (uint16_t)(b->frame_dof[obs->cam] + 2U);
    } else {
        return st;
    }
    if (st == MFNS_FILTER_GATED) {
        return st; /* the full filter's gate decides for every subset */
    }
    *applied = true;
    for (int k = 0; k < MFNS_BANK_MAX_HYP; k++) {
        /* a camera's hypothesis takes its own camera's frame as a whole, its
         * fault parameters eliminated (mfns_filter_update_invariant) */
        const bool skip = k < MFNS_BANK_CAM_HYP ? k == (int)obs->cam
                                                : (b->slot_beacon[k - MFNS_BANK_CAM_HYP] == NO_BEACON ||
                                                   k - MFNS_BANK_CAM_HYP == slot);
        if (skip) {
            continue;
        }
        /* ungated: the same data as the full filter but its hypothesis's; a
         * coasted camera subset that cannot follow any more (E_TIME) shows in
         * evaluate */
        (void)mfns_filter_update_ungated(&b->sub[k], fs, rig, sigma_px, obs, NULL);
        b->work++;
    }
    return st;
}

/* The frame's observations that fail the gate against filter f's
 * prediction (excluded beacons not counted). */
static mfns_filter_status_t frame_fails(mfns_filter_bank_t *b, const mfns_filter_t *f,
                                        const mfns_filter_settings_t *fs, const mfns_rig_t *rig, float sigma_px,
                                        int n, const int16_t beacon[], const mfns_filter_obs_t obs[], int *fails)
{
    const float gate = mfns_filter_gate_nis(fs);
    *fails = 0;
    for (int i = 0; i < n; i++) {
        if (excl_index(b, beacon[i]) >= 0) {
            continue;
        }
        float nis = 0.0f;
        const mfns_filter_status_t st = mfns_filter_test(f, fs, rig, sigma_px, &obs[i], &nis);
        b->work++;
        if (st == MFNS_FILTER_E_TIME || st == MFNS_FILTER_E_ARG) {
            return st;
        }
        *fails += (st != MFNS_FILTER_OK || !(nis <= gate)) ? 1 : 0;
    }
    return MFNS_FILTER_OK;
}

static void separation(const mfns_filter_t *f0, const mfns_filter_t *fk, float s[6]);

/* Has camera c's data pulled the full filter off its subset: a separation
 * beyond the gate's own level, sqrt(gate NIS) per axis, at t_us. A subset
 * merely too uncertain to judge a frame is not blamed for it. */
static bool pulled_by(mfns_filter_bank_t *b, const mfns_filter_settings_t *fs, int c, int64_t t_us)
{
    mfns_filter_t f0 = b->full, fk = b->sub[c]; /* 2 x 1.2 KB of stack, propagated copies */
    if (mfns_filter_propagate(&f0, fs, t_us) != MFNS_FILTER_OK ||
        mfns_filter_propagate(&fk, fs, t_us) != MFNS_FILTER_OK) {
        return false;
    }
    b->work += 3U;
    float s[6];
    separation(&f0, &fk, s);
    const float k = sqrtf(mfns_filter_gate_nis(fs));
    for (int j = 0; j < MFNS_BANK_AXES; j++) {
        const float p0 = f0.P[j][j];
        const float v = fmaxf(fk.P[j][j] - p0, fmaxf(MFNS_BANK_VAR_FLOOR_REL * p0, b->var_floor[j]));
        if (fabsf(s[j]) > k * sqrtf(v)) {
            return true;
        }
    }
    return false;
}

mfns_filter_status_t mfns_bank_doubt_timing(mfns_filter_bank_t *b, int cam, float resolve_s)
{
    if (b == NULL || b->initialised == 0U || cam < 0 || cam >= MFNS_NUM_CAMERAS || !(resolve_s > 0.0f) ||
        !(resolve_s <= MFNS_FILTER_CONSIDER_TAU_MAX_S)) {
        return MFNS_FILTER_E_ARG;
    }
    b->timing_doubt[cam] = 1;
    b->timing_clean[cam] = 0;
    b->timing_resolve_s[cam] = resolve_s;
    return MFNS_FILTER_OK;
}

/* A frame of a camera whose clock is in doubt (mfns_bank_doubt_timing):
 * timing-free in every filter, gated as a whole on the full filter's rows,
 * the clock read. Excluded beacons' observations are left out untested (a
 * clock in doubt tests nothing for re-admission). */
static mfns_filter_status_t observe_timing_free(mfns_filter_bank_t *b, const mfns_filter_settings_t *fs,
                                                const mfns_rig_t *rig, float sigma_px, int n,
                                                const int16_t beacon[], const mfns_filter_obs_t obs[])
{
    const int cam = obs[0].cam;
    mfns_filter_obs_t use[MFNS_MAX_OBS_PER_CAMERA];
    int8_t slot_of_use[MFNS_MAX_OBS_PER_CAMERA];
    int m = 0;
    for (int i = 0; i < n; i++) {
        if (excl_index(b, beacon[i]) >= 0) {
            continue;
        }
        const int slot = use_slot(b, beacon[i]);
        if (slot >= 0) {
            use[m] = obs[i];
            slot_of_use[m] = (int8_t)slot;
            m++;
        }
    }
    if (m == 0) {
        return MFNS_FILTER_OK;
    }
    /* the full filter's velocity before the frame gives every filter the one
     * direction to eliminate (nav_filter.h): they take the same functionals */
    const mfns_filter_t ref = b->full;
    mfns_filter_t g = b->full; /* the frame tested as a whole before the full filter takes it */
    mfns_filter_invariant_info_t info;
    mfns_filter_status_t st =
        mfns_filter_update_timing_free(&g, fs, rig, sigma_px, m, use, &ref, b->timing_resolve_s[cam], &info);
    b->work++;
    if (st == MFNS_FILTER_E_TIME || st == MFNS_FILTER_E_ARG) {
        return st;
    }
    if (st != MFNS_FILTER_OK) {
        return MFNS_FILTER_OK; /* a degenerate fit: less data, never a fault in */
    }
    if (info.rows > 0U && !(info.nis <= mfns_filter_chi2_quantile((float)info.rows, fs->gate_p))) {
        b->cam_gated[cam] = (uint16_t)(b->cam_gated[cam] + (uint16_t)m);
        b->frame_rejected[cam] = 1;
        return MFNS_FILTER_GATED;
    }
    b->full = g;
    b->cam_passed[cam] = (uint16_t)(b->cam_passed[cam] + (uint16_t)m);
    b->frame_nis[cam] += info.nis;
    b->frame_dof[cam] = (uint16_t)(b->frame_dof[cam] + info.rows);
    for (int i = 0; i < m; i++) {
        b->slot_passed[slot_of_use[i]] = 1;
    }
    const float dev = fabsf(info.tau_s);
    if (!(dev <= MFNS_BANK_TIMING_K * info.tau_sigma_s)) {
        b->timing_read[cam] = 2; /* dirty, whatever the power (a NaN reading too) */
    } else if (MFNS_BANK_TIMING_K * info.tau_sigma_s <= b->timing_resolve_s[cam] && b->timing_read[cam] == 0U) {
        b->timing_read[cam] = 1;
    }
    /* every subset: a camera's own hypothesis as always (its pointing and
     * timing eliminated), the others timing-free, each beacon's without its
     * beacon */
    for (int k = 0; k < MFNS_BANK_MAX_HYP; k++) {
        if (k < MFNS_BANK_CAM_HYP) {
            st = k == cam ? mfns_filter_update_invariant(&b->sub[k], fs, rig, sigma_px, m, use, NULL)
                          : mfns_filter_update_timing_free(&b->sub[k], fs, rig, sigma_px, m, use, &ref, 0.0f, NULL);
        } else {
            const int slot = k - MFNS_BANK_CAM_HYP;
            if (b->slot_beacon[slot] == NO_BEACON) {
                continue;
            }
            mfns_filter_obs_t rest[MFNS_MAX_OBS_PER_CAMERA];
            int r = 0;
            for (int i = 0; i < m; i++) {
                if (slot_of_use[i] != slot) {
                    rest[r++] = use[i];
                }
            }
            if (r == 0) {
                continue;
            }
            st = mfns_filter_update_timing_free(&b->sub[k], fs, rig, sigma_px, r, rest, &ref, 0.0f, NULL);
        }
        b->work++;
        if (st == MFNS_FILTER_E_ARG) {
            return st;
        }
        /* the full filter's offset term (nav_filter.h tau_bound_s), the
         * same in every filter: the term is one error common to all (the
         * offset times the reference velocity's error), so the separations'
         * covariance P_k - P_0 is left as the data made it (each filter's
         * own term differs from the full filter's by its gains, and a
         * subset whose term came out smaller failed its separation test on
         * a healthy camera: test_filter_bank's dropped frame) */
        if (st == MFNS_FILTER_OK && !mfns_filter_add_cov(&b->sub[k], info.added_cov)) {
            return MFNS_FILTER_E_ARG;
        }
        /* E_TIME (a subset that coasted too long) shows in evaluate; E_GEOM
         * leaves that subset unupdated: less data, never a fault in */
    }
    return MFNS_FILTER_OK;
}

mfns_filter_status_t mfns_bank_observe_frame(mfns_filter_bank_t *b, const mfns_filter_settings_t *fs,
                                             const mfns_rig_t *rig, float sigma_px, int n, const int16_t beacon[],
                                             const mfns_filter_obs_t obs[])
{
    if (b == NULL || b->initialised == 0U || !mfns_filter_settings_valid(fs) || rig == NULL || n < 0 ||
        n > MFNS_MAX_OBS_PER_CAMERA || (n > 0 && (beacon == NULL || obs == NULL))) {
        return MFNS_FILTER_E_ARG;
    }
    for (int i = 0; i < n; i++) {
        if (beacon[i] < 0 || beacon[i] >= MFNS_MAX_BEACONS || obs[i].cam != obs[0].cam ||
            obs[i].cam >= MFNS_NUM_CAMERAS || obs[i].t_us != obs[0].t_us) {
            return MFNS_FILTER_E_ARG;
        }
    }
    if (n == 0) {
        return MFNS_FILTER_OK;
    }
    const int cam = obs[0].cam;
    if (b->timing_doubt[cam] != 0U && b->cam_excluded[cam] == 0U) {
        return observe_timing_free(b, fs, rig, sigma_px, n, beacon, obs);
    }
    /* the frame against the prediction, before any of it is applied: a
     * single beacon fault fails one observation of a frame, a camera fault
     * (pointing, a late frame) or a robot beyond the motion bound fails
     * several, and a frame applied one by one would pull the filter toward
     * its first observations before the rest could be seen to disagree */
    int fails = 0;
    if (b->cam_excluded[cam] == 0U) {
        mfns_filter_status_t st = frame_fails(b, &b->full, fs, rig, sigma_px, n, beacon, obs, &fails);
        if (st != MFNS_FILTER_OK) {
            return st;
        }
        /* Who is wrong: this frame, or a camera whose frame the full filter
         * took before and that pulled it off? The camera subsets answer: a
         * frame consistent with the subset that never took camera c' names
         * c' (a late or moved camera seen first in the cycle). At most one
         * such exclusion per cycle. */
        for (int c = 0; c < MFNS_NUM_CAMERAS && fails >= 2 && b->det_kind == MFNS_BANK_HYP_NONE; c++) {
            int f2 = 0;
            if (c == cam || b->cam_excluded[c] != 0U || !pulled_by(b, fs, c, obs[0].t_us) ||
                frame_fails(b, &b->sub[c], fs, rig, sigma_px, n, beacon, obs, &f2) != MFNS_FILTER_OK || f2 >= 2) {
                continue;
            }
            if (exclude(b, c)) {
                b->det_by_gate = 1;
                st = frame_fails(b, &b->full, fs, rig, sigma_px, n, beacon, obs, &fails);
                if (st != MFNS_FILTER_OK) {
                    return st;
                }
            }
        }
    }
    if (fails >= 2) {
        b->cam_gated[cam] = (uint16_t)(b->cam_gated[cam] + (uint16_t)fails);
        b->frame_rejected[cam] = 1;
        for (int i = 0; i < n; i++) {
            const int slot = slot_of(b, beacon[i]);
            if (slot >= 0) {
                b->slot_seen[slot] = 1; /* in view: not evicted */
            }
        }
        return MFNS_FILTER_GATED;
    }
    /* the frame's usable observations first, then the held ones tested
     * against the filter they updated: a test at the start of a frame has
     * the whole inter-frame process noise in it (0.8 px at the default
     * bound), one after the frame's other beacons has not */
    mfns_filter_status_t worst = MFNS_FILTER_OK;
    mfns_filter_obs_t took[MFNS_MAX_OBS_PER_CAMERA];
    int n_took = 0;
    for (int pass = 0; pass < 2; pass++) {
        for (int i = 0; i < n; i++) {
            const bool held = excl_index(b, beacon[i]) >= 0 || b->cam_excluded[cam] != 0U;
            if (held != (pass == 1)) {
                continue;
            }
            bool applied = false;
            const mfns_filter_status_t st = observe_one(b, fs, rig, sigma_px, beacon[i], &obs[i], &applied);
            if (st == MFNS_FILTER_E_TIME || st == MFNS_FILTER_E_ARG) {
                return st;
            }
            worst = st != MFNS_FILTER_OK ? st : worst;
            if (applied) {
                took[n_took++] = obs[i];
            }
        }
    }
    /* the camera's hypothesis: what the full filter took of the frame, with
     * the camera's pointing and timing eliminated (its subset then moves
     * with no value of them); a frame of one or two beacons leaves it
     * coasting. E_GEOM (a degenerate fit) leaves it unupdated: less data,
     * never a fault in. */
    if (n_took > 0) {
        const mfns_filter_status_t st =
            mfns_filter_update_invariant(&b->sub[cam], fs, rig, sigma_px, n_took, took, NULL);
        b->work++;
        if (st == MFNS_FILTER_E_TIME || st == MFNS_FILTER_E_ARG) {
            return st;
        }
    }
    return worst;
}

/* The separation x_0 - x_k on the pose axes (attitude rad: C_b_w0 =
 * exp(s) C_b_wk; position mm). */
static void separation(const mfns_filter_t *f0, const mfns_filter_t *fk, float s[6])
{
    mfns_m3_t ct, d;
    mfns_m3_transpose_at(&f0->C_w_b, &ct);
    mfns_m3_mul_at(&ct, &fk->C_w_b, &d); /* C_b_w0 C_w_bk */
    const mfns_v3_t a = mfns_rot_log(d);
    s[0] = a.x;
    s[1] = a.y;
    s[2] = a.z;
    s[3] = f0->r_wb_w.x - fk->r_wb_w.x;
    s[4] = f0->r_wb_w.y - fk->r_wb_w.y;
    s[5] = f0->r_wb_w.z - fk->r_wb_w.z;
}


/* After an exclusion the full filter (the chosen subset) restarts from its
 * own state under the start's diffuse prior (MFNS_BANK_START_SIGMA_*,
 * MFNS_BANK_SIGMA_V0_MM_S, _W0_RAD_S; its own variance where larger), and
 * every hypothesis then starts as a copy of it. Why not the subset as it is:
 * when the subject was named wrongly (a healthy beacon of a knocked or
 * drifting camera gated first) the subset took the fault, a copy of it would
 * too, and the copies' separations would start at zero: the PL, the observed
 * separation's (integrity.h mfns_integrity_pl_axis), would not see what is
 * already in the state (a ramp on one of two cameras with the other camera
 * named: a usable fix 1.05 x its PL, test_filter_bank). From the diffuse
 * prior every filter rests on the observations it takes from here on, as at
 * a start (nav_filter_cycle.h); the cost is the cycles the PL needs to come
 * back under the alert limit. The innovation window goes with the old state. */
static bool restart_diffuse(mfns_filter_bank_t *b)
{
    const mfns_filter_t *f = &b->full;
    const mfns_pose_t pose = mfns_filter_pose(f);
    float var_ros[6], prior[6][6]; /* cov_ros order: position first */
    float sv = MFNS_BANK_SIGMA_V0_MM_S, sw = MFNS_BANK_SIGMA_W0_RAD_S;
    for (int i = 0; i < 3; i++) {
        var_ros[i] = f->P[MFNS_FILTER_POS + i][MFNS_FILTER_POS + i];
        var_ros[3 + i] = f->P[MFNS_FILTER_ATT + i][MFNS_FILTER_ATT + i];
        sv = fmaxf(sv, sqrtf(fmaxf(f->P[MFNS_FILTER_VEL + i][MFNS_FILTER_VEL + i], 0.0f)));
        sw = fmaxf(sw, sqrtf(fmaxf(f->P[MFNS_FILTER_OMEGA + i][MFNS_FILTER_OMEGA + i], 0.0f)));
    }
    mfns_bank_diffuse_prior(var_ros, prior);
    mfns_filter_t g;
    if (mfns_filter_init(&g, &pose, (const float(*)[6])prior, f->v_w, sv, f->w_w, sw, f->t_us) != MFNS_FILTER_OK) {
        return false;
    }
    b->full = g;
    for (int j = 0; j < MFNS_BANK_AXES; j++) {
        b->var_floor[j] = MFNS_BANK_VAR_FLOOR_EPS * FLT_EPSILON * b->full.P[j][j];
    }
    return true;
}

/* Exclude hypothesis k (sub index): the full filter becomes its subset. */
static bool exclude(mfns_filter_bank_t *b, int k)
{
    if (k < MFNS_BANK_CAM_HYP) {
        b->cam_excluded[k] = 1;
        b->cam_clean[k] = 0;
        b->det_kind = MFNS_BANK_HYP_CAMERA;
        b->det_id = (int16_t)k;
    } else {
        const int slot = k - MFNS_BANK_CAM_HYP;
        const int16_t beacon = b->slot_beacon[slot];
        int e = -1;
        for (int i = 0; i < MFNS_BANK_MAX_EXCLUDED_BEACONS && e < 0; i++) {
            e = b->excl_beacon[i] == NO_BEACON ? i : -1;
        }
        b->det_kind = MFNS_BANK_HYP_BEACON;
        b->det_id = beacon;
        if (e < 0) {
            return false; /* no room to hold it out: FAULT_DETECTED */
        }
        b->excl_beacon[e] = beacon;
        b->excl_beacon_clean[e] = 0;
        b->slot_beacon[slot] = NO_BEACON;
    }
    b->full = b->sub[k];
    mfns_filter_strip_aug(&b->full); /* the camera is held out: its fault parameters are not needed */
    if (!restart_diffuse(b)) {
        return false;
    }
    restart_hypotheses(b);
    for (int i = 0; i < MFNS_BANK_MAX_BEACON_HYP; i++) {
        b->slot_gate_run[i] = 0;
    }
    return true;
}

/* Re-admission after hold consecutive clean cycles of tests. */
static void readmit(mfns_filter_bank_t *b, uint16_t hold, mfns_bank_output_t *out)
{
    for (int i = 0; i < MFNS_BANK_MAX_EXCLUDED_BEACONS; i++) {
        if (b->excl_beacon[i] == NO_BEACON || b->excl_beacon_tested[i] == 0U) {
            continue;
        }
        b->excl_beacon_clean[i] = b->excl_beacon_dirty[i] != 0U ? 0U : (uint16_t)(b->excl_beacon_clean[i] + 1U);
        if (b->excl_beacon_clean[i] >= hold) {
            out->readmitted_beacon = b->excl_beacon[i];
            b->excl_beacon[i] = NO_BEACON;
        }
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        if (b->cam_excluded[c] == 0U || b->cam_tested[c] == 0U) {
            continue;
        }
        const bool clean =
            b->cam_held_nis[c] <= mfns_filter_chi2_quantile((float)b->cam_held_dof[c], MFNS_BANK_READMIT_P);
        b->cam_dirty[c] = (uint8_t)(clean ? 0U : 1U);
        b->cam_clean[c] = b->cam_dirty[c] != 0U ? 0U : (uint16_t)(b->cam_clean[c] + 1U);
        if (b->cam_clean[c] >= hold) {
            out->readmitted_camera = (int8_t)c;
            b->cam_excluded[c] = 0;
            start_hypothesis(b, c); /* its hypothesis starts afresh */
        }
    }
}

/* A subject named by the full filter's gate this cycle: sub index or -1. */
static int gate_subject(const mfns_filter_bank_t *b, uint8_t *by_gate)
{
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        bool other_passed = false;
        for (int o = 0; o < MFNS_NUM_CAMERAS; o++) {
            other_passed = other_passed || (o != c && b->cam_passed[o] > 0U);
        }
        if (b->cam_gated[c] >= 2U && other_passed) {
            *by_gate = 1;
            return c;
        }
    }
    for (int i = 0; i < MFNS_BANK_MAX_BEACON_HYP; i++) {
        if (b->slot_beacon[i] != NO_BEACON && b->slot_gate_run[i] >= MFNS_BANK_GATE_EXCLUDE_RUN) {
            *by_gate = 1;
            return MFNS_BANK_CAM_HYP + i;
        }
    }
    return -1;
}

typedef struct {
    float pl[MFNS_BANK_AXES];
    float pl_b[MFNS_BANK_AXES]; /* fault-free and beacon hypotheses only */
    float max_ns;
    int worst;
    uint16_t nh, unmon;
    bool failed[MFNS_BANK_MAX_HYP];
} sep_eval_t;

static void evaluate_sep(mfns_filter_bank_t *b, const mfns_integrity_settings_t *is, const float dvar[6],
                         const bool active[MFNS_BANK_MAX_HYP], const bool ok[MFNS_BANK_MAX_HYP],
                         mfns_bank_output_t *out, sep_eval_t *ev)
{
    ev->nh = 0;
    ev->unmon = 0;
    for (int k = 0; k < MFNS_BANK_MAX_HYP; k++) {
        ev->nh = (uint16_t)(ev->nh + (active[k] ? 1U : 0U));
        ev->unmon = (uint16_t)(ev->unmon + (active[k] && !ok[k] ? 1U : 0U));
    }
    out->k_fa = mfns_integrity_q_inv(is->p_fa / (2.0f * (float)MFNS_BANK_AXES * (float)(ev->nh > 0 ? ev->nh : 1)));
    out->k_md = mfns_integrity_q_inv(is->p_md);
    const float k_ff = mfns_integrity_q_inv(0.5f * is->p_md);
    for (int j = 0; j < MFNS_BANK_AXES; j++) {
        ev->pl[j] = k_ff * sqrtf(fmaxf(b->full.P[j][j] + dvar[j], 0.0f));
        ev->pl_b[j] = ev->pl[j];
    }
    ev->max_ns = 0.0f;
    ev->worst = -1;
    for (int k = 0; k < MFNS_BANK_MAX_HYP; k++) {
        ev->failed[k] = false;
        if (!active[k]) {
            continue;
        }
        if (!ok[k]) {
            for (int j = 0; j < MFNS_BANK_AXES; j++) {
                ev->pl[j] = INFINITY;
                ev->pl_b[j] = k < MFNS_BANK_CAM_HYP ? ev->pl_b[j] : INFINITY;
            }
            continue;
        }
        float s[6];
        separation(&b->full, &b->sub[k], s);
        b->work++;
        for (int j = 0; j < MFNS_BANK_AXES; j++) {
            const float p0 = b->full.P[j][j];
            const float vss = fmaxf(b->sub[k].P[j][j] - p0, fmaxf(MFNS_BANK_VAR_FLOOR_REL * p0, b->var_floor[j]));
            const float t = out->k_fa * sqrtf(vss);
            const float ns = fabsf(s[j]) / t;
            ev->failed[k] = ev->failed[k] || ns > 1.0f;
            if (ns > ev->max_ns) {
                ev->max_ns = ns;
                ev->worst = k;
            }
            /* every subset is unmoved by its hypothesis's fault (a
             * beacon's never took the beacon, a camera's took its frames
             * with the camera's pointing and timing eliminated): the
             * observed separation's bound (integrity.h) */
            const float var_k = b->sub[k].P[j][j] + dvar[j];
            const float plk = mfns_integrity_pl_axis(s[j], var_k, k_ff);
            ev->pl[j] = fmaxf(ev->pl[j], plk);
            ev->pl_b[j] = k < MFNS_BANK_CAM_HYP ? ev->pl_b[j] : fmaxf(ev->pl_b[j], plk);
        }
    }
}

/* The hypothesis that explains a failed innovation window: the most
 * consistent active subset, if consistent (z <= MFNS_BANK_EXPLAIN_Z); a
 * beacon preferred to a camera as in attribute(). -1: none does. */
static int explain(const mfns_filter_bank_t *b)
{
    int best_b = -1, best_c = -1;
    float zb = INFINITY, zc = INFINITY;
    for (int k = 0; k < MFNS_BANK_MAX_HYP; k++) {
        const bool active = k < MFNS_BANK_CAM_HYP ? b->cam_excluded[k] == 0U
                                                  : b->slot_beacon[k - MFNS_BANK_CAM_HYP] != NO_BEACON;
        if (!active || !(b->cons_dof[k] >= MFNS_BANK_CONSIST_MIN_DOF)) {
            continue;
        }
        const float z = consistency_z(b, k);
        if (k < MFNS_BANK_CAM_HYP && z < zc) {
            zc = z;
            best_c = k;
        } else if (k >= MFNS_BANK_CAM_HYP && z < zb) {
            zb = z;
            best_b = k;
        }
    }
    if (best_c >= 0 && (best_b < 0 || zc < zb - MFNS_BANK_CAMERA_PREF_Z)) {
        return zc <= MFNS_BANK_EXPLAIN_Z ? best_c : -1;
    }
    return best_b >= 0 && zb <= MFNS_BANK_EXPLAIN_Z ? best_b : -1;
}

/* The subject of a failed separation test (MFNS_BANK_CONSIST_FORGET). */
static int attribute(const mfns_filter_bank_t *b, const sep_eval_t *ev, const bool ok[MFNS_BANK_MAX_HYP])
{
    int best_b = -1, best_c = -1;
    float zb = INFINITY, zc = INFINITY;
    for (int k = 0; k < MFNS_BANK_MAX_HYP; k++) {
        /* a camera's subset is a candidate whether or not its own test
         * failed: it is the one subset a camera fault leaves where it was,
         * and its test has the least power (it lost the camera's pointing
         * and timing), so another subset's test often fails first */
        if ((!ev->failed[k] && !(k < MFNS_BANK_CAM_HYP && ok[k])) || !(b->cons_dof[k] >= MFNS_BANK_CONSIST_MIN_DOF)) {
            continue;
        }
        const float z = consistency_z(b, k);
        if (k < MFNS_BANK_CAM_HYP && z < zc) {
            zc = z;
            best_c = k;
        } else if (k >= MFNS_BANK_CAM_HYP && z < zb) {
            zb = z;
            best_b = k;
        }
    }
    if (best_b < 0) {
        return best_c;
    }
    if (best_c >= 0 && zc < zb - MFNS_BANK_CAMERA_PREF_Z) {
        return best_c;
    }
    return best_b;
}

/* The camera whose frame, taken by the full filter this cycle, is beyond
 * the FRAME_SUSPECT point (filter_bank.h), the most unlikely; -1 none. */
static int suspect_frame(const mfns_filter_bank_t *b)
{
    int worst = -1;
    float worst_ratio = 1.0f;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        if (b->frame_dof[c] == 0U) {
            continue;
        }
        const float dof = (float)b->frame_dof[c];
        /* two degrees of freedom: the exact point (the quantile's approximation is for dof >= 4) */
        const float q = b->frame_dof[c] <= 2U ? -2.0f * logf(MFNS_BANK_FRAME_SUSPECT_P)
                                               : mfns_filter_chi2_quantile(dof, MFNS_BANK_FRAME_SUSPECT_P);
        const float ratio = b->frame_nis[c] / q;
        if (!(ratio <= worst_ratio)) { /* a NaN sum is suspect too */
            worst = c;
            worst_ratio = isfinite(ratio) ? ratio : INFINITY;
        }
    }
    return worst;
}

mfns_filter_status_t mfns_bank_suspect_frame(mfns_filter_bank_t *b, int cam)
{
    if (b == NULL || cam < 0 || cam >= MFNS_NUM_CAMERAS) {
        return MFNS_FILTER_E_ARG;
    }
    b->told_suspect = (int8_t)cam;
    return MFNS_FILTER_OK;
}

/* Bit c: camera c's clock in doubt. */
static uint8_t doubt_mask(const mfns_filter_bank_t *b)
{
    unsigned m = 0U;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        m |= b->timing_doubt[c] != 0U ? 1U << c : 0U;
    }
    return (uint8_t)m;
}

mfns_filter_status_t mfns_bank_evaluate(mfns_filter_bank_t *b, const mfns_filter_settings_t *fs,
                                        const mfns_integrity_settings_t *is, const mfns_map_datum_t *datum,
                                        int64_t t_us, mfns_bank_output_t *out)
{
    if (out == NULL) {
        return MFNS_FILTER_E_ARG;
    }
    memset(out, 0, sizeof(*out));
    out->status = MFNS_POSE_NO_FIX;
    out->reason = MFNS_POSE_R_BAD_ARG;
    out->readmitted_beacon = NO_BEACON;
    out->readmitted_camera = -1;
    out->timing_trusted = -1;
    out->suspect_camera = -1;
    out->detected_id = NO_BEACON;
    if (b == NULL || b->initialised == 0U || !mfns_filter_settings_valid(fs) || is == NULL ||
        !mfns_integrity_settings_valid(is)) {
        return MFNS_FILTER_E_ARG;
    }
    out->timing_doubt_mask = doubt_mask(b); /* as it stands, should this cycle end early */
    /* Two cameras against the prediction in one cycle are the motion (a
     * single beacon or camera fault fails one camera): two frames failed as
     * a whole (two or more observations each, not applied), or one such
     * frame and another camera whose every observation failed the gate (a
     * camera with one beacon in view can fail no other way). Not two
     * cameras that failed only beacon by beacon: a dominant camera's late
     * frame, applied, pulls the full filter, and the next cameras' single
     * beacons then fail against it (the camera subsets name that camera). */
    int rejected = 0, cams_all_gated = 0;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        rejected += b->frame_rejected[c] != 0U ? 1 : 0;
        cams_all_gated += b->frame_rejected[c] == 0U && b->cam_gated[c] > 0U && b->cam_passed[c] == 0U ? 1 : 0;
    }
    if (rejected >= 2 || (rejected == 1 && cams_all_gated >= 1)) {
        b->full.motion_exceeded = 1;
    }
    const mfns_filter_status_t st = mfns_filter_propagate(&b->full, fs, t_us);
    b->work++;
    const uint8_t motion_before = b->full.motion_exceeded;
    const bool window_failed = mfns_filter_end_cycle(&b->full, fs); /* the windowed motion test */
    for (int k = 0; k < MFNS_BANK_MAX_HYP; k++) {
        b->cons_nis[k] = MFNS_BANK_CONSIST_FORGET * b->cons_nis[k] + b->sub[k].cyc_nis;
        b->cons_dof[k] = MFNS_BANK_CONSIST_FORGET * b->cons_dof[k] + (float)b->sub[k].cyc_dof;
        mfns_filter_reset_window(&b->sub[k]); /* only the full filter's window is tested */
    }
    if (window_failed && motion_before == 0U && st == MFNS_FILTER_OK) {
        /* the full filter's innovations are too large over the window: the
         * motion, or one beacon or camera (a slow ramp the separation has
         * not reached yet). A hypothesis whose subset took all but its
         * data and stayed consistent explains it: exclude that one. */
        const int k = explain(b);
        if (k >= 0 && exclude(b, k)) {
            b->full.motion_exceeded = 0;
        }
    }
    if (st != MFNS_FILTER_OK || b->full.motion_exceeded != 0U) {
        /* the filter cannot vouch for anything: re-acquire */
        out->restart = true;
        out->reason = st == MFNS_FILTER_E_ARG ? MFNS_POSE_R_BAD_ARG
                      : st == MFNS_FILTER_E_TIME ? MFNS_POSE_R_TRACK_LOST
                                                 : MFNS_POSE_R_MOTION_EXCEEDED;
        out->work = b->work;
        clear_cycle(b);
        return st == MFNS_FILTER_E_ARG ? st : MFNS_FILTER_OK;
    }
    for (int i = 0; i < MFNS_BANK_MAX_BEACON_HYP; i++) {
        const bool all_gated = b->slot_gated[i] != 0U && b->slot_passed[i] == 0U;
        b->slot_gate_run[i] = all_gated ? (uint8_t)(b->slot_gate_run[i] < UINT8_MAX ? b->slot_gate_run[i] + 1U
                                                                                   : UINT8_MAX)
                                        : 0U;
    }
    bool active[MFNS_BANK_MAX_HYP], ok[MFNS_BANK_MAX_HYP];
    for (int k = 0; k < MFNS_BANK_MAX_HYP; k++) {
        active[k] = k < MFNS_BANK_CAM_HYP ? b->cam_excluded[k] == 0U
                                          : b->slot_beacon[k - MFNS_BANK_CAM_HYP] != NO_BEACON;
        ok[k] = active[k] && mfns_filter_propagate(&b->sub[k], fs, t_us) == MFNS_FILTER_OK;
        b->work += active[k] ? 1U : 0U;
    }
    out->pose = mfns_filter_pose(&b->full);
    float d[6][6], dvar[6];
    mfns_filter_datum_cov(&out->pose, datum, d);
    for (int j = 0; j < 6; j++) {
        dvar[j] = d[j][j];
    }
    sep_eval_t ev;
    evaluate_sep(b, is, dvar, active, ok, out, &ev);
    out->max_norm_sep = ev.max_ns;
    bool excl_failed = false;
    int subject = b->det_kind != MFNS_BANK_HYP_NONE ? -1 : gate_subject(b, &b->det_by_gate);
    if (subject < 0 && ev.max_ns > 1.0f) {
        subject = attribute(b, &ev, ok);
    }
    if (subject >= 0) {
        excl_failed = !exclude(b, subject);
        for (int k = 0; k < MFNS_BANK_MAX_HYP; k++) {
            active[k] = k < MFNS_BANK_CAM_HYP ? b->cam_excluded[k] == 0U
                                              : b->slot_beacon[k - MFNS_BANK_CAM_HYP] != NO_BEACON;
            ok[k] = active[k];
        }
        out->pose = mfns_filter_pose(&b->full);
        evaluate_sep(b, is, dvar, active, ok, out, &ev);
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        if (b->timing_doubt[c] == 0U) {
            continue;
        }
        b->timing_clean[c] = b->timing_read[c] == 2U   ? 0U
                             : b->timing_read[c] == 1U ? (uint16_t)(b->timing_clean[c] + 1U)
                                                       : b->timing_clean[c];
        if (b->timing_clean[c] >= is->hold_cycles && out->timing_trusted < 0) {
            b->timing_doubt[c] = 0;
            b->timing_clean[c] = 0;
            out->timing_trusted = (int8_t)c;
        }
    }
    out->timing_doubt_mask = doubt_mask(b);
    if (b->last_usable != 0U) {
        /* a clean test counts only against a filter that was certified: an
         * uncertain one sees no fault (a camera a frame late passes the test
         * of a filter whose PL is already beyond the alert limit) */
        readmit(b, is->hold_cycles, out);
    }
    /* evict the decayed hypotheses of beacons out of view */
    for (int i = 0; i < MFNS_BANK_MAX_BEACON_HYP; i++) {
        if (b->slot_beacon[i] != NO_BEACON && b->slot_seen[i] == 0U &&
            residual_influence(&b->full, &b->sub[MFNS_BANK_CAM_HYP + i]) <= MFNS_BANK_EVICT_RATIO) {
            b->slot_beacon[i] = NO_BEACON;
        }
    }
    const int own_suspect = suspect_frame(b);
    out->suspect_camera = (int8_t)(own_suspect >= 0 ? own_suspect : b->told_suspect);
    out->detected_kind = b->det_kind;
    out->detected_id = b->det_id;
    out->by_gate = b->det_by_gate;
    mfns_filter_pose_cov_ros(&b->full, datum, out->cov_ros);
    out->hypotheses = ev.nh;
    out->unmonitorable = ev.unmon;
    out->pl_pos_mm = fmaxf(fmaxf(ev.pl[3], ev.pl[4]), ev.pl[5]);
    out->pl_att_deg = fmaxf(fmaxf(ev.pl[0], ev.pl[1]), ev.pl[2]) * MFNS_DEG_PER_RAD_F;
    out->pl_beacon_pos_mm = fmaxf(fmaxf(ev.pl_b[3], ev.pl_b[4]), ev.pl_b[5]);
    out->pl_beacon_att_deg = fmaxf(fmaxf(ev.pl_b[0], ev.pl_b[1]), ev.pl_b[2]) * MFNS_DEG_PER_RAD_F;
    bool held = false;
    for (int i = 0; i < MFNS_BANK_MAX_EXCLUDED_BEACONS; i++) {
        held = held || b->excl_beacon[i] != NO_BEACON;
    }
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        held = held || b->cam_excluded[c] != 0U;
    }
    if (excl_failed) {
        out->reason = MFNS_POSE_R_FAULT_DETECTED;
    } else if (ev.unmon > 0U) {
        out->reason = MFNS_POSE_R_UNMONITORED;
    } else if (!(out->pl_pos_mm <= is->alert_limit_pos_mm && out->pl_att_deg <= is->alert_limit_att_deg)) {
        out->reason = MFNS_POSE_R_PL_EXCEEDS_AL;
    } else if (out->suspect_camera >= 0) {
        out->reason = MFNS_POSE_R_FRAME_SUSPECT;
    } else {
        out->usable = true;
        out->status = held ? MFNS_POSE_DEGRADED : MFNS_POSE_OK;
        out->reason = held ? MFNS_POSE_R_EXCLUDED : MFNS_POSE_R_NONE;
    }
    b->last_usable = out->usable ? 1U : 0U;
    out->work = b->work;
    clear_cycle(b);
    return MFNS_FILTER_OK;
}
