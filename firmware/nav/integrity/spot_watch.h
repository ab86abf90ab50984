/* spot_watch.h -- what each camera's spots did since its last frame: two
 * camera faults no geometric test of one frame sees.
 *
 * Matching. Each camera's accepted, unsaturated blobs of this frame are
 * matched to those of its last frame by position: first the spots' common
 * shift (a turn of the robot, or a knock of the mount, moves every spot of a
 * camera by nearly the same pixels; the shift that brings most of the
 * MFNS_SPOT_VOTE_SPOTS brightest together wins, up to MFNS_SPOT_MAX_SHIFT_PX,
 * and a second as good elsewhere leaves the frame untested), then each spot
 * to the nearest within MFNS_SPOT_MATCH_PX of its shifted place, the match
 * unique both ways. Each remembered spot keeps its own motion over its last
 * frame (its image velocity, px per frame), and where it should be now is
 * where it was moved on by that motion (when it is one frame's): the common
 * shift is then what the camera did beyond its smooth motion, so a smooth
 * turn, roll or parallax matches spot by spot.
 *
 * 1. The response stepped: a gain register lost or rewritten, a readout
 * scaled, an exposure the driver did not apply, while the frame's metadata
 * still reports the old setting. Such a camera still delivers sharp spots at
 * the right places (a halved gain costs signal to noise; the centroider's
 * per-blob covariance follows the blob's own photometry, so the pose stays
 * honestly weighted), yet it is not what the table calibrated and the
 * operator must know which one changed. A beacon's flux changes with its
 * range and viewing angle by well under a percent per frame; the flux ratio
 * of each matched pair, divided by the ratio of the two frames' reported
 * response (exposure x linear gain, when the caller gives it), is 1 up to
 * the blobs' photon and read noise. The camera's response stepped when at
 * least MFNS_SPOT_MIN_MATCHED pairs matched, their median ratio is beyond
 * MFNS_SPOT_STEP_RATIO (or its inverse), and at least three in four of the
 * pairs are beyond it on the same side (one beacon occluded, a reflection
 * merging with one spot, moves one pair, not the camera's median).
 * Attribution: only when that camera stepped alone this cycle; two or more
 * cameras stepping together is the beacons' or the scene's (the LEDs'
 * supply), reported as common and naming no camera.
 *
 * 2. The spots jumped: a free flyer's image motion is smooth (the table's
 * motion bound, 0.25 rad/s^2, changes a spot's motion by about 1 px a frame
 * at 18.5 Hz on a 1,600 px focal length), so a spot's motion this frame is
 * its motion over the last one, to that. Each spot matched in both frames
 * gives the change of its motion; the camera's jump is the median of their
 * lengths over at least MFNS_SPOT_MIN_MATCHED spots (a spot's own parallax
 * is in its own motion, so spots entering or leaving do not move the median;
 * lengths, not vectors: a mount turned about the optical axis moves its
 * spots in every direction). Beyond MFNS_SPOT_JUMP_PX: the camera's mount moved
 * in that frame (a knock: 0.3 deg is 8.5 px), or its frames stopped
 * following the scene (a frozen or alternating camera: its spots stop, or
 * swing back and forth), or the whole robot jolted (every camera's spots
 * jump: a collision, the navigation filter's MOTION_EXCEEDED). Attribution:
 * the camera that jumped while another camera's spots were tested smooth.
 * Spots that moved smoothly (MFNS_SPOT_MIN_MATCHED with a motion of one
 * frame), of which no common change of motion brings two back and not one
 * is where it should be, while the camera still shows a spot, jumped but
 * not together (a mount turned about its optical axis, a swapped stream; or
 * every one of them but a new one left the image at once): a jump of
 * MFNS_SPOT_UNMATCHED_JUMP_PX. Measured: grown campaign seed 3, camera y
 * turned 1 deg about its optical axis, two spots before the knock and one
 * (moved 7.7 px) in its frame.
 * What the jump is for: a fix computed from a frame whose spots jumped is
 * not to be trusted in that cycle (nav_cycle.c refuses the navigation
 * filter's fix of the cycle, FRAME_SUSPECT), before the filter's tests can
 * see the fault.
 *
 * What it misses (say it in every report):
 *   - a slow fade (a few percent per frame never steps), a slow pointing
 *     drift (a fraction of a pixel per frame never jumps): each frame is
 *     compared with the last one only;
 *   - a step smaller than the ratio (a gain 0.8x), a jump below
 *     MFNS_SPOT_JUMP_PX (a knock of 0.1 deg; a camera that freezes while the
 *     robot's image moves less than that a frame);
 *   - a camera with fewer than MFNS_SPOT_MIN_MATCHED matched spots (a jump
 *     needs them matched over three frames), or a change in the frame its
 *     spots jump beyond MFNS_SPOT_MAX_SHIFT_PX or not together (a swapped
 *     stream): nothing matches;
 *   - a step that saturates the spots (a gain doubled on bright beacons):
 *     saturated blobs carry no flux ratio;
 *   - a commanded change of exposure or gain the caller does not report
 *     (response 0): read as a step of the camera's response; so is one
 *     reported a frame or more before the sensor applies it (the response
 *     must be the frame's own, as libcamera's per-frame metadata gives it);
 *   - a camera whose last frame is not the last cycle's (a dropped frame):
 *     its motion history starts again.
 * The response watch also sees what is not a gain: a frame that does not
 * follow its own reported exposure change is a frame not taken with it (a
 * frozen camera re-delivering old content, another camera's stream): on the
 * grown campaign the simulator's auto-exposure steps 5x, and a frozen,
 * alternating or swapped camera was named at that step, 13-23 cycles after
 * the freeze (the right camera, reported as a response step).
 * Work: per camera MFNS_SPOT_VOTE_SPOTS^4 distance tests for the shift
 * (4,096), 2 MFNS_SPOT_MAX_BLOBS^2 for the matches and three medians of at
 * most MFNS_SPOT_MAX_BLOBS values (insertion sort); no heap, caller-owned
 * state. */
#ifndef MFNS_SPOT_WATCH_H
#define MFNS_SPOT_WATCH_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/nav/centroid/centroid.h"
#include "firmware/nav/settings/nav_settings.h"

#define MFNS_SPOT_MAX_BLOBS MFNS_MAX_OBS_PER_CAMERA /* the brightest remembered per camera */
#define MFNS_SPOT_MATCH_PX 3.0f     /* a spot's own motion after the camera's common shift, at most */
#define MFNS_SPOT_MAX_SHIFT_PX 60.0f /* the common shift between two frames, at most */
#define MFNS_SPOT_VOTE_SPOTS 8u      /* the brightest spots that vote for the shift */
#define MFNS_SPOT_STEP_RATIO 0.7f                    /* a step: flux ratio below this, or above its inverse */
#define MFNS_SPOT_MIN_MATCHED 2u                     /* matched spots a camera's test needs */
#define MFNS_SPOT_JUMP_PX 3.0f /* a jump: a camera's spots' motion changed by more than this in one frame */
#define MFNS_SPOT_UNMATCHED_JUMP_PX MFNS_SPOT_MAX_SHIFT_PX /* the jump reported when smooth spots no longer match */
#define MFNS_SPOT_EPISODE_CYCLES 20u /* a camera's jumps this close together are one episode (reported once) */
_Static_assert(MFNS_SPOT_MAX_BLOBS <= 255, "a match count fits a byte");
_Static_assert(MFNS_NUM_CAMERAS <= 8, "a camera mask fits a byte");
_Static_assert(MFNS_SPOT_EPISODE_CYCLES >= 2u && MFNS_SPOT_EPISODE_CYCLES <= 255u,
               "an episode outlasts the cycle after a jump, and its count fits a byte");
_Static_assert(MFNS_SPOT_MIN_MATCHED >= 2u, "one spot alone is a beacon's, not a camera's");
_Static_assert(MFNS_SPOT_VOTE_SPOTS >= MFNS_SPOT_MIN_MATCHED && MFNS_SPOT_VOTE_SPOTS <= MFNS_SPOT_MAX_BLOBS,
               "the voting spots can carry a shift");

typedef enum {
    MFNS_SPOT_OK = 0,
    MFNS_SPOT_E_ARG = -1, /* NULL, a camera out of range, a count above the maximum, a response not finite or < 0 */
} mfns_spot_status_t;

/* Per-camera memory of the last frame's spots. Caller-owned; zero it with
 * mfns_spot_init. */
typedef struct {
    float u[MFNS_NUM_CAMERAS][MFNS_SPOT_MAX_BLOBS], v[MFNS_NUM_CAMERAS][MFNS_SPOT_MAX_BLOBS];
    float flux_dn[MFNS_NUM_CAMERAS][MFNS_SPOT_MAX_BLOBS];
    /* each spot's motion over the last frame (px), valid when moved != 0 */
    float du[MFNS_NUM_CAMERAS][MFNS_SPOT_MAX_BLOBS], dv[MFNS_NUM_CAMERAS][MFNS_SPOT_MAX_BLOBS];
    uint8_t moved[MFNS_NUM_CAMERAS][MFNS_SPOT_MAX_BLOBS];
    uint8_t n[MFNS_NUM_CAMERAS];
    float response[MFNS_NUM_CAMERAS]; /* the last frame's reported response, 0 unknown */
    uint8_t last_cycle[MFNS_NUM_CAMERAS]; /* the camera's last frame was the last cycle's */
    /* this cycle, from mfns_spot_observe */
    uint8_t seen[MFNS_NUM_CAMERAS];  /* observed this cycle */
    float ratio[MFNS_NUM_CAMERAS]; /* median flux ratio against the last frame, response-corrected; 0 untested */
    uint8_t matched[MFNS_NUM_CAMERAS];
    int8_t side[MFNS_NUM_CAMERAS]; /* -1 stepped down, +1 up, 0 no step */
    float jump_px[MFNS_NUM_CAMERAS]; /* the change of its spots' motion; < 0 untested */
    uint8_t jump_hold[MFNS_NUM_CAMERAS]; /* cycles left of the camera's jump episode */
} mfns_spot_watch_t;

/* This cycle's verdict (mfns_spot_evaluate). */
typedef struct {
    int8_t camera;   /* the camera whose response stepped alone this cycle, -1 none */
    float ratio;     /* its median flux ratio (this frame / its last) */
    uint8_t matched; /* spots the ratio is the median of */
    uint8_t common;  /* cameras that stepped together this cycle (>= 2: not a camera's; none named) */
    uint8_t jump_mask; /* bit c: camera c's spots jumped this cycle */
    int8_t jump_camera; /* the one that jumped while another camera's spots were tested smooth, -1 none */
    float jump_px;      /* the largest jump this cycle (px), 0 none tested */
    float others_px;    /* jump_camera: the largest change of the other tested cameras' spots' motion */
    bool jump_new;      /* jump_camera's first jump of an episode (report it once) */
    uint8_t recent_mask; /* bit c: camera c's spots jumped this cycle or the last (its frame may still
                            weigh on what took it: nav_cycle.c refuses the filter's fix for both) */
} mfns_spot_report_t;

void mfns_spot_init(mfns_spot_watch_t *w);

/* Camera cam's frame: its centroider result's blobs (the accepted ones are
 * the first n_accepted) and the frame's reported response (exposure x linear
 * gain, any unit, the same for every frame of the camera; 0 unknown: taken
 * as unchanged). Compares with the camera's last frame, then remembers this
 * one. A camera without a frame this cycle is not called and keeps its
 * memory. */
mfns_spot_status_t mfns_spot_observe(mfns_spot_watch_t *w, int cam, const mfns_centroid_result_t *r,
                                     float response);

/* After every camera's frame: which camera stepped alone, which jumped.
 * A camera not observed this cycle starts its motion history again. Clears
 * the cycle. */
void mfns_spot_evaluate(mfns_spot_watch_t *w, mfns_spot_report_t *rep);

#endif /* MFNS_SPOT_WATCH_H */
