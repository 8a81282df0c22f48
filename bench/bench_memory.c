/* bench/bench_memory.c - <prefix>_estimate_bytes against the memory handles
 * hold (stats.bytes): the table of docs/api.md, "Memory".
 *
 *   cc -O2 -march=native -fopenmp -I. bench/bench_memory.c -o bench_memory \
 *      -llapacke -lopenblas -lm
 *   ./bench_memory [--quick]          or: make bench-memory
 *
 * Groups: uniform points in a cube (3,000 to 150,000 points at orders 2 to
 * 10, sources alone and separate targets, and 1M points at orders 4, 6, 8;
 * laplace, laplacef, stokes, yukawa and laplace with the dense M2L);
 * uniform points with one, two and three periodic directions (100,000 and
 * 200,000 of them, order 6); points on a
 * sphere and clustered, and Plummer's sphere (100,000 and 1M points;
 * bench/points.h). One line per case, then per group
 * the ratios' range, the middle 95 % and the mean |ln(held / estimate)|.
 * --quick: 30,000 points and orders 4 and 6 only. Memory only: timings do
 * not matter here, and OPENBLAS_CORETYPE is left alone. */
#include "kifmm.h"
#define KIFMM_KERNEL laplace
#define KIFMM_REAL float
#include "kifmm.h"
#define KIFMM_KERNEL stokes
#include "kifmm.h"
#define KIFMM_KERNEL yukawa
#include "kifmm.h"
#define KIFMM_KERNEL laplace
#define KIFMM_NAME kifmm_laplace_dense
#define KIFMM_M2L_DENSE 1
#include "kifmm.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "points.h"

enum { NKERNEL = 5 };
static const char *kernel_names[NKERNEL] = {"laplace", "laplacef", "stokes", "yukawa",
                                            "laplace (dense M2L)"};

/* held and estimate, in bytes, for kernel P in precision R; 1 on an error */
#define MEASURE(P, R)                                                                            \
    static int measure_##P(const kifmm_opts *o, int64_t n, const double *x, const double *y,     \
                           double *held, double *est)                                            \
    {                                                                                            \
        R *xs = (R *)malloc(sizeof(R) * (size_t)(3 * n)), *ys = xs;                              \
        P *h = NULL;                                                                             \
        kifmm_stats st;                                                                          \
        int64_t i;                                                                               \
        int rc;                                                                                  \
        if (y) ys = (R *)malloc(sizeof(R) * (size_t)(3 * n));                                    \
        for (i = 0; i < 3 * n; i++) {                                                            \
            xs[i] = (R)x[i];                                                                     \
            if (y) ys[i] = (R)y[i];                                                              \
        }                                                                                        \
        rc = P##_estimate_bytes(o, n, y ? n : KIFMM_SAME_POINTS, est);                           \
        if (!rc) rc = P##_create(&h, o, n, xs, n, ys);                                           \
        if (!rc) rc = P##_stats(h, &st);                                                         \
        if (!rc) *held = st.bytes;                                                               \
        P##_destroy(h);                                                                          \
        if (ys != xs) free(ys);                                                                  \
        free(xs);                                                                                \
        if (rc) fprintf(stderr, "%s: %s\n", #P, kifmm_strerror(rc));                             \
        return rc != 0;                                                                          \
    }
MEASURE(kifmm_laplace, double)
MEASURE(kifmm_laplacef, float)
MEASURE(kifmm_stokes, double)
MEASURE(kifmm_yukawa, double)
MEASURE(kifmm_laplace_dense, double)

static int measure(int k, const kifmm_opts *o, int64_t n, const double *x, const double *y,
                   double *held, double *est)
{
    switch (k) {
    case 0: return measure_kifmm_laplace(o, n, x, y, held, est);
    case 1: return measure_kifmm_laplacef(o, n, x, y, held, est);
    case 2: return measure_kifmm_stokes(o, n, x, y, held, est);
    case 3: return measure_kifmm_yukawa(o, n, x, y, held, est);
    default: return measure_kifmm_laplace_dense(o, n, x, y, held, est);
    }
}

/* the ratios of one group */
typedef struct {
    const char *name;
    double r[512];
    int n;
} group;

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static void group_summary(group *g)
{
    double lg = 0.0;
    int i;
    if (g->n == 0) return;
    qsort(g->r, (size_t)g->n, sizeof(double), cmp_double);
    for (i = 0; i < g->n; i++) lg += fabs(log(g->r[i]));
    printf("%-34s %4d cases  held / estimate %.3f to %.3f, 95 %% within %.3f to %.3f, "
           "mean |ln| %.4f\n",
           g->name, g->n, g->r[0], g->r[g->n - 1], g->r[(int)(0.025 * g->n)],
           g->r[(int)(0.975 * g->n)], lg / g->n);
}

/* one case: measure, print its line, add its ratio to g */
static void run_case(group *g, int k, const char *dname, int64_t n, int p, int sep, int nper,
                     const double *x, const double *y)
{
    kifmm_opts o;
    double held = 0.0, est = 0.0;
    int d;
    memset(&o, 0, sizeof o);
    o.order = p;
    for (d = 0; d < nper; d++) o.period[d] = 1.0;
    if (measure(k, &o, n, x, sep ? y : NULL, &held, &est) || g->n >= 512) return;
    g->r[g->n++] = held / est;
    printf("%-20s %-9s %8lld  p %2d  %-8s  periodic %d  held %9.1f MiB  estimate %9.1f MiB  "
           "%.3f\n",
           kernel_names[k], dname, (long long)n, p, sep ? "separate" : "same", nper,
           held / 1048576.0, est / 1048576.0, held / est);
    fflush(stdout);
}

int main(int argc, char **argv)
{
    const int quick = argc > 1 && !strcmp(argv[1], "--quick");
    static const int64_t ns_full[5] = {3000, 10000, 30000, 60000, 150000}, ns_quick[1] = {30000};
    static const int ps_full[6] = {2, 3, 4, 6, 8, 10}, ps_quick[2] = {4, 6};
    const int64_t *ns = quick ? ns_quick : ns_full;
    const int *ps = quick ? ps_quick : ps_full;
    const int nn = quick ? 1 : 5, np = quick ? 2 : 6;
    const int64_t nmax = quick ? 200000 : 1000000;
    double *x = (double *)malloc(sizeof(double) * 3 * (size_t)nmax);
    double *y = (double *)malloc(sizeof(double) * 3 * (size_t)nmax);
    double *q = (double *)malloc(sizeof(double) * (size_t)nmax);
    static group gu = {"uniform", {0}, 0}, gp = {"uniform, periodic", {0}, 0};
    static group gs = {"sphere and clustered, laplace-like", {0}, 0};
    static group gy = {"sphere and clustered, yukawa", {0}, 0};
    static group gpl = {"Plummer, laplace-like", {0}, 0}, gpy = {"Plummer, yukawa", {0}, 0};
    int k, i, j, sep, per, dist;
    if (!x || !y || !q) return 1;
    printf("kifmm estimate_bytes against stats.bytes (%s)\n", quick ? "--quick" : "full");
    for (k = 0; k < NKERNEL; k++)
        for (i = 0; i < nn; i++) {
            make_points(DIST_CUBE, ns[i], 1, 7, x, q);
            make_points(DIST_CUBE, ns[i], 1, 8, y, q);
            for (j = 0; j < np; j++)
                for (sep = 0; sep < 2; sep++)
                    run_case(&gu, k, "cube", ns[i], ps[j], sep, 0, x, y);
        }
    if (!quick) {
        make_points(DIST_CUBE, nmax, 1, 7, x, q);
        for (k = 0; k < NKERNEL; k++)
            for (j = 4; j <= 8; j += 2) run_case(&gu, k, "cube", nmax, j, 0, 0, x, y);
    }
    for (k = 0; k < 4; k++)
        for (i = 0; i < (quick ? 1 : 2); i++) {
            const int64_t n = quick ? 30000 : 100000 * (i + 1);
            make_points(DIST_CUBE, n, 1, 7, x, q);
            for (per = 1; per <= 3; per++) run_case(&gp, k, "cube", n, 6, 0, per, x, y);
        }
    for (dist = DIST_SPHERE; dist <= DIST_CLUSTERED; dist++)
        for (i = 0; i < (quick ? 1 : 3); i++) {
            const int64_t n = i == 0 ? 30000 : i == 1 ? 200000 : 1000000;
            make_points(dist, n, 1, 7, x, q);
            for (k = 0; k < 4; k++)
                for (j = 4; j <= (quick ? 6 : 8); j += 2)
                    run_case(k == 3 ? &gy : &gs, k, dist_names[dist], n, j, 0, 0, x, y);
        }
    for (i = 0; i < (quick ? 1 : 2); i++) {
        const int64_t n = i == 0 ? 100000 : 1000000;
        make_plummer(n, 1, 7, x, q);
        for (k = 0; k < 4; k++)
            for (j = 4; j <= (quick ? 6 : 8); j += 2)
                run_case(k == 3 ? &gpy : &gpl, k, "Plummer", n, j, 0, 0, x, y);
    }
    printf("\n");
    group_summary(&gu);
    group_summary(&gp);
    group_summary(&gs);
    group_summary(&gy);
    group_summary(&gpl);
    group_summary(&gpy);
    free(x);
    free(y);
    free(q);
    return 0;
}
