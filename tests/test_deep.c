/* test_deep.c - derivatives in deep trees: a cluster of points far below
 * the sources that make its field. The cluster's points (a cube of side
 * 1e-2) carry no charge, or charges of 1e-150; five unit charges sit about
 * 1 away. With leaves of one point the cluster's boxes reach level 16, and
 * every one of them refits its downward density although almost all its
 * field comes from far above. The outputs of laplace_hess (14 anchors),
 * yukawa_grad, laplace_grad and helmholtz_grad (4; k = 2, real charges) are
 * compared with a direct sum in long double, over the cluster's targets,
 * for the tree of 16 levels and for
 * the same points with max_depth 6 (the cluster in one leaf): the deep
 * tree's errors in the gradient and the Hessian must stay within 8 times
 * the shallow one's (1 to 3 times measured). Without the downward
 * densities' anchors (KIFMM_NO_ANCHORS) they grew with the depth:
 * laplace_hess at p = 6, gradient 3.5e-5 and Hessian 0.83 against 1.4e-7
 * and 1.4e-6 with max_depth 6; at p = 4 the Hessian's was 252, and
 * laplace_grad's gradient at p = 8 1.3e-5 against 6.4e-9. helmholtz_grad
 * had no anchors (complex kernels went without): its gradient at p = 6
 * was 1.75e-5 against 9.2e-8 (at p = 8 9.8e-7 against 9.7e-11); and the
 * same problem at k = 2e4 on the points times 1e-4 had none either, the
 * kernel's probe for them (P__st_derivative) reading it only at distances
 * of 1e-3, where it oscillates (1.75e-5 again). */
#define KIFMM_KERNEL laplace_hess
#include "kifmm.h"
#define KIFMM_KERNEL yukawa_grad
#include "kifmm.h"
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"
#define KIFMM_KERNEL helmholtz_grad
#include "kifmm.h"

#include "test.h"

#ifdef KIFMM_TEST_QUICK
#define NCL 800
#else
#define NCL 2000
#endif
#define NFAR 5
#define LAMBDA 2.0
/* helmholtz_grad's wavenumber and the points' scale: k = 2 on the points
 * as made, and k = 2e4 on the points times 1e-4 (the same problem in
 * wavelengths, where the anchors' probe at distances of 1e-3 had seen
 * the kernel oscillate and given none) */
static double wavenumber = 2.0, xscale = 1.0;

/* ref[10] at t: potential, gradient and Hessian (xx, yy, zz, xy, xz, yz)
 * of sum q / (4 pi r) (yukawa: exp(-LAMBDA r) / (4 pi r), first 4 only),
 * in long double */
static void direct_at(int yuk, int64_t ns, const double *s, const double *q, const double *t,
                      double *ref)
{
    static const int hi[6] = {0, 1, 2, 0, 0, 1}, hj[6] = {0, 1, 2, 1, 2, 2};
    long double acc[10] = {0};
    int64_t j;
    int m;
    for (j = 0; j < ns; j++) {
        long double d[3], r2 = 0.0L, r, g, dg, d2g;
        for (m = 0; m < 3; m++) {
            d[m] = (long double)t[m] - (long double)s[3 * j + m];
            r2 += d[m] * d[m];
        }
        if (r2 == 0.0L || q[j] == 0.0) continue;
        r = sqrtl(r2);
        /* g(r) and its first two derivatives with respect to r */
        if (yuk) {
            const long double e = expl(-LAMBDA * r);
            g = e / r;
            dg = -e * (1.0L + LAMBDA * r) / r2;
            d2g = e * (2.0L + 2.0L * LAMBDA * r + LAMBDA * LAMBDA * r2) / (r2 * r);
        } else {
            g = 1.0L / r;
            dg = -1.0L / r2;
            d2g = 2.0L / (r2 * r);
        }
        acc[0] += q[j] * g;
        for (m = 0; m < 3; m++) acc[1 + m] += q[j] * dg * d[m] / r;
        for (m = 0; m < 6; m++) {
            const long double u = d[hi[m]] * d[hj[m]] / r2;
            acc[4 + m] += q[j] * (d2g * u + dg / r * ((hi[m] == hj[m] ? 1.0L : 0.0L) - u));
        }
    }
    for (m = 0; m < 10; m++) ref[m] = (double)(acc[m] / (4.0L * 3.141592653589793238462643383279503L));
}

/* the cluster (first NCL points) and the far charges after it */
/* ref[0..7] at t: the potential and gradient of sum q e^(i k r) / (4 pi
 * r) (k = wavenumber, real charges q), (re, im) pairs, in long double */
static void direct_helm(int64_t ns, const double *s, const double *q, const double *t, double *ref)
{
    long double acc[8] = {0};
    int64_t j;
    int m;
    for (j = 0; j < ns; j++) {
        long double d[3], r2 = 0.0L, r, c, sn, gr, gi, dr, di;
        for (m = 0; m < 3; m++) {
            d[m] = (long double)t[m] - (long double)s[3 * j + m];
            r2 += d[m] * d[m];
        }
        if (r2 == 0.0L || q[j] == 0.0) continue;
        r = sqrtl(r2);
        c = cosl(wavenumber * r), sn = sinl(wavenumber * r);
        gr = q[j] * c / r, gi = q[j] * sn / r; /* q G 4 pi */
        /* d/dr (e^(ikr) / r) = e^(ikr) (i k r - 1) / r^2, times d / r */
        dr = (-gr - wavenumber * r * gi) / r2, di = (-gi + wavenumber * r * gr) / r2;
        acc[0] += gr, acc[1] += gi;
        for (m = 0; m < 3; m++) acc[2 + 2 * m] += dr * d[m], acc[3 + 2 * m] += di * d[m];
    }
    for (m = 0; m < 8; m++) ref[m] = (double)(acc[m] / (4.0L * (long double)T_PI));
}

static void make_points(double *x, double *q, double qc)
{
    t_rng r = t_rng_seed(2027);
    int64_t i;
    t_gen_cube(&r, NCL, x, -5e-3, 5e-3);
    for (i = 0; i < NCL; i++) q[i] = qc * t_uniform(&r, -1.0, 1.0);
    for (i = 0; i < NFAR; i++) {
        x[3 * (NCL + i)] = 0.7 + 0.1 * (double)i;
        x[3 * (NCL + i) + 1] = -0.6;
        x[3 * (NCL + i) + 2] = 0.3 * (double)i - 0.5;
        q[NCL + i] = 1.0 - 0.3 * (double)i;
    }
}

enum { HESS, YUK, GRAD, HELM };
static const char *const names[] = {"laplace_hess", "yukawa_grad", "laplace_grad", "helmholtz_grad"};

/* relative L2 errors over the cluster's targets of kernel kind: gradient
 * (e[0]) and, for laplace_hess, Hessian (e[1]); the tree's levels in
 * *levels */
static void run(int kind, int order, int max_depth, const double *x, const double *q, double *e,
                int *levels)
{
    const int64_t n = NCL + NFAR;
    const int td = kind == HESS ? 10 : kind == HELM ? 8 : 4, yuk = kind == YUK;
    const int g0 = kind == HELM ? 2 : 1, h0 = kind == HESS ? 4 : td; /* gradient, Hessian from */
    kifmm_opts o = t_opts(order, 1, max_depth);
    double *out = t_doubles(td * n), num[2] = {0, 0}, den[2] = {0, 0}, ref[10];
    kifmm_stats st;
    int64_t i;
    int rc, k;
    t_fill(td * n, out, NAN);
    memset(&st, 0, sizeof st);
    if (kind == GRAD) {
        kifmm_laplace_grad *h = NULL;
        rc = kifmm_laplace_grad_create(&h, &o, n, x, n, x);
        if (!rc) rc = kifmm_laplace_grad_evaluate(h, q, out);
        if (!rc) rc = kifmm_laplace_grad_stats(h, &st);
        kifmm_laplace_grad_destroy(h);
    } else if (kind == HELM) {
        kifmm_helmholtz_grad *h = NULL;
        double *qc = t_doubles(2 * n);
        for (i = 0; i < n; i++) qc[2 * i] = q[i], qc[2 * i + 1] = 0.0;
        o.kernel_param[0] = wavenumber;
        rc = kifmm_helmholtz_grad_create(&h, &o, n, x, n, x);
        if (!rc) rc = kifmm_helmholtz_grad_evaluate(h, qc, out);
        if (!rc) rc = kifmm_helmholtz_grad_stats(h, &st);
        kifmm_helmholtz_grad_destroy(h);
        free(qc);
    } else if (yuk) {
        kifmm_yukawa_grad *h = NULL;
        o.kernel_param[0] = LAMBDA;
        rc = kifmm_yukawa_grad_create(&h, &o, n, x, n, x);
        if (!rc) rc = kifmm_yukawa_grad_evaluate(h, q, out);
        if (!rc) rc = kifmm_yukawa_grad_stats(h, &st);
        kifmm_yukawa_grad_destroy(h);
    } else {
        kifmm_laplace_hess *h = NULL;
        rc = kifmm_laplace_hess_create(&h, &o, n, x, n, x);
        if (!rc) rc = kifmm_laplace_hess_evaluate(h, q, out);
        if (!rc) rc = kifmm_laplace_hess_stats(h, &st);
        kifmm_laplace_hess_destroy(h);
    }
    CHECK(rc == 0, "%s p=%d max_depth %d: rc %d", names[kind], order, max_depth, rc);
    for (i = 0; i < NCL; i++) {
        if (kind == HELM) direct_helm(n, x, q, x + 3 * i, ref);
        else direct_at(yuk, n, x, q, x + 3 * i, ref);
        for (k = g0; k < td; k++) {
            const double d = out[i * td + k] - ref[k];
            num[k >= h0] += d * d;
            den[k >= h0] += ref[k] * ref[k];
            if (d != d) num[k >= h0] = NAN;
        }
    }
    e[0] = sqrt(num[0] / den[0]);
    e[1] = kind == HESS ? sqrt(num[1] / den[1]) : 0.0;
    *levels = st.levels;
    free(out);
}

static void check(int kind, int order, double qc)
{
    double *x = t_doubles(3 * (NCL + NFAR)), *q = t_doubles(NCL + NFAR), ed[2], es[2];
    int ld, ls;
    int64_t i;
    make_points(x, q, qc);
    for (i = 0; i < 3 * (NCL + NFAR); i++) x[i] *= xscale;
    run(kind, order, 0, x, q, ed, &ld);
    run(kind, order, 6, x, q, es, &ls);
    printf("  %-12s p=%d cluster charges %-6g scale %g levels %2d: gradient %.2e Hessian %.2e | "
           "levels %d: %.2e %.2e\n",
           names[kind], order, qc, xscale, ld, ed[0], ed[1], ls, es[0], es[1]);
    CHECK(ld >= 14, "the cluster's tree has %d levels", ld);
    CHECK_ERR(ed[0], 8.0 * es[0] + 1e-12, "%s p=%d gradient, 16 levels against 6", names[kind], order);
    if (kind == HESS)
        CHECK_ERR(ed[1], 8.0 * es[1] + 1e-12, "laplace_hess p=%d Hessian, 16 levels against 6", order);
    free(x);
    free(q);
}

int main(void)
{
    t_group("deep trees: derivatives of a far field");
    check(HESS, 4, 0.0);
    check(HESS, 6, 0.0);
    check(HESS, 6, 1e-150);
    check(YUK, 4, 0.0);
    check(YUK, 6, 0.0);
    check(GRAD, 4, 0.0);
    check(GRAD, 8, 0.0);
    check(HELM, 4, 0.0);
    check(HELM, 6, 0.0);
    wavenumber = 2e4, xscale = 1e-4;
    check(HELM, 6, 0.0);
    return t_finish();
}
