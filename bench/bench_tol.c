/* bench/bench_tol.c - the errors behind opts.tol's tables, per output: for
 * each shipped kernel and order, the relative L2 error of each of its
 * outputs (potential, gradient, Hessian, velocity, pressure, velocity
 * gradient) at 300 targets against <prefix>_direct, on cube, sphere and
 * clustered points (bench/points.h), sources = targets, densities uniform
 * in [-1, 1]; the largest over the distributions and seeds per order, and
 * the worst output's table, the one create takes the order from
 * (kifmm_kernels.h, KIFMM_HAS_TOL; docs/api.md, "Tolerance").
 *
 *   cc -O2 -march=native -fopenmp -I. bench/bench_tol.c -o bench_tol \
 *      -llapacke -lopenblas -lm
 *   ./bench_tol [-n N] [-s SEEDS] [-p P0 P1] [-k KERNEL ...]
 *   or: make bench-tol (20,000 points, two seeds, then 200,000, one seed)
 *
 * Defaults: 20,000 points, seeds 1 and 2, orders 2 to 12, every kernel.
 * Accuracy only: OPENBLAS_CORETYPE is left alone. */
/* every level at the order measured (no wide level raised: kifmm.h, >>orders) */
#define KIFMM_RAISE_SLACK 0
#include "kifmm.h"
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"
#define KIFMM_KERNEL laplace_hess
#include "kifmm.h"
#define KIFMM_KERNEL laplace_dipole
#include "kifmm.h"
#define KIFMM_KERNEL laplace_dipole_grad
#include "kifmm.h"
#define KIFMM_KERNEL laplace_cd
#include "kifmm.h"
#define KIFMM_KERNEL laplace_cd_grad
#include "kifmm.h"
#define KIFMM_KERNEL laplace_cd_hess
#include "kifmm.h"
#define KIFMM_KERNEL yukawa
#include "kifmm.h"
#define KIFMM_KERNEL yukawa_grad
#include "kifmm.h"
#define KIFMM_KERNEL yukawa_cd
#include "kifmm.h"
#define KIFMM_KERNEL yukawa_cd_grad
#include "kifmm.h"
#define KIFMM_KERNEL stokes
#include "kifmm.h"
#define KIFMM_KERNEL stokes_grad
#include "kifmm.h"
#define KIFMM_KERNEL stokes_pvel
#include "kifmm.h"
#define KIFMM_KERNEL stokes_dl
#include "kifmm.h"
#define KIFMM_KERNEL biot_savart
#include "kifmm.h"
#define KIFMM_KERNEL biot_savart_grad
#include "kifmm.h"
#define KIFMM_KERNEL helmholtz_grad
#include "kifmm.h"
#define KIFMM_KERNEL helmholtz_cd_grad
#include "kifmm.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "points.h"

#define NCHK 300
#define MAXG 3

typedef int (*run_fn)(const kifmm_opts *o, int64_t n, const double *x, const double *q,
                      int64_t nc, const double *xc, double *out, double *ref);

/* create, evaluate, and direct at the nc check targets (xc) */
#define BT_RUN(P, TD)                                                                          \
    static int run_##P(const kifmm_opts *o, int64_t n, const double *x, const double *q,       \
                       int64_t nc, const double *xc, double *out, double *ref)                 \
    {                                                                                          \
        kifmm_##P *h = NULL;                                                                   \
        int rc = kifmm_##P##_create(&h, o, n, x, n, x);                                        \
        if (!rc) rc = kifmm_##P##_evaluate(h, q, out);                                         \
        kifmm_##P##_destroy(h);                                                                \
        if (!rc) rc = kifmm_##P##_direct(o, n, x, q, nc, xc, ref);                             \
        return rc;                                                                             \
    }
BT_RUN(laplace, 1)
BT_RUN(laplace_grad, 4)
BT_RUN(laplace_hess, 10)
BT_RUN(laplace_dipole, 1)
BT_RUN(laplace_dipole_grad, 4)
BT_RUN(laplace_cd, 1)
BT_RUN(laplace_cd_grad, 4)
BT_RUN(laplace_cd_hess, 10)
BT_RUN(yukawa, 1)
BT_RUN(yukawa_grad, 4)
BT_RUN(yukawa_cd, 1)
BT_RUN(yukawa_cd_grad, 4)
BT_RUN(stokes, 3)
BT_RUN(stokes_grad, 12)
BT_RUN(stokes_pvel, 4)
BT_RUN(stokes_dl, 3)
BT_RUN(biot_savart, 3)
BT_RUN(biot_savart_grad, 12)
BT_RUN(helmholtz_grad, 8)
BT_RUN(helmholtz_cd_grad, 8)

/* an output: its first component and count */
typedef struct {
    const char *name;
    int at, n;
} group;

typedef struct {
    const char *name;
    int sd, td;
    run_fn run;
    group g[MAXG];
    int waves; /* an oscillating kernel: a table per order and width */
} kernel;

#define PHI {"potential", 0, 1}
#define GRAD {"gradient", 1, 3}
#define HESS {"Hessian", 4, 6}
#define VEL {"velocity", 0, 3}
#define VGRAD {"velocity gradient", 3, 9}
static const kernel kernels[] = {
    {"laplace", 1, 1, run_laplace, {PHI}, 0},
    {"laplace_grad", 1, 4, run_laplace_grad, {PHI, GRAD}, 0},
    {"laplace_hess", 1, 10, run_laplace_hess, {PHI, GRAD, HESS}, 0},
    {"laplace_dipole", 3, 1, run_laplace_dipole, {PHI}, 0},
    {"laplace_dipole_grad", 3, 4, run_laplace_dipole_grad, {PHI, GRAD}, 0},
    {"laplace_cd", 4, 1, run_laplace_cd, {PHI}, 0},
    {"laplace_cd_grad", 4, 4, run_laplace_cd_grad, {PHI, GRAD}, 0},
    {"laplace_cd_hess", 4, 10, run_laplace_cd_hess, {PHI, GRAD, HESS}, 0},
    {"yukawa", 1, 1, run_yukawa, {PHI}, 0},
    {"yukawa_grad", 1, 4, run_yukawa_grad, {PHI, GRAD}, 0},
    {"yukawa_cd", 4, 1, run_yukawa_cd, {PHI}, 0},
    {"yukawa_cd_grad", 4, 4, run_yukawa_cd_grad, {PHI, GRAD}, 0},
    {"stokes", 3, 3, run_stokes, {VEL}, 0},
    {"stokes_grad", 3, 12, run_stokes_grad, {VEL, VGRAD}, 0},
    {"stokes_pvel", 3, 4, run_stokes_pvel, {{"pressure", 0, 1}, {"velocity", 1, 3}}, 0},
    {"stokes_dl", 6, 3, run_stokes_dl, {VEL}, 0},
    {"biot_savart", 3, 3, run_biot_savart, {VEL}, 0},
    {"biot_savart_grad", 3, 12, run_biot_savart_grad, {VEL, VGRAD}, 0},
    {"helmholtz_grad", 2, 8, run_helmholtz_grad, {{"potential", 0, 2}, {"gradient", 2, 6}}, 1},
    {"helmholtz_cd_grad", 8, 8, run_helmholtz_cd_grad, {{"potential", 0, 2}, {"gradient", 2, 6}}, 1},
};
#define NKER ((int)(sizeof kernels / sizeof kernels[0]))

/* The oscillating kernels' widths (wavelengths across a level-2 box, the
 * widest whose expansions the passes use): NW fixed ones, then the order's
 * limit (_WAVES_MAX) as the last column */
#define NW 7
static const double widths[NW] = {0.02, 0.25, 0.5, 0.75, 1.0, 1.25, 1.5};
static const double waves_max[KIFMM_MAX_ORDER + 1] = KIFMM_KERNEL__HELM_WAVES;

/* one run of kernel k at order p on distribution d, seed s; for an
 * oscillating kernel the root is the points' bounding cube (opts.domain)
 * and the wavenumber makes its level-2 boxes w wavelengths wide. e[g]:
 * each output's relative L2 error at NCHK targets; nonzero on failure */
static int one_run(const kernel *k, int p, int d, int s, int64_t n, double w, double *e)
{
    double *x = (double *)malloc((size_t)n * 3 * sizeof(double));
    double *q = (double *)malloc((size_t)n * k->sd * sizeof(double));
    double *out = (double *)malloc((size_t)n * k->td * sizeof(double));
    double *xc = (double *)malloc((size_t)NCHK * 3 * sizeof(double));
    double *ref = (double *)malloc((size_t)NCHK * k->td * sizeof(double));
    kifmm_opts o;
    int rc = 1, g, i, c;
    if (!x || !q || !out || !xc || !ref) {
        free(x), free(q), free(out), free(xc), free(ref);
        return rc;
    }
    memset(&o, 0, sizeof o);
    o.order = p;
    make_points(d, n, k->sd, (uint64_t)(1000 * s + 17 * d + 5), x, q);
    if (k->waves) {
        double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300}, half = 0.0;
        for (i = 0; i < 3 * n; i++) {
            lo[i % 3] = x[i] < lo[i % 3] ? x[i] : lo[i % 3];
            hi[i % 3] = x[i] > hi[i % 3] ? x[i] : hi[i % 3];
        }
        for (c = 0; c < 3; c++) half = 0.5 * (hi[c] - lo[c]) > half ? 0.5 * (hi[c] - lo[c]) : half;
        half *= 1.0 + 1e-9;
        for (c = 0; c < 3; c++) o.domain[c] = 0.5 * (lo[c] + hi[c]);
        o.domain[3] = half;
        o.kernel_param[0] = 4.0 * PI * w / half; /* (2 half / 4) k / (2 pi) = w */
    }
    for (i = 0; i < NCHK; i++) memcpy(xc + 3 * i, x + 3 * (i * (n / NCHK)), 3 * sizeof(double));
    rc = k->run(&o, n, x, q, NCHK, xc, out, ref);
    for (g = 0; g < MAXG && k->g[g].name && !rc; g++) {
        double num = 0.0, den = 0.0;
        for (i = 0; i < NCHK; i++)
            for (c = k->g[g].at; c < k->g[g].at + k->g[g].n; c++) {
                const double u = out[(size_t)(i * (n / NCHK)) * k->td + c];
                const double v = ref[(size_t)i * k->td + c];
                num += (u - v) * (u - v);
                den += v * v;
            }
        e[g] = sqrt(num / den);
    }
    free(x), free(q), free(out), free(xc), free(ref);
    return rc;
}

/* x rounded up to two digits */
static double up2(double x)
{
    const double e = x > 0.0 ? pow(10.0, floor(log10(x)) - 1.0) : 1.0;
    return x > 0.0 ? ceil(x / e - 1e-9) * e : x;
}

/* an oscillating kernel's table: the worst output's error per order and
 * width, the largest over distributions and seeds, rounded up
 * (kifmm_kernels.h, KIFMM_KERNEL__HELM_TOL); a width where a run failed
 * is left out (0) */
static void waves_table(const kernel *k, int p0, int p1, int seeds, int64_t n)
{
    double worst[KIFMM_MAX_ORDER + 1][NW + 1];
    int p, j, d, s, g, ng = 0;
    while (ng < MAXG && k->g[ng].name) ng++;
    memset(worst, 0, sizeof worst);
    for (p = p0; p <= p1; p++)
        for (j = 0; j <= NW; j++) {
            const double w = j < NW ? widths[j] : waves_max[p] * (1.0 - 1e-9);
            if (j < NW && widths[j] >= waves_max[p]) continue;
            for (d = 0; d < NDIST; d++)
                for (s = 1; s <= seeds; s++) {
                    double e[MAXG];
                    int rc = one_run(k, p, d, s, n, w, e);
                    printf("%-20s p=%2d w=%.3f %-9s seed %d", k->name, p, w, dist_names[d], s);
                    if (rc) printf(" error %d (%s)", rc, kifmm_strerror(rc));
                    if (rc) worst[p][j] = -1.0;
                    for (g = 0; g < ng && !rc; g++) {
                        printf("  %s %.2e", k->g[g].name, e[g]);
                        if (e[g] > worst[p][j] && worst[p][j] >= 0.0) worst[p][j] = e[g];
                    }
                    printf("\n");
                    fflush(stdout);
                }
        }
    printf("## %s: the worst output's largest error per order (rows) and width in "
           "wavelengths (columns:", k->name);
    for (j = 0; j < NW; j++) printf(" %.2f", widths[j]);
    printf(" and the order's limit)\n");
    for (p = p0; p <= p1; p++) {
        printf("## {");
        for (j = 0; j <= NW; j++) printf("%.1e%s", worst[p][j] > 0.0 ? up2(worst[p][j]) : 0.0, j < NW ? ", " : "},");
        printf(" /* p = %d, limit %.2f */\n", p, waves_max[p]);
    }
    fflush(stdout);
}

int main(int argc, char **argv)
{
    int64_t n = 20000;
    int seeds = 2, p0 = 2, p1 = KIFMM_MAX_ORDER, a, nsel = 0, ki;
    const char *sel[NKER];
    for (a = 1; a < argc; a++) {
        if (!strcmp(argv[a], "-n") && a + 1 < argc) n = atoll(argv[++a]);
        else if (!strcmp(argv[a], "-s") && a + 1 < argc) seeds = atoi(argv[++a]);
        else if (!strcmp(argv[a], "-p") && a + 2 < argc) p0 = atoi(argv[++a]), p1 = atoi(argv[++a]);
        else if (!strcmp(argv[a], "-k") && a + 1 < argc && nsel < NKER) sel[nsel++] = argv[++a];
        else {
            fprintf(stderr, "usage: %s [-n N] [-s SEEDS] [-p P0 P1] [-k KERNEL ...]\n", argv[0]);
            return 2;
        }
    }
    if (n < NCHK || seeds < 1 || p0 < 2 || p1 > KIFMM_MAX_ORDER || p0 > p1) return 2;
    printf("# relative L2 error per output at %d targets against direct sums; %lld points, "
           "seeds 1..%d, cube / sphere / clustered, sources = targets\n",
           NCHK, (long long)n, seeds);
    for (ki = 0; ki < NKER; ki++) {
        const kernel *k = &kernels[ki];
        double worst[KIFMM_MAX_ORDER + 1][MAXG];
        int p, g, ng = 0, s, d, i, skip = nsel > 0;
        for (i = 0; i < nsel; i++) skip &= strcmp(sel[i], k->name) != 0;
        if (skip) continue;
        if (k->waves) {
            waves_table(k, p0, p1, seeds, n);
            continue;
        }
        while (ng < MAXG && k->g[ng].name) ng++;
        memset(worst, 0, sizeof worst);
        for (p = p0; p <= p1; p++)
            for (d = 0; d < NDIST; d++)
                for (s = 1; s <= seeds; s++) {
                    double e[MAXG];
                    int rc = one_run(k, p, d, s, n, 0.0, e);
                    printf("%-20s p=%2d %-9s seed %d", k->name, p, dist_names[d], s);
                    if (rc) printf(" error %d (%s)", rc, kifmm_strerror(rc));
                    for (g = 0; g < ng && !rc; g++) {
                        printf("  %s %.2e", k->g[g].name, e[g]);
                        if (e[g] > worst[p][g]) worst[p][g] = e[g];
                    }
                    printf("\n");
                    fflush(stdout);
                }
        printf("## %s: largest per order", k->name);
        for (g = 0; g < ng; g++) printf(" | %s", k->g[g].name);
        printf(" | worst / first\n");
        for (p = p0; p <= p1; p++) {
            double w = 0.0;
            printf("## %s p=%2d", k->name, p);
            for (g = 0; g < ng; g++) {
                printf(" | %.2e", worst[p][g]);
                if (worst[p][g] > w) w = worst[p][g];
            }
            printf(" | %.2f\n", w / worst[p][0]);
        }
        fflush(stdout);
    }
    return 0;
}
