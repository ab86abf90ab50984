/* rotation.c -- see rotation.h. */
#include "math/rotation.h"

#include <math.h>

mfns_m3_t mfns_rot_r1(float a)
{
    const float c = cosf(a), s = sinf(a);
    mfns_m3_t r = {{{1.0f, 0.0f, 0.0f}, {0.0f, c, s}, {0.0f, -s, c}}};
    return r;
}

mfns_m3_t mfns_rot_r2(float a)
{
    const float c = cosf(a), s = sinf(a);
    mfns_m3_t r = {{{c, 0.0f, -s}, {0.0f, 1.0f, 0.0f}, {s, 0.0f, c}}};
    return r;
}

mfns_m3_t mfns_rot_r3(float a)
{
    const float c = cosf(a), s = sinf(a);
    mfns_m3_t r = {{{c, s, 0.0f}, {-s, c, 0.0f}, {0.0f, 0.0f, 1.0f}}};
    return r;
}

mfns_m3_t mfns_euler213_to_m3(mfns_euler_t e)
{
    /* Multiplied out (docs/system.md §2) rather than three products: fewer roundings. */
    const float cf = cosf(e.roll), sf = sinf(e.roll);
    const float ct = cosf(e.pitch), st = sinf(e.pitch);
    const float cp = cosf(e.yaw), sp = sinf(e.yaw);
    mfns_m3_t c = {{
        {cp * ct + sp * st * sf, sp * cf, -cp * st + sp * ct * sf},
        {-sp * ct + cp * st * sf, cp * cf, sp * st + cp * ct * sf},
        {cf * st, -sf, ct * cf},
    }};
    return c;
}

bool mfns_m3_to_euler213_at(const mfns_m3_t *c, mfns_euler_t *e)
{
    /* r32 = -sin(roll); r31 = cos(roll) sin(pitch), r33 = cos(roll) cos(pitch);
     * r12 = sin(yaw) cos(roll), r22 = cos(yaw) cos(roll). */
    const float cos_roll = sqrtf(c->m[2][0] * c->m[2][0] + c->m[2][2] * c->m[2][2]);
    e->roll = atan2f(-c->m[2][1], cos_roll);
    if (cos_roll < MFNS_EULER_SINGULAR_COS) {
        /* roll = +-90: r11 = cos(yaw -+ pitch), r21 = -sin(yaw -+ pitch). */
        e->pitch = 0.0f;
        e->yaw = atan2f(-c->m[1][0], c->m[0][0]);
        return false;
    }
    e->pitch = atan2f(c->m[2][0], c->m[2][2]);
    e->yaw = atan2f(c->m[0][1], c->m[1][1]);
    return true;
}

bool mfns_m3_to_euler213(mfns_m3_t c, mfns_euler_t *e)
{
    return mfns_m3_to_euler213_at(&c, e);
}

mfns_m3_t mfns_rot_small_angle(mfns_v3_t a)
{
    mfns_m3_t r = {{{1.0f, a.z, -a.y}, {-a.z, 1.0f, a.x}, {a.y, -a.x, 1.0f}}};
    return r;
}

mfns_m3_t mfns_rot_exp(mfns_v3_t w)
{
    const float th2 = mfns_v3_dot(w, w);
    const float th = sqrtf(th2);
    float a, b; /* R = I + a K + b K^2, K = skew(w) */
    if (th < 1e-4f) {
        a = 1.0f - th2 / 6.0f;
        b = 0.5f - th2 / 24.0f;
    } else {
        a = sinf(th) / th;
        b = (1.0f - cosf(th)) / th2;
    }
    const mfns_m3_t k = mfns_m3_skew(w);
    mfns_m3_t k2;
    mfns_m3_mul_at(&k, &k, &k2);
    mfns_m3_t r = mfns_m3_identity();
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            r.m[i][j] += a * k.m[i][j] + b * k2.m[i][j];
        }
    }
    return r;
}

mfns_v3_t mfns_rot_log(mfns_m3_t r)
{
    const float tr = r.m[0][0] + r.m[1][1] + r.m[2][2];
    float cos_th = 0.5f * (tr - 1.0f);
    cos_th = cos_th > 1.0f ? 1.0f : (cos_th < -1.0f ? -1.0f : cos_th);
    /* vee(R - R^T) = 2 sin(th) axis */
    const mfns_v3_t v = mfns_v3(r.m[2][1] - r.m[1][2], r.m[0][2] - r.m[2][0], r.m[1][0] - r.m[0][1]);
    const float sin_th = 0.5f * mfns_v3_norm(v);
    const float th = atan2f(sin_th, cos_th);
    if (th < 1e-4f) {
        return mfns_v3_scale(v, 0.5f * (1.0f + th * th / 6.0f));
    }
    if (th < 2.0f) {
        return mfns_v3_scale(v, 0.5f * th / sin_th);
    }
    /* Large angles: sin(th) is small and v loses relative precision, so take
     * the axis from the symmetric part (R + R^T)/2 - cos(th) I = (1 - cos th) n n^T,
     * whose largest diagonal gives a well-conditioned column, and only the
     * sign of n from v (valid unless th == pi, where both signs are right). */
    int k = 0;
    if (r.m[1][1] > r.m[k][k]) {
        k = 1;
    }
    if (r.m[2][2] > r.m[k][k]) {
        k = 2;
    }
    mfns_v3_t col;
    col.x = 0.5f * (r.m[0][k] + r.m[k][0]);
    col.y = 0.5f * (r.m[1][k] + r.m[k][1]);
    col.z = 0.5f * (r.m[2][k] + r.m[k][2]);
    if (k == 0) {
        col.x -= cos_th;
    } else if (k == 1) {
        col.y -= cos_th;
    } else {
        col.z -= cos_th;
    }
    mfns_v3_t n;
    if (!mfns_v3_normalize(col, &n)) {
        return mfns_v3(0.0f, 0.0f, 0.0f);
    }
    if (mfns_v3_dot(n, v) < 0.0f) {
        n = mfns_v3_scale(n, -1.0f);
    }
    return mfns_v3_scale(n, th);
}

float mfns_rot_angle_between_at(const mfns_m3_t *ra, const mfns_m3_t *rb)
{
    mfns_m3_t d;
    mfns_m3_transpose_at(ra, &d);
    mfns_m3_mul_at(&d, rb, &d);
    return mfns_v3_norm(mfns_rot_log(d));
}

float mfns_rot_angle_between(mfns_m3_t ra, mfns_m3_t rb)
{
    return mfns_rot_angle_between_at(&ra, &rb);
}

void mfns_m3_to_quat(mfns_m3_t r, float q_wxyz[4])
{
    const float tr = r.m[0][0] + r.m[1][1] + r.m[2][2];
    /* 4 q_i^2 for i = w, x, y, z from the diagonal */
    const float d[4] = {1.0f + tr, 1.0f + r.m[0][0] - r.m[1][1] - r.m[2][2],
                        1.0f - r.m[0][0] + r.m[1][1] - r.m[2][2], 1.0f - r.m[0][0] - r.m[1][1] + r.m[2][2]};
    int k = 0;
    for (int i = 1; i < 4; i++) {
        if (d[i] > d[k]) {
            k = i;
        }
    }
    const float s4 = 2.0f * sqrtf(d[k] > 0.0f ? d[k] : 0.0f); /* 4 |q_k| */
    const float inv = s4 > 0.0f ? 1.0f / s4 : 0.0f;
    /* off-diagonal combinations: 4 q_w q_x, 4 q_w q_y, 4 q_w q_z, 4 q_x q_y, 4 q_x q_z, 4 q_y q_z */
    const float wx = r.m[2][1] - r.m[1][2], wy = r.m[0][2] - r.m[2][0], wz = r.m[1][0] - r.m[0][1];
    const float xy = r.m[0][1] + r.m[1][0], xz = r.m[0][2] + r.m[2][0], yz = r.m[1][2] + r.m[2][1];
    float q[4];
    if (k == 0) {
        q[0] = 0.25f * s4, q[1] = wx * inv, q[2] = wy * inv, q[3] = wz * inv;
    } else if (k == 1) {
        q[0] = wx * inv, q[1] = 0.25f * s4, q[2] = xy * inv, q[3] = xz * inv;
    } else if (k == 2) {
        q[0] = wy * inv, q[1] = xy * inv, q[2] = 0.25f * s4, q[3] = yz * inv;
    } else {
        q[0] = wz * inv, q[1] = xz * inv, q[2] = yz * inv, q[3] = 0.25f * s4;
    }
    const float n2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
    const float sgn = q[0] < 0.0f ? -1.0f : 1.0f;
    const float scale = n2 > 0.0f ? sgn / sqrtf(n2) : 0.0f;
    for (int i = 0; i < 4; i++) {
        q_wxyz[i] = q[i] * scale;
    }
}
