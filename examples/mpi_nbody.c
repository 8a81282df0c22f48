/* examples/mpi_nbody.c - an N-body code on MPI ranks with kifmm.h
 *
 * A Plummer sphere of N equal masses, each rank holding its own bodies (a
 * share generated on that rank, as a distributed code would hold them),
 * stepped with leapfrog (kick, drift, kick). The accelerations come from
 * the laplace_grad kernel, as in examples/timestep.c: with K = 1 / (4 pi r)
 * the outputs at body j are phi_j = sum_i m_i / (4 pi r_ij) and its
 * gradient, so a_j = 4 pi G grad phi_j.
 *
 * One MPI handle (kifmm_laplace_grad_create_mpi, KIFMM_MPI defined before
 * the include) serves every step: each rank passes its own bodies and gets
 * the outputs at them, in its order; update_points gives it the moved
 * bodies (a new partition, ghosts and tree; the operators kept). Every
 * call on the handle is collective. At the end rank 0 gathers every body
 * and checks its first 200 accelerations against direct sums; each rank
 * prints what it owns and sends; the program exits nonzero if the error
 * is off.
 *
 * Build and run (from the repository root; Open MPI or MPICH):
 *     mpicc -O2 -march=native -fopenmp -I. examples/mpi_nbody.c -o mpi_nbody \
 *        -llapacke -lopenblas -lm
 *     mpirun -np 4 ./mpi_nbody [N] [steps] [order]    defaults 200000, 5 and 6
 * or `make mpi_nbody` (NP=4 ARGS="1000000 5 8").
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define KIFMM_MPI
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"

#define G 1.0
#define PI 3.14159265358979323846

static double rnd(uint64_t *s) /* splitmix64, in [0, 1) */
{
    uint64_t z = (*s += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return (double)((z ^ (z >> 31)) >> 11) * (1.0 / 9007199254740992.0);
}

/* n bodies of a Plummer sphere (scale 1, total mass 1 over N bodies), at
 * rest: radii from the cumulative mass, cut at 10 */
static void plummer(int64_t n, uint64_t seed, double *x)
{
    for (int64_t i = 0; i < n; i++) {
        double r, z, ph;
        do r = 1.0 / sqrt(pow(rnd(&seed) * 0.999 + 1e-9, -2.0 / 3.0) - 1.0);
        while (r > 10.0);
        z = 2.0 * rnd(&seed) - 1.0;
        ph = 2.0 * PI * rnd(&seed);
        x[3 * i] = r * sqrt(1.0 - z * z) * cos(ph);
        x[3 * i + 1] = r * sqrt(1.0 - z * z) * sin(ph);
        x[3 * i + 2] = r * z;
    }
}

static void die(int rc, const char *what)
{
    fprintf(stderr, "mpi_nbody: %s: %s\n", what, kifmm_strerror(rc));
    MPI_Abort(MPI_COMM_WORLD, 1);
}

int main(int argc, char **argv)
{
    int rank, size, rc, k, steps, bad = 0;
    int64_t N, n, i;
    double *x, *v, *m, *out, dt = 1e-3, t0, tstep = 0.0;
    kifmm_laplace_grad *fmm = NULL;
    kifmm_opts opts;
    kifmm_stats st;
    memset(&st, 0, sizeof st);
    MPI_Init(&argc, &argv);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    N = argc > 1 ? atoll(argv[1]) : 200000;
    steps = argc > 2 ? atoi(argv[2]) : 5;
    n = N / size + (rank < N % size);
    x = (double *)malloc((size_t)(3 * n + 3) * sizeof(double));
    v = (double *)calloc((size_t)(3 * n + 3), sizeof(double));
    m = (double *)malloc((size_t)(n + 1) * sizeof(double));
    out = (double *)malloc((size_t)(4 * n + 4) * sizeof(double));
    plummer(n, 12345 + (uint64_t)rank, x);
    for (i = 0; i < n; i++) m[i] = 1.0 / (double)N;
    memset(&opts, 0, sizeof opts);
    opts.order = argc > 3 ? atoi(argv[3]) : 6;

    /* every rank passes its own bodies, as sources and as targets */
    if ((rc = kifmm_laplace_grad_create_mpi(&fmm, MPI_COMM_WORLD, &opts, n, x, n, x))) die(rc, "create_mpi");
    if ((rc = kifmm_laplace_grad_evaluate(fmm, m, out))) die(rc, "evaluate");
    for (k = 0; k < steps; k++) {
        MPI_Barrier(MPI_COMM_WORLD);
        t0 = MPI_Wtime();
        for (i = 0; i < n; i++) /* kick, drift */
            for (int d = 0; d < 3; d++) {
                v[3 * i + d] += 0.5 * dt * 4.0 * PI * G * out[4 * i + 1 + d];
                x[3 * i + d] += dt * v[3 * i + d];
            }
        if ((rc = kifmm_laplace_grad_update_points(fmm, n, x, n, x))) die(rc, "update_points");
        if ((rc = kifmm_laplace_grad_evaluate(fmm, m, out))) die(rc, "evaluate");
        for (i = 0; i < n; i++) /* kick */
            for (int d = 0; d < 3; d++) v[3 * i + d] += 0.5 * dt * 4.0 * PI * G * out[4 * i + 1 + d];
        tstep += MPI_Wtime() - t0;
    }
    if ((rc = kifmm_laplace_grad_stats(fmm, &st))) die(rc, "stats");
    printf("rank %d of %d: %lld bodies passed, %lld owned, %lld ghosts, %lld boxes received; "
           "evaluate %.3f s (%.3f in MPI), %.2f MiB sent\n",
           rank, size, (long long)n, (long long)st.mpi_sources, (long long)st.mpi_ghost_points,
           (long long)st.mpi_ghost_boxes, st.t_evaluate, st.t_mpi_wait, st.mpi_bytes_sent / 1048576.0);
    fflush(stdout);

    { /* rank 0: the first 200 of its bodies against direct sums over all */
        int *cnt = (int *)malloc((size_t)size * sizeof(int)), *dsp = (int *)malloc((size_t)size * sizeof(int));
        int c = (int)(3 * n), tot = 0;
        double *all = NULL, *ref, e2 = 0.0, r2 = 0.0, *q;
        int64_t nc = n < 200 ? n : 200;
        MPI_Gather(&c, 1, MPI_INT, cnt, 1, MPI_INT, 0, MPI_COMM_WORLD);
        if (rank == 0) {
            for (k = 0; k < size; k++) dsp[k] = tot, tot += cnt[k];
            all = (double *)malloc((size_t)tot * sizeof(double));
        }
        MPI_Gatherv(x, c, MPI_DOUBLE, all, cnt, dsp, MPI_DOUBLE, 0, MPI_COMM_WORLD);
        if (rank == 0) {
            q = (double *)malloc((size_t)(tot / 3 + 1) * sizeof(double));
            ref = (double *)malloc((size_t)(4 * nc + 4) * sizeof(double));
            for (i = 0; i < tot / 3; i++) q[i] = 1.0 / (double)N;
            if ((rc = kifmm_laplace_grad_direct(&opts, tot / 3, all, q, nc, x, ref))) die(rc, "direct");
            for (i = 0; i < 4 * nc; i++) e2 += (out[i] - ref[i]) * (out[i] - ref[i]), r2 += ref[i] * ref[i];
            printf("%lld bodies on %d ranks, order %d: %.3f s a step (update_points + evaluate); "
                   "error against direct sums at %lld bodies %.2e\n",
                   (long long)N, size, opts.order, tstep / (steps > 0 ? steps : 1), (long long)nc, sqrt(e2 / r2));
            bad = !(sqrt(e2 / r2) < 1e-3);
            free(q), free(ref), free(all);
        }
        free(cnt), free(dsp);
    }
    kifmm_laplace_grad_destroy(fmm); /* collective, before MPI_Finalize */
    free(x), free(v), free(m), free(out);
    MPI_Bcast(&bad, 1, MPI_INT, 0, MPI_COMM_WORLD);
    MPI_Finalize();
    return bad;
}
