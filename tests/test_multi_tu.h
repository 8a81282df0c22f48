/* test_multi_tu.h - the interface between the two translation units of
 * test_multi_tu. */
#ifndef TEST_MULTI_TU_H
#define TEST_MULTI_TU_H
#include <stdint.h>

/* Runs laplace_grad and a laplace instance named tu_b_pot on n uniform
 * points in translation unit b; returns the first kifmm error code (0 on
 * success) and the relative errors vs direct summation. */
int tu_b_run(int64_t n, uint64_t seed, double *err_pot, double *err_grad, double *err_named);

/* Trees shared across the units (unit b has an allocator of its own that
 * aborts on a block it did not allocate; the default allocator of unit a
 * rejects b's blocks). Unit b's laplace_grad handle on n points x: *h and
 * its tree, returned by tu_b_tree; evaluated into out by tu_b_eval
 * (charges q); destroyed by tu_b_destroy. tu_b_on_tree: a laplace_grad
 * handle of unit b made on the tree t (built by unit a), evaluated into
 * out and destroyed after unit a has let go of t (*release_a is called in
 * between). tu_b_live: blocks of b's allocator not yet freed. */
struct kifmm_tree;
int tu_b_make(int64_t n, const double *x, void **h, struct kifmm_tree **tree);
int tu_b_eval(void *h, const double *q, double *out);
void tu_b_destroy(void *h);
int tu_b_on_tree(struct kifmm_tree *t, const double *q, double *out, void (*release_a)(void));
long tu_b_live(void);

#endif
