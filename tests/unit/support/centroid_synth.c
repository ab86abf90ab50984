/* centroid_synth.c -- see centroid_synth.h. */
#include "tests/unit/support/centroid_synth.h"

#include <math.h>

#define CS_NODES 64

static double Phi(double t)
{
    return 0.5 * erfc(-t / sqrt(2.0));
}

/* Antiderivative of Phi: d/dt (t Phi(t) + phi(t)) = Phi(t). */
static double Psi(double t)
{
    return t * Phi(t) + exp(-0.5 * t * t) / sqrt(2.0 * 3.14159265358979323846);
}

double cs_spot_sigma(const cs_spot_t *s)
{
    return s->kind == CS_GAUSS ? s->sigma : sqrt(0.25 * s->radius * s->radius + s->blur * s->blur);
}

int cs_half_window(const cs_spot_t *s)
{
    const double r = s->kind == CS_GAUSS ? 6.5 * s->sigma : s->radius + 6.5 * s->blur;
    return (int)ceil(r) + 1;
}

void cs_profile(const cs_spot_t *s, int ix0, int iy0, int n, double *out)
{
    if (n > CS_MAX_WINDOW) {
        n = CS_MAX_WINDOW;
    }
    if (s->kind == CS_GAUSS) {
        double ex[CS_MAX_WINDOW], ey[CS_MAX_WINDOW];
        for (int i = 0; i < n; i++) {
            const double xc = ix0 + i, yc = iy0 + i;
            ex[i] = Phi((xc + 0.5 - s->x0) / s->sigma) - Phi((xc - 0.5 - s->x0) / s->sigma);
            ey[i] = Phi((yc + 0.5 - s->y0) / s->sigma) - Phi((yc - 0.5 - s->y0) / s->sigma);
        }
        for (int j = 0; j < n; j++) {
            for (int i = 0; i < n; i++) {
                out[j * n + i] = ex[i] * ey[j];
            }
        }
        return;
    }
    /* Disk of radius R blurred by a Gaussian b, integrated over the pixel:
     * value = 1/(pi R^2) int du gx(u) int_{chord(u)} gy(v) dv, with
     * u = x0 + R sin(theta) (du = R cos(theta) dtheta), chord half R cos(theta). */
    static double gx[CS_MAX_WINDOW][CS_NODES], gy[CS_MAX_WINDOW][CS_NODES];
    const double R = s->radius, b = s->blur, pi = 3.14159265358979323846;
    for (int k = 0; k < CS_NODES; k++) {
        const double th = -0.5 * pi + (k + 0.5) * pi / CS_NODES;
        const double u = s->x0 + R * sin(th), c = R * cos(th);
        const double vlo = s->y0 - c, vhi = s->y0 + c;
        const double wk = R * cos(th) * (pi / CS_NODES) / (pi * R * R);
        for (int i = 0; i < n; i++) {
            const double xc = ix0 + i, yc = iy0 + i;
            gx[i][k] = wk * (Phi((xc + 0.5 - u) / b) - Phi((xc - 0.5 - u) / b));
            gy[i][k] = b * (Psi((yc + 0.5 - vlo) / b) - Psi((yc + 0.5 - vhi) / b)) -
                       b * (Psi((yc - 0.5 - vlo) / b) - Psi((yc - 0.5 - vhi) / b));
        }
    }
    for (int j = 0; j < n; j++) {
        for (int i = 0; i < n; i++) {
            double acc = 0.0;
            for (int k = 0; k < CS_NODES; k++) {
                acc += gx[i][k] * gy[j][k];
            }
            out[j * n + i] = acc;
        }
    }
}
