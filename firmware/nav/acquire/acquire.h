/* acquire.h -- lost-in-space acquisition: which blob is which beacon, with
 * no prior, in any map the table can hold (docs/pose.md "Acquisition").
 *
 * Hypothesize and verify, grown along the map index (beacon_index.h):
 *   1. anchors: pairs of blobs in one image, nearest pairs first (the
 *      nearest blob of a blob is, in the measured maps, the nearest beacon
 *      in space at the median); with each, a third blob (the anchor's next
 *      nearest in the same image, else, at most two per pair, a blob of
 *      another camera) and up to two verification blobs (the next ones
 *      after that; for a pair alone in its image, the third blob's nearest
 *      in its own image);
 *   2. bands: for anchor blobs (i, j, k) every beacon a with its neighbours
 *      b = nbr(a)[rb], c = nbr(a)[rc] (another camera's third: every c),
 *      in growing rank windows 1, 2, 4, .. k_nbr, so that likely hypotheses
 *      come first; each pair must admit its measured angle (pair intervals);
 *      for a third blob in the same image, the triples whose beacon
 *      distances have the shares of the measured angles (the "shape") come
 *      first, to rank 8 and then to k_nbr, each before the other triples of
 *      those ranks (an order only: every triple is tried in the end);
 *   3. the generalized P3P (pose_init.h) on the three rays, with the third
 *      beacon's range interval; every pose whose body origin is near the
 *      workspace and that sees a, b, c from the front of their LEDs is
 *      checked on the verification blobs against the beacons near a, b, c
 *      (cheap; one of them may be left unexplained), then associated in
 *      pixels, refined (ML) and tested: chi-square of the residuals with
 *      per-observation variance (pixel noise plus the beacon's survey sigma
 *      projected at its range), physical (body origin inside the workspace
 *      within its own 6 sigma, every inlier's LED facing its camera), and
 *      the count of beacons it predicts inside an image, facing the camera,
 *      that no blob explains ("missing");
 *   4. the certificate: a pose is a fix only with at least
 *      index.cert_inliers consistent inliers, at most index.max_missing
 *      missing beacons and at most index.max_unexplained blobs left
 *      without a beacon (cert_inliers[missing]). The map analysis
 *      (acquire_certify.h) found no wrong identification reaching that many
 *      over the sampled workspace, so the search stops at the first
 *      certified pose. A frame with fewer blobs than that (4 blobs: the
 *      certificate is at least 5) is certified by completion instead: when the
 *      bands end (at once when a candidate explains every blob), one anchor
 *      is enumerated exhaustively (every admissible beacon triple); any
 *      other pose explaining every blob explains that anchor's three and is
 *      found there (a minimal pose is dropped only when its body origin is
 *      outside the workspace by more than 6 sigma of its own propagated
 *      covariance). Exactly one such pose within the allowances: the fix;
 *      a second one ends the completion as AMBIGUOUS. A frame of five blobs
 *      (four beacons and a reflection, issue 27) not certified by the bands
 *      is completed over its five hypotheses of a blob left out: for each,
 *      one triple of the other four is enumerated exhaustively and the
 *      fourth checked soundly, so every pose explaining at least four of
 *      the five blobs is found. Exactly one such identification (one that
 *      is part of another counts as that one): the fix, its spurious blob
 *      without a beacon; two: SPURIOUS_AMBIGUOUS, no fix. Nothing else is reported
 *      as a fix: an unfinished search, or one that ends with only
 *      uncertified candidates, is NO_FIX (NOT_IDENTIFIED, or AMBIGUOUS when
 *      two different correspondences tie).
 *
 * Resumable: a search the budget stops keeps its place (mfns_acq_cursor_t)
 * and its own copy of the frame, and mfns_acq_resume() goes on from the very
 * hypothesis the budget refused, so a search split over calls tries exactly
 * the hypotheses, in the same order, of one call with their summed budget
 * (test_acquire.c). acquire_cycle.h schedules this over navigation cycles.
 *
 * Work units: one per P3P solve and per cheap check, VERIFY_UNITS plus one
 * per 8 beacons per full verification (association of every beacon +
 * refinement), one per 8 beacons for the missing-beacon count; a call stops
 * when it has spent
 * its budget (index.budget_units per cycle in flight: about 1 us per unit on
 * the benchmark host). All state lives in the caller's mfns_acq_t, so two
 * navigators can run in one process; nothing allocates; every loop is
 * bounded by the counts of the frame, the map and the budget.
 */
#ifndef MFNS_ACQUIRE_H
#define MFNS_ACQUIRE_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/nav/map/beacon_index.h"
#include "firmware/nav/pose/pose.h"

/* Blobs a fix needs: three make a hypothesis, a fourth checks it. */
#define MFNS_ACQ_MIN_BLOBS 4
/* A frame of one blob more is completed over the hypotheses of one blob left
 * out (four beacons and a reflection), when the index allows a blob left
 * unexplained. */
#define MFNS_ACQ_LOO_BLOBS (MFNS_ACQ_MIN_BLOBS + 1)
#define MFNS_ACQ_MAX_ANCHORS 6
#define MFNS_ACQ_MAX_CAND 8
#define MFNS_ACQ_VERIFY_UNITS 8u
#define MFNS_ACQ_MAX_MEAS (MFNS_NUM_CAMERAS * MFNS_MAX_OBS_PER_CAMERA)
_Static_assert(MFNS_ACQ_MIN_BLOBS < MFNS_BIDX_MIN_CERT,
               "a 4-blob frame is below every certificate: only the completion certifies it");
_Static_assert(MFNS_MAX_OBS_PER_CAMERA <= 256, "mfns_acq_blob_t.idx is a u8");
_Static_assert(MFNS_ACQ_MAX_MEAS <= INT16_MAX, "cam_blob[][] and the anchors hold blob indices in int16");
_Static_assert(MFNS_ACQ_MAX_ANCHORS <= 255, "progress.anchors and cursor.anchor are u8");
_Static_assert(MFNS_MAX_BEACONS <= INT16_MAX, "the cursor holds beacon indices in int16");

/* Where the search stands (telemetry: housekeeping). units and budget_out
 * are the last call's; the rest covers the whole search (every call since
 * mfns_acquire started it). */
typedef struct {
    uint32_t units;        /* work spent by the call */
    uint32_t units_total;  /* work spent by the search over all its calls */
    uint16_t calls;        /* calls the search has taken (1: started, not resumed) */
    uint32_t hypotheses;   /* P3P solves */
    uint16_t verified;     /* poses that reached full verification */
    uint8_t anchors;       /* anchors of the frame */
    uint8_t band;          /* rank window reached: 1, 2, 4, .. k_nbr (0: none) */
    uint8_t best_inliers;  /* best candidate's consistent inliers (0: none) */
    uint8_t best_missing;  /* and its missing beacons */
    bool finished;         /* every band of every anchor enumerated */
    bool budget_out;       /* stopped by the budget */
    bool certified;        /* stopped on a certified pose */
    bool completed;        /* certified by the exhaustive completion */
    uint8_t rivals;        /* completion: other poses that explain every blob too */
} mfns_acq_progress_t;

typedef struct {
    mfns_pose_solution_t sol;
    uint8_t inliers, missing;
} mfns_acq_cand_t;

/* One blob as a body-frame ray. */
typedef struct {
    uint8_t cam, idx;
    mfns_v3_t c, d;
} mfns_acq_blob_t;

typedef struct {
    int16_t i, j, k;    /* anchor pair and third blob */
    int16_t v[2];       /* verification blobs in the same image (-1 none) */
    bool cross;         /* the third blob is in another camera */
} mfns_acq_anchor_t;

/* Where a search stands between calls: the phase, the band schedule's step
 * and window, the anchor, and the loop indices of the hypothesis the budget
 * refused (the next call starts there). */
typedef enum {
    MFNS_ACQ_PHASE_IDLE = 0, /* no search (or its input was refused) */
    MFNS_ACQ_PHASE_BANDS,    /* growing hypotheses along the neighbour lists */
    MFNS_ACQ_PHASE_COMPLETE, /* the exhaustive completion of a 4-blob frame */
    MFNS_ACQ_PHASE_DONE,     /* ended: certified, or nothing left to try */
} mfns_acq_phase_t;

typedef struct {
    uint8_t phase;      /* mfns_acq_phase_t */
    uint8_t stage;      /* band schedule step */
    uint8_t w_done[3];  /* windows done per pass kind (same image, cross, same-image shape pass) */
    uint8_t w0, w;      /* the window being enumerated: ranks [w0, w); w 0: the step starts */
    uint8_t anchor;     /* the anchor being enumerated */
    uint8_t resume;     /* the loops start at (a, r1, r2) once */
    int16_t a, r1, r2;  /* beacon a, then ranks or beacons of b and c */
    uint8_t skip;       /* five-blob completion: the blob left out by the hypothesis being enumerated */
} mfns_acq_cursor_t;

/* Caller storage of one acquisition (about 11 KB): place it with the
 * navigator (static). A search stopped by its budget stays resumable until
 * the next mfns_acquire on this storage; rig, map, index and config must stay
 * in place until then (the frame is copied). */
typedef struct {
    mfns_acq_progress_t progress;
    mfns_acq_cursor_t cur;
    mfns_obs_frame_t frame_copy; /* the searched frame, kept for a resume */
    /* bound by mfns_acq_prepare */
    const mfns_rig_t *rig;
    const mfns_beacon_map_t *map;
    const mfns_beacon_index_t *idx;
    const mfns_obs_frame_t *frame;
    const mfns_pose_config_t *cfg;
    uint32_t budget;
    bool analysis; /* certify mode: no early stop, keep every candidate */
    bool exhaustive; /* in the completion: checks scan the whole map */
    bool to_complete; /* a candidate explains every blob: go to the completion */
    bool settled;     /* the completion found two full explanations: AMBIGUOUS */
    bool pause_before_completion; /* stop (pending) where the completion would start */
    bool paused;      /* stopped there */
    mfns_acq_blob_t blobs[MFNS_ACQ_MAX_MEAS];
    int16_t cam_blob[MFNS_NUM_CAMERAS][MFNS_MAX_OBS_PER_CAMERA];
    int nb;
    mfns_acq_anchor_t anchor[MFNS_ACQ_MAX_ANCHORS];
    int na;
    float gate_n[MFNS_NUM_CAMERAS];
    mfns_acq_cand_t cand[MFNS_ACQ_MAX_CAND];
    int ncand;
    int best;
    int certified; /* index into cand of the certified pose, -1 none */
    int skip;      /* the blob the completion leaves out (five-blob frame), -1 none */
} mfns_acq_t;

/* Acquire from frame with no prior, spending at most budget_units work
 * units. out is OK/DEGRADED only for a certified pose (see top of file). */
mfns_pose_status_t mfns_acquire(mfns_acq_t *acq, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                const mfns_beacon_index_t *idx, const mfns_obs_frame_t *frame,
                                const mfns_pose_config_t *cfg, uint32_t budget_units, mfns_pose_solution_t *out);

/* Go on with the search mfns_acquire (or an earlier resume) left unfinished
 * on its budget, for at most budget_units more: same outcomes as
 * mfns_acquire. With no such search (none started, certified, ended, or its
 * input refused): NO_FIX with reason BAD_ARG and no work done. */
mfns_pose_status_t mfns_acq_resume(mfns_acq_t *acq, uint32_t budget_units, mfns_pose_solution_t *out);

/* Did the last call stop on its budget (or before a completion, mfns_acq_start)
 * with hypotheses left to try? */
bool mfns_acq_pending(const mfns_acq_t *acq);

/* Drop any search: nothing is pending afterwards. */
void mfns_acq_reset(mfns_acq_t *acq);

#endif /* MFNS_ACQUIRE_H */
