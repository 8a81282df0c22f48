/* examples/laplace.c - a first program with kifmm.h
 *
 * Computes the potential and its gradient at N random points in the unit cube,
 * due to random charges at the same points, with the fast multipole method:
 *
 *     pot(y_j)  = sum_i q_i / (4 pi |y_j - x_i|)           (pairs with x_i == y_j skipped)
 *     grad(y_j) = sum_i -q_i (y_j - x_i) / (4 pi |y_j - x_i|^3)
 *
 * then checks 1000 of the N targets against direct summation.
 *
 * Build and run (from the repository root):
 *     cc -O2 -march=native -fopenmp -I. examples/laplace.c -o laplace \
 *        -llapacke -lopenblas -lm
 *     ./laplace [N] [order]          N defaults to 1000000, order to 6
 * or simply `make run`.
 *
 * OpenBLAS: on machines where OpenBLAS misdetects the CPU, set the variable
 * OPENBLAS_CORETYPE before running (e.g. OPENBLAS_CORETYPE=Haswell ./laplace,
 * or SkylakeX on a CPU with AVX-512).  This program does not set it.
 */
#define _POSIX_C_SOURCE 199309L /* clock_gettime, when built without OpenMP */

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

/* One include per kernel.  KIFMM_KERNEL picks the kernel; the header defines
 * the type kifmm_laplace_grad and the functions kifmm_laplace_grad_create,
 * _evaluate, _options and _destroy.  (A bare #include "kifmm.h" gives the
 * potential-only kernel, kifmm_laplace_*.) */
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"

#ifdef _OPENMP
#include <omp.h>
#endif

static double wall_seconds(void)
{
#ifdef _OPENMP
    return omp_get_wtime();
#else
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
#endif
}

/* A small deterministic random number generator (splitmix64), uniform in [0, 1). */
static double random01(uint64_t *state)
{
    uint64_t z = (*state += UINT64_C(0x9E3779B97F4A7C15));
    z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
    z ^= z >> 31;
    return (double)(z >> 11) * (1.0 / 9007199254740992.0);
}

int main(int argc, char **argv)
{
    const double pi = 3.14159265358979323846;
    int64_t n = argc > 1 ? atol(argv[1]) : 1000000;
    int order = argc > 2 ? atoi(argv[2]) : 6;
    int64_t nsample = n < 1000 ? n : 1000;
    uint64_t seed = 42;
    double *xyz, *charges, *out;
    double t0, t_create, t_eval, estimate = 0.0;
    double num_pot = 0, den_pot = 0, num_grad = 0, den_grad = 0;
    kifmm_opts opts = {0}; /* every field 0 means "default" */
    kifmm_opts used;
    kifmm_stats stats;
    kifmm_laplace_grad *fmm = NULL;
    int64_t i, s;
    int rc;

    if (n < 1) {
        fprintf(stderr, "usage: %s [N >= 1] [order 2..%d]\n", argv[0], KIFMM_MAX_ORDER);
        return 2;
    }

    /* Points, interleaved: point i is (xyz[3i], xyz[3i+1], xyz[3i+2]).
     * Here the sources are also the targets. */
    xyz = malloc((size_t)n * 3 * sizeof(double));
    charges = malloc((size_t)n * sizeof(double));
    out = malloc((size_t)n * 4 * sizeof(double)); /* 4 values per target */
    if (!xyz || !charges || !out) {
        fprintf(stderr, "out of memory\n");
        return 1;
    }
    for (i = 0; i < 3 * n; i++) xyz[i] = random01(&seed);
    for (i = 0; i < n; i++) charges[i] = 2.0 * random01(&seed) - 1.0;

    printf("kifmm example: N = %ld points in the unit cube, order %d\n", (long)n, order);
    printf("note: if OpenBLAS misdetects this CPU, set OPENBLAS_CORETYPE (e.g. Haswell)\n");

    /* 1. Create: builds the octree over sources and targets and precomputes
     *    the translation operators.  The handle copies what it needs: the
     *    coordinate arrays may be freed afterwards. */
    opts.order = order; /* expansion order: higher is more accurate and slower */
    /* The memory the handle will hold, from the counts alone (a model of
     * points spread through a volume, as these are). */
    rc = kifmm_laplace_grad_estimate_bytes(&opts, n, KIFMM_SAME_POINTS, &estimate);
    if (rc != KIFMM_SUCCESS) {
        fprintf(stderr, "kifmm_laplace_grad_estimate_bytes: %s\n", kifmm_strerror(rc));
        return 1;
    }
    t0 = wall_seconds();
    rc = kifmm_laplace_grad_create(&fmm, &opts, n, xyz, n, xyz);
    t_create = wall_seconds() - t0;
    if (rc != KIFMM_SUCCESS) {
        fprintf(stderr, "kifmm_laplace_grad_create: %s\n", kifmm_strerror(rc));
        return 1;
    }
    kifmm_laplace_grad_options(fmm, &used); /* the options actually used */
    kifmm_laplace_grad_stats(fmm, &stats);  /* what the handle is made of */
    printf("create:   %.3f s  (order %d, leaf size %d, max depth %d)\n", t_create, used.order,
           used.leaf_size, used.max_depth);
    printf("build:    %s\n", stats.build); /* shows a build without -march or -fopenmp */
    printf("memory:   %.1f MiB held (estimated before create: %.1f MiB)\n", stats.bytes / 1048576.0,
           estimate / 1048576.0);

    /* 2. Evaluate: may be called any number of times with new charges.
     *    out[4j] is the potential at target j, out[4j+1..4j+3] its gradient. */
    t0 = wall_seconds();
    rc = kifmm_laplace_grad_evaluate(fmm, charges, out);
    t_eval = wall_seconds() - t0;
    if (rc != KIFMM_SUCCESS) {
        fprintf(stderr, "kifmm_laplace_grad_evaluate: %s\n", kifmm_strerror(rc));
        kifmm_laplace_grad_destroy(fmm);
        return 1;
    }
    printf("evaluate: %.3f s\n", t_eval);

    /* 3. Destroy the handle when done. */
    kifmm_laplace_grad_destroy(fmm);

    /* Check against direct summation on nsample targets spread over the set. */
    for (s = 0; s < nsample; s++) {
        int64_t j = s * (n / nsample);
        const double *y = xyz + 3 * j;
        double pot = 0, gx = 0, gy = 0, gz = 0, d;
        for (i = 0; i < n; i++) {
            double dx = y[0] - xyz[3 * i], dy = y[1] - xyz[3 * i + 1], dz = y[2] - xyz[3 * i + 2];
            double r2 = dx * dx + dy * dy + dz * dz, rinv;
            if (r2 == 0.0) continue; /* the point itself */
            rinv = 1.0 / sqrt(r2);
            pot += charges[i] * rinv;
            gx -= charges[i] * rinv * rinv * rinv * dx;
            gy -= charges[i] * rinv * rinv * rinv * dy;
            gz -= charges[i] * rinv * rinv * rinv * dz;
        }
        pot /= 4 * pi;
        gx /= 4 * pi;
        gy /= 4 * pi;
        gz /= 4 * pi;
        d = out[4 * j] - pot;
        num_pot += d * d;
        den_pot += pot * pot;
        d = out[4 * j + 1] - gx;
        num_grad += d * d;
        d = out[4 * j + 2] - gy;
        num_grad += d * d;
        d = out[4 * j + 3] - gz;
        num_grad += d * d;
        den_grad += gx * gx + gy * gy + gz * gz;
    }
    printf("relative L2 error on %ld targets: potential %.3e, gradient %.3e\n", (long)nsample,
           sqrt(num_pot / den_pot), sqrt(num_grad / den_grad));

    free(xyz);
    free(charges);
    free(out);
    return 0;
}
