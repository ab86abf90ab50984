/* cam_sync.c -- see cam_sync.h. */
#include "firmware/frames/cam_sync.h"

void cam_sync_init(cam_sync_t *s, uint32_t window_us)
{
    s->window_us = window_us;
    s->have_last = false;
    s->last_us = 0;
}

bool cam_sync_is_stale(const cam_sync_t *s, uint64_t t_us)
{
    return s->have_last && t_us <= s->last_us + s->window_us;
}

/* Candidates of the cycle within the window at and after t0. */
static unsigned within(const cam_sync_t *s, const bool *have, const uint64_t *t_us, unsigned n, uint64_t t0)
{
    unsigned m = 0;
    for (unsigned j = 0; j < n; j++) {
        m += (have[j] && t_us[j] >= t0 && t_us[j] - t0 <= s->window_us) ? 1u : 0u;
    }
    return m;
}

bool cam_sync_cycle(cam_sync_t *s, const bool *have, const uint64_t *t_us, unsigned n, cam_sync_verdict_t *v,
                    uint64_t *cycle_us)
{
    bool any = false;
    uint64_t ref = 0;
    unsigned best = 0;
    for (unsigned k = 0; k < n; k++) {
        v[k] = CAM_SYNC_NONE;
        if (!have[k]) {
            continue;
        }
        const unsigned m = within(s, have, t_us, n, t_us[k]);
        if (!any || m > best || (m == best && t_us[k] < ref)) {
            ref = t_us[k];
            best = m;
            any = true;
        }
    }
    if (!any) {
        return false;
    }
    for (unsigned k = 0; k < n; k++) {
        if (have[k]) {
            v[k] = t_us[k] < ref ? CAM_SYNC_BEHIND : t_us[k] - ref <= s->window_us ? CAM_SYNC_USE : CAM_SYNC_AHEAD;
        }
    }
    s->have_last = true;
    s->last_us = ref;
    *cycle_us = ref;
    return true;
}

int32_t cam_sync_offset_us(uint64_t t_us, uint64_t ref_us)
{
    if (t_us >= ref_us) {
        const uint64_t d = t_us - ref_us;
        return d > (uint64_t)INT32_MAX ? INT32_MAX : (int32_t)d;
    }
    const uint64_t d = ref_us - t_us;
    return d > (uint64_t)INT32_MAX ? -INT32_MAX : -(int32_t)d;
}

void cam_health_init(cam_health_t *h)
{
    h->state = CAM_HEALTH_UP;
    h->missed = 0;
    h->since_reopen = 0;
    h->outage = 0;
}

cam_health_event_t cam_health_update(cam_health_t *h, bool used)
{
    if (h->state == CAM_HEALTH_ENDED) {
        return CAM_HEALTH_EV_NONE;
    }
    if (used) {
        const bool was_down = h->state == CAM_HEALTH_LOST || h->state == CAM_HEALTH_OFF;
        h->outage = h->missed;
        h->missed = 0;
        h->since_reopen = 0;
        h->state = CAM_HEALTH_UP;
        return was_down ? CAM_HEALTH_EV_RECOVERED : CAM_HEALTH_EV_NONE;
    }
    if (h->missed < UINT32_MAX) {
        h->missed++;
    }
    if (h->state == CAM_HEALTH_UP && h->missed >= MFNS_CAM_LOST_CYCLES) {
        h->state = CAM_HEALTH_LOST;
        h->since_reopen = 0;
        return CAM_HEALTH_EV_LOST;
    }
    return CAM_HEALTH_EV_NONE;
}

bool cam_health_reopen_due(cam_health_t *h)
{
    if (h->state != CAM_HEALTH_LOST && h->state != CAM_HEALTH_OFF) {
        return false;
    }
    if (++h->since_reopen >= MFNS_CAM_REOPEN_CYCLES) {
        h->since_reopen = 0;
        return true;
    }
    return false;
}
