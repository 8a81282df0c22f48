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
#define KIFMM_KERNEL laplace_cd_grad
#include "kifmm.h"
#define KIFMM_KERNEL yukawa_cd
#include "kifmm.h"
#define KIFMM_KERNEL stokes_pvel
#include "kifmm.h"
#define KIFMM_KERNEL biot_savart
#include "kifmm.h"
#define KIFMM_KERNEL stokes_dl
#include "kifmm.h"
#define KIFMM_KERNEL helmholtz_grad
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

/* One instance behind type-erased calls in double (float instances get
 * rounded copies and give their outputs widened, exactly); the same array
 * twice when the sources are the targets, as a caller would pass it. */
typedef struct {
    const char *name;
    int sd, td;
    int (*create_mpi)(void **h, const kifmm_opts *o, int64_t ns, const double *s, int64_t nt,
                      const double *t);
    int (*create)(void **h, const kifmm_opts *o, int64_t ns, const double *s, int64_t nt,
                  const double *t);
    int (*update)(void *h, int64_t ns, const double *s, int64_t nt, const double *t);
    int (*evaluate)(void *h, int nv, int64_t ns, const double *q, int64_t nt, double *out);
    int (*direct)(const kifmm_opts *o, int64_t ns, const double *s, const double *q, int64_t nt,
                  const double *t, double *out);
    int (*stats)(const void *h, kifmm_stats *st);
    void (*destroy)(void *h);
} m_api;

/* n values of a in the instance's type R */
#define T_MPI_CONV(R, a, n) conv_##R(a, n)
static float *conv_float(const double *a, int64_t n)
{
    float *b = (float *)t_malloc_or_die((size_t)(n + 1) * sizeof(float));
    for (int64_t i = 0; i < n; i++) b[i] = (float)a[i];
    b[n] = 0.0f; /* (g++ 12 took n = 0 for a read of uninitialised memory) */
    return b;
}
static double *conv_double(const double *a, int64_t n)
{
    double *b = (double *)t_malloc_or_die((size_t)(n + 1) * sizeof(double));
    for (int64_t i = 0; i < n; i++) b[i] = a[i];
    b[n] = 0.0;
    return b;
}

/* the calls with points: create_mpi, create or update_points (call) */
#define T_MPI_POINTS(P, R, name, call, ...)                                                        \
    static int P##_m_##name(__VA_ARGS__, int64_t ns, const double *s, int64_t nt, const double *t) \
    {                                                                                              \
        R *a = T_MPI_CONV(R, s, 3 * ns), *b = s == t && ns == nt ? a : T_MPI_CONV(R, t, 3 * nt);    \
        int rc = call;                                                                             \
        free(a);                                                                                   \
        if (b != a) free(b);                                                                       \
        return rc;                                                                                 \
    }

#define T_MPI_API(P, R, SD, TD)                                                                    \
    T_MPI_POINTS(P, R, create_mpi, P##_create_mpi((P **)h, MPI_COMM_WORLD, o, ns, a, nt, b),       \
                 void **h, const kifmm_opts *o)                                                    \
    T_MPI_POINTS(P, R, create, P##_create((P **)h, o, ns, a, nt, b), void **h, const kifmm_opts *o) \
    T_MPI_POINTS(P, R, update, P##_update_points((P *)h, ns, a, nt, b), void *h)                  \
    static int P##_m_evaluate(void *h, int nv, int64_t ns, const double *q, int64_t nt, double *o) \
    {                                                                                              \
        R *a = T_MPI_CONV(R, q, nv * ns * (SD));                                                   \
        R *b = (R *)t_malloc_or_die((size_t)(nv * nt * (TD) + 1) * sizeof(R));                      \
        int rc = P##_evaluate_many((P *)h, nv, a, b);                                              \
        for (int64_t i = 0; i < nv * nt * (TD); i++) o[i] = (double)b[i];                          \
        free(a), free(b);                                                                          \
        return rc;                                                                                 \
    }                                                                                              \
    static int P##_m_direct(const kifmm_opts *o, int64_t ns, const double *s, const double *q,     \
                            int64_t nt, const double *t, double *out)                              \
    {                                                                                              \
        R *a = T_MPI_CONV(R, s, 3 * ns), *b = T_MPI_CONV(R, q, ns * (SD));                          \
        R *c = T_MPI_CONV(R, t, 3 * nt), *d = (R *)t_malloc_or_die((size_t)(nt * (TD) + 1) * sizeof(R)); \
        int rc = P##_direct(o, ns, a, b, nt, c, d);                                                \
        for (int64_t i = 0; i < nt * (TD); i++) out[i] = (double)d[i];                             \
        free(a), free(b), free(c), free(d);                                                        \
        return rc;                                                                                 \
    }                                                                                              \
    static int P##_m_stats(const void *h, kifmm_stats *st) { return P##_stats((const P *)h, st); } \
    static void P##_m_destroy(void *h) { P##_destroy((P *)h); }                                    \
    static const m_api P##_m = {#P, SD, TD, P##_m_create_mpi, P##_m_create, P##_m_update,          \
                                P##_m_evaluate, P##_m_direct, P##_m_stats, P##_m_destroy};

T_MPI_API(kifmm_laplace_grad, double, 1, 4)
T_MPI_API(kifmm_laplacef, float, 1, 1)
T_MPI_API(kifmm_yukawa_grad, double, 1, 4)
T_MPI_API(kifmm_stokes, double, 3, 3)
T_MPI_API(kifmm_laplace_dipole_grad, double, 3, 4)
T_MPI_API(kifmm_laplace_cd_grad, double, 4, 4)
T_MPI_API(kifmm_yukawa_cd, double, 4, 1)
T_MPI_API(kifmm_stokes_pvel, double, 3, 4)
T_MPI_API(kifmm_biot_savart, double, 3, 3)
T_MPI_API(kifmm_stokes_dl, double, 6, 3)
T_MPI_API(kifmm_helmholtz_grad, double, 2, 8)

/* the kernel parameters of run_case (0: each kernel's defaults) */
static double g_kparam[2], g_tol; /* g_tol: opts.tol, with the unit cube as opts.domain */

/* the global sample: every step-th of the NT targets */
static int64_t sample_step(int64_t NT) { return NT / NSAMPLE > 0 ? NT / NSAMPLE : 1; }

/* direct sums of nv vectors at the sample of the NT targets y */
static double *direct_ref(const m_api *a, const kifmm_opts *o, int64_t N, const double *x,
                          const double *q, int64_t NT, const double *y, int nv)
{
    const int64_t step = sample_step(NT), ns = (NT + step - 1) / step;
    double *ys = t_doubles(3 * ns + 3), *ref = t_doubles(nv * ns * a->td + 1);
    for (int64_t j = 0; j < ns; j++) memcpy(ys + 3 * j, y + 3 * j * step, 3 * sizeof(double));
    for (int v = 0; v < nv; v++)
        if (a->direct(o, N, x, q + (size_t)v * N * a->sd, ns, ys, ref + (size_t)v * ns * a->td))
            CHECK(0, "%s: direct sums failed", a->name);
    free(ys);
    return ref;
}

/* The relative L2 error of out (nt targets, global ids tid) at the sample,
 * against ref (direct_ref's): over every rank's (all) or this one's. */
static double sample_err(const m_api *a, int64_t nt, const int64_t *tid, const double *out, int nv,
                         int64_t NT, const double *ref, int all)
{
    const int64_t step = sample_step(NT), ns = (NT + step - 1) / step;
    double e2 = 0.0, r2 = 0.0;
    for (int64_t i = 0; i < nt; i++)
        if (tid[i] % step == 0)
            for (int v = 0; v < nv; v++)
                for (int k = 0; k < a->td; k++) {
                    const double u = out[(v * nt + i) * a->td + k], w = ref[(v * ns + tid[i] / step) * a->td + k];
                    e2 += (u - w) * (u - w), r2 += w * w;
                }
    if (!all) return r2 > 0.0 ? sqrt(e2 / r2) : sqrt(e2);
    return global_rel(e2, r2);
}

/* this rank's values of the points ids (dim each, vector-major over nv) */
static double *pick(const double *v, int64_t n, int dim, int nv, int64_t N, const int64_t *ids)
{
    double *b = t_doubles(n * dim * nv + 1);
    for (int k = 0; k < nv; k++)
        for (int64_t i = 0; i < n; i++)
            memcpy(b + (k * n + i) * dim, v + ((size_t)k * N + ids[i]) * dim, dim * sizeof(double));
    return b;
}

/* A global problem (points of a kind, N sources, NT separate targets or the
 * sources when NT == 0, nv vectors) and this rank's share of it. */
typedef struct {
    int same, nv;
    int64_t N, NT, ns, nt, *sid, *tid;
    double *X, *Y, *Q, *x, *y, *q, *out;
} m_case;

static m_case case_make(const m_api *a, int kind, int mode, int64_t NT, int64_t N, int nv,
                        uint64_t seed)
{
    m_case c;
    c.same = NT == 0, c.nv = nv, c.N = N, c.NT = c.same ? N : NT;
    c.X = gen_points(kind, seed + (uint64_t)kind, N);
    c.Y = c.same ? c.X : gen_points(kind == 1 ? 0 : kind, seed + 12 + (uint64_t)kind, NT);
    c.Q = t_densities(seed + 5, N, a->sd, nv, 0);
    c.ns = share(N, mode, seed, &c.sid);
    c.nt = c.same ? c.ns : share(NT, mode, seed + 1, &c.tid);
    if (c.same) c.tid = c.sid;
    c.x = pick(c.X, c.ns, 3, 1, N, c.sid), c.q = pick(c.Q, c.ns, a->sd, nv, N, c.sid);
    c.y = c.same ? c.x : pick(c.Y, c.nt, 3, 1, NT, c.tid);
    c.out = t_doubles(nv * c.nt * a->td + 1);
    return c;
}

static void case_free(m_case *c)
{
    free(c->X), free(c->Q), free(c->x), free(c->q), free(c->out), free(c->sid);
    if (!c->same) free(c->Y), free(c->y), free(c->tid);
}

/* update_points onto another set (other points, another handout): equal,
 * bit for bit, to a new create_mpi there, and within bound of the sums */
static void update_case(const m_api *a, void *h, const kifmm_opts *o, int kind, int mode, int64_t NT,
                        int64_t N, int nv, double bound)
{
    m_case c = case_make(a, kind, mode, NT, N, nv, 101);
    double *out2 = t_doubles(nv * c.nt * a->td + 1), *ref, err;
    void *h2 = NULL;
    int rc = a->update(h, c.ns, c.x, c.nt, c.y);
    if (!rc) rc = a->evaluate(h, nv, c.ns, c.q, c.nt, c.out);
    CHECK(rc == KIFMM_SUCCESS, "%s update_points: %s", a->name, kifmm_strerror(rc));
    rc = a->create_mpi(&h2, o, c.ns, c.x, c.nt, c.y);
    if (!rc) rc = a->evaluate(h2, nv, c.ns, c.q, c.nt, out2);
    CHECK(rc == KIFMM_SUCCESS, "%s create_mpi: %s", a->name, kifmm_strerror(rc));
    CHECK(all_ranks(!memcmp(c.out, out2, (size_t)nv * c.nt * a->td * sizeof(double))),
          "%s: update_points != create_mpi", a->name);
    ref = direct_ref(a, o, N, c.X, c.Q, c.NT, c.Y, nv);
    err = sample_err(a, c.nt, c.tid, c.out, nv, c.NT, ref, 1);
    if (g_rank == 0) CHECK_ERR(err, bound, "  after update_points");
    a->destroy(h2);
    free(out2), free(ref);
    case_free(&c);
}

/* One process's error on the whole problem, at the sample (rank 0), and
 * with one rank its outputs equal to the MPI handle's bit for bit. */
static double one_process(const m_api *a, const kifmm_opts *o, const m_case *c, const double *ref)
{
    int64_t *all = (int64_t *)t_malloc_or_die((size_t)(c->NT + 1) * sizeof(int64_t));
    double *o1 = t_doubles(c->nv * c->NT * a->td + 1), e1;
    void *s = NULL;
    int rc;
    for (int64_t i = 0; i < c->NT; i++) all[i] = i;
    rc = a->create(&s, o, c->N, c->X, c->NT, c->Y);
    if (!rc) rc = a->evaluate(s, c->nv, c->N, c->Q, c->NT, o1);
    CHECK(rc == KIFMM_SUCCESS, "%s one process: %s", a->name, kifmm_strerror(rc));
    e1 = sample_err(a, c->NT, all, o1, c->nv, c->NT, ref, 0);
    if (g_size == 1)
        CHECK(!memcmp(c->out, o1, (size_t)c->nv * c->NT * a->td * sizeof(double)), "%s: 1 rank != create",
              a->name);
    a->destroy(s);
    free(all), free(o1);
    return e1;
}

/* One case: the error against direct sums at the global sample, against
 * bound and against 3 times one process's error; the owned counts; then
 * update_points (update_case). */
static void run_case(const m_api *a, int kind, int mode, int64_t NT, int64_t N, int nv, int order,
                     double bound)
{
    kifmm_opts o = t_opts(order, 0, 0);
    m_case c = case_make(a, kind, mode, NT, N, nv, 11);
    double *ref, err, e1 = 0.0;
    int64_t cnt[2];
    kifmm_stats st;
    void *h = NULL;
    int rc;
    o.kernel_param[0] = g_kparam[0], o.kernel_param[1] = g_kparam[1];
    if (g_tol > 0.0) o.order = 0, o.tol = g_tol, o.domain[0] = o.domain[1] = o.domain[2] = o.domain[3] = 0.5;
    rc = a->create_mpi(&h, &o, c.ns, c.x, c.nt, c.y);
    CHECK(rc == KIFMM_SUCCESS, "%s create_mpi: %s", a->name, kifmm_strerror(rc));
    if (rc) return;
    rc = a->evaluate(h, nv, c.ns, c.q, c.nt, c.out);
    CHECK(rc == KIFMM_SUCCESS, "%s evaluate: %s", a->name, kifmm_strerror(rc));
    ref = direct_ref(a, &o, N, c.X, c.Q, c.NT, c.Y, nv);
    err = sample_err(a, c.nt, c.tid, c.out, nv, c.NT, ref, 1);
    if (g_rank == 0) e1 = one_process(a, &o, &c, ref);
    MPI_Bcast(&e1, 1, MPI_DOUBLE, 0, MPI_COMM_WORLD);
    if (g_rank == 0) {
        CHECK_ERR(err, bound, "%s %s %s%s, %lld, %d ranks, p = %d", a->name, kind_name[kind], mode_name[mode],
                  c.same ? "" : ", targets apart", (long long)N, g_size, order);
        CHECK_ERR(err, 3.0 * e1 + 1e-13, "  and against 3 x one process's %.2e", e1);
    }
    memset(&st, 0, sizeof st);
    CHECK(a->stats(h, &st) == KIFMM_SUCCESS && st.mpi_ranks == g_size, "%s stats", a->name);
    cnt[0] = st.mpi_sources, cnt[1] = st.mpi_targets;
    MPI_Allreduce(MPI_IN_PLACE, cnt, 2, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
    CHECK(cnt[0] == N && cnt[1] == c.NT, "%s: owned %lld %lld", a->name, (long long)cnt[0], (long long)cnt[1]);
    update_case(a, h, &o, kind, mode, NT, N, nv, bound);
    a->destroy(h);
    free(ref);
    case_free(&c);
}

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
    if (g_rank == 0 && ns > 1) x[3] = -NAN;
    rc = kifmm_laplace_grad_update_points(h, ns, x, ns, x);
    CHECK(all_ranks(rc == KIFMM_ERR_NONFINITE), "update_points, a NaN point: %s", kifmm_strerror(rc));
    if (g_rank == 0 && ns > 1) x[3] = gx[3 * sid[1]];
    rc = kifmm_laplace_grad_evaluate(h, q, out);
    CHECK(all_ranks(rc == KIFMM_SUCCESS && !memcmp(out, keep, 4 * (size_t)ns * sizeof(double))),
          "the handle as it was: %s", kifmm_strerror(rc));
    rc = kifmm_laplace_grad_evaluate_many(h, 0, NULL, NULL);
    CHECK(all_ranks(rc == KIFMM_SUCCESS), "no vectors: %s", kifmm_strerror(rc));
    { /* the options as given, resolved; the memory: the handles, their plan, the layer */
        kifmm_opts u, c;
        kifmm_stats st;
        kifmm_laplace_grad *one = NULL;
        memset(&st, 0, sizeof st);
        rc = kifmm_laplace_grad_create(&one, &o, ns, x, ns, x);
        if (!rc) rc = kifmm_laplace_grad_options(one, &c);
        if (!rc) rc = kifmm_laplace_grad_options(h, &u);
        if (!rc) rc = kifmm_laplace_grad_stats(h, &st);
        CHECK(all_ranks(rc == KIFMM_SUCCESS && !memcmp(&u, &c, sizeof u)), "options: %s", kifmm_strerror(rc));
        CHECK(all_ranks(st.plan_bytes > 0 && st.tree_bytes > 0 && st.bytes >= st.plan_bytes + st.tree_bytes),
              "bytes %.0f, plan %.0f, tree %.0f", st.bytes, st.plan_bytes, st.tree_bytes);
        kifmm_laplace_grad_destroy(one);
    }
    CHECK(kifmm_laplace_grad_tree(h) == NULL && kifmm_laplace_grad_create_on_tree(&g, &o, NULL) == KIFMM_ERR_NULL &&
              kifmm_laplace_grad_update_on_tree(h, (kifmm_tree *)&nan) == KIFMM_ERR_TREE,
          "no tree to share");
    kifmm_laplace_grad_destroy(h);
    free(gx), free(gq), free(sid), free(x), free(q), free(out), free(keep);
}

/* An allocation that fails on the last rank only, at each of create_mpi's,
 * evaluate's and update_points's allocations in turn (every = 1: every one
 * with KIFMM_TEST_ALLOC_ALL set, as tests/mpi.sh sets it for one run, else
 * about 50 of them; 2: about 50; 0: about 12):
 * every rank returns an error together (none is left waiting in a
 * collective call), KIFMM_ERR_NOMEM on the last rank, no handle, nothing
 * leaked (or every rank succeeds, where the library had another way); a
 * failed evaluate or update leaves the handle working. */
static void alloc_failures(const m_api *a, int every)
{
    const int64_t N = 600, last = g_size - 1;
    double *gx = gen_points(2, 17, N), *gq = t_densities(18, N, a->sd, 1, 0);
    int64_t *sid, ns = share(N, 0, 19, &sid), i;
    double *x = t_doubles(3 * ns + 3), *q = t_doubles(a->sd * ns + 1), *out = t_doubles(a->td * ns + 4);
    double *keep = t_doubles(a->td * ns + 4);
    kifmm_opts o = t_opts(4, 16, 0);
    long total[3] = {0, 0, 0}, k, stride;
    int bad[3] = {0, 0, 0}, stage, rc, injected;
    static const char *what[3] = {"create_mpi", "evaluate", "update_points"};
    for (i = 0; i < ns; i++) {
        memcpy(x + 3 * i, gx + 3 * sid[i], 3 * sizeof(double));
        memcpy(q + a->sd * i, gq + a->sd * sid[i], a->sd * sizeof(double));
    }
    for (stage = 0; stage < 3; stage++) {
        void *h = NULL;
        /* the count of the stage's allocations on this rank, without failures */
        if (stage > 0) {
            rc = a->create_mpi(&h, &o, ns, x, ns, x);
            if (!rc) rc = a->evaluate(h, 1, ns, q, ns, keep);
        }
        alloc_calls = 0;
        rc = stage == 0 ? a->create_mpi(&h, &o, ns, x, ns, x)
             : stage == 1 ? a->evaluate(h, 1, ns, q, ns, out)
                          : a->update(h, ns, x, ns, x);
        total[stage] = alloc_calls;
        CHECK(all_ranks(rc == KIFMM_SUCCESS), "stage %d: %s", stage, kifmm_strerror(rc));
        MPI_Allreduce(MPI_IN_PLACE, &total[stage], 1, MPI_LONG, MPI_MAX, MPI_COMM_WORLD);
        stride = every == 1 && getenv("KIFMM_TEST_ALLOC_ALL") ? 1 : total[stage] / (every ? 50 : 12) + 1;
        for (k = 0; k < total[stage]; k += stride) {
            void *g = NULL;
            alloc_calls = 0;
            fail_at = g_rank == last ? k : -1;
            rc = stage == 0 ? a->create_mpi(&g, &o, ns, x, ns, x)
                 : stage == 1 ? a->evaluate(h, 1, ns, q, ns, out)
                              : a->update(h, ns, x, ns, x);
            fail_at = -1;
            injected = g_rank == last && alloc_calls > k; /* the last rank made k + 1 or more */
            MPI_Bcast(&injected, 1, MPI_INT, (int)last, MPI_COMM_WORLD);
            /* an injected failure gives KIFMM_ERR_NOMEM there (or success where
             * the library has another way, e.g. spectra built per task) */
            if (!injected) bad[stage] |= rc != KIFMM_SUCCESS;
            else bad[stage] |= g_rank == last && rc != KIFMM_ERR_NOMEM && rc != KIFMM_SUCCESS;
            bad[stage] |= !all_ranks(rc == KIFMM_SUCCESS) && all_ranks(rc != KIFMM_SUCCESS) == 0;
            bad[stage] |= stage == 0 && rc != KIFMM_SUCCESS && g != NULL;
            if (g) a->destroy(g);
            if (stage > 0) { /* the handle still works, with its outputs */
                rc = a->evaluate(h, 1, ns, q, ns, out);
                bad[stage] |= rc != KIFMM_SUCCESS || memcmp(out, keep, a->td * (size_t)ns * sizeof(double));
            }
        }
        if (h) a->destroy(h);
        k = all_ranks(!bad[stage]);
        CHECK(k, "%s %s: an allocation failing on the last rank", a->name, what[stage]);
        if (g_rank == 0)
            printf("  %-4s %s %s: an allocation failing on rank %lld, at %ld of the %ld allocations\n",
                   k ? "ok" : "FAIL", a->name, what[stage], (long long)last, (total[stage] + stride - 1) / stride,
                   total[stage]);
    }
    free(gx), free(gq), free(sid), free(x), free(q), free(out), free(keep);
}

int main(int argc, char **argv)
{
    int light;
    MPI_Init(&argc, &argv);
    MPI_Comm_rank(MPI_COMM_WORLD, &g_rank);
    MPI_Comm_size(MPI_COMM_WORLD, &g_size);
    group("laplace_grad, p = 6");
    for (int kind = 0; kind < 3; kind++)
        for (int mode = 0; mode < 2; mode++) {
            run_case(&kifmm_laplace_grad_m, kind, mode, 0, 20000, 1, 6, 3e-5);
            run_case(&kifmm_laplace_grad_m, kind, mode, 8000, 12000, 1, 6, 3e-5);
        }
    /* KIFMM_TEST_MPI_LIGHT (tests/mpi.sh but with CONFIGS=all: the 1-, 3- and 4-rank,
     * sanitizer and C++ runs): the first group, one
     * kernel with fitted proxies, the errors */
    light = getenv("KIFMM_TEST_MPI_LIGHT") && *getenv("KIFMM_TEST_MPI_LIGHT");
    if (!light) {
        group("laplace_grad, p = 8, three vectors");
        run_case(&kifmm_laplace_grad_m, 2, 0, 0, 20000, 3, 8, 2e-6);
        group("laplace (float)");
        run_case(&kifmm_laplacef_m, 0, 0, 0, 20000, 1, 4, 1e-3);
        run_case(&kifmm_laplacef_m, 2, 0, 5000, 15000, 1, 6, 1e-4);
        group("yukawa_grad");
        run_case(&kifmm_yukawa_grad_m, 1, 0, 0, 15000, 1, 6, 3e-5);
        run_case(&kifmm_yukawa_grad_m, 2, 1, 6000, 10000, 1, 6, 3e-5);
        group("stokes");
        run_case(&kifmm_stokes_m, 0, 0, 0, 12000, 1, 6, 3e-5);
        run_case(&kifmm_stokes_m, 2, 0, 5000, 10000, 2, 6, 3e-5);
    }
    /* (one rank: the handle is create's, whatever the kernel; the laplace
     * cases above check it) */
    if (g_size > 1) {
        group("kernels whose sources are not their surfaces' (proxies fitted or picked)");
        run_case(&kifmm_laplace_dipole_grad_m, 2, 0, 0, 12000, 1, 6, 3e-5);
        if (!light) {
            run_case(&kifmm_laplace_dipole_grad_m, 0, 0, 5000, 8000, 1, 6, 3e-5);
            run_case(&kifmm_laplace_cd_grad_m, 1, 0, 0, 12000, 1, 6, 3e-5);
            run_case(&kifmm_yukawa_cd_m, 2, 0, 0, 10000, 1, 6, 3e-5);
            run_case(&kifmm_stokes_pvel_m, 0, 0, 0, 10000, 1, 6, 3e-5);
            run_case(&kifmm_biot_savart_m, 2, 0, 0, 10000, 1, 6, 3e-5);
        }
        group("a kernel with a density map (proxies as the surface kernel's sources)");
        run_case(&kifmm_stokes_dl_m, 2, 0, 0, 10000, 1, 6, 3e-5);
        if (!light) run_case(&kifmm_stokes_dl_m, 1, 1, 6000, 8000, 2, 6, 3e-5);
        /* (MPI mode's trees may take expansions of boxes twice as wide as one
         * process's: half the wavelengths a unit; docs/kernels.md) */
        group("helmholtz_grad (complex pairs), 1.5 wavelengths a unit, Im k 0.3");
        g_kparam[0] = 2.0 * T_PI * 1.5, g_kparam[1] = 0.3;
        run_case(&kifmm_helmholtz_grad_m, 0, 0, 0, 10000, 1, 6, 3e-5);
        /* opts.tol (the order for boxes half the root wide where there are
         * several ranks) */
        g_tol = 1e-5;
        run_case(&kifmm_helmholtz_grad_m, 0, 0, 0, 10000, 1, 0, 1e-5);
        g_kparam[0] = g_kparam[1] = g_tol = 0.0;
        /* (CONFIGS=all: three handles' operators at p = 8, 35 s on 2 ranks) */
        if (getenv("KIFMM_TEST_MPI_ALL") && *getenv("KIFMM_TEST_MPI_ALL") && g_size == 2)
            run_case(&kifmm_stokes_dl_m, 0, 0, 0, 20000, 1, 8, 1e-7);
    }
    group("a few points on many ranks");
    run_case(&kifmm_laplace_grad_m, 0, 0, 0, 3, 1, 6, 1e-12);
    run_case(&kifmm_laplace_grad_m, 2, 0, 2, 5, 1, 6, 1e-12);
    group("errors on one rank");
    errors();
    group("allocation failures on one rank");
    alloc_failures(&kifmm_laplace_grad_m, 1);
    if (!light && g_size > 1) {
        alloc_failures(&kifmm_laplace_dipole_grad_m, 0); /* the fits */
        alloc_failures(&kifmm_stokes_pvel_m, 0);
        if (getenv("KIFMM_TEST_ALLOC_ALL")) /* the proxies' second role (25 s: in one run) */
            alloc_failures(&kifmm_stokes_dl_m, 2);
    }
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
