/* acquire_certify.h -- the map analysis behind the acquisition's certificate
 * (offline: `mfns table build` runs it through the shared library).
 *
 * For sampled body poses in the workspace, the frame the rig would see is
 * made with the flight camera model (in front, inside the image, facing the
 * beacon's emission cone; at most MFNS_MAX_OBS_PER_CAMERA per camera, nearest
 * first) and the flight acquisition runs on it in analysis mode: every band
 * of every anchor, no early stop, every distinct consistent candidate kept.
 * A candidate whose correspondence differs from the truth on any inlier is a
 * rival; the most inliers of a rival within the index's unexplained
 * allowance, for each count of missing beacons up to max_missing, over all
 * samples, is the map's self-similarity: a fix with that many missing needs
 * one more (at least MFNS_BIDX_MIN_CERT). Poses whose rival explains as many blobs as
 * the truth are ambiguous views of the map and are reported (the worst one
 * in full). Bounded: samples x budget units.
 */
#ifndef MFNS_ACQUIRE_CERTIFY_H
#define MFNS_ACQUIRE_CERTIFY_H

#include <stdint.h>

#include "firmware/nav/acquire/acquire.h"

#define MFNS_CERTIFY_MAX_BLOBS MFNS_ACQ_MAX_MEAS

typedef struct {
    uint32_t sample;                 /* index of the pose */
    uint16_t n_blobs;                /* blobs of its frame */
    uint16_t rival_inliers, rival_missing;
    uint16_t truth_id[MFNS_CERTIFY_MAX_BLOBS]; /* beacon id of each blob (round order: cam x, y, z) */
    int32_t rival_id[MFNS_CERTIFY_MAX_BLOBS];  /* rival's beacon id per blob, -1 none */
} mfns_certify_case_t;

typedef struct {
    uint32_t samples;      /* poses given */
    uint32_t usable;       /* with >= MFNS_ACQ_MIN_BLOBS beacons in view */
    uint32_t truth_found;  /* usable poses where the right identification was a candidate */
    uint32_t ambiguous;    /* usable poses with a rival of as many inliers as in view */
    uint32_t rival_hist[MFNS_BIDX_MAX_CERT + 1]; /* poses by their best rival's inliers (capped) */
    uint16_t max_rival;    /* most inliers of a rival (0: none) */
    uint16_t rival_by_missing[MFNS_BIDX_MAX_MISSING + 1u]; /* most inliers of a rival with that many missing */
    /* the certificate: per missing count m <= max_missing,
     * max(MFNS_BIDX_MIN_CERT, 1 + most inliers of a rival with m missing),
     * made non-decreasing and capped at MFNS_BIDX_MAX_CERT; 0 beyond */
    uint8_t cert_inliers[MFNS_BIDX_MAX_MISSING + 1u];
    uint8_t cert_capped;   /* the map needs more than MFNS_BIDX_MAX_CERT: ambiguous map */
    mfns_certify_case_t worst; /* the pose of the strongest rival */
} mfns_certify_result_t;

/* The frame (and its true beacon per blob) that the rig sees from pose. */
void mfns_certify_frame(const mfns_rig_t *rig, const mfns_beacon_map_t *map, const mfns_beacon_index_t *idx,
                        const mfns_pose_t *pose, mfns_obs_frame_t *frame, mfns_pose_assoc_t *truth);

/* Analyse n poses; acq and frame are the caller's scratch. Returns
 * MFNS_BIDX_E_ARG on bad input. */
mfns_bidx_status_t mfns_certify(mfns_acq_t *acq, const mfns_rig_t *rig, const mfns_beacon_map_t *map,
                                const mfns_beacon_index_t *idx, const mfns_pose_config_t *cfg,
                                const mfns_pose_t *poses, uint32_t n, uint32_t budget_per_pose,
                                mfns_obs_frame_t *frame, mfns_certify_result_t *res);

/* The certificate of res from its rivals (mfns_certify calls it; after
 * accumulating several runs, call it again). */
void mfns_certify_finish(mfns_certify_result_t *res, const mfns_beacon_index_t *idx);

/* Add the run part (whose first pose was number first_sample) to total. */
void mfns_certify_accumulate(mfns_certify_result_t *total, const mfns_certify_result_t *part, uint32_t first_sample);

/* Write the certificate and the analysis figures of res into the index. */
void mfns_certify_apply(mfns_beacon_index_t *idx, const mfns_certify_result_t *res);

#endif /* MFNS_ACQUIRE_CERTIFY_H */
