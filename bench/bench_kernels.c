/* bench/bench_kernels.c - the shipped kernels side by side on the same points
 *
 *   bench_kernels DIST N P [--sample S] [--repeat R] [--dump FILE]
 *
 * Runs laplace_grad, yukawa_grad (lambda 1) and stokes (mu 1) on the same N
 * points of DIST (cube, sphere, clustered: bench/points.h), sources =
 * targets, one after the other in this process, and prints one row per
 * kernel: create and evaluate time (the fastest of R evaluates), their sum
 * and its ratio to laplace_grad's, the memory the handle holds and its ratio
 * to laplace_grad's, and the relative L2 error of the first output group
 * (potential, velocity) and of the gradient at S sample targets against
 * direct sums computed here. --dump writes the Stokes case for
 * bench/fmm3d_stokes.py (little endian: int64 n, int64 ns, double xyz[3n],
 * double f[3n], int64 idx[ns], double u[3ns], double kifmm_err,
 * double kifmm_seconds).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"
#define KIFMM_KERNEL yukawa_grad
#include "kifmm.h"
#define KIFMM_KERNEL stokes
#include "kifmm.h"

#include <omp.h>

#include "points.h"

enum { K_LAPG, K_YUKG, K_STOKES };

/* ref[s td ..] at target idx[s]: laplace_grad / yukawa_grad (lambda 1):
 * potential and gradient; stokes (mu 1): velocity */
static void direct(int kind, int64_t n, const double *x, const double *q, int64_t ns,
                   const int64_t *idx, double *ref)
{
    const int td = kind == K_STOKES ? 3 : 4;
#pragma omp parallel for schedule(dynamic, 4)
    for (int64_t s = 0; s < ns; s++) {
        const double *t = x + 3 * idx[s];
        double a[4] = {0, 0, 0, 0};
        for (int64_t j = 0; j < n; j++) {
            const double dx = t[0] - x[3 * j], dy = t[1] - x[3 * j + 1], dz = t[2] - x[3 * j + 2];
            const double r2 = dx * dx + dy * dy + dz * dz, r = sqrt(r2);
            if (r2 == 0.0) continue;
            if (kind == K_STOKES) {
                const double *f = q + 3 * j, fd = (dx * f[0] + dy * f[1] + dz * f[2]) / (r2 * r);
                a[0] += f[0] / r + dx * fd;
                a[1] += f[1] / r + dy * fd;
                a[2] += f[2] / r + dz * fd;
            } else {
                const double e = kind == K_YUKG ? exp(-r) : 1.0, p = q[j] * e / r;
                const double g = -p * (1.0 + (kind == K_YUKG ? r : 0.0)) / r2;
                a[0] += p;
                a[1] += g * dx;
                a[2] += g * dy;
                a[3] += g * dz;
            }
        }
        for (int k = 0; k < td; k++) ref[s * td + k] = a[k] / (kind == K_STOKES ? 8 * PI : 4 * PI);
    }
}

/* relative L2 error of outputs [k0, k1) of each target against ref */
static double rel(int td, int k0, int k1, int64_t ns, const int64_t *idx, const double *out,
                  const double *ref)
{
    double num = 0, den = 0;
    for (int64_t s = 0; s < ns; s++)
        for (int k = k0; k < k1; k++) {
            const double d = out[idx[s] * td + k] - ref[s * td + k];
            num += d * d;
            den += ref[s * td + k] * ref[s * td + k];
        }
    return sqrt(num / den);
}

typedef struct {
    double create, eval, mib, e0, e1;
} res;

#define RUN(P, KIND, TD)                                                                     \
    do {                                                                                     \
        P *h = NULL;                                                                         \
        kifmm_stats st = {0};                                                                \
        int rc = P##_create(&h, &o, n, x, n, x), k;                                          \
        double *ref = (double *)malloc(sizeof(double) * (size_t)(TD * ns));                  \
        if (rc) {                                                                            \
            fprintf(stderr, "%s: %s\n", #P, kifmm_strerror(rc));                             \
            exit(1);                                                                         \
        }                                                                                    \
        P##_stats(h, &st);                                                                   \
        r[KIND].create = st.t_tree + st.t_operators;                                         \
        r[KIND].eval = 1e30;                                                                 \
        for (k = 0; k < rep; k++) {                                                          \
            P##_evaluate(h, KIND == K_STOKES ? f : q, out);                                  \
            P##_stats(h, &st);                                                               \
            if (st.t_evaluate < r[KIND].eval) r[KIND].eval = st.t_evaluate;                  \
        }                                                                                    \
        r[KIND].mib = st.bytes / 1048576.0;                                                  \
        P##_destroy(h);                                                                      \
        direct(KIND, n, x, KIND == K_STOKES ? f : q, ns, idx, ref);                           \
        r[KIND].e0 = rel(TD, 0, TD == 3 ? 3 : 1, ns, idx, out, ref);                          \
        r[KIND].e1 = TD == 4 ? rel(TD, 1, 4, ns, idx, out, ref) : 0.0;                       \
        if (KIND == K_STOKES && dump) write_dump(dump, n, x, f, ns, idx, ref, r[KIND]);      \
        free(ref);                                                                           \
    } while (0)

static void write_dump(const char *path, int64_t n, const double *x, const double *f,
                       int64_t ns, const int64_t *idx, const double *u, res r)
{
    FILE *fp = fopen(path, "wb");
    const double tail[2] = {r.e0, r.create + r.eval};
    if (!fp || fwrite(&n, 8, 1, fp) != 1 || fwrite(&ns, 8, 1, fp) != 1 ||
        fwrite(x, 8, (size_t)(3 * n), fp) != (size_t)(3 * n) ||
        fwrite(f, 8, (size_t)(3 * n), fp) != (size_t)(3 * n) ||
        fwrite(idx, 8, (size_t)ns, fp) != (size_t)ns ||
        fwrite(u, 8, (size_t)(3 * ns), fp) != (size_t)(3 * ns) || fwrite(tail, 8, 2, fp) != 2) {
        fprintf(stderr, "cannot write %s\n", path);
        exit(1);
    }
    fclose(fp);
}

int main(int argc, char **argv)
{
    static const char *names[3] = {"laplace_grad", "yukawa_grad", "stokes"};
    int dist = -1, p, rep = 3, a, k;
    int64_t n, ns = 500, s;
    const char *dump = NULL;
    kifmm_opts o;
    res r[3];
    double *x, *q, *f, *out;
    int64_t *idx;
    if (argc < 4) {
        fprintf(stderr, "usage: %s DIST N P [--sample S] [--repeat R] [--dump FILE]\n", argv[0]);
        return 2;
    }
    for (k = 0; k < NDIST; k++)
        if (!strcmp(argv[1], dist_names[k])) dist = k;
    n = (int64_t)atof(argv[2]);
    p = atoi(argv[3]);
    for (a = 4; a + 1 < argc; a += 2) {
        if (!strcmp(argv[a], "--sample")) ns = (int64_t)atof(argv[a + 1]);
        else if (!strcmp(argv[a], "--repeat")) rep = atoi(argv[a + 1]);
        else if (!strcmp(argv[a], "--dump")) dump = argv[a + 1];
    }
    if (dist < 0 || n < 1 || ns < 1 || rep < 1) {
        fprintf(stderr, "bad arguments\n");
        return 2;
    }
    if (ns > n) ns = n;
    x = (double *)malloc(sizeof(double) * (size_t)(3 * n));
    q = (double *)malloc(sizeof(double) * (size_t)n);
    f = (double *)malloc(sizeof(double) * (size_t)(3 * n));
    out = (double *)malloc(sizeof(double) * (size_t)(4 * n));
    idx = (int64_t *)malloc(sizeof(int64_t) * (size_t)ns);
    make_points(dist, n, 1, UINT64_C(0x5eed) + 1000003 * (uint64_t)dist + (uint64_t)n, x, q);
    make_points(dist, n, 3, UINT64_C(0x5eed) + 1000003 * (uint64_t)dist + (uint64_t)n, x, f);
    for (s = 0; s < ns; s++) idx[s] = (s * 7919) % n;
    memset(&o, 0, sizeof o);
    o.order = p;
    RUN(kifmm_laplace_grad, K_LAPG, 4);
    RUN(kifmm_yukawa_grad, K_YUKG, 4);
    RUN(kifmm_stokes, K_STOKES, 3);
    for (k = 0; k < 3; k++)
        printf("%-9s %8.0f %2d %-12s %7.3f %7.3f %7.3f %6.2f %7.0f %6.2f %9.2e %9.2e\n",
               dist_names[dist], (double)n, p, names[k], r[k].create, r[k].eval,
               r[k].create + r[k].eval,
               (r[k].create + r[k].eval) / (r[0].create + r[0].eval), r[k].mib,
               r[k].mib / r[0].mib, r[k].e0, r[k].e1);
    free(x); free(q); free(f); free(out); free(idx);
    return 0;
}
