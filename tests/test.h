/* tests/test.h - a tiny test harness and the helpers shared by the kifmm.h tests.
 *
 * Include it AFTER kifmm.h (the API table below uses kifmm_opts).
 *
 *   CHECK(cond, fmt, ...)          count a pass, or count a failure and print a line
 *   CHECK_ERR(err, bound, fmt,...) check err <= bound and always print the figure
 *   t_finish()                     print "RESULT <passed> <failed>"; returns 1 on failure
 *
 * Helpers: a deterministic RNG (splitmix64), point generators (cube, sphere,
 * clustered, degenerate sets), and an independent direct summation of the
 * Laplace potential 1/(4 pi r) and its gradient.  The direct sums never call
 * the library.
 *
 * Everything here is static inline, so that a test using only part of it
 * compiles warning-free.
 */
#ifndef KIFMM_TEST_H
#define KIFMM_TEST_H

#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#define T_PI 3.14159265358979323846

/* ------------------------------------------------------------------------ */
/* Pass / fail counters                                                     */
/* ------------------------------------------------------------------------ */

static inline long *t_counters(void)
{
    static long c[2]; /* [0] passed, [1] failed */
    return c;
}

#define CHECK(cond, ...)                                                      \
    do {                                                                      \
        if (cond) {                                                           \
            t_counters()[0]++;                                                \
        } else {                                                              \
            t_counters()[1]++;                                                \
            printf("  FAIL %s:%d: (%s) ", __FILE__, __LINE__, #cond);         \
            printf(__VA_ARGS__);                                              \
            printf("\n");                                                     \
            fflush(stdout);                                                   \
        }                                                                     \
    } while (0)

static inline void t_check_err(const char *file, int line, double err, double bound,
                               const char *fmt, ...)
{
    char what[256];
    va_list ap;
    int ok = err <= bound; /* a NaN error fails */
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    printf("  %-4s %-62s err %.3e  bound %.1e\n", ok ? "ok" : "FAIL", what, err, bound);
    if (ok) {
        t_counters()[0]++;
    } else {
        t_counters()[1]++;
        printf("  FAIL %s:%d: error above bound\n", file, line);
    }
    fflush(stdout);
}

/* CHECK_ERR(err, bound, fmt, ...): the formatted text names what was measured. */
#define CHECK_ERR(err, bound, ...) t_check_err(__FILE__, __LINE__, (err), (bound), __VA_ARGS__)

/* Wall-clock seconds (informational only: no test depends on a time). */
static inline double t_wall(void)
{
#ifdef _OPENMP
    return omp_get_wtime();
#else
    return (double)clock() / (double)CLOCKS_PER_SEC;
#endif
}

/* Starts a group of checks; prints the time spent since the previous group. */
static inline void t_group(const char *name)
{
    static double last = -1.0;
    double now = t_wall();
    if (last >= 0.0) printf("   (%.1fs)\n", now - last);
    last = now;
    printf("== %s\n", name);
    fflush(stdout);
}

static inline int t_finish(void)
{
    t_group("end");
    printf("RESULT %ld %ld\n", t_counters()[0], t_counters()[1]);
    fflush(stdout);
    return t_counters()[1] != 0;
}

/* ------------------------------------------------------------------------ */
/* Memory                                                                   */
/* ------------------------------------------------------------------------ */

static inline void *t_malloc_or_die(size_t bytes)
{
    void *p = malloc(bytes ? bytes : 1);
    if (!p) {
        fprintf(stderr, "test: out of memory (%lu bytes)\n", (unsigned long)bytes);
        exit(2);
    }
    return p;
}

static inline double *t_doubles(int64_t n)
{
    return (double *)t_malloc_or_die((size_t)(n > 0 ? n : 1) * sizeof(double));
}

static inline double *t_dup(int64_t n, const double *a)
{
    double *b = t_doubles(n);
    if (n > 0) memcpy(b, a, (size_t)n * sizeof(double));
    return b;
}

static inline void t_fill(int64_t n, double *a, double v)
{
    int64_t i;
    for (i = 0; i < n; i++) a[i] = v;
}

/* ------------------------------------------------------------------------ */
/* Deterministic RNG: splitmix64                                            */
/* ------------------------------------------------------------------------ */

typedef struct t_rng {
    uint64_t s;
} t_rng;

static inline t_rng t_rng_seed(uint64_t seed)
{
    t_rng r;
    r.s = seed;
    return r;
}

static inline uint64_t t_rng_next(t_rng *r)
{
    uint64_t z = (r->s += UINT64_C(0x9E3779B97F4A7C15));
    z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
    return z ^ (z >> 31);
}

/* uniform in [0, 1) with 53 random bits */
static inline double t_rand01(t_rng *r)
{
    return (double)(t_rng_next(r) >> 11) * (1.0 / 9007199254740992.0);
}

static inline double t_uniform(t_rng *r, double lo, double hi)
{
    return lo + (hi - lo) * t_rand01(r);
}

/* standard normal (Box-Muller) */
static inline double t_randn(t_rng *r)
{
    double u1 = 1.0 - t_rand01(r); /* (0, 1] */
    double u2 = t_rand01(r);
    return sqrt(-2.0 * log(u1)) * cos(2.0 * T_PI * u2);
}

/* ------------------------------------------------------------------------ */
/* Point generators (interleaved xyz, 3 doubles per point)                  */
/* ------------------------------------------------------------------------ */

/* uniform in the cube [lo, hi]^3 */
static inline void t_gen_cube(t_rng *r, int64_t n, double *xyz, double lo, double hi)
{
    int64_t i;
    for (i = 0; i < 3 * n; i++) xyz[i] = t_uniform(r, lo, hi);
}

/* uniform on the sphere of centre (0.5, 0.5, 0.5) and radius 0.5 */
static inline void t_gen_sphere(t_rng *r, int64_t n, double *xyz)
{
    int64_t i;
    for (i = 0; i < n; i++) {
        double x, y, z, s;
        do {
            x = t_randn(r);
            y = t_randn(r);
            z = t_randn(r);
            s = sqrt(x * x + y * y + z * z);
        } while (s < 1e-8);
        xyz[3 * i + 0] = 0.5 + 0.5 * x / s;
        xyz[3 * i + 1] = 0.5 + 0.5 * y / s;
        xyz[3 * i + 2] = 0.5 + 0.5 * z / s;
    }
}

/* strongly clustered: 4 Gaussian blobs of width 1e-3 at random centres in
 * [0.1, 0.9]^3 holding 80% of the points, the rest uniform in the unit cube */
static inline void t_gen_blobs(t_rng *r, int64_t n, double *xyz)
{
    double c[4][3];
    int b, k;
    int64_t i;
    for (b = 0; b < 4; b++)
        for (k = 0; k < 3; k++) c[b][k] = t_uniform(r, 0.1, 0.9);
    for (i = 0; i < n; i++) {
        if (t_rand01(r) < 0.8) {
            b = (int)(t_rng_next(r) % 4);
            for (k = 0; k < 3; k++) xyz[3 * i + k] = c[b][k] + 1e-3 * t_randn(r);
        } else {
            for (k = 0; k < 3; k++) xyz[3 * i + k] = t_rand01(r);
        }
    }
}

/* density ~ r^-2 toward the corner (0, 0, 0): the distance r to the corner is
 * uniform in (0, 1], the direction uniform over the positive octant */
static inline void t_gen_corner(t_rng *r, int64_t n, double *xyz)
{
    int64_t i;
    for (i = 0; i < n; i++) {
        double x, y, z, s, rad;
        do {
            x = fabs(t_randn(r));
            y = fabs(t_randn(r));
            z = fabs(t_randn(r));
            s = sqrt(x * x + y * y + z * z);
        } while (s < 1e-8);
        rad = 1.0 - t_rand01(r);
        xyz[3 * i + 0] = rad * x / s;
        xyz[3 * i + 1] = rad * y / s;
        xyz[3 * i + 2] = rad * z / s;
    }
}

/* all n points at (x, y, z) */
static inline void t_gen_coincident(int64_t n, double *xyz, double x, double y, double z)
{
    int64_t i;
    for (i = 0; i < n; i++) {
        xyz[3 * i + 0] = x;
        xyz[3 * i + 1] = y;
        xyz[3 * i + 2] = z;
    }
}

/* two clusters, each uniform in a cube of side `size`: the first n/2 points
 * in [0, size]^3, the others shifted by dist along (1, 1, 1)/sqrt(3) */
static inline void t_gen_two_clusters(t_rng *r, int64_t n, double *xyz, double size, double dist)
{
    int64_t i;
    double shift = dist / sqrt(3.0);
    for (i = 0; i < n; i++) {
        int k;
        for (k = 0; k < 3; k++) xyz[3 * i + k] = size * t_rand01(r) + (i >= n / 2 ? shift : 0.0);
    }
}

/* points on a line: axis-aligned (x varies, y = z = 0.5) or tilted through the cube */
static inline void t_gen_line(t_rng *r, int64_t n, double *xyz, int axis_aligned)
{
    int64_t i;
    for (i = 0; i < n; i++) {
        double t = t_rand01(r);
        if (axis_aligned) {
            xyz[3 * i + 0] = t;
            xyz[3 * i + 1] = 0.5;
            xyz[3 * i + 2] = 0.5;
        } else {
            xyz[3 * i + 0] = t;
            xyz[3 * i + 1] = 0.2 + 0.5 * t;
            xyz[3 * i + 2] = 0.9 - 0.7 * t;
        }
    }
}

/* points on a plane: axis-aligned (z = 0.5) or tilted (x + 2y + 3z = 3) */
static inline void t_gen_plane(t_rng *r, int64_t n, double *xyz, int axis_aligned)
{
    int64_t i;
    for (i = 0; i < n; i++) {
        double u = t_rand01(r), v = t_rand01(r);
        if (axis_aligned) {
            xyz[3 * i + 0] = u;
            xyz[3 * i + 1] = v;
            xyz[3 * i + 2] = 0.5;
        } else {
            xyz[3 * i + 0] = u;
            xyz[3 * i + 1] = v;
            xyz[3 * i + 2] = (3.0 - u - 2.0 * v) / 3.0;
        }
    }
}

/* densities uniform in [lo, hi) */
static inline void t_gen_charges(t_rng *r, int64_t n, double *q, double lo, double hi)
{
    int64_t i;
    for (i = 0; i < n; i++) q[i] = t_uniform(r, lo, hi);
}

/* nv vectors of n sources' sd densities, uniform in [-1, 1) from seed
 * (t_doubles: the caller frees them); neutral: each vector's values sum to
 * zero (periodic scale-invariant kernels need it). */
static inline double *t_densities(uint64_t seed, int64_t n, int sd, int nv, int neutral)
{
    t_rng r = t_rng_seed(seed);
    double *q = t_doubles(n * sd * nv + 1);
    int64_t i;
    int v;
    for (v = 0; v < nv; v++) {
        double *p = q + v * n * sd, sum = 0.0;
        for (i = 0; i < n * sd; i++) sum += p[i] = t_uniform(&r, -1.0, 1.0);
        if (neutral)
            for (i = 0; i < n * sd; i++) p[i] -= sum / (double)(n * sd);
    }
    return q;
}

/* |a - b| in units of the last place of b (2^-1074 below the normal range,
 * DBL_MIN = 2^-1022); a NaN against a number, or a number against a NaN,
 * is infinitely wrong, two NaNs agree */
static inline double t_ulps(double a, double b)
{
    int e;
    if (isnan(a) || isnan(b)) return isnan(a) && isnan(b) ? 0.0 : HUGE_VAL;
    if (a == b) return 0.0;
    if (b == 0.0 || fabs(b) < 2.2250738585072014e-308) return fabs(a - b) / ldexp(1.0, -1074);
    frexp(b, &e);
    return fabs(a - b) / ldexp(1.0, e - 53);
}

/* ------------------------------------------------------------------------ */
/* Independent direct summation                                             */
/* ------------------------------------------------------------------------ */

/* A direct evaluator: res[0..trg_dim-1] at target y from all sources. */
typedef void (*t_direct_fn)(int64_t ns, const double *src, const double *q, const double *y,
                            double *res);

/* Laplace: res[0] = sum_i q_i / (4 pi r), res[1..3] = sum_i -q_i (y - x_i) / (4 pi r^3),
 * pairs with r == 0 skipped. */
static inline void t_direct_laplace(int64_t ns, const double *src, const double *q,
                                    const double *y, double *res)
{
    double p = 0, gx = 0, gy = 0, gz = 0;
    int64_t i;
    for (i = 0; i < ns; i++) {
        double dx = y[0] - src[3 * i + 0];
        double dy = y[1] - src[3 * i + 1];
        double dz = y[2] - src[3 * i + 2];
        double r2 = dx * dx + dy * dy + dz * dz;
        double rinv, qr3;
        if (r2 == 0.0) continue;
        rinv = 1.0 / sqrt(r2);
        p += q[i] * rinv;
        qr3 = q[i] * rinv * rinv * rinv;
        gx -= qr3 * dx;
        gy -= qr3 * dy;
        gz -= qr3 * dz;
    }
    res[0] = p / (4.0 * T_PI);
    res[1] = gx / (4.0 * T_PI);
    res[2] = gy / (4.0 * T_PI);
    res[3] = gz / (4.0 * T_PI);
}

/* Index of the i-th of nsample targets spread evenly over 0..nt-1. */
static inline int64_t t_sample_index(int64_t i, int64_t nsample, int64_t nt)
{
    if (nsample >= nt) return i;
    return (int64_t)(((double)i + 0.5) * (double)nt / (double)nsample);
}

typedef struct t_err {
    double pot;  /* relative L2 error of the potential (column 0) */
    double grad; /* relative L2 error over columns 1..3 (trg_dim 4), else 0 */
} t_err;

/* Relative L2 errors of `out` (row j = target j, trg_dim columns) against the
 * direct evaluator `fn` over min(nsample, nt) evenly spread targets.  When the
 * reference norm is 0 the absolute L2 norm of the difference is returned. */
static inline t_err t_error_vs(t_direct_fn fn, int64_t ns, const double *src, const double *q,
                               int64_t nt, const double *trg, const double *out, int trg_dim,
                               int64_t nsample)
{
    t_err e;
    double num[2] = {0, 0}, den[2] = {0, 0};
    int64_t m = nsample < nt ? nsample : nt, i;
    for (i = 0; i < m; i++) {
        int64_t j = t_sample_index(i, m, nt);
        double ref[8];
        int k;
        fn(ns, src, q, trg + 3 * j, ref);
        for (k = 0; k < trg_dim; k++) {
            double d = out[j * trg_dim + k] - ref[k];
            int c = k == 0 ? 0 : 1;
            num[c] += d * d;
            den[c] += ref[k] * ref[k];
            if (d != d) num[c] = NAN; /* keep NaN visible */
        }
    }
    e.pot = den[0] > 0 ? sqrt(num[0] / den[0]) : sqrt(num[0]);
    e.grad = trg_dim < 4 ? 0.0 : (den[1] > 0 ? sqrt(num[1] / den[1]) : sqrt(num[1]));
    return e;
}

static inline t_err t_error_laplace(int64_t ns, const double *src, const double *q, int64_t nt,
                                    const double *trg, const double *out, int trg_dim,
                                    int64_t nsample)
{
    return t_error_vs(t_direct_laplace, ns, src, q, nt, trg, out, trg_dim, nsample);
}

/* ||a - b|| / ||b|| over n values read with strides sa and sb. */
static inline double t_rel_diff(int64_t n, const double *a, int sa, const double *b, int sb)
{
    double num = 0, den = 0;
    int64_t i;
    for (i = 0; i < n; i++) {
        double d = a[i * sa] - b[i * sb];
        num += d * d;
        den += b[i * sb] * b[i * sb];
        if (d != d) return NAN;
    }
    return den > 0 ? sqrt(num / den) : sqrt(num);
}

static inline double t_max_abs(int64_t n, const double *a)
{
    double m = 0;
    int64_t i;
    for (i = 0; i < n; i++) {
        if (a[i] != a[i]) return NAN;
        if (fabs(a[i]) > m) m = fabs(a[i]);
    }
    return m;
}

/* ------------------------------------------------------------------------ */
/* A type-erased table over one kifmm instance, so one test body can run    */
/* against several kernels.  T_DEFINE_API(prefix, trg_dim) after the        */
/* instance's include defines prefix_t_api(); no trailing semicolon.        */
/* ------------------------------------------------------------------------ */

typedef struct t_api {
    const char *name;
    int trg_dim;
    int (*create)(void **out, const kifmm_opts *opts, int64_t ns, const double *src, int64_t nt,
                  const double *trg);
    int (*evaluate)(void *h, const double *q, double *out);
    void (*destroy)(void *h);
    int (*options)(const void *h, kifmm_opts *used);
} t_api;

/* create() passes the caller's current *out value through, so a test can
 * check that a failing create really overwrites it with NULL. */
#define T_DEFINE_API(P, TRG_DIM)                                                          \
    static inline int P##_t_create(void **out, const kifmm_opts *opts, int64_t ns,        \
                                   const double *src, int64_t nt, const double *trg)      \
    {                                                                                     \
        P *h;                                                                             \
        int rc;                                                                           \
        if (!out) return P##_create(NULL, opts, ns, src, nt, trg);                        \
        h = (P *)*out;                                                                    \
        rc = P##_create(&h, opts, ns, src, nt, trg);                                      \
        *out = (void *)h;                                                                 \
        return rc;                                                                        \
    }                                                                                     \
    static inline int P##_t_evaluate(void *h, const double *q, double *out)               \
    {                                                                                     \
        return P##_evaluate((P *)h, q, out);                                              \
    }                                                                                     \
    static inline void P##_t_destroy(void *h) { P##_destroy((P *)h); }                   \
    static inline int P##_t_options(const void *h, kifmm_opts *used)                      \
    {                                                                                     \
        return P##_options((const P *)h, used);                                           \
    }                                                                                     \
    static inline t_api P##_t_api(void)                                                   \
    {                                                                                     \
        t_api a;                                                                          \
        a.name = #P;                                                                      \
        a.trg_dim = (TRG_DIM);                                                            \
        a.create = P##_t_create;                                                          \
        a.evaluate = P##_t_evaluate;                                                      \
        a.destroy = P##_t_destroy;                                                        \
        a.options = P##_t_options;                                                        \
        return a;                                                                         \
    }

static inline kifmm_opts t_opts(int order, int leaf_size, int max_depth)
{
    kifmm_opts o;
    memset(&o, 0, sizeof o);
    o.order = order;
    o.leaf_size = leaf_size;
    o.max_depth = max_depth;
    return o;
}

/* Create, evaluate and destroy in one go.  Returns the first nonzero code
 * (create's or evaluate's), 0 on success; times in seconds if non-NULL. */
static inline int t_run(const t_api *api, const kifmm_opts *opts, int64_t ns, const double *src,
                        int64_t nt, const double *trg, const double *q, double *out,
                        double *t_create, double *t_eval)
{
    void *h = NULL;
    double t0 = t_wall(), t1, t2;
    int rc = api->create(&h, opts, ns, src, nt, trg);
    t1 = t_wall();
    if (rc != 0) return rc;
    rc = api->evaluate(h, q, out);
    t2 = t_wall();
    api->destroy(h);
    if (t_create) *t_create = t1 - t0;
    if (t_eval) *t_eval = t2 - t1;
    return rc;
}

/* run_P: create, evaluate (nrhs == 1) or evaluate_many, destroy, for an
 * instance P of element type R with SD densities per source and TD outputs
 * per target; float instances get rounded copies of the inputs and return
 * their outputs widened; *used (if not NULL) gets the options used. */
#define T_DEFINE_RUN(P, R, SD, TD)                                                               \
    static int run_##P(const kifmm_opts *o, int64_t ns, const double *s, int64_t nt,           \
                       const double *t, const double *q, int nrhs, double *out,                \
                       kifmm_opts *used)                                                       \
    {                                                                                          \
        P *h = NULL;                                                                           \
        int64_t i, nq = (int64_t)nrhs * ns * (SD), no = (int64_t)nrhs * nt * (TD);            \
        R *sr = (R *)malloc(sizeof(R) * (size_t)(3 * ns + 1));                                 \
        R *tr = (R *)malloc(sizeof(R) * (size_t)(3 * nt + 1));                                 \
        R *qr = (R *)malloc(sizeof(R) * (size_t)(nq + 1));                                     \
        R *orr = (R *)malloc(sizeof(R) * (size_t)(no + 1));                                    \
        int rc;                                                                                \
        for (i = 0; i < 3 * ns; i++) sr[i] = (R)s[i];                                          \
        for (i = 0; i < 3 * nt; i++) tr[i] = (R)t[i];                                          \
        for (i = 0; i < nq; i++) qr[i] = (R)q[i];                                              \
        for (i = 0; i < no; i++) orr[i] = (R)NAN;                                              \
        /* the same array twice when the sources are the targets, as a caller \
         * would pass it (create then sorts once and pairs of leaves are      \
         * computed once for both) */                                         \
        rc = P##_create(&h, o, ns, sr, nt, s == t && ns == nt ? sr : tr);                      \
        if (rc == 0 && used) rc = P##_options(h, used);                                        \
        if (rc == 0)                                                                           \
            rc = nrhs == 1 ? P##_evaluate(h, qr, orr) : P##_evaluate_many(h, nrhs, qr, orr);   \
        for (i = 0; i < no; i++) out[i] = (double)orr[i];                                      \
        P##_destroy(h);                                                                        \
        free(sr); free(tr); free(qr); free(orr);                                               \
        return rc;                                                                             \
    }

/* direct_P: P_direct through doubles (points, densities and outputs
 * converted to and from R); out is left as it was unless it succeeds. */
#define T_DEFINE_DIRECT(P, R, SD, TD)                                                            \
    static int direct_##P(const kifmm_opts *o, int64_t ns, const double *s, const double *q,    \
                          int64_t nt, const double *t, double *out)                             \
    {                                                                                          \
        int64_t i;                                                                             \
        R *sr = (R *)calloc((size_t)(3 * ns + 1), sizeof(R));                                 \
        R *tr = (R *)calloc((size_t)(3 * nt + 1), sizeof(R));                                 \
        R *qr = (R *)calloc((size_t)(ns * (SD) + 1), sizeof(R));                              \
        R *orr = (R *)calloc((size_t)(nt * (TD) + 1), sizeof(R));                             \
        int rc;                                                                                \
        for (i = 0; i < 3 * ns; i++) sr[i] = (R)s[i];                                          \
        for (i = 0; i < 3 * nt; i++) tr[i] = (R)t[i];                                          \
        for (i = 0; i < ns * (SD); i++) qr[i] = (R)q[i];                                       \
        rc = P##_direct(o, ns, sr, qr, nt, tr, orr);                                           \
        for (i = 0; i < nt * (TD) && rc == 0; i++) out[i] = (double)orr[i];                    \
        free(sr); free(tr); free(qr); free(orr);                                               \
        return rc;                                                                             \
    }

/* One-way near-field hooks (double and float) against a long double
 * reference: blocks of 0 to 129 targets and sources (around the stack block
 * of 64 points), coincident pairs, two calls adding up; the error of each
 * output relative to the sum of |terms| (mag) that make it. ref(nb, b, q,
 * a, ref, mag) gives the outputs at the target a of nb sources b (xyz
 * interleaved) with densities q (qd per source); param goes to the hooks;
 * hf NULL: a kernel with the double hook only. Bounds: `bound` in double,
 * 2e-6 in float. */
typedef void (*t_hook_d)(const double *, const double *, const double *, const double *, int64_t,
                         const double *, const double *, const double *, const double *, int64_t,
                         double, double *);
typedef void (*t_hook_f)(const double *, const float *, const float *, const float *, int64_t,
                         const float *, const float *, const float *, const float *, int64_t,
                         float, float *);
typedef void (*t_hook_ref)(int64_t nb, const double *b, const double *q, const double *a,
                           double *ref, double *mag);
static inline void t_hook_case(t_rng *r, int64_t na, int64_t nb, int qd, int td, int fl,
                               const double *param, t_hook_d hd, t_hook_f hf, t_hook_ref ref,
                               double *worst)
{
    double *pa = t_doubles(3 * na + 3), *pb = t_doubles(3 * nb + 3), *dq = t_doubles(qd * nb + 1);
    double *soa = t_doubles(3 * (na + nb) + 6), *out = t_doubles(td * na + 1);
    float *sf = (float *)t_malloc_or_die(sizeof(float) * (size_t)(3 * (na + nb) + 6));
    float *qf = (float *)t_malloc_or_die(sizeof(float) * (size_t)(qd * nb + 1));
    float *of = (float *)t_malloc_or_die(sizeof(float) * (size_t)(td * na + 1));
    double rv[16], mag[16];
    int64_t i;
    int k, c;
    for (i = 0; i < 3 * na; i++) pa[i] = t_uniform(r, -0.5, 0.5);
    for (i = 0; i < 3 * nb; i++) pb[i] = t_uniform(r, -0.5, 0.5);
    for (i = 0; i < na && i < nb; i += 4) /* coincident pairs */
        for (k = 0; k < 3; k++) pa[3 * i + k] = pb[3 * i + k];
    for (i = 0; i < qd * nb; i++) dq[i] = t_uniform(r, -1.0, 1.0);
    if (fl) { /* the reference sees the float inputs */
        for (i = 0; i < 3 * na; i++) pa[i] = (float)pa[i];
        for (i = 0; i < 3 * nb; i++) pb[i] = (float)pb[i];
        for (i = 0; i < qd * nb; i++) dq[i] = (float)dq[i];
    }
    for (k = 0; k < 3; k++) {
        for (i = 0; i < na; i++) soa[k * na + i] = pa[3 * i + k];
        for (i = 0; i < nb; i++) soa[3 * na + k * nb + i] = pb[3 * i + k];
    }
    for (i = 0; i < 3 * (na + nb); i++) sf[i] = (float)soa[i];
    for (i = 0; i < qd * nb; i++) qf[i] = (float)dq[i];
    for (i = 0; i < td * na; i++) out[i] = 0.0, of[i] = 0.0f;
    for (c = 0; c < 2; c++) {
        if (fl)
            hf(param, sf, sf + na, sf + 2 * na, na, sf + 3 * na, sf + 3 * na + nb,
               sf + 3 * na + 2 * nb, qf, nb, 1.5f, of);
        else
            hd(param, soa, soa + na, soa + 2 * na, na, soa + 3 * na, soa + 3 * na + nb,
               soa + 3 * na + 2 * nb, dq, nb, 1.5, out);
    }
    for (i = 0; i < na; i++) {
        ref(nb, pb, dq, pa + 3 * i, rv, mag);
        for (k = 0; k < td; k++) {
            const double o = fl ? (double)of[td * i + k] : out[td * i + k];
            const double e = fabs(o - 3.0 * rv[k]) / (3.0 * mag[k] + 1e-300);
            if (!(e <= worst[fl])) worst[fl] = e;
        }
    }
    free(pa), free(pb), free(dq), free(soa), free(out), free(sf), free(qf), free(of);
}
static inline void t_check_hooks(const char *name, int qd, int td, const double *param,
                                 double bound, t_hook_d hd, t_hook_f hf, t_hook_ref ref)
{
    static const int64_t sizes[] = {0, 1, 3, 7, 8, 9, 17, 64, 65, 129};
    const int nsz = (int)(sizeof sizes / sizeof sizes[0]);
    double worst[2] = {0.0, 0.0};
    t_rng r = t_rng_seed(77 + (uint64_t)qd * 10 + (uint64_t)td);
    int a, b, fl;
    for (a = 0; a < nsz; a++)
        for (b = 0; b < nsz; b++)
            for (fl = 0; fl < (hf ? 2 : 1); fl++) t_hook_case(&r, sizes[a], sizes[b], qd, td, fl, param, hd, hf, ref,
                                                   worst);
    CHECK_ERR(worst[0], bound, "%s_p2p  vs long double, blocks of 0 to 129, two calls", name);
    if (hf) CHECK_ERR(worst[1], 2e-6, "%s_p2pf vs long double on its float inputs", name);
}

#endif /* KIFMM_TEST_H */
