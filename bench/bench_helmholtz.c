/* bench/bench_helmholtz.c - helmholtz_grad against laplace_grad on the same
 * points
 *
 *   bench_helmholtz N P WAVES [--sample S] [--repeat R] [--dump FILE]
 *
 * N uniform points in the unit cube (bench/points.h), sources = targets;
 * laplace_grad on the real parts of the charges, then helmholtz_grad
 * (complex charges, k = 2 pi WAVES: WAVES wavelengths across the cube) at
 * order P, one after the other in this process. One row each: create and
 * evaluate (the fastest of R) seconds, their sum and its ratio to
 * laplace_grad's, the near field's and the M2L's share of the evaluate,
 * and the relative L2 errors of the potential and of the gradient at S
 * sample targets against direct sums computed here. A third row runs the
 * same helmholtz_grad as a real 2 x 2 kernel (helmholtz_2x2 below: the same
 * values and near-field hooks, its surface kernel without
 * KIFMM_HAS_COMPLEX), and the last lines give each pass's seconds and
 * create's tree and operator seconds (laplace_grad, native, 2 x 2), and
 * compare native and 2 x 2: the M2L's seconds and the plan's (operators')
 * memory side by side. --dump FILE writes the
 * helmholtz_grad case for bench/fmm3d_kernels.py (kind 2: its format, then
 * the wavenumber's real and imaginary parts).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"
#define KIFMM_KERNEL helmholtz_grad
#include "kifmm.h"

/* helmholtz_grad written as a real 2 x 2 kernel, as a user would without
 * KIFMM_HAS_COMPLEX: its FFT M2L transforms the re and im components apart
 * and multiplies 2 x 2 blocks of half spectra */
#define kifmm_kernel_helm2_SRC_DIM 2
#define kifmm_kernel_helm2_TRG_DIM 2
#define kifmm_kernel_helm2_SCALE_INVARIANT 0
#define kifmm_kernel_helm2_DEGREE 0
#define kifmm_kernel_helm2_HAS (KIFMM_HAS_SETUP | KIFMM_HAS_WAVES | KIFMM_KERNEL__HELM_HOOKS)
#define kifmm_kernel_helm2_setup kifmm_kernel__wavenumber_setup
#define kifmm_kernel_helm2_wavenumber kifmm_kernel__wavenumber
#define kifmm_kernel_helm2_WAVES_MAX KIFMM_KERNEL__HELM_WAVES
#define kifmm_kernel_helm2_eval kifmm_kernel_helmholtz_eval
#define kifmm_kernel_helm2_p2p kifmm_kernel_helmholtz_p2p
#define kifmm_kernel_helm2_p2pf kifmm_kernel_helmholtz_p2pf
#define kifmm_kernel_helmholtz_2x2_SRC_DIM 2
#define kifmm_kernel_helmholtz_2x2_TRG_DIM 8
#define kifmm_kernel_helmholtz_2x2_SCALE_INVARIANT 0
#define kifmm_kernel_helmholtz_2x2_DEGREE 0
#define kifmm_kernel_helmholtz_2x2_EQUIV helm2
#define kifmm_kernel_helmholtz_2x2_HAS (kifmm_kernel_helm2_HAS | KIFMM_KERNEL__HELM_MUTUAL)
#define kifmm_kernel_helmholtz_2x2_setup kifmm_kernel__wavenumber_setup
#define kifmm_kernel_helmholtz_2x2_wavenumber kifmm_kernel__wavenumber
#define kifmm_kernel_helmholtz_2x2_WAVES_MAX KIFMM_KERNEL__HELM_WAVES
#define kifmm_kernel_helmholtz_2x2_eval kifmm_kernel_helmholtz_grad_eval
#define kifmm_kernel_helmholtz_2x2_p2p kifmm_kernel_helmholtz_grad_p2p
#define kifmm_kernel_helmholtz_2x2_p2pf kifmm_kernel_helmholtz_grad_p2pf
#define kifmm_kernel_helmholtz_2x2_p2ps kifmm_kernel_helmholtz_grad_p2ps
#define kifmm_kernel_helmholtz_2x2_p2psf kifmm_kernel_helmholtz_grad_p2psf
#define KIFMM_KERNEL helmholtz_2x2
#include "kifmm.h"

#include "points.h"

/* direct sums at the sample targets idx: laplace_grad (k < 0: real charges
 * q[2 j]) or helmholtz_grad (complex charges, wavenumber k); ref: 4 or 8
 * values a target */
static void direct(double k, int64_t n, const double *x, const double *q, int64_t ns,
                   const int64_t *idx, double *ref)
{
    const int td = k < 0.0 ? 4 : 8;
#pragma omp parallel for schedule(dynamic, 4)
    for (int64_t s = 0; s < ns; s++) {
        const double *t = x + 3 * idx[s];
        double a[8] = {0, 0, 0, 0, 0, 0, 0, 0};
        for (int64_t j = 0; j < n; j++) {
            const double d[3] = {t[0] - x[3 * j], t[1] - x[3 * j + 1], t[2] - x[3 * j + 2]};
            const double r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2], r = sqrt(r2);
            if (r2 == 0.0) continue;
            if (k < 0.0) {
                a[0] += q[2 * j] / r;
                for (int m = 0; m < 3; m++) a[1 + m] -= q[2 * j] * d[m] / (r2 * r);
            } else { /* G q and G (i k r - 1) / r^2 q d */
                const double gr = cos(k * r) / r, gi = sin(k * r) / r;
                const double pr = gr * q[2 * j] - gi * q[2 * j + 1], pi = gr * q[2 * j + 1] + gi * q[2 * j];
                const double ar = (-pr - pi * k * r) / r2, ai = (pr * k * r - pi) / r2;
                a[0] += pr, a[1] += pi;
                for (int m = 0; m < 3; m++) a[2 + 2 * m] += ar * d[m], a[3 + 2 * m] += ai * d[m];
            }
        }
        for (int c = 0; c < td; c++) ref[s * td + c] = a[c] / (4.0 * PI);
    }
}

/* relative L2 error of outputs [k0, k1) of each sample target */
static double rel(int td, int k0, int k1, int64_t ns, const int64_t *idx, const double *out,
                  const double *ref)
{
    double num = 0, den = 0;
    for (int64_t s = 0; s < ns; s++)
        for (int c = k0; c < k1; c++) {
            const double e = out[idx[s] * td + c] - ref[s * td + c];
            num += e * e, den += ref[s * td + c] * ref[s * td + c];
        }
    return sqrt(num / den);
}

static void dump(const char *path, int64_t n, const double *x, const double *q, int64_t ns,
                 const int64_t *idx, const double *ref, const double *tail, double k)
{
    const int64_t head[3] = {2, n, ns}, sd = 2, td = 8;
    const double zk[2] = {k, 0.0};
    FILE *fp = fopen(path, "wb");
    if (!fp || fwrite(head, 8, 3, fp) != 3 || fwrite(x, 8, (size_t)(3 * n), fp) != (size_t)(3 * n) ||
        fwrite(&sd, 8, 1, fp) != 1 || fwrite(q, 8, (size_t)(2 * n), fp) != (size_t)(2 * n) ||
        fwrite(idx, 8, (size_t)ns, fp) != (size_t)ns || fwrite(&td, 8, 1, fp) != 1 ||
        fwrite(ref, 8, (size_t)(8 * ns), fp) != (size_t)(8 * ns) || fwrite(tail, 8, 3, fp) != 3 ||
        fwrite(zk, 8, 2, fp) != 2) {
        fprintf(stderr, "cannot write %s\n", path);
        exit(1);
    }
    fclose(fp);
}

#define RUN(P, TD, Q, OUT, ST, CREATE, EVAL)                                                 \
    do {                                                                                     \
        P *h = NULL;                                                                         \
        double t0 = kifmm__now();                                                            \
        int rc = P##_create(&h, &o, n, x, n, x), k;                                          \
        CREATE = kifmm__now() - t0;                                                          \
        if (rc) {                                                                            \
            fprintf(stderr, "%s: %s\n", #P, kifmm_strerror(rc));                             \
            exit(1);                                                                         \
        }                                                                                    \
        EVAL = 1e30;                                                                         \
        for (k = 0; k < rep; k++) {                                                          \
            kifmm_stats st_;                                                                 \
            P##_evaluate(h, Q, OUT);                                                         \
            P##_stats(h, &st_);                                                              \
            if (st_.t_evaluate < EVAL) EVAL = st_.t_evaluate, ST = st_;                      \
        }                                                                                    \
        P##_destroy(h);                                                                      \
    } while (0)

int main(int argc, char **argv)
{
    int64_t n, ns = 300, s;
    int p, rep = 3, a;
    double waves, k, *x, *q, *ql, *out, *ref, lc, le, hc, he, tail[3], rc2, re2;
    const char *dpath = NULL;
    kifmm_stats sl, sh, s2;
    kifmm_opts o;
    int64_t *idx;
    if (argc < 4) {
        fprintf(stderr, "usage: bench_helmholtz N P WAVES [--sample S] [--repeat R] [--dump FILE]\n");
        return 2;
    }
    n = (int64_t)atof(argv[1]), p = atoi(argv[2]), waves = atof(argv[3]);
    for (a = 4; a + 1 < argc; a += 2) {
        if (!strcmp(argv[a], "--sample")) ns = atoi(argv[a + 1]);
        else if (!strcmp(argv[a], "--repeat")) rep = atoi(argv[a + 1]);
        else if (!strcmp(argv[a], "--dump")) dpath = argv[a + 1];
    }
    k = 2.0 * PI * waves;
    x = (double *)malloc(sizeof(double) * (size_t)(3 * n));
    q = (double *)malloc(sizeof(double) * (size_t)(2 * n));
    ql = (double *)malloc(sizeof(double) * (size_t)n);
    out = (double *)malloc(sizeof(double) * (size_t)(8 * n));
    ref = (double *)malloc(sizeof(double) * (size_t)(8 * ns));
    idx = (int64_t *)malloc(sizeof(int64_t) * (size_t)ns);
    make_points(DIST_CUBE, n, 2, 11, x, q);
    for (s = 0; s < n; s++) ql[s] = q[2 * s];
    for (s = 0; s < ns; s++) idx[s] = s * (n / ns);
    memset(&o, 0, sizeof o);
    memset(&sl, 0, sizeof sl);
    memset(&sh, 0, sizeof sh);
    memset(&s2, 0, sizeof s2);
    o.order = p;
    RUN(kifmm_laplace_grad, 4, ql, out, sl, lc, le);
    direct(-1.0, n, x, q, ns, idx, ref);
    printf("%s points, sources = targets\n", dist_names[DIST_CUBE]);
    printf("kernel            N  p  waves  create    eval   total  x lapg  p2p%%  m2l%%  err(pot)  err(grad)\n");
    printf("laplace_grad %7lld %2d      - %7.3f %7.3f %7.3f    1.00  %4.0f  %4.0f  %.2e   %.2e\n", (long long)n, p,
           lc, le, lc + le, 100.0 * sl.t_p2p / le, 100.0 * sl.t_m2l / le, rel(4, 0, 1, ns, idx, out, ref),
           rel(4, 1, 4, ns, idx, out, ref));
    o.kernel_param[0] = k;
    RUN(kifmm_helmholtz_grad, 8, q, out, sh, hc, he);
    direct(k, n, x, q, ns, idx, ref);
    tail[0] = rel(8, 0, 2, ns, idx, out, ref), tail[1] = rel(8, 2, 8, ns, idx, out, ref), tail[2] = hc + he;
    printf("helmholtz_grad %5lld %2d %6.1f %7.3f %7.3f %7.3f %7.2f  %4.0f  %4.0f  %.2e   %.2e\n", (long long)n, p, waves,
           hc, he, hc + he, (hc + he) / (lc + le), 100.0 * sh.t_p2p / he, 100.0 * sh.t_m2l / he, tail[0], tail[1]);
    if (dpath) dump(dpath, n, x, q, ns, idx, ref, tail, k);
    RUN(kifmm_helmholtz_2x2, 8, q, out, s2, rc2, re2);
    printf("helmholtz 2x2  %5lld %2d %6.1f %7.3f %7.3f %7.3f %7.2f  %4.0f  %4.0f  %.2e   %.2e\n", (long long)n, p, waves,
           rc2, re2, rc2 + re2, (rc2 + re2) / (lc + le), 100.0 * s2.t_p2p / re2, 100.0 * s2.t_m2l / re2,
           rel(8, 0, 2, ns, idx, out, ref), rel(8, 2, 8, ns, idx, out, ref));
    for (a = 0; a < 3; a++) { /* each pass's seconds, laplace_grad, native and 2 x 2; create's parts */
        const kifmm_stats *z = a == 2 ? &s2 : a ? &sh : &sl;
        printf("%s passes: p2m %.3f m2m %.3f m2l %.3f l2l %.3f p2l %.3f l2p %.3f m2p %.3f p2p %.3f;"
               " create: tree %.3f operators %.3f\n",
               a == 2 ? "2x2    " : a ? "complex" : "laplace", z->t_p2m, z->t_m2m, z->t_m2l, z->t_l2l,
               z->t_p2l, z->t_l2p, z->t_m2p, z->t_p2p, z->t_tree, z->t_operators);
    }
    printf("complex M2L %.3f s against 2x2 %.3f s (%.2fx), plan %.1f MiB against %.1f MiB (%.2fx)\n", sh.t_m2l,
           s2.t_m2l, s2.t_m2l / sh.t_m2l, sh.plan_bytes / 1048576.0, s2.plan_bytes / 1048576.0,
           s2.plan_bytes / sh.plan_bytes);
    free(x), free(q), free(ql), free(out), free(ref), free(idx);
    return 0;
}
