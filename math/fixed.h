/* fixed.h -- the fixed-point formats of the flight code. Every integer that
 * carries a fraction uses one of these types and says so in its name.
 *
 * q16_16_t  signed Q16.16 in int32_t: value = raw / 2^16.
 *           Range [-32768, 32768 - 2^-16], resolution 1.53e-5.
 *           Used for the distortion-correction grid and general fractions.
 * px_q8_t   pixel coordinate, signed Q23.8 in int32_t: value = raw / 256 px.
 *           Resolution 1/256 px (0.0039 px), range +-8.4e6 px, far beyond any
 *           sensor. The centroider's output format (u_q8, v_q8).
 *
 * Rounding: conversions from float and from ratios round to nearest, ties away
 * from zero. Arithmetic saturates at the type's limits instead of wrapping
 * (wrap-around in a coordinate would be a silent gross error). Conversions
 * from NaN give 0 and report failure through the _checked variants.
 */
#ifndef MFNS_FIXED_H
#define MFNS_FIXED_H

#include <stdbool.h>
#include <stdint.h>

typedef int32_t q16_16_t;
typedef int32_t px_q8_t;

#define MFNS_Q16_16_FRAC_BITS 16
#define MFNS_Q16_16_ONE ((q16_16_t)65536)
#define MFNS_Q16_16_MAX INT32_MAX
#define MFNS_Q16_16_MIN INT32_MIN
#define MFNS_PX_Q8_FRAC_BITS 8
#define MFNS_PX_Q8_ONE ((px_q8_t)256)
#define MFNS_PX_Q8_MAX INT32_MAX
#define MFNS_PX_Q8_MIN INT32_MIN
_Static_assert(MFNS_Q16_16_ONE == (1 << MFNS_Q16_16_FRAC_BITS), "Q16.16: one is 2^16");
_Static_assert(MFNS_PX_Q8_ONE == (1 << MFNS_PX_Q8_FRAC_BITS), "px_q8: one pixel is 2^8");
_Static_assert(sizeof(q16_16_t) == 4 && sizeof(px_q8_t) == 4, "both formats are int32_t");

/* Saturate a 64-bit intermediate into int32_t. */
int32_t mfns_sat_i32(int64_t v);

q16_16_t mfns_q16_from_float(float f);
/* As above; false when f is NaN or outside the range (result saturated, 0 for NaN). */
bool mfns_q16_from_float_checked(float f, q16_16_t *out);
float mfns_q16_to_float(q16_16_t q);
q16_16_t mfns_q16_add_sat(q16_16_t a, q16_16_t b);
q16_16_t mfns_q16_sub_sat(q16_16_t a, q16_16_t b);
/* a*b rounded to nearest (ties away from zero), saturated. */
q16_16_t mfns_q16_mul_sat(q16_16_t a, q16_16_t b);
/* Linear interpolation a + (b - a) * t, t in Q16.16 within [0, 1]; saturated. */
q16_16_t mfns_q16_lerp(q16_16_t a, q16_16_t b, q16_16_t t);

px_q8_t mfns_px_q8_from_float(float f);
bool mfns_px_q8_from_float_checked(float f, px_q8_t *out);
float mfns_px_q8_to_float(px_q8_t p);
px_q8_t mfns_px_q8_add_sat(px_q8_t a, px_q8_t b);
/* num/den in px_q8 (i.e. round(256 * num / den)), for centroids: num is a
 * first moment, den the zeroth. den must be > 0; returns false otherwise or
 * when the quotient does not fit (result saturated or 0). */
bool mfns_px_q8_from_ratio(int64_t num, int64_t den, px_q8_t *out);

#endif /* MFNS_FIXED_H */
