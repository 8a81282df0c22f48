/* test_small.c - small, empty and degenerate problems, handle semantics
 * (reuse, determinism, no retained caller pointers, overwritten outputs) and
 * option handling, for kifmm_laplace and kifmm_laplace_grad. */
#include "kifmm.h"
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"

#include "test.h"

T_DEFINE_API(kifmm_laplace, 1)
T_DEFINE_API(kifmm_laplace_grad, 4)

#define NSAMPLE 600
#define BOUND_P6 4e-6
#define BOUND_EXACT 1e-13
/* p = 6 when every target is far from every source: no exact near field
 * dilutes the relative error, which is then the far-field error itself
 * (several 1e-6 at p = 6), possibly carried through many tree levels. */
#define BOUND_P6_FAR 2e-5

static t_api apis[2];

/* Runs one problem on `api` (outputs prefilled with NaN), prints and checks
 * the potential error against `bound` and the gradient's against 10 x bound. */
static void run_vs_direct(const t_api *api, const kifmm_opts *o, int64_t ns, const double *s,
                          int64_t nt, const double *t, const double *q, double bound,
                          const char *what)
{
    double *out = t_doubles(nt * api->trg_dim);
    int rc;
    t_err e;
    t_fill(nt * api->trg_dim, out, NAN);
    rc = t_run(api, o, ns, s, nt, t, q, out, NULL, NULL);
    CHECK(rc == KIFMM_SUCCESS, "%s %s: rc=%d (%s)", what, api->name, rc, kifmm_strerror(rc));
    if (rc == KIFMM_SUCCESS) {
        e = t_error_laplace(ns, s, q, nt, t, out, api->trg_dim, NSAMPLE);
        CHECK_ERR(e.pot, bound, "%s %s potential", what, api->name);
        if (api->trg_dim == 4)
            CHECK_ERR(e.grad, 10 * bound, "%s %s gradient", what, api->name);
    }
    free(out);
}

/* Problems smaller than one leaf are pure direct sums: exact to rounding. */
static void test_tiny(void)
{
    static const int sizes[] = {1, 2, 3, 5, 8, 15};
    t_rng r = t_rng_seed(11);
    int a, i;
    t_group("problems smaller than a leaf (exact to rounding)");
    for (a = 0; a < 2; a++) {
        for (i = 0; i < (int)(sizeof sizes / sizeof sizes[0]); i++) {
            int64_t n = sizes[i], nt = n + 1;
            double s[3 * 16], t[3 * 17], q[16];
            char what[128];
            /* the order does not matter for a single leaf: cycle 2, 4, 6 */
            kifmm_opts o = t_opts(2 + 2 * (i % 3), 32, 0);
            t_gen_cube(&r, n, s, 0.0, 1.0);
            t_gen_cube(&r, nt, t, 0.25, 1.25);
            t_gen_charges(&r, n, q, -1.0, 1.0);
            sprintf(what, "N=%ld p=%d leaf 32 same", (long)n, o.order);
            run_vs_direct(&apis[a], &o, n, s, n, s, q, BOUND_EXACT, what);
            sprintf(what, "N=%ld p=%d leaf 32 separate nt=%ld", (long)n, o.order, (long)nt);
            run_vs_direct(&apis[a], &o, n, s, nt, t, q, BOUND_EXACT, what);
        }
    }
    /* default options: whatever the default leaf size is, a problem that
     * fits in it is exact */
    for (a = 0; a < 2; a++) {
        double s[3 * 8], q[8];
        kifmm_opts used;
        void *h = NULL;
        int rc;
        t_gen_cube(&r, 8, s, -3.0, 2.0);
        t_gen_charges(&r, 8, q, 0.0, 1.0);
        rc = apis[a].create(&h, NULL, 8, s, 8, s);
        CHECK(rc == KIFMM_SUCCESS, "create rc=%d", rc);
        if (rc != KIFMM_SUCCESS) continue;
        rc = apis[a].options(h, &used);
        apis[a].destroy(h);
        CHECK(rc == KIFMM_SUCCESS && used.leaf_size > 0, "options rc=%d leaf_size %d", rc,
              used.leaf_size);
        if (rc == KIFMM_SUCCESS && used.leaf_size > 0) {
            int m = used.leaf_size < 8 ? used.leaf_size : 8;
            char what[64];
            sprintf(what, "N=%d default options (leaf_size %d)", m, used.leaf_size);
            run_vs_direct(&apis[a], NULL, m, s, m, s, q, BOUND_EXACT, what);
        }
    }
}

/* Zero sources: outputs are zeros. Zero targets: nothing written. */
static void test_empty(void)
{
    t_rng r = t_rng_seed(12);
    double pts[30], q[10], out[40];
    int a, k;
    t_group("zero sources / zero targets");
    t_gen_cube(&r, 10, pts, 0.0, 1.0);
    t_gen_charges(&r, 10, q, -1.0, 1.0);
    for (a = 0; a < 2; a++) {
        const t_api *api = &apis[a];
        int d = api->trg_dim, rc, bad;
        void *h = (void *)&r;

        /* no sources */
        rc = api->create(&h, NULL, 0, NULL, 10, pts);
        CHECK(rc == KIFMM_SUCCESS && h != NULL, "%s ns=0 create rc=%d", api->name, rc);
        if (rc == KIFMM_SUCCESS) {
            t_fill(40, out, 7.0);
            rc = api->evaluate(h, NULL, out);
            bad = 0;
            for (k = 0; k < 10 * d; k++) bad += out[k] != 0.0;
            for (k = 10 * d; k < 40; k++) bad += out[k] != 7.0;
            CHECK(rc == KIFMM_SUCCESS && bad == 0,
                  "%s ns=0, NULL densities: rc=%d, %d wrong values", api->name, rc, bad);
            t_fill(40, out, -3.0);
            rc = api->evaluate(h, q, out);
            bad = 0;
            for (k = 0; k < 10 * d; k++) bad += out[k] != 0.0;
            CHECK(rc == KIFMM_SUCCESS && bad == 0,
                  "%s ns=0, non-NULL densities: rc=%d, %d wrong values", api->name, rc, bad);
            api->destroy(h);
        }

        /* no targets */
        h = (void *)&r;
        rc = api->create(&h, NULL, 10, pts, 0, NULL);
        CHECK(rc == KIFMM_SUCCESS && h != NULL, "%s nt=0 create rc=%d", api->name, rc);
        if (rc == KIFMM_SUCCESS) {
            rc = api->evaluate(h, q, NULL);
            CHECK(rc == KIFMM_SUCCESS, "%s nt=0, NULL out: rc=%d", api->name, rc);
            t_fill(40, out, 7.0);
            rc = api->evaluate(h, q, out);
            bad = 0;
            for (k = 0; k < 40; k++) bad += out[k] != 7.0;
            CHECK(rc == KIFMM_SUCCESS && bad == 0, "%s nt=0: rc=%d, %d values written",
                  api->name, rc, bad);
            api->destroy(h);
        }

        /* neither */
        h = (void *)&r;
        rc = api->create(&h, NULL, 0, NULL, 0, NULL);
        CHECK(rc == KIFMM_SUCCESS && h != NULL, "%s ns=nt=0 create rc=%d", api->name, rc);
        if (rc == KIFMM_SUCCESS) {
            rc = api->evaluate(h, NULL, NULL);
            CHECK(rc == KIFMM_SUCCESS, "%s ns=nt=0 evaluate rc=%d", api->name, rc);
            api->destroy(h);
        }
    }
}

/* 1000 points at one place: every pair at distance 0, so the result is 0. */
static void test_coincident(void)
{
    int64_t n = 1000, nt = 500;
    double *x = t_doubles(3 * n), *t = t_doubles(3 * nt), *q = t_doubles(n);
    double *out = t_doubles(4 * n);
    t_rng r = t_rng_seed(13);
    int a, v;
    t_group("coincident points");
    t_gen_coincident(n, x, 0.25, 0.5, 0.75);
    t_gen_charges(&r, n, q, -1.0, 1.0);
    t_gen_cube(&r, nt, t, 0.0, 1.0);
    for (a = 0; a < 2; a++) {
        const t_api *api = &apis[a];
        /* leaf_size default or 1, max_depth default or KIFMM_MAX_DEPTH */
        for (v = 0; v < 3; v++) {
            kifmm_opts o = t_opts(6, v == 0 ? 0 : 1, v == 2 ? KIFMM_MAX_DEPTH : 0);
            int rc;
            t_fill(n * api->trg_dim, out, NAN);
            rc = t_run(api, &o, n, x, n, x, q, out, NULL, NULL);
            CHECK(rc == KIFMM_SUCCESS, "%s coincident leaf %d depth %d rc=%d", api->name,
                  o.leaf_size, o.max_depth, rc);
            if (rc == KIFMM_SUCCESS)
                CHECK(t_max_abs(n * api->trg_dim, out) == 0.0,
                      "%s coincident leaf %d depth %d: max |out| = %g, expected 0", api->name,
                      o.leaf_size, o.max_depth, t_max_abs(n * api->trg_dim, out));
        }
        {
            kifmm_opts o = t_opts(6, 0, 0);
            run_vs_direct(api, &o, n, x, nt, t, q, BOUND_P6_FAR,
                          "coincident sources, random targets");
        }
    }
    free(x);
    free(t);
    free(q);
    free(out);
}

/* Degenerate but valid geometries at p = 6, sources = targets. */
static void test_degenerate(void)
{
    int64_t n = 4096, i; /* 16^3, for the lattice */
    double *x = t_doubles(3 * n), *q = t_doubles(n);
    t_rng r = t_rng_seed(14);
    kifmm_opts o = t_opts(6, 0, 0);
    int a;
    t_group("degenerate geometries, p = 6, sources = targets");
    t_gen_charges(&r, n, q, -1.0, 1.0);
    for (a = 0; a < 2; a++) {
        const t_api *api = &apis[a];

        /* two clusters of size 1e-3 at distance 1e3 (1e6 x their size) */
        t_gen_two_clusters(&r, n, x, 1e-3, 1e3);
        run_vs_direct(api, &o, n, x, n, x, q, BOUND_P6, "two far clusters");

        t_gen_line(&r, n, x, 1);
        run_vs_direct(api, &o, n, x, n, x, q, BOUND_P6, "line (axis-aligned)");
        t_gen_line(&r, n, x, 0);
        run_vs_direct(api, &o, n, x, n, x, q, BOUND_P6, "line (tilted)");
        t_gen_plane(&r, n, x, 1);
        run_vs_direct(api, &o, n, x, n, x, q, BOUND_P6, "plane (axis-aligned)");
        t_gen_plane(&r, n, x, 0);
        run_vs_direct(api, &o, n, x, n, x, q, BOUND_P6, "plane (tilted)");

        /* a 16 x 16 x 16 lattice with spacing 1/15: points on the root
         * box's faces and on the children's dividing planes */
        for (i = 0; i < n; i++) {
            x[3 * i + 0] = (double)(i % 16) / 15.0;
            x[3 * i + 1] = (double)((i / 16) % 16) / 15.0;
            x[3 * i + 2] = (double)(i / 256) / 15.0;
        }
        run_vs_direct(api, &o, n, x, n, x, q, BOUND_P6, "lattice");

        /* every point twice: the twin is at distance 0 and skipped */
        t_gen_cube(&r, n / 2, x, 0.0, 1.0);
        for (i = 0; i < 3 * (n / 2); i++) x[3 * (n / 2) + i] = x[i];
        run_vs_direct(api, &o, n, x, n, x, q, BOUND_P6, "duplicated point set");
    }
    free(x);
    free(q);
}

/* Targets in deep leaves (coincident targets, or a tight target cluster far
 * from the sources): the local field reaches them through many levels, and
 * the gradient there is small next to potential / leaf size.  Same rule as
 * everywhere else: the gradient within 10 x the potential bound. */
static void test_deep_targets(void)
{
    int64_t n = 4000;
    double *x = t_doubles(3 * n), *t = t_doubles(3 * n), *q = t_doubles(n);
    t_rng r = t_rng_seed(18);
    kifmm_opts o = t_opts(6, 0, 0);
    int a;
    t_group("targets in deep leaves: coincident or tightly clustered, p = 6");
    t_gen_charges(&r, n, q, -1.0, 1.0);
    for (a = 0; a < 2; a++) {
        const t_api *api = &apis[a];

        /* 500 random sources, 1000 coincident targets */
        t_gen_cube(&r, 500, x, 0.0, 1.0);
        t_gen_coincident(1000, t, 0.25, 0.5, 0.75);
        run_vs_direct(api, &o, 500, x, 1000, t, q, BOUND_P6_FAR,
                      "random sources, coincident targets");

        /* half coincident, half random, sources = targets */
        t_gen_cube(&r, n, x, 0.0, 1.0);
        t_gen_coincident(n / 2, x, 0.3, 0.3, 0.3);
        run_vs_direct(api, &o, n, x, n, x, q, BOUND_P6, "half coincident");

        /* sources in one cluster of size 1e-3, targets in another 1e3 away */
        t_gen_two_clusters(&r, n, x, 1e-3, 1e3);
        run_vs_direct(api, &o, n / 2, x, n / 2, x + 3 * (n / 2), q, BOUND_P6_FAR,
                      "two far clusters, A -> B");
        /* the same with clusters of size 1 at distance 1e6 */
        t_gen_two_clusters(&r, n, x, 1.0, 1e6);
        run_vs_direct(api, &o, n / 2, x, n / 2, x + 3 * (n / 2), q, BOUND_P6_FAR,
                      "two far clusters (size 1, dist 1e6), A -> B");
    }
    free(x);
    free(t);
    free(q);
}

/* One handle, several evaluations; determinism; no retained caller pointers;
 * outputs overwritten. */
static void test_handle(void)
{
    int64_t ns = 5000, nt = 3000;
    t_rng r = t_rng_seed(15);
    int a;
    t_group("handle reuse, determinism, ownership, overwrite");
    for (a = 0; a < 2; a++) {
        const t_api *api = &apis[a];
        int d = api->trg_dim, rc, rc2;
        double *s = t_doubles(3 * ns), *t = t_doubles(3 * nt);
        double *q1 = t_doubles(ns), *q2 = t_doubles(ns);
        double *o1 = t_doubles(nt * d), *o2 = t_doubles(nt * d), *o3 = t_doubles(nt * d);
        double *s_copy, *t_copy;
        kifmm_opts o = t_opts(6, 0, 0);
        void *h = NULL, *h2 = NULL;
        t_err e;

        t_gen_cube(&r, ns, s, 0.0, 1.0);
        t_gen_cube(&r, nt, t, 0.0, 1.0);
        t_gen_charges(&r, ns, q1, -1.0, 1.0);
        t_gen_charges(&r, ns, q2, 0.0, 1.0);
        s_copy = t_dup(3 * ns, s);
        t_copy = t_dup(3 * nt, t);

        rc = api->create(&h, &o, ns, s, nt, t);
        CHECK(rc == KIFMM_SUCCESS, "%s create rc=%d", api->name, rc);
        if (rc != KIFMM_SUCCESS) {
            free(s); free(t); free(q1); free(q2); free(o1); free(o2); free(o3);
            free(s_copy); free(t_copy);
            continue;
        }
        /* the caller's coordinates are scribbled over and freed: the handle
         * must not need them */
        memset(s, 0xff, (size_t)(3 * ns) * sizeof(double));
        memset(t, 0xff, (size_t)(3 * nt) * sizeof(double));
        free(s);
        free(t);

        /* two densities on one handle, outputs prefilled with garbage */
        t_fill(nt * d, o1, NAN);
        rc = api->evaluate(h, q1, o1);
        t_fill(nt * d, o2, 1e300);
        rc2 = api->evaluate(h, q2, o2);
        CHECK(rc == KIFMM_SUCCESS && rc2 == KIFMM_SUCCESS, "%s evaluate rc=%d %d", api->name, rc,
              rc2);
        e = t_error_laplace(ns, s_copy, q1, nt, t_copy, o1, d, NSAMPLE);
        CHECK_ERR(e.pot, BOUND_P6, "%s freed coordinates, densities 1, NaN prefill", api->name);
        if (d == 4) CHECK_ERR(e.grad, 10 * BOUND_P6, "%s  gradient", api->name);
        e = t_error_laplace(ns, s_copy, q2, nt, t_copy, o2, d, NSAMPLE);
        CHECK_ERR(e.pot, BOUND_P6, "%s same handle, densities 2, 1e300 prefill", api->name);
        if (d == 4) CHECK_ERR(e.grad, 10 * BOUND_P6, "%s  gradient", api->name);

        /* determinism: the same handle again, then a second handle */
        t_fill(nt * d, o3, -1.0);
        rc = api->evaluate(h, q1, o3);
        CHECK(rc == KIFMM_SUCCESS && memcmp(o1, o3, (size_t)(nt * d) * sizeof(double)) == 0,
              "%s re-evaluation not bit-identical (rc=%d)", api->name, rc);
        rc = api->create(&h2, &o, ns, s_copy, nt, t_copy);
        CHECK(rc == KIFMM_SUCCESS, "%s second create rc=%d", api->name, rc);
        if (rc == KIFMM_SUCCESS) {
            t_fill(nt * d, o3, 2.0);
            rc = api->evaluate(h2, q1, o3);
            CHECK(rc == KIFMM_SUCCESS &&
                      memcmp(o1, o3, (size_t)(nt * d) * sizeof(double)) == 0,
                  "%s second handle not bit-identical (rc=%d)", api->name, rc);
            t_fill(nt * d, o3, 3.0);
            rc = api->evaluate(h2, q2, o3);
            CHECK(rc == KIFMM_SUCCESS &&
                      memcmp(o2, o3, (size_t)(nt * d) * sizeof(double)) == 0,
                  "%s second handle, densities 2, not bit-identical (rc=%d)", api->name, rc);
            api->destroy(h2);
        }
        api->destroy(h);

        free(q1); free(q2); free(o1); free(o2); free(o3);
        free(s_copy); free(t_copy);
    }
}

/* Extreme tree options stay accurate. */
static void test_tree_options(void)
{
    t_rng r = t_rng_seed(16);
#ifdef KIFMM_TEST_QUICK
    int64_t n = 1500;
#else
    int64_t n = 3000;
#endif
    double *x = t_doubles(3 * n), *q = t_doubles(n);
    int a;
    t_group("tree options");
    t_gen_cube(&r, n, x, 0.0, 1.0);
    t_gen_charges(&r, n, q, -1.0, 1.0);
    for (a = 0; a < 2; a++) {
        kifmm_opts o = t_opts(6, 1, 0);
        run_vs_direct(&apis[a], &o, n, x, n, x, q, BOUND_P6, "leaf_size 1");
        o = t_opts(6, 0, 2);
        run_vs_direct(&apis[a], &o, n, x, n, x, q, BOUND_P6, "max_depth 2");
        o = t_opts(6, 0, 1);
        run_vs_direct(&apis[a], &o, n, x, n, x, q, BOUND_P6, "max_depth 1");
        o = t_opts(6, 1, 3);
        run_vs_direct(&apis[a], &o, n, x, n, x, q, BOUND_P6, "leaf_size 1, max_depth 3");
        o = t_opts(6, 0, 0);
        o.nthreads = 1;
        run_vs_direct(&apis[a], &o, n, x, n, x, q, BOUND_P6, "nthreads 1");
        run_vs_direct(&apis[a], NULL, n, x, n, x, q, BOUND_P6, "opts NULL (order 6)");
    }
    free(x);
    free(q);
}

/* The same problem scaled by 1e-6 and 1e6 and shifted by 1e6: the operators
 * of a scale-invariant kernel are rescaled per level, and the gradient
 * scales with a different power than the potential. */
static void test_scale_shift(void)
{
    t_rng r = t_rng_seed(19);
    int64_t n = 4000, i;
    double *x0 = t_doubles(3 * n), *x = t_doubles(3 * n), *q = t_doubles(n);
    kifmm_opts o = t_opts(6, 0, 0);
    int a, v;
    t_group("scaled and shifted point sets, p = 6");
    t_gen_cube(&r, n, x0, 0.0, 1.0);
    t_gen_charges(&r, n, q, -1.0, 1.0);
    for (a = 0; a < 2; a++) {
        for (v = 0; v < 4; v++) {
            static const char *names[4] = {"cube of side 1e-6", "cube of side 1e6",
                                           "unit cube shifted by 1e6", "cube [-1e3, 0]^3"};
            for (i = 0; i < 3 * n; i++) {
                switch (v) {
                case 0: x[i] = 1e-6 * x0[i]; break;
                case 1: x[i] = 1e6 * x0[i]; break;
                case 2: x[i] = x0[i] + 1e6; break;
                default: x[i] = -1e3 * x0[i]; break;
                }
            }
            run_vs_direct(&apis[a], &o, n, x, n, x, q, BOUND_P6, names[v]);
        }
    }
    free(x0);
    free(x);
    free(q);
}

#ifdef _OPENMP
/* nthreads is honoured without touching the caller's OpenMP settings. */
static void test_threads(void)
{
    t_rng r = t_rng_seed(20);
    int64_t n = 3000;
    double *x = t_doubles(3 * n), *q = t_doubles(n);
    int a, v, before = omp_get_max_threads(), dyn = omp_get_dynamic();
    t_group("nthreads and the caller's OpenMP state");
    t_gen_cube(&r, n, x, 0.0, 1.0);
    t_gen_charges(&r, n, q, -1.0, 1.0);
    for (a = 0; a < 2; a++) {
        for (v = 1; v <= 3; v++) {
            kifmm_opts o = t_opts(6, 0, 0);
            char what[64];
            o.nthreads = v;
            sprintf(what, "nthreads %d", v);
            run_vs_direct(&apis[a], &o, n, x, n, x, q, BOUND_P6, what);
            CHECK(omp_get_max_threads() == before && omp_get_dynamic() == dyn,
                  "%s nthreads %d changed omp_get_max_threads %d -> %d or dynamic %d -> %d",
                  apis[a].name, v, before, omp_get_max_threads(), dyn, omp_get_dynamic());
        }
    }
    free(x);
    free(q);
}

/* Distinct handles created and evaluated from two threads at once give the
 * same bits as when created and evaluated one after the other. */
static void test_concurrent_handles(void)
{
    int64_t n = 3000;
    double *x[2], *q[2], *serial[2], *par[2];
    int a, k, rc_serial[2] = {0, 0}, rc_par[2] = {0, 0};
    t_group("distinct handles in concurrent threads");
    for (k = 0; k < 2; k++) {
        t_rng r = t_rng_seed(60 + (uint64_t)k);
        x[k] = t_doubles(3 * n);
        q[k] = t_doubles(n);
        serial[k] = t_doubles(4 * n);
        par[k] = t_doubles(4 * n);
        t_gen_cube(&r, n, x[k], 0.0, 1.0);
        t_gen_charges(&r, n, q[k], -1.0, 1.0);
    }
    for (a = 0; a < 2; a++) {
        const t_api *api = &apis[a];
        kifmm_opts o = t_opts(6, 0, 0);
        o.nthreads = 1; /* the same thread count in both runs */
        for (k = 0; k < 2; k++) {
            o.order = 4 + 2 * k; /* two different problems */
            rc_serial[k] = t_run(api, &o, n, x[k], n, x[k], q[k], serial[k], NULL, NULL);
        }
#pragma omp parallel for num_threads(2) schedule(static, 1) firstprivate(o)
        for (k = 0; k < 2; k++) {
            o.order = 4 + 2 * k;
            rc_par[k] = t_run(api, &o, n, x[k], n, x[k], q[k], par[k], NULL, NULL);
        }
        for (k = 0; k < 2; k++) {
            size_t bytes = (size_t)(n * api->trg_dim) * sizeof(double);
            CHECK(rc_serial[k] == 0 && rc_par[k] == 0 && memcmp(serial[k], par[k], bytes) == 0,
                  "%s problem %d: concurrent result differs from serial (rc %d %d)", api->name,
                  k, rc_serial[k], rc_par[k]);
        }
    }
    for (k = 0; k < 2; k++) {
        free(x[k]);
        free(q[k]);
        free(serial[k]);
        free(par[k]);
    }
}
#endif

/* P_options reports resolved defaults and echoes explicit values. */
static void test_options(void)
{
    t_rng r = t_rng_seed(17);
    int64_t n = 2000;
    double *x = t_doubles(3 * n);
    int a;
    t_group("resolved options");
    t_gen_cube(&r, n, x, 0.0, 1.0);
    for (a = 0; a < 2; a++) {
        const t_api *api = &apis[a];
        kifmm_opts o = t_opts(0, 0, 0), used;
        void *h = NULL;
        int rc, v;
        for (v = 0; v < 2; v++) {
            rc = api->create(&h, v == 0 ? &o : NULL, n, x, n, x);
            CHECK(rc == KIFMM_SUCCESS, "%s create rc=%d", api->name, rc);
            if (rc != KIFMM_SUCCESS) continue;
            memset(&used, 0, sizeof used);
            rc = api->options(h, &used);
            CHECK(rc == KIFMM_SUCCESS, "%s options rc=%d", api->name, rc);
            CHECK(used.order == 6, "%s %s: default order %d, expected 6", api->name,
                  v ? "NULL opts" : "zero opts", used.order);
            CHECK(used.leaf_size > 0, "%s default leaf_size %d", api->name, used.leaf_size);
            CHECK(used.max_depth == 16, "%s default max_depth %d, expected 16", api->name,
                  used.max_depth);
            CHECK(used.nthreads >= 0, "%s nthreads %d", api->name, used.nthreads);
            api->destroy(h);
            h = NULL;
        }

        o = t_opts(8, 40, 12);
        rc = api->create(&h, &o, n, x, n, x);
        CHECK(rc == KIFMM_SUCCESS, "%s create rc=%d", api->name, rc);
        if (rc == KIFMM_SUCCESS) {
            rc = api->options(h, &used);
            CHECK(rc == KIFMM_SUCCESS && used.order == 8 && used.leaf_size == 40 &&
                      used.max_depth == 12,
                  "%s explicit options not echoed: rc=%d order %d leaf %d depth %d", api->name,
                  rc, used.order, used.leaf_size, used.max_depth);
            api->destroy(h);
        }

        /* the extreme valid orders create and evaluate (the largest one is
         * slow to precompute: quick builds other than the sanitizer build
         * leave it out) */
        for (v = 0; v < 2; v++) {
#if defined(KIFMM_TEST_QUICK) && !defined(__SANITIZE_ADDRESS__)
            if (v == 1) break;
#endif
            int p = v == 0 ? 2 : KIFMM_MAX_ORDER;
            double *q = t_doubles(200), *out = t_doubles(200 * api->trg_dim);
            int i;
            for (i = 0; i < 200; i++) q[i] = 1.0;
            o = t_opts(p, 0, 0);
            h = NULL;
            rc = api->create(&h, &o, 200, x, 200, x);
            CHECK(rc == KIFMM_SUCCESS, "%s order %d create rc=%d", api->name, p, rc);
            if (rc == KIFMM_SUCCESS) {
                rc = api->options(h, &used);
                CHECK(rc == KIFMM_SUCCESS && used.order == p, "%s order %d reported %d",
                      api->name, p, used.order);
                rc = api->evaluate(h, q, out);
                CHECK(rc == KIFMM_SUCCESS, "%s order %d evaluate rc=%d", api->name, p, rc);
                api->destroy(h);
            }
            free(q);
            free(out);
        }
    }
    free(x);
}

int main(void)
{
    double t0 = t_wall();
    apis[0] = kifmm_laplace_t_api();
    apis[1] = kifmm_laplace_grad_t_api();
    test_tiny();
    test_empty();
    test_coincident();
    test_degenerate();
    test_deep_targets();
    test_handle();
    test_tree_options();
    test_scale_shift();
#ifdef _OPENMP
    test_threads();
    test_concurrent_handles();
#endif
    test_options();
    printf("test_small: %.1fs\n", t_wall() - t0);
    return t_finish();
}
