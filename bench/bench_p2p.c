/* bench_p2p.c - pairs per second of the near-field loop, single thread: the
 * generic loop kifmm.h compiles for a kernel without a hook (a copy of
 * KIFMM__DEFINE_P2P below) against the kernels' hooks kifmm_kernel_*_p2p, for
 * laplace and laplace_grad (with their many-vector, mutual and float hooks),
 * then every shipped kernel's one-way double hook, on square blocks of nt = ns
 * targets and sources.
 *
 *   gcc -std=c99 -O2 -march=native -Wall -Wextra -Werror -pedantic -I. bench_p2p.c -o bench_p2p -lm
 *   ./bench_p2p [seconds per measurement, default 0.2]
 *
 * Each figure is the best of 5 measurements.  Run it on a quiet machine.
 */
#define _POSIX_C_SOURCE 199309L
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "kifmm_kernels.h"

#if defined(__AVX512F__)
#define BODY "AVX-512F"
#elif defined(__AVX2__) && defined(__FMA__)
#define BODY "AVX2 + FMA"
#elif defined(KIFMM_KERNEL__NEON)
#define BODY "NEON (laplace, laplace_grad; portable C for the rest)"
#else
#define BODY "portable C"
#endif

/* The generic loop of kifmm.h (KIFMM__DEFINE_P2P), SRC_DIM = 1. */
#define GENERIC_P2P(fname, kfun, dim)                                                        \
    static void fname(const double *prm, const double *tx, const double *ty,                 \
                      const double *tz, int64_t nt, const double *sx, const double *sy,      \
                      const double *sz, const double *q, int64_t ns, double scale,           \
                      double *out)                                                           \
    {                                                                                        \
        int64_t i, j;                                                                        \
        int a;                                                                               \
        for (i = 0; i < nt; i++) {                                                           \
            double acc[dim], k[dim];                                                         \
            for (a = 0; a < (dim); a++) acc[a] = 0.0;                                        \
            for (j = 0; j < ns; j++) {                                                       \
                kfun(prm, tx[i] - sx[j], ty[i] - sy[j], tz[i] - sz[j], k);                   \
                for (a = 0; a < (dim); a++) acc[a] += k[a] * q[j];                           \
            }                                                                                \
            for (a = 0; a < (dim); a++) out[i * (dim) + a] += scale * acc[a];                \
        }                                                                                    \
    }

GENERIC_P2P(generic_laplace, kifmm_kernel_laplace_eval, 1)
GENERIC_P2P(generic_laplace_grad, kifmm_kernel_laplace_grad_eval, 4)

/* The generic loop for any SRC_DIM (densities q[j * SD + s], kernel
 * k[t * SD + s]). */
#define GENERIC_SD(kname)                                                                     \
    static void gen_##kname(const double *p, const double *tx_, const double *ty_,            \
                            const double *tz_, int64_t nt, const double *sx_,                 \
                            const double *sy_, const double *sz_, const double *q_,           \
                            int64_t ns, double scale, double *out_)                           \
    {                                                                                         \
        enum { SD = kifmm_kernel_##kname##_SRC_DIM, TD = kifmm_kernel_##kname##_TRG_DIM };    \
        int64_t i, j;                                                                         \
        int a, b;                                                                             \
        for (i = 0; i < nt; i++) {                                                            \
            double acc[TD], k[TD * SD];                                                       \
            for (a = 0; a < TD; a++) acc[a] = 0.0;                                            \
            for (j = 0; j < ns; j++) {                                                        \
                kifmm_kernel_##kname##_eval(p, tx_[i] - sx_[j], ty_[i] - sy_[j],              \
                                            tz_[i] - sz_[j], k);                              \
                for (a = 0; a < TD; a++)                                                      \
                    for (b = 0; b < SD; b++) acc[a] += k[a * SD + b] * q_[j * SD + b];       \
            }                                                                                 \
            for (a = 0; a < TD; a++) out_[i * TD + a] += scale * acc[a];                      \
        }                                                                                     \
    }

typedef void (*p2p_fn)(const double *, const double *, const double *, const double *, int64_t,
                       const double *, const double *, const double *, const double *, int64_t,
                       double, double *);

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* splitmix64, uniform in [0, 1) */
static double rand01(uint64_t *s)
{
    uint64_t z = (*s += UINT64_C(0x9E3779B97F4A7C15));
    z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
    return (double)((z ^ (z >> 31)) >> 11) * (1.0 / 9007199254740992.0);
}

#define NMAX 512
#define NV 8 /* density vectors of the many-vector hooks */
static double tx[NMAX], ty[NMAX], tz[NMAX], sx[NMAX], sy[NMAX], sz[NMAX], q[NV * NMAX];
static double out[NV * 4 * NMAX];
static double checksum;
/* the kernels' parameters (lambda, k, viscosity: 1), as create resolves 0 */
static const double prm[4] = {1.0, 0.0, 0.0, 0.0};

#if (kifmm_kernel_laplace_HAS & KIFMM_HAS_P2PN) && (kifmm_kernel_laplace_grad_HAS & KIFMM_HAS_P2PN)
typedef void (*p2pn_fn)(const double *, const double *, const double *, const double *, int64_t,
                        const double *, const double *, const double *, const double *, int64_t,
                        int, size_t, double, double *, size_t);
static p2pn_fn g_many;
static int64_t g_td;
/* NV vectors per call of the many-vector hook g_many */
static void many8(const double *prm, const double *tx_, const double *ty_, const double *tz_,
                  int64_t nt, const double *sx_, const double *sy_, const double *sz_,
                  const double *q_, int64_t ns, double scale, double *out_)
{
    g_many(prm, tx_, ty_, tz_, nt, sx_, sy_, sz_, q_, ns, NV, NMAX, scale, out_,
           (size_t)(g_td * NMAX));
}
#endif

#if (kifmm_kernel_laplace_HAS & KIFMM_HAS_P2PS) && (kifmm_kernel_laplace_grad_HAS & KIFMM_HAS_P2PS)
typedef void (*p2ps_fn)(const double *, const double *, const double *, const double *,
                        const double *, int64_t, const double *, const double *, const double *,
                        const double *, int64_t, double, double *, double *);
static p2ps_fn g_mut;
static int64_t g_mtd;
/* both directions between the targets (A, charges q + NMAX) and the sources (B) */
static void mutual(const double *prm, const double *tx_, const double *ty_, const double *tz_,
                   int64_t nt, const double *sx_, const double *sy_, const double *sz_,
                   const double *q_, int64_t ns, double scale, double *out_)
{
    g_mut(prm, tx_, ty_, tz_, q_ + NMAX, nt, sx_, sy_, sz_, q_, ns, scale, out_,
          out_ + g_mtd * NMAX);
}
#endif

/* Every shipped kernel with a one-way double hook: the hook against the
 * generic loop over its eval (stokes_dl left out: its densities pass through
 * a map, so its eval is not the sum its hook computes). */
#if (kifmm_kernel_laplace_HAS & KIFMM_HAS_P2P)
GENERIC_SD(laplace)
#endif
#if (kifmm_kernel_laplace_grad_HAS & KIFMM_HAS_P2P)
GENERIC_SD(laplace_grad)
#endif
#if (kifmm_kernel_laplace_hess_HAS & KIFMM_HAS_P2P)
GENERIC_SD(laplace_hess)
#endif
#if (kifmm_kernel_laplace_dipole_HAS & KIFMM_HAS_P2P)
GENERIC_SD(laplace_dipole)
#endif
#if (kifmm_kernel_laplace_dipole_grad_HAS & KIFMM_HAS_P2P)
GENERIC_SD(laplace_dipole_grad)
#endif
#if (kifmm_kernel_laplace_cd_HAS & KIFMM_HAS_P2P)
GENERIC_SD(laplace_cd)
#endif
#if (kifmm_kernel_laplace_cd_grad_HAS & KIFMM_HAS_P2P)
GENERIC_SD(laplace_cd_grad)
#endif
#if (kifmm_kernel_laplace_cd_hess_HAS & KIFMM_HAS_P2P)
GENERIC_SD(laplace_cd_hess)
#endif
#if (kifmm_kernel_yukawa_HAS & KIFMM_HAS_P2P)
GENERIC_SD(yukawa)
#endif
#if (kifmm_kernel_yukawa_grad_HAS & KIFMM_HAS_P2P)
GENERIC_SD(yukawa_grad)
#endif
#if (kifmm_kernel_yukawa_cd_HAS & KIFMM_HAS_P2P)
GENERIC_SD(yukawa_cd)
#endif
#if (kifmm_kernel_yukawa_cd_grad_HAS & KIFMM_HAS_P2P)
GENERIC_SD(yukawa_cd_grad)
#endif
#if (kifmm_kernel_helmholtz_HAS & KIFMM_HAS_P2P)
GENERIC_SD(helmholtz)
#endif
#if (kifmm_kernel_helmholtz_grad_HAS & KIFMM_HAS_P2P)
GENERIC_SD(helmholtz_grad)
#endif
#if (kifmm_kernel_helmholtz_cd_grad_HAS & KIFMM_HAS_P2P)
GENERIC_SD(helmholtz_cd_grad)
#endif
#if (kifmm_kernel_stokes_HAS & KIFMM_HAS_P2P)
GENERIC_SD(stokes)
#endif
#if (kifmm_kernel_stokes_grad_HAS & KIFMM_HAS_P2P)
GENERIC_SD(stokes_grad)
#endif
#if (kifmm_kernel_stokes_pvel_HAS & KIFMM_HAS_P2P)
GENERIC_SD(stokes_pvel)
#endif
#if (kifmm_kernel_biot_savart_HAS & KIFMM_HAS_P2P)
GENERIC_SD(biot_savart)
#endif
#if (kifmm_kernel_biot_savart_grad_HAS & KIFMM_HAS_P2P)
GENERIC_SD(biot_savart_grad)
#endif
typedef struct {
    const char *name;
    p2p_fn gen, hook;
    int td;
} hook_row;
static const hook_row hook_rows[] = {
#if (kifmm_kernel_laplace_HAS & KIFMM_HAS_P2P)
    {"laplace", gen_laplace, kifmm_kernel_laplace_p2p, kifmm_kernel_laplace_TRG_DIM},
#endif
#if (kifmm_kernel_laplace_grad_HAS & KIFMM_HAS_P2P)
    {"laplace_grad", gen_laplace_grad, kifmm_kernel_laplace_grad_p2p, kifmm_kernel_laplace_grad_TRG_DIM},
#endif
#if (kifmm_kernel_laplace_hess_HAS & KIFMM_HAS_P2P)
    {"laplace_hess", gen_laplace_hess, kifmm_kernel_laplace_hess_p2p, kifmm_kernel_laplace_hess_TRG_DIM},
#endif
#if (kifmm_kernel_laplace_dipole_HAS & KIFMM_HAS_P2P)
    {"laplace_dipole", gen_laplace_dipole, kifmm_kernel_laplace_dipole_p2p, kifmm_kernel_laplace_dipole_TRG_DIM},
#endif
#if (kifmm_kernel_laplace_dipole_grad_HAS & KIFMM_HAS_P2P)
    {"laplace_dipole_grad", gen_laplace_dipole_grad, kifmm_kernel_laplace_dipole_grad_p2p, kifmm_kernel_laplace_dipole_grad_TRG_DIM},
#endif
#if (kifmm_kernel_laplace_cd_HAS & KIFMM_HAS_P2P)
    {"laplace_cd", gen_laplace_cd, kifmm_kernel_laplace_cd_p2p, kifmm_kernel_laplace_cd_TRG_DIM},
#endif
#if (kifmm_kernel_laplace_cd_grad_HAS & KIFMM_HAS_P2P)
    {"laplace_cd_grad", gen_laplace_cd_grad, kifmm_kernel_laplace_cd_grad_p2p, kifmm_kernel_laplace_cd_grad_TRG_DIM},
#endif
#if (kifmm_kernel_laplace_cd_hess_HAS & KIFMM_HAS_P2P)
    {"laplace_cd_hess", gen_laplace_cd_hess, kifmm_kernel_laplace_cd_hess_p2p, kifmm_kernel_laplace_cd_hess_TRG_DIM},
#endif
#if (kifmm_kernel_yukawa_HAS & KIFMM_HAS_P2P)
    {"yukawa", gen_yukawa, kifmm_kernel_yukawa_p2p, kifmm_kernel_yukawa_TRG_DIM},
#endif
#if (kifmm_kernel_yukawa_grad_HAS & KIFMM_HAS_P2P)
    {"yukawa_grad", gen_yukawa_grad, kifmm_kernel_yukawa_grad_p2p, kifmm_kernel_yukawa_grad_TRG_DIM},
#endif
#if (kifmm_kernel_yukawa_cd_HAS & KIFMM_HAS_P2P)
    {"yukawa_cd", gen_yukawa_cd, kifmm_kernel_yukawa_cd_p2p, kifmm_kernel_yukawa_cd_TRG_DIM},
#endif
#if (kifmm_kernel_yukawa_cd_grad_HAS & KIFMM_HAS_P2P)
    {"yukawa_cd_grad", gen_yukawa_cd_grad, kifmm_kernel_yukawa_cd_grad_p2p, kifmm_kernel_yukawa_cd_grad_TRG_DIM},
#endif
#if (kifmm_kernel_helmholtz_HAS & KIFMM_HAS_P2P)
    {"helmholtz", gen_helmholtz, kifmm_kernel_helmholtz_p2p, kifmm_kernel_helmholtz_TRG_DIM},
#endif
#if (kifmm_kernel_helmholtz_grad_HAS & KIFMM_HAS_P2P)
    {"helmholtz_grad", gen_helmholtz_grad, kifmm_kernel_helmholtz_grad_p2p, kifmm_kernel_helmholtz_grad_TRG_DIM},
#endif
#if (kifmm_kernel_helmholtz_cd_grad_HAS & KIFMM_HAS_P2P)
    {"helmholtz_cd_grad", gen_helmholtz_cd_grad, kifmm_kernel_helmholtz_cd_grad_p2p, kifmm_kernel_helmholtz_cd_grad_TRG_DIM},
#endif
#if (kifmm_kernel_stokes_HAS & KIFMM_HAS_P2P)
    {"stokes", gen_stokes, kifmm_kernel_stokes_p2p, kifmm_kernel_stokes_TRG_DIM},
#endif
#if (kifmm_kernel_stokes_grad_HAS & KIFMM_HAS_P2P)
    {"stokes_grad", gen_stokes_grad, kifmm_kernel_stokes_grad_p2p, kifmm_kernel_stokes_grad_TRG_DIM},
#endif
#if (kifmm_kernel_stokes_pvel_HAS & KIFMM_HAS_P2P)
    {"stokes_pvel", gen_stokes_pvel, kifmm_kernel_stokes_pvel_p2p, kifmm_kernel_stokes_pvel_TRG_DIM},
#endif
#if (kifmm_kernel_biot_savart_HAS & KIFMM_HAS_P2P)
    {"biot_savart", gen_biot_savart, kifmm_kernel_biot_savart_p2p, kifmm_kernel_biot_savart_TRG_DIM},
#endif
#if (kifmm_kernel_biot_savart_grad_HAS & KIFMM_HAS_P2P)
    {"biot_savart_grad", gen_biot_savart_grad, kifmm_kernel_biot_savart_grad_p2p, kifmm_kernel_biot_savart_grad_TRG_DIM},
#endif
    {NULL, NULL, NULL, 0}};

/* Best pairs per second of `f` on an n x n block over 5 measurements. */
static double rate(p2p_fn f, int td, int64_t n, double seconds)
{
    double best = 0.0;
    int64_t reps = 1, r;
    int m, i;
    /* calibrate: enough repetitions for about `seconds` */
    for (;;) {
        double t = now();
        for (r = 0; r < reps; r++) f(prm, tx, ty, tz, n, sx, sy, sz, q, n, 1e-3, out);
        t = now() - t;
        if (t > 0.2 * seconds) {
            reps = (int64_t)((double)reps * seconds / t) + 1;
            break;
        }
        reps *= 2;
    }
    for (m = 0; m < 5; m++) {
        double t = now(), v;
        for (r = 0; r < reps; r++) f(prm, tx, ty, tz, n, sx, sy, sz, q, n, 1e-3, out);
        t = now() - t;
        v = (double)reps * (double)n * (double)n / t;
        if (v > best) best = v;
    }
    for (i = 0; i < td * n; i++) checksum += out[i];
    return best;
}

#if (kifmm_kernel_laplace_grad_HAS & KIFMM_HAS_P2PF) && (kifmm_kernel_laplace_grad_HAS & KIFMM_HAS_P2PSF)
/* The float hooks: one-way (_p2pf) and mutual (_p2psf), laplace_grad, on the
 * same points rounded to float. */
static float fx[NMAX], fy[NMAX], fz[NMAX], gx[NMAX], gy[NMAX], gz[NMAX], fq[2 * NMAX];
static float fout[2 * 4 * NMAX];

/* The float hooks in the signature of rate(): the block is the first nt
 * points of the float copies (the double arguments are not used). */
static void float_oneway(const double *prm, const double *tx_, const double *ty_,
                         const double *tz_, int64_t nt, const double *sx_, const double *sy_,
                         const double *sz_, const double *q_, int64_t ns, double scale,
                         double *out_)
{
    (void)tx_; (void)ty_; (void)tz_; (void)sx_; (void)sy_; (void)sz_; (void)q_; (void)out_;
    kifmm_kernel_laplace_grad_p2pf(prm, fx, fy, fz, nt, gx, gy, gz, fq, ns, (float)scale, fout);
}
static void float_mutual(const double *prm, const double *tx_, const double *ty_,
                         const double *tz_, int64_t nt, const double *sx_, const double *sy_,
                         const double *sz_, const double *q_, int64_t ns, double scale,
                         double *out_)
{
    (void)tx_; (void)ty_; (void)tz_; (void)sx_; (void)sy_; (void)sz_; (void)q_; (void)out_;
    kifmm_kernel_laplace_grad_p2psf(prm, fx, fy, fz, fq + NMAX, nt, gx, gy, gz, fq, ns,
                                    (float)scale, fout, fout + 4 * NMAX);
}
#endif

int main(int argc, char **argv)
{
    static const int64_t sizes[] = {30, 64, 128, 512};
    const double seconds = argc > 1 ? atof(argv[1]) : 0.2;
    uint64_t s = 42;
    int i, k;

    /* targets and sources: two independent uniform sets in the unit cube */
    for (i = 0; i < NV * NMAX; i++) q[i] = 2.0 * rand01(&s) - 1.0;
    for (i = 0; i < NMAX; i++) {
        tx[i] = rand01(&s);
        ty[i] = rand01(&s);
        tz[i] = rand01(&s);
        sx[i] = rand01(&s);
        sy[i] = rand01(&s);
        sz[i] = rand01(&s);
    }
    printf("bench_p2p: near-field pairs per second, single thread, hook body: %s\n", BODY);
    printf("%-13s %6s %14s %14s %8s\n", "kernel", "nt=ns", "generic (1/s)", "hook (1/s)",
           "speedup");
    for (k = 0; k < 2; k++) {
        const char *name = k == 0 ? "laplace" : "laplace_grad";
        p2p_fn g = k == 0 ? generic_laplace : generic_laplace_grad;
        p2p_fn h = k == 0 ? kifmm_kernel_laplace_p2p : kifmm_kernel_laplace_grad_p2p;
        int td = k == 0 ? 1 : 4;
        for (i = 0; i < (int)(sizeof sizes / sizeof sizes[0]); i++) {
            double rg = rate(g, td, sizes[i], seconds), rh = rate(h, td, sizes[i], seconds);
            printf("%-13s %6ld %14.3e %14.3e %7.2fx\n", name, (long)sizes[i], rg, rh, rh / rg);
            fflush(stdout);
        }
    }
#if (kifmm_kernel_laplace_HAS & KIFMM_HAS_P2PN) && (kifmm_kernel_laplace_grad_HAS & KIFMM_HAS_P2PN)
    printf("\nmany-vector hooks (_p2pn), %d density vectors per call: pairs x vectors per second\n",
           NV);
    printf("%-13s %6s %14s %14s %8s\n", "kernel", "nt=ns", "_p2p (1/s)", "_p2pn (1/s)", "speedup");
    for (k = 0; k < 2; k++) {
        const char *name = k == 0 ? "laplace" : "laplace_grad";
        p2p_fn h = k == 0 ? kifmm_kernel_laplace_p2p : kifmm_kernel_laplace_grad_p2p;
        int td = k == 0 ? 1 : 4;
        g_many = k == 0 ? kifmm_kernel_laplace_p2pn : kifmm_kernel_laplace_grad_p2pn;
        g_td = td;
        for (i = 0; i < (int)(sizeof sizes / sizeof sizes[0]); i++) {
            double rh = rate(h, td, sizes[i], seconds), rm = NV * rate(many8, td, sizes[i], seconds);
            printf("%-13s %6ld %14.3e %14.3e %7.2fx\n", name, (long)sizes[i], rh, rm, rm / rh);
            fflush(stdout);
        }
    }
#endif
#if (kifmm_kernel_laplace_HAS & KIFMM_HAS_P2PS) && (kifmm_kernel_laplace_grad_HAS & KIFMM_HAS_P2PS)
    printf("\nmutual hooks (_p2ps): both directions of nt x ns pairs, against _p2p twice;\n"
           "pairs per second, each pair counted once for both directions\n");
    printf("%-13s %6s %14s %14s %8s\n", "kernel", "nt=ns", "2 x _p2p (1/s)", "_p2ps (1/s)",
           "speedup");
    for (k = 0; k < 2; k++) {
        const char *name = k == 0 ? "laplace" : "laplace_grad";
        p2p_fn h = k == 0 ? kifmm_kernel_laplace_p2p : kifmm_kernel_laplace_grad_p2p;
        int td = k == 0 ? 1 : 4;
        g_mut = k == 0 ? kifmm_kernel_laplace_p2ps : kifmm_kernel_laplace_grad_p2ps;
        g_mtd = td;
        for (i = 0; i < (int)(sizeof sizes / sizeof sizes[0]); i++) {
            double rh = 0.5 * rate(h, td, sizes[i], seconds), rm = rate(mutual, td, sizes[i], seconds);
            printf("%-13s %6ld %14.3e %14.3e %7.2fx\n", name, (long)sizes[i], rh, rm, rm / rh);
            fflush(stdout);
        }
    }
#endif
#if (kifmm_kernel_laplace_grad_HAS & KIFMM_HAS_P2PF) && (kifmm_kernel_laplace_grad_HAS & KIFMM_HAS_P2PSF)
    for (i = 0; i < NMAX; i++) {
        fx[i] = (float)tx[i]; fy[i] = (float)ty[i]; fz[i] = (float)tz[i];
        gx[i] = (float)sx[i]; gy[i] = (float)sy[i]; gz[i] = (float)sz[i];
        fq[i] = (float)q[i]; fq[NMAX + i] = (float)q[NMAX + i];
    }
    printf("\nfloat hooks, laplace_grad: _p2pf one way, _p2psf both directions (each pair\n"
           "counted once); pairs per second, and the ratio to the double hooks above\n");
    printf("%-13s %6s %14s %14s %8s %8s\n", "kernel", "nt=ns", "_p2pf (1/s)", "_p2psf (1/s)",
           "vs _p2p", "vs _p2ps");
    for (i = 0; i < (int)(sizeof sizes / sizeof sizes[0]); i++) {
        double r1 = rate(float_oneway, 4, sizes[i], seconds);
        double r2 = rate(float_mutual, 4, sizes[i], seconds);
        double d1 = rate(kifmm_kernel_laplace_grad_p2p, 4, sizes[i], seconds), d2 = 0.0;
#if (kifmm_kernel_laplace_HAS & KIFMM_HAS_P2PS) && (kifmm_kernel_laplace_grad_HAS & KIFMM_HAS_P2PS)
        g_mut = kifmm_kernel_laplace_grad_p2ps;
        g_mtd = 4;
        d2 = rate(mutual, 4, sizes[i], seconds);
#endif
        printf("%-13s %6ld %14.3e %14.3e %7.2fx %7.2fx\n", "laplace_grad", (long)sizes[i], r1, r2,
               r1 / d1, d2 > 0.0 ? r2 / d2 : 0.0);
        fflush(stdout);
    }
    for (i = 0; i < 8 * NMAX; i++) checksum += fout[i]; /* the float sums, as rate() does */
#endif
    printf("\nevery kernel's one-way double hook (_p2p) against the generic loop over its\n"
           "eval: nanoseconds per pair (parameters 1), and the ratio\n");
    printf("%-20s %6s %12s %12s %8s\n", "kernel", "nt=ns", "generic (ns)", "hook (ns)",
           "speedup");
    for (k = 0; hook_rows[k].name; k++) {
        static const int64_t hs[] = {64, 256};
        for (i = 0; i < 2; i++) {
            double rg = rate(hook_rows[k].gen, hook_rows[k].td, hs[i], seconds);
            double rh = rate(hook_rows[k].hook, hook_rows[k].td, hs[i], seconds);
            printf("%-20s %6ld %12.3f %12.3f %7.2fx\n", hook_rows[k].name, (long)hs[i], 1e9 / rg,
                   1e9 / rh, rh / rg);
            fflush(stdout);
        }
    }
    printf("(checksum %.6e)\n", checksum);
    return 0;
}
