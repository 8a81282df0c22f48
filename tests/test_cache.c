/* test_cache.c - opts.operator_cache: operator sets written to a directory
 * by one create and read back by the next. A handle whose sets were read
 * must give, bit for bit, the outputs of a handle that built them (and
 * those match direct sums to the method's accuracy); every file that is not
 * the one a set would write (a byte changed, cut short, grown, another
 * set's file under its name, another kernel parameter) must be refused and
 * the set built and written again; a directory that does not exist, or a
 * path freed after create, must change nothing but the counts. Cases:
 * scale-invariant kernels (one set), Yukawa (one set per level, and new
 * ones after update_points moves the points, and a level whose kernel
 * underflows: sets of rank 0), Stokes (three components, mirrored M2M),
 * Helmholtz with wide levels at a higher order than the level below
 * (sets whose M2M or L2L reach another order's surfaces), float and
 * double, plans, handles made on threads. */
#define _POSIX_C_SOURCE 200809L /* mkdtemp, opendir */
#include <dirent.h>
#include <sys/stat.h>
#include <unistd.h>

#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"
#define KIFMM_KERNEL laplace
#define KIFMM_REAL float
#include "kifmm.h"
#define KIFMM_KERNEL yukawa_grad
#include "kifmm.h"
#define KIFMM_KERNEL stokes
#include "kifmm.h"
#define KIFMM_KERNEL helmholtz_grad
#include "kifmm.h"

#include "test.h"

/* points of the instances' cycles (fewer in the quick builds: gcc -O0 and
 * the sanitizers) */
#ifdef KIFMM_TEST_QUICK
#define T_N 6000
#else
#define T_N 12000
#endif

/* ---- the directory -------------------------------------------------------- */

static char g_root[256]; /* mkdtemp's; each case a subdirectory */

/* A new empty directory under g_root, into out. */
static void new_dir(char *out, size_t n, const char *name)
{
    snprintf(out, n, "%s/%s", g_root, name);
    CHECK(mkdir(out, 0700) == 0, "mkdir %s", out);
}

/* Files in dir: all of them, and those left by a write (".tmp-"); the
 * paths of the set files into paths (up to np). */
static int list_dir(const char *dir, int *tmp, char paths[][512], int np)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    int n = 0;
    *tmp = 0;
    if (!d) return -1;
    while ((e = readdir(d)) != NULL) {
        if (e->d_name[0] == '.') continue;
        if (strstr(e->d_name, ".tmp-")) (*tmp)++;
        else if (n < np) snprintf(paths[n], 512, "%s/%s", dir, e->d_name);
        n++;
    }
    closedir(d);
    return n;
}

static void remove_tree(const char *dir)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    char p[768];
    if (!d) return;
    while ((e = readdir(d)) != NULL) {
        struct stat st;
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
        snprintf(p, sizeof p, "%s/%s", dir, e->d_name);
        if (stat(p, &st) == 0 && S_ISDIR(st.st_mode)) remove_tree(p);
        else remove(p);
    }
    closedir(d);
    rmdir(dir);
}

static long file_size(const char *path)
{
    FILE *f = fopen(path, "rb");
    long n;
    if (!f) return -1;
    fseek(f, 0, SEEK_END);
    n = ftell(f);
    fclose(f);
    return n;
}

/* The ways a file is spoiled: a byte flipped at `at` (a fraction of the
 * length), cut to half, one byte appended. */
enum { SPOIL_FLIP, SPOIL_CUT, SPOIL_GROW };
static void spoil(const char *path, int how, double at)
{
    const long n = file_size(path);
    unsigned char *b = (unsigned char *)malloc((size_t)n + 1);
    FILE *f = fopen(path, "rb");
    size_t got = f ? fread(b, 1, (size_t)n, f) : 0;
    long m = n;
    if (f) fclose(f);
    CHECK(n > 0 && got == (size_t)n, "read %s", path);
    if (how == SPOIL_FLIP) b[(long)(at * (double)(n - 1))] ^= 0x10;
    if (how == SPOIL_CUT) m = n / 2;
    if (how == SPOIL_GROW) b[n] = 0, m = n + 1;
    f = fopen(path, "wb");
    CHECK(f && fwrite(b, 1, (size_t)m, f) == (size_t)m, "write %s", path);
    if (f) fclose(f);
    free(b);
}

/* ---- one instance --------------------------------------------------------- */

/* run_P: create (on plan pl if not NULL), evaluate, destroy; the stats'
 * cache counts into rw[0] (read) and rw[1] (written); outputs in double. */
#define T_CACHE_RUN(P, R, SD, TD)                                                               \
    static int run_##P(const kifmm_opts *o, P##_plan *pl, int64_t n, const double *x,          \
                       const double *q, double *out, int *rw)                                  \
    {                                                                                          \
        P *h = NULL;                                                                           \
        kifmm_stats st;                                                                        \
        int64_t i;                                                                             \
        R *xr = (R *)malloc(sizeof(R) * (size_t)(3 * n));                                      \
        R *qr = (R *)malloc(sizeof(R) * (size_t)(SD * n));                                     \
        R *orr = (R *)malloc(sizeof(R) * (size_t)(TD * n));                                    \
        int rc;                                                                                \
        for (i = 0; i < 3 * n; i++) xr[i] = (R)x[i];                                           \
        for (i = 0; i < SD * n; i++) qr[i] = (R)q[i];                                          \
        rc = pl ? P##_create_with_plan(&h, pl, n, xr, n, xr) : P##_create(&h, o, n, xr, n, xr); \
        if (rc == 0) rc = P##_evaluate(h, qr, orr);                                            \
        if (rc == 0) rc = P##_stats(h, &st);                                                   \
        if (rc == 0) rw[0] = st.cache_read, rw[1] = st.cache_written;                          \
        for (i = 0; i < TD * n; i++) out[i] = (double)orr[i];                                  \
        P##_destroy(h);                                                                        \
        free(xr); free(qr); free(orr);                                                         \
        return rc;                                                                             \
    }
T_CACHE_RUN(kifmm_laplace_grad, double, 1, 4)
T_CACHE_RUN(kifmm_laplacef, float, 1, 1)
T_CACHE_RUN(kifmm_yukawa_grad, double, 1, 4)
T_CACHE_RUN(kifmm_stokes, double, 3, 3)

typedef int (*run_fn)(const kifmm_opts *, void *, int64_t, const double *, const double *, double *,
                      int *);

static int same_bits(const double *a, const double *b, int64_t n)
{
    return memcmp(a, b, sizeof(double) * (size_t)n) == 0;
}

/* The whole cycle for one instance: no cache, an empty directory (written,
 * then read), each way of spoiling its files (refused, built, written
 * again), another set's file under each name. nset: the sets its tree
 * uses. */
static void cycle(const char *name, run_fn run, const kifmm_opts *base, int64_t n, const double *x,
                  const double *q, int td, int nset)
{
    double *ref = (double *)malloc(sizeof(double) * (size_t)(td * n));
    double *out = (double *)malloc(sizeof(double) * (size_t)(td * n));
    char dir[300], paths[64][512];
    kifmm_opts o = *base;
    int rw[2] = {-1, -1}, tmp, nf, how, k;
    o.operator_cache = NULL;
    CHECK(run(&o, NULL, n, x, q, ref, rw) == 0, "%s: create without a cache", name);
    CHECK(rw[0] == 0 && rw[1] == 0, "%s: no cache, counts %d %d", name, rw[0], rw[1]);
    new_dir(dir, sizeof dir, name);
    o.operator_cache = dir;
    CHECK(run(&o, NULL, n, x, q, out, rw) == 0, "%s: first create with the cache", name);
    CHECK(rw[0] == 0 && rw[1] == nset, "%s: first create: read %d (0), written %d (%d)", name, rw[0],
          rw[1], nset);
    CHECK(same_bits(out, ref, td * n), "%s: sets built and written: outputs as without a cache", name);
    nf = list_dir(dir, &tmp, paths, 64);
    CHECK(nf == nset && tmp == 0, "%s: %d files (%d), %d left unrenamed", name, nf, nset, tmp);
    CHECK(run(&o, NULL, n, x, q, out, rw) == 0, "%s: second create with the cache", name);
    CHECK(rw[0] == nset && rw[1] == 0, "%s: second create: read %d (%d), written %d (0)", name,
          rw[0], nset, rw[1]);
    CHECK(same_bits(out, ref, td * n), "%s: sets read: outputs bit for bit as built", name);
    for (how = 0; how < 5; how++) {
        const char *what[5] = {"a byte flipped early", "a byte flipped late", "cut short", "grown",
                               "another set's file"};
        nf = list_dir(dir, &tmp, paths, 64);
        for (k = 0; k < nf && k < 64; k++) {
            if (how == 0) spoil(paths[k], SPOIL_FLIP, 0.01);
            if (how == 1) spoil(paths[k], SPOIL_FLIP, 0.99);
            if (how == 2) spoil(paths[k], SPOIL_CUT, 0.0);
            if (how == 3) spoil(paths[k], SPOIL_GROW, 0.0);
        }
        if (how == 4) { /* each file under the next one's name */
            char moved[512 + 8];
            if (nf <= 1) continue;
            for (k = 0; k < nf && k < 64; k++) {
                snprintf(moved, sizeof moved, "%.500s.x", paths[k]);
                CHECK(rename(paths[k], moved) == 0, "rename %s", paths[k]);
            }
            for (k = 0; k < nf && k < 64; k++) {
                snprintf(moved, sizeof moved, "%.500s.x", paths[k]);
                CHECK(rename(moved, paths[(k + 1) % nf]) == 0, "rename %s", moved);
            }
        }
        CHECK(run(&o, NULL, n, x, q, out, rw) == 0, "%s: create over files %s", name, what[how]);
        CHECK(rw[0] == 0 && rw[1] == nset, "%s: files %s: read %d (0), written %d (%d)", name,
              what[how], rw[0], rw[1], nset);
        CHECK(same_bits(out, ref, td * n), "%s: files %s: outputs as without a cache", name,
              what[how]);
        CHECK(run(&o, NULL, n, x, q, out, rw) == 0 && rw[0] == nset && rw[1] == 0 &&
                  same_bits(out, ref, td * n),
              "%s: after files %s were written again: read %d (%d), written %d", name, what[how],
              rw[0], nset, rw[1]);
    }
    free(ref);
    free(out);
}

/* ---- the cases ----------------------------------------------------------- */

static void points(int64_t n, uint64_t seed, double *x, double *q, int sd)
{
    t_rng r = t_rng_seed(seed);
    t_gen_cube(&r, n, x, 0.0, 1.0);
    t_gen_charges(&r, n * sd, q, -1.0, 1.0);
}

static int run_lg(const kifmm_opts *o, void *pl, int64_t n, const double *x, const double *q,
                  double *out, int *rw)
{
    return run_kifmm_laplace_grad(o, (kifmm_laplace_grad_plan *)pl, n, x, q, out, rw);
}
static int run_lf(const kifmm_opts *o, void *pl, int64_t n, const double *x, const double *q,
                  double *out, int *rw)
{
    return run_kifmm_laplacef(o, (kifmm_laplacef_plan *)pl, n, x, q, out, rw);
}
static int run_yg(const kifmm_opts *o, void *pl, int64_t n, const double *x, const double *q,
                  double *out, int *rw)
{
    return run_kifmm_yukawa_grad(o, (kifmm_yukawa_grad_plan *)pl, n, x, q, out, rw);
}
static int run_st(const kifmm_opts *o, void *pl, int64_t n, const double *x, const double *q,
                  double *out, int *rw)
{
    return run_kifmm_stokes(o, (kifmm_stokes_plan *)pl, n, x, q, out, rw);
}

/* The files of every instance, their outputs as built, and those against
 * direct sums (laplace_grad: the test's own). */
static void test_cycles(void)
{
    const int64_t n = T_N;
    double *x = (double *)malloc(sizeof(double) * 3 * n), *q = (double *)malloc(sizeof(double) * 3 * n);
    double *out = (double *)malloc(sizeof(double) * 4 * n);
    kifmm_opts o = t_opts(6, 64, 0);
    char dir[300];
    int rw[2], lev = 0;
    t_err e;
    kifmm_stats st;
    points(n, 11, x, q, 3);
    printf("cycles: laplace_grad, laplace (float), yukawa_grad (a set per level), stokes\n");
    cycle("laplace_grad", run_lg, &o, n, x, q, 4, 1);
    /* the sets read give the method's accuracy */
    new_dir(dir, sizeof dir, "accuracy");
    o.operator_cache = dir;
    CHECK(run_lg(&o, NULL, n, x, q, out, rw) == 0 && run_lg(&o, NULL, n, x, q, out, rw) == 0 && rw[0] == 1,
          "laplace_grad: read %d", rw[0]);
    e = t_error_laplace(n, x, q, n, x, out, 4, 300);
    CHECK_ERR(e.pot, 1e-5, "laplace_grad p = 6 from the cache: potential vs direct sums");
    CHECK_ERR(e.grad, 1e-4, "laplace_grad p = 6 from the cache: gradient vs direct sums");
    o = t_opts(6, 64, 0);
    cycle("laplacef", run_lf, &o, n, x, q, 1, 1);
    /* Yukawa: one set per level that has operators */
    o = t_opts(5, 64, 0);
    o.kernel_param[0] = 3.0;
    {
        kifmm_yukawa_grad *h = NULL;
        const int rc = kifmm_yukawa_grad_create(&h, &o, n, x, n, x);
        CHECK(rc == 0 && kifmm_yukawa_grad_stats(h, &st) == 0, "yukawa_grad create");
        lev = rc == 0 ? st.levels : 0;
        kifmm_yukawa_grad_destroy(h);
    }
    cycle("yukawa_grad", run_yg, &o, n, x, q, 4, lev - 2);
    o = t_opts(4, 0, 0);
    cycle("stokes", run_st, &o, n, x, q, 3, 1);
    free(x);
    free(q);
    free(out);
}

/* Another kernel parameter, another order: other files, none read. */
static void test_keys(void)
{
    const int64_t n = 8000;
    double *x = (double *)malloc(sizeof(double) * 3 * n), *q = (double *)malloc(sizeof(double) * n);
    double *a = (double *)malloc(sizeof(double) * 4 * n), *b = (double *)malloc(sizeof(double) * 4 * n);
    kifmm_opts o = t_opts(4, 64, 0);
    char dir[300], paths[64][512];
    int rw[2], tmp, n1, n2;
    points(n, 12, x, q, 1);
    new_dir(dir, sizeof dir, "keys");
    o.operator_cache = dir;
    o.kernel_param[0] = 2.0;
    CHECK(run_yg(&o, NULL, n, x, q, a, rw) == 0 && rw[1] >= 1, "yukawa lambda 2: written %d", rw[1]);
    n1 = list_dir(dir, &tmp, paths, 64);
    o.kernel_param[0] = 2.5;
    CHECK(run_yg(&o, NULL, n, x, q, b, rw) == 0 && rw[0] == 0 && rw[1] >= 1,
          "yukawa lambda 2.5 beside lambda 2's files: read %d (0), written %d", rw[0], rw[1]);
    n2 = list_dir(dir, &tmp, paths, 64);
    CHECK(n2 == 2 * n1, "files of both parameters: %d (%d)", n2, 2 * n1);
    CHECK(!same_bits(a, b, 4 * n), "the two parameters give different outputs");
    /* order 4's file under order 5's name: refused */
    o = t_opts(4, 64, 0);
    o.operator_cache = dir;
    CHECK(run_lg(&o, NULL, n, x, q, a, rw) == 0 && rw[1] == 1, "laplace_grad p = 4 written");
    {
        char p4[512], p5[512];
        int i, m = list_dir(dir, &tmp, paths, 64);
        p4[0] = p5[0] = 0;
        o.order = 5;
        CHECK(run_lg(&o, NULL, n, x, q, b, rw) == 0 && rw[1] == 1, "laplace_grad p = 5 written");
        m = list_dir(dir, &tmp, paths, 64);
        for (i = 0; i < m && i < 64; i++) {
            if (strstr(paths[i], "laplace_grad-d-p4-")) snprintf(p4, sizeof p4, "%.500s", paths[i]);
            if (strstr(paths[i], "laplace_grad-d-p5-")) snprintf(p5, sizeof p5, "%.500s", paths[i]);
        }
        CHECK(p4[0] && p5[0], "files of orders 4 and 5 found");
        if (p4[0] && p5[0]) {
            double *c = (double *)malloc(sizeof(double) * 4 * n);
            CHECK(rename(p4, p5) == 0, "order 4's file renamed as order 5's");
            CHECK(run_lg(&o, NULL, n, x, q, c, rw) == 0 && rw[0] == 0 && rw[1] == 1,
                  "order 4's set under order 5's name: read %d (0), written %d (1)", rw[0], rw[1]);
            CHECK(same_bits(c, b, 4 * n), "order 5 built again: outputs as the first time");
            free(c);
        }
    }
    free(x);
    free(q);
    free(a);
    free(b);
}

/* No such directory: built, nothing written, no error. A path freed after
 * create: update_points writes into the plan's copy of it. */
static void test_paths(void)
{
    const int64_t n = 8000;
    double *x = (double *)malloc(sizeof(double) * 3 * n), *q = (double *)malloc(sizeof(double) * n);
    double *a = (double *)malloc(sizeof(double) * 4 * n), *b = (double *)malloc(sizeof(double) * 4 * n);
    kifmm_opts o = t_opts(4, 64, 0), used;
    char dir[300], missing[320], paths[64][512];
    char *heap;
    int rw[2] = {-1, -1}, tmp, nf;
    kifmm_yukawa_grad *h = NULL;
    kifmm_stats st;
    memset(&st, 0, sizeof st);
    points(n, 13, x, q, 1);
    snprintf(missing, sizeof missing, "%s/no/such/dir", g_root);
    o.operator_cache = missing;
    CHECK(run_lg(&o, NULL, n, x, q, a, rw) == 0 && rw[0] == 0 && rw[1] == 0,
          "a directory that does not exist: create succeeds, read %d written %d", rw[0], rw[1]);
    o.operator_cache = "";
    CHECK(run_lg(&o, NULL, n, x, q, b, rw) == 0 && rw[0] == 0 && rw[1] == 0 && same_bits(a, b, 4 * n),
          "\"\": no cache");
    /* Yukawa's sets depend on the root: moved points need new ones */
    new_dir(dir, sizeof dir, "paths");
    heap = (char *)malloc(strlen(dir) + 1);
    strcpy(heap, dir);
    o.operator_cache = heap;
    o.kernel_param[0] = 1.5;
    CHECK(kifmm_yukawa_grad_create(&h, &o, n, x, n, x) == 0, "yukawa create");
    memset(heap, 'x', strlen(heap)); /* the caller's string changed and freed */
    free(heap);
    CHECK(kifmm_yukawa_grad_options(h, &used) == 0 && used.operator_cache &&
              strcmp(used.operator_cache, dir) == 0,
          "options: the cache's path, the plan's copy");
    {
        double *y = (double *)malloc(sizeof(double) * 3 * n);
        int64_t i;
        int w0;
        CHECK(kifmm_yukawa_grad_stats(h, &st) == 0, "stats");
        w0 = st.cache_written;
        for (i = 0; i < 3 * n; i++) y[i] = 2.0 * x[i] - 0.3; /* a root twice as wide */
        CHECK(kifmm_yukawa_grad_update_points(h, n, y, n, y) == 0, "update_points");
        CHECK(kifmm_yukawa_grad_stats(h, &st) == 0 && st.cache_written > w0,
              "update_points wrote the new root's sets: %d after %d", st.cache_written, w0);
        CHECK(kifmm_yukawa_grad_evaluate(h, q, a) == 0, "evaluate after update");
        o.operator_cache = NULL;
        CHECK(run_yg(&o, NULL, n, y, q, b, rw) == 0 && same_bits(a, b, 4 * n),
              "after update_points: outputs as a new handle's without a cache");
        o.operator_cache = dir;
        CHECK(run_yg(&o, NULL, n, y, q, b, rw) == 0 && rw[0] >= 1 && rw[1] == 0 && same_bits(a, b, 4 * n),
              "the moved points' sets read back: read %d, written %d", rw[0], rw[1]);
        free(y);
    }
    kifmm_yukawa_grad_destroy(h);
    nf = list_dir(dir, &tmp, paths, 64);
    CHECK(nf >= 2 && tmp == 0, "files %d, unrenamed %d", nf, tmp);
    free(x);
    free(q);
    free(a);
    free(b);
}

/* A plan writes its set at plan_create; the next plan reads it; handles
 * made on threads at once with one empty directory all finish and agree. */
static void test_plans_threads(void)
{
    const int64_t n = 10000;
    double *x = (double *)malloc(sizeof(double) * 3 * n), *q = (double *)malloc(sizeof(double) * n);
    double *ref = (double *)malloc(sizeof(double) * 4 * n);
    double *outs = (double *)malloc(sizeof(double) * 4 * n * 4);
    kifmm_opts o = t_opts(6, 64, 0);
    kifmm_laplace_grad_plan *pl = NULL;
    char dir[300], paths[64][512];
    int rw[2], ok[4] = {0, 0, 0, 0}, tmp, nf, k;
    points(n, 14, x, q, 1);
    o.nthreads = 1; /* (the sums' order follows the threads) */
    CHECK(run_lg(&o, NULL, n, x, q, ref, rw) == 0, "reference");
    new_dir(dir, sizeof dir, "plans");
    o.operator_cache = dir;
    CHECK(kifmm_laplace_grad_plan_create(&pl, &o) == 0, "plan_create");
    CHECK(run_lg(NULL, pl, n, x, q, outs, rw) == 0 && rw[0] == 0 && rw[1] == 1 && same_bits(outs, ref, 4 * n),
          "plan_create wrote its set: read %d written %d", rw[0], rw[1]);
    kifmm_laplace_grad_plan_destroy(pl);
    pl = NULL;
    CHECK(kifmm_laplace_grad_plan_create(&pl, &o) == 0, "second plan_create");
    CHECK(run_lg(NULL, pl, n, x, q, outs, rw) == 0 && rw[0] == 1 && rw[1] == 0 && same_bits(outs, ref, 4 * n),
          "the second plan read it: read %d written %d", rw[0], rw[1]);
    kifmm_laplace_grad_plan_destroy(pl);
    new_dir(dir, sizeof dir, "threads");
    o.operator_cache = dir;
#ifdef _OPENMP
#pragma omp parallel for num_threads(4) schedule(static, 1)
#endif
    for (int i = 0; i < 4; i++) {
        int c[2];
        ok[i] = run_lg(&o, NULL, n, x, q, outs + (size_t)i * 4 * (size_t)n, c) == 0;
    }
    for (k = 0; k < 4; k++)
        CHECK(ok[k] && same_bits(outs + (size_t)k * 4 * (size_t)n, ref, 4 * n),
              "handle %d of 4 made on threads with one directory: outputs as built", k);
    nf = list_dir(dir, &tmp, paths, 64);
    CHECK(nf == 1 && tmp == 0, "one file after the threads (%d), unrenamed %d", nf, tmp);
    CHECK(run_lg(&o, NULL, n, x, q, outs, rw) == 0 && rw[0] == 1 && same_bits(outs, ref, 4 * n),
          "and it reads back whole: read %d", rw[0]);
    free(x);
    free(q);
    free(ref);
    free(outs);
}

/* Sets that reach other orders' surfaces (Helmholtz's raised wide
 * levels) and sets of rank 0 (Yukawa at lambda r where the kernel
 * underflows on a level's surfaces): written, read back whole, the outputs
 * as built. */
static void test_odd_sets(void)
{
    const int64_t n = 6000;
    double *x = (double *)malloc(sizeof(double) * 3 * n), *q = (double *)malloc(sizeof(double) * 2 * n);
    double *a = (double *)malloc(sizeof(double) * 8 * n), *b = (double *)malloc(sizeof(double) * 8 * n);
    kifmm_opts o = t_opts(8, 64, 0);
    char dir[300];
    int64_t i;
    int k, rw[2][2] = {{-1, -1}, {-1, -1}}, rc = 0;
    points(n, 15, x, q, 2);
    for (i = 0; i < 3 * n; i++) x[i] *= 2.5; /* 5 wavelengths across */
    o.kernel_param[0] = 4.0 * T_PI;
    o.nthreads = 1;
    for (k = 0; k < 3 && rc == 0; k++) { /* no cache, writing, reading */
        kifmm_helmholtz_grad *h = NULL;
        kifmm_stats st;
        if (k == 1) new_dir(dir, sizeof dir, "helmholtz");
        o.operator_cache = k ? dir : NULL;
        rc = kifmm_helmholtz_grad_create(&h, &o, n, x, n, x);
        if (!rc) rc = kifmm_helmholtz_grad_evaluate(h, q, k ? b : a);
        if (!rc) rc = kifmm_helmholtz_grad_stats(h, &st);
        if (!rc && k) rw[k - 1][0] = st.cache_read, rw[k - 1][1] = st.cache_written;
        if (!rc && k == 1)
            CHECK(strstr(st.build, "wide levels") != NULL, "helmholtz: levels at a higher order (%s)", st.build);
        kifmm_helmholtz_grad_destroy(h);
        if (k) CHECK(rc == 0 && same_bits(a, b, 8 * n), "helmholtz raised levels, %s: outputs as built",
                     k == 1 ? "writing" : "reading");
    }
    CHECK(rw[0][0] == 0 && rw[0][1] >= 2 && rw[1][0] == rw[0][1] && rw[1][1] == 0,
          "helmholtz raised levels: written %d, then read %d of them and written %d", rw[0][1], rw[1][0],
          rw[1][1]);
    /* Yukawa: lambda 3000 on a unit cube, the deep levels' kernels below DBL_MIN */
    o = t_opts(4, 32, 0);
    o.kernel_param[0] = 3000.0;
    o.operator_cache = NULL;
    CHECK(run_yg(&o, NULL, n, x, q, a, rw[0]) == 0, "yukawa lambda 3000");
    {
        kifmm_yukawa_grad *h = NULL;
        kifmm_stats st;
        memset(&st, 0, sizeof st);
        CHECK(kifmm_yukawa_grad_create(&h, &o, n, x, n, x) == 0 && kifmm_yukawa_grad_stats(h, &st) == 0,
              "yukawa lambda 3000 create");
        k = h ? st.levels - 2 : -1; /* its sets: one per level from 2 */
        kifmm_yukawa_grad_destroy(h);
    }
    new_dir(dir, sizeof dir, "rank0");
    o.operator_cache = dir;
    CHECK(run_yg(&o, NULL, n, x, q, b, rw[0]) == 0 && run_yg(&o, NULL, n, x, q, b, rw[1]) == 0,
          "yukawa lambda 3000 with the cache");
    CHECK(rw[0][1] == k && rw[1][0] == k && rw[1][1] == 0 && same_bits(a, b, 4 * n),
          "yukawa lambda 3000: written %d of %d sets, read %d, written again %d; outputs as built", rw[0][1],
          k, rw[1][0], rw[1][1]);
    free(x);
    free(q);
    free(a);
    free(b);
}

int main(void)
{
    const char *base = getenv("TMPDIR");
    snprintf(g_root, sizeof g_root, "%s/kifmm_cache_XXXXXX", base && *base ? base : "/tmp");
    if (!mkdtemp(g_root)) {
        printf("cannot make a directory under %s\n", g_root);
        return 1;
    }
    test_cycles();
    test_keys();
    test_paths();
    test_plans_threads();
    test_odd_sets();
    remove_tree(g_root);
    return t_finish();
}
