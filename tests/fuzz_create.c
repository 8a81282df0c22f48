/* fuzz_create.c - libFuzzer target for the public API of kifmm.h.
 *
 * Build (make fuzz does this; tests/fuzz.sh runs it inside make test): this
 * file and the two halves of the instances (tests/fuzz_instances.c with
 * -DFUZZ_PART=1 and 2), each
 *   clang -g -O1 -fopenmp -fsanitize=fuzzer,address,undefined \
 *         -fno-sanitize-recover=all -I. -c FILE
 * then linked into build/fuzz_create with -llapacke -lopenblas -lm
 *   build/fuzz_create -max_len=512 CORPUS_DIR
 * Reproduce one input: build/fuzz_create crash-FILE (FUZZ_TRACE=1 prints the
 * decoded input first).
 *
 * The input's bytes pick a kernel, options, point sets, densities and the
 * way the calls are made; short inputs are padded with zero bytes, so every
 * input decodes.  Bulk coordinates and densities come from a generator
 * seeded by the input, then a few entries are overwritten with special
 * values: libFuzzer mutates a few hundred bytes, and thousands of points
 * spelled out byte by byte would make it wander.
 *
 * What is checked (a failure prints "fuzz_create: CHECK FAILED: ..." and
 * aborts, so libFuzzer keeps the input):
 *   - no sanitizer report, and no leak (LeakSanitizer, on by default);
 *   - a failing call writes nothing the caller owns (outputs are filled
 *     with a sentinel before each call and compared after), except
 *     create's *out = NULL and the outputs of KIFMM_ERR_OVERFLOW;
 *   - a create that succeeds had valid inputs (finite coordinates within
 *     KIFMM_COORD_MAX, finite parameters, valid counts and periods);
 *   - evaluate, evaluate_many and direct: success means every output is
 *     written and finite; NaN or infinite densities give KIFMM_ERR_DENSITY;
 *     KIFMM_ERR_OVERFLOW comes with a non-finite output and only where the
 *     exact sums, or the kernel at the closest pair, are near the end of
 *     the number range (bounded below: sum |density| / r^sing, with the
 *     images of a periodic set);
 *   - evaluate and evaluate_many with one vector agree bit for bit (the
 *     documented determinism), zero outputs without sources;
 *   - for free-space sets far from overflow, evaluate agrees with direct at
 *     a few targets within 5 % of the sum of |terms| there from order 4 on,
 *     10 % at order 3 and 25 % at order 2: loose enough for any tree, tight
 *     enough to catch a wrong far field.  The most singular output decides
 *     the sum (|q| / r^3 for a Hessian), and a Hessian's truncation error at
 *     low orders is a sizeable part of it: laplace_hess on 20 to 300 points
 *     spread over 2^-60 to 2^60 (150 sets, leaves of 1 to 20) measured up to
 *     8.9 % at order 2, 3.0 % at 3, 0.45 % at 4 and 0.023 % at 6; uniform
 *     points 7.2 %, 0.82 %, 0.31 % and 0.013 %;
 *   - stats and options report finite, resolved values.
 *
 * Documented behaviour the checks allow (-DFUZZ_NO_SKIPS turns it off):
 *   FUZZ_SKIP_CLOSE_PAIR_OVERFLOW: the kernels form r^-3 (r^-5 for
 *   laplace_hess and stokes_dl) before multiplying by d, so a pair closer
 *   than about 1e-103 (1e-62) gives KIFMM_ERR_OVERFLOW although the
 *   outputs, about r^-2 (r^-3), are inside the range (docs/api.md,
 *   "Limits").  KIFMM_ERR_OVERFLOW is accepted wherever that power of the
 *   closest distance is near overflow.
 * Densities far from 1 (1e40 at orders <= 4, whose M2L runs in float) and
 * coincident points near 1e-161 (NaN in the AVX-512 gradient loop's dead
 * lanes) are checked without exception: both were fixed.
 */
#ifndef FUZZ_NO_SKIPS
#define FUZZ_SKIP_CLOSE_PAIR_OVERFLOW
#endif
#include "fuzz_instances.h" /* the thirteen instances, declared */
#include "kifmm_kernels.h"  /* their dimensions (kifmm_kernel_NAME_SRC_DIM) */

#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <fcntl.h>
#ifdef _OPENMP
#include <omp.h>
#endif

/* ---- one table entry per instance, arrays passed as void * ------------- */

typedef struct {
    const char *name;
    int sd, td;     /* density components per source, outputs per target */
    int fl;         /* float instance */
    int sing;       /* the kernel's outputs grow like |density| / r^sing */
    int si;         /* scale invariant (periodic sums need neutral densities) */
    int stokes_mu;  /* kernel_param[0] is mu (outputs scale with 1 / mu) */
    int yukawa;     /* kernel_param[0] is lambda */
    int pairs;      /* density components that multiply (stokes_dl: q times n) */
    int heavy;      /* three surface density components: slow operators and M2L */
    int (*create)(void **h, const kifmm_opts *o, int64_t ns, const void *s, int64_t nt,
                  const void *t);
    int (*evaluate)(void *h, const void *q, void *out);
    int (*evaluate_many)(void *h, int nrhs, const void *q, void *out);
    void (*destroy)(void *h);
    int (*stats)(const void *h, kifmm_stats *st);
    int (*options)(const void *h, kifmm_opts *o);
    int (*direct)(const kifmm_opts *o, int64_t ns, const void *s, const void *q, int64_t nt,
                  const void *t, void *out);
    int (*estimate)(const kifmm_opts *o, int64_t ns, int64_t nt, double *bytes);
    int (*update)(void *h, int64_t ns, const void *s, int64_t nt, const void *t);
    int (*on_tree)(void **out, const kifmm_opts *o, const void *h); /* create_on_tree(h's) */
} api;

#define FUZZ_API(P, R)                                                                         \
    static int P##_z_create(void **h, const kifmm_opts *o, int64_t ns, const void *s,         \
                            int64_t nt, const void *t)                                         \
    {                                                                                          \
        P *x;                                                                                  \
        int rc;                                                                                \
        if (!h) return P##_create(NULL, o, ns, (const R *)s, nt, (const R *)t);                \
        x = (P *)*h;                                                                           \
        rc = P##_create(&x, o, ns, (const R *)s, nt, (const R *)t);                            \
        *h = x;                                                                                \
        return rc;                                                                             \
    }                                                                                          \
    static int P##_z_evaluate(void *h, const void *q, void *out)                              \
    {                                                                                          \
        return P##_evaluate((P *)h, (const R *)q, (R *)out);                                   \
    }                                                                                          \
    static int P##_z_evaluate_many(void *h, int nrhs, const void *q, void *out)               \
    {                                                                                          \
        return P##_evaluate_many((P *)h, nrhs, (const R *)q, (R *)out);                        \
    }                                                                                          \
    static void P##_z_destroy(void *h) { P##_destroy((P *)h); }                                \
    static int P##_z_stats(const void *h, kifmm_stats *st)                                    \
    {                                                                                          \
        return P##_stats((const P *)h, st);                                                    \
    }                                                                                          \
    static int P##_z_options(const void *h, kifmm_opts *o)                                    \
    {                                                                                          \
        return P##_options((const P *)h, o);                                                   \
    }                                                                                          \
    static int P##_z_direct(const kifmm_opts *o, int64_t ns, const void *s, const void *q,    \
                            int64_t nt, const void *t, void *out)                              \
    {                                                                                          \
        return P##_direct(o, ns, (const R *)s, (const R *)q, nt, (const R *)t, (R *)out);      \
    }                                                                                          \
    static int P##_z_update(void *h, int64_t ns, const void *s, int64_t nt, const void *t)    \
    {                                                                                          \
        return P##_update_points((P *)h, ns, (const R *)s, nt, (const R *)t);                  \
    }                                                                                          \
    static int P##_z_on_tree(void **out, const kifmm_opts *o, const void *h)                  \
    {                                                                                          \
        P *g = NULL;                                                                           \
        int rc = P##_create_on_tree(&g, o, P##_tree((const P *)h));                            \
        *out = g;                                                                              \
        return rc;                                                                             \
    }
#define FUZZ_ENTRY(P, K, FL, SING, SI, MU, YU, PAIRS, HEAVY)                                    \
    {#P, kifmm_kernel_##K##_SRC_DIM, kifmm_kernel_##K##_TRG_DIM, FL, SING, SI, MU, YU, PAIRS,  \
     HEAVY,                                                                                     \
     P##_z_create, P##_z_evaluate, P##_z_evaluate_many, P##_z_destroy, P##_z_stats,            \
     P##_z_options, P##_z_direct, P##_estimate_bytes, P##_z_update, P##_z_on_tree}

FUZZ_API(kifmm_laplace, double)
FUZZ_API(kifmm_laplace_grad, double)
FUZZ_API(kifmm_laplace_hess, double)
FUZZ_API(kifmm_laplace_dipole, double)
FUZZ_API(kifmm_laplace_cd, double)
FUZZ_API(kifmm_yukawa, double)
FUZZ_API(kifmm_yukawa_grad, double)
FUZZ_API(kifmm_stokes, double)
FUZZ_API(kifmm_stokes_dl, double)
FUZZ_API(kifmm_biot_savart, double)
FUZZ_API(kifmm_laplacef, float)
FUZZ_API(kifmm_stokesf, float)
FUZZ_API(kifmm_yukawaf, float)

/* sing: the power of 1/r of the largest output (laplace_cd: the dipole's
 * 1/r^2 dominates below r = 1, the charge's 1/r above; both are counted). */
static const api apis[] = {
    FUZZ_ENTRY(kifmm_laplace, laplace, 0, 1, 1, 0, 0, 0, 0),
    FUZZ_ENTRY(kifmm_laplace_grad, laplace_grad, 0, 2, 1, 0, 0, 0, 0),
    FUZZ_ENTRY(kifmm_laplace_hess, laplace_hess, 0, 3, 1, 0, 0, 0, 0),
    FUZZ_ENTRY(kifmm_laplace_dipole, laplace_dipole, 0, 2, 1, 0, 0, 0, 0),
    FUZZ_ENTRY(kifmm_laplace_cd, laplace_cd, 0, 2, 1, 0, 0, 0, 0),
    FUZZ_ENTRY(kifmm_yukawa, yukawa, 0, 1, 0, 0, 1, 0, 0),
    FUZZ_ENTRY(kifmm_yukawa_grad, yukawa_grad, 0, 2, 0, 0, 1, 0, 0),
    FUZZ_ENTRY(kifmm_stokes, stokes, 0, 1, 1, 1, 0, 0, 1),
    FUZZ_ENTRY(kifmm_stokes_dl, stokes_dl, 0, 2, 1, 0, 0, 1, 1),
    FUZZ_ENTRY(kifmm_biot_savart, biot_savart, 0, 2, 1, 0, 0, 0, 1),
    FUZZ_ENTRY(kifmm_laplacef, laplace, 1, 1, 1, 0, 0, 0, 0),
    FUZZ_ENTRY(kifmm_stokesf, stokes, 1, 1, 1, 1, 0, 0, 1),
    FUZZ_ENTRY(kifmm_yukawaf, yukawa, 1, 1, 0, 0, 1, 0, 0),
};
#define NAPIS ((int)(sizeof apis / sizeof apis[0]))

/* ---- failure reporting ---------------------------------------------------- */

static int trace; /* FUZZ_TRACE=1: print what each input decodes to */
static char desc[1024];
static int quiet_fd = -1; /* the real stderr while the library's is muted */

static void unmute(void)
{
    if (quiet_fd < 0) return;
    fflush(stderr);
    dup2(quiet_fd, 2);
    close(quiet_fd);
    quiet_fd = -1;
}

static void fail(const char *fmt, ...)
{
    va_list ap;
    unmute();
    fprintf(stderr, "fuzz_create: CHECK FAILED: ");
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fprintf(stderr, "\nfuzz_create: input: %s\n", desc);
    abort();
}
#define CHECK(c, ...)                                                                          \
    do {                                                                                       \
        if (!(c)) fail(__VA_ARGS__);                                                           \
    } while (0)

static void note(const char *fmt, ...)
{
    size_t len = strlen(desc);
    va_list ap;
    if (len + 1 >= sizeof desc) return;
    va_start(ap, fmt);
    vsnprintf(desc + len, sizeof desc - len, fmt, ap);
    va_end(ap);
}

/* ---- the input's bytes ------------------------------------------------------ */

typedef struct {
    const uint8_t *d;
    size_t n, i;
} reader;

static unsigned u8(reader *r) { return r->i < r->n ? r->d[r->i++] : 0u; }
static unsigned u16(reader *r) { return u8(r) | u8(r) << 8; }
static uint64_t u64(reader *r)
{
    uint64_t v = 0;
    int k;
    for (k = 0; k < 8; k++) v |= (uint64_t)u8(r) << (8 * k);
    return v;
}
#define PICK(r, table) ((table)[u8(r) % (sizeof(table) / sizeof((table)[0]))])

typedef struct { uint64_t s; } rng;
static uint64_t next(rng *g) /* splitmix64 */
{
    uint64_t z = (g->s += UINT64_C(0x9e3779b97f4a7c15));
    z = (z ^ (z >> 30)) * UINT64_C(0xbf58476d1ce4e5b9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94d049bb133111eb);
    return z ^ (z >> 31);
}
static double unif(rng *g) { return (double)(next(g) >> 11) * (1.0 / 9007199254740992.0); }

/* Values at the edges: overflow and underflow in squares and cubes of
 * distances (1e103, 1e-110 cubed), of double and of float, denormals,
 * zero of both signs, and non-finite ones. */
static const double specials[] = {
    0.0,    -0.0,    1.0,     -1.0,     0.5,     2.0,     3.0,      1e6,     -1e6,
    1e20,   1e103,   -1e103,  1e300,    -1e300,  DBL_MAX, -DBL_MAX, 1e-6,    1e-110,
    -1e-110, 1e-300, DBL_MIN, 1e-310,   4.9e-324, 1.0 + DBL_EPSILON, 1e38, 3.4e38,
    1e-38,  1e-40,   1e-45,   0.1,      NAN,     INFINITY, -INFINITY, 1e155, 1e-155,
};
#define NSPECIALS ((unsigned)(sizeof specials / sizeof specials[0]))

/* ---- the point sets --------------------------------------------------------- */

/* Fills n points (3n doubles) by one of several shapes; big values and
 * non-finite ones come from the scale, the centre and the patches. */
static void gen_points(reader *r, rng *g, double *x, int64_t n, double period, const char *what)
{
    static const double scales[] = {1.0, 1e-3, 1e3, 1e-110, 1e103, 1e-300, 1e300, 1e-310,
                                    1e-20, 1e20, 2.0, 1e-160, 1e150, 0.999, 0.0, 1e-45};
    static const double centres[] = {0.0, 0.5, -1.0, 1e6, 1e20, 1e103, -1e300, 1e-300,
                                     3.0, 1e15, 1.5, 1e-110};
    unsigned shape = u8(r) % 9;
    double sc = PICK(r, scales), c[3], dir[3], e2[3];
    unsigned cs = u8(r);
    int64_t i, k, npatch;
    int d;
    /* in a periodic set the points often span a fraction of the period, or
     * several periods (they are wrapped in) */
    if (period > 0.0 && (cs & 0x80)) {
        static const double frac[] = {0.999, 0.5, 1e-3, 3.0, 1e3};
        sc = period * frac[(cs >> 4) & 3];
        if ((cs & 0x70) == 0x70) sc = period * frac[4];
    }
    for (d = 0; d < 3; d++) {
        c[d] = centres[(cs + (unsigned)d * (cs >> 3)) % (sizeof centres / sizeof centres[0])];
        if (!(cs & 4)) c[d] = 0.0;
        dir[d] = (double)((int)(u8(r) % 7) - 3);
        e2[d] = (double)((int)(u8(r) % 7) - 3);
    }
    note("%s: shape %u scale %g centre (%g %g %g); ", what, shape, sc, c[0], c[1], c[2]);
    for (i = 0; i < n; i++) {
        double u = unif(g), v = unif(g), w = unif(g), t;
        double p[3];
        switch (shape) {
        case 0: /* uniform in a cube */
        default: p[0] = u; p[1] = v; p[2] = w; break;
        case 1: /* collinear */
            for (d = 0; d < 3; d++) p[d] = u * dir[d];
            break;
        case 2: /* coplanar */
            for (d = 0; d < 3; d++) p[d] = u * dir[d] + v * e2[d];
            break;
        case 3: /* all at one point */
            p[0] = p[1] = p[2] = 0.25;
            break;
        case 4: /* a few distinct points, each repeated */
            k = (int64_t)(next(g) % 5);
            p[0] = 0.1 * (double)k; p[1] = 0.2 * (double)(k % 2); p[2] = 0.3;
            break;
        case 5: /* on a sphere */
            t = 2.0 * 3.141592653589793 * u;
            w = 2.0 * w - 1.0;
            p[0] = sqrt(1.0 - w * w) * cos(t); p[1] = sqrt(1.0 - w * w) * sin(t); p[2] = w;
            break;
        case 6: /* two tight clusters far apart */
            for (d = 0; d < 3; d++) p[d] = (i & 1 ? 1.0 : 0.0) + 1e-9 * (d ? v : w);
            break;
        case 7: /* on a coarse lattice: exact duplicates and ties in every axis */
            p[0] = (double)(next(g) % 4); p[1] = (double)(next(g) % 4); p[2] = (double)(next(g) % 4);
            break;
        case 8: /* spread over magnitudes: 2^-60 .. 2^60 from the centre */
            for (d = 0; d < 3; d++) p[d] = ldexp(u - 0.5, (int)(next(g) % 121) - 60);
            break;
        }
        for (d = 0; d < 3; d++) x[3 * i + d] = c[d] + sc * p[d];
    }
    npatch = n ? (int64_t)(u8(r) % 6) : 0;
    for (k = 0; k < npatch; k++) {
        int64_t at = (int64_t)(u16(r) % (unsigned)(3 * n));
        double v = specials[u8(r) % NSPECIALS];
        x[at] = v;
        note("%s[%lld] = %g; ", what, (long long)at, v);
    }
}

/* Densities: random in [-1, 1] times a scale, made neutral or not, with
 * special values patched in. */
static void gen_densities(reader *r, rng *g, double *q, int64_t n, int sd, int nrhs)
{
    static const double scales[] = {1.0, 1e-300, 1e300, 1e150, 1e-150, 0.0, 1e30, 1e-30,
                                    1e200, 1e-310};
    unsigned mode = u8(r);
    double sc = PICK(r, scales);
    int64_t i, k, npatch, len = n * sd * nrhs;
    note("densities: mode %u scale %g; ", mode % 4, sc);
    for (i = 0; i < len; i++) {
        switch (mode % 4) {
        case 0: q[i] = sc * (2.0 * unif(g) - 1.0); break;
        case 1: q[i] = sc; break;                        /* constant: a net charge */
        case 2: q[i] = (i / sd) % 2 ? sc : -sc; break;  /* alternate: neutral if n even */
        default: q[i] = sc * (double)((int)(next(g) % 5) - 2); break;
        }
    }
    /* exactly neutral per vector and component: the last source balances */
    if ((mode & 4) && n > 1) {
        int v, c;
        for (v = 0; v < nrhs; v++)
            for (c = 0; c < sd; c++) {
                double s = 0.0;
                for (i = 0; i + 1 < n; i++) s += q[(v * n + i) * sd + c];
                q[(v * n + n - 1) * sd + c] = -s;
            }
    }
    npatch = len ? (int64_t)(u8(r) % 4) : 0;
    for (k = 0; k < npatch; k++) {
        int64_t at = (int64_t)(u16(r) % (unsigned)len);
        q[at] = specials[u8(r) % NSPECIALS];
        note("q[%lld] = %g; ", (long long)at, q[at]);
    }
}

/* ---- helpers -------------------------------------------------------------------- */

static void *xmalloc(size_t n)
{
    void *p = malloc(n ? n : 1);
    if (!p) abort();
    return p;
}

/* the instance's copy of a double array (float instances round) */
static void *as_real(const api *a, const double *x, int64_t n)
{
    void *p = xmalloc((size_t)n * (a->fl ? sizeof(float) : sizeof(double)));
    int64_t i;
    for (i = 0; i < n; i++) {
        if (a->fl) ((float *)p)[i] = (float)x[i];
        else ((double *)p)[i] = x[i];
    }
    return p;
}
static double at(const api *a, const void *p, int64_t i)
{
    return a->fl ? (double)((const float *)p)[i] : ((const double *)p)[i];
}
static size_t rsize(const api *a) { return a->fl ? sizeof(float) : sizeof(double); }

#define SENTINEL_BYTE 0xA5

/* an output array of n values with a guard of 8 values after it */
static void *sentinel_array(const api *a, int64_t n)
{
    size_t b = (size_t)(n + 8) * rsize(a);
    void *p = xmalloc(b);
    memset(p, SENTINEL_BYTE, b);
    return p;
}
static int untouched(const api *a, const void *p, int64_t n)
{
    size_t b = (size_t)(n + 8) * rsize(a), i;
    for (i = 0; i < b; i++)
        if (((const unsigned char *)p)[i] != SENTINEL_BYTE) return 0;
    return 1;
}
static int is_sentinel(const api *a, const void *p, int64_t i)
{
    const unsigned char *b = (const unsigned char *)p + (size_t)i * rsize(a);
    size_t k;
    for (k = 0; k < rsize(a); k++)
        if (b[k] != SENTINEL_BYTE) return 0;
    return 1;
}

/* ---- how large the exact sums can be ---------------------------------------------- */

/* log10 of an upper bound of |output| over all targets (long double: no
 * overflow on the way), or +inf when unknown or infinite.  Each term is at
 * most |density| / r^sing (the kernels' constants are all below 1 in this
 * form: 1/(4 pi), 1/(8 pi mu) * 2, 3/(4 pi)), r measured as the largest
 * coordinate difference (r >= that); coincident points contribute nothing.
 * A periodic set gets the images: distances to the nearest image, at most
 * the period, and a factor for the lattice sum. */
static long double log_bound(const api *a, const kifmm_opts *o, int64_t ns, const void *s,
                             const void *q, int64_t nt, const void *t, int64_t t0, int64_t t1,
                             long double *per_target, long double *kmax)
{
    long double rmin = INFINITY;
    long double qsum = 0.0L, worst = -INFINITY, lg, L = 0.0L, extra = 0.0L;
    int d, nper = 0;
    int64_t i, j;
    long double *qa = (long double *)xmalloc((size_t)(ns ? ns : 1) * sizeof(long double));
    for (d = 0; d < 3; d++)
        if (o->period[d] > 0.0) {
            L = o->period[d];
            nper++;
        }
    for (i = 0; i < ns; i++) {
        long double m = 0.0L;
        int c;
        if (a->pairs) { /* stokes_dl: (sum |q|) (sum |n|) */
            long double m1 = 0.0L, m2 = 0.0L;
            for (c = 0; c < 3; c++) {
                m1 += fabsl((long double)at(a, q, i * 6 + c));
                m2 += fabsl((long double)at(a, q, i * 6 + 3 + c));
            }
            m = m1 * m2;
        } else {
            for (c = 0; c < a->sd; c++) m += fabsl((long double)at(a, q, i * a->sd + c));
        }
        /* not finite, or (a density map's products, stokes_dl) beyond the
         * instance's range: the library may refuse with KIFMM_ERR_OVERFLOW */
        if (!isfinite(m) || m > (a->fl ? (long double)FLT_MAX : (long double)DBL_MAX)) {
            free(qa);
            *kmax = INFINITY;
            return INFINITY;
        }
        qa[i] = m;
        qsum += m;
    }
    if (a->stokes_mu) {
        double mu = o->kernel_param[0] == 0.0 ? 1.0 : o->kernel_param[0];
        if (!(mu > 0.0)) {
            free(qa);
            *kmax = INFINITY;
            return INFINITY;
        }
        extra -= log10l((long double)mu);
    }
    if (nper) {
        /* lattice sums: a decaying kernel adds about (1 / (lambda L))^nper
         * images within its range; a scale-invariant one converges to a few
         * times the nearest image's term (with the background of a net
         * charge, ~Q / L) */
        if (a->yukawa) {
            double lam = o->kernel_param[0] == 0.0 ? 1.0 : o->kernel_param[0];
            long double f = 1.0L / ((long double)lam * L);
            extra += log10l(1.0L + powl(f > 1.0L ? f : 1.0L, (long double)nper) * 30.0L);
        } else {
            extra += 3.0L;
        }
    }
    for (j = t0; j < t1; j++) {
        long double sum = 0.0L;
        for (i = 0; i < ns; i++) {
            long double r = 0.0L;
            int same = 1;
            for (d = 0; d < 3; d++) {
                long double xs = (long double)at(a, s, 3 * i + d),
                            xt = (long double)at(a, t, 3 * j + d), dd;
                if (xs != xt) same = 0;
                if (o->period[d] > 0.0) {
                    xs -= L * floorl(xs / L);
                    xt -= L * floorl(xt / L);
                    dd = fabsl(xs - xt);
                    dd = fminl(dd, fabsl(L - dd));
                } else {
                    dd = fabsl(xs - xt);
                }
                if (dd > r) r = dd;
            }
            if (nper && (r > L || r == 0.0L)) r = L; /* images of itself, or far */
            if (same && !nper) continue;
            if (r == 0.0L) continue; /* wrapped onto each other: the library may not see it */
            if (r < rmin) rmin = r;
            if (qa[i] == 0.0L) continue;
            sum += qa[i] / powl(r, (long double)a->sing);
            if (a->sing > 1 && r > 1.0L) sum += qa[i] / r; /* laplace_cd's charge */
        }
        lg = sum > 0.0L ? log10l(sum) + extra : -INFINITY;
        if (per_target) per_target[j - t0] = sum * powl(10.0L, extra);
        if (lg > worst) worst = lg;
    }
    {
        int pw = a->sing;
#ifdef FUZZ_SKIP_CLOSE_PAIR_OVERFLOW
        pw = a->stokes_mu ? 3 : a->sing == 1 ? 1 : (a->sing == 3 || a->pairs) ? 5 : 3;
#endif
        *kmax = rmin < INFINITY ? -(long double)pw * log10l(rmin) + extra : -INFINITY;
    }
    (void)qsum;
    (void)nt;
    free(qa);
    return worst;
}

/* ---- one input ----------------------------------------------------------------------- */

/* whether any of n values is NaN or infinite */
static int nonfinite_at(const api *a, const void *p, int64_t n)
{
    int64_t i;
    for (i = 0; i < n; i++)
        if (!isfinite(at(a, p, i))) return 1;
    return 0;
}

/* The contract of evaluate, evaluate_many and direct for a call whose
 * pointers are valid.  snap: the output array's bytes before the call (NULL:
 * the sentinel alone); strict: every output must have been written.
 * lb, kmax: log10 of the exact sums' bound and of the kernel at the closest
 * pair, INFINITY if unknown. */
static void check_result(const api *a, const char *fn, int rc, const void *out, const void *snap,
                         int64_t n, int strict, int bad_q, long double lb, long double kmax,
                         const kifmm_opts *used, int64_t nt)
{
    const long double lim = a->fl ? 25.0L : 280.0L, klim = a->fl ? 36.0L : 300.0L;
    int64_t i;
    int per = used->period[0] > 0.0 || used->period[1] > 0.0 || used->period[2] > 0.0;
    if (rc == KIFMM_SUCCESS) {
        CHECK(!bad_q || nt == 0, "%s %s: success with a NaN or infinite density", a->name, fn);
        for (i = 0; i < n; i++) {
            CHECK(!strict || !is_sentinel(a, out, i), "%s %s: output %lld not written", a->name,
                  fn, (long long)i);
            CHECK(isfinite(at(a, out, i)), "%s %s: out[%lld] = %g with success", a->name, fn,
                  (long long)i, at(a, out, i));
        }
        return;
    }
    if (rc == KIFMM_ERR_OVERFLOW) {
        CHECK(!bad_q, "%s %s: KIFMM_ERR_OVERFLOW for a non-finite density", a->name, fn);
        if (strcmp(fn, "direct") == 0) /* direct writes only on success */
            CHECK(untouched(a, out, n), "%s direct failed (%d) but wrote out", a->name, rc);
        else
            CHECK(nonfinite_at(a, out, n), "%s %s: KIFMM_ERR_OVERFLOW with finite outputs",
                  a->name, fn);
        CHECK(lb >= lim || kmax >= klim,
              "%s %s: KIFMM_ERR_OVERFLOW where the sums stay below 1e%.0Lf and the kernel at "
              "the closest pair below 1e%.0Lf", a->name, fn, lb, kmax);
        return;
    }
    if (snap)
        CHECK(memcmp(snap, out, (size_t)(n + 8) * rsize(a)) == 0, "%s %s failed (%d) but wrote out",
              a->name, fn, rc);
    else
        CHECK(untouched(a, out, n), "%s %s failed (%d) but wrote out", a->name, fn, rc);
    if (rc == KIFMM_ERR_DENSITY) {
        CHECK(bad_q, "%s %s: KIFMM_ERR_DENSITY with finite densities", a->name, fn);
        return;
    }
    CHECK(!bad_q, "%s %s: gave %d for a NaN or infinite density, not KIFMM_ERR_DENSITY", a->name,
          fn, rc);
    CHECK(rc == KIFMM_ERR_NEUTRAL && per, "%s %s gave %d (%s)", a->name, fn, rc,
          kifmm_strerror(rc));
}

static void check_options(const api *a, const kifmm_opts *in, const kifmm_opts *used)
{
    int d;
    CHECK(used->order >= 2 && used->order <= KIFMM_MAX_ORDER, "%s options: order %d", a->name,
          used->order);
    CHECK(in->order == 0 || used->order == in->order, "%s options: order %d, asked %d", a->name,
          used->order, in->order);
    CHECK(used->leaf_size >= 1, "%s options: leaf_size %d", a->name, used->leaf_size);
    CHECK(used->max_depth >= 1 && used->max_depth <= KIFMM_MAX_DEPTH, "%s options: max_depth %d",
          a->name, used->max_depth);
    CHECK(used->nthreads >= 1 && used->nthreads <= 2, "%s options: nthreads %d", a->name,
          used->nthreads);
    CHECK(used->verbose == in->verbose, "%s options: verbose", a->name);
    for (d = 0; d < 3; d++)
        CHECK(used->period[d] == in->period[d], "%s options: period[%d] %g, asked %g", a->name, d,
              used->period[d], in->period[d]);
    for (d = 0; d < 4; d++)
        CHECK(isfinite(used->kernel_param[d]), "%s options: kernel_param[%d] %g", a->name, d,
              used->kernel_param[d]);
}

static void check_stats(const api *a, const kifmm_stats *st)
{
    const double t[] = {st->t_tree, st->t_operators, st->t_p2m, st->t_m2m, st->t_m2l,
                        st->t_l2l,  st->t_p2l,       st->t_l2p, st->t_m2p, st->t_p2p,
                        st->t_evaluate};
    size_t k;
    for (k = 0; k < sizeof t / sizeof t[0]; k++)
        CHECK(isfinite(t[k]) && t[k] >= 0.0, "%s stats: time %zu = %g", a->name, k, t[k]);
    CHECK(isfinite(st->bytes) && st->bytes > 0.0, "%s stats: bytes %g", a->name, st->bytes);
    CHECK(st->levels >= 0 && st->boxes >= 0 && st->leaves >= 0 && st->max_leaf >= 0 &&
              st->crowded >= 0,
          "%s stats: negative counts", a->name);
    CHECK(st->threads >= 1 && st->threads <= 2, "%s stats: threads %d", a->name, st->threads);
    CHECK(memchr(st->build, 0, sizeof st->build) != NULL, "%s stats: build not terminated",
          a->name);
}

static int64_t pick_count_(reader *r, int64_t cap);
static int64_t pick_count(reader *r, int64_t cap)
{
    int64_t n = pick_count_(r, cap);
    return n > cap && n <= KIFMM_MAX_POINTS ? cap : n;
}
static int64_t pick_count_(reader *r, int64_t cap)
{
    unsigned c = u8(r);
    switch (c % 10) {
    case 0: return 0;
    case 1: return 1 + (int64_t)(u8(r) % 8);
    case 2: case 3: return (int64_t)(u8(r) % 200);
    case 4: return (int64_t)(u16(r) % (unsigned)(cap + 1));
    case 5: return (int64_t)(u8(r) % 64) + 1;
    case 6: return 2;
    case 7: { static const int64_t bad[] = {-1, -2, INT64_MIN, KIFMM_MAX_POINTS + 1, INT64_MAX,
                                           (int64_t)1 << 62, INT64_MAX / 3 + 1};
              return PICK(r, bad); }
    default: return (int64_t)(u8(r) % 32) + 1;
    }
}
static int count_ok(int64_t n) { return n >= 0 && n <= KIFMM_MAX_POINTS; }

/* a NULL-or-array pointer for a count that may be invalid: invalid counts
 * get a small array, which the library must not read */
static int64_t storage(int64_t n) { return count_ok(n) ? n : 4; }

static void run_one(const uint8_t *data, size_t size)
{
    reader rd = {data, size, 0}, *r = &rd;
    rng g;
    const api *a = &apis[u8(r) % NAPIS];
    kifmm_opts o;
    int64_t ns, nt, nsb, ntb, nq, i;
    unsigned tmode, pmode, calls;
    double *xs, *xt = NULL, *q, L = 0.0;
    void *rs, *rt = NULL, *rq, *h;
    int rc, d, nrhs, all_finite_pts = 1, valid;
    long double lb = INFINITY;
    static int dummy;

    desc[0] = 0;
    memset(&o, 0, sizeof o);
    note("%s; ", a->name);

    /* options */
    {
        static const int orders[] = {0, 1, -1, 13, INT_MAX, INT_MIN, 6, 7, 12, 2, 3};
        static const double tols[] = {0.1, 1e-2, 1e-3, 1.0, 1e10, DBL_MAX, -1e-3, NAN, INFINITY,
                                      1e-300, 4.9e-324, 1e-11, 2e-5, 1e-5, -0.0};
        static const int leaves[] = {0, 1, 2, 3, 8, 32, 100, 1000, -1, INT_MAX, INT_MIN};
        static const int depths[] = {0, 1, 2, 3, 5, 20, 21, -1, INT_MAX};
        static const int threads[] = {1, 2, 0, 1, 2, -1, 1025, INT_MAX};
        static const double params[] = {0.0, 1.0, 2.0, 0.5, 1e-3, 1e3, 1e6, 1e-150, 1e150,
                                        1e-151, 1e151, -1.0, NAN, INFINITY, -INFINITY, 1e300,
                                        DBL_MIN, 4.9e-324, -0.0, 30.0};
        static const double periods[] = {1.0, 2.0, 0.5, 1e-3, 1e3, 1e103, 1e-110, 1e300, 1e-300,
                                         4.9e-324, -1.0, NAN, INFINITY, 0.0, 1e-100, 1e100,
                                         DBL_MAX, 1e20};
        static const int verbs[] = {0, 0, 0, 0, 0, 0, 0, 1, 2, -1};
        unsigned b = u8(r);
        o.order = (b & 0x80) ? PICK(r, orders) : (int)(b % 4) + 2;
        b = u8(r);
        if ((b & 0xC0) == 0xC0) {
            o.tol = PICK(r, tols);
            if (!(b & 0x20)) o.order = 0;
        }
        b = u8(r);
        o.leaf_size = (b & 0x80) ? PICK(r, leaves) : (int)(b % 64);
        o.max_depth = PICK(r, depths);
        o.nthreads = PICK(r, threads);
        b = u8(r);
        o.kernel_param[0] = params[b % (sizeof params / sizeof params[0])];
        if ((b & 0xE0) == 0xE0) o.kernel_param[1 + u8(r) % 3] = PICK(r, params);
        pmode = u8(r);
        if (pmode % 3 == 0) { /* periodic in some directions */
            double p = PICK(r, periods);
            unsigned mask = 1 + (pmode >> 2) % 7;
            for (d = 0; d < 3; d++)
                if (mask & (1u << d)) o.period[d] = p;
            if ((pmode & 0xF0) == 0xF0) o.period[u8(r) % 3] = PICK(r, periods);
        }
        o.verbose = PICK(r, verbs);
    }
    for (d = 0; d < 3; d++)
        if (o.period[d] > 0.0) L = o.period[d];
    note("order %d tol %g leaf %d depth %d threads %d param (%g %g %g %g) period (%g %g %g) "
         "verbose %d; ",
         o.order, o.tol, o.leaf_size, o.max_depth, o.nthreads, o.kernel_param[0],
         o.kernel_param[1], o.kernel_param[2], o.kernel_param[3], o.period[0], o.period[1],
         o.period[2], o.verbose);

    /* counts: a few thousand at most, fewer where create or evaluate cost
     * more per point under the sanitizers (stokes-like kernels' M2L, per
     * level operators of yukawa, tiny leaves, high orders, periodic
     * lattices), so that an input runs in about a second at most */
    {
        int64_t cap = 3000;
        int big_order = o.order > 4 || o.order == 0 || (o.tol > 0.0 && o.tol < 1e-3);
        /* operators at orders above 4 cost seconds to minutes under the
         * sanitizers for kernels with several surface components, per level
         * for yukawa, with lattices, or in trees of small leaves: orders
         * above 4 are fuzzed on the other inputs (one leaf) */
        if (big_order && o.order >= 0 && o.order <= KIFMM_MAX_ORDER &&
            !(o.tol > 0.0 && o.tol < 1e-10) && /* refused at once */
            (a->heavy || a->yukawa || L > 0.0 || (o.leaf_size > 0 && o.leaf_size < 150))) {
            o.order = 4;
            o.tol = 0.0;
            big_order = 0;
            note("order 4 instead; ");
        }
        if (a->heavy) cap = 600;
        if (a->yukawa) cap = 1000;
        if (o.leaf_size > 0 && o.leaf_size < 16) cap = 200;
        if (big_order) cap = 150;
        if (L > 0.0) cap = cap < 300 ? cap : 300;
        if (L > 0.0 && a->heavy && (big_order || o.order > 3)) cap = 60;
        ns = pick_count(r, cap);
        tmode = u8(r) % 6;
        nt = (tmode == 2 || tmode == 4) ? pick_count(r, cap) : tmode == 1 ? 0 : ns;
        if (tmode == 5) nt = count_ok(ns) && ns > 1 ? ns / 2 : ns;
    }
    g.s = u64(r);
    nsb = storage(ns);
    xs = (double *)xmalloc((size_t)(3 * nsb + 1) * sizeof(double));
    note("ns %lld nt %lld targets mode %u; ", (long long)ns, (long long)nt, tmode);
    gen_points(r, &g, xs, nsb, L, "src");
    ntb = storage(nt);
    rs = as_real(a, xs, 3 * nsb);
    switch (tmode) {
    case 0: rt = rs; break;                             /* the same array */
    case 1: rt = NULL; break;                           /* no targets */
    case 2:                                             /* separate targets */
        xt = (double *)xmalloc((size_t)(3 * ntb + 1) * sizeof(double));
        gen_points(r, &g, xt, ntb, L, "trg");
        rt = as_real(a, xt, 3 * ntb);
        free(xt);
        break;
    case 3: rt = as_real(a, xs, 3 * nsb); break;        /* a copy of the sources */
    case 4: rt = NULL; break;                           /* NULL, with a count */
    default: rt = rs; break;                            /* the first half of the sources */
    }

    /* what a successful create requires of its points */
    {
        const double cmax = a->fl ? KIFMM_COORD_MAX_FLOAT : KIFMM_COORD_MAX;
        for (i = 0; i < 3 * (count_ok(ns) ? ns : 0); i++)
            if (!(fabs(at(a, rs, i)) <= cmax)) all_finite_pts = 0;
        for (i = 0; rt && i < 3 * (count_ok(nt) ? nt : 0); i++)
            if (!(fabs(at(a, rt, i)) <= cmax)) all_finite_pts = 0;
    }

    /* densities for up to 9 vectors (evaluate_many passes 8 at a time) */
    {
        static const int nrhss[] = {1, 1, 2, 3, 0, 9, -1, INT_MIN, 1};
        nrhs = PICK(r, nrhss);
        if (nrhs > 3 && count_ok(ns) && count_ok(nt) && ns + nt > 1000) nrhs = 2;
    }
    nq = nsb * a->sd * (nrhs > 1 ? nrhs : 1);
    q = (double *)xmalloc((size_t)(nq + 1) * sizeof(double));
    gen_densities(r, &g, q, nsb, a->sd, nrhs > 1 ? nrhs : 1);
    rq = as_real(a, q, nq);
    calls = u8(r);
    if (trace) fprintf(stderr, "fuzz_create: %s\n", desc);

    /* the library prints its stages with verbose = 1: keep the fuzzer's log
     * readable unless FUZZ_VERBOSE=1 */
    if (o.verbose == 1 && !getenv("FUZZ_VERBOSE")) {
        fflush(stderr);
        int nul = open("/dev/null", O_WRONLY);
        if (nul >= 0) {
            quiet_fd = dup(2);
            dup2(nul, 2);
            close(nul);
        }
    }

    /* estimate_bytes: the same options and counts */
    {
        double bytes = -12345.0;
        rc = a->estimate(&o, ns, tmode == 0 ? KIFMM_SAME_POINTS : nt, &bytes);
        if (rc == KIFMM_SUCCESS)
            CHECK(isfinite(bytes) && bytes > 0.0, "%s estimate_bytes: %g", a->name, bytes);
        else
            CHECK(bytes == -12345.0, "%s estimate_bytes failed (%d) but wrote %g", a->name, rc,
                  bytes);
        if (calls & 1) CHECK(a->estimate(&o, ns, nt, NULL) != KIFMM_SUCCESS,
                             "%s estimate_bytes(NULL) succeeded", a->name);
    }

    /* create */
    h = &dummy;
    rc = a->create(&h, &o, ns, rs, nt, rt);
    valid = count_ok(ns) && count_ok(nt) && all_finite_pts && (nt == 0 || rt) && (ns == 0 || rs);
    for (d = 0; d < 4; d++) valid &= isfinite(o.kernel_param[d]);
    for (d = 0; d < 3; d++) valid &= o.period[d] >= 0.0 && isfinite(o.period[d]);
    if (rc != KIFMM_SUCCESS) {
        CHECK(h == NULL, "%s create failed (%d) but *out = %p", a->name, rc, h);
        CHECK(rc < 0 && strlen(kifmm_strerror(rc)) > 0, "%s create: code %d", a->name, rc);
    } else {
        CHECK(h != NULL && h != &dummy, "%s create succeeded without a handle", a->name);
        CHECK(valid, "%s create succeeded on invalid input (counts %lld %lld, finite points %d)",
              a->name, (long long)ns, (long long)nt, all_finite_pts);
    }
    if ((calls & 6) == 6) CHECK(a->create(NULL, &o, ns, rs, nt, rt) == KIFMM_ERR_NULL,
                                "%s create(NULL) did not give KIFMM_ERR_NULL", a->name);
    note("create %d; ", rc);

    if (rc == KIFMM_SUCCESS) {
        kifmm_opts used;
        kifmm_stats st;
        void *q1 = rq, *out1, *bufm;
        int64_t no = nt * a->td, nqv = ns * a->sd;
        int eval_rc, bad_q;
        long double kmax = INFINITY;

        memset(&used, 0x5a, sizeof used);
        CHECK(a->options(h, &used) == KIFMM_SUCCESS, "%s options failed", a->name);
        check_options(a, &o, &used);
        CHECK(a->stats(h, &st) == KIFMM_SUCCESS, "%s stats failed", a->name);
        check_stats(a, &st);

        /* how close the exact sums come to overflow: KIFMM_ERR_OVERFLOW is
         * only right near it */
        if (ns > 0 && nt > 0 && ns * nt <= 4000000)
            lb = log_bound(a, &used, ns, rs, rq, nt, rt, 0, nt, NULL, &kmax);
        else if (ns == 0 || nt == 0)
            lb = kmax = -INFINITY;
        note("log10 bound %Lg kernel %Lg; ", lb, kmax);
        bad_q = nonfinite_at(a, rq, nqv);

        /* evaluate, with the pointer misuses it must refuse */
        out1 = sentinel_array(a, no);
        if ((calls & 0x18) == 0x18 && ns > 0 && nt > 0) {
            rc = a->evaluate(h, NULL, out1);
            CHECK(rc == KIFMM_ERR_NULL, "%s evaluate(NULL densities) gave %d", a->name, rc);
            CHECK(untouched(a, out1, no), "%s evaluate(NULL densities) wrote out", a->name);
        }
        if ((calls & 0x18) == 0x10 && nt > 0) {
            rc = a->evaluate(h, q1, NULL);
            CHECK(rc == KIFMM_ERR_NULL, "%s evaluate(NULL out) gave %d", a->name, rc);
        }
        rc = eval_rc = a->evaluate(h, q1, out1);
        note("evaluate %d; ", rc);
        check_result(a, "evaluate", rc, out1, NULL, no, 1, bad_q, lb, kmax, &used, nt);
        if (rc == KIFMM_SUCCESS && ns == 0)
            for (i = 0; i < no; i++)
                CHECK(at(a, out1, i) == 0.0, "%s evaluate without sources: out[%lld] = %g",
                      a->name, (long long)i, at(a, out1, i));

        /* evaluate_many: out of place, or in place over the densities */
        {
            int64_t nv = nrhs > 0 ? nrhs : 1;
            int64_t len = nqv > no ? nqv : no;
            int inplace = (calls & 0x20) && nrhs > 0;
            int64_t outlen = inplace ? nv * len : nv * no;
            size_t bytes = (size_t)(outlen + 8) * rsize(a);
            void *snap;
            int bad_all = nonfinite_at(a, rq, nv * nqv);
            bufm = sentinel_array(a, outlen);
            if (inplace) memcpy(bufm, rq, (size_t)(nv * nqv) * rsize(a));
            snap = xmalloc(bytes);
            memcpy(snap, bufm, bytes);
            rc = a->evaluate_many(h, nrhs, inplace ? bufm : rq, bufm);
            note("evaluate_many(%d%s) %d; ", nrhs, inplace ? ", in place" : "", rc);
            if (nrhs < 0) {
                CHECK(rc == KIFMM_ERR_COUNT, "%s evaluate_many(%d) gave %d", a->name, nrhs, rc);
                CHECK(memcmp(snap, bufm, bytes) == 0, "%s evaluate_many(%d) wrote out", a->name,
                      nrhs);
            } else if (nrhs == 0) {
                CHECK(rc == KIFMM_SUCCESS, "%s evaluate_many(0) gave %d", a->name, rc);
                CHECK(memcmp(snap, bufm, bytes) == 0, "%s evaluate_many(0) wrote out", a->name);
            } else {
                /* the bound is the first vector's: the others' overflow is not judged */
                check_result(a, "evaluate_many", rc, bufm, snap, nv * no, nv == 1 && !inplace,
                             bad_all, nv == 1 ? lb : INFINITY, kmax, &used, nt);
                if (rc == KIFMM_SUCCESS)
                    CHECK(is_sentinel(a, bufm, outlen), "%s evaluate_many wrote past the outputs",
                          a->name);
                if (nrhs == 1)
                    CHECK(rc == eval_rc, "%s evaluate_many(1) gave %d, evaluate %d", a->name,
                          rc, eval_rc);
                /* one vector is evaluate's own computation: bit for bit */
                if (nrhs == 1 && no > 0 && eval_rc == KIFMM_SUCCESS && rc == KIFMM_SUCCESS)
                    CHECK(memcmp(bufm, out1, (size_t)no * rsize(a)) == 0,
                          "%s evaluate_many(1) differs from evaluate", a->name);
            }
            free(snap);
            free(bufm);
        }

        /* update_points to the same points: the outputs of a handle made on
         * them, evaluate's own, bit for bit; an update refused (a NaN in a
         * copy of the sources) changes nothing */
        if ((calls & 0x06) == 0x02 && eval_rc == KIFMM_SUCCESS && no > 0 && ns > 0) {
            void *out2 = sentinel_array(a, no), *bad = xmalloc((size_t)(3 * ns) * rsize(a));
            memcpy(bad, rs, (size_t)(3 * ns) * rsize(a));
            if (a->fl) ((float *)bad)[3 * ns - 1] = NAN;
            else ((double *)bad)[3 * ns - 1] = NAN;
            rc = a->update(h, ns, bad, nt, rt == rs ? bad : rt);
            CHECK(rc == KIFMM_ERR_NONFINITE, "%s update_points with a NaN gave %d", a->name, rc);
            rc = a->update(h, ns, rs, nt, rt);
            note("update_points %d; ", rc);
            CHECK(rc == KIFMM_SUCCESS, "%s update_points to the same points gave %d", a->name, rc);
            if (rc == KIFMM_SUCCESS) {
                rc = a->evaluate(h, q1, out2);
                CHECK(rc == eval_rc && memcmp(out2, out1, (size_t)no * rsize(a)) == 0,
                      "%s after update_points to the same points evaluate differs (%d)", a->name,
                      rc);
            }
            free(out2);
            free(bad);
        }

        /* a second handle of the kernel on this one's tree, with its
         * options: evaluate's outputs, bit for bit */
        if ((calls & 0x06) == 0x04 && eval_rc == KIFMM_SUCCESS && no > 0) {
            void *g = NULL, *out2 = sentinel_array(a, no);
            kifmm_opts used;
            rc = a->options(h, &used);
            if (used.tol != 0.0) used.order = 0; /* the order tol picks, picked again */
            if (rc == KIFMM_SUCCESS) rc = a->on_tree(&g, &used, h);
            note("create_on_tree %d; ", rc);
            CHECK(rc == KIFMM_SUCCESS, "%s create_on_tree with the handle's options gave %d",
                  a->name, rc);
            if (rc == KIFMM_SUCCESS) {
                rc = a->evaluate(g, q1, out2);
                CHECK(rc == eval_rc && memcmp(out2, out1, (size_t)no * rsize(a)) == 0,
                      "%s on the handle's tree evaluate differs (%d)", a->name, rc);
            }
            a->destroy(g);
            free(out2);
        }

        /* direct at a few targets (free space only) against evaluate */
        if (nt > 0) {
            int64_t k = nt < 6 ? nt : 6;
            void *ref = sentinel_array(a, k * a->td);
            const void *dq = (calls & 0xC0) == 0xC0 ? NULL : rq;
            long double *abs_sum = (long double *)xmalloc((size_t)k * sizeof(long double));
            long double kk = INFINITY, lbk = log_bound(a, &used, ns, rs, rq, nt, rt, 0, k,
                                                       abs_sum, &kk);
            rc = a->direct(&o, ns, rs, dq, k, rt, ref);
            note("direct %d; ", rc);
            if (L > 0.0) {
                CHECK(rc == KIFMM_ERR_PERIODIC || (rc == KIFMM_ERR_NULL && !dq && ns > 0) ||
                          (rc == KIFMM_ERR_DENSITY && bad_q),
                      "%s direct with a period gave %d", a->name, rc);
                CHECK(untouched(a, ref, k * a->td), "%s direct failed (%d) but wrote out",
                      a->name, rc);
            } else if (!dq && ns > 0) {
                CHECK(rc == KIFMM_ERR_NULL, "%s direct(NULL densities) gave %d", a->name, rc);
                CHECK(untouched(a, ref, k * a->td), "%s direct failed (%d) but wrote out",
                      a->name, rc);
            } else {
                check_result(a, "direct", rc, ref, NULL, k * a->td, 1, bad_q, lbk, kk, &used, k);
                if (rc == KIFMM_SUCCESS && eval_rc == KIFMM_SUCCESS && lb < (a->fl ? 25.0L : 280.0L)) {
                    for (i = 0; i < k * a->td; i++) {
                        double e = at(a, out1, i), x = at(a, ref, i);
                        long double frac = used.order <= 2 ? 0.25L
                                           : used.order == 3 ? 0.10L : 0.05L;
                        long double tolr = frac * abs_sum[i / a->td] +
                                           (a->fl ? 1e-30L : 1e-290L);
                        CHECK(fabsl((long double)e - (long double)x) <= tolr,
                              "%s evaluate out[%lld] = %.17g, direct %.17g, allowed %Lg",
                              a->name, (long long)i, e, x, tolr);
                    }
                }
            }
            free(abs_sum);
            free(ref);
        }
        /* direct without targets reads no densities */
        if (ns > 0 && (calls & 0xC0) == 0x80) {
            void *ref = sentinel_array(a, 0);
            rc = a->direct(&o, ns, rs, NULL, 0, NULL, ref);
            CHECK(untouched(a, ref, 0), "%s direct(no targets) wrote out", a->name);
            CHECK(rc == KIFMM_SUCCESS || L > 0.0, "%s direct(no targets) gave %d", a->name, rc);
            free(ref);
        }
        /* direct into the targets' own array: KIFMM_ERR_OVERLAP, nothing written */
        if (ns > 0 && nt > 0 && (calls & 0xC0) == 0x40 && L == 0.0) {
            int64_t k = nt < 4 ? nt : 4;
            size_t b = (size_t)(3 * nt) * rsize(a);
            void *tcopy = xmalloc(b), *snap = xmalloc(b);
            memcpy(tcopy, rt, b);
            memcpy(snap, rt, b);
            rc = a->direct(&o, ns, rs, rq, k, tcopy, tcopy);
            CHECK(rc != KIFMM_SUCCESS, "%s direct with out over the targets succeeded", a->name);
            CHECK(memcmp(tcopy, snap, b) == 0, "%s direct failed (%d) but wrote over the targets",
                  a->name, rc);
            free(tcopy);
            free(snap);
        }
        CHECK(a->stats(h, &st) == KIFMM_SUCCESS, "%s stats failed", a->name);
        check_stats(a, &st);
        free(out1);
        a->destroy(h);
    } else {
        /* direct on whatever create refused: its own checks, no crash */
        int64_t k = count_ok(nt) ? (nt < 4 ? nt : 4) : nt;
        void *ref = sentinel_array(a, count_ok(k) ? k * a->td : 0);
        const void *dq = (calls & 0xC0) == 0xC0 ? NULL : rq;
        rc = a->direct(&o, ns, rs, dq, k, rt, ref);
        note("direct %d; ", rc);
        if (rc != KIFMM_SUCCESS) CHECK(untouched(a, ref, count_ok(k) ? k * a->td : 0),
                                       "%s direct failed (%d) but wrote out", a->name, rc);
        free(ref);
    }
    a->destroy(NULL);

    unmute();
    if (rt && rt != rs) free(rt);
    free(rs);
    free(xs);
    free(q);
    free(rq);
}

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    trace = getenv("FUZZ_TRACE") != NULL;
#ifdef _OPENMP
    omp_set_num_threads(2); /* opts.nthreads = 0 means this */
#endif
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    run_one(data, size);
    return 0;
}
