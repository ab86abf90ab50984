/* linalg.h -- 3-vectors and 3x3 matrices in float, the working type of the
 * flight target. Small structs passed and returned by value: no aliasing
 * questions, no heap, and gcc keeps the vectors in registers. A matrix (36
 * bytes) is copied through the stack at every by-value call on a 32-bit
 * target, so the products also come by address (the *_at functions at the
 * end), which the flight core uses.
 *
 * Matrices are row-major: m[row][col]. All functions are pure and total
 * (defined for every finite input); none allocates or calls the OS.
 */
#ifndef MFNS_LINALG_H
#define MFNS_LINALG_H

#include <stdbool.h>

typedef struct {
    float x, y, z;
} mfns_v3_t;

typedef struct {
    float m[3][3];
} mfns_m3_t;

mfns_v3_t mfns_v3(float x, float y, float z);
mfns_v3_t mfns_v3_add(mfns_v3_t a, mfns_v3_t b);
mfns_v3_t mfns_v3_sub(mfns_v3_t a, mfns_v3_t b);
mfns_v3_t mfns_v3_scale(mfns_v3_t a, float s);
float mfns_v3_dot(mfns_v3_t a, mfns_v3_t b);
mfns_v3_t mfns_v3_cross(mfns_v3_t a, mfns_v3_t b);
float mfns_v3_norm(mfns_v3_t a);
/* Unit vector along a; returns false (and a zero vector) when |a| < 1e-30. */
bool mfns_v3_normalize(mfns_v3_t a, mfns_v3_t *out);

mfns_m3_t mfns_m3_identity(void);
mfns_m3_t mfns_m3_mul(mfns_m3_t a, mfns_m3_t b);
mfns_m3_t mfns_m3_transpose(mfns_m3_t a);
mfns_m3_t mfns_m3_add(mfns_m3_t a, mfns_m3_t b);
mfns_m3_t mfns_m3_scale(mfns_m3_t a, float s);
mfns_v3_t mfns_m3_mul_v3(mfns_m3_t a, mfns_v3_t v);
/* a^T v without forming the transpose. */
mfns_v3_t mfns_m3_tmul_v3(mfns_m3_t a, mfns_v3_t v);
float mfns_m3_det(mfns_m3_t a);
/* Skew-symmetric cross-product matrix: skew(a) v == a x v. */
mfns_m3_t mfns_m3_skew(mfns_v3_t a);

/* Largest |(A^T A - I)_ij|: 0 for an exact rotation or reflection. */
float mfns_m3_orthonormality_error(mfns_m3_t a);
/* True when A is a proper rotation: orthonormal to tol and det(A) > 0. */
bool mfns_m3_is_rotation(mfns_m3_t a, float tol);
/* Nearest rotation by symmetric re-orthonormalization, R <- R (3I - R^T R)/2,
 * applied up to max_iter times (bounded) until the orthonormality error is
 * below tol. Converges for inputs within ~0.5 of orthonormal (the drift left
 * by repeated float updates). Returns false when it did not reach tol or the
 * result is not a proper rotation; *out is then the last iterate. */
bool mfns_m3_reorthonormalize(mfns_m3_t a, int max_iter, float tol, mfns_m3_t *out);

/* The same products by address: the flight core's calls, where a matrix by
 * value is 36 bytes copied at every call on a 32-bit target (docs/budgets.md).
 * Each computes exactly what its by-value twin above computes (the by-value
 * functions call these); *out may be the same matrix as *a or *b. */
void mfns_m3_mul_at(const mfns_m3_t *a, const mfns_m3_t *b, mfns_m3_t *out);
void mfns_m3_transpose_at(const mfns_m3_t *a, mfns_m3_t *out);
void mfns_m3_scale_at(const mfns_m3_t *a, float s, mfns_m3_t *out);
mfns_v3_t mfns_m3_mul_v3_at(const mfns_m3_t *a, mfns_v3_t v);
mfns_v3_t mfns_m3_tmul_v3_at(const mfns_m3_t *a, mfns_v3_t v);
bool mfns_m3_is_rotation_at(const mfns_m3_t *a, float tol);
bool mfns_m3_reorthonormalize_at(const mfns_m3_t *a, int max_iter, float tol, mfns_m3_t *out);

#endif /* MFNS_LINALG_H */
