/* bench/bench_update.c - a time step's cost: update_points against create
 *
 *   bench_update N [--repeat R] [--move EPS]
 *
 * On N uniform points in the unit cube (sources = targets, bench/points.h),
 * for laplace_grad at p = 6, 8 and 12, yukawa_grad (lambda 1) at p = 6 and
 * stokes (mu 1) at p = 6: create a handle, then R times: move every point
 * by up to EPS (default 1e-3) in each coordinate (inside the cube) and call
 * update_points, then evaluate. A new handle on the last points gives the
 * create + evaluate a step would cost without update_points. One row per
 * case, the fastest of R for each column: create, update_points,
 * update / create, evaluate, a step (update + evaluate), create + evaluate,
 * and their ratio; then the stages of create (plan, points, workspace,
 * stats.t_plan and friends) of the new handle. yukawa_grad runs twice:
 * with the root box from the points (its per-level operators follow the
 * points' extent) and with opts.domain fixed (they are kept). Last, four
 * laplace_grad handles at p = 10 on N points each (different sets), made
 * by create and made on one plan (plan_create, create_with_plan): the
 * memory they hold (stats.bytes, and the plan's apart) and their create
 * times. Then the boundary-element pair on N points of a sphere surface:
 * the single layer (laplace_grad) and the double layer
 * (laplace_dipole_grad) at p = 6, the second made by create and made on
 * the first one's tree (create_on_tree): its time, fastest of R, and the
 * two handles' memory.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"
#define KIFMM_KERNEL yukawa_grad
#include "kifmm.h"
#define KIFMM_KERNEL stokes
#include "kifmm.h"
#define KIFMM_KERNEL laplace_dipole_grad
#include "kifmm.h"

#include <omp.h>

#include "points.h"

/* one kernel's case through its instance P (sd densities per point) */
#define BENCH_CASE(P, sd)                                                                        \
    static void P##_case(const char *name, int p, const double *domain, int64_t n,             \
                         const double *x0, int repeat, double eps)                             \
    {                                                                                          \
        kifmm_opts o;                                                                          \
        P *h = NULL, *g = NULL;                                                                \
        double *x = (double *)malloc(3 * (size_t)n * sizeof(double));                          \
        double *q = (double *)malloc((size_t)n * (sd) * sizeof(double));                       \
        double *out = (double *)malloc((size_t)n * 4 * sizeof(double));                        \
        double tc, tu = 1e30, te = 1e30, tstep = 1e30, tce = 1e30, t0, t1, t2;                 \
        uint64_t seed = 7;                                                                     \
        kifmm_stats st;                                                                        \
        int r, rc;                                                                             \
        int64_t i;                                                                             \
        memset(&o, 0, sizeof o);                                                               \
        memset(&st, 0, sizeof st);                                                             \
        o.order = p;                                                                           \
        if (domain) memcpy(o.domain, domain, sizeof o.domain);                                 \
        memcpy(x, x0, 3 * (size_t)n * sizeof(double));                                        \
        for (i = 0; i < n * (sd); i++) q[i] = 2.0 * random01(&seed) - 1.0;                     \
        t0 = omp_get_wtime();                                                                  \
        rc = P##_create(&h, &o, n, x, n, x);                                                   \
        tc = omp_get_wtime() - t0;                                                             \
        if (!rc) rc = P##_evaluate(h, q, out);                                                 \
        for (r = 0; r < repeat && !rc; r++) {                                                  \
            for (i = 0; i < 3 * n; i++) {                                                      \
                double v = x[i] + eps * (2.0 * random01(&seed) - 1.0);                         \
                x[i] = v < 0.0 ? 0.0 : v > 1.0 ? 1.0 : v;                                      \
            }                                                                                  \
            t0 = omp_get_wtime();                                                              \
            rc = P##_update_points(h, n, x, n, x);                                             \
            t1 = omp_get_wtime();                                                              \
            if (!rc) rc = P##_evaluate(h, q, out);                                             \
            t2 = omp_get_wtime();                                                              \
            tu = t1 - t0 < tu ? t1 - t0 : tu;                                                  \
            te = t2 - t1 < te ? t2 - t1 : te;                                                  \
            tstep = t2 - t0 < tstep ? t2 - t0 : tstep;                                         \
        }                                                                                      \
        for (r = 0; r < repeat && !rc; r++) { /* a step without update_points */               \
            P##_destroy(g);                                                                    \
            g = NULL;                                                                          \
            t0 = omp_get_wtime();                                                              \
            rc = P##_create(&g, &o, n, x, n, x);                                               \
            t1 = omp_get_wtime();                                                              \
            if (!rc) rc = P##_evaluate(g, q, out);                                             \
            t2 = omp_get_wtime();                                                              \
            tc = t1 - t0 < tc ? t1 - t0 : tc;                                                  \
            tce = t2 - t0 < tce ? t2 - t0 : tce;                                               \
        }                                                                                      \
        if (rc) {                                                                              \
            printf("%-22s %2d  FAILED: %s\n", name, p, kifmm_strerror(rc));                  \
        } else {                                                                               \
            P##_stats(g, &st);                                                                 \
            printf("%-22s %2d %7.3f %7.3f %6.2fx %7.3f %7.3f %7.3f %6.2fx   %6.3f %6.3f %6.3f\n", \
                   name, p, tc, tu, tu / tc, te, tstep, tce, tstep / tce, st.t_plan, st.t_points, \
                   st.t_workspace);                                                            \
        }                                                                                      \
        fflush(stdout);                                                                        \
        P##_destroy(h);                                                                        \
        P##_destroy(g);                                                                        \
        free(x);                                                                               \
        free(q);                                                                               \
        free(out);                                                                             \
    }

BENCH_CASE(kifmm_laplace_grad, 1)

/* four handles at order p on n points each: made by create, and on one plan */
static void four_handles(int64_t n, int p)
{
    kifmm_opts o;
    kifmm_laplace_grad *a[4] = {NULL}, *b[4] = {NULL};
    kifmm_laplace_grad_plan *pl = NULL;
    double *x = (double *)malloc(3 * (size_t)n * sizeof(double)), *q = (double *)malloc((size_t)n * sizeof(double));
    double ba = 0.0, bb = 0.0, ta = 0.0, tb = 0.0, tp, t0, bc;
    kifmm_stats st;
    int i, rc = 0;
    memset(&o, 0, sizeof o);
    o.order = p;
    for (i = 0; i < 4 && !rc; i++) {
        make_points(DIST_CUBE, n, 1, 11 + (uint64_t)i, x, q);
        t0 = omp_get_wtime();
        rc = kifmm_laplace_grad_create(&a[i], &o, n, x, n, x);
        ta += omp_get_wtime() - t0;
        if (!rc && !kifmm_laplace_grad_stats(a[i], &st)) ba += st.bytes;
    }
    t0 = omp_get_wtime();
    if (!rc) rc = kifmm_laplace_grad_plan_create(&pl, &o);
    tp = omp_get_wtime() - t0;
    for (i = 0; i < 4 && !rc; i++) {
        make_points(DIST_CUBE, n, 1, 11 + (uint64_t)i, x, q);
        t0 = omp_get_wtime();
        rc = kifmm_laplace_grad_create_with_plan(&b[i], pl, n, x, n, x);
        tb += omp_get_wtime() - t0;
        if (!rc && !kifmm_laplace_grad_stats(b[i], &st)) bb += st.bytes;
    }
    /* the plan's bytes, after the last handle */
    bc = !rc && !kifmm_laplace_grad_stats(b[3], &st) ? st.plan_bytes : 0.0;
    if (rc) {
        printf("four handles: FAILED: %s\n", kifmm_strerror(rc));
    } else {
        printf("4 handles, laplace_grad p = %d, %lld points each:\n", p, (long long)n);
        printf("  by create:               %8.1f MiB, creates %.3f s\n", ba / 1048576.0, ta);
        printf("  on one plan:             %8.1f MiB handles + %.1f MiB plan = %.1f MiB (%.2fx), "
               "plan_create %.3f s + creates %.3f s\n",
               bb / 1048576.0, bc / 1048576.0, (bb + bc) / 1048576.0, (bb + bc) / ba, tp, tb);
    }
    for (i = 0; i < 4; i++) {
        kifmm_laplace_grad_destroy(a[i]);
        kifmm_laplace_grad_destroy(b[i]);
    }
    kifmm_laplace_grad_plan_destroy(pl);
    free(x);
    free(q);
}
BENCH_CASE(kifmm_yukawa_grad, 1)
BENCH_CASE(kifmm_stokes, 3)

/* the single and the double layer on one geometry (a sphere's surface):
 * the double layer's handle by create and on the single layer's tree */
static void bem_pair(int64_t n, int p, int repeat)
{
    kifmm_opts o;
    kifmm_laplace_grad *s = NULL;
    kifmm_laplace_dipole_grad *d = NULL;
    double *x = (double *)malloc(3 * (size_t)n * sizeof(double)), *q = (double *)malloc((size_t)n * sizeof(double));
    double ts = 1e30, tc = 1e30, tt = 1e30, t0, bs = 0.0, bc = 0.0, bt = 0.0, tp = 0.0;
    kifmm_stats st;
    int r, rc = 0;
    memset(&o, 0, sizeof o);
    o.order = p;
    make_points(DIST_SPHERE, n, 1, 5, x, q);
    for (r = 0; r < repeat && !rc; r++) {
        t0 = omp_get_wtime();
        rc = kifmm_laplace_grad_create(&s, &o, n, x, n, x);
        t0 = omp_get_wtime() - t0;
        ts = t0 < ts ? t0 : ts;
        if (!rc && !kifmm_laplace_grad_stats(s, &st)) bs = st.bytes;
        if (!rc) {
            kifmm_opts u = o;
            kifmm_laplace_grad_options(s, &u); /* the same leaf size as the tree's */
            o.leaf_size = u.leaf_size;
            t0 = omp_get_wtime();
            rc = kifmm_laplace_dipole_grad_create(&d, &o, n, x, n, x);
            t0 = omp_get_wtime() - t0;
            tc = t0 < tc ? t0 : tc;
            if (!rc && !kifmm_laplace_dipole_grad_stats(d, &st)) bc = st.bytes;
            kifmm_laplace_dipole_grad_destroy(d);
            d = NULL;
            o.leaf_size = 0;
        }
        if (!rc) {
            t0 = omp_get_wtime();
            rc = kifmm_laplace_dipole_grad_create_on_tree(&d, &o, kifmm_laplace_grad_tree(s));
            t0 = omp_get_wtime() - t0;
            tt = t0 < tt ? t0 : tt;
            if (!rc && !kifmm_laplace_dipole_grad_stats(d, &st)) bt = st.bytes, tp = st.t_points;
            kifmm_laplace_dipole_grad_destroy(d);
            d = NULL;
        }
        kifmm_laplace_grad_destroy(s);
        s = NULL;
    }
    if (rc) {
        printf("single and double layer: FAILED: %s\n", kifmm_strerror(rc));
    } else {
        printf("single and double layer, p = %d, %lld points of a sphere's surface (laplace_grad, then "
               "laplace_dipole_grad):\n", p, (long long)n);
        printf("  laplace_grad create:            %7.3f s %8.1f MiB\n", ts, bs / 1048576.0);
        printf("  laplace_dipole_grad create:     %7.3f s %8.1f MiB (pair %.1f MiB)\n", tc,
               bc / 1048576.0, (bs + bc) / 1048576.0);
        printf("  laplace_dipole_grad on the tree: %6.3f s %8.1f MiB (pair %.1f MiB; %.2fx the time, "
               "points' part %.3f s)\n", tt, bt / 1048576.0, (bs + bt) / 1048576.0, tt / tc, tp);
    }
    free(x);
    free(q);
}

int main(int argc, char **argv)
{
    const int64_t n = argc > 1 ? (int64_t)atof(argv[1]) : 200000;
    int repeat = 3, a;
    double eps = 1e-3, *x, *q;
    const double box[4] = {0.5, 0.5, 0.5, 0.5};
    for (a = 2; a < argc; a++) {
        if (!strcmp(argv[a], "--repeat") && a + 1 < argc) repeat = atoi(argv[++a]);
        else if (!strcmp(argv[a], "--move") && a + 1 < argc) eps = atof(argv[++a]);
    }
    if (n < 1 || repeat < 1) {
        fprintf(stderr, "usage: bench_update N [--repeat R] [--move EPS]\n");
        return 2;
    }
    x = (double *)malloc(3 * (size_t)n * sizeof(double));
    q = (double *)malloc((size_t)n * sizeof(double));
    make_points(DIST_CUBE, n, 1, 1, x, q);
    printf("%lld %s points (the unit cube), sources = targets, %d threads, moved by up to %g per step, "
           "fastest of %d\n", (long long)n, dist_names[DIST_CUBE], omp_get_max_threads(), eps, repeat);
    printf("%-22s %2s %7s %7s %7s %7s %7s %7s %7s   %-20s\n", "kernel", "p", "create", "update",
           "/create", "eval", "step", "cr+eval", "/cr+ev", "create: plan points work");
    kifmm_laplace_grad_case("laplace_grad", 6, NULL, n, x, repeat, eps);
    kifmm_laplace_grad_case("laplace_grad", 8, NULL, n, x, repeat, eps);
    kifmm_laplace_grad_case("laplace_grad", 12, NULL, n, x, repeat, eps);
    kifmm_yukawa_grad_case("yukawa_grad", 6, NULL, n, x, repeat, eps);
    kifmm_yukawa_grad_case("yukawa_grad domain", 6, box, n, x, repeat, eps);
    kifmm_stokes_case("stokes", 6, NULL, n, x, repeat, eps);
    four_handles(n, 10);
    bem_pair(n, 6, repeat);
    free(x);
    free(q);
    return 0;
}
