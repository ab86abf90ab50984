/* frame_health.h -- camera data health: is each camera's frame what its
 * stamp and sequence number claim? Per camera, every frame, before the frame
 * may be fused. Portable policy (no OS, no heap, bounded): the program feeds
 * it what the driver says of each frame; it answers which cameras may be
 * fused, which time correction applies, and what to report.
 *
 * Per camera, each fresh frame (fh_observe) is checked against the camera's
 * own previous frame:
 *   FROZEN       the content digest (fh_digest) equals the previous frame's,
 *                or the sequence number did not advance. A real sensor has
 *                read noise in every row, so identical sampled rows mean a
 *                stuck sensor/ISP or a buffer delivered twice.
 *                Misses: a pipeline that freezes the image but adds fresh
 *                noise; a stuck sequence of a driver that numbers no frame
 *                (every buffer 0, e.g. v4l2loopback 0.12: the V4L2 backend
 *                then numbers the frames itself, camera_backend.h); a
 *                frozen image whose stamps and sequence advance and
 *                that alternates between two buffers (A B A B: each differs
 *                from the one before); a frozen uniform image (no content:
 *                not compared, see fh_digest). False alarm: a noise-free (simulated,
 *                or fully black/saturated) image of a static scene, or two
 *                frames that differ only in rows the digest does not sample.
 *   CLOCK_FAULT  the stamp step against the camera's own cadence:
 *                |dt - dseq * period| > tol(dseq), where the period is learned
 *                per camera (FH_LEARN_STEPS consistent steps; a step that
 *                does not fit restarts learning) and refined from the
 *                longest consistent span; tol = period * (3 J + 2 J dseq /
 *                span) with J = FH_JITTER_FRAC the stated bound of one stamp's
 *                jitter (two stamps, plus one J margin, plus the period
 *                estimate's error over dseq frames). Also a stamp that does
 *                not advance while the sequence does, and (arrival clock
 *                valid, stamp source on the same clock) a stamp later than
 *                the frame's arrival. The measured step is the camera's clock
 *                correction (see Recovery).
 *                Misses: a step below tol (0.3 period for dseq = 1: it moves
 *                the frame by less than a third of a period, which the sync
 *                window of < half a period tolerates); any step during the
 *                first FH_LEARN_STEPS frames (learning restarts: the
 *                sequence cross-check still sees it against learned cameras);
 *                a slow drift of the clock rate (tracked as the period);
 *                a step across a re-open of a backend that restarts its
 *                sequence numbers (V4L2, libcamera): the arrival check still
 *                sees it there. A driver that leaves dropped frames out of
 *                its sequence numbers (V4L2 says they count) looks like a
 *                clock step of whole periods: re-aligned by it, the camera
 *                would be a frame off; with a valid arrival clock the
 *                corrected stamp then shows a period more latency (LATE when
 *                the normal latency is under half a period), without one it
 *                is missed.
 *   LATE         arrival - capture > FH_LATE_PERIODS periods (arrival clock
 *                valid and the stamp a capture stamp on the arrival's clock):
 *                a healthy pipeline hands a frame over before the next one
 *                is read out. Misses: a frame stale by one period in a
 *                pipeline whose normal latency is above half a period; any
 *                stale frame where the arrival time is unknown (replay
 *                without pacing) or the stamp is a copy/unknown source: the
 *                geometric fault detection (integrity) is the backstop.
 *   OUT_OF_STEP  across cameras (fh_cross_check, once per cycle before
 *                synchronisation): for each pair of cameras with a frame
 *                this cycle, the time difference of their frames must be the
 *                one their sequence numbers predict from the pair's last
 *                consistent cycle: |dt_jk - (dt_ref + (ds_jk - ds_ref) p)| <=
 *                p / 2 (a whole frame apart is a mismatch; the reference
 *                follows slow phase drift of free-running cameras). With
 *                three healthy cameras the odd one out is flagged; with two
 *                that disagree, both. A camera in probation must agree with
 *                every healthy camera it can be compared with. A sequence
 *                number that goes backwards without a re-open is OUT_OF_STEP.
 *                Misses: cameras at different rates (periods differing by
 *                more than FH_RATE_MATCH_FRAC: no check); pairs never fused
 *                together yet; all cameras wrong in the same way; a pair
 *                learned while one camera was already wrong (start-up).
 *                Offsets survive a re-open only when the backend continues
 *                sequence numbers (replay); otherwise they are learned again.
 *                The pair's reference follows a phase drift of at most
 *                FH_PHASE_FOLLOW_PPM (free-running cameras' oscillators);
 *                a clock drifting faster (a camera whose clock runs 1 %
 *                fast) accumulates against it and is OUT_OF_STEP at half a
 *                period (before 7 Dec 2026 the reference took each cycle's
 *                relation whole, so a drift of any rate below half a period
 *                per frame was followed and never seen).
 *   CLOCK_DRIFT  the same pairs, finer (not a fault: the camera stays
 *                fused, its clock in doubt, fh_drift_suspect): a pair
 *                learns its reference as the mean of its first
 *                FH_PHASE_LEARN relations and the mean square of its
 *                residuals (dt - pred); from then on a residual beyond
 *                max(FH_PHASE_FLOOR_US, min(FH_PHASE_K x rms, 3 J of a
 *                period)) marks the pair (3 J: two stamps at the stated
 *                bound and one J for the reference's own error). The
 *                camera marked against two cameras is suspect (with only
 *                one pair checked, both of it; one marked pair among three
 *                cameras, each agreeing with the third, names no one), an
 *                event on entering, cleared after FH_PROBATION_FRAMES
 *                cross-checks back inside. A marked pair's reference stays
 *                where it is, so the drift keeps counting; residuals learn
 *                only within half the test, so a ramp creeps in slowly.
 *                Misses: an offset below the floor (1 ms: 0.08 mm at 80
 *                mm/s); a drift slower than the reference follows (200 ppm:
 *                11 us a frame); a drift that began while the pair learned
 *                (start-up); every camera drifting alike; a camera stale by
 *                whole periods whose stamps are right for its (old) content
 *                (no clock is wrong: the geometry's lag monitor sees it).
 *                False alarm: stamps whose jitter grows after learning (a
 *                loaded bus), at which the camera's frames are taken with
 *                their time offset left free until the relation is back
 *                inside.
 *
 * States and recovery: HEALTHY cameras are fused. A fault puts the camera in
 * FROZEN / CLOCK_FAULT / LATE / OUT_OF_STEP (an event on entering each) and
 * its frames are left out; each fault-free frame after that is PROBATION,
 * and FH_PROBATION_FRAMES consecutive fault-free frames make it HEALTHY again
 * (event). A camera whose clock stepped is re-aligned by the measured step
 * (its stamps are corrected by fh_correction_us) but comes back only when
 * the cross-check has confirmed the corrected stamps against a healthy
 * camera during its probation (with no healthy camera at all, e.g. every
 * clock stepped at once: against another camera in probation, whose
 * correction was measured on its own cadence; two that disagree confirm
 * neither); with nothing to confirm it, or when the step could not be
 * measured (period not yet learned, stamp later than arrival), it stays out.
 *
 * Every loop is bounded by FH_MAX_CAMERAS or the sampled rows of a frame.
 */
#ifndef MFNS_FRAME_HEALTH_H
#define MFNS_FRAME_HEALTH_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/nav/centroid/centroid.h" /* mfns_frame_t */

#define FH_MAX_CAMERAS 3u
#define FH_PAIRS (FH_MAX_CAMERAS * (FH_MAX_CAMERAS - 1u) / 2u)
#define FH_JITTER_PERMILLE 100u    /* stated bound of one stamp's jitter: 0.1 of the period */
#define FH_JITTER_FRAC ((float)FH_JITTER_PERMILLE / 1000.0f)
#define FH_LEARN_STEPS 8u          /* consistent steps before the period is trusted */
#define FH_LEARN_TOL_FRAC 0.3f     /* a learning step within this fraction of the estimate is consistent */
#define FH_MAX_DSEQ 10000u         /* a gap longer than this re-baselines instead of being judged */
#define FH_LATE_PERIODS 1.5f       /* arrival - capture above this many periods is LATE */
#define FH_LATE_UNLEARNED_US 200000u /* the LATE bound before the period is learned */
#define FH_CROSS_TOL_PERMILLE 500u /* cross-camera mismatch: half a period */
#define FH_CROSS_TOL_FRAC ((float)FH_CROSS_TOL_PERMILLE / 1000.0f)
#define FH_RATE_MATCH_FRAC 0.01f   /* periods of a pair within 1 %: same rate, cross-check applies */
#define FH_PROBATION_FRAMES 10u    /* consecutive fault-free frames before a camera is fused again */
#define FH_DIGEST_ROW_STEP 16u     /* digest: every 16th row (and the last) */
#define FH_PHASE_FOLLOW_PPM 200u   /* a pair's phase reference follows at most this drift rate: two free-running
                                      oscillators of +-50 ppm each, twice over */
#define FH_PHASE_GAIN_DIV 8        /* the reference takes 1/8 of each agreeing residual: one stamp's jitter smoothed */
#define FH_PHASE_LEARN 8u          /* residuals learned before the pair's own jitter sets the drift test */
#define FH_PHASE_AVG 64u           /* memory of the learned mean square, cycles */
#define FH_PHASE_K 6.0f            /* drift test: |residual| beyond K x the learned rms ... */
#define FH_PHASE_FLOOR_US 1000.0f  /* ... and beyond 1 ms (0.08 mm of motion at 80 mm/s) */

_Static_assert(3u * FH_JITTER_PERMILLE < FH_CROSS_TOL_PERMILLE,
               "a step the cadence check lets through (3 J at dseq 1) is below the cross-check's tolerance");
_Static_assert(FH_LEARN_STEPS >= 2u && FH_PROBATION_FRAMES >= 1u, "learning and probation need frames");
_Static_assert(FH_DIGEST_ROW_STEP >= 1u, "the digest samples rows");
_Static_assert(FH_PHASE_LEARN >= 8u && FH_PHASE_AVG >= FH_PHASE_LEARN, "the drift test learns a pair's rms first");
_Static_assert(FH_PHASE_GAIN_DIV >= 1, "the reference takes a share of each residual");

/* Where a frame's stamp comes from (the driver's flags, portable). */
typedef enum {
    FH_TS_UNKNOWN = 0,  /* no statement: arrival checks skipped */
    FH_TS_CAPTURE_SOE,  /* capture clock (CLOCK_MONOTONIC), start of exposure */
    FH_TS_CAPTURE_EOF,  /* capture clock, end of frame */
    FH_TS_COPY,         /* copied from elsewhere (e.g. an output buffer): not a capture time */
    FH_TS_RECORDED      /* replay: the recorded capture time; arrival on the recording's time base */
} fh_ts_source_t;

typedef enum {
    FH_HEALTHY = 0,
    FH_PROBATION,
    FH_FROZEN,
    FH_CLOCK_FAULT,
    FH_LATE,
    FH_OUT_OF_STEP,
    FH_STATE_COUNT
} fh_state_t;

typedef enum {
    FH_EV_NONE = 0,
    FH_EV_FROZEN,       /* arg0 0 (same digest) or 1 (sequence did not advance); arg1 sequence */
    FH_EV_CLOCK_JUMP,   /* arg0 step, us (stamp - expected); arg1 sequence */
    FH_EV_LATE,         /* arg0 arrival - capture, us; arg1 sequence */
    FH_EV_SEQ_MISMATCH, /* arg0 disagreement, frames (signed); arg1 the other camera */
    FH_EV_CLOCK_DRIFT,  /* arg0 residual, us (the pair's time difference - the reference's); arg1 the other camera */
    FH_EV_HEALTHY       /* arg0 fault-free frames of its probation; arg1 clock correction, us */
} fh_event_kind_t;

typedef struct {
    fh_event_kind_t kind;
    int64_t arg0, arg1;
} fh_event_t;

/* What the driver says of one frame. */
typedef struct {
    uint32_t sequence;
    uint32_t dropped_before;
    uint64_t capture_us;   /* the frame's stamp, as delivered (uncorrected) */
    uint64_t arrival_us;   /* when it was dequeued, on the capture clock's time base */
    bool arrival_valid;
    fh_ts_source_t ts_source;
    uint64_t digest;       /* fh_digest of its pixels */
    bool digest_valid;
} fh_frame_t;

typedef struct {
    fh_state_t state;
    fh_state_t episode;      /* the fault that began the episode (HEALTHY: none) */
    uint32_t clean_run;      /* consecutive fault-free frames since the last fault */
    bool confirmed;          /* the cross-check confirmed it during this probation */
    bool corr_unknown;       /* its clock stepped by an amount not measured */
    int64_t corr_us;         /* added to its stamps (re-alignment after a measured step) */
    /* previous frame */
    bool have_prev, have_digest;
    uint32_t prev_seq;
    uint64_t prev_t_us;
    uint64_t prev_digest;
    /* cadence */
    bool period_known, have_anchor;
    float period_us;
    uint32_t period_span;    /* frames the period estimate spans */
    uint32_t learn_steps;
    uint32_t anchor_seq;
    uint64_t anchor_t_us;
    /* this cycle */
    bool present, clean_now;
    uint32_t seq;
    uint64_t t_us;           /* corrected stamp of its frame this cycle */
    /* phase drift against the other cameras (CLOCK_DRIFT) */
    bool drift_suspect;      /* in doubt since the event, until drift_clean */
    uint32_t drift_clean;    /* cross-checks back inside since the last marked one */
    /* counts */
    uint32_t n_frozen, n_clock, n_late, n_seq, n_healthy, n_drift;
} fh_cam_t;

typedef enum { FH_RATE_UNKNOWN = 0, FH_RATE_SAME, FH_RATE_DIFFERENT } fh_rate_t;

typedef struct {
    bool valid;
    int64_t dt_ref_us;       /* t_k - t_j at the pair's last consistent cycle */
    int64_t ds_ref;          /* seq_k - seq_j then */
    uint32_t seq_j_ref;      /* seq_j then: frames since, for the follow's bound */
    uint32_t n_res;          /* residuals learned (saturates at FH_PHASE_AVG) */
    float res_us2;           /* their mean square, us^2 */
    uint8_t rate;            /* fh_rate_t: the periods compared once, when both are first known */
} fh_pair_t;

typedef struct {
    unsigned n;              /* cameras, <= FH_MAX_CAMERAS */
    fh_cam_t cam[FH_MAX_CAMERAS];
    fh_pair_t pair[FH_PAIRS];
} fh_monitor_t;

/* Every camera HEALTHY, nothing learned. n is clamped to FH_MAX_CAMERAS. */
void fh_init(fh_monitor_t *m, unsigned n);
/* Start of a cycle: no camera has a frame yet. */
void fh_begin_cycle(fh_monitor_t *m);
/* One fresh frame of camera k (every frame dequeued, also those later found
 * stale): the per-camera checks, state and the cycle's frame of k. Returns
 * the event to report (FH_EV_NONE mostly). */
fh_event_t fh_observe(fh_monitor_t *m, unsigned k, const fh_frame_t *f);
/* A frame of k observed in an earlier cycle and offered again this cycle
 * (held for being ahead); t_us is its corrected stamp. */
void fh_present_again(fh_monitor_t *m, unsigned k, uint32_t sequence, uint64_t t_us);
/* The cross-camera sequence check over this cycle's frames; ev[k] gets
 * camera k's event. Call once per cycle after every camera was observed. */
void fh_cross_check(fh_monitor_t *m, fh_event_t ev[FH_MAX_CAMERAS]);
/* Camera k's frames may be fused (HEALTHY). */
bool fh_usable(const fh_monitor_t *m, unsigned k);
fh_state_t fh_state(const fh_monitor_t *m, unsigned k);
/* Camera k's clock drifts against the others' (CLOCK_DRIFT): fused, but its
 * stamps are in doubt. */
bool fh_drift_suspect(const fh_monitor_t *m, unsigned k);
/* Correction to add to camera k's stamps, us. */
int64_t fh_correction_us(const fh_monitor_t *m, unsigned k);
/* Camera k was closed and opened again; seq_continues: its backend goes on
 * with the same sequence numbers (replay) rather than restarting them. */
void fh_reopened(fh_monitor_t *m, unsigned k, bool seq_continues);
/* FNV-1a/64 over the image bytes of every FH_DIGEST_ROW_STEP-th row and the
 * last row (width * bytes per pixel of each: row padding never read), with
 * the size and format. Cost: height / FH_DIGEST_ROW_STEP + 1 rows, one
 * multiply per byte (about 1/16 of the frame). 0 for a NULL frame/data.
 * *flat (may be NULL): every sampled byte is the same (a uniform frame: dark
 * cabin, covered lens). Such a frame has nothing to freeze and no beacon to
 * mislead with; the caller passes it with digest_valid = false, so a dark
 * spell is not FROZEN and costs no probation when the light returns. */
uint64_t fh_digest(const mfns_frame_t *f, bool *flat);
const char *fh_state_name(fh_state_t s);

#endif /* MFNS_FRAME_HEALTH_H */
