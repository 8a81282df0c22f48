/* test_tree.c - one tree for several kernels: a handle made on another
 * handle's tree (<prefix>_tree, <prefix>_create_on_tree,
 * <prefix>_create_with_plan_on_tree, <prefix>_update_on_tree) sorts and
 * refines nothing again, and its outputs must equal, bit for bit, those of
 * a handle of the same kernel created on the same points with the same
 * options (the tree is the same tree), and match the direct sums of
 * <prefix>_direct (no tree, no expansions) to the method's accuracy.
 * Cases: the boundary-element pair (laplace_grad's tree for
 * laplace_dipole_grad), another order of the same kernel, a kernel that is
 * not scale invariant (yukawa_grad), another number of components
 * (stokes), float, periodic trees, separate targets, empty sets, the dense
 * M2L (which needs the V lists an FFT tree lacks), handles on one tree on
 * several threads at once, the tree outliving the handle that built it,
 * and trees that do not fit (KIFMM_ERR_TREE, nothing changed). */
#include "kifmm.h"
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"
#define KIFMM_KERNEL laplace_dipole_grad
#include "kifmm.h"
#define KIFMM_KERNEL yukawa_grad
#include "kifmm.h"
#define KIFMM_KERNEL stokes
#include "kifmm.h"
#define KIFMM_KERNEL laplace
#define KIFMM_REAL float
#include "kifmm.h"
#define KIFMM_KERNEL yukawa_grad
#define KIFMM_REAL float
#include "kifmm.h"
#define KIFMM_KERNEL laplace
#define KIFMM_M2L_DENSE
#define KIFMM_NAME kifmm_laplace_dense
#include "kifmm.h"
#undef KIFMM_M2L_DENSE

#include "test.h"

/* a point set in double */
typedef struct {
    int64_t n;
    double *x;
} pset;

static pset set_of(int kind, uint64_t seed, int64_t n)
{
    t_rng r = t_rng_seed(seed);
    pset s;
    s.n = n;
    s.x = t_doubles(3 * n + 3);
    if (kind == 0) t_gen_cube(&r, n, s.x, 0.0, 1.0);
    else if (kind == 1) t_gen_sphere(&r, n, s.x);
    else t_gen_blobs(&r, n, s.x);
    return s;
}

#define T_CONV(R)                                                                                  \
    static R *conv_##R(const double *x, int64_t n)                                                 \
    {                                                                                              \
        R *y = (R *)t_malloc_or_die((size_t)(n > 0 ? n : 1) * sizeof(R));                          \
        int64_t i;                                                                                 \
        for (i = 0; i < n; i++) y[i] = (R)x[i];                                                    \
        return y;                                                                                  \
    }
T_CONV(double)
T_CONV(float)

/* One pair: A's handle on (s, t) (t NULL: targets = sources, the same
 * array) with options oa; B's handle on A's tree with options ob (its
 * leaf size and depth 0: the tree's), against B's handle created on the
 * same points with ob and A's leaf size and depth. B has sd densities per
 * source and td outputs per target. bound: relative L2 error against
 * direct sums at up to 300 targets (0: not checked, periodic). Then A is
 * destroyed (B keeps the tree), A' is made on points s2 and B follows it
 * (update_on_tree), against B created on s2. */
#define T_PAIR(A, B, R)                                                                            \
    static void A##_##B(const char *what, const kifmm_opts *oa, const kifmm_opts *ob, int sd,      \
                        int td, const pset *s, const pset *t, const pset *s2, int neutral,          \
                        double bound)                                                              \
    {                                                                                              \
        R *xs = conv_##R(s->x, 3 * s->n), *xt = t ? conv_##R(t->x, 3 * t->n) : xs;                 \
        R *xs2 = conv_##R(s2->x, 3 * s2->n);                                                       \
        const int64_t nt = t ? t->n : s->n, nmax = nt > s2->n ? nt : s2->n;                         \
        double *qd = t_densities(21, s->n, sd, 2, neutral);                                        \
        double *qd2 = t_densities(22, s2->n, sd, 1, neutral);                                      \
        R *q = conv_##R(qd, 2 * s->n * sd), *q2 = conv_##R(qd2, s2->n * sd);                       \
        R *u = (R *)t_malloc_or_die((size_t)(2 * nmax * td + 1) * sizeof(R));                      \
        R *f = (R *)t_malloc_or_die((size_t)(2 * nmax * td + 1) * sizeof(R));                      \
        A *a = NULL, *a2 = NULL;                                                                   \
        B *b = NULL, *g = NULL, *g2 = NULL;                                                        \
        kifmm_opts og = *ob, used = *ob;                                                              \
        kifmm_stats sa, sb, sg;                                                                    \
        const double t_start = t_wall();                                                           \
        int rc, rc2, k;                                                                            \
        int64_t i;                                                                                 \
        rc = A##_create(&a, oa, s->n, xs, nt, xt);                                                 \
        CHECK(rc == 0, "%s %s: %s create rc=%d (%s)", #B, what, #A, rc, kifmm_strerror(rc));       \
        if (rc) goto done;                                                                         \
        b = (B *)&og; /* a failing call must set it to NULL */                                     \
        rc = B##_create_on_tree(&b, ob, A##_tree(a));                                              \
        CHECK(rc == 0 && b, "%s %s: create_on_tree rc=%d (%s)", #B, what, rc, kifmm_strerror(rc)); \
        A##_options(a, &used);                                                                     \
        og.leaf_size = used.leaf_size, og.max_depth = used.max_depth;                              \
        rc2 = B##_create(&g, &og, s->n, xs, nt, xt);                                               \
        CHECK(rc2 == 0, "%s %s: fresh create rc=%d", #B, what, rc2);                               \
        if (rc || rc2) goto done;                                                                  \
        CHECK(B##_tree(b) == A##_tree(a) && B##_tree(g) != A##_tree(a),                            \
              "%s %s: the handle holds the tree it was made on", #B, what);                        \
        for (k = 1; k <= 2; k++) {                                                                 \
            const size_t no = (size_t)(k * nt * td);                                               \
            rc = k == 1 ? B##_evaluate(b, q, u) : B##_evaluate_many(b, 2, q, u);                   \
            rc2 = k == 1 ? B##_evaluate(g, q, f) : B##_evaluate_many(g, 2, q, f);                  \
            CHECK(rc == 0 && rc2 == 0, "%s %s: evaluate rc=%d, fresh %d", #B, what, rc, rc2);       \
            CHECK(!memcmp(u, f, no * sizeof(R)),                                                   \
                  "%s %s: %d vector(s): on %s's tree the outputs differ from a fresh handle's",    \
                  #B, what, k, #A);                                                                \
        }                                                                                          \
        if (bound > 0.0 && nt > 0 && s->n > 0) {                                                   \
            const int64_t m = nt < 300 ? nt : 300;                                                 \
            R *ref = (R *)t_malloc_or_die((size_t)(m * td) * sizeof(R));                           \
            double e2 = 0.0, r2 = 0.0;                                                             \
            rc = B##_evaluate(b, q, u);                                                            \
            rc2 = B##_direct(ob, s->n, xs, q, m, xt, ref);                                         \
            CHECK(rc == 0 && rc2 == 0, "%s %s: direct rc=%d", #B, what, rc2);                      \
            for (i = 0; i < m * td; i++) {                                                         \
                e2 += ((double)u[i] - (double)ref[i]) * ((double)u[i] - (double)ref[i]);           \
                r2 += (double)ref[i] * (double)ref[i];                                             \
            }                                                                                      \
            CHECK_ERR(sqrt(e2 / r2), bound, "%s %s: on %s's tree vs direct", #B, what, #A);        \
            free(ref);                                                                             \
        }                                                                                          \
        /* memory: the tree counted once, by the handle that built it; the  \
         * rest as a fresh handle's */                          \
        if (!A##_stats(a, &sa) && !B##_stats(b, &sb) && !B##_stats(g, &sg)) {                      \
            CHECK(sb.tree_bytes == sa.tree_bytes && sb.tree_bytes > 0.0 &&                         \
                      sb.bytes == sg.bytes - sg.tree_bytes,                                        \
                  "%s %s: bytes %.0f, tree %.0f (builder's %.0f); a fresh handle %.0f, tree %.0f", \
                  #B, what, sb.bytes, sb.tree_bytes, sa.tree_bytes, sg.bytes, sg.tree_bytes);      \
        }                                                                                          \
        /* the tree outlives the handle that built it */                                          \
        A##_destroy(a);                                                                            \
        a = NULL;                                                                                  \
        rc = B##_evaluate(b, q, u);                                                                \
        rc2 = B##_evaluate(g, q, f);                                                               \
        CHECK(rc == 0 && rc2 == 0 && !memcmp(u, f, (size_t)(nt * td) * sizeof(R)),                 \
              "%s %s: after %s's handle is gone (rc=%d)", #B, what, #A, rc);                       \
        /* B follows A onto new points (sources = targets) */                                     \
        rc = A##_create(&a2, oa, s2->n, xs2, s2->n, xs2);                                          \
        CHECK(rc == 0, "%s %s: %s create on the second points rc=%d", #B, what, #A, rc);           \
        if (rc) goto done;                                                                         \
        rc = B##_update_on_tree(b, A##_tree(a2));                                                  \
        rc2 = B##_create(&g2, &og, s2->n, xs2, s2->n, xs2);                                        \
        CHECK(rc == 0 && rc2 == 0, "%s %s: update_on_tree rc=%d (%s), fresh %d", #B, what, rc,     \
              kifmm_strerror(rc), rc2);                                                            \
        if (rc || rc2) goto done;                                                                  \
        rc = B##_evaluate(b, q2, u);                                                               \
        rc2 = B##_evaluate(g2, q2, f);                                                             \
        CHECK(rc == 0 && rc2 == 0 && !memcmp(u, f, (size_t)(s2->n * td) * sizeof(R)),              \
              "%s %s: after update_on_tree the outputs differ from a fresh handle's", #B, what);  \
        /* and back to points of its own */                                                        \
        rc = B##_update_points(b, s2->n, xs2, s2->n, xs2);                                         \
        CHECK(rc == 0 && B##_tree(b) != A##_tree(a2), "%s %s: update_points rc=%d", #B, what, rc); \
        rc = B##_evaluate(b, q2, u);                                                               \
        CHECK(rc == 0 && !memcmp(u, f, (size_t)(s2->n * td) * sizeof(R)),                         \
              "%s %s: on a tree of its own again the outputs differ (rc=%d)", #B, what, rc);       \
        printf("  done %-20s on %-20s %-22s %.2f s\n", #B, #A, what, t_wall() - t_start);          \
    done:                                                                                          \
        A##_destroy(a);                                                                            \
        A##_destroy(a2);                                                                           \
        B##_destroy(b);                                                                            \
        B##_destroy(g);                                                                            \
        B##_destroy(g2);                                                                           \
        free(xs), free(xs2), free(qd), free(qd2), free(q), free(q2), free(u), free(f);             \
        if (t) free(xt);                                                                           \
    }

T_PAIR(kifmm_laplace_grad, kifmm_laplace_dipole_grad, double)
T_PAIR(kifmm_laplace_grad, kifmm_laplace_grad, double)
T_PAIR(kifmm_laplace, kifmm_yukawa_grad, double)
T_PAIR(kifmm_laplace_dipole_grad, kifmm_stokes, double)
T_PAIR(kifmm_laplacef, kifmm_yukawa_gradf, float)
T_PAIR(kifmm_laplace_dense, kifmm_laplace_grad, double)
T_PAIR(kifmm_laplace_grad, kifmm_laplace, double)

#ifdef KIFMM_TEST_QUICK
#define T_N 4000
#define T_HIGH 6 /* the order on another order's tree */
#else
#define T_N 20000
#define T_HIGH 8
#endif

static void test_pairs(void)
{
    kifmm_opts o = t_opts(6, 0, 0), o4 = t_opts(4, 0, 0), o8 = t_opts(T_HIGH, 0, 0);
    kifmm_opts oy = t_opts(6, 0, 0), of = t_opts(5, 0, 0), op = t_opts(6, 0, 0);
    pset cube = set_of(0, 1, T_N), sphere = set_of(1, 2, T_N), blobs = set_of(2, 3, T_N);
    pset few = set_of(0, 4, T_N / 3);
    oy.kernel_param[0] = 3.0;
    t_group("a handle on another kernel's tree: as a fresh handle, bit for bit");
    kifmm_laplace_grad_kifmm_laplace_dipole_grad("cube", &o, &o, 3, 4, &cube, NULL, &blobs, 0, 5e-5);
    kifmm_laplace_grad_kifmm_laplace_dipole_grad("sphere, cube targets", &o, &o, 3, 4, &sphere,
                                                 &cube, &few, 0, 5e-5);
    kifmm_laplace_grad_kifmm_laplace_grad("order 4's tree, higher", &o4, &o8, 1, 4, &blobs, NULL,
                                          &cube, 0, T_HIGH == 8 ? 1e-6 : 5e-5);
    kifmm_laplace_kifmm_yukawa_grad("clustered", &o, &oy, 1, 4, &blobs, NULL, &sphere, 0, 5e-5);
    kifmm_laplace_dipole_grad_kifmm_stokes("sphere", &of, &of, 3, 3, &sphere, NULL, &cube, 0, 2e-4);
    kifmm_laplacef_kifmm_yukawa_gradf("float, cube", &of, &oy, 1, 4, &cube, NULL, &blobs, 0, 2e-4);
    kifmm_laplace_dense_kifmm_laplace_grad("a dense M2L's tree", &o, &o, 1, 4, &blobs, &sphere, &few,
                                           0, 5e-5);
    /* periodic: the charges sum to zero */
    op.period[0] = op.period[1] = op.period[2] = 1.0;
    kifmm_laplace_grad_kifmm_laplace("periodic cube", &op, &op, 1, 1, &cube, NULL, &few, 1, 0.0);
    op.period[2] = 0.0;
    kifmm_laplace_grad_kifmm_laplace("periodic slab, targets", &op, &op, 1, 1, &cube, &few, &cube, 1,
                                     0.0);
    free(cube.x), free(sphere.x), free(blobs.x), free(few.x);
}

/* Trees that do not fit: KIFMM_ERR_TREE, *out NULL, and a handle given one
 * by update_on_tree evaluates its old points as before. Empty sets. */
static void test_fits(void)
{
    pset s = set_of(0, 5, 3000);
    float *sf = conv_float(s.x, 3 * s.n);
    double *q = t_densities(6, s.n, 1, 1, 0), *u = t_doubles(4 * s.n), *f = t_doubles(4 * s.n);
    kifmm_opts o = t_opts(6, 40, 0), ob = t_opts(6, 0, 0);
    kifmm_laplace_grad *a = NULL, *b = NULL, *c = NULL;
    kifmm_laplacef *af = NULL;
    kifmm_laplace_dense *d = NULL;
    int rc, k;
    t_group("trees that do not fit, bad arguments, empty sets");
    rc = kifmm_laplace_grad_create(&a, &o, s.n, s.x, s.n, s.x);
    rc |= kifmm_laplacef_create(&af, &o, s.n, sf, s.n, sf);
    CHECK(rc == 0, "create rc=%d", rc);
    if (rc) goto done;
    CHECK(kifmm_laplace_grad_tree(NULL) == NULL, "tree(NULL)");
    CHECK(kifmm_laplace_grad_create_on_tree(NULL, &o, kifmm_laplace_grad_tree(a)) == KIFMM_ERR_NULL,
          "create_on_tree(NULL out)");
    b = a;
    CHECK(kifmm_laplace_grad_create_on_tree(&b, &o, NULL) == KIFMM_ERR_NULL && b == NULL,
          "create_on_tree(NULL tree)");
    for (k = 0; k < 7; k++) {
        kifmm_opts ok = ob;
        const char *why[] = {"leaf size", "depth", "period", "domain", "precision", "dense M2L",
                             "order out of range"};
        int want = k == 6 ? KIFMM_ERR_ORDER : KIFMM_ERR_TREE;
        if (k == 0) ok.leaf_size = 41;
        if (k == 1) ok.max_depth = 9;
        if (k == 2) ok.period[0] = ok.period[1] = ok.period[2] = 2.0;
        if (k == 3) ok.domain[0] = ok.domain[1] = ok.domain[2] = ok.domain[3] = 1.0;
        if (k == 6) ok.order = 99;
        b = a, d = (kifmm_laplace_dense *)a; /* a failing call sets its *out to NULL */
        if (k == 4) rc = kifmm_laplace_grad_create_on_tree(&b, &ok, kifmm_laplacef_tree(af));
        else if (k == 5) rc = kifmm_laplace_dense_create_on_tree(&d, &ok, kifmm_laplace_grad_tree(a));
        else rc = kifmm_laplace_grad_create_on_tree(&b, &ok, kifmm_laplace_grad_tree(a));
        CHECK(rc == want && (k == 5 ? d == NULL : b == NULL), "a tree of another %s: rc=%d (%s)",
              why[k], rc, kifmm_strerror(rc));
        b = NULL, d = NULL;
    }
    /* the same leaf size and depth given: fits */
    ob.leaf_size = 40;
    rc = kifmm_laplace_grad_create_on_tree(&b, &ob, kifmm_laplace_grad_tree(a));
    CHECK(rc == 0, "the tree's leaf size given: rc=%d", rc);
    /* a handle with its own leaf size refuses another tree, and keeps its points */
    ob.leaf_size = 30;
    rc = kifmm_laplace_grad_create(&c, &ob, s.n, s.x, s.n, s.x);
    rc |= kifmm_laplace_grad_evaluate(c, q, f);
    CHECK(rc == 0, "create with leaf size 30: rc=%d", rc);
    if (!rc) {
        rc = kifmm_laplace_grad_update_on_tree(c, kifmm_laplace_grad_tree(a));
        CHECK(rc == KIFMM_ERR_TREE, "update_on_tree onto a tree of leaf size 40: rc=%d", rc);
        CHECK(kifmm_laplace_grad_update_on_tree(c, NULL) == KIFMM_ERR_NULL, "update_on_tree(NULL)");
        CHECK(kifmm_laplace_grad_update_on_tree(NULL, kifmm_laplace_grad_tree(a)) == KIFMM_ERR_NULL,
              "update_on_tree(NULL handle)");
        rc = kifmm_laplace_grad_evaluate(c, q, u);
        CHECK(rc == 0 && !memcmp(u, f, (size_t)(4 * s.n) * sizeof(double)),
              "refused update_on_tree: the handle's outputs changed (rc=%d)", rc);
    }
    kifmm_laplace_grad_destroy(b);
    kifmm_laplace_grad_destroy(c);
    b = c = NULL;
    /* period and domain all 0: the tree's (create_on_tree), but not for a
     * plan's handle nor in update_on_tree, whose options are set */
    {
        kifmm_opts op = t_opts(6, 0, 0), got = op;
        kifmm_laplace_grad *p = NULL, *e = NULL;
        kifmm_laplace_grad_plan *pl = NULL;
        op.period[0] = op.period[1] = op.period[2] = 1.0;
        rc = kifmm_laplace_grad_create(&p, &op, s.n, s.x, s.n, s.x);
        rc |= kifmm_laplace_grad_create_on_tree(&e, NULL, kifmm_laplace_grad_tree(p));
        rc |= kifmm_laplace_grad_options(e, &got);
        CHECK(rc == 0 && got.period[0] == 1.0 && got.period[2] == 1.0,
              "no period given on a periodic tree: the tree's (rc=%d, period %g)", rc, got.period[0]);
        rc = kifmm_laplace_grad_update_on_tree(a, kifmm_laplace_grad_tree(p));
        CHECK(rc == KIFMM_ERR_TREE, "update_on_tree of a free handle onto a periodic tree: rc=%d", rc);
        rc = kifmm_laplace_grad_plan_create(&pl, NULL);
        kifmm_laplace_grad_destroy(e);
        e = (kifmm_laplace_grad *)pl;
        if (!rc) rc = kifmm_laplace_grad_create_with_plan_on_tree(&e, pl, kifmm_laplace_grad_tree(p));
        CHECK(rc == KIFMM_ERR_TREE && e == NULL, "a free plan's handle on a periodic tree: rc=%d", rc);
        kifmm_laplace_grad_plan_destroy(pl);
        kifmm_laplace_grad_destroy(p);
    }
    /* empty sets: no sources, then no targets */
    for (k = 0; k < 2; k++) {
        kifmm_laplace_grad *e = NULL;
        kifmm_laplace_dipole_grad *p = NULL;
        double qq[3 * 10], out[4 * 10];
        rc = kifmm_laplace_grad_create(&e, NULL, k ? 10 : 0, s.x, k ? 0 : 10, s.x);
        rc |= kifmm_laplace_dipole_grad_create_on_tree(&p, NULL, kifmm_laplace_grad_tree(e));
        memset(qq, 0, sizeof qq);
        for (int i = 0; i < 40; i++) out[i] = 1.0;
        rc |= kifmm_laplace_dipole_grad_evaluate(p, qq, out);
        CHECK(rc == 0 && (k || (out[0] == 0.0 && out[39] == 0.0)),
              "no %s: a handle on the tree rc=%d", k ? "targets" : "sources", rc);
        kifmm_laplace_grad_destroy(e);
        kifmm_laplace_dipole_grad_destroy(p);
    }
done:
    kifmm_laplace_grad_destroy(a);
    kifmm_laplacef_destroy(af);
    free(s.x), free(sf), free(q), free(u), free(f);
}

/* NH handles of two kernels and two plans on one tree, made, evaluated and
 * destroyed on NH threads at once (the builder destroyed first, on the
 * main thread): each equals a handle of its own on the same points. */
#define NH 4
static void test_threads(void)
{
    pset s = set_of(2, 7, T_N / 2);
    double *q = t_densities(8, s.n, 3, 1, 0), *u[NH], *f[NH];
    kifmm_opts o = t_opts(5, 0, 0), used = o;
    kifmm_laplace_grad *a = NULL, *g1 = NULL;
    kifmm_laplace_dipole_grad *g0 = NULL;
    kifmm_laplace_dipole_grad_plan *pl = NULL;
    kifmm_tree *tree;
    int rc, rcs[NH], i;
    t_group("handles on one tree on several threads at once");
    o.nthreads = 1;
    rc = kifmm_laplace_grad_create(&a, &o, s.n, s.x, s.n, s.x);
    rc |= kifmm_laplace_dipole_grad_plan_create(&pl, &o);
    CHECK(rc == 0, "create, plan_create rc=%d", rc);
    if (rc) goto done;
    kifmm_laplace_grad_options(a, &used);
    tree = kifmm_laplace_grad_tree(a);
    for (i = 0; i < NH; i++) {
        u[i] = t_doubles(4 * s.n);
        f[i] = t_doubles(4 * s.n);
    }
    KIFMM__OMP(parallel for schedule(static, 1) num_threads(NH))
    for (int k = 0; k < NH; k++) {
        if (k % 2 == 0) {
            kifmm_laplace_dipole_grad *h = NULL;
            rcs[k] = k == 0 ? kifmm_laplace_dipole_grad_create_on_tree(&h, &o, tree)
                            : kifmm_laplace_dipole_grad_create_with_plan_on_tree(&h, pl, tree);
            if (!rcs[k]) rcs[k] = kifmm_laplace_dipole_grad_evaluate(h, q, u[k]);
            kifmm_laplace_dipole_grad_destroy(h);
        } else {
            kifmm_laplace_grad *h = NULL;
            rcs[k] = kifmm_laplace_grad_create_on_tree(&h, &o, tree);
            if (!rcs[k]) rcs[k] = kifmm_laplace_grad_evaluate(h, q, u[k]);
            kifmm_laplace_grad_destroy(h);
        }
    }
    o.leaf_size = used.leaf_size;
    rc = kifmm_laplace_dipole_grad_create(&g0, &o, s.n, s.x, s.n, s.x);
    rc |= kifmm_laplace_grad_create(&g1, &o, s.n, s.x, s.n, s.x);
    rc |= kifmm_laplace_dipole_grad_evaluate(g0, q, f[0]);
    rc |= kifmm_laplace_grad_evaluate(g1, q, f[1]);
    CHECK(rc == 0, "handles alone rc=%d", rc);
    for (i = 0; i < NH; i++) {
        CHECK(rcs[i] == 0 && !memcmp(u[i], f[i % 2], (size_t)(4 * s.n) * sizeof(double)),
              "thread %d: %s on the shared tree differs from one alone (rc=%d)", i,
              i % 2 ? "laplace_grad" : "laplace_dipole_grad", rcs[i]);
    }
    for (i = 0; i < NH; i++) free(u[i]), free(f[i]);
done:
    kifmm_laplace_grad_destroy(a);
    kifmm_laplace_grad_destroy(g1);
    kifmm_laplace_dipole_grad_destroy(g0);
    kifmm_laplace_dipole_grad_plan_destroy(pl);
    free(s.x), free(q);
}

int main(void)
{
    printf("== one tree for several kernels\n");
    test_pairs();
    test_fits();
    test_threads();
    return t_finish();
}
