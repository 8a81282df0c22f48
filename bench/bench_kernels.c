/* bench/bench_kernels.c - the shipped kernels side by side on the same points
 *
 *   bench_kernels DIST N P [--sample S] [--repeat R] [--dump FILE] [--leaf L] [--passes]
 *
 * Runs laplace_grad, yukawa_grad (lambda 1), stokes (mu 1) and
 * laplace_cd_grad (a charge and a dipole per point) on the same N
 * points of DIST (cube, sphere, clustered: bench/points.h), sources =
 * targets, one after the other in this process, and prints one row per
 * kernel: the build's instruction set, create and evaluate time (the
 * fastest of R evaluates), their sum and its ratio to laplace_grad's,
 * the memory the handle holds and its ratio to laplace_grad's, and the
 * relative L2 error of the first output group
 * (potential, velocity) and of the gradient at S sample targets against
 * direct sums computed here. --dump FILE writes the Stokes case to FILE and
 * the laplace_cd_grad case to FILE.cd, for bench/fmm3d_kernels.py (little
 * endian: int64 kind (0 Stokes, 1 charges and dipoles), int64 n, int64 ns,
 * double xyz[3n], int64 sd, double densities[sd n], int64 idx[ns], int64 td,
 * double ref[td ns], double kifmm_err[2] (first group, gradient),
 * double kifmm_seconds). --leaf sets opts.leaf_size for every kernel (default:
 * each kernel's own). --passes adds a line per kernel with the fastest
 * evaluate's time per pass and create's tree and operator times. A last
 * line compares the Stokes far field with the harmonic route's
 * (harmonic_route below).
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
#define KIFMM_KERNEL laplace_cd_grad
#include "kifmm.h"
#define KIFMM_KERNEL biot_savart
#include "kifmm.h"

#include <omp.h>

#include "points.h"

enum { K_LAPG, K_YUKG, K_STOKES, K_LCDG, K_BS, NKIND };

/* the build's instruction set (the near-field hooks' vectors) */
#if defined(__AVX512F__)
#define ISA "avx512"
#elif defined(__AVX2__) && defined(__FMA__)
#define ISA "avx2"
#else
#define ISA "generic"
#endif

/* ref[s td ..] at target idx[s]: laplace_grad / yukawa_grad (lambda 1):
 * potential and gradient; stokes (mu 1): velocity */
static void direct(int kind, int64_t n, const double *x, const double *q, int64_t ns,
                   const int64_t *idx, double *ref)
{
    const int td = kind == K_STOKES || kind == K_BS ? 3 : 4;
#pragma omp parallel for schedule(dynamic, 4)
    for (int64_t s = 0; s < ns; s++) {
        const double *t = x + 3 * idx[s];
        double a[4] = {0, 0, 0, 0};
        for (int64_t j = 0; j < n; j++) {
            const double dx = t[0] - x[3 * j], dy = t[1] - x[3 * j + 1], dz = t[2] - x[3 * j + 2];
            const double r2 = dx * dx + dy * dy + dz * dz, r = sqrt(r2);
            if (r2 == 0.0) continue;
            if (kind == K_LCDG) { /* charge q, dipole v: q / r + v . d / r^3 and the gradient */
                const double *c = q + 4 * j, vd = dx * c[1] + dy * c[2] + dz * c[3];
                const double r3 = r2 * r, m = (c[0] + 3.0 * vd / r2) / r3;
                a[0] += c[0] / r + vd / r3;
                a[1] += c[1] / r3 - dx * m;
                a[2] += c[2] / r3 - dy * m;
                a[3] += c[3] / r3 - dz * m;
            } else if (kind == K_BS) { /* vortex strength: a x d / r^3 */
                const double *w = q + 3 * j, r3 = r2 * r;
                a[0] += (w[1] * dz - w[2] * dy) / r3;
                a[1] += (w[2] * dx - w[0] * dz) / r3;
                a[2] += (w[0] * dy - w[1] * dx) / r3;
            } else if (kind == K_STOKES) {
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
    int leaf;         /* the leaf size the handle used */
    kifmm_stats best; /* the stats of the fastest evaluate */
} res;

#define RUN(P, KIND, TD)                                                                     \
    do {                                                                                     \
        P *h = NULL;                                                                         \
        kifmm_stats st = {0};                                                                \
        kifmm_opts used;                                                                     \
        int rc = P##_create(&h, &o, n, x, n, x), k;                                          \
        double *ref = (double *)malloc(sizeof(double) * (size_t)(TD * ns));                  \
        if (rc) {                                                                            \
            fprintf(stderr, "%s: %s\n", #P, kifmm_strerror(rc));                             \
            exit(1);                                                                         \
        }                                                                                    \
        P##_stats(h, &st);                                                                   \
        r[KIND].leaf = P##_options(h, &used) == KIFMM_SUCCESS ? used.leaf_size : 0;          \
        r[KIND].create = st.t_tree + st.t_operators;                                         \
        r[KIND].eval = 1e30;                                                                 \
        for (k = 0; k < rep; k++) {                                                          \
            P##_evaluate(h, KIND == K_STOKES || KIND == K_BS ? f : KIND == K_LCDG ? cd : q, out); \
            P##_stats(h, &st);                                                               \
            if (st.t_evaluate < r[KIND].eval) {                                              \
                r[KIND].eval = st.t_evaluate;                                                \
                r[KIND].best = st;                                                           \
            }                                                                                \
        }                                                                                    \
        r[KIND].mib = st.bytes / 1048576.0;                                                  \
        P##_destroy(h);                                                                      \
        direct(KIND, n, x, KIND == K_STOKES || KIND == K_BS ? f : KIND == K_LCDG ? cd : q, ns, idx, \
               ref);                                                                         \
        r[KIND].e0 = rel(TD, 0, TD == 3 ? 3 : 1, ns, idx, out, ref);                          \
        r[KIND].e1 = TD == 4 ? rel(TD, 1, 4, ns, idx, out, ref) : 0.0;                       \
        if ((KIND == K_STOKES || KIND == K_LCDG) && dump)                                    \
            write_dump(dump, KIND == K_LCDG, n, x, KIND == K_LCDG ? cd : f, ns, idx, ref,      \
                       r[KIND]);                                                             \
        free(ref);                                                                           \
    } while (0)

static void write_dump(const char *path, int cd, int64_t n, const double *x, const double *dens,
                       int64_t ns, const int64_t *idx, const double *ref, res r)
{
    char name[4096];
    FILE *fp;
    const int64_t kind = cd, sd = cd ? 4 : 3, td = cd ? 4 : 3;
    const double tail[3] = {r.e0, r.e1, r.create + r.eval};
    snprintf(name, sizeof name, "%s%s", path, cd ? ".cd" : "");
    fp = fopen(name, "wb");
    if (!fp || fwrite(&kind, 8, 1, fp) != 1 || fwrite(&n, 8, 1, fp) != 1 ||
        fwrite(&ns, 8, 1, fp) != 1 || fwrite(x, 8, (size_t)(3 * n), fp) != (size_t)(3 * n) ||
        fwrite(&sd, 8, 1, fp) != 1 || fwrite(dens, 8, (size_t)(sd * n), fp) != (size_t)(sd * n) ||
        fwrite(idx, 8, (size_t)ns, fp) != (size_t)ns || fwrite(&td, 8, 1, fp) != 1 ||
        fwrite(ref, 8, (size_t)(td * ns), fp) != (size_t)(td * ns) || fwrite(tail, 8, 3, fp) != 3) {
        fprintf(stderr, "cannot write %s\n", name);
        exit(1);
    }
    fclose(fp);
}

/* The Stokeslet carried by Laplace expansions, as FMM3D does: with phi_j
 * the Laplace fields of f_j (j = 1..3), phi_4 that of y . f and g_j their
 * gradients, u_i = (phi_i - x_j g_j,i + g_4,i) / (2 mu) (the kernels' 1 /
 * (4 pi) normalisation). Run here as laplace_grad over those four density
 * vectors on the tree the shipped Stokes used (same order, same leaves):
 * its far field (evaluate minus the near field) against the shipped
 * three-component far field, and the velocity it gives against the direct
 * sums. The route's near field would be the Stokes hook's (the same pairs). */
static void harmonic_route(const kifmm_opts *o, int64_t n, const double *x, const double *f,
                           int rep, res stk, int64_t ns, const int64_t *idx)
{
    kifmm_laplace_grad *h = NULL;
    kifmm_stats st = {0};
    kifmm_opts ol = *o;
    double *d = (double *)malloc(sizeof(double) * (size_t)(4 * n));
    double *u = (double *)malloc(sizeof(double) * (size_t)(16 * n));
    double *ref = (double *)malloc(sizeof(double) * (size_t)(3 * ns));
    double *v = (double *)malloc(sizeof(double) * (size_t)(3 * n)), far = 1e30;
    int64_t i;
    int k;
    ol.leaf_size = stk.leaf;
    if (!d || !u || !ref || !v || kifmm_laplace_grad_create(&h, &ol, n, x, n, x)) {
        fprintf(stderr, "harmonic route: create failed\n");
        exit(1);
    }
    for (i = 0; i < n; i++) {
        for (k = 0; k < 3; k++) d[k * n + i] = f[3 * i + k];
        d[3 * n + i] = x[3 * i] * f[3 * i] + x[3 * i + 1] * f[3 * i + 1] + x[3 * i + 2] * f[3 * i + 2];
    }
    for (k = 0; k < rep; k++) {
        kifmm_laplace_grad_evaluate_many(h, 4, d, u);
        kifmm_laplace_grad_stats(h, &st);
        if (st.t_evaluate - st.t_p2p < far) far = st.t_evaluate - st.t_p2p;
    }
    for (i = 0; i < n; i++) /* vector j's output block at u + 4 n j */
        for (k = 0; k < 3; k++) {
            const double *g = u + 4 * i + 1 + k;
            v[3 * i + k] = 0.5 * (u[(size_t)k * 4 * n + 4 * i] - x[3 * i] * g[0] -
                                  x[3 * i + 1] * g[4 * n] - x[3 * i + 2] * g[8 * n] + g[12 * n]);
        }
    direct(K_STOKES, n, x, f, ns, idx, ref);
    printf("  stokes far field on its tree (leaf %d): 3 components %.3f s, error %.2e; "
           "4 Laplace fields (global coordinates) %.3f s, error %.2e\n",
           stk.leaf, stk.eval - stk.best.t_p2p, stk.e0, far, rel(3, 0, 3, ns, idx, v, ref));
    kifmm_laplace_grad_destroy(h);
    free(d);
    free(u);
    free(ref);
    free(v);
}

/* One small laplace_grad run before the timed ones: the first create of
 * a process also starts OpenMP's and OpenBLAS's threads (0.05 to 0.3 s
 * here), which laplace_grad, the first kernel and the ratios' base, paid
 * alone. */
static void warm_up(const kifmm_opts *o, int64_t n, const double *x, const double *q, double *out)
{
    kifmm_laplace_grad *h = NULL;
    if (kifmm_laplace_grad_create(&h, o, n, x, n, x) == KIFMM_SUCCESS) kifmm_laplace_grad_evaluate(h, q, out);
    kifmm_laplace_grad_destroy(h);
}

int main(int argc, char **argv)
{
    static const char *names[NKIND] = {"laplace_grad", "yukawa_grad", "stokes", "laplace_cd_grad",
                                               "biot_savart"};
    int dist = -1, p, rep = 3, a, k, leaf = 0, passes = 0;
    int64_t n, ns = 500, s;
    const char *dump = NULL;
    kifmm_opts o;
    res r[NKIND];
    double *x, *q, *f, *cd, *out;
    int64_t *idx;
    if (argc < 4) {
        fprintf(stderr, "usage: %s DIST N P [--sample S] [--repeat R] [--dump FILE] [--leaf L] [--passes]\n", argv[0]);
        return 2;
    }
    for (k = 0; k < NDIST; k++)
        if (!strcmp(argv[1], dist_names[k])) dist = k;
    n = (int64_t)atof(argv[2]);
    p = atoi(argv[3]);
    for (a = 4; a < argc; a++) {
        const char *v = a + 1 < argc ? argv[a + 1] : "";
        if (!strcmp(argv[a], "--passes")) passes = 1;
        else if (!strcmp(argv[a], "--sample")) ns = (int64_t)atof(v), a++;
        else if (!strcmp(argv[a], "--repeat")) rep = atoi(v), a++;
        else if (!strcmp(argv[a], "--dump")) dump = v, a++;
        else if (!strcmp(argv[a], "--leaf")) leaf = atoi(v), a++;
        else dist = -1; /* unknown: refused below */
    }
    if (dist < 0 || n < 1 || ns < 1 || rep < 1 || leaf < 0) {
        fprintf(stderr, "bad arguments\n");
        return 2;
    }
    if (ns > n) ns = n;
    x = (double *)malloc(sizeof(double) * (size_t)(3 * n));
    q = (double *)malloc(sizeof(double) * (size_t)n);
    f = (double *)malloc(sizeof(double) * (size_t)(3 * n));
    cd = (double *)malloc(sizeof(double) * (size_t)(4 * n));
    out = (double *)malloc(sizeof(double) * (size_t)(4 * n));
    idx = (int64_t *)malloc(sizeof(int64_t) * (size_t)ns);
    make_points(dist, n, 1, UINT64_C(0x5eed) + 1000003 * (uint64_t)dist + (uint64_t)n, x, q);
    make_points(dist, n, 3, UINT64_C(0x5eed) + 1000003 * (uint64_t)dist + (uint64_t)n, x, f);
    make_points(dist, n, 4, UINT64_C(0x5eed) + 1000003 * (uint64_t)dist + (uint64_t)n, x, cd);
    for (s = 0; s < ns; s++) idx[s] = (s * 7919) % n;
    memset(&o, 0, sizeof o);
    o.order = p;
    o.leaf_size = leaf;
    warm_up(&o, n < 20000 ? n : 20000, x, q, out);
    RUN(kifmm_laplace_grad, K_LAPG, 4);
    RUN(kifmm_yukawa_grad, K_YUKG, 4);
    RUN(kifmm_stokes, K_STOKES, 3);
    RUN(kifmm_laplace_cd_grad, K_LCDG, 4);
    RUN(kifmm_biot_savart, K_BS, 3);
    for (k = 0; k < NKIND; k++)
        printf("%-9s %8.0f %2d %-7s %-15s %7.3f %7.3f %7.3f %6.2f %7.0f %6.2f %9.2e %9.2e\n",
               dist_names[dist], (double)n, p, ISA, names[k], r[k].create, r[k].eval,
               r[k].create + r[k].eval,
               (r[k].create + r[k].eval) / (r[0].create + r[0].eval), r[k].mib,
               r[k].mib / r[0].mib, r[k].e0, r[k].e1);
    harmonic_route(&o, n, x, f, rep, r[K_STOKES], ns, idx);
    for (k = 0; passes && k < NKIND; k++) {
        const kifmm_stats *b = &r[k].best;
        printf("  %-12s tree %.3f operators %.3f | p2m %.3f m2m %.3f m2l %.3f l2l %.3f p2l %.3f "
               "l2p %.3f m2p %.3f p2p %.3f | levels %d leaves %lld\n",
               names[k], b->t_tree, b->t_operators, b->t_p2m, b->t_m2m, b->t_m2l, b->t_l2l,
               b->t_p2l, b->t_l2p, b->t_m2p, b->t_p2p, b->levels, (long long)b->leaves);
    }
    free(x); free(q); free(f); free(cd); free(out); free(idx);
    return 0;
}
