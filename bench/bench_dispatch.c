/* bench/bench_dispatch.c - the compiled library (libkifmm, its instruction-set
 * level chosen at run time: src/kifmm_dispatch.c) against the same kernels
 * compiled here from the headers, on the same points in one process
 *
 *   bench_dispatch N [P] [--repeat R]
 *
 * For laplace_grad, stokes and yukawa_grad (default parameters) on N uniform
 * points in the unit cube (sources = targets, order P, default 6): a
 * handle of the library and one of this program's own instance, each
 * evaluating R times (default 3) in turn, lib and header interleaved; prints
 * the fastest evaluate of each, the library's over the header's, and the
 * largest difference between their outputs relative to the largest output.
 * The first line gives the library's stats.build (its level) and this
 * program's instruction set. Build it with the flags to compare against
 * (bench/run.sh: -march=native, and -mno-avx512f beside KIFMM_ISA=avx2) and
 * link libkifmm. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <omp.h>

#include "kifmm_lib.h"

#define KIFMM_NAME hdr_laplace_grad
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"
#define KIFMM_NAME hdr_stokes
#define KIFMM_KERNEL stokes
#include "kifmm.h"
#define KIFMM_NAME hdr_yukawa_grad
#define KIFMM_KERNEL yukawa_grad
#include "kifmm.h"

#include "points.h"

#if defined(__AVX512F__)
#define ISA "AVX-512"
#elif defined(__AVX2__) && defined(__FMA__)
#define ISA "AVX2"
#else
#define ISA "portable C"
#endif

/* One instance's create, evaluate and destroy behind a void handle, so that
 * one function times the library's and the header's alike. */
typedef struct {
    int (*create)(void **h, const kifmm_opts *o, int64_t n, const double *x);
    int (*evaluate)(void *h, const double *q, double *u);
    void (*destroy)(void *h);
} api;
#define API(P)                                                                                     \
    static int P##_c(void **h, const kifmm_opts *o, int64_t n, const double *x)                   \
    {                                                                                              \
        P *t = NULL;                                                                               \
        int rc = P##_create(&t, o, n, x, n, x);                                                    \
        *h = t;                                                                                    \
        return rc;                                                                                 \
    }                                                                                              \
    static int P##_e(void *h, const double *q, double *u) { return P##_evaluate((P *)h, q, u); }  \
    static void P##_d(void *h) { P##_destroy((P *)h); }                                           \
    static const api P##_api = {P##_c, P##_e, P##_d};
API(kifmm_laplace_grad)
API(hdr_laplace_grad)
API(kifmm_stokes)
API(hdr_stokes)
API(kifmm_yukawa_grad)
API(hdr_yukawa_grad)

/* One kernel: both handles on the same points, R evaluates each in turn,
 * the row; 0 or 1 for a failure. */
static int bench_one(const char *name, const api *lib, const api *hdr, int sd, int td,
                     const kifmm_opts *o, int64_t n, int reps, double *x)
{
    void *hl = NULL, *hh = NULL;
    double tl = 1e30, th = 1e30, t0, t, diff = 0, big = 0;
    double *q = malloc(sizeof(double) * (size_t)sd * (size_t)n);
    double *ul = malloc(sizeof(double) * (size_t)td * (size_t)n);
    double *uh = malloc(sizeof(double) * (size_t)td * (size_t)n);
    int r, rc = q && ul && uh ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM;
    int64_t i;
    if (!rc) make_points(0, n, sd, 11, x, q);
    if (!rc) rc = lib->create(&hl, o, n, x);
    if (!rc) rc = hdr->create(&hh, o, n, x);
    for (r = 0; r < reps && !rc; r++) {
        t0 = omp_get_wtime();
        rc = lib->evaluate(hl, q, ul);
        t = omp_get_wtime() - t0;
        if (t < tl) tl = t;
        t0 = omp_get_wtime();
        if (!rc) rc = hdr->evaluate(hh, q, uh);
        t = omp_get_wtime() - t0;
        if (t < th) th = t;
    }
    for (i = 0; !rc && i < (int64_t)td * n; i++) {
        if (fabs(ul[i] - uh[i]) > diff) diff = fabs(ul[i] - uh[i]);
        if (fabs(uh[i]) > big) big = fabs(uh[i]);
    }
    if (!rc)
        printf("%-13s %9lld %2d %9.3f %9.3f %8.3f %10.1e\n", name, (long long)n, o->order, tl, th, tl / th,
               diff / big);
    else
        printf("%-13s FAILED: %s\n", name, kifmm_lib_strerror(rc));
    if (hl) lib->destroy(hl);
    if (hh) hdr->destroy(hh);
    free(q), free(ul), free(uh);
    return rc != KIFMM_SUCCESS;
}

int main(int argc, char **argv)
{
    int64_t n = argc > 1 ? (int64_t)atof(argv[1]) : 100000;
    int p = argc > 2 && argv[2][0] != '-' ? atoi(argv[2]) : 6, reps = 3, i, failed = 0;
    double *x;
    for (i = 1; i < argc; i++)
        if (!strcmp(argv[i], "--repeat") && i + 1 < argc) reps = atoi(argv[++i]);
    if (n < 1 || p < 2 || reps < 1) {
        fprintf(stderr, "usage: bench_dispatch N [P] [--repeat R]\n");
        return 2;
    }
    x = malloc(sizeof(double) * 3 * (size_t)n);
    if (!x) return 1;
    {
        kifmm_laplace_grad *h = NULL;
        kifmm_stats st;
        kifmm_opts o = {0};
        o.order = p;
        if (kifmm_laplace_grad_create(&h, &o, 0, NULL, 0, NULL) || kifmm_laplace_grad_stats(h, &st)) {
            printf("libkifmm: create or stats failed\n");
            return 1;
        }
        printf("libkifmm: %s\nthis program: %s\n", st.build, ISA);
        kifmm_laplace_grad_destroy(h);
    }
    printf("%s points\nkernel                N  p   lib (s)   hdr (s)  lib/hdr  max |diff|\n", dist_names[0]);
    {
        kifmm_opts o = {0};
        o.order = p;
        failed |= bench_one("laplace_grad", &kifmm_laplace_grad_api, &hdr_laplace_grad_api, 1, 4, &o, n, reps, x);
        failed |= bench_one("stokes", &kifmm_stokes_api, &hdr_stokes_api, 3, 3, &o, n, reps, x);
        failed |= bench_one("yukawa_grad", &kifmm_yukawa_grad_api, &hdr_yukawa_grad_api, 1, 4, &o, n, reps, x);
    }
    free(x);
    return failed;
}
