/* linalg.c -- see linalg.h. */
#include "math/linalg.h"
#include "math/core_inline.h"

#include <math.h>

mfns_v3_t mfns_v3(float x, float y, float z)
{
    mfns_v3_t v = {x, y, z};
    return v;
}

mfns_v3_t mfns_v3_add(mfns_v3_t a, mfns_v3_t b) { return mfns_v3(a.x + b.x, a.y + b.y, a.z + b.z); }
mfns_v3_t mfns_v3_sub(mfns_v3_t a, mfns_v3_t b) { return mfns_v3(a.x - b.x, a.y - b.y, a.z - b.z); }
mfns_v3_t mfns_v3_scale(mfns_v3_t a, float s) { return mfns_v3(a.x * s, a.y * s, a.z * s); }
float mfns_v3_dot(mfns_v3_t a, mfns_v3_t b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

mfns_v3_t mfns_v3_cross(mfns_v3_t a, mfns_v3_t b)
{
    return mfns_v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

float mfns_v3_norm(mfns_v3_t a) { return sqrtf(mfns_v3_dot(a, a)); }

MFNS_OUT_OF_LINE
bool mfns_v3_normalize(mfns_v3_t a, mfns_v3_t *out)
{
    const float n = mfns_v3_norm(a);
    if (!(n > 1e-30f)) {
        *out = mfns_v3(0.0f, 0.0f, 0.0f);
        return false;
    }
    *out = mfns_v3_scale(a, 1.0f / n);
    return true;
}

mfns_m3_t mfns_m3_identity(void)
{
    mfns_m3_t r = {{{1.0f, 0.0f, 0.0f}, {0.0f, 1.0f, 0.0f}, {0.0f, 0.0f, 1.0f}}};
    return r;
}

void mfns_m3_mul_at(const mfns_m3_t *a, const mfns_m3_t *b, mfns_m3_t *out)
{
    mfns_m3_t r; /* out may be a or b */
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            r.m[i][j] = a->m[i][0] * b->m[0][j] + a->m[i][1] * b->m[1][j] + a->m[i][2] * b->m[2][j];
        }
    }
    *out = r;
}

mfns_m3_t mfns_m3_mul(mfns_m3_t a, mfns_m3_t b)
{
    mfns_m3_t r;
    mfns_m3_mul_at(&a, &b, &r);
    return r;
}

void mfns_m3_transpose_at(const mfns_m3_t *a, mfns_m3_t *out)
{
    mfns_m3_t r; /* out may be a */
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            r.m[i][j] = a->m[j][i];
        }
    }
    *out = r;
}

mfns_m3_t mfns_m3_transpose(mfns_m3_t a)
{
    mfns_m3_t r;
    mfns_m3_transpose_at(&a, &r);
    return r;
}

mfns_m3_t mfns_m3_add(mfns_m3_t a, mfns_m3_t b)
{
    mfns_m3_t r;
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            r.m[i][j] = a.m[i][j] + b.m[i][j];
        }
    }
    return r;
}

void mfns_m3_scale_at(const mfns_m3_t *a, float s, mfns_m3_t *out)
{
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            out->m[i][j] = a->m[i][j] * s; /* element by element: out may be a */
        }
    }
}

mfns_m3_t mfns_m3_scale(mfns_m3_t a, float s)
{
    mfns_m3_t r;
    mfns_m3_scale_at(&a, s, &r);
    return r;
}

mfns_v3_t mfns_m3_mul_v3_at(const mfns_m3_t *a, mfns_v3_t v)
{
    return mfns_v3(a->m[0][0] * v.x + a->m[0][1] * v.y + a->m[0][2] * v.z,
                   a->m[1][0] * v.x + a->m[1][1] * v.y + a->m[1][2] * v.z,
                   a->m[2][0] * v.x + a->m[2][1] * v.y + a->m[2][2] * v.z);
}

mfns_v3_t mfns_m3_mul_v3(mfns_m3_t a, mfns_v3_t v)
{
    return mfns_m3_mul_v3_at(&a, v);
}

mfns_v3_t mfns_m3_tmul_v3_at(const mfns_m3_t *a, mfns_v3_t v)
{
    return mfns_v3(a->m[0][0] * v.x + a->m[1][0] * v.y + a->m[2][0] * v.z,
                   a->m[0][1] * v.x + a->m[1][1] * v.y + a->m[2][1] * v.z,
                   a->m[0][2] * v.x + a->m[1][2] * v.y + a->m[2][2] * v.z);
}

mfns_v3_t mfns_m3_tmul_v3(mfns_m3_t a, mfns_v3_t v)
{
    return mfns_m3_tmul_v3_at(&a, v);
}

static float det_at(const mfns_m3_t *a)
{
    return a->m[0][0] * (a->m[1][1] * a->m[2][2] - a->m[1][2] * a->m[2][1]) -
           a->m[0][1] * (a->m[1][0] * a->m[2][2] - a->m[1][2] * a->m[2][0]) +
           a->m[0][2] * (a->m[1][0] * a->m[2][1] - a->m[1][1] * a->m[2][0]);
}

float mfns_m3_det(mfns_m3_t a)
{
    return det_at(&a);
}

MFNS_OUT_OF_LINE
mfns_m3_t mfns_m3_skew(mfns_v3_t a)
{
    mfns_m3_t r = {{{0.0f, -a.z, a.y}, {a.z, 0.0f, -a.x}, {-a.y, a.x, 0.0f}}};
    return r;
}

static float orthonormality_error_at(const mfns_m3_t *a)
{
    mfns_m3_t ata;
    mfns_m3_transpose_at(a, &ata);
    mfns_m3_mul_at(&ata, a, &ata);
    float worst = 0.0f;
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            const float e = fabsf(ata.m[i][j] - (i == j ? 1.0f : 0.0f));
            /* NaN must not look orthonormal: !(e <= worst) catches it. */
            if (!(e <= worst)) {
                worst = isnan(e) ? INFINITY : e;
            }
        }
    }
    return worst;
}

float mfns_m3_orthonormality_error(mfns_m3_t a)
{
    return orthonormality_error_at(&a);
}

bool mfns_m3_is_rotation_at(const mfns_m3_t *a, float tol)
{
    return orthonormality_error_at(a) <= tol && det_at(a) > 0.0f;
}

bool mfns_m3_is_rotation(mfns_m3_t a, float tol)
{
    return mfns_m3_is_rotation_at(&a, tol);
}

bool mfns_m3_reorthonormalize_at(const mfns_m3_t *a, int max_iter, float tol, mfns_m3_t *out)
{
    mfns_m3_t r = *a; /* out may be a */
    for (int it = 0; it < max_iter; it++) {
        if (orthonormality_error_at(&r) <= tol) {
            break;
        }
        mfns_m3_t rtr;
        mfns_m3_transpose_at(&r, &rtr);
        mfns_m3_mul_at(&rtr, &r, &rtr);
        mfns_m3_t k;
        mfns_m3_scale_at(&rtr, -0.5f, &k);
        for (int i = 0; i < 3; i++) {
            k.m[i][i] += 1.5f;
        }
        mfns_m3_mul_at(&r, &k, &r);
    }
    *out = r;
    return mfns_m3_is_rotation_at(&r, tol);
}

bool mfns_m3_reorthonormalize(mfns_m3_t a, int max_iter, float tol, mfns_m3_t *out)
{
    return mfns_m3_reorthonormalize_at(&a, max_iter, tol, out);
}
