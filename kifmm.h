/* kifmm.h - v0.1.0 - kernel-independent fast multipole method in 3-D, header-only C
 *
 * CONTENTS
 *   1. Quick start
 *   2. Template parameters and compile-time options
 *   3. Shared part (once per translation unit): results, options, memory,
 *      Morton keys, the adaptive octree and its lists
 *   4. Kernel template (once per include, in the instance's precision):
 *      kernel loops, operators, the level passes, the evaluation passes in
 *      pipeline order, the public entry points
 *   5. Epilogue (#undef of the template parameters), license
 *
 * 1. QUICK START
 *
 *   #include "kifmm.h"                      // Laplace 1/(4 pi r), double
 *   kifmm_opts opts = {0};                  // zero = default, or pass NULL
 *   opts.order = 6;
 *   kifmm_laplace *fmm = NULL;
 *   int rc = kifmm_laplace_create(&fmm, &opts, ns, src_xyz, nt, trg_xyz);
 *   if (rc < 0) fprintf(stderr, "kifmm: %s\n", kifmm_strerror(rc));
 *   rc = kifmm_laplace_evaluate(fmm, charges, pot);   // as often as needed
 *   rc = kifmm_laplace_evaluate_many(fmm, 4, q4, pot4); // 4 density vectors at once
 *   kifmm_laplace_destroy(fmm);
 *
 *   Link with -llapacke -lopenblas -lm, and -fopenmp for threads.
 *
 * 2. TEMPLATE PARAMETERS (set before an include; the header #undefs them)
 *
 *   KIFMM_KERNEL  kernel name from kifmm_kernels.h or one of your own
 *                 (docs/kernels.md); default laplace
 *   KIFMM_REAL    double (default) or float: coordinates, densities, outputs
 *                 and the arithmetic of the passes (operators are built in
 *                 double and rounded)
 *   KIFMM_NAME    prefix of the generated type and functions; default
 *                 kifmm_<KIFMM_KERNEL>, or kifmm_<KIFMM_KERNEL>f for float
 *
 *   e.g.  #define KIFMM_KERNEL stokes
 *         #define KIFMM_REAL float
 *         #define KIFMM_NAME kifmm_stokesf
 *         #include "kifmm.h"                 // kifmm_stokesf_create(..., const float *, ...)
 *
 *   COMPILE-TIME OPTIONS (set before the first include in a translation unit)
 *
 *   KIFMM_MALLOC(size) / KIFMM_FREE(ptr)   allocator pair; define both or none
 *   KIFMM_SVD_CUTOFF   relative singular value cutoff of the check-to-equivalent
 *                      pseudo-inverses (default 1e-14, see docs/algorithm.md)
 *
 *   Documentation: docs/api.md (functions, options, errors), docs/algorithm.md
 *   (how the method maps to this file), docs/kernels.md (writing a kernel).
 *
 *   OpenBLAS: BLAS is only called outside OpenMP parallel regions, with large
 *   matrices; its own threads follow OPENBLAS_NUM_THREADS. On machines where
 *   OpenBLAS misdetects the CPU, set OPENBLAS_CORETYPE (e.g. SkylakeX, Haswell).
 */

/* g++ 12 false positives inside its AVX-512 intrinsics (see kifmm_kernels.h):
 * silenced for this file's code, restored at its end. */
#if defined(__GNUC__) && !defined(__clang__) && defined(__cplusplus)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#endif

/* ======================================================================== */
/* 3. Shared part                                                           */
/* ======================================================================== */
#ifndef KIFMM_H_SHARED
#define KIFMM_H_SHARED

#define KIFMM_VERSION_MAJOR 0
#define KIFMM_VERSION_MINOR 1
#define KIFMM_VERSION_PATCH 0

/* System headers with C++ linkage even inside a C++ host's extern "C". */
#ifdef __cplusplus
extern "C++" {
#endif
#include <float.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <math.h>
#include <time.h>
#include <cblas.h>
#include <lapacke.h>
#ifdef _OPENMP
#include <omp.h>
#endif
#if defined(__AVX2__) && defined(__FMA__)
#include <immintrin.h>
#endif
#ifdef __cplusplus
}
#endif

#include "kifmm_kernels.h"

#if defined(KIFMM_MALLOC) && !defined(KIFMM_FREE)
#error "kifmm.h: KIFMM_MALLOC is defined but KIFMM_FREE is not; define both or neither"
#endif
#if defined(KIFMM_FREE) && !defined(KIFMM_MALLOC)
#error "kifmm.h: KIFMM_FREE is defined but KIFMM_MALLOC is not; define both or neither"
#endif
#ifndef KIFMM_MALLOC
#define KIFMM_MALLOC(size) malloc(size)
#define KIFMM_FREE(ptr) free(ptr)
#endif

#ifndef KIFMM_SVD_CUTOFF
#define KIFMM_SVD_CUTOFF 1e-14
#endif

/* KIFMM_CHECK_ORDER_DIFF: check surfaces use order p + this. Left undefined,
 * it is 0 up to order KIFMM_SQUARE_MAX_ORDER for kernels with the FFT M2L,
 * and 1 above and for the others (see kifmm__check_diff). */
#ifndef KIFMM_SQUARE_MAX_ORDER
#define KIFMM_SQUARE_MAX_ORDER 7
#endif

/* Double instances of scale-invariant kernels keep the FFT M2L's spectra
 * and products in float up to this order (float instances always do): half
 * the spectra's memory and products about 1.4 times faster. Float spectra
 * carry an error of about 1e-7 relative to each box's own field, not to the
 * total, and where the fields of many boxes cancel (charges that sum to
 * zero, seen from afar) that error can pass the truncation error: 20,000
 * neutral charges with targets 30 cloud sizes away give 3.9e-5 with float
 * spectra at p = 6 against 1.6e-6 in double; at p = 4 and 5 the truncation
 * error still dominates (1.8e-4 against 1.7e-4, 2.3e-6 against 5.2e-6; at
 * 300 sizes away 7.8e-4 both, 9.7e-6 against 8.7e-6). Hence 5; 0 for double
 * spectra at every order, 6 or more for speed where nothing cancels. */
#ifndef KIFMM_FFT_SINGLE_MAX_ORDER
#define KIFMM_FFT_SINGLE_MAX_ORDER 5
#endif

/* Memory for the spectra of the FFT M2L, in MiB: a level whose source
 * spectra do not fit is done in slabs of target parents, each with the
 * spectra of its own neighbours (some computed twice). A handle whose
 * expansion array (one of the two) takes more uses that much, up to 4 times
 * this. */
#ifndef KIFMM_FFT_SPEC_MB
#define KIFMM_FFT_SPEC_MB 64
#endif

#define KIFMM_MAX_ORDER 12   /* largest expansion order accepted */
#define KIFMM_MAX_DEPTH 20   /* deepest tree level (Morton keys hold 3 x 20 bits) */
#define KIFMM_DEFAULT_ORDER 6
#define KIFMM_DEFAULT_DEPTH 16

/* Most threads a handle accepts (opts.nthreads): each thread has buffers of
 * its own (a few MiB at high orders), and starting thousands of threads
 * takes seconds. Define it before the first include to change it. */
#ifndef KIFMM_MAX_THREADS
#define KIFMM_MAX_THREADS 1024
#endif

/* Most points of one set: beyond this, 3 coordinates and 8 vectors of up to
 * 16 components of 8 bytes would not fit in any address space (far beyond
 * any memory; the check exists so that counts such as INT64_MAX give
 * KIFMM_ERR_COUNT instead of an overflow). */
#define KIFMM_MAX_POINTS ((int64_t)(PTRDIFF_MAX / 1024))

#if defined(__GNUC__) || defined(__clang__)
#define KIFMM__FN static __attribute__((unused))
#else
#define KIFMM__FN static
#endif

/* OpenMP regions follow one rule, so that a reviewer can check it at a
 * glance: every variable a region writes is declared inside the region (the
 * index of a parallel loop in its for statement) or named in a reduction
 * clause; everything declared outside is only read. Shared arrays are
 * written at indices that belong to one iteration or one thread (each region
 * says which). */
#define KIFMM__PRAGMA(x) _Pragma(#x)
#ifdef _OPENMP
#define KIFMM__OMP(x) KIFMM__PRAGMA(omp x)
#else
#define KIFMM__OMP(x)
#endif

/* restrict in C99, its extension in C++ */
#if defined(__cplusplus)
#define KIFMM__RESTRICT __restrict
#else
#define KIFMM__RESTRICT restrict
#endif

#define KIFMM__CAT_(a, b) a##b
#define KIFMM__CAT(a, b) KIFMM__CAT_(a, b)
#define KIFMM__CAT3(a, b, c) KIFMM__CAT(KIFMM__CAT(a, b), c)

/* Preprocessor tests on macros that may be undefined, without evaluating an
 * undefined name in #if (-Wundef clean): KIFMM__IS_ONE(x) is the token 1 if
 * x expands to 1, else 0; KIFMM__IS_PAREN(x) is 1 if x expands to something
 * in parentheses, else 0; KIFMM__IF(c)(a, b) is a if c is 1, else b. */
#define KIFMM__SECOND_(a, b, ...) b
#define KIFMM__SECOND(...) KIFMM__SECOND_(__VA_ARGS__, 0, 0)
#define KIFMM__PROBE ~, 1
#define KIFMM__ONE_1 KIFMM__PROBE
#define KIFMM__IS_ONE(x) KIFMM__SECOND(KIFMM__CAT(KIFMM__ONE_, x))
#define KIFMM__PAREN_PROBE(...) KIFMM__PROBE
#define KIFMM__IS_PAREN(x) KIFMM__SECOND(KIFMM__PAREN_PROBE x)
#define KIFMM__IF(c) KIFMM__CAT(KIFMM__IF_, c)
#define KIFMM__IF_1(a, b) a
#define KIFMM__IF_0(a, b) b

/* C99 static assert: a typedef'd array whose name is the message. */
#define KIFMM__STATIC_ASSERT(cond, msg) typedef char KIFMM__CAT(kifmm__assert_, msg)[(cond) ? 1 : -1]

/* ---- results ------------------------------------------------------------ */

/* Every result code and its message, from one list: X(name, value, message). */
#define KIFMM__RESULTS(X)                                                                     \
    X(KIFMM_SUCCESS, 0, "success")                                                            \
    X(KIFMM_ERR_NULL, -1, "a required pointer argument is NULL")                              \
    X(KIFMM_ERR_COUNT, -2,                                                                    \
      "a count is negative or too large for any array (see KIFMM_MAX_POINTS)")                \
    X(KIFMM_ERR_NONFINITE, -3, "a coordinate is NaN or infinite")                            \
    X(KIFMM_ERR_ORDER, -4, "expansion order out of range (2 to KIFMM_MAX_ORDER)")             \
    X(KIFMM_ERR_LEAF_SIZE, -5, "leaf size is negative")                                       \
    X(KIFMM_ERR_DEPTH, -6, "maximum depth out of range (0 to KIFMM_MAX_DEPTH)")               \
    X(KIFMM_ERR_NTHREADS, -7, "number of threads out of range (0 to KIFMM_MAX_THREADS)")      \
    X(KIFMM_ERR_PARAM, -8, "a kernel parameter is out of range")                              \
    X(KIFMM_ERR_NOMEM, -9, "memory allocation failed")                                        \
    X(KIFMM_ERR_LAPACK, -10, "a singular value decomposition did not converge")               \
    X(KIFMM_ERR_INTERNAL, -11, "an internal limit was exceeded (please report)")              \
    X(KIFMM_ERR_KERNEL, -12,                                                                  \
      "the kernel gave a NaN or infinite value on the expansion surfaces (check its "         \
      "parameters)")

#define KIFMM__RESULT_ENUM(name, value, message) name = value,
#define KIFMM__RESULT_CASE(name, value, message)                                              \
    case value: return message;
enum { KIFMM__RESULTS(KIFMM__RESULT_ENUM) };

/* kifmm_strerror: a one-line message for a result code; never NULL. */
KIFMM__FN const char *kifmm_strerror(int code)
{
    switch (code) {
        KIFMM__RESULTS(KIFMM__RESULT_CASE)
    default: return "unknown kifmm result code";
    }
}
#undef KIFMM__RESULT_ENUM
#undef KIFMM__RESULT_CASE

/* ---- options ------------------------------------------------------------ */

/* Every field zero means its default, so {0} (or a NULL pointer) is valid. */
typedef struct kifmm_opts {
    int order;              /* expansion order p, 2..KIFMM_MAX_ORDER; 0 = 6 */
    int leaf_size;          /* max points per leaf; 0 = chosen per order */
    int max_depth;          /* deepest level, 1..KIFMM_MAX_DEPTH; 0 = 16 */
    int nthreads;           /* OpenMP threads, 1..KIFMM_MAX_THREADS; 0 =
                               omp_get_max_threads(); always 1 without OpenMP */
    double kernel_param[4]; /* kernel parameters; 0 = the kernel's default */
} kifmm_opts;

KIFMM__FN int kifmm__default_leaf(int order)
{
    /* Larger expansions make the far field dearer per box, so leaves grow
     * with the number of surface points; from p = 7 on the M2L products run
     * in double and leaves of a few hundred points pay (measured: 1M uniform
     * points, p = 8: 5.8 s at 384 against 10.3 s at 192; 1M points on a
     * sphere: p = 4 1.4 s at 128 against 2.3 s at 64, p = 5 2.0 s at 128
     * against 2.8 s at 96); see docs/algorithm.md. */
    static const int leaf[KIFMM_MAX_ORDER + 1] = {0, 0, 32, 48, 128, 128, 128, 384, 384,
                                                  448, 512, 576, 640};
    return leaf[order];
}

/* Resolve defaults and check ranges; *out gets the values actually used. */
KIFMM__FN int kifmm__resolve_opts(const kifmm_opts *in, kifmm_opts *out)
{
    kifmm_opts o;
    if (in) o = *in;
    else memset(&o, 0, sizeof o);
    if (o.order == 0) o.order = KIFMM_DEFAULT_ORDER;
    if (o.order < 2 || o.order > KIFMM_MAX_ORDER) return KIFMM_ERR_ORDER;
    if (o.leaf_size < 0) return KIFMM_ERR_LEAF_SIZE;
    if (o.leaf_size == 0) o.leaf_size = kifmm__default_leaf(o.order);
    if (o.max_depth < 0 || o.max_depth > KIFMM_MAX_DEPTH) return KIFMM_ERR_DEPTH;
    if (o.max_depth == 0) o.max_depth = KIFMM_DEFAULT_DEPTH;
    if (o.nthreads < 0 || o.nthreads > KIFMM_MAX_THREADS) return KIFMM_ERR_NTHREADS;
#ifdef _OPENMP
    if (o.nthreads == 0) o.nthreads = omp_get_max_threads();
    if (o.nthreads > KIFMM_MAX_THREADS) o.nthreads = KIFMM_MAX_THREADS;
#else
    o.nthreads = 1; /* what really runs: a build without OpenMP has one thread */
#endif
    *out = o;
    return KIFMM_SUCCESS;
}

/* ---- statistics --------------------------------------------------------- */

/* What a handle is made of and where the last evaluation spent its time. */
typedef struct kifmm_stats {
    int levels;                 /* tree levels */
    int64_t boxes, leaves;      /* boxes in the tree, leaves holding targets */
    double t_tree, t_operators; /* create: tree and lists, operators (seconds) */
    double t_p2m, t_m2m, t_m2l, t_l2l, t_p2l, t_l2p, t_m2p, t_p2p; /* last evaluate */
    double t_evaluate;          /* last evaluate, total */
    double bytes;               /* memory held by the handle */
    int64_t max_leaf;           /* most sources or targets in one leaf */
    int64_t crowded;            /* points in leaves holding more than leaf_size of
                                   them: leaves at max_depth, or of points that
                                   share one position at depth KIFMM_MAX_DEPTH;
                                   their near field is a direct sum, O(n^2) in
                                   such a leaf's n (docs/api.md, "Limits") */
    int threads;                /* threads the handle's loops run on */
    int simd;                   /* vector width the build's kernels use, in bits:
                                   512 (AVX-512), 256 (AVX2 + FMA), 0 (none:
                                   compiled without -march or -mavx2 -mfma) */
    char build[256];            /* the code paths of this instance, in words */
} kifmm_stats;

/* The widest instruction set the build's own kernels use. */
#if defined(__AVX512F__)
#define KIFMM__SIMD_BITS 512
#define KIFMM__SIMD_NAME "AVX-512"
#elif defined(__AVX2__) && defined(__FMA__)
#define KIFMM__SIMD_BITS 256
#define KIFMM__SIMD_NAME "AVX2"
#else
#define KIFMM__SIMD_BITS 0
#define KIFMM__SIMD_NAME "portable C"
#endif

/* Wall-clock seconds (CPU seconds in builds without OpenMP, which run on one
 * thread; C99 has no portable wall clock). */
KIFMM__FN double kifmm__now(void)
{
#ifdef _OPENMP
    return omp_get_wtime();
#else
    return (double)clock() / (double)CLOCKS_PER_SEC;
#endif
}

/* ---- memory ------------------------------------------------------------- */

/* 64-byte aligned blocks through the user's allocator; the raw pointer sits
 * just below the aligned one. Returns NULL on overflow or failure. */
KIFMM__FN void *kifmm__alloc(size_t count, size_t size)
{
    size_t n;
    unsigned char *raw, *p;
    if (size && count > (SIZE_MAX - 128) / size) return NULL;
    n = count * size + 64 + sizeof(void *);
    raw = (unsigned char *)KIFMM_MALLOC(n);
    if (!raw) return NULL;
    p = raw + sizeof(void *);
    p += (64 - ((uintptr_t)p & 63)) & 63;
    memcpy(p - sizeof(void *), &raw, sizeof(void *));
    return p;
}

KIFMM__FN void *kifmm__calloc(size_t count, size_t size)
{
    void *p = kifmm__alloc(count, size);
    if (p) memset(p, 0, count * size);
    return p;
}

/* Do the byte ranges [a, a + na) and [b, b + nb) overlap? */
KIFMM__FN int kifmm__overlap(const void *a, size_t na, const void *b, size_t nb)
{
    const uintptr_t x = (uintptr_t)a, y = (uintptr_t)b;
    return x < y + nb && y < x + na;
}

KIFMM__FN void kifmm__free(void *p)
{
    void *raw;
    if (!p) return;
    memcpy(&raw, (unsigned char *)p - sizeof(void *), sizeof(void *));
    KIFMM_FREE(raw);
}

/* ---- dense linear algebra ---------------------------------------------- */

/* C = alpha op(A) op(B) + beta C, column major. Called outside parallel
 * regions only, so a threaded BLAS uses its own threads on a large call. */
KIFMM__FN void kifmm__gemm(int ta, int tb, int m, int n, int k, double alpha,
                           const double *a, int lda, const double *b, int ldb,
                           double beta, double *c, int ldc)
{
    if (m <= 0 || n <= 0) return;
    if (k <= 0) {
        int i, j;
        for (j = 0; j < n; j++)
            for (i = 0; i < m; i++) c[i + (size_t)j * ldc] *= beta;
        return;
    }
    cblas_dgemm(CblasColMajor, ta ? CblasTrans : CblasNoTrans, tb ? CblasTrans : CblasNoTrans,
                m, n, k, alpha, a, lda, b, ldb, beta, c, ldc);
}

/* Pseudo-inverse of the m x n matrix A (destroyed) from its SVD, truncated at
 * s_i > cutoff * s_0, kept as two factors: pinv(A) = vs * ut with
 * ut = U_k^T (k x m) and vs = V_k S_k^-1 (n x k). Applying them one after the
 * other keeps the digits that forming the product would lose. */
KIFMM__FN int kifmm__pinv(double *a, int m, int n, double cutoff, double **ut_out,
                          double **vs_out, int *rank)
{
    int mn = m < n ? m : n, i, j, k, rc = KIFMM_SUCCESS;
    lapack_int info;
    double query, *s, *u, *vt, *work = NULL, *ut = NULL, *vs = NULL;
    lapack_int *iwork = NULL;
    size_t lwork;
    s = (double *)kifmm__alloc((size_t)mn, sizeof(double));
    u = (double *)kifmm__alloc((size_t)m * mn, sizeof(double));
    vt = (double *)kifmm__alloc((size_t)mn * n, sizeof(double));
    if (!s || !u || !vt) { rc = KIFMM_ERR_NOMEM; goto done; }
    iwork = (lapack_int *)kifmm__alloc((size_t)8 * mn, sizeof(lapack_int));
    if (!iwork) { rc = KIFMM_ERR_NOMEM; goto done; }
    info = LAPACKE_dgesdd_work(LAPACK_COL_MAJOR, 'S', m, n, a, m, s, u, m, vt, mn, &query, -1,
                               iwork);
    if (info != 0) { rc = KIFMM_ERR_LAPACK; goto done; }
    lwork = (size_t)query + 1;
    work = (double *)kifmm__alloc(lwork, sizeof(double));
    if (!work) { rc = KIFMM_ERR_NOMEM; goto done; }
    info = LAPACKE_dgesdd_work(LAPACK_COL_MAJOR, 'S', m, n, a, m, s, u, m, vt, mn, work,
                               (lapack_int)lwork, iwork);
    if (info != 0) { rc = KIFMM_ERR_LAPACK; goto done; }
    /* rank 0 for a zero matrix (a level whose far field is dropped) */
    for (k = 0; k < mn && s[k] > cutoff * s[0]; k++) {}
    ut = (double *)kifmm__alloc((size_t)k * m, sizeof(double));
    vs = (double *)kifmm__alloc((size_t)n * k, sizeof(double));
    if (!ut || !vs) { rc = KIFMM_ERR_NOMEM; goto done; }
    for (i = 0; i < m; i++)
        for (j = 0; j < k; j++) ut[j + (size_t)i * k] = u[i + (size_t)j * m];
    for (j = 0; j < k; j++)
        for (i = 0; i < n; i++) vs[i + (size_t)j * n] = vt[j + (size_t)i * mn] / s[j];
    *ut_out = ut;
    *vs_out = vs;
    *rank = k;
    ut = vs = NULL;
done:
    kifmm__free(s);
    kifmm__free(u);
    kifmm__free(vt);
    kifmm__free(work);
    kifmm__free(iwork);
    kifmm__free(ut);
    kifmm__free(vs);
    return rc;
}

/* ---- GEMM over columns given by pointers ------------------------------------ */

/* C(:, j) = A B(:, j), or C(:, j) += A B(:, j) if acc, for ncol columns given
 * by pointers (column j of B at bp[j], k values; of C at cp[j], m values), A
 * m x k column major. The level passes (M2M, L2L, the solves) use it on
 * pieces of KIFMM__GC_NC columns, so their columns need not be contiguous (no
 * gather into a level-sized workspace, no scatter back).
 *
 * With AVX2 + FMA it runs on the calling thread alone and the passes split
 * their pieces over their own threads: no threaded BLAS runs beside or inside
 * their parallel regions, where it would nest, or contend with the waiting
 * OpenMP workers (measured at 1M points, p = 6: M2M 0.17 s -> 0.09..0.11 s,
 * L2L 0.16 s -> 0.10..0.11 s). Blocked for the caches: k in equal steps of
 * at most KC, a tile of 2 vectors x 6 columns of C in registers (AVX-512:
 * 3 x 8, below). Without AVX2 the
 * columns are gathered into `work` ((k + m) x ncol) for one BLAS call, made
 * by the passes outside parallel regions with pieces of 512 columns (plain C
 * tiles measured 3 to 5 times slower than OpenBLAS there). */
#if defined(__AVX512F__)
/* AVX-512: a tile of 3 vectors (24 doubles, 48 floats) x 8 columns of C in
 * 24 of the 32 registers; masked loads and stores for the rows past m. One
 * core, 48 columns, double: 50-54 Gflop/s for the shapes of M2M, L2L and
 * the solves at p = 6 and 12 (152 x 1216, 1216 x 152, 866 x 728), against
 * 34-42 with the AVX2 tile and 46-56 for OpenBLAS's dgemm (SkylakeX) on
 * contiguous columns; k in blocks of 128 measured the same or slower. */
#define KIFMM__GC_FAST 1
#define KIFMM__GC_NC 48
#define KIFMM__GC_NR 8
#define KIFMM__GC_KC 256
KIFMM__FN __mmask8 kifmm__gc_maskd(int n)
{
    return (__mmask8)(n <= 0 ? 0u : n >= 8 ? 0xFFu : (1u << n) - 1u);
}
KIFMM__FN __mmask16 kifmm__gc_maskf(int n)
{
    return (__mmask16)(n <= 0 ? 0u : n >= 16 ? 0xFFFFu : (1u << n) - 1u);
}
#define KIFMM__GC_ROW5(j, FMA, BC)                                                              \
    x = BC(b[j][kk]);                                                                          \
    s##j##0 = FMA(a0, x, s##j##0);                                                             \
    s##j##1 = FMA(a1, x, s##j##1);                                                             \
    s##j##2 = FMA(a2, x, s##j##2);
#define KIFMM__GC_MICRO5(T, SFX, V, VL, M, MLOAD, MSTORE, FMA, BC, ZERO, ADD)                    \
    KIFMM__FN void kifmm__gc_micro##SFX(int mr, int nr, int kc, const T *a, int lda,            \
                                        const T *const *b, int acc, T *const *c)                \
    {                                                                                          \
        const M m0 = kifmm__gc_mask##SFX(mr), m1 = kifmm__gc_mask##SFX(mr - VL),               \
                m2 = kifmm__gc_mask##SFX(mr - 2 * VL);                                         \
        V s00 = ZERO, s01 = ZERO, s02 = ZERO, s10 = ZERO, s11 = ZERO, s12 = ZERO;              \
        V s20 = ZERO, s21 = ZERO, s22 = ZERO, s30 = ZERO, s31 = ZERO, s32 = ZERO;              \
        V s40 = ZERO, s41 = ZERO, s42 = ZERO, s50 = ZERO, s51 = ZERO, s52 = ZERO;              \
        V s60 = ZERO, s61 = ZERO, s62 = ZERO, s70 = ZERO, s71 = ZERO, s72 = ZERO;              \
        V acc_[8][3];                                                                          \
        M mh[3];                                                                               \
        int kk, j, h;                                                                          \
        for (kk = 0; kk < kc; kk++) {                                                          \
            const T *ak = a + (size_t)kk * lda;                                                \
            const V a0 = MLOAD(m0, ak), a1 = MLOAD(m1, ak + VL), a2 = MLOAD(m2, ak + 2 * VL);  \
            V x;                                                                               \
            KIFMM__GC_ROW5(0, FMA, BC) KIFMM__GC_ROW5(1, FMA, BC) KIFMM__GC_ROW5(2, FMA, BC)   \
            KIFMM__GC_ROW5(3, FMA, BC) KIFMM__GC_ROW5(4, FMA, BC) KIFMM__GC_ROW5(5, FMA, BC)   \
            KIFMM__GC_ROW5(6, FMA, BC) KIFMM__GC_ROW5(7, FMA, BC)                              \
        }                                                                                      \
        acc_[0][0] = s00; acc_[0][1] = s01; acc_[0][2] = s02;                                  \
        acc_[1][0] = s10; acc_[1][1] = s11; acc_[1][2] = s12;                                  \
        acc_[2][0] = s20; acc_[2][1] = s21; acc_[2][2] = s22;                                  \
        acc_[3][0] = s30; acc_[3][1] = s31; acc_[3][2] = s32;                                  \
        acc_[4][0] = s40; acc_[4][1] = s41; acc_[4][2] = s42;                                  \
        acc_[5][0] = s50; acc_[5][1] = s51; acc_[5][2] = s52;                                  \
        acc_[6][0] = s60; acc_[6][1] = s61; acc_[6][2] = s62;                                  \
        acc_[7][0] = s70; acc_[7][1] = s71; acc_[7][2] = s72;                                  \
        mh[0] = m0; mh[1] = m1; mh[2] = m2;                                                    \
        for (j = 0; j < nr; j++)                                                               \
            for (h = 0; h < 3 && h * VL < mr; h++) {                                           \
                T *cj = c[j] + h * VL;                                                         \
                V v = acc_[j][h];                                                              \
                if (acc) v = ADD(MLOAD(mh[h], cj), v);                                         \
                MSTORE(cj, mh[h], v);                                                          \
            }                                                                                  \
    }
KIFMM__GC_MICRO5(double, d, __m512d, 8, __mmask8, _mm512_maskz_loadu_pd, _mm512_mask_storeu_pd,
                 _mm512_fmadd_pd, _mm512_set1_pd, _mm512_setzero_pd(), _mm512_add_pd)
KIFMM__GC_MICRO5(float, f, __m512, 16, __mmask16, _mm512_maskz_loadu_ps, _mm512_mask_storeu_ps,
                 _mm512_fmadd_ps, _mm512_set1_ps, _mm512_setzero_ps(), _mm512_add_ps)
#undef KIFMM__GC_MICRO5
#undef KIFMM__GC_ROW5
#define KIFMM__GC_MR_D 24
#define KIFMM__GC_MR_F 48
#elif defined(__AVX2__) && defined(__FMA__)
#define KIFMM__GC_NR 6
#define KIFMM__GC_KC 256
#define KIFMM__GC_MR_D 8
#define KIFMM__GC_MR_F 16
#define KIFMM__GC_FAST 1
#define KIFMM__GC_NC 48
KIFMM__FN __m256i kifmm__gc_maskd(int n)
{
    return _mm256_cmpgt_epi64(_mm256_set1_epi64x(n), _mm256_setr_epi64x(0, 1, 2, 3));
}
KIFMM__FN __m256i kifmm__gc_maskf(int n)
{
    return _mm256_cmpgt_epi32(_mm256_set1_epi32(n), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
}
/* One tile: C[0:mr, 0:nr] (+)= A[0:mr, 0:kc] B[0:kc, 0:nr], mr <= 2 VL; the
 * columns past nr repeat the last one and are not stored. */
#define KIFMM__GC_MICRO(T, SFX, V, VL, LOADU, MLOAD, MSTORE, FMA, BC, ZERO, ADD)                 \
    KIFMM__FN void kifmm__gc_micro##SFX(int mr, int nr, int kc, const T *a, int lda,            \
                                        const T *const *b, int acc, T *const *c)                \
    {                                                                                          \
        const __m256i m0 = kifmm__gc_mask##SFX(mr), m1 = kifmm__gc_mask##SFX(mr - VL);         \
        V s00 = ZERO, s01 = ZERO, s10 = ZERO, s11 = ZERO, s20 = ZERO, s21 = ZERO;              \
        V s30 = ZERO, s31 = ZERO, s40 = ZERO, s41 = ZERO, s50 = ZERO, s51 = ZERO;              \
        V acc_[6][2];                                                                          \
        const T *b0 = b[0], *b1 = b[1], *b2 = b[2], *b3 = b[3], *b4 = b[4], *b5 = b[5];        \
        int kk, j, h;                                                                          \
        for (kk = 0; kk < kc; kk++) {                                                          \
            const T *ak = a + (size_t)kk * lda;                                                \
            const V a0 = mr == 2 * VL ? LOADU(ak) : MLOAD(ak, m0);                             \
            const V a1 = mr == 2 * VL ? LOADU(ak + VL) : MLOAD(ak + VL, m1);                   \
            V x;                                                                               \
            x = BC(b0 + kk); s00 = FMA(a0, x, s00); s01 = FMA(a1, x, s01);                     \
            x = BC(b1 + kk); s10 = FMA(a0, x, s10); s11 = FMA(a1, x, s11);                     \
            x = BC(b2 + kk); s20 = FMA(a0, x, s20); s21 = FMA(a1, x, s21);                     \
            x = BC(b3 + kk); s30 = FMA(a0, x, s30); s31 = FMA(a1, x, s31);                     \
            x = BC(b4 + kk); s40 = FMA(a0, x, s40); s41 = FMA(a1, x, s41);                     \
            x = BC(b5 + kk); s50 = FMA(a0, x, s50); s51 = FMA(a1, x, s51);                     \
        }                                                                                      \
        acc_[0][0] = s00; acc_[0][1] = s01; acc_[1][0] = s10; acc_[1][1] = s11;                \
        acc_[2][0] = s20; acc_[2][1] = s21; acc_[3][0] = s30; acc_[3][1] = s31;                \
        acc_[4][0] = s40; acc_[4][1] = s41; acc_[5][0] = s50; acc_[5][1] = s51;                \
        for (j = 0; j < nr; j++)                                                               \
            for (h = 0; h < 2; h++) {                                                          \
                T *cj = c[j] + h * VL;                                                         \
                const __m256i mh = h ? m1 : m0;                                                \
                V v = acc_[j][h];                                                              \
                if (acc) v = ADD(MLOAD(cj, mh), v);                                            \
                MSTORE(cj, mh, v);                                                             \
            }                                                                                  \
    }
KIFMM__GC_MICRO(double, d, __m256d, 4, _mm256_loadu_pd, _mm256_maskload_pd, _mm256_maskstore_pd,
                _mm256_fmadd_pd, _mm256_broadcast_sd, _mm256_setzero_pd(), _mm256_add_pd)
KIFMM__GC_MICRO(float, f, __m256, 8, _mm256_loadu_ps, _mm256_maskload_ps, _mm256_maskstore_ps,
                _mm256_fmadd_ps, _mm256_broadcast_ss, _mm256_setzero_ps(), _mm256_add_ps)
#endif
#ifndef KIFMM__GC_FAST
#define KIFMM__GC_FAST 0 /* no AVX2: the level passes call BLAS */
#endif

#if KIFMM__GC_FAST
#define KIFMM__GC_COLS(T, SFX, MR)                                                             \
    KIFMM__FN void kifmm__gemm_cols##SFX(int m, int k, const T *a, int lda, int ncol,          \
                                         const T *const *bp, T *const *cp, int acc, T *work)   \
    {                                                                                          \
        int k0, i0, j0, j, i;                                                                  \
        (void)work;                                                                            \
        if (k <= 0) {                                                                          \
            if (!acc)                                                                          \
                for (j = 0; j < ncol; j++)                                                     \
                    for (i = 0; i < m; i++) cp[j][i] = 0;                                      \
            return;                                                                            \
        }                                                                                      \
        /* k in equal blocks of at most KC (no short last block) */                           \
        const int nkb = (k + KIFMM__GC_KC - 1) / KIFMM__GC_KC, kb = (k + nkb - 1) / nkb;       \
        for (k0 = 0; k0 < k; k0 += kb) {                                                       \
            const int kc = k - k0 < kb ? k - k0 : kb;                                          \
            for (i0 = 0; i0 < m; i0 += MR)                                                     \
                for (j0 = 0; j0 < ncol; j0 += KIFMM__GC_NR) {                                  \
                    const T *b6[KIFMM__GC_NR];                                                 \
                    T *c6[KIFMM__GC_NR];                                                       \
                    const int nr = ncol - j0 < KIFMM__GC_NR ? ncol - j0 : KIFMM__GC_NR;        \
                    for (j = 0; j < KIFMM__GC_NR; j++) {                                       \
                        const int jj = j0 + (j < nr ? j : nr - 1);                             \
                        b6[j] = bp[jj] + k0;                                                   \
                        c6[j] = cp[jj] + i0;                                                   \
                    }                                                                          \
                    kifmm__gc_micro##SFX(m - i0 < MR ? m - i0 : MR, nr, kc,                    \
                                         a + i0 + (size_t)k0 * lda, lda, b6, acc || k0 > 0,    \
                                         c6);                                                  \
                }                                                                              \
        }                                                                                      \
    }
KIFMM__GC_COLS(double, d, KIFMM__GC_MR_D)
KIFMM__GC_COLS(float, f, KIFMM__GC_MR_F)
#else
#define KIFMM__GC_NR 6
#define KIFMM__GC_KC 256
#define KIFMM__GC_NC 512
#define KIFMM__GC_COLS(T, SFX, GEMM, ONE, ZERO)                                                \
    KIFMM__FN void kifmm__gemm_cols##SFX(int m, int k, const T *a, int lda, int ncol,          \
                                         const T *const *bp, T *const *cp, int acc, T *work)   \
    {                                                                                          \
        T *bw = work, *cw = work + (size_t)k * ncol;                                           \
        int i, j;                                                                              \
        if (m <= 0 || ncol <= 0) return;                                                       \
        for (j = 0; j < ncol; j++) memcpy(bw + (size_t)j * k, bp[j], (size_t)k * sizeof(T));   \
        GEMM(CblasColMajor, CblasNoTrans, CblasNoTrans, m, ncol, k, ONE, a, lda, bw,           \
             k > 0 ? k : 1, ZERO, cw, m);                                                      \
        for (j = 0; j < ncol; j++)                                                             \
            for (i = 0; i < m; i++)                                                            \
                cp[j][i] = acc ? cp[j][i] + cw[(size_t)j * m + i] : cw[(size_t)j * m + i];     \
    }
KIFMM__GC_COLS(double, d, cblas_dgemm, 1.0, 0.0)
KIFMM__GC_COLS(float, f, cblas_sgemm, 1.0f, 0.0f)
#endif

/* ---- surfaces ----------------------------------------------------------- */

/* Number of points on the surface of a p x p x p grid: 6 (p-1)^2 + 2. */
KIFMM__FN int kifmm__surf_count(int p) { return 6 * (p - 1) * (p - 1) + 2; }

/* The surface grid points on [-1, 1]^3, structure of arrays (x[n], y[n], z[n]). */
KIFMM__FN void kifmm__surf_unit(int p, double *s)
{
    int n = kifmm__surf_count(p), c = 0, i, j, k;
    for (i = 0; i < p; i++)
        for (j = 0; j < p; j++)
            for (k = 0; k < p; k++) {
                if (i != 0 && i != p - 1 && j != 0 && j != p - 1 && k != 0 && k != p - 1)
                    continue;
                s[c] = -1.0 + 2.0 * i / (p - 1);
                s[n + c] = -1.0 + 2.0 * j / (p - 1);
                s[2 * n + c] = -1.0 + 2.0 * k / (p - 1);
                c++;
            }
}

/* Unit surface scaled by `radius` and moved to `c`, into out (SoA, n points). */
KIFMM__FN void kifmm__surf_place(const double *unit, int n, const double *c, double radius,
                                 double *out)
{
    int i, d;
    for (d = 0; d < 3; d++)
        for (i = 0; i < n; i++) out[d * n + i] = c[d] + radius * unit[d * n + i];
}

/* Surface radii in units of the box half-width. */
#define KIFMM__ALPHA_INNER 1.05 /* upward equivalent, downward check */
/* upward check, downward equivalent: 2.95 with check surfaces of order p + 1,
 * 4.5 with order p (see kifmm__check_diff) */
#define KIFMM__ALPHA_OUTER_LSQ 2.95
#define KIFMM__ALPHA_OUTER_SQUARE 4.5

/* The check surfaces' order minus the equivalent surfaces' order p, for an
 * instance with the FFT M2L (fft) or not. With the FFT M2L up to order
 * KIFMM_SQUARE_MAX_ORDER: 0, with the outer surfaces at 4.5 box half-widths
 * (check and equivalent surfaces of the same order, square systems), whose
 * M2L runs on a (2p - 1)^3 grid instead of (2p + 1)^3: half the frequencies
 * at p = 4, 0.6 times at p = 6. Measured against order p + 1 at 2.95 on
 * uniform, sphere, clustered and separate point sets (p = 4, 6, 7; p = 2,
 * 3, 5 at radius 3.5), the errors are the same or smaller
 * (docs/algorithm.md). From order 8 on the square systems lose digits (at
 * radius 3.5), and Stokes (dense M2L) loses them at every order: 1 there.
 * A definition of KIFMM_CHECK_ORDER_DIFF before the include applies to every
 * order and kernel (the outer radius 4.5 when it is 0, 2.95 otherwise). */
KIFMM__FN int kifmm__check_diff(int p, int fft)
{
#ifdef KIFMM_CHECK_ORDER_DIFF
    (void)p;
    (void)fft;
    return KIFMM_CHECK_ORDER_DIFF;
#else
    return fft && p <= KIFMM_SQUARE_MAX_ORDER ? 0 : 1;
#endif
}

KIFMM__FN double kifmm__alpha_outer(int diff)
{
    return diff == 0 ? KIFMM__ALPHA_OUTER_SQUARE : KIFMM__ALPHA_OUTER_LSQ;
}

/* ---- Morton keys ------------------------------------------------------- */

/* A key at level l holds 3 l bits: bit 3i+2 is bit i of x, 3i+1 of y, 3i of z.
 * Children append three bits (octant c: x = c>>2 & 1, y = c>>1 & 1, z = c & 1). */
KIFMM__FN uint64_t kifmm__spread(uint64_t v)
{
    v &= 0x1fffff;
    v = (v | v << 32) & 0x1f00000000ffffULL;
    v = (v | v << 16) & 0x1f0000ff0000ffULL;
    v = (v | v << 8) & 0x100f00f00f00f00fULL;
    v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
    v = (v | v << 2) & 0x1249249249249249ULL;
    return v;
}

KIFMM__FN uint64_t kifmm__compact(uint64_t v)
{
    v &= 0x1249249249249249ULL;
    v = (v ^ (v >> 2)) & 0x10c30c30c30c30c3ULL;
    v = (v ^ (v >> 4)) & 0x100f00f00f00f00fULL;
    v = (v ^ (v >> 8)) & 0x1f0000ff0000ffULL;
    v = (v ^ (v >> 16)) & 0x1f00000000ffffULL;
    v = (v ^ (v >> 32)) & 0x1fffff;
    return v;
}

KIFMM__FN uint64_t kifmm__encode(int64_t x, int64_t y, int64_t z)
{
    return kifmm__spread((uint64_t)x) << 2 | kifmm__spread((uint64_t)y) << 1 |
           kifmm__spread((uint64_t)z);
}

KIFMM__FN void kifmm__decode(uint64_t key, int64_t *a)
{
    a[0] = (int64_t)kifmm__compact(key >> 2);
    a[1] = (int64_t)kifmm__compact(key >> 1);
    a[2] = (int64_t)kifmm__compact(key);
}

/* The calling thread's number in the innermost parallel region (0 outside
 * one and without OpenMP): the index of its part of per-thread buffers. */
KIFMM__FN int kifmm__thread_num(void)
{
#ifdef _OPENMP
    return omp_get_thread_num();
#else
    return 0;
#endif
}

/* The calling thread's contiguous share [lo, hi) of n items; returns its
 * thread number (0 outside a parallel region or without OpenMP). */
KIFMM__FN int kifmm__thread_chunk(int64_t n, int64_t *lo, int64_t *hi)
{
    int me = 0, np = 1;
#ifdef _OPENMP
    me = omp_get_thread_num();
    np = omp_get_num_threads();
#endif
    *lo = n * me / np;
    *hi = n * (me + 1) / np;
    return me;
}

/* Stable LSD radix sort of (key, idx) pairs by key, 8 bits a pass, in
 * parallel: each thread counts its own contiguous chunk, the counts are
 * summed digit by digit and thread by thread, and each thread scatters its
 * chunk in order, so the result does not depend on the thread count. Passes
 * in which every key has the same digit are skipped. */
KIFMM__FN int kifmm__radix_sort(uint64_t *key, int64_t *idx, int64_t n, int nth)
{
    uint64_t *k2 = (uint64_t *)kifmm__alloc((size_t)n, sizeof(uint64_t)), *ka = key, *kb = k2;
    int64_t *i2 = (int64_t *)kifmm__alloc((size_t)n, sizeof(int64_t)), *ia = idx, *ib = i2;
    int64_t *cnt = (int64_t *)kifmm__alloc((size_t)nth * 256, sizeof(int64_t));
    int shift;
    if (!k2 || !i2 || !cnt) {
        kifmm__free(k2);
        kifmm__free(i2);
        kifmm__free(cnt);
        return KIFMM_ERR_NOMEM;
    }
    /* each pass scatters from (ka, ia) into (kb, ib), then the two swap */
    for (shift = 0; shift < 64 && n > 0; shift += 8) {
        int64_t sum = 0, total0 = 0;
        int th, b, same;
        memset(cnt, 0, (size_t)nth * 256 * sizeof(int64_t));
        KIFMM__OMP(parallel num_threads(nth))
        {
            int64_t i, lo, hi, *c = cnt + (size_t)kifmm__thread_chunk(n, &lo, &hi) * 256;
            for (i = lo; i < hi; i++) c[(ka[i] >> shift) & 255]++;
        }
        for (th = 0; th < nth; th++) total0 += cnt[(size_t)th * 256 + ((ka[0] >> shift) & 255)];
        same = total0 == n;
        if (same) continue;
        for (b = 0; b < 256; b++)
            for (th = 0; th < nth; th++) {
                int64_t c = cnt[(size_t)th * 256 + b];
                cnt[(size_t)th * 256 + b] = sum;
                sum += c;
            }
        KIFMM__OMP(parallel num_threads(nth))
        {
            int64_t i, lo, hi, *c = cnt + (size_t)kifmm__thread_chunk(n, &lo, &hi) * 256;
            for (i = lo; i < hi; i++) {
                int64_t d = c[(ka[i] >> shift) & 255]++;
                kb[d] = ka[i];
                ib[d] = ia[i];
            }
        }
        {
            uint64_t *kt = ka;
            int64_t *it = ia;
            ka = kb; kb = kt;
            ia = ib; ib = it;
        }
    }
    if (ka != key) {
        KIFMM__OMP(parallel for schedule(static) num_threads(nth))
        for (int64_t i = 0; i < n; i++) {
            key[i] = ka[i];
            idx[i] = ia[i];
        }
    }
    kifmm__free(k2);
    kifmm__free(i2);
    kifmm__free(cnt);
    return KIFMM_SUCCESS;
}

/* First position in the sorted array a[0..n) holding a value >= v. */
KIFMM__FN int64_t kifmm__lower_bound(const uint64_t *a, int64_t n, uint64_t v)
{
    int64_t lo = 0, hi = n;
    while (lo < hi) {
        int64_t mid = lo + (hi - lo) / 2;
        if (a[mid] < v) lo = mid + 1;
        else hi = mid;
    }
    return lo;
}

/* ---- the adaptive octree ------------------------------------------------ */

#define KIFMM__D KIFMM_MAX_DEPTH /* level of the point keys */
#define KIFMM__NT 316            /* M2L transfer vectors: 7^3 - 3^3 */

/* Caps on the interaction lists of one box. With 2:1 balance the published
 * bounds are |U| <= 60, |V| <= 189, |W| <= 148, |X| <= 19. */
#define KIFMM__MAXU 128
#define KIFMM__MAXV 189
#define KIFMM__MAXW 208
#define KIFMM__MAXX 64

/* Boxes are stored level by level, sorted by key within a level; the eight
 * children of a box are consecutive, so the boxes of level l + 1 are exactly
 * the children of the internal boxes of level l, in order. Points are sorted
 * by key and each box owns a contiguous range of them. */
typedef struct kifmm__tree {
    int64_t ns, nt;
    double *src, *trg;       /* sorted points, structure of arrays (x | y | z) */
    int64_t *sperm, *tperm;  /* sorted position -> caller's index */
    int same;                /* targets are the sources: trg = src, tperm = sperm */
    double origin[3];        /* shift of each axis: the root's centre where that is
                                exact, else 0 (see kifmm__tree_build) */
    double lo[3], width;     /* root cube: lower corner relative to origin, and edge */
    int nlev;                /* levels 0 .. nlev - 1 */
    int32_t nbox;
    int32_t loff[KIFMM__D + 2];   /* boxes of level l: [loff[l], loff[l+1]) */
    int32_t ioff[KIFMM__D + 2];   /* internal boxes of level l: inner[ioff[l] .. ioff[l+1]) */
    uint64_t *key;
    int32_t *child;               /* first of the 8 children, or -1 for a leaf */
    int32_t *parent;              /* -1 for the root */
    int32_t *anchor;              /* integer coordinates of each box at its level (3 per box) */
    unsigned char *lev;           /* level of each box */
    int32_t *dsrc;                /* box whose local expansion serves this box, or -1 */
    int32_t *inner;               /* internal boxes, level by level */
    int64_t *s0, *s1, *t0, *t1;   /* point ranges of each box */
    int32_t *uo, *u, *vo, *v, *wo, *w, *xo, *x; /* lists, offsets per box (v: NULL
                                                   unless built with V entries) */
    uint16_t *vt;                 /* transfer vector index of each V entry (or NULL) */
    int32_t *m2lo, *m2l;          /* per level: boxes with targets and a V list */
    int32_t *leaves;              /* leaves with targets, in Morton order */
    int32_t nleaves;
    int32_t *dix;                 /* while the lists are built: box of each key of the
                                     levels with dixo[l] >= 0 (-1 where none), or NULL */
    int64_t dixo[KIFMM__D + 2];
} kifmm__tree;

KIFMM__FN void kifmm__tree_free(kifmm__tree *t)
{
    void *p[] = {t->src, t->same ? NULL : t->trg, t->sperm, t->same ? NULL : t->tperm,
                 t->key, t->child, t->parent, t->anchor, t->lev, t->dsrc, t->inner,
                 t->s0, t->s1, t->t0, t->t1, t->uo, t->u, t->vo, t->v, t->wo, t->w,
                 t->xo, t->x, t->vt, t->m2lo, t->m2l, t->leaves};
    size_t i;
    for (i = 0; i < sizeof p / sizeof p[0]; i++) kifmm__free(p[i]);
    memset(t, 0, sizeof *t);
}

KIFMM__FN int kifmm__level_of(const kifmm__tree *t, int32_t b)
{
    return t->lev[b];
}

/* Box index of (level, key), or -1. */
KIFMM__FN int32_t kifmm__find(const kifmm__tree *t, int l, uint64_t key)
{
    int32_t lo = t->loff[l], n = t->loff[l + 1] - lo;
    int64_t i;
    if (l >= t->nlev) return -1;
    if (t->dix && t->dixo[l] >= 0) return t->dix[t->dixo[l] + (int64_t)key];
    i = kifmm__lower_bound(t->key + lo, n, key);
    return (i < n && t->key[lo + i] == key) ? lo + (int32_t)i : -1;
}

/* The box of level <= l that contains the level-l position `key`, or -1. */
KIFMM__FN int32_t kifmm__find_cover(const kifmm__tree *t, int l, uint64_t key)
{
    int m;
    for (m = l < t->nlev - 1 ? l : t->nlev - 1; m >= 0; m--) {
        int32_t b = kifmm__find(t, m, key >> (3 * (l - m)));
        if (b >= 0) return b;
    }
    return -1;
}

/* Do boxes a and b touch or overlap (closed cubes)? */
KIFMM__FN int kifmm__adjacent(const kifmm__tree *t, int32_t a, int32_t b)
{
    int sa = KIFMM__D - t->lev[a], sb = KIFMM__D - t->lev[b], d;
    const int32_t *xa = t->anchor + 3 * (size_t)a, *xb = t->anchor + 3 * (size_t)b;
    for (d = 0; d < 3; d++) {
        int32_t a0 = xa[d] << sa, a1 = (xa[d] + 1) << sa;
        int32_t b0 = xb[d] << sb, b1 = (xb[d] + 1) << sb;
        if (a0 > b1 || b0 > a1) return 0;
    }
    return 1;
}

KIFMM__FN void kifmm__box_center(const kifmm__tree *t, int32_t b, double *c, double *half)
{
    int l = kifmm__level_of(t, b), d;
    const int32_t *a = t->anchor + 3 * (size_t)b;
    double w = t->width / (double)((int64_t)1 << l);
    for (d = 0; d < 3; d++) c[d] = t->lo[d] + ((double)a[d] + 0.5) * w;
    *half = 0.5 * w;
}

/* c - fc into d, the centre of a surface in a frame */
KIFMM__FN void kifmm__sub3(const double *c, const double *fc, double *d)
{
    d[0] = c[0] - fc[0];
    d[1] = c[1] - fc[1];
    d[2] = c[2] - fc[2];
}

/* Index of the transfer vector (dx, dy, dz), each in [-3, 3] and not all in
 * [-1, 1], among the 316 in lexicographic order. */
KIFMM__FN int kifmm__transfer_index(int dx, int dy, int dz)
{
    /* minus the near offsets (all |d| <= 1) lexicographically before it: 9 per
     * near x-slab before dx, 3 per near row before dy in the same slab, then the
     * near cells before dz in the same row */
#define KIFMM__CL3(v) ((v) < -1 ? 0 : (v) > 1 ? 3 : (v) + 1)
    int near = 9 * KIFMM__CL3(dx);
    if (dx >= -1 && dx <= 1) {
        near += 3 * KIFMM__CL3(dy);
        if (dy >= -1 && dy <= 1) near += KIFMM__CL3(dz);
    }
#undef KIFMM__CL3
    return (dx + 3) * 49 + (dy + 3) * 7 + (dz + 3) - near;
}

KIFMM__FN void kifmm__transfer_vector(int t, int *d)
{
    int c = 0, i, j, k;
    for (i = -3; i <= 3; i++)
        for (j = -3; j <= 3; j++)
            for (k = -3; k <= 3; k++) {
                if (i >= -1 && i <= 1 && j >= -1 && j <= 1 && k >= -1 && k <= 1) continue;
                if (c++ == t) { d[0] = i; d[1] = j; d[2] = k; return; }
            }
}

/* A growable array of keys. */
typedef struct { uint64_t *a; int64_t n, cap; } kifmm__keys;

KIFMM__FN int kifmm__keys_push(kifmm__keys *k, uint64_t v)
{
    if (k->n == k->cap) {
        int64_t cap = k->cap ? 2 * k->cap : 64;
        uint64_t *a = (uint64_t *)kifmm__alloc((size_t)cap, sizeof(uint64_t));
        if (!a) return KIFMM_ERR_NOMEM;
        if (k->n) memcpy(a, k->a, (size_t)k->n * sizeof *a);
        kifmm__free(k->a);
        k->a = a;
        k->cap = cap;
    }
    k->a[k->n++] = v;
    return KIFMM_SUCCESS;
}

KIFMM__FN int kifmm__cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* Sort and drop duplicates. */
KIFMM__FN void kifmm__keys_unique(kifmm__keys *k)
{
    int64_t i, m = 0;
    if (k->n < 2) return;
    qsort(k->a, (size_t)k->n, sizeof(uint64_t), kifmm__cmp_u64);
    for (i = 0; i < k->n; i++)
        if (m == 0 || k->a[i] != k->a[m - 1]) k->a[m++] = k->a[i];
    k->n = m;
}

/* Sort one point set by key: sorted SoA coordinates relative to t->origin,
 * permutation, keys. Every later step works in these coordinates: a cloud
 * far from the caller's origin keeps the digits of its own size (surface
 * points placed at c + r u would lose those of |c|). */
KIFMM__FN int kifmm__sort_points(const kifmm__tree *t, int64_t n, const double *xyz,
                                 double **out, int64_t **perm, uint64_t **keys, int nth)
{
    double scale = (double)((int64_t)1 << KIFMM__D) / t->width;
    int64_t maxi = ((int64_t)1 << KIFMM__D) - 1;
    int rc;
    *out = (double *)kifmm__alloc((size_t)(3 * n), sizeof(double));
    *perm = (int64_t *)kifmm__alloc((size_t)n, sizeof(int64_t));
    *keys = (uint64_t *)kifmm__alloc((size_t)n, sizeof(uint64_t));
    if (!*out || !*perm || !*keys) return KIFMM_ERR_NOMEM;
    KIFMM__OMP(parallel for schedule(static) num_threads(nth))
    for (int64_t i = 0; i < n; i++) {
        int64_t a[3];
        int d;
        for (d = 0; d < 3; d++) {
            double f = ((xyz[3 * i + d] - t->origin[d]) - t->lo[d]) * scale;
            a[d] = f <= 0.0 ? 0 : (f >= (double)maxi ? maxi : (int64_t)f);
        }
        (*keys)[i] = kifmm__encode(a[0], a[1], a[2]);
        (*perm)[i] = i;
    }
    rc = kifmm__radix_sort(*keys, *perm, n, nth);
    if (rc) return rc;
    KIFMM__OMP(parallel for schedule(static) num_threads(nth))
    for (int64_t i = 0; i < n; i++) {
        int d;
        for (d = 0; d < 3; d++) (*out)[d * n + i] = xyz[3 * (*perm)[i] + d] - t->origin[d];
    }
    return KIFMM_SUCCESS;
}

/* ---- interaction lists --------------------------------------------------- */

typedef struct {
    int32_t u[KIFMM__MAXU], v[KIFMM__MAXV], w[KIFMM__MAXW], x[KIFMM__MAXX];
    uint16_t vt[KIFMM__MAXV];
    int nu, nv, nw, nx, overflow;
} kifmm__lists;

KIFMM__FN void kifmm__add(int32_t *list, int *n, int cap, int32_t b, int *overflow, int dedupe)
{
    int i;
    if (dedupe)
        for (i = 0; i < *n; i++)
            if (list[i] == b) return;
    if (*n >= cap) { *overflow = 1; return; }
    list[(*n)++] = b;
}

/* U and W of leaf b from box c, a colleague of b or a descendant of one:
 * adjacent leaves go to U, adjacent internal boxes are opened, and boxes not
 * adjacent to b (whose parent is) go to W. */
KIFMM__FN void kifmm__collect_uw(const kifmm__tree *t, int32_t b, int32_t c, kifmm__lists *L)
{
    if (t->s1[c] == t->s0[c]) return;
    if (kifmm__adjacent(t, b, c)) {
        int o;
        if (t->child[c] < 0) {
            kifmm__add(L->u, &L->nu, KIFMM__MAXU, c, &L->overflow, 0);
            return;
        }
        for (o = 0; o < 8; o++) kifmm__collect_uw(t, b, t->child[c] + o, L);
    } else {
        kifmm__add(L->w, &L->nw, KIFMM__MAXW, c, &L->overflow, 0);
    }
}

/* All four lists of box b (U and W only when b is a leaf). Only boxes that
 * hold sources enter a list. */
KIFMM__FN void kifmm__box_lists(const kifmm__tree *t, int32_t b, kifmm__lists *L)
{
    int l = kifmm__level_of(t, b), dx, dy, dz;
    int64_t a[3] = {t->anchor[3 * (size_t)b], t->anchor[3 * (size_t)b + 1],
                    t->anchor[3 * (size_t)b + 2]};
    int64_t side = (int64_t)1 << l;
    L->nu = L->nv = L->nw = L->nx = L->overflow = 0;
    if (t->child[b] < 0) {
        for (dx = -1; dx <= 1; dx++)
            for (dy = -1; dy <= 1; dy++)
                for (dz = -1; dz <= 1; dz++) {
                    int64_t n[3] = {a[0] + dx, a[1] + dy, a[2] + dz};
                    uint64_t k;
                    int32_t c;
                    if (n[0] < 0 || n[1] < 0 || n[2] < 0 || n[0] >= side || n[1] >= side ||
                        n[2] >= side)
                        continue;
                    k = kifmm__encode(n[0], n[1], n[2]);
                    c = kifmm__find(t, l, k);
                    if (c >= 0) {
                        kifmm__collect_uw(t, b, c, L);
                    } else {
                        /* inside a coarser leaf, which touches b */
                        c = kifmm__find_cover(t, l, k);
                        if (c >= 0 && t->s1[c] > t->s0[c])
                            kifmm__add(L->u, &L->nu, KIFMM__MAXU, c, &L->overflow, 1);
                    }
                }
    }
    if (l >= 1) {
        int64_t p[3] = {a[0] >> 1, a[1] >> 1, a[2] >> 1}, pside = side >> 1;
        for (dx = -1; dx <= 1; dx++)
            for (dy = -1; dy <= 1; dy++)
                for (dz = -1; dz <= 1; dz++) {
                    int64_t n[3] = {p[0] + dx, p[1] + dy, p[2] + dz};
                    uint64_t k;
                    int32_t c;
                    if (n[0] < 0 || n[1] < 0 || n[2] < 0 || n[0] >= pside ||
                        n[1] >= pside || n[2] >= pside)
                        continue;
                    k = kifmm__encode(n[0], n[1], n[2]);
                    c = kifmm__find(t, l - 1, k);
                    if (c >= 0 && t->child[c] >= 0) {
                        int o;
                        for (o = 0; o < 8; o++) {
                            int32_t s = t->child[c] + o;
                            const int32_t *sa = t->anchor + 3 * (size_t)s;
                            if (t->s1[s] == t->s0[s] || kifmm__adjacent(t, b, s)) continue;
                            if (L->nv >= KIFMM__MAXV) { L->overflow = 1; continue; }
                            L->vt[L->nv] = (uint16_t)kifmm__transfer_index(
                                (int)(sa[0] - a[0]), (int)(sa[1] - a[1]), (int)(sa[2] - a[2]));
                            L->v[L->nv++] = s;
                        }
                    } else {
                        /* a leaf of the parent's level or coarser: X if apart from b */
                        if (c < 0) c = kifmm__find_cover(t, l - 1, k);
                        if (c >= 0 && t->s1[c] > t->s0[c] && !kifmm__adjacent(t, b, c))
                            kifmm__add(L->x, &L->nx, KIFMM__MAXX, c, &L->overflow, 1);
                    }
                }
    }
}

/* The lists of a range of boxes, appended in box order: U, V, W, X (and the
 * transfer vectors of V), growing by doubling. */
typedef struct {
    int32_t *a[4];
    uint16_t *vt;
    size_t n[4], cap[4];
    int fail;
} kifmm__lbuf;

KIFMM__FN void kifmm__lbuf_put(kifmm__lbuf *B, int j, const int32_t *src, int cnt,
                               const uint16_t *vt)
{
    if (B->fail || cnt == 0) return;
    if (B->n[j] + (size_t)cnt > B->cap[j]) {
        size_t cap = 2 * (B->n[j] + (size_t)cnt) + 256;
        int32_t *a = (int32_t *)kifmm__alloc(cap, sizeof(int32_t));
        uint16_t *v = j == 1 ? (uint16_t *)kifmm__alloc(cap, sizeof(uint16_t)) : NULL;
        if (!a || (j == 1 && !v)) {
            kifmm__free(a);
            kifmm__free(v);
            B->fail = 1;
            return;
        }
        if (B->n[j]) memcpy(a, B->a[j], B->n[j] * sizeof(int32_t));
        kifmm__free(B->a[j]);
        B->a[j] = a;
        if (j == 1) {
            if (B->n[j]) memcpy(v, B->vt, B->n[j] * sizeof(uint16_t));
            kifmm__free(B->vt);
            B->vt = v;
        }
        B->cap[j] = cap;
    }
    memcpy(B->a[j] + B->n[j], src, (size_t)cnt * sizeof(int32_t));
    if (j == 1) memcpy(B->vt + B->n[j], vt, (size_t)cnt * sizeof(uint16_t));
    B->n[j] += (size_t)cnt;
}

/* One pass over the boxes with targets, in chunks of consecutive boxes (many
 * more than threads, for balance), each collecting its lists in a buffer of
 * its own; then the offsets, and each chunk's lists copied into place. The
 * V entries themselves are kept only if `vlists` (the dense M2L reads them;
 * the FFT M2L works from the colleagues and needs only their counts). */
/* t->dsrc: a box refits a local expansion only where its own level brings
 * new far-field content: a V list, or an X list when the box holds at least
 * `xdirect` targets (boxes with fewer take their X sources directly).
 * Elsewhere it keeps its ancestor's, which is evaluated directly: a refit
 * adds an error of the fit order relative to the whole local field on the
 * box's own scale, which along a chain of boxes down to an isolated cluster
 * would swamp its gradient. */
KIFMM__FN void kifmm__tree_dsrc(kifmm__tree *t, int64_t xdirect)
{
    int32_t b;
    for (b = 0; b < t->nbox; b++) {
        int fresh = t->vo[b + 1] > t->vo[b] ||
                    (t->xo[b + 1] > t->xo[b] && t->t1[b] - t->t0[b] >= xdirect);
        if (b < t->loff[2 < t->nlev ? 2 : t->nlev]) t->dsrc[b] = -1;
        else if (fresh) t->dsrc[b] = b;
        else t->dsrc[b] = t->dsrc[t->parent[b]];
    }
}

KIFMM__FN int kifmm__tree_lists(kifmm__tree *t, int nth, int vlists)
{
    int32_t nb = t->nbox, b, nk = 16 * (nth > 0 ? nth : 1), k;
    int overflow = 0, fail = 0, l, j;
    int32_t *off[4];
    kifmm__lbuf *buf;
    if (nk > nb) nk = nb;
    t->uo = (int32_t *)kifmm__calloc((size_t)nb + 1, sizeof(int32_t));
    t->vo = (int32_t *)kifmm__calloc((size_t)nb + 1, sizeof(int32_t));
    t->wo = (int32_t *)kifmm__calloc((size_t)nb + 1, sizeof(int32_t));
    t->xo = (int32_t *)kifmm__calloc((size_t)nb + 1, sizeof(int32_t));
    buf = (kifmm__lbuf *)kifmm__calloc((size_t)nk, sizeof(kifmm__lbuf));
    if (!t->uo || !t->vo || !t->wo || !t->xo || !buf) {
        kifmm__free(buf);
        return KIFMM_ERR_NOMEM;
    }
    off[0] = t->uo; off[1] = t->vo; off[2] = t->wo; off[3] = t->xo;
    {
        /* a direct index (key -> box) for the levels where it costs at most
         * 8 entries per box (all of them in a uniform tree): a neighbour
         * found in one load instead of a binary search (tree 0.19-0.21 s ->
         * 0.15-0.17 s at 1M uniform points); the other levels, and all of
         * them if the index cannot be allocated, search */
        int64_t tot = 0;
        for (l = 0; l < t->nlev; l++) {
            const int64_t full = (int64_t)1 << (3 * l), nl = t->loff[l + 1] - t->loff[l];
            t->dixo[l] = l <= 10 && full <= 8 * nl + 4096 ? tot : -1;
            if (t->dixo[l] >= 0) tot += full;
        }
        t->dix = tot > 0 ? (int32_t *)kifmm__alloc((size_t)tot, sizeof(int32_t)) : NULL;
        if (t->dix) {
            KIFMM__OMP(parallel for schedule(static) num_threads(nth))
            for (int64_t e = 0; e < tot; e++) t->dix[e] = -1;
            for (l = 0; l < t->nlev; l++)
                if (t->dixo[l] >= 0)
                    for (b = t->loff[l]; b < t->loff[l + 1]; b++)
                        t->dix[t->dixo[l] + (int64_t)t->key[b]] = b;
        }
    }
    KIFMM__OMP(parallel for schedule(dynamic, 1) num_threads(nth) reduction(| : overflow))
    for (int32_t k = 0; k < nk; k++) {
        const int32_t b0 = (int32_t)((int64_t)nb * k / nk), b1 = (int32_t)((int64_t)nb * (k + 1) / nk);
        int32_t c;
        for (c = b0; c < b1; c++) {
            kifmm__lists L;
            if (t->t1[c] == t->t0[c]) continue;
            kifmm__box_lists(t, c, &L);
            overflow |= L.overflow;
            t->uo[c + 1] = L.nu; t->vo[c + 1] = L.nv;
            t->wo[c + 1] = L.nw; t->xo[c + 1] = L.nx;
            kifmm__lbuf_put(&buf[k], 0, L.u, L.nu, NULL);
            if (vlists) kifmm__lbuf_put(&buf[k], 1, L.v, L.nv, L.vt);
            kifmm__lbuf_put(&buf[k], 2, L.w, L.nw, NULL);
            kifmm__lbuf_put(&buf[k], 3, L.x, L.nx, NULL);
        }
    }
    kifmm__free(t->dix);
    t->dix = NULL;
    for (k = 0; k < nk; k++) fail |= buf[k].fail;
    if (!overflow && !fail) {
        for (j = 0; j < 4; j++)
            for (b = 0; b < nb; b++) off[j][b + 1] += off[j][b];
        t->u = (int32_t *)kifmm__alloc((size_t)t->uo[nb] + 1, sizeof(int32_t));
        if (vlists) {
            t->v = (int32_t *)kifmm__alloc((size_t)t->vo[nb] + 1, sizeof(int32_t));
            t->vt = (uint16_t *)kifmm__alloc((size_t)t->vo[nb] + 1, sizeof(uint16_t));
        }
        t->w = (int32_t *)kifmm__alloc((size_t)t->wo[nb] + 1, sizeof(int32_t));
        t->x = (int32_t *)kifmm__alloc((size_t)t->xo[nb] + 1, sizeof(int32_t));
        fail = !t->u || (vlists && (!t->v || !t->vt)) || !t->w || !t->x;
    }
    if (!overflow && !fail) {
        int32_t *dst[4];
        dst[0] = t->u; dst[1] = t->v; dst[2] = t->w; dst[3] = t->x;
        KIFMM__OMP(parallel for schedule(static) num_threads(nth))
        for (int32_t k = 0; k < nk; k++) {
            const int32_t b0 = (int32_t)((int64_t)nb * k / nk);
            int m;
            for (m = 0; m < 4; m++)
                if (buf[k].n[m]) memcpy(dst[m] + off[m][b0], buf[k].a[m], buf[k].n[m] * sizeof(int32_t));
            if (buf[k].n[1]) memcpy(t->vt + t->vo[b0], buf[k].vt, buf[k].n[1] * sizeof(uint16_t));
        }
    }
    for (k = 0; k < nk; k++) {
        for (j = 0; j < 4; j++) kifmm__free(buf[k].a[j]);
        kifmm__free(buf[k].vt);
    }
    kifmm__free(buf);
    if (overflow) return KIFMM_ERR_INTERNAL;
    if (fail) return KIFMM_ERR_NOMEM;
    /* per level, the boxes that receive M2L; and the leaves with targets */
    t->m2lo = (int32_t *)kifmm__calloc((size_t)t->nlev + 1, sizeof(int32_t));
    t->m2l = (int32_t *)kifmm__alloc((size_t)nb + 1, sizeof(int32_t));
    t->leaves = (int32_t *)kifmm__alloc((size_t)nb + 1, sizeof(int32_t));
    if (!t->m2lo || !t->m2l || !t->leaves) return KIFMM_ERR_NOMEM;
    for (l = 0; l < t->nlev; l++) {
        t->m2lo[l + 1] = t->m2lo[l];
        for (b = t->loff[l]; b < t->loff[l + 1]; b++)
            if (t->vo[b + 1] > t->vo[b]) t->m2l[t->m2lo[l + 1]++] = b;
    }
    /* leaves in Morton order (depth first, children in key order), which is
     * the order of their points */
    t->nleaves = 0;
    if (nb > 0) {
        int32_t stk[8 * (KIFMM__D + 2)], sp = 0;
        stk[sp++] = 0;
        while (sp > 0) {
            int o;
            b = stk[--sp];
            if (t->t1[b] == t->t0[b]) continue;
            if (t->child[b] < 0) t->leaves[t->nleaves++] = b;
            else
                for (o = 7; o >= 0; o--) stk[sp++] = t->child[b] + o;
        }
    }
    /* which box's local expansion serves each box (the handle redoes this
     * with its X threshold) */
    t->dsrc = (int32_t *)kifmm__alloc((size_t)nb, sizeof(int32_t));
    if (!t->dsrc) return KIFMM_ERR_NOMEM;
    kifmm__tree_dsrc(t, 0);
    return KIFMM_SUCCESS;
}

/* Build the tree: bounding cube, sorted points, top-down refinement while a
 * box holds more than `leaf` sources or targets, 2:1 balance, lists. */
KIFMM__FN int kifmm__tree_build(kifmm__tree *t, int64_t ns, const double *src, int64_t nt,
                                const double *trg, int leaf, int maxdepth, int nth, int vlists)
{
    double lo[3], hi[3], half = 0.0;
    uint64_t *skey = NULL, *tkey = NULL;
    kifmm__keys in[KIFMM__D + 1];
    int d, l, rc = KIFMM_SUCCESS, deepest = 0;
    int32_t nb, b;
    size_t nbz;
    memset(in, 0, sizeof in);
    memset(t, 0, sizeof *t);
    t->ns = ns;
    t->nt = nt;
    for (d = 0; d < 3; d++) {
        double mn = HUGE_VAL, mx = -HUGE_VAL;
        KIFMM__OMP(parallel for schedule(static) num_threads(nth) reduction(min : mn) reduction(max : mx))
        for (int64_t i = 0; i < ns + nt; i++) {
            double v = i < ns ? src[3 * i + d] : trg[3 * (i - ns) + d];
            mn = v < mn ? v : mn;
            mx = v > mx ? v : mx;
        }
        lo[d] = mn;
        hi[d] = mx;
    }
    for (d = 0; d < 3; d++)
        if (0.5 * (hi[d] - lo[d]) > half) half = 0.5 * (hi[d] - lo[d]);
    if (!(half > 0.0)) half = 0.5;
    half *= 1.0 + 1e-10;
    for (d = 0; d < 3; d++) {
        /* shift an axis only where the shift is exact: with |centre| >= the
         * root's width, every coordinate lies within a factor 2 of the
         * centre, so x - centre is exact (Sterbenz). Elsewhere the points
         * keep their own coordinates, whose differences are exact for
         * nearby points, and the cloud is within a width of the origin
         * anyway, so surfaces lose at most a bit or two there. */
        const double c = 0.5 * (lo[d] + hi[d]);
        t->origin[d] = fabs(c) >= 2.0 * half ? c : 0.0;
        t->lo[d] = (c - t->origin[d]) - half;
    }
    t->width = 2.0 * half;

    rc = kifmm__sort_points(t, ns, src, &t->src, &t->sperm, &skey, nth);
    if (!rc && trg == src && nt == ns) {
        /* targets = sources: the sorted sources serve as both */
        t->same = 1;
        t->trg = t->src;
        t->tperm = t->sperm;
        tkey = skey;
    } else if (!rc) {
        rc = kifmm__sort_points(t, nt, trg, &t->trg, &t->tperm, &tkey, nth);
    }
    if (rc) goto done;

    /* top down: in[l] holds the keys of the boxes of level l that split */
    {
        kifmm__keys cur = {0, 0, 0}, next = {0, 0, 0};
        unsigned char *split = NULL;
        if ((rc = kifmm__keys_push(&cur, 0))) goto topdone;
        for (l = 0; l < maxdepth && cur.n > 0; l++) {
            int sh = 3 * (KIFMM__D - l);
            int64_t j;
            kifmm__free(split);
            split = (unsigned char *)kifmm__alloc((size_t)cur.n, 1);
            if (!split) { rc = KIFMM_ERR_NOMEM; goto topdone; }
            KIFMM__OMP(parallel for schedule(dynamic, 256) num_threads(nth))
            for (int64_t j = 0; j < cur.n; j++) {
                uint64_t k0 = cur.a[j] << sh, k1 = (cur.a[j] + 1) << sh;
                int64_t fs = kifmm__lower_bound(skey, ns, k0), ft = kifmm__lower_bound(tkey, nt, k0);
                int64_t cs = kifmm__lower_bound(skey, ns, k1) - fs;
                int64_t ct = kifmm__lower_bound(tkey, nt, k1) - ft;
                split[j] = 1;
                if (cs <= leaf && ct <= leaf) split[j] = 0;
                /* points that share one finest key never separate: keep a leaf */
                else if ((cs == 0 || skey[fs] == skey[fs + cs - 1]) &&
                         (ct == 0 || tkey[ft] == tkey[ft + ct - 1]) &&
                         (cs == 0 || ct == 0 || skey[fs] == tkey[ft]))
                    split[j] = 0;
            }
            next.n = 0;
            for (j = 0; j < cur.n; j++) {
                int o;
                if (!split[j]) continue;
                if ((rc = kifmm__keys_push(&in[l], cur.a[j]))) goto topdone;
                for (o = 0; o < 8; o++)
                    if ((rc = kifmm__keys_push(&next, cur.a[j] << 3 | (uint64_t)o))) goto topdone;
            }
            { kifmm__keys tmp = cur; cur = next; next = tmp; }
        }
    topdone:
        kifmm__free(split);
        kifmm__free(cur.a);
        kifmm__free(next.a);
        if (rc) goto done;
    }
    for (l = 0; l <= KIFMM__D; l++)
        if (in[l].n > 0) deepest = l + 1;

    /* 2:1 balance, finest level first: every neighbour of a box of level l
     * must lie in a box of level l - 1, i.e. its grandparent must split.
     * Missing grandparents are marked in parallel (one flag per box of level
     * l and neighbour), then appended in order. */
    for (l = deepest; l >= 2; l--) {
        int64_t j, side = (int64_t)1 << l, n0 = in[l - 2].n, nb8 = 8 * in[l - 1].n;
        uint64_t *need = (uint64_t *)kifmm__alloc((size_t)nb8 * 27 + 1, sizeof(uint64_t));
        if (!need) { rc = KIFMM_ERR_NOMEM; goto done; }
        KIFMM__OMP(parallel for schedule(static) num_threads(nth))
        for (int64_t j = 0; j < nb8; j++) {
            int64_t a[3];
            int dx, dy, dz, m = 0;
            kifmm__decode(in[l - 1].a[j >> 3] << 3 | (uint64_t)(j & 7), a);
            for (dx = -1; dx <= 1; dx++)
                for (dy = -1; dy <= 1; dy++)
                    for (dz = -1; dz <= 1; dz++) {
                        int64_t x = a[0] + dx, y = a[1] + dy, z = a[2] + dz, pos;
                        uint64_t g = UINT64_MAX;
                        if (x >= 0 && y >= 0 && z >= 0 && x < side && y < side && z < side) {
                            g = kifmm__encode(x, y, z) >> 6;
                            pos = kifmm__lower_bound(in[l - 2].a, n0, g);
                            if (pos < n0 && in[l - 2].a[pos] == g) g = UINT64_MAX;
                        }
                        need[27 * j + m++] = g;
                    }
        }
        for (j = 0; j < 27 * nb8; j++)
            if (need[j] != UINT64_MAX && (rc = kifmm__keys_push(&in[l - 2], need[j]))) break;
        kifmm__free(need);
        if (rc) goto done;
        if (in[l - 2].n > n0) kifmm__keys_unique(&in[l - 2]);
    }

    /* lay the boxes out level by level */
    t->nlev = deepest + 1;
    {
        int64_t total = 1;
        for (l = 0; l < deepest; l++) total += 8 * in[l].n;
        if (total > INT32_MAX / 8) { rc = KIFMM_ERR_NOMEM; goto done; }
        nb = (int32_t)total;
        nbz = (size_t)total;
    }
    t->nbox = nb;
    t->key = (uint64_t *)kifmm__alloc(nbz, sizeof(uint64_t));
    t->child = (int32_t *)kifmm__alloc(nbz, sizeof(int32_t));
    t->inner = (int32_t *)kifmm__alloc(nbz, sizeof(int32_t));
    t->parent = (int32_t *)kifmm__alloc(nbz, sizeof(int32_t));
    t->anchor = (int32_t *)kifmm__alloc(3 * nbz, sizeof(int32_t));
    t->lev = (unsigned char *)kifmm__alloc(nbz, 1);
    t->s0 = (int64_t *)kifmm__alloc(nbz, sizeof(int64_t));
    t->s1 = (int64_t *)kifmm__alloc(nbz, sizeof(int64_t));
    t->t0 = (int64_t *)kifmm__alloc(nbz, sizeof(int64_t));
    t->t1 = (int64_t *)kifmm__alloc(nbz, sizeof(int64_t));
    if (!t->key || !t->child || !t->inner || !t->parent || !t->anchor || !t->lev || !t->s0 || !t->s1 || !t->t0 || !t->t1) {
        rc = KIFMM_ERR_NOMEM;
        goto done;
    }
    t->loff[0] = 0;
    t->loff[1] = 1;
    t->key[0] = 0;
    t->parent[0] = -1;
    for (l = 1; l < t->nlev; l++) {
        int32_t c = t->loff[l];
        int64_t j;
        for (j = 0; j < in[l - 1].n; j++) {
            int o;
            for (o = 0; o < 8; o++) t->key[c++] = in[l - 1].a[j] << 3 | (uint64_t)o;
        }
        t->loff[l + 1] = c;
    }
    for (l = t->nlev + 1; l <= KIFMM__D + 1; l++) t->loff[l] = t->loff[t->nlev];
    t->ioff[0] = 0;
    for (l = 0; l < t->nlev; l++) {
        int64_t j = 0;
        t->ioff[l + 1] = t->ioff[l];
        for (b = t->loff[l]; b < t->loff[l + 1]; b++) {
            while (j < in[l].n && in[l].a[j] < t->key[b]) j++;
            if (j < in[l].n && in[l].a[j] == t->key[b]) {
                int o;
                t->child[b] = t->loff[l + 1] + (int32_t)(8 * j);
                for (o = 0; o < 8; o++) t->parent[t->child[b] + o] = b;
                t->inner[t->ioff[l + 1]++] = b;
            } else {
                t->child[b] = -1;
            }
        }
    }
    for (l = t->nlev + 1; l <= KIFMM__D + 1; l++) t->ioff[l] = t->ioff[t->nlev];
    for (l = 0; l < t->nlev; l++) {
        int sh = 3 * (KIFMM__D - l);
        KIFMM__OMP(parallel for schedule(static) num_threads(nth))
        for (int32_t b = t->loff[l]; b < t->loff[l + 1]; b++) {
            int64_t a[3];
            kifmm__decode(t->key[b], a);
            t->anchor[3 * (size_t)b] = (int32_t)a[0];
            t->anchor[3 * (size_t)b + 1] = (int32_t)a[1];
            t->anchor[3 * (size_t)b + 2] = (int32_t)a[2];
            t->lev[b] = (unsigned char)l;
            uint64_t k0 = t->key[b] << sh, k1 = (t->key[b] + 1) << sh;
            t->s0[b] = kifmm__lower_bound(skey, ns, k0);
            t->s1[b] = kifmm__lower_bound(skey, ns, k1);
            t->t0[b] = kifmm__lower_bound(tkey, nt, k0);
            t->t1[b] = kifmm__lower_bound(tkey, nt, k1);
        }
    }
    rc = kifmm__tree_lists(t, nth, vlists);
done:
    for (l = 0; l <= KIFMM__D; l++) kifmm__free(in[l].a);
    kifmm__free(skey);
    if (tkey != skey) kifmm__free(tkey);
    return rc;
}

/* ---- operators (built in double for every instance) --------------------- */

/* Operators of one level, built with the target box's half-width. Check
 * vectors have nc entries, equivalent densities ne (points x components). */
typedef struct kifmm__ops {
    double sigma;           /* scale of the check potentials (see build_c2e) */
    int ku, kd;             /* ranks kept by the two pseudo-inverses */
    double *ut_up, *vs_up;  /* pinv K(up check <- up equiv) = vs_up ut_up */
    double *ut_dn, *vs_dn;  /* pinv K(down check <- down equiv) */
    double *m2m;            /* nc x 8 ne: children's equiv -> parent's check */
    double *l2l;            /* 8 nc x ne: parent's equiv -> children's check */
    double *m2l;            /* kd x 316 ne: source equiv -> ut_dn (target check) */
    double *conv;           /* FFT M2L, nc x ne: upward equivalent density -> a density
                               on the check surface's lattice (1.05 r) with the same
                               field outside the upward check surface */
    double *khat;           /* FFT M2L: the 316 kernel spectra on that lattice,
                               frequency-major: khat[(f 316 + t) 2] (re, im) */
} kifmm__ops;

KIFMM__FN void kifmm__ops_free(kifmm__ops *o)
{
    kifmm__free(o->ut_up); kifmm__free(o->vs_up);
    kifmm__free(o->ut_dn); kifmm__free(o->vs_dn);
    kifmm__free(o->m2m); kifmm__free(o->l2l); kifmm__free(o->m2l);
    kifmm__free(o->conv); kifmm__free(o->khat);
    memset(o, 0, sizeof *o);
}

/* The most sources or targets in one leaf. */
KIFMM__FN int64_t kifmm__max_leaf(const kifmm__tree *t)
{
    int64_t m = 0;
    int32_t b;
    for (b = 0; b < t->nbox; b++) {
        if (t->child[b] >= 0) continue;
        if (t->s1[b] - t->s0[b] > m) m = t->s1[b] - t->s0[b];
        if (t->t1[b] - t->t0[b] > m) m = t->t1[b] - t->t0[b];
    }
    return m;
}

KIFMM__FN int kifmm__max_level_boxes(const kifmm__tree *t)
{
    int l, m = 1;
    for (l = 0; l < t->nlev; l++)
        if (t->loff[l + 1] - t->loff[l] > m) m = t->loff[l + 1] - t->loff[l];
    return m;
}

/* The boxes the equivalent-density solves visit: a[loff[l] ..] lists, by
 * index within level l, its boxes with sources (the upward solve: the others'
 * check potentials are zero), a[nbox + loff[l] ..] those with targets (the
 * downward solve: no target reads the others' local expansions), and
 * a[2 nbox + 2 l] and a[2 nbox + 2 l + 1] count them. On surfaces and in
 * clusters about half the boxes are empty. NULL if out of memory. */
KIFMM__FN int32_t *kifmm__active(const kifmm__tree *t)
{
    int32_t *a = (int32_t *)kifmm__alloc(2 * (size_t)t->nbox + 2 * (size_t)t->nlev,
                                         sizeof(int32_t));
    int l;
    if (!a) return NULL;
    for (l = 0; l < t->nlev; l++) {
        int32_t b, nu = 0, nd = 0, o = t->loff[l];
        for (b = o; b < t->loff[l + 1]; b++) {
            if (t->s1[b] > t->s0[b]) a[o + nu++] = b - o;
            if (t->t1[b] > t->t0[b]) a[t->nbox + o + nd++] = b - o;
        }
        a[2 * t->nbox + 2 * l] = nu;
        a[2 * t->nbox + 2 * l + 1] = nd;
    }
    return a;
}

/* ---- FFT M2L (kernels with one density component) ----------------------- */

/* The downward check surface (order q = p + kifmm__check_diff(p, 1), radius
 * 1.05 r) is the boundary of a q^3 lattice of spacing h = 2.1 r / (q - 1).
 * Each source multipole is first moved to a density on the same lattice
 * around its own box (conv, fitted on the upward check surface, so its field
 * outside is the multipole's); then K_t(i, j) = G(h (i - j) - 2 r t) depends
 * only on the lattice offset i - j, and the M2L of one box pair is a
 * circular convolution on an n^3 grid, n = 2q - 1: a pointwise product of
 * spectra, whose inverse gives the potentials on the check surface itself,
 * exactly the values the dense M2L computes. Spectra are real-to-complex (kz
 * in 0 .. n/2); the transforms are separable small DFTs pruned to the lattice
 * (n <= 25 here, where a radix FFT would gain little). Frequencies are
 * grouped in chunks of F; the products run per target parent over its
 * neighbouring source parents, one 8 x 8 complex block (child of source
 * parent -> child of target parent) per frequency, zero for adjacent child
 * pairs (those are not in the V list). Below, p is the lattice order q. */
#define KIFMM__FFT_F 4 /* frequencies per chunk (the AVX2 product kernels assume 4) */
#define KIFMM__FFT_KB_MB 24 /* the products' blocks are kept if they fit in this */
KIFMM__STATIC_ASSERT(KIFMM__FFT_F == 4, fft_product_kernels_take_4_frequencies_per_chunk);

typedef struct kifmm__fft {
    int p, n, nh, nf, nchunk, nfp, ne; /* nfp = nchunk * F */
    int single;                        /* spectra and products in float */
    int *ijk;                          /* lattice indices of the surface points */
    double *wr, *wi;                   /* exp(-2 pi i a b / n), [a * n + b] */
    double *wz;                        /* weights of the inverse real transform, / n^3 */
} kifmm__fft;

KIFMM__FN void kifmm__fft_free(kifmm__fft *pl)
{
    kifmm__free(pl->ijk); kifmm__free(pl->wr); kifmm__free(pl->wi); kifmm__free(pl->wz);
    memset(pl, 0, sizeof *pl);
}

KIFMM__FN int kifmm__fft_init(kifmm__fft *pl, int p)
{
    int n = 2 * p - 1, nh = n / 2 + 1, a, b, c = 0, i, j, k;
    memset(pl, 0, sizeof *pl);
    pl->p = p; pl->n = n; pl->nh = nh; pl->nf = n * n * nh;
    pl->nchunk = (pl->nf + KIFMM__FFT_F - 1) / KIFMM__FFT_F;
    pl->nfp = pl->nchunk * KIFMM__FFT_F;
    pl->ne = kifmm__surf_count(p);
    pl->ijk = (int *)kifmm__alloc((size_t)3 * pl->ne, sizeof(int));
    pl->wr = (double *)kifmm__alloc((size_t)n * n, sizeof(double));
    pl->wi = (double *)kifmm__alloc((size_t)n * n, sizeof(double));
    pl->wz = (double *)kifmm__alloc((size_t)nh, sizeof(double));
    if (!pl->ijk || !pl->wr || !pl->wi || !pl->wz) return KIFMM_ERR_NOMEM;
    /* the order of kifmm__surf_unit */
    for (i = 0; i < p; i++)
        for (j = 0; j < p; j++)
            for (k = 0; k < p; k++) {
                if (i != 0 && i != p - 1 && j != 0 && j != p - 1 && k != 0 && k != p - 1)
                    continue;
                pl->ijk[3 * c] = i; pl->ijk[3 * c + 1] = j; pl->ijk[3 * c + 2] = k;
                c++;
            }
    for (a = 0; a < n; a++)
        for (b = 0; b < n; b++) {
            double ang = -6.283185307179586476925286766559 * (double)((a * b) % n) / n;
            pl->wr[a * n + b] = cos(ang);
            pl->wi[a * n + b] = sin(ang);
        }
    for (a = 0; a < nh; a++) pl->wz[a] = (a == 0 ? 1.0 : 2.0) / ((double)n * n * n);
    return KIFMM_SUCCESS;
}

/* Doubles of work space for kifmm__fft_grid. */
KIFMM__FN size_t kifmm__fft_work(const kifmm__fft *pl)
{
    return (size_t)4 * pl->n * pl->n * pl->nh + (size_t)pl->n * pl->n * pl->n;
}


/* Spectrum of a real n^3 grid g ([(i n + j) n + k]) into khat (frequency f
 * at 2 f, re and im), full transform. */
KIFMM__FN void kifmm__fft_grid(const kifmm__fft *pl, const double *g, double *khat, double *work)
{
    int n = pl->n, nh = pl->nh, i, j, k, kx, ky, kz;
    double *s1r = work, *s1i = s1r + n * n * nh, *s2r = s1i + n * n * nh, *s2i = s2r + n * n * nh;
    for (i = 0; i < n * n; i++)
        for (kz = 0; kz < nh; kz++) {
            double sr = 0, si = 0;
            for (k = 0; k < n; k++) {
                sr += g[i * n + k] * pl->wr[kz * n + k];
                si += g[i * n + k] * pl->wi[kz * n + k];
            }
            s1r[i * nh + kz] = sr; s1i[i * nh + kz] = si;
        }
    for (i = 0; i < n; i++)
        for (ky = 0; ky < n; ky++)
            for (kz = 0; kz < nh; kz++) {
                double sr = 0, si = 0;
                for (j = 0; j < n; j++) {
                    double xr = s1r[(i * n + j) * nh + kz], xi = s1i[(i * n + j) * nh + kz];
                    double w0 = pl->wr[ky * n + j], w1 = pl->wi[ky * n + j];
                    sr += xr * w0 - xi * w1;
                    si += xr * w1 + xi * w0;
                }
                s2r[(i * n + ky) * nh + kz] = sr; s2i[(i * n + ky) * nh + kz] = si;
            }
    for (kx = 0; kx < n; kx++)
        for (ky = 0; ky < n; ky++)
            for (kz = 0; kz < nh; kz++) {
                double sr = 0, si = 0;
                size_t f = ((size_t)kx * n + ky) * nh + kz;
                for (i = 0; i < n; i++) {
                    double xr = s2r[(i * n + ky) * nh + kz], xi = s2i[(i * n + ky) * nh + kz];
                    double w0 = pl->wr[kx * n + i], w1 = pl->wi[kx * n + i];
                    sr += xr * w0 - xi * w1;
                    si += xr * w1 + xi * w0;
                }
                khat[2 * f] = sr; khat[2 * f + 1] = si;
            }
}

/* Lanes of the batched transforms: the 8 children of one parent at once. */
#define KIFMM__FFT_L 8

/* Doubles of work space for one batched transform (forward or inverse). */
KIFMM__FN size_t kifmm__fft_work8(const kifmm__fft *pl)
{
    return (size_t)KIFMM__FFT_L * 2 * pl->nh * ((size_t)pl->n * pl->n + (size_t)pl->p * pl->n +
                                                 (size_t)pl->p * pl->p);
}

/* The batched transforms, for work arrays of type T (suffix SFX): double,
 * and float where the spectra are float (the products' precision).
 *
 * kifmm__caxpy: d += x w over n complex values in split form (dr, di +=
 * (xr, xi) (w0 + i w1)), the one step of every separable DFT stage.
 *
 * kifmm__fft_forward8: spectra of 8 surface densities at once, m[s 8 + v]
 * (lane v = child v), into out: frequency f of lane v goes to out[(f / F)
 * cstride + (f % F) 16 + v] (re) and 8 further (im), the layout of the
 * products. Pruned: only the p^3 lattice is nonzero. Every stage is a loop
 * over the 8 lanes with the same twiddle, which compilers vectorise.
 *
 * kifmm__fft_inverse8: 8 half spectra addressed as above -> the values at
 * the ne lattice surface points, chk[s 8 + v]. */
#define KIFMM__FFT_XFORMS(T, SFX)                                                              \
    KIFMM__FN void kifmm__caxpy##SFX(int n, T w0, T w1, const T *KIFMM__RESTRICT xr,           \
                                     const T *KIFMM__RESTRICT xi, T *KIFMM__RESTRICT dr,       \
                                     T *KIFMM__RESTRICT di)                                    \
    {                                                                                          \
        int q, v;                                                                              \
        for (q = 0; q < n; q += KIFMM__FFT_L) /* n is a multiple of the 8 lanes */            \
            for (v = q; v < q + KIFMM__FFT_L; v++) {                                           \
                dr[v] += xr[v] * w0 - xi[v] * w1;                                              \
                di[v] += xr[v] * w1 + xi[v] * w0;                                              \
            }                                                                                  \
    }                                                                                          \
    /* d = sum_j x_j (wr + i sg wi)[j ws] over nin inputs x_j = x + j xs (len values) */      \
    KIFMM__FN void kifmm__dft_sum##SFX(int len, int nin, const double *wr, const double *wi,   \
                                       int ws, double sg, const T *xr, const T *xi, size_t xs, \
                                       T *dr, T *di)                                           \
    {                                                                                          \
        int j;                                                                                 \
        memset(dr, 0, sizeof(T) * (size_t)len);                                                \
        memset(di, 0, sizeof(T) * (size_t)len);                                                \
        for (j = 0; j < nin; j++)                                                              \
            kifmm__caxpy##SFX(len, (T)wr[j * ws], (T)(sg * wi[j * ws]), xr + j * xs,           \
                              xi + j * xs, dr, di);                                            \
    }                                                                                          \
    KIFMM__FN void kifmm__fft_forward8##SFX(const kifmm__fft *pl, const double *m, void *out,  \
                                            size_t cstride, T *work)                           \
    {                                                                                          \
        const int L = KIFMM__FFT_L, p = pl->p, n = pl->n, nh = pl->nh;                         \
        int s, i, kx, ky, kz, q, v;                                                            \
        T *s1r = work, *s1i = s1r + L * p * p * nh, *s2r = s1i + L * p * p * nh;               \
        T *s2i = s2r + L * p * n * nh, *tr = s2i + L * p * n * nh, *ti = tr + L * n * nh;      \
        memset(s1r, 0, sizeof(T) * 2 * L * p * p * nh);                                        \
        for (s = 0; s < pl->ne; s++) {                                                         \
            int a = pl->ijk[3 * s], b = pl->ijk[3 * s + 1], c = pl->ijk[3 * s + 2];            \
            T mv[KIFMM__FFT_L], *r = s1r + L * (a * p + b) * nh, *im = s1i + L * (a * p + b) * nh; \
            for (v = 0; v < L; v++) mv[v] = (T)m[L * s + v];                                   \
            for (kz = 0; kz < nh; kz++) {                                                      \
                const T w0 = (T)pl->wr[kz * n + c], w1 = (T)pl->wi[kz * n + c];                \
                for (v = 0; v < L; v++) {                                                      \
                    r[L * kz + v] += mv[v] * w0;                                               \
                    im[L * kz + v] += mv[v] * w1;                                              \
                }                                                                              \
            }                                                                                  \
        }                                                                                      \
        for (i = 0; i < p; i++)                                                                \
            for (ky = 0; ky < n; ky++)                                                         \
                kifmm__dft_sum##SFX(L * nh, p, pl->wr + ky * n, pl->wi + ky * n, 1, 1.0,       \
                                    s1r + L * i * p * nh, s1i + L * i * p * nh, (size_t)L * nh, \
                                    s2r + L * (i * n + ky) * nh, s2i + L * (i * n + ky) * nh); \
        for (kx = 0; kx < n; kx++) {                                                           \
            const int f0 = kx * n * nh;                                                        \
            kifmm__dft_sum##SFX(L * n * nh, p, pl->wr + kx * n, pl->wi + kx * n, 1, 1.0, s2r,  \
                                s2i, (size_t)L * n * nh, tr, ti);                              \
            for (q = 0; q < n * nh; q++) {                                                     \
                const int f = f0 + q;                                                          \
                const size_t a =                                                               \
                    (size_t)(f / KIFMM__FFT_F) * cstride + (size_t)(f % KIFMM__FFT_F) * 16;    \
                if (pl->single) {                                                              \
                    float *o = (float *)out + a;                                               \
                    for (v = 0; v < L; v++) {                                                  \
                        o[v] = (float)tr[L * q + v];                                           \
                        o[8 + v] = (float)ti[L * q + v];                                       \
                    }                                                                          \
                } else {                                                                       \
                    double *o = (double *)out + a;                                             \
                    for (v = 0; v < L; v++) {                                                  \
                        o[v] = (double)tr[L * q + v];                                          \
                        o[8 + v] = (double)ti[L * q + v];                                      \
                    }                                                                          \
                }                                                                              \
            }                                                                                  \
        }                                                                                      \
    }                                                                                          \
    KIFMM__FN void kifmm__fft_inverse8##SFX(const kifmm__fft *pl, const void *in, size_t cstride, \
                                            double *chk, T *work)                              \
    {                                                                                          \
        const int L = KIFMM__FFT_L, p = pl->p, n = pl->n, nh = pl->nh;                         \
        int i, j, k, kz, q, s, v;                                                              \
        T *yr = work, *yi = yr + L * n * n * nh, *t1r = yi + L * n * n * nh;                   \
        T *t1i = t1r + L * p * n * nh, *t2r = t1i + L * p * n * nh, *t2i = t2r + L * p * p * nh; \
        for (q = 0; q < pl->nf; q++) {                                                         \
            const size_t a =                                                                   \
                (size_t)(q / KIFMM__FFT_F) * cstride + (size_t)(q % KIFMM__FFT_F) * 16;        \
            if (pl->single) {                                                                  \
                const float *x = (const float *)in + a;                                        \
                for (v = 0; v < L; v++) {                                                      \
                    yr[L * q + v] = (T)x[v];                                                   \
                    yi[L * q + v] = (T)x[8 + v];                                               \
                }                                                                              \
            } else {                                                                           \
                const double *x = (const double *)in + a;                                      \
                for (v = 0; v < L; v++) {                                                      \
                    yr[L * q + v] = (T)x[v];                                                   \
                    yi[L * q + v] = (T)x[8 + v];                                               \
                }                                                                              \
            }                                                                                  \
        }                                                                                      \
        for (i = 0; i < p; i++)                                                                \
            kifmm__dft_sum##SFX(L * n * nh, n, pl->wr + i, pl->wi + i, n, -1.0, yr, yi,        \
                                (size_t)L * n * nh, t1r + L * i * n * nh, t1i + L * i * n * nh); \
        for (i = 0; i < p; i++)                                                                \
            for (j = 0; j < p; j++)                                                            \
                kifmm__dft_sum##SFX(L * nh, n, pl->wr + j, pl->wi + j, n, -1.0,                \
                                    t1r + L * i * n * nh, t1i + L * i * n * nh, (size_t)L * nh, \
                                    t2r + L * (i * p + j) * nh, t2i + L * (i * p + j) * nh);   \
        for (s = 0; s < pl->ne; s++) {                                                         \
            T acc[KIFMM__FFT_L];                                                               \
            const T *xr, *xi;                                                                  \
            i = pl->ijk[3 * s]; j = pl->ijk[3 * s + 1]; k = pl->ijk[3 * s + 2];                \
            xr = t2r + L * (i * p + j) * nh;                                                   \
            xi = t2i + L * (i * p + j) * nh;                                                   \
            for (v = 0; v < L; v++) acc[v] = 0;                                                \
            for (kz = 0; kz < nh; kz++) {                                                      \
                const T w0 = (T)(pl->wz[kz] * pl->wr[kz * n + k]);                             \
                const T w1 = (T)(pl->wz[kz] * pl->wi[kz * n + k]);                             \
                for (v = 0; v < L; v++) acc[v] += xr[L * kz + v] * w0 + xi[L * kz + v] * w1;   \
            }                                                                                  \
            for (v = 0; v < L; v++) chk[L * s + v] = (double)acc[v];                           \
        }                                                                                      \
    }

KIFMM__FFT_XFORMS(double, )
KIFMM__FFT_XFORMS(float, f)
#undef KIFMM__FFT_XFORMS

/* Transfer vector of each child pair of two parents at offset o (0..26,
 * (ox+1) 9 + (oy+1) 3 + (oz+1)): tv[(o 8 + cs) 8 + ct], -1 if adjacent. */
KIFMM__FN void kifmm__fft_tvmap(int *tv)
{
    int o, cs, ct;
    for (o = 0; o < 27; o++)
        for (cs = 0; cs < 8; cs++)
            for (ct = 0; ct < 8; ct++) {
                int dx = 2 * (o / 9 - 1) + (cs >> 2 & 1) - (ct >> 2 & 1);
                int dy = 2 * (o / 3 % 3 - 1) + (cs >> 1 & 1) - (ct >> 1 & 1);
                int dz = 2 * (o % 3 - 1) + (cs & 1) - (ct & 1);
                int near = dx >= -1 && dx <= 1 && dy >= -1 && dy <= 1 && dz >= -1 && dz <= 1;
                tv[(o * 8 + cs) * 8 + ct] = near ? -1 : kifmm__transfer_index(dx, dy, dz);
            }
}

/* The 8 x 8 blocks of frequency chunk ch for the 27 parent offsets, from the
 * 316 spectra (khat[(f 316 + t) 2]): kb[(o F + fi) 128 + cs 16 + ct] (re),
 * + 8 (im). */
KIFMM__FN void kifmm__fft_blocks(const kifmm__fft *pl, const double *khat, const int *tv, int ch,
                                 void *kbv)
{
    double *kb = (double *)kbv;
    float *kf = (float *)kbv;
    int o, fi, cs, ct;
    for (o = 0; o < 27; o++)
        for (cs = 0; cs < 8; cs++)
            for (ct = 0; ct < 8; ct++) {
                int t = tv[(o * 8 + cs) * 8 + ct];
                for (fi = 0; fi < KIFMM__FFT_F; fi++) {
                    size_t a = ((size_t)o * KIFMM__FFT_F + fi) * 128 + cs * 16 + ct;
                    const double *s =
                        khat + (((size_t)ch * KIFMM__FFT_F + fi) * KIFMM__NT + (t < 0 ? 0 : t)) * 2;
                    double re = t < 0 ? 0.0 : s[0], im = t < 0 ? 0.0 : s[1];
                    if (pl->single) {
                        kf[a] = (float)re;
                        kf[a + 8] = (float)im;
                    } else {
                        kb[a] = re;
                        kb[a + 8] = im;
                    }
                }
            }
}

/* Keeps a loaded vector in a register: each block vector is used by two
 * FMAs, and compilers otherwise fold the load into both as a memory operand,
 * which doubles the loads of a loop that is bound by them (float products
 * 37 -> 45-55 Gflop/s on one core). KIFMM__PREFETCH: a read prefetch hint. */
#if defined(__GNUC__) || defined(__clang__)
#define KIFMM__IN_REG(v) __asm__("" : "+x"(v))
#define KIFMM__PREFETCH(a) __builtin_prefetch((a), 0, 3)
#else
#define KIFMM__IN_REG(v) ((void)0)
#define KIFMM__PREFETCH(a) ((void)0)
#endif

/* The products of kifmm__fft_products in plain C, for element type T
 * (variables nn, nb, no, sch, sc, kb, oc, e, fi, cs of the caller). */
#define KIFMM__FFT_PRODUCTS_C(T)                                                              \
    do {                                                                                      \
        int ct_, q_;                                                                          \
        memset(oc, 0, sizeof(T) * 16 * KIFMM__FFT_F);                                         \
        for (e = 0; e < nn; e++)                                                              \
            for (fi = 0; fi < KIFMM__FFT_F; fi++) {                                           \
                const T *x_ = sc + ((size_t)nb[e] * KIFMM__FFT_F + fi) * 16;                  \
                const T *k_ = kb + ((size_t)no[e] * KIFMM__FFT_F + fi) * 128;                 \
                const unsigned char *h_ = sch + 9 * (size_t)nb[e];                            \
                T *acc_ = oc + fi * 16;                                                       \
                for (q_ = 0; q_ < h_[0]; q_++)                                                \
                    for (cs = h_[1 + q_], ct_ = 0; ct_ < 8; ct_++) {                          \
                        T kr_ = k_[cs * 16 + ct_], ki_ = k_[cs * 16 + 8 + ct_];               \
                        acc_[ct_] += kr_ * x_[cs] - ki_ * x_[8 + cs];                         \
                        acc_[8 + ct_] += kr_ * x_[8 + cs] + ki_ * x_[cs];                     \
                    }                                                                         \
            }                                                                                 \
    } while (0)

/* STEP (a braced block) for each source child cs listed in h (count, then
 * which; variables cs and q of the caller). With all 8 the loop keeps its
 * fixed count: a loop over the list there took 15 % more time in the
 * uniform cube. */
#define KIFMM__FFT_CHILDREN(h, STEP)                                                          \
    if ((h)[0] == 8)                                                                          \
        for (cs = 0; cs < 8; cs++) STEP                                                       \
    else                                                                                      \
        for (q = 0; q < (h)[0]; q++) {                                                        \
            cs = (h)[1 + q];                                                                  \
            STEP                                                                              \
        }

/* One child cs and frequency fi of the products' accumulation for a vector
 * of 8 lanes (the 8 target children): R + i I += (kr + i ki) (xr + i xi),
 * with the block row k[fi 128 + cs 16] (re 8 | im 8) and the source
 * child's spectrum x[fi 16 + cs] (re), 8 further (im), in vectors V of 8
 * lanes (double with AVX-512, float with AVX2). */
#define KIFMM__FFT_STEP8(V, BCAST, LOAD, FMADD, FNMADD, R, I, fi)                              \
    {                                                                                          \
        const V xr = BCAST(x + (fi) * 16 + cs), xi = BCAST(x + (fi) * 16 + 8 + cs);            \
        V kr = LOAD(k + (fi) * 128 + cs * 16), ki = LOAD(k + (fi) * 128 + cs * 16 + 8);        \
        KIFMM__IN_REG(kr);                                                                     \
        KIFMM__IN_REG(ki);                                                                     \
        R = FMADD(kr, xr, R);                                                                  \
        R = FNMADD(ki, xi, R);                                                                 \
        I = FMADD(kr, xi, I);                                                                  \
        I = FMADD(ki, xr, I);                                                                  \
    }
/* The products of one target parent and chunk with the 4 frequencies at
 * once (8 accumulators over all e), then stored to oc; T, V as above. */
#define KIFMM__FFT_PRODUCTS8(T, V, ZERO, BCAST, LOAD, STORE, FMADD, FNMADD)                    \
    {                                                                                          \
        V r0 = ZERO, i0 = r0, r1 = r0, i1 = r0, r2 = r0, i2 = r0, r3 = r0, i3 = r0;            \
        for (e = 0; e < nn; e++) {                                                             \
            const T *x = sc + (size_t)nb[e] * KIFMM__FFT_F * 16;                               \
            const T *k = kb + (size_t)no[e] * KIFMM__FFT_F * 128;                              \
            const unsigned char *h = sch + 9 * (size_t)nb[e];                                  \
            int q;                                                                             \
            KIFMM__FFT_CHILDREN(h, {                                                           \
                KIFMM__FFT_STEP8(V, BCAST, LOAD, FMADD, FNMADD, r0, i0, 0)                     \
                KIFMM__FFT_STEP8(V, BCAST, LOAD, FMADD, FNMADD, r1, i1, 1)                     \
                KIFMM__FFT_STEP8(V, BCAST, LOAD, FMADD, FNMADD, r2, i2, 2)                     \
                KIFMM__FFT_STEP8(V, BCAST, LOAD, FMADD, FNMADD, r3, i3, 3)                     \
            })                                                                                 \
        }                                                                                      \
        STORE(oc, r0); STORE(oc + 8, i0); STORE(oc + 16, r1); STORE(oc + 24, i1);              \
        STORE(oc + 32, r2); STORE(oc + 40, i2); STORE(oc + 48, r3); STORE(oc + 56, i3);        \
    }
#if defined(__AVX512F__)
#define KIFMM__BCAST8D(p) _mm512_set1_pd(*(p))
#endif

/* One target parent, one chunk: oc[fi 16 ..] = sum over its nn source
 * parents e of K[no[e]][fi] (8 x 8 complex) times the 8 child spectra
 * sc[nb[e]] at fi (re 8 | im 8). Only the children listed in sch[9 nb[e]]
 * (count, then which) have sources: the others' spectra are zero and are
 * skipped (on surfaces and clusters about half of them). */
KIFMM__FN void kifmm__fft_products(int nn, const int32_t *nb, const unsigned char *no,
                                   const unsigned char *sch, const double *sc, const double *kb,
                                   double *oc)
{
    int fi, e, cs;
#if defined(__AVX512F__)
    /* the 4 frequencies of the chunk at once, the 8 target children in one
     * register: 8 accumulators over all e, 4 FMAs per child and frequency
     * with the child's spectrum broadcast from memory */
    (void)fi;
    KIFMM__FFT_PRODUCTS8(double, __m512d, _mm512_setzero_pd(), KIFMM__BCAST8D, _mm512_load_pd,
                         _mm512_store_pd, _mm512_fmadd_pd, _mm512_fnmadd_pd)
#elif defined(__AVX2__) && defined(__FMA__)
    /* two frequencies at a time: 8 accumulators in registers over all e */
    for (fi = 0; fi < KIFMM__FFT_F; fi += 2) {
        __m256d a0 = _mm256_setzero_pd(), a1 = a0, a2 = a0, a3 = a0;
        __m256d b0 = a0, b1 = a0, b2 = a0, b3 = a0;
        for (e = 0; e < nn; e++) {
            const double *x = sc + ((size_t)nb[e] * KIFMM__FFT_F + fi) * 16;
            const double *k = kb + ((size_t)no[e] * KIFMM__FFT_F + fi) * 128;
            const unsigned char *h = sch + 9 * (size_t)nb[e];
            int q;
#define KIFMM__FFT_STEPD                                                                       \
    {                                                                                          \
        const __m256d xr = _mm256_broadcast_sd(x + cs), xi = _mm256_broadcast_sd(x + 8 + cs);  \
        const __m256d yr = _mm256_broadcast_sd(x + 16 + cs);                                   \
        const __m256d yi = _mm256_broadcast_sd(x + 24 + cs);                                   \
        const double *k0 = k + cs * 16, *k1 = k + 128 + cs * 16;                               \
        __m256d r0 = _mm256_load_pd(k0), r1 = _mm256_load_pd(k0 + 4);                          \
        __m256d i0 = _mm256_load_pd(k0 + 8), i1 = _mm256_load_pd(k0 + 12);                     \
        KIFMM__IN_REG(r0); KIFMM__IN_REG(r1); KIFMM__IN_REG(i0); KIFMM__IN_REG(i1);            \
        a0 = _mm256_fmadd_pd(r0, xr, a0); a1 = _mm256_fmadd_pd(r1, xr, a1);                    \
        a2 = _mm256_fmadd_pd(r0, xi, a2); a3 = _mm256_fmadd_pd(r1, xi, a3);                    \
        a0 = _mm256_fnmadd_pd(i0, xi, a0); a1 = _mm256_fnmadd_pd(i1, xi, a1);                  \
        a2 = _mm256_fmadd_pd(i0, xr, a2); a3 = _mm256_fmadd_pd(i1, xr, a3);                    \
        r0 = _mm256_load_pd(k1); r1 = _mm256_load_pd(k1 + 4);                                  \
        i0 = _mm256_load_pd(k1 + 8); i1 = _mm256_load_pd(k1 + 12);                             \
        KIFMM__IN_REG(r0); KIFMM__IN_REG(r1); KIFMM__IN_REG(i0); KIFMM__IN_REG(i1);            \
        b0 = _mm256_fmadd_pd(r0, yr, b0); b1 = _mm256_fmadd_pd(r1, yr, b1);                    \
        b2 = _mm256_fmadd_pd(r0, yi, b2); b3 = _mm256_fmadd_pd(r1, yi, b3);                    \
        b0 = _mm256_fnmadd_pd(i0, yi, b0); b1 = _mm256_fnmadd_pd(i1, yi, b1);                  \
        b2 = _mm256_fmadd_pd(i0, yr, b2); b3 = _mm256_fmadd_pd(i1, yr, b3);                    \
    }
            KIFMM__FFT_CHILDREN(h, KIFMM__FFT_STEPD)
#undef KIFMM__FFT_STEPD
        }
        _mm256_store_pd(oc + fi * 16, a0); _mm256_store_pd(oc + fi * 16 + 4, a1);
        _mm256_store_pd(oc + fi * 16 + 8, a2); _mm256_store_pd(oc + fi * 16 + 12, a3);
        _mm256_store_pd(oc + fi * 16 + 16, b0); _mm256_store_pd(oc + fi * 16 + 20, b1);
        _mm256_store_pd(oc + fi * 16 + 24, b2); _mm256_store_pd(oc + fi * 16 + 28, b3);
    }
#else
    KIFMM__FFT_PRODUCTS_C(double);
#endif
}

/* kifmm__fft_products in float: spectra and blocks of 16 floats (re 8 |
 * im 8) per frequency, the 8 target children in one AVX register. */
KIFMM__FN void kifmm__fft_products_f(int nn, const int32_t *nb, const unsigned char *no,
                                     const unsigned char *sch, const float *sc, const float *kb,
                                     float *oc)
{
    int e, cs;
#if defined(__AVX512F__)
    /* A block row, re 8 | im 8, in one register K: per child and frequency
     * one load and two FMAs, A += K xr and B += K xi, and the complex product
     * formed once at the end, re = A.lo - B.hi and im = A.hi + B.lo (the
     * AVX2 kernel below needs two loads and two broadcasts for four FMAs of
     * half the width, which kept it bound by the loads) */
    __m512 a0 = _mm512_setzero_ps(), b0 = a0, a1 = a0, b1 = a0, a2 = a0, b2 = a0, a3 = a0, b3 = a0;
    const __m512 sg = _mm512_setr_ps(-1.0f, -1.0f, -1.0f, -1.0f, -1.0f, -1.0f, -1.0f, -1.0f, 1.0f,
                                     1.0f, 1.0f, 1.0f, 1.0f, 1.0f, 1.0f, 1.0f);
    for (e = 0; e < nn; e++) {
        const float *x = sc + (size_t)nb[e] * KIFMM__FFT_F * 16;
        const float *k = kb + (size_t)no[e] * KIFMM__FFT_F * 128;
        const unsigned char *h = sch + 9 * (size_t)nb[e];
        int q;
#define KIFMM__FFT_STEP16(A, B, fi)                                                            \
    {                                                                                          \
        __m512 kk = _mm512_loadu_ps(k + (fi) * 128 + cs * 16);                                 \
        KIFMM__IN_REG(kk);                                                                     \
        A = _mm512_fmadd_ps(kk, _mm512_set1_ps(x[(fi) * 16 + cs]), A);                         \
        B = _mm512_fmadd_ps(kk, _mm512_set1_ps(x[(fi) * 16 + 8 + cs]), B);                     \
    }
#define KIFMM__FFT_STEPS16                                                                     \
    {                                                                                          \
        KIFMM__FFT_STEP16(a0, b0, 0) KIFMM__FFT_STEP16(a1, b1, 1)                              \
        KIFMM__FFT_STEP16(a2, b2, 2) KIFMM__FFT_STEP16(a3, b3, 3)                              \
    }
        KIFMM__FFT_CHILDREN(h, KIFMM__FFT_STEPS16)
#undef KIFMM__FFT_STEPS16
#undef KIFMM__FFT_STEP16
    }
    /* B with its halves swapped is (ki xi | kr xi) */
    _mm512_storeu_ps(oc, _mm512_fmadd_ps(sg, _mm512_shuffle_f32x4(b0, b0, 0x4E), a0));
    _mm512_storeu_ps(oc + 16, _mm512_fmadd_ps(sg, _mm512_shuffle_f32x4(b1, b1, 0x4E), a1));
    _mm512_storeu_ps(oc + 32, _mm512_fmadd_ps(sg, _mm512_shuffle_f32x4(b2, b2, 0x4E), a2));
    _mm512_storeu_ps(oc + 48, _mm512_fmadd_ps(sg, _mm512_shuffle_f32x4(b3, b3, 0x4E), a3));
#elif defined(__AVX2__) && defined(__FMA__)
    /* the 4 frequencies of a chunk at once: 8 accumulators over all e */
    KIFMM__FFT_PRODUCTS8(float, __m256, _mm256_setzero_ps(), _mm256_broadcast_ss, _mm256_load_ps,
                         _mm256_store_ps, _mm256_fmadd_ps, _mm256_fnmadd_ps)
#else
    int fi;
    KIFMM__FFT_PRODUCTS_C(float);
#endif
}

/* Internal neighbours ("colleagues") of every internal box of level l - 1,
 * for the M2L into level l: for the j-th internal box of level l - 1, the
 * internal indices (relative to the level) of its adjacent internal boxes
 * at that level and their offset codes (not 13, the box itself). CSR over
 * all internal boxes in the order of t->inner. */
KIFMM__FN int kifmm__colleagues(const kifmm__tree *t, int nth, int32_t **co_out,
                                int32_t **cj_out, unsigned char **cc_out)
{
    int32_t ni = t->ioff[t->nlev], i, *co, *cj;
    unsigned char *cc;
    int pass;
    co = (int32_t *)kifmm__calloc((size_t)ni + 1, sizeof(int32_t));
    cj = (int32_t *)kifmm__alloc((size_t)ni * 26 + 1, sizeof(int32_t));
    cc = (unsigned char *)kifmm__alloc((size_t)ni * 26 + 1, 1);
    *co_out = co; *cj_out = cj; *cc_out = cc;
    if (!co || !cj || !cc) return KIFMM_ERR_NOMEM;
    (void)nth;
    for (pass = 0; pass < 2; pass++) {
        KIFMM__OMP(parallel for schedule(static) num_threads(nth))
        for (int32_t i = 0; i < ni; i++) {
            int32_t p = t->inner[i], m = 0;
            int l = t->lev[p], o;
            int64_t side = (int64_t)1 << l;
            const int32_t *a = t->anchor + 3 * (size_t)p;
            for (o = 0; o < 27; o++) {
                int64_t x = a[0] + o / 9 - 1, y = a[1] + o / 3 % 3 - 1, z = a[2] + o % 3 - 1;
                int32_t q;
                if (o == 13 || x < 0 || y < 0 || z < 0 || x >= side || y >= side || z >= side)
                    continue;
                q = kifmm__find(t, l, kifmm__encode(x, y, z));
                if (q < 0 || t->child[q] < 0) continue;
                if (pass == 1) {
                    cj[co[i] + m] = (t->child[q] - t->loff[l + 1]) / 8;
                    cc[co[i] + m] = (unsigned char)o;
                }
                m++;
            }
            if (pass == 0) co[i + 1] = m;
        }
        if (pass == 0)
            for (i = 0; i < ni; i++) co[i + 1] += co[i];
    }
    return KIFMM_SUCCESS;
}

/* KIFMM_REAL must name one of these two types. */
#define KIFMM__REAL_IS_double 1
#define KIFMM__REAL_IS_float 2

/* Density vectors processed together by evaluate_many; more are done in
 * groups of this many, so the workspace stays bounded. */
#define KIFMM__RHS_MAX 8


#endif /* KIFMM_H_SHARED */

/* ======================================================================== */
/* 4. Kernel template                                                       */
/* ======================================================================== */

#ifndef KIFMM_KERNEL
#define KIFMM_KERNEL laplace
#endif
#ifndef KIFMM_REAL
#define KIFMM_REAL double
#endif

#if KIFMM__CAT(KIFMM__REAL_IS_, KIFMM_REAL) == 1
#define KIFMM__FLOAT 0
#elif KIFMM__CAT(KIFMM__REAL_IS_, KIFMM_REAL) == 2
#define KIFMM__FLOAT 1
#else
#error "kifmm.h: KIFMM_REAL must be double or float"
#endif

/* default names: kifmm_<kernel>, and kifmm_<kernel>f for float instances */
#ifndef KIFMM_NAME
#if KIFMM__FLOAT
#define KIFMM_NAME KIFMM__CAT3(kifmm_, KIFMM_KERNEL, f)
#else
#define KIFMM_NAME KIFMM__CAT(kifmm_, KIFMM_KERNEL)
#endif
#endif

#define KIFMM__K(suffix) KIFMM__CAT3(kifmm_kernel_, KIFMM_KERNEL, suffix)
#define KIFMM__F(suffix) KIFMM__CAT(KIFMM_NAME, suffix)
#define KIFMM__R KIFMM_REAL

#if !KIFMM__K(_SRC_DIM) || !KIFMM__K(_TRG_DIM)
#error "kifmm.h: the kernel named by KIFMM_KERNEL must define kifmm_kernel_<name>_SRC_DIM and _TRG_DIM (see docs/kernels.md)"
#endif

/* The kernel's traits, resolved once. QD: density components per source
 * point; TD: outputs per target; SD: density components per point of the
 * equivalent surfaces (the surface kernel's). */
#define KIFMM__QD KIFMM__K(_SRC_DIM)
#define KIFMM__TD KIFMM__K(_TRG_DIM)
#define KIFMM__SI KIFMM__K(_SCALE_INVARIANT)
#define KIFMM__DEGREE KIFMM__K(_DEGREE)

/* The four kernel roles (docs/kernels.md), each a kernel name:
 *   QT  points -> targets (TD x QD): the kernel itself;
 *   SC  surface -> check surface (SD x SD): the surface kernel, _EQUIV, or
 *       the kernel itself when TD == QD;
 *   ST  surface -> targets (TD x SD): the kernel itself when QD == SD,
 *       else _SURFACE;
 *   QC  points -> check surface (SD x QD): SC when QD == SD, the kernel
 *       itself when TD == SD, else _CHECK.
 * Today's kernels (QD = SD) name at most _EQUIV, as before. */
#define KIFMM__ROLE_QT KIFMM_KERNEL
#if KIFMM__K(_TRG_DIM) == KIFMM__K(_SRC_DIM)
#define KIFMM__ROLE_SC KIFMM_KERNEL
#else
#define KIFMM__ROLE_SC KIFMM__K(_EQUIV)
#endif
/* kifmm_kernel_<the role's kernel><suffix>; a concatenation of its own, as
 * the role's name may itself expand through KIFMM__CAT */
#define KIFMM__RCAT_(a, b, c) a##b##c
#define KIFMM__RCAT(a, b, c) KIFMM__RCAT_(a, b, c)
#define KIFMM__R_(role, suffix) KIFMM__RCAT(kifmm_kernel_, KIFMM__ROLE_##role, suffix)
#define KIFMM__SD KIFMM__R_(SC, _SRC_DIM)
#if KIFMM__QD == KIFMM__SD
#define KIFMM__ROLE_ST KIFMM_KERNEL
#define KIFMM__ROLE_QC KIFMM__ROLE_SC
#elif KIFMM__TD == KIFMM__SD
#define KIFMM__ROLE_ST KIFMM__K(_SURFACE)
#define KIFMM__ROLE_QC KIFMM_KERNEL
#else
#define KIFMM__ROLE_ST KIFMM__K(_SURFACE)
#define KIFMM__ROLE_QC KIFMM__K(_CHECK)
#endif
KIFMM__STATIC_ASSERT(KIFMM__R_(SC, _TRG_DIM) == KIFMM__SD && KIFMM__R_(ST, _SRC_DIM) == KIFMM__SD &&
                         KIFMM__R_(ST, _TRG_DIM) == KIFMM__TD &&
                         KIFMM__R_(QC, _SRC_DIM) == KIFMM__QD &&
                         KIFMM__R_(QC, _TRG_DIM) == KIFMM__SD,
                     KIFMM__CAT(KIFMM_NAME, _kernel_roles_must_have_matching_dimensions));

/* A role kernel's optional features: its _HAS mask (in parentheses, of
 * KIFMM_HAS_* bits: a misspelt bit name stops the build, see below), or,
 * for kernels written before the mask, the flags _SETUP, _P2P, _P2PF, ...
 * each defined as 1. */
#define KIFMM__LEGACY_HAS(k)                                                                \
    (KIFMM__IS_ONE(KIFMM__CAT3(kifmm_kernel_, k, _SETUP)) * KIFMM_HAS_SETUP |               \
     KIFMM__IS_ONE(KIFMM__CAT3(kifmm_kernel_, k, _P2P)) * KIFMM_HAS_P2P |                   \
     KIFMM__IS_ONE(KIFMM__CAT3(kifmm_kernel_, k, _P2PF)) * KIFMM_HAS_P2PF |                 \
     KIFMM__IS_ONE(KIFMM__CAT3(kifmm_kernel_, k, _P2PN)) * KIFMM_HAS_P2PN |                 \
     KIFMM__IS_ONE(KIFMM__CAT3(kifmm_kernel_, k, _P2PNF)) * KIFMM_HAS_P2PNF |               \
     KIFMM__IS_ONE(KIFMM__CAT3(kifmm_kernel_, k, _P2PS)) * KIFMM_HAS_P2PS |                 \
     KIFMM__IS_ONE(KIFMM__CAT3(kifmm_kernel_, k, _P2PSF)) * KIFMM_HAS_P2PSF |               \
     KIFMM__IS_ONE(KIFMM__CAT3(kifmm_kernel_, k, _P2PSN)) * KIFMM_HAS_P2PSN |               \
     KIFMM__IS_ONE(KIFMM__CAT3(kifmm_kernel_, k, _P2PSNF)) * KIFMM_HAS_P2PSNF)
#define KIFMM__HAS_OF(k)                                                                    \
    KIFMM__IF(KIFMM__IS_PAREN(KIFMM__CAT3(kifmm_kernel_, k, _HAS)))(                        \
        KIFMM__CAT3(kifmm_kernel_, k, _HAS), KIFMM__LEGACY_HAS(k))
#define KIFMM__HAS_QT KIFMM__HAS_OF(KIFMM__ROLE_QT)
#define KIFMM__HAS_ST KIFMM__HAS_OF(KIFMM__ROLE_ST)
#define KIFMM__HAS_QC KIFMM__HAS_OF(KIFMM__ROLE_QC)
#define KIFMM__HAS_SC KIFMM__HAS_OF(KIFMM__ROLE_SC)
/* in C, where a misspelt KIFMM_HAS_ name is an undeclared identifier */
KIFMM__STATIC_ASSERT(((KIFMM__HAS_QT | KIFMM__HAS_ST | KIFMM__HAS_QC | KIFMM__HAS_SC) &
                      ~KIFMM_HAS_ALL) == 0,
                     KIFMM__CAT(KIFMM_NAME, _kernel_HAS_mask_has_unknown_bits));

/* The hook bits of this precision: one-way, many-vector, mutual, mutual
 * many-vector; and the suffix of the hooks' names. */
#if KIFMM__FLOAT
#define KIFMM__B_P2P KIFMM_HAS_P2PF
#define KIFMM__B_P2PN KIFMM_HAS_P2PNF
#define KIFMM__B_P2PS KIFMM_HAS_P2PSF
#define KIFMM__B_P2PSN KIFMM_HAS_P2PSNF
#define KIFMM__HOOK(role, h) KIFMM__R_(role, KIFMM__CAT3(_, h, f))
#else
#define KIFMM__B_P2P KIFMM_HAS_P2P
#define KIFMM__B_P2PN KIFMM_HAS_P2PN
#define KIFMM__B_P2PS KIFMM_HAS_P2PS
#define KIFMM__B_P2PSN KIFMM_HAS_P2PSN
#define KIFMM__HOOK(role, h) KIFMM__R_(role, KIFMM__CAT(_, h))
#endif

/* Resolved to 0 / 1 for use in C expressions. */
#if KIFMM__HAS_QT & KIFMM__B_P2P
#define KIFMM__NEAR_HOOK 1
#else
#define KIFMM__NEAR_HOOK 0
#endif
#if KIFMM__HAS_QT & KIFMM__B_P2PS
#define KIFMM__MUTUAL 1
#else
#define KIFMM__MUTUAL 0
#endif
/* The single-thread column GEMM of this precision. */
#if KIFMM__FLOAT
#define KIFMM__GEMM_COLS kifmm__gemm_colsf
#else
#define KIFMM__GEMM_COLS kifmm__gemm_colsd
#endif

/* M2L by FFT for kernels with one surface density component (unless
 * KIFMM_M2L_DENSE is defined); dense stacked GEMMs otherwise. */
#if KIFMM__SD == 1 && !defined(KIFMM_M2L_DENSE)
#define KIFMM__FFT 1
#else
#define KIFMM__FFT 0
#endif

/* Singular value cutoff of the check-to-equivalent pseudo-inverses; the
 * smallest kernel magnitude on the surfaces for which a level keeps its far
 * field (see build_c2e). */
#if KIFMM__FLOAT
#define KIFMM__CUTOFF (KIFMM_SVD_CUTOFF > 1e-7 ? KIFMM_SVD_CUTOFF : 1e-7)
#define KIFMM__TINY ((double)FLT_MIN)
#else
#define KIFMM__CUTOFF KIFMM_SVD_CUTOFF
#define KIFMM__TINY DBL_MIN
#endif

/* ---- the handle ---------------------------------------------------------- */

/* Operators of one level in the instance's precision (see kifmm__ops). */
typedef struct {
    double sigma;
    int ku, kd;
    KIFMM__R *ut_up, *vs_up, *ut_dn, *vs_dn, *m2m, *l2l, *m2l, *conv;
    double *khat;
    void *kb; /* FFT M2L: the 8 x 8 blocks of every chunk (kifmm__fft_blocks), or NULL
                 when they would take too much memory and are built per task */
} KIFMM__F(__ops);

/* Expansions and workspace for up to `nrhs` density vectors, rhs-major:
 * vector r of an array starts at r times the array's per-vector size. */
typedef struct {
    int nrhs;
    KIFMM__R *ue, *de;       /* nbox x ne per vector */
    KIFMM__R *chk;           /* check vectors of one level: nc x (boxes of the level) */
    KIFMM__R *tmp;           /* dense M2L: max(nc, ne) x (boxes of a level) */
    KIFMM__R *stack;         /* 316 ne x (M2L block columns) */
    KIFMM__R *m2l_out;       /* kd x (M2L block columns) */
    KIFMM__R *qs;            /* densities in sorted order */
    /* Outputs: either all of them in sorted order (outs), gathered into the
     * caller's order at the end; or, when that saves memory, each task sums
     * its targets in its thread's part of lbuf (lbuf_per values) and adds
     * them to the caller's out (dst, set during an evaluate) itself. */
    KIFMM__R *outs, *lbuf, *dst;
    size_t lbuf_per;
} KIFMM__F(__work);

typedef struct KIFMM_NAME KIFMM_NAME;
struct KIFMM_NAME {
    kifmm_opts opts;
    kifmm__tree tree;
    KIFMM__R *src, *trg;     /* sorted points (SoA); the tree's own in double */
    int nse, nsc;            /* equivalent and check surface points */
    int cdiff;               /* check order - equivalent order (kifmm__check_diff) */
    double ao;               /* outer surfaces' radius, in box half-widths */
    int ne, nc;              /* vector lengths: points x SRC_DIM */
    double *surf_e, *surf_c; /* unit surfaces (SoA) */
    double degree;
    KIFMM__F(__ops) *ops;    /* ops[l] for the levels that use them */
    int nops;
    double param[4];         /* kernel parameters, defaults resolved */
    int m2l_cols;            /* columns (box x vector) per M2L GEMM */
    int mb;                  /* most boxes on one level */
    KIFMM__R *scratch;       /* per thread: see __scratch_per */
    size_t fpts;             /* points of the float instances' frame buffers */
    KIFMM__R *gbuf;          /* column GEMM passes: see kifmm__gbuf_per */
    size_t gbuf_n;           /* its values */
    int nthreads;
    KIFMM__F(__work) *w;     /* grows to the largest nrhs evaluated (<= RHS_MAX) */
    kifmm__fft fft;          /* FFT M2L: transforms of the order-p lattice */
    int32_t *co, *cj;        /* FFT M2L: internal colleagues of internal boxes */
    unsigned char *cc;       /*          and their offset codes */
    void *spec;              /* FFT M2L: child spectra of one slab (float or double) */
    int32_t slots;           /*          parents whose spectra fit in spec */
    int32_t *loc, *need, *cjl; /*        slab: slot of a parent, parents, local colleagues */
    unsigned char *sch;      /*          per slot: number of children with sources, then
                                which (9 bytes) */
    double *fbuf;            /* FFT M2L: per-thread blocks, products, work */
    size_t fbuf_per;         /* doubles of fbuf per thread */
    int ftb;                 /* FFT M2L: target parents per task (products buffer) */
    void *fout;              /* FFT M2L without kept blocks: products of a slab's target
                                parents (slots of them), chunk-major; or NULL */
    int32_t fft_m, fft_mc;   /*          sizes of loc/need and cjl */
    int32_t *pchunk;         /* mutual near field: chunks of leaves (or NULL) */
    int32_t *act;            /* boxes of each level the solves visit (see kifmm__active) */
    int npchunk;
    kifmm_stats *stats;      /* written by create and evaluate */
};

/* ---- dense linear algebra in the instance's precision ------------------ */

/* C = A B (+ C if beta), column major, no transposes. Outside parallel
 * regions only. */
KIFMM__FN void KIFMM__F(__gemm)(int m, int n, int k, const KIFMM__R *a, int lda,
                                const KIFMM__R *b, int ldb, int beta, KIFMM__R *c, int ldc)
{
    if (m <= 0 || n <= 0) return;
    if (k <= 0) {
        int i, j;
        if (!beta)
            for (j = 0; j < n; j++)
                for (i = 0; i < m; i++) c[i + (size_t)j * ldc] = 0;
        return;
    }
#if KIFMM__FLOAT
    cblas_sgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, m, n, k, 1.0f, a, lda, b, ldb,
                beta ? 1.0f : 0.0f, c, ldc);
#else
    cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, m, n, k, 1.0, a, lda, b, ldb,
                beta ? 1.0 : 0.0, c, ldc);
#endif
}

/* A copy of n doubles in the instance's precision (the array itself for
 * double, which then changes owner). NULL on allocation failure. */
KIFMM__FN KIFMM__R *KIFMM__F(__own)(double **d, size_t n)
{
#if KIFMM__FLOAT
    KIFMM__R *f = (KIFMM__R *)kifmm__alloc(n, sizeof(KIFMM__R));
    size_t i;
    if (f)
        for (i = 0; i < n; i++) f[i] = (KIFMM__R)(*d)[i];
    kifmm__free(*d);
    *d = NULL;
    return f;
#else
    KIFMM__R *f = *d;
    (void)n;
    *d = NULL;
    return f;
#endif
}

/* Unit surface scaled by `radius` and moved to `c`, into out (SoA, n points). */
KIFMM__FN void KIFMM__F(__place)(const double *unit, int n, const double *c, double radius,
                                 KIFMM__R *out)
{
    int i, d;
    for (d = 0; d < 3; d++)
        for (i = 0; i < n; i++) out[d * n + i] = (KIFMM__R)(c[d] + radius * unit[d * n + i]);
}

/* ---- direct interactions ------------------------------------------------ */

/* The signature of the instance's direct-interaction loops below. */
#define KIFMM__P2P_SIG(fname)                                                                \
    KIFMM__FN void fname(const double *prm, const KIFMM__R *tx, const KIFMM__R *ty,          \
                         const KIFMM__R *tz, int64_t nt, const KIFMM__R *sx,                 \
                         const KIFMM__R *sy, const KIFMM__R *sz, const KIFMM__R *q,          \
                         int64_t ns, int nrhs, size_t qld, double scale, KIFMM__R *out,      \
                         size_t old)

/* out[r*old + i*dim + a] += scale * sum_j K(t_i - s_j) q[r*qld + j*qdim + s]
 * for nrhs density vectors; targets and sources as structure-of-arrays
 * coordinates; `kfun` has `dim` output and `qdim` density components. The
 * kernel is evaluated once per pair for all vectors. */
#define KIFMM__DEFINE_P2P(fname, kfun, dim, qdim)                                            \
    KIFMM__P2P_SIG(fname)                                                                    \
    {                                                                                        \
        int64_t i, j;                                                                        \
        int a, s, r;                                                                         \
        for (i = 0; i < nt; i++) {                                                           \
            double acc[KIFMM__RHS_MAX * (dim)], k[(dim) * (qdim)];                           \
            for (a = 0; a < nrhs * (dim); a++) acc[a] = 0.0;                                 \
            for (j = 0; j < ns; j++) {                                                       \
                kfun(prm, (double)tx[i] - (double)sx[j], (double)ty[i] - (double)sy[j],      \
                     (double)tz[i] - (double)sz[j], k);                                      \
                for (r = 0; r < nrhs; r++) {                                                 \
                    const KIFMM__R *qj = q + r * qld + j * (qdim);                           \
                    for (a = 0; a < (dim); a++)                                              \
                        for (s = 0; s < (qdim); s++)                                         \
                            acc[r * (dim) + a] += k[a * (qdim) + s] * (double)qj[s];         \
                }                                                                            \
            }                                                                                \
            for (r = 0; r < nrhs; r++)                                                       \
                for (a = 0; a < (dim); a++)                                                  \
                    out[r * old + i * (dim) + a] += (KIFMM__R)(scale * acc[r * (dim) + a]);  \
        }                                                                                    \
    }

/* The same through a kernel's hand-written hook, one vector at a time. */
#define KIFMM__DEFINE_P2P_HOOK(fname, hook)                                                  \
    KIFMM__P2P_SIG(fname)                                                                    \
    {                                                                                        \
        int r;                                                                               \
        for (r = 0; r < nrhs; r++)                                                           \
            hook(prm, tx, ty, tz, nt, sx, sy, sz, q + r * qld, ns, (KIFMM__R)scale,          \
                 out + r * old);                                                             \
    }

/* The same through a kernel's many-vector hook when nrhs > 1. */
#define KIFMM__DEFINE_P2P_HOOKN(fname, hook, hookn)                                          \
    KIFMM__P2P_SIG(fname)                                                                    \
    {                                                                                        \
        if (nrhs > 1)                                                                        \
            hookn(prm, tx, ty, tz, nt, sx, sy, sz, q, ns, nrhs, qld, (KIFMM__R)scale, out,   \
                  old);                                                                      \
        else                                                                                 \
            hook(prm, tx, ty, tz, nt, sx, sy, sz, q, ns, (KIFMM__R)scale, out);              \
    }

/* One loop per kernel role (see the roles above): the role kernel's hooks
 * where it has them (one-way, and many-vector for nrhs > 1), else the
 * generic loop over its eval.
 *   __p2p_qt  points -> targets: U lists, and W and X sources taken directly
 *   __p2p_st  surface densities -> targets: L2P, M2P
 *   __p2p_qc  points -> check surfaces: P2M, P2L
 *   __p2p_sc  surface densities -> check surfaces: L2L from a far ancestor */
#if (KIFMM__HAS_QT & KIFMM__B_P2P) && (KIFMM__HAS_QT & KIFMM__B_P2PN)
KIFMM__DEFINE_P2P_HOOKN(KIFMM__F(__p2p_qt), KIFMM__HOOK(QT, p2p), KIFMM__HOOK(QT, p2pn))
#elif KIFMM__HAS_QT & KIFMM__B_P2P
KIFMM__DEFINE_P2P_HOOK(KIFMM__F(__p2p_qt), KIFMM__HOOK(QT, p2p))
#else
KIFMM__DEFINE_P2P(KIFMM__F(__p2p_qt), KIFMM__R_(QT, _eval), KIFMM__TD, KIFMM__QD)
#endif
#if (KIFMM__HAS_ST & KIFMM__B_P2P) && (KIFMM__HAS_ST & KIFMM__B_P2PN)
KIFMM__DEFINE_P2P_HOOKN(KIFMM__F(__p2p_st), KIFMM__HOOK(ST, p2p), KIFMM__HOOK(ST, p2pn))
#elif KIFMM__HAS_ST & KIFMM__B_P2P
KIFMM__DEFINE_P2P_HOOK(KIFMM__F(__p2p_st), KIFMM__HOOK(ST, p2p))
#else
KIFMM__DEFINE_P2P(KIFMM__F(__p2p_st), KIFMM__R_(ST, _eval), KIFMM__TD, KIFMM__SD)
#endif
#if (KIFMM__HAS_QC & KIFMM__B_P2P) && (KIFMM__HAS_QC & KIFMM__B_P2PN)
KIFMM__DEFINE_P2P_HOOKN(KIFMM__F(__p2p_qc), KIFMM__HOOK(QC, p2p), KIFMM__HOOK(QC, p2pn))
#elif KIFMM__HAS_QC & KIFMM__B_P2P
KIFMM__DEFINE_P2P_HOOK(KIFMM__F(__p2p_qc), KIFMM__HOOK(QC, p2p))
#else
KIFMM__DEFINE_P2P(KIFMM__F(__p2p_qc), KIFMM__R_(QC, _eval), KIFMM__SD, KIFMM__QD)
#endif
#if (KIFMM__HAS_SC & KIFMM__B_P2P) && (KIFMM__HAS_SC & KIFMM__B_P2PN)
KIFMM__DEFINE_P2P_HOOKN(KIFMM__F(__p2p_sc), KIFMM__HOOK(SC, p2p), KIFMM__HOOK(SC, p2pn))
#elif KIFMM__HAS_SC & KIFMM__B_P2P
KIFMM__DEFINE_P2P_HOOK(KIFMM__F(__p2p_sc), KIFMM__HOOK(SC, p2p))
#else
KIFMM__DEFINE_P2P(KIFMM__F(__p2p_sc), KIFMM__R_(SC, _eval), KIFMM__SD, KIFMM__SD)
#endif

/* ---- operators ------------------------------------------------------------ */

/* Matrix of the surface kernel from sources s (SoA, nsp points) to targets tp
 * (SoA, ntp points), times sigma: row i*SD + a, column j*SD + b, leading
 * dimension ld. Returns the largest |entry| before sigma, or NaN if the
 * kernel gave a value that is not finite (nothing then reaches LAPACK). */
KIFMM__FN double KIFMM__F(__kmat)(const double *prm, const double *tp, int ntp,
                                  const double *sp, int nsp, double sigma, double *m, size_t ld)
{
    int i, j, a, b;
    double k[KIFMM__SD * KIFMM__SD], big = 0.0;
    for (j = 0; j < nsp; j++)
        for (i = 0; i < ntp; i++) {
            KIFMM__R_(SC, _eval)(prm, tp[i] - sp[j], tp[ntp + i] - sp[nsp + j],
                         tp[2 * ntp + i] - sp[2 * nsp + j], k);
            for (b = 0; b < KIFMM__SD; b++)
                for (a = 0; a < KIFMM__SD; a++) {
                    const double v = k[a * KIFMM__SD + b];
                    if (!(fabs(v) <= DBL_MAX)) return NAN;
                    big = fabs(v) > big ? fabs(v) : big;
                    m[(size_t)(i * KIFMM__SD + a) + (size_t)(j * KIFMM__SD + b) * ld] = sigma * v;
                }
        }
    return big;
}

/* The operators for target boxes of half-width r (see kifmm__ops), in double. */
/* K(check <- equivalent) times sigma into m (leading dimension ld): the
 * check surface of order ordc... placed at centre cc with radius crad (unit
 * surface uc, nc points), the equivalent one likewise. *big (if not NULL)
 * gets the largest |entry| before sigma. KIFMM_ERR_KERNEL if the kernel gave
 * a value that is not finite, KIFMM_ERR_NOMEM. */
KIFMM__FN int KIFMM__F(__surf_kmat)(const KIFMM_NAME *c, const double *uc, int nc,
                                    const double *cc, double crad, const double *ue, int ne,
                                    const double *ec, double erad, double sigma, double *m,
                                    size_t ld, double *big)
{
    double *pc = (double *)kifmm__alloc((size_t)3 * (nc + ne), sizeof(double)), b;
    if (!pc) return KIFMM_ERR_NOMEM;
    kifmm__surf_place(uc, nc, cc, crad, pc);
    kifmm__surf_place(ue, ne, ec, erad, pc + 3 * nc);
    b = KIFMM__F(__kmat)(c->param, pc, nc, pc + 3 * nc, ne, sigma, m, ld);
    kifmm__free(pc);
    if (big) *big = b;
    return b == b ? KIFMM_SUCCESS : KIFMM_ERR_KERNEL;
}

/* UC2E and DC2E, the check-to-equivalent solves of boxes of half-width r:
 * pseudo-inverses of K(up check at ao r <- up equiv at 1.05 r) and K(down
 * check at 1.05 r <- down equiv at ao r). Float instances truncate at float
 * resolution: factors that resolve singular values below it would amplify
 * the rounding of the passes.
 *
 * Every operator that yields check potentials of boxes of this size is
 * scaled by sigma = 1 / (the largest entry of the first matrix), and so are
 * the check potentials the passes compute from points (kifmm__level_scale):
 * the pseudo-inverses see matrices of norm about 1 whatever the kernel's
 * magnitude (a Yukawa kernel at exp(-300), a Stokeslet with viscosity 1e100),
 * and the densities they give are the true ones. Where that largest entry is
 * below the smallest normal number of the instance's precision (a Yukawa
 * kernel whose lambda times the box size is in the hundreds), sigma is 0:
 * every operator of the level is zero (ranks 0) and its far field, smaller
 * still, is dropped. */
KIFMM__FN int KIFMM__F(__build_c2e)(const KIFMM_NAME *c, double r, kifmm__ops *o)
{
    const double zero[3] = {0.0, 0.0, 0.0};
    const size_t nn = (size_t)c->nc * (size_t)c->ne;
    double *a = (double *)kifmm__alloc(nn, sizeof(double)), big = 0.0;
    size_t i;
    int rc;
    if (!a) return KIFMM_ERR_NOMEM;
    rc = KIFMM__F(__surf_kmat)(c, c->surf_c, c->nsc, zero, c->ao * r, c->surf_e, c->nse, zero,
                               KIFMM__ALPHA_INNER * r, 1.0, a, (size_t)c->nc, &big);
    if (!rc) {
        o->sigma = big >= KIFMM__TINY ? 1.0 / big : 0.0;
        for (i = 0; i < nn; i++) a[i] *= o->sigma;
        rc = kifmm__pinv(a, c->nc, c->ne, KIFMM__CUTOFF, &o->ut_up, &o->vs_up, &o->ku);
    }
    if (!rc)
        rc = KIFMM__F(__surf_kmat)(c, c->surf_c, c->nsc, zero, KIFMM__ALPHA_INNER * r,
                                   c->surf_e, c->nse, zero, c->ao * r, o->sigma, a,
                                   (size_t)c->nc, NULL);
    if (!rc) rc = kifmm__pinv(a, c->nc, c->ne, KIFMM__CUTOFF, &o->ut_dn, &o->vs_dn, &o->kd);
    kifmm__free(a);
    return rc;
}

/* M2M and L2L, per child octant: a child's upward equivalent density (half
 * r / 2, centre r / 2 sgn) -> the parent's upward check potential (half r);
 * the parent's downward equivalent density (half 2 r, centre -r sgn) -> a
 * child's downward check potential (half r). Times sigma. */
KIFMM__FN int KIFMM__F(__build_m2m_l2l)(const KIFMM_NAME *c, double r, kifmm__ops *o)
{
    const double zero[3] = {0.0, 0.0, 0.0};
    const size_t nc = (size_t)c->nc, ne = (size_t)c->ne;
    int oct, d, rc = KIFMM_SUCCESS;
    o->m2m = (double *)kifmm__alloc(nc * 8 * ne, sizeof(double));
    o->l2l = (double *)kifmm__alloc(8 * nc * ne, sizeof(double));
    if (!o->m2m || !o->l2l) return KIFMM_ERR_NOMEM;
    for (oct = 0; oct < 8 && !rc; oct++) {
        const double sgn[3] = {(oct >> 2 & 1) ? 1.0 : -1.0, (oct >> 1 & 1) ? 1.0 : -1.0,
                               (oct & 1) ? 1.0 : -1.0};
        double cm[3], cl[3];
        for (d = 0; d < 3; d++) {
            cm[d] = 0.5 * r * sgn[d];
            cl[d] = -r * sgn[d];
        }
        rc = KIFMM__F(__surf_kmat)(c, c->surf_c, c->nsc, zero, c->ao * r, c->surf_e, c->nse, cm,
                                   KIFMM__ALPHA_INNER * 0.5 * r, o->sigma,
                                   o->m2m + (size_t)oct * ne * nc, nc, NULL);
        if (!rc)
            rc = KIFMM__F(__surf_kmat)(c, c->surf_c, c->nsc, zero, KIFMM__ALPHA_INNER * r,
                                       c->surf_e, c->nse, cl, c->ao * 2.0 * r, o->sigma,
                                       o->l2l + (size_t)oct * nc, 8 * nc, NULL);
    }
    return rc;
}

#if KIFMM__FFT
/* The FFT M2L's lattice density: conv (nc x ne) maps the order-p upward
 * equivalent density to a density on the check-order lattice at the same
 * radius with the same field outside (fitted on the upward check surface).
 * With check surfaces of order p the lattice is the equivalent surface
 * itself and conv the identity, exactly: none is built (the fit gave it
 * with max |conv - I| 7e-11 at p = 4, 8e-6 at p = 6, 3e-2 at p = 7). */
KIFMM__FN int KIFMM__F(__build_conv)(const KIFMM_NAME *c, double r, kifmm__ops *o)
{
    const double zero[3] = {0.0, 0.0, 0.0};
    const int nc = c->nc, ne = c->ne;
    double *kb, *a, *ut = NULL, *vs = NULL, *tmp = NULL;
    int k = 0, rc = KIFMM_SUCCESS;
    if (c->cdiff == 0) return KIFMM_SUCCESS;
    kb = (double *)kifmm__alloc((size_t)nc * ne, sizeof(double));
    a = (double *)kifmm__alloc((size_t)nc * nc, sizeof(double));
    if (!kb || !a) { rc = KIFMM_ERR_NOMEM; goto done; }
    rc = KIFMM__F(__surf_kmat)(c, c->surf_c, c->nsc, zero, c->ao * r, c->surf_e, c->nse, zero,
                               KIFMM__ALPHA_INNER * r, 1.0, kb, (size_t)nc, NULL);
    if (!rc)
        rc = KIFMM__F(__surf_kmat)(c, c->surf_c, c->nsc, zero, c->ao * r, c->surf_c, c->nsc,
                                   zero, KIFMM__ALPHA_INNER * r, 1.0, a, (size_t)nc, NULL);
    if (!rc) rc = kifmm__pinv(a, nc, nc, KIFMM__CUTOFF, &ut, &vs, &k);
    if (rc) goto done;
    tmp = (double *)kifmm__alloc((size_t)k * ne, sizeof(double));
    o->conv = (double *)kifmm__alloc((size_t)nc * ne, sizeof(double));
    if (!tmp || !o->conv) { rc = KIFMM_ERR_NOMEM; goto done; }
    kifmm__gemm(0, 0, k, ne, nc, 1.0, ut, k, kb, nc, 0.0, tmp, k);
    kifmm__gemm(0, 0, nc, ne, k, 1.0, vs, nc, tmp, k, 0.0, o->conv, nc);
done:
    kifmm__free(kb);
    kifmm__free(a);
    kifmm__free(ut);
    kifmm__free(vs);
    kifmm__free(tmp);
    return rc;
}

/* The FFT M2L's 316 kernel spectra for boxes of half-width r, times sigma:
 * the kernel at the lattice offsets h (i - j) - 2 r t on the (2q - 1)^3
 * grid, transformed (kifmm__fft_grid), then stored frequency-major
 * (khat[(f 316 + t) 2], re and im) so that the blocks of a chunk of
 * frequencies read one contiguous piece. */
KIFMM__FN int KIFMM__F(__build_m2l_fft)(const KIFMM_NAME *c, double r, kifmm__ops *o)
{
    const kifmm__fft *pl = &c->fft;
    const int n = pl->n, p = pl->p;
    const size_t per = (size_t)n * n * n + kifmm__fft_work(pl), nk = (size_t)KIFMM__NT * 2 * pl->nfp;
    const double h = 2.0 * KIFMM__ALPHA_INNER * r / (p - 1), sigma = o->sigma;
    double *kall, *kt; /* per thread grids and work; spectra per transfer vector */
    double big = 0.0;
    int bad = 0;
    o->khat = (double *)kifmm__alloc(nk, sizeof(double));
    kall = (double *)kifmm__alloc((size_t)c->nthreads * per + nk, sizeof(double));
    if (!o->khat || !kall) {
        kifmm__free(kall);
        return KIFMM_ERR_NOMEM;
    }
    kt = kall + (size_t)c->nthreads * per;
    memset(kt, 0, sizeof(double) * nk); /* the padding frequencies stay 0 */
    /* each transfer vector writes its own spectrum; g is the thread's grid */
    KIFMM__OMP(parallel for schedule(dynamic, 1) num_threads(c->nthreads) reduction(| : bad) \
               reduction(max : big))
    for (int tv = 0; tv < KIFMM__NT; tv++) {
        double *g = kall + (size_t)kifmm__thread_num() * per, kv[1];
        int d[3] = {0, 0, 0}, i, j, k;
        kifmm__transfer_vector(tv, d);
        memset(g, 0, sizeof(double) * (size_t)n * n * n);
        for (i = 1 - p; i < p; i++)
            for (j = 1 - p; j < p; j++)
                for (k = 1 - p; k < p; k++) {
                    KIFMM__R_(SC, _eval)(c->param, h * i - 2.0 * r * d[0], h * j - 2.0 * r * d[1],
                                 h * k - 2.0 * r * d[2], kv);
                    bad |= !(fabs(kv[0]) <= DBL_MAX);
                    big = fabs(sigma * kv[0]) > big ? fabs(sigma * kv[0]) : big;
                    g[((i + n) % n * n + (j + n) % n) * n + (k + n) % n] = sigma * kv[0];
                }
        kifmm__fft_grid(pl, g, kt + (size_t)tv * 2 * pl->nfp, g + (size_t)n * n * n);
    }
    /* each frequency f writes its own row of khat */
    KIFMM__OMP(parallel for schedule(static) num_threads(c->nthreads))
    for (int32_t f = 0; f < pl->nfp; f++)
        for (int t = 0; t < KIFMM__NT; t++) {
            o->khat[((size_t)f * KIFMM__NT + t) * 2] = kt[(size_t)t * 2 * pl->nfp + 2 * f];
            o->khat[((size_t)f * KIFMM__NT + t) * 2 + 1] = kt[(size_t)t * 2 * pl->nfp + 2 * f + 1];
        }
    kifmm__free(kall);
    /* The M2L's kernel values reach those at the nearest lattice points of
     * well separated boxes (1.9 r apart), sigma is scaled to those of the
     * solves' surfaces (3.45 r): for a Yukawa kernel their ratio is
     * exp(1.55 lambda r), which passes the range of float spectra (float
     * instances) beyond lambda r = 45. The level's M2L is then left out: it
     * carries interactions at 1.9 r and more, where that kernel is below
     * exp(-85) / (4 pi r), under float's normal range for r >= 1e-2. Double
     * spectra would need lambda r > 445, past the point where the level's
     * surfaces already drop it (build_c2e). */
    if (big > (pl->single ? 1e30 : 1e300)) memset(o->khat, 0, sizeof(double) * nk);
    return bad ? KIFMM_ERR_KERNEL : KIFMM_SUCCESS;
}
#else
/* The dense M2L for boxes of half-width r: per transfer vector t, the
 * source box's upward equivalent density (centre 2 r t) -> the target box's
 * downward check potential, times sigma and times ut_dn (the first factor
 * of the downward solve): m2l = [ut_dn K_1 ... ut_dn K_316], kd x 316 ne.
 * Assembled CH transfer vectors at a time (in parallel), then one GEMM. */
KIFMM__FN int KIFMM__F(__build_m2l_dense)(const KIFMM_NAME *c, double r, kifmm__ops *o)
{
    enum { CH = 16 };
    const double zero[3] = {0.0, 0.0, 0.0};
    const int nc = c->nc, ne = c->ne;
    double *kall = (double *)kifmm__alloc((size_t)nc * CH * ne, sizeof(double));
    int bad = 0;
    o->m2l = (double *)kifmm__alloc((size_t)o->kd * KIFMM__NT * ne, sizeof(double));
    if (!o->m2l || !kall) {
        kifmm__free(kall);
        return KIFMM_ERR_NOMEM;
    }
    for (int tv = 0; tv < KIFMM__NT && !bad; tv += CH) {
        const int nch = KIFMM__NT - tv < (int)CH ? KIFMM__NT - tv : (int)CH;
        /* each k fills its own block of kall */
        KIFMM__OMP(parallel for schedule(dynamic, 1) num_threads(c->nthreads) reduction(| : bad))
        for (int k = 0; k < nch; k++) {
            int d[3] = {0, 0, 0};
            double cs[3];
            kifmm__transfer_vector(tv + k, d);
            cs[0] = 2.0 * r * d[0];
            cs[1] = 2.0 * r * d[1];
            cs[2] = 2.0 * r * d[2];
            bad |= KIFMM__F(__surf_kmat)(c, c->surf_c, c->nsc, zero, KIFMM__ALPHA_INNER * r,
                                         c->surf_e, c->nse, cs, KIFMM__ALPHA_INNER * r,
                                         o->sigma, kall + (size_t)k * nc * ne, (size_t)nc,
                                         NULL) != KIFMM_SUCCESS;
        }
        kifmm__gemm(0, 0, o->kd, nch * ne, nc, 1.0, o->ut_dn, o->kd, kall, nc, 0.0,
                    o->m2l + (size_t)tv * ne * o->kd, o->kd);
    }
    kifmm__free(kall);
    return bad ? KIFMM_ERR_KERNEL : KIFMM_SUCCESS;
}
#endif

/* The operators for target boxes of half-width r (see kifmm__ops), in
 * double, in the order of the method; the M2L's only if m2l (a level that
 * has boxes with V lists). */
KIFMM__FN int KIFMM__F(__ops_build)(const KIFMM_NAME *c, double r, int m2l, kifmm__ops *o)
{
    int rc = KIFMM__F(__build_c2e)(c, r, o);
    if (!rc) rc = KIFMM__F(__build_m2m_l2l)(c, r, o);
#if KIFMM__FFT
    if (!rc && m2l) rc = KIFMM__F(__build_conv)(c, r, o);
    if (!rc && m2l) rc = KIFMM__F(__build_m2l_fft)(c, r, o);
#else
    if (!rc && m2l) rc = KIFMM__F(__build_m2l_dense)(c, r, o);
#endif
    return rc;
}

/* Build one level's operators in double and keep them in the instance's
 * precision. */
KIFMM__FN int KIFMM__F(__ops_make)(const KIFMM_NAME *c, double r, int m2l,
                                   KIFMM__F(__ops) *out)
{
    kifmm__ops o;
    size_t ne = (size_t)c->ne, nc = (size_t)c->nc;
    int rc;
    memset(&o, 0, sizeof o);
    rc = KIFMM__F(__ops_build)(c, r, m2l, &o);
    if (!rc) {
        out->sigma = o.sigma;
        out->ku = o.ku;
        out->kd = o.kd;
        out->ut_up = KIFMM__F(__own)(&o.ut_up, (size_t)o.ku * nc);
        out->vs_up = KIFMM__F(__own)(&o.vs_up, ne * (size_t)o.ku);
        out->ut_dn = KIFMM__F(__own)(&o.ut_dn, (size_t)o.kd * nc);
        out->vs_dn = KIFMM__F(__own)(&o.vs_dn, ne * (size_t)o.kd);
        out->m2m = KIFMM__F(__own)(&o.m2m, nc * 8 * ne);
        out->l2l = KIFMM__F(__own)(&o.l2l, 8 * nc * ne);
#if KIFMM__FFT
        if (o.conv) {
            out->conv = KIFMM__F(__own)(&o.conv, nc * ne);
            if (!out->conv) rc = KIFMM_ERR_NOMEM;
        }
        out->khat = o.khat;
        o.khat = NULL;
#else
        if (o.m2l) {
            out->m2l = KIFMM__F(__own)(&o.m2l, (size_t)o.kd * KIFMM__NT * ne);
            if (!out->m2l) rc = KIFMM_ERR_NOMEM;
        }
#endif
        if (!out->ut_up || !out->vs_up || !out->ut_dn || !out->vs_dn || !out->m2m ||
            !out->l2l)
            rc = KIFMM_ERR_NOMEM;
    }
    kifmm__ops_free(&o);
    return rc;
}

KIFMM__FN void KIFMM__F(__ops_free)(KIFMM__F(__ops) *o)
{
    kifmm__free(o->ut_up); kifmm__free(o->vs_up);
    kifmm__free(o->ut_dn); kifmm__free(o->vs_dn);
    kifmm__free(o->m2m); kifmm__free(o->l2l); kifmm__free(o->m2l);
    kifmm__free(o->conv); kifmm__free(o->khat); kifmm__free(o->kb);
    memset(o, 0, sizeof *o);
}

/* Scale-invariant kernels: one set at half-width 1, rescaled per level.
 * Others: one set per level that uses operators (levels 2 and deeper).
 * Only what the tree uses: none for a tree of fewer than 3 levels (a direct
 * sum), and the M2L's only for levels with boxes that have V lists. */
KIFMM__FN int KIFMM__F(__precompute)(KIFMM_NAME *c)
{
    const kifmm__tree *t = &c->tree;
    int l, rc, any = 0;
    c->nops = KIFMM__SI ? 1 : t->nlev;
    c->ops = (KIFMM__F(__ops) *)kifmm__calloc((size_t)c->nops, sizeof(KIFMM__F(__ops)));
    if (!c->ops) return KIFMM_ERR_NOMEM;
    for (l = 2; l < t->nlev; l++) any |= t->m2lo[l + 1] > t->m2lo[l];
    if (KIFMM__SI) {
        if (t->nlev > 2 && (rc = KIFMM__F(__ops_make)(c, 1.0, any, &c->ops[0]))) return rc;
    } else {
        for (l = 2; l < t->nlev; l++) {
            double half = 0.5 * t->width / (double)((int64_t)1 << l);
            if ((rc = KIFMM__F(__ops_make)(c, half, t->m2lo[l + 1] > t->m2lo[l], &c->ops[l])))
                return rc;
        }
    }
#if KIFMM__FFT
    {
        /* the products' blocks of every chunk, built once when all of them fit in
         * KIFMM__FFT_KB_MB (float spectra, one set of operators: 5.6 MiB at p = 4,
         * 16 MiB at p = 6) or take no more than one expansion array of the handle
         * (double spectra at p = 8: 72 MiB, kept from about 1M points on);
         * otherwise the products build each chunk's blocks once per slab */
        const kifmm__fft *pl = &c->fft;
        const size_t esz = pl->single ? sizeof(float) : sizeof(double);
        const size_t per = (size_t)27 * 128 * KIFMM__FFT_F * esz, all = per * (size_t)pl->nchunk;
        int tvm[27 * 64], n = 0;
        const size_t one = (size_t)c->tree.nbox * (size_t)c->ne * sizeof(KIFMM__R);
        for (l = 0; l < c->nops; l++) n += c->ops[l].khat != NULL;
        if (n > 0 && (all * (size_t)n <= (size_t)KIFMM__FFT_KB_MB << 20 || all * (size_t)n <= one)) {
            kifmm__fft_tvmap(tvm);
            for (l = 0; l < c->nops; l++) {
                KIFMM__F(__ops) *o = &c->ops[l];
                if (!o->khat) continue;
                o->kb = kifmm__alloc(all, 1);
                if (!o->kb) return KIFMM_ERR_NOMEM;
                KIFMM__OMP(parallel for schedule(static) num_threads(c->nthreads))
                for (int ch = 0; ch < pl->nchunk; ch++)
                    kifmm__fft_blocks(pl, o->khat, tvm, ch, (char *)o->kb + per * (size_t)ch);
            }
        }
    }
#endif
    return KIFMM_SUCCESS;
}

KIFMM__FN const KIFMM__F(__ops) *KIFMM__F(__ops_at)(const KIFMM_NAME *c, int l)
{
    return KIFMM__SI ? &c->ops[0] : &c->ops[l];
}

/* Factor multiplying check potentials computed directly from points at
 * level l: the level's sigma (see build_c2e), times (half-width)^(-degree)
 * for a scale-invariant kernel, whose operators are built once at
 * half-width 1. */
KIFMM__FN double KIFMM__F(__level_scale)(const KIFMM_NAME *c, int l)
{
    double half = 0.5 * c->tree.width / (double)((int64_t)1 << l);
    return KIFMM__SI ? pow(half, -c->degree) * c->ops[0].sigma
                                      : c->ops[l].sigma;
}

/* ---- workspace -------------------------------------------------------------- */

KIFMM__FN void KIFMM__F(__work_free)(KIFMM__F(__work) *w)
{
    if (!w) return;
    kifmm__free(w->ue); kifmm__free(w->de); kifmm__free(w->chk); kifmm__free(w->tmp);
    kifmm__free(w->stack); kifmm__free(w->m2l_out); kifmm__free(w->qs); kifmm__free(w->outs);
    kifmm__free(w->lbuf);
    kifmm__free(w);
}

/* Per-vector sizes of the workspace arrays, in elements. */
KIFMM__FN void KIFMM__F(__work_sizes)(const KIFMM_NAME *c, size_t *sz)
{
    size_t big = (size_t)(c->nc > c->ne ? c->nc : c->ne);
    sz[0] = (size_t)c->tree.nbox * (size_t)c->ne;                  /* ue, de */
    sz[1] = (size_t)c->mb * (size_t)c->nc;                         /* chk */
#if KIFMM__FFT
    sz[2] = 0;
    (void)big;
#else
    sz[2] = (size_t)c->mb * big; /* tmp: the first solve step and the dense M2L, a level */
#endif
    sz[3] = (size_t)c->tree.ns * KIFMM__QD;                        /* qs */
    sz[4] = (size_t)c->tree.nt * KIFMM__TD;                        /* outs */
}

/* Values per thread of the task output buffers for up to nrhs vectors: the
 * targets of a leaf, of a box with X sources evaluated directly (fewer than
 * nsc) and of a chunk of the mutual near field, a multiple of 16 (64-byte
 * parts for double); 0 when all threads' parts would take more than half
 * of the sorted output array. */
KIFMM__FN size_t KIFMM__F(__lbuf_per)(const KIFMM_NAME *c, int nrhs)
{
    const kifmm__tree *t = &c->tree;
    int64_t m = c->nsc, all = t->nt * (int64_t)nrhs * KIFMM__TD;
    int32_t i;
    for (i = 0; i < t->nleaves; i++)
        if (t->t1[t->leaves[i]] - t->t0[t->leaves[i]] > m)
            m = t->t1[t->leaves[i]] - t->t0[t->leaves[i]];
    for (i = 0; c->pchunk && i < c->npchunk; i++) {
        const int32_t i0 = c->pchunk[i], i1 = c->pchunk[i + 1];
        const int64_t lo = i0 < t->nleaves ? t->t0[t->leaves[i0]] : t->nt;
        const int64_t hi = i1 < t->nleaves ? t->t0[t->leaves[i1]] : t->nt;
        if (hi - lo > m) m = hi - lo;
    }
    m = (m * (int64_t)nrhs * KIFMM__TD + 15) / 16 * 16;
    return 2 * (int64_t)c->nthreads * m <= all ? (size_t)m : 0;
}

/* out[r dst + tperm[t0 + i] TD + k] += b[r ld + i TD + k]: a task's sums for
 * its n targets from sorted position t0 on, added to the caller's outputs. */
KIFMM__FN void KIFMM__F(__put)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs,
                               int64_t t0, int64_t n, const KIFMM__R *b, size_t ld)
{
    const kifmm__tree *t = &c->tree;
    const size_t oper = (size_t)t->nt * KIFMM__TD;
    int64_t i;
    int r, k;
    for (r = 0; r < nrhs; r++)
        for (i = 0; i < n; i++) {
            KIFMM__R *d = w->dst + r * oper + (size_t)t->tperm[t0 + i] * KIFMM__TD;
            const KIFMM__R *s = b + r * ld + (size_t)i * KIFMM__TD;
            for (k = 0; k < KIFMM__TD; k++) d[k] += s[k];
        }
}

/* The calling thread's task output buffer, zeroed for nrhs x n targets. */
KIFMM__FN KIFMM__R *KIFMM__F(__lbuf)(const KIFMM__F(__work) *w, int nrhs, int64_t n)
{
#ifdef _OPENMP
    KIFMM__R *b = w->lbuf + (size_t)omp_get_thread_num() * w->lbuf_per;
#else
    KIFMM__R *b = w->lbuf;
#endif
    memset(b, 0, (size_t)nrhs * (size_t)n * KIFMM__TD * sizeof(KIFMM__R));
    return b;
}

KIFMM__FN KIFMM__F(__work) *KIFMM__F(__work_new)(const KIFMM_NAME *c, int nrhs)
{
    KIFMM__F(__work) *w = (KIFMM__F(__work) *)kifmm__calloc(1, sizeof *w);
    size_t sz[5], n = (size_t)nrhs, big = (size_t)(c->nc > c->ne ? c->nc : c->ne);
    if (!w) return NULL;
    KIFMM__F(__work_sizes)(c, sz);
    w->nrhs = nrhs;
    w->ue = (KIFMM__R *)kifmm__alloc(n * sz[0], sizeof(KIFMM__R));
    w->de = (KIFMM__R *)kifmm__alloc(n * sz[0], sizeof(KIFMM__R));
    w->chk = (KIFMM__R *)kifmm__alloc(n * sz[1], sizeof(KIFMM__R));
#if KIFMM__FFT
    (void)big;
#else
    w->tmp = (KIFMM__R *)kifmm__alloc(n * sz[2], sizeof(KIFMM__R));
    w->stack = (KIFMM__R *)kifmm__alloc((size_t)c->m2l_cols * KIFMM__NT * (size_t)c->ne,
                                        sizeof(KIFMM__R));
    w->m2l_out = (KIFMM__R *)kifmm__alloc((size_t)c->m2l_cols * big, sizeof(KIFMM__R));
    if (!w->tmp || !w->stack || !w->m2l_out) {
        KIFMM__F(__work_free)(w);
        return NULL;
    }
#endif
    w->qs = (KIFMM__R *)kifmm__alloc(n * sz[3], sizeof(KIFMM__R));
    w->lbuf_per = KIFMM__F(__lbuf_per)(c, nrhs);
    if (w->lbuf_per) w->lbuf = (KIFMM__R *)kifmm__alloc((size_t)c->nthreads * w->lbuf_per,
                                                        sizeof(KIFMM__R));
    else w->outs = (KIFMM__R *)kifmm__alloc(n * sz[4], sizeof(KIFMM__R));
    if (!w->ue || !w->de || !w->chk || !w->qs || (!w->outs && !w->lbuf)) {
        KIFMM__F(__work_free)(w);
        return NULL;
    }
    {
        /* the solves skip boxes without sources (ue) or targets (de): their
         * expansions are zero once and for all */
        const kifmm__tree *t = &c->tree;
        int32_t b;
        int r;
        for (r = 0; r < nrhs; r++)
            for (b = 0; b < t->nbox; b++) {
                const size_t at = (size_t)r * sz[0] + (size_t)b * c->ne;
                if (t->s1[b] == t->s0[b]) memset(w->ue + at, 0, (size_t)c->ne * sizeof(KIFMM__R));
                if (t->t1[b] == t->t0[b]) memset(w->de + at, 0, (size_t)c->ne * sizeof(KIFMM__R));
            }
    }
    return w;
}

/* Values per buffer of the column GEMM passes: the solve's intermediate
 * (ne x KIFMM__GC_NC), and without AVX2 the gather workspace of the largest
 * product ((k + m) x KIFMM__GC_NC, k + m <= 9 max(nc, ne)). One buffer per
 * thread with AVX2 (the passes run in parallel), else one. */
KIFMM__FN size_t KIFMM__F(__gbuf_per)(const KIFMM_NAME *c)
{
    const size_t big = (size_t)(c->nc > c->ne ? c->nc : c->ne);
    return ((size_t)c->ne + (KIFMM__GC_FAST ? 0 : 9 * big)) * KIFMM__GC_NC;
}

/* The calling thread's buffer (thread 0 outside parallel regions). */
KIFMM__FN KIFMM__R *KIFMM__F(__gbuf)(const KIFMM_NAME *c)
{
#ifdef _OPENMP
    return c->gbuf + (size_t)omp_get_thread_num() * KIFMM__F(__gbuf_per)(c);
#else
    return c->gbuf;
#endif
}

/* Values per thread of the scratch: three surfaces of max(nsc, nse)
 * points, then (float instances) a frame of c->fpts points. */
KIFMM__FN size_t KIFMM__F(__scratch_per)(const KIFMM_NAME *c)
{
    return 9 * (size_t)(c->nsc > c->nse ? c->nsc : c->nse) + 3 * c->fpts;
}

/* The calling thread's scratch (see __scratch_per). */
KIFMM__FN KIFMM__R *KIFMM__F(__scratch)(const KIFMM_NAME *c)
{
    return c->scratch + (size_t)kifmm__thread_num() * KIFMM__F(__scratch_per)(c);
}

/* The calling thread's frame buffer: after its three surfaces. */
KIFMM__FN KIFMM__R *KIFMM__F(__framebuf)(const KIFMM_NAME *c)
{
    return KIFMM__F(__scratch)(c) + 9 * (size_t)(c->nsc > c->nse ? c->nsc : c->nse);
}

/* The n points of a sorted set from position p0 on (structure of arrays,
 * *ld values per coordinate) in a frame centred at fc. Float instances
 * shift them in double and round them into buf (3 n values, *ld becomes n):
 * coordinates relative to the root keep float's digits of the root's size,
 * and a surface placed next to points of a box 1e-4 of the root wide would be
 * off by 1e-4 of the box; in the box's own frame both keep the digits of its
 * size. Double instances use the points in place, in the frame centred at
 * the origin (fc is zeroed). Surfaces are then placed at (centre - fc). */
KIFMM__FN const KIFMM__R *KIFMM__F(__frame)(const KIFMM__R *pts, size_t *ld, int64_t p0,
                                           int64_t n, double *fc, KIFMM__R *buf)
{
#if KIFMM__FLOAT
    int64_t i;
    int d;
    for (d = 0; d < 3; d++)
        for (i = 0; i < n; i++)
            buf[(size_t)d * n + i] = (KIFMM__R)((double)pts[(size_t)d * *ld + p0 + i] - fc[d]);
    *ld = (size_t)n;
    return buf;
#else
    (void)ld;
    (void)n;
    (void)buf;
    fc[0] = fc[1] = fc[2] = 0.0;
    return pts + p0;
#endif
}

/* Bytes held by a handle, counted from the sizes it allocated. */
KIFMM__FN double KIFMM__F(__bytes)(const KIFMM_NAME *c)
{
    const kifmm__tree *t = &c->tree;
    const double R = (double)sizeof(KIFMM__R), ne = c->ne, nc = c->nc;
    double b = 0.0, big = nc > ne ? nc : ne, ns = c->nsc > c->nse ? c->nsc : c->nse;
    size_t sz[5];
    int i;
    b += (double)t->ns * (3 * R + 8) + (t->same ? 0.0 : (double)t->nt * (3 * R + 8));
    b += (double)t->nbox * (8 + 4 * 4 + 4 * 8 + 5 * 4 + 1);
    b += 4.0 * (t->uo[t->nbox] + t->wo[t->nbox] + t->xo[t->nbox]);
    b += 4.0 * (c->pchunk ? c->npchunk + 1 : 0);
    b += 4.0 * (2.0 * t->nbox + 2.0 * t->nlev);
    if (t->v) b += 6.0 * t->vo[t->nbox];
    for (i = 0; i < c->nops; i++) {
        const KIFMM__F(__ops) *o = &c->ops[i];
        if (!o->ut_up) continue;
        b += R * ((o->ku + o->kd) * (nc + ne) + 16 * nc * ne);
        b += R * (double)o->kd * KIFMM__NT * ne * (o->m2l != NULL);
        b += R * nc * ne * (o->conv != NULL) + 8.0 * KIFMM__NT * 2 * c->fft.nfp * (o->khat != NULL);
        b += (o->kb != NULL) * 27.0 * 128 * KIFMM__FFT_F * (c->fft.single ? 4 : 8) * c->fft.nchunk;
    }
    if (c->w) {
        KIFMM__F(__work_sizes)(c, sz);
        b += R * c->w->nrhs * (2.0 * sz[0] + sz[1] + sz[2] + sz[3]);
        b += R * (c->w->lbuf ? (double)c->nthreads * c->w->lbuf_per : (double)c->w->nrhs * sz[4]);
#if KIFMM__FFT
        (void)big;
#else
        b += R * (double)c->m2l_cols * (KIFMM__NT * ne + big);
#endif
    }
#if KIFMM__FFT
    if (c->spec) {
        b += (c->fft.single ? 4.0 : 8.0) * 16 * c->fft.nfp * c->slots * (1 + (c->fout != NULL)) +
             8.0 * c->nthreads * c->fbuf_per;
        b += 8.0 * c->fft_m + 4.0 * c->fft_mc + 9.0 * c->slots;
        b += 4.0 * (t->ioff[t->nlev] + 1) + 5.0 * (26.0 * t->ioff[t->nlev] + 1); /* co, cj, cc */
    }
#endif
    b += R * c->nthreads * (double)KIFMM__F(__scratch_per)(c);
    (void)ns;
    b += R * (double)c->gbuf_n;
    return b;
}



/* ---- the level passes ------------------------------------------------------- */

/* Layout of the per-level arrays chk and tmp: vector r, box b of level l, with
 * `rows` entries per box: [(r * n_l + (b - loff[l])) * rows]. */
#define KIFMM__LVL(c, l) ((c)->tree.loff[(l) + 1] - (c)->tree.loff[(l)])

/* Check vectors -> equivalent densities for every box of level l: per piece
 * of KIFMM__GC_NC columns (box x vector; chk holds them in that order),
 * t = ut chk into the thread's own buffer, then equiv = vs t (the two
 * factors of the pseudo-inverse, one after the other). */
KIFMM__FN void KIFMM__F(__solve)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs, int l,
                                 int up)
{
    const kifmm__tree *t = &c->tree;
    const KIFMM__F(__ops) *o = KIFMM__F(__ops_at)(c, l);
    const int n = KIFMM__LVL(c, l), k = up ? o->ku : o->kd;
    const int32_t *ai = c->act + (up ? 0 : t->nbox) + t->loff[l];
    const int na = c->act[2 * t->nbox + 2 * l + !up];
    const int ppv = (na + KIFMM__GC_NC - 1) / KIFMM__GC_NC, np = ppv * nrhs;
    const size_t per = (size_t)t->nbox * (size_t)c->ne;
    KIFMM__R *eq = up ? w->ue : w->de;
    KIFMM__OMP(parallel for schedule(dynamic, 1) num_threads(c->nthreads) if (KIFMM__GC_FAST))
    for (int p = 0; p < np; p++) {
        /* pieces of one vector each, cut as for evaluate: without AVX2 each is a
         * BLAS call, whose result for a column can depend on the call's other
         * columns, and the float FFT spectra turn last-bit differences into
         * float rounding ones between evaluate_many and evaluate */
        const KIFMM__R *bp[KIFMM__GC_NC], *tb[KIFMM__GC_NC];
        KIFMM__R *tp[KIFMM__GC_NC], *cp[KIFMM__GC_NC];
        KIFMM__R *buf = KIFMM__F(__gbuf)(c);
        const size_t per_t = (size_t)c->ne * KIFMM__GC_NC;
        const int r = p / ppv, j0 = (p % ppv) * KIFMM__GC_NC;
        int q, nq = na - j0;
        if (nq > KIFMM__GC_NC) nq = KIFMM__GC_NC;
        for (q = 0; q < nq; q++) {
            const size_t b = (size_t)ai[j0 + q]; /* within the level */
            bp[q] = w->chk + ((size_t)r * n + b) * c->nc;
            tb[q] = tp[q] = buf + (size_t)q * k;
            cp[q] = eq + (size_t)r * per + ((size_t)t->loff[l] + b) * c->ne;
        }
        KIFMM__GEMM_COLS(k, c->nc, up ? o->ut_up : o->ut_dn, k, nq, bp, tp, 0, buf + per_t);
        KIFMM__GEMM_COLS(c->ne, k, up ? o->vs_up : o->vs_dn, c->ne, nq, tb, cp, 0, buf + per_t);
    }
}

#if !KIFMM__FFT
/* The downward solve around the dense M2L, which adds its results between
 * the two factors (its matrices include ut_dn): step 0, tmp = ut chk (one GEMM
 * over boxes and vectors); step 1, equiv = vs tmp. */
KIFMM__FN void KIFMM__F(__solve_step)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs,
                                      int l, int up, int step)
{
    const kifmm__tree *t = &c->tree;
    const KIFMM__F(__ops) *o = KIFMM__F(__ops_at)(c, l);
    int n = KIFMM__LVL(c, l), k = up ? o->ku : o->kd, r;
    size_t per = (size_t)t->nbox * (size_t)c->ne;
    if (step == 0) {
        KIFMM__F(__gemm)(k, n * nrhs, c->nc, up ? o->ut_up : o->ut_dn, k, w->chk, c->nc, 0, w->tmp,
                         k);
        return;
    }
    for (r = 0; r < nrhs; r++)
        KIFMM__F(__gemm)(c->ne, n, k, up ? o->vs_up : o->vs_dn, c->ne,
                         w->tmp + (size_t)r * n * k, k, 0,
                         (up ? w->ue : w->de) + r * per + (size_t)t->loff[l] * c->ne, c->ne);
}
#endif

/* Between the internal boxes of level lp and their children, whose boxes are
 * 8j..8j+7 of level lp + 1 for the j-th internal box: M2M (down = 0) adds
 * the children's equivalent densities, one column of 8 ne values, to the
 * parent's check vector; L2L (down = 1) sets the children's check vectors,
 * one column of 8 nc values, from the parent's equivalent density. Columns
 * (box x vector) in pieces of KIFMM__GC_NC over the threads. */
KIFMM__FN void KIFMM__F(__family_level)(const KIFMM_NAME *c, const KIFMM__F(__work) *w,
                                        int nrhs, int lp, int down)
{
    const kifmm__tree *t = &c->tree;
    const int ni = t->ioff[lp + 1] - t->ioff[lp], n = KIFMM__LVL(c, lp + down);
    const int ppv = (ni + KIFMM__GC_NC - 1) / KIFMM__GC_NC, np = ppv * nrhs;
    const int m = down ? 8 * c->nc : c->nc, k = down ? c->ne : 8 * c->ne;
    const size_t per = (size_t)t->nbox * (size_t)c->ne;
    const KIFMM__R *op = down ? KIFMM__F(__ops_at)(c, lp + 1)->l2l : KIFMM__F(__ops_at)(c, lp)->m2m;
    if (ni == 0 || lp + 1 >= t->nlev) return;
    KIFMM__OMP(parallel for schedule(dynamic, 1) num_threads(c->nthreads) if (KIFMM__GC_FAST))
    for (int p = 0; p < np; p++) {
        const KIFMM__R *bp[KIFMM__GC_NC];
        KIFMM__R *cp[KIFMM__GC_NC];
        const int jr = p / ppv, j0 = (p % ppv) * KIFMM__GC_NC; /* as in __solve */
        int q, nq = ni - j0;
        if (nq > KIFMM__GC_NC) nq = KIFMM__GC_NC;
        for (q = 0; q < nq; q++) {
            const int jb = j0 + q;
            const int32_t b = t->inner[t->ioff[lp] + jb];
            if (down) {
                bp[q] = w->de + jr * per + (size_t)b * c->ne;
                cp[q] = w->chk + ((size_t)jr * n + 8 * (size_t)jb) * c->nc;
            } else {
                bp[q] = w->ue + jr * per + ((size_t)t->loff[lp + 1] + 8 * (size_t)jb) * c->ne;
                cp[q] = w->chk + ((size_t)jr * n + (size_t)(b - t->loff[lp])) * c->nc;
            }
        }
        KIFMM__GEMM_COLS(m, k, op, m, nq, bp, cp, !down,
                         KIFMM__F(__gbuf)(c) + (size_t)c->ne * KIFMM__GC_NC);
    }
}

/* M2L into level l: per block of (target box, vector) columns, stack the
 * multipoles of the target's V list by transfer vector (zeros elsewhere) and
 * multiply by the 316 matrices side by side in one GEMM. The matrices include
 * the first factor of the downward solve (ut_dn K_t), so the results are added
 * to the level's tmp (kd rows) between the two solve steps. No target is
 * written by two threads. */
#if !KIFMM__FFT
KIFMM__FN void KIFMM__F(__m2l_level)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs,
                                     int l)
{
    const kifmm__tree *t = &c->tree;
    const KIFMM__F(__ops) *o = KIFMM__F(__ops_at)(c, l);
    int32_t n = t->m2lo[l + 1] - t->m2lo[l], b0, blk = c->m2l_cols / nrhs;
    int nl = KIFMM__LVL(c, l);
    size_t col = (size_t)KIFMM__NT * c->ne, per = (size_t)t->nbox * (size_t)c->ne;
    if (blk < 1) blk = 1;
    for (b0 = 0; b0 < n; b0 += blk) {
        int32_t nb = n - b0 < blk ? n - b0 : blk;
        KIFMM__OMP(parallel for schedule(dynamic, 4) num_threads(c->nthreads))
        for (int32_t j = 0; j < nb * nrhs; j++) {
            int32_t b = t->m2l[t->m2lo[l] + b0 + j / nrhs], e;
            const KIFMM__R *ue = w->ue + (size_t)(j % nrhs) * per;
            KIFMM__R *st = w->stack + (size_t)j * col;
            memset(st, 0, col * sizeof(KIFMM__R));
            for (e = t->vo[b]; e < t->vo[b + 1]; e++)
                memcpy(st + (size_t)t->vt[e] * c->ne, ue + (size_t)t->v[e] * c->ne,
                       (size_t)c->ne * sizeof(KIFMM__R));
        }
        KIFMM__F(__gemm)(o->kd, nb * nrhs, (int)col, o->m2l, o->kd, w->stack, (int)col, 0,
                         w->m2l_out, o->kd);
        KIFMM__OMP(parallel for schedule(static) num_threads(c->nthreads))
        for (int32_t j = 0; j < nb * nrhs; j++) {
            int32_t b = t->m2l[t->m2lo[l] + b0 + j / nrhs];
            KIFMM__R *dst = w->tmp + ((size_t)(j % nrhs) * nl + (size_t)(b - t->loff[l])) * o->kd;
            const KIFMM__R *s = w->m2l_out + (size_t)j * o->kd;
            int i;
            for (i = 0; i < o->kd; i++) dst[i] += s[i];
        }
    }
}
#endif

#if KIFMM__FFT
/* The calling thread's FFT buffers: blocks, products, transform work, one
 * density in double. */
KIFMM__FN double *KIFMM__F(__fbuf)(const KIFMM_NAME *c)
{
#ifdef _OPENMP
    return c->fbuf + (size_t)omp_get_thread_num() * c->fbuf_per;
#else
    return c->fbuf;
#endif
}

/* The densities of 8 multipoles u_v (ne values each, consecutive) on the
 * check-order lattice: m[i 8 + v] = sum_j conv[j nc + i] u_v[j] (conv NULL:
 * the identity). */
KIFMM__FN void KIFMM__F(__conv8)(const KIFMM__R *conv, int nc, int ne, const KIFMM__R *u,
                                 double *m)
{
    int i, j, v;
    if (!conv) {
        /* the identity (nc = ne): interleave the 8 densities */
        for (i = 0; i < nc; i++)
            for (v = 0; v < 8; v++) m[8 * i + v] = (double)u[(size_t)v * ne + i];
        return;
    }
#if defined(__AVX2__) && defined(__FMA__)
    for (i = 0; i < 8 * nc; i++) m[i] = 0.0;
    for (j = 0; j < ne; j += 4) {
        /* four columns of conv per sweep over m; the 8 lanes in two registers */
        const int nj = ne - j < 4 ? ne - j : 4;
        __m256d ua[4], ub[4];
        const KIFMM__R *cj[4];
        double t[8];
        int a;
        for (a = 0; a < 4; a++) {
            for (v = 0; v < 8; v++) t[v] = a < nj ? (double)u[(size_t)v * ne + j + a] : 0.0;
            ua[a] = _mm256_loadu_pd(t);
            ub[a] = _mm256_loadu_pd(t + 4);
            cj[a] = conv + (size_t)(a < nj ? j + a : j) * nc;
        }
        for (i = 0; i < nc; i++) {
            __m256d x = _mm256_loadu_pd(m + 8 * i), y = _mm256_loadu_pd(m + 8 * i + 4);
            for (a = 0; a < 4; a++) {
                const __m256d c = _mm256_set1_pd((double)cj[a][i]);
                x = _mm256_fmadd_pd(c, ua[a], x);
                y = _mm256_fmadd_pd(c, ub[a], y);
            }
            _mm256_storeu_pd(m + 8 * i, x);
            _mm256_storeu_pd(m + 8 * i + 4, y);
        }
    }
#else
    for (i = 0; i < 8 * nc; i++) m[i] = 0.0;
    for (j = 0; j < ne; j++)
        for (v = 0; v < 8; v++) {
            const double uj = (double)u[(size_t)v * ne + j];
            for (i = 0; i < nc; i++) m[8 * i + v] += (double)conv[(size_t)j * nc + i] * uj;
        }
#endif
}

/* Does any child of the j-th internal box of level l - 1 receive M2L? */
KIFMM__FN int KIFMM__F(__fft_wanted)(const kifmm__tree *t, int l, int32_t j)
{
    int32_t b = t->loff[l] + 8 * j, c;
    for (c = 0; c < 8; c++)
        if (t->vo[b + c + 1] > t->vo[b + c]) return 1;
    return 0;
}

/* The products of one target parent for frequency chunk ch (see
 * kifmm__fft_products): its nn source parents at slots nbr, offsets cc.
 * The spectra at chunk chx of the nx source parents at slots nxt (the next
 * target parent's) are prefetched meanwhile: they lie scattered over the
 * spectra buffer, out of reach of the hardware prefetchers. */
KIFMM__FN void KIFMM__F(__fft_products)(const KIFMM_NAME *c, int ch, const int32_t *nbr, int nn,
                                        const unsigned char *cc, const void *kb, void *out,
                                        int chx, const int32_t *nxt, int nx)
{
    const size_t at = (size_t)ch * (size_t)c->slots * KIFMM__FFT_F * 16;
    const size_t ax = (size_t)chx * (size_t)c->slots * KIFMM__FFT_F * 16;
    const size_t esz = c->fft.single ? sizeof(float) : sizeof(double);
    int e, q;
    for (e = 0; e < nx; e++) {
        const char *a = (const char *)c->spec + (ax + (size_t)nxt[e] * KIFMM__FFT_F * 16) * esz;
        for (q = 0; q < (int)(KIFMM__FFT_F * 16 * esz); q += 64) KIFMM__PREFETCH(a + q);
    }
    if (c->fft.single)
        kifmm__fft_products_f(nn, nbr, cc, c->sch, (const float *)c->spec + at, (const float *)kb,
                              (float *)out);
    else
        kifmm__fft_products(nn, nbr, cc, c->sch, (const double *)c->spec + at, (const double *)kb,
                            (double *)out);
}

/* The inverse transforms of the products of the j-th target parent of level
 * l - 1 (op: its first chunk, chunks ocs elements apart), added to the check
 * vectors chk of its children that have a V list. */
KIFMM__FN void KIFMM__F(__fft_finish)(const KIFMM_NAME *c, int l, int32_t j, const void *op,
                                      size_t ocs, double *work, KIFMM__R *chk)
{
    const kifmm__tree *t = &c->tree;
    double *dchk = work + kifmm__fft_work8(&c->fft);
    int q, i, nc = c->nc;
    if (c->fft.single) kifmm__fft_inverse8f(&c->fft, op, ocs, dchk, (float *)work);
    else kifmm__fft_inverse8(&c->fft, op, ocs, dchk, work);
    for (q = 0; q < 8; q++) {
        int32_t lb = 8 * j + q, box = t->loff[l] + lb;
        KIFMM__R *dst = chk + (size_t)lb * nc;
        if (t->vo[box + 1] == t->vo[box]) continue;
        for (i = 0; i < nc; i++) dst[i] += (KIFMM__R)dchk[8 * i + q];
    }
}

/* M2L into level l by FFT (see kifmm__fft): the level's multipoles
 * (children of the internal boxes of level l - 1) moved to the check
 * surface's lattice (conv) and transformed, products per target parent over
 * its internal colleagues, inverse transforms added to the downward check
 * vectors of the boxes with a V list, before the downward solve. Target
 * parents are processed in slabs whose source spectra fit the spectra buffer;
 * within a slab each target parent belongs to one task, so no output is
 * written by two threads. */
KIFMM__FN void KIFMM__F(__m2l_fft)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs,
                                   int l)
{
    const kifmm__tree *t = &c->tree;
    const kifmm__fft *pl = &c->fft;
    const KIFMM__F(__ops) *o = KIFMM__F(__ops_at)(c, l);
    const int32_t ni = t->ioff[l] - t->ioff[l - 1], base = t->ioff[l - 1];
    const int nl = KIFMM__LVL(c, l), ne = c->ne, nc = c->nc;
    const size_t cstride = (size_t)c->slots * KIFMM__FFT_F * 16, per = (size_t)t->nbox * ne;
    const size_t esz = pl->single ? sizeof(float) : sizeof(double); /* spectra, blocks */
    const size_t kbn = (size_t)27 * 128 * KIFMM__FFT_F * esz / sizeof(double); /* doubles */
    const size_t outn =
        ((size_t)pl->nfp * c->ftb * 16 * esz + sizeof(double) - 1) / sizeof(double);
    const int32_t *co = c->co, *cj = c->cj;
    int32_t *loc = c->loc, *need = c->need, *cjl = c->cjl, s0, s1, e, tb;
    size_t ocs;
    int tv[27 * 64], r;
    kifmm__fft_tvmap(tv);
    for (s0 = 0; s0 < ni; s0 = s1) {
        /* a slab of target parents [s0, s1) whose source parents fit */
        int32_t nneed = 0, nblk;
        for (s1 = s0; s1 < ni; s1++) {
            int32_t g = base + s1, add = 0;
            if (!o->kb && s1 - s0 >= c->slots) break; /* the outputs fit in fout */
            if (!KIFMM__F(__fft_wanted)(t, l, s1)) continue; /* no child has a V list */
            for (e = co[g]; e < co[g + 1]; e++) add += loc[cj[e]] < 0;
            if (s1 > s0 && nneed + add > c->slots) break;
            for (e = co[g]; e < co[g + 1]; e++) {
                if (loc[cj[e]] < 0) {
                    loc[cj[e]] = nneed;
                    need[nneed++] = cj[e];
                }
                cjl[e - co[base + s0]] = loc[cj[e]];
            }
        }
        /* target parents per task: up to ftb, but at least 4 tasks per thread */
        tb = (s1 - s0) / (4 * c->nthreads);
        tb = tb < 1 ? 1 : tb > c->ftb ? c->ftb : tb;
        ocs = (size_t)tb * KIFMM__FFT_F * 16; /* elements of esz */
        nblk = (s1 - s0 + tb - 1) / tb;
        for (r = 0; r < nrhs; r++) {
            const KIFMM__R *ue = w->ue + r * per + (size_t)t->loff[l] * ne;
            KIFMM__R *chk = w->chk + (size_t)r * nl * nc;
            KIFMM__OMP(parallel for schedule(static) num_threads(c->nthreads))
            for (int32_t b = 0; b < nneed; b++) {
                double *work = KIFMM__F(__fbuf)(c) + kbn + outn;
                double *m = work + kifmm__fft_work8(pl);
                const KIFMM__R *u = ue + (size_t)8 * need[b] * ne; /* the 8 children */
                const int32_t ch0 = t->loff[l] + 8 * need[b];
                unsigned char *h = c->sch + 9 * (size_t)b;
                int q;
                for (h[0] = 0, q = 0; q < 8; q++)
                    if (t->s1[ch0 + q] > t->s0[ch0 + q]) h[1 + h[0]++] = (unsigned char)q;
                KIFMM__F(__conv8)(o->conv, nc, ne, u, m);
                if (pl->single)
                    kifmm__fft_forward8f(pl, m, (char *)c->spec + (size_t)b * KIFMM__FFT_F * 16 * esz,
                                         cstride, (float *)work);
                else
                    kifmm__fft_forward8(pl, m, (char *)c->spec + (size_t)b * KIFMM__FFT_F * 16 * esz,
                                        cstride, work);
            }
            if (!o->kb) {
                /* blocks not kept: tasks over chunks, all target parents of the
                 * slab in each, so that each chunk's blocks are built once */
                const size_t fcs = (size_t)c->slots * KIFMM__FFT_F * 16; /* fout chunk */
                KIFMM__OMP(parallel for schedule(dynamic, 2) num_threads(c->nthreads))
                for (int ch = 0; ch < pl->nchunk; ch++) {
                    double *kb = KIFMM__F(__fbuf)(c);
                    int32_t P;
                    kifmm__fft_blocks(pl, o->khat, tv, ch, kb);
                    for (P = s0; P < s1; P++) {
                        /* (slots are set only for wanted target parents) */
                        const int32_t g = base + P;
                        const int32_t nx = P + 1 < s1 && KIFMM__F(__fft_wanted)(t, l, P + 1)
                                               ? co[g + 2] - co[g + 1]
                                               : 0;
                        if (KIFMM__F(__fft_wanted)(t, l, P))
                            KIFMM__F(__fft_products)(c, ch, cjl + (co[g] - co[base + s0]),
                                                     co[g + 1] - co[g], c->cc + co[g], kb,
                                                     (char *)c->fout + (ch * fcs + (size_t)(P - s0) *
                                                                        KIFMM__FFT_F * 16) * esz,
                                                     ch, cjl + (co[g + 1] - co[base + s0]), nx);
                    }
                }
                KIFMM__OMP(parallel for schedule(dynamic, 4) num_threads(c->nthreads))
                for (int32_t b = s0; b < s1; b++) {
                    double *work = KIFMM__F(__fbuf)(c) + kbn + outn;
                    if (KIFMM__F(__fft_wanted)(t, l, b))
                        KIFMM__F(__fft_finish)(c, l, b,
                                               (const char *)c->fout +
                                                   (size_t)(b - s0) * KIFMM__FFT_F * 16 * esz,
                                               fcs, work, chk);
                }
                continue;
            }
            KIFMM__OMP(parallel for schedule(dynamic, 1) num_threads(c->nthreads))
            for (int32_t blk = 0; blk < nblk; blk++) {
                double *kb = KIFMM__F(__fbuf)(c), *out = kb + kbn, *work = out + outn;
                int32_t p0 = s0 + blk * tb;
                int32_t nb = s1 - p0 < tb ? s1 - p0 : tb, P;
                int ch;
                for (ch = 0; ch < pl->nchunk; ch++) {
                    const double *kc = (const double *)o->kb + kbn * (size_t)ch;
                    for (P = 0; P < nb; P++) {
                        /* prefetched: the next target parent's sources, or
                         * after the last the first's at the next chunk */
                        const int32_t g = base + p0 + P, last = P + 1 == nb;
                        const int32_t gx = last ? base + p0 : g + 1;
                        const int chx = last ? ch + 1 : ch;
                        if (KIFMM__F(__fft_wanted)(t, l, p0 + P))
                            KIFMM__F(__fft_products)(c, ch, cjl + (co[g] - co[base + s0]),
                                                     co[g + 1] - co[g], c->cc + co[g], kc,
                                                     (char *)out + ((size_t)ch * ocs +
                                                                    (size_t)P * KIFMM__FFT_F * 16) *
                                                                       esz,
                                                     chx, cjl + (co[gx] - co[base + s0]),
                                                     chx < pl->nchunk &&
                                                             KIFMM__F(__fft_wanted)(t, l, gx - base)
                                                         ? co[gx + 1] - co[gx]
                                                         : 0);
                    }
                }
                for (P = 0; P < nb; P++)
                    if (KIFMM__F(__fft_wanted)(t, l, p0 + P))
                        KIFMM__F(__fft_finish)(c, l, p0 + P,
                                               (const char *)out + (size_t)P * KIFMM__FFT_F * 16 * esz,
                                               ocs, work, chk);
            }
        }
        for (e = 0; e < nneed; e++) loc[need[e]] = -1;
    }
}
#endif

/* ---- the evaluation passes, in pipeline order -------------------------- */

/* Upward pass at level l: P2M into the leaves' check vectors, M2M into the
 * internal boxes', then the solve for the equivalent densities. */
KIFMM__FN void KIFMM__F(__upward)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs, int l)
{
    const kifmm__tree *t = &c->tree;
    int nl = KIFMM__LVL(c, l);
    double scale = KIFMM__F(__level_scale)(c, l), t0 = kifmm__now(), t1;
    memset(w->chk, 0, (size_t)nl * nrhs * c->nc * sizeof(KIFMM__R));
    KIFMM__OMP(parallel for schedule(dynamic, 8) num_threads(c->nthreads))
    for (int32_t b = t->loff[l]; b < t->loff[l + 1]; b++) {
        const int64_t s0 = t->s0[b], ns = t->s1[b] - s0;
        KIFMM__R *pc = KIFMM__F(__scratch)(c);
        const KIFMM__R *xs;
        double ctr[3], fc[3], rc[3], half;
        size_t ld = (size_t)t->ns;
        if (t->child[b] >= 0 || ns == 0) continue;
        kifmm__box_center(t, b, ctr, &half);
        memcpy(fc, ctr, sizeof fc);
        xs = KIFMM__F(__frame)(c->src, &ld, s0, ns, fc, KIFMM__F(__framebuf)(c));
        kifmm__sub3(ctr, fc, rc);
        KIFMM__F(__place)(c->surf_c, c->nsc, rc, c->ao * half, pc);
        KIFMM__F(__p2p_qc)(c->param, pc, pc + c->nsc, pc + 2 * c->nsc, c->nsc, xs, xs + ld,
                              xs + 2 * ld, w->qs + s0 * KIFMM__QD, ns, nrhs,
                              (size_t)t->ns * KIFMM__QD, scale,
                              w->chk + (size_t)(b - t->loff[l]) * c->nc, (size_t)nl * c->nc);
    }
    t1 = kifmm__now();
    c->stats->t_p2m += t1 - t0;
    KIFMM__F(__family_level)(c, w, nrhs, l, 0); /* M2M */
    KIFMM__F(__solve)(c, w, nrhs, l, 1);
    c->stats->t_m2m += kifmm__now() - t1;
}

/* out += the field, at nt targets, of the sources of box a (vector r's
 * outputs from out + r old on). */
KIFMM__FN void KIFMM__F(__from_sources)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs,
                                        int32_t a, const KIFMM__R *tx, const KIFMM__R *ty,
                                        const KIFMM__R *tz, int64_t nt, KIFMM__R *out,
                                        size_t old)
{
    const kifmm__tree *t = &c->tree;
    int64_t s0 = t->s0[a];
    KIFMM__F(__p2p_qt)(c->param, tx, ty, tz, nt, c->src + s0, c->src + t->ns + s0,
                    c->src + 2 * t->ns + s0, w->qs + s0 * KIFMM__QD, t->s1[a] - s0, nrhs,
                    (size_t)t->ns * KIFMM__QD, 1.0, out, old);
}

/* Downward pass at level l: L2L from the parents, P2L over X lists (their
 * sources straight to the targets of a box with fewer targets than check
 * points), then
 * either the FFT M2L into the check vectors and the two solve steps, or the
 * first solve step, the dense M2L (already in the solve's space) and the
 * second. Timed as L2L (with the solve), P2L and M2L. */
KIFMM__FN void KIFMM__F(__downward)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs,
                                    int l)
{
    const kifmm__tree *t = &c->tree;
    int nl = KIFMM__LVL(c, l);
    size_t cst = (size_t)nl * c->nc, per = (size_t)t->nbox * (size_t)c->ne;
    double scale = KIFMM__F(__level_scale)(c, l), t0 = kifmm__now(), t1, t2, t3, t4;
    const double zero[3] = {0.0, 0.0, 0.0};
    if (l >= 3) KIFMM__F(__family_level)(c, w, nrhs, l - 1, 1); /* L2L */
    else memset(w->chk, 0, (size_t)nrhs * cst * sizeof(KIFMM__R));
    t1 = kifmm__now();
    KIFMM__OMP(parallel for schedule(dynamic, 8) num_threads(c->nthreads))
    for (int32_t b = t->loff[l]; b < t->loff[l + 1]; b++) {
        KIFMM__R *pc, *pe;
        double ctr[3], half;
        KIFMM__R *chk = w->chk + (size_t)(b - t->loff[l]) * c->nc;
        int32_t e, a = l >= 3 ? t->dsrc[t->parent[b]] : -1;
        const int64_t tb0 = t->t0[b], ntb = t->t1[b] - tb0;
        const int xdirect = ntb < c->nsc;
        int r;
        if (xdirect && t->xo[b + 1] > t->xo[b]) {
            /* fewer targets than check points: X sources straight to the
             * targets (only this task writes them; the leaves' pass runs
             * after the downward pass), and no refit for them (dsrc) */
            KIFMM__R *o = w->outs ? w->outs + tb0 * KIFMM__TD : KIFMM__F(__lbuf)(w, nrhs, ntb);
            const size_t old = w->outs ? (size_t)t->nt * KIFMM__TD : (size_t)ntb * KIFMM__TD;
            for (e = t->xo[b]; e < t->xo[b + 1]; e++)
                KIFMM__F(__from_sources)(c, w, nrhs, t->x[e], c->trg + tb0, c->trg + t->nt + tb0,
                                         c->trg + 2 * t->nt + tb0, ntb, o, old);
            if (!w->outs) KIFMM__F(__put)(c, w, nrhs, tb0, ntb, o, old);
        }
        if (t->dsrc[b] != b) {
            /* no refit here: the box is served by an ancestor's expansion */
            for (r = 0; r < nrhs; r++) memset(chk + r * cst, 0, (size_t)c->nc * sizeof(KIFMM__R));
            continue;
        }
        pc = KIFMM__F(__scratch)(c);
        pe = pc + 3 * (c->nsc > c->nse ? c->nsc : c->nse);
        kifmm__box_center(t, b, ctr, &half);
        /* in the frame of box b (float instances; see __frame) */
        KIFMM__F(__place)(c->surf_c, c->nsc, KIFMM__FLOAT ? zero : ctr, KIFMM__ALPHA_INNER * half,
                          pc);
        if (a >= 0 && a != t->parent[b]) {
            /* L2L from an ancestor above the parent, by direct evaluation */
            double ac[3], ah;
            kifmm__box_center(t, a, ac, &ah);
            if (KIFMM__FLOAT) kifmm__sub3(ac, ctr, ac);
            KIFMM__F(__place)(c->surf_e, c->nse, ac, c->ao * ah, pe);
            KIFMM__F(__p2p_sc)(c->param, pc, pc + c->nsc, pc + 2 * c->nsc, c->nsc, pe,
                                  pe + c->nse, pe + 2 * c->nse, w->de + (size_t)a * c->ne,
                                  c->nse, nrhs, per, scale, chk, cst);
        }
        for (e = t->xo[b]; e < t->xo[b + 1] && !xdirect; e++) {
            const int32_t xb = t->x[e];
            const int64_t s0 = t->s0[xb];
            double fc[3];
            size_t ld = (size_t)t->ns;
            const KIFMM__R *xs;
            memcpy(fc, ctr, sizeof fc);
            xs = KIFMM__F(__frame)(c->src, &ld, s0, t->s1[xb] - s0, fc, KIFMM__F(__framebuf)(c));
            KIFMM__F(__p2p_qc)(c->param, pc, pc + c->nsc, pc + 2 * c->nsc, c->nsc, xs, xs + ld,
                                  xs + 2 * ld, w->qs + s0 * KIFMM__QD, t->s1[xb] - s0, nrhs,
                                  (size_t)t->ns * KIFMM__QD, scale, chk, cst);
        }
    }
    t2 = kifmm__now();
#if KIFMM__FFT
    /* FFT M2L: potentials on the check surface itself, added to chk */
    if (t->m2lo[l + 1] > t->m2lo[l]) KIFMM__F(__m2l_fft)(c, w, nrhs, l);
    t3 = kifmm__now();
    KIFMM__F(__solve)(c, w, nrhs, l, 0);
    t4 = kifmm__now();
    c->stats->t_m2l += t3 - t2;
    c->stats->t_l2l += (t1 - t0) + (t4 - t3);
#else
    KIFMM__F(__solve_step)(c, w, nrhs, l, 0, 0);
    t3 = kifmm__now();
    KIFMM__F(__m2l_level)(c, w, nrhs, l); /* into the first step's result */
    t4 = kifmm__now();
    KIFMM__F(__solve_step)(c, w, nrhs, l, 0, 1);
    c->stats->t_m2l += t4 - t3;
    c->stats->t_l2l += (t1 - t0) + (t3 - t2) + (kifmm__now() - t4);
#endif
    c->stats->t_p2l += t2 - t1;
}

/* out += the field, at nt targets (coordinates in the frame centred at fc,
 * see __frame), of densities (vector stride nbox ne) on the surface of box a
 * (radius alpha half-widths); pe holds the placed surface; vector r's
 * outputs from out + r old on. */
KIFMM__FN void KIFMM__F(__from_surface)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs,
                                        int32_t a, double alpha, const KIFMM__R *dens,
                                        const double *fc, const KIFMM__R *tx,
                                        const KIFMM__R *ty, const KIFMM__R *tz, int64_t nt,
                                        KIFMM__R *pe, KIFMM__R *out, size_t old)
{
    double ctr[3], half;
    kifmm__box_center(&c->tree, a, ctr, &half);
    kifmm__sub3(ctr, fc, ctr); /* in the targets' frame */
    KIFMM__F(__place)(c->surf_e, c->nse, ctr, alpha * half, pe);
    KIFMM__F(__p2p_st)(c->param, tx, ty, tz, nt, pe, pe + c->nse, pe + 2 * c->nse, dens, c->nse,
                    nrhs, (size_t)c->tree.nbox * c->ne, 1.0, out, old);
    (void)w;
}

/* Leaf i of t->leaves: L2P, M2P over W (direct when the box holds fewer
 * sources than its surface has points), P2P over U. With the mutual near
 * field (lo < hi: the points [lo, hi) of the leaf's chunk), a U leaf of the
 * same chunk is computed once for both leaves by the one first in Morton
 * order, and skipped by the other. The outputs of sorted target j go to
 * ob + (j - base) TD, vector r's old further on. tm[0..2] += the time of the
 * three. */
KIFMM__FN void KIFMM__F(__leaf)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs,
                                int32_t i, int64_t lo, int64_t hi, double *tm, KIFMM__R *ob,
                                int64_t base, size_t old)
{
    const kifmm__tree *t = &c->tree;
    int32_t b = t->leaves[i], e;
    int64_t t0 = t->t0[b], ntb = t->t1[b] - t0;
    const KIFMM__R *tx = c->trg + t0, *ty = c->trg + t->nt + t0, *tz = c->trg + 2 * t->nt + t0;
    KIFMM__R *out = ob + (t0 - base) * KIFMM__TD, *pe = KIFMM__F(__scratch)(c);
    double c0 = kifmm__now(), c1, c2, fc[3], half;
    const KIFMM__R *xf = NULL; /* the targets in the leaf's frame, for the surfaces */
    size_t ld = (size_t)t->nt;
    if (t->dsrc[b] >= 0 || t->wo[b + 1] > t->wo[b]) {
        kifmm__box_center(t, b, fc, &half);
        xf = KIFMM__F(__frame)(c->trg, &ld, t0, ntb, fc, KIFMM__F(__framebuf)(c));
    }
    if (t->dsrc[b] >= 0)
        KIFMM__F(__from_surface)(c, w, nrhs, t->dsrc[b], c->ao,
                                 w->de + (size_t)t->dsrc[b] * c->ne, fc, xf, xf + ld,
                                 xf + 2 * ld, ntb, pe, out, old);
    c1 = kifmm__now();
    for (e = t->wo[b]; e < t->wo[b + 1]; e++) {
        int32_t a = t->w[e];
        if (t->s1[a] - t->s0[a] <= c->nse)
            KIFMM__F(__from_sources)(c, w, nrhs, a, tx, ty, tz, ntb, out, old);
        else
            KIFMM__F(__from_surface)(c, w, nrhs, a, KIFMM__ALPHA_INNER,
                                     w->ue + (size_t)a * c->ne, fc, xf, xf + ld, xf + 2 * ld,
                                     ntb, pe, out, old);
    }
    c2 = kifmm__now();
    for (e = t->uo[b]; e < t->uo[b + 1]; e++) {
        int32_t a = t->u[e];
#if KIFMM__MUTUAL
        int64_t ta = t->t0[a];
        if (a != b && ta >= lo && ta < hi) {
            /* sources are the targets: s0 = t0, src = trg */
            const KIFMM__R *qa = w->qs + t0 * KIFMM__QD, *qb = w->qs + ta * KIFMM__QD;
            const size_t qld = (size_t)t->ns * KIFMM__QD;
            KIFMM__R *oa = ob + (ta - base) * KIFMM__TD;
            if (ta > t0 && nrhs == 1)
                KIFMM__HOOK(QT, p2ps)(c->param, tx, ty, tz, qa, ntb, c->src + ta,
                                      c->src + t->ns + ta, c->src + 2 * t->ns + ta, qb,
                                      t->t1[a] - ta, (KIFMM__R)1, out, oa);
            else if (ta > t0)
#if KIFMM__HAS_QT & KIFMM__B_P2PSN
                KIFMM__HOOK(QT, p2psn)(c->param, tx, ty, tz, qa, ntb, c->src + ta,
                                       c->src + t->ns + ta, c->src + 2 * t->ns + ta, qb,
                                       t->t1[a] - ta, nrhs, qld, (KIFMM__R)1, out, oa, old);
#else
            {
                int r;
                for (r = 0; r < nrhs; r++)
                    KIFMM__HOOK(QT, p2ps)(c->param, tx, ty, tz, qa + r * qld, ntb, c->src + ta,
                                          c->src + t->ns + ta, c->src + 2 * t->ns + ta,
                                          qb + r * qld, t->t1[a] - ta, (KIFMM__R)1,
                                          out + r * old, oa + r * old);
            }
#endif
            continue;
        }
#else
        (void)lo;
        (void)hi;
#endif
        KIFMM__F(__from_sources)(c, w, nrhs, a, tx, ty, tz, ntb, out, old);
    }
    tm[0] += c1 - c0;
    tm[1] += c2 - c1;
    tm[2] += kifmm__now() - c2;
}

/* The leaves' passes. With the mutual near field (sources = targets, a
 * kernel with a _p2ps hook: c->pchunk), the leaves go
 * in chunks of consecutive leaves, one chunk per task, so that both leaves
 * of a pair computed once belong to the thread that writes their outputs. */
KIFMM__FN void KIFMM__F(__leaves)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs)
{
    const kifmm__tree *t = &c->tree;
    double tl = 0.0, tw = 0.0, tu = 0.0;
    if (c->pchunk) {
        KIFMM__OMP(parallel for schedule(dynamic, 1) num_threads(c->nthreads) reduction(+ : tl, tw, tu))
        for (int32_t i = 0; i < c->npchunk; i++) {
            const int32_t i0 = c->pchunk[i], i1 = c->pchunk[i + 1];
            double tm[3] = {0.0, 0.0, 0.0};
            int32_t j;
            if (i0 < i1) {
                const int64_t lo = t->t0[t->leaves[i0]];
                const int64_t hi = i1 < t->nleaves ? t->t0[t->leaves[i1]] : t->nt;
                const size_t old = (size_t)(hi - lo) * KIFMM__TD;
                if (w->outs) {
                    for (j = i0; j < i1; j++)
                        KIFMM__F(__leaf)(c, w, nrhs, j, lo, hi, tm, w->outs, 0,
                                         (size_t)t->nt * KIFMM__TD);
                } else {
                    KIFMM__R *ob = KIFMM__F(__lbuf)(w, nrhs, hi - lo);
                    double p0;
                    for (j = i0; j < i1; j++)
                        KIFMM__F(__leaf)(c, w, nrhs, j, lo, hi, tm, ob, lo, old);
                    p0 = kifmm__now();
                    KIFMM__F(__put)(c, w, nrhs, lo, hi - lo, ob, old);
                    tm[2] += kifmm__now() - p0; /* counted as near field */
                }
            }
            tl += tm[0];
            tw += tm[1];
            tu += tm[2];
        }
    } else {
        KIFMM__OMP(parallel for schedule(dynamic, 4) num_threads(c->nthreads) reduction(+ : tl, tw, tu))
        for (int32_t i = 0; i < t->nleaves; i++) {
            double tm[3] = {0.0, 0.0, 0.0};
            const int64_t t0 = t->t0[t->leaves[i]], n = t->t1[t->leaves[i]] - t0;
            if (w->outs) {
                KIFMM__F(__leaf)(c, w, nrhs, i, 0, 0, tm, w->outs, 0, (size_t)t->nt * KIFMM__TD);
            } else if (n > 0) {
                KIFMM__R *ob = KIFMM__F(__lbuf)(w, nrhs, n);
                double p0;
                KIFMM__F(__leaf)(c, w, nrhs, i, 0, 0, tm, ob, t0, (size_t)n * KIFMM__TD);
                p0 = kifmm__now();
                KIFMM__F(__put)(c, w, nrhs, t0, n, ob, (size_t)n * KIFMM__TD);
                tm[2] += kifmm__now() - p0; /* counted as near field */
            }
            tl += tm[0];
            tw += tm[1];
            tu += tm[2];
        }
    }
    c->stats->t_l2p += tl / c->nthreads;
    c->stats->t_m2p += tw / c->nthreads;
    c->stats->t_p2p += tu / c->nthreads;
}

/* The chunks of the mutual near field: the leaves in Morton order cut into
 * KIFMM__PAIR_CHUNKS chunks per thread of about equal estimated work (U
 * pairs counted half, and the surface evaluations). A pair of leaves in two
 * chunks is computed by each for its own targets, so fewer, larger chunks
 * compute fewer pairs twice; several per thread keep the threads balanced.
 * One thread: one chunk. */
#ifndef KIFMM__PAIR_CHUNKS
#define KIFMM__PAIR_CHUNKS 4
#endif
KIFMM__FN int KIFMM__F(__pair_plan)(KIFMM_NAME *c)
{
    const kifmm__tree *t = &c->tree;
    int32_t nk = c->nthreads > 1 ? KIFMM__PAIR_CHUNKS * c->nthreads : 1, i, k = 0;
    double total = 0.0, acc = 0.0;
    int pass;
    if (nk > t->nleaves) nk = t->nleaves;
    if (nk < 1) return KIFMM_SUCCESS;
    c->pchunk = (int32_t *)kifmm__alloc((size_t)nk + 1, sizeof(int32_t));
    if (!c->pchunk) return KIFMM_ERR_NOMEM;
    for (pass = 0; pass < 2; pass++) {
        for (i = 0; i < t->nleaves; i++) {
            int32_t b = t->leaves[i], e;
            double wk = (double)c->nse * (1 + t->wo[b + 1] - t->wo[b]);
            for (e = t->uo[b]; e < t->uo[b + 1]; e++)
                wk += 0.5 * (double)(t->s1[t->u[e]] - t->s0[t->u[e]]);
            wk *= (double)(t->t1[b] - t->t0[b]);
            if (pass == 0) {
                total += wk;
                continue;
            }
            while (k < nk && acc >= total * k / nk) c->pchunk[k++] = i;
            acc += wk;
        }
    }
    while (k <= nk) c->pchunk[k++] = t->nleaves; /* any empty chunks last */
    c->npchunk = nk;
    return KIFMM_SUCCESS;
}

/* ---- public entry points ------------------------------------------------ */

/* <prefix>_destroy: free a handle and everything it owns. NULL is a no-op. */
KIFMM__FN void KIFMM__F(_destroy)(KIFMM_NAME *h)
{
    int i;
    if (!h) return;
#if KIFMM__FLOAT
    kifmm__free(h->src);
    if (h->trg != h->src) kifmm__free(h->trg);
#endif
    kifmm__tree_free(&h->tree);
    if (h->ops) {
        for (i = 0; i < h->nops; i++) KIFMM__F(__ops_free)(&h->ops[i]);
        kifmm__free(h->ops);
    }
    kifmm__free(h->surf_e);
    kifmm__free(h->surf_c);
    kifmm__free(h->scratch);
    kifmm__free(h->gbuf);
    KIFMM__F(__work_free)(h->w);
    kifmm__fft_free(&h->fft);
    kifmm__free(h->co);
    kifmm__free(h->cj);
    kifmm__free(h->cc);
    kifmm__free(h->spec);
    kifmm__free(h->fbuf);
    kifmm__free(h->fout);
    kifmm__free(h->loc);
    kifmm__free(h->need);
    kifmm__free(h->cjl);
    kifmm__free(h->sch);
    kifmm__free(h->pchunk);
    kifmm__free(h->act);
    kifmm__free(h->stats);
    kifmm__free(h);
}

/* What the handle is made of, for <prefix>_stats: the largest leaf, the
 * points of crowded leaves, and the code paths of this build. */
KIFMM__FN void KIFMM__F(__describe)(KIFMM_NAME *h)
{
    const kifmm__tree *t = &h->tree;
    kifmm_stats *st = h->stats;
    const char *near =
        KIFMM__NEAR_HOOK ? (KIFMM__MUTUAL && t->same ? "kernel hooks, each pair once"
                                                     : "kernel hooks")
                         : "generic loop over the kernel's eval";
    int32_t b;
    st->max_leaf = st->crowded = 0;
    for (b = 0; b < t->nbox; b++) {
        const int64_t ns = t->s1[b] - t->s0[b], nt = t->same ? 0 : t->t1[b] - t->t0[b];
        if (t->child[b] >= 0) continue;
        if (ns > st->max_leaf) st->max_leaf = ns;
        if (nt > st->max_leaf) st->max_leaf = nt;
        if (ns > h->opts.leaf_size || nt > h->opts.leaf_size) st->crowded += ns + nt;
    }
    st->threads = h->nthreads;
    st->simd = KIFMM__SIMD_BITS;
    snprintf(st->build, sizeof st->build,
             "near field: %s, %s; level passes: %s; M2L: %s%s; %s %d thread%s", KIFMM__SIMD_NAME,
             near, KIFMM__GC_FAST ? KIFMM__SIMD_NAME " column GEMM" : "BLAS",
             KIFMM__FFT ? "FFT, " KIFMM__SIMD_NAME " products, " : "dense BLAS",
             KIFMM__FFT ? (h->fft.single ? "float spectra" : "double spectra") : "",
#ifdef _OPENMP
             "OpenMP,",
#else
             "no OpenMP (built without -fopenmp):",
#endif
             h->nthreads, h->nthreads == 1 ? "" : "s");
}

KIFMM__FN int KIFMM__F(__check_points)(int64_t n, const KIFMM__R *xyz, int nth)
{
    int bad = 0;
    if (n < 0 || n > KIFMM_MAX_POINTS) return KIFMM_ERR_COUNT;
    if (n > 0 && !xyz) return KIFMM_ERR_NULL;
    KIFMM__OMP(parallel for schedule(static) num_threads(nth) reduction(| : bad) if (n > 65536))
    for (int64_t i = 0; i < 3 * n; i++) bad |= !isfinite(xyz[i]);
    (void)nth;
    return bad ? KIFMM_ERR_NONFINITE : KIFMM_SUCCESS;
}

/* The kernel's parameters with defaults resolved, or KIFMM_ERR_PARAM. */
KIFMM__FN int KIFMM__F(__params)(const double *in, double *out)
{
    int d;
    for (d = 0; d < 4; d++) {
        if (!isfinite(in[d])) return KIFMM_ERR_PARAM;
        out[d] = in[d];
    }
#if KIFMM__HAS_QT & KIFMM_HAS_SETUP
    if (KIFMM__K(_setup)(in, out) != 0) return KIFMM_ERR_PARAM;
#endif
    return KIFMM_SUCCESS;
}

/* Tree over the points given in the instance's precision: double goes
 * straight in, float through a double copy. Sets c->src and c->trg. */
KIFMM__FN int KIFMM__F(__tree)(KIFMM_NAME *c, int64_t ns, const KIFMM__R *src, int64_t nt,
                               const KIFMM__R *trg)
{
    const kifmm_opts *o = &c->opts;
    int rc;
#if KIFMM__FLOAT
    const int same = src == trg && ns == nt; /* one copy, and the tree sorts once */
    double *s = (double *)kifmm__alloc((size_t)(3 * ns), sizeof(double));
    double *g = same ? s : (double *)kifmm__alloc((size_t)(3 * nt), sizeof(double));
    if (!s || !g) {
        kifmm__free(s);
        if (!same) kifmm__free(g);
        return KIFMM_ERR_NOMEM;
    }
    KIFMM__OMP(parallel for schedule(static) num_threads(o->nthreads))
    for (int64_t i = 0; i < 3 * ns; i++) s[i] = src[i];
    if (!same) {
        KIFMM__OMP(parallel for schedule(static) num_threads(o->nthreads))
        for (int64_t i = 0; i < 3 * nt; i++) g[i] = trg[i];
    }
    rc = kifmm__tree_build(&c->tree, ns, s, nt, g, o->leaf_size, o->max_depth, o->nthreads,
                           !KIFMM__FFT);
    kifmm__free(s);
    if (!same) kifmm__free(g);
    if (rc) return rc;
    c->src = KIFMM__F(__own)(&c->tree.src, (size_t)(3 * ns));
    if (c->tree.same) {
        c->trg = c->src;
        c->tree.trg = NULL;
    } else {
        c->trg = KIFMM__F(__own)(&c->tree.trg, (size_t)(3 * nt));
    }
    if (!c->src || !c->trg) return KIFMM_ERR_NOMEM;
#else
    rc = kifmm__tree_build(&c->tree, ns, src, nt, trg, o->leaf_size, o->max_depth, o->nthreads,
                           !KIFMM__FFT);
    if (rc) return rc;
    c->src = c->tree.src;
    c->trg = c->tree.trg;
#endif
    return KIFMM_SUCCESS;
}

/* <prefix>_create: build the tree and the operators for these points.
 *   out      (out) the new handle; NULL on failure
 *   opts     (in)  options, NULL for all defaults (see kifmm_opts)
 *   nsources, src_xyz  (in) source points, x[3*i+k]
 *   ntargets, trg_xyz  (in) target points, x[3*j+k]
 * Coordinates, densities and outputs are KIFMM_REAL (double unless the
 * instance was made with KIFMM_REAL float). The handle keeps no pointer to the
 * caller's arrays. Returns KIFMM_SUCCESS or a negative kifmm result; on
 * failure nothing is leaked. Thread safe: distinct handles may be created
 * concurrently. */
KIFMM__FN int KIFMM__F(_create)(KIFMM_NAME **out, const kifmm_opts *opts, int64_t nsources,
                                const KIFMM__R *src_xyz, int64_t ntargets,
                                const KIFMM__R *trg_xyz)
{
    KIFMM_NAME *h;
    kifmm_opts o;
    double param[4];
    int rc;
    double t0, t1;
    if (!out) return KIFMM_ERR_NULL;
    *out = NULL;
    if ((rc = kifmm__resolve_opts(opts, &o))) return rc;
    if ((rc = KIFMM__F(__check_points)(nsources, src_xyz, o.nthreads))) return rc;
    if ((rc = KIFMM__F(__check_points)(ntargets, trg_xyz, o.nthreads))) return rc;
    if ((rc = KIFMM__F(__params)(o.kernel_param, param))) return rc;
    memcpy(o.kernel_param, param, sizeof param);
    h = (KIFMM_NAME *)kifmm__calloc(1, sizeof *h);
    if (!h) return KIFMM_ERR_NOMEM;
    h->stats = (kifmm_stats *)kifmm__calloc(1, sizeof(kifmm_stats));
    if (!h->stats) {
        kifmm__free(h);
        return KIFMM_ERR_NOMEM;
    }
    h->opts = o;
    h->nthreads = o.nthreads;
    h->degree = (double)(KIFMM__DEGREE);
    memcpy(h->param, param, sizeof param);
    h->tree.ns = nsources;
    h->tree.nt = ntargets;
    if (nsources == 0 || ntargets == 0) {
        KIFMM__F(__describe)(h);
        *out = h;
        return KIFMM_SUCCESS;
    }
    h->cdiff = kifmm__check_diff(o.order, KIFMM__FFT);
    h->ao = kifmm__alpha_outer(h->cdiff);
    h->nse = kifmm__surf_count(o.order);
    h->nsc = kifmm__surf_count(o.order + h->cdiff);
    h->ne = h->nse * KIFMM__SD;
    h->nc = h->nsc * KIFMM__SD;
    h->surf_e = (double *)kifmm__alloc((size_t)3 * h->nse, sizeof(double));
    h->surf_c = (double *)kifmm__alloc((size_t)3 * h->nsc, sizeof(double));
    if (!h->surf_e || !h->surf_c) { rc = KIFMM_ERR_NOMEM; goto fail; }
    kifmm__surf_unit(o.order, h->surf_e);
    kifmm__surf_unit(o.order + h->cdiff, h->surf_c);
    t0 = kifmm__now();
    if ((rc = KIFMM__F(__tree)(h, nsources, src_xyz, ntargets, trg_xyz))) goto fail;
    kifmm__tree_dsrc(&h->tree, h->nsc); /* X lists of boxes with few targets go direct */
    t1 = kifmm__now();
    /* per thread: three surfaces, and for float instances the frame of the
     * largest leaf (see __frame) */
    h->fpts = KIFMM__FLOAT ? (size_t)kifmm__max_leaf(&h->tree) : 0;
    h->scratch = (KIFMM__R *)kifmm__alloc((size_t)h->nthreads * KIFMM__F(__scratch_per)(h),
                                          sizeof(KIFMM__R));
    if (!h->scratch) { rc = KIFMM_ERR_NOMEM; goto fail; }
    /* the level passes' buffers, for trees that have levels 2 and deeper */
    h->gbuf_n = h->tree.nlev > 2 ? (size_t)(KIFMM__GC_FAST ? h->nthreads : 1) *
                                       KIFMM__F(__gbuf_per)(h)
                                 : 0;
    if (!(h->gbuf = (KIFMM__R *)kifmm__alloc(h->gbuf_n, sizeof(KIFMM__R)))) {
        rc = KIFMM_ERR_NOMEM;
        goto fail;
    }
#if KIFMM__FFT
    if ((rc = kifmm__fft_init(&h->fft, o.order + h->cdiff))) goto fail;
    /* float spectra: float instances, and on request double instances of
     * scale-invariant kernels (whose spectra's range fits float at every
     * level, unlike those of a Yukawa kernel at large lambda r) */
    h->fft.single = KIFMM__FLOAT || (KIFMM__SI &&
                                     o.order <= KIFMM_FFT_SINGLE_MAX_ORDER);
    if ((rc = kifmm__colleagues(&h->tree, h->nthreads, &h->co, &h->cj, &h->cc))) goto fail;
    {
        const kifmm__tree *t = &h->tree;
        const size_t esz = h->fft.single ? sizeof(float) : sizeof(double);
        const size_t slot = (size_t)h->fft.nfp * 16 * esz;
        int32_t l, m = 1, mc = 1, i;
        for (l = 1; l + 1 < t->nlev; l++) {
            if (t->ioff[l + 1] - t->ioff[l] > m) m = t->ioff[l + 1] - t->ioff[l];
            if (h->co[t->ioff[l + 1]] - h->co[t->ioff[l]] > mc)
                mc = h->co[t->ioff[l + 1]] - h->co[t->ioff[l]];
        }
        {
            /* KIFMM_FFT_SPEC_MB, or as much as one expansion array of the
             * handle when that is larger, up to 4 times that: fewer slabs and
             * fewer spectra computed twice where the handle is big anyway (two
             * arrays' worth measured no faster at 1M uniform points, p = 6,
             * for 23 MiB more) */
            const size_t lo = (size_t)KIFMM_FFT_SPEC_MB << 20;
            size_t budget = (size_t)t->nbox * (size_t)h->ne * sizeof(KIFMM__R);
            budget = budget < lo ? lo : budget > 4 * lo ? 4 * lo : budget;
            h->slots = (int32_t)(budget / slot);
        }
        if (h->slots < 256) h->slots = 256; /* at high orders: few slabs per level */
        if (h->slots > m) h->slots = m;
        h->loc = (int32_t *)kifmm__alloc((size_t)m, sizeof(int32_t));
        h->need = (int32_t *)kifmm__alloc((size_t)m, sizeof(int32_t));
        h->cjl = (int32_t *)kifmm__alloc((size_t)mc, sizeof(int32_t));
        h->sch = (unsigned char *)kifmm__alloc((size_t)h->slots, 9);
        if (!h->loc || !h->need || !h->cjl || !h->sch) { rc = KIFMM_ERR_NOMEM; goto fail; }
        for (i = 0; i < m; i++) h->loc[i] = -1;
        /* forward transforms write every frequency below nf of a slot; the
         * padding frequencies (the last chunk's tail) stay 0. Only that chunk
         * is zeroed here: zeroing all of it (45 MiB at 1M points, p = 6) took
         * 0.05 s of one thread in create */
        h->spec = kifmm__alloc((size_t)h->slots, slot);
        if (h->spec && h->fft.nfp > h->fft.nf) {
            const size_t chunk = (size_t)h->slots * KIFMM__FFT_F * 16 * esz;
            memset((char *)h->spec + (size_t)(h->fft.nchunk - 1) * chunk, 0, chunk);
        }
        h->fft_m = m;
        h->fft_mc = mc;
        /* products of up to 128 target parents per task, at most about 4 MiB */
        h->ftb = (int)((size_t)(4u << 20) / ((size_t)h->fft.nfp * 16 * esz));
        if (h->ftb > 128) h->ftb = 128;
        if (h->ftb < 1) h->ftb = 1;
        h->fbuf_per = (size_t)27 * 128 * KIFMM__FFT_F * esz / sizeof(double) +
                      ((size_t)h->fft.nfp * h->ftb * 16 * esz + 7) / 8 +
                      kifmm__fft_work8(&h->fft) + (size_t)8 * h->nc;
        h->fbuf_per = (h->fbuf_per + 7) / 8 * 8; /* keeps each thread's part 64-byte aligned */
        h->fbuf = (double *)kifmm__alloc((size_t)h->nthreads * h->fbuf_per, sizeof(double));
        if (!h->spec || !h->fbuf) { rc = KIFMM_ERR_NOMEM; goto fail; }
    }
#endif
    if (KIFMM__MUTUAL && h->tree.same && (rc = KIFMM__F(__pair_plan)(h))) goto fail;
    if ((rc = KIFMM__F(__precompute)(h))) goto fail;
#if KIFMM__FFT
    {
        /* a level whose products' blocks are not kept runs its products over
         * chunks of frequencies (each chunk's blocks built once per slab), into
         * one output buffer for the slab's target parents */
        int l;
        for (l = 0; l < h->nops; l++)
            if (h->ops[l].khat && !h->ops[l].kb) break;
        if (l < h->nops) {
            h->fout = kifmm__alloc((size_t)h->slots,
                                   (size_t)h->fft.nfp * 16 * (h->fft.single ? 4 : 8));
            if (!h->fout) { rc = KIFMM_ERR_NOMEM; goto fail; }
        }
    }
#endif
    h->mb = kifmm__max_level_boxes(&h->tree);
    if (!(h->act = kifmm__active(&h->tree))) { rc = KIFMM_ERR_NOMEM; goto fail; }
    {
        /* about 64 MB of stacked multipoles per M2L GEMM */
        size_t cols = (size_t)(64u << 20) / (sizeof(KIFMM__R) * KIFMM__NT * (size_t)h->ne);
        if (cols < KIFMM__RHS_MAX) cols = KIFMM__RHS_MAX;
        if (cols > (size_t)h->mb * KIFMM__RHS_MAX) cols = (size_t)h->mb * KIFMM__RHS_MAX;
        if (h->tree.m2lo[h->tree.nlev] == 0) cols = 0; /* no M2L in this tree */
        h->m2l_cols = (int)cols;
    }
    if (!(h->w = KIFMM__F(__work_new)(h, 1))) { rc = KIFMM_ERR_NOMEM; goto fail; }
    h->stats->t_tree = t1 - t0;
    h->stats->t_operators = kifmm__now() - t1;
    KIFMM__F(__describe)(h);
    h->stats->levels = h->tree.nlev;
    h->stats->boxes = h->tree.nbox;
    h->stats->leaves = h->tree.nleaves;
    h->stats->bytes = KIFMM__F(__bytes)(h);
    *out = h;
    return KIFMM_SUCCESS;
fail:
    KIFMM__F(_destroy)(h);
    return rc;
}

/* <prefix>_evaluate_many: nrhs density vectors at once, densities as nrhs
 * consecutive blocks of nsources*SRC_DIM, outputs as nrhs consecutive blocks
 * of ntargets*TRG_DIM (each block laid out as in evaluate). The kernel is
 * evaluated once per point pair for up to 8 vectors (generic kernel loops)
 * and the translations run as GEMMs over boxes and vectors together. Outputs
 * are overwritten; out may be the densities' own array (in place) or overlap
 * it. Returns KIFMM_SUCCESS, KIFMM_ERR_NULL, KIFMM_ERR_COUNT (nrhs < 0, or
 * more vectors than any array holds) or KIFMM_ERR_NOMEM (workspace for more
 * vectors than before, or the copy of overlapping densities; then out is
 * untouched). nrhs == 0 does nothing. Not thread safe on one handle. */
KIFMM__FN int KIFMM__F(_evaluate_many)(const KIFMM_NAME *h, int nrhs, const KIFMM__R *densities,
                                       KIFMM__R *out)
{
    const kifmm__tree *t;
    KIFMM__F(__work) *w;
    KIFMM__R *dcopy = NULL;
    int l, r0, nr, cap;
    double t0;
    size_t qper, oper;
    if (!h) return KIFMM_ERR_NULL;
    if (nrhs < 0) return KIFMM_ERR_COUNT;
    t = &h->tree;
    if ((t->ns > 0 && nrhs > 0 && !densities) || (t->nt > 0 && nrhs > 0 && !out))
        return KIFMM_ERR_NULL;
    if (t->nt == 0 || nrhs == 0) return KIFMM_SUCCESS;
    qper = (size_t)t->ns * KIFMM__QD;
    oper = (size_t)t->nt * KIFMM__TD;
    if ((size_t)nrhs > (size_t)PTRDIFF_MAX / sizeof(KIFMM__R) / (qper > oper ? qper : oper))
        return KIFMM_ERR_COUNT; /* no array holds that many vectors */
    if (t->ns == 0) {
        memset(out, 0, (size_t)nrhs * oper * sizeof(KIFMM__R));
        return KIFMM_SUCCESS;
    }
    cap = nrhs < KIFMM__RHS_MAX ? nrhs : KIFMM__RHS_MAX;
    if (nrhs > cap && kifmm__overlap(densities, (size_t)nrhs * qper * sizeof(KIFMM__R), out,
                                     (size_t)nrhs * oper * sizeof(KIFMM__R))) {
        /* in place (out over densities): each group of up to RHS_MAX
         * vectors reads its densities before it writes its outputs, so only
         * a later group's densities could be overwritten; those are copied */
        dcopy = (KIFMM__R *)kifmm__alloc((size_t)nrhs * qper, sizeof(KIFMM__R));
        if (!dcopy) return KIFMM_ERR_NOMEM;
        memcpy(dcopy, densities, (size_t)nrhs * qper * sizeof(KIFMM__R));
        densities = dcopy;
    }
    if (h->w->nrhs < cap) {
        /* more vectors than any call before: a larger workspace (the handle
         * is the caller's, allocated by create; only its workspace changes) */
        KIFMM__F(__work) *nw = KIFMM__F(__work_new)(h, cap);
        if (!nw) {
            kifmm__free(dcopy);
            return KIFMM_ERR_NOMEM;
        }
        KIFMM__F(__work_free)(h->w);
        ((KIFMM_NAME *)h)->w = nw;
        h->stats->bytes = KIFMM__F(__bytes)(h);
    }
    w = h->w;
    t0 = kifmm__now();
    {
        kifmm_stats *st = h->stats;
        st->t_p2m = st->t_m2m = st->t_m2l = st->t_l2l = st->t_p2l = 0.0;
        st->t_l2p = st->t_m2p = st->t_p2p = 0.0;
    }
    for (r0 = 0; r0 < nrhs; r0 += nr) {
        nr = nrhs - r0 < cap ? nrhs - r0 : cap;
        KIFMM__OMP(parallel for schedule(static) num_threads(h->nthreads))
        for (int64_t i = 0; i < t->ns; i++) {
            int k, r;
            for (r = 0; r < nr; r++)
                for (k = 0; k < KIFMM__QD; k++)
                    w->qs[r * qper + i * KIFMM__QD + k] =
                        densities[(r0 + r) * qper + t->sperm[i] * KIFMM__QD + k];
        }
        /* outputs summed in sorted order (outs) and gathered at the end, or
         * added by each task to the caller's out (dst, see the workspace) */
        w->dst = out + (size_t)r0 * oper;
        memset(w->outs ? w->outs : w->dst, 0, (size_t)nr * oper * sizeof(KIFMM__R));
        for (l = t->nlev - 1; l >= 2; l--) KIFMM__F(__upward)(h, w, nr, l);
        for (l = 2; l < t->nlev; l++) KIFMM__F(__downward)(h, w, nr, l);
        KIFMM__F(__leaves)(h, w, nr);
        w->dst = NULL;
        if (w->outs) {
            KIFMM__OMP(parallel for schedule(static) num_threads(h->nthreads))
            for (int64_t i = 0; i < t->nt; i++) {
                int k, r;
                for (r = 0; r < nr; r++)
                    for (k = 0; k < KIFMM__TD; k++)
                        out[(r0 + r) * oper + t->tperm[i] * KIFMM__TD + k] =
                            w->outs[r * oper + i * KIFMM__TD + k];
            }
        }
    }
    h->stats->t_evaluate = kifmm__now() - t0;
    kifmm__free(dcopy);
    return KIFMM_SUCCESS;
}

/* <prefix>_evaluate: out[j*TRG_DIM + k] for every target, in the caller's
 * order, from densities[i*SRC_DIM + d]. Outputs are overwritten. Returns
 * KIFMM_SUCCESS or KIFMM_ERR_NULL (then out is untouched). Not thread safe
 * on one handle (the handle holds the workspace); use one handle per thread. */
KIFMM__FN int KIFMM__F(_evaluate)(const KIFMM_NAME *h, const KIFMM__R *densities, KIFMM__R *out)
{
    return KIFMM__F(_evaluate_many)(h, 1, densities, out);
}

/* <prefix>_stats: tree size, memory held, and the time of create's stages
 * and of the last evaluate's passes (see kifmm_stats). */
KIFMM__FN int KIFMM__F(_stats)(const KIFMM_NAME *h, kifmm_stats *out)
{
    if (!h || !out) return KIFMM_ERR_NULL;
    *out = *h->stats;
    return KIFMM_SUCCESS;
}

/* <prefix>_options: the options the handle uses, defaults resolved (kernel
 * parameters included). */
KIFMM__FN int KIFMM__F(_options)(const KIFMM_NAME *h, kifmm_opts *used)
{
    if (!h || !used) return KIFMM_ERR_NULL;
    *used = h->opts;
    return KIFMM_SUCCESS;
}

/* ======================================================================== */
/* 5. Epilogue: the next include starts clean                              */
/* ======================================================================== */
#undef KIFMM__LVL
#undef KIFMM__NEAR_HOOK
#undef KIFMM__MUTUAL
#undef KIFMM__GEMM_COLS
#undef KIFMM__FFT
#undef KIFMM__CUTOFF
#undef KIFMM__TINY
#undef KIFMM_M2L_DENSE
#undef KIFMM__DEFINE_P2P_HOOKN
#undef KIFMM__P2P_SIG
#undef KIFMM__DEFINE_P2P_HOOK
#undef KIFMM__DEFINE_P2P
#undef KIFMM__QD
#undef KIFMM__SI
#undef KIFMM__DEGREE
#undef KIFMM__ROLE_QT
#undef KIFMM__ROLE_SC
#undef KIFMM__ROLE_ST
#undef KIFMM__ROLE_QC
#undef KIFMM__R_
#undef KIFMM__RCAT
#undef KIFMM__RCAT_
#undef KIFMM__LEGACY_HAS
#undef KIFMM__HAS_OF
#undef KIFMM__HAS_QT
#undef KIFMM__HAS_ST
#undef KIFMM__HAS_QC
#undef KIFMM__HAS_SC
#undef KIFMM__B_P2P
#undef KIFMM__B_P2PN
#undef KIFMM__B_P2PS
#undef KIFMM__B_P2PSN
#undef KIFMM__HOOK
#undef KIFMM__FLOAT
#undef KIFMM__R
#undef KIFMM__TD
#undef KIFMM__SD
#undef KIFMM__F
#undef KIFMM__K
#undef KIFMM_NAME
#undef KIFMM_REAL
#undef KIFMM_KERNEL

#if defined(__GNUC__) && !defined(__clang__) && defined(__cplusplus)
#pragma GCC diagnostic pop
#endif

/* License: MIT. Copyright (c) 2026 the kifmm.h authors. Permission is hereby
 * granted, free of charge, to any person obtaining a copy of this software, to
 * deal in it without restriction, provided this notice is kept. THE SOFTWARE
 * IS PROVIDED "AS IS", WITHOUT WARRANTY OF ANY KIND. */
