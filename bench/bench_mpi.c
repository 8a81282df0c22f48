/* bench/bench_mpi.c - MPI mode (KIFMM_MPI, kifmm_laplace_grad_create_mpi):
 * balance, bytes and weak scaling. Run under mpirun (bench/run.sh runs it
 * oversubscribed on small machines, one OpenMP thread a rank):
 *
 *   bench_mpi fixed N DIST [P]   N points in all (DIST cube, plummer or
 *                                clustered, bench/points.h's blobs,
 *                                sources = targets; or hotspot, uniform
 *                                sources and N / 2 targets in the cube
 *                                [0.4, 0.5]^3), each rank generating its
 *                                share: per rank the points it owns after
 *                                the partition, ghosts, boxes, work (evaluate
 *                                less the time in MPI calls), bytes; the
 *                                slowest rank's work over the mean
 *   bench_mpi weak NPER [P]      NPER uniform points a rank in the unit cube:
 *                                every rank first evaluates its own points
 *                                alone (MPI_COMM_SELF, all ranks at once, so
 *                                both runs share the cores alike), then all
 *                                together; efficiency = alone / together
 *
 * Order P (default 6); evaluate timed as the fastest of 3. */
#define KIFMM_MPI
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "points.h"


typedef kifmm_laplace_grad fmm;

static int rank_, size_;

/* create (targets y, ny of them: NULL for the sources), then evaluate 3
 * times: the fastest; its stats in *st */
static int run(MPI_Comm comm, int64_t n, const double *x, const double *q, int64_t ny, const double *y,
               int p, double *tc, double *te, kifmm_stats *st)
{
    kifmm_opts o;
    fmm *h = NULL;
    double *out = (double *)malloc((size_t)(4 * (y ? ny : n) + 4) * sizeof(double)), t0;
    int rc, k;
    memset(&o, 0, sizeof o);
    o.order = p;
    MPI_Barrier(comm);
    t0 = MPI_Wtime();
    rc = y ? kifmm_laplace_grad_create_mpi(&h, comm, &o, n, x, ny, y) : kifmm_laplace_grad_create_mpi(&h, comm, &o, n, x, n, x);
    *tc = MPI_Wtime() - t0;
    *te = 1e30;
    for (k = 0; k < 3 && !rc; k++) {
        kifmm_stats s;
        MPI_Barrier(comm);
        rc = kifmm_laplace_grad_evaluate(h, q, out);
        if (!rc) rc = kifmm_laplace_grad_stats(h, &s);
        if (!rc && s.t_evaluate < *te) *te = s.t_evaluate, *st = s;
    }
    kifmm_laplace_grad_destroy(h);
    free(out);
    return rc;
}

/* max and mean of v over the ranks */
static void maxmean(double v, double *mx, double *mean)
{
    MPI_Allreduce(&v, mx, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    MPI_Allreduce(&v, mean, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    *mean /= size_;
}

static int fixed(int64_t N, const char *dist, int p)
{
    const int64_t n = N / size_ + (rank_ < N % size_);
    double *x = (double *)malloc((size_t)(3 * n + 3) * sizeof(double));
    double *q = (double *)malloc((size_t)(n + 1) * sizeof(double)), tc, te, row[11], *all = NULL, *y = NULL;
    double wmx, wmean, smx, smean, rmx, rmean;
    kifmm_stats st;
    int rc, r;
    if (!strcmp(dist, "hotspot")) { /* uniform sources, half as many targets in a cube a tenth as wide */
        make_points(DIST_CUBE, n, 1, 1000 + (uint64_t)rank_, x, q);
        double *qy = (double *)malloc((size_t)(n / 2 + 1) * sizeof(double));
        y = (double *)malloc((size_t)(3 * (n / 2) + 3) * sizeof(double));
        make_points(DIST_CUBE, n / 2, 1, 3000 + (uint64_t)rank_, y, qy);
        free(qy);
        for (int64_t i = 0; i < 3 * (n / 2); i++) y[i] = 0.4 + 0.1 * y[i];
    } else if (!strcmp(dist, "plummer")) make_plummer(n, 1, 1000 + (uint64_t)rank_, x, q);
    else make_points(!strcmp(dist, "clustered") ? DIST_CLUSTERED : DIST_CUBE, n, 1, 1000 + (uint64_t)rank_, x, q);
    memset(&st, 0, sizeof st);
    if ((rc = run(MPI_COMM_WORLD, n, x, q, n / 2, y, p, &tc, &te, &st))) {
        if (!rank_) printf("mpi fixed %s: %s\n", dist, kifmm_strerror(rc));
        return 1;
    }
    row[0] = (double)st.mpi_sources, row[1] = (double)st.mpi_ghost_points;
    row[2] = (double)st.mpi_ghost_boxes, row[3] = st.t_evaluate - st.t_mpi_wait, row[4] = st.t_mpi_wait;
    row[5] = st.mpi_bytes_sent, row[6] = st.mpi_bytes_recv, row[7] = st.t_evaluate, row[8] = (double)st.boxes;
    row[9] = st.mpi_ghost_bytes, row[10] = st.t_mpi_work;
    if (!rank_) all = (double *)malloc(11 * (size_t)size_ * sizeof(double));
    MPI_Gather(row, 11, MPI_DOUBLE, all, 11, MPI_DOUBLE, 0, MPI_COMM_WORLD);
    maxmean(st.t_mpi_work, &wmx, &wmean);
    maxmean(st.mpi_bytes_sent, &smx, &smean);
    maxmean(st.mpi_bytes_recv, &rmx, &rmean);
    if (!rank_) {
        printf("mpi %s %lld, %d ranks, p = %d: create %.3f s, evaluate %.3f s; work (CPU) max / mean %.2f; "
               "MiB a rank sent %.2f (max %.2f), received %.2f (max %.2f)\n",
               dist, (long long)N, size_, p, tc, row[7], wmx / wmean, smean / 1048576.0, smx / 1048576.0,
               rmean / 1048576.0, rmx / 1048576.0);
        printf("  rank   points    boxes   ghosts  proxies  work s (CPU)  MPI s  sent MiB  recv MiB  of which ghosts MiB\n");
        for (r = 0; r < size_; r++) {
            const double *a = all + 11 * r;
            printf("  %4d %8.0f %8.0f %8.0f %8.0f %7.3f (%6.3f) %6.3f %9.2f %9.2f %9.2f\n", r, a[0], a[8], a[1],
                   a[2], a[3], a[10], a[4], a[5] / 1048576.0, a[6] / 1048576.0, a[9] / 1048576.0);
        }
        free(all);
    }
    if (getenv("BENCH_MPI_PASSES"))
        printf("  rank %d passes: p2m %.3f m2m %.3f m2l %.3f l2l %.3f p2l %.3f l2p %.3f m2p %.3f p2p %.3f\n", rank_,
               st.t_p2m, st.t_m2m, st.t_m2l, st.t_l2l, st.t_p2l, st.t_l2p, st.t_m2p, st.t_p2p);
    free(x);
    free(y);
    free(q);
    return 0;
}

static int weak(int64_t n, int p)
{
    double *x = (double *)malloc((size_t)(3 * n + 3) * sizeof(double));
    double *q = (double *)malloc((size_t)(n + 1) * sizeof(double)), tc1, te1, tc, te;
    double a, amean, b, bmean, c1, c1m, c, cm, w1, w1m, w, wm;
    kifmm_stats st1, st;
    int rc;
    make_points(DIST_CUBE, n, 1, 2000 + (uint64_t)rank_, x, q);
    memset(&st1, 0, sizeof st1);
    memset(&st, 0, sizeof st);
    rc = run(MPI_COMM_SELF, n, x, q, 0, NULL, p, &tc1, &te1, &st1);
    if (!rc) rc = run(MPI_COMM_WORLD, n, x, q, 0, NULL, p, &tc, &te, &st);
    MPI_Allreduce(MPI_IN_PLACE, &rc, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (rc) {
        if (!rank_) printf("mpi weak: %s\n", kifmm_strerror(rc));
        return 1;
    }
    maxmean(te1, &a, &amean);
    maxmean(st.t_evaluate, &b, &bmean);
    maxmean(tc1, &c1, &c1m);
    maxmean(tc, &c, &cm);
    maxmean(st1.t_mpi_work, &w1, &w1m);
    maxmean(st.t_mpi_work, &w, &wm);
    if (!rank_)
        printf("mpi weak %lld a rank, %2d ranks, p = %d: alone create %.3f evaluate %.3f s; together "
               "create %.3f evaluate %.3f s; efficiency %.2f (evaluate), %.2f (create), %.2f (evaluate's "
               "CPU work)\n",
               (long long)n, size_, p, c1m, amean, c, b, amean / b, c1m / c, w1m / wm);
    free(x);
    free(q);
    return 0;
}

int main(int argc, char **argv)
{
    int rc = 1;
    (void)dist_names; /* points.h's, for the other benches */
    MPI_Init(&argc, &argv);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
    if (argc >= 4 && !strcmp(argv[1], "fixed"))
        rc = fixed(atoll(argv[2]), argv[3], argc > 4 ? atoi(argv[4]) : 6);
    else if (argc >= 3 && !strcmp(argv[1], "weak"))
        rc = weak(atoll(argv[2]), argc > 3 ? atoi(argv[3]) : 6);
    else if (!rank_)
        fprintf(stderr, "usage: bench_mpi fixed N cube|plummer|clustered|hotspot [P] | weak NPER [P]\n");
    MPI_Finalize();
    return rc;
}
