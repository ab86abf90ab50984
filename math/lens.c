/* lens.c -- see lens.h. */
#include "math/lens.h"

#include <stddef.h>

#include "math/rotation.h"

void mfns_cam_distort(const mfns_intrinsics_t *k, float x, float y, float *xd, float *yd,
                      float jac[2][2])
{
    const float k1 = k->dist[0], k2 = k->dist[1], p1 = k->dist[2], p2 = k->dist[3], k3 = k->dist[4];
    const float r2 = x * x + y * y;
    const float radial = 1.0f + r2 * (k1 + r2 * (k2 + r2 * k3));
    *xd = x * radial + 2.0f * p1 * x * y + p2 * (r2 + 2.0f * x * x);
    *yd = y * radial + p1 * (r2 + 2.0f * y * y) + 2.0f * p2 * x * y;
    if (jac != NULL) {
        /* d radial / d r2 */
        const float dr = k1 + r2 * (2.0f * k2 + 3.0f * k3 * r2);
        jac[0][0] = radial + 2.0f * x * x * dr + 2.0f * p1 * y + 6.0f * p2 * x;
        jac[0][1] = 2.0f * x * y * dr + 2.0f * p1 * x + 2.0f * p2 * y;
        jac[1][0] = 2.0f * x * y * dr + 2.0f * p1 * x + 2.0f * p2 * y;
        jac[1][1] = radial + 2.0f * y * y * dr + 6.0f * p1 * y + 2.0f * p2 * x;
    }
}

void mfns_cam_distorted_to_pixel(const mfns_intrinsics_t *k, float xd, float yd, float *u, float *v)
{
    *u = k->fx * xd + k->skew * yd + k->cx;
    *v = k->fy * yd + k->cy;
}

void mfns_cam_pixel_to_distorted(const mfns_intrinsics_t *k, float u, float v, float *xd, float *yd)
{
    *yd = (v - k->cy) / k->fy;
    *xd = (u - k->cx - k->skew * *yd) / k->fx;
}

mfns_proj_status_t mfns_cam_project_c(const mfns_intrinsics_t *k, mfns_v3_t p_c, float uv[2],
                                      float jac[2][3])
{
    if (!(p_c.z >= MFNS_CAM_MIN_DEPTH_MM)) {
        return MFNS_PROJ_BEHIND;
    }
    const float iz = 1.0f / p_c.z;
    const float x = p_c.x * iz, y = p_c.y * iz;
    float xd, yd, dd[2][2];
    mfns_cam_distort(k, x, y, &xd, &yd, jac != NULL ? dd : NULL);
    mfns_cam_distorted_to_pixel(k, xd, yd, &uv[0], &uv[1]);
    if (jac != NULL) {
        /* d(u,v)/d(xd,yd) = [[fx, skew], [0, fy]]; d(x,y)/d(p_c) = [[1/z, 0, -x/z], [0, 1/z, -y/z]] */
        const float a00 = k->fx * dd[0][0] + k->skew * dd[1][0];
        const float a01 = k->fx * dd[0][1] + k->skew * dd[1][1];
        const float a10 = k->fy * dd[1][0];
        const float a11 = k->fy * dd[1][1];
        jac[0][0] = a00 * iz;
        jac[0][1] = a01 * iz;
        jac[0][2] = -(a00 * x + a01 * y) * iz;
        jac[1][0] = a10 * iz;
        jac[1][1] = a11 * iz;
        jac[1][2] = -(a10 * x + a11 * y) * iz;
    }
    return MFNS_PROJ_OK;
}

void mfns_cam_chain_pose_jac(const mfns_camera_t *cam, mfns_v3_t q, const float jc[2][3], float jac[2][6])
{
    /* d p_c / d p_b = C_k_b^T; d p_b / d dtheta = -skew(q); d p_b / d dt = I. */
    for (int r = 0; r < 2; r++) {
        /* row r of d f/d p_b = jc C_k_b^T, i.e. C_k_b jc_r */
        const mfns_v3_t row = mfns_m3_mul_v3_at(&cam->C_k_b, mfns_v3(jc[r][0], jc[r][1], jc[r][2]));
        /* jb * (-skew(q)) = (q x jb_row)^T as a row: -jb . (e_i x q) = (q x jb)_i */
        const mfns_v3_t rot = mfns_v3_cross(q, row);
        jac[r][0] = rot.x;
        jac[r][1] = rot.y;
        jac[r][2] = rot.z;
        jac[r][3] = row.x;
        jac[r][4] = row.y;
        jac[r][5] = row.z;
    }
}

mfns_v3_t mfns_cam_world_to_camera(const mfns_camera_t *cam, const mfns_pose_t *pose, mfns_v3_t p_w)
{
    const mfns_v3_t p_b = mfns_v3_add(mfns_m3_mul_v3_at(&pose->C_w_b, p_w), pose->r_bw_b);
    return mfns_m3_tmul_v3_at(&cam->C_k_b, mfns_v3_sub(p_b, cam->r_bk_b));
}

mfns_proj_status_t mfns_cam_project(const mfns_camera_t *cam, const mfns_pose_t *pose, mfns_v3_t p_w,
                                    float uv[2], float jac[2][6])
{
    const mfns_v3_t q = mfns_m3_mul_v3_at(&pose->C_w_b, p_w); /* rotated world point, body frame */
    const mfns_v3_t p_b = mfns_v3_add(q, pose->r_bw_b);
    const mfns_v3_t p_c = mfns_m3_tmul_v3_at(&cam->C_k_b, mfns_v3_sub(p_b, cam->r_bk_b));
    float jc[2][3];
    const mfns_proj_status_t st = mfns_cam_project_c(&cam->k, p_c, uv, jac != NULL ? jc : NULL);
    if (st != MFNS_PROJ_OK || jac == NULL) {
        return st;
    }
    mfns_cam_chain_pose_jac(cam, q, jc, jac);
    return MFNS_PROJ_OK;
}

bool mfns_cam_in_image(const mfns_intrinsics_t *k, float u, float v)
{
    return u >= -0.5f && v >= -0.5f && u < (float)k->width - 0.5f && v < (float)k->height - 0.5f;
}

mfns_v3_t mfns_pose_position_w(const mfns_pose_t *pose)
{
    return mfns_v3_scale(mfns_m3_tmul_v3_at(&pose->C_w_b, pose->r_bw_b), -1.0f);
}

mfns_pose_t mfns_pose_from_position_at(const mfns_m3_t *C_w_b, mfns_v3_t r_wb_w)
{
    mfns_pose_t p;
    p.r_bw_b = mfns_v3_scale(mfns_m3_mul_v3_at(C_w_b, r_wb_w), -1.0f);
    p.C_w_b = *C_w_b;
    return p;
}

mfns_pose_t mfns_pose_from_position(mfns_m3_t C_w_b, mfns_v3_t r_wb_w)
{
    return mfns_pose_from_position_at(&C_w_b, r_wb_w);
}

mfns_pose_t mfns_pose_apply(const mfns_pose_t *pose, const float d[6])
{
    mfns_pose_t p;
    const mfns_m3_t dc = mfns_rot_exp(mfns_v3(d[0], d[1], d[2]));
    mfns_m3_mul_at(&dc, &pose->C_w_b, &p.C_w_b);
    p.r_bw_b = mfns_v3_add(pose->r_bw_b, mfns_v3(d[3], d[4], d[5]));
    return p;
}
