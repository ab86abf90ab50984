/* fixed.c -- see fixed.h. */
#include "math/fixed.h"

#include <math.h>

int32_t mfns_sat_i32(int64_t v)
{
    if (v > (int64_t)INT32_MAX) {
        return INT32_MAX;
    }
    if (v < (int64_t)INT32_MIN) {
        return INT32_MIN;
    }
    return (int32_t)v;
}

/* Scale by 2^frac_bits, round ties away from zero, saturate. The comparisons
 * are done in float against exactly representable limits (2^31). */
static bool from_float(float f, float scale, int32_t *out)
{
    if (isnan(f)) {
        *out = 0;
        return false;
    }
    const float x = roundf(f * scale);
    if (x >= 2147483648.0f) {
        *out = INT32_MAX;
        return false;
    }
    if (x < -2147483648.0f) {
        *out = INT32_MIN;
        return false;
    }
    *out = (int32_t)x;
    return true;
}

bool mfns_q16_from_float_checked(float f, q16_16_t *out) { return from_float(f, (float)MFNS_Q16_16_ONE, out); }

q16_16_t mfns_q16_from_float(float f)
{
    q16_16_t q;
    (void)from_float(f, (float)MFNS_Q16_16_ONE, &q); /* saturated value is the documented result */
    return q;
}

float mfns_q16_to_float(q16_16_t q) { return (float)q * (1.0f / (float)MFNS_Q16_16_ONE); }
q16_16_t mfns_q16_add_sat(q16_16_t a, q16_16_t b) { return mfns_sat_i32((int64_t)a + b); }
q16_16_t mfns_q16_sub_sat(q16_16_t a, q16_16_t b) { return mfns_sat_i32((int64_t)a - b); }

/* Round-to-nearest (ties away from zero) right shift of a signed value. */
static int64_t shift_round(int64_t v, int bits)
{
    const int64_t half = (int64_t)1 << (bits - 1);
    if (v >= 0) {
        return (v + half) >> bits;
    }
    return -((-v + half) >> bits);
}

q16_16_t mfns_q16_mul_sat(q16_16_t a, q16_16_t b)
{
    /* |a*b| < 2^62: the 64-bit product cannot overflow. */
    return mfns_sat_i32(shift_round((int64_t)a * b, MFNS_Q16_16_FRAC_BITS));
}

q16_16_t mfns_q16_lerp(q16_16_t a, q16_16_t b, q16_16_t t)
{
    /* (b - a) fits in 33 bits, t in 17: the product fits in int64. */
    const int64_t d = (int64_t)b - a;
    return mfns_sat_i32((int64_t)a + shift_round(d * t, MFNS_Q16_16_FRAC_BITS));
}

px_q8_t mfns_px_q8_from_float(float f)
{
    px_q8_t p;
    (void)from_float(f, (float)MFNS_PX_Q8_ONE, &p); /* saturated value is the documented result */
    return p;
}

bool mfns_px_q8_from_float_checked(float f, px_q8_t *out) { return from_float(f, (float)MFNS_PX_Q8_ONE, out); }
float mfns_px_q8_to_float(px_q8_t p) { return (float)p * (1.0f / (float)MFNS_PX_Q8_ONE); }
px_q8_t mfns_px_q8_add_sat(px_q8_t a, px_q8_t b) { return mfns_sat_i32((int64_t)a + b); }

bool mfns_px_q8_from_ratio(int64_t num, int64_t den, px_q8_t *out)
{
    if (den <= 0) {
        *out = 0;
        return false;
    }
    /* round(256 num / den) without overflow: split num into quotient and
     * remainder first, so 256 * num is never formed for large num. */
    const int64_t q = num / den;
    const int64_t r = num % den; /* same sign as num */
    if (q > ((int64_t)INT32_MAX >> MFNS_PX_Q8_FRAC_BITS) || q < ((int64_t)INT32_MIN >> MFNS_PX_Q8_FRAC_BITS)) {
        *out = q > 0 ? INT32_MAX : INT32_MIN;
        return false;
    }
    /* r * 256 may overflow only if |den| > 2^55, which no image produces;
     * guard anyway. */
    if (den > ((int64_t)1 << 54)) {
        *out = 0;
        return false;
    }
    const int64_t r256 = r * MFNS_PX_Q8_ONE;
    int64_t frac = r256 / den;
    const int64_t rem = r256 % den;
    if (2 * (rem < 0 ? -rem : rem) >= den) {
        frac += (rem < 0) ? -1 : 1;
    }
    *out = mfns_sat_i32(q * MFNS_PX_Q8_ONE + frac);
    return true;
}
