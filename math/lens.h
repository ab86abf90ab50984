/* lens.h -- the MFNS imaging model (docs/system.md §3, Eqs. 1-2): pinhole with
 * skew, the 5-coefficient Bouguet/OpenCV distortion, three cameras rigidly on
 * the body, and the body pose in the world. Pixel convention: integer
 * coordinates are pixel centres (docs/conventions.md).
 *
 * Pose parametrisation and its increment (what the pose solver linearises):
 *   p_b = C_w_b p_w + r_bw_b              (world point in the body frame)
 *   p_k = C_k_b^T (p_b - r_bk_b)          (in camera k)
 *   increment d = (dtheta[3] rad, dt[3] mm):
 *     C_w_b <- exp(dtheta) C_w_b,  r_bw_b <- r_bw_b + dt
 *   (rotation updated on the manifold, perturbation in the body frame).
 */
#ifndef MFNS_CAMERA_H
#define MFNS_CAMERA_H

#include <stdbool.h>
#include <stdint.h>

#include "math/linalg.h"

#define MFNS_NUM_CAMERAS 3
/* Points closer than this in front of the pinhole are "behind" (mm). */
#define MFNS_CAM_MIN_DEPTH_MM 1.0f

typedef struct {
    float fx, fy;    /* alpha_x, alpha_y (px) */
    float cx, cy;    /* u0, v0 (px) */
    float skew;      /* gamma (px) */
    float dist[5];   /* k1 k2 p1 p2 k3 */
    uint16_t width;  /* image size (px) */
    uint16_t height;
} mfns_intrinsics_t;

typedef struct {
    mfns_intrinsics_t k;
    mfns_m3_t C_k_b;   /* camera -> body */
    mfns_v3_t r_bk_b;  /* body origin -> camera centre, body frame (mm) */
} mfns_camera_t;

typedef struct {
    mfns_camera_t cam[MFNS_NUM_CAMERAS];
} mfns_rig_t;

typedef struct {
    mfns_m3_t C_w_b;   /* world -> body */
    mfns_v3_t r_bw_b;  /* body origin -> world origin, body frame (mm) */
} mfns_pose_t;

typedef enum {
    MFNS_PROJ_OK = 0,
    MFNS_PROJ_BEHIND, /* depth < MFNS_CAM_MIN_DEPTH_MM: no image */
} mfns_proj_status_t;

/* Distort normalized coordinates (x, y) -> (xd, yd). When jac is not NULL it
 * receives d(xd, yd)/d(x, y) row-major. */
void mfns_cam_distort(const mfns_intrinsics_t *k, float x, float y, float *xd, float *yd,
                      float jac[2][2]);
/* (xd, yd) -> pixel (u, v), and its inverse (pixel -> distorted normalized). */
void mfns_cam_distorted_to_pixel(const mfns_intrinsics_t *k, float xd, float yd, float *u, float *v);
void mfns_cam_pixel_to_distorted(const mfns_intrinsics_t *k, float u, float v, float *xd, float *yd);

/* Point in the camera frame (mm) -> pixel. jac (nullable) = d(u,v)/d(p_c). */
mfns_proj_status_t mfns_cam_project_c(const mfns_intrinsics_t *k, mfns_v3_t p_c, float uv[2],
                                      float jac[2][3]);

/* World point through the body pose and camera mount -> pixel. jac (nullable)
 * = d(u,v)/d(increment) with the increment defined at the top of this file:
 * columns 0-2 dtheta (px/rad), 3-5 dt (px/mm). */
mfns_proj_status_t mfns_cam_project(const mfns_camera_t *cam, const mfns_pose_t *pose, mfns_v3_t p_w,
                                    float uv[2], float jac[2][6]);

/* Chain rule from the camera frame to the pose increment: given rows
 * jc = d(f)/d(p_c) of any two-valued function f of p_c, and q = C_w_b p_w (the
 * rotated world point, body frame), jac = d(f)/d(increment), columns 0-2
 * dtheta, 3-5 dt. One owner for the projection's and paper mode's Jacobians. */
void mfns_cam_chain_pose_jac(const mfns_camera_t *cam, mfns_v3_t q, const float jc[2][3], float jac[2][6]);

/* World point -> camera frame (mm). */
mfns_v3_t mfns_cam_world_to_camera(const mfns_camera_t *cam, const mfns_pose_t *pose, mfns_v3_t p_w);

/* True when (u, v) lies on the sensor: [-0.5, W-0.5) x [-0.5, H-0.5). */
bool mfns_cam_in_image(const mfns_intrinsics_t *k, float u, float v);

/* Navigation output of a pose: body position in the world r_wb_w = -C_w_b^T r_bw_b. */
mfns_v3_t mfns_pose_position_w(const mfns_pose_t *pose);
/* Pose from the body position in the world and C_w_b. */
mfns_pose_t mfns_pose_from_position(mfns_m3_t C_w_b, mfns_v3_t r_wb_w);
/* The same with C_w_b by address (no 36-byte copy; linalg.h's *_at). */
mfns_pose_t mfns_pose_from_position_at(const mfns_m3_t *C_w_b, mfns_v3_t r_wb_w);
/* Apply an increment d (see top of file). */
mfns_pose_t mfns_pose_apply(const mfns_pose_t *pose, const float d[6]);

#endif /* MFNS_CAMERA_H */
