/* test_multi_tu_b.c - the second translation unit of test_multi_tu: it
 * instantiates the same kernels as test_multi_tu_a.c, plus one under its own
 * prefix (KIFMM_NAME), and runs a small problem. Its compile-time options
 * differ from unit a's: the FFT M2L gets the smallest spectra buffer, so
 * every level with more than 27 parents is done in many slabs, and its
 * allocator is its own (KIFMM_MALLOC, KIFMM_FREE), so that a tree shared
 * between the units must be freed by the unit that built it. */
#define KIFMM_FFT_SPEC_MB 0
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
/* unit b's own allocator: a header before each block, checked on free */
static long tu_b_blocks;
static void *tu_b_malloc(size_t n)
{
    unsigned char *p = (unsigned char *)malloc(n + 32);
    if (!p) return NULL;
    memcpy(p, "kifmm-tu-b", 11);
#ifdef _OPENMP
#pragma omp atomic /* the library allocates inside parallel regions too */
#endif
    tu_b_blocks++;
    return p + 32;
}
static void tu_b_free(void *q)
{
    unsigned char *p = (unsigned char *)q - 32;
    if (!q) return;
    if (memcmp(p, "kifmm-tu-b", 11)) {
        fprintf(stderr, "unit b: a block of another allocator freed with b's\n");
        abort();
    }
#ifdef _OPENMP
#pragma omp atomic
#endif
    tu_b_blocks--;
    free(p);
}
#define KIFMM_MALLOC(n) tu_b_malloc(n)
#define KIFMM_FREE(p) tu_b_free(p)
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

int tu_b_make(int64_t n, const double *x, void **h, struct kifmm_tree **tree)
{
    kifmm_laplace_grad *g = NULL;
    int rc = kifmm_laplace_grad_create(&g, NULL, n, x, n, x);
    *h = g;
    *tree = kifmm_laplace_grad_tree(g);
    return rc;
}

int tu_b_eval(void *h, const double *q, double *out)
{
    return kifmm_laplace_grad_evaluate((kifmm_laplace_grad *)h, q, out);
}

void tu_b_destroy(void *h) { kifmm_laplace_grad_destroy((kifmm_laplace_grad *)h); }

int tu_b_on_tree(struct kifmm_tree *t, const double *q, double *out, void (*release_a)(void))
{
    kifmm_laplace_grad *g = NULL;
    int rc = kifmm_laplace_grad_create_on_tree(&g, NULL, t);
    release_a();
    if (rc == KIFMM_SUCCESS) rc = kifmm_laplace_grad_evaluate(g, q, out);
    kifmm_laplace_grad_destroy(g); /* the last reference: unit a's allocator frees the tree */
    return rc;
}

long tu_b_live(void)
{
    long n;
#ifdef _OPENMP
#pragma omp atomic read
#endif
    n = tu_b_blocks;
    return n;
}
