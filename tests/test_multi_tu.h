/* test_multi_tu.h - the interface between the two translation units of
 * test_multi_tu. */
#ifndef TEST_MULTI_TU_H
#define TEST_MULTI_TU_H
#include <stdint.h>

/* Runs laplace_grad and a laplace instance named tu_b_pot on n uniform
 * points in translation unit b; returns the first kifmm error code (0 on
 * success) and the relative errors vs direct summation. */
int tu_b_run(int64_t n, uint64_t seed, double *err_pot, double *err_grad, double *err_named);

#endif
