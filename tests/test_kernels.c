/* test_kernels.c - several kernels in one translation unit: the shipped
 * laplace and laplace_grad, and three test-only kernels written against the
 * kernel contract:
 *   yukawa2       exp(-2 r) / (4 pi r)        not scale invariant
 *   yukawa2_grad  its potential and gradient  TRG_DIM 4, EQUIV yukawa2
 *   lap25         2.5 / (4 pi r)              scale invariant, DEGREE -1
 */
#include <math.h>

#define TEST_PI 3.14159265358979323846
#define YUKAWA_LAMBDA 2.0

/* ---- yukawa2: screened Coulomb, lambda = 2 -------------------------------- */
#define kifmm_kernel_yukawa2_SRC_DIM 1
#define kifmm_kernel_yukawa2_TRG_DIM 1
#define kifmm_kernel_yukawa2_SCALE_INVARIANT 0
#define kifmm_kernel_yukawa2_DEGREE 0
static inline void kifmm_kernel_yukawa2_eval(const double *param, double dx, double dy,
                                             double dz, double *k)
{
    double r = sqrt(dx * dx + dy * dy + dz * dz);
    (void)param;
    k[0] = r > 0.0 ? exp(-YUKAWA_LAMBDA * r) / (4.0 * TEST_PI * r) : 0.0;
}

/* ---- yukawa2_grad: potential and gradient wrt the target ----------------- */
#define kifmm_kernel_yukawa2_grad_SRC_DIM 1
#define kifmm_kernel_yukawa2_grad_TRG_DIM 4
#define kifmm_kernel_yukawa2_grad_SCALE_INVARIANT 0
#define kifmm_kernel_yukawa2_grad_DEGREE 0
#define kifmm_kernel_yukawa2_grad_EQUIV yukawa2
static inline void kifmm_kernel_yukawa2_grad_eval(const double *param, double dx, double dy,
                                                  double dz, double *k)
{
    double r = sqrt(dx * dx + dy * dy + dz * dz), e, g;
    (void)param;
    if (r == 0.0) {
        k[0] = k[1] = k[2] = k[3] = 0.0;
        return;
    }
    e = exp(-YUKAWA_LAMBDA * r) / (4.0 * TEST_PI * r);
    g = -e * (1.0 + YUKAWA_LAMBDA * r) / (r * r);
    k[0] = e;
    k[1] = g * dx;
    k[2] = g * dy;
    k[3] = g * dz;
}

/* ---- lap25: a scale-invariant kernel that is not the shipped one ---------- */
#define kifmm_kernel_lap25_SRC_DIM 1
#define kifmm_kernel_lap25_TRG_DIM 1
#define kifmm_kernel_lap25_SCALE_INVARIANT 1
#define kifmm_kernel_lap25_DEGREE (-1)
static inline void kifmm_kernel_lap25_eval(const double *param, double dx, double dy, double dz,
                                           double *k)
{
    double r = sqrt(dx * dx + dy * dy + dz * dz);
    (void)param;
    k[0] = r > 0.0 ? 2.5 / (4.0 * TEST_PI * r) : 0.0;
}

/* ---- yukp: screened Coulomb with lambda = kernel_param[0] (0: default 1) --- */
#define kifmm_kernel_yukp_SRC_DIM 1
#define kifmm_kernel_yukp_TRG_DIM 1
#define kifmm_kernel_yukp_SCALE_INVARIANT 0
#define kifmm_kernel_yukp_DEGREE 0
static inline void kifmm_kernel_yukp_eval(const double *param, double dx, double dy, double dz,
                                          double *k)
{
    double r = sqrt(dx * dx + dy * dy + dz * dz);
    double lambda = param[0] != 0.0 ? param[0] : 1.0;
    k[0] = r > 0.0 ? exp(-lambda * r) / (4.0 * TEST_PI * r) : 0.0;
}

#include "kifmm.h"
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"
#define KIFMM_KERNEL yukawa2
#include "kifmm.h"
#define KIFMM_KERNEL yukawa2_grad
#include "kifmm.h"
#define KIFMM_KERNEL lap25
#include "kifmm.h"
#define KIFMM_KERNEL yukp
#include "kifmm.h"

#include "test.h"

T_DEFINE_API(kifmm_laplace, 1)
T_DEFINE_API(kifmm_laplace_grad, 4)
T_DEFINE_API(kifmm_yukawa2, 1)
T_DEFINE_API(kifmm_yukawa2_grad, 4)
T_DEFINE_API(kifmm_lap25, 1)
T_DEFINE_API(kifmm_yukp, 1)

#ifdef KIFMM_TEST_QUICK
#define N 8000
#else
#define N 20000
#endif
#define NSAMPLE 600

/* Independent direct sums (written out here, not through the kernels above). */
static void direct_yukawa(int64_t ns, const double *src, const double *q, const double *y,
                          double *res)
{
    double p = 0, gx = 0, gy = 0, gz = 0;
    int64_t i;
    for (i = 0; i < ns; i++) {
        double dx = y[0] - src[3 * i], dy = y[1] - src[3 * i + 1], dz = y[2] - src[3 * i + 2];
        double r = sqrt(dx * dx + dy * dy + dz * dz), phi, dphi;
        if (r == 0.0) continue;
        phi = q[i] * exp(-2.0 * r) / r;
        dphi = -phi * (1.0 / r + 2.0) / r; /* d(phi)/dr / r */
        p += phi;
        gx += dphi * dx;
        gy += dphi * dy;
        gz += dphi * dz;
    }
    res[0] = p / (4.0 * T_PI);
    res[1] = gx / (4.0 * T_PI);
    res[2] = gy / (4.0 * T_PI);
    res[3] = gz / (4.0 * T_PI);
}

/* lambda for direct_yukawa_lambda (a direct evaluator takes no parameter) */
static double direct_lambda;

static void direct_yukawa_lambda(int64_t ns, const double *src, const double *q, const double *y,
                                 double *res)
{
    double p = 0;
    int64_t i;
    for (i = 0; i < ns; i++) {
        double dx = y[0] - src[3 * i], dy = y[1] - src[3 * i + 1], dz = y[2] - src[3 * i + 2];
        double r = sqrt(dx * dx + dy * dy + dz * dz);
        if (r > 0.0) p += q[i] * exp(-direct_lambda * r) / r;
    }
    res[0] = p / (4.0 * T_PI);
}

static void direct_lap25(int64_t ns, const double *src, const double *q, const double *y,
                         double *res)
{
    double p = 0;
    int64_t i;
    for (i = 0; i < ns; i++) {
        double dx = y[0] - src[3 * i], dy = y[1] - src[3 * i + 1], dz = y[2] - src[3 * i + 2];
        double r2 = dx * dx + dy * dy + dz * dz;
        if (r2 > 0.0) p += q[i] / sqrt(r2);
    }
    res[0] = 2.5 * p / (4.0 * T_PI);
}

static void check(const t_api *api, t_direct_fn fn, const kifmm_opts *o, int64_t ns,
                  const double *s, int64_t nt, const double *t, const double *q, double bound,
                  const char *what)
{
    int d = api->trg_dim, rc;
    double *out = t_doubles(nt * d), tc = 0, te = 0;
    t_fill(nt * d, out, NAN);
    rc = t_run(api, o, ns, s, nt, t, q, out, &tc, &te);
    CHECK(rc == KIFMM_SUCCESS, "%s %s rc=%d (%s)", api->name, what, rc, kifmm_strerror(rc));
    if (rc == KIFMM_SUCCESS) {
        t_err e = t_error_vs(fn, ns, s, q, nt, t, out, d, NSAMPLE);
        CHECK_ERR(e.pot, bound, "%-18s %s potential (create %.2fs eval %.2fs)", api->name, what,
                  tc, te);
        if (d == 4) CHECK_ERR(e.grad, 10 * bound, "%-18s %s gradient", api->name, what);
    }
    free(out);
}

int main(void)
{
    t_api lap = kifmm_laplace_t_api(), grd = kifmm_laplace_grad_t_api();
    t_api yuk = kifmm_yukawa2_t_api(), yukg = kifmm_yukawa2_grad_t_api();
    t_api l25 = kifmm_lap25_t_api();
    int64_t n = N, nt = N / 2;
    double *x = t_doubles(3 * n), *t = t_doubles(3 * nt), *q = t_doubles(n);
    t_rng r = t_rng_seed(41);
    kifmm_opts o = t_opts(6, 0, 0);
    double t0 = t_wall();
    char what[64];

    t_gen_cube(&r, n, x, 0.0, 1.0);
    t_gen_cube(&r, nt, t, 0.0, 1.0);
    t_gen_charges(&r, n, q, -1.0, 1.0);
    sprintf(what, "p=6 N=%ld", (long)n);

    t_group("shipped kernels in a translation unit with user kernels");
    check(&lap, t_direct_laplace, &o, n, x, n, x, q, 4e-6, what);
    check(&grd, t_direct_laplace, &o, n, x, n, x, q, 4e-6, what);

    t_group("user kernel, not scale invariant: yukawa exp(-2r)/(4 pi r)");
    check(&yuk, direct_yukawa, &o, n, x, n, x, q, 1e-5, what);
    check(&yukg, direct_yukawa, &o, n, x, n, x, q, 1e-5, what);
    check(&yuk, direct_yukawa, &o, n, x, nt, t, q, 1e-5, "p=6 separate targets");
    /* a larger domain: more levels with distinct operators, and a stronger
     * screening across the box */
    {
        double *xb = t_doubles(3 * n);
        int64_t i;
        for (i = 0; i < 3 * n; i++) xb[i] = 8.0 * x[i];
        check(&yuk, direct_yukawa, &o, n, xb, n, xb, q, 1e-5, "p=6 cube of side 8");
        t_gen_blobs(&r, n, xb);
        check(&yuk, direct_yukawa, &o, n, xb, n, xb, q, 1e-5, "p=6 blobs");
        free(xb);
    }

    t_group("user kernel reading kernel_param: exp(-lambda r)/(4 pi r)");
    {
        t_api yp = kifmm_yukp_t_api();
        kifmm_opts op = t_opts(6, 0, 0);
        direct_lambda = 1.0; /* kernel_param[0] = 0: the kernel's default */
        check(&yp, direct_yukawa_lambda, &op, n, x, nt, t, q, 1e-5, "p=6 lambda default (1)");
        op.kernel_param[0] = 3.0;
        direct_lambda = 3.0;
        check(&yp, direct_yukawa_lambda, &op, n, x, nt, t, q, 1e-5, "p=6 lambda 3");
    }

    t_group("user kernel, scale invariant: 2.5/(4 pi r)");
    check(&l25, direct_lap25, &o, n, x, n, x, q, 4e-6, what);
    check(&l25, direct_lap25, &o, n, x, nt, t, q, 4e-6, "p=6 separate targets");

    free(x);
    free(t);
    free(q);
    printf("test_kernels: %.1fs\n", t_wall() - t0);
    return t_finish();
}
