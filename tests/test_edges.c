/* test_edges.c - valid inputs at the edges of the range, each once a defect:
 * Yukawa with lambda times the box size in the hundreds and thousands (NaN
 * with success), neutral charges seen from far away (float spectra),
 * stokes trees with no M2L (operators built anyway: 67 s and 5.6 GB), a
 * cluster below the depth limit (reported), evaluate_many in place, Stokes
 * viscosities near the subnormal range and a kernel that returns NaN
 * (LAPACK errors and noise). Every result against a direct sum written
 * here, independently of the library. */
#include "kifmm.h"
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"
#define KIFMM_KERNEL yukawa
#include "kifmm.h"
#define KIFMM_KERNEL yukawa_grad
#include "kifmm.h"
#define KIFMM_KERNEL stokes
#include "kifmm.h"

/* a kernel that returns NaN when param[0] is 7 (and 1 / (4 pi r) otherwise) */
#define kifmm_kernel_nanny_SRC_DIM 1
#define kifmm_kernel_nanny_TRG_DIM 1
#define kifmm_kernel_nanny_SCALE_INVARIANT 1
#define kifmm_kernel_nanny_DEGREE (-1)
static inline void kifmm_kernel_nanny_eval(const double *param, double dx, double dy, double dz,
                                           double *k)
{
    double r2 = dx * dx + dy * dy + dz * dz;
    k[0] = r2 > 0.0 ? (param[0] == 7.0 ? NAN : 1.0) / (4.0 * 3.14159265358979323846 * sqrt(r2))
                    : 0.0;
}
#define KIFMM_KERNEL nanny
#include "kifmm.h"

#include "test.h"

/* ---- independent direct sums -------------------------------------------- */

static double g_lambda = 1.0, g_mu = 1.0;

/* exp(-lambda r) / (4 pi r) and its gradient, lambda = g_lambda */
static void direct_yukawa(int64_t ns, const double *src, const double *q, const double *y,
                          double *res)
{
    double p = 0, g[3] = {0, 0, 0};
    int64_t i;
    int k;
    for (i = 0; i < ns; i++) {
        double d[3], r2 = 0, r, e;
        for (k = 0; k < 3; k++) {
            d[k] = y[k] - src[3 * i + k];
            r2 += d[k] * d[k];
        }
        if (r2 == 0.0) continue;
        r = sqrt(r2);
        e = q[i] * exp(-g_lambda * r) / r;
        p += e;
        for (k = 0; k < 3; k++) g[k] -= e * (1.0 + g_lambda * r) * d[k] / r2;
    }
    res[0] = p / (4.0 * T_PI);
    for (k = 0; k < 3; k++) res[1 + k] = g[k] / (4.0 * T_PI);
}

/* Stokeslet (delta_ij / r + d_i d_j / r^3) / (8 pi mu), mu = g_mu */
static void direct_stokes(int64_t ns, const double *src, const double *f, const double *y,
                          double *u)
{
    int64_t i;
    int a, b;
    double acc[3] = {0, 0, 0};
    for (i = 0; i < ns; i++) {
        double d[3], r2 = 0, r, fd = 0;
        for (a = 0; a < 3; a++) {
            d[a] = y[a] - src[3 * i + a];
            r2 += d[a] * d[a];
        }
        if (r2 == 0.0) continue;
        r = sqrt(r2);
        for (b = 0; b < 3; b++) fd += d[b] * f[3 * i + b];
        for (a = 0; a < 3; a++) acc[a] += f[3 * i + a] / r + d[a] * fd / (r2 * r);
    }
    for (a = 0; a < 3; a++) u[a] = acc[a] / (8.0 * T_PI * g_mu);
}

/* relative L2 error over all components of nt targets (dim each) */
static double rel_err(t_direct_fn fn, int64_t ns, const double *src, const double *q,
                      int64_t nt, const double *trg, const double *out, int dim,
                      int64_t nsample, double *ref_norm)
{
    double num = 0, den = 0;
    int64_t m = nsample < nt ? nsample : nt, i;
    for (i = 0; i < m; i++) {
        int64_t j = t_sample_index(i, m, nt);
        double ref[8];
        int k;
        fn(ns, src, q, trg + 3 * j, ref);
        for (k = 0; k < dim; k++) {
            double d = out[j * dim + k] - ref[k];
            if (d != d) return NAN;
            num += d * d;
            den += ref[k] * ref[k];
        }
    }
    if (ref_norm) *ref_norm = sqrt(den);
    return den > 0 ? sqrt(num / den) : sqrt(num);
}

/* ---- Yukawa with large lambda ------------------------------------------- */

/* Every lambda from ordinary to one where every pair underflows: no NaN, the
 * direct sum's accuracy where there is a field, zeros where there is none.
 * lambda times the box half-width of the levels that hold operators spans
 * about 1 to 1e5 here. */
static void test_yukawa_lambda(void)
{
    static const double lambdas[] = {1.0, 30.0, 300.0, 1000.0, 1650.0, 2000.0, 3000.0,
                                     5000.0, 2e4, 1e6};
    const int64_t n = 3000;
    double *x = t_doubles(3 * n), *q = t_doubles(n), *out = t_doubles(4 * n);
    t_rng r = t_rng_seed(301);
    int i, g;
    t_group("yukawa and yukawa_grad, 3000 uniform points, lambda 1 to 1e6, p = 6");
    t_gen_cube(&r, n, x, 0.0, 1.0);
    t_gen_charges(&r, n, q, -1.0, 1.0);
    for (i = 0; i < (int)(sizeof lambdas / sizeof lambdas[0]); i++) {
        for (g = 0; g < 2; g++) {
            kifmm_opts o = t_opts(6, 32, 0); /* small leaves: levels down to half-width 1/64 */
            double e, norm;
            int rc;
            o.kernel_param[0] = g_lambda = lambdas[i];
            t_fill(4 * n, out, NAN);
            if (g == 0) {
                kifmm_yukawa *h = NULL;
                rc = kifmm_yukawa_create(&h, &o, n, x, n, x);
                if (!rc) rc = kifmm_yukawa_evaluate(h, q, out);
                kifmm_yukawa_destroy(h);
            } else {
                kifmm_yukawa_grad *h = NULL;
                rc = kifmm_yukawa_grad_create(&h, &o, n, x, n, x);
                if (!rc) rc = kifmm_yukawa_grad_evaluate(h, q, out);
                kifmm_yukawa_grad_destroy(h);
            }
            CHECK(rc == 0, "yukawa%s lambda %g: rc=%d (%s)", g ? "_grad" : "", lambdas[i], rc,
                  kifmm_strerror(rc));
            if (g == 0) {
                /* the potential alone: compare with column 0 of the direct sum */
                double *o4 = t_doubles(4 * n);
                int64_t j;
                for (j = 0; j < n; j++) {
                    o4[4 * j] = out[j];
                    o4[4 * j + 1] = o4[4 * j + 2] = o4[4 * j + 3] = 0.0;
                }
                e = t_error_vs(direct_yukawa, n, x, q, n, x, o4, 4, 400).pot;
                norm = 1.0;
                free(o4);
            } else {
                e = rel_err(direct_yukawa, n, x, q, n, x, out, 4, 400, &norm);
            }
            if (norm > 0) {
                CHECK_ERR(e, 1e-5, "yukawa%s lambda %g, rel L2 error", g ? "_grad" : "",
                          lambdas[i]);
            } else {
                /* every pair underflows in the direct sum: all outputs 0 */
                CHECK(t_max_abs(g ? 4 * n : n, out) == 0.0,
                      "yukawa%s lambda %g: direct sum is 0, FMM max |out| %g", g ? "_grad" : "",
                      lambdas[i], t_max_abs(g ? 4 * n : n, out));
            }
        }
    }
    g_lambda = 1.0;
    free(x);
    free(q);
    free(out);
}

/* ---- neutral charges seen from far away --------------------------------- */

/* Sources in one unit cube, targets in another at distance d (along the
 * diagonal), charges uniform in [-1, 1] less their mean: the far field is the small
 * remainder of cancelling contributions. The bounds are 1.5 times the
 * errors of the double-precision FFT M2L measured on these points; float
 * spectra at p = 6 (-DKIFMM_FFT_SINGLE_MAX_ORDER=6, once the default) gave
 * 3.9e-5 and 5.2e-6, and at p = 5 (=5, once the default) 8.8e-7 to 2.2e-5
 * at distance 30, as the rounding of the operators fell. */
static void test_neutral_far(void)
{
    static const double dist[2] = {30.0, 300.0};
    /* [order 4, 5, 6][distance 30, 300]: 1.5 times 1.7e-4, 7.8e-4; 5.2e-6,
     * 8.7e-6; 1.6e-6, 3.2e-6 */
    static const double bound[3][2] = {{2.5e-4, 1.2e-3}, {7.8e-6, 1.3e-5}, {2.4e-6, 4.8e-6}};
    const int64_t n = 20000;
    double *s = t_doubles(3 * n), *t = t_doubles(3 * n), *q = t_doubles(n), *out = t_doubles(n);
    t_rng r = t_rng_seed(302);
    int d, p;
    t_group("laplace, 20000 neutral charges, targets at distance 30 and 300");
    t_gen_charges(&r, n, q, -1.0, 1.0);
    {
        /* exactly neutral: the far field is the dipole's and beyond */
        double mean = 0.0;
        int64_t i;
        for (i = 0; i < n; i++) mean += q[i];
        mean /= (double)n;
        for (i = 0; i < n; i++) q[i] -= mean;
    }
    for (d = 0; d < 2; d++) {
        int64_t i;
        t_gen_cube(&r, n, s, 0.0, 1.0);
        t_gen_cube(&r, n, t, 0.0, 1.0);
        for (i = 0; i < 3 * n; i++) t[i] += dist[d] / sqrt(3.0);
        for (p = 0; p < 3; p++) {
            kifmm_opts o = t_opts(4 + p, 0, 0);
            kifmm_laplace *h = NULL;
            int rc = kifmm_laplace_create(&h, &o, n, s, n, t);
            t_err e;
            if (!rc) rc = kifmm_laplace_evaluate(h, q, out);
            kifmm_laplace_destroy(h);
            CHECK(rc == 0, "rc=%d", rc);
            e = t_error_laplace(n, s, q, n, t, out, 1, 500);
            CHECK_ERR(e.pot, bound[p][d], "p=%d, distance %g", 4 + p, dist[d]);
        }
    }
    free(s);
    free(t);
    free(q);
    free(out);
}

/* ---- Stokes: a tree with no M2L, and the viscosity's range -------------- */

static void run_stokes(int64_t n, const double *x, const double *f, int order, double mu,
                       double bound, const char *what, double max_mib)
{
    kifmm_stokes *h = NULL;
    kifmm_opts o = t_opts(order, 0, 0);
    kifmm_stats st;
    double *u = t_doubles(3 * n), e;
    int rc;
    o.kernel_param[0] = g_mu = mu;
    t_fill(3 * n, u, NAN);
    rc = kifmm_stokes_create(&h, &o, n, x, n, x);
    if (!rc) rc = kifmm_stokes_evaluate(h, f, u);
    CHECK(rc == 0, "stokes %s rc=%d (%s)", what, rc, kifmm_strerror(rc));
    if (!rc && max_mib > 0) {
        memset(&st, 0, sizeof st);
        kifmm_stokes_stats(h, &st);
        CHECK(st.bytes <= max_mib * 1048576.0,
              "stokes %s: %.0f MiB held, at most %.0f expected (%d levels)", what,
              st.bytes / 1048576.0, max_mib, st.levels);
        printf("       %s: %d levels, %.1f MiB held, create %.3f s\n", what, st.levels,
               st.bytes / 1048576.0, st.t_tree + st.t_operators);
    }
    kifmm_stokes_destroy(h);
    e = rel_err(direct_stokes, n, x, f, n, x, u, 3, 300, NULL);
    CHECK_ERR(e, bound, "stokes %s, rel L2 error", what);
    g_mu = 1.0;
    free(u);
}

static void test_stokes(void)
{
    const int64_t n = 3000;
    double *x = t_doubles(3 * n), *f = t_doubles(3 * n);
    t_rng r = t_rng_seed(303);
    static const double bad_mu[] = {1e-310, 4.9e-324, 1e-300, 1e-151, 2e150, 1e200, -1.0};
    int i;
    t_group("stokes: no operators for a tree without M2L; viscosity range");
    t_gen_cube(&r, n, x, 0.0, 1.0);
    t_gen_charges(&r, 3 * n, f, -1.0, 1.0);
    /* 3000 points at p = 10: leaves of 512, two levels, a direct sum (the
     * dense M2L's operators alone were 5.6 GB) */
    run_stokes(n, x, f, 10, 1.0, 1e-12, "p=10, two levels", 64.0);
    run_stokes(n, x, f, 6, 1e-150, 1e-5, "p=6 mu=1e-150", 0);
    run_stokes(n, x, f, 6, 1e150, 1e-5, "p=6 mu=1e150", 0);
    for (i = 0; i < (int)(sizeof bad_mu / sizeof bad_mu[0]); i++) {
        kifmm_stokes *h = (kifmm_stokes *)&r;
        kifmm_opts o = t_opts(6, 0, 0);
        int rc;
        o.kernel_param[0] = bad_mu[i];
        rc = kifmm_stokes_create(&h, &o, n, x, n, x);
        CHECK(rc == KIFMM_ERR_PARAM && h == NULL, "stokes mu=%g: rc=%d (%s), expected %d", bad_mu[i],
              rc, kifmm_strerror(rc), KIFMM_ERR_PARAM);
        if (rc == 0) kifmm_stokes_destroy(h);
    }
    free(x);
    free(f);
}

/* A kernel that gives NaN on the surfaces: a clear code, nothing from LAPACK. */
static void test_nan_kernel(void)
{
    const int64_t n = 4000;
    double *x = t_doubles(3 * n);
    t_rng r = t_rng_seed(304);
    kifmm_nanny *h = (kifmm_nanny *)&r;
    kifmm_opts o = t_opts(6, 0, 0);
    int rc;
    t_group("a kernel that returns NaN");
    t_gen_cube(&r, n, x, 0.0, 1.0);
    o.kernel_param[0] = 7.0;
    rc = kifmm_nanny_create(&h, &o, n, x, n, x);
    CHECK(rc == KIFMM_ERR_KERNEL && h == NULL, "rc=%d (%s), expected KIFMM_ERR_KERNEL", rc,
          kifmm_strerror(rc));
    if (rc == 0) kifmm_nanny_destroy(h);
    o.kernel_param[0] = 1.0;
    h = NULL;
    rc = kifmm_nanny_create(&h, &o, n, x, n, x);
    CHECK(rc == 0, "the same kernel with param 1: rc=%d", rc);
    kifmm_nanny_destroy(h);
    free(x);
}

/* ---- a cluster below the depth limit ------------------------------------ */

/* n points in a cube of side 2^-22 at (0.3, 0.6, 0.2) and one point at the
 * far corner: the root is about 1 wide and the cluster sits inside one box
 * of the deepest level. It becomes one leaf (a direct sum) and stats say
 * so; the result stays right. */
static void test_deep_cluster(void)
{
#ifdef KIFMM_TEST_QUICK
    const int64_t n = 4000;
#else
    const int64_t n = 12000;
#endif
    double *x = t_doubles(3 * (n + 1)), *q = t_doubles(n + 1), *out = t_doubles(4 * (n + 1));
    t_rng r = t_rng_seed(305);
    kifmm_laplace_grad *h = NULL;
    kifmm_opts o = t_opts(6, 0, 0);
    kifmm_stats st;
    int64_t i;
    int k, rc;
    t_group("a cluster smaller than the deepest box");
    for (i = 0; i < n; i++)
        for (k = 0; k < 3; k++)
            x[3 * i + k] = (k == 0 ? 0.3 : k == 1 ? 0.6 : 0.2) + ldexp(t_rand01(&r), -22);
    for (k = 0; k < 3; k++) x[3 * n + k] = 1.0;
    t_gen_charges(&r, n + 1, q, -1.0, 1.0);
    rc = kifmm_laplace_grad_create(&h, &o, n + 1, x, n + 1, x);
    if (!rc) rc = kifmm_laplace_grad_evaluate(h, q, out);
    CHECK(rc == 0, "rc=%d", rc);
    if (!rc) {
        t_err e = t_error_laplace(n + 1, x, q, n + 1, x, out, 4, 300);
        memset(&st, 0, sizeof st);
        kifmm_laplace_grad_stats(h, &st);
        /* the cluster may straddle a box boundary and lose a few points to
         * a neighbouring leaf */
        CHECK(st.max_leaf >= n - n / 100 && st.crowded >= st.max_leaf && st.crowded <= n,
              "stats: crowded %lld, max_leaf %lld, expected about %lld both",
              (long long)st.crowded, (long long)st.max_leaf, (long long)n);
        printf("       stats: %d levels, largest leaf %lld points, %lld points in crowded leaves\n",
               st.levels, (long long)st.max_leaf, (long long)st.crowded);
        CHECK_ERR(e.pot, 1e-10, "potential, rel L2 error (a direct sum)");
    }
    kifmm_laplace_grad_destroy(h);
    free(x);
    free(q);
    free(out);
}

/* ---- evaluate_many in place ---------------------------------------------- */

/* 16 vectors of laplace_grad with out == densities (an array of 16 x 4n
 * whose first 16 n values are the densities), and with out starting inside
 * the densities: the same bits as separate arrays. */
static void test_in_place(void)
{
    const int64_t n = 5000;
    const int nv = 16;
    double *x = t_doubles(3 * n), *q = t_doubles(nv * n), *ref = t_doubles(4 * nv * n);
    double *buf = t_doubles(4 * nv * n + n);
    t_rng r = t_rng_seed(306);
    kifmm_laplace_grad *h = NULL;
    int rc, v, shift;
    t_group("evaluate_many in place, 16 vectors");
    t_gen_cube(&r, n, x, 0.0, 1.0);
    t_gen_charges(&r, nv * n, q, -1.0, 1.0);
    rc = kifmm_laplace_grad_create(&h, NULL, n, x, n, x);
    if (!rc) rc = kifmm_laplace_grad_evaluate_many(h, nv, q, ref);
    CHECK(rc == 0, "out of place rc=%d", rc);
    for (shift = 0; shift <= 1 && !rc; shift++) {
        /* shift 0: out == densities; 1: out starts n values before them */
        double *dens = buf + shift * n, *o = buf;
        int bad = 0;
        memcpy(dens, q, (size_t)(nv * n) * sizeof(double));
        rc = kifmm_laplace_grad_evaluate_many(h, nv, dens, o);
        CHECK(rc == 0, "in place (shift %d) rc=%d", shift, rc);
        for (v = 0; v < nv; v++)
            bad += memcmp(o + (size_t)v * 4 * n, ref + (size_t)v * 4 * n,
                          (size_t)(4 * n) * sizeof(double)) != 0;
        CHECK(bad == 0, "in place (shift %d): %d of %d vectors differ from out of place", shift,
              bad, nv);
    }
    kifmm_laplace_grad_destroy(h);
    free(x);
    free(q);
    free(ref);
    free(buf);
}

/* ---- the timings in kifmm_stats ------------------------------------------ */

/* Each pass of a deep tree takes some time and the passes add up to at most
 * the whole evaluation: a pass timed into another one's field (M2L counted
 * as L2L, say) fails here. Laplace runs the FFT M2L, Stokes the dense one. */
#define T_STATS_CHECK(P, what)                                                      \
    do {                                                                                   \
        P *h = NULL;                                                                       \
        kifmm_stats st;                                                                    \
        double sum;                                                                        \
        int rc = P##_create(&h, &o, n, x, n, x);                                           \
        if (!rc) rc = P##_evaluate(h, q, out);                                             \
        if (!rc) rc = P##_stats(h, &st);                                                   \
        CHECK(rc == 0, "%s: rc=%d", what, rc);                                             \
        if (!rc) {                                                                         \
            sum = st.t_p2m + st.t_m2m + st.t_m2l + st.t_l2l + st.t_p2l + st.t_l2p +        \
                  st.t_m2p + st.t_p2p;                                                     \
            printf("       %s: %d levels; P2M %.4f M2M %.4f M2L %.4f L2L %.4f L2P %.4f "     \
                   "P2P %.4f, sum %.4f of %.4f s\n",                                       \
                   what, st.levels, st.t_p2m, st.t_m2m, st.t_m2l, st.t_l2l, st.t_l2p,       \
                   st.t_p2p, sum, st.t_evaluate);                                          \
            CHECK(st.levels >= 4 && st.t_p2m > 0 && st.t_m2m > 0 && st.t_m2l > 0 &&        \
                      st.t_l2l > 0 && st.t_l2p > 0 && st.t_p2p > 0,                        \
                  "%s: every pass of the tree timed", what);                               \
            CHECK(st.t_m2l > 0.1 * st.t_l2l, "%s: M2L %.2e s against L2L %.2e s", what,     \
                  st.t_m2l, st.t_l2l);                                                     \
            CHECK(sum <= 1.01 * st.t_evaluate + 1e-4 && sum >= 0.5 * st.t_evaluate,        \
                  "%s: passes sum to %.4f s of %.4f s", what, sum, st.t_evaluate);         \
        }                                                                                  \
        P##_destroy(h);                                                                    \
    } while (0)

static void test_stats_timings(void)
{
    const int64_t n = 20000;
    double *x = t_doubles(3 * n), *q = t_doubles(3 * n), *out = t_doubles(3 * n);
    kifmm_opts o = t_opts(6, 40, 0);
    t_rng r = t_rng_seed(17);
    t_group("the timings in kifmm_stats");
    t_gen_cube(&r, n, x, 0.0, 1.0);
    t_gen_charges(&r, 3 * n, q, -1.0, 1.0);
    T_STATS_CHECK(kifmm_laplace, "laplace (FFT M2L)");
    o.order = 4;
    o.leaf_size = 120;
    T_STATS_CHECK(kifmm_stokes, "stokes (dense M2L)");
    free(x);
    free(q);
    free(out);
}

int main(void)
{
    test_yukawa_lambda();
    test_neutral_far();
    test_stokes();
    test_nan_kernel();
    test_deep_cluster();
    test_in_place();
    test_stats_timings();
    return t_finish();
}
