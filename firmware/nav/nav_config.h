/* nav_config.h -- compile-time maxima and the run-time settings of the
 * navigation core that the calibration table carries (docs/caltable.md).
 * Shared by the table loader (caltable.c), the centroider (centroid.c) and the
 * pose solver (pose.c), so none of them depends on another's header.
 */
#ifndef MFNS_NAV_CONFIG_H
#define MFNS_NAV_CONFIG_H

#include <stdint.h>

#include "camera.h"

/* Compile-time maxima: every table and buffer of the core is sized by these. */
#define MFNS_MAX_BEACONS 256         /* beacons in the map (indices fit in a u8) */
#define MFNS_MAX_BLOBS_PER_CAMERA 64 /* blob table of the centroider, per camera */
#define MFNS_MAX_OBS_PER_CAMERA 32   /* corrected observations handed to the solver */
#define MFNS_MAX_GRID_NODES 16384    /* correction-grid nodes per camera (nx*ny): a k1 = -0.21 lens needs 15,429 for 0.01 px */

typedef struct {
    uint16_t id;       /* beacon id as surveyed (telemetry reports it) */
    mfns_v3_t p_w;     /* position in the world frame (mm) */
    float sigma_mm;    /* 1-sigma of the position survey (mm) */
} mfns_beacon_t;

typedef struct {
    uint16_t count;
    mfns_beacon_t beacon[MFNS_MAX_BEACONS];
} mfns_beacon_map_t;

/* Centroiding (firmware/nav/centroid.h). */
typedef struct {
    uint16_t threshold_dn;      /* fixed threshold above background (DN); 0 = k_sigma rule */
    float threshold_k_sigma;    /* threshold = background + k * noise sigma */
    uint16_t min_area_px;       /* smaller blobs rejected (noise, hot pixels) */
    uint16_t max_area_px;       /* larger blobs rejected (reflections, glare) */
    float max_elongation;       /* ratio of second-moment eigenvalues, >= 1 */
    uint16_t roi_half_size_px;  /* tracking window half size around a prediction */
    uint16_t saturation_dn;     /* pixel value treated as saturated (0 = max of format) */
    uint16_t gain_dn_per_e_q12; /* sensor system gain K (DN per electron, EMVA 1288), Q4.12
                                   (MFNS_GAIN_Q12_ONE = 1 DN/e-): the shot-noise variance of a
                                   pixel grows by K DN^2 per DN of signal; the centroid
                                   covariance uses it (docs/centroiding.md). 0 = no shot-noise
                                   term (read-noise-limited sensor) */
} mfns_centroid_settings_t;
/* Q4.12 of gain_dn_per_e_q12: 1/4096 DN/e- per unit, at most 16 DN/e-. */
#define MFNS_GAIN_Q12_ONE 4096.0f
/* The default gain (nav_defaults.c, centroid.c): 102 / 4096 = 0.0249 DN/e- (40 e-/DN), a
 * machine-vision CMOS sensor at 0 dB read out in 8 bits (a ~10 ke- full well over 255 DN).
 * A table states the gain of its own camera; docs/caltable.md "Default settings". */
#define MFNS_CENTROID_DEFAULT_GAIN_Q12 102u

/* Pose solve (firmware/nav/pose.h). */
typedef struct {
    uint16_t max_iterations;    /* hard cap of the Gauss-Newton/LM refinement */
    float step_tol;             /* converged when |rotation step| (rad) and |translation step|/1000 mm below */
    float grad_tol;             /* or when the scaled gradient is below */
    float huber_k;              /* robust loss threshold, in units of pixel sigma */
    float outlier_gate_sigma;   /* residual beyond gate * sigma marks an outlier */
    float max_residual_rms_px;  /* NO_FIX when the inlier RMS exceeds this */
    float track_gate_px;        /* association gate when tracking */
    float min_rcond;            /* normal equations below this are singular geometry */
} mfns_solver_settings_t;

/* The default settings: one set, used by the flight code's tests and tools
 * and written into every table by `mfns table build` (which reads them from
 * here through the shared library). nav_defaults.c gives the reasons. */
void mfns_centroid_settings_default(mfns_centroid_settings_t *c);
void mfns_solver_settings_default(mfns_solver_settings_t *s);

#endif /* MFNS_NAV_CONFIG_H */
