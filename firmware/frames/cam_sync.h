/* cam_sync.h -- which camera frames a navigation cycle may fuse, and the
 * health of each camera over cycles. Pure bookkeeping (no OS, no I/O), so the
 * rules are unit-tested on their own (tests/unit/test_cam_sync.c).
 *
 * Synchronised cycles: every frame carries its capture time (V4L2/libcamera
 * buffer timestamp, replay frames.csv t_s). A cycle fuses only frames within
 * window_us of the cycle's reference time: the time of the candidate frame
 * that has the most candidates within the window after it (the majority),
 * the oldest such on a tie. A frame later than the window is out of step
 * (AHEAD): it is held for a later cycle, not used in this one. A frame older
 * than the reference (BEHIND) is out of step the other way: the majority's
 * cycle has begun without it and no later cycle will take it, so it is given
 * back (why a majority and not the oldest frame: a camera whose clock runs
 * fast brings a frame just beyond the window, held; the next cycle that held
 * frame, older than the others' fresh frames by most of a period, would set
 * the time and push every healthy camera out of step instead, blame on the
 * wrong cameras and, cycle after cycle, one camera fused alone). With two
 * cameras that disagree there is no majority: the older one sets the time. A
 * frame not later than the previous cycle's time plus the window belongs to a
 * cycle already done (STALE): it is thrown away and the camera may dequeue
 * again to catch up. With window_us below half the frame period one camera
 * can never bring two frames to one cycle.
 *
 * Health: a camera with no fused frame for MFNS_CAM_LOST_CYCLES consecutive
 * cycles goes LOST; while LOST (or OFF) a re-open is due every
 * MFNS_CAM_REOPEN_CYCLES cycles; its next fused frame makes it UP again. */
#ifndef MFNS_CAM_SYNC_H
#define MFNS_CAM_SYNC_H

#include <stdbool.h>
#include <stdint.h>

#define MFNS_SYNC_WINDOW_US_DEFAULT 25000u /* < half of the 53.8 ms period at 18.6 fps */
#define MFNS_SYNC_WINDOW_US_MAX 1000000u
#define MFNS_CAM_LOST_CYCLES 10u           /* 0.54 s at 18.6 fps */
#define MFNS_CAM_REOPEN_CYCLES 10u
#define MFNS_CAM_FRAME_PERIOD_US 53800u    /* 18.6 fps, the cameras' rate (docs/cameras.md) */

_Static_assert(2u * MFNS_SYNC_WINDOW_US_DEFAULT < MFNS_CAM_FRAME_PERIOD_US,
               "the default window is below half the frame period: one camera never brings two frames to one cycle");
_Static_assert(MFNS_SYNC_WINDOW_US_DEFAULT <= MFNS_SYNC_WINDOW_US_MAX, "the default window is a valid --sync-window-ms");
_Static_assert(MFNS_CAM_LOST_CYCLES >= 1u && MFNS_CAM_REOPEN_CYCLES >= 1u, "LOST and re-open need at least one cycle");

typedef enum { CAM_SYNC_NONE = 0, CAM_SYNC_USE, CAM_SYNC_AHEAD, CAM_SYNC_BEHIND } cam_sync_verdict_t;

typedef struct {
    uint32_t window_us;
    bool have_last;
    uint64_t last_us; /* reference time of the last cycle that fused a frame */
} cam_sync_t;

void cam_sync_init(cam_sync_t *s, uint32_t window_us);
/* A frame at t_us belongs to a cycle already done (or an older one). */
bool cam_sync_is_stale(const cam_sync_t *s, uint64_t t_us);
/* One cycle over n candidates (have[k], t_us[k]; none stale): verdict per
 * camera, *cycle_us the reference time. Returns true (and records the time)
 * when some frame is used. */
bool cam_sync_cycle(cam_sync_t *s, const bool *have, const uint64_t *t_us, unsigned n, cam_sync_verdict_t *v,
                    uint64_t *cycle_us);
/* Signed t_us - ref_us in microseconds, saturated to int32. */
int32_t cam_sync_offset_us(uint64_t t_us, uint64_t ref_us);

typedef enum { CAM_HEALTH_UP = 0, CAM_HEALTH_LOST, CAM_HEALTH_OFF, CAM_HEALTH_ENDED } cam_health_state_t;
typedef enum { CAM_HEALTH_EV_NONE = 0, CAM_HEALTH_EV_LOST, CAM_HEALTH_EV_RECOVERED } cam_health_event_t;

typedef struct {
    cam_health_state_t state;
    uint32_t missed;      /* consecutive cycles without a fused frame */
    uint32_t since_reopen;
    uint32_t outage;      /* cycles of the outage that just ended (valid at EV_RECOVERED) */
} cam_health_t;

void cam_health_init(cam_health_t *h);
/* After a cycle: used = one of this camera's frames was fused. ENDED stays. */
cam_health_event_t cam_health_update(cam_health_t *h, bool used);
/* Counts a cycle while LOST or OFF; true when a re-open is due now. */
bool cam_health_reopen_due(cam_health_t *h);

#endif
