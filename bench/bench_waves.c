/* bench/bench_waves.c - helmholtz's error against the width of its widest
 * boxes, the measurement behind the frequency limits (kifmm_kernels.h,
 * KIFMM_KERNEL__HELM_WAVES; docs/kernels.md, "Helmholtz")
 *
 *   bench_waves P W0 W1 DW [N]
 *
 * N (20,000) uniform points in the unit cube, which is also the root
 * (opts.domain), leaves of 64 points, complex charges, order P; for each
 * width W = W0, W0 + DW, ..., W1 the wavenumber that makes the level-2
 * boxes (the widest whose expansions the passes use) W wavelengths wide,
 * and one row: W and the potential's relative L2 error at 300 targets
 * against direct sums computed here. The order's limits are lifted for
 * the scan (the kernel's _WAVES_MAX redefined below), so that the rows go
 * past them. Not part of `make bench` (minutes at p >= 10).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "kifmm_kernels.h"
#define KPI 3.14159265358979323846
#undef KIFMM_KERNEL__HELM_WAVES
#define KIFMM_KERNEL__HELM_WAVES {9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9}
#define KIFMM_KERNEL helmholtz
/* every level at the order measured (no wide level raised: kifmm.h, >>orders) */
#define KIFMM_RAISE_SLACK 0
#include "kifmm.h"

static double urand(unsigned long long *s)
{
    *s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(*s >> 11) / 9007199254740992.0;
}

/* the potential's relative L2 error at m targets against direct sums */
static double error(int n, const double *x, const double *q, const double *out, double k, int m)
{
    double e2 = 0.0, r2 = 0.0;
    for (int i = 0; i < m; i++) {
        const int t = (int)((long long)i * n / m);
        double re = 0.0, im = 0.0;
        for (int j = 0; j < n; j++) {
            const double dx = x[3 * j] - x[3 * t], dy = x[3 * j + 1] - x[3 * t + 1], dz = x[3 * j + 2] - x[3 * t + 2];
            const double r = sqrt(dx * dx + dy * dy + dz * dz);
            if (r == 0.0) continue;
            const double c = cos(k * r) / (4.0 * KPI * r), s = sin(k * r) / (4.0 * KPI * r);
            re += c * q[2 * j] - s * q[2 * j + 1];
            im += c * q[2 * j + 1] + s * q[2 * j];
        }
        e2 += (out[2 * t] - re) * (out[2 * t] - re) + (out[2 * t + 1] - im) * (out[2 * t + 1] - im);
        r2 += re * re + im * im;
    }
    return sqrt(e2 / r2);
}

int main(int argc, char **argv)
{
    if (argc < 5) {
        fprintf(stderr, "usage: %s P W0 W1 DW [N]\n", argv[0]);
        return 2;
    }
    const int p = atoi(argv[1]), n = argc > 5 ? atoi(argv[5]) : 20000;
    const double w0 = atof(argv[2]), w1 = atof(argv[3]), dw = atof(argv[4]);
    double *x = malloc(sizeof(double) * 3 * n), *q = malloc(sizeof(double) * 2 * n);
    double *out = malloc(sizeof(double) * 2 * n);
    unsigned long long s = 1;
    if (!x || !q || !out || n < 300 || !(dw > 0.0)) return 2;
    for (int i = 0; i < 3 * n; i++) x[i] = urand(&s);
    for (int i = 0; i < 2 * n; i++) q[i] = urand(&s) - 0.5;
    printf("# helmholtz, %d uniform points, p = %d: level-2 width (wavelengths), potential error\n", n, p);
    for (double w = w0; w <= w1 + 1e-9; w += dw) {
        kifmm_opts o = {0};
        kifmm_helmholtz *h = NULL;
        o.order = p, o.leaf_size = 64;
        o.domain[0] = o.domain[1] = o.domain[2] = o.domain[3] = 0.5;
        o.kernel_param[0] = 2.0 * KPI * w / 0.25;
        int rc = kifmm_helmholtz_create(&h, &o, n, x, n, x);
        if (!rc) rc = kifmm_helmholtz_evaluate(h, q, out);
        kifmm_helmholtz_destroy(h);
        if (rc)
            printf("%.4f %s\n", w, kifmm_strerror(rc));
        else
            printf("%.4f %.3e\n", w, error(n, x, q, out, o.kernel_param[0], 300));
        fflush(stdout);
    }
    free(x), free(q), free(out);
    return 0;
}
