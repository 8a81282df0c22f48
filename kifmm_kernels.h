/* kifmm_kernels.h - kernels shipped with kifmm.h
 *
 * A kernel NAME is a handful of definitions with the prefix kifmm_kernel_NAME_
 * (the contract is in docs/kernels.md):
 *
 *   kifmm_kernel_NAME_SRC_DIM          density components per source point
 *   kifmm_kernel_NAME_TRG_DIM          output components per target point
 *   kifmm_kernel_NAME_SCALE_INVARIANT  1 if K(a d) = a^DEGREE K(d) for a > 0
 *   kifmm_kernel_NAME_DEGREE           that degree (read only when invariant)
 *   kifmm_kernel_NAME_EQUIV            (only when TRG_DIM != SRC_DIM) the kernel
 *                                      used on check and equivalent surfaces
 *   kifmm_kernel_NAME_eval(param, dx, dy, dz, k)
 *       k[t * SRC_DIM + s] for the displacement d = target - source; zero at d = 0.
 *
 * kifmm.h includes this file itself; including it again is harmless.
 */
#ifndef KIFMM_KERNELS_H
#define KIFMM_KERNELS_H

#include <math.h>

#define KIFMM_INV_4PI 0.07957747154594766788444188168625718 /* 1 / (4 pi) */

/* laplace: phi(y) = q / (4 pi |y - x|). */
#define kifmm_kernel_laplace_SRC_DIM 1
#define kifmm_kernel_laplace_TRG_DIM 1
#define kifmm_kernel_laplace_SCALE_INVARIANT 1
#define kifmm_kernel_laplace_DEGREE (-1)
static inline void kifmm_kernel_laplace_eval(const double *param, double dx,
                                             double dy, double dz, double *k)
{
    double r2 = dx * dx + dy * dy + dz * dz;
    (void)param;
    k[0] = r2 > 0.0 ? KIFMM_INV_4PI / sqrt(r2) : 0.0;
}

/* laplace_grad: the potential and its gradient with respect to the target,
 * k = (1, -dx / r^2, -dy / r^2, -dz / r^2) / (4 pi r). */
#define kifmm_kernel_laplace_grad_SRC_DIM 1
#define kifmm_kernel_laplace_grad_TRG_DIM 4
#define kifmm_kernel_laplace_grad_SCALE_INVARIANT 1
#define kifmm_kernel_laplace_grad_DEGREE (-1)
#define kifmm_kernel_laplace_grad_EQUIV laplace
static inline void kifmm_kernel_laplace_grad_eval(const double *param, double dx,
                                                  double dy, double dz, double *k)
{
    double r2 = dx * dx + dy * dy + dz * dz;
    double inv = r2 > 0.0 ? 1.0 / sqrt(r2) : 0.0;
    double inv3 = KIFMM_INV_4PI * inv * inv * inv;
    (void)param;
    k[0] = KIFMM_INV_4PI * inv;
    k[1] = -dx * inv3;
    k[2] = -dy * inv3;
    k[3] = -dz * inv3;
}

#endif /* KIFMM_KERNELS_H */
