/* test_mpi.c - MPI mode (<prefix>_create_mpi, KIFMM_MPI): run under mpirun
 * with 1 to 4 ranks (tests/mpi.sh). Each rank holds its own share of one
 * global point set (handed out at random, or all on rank 0), and its
 * outputs must match direct sums over all the points (<prefix>_direct, no
 * tree) at the targets it passed, to the bounds of one process; with one
 * rank they must equal a create handle's bit for bit. Cases: uniform,
 * sphere-surface and Plummer points, sources = targets and separate
 * targets, laplace_grad, float laplace, yukawa_grad and stokes, several
 * vectors, update_points (equal, bit for bit, to a new create_mpi on the
 * same points), a few points over more ranks, stats, and errors met on one
 * rank only (every rank returns one, nothing written); every block the
 * library allocated is freed in the end. */
#include <stdlib.h>

/* every block the library allocates, counted: none may be left once the
 * handles are destroyed, failures included */
static long live_blocks;
static long fail_at = -1; /* >= 0: this rank's allocation number fail_at fails */
static long alloc_calls;
static void *count_malloc(size_t n)
{
    void *p;
    long k;
#ifdef _OPENMP
#pragma omp atomic capture
#endif
    k = alloc_calls++;
    if (k == fail_at) return NULL;
    p = malloc(n);
    if (p) {
#ifdef _OPENMP
#pragma omp atomic
#endif
        live_blocks++;
    }
    return p;
}
static void count_free(void *p)
{
    if (!p) return;
#ifdef _OPENMP
#pragma omp atomic
#endif
    live_blocks--;
    free(p);
}
#define KIFMM_MALLOC(n) count_malloc(n)
#define KIFMM_FREE(p) count_free(p)

#define KIFMM_MPI
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"
#define KIFMM_KERNEL laplace
#define KIFMM_REAL float
#include "kifmm.h"
#define KIFMM_KERNEL yukawa_grad
#include "kifmm.h"
#define KIFMM_KERNEL stokes
#include "kifmm.h"
#define KIFMM_KERNEL laplace_dipole_grad
#include "kifmm.h"

#include "../test.h"

static int g_rank, g_size;

/* groups and errors are reported by rank 0; any rank prints its FAILs */
static void group(const char *name)
{
    if (g_rank == 0) t_group(name);
}

/* Plummer sphere (scale 1), radii cut at 20 */
static void gen_plummer(t_rng *r, int64_t n, double *x)
{
    for (int64_t i = 0; i < n; i++) {
        double u, rad, z, ph;
        do {
            u = t_uniform(r, 1e-6, 1.0);
            rad = 1.0 / sqrt(pow(u, -2.0 / 3.0) - 1.0);
        } while (rad > 20.0);
        z = t_uniform(r, -1.0, 1.0);
        ph = t_uniform(r, 0.0, 2.0 * T_PI);
        x[3 * i] = rad * sqrt(1.0 - z * z) * cos(ph);
        x[3 * i + 1] = rad * sqrt(1.0 - z * z) * sin(ph);
        x[3 * i + 2] = rad * z;
    }
}

static double *gen_points(int kind, uint64_t seed, int64_t n)
{
    t_rng r = t_rng_seed(seed);
    double *x = t_doubles(3 * n + 3);
    if (kind == 0) t_gen_cube(&r, n, x, 0.0, 1.0);
    else if (kind == 1) t_gen_sphere(&r, n, x);
    else gen_plummer(&r, n, x);
    return x;
}

static const char *kind_name[3] = {"uniform", "sphere", "Plummer"};
static const char *mode_name[2] = {"handed out at random", "all on rank 0"};

/* the rank that gets global point i (mode 0: a hash, 1: rank 0) */
static int owner_of(int64_t i, int mode, uint64_t salt)
{
    uint64_t h = (uint64_t)i * 0x9e3779b97f4a7c15ULL ^ salt;
    h ^= h >> 29;
    h *= 0xbf58476d1ce4e5b9ULL;
    h ^= h >> 32;
    return mode == 1 ? 0 : (int)(h % (uint64_t)g_size);
}

/* this rank's share of n points of dimension dim (values a, in global
 * order): *ids gets their global indices; returns the count */
static int64_t share(int64_t n, int mode, uint64_t salt, int64_t **ids)
{
    int64_t k = 0;
    *ids = (int64_t *)t_malloc_or_die((size_t)(n + 1) * sizeof(int64_t));
    for (int64_t i = 0; i < n; i++)
        if (owner_of(i, mode, salt) == g_rank) (*ids)[k++] = i;
    return k;
}

/* the global relative L2 difference over every rank's (e2, r2) */
static double global_rel(double e2, double r2)
{
    double v[2] = {e2, r2};
    MPI_Allreduce(MPI_IN_PLACE, v, 2, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    return v[1] > 0.0 ? sqrt(v[0] / v[1]) : sqrt(v[0]);
}

/* every rank's condition holds */
static int all_ranks(int ok)
{
    MPI_Allreduce(MPI_IN_PLACE, &ok, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    return ok;
}

#define NSAMPLE 300

#define T_MPI_RUN(P, R, SD, TD)                                                                    \
    static void run_##P(int kind, int mode, int64_t NT, int64_t N, int nv, int order, double bound) \
    {                                                                                              \
        kifmm_opts o = t_opts(order, 0, 0);                                                        \
        const int same = NT == 0;                                                                  \
        const int64_t nt_g = same ? N : NT;                                                        \
        double *gx = gen_points(kind, 11 + kind, N), *gq = t_densities(5 + kind, N, SD, nv, 0);    \
        double *gy = same ? gx : gen_points(kind == 1 ? 0 : kind, 23 + kind, NT), e1 = 0.0, err;   \
        R *X = P##_conv(gx, 3 * N), *Y = same ? X : P##_conv(gy, 3 * NT);                          \
        R *Q = P##_conv(gq, N * SD * nv), *x, *y, *q, *out, *ref, *o1 = NULL;                      \
        int64_t *sid, *tid, ns, nt;                                                                \
        kifmm_stats st;                                                                            \
        int64_t cnt[2];                                                                            \
        P *h = NULL;                                                                               \
        int rc;                                                                                    \
        ns = share(N, mode, 1, &sid);                                                              \
        nt = same ? ns : share(NT, mode, 2, &tid);                                                 \
        if (same) tid = sid;                                                                       \
        x = P##_pick(X, ns, 3, 1, N, sid), q = P##_pick(Q, ns, SD, nv, N, sid);                    \
        y = same ? x : P##_pick(Y, nt, 3, 1, NT, tid);                                             \
        out = (R *)t_malloc_or_die((size_t)(nv * nt * TD + 1) * sizeof(R));                        \
        rc = P##_create_mpi(&h, MPI_COMM_WORLD, &o, ns, x, nt, y);                                 \
        CHECK(rc == KIFMM_SUCCESS, "%s create_mpi: %s", #P, kifmm_strerror(rc));                   \
        if (rc) return;                                                                            \
        rc = P##_evaluate_many(h, nv, q, out);                                                     \
        CHECK(rc == KIFMM_SUCCESS, "%s evaluate: %s", #P, kifmm_strerror(rc));                     \
        ref = P##_ref(&o, N, X, Q, nt_g, Y, nv);                                                   \
        err = P##_err(nt, tid, out, nv, nt_g, ref, 1);                                             \
        if (g_rank == 0) { /* one process, all the points */                                       \
            int64_t *all = (int64_t *)t_malloc_or_die((size_t)(nt_g + 1) * sizeof(int64_t));       \
            P *s = NULL;                                                                           \
            o1 = (R *)t_malloc_or_die((size_t)(nv * nt_g * TD + 1) * sizeof(R));                   \
            for (int64_t i = 0; i < nt_g; i++) all[i] = i;                                         \
            rc = P##_create(&s, &o, N, X, nt_g, Y);                                                \
            if (!rc) rc = P##_evaluate_many(s, nv, Q, o1);                                         \
            CHECK(rc == KIFMM_SUCCESS, "%s one process: %s", #P, kifmm_strerror(rc));              \
            e1 = P##_err(nt_g, all, o1, nv, nt_g, ref, 0);                                         \
            P##_destroy(s);                                                                        \
            free(all);                                                                             \
        }                                                                                          \
        MPI_Bcast(&e1, 1, MPI_DOUBLE, 0, MPI_COMM_WORLD);                                          \
        if (g_rank == 0) {                                                                         \
            CHECK_ERR(err, bound, "%s %s %s%s, %lld, %d ranks, p = %d", #P, kind_name[kind],       \
                      mode_name[mode], same ? "" : ", targets apart", (long long)N, g_size, order); \
            CHECK_ERR(err, 3.0 * e1 + 1e-13, "  and against 3 x one process's %.2e", e1);          \
        }                                                                                          \
        if (g_size == 1)                                                                           \
            CHECK(!memcmp(out, o1, (size_t)nv * nt * TD * sizeof(R)), "%s: 1 rank != create", #P); \
        memset(&st, 0, sizeof st);                                                                 \
        CHECK(P##_stats(h, &st) == KIFMM_SUCCESS && st.mpi_ranks == g_size, "%s stats", #P);      \
        cnt[0] = st.mpi_sources, cnt[1] = st.mpi_targets;                                          \
        MPI_Allreduce(MPI_IN_PLACE, cnt, 2, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);                  \
        CHECK(cnt[0] == N && cnt[1] == nt_g, "%s: owned %lld %lld", #P, (long long)cnt[0],         \
              (long long)cnt[1]);                                                                  \
        P##_update(h, &o, kind, mode, same, N, NT, nv, bound);                                     \
        P##_destroy(h);                                                                            \
        free(gx), free(gq), free(X), free(Q), free(x), free(q), free(out), free(ref), free(o1);    \
        free(sid);                                                                                 \
        if (!same) free(gy), free(Y), free(y), free(tid);                                          \
    }

/* update_points onto another set (other points, another handout): equal,
 * bit for bit, to a new create_mpi there, and within bound of the sums */
#define T_MPI_UPDATE(P, R, SD, TD)                                                                 \
    static void P##_update(P *h, const kifmm_opts *o, int kind, int mode, int same, int64_t N,     \
                           int64_t NT, int nv, double bound)                                       \
    {                                                                                              \
        const int64_t nt_g = same ? N : NT;                                                        \
        double *gx = gen_points(kind, 101 + kind, N), *gq = t_densities(9, N, SD, nv, 0);          \
        double *gy = same ? gx : gen_points(0, 103, NT), err;                                      \
        R *X = P##_conv(gx, 3 * N), *Y = same ? X : P##_conv(gy, 3 * NT);                          \
        R *Q = P##_conv(gq, N * SD * nv), *x, *y, *q, *out, *out2, *ref;                           \
        int64_t *sid, *tid, ns, nt;                                                                \
        P *h2 = NULL;                                                                              \
        int rc;                                                                                    \
        ns = share(N, mode, 7, &sid);                                                              \
        nt = same ? ns : share(NT, mode, 8, &tid);                                                 \
        if (same) tid = sid;                                                                       \
        x = P##_pick(X, ns, 3, 1, N, sid), q = P##_pick(Q, ns, SD, nv, N, sid);                    \
        y = same ? x : P##_pick(Y, nt, 3, 1, NT, tid);                                             \
        out = (R *)t_malloc_or_die((size_t)(nv * nt * TD + 1) * sizeof(R));                        \
        out2 = (R *)t_malloc_or_die((size_t)(nv * nt * TD + 1) * sizeof(R));                       \
        rc = P##_update_points(h, ns, x, nt, y);                                                   \
        if (!rc) rc = P##_evaluate_many(h, nv, q, out);                                            \
        CHECK(rc == KIFMM_SUCCESS, "%s update_points: %s", #P, kifmm_strerror(rc));                \
        rc = P##_create_mpi(&h2, MPI_COMM_WORLD, o, ns, x, nt, y);                                 \
        if (!rc) rc = P##_evaluate_many(h2, nv, q, out2);                                          \
        CHECK(rc == KIFMM_SUCCESS, "%s create_mpi: %s", #P, kifmm_strerror(rc));                   \
        CHECK(all_ranks(!memcmp(out, out2, (size_t)nv * nt * TD * sizeof(R))),                    \
              "%s: update_points != create_mpi", #P);                                              \
        ref = P##_ref(o, N, X, Q, nt_g, Y, nv);                                                    \
        err = P##_err(nt, tid, out, nv, nt_g, ref, 1);                                             \
        if (g_rank == 0) CHECK_ERR(err, bound, "  after update_points");                           \
        P##_destroy(h2);                                                                           \
        free(gx), free(gq), free(X), free(Q), free(x), free(q), free(out), free(out2), free(ref);   \
        free(sid);                                                                                 \
        if (!same) free(gy), free(Y), free(y), free(tid);                                          \
    }

/* One case of instance P (coordinates and densities R, SD density and TD
 * output components): N sources (and NT separate targets, or the sources
 * when NT == 0) of distribution kind, handed out by mode; nv vectors.
 * Checks the error against direct sums at a global sample of targets,
 * against bound and against 3 times the error of one process (a create
 * handle on all the points, on rank 0) plus a floor; with one rank the
 * outputs equal create's bit for bit; update_points onto another set equals
 * a new create_mpi there, bit for bit, and meets the bound. */
#define T_MPI_CASE(P, R, SD, TD)                                                                   \
    static R *P##_conv(const double *x, int64_t n)                                                 \
    {                                                                                              \
        R *y = (R *)t_malloc_or_die((size_t)(n + 1) * sizeof(R));                                  \
        for (int64_t i = 0; i < n; i++) y[i] = (R)x[i];                                            \
        return y;                                                                                  \
    }                                                                                              \
    /* the error of out (this rank's targets, global ids tid) at the sample                        \
     * (global target j is sampled when j % step == 0), against ref (direct at                     \
     * the sample, in sample order) */                                                             \
    static double P##_err(int64_t nt, const int64_t *tid, const R *out, int nv, int64_t NT,        \
                          const R *ref, int all)                                                   \
    {                                                                                              \
        const int64_t step = NT / NSAMPLE > 0 ? NT / NSAMPLE : 1, ns = (NT + step - 1) / step;     \
        double e2 = 0.0, r2 = 0.0;                                                                 \
        for (int64_t i = 0; i < nt; i++)                                                           \
            if (tid[i] % step == 0)                                                                \
                for (int v = 0; v < nv; v++)                                                       \
                    for (int k = 0; k < TD; k++) {                                                 \
                        const double a = (double)out[(v * nt + i) * TD + k];                       \
                        const double b = (double)ref[(v * ns + tid[i] / step) * TD + k];           \
                        e2 += (a - b) * (a - b), r2 += b * b;                                      \
                    }                                                                              \
        if (!all) return r2 > 0.0 ? sqrt(e2 / r2) : sqrt(e2);                                      \
        return global_rel(e2, r2);                                                                 \
    }                                                                                              \
    /* direct sums of nv vectors at the sample of the NT targets y */                              \
    static R *P##_ref(const kifmm_opts *o, int64_t N, const R *x, const R *q, int64_t NT,         \
                      const R *y, int nv)                                                          \
    {                                                                                              \
        const int64_t step = NT / NSAMPLE > 0 ? NT / NSAMPLE : 1, ns = (NT + step - 1) / step;     \
        R *ys = (R *)t_malloc_or_die((size_t)(3 * ns + 1) * sizeof(R));                            \
        R *ref = (R *)t_malloc_or_die((size_t)(nv * ns * TD + 1) * sizeof(R));                     \
        for (int64_t j = 0; j < ns; j++)                                                           \
            for (int d = 0; d < 3; d++) ys[3 * j + d] = y[3 * j * step + d];                        \
        for (int v = 0; v < nv; v++)                                                               \
            if (P##_direct(o, N, x, q + (size_t)v * N * SD, ns, ys, ref + (size_t)v * ns * TD))    \
                CHECK(0, "direct sums failed");                                                    \
        free(ys);                                                                                  \
        return ref;                                                                                \
    }                                                                                              \
    /* this rank's values of the points ids (dim each, vector-major over nv) */                   \
    static R *P##_pick(const R *a, int64_t n, int dim, int nv, int64_t N, const int64_t *ids)     \
    {                                                                                              \
        R *b = (R *)t_malloc_or_die((size_t)(n * dim * nv + 1) * sizeof(R));                       \
        for (int v = 0; v < nv; v++)                                                               \
            for (int64_t i = 0; i < n; i++)                                                        \
                for (int k = 0; k < dim; k++)                                                      \
                    b[(v * n + i) * dim + k] = a[((size_t)v * N + ids[i]) * dim + k];              \
        return b;                                                                                  \
    }                                                                                              \
    T_MPI_UPDATE(P, R, SD, TD)                                                                     \
    T_MPI_RUN(P, R, SD, TD)


T_MPI_CASE(kifmm_laplace_grad, double, 1, 4)
T_MPI_CASE(kifmm_laplacef, float, 1, 1)
T_MPI_CASE(kifmm_yukawa_grad, double, 1, 4)
T_MPI_CASE(kifmm_stokes, double, 3, 3)


/* Errors met on one rank (the last) only: every rank returns one, no
 * handle, nothing written; the handle is kept after a failed update. */
static void errors(void)
{
    const int64_t N = 3000, last = g_size - 1;
    double *gx = gen_points(0, 3, N), *gq = t_densities(4, N, 1, 2, 0);
    int64_t *sid, ns = share(N, 0, 5, &sid), i;
    double *x = t_doubles(3 * ns + 3), *q = t_doubles(2 * ns + 2), *out = t_doubles(8 * ns + 8);
    double *keep = t_doubles(8 * ns + 8), nan = NAN;
    kifmm_laplace_grad *h = (kifmm_laplace_grad *)&nan, *g = NULL;
    kifmm_laplace_dipole_grad *hd = (kifmm_laplace_dipole_grad *)&nan;
    kifmm_opts o = t_opts(4, 0, 0);
    int rc;
    for (i = 0; i < ns; i++) {
        memcpy(x + 3 * i, gx + 3 * sid[i], 3 * sizeof(double));
        q[i] = gq[sid[i]], q[ns + i] = gq[N + sid[i]];
    }
    if (g_rank == last && ns > 0) x[1] = NAN;
    rc = kifmm_laplace_grad_create_mpi(&h, MPI_COMM_WORLD, &o, ns, x, ns, x);
    CHECK(all_ranks(rc == KIFMM_ERR_NONFINITE && h == NULL), "NaN point: %s", kifmm_strerror(rc));
    if (g_rank == last && ns > 0) x[1] = gx[3 * sid[0] + 1];
    o.period[0] = o.period[1] = o.period[2] = 2.0;
    rc = kifmm_laplace_grad_create_mpi(&h, MPI_COMM_WORLD, &o, ns, x, ns, x);
    CHECK(all_ranks(rc == KIFMM_ERR_PERIODIC && h == NULL), "periodic: %s", kifmm_strerror(rc));
    o.period[0] = o.period[1] = o.period[2] = 0.0;
    rc = kifmm_laplace_dipole_grad_create_mpi(&hd, MPI_COMM_WORLD, &o, ns, x, ns, x);
    CHECK(all_ranks(rc == KIFMM_ERR_MPI && hd == NULL), "no MPI mode yet: %s", kifmm_strerror(rc));
    rc = kifmm_laplace_grad_create_mpi(g_rank == last ? NULL : &h, MPI_COMM_WORLD, &o, ns, x, ns, x);
    CHECK(all_ranks(rc == KIFMM_ERR_NULL && (g_rank == last || h == NULL)), "NULL out: %s", kifmm_strerror(rc));
    rc = kifmm_laplace_grad_create_mpi(&h, MPI_COMM_WORLD, &o, ns, x, ns, x);
    if (!rc) rc = kifmm_laplace_grad_evaluate(h, q, keep);
    CHECK(all_ranks(rc == KIFMM_SUCCESS), "create_mpi: %s", kifmm_strerror(rc));
    if (rc) return;
    t_fill(8 * ns, out, 7.0);
    if (g_rank == last && ns > 0) q[0] = INFINITY;
    rc = kifmm_laplace_grad_evaluate(h, q, out);
    CHECK(all_ranks(rc == KIFMM_ERR_DENSITY && t_max_abs(4 * ns, out) == (ns ? 7.0 : 0.0)),
          "an infinite density: %s", kifmm_strerror(rc));
    if (g_rank == last && ns > 0) q[0] = gq[sid[0]];
    if (g_size > 1) {
        rc = kifmm_laplace_grad_evaluate_many(h, g_rank == 0 ? 2 : 1, q, out);
        CHECK(all_ranks(rc == KIFMM_ERR_MPI && t_max_abs(4 * ns, out) == (ns ? 7.0 : 0.0)),
              "counts of vectors that differ: %s", kifmm_strerror(rc));
    }
    rc = kifmm_laplace_grad_evaluate(h, q, g_rank == last && ns > 0 ? NULL : out);
    CHECK(all_ranks(rc == KIFMM_ERR_NULL), "NULL outputs: %s", kifmm_strerror(rc));
    if (g_rank == 0 && ns > 0) x[3] = -NAN;
    rc = kifmm_laplace_grad_update_points(h, ns, x, ns, x);
    CHECK(all_ranks(rc == KIFMM_ERR_NONFINITE), "update_points, a NaN point: %s", kifmm_strerror(rc));
    rc = kifmm_laplace_grad_evaluate(h, q, out);
    CHECK(all_ranks(rc == KIFMM_SUCCESS && !memcmp(out, keep, 4 * (size_t)ns * sizeof(double))),
          "the handle as it was: %s", kifmm_strerror(rc));
    rc = kifmm_laplace_grad_evaluate_many(h, 0, NULL, NULL);
    CHECK(all_ranks(rc == KIFMM_SUCCESS), "no vectors: %s", kifmm_strerror(rc));
    CHECK(kifmm_laplace_grad_tree(h) == NULL && kifmm_laplace_grad_create_on_tree(&g, &o, NULL) == KIFMM_ERR_NULL &&
              kifmm_laplace_grad_update_on_tree(h, (kifmm_tree *)&nan) == KIFMM_ERR_TREE,
          "no tree to share");
    kifmm_laplace_grad_destroy(h);
    free(gx), free(gq), free(sid), free(x), free(q), free(out), free(keep);
}

/* An allocation that fails on the last rank only, at each of create_mpi's,
 * evaluate's and update_points's allocations in turn (every one with
 * KIFMM_TEST_ALLOC_ALL set, as tests/mpi.sh sets it for one run; else about
 * 50 of them):
 * every rank returns an error together (none is left waiting in a
 * collective call), KIFMM_ERR_NOMEM on the last rank, no handle, nothing
 * leaked (or every rank succeeds, where the library had another way); a
 * failed evaluate or update leaves the handle working. */
static void alloc_failures(void)
{
    const int64_t N = 600, last = g_size - 1;
    double *gx = gen_points(2, 17, N), *gq = t_densities(18, N, 1, 1, 0);
    int64_t *sid, ns = share(N, 0, 19, &sid), i;
    double *x = t_doubles(3 * ns + 3), *q = t_doubles(ns + 1), *out = t_doubles(4 * ns + 4);
    double *keep = t_doubles(4 * ns + 4);
    kifmm_opts o = t_opts(4, 16, 0);
    long total[3] = {0, 0, 0}, k, stride;
    int bad[3] = {0, 0, 0}, stage, rc, injected;
    static const char *what[3] = {"create_mpi", "evaluate", "update_points"};
    for (i = 0; i < ns; i++) memcpy(x + 3 * i, gx + 3 * sid[i], 3 * sizeof(double)), q[i] = gq[sid[i]];
    for (stage = 0; stage < 3; stage++) {
        kifmm_laplace_grad *h = NULL;
        /* the count of the stage's allocations on this rank, without failures */
        if (stage > 0) {
            rc = kifmm_laplace_grad_create_mpi(&h, MPI_COMM_WORLD, &o, ns, x, ns, x);
            if (!rc) rc = kifmm_laplace_grad_evaluate(h, q, keep);
        }
        alloc_calls = 0;
        rc = stage == 0 ? kifmm_laplace_grad_create_mpi(&h, MPI_COMM_WORLD, &o, ns, x, ns, x)
             : stage == 1 ? kifmm_laplace_grad_evaluate(h, q, out)
                          : kifmm_laplace_grad_update_points(h, ns, x, ns, x);
        total[stage] = alloc_calls;
        CHECK(all_ranks(rc == KIFMM_SUCCESS), "stage %d: %s", stage, kifmm_strerror(rc));
        MPI_Allreduce(MPI_IN_PLACE, &total[stage], 1, MPI_LONG, MPI_MAX, MPI_COMM_WORLD);
        stride = getenv("KIFMM_TEST_ALLOC_ALL") ? 1 : total[stage] / 50 + 1;
        for (k = 0; k < total[stage]; k += stride) {
            kifmm_laplace_grad *g = NULL;
            alloc_calls = 0;
            fail_at = g_rank == last ? k : -1;
            rc = stage == 0 ? kifmm_laplace_grad_create_mpi(&g, MPI_COMM_WORLD, &o, ns, x, ns, x)
                 : stage == 1 ? kifmm_laplace_grad_evaluate(h, q, out)
                              : kifmm_laplace_grad_update_points(h, ns, x, ns, x);
            fail_at = -1;
            injected = g_rank == last && alloc_calls > k; /* the last rank made k + 1 or more */
            MPI_Bcast(&injected, 1, MPI_INT, (int)last, MPI_COMM_WORLD);
            /* an injected failure gives KIFMM_ERR_NOMEM there (or success where
             * the library has another way, e.g. spectra built per task) */
            if (!injected) bad[stage] |= rc != KIFMM_SUCCESS;
            else bad[stage] |= g_rank == last && rc != KIFMM_ERR_NOMEM && rc != KIFMM_SUCCESS;
            bad[stage] |= !all_ranks(rc == KIFMM_SUCCESS) && all_ranks(rc != KIFMM_SUCCESS) == 0;
            bad[stage] |= stage == 0 && rc != KIFMM_SUCCESS && g != NULL;
            kifmm_laplace_grad_destroy(g);
            if (stage > 0) { /* the handle still works, with its outputs */
                rc = kifmm_laplace_grad_evaluate(h, q, out);
                bad[stage] |= rc != KIFMM_SUCCESS || memcmp(out, keep, 4 * (size_t)ns * sizeof(double));
            }
        }
        kifmm_laplace_grad_destroy(h);
        k = all_ranks(!bad[stage]);
        CHECK(k, "%s: an allocation failing on the last rank", what[stage]);
        if (g_rank == 0)
            printf("  %-4s %s: an allocation failing on rank %lld, at %ld of the %ld allocations\n",
                   k ? "ok" : "FAIL", what[stage], (long long)last, (total[stage] + stride - 1) / stride,
                   total[stage]);
    }
    free(gx), free(gq), free(sid), free(x), free(q), free(out), free(keep);
}

int main(int argc, char **argv)
{
    MPI_Init(&argc, &argv);
    MPI_Comm_rank(MPI_COMM_WORLD, &g_rank);
    MPI_Comm_size(MPI_COMM_WORLD, &g_size);
    group("laplace_grad, p = 6");
    for (int kind = 0; kind < 3; kind++)
        for (int mode = 0; mode < 2; mode++) {
            run_kifmm_laplace_grad(kind, mode, 0, 20000, 1, 6, 3e-5);
            run_kifmm_laplace_grad(kind, mode, 8000, 12000, 1, 6, 3e-5);
        }
    group("laplace_grad, p = 8, three vectors");
    run_kifmm_laplace_grad(2, 0, 0, 20000, 3, 8, 2e-6);
    group("laplace (float)");
    run_kifmm_laplacef(0, 0, 0, 20000, 1, 4, 1e-3);
    run_kifmm_laplacef(2, 0, 5000, 15000, 1, 6, 1e-4);
    group("yukawa_grad");
    run_kifmm_yukawa_grad(1, 0, 0, 15000, 1, 6, 3e-5);
    run_kifmm_yukawa_grad(2, 1, 6000, 10000, 1, 6, 3e-5);
    group("stokes");
    run_kifmm_stokes(0, 0, 0, 12000, 1, 6, 3e-5);
    run_kifmm_stokes(2, 0, 5000, 10000, 2, 6, 3e-5);
    group("a few points on many ranks");
    run_kifmm_laplace_grad(0, 0, 0, 3, 1, 6, 1e-12);
    run_kifmm_laplace_grad(2, 0, 2, 5, 1, 6, 1e-12);
    group("errors on one rank");
    errors();
    group("allocation failures on one rank");
    alloc_failures();
    CHECK(live_blocks == 0, "%ld blocks of the library not freed", live_blocks);
    {
        long c[2] = {t_counters()[0], t_counters()[1]};
        MPI_Allreduce(MPI_IN_PLACE, c, 2, MPI_LONG, MPI_SUM, MPI_COMM_WORLD);
        t_counters()[0] = c[0], t_counters()[1] = c[1];
    }
    int rc = g_rank == 0 ? t_finish() : t_counters()[1] != 0;
    MPI_Finalize();
    return rc;
}
