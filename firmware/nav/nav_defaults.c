/* nav_defaults.c -- the one set of default settings (nav_config.h,
 * beacon_index.h). The host tools read them through the shared library, so a
 * table built with defaults carries exactly these numbers; docs/caltable.md
 * "Default settings" lists them with the same reasons. */
#include <string.h>

#include "beacon_index.h"
#include "nav_config.h"

void mfns_centroid_settings_default(mfns_centroid_settings_t *c)
{
    memset(c, 0, sizeof *c);
    c->threshold_dn = 0;          /* use the adaptive k-sigma rule (noise varies with exposure) */
    c->threshold_k_sigma = 6.0f;  /* ~1e-9 false alarms per pixel: < 1 per 1.3 Mpx frame */
    c->min_area_px = 3;           /* hot pixels and single-pixel noise; a defocused LED covers >= 3x3 */
    c->max_area_px = 2000;        /* ~50 px diameter: larger is glare or a reflection */
    c->max_elongation = 3.0f;     /* LED spots are round; streaks and edges are not */
    c->roi_half_size_px = 32;     /* ~30 px of motion between frames at 18.6 fps */
    c->saturation_dn = 0;         /* the pixel format's maximum */
    c->gain_dn_per_e_q12 = MFNS_CENTROID_DEFAULT_GAIN_Q12; /* 40 e-/DN: 8-bit CMOS at 0 dB (nav_config.h) */
}

void mfns_solver_settings_default(mfns_solver_settings_t *s)
{
    memset(s, 0, sizeof *s);
    s->max_iterations = 20;        /* LM converges in < 10 from a tracking prediction: hard cap */
    s->step_tol = 1e-6f;           /* rad, and mm/1000: far below what the system achieves */
    s->grad_tol = 1e-6f;           /* scaled gradient */
    s->huber_k = 3.0f;             /* whitened sigmas: quadratic up to 3 sigma, robust beyond */
    s->outlier_gate_sigma = 30.0f; /* 3 px at 0.1 px: calibration errors give ~1-2 px, a wrong match tens */
    /* whitened RMS per coordinate: 20 sigma is the former 2 px at the former
     * fixed 0.1 px, the calibration-limited few px; a wrong identification or
     * desynchronised frames give tens of px, hundreds of sigma */
    s->max_residual_rms_sigma = 20.0f;
    s->track_gate_px = 20.0f;      /* association gate around a tracked prediction */
    s->min_rcond = 1e-7f;          /* float normal equations below this are singular geometry */
}

void mfns_bidx_params_default(mfns_bidx_params_t *p)
{
    memset(p, 0, sizeof *p);
    p->k_nbr = MFNS_BIDX_MAX_NBR; /* rank of the third blob's beacon: p99 23 in a 200-beacon map */
    p->cert_inliers = MFNS_BIDX_MIN_CERT; /* replaced by the map analysis (acquire_certify.c) */
    p->max_missing = 1;           /* one predicted beacon may be hidden (occlusion, image edge) */
    p->max_unexplained = 1;       /* one blob may be a reflection (no beacon) */
    /* ~16 ms of search per cycle on the benchmark host (0.9-1.3 us per unit,
     * docs/pose.md): under the 20 ms per-cycle p99 of issue 11 and a third of
     * the 53.8 ms frame period at 18.6 Hz, the rest for centroiding and
     * telemetry. A search that needs more goes on over the next cycles
     * (acquire_cycle.h). A slower flight board needs a smaller number. */
    p->budget_units = 15000u;
}
