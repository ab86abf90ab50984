/* response_watch.h -- a camera whose photometric response steps: a gain
 * register lost or rewritten, a readout scaled by half, an exposure the
 * driver did not apply, while the frame's metadata still reports the old
 * setting.
 *
 * Why a monitor of its own: such a camera still delivers sharp spots at the
 * right places, so no geometric test sees it (a halved gain costs signal to
 * noise; the centroider's per-blob covariance follows the blob's own
 * photometry, so the pose stays honestly weighted), yet the camera is not
 * what the table calibrated and the operator must know which one changed.
 *
 * The test. Each camera's accepted, unsaturated blobs of this frame are
 * matched to those of its last frame by position: first the spots' common
 * shift (a turn of the robot, or a knock of the mount, moves every spot of a
 * camera by nearly the same pixels; the shift that brings most of the
 * MFNS_RESP_VOTE_SPOTS brightest together wins, up to MFNS_RESP_MAX_SHIFT_PX,
 * and a second as good elsewhere leaves the frame untested), then each spot
 * to the nearest within MFNS_RESP_MATCH_PX of its shifted place, the match
 * unique both ways. A beacon's flux changes with its range and viewing
 * angle by well under a percent per frame. The flux
 * ratio of each matched pair, divided by the ratio of the two frames'
 * reported response (exposure x linear gain, when the caller gives it), is
 * 1 up to the blobs' photon and read noise. The camera's response stepped
 * when at least MFNS_RESP_MIN_MATCHED pairs matched, their median ratio is
 * beyond MFNS_RESP_STEP_RATIO (or its inverse), and at least three in four
 * of the pairs are beyond it on the same side (one beacon occluded, a
 * reflection merging with one spot, moves one pair, not the camera's
 * median). Attribution: only when that camera stepped alone this cycle; two
 * or more cameras stepping together is the beacons' or the scene's (the
 * LEDs' supply), reported as common and naming no camera.
 *
 * What it misses (say it in every report):
 *   - a slow fade (a few percent per frame never steps): each frame is
 *     compared with the last one only;
 *   - a step smaller than the ratio (a gain 0.8x);
 *   - a camera with fewer than MFNS_RESP_MIN_MATCHED matched spots, or a
 *     step in the same frame as a jump of its spots beyond
 *     MFNS_RESP_MAX_SHIFT_PX or not common to them (a swapped stream):
 *     nothing matches;
 *   - a step that saturates the spots (a gain doubled on bright beacons):
 *     saturated blobs carry no flux ratio;
 *   - a commanded change of exposure or gain the caller does not report
 *     (response 0): read as a step of the camera's response; so is one
 *     reported a frame or more before the sensor applies it (the response
 *     must be the frame's own, as libcamera's per-frame metadata gives it).
 * It also sees what is not a gain: a frame that does not follow its own
 * reported exposure change is a frame not taken with it (a frozen camera
 * re-delivering old content, another camera's stream): on the grown
 * campaign the simulator's auto-exposure steps 5x, and a frozen, alternating
 * or swapped camera was named by this watch at that step, 13-23 cycles after
 * the freeze (the right camera, reported as a response step).
 * Work: per camera MFNS_RESP_VOTE_SPOTS^4 distance tests for the shift (4,096),
 * 2 MFNS_RESP_MAX_BLOBS^2 for the matches and one median of at most
 * MFNS_RESP_MAX_BLOBS values (insertion sort); no heap, caller-owned state. */
#ifndef MFNS_RESPONSE_WATCH_H
#define MFNS_RESPONSE_WATCH_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/nav/centroid/centroid.h"
#include "firmware/nav/settings/nav_settings.h"

#define MFNS_RESP_MAX_BLOBS MFNS_MAX_OBS_PER_CAMERA /* the brightest remembered per camera */
#define MFNS_RESP_MATCH_PX 3.0f     /* a spot's own motion after the camera's common shift, at most */
#define MFNS_RESP_MAX_SHIFT_PX 60.0f /* the common shift between two frames, at most */
#define MFNS_RESP_VOTE_SPOTS 8u      /* the brightest spots that vote for the shift */
#define MFNS_RESP_STEP_RATIO 0.7f                    /* a step: flux ratio below this, or above its inverse */
#define MFNS_RESP_MIN_MATCHED 2u                     /* matched spots a camera's test needs */
_Static_assert(MFNS_RESP_MAX_BLOBS <= 255, "a match count fits a byte");
_Static_assert(MFNS_RESP_MIN_MATCHED >= 2u, "one spot alone is a beacon's, not a camera's");
_Static_assert(MFNS_RESP_VOTE_SPOTS >= MFNS_RESP_MIN_MATCHED && MFNS_RESP_VOTE_SPOTS <= MFNS_RESP_MAX_BLOBS,
               "the voting spots can carry a shift");

typedef enum {
    MFNS_RESP_OK = 0,
    MFNS_RESP_E_ARG = -1, /* NULL, a camera out of range, a count above the maximum, a response not finite or < 0 */
} mfns_resp_status_t;

/* Per-camera memory of the last frame's spots. Caller-owned; zero it with
 * mfns_resp_init. */
typedef struct {
    float u[MFNS_NUM_CAMERAS][MFNS_RESP_MAX_BLOBS], v[MFNS_NUM_CAMERAS][MFNS_RESP_MAX_BLOBS];
    float flux_dn[MFNS_NUM_CAMERAS][MFNS_RESP_MAX_BLOBS];
    uint8_t n[MFNS_NUM_CAMERAS];
    float response[MFNS_NUM_CAMERAS]; /* the last frame's reported response, 0 unknown */
    /* this cycle, from mfns_resp_observe */
    float ratio[MFNS_NUM_CAMERAS]; /* median flux ratio against the last frame, response-corrected; 0 untested */
    uint8_t matched[MFNS_NUM_CAMERAS];
    int8_t side[MFNS_NUM_CAMERAS]; /* -1 stepped down, +1 up, 0 no step */
} mfns_resp_watch_t;

/* This cycle's verdict (mfns_resp_evaluate). */
typedef struct {
    int8_t camera;  /* the camera whose response stepped alone this cycle, -1 none */
    float ratio;    /* its median flux ratio (this frame / its last) */
    uint8_t matched; /* spots the ratio is the median of */
    uint8_t common;  /* cameras that stepped together this cycle (>= 2: not a camera's; none named) */
} mfns_resp_report_t;

void mfns_resp_init(mfns_resp_watch_t *w);

/* Camera cam's frame: its centroider result's blobs (the accepted ones are
 * the first n_accepted) and the frame's reported response (exposure x linear
 * gain, any unit, the same for every frame of the camera; 0 unknown: taken
 * as unchanged). Compares with the camera's last frame, then remembers this
 * one. A camera without a frame this cycle is not called and keeps its
 * memory. */
mfns_resp_status_t mfns_resp_observe(mfns_resp_watch_t *w, int cam, const mfns_centroid_result_t *r,
                                     float response);

/* After every camera's frame: which camera stepped alone. Clears the cycle. */
void mfns_resp_evaluate(mfns_resp_watch_t *w, mfns_resp_report_t *rep);

#endif /* MFNS_RESPONSE_WATCH_H */
