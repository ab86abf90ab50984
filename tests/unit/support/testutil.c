/* testutil.c -- see testutil.h. */
#include "tests/unit/support/testutil.h"

#include <stdio.h>
#include <stdlib.h>

void mfns_assert_near(double actual, double expected, double tol, const char *expr, const char *file,
                      int line)
{
    const double err = fabs(actual - expected);
    if (!(err <= tol)) {
        print_error("%s:%d: %s = %.9g, expected %.9g (|err| %.3g > tol %.3g)\n", file, line, expr,
                       actual, expected, err, tol);
        _fail(file, line);
    }
}

void mfns_rng_seed(mfns_rng_t *r, uint64_t seed) { r->s = seed ? seed : 0x9E3779B97F4A7C15ull; }

static uint64_t next(mfns_rng_t *r)
{
    r->s ^= r->s >> 12;
    r->s ^= r->s << 25;
    r->s ^= r->s >> 27;
    return r->s * 2685821657736338717ull;
}

double mfns_rng_uniform(mfns_rng_t *r) { return (double)(next(r) >> 11) * (1.0 / 9007199254740992.0); }

double mfns_rng_range(mfns_rng_t *r, double lo, double hi) { return lo + (hi - lo) * mfns_rng_uniform(r); }

double mfns_rng_normal(mfns_rng_t *r)
{
    double u1 = mfns_rng_uniform(r);
    const double u2 = mfns_rng_uniform(r);
    if (u1 < 1e-300) {
        u1 = 1e-300;
    }
    return sqrt(-2.0 * log(u1)) * cos(6.283185307179586 * u2);
}

const char *mfns_test_gen_dir(void)
{
    const char *g = getenv("MFNS_GEN");
    return (g != NULL && g[0] != '\0') ? g : "build/gen";
}

size_t mfns_test_read_gen(const char *name, uint8_t *buf, size_t cap)
{
    char path[512];
    const int w = snprintf(path, sizeof path, "%s/%s", mfns_test_gen_dir(), name);
    if (w <= 0 || (size_t)w >= sizeof path) {
        return 0;
    }
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        fprintf(stderr, "cannot open %s (run make gen)\n", path);
        return 0;
    }
    const size_t n = fread(buf, 1, cap, f);
    if (fclose(f) != 0) {
        return 0;
    }
    return n;
}
