/* test_multi_tu_a.c - two translation units that both include kifmm.h with
 * the same kernels link into one program (no duplicate symbols), and both
 * compute correct results. */
#include "kifmm.h"
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"

#include "test.h"

#include "test_multi_tu.h"

int main(void)
{
    int64_t n = 6000;
    double *x = t_doubles(3 * n), *q = t_doubles(n), *out = t_doubles(4 * n);
    double ep = NAN, eg = NAN, en = NAN;
    t_rng r = t_rng_seed(51);
    kifmm_opts o;
    kifmm_laplace *h = NULL;
    kifmm_laplace_grad *hg = NULL;
    t_err e;
    int rc;

    t_group("two translation units in one program");
    rc = tu_b_run(5000, 52, &ep, &eg, &en);
    CHECK(rc == KIFMM_SUCCESS, "tu_b_run rc=%d (%s)", rc, kifmm_strerror(rc));
    CHECK_ERR(ep, 4e-6, "unit b: laplace_grad potential");
    CHECK_ERR(eg, 4e-5, "unit b: laplace_grad gradient");
    CHECK_ERR(en, 4e-6, "unit b: laplace under KIFMM_NAME tu_b_pot");

    memset(&o, 0, sizeof o);
    o.order = 6;
    t_gen_cube(&r, n, x, 0.0, 1.0);
    t_gen_charges(&r, n, q, -1.0, 1.0);

    rc = kifmm_laplace_create(&h, &o, n, x, n, x);
    CHECK(rc == KIFMM_SUCCESS, "unit a: laplace create rc=%d", rc);
    if (rc == KIFMM_SUCCESS) {
        rc = kifmm_laplace_evaluate(h, q, out);
        CHECK(rc == KIFMM_SUCCESS, "unit a: laplace evaluate rc=%d", rc);
        e = t_error_laplace(n, x, q, n, x, out, 1, 500);
        CHECK_ERR(e.pot, 4e-6, "unit a: laplace potential");
    }
    kifmm_laplace_destroy(h);

    rc = kifmm_laplace_grad_create(&hg, &o, n, x, n, x);
    CHECK(rc == KIFMM_SUCCESS, "unit a: laplace_grad create rc=%d", rc);
    if (rc == KIFMM_SUCCESS) {
        rc = kifmm_laplace_grad_evaluate(hg, q, out);
        CHECK(rc == KIFMM_SUCCESS, "unit a: laplace_grad evaluate rc=%d", rc);
        e = t_error_laplace(n, x, q, n, x, out, 4, 500);
        CHECK_ERR(e.pot, 4e-6, "unit a: laplace_grad potential");
        CHECK_ERR(e.grad, 4e-5, "unit a: laplace_grad gradient");
    }
    kifmm_laplace_grad_destroy(hg);

    free(x);
    free(q);
    free(out);
    return t_finish();
}
