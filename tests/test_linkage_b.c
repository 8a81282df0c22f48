/* test_linkage_b.c - the second program linked against libkifmm_linkage.a
 * (see tests/test_linkage.h): the potential and gradient instance, and the
 * Laplace instance that test_linkage_a also uses, from the same library
 * object. */
#include "test_linkage.h"
#include "test.h"

int main(void)
{
    const int64_t n = 6000;
    double *x = t_doubles(3 * n), *y = t_doubles(3 * n), *q = t_doubles(n);
    double *out = t_doubles(4 * n), *pot = t_doubles(n);
    t_rng r = t_rng_seed(42);
    kifmm_opts o;
    kifmm_laplace_grad *h = NULL;
    kifmm_laplace *hp = NULL;
    t_err e;
    int rc;

    t_group("a second program linked against the same library");
    memset(&o, 0, sizeof o);
    o.order = 7;
    t_gen_sphere(&r, n, x);
    t_gen_cube(&r, n, y, -1.0, 1.0);
    t_gen_charges(&r, n, q, -1.0, 1.0);
    rc = kifmm_laplace_grad_create(&h, &o, n, x, n, y);
    if (rc == KIFMM_SUCCESS) rc = kifmm_laplace_grad_evaluate(h, q, out);
    CHECK(rc == KIFMM_SUCCESS, "kifmm_laplace_grad from the library: %s", kifmm_strerror(rc));
    if (rc == KIFMM_SUCCESS) {
        e = t_error_laplace(n, x, q, n, y, out, 4, 300);
        CHECK_ERR(e.pot, 1e-6, "library laplace_grad potential, p = 7, sphere to cube");
        CHECK_ERR(e.grad, 5e-6, "library laplace_grad gradient, p = 7, sphere to cube");
    }
    kifmm_laplace_grad_destroy(h);

    o.order = 4;
    rc = kifmm_laplace_create(&hp, &o, n, x, n, y);
    if (rc == KIFMM_SUCCESS) rc = kifmm_laplace_evaluate(hp, q, pot);
    CHECK(rc == KIFMM_SUCCESS, "kifmm_laplace from the library: %s", kifmm_strerror(rc));
    if (rc == KIFMM_SUCCESS)
        CHECK_ERR(t_error_laplace(n, x, q, n, y, pot, 1, 300).pot, 5e-4,
                  "library laplace, p = 4, sphere to cube");
    kifmm_laplace_destroy(hp);

    /* a bad argument reaches the library's checks */
    CHECK(kifmm_laplace_create(NULL, &o, n, x, n, y) == KIFMM_ERR_NULL,
          "the library's argument checks: NULL handle pointer -> KIFMM_ERR_NULL");

    free(x);
    free(y);
    free(q);
    free(out);
    free(pot);
    return t_finish();
}
