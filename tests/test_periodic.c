/* test_periodic.c - periodic boundaries (opts.period) against references
 * computed here, never by the library:
 *   - Yukawa in one, two and three periodic directions: direct sums over
 *     the image lattice, |n| <= N, converged (the sum at N - 2 agrees to
 *     1e-11);
 *   - Laplace with one periodic direction, neutral charges: direct sums over
 *     N images either side, extrapolated in N (the error of the symmetric
 *     sum runs in 1/N^2, 1/N^4, ...; the last extrapolation step must move
 *     it by less than 1e-10);
 *   - Laplace with two periodic directions, neutral charges: Ewald's sum
 *     for two periodic directions (tests/ewald.h), checked here against
 *     two of its own splits and against direct sums over growing squares;
 * on points spread over the cell, crowding one face, crowding one corner
 * (given partly outside the cell, so that they wrap), far from the origin,
 * and with separate targets (crowding a face or corner, the sources spread
 * over the cell: where the far images came through the root's expansions,
 * targets crowding a corner measured up to 1.1e-4 at p = 6); relative L2
 * error at p = 6 at most 1e-5 and at p = 10 at most 1e-8, the documented
 * bounds (docs/api.md). And the errors:
 * bad periods, points wider than 1024 periods in a free direction, net
 * charge where it must be zero (out untouched). Three periodic directions
 * of scale-invariant kernels: test_periodic3.c. */
#include "kifmm.h"
#define KIFMM_KERNEL yukawa
#include "kifmm.h"
#define KIFMM_REAL float
#include "kifmm.h"
#define KIFMM_KERNEL stokes
#include "kifmm.h"
#define KIFMM_KERNEL yukawa
#define KIFMM_REAL float
#include "kifmm.h"

#include "ewald.h"
#include "test.h"

#ifdef KIFMM_TEST_QUICK
#define NPTS 500
#else
#define NPTS 1000
#endif
#define NCHK 12 /* targets checked against each reference */
#include "periodic_refs.h"

/* ---- point sets, in or around the unit cell [0, 1)^3 --------------------- */

enum { UNIFORM, FACE, CORNER, FAR };
static const char *set_name[] = {"uniform", "face", "corner", "far from the origin"};

/* set k of n points: uniform; crowding the face x = 0 from both sides
 * (x in [-0.04, 0.04], given so: they wrap); crowding the corner 0 from all
 * sides; uniform moved by 1000 periods along the periodic directions of
 * mask pm. A free direction keeps its points in [0, 1) (crowding: in [0,
 * 0.08]), so that sources and targets together span less than the period. */
static void gen_set(t_rng *r, int k, int pm, int64_t n, double *x)
{
    int64_t i;
    int d;
    for (i = 0; i < n; i++)
        for (d = 0; d < 3; d++) {
            double v = t_rand01(r);
            if ((k == FACE && d == 0) || k == CORNER)
                v = t_uniform(r, -0.04, 0.04) + (pm >> d & 1 ? 0.0 : 0.04);
            if (k == FAR && (pm >> d & 1)) v += 1000.0 * (d == 1 ? -2 : d + 1);
            x[3 * i + d] = v;
        }
}

/* ---- references ----------------------------------------------------------- */

/* two periodic directions (x and y), Laplace, neutral charges: Ewald */
static void ref_laplace2d(int64_t ns, const double *xs, const double *q, const double *t,
                          double *ref)
{
    t_ewald2d_laplace(ns, xs, q, NCHK, t, 1.0, ref);
}

/* ---- the cases ---------------------------------------------------------- */

static double bound_for(int p) { return p >= 10 ? 1e-8 : 1e-5; }

/* one case: kernel (0 Laplace, else Yukawa with that lambda), periodic
 * mask, point set, separate targets or not, order; the reference by kind */
static void run_case(double lam, int pm, int set, int sep, int p, int N)
{
    const int64_t ns = NPTS, nt = sep ? NPTS / 2 : NPTS;
    t_rng r = t_rng_seed(0x9e37ULL + (uint64_t)(pm * 131 + set * 17 + sep * 7 + (lam > 0)));
    double *xs = t_doubles(3 * ns), *q = t_doubles(ns), *xt = sep ? t_doubles(3 * nt) : xs;
    double *out = t_doubles(nt), ref[NCHK], t[3 * NCHK], conv = 0.0, err = 1.0;
    kifmm_opts o = popts(p, pm);
    int rc;
    gen_set(&r, sep ? UNIFORM : set, pm, ns, xs);
    if (sep) gen_set(&r, set, pm, nt, xt);
    gen_q(&r, ns, q, lam == 0.0);
    chk_points(nt, xt, t);
    if (lam > 0.0) {
        kifmm_yukawa *h = NULL;
        o.kernel_param[0] = lam;
        rc = kifmm_yukawa_create(&h, &o, ns, xs, nt, xt);
        if (!rc) rc = kifmm_yukawa_evaluate(h, q, out);
        kifmm_yukawa_destroy(h);
        conv = ref_yukawa(pm, N, lam, ns, xs, q, t, ref);
        CHECK(conv <= 1e-11, "Yukawa image sums converged at N = %d: change %.1e", N, conv);
    } else {
        kifmm_laplace *h = NULL;
        rc = kifmm_laplace_create(&h, &o, ns, xs, nt, xt);
        if (!rc) rc = kifmm_laplace_evaluate(h, q, out);
        kifmm_laplace_destroy(h);
        if (pm == 3) {
            ref_laplace2d(ns, xs, q, t, ref);
        } else {
            conv = ref_laplace1d(pm, N, ns, xs, q, t, ref);
            CHECK(conv <= 1e-10, "extrapolated image sums converged: change %.1e", conv);
        }
    }
    CHECK(rc == KIFMM_SUCCESS, "create and evaluate: %s", kifmm_strerror(rc));
    if (!rc) err = rel_l2(nt, out, 1, 0, ref, 1);
    CHECK_ERR(err, bound_for(p), "%s, period mask %d, %s%s, p = %d", lam > 0 ? "yukawa" : "laplace",
              pm, set_name[set], sep ? ", separate targets" : "", p);
    free(xs);
    free(q);
    free(out);
    if (sep) free(xt);
}

/* Yukawa (lambda 8), three periodic directions, dense crowds on the cell's
 * faces: 5,000 sources, half crowding the face x = 0 and half the corner 0
 * (within 0.04, from both sides), 1,000 targets spread over the cell. While
 * the tree's frame was the cell's (kifmm__frame_offset) this measured
 * 1.87e-5 at p = 6 (seeds 1 to 3 over 60 targets: 3.1e-6 to 1.9e-5); with
 * the frame moved 6.2e-6 (1.1e-6 to 4.4e-6). */
static void run_dense(int seed)
{
    const int64_t ns = 5000, nt = 1000;
    t_rng r = t_rng_seed((uint64_t)seed);
    double *xs = t_doubles(3 * ns), *q = t_doubles(ns), *xt = t_doubles(3 * nt);
    double *out = t_doubles(nt), ref[NCHK], t[3 * NCHK], conv, err = 1.0;
    kifmm_opts o = popts(6, 7);
    kifmm_yukawa *h = NULL;
    int64_t i;
    int rc, d;
    for (i = 0; i < ns; i++)
        for (d = 0; d < 3; d++) {
            double v = t_rand01(&r);
            if (d == 0 || i % 2) v = t_uniform(&r, -0.04, 0.04);
            xs[3 * i + d] = v;
        }
    gen_q(&r, ns, q, 0);
    for (i = 0; i < 3 * nt; i++) xt[i] = t_rand01(&r);
    o.kernel_param[0] = 8.0;
    rc = kifmm_yukawa_create(&h, &o, ns, xs, nt, xt);
    if (!rc) rc = kifmm_yukawa_evaluate(h, q, out);
    kifmm_yukawa_destroy(h);
    chk_points(nt, xt, t);
    conv = ref_yukawa(7, 6, 8.0, ns, xs, q, t, ref);
    CHECK(conv <= 1e-11, "Yukawa image sums converged at N = 6: change %.1e", conv);
    CHECK(rc == KIFMM_SUCCESS, "create and evaluate: %s", kifmm_strerror(rc));
    if (!rc) err = rel_l2(nt, out, 1, 0, ref, 1);
    CHECK_ERR(err, 1e-5, "yukawa (lambda 8), 5,000 sources crowding a face and a corner, "
              "1,000 targets spread, seed %d, p = 6", seed);
    free(xs);
    free(q);
    free(xt);
    free(out);
}

/* the 2-D Ewald reference: two splits agree, and direct sums over squares of
 * growing side approach it (their error runs in 1 / N) */
static void test_ewald2d(void)
{
    enum { N = 200 };
    t_rng r = t_rng_seed(77);
    double x[3 * N], q[N], a[NCHK], b[NCHK], t[3 * NCHK], e32 = 0.0, e64 = 0.0, ex = 0.0, s = 0.0;
    int c;
    gen_set(&r, UNIFORM, 3, N, x);
    gen_q(&r, N, q, 1);
    chk_points(N, x, t);
    t_ewald2d_split(N, x, q, NCHK, t, 1.0, t_ewald_plan(1.0, 4.0, 1e-16), a);
    t_ewald2d_split(N, x, q, NCHK, t, 1.0, t_ewald_plan(1.0, 7.0, 1e-16), b);
    CHECK(t_rel_diff(NCHK, a, 1, b, 1) <= 1e-14, "2-D Ewald: two splits agree (%.1e)",
          t_rel_diff(NCHK, a, 1, b, 1));
    for (c = 0; c < NCHK; c++) {
        const double s32 = image_sum(3, 32, 0.0, N, x, q, t + 3 * c);
        const double s64 = image_sum(3, 64, 0.0, N, x, q, t + 3 * c);
        e32 += (s32 - a[c]) * (s32 - a[c]);
        e64 += (s64 - a[c]) * (s64 - a[c]);
        ex += (2.0 * s64 - s32 - a[c]) * (2.0 * s64 - s32 - a[c]);
        s += a[c] * a[c];
    }
    e32 = sqrt(e32 / s);
    e64 = sqrt(e64 / s);
    ex = sqrt(ex / s);
    CHECK(e64 < 0.6 * e32 && ex <= 1e-4,
          "2-D Ewald: direct sums over squares approach it as 1/N (N = 32: %.1e, 64: %.1e, "
          "extrapolated: %.1e)",
          e32, e64, ex);
}

/* Stokes (mu 1), periodic along x, forces summing to zero: against the
 * image sums at 100, 200, 400, 800 images either side, extrapolated in
 * 1/N^2 as for Laplace; and a net force: KIFMM_ERR_NEUTRAL */
static void test_stokes(void)
{
    const int64_t n = NPTS / 2;
    t_rng r = t_rng_seed(11);
    double *x = t_doubles(3 * n), *f = t_doubles(3 * n), *o = t_doubles(3 * n), m[3] = {0, 0, 0};
    double e = 0.0, s = 0.0, ch = 0.0, big = 0.0;
    kifmm_opts op = popts(6, 1);
    kifmm_stokes *h = NULL;
    int64_t i;
    int c, k, d, rc;
    gen_set(&r, FACE, 1, n, x);
    for (i = 0; i < 3 * n; i++) m[i % 3] += (f[i] = t_rand01(&r) - 0.5);
    f[0] += 1.0; /* a net force first */
    rc = kifmm_stokes_create(&h, &op, n, x, n, x);
    CHECK(rc == KIFMM_SUCCESS, "stokes, period x: create");
    CHECK(kifmm_stokes_evaluate(h, f, o) == KIFMM_ERR_NEUTRAL, "stokes, a net force: refused");
    f[0] -= 1.0;
    for (i = 0; i < 3 * n; i++) f[i] -= m[i % 3] / (double)n;
    rc = kifmm_stokes_evaluate(h, f, o);
    kifmm_stokes_destroy(h);
    for (c = 0; c < NCHK; c++) {
        const int64_t t = chk_index(c, n);
        double R[5][5][3], u[3];
        for (k = 0; k < 4; k++) stokes_images(1, 100 << k, n, x, f, x + 3 * t, R[k][0]);
        extrapolate(R, 4, 4.0, 3, u, &ch, &big);
        for (d = 0; d < 3; d++) {
            e += (o[3 * t + d] - u[d]) * (o[3 * t + d] - u[d]);
            s += u[d] * u[d];
        }
    }
    CHECK(sqrt(ch / big) <= 1e-10, "Stokes image sums converged: change %.1e", sqrt(ch / big));
    CHECK(rc == KIFMM_SUCCESS, "stokes evaluate: %s", kifmm_strerror(rc));
    CHECK_ERR(rc ? 1.0 : sqrt(e / s), 1e-5, "stokes, period x, face, zero net force, p = 6");
    free(x);
    free(f);
    free(o);
}

/* float instance: the same case in float, to its own resolution */
static void test_float(void)
{
    const int64_t n = NPTS;
    t_rng r = t_rng_seed(5);
    double *x = t_doubles(3 * n), *q = t_doubles(n), ref[NCHK], t[3 * NCHK], *o = t_doubles(n);
    float *xf = (float *)t_malloc_or_die((size_t)n * 3 * sizeof(float));
    float *qf = (float *)t_malloc_or_die((size_t)n * sizeof(float));
    float *of = (float *)t_malloc_or_die((size_t)n * sizeof(float));
    kifmm_opts op = popts(4, 1);
    kifmm_laplacef *h = NULL;
    int64_t i;
    int rc;
    gen_set(&r, FACE, 1, n, x);
    for (i = 0; i < 3 * n; i++) x[i] = (double)(xf[i] = (float)x[i]);
    gen_q(&r, n, q, 1);
    for (i = 0; i < n; i++) q[i] = (double)(qf[i] = (float)q[i]);
    rc = kifmm_laplacef_create(&h, &op, n, xf, n, xf);
    if (!rc) rc = kifmm_laplacef_evaluate(h, qf, of);
    kifmm_laplacef_destroy(h);
    for (i = 0; i < n; i++) o[i] = of[i];
    chk_points(n, x, t);
    ref_laplace1d(1, 100, n, x, q, t, ref);
    CHECK(rc == KIFMM_SUCCESS, "float create and evaluate: %s", kifmm_strerror(rc));
    CHECK_ERR(rc ? 1.0 : rel_l2(n, o, 1, 0, ref, 1), 1e-3, "float laplace, period x, face, p = 4");
    free(x);
    free(q);
    free(o);
    free(xf);
    free(qf);
    free(of);
}

/* Yukawa kernels that decay below float's range within a period (lambda L =
 * 100 to 700): the float instance drops the far images as its operators
 * do (they are below its resolution) and agrees with the double one; the
 * far images' exchange once gave KIFMM_ERR_OVERFLOW there */
static void test_float_decayed(void)
{
    static const double lams[] = {30.0, 100.0, 300.0, 700.0};
    const int64_t n = 300;
    t_rng r = t_rng_seed(21);
    double *x = t_doubles(3 * n), *q = t_doubles(n), *o = t_doubles(n);
    float *xf = (float *)t_malloc_or_die((size_t)n * 3 * sizeof(float));
    float *qf = (float *)t_malloc_or_die((size_t)n * sizeof(float));
    float *of = (float *)t_malloc_or_die((size_t)n * sizeof(float));
    int64_t i;
    int k, pm;
    gen_set(&r, UNIFORM, 7, n, x);
    for (i = 0; i < 3 * n; i++) x[i] = (double)(xf[i] = (float)x[i]);
    for (i = 0; i < n; i++) q[i] = (double)(qf[i] = (float)(t_rand01(&r) - 0.5));
    for (pm = 1; pm <= 7; pm += 6)
        for (k = 0; k < 4; k++) {
            kifmm_opts op = popts(6, pm);
            kifmm_yukawa *h = NULL;
            kifmm_yukawaf *hf = NULL;
            double e = 0.0, s = 0.0;
            int rc, rcf;
            op.kernel_param[0] = lams[k];
            rc = kifmm_yukawa_create(&h, &op, n, x, n, x);
            if (!rc) rc = kifmm_yukawa_evaluate(h, q, o);
            rcf = kifmm_yukawaf_create(&hf, &op, n, xf, n, xf);
            if (!rcf) rcf = kifmm_yukawaf_evaluate(hf, qf, of);
            kifmm_yukawa_destroy(h);
            kifmm_yukawaf_destroy(hf);
            for (i = 0; i < n && !rc && !rcf; i++) {
                e += (of[i] - o[i]) * (of[i] - o[i]);
                s += o[i] * o[i];
            }
            CHECK(rc == KIFMM_SUCCESS && rcf == KIFMM_SUCCESS, "yukawa, lambda %g, period mask %d: "
                  "double %s, float %s", lams[k], pm, kifmm_strerror(rc), kifmm_strerror(rcf));
            CHECK_ERR(rc || rcf || !(s > 0.0) ? 1.0 : sqrt(e / s), 1e-4,
                      "yukawaf against yukawa, lambda %g, period mask %d, p = 6", lams[k], pm);
        }
    free(x);
    free(q);
    free(o);
    free(xf);
    free(qf);
    free(of);
}

static void test_errors(void)
{
    const int64_t n = 64;
    t_rng r = t_rng_seed(9);
    double x[3 * 64], q[64], out[64];
    kifmm_opts o = popts(4, 1);
    kifmm_laplace *h = NULL;
    int i, rc;
    gen_set(&r, UNIFORM, 1, n, x);
    gen_q(&r, n, q, 0);
    o.period[0] = -1.0;
    CHECK(kifmm_laplace_create(&h, &o, n, x, n, x) == KIFMM_ERR_PERIOD && !h, "negative period");
    o.period[0] = NAN;
    CHECK(kifmm_laplace_create(&h, &o, n, x, n, x) == KIFMM_ERR_PERIOD && !h, "NaN period");
    o.period[0] = INFINITY;
    CHECK(kifmm_laplace_create(&h, &o, n, x, n, x) == KIFMM_ERR_PERIOD && !h, "infinite period");
    o.period[0] = 1.0;
    o.period[1] = 2.0;
    CHECK(kifmm_laplace_create(&h, &o, n, x, n, x) == KIFMM_ERR_PERIOD && !h, "unequal periods");
    o.period[1] = 0.0;
    x[4] = 1500.0; /* y spans 1500 periods: free directions must fit in 1024 (test_slab) */
    CHECK(kifmm_laplace_create(&h, &o, n, x, n, x) == KIFMM_ERR_PERIOD && !h,
          "a free direction 1500 periods wide");
    x[4] = 0.5;
    o.period[1] = o.period[2] = 1.0;
    rc = kifmm_laplace_create(&h, &o, n, x, n, x);
    CHECK(rc == KIFMM_SUCCESS && kifmm_laplace_evaluate(h, q, out) == KIFMM_SUCCESS,
          "three periodic directions of Laplace, a net charge: the neutralising background "
          "(test_periodic3)");
    kifmm_laplace_destroy(h);
    h = NULL;
    o.period[1] = o.period[2] = 0.0;
    rc = kifmm_laplace_create(&h, &o, n, x, n, x);
    CHECK(rc == KIFMM_SUCCESS, "create, one periodic direction");
    for (i = 0; i < n; i++) out[i] = 123.0;
    rc = kifmm_laplace_evaluate(h, q, out);
    for (i = 0; i < n && out[i] == 123.0; i++) {}
    CHECK(rc == KIFMM_ERR_NEUTRAL && i == n, "net charge, one periodic direction: %s, out untouched",
          kifmm_strerror(rc));
    gen_q(&r, n, q, 1);
    CHECK(kifmm_laplace_evaluate(h, q, out) == KIFMM_SUCCESS, "the same handle, neutral charges");
    kifmm_laplace_destroy(h);
}

int main(void)
{
    static const int pms[] = {1, 2, 3, 5, 7};
    int k, s;
    t_group("errors");
    test_errors();
    t_group("2-D Ewald reference");
    test_ewald2d();
    t_group("Yukawa, lambda 3: every set of periodic directions, p = 6");
    for (k = 0; k < 5; k++) run_case(pms[k] == 7 ? 4.0 : 3.0, pms[k], UNIFORM, 0, 6, pms[k] == 7 ? 10 : 14);
    t_group("Yukawa: crowded faces and corners, far from the origin, separate targets");
    for (s = FACE; s <= FAR; s++) run_case(3.0, 3, s, 0, 6, 14);
    run_case(4.0, 7, CORNER, 1, 6, 10);
    run_case(1.0, 1, FACE, 1, 6, 44);
    run_case(3.0, 3, UNIFORM, 1, 6, 14);
    run_case(3.0, 3, CORNER, 1, 6, 14); /* 3.6e-5 through the root's expansions */
    run_dense(3);
    t_group("Laplace, one periodic direction, neutral charges");
    for (s = UNIFORM; s <= FAR; s++) run_case(0.0, s == CORNER ? 4 : s == FAR ? 2 : 1, s, 0, 6, 100);
    run_case(0.0, 2, UNIFORM, 1, 6, 100);
    run_case(0.0, 1, CORNER, 1, 6, 100); /* 4.1e-5 through the root's expansions */
    t_group("Laplace, two periodic directions (x, y), neutral charges");
    for (s = UNIFORM; s <= FAR; s++) run_case(0.0, 3, s, 0, 6, 0);
    run_case(0.0, 3, FACE, 1, 6, 0);
    run_case(0.0, 3, CORNER, 1, 6, 0); /* 1.1e-4 through the root's expansions */
    t_group("p = 10");
    run_case(0.0, 1, CORNER, 0, 10, 100);
#ifndef KIFMM_TEST_QUICK /* the full tables' configuration: a second apiece */
    run_case(4.0, 7, FACE, 0, 10, 10);
    run_case(0.0, 3, FACE, 1, 10, 0);
    run_case(0.0, 3, CORNER, 1, 10, 0); /* 2.5e-8 through the root's expansions */
#endif
    t_group("Stokes");
    test_stokes();
    t_group("float");
    test_float();
    test_float_decayed();
    return t_finish();
}
