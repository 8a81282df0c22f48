/* test_estimate.c - <prefix>_estimate_bytes against the memory the handle
 * then holds (stats.bytes, every block counted where create allocates it).
 *
 * Uniform points, the estimate's model: laplace (double and float), stokes
 * and yukawa (one set of operators per level), orders 4, 6 (and 8 outside
 * the quick builds), sources alone and separate targets, two sizes. Each
 * case within 0.8 to 1.25 of the estimate, and over the group the mean of
 * |ln(held / estimate)| at most 0.03 (bench/bench_memory.c, 315 such
 * cases, orders 2 to 10: 0.0055; cases 0.961 to 1.204, 95 % within 0.977
 * and 1.022; a level about to split makes the outliers). Periodic trees:
 * 0.9 to 1.1.
 * Points on a sphere and in clusters: laplace within 0.5 to 2 (measured
 * 0.58 to 1.74 for the scale-invariant kernels, docs/api.md "Memory").
 * Empty sets: the estimate is the handle's size, exactly. And the errors:
 * NULL, bad counts, bad options, bad parameters; *bytes untouched.
 * helmholtz_grad with opts.domain, where create raises the wide levels'
 * orders (>>orders in kifmm.h): within 0.9 to 1.1 (measured 0.987 to
 * 1.006, orders 3 to 12, 1 to 5 wavelengths), and KIFMM_ERR_FREQUENCY from
 * both where no order serves a level. */
#include "kifmm.h"
#define KIFMM_KERNEL laplace
#define KIFMM_REAL float
#include "kifmm.h"
#define KIFMM_KERNEL stokes
#include "kifmm.h"
#define KIFMM_KERNEL yukawa
#include "kifmm.h"
#define KIFMM_KERNEL helmholtz_grad
#include "kifmm.h"

#include "test.h"

#ifdef KIFMM_TEST_QUICK
#define NSMALL 8000
#define NLARGE 40000
#define PMAX 6
#else
#define NSMALL 10000
#define NLARGE 60000
#define PMAX 8
#endif

/* held / estimate for handle type P of precision R over ns sources x and
 * nt targets y (y == x: the targets are the sources); 0 on an error. */
#define EST_RATIO(P, R)                                                                          \
    static double ratio_##P(const kifmm_opts *o, int64_t ns, const double *x, int64_t nt,        \
                            const double *y)                                                     \
    {                                                                                            \
        R *xs = (R *)malloc(sizeof(R) * (size_t)(3 * ns + 3));                                   \
        R *ys = y == x ? xs : (R *)malloc(sizeof(R) * (size_t)(3 * nt + 3));                     \
        P *h = NULL;                                                                             \
        kifmm_stats st;                                                                          \
        double est = -1.0;                                                                       \
        int64_t i;                                                                               \
        int rc;                                                                                  \
        memset(&st, 0, sizeof st);                                                               \
        for (i = 0; i < 3 * ns; i++) xs[i] = (R)x[i];                                            \
        for (i = 0; y != x && i < 3 * nt; i++) ys[i] = (R)y[i];                                  \
        rc = P##_estimate_bytes(o, ns, y == x ? KIFMM_SAME_POINTS : nt, &est);                   \
        if (!rc) rc = P##_create(&h, o, ns, xs, nt, ys);                                         \
        if (!rc) rc = P##_stats(h, &st);                                                         \
        P##_destroy(h);                                                                          \
        if (ys != xs) free(ys);                                                                  \
        free(xs);                                                                                \
        if (rc) printf("  %s: %s\n", #P, kifmm_strerror(rc));                                    \
        return rc || !(est > 0.0) ? 0.0 : st.bytes / est;                                        \
    }
EST_RATIO(kifmm_laplace, double)
EST_RATIO(kifmm_laplacef, float)
EST_RATIO(kifmm_stokes, double)
EST_RATIO(kifmm_yukawa, double)
EST_RATIO(kifmm_helmholtz_grad, double)

static double ratio_of(int k, const kifmm_opts *o, int64_t ns, const double *x, int64_t nt,
                       const double *y)
{
    switch (k) {
    case 0: return ratio_kifmm_laplace(o, ns, x, nt, y);
    case 1: return ratio_kifmm_laplacef(o, ns, x, nt, y);
    case 2: return ratio_kifmm_stokes(o, ns, x, nt, y);
    default: return ratio_kifmm_yukawa(o, ns, x, nt, y);
    }
}

static const char *kname[4] = {"laplace", "laplacef", "stokes", "yukawa"};

static void check_uniform(void)
{
    const int64_t sizes[2] = {NSMALL, NLARGE};
    double *x = t_doubles(3 * NLARGE), *y = t_doubles(3 * NLARGE), sum = 0.0, lo = 1e300, hi = 0.0;
    t_rng r = t_rng_seed(4100);
    int k, p, s, sep, cases = 0;
    t_gen_cube(&r, NLARGE, x, 0.0, 1.0);
    t_gen_cube(&r, NLARGE, y, 0.0, 1.0);
    for (k = 0; k < 4; k++)
        for (p = 4; p <= PMAX; p += 2)
            for (s = 0; s < 2; s++)
                for (sep = 0; sep < 2; sep++) {
                    kifmm_opts o;
                    double q;
                    if (k == 2 && p > 6) continue; /* stokes at p = 8: 0.4 GB, 1.5 s a case */
                    memset(&o, 0, sizeof o);
                    o.order = p;
                    q = ratio_of(k, &o, sizes[s], x, sizes[s], sep ? y : x);
                    CHECK(q >= 0.8 && q <= 1.25, "%s p = %d, %lld points%s: held / estimate %.3f",
                          kname[k], p, (long long)sizes[s], sep ? ", separate targets" : "", q);
                    if (q > 0.0) sum += fabs(log(q));
                    lo = q < lo ? q : lo;
                    hi = q > hi ? q : hi;
                    cases++;
                }
    printf("  uniform: %d cases, held / estimate %.3f to %.3f, mean |ln| %.4f\n", cases, lo, hi,
           sum / cases);
    CHECK(sum / cases <= 0.03, "mean |ln(held / estimate)| %.4f over %d cases", sum / cases, cases);
    free(x);
    free(y);
}

static void check_periodic(void)
{
    const int64_t n = NSMALL;
    double *x = t_doubles(3 * n);
    t_rng r = t_rng_seed(4200);
    int k, np;
    t_gen_cube(&r, n, x, 0.0, 1.0);
    for (k = 0; k < 4; k++)
        for (np = 1; np <= 3; np += 2) {
            kifmm_opts o;
            double q;
            int d;
            memset(&o, 0, sizeof o);
            o.order = k == 2 ? 4 : 6;
            for (d = 0; d < np; d++) o.period[d] = 1.0;
            q = ratio_of(k, &o, n, x, n, x);
            CHECK(q >= 0.9 && q <= 1.1, "%s p = %d, %d periodic direction%s: held / estimate %.3f",
                  kname[k], o.order, np, np > 1 ? "s" : "", q);
        }
    free(x);
}

/* On a sphere and in clusters the estimate's uniform tree is not the
 * tree, and the workspace (the FFT M2L's spectra of more parents, more
 * expansions) is what it misses: held - estimate was 23.6 MB for laplace
 * at p = 6, 40,000 points on a sphere, both when the plan kept the 316
 * transfer vectors' spectra (held / estimate 1.77) and since it keeps the
 * 16 they are turned from (1.86; 2.04 and 2.07 on a sphere and clustered
 * in the clang-c99 configuration). The bound covers the ratio with a
 * margin; docs/api.md ("Memory") gives the range measured over 54 such
 * cases (0.56 to 2.01). */
static void check_other_sets(void)
{
    const int64_t n = NLARGE;
    double *x = t_doubles(3 * n);
    t_rng r = t_rng_seed(4300);
    int d, p;
    for (d = 0; d < 2; d++) {
        if (d == 0) t_gen_sphere(&r, n, x);
        else t_gen_blobs(&r, n, x);
        for (p = 4; p <= 6; p += 2) {
            kifmm_opts o;
            double q;
            memset(&o, 0, sizeof o);
            o.order = p;
            q = ratio_of(0, &o, n, x, n, x);
            CHECK(q >= 0.5 && q <= 2.5, "laplace p = %d, %s: held / estimate %.3f", p,
                  d ? "clustered" : "sphere", q);
        }
    }
    free(x);
}

/* No sources or no targets: create's handle holds only itself. One point:
 * a one-box tree. */
static void check_small(void)
{
    const double x[6] = {0.1, 0.2, 0.3, 0.4, 0.5, 0.6};
    kifmm_laplace *h = NULL;
    kifmm_stats st;
    double est = -1.0, q;
    int rc, k;
    memset(&st, 0, sizeof st);
    rc = kifmm_laplace_create(&h, NULL, 0, NULL, 2, x);
    if (!rc) rc = kifmm_laplace_stats(h, &st);
    kifmm_laplace_destroy(h);
    if (!rc) rc = kifmm_laplace_estimate_bytes(NULL, 0, 2, &est);
    CHECK(rc == KIFMM_SUCCESS && est == st.bytes, "no sources: estimate %.0f, held %.0f: %s", est,
          rc ? 0.0 : st.bytes, kifmm_strerror(rc));
    rc = kifmm_laplace_estimate_bytes(NULL, 5, 0, &est);
    CHECK(rc == KIFMM_SUCCESS && est == st.bytes, "no targets: estimate %.0f, held %.0f: %s", est,
          st.bytes, kifmm_strerror(rc));
    for (k = 0; k < 4; k++) {
        q = ratio_of(k, NULL, 2, x, 2, x);
        CHECK(q >= 0.9 && q <= 1.1, "%s, 2 points: held / estimate %.3f", kname[k], q);
    }
}

/* Bad input: the code create would give, and *bytes untouched. */
static void check_errors(void)
{
    const double sentinel = -7.0;
    double b = sentinel;
    kifmm_opts o;
    int rc;
    rc = kifmm_laplace_estimate_bytes(NULL, 10, 10, NULL);
    CHECK(rc == KIFMM_ERR_NULL, "bytes NULL: %s", kifmm_strerror(rc));
    rc = kifmm_laplace_estimate_bytes(NULL, -1, 10, &b);
    CHECK(rc == KIFMM_ERR_COUNT && b == sentinel, "nsources -1: %s", kifmm_strerror(rc));
    rc = kifmm_laplace_estimate_bytes(NULL, 10, -2, &b);
    CHECK(rc == KIFMM_ERR_COUNT && b == sentinel, "ntargets -2: %s", kifmm_strerror(rc));
    rc = kifmm_laplace_estimate_bytes(NULL, KIFMM_MAX_POINTS + 1, 10, &b);
    CHECK(rc == KIFMM_ERR_COUNT && b == sentinel, "nsources past KIFMM_MAX_POINTS: %s",
          kifmm_strerror(rc));
    rc = kifmm_laplace_estimate_bytes(NULL, 10, INT64_MAX, &b);
    CHECK(rc == KIFMM_ERR_COUNT && b == sentinel, "ntargets INT64_MAX: %s", kifmm_strerror(rc));
    memset(&o, 0, sizeof o);
    o.order = KIFMM_MAX_ORDER + 1;
    rc = kifmm_laplace_estimate_bytes(&o, 10, 10, &b);
    CHECK(rc == KIFMM_ERR_ORDER && b == sentinel, "order 13: %s", kifmm_strerror(rc));
    o.order = 6;
    o.tol = 1e-6;
    rc = kifmm_laplace_estimate_bytes(&o, 10, 10, &b);
    CHECK(rc == KIFMM_ERR_TOL && b == sentinel, "tol with order: %s", kifmm_strerror(rc));
    o.order = 0;
    o.tol = 1e-5;
    rc = kifmm_laplacef_estimate_bytes(&o, 10, 10, &b);
    CHECK(rc == KIFMM_ERR_TOL && b == sentinel, "float, tol 1e-5: %s", kifmm_strerror(rc));
    memset(&o, 0, sizeof o);
    o.period[1] = -1.0;
    rc = kifmm_laplace_estimate_bytes(&o, 10, 10, &b);
    CHECK(rc == KIFMM_ERR_PERIOD && b == sentinel, "period -1: %s", kifmm_strerror(rc));
    memset(&o, 0, sizeof o);
    o.kernel_param[0] = NAN;
    rc = kifmm_yukawa_estimate_bytes(&o, 10, 10, &b);
    CHECK(rc == KIFMM_ERR_PARAM && b == sentinel, "yukawa, lambda NaN: %s", kifmm_strerror(rc));
    memset(&o, 0, sizeof o);
    o.nthreads = -1;
    rc = kifmm_stokes_estimate_bytes(&o, 10, 10, &b);
    CHECK(rc == KIFMM_ERR_NTHREADS && b == sentinel, "nthreads -1: %s", kifmm_strerror(rc));
}

/* opts.tol: the estimate of the order create picks. */
static void check_tol(void)
{
    kifmm_opts o, used;
    kifmm_laplace *h = NULL;
    double a = -1.0, b = -2.0, *x = t_doubles(3 * NSMALL);
    t_rng r = t_rng_seed(4400);
    int rc;
    t_gen_cube(&r, NSMALL, x, 0.0, 1.0);
    memset(&o, 0, sizeof o);
    o.tol = 1e-7;
    rc = kifmm_laplace_create(&h, &o, NSMALL, x, NSMALL, x);
    if (!rc) rc = kifmm_laplace_options(h, &used);
    kifmm_laplace_destroy(h);
    if (!rc) rc = kifmm_laplace_estimate_bytes(&o, NSMALL, KIFMM_SAME_POINTS, &a);
    used.tol = 0.0;
    if (!rc) rc = kifmm_laplace_estimate_bytes(&used, NSMALL, KIFMM_SAME_POINTS, &b);
    CHECK(rc == KIFMM_SUCCESS && a == b, "tol 1e-7: %.0f, its order %d: %.0f (%s)", a,
          rc ? 0 : used.order, b, kifmm_strerror(rc));
    free(x);
}

/* helmholtz_grad in the unit cube given as opts.domain: orders 4, 6 and 8
 * at 2 wavelengths across (no level raised) and 5 (level 2 raised: the
 * handle holds more), and 7 (past order 12's limit). */
static void check_waves(void)
{
    static const int order[3] = {4, 6, 8};
    double *x = t_doubles(3 * NSMALL), b = -7.0;
    t_rng r = t_rng_seed(4500);
    kifmm_helmholtz_grad *h = NULL;
    kifmm_opts o;
    int i, w, rc;
    t_gen_cube(&r, NSMALL, x, 0.0, 1.0);
    memset(&o, 0, sizeof o);
    o.domain[0] = o.domain[1] = o.domain[2] = o.domain[3] = 0.5;
    for (i = 0; i < 3; i++) {
        double e[2] = {0.0, 0.0};
        o.order = order[i];
        for (w = 0; w < 2; w++) {
            double q;
            o.kernel_param[0] = 2.0 * 3.14159265358979323846 * (w ? 5.0 : 2.0);
            q = ratio_kifmm_helmholtz_grad(&o, NSMALL, x, NSMALL, x);
            rc = kifmm_helmholtz_grad_estimate_bytes(&o, NSMALL, KIFMM_SAME_POINTS, &e[w]);
            CHECK(q >= 0.9 && q <= 1.1 && !rc, "helmholtz_grad p = %d, %d wavelengths: held / estimate %.3f",
                  o.order, w ? 5 : 2, q);
        }
        CHECK(e[1] > 1.05 * e[0], "p = %d: estimate %.0f at 5 wavelengths, %.0f at 2 (no level raised?)",
              o.order, e[1], e[0]);
    }
    o.kernel_param[0] = 2.0 * 3.14159265358979323846 * 7.0;
    rc = kifmm_helmholtz_grad_estimate_bytes(&o, NSMALL, KIFMM_SAME_POINTS, &b);
    CHECK(rc == KIFMM_ERR_FREQUENCY && b == -7.0, "7 wavelengths: estimate %s", kifmm_strerror(rc));
    rc = kifmm_helmholtz_grad_create(&h, &o, NSMALL, x, NSMALL, x);
    kifmm_helmholtz_grad_destroy(h);
    CHECK(rc == KIFMM_ERR_FREQUENCY, "7 wavelengths: create %s", kifmm_strerror(rc));
    free(x);
}

int main(void)
{
    t_group("errors");
    check_errors();
    t_group("empty and tiny sets");
    check_small();
    t_group("opts.tol");
    check_tol();
    t_group("uniform points");
    check_uniform();
    t_group("periodic trees");
    check_periodic();
    t_group("points on a sphere, clustered points");
    check_other_sets();
    t_group("helmholtz_grad, wide levels");
    check_waves();
    return t_finish();
}
