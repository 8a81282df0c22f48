/* examples/timestep.c - a time-stepping N-body code with kifmm.h
 *
 * A Plummer sphere of N equal masses stepped with leapfrog (kick, drift,
 * kick). The accelerations come from the laplace_grad kernel: with
 * K = 1 / (4 pi r) the outputs at body j are the potential
 * phi_j = sum_i m_i / (4 pi r_ij) and its gradient, so the acceleration is
 * a_j = 4 pi G grad phi_j and the potential energy -2 pi G sum_j m_j phi_j.
 *
 * One handle serves every step: kifmm_laplace_grad_update_points gives it
 * the moved bodies (a new tree and new lists; the operators, which depend
 * on the options alone for this kernel, are kept), then one evaluate. The
 * program prints the time of a step against a step that creates a new
 * handle (create + evaluate on the same bodies), checks the accelerations
 * of the last step against direct sums at 200 bodies, and the total
 * energy's relative change over the run; it exits nonzero if either is off.
 *
 * Build and run (from the repository root):
 *     cc -O2 -march=native -fopenmp -I. examples/timestep.c -o timestep \
 *        -llapacke -lopenblas -lm
 *     ./timestep [N] [steps] [order]     defaults 200000, 10 and 6
 * or `make timestep` (ARGS="1000000 5 8").
 */
#define _POSIX_C_SOURCE 199309L /* clock_gettime, when built without OpenMP */

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"

#ifdef _OPENMP
#include <omp.h>
#endif

#define G 1.0
#define PI 3.14159265358979323846

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

/* splitmix64, uniform in (0, 1) */
static double random01(uint64_t *state)
{
    uint64_t z = (*state += UINT64_C(0x9E3779B97F4A7C15));
    z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
    z ^= z >> 31;
    return ((double)(z >> 11) + 0.5) * (1.0 / 9007199254740992.0);
}

/* a random direction times r into x[0..2] */
static void direction(uint64_t *s, double r, double *x)
{
    const double c = 2.0 * random01(s) - 1.0, ph = 2.0 * PI * random01(s);
    const double st = sqrt(1.0 - c * c);
    x[0] = r * st * cos(ph);
    x[1] = r * st * sin(ph);
    x[2] = r * c;
}

/* A Plummer sphere of total mass 1 and scale 1 (Aarseth, Henon and Wielen
 * 1974): radii from the cumulative mass (cut at 10), speeds by rejection
 * from q^2 (1 - q^2)^(7/2) times the escape speed. */
static void plummer(int64_t n, double *x, double *v, uint64_t seed)
{
    int64_t i;
    for (i = 0; i < n; i++) {
        double r, q, g, ve;
        do r = 1.0 / sqrt(pow(random01(&seed), -2.0 / 3.0) - 1.0);
        while (r > 10.0);
        direction(&seed, r, x + 3 * i);
        do {
            q = random01(&seed);
            g = 0.1 * random01(&seed);
        } while (g > q * q * pow(1.0 - q * q, 3.5));
        ve = sqrt(2.0 * G) * pow(1.0 + r * r, -0.25);
        direction(&seed, q * ve, v + 3 * i);
    }
}

/* accelerations a (3 per body) and potentials phi from the FMM's outputs */
static void split(int64_t n, const double *out, double *a, double *phi)
{
    int64_t i;
    for (i = 0; i < n; i++) {
        phi[i] = out[4 * i];
        a[3 * i] = 4.0 * PI * G * out[4 * i + 1];
        a[3 * i + 1] = 4.0 * PI * G * out[4 * i + 2];
        a[3 * i + 2] = 4.0 * PI * G * out[4 * i + 3];
    }
}

static double energy(int64_t n, const double *v, const double *m, const double *phi)
{
    double k = 0.0, w = 0.0;
    int64_t i;
    for (i = 0; i < n; i++) {
        k += 0.5 * m[i] * (v[3 * i] * v[3 * i] + v[3 * i + 1] * v[3 * i + 1] + v[3 * i + 2] * v[3 * i + 2]);
        w -= 2.0 * PI * G * m[i] * phi[i];
    }
    return k + w;
}

static int fail(const char *what, int rc)
{
    fprintf(stderr, "timestep: %s: %s\n", what, kifmm_strerror(rc));
    return 1;
}

int main(int argc, char **argv)
{
    const int64_t n = argc > 1 ? (int64_t)atof(argv[1]) : 200000;
    const int steps = argc > 2 ? atoi(argv[2]) : 10;
    kifmm_opts opts = {0};
    double *x, *v, *m, *out, *a, *phi, *ref;
    double e0, e1, t_step = 0.0, t_upd = 0.0, t_eval = 0.0, t_new, t0, err2 = 0.0, ref2 = 0.0;
    const double dt = 1e-3;
    kifmm_laplace_grad *fmm = NULL, *fresh = NULL;
    int64_t i, nref;
    int s, rc;
    opts.order = argc > 3 ? atoi(argv[3]) : 6;
    if (n < 2 || steps < 1) {
        fprintf(stderr, "usage: timestep [N >= 2] [steps >= 1] [order]\n");
        return 2;
    }
    x = malloc(3 * (size_t)n * sizeof *x);
    v = malloc(3 * (size_t)n * sizeof *v);
    a = malloc(3 * (size_t)n * sizeof *a);
    m = malloc((size_t)n * sizeof *m);
    phi = malloc((size_t)n * sizeof *phi);
    out = malloc(4 * (size_t)n * sizeof *out);
    ref = malloc(4 * 200 * sizeof *ref);
    if (!x || !v || !a || !m || !phi || !out || !ref) {
        fprintf(stderr, "timestep: out of memory\n");
        return 1;
    }
    plummer(n, x, v, 1);
    for (i = 0; i < n; i++) m[i] = 1.0 / (double)n;

    /* the handle, created once */
    if ((rc = kifmm_laplace_grad_create(&fmm, &opts, n, x, n, x))) return fail("create", rc);
    if ((rc = kifmm_laplace_grad_evaluate(fmm, m, out))) return fail("evaluate", rc);
    split(n, out, a, phi);
    e0 = energy(n, v, m, phi);
    printf("Plummer sphere, %lld bodies, order %d, dt %g, %d leapfrog steps\n", (long long)n,
           opts.order, dt, steps);
    for (s = 0; s < steps; s++) {
        double ta, tb, tc;
        for (i = 0; i < 3 * n; i++) v[i] += 0.5 * dt * a[i];
        for (i = 0; i < 3 * n; i++) x[i] += dt * v[i];
        ta = wall_seconds();
        if ((rc = kifmm_laplace_grad_update_points(fmm, n, x, n, x))) return fail("update_points", rc);
        tb = wall_seconds();
        if ((rc = kifmm_laplace_grad_evaluate(fmm, m, out))) return fail("evaluate", rc);
        tc = wall_seconds();
        t_upd += tb - ta;
        t_eval += tc - tb;
        t_step += tc - ta;
        split(n, out, a, phi);
        for (i = 0; i < 3 * n; i++) v[i] += 0.5 * dt * a[i];
    }
    e1 = energy(n, v, m, phi);

    /* the last step's outputs against direct sums at up to 200 bodies */
    nref = n < 200 ? n : 200;
    if ((rc = kifmm_laplace_grad_direct(&opts, n, x, m, nref, x, ref))) return fail("direct", rc);
    for (i = 0; i < nref; i++) {
        int k;
        for (k = 1; k < 4; k++) {
            const double d = out[4 * i + k] - ref[4 * i + k];
            err2 += d * d;
            ref2 += ref[4 * i + k] * ref[4 * i + k];
        }
    }

    /* the same step with a new handle, on the same bodies */
    t0 = wall_seconds();
    rc = kifmm_laplace_grad_create(&fresh, &opts, n, x, n, x);
    if (!rc) rc = kifmm_laplace_grad_evaluate(fresh, m, out);
    t_new = wall_seconds() - t0;
    kifmm_laplace_grad_destroy(fresh);
    if (rc) return fail("create + evaluate", rc);

    printf("  a step: update_points %.3f s + evaluate %.3f s = %.3f s\n", t_upd / steps,
           t_eval / steps, t_step / steps);
    printf("  a step with a new handle (create + evaluate): %.3f s (%.2fx the step)\n", t_new,
           t_new / (t_step / steps));
    printf("  accelerations against direct sums at %lld bodies: %.2e\n", (long long)nref,
           sqrt(err2 / ref2));
    printf("  total energy %.6f -> %.6f, relative change %.1e\n", e0, e1, fabs(e1 - e0) / fabs(e0));
    kifmm_laplace_grad_destroy(fmm);
    rc = !(sqrt(err2 / ref2) < 10.0 * pow(10.0, -0.8 * opts.order)) ||
         !(fabs(e1 - e0) / fabs(e0) < 1e-4);
    free(x), free(v), free(a), free(m), free(phi), free(out), free(ref);
    return rc;
}
