/* test_shipped.c - the kernels shipped beyond Laplace, single precision and
 * many density vectors per call, all against direct sums written out here:
 *   yukawa, yukawa_grad   exp(-lambda r) / (4 pi r), lambda from 0.1 to 10
 *   stokes                the Stokeslet, all three velocity components
 *   float instances       of every shipped kernel, next to the double ones
 *   evaluate_many         against separate evaluations, double and float
 *   kernel parameters     defaults (0 -> 1), negative / NaN / inf rejected
 */
#include <math.h>

#include "kifmm.h"
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"
#define KIFMM_KERNEL yukawa
#include "kifmm.h"
#define KIFMM_KERNEL yukawa_grad
#include "kifmm.h"
#define KIFMM_KERNEL stokes
#include "kifmm.h"
/* stokesm: the shipped Stokeslet with a mutual near-field hook written here
 * in plain C (kernels.md), so that the mutual pass runs for a kernel with 3
 * density components: its densities are read at 3 per point */
#define kifmm_kernel_stokesm_SRC_DIM 3
#define kifmm_kernel_stokesm_TRG_DIM 3
#define kifmm_kernel_stokesm_SCALE_INVARIANT 1
#define kifmm_kernel_stokesm_DEGREE (-1)
#define kifmm_kernel_stokesm_SETUP 1
#define kifmm_kernel_stokesm_setup kifmm_kernel__positive_setup
#define kifmm_kernel_stokesm_eval kifmm_kernel_stokes_eval
#define kifmm_kernel_stokesm_P2PS 1
static inline void kifmm_kernel_stokesm_p2ps(const double *param, const double *ax,
                                             const double *ay, const double *az,
                                             const double *qa, int64_t na, const double *bx,
                                             const double *by, const double *bz,
                                             const double *qb, int64_t nb, double scale,
                                             double *outa, double *outb)
{
    int64_t i, j;
    int a, b;
    for (i = 0; i < na; i++)
        for (j = 0; j < nb; j++) {
            double k[9]; /* G(d) = G(-d) */
            kifmm_kernel_stokes_eval(param, ax[i] - bx[j], ay[i] - by[j], az[i] - bz[j], k);
            for (a = 0; a < 3; a++)
                for (b = 0; b < 3; b++) {
                    outa[3 * i + a] += scale * k[3 * a + b] * qb[3 * j + b];
                    outb[3 * j + a] += scale * k[3 * a + b] * qa[3 * i + b];
                }
        }
}
#define KIFMM_KERNEL stokesm
#include "kifmm.h"
/* single precision instances of the same kernels, in the same unit */
#define KIFMM_KERNEL laplace
#define KIFMM_REAL float
#define KIFMM_NAME kifmm_laplacef
#include "kifmm.h"
#define KIFMM_KERNEL laplace_grad
#define KIFMM_REAL float
#define KIFMM_NAME kifmm_laplace_gradf
#include "kifmm.h"
#define KIFMM_KERNEL yukawa
#define KIFMM_REAL float
#define KIFMM_NAME kifmm_yukawaf
#include "kifmm.h"
#define KIFMM_KERNEL yukawa_grad
#define KIFMM_REAL float
#define KIFMM_NAME kifmm_yukawa_gradf
#include "kifmm.h"
#define KIFMM_KERNEL stokes
#define KIFMM_REAL float
#define KIFMM_NAME kifmm_stokesf
#include "kifmm.h"

#include "test.h"

#ifdef KIFMM_TEST_QUICK
#define N 6000
#else
#define N 16000
#endif
#define NSAMPLE 400

/* ---- independent direct sums ------------------------------------------- */

/* Kernel selector and parameter of `direct` (a plain function of the points). */
enum { K_LAPLACE, K_YUKAWA, K_STOKES };

/* res (tdim values) at y: Laplace / Yukawa potential and gradient, or the
 * Stokes velocity. q has 3 components per source for Stokes, else 1. */
static void direct(int kind, double prm, int64_t ns, const double *src, const double *q,
                   const double *y, double *res)
{
    double acc[4] = {0, 0, 0, 0};
    int64_t i;
    int a;
    for (i = 0; i < ns; i++) {
        double d[3], r;
        for (a = 0; a < 3; a++) d[a] = y[a] - src[3 * i + a];
        r = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        if (r == 0.0) continue;
        if (kind == K_STOKES) {
            const double *f = q + 3 * i;
            double df = d[0] * f[0] + d[1] * f[1] + d[2] * f[2];
            for (a = 0; a < 3; a++) acc[a] += f[a] / r + d[a] * df / (r * r * r);
        } else {
            double lam = kind == K_YUKAWA ? prm : 0.0;
            double phi = q[i] * exp(-lam * r) / r;
            double dphi = -phi * (1.0 / r + lam) / r; /* d(phi)/dr / r */
            acc[0] += phi;
            for (a = 0; a < 3; a++) acc[a + 1] += dphi * d[a];
        }
    }
    if (kind == K_STOKES)
        for (a = 0; a < 3; a++) res[a] = acc[a] / (8.0 * T_PI * prm);
    else
        for (a = 0; a < 4; a++) res[a] = acc[a] / (4.0 * T_PI);
}

/* Relative L2 errors over the sampled targets: e[0] of output column 0
 * (potential; for Stokes all three velocity components together), e[1] of
 * columns 1..3 (gradient) when tdim == 4, else e[1..3] per Stokes component. */
static void errors(int kind, double prm, int64_t ns, const double *src, const double *q,
                   int64_t nt, const double *trg, const double *out, int tdim, double *e)
{
    double num[4] = {0, 0, 0, 0}, den[4] = {0, 0, 0, 0};
    int64_t m = NSAMPLE < nt ? NSAMPLE : nt, i;
    int k;
    for (i = 0; i < m; i++) {
        int64_t j = t_sample_index(i, m, nt);
        double ref[4];
        direct(kind, prm, ns, src, q, trg + 3 * j, ref);
        for (k = 0; k < tdim; k++) {
            double d = out[j * tdim + k] - ref[k];
            int c = kind == K_STOKES ? k + 1 : (k == 0 ? 0 : 1);
            if (d != d) d = HUGE_VAL;
            num[c] += d * d;
            den[c] += ref[k] * ref[k];
            if (kind == K_STOKES) {
                num[0] += d * d;
                den[0] += ref[k] * ref[k];
            }
        }
    }
    for (k = 0; k < 4; k++) e[k] = den[k] > 0 ? sqrt(num[k] / den[k]) : sqrt(num[k]);
}

/* ---- one evaluation per instance, through a small table ------------------ */

typedef struct {
    const char *name;
    int kind, sdim, tdim, is_float;
    int (*run)(const kifmm_opts *o, int64_t ns, const double *s, int64_t nt, const double *t,
               const double *q, int nrhs, double *out, kifmm_opts *used);
} inst;

T_DEFINE_RUN(kifmm_laplace, double, 1, 1)
T_DEFINE_RUN(kifmm_laplace_grad, double, 1, 4)
T_DEFINE_RUN(kifmm_yukawa, double, 1, 1)
T_DEFINE_RUN(kifmm_yukawa_grad, double, 1, 4)
T_DEFINE_RUN(kifmm_stokes, double, 3, 3)
T_DEFINE_RUN(kifmm_stokesm, double, 3, 3)
T_DEFINE_RUN(kifmm_laplacef, float, 1, 1)
T_DEFINE_RUN(kifmm_laplace_gradf, float, 1, 4)
T_DEFINE_RUN(kifmm_yukawaf, float, 1, 1)
T_DEFINE_RUN(kifmm_yukawa_gradf, float, 1, 4)
T_DEFINE_RUN(kifmm_stokesf, float, 3, 3)

static const inst LAP = {"laplace", K_LAPLACE, 1, 1, 0, run_kifmm_laplace};
static const inst LAPG = {"laplace_grad", K_LAPLACE, 1, 4, 0, run_kifmm_laplace_grad};
static const inst YUK = {"yukawa", K_YUKAWA, 1, 1, 0, run_kifmm_yukawa};
static const inst YUKG = {"yukawa_grad", K_YUKAWA, 1, 4, 0, run_kifmm_yukawa_grad};
static const inst STK = {"stokes", K_STOKES, 3, 3, 0, run_kifmm_stokes};
static const inst STKM = {"stokes+p2ps", K_STOKES, 3, 3, 0, run_kifmm_stokesm};
static const inst LAPF = {"laplacef", K_LAPLACE, 1, 1, 1, run_kifmm_laplacef};
static const inst LAPGF = {"laplace_gradf", K_LAPLACE, 1, 4, 1, run_kifmm_laplace_gradf};
static const inst YUKF = {"yukawaf", K_YUKAWA, 1, 1, 1, run_kifmm_yukawaf};
static const inst YUKGF = {"yukawa_gradf", K_YUKAWA, 1, 4, 1, run_kifmm_yukawa_gradf};
static const inst STKF = {"stokesf", K_STOKES, 3, 3, 1, run_kifmm_stokesf};

/* Points and densities of one case; q holds 3 vectors' worth of densities. */
typedef struct {
    const char *dist;
    int64_t n;
    double *x, *q;
} pts;

static pts make(const char *dist, int64_t n, uint64_t seed)
{
    pts p;
    t_rng r = t_rng_seed(seed);
    p.dist = dist;
    p.n = n;
    p.x = t_doubles(3 * n);
    p.q = t_doubles(8 * 3 * n);
    if (strcmp(dist, "sphere") == 0) t_gen_sphere(&r, n, p.x);
    else t_gen_cube(&r, n, p.x, 0.0, 1.0);
    t_gen_charges(&r, 8 * 3 * n, p.q, -1.0, 1.0);
    return p;
}

/* One case: sources = targets = p, kernel parameter prm (0 = default, and
 * the direct sum then uses dprm), order `order`, leaf size `leaf` (0 = the
 * default). */
static void check_leaf(const inst *k, const pts *p, int order, int leaf, double prm, double dprm,
                       double bound, double gbound)
{
    kifmm_opts o = t_opts(order, leaf, 0);
    double *out = t_doubles(p->n * k->tdim), e[4], t0 = t_wall();
    int rc;
    o.kernel_param[0] = prm;
    rc = k->run(&o, p->n, p->x, p->n, p->x, p->q, 1, out, NULL);
    CHECK(rc == KIFMM_SUCCESS, "%s create/evaluate rc=%d (%s)", k->name, rc, kifmm_strerror(rc));
    if (rc == KIFMM_SUCCESS) {
        errors(k->kind, dprm, p->n, p->x, p->q, p->n, p->x, out, k->tdim, e);
        CHECK_ERR(e[0], bound, "%-13s %-6s N=%ld p=%d leaf %s param %-4g %s (%.2fs)", k->name,
                  p->dist, (long)p->n, order, leaf ? "set" : "default", dprm,
                  k->kind == K_STOKES ? "velocity" : "potential", t_wall() - t0);
        if (k->tdim == 4)
            CHECK_ERR(e[1], gbound, "%-13s %-6s gradient", k->name, p->dist);
        if (k->kind == K_STOKES) {
            CHECK_ERR(e[1], bound, "%-13s %-6s u_x", k->name, p->dist);
            CHECK_ERR(e[2], bound, "%-13s %-6s u_y", k->name, p->dist);
            CHECK_ERR(e[3], bound, "%-13s %-6s u_z", k->name, p->dist);
        }
    }
    free(out);
}

static void check(const inst *k, const pts *p, int order, double prm, double dprm,
                  double bound, double gbound)
{
    check_leaf(k, p, order, 0, prm, dprm, bound, gbound);
}

/* The Stokeslet's default leaves are larger (kifmm__default_leaf); at the
 * 16,000 points here they would leave a tree of two levels, so the rows
 * below also run with the scalar kernels' leaves, a tree as deep as theirs
 * (every pass of the far field at several levels). */
static void check_stokes(const inst *k, const pts *p, int order, double prm, double dprm,
                         double bound)
{
    check_leaf(k, p, order, kifmm__default_leaf(order, 0), prm, dprm, bound, 0);
}

/* evaluate_many(nrhs) against nrhs separate evaluate calls of a fresh handle
 * each; the two agree to rounding (sums in another order). */
static void check_many(const inst *k, const pts *p, int order, int nrhs, double bound)
{
    kifmm_opts o = t_opts(order, 0, 0);
    int64_t no = p->n * k->tdim, nq = p->n * k->sdim;
    double *many = t_doubles(nrhs * no), *one = t_doubles(no), worst = 0;
    int r, rc = k->run(&o, p->n, p->x, p->n, p->x, p->q, nrhs, many, NULL);
    CHECK(rc == KIFMM_SUCCESS, "%s evaluate_many rc=%d", k->name, rc);
    for (r = 0; r < nrhs && rc == KIFMM_SUCCESS; r++) {
        double d;
        rc = k->run(&o, p->n, p->x, p->n, p->x, p->q + r * nq, 1, one, NULL);
        CHECK(rc == KIFMM_SUCCESS, "%s evaluate rc=%d", k->name, rc);
        d = t_rel_diff(no, many + r * no, 1, one, 1);
        if (!(d <= worst)) worst = d;
    }
    CHECK_ERR(worst, bound, "%-13s evaluate_many(%d) vs %d evaluate calls, worst vector", k->name,
              nrhs, nrhs);
    /* and the last vector against the direct sum, so agreement is not
     * agreement on something wrong */
    if (rc == KIFMM_SUCCESS) {
        double e[4];
        errors(k->kind, 1.0, p->n, p->x, p->q + (nrhs - 1) * nq, p->n, p->x,
               many + (nrhs - 1) * no, k->tdim, e);
        CHECK_ERR(e[0], order <= 4 ? 1e-3 : order >= 8 ? 1e-7 : (k->is_float ? 3e-5 : 1e-5),
                  "%-13s evaluate_many(%d), last vector vs direct", k->name, nrhs);
    }
    free(many);
    free(one);
}

/* Kernel parameters: zero means the default, bad values are rejected before
 * anything is allocated. */
static void check_params(void)
{
    static const double bad[] = {-1.0, -1e-300, HUGE_VAL, -HUGE_VAL, NAN};
    double x[6] = {0, 0, 0, 1, 1, 1}, q[6] = {1, 2, 3, 4, 5, 6}, out[8];
    kifmm_opts o = t_opts(4, 0, 0), used;
    const inst *ks[] = {&YUK, &YUKG, &STK, &YUKF, &STKF};
    size_t i, j;
    for (j = 0; j < sizeof ks / sizeof ks[0]; j++) {
        int rc;
        o.kernel_param[0] = 0.0;
        rc = ks[j]->run(&o, 2, x, 2, x, q, 1, out, &used);
        CHECK(rc == 0 && used.kernel_param[0] == 1.0, "%s: parameter 0 means 1 (rc %d, got %g)",
              ks[j]->name, rc, used.kernel_param[0]);
        o.kernel_param[0] = 2.5;
        rc = ks[j]->run(&o, 2, x, 2, x, q, 1, out, &used);
        CHECK(rc == 0 && used.kernel_param[0] == 2.5, "%s: parameter 2.5 kept (rc %d)",
              ks[j]->name, rc);
        for (i = 0; i < sizeof bad / sizeof bad[0]; i++) {
            kifmm_stokes *hs = (kifmm_stokes *)&o; /* any non-NULL value: create must reset it */
            o.kernel_param[0] = bad[i];
            rc = ks[j]->run(&o, 2, x, 2, x, q, 1, out, NULL);
            CHECK(rc == KIFMM_ERR_PARAM, "%s: parameter %g rejected (rc %d)", ks[j]->name, bad[i],
                  rc);
            if (ks[j] == &STK) {
                rc = kifmm_stokes_create(&hs, &o, 2, x, 2, x);
                CHECK(rc == KIFMM_ERR_PARAM && hs == NULL, "stokes_create(mu = %g): NULL handle",
                      bad[i]);
            }
        }
    }
    o.kernel_param[0] = 0.0;
    {
        kifmm_laplace *h = NULL;
        double d[3] = {1, 1, 1}, r[3] = {7, 7, 7};
        CHECK(kifmm_laplace_create(&h, &o, 2, x, 2, x) == 0, "laplace create");
        CHECK(kifmm_laplace_evaluate_many(h, -1, d, r) == KIFMM_ERR_COUNT && r[0] == 7,
              "evaluate_many(nrhs = -1) rejected, out untouched");
        CHECK(kifmm_laplace_evaluate_many(h, 0, NULL, NULL) == KIFMM_SUCCESS,
              "evaluate_many(nrhs = 0) does nothing");
        CHECK(kifmm_laplace_evaluate_many(h, 2, NULL, r) == KIFMM_ERR_NULL && r[0] == 7,
              "evaluate_many with NULL densities rejected");
        CHECK(kifmm_laplace_evaluate_many(NULL, 2, d, r) == KIFMM_ERR_NULL, "NULL handle");
        kifmm_laplace_destroy(h);
    }
}

int main(void)
{
    double t0 = t_wall();
    pts cube = make("cube", N, 7), sph = make("sphere", N, 8);
    static const double lambdas[] = {0.1, 1.0, 10.0};
    size_t i;

    t_group("kernel parameters");
    check_params();

    t_group("yukawa exp(-lambda r)/(4 pi r), double, p = 6, lambda 0.1 .. 10");
    for (i = 0; i < sizeof lambdas / sizeof lambdas[0]; i++) {
        check(&YUK, &cube, 6, lambdas[i], lambdas[i], 1e-5, 0);
        check(&YUK, &sph, 6, lambdas[i], lambdas[i], 1e-5, 0);
    }
    check(&YUK, &cube, 6, 0.0, 1.0, 1e-5, 0); /* default lambda */
    check(&YUKG, &cube, 6, 10.0, 10.0, 1e-5, 1e-4);
    check(&YUKG, &sph, 6, 0.1, 0.1, 1e-5, 1e-4);

    t_group("stokes, double, p = 6, all three components");
    check(&STK, &cube, 6, 0.0, 1.0, 1e-5, 0);
    check_stokes(&STK, &cube, 6, 0.0, 1.0, 1e-5);
    check_stokes(&STK, &sph, 6, 0.0, 1.0, 1e-5);
    check(&STK, &cube, 6, 0.01, 0.01, 1e-5, 0); /* mu scales the result */
    /* a user kernel's mutual hook with 3 density components (sources = targets) */
    check_stokes(&STKM, &cube, 6, 0.0, 1.0, 1e-5);
#ifndef KIFMM_TEST_QUICK
    t_group("stokes, double, p = 8 and 10 (the bounds of Laplace at these orders)");
    check_stokes(&STK, &cube, 8, 0.0, 1.0, 1e-7);
    check_stokes(&STK, &sph, 8, 0.0, 1.0, 1e-7);
    check_stokes(&STK, &cube, 10, 0.0, 1.0, 5e-9);
    check_stokes(&STK, &sph, 10, 0.0, 1.0, 5e-9);
#endif

    t_group("single precision, p = 4 (bound 1e-3) and its floor at p = 6");
    check(&LAPF, &cube, 4, 0, 0, 1e-3, 0);
    check(&LAPF, &sph, 4, 0, 0, 1e-3, 0);
    check(&LAPGF, &cube, 4, 0, 0, 1e-3, 4e-3);
    check(&YUKF, &cube, 4, 1.0, 1.0, 1e-3, 0);
    check(&YUKF, &sph, 4, 10.0, 10.0, 1e-3, 0);
    check(&YUKGF, &cube, 4, 1.0, 1.0, 1e-3, 4e-3);
    check(&STKF, &cube, 4, 0, 1.0, 1e-3, 0);
    check_stokes(&STKF, &sph, 4, 0, 1.0, 1e-3);
    check(&LAPF, &cube, 6, 0, 0, 3e-5, 0);
    check(&LAPGF, &sph, 6, 0, 0, 3e-5, 3e-4);
    /* higher orders in float: the pseudo-inverses are truncated at float
     * resolution (without that, p = 8 with small leaves diverged) */
    {
        kifmm_opts o8 = t_opts(8, 16, 0);
        double *out = t_doubles(cube.n), e[4];
        int rc = run_kifmm_laplacef(&o8, cube.n, cube.x, cube.n, cube.x, cube.q, 1, out, NULL);
        CHECK(rc == KIFMM_SUCCESS, "laplacef p=8 rc=%d", rc);
        errors(K_LAPLACE, 0, cube.n, cube.x, cube.q, cube.n, cube.x, out, 1, e);
        CHECK_ERR(e[0], 3e-6, "laplacef      cube   p=8 leaf 16 (float floor)");
        free(out);
    }
    /* and the double instances of the same two kernels alongside */
    check(&LAP, &cube, 6, 0, 0, 4e-6, 0);
    check(&LAPG, &sph, 6, 0, 0, 4e-6, 4e-5);

    t_group("evaluate_many against separate evaluations");
    check_many(&LAP, &cube, 6, 3, 1e-12);
    check_many(&LAP, &cube, 8, 2, 1e-12); /* double spectra, blocks built per slab */
    check_many(&LAPG, &sph, 4, 8, 1e-12);
    check_many(&STK, &cube, 4, 2, 1e-12);
    check_many(&YUKG, &cube, 4, 9, 1e-12); /* more than one group of 8 */
    check_many(&LAPF, &cube, 4, 5, 1e-5);
    check_many(&LAPGF, &sph, 4, 8, 1e-5);

    free(cube.x); free(cube.q); free(sph.x); free(sph.q);
    printf("test_shipped: %.1fs\n", t_wall() - t0);
    return t_finish();
}
