/* test_update.c - <prefix>_update_points: new points for a handle keep its
 * options and, where they still apply, its operators (the plan). After an
 * update the handle's outputs must equal, bit for bit, those of a handle
 * created afresh on the same points with the same options (the operators
 * kept are the ones create would build), and both must match the direct
 * sums of <prefix>_direct (no tree, no expansions) to the method's
 * accuracy. Cases: kernels with and without scale invariance, every
 * kernel family (laplace, its gradient, Hessian and dipole, yukawa,
 * stokes and its double layer, biot_savart), float and double, dense and
 * FFT M2L,
 * sources = targets and separate targets, counts that grow and shrink,
 * points moved a little and across the whole box, opts.domain (then even
 * Yukawa keeps its plan), periodic handles, empty sets, bad input (the
 * handle keeps evaluating its old points, bit for bit). */
#include "kifmm.h"
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"
#define KIFMM_KERNEL yukawa_grad
#include "kifmm.h"
#define KIFMM_KERNEL stokes
#include "kifmm.h"
#define KIFMM_KERNEL laplace
#define KIFMM_REAL float
#include "kifmm.h"
#define KIFMM_KERNEL yukawa
#define KIFMM_REAL float
#include "kifmm.h"
/* the dense M2L and the other kernel families: in the full build (the
 * configurations with KIFMM_TEST_QUICK compile and run the rest) */
#ifndef KIFMM_TEST_QUICK
#define T_UPDATE_ALL 1
#define KIFMM_KERNEL laplace
#define KIFMM_M2L_DENSE
#define KIFMM_NAME kifmm_laplace_dense
#include "kifmm.h"
#define KIFMM_KERNEL laplace_hess
#include "kifmm.h"
#define KIFMM_KERNEL laplace_dipole
#include "kifmm.h"
#define KIFMM_KERNEL stokes_dl
#include "kifmm.h"
#define KIFMM_KERNEL biot_savart
#include "kifmm.h"
#else
#define T_UPDATE_ALL 0
#endif

#include "test.h"

/* a point set: n points, x in the instance's precision */
typedef struct {
    int64_t n;
    double *x;
} pset;

static pset set_cube(uint64_t seed, int64_t n, double lo, double hi)
{
    t_rng r = t_rng_seed(seed);
    pset s;
    s.n = n;
    s.x = t_doubles(3 * n + 3);
    t_gen_cube(&r, n, s.x, lo, hi);
    return s;
}

/* s moved by at most eps in each coordinate, inside [lo, hi] */
static pset set_jitter(const pset *s, uint64_t seed, double eps, double lo, double hi)
{
    t_rng r = t_rng_seed(seed);
    pset m;
    int64_t i;
    m.n = s->n;
    m.x = t_doubles(3 * s->n + 3);
    for (i = 0; i < 3 * s->n; i++) {
        double v = s->x[i] + t_uniform(&r, -eps, eps);
        m.x[i] = v < lo ? lo : v > hi ? hi : v;
    }
    return m;
}

/* One case for instance P of precision R (sd densities per source, td
 * outputs per target): a handle created on (s0, t0) and moved to (s1, t1)
 * (t == NULL: targets = sources, the same array), against a handle created
 * on (s1, t1). keep: 1 if the plan must be kept (the same operators), 0 if
 * it must be replaced, -1 either. bound: relative L2 error against direct
 * sums at up to 300 targets (free space only; 0: not checked). */
#define T_UPDATE_CASE(P, R)                                                                        \
    static R *P##_conv(const double *x, int64_t n)                                                 \
    {                                                                                              \
        R *y = (R *)t_malloc_or_die((size_t)(n > 0 ? n : 1) * sizeof(R));                          \
        int64_t i;                                                                                 \
        for (i = 0; i < n; i++) y[i] = (R)x[i];                                                    \
        return y;                                                                                  \
    }                                                                                              \
    static void P##_case(const char *what, const kifmm_opts *o, int sd, int td, const pset *s0,    \
                         const pset *t0, const pset *s1, const pset *t1, int keep, int neutral,     \
                         double bound)                                                             \
    {                                                                                              \
        R *xs0 = P##_conv(s0->x, 3 * s0->n), *xs1 = P##_conv(s1->x, 3 * s1->n);                    \
        R *xt0 = t0 ? P##_conv(t0->x, 3 * t0->n) : xs0, *xt1 = t1 ? P##_conv(t1->x, 3 * t1->n) : xs1; \
        const int64_t nt0 = t0 ? t0->n : s0->n, nt1 = t1 ? t1->n : s1->n;                          \
        double *qd0 = t_densities(11, s0->n, sd, 1, neutral);                                      \
        double *qd1 = t_densities(12, s1->n, sd, 2, neutral);                                      \
        R *q0 = P##_conv(qd0, s0->n * sd), *q1 = P##_conv(qd1, s1->n * 2 * sd);                    \
        R *o0 = (R *)t_malloc_or_die((size_t)(nt0 * td + 1) * sizeof(R));                          \
        R *o0b = (R *)t_malloc_or_die((size_t)(nt0 * td + 1) * sizeof(R));                         \
        R *u = (R *)t_malloc_or_die((size_t)(2 * nt1 * td + 1) * sizeof(R));                       \
        R *f = (R *)t_malloc_or_die((size_t)(2 * nt1 * td + 1) * sizeof(R));                       \
        P *h = NULL, *g = NULL;                                                                    \
        const void *lv0[sizeof h->lv / sizeof h->lv[0] + 1];                                       \
        const double t_start = t_wall();                                                           \
        int rc, rc2, k;                                                                            \
        int64_t i;                                                                                 \
        kifmm_stats st;                                                                            \
        rc = P##_create(&h, o, s0->n, xs0, nt0, xt0);                                              \
        CHECK(rc == 0, "%s %s: create rc=%d (%s)", #P, what, rc, kifmm_strerror(rc));              \
        if (rc) goto done;                                                                         \
        CHECK(P##_evaluate(h, q0, o0) == 0, "%s %s: evaluate on the first points", #P, what);     \
        for (k = 0; k < (int)(sizeof h->lv / sizeof h->lv[0]); k++) lv0[k] = h->lv[k];             \
        lv0[k] = h->far;                                                                           \
        rc = P##_update_points(h, s1->n, xs1, nt1, xt1);                                           \
        CHECK(rc == 0, "%s %s: update_points rc=%d (%s)", #P, what, rc, kifmm_strerror(rc));       \
        rc2 = P##_create(&g, o, s1->n, xs1, nt1, xt1);                                             \
        CHECK(rc2 == 0, "%s %s: fresh create rc=%d", #P, what, rc2);                               \
        if (rc || rc2) goto done;                                                                  \
        if (keep >= 0) { /* every operator set (and far images) one the handle had */            \
            int kept = 1, j, n = (int)(sizeof h->lv / sizeof h->lv[0]);                            \
            for (k = 0; k <= n; k++) {                                                             \
                const void *e = k < n ? (const void *)h->lv[k] : (const void *)h->far;             \
                int had = 0;                                                                       \
                for (j = 0; j <= n; j++) had |= e == lv0[j];                                       \
                kept &= !e || had;                                                                 \
            }                                                                                      \
            CHECK(kept == keep, "%s %s: operators %s, want %s", #P, what, kept ? "kept" : "rebuilt", \
                  keep ? "kept" : "rebuilt");                                                      \
        }                                                                                          \
        for (k = 1; k <= 2; k++) {                                                                 \
            size_t no = (size_t)(k * nt1 * td);                                                    \
            double dmax = 0.0, fmax = 0.0;                                                         \
            int differ;                                                                            \
            rc = k == 1 ? P##_evaluate(h, q1, u) : P##_evaluate_many(h, 2, q1, u);                 \
            rc2 = k == 1 ? P##_evaluate(g, q1, f) : P##_evaluate_many(g, 2, q1, f);                \
            CHECK(rc == 0 && rc2 == 0, "%s %s: evaluate rc=%d, fresh %d", #P, what, rc, rc2);       \
            differ = memcmp(u, f, no * sizeof(R)) != 0;                                            \
            for (i = 0; i < (int64_t)no; i++) {                                                    \
                double dd = fabs((double)u[i] - (double)f[i]);                                      \
                dmax = dd > dmax ? dd : dmax;                                                      \
                fmax = fabs((double)f[i]) > fmax ? fabs((double)f[i]) : fmax;                      \
            }                                                                                      \
            CHECK(!differ, "%s %s: %d vector(s): updated handle differs from a fresh one by %.3e " \
                  "(largest output %.3e)", #P, what, k, dmax, fmax);                              \
        }                                                                                          \
        if (bound > 0.0 && nt1 > 0 && s1->n > 0) {                                                \
            const int64_t m = nt1 < 300 ? nt1 : 300;                                               \
            R *ref = (R *)t_malloc_or_die((size_t)(m * td) * sizeof(R));                           \
            double e2 = 0.0, r2 = 0.0;                                                             \
            rc = P##_evaluate(h, q1, u);                                                           \
            rc2 = P##_direct(o, s1->n, xs1, q1, m, xt1, ref);                                      \
            CHECK(rc == 0 && rc2 == 0, "%s %s: direct rc=%d", #P, what, rc2);                      \
            for (i = 0; i < m * td; i++) {                                                         \
                e2 += ((double)u[i] - (double)ref[i]) * ((double)u[i] - (double)ref[i]);           \
                r2 += (double)ref[i] * (double)ref[i];                                             \
            }                                                                                      \
            CHECK_ERR(sqrt(e2 / r2), bound, "%s %s: after update vs direct", #P, what);            \
            free(ref);                                                                             \
        }                                                                                          \
        /* bad input: an error, and the handle still evaluates its points */                      \
        if (s1->n > 0 && nt1 > 0) {                                                                \
            R keepv = xs0[0];                                                                      \
            CHECK(P##_evaluate(h, q1, f) == 0, "%s %s: evaluate before bad input", #P, what);       \
            xs0[0] = (R)NAN;                                                                       \
            rc = P##_update_points(h, s0->n, xs0, nt0, t0 ? xt0 : xs0);                            \
            xs0[0] = keepv;                                                                        \
            CHECK(rc == KIFMM_ERR_NONFINITE, "%s %s: NaN point: rc=%d", #P, what, rc);             \
            rc = P##_update_points(h, s0->n, NULL, nt0, xt0);                                      \
            CHECK(rc == KIFMM_ERR_NULL, "%s %s: NULL sources: rc=%d", #P, what, rc);               \
            rc = P##_update_points(h, -1, xs0, nt0, xt0);                                          \
            CHECK(rc == KIFMM_ERR_COUNT, "%s %s: count -1: rc=%d", #P, what, rc);                  \
            rc = P##_update_points(h, INT64_MAX, xs0, nt0, xt0);                                   \
            CHECK(rc == KIFMM_ERR_COUNT, "%s %s: count INT64_MAX: rc=%d", #P, what, rc);           \
            CHECK(P##_update_points(NULL, s0->n, xs0, nt0, xt0) == KIFMM_ERR_NULL,                 \
                  "%s %s: NULL handle", #P, what);                                                 \
            rc = P##_evaluate(h, q1, u);                                                           \
            CHECK(rc == 0 && !memcmp(u, f, (size_t)(nt1 * td) * sizeof(R)),                        \
                  "%s %s: after refused updates the handle's outputs changed (rc=%d)", #P, what, rc); \
        }                                                                                          \
        CHECK(P##_stats(h, &st) == 0 && st.t_update > 0.0 && st.t_points >= 0.0,                   \
              "%s %s: stats.t_update %g", #P, what, st.t_update);                                  \
        /* and back to the first points: as after create */                                        \
        rc = P##_update_points(h, s0->n, xs0, nt0, xt0);                                           \
        CHECK(rc == 0, "%s %s: update back rc=%d", #P, what, rc);                                  \
        if (!rc && nt0 > 0) {                                                                      \
            rc = P##_evaluate(h, q0, o0b);                                                         \
            CHECK(rc == 0 && !memcmp(o0, o0b, (size_t)(nt0 * td) * sizeof(R)),                     \
                  "%s %s: back on the first points the outputs differ from create's", #P, what);  \
        }                                                                                          \
        printf("  done %-20s %-26s %.2f s\n", #P, what, t_wall() - t_start);                        \
    done:                                                                                          \
        P##_destroy(h);                                                                            \
        P##_destroy(g);                                                                            \
        free(xs0);                                                                                 \
        free(xs1);                                                                                 \
        if (t0) free(xt0);                                                                         \
        if (t1) free(xt1);                                                                         \
        free(qd0);                                                                                 \
        free(qd1);                                                                                 \
        free(q0);                                                                                  \
        free(q1);                                                                                  \
        free(o0);                                                                                  \
        free(o0b);                                                                                 \
        free(u);                                                                                   \
        free(f);                                                                                   \
    }

T_UPDATE_CASE(kifmm_laplace, double)
T_UPDATE_CASE(kifmm_laplace_grad, double)
T_UPDATE_CASE(kifmm_yukawa_grad, double)
T_UPDATE_CASE(kifmm_stokes, double)
T_UPDATE_CASE(kifmm_laplacef, float)
T_UPDATE_CASE(kifmm_yukawaf, float)
#if T_UPDATE_ALL
T_UPDATE_CASE(kifmm_laplace_dense, double)
T_UPDATE_CASE(kifmm_laplace_hess, double)
T_UPDATE_CASE(kifmm_laplace_dipole, double)
T_UPDATE_CASE(kifmm_stokes_dl, double)
T_UPDATE_CASE(kifmm_biot_savart, double)
#endif

/* The moves of one instance: sources = targets moved a little, the same
 * count; all new points, more of them; fewer, separate targets; and (all
 * but light instances, whose operators are slow to build) back to the
 * same, no sources, and from no targets. */
#define T_MOVES(P, o, sd, td, keep_si, bound, light)                                               \
    do {                                                                                           \
        pset a = set_cube(1, 4000, 0.0, 1.0), b = set_jitter(&a, 2, 1e-3, 0.0, 1.0);               \
        pset c = set_cube(3, 6000, -0.5, 2.0), d = set_cube(4, 1500, 0.2, 0.7);                    \
        pset e = set_cube(5, 2500, 0.0, 1.0), z = {0, NULL};                                       \
        z.x = t_doubles(3);                                                                        \
        P##_case("moved 1e-3", o, sd, td, &a, NULL, &b, NULL, keep_si, 0, bound);                  \
        P##_case("new and more", o, sd, td, &a, NULL, &c, NULL, keep_si, 0, bound);                \
        P##_case("fewer, separate targets", o, sd, td, &c, NULL, &d, &e, keep_si, 0, bound);       \
        if (!(light)) {                                                                            \
            P##_case("separate -> same", o, sd, td, &d, &e, &a, NULL, -1, 0, bound);               \
            P##_case("no sources", o, sd, td, &a, NULL, &z, &e, -1, 0, 0.0);                       \
            P##_case("from no targets", o, sd, td, &d, &z, &b, NULL, -1, 0, bound);                \
        }                                                                                          \
        free(a.x), free(b.x), free(c.x), free(d.x), free(e.x), free(z.x);                          \
    } while (0)

/* opts.domain: a fixed root box; points moving inside it keep every
 * operator, even those of a kernel that is not scale invariant */
static void test_domain(void)
{
    kifmm_opts o = t_opts(6, 0, 0);
    pset a = set_cube(21, 5000, 0.1, 0.9), b = set_cube(22, 7000, 0.0, 1.0);
    pset c = set_jitter(&b, 23, 1e-2, 0.0, 1.0), w = set_cube(24, 100, 0.0, 1.0);
    kifmm_yukawa_grad *h = NULL;
    double *q = t_densities(5, 7000, 1, 1, 0), *out = t_doubles(4 * 7000);
    int rc;
    o.kernel_param[0] = 3.0;
    o.domain[0] = o.domain[1] = o.domain[2] = 0.5;
    o.domain[3] = 0.5;
    t_group("opts.domain");
    kifmm_yukawa_grad_case("domain, new points", &o, 1, 4, &a, NULL, &b, NULL, 1, 0, 5e-5);
    kifmm_yukawa_grad_case("domain, moved 1e-2", &o, 1, 4, &b, NULL, &c, NULL, 1, 0, 5e-5);
    kifmm_laplace_grad_case("domain, separate", &o, 1, 4, &a, NULL, &c, &b, 1, 0, 5e-5);
    /* without the box the Yukawa operators follow the points' extent */
    o.domain[0] = o.domain[1] = o.domain[2] = o.domain[3] = 0.0;
    kifmm_yukawa_grad_case("no domain, new extent", &o, 1, 4, &a, NULL, &b, NULL, 0, 0, 5e-5);
    kifmm_yukawa_grad_case("no domain, same extent", &o, 1, 4, &b, NULL, &b, NULL, 1, 0, 5e-5);
    /* a point outside: KIFMM_ERR_DOMAIN from create and update_points */
    o.domain[0] = o.domain[1] = o.domain[2] = 0.5;
    o.domain[3] = 0.5;
    w.x[3 * 50 + 1] = 1.0 + 1e-9;
    rc = kifmm_yukawa_grad_create(&h, &o, 100, w.x, 100, w.x);
    CHECK(rc == KIFMM_ERR_DOMAIN && h == NULL, "create with a point outside: rc=%d", rc);
    rc = kifmm_yukawa_grad_create(&h, &o, 5000, a.x, 5000, a.x);
    CHECK(rc == 0, "create in the box: rc=%d", rc);
    if (!rc) {
        double *ref = t_doubles(4 * 5000);
        CHECK(kifmm_yukawa_grad_evaluate(h, q, ref) == 0, "evaluate in the box");
        rc = kifmm_yukawa_grad_update_points(h, 100, w.x, 100, w.x);
        CHECK(rc == KIFMM_ERR_DOMAIN, "update_points with a point outside: rc=%d", rc);
        rc = kifmm_yukawa_grad_update_points(h, 5000, a.x, 100, w.x);
        CHECK(rc == KIFMM_ERR_DOMAIN, "update_points with a target outside: rc=%d", rc);
        CHECK(kifmm_yukawa_grad_evaluate(h, q, out) == 0 && !memcmp(out, ref, 4 * 5000 * sizeof(double)),
              "the handle evaluates its points as before");
        free(ref);
    }
    kifmm_yukawa_grad_destroy(h);
    /* the box's own checks */
    {
        static const double bad[][4] = {{0.5, 0.5, 0.5, 0.0}, {0.5, 0.5, 0.5, -1.0},
                                        {NAN, 0.5, 0.5, 1.0}, {0.5, 0.5, 0.5, INFINITY},
                                        {1.0, 0.0, 0.0, 0.0}};
        int i;
        for (i = 0; i < 5; i++) {
            kifmm_opts ob = t_opts(6, 0, 0);
            memcpy(ob.domain, bad[i], sizeof ob.domain);
            h = NULL;
            rc = kifmm_yukawa_grad_create(&h, &ob, 5000, a.x, 5000, a.x);
            CHECK(rc == KIFMM_ERR_DOMAIN && h == NULL, "domain {%g %g %g %g}: rc=%d", bad[i][0],
                  bad[i][1], bad[i][2], bad[i][3], rc);
        }
        o.period[0] = 1.0;
        rc = kifmm_yukawa_grad_create(&h, &o, 5000, a.x, 5000, a.x);
        CHECK(rc == KIFMM_ERR_DOMAIN && h == NULL, "domain with a period: rc=%d", rc);
    }
    free(a.x), free(b.x), free(c.x), free(w.x), free(q), free(out);
}

/* periodic handles: the far images' operators are kept while the root and
 * the level-1 leaves are the same */
static void test_periodic(void)
{
    kifmm_opts o = t_opts(6, 0, 0);
    /* moved inside [0, 0.999): the slab's free direction keeps its root */
    pset a = set_cube(31, 3000, 0.0, 0.999), b = set_jitter(&a, 32, 5e-3, 0.0, 0.999);
    pset c = set_cube(33, 4000, 0.0, 1.0), d = set_cube(34, 2000, 0.0, 0.999);
    t_group("periodic");
    o.period[0] = o.period[1] = 1.0; /* a slab: charges that sum to zero */
    kifmm_laplace_case("slab, moved", &o, 1, 1, &a, NULL, &b, NULL, 1, 1, 0.0);
    kifmm_laplace_case("slab, new, separate", &o, 1, 1, &a, NULL, &c, &d, -1, 1, 0.0);
    o.period[2] = 1.0;
    o.kernel_param[0] = 4.0;
    kifmm_yukawaf_case("cube, moved", &o, 1, 1, &a, NULL, &b, NULL, 1, 0, 0.0);
    kifmm_yukawa_grad_case("cube, new, separate", &o, 1, 4, &b, NULL, &c, &d, -1, 0, 0.0);
    free(a.x), free(b.x), free(c.x), free(d.x);
}

/* Handles on one plan (plan_create, create_with_plan), created, moved
 * and evaluated on NH threads at once: each handle's outputs equal those
 * of a handle of its own (create) on the same points, bit for bit; the
 * operator sets are shared (the same entries); stats.bytes leaves the plan
 * out; the plan outlives plan_destroy while handles use it. */
#define NH 4
#define T_SHARED(P, R, sd, td)                                                                     \
    static void P##_shared(const char *what, const kifmm_opts *o)                                  \
    {                                                                                              \
        P##_plan *pl = NULL;                                                                       \
        P *h[NH] = {NULL}, *g[NH] = {NULL};                                                        \
        R *x[NH], *y[NH], *q[NH], *u[NH], *f[NH];                                                  \
        int64_t n[NH];                                                                             \
        int rc[NH], rcg[NH], same[NH], i, shared = 1, rc0;                                         \
        double own = 0.0, on = 0.0;                                                                \
        rc0 = P##_plan_create(&pl, o);                                                             \
        CHECK(rc0 == 0 && pl, "%s %s: plan_create rc=%d", #P, what, rc0);                          \
        if (rc0) return;                                                                           \
        for (i = 0; i < NH; i++) {                                                                 \
            pset a = set_cube(50 + i, 2500 + 700 * i, 0.05 * i, 1.0 - 0.05 * i);                   \
            pset b = set_jitter(&a, 60 + i, 2e-3, 0.0, 1.0);                                       \
            double *qd = t_densities(70 + i, a.n, sd, 1, 0);                                       \
            n[i] = a.n;                                                                            \
            x[i] = P##_conv(a.x, 3 * a.n), y[i] = P##_conv(b.x, 3 * a.n), q[i] = P##_conv(qd, a.n * sd); \
            u[i] = (R *)t_malloc_or_die((size_t)(a.n * td) * sizeof(R));                           \
            f[i] = (R *)t_malloc_or_die((size_t)(a.n * td) * sizeof(R));                           \
            free(a.x), free(b.x), free(qd);                                                        \
        }                                                                                          \
        /* each thread its own handle: create, evaluate, move, evaluate */                        \
        KIFMM__OMP(parallel for schedule(static, 1) num_threads(NH))                               \
        for (int k = 0; k < NH; k++) {                                                             \
            rc[k] = P##_create_with_plan(&h[k], pl, n[k], x[k], n[k], x[k]);                       \
            if (!rc[k]) rc[k] = P##_evaluate(h[k], q[k], u[k]);                                    \
            if (!rc[k]) rc[k] = P##_update_points(h[k], n[k], y[k], n[k], y[k]);                   \
            if (!rc[k]) rc[k] = P##_evaluate(h[k], q[k], u[k]);                                    \
        }                                                                                          \
        P##_plan_destroy(pl); /* the handles keep it */                                            \
        for (i = 0; i < NH; i++) {                                                                 \
            kifmm_stats a, b;                                                                      \
            rcg[i] = P##_create(&g[i], o, n[i], y[i], n[i], y[i]);                                 \
            if (!rcg[i]) rcg[i] = P##_evaluate(g[i], q[i], f[i]);                                  \
            CHECK(rc[i] == 0 && rcg[i] == 0, "%s %s: handle %d rc=%d (%s), alone %d", #P, what, i,  \
                  rc[i], kifmm_strerror(rc[i]), rcg[i]);                                           \
            same[i] = !rc[i] && !rcg[i] && !memcmp(u[i], f[i], (size_t)(n[i] * td) * sizeof(R));    \
            CHECK(same[i], "%s %s: handle %d on the shared plan differs from one alone", #P, what, i); \
            if (!rc[i] && i > 0 && h[i]->tree->nlev == h[0]->tree->nlev &&                           \
                h[i]->tree->width == h[0]->tree->width) {                                            \
                int l;                                                                             \
                for (l = 0; l < h[i]->tree->nlev; l++) shared &= h[i]->lv[l] == h[0]->lv[l];         \
            }                                                                                      \
            if (!rc[i] && !rcg[i] && !P##_stats(h[i], &a) && !P##_stats(g[i], &b)) {               \
                on += a.bytes;                                                                     \
                own += b.bytes;                                                                    \
            }                                                                                      \
        }                                                                                          \
        CHECK(shared, "%s %s: handles with the same levels hold different operator sets", #P, what); \
        printf("  %-18s %s: %d handles on one plan hold %.1f MiB (plan apart), %.1f MiB alone\n",   \
               #P, what, NH, on / 1048576.0, own / 1048576.0);                                     \
        CHECK(on < own, "%s %s: shared handles' bytes %.0f not below their own plans' %.0f", #P,    \
              what, on, own);                                                                      \
        for (i = 0; i < NH; i++) {                                                                 \
            P##_destroy(h[i]);                                                                     \
            P##_destroy(g[i]);                                                                     \
            free(x[i]), free(y[i]), free(q[i]), free(u[i]), free(f[i]);                            \
        }                                                                                          \
    }

T_SHARED(kifmm_laplace_grad, double, 1, 4)
T_SHARED(kifmm_yukawa_grad, double, 1, 4)
T_SHARED(kifmm_stokes, double, 3, 3)
T_SHARED(kifmm_laplacef, float, 1, 1)

static void test_shared(void)
{
    kifmm_opts o = t_opts(6, 0, 0), ob;
    kifmm_laplace_grad_plan *pl = (kifmm_laplace_grad_plan *)&o;
    kifmm_laplace_grad *h = (kifmm_laplace_grad *)&o;
    double x[6] = {0.1, 0.2, 0.3, 0.4, 0.5, 0.6};
    int rc;
    t_group("handles on one plan, on several threads at once");
    o.nthreads = 1;
    kifmm_laplace_grad_shared("p = 6", &o);
    kifmm_stokes_shared("p = 5", (o.order = 5, &o));
    kifmm_laplacef_shared("p = 5", &o);
    o.order = 6;
    o.kernel_param[0] = 2.0;
    o.domain[0] = o.domain[1] = o.domain[2] = o.domain[3] = 0.5;
    kifmm_yukawa_grad_shared("p = 6, domain", &o);
    o.domain[0] = o.domain[1] = o.domain[2] = o.domain[3] = 0.0;
    kifmm_yukawa_grad_shared("p = 6, boxes from the points", &o);
    /* errors */
    CHECK(kifmm_laplace_grad_plan_create(NULL, &o) == KIFMM_ERR_NULL, "plan_create(NULL out)");
    ob = t_opts(1, 0, 0);
    rc = kifmm_laplace_grad_plan_create(&pl, &ob);
    CHECK(rc == KIFMM_ERR_ORDER && pl == NULL, "plan_create with order 1: rc=%d", rc);
    rc = kifmm_laplace_grad_create_with_plan(&h, NULL, 2, x, 2, x);
    CHECK(rc == KIFMM_ERR_NULL && h == NULL, "create_with_plan(NULL plan): rc=%d", rc);
    o = t_opts(4, 0, 0);
    o.domain[0] = o.domain[1] = o.domain[2] = 0.0;
    o.domain[3] = 0.25;
    rc = kifmm_laplace_grad_plan_create(&pl, &o);
    CHECK(rc == 0, "plan_create with a domain: rc=%d", rc);
    h = (kifmm_laplace_grad *)&o;
    rc = kifmm_laplace_grad_create_with_plan(&h, pl, 2, x, 2, x);
    CHECK(rc == KIFMM_ERR_DOMAIN && h == NULL, "create_with_plan, points outside its domain: rc=%d", rc);
    kifmm_laplace_grad_plan_destroy(pl);
    kifmm_laplace_grad_plan_destroy(NULL);
}

int main(void)
{
    kifmm_opts o = t_opts(6, 0, 0), oy = t_opts(6, 0, 0), of = t_opts(5, 0, 0);
    oy.kernel_param[0] = 2.0;
    printf("== update_points: results as a fresh handle's, bit for bit\n");
    t_group("scale invariant: the plan kept");
    T_MOVES(kifmm_laplace, &o, 1, 1, 1, 5e-5, 0);
    T_MOVES(kifmm_laplace_grad, &o, 1, 4, 1, 5e-5, 0);
    T_MOVES(kifmm_stokes, &of, 3, 3, 1, 2e-4, 1);
    T_MOVES(kifmm_laplacef, &of, 1, 1, 1, 2e-4, 0);
#if T_UPDATE_ALL
    T_MOVES(kifmm_laplace_dense, &of, 1, 1, 1, 2e-4, 1);
#endif
#if T_UPDATE_ALL
    t_group("the other kernel families: new points, more of them, separate targets");
    {
        kifmm_opts o4 = t_opts(4, 0, 0);
        pset a = set_cube(81, 3000, 0.0, 1.0), c = set_cube(82, 4000, -0.5, 1.5);
        pset d = set_cube(83, 1500, 0.2, 0.7);
        kifmm_laplace_hess_case("new, separate", &o4, 1, 10, &a, NULL, &c, &d, 1, 0, 2e-3);
        kifmm_laplace_dipole_case("new, separate", &o4, 3, 1, &a, NULL, &c, &d, 1, 0, 1e-3);
        kifmm_stokes_dl_case("new, separate", &o4, 6, 3, &a, NULL, &c, &d, 1, 0, 1e-3);
        kifmm_biot_savart_case("new, separate", &o4, 3, 3, &a, NULL, &c, &d, 1, 0, 1e-3);
        free(a.x), free(c.x), free(d.x);
    }
#endif
    t_group("Yukawa: the levels whose width changed rebuilt");
    T_MOVES(kifmm_yukawa_grad, &oy, 1, 4, -1, 5e-5, 0);
    T_MOVES(kifmm_yukawaf, &of, 1, 1, -1, 2e-4, 0);
    test_domain();
    test_periodic();
    test_shared();
    return t_finish();
}
