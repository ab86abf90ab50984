/* workspace_watch.h -- is the robot inside the workspace its table was
 * certified for? (docs/pose.md "The table's workspace")
 *
 * The acquisition's identification is certified unique by the map analysis
 * (beacon_index.h, firmware/host/acquire_certify.h) for a body origin inside
 * the table's workspace box only, and the acquisition refuses any pose
 * outside it (mfns_acq_physical). The box is a declaration: for a robot that
 * really is outside, a wrong identification whose pose lies inside the box
 * was never weighed against the views from where the robot is, and could be
 * certified. So the box must be watched, from the poses the acquisition does
 * not make:
 *
 *   - Test: mfns_ws_beyond, the body origin against the box widened per axis
 *     by MFNS_WS_TOL_MM plus MFNS_WS_TOL_SIGMA of the pose's own position
 *     sigma (a right pose is never called outside for its noise). The
 *     acquisition's physical test is this same call.
 *   - Watch (mfns_ws_watch_update): a pose that carries the track and came
 *     from tracking (not from this cycle's acquisition) sets the state:
 *     OUTSIDE when it is beyond the box (reported once: left), INSIDE when it
 *     is within (reported: reentered, after OUTSIDE). Coasting and a lost
 *     track leave the state as it was: a robot last seen outside may still be
 *     outside.
 *   - Consequence (mfns_ws_watch_refuses): while OUTSIDE, an acquisition's
 *     fix is refused (NO_FIX, MFNS_POSE_R_OUTSIDE_WORKSPACE) and does not
 *     carry the track, so nothing it found can clear the state. The state
 *     clears only by a tracked pose inside the box: the track itself coming
 *     back, or tracking from an operator's pose (SET_POSE_HINT), or by a new
 *     table (mfns_nav_init: a new declaration).
 *
 * What it misses (say it with every report):
 *   - a robot that leaves the box while no pose is tracked (lost inside,
 *     carried out unseen): nothing saw it leave, the acquisition's
 *     certificate is trusted as if it were inside;
 *   - a robot started outside its box (the declaration is taken at table
 *     load): the acquisition never finds the right pose (outside: refused as
 *     not physical) and a wrong one inside is not ruled out;
 *   - excursions smaller than the tolerance (20 mm plus 6 sigma): inside by
 *     this test, outside the sampled box. The planner pads its box by 5 %
 *     plus 1 mm (mfns plan optimize), the tolerance is the acquisition's own.
 * Work: one box test per cycle; no heap, caller-owned state.
 */
#ifndef MFNS_WORKSPACE_WATCH_H
#define MFNS_WORKSPACE_WATCH_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/nav/map/beacon_index.h"
#include "firmware/nav/pose/pose.h"

/* The box test's widening: a fixed part (the LED, the body origin's own
 * offsets, the map's survey error) and a multiple of the pose's position
 * sigma per axis. The acquisition's tests use the same numbers. */
#define MFNS_WS_TOL_MM 20.0f
#define MFNS_WS_TOL_SIGMA 6.0f

typedef enum {
    MFNS_WS_INSIDE = 0,       /* the last tracked pose was inside the box (or none yet: the declaration) */
    MFNS_WS_OUTSIDE = 1,      /* the last tracked pose was outside: acquisitions are refused */
} mfns_ws_state_t;

typedef struct {
    uint8_t state;           /* mfns_ws_state_t */
    uint32_t cycles_outside; /* cycles since the state became OUTSIDE (saturates) */
} mfns_ws_watch_t;

typedef struct {
    bool left;             /* a tracked pose went beyond the box this cycle (INSIDE -> OUTSIDE) */
    bool reentered;        /* a tracked pose came back inside (OUTSIDE -> INSIDE) */
    uint8_t axes;          /* the axes the tested pose is beyond (bit 0 x, 1 y, 2 z; 0 inside or untested) */
    float beyond_mm;       /* how far beyond the widened box (mm; 0 inside or untested) */
    float tol_mm;          /* the widening on the axis furthest out (mm) */
    uint32_t cycles_outside; /* on reentered: the cycles it was outside */
} mfns_ws_report_t;

/* How far sol's body origin lies beyond the index's workspace box widened by
 * MFNS_WS_TOL_MM + MFNS_WS_TOL_SIGMA * sigma_pos_mm[a] on each axis a: the
 * largest excess (mm, 0 within), the axes beyond in *axes (bit a), that
 * axis's widening in *tol_mm (either may be NULL). A position that is not
 * finite is beyond on every axis it is not finite on (excess +inf). */
float mfns_ws_beyond(const mfns_beacon_index_t *idx, const mfns_pose_solution_t *sol, uint8_t *axes, float *tol_mm);

void mfns_ws_watch_init(mfns_ws_watch_t *w);

/* True while acquisitions are not certified for where the robot may be
 * (state OUTSIDE): the caller refuses the acquisition's fix. */
bool mfns_ws_watch_refuses(const mfns_ws_watch_t *w);

/* After the cycle's verdict. sol is the cycle's pose; carries: it carries
 * the track (nav_cycle.c carries_track); tracked: it came from tracking, not
 * from this cycle's acquisition. Only such poses move the state. */
void mfns_ws_watch_update(mfns_ws_watch_t *w, const mfns_beacon_index_t *idx, const mfns_pose_solution_t *sol,
                          bool carries, bool tracked, mfns_ws_report_t *rep);

const char *mfns_ws_state_str(mfns_ws_state_t s);

#endif /* MFNS_WORKSPACE_WATCH_H */
