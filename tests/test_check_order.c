/* test_check_order.c - the check-surface options defined before the include.
 *
 * KIFMM_CHECK_ORDER_DIFF 1 puts the check surfaces at order p + 1 (outer
 * radius 2.95) at every order, as before square systems became the default
 * (now up to order 10, 7 in float); KIFMM_SQUARE_MAX_ORDER and the FFT M2L
 * are then not consulted.
 * This translation unit checks that the override reaches the handle (surface
 * sizes, radius) and that the results still meet the accuracy bounds of
 * test_accuracy against an independent direct sum, at orders 4 and 6 and on
 * uniform and sphere-surface points.
 */
#define KIFMM_CHECK_ORDER_DIFF 1
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"

#include "test.h"

#ifdef KIFMM_TEST_QUICK
#define N_POINTS 6000
#else
#define N_POINTS 20000
#endif
#define NSAMPLE 600

static void run(const char *name, int sphere, int p, double bound)
{
    int64_t n = N_POINTS;
    double *x = t_doubles(3 * n), *q = t_doubles(n), *out = t_doubles(4 * n);
    t_rng r = t_rng_seed(4004 + p);
    kifmm_opts o = t_opts(p, 0, 0);
    kifmm_laplace_grad *h = NULL;
    t_err e;
    int rc;

    if (sphere) t_gen_sphere(&r, n, x);
    else t_gen_cube(&r, n, x, 0.0, 1.0);
    t_gen_charges(&r, n, q, -1.0, 1.0);

    rc = kifmm_laplace_grad_create(&h, &o, n, x, n, x);
    CHECK(rc == KIFMM_SUCCESS && h != NULL, "%s p=%d create rc=%d", name, p, rc);
    if (rc != KIFMM_SUCCESS) goto done;
    /* the override reached the handle: order p + 1 on the check surfaces, at
     * the least-squares radius */
    CHECK(h->pl->surf.cdiff == 1, "%s p=%d check order difference %d, want 1", name, p, h->pl->surf.cdiff);
    CHECK(h->pl->surf.nsc == kifmm__surf_count(p + 1) && h->pl->surf.nse == kifmm__surf_count(p),
          "%s p=%d surface sizes %d / %d", name, p, h->pl->surf.nsc, h->pl->surf.nse);
    CHECK(h->pl->surf.ao == KIFMM__ALPHA_OUTER_LSQ, "%s p=%d outer radius %g", name, p, h->pl->surf.ao);
    t_fill(4 * n, out, NAN);
    rc = kifmm_laplace_grad_evaluate(h, q, out);
    CHECK(rc == KIFMM_SUCCESS, "%s p=%d evaluate rc=%d", name, p, rc);
    e = t_error_laplace(n, x, q, n, x, out, 4, NSAMPLE);
    CHECK_ERR(e.pot, bound, "%-6s p=%d N=%ld check order p+1: potential", name, p, (long)n);
    CHECK_ERR(e.grad, 10 * bound, "%-6s p=%d N=%ld check order p+1: gradient", name, p,
              (long)n);
done:
    kifmm_laplace_grad_destroy(h);
    free(x);
    free(q);
    free(out);
}

int main(void)
{
    double t0 = t_wall();
    t_group("KIFMM_CHECK_ORDER_DIFF 1 (check surfaces of order p + 1 at every order)");
    /* the bounds of test_accuracy */
    run("cube", 0, 4, 4e-4);
    run("cube", 0, 6, 4e-6);
    run("sphere", 1, 6, 4e-6);
    printf("test_check_order: %.1fs\n", t_wall() - t0);
    return t_finish();
}
