/* acquire_internal.h -- what the acquisition's own files share (acquire.h is
 * the contract with the rest of the core; this header is not). The search is
 * split by job:
 *   acquire.c          the API, the band schedule and the run loop (resume)
 *   acquire_anchor.c   frame set-up: blobs as rays, anchors
 *   acquire_enum.c     enumeration: bands, exhaustive enumeration, hypotheses
 *   acquire_verify.c   checks of a hypothesis pose and the candidate list
 *   acquire_complete.c the completion of a 4-blob frame and its sound check
 * Callers of the core use it too: acquire_cycle.c (mfns_acq_start) and the
 * map analysis, firmware/host/acquire_certify.c (prepare, search, acceptable).
 */
#ifndef MFNS_ACQUIRE_INTERNAL_H
#define MFNS_ACQUIRE_INTERNAL_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/nav/acquire/acquire.h"
#include "firmware/nav/pose/pose_internal.h"
#include "firmware/nav/acquire/workspace_watch.h"

/* A pose from three rays carries their noise amplified by the geometry
 * (tens of times near the "danger cylinder"): measured, a right minimal pose
 * at 0.3 px noise predicted a fourth beacon 16 px off. The first association
 * therefore uses this multiple of the tracking gate; the refined pose is then
 * associated again with the tracking gate itself. */
#define MFNS_ACQ_MINIMAL_GATE_FACTOR 4.0f

/* The acquisition gathers a frame's blobs (every one, or the completion's 4)
 * into the pose solver's measurement arrays. */
_Static_assert(sizeof(((mfns_acq_t *)0)->blobs) / sizeof(mfns_acq_blob_t) <= MFNS_POSE_MAX_MEAS,
               "a frame's blobs fit the solver's measurements");
_Static_assert(MFNS_ACQ_MIN_BLOBS <= MFNS_POSE_MAX_MEAS, "the completion refines 4 measurements");

/* ---- The entry points of the acquisition's callers in the core
 * (acquire_cycle.c, firmware/host/acquire_certify.c), beside mfns_acquire.
 *
 * mfns_acquire, optionally stopping (pending, resumable)
 * where a 4-blob frame's completion would start, so that a caller already
 * completing another frame of the same view need not pay for this one's: */
mfns_pose_status_t mfns_acq_start(mfns_acq_t *acq, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                  const mfns_beacon_index_t *idx, const mfns_obs_frame_t *frame,
                                  const mfns_pose_config_t *cfg, uint32_t budget_units, bool pause_before_completion,
                                  mfns_pose_solution_t *out);
/* Check the inputs and set acq up for frame (false on bad input), then run
 * the search and fill its candidates. */
bool mfns_acq_prepare(mfns_acq_t *acq, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                      const mfns_beacon_index_t *idx, const mfns_obs_frame_t *frame, const mfns_pose_config_t *cfg,
                      uint32_t budget_units, bool analysis);
void mfns_acq_search(mfns_acq_t *acq);
/* A candidate within the index's missing and unexplained allowances (the
 * certificate then only asks for enough inliers). */
bool mfns_acq_acceptable(const mfns_acq_t *acq, const mfns_acq_cand_t *cd);

/* ---- Shared among the acquisition's files. */

/* Has the search to stop here (certified, going to the completion, out of
 * budget, or the completion found two full explanations)? */
static inline bool mfns_acq_stop(const mfns_acq_t *q)
{
    return q->certified >= 0 || q->to_complete || q->progress.budget_out || q->settled;
}

/* acquire_anchor.c */
/* Angle between the rays of two blobs (rad). */
float mfns_acq_ray_angle(const mfns_acq_blob_t *a, const mfns_acq_blob_t *b);
/* Pad of a pair's angle for blobs of two cameras (their rays start at
 * different centres); 0 for one camera. */
float mfns_acq_parallax_pad(const mfns_acq_blob_t *a, const mfns_acq_blob_t *b);
/* The frame's blobs as body-frame rays and the per-camera minimal gates;
 * false on a non-finite observation. */
bool mfns_acq_setup(mfns_acq_t *q);
/* Three blobs of one image nearly on one line (their gP3P cannot fix the
 * rotation about it: never an anchor's triple). */
bool mfns_acq_flat_triangle(const mfns_acq_t *q, int i, int j, int k);
/* The anchors of the frame (acquire.h, step 1). */
void mfns_acq_make_anchors(mfns_acq_t *q);

/* acquire_verify.c */
/* The centre of camera c in the world at pose (body origin + C_w_b^T r_bk_b). */
mfns_v3_t mfns_acq_cam_centre_w(const mfns_acq_t *q, const mfns_pose_t *pose, int c);
/* Does beacon b's LED face the point p_w (its emission cone, mfns_bidx_emits_toward)? */
bool mfns_acq_faces(const mfns_acq_t *q, int b, mfns_v3_t p_w);
/* The inliers' residuals are plausible under the noise (chi-square). */
bool mfns_acq_chi2_consistent(const mfns_acq_t *q, const mfns_pose_solution_t *sol);
/* Beacons predicted in an image, facing the camera, that no inlier explains. */
int mfns_acq_count_missing(mfns_acq_t *q, const mfns_pose_solution_t *sol);
/* The pose is one the rig can physically have (workspace, LEDs facing). */
bool mfns_acq_physical(const mfns_acq_t *q, const mfns_pose_solution_t *sol);
/* Refine from pose on the n measurements m (n < 0: none) into sol: true
 * when the solve uses at least min_used beacons and is consistent and
 * physical (the test of every re-solve of a candidate). */
bool mfns_acq_solve_checked(mfns_acq_t *q, mfns_pose_meas_t *m, int n, const mfns_pose_t *pose, uint32_t min_used,
                            mfns_pose_solution_t *sol);
/* Keep a candidate (unless its correspondence is already kept) and update
 * the best, the certified one and the completion's flags. */
void mfns_acq_add_candidate(mfns_acq_t *q, const mfns_acq_cand_t *cd);
/* The cheap check of a minimal pose on the anchor's verification blobs. */
bool mfns_acq_quick_check(mfns_acq_t *q, const mfns_pose_t *pose, const mfns_acq_anchor_t *an, const int abc[3]);
/* From a candidate's refined pose, associate again (the tracking gate, then
 * the minimal gate) and keep a consistent, physical re-solve that explains
 * more blobs. m: the caller's scratch (overwritten). */
void mfns_acq_extend(mfns_acq_t *q, mfns_acq_cand_t *cd, mfns_pose_meas_t m[MFNS_POSE_MAX_MEAS]);
/* The distinct identifications among the candidates within the allowances
 * (mfns_acq_acceptable): one whose inlier correspondences are all part of
 * another's is that one. *keep: one of them with the most inliers (-1 none). */
int mfns_acq_identifications(const mfns_acq_t *q, int *keep);
/* Associate, refine, associate again and score: the candidate or false. */
bool mfns_acq_full_verify(mfns_acq_t *q, const mfns_pose_t *pose, mfns_acq_cand_t *cd);

/* acquire_enum.c */
/* Which triples a band tries (same-image anchors; a cross anchor tries all):
 * every admissible one but those the shape pass had (shape-matching, both
 * ranks below shape_done), or only the shape-matching ones. */
typedef struct {
    bool shape_only;
    int shape_done;
} mfns_acq_band_mode_t;

/* Band [w0, w1) of one anchor, from the cursor. */
void mfns_acq_band(mfns_acq_t *q, const mfns_acq_anchor_t *an, int w0, int w1, mfns_acq_band_mode_t mode);
/* Every admissible ordered beacon triple for the anchor, from the cursor. */
void mfns_acq_exhaust(mfns_acq_t *q, const mfns_acq_anchor_t *an);

/* acquire_complete.c */
/* The completion's sound check of one minimal pose (every fourth beacon
 * within the propagated gate). */
void mfns_acq_sound_verify(mfns_acq_t *q, const mfns_pose_t *pose, const mfns_acq_anchor_t *an, const int abc[3]);
/* A frame the completion covers over the hypotheses of one blob left out
 * (MFNS_ACQ_LOO_BLOBS blobs, one may stay unexplained). */
bool mfns_acq_leave_one_out(const mfns_acq_t *q);
/* Does the completion follow the bands for this frame? */
bool mfns_acq_completion_applies(const mfns_acq_t *q);
/* Run the completion from the cursor. */
void mfns_acq_run_completion(mfns_acq_t *q);

#endif /* MFNS_ACQUIRE_INTERNAL_H */
