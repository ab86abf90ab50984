/* core_inline.h -- MFNS_OUT_OF_LINE: keeps a small, often-called function of
 * the portable core out of line on a build for flash size.
 *
 * With link-time optimisation (the flight image of `make size`, docs/
 * budgets.md) GCC inlines some helpers at every call site where a call is
 * shorter: the table loader's failure report at its 35 sites, the skew matrix,
 * the acquisition's skip and start, ... (each one measured: docs/budgets.md). A board built for size defines
 * MFNS_CORE_OUT_OF_LINE=1 (boards/cortex-m7-core) and these functions are then
 * noinline; everywhere else the macro is empty and the code compiles exactly
 * as before. Inlining never changes what the code computes (C11 mode: no
 * floating-point contraction, the same operations either way).
 */
#ifndef MFNS_CORE_INLINE_H
#define MFNS_CORE_INLINE_H

#ifndef MFNS_CORE_OUT_OF_LINE
#define MFNS_CORE_OUT_OF_LINE 0
#endif

#if MFNS_CORE_OUT_OF_LINE && defined(__GNUC__)
#define MFNS_OUT_OF_LINE __attribute__((noinline))
#else
#define MFNS_OUT_OF_LINE
#endif

#endif /* MFNS_CORE_INLINE_H */
