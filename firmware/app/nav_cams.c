/* nav_cams.c -- see nav_cams.h. */
#include "firmware/app/nav_cams.h"

#include <limits.h>
#include <stdio.h>
#include <string.h>

#include "drivers/camera/camera_v4l2.h"

#define RECOVER_ATTEMPTS 20 /* driver-level recovery tries before it reports the camera gone */

_Static_assert(FH_MAX_CAMERAS == MFNS_NUM_CAMERAS, "the health monitor watches every camera");

static const char k_letter[MFNS_NUM_CAMERAS] = {'x', 'y', 'z'};

static void send_event(nav_tlm_t *tlm, uint32_t cycle, uint64_t t_us, tlm_event_code_t code, tlm_severity_t sev,
                       int k, int32_t a0, int32_t a1)
{
    (void)nav_tlm_event(tlm, cycle, t_us, code, sev, (uint8_t)k, a0, a1); /* failures counted in tlm */
}

void nav_cams_init(nav_cams_t *cs, uint32_t sync_window_us)
{
    memset(cs, 0, sizeof *cs);
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        cs->cam[k].letter = k_letter[k];
        cs->cam[k].enabled = true;
    }
    cam_sync_init(&cs->sync, sync_window_us);
    fh_init(&cs->health, MFNS_NUM_CAMERAS);
}

/* Opens and starts camera k; with resume (a re-open), a replay camera goes
 * on after frame time after_us instead of from its first frame. */
static mfns_cam_err_t open_camera(nav_cam_t *c, const nav_opts_t *o, int k, bool resume, uint64_t after_us,
                                  char *msg, size_t msg_size)
{
    /* a V4L2 camera named by identity (bus_info:, card:) is looked up at each
     * (re-)open: a camera plugged in late, or renumbered, is found again */
    char dev[MFNS_CAM_MSG_LEN]; /* a /dev/videoN or the identity as given (camera.c checks its length) */
    const char *path = o->cam_path[k];
    if (o->backend == MFNS_CAM_BACKEND_V4L2) {
        if (mfns_cam_v4l2_resolve(path, NULL, dev, sizeof dev, msg, msg_size) != 0) {
            return MFNS_CAM_E_OPEN;
        }
        path = dev;
    }
    mfns_cam_settings_t s = mfns_cam_default_settings(o->backend, path);
    s.replay_camera = c->letter;
    s.replay_realtime = o->realtime;
    s.replay_resume = resume;
    s.replay_resume_after_ns = after_us * 1000u;
    s.recover_attempts = RECOVER_ATTEMPTS;
    s.width = c->width;
    s.height = c->height;
    mfns_cam_err_t e = mfns_cam_open(&s, &c->cam, msg, msg_size);
    if (e != MFNS_CAM_OK) {
        return e;
    }
    e = mfns_cam_start(c->cam);
    if (e != MFNS_CAM_OK) {
        (void)snprintf(msg, msg_size, "start: %s", mfns_cam_message(c->cam));
        mfns_cam_close(c->cam);
        c->cam = NULL;
    }
    return e;
}

int nav_cams_open(nav_cams_t *cs, const nav_opts_t *o, const mfns_caltable_t *table)
{
    int opened = 0;
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        nav_cam_t *c = &cs->cam[k];
        cam_health_init(&c->health);
        c->width = table->rig.cam[k].k.width;
        c->height = table->rig.cam[k].k.height;
        char msg[MFNS_CAM_MSG_LEN];
        const mfns_cam_err_t e = open_camera(c, o, k, false, 0, msg, sizeof msg);
        c->open_err = e;
        if (e != MFNS_CAM_OK) {
            /* a live camera missing at start: reported, the others run, and it
             * is re-opened like a camera lost later; a replay's is an input error */
            fprintf(stderr, "mfns-nav: camera %c (%s): %s: %s\n", c->letter, o->cam_path[k], mfns_cam_strerror(e), msg);
            c->last_err = e;
            if (o->backend == MFNS_CAM_BACKEND_REPLAY) {
                return -1;
            }
            continue;
        }
        opened++;
    }
    if (opened == 0) {
        fprintf(stderr, "mfns-nav: no camera opened\n");
        return -1;
    }
    return 0;
}

/* One stderr line per fault, the first NAV_CAMS_FAULT_LINES of each kind per camera. */
static void fault_line(uint32_t *printed, char letter, const char *line)
{
    if (*printed >= NAV_CAMS_FAULT_LINES + 1u) {
        return;
    }
    if (++*printed > NAV_CAMS_FAULT_LINES) {
        fprintf(stderr, "mfns-nav: camera %c: further faults of this kind in telemetry only\n", letter);
        return;
    }
    fprintf(stderr, "mfns-nav: camera %c: %s\n", letter, line);
}

static int32_t sat_i32(int64_t v)
{
    return v > INT32_MAX ? INT32_MAX : v < -INT32_MAX ? -INT32_MAX : (int32_t)v;
}

/* A health monitor event of camera k: telemetry, and one stderr line (the
 * first NAV_CAMS_FAULT_LINES of each kind). */
static void health_event(nav_cam_t *c, int k, nav_tlm_t *tlm, uint32_t cycle, uint64_t t_us, fh_event_t ev)
{
    char line[192];
    tlm_event_code_t code;
    tlm_severity_t sev = TLM_SEV_WARNING;
    switch (ev.kind) {
    case FH_EV_FROZEN:
        code = TLM_EVT_CAMERA_FROZEN;
        (void)snprintf(line, sizeof line, "cycle %u: frame %lld %s: frozen, left out", cycle, (long long)ev.arg1,
                       ev.arg0 == 0 ? "has the previous frame's content" : "repeats the previous sequence number");
        break;
    case FH_EV_CLOCK_JUMP:
        code = TLM_EVT_CAMERA_CLOCK_JUMP;
        (void)snprintf(line, sizeof line,
                       "cycle %u: frame %lld: clock stepped by %.3f ms against its cadence: left out", cycle,
                       (long long)ev.arg1, (double)ev.arg0 * 1e-3);
        break;
    case FH_EV_LATE:
        code = TLM_EVT_CAMERA_LATE;
        (void)snprintf(line, sizeof line, "cycle %u: frame %lld arrived %.3f ms after its capture stamp: left out",
                       cycle, (long long)ev.arg1, (double)ev.arg0 * 1e-3);
        break;
    case FH_EV_SEQ_MISMATCH:
        code = TLM_EVT_CAMERA_SEQ_MISMATCH;
        (void)snprintf(line, sizeof line,
                       "cycle %u: sequence numbers disagree with camera %c's by %lld frames for the frames' times: "
                       "left out",
                       cycle, (char)('x' + (int)ev.arg1), (long long)ev.arg0);
        break;
    case FH_EV_CLOCK_DRIFT:
        code = TLM_EVT_CAMERA_CLOCK_DRIFT;
        (void)snprintf(line, sizeof line,
                       "cycle %u: stamps drift %.3f ms against camera %c's beyond their jitter: clock in doubt", cycle,
                       (double)ev.arg0 * 1e-3, (char)('x' + (int)ev.arg1));
        break;
    case FH_EV_HEALTHY:
        code = TLM_EVT_CAMERA_HEALTHY;
        sev = TLM_SEV_INFO;
        (void)snprintf(line, sizeof line,
                       "cycle %u: healthy again after %lld fault-free frames (clock correction %.3f ms)", cycle,
                       (long long)ev.arg0, (double)ev.arg1 * 1e-3);
        break;
    case FH_EV_NONE:
    default: return;
    }
    /* every fault of a frame's time or content puts the camera's clock in
     * doubt: the frames it delivers after it may be stamped right and show
     * another time (a stale camera after a drop, a frozen pipeline) */
    c->timing_doubt = c->timing_doubt || ev.kind != FH_EV_HEALTHY;
    send_event(tlm, cycle, t_us, code, sev, k, sat_i32(ev.arg0), sat_i32(ev.arg1));
    fault_line(&c->lines_health[ev.kind], c->letter, line);
}

static fh_ts_source_t fh_source(mfns_cam_ts_source_t s)
{
    switch (s) {
    case MFNS_CAM_TS_MONOTONIC_SOE: return FH_TS_CAPTURE_SOE;
    case MFNS_CAM_TS_MONOTONIC_EOF: return FH_TS_CAPTURE_EOF;
    case MFNS_CAM_TS_COPY: return FH_TS_COPY;
    case MFNS_CAM_TS_RECORDED: return FH_TS_RECORDED;
    case MFNS_CAM_TS_UNKNOWN:
    default: return FH_TS_UNKNOWN;
    }
}

static bool to_nav_frame(const mfns_cam_frame_t *f, mfns_frame_t *nf);

/* A fresh frame of camera k through the health monitor: its stamp corrected
 * by the camera's clock re-alignment; false when the camera is held out. */
static bool health_check(nav_cams_t *cs, int k, nav_tlm_t *tlm, uint32_t cycle, uint64_t event_t_us)
{
    nav_cam_t *c = &cs->cam[k];
    mfns_cam_frame_t *fr = &c->frame;
    mfns_frame_t nf;
    const bool image = to_nav_frame(fr, &nf);
    bool flat = true;
    const uint64_t digest = image ? fh_digest(&nf, &flat) : 0u;
    const fh_frame_t in = {
        .sequence = fr->sequence,
        .dropped_before = fr->dropped_before,
        .capture_us = fr->timestamp_ns / 1000u,
        .arrival_us = fr->arrival_ns / 1000u,
        .arrival_valid = fr->arrival_ns != 0u,
        .ts_source = fh_source(fr->ts_source),
        .digest = digest,
        .digest_valid = image && !flat, /* a uniform frame has nothing to freeze */
    };
    health_event(c, k, tlm, cycle, event_t_us, fh_observe(&cs->health, (unsigned)k, &in));
    if (!fh_usable(&cs->health, (unsigned)k)) {
        return false;
    }
    const int64_t t_ns = (int64_t)fr->timestamp_ns + fh_correction_us(&cs->health, (unsigned)k) * 1000;
    fr->timestamp_ns = t_ns > 0 ? (uint64_t)t_ns : 0u;
    return true;
}

/* A frame the health monitor leaves out: given back at once. */
static void hold_out(nav_cams_t *cs, nav_cam_t *c)
{
    c->held_out = true;
    c->n_held_out++;
    if (mfns_cam_requeue(c->cam, &c->frame) != MFNS_CAM_OK) {
        cs->errors++;
    }
}

/* A dequeue that gave no frame: counted, reported, and the camera's state
 * moved on (ENDED at the end of a replay, OFF when the device is gone). */
static void dequeue_failed(nav_cams_t *cs, nav_cam_t *c, int k, nav_tlm_t *tlm, const nav_opts_t *o, uint32_t cycle,
                           uint64_t event_t_us, mfns_cam_err_t e)
{
    c->last_err = e;
    if (e == MFNS_CAM_E_END) {
        c->ended = true;
    } else if (e == MFNS_CAM_E_DATA) {
        c->n_rejected++;
        cs->errors++;
        send_event(tlm, cycle, event_t_us, TLM_EVT_FRAME_REJECTED, TLM_SEV_WARNING, k, (int32_t)e,
                   (int32_t)c->n_rejected);
        char line[256];
        (void)snprintf(line, sizeof line, "cycle %u: frame rejected: %s", cycle, mfns_cam_message(c->cam));
        fault_line(&c->lines_rejected, c->letter, line);
    } else {
        cs->errors++; /* timeout, device lost or recovering, I/O: no frame this cycle */
        if (e == MFNS_CAM_E_TIMEOUT) {
            c->n_timeouts++;
        }
        if (e == MFNS_CAM_E_NO_DEVICE) {
            c->health.state = CAM_HEALTH_OFF;
        }
        if (o->verbose) {
            fprintf(stderr, "mfns-nav: cycle %u camera %c: %s: %s\n", cycle, c->letter, mfns_cam_strerror(e),
                    mfns_cam_message(c->cam));
        }
    }
}

/* The frame of camera k for this cycle, into c->frame: the one held from an
 * earlier cycle, or a fresh one; stale frames are given back and the camera
 * asked again (bounded) so it catches up. Returns true with a frame. */
static bool gather_one(nav_cams_t *cs, int k, nav_tlm_t *tlm, const nav_opts_t *o, uint32_t cycle,
                       uint64_t event_t_us)
{
    nav_cam_t *c = &cs->cam[k];
    mfns_cam_frame_t *fr = &c->frame;
    if (c->have_held) {
        *fr = c->held; /* checked (and its stamp corrected) when it came */
        c->have_held = false;
        fh_present_again(&cs->health, (unsigned)k, fr->sequence, fr->timestamp_ns / 1000u);
        return true;
    }
    if (!c->cam || c->health.state == CAM_HEALTH_ENDED) {
        return false;
    }
    /* a camera already down is asked without waiting: it never stalls the others */
    const bool down = c->health.state != CAM_HEALTH_UP;
    for (int attempt = 0; attempt < NAV_CAMS_STALE_TRIES; attempt++) {
        /* after a stale frame the fresh one may still be on its way: wait for it as usual */
        const mfns_cam_err_t e = mfns_cam_dequeue(c->cam, fr, down ? 0 : o->frame_timeout_ms);
        if (e != MFNS_CAM_OK) {
            dequeue_failed(cs, c, k, tlm, o, cycle, event_t_us, e);
            return false;
        }
        /* a device the driver re-opened by itself (recovery) restarts its sequence numbers */
        c->driver_events |= mfns_cam_take_events(c->cam);
        if ((c->driver_events & MFNS_CAM_EV_RECOVERED) != 0U && !c->recovery_seen) {
            c->recovery_seen = true;
            fh_reopened(&cs->health, (unsigned)k, o->backend == MFNS_CAM_BACKEND_REPLAY);
        }
        if (c->enabled && !health_check(cs, k, tlm, cycle, event_t_us)) {
            hold_out(cs, c); /* one frame per cycle: its frames keep pace with the others' */
            return false;
        }
        const uint64_t t = fr->timestamp_ns / 1000u;
        if (!cam_sync_is_stale(&cs->sync, t)) {
            return true;
        }
        c->n_stale++;
        const int32_t off = cam_sync_offset_us(t, cs->sync.last_us);
        send_event(tlm, cycle, event_t_us, TLM_EVT_CAMERA_STALE, TLM_SEV_WARNING, k, off, (int32_t)fr->sequence);
        char line[192];
        (void)snprintf(line, sizeof line,
                       "cycle %u: frame %u at %.6f s is stale (%.1f ms after the last cycle's %.6f s): dropped", cycle,
                       fr->sequence, (double)t * 1e-6, (double)off * 1e-3, (double)cs->sync.last_us * 1e-6);
        fault_line(&c->lines_stale, c->letter, line);
        (void)mfns_cam_requeue(c->cam, fr); /* a stale frame given back: a failure shows at the next dequeue */
    }
    return false;
}

int nav_cams_gather(nav_cams_t *cs, nav_tlm_t *tlm, const nav_opts_t *o, uint32_t cycle, uint64_t event_t_us)
{
    int active = 0;
    fh_begin_cycle(&cs->health);
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        nav_cam_t *c = &cs->cam[k];
        memset(&c->frame, 0, sizeof c->frame);
        c->used = false;
        c->held_out = false;
        c->ended = false;
        c->verdict = CAM_SYNC_NONE;
        c->have = gather_one(cs, k, tlm, o, cycle, event_t_us);
        if (c->have && !c->enabled) {
            /* CAMERA_DISABLE: its frames keep flowing (no driver backlog) but are not fused */
            if (mfns_cam_requeue(c->cam, &c->frame) != MFNS_CAM_OK) {
                cs->errors++;
            }
            c->have = false;
        }
        if (c->health.state != CAM_HEALTH_ENDED && !c->ended) {
            active++;
        }
    }
    return active;
}

void nav_cams_report_ended(nav_cams_t *cs, nav_tlm_t *tlm, uint32_t cycle, uint64_t t_us)
{
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        nav_cam_t *c = &cs->cam[k];
        if (!c->ended) {
            continue;
        }
        c->health.state = CAM_HEALTH_ENDED;
        if (c->ended_reported) {
            continue;
        }
        c->ended_reported = true;
        cs->errors++;
        mfns_cam_stats_t st;
        memset(&st, 0, sizeof st);
        (void)mfns_cam_get_stats(c->cam, &st); /* zeros on failure are the honest answer */
        send_event(tlm, cycle, t_us, TLM_EVT_CAMERA_ENDED, TLM_SEV_WARNING, k, (int32_t)c->last_seq,
                   (int32_t)(st.frames > INT32_MAX ? INT32_MAX : st.frames));
        fprintf(stderr,
                "mfns-nav: camera %c: recorded frames ended at cycle %u (last frame %u) while other cameras go on\n",
                c->letter, cycle, c->last_seq);
    }
}

/* The driver's frame as the navigator reads it; false for a pixel format it
 * does not know or a payload shorter than the image. */
static bool to_nav_frame(const mfns_cam_frame_t *f, mfns_frame_t *nf)
{
    mfns_pixfmt_t fmt;
    switch (f->pixfmt) {
    case MFNS_CAM_PIX_GREY: fmt = MFNS_PIXFMT_GREY; break;
    case MFNS_CAM_PIX_Y10: fmt = MFNS_PIXFMT_Y10; break;
    case MFNS_CAM_PIX_Y12: fmt = MFNS_PIXFMT_Y12; break;
    case MFNS_CAM_PIX_Y16: fmt = MFNS_PIXFMT_Y16; break;
    default: return false;
    }
    if (f->width > UINT16_MAX || f->height > UINT16_MAX || (uint64_t)f->stride * f->height > f->bytesused) {
        return false; /* short payload: never centroid past the data */
    }
    *nf = (mfns_frame_t){f->data, (uint16_t)f->width, (uint16_t)f->height, f->stride, fmt};
    return true;
}

/* An out-of-step frame: left out of this cycle, kept for the one it belongs to. */
static void hold_ahead(nav_cam_t *c, int k, nav_tlm_t *tlm, uint32_t cycle, uint64_t t_us)
{
    const uint64_t t_frame = c->frame.timestamp_ns / 1000u;
    c->held = c->frame;
    c->have_held = true;
    c->n_ahead++;
    c->timing_doubt = true; /* the cycle's own frame never came: what follows may be a period stale */
    const int32_t off = cam_sync_offset_us(t_frame, t_us);
    send_event(tlm, cycle, t_us, TLM_EVT_CAMERA_OUT_OF_STEP, TLM_SEV_WARNING, k, off, (int32_t)c->frame.sequence);
    char line[192];
    (void)snprintf(line, sizeof line,
                   "cycle %u: frame %u at %.6f s is %.1f ms ahead of the cycle's %.6f s (out of step): "
                   "held for a later cycle",
                   cycle, c->frame.sequence, (double)t_frame * 1e-6, (double)off * 1e-3, (double)t_us * 1e-6);
    fault_line(&c->lines_ahead, c->letter, line);
}

/* A frame older than the majority's cycle (cam_sync.h BEHIND): no cycle will
 * take it, so it is given back; reported as stale, and its camera's clock is
 * in doubt (it was held a cycle ago for being ahead, or runs late). */
static void drop_behind(nav_cams_t *cs, nav_cam_t *c, int k, nav_tlm_t *tlm, uint32_t cycle, uint64_t t_us)
{
    const uint64_t t_frame = c->frame.timestamp_ns / 1000u;
    c->n_stale++;
    c->timing_doubt = true;
    const int32_t off = cam_sync_offset_us(t_frame, t_us);
    send_event(tlm, cycle, t_us, TLM_EVT_CAMERA_STALE, TLM_SEV_WARNING, k, off, (int32_t)c->frame.sequence);
    char line[192];
    (void)snprintf(line, sizeof line,
                   "cycle %u: frame %u at %.6f s is %.1f ms behind the other cameras' %.6f s (out of step): dropped",
                   cycle, c->frame.sequence, (double)t_frame * 1e-6, (double)-off * 1e-3, (double)t_us * 1e-6);
    fault_line(&c->lines_stale, c->letter, line);
    if (mfns_cam_requeue(c->cam, &c->frame) != MFNS_CAM_OK) {
        cs->errors++;
    }
}

uint64_t nav_cams_synchronise(nav_cams_t *cs, nav_tlm_t *tlm, uint32_t cycle, uint64_t clock_t_us,
                              const mfns_frame_t *frames[MFNS_NUM_CAMERAS])
{
    bool have[MFNS_NUM_CAMERAS];
    uint64_t t_frame[MFNS_NUM_CAMERAS];
    cam_sync_verdict_t verdict[MFNS_NUM_CAMERAS];
    /* the cameras' sequence numbers against each other, before any frame can set the cycle's time */
    fh_event_t ev[FH_MAX_CAMERAS];
    fh_cross_check(&cs->health, ev);
    const uint64_t event_t_us = cs->sync.have_last ? cs->sync.last_us : clock_t_us;
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        nav_cam_t *c = &cs->cam[k];
        health_event(c, k, tlm, cycle, event_t_us, ev[k]);
        /* a clock drifting against the others stays in doubt while it does (the event comes once) */
        c->timing_doubt = c->timing_doubt || fh_drift_suspect(&cs->health, (unsigned)k);
        if (c->have && c->enabled && !fh_usable(&cs->health, (unsigned)k)) {
            hold_out(cs, c);
            c->have = false;
        }
    }
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        have[k] = cs->cam[k].have;
        t_frame[k] = cs->cam[k].frame.timestamp_ns / 1000u;
    }
    uint64_t t_us = 0;
    if (!cam_sync_cycle(&cs->sync, have, t_frame, MFNS_NUM_CAMERAS, verdict, &t_us)) {
        /* no camera delivered (or every one held out): the last fused cycle's
         * frame time moved on by the program's clock since, so the stamps
         * stay on the frames' time base and never step back; before any
         * frame, the program's clock */
        t_us = cs->sync.have_last ? cs->sync.last_us + (clock_t_us - cs->last_fused_clock_us) : clock_t_us;
    } else {
        cs->last_fused_clock_us = clock_t_us;
    }
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        nav_cam_t *c = &cs->cam[k];
        c->verdict = verdict[k];
        frames[k] = NULL;
        if (verdict[k] == CAM_SYNC_AHEAD) {
            hold_ahead(c, k, tlm, cycle, t_us);
        } else if (verdict[k] == CAM_SYNC_BEHIND) {
            drop_behind(cs, c, k, tlm, cycle, t_us);
        } else if (verdict[k] == CAM_SYNC_USE) {
            c->last_seq = c->frame.sequence;
            if (to_nav_frame(&c->frame, &c->nav_frame)) {
                frames[k] = &c->nav_frame;
                c->used = true;
            } else {
                c->last_err = MFNS_CAM_E_DATA;
                cs->errors++;
            }
        }
    }
    return t_us;
}

void nav_cams_give_back_used(nav_cams_t *cs)
{
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        nav_cam_t *c = &cs->cam[k];
        if (c->verdict == CAM_SYNC_USE && mfns_cam_requeue(c->cam, &c->frame) != MFNS_CAM_OK) {
            cs->errors++;
        }
    }
}

void nav_cams_driver_events(nav_cams_t *cs, nav_tlm_t *tlm, uint32_t cycle, uint64_t t_us, uint64_t now_ms)
{
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        nav_cam_t *c = &cs->cam[k];
        const uint32_t ev = c->driver_events | (c->cam ? mfns_cam_take_events(c->cam) : 0u);
        c->driver_events = 0;
        c->recovery_seen = false;
        if ((ev & MFNS_CAM_EV_LOST) != 0U) {
            c->lost_at_ms = now_ms;
            send_event(tlm, cycle, t_us, TLM_EVT_CAMERA_LOST, TLM_SEV_WARNING, k, MFNS_CAM_E_LOST, 0);
        }
        if ((ev & MFNS_CAM_EV_RECOVERED) != 0U) {
            send_event(tlm, cycle, t_us, TLM_EVT_CAMERA_RECOVERED, TLM_SEV_INFO, k, (int32_t)(now_ms - c->lost_at_ms),
                       0);
        }
        if ((ev & MFNS_CAM_EV_RECOVERY_FAILED) != 0U) {
            c->health.state = CAM_HEALTH_OFF;
            send_event(tlm, cycle, t_us, TLM_EVT_CAMERA_LOST, TLM_SEV_ERROR, k, MFNS_CAM_E_NO_DEVICE, 0);
        }
    }
}

/* A camera down for MFNS_CAM_REOPEN_CYCLES: closed and opened again, a
 * replay going on after the cycle's frame time (on the camera's own clock:
 * the cycle's time less its clock correction). */
static void reopen(nav_cams_t *cs, nav_cam_t *c, int k, const nav_opts_t *o, uint64_t t_us)
{
    c->n_reopens++;
    mfns_cam_close(c->cam);
    c->cam = NULL;
    c->have_held = false;
    /* replay carries on with the recorded frame numbers; a device restarts its counter */
    fh_reopened(&cs->health, (unsigned)k, o->backend == MFNS_CAM_BACKEND_REPLAY);
    const int64_t own = (int64_t)t_us - fh_correction_us(&cs->health, (unsigned)k);
    char msg[MFNS_CAM_MSG_LEN];
    const mfns_cam_err_t e = open_camera(c, o, k, true, own > 0 ? (uint64_t)own : 0u, msg, sizeof msg);
    if (e != MFNS_CAM_OK) {
        c->last_err = e;
        if (o->verbose) {
            fprintf(stderr, "mfns-nav: camera %c: re-open: %s: %s\n", c->letter, mfns_cam_strerror(e), msg);
        }
    }
}

void nav_cams_update_health(nav_cams_t *cs, nav_tlm_t *tlm, const nav_opts_t *o, uint32_t cycle, uint64_t t_us)
{
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        nav_cam_t *c = &cs->cam[k];
        if (!c->enabled) {
            continue; /* disabled by command: neither LOST nor re-opened */
        }
        /* a camera the data health monitor holds out still delivers: not lost */
        const cam_health_event_t ev = cam_health_update(&c->health, c->used || c->held_out);
        if (ev == CAM_HEALTH_EV_LOST) {
            c->n_lost++;
            send_event(tlm, cycle, t_us, TLM_EVT_CAMERA_LOST, TLM_SEV_WARNING, k, (int32_t)c->last_err,
                       (int32_t)c->health.missed);
            fprintf(stderr, "mfns-nav: camera %c lost: no valid frame for %u cycles (cycle %u; last: %s)\n", c->letter,
                    c->health.missed, cycle, mfns_cam_strerror(c->last_err));
        } else if (ev == CAM_HEALTH_EV_RECOVERED) {
            c->n_recovered++;
            const uint64_t outage_us = t_us - c->last_used_us;
            send_event(tlm, cycle, t_us, TLM_EVT_CAMERA_RECOVERED, TLM_SEV_INFO, k,
                       (int32_t)(outage_us / 1000u > INT32_MAX ? INT32_MAX : outage_us / 1000u),
                       (int32_t)c->health.outage);
            fprintf(stderr, "mfns-nav: camera %c recovered at cycle %u after %u cycles (%.1f ms of frame time)\n",
                    c->letter, cycle, c->health.outage, (double)outage_us * 1e-3);
        }
        if (c->used) {
            c->last_used_us = t_us;
        }
        if (cam_health_reopen_due(&c->health)) {
            reopen(cs, c, k, o, t_us);
        }
    }
}

bool nav_cams_all_gone(const nav_cams_t *cs)
{
    bool all_off = true;
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        const cam_health_state_t s = cs->cam[k].health.state;
        all_off = all_off && (s == CAM_HEALTH_OFF || s == CAM_HEALTH_ENDED);
    }
    return all_off;
}

uint8_t nav_cams_enabled_mask(const nav_cams_t *cs)
{
    unsigned m = 0;
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        m |= cs->cam[k].enabled ? (1u << k) : 0u;
    }
    return (uint8_t)m;
}

void nav_cams_release_held(nav_cams_t *cs)
{
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        nav_cam_t *c = &cs->cam[k];
        if (c->have_held) {
            (void)mfns_cam_requeue(c->cam, &c->held); /* the camera closes next: nothing to count */
            c->have_held = false;
        }
    }
}

void nav_cams_close(nav_cams_t *cs)
{
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        mfns_cam_close(cs->cam[k].cam);
        cs->cam[k].cam = NULL;
    }
}

void nav_cams_print_faults(const nav_cams_t *cs)
{
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        const nav_cam_t *c = &cs->cam[k];
        const fh_cam_t *h = &cs->health.cam[k];
        if (h->n_frozen + h->n_clock + h->n_late + h->n_seq > 0) {
            fprintf(stderr,
                    "mfns-nav: camera %c health: %u frozen, %u clock faults, %u late, %u out of step, %u back healthy, "
                    "%u frames left out, now %s\n",
                    c->letter, h->n_frozen, h->n_clock, h->n_late, h->n_seq, h->n_healthy, c->n_held_out,
                    fh_state_name(h->state));
        }
        if (c->n_stale + c->n_ahead + c->n_rejected + c->n_timeouts + c->n_lost + (c->ended_reported ? 1u : 0u) > 0) {
            fprintf(stderr,
                    "mfns-nav: camera %c faults: %u rejected, %u stale, %u out of step, %u timeouts, %u lost, "
                    "%u recovered, %u re-opens%s\n",
                    c->letter, c->n_rejected, c->n_stale, c->n_ahead, c->n_timeouts, c->n_lost, c->n_recovered,
                    c->n_reopens, c->ended_reported ? ", frames ended early" : "");
        }
    }
}

/* The camera's state: the link's when it is off or ended, else the data
 * health monitor's when it holds the camera out, else the link's. */
static uint8_t camera_state(const nav_cams_t *cams, const mfns_nav_output_t *out, int k)
{
    const nav_cam_t *c = &cams->cam[k];
    switch (c->health.state) {
    case CAM_HEALTH_OFF: return TLM_CAM_OFF;
    case CAM_HEALTH_ENDED: return TLM_CAM_ENDED;
    case CAM_HEALTH_LOST:
    case CAM_HEALTH_UP: break;
    }
    switch (fh_state(&cams->health, (unsigned)k)) {
    case FH_PROBATION: return TLM_CAM_PROBATION;
    case FH_FROZEN: return TLM_CAM_FROZEN;
    case FH_CLOCK_FAULT: return TLM_CAM_CLOCK_FAULT;
    case FH_LATE: return TLM_CAM_LATE;
    case FH_OUT_OF_STEP: return TLM_CAM_OUT_OF_STEP;
    case FH_HEALTHY:
    case FH_STATE_COUNT: break;
    }
    if (c->health.state == CAM_HEALTH_LOST) {
        return TLM_CAM_LOST;
    }
    /* integrity's holds (integrity_lag.h) describe frames the camera gave:
     * without one this cycle it is SKIPPED, what the operator must see first */
    if (c->have && out->cam_held[k] == 2U) {
        return TLM_CAM_LAGGING; /* its frames lag */
    }
    if (c->have && out->cam_held[k] == 3U) {
        return TLM_CAM_LAG_VERIFY;
    }
    if (c->have && out->cameras.state[k] == 1U) {
        return TLM_CAM_INCONSISTENT; /* no spot where the other cameras' fix puts a beacon */
    }
    if (c->have && out->cameras.state[k] == 2U) {
        return TLM_CAM_DISAGREES; /* no spot where the one other camera's fix puts a beacon */
    }
    return c->used ? TLM_CAM_OK : TLM_CAM_SKIPPED;
}

void nav_cams_packets(const nav_cams_t *cams, nav_tlm_t *t, const mfns_nav_output_t *out, uint32_t cycle,
                      uint64_t t_us)
{
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        const nav_cam_t *cs = &cams->cam[k];
        tlm_packet_t p;
        memset(&p, 0, sizeof p);
        p.type = TLM_TYPE_CAMERA;
        p.time = tlm_time_from_us(t_us);
        tlm_camera_t *c = &p.u.camera;
        mfns_cam_stats_t st;
        memset(&st, 0, sizeof st);
        if (cs->cam) {
            (void)mfns_cam_get_stats(cs->cam, &st); /* zeros on failure are the honest answer */
        }
        c->cycle = cycle;
        c->camera = (uint8_t)k;
        c->state = camera_state(cams, out, k);
        c->blobs = (uint8_t)(out->cam[k].blobs > 255 ? 255 : out->cam[k].blobs);
        c->beacons_identified = (uint8_t)out->cam[k].identified;
        c->exposure_us = cs->used && cs->frame.exposure_us > 0 ? (uint32_t)cs->frame.exposure_us : 0;
        /* a frame the health monitor left out still names its sequence number */
        c->frame_seq = cs->used || cs->held_out ? cs->frame.sequence : 0;
        c->frames_dropped = (uint32_t)(st.dropped > UINT32_MAX ? UINT32_MAX : st.dropped);
        (void)nav_tlm_send(t, &p); /* failures counted in encode_errors */
    }
}
