/* units.h -- named constants for pi, angle and length unit factors, and the
 * wire scales of the telemetry units (docs/conventions.md). Every literal of
 * this kind in the code is one of these names; a bare 3.14159f or 57.29f is a
 * defect. Q formats of the fixed-point types are in fixed.h.
 *
 * float is the working type; the _D (double) forms are for host code and for
 * conversions whose operand is already double (e.g. the 1e-6 deg wire unit of
 * a 360 deg range needs more than float's 24-bit mantissa).
 */
#ifndef MFNS_UNITS_H
#define MFNS_UNITS_H

#define MFNS_PI_D 3.14159265358979323846
#define MFNS_PI_F 3.14159265358979f
#define MFNS_TWO_PI_F 6.28318530717959f
#define MFNS_HALF_PI_F 1.57079632679490f

#define MFNS_DEG_PER_RAD_D 57.295779513082320876
#define MFNS_RAD_PER_DEG_D 0.017453292519943295769
#define MFNS_DEG_PER_RAD_F 57.29577951308232f
#define MFNS_RAD_PER_DEG_F 0.017453292519943295f

/* Unit factors. The telemetry's wire scales are not here: they are the XTCE
 * dictionary's calibrators, generated as TLM_SCALE_* (tlm_codes_gen.h). */
#define MFNS_UM_PER_MM_F 1000.0f
#define MFNS_UDEG_PER_DEG_F 1.0e6f
#define MFNS_M_PER_MM_F 1.0e-3f
#define MFNS_US_PER_S 1000000u
#define MFNS_S_PER_US_F 1.0e-6f
#define MFNS_MS_PER_S 1000u
#define MFNS_DB_PER_AMPLITUDE_DECADE 20.0f /* a gain in dB is 20 log10 of its amplitude factor */

_Static_assert(sizeof(float) == 4, "the flight code assumes IEEE-754 binary32 float");

#endif /* MFNS_UNITS_H */
