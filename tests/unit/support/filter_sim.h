/* filter_sim.h -- a double-precision truth for the navigation filter's tests
 * (tests/unit/test_nav_filter.c, test_filter_bank.c): a free-flying body
 * moved by the filter's own continuous white-acceleration model (exact
 * discretisation) or by a given acceleration, observed through the lens
 * model (pose_testlib.h pt_project) with Gaussian pixel noise, and the
 * filter's pose error against it (NEES). */
#ifndef MFNS_FILTER_SIM_H
#define MFNS_FILTER_SIM_H

#include "firmware/nav/filter/nav_filter.h"
#include "tests/unit/support/pose_testlib.h"

typedef struct {
    double C_w_b[3][3];
    double r_wb_w[3]; /* mm */
    double v_w[3];    /* mm/s */
    double w_w[3];    /* rad/s, world: C_b_w' = exp(w dt) C_b_w */
} fs_truth_t;

/* Move the truth on by dt (s): constant velocity plus, when rng is not NULL,
 * the exact discretisation of white acceleration of spectral densities q_lin
 * (mm^2/s^3) and q_ang (rad^2/s^3), plus a constant acceleration a_lin
 * (mm/s^2, may be NULL) over the step. */
void fs_truth_advance(fs_truth_t *x, double dt, double q_lin, double q_ang, const double a_lin[3],
                      mfns_rng_t *rng);

pt_dpose_t fs_truth_pose(const fs_truth_t *x);

/* The observations of camera cam of every map beacon in its image at the
 * truth, pixel noise sigma_px (rng), stamped t_us; beacon[] gets map
 * indices. Returns the count (<= max). */
int fs_observe(const mfns_rig_t *rig, const mfns_beacon_map_t *map, const fs_truth_t *x, int cam, double sigma_px,
               mfns_rng_t *rng, int64_t t_us, mfns_filter_obs_t *obs, int16_t *beacon, int max);

/* The pose error of f against the truth in the filter's order (phi_w rad,
 * dr_w mm; truth = estimate (+) e), and its NEES e^T P_pose^-1 e. */
void fs_pose_error(const mfns_filter_t *f, const fs_truth_t *x, double e[6]);
double fs_nees(const mfns_filter_t *f, const fs_truth_t *x);

/* A filter state drawn around the truth from the pose covariance of sigmas
 * sig_att_rad, sig_pos_mm (diagonal), the velocity prior sigma_v / sigma_w
 * drawn too: a consistent start. */
void fs_init_filter(mfns_filter_t *f, const fs_truth_t *x, double sig_att_rad, double sig_pos_mm, double sigma_v,
                    double sigma_w, int64_t t_us, mfns_rng_t *rng);

#endif
