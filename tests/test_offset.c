/* test_offset.c - accuracy does not depend on where the cloud sits: a cloud
 * far from the origin (relative to its own size) against the very same cloud
 * moved to the origin, each against its own direct sum. Both are the same
 * geometry: the cloud at the origin is the shifted one minus the shift, which
 * is exact in floating point, and so are the differences the direct sums
 * take. Surface points placed in the caller's coordinates once lost the
 * digits of the offset (5e-6 against 1.1e-6 at p = 6 for a cube of side 1e-3
 * at (1e6, -1e6, 0); float instances reached a relative error of 81 at an
 * offset of 1e5 cloud sizes). */
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"
#define KIFMM_KERNEL laplace
#define KIFMM_REAL float
#include "kifmm.h"

#include "test.h"

#ifdef KIFMM_TEST_QUICK
#define NPTS 8000
#else
#define NPTS 20000
#endif
#define NSAMPLE 1500

/* Relative L2 errors of a laplace_grad run on x (n points, sources =
 * targets) against the direct sum, potential and gradient. */
static t_err run_double(int64_t n, const double *x, const double *q, int order)
{
    kifmm_laplace_grad *h = NULL;
    kifmm_opts o = t_opts(order, 0, 0);
    double *out = t_doubles(4 * n);
    t_err e;
    int rc;
    t_fill(4 * n, out, NAN);
    rc = kifmm_laplace_grad_create(&h, &o, n, x, n, x);
    if (!rc) rc = kifmm_laplace_grad_evaluate(h, q, out);
    kifmm_laplace_grad_destroy(h);
    CHECK(rc == 0, "laplace_grad p=%d rc=%d", order, rc);
    e = t_error_laplace(n, x, q, n, x, out, 4, NSAMPLE);
    free(out);
    return e;
}

/* The same for the float instance: points and charges given in float, the
 * direct sum over the same float values widened to double. */
static double run_float(int64_t n, const float *xf, const float *qf, int order)
{
    kifmm_laplacef *h = NULL;
    kifmm_opts o = t_opts(order, 0, 0);
    float *out = (float *)t_malloc_or_die((size_t)n * sizeof(float));
    double *x = t_doubles(3 * n), *q = t_doubles(n), *od = t_doubles(n);
    t_err e;
    int64_t i;
    int rc;
    for (i = 0; i < 3 * n; i++) x[i] = (double)xf[i];
    for (i = 0; i < n; i++) q[i] = (double)qf[i];
    rc = kifmm_laplacef_create(&h, &o, n, xf, n, xf);
    if (!rc) rc = kifmm_laplacef_evaluate(h, qf, out);
    kifmm_laplacef_destroy(h);
    CHECK(rc == 0, "laplacef p=%d rc=%d", order, rc);
    for (i = 0; i < n; i++) od[i] = rc ? NAN : (double)out[i];
    e = t_error_laplace(n, x, q, n, x, od, 1, NSAMPLE);
    free(out);
    free(x);
    free(q);
    free(od);
    return e.pot;
}

/* err at the offset is within 1.5 times the error at the origin */
static void check_ratio(double e_off, double e0, const char *what)
{
    CHECK_ERR(e_off, 1.5 * e0, "%s (origin %.2e)", what, e0);
}

static void test_double(void)
{
    const int64_t n = NPTS;
    const double shift[3] = {1e6, -1e6, 0.0}, side = 1e-3;
    double *x = t_doubles(3 * n), *x0 = t_doubles(3 * n), *q = t_doubles(n);
    t_rng r = t_rng_seed(404);
    int64_t i;
    int p;
    t_group("double: cube of side 1e-3 at (1e6, -1e6, 0) against the same cube at the origin");
    for (i = 0; i < n; i++) {
        int k;
        for (k = 0; k < 3; k++) {
            x[3 * i + k] = shift[k] + side * t_rand01(&r);
            x0[3 * i + k] = x[3 * i + k] - shift[k]; /* exact */
        }
    }
    t_gen_charges(&r, n, q, -1.0, 1.0);
    for (p = 6; p <= 8; p += 2) {
        t_err e0 = run_double(n, x0, q, p), e1 = run_double(n, x, q, p);
        char what[96];
        sprintf(what, "p=%d potential at the offset", p);
        check_ratio(e1.pot, e0.pot, what);
        sprintf(what, "p=%d gradient at the offset", p);
        check_ratio(e1.grad, e0.grad, what);
    }
    free(x);
    free(x0);
    free(q);
}

static void test_float(void)
{
    const int64_t n = NPTS;
    static const double offs[3] = {1e3, 1e4, 1e5};
    float *x = (float *)t_malloc_or_die((size_t)(3 * n) * sizeof(float));
    float *x0 = (float *)t_malloc_or_die((size_t)(3 * n) * sizeof(float));
    float *q = (float *)t_malloc_or_die((size_t)n * sizeof(float));
    t_rng r = t_rng_seed(405);
    int64_t i;
    int v, p;
    t_group("float: unit cube at 1e3, 1e4, 1e5 sizes from the origin against the same cube "
            "at the origin");
    for (i = 0; i < n; i++) q[i] = (float)t_uniform(&r, -1.0, 1.0);
    for (v = 0; v < 3; v++) {
        const double sh[3] = {offs[v], -0.5 * offs[v], 0.25 * offs[v]};
        for (i = 0; i < n; i++) {
            int k;
            for (k = 0; k < 3; k++) {
                x[3 * i + k] = (float)(sh[k] + t_rand01(&r));
                x0[3 * i + k] = (float)((double)x[3 * i + k] - sh[k]); /* exact */
            }
        }
        for (p = 4; p <= 6; p += 2) {
            double e0 = run_float(n, x0, q, p), e1 = run_float(n, x, q, p);
            char what[96];
            sprintf(what, "laplacef p=%d, offset %.0e cube sizes", p, offs[v]);
            check_ratio(e1, e0, what);
        }
    }
    free(x);
    free(x0);
    free(q);
}

/* Float instances on a deep tree: blobs of width 1e-3 in the unit cube
 * make leaves 1e-4 of the root wide. Surfaces placed in coordinates
 * relative to the root were off by float's resolution of the root, 1e-4 of
 * such a box (6.4e-5 at p = 6, against 8e-6 on the uniform cube); in each
 * box's own frame they keep its digits. Bounds: 2.5 times the uniform
 * cube's errors (p = 4 1.2e-4, p = 6 8.3e-6), against direct sums over the
 * float points. */
static void test_float_deep(void)
{
    const int64_t n = NPTS;
    double *x = t_doubles(3 * n);
    float *xf = (float *)t_malloc_or_die((size_t)(3 * n) * sizeof(float));
    float *q = (float *)t_malloc_or_die((size_t)n * sizeof(float));
    t_rng r = t_rng_seed(406);
    int64_t i;
    int p;
    t_group("float: clustered points (deep tree), each box in its own frame");
    t_gen_blobs(&r, n, x);
    for (i = 0; i < 3 * n; i++) xf[i] = (float)x[i];
    for (i = 0; i < n; i++) q[i] = (float)t_uniform(&r, -1.0, 1.0);
    for (p = 4; p <= 6; p += 2) {
        double e = run_float(n, xf, q, p);
        CHECK_ERR(e, p == 4 ? 3e-4 : 2e-5, "laplacef p=%d, blobs of width 1e-3", p);
    }
    free(x);
    free(xf);
    free(q);
}

int main(void)
{
    test_double();
    test_float();
    test_float_deep();
    return t_finish();
}
