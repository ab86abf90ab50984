/* nav_settings.h -- compile-time maxima and the run-time settings of the
 * navigation core that the calibration table carries (docs/caltable.md).
 * Shared by the table loader (caltable.c), the centroider (centroid.c) and the
 * pose solver (pose.c), so none of them depends on another's header.
 */
#ifndef MFNS_NAV_CONFIG_H
#define MFNS_NAV_CONFIG_H

#include <stdint.h>

#include "firmware/nav/generated/caltable_layout_gen.h"
#include "math/lens.h"

/* Compile-time maxima: every table and buffer of the core is sized by these. */
#define MFNS_MAX_BEACONS 256         /* beacons in the map (indices fit in a u8) */
#define MFNS_MAX_BLOBS_PER_CAMERA 64 /* blob table of the centroider, per camera */
#define MFNS_MAX_OBS_PER_CAMERA 32   /* corrected observations handed to the solver */
#define MFNS_MAX_GRID_NODES 16384    /* correction-grid nodes per camera (nx*ny): a k1 = -0.21 lens needs 15,429 for 0.01 px */
_Static_assert(MFNS_MAX_BEACONS <= 256, "beacon indices fit in a u8");
_Static_assert(MFNS_MAX_GRID_NODES >= 15429, "a k1 = -0.21 lens needs 15,429 nodes for 0.01 px");

typedef struct {
    uint16_t id;       /* beacon id as surveyed (telemetry reports it) */
    mfns_v3_t p_w;     /* position in the world frame (mm) */
    float sigma_mm;    /* 1-sigma of the position survey (mm) */
} mfns_beacon_t;

typedef struct {
    uint16_t count;
    mfns_beacon_t beacon[MFNS_MAX_BEACONS];
} mfns_beacon_map_t;

/* Centroiding (firmware/nav/centroid/centroid.h). */
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
/* The default gain (nav_defaults_gen.c): 102 / 4096 = 0.0249 DN/e- (40 e-/DN), a
 * machine-vision CMOS sensor at 0 dB read out in 8 bits (a ~10 ke- full well over 255 DN).
 * A table states the gain of its own camera; the number is the calibration table's default
 * (caltable_layout.toml, docs/caltable.md "Default settings"). */
#define MFNS_CENTROID_DEFAULT_GAIN_Q12 MFNS_CALTABLE_DEFAULT_GLOBALS_CENTROID_GAIN_DN_PER_E_Q12

/* Pose solve (firmware/nav/pose/pose.h). */
typedef struct {
    uint16_t max_iterations;    /* hard cap of the Gauss-Newton/LM refinement */
    float step_tol;             /* converged when |rotation step| (rad) and |translation step|/1000 mm below */
    float grad_tol;             /* or when the scaled gradient is below */
    float huber_k;              /* robust loss threshold on the whitened residual |L^-1 r| (sigmas) */
    float outlier_gate_sigma;   /* whitened residual |L^-1 r| beyond this marks an outlier (sigmas) */
    float max_residual_rms_sigma; /* NO_FIX when the whitened inlier RMS per coordinate exceeds this */
    float track_gate_px;        /* association gate when tracking */
    float min_rcond;            /* normal equations below this are singular geometry */
} mfns_solver_settings_t;

/* Integrity: fault detection and exclusion and the protection level
 * (firmware/nav/integrity/integrity.h, docs/pose.md "Integrity"). */
typedef struct {
    float alert_limit_pos_mm;  /* a fix is usable only with its position PL <= this (per world axis) */
    float alert_limit_att_deg; /* and its attitude PL <= this */
    float p_fa;                /* total false-alarm probability per fix, (0, 0.5) */
    float p_md;                /* missed-detection probability, (0, 0.5) */
    uint16_t hold_cycles;      /* an excluded beacon or camera stays out this many cycles */
    /* 1: a fix is usable only when every single-camera fault is bounded too
     * (monitorable and inside the alert limits). 0: a fix whose camera
     * faults cannot be bounded within the alert limits, but whose beacon
     * faults can, is usable as DEGRADED CAMERA_UNMONITORED: a camera fault
     * (a stale, late or frozen frame) is then left to the camera health
     * checks; camera hypotheses that are monitorable are still tested and
     * excluded. */
    uint8_t require_camera_monitor;
    /* 1: monitor only (a bench, never flight): a fix refused only for want of
     * redundancy or for its protection level is DEGRADED with that reason
     * instead of NO_FIX; a detected fault is still refused (nav_cycle.c). */
    uint8_t monitor_only;
} mfns_integrity_settings_t;

/* The motion bound and the navigation filter's settings (docs/caltable.md
 * "Motion bound"; firmware/nav/filter/nav_filter.h argues the model,
 * filter_bank.h the camera hypotheses' priors). */
typedef struct {
    float accel_bound_mm_s2;  /* unmodelled linear acceleration bound a_max */
    float alpha_bound_rad_s2; /* unmodelled angular acceleration bound alpha_max */
    float bound_time_s;       /* T: span over which Q overbounds a sustained bound */
    float max_coast_s;        /* longest time without an applied observation (E_TIME: restart), <= T */
    float gate_p;             /* per-observation gate false-alarm probability, (0, 0.5) */
    uint16_t gate_reject_run; /* consecutive gated observations that flag motion_exceeded */
    float aug_rot_rad;        /* a camera pointing fault's scale: steadies its per-frame fit (nav_filter.h) */
    float aug_dt_s;           /* the same for its time offset */
} mfns_filter_settings_t;

/* Calibration uncertainty (docs/caltable.md "Calibration covariance"): the
 * covariance of the calibration's errors (estimate minus truth), jointly over
 * the three cameras, MFNS_CALIB_PARAMS_PER_CAMERA parameters per camera in the
 * order of mfns_calib_param_t (camera x first). theta: small rotation error of
 * the mount about the body axes, C_k_b(est) = exp([theta]x) C_k_b(true); r:
 * error of r_bk_b (mm, body). Units px, unitless (distortion), rad, mm. */
typedef enum {
    MFNS_CALIB_FX = 0,
    MFNS_CALIB_FY,
    MFNS_CALIB_CX,
    MFNS_CALIB_CY,
    MFNS_CALIB_K1,
    MFNS_CALIB_K2,
    MFNS_CALIB_P1,
    MFNS_CALIB_P2,
    MFNS_CALIB_K3,
    MFNS_CALIB_THETA_X,
    MFNS_CALIB_THETA_Y,
    MFNS_CALIB_THETA_Z,
    MFNS_CALIB_R_X,
    MFNS_CALIB_R_Y,
    MFNS_CALIB_R_Z,
    MFNS_CALIB_PARAMS_PER_CAMERA
} mfns_calib_param_t;
#define MFNS_CALIB_PARAMS (MFNS_NUM_CAMERAS * MFNS_CALIB_PARAMS_PER_CAMERA)

typedef struct {
    uint8_t present; /* 0: not known (the table has none): no calibration term */
    float cov[MFNS_CALIB_PARAMS][MFNS_CALIB_PARAMS]; /* symmetric PSD; index = camera * 15 + param */
} mfns_calib_cov_t;

/* The beacon map's datum (docs/caltable.md "Map datum covariance"): the error the
 * whole map shares, a rigid motion of it -- a shift dt (mm) and a small turn dth
 * (rad) about c_w -- so that each surveyed position is p_w(table) = p_w(true) + dt
 * + dth x (p_w(true) - c_w) + its own relative error (the table's sigma_mm). A fix
 * moves rigidly with the map: the datum adds to the pose covariance once
 * (mfns_pose_datum_term), where written into every beacon's sigma_mm as
 * independent it would be multiplied by a weak geometry, and it leaves every
 * residual, gate and fault test unchanged. Order of cov: dt x, y, z, dth x, y, z. */
#define MFNS_MAP_DATUM_PARAMS 6
typedef struct {
    uint8_t present; /* 0: the table has none: no datum term */
    mfns_v3_t c_w;   /* mm, world */
    float cov[MFNS_MAP_DATUM_PARAMS][MFNS_MAP_DATUM_PARAMS]; /* symmetric PSD; mm^2, mm rad, rad^2 */
} mfns_map_datum_t;

/* The default settings: one set, used by the flight code's tests and tools
 * and written into every table by `mfns table build`. Generated
 * (nav_defaults_gen.c) from the table's definition, caltable_layout.toml, which
 * gives the reasons. */
void mfns_centroid_settings_default(mfns_centroid_settings_t *c);
void mfns_solver_settings_default(mfns_solver_settings_t *s);
void mfns_integrity_settings_default(mfns_integrity_settings_t *s);
void mfns_filter_settings_default(mfns_filter_settings_t *s);

#endif /* MFNS_NAV_CONFIG_H */
