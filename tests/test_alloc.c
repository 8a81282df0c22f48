/* test_alloc.c - allocation failure handling through the KIFMM_MALLOC /
 * KIFMM_FREE hooks: an allocator that fails on its k-th call, for k = 0, 1,
 * 2, ... until create succeeds.  Every failing create must return
 * KIFMM_ERR_NOMEM, set the handle to NULL and leave no live allocation.
 * With opts.operator_cache a failure in reading or writing a set's file is
 * not an error (the set is built, or not kept): there every create must
 * give NOMEM as above or succeed with the outputs of a handle without it. */
#define _POSIX_C_SOURCE 200809L /* mkdtemp, opendir */
#include <dirent.h>
#include <stddef.h>
#include <stdlib.h>
#include <unistd.h>

static void *counting_malloc(size_t size);
static void counting_free(void *ptr);
#define KIFMM_MALLOC(size) counting_malloc(size)
#define KIFMM_FREE(ptr) counting_free(ptr)

#include "kifmm.h"
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"
#define KIFMM_KERNEL yukawa
#include "kifmm.h"
#define KIFMM_KERNEL stokes
#define KIFMM_REAL float
#define KIFMM_NAME kifmm_stokesf
#include "kifmm.h"

#include "test.h"

T_DEFINE_API(kifmm_laplace, 1)
T_DEFINE_API(kifmm_laplace_grad, 4)

/* ---- the counting allocator --------------------------------------------- */

static long alloc_calls;      /* KIFMM_MALLOC calls since the last reset */
static long alloc_live;       /* blocks allocated and not yet freed */
static long alloc_fail_at = -1; /* fail the call with this index (-1: never) */
static long alloc_failed;     /* failures injected since the last reset */
static long alloc_bad_free;   /* frees of pointers not from counting_malloc */

#define ALLOC_MAGIC UINT64_C(0x6b69666d6d414c43)
#define ALLOC_FREED UINT64_C(0x46524545444b4946)
#define ALLOC_HEADER 16 /* keeps malloc's 16-byte alignment */

static void *counting_malloc(size_t size)
{
    unsigned char *p = NULL;
    int fail;
#ifdef _OPENMP
#pragma omp critical(kifmm_test_alloc)
#endif
    {
        fail = alloc_fail_at >= 0 && alloc_calls == alloc_fail_at;
        alloc_calls++;
        if (fail) {
            alloc_failed++;
        } else {
            p = (unsigned char *)malloc(size + ALLOC_HEADER);
            if (p) {
                uint64_t magic = ALLOC_MAGIC;
                memcpy(p, &magic, sizeof magic);
                alloc_live++;
            }
        }
    }
    return p ? p + ALLOC_HEADER : NULL;
}

static void counting_free(void *ptr)
{
    unsigned char *p;
    uint64_t magic;
    int ok;
    if (!ptr) return;
    p = (unsigned char *)ptr - ALLOC_HEADER;
    memcpy(&magic, p, sizeof magic);
#ifdef _OPENMP
#pragma omp critical(kifmm_test_alloc)
#endif
    {
        ok = magic == ALLOC_MAGIC;
        if (!ok) {
            alloc_bad_free++; /* double free or a foreign pointer: leak it */
        } else {
            magic = ALLOC_FREED;
            memcpy(p, &magic, sizeof magic);
            alloc_live--;
        }
    }
    if (ok) free(p);
}

static void alloc_reset(long fail_at)
{
    alloc_calls = 0;
    alloc_failed = 0;
    alloc_fail_at = fail_at;
}

/* ---- the test ------------------------------------------------------------ */

#define N 3000
#define MAX_K 100000

static void test_kernel(const t_api *api, const kifmm_opts *o, const double *x, const double *q)
{
    int d = api->trg_dim;
    double *out = t_doubles(N * d);
    void *h = NULL;
    long k, nomem_ok = 0, nomem_bad = 0, handle_bad = 0, leak_bad = 0, spurious = 0;
    long live_before = alloc_live;
    int rc = KIFMM_ERR_NOMEM;

    printf("  %s: N=%d order %d leaf_size %d\n", api->name, N, o->order, o->leaf_size);
    for (k = 0; k < MAX_K; k++) {
        h = (void *)&alloc_calls; /* non-NULL: create must overwrite it */
        alloc_reset(k);
        rc = api->create(&h, o, N, x, N, x);
        if (rc == KIFMM_SUCCESS) break;
        if (rc == KIFMM_ERR_NOMEM) nomem_ok++;
        else {
            if (nomem_bad++ < 5)
                printf("  FAIL detail: fail at call %ld: rc=%d (%s)\n", k, rc, kifmm_strerror(rc));
        }
        if (h != NULL) handle_bad++;
        if (alloc_live != live_before) {
            if (leak_bad++ < 5)
                printf("  FAIL detail: fail at call %ld: %ld blocks leaked\n", k,
                       alloc_live - live_before);
            live_before = alloc_live; /* report each leak once */
        }
        if (alloc_failed != 1) spurious++; /* failed without the injected failure */
    }
    printf("  %s: create succeeded after %ld injected failures (%ld allocations)\n", api->name,
           k, alloc_calls);
    CHECK(rc == KIFMM_SUCCESS, "%s: create never succeeded (k up to %ld)", api->name, k);
    CHECK(k > 0, "%s: create made no allocation through KIFMM_MALLOC", api->name);
    CHECK(nomem_bad == 0, "%s: %ld failing creates returned a code other than NOMEM", api->name,
          nomem_bad);
    CHECK(handle_bad == 0, "%s: %ld failing creates did not set the handle to NULL", api->name,
          handle_bad);
    CHECK(leak_bad == 0, "%s: %ld failing creates leaked", api->name, leak_bad);
    CHECK(spurious == 0, "%s: %ld creates failed without reaching the injected failure",
          api->name, spurious);
    CHECK(nomem_ok == k, "%s: %ld NOMEM of %ld failing creates", api->name, nomem_ok, k);

    if (rc == KIFMM_SUCCESS) {
        long live_handle = alloc_live;
        long j;
        t_err e;
        /* evaluate under allocation failure too: either it needs no
         * allocation or it fails cleanly with NOMEM */
        for (j = 0; j < MAX_K; j++) {
            alloc_reset(j);
            t_fill(N * d, out, NAN);
            rc = api->evaluate(h, q, out);
            if (rc == KIFMM_SUCCESS) break;
            if (rc != KIFMM_ERR_NOMEM) break;
            if (alloc_live != live_handle) break;
        }
        CHECK(rc == KIFMM_SUCCESS, "%s: evaluate under failing allocator: rc=%d at k=%ld",
              api->name, rc, j);
        CHECK(alloc_live == live_handle, "%s: evaluate leaked %ld blocks", api->name,
              alloc_live - live_handle);
        printf("  %s: evaluate succeeded after %ld injected failures\n", api->name, j);
        alloc_reset(-1);
        if (rc == KIFMM_SUCCESS) {
            e = t_error_laplace(N, x, q, N, x, out, d, 600);
            CHECK_ERR(e.pot, 4e-4, "%s order 4 potential after the failure loop", api->name);
            if (d == 4) CHECK_ERR(e.grad, 4e-3, "%s order 4 gradient", api->name);
        }
        api->destroy(h);
    }
    CHECK(alloc_live == 0, "%s: %ld blocks live after destroy", api->name, alloc_live);
    CHECK(alloc_bad_free == 0, "%s: %ld bad frees", api->name, alloc_bad_free);
    alloc_live = 0;
    alloc_bad_free = 0;
    free(out);
}

/* Invalid inputs found at any stage of create leave nothing allocated. */
static void test_invalid_inputs(const t_api *api, const double *x)
{
    double *y = t_dup(3 * N, x);
    kifmm_opts o;
    void *h;
    int rc, v;
    for (v = 0; v < 4; v++) {
        const char *what = "";
        o = t_opts(4, 32, 0);
        memcpy(y, x, 3 * N * sizeof(double));
        switch (v) {
        case 0: y[3 * N - 1] = NAN; what = "NaN in the last target coordinate"; break;
        case 1: o.order = 1; what = "order 1"; break;
        case 2: o.max_depth = KIFMM_MAX_DEPTH + 1; what = "max_depth too large"; break;
        default: y[3 * (N / 2)] = -HUGE_VAL; what = "-inf in a middle coordinate"; break;
        }
        alloc_reset(-1);
        h = (void *)&alloc_calls;
        rc = api->create(&h, &o, N, x, N, y);
        CHECK(rc < 0 && h == NULL && alloc_live == 0,
              "%s %s: rc=%d, handle %s, %ld blocks live", api->name, what, rc,
              h ? "not NULL" : "NULL", alloc_live);
        if (rc == KIFMM_SUCCESS && h != NULL) api->destroy(h);
        alloc_live = 0;
    }
    free(y);
}

/* periodic directions (mask) of the next test_many_ run: with them, create
 * also builds the far images' operators (levels of super-cells, or the
 * fixed point, and the exchange with level 1) */
static int many_period;

/* update_points under failing allocation on handle h (points xr, 3
 * density vectors q; out: room for 3 vectors' outputs): the points shrunk
 * towards the centre (a new width: the per-level operators are rebuilt,
 * or copied where the widths agree). Each failure returns KIFMM_ERR_NOMEM,
 * leaks nothing, and leaves the handle evaluating its old points as before
 * (bit for bit); the update that succeeds gives a fresh handle's outputs.
 * The full build fails every allocation in turn; the KIFMM_TEST_QUICK
 * configurations (sanitizers, -O0) every third, which still reaches every
 * stage of an update (each allocates 110 to 130 blocks here) at a third of
 * the time (this test at -O0: 384 -> 145 s). */
#ifdef KIFMM_TEST_QUICK
#define UPDATE_STRIDE 3
#else
#define UPDATE_STRIDE 1
#endif
#define DEFINE_UPDATE_ALLOC(P, R, SD, TD)                                                    \
    static void P##_update_alloc(P *h, const R *xr, const R *q, R *out)                      \
    {                                                                                        \
        R *y = (R *)malloc(sizeof(R) * 3 * N), *ref = (R *)malloc(sizeof(R) * 3 * N * (TD)); \
        P *g = NULL;                                                                         \
        long k, bad = 0, changed = 0, live_before;                                           \
        int rc = KIFMM_ERR_NOMEM, i;                                                         \
        for (i = 0; i < 3 * N; i++) y[i] = (R)(0.25 + 0.5 * (double)xr[i]);                  \
        alloc_reset(-1);                                                                     \
        rc = P##_evaluate_many(h, 3, q, ref);                                                \
        live_before = alloc_live;                                                            \
        for (k = 0; k < MAX_K && rc == KIFMM_SUCCESS; k += UPDATE_STRIDE) {                  \
            alloc_reset(k);                                                                  \
            rc = P##_update_points(h, N, y, N, y);                                           \
            if (rc == KIFMM_SUCCESS) break;                                                  \
            if (rc != KIFMM_ERR_NOMEM || alloc_live != live_before) bad++;                   \
            alloc_reset(-1);                                                                 \
            rc = P##_evaluate_many(h, 3, q, out);                                            \
            if (rc != KIFMM_SUCCESS || memcmp(out, ref, sizeof(R) * 3 * N * (TD))) changed++; \
            rc = KIFMM_SUCCESS;                                                              \
        }                                                                                    \
        alloc_reset(-1);                                                                     \
        printf("  %s: update_points succeeded after %ld injected failures\n", #P, k);        \
        CHECK(rc == KIFMM_SUCCESS && k > 0 && bad == 0, "%s: %ld failing update_points misbehaved", \
              #P, bad);                                                                      \
        CHECK(changed == 0, "%s: %ld failed updates changed the handle's outputs", #P, changed); \
        {                                                                                    \
            kifmm_opts o;                                                                    \
            P##_options(h, &o);                                                              \
            rc = P##_create(&g, &o, N, y, N, y);                                             \
        }                                                                                    \
        CHECK(rc == KIFMM_SUCCESS && P##_evaluate_many(h, 3, q, out) == KIFMM_SUCCESS &&      \
                  P##_evaluate_many(g, 3, q, ref) == KIFMM_SUCCESS &&                        \
                  !memcmp(out, ref, sizeof(R) * 3 * N * (TD)),                               \
              "%s: after update_points the outputs differ from a fresh handle's", #P);        \
        P##_destroy(g);                                                                      \
        free(y);                                                                             \
        free(ref);                                                                           \
    }

DEFINE_UPDATE_ALLOC(kifmm_yukawa, double, 1, 1)
DEFINE_UPDATE_ALLOC(kifmm_laplace, double, 1, 1)
DEFINE_UPDATE_ALLOC(kifmm_stokesf, float, 3, 3)

/* Create under failing allocation for an instance P with real type R
 * (non-scale-invariant operators per level, float arrays), then
 * evaluate_many: growing the workspace for 3 vectors fails cleanly (NOMEM,
 * out untouched, nothing leaked) until it succeeds. */
#define DEFINE_MANY_TEST(P, R, SD, TD)                                                       \
    static void test_many_##P(const double *x)                                               \
    {                                                                                        \
        R *xr = (R *)malloc(sizeof(R) * 3 * N), *q = (R *)malloc(sizeof(R) * 3 * N * (SD)); \
        R *out = (R *)malloc(sizeof(R) * 3 * N * (TD));                                     \
        kifmm_opts o = t_opts(3, 100, 0); /* levels 0..2: one level of operators */  \
        P *h = NULL;                                                                         \
        long k, bad = 0, untouched_bad = 0, live_before;                                     \
        int rc = KIFMM_ERR_NOMEM, i;                                                         \
        for (i = 0; i < 3; i++) o.period[i] = many_period >> i & 1 ? 1.0 : 0.0;             \
        for (i = 0; i < 3 * N; i++) xr[i] = (R)x[i];                                         \
        for (i = 0; i < 3 * N * (SD); i++) q[i] = (R)((i % 7) - 3);                          \
        for (i = 0; i < 3 * (SD); i++) { /* each vector's components sum to zero */         \
            R *v = q + (size_t)(i / (SD)) * N * (SD) + i % (SD);                             \
            double m = 0.0;                                                                  \
            int j;                                                                           \
            for (j = 0; j < N; j++) m += (double)v[(size_t)j * (SD)];                        \
            for (j = 0; j < N; j++) v[(size_t)j * (SD)] = (R)((double)v[(size_t)j * (SD)] - m / N); \
        }                                                                                    \
        for (k = 0; k < MAX_K; k++) {                                                        \
            alloc_reset(k);                                                                  \
            rc = P##_create(&h, &o, N, xr, N, xr);                                           \
            if (rc == KIFMM_SUCCESS) break;                                                  \
            if (rc != KIFMM_ERR_NOMEM || h != NULL || alloc_live != 0) bad++;                \
        }                                                                                    \
        printf("  %s: create succeeded after %ld injected failures\n", #P, k);              \
        CHECK(rc == KIFMM_SUCCESS && bad == 0, "%s: %ld failing creates misbehaved", #P, bad); \
        live_before = alloc_live;                                                            \
        for (k = 0; k < MAX_K && rc == KIFMM_SUCCESS; k++) {                                 \
            alloc_reset(k);                                                                  \
            for (i = 0; i < 3 * N * (TD); i++) out[i] = (R)7;                                \
            rc = P##_evaluate_many(h, 3, q, out);                                            \
            if (rc == KIFMM_SUCCESS) break;                                                  \
            if (rc != KIFMM_ERR_NOMEM || alloc_live != live_before) bad++;                   \
            for (i = 0; i < 3 * N * (TD); i++)                                               \
                if (out[i] != (R)7) untouched_bad++;                                         \
            rc = KIFMM_SUCCESS;                                                              \
        }                                                                                    \
        alloc_reset(-1);                                                                     \
        printf("  %s: evaluate_many(3) succeeded after %ld injected failures\n", #P, k);    \
        CHECK(k > 0 && bad == 0, "%s: %ld failing evaluate_many calls misbehaved", #P, bad);  \
        CHECK(untouched_bad == 0, "%s: failing evaluate_many wrote %ld outputs", #P,          \
              untouched_bad);                                                                \
        if (rc == KIFMM_SUCCESS) P##_update_alloc(h, xr, q, out);                            \
        P##_destroy(h);                                                                      \
        CHECK(alloc_live == 0 && alloc_bad_free == 0, "%s: %ld blocks live after destroy", #P, \
              alloc_live);                                                                   \
        alloc_live = 0;                                                                      \
        alloc_bad_free = 0;                                                                  \
        free(xr);                                                                            \
        free(q);                                                                             \
        free(out);                                                                           \
    }

DEFINE_MANY_TEST(kifmm_yukawa, double, 1, 1)
DEFINE_MANY_TEST(kifmm_laplace, double, 1, 1)
DEFINE_MANY_TEST(kifmm_stokesf, float, 3, 3)

/* One tree for two kernels under failing allocation: a laplace handle made
 * on a laplace_grad handle's tree, then moved onto another one's
 * (update_on_tree); the allocations of the operators themselves are
 * create's and update_points' (above). In the KIFMM_TEST_QUICK builds every
 * third allocation fails (UPDATE_STRIDE). Each failure returns KIFMM_ERR_NOMEM, leaks nothing
 * (the trees' references included: they are freed with their handles),
 * and a failed move leaves the handle evaluating its old points bit for
 * bit; the handles that succeed equal fresh ones. */
static void test_tree_alloc(const double *x, const double *q)
{
    double *y = (double *)malloc(sizeof(double) * 3 * N), *out = t_doubles(N), *ref = t_doubles(N);
    kifmm_opts o = t_opts(4, 0, 0), used = o;
    kifmm_laplace_grad *a = NULL, *a2 = NULL;
    kifmm_laplace *b = NULL, *g = NULL;
    long k, bad = 0, changed = 0, live;
    int rc, i;
    for (i = 0; i < 3 * N; i++) y[i] = 0.25 + 0.5 * x[i];
    alloc_reset(-1);
    rc = kifmm_laplace_grad_create(&a, &o, N, x, N, x);
    rc |= kifmm_laplace_grad_create(&a2, &o, N, y, N, y);
    CHECK(rc == 0, "laplace_grad creates rc=%d", rc);
    if (rc) goto done;
    kifmm_laplace_grad_options(a, &used);
    live = alloc_live;
    for (k = 0; k < MAX_K; k += UPDATE_STRIDE) {
        alloc_reset(k);
        rc = kifmm_laplace_create_on_tree(&b, &o, kifmm_laplace_grad_tree(a));
        if (rc == KIFMM_SUCCESS) break;
        if (rc != KIFMM_ERR_NOMEM || b != NULL || alloc_live != live) bad++;
    }
    alloc_reset(-1);
    printf("  kifmm_laplace: create_on_tree succeeded after %ld injected failures\n", k);
    CHECK(rc == KIFMM_SUCCESS && k > 0 && bad == 0, "%ld failing create_on_tree misbehaved", bad);
    if (rc) goto done;
    rc = kifmm_laplace_evaluate(b, q, ref);
    live = alloc_live;
    for (k = 0; k < MAX_K && rc == KIFMM_SUCCESS; k += UPDATE_STRIDE) {
        alloc_reset(k);
        rc = kifmm_laplace_update_on_tree(b, kifmm_laplace_grad_tree(a2));
        if (rc == KIFMM_SUCCESS) break;
        if (rc != KIFMM_ERR_NOMEM || alloc_live != live) bad++;
        alloc_reset(-1);
        rc = kifmm_laplace_evaluate(b, q, out);
        if (rc != KIFMM_SUCCESS || memcmp(out, ref, sizeof(double) * N)) changed++;
        rc = KIFMM_SUCCESS;
    }
    alloc_reset(-1);
    printf("  kifmm_laplace: update_on_tree succeeded after %ld injected failures\n", k);
    CHECK(rc == KIFMM_SUCCESS && k > 0 && bad == 0, "%ld failing update_on_tree misbehaved", bad);
    CHECK(changed == 0, "%ld failed update_on_tree changed the handle's outputs", changed);
    o.leaf_size = used.leaf_size;
    rc = kifmm_laplace_create(&g, &o, N, y, N, y);
    CHECK(rc == 0 && kifmm_laplace_evaluate(b, q, out) == 0 && kifmm_laplace_evaluate(g, q, ref) == 0 &&
              !memcmp(out, ref, sizeof(double) * N),
          "after update_on_tree the outputs differ from a fresh handle's");
done:
    kifmm_laplace_grad_destroy(a);
    kifmm_laplace_grad_destroy(a2);
    kifmm_laplace_destroy(b);
    kifmm_laplace_destroy(g);
    CHECK(alloc_live == 0 && alloc_bad_free == 0, "trees: %ld blocks live after destroy", alloc_live);
    alloc_live = 0;
    alloc_bad_free = 0;
    free(y), free(out), free(ref);
}

/* opts.operator_cache under failing allocations: creates that write their
 * set's file (the directory emptied before each) and creates that read it.
 * Each returns NOMEM, with the handle NULL and nothing left allocated, or
 * succeeds with the outputs, bit for bit, of a handle made without the
 * cache; every allocation index is failed once (every third with
 * UPDATE_STRIDE 3). */
static void empty_dir(const char *dir)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    char p[600];
    while (d && (e = readdir(d)) != NULL) {
        if (e->d_name[0] == '.') continue;
        snprintf(p, sizeof p, "%.300s/%.280s", dir, e->d_name);
        remove(p);
    }
    if (d) closedir(d);
}

static void test_cache_alloc(const double *x, const double *q)
{
    char dir[64];
    double *out = t_doubles(4 * N), *ref = t_doubles(4 * N);
    kifmm_opts o = t_opts(4, 32, 0);
    kifmm_laplace_grad *h = NULL;
    const char *base = getenv("TMPDIR");
    long k, bad = 0, changed = 0, ok_after_fail = 0;
    int rc, phase;
    snprintf(dir, sizeof dir, "%.40s/kifmm_alloc_XXXXXX", base && *base && strlen(base) < 40 ? base : "/tmp");
    if (!mkdtemp(dir)) {
        CHECK(0, "mkdtemp %s", dir);
        free(out), free(ref);
        return;
    }
    alloc_reset(-1);
    rc = kifmm_laplace_grad_create(&h, &o, N, x, N, x);
    rc = rc ? rc : kifmm_laplace_grad_evaluate(h, q, ref);
    kifmm_laplace_grad_destroy(h);
    CHECK(rc == 0, "laplace_grad without the cache rc=%d", rc);
    o.operator_cache = dir;
    for (phase = 0; phase < 2 && rc == 0; phase++) { /* 0: writing, 1: reading */
        long live = alloc_live;
        for (k = 0; k < MAX_K; k += UPDATE_STRIDE) {
            if (phase == 0) empty_dir(dir);
            h = (kifmm_laplace_grad *)&alloc_calls; /* non-NULL: create must overwrite it */
            alloc_reset(k);
            rc = kifmm_laplace_grad_create(&h, &o, N, x, N, x);
            if (rc == KIFMM_ERR_NOMEM) {
                if (h != NULL || alloc_live != live) bad++;
                continue;
            }
            if (rc != KIFMM_SUCCESS) {
                bad++;
                break;
            }
            ok_after_fail += alloc_failed > 0;
            {
                const long failed = alloc_failed;
                alloc_reset(-1);
                if (kifmm_laplace_grad_evaluate(h, q, out) != 0 || memcmp(out, ref, sizeof(double) * 4 * N))
                    changed++;
                kifmm_laplace_grad_destroy(h);
                if (failed == 0) break; /* past the last allocation */
            }
        }
        printf("  laplace_grad %s its set's file: every allocation of %ld failed in turn\n",
               phase ? "reading" : "writing", k);
        rc = 0;
    }
    alloc_reset(-1);
    CHECK(bad == 0, "%ld creates with the cache failed otherwise than NOMEM, or leaked", bad);
    CHECK(changed == 0, "%ld creates with the cache gave other outputs", changed);
    CHECK(ok_after_fail > 0, "no create succeeded despite a failed allocation (%ld)", ok_after_fail);
    CHECK(alloc_live == 0 && alloc_bad_free == 0, "cache: %ld blocks live after destroy", alloc_live);
    alloc_live = 0;
    alloc_bad_free = 0;
    empty_dir(dir);
    rmdir(dir);
    free(out), free(ref);
}

int main(void)
{
    t_api apis[2];
    double *x = t_doubles(3 * N), *q = t_doubles(N);
    t_rng r = t_rng_seed(31);
    kifmm_opts o = t_opts(4, 32, 0);
    int a;
    double t0 = t_wall();

    apis[0] = kifmm_laplace_t_api();
    apis[1] = kifmm_laplace_grad_t_api();
    t_gen_cube(&r, N, x, 0.0, 1.0);
    t_gen_charges(&r, N, q, -1.0, 1.0);

    t_group("allocation failures in create and evaluate");
    for (a = 0; a < 2; a++) test_kernel(&apis[a], &o, x, q);
    t_group("invalid inputs leave no allocation");
    for (a = 0; a < 2; a++) test_invalid_inputs(&apis[a], x);
    /* a clustered problem gives an adaptive tree (W and X lists) */
    t_gen_blobs(&r, N, x);
    t_group("allocation failures, clustered points");
    for (a = 0; a < 2; a++) test_kernel(&apis[a], &o, x, q);
    t_group("per-level operators, float, and evaluate_many's workspace");
    test_many_kifmm_yukawa(x);
    test_many_kifmm_stokesf(x);
    t_group("periodic boundaries: the same, three periodic directions");
    many_period = 7;
    test_many_kifmm_yukawa(x);
    t_group("periodic boundaries: one and two periodic directions");
    many_period = 1;
    test_many_kifmm_yukawa(x);
    many_period = 3;
    test_many_kifmm_laplace(x);
    many_period = 0;
    t_group("one tree for two kernels");
    test_tree_alloc(x, q);
    t_group("the operator cache's files");
    test_cache_alloc(x, q);

    free(x);
    free(q);
    printf("test_alloc: %.1fs\n", t_wall() - t0);
    return t_finish();
}
