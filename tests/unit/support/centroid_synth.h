/* centroid_synth.h -- synthetic beacon spots for the centroiding tests and
 * benchmark: pixel-integrated profiles under the pixel-centre convention of
 * docs/conventions.md (pixel (i, j) covers [i-0.5, i+0.5) x [j-0.5, j+0.5)). */
#ifndef MFNS_CENTROID_SYNTH_H
#define MFNS_CENTROID_SYNTH_H

#define CS_MAX_WINDOW 64

typedef enum { CS_GAUSS = 0, CS_DISK = 1 } cs_kind_t;

typedef struct {
    cs_kind_t kind;
    double x0, y0; /* true centre (px, pixel-centre convention) */
    double sigma;  /* CS_GAUSS: standard deviation per axis (px) */
    double radius; /* CS_DISK: radius of the uniform disk (px) */
    double blur;   /* CS_DISK: Gaussian blur of the disk edge (px), > 0 */
} cs_spot_t;

/* Unit-flux profile integrated over each pixel of the n x n window whose
 * top-left pixel is (ix0, iy0): out[j * n + i] for pixel (ix0 + i, iy0 + j).
 * n <= CS_MAX_WINDOW. The disk is integrated by a 64-node rule in the chord
 * angle (smooth in x0, y0, so finite differences of it are usable). */
void cs_profile(const cs_spot_t *s, int ix0, int iy0, int n, double *out);

/* Per-axis standard deviation of the spot (px). */
double cs_spot_sigma(const cs_spot_t *s);

/* Half size of a window holding all but ~1e-9 of the flux. */
int cs_half_window(const cs_spot_t *s);

#endif
