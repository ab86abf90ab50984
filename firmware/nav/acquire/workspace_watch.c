/* workspace_watch.c -- see workspace_watch.h. */
#include "firmware/nav/acquire/workspace_watch.h"

#include <math.h>
#include <stddef.h>

#include "math/core_text.h"

float mfns_ws_beyond(const mfns_beacon_index_t *idx, const mfns_pose_solution_t *sol, uint8_t *axes, float *tol_mm)
{
    const mfns_v3_t p = mfns_pose_position_w(&sol->pose);
    const float pw[3] = {p.x, p.y, p.z};
    const float lo[3] = {idx->ws_min_w.x, idx->ws_min_w.y, idx->ws_min_w.z};
    const float hi[3] = {idx->ws_max_w.x, idx->ws_max_w.y, idx->ws_max_w.z};
    uint8_t out = 0U;
    float worst = 0.0f, worst_tol = 0.0f;
    for (int a = 0; a < 3; a++) {
        const float tol = MFNS_WS_TOL_MM + MFNS_WS_TOL_SIGMA * sol->sigma_pos_mm[a];
        /* written so that NaN (position or sigma) is beyond */
        if (!(pw[a] >= lo[a] - tol && pw[a] <= hi[a] + tol)) {
            out = (uint8_t)(out | (1U << a));
            const float below = (lo[a] - tol) - pw[a], above = pw[a] - (hi[a] + tol);
            float e = below > above ? below : above;
            if (!(e > 0.0f)) { /* NaN */
                e = INFINITY;
            }
            if (e > worst) {
                worst = e;
                worst_tol = tol;
            }
        }
    }
    if (axes != NULL) {
        *axes = out;
    }
    if (tol_mm != NULL) {
        *tol_mm = worst_tol;
    }
    return worst;
}

void mfns_ws_watch_init(mfns_ws_watch_t *w)
{
    w->state = (uint8_t)MFNS_WS_INSIDE;
    w->cycles_outside = 0U;
}

bool mfns_ws_watch_refuses(const mfns_ws_watch_t *w)
{
    return w->state != (uint8_t)MFNS_WS_INSIDE;
}

void mfns_ws_watch_update(mfns_ws_watch_t *w, const mfns_beacon_index_t *idx, const mfns_pose_solution_t *sol,
                          bool carries, bool tracked, mfns_ws_report_t *rep)
{
    rep->left = false;
    rep->reentered = false;
    rep->axes = 0U;
    rep->beyond_mm = 0.0f;
    rep->tol_mm = 0.0f;
    rep->cycles_outside = 0U;
    if (w->state != (uint8_t)MFNS_WS_INSIDE && w->cycles_outside < UINT32_MAX) {
        w->cycles_outside++;
    }
    if (!carries || !tracked) {
        /* an acquisition's pose is inside by construction (or refused), a
         * lost or coasting track says nothing new: the state stands */
        return;
    }
    rep->beyond_mm = mfns_ws_beyond(idx, sol, &rep->axes, &rep->tol_mm);
    if (rep->axes != 0U) {
        if (w->state == (uint8_t)MFNS_WS_INSIDE) {
            rep->left = true;
            w->state = (uint8_t)MFNS_WS_OUTSIDE;
            w->cycles_outside = 0U;
        }
    } else if (w->state != (uint8_t)MFNS_WS_INSIDE) {
        rep->reentered = true;
        rep->cycles_outside = w->cycles_outside;
        w->state = (uint8_t)MFNS_WS_INSIDE;
        w->cycles_outside = 0U;
    }
}

const char *mfns_ws_state_str(mfns_ws_state_t s)
{
    switch (s) {
    case MFNS_WS_INSIDE:
        return MFNS_MSG("inside");
    case MFNS_WS_OUTSIDE:
        return MFNS_MSG("outside");
    }
    return MFNS_MSG("?");
}
