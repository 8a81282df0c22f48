/* custom_kernel.c - a kernel of your own, written entirely in this file.
 *
 *   make custom ARGS="[N] [order]"      defaults 50000 points, order 6
 *   (or: cc -O3 -march=native -fopenmp -I. examples/custom_kernel.c
 *        -o custom_kernel -llapacke -lopenblas -lm)
 *
 * The kernel is the Gaussian-regularized Laplace potential
 *     K(d) = erf(|d| / delta) / (4 pi |d|),
 * the field of a Gaussian blob of charge of width delta (vortex and particle
 * methods use such cores), with delta read from kernel_param[0] at run time.
 * It is not homogeneous, so the operators are built per level. The program
 * evaluates it with the FMM, checks the result against direct summation at
 * sampled targets (written out here, and the library's kifmm_blob_direct,
 * which sums the kernel's own eval), and returns nonzero if the relative
 * error is above the bound of the Laplace accuracy table for the order.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- the kernel: five definitions and two small functions ------------- */
#define kifmm_kernel_blob_SRC_DIM 1         /* one density value per source */
#define kifmm_kernel_blob_TRG_DIM 1         /* one output value per target */
#define kifmm_kernel_blob_SCALE_INVARIANT 0 /* delta sets a length scale */
#define kifmm_kernel_blob_DEGREE 0          /* read only when invariant */
#define kifmm_kernel_blob_HAS (KIFMM_HAS_SETUP) /* a setup function checks the parameters */

/* Resolve the defaults of the four run-time parameters and reject bad ones
 * (create then returns KIFMM_ERR_PARAM): delta = param[0] > 0, default 1e-3. */
static int kifmm_kernel_blob_setup(const double *in, double *out)
{
    out[0] = in[0] == 0.0 ? 1e-3 : in[0];
    out[1] = out[2] = out[3] = 0.0;
    return out[0] > 0.0 ? 0 : -1;
}

/* The kernel at displacement d = target - source; zero at d = 0, so a
 * source does not act on itself. */
static inline void kifmm_kernel_blob_eval(const double *param, double dx, double dy, double dz,
                                          double *k)
{
    double r = sqrt(dx * dx + dy * dy + dz * dz);
    k[0] = r > 0.0 ? erf(r / param[0]) / (4.0 * 3.14159265358979323846 * r) : 0.0;
}

#define KIFMM_KERNEL blob
#include "kifmm.h" /* kifmm_blob_create, _evaluate, _evaluate_many, _destroy, ... */

/* ---- a run ---------------------------------------------------------------- */

static double rand01(uint64_t *s)
{
    *s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(*s >> 11) * (1.0 / 9007199254740992.0);
}

int main(int argc, char **argv)
{
    int64_t n = argc > 1 ? (int64_t)atof(argv[1]) : 50000, i, j, nsample = 200;
    int order = argc > 2 ? atoi(argv[2]) : 6, rc;
    double *x = malloc(sizeof(double) * 3 * (size_t)n), *q = malloc(sizeof(double) * (size_t)n);
    double *u = malloc(sizeof(double) * (size_t)n), num = 0, den = 0, dnum = 0, err, bound;
    double xt[3 * 200], ud[200]; /* the sampled targets, their direct sums */
    const double delta = 0.01;
    uint64_t seed = 42;
    kifmm_opts opts = {0};
    kifmm_blob *fmm = NULL;

    if (!x || !q || !u || n < 1) {
        fprintf(stderr, "custom_kernel: bad size or out of memory\n");
        return 1;
    }
    for (i = 0; i < 3 * n; i++) x[i] = rand01(&seed);
    for (i = 0; i < n; i++) q[i] = rand01(&seed) - 0.5;

    opts.order = order;
    opts.kernel_param[0] = delta; /* the blob width */
    rc = kifmm_blob_create(&fmm, &opts, n, x, n, x);
    if (rc == KIFMM_SUCCESS) rc = kifmm_blob_evaluate(fmm, q, u);
    kifmm_blob_destroy(fmm);
    if (rc != KIFMM_SUCCESS) {
        fprintf(stderr, "custom_kernel: %s\n", kifmm_strerror(rc));
        return 1;
    }

    /* direct summation, written out independently of the kernel above; and
     * the library's direct sums of the kernel's eval at the same targets */
    for (j = 0; j < nsample; j++) memcpy(xt + 3 * j, x + 3 * (j * (n / nsample)), 3 * sizeof(double));
    rc = kifmm_blob_direct(&opts, n, x, q, nsample, xt, ud);
    if (rc != KIFMM_SUCCESS) {
        fprintf(stderr, "custom_kernel: direct: %s\n", kifmm_strerror(rc));
        return 1;
    }
    for (j = 0; j < nsample; j++) {
        int64_t t = j * (n / nsample);
        double s = 0;
        for (i = 0; i < n; i++) {
            double dx = x[3 * t] - x[3 * i], dy = x[3 * t + 1] - x[3 * i + 1];
            double dz = x[3 * t + 2] - x[3 * i + 2], r2 = dx * dx + dy * dy + dz * dz;
            double r = sqrt(r2);
            if (i != t) s += q[i] * erf(r / delta) / (4.0 * 3.14159265358979323846 * r);
        }
        num += (u[t] - s) * (u[t] - s);
        den += s * s;
        dnum += (ud[j] - s) * (ud[j] - s);
    }
    err = sqrt(num / den);
    printf("kifmm_blob_direct against the sums written out: %.1e\n", sqrt(dnum / den));
    /* the Laplace accuracy table's bounds, which this kernel also meets */
    bound = order <= 4 ? 4e-4 : order <= 6 ? 4e-6 : order <= 8 ? 1e-7 : 5e-9;
    printf("kernel erf(r/delta)/(4 pi r), delta = %g, N = %lld, order %d: relative L2 error "
           "%.2e at %lld targets (bound %.0e) %s\n",
           delta, (long long)n, order, err, (long long)nsample, bound, err <= bound ? "ok" : "FAIL");
    free(x);
    free(q);
    free(u);
    return err <= bound ? 0 : 1;
}
