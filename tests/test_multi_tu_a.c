/* test_multi_tu_a.c - two translation units that both include kifmm.h with
 * the same kernels link into one program (no duplicate symbols), and both
 * compute correct results. */
#include "kifmm.h"
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"

#include "test.h"

#include "test_multi_tu.h"

static kifmm_laplace_grad *tree_owner; /* unit a's handle whose tree unit b uses */
static void release_owner(void)
{
    kifmm_laplace_grad_destroy(tree_owner);
    tree_owner = NULL;
}

/* A tree built by one unit, used by the other, and let go of last by the
 * other: each unit's handles equal the builder's outputs bit for bit, and
 * the tree is freed with its builder's allocator (unit b's aborts on a
 * block it did not allocate; a's, the C library's, would fail on b's). */
static void test_shared_tree(void)
{
    const int64_t n = 4000;
    double *x = t_doubles(3 * n), *q = t_doubles(n), *u = t_doubles(4 * n), *f = t_doubles(4 * n);
    t_rng r = t_rng_seed(53);
    kifmm_laplace_grad *g = NULL;
    kifmm_tree *t = NULL;
    void *hb = NULL;
    int rc;
    t_group("a tree shared between the units, each with its own allocator");
    t_gen_blobs(&r, n, x);
    t_gen_charges(&r, n, q, -1.0, 1.0);
    /* built by b, used by a, b's handle destroyed first */
    rc = tu_b_make(n, x, &hb, &t);
    if (rc == KIFMM_SUCCESS) rc = tu_b_eval(hb, q, f);
    if (rc == KIFMM_SUCCESS) rc = kifmm_laplace_grad_create_on_tree(&g, NULL, t);
    tu_b_destroy(hb);
    if (rc == KIFMM_SUCCESS) rc = kifmm_laplace_grad_evaluate(g, q, u);
    CHECK(rc == KIFMM_SUCCESS && !memcmp(u, f, sizeof(double) * 4 * (size_t)n) &&
              tu_b_live() > 0,
          "unit a's handle on unit b's tree: rc=%d, outputs as b's, b's blocks held %ld", rc,
          tu_b_live());
    kifmm_laplace_grad_destroy(g);
    CHECK(tu_b_live() == 0, "unit b's tree freed by unit a's last handle: %ld b blocks left",
          tu_b_live());
    /* built by a, used by b, a's handle destroyed first */
    rc = kifmm_laplace_grad_create(&tree_owner, NULL, n, x, n, x);
    if (rc == KIFMM_SUCCESS) rc = kifmm_laplace_grad_evaluate(tree_owner, q, f);
    if (rc == KIFMM_SUCCESS) rc = tu_b_on_tree(kifmm_laplace_grad_tree(tree_owner), q, u, release_owner);
    CHECK(rc == KIFMM_SUCCESS && !memcmp(u, f, sizeof(double) * 4 * (size_t)n) && tu_b_live() == 0,
          "unit b's handle on unit a's tree: rc=%d, outputs as a's, b blocks left %ld", rc,
          tu_b_live());
    kifmm_laplace_grad_destroy(tree_owner);
    free(x), free(q), free(u), free(f);
}

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
    test_shared_tree();

    free(x);
    free(q);
    free(out);
    return t_finish();
}
