/* frame_health.c -- see frame_health.h. */
#include "firmware/frames/frame_health.h"
#include "math/core_inline.h"

#include <math.h>
#include <string.h>

#define FNV64_OFFSET 0xcbf29ce484222325ull
#define FNV64_PRIME 0x100000001b3ull

static const char *const k_state_names[FH_STATE_COUNT] = {"HEALTHY", "PROBATION", "FROZEN", "CLOCK_FAULT", "LATE",
                                                          "OUT_OF_STEP"};

const char *fh_state_name(fh_state_t s)
{
    return (unsigned)s < (unsigned)FH_STATE_COUNT ? k_state_names[s] : "?";
}

void fh_init(fh_monitor_t *m, unsigned n)
{
    memset(m, 0, sizeof *m);
    m->n = n > FH_MAX_CAMERAS ? FH_MAX_CAMERAS : n;
    for (unsigned k = 0; k < FH_MAX_CAMERAS; k++) {
        m->cam[k].state = FH_HEALTHY;
    }
}

void fh_begin_cycle(fh_monitor_t *m)
{
    for (unsigned k = 0; k < m->n; k++) {
        m->cam[k].present = false;
        m->cam[k].clean_now = false;
    }
}

static int64_t abs64(int64_t v)
{
    return v < 0 ? -v : v;
}

/* |x| in microseconds compared as float: stamps differ by far less than 2^63. */
MFNS_OUT_OF_LINE
static float absf_i64(int64_t v)
{
    return (float)abs64(v);
}

static int64_t round_i64(float v)
{
    return (int64_t)(v < 0.0f ? v - 0.5f : v + 0.5f);
}

/* ---- cadence ------------------------------------------------------------ */

/* Tolerance of a step over ds frames (frame_health.h, CLOCK_FAULT). */
static float step_tol_us(const fh_cam_t *c, uint32_t ds)
{
    const float j = FH_JITTER_FRAC * c->period_us;
    const float span = c->period_span > 0u ? (float)c->period_span : 1.0f;
    return 3.0f * j + 2.0f * j * (float)ds / span;
}

static void learn_restart(fh_cam_t *c)
{
    c->have_anchor = true;
    c->anchor_seq = c->prev_seq;
    c->anchor_t_us = c->prev_t_us;
    c->learn_steps = 0;
}

/* A fault-free step from the previous frame to (seq, t): learning, or the
 * period refined over the longest span. */
static void cadence_clean_step(fh_cam_t *c, uint32_t seq, uint64_t t_us, uint32_t ds, int64_t dt)
{
    if (!c->have_anchor) {
        learn_restart(c);
    }
    const uint32_t span = seq - c->anchor_seq;
    const float est = span > 0u && t_us > c->anchor_t_us ? (float)(t_us - c->anchor_t_us) / (float)span : 0.0f;
    if (!c->period_known) {
        if (c->learn_steps > 0u) {
            const float prior = (float)(c->prev_t_us - c->anchor_t_us) / (float)(c->prev_seq - c->anchor_seq);
            if (absf_i64(dt - round_i64((float)ds * prior)) > FH_LEARN_TOL_FRAC * prior) {
                /* a step that does not fit: learning starts again after it */
                c->anchor_seq = seq;
                c->anchor_t_us = t_us;
                c->learn_steps = 0;
                return;
            }
        }
        c->learn_steps++;
        if (c->learn_steps >= FH_LEARN_STEPS && est > 0.0f) {
            c->period_known = true;
            c->period_us = est;
            c->period_span = span;
        }
        return;
    }
    if (span > c->period_span && est > 0.0f) {
        c->period_us = est;
        c->period_span = span;
    }
}

/* The per-camera clock check; returns the fault (NONE, CLOCK_FAULT) and the
 * measured step in *step_us. */
static fh_state_t check_clock(fh_cam_t *c, const fh_frame_t *f, int32_t ds, int64_t *step_us, bool *rebase)
{
    const int64_t dt = (int64_t)f->capture_us - (int64_t)c->prev_t_us;
    *step_us = dt;
    if (ds > 0 && (uint32_t)ds > FH_MAX_DSEQ) {
        *rebase = true; /* too long a gap to predict: start the cadence again */
        return FH_HEALTHY;
    }
    if (dt <= 0) {
        /* a stamp that does not advance while the sequence does */
        if (c->period_known) {
            *step_us = dt - round_i64((float)ds * c->period_us);
        } else {
            c->corr_unknown = true;
        }
        return FH_CLOCK_FAULT;
    }
    if (!c->period_known) {
        return FH_HEALTHY;
    }
    const int64_t err = dt - round_i64((float)ds * c->period_us);
    *step_us = err;
    return absf_i64(err) > step_tol_us(c, (uint32_t)ds) ? FH_CLOCK_FAULT : FH_HEALTHY;
}

/* Arrival against capture (both on the capture clock); LATE or CLOCK_FAULT. */
static fh_state_t check_arrival(const fh_cam_t *c, const fh_frame_t *f, int64_t *arg)
{
    if (!f->arrival_valid || (f->ts_source != FH_TS_CAPTURE_SOE && f->ts_source != FH_TS_CAPTURE_EOF &&
                              f->ts_source != FH_TS_RECORDED)) {
        return FH_HEALTHY;
    }
    const int64_t t = (int64_t)f->capture_us + c->corr_us;
    const int64_t lat = (int64_t)f->arrival_us - t;
    *arg = lat;
    if (lat < 0) {
        return FH_CLOCK_FAULT; /* stamped after it arrived */
    }
    const float bound = c->period_known ? FH_LATE_PERIODS * c->period_us : (float)FH_LATE_UNLEARNED_US;
    return (float)lat > bound ? FH_LATE : FH_HEALTHY;
}

/* ---- state -------------------------------------------------------------- */

static fh_event_kind_t event_of(fh_state_t fault)
{
    switch (fault) {
    case FH_FROZEN: return FH_EV_FROZEN;
    case FH_CLOCK_FAULT: return FH_EV_CLOCK_JUMP;
    case FH_LATE: return FH_EV_LATE;
    case FH_OUT_OF_STEP: return FH_EV_SEQ_MISMATCH;
    case FH_HEALTHY:
    case FH_PROBATION:
    case FH_STATE_COUNT: break;
    }
    return FH_EV_NONE;
}

/* Camera c enters (or stays in) fault; an event when it was not already there. */
static fh_event_t enter_fault(fh_cam_t *c, fh_state_t fault, int64_t a0, int64_t a1)
{
    fh_event_t ev = {FH_EV_NONE, a0, a1};
    /* an event on entering a fault; an OUT_OF_STEP that takes a camera back
     * from the probation of an OUT_OF_STEP episode is not reported again (a
     * clock that keeps drifting would otherwise send one every cycle; a
     * per-frame fault found again in probation is) */
    const bool same_episode = c->state == FH_PROBATION && c->episode == fault && fault == FH_OUT_OF_STEP;
    c->episode = fault;
    if (c->state != fault && !same_episode) {
        ev.kind = event_of(fault);
        switch (fault) {
        case FH_FROZEN: c->n_frozen++; break;
        case FH_CLOCK_FAULT: c->n_clock++; break;
        case FH_LATE: c->n_late++; break;
        default: c->n_seq++; break;
        }
    }
    c->state = fault;
    c->clean_run = 0;
    c->confirmed = false;
    return ev;
}

/* A probation that has run its frames ends when nothing is left to confirm. */
static fh_event_t maybe_healthy(fh_cam_t *c)
{
    fh_event_t ev = {FH_EV_NONE, 0, 0};
    const bool needs_confirmation = c->corr_us != 0 || c->corr_unknown;
    if (c->state == FH_PROBATION && c->clean_run >= FH_PROBATION_FRAMES && (!needs_confirmation || c->confirmed)) {
        c->state = FH_HEALTHY;
        c->episode = FH_HEALTHY;
        c->corr_unknown = false;
        c->n_healthy++;
        ev = (fh_event_t){FH_EV_HEALTHY, (int64_t)c->clean_run, c->corr_us};
    }
    return ev;
}

fh_event_t fh_observe(fh_monitor_t *m, unsigned k, const fh_frame_t *f)
{
    fh_event_t none = {FH_EV_NONE, 0, 0};
    if (k >= m->n || !f) {
        return none;
    }
    fh_cam_t *c = &m->cam[k];
    fh_state_t fault = FH_HEALTHY;
    int64_t a0 = 0;
    bool rebase = !c->have_prev;
    int32_t ds = 0;
    if (c->have_digest && f->digest_valid && f->digest == c->prev_digest) {
        fault = FH_FROZEN; /* a0 0: same content */
    }
    if (c->have_prev) {
        ds = (int32_t)(f->sequence - c->prev_seq); /* modulo 2^32: wraps are fine */
        if (ds == 0 && fault == FH_HEALTHY) {
            fault = FH_FROZEN;
            a0 = 1;
        } else if (ds < 0 && fault == FH_HEALTHY) {
            fault = FH_OUT_OF_STEP; /* sequence went backwards without a re-open */
            a0 = ds;
            rebase = true;
        } else if (ds > 0) {
            int64_t step = 0;
            const fh_state_t clk = check_clock(c, f, ds, &step, &rebase);
            if (clk == FH_CLOCK_FAULT) {
                if (c->period_known) {
                    c->corr_us -= step; /* re-aligned by the measured step: confirmed before use */
                }
                c->have_anchor = false; /* a new clock segment: the period is kept, the anchor moves */
                if (!c->period_known) {
                    c->learn_steps = 0;
                }
                if (fault == FH_HEALTHY) {
                    fault = FH_CLOCK_FAULT;
                    a0 = step;
                }
            } else if (!rebase && fault == FH_HEALTHY) {
                const int64_t dt = (int64_t)f->capture_us - (int64_t)c->prev_t_us;
                cadence_clean_step(c, f->sequence, f->capture_us, (uint32_t)ds, dt);
            }
        }
    }
    if (fault == FH_HEALTHY) {
        int64_t lat = 0;
        const fh_state_t arr = check_arrival(c, f, &lat);
        if (arr != FH_HEALTHY) {
            fault = arr;
            a0 = lat;
            if (arr == FH_CLOCK_FAULT) {
                c->corr_unknown = true;
            }
        }
    }
    if (rebase) {
        c->have_anchor = false;
        if (!c->period_known) {
            c->learn_steps = 0;
        }
    }
    c->have_prev = true;
    c->prev_seq = f->sequence;
    c->prev_t_us = f->capture_us;
    c->have_digest = f->digest_valid;
    c->prev_digest = f->digest;
    c->present = true;
    c->seq = f->sequence;
    const int64_t t = (int64_t)f->capture_us + c->corr_us;
    c->t_us = t > 0 ? (uint64_t)t : 0u;
    if (fault != FH_HEALTHY) {
        return enter_fault(c, fault, a0, (int64_t)f->sequence);
    }
    c->clean_now = true;
    if (c->state != FH_HEALTHY) {
        c->state = FH_PROBATION;
        c->clean_run++;
        return maybe_healthy(c);
    }
    return none;
}

void fh_present_again(fh_monitor_t *m, unsigned k, uint32_t sequence, uint64_t t_us)
{
    if (k >= m->n) {
        return;
    }
    fh_cam_t *c = &m->cam[k];
    c->present = true;
    c->clean_now = c->state == FH_HEALTHY;
    c->seq = sequence;
    c->t_us = t_us;
}

/* ---- across cameras ----------------------------------------------------- */

static unsigned pair_index(unsigned j, unsigned k)
{
    /* j < k < 3: (0,1) 0, (0,2) 1, (1,2) 2 */
    return j == 0u ? k - 1u : 2u;
}
_Static_assert(FH_MAX_CAMERAS == 3u, "pair_index is written for three cameras");

typedef enum { PAIR_UNCHECKED = 0, PAIR_AGREE, PAIR_DISAGREE } pair_verdict_t;

/* A pair's period: the mean of its cameras' learned periods. */
static float pair_period(const fh_cam_t *a, const fh_cam_t *b)
{
    return 0.5f * (a->period_us + b->period_us);
}

/* The time difference t_k - t_j the pair's reference predicts for this
 * cycle's sequence numbers, us. */
static int64_t pair_pred(const fh_pair_t *p, const fh_cam_t *a, const fh_cam_t *b, float period_us)
{
    const int64_t ds = (int64_t)(int32_t)(b->seq - a->seq);
    return p->dt_ref_us + round_i64((float)(ds - p->ds_ref) * period_us);
}

/* The pair (j, k) this cycle; *frames the disagreement in frames. */
static pair_verdict_t check_pair(const fh_monitor_t *m, unsigned j, unsigned k, int64_t *frames, float *res_us)
{
    const fh_cam_t *a = &m->cam[j];
    const fh_cam_t *b = &m->cam[k];
    const fh_pair_t *p = &m->pair[pair_index(j, k)];
    if (!a->present || !b->present || !p->valid || !a->period_known || !b->period_known ||
        p->rate != FH_RATE_SAME) {
        return PAIR_UNCHECKED; /* different rates (at the anchor): the sequence numbers do not predict the times */
    }
    const float period = pair_period(a, b);
    const int64_t dt = (int64_t)b->t_us - (int64_t)a->t_us;
    const int64_t pred = pair_pred(p, a, b, period);
    *frames = round_i64((float)(dt - pred) / period);
    *res_us = (float)(dt - pred);
    return absf_i64(dt - pred) > FH_CROSS_TOL_FRAC * period ? PAIR_DISAGREE : PAIR_AGREE;
}

static void pair_anchor(fh_monitor_t *m, unsigned j, unsigned k)
{
    const fh_cam_t *a = &m->cam[j];
    const fh_cam_t *b = &m->cam[k];
    fh_pair_t *p = &m->pair[pair_index(j, k)];
    p->valid = true;
    p->dt_ref_us = (int64_t)b->t_us - (int64_t)a->t_us;
    p->ds_ref = (int64_t)(int32_t)(b->seq - a->seq);
    p->seq_j_ref = a->seq;
    p->n_res = 0;
    p->res_us2 = 0.0f;
    p->rate = FH_RATE_UNKNOWN;
}

/* The rates of an anchored pair are compared once, when both periods are
 * first known: a clock that starts to run fast afterwards (its learned
 * period follows it) stays checked against the relation, which is how its
 * drift shows. */
static void pair_rates(fh_monitor_t *m)
{
    for (unsigned j = 0; j < m->n; j++) {
        for (unsigned k = j + 1u; k < m->n; k++) {
            const fh_cam_t *a = &m->cam[j];
            const fh_cam_t *b = &m->cam[k];
            fh_pair_t *p = &m->pair[pair_index(j, k)];
            if (p->valid && p->rate == FH_RATE_UNKNOWN && a->period_known && b->period_known) {
                const float period = pair_period(a, b);
                p->rate = absf_i64(round_i64(a->period_us - b->period_us)) <= FH_RATE_MATCH_FRAC * period
                              ? FH_RATE_SAME
                              : FH_RATE_DIFFERENT;
            }
        }
    }
}

/* The drift test's threshold, us, once the pair has learned (before: no
 * test, only the half period of OUT_OF_STEP): FH_PHASE_K x its rms within
 * [FH_PHASE_FLOOR_US, 3 J of a period] (3 J: two stamps at the stated bound
 * and one J for the reference's own error). */
static float drift_threshold(const fh_pair_t *p, float period_us)
{
    const float stated = 3.0f * FH_JITTER_FRAC * period_us;
    const float learned = FH_PHASE_K * sqrtf(p->res_us2);
    const float thr = learned < stated ? learned : stated;
    return thr > FH_PHASE_FLOOR_US ? thr : FH_PHASE_FLOOR_US;
}

/* An agreeing pair's reference moves a share of the residual toward this
 * cycle's relation, by at most the follow rate over the frames since, and
 * learns the residual's mean square. */
static void pair_follow(fh_monitor_t *m, unsigned j, unsigned k, float res_us, float period_us)
{
    const fh_cam_t *a = &m->cam[j];
    const fh_cam_t *b = &m->cam[k];
    fh_pair_t *p = &m->pair[pair_index(j, k)];
    const int64_t pred = pair_pred(p, a, b, period_us);
    uint32_t frames = a->seq - p->seq_j_ref;
    frames = frames == 0u || frames > FH_MAX_DSEQ ? 1u : frames;
    const float lim = (float)FH_PHASE_FOLLOW_PPM * 1e-6f * period_us * (float)frames;
    const bool learning = p->n_res < FH_PHASE_LEARN;
    float step;
    if (learning) {
        step = res_us / (float)(p->n_res + 2u); /* the mean of the relations so far (the anchor's the first) */
    } else {
        step = res_us / (float)FH_PHASE_GAIN_DIV;
        step = step > lim ? lim : step < -lim ? -lim : step;
    }
    p->dt_ref_us = pred + round_i64(step);
    p->ds_ref = (int64_t)(int32_t)(b->seq - a->seq);
    p->seq_j_ref = a->seq;
    if (!learning && fabsf(res_us) > 0.5f * drift_threshold(p, period_us)) {
        return; /* learned from residuals well inside the test only: a ramp below it creeps in slowly */
    }
    if (p->n_res < FH_PHASE_AVG) {
        p->n_res++;
    }
    p->res_us2 += (res_us * res_us - p->res_us2) / (float)p->n_res;
}

/* The pair's residual beyond what its jitter explains (CLOCK_DRIFT). */
static bool pair_drifts(const fh_pair_t *p, float res_us, float period_us)
{
    return p->n_res >= FH_PHASE_LEARN && fabsf(res_us) > drift_threshold(p, period_us);
}

/* CLOCK_DRIFT among the healthy cameras whose pairs agree this cycle: the
 * camera in the most marked pairs (frame_health.h). */
static void drift_check(fh_monitor_t *m, const pair_verdict_t v[FH_MAX_CAMERAS][FH_MAX_CAMERAS],
                        const float res[FH_MAX_CAMERAS][FH_MAX_CAMERAS], fh_event_t ev[FH_MAX_CAMERAS])
{
    unsigned marked[FH_MAX_CAMERAS] = {0, 0, 0}, checked[FH_MAX_CAMERAS] = {0, 0, 0};
    int other[FH_MAX_CAMERAS] = {-1, -1, -1};
    unsigned most = 0;
    for (unsigned j = 0; j < m->n; j++) {
        for (unsigned k = j + 1u; k < m->n; k++) {
            const fh_cam_t *a = &m->cam[j];
            const fh_cam_t *b = &m->cam[k];
            const fh_pair_t *p = &m->pair[pair_index(j, k)];
            if (!a->clean_now || !b->clean_now || a->state != FH_HEALTHY || b->state != FH_HEALTHY ||
                v[j][k] != PAIR_AGREE) {
                continue;
            }
            checked[j]++;
            checked[k]++;
            if (pair_drifts(p, res[k][j], pair_period(a, b))) {
                marked[j]++;
                marked[k]++;
                other[j] = (int)k;
                other[k] = (int)j;
            }
        }
    }
    unsigned pairs = 0;
    for (unsigned k = 0; k < m->n; k++) {
        most = marked[k] > most ? marked[k] : most;
        pairs += checked[k];
    }
    /* one pair checked: both of it; more: the camera marked against two (one
     * marked pair among three cameras, each agreeing with the third, names
     * no one: a stamp's jitter, not a clock) */
    const unsigned need = pairs / 2u <= 1u ? 1u : 2u;
    for (unsigned k = 0; k < m->n; k++) {
        fh_cam_t *c = &m->cam[k];
        if (most >= need && marked[k] == most) {
            if (!c->drift_suspect && ev[k].kind == FH_EV_NONE) {
                ev[k] = (fh_event_t){FH_EV_CLOCK_DRIFT, round_i64(res[k][other[k]]), other[k]};
                c->n_drift++;
            }
            c->drift_suspect = true;
            c->drift_clean = 0;
        } else if (c->drift_suspect && checked[k] > marked[k]) {
            c->drift_clean++;
            c->drift_suspect = c->drift_clean < FH_PROBATION_FRAMES;
        }
    }
}

void fh_cross_check(fh_monitor_t *m, fh_event_t ev[FH_MAX_CAMERAS])
{
    pair_verdict_t v[FH_MAX_CAMERAS][FH_MAX_CAMERAS];
    int64_t frames[FH_MAX_CAMERAS][FH_MAX_CAMERAS];
    float res[FH_MAX_CAMERAS][FH_MAX_CAMERAS];
    memset(v, 0, sizeof v);
    memset(frames, 0, sizeof frames);
    memset(res, 0, sizeof res);
    for (unsigned k = 0; k < FH_MAX_CAMERAS; k++) {
        ev[k] = (fh_event_t){FH_EV_NONE, 0, 0};
    }
    pair_rates(m);
    for (unsigned j = 0; j < m->n; j++) {
        for (unsigned k = j + 1u; k < m->n; k++) {
            int64_t f = 0;
            float r = 0.0f;
            v[j][k] = v[k][j] = check_pair(m, j, k, &f, &r);
            frames[k][j] = f; /* frames[a][b]: camera a's disagreement with b, frames */
            frames[j][k] = -f;
            res[k][j] = r; /* res[a][b]: camera a's time against b's, us */
            res[j][k] = -r;
        }
    }
    /* among the healthy cameras: the odd one out, or every camera of a disagreeing pair */
    bool healthy[FH_MAX_CAMERAS] = {false, false, false};
    unsigned n_healthy = 0;
    for (unsigned k = 0; k < m->n; k++) {
        healthy[k] = m->cam[k].present && m->cam[k].clean_now && m->cam[k].state == FH_HEALTHY;
        n_healthy += healthy[k] ? 1u : 0u;
    }
    unsigned dis[FH_MAX_CAMERAS] = {0, 0, 0}, agr[FH_MAX_CAMERAS] = {0, 0, 0};
    int other[FH_MAX_CAMERAS] = {-1, -1, -1};
    for (unsigned j = 0; j < m->n; j++) {
        for (unsigned k = 0; k < m->n; k++) {
            if (j == k || !healthy[j] || !healthy[k]) {
                continue;
            }
            if (v[j][k] == PAIR_DISAGREE) {
                dis[j]++;
                other[j] = (int)k;
            } else if (v[j][k] == PAIR_AGREE) {
                agr[j]++;
            }
        }
    }
    bool flag[FH_MAX_CAMERAS] = {false, false, false};
    int odd = -1;
    unsigned n_odd = 0;
    for (unsigned k = 0; k < m->n; k++) {
        if (healthy[k] && dis[k] >= 2u && agr[k] == 0u) {
            odd = (int)k;
            n_odd++;
        }
    }
    bool others_agree = n_odd == 1u;
    for (unsigned k = 0; k < m->n && others_agree; k++) {
        others_agree = (int)k == odd || !healthy[k] || dis[k] <= 1u;
    }
    for (unsigned k = 0; k < m->n; k++) {
        if (n_healthy >= 3u && others_agree) {
            flag[k] = (int)k == odd;
        } else {
            flag[k] = healthy[k] && dis[k] > 0u;
        }
    }
    for (unsigned k = 0; k < m->n; k++) {
        if (flag[k]) {
            const int o = other[k] >= 0 ? other[k] : 0;
            ev[k] = enter_fault(&m->cam[k], FH_OUT_OF_STEP, frames[k][o], o);
            m->cam[k].clean_now = false;
        }
    }
    /* a camera in probation against every healthy camera it can be compared
     * with; with none, against the others in probation (their corrections
     * were measured each on its own cadence: agreeing, they confirm each
     * other; disagreeing, neither is confirmed nor blamed) */
    bool prob[FH_MAX_CAMERAS] = {false, false, false};
    bool any_ref = false;
    for (unsigned k = 0; k < m->n; k++) {
        const fh_cam_t *c = &m->cam[k];
        prob[k] = c->present && c->clean_now && c->state == FH_PROBATION;
        any_ref = any_ref || (healthy[k] && !flag[k]);
    }
    for (unsigned k = 0; k < m->n; k++) {
        fh_cam_t *c = &m->cam[k];
        if (!prob[k]) {
            continue;
        }
        bool bad = false, good = false, peer_bad = false;
        int o = -1;
        for (unsigned j = 0; j < m->n; j++) {
            if (j == k) {
                continue;
            }
            if (healthy[j] && !flag[j]) {
                bad = bad || v[k][j] == PAIR_DISAGREE;
                good = good || v[k][j] == PAIR_AGREE;
                o = v[k][j] == PAIR_DISAGREE ? (int)j : o;
            } else if (!any_ref && prob[j]) {
                peer_bad = peer_bad || v[k][j] == PAIR_DISAGREE;
                good = good || v[k][j] == PAIR_AGREE;
            }
        }
        if (bad) {
            ev[k] = enter_fault(c, FH_OUT_OF_STEP, frames[k][o], o);
            c->clean_now = false;
        } else if (good && !peer_bad) {
            c->confirmed = true;
            ev[k] = maybe_healthy(c);
        }
    }
    drift_check(m, v, res, ev);
    /* pairs of healthy cameras that agree follow their drift at a bounded
     * rate, unless one of them drifts; new pairs a frame apart at most are
     * anchored */
    for (unsigned j = 0; j < m->n; j++) {
        for (unsigned k = j + 1u; k < m->n; k++) {
            const fh_cam_t *a = &m->cam[j];
            const fh_cam_t *b = &m->cam[k];
            if (!a->present || !b->present || !a->clean_now || !b->clean_now || a->state != FH_HEALTHY ||
                b->state != FH_HEALTHY) {
                continue;
            }
            const fh_pair_t *p = &m->pair[pair_index(j, k)];
            const float period = a->period_known ? a->period_us : b->period_us;
            const bool fresh_pair_in_step = !p->valid && (a->period_known || b->period_known) &&
                                            absf_i64((int64_t)b->t_us - (int64_t)a->t_us) <= FH_CROSS_TOL_FRAC * period;
            if (fresh_pair_in_step) {
                pair_anchor(m, j, k);
            } else if (v[j][k] == PAIR_AGREE && !pair_drifts(p, res[k][j], pair_period(a, b))) {
                pair_follow(m, j, k, res[k][j], pair_period(a, b));
            }
        }
    }
}

bool fh_drift_suspect(const fh_monitor_t *m, unsigned k)
{
    return k < m->n && m->cam[k].drift_suspect;
}

bool fh_usable(const fh_monitor_t *m, unsigned k)
{
    return k < m->n && m->cam[k].state == FH_HEALTHY;
}

fh_state_t fh_state(const fh_monitor_t *m, unsigned k)
{
    return k < m->n ? m->cam[k].state : FH_HEALTHY;
}

int64_t fh_correction_us(const fh_monitor_t *m, unsigned k)
{
    return k < m->n ? m->cam[k].corr_us : 0;
}

void fh_reopened(fh_monitor_t *m, unsigned k, bool seq_continues)
{
    if (k >= m->n || seq_continues) {
        return; /* the next frame's step spans the gap: judged as any other */
    }
    fh_cam_t *c = &m->cam[k];
    c->have_prev = false; /* sequence restarts: no step to judge; the digest is still compared */
    c->have_anchor = false;
    for (unsigned j = 0; j < m->n; j++) {
        if (j != k) {
            m->pair[j < k ? pair_index(j, k) : pair_index(k, j)].valid = false;
        }
    }
}

/* ---- digest ------------------------------------------------------------- */

/* FNV-1a over n bytes; *diff set when a byte differs from first. */
static uint64_t fnv_bytes(uint64_t h, const uint8_t *p, uint32_t n, uint8_t first, bool *diff)
{
    uint8_t acc = 0;
    for (uint32_t i = 0; i < n; i++) {
        h ^= p[i];
        h *= FNV64_PRIME;
        acc |= (uint8_t)(p[i] ^ first);
    }
    *diff = *diff || acc != 0u;
    return h;
}

uint64_t fh_digest(const mfns_frame_t *f, bool *flat)
{
    bool dummy = true;
    bool *fl = flat ? flat : &dummy;
    *fl = true;
    if (!f || !f->data || f->width == 0u || f->height == 0u) {
        return 0;
    }
    const uint32_t bpp = f->format == MFNS_PIXFMT_GREY ? 1u : 2u;
    const uint32_t row_bytes = (uint32_t)f->width * bpp;
    if (f->stride_bytes < row_bytes) {
        return 0;
    }
    bool diff = false;
    const uint8_t hdr[5] = {(uint8_t)(f->width & 0xffu), (uint8_t)(f->width >> 8), (uint8_t)(f->height & 0xffu),
                            (uint8_t)(f->height >> 8), (uint8_t)f->format};
    bool hdr_diff = false;
    uint64_t h = fnv_bytes(FNV64_OFFSET, hdr, (uint32_t)sizeof hdr, 0u, &hdr_diff);
    const uint8_t *base = (const uint8_t *)f->data;
    const uint8_t first = base[0];
    for (uint32_t r = 0; r < f->height; r += FH_DIGEST_ROW_STEP) {
        h = fnv_bytes(h, base + (size_t)r * f->stride_bytes, row_bytes, first, &diff);
    }
    const uint32_t last = (uint32_t)f->height - 1u;
    if (last % FH_DIGEST_ROW_STEP != 0u) {
        h = fnv_bytes(h, base + (size_t)last * f->stride_bytes, row_bytes, first, &diff);
    }
    *fl = !diff;
    return h;
}
