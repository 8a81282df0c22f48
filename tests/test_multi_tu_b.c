/* test_multi_tu_b.c - the second translation unit of test_multi_tu: it
 * instantiates the same kernels as test_multi_tu_a.c, plus one under its own
 * prefix (KIFMM_NAME), and runs a small problem. Its compile-time options
 * differ from unit a's: the FFT M2L gets the smallest spectra buffer, so
 * every level with more than 27 parents is done in many slabs. */
#define KIFMM_FFT_SPEC_MB 0
#include "kifmm.h"
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"
#define KIFMM_KERNEL laplace
#define KIFMM_NAME tu_b_pot
#include "kifmm.h"

#include "test.h"

#include "test_multi_tu.h"

int tu_b_run(int64_t n, uint64_t seed, double *err_pot, double *err_grad, double *err_named)
{
    double *x = t_doubles(3 * n), *q = t_doubles(n), *out = t_doubles(4 * n);
    t_rng r = t_rng_seed(seed);
    kifmm_opts o;
    kifmm_laplace_grad *h = NULL;
    tu_b_pot *hb = NULL;
    t_err e;
    int rc;

    memset(&o, 0, sizeof o);
    o.order = 6;
    t_gen_cube(&r, n, x, 0.0, 1.0);
    t_gen_charges(&r, n, q, -1.0, 1.0);

    rc = kifmm_laplace_grad_create(&h, &o, n, x, n, x);
    if (rc == KIFMM_SUCCESS) rc = kifmm_laplace_grad_evaluate(h, q, out);
    kifmm_laplace_grad_destroy(h);
    if (rc == KIFMM_SUCCESS) {
        e = t_error_laplace(n, x, q, n, x, out, 4, 500);
        *err_pot = e.pot;
        *err_grad = e.grad;
    }
    o.leaf_size = 20; /* a deeper tree: 64 parents at level 2 */
    if (rc == KIFMM_SUCCESS) rc = tu_b_pot_create(&hb, &o, n, x, n, x);
    if (rc == KIFMM_SUCCESS) rc = tu_b_pot_evaluate(hb, q, out);
    tu_b_pot_destroy(hb);
    if (rc == KIFMM_SUCCESS) *err_named = t_error_laplace(n, x, q, n, x, out, 1, 500).pot;

    free(x);
    free(q);
    free(out);
    return rc;
}
