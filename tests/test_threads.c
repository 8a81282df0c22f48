/* test_threads.c - the same problem gives the same answer whatever the thread
 * count: for every shipped kernel with the FFT M2L (double and float) and one
 * without (stokes, dense M2L), handles created with 2, 3 and 4 threads (more
 * threads than this machine may have cores) are compared with a handle
 * created with 1 thread on the same points, several times over. A data race
 * in create or evaluate shows as handles that differ far beyond rounding
 * (a shared loop index once made 4 to 6 of 8 handles wrong by 10 % to 60 %
 * in builds at -O0), so the bound is a few hundred units of rounding of the
 * instance's precision, not an accuracy bound. */
#include "kifmm.h"
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"
#define KIFMM_KERNEL yukawa
#include "kifmm.h"
#define KIFMM_KERNEL yukawa_grad
#include "kifmm.h"
#define KIFMM_KERNEL stokes
#include "kifmm.h"
#define KIFMM_KERNEL laplace
#define KIFMM_REAL float
#define KIFMM_NAME kifmm_laplacef
#include "kifmm.h"
#define KIFMM_KERNEL yukawa_grad
#define KIFMM_REAL float
#define KIFMM_NAME kifmm_yukawa_gradf
#include "kifmm.h"
#define KIFMM_KERNEL laplace_grad
#define KIFMM_NAME kifmm_laplace_grad_dense
#define KIFMM_M2L_DENSE 1
#include "kifmm.h"

#include "test.h"

#ifdef KIFMM_TEST_QUICK
#define REPEATS 2
#define NPOINTS 8000
#define NSTOKES 3000
#else
#define REPEATS 4
#define NPOINTS 20000
#define NSTOKES 6000
#endif

/* ||a - b|| / ||b|| in double over n values of type T */
#define REL_DIFF(T)                                                                         \
    static double rel_diff_##T(int64_t n, const T *a, const T *b)                          \
    {                                                                                       \
        double num = 0, den = 0;                                                            \
        int64_t i;                                                                          \
        for (i = 0; i < n; i++) {                                                           \
            double d = (double)a[i] - (double)b[i];                                         \
            if (d != d) return NAN;                                                         \
            num += d * d;                                                                   \
            den += (double)b[i] * (double)b[i];                                             \
        }                                                                                   \
        return den > 0 ? sqrt(num / den) : sqrt(num);                                       \
    }
REL_DIFF(double)
REL_DIFF(float)

/* For instance P of real type T (SD, TD components): a 1-thread reference,
 * then REPEATS handles for each of 2, 3 and 4 threads, each evaluated twice;
 * the largest relative difference from the reference is checked against
 * `bound`. */
#define THREAD_CHECK(P, T, SD, TD)                                                          \
    static void check_##P(const char *dist, int64_t n, const double *xd, int order,        \
                          double bound)                                                     \
    {                                                                                       \
        T *x = (T *)t_malloc_or_die((size_t)(3 * n) * sizeof(T));                           \
        T *q = (T *)t_malloc_or_die((size_t)(SD * n) * sizeof(T));                          \
        T *ref = (T *)t_malloc_or_die((size_t)(TD * n) * sizeof(T));                        \
        T *out = (T *)t_malloc_or_die((size_t)(TD * n) * sizeof(T));                        \
        t_rng r = t_rng_seed(77);                                                           \
        kifmm_opts o = t_opts(order, 0, 0);                                                 \
        P *h = NULL;                                                                        \
        double worst = 0.0;                                                                 \
        int64_t i;                                                                          \
        int th, rep, ev, rc, nbad = 0;                                                      \
        for (i = 0; i < 3 * n; i++) x[i] = (T)xd[i];                                        \
        for (i = 0; i < SD * n; i++) q[i] = (T)t_uniform(&r, -1.0, 1.0);                    \
        o.kernel_param[0] = 3.0;                                                            \
        o.nthreads = 1;                                                                     \
        rc = P##_create(&h, &o, n, x, n, x);                                                \
        if (!rc) rc = P##_evaluate(h, q, ref);                                              \
        P##_destroy(h);                                                                     \
        CHECK(rc == 0, "%s %s: 1-thread reference rc=%d", #P, dist, rc);                    \
        for (th = 2; th <= 4 && rc == 0; th++)                                              \
            for (rep = 0; rep < REPEATS; rep++) {                                           \
                o.nthreads = th;                                                            \
                h = NULL;                                                                   \
                rc = P##_create(&h, &o, n, x, n, x);                                        \
                for (ev = 0; ev < 2 && rc == 0; ev++) {                                     \
                    double d;                                                               \
                    for (i = 0; i < TD * n; i++) out[i] = (T)NAN;                           \
                    rc = P##_evaluate(h, q, out);                                           \
                    d = rel_diff_##T(TD * n, out, ref);                                     \
                    if (!(d <= bound)) nbad++;                                              \
                    if (!(d <= worst)) worst = d;                                           \
                }                                                                           \
                P##_destroy(h);                                                             \
                CHECK(rc == 0, "%s %s: %d threads rc=%d", #P, dist, th, rc);                \
            }                                                                               \
        CHECK(nbad == 0, "%s %s: %d of %d evaluations differ from 1 thread by more than "   \
                         "%.0e",                                                            \
              #P, dist, nbad, 3 * REPEATS * 2, bound);                                      \
        CHECK_ERR(worst, bound, "%s %s p=%d: 2-4 threads vs 1, max rel diff", #P, dist,     \
                  order);                                                                   \
        free(x);                                                                            \
        free(q);                                                                            \
        free(ref);                                                                          \
        free(out);                                                                          \
    }
/* The operators factored side by side on the handle's threads (2 threads,
 * OpenBLAS at one thread a call: kifmm__blas_serial) and one after the
 * other (1 thread): bitwise the same factors, lattice fits and dense M2L
 * matrices at every level. OpenBLAS's thread count is set through a weak
 * reference (skipped where the BLAS is not OpenBLAS, the platform has no
 * weak symbols, or without OpenMP, where nothing runs side by side). */
#if defined(__ELF__) && defined(__GNUC__) && !defined(KIFMM_NO_BLAS_PROBE) && defined(_OPENMP)
#ifdef __cplusplus
extern "C"
#endif
void openblas_set_num_threads(int) __attribute__((weak));
#define HAVE_SET_THREADS 1
#else
#define HAVE_SET_THREADS 0
#endif
#define SAME(a, b, n) ((a) == (b) || ((a) && (b) && memcmp((a), (b), (size_t)(n) * sizeof *(a)) == 0))
#define SOLVES_CHECK(P)                                                                     \
    static void solves_##P(const char *dist, int64_t n, const double *x, int order)        \
    {                                                                                       \
        kifmm_opts o = t_opts(order, 64, 0); /* levels with V lists at 3,000 points */     \
        P *h[2] = {NULL, NULL};                                                             \
        int k, l, rc = 0, sets = 0, same = 1;                                               \
        o.kernel_param[0] = 3.0;                                                            \
        for (k = 0; k < 2 && !rc; k++) {                                                    \
            o.nthreads = 2 - k;                                                             \
            rc = P##_create(&h[k], &o, n, x, n, x);                                         \
        }                                                                                   \
        CHECK(rc == 0 && kifmm__blas_serial(), "%s %s: rc=%d, OpenBLAS at one thread", #P,   \
              dist, rc);                                                                    \
        for (l = 0; !rc && l < h[0]->tree->nlev; l++) {                                     \
            const P##__ops *a = h[0]->lv[l], *b = h[1]->lv[l];                              \
            const size_t nc = (size_t)h[0]->pl->surf.nc, ne = (size_t)h[0]->pl->surf.ne;    \
            const size_t nd = (size_t)h[0]->pl->surf.nde;                                   \
            if (!a || !b) {                                                                 \
                same &= !a && !b;                                                           \
                continue;                                                                   \
            }                                                                               \
            sets++;                                                                         \
            same &= a->ku == b->ku && a->kd == b->kd && SAME(a->ut_up, b->ut_up, a->ku * nc) && \
                    SAME(a->vs_up, b->vs_up, ne * a->ku) && SAME(a->ut_dn, b->ut_dn, a->kd * nc) && \
                    SAME(a->vs_dn, b->vs_dn, nd * a->kd) && SAME(a->conv, b->conv, nc * ne) &&  \
                    SAME(a->m2l, b->m2l, (size_t)a->kd * KIFMM__NT * ne);                       \
        }                                                                                   \
        if (!rc)                                                                            \
            CHECK(same && sets > 0, "%s %s p=%d: %d operator sets factored side by side "   \
                  "(2 threads) bitwise those one after the other (1 thread)", #P, dist, order, sets); \
        P##_destroy(h[0]);                                                                  \
        P##_destroy(h[1]);                                                                  \
    }
#if HAVE_SET_THREADS
SOLVES_CHECK(kifmm_laplace_grad)
SOLVES_CHECK(kifmm_yukawa_grad)
SOLVES_CHECK(kifmm_stokes)
SOLVES_CHECK(kifmm_laplace_grad_dense)
#endif

THREAD_CHECK(kifmm_laplace, double, 1, 1)
THREAD_CHECK(kifmm_laplace_grad, double, 1, 4)
THREAD_CHECK(kifmm_yukawa, double, 1, 1)
THREAD_CHECK(kifmm_yukawa_grad, double, 1, 4)
THREAD_CHECK(kifmm_stokes, double, 3, 3)
THREAD_CHECK(kifmm_laplacef, float, 1, 1)
THREAD_CHECK(kifmm_yukawa_gradf, float, 1, 4)

int main(void)
{
    const int64_t n = NPOINTS, ns = NSTOKES;
    double *cube = t_doubles(3 * n), *sphere = t_doubles(3 * n);
    t_rng r = t_rng_seed(5);
    /* differences from summation order alone: a few units of rounding of
     * the result's norm; the bound leaves room for a few hundred */
    const double bd = 1e-13, bf = 3e-5;
    t_gen_cube(&r, n, cube, 0.0, 1.0);
    t_gen_sphere(&r, n, sphere);
#ifndef _OPENMP
    printf("  built without OpenMP: nthreads 2-4 run on one thread (still compared)\n");
#endif
    t_group("FFT M2L kernels, double: 2, 3, 4 threads against 1");
    check_kifmm_laplace("cube", n, cube, 6, bd);
    check_kifmm_laplace("sphere", n, sphere, 6, bd);
    check_kifmm_laplace_grad("cube", n, cube, 8, bd);
    check_kifmm_yukawa("cube", n, cube, 6, bd);
    check_kifmm_yukawa_grad("sphere", n, sphere, 4, bd);
    t_group("FFT M2L kernels, float");
    check_kifmm_laplacef("cube", n, cube, 4, bf);
    check_kifmm_yukawa_gradf("sphere", n, sphere, 4, bf);
    t_group("dense M2L: stokes");
    check_kifmm_stokes("cube", ns, cube, 4, bd);
    t_group("operators factored side by side (OpenBLAS at 1 thread) and one after the other");
#if HAVE_SET_THREADS /* (kifmm.h declares openblas_get_num_threads and _parallel, weak) */
    if (openblas_set_num_threads && openblas_get_num_threads && openblas_get_parallel &&
        openblas_get_parallel() != 0) { /* a threaded OpenBLAS (kifmm__blas_serial) */
        const int blas0 = openblas_get_num_threads();
        openblas_set_num_threads(1);
        solves_kifmm_laplace_grad("cube", n, cube, 10);
        solves_kifmm_yukawa_grad("sphere", n, sphere, 6);
        solves_kifmm_stokes("cube", ns, cube, 6);
        solves_kifmm_laplace_grad_dense("cube", ns, cube, 6);
        openblas_set_num_threads(blas0);
    } else
#endif
        printf("  not a threaded OpenBLAS, or no OpenMP: not compared\n");
    free(cube);
    free(sphere);
    return t_finish();
}
