/* test_families.c - the Yukawa charge-and-dipole, Stokes and vortex kernels
 * of kifmm_kernels.h (yukawa_cd, yukawa_cd_grad, stokes_pvel, stokes_grad,
 * stokes_dl, biot_savart, biot_savart_grad) in double at p = 6 and in float
 * at p = 4, against direct sums in long double written here from the
 * formulas of the kernels' documentation (not from their eval functions),
 * on uniform, sphere-surface and clustered points, with sources = targets
 * and with separate targets. Relative L2 error of each output group at
 * sample targets. And stokes_dl in three periodic directions against Ewald
 * and Hasimoto sums (tests/ewald.h). */
#define KIFMM_KERNEL yukawa_cd
#include "kifmm.h"
#define KIFMM_KERNEL yukawa_cd_grad
#include "kifmm.h"
#define KIFMM_KERNEL stokes_pvel
#include "kifmm.h"
#define KIFMM_KERNEL stokes_grad
#include "kifmm.h"
#define KIFMM_KERNEL stokes_dl
#include "kifmm.h"
#define KIFMM_KERNEL biot_savart
#include "kifmm.h"
#define KIFMM_KERNEL biot_savart_grad
#include "kifmm.h"
#define KIFMM_REAL float
#define KIFMM_KERNEL yukawa_cd
#define KIFMM_NAME kifmm_yukawa_cdf
#include "kifmm.h"
#define KIFMM_REAL float
#define KIFMM_KERNEL yukawa_cd_grad
#define KIFMM_NAME kifmm_yukawa_cd_gradf
#include "kifmm.h"
#define KIFMM_REAL float
#define KIFMM_KERNEL stokes_pvel
#define KIFMM_NAME kifmm_stokes_pvelf
#include "kifmm.h"
#define KIFMM_REAL float
#define KIFMM_KERNEL stokes_grad
#define KIFMM_NAME kifmm_stokes_gradf
#include "kifmm.h"
#define KIFMM_REAL float
#define KIFMM_KERNEL stokes_dl
#define KIFMM_NAME kifmm_stokes_dlf
#include "kifmm.h"
#define KIFMM_REAL float
#define KIFMM_KERNEL biot_savart
#define KIFMM_NAME kifmm_biot_savartf
#include "kifmm.h"
#define KIFMM_REAL float
#define KIFMM_KERNEL biot_savart_grad
#define KIFMM_NAME kifmm_biot_savart_gradf
#include "kifmm.h"

#include "ewald.h"
#include "test.h"

#ifdef KIFMM_TEST_QUICK
#define N 2500
#define QUICK 1
#else
#define N 12000
#define QUICK 0
#endif
#define NSAMPLE 200
#define LAMBDA 3.0 /* yukawa's lambda */
#ifndef MU
#define MU 0.7 /* the Stokes viscosity (stokes_dl does not depend on it) */
#endif

T_DEFINE_RUN(kifmm_yukawa_cd, double, 4, 1)
T_DEFINE_RUN(kifmm_yukawa_cd_grad, double, 4, 4)
T_DEFINE_RUN(kifmm_stokes_pvel, double, 3, 4)
T_DEFINE_RUN(kifmm_stokes_grad, double, 3, 12)
T_DEFINE_RUN(kifmm_stokes_dl, double, 6, 3)
T_DEFINE_RUN(kifmm_biot_savart, double, 3, 3)
T_DEFINE_RUN(kifmm_biot_savart_grad, double, 3, 12)
T_DEFINE_RUN(kifmm_yukawa_cdf, float, 4, 1)
T_DEFINE_RUN(kifmm_yukawa_cd_gradf, float, 4, 4)
T_DEFINE_RUN(kifmm_stokes_pvelf, float, 3, 4)
T_DEFINE_RUN(kifmm_stokes_gradf, float, 3, 12)
T_DEFINE_RUN(kifmm_stokes_dlf, float, 6, 3)
T_DEFINE_RUN(kifmm_biot_savartf, float, 3, 3)
T_DEFINE_RUN(kifmm_biot_savart_gradf, float, 3, 12)
T_DEFINE_DIRECT(kifmm_yukawa_cd, double, 4, 1)
T_DEFINE_DIRECT(kifmm_yukawa_cd_grad, double, 4, 4)
T_DEFINE_DIRECT(kifmm_stokes_pvel, double, 3, 4)
T_DEFINE_DIRECT(kifmm_stokes_grad, double, 3, 12)
T_DEFINE_DIRECT(kifmm_stokes_dl, double, 6, 3)
T_DEFINE_DIRECT(kifmm_biot_savart, double, 3, 3)
T_DEFINE_DIRECT(kifmm_biot_savart_grad, double, 3, 12)
T_DEFINE_DIRECT(kifmm_yukawa_cdf, float, 4, 1)
T_DEFINE_DIRECT(kifmm_yukawa_cd_gradf, float, 4, 4)
T_DEFINE_DIRECT(kifmm_stokes_pvelf, float, 3, 4)
T_DEFINE_DIRECT(kifmm_stokes_gradf, float, 3, 12)
T_DEFINE_DIRECT(kifmm_stokes_dlf, float, 6, 3)
T_DEFINE_DIRECT(kifmm_biot_savartf, float, 3, 3)
T_DEFINE_DIRECT(kifmm_biot_savart_gradf, float, 3, 12)

typedef int (*run_fn)(const kifmm_opts *, int64_t, const double *, int64_t, const double *,
                      const double *, int, double *, kifmm_opts *);
enum { YUK, STOKES, DL, BS };
typedef struct {
    const char *name;
    int family, sd, td;
    int split;                /* outputs [0, split) and [split, td) are the two groups */
    const char *g0, *g1;      /* their names */
    double b0, b1;            /* their bounds at p = 6 */
    run_fn run, runf;
} kern;

static const kern kernels[] = {
    {"yukawa_cd", YUK, 4, 1, 1, "potential", NULL, 1e-5, 0, run_kifmm_yukawa_cd,
     run_kifmm_yukawa_cdf},
    {"yukawa_cd_grad", YUK, 4, 4, 1, "potential", "gradient", 1e-5, 1e-4, run_kifmm_yukawa_cd_grad,
     run_kifmm_yukawa_cd_gradf},
    {"stokes_pvel", STOKES, 3, 4, 1, "pressure", "velocity", 1e-5, 1e-5, run_kifmm_stokes_pvel,
     run_kifmm_stokes_pvelf},
    {"stokes_grad", STOKES, 3, 12, 3, "velocity", "gradient", 1e-5, 1e-4, run_kifmm_stokes_grad,
     run_kifmm_stokes_gradf},
    {"stokes_dl", DL, 6, 3, 3, "velocity", NULL, 1e-5, 0, run_kifmm_stokes_dl, run_kifmm_stokes_dlf},
    {"biot_savart", BS, 3, 3, 3, "velocity", NULL, 1e-5, 0, run_kifmm_biot_savart,
     run_kifmm_biot_savartf},
    {"biot_savart_grad", BS, 3, 12, 3, "velocity", "gradient", 1e-5, 1e-4,
     run_kifmm_biot_savart_grad, run_kifmm_biot_savart_gradf},
};

typedef int (*direct_fn)(const kifmm_opts *, int64_t, const double *, const double *, int64_t,
                         const double *, double *);
static const direct_fn directs[][2] = { /* in the order of kernels[] */
    {direct_kifmm_yukawa_cd, direct_kifmm_yukawa_cdf},
    {direct_kifmm_yukawa_cd_grad, direct_kifmm_yukawa_cd_gradf},
    {direct_kifmm_stokes_pvel, direct_kifmm_stokes_pvelf},
    {direct_kifmm_stokes_grad, direct_kifmm_stokes_gradf},
    {direct_kifmm_stokes_dl, direct_kifmm_stokes_dlf},
    {direct_kifmm_biot_savart, direct_kifmm_biot_savartf},
    {direct_kifmm_biot_savart_grad, direct_kifmm_biot_savart_gradf}};

/* The outputs of one source with densities w at d = target - source, all
 * of the family's (in the layouts of kifmm_kernels.h), in long double:
 *   YUK    (q, v) -> potential, gradient
 *   STOKES f -> pressure (0), velocity (1..3), du_i/dy_j (4 + 3 i + j)
 *   DL     (q, n) -> velocity
 *   BS     a -> velocity (0..2), du_i/dy_j (3 + 3 i + j) */
static void pair(int family, const long double *d, const double *w, long double *o)
{
    const long double pi4 = 4.0L * 3.141592653589793238462643383279503L;
    const long double r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2], r = sqrtl(r2);
    const long double r3 = r2 * r, r5 = r3 * r2;
    int i, j;
    if (family == YUK) {
        const long double lr = LAMBDA * r, e = expl(-lr) / pi4;
        const long double vd = w[1] * d[0] + w[2] * d[1] + w[3] * d[2];
        o[0] = w[0] * e / r + vd * e * (1.0L + lr) / r3;
        for (i = 0; i < 3; i++)
            o[1 + i] = -w[0] * e * (1.0L + lr) * d[i] / r3 + w[1 + i] * e * (1.0L + lr) / r3 -
                       vd * d[i] * e * (3.0L + 3.0L * lr + lr * lr) / r5;
    } else if (family == STOKES) {
        const long double fd = w[0] * d[0] + w[1] * d[1] + w[2] * d[2], c = 1.0L / (2.0L * pi4 * MU);
        o[0] = fd / (pi4 * r3);
        for (i = 0; i < 3; i++) {
            o[1 + i] = c * (w[i] / r + d[i] * fd / r3);
            for (j = 0; j < 3; j++) /* d/dy_j of (f_i / r + d_i (f . d) / r^3) */
                o[4 + 3 * i + j] =
                    c * (-w[i] * d[j] / r3 + ((i == j) * fd + d[i] * w[j]) / r3 -
                         3.0L * d[i] * fd * d[j] / r5);
        }
    } else if (family == DL) {
        const long double qd = w[0] * d[0] + w[1] * d[1] + w[2] * d[2];
        const long double nd = w[3] * d[0] + w[4] * d[1] + w[5] * d[2];
        for (i = 0; i < 3; i++) o[i] = -3.0L * d[i] * qd * nd / (pi4 * r5);
    } else {
        const long double u[3] = {w[1] * d[2] - w[2] * d[1], w[2] * d[0] - w[0] * d[2],
                                  w[0] * d[1] - w[1] * d[0]};
        for (i = 0; i < 3; i++) {
            o[i] = u[i] / (pi4 * r3);
            for (j = 0; j < 3; j++) { /* d/dy_j (a x d)_i = (a x e_j)_i */
                const long double axe = (i == j) ? 0.0L
                                      : ((j == (i + 2) % 3) ? w[(i + 1) % 3] : -w[(i + 2) % 3]);
                o[3 + 3 * i + j] = axe / (pi4 * r3) - 3.0L * u[i] * d[j] / (pi4 * r5);
            }
        }
    }
}

/* ref[16] at target t: the sum over the ns sources */
static void direct(int family, int sd, int64_t ns, const double *s, const double *w,
                   const double *t, double *ref)
{
    long double acc[16] = {0}, o[16];
    int64_t j;
    int m;
    for (j = 0; j < ns; j++) {
        const long double d[3] = {(long double)t[0] - s[3 * j], (long double)t[1] - s[3 * j + 1],
                                  (long double)t[2] - s[3 * j + 2]};
        if (d[0] == 0.0L && d[1] == 0.0L && d[2] == 0.0L) continue;
        pair(family, d, w + sd * j, o);
        for (m = 0; m < 13; m++) acc[m] += o[m];
    }
    for (m = 0; m < 16; m++) ref[m] = (double)acc[m];
}

/* the kernel's outputs from the family's: pvel (p, u); stokes_grad (u, grad u) */
static int out_index(const kern *K, int k)
{
    if (K->family == STOKES && K->td == 12) return 1 + k;
    return k;
}

/* relative L2 error of outputs [k0, k1) over the sample (in long double:
 * outputs of 1e-190 square to below the doubles) */
static double group_err(const kern *K, int k0, int k1, const int64_t *idx, const double *out,
                        const double *ref)
{
    long double num = 0.0L, den = 0.0L;
    int64_t i;
    int k;
    for (i = 0; i < NSAMPLE; i++)
        for (k = k0; k < k1; k++) {
            const long double rv = ref[16 * i + out_index(K, k)], e = out[idx[i] * K->td + k] - rv;
            num += e * e;
            den += rv * rv;
        }
    return (double)sqrtl(num / den);
}

/* the densities of kernel K for n sources, from uniform numbers in [-1, 1];
 * stokes_dl gets unit normals */
static void densities(const kern *K, int64_t n, t_rng *r, double *w)
{
    int64_t i;
    for (i = 0; i < n * K->sd; i++) w[i] = t_uniform(r, -1.0, 1.0);
    for (i = 0; i < n && K->family == DL; i++) {
        double *nv = w + 6 * i + 3, s;
        do {
            nv[0] = t_randn(r), nv[1] = t_randn(r), nv[2] = t_randn(r);
            s = sqrt(nv[0] * nv[0] + nv[1] * nv[1] + nv[2] * nv[2]);
        } while (s < 1e-3);
        nv[0] /= s, nv[1] /= s, nv[2] /= s;
    }
}

static void check_case(const char *dist, int separate, int with_float)
{
    const int64_t n = N, nt = separate ? N / 2 : N, na = n + (separate ? nt : 0);
    double *all = t_doubles(3 * na), *s = all, *t = separate ? all + 3 * n : s;
    double *allr = t_doubles(3 * na), *w = t_doubles(6 * n), *wr = t_doubles(6 * n);
    double *ref = t_doubles(16 * NSAMPLE), *out = t_doubles(12 * nt);
    int64_t idx[NSAMPLE], i;
    t_rng r = t_rng_seed(43 + (uint64_t)separate + 5 * (uint64_t)dist[1]);
    size_t k;
    int fl;
    if (strcmp(dist, "sphere") == 0) t_gen_sphere(&r, na, all);
    else if (strcmp(dist, "clustered") == 0) t_gen_blobs(&r, na, all);
    else t_gen_cube(&r, na, all, 0.0, 1.0);
    for (i = 0; i < NSAMPLE; i++) idx[i] = (i * 7919) % nt;
    for (k = 0; k < sizeof kernels / sizeof kernels[0]; k++) {
        const kern *K = &kernels[k];
        densities(K, n, &r, w);
        for (fl = 0; fl < 1 + with_float; fl++) {
            kifmm_opts o = t_opts(fl ? 4 : 6, 0, 0);
            int rc;
            o.kernel_param[0] = K->family == YUK ? LAMBDA : MU;
            rc = (fl ? K->runf : K->run)(&o, n, s, nt, t, w, 1, out, NULL);
            /* in float, the reference sees the inputs rounded to float */
            for (i = 0; i < 3 * na; i++) allr[i] = fl ? (float)all[i] : all[i];
            for (i = 0; i < K->sd * n; i++) wr[i] = fl ? (float)w[i] : w[i];
            for (i = 0; i < NSAMPLE; i++)
                direct(K->family, K->sd, n, allr, wr, allr + (t - s) + 3 * idx[i], ref + 16 * i);
            CHECK(rc == KIFMM_SUCCESS, "%s%s rc=%d", K->name, fl ? "f" : "", rc);
            if (rc != KIFMM_SUCCESS) continue;
            CHECK_ERR(group_err(K, 0, K->split, idx, out, ref), fl ? 1e-3 : K->b0,
                      "%s%-2s %-9s %s p=%d %s", K->name, fl ? "f" : "", dist,
                      separate ? "separate" : "same", fl ? 4 : 6, K->g0);
            if (K->g1)
                CHECK_ERR(group_err(K, K->split, K->td, idx, out, ref), fl ? 1e-3 : K->b1,
                          "%s%-2s %-9s %s", K->name, fl ? "f" : "", dist, K->g1);
        }
    }
    free(all);
    free(allr);
    free(w);
    free(wr);
    free(ref);
    free(out);
}

/* The one-way hooks of biot_savart and biot_savart_grad against the sums of
 * pair() (t_check_hooks), with the sums of |terms| of each output */
static void bs_ref(int64_t nb, const double *b, const double *q, const double *a, double *ref,
                   double *mag)
{
    const long double pi4 = 4.0L * 3.141592653589793238462643383279503L;
    long double acc[12] = {0}, am[12] = {0}, o[16];
    int64_t j;
    int i, m;
    for (j = 0; j < nb; j++) {
        const long double d[3] = {(long double)a[0] - b[3 * j], (long double)a[1] - b[3 * j + 1],
                                  (long double)a[2] - b[3 * j + 2]};
        const long double r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2], r = sqrtl(r2);
        const double *w = q + 3 * j;
        if (r2 == 0.0L) continue;
        pair(BS, d, w, o);
        for (i = 0; i < 3; i++) { /* |a_nx d_px| + |a_px d_nx|, over r^3 */
            const long double c = fabsl(w[(i + 1) % 3] * d[(i + 2) % 3]) +
                                  fabsl(w[(i + 2) % 3] * d[(i + 1) % 3]);
            acc[i] += o[i];
            am[i] += c / (pi4 * r2 * r);
            for (m = 0; m < 3; m++) {
                acc[3 + 3 * i + m] += o[3 + 3 * i + m];
                am[3 + 3 * i + m] += (i == m ? 0.0L : fabsl(w[3 - i - m])) / (pi4 * r2 * r) +
                                     3.0L * c * fabsl(d[m]) / (pi4 * r2 * r2 * r);
            }
        }
    }
    for (m = 0; m < 12; m++) ref[m] = (double)acc[m], mag[m] = (double)am[m];
}

/* The other hooks against their kernel's eval (checked against the
 * formulas by the FMM cases below), summed in long double: out_k = sum_j
 * sum_s k_ks(d_j) q_js; the error relative to the sum over j of the
 * largest |k_ts q_js| (the scale of a pair's terms: an entry of eval's
 * matrix can be a small difference that the hook forms from its terms, as
 * a_k (1 - 3 d_k^2 / r^2) of the velocity gradient's diagonal) */
typedef void (*eval_fn)(const double *, double, double, double, double *);
static eval_fn ev;
static int ev_qd, ev_td;
static double ev_param[4];
static void eval_ref(int64_t nb, const double *b, const double *q, const double *a, double *ref,
                     double *mag)
{
    const double *prm = ev_param;
    long double acc[16] = {0}, am[16] = {0};
    double k[128];
    int64_t j;
    int t, s;
    for (j = 0; j < nb; j++) {
        long double big = 0.0L;
        ev(prm, a[0] - b[3 * j], a[1] - b[3 * j + 1], a[2] - b[3 * j + 2], k);
        for (t = 0; t < ev_td; t++)
            for (s = 0; s < ev_qd; s++) {
                const long double v = (long double)k[t * ev_qd + s] * q[ev_qd * j + s];
                acc[t] += v;
                big = fabsl(v) > big ? fabsl(v) : big;
            }
        for (t = 0; t < ev_td; t++) am[t] += big;
    }
    for (t = 0; t < 16; t++) ref[t] = (double)acc[t], mag[t] = (double)am[t];
}
/* bound 1e-14 in double; for Yukawa plus the conditioning of exp(-lambda r)
 * in r (lambda r times the 3 ulp by which the hook's r = r^2 / r and
 * eval's sqrt may differ), r up to sqrt(3) here */
#define HOOK(name, qd, td) HOOK_P(name, qd, td, MU, 1e-14, kifmm_kernel_##name##_p2pf)
#define HOOK_P(name, qd, td, p0, bound, hf)                                                    \
    do {                                                                                       \
        ev_param[0] = p0;                                                                      \
        ev = kifmm_kernel_##name##_eval, ev_qd = qd, ev_td = td;                               \
        t_check_hooks(#name, qd, td, ev_param, bound, kifmm_kernel_##name##_p2p, hf, eval_ref); \
    } while (0)

/* ---- stokes_dl in three periodic directions ----------------------------------
 * The double layer u_i = sum T_ijk q_j n_k, T_ijk = -3 d_i d_j d_k / (4 pi
 * r^5), is the stress of the Stokeslet (viscosity 1): T_ijk = -delta_ik P_j
 * + d_k G_ij + d_i G_kj, G = (delta_ij / r + d_i d_j / r^3) / (8 pi), P_j =
 * d_j / (4 pi r^3) = -d_j 1 / (4 pi r). Periodic in x, y and z with period 1,
 * the reference sums each part over the images (tests/ewald.h, both sums
 * leaving out k = 0): u_i = sum_j d_j Phi_ij (Phi_ij Ewald's potential of
 * the charges n_i q_j) + sum_k d_k U^k_i + d_i sum_k U^k_k (U^k Hasimoto's
 * velocity of the forces q n_k), with the gradients of both sums written
 * out. Sources spread over the cell or crowding a corner (partly outside
 * it, so that they wrap), with separate targets, p = 6. */
#define NPER 1000
#define NPCHK 16

static void dl_ewald(int64_t ns, const double *s, const double *w, const double *t, double *ref)
{
    double *ch = t_doubles(9 * ns), *fk = t_doubles(9 * ns), *g = t_doubles(9 * 12 * NPCHK);
    int64_t m;
    int i, j, k, c;
    memset(ref, 0, 3 * NPCHK * sizeof(double));
    for (m = 0; m < ns; m++) /* charges n_i q_j (set 3 i + j), forces q n_k (set k) */
        for (i = 0; i < 3; i++)
            for (j = 0; j < 3; j++) {
                ch[9 * m + 3 * i + j] = w[6 * m + 3 + i] * w[6 * m + j];
                fk[9 * m + 3 * i + j] = w[6 * m + j] * w[6 * m + 3 + i];
            }
    t_ewald_laplace_d(ns, s, ch, 9, NPCHK, t, 1.0, 4, g);
    for (c = 0; c < NPCHK; c++)
        for (i = 0; i < 3; i++)
            for (j = 0; j < 3; j++) ref[3 * c + i] += g[4 * (9 * c + 3 * i + j) + 1 + j];
    t_ewald_stokes_d(ns, s, fk, 3, NPCHK, t, 1.0, 12, g);
    for (c = 0; c < NPCHK; c++)
        for (k = 0; k < 3; k++)
            for (i = 0; i < 3; i++) { /* d_k U^k_i + d_i U^k_k */
                const double *e = g + 12 * (3 * c + k);
                ref[3 * c + i] += e[3 + 3 * i + k] + e[3 + 3 * k + i];
            }
    free(ch);
    free(fk);
    free(g);
}

static void check_periodic_dl(int corner)
{
    const int64_t ns = NPER, nt = NPER / 2;
    double *s = t_doubles(3 * ns), *t = t_doubles(3 * nt), *w = t_doubles(6 * ns);
    double *out = t_doubles(3 * nt), tc[3 * NPCHK], ref[3 * NPCHK], num = 0.0, den = 0.0;
    kifmm_opts o = t_opts(6, 0, 0);
    t_rng r = t_rng_seed(83 + (uint64_t)corner);
    int64_t i;
    int c, rc;
    for (i = 0; i < 3 * ns; i++) s[i] = corner ? t_uniform(&r, -0.04, 0.04) : t_rand01(&r);
    for (i = 0; i < 3 * nt; i++) t[i] = corner ? t_uniform(&r, -0.04, 0.04) : t_rand01(&r);
    densities(&kernels[4], ns, &r, w);
    o.period[0] = o.period[1] = o.period[2] = 1.0;
    rc = run_kifmm_stokes_dl(&o, ns, s, nt, t, w, 1, out, NULL);
    CHECK(rc == KIFMM_SUCCESS, "stokes_dl, three periodic directions: %s", kifmm_strerror(rc));
    for (c = 0; c < NPCHK; c++) memcpy(tc + 3 * c, t + 3 * (c * nt / NPCHK), 3 * sizeof(double));
    dl_ewald(ns, s, w, tc, ref);
    for (c = 0; c < 3 * NPCHK; c++) {
        const double e = out[3 * (c / 3 * nt / NPCHK) + c % 3] - ref[c];
        num += e * e;
        den += ref[c] * ref[c];
    }
    /* five seeds of both sets: 1.5e-6 to 1.35e-5 spread, 2e-7 to 5.5e-7
     * crowding a corner; about twice the largest, as test_periodic3.c bounds
     * stokes_pvel and biot_savart */
    CHECK_ERR(rc ? 1.0 : sqrt(num / den), 3e-5, "stokes_dl, %s, separate targets: velocity",
              corner ? "crowding a corner" : "spread");
    free(s);
    free(t);
    free(w);
    free(out);
}

/* P_direct of every kernel (double and float) against the sums written
 * here: 3,000 sources in the unit cube, NSAMPLE targets, four of them at
 * sources (left out, as in evaluate); the float instances against the sums
 * of their rounded inputs. And its errors, out untouched. */
static void check_direct(void)
{
    const int64_t n = 3000, nt = NSAMPLE;
    double *s = t_doubles(3 * n), *t = t_doubles(3 * nt), *w = t_doubles(6 * n), *wr = t_doubles(6 * n);
    double *sr = t_doubles(3 * n), *tr = t_doubles(3 * nt), *ref = t_doubles(16 * nt), *out = t_doubles(12 * nt);
    int64_t idx[NSAMPLE], i;
    t_rng r = t_rng_seed(97);
    size_t k;
    int fl, rc;
    t_gen_cube(&r, n, s, 0.0, 1.0);
    t_gen_cube(&r, nt, t, 0.0, 1.0);
    memcpy(t, s, 12 * sizeof(double)); /* four targets at sources */
    for (i = 0; i < nt; i++) idx[i] = i;
    for (k = 0; k < sizeof kernels / sizeof kernels[0]; k++) {
        const kern *K = &kernels[k];
        densities(K, n, &r, w);
        for (fl = 0; fl < 2; fl++) {
            kifmm_opts o = t_opts(0, 0, 0);
            o.kernel_param[0] = K->family == YUK ? LAMBDA : MU;
            for (i = 0; i < 3 * n; i++) sr[i] = fl ? (float)s[i] : s[i];
            for (i = 0; i < 3 * nt; i++) tr[i] = fl ? (float)t[i] : t[i];
            for (i = 0; i < K->sd * n; i++) wr[i] = fl ? (float)w[i] : w[i];
            for (i = 0; i < nt; i++) direct(K->family, K->sd, n, sr, wr, tr + 3 * i, ref + 16 * i);
            rc = directs[k][fl](&o, n, s, w, nt, t, out);
            CHECK(rc == KIFMM_SUCCESS, "%s%s_direct: %s", K->name, fl ? "f" : "", kifmm_strerror(rc));
            CHECK_ERR(rc ? 1.0 : group_err(K, 0, K->td, idx, out, ref), fl ? 1e-6 : 1e-13,
                      "%s%s_direct against the sums written here", K->name, fl ? "f" : "");
        }
    }
    { /* the errors, on stokes_dl: out as it was */
        kifmm_opts o = t_opts(0, 0, 0);
        double keep;
        for (i = 0; i < 3 * nt; i++) out[i] = 7.0;
        o.period[0] = 1.0;
        CHECK(kifmm_stokes_dl_direct(&o, n, s, w, nt, t, out) == KIFMM_ERR_PERIODIC,
              "periodic options: KIFMM_ERR_PERIODIC");
        CHECK(kifmm_stokes_dl_direct(NULL, n, s, NULL, nt, t, out) == KIFMM_ERR_NULL,
              "densities NULL: KIFMM_ERR_NULL");
        CHECK(kifmm_stokes_dl_direct(NULL, -1, s, w, nt, t, out) == KIFMM_ERR_COUNT,
              "a negative count: KIFMM_ERR_COUNT");
        keep = t[5];
        t[5] = NAN;
        CHECK(kifmm_stokes_dl_direct(NULL, n, s, w, nt, t, out) == KIFMM_ERR_NONFINITE,
              "a NaN target: KIFMM_ERR_NONFINITE");
        t[5] = keep;
        o.period[0] = 0.0;
        o.nthreads = -1;
        CHECK(kifmm_stokes_dl_direct(&o, n, s, w, nt, t, out) == KIFMM_ERR_NTHREADS,
              "nthreads -1: KIFMM_ERR_NTHREADS");
        for (i = 0, keep = 0.0; i < 3 * nt; i++) keep += out[i] != 7.0;
        CHECK(keep == 0.0, "out untouched by the refused calls");
        CHECK(kifmm_stokes_dl_direct(NULL, 0, NULL, NULL, nt, t, out) == KIFMM_SUCCESS && out[0] == 0.0,
              "no sources: zeros");
    }
    free(s);
    free(t);
    free(w);
    free(wr);
    free(sr);
    free(tr);
    free(ref);
    free(out);
}

/* A small cluster far from its targets: 1,500 stokes_dl sources on a sphere
 * of radius `rad` about (0.3, 0.3, 0.3), 1,500 targets spread over [0, 1]^3,
 * p = 6. The double layer has no net force, so the cluster's far field is
 * that of its first moments, and every level between the cluster and the
 * targets' boxes passes it up (M2M). The fitted densities' sums used to
 * carry a relative error that, against the field, doubled per level: here
 * 1.6e-5 at radius 1e-3 and 3.9e-4 at 1e-6 (KIFMM_MONO_FIX 0); with the sums
 * set (__mono_fix) 1.4e-5 and 7.9e-6. */
static void check_small_cluster(double rad)
{
    const kern *K = &kernels[4];
    const int64_t n = 1500, nt = 1500;
    double *s = t_doubles(3 * n), *t = t_doubles(3 * nt), *w = t_doubles(6 * n);
    double *ref = t_doubles(16 * NSAMPLE), *out = t_doubles(3 * nt);
    int64_t idx[NSAMPLE], i;
    t_rng r = t_rng_seed(977);
    kifmm_opts o = t_opts(6, 0, 0);
    int rc;
    t_gen_sphere(&r, n, s);
    for (i = 0; i < 3 * n; i++) s[i] = 0.3 + 2.0 * rad * (s[i] - 0.5);
    t_gen_cube(&r, nt, t, 0.0, 1.0);
    densities(K, n, &r, w);
    for (i = 0; i < NSAMPLE; i++) idx[i] = (i * 7919) % nt;
    rc = K->run(&o, n, s, nt, t, w, 1, out, NULL);
    CHECK(rc == KIFMM_SUCCESS, "stokes_dl, cluster of radius %g: rc=%d", rad, rc);
    if (rc == KIFMM_SUCCESS) {
        for (i = 0; i < NSAMPLE; i++) direct(K->family, K->sd, n, s, w, t + 3 * idx[i], ref + 16 * i);
        CHECK_ERR(group_err(K, 0, 3, idx, out, ref), 1e-4, "stokes_dl, cluster of radius %g, p = 6",
                  rad);
    }
    free(s);
    free(t);
    free(w);
    free(ref);
    free(out);
}

/* stokes_dl's densities at the ends of the number range: strengths of
 * 1e200 with normals of 1e-200, products of about 1, which the passes must
 * scale as products (scaled by the strengths' size, 2^-664, the far field's
 * float M2L at p = 4 lost them: 4.2e-2 where unit densities give 2.7e-4).
 * And points spread so far apart that the loops' r^-5 (stokes_dl) or r^-3
 * (biot_savart) leaves the range: the pairs' terms vanished (zeros with
 * success); create and direct refuse with KIFMM_ERR_RANGE, and just inside
 * the limit (biot_savart 1e95, float stokes_dl 1e6) the error is a unit
 * cube's. */
static void check_far_range(void)
{
    static const struct {
        int k, fl;
        double spread;
        int inside;
    } cs[5] = {{4, 0, 1e70, 0}, {5, 0, 1e95, 1}, {5, 0, 1e110, 0}, {4, 1, 1e6, 1}, {4, 1, 1e9, 0}};
    const int64_t n = 2000;
    double *x = t_doubles(3 * n), *xs = t_doubles(3 * n), *w = t_doubles(6 * n);
    double *out = t_doubles(3 * n), *ref = t_doubles(16 * NSAMPLE);
    int64_t idx[NSAMPLE], i;
    t_rng r = t_rng_seed(77);
    int c;
    const kifmm_opts o = t_opts(4, 0, 0);
    t_gen_cube(&r, n, x, 0.0, 1.0);
    densities(&kernels[4], n, &r, w);
    for (i = 0; i < NSAMPLE; i++) idx[i] = (i * 7919) % n;
    for (c = 0; c < 2; c++) { /* (1e200, 1e-200), then (1e-200, 1e200) */
        for (i = 0; i < 6 * n; i++) w[i] *= (i % 6 < 3) == (c == 0) ? 1e200 : 1e-200;
        for (i = 0; i < NSAMPLE; i++) direct(DL, 6, n, x, w, x + 3 * idx[i], ref + 16 * i);
        CHECK(kernels[4].run(&o, n, x, n, x, w, 1, out, NULL) == KIFMM_SUCCESS,
              "stokes_dl, densities 1e200 and 1e-200");
        CHECK_ERR(group_err(&kernels[4], 0, 3, idx, out, ref), 1e-3,
                  "stokes_dl p=4, strengths 1e%d, normals 1e%d", c ? -200 : 200, c ? 200 : -200);
        for (i = 0; i < 6 * n; i++) w[i] *= (i % 6 < 3) == (c == 0) ? 1e-200 : 1e200;
    }
    for (c = 0; c < 5; c++) {
        const kern *K = &kernels[cs[c].k];
        const int fl = cs[c].fl;
        int rc;
        for (i = 0; i < 3 * n; i++)
            xs[i] = fl ? (double)(float)(x[i] * cs[c].spread) : x[i] * cs[c].spread;
        rc = (fl ? K->runf : K->run)(&o, n, xs, n, xs, w, 1, out, NULL);
        CHECK(cs[c].inside ? rc == KIFMM_SUCCESS : rc == KIFMM_ERR_RANGE,
              "%s%s, points spread over %g: %d", K->name, fl ? "f" : "", cs[c].spread, rc);
        if (!rc) {
            for (i = 0; i < NSAMPLE; i++) direct(K->family, K->sd, n, xs, w, xs + 3 * idx[i], ref + 16 * i);
            CHECK_ERR(group_err(K, 0, K->td, idx, out, ref), 1e-3, "%s%s p=4, spread %g", K->name,
                      fl ? "f" : "", cs[c].spread);
        }
        rc = directs[cs[c].k][fl](&o, n, xs, w, 1, xs, out);
        CHECK(cs[c].inside ? rc == KIFMM_SUCCESS : rc == KIFMM_ERR_RANGE, "%s%s_direct, spread %g: %d",
              K->name, fl ? "f" : "", cs[c].spread, rc);
    }
    { /* a tree built for a kernel whose powers fit (biot_savart, r^-3) at
       * 1e70 does not carry stokes_dl (r^-5) past the check */
        kifmm_biot_savart *b = NULL;
        kifmm_stokes_dl *h = NULL, *h2 = NULL;
        int rc;
        for (i = 0; i < 3 * n; i++) xs[i] = x[i] * 1e70;
        rc = kifmm_biot_savart_create(&b, &o, n, xs, n, xs);
        CHECK(rc == KIFMM_SUCCESS, "biot_savart at 1e70: %d", rc);
        if (!rc) {
            rc = kifmm_stokes_dl_create_on_tree(&h, &o, kifmm_biot_savart_tree(b));
            CHECK(rc == KIFMM_ERR_RANGE && h == NULL,
                  "stokes_dl_create_on_tree, biot_savart's tree at 1e70: %d", rc);
            for (i = 0; i < 3 * n; i++) xs[i] = x[i];
            rc = kifmm_stokes_dl_create(&h2, &o, n, xs, n, xs);
            CHECK(rc == KIFMM_SUCCESS, "stokes_dl on the unit cube: %d", rc);
            if (!rc) {
                rc = kifmm_stokes_dl_update_on_tree(h2, kifmm_biot_savart_tree(b));
                CHECK(rc == KIFMM_ERR_RANGE, "stokes_dl_update_on_tree, biot_savart's tree at 1e70: %d", rc);
                kifmm_stokes_dl_destroy(h2);
            }
            kifmm_biot_savart_destroy(b);
        }
    }
    free(x), free(xs), free(w), free(out), free(ref);
}

/* stokes_dl on cubes of side 1e-10 to 1e10 (2,000 uniform points, leaves
 * of 40, double at p = 6, float at p = 4): the error of the unit cube,
 * within 1.5 times. Its check potentials mix degrees (phi = (q . n) / (4 pi
 * r), the velocity r^-2), so a box's equivalent densities (c, f) differ by
 * a power of its size; one SVD of the surfaces' matrix mixed them at its
 * rounding, which that power then grew (before: 38.6 at side 1e-10, 3.9e-4
 * at 1e-5, 4.9e-5 at 1e10, 8.8e-6 at 1; the groups' own SVDs,
 * kifmm__pinv_groups, keep c and f apart). */
static void check_dl_scale(void)
{
    static const double side[8] = {1.0, 1e-10, 1e-5, 1e5, 1e10, 1.0, 1e-5, 1e5};
    const kern *K = &kernels[4];
    const int64_t n = 2000;
    double *x = t_doubles(3 * n), *xs = t_doubles(3 * n), *w = t_doubles(6 * n);
    double *out = t_doubles(3 * n), *ref = t_doubles(16 * NSAMPLE), unit[2] = {0.0, 0.0};
    int64_t idx[NSAMPLE], i;
    t_rng r = t_rng_seed(91);
    int c;
    t_gen_cube(&r, n, x, 0.0, 1.0);
    densities(K, n, &r, w);
    for (i = 0; i < NSAMPLE; i++) idx[i] = (i * 7919) % n;
    for (c = 0; c < 8; c++) {
        const int fl = c >= 5;
        const kifmm_opts o = t_opts(fl ? 4 : 6, 40, 0); /* four levels, a far field */
        double e;
        int rc;
        for (i = 0; i < 3 * n; i++) xs[i] = fl ? (double)(float)(x[i] * side[c]) : x[i] * side[c];
        rc = (fl ? K->runf : K->run)(&o, n, xs, n, xs, w, 1, out, NULL);
        CHECK(rc == KIFMM_SUCCESS, "stokes_dl%s on a cube of side %g: %d", fl ? "f" : "", side[c], rc);
        if (rc) continue;
        for (i = 0; i < NSAMPLE; i++) direct(DL, 6, n, xs, w, xs + 3 * idx[i], ref + 16 * i);
        e = group_err(K, 0, 3, idx, out, ref);
        if (side[c] == 1.0) unit[fl] = e;
        CHECK_ERR(e, side[c] == 1.0 ? (fl ? 1e-3 : K->b0) : 1.5 * unit[fl], "stokes_dl%s p=%d, side %g%s",
                  fl ? "f" : "", fl ? 4 : 6, side[c], side[c] == 1.0 ? "" : " (1.5 x side 1's)");
    }
    free(x), free(xs), free(w), free(out), free(ref);
}

int main(void)
{
    static const char *dists[3] = {"cube", "sphere", "clustered"};
    int d, sep;
    t_group("one-way hooks of biot_savart, biot_savart_grad");
    CHECK((kifmm_kernel_biot_savart_HAS & KIFMM_HAS_P2P) &&
              (kifmm_kernel_biot_savart_grad_HAS & KIFMM_HAS_P2PF),
          "the hooks are announced");
    t_check_hooks("biot_savart", 3, 3, NULL, 1e-14, kifmm_kernel_biot_savart_p2p,
                  kifmm_kernel_biot_savart_p2pf, bs_ref);
    t_check_hooks("biot_savart_grad", 3, 12, NULL, 1e-14, kifmm_kernel_biot_savart_grad_p2p,
                  kifmm_kernel_biot_savart_grad_p2pf, bs_ref);
    t_group("one-way hooks of the Stokes family and of the surface kernels");
    CHECK((kifmm_kernel_stokes_pvel_HAS & KIFMM_HAS_P2P) && (kifmm_kernel_stokes_dl_HAS & KIFMM_HAS_P2PF) &&
              (kifmm_kernel_stokes_grad_HAS & KIFMM_HAS_P2P),
          "the hooks are announced");
    HOOK(stokes_pvel, 3, 4);
    HOOK(stokes_grad, 3, 12);
    HOOK(stokes_dl, 9, 3);
    HOOK(_stokes_pvel_qc, 3, 4);
    HOOK(_stokes_pvel_st, 4, 4);
    HOOK(_stokes_dl_st, 4, 3);
    HOOK(_stokes_dl_qc, 9, 4);
    HOOK(_laplace3, 3, 3);
    t_group("one-way hooks of yukawa_cd, yukawa_cd_grad (double)");
    CHECK((kifmm_kernel_yukawa_cd_grad_HAS & KIFMM_HAS_P2P) && (kifmm_kernel_yukawa_cd_HAS & KIFMM_HAS_P2P),
          "the hooks are announced");
    HOOK_P(yukawa_cd, 4, 1, LAMBDA, 1e-14 + 7e-16 * LAMBDA * 1.7321, NULL);
    HOOK_P(yukawa_cd_grad, 4, 4, LAMBDA, 1e-14 + 7e-16 * LAMBDA * 1.7321, NULL);
    HOOK_P(yukawa_cd_grad, 4, 4, 40.0, 1e-14 + 7e-16 * 40.0 * 1.7321, NULL); /* exp to 1e-30 */
    /* the quick builds (every configuration but one, see tests/run.sh): two
     * of the six cases, float in the first */
    for (d = 0; d < 3; d++)
        for (sep = 0; sep < 2; sep++) {
            char name[64];
            if (QUICK && !((d == 0 && !sep) || (d == 2 && sep))) continue;
            snprintf(name, sizeof name, "%s, %s targets", dists[d], sep ? "separate" : "the source");
            t_group(name);
            check_case(dists[d], sep, !QUICK || d == 0);
        }
    t_group("stokes_dl, a small cluster far from its targets");
    check_small_cluster(1e-3);
    check_small_cluster(1e-6);
    t_group("P_direct");
    check_direct();
    t_group("stokes_dl on cubes of side 1e-10 to 1e10");
    check_dl_scale();
    t_group("densities 1e200 and 1e-200; points spread over 1e95 to 1e110 (float 1e6, 1e9)");
    check_far_range();
    t_group("stokes_dl, three periodic directions, against Ewald and Hasimoto sums, p = 6");
    check_periodic_dl(0);
    check_periodic_dl(1);
    return t_finish();
}
