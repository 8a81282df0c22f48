/* test_roles.c - a kernel whose source points carry something other than the
 * surface densities: the four kernel roles of docs/kernels.md named
 * explicitly. Point dipoles (3 components) to the potential and gradient (4
 * outputs), with Laplace charges on the surfaces:
 *
 *   QT  dip       dipoles -> potential and gradient    4 x 3
 *   SC  laplace   (_EQUIV)   charges -> potential      1 x 1
 *   ST  laplace_grad (_SURFACE) charges -> 4 outputs   4 x 1
 *   QC  dip_pot   (_CHECK)   dipoles -> potential      1 x 3
 *
 * against a direct sum written here from the formulas, not from the kernels'
 * eval functions; and three charges coupled by a matrix (3 x 3, no
 * symmetry of the cube turns them as a vector), against its sum here. */
#include <math.h>
#include <stdint.h>
#include "kifmm_kernels.h"

/* dipole d at s, seen at t: phi = d . r / (4 pi |r|^3), r = t - s */
#define kifmm_kernel_dip_pot_SRC_DIM 3
#define kifmm_kernel_dip_pot_TRG_DIM 1
#define kifmm_kernel_dip_pot_SCALE_INVARIANT 1
#define kifmm_kernel_dip_pot_DEGREE (-2)
static inline void kifmm_kernel_dip_pot_eval(const double *param, double dx, double dy,
                                             double dz, double *k)
{
    double r2 = dx * dx + dy * dy + dz * dz;
    double c = r2 > 0.0 ? KIFMM_INV_4PI / (r2 * sqrt(r2)) : 0.0;
    (void)param;
    k[0] = c * dx;
    k[1] = c * dy;
    k[2] = c * dz;
}

/* the potential and its gradient: grad phi = (d - 3 (d . rh) rh) / (4 pi r^3) */
#define kifmm_kernel_dip_SRC_DIM 3
#define kifmm_kernel_dip_TRG_DIM 4
#define kifmm_kernel_dip_SCALE_INVARIANT 1
#define kifmm_kernel_dip_DEGREE (-2)
#define kifmm_kernel_dip_EQUIV laplace
#define kifmm_kernel_dip_SURFACE laplace_grad
#define kifmm_kernel_dip_CHECK dip_pot
static inline void kifmm_kernel_dip_eval(const double *param, double dx, double dy, double dz,
                                         double *k)
{
    double r2 = dx * dx + dy * dy + dz * dz, d[3], c, c5;
    int i, j;
    (void)param;
    d[0] = dx;
    d[1] = dy;
    d[2] = dz;
    c = r2 > 0.0 ? KIFMM_INV_4PI / (r2 * sqrt(r2)) : 0.0;
    c5 = r2 > 0.0 ? 3.0 * c / r2 : 0.0;
    for (j = 0; j < 3; j++) k[j] = c * d[j];
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) k[3 * (i + 1) + j] = (i == j ? c : 0.0) - c5 * d[i] * d[j];
}

#define KIFMM_KERNEL dip
#include "kifmm.h"
#define KIFMM_KERNEL dip
#define KIFMM_REAL float
#include "kifmm.h"

/* A smoothed charge, erf(r / delta) / (4 pi r) (delta = param[0]), with
 * Laplace surfaces (_USE_EQUIV: the far field is Laplace's): its near field
 * is not a power of r, so its size in delta and not its units decide. */
#define kifmm_kernel_blob_SRC_DIM 1
#define kifmm_kernel_blob_TRG_DIM 1
#define kifmm_kernel_blob_SCALE_INVARIANT 0
#define kifmm_kernel_blob_DEGREE 0
#define kifmm_kernel_blob_EQUIV laplace
#define kifmm_kernel_blob_USE_EQUIV 1
static inline void kifmm_kernel_blob_eval(const double *param, double dx, double dy, double dz,
                                          double *k)
{
    const double r = sqrt(dx * dx + dy * dy + dz * dz);
    k[0] = r > 0.0 ? erf(r / param[0]) * KIFMM_INV_4PI / r : 0.0;
}
#define KIFMM_KERNEL blob
#include "kifmm.h"

/* Three charges coupled by a fixed matrix, M q / (4 pi r): three components
 * that the cube's symmetries do not turn as a vector (nor keep apart), so
 * its pseudo-inverses, spectra and M2M take no symmetry (docs/algorithm.md,
 * "Vector kernels": the probe must refuse it) */
static const double mix3_m[3][3] = {{2.0, 1.0, 0.0}, {0.5, 1.0, 0.3}, {0.0, -0.2, 1.5}};
#define kifmm_kernel_mix3_SRC_DIM 3
#define kifmm_kernel_mix3_TRG_DIM 3
#define kifmm_kernel_mix3_SCALE_INVARIANT 1
#define kifmm_kernel_mix3_DEGREE (-1)
static inline void kifmm_kernel_mix3_eval(const double *param, double dx, double dy, double dz,
                                          double *k)
{
    const double r2 = dx * dx + dy * dy + dz * dz, g = r2 > 0.0 ? KIFMM_INV_4PI / sqrt(r2) : 0.0;
    int a, b;
    (void)param;
    for (a = 0; a < 3; a++)
        for (b = 0; b < 3; b++) k[3 * a + b] = mix3_m[a][b] * g;
}
#define KIFMM_KERNEL mix3
#include "kifmm.h"

#include "test.h"

/* relative L2 errors of the potential and the gradient at nsample targets */
static void dip_errors(int64_t ns, const double *s, const double *q, int64_t nt,
                       const double *t, const double *out, int64_t nsample, double *ep,
                       double *eg)
{
    double np = 0, dp = 0, ng = 0, dg = 0;
    int64_t a, i, j;
    for (a = 0; a < nsample; a++) {
        double v[4] = {0, 0, 0, 0};
        int k;
        j = t_sample_index(a, nsample, nt);
        for (i = 0; i < ns; i++) {
            double r[3], r2, ir3, dr;
            for (k = 0; k < 3; k++) r[k] = t[3 * j + k] - s[3 * i + k];
            r2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
            if (r2 == 0.0) continue;
            ir3 = 1.0 / (4.0 * T_PI * r2 * sqrt(r2));
            dr = q[3 * i] * r[0] + q[3 * i + 1] * r[1] + q[3 * i + 2] * r[2];
            v[0] += dr * ir3;
            for (k = 0; k < 3; k++) v[1 + k] += (q[3 * i + k] - 3.0 * dr * r[k] / r2) * ir3;
        }
        np += (out[4 * j] - v[0]) * (out[4 * j] - v[0]);
        dp += v[0] * v[0];
        for (k = 1; k < 4; k++) {
            ng += (out[4 * j + k] - v[k]) * (out[4 * j + k] - v[k]);
            dg += v[k] * v[k];
        }
    }
    *ep = sqrt(np / dp);
    *eg = sqrt(ng / dg);
}

static void run(const char *name, int64_t n, const double *x, const double *y, int order,
                double bp, double bg)
{
    double *q = t_doubles(3 * n), *out = t_doubles(4 * n), ep, eg;
    t_rng r = t_rng_seed(7);
    kifmm_opts o = t_opts(order, 0, 0);
    kifmm_dip *h = NULL;
    int rc;
    t_gen_charges(&r, 3 * n, q, -1.0, 1.0);
    rc = kifmm_dip_create(&h, &o, n, x, n, y);
    if (!rc) rc = kifmm_dip_evaluate(h, q, out);
    CHECK(rc == 0, "%s: rc=%d (%s)", name, rc, kifmm_strerror(rc));
    if (!rc) {
        dip_errors(n, x, q, n, y, out, 300, &ep, &eg);
        CHECK_ERR(ep, bp, "%s, p = %d: dipole potential", name, order);
        CHECK_ERR(eg, bg, "%s, p = %d: dipole gradient", name, order);
    }
    kifmm_dip_destroy(h);
    free(q);
    free(out);
}

static void run_float(int64_t n, const double *x, int order, double bp, double bg)
{
    double *q = t_doubles(3 * n), *outd = t_doubles(4 * n), *xd = t_doubles(3 * n), ep, eg;
    float *xf = (float *)t_malloc_or_die(3 * (size_t)n * sizeof(float));
    float *qf = (float *)t_malloc_or_die(3 * (size_t)n * sizeof(float));
    float *of = (float *)t_malloc_or_die(4 * (size_t)n * sizeof(float));
    t_rng r = t_rng_seed(8);
    kifmm_opts o = t_opts(order, 0, 0);
    kifmm_dipf *h = NULL;
    int64_t i;
    int rc;
    t_gen_charges(&r, 3 * n, q, -1.0, 1.0);
    for (i = 0; i < 3 * n; i++) {
        xf[i] = (float)x[i];
        qf[i] = (float)q[i];
        xd[i] = xf[i];
        q[i] = qf[i];
    }
    rc = kifmm_dipf_create(&h, &o, n, xf, n, xf);
    if (!rc) rc = kifmm_dipf_evaluate(h, qf, of);
    CHECK(rc == 0, "float: rc=%d", rc);
    if (!rc) {
        for (i = 0; i < 4 * n; i++) outd[i] = of[i];
        dip_errors(n, xd, q, n, xd, outd, 300, &ep, &eg);
        CHECK_ERR(ep, bp, "float, uniform cube, p = %d: dipole potential", order);
        CHECK_ERR(eg, bg, "float, uniform cube, p = %d: dipole gradient", order);
    }
    kifmm_dipf_destroy(h);
    free(q);
    free(outd);
    free(xd);
    free(xf);
    free(qf);
    free(of);
}

/* The blob on [0, 1]^3 with delta = 1e-3 and on [0, 1000]^3 with delta =
 * 1, the same problem in other units: the same error (1.4e-6 at p = 6),
 * against sums in long double written here. A check of the far pairs that
 * read the blob's degree at distance 1 refused the second
 * (KIFMM_ERR_RANGE). */
static void blob_units(void)
{
    const int64_t n = 3000;
    const double len[2] = {1.0, 1000.0}, del[2] = {1e-3, 1.0};
    double *x = t_doubles(3 * n), *q = t_doubles(n), *u = t_doubles(n), e[2] = {0.0, 0.0};
    t_rng r = t_rng_seed(9);
    int64_t i, j;
    int c;
    for (i = 0; i < n; i++) q[i] = t_uniform(&r, -1.0, 1.0);
    for (c = 0; c < 2; c++) {
        kifmm_opts o = t_opts(6, 40, 0);
        long double num = 0.0L, den = 0.0L;
        int rc;
        o.kernel_param[0] = del[c];
        r = t_rng_seed(10);
        t_gen_cube(&r, n, x, 0.0, len[c]);
        {
            kifmm_blob *h = NULL;
            rc = kifmm_blob_create(&h, &o, n, x, n, x);
            if (!rc) rc = kifmm_blob_evaluate(h, q, u);
            kifmm_blob_destroy(h);
        }
        CHECK(rc == KIFMM_SUCCESS, "blob, delta %g on [0, %g]^3: %d", del[c], len[c], rc);
        if (rc) continue;
        for (i = 0; i < n; i += 15) {
            long double s = 0.0L;
            for (j = 0; j < n; j++) {
                const long double dx = (long double)x[3 * i] - x[3 * j];
                const long double dy = (long double)x[3 * i + 1] - x[3 * j + 1];
                const long double dz = (long double)x[3 * i + 2] - x[3 * j + 2];
                const long double d = sqrtl(dx * dx + dy * dy + dz * dz);
                if (j != i) s += q[j] * erfl(d / del[c]) / (4.0L * 3.141592653589793238462643383279503L * d);
            }
            num += (u[i] - s) * (u[i] - s);
            den += s * s;
        }
        e[c] = (double)sqrtl(num / den);
        CHECK_ERR(e[c], 1e-5, "blob p=6, delta %g on [0, %g]^3", del[c], len[c]);
    }
    CHECK(fabs(e[1] - e[0]) <= 1e-3 * e[0], "the same problem in other units: %.4g and %.4g", e[0], e[1]);
    free(x), free(q), free(u);
}

/* mix3 on n uniform points, order 6, against the direct sum written here
 * (M times the Laplace sums of the three charges) at 200 targets */
static void mix3_run(int64_t n, const double *x)
{
    double *q = t_doubles(3 * n), *out = t_doubles(3 * n), num = 0.0, den = 0.0;
    t_rng r = t_rng_seed(11);
    kifmm_opts o = t_opts(6, 0, 0);
    kifmm_mix3 *h = NULL;
    int64_t a, i, j;
    int rc, c, b;
    t_gen_charges(&r, 3 * n, q, -1.0, 1.0);
    rc = kifmm_mix3_create(&h, &o, n, x, n, x);
    if (!rc) rc = kifmm_mix3_evaluate(h, q, out);
    CHECK(rc == 0, "mix3: rc=%d (%s)", rc, kifmm_strerror(rc));
    for (a = 0; !rc && a < 200; a++) {
        double s[3] = {0.0, 0.0, 0.0};
        j = t_sample_index(a, 200, n);
        for (i = 0; i < n; i++) {
            const double dx = x[3 * j] - x[3 * i], dy = x[3 * j + 1] - x[3 * i + 1], dz = x[3 * j + 2] - x[3 * i + 2];
            const double r2 = dx * dx + dy * dy + dz * dz;
            if (r2 == 0.0) continue;
            for (c = 0; c < 3; c++) s[c] += q[3 * i + c] / (4.0 * T_PI * sqrt(r2));
        }
        for (c = 0; c < 3; c++) {
            double v = 0.0;
            for (b = 0; b < 3; b++) v += mix3_m[c][b] * s[b];
            num += (out[3 * j + c] - v) * (out[3 * j + c] - v), den += v * v;
        }
    }
    if (!rc) CHECK_ERR(sqrt(num / den), 1e-5, "mix3 (coupled charges, no symmetry), p = 6, %lld points", (long long)n);
    kifmm_mix3_destroy(h);
    free(q), free(out);
}

int main(void)
{
#ifdef KIFMM_TEST_QUICK
    const int64_t n = 6000;
#else
    const int64_t n = 20000;
#endif
    double *x = t_doubles(3 * n), *y = t_doubles(3 * n);
    t_rng r = t_rng_seed(5);
    t_group("kernel roles: point dipoles with Laplace surfaces (SRC_DIM 3, SD 1)");
    t_gen_cube(&r, n, x, 0.0, 1.0);
    run("uniform cube", n, x, x, 4, 2e-3, 5e-4);
    run("uniform cube", n, x, x, 6, 3e-5, 1e-5);
    run("uniform cube", n, x, x, 8, 5e-7, 1e-7);
    t_gen_sphere(&r, n, x);
    t_gen_cube(&r, n, y, -0.5, 0.5);
    run("sphere to cube", n, x, y, 6, 3e-5, 1e-5);
    t_gen_cube(&r, n, x, 0.0, 1.0);
    run_float(n, x, 6, 1.5e-4, 3e-5);
    t_group("a smoothed charge with Laplace surfaces, in two units");
    blob_units();
    t_group("three charges coupled by a matrix: no symmetry taken");
    t_gen_cube(&r, n, x, 0.0, 1.0);
    mix3_run(n, x);
    free(x);
    free(y);
    return t_finish();
}
