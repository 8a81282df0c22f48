/* test_errors.c - every invalid input gives its documented error code, sets
 * the handle to NULL and writes nothing the caller owns; kifmm_strerror. */
#include "kifmm.h"
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"

#include "test.h"

T_DEFINE_API(kifmm_laplace, 1)
T_DEFINE_API(kifmm_laplace_grad, 4)

#define NP 300
#define SENTINEL (-12345.678)

static int dummy_object;

/* Calls create with a non-NULL *out and checks code and *out == NULL. */
static void expect_create_fails(const t_api *api, int expected, const kifmm_opts *o, int64_t ns,
                                const double *s, int64_t nt, const double *t, const char *what)
{
    void *h = (void *)&dummy_object;
    int rc = api->create(&h, o, ns, s, nt, t);
    CHECK(rc == expected, "%s %s: rc=%d (%s), expected %d (%s)", api->name, what, rc,
          kifmm_strerror(rc), expected, kifmm_strerror(expected));
    CHECK(h == NULL, "%s %s: *out not set to NULL", api->name, what);
    if (rc == KIFMM_SUCCESS && h != NULL && h != (void *)&dummy_object) api->destroy(h);
}

static void test_create_errors(const t_api *api)
{
    t_rng r = t_rng_seed(21);
    double *s = t_doubles(3 * NP), *t = t_doubles(3 * NP);
    double bad_values[3];
    const char *bad_names[3] = {"NaN", "+inf", "-inf"};
    kifmm_opts o;
    int b, k, rc;
    char what[96];

    bad_values[0] = NAN;
    bad_values[1] = HUGE_VAL;
    bad_values[2] = -HUGE_VAL;
    t_gen_cube(&r, NP, s, 0.0, 1.0);
    t_gen_cube(&r, NP, t, 0.0, 1.0);

    printf("  %s\n", api->name);
    /* NULL handle pointer: nothing to set, just the code */
    rc = api->create(NULL, NULL, NP, s, NP, t);
    CHECK(rc == KIFMM_ERR_NULL, "%s create(NULL, ...) rc=%d", api->name, rc);

    expect_create_fails(api, KIFMM_ERR_NULL, NULL, NP, NULL, NP, t, "NULL sources");
    expect_create_fails(api, KIFMM_ERR_NULL, NULL, NP, s, NP, NULL, "NULL targets");
    expect_create_fails(api, KIFMM_ERR_NULL, NULL, 1, NULL, 0, NULL, "NULL sources, nt=0");
    expect_create_fails(api, KIFMM_ERR_NULL, NULL, 0, NULL, 1, NULL, "NULL targets, ns=0");

    expect_create_fails(api, KIFMM_ERR_COUNT, NULL, -1, s, NP, t, "nsources -1");
    expect_create_fails(api, KIFMM_ERR_COUNT, NULL, NP, s, -1, t, "ntargets -1");
    expect_create_fails(api, KIFMM_ERR_COUNT, NULL, INT64_MIN, s, NP, t, "nsources INT64_MIN");
    /* counts no array can hold: refused before anything is read (the arrays
     * here hold NP points, so reading them would crash or fail the check) */
    {
        static const int64_t huge[] = {INT64_MAX, (int64_t)1 << 61, INT64_MAX / 3 + 1,
                                       INT64_MAX / 24 + 1, KIFMM_MAX_POINTS + 1};
        for (k = 0; k < (int)(sizeof huge / sizeof huge[0]); k++) {
            sprintf(what, "nsources %lld", (long long)huge[k]);
            expect_create_fails(api, KIFMM_ERR_COUNT, NULL, huge[k], s, NP, t, what);
            sprintf(what, "ntargets %lld", (long long)huge[k]);
            expect_create_fails(api, KIFMM_ERR_COUNT, NULL, NP, s, huge[k], t, what);
        }
    }

    /* non-finite coordinates: each component, first and last point, in
     * sources and in targets */
    for (b = 0; b < 3; b++) {
        for (k = 0; k < 3; k++) {
            int64_t idx[2], m;
            idx[0] = k;
            idx[1] = 3 * (NP - 1) + k;
            for (m = 0; m < 2; m++) {
                double save = s[idx[m]];
                s[idx[m]] = bad_values[b];
                sprintf(what, "%s in source coordinate %ld", bad_names[b], (long)idx[m]);
                expect_create_fails(api, KIFMM_ERR_NONFINITE, NULL, NP, s, NP, t, what);
                s[idx[m]] = save;
                save = t[idx[m]];
                t[idx[m]] = bad_values[b];
                sprintf(what, "%s in target coordinate %ld", bad_names[b], (long)idx[m]);
                expect_create_fails(api, KIFMM_ERR_NONFINITE, NULL, NP, s, NP, t, what);
                t[idx[m]] = save;
            }
        }
    }
    /* sources = targets, same array */
    s[5] = NAN;
    expect_create_fails(api, KIFMM_ERR_NONFINITE, NULL, NP, s, NP, s, "NaN, sources = targets");
    s[5] = 0.5;

    o = t_opts(1, 0, 0);
    expect_create_fails(api, KIFMM_ERR_ORDER, &o, NP, s, NP, t, "order 1");
    o = t_opts(-1, 0, 0);
    expect_create_fails(api, KIFMM_ERR_ORDER, &o, NP, s, NP, t, "order -1");
    o = t_opts(KIFMM_MAX_ORDER + 1, 0, 0);
    expect_create_fails(api, KIFMM_ERR_ORDER, &o, NP, s, NP, t, "order KIFMM_MAX_ORDER+1");
    o = t_opts(1000, 0, 0);
    expect_create_fails(api, KIFMM_ERR_ORDER, &o, NP, s, NP, t, "order 1000");

    o = t_opts(0, -1, 0);
    expect_create_fails(api, KIFMM_ERR_LEAF_SIZE, &o, NP, s, NP, t, "leaf_size -1");

    o = t_opts(0, 0, -1);
    expect_create_fails(api, KIFMM_ERR_DEPTH, &o, NP, s, NP, t, "max_depth -1");
    o = t_opts(0, 0, KIFMM_MAX_DEPTH + 1);
    expect_create_fails(api, KIFMM_ERR_DEPTH, &o, NP, s, NP, t, "max_depth KIFMM_MAX_DEPTH+1");

    o = t_opts(0, 0, 0);
    o.nthreads = -1;
    expect_create_fails(api, KIFMM_ERR_NTHREADS, &o, NP, s, NP, t, "nthreads -1");
    /* thread counts that would start thousands of threads are refused (they
     * crashed the OpenMP runtime or spent tens of seconds starting threads) */
    {
        static const int many[] = {KIFMM_MAX_THREADS + 1, 10000, 100000, 2147483647};
        for (k = 0; k < 4; k++) {
            o.nthreads = many[k];
            sprintf(what, "nthreads %d", many[k]);
            expect_create_fails(api, KIFMM_ERR_NTHREADS, &o, NP, s, NP, t, what);
        }
    }

    /* kernel parameters must be finite, even for a kernel that ignores them */
    for (k = 0; k < 4; k++) {
        for (b = 0; b < 3; b++) {
            o = t_opts(0, 0, 0);
            o.kernel_param[k] = bad_values[b];
            sprintf(what, "kernel_param[%d] = %s", k, bad_names[b]);
            expect_create_fails(api, KIFMM_ERR_PARAM, &o, NP, s, NP, t, what);
        }
    }

    /* an error in the options is reported even for an empty problem */
    o = t_opts(1, 0, 0);
    expect_create_fails(api, KIFMM_ERR_ORDER, &o, 0, NULL, 0, NULL, "order 1, empty problem");

    /* the inputs were only read */
    {
        t_rng r2 = t_rng_seed(21);
        double *s2 = t_doubles(3 * NP);
        t_gen_cube(&r2, NP, s2, 0.0, 1.0);
        s2[5] = 0.5;
        CHECK(memcmp(s, s2, 3 * NP * sizeof(double)) == 0, "%s source array modified",
              api->name);
        free(s2);
    }
    free(s);
    free(t);
}

static void test_evaluate_errors(const t_api *api)
{
    t_rng r = t_rng_seed(22);
    double *s = t_doubles(3 * NP), *q = t_doubles(NP), *out = t_doubles(4 * NP);
    void *h = NULL;
    kifmm_opts used;
    int rc, k, bad;

    t_gen_cube(&r, NP, s, 0.0, 1.0);
    t_gen_charges(&r, NP, q, -1.0, 1.0);
    rc = api->create(&h, NULL, NP, s, NP, s);
    CHECK(rc == KIFMM_SUCCESS, "%s create rc=%d", api->name, rc);
    if (rc != KIFMM_SUCCESS) {
        free(s); free(q); free(out);
        return;
    }

    t_fill(4 * NP, out, SENTINEL);
    rc = api->evaluate(NULL, q, out);
    bad = 0;
    for (k = 0; k < 4 * NP; k++) bad += out[k] != SENTINEL;
    CHECK(rc == KIFMM_ERR_NULL && bad == 0, "%s evaluate(NULL handle): rc=%d, %d values written",
          api->name, rc, bad);

    rc = api->evaluate(h, NULL, out);
    bad = 0;
    for (k = 0; k < 4 * NP; k++) bad += out[k] != SENTINEL;
    CHECK(rc == KIFMM_ERR_NULL && bad == 0,
          "%s evaluate(NULL densities): rc=%d, %d values written", api->name, rc, bad);

    rc = api->evaluate(h, q, NULL);
    CHECK(rc == KIFMM_ERR_NULL, "%s evaluate(NULL out): rc=%d", api->name, rc);

    rc = api->evaluate(NULL, NULL, NULL);
    CHECK(rc == KIFMM_ERR_NULL, "%s evaluate(NULL, NULL, NULL): rc=%d", api->name, rc);

    rc = api->options(NULL, &used);
    CHECK(rc == KIFMM_ERR_NULL, "%s options(NULL handle): rc=%d", api->name, rc);
    rc = api->options(h, NULL);
    CHECK(rc == KIFMM_ERR_NULL, "%s options(h, NULL): rc=%d", api->name, rc);

    /* the handle still works after the failed calls */
    rc = api->evaluate(h, q, out);
    CHECK(rc == KIFMM_SUCCESS, "%s evaluate after errors rc=%d", api->name, rc);
    if (rc == KIFMM_SUCCESS) {
        t_err e = t_error_laplace(NP, s, q, NP, s, out, api->trg_dim, NP);
        CHECK_ERR(e.pot, 4e-6, "%s evaluate after the failed calls", api->name);
    }
    api->destroy(h);

    api->destroy(NULL); /* a no-op: a crash here loses the RESULT line */

    free(s);
    free(q);
    free(out);
}

static void test_strerror(void)
{
    static const int codes[] = {KIFMM_SUCCESS,     KIFMM_ERR_NULL,      KIFMM_ERR_COUNT,
                                KIFMM_ERR_NONFINITE, KIFMM_ERR_ORDER,   KIFMM_ERR_LEAF_SIZE,
                                KIFMM_ERR_DEPTH,   KIFMM_ERR_NTHREADS,  KIFMM_ERR_PARAM,
                                KIFMM_ERR_NOMEM,   KIFMM_ERR_LAPACK,    KIFMM_ERR_INTERNAL,
                                KIFMM_ERR_KERNEL,  KIFMM_ERR_PERIOD,    KIFMM_ERR_PERIODIC,
                                KIFMM_ERR_NEUTRAL, KIFMM_ERR_TOL,       KIFMM_ERR_VERBOSE,
                                KIFMM_ERR_RANGE,   KIFMM_ERR_DENSITY,   KIFMM_ERR_OVERLAP,
                                KIFMM_ERR_OVERFLOW, KIFMM_ERR_DOMAIN,   KIFMM_ERR_TREE,
                                KIFMM_ERR_MPI,     KIFMM_ERR_FREQUENCY};
    static const int unknown[] = {1, -26, 42, -1000, 2147483647, -2147483647 - 1};
    const int nc = (int)(sizeof codes / sizeof codes[0]);
    int i, j;
    /* the documented values */
    CHECK(KIFMM_SUCCESS == 0 && KIFMM_ERR_NULL == -1 && KIFMM_ERR_COUNT == -2 &&
              KIFMM_ERR_NONFINITE == -3 && KIFMM_ERR_ORDER == -4 && KIFMM_ERR_LEAF_SIZE == -5 &&
              KIFMM_ERR_DEPTH == -6 && KIFMM_ERR_NTHREADS == -7 && KIFMM_ERR_PARAM == -8 &&
              KIFMM_ERR_NOMEM == -9 && KIFMM_ERR_LAPACK == -10 && KIFMM_ERR_INTERNAL == -11 &&
              KIFMM_ERR_KERNEL == -12 && KIFMM_ERR_PERIOD == -13 && KIFMM_ERR_PERIODIC == -14 &&
              KIFMM_ERR_NEUTRAL == -15 && KIFMM_ERR_TOL == -16 && KIFMM_ERR_VERBOSE == -17 &&
              KIFMM_ERR_RANGE == -18 && KIFMM_ERR_DENSITY == -19 && KIFMM_ERR_OVERLAP == -20 &&
              KIFMM_ERR_OVERFLOW == -21 && KIFMM_ERR_DOMAIN == -22 && KIFMM_ERR_TREE == -23 &&
              KIFMM_ERR_MPI == -24 && KIFMM_ERR_FREQUENCY == -25,
          "error code values differ from the documented ones");
    CHECK(KIFMM_MAX_ORDER == 12 && KIFMM_MAX_DEPTH == 20, "KIFMM_MAX_ORDER %d KIFMM_MAX_DEPTH %d",
          (int)KIFMM_MAX_ORDER, (int)KIFMM_MAX_DEPTH);
    for (i = 0; i < nc; i++) {
        const char *m = kifmm_strerror(codes[i]);
        CHECK(m != NULL && m[0] != '\0', "kifmm_strerror(%d) empty or NULL", codes[i]);
        if (!m) continue;
        printf("  %4d: %s\n", codes[i], m);
        for (j = 0; j < i; j++) {
            const char *m2 = kifmm_strerror(codes[j]);
            CHECK(m2 == NULL || strcmp(m, m2) != 0, "kifmm_strerror(%d) == kifmm_strerror(%d)",
                  codes[i], codes[j]);
        }
    }
    for (i = 0; i < (int)(sizeof unknown / sizeof unknown[0]); i++) {
        const char *m = kifmm_strerror(unknown[i]);
        CHECK(m != NULL && m[0] != '\0', "kifmm_strerror(%d) (unknown code) empty or NULL",
              unknown[i]);
    }
}

int main(void)
{
    t_api apis[2];
    int a;
    apis[0] = kifmm_laplace_t_api();
    apis[1] = kifmm_laplace_grad_t_api();
    t_group("create errors");
    for (a = 0; a < 2; a++) test_create_errors(&apis[a]);
    t_group("evaluate / options / destroy errors");
    for (a = 0; a < 2; a++) test_evaluate_errors(&apis[a]);
    t_group("kifmm_strerror");
    test_strerror();
    return t_finish();
}
