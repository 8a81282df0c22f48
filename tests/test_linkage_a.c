/* test_linkage_a.c - a program linked against libkifmm_linkage.a (see
 * tests/test_linkage.h): it sees the library's instances through their
 * declarations only. Laplace in double and the Stokeslet in float, each
 * against a direct sum of its own. */
#include "test_linkage.h"

/* The declarations need neither LAPACKE's nor CBLAS's headers. */
#if defined(LAPACK_ROW_MAJOR) || defined(CBLAS_H) || defined(CBLAS_INDEX)
#error "KIFMM_DECLARE included the BLAS or LAPACK headers"
#endif

#include "test.h"

/* u(y) = sum_x (f / r + (d . f) d / r^3) / (8 pi), d = y - x, viscosity 1 */
static double stokes_error(int64_t n, const double *x, const double *f, const float *u,
                           int64_t nsample)
{
    double num = 0.0, den = 0.0;
    int64_t s, i, j;
    for (s = 0; s < nsample; s++) {
        double v[3] = {0.0, 0.0, 0.0};
        int k;
        j = t_sample_index(s, nsample, n);
        for (i = 0; i < n; i++) {
            double d[3], r2, r, df;
            for (k = 0; k < 3; k++) d[k] = x[3 * j + k] - x[3 * i + k];
            r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            if (r2 == 0.0) continue;
            r = sqrt(r2);
            df = d[0] * f[3 * i] + d[1] * f[3 * i + 1] + d[2] * f[3 * i + 2];
            for (k = 0; k < 3; k++) v[k] += (f[3 * i + k] / r + df * d[k] / (r2 * r)) / (8.0 * T_PI);
        }
        for (k = 0; k < 3; k++) {
            num += (u[3 * j + k] - v[k]) * (u[3 * j + k] - v[k]);
            den += v[k] * v[k];
        }
    }
    return sqrt(num / den);
}

int main(void)
{
    const int64_t n = 8000;
    double *x = t_doubles(3 * n), *q = t_doubles(3 * n), *pot = t_doubles(n);
    float *xf = (float *)t_malloc_or_die(3 * (size_t)n * sizeof(float));
    float *ff = (float *)t_malloc_or_die(3 * (size_t)n * sizeof(float));
    float *uf = (float *)t_malloc_or_die(3 * (size_t)n * sizeof(float));
    t_rng r = t_rng_seed(41);
    kifmm_opts o;
    kifmm_laplace *h = NULL;
    lib_stokes *hs = NULL;
    kifmm_stats st;
    int rc, i;

    t_group("a program linked against a library of instances (KIFMM_DECLARE)");
    memset(&o, 0, sizeof o);
    o.order = 6;
    t_gen_cube(&r, n, x, 0.0, 1.0);
    t_gen_charges(&r, n, q, -1.0, 1.0);
    rc = kifmm_laplace_create(&h, &o, n, x, n, x);
    if (rc == KIFMM_SUCCESS) rc = kifmm_laplace_evaluate(h, q, pot);
    CHECK(rc == KIFMM_SUCCESS, "kifmm_laplace from the library: %s", kifmm_strerror(rc));
    if (rc == KIFMM_SUCCESS) {
        CHECK_ERR(t_error_laplace(n, x, q, n, x, pot, 1, 300).pot, 1e-5,
                  "library laplace, p = 6, %lld uniform points", (long long)n);
        rc = kifmm_laplace_stats(h, &st);
        CHECK(rc == KIFMM_SUCCESS && st.levels > 2 && st.bytes > 0.0,
              "stats through the library: %d levels, %.1f MiB", st.levels, st.bytes / 1048576.0);
    }
    kifmm_laplace_destroy(h);

    /* the float Stokeslet under its own prefix */
    for (i = 0; i < 3 * n; i++) q[i] = t_uniform(&r, -1.0, 1.0);
    for (i = 0; i < 3 * n; i++) {
        xf[i] = (float)x[i];
        ff[i] = (float)q[i];
        x[i] = xf[i]; /* the reference sums the points the library sees */
        q[i] = ff[i];
    }
    o.order = 5;
    rc = lib_stokes_create(&hs, &o, n, xf, n, xf);
    if (rc == KIFMM_SUCCESS) rc = lib_stokes_evaluate(hs, ff, uf);
    CHECK(rc == KIFMM_SUCCESS, "lib_stokes (float) from the library: %s", kifmm_strerror(rc));
    if (rc == KIFMM_SUCCESS)
        CHECK_ERR(stokes_error(n, x, q, uf, 200), 3e-4, "library Stokeslet in float, p = 5");
    lib_stokes_destroy(hs);

    free(x);
    free(q);
    free(pot);
    free(xf);
    free(ff);
    free(uf);
    return t_finish();
}
