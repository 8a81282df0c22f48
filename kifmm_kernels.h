/* kifmm_kernels.h - kernels shipped with kifmm.h
 *
 * A kernel NAME is a handful of definitions with the prefix kifmm_kernel_NAME_
 * (the contract is in docs/kernels.md):
 *
 *   kifmm_kernel_NAME_SRC_DIM          density components per source point
 *   kifmm_kernel_NAME_TRG_DIM          output components per target point
 *   kifmm_kernel_NAME_SCALE_INVARIANT  1 if K(a d) = a^DEGREE K(d) for a > 0
 *   kifmm_kernel_NAME_DEGREE           that degree (read only when invariant)
 *   kifmm_kernel_NAME_EQUIV            (only when TRG_DIM != SRC_DIM) the kernel
 *                                      used on check and equivalent surfaces
 *   kifmm_kernel_NAME_eval(param, dx, dy, dz, k)
 *       k[t * SRC_DIM + s] for the displacement d = target - source; zero at d = 0.
 *   kifmm_kernel_NAME_P2P              (optional) 1 when the kernel has a near-field
 *   kifmm_kernel_NAME_p2p(...)         hook, used for every direct interaction
 *                                      (see "Near-field hooks" below)
 *
 * kifmm.h includes this file itself; including it again is harmless.
 */
#ifndef KIFMM_KERNELS_H
#define KIFMM_KERNELS_H

/* The system headers keep C++ linkage when a C++ host wraps the include of
 * kifmm.h in extern "C" (they declare templates in C++ builds). */
#ifdef __cplusplus
extern "C++" {
#endif
#include <float.h>
#include <math.h>
#include <stdint.h>
#if defined(__AVX2__) && defined(__FMA__)
#include <immintrin.h>
#elif defined(__aarch64__) && defined(__ARM_NEON)
#include <arm_neon.h>
/* aarch64: the hooks written on the vector layer (>>vector) use Advanced
 * SIMD; the others are the portable loops. */
#define KIFMM_KERNEL__NEON 1
#endif
#ifdef __cplusplus
}
#endif

/* g++ 12 reports the _mm*_undefined_* placeholders inside its own AVX-512
 * intrinsics (shuffles, extracts, rsqrt14) as maybe uninitialized when they
 * are inlined into C++ code (GCC bug 105593, fixed in GCC 13): silenced for
 * the code of this file and kifmm.h only, restored at their ends. */
#if defined(__GNUC__) && !defined(__clang__) && defined(__cplusplus)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#endif

#define KIFMM_INV_4PI 0.07957747154594766788444188168625718 /* 1 / (4 pi) */

/* A kernel's optional features, for its mask
 *   #define kifmm_kernel_NAME_HAS (KIFMM_HAS_SETUP | KIFMM_HAS_P2P | ...)
 * (in parentheses; docs/kernels.md): a setup function for its parameters,
 * and near-field hooks in double and float (F): one-way, for several density
 * vectors (N), mutual (S: both directions between two sets of points), and
 * mutual for several vectors (SN); and a map from the caller's densities to
 * the ones the kernel is linear in (DENSITY: kifmm_kernel_NAME_DENSITY_DIM
 * and kifmm_kernel_NAME_density(param, in, out), stokes_dl); and RADIAL, a
 * one-component or complex kernel that depends on |d| alone (laplace,
 * yukawa, helmholtz), whose M2L spectra are then built for 16 transfer
 * vectors and turned to the other 300, M2M and L2L mirrored from one
 * octant, and pseudo-inverses taken block by block, by the cube's
 * symmetries; and TOL, the kernel's own errors per order
 * for opts.tol (kifmm_kernel_NAME_TOL_ERRORS, an initializer of
 * KIFMM_MAX_ORDER + 1 numbers: the largest relative L2 error of its worst
 * output measured at each order, 0 where not measured (orders 0 and 1
 * always), which tol never takes; without it, laplace's table; for a WAVES
 * kernel a table per order and width, KIFMM_MAX_ORDER + 1 rows of
 * KIFMM_TOL_WAVES_NW + 1: the errors with the widest expansions
 * KIFMM_TOL_WAVES_WIDTHS wavelengths wide, those below the order's limit,
 * and at the limit last); and WAVES,
 * an oscillating kernel (helmholtz): kifmm_kernel_NAME_wavenumber(param)
 * gives the real part of its wavenumber, from which create refuses boxes
 * too many wavelengths wide for the order (KIFMM_ERR_FREQUENCY) and moves
 * each level's inner surfaces off their interior resonances, and periodic
 * options are refused; and COMPLEX, a two-component kernel that is the real
 * 2 x 2 form of one complex value G (densities and outputs (re, im) pairs,
 * k = {Re G, -Im G, Im G, Re G}), whose FFT M2L then runs on complex
 * spectra of the full grid, one product a frequency (with RADIAL as well:
 * G depends on |d| alone, spectra built for 16 transfer vectors). A
 * misspelt bit stops the build. */
#define KIFMM_HAS_SETUP 1
#define KIFMM_HAS_P2P 2
#define KIFMM_HAS_P2PF 4
#define KIFMM_HAS_P2PN 8
#define KIFMM_HAS_P2PNF 16
#define KIFMM_HAS_P2PS 32
#define KIFMM_HAS_P2PSF 64
#define KIFMM_HAS_P2PSN 128
#define KIFMM_HAS_P2PSNF 256
#define KIFMM_HAS_DENSITY 512
#define KIFMM_HAS_RADIAL 1024
#define KIFMM_HAS_EWALD 2048
#define KIFMM_HAS_BACKGROUND 4096
#define KIFMM_HAS_TOL 8192
#define KIFMM_HAS_WAVES 16384
#define KIFMM_HAS_COMPLEX 32768
#define KIFMM_HAS_ALL 65535

/* The widths (wavelengths across the widest boxes that carry expansions)
 * at which a WAVES kernel's opts.tol table is measured (HAS_TOL above) */
#define KIFMM_TOL_WAVES_NW 7
#define KIFMM_TOL_WAVES_WIDTHS {0.02, 0.25, 0.5, 0.75, 1.0, 1.25, 1.5}

/* Three periodic directions (docs/api.md) need two more hooks of a
 * scale-invariant kernel. EWALD, on the surface kernel (SD x SD, k[a SD +
 * b]): kifmm_kernel_NAME_ewald(param, alpha, part, x, y, z, k) splits the
 * kernel G = R + S at alpha into a real-space part R (part
 * KIFMM_EWALD_REAL, at the offset (x, y, z)) that decays like exp(-(alpha
 * r)^2) and a smooth part S (KIFMM_EWALD_SMOOTH, finite at 0), gives S's
 * Fourier transform at the wave vector (x, y, z) != 0 (KIFMM_EWALD_FOURIER,
 * so that the lattice sum of G over a cell of volume V is sum_n R(d + n L)
 * + (1 / V) sum_{k != 0} F(k) cos(k . d) + c0 / V) and c0 = -integral of R
 * over space (KIFMM_EWALD_MEAN: the field then has zero mean over the
 * cell). BACKGROUND, on the surface kernel and the kernel itself (rows as
 * the kernel's outputs, columns as its densities): a particular field, a
 * polynomial of degree <= 2 in d, of a unit density of each kind spread
 * uniformly over space (laplace: |d|^2 / 6, as -lap (|d|^2 / 6) = -1; the
 * Stokeslet's velocity: 0, a pressure gradient balances a uniform force),
 * derived from it as the kernel is from its surface kernel. */
#define KIFMM_EWALD_REAL 0
#define KIFMM_EWALD_SMOOTH 1
#define KIFMM_EWALD_FOURIER 2
#define KIFMM_EWALD_MEAN 3
#define KIFMM_KERNEL__PER (KIFMM_HAS_EWALD | KIFMM_HAS_BACKGROUND)

/* laplace: phi(y) = q / (4 pi |y - x|). */
#define kifmm_kernel_laplace_SRC_DIM 1
#define kifmm_kernel_laplace_TRG_DIM 1
#define kifmm_kernel_laplace_SCALE_INVARIANT 1
#define kifmm_kernel_laplace_DEGREE (-1)
static inline void kifmm_kernel_laplace_eval(const double *param, double dx,
                                             double dy, double dz, double *k)
{
    double r2 = dx * dx + dy * dy + dz * dz;
    (void)param;
    k[0] = r2 > 0.0 ? KIFMM_INV_4PI / sqrt(r2) : 0.0;
}

/* laplace_grad: the potential and its gradient with respect to the target,
 * k = (1, -dx / r^2, -dy / r^2, -dz / r^2) / (4 pi r). */
#define kifmm_kernel_laplace_grad_SRC_DIM 1
#define kifmm_kernel_laplace_grad_TRG_DIM 4
#define kifmm_kernel_laplace_grad_SCALE_INVARIANT 1
#define kifmm_kernel_laplace_grad_DEGREE (-1)
#define kifmm_kernel_laplace_grad_EQUIV laplace
static inline void kifmm_kernel_laplace_grad_eval(const double *param, double dx,
                                                  double dy, double dz, double *k)
{
    double r2 = dx * dx + dy * dy + dz * dz;
    double inv = r2 > 0.0 ? 1.0 / sqrt(r2) : 0.0;
    double inv3 = KIFMM_INV_4PI * inv * inv * inv;
    (void)param;
    k[0] = KIFMM_INV_4PI * inv;
    k[1] = -dx * inv3;
    k[2] = -dy * inv3;
    k[3] = -dz * inv3;
}

/* Setup of a kernel whose param[0] must be positive, 0 meaning 1: lambda
 * of yukawa. Nonzero (KIFMM_ERR_PARAM) for a bad value. */
static inline int kifmm_kernel__positive_setup(const double *in, double *out)
{
    out[0] = in[0] == 0.0 ? 1.0 : in[0];
    out[1] = out[2] = out[3] = 0.0;
    return out[0] > 0.0 && out[0] <= 1e300 ? 0 : -1;
}

/* The same for a viscosity (mu of the Stokes kernels), in [1e-150, 1e150]:
 * 1 / (8 pi mu) and the velocities of any sensible forces stay far from
 * overflow and from the subnormal range. */
static inline int kifmm_kernel__viscosity_setup(const double *in, double *out)
{
    out[0] = in[0] == 0.0 ? 1.0 : in[0];
    out[1] = out[2] = out[3] = 0.0;
    return out[0] >= 1e-150 && out[0] <= 1e150 ? 0 : -1;
}

/* yukawa: the modified Helmholtz (screened Coulomb) potential
 * phi(y) = q exp(-lambda |y - x|) / (4 pi |y - x|), lambda = param[0] > 0
 * (0 = the default, 1). Not scale invariant: operators are built per level. */
#define kifmm_kernel_yukawa_SRC_DIM 1
#define kifmm_kernel_yukawa_TRG_DIM 1
#define kifmm_kernel_yukawa_SCALE_INVARIANT 0
#define kifmm_kernel_yukawa_DEGREE 0
#define kifmm_kernel_yukawa_HAS (KIFMM_KERNEL__YUKAWA_HAS | KIFMM_HAS_RADIAL | KIFMM_HAS_TOL) /* below */
#define kifmm_kernel_yukawa_TOL_ERRORS KIFMM_KERNEL__TOL_YUKAWA
#define kifmm_kernel_yukawa_setup kifmm_kernel__positive_setup
static inline void kifmm_kernel_yukawa_eval(const double *param, double dx, double dy,
                                            double dz, double *k)
{
    double r = sqrt(dx * dx + dy * dy + dz * dz);
    k[0] = r > 0.0 ? KIFMM_INV_4PI * exp(-param[0] * r) / r : 0.0;
}

/* yukawa_grad: the potential and its gradient with respect to the target,
 * k = (1, -(1 + lambda r) d / r^2) exp(-lambda r) / (4 pi r). */
#define kifmm_kernel_yukawa_grad_SRC_DIM 1
#define kifmm_kernel_yukawa_grad_TRG_DIM 4
#define kifmm_kernel_yukawa_grad_SCALE_INVARIANT 0
#define kifmm_kernel_yukawa_grad_DEGREE 0
#define kifmm_kernel_yukawa_grad_EQUIV yukawa
#define kifmm_kernel_yukawa_grad_HAS (KIFMM_KERNEL__YUKAWA_HAS | KIFMM_HAS_TOL)
#define kifmm_kernel_yukawa_grad_TOL_ERRORS KIFMM_KERNEL__TOL_GRAD
#define kifmm_kernel_yukawa_grad_setup kifmm_kernel__positive_setup
static inline void kifmm_kernel_yukawa_grad_eval(const double *param, double dx, double dy,
                                                 double dz, double *k)
{
    double r2 = dx * dx + dy * dy + dz * dz, r, p, g;
    if (!(r2 > 0.0)) {
        k[0] = k[1] = k[2] = k[3] = 0.0;
        return;
    }
    r = sqrt(r2);
    p = KIFMM_INV_4PI * exp(-param[0] * r) / r;
    g = -p * (1.0 + param[0] * r) / r2;
    k[0] = p;
    k[1] = g * dx;
    k[2] = g * dy;
    k[3] = g * dz;
}

/* k[0 .. n) = 0 */
static inline void kifmm_kernel__zero(int n, double *k)
{
    int i;
    for (i = 0; i < n; i++) k[i] = 0.0;
}
/* k[i * ld + j] (i, j < 3) = c (delta_ij + d_i d_j / r^2), c = 1 / (8 pi mu r) */
static inline void kifmm_kernel__stokeslet(const double *d, double c, double ir2, int ld,
                                           double *k)
{
    int i, j;
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) k[i * ld + j] = c * d[i] * d[j] * ir2 + (i == j ? c : 0.0);
}

/* The start of a kernel matrix of n entries: d = (dx, dy, dz), 1 / r and
 * 1 / r^2, k zeroed; 0 (k left zero) for d = 0 or not finite */
static inline int kifmm_kernel__begin(double dx, double dy, double dz, int n, double *d,
                                      double *inv, double *ir2, double *k)
{
    const double r2 = dx * dx + dy * dy + dz * dz;
    d[0] = dx, d[1] = dy, d[2] = dz;
    *inv = 1.0 / sqrt(r2);
    *ir2 = *inv * *inv;
    kifmm_kernel__zero(n, k);
    return r2 > 0.0 && *inv > 0.0;
}

/* stokes: the Stokeslet, velocity u_i(y) = sum_j G_ij(y - x) f_j with
 * G_ij(d) = (delta_ij / r + d_i d_j / r^3) / (8 pi mu), viscosity
 * mu = param[0] in [1e-150, 1e150] (0 = the default, 1). Densities are forces (3 per
 * source), outputs velocities (3 per target). */
#define kifmm_kernel_stokes_SRC_DIM 3
#define kifmm_kernel_stokes_TRG_DIM 3
#define kifmm_kernel_stokes_SCALE_INVARIANT 1
#define kifmm_kernel_stokes_DEGREE (-1)
#define kifmm_kernel_stokes_HAS                                                           \
    (KIFMM_HAS_SETUP | KIFMM_HAS_P2P | KIFMM_HAS_P2PF | KIFMM_HAS_P2PS | KIFMM_HAS_P2PSF |       \
     KIFMM_KERNEL__PER | KIFMM_HAS_TOL)
#define kifmm_kernel_stokes_TOL_ERRORS KIFMM_KERNEL__TOL_STOKES
#define kifmm_kernel_stokes_setup kifmm_kernel__viscosity_setup
#define kifmm_kernel_stokes_INNER_NARROW 1 /* inner surfaces at 0.95 (kifmm.h) */
static inline void kifmm_kernel_stokes_eval(const double *param, double dx, double dy,
                                            double dz, double *k)
{
    double d[3], inv, ir2;
    if (!kifmm_kernel__begin(dx, dy, dz, 9, d, &inv, &ir2, k)) return;
    kifmm_kernel__stokeslet(d, 0.5 * KIFMM_INV_4PI / param[0] * inv, ir2, 3, k);
}

/* ------------------------------------------------------------------------ */
/* The Laplace family: charges q, dipoles v, potential, gradient, Hessian   */
/* ------------------------------------------------------------------------ */
/* d = target - source, r = |d|. A charge q gives q / (4 pi r); a dipole v
 * gives v . d / (4 pi r^3) (the field of a charge pair +q at s + v / (2 q),
 * -q at s - v / (2 q) as v / q -> 0: the double layer's kernel). Gradients
 * are with respect to the target; Hessians as 6 components xx, yy, zz, xy,
 * xz, yz. Outputs per target in the order potential, gradient, Hessian;
 * densities per source in the order q, v. All of them carry Laplace
 * charges on the surfaces (_EQUIV laplace) and name the kernels that map
 * surface charges to their outputs (_SURFACE) and their sources to a
 * potential (_CHECK). */

/* 1 / (4 pi r), 1 / (4 pi r^3), 1 / (4 pi r^5) in c[0..2]; 0 if r = 0 or
 * not finite (the pair then adds nothing) */
static inline int kifmm_kernel__lap_powers(double dx, double dy, double dz, double *c)
{
    const double r2 = dx * dx + dy * dy + dz * dz, inv = 1.0 / sqrt(r2);
    if (!(r2 > 0.0) || !(inv > 0.0)) return 0;
    c[0] = KIFMM_INV_4PI * inv;
    c[1] = c[0] * inv * inv;
    c[2] = c[1] * inv * inv;
    return 1;
}
/* the Hessian pairs (i, j) in output order xx, yy, zz, xy, xz, yz: m < 3 is
 * (m, m), 3, 4, 5 are (0, 1), (0, 2), (1, 2) */
#define KIFMM_KERNEL__HI(m) ((m) < 3 ? (m) : (m) == 5)
#define KIFMM_KERNEL__HJ(m) ((m) < 3 ? (m) : (m) == 3 ? 1 : 2)

/* Rows of the charge's potential (1), gradient (3) and Hessian (6) at
 * k[0], k[ld], ..., k[9 ld], as many as `rows`: q / (4 pi r), -q d / (4 pi
 * r^3), q (3 d_i d_j - r^2 delta_ij) / (4 pi r^5). */
static inline void kifmm_kernel__lap_charge(const double *d, const double *c, int rows, int ld,
                                            double *k)
{
    int m;
    k[0] = c[0];
    for (m = 0; m < 3 && rows > 1; m++) k[(1 + m) * ld] = -c[1] * d[m];
    for (m = 0; m < 6 && rows > 4; m++) {
        const int i = KIFMM_KERNEL__HI(m), j = KIFMM_KERNEL__HJ(m);
        k[(4 + m) * ld] = 3.0 * c[2] * d[i] * d[j] - (i == j ? c[1] : 0.0);
    }
}
/* The same for a dipole, columns 0..2 (v_x, v_y, v_z): potential d_k /
 * (4 pi r^3); gradient (delta_ik - 3 d_i d_k / r^2) / (4 pi r^3); Hessian
 * (15 d_i d_j d_k / r^2 - 3 (delta_ik d_j + delta_jk d_i + delta_ij d_k)) /
 * (4 pi r^5). */
static inline void kifmm_kernel__lap_dipole(const double *d, const double *c, int rows, int ld,
                                            double *k)
{
    const double ir2 = rows > 4 ? 1.0 / (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) : 0.0;
    int m, a;
    for (a = 0; a < 3; a++) {
        k[a] = c[1] * d[a];
        for (m = 0; m < 3 && rows > 1; m++)
            k[(1 + m) * ld + a] = (m == a ? c[1] : 0.0) - 3.0 * c[2] * d[m] * d[a];
        for (m = 0; m < 6 && rows > 4; m++) {
            const int i = KIFMM_KERNEL__HI(m), j = KIFMM_KERNEL__HJ(m);
            k[(4 + m) * ld + a] =
                c[2] * (15.0 * d[i] * d[j] * d[a] * ir2 -
                        3.0 * ((i == a ? d[j] : 0.0) + (j == a ? d[i] : 0.0) + (i == j ? d[a] : 0.0)));
        }
    }
}

/* k = the kernel matrix of charges (ch), dipoles (dip) or both, `rows`
 * outputs (1, 4 or 10), row by row: column 0 the charge's, then the
 * dipole's three */
static inline void kifmm_kernel__lap_eval(double dx, double dy, double dz, int ch, int dip,
                                          int rows, double *k)
{
    const double d[3] = {dx, dy, dz};
    const int ld = ch + 3 * dip;
    double c[3];
    if (!kifmm_kernel__lap_powers(dx, dy, dz, c)) {
        kifmm_kernel__zero(rows * ld, k);
        return;
    }
    if (ch) kifmm_kernel__lap_charge(d, c, rows, ld, k);
    if (dip) kifmm_kernel__lap_dipole(d, c, rows, ld, k + ch);
}

/* laplace_hess: charges -> potential, gradient, Hessian (10 outputs) */
#define kifmm_kernel_laplace_hess_SRC_DIM 1
#define kifmm_kernel_laplace_hess_TRG_DIM 10
#define kifmm_kernel_laplace_hess_SCALE_INVARIANT 1
#define kifmm_kernel_laplace_hess_HAS (KIFMM_KERNEL__OW_HAS | KIFMM_HAS_BACKGROUND | KIFMM_HAS_TOL) /* below */
#define kifmm_kernel_laplace_hess_TOL_ERRORS KIFMM_KERNEL__TOL_GRAD
#define kifmm_kernel_laplace_hess_DEGREE (-1)
#define kifmm_kernel_laplace_hess_EQUIV laplace
static inline void kifmm_kernel_laplace_hess_eval(const double *param, double dx, double dy,
                                                  double dz, double *k)
{
    (void)param;
    kifmm_kernel__lap_eval(dx, dy, dz, 1, 0, 10, k);
}

/* opts.tol's tables (KIFMM_HAS_TOL): per order p = 2 ... 12, at its
 * default leaf size, the largest relative L2 error of the kernel's worst
 * output (each of potential, gradient, Hessian, velocity, pressure and
 * velocity gradient against its own norm) at 300 targets against direct
 * sums, on uniform, sphere-surface and clustered points, 20,000 of them
 * (two seeds) and 200,000 (one), rounded up to two digits (bench/bench_tol.c,
 * make bench-tol; docs/api.md, "Tolerance"). The first outputs are the
 * worst for the dipole, charge-and-dipole, Biot-Savart and double-layer
 * kernels (their gradients and Hessians measured 3 to 10 times below at
 * 20,000 points, biot_savart_grad's also at 200,000): one table per family,
 * the charge-and-dipole kernels' shared (laplace_cd's and yukawa_cd's, at
 * the default lambda, agree to two digits). The gradients are the worst of
 * laplace_grad, laplace_hess and yukawa_grad (up to 4.1 times the
 * potential; one table, laplace_hess's and yukawa_grad's agree within 10
 * %), the velocity gradient of stokes_grad (up to 3.8 times the velocity),
 * the velocity of stokes_pvel at most orders. stokes and yukawa have tables
 * of their own: their velocity and potential ran up to 3.1 and 1.2 times
 * laplace's. */
#define KIFMM_KERNEL__TOL_DIPOLE                                                                \
    {0.0, 0.0, 4.2e-2, 4.7e-3, 4.4e-4, 9.3e-5, 8.6e-6,                                         \
     1.0e-6, 1.1e-7, 2.2e-8, 3.1e-9, 7.3e-10, 9.5e-11}
#define KIFMM_KERNEL__TOL_CD                                                                    \
    {0.0, 0.0, 6.2e-2, 5.3e-3, 4.4e-4, 5.5e-5, 1.2e-5,                                         \
     1.0e-6, 1.5e-7, 3.9e-8, 3.6e-9, 5.4e-10, 1.4e-10}
#define KIFMM_KERNEL__TOL_BIOT_SAVART                                                           \
    {0.0, 0.0, 3.9e-2, 3.9e-3, 4.3e-4, 4.9e-5, 5.5e-6,                                         \
     7.1e-7, 1.0e-7, 1.7e-8, 2.3e-9, 4.6e-10, 2.2e-10}
#define KIFMM_KERNEL__TOL_STOKES_DL                                                             \
    {0.0, 0.0, 8.4e-2, 6.7e-3, 5.1e-4, 5.4e-5, 1.1e-5,                                         \
     9.0e-7, 2.3e-7, 5.4e-8, 2.7e-8, 1.6e-8, 1.9e-9}

#define KIFMM_KERNEL__TOL_GRAD                                                                  \
    {0.0, 0.0, 4.5e-2, 3.3e-3, 3.6e-4, 4.2e-5, 6.8e-6,                                          \
     6.2e-7, 1.3e-7, 2.1e-8, 2.4e-9, 4.4e-10, 6.9e-11}
#define KIFMM_KERNEL__TOL_YUKAWA                                                                \
    {0.0, 0.0, 4.5e-2, 2.4e-3, 2.2e-4, 2.0e-5, 2.2e-6,                                          \
     2.6e-7, 4.5e-8, 6.9e-9, 8.6e-10, 1.5e-10, 2.0e-11}
#define KIFMM_KERNEL__TOL_STOKES                                                                \
    {0.0, 0.0, 6.4e-2, 4.2e-3, 3.1e-4, 2.4e-5, 2.7e-6,                                          \
     2.2e-7, 3.3e-8, 5.4e-9, 1.5e-9, 4.4e-10, 4.6e-11}
#define KIFMM_KERNEL__TOL_STOKES_GRAD                                                           \
    {0.0, 0.0, 6.4e-2, 4.6e-3, 5.1e-4, 2.9e-5, 4.7e-6,                                          \
     4.5e-7, 8.7e-8, 1.4e-8, 4.0e-9, 1.2e-9, 2.1e-10}
#define KIFMM_KERNEL__TOL_STOKES_PVEL                                                           \
    {0.0, 0.0, 7.0e-2, 5.1e-3, 3.9e-4, 3.5e-5, 4.2e-6,                                          \
     3.8e-7, 6.3e-8, 1.5e-8, 6.5e-9, 1.3e-9, 4.4e-10}

/* laplace_dipole: dipoles (3 per source) -> potential */
#define kifmm_kernel_laplace_dipole_SRC_DIM 3
#define kifmm_kernel_laplace_dipole_TRG_DIM 1
#define kifmm_kernel_laplace_dipole_SCALE_INVARIANT 1
#define kifmm_kernel_laplace_dipole_HAS (KIFMM_KERNEL__OW_HAS | KIFMM_HAS_BACKGROUND | KIFMM_HAS_TOL) /* below */
#define kifmm_kernel_laplace_dipole_TOL_ERRORS KIFMM_KERNEL__TOL_DIPOLE
#define kifmm_kernel_laplace_dipole_DEGREE (-2)
#define kifmm_kernel_laplace_dipole_EQUIV laplace
#define kifmm_kernel_laplace_dipole_SURFACE laplace
static inline void kifmm_kernel_laplace_dipole_eval(const double *param, double dx, double dy,
                                                    double dz, double *k)
{
    (void)param;
    kifmm_kernel__lap_eval(dx, dy, dz, 0, 1, 1, k);
}

/* laplace_dipole_grad: dipoles -> potential and gradient */
#define kifmm_kernel_laplace_dipole_grad_SRC_DIM 3
#define kifmm_kernel_laplace_dipole_grad_TRG_DIM 4
#define kifmm_kernel_laplace_dipole_grad_SCALE_INVARIANT 1
#define kifmm_kernel_laplace_dipole_grad_HAS (KIFMM_KERNEL__OW_HAS | KIFMM_HAS_BACKGROUND | KIFMM_HAS_TOL) /* below */
#define kifmm_kernel_laplace_dipole_grad_TOL_ERRORS KIFMM_KERNEL__TOL_DIPOLE
#define kifmm_kernel_laplace_dipole_grad_DEGREE (-2)
#define kifmm_kernel_laplace_dipole_grad_EQUIV laplace
#define kifmm_kernel_laplace_dipole_grad_SURFACE laplace_grad
#define kifmm_kernel_laplace_dipole_grad_CHECK laplace_dipole
static inline void kifmm_kernel_laplace_dipole_grad_eval(const double *param, double dx,
                                                         double dy, double dz, double *k)
{
    (void)param;
    kifmm_kernel__lap_eval(dx, dy, dz, 0, 1, 4, k);
}

/* laplace_cd: charges and dipoles (q, v: 4 per source) -> potential */
#define kifmm_kernel_laplace_cd_SRC_DIM 4
#define kifmm_kernel_laplace_cd_TRG_DIM 1
#define kifmm_kernel_laplace_cd_SCALE_INVARIANT 1
#define kifmm_kernel_laplace_cd_HAS (KIFMM_KERNEL__OW_HAS | KIFMM_HAS_BACKGROUND | KIFMM_HAS_TOL) /* below */
#define kifmm_kernel_laplace_cd_TOL_ERRORS KIFMM_KERNEL__TOL_CD
#define kifmm_kernel_laplace_cd_DEGREE (-1)
#define kifmm_kernel_laplace_cd_EQUIV laplace
#define kifmm_kernel_laplace_cd_SURFACE laplace
static inline void kifmm_kernel_laplace_cd_eval(const double *param, double dx, double dy,
                                                double dz, double *k)
{
    (void)param;
    kifmm_kernel__lap_eval(dx, dy, dz, 1, 1, 1, k);
}

/* laplace_cd_grad: charges and dipoles -> potential and gradient */
#define kifmm_kernel_laplace_cd_grad_SRC_DIM 4
#define kifmm_kernel_laplace_cd_grad_TRG_DIM 4
#define kifmm_kernel_laplace_cd_grad_SCALE_INVARIANT 1
#define kifmm_kernel_laplace_cd_grad_HAS (KIFMM_KERNEL__OW_HAS | KIFMM_HAS_BACKGROUND | KIFMM_HAS_TOL) /* below */
#define kifmm_kernel_laplace_cd_grad_TOL_ERRORS KIFMM_KERNEL__TOL_CD
#define kifmm_kernel_laplace_cd_grad_DEGREE (-1)
#define kifmm_kernel_laplace_cd_grad_EQUIV laplace
#define kifmm_kernel_laplace_cd_grad_USE_EQUIV 1 /* 4 x 4, yet not its own surface kernel */
#define kifmm_kernel_laplace_cd_grad_SURFACE laplace_grad
#define kifmm_kernel_laplace_cd_grad_CHECK laplace_cd
static inline void kifmm_kernel_laplace_cd_grad_eval(const double *param, double dx, double dy,
                                                     double dz, double *k)
{
    (void)param;
    kifmm_kernel__lap_eval(dx, dy, dz, 1, 1, 4, k);
}

/* laplace_cd_hess: charges and dipoles -> potential, gradient, Hessian */
#define kifmm_kernel_laplace_cd_hess_SRC_DIM 4
#define kifmm_kernel_laplace_cd_hess_TRG_DIM 10
#define kifmm_kernel_laplace_cd_hess_SCALE_INVARIANT 1
#define kifmm_kernel_laplace_cd_hess_HAS (KIFMM_KERNEL__OW_HAS | KIFMM_HAS_BACKGROUND | KIFMM_HAS_TOL) /* below */
#define kifmm_kernel_laplace_cd_hess_TOL_ERRORS KIFMM_KERNEL__TOL_CD
#define kifmm_kernel_laplace_cd_hess_DEGREE (-1)
#define kifmm_kernel_laplace_cd_hess_EQUIV laplace
#define kifmm_kernel_laplace_cd_hess_SURFACE laplace_hess
#define kifmm_kernel_laplace_cd_hess_CHECK laplace_cd
static inline void kifmm_kernel_laplace_cd_hess_eval(const double *param, double dx, double dy,
                                                     double dz, double *k)
{
    (void)param;
    kifmm_kernel__lap_eval(dx, dy, dz, 1, 1, 10, k);
}

/* ------------------------------------------------------------------------ */
/* Yukawa charges and dipoles                                               */
/* ------------------------------------------------------------------------ */
/* G = exp(-lambda r) / (4 pi r), lambda = param[0] (yukawa's setup). A charge
 * q gives q G, gradient -q (1 + lambda r) exp(-lambda r) d / (4 pi r^3); a
 * dipole v gives v . grad_source G = (v . d) (1 + lambda r) exp(-lambda r) /
 * (4 pi r^3), gradient (v (1 + lambda r) - (v . d) d (3 + 3 lambda r +
 * lambda^2 r^2) / r^2) exp(-lambda r) / (4 pi r^3); lambda = 0 gives the
 * Laplace family's. Densities (q, v), outputs potential, gradient. */
static inline void kifmm_kernel__yuk_cd(const double *param, double dx, double dy, double dz,
                                        int rows, double *k)
{
    double d[3], inv, ir2, lr, e, c1, c3;
    int m;
    if (!kifmm_kernel__begin(dx, dy, dz, 4 * rows, d, &inv, &ir2, k)) return;
    lr = param[0] / inv;
    e = KIFMM_INV_4PI * exp(-lr) * inv;      /* G */
    c1 = e * (1.0 + lr) * ir2;               /* (1 + lambda r) G / r^2 */
    c3 = e * (3.0 + lr * (3.0 + lr)) * ir2 * ir2;
    k[0] = e;
    for (m = 0; m < 3; m++) k[1 + m] = c1 * d[m];
    for (m = 0; m < 3 && rows > 1; m++) {
        int a;
        k[4 * (1 + m)] = -c1 * d[m];
        for (a = 0; a < 3; a++) k[4 * (1 + m) + 1 + a] = (m == a ? c1 : 0.0) - c3 * d[m] * d[a];
    }
}

/* yukawa_cd: charges and dipoles (q, v: 4 per source) -> potential */
#define kifmm_kernel_yukawa_cd_SRC_DIM 4
#define kifmm_kernel_yukawa_cd_TRG_DIM 1
#define kifmm_kernel_yukawa_cd_SCALE_INVARIANT 0
#define kifmm_kernel_yukawa_cd_DEGREE 0
#define kifmm_kernel_yukawa_cd_HAS (KIFMM_HAS_SETUP | KIFMM_HAS_P2P | KIFMM_HAS_TOL) /* hook below */
#define kifmm_kernel_yukawa_cd_TOL_ERRORS KIFMM_KERNEL__TOL_CD
#define kifmm_kernel_yukawa_cd_setup kifmm_kernel__positive_setup
#define kifmm_kernel_yukawa_cd_EQUIV yukawa
#define kifmm_kernel_yukawa_cd_SURFACE yukawa
static inline void kifmm_kernel_yukawa_cd_eval(const double *param, double dx, double dy,
                                               double dz, double *k)
{
    kifmm_kernel__yuk_cd(param, dx, dy, dz, 1, k);
}

/* yukawa_cd_grad: charges and dipoles -> potential and gradient */
#define kifmm_kernel_yukawa_cd_grad_SRC_DIM 4
#define kifmm_kernel_yukawa_cd_grad_TRG_DIM 4
#define kifmm_kernel_yukawa_cd_grad_SCALE_INVARIANT 0
#define kifmm_kernel_yukawa_cd_grad_DEGREE 0
#define kifmm_kernel_yukawa_cd_grad_HAS (KIFMM_HAS_SETUP | KIFMM_HAS_P2P | KIFMM_HAS_TOL) /* hook below */
#define kifmm_kernel_yukawa_cd_grad_TOL_ERRORS KIFMM_KERNEL__TOL_CD
#define kifmm_kernel_yukawa_cd_grad_setup kifmm_kernel__positive_setup
#define kifmm_kernel_yukawa_cd_grad_EQUIV yukawa
#define kifmm_kernel_yukawa_cd_grad_USE_EQUIV 1
#define kifmm_kernel_yukawa_cd_grad_SURFACE yukawa_grad
#define kifmm_kernel_yukawa_cd_grad_CHECK yukawa_cd
static inline void kifmm_kernel_yukawa_cd_grad_eval(const double *param, double dx, double dy,
                                                    double dz, double *k)
{
    kifmm_kernel__yuk_cd(param, dx, dy, dz, 4, k);
}

/* ------------------------------------------------------------------------ */
/* Helmholtz: complex values as (re, im) pairs                              */
/* ------------------------------------------------------------------------ */
/* G(r) = exp(i k r) / (4 pi r), the wavenumber k = param[0] + i param[1]
 * (param[1] >= 0: waves damped as they travel; k = 0 is Laplace's kernel).
 * Densities and outputs are complex numbers stored as (re, im) pairs of
 * reals, and each complex entry c of the kernel is the real 2 x 2 block
 * [[Re c, -Im c], [Im c, Re c]] (rows: an output's re, im; columns: a
 * density's re, im), so that the method runs on real pairs. With d = target
 * - source, z = i k r: grad_target G = A d, A = G (z - 1) / r^2; the
 * Hessian is A delta_ij + B d_i d_j, B = G (3 - 3 z + z^2) / r^4. A charge q
 * gives q G, gradient q A d; a dipole v gives v . grad_source G = -A (v .
 * d), gradient -A v - B (v . d) d (k = i lambda: yukawa_cd's). Densities
 * (q, v), outputs potential then gradient, each a complex pair. */
static inline int kifmm_kernel__wavenumber_setup(const double *in, double *out)
{
    out[0] = in[0], out[1] = in[1];
    out[2] = out[3] = 0.0;
    return fabs(out[0]) <= 1e150 && out[1] >= 0.0 && out[1] <= 1e150 ? 0 : -1;
}
static inline double kifmm_kernel__wavenumber(const double *param) { return fabs(param[0]); }
/* complex c at (output a, density b) of a kernel matrix of ld reals a row */
static inline void kifmm_kernel__cput(double *k, int ld, int a, int b, double cr, double ci)
{
    k[2 * a * ld + 2 * b] = cr, k[2 * a * ld + 2 * b + 1] = -ci;
    k[(2 * a + 1) * ld + 2 * b] = ci, k[(2 * a + 1) * ld + 2 * b + 1] = cr;
}
/* rows 1 (potential) or 4 (and gradient) of charges (cd 0) or charges and
 * dipoles (cd 1) */
static inline void kifmm_kernel__helm(const double *param, double dx, double dy, double dz,
                                      int rows, int cd, double *k)
{
    const int ld = cd ? 8 : 2;
    double d[3], inv, ir2, r, e, g[2], t[2], a[2], b[2];
    int i, j;
    if (!kifmm_kernel__begin(dx, dy, dz, 2 * rows * ld, d, &inv, &ir2, k)) return;
    r = 1.0 / inv;
    e = KIFMM_INV_4PI * exp(-param[1] * r) * inv;
    g[0] = e * cos(param[0] * r), g[1] = e * sin(param[0] * r); /* G */
    kifmm_kernel__cput(k, ld, 0, 0, g[0], g[1]);
    if (rows == 1 && !cd) return;
    if (g[0] == 0.0 && g[1] == 0.0) return; /* exp(-Im k r) below the range: all zero */
    /* (z - 1) / r^2 = u / r - 1 / r^2 and (3 - 3 z + z^2) / r^4 = 3 / r^4 - 3 u
     * / r^3 + u^2 / r^2, u = i k: no k^2 r^2, which overflows first */
    t[0] = -param[1] * inv - ir2, t[1] = param[0] * inv;
    a[0] = g[0] * t[0] - g[1] * t[1], a[1] = g[0] * t[1] + g[1] * t[0];
    t[0] = 3.0 * ir2 * ir2 + 3.0 * param[1] * ir2 * inv + (param[1] * param[1] - param[0] * param[0]) * ir2;
    t[1] = -3.0 * param[0] * ir2 * inv - 2.0 * param[1] * param[0] * ir2;
    b[0] = g[0] * t[0] - g[1] * t[1], b[1] = g[0] * t[1] + g[1] * t[0];
    for (i = 0; i < 3 && rows > 1; i++) kifmm_kernel__cput(k, ld, 1 + i, 0, a[0] * d[i], a[1] * d[i]);
    for (j = 0; j < 3 && cd; j++) {
        kifmm_kernel__cput(k, ld, 0, 1 + j, -a[0] * d[j], -a[1] * d[j]);
        for (i = 0; i < 3 && rows > 1; i++)
            kifmm_kernel__cput(k, ld, 1 + i, 1 + j, -(i == j ? a[0] : 0.0) - b[0] * d[i] * d[j],
                               -(i == j ? a[1] : 0.0) - b[1] * d[i] * d[j]);
    }
}
#define KIFMM_KERNEL__HELM_HAS (KIFMM_HAS_SETUP | KIFMM_HAS_WAVES)
/* The widest box an expansion may span, in wavelengths, per order (0 to
 * KIFMM_MAX_ORDER): the widest at which helmholtz (bench/bench_waves.c:
 * 20,000 uniform points in a fixed unit root, Im k = 0, the level-2 boxes'
 * expansions the widest; steps of 0.01 near the limits at p = 4 to 6
 * (their surfaces those of a one-component kernel, kifmm.h,
 * KIFMM__CPLX_SQUARE_MAX), 0.02 at p = 8, 0.1 above) stayed within 100
 * times its error at 0.05 wavelengths (two
 * digits), with every smaller width, and at most 1.6 (measured to 1.7;
 * p = 2, 3 kept at 0.5). The inner surfaces move off their interior
 * resonances (kifmm.h, kifmm__alpha_waves), which had capped every order
 * at 0.8: p = 8 gave an error of 4.8e3 at 0.8660254 wavelengths, 3.4e-8
 * since (docs/kernels.md, "Helmholtz"). */
#define KIFMM_KERNEL__HELM_WAVES {0.0, 0.0, 0.5, 0.5, 0.87, 0.99, 1.08, 1.2, 1.34, 1.5, 1.6, 1.6, 1.6}
/* opts.tol's table (KIFMM_HAS_TOL with WAVES): per order (rows) the
 * largest relative L2 error of any output of helmholtz_grad and
 * helmholtz_cd_grad at 300 targets against direct sums, on cube, sphere
 * and clustered points (20,000 of them; helmholtz_grad two seeds,
 * helmholtz_cd_grad one; and 200,000, helmholtz_grad, orders 3 to 10 and
 * 11 to 1.25 wavelengths), sources = targets, Im k = 0, the root the points'
 * bounding cube and the wavenumber making its level-2 boxes the column's
 * width (KIFMM_TOL_WAVES_WIDTHS, then the order's limit); 0 where a width
 * is at or past the limit; rounded up to two digits (bench/bench_tol.c,
 * make bench-tol; docs/api.md, "Tolerance") */
#define KIFMM_KERNEL__HELM_TOL {{0}, {0}, \
        {5.2e-02, 7.1e-02, 0, 0, 0, 0, 0, 6.1e-01}, \
        {3.7e-03, 3.7e-03, 0, 0, 0, 0, 0, 1.5e-02}, \
        {3.7e-04, 3.7e-04, 5.7e-04, 4.5e-03, 0, 0, 0, 1.1e-02}, \
        {4.6e-05, 4.6e-05, 4.6e-05, 2.1e-04, 0, 0, 0, 1.3e-03}, \
        {8.5e-06, 8.5e-06, 8.5e-06, 1.1e-05, 7.3e-05, 0, 0, 1.5e-04}, \
        {5.8e-07, 5.7e-07, 6.1e-07, 8.4e-07, 3.5e-06, 0, 0, 1.8e-05}, \
        {8.6e-08, 8.8e-08, 9.1e-08, 1.2e-07, 2.6e-07, 1.4e-06, 0, 2.7e-06}, \
        {1.3e-08, 1.3e-08, 1.3e-08, 1.3e-08, 1.9e-08, 6.9e-08, 0, 5.3e-07}, \
        {2.0e-09, 2.0e-09, 1.5e-09, 1.8e-09, 2.3e-09, 5.6e-09, 2.1e-08, 5.6e-08}, \
        {3.0e-10, 3.0e-10, 3.1e-10, 2.8e-10, 2.8e-10, 5.1e-10, 1.8e-09, 2.9e-09}, \
        {7.3e-11, 6.6e-11, 5.4e-11, 5.0e-11, 5.0e-11, 7.5e-11, 1.8e-10, 2.6e-10}}

/* helmholtz: charges -> potential (a complex pair each) */
#define kifmm_kernel_helmholtz_SRC_DIM 2
#define kifmm_kernel_helmholtz_TRG_DIM 2
#define kifmm_kernel_helmholtz_SCALE_INVARIANT 0
#define kifmm_kernel_helmholtz_DEGREE 0
#define kifmm_kernel_helmholtz_HAS                                                            \
    (KIFMM_KERNEL__HELM_HAS | KIFMM_HAS_TOL | KIFMM_HAS_COMPLEX | KIFMM_HAS_RADIAL |             \
     KIFMM_KERNEL__HELM_HOOKS | KIFMM_KERNEL__HELM_MUTUAL) /* hooks below; the others' surface kernel */
#define kifmm_kernel_helmholtz_setup kifmm_kernel__wavenumber_setup
#define kifmm_kernel_helmholtz_wavenumber kifmm_kernel__wavenumber
#define kifmm_kernel_helmholtz_WAVES_MAX KIFMM_KERNEL__HELM_WAVES
#define kifmm_kernel_helmholtz_TOL_ERRORS KIFMM_KERNEL__HELM_TOL
static inline void kifmm_kernel_helmholtz_eval(const double *param, double dx, double dy,
                                               double dz, double *k)
{
    kifmm_kernel__helm(param, dx, dy, dz, 1, 0, k);
}

/* helmholtz_grad: charges -> potential and gradient (4 complex pairs) */
#define kifmm_kernel_helmholtz_grad_SRC_DIM 2
#define kifmm_kernel_helmholtz_grad_TRG_DIM 8
#define kifmm_kernel_helmholtz_grad_SCALE_INVARIANT 0
#define kifmm_kernel_helmholtz_grad_DEGREE 0
#define kifmm_kernel_helmholtz_grad_EQUIV helmholtz
#define kifmm_kernel_helmholtz_grad_HAS                                                       \
    (KIFMM_KERNEL__HELM_HAS | KIFMM_HAS_TOL | KIFMM_KERNEL__HELM_HOOKS | KIFMM_KERNEL__HELM_MUTUAL)
#define kifmm_kernel_helmholtz_grad_setup kifmm_kernel__wavenumber_setup
#define kifmm_kernel_helmholtz_grad_wavenumber kifmm_kernel__wavenumber
#define kifmm_kernel_helmholtz_grad_WAVES_MAX KIFMM_KERNEL__HELM_WAVES
#define kifmm_kernel_helmholtz_grad_TOL_ERRORS KIFMM_KERNEL__HELM_TOL
static inline void kifmm_kernel_helmholtz_grad_eval(const double *param, double dx, double dy,
                                                    double dz, double *k)
{
    kifmm_kernel__helm(param, dx, dy, dz, 4, 0, k);
}

/* helmholtz_cd_grad: charges and dipoles (q, v: 4 complex pairs a source)
 * -> potential and gradient: the combined field of boundary integral
 * equations */
#define kifmm_kernel_helmholtz_cd_grad_SRC_DIM 8
#define kifmm_kernel_helmholtz_cd_grad_TRG_DIM 8
#define kifmm_kernel_helmholtz_cd_grad_SCALE_INVARIANT 0
#define kifmm_kernel_helmholtz_cd_grad_DEGREE 0
#define kifmm_kernel_helmholtz_cd_grad_HAS (KIFMM_KERNEL__HELM_HAS | KIFMM_HAS_TOL | KIFMM_KERNEL__HELM_HOOKS)
#define kifmm_kernel_helmholtz_cd_grad_setup kifmm_kernel__wavenumber_setup
#define kifmm_kernel_helmholtz_cd_grad_wavenumber kifmm_kernel__wavenumber
#define kifmm_kernel_helmholtz_cd_grad_WAVES_MAX KIFMM_KERNEL__HELM_WAVES
#define kifmm_kernel_helmholtz_cd_grad_TOL_ERRORS KIFMM_KERNEL__HELM_TOL
#define kifmm_kernel_helmholtz_cd_grad_EQUIV helmholtz
#define kifmm_kernel_helmholtz_cd_grad_USE_EQUIV 1
#define kifmm_kernel_helmholtz_cd_grad_SURFACE helmholtz_grad
#define kifmm_kernel_helmholtz_cd_grad_CHECK _helmholtz_cd
static inline void kifmm_kernel_helmholtz_cd_grad_eval(const double *param, double dx, double dy,
                                                       double dz, double *k)
{
    kifmm_kernel__helm(param, dx, dy, dz, 4, 1, k);
}
/* its check kernel: charges and dipoles -> potential */
#define kifmm_kernel__helmholtz_cd_SRC_DIM 8
#define kifmm_kernel__helmholtz_cd_TRG_DIM 2
static inline void kifmm_kernel__helmholtz_cd_eval(const double *param, double dx, double dy,
                                                   double dz, double *k)
{
    kifmm_kernel__helm(param, dx, dy, dz, 1, 1, k);
}

/* ------------------------------------------------------------------------ */
/* The Stokes family: velocity gradient, pressure, double layer             */
/* ------------------------------------------------------------------------ */
/* d = target - source, r = |d|, mu = param[0] (the Stokes setup). Forces f
 * (3 per source) give the Stokeslet velocity u_i = G_ij f_j, G_ij = (delta_ij
 * / r + d_i d_j / r^3) / (8 pi mu), the pressure p = f . d / (4 pi r^3) and
 * the velocity gradient du_i / dy_j = ((delta_ij d_k + delta_jk d_i -
 * delta_ik d_j) / r^3 - 3 d_i d_j d_k / r^5) f_k / (8 pi mu) at [i * 3 + j].
 * The double layer of a density q with normal n (q then n, 6 per source)
 * gives u_i = T_ijk q_j n_k, T_ijk = -3 d_i d_j d_k / (4 pi r^5), whatever
 * mu.
 *
 * The velocities and gradients ride on Stokeslet surfaces (stokes). The
 * pressure is harmonic, and so is the flux of a double layer (its trace part
 * (q . n) grad (1 / (4 pi r)) is a potential flow, which no Stokeslet
 * density carries through a closed surface): stokes_pvel and stokes_dl add
 * a Laplace charge to each surface point, 4 components (c, f) whose check
 * potentials are (phi, u) = (c / (4 pi r), G f), with mu = 1 on the
 * surfaces so that no viscosity puts the two blocks apart in scale. */

/* stokes_grad: forces -> velocity (3) and its gradient (9, du_i/dy_j at 3 + 3 i + j) */
#define kifmm_kernel_stokes_grad_SRC_DIM 3
#define kifmm_kernel_stokes_grad_TRG_DIM 12
#define kifmm_kernel_stokes_grad_SCALE_INVARIANT 1
#define kifmm_kernel_stokes_grad_DEGREE (-1)
#define kifmm_kernel_stokes_grad_EQUIV stokes
#define kifmm_kernel_stokes_grad_HAS (KIFMM_HAS_SETUP | KIFMM_KERNEL__OW_HAS | KIFMM_HAS_BACKGROUND | KIFMM_HAS_TOL) /* below */
#define kifmm_kernel_stokes_grad_TOL_ERRORS KIFMM_KERNEL__TOL_STOKES_GRAD
#define kifmm_kernel_stokes_grad_setup kifmm_kernel__viscosity_setup
static inline void kifmm_kernel_stokes_grad_eval(const double *param, double dx, double dy,
                                                 double dz, double *k)
{
    double d[3], inv, ir2, c, c3;
    int i, j, m;
    if (!kifmm_kernel__begin(dx, dy, dz, 36, d, &inv, &ir2, k)) return;
    c = 0.5 * KIFMM_INV_4PI / param[0] * inv; /* 1 / (8 pi mu r) */
    c3 = c * ir2;
    kifmm_kernel__stokeslet(d, c, ir2, 3, k);
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++)
            for (m = 0; m < 3; m++)
                k[3 * (3 + 3 * i + j) + m] =
                    c3 * ((i == j ? d[m] : 0.0) + (j == m ? d[i] : 0.0) - (i == m ? d[j] : 0.0) -
                          3.0 * d[i] * d[j] * d[m] * ir2);
}

/* The surfaces of stokes_pvel and stokes_dl: densities (c, f_1..3), check
 * potentials (c / (4 pi r), G f with mu = 1) */
#define kifmm_kernel__stokes_pl_SRC_DIM 4
#define kifmm_kernel__stokes_pl_TRG_DIM 4
#define kifmm_kernel__stokes_pl_SCALE_INVARIANT 1
#define kifmm_kernel__stokes_pl_DEGREE (-1)
#define kifmm_kernel__stokes_pl_HAS KIFMM_KERNEL__PER
static inline void kifmm_kernel__stokes_pl_eval(const double *param, double dx, double dy,
                                                double dz, double *k)
{
    double d[3], inv, ir2;
    (void)param;
    if (!kifmm_kernel__begin(dx, dy, dz, 16, d, &inv, &ir2, k)) return;
    k[0] = KIFMM_INV_4PI * inv;
    kifmm_kernel__stokeslet(d, 0.5 * KIFMM_INV_4PI * inv, ir2, 4, k + 5);
}

/* stokes_pvel: forces -> pressure and velocity (p, u) */
#define kifmm_kernel_stokes_pvel_SRC_DIM 3
#define kifmm_kernel_stokes_pvel_TRG_DIM 4
#define kifmm_kernel_stokes_pvel_SCALE_INVARIANT 1
#define kifmm_kernel_stokes_pvel_DEGREE (-1)
#define kifmm_kernel_stokes_pvel_HAS (KIFMM_HAS_SETUP | KIFMM_KERNEL__OW_HAS | KIFMM_HAS_BACKGROUND | KIFMM_HAS_TOL) /* below */
#define kifmm_kernel_stokes_pvel_TOL_ERRORS KIFMM_KERNEL__TOL_STOKES_PVEL
#define kifmm_kernel_stokes_pvel_setup kifmm_kernel__viscosity_setup
#define kifmm_kernel_stokes_pvel_EQUIV _stokes_pl
#define kifmm_kernel_stokes_pvel_SURFACE _stokes_pvel_st
#define kifmm_kernel_stokes_pvel_CHECK _stokes_pvel_qc
#define kifmm_kernel_stokes_pvel_USE_CHECK 1
/* k rows p, u; cols f; u with viscosity mu (or 1 in the check kernel) */
static inline void kifmm_kernel__pvel(double mu, double dx, double dy, double dz, double *k)
{
    double d[3], inv, ir2;
    int j;
    if (!kifmm_kernel__begin(dx, dy, dz, 12, d, &inv, &ir2, k)) return;
    for (j = 0; j < 3; j++) k[j] = KIFMM_INV_4PI * inv * ir2 * d[j];
    kifmm_kernel__stokeslet(d, 0.5 * KIFMM_INV_4PI / mu * inv, ir2, 3, k + 3);
}
static inline void kifmm_kernel_stokes_pvel_eval(const double *param, double dx, double dy,
                                                 double dz, double *k)
{
    kifmm_kernel__pvel(param[0], dx, dy, dz, k);
}
/* MPI mode (kifmm.h, __mpi_pick): a box's equivalent density (c, f) goes
 * to another rank as forces f at its surface points, c (the pressure's
 * charge) dropped: outside the box the forces' velocity is the box's, and
 * so is their pressure (grad p = mu lap u there, both vanishing far off) */
#define kifmm_kernel_stokes_pvel_MPI_PICK 1
static inline void kifmm_kernel_stokes_pvel_mpi_pick(int *sel)
{
    sel[0] = -1, sel[1] = 0, sel[2] = 1, sel[3] = 2;
}
/* its check kernel: forces -> (p, u at mu = 1) */
#define kifmm_kernel__stokes_pvel_qc_HAS KIFMM_KERNEL__OW_HAS
#define kifmm_kernel__stokes_pvel_qc_SRC_DIM 3
#define kifmm_kernel__stokes_pvel_qc_TRG_DIM 4
static inline void kifmm_kernel__stokes_pvel_qc_eval(const double *param, double dx, double dy,
                                                     double dz, double *k)
{
    (void)param;
    kifmm_kernel__pvel(1.0, dx, dy, dz, k);
}
/* its surface kernel: (c, f) -> (p, u) = (c / (4 pi r), G f / mu) */
#define kifmm_kernel__stokes_pvel_st_HAS KIFMM_KERNEL__OW_HAS
#define kifmm_kernel__stokes_pvel_st_SRC_DIM 4
#define kifmm_kernel__stokes_pvel_st_TRG_DIM 4
static inline void kifmm_kernel__stokes_pvel_st_eval(const double *param, double dx, double dy,
                                                     double dz, double *k)
{
    double d[3], inv, ir2;
    if (!kifmm_kernel__begin(dx, dy, dz, 16, d, &inv, &ir2, k)) return;
    k[0] = KIFMM_INV_4PI * inv;
    kifmm_kernel__stokeslet(d, 0.5 * KIFMM_INV_4PI / param[0] * inv, ir2, 4, k + 5);
}

/* stokes_dl: the double layer, densities (q, n) per source, mapped to the
 * 9 products q_j n_k (at 3 j + k) the kernel is linear in */
#define kifmm_kernel_stokes_dl_SRC_DIM 6
#define kifmm_kernel_stokes_dl_DENSITY_DIM 9
#define kifmm_kernel_stokes_dl_TRG_DIM 3
#define kifmm_kernel_stokes_dl_SCALE_INVARIANT 1
#define kifmm_kernel_stokes_dl_DEGREE (-2)
#define kifmm_kernel_stokes_dl_HAS (KIFMM_HAS_DENSITY | KIFMM_KERNEL__OW_HAS | KIFMM_HAS_BACKGROUND | KIFMM_HAS_TOL) /* below */
#define kifmm_kernel_stokes_dl_TOL_ERRORS KIFMM_KERNEL__TOL_STOKES_DL
#define kifmm_kernel_stokes_dl_EQUIV _stokes_pl
#define kifmm_kernel_stokes_dl_SURFACE _stokes_dl_st
#define kifmm_kernel_stokes_dl_CHECK _stokes_dl_qc
static inline void kifmm_kernel_stokes_dl_density(const double *param, const double *in,
                                                  double *out)
{
    int j, m;
    (void)param;
    for (j = 0; j < 3; j++)
        for (m = 0; m < 3; m++) out[3 * j + m] = in[j] * in[3 + m];
}
/* k[i * ld + 3 j + m] = c d_i d_j d_m, c = -3 / (4 pi r^5) */
static inline void kifmm_kernel__stresslet(const double *d, double c, int ld, double *k)
{
    int i, j, m;
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++)
            for (m = 0; m < 3; m++) k[i * ld + 3 * j + m] = c * d[i] * d[j] * d[m];
}
static inline void kifmm_kernel_stokes_dl_eval(const double *param, double dx, double dy,
                                               double dz, double *k)
{
    double d[3], inv, ir2;
    (void)param;
    if (!kifmm_kernel__begin(dx, dy, dz, 27, d, &inv, &ir2, k)) return;
    kifmm_kernel__stresslet(d, -3.0 * KIFMM_INV_4PI * inv * ir2 * ir2, 9, k);
}
/* its check kernel: q_j n_k -> (phi, u - grad phi), phi = (q . n) / (4 pi
 * r) the trace part's potential, u - grad phi = T_ijk q_j n_k + (q . n) d_i
 * / (4 pi r^3) the traceless part's velocity (a Stokes flow without flux) */
#define kifmm_kernel__stokes_dl_qc_HAS KIFMM_KERNEL__OW_HAS
#define kifmm_kernel__stokes_dl_qc_SRC_DIM 9
#define kifmm_kernel__stokes_dl_qc_TRG_DIM 4
static inline void kifmm_kernel__stokes_dl_qc_eval(const double *param, double dx, double dy,
                                                   double dz, double *k)
{
    double d[3], inv, ir2;
    int i;
    (void)param;
    if (!kifmm_kernel__begin(dx, dy, dz, 36, d, &inv, &ir2, k)) return;
    kifmm_kernel__stresslet(d, -3.0 * KIFMM_INV_4PI * inv * ir2 * ir2, 9, k + 9);
    for (i = 0; i < 3; i++) {
        k[4 * i] = KIFMM_INV_4PI * inv;
        k[9 * (1 + i) + 0] += KIFMM_INV_4PI * inv * ir2 * d[i];
        k[9 * (1 + i) + 4] += KIFMM_INV_4PI * inv * ir2 * d[i];
        k[9 * (1 + i) + 8] += KIFMM_INV_4PI * inv * ir2 * d[i];
    }
}
/* its surface kernel: (c, f) -> u = c grad (1 / (4 pi r)) + G f (mu = 1) */
#define kifmm_kernel__stokes_dl_st_HAS KIFMM_KERNEL__OW_HAS
#define kifmm_kernel__stokes_dl_st_SRC_DIM 4
#define kifmm_kernel__stokes_dl_st_TRG_DIM 3
static inline void kifmm_kernel__stokes_dl_st_eval(const double *param, double dx, double dy,
                                                   double dz, double *k)
{
    double d[3], inv, ir2;
    int i;
    (void)param;
    if (!kifmm_kernel__begin(dx, dy, dz, 12, d, &inv, &ir2, k)) return;
    for (i = 0; i < 3; i++) k[4 * i] = -KIFMM_INV_4PI * inv * ir2 * d[i];
    kifmm_kernel__stokeslet(d, 0.5 * KIFMM_INV_4PI * inv, ir2, 4, k + 1);
}

/* ------------------------------------------------------------------------ */
/* Biot-Savart: vortex particles                                            */
/* ------------------------------------------------------------------------ */
/* A vortex strength a (3 per source) gives the velocity u = a x d / (4 pi
 * r^3) = curl (a / (4 pi r)) and its gradient du_i / dy_j = (eps_ilj a_l /
 * r^3 - 3 (a x d)_i d_j / r^5) / (4 pi) at [i * 3 + j]. The expansions are
 * those of the vector potential a / (4 pi r): three Laplace charges per
 * surface point (_laplace3). */
#define kifmm_kernel__laplace3_HAS (KIFMM_KERNEL__OW_HAS | KIFMM_KERNEL__PER)
#define kifmm_kernel__laplace3_SRC_DIM 3
#define kifmm_kernel__laplace3_TRG_DIM 3
#define kifmm_kernel__laplace3_SCALE_INVARIANT 1
#define kifmm_kernel__laplace3_DEGREE (-1)
static inline void kifmm_kernel__laplace3_eval(const double *param, double dx, double dy,
                                               double dz, double *k)
{
    double d[3], inv, ir2;
    (void)param;
    if (!kifmm_kernel__begin(dx, dy, dz, 9, d, &inv, &ir2, k)) return;
    k[0] = k[4] = k[8] = KIFMM_INV_4PI * inv;
}
/* rows of u (3) and, with the gradient, du_i/dy_j (9) of a x d / (4 pi r^3) */
static inline void kifmm_kernel__bs_eval(double dx, double dy, double dz, int grad, double *k)
{
    static const int nx[3] = {1, 2, 0}, px[3] = {2, 0, 1}; /* (a x d)_i = a_nx d_px - a_px d_nx */
    double d[3], inv, ir2, c3, e[3][3] = {{0.0}}; /* e[i][l] = eps_ilm d_m */
    int i, j, l;
    if (!kifmm_kernel__begin(dx, dy, dz, grad ? 36 : 9, d, &inv, &ir2, k)) return;
    c3 = KIFMM_INV_4PI * inv * ir2;
    for (i = 0; i < 3; i++) {
        e[i][nx[i]] = d[px[i]];
        e[i][px[i]] = -d[nx[i]];
        for (l = 0; l < 3; l++) k[3 * i + l] = c3 * e[i][l];
    }
    for (i = 0; i < 3 && grad; i++) /* (eps_ilj - 3 e[i][l] d_j / r^2) / (4 pi r^3) */
        for (j = 0; j < 3; j++)
            for (l = 0; l < 3; l++)
                k[3 * (3 + 3 * i + j) + l] =
                    c3 * ((l == nx[i] && j == px[i]) - (l == px[i] && j == nx[i]) -
                          3.0 * e[i][l] * d[j] * ir2);
}

/* biot_savart: vortex strengths -> velocity */
#define kifmm_kernel_biot_savart_SRC_DIM 3
#define kifmm_kernel_biot_savart_TRG_DIM 3
#define kifmm_kernel_biot_savart_SCALE_INVARIANT 1
#define kifmm_kernel_biot_savart_HAS (KIFMM_KERNEL__OW_HAS | KIFMM_HAS_BACKGROUND | KIFMM_HAS_TOL) /* below */
#define kifmm_kernel_biot_savart_TOL_ERRORS KIFMM_KERNEL__TOL_BIOT_SAVART
#define kifmm_kernel_biot_savart_DEGREE (-2)
#define kifmm_kernel_biot_savart_EQUIV _laplace3
#define kifmm_kernel_biot_savart_USE_EQUIV 1
static inline void kifmm_kernel_biot_savart_eval(const double *param, double dx, double dy,
                                                 double dz, double *k)
{
    (void)param;
    kifmm_kernel__bs_eval(dx, dy, dz, 0, k);
}

/* biot_savart_grad: vortex strengths -> velocity and its gradient */
#define kifmm_kernel_biot_savart_grad_SRC_DIM 3
#define kifmm_kernel_biot_savart_grad_TRG_DIM 12
#define kifmm_kernel_biot_savart_grad_SCALE_INVARIANT 1
#define kifmm_kernel_biot_savart_grad_HAS (KIFMM_KERNEL__OW_HAS | KIFMM_HAS_BACKGROUND | KIFMM_HAS_TOL) /* below */
#define kifmm_kernel_biot_savart_grad_TOL_ERRORS KIFMM_KERNEL__TOL_BIOT_SAVART
#define kifmm_kernel_biot_savart_grad_DEGREE (-2)
#define kifmm_kernel_biot_savart_grad_EQUIV _laplace3
static inline void kifmm_kernel_biot_savart_grad_eval(const double *param, double dx, double dy,
                                                      double dz, double *k)
{
    (void)param;
    kifmm_kernel__bs_eval(dx, dy, dz, 1, k);
}

/* ------------------------------------------------------------------------ */
/* Three periodic directions: Ewald splits and backgrounds                  */
/* ------------------------------------------------------------------------ */
/* The surface kernels' splits at alpha (KIFMM_HAS_EWALD, see the top of this
 * file) and every scale-invariant kernel's background (KIFMM_HAS_BACKGROUND).
 * 1 / (4 pi r) splits as erfc(alpha r) / (4 pi r) + erf(alpha r) / (4 pi
 * r), the second transforming to exp(-k^2 / (4 alpha^2)) / k^2, and the
 * first integrating to 1 / (4 alpha^2) (Ewald 1921). The Stokeslet
 * (delta_ij / r + d_i d_j / r^3) = (delta_ij lap - d_i d_j) r splits with r
 * = r erfc(alpha r) + r erf(alpha r) (Beenakker 1986): the smooth part
 * transforms to (8 pi / k^4) (1 + k^2 / (4 alpha^2) + k^4 / (8 alpha^4))
 * (k^2 delta_ij - k_i k_j) exp(-k^2 / (4 alpha^2)), the real part
 * integrates to 0. */
static inline double kifmm_kernel__lap_ewald(double alpha, int part, double x, double y, double z)
{
    const double r2 = x * x + y * y + z * z, r = sqrt(r2);
    switch (part) {
    case KIFMM_EWALD_REAL: return r > 0.0 ? KIFMM_INV_4PI * erfc(alpha * r) / r : 0.0;
    case KIFMM_EWALD_SMOOTH:
        return KIFMM_INV_4PI * (r > 0.0 ? erf(alpha * r) / r : 1.1283791670955126 * alpha);
    case KIFMM_EWALD_FOURIER: return exp(-r2 / (4.0 * alpha * alpha)) / r2;
    default: return -1.0 / (4.0 * alpha * alpha);
    }
}

/* The Stokeslet's part times c into the 3 x 3 block k[i * ld + j]: a delta_ij
 * + b d_i d_j / r^2 in real space, its transform at k = (x, y, z) */
static inline void kifmm_kernel__stokes_ewald(double alpha, int part, double x, double y, double z,
                                              double c, int ld, double *k)
{
    const double d[3] = {x, y, z}, r2 = x * x + y * y + z * z, r = sqrt(r2);
    const double e = 1.1283791670955126 * alpha * exp(-alpha * alpha * r2), s = 2.0 * alpha * alpha * r2;
    double a = 0.0, b = 0.0;
    int i, j;
    if (part == KIFMM_EWALD_REAL && r > 0.0) {
        a = erfc(alpha * r) / r + (s - 3.0) * e;
        b = erfc(alpha * r) / r + (1.0 - s) * e;
    } else if (part == KIFMM_EWALD_SMOOTH) {
        a = r > 0.0 ? erf(alpha * r) / r + (3.0 - s) * e : 4.0 * e;
        b = r > 0.0 ? erf(alpha * r) / r - (1.0 - s) * e : 0.0;
    } else if (part == KIFMM_EWALD_FOURIER) {
        const double q = r2 / (4.0 * alpha * alpha);
        a = 8.0 * 3.14159265358979323846 / (r2 * r2) * (1.0 + q + 2.0 * q * q) * exp(-q);
        b = -a; /* (k^2 delta - k k) = k^2 (delta - k k / k^2) */
        a *= r2;
        b *= r2;
    }
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) k[i * ld + j] = c * ((i == j ? a : 0.0) + (r2 > 0.0 ? b * d[i] * d[j] / r2 : 0.0));
}

static inline void kifmm_kernel_laplace_ewald(const double *param, double alpha, int part, double x,
                                              double y, double z, double *k)
{
    (void)param;
    k[0] = kifmm_kernel__lap_ewald(alpha, part, x, y, z);
}
static inline void kifmm_kernel_laplace_background(const double *param, double dx, double dy,
                                                   double dz, double *k)
{
    (void)param;
    k[0] = (dx * dx + dy * dy + dz * dz) / 6.0;
}
static inline void kifmm_kernel__laplace3_ewald(const double *param, double alpha, int part, double x,
                                                double y, double z, double *k)
{
    (void)param;
    kifmm_kernel__zero(9, k);
    k[0] = k[4] = k[8] = kifmm_kernel__lap_ewald(alpha, part, x, y, z);
}
static inline void kifmm_kernel__laplace3_background(const double *param, double dx, double dy,
                                                     double dz, double *k)
{
    (void)param;
    kifmm_kernel__zero(9, k);
    k[0] = k[4] = k[8] = (dx * dx + dy * dy + dz * dz) / 6.0;
}
static inline void kifmm_kernel_stokes_ewald(const double *param, double alpha, int part, double x,
                                             double y, double z, double *k)
{
    kifmm_kernel__stokes_ewald(alpha, part, x, y, z, 0.5 * KIFMM_INV_4PI / param[0], 3, k);
}
static inline void kifmm_kernel__stokes_pl_ewald(const double *param, double alpha, int part, double x,
                                                 double y, double z, double *k)
{
    (void)param;
    kifmm_kernel__zero(16, k);
    k[0] = kifmm_kernel__lap_ewald(alpha, part, x, y, z);
    kifmm_kernel__stokes_ewald(alpha, part, x, y, z, 0.5 * KIFMM_INV_4PI, 4, k + 5);
}
static inline void kifmm_kernel__stokes_pl_background(const double *param, double dx, double dy,
                                                      double dz, double *k)
{
    (void)param;
    kifmm_kernel__zero(16, k);
    k[0] = (dx * dx + dy * dy + dz * dz) / 6.0;
}

/* The Laplace family's (rows and columns as kifmm_kernel__lap_eval's): a
 * charge's |d|^2 / 6, gradient d / 3, Hessian delta_ij / 3; a dipole v's
 * v . grad_source of those, -v . d / 3, gradient -v / 3. */
static inline void kifmm_kernel__lap_background(double dx, double dy, double dz, int ch, int dip,
                                                int rows, double *k)
{
    const double d[3] = {dx, dy, dz};
    const int ld = ch + 3 * dip;
    int m, a;
    kifmm_kernel__zero(rows * ld, k);
    if (ch) {
        k[0] = (dx * dx + dy * dy + dz * dz) / 6.0;
        for (m = 0; m < 3 && rows > 1; m++) k[(1 + m) * ld] = d[m] / 3.0;
        for (m = 0; m < 3 && rows > 4; m++) k[(4 + m) * ld] = 1.0 / 3.0;
    }
    for (a = 0; a < 3 && dip; a++) {
        k[ch + a] = -d[a] / 3.0;
        if (rows > 1) k[(1 + a) * ld + ch + a] = -1.0 / 3.0;
    }
}
#define KIFMM_KERNEL__LAP_BG(name, ch, dip, rows)                                                \
    static inline void kifmm_kernel_##name##_background(const double *param, double dx, double dy, \
                                                        double dz, double *k)                   \
    {                                                                                           \
        (void)param;                                                                            \
        kifmm_kernel__lap_background(dx, dy, dz, ch, dip, rows, k);                             \
    }
KIFMM_KERNEL__LAP_BG(laplace_grad, 1, 0, 4)
KIFMM_KERNEL__LAP_BG(laplace_hess, 1, 0, 10)
KIFMM_KERNEL__LAP_BG(laplace_dipole, 0, 1, 1)
KIFMM_KERNEL__LAP_BG(laplace_dipole_grad, 0, 1, 4)
KIFMM_KERNEL__LAP_BG(laplace_cd, 1, 1, 1)
KIFMM_KERNEL__LAP_BG(laplace_cd_grad, 1, 1, 4)
KIFMM_KERNEL__LAP_BG(laplace_cd_hess, 1, 1, 10)
#undef KIFMM_KERNEL__LAP_BG

/* The Stokes family: no velocity (nor its gradient) from a uniform force,
 * which a pressure gradient balances; pressure -f . d / 3, the force's
 * f . grad_source |d|^2 / 6 (as p = f . grad_source 1 / (4 pi r)); the
 * double layer's flux (q . n) as a Laplace charge's gradient: (q . n) d / 3. */
static inline void kifmm_kernel_stokes_background(const double *param, double dx, double dy,
                                                  double dz, double *k)
{
    (void)param, (void)dx, (void)dy, (void)dz;
    kifmm_kernel__zero(9, k);
}
static inline void kifmm_kernel_stokes_grad_background(const double *param, double dx, double dy,
                                                       double dz, double *k)
{
    (void)param, (void)dx, (void)dy, (void)dz;
    kifmm_kernel__zero(36, k);
}
static inline void kifmm_kernel_stokes_pvel_background(const double *param, double dx, double dy,
                                                       double dz, double *k)
{
    (void)param;
    kifmm_kernel__zero(12, k);
    k[0] = -dx / 3.0, k[1] = -dy / 3.0, k[2] = -dz / 3.0;
}
static inline void kifmm_kernel_stokes_dl_background(const double *param, double dx, double dy,
                                                     double dz, double *k)
{
    const double d[3] = {dx, dy, dz};
    int i, j;
    (void)param;
    kifmm_kernel__zero(27, k);
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) k[i * 9 + 4 * j] = d[i] / 3.0;
}

/* Biot-Savart: the curl of the vector potential's a |d|^2 / 6: (d x a) / 3,
 * gradient d(d x a)_i / dy_j = eps_ijl a_l / 3 */
static inline void kifmm_kernel__bs_background(double dx, double dy, double dz, int grad, double *k)
{
    static const int nx[3] = {1, 2, 0}, px[3] = {2, 0, 1}; /* (d x a)_i = d_nx a_px - d_px a_nx */
    const double d[3] = {dx, dy, dz};
    int i, j;
    kifmm_kernel__zero(grad ? 36 : 9, k);
    for (i = 0; i < 3; i++) {
        k[3 * i + px[i]] = d[nx[i]] / 3.0;
        k[3 * i + nx[i]] = -d[px[i]] / 3.0;
        for (j = 0; j < 3 && grad; j++) {
            k[3 * (3 + 3 * i + j) + px[i]] = j == nx[i] ? 1.0 / 3.0 : 0.0;
            k[3 * (3 + 3 * i + j) + nx[i]] = j == px[i] ? -1.0 / 3.0 : 0.0;
        }
    }
}
static inline void kifmm_kernel_biot_savart_background(const double *param, double dx, double dy,
                                                       double dz, double *k)
{
    (void)param;
    kifmm_kernel__bs_background(dx, dy, dz, 0, k);
}
static inline void kifmm_kernel_biot_savart_grad_background(const double *param, double dx,
                                                            double dy, double dz, double *k)
{
    (void)param;
    kifmm_kernel__bs_background(dx, dy, dz, 1, k);
}

/* ------------------------------------------------------------------------ */
/* Near-field hooks (kifmm_kernel_NAME_P2P, kifmm_kernel_NAME_p2p)          */
/* ------------------------------------------------------------------------ */
/* kifmm_kernel_NAME_p2p(param, tx, ty, tz, nt, sx, sy, sz, q, ns, scale, out):
 * out[i * TRG_DIM + k] += scale * sum_j K_k(t_i - s_j) q_j, targets and
 * sources as structure-of-arrays coordinates, pairs at distance 0 skipped,
 * no alignment assumed, nt and ns any size including 0.
 *
 * One body is compiled, chosen by the target ISA: AVX-512F, else AVX2 + FMA,
 * else portable C written for the compiler's vectorizer; laplace's and
 * laplace_grad's are written once on the vector layer (>>vector), which also
 * covers aarch64's NEON.  Each pair is within
 * a few ulp of the scalar kernel (1 / sqrt(r^2) in double); 1 / (4 pi) and
 * scale are applied once per target.  The sums run in another order than in
 * the generic loop, so results agree to rounding, not bitwise. */

#if defined(__AVX2__) && defined(__FMA__)
/* Shared by the AVX2 loops below (also on AVX-512 builds, whose float and
 * many-vector loops are the AVX2 ones). */
/* All ones in the lanes [0, n) of 4 (double) or 8 (float): none for n <= 0,
 * all for n >= 4 (8). */
static inline __m256i kifmm_kernel__first4i(int64_t n)
{
    return _mm256_cmpgt_epi64(_mm256_set1_epi64x((long long)n), _mm256_setr_epi64x(0, 1, 2, 3));
}
static inline __m256i kifmm_kernel__first8i(int64_t n)
{
    return _mm256_cmpgt_epi32(_mm256_set1_epi32((int)(n < 8 ? n : 8)),
                              _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
}
/* o[0] += s (sum of the lanes of a0), o[k] += t (sum of ak) for k = 1..3. */
static inline void kifmm_kernel__red4(__m256d a0, __m256d a1, __m256d a2, __m256d a3, double s,
                                      double t, double *o)
{
    const __m256d ab = _mm256_hadd_pd(a0, a1), cd = _mm256_hadd_pd(a2, a3);
    const __m256d v = _mm256_add_pd(_mm256_permute2f128_pd(ab, cd, 0x20),
                                    _mm256_permute2f128_pd(ab, cd, 0x31));
    _mm256_storeu_pd(o, _mm256_fmadd_pd(_mm256_setr_pd(s, t, t, t), v, _mm256_loadu_pd(o)));
}
#endif

#if defined(__AVX512F__)
#include <float.h>
#include <immintrin.h>

/* Lanes [0, n) (all for n >= 8 or 16, none for n <= 0). */
static inline __mmask8 kifmm_kernel__first8(int64_t n)
{
    return (__mmask8)(n <= 0 ? 0u : n >= 8 ? 0xFFu : (1u << n) - 1u);
}
static inline __mmask16 kifmm_kernel__first16(int64_t n)
{
    return (__mmask16)(n <= 0 ? 0u : n >= 16 ? 0xFFFFu : (1u << n) - 1u);
}
static inline double kifmm_kernel__hsum8(__m512d v) { return _mm512_reduce_add_pd(v); }
static inline float kifmm_kernel__hsum16(__m512 v) { return _mm512_reduce_add_ps(v); }
/* 1 / r without a division: rsqrt14 (relative error below 2^-14) and, in
 * double, one correction of fourth order, y (1 + e/2 + 3e^2/8 + 5e^3/16)
 * with e = 1 - r2 y^2, whose error is about 0.27 e^4 < 2^-57 before
 * rounding (two Newton steps take two more operations for the same
 * accuracy); in float one Newton step (about 2^-27).
 * Double: 1 / sqrt(r2) for 0 < r2 < inf (subnormal r2 included), 0
 * elsewhere: r2 = 0 gives y = inf and r2 = inf gives y = 0, and then e is
 * NaN in both, as it is for a NaN r2, so the lanes where e is NaN are the
 * ones zeroed. */
static inline __m512d kifmm_kernel__rinv8(__m512d r2)
{
    const __m512d y = _mm512_rsqrt14_pd(r2);
    const __m512d e = _mm512_fnmadd_pd(_mm512_mul_pd(r2, y), y, _mm512_set1_pd(1.0));
    const __mmask8 live = _mm512_cmp_pd_mask(e, e, _CMP_ORD_Q);
    __m512d p = _mm512_fmadd_pd(_mm512_set1_pd(0.3125), e, _mm512_set1_pd(0.375));
    p = _mm512_fmadd_pd(p, e, _mm512_set1_pd(0.5));
    return _mm512_maskz_fmadd_pd(live, _mm512_mul_pd(y, e), p, y);
}
/* Float: FLT_MIN <= r2 <= FLT_MAX as in the AVX2 float loops (closer pairs
 * count as coincident), rsqrt14 and one Newton step (about 2^-27). */
static inline __m512 kifmm_kernel__rinv16(__m512 r2)
{
    const __mmask16 live = _mm512_mask_cmp_ps_mask(
        _mm512_cmp_ps_mask(r2, _mm512_set1_ps(FLT_MIN), _CMP_GE_OQ), r2,
        _mm512_set1_ps(FLT_MAX), _CMP_LE_OQ);
    const __m512 y = _mm512_maskz_rsqrt14_ps(live, r2);
    const __m512 e = _mm512_fnmadd_ps(_mm512_mul_ps(r2, y), y, _mm512_set1_ps(1.0f));
    return _mm512_maskz_fmadd_ps(live, _mm512_mul_ps(_mm512_set1_ps(0.5f), y), e, y);
}

/* o[k] += s * (sum of the lanes of ak), o[4 + k] += s * (sum of ck), k = 0..3,
 * the second four only if both: one transposing reduction of the 8 vectors. */
static inline void kifmm_kernel__red8x8(__m512d a0, __m512d a1, __m512d a2, __m512d a3,
                                        __m512d c0, __m512d c1, __m512d c2, __m512d c3,
                                        double s, double *o, int both)
{
    /* per 128-bit block: pairs of lanes added, two vectors side by side */
    const __m512d s0 = _mm512_add_pd(_mm512_unpacklo_pd(a0, a1), _mm512_unpackhi_pd(a0, a1));
    const __m512d s1 = _mm512_add_pd(_mm512_unpacklo_pd(a2, a3), _mm512_unpackhi_pd(a2, a3));
    const __m512d s2 = _mm512_add_pd(_mm512_unpacklo_pd(c0, c1), _mm512_unpackhi_pd(c0, c1));
    const __m512d s3 = _mm512_add_pd(_mm512_unpacklo_pd(c2, c3), _mm512_unpackhi_pd(c2, c3));
    /* blocks 0+1 and 2+3 of s0, s1 (and s2, s3) */
    const __m512d v0 = _mm512_add_pd(_mm512_shuffle_f64x2(s0, s1, 0x88),
                                     _mm512_shuffle_f64x2(s0, s1, 0xDD));
    const __m512d v1 = _mm512_add_pd(_mm512_shuffle_f64x2(s2, s3, 0x88),
                                     _mm512_shuffle_f64x2(s2, s3, 0xDD));
    /* lanes: sums of a0, a1, a2, a3, c0, c1, c2, c3 */
    const __m512d v = _mm512_add_pd(_mm512_shuffle_f64x2(v0, v1, 0x88),
                                    _mm512_shuffle_f64x2(v0, v1, 0xDD));
    const __mmask8 m = both ? 0xFF : 0x0F;
    _mm512_mask_storeu_pd(o, m, _mm512_fmadd_pd(_mm512_set1_pd(s), v, _mm512_maskz_loadu_pd(m, o)));
}
/* The same in float: 16 lanes, the 8 sums in the low 8. */
static inline void kifmm_kernel__red8x16(__m512 a0, __m512 a1, __m512 a2, __m512 a3, __m512 c0,
                                         __m512 c1, __m512 c2, __m512 c3, float s, float *o,
                                         int both)
{
    const __m512 s0 = _mm512_add_ps(_mm512_unpacklo_ps(a0, a1), _mm512_unpackhi_ps(a0, a1));
    const __m512 s1 = _mm512_add_ps(_mm512_unpacklo_ps(a2, a3), _mm512_unpackhi_ps(a2, a3));
    const __m512 s2 = _mm512_add_ps(_mm512_unpacklo_ps(c0, c1), _mm512_unpackhi_ps(c0, c1));
    const __m512 s3 = _mm512_add_ps(_mm512_unpacklo_ps(c2, c3), _mm512_unpackhi_ps(c2, c3));
    /* per 128-bit block, lanes (a0 a1 a0 a1) and (a2 a3 a2 a3): pairs added */
    const __m512 t0 = _mm512_add_ps(_mm512_shuffle_ps(s0, s1, 0x44), _mm512_shuffle_ps(s0, s1, 0xEE));
    const __m512 t1 = _mm512_add_ps(_mm512_shuffle_ps(s2, s3, 0x44), _mm512_shuffle_ps(s2, s3, 0xEE));
    /* each 128-bit block holds a0..a3 (t0) or c0..c3 (t1): add the 4 blocks */
    const __m512 u = _mm512_add_ps(_mm512_shuffle_f32x4(t0, t1, 0x88),
                                   _mm512_shuffle_f32x4(t0, t1, 0xDD));
    const __m512 v = _mm512_add_ps(_mm512_shuffle_f32x4(u, u, 0x08), _mm512_shuffle_f32x4(u, u, 0x0D));
    const __mmask16 m = both ? 0xFF : 0x0F;
    _mm512_mask_storeu_ps(o, m, _mm512_fmadd_ps(_mm512_set1_ps(s), v, _mm512_maskz_loadu_ps(m, o)));
}
/* Adds the sources j..j+7 of `valid` to the sums of the target (X, Y, Z);
 * lanes outside `valid` are neither read nor counted. */
static inline __m512d kifmm_kernel__avx512_laplace(__m512d acc, __mmask8 valid, __m512d X,
                                                   __m512d Y, __m512d Z, const double *sx,
                                                   const double *sy, const double *sz,
                                                   const double *q)
{
    __m512d dx = _mm512_sub_pd(X, _mm512_maskz_loadu_pd(valid, sx));
    __m512d dy = _mm512_sub_pd(Y, _mm512_maskz_loadu_pd(valid, sy));
    __m512d dz = _mm512_sub_pd(Z, _mm512_maskz_loadu_pd(valid, sz));
    __m512d r2 = _mm512_fmadd_pd(dz, dz, _mm512_fmadd_pd(dy, dy, _mm512_mul_pd(dx, dx)));
    return _mm512_fmadd_pd(kifmm_kernel__rinv8(r2), _mm512_maskz_loadu_pd(valid, q), acc);
}

static inline void kifmm_kernel__avx512_laplace_grad(__m512d *acc, __mmask8 valid, __m512d X,
                                                     __m512d Y, __m512d Z, const double *sx,
                                                     const double *sy, const double *sz,
                                                     const double *q)
{
    __m512d dx = _mm512_sub_pd(X, _mm512_maskz_loadu_pd(valid, sx));
    __m512d dy = _mm512_sub_pd(Y, _mm512_maskz_loadu_pd(valid, sy));
    __m512d dz = _mm512_sub_pd(Z, _mm512_maskz_loadu_pd(valid, sz));
    __m512d r2 = _mm512_fmadd_pd(dz, dz, _mm512_fmadd_pd(dy, dy, _mm512_mul_pd(dx, dx)));
    /* dead lanes zeroed: their sources load as 0, and for a target within
     * 1e-154 of 0 their 1 / r^2 overflows, which a zero density would turn
     * into NaN */
    __m512d inv = _mm512_maskz_mov_pd(valid, kifmm_kernel__rinv8(r2)), qv = _mm512_maskz_loadu_pd(valid, q);
    /* q / r added on the adder pipes, then reused for q / r^3 */
    __m512d qi = _mm512_mul_pd(qv, inv), qi3 = _mm512_mul_pd(qi, _mm512_mul_pd(inv, inv));
    acc[0] = _mm512_add_pd(acc[0], qi); /* the densities are 0 in dead lanes */
    acc[1] = _mm512_fnmadd_pd(qi3, dx, acc[1]);
    acc[2] = _mm512_fnmadd_pd(qi3, dy, acc[2]);
    acc[3] = _mm512_fnmadd_pd(qi3, dz, acc[3]);
}

#elif defined(__AVX2__) && defined(__FMA__)
#include <immintrin.h>

/* 1 / sqrt(r2) where r2 > 0, 0 elsewhere, from a correctly rounded sqrt and
 * division: within 1 ulp over the whole range (subnormal r2 included; r2 ==
 * inf gives 0, as the scalar kernel does).  On AMD Zen 3 this measured as fast
 * as float rsqrt + 3 Newton steps for laplace and 1.35x faster for
 * laplace_grad, and it needs no range handling. */
static inline __m256d kifmm_kernel__avx2_rinv(__m256d r2)
{
    const __m256d live = _mm256_cmp_pd(r2, _mm256_setzero_pd(), _CMP_GT_OQ);
    return _mm256_and_pd(_mm256_div_pd(_mm256_set1_pd(1.0), _mm256_sqrt_pd(r2)), live);
}


static inline __m256d kifmm_kernel__avx2_r2(__m256d dx, __m256d dy, __m256d dz)
{
    return _mm256_fmadd_pd(dz, dz, _mm256_fmadd_pd(dy, dy, _mm256_mul_pd(dx, dx)));
}

static inline double kifmm_kernel__avx2_sum(__m256d v)
{
    __m128d s = _mm_add_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1));
    return _mm_cvtsd_f64(_mm_add_sd(s, _mm_unpackhi_pd(s, s)));
}

/* Potential and gradient sums of one target over 4 sources; inv is 0 in the
 * lanes that do not count, so those add exactly 0. */
static inline void kifmm_kernel__avx2_grad_add(__m256d *acc, __m256d dx, __m256d dy,
                                               __m256d dz, __m256d q, __m256d inv)
{
    __m256d qi = _mm256_mul_pd(q, inv);
    __m256d qi3 = _mm256_mul_pd(_mm256_mul_pd(qi, inv), inv);
    acc[0] = _mm256_add_pd(acc[0], qi);
    acc[1] = _mm256_fnmadd_pd(qi3, dx, acc[1]);
    acc[2] = _mm256_fnmadd_pd(qi3, dy, acc[2]);
    acc[3] = _mm256_fnmadd_pd(qi3, dz, acc[3]);
}

#else

#include <string.h>

/* Targets per block of the portable loops: the fixed trip count of the inner
 * loop lets gcc vectorize it at -O2. */
#define kifmm_kernel__NB 8

/* 1 / sqrt(r2) for r2 normal (0 for r2 == 0), without a call to sqrt(),
 * whose errno side effect keeps compilers from vectorizing: a first guess
 * from the halved exponent (relative error < 3.5%), then four Newton steps,
 * each squaring the error.  Wrong for subnormal, infinite or NaN r2: the
 * callers flag those with kifmm_kernel__rare and redo such blocks with
 * kifmm_kernel__rinv_exact. */
static inline double kifmm_kernel__rinv(double r2)
{
    const double h = 0.5 * r2;
    uint64_t u, keep;
    double y;
    memcpy(&u, &r2, sizeof u);
    keep = ((u - 1) >> 63) - 1; /* 0 if r2 == 0, all ones otherwise */
    u = UINT64_C(0x5FE6EB50C7B537A9) - (u >> 1);
    memcpy(&y, &u, sizeof y);
    y *= 1.5 - h * y * y;
    y *= 1.5 - h * y * y;
    y *= 1.5 - h * y * y;
    y += y * (0.5 - h * y * y); /* last step in the form that rounds best */
    memcpy(&u, &y, sizeof u);
    u &= keep;
    memcpy(&y, &u, sizeof y);
    return y;
}

/* 1 if r2 is subnormal, infinite or NaN (kifmm_kernel__rinv's blind spots),
 * else 0: sign bits of u - 2^52 and u - 1 differ for subnormal r2, that of
 * u + 2^52 is set for inf and NaN, that of u for a NaN with the sign set.
 * Integer arithmetic on the bits u of r2, not compares, which compilers may
 * turn into branches that block vectorization. */
static inline uint64_t kifmm_kernel__rare(double r2)
{
    const uint64_t e1 = UINT64_C(1) << 52;
    uint64_t u;
    memcpy(&u, &r2, sizeof u);
    return (((u - e1) ^ (u - 1)) | (u + e1) | u) >> 63;
}

/* The scalar kernel's 1 / sqrt(r2): 0 for r2 == 0 (and NaN), 0 for inf. */
static inline double kifmm_kernel__rinv_exact(double r2)
{
    return r2 > 0.0 ? 1.0 / sqrt(r2) : 0.0;
}

/* Loads targets i0 .. i0 + nb - 1 into x, y, z, padded to kifmm_kernel__NB
 * with copies of the first (their results are dropped). */
static inline void kifmm_kernel__block(const double *tx, const double *ty, const double *tz,
                                       int64_t i0, int nb, double *x, double *y, double *z)
{
    int i;
    for (i = 0; i < kifmm_kernel__NB; i++) {
        x[i] = tx[i0 + (i < nb ? i : 0)];
        y[i] = ty[i0 + (i < nb ? i : 0)];
        z[i] = tz[i0 + (i < nb ? i : 0)];
    }
}

#if !defined(KIFMM_KERNEL__NEON)
/* (aarch64: the vector layer's hooks, below) */
static inline void kifmm_kernel_laplace_p2p(const double *param, const double *tx,
                                            const double *ty, const double *tz, int64_t nt,
                                            const double *sx, const double *sy,
                                            const double *sz, const double *q, int64_t ns,
                                            double scale, double *out)
{
    const double s = scale * KIFMM_INV_4PI;
    double x[kifmm_kernel__NB], y[kifmm_kernel__NB], z[kifmm_kernel__NB], acc[kifmm_kernel__NB];
    uint64_t rare[kifmm_kernel__NB];
    int64_t i0, j;
    int i, nb;
    (void)param;
    for (i0 = 0; i0 < nt; i0 += kifmm_kernel__NB) {
        nb = nt - i0 < kifmm_kernel__NB ? (int)(nt - i0) : kifmm_kernel__NB;
        kifmm_kernel__block(tx, ty, tz, i0, nb, x, y, z);
        for (i = 0; i < kifmm_kernel__NB; i++) {
            acc[i] = 0.0;
            rare[i] = 0;
        }
        for (j = 0; j < ns; j++) {
            const double X = sx[j], Y = sy[j], Z = sz[j], Q = q[j];
            for (i = 0; i < kifmm_kernel__NB; i++) {
                const double dx = x[i] - X, dy = y[i] - Y, dz = z[i] - Z;
                const double r2 = dx * dx + dy * dy + dz * dz;
                acc[i] += Q * kifmm_kernel__rinv(r2);
                rare[i] |= kifmm_kernel__rare(r2);
            }
        }
        for (i = 1; i < kifmm_kernel__NB; i++) rare[0] |= rare[i];
        if (rare[0]) { /* a subnormal or infinite distance: the block again, exactly */
            for (i = 0; i < nb; i++) {
                acc[i] = 0.0;
                for (j = 0; j < ns; j++) {
                    const double dx = x[i] - sx[j], dy = y[i] - sy[j], dz = z[i] - sz[j];
                    acc[i] += q[j] * kifmm_kernel__rinv_exact(dx * dx + dy * dy + dz * dz);
                }
            }
        }
        for (i = 0; i < nb; i++) out[i0 + i] += s * acc[i];
    }
}

static inline void kifmm_kernel_laplace_grad_p2p(const double *param, const double *tx,
                                                 const double *ty, const double *tz,
                                                 int64_t nt, const double *sx,
                                                 const double *sy, const double *sz,
                                                 const double *q, int64_t ns, double scale,
                                                 double *out)
{
    const double s = scale * KIFMM_INV_4PI;
    double x[kifmm_kernel__NB], y[kifmm_kernel__NB], z[kifmm_kernel__NB];
    double p[kifmm_kernel__NB], gx[kifmm_kernel__NB], gy[kifmm_kernel__NB], gz[kifmm_kernel__NB];
    uint64_t rare[kifmm_kernel__NB];
    int64_t i0, j;
    int i, nb;
    (void)param;
    for (i0 = 0; i0 < nt; i0 += kifmm_kernel__NB) {
        nb = nt - i0 < kifmm_kernel__NB ? (int)(nt - i0) : kifmm_kernel__NB;
        kifmm_kernel__block(tx, ty, tz, i0, nb, x, y, z);
        for (i = 0; i < kifmm_kernel__NB; i++) {
            p[i] = gx[i] = gy[i] = gz[i] = 0.0;
            rare[i] = 0;
        }
        for (j = 0; j < ns; j++) {
            const double X = sx[j], Y = sy[j], Z = sz[j], Q = q[j];
            for (i = 0; i < kifmm_kernel__NB; i++) {
                const double dx = x[i] - X, dy = y[i] - Y, dz = z[i] - Z;
                const double r2 = dx * dx + dy * dy + dz * dz;
                const double inv = kifmm_kernel__rinv(r2);
                const double qi = Q * inv, qi3 = qi * inv * inv;
                p[i] += qi;
                gx[i] -= qi3 * dx;
                gy[i] -= qi3 * dy;
                gz[i] -= qi3 * dz;
                rare[i] |= kifmm_kernel__rare(r2);
            }
        }
        for (i = 1; i < kifmm_kernel__NB; i++) rare[0] |= rare[i];
        if (rare[0]) { /* a subnormal or infinite distance: the block again, exactly */
            for (i = 0; i < nb; i++) {
                p[i] = gx[i] = gy[i] = gz[i] = 0.0;
                for (j = 0; j < ns; j++) {
                    const double dx = x[i] - sx[j], dy = y[i] - sy[j], dz = z[i] - sz[j];
                    const double inv = kifmm_kernel__rinv_exact(dx * dx + dy * dy + dz * dz);
                    const double qi = q[j] * inv, qi3 = qi * inv * inv;
                    p[i] += qi;
                    gx[i] -= qi3 * dx;
                    gy[i] -= qi3 * dy;
                    gz[i] -= qi3 * dz;
                }
            }
        }
        for (i = 0; i < nb; i++) {
            out[4 * (i0 + i) + 0] += s * p[i];
            out[4 * (i0 + i) + 1] += s * gx[i];
            out[4 * (i0 + i) + 2] += s * gy[i];
            out[4 * (i0 + i) + 3] += s * gz[i];
        }
    }
}

#endif /* !KIFMM_KERNEL__NEON */
#endif

/* ------------------------------------------------------------------------ */
/* The vector layer: a double vector and its operations per instruction set */
/* ------------------------------------------------------------------------ */
// >>vector
/* kifmm_kernel__vd holds kifmm_kernel__VDN doubles: 8 with AVX-512F, 4 with
 * AVX2 + FMA, 2 with aarch64's Advanced SIMD (NEON); elsewhere the layer is
 * absent (kifmm_kernel__VDN undefined) and the hooks are the portable loops
 * above. Hooks written on it have one body for every instruction set.
 *   vd_set1(a), vd_zero()       every lane a, or 0
 *   vd_load(p)                  p[0 .. VDN - 1], unaligned
 *   vd_loadn(p, n)              p[0 .. n - 1] and 0 above, 0 < n < VDN, nothing
 *                               read past p + n - 1
 *   vd_keep(v, n)               v with the lanes from n up set to 0
 *   vd_add, vd_sub, vd_mul      a + b, a - b, a b
 *   vd_fma(a, b, c), vd_fnma    a b + c and c - a b, one rounding
 *   vd_rinv(r2)                 1 / sqrt(r2) for 0 < r2 < inf (AVX-512:
 *                               rsqrt14 and a fourth-order correction, a few
 *                               ulp; else sqrt and division, 1 ulp), 0 for
 *                               r2 = 0, inf or NaN
 *   vd_hsum(v)                  the sum of the lanes
 *   vd_red4x2(a, c, s, o, both) o[k] += s sum(a[k]), and o[4 + k] += s
 *                               sum(c[k]) if both, k = 0 .. 3 */
#if defined(__AVX512F__)
#define kifmm_kernel__VDN 8
typedef __m512d kifmm_kernel__vd;
static inline __m512d kifmm_kernel__vd_set1(double a) { return _mm512_set1_pd(a); }
static inline __m512d kifmm_kernel__vd_zero(void) { return _mm512_setzero_pd(); }
static inline __m512d kifmm_kernel__vd_load(const double *p) { return _mm512_loadu_pd(p); }
static inline __m512d kifmm_kernel__vd_loadn(const double *p, int64_t n)
{
    return _mm512_maskz_loadu_pd(kifmm_kernel__first8(n), p);
}
static inline __m512d kifmm_kernel__vd_keep(__m512d v, int64_t n)
{
    return _mm512_maskz_mov_pd(kifmm_kernel__first8(n), v);
}
static inline __m512d kifmm_kernel__vd_add(__m512d a, __m512d b) { return _mm512_add_pd(a, b); }
static inline __m512d kifmm_kernel__vd_sub(__m512d a, __m512d b) { return _mm512_sub_pd(a, b); }
static inline __m512d kifmm_kernel__vd_mul(__m512d a, __m512d b) { return _mm512_mul_pd(a, b); }
static inline __m512d kifmm_kernel__vd_fma(__m512d a, __m512d b, __m512d c)
{
    return _mm512_fmadd_pd(a, b, c);
}
static inline __m512d kifmm_kernel__vd_fnma(__m512d a, __m512d b, __m512d c)
{
    return _mm512_fnmadd_pd(a, b, c);
}
static inline __m512d kifmm_kernel__vd_rinv(__m512d r2) { return kifmm_kernel__rinv8(r2); }
static inline double kifmm_kernel__vd_hsum(__m512d v) { return _mm512_reduce_add_pd(v); }
static inline void kifmm_kernel__vd_red4x2(const __m512d *a, const __m512d *c, double s,
                                           double *o, int both)
{
    kifmm_kernel__red8x8(a[0], a[1], a[2], a[3], c[0], c[1], c[2], c[3], s, o, both);
}
#elif defined(__AVX2__) && defined(__FMA__)
#define kifmm_kernel__VDN 4
typedef __m256d kifmm_kernel__vd;
static inline __m256d kifmm_kernel__vd_set1(double a) { return _mm256_set1_pd(a); }
static inline __m256d kifmm_kernel__vd_zero(void) { return _mm256_setzero_pd(); }
static inline __m256d kifmm_kernel__vd_load(const double *p) { return _mm256_loadu_pd(p); }
static inline __m256d kifmm_kernel__vd_loadn(const double *p, int64_t n)
{
    return _mm256_maskload_pd(p, kifmm_kernel__first4i(n));
}
static inline __m256d kifmm_kernel__vd_keep(__m256d v, int64_t n)
{
    return _mm256_and_pd(_mm256_castsi256_pd(kifmm_kernel__first4i(n)), v);
}
static inline __m256d kifmm_kernel__vd_add(__m256d a, __m256d b) { return _mm256_add_pd(a, b); }
static inline __m256d kifmm_kernel__vd_sub(__m256d a, __m256d b) { return _mm256_sub_pd(a, b); }
static inline __m256d kifmm_kernel__vd_mul(__m256d a, __m256d b) { return _mm256_mul_pd(a, b); }
static inline __m256d kifmm_kernel__vd_fma(__m256d a, __m256d b, __m256d c)
{
    return _mm256_fmadd_pd(a, b, c);
}
static inline __m256d kifmm_kernel__vd_fnma(__m256d a, __m256d b, __m256d c)
{
    return _mm256_fnmadd_pd(a, b, c);
}
static inline __m256d kifmm_kernel__vd_rinv(__m256d r2) { return kifmm_kernel__avx2_rinv(r2); }
static inline double kifmm_kernel__vd_hsum(__m256d v) { return kifmm_kernel__avx2_sum(v); }
static inline void kifmm_kernel__vd_red4x2(const __m256d *a, const __m256d *c, double s,
                                           double *o, int both)
{
    kifmm_kernel__red4(a[0], a[1], a[2], a[3], s, s, o);
    if (both) kifmm_kernel__red4(c[0], c[1], c[2], c[3], s, s, o + 4);
}
#elif defined(KIFMM_KERNEL__NEON)
#define kifmm_kernel__VDN 2
typedef float64x2_t kifmm_kernel__vd;
static inline float64x2_t kifmm_kernel__vd_set1(double a) { return vdupq_n_f64(a); }
static inline float64x2_t kifmm_kernel__vd_zero(void) { return vdupq_n_f64(0.0); }
static inline float64x2_t kifmm_kernel__vd_load(const double *p) { return vld1q_f64(p); }
static inline float64x2_t kifmm_kernel__vd_loadn(const double *p, int64_t n)
{
    (void)n; /* 0 < n < 2 */
    return vsetq_lane_f64(p[0], vdupq_n_f64(0.0), 0);
}
static inline float64x2_t kifmm_kernel__vd_keep(float64x2_t v, int64_t n)
{
    return n >= 2 ? v : n == 1 ? vsetq_lane_f64(0.0, v, 1) : vdupq_n_f64(0.0);
}
static inline float64x2_t kifmm_kernel__vd_add(float64x2_t a, float64x2_t b) { return vaddq_f64(a, b); }
static inline float64x2_t kifmm_kernel__vd_sub(float64x2_t a, float64x2_t b) { return vsubq_f64(a, b); }
static inline float64x2_t kifmm_kernel__vd_mul(float64x2_t a, float64x2_t b) { return vmulq_f64(a, b); }
static inline float64x2_t kifmm_kernel__vd_fma(float64x2_t a, float64x2_t b, float64x2_t c)
{
    return vfmaq_f64(c, a, b);
}
static inline float64x2_t kifmm_kernel__vd_fnma(float64x2_t a, float64x2_t b, float64x2_t c)
{
    return vfmsq_f64(c, a, b);
}
static inline float64x2_t kifmm_kernel__vd_rinv(float64x2_t r2)
{
    const uint64x2_t live = vcgtq_f64(r2, vdupq_n_f64(0.0));
    const float64x2_t y = vdivq_f64(vdupq_n_f64(1.0), vsqrtq_f64(r2));
    return vreinterpretq_f64_u64(vandq_u64(vreinterpretq_u64_f64(y), live));
}
static inline double kifmm_kernel__vd_hsum(float64x2_t v) { return vaddvq_f64(v); }
static inline void kifmm_kernel__vd_red4x2(const float64x2_t *a, const float64x2_t *c, double s,
                                           double *o, int both)
{
    int k;
    for (k = 0; k < 4; k++) o[k] += s * vaddvq_f64(a[k]);
    if (both)
        for (k = 0; k < 4; k++) o[4 + k] += s * vaddvq_f64(c[k]);
}
#endif

/* kifmm_kernel__vf: the same in float, kifmm_kernel__VFN lanes (16, 8, 4),
 * the same operations named vf_; vf_rinv(r2) is 1 / sqrt(r2) for FLT_MIN <=
 * r2 <= FLT_MAX (closer pairs count as coincident) and 0 elsewhere: AVX-512
 * rsqrt14 and one Newton step (about 2^-27), AVX2 rsqrt and one Newton step
 * (relative error about 3e-7, a few float ulp), NEON sqrt and division. */
#if defined(__AVX512F__)
#define kifmm_kernel__VFN 16
typedef __m512 kifmm_kernel__vf;
static inline __m512 kifmm_kernel__vf_set1(float a) { return _mm512_set1_ps(a); }
static inline __m512 kifmm_kernel__vf_zero(void) { return _mm512_setzero_ps(); }
static inline __m512 kifmm_kernel__vf_load(const float *p) { return _mm512_loadu_ps(p); }
static inline __m512 kifmm_kernel__vf_loadn(const float *p, int64_t n)
{
    return _mm512_maskz_loadu_ps(kifmm_kernel__first16(n), p);
}
static inline __m512 kifmm_kernel__vf_add(__m512 a, __m512 b) { return _mm512_add_ps(a, b); }
static inline __m512 kifmm_kernel__vf_sub(__m512 a, __m512 b) { return _mm512_sub_ps(a, b); }
static inline __m512 kifmm_kernel__vf_mul(__m512 a, __m512 b) { return _mm512_mul_ps(a, b); }
static inline __m512 kifmm_kernel__vf_fma(__m512 a, __m512 b, __m512 c) { return _mm512_fmadd_ps(a, b, c); }
static inline __m512 kifmm_kernel__vf_fnma(__m512 a, __m512 b, __m512 c)
{
    return _mm512_fnmadd_ps(a, b, c);
}
static inline __m512 kifmm_kernel__vf_rinv(__m512 r2) { return kifmm_kernel__rinv16(r2); }
static inline float kifmm_kernel__vf_hsum(__m512 v) { return _mm512_reduce_add_ps(v); }
static inline void kifmm_kernel__vf_red4x2(const __m512 *a, const __m512 *c, float s, float *o,
                                           int both)
{
    kifmm_kernel__red8x16(a[0], a[1], a[2], a[3], c[0], c[1], c[2], c[3], s, o, both);
}
#elif defined(__AVX2__) && defined(__FMA__)
#define kifmm_kernel__VFN 8
typedef __m256 kifmm_kernel__vf;
static inline __m256 kifmm_kernel__avx2_rinvf(__m256 r2)
{
    const __m256 live = _mm256_and_ps(_mm256_cmp_ps(r2, _mm256_set1_ps(FLT_MIN), _CMP_GE_OQ),
                                      _mm256_cmp_ps(r2, _mm256_set1_ps(FLT_MAX), _CMP_LE_OQ));
    __m256 y = _mm256_rsqrt_ps(r2);
    __m256 e = _mm256_fnmadd_ps(_mm256_mul_ps(r2, y), y, _mm256_set1_ps(1.0f));
    y = _mm256_fmadd_ps(_mm256_mul_ps(_mm256_set1_ps(0.5f), y), e, y);
    return _mm256_and_ps(y, live);
}
static inline float kifmm_kernel__avx2_sumf(__m256 v)
{
    __m128 s = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));
    s = _mm_add_ps(s, _mm_movehl_ps(s, s));
    return _mm_cvtss_f32(_mm_add_ss(s, _mm_movehdup_ps(s)));
}
static inline __m256 kifmm_kernel__vf_set1(float a) { return _mm256_set1_ps(a); }
static inline __m256 kifmm_kernel__vf_zero(void) { return _mm256_setzero_ps(); }
static inline __m256 kifmm_kernel__vf_load(const float *p) { return _mm256_loadu_ps(p); }
static inline __m256 kifmm_kernel__vf_loadn(const float *p, int64_t n)
{
    return _mm256_maskload_ps(p, kifmm_kernel__first8i(n));
}
static inline __m256 kifmm_kernel__vf_add(__m256 a, __m256 b) { return _mm256_add_ps(a, b); }
static inline __m256 kifmm_kernel__vf_sub(__m256 a, __m256 b) { return _mm256_sub_ps(a, b); }
static inline __m256 kifmm_kernel__vf_mul(__m256 a, __m256 b) { return _mm256_mul_ps(a, b); }
static inline __m256 kifmm_kernel__vf_fma(__m256 a, __m256 b, __m256 c) { return _mm256_fmadd_ps(a, b, c); }
static inline __m256 kifmm_kernel__vf_fnma(__m256 a, __m256 b, __m256 c)
{
    return _mm256_fnmadd_ps(a, b, c);
}
static inline __m256 kifmm_kernel__vf_rinv(__m256 r2) { return kifmm_kernel__avx2_rinvf(r2); }
static inline float kifmm_kernel__vf_hsum(__m256 v) { return kifmm_kernel__avx2_sumf(v); }
static inline void kifmm_kernel__vf_red4x2(const __m256 *a, const __m256 *c, float s, float *o,
                                           int both)
{
    int k;
    for (k = 0; k < 4; k++) o[k] += s * kifmm_kernel__avx2_sumf(a[k]);
    if (both)
        for (k = 0; k < 4; k++) o[4 + k] += s * kifmm_kernel__avx2_sumf(c[k]);
}
#elif defined(KIFMM_KERNEL__NEON)
#define kifmm_kernel__VFN 4
typedef float32x4_t kifmm_kernel__vf;
static inline float32x4_t kifmm_kernel__vf_set1(float a) { return vdupq_n_f32(a); }
static inline float32x4_t kifmm_kernel__vf_zero(void) { return vdupq_n_f32(0.0f); }
static inline float32x4_t kifmm_kernel__vf_load(const float *p) { return vld1q_f32(p); }
static inline float32x4_t kifmm_kernel__vf_loadn(const float *p, int64_t n)
{
    float b[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    int64_t i;
    for (i = 0; i < n && i < 4; i++) b[i] = p[i];
    return vld1q_f32(b);
}
static inline float32x4_t kifmm_kernel__vf_add(float32x4_t a, float32x4_t b) { return vaddq_f32(a, b); }
static inline float32x4_t kifmm_kernel__vf_sub(float32x4_t a, float32x4_t b) { return vsubq_f32(a, b); }
static inline float32x4_t kifmm_kernel__vf_mul(float32x4_t a, float32x4_t b) { return vmulq_f32(a, b); }
static inline float32x4_t kifmm_kernel__vf_fma(float32x4_t a, float32x4_t b, float32x4_t c)
{
    return vfmaq_f32(c, a, b);
}
static inline float32x4_t kifmm_kernel__vf_fnma(float32x4_t a, float32x4_t b, float32x4_t c)
{
    return vfmsq_f32(c, a, b);
}
static inline float32x4_t kifmm_kernel__vf_rinv(float32x4_t r2)
{
    const uint32x4_t live = vandq_u32(vcgeq_f32(r2, vdupq_n_f32(FLT_MIN)),
                                      vcleq_f32(r2, vdupq_n_f32(FLT_MAX)));
    const float32x4_t y = vdivq_f32(vdupq_n_f32(1.0f), vsqrtq_f32(r2));
    return vreinterpretq_f32_u32(vandq_u32(vreinterpretq_u32_f32(y), live));
}
static inline float kifmm_kernel__vf_hsum(float32x4_t v) { return vaddvq_f32(v); }
static inline void kifmm_kernel__vf_red4x2(const float32x4_t *a, const float32x4_t *c, float s,
                                           float *o, int both)
{
    int k;
    for (k = 0; k < 4; k++) o[k] += s * vaddvq_f32(a[k]);
    if (both)
        for (k = 0; k < 4; k++) o[4 + k] += s * vaddvq_f32(c[k]);
}
#endif

#if defined(kifmm_kernel__VDN)
/* The hooks of laplace and laplace_grad on the layer (the portable loops
 * above without it).  The last sources, fewer than a vector, are loaded
 * with vd_loadn and their lanes of 1 / r kept with vd_keep: the dead lanes'
 * sources read as 0, and for a target within 1e-154 of 0 their 1 / r^2
 * would overflow, which a zero density would turn into NaN. */

/* The sums of one target (X, Y, Z) over one vector of sources: n live
 * lanes (kifmm_kernel__VDN for a whole vector). */
/* 1 / r and the differences d of one target and one vector of sources, the
 * lanes from n up of 1 / r set to 0 */
static inline kifmm_kernel__vd kifmm_kernel__vd_pair(kifmm_kernel__vd X, kifmm_kernel__vd Y,
                                                     kifmm_kernel__vd Z, const kifmm_kernel__vd *s,
                                                     int64_t n, kifmm_kernel__vd *d)
{
    kifmm_kernel__vd inv;
    d[0] = kifmm_kernel__vd_sub(X, s[0]);
    d[1] = kifmm_kernel__vd_sub(Y, s[1]);
    d[2] = kifmm_kernel__vd_sub(Z, s[2]);
    inv = kifmm_kernel__vd_rinv(kifmm_kernel__vd_fma(
        d[2], d[2], kifmm_kernel__vd_fma(d[1], d[1], kifmm_kernel__vd_mul(d[0], d[0]))));
    return n < kifmm_kernel__VDN ? kifmm_kernel__vd_keep(inv, n) : inv;
}
static inline kifmm_kernel__vd kifmm_kernel__vd_laplace(kifmm_kernel__vd acc, kifmm_kernel__vd X,
                                                        kifmm_kernel__vd Y, kifmm_kernel__vd Z,
                                                        const kifmm_kernel__vd *s, int64_t n)
{
    kifmm_kernel__vd d[3];
    return kifmm_kernel__vd_fma(kifmm_kernel__vd_pair(X, Y, Z, s, n, d), s[3], acc);
}
static inline void kifmm_kernel__vd_laplace_grad(kifmm_kernel__vd *acc, kifmm_kernel__vd X,
                                                 kifmm_kernel__vd Y, kifmm_kernel__vd Z,
                                                 const kifmm_kernel__vd *s, int64_t n)
{
    kifmm_kernel__vd d[3];
    const kifmm_kernel__vd inv = kifmm_kernel__vd_pair(X, Y, Z, s, n, d);
    /* q / r added on the adder pipes, then reused for q / r^3 */
    const kifmm_kernel__vd qi = kifmm_kernel__vd_mul(s[3], inv);
    const kifmm_kernel__vd qi3 = kifmm_kernel__vd_mul(qi, kifmm_kernel__vd_mul(inv, inv));
    acc[0] = kifmm_kernel__vd_add(acc[0], qi);
    acc[1] = kifmm_kernel__vd_fnma(qi3, d[0], acc[1]);
    acc[2] = kifmm_kernel__vd_fnma(qi3, d[1], acc[2]);
    acc[3] = kifmm_kernel__vd_fnma(qi3, d[2], acc[3]);
}
/* Sources j .. j + n - 1 (x, y, z, q) into s[0 .. 3]: a whole vector, or
 * the last n < VDN. */
static inline void kifmm_kernel__vd_src(const double *sx, const double *sy, const double *sz,
                                        const double *q, int64_t j, int64_t n,
                                        kifmm_kernel__vd *s)
{
    if (n >= kifmm_kernel__VDN) {
        s[0] = kifmm_kernel__vd_load(sx + j);
        s[1] = kifmm_kernel__vd_load(sy + j);
        s[2] = kifmm_kernel__vd_load(sz + j);
        s[3] = kifmm_kernel__vd_load(q + j);
    } else {
        s[0] = kifmm_kernel__vd_loadn(sx + j, n);
        s[1] = kifmm_kernel__vd_loadn(sy + j, n);
        s[2] = kifmm_kernel__vd_loadn(sz + j, n);
        s[3] = kifmm_kernel__vd_loadn(q + j, n);
    }
}

static inline void kifmm_kernel_laplace_p2p(const double *param, const double *tx,
                                            const double *ty, const double *tz, int64_t nt,
                                            const double *sx, const double *sy,
                                            const double *sz, const double *q, int64_t ns,
                                            double scale, double *out)
{
    const double s = scale * KIFMM_INV_4PI;
    const int64_t nv = ns - ns % kifmm_kernel__VDN;
    kifmm_kernel__vd v[4];
    int64_t i, j;
    (void)param;
    for (i = 0; i < nt; i++) {
        const kifmm_kernel__vd X = kifmm_kernel__vd_set1(tx[i]), Y = kifmm_kernel__vd_set1(ty[i]),
                               Z = kifmm_kernel__vd_set1(tz[i]);
        kifmm_kernel__vd acc = kifmm_kernel__vd_zero();
        for (j = 0; j < nv; j += kifmm_kernel__VDN) {
            kifmm_kernel__vd_src(sx, sy, sz, q, j, kifmm_kernel__VDN, v);
            acc = kifmm_kernel__vd_laplace(acc, X, Y, Z, v, kifmm_kernel__VDN);
        }
        if (nv < ns) {
            kifmm_kernel__vd_src(sx, sy, sz, q, nv, ns - nv, v);
            acc = kifmm_kernel__vd_laplace(acc, X, Y, Z, v, ns - nv);
        }
        out[i] += s * kifmm_kernel__vd_hsum(acc);
    }
}

static inline void kifmm_kernel_laplace_grad_p2p(const double *param, const double *tx,
                                                 const double *ty, const double *tz,
                                                 int64_t nt, const double *sx,
                                                 const double *sy, const double *sz,
                                                 const double *q, int64_t ns, double scale,
                                                 double *out)
{
    const double s = scale * KIFMM_INV_4PI;
    const int64_t nv = ns - ns % kifmm_kernel__VDN;
    kifmm_kernel__vd v[4];
    int64_t i, j;
    (void)param;
    /* two targets per pass (i1 = i for the last of an odd count, not
     * stored): each vector of sources loaded once for both */
    for (i = 0; i < nt; i += 2) {
        const int64_t i1 = i + 1 < nt ? i + 1 : i;
        const kifmm_kernel__vd X0 = kifmm_kernel__vd_set1(tx[i]), Y0 = kifmm_kernel__vd_set1(ty[i]),
                               Z0 = kifmm_kernel__vd_set1(tz[i]), X1 = kifmm_kernel__vd_set1(tx[i1]),
                               Y1 = kifmm_kernel__vd_set1(ty[i1]), Z1 = kifmm_kernel__vd_set1(tz[i1]);
        kifmm_kernel__vd a[4], c[4];
        int k;
        for (k = 0; k < 4; k++) a[k] = c[k] = kifmm_kernel__vd_zero();
        for (j = 0; j < nv; j += kifmm_kernel__VDN) {
            kifmm_kernel__vd_src(sx, sy, sz, q, j, kifmm_kernel__VDN, v);
            kifmm_kernel__vd_laplace_grad(a, X0, Y0, Z0, v, kifmm_kernel__VDN);
            kifmm_kernel__vd_laplace_grad(c, X1, Y1, Z1, v, kifmm_kernel__VDN);
        }
        if (nv < ns) {
            kifmm_kernel__vd_src(sx, sy, sz, q, nv, ns - nv, v);
            kifmm_kernel__vd_laplace_grad(a, X0, Y0, Z0, v, ns - nv);
            kifmm_kernel__vd_laplace_grad(c, X1, Y1, Z1, v, ns - nv);
        }
        kifmm_kernel__vd_red4x2(a, c, s, out + 4 * i, i1 > i);
    }
}
#endif /* kifmm_kernel__VDN */

/* Float hooks on the layer with AVX-512 and NEON; with AVX2 the hand-written
 * ones (the single-precision section), which measured faster there
 * (bench_p2p, laplace_grad _p2pf, blocks of 64 to 512: the layer's form 0.92
 * to 0.97 times their pairs per second with one target a pass, 0.90 to 0.93
 * with two). */
#if defined(kifmm_kernel__VFN) && (defined(__AVX512F__) || !defined(__AVX2__))
/* laplace's and laplace_grad's float hooks (_p2pf, the contract of the
 * single-precision section below). The dead lanes of a last partial vector
 * load as 0: their density is 0, each product starts from it (q / r, then
 * times 1 / r twice), and vf_rinv is at most 1 / sqrt(FLT_MIN), so they add
 * exactly 0. */
static inline void kifmm_kernel__vf_src(const float *sx, const float *sy, const float *sz,
                                        const float *q, int64_t j, int64_t n, kifmm_kernel__vf *s)
{
    if (n >= kifmm_kernel__VFN) {
        s[0] = kifmm_kernel__vf_load(sx + j);
        s[1] = kifmm_kernel__vf_load(sy + j);
        s[2] = kifmm_kernel__vf_load(sz + j);
        s[3] = kifmm_kernel__vf_load(q + j);
    } else {
        s[0] = kifmm_kernel__vf_loadn(sx + j, n);
        s[1] = kifmm_kernel__vf_loadn(sy + j, n);
        s[2] = kifmm_kernel__vf_loadn(sz + j, n);
        s[3] = kifmm_kernel__vf_loadn(q + j, n);
    }
}
/* 1 / r and the differences of one target and one vector of sources */
static inline kifmm_kernel__vf kifmm_kernel__vf_pair(kifmm_kernel__vf X, kifmm_kernel__vf Y,
                                                     kifmm_kernel__vf Z, const kifmm_kernel__vf *s,
                                                     kifmm_kernel__vf *d)
{
    d[0] = kifmm_kernel__vf_sub(X, s[0]);
    d[1] = kifmm_kernel__vf_sub(Y, s[1]);
    d[2] = kifmm_kernel__vf_sub(Z, s[2]);
    return kifmm_kernel__vf_rinv(kifmm_kernel__vf_fma(
        d[2], d[2], kifmm_kernel__vf_fma(d[1], d[1], kifmm_kernel__vf_mul(d[0], d[0]))));
}
static inline void kifmm_kernel__vf_laplace_grad(kifmm_kernel__vf *acc, kifmm_kernel__vf X,
                                                 kifmm_kernel__vf Y, kifmm_kernel__vf Z,
                                                 const kifmm_kernel__vf *s)
{
    kifmm_kernel__vf d[3];
    const kifmm_kernel__vf inv = kifmm_kernel__vf_pair(X, Y, Z, s, d);
    const kifmm_kernel__vf qi3 = kifmm_kernel__vf_mul(
        kifmm_kernel__vf_mul(kifmm_kernel__vf_mul(s[3], inv), inv), inv);
    acc[0] = kifmm_kernel__vf_fma(s[3], inv, acc[0]);
    acc[1] = kifmm_kernel__vf_fnma(qi3, d[0], acc[1]);
    acc[2] = kifmm_kernel__vf_fnma(qi3, d[1], acc[2]);
    acc[3] = kifmm_kernel__vf_fnma(qi3, d[2], acc[3]);
}

static inline void kifmm_kernel_laplace_p2pf(const double *param, const float *tx,
                                             const float *ty, const float *tz, int64_t nt,
                                             const float *sx, const float *sy, const float *sz,
                                             const float *q, int64_t ns, float scale, float *out)
{
    const float s = scale * (float)KIFMM_INV_4PI;
    kifmm_kernel__vf v[4], d[3];
    int64_t i, j;
    (void)param;
    for (i = 0; i < nt; i++) {
        const kifmm_kernel__vf X = kifmm_kernel__vf_set1(tx[i]), Y = kifmm_kernel__vf_set1(ty[i]),
                               Z = kifmm_kernel__vf_set1(tz[i]);
        kifmm_kernel__vf acc = kifmm_kernel__vf_zero();
        for (j = 0; j < ns; j += kifmm_kernel__VFN) {
            kifmm_kernel__vf_src(sx, sy, sz, q, j, ns - j, v);
            acc = kifmm_kernel__vf_fma(kifmm_kernel__vf_pair(X, Y, Z, v, d), v[3], acc);
        }
        out[i] += s * kifmm_kernel__vf_hsum(acc);
    }
}

static inline void kifmm_kernel_laplace_grad_p2pf(const double *param, const float *tx,
                                                  const float *ty, const float *tz, int64_t nt,
                                                  const float *sx, const float *sy,
                                                  const float *sz, const float *q, int64_t ns,
                                                  float scale, float *out)
{
    const float s = scale * (float)KIFMM_INV_4PI;
    kifmm_kernel__vf v[4];
    int64_t i, j;
    (void)param;
    /* two targets per pass (i1 = i for the last of an odd count, not stored) */
    for (i = 0; i < nt; i += 2) {
        const int64_t i1 = i + 1 < nt ? i + 1 : i;
        const kifmm_kernel__vf X0 = kifmm_kernel__vf_set1(tx[i]), Y0 = kifmm_kernel__vf_set1(ty[i]),
                               Z0 = kifmm_kernel__vf_set1(tz[i]), X1 = kifmm_kernel__vf_set1(tx[i1]),
                               Y1 = kifmm_kernel__vf_set1(ty[i1]), Z1 = kifmm_kernel__vf_set1(tz[i1]);
        kifmm_kernel__vf a[4], c[4];
        int k;
        for (k = 0; k < 4; k++) a[k] = c[k] = kifmm_kernel__vf_zero();
        for (j = 0; j < ns; j += kifmm_kernel__VFN) {
            kifmm_kernel__vf_src(sx, sy, sz, q, j, ns - j, v);
            kifmm_kernel__vf_laplace_grad(a, X0, Y0, Z0, v);
            kifmm_kernel__vf_laplace_grad(c, X1, Y1, Z1, v);
        }
        kifmm_kernel__vf_red4x2(a, c, s, out + 4 * i, i1 > i);
    }
}
#endif /* kifmm_kernel__VFN */

/* ------------------------------------------------------------------------ */
/* Single-precision near-field hooks (kifmm_kernel_NAME_P2PF, _p2pf)         */
/* ------------------------------------------------------------------------ */
/* The same contract as _p2p with float coordinates, densities, scale and
 * outputs, used by instances built with KIFMM_REAL float. AVX2 + FMA: 8
 * lanes, rsqrt and one Newton step (relative error about 3e-7, a few float
 * ulp); AVX-512: 16 lanes, rsqrt14 and one Newton step. Pairs closer than
 * sqrt(FLT_MIN) (1.1e-19) count as coincident and add 0. laplace's and
 * laplace_grad's are the vector layer's (>>vector, kifmm_kernel__vf) with
 * AVX-512 and with NEON on aarch64 (4 lanes, sqrt and division), the bodies
 * below with AVX2 alone; without any of these the generic loop is used. */

#if defined(__AVX2__) && defined(__FMA__) && !defined(__AVX512F__)
/* Differences, 1 / r and the (masked) densities of one target and 8 sources. */
static inline __m256 kifmm_kernel__avx2_pairf(__m256 X, __m256 Y, __m256 Z, const float *sx,
                                              const float *sy, const float *sz, const float *q,
                                              __m256i m, int full, __m256 *dx, __m256 *dy,
                                              __m256 *dz, __m256 *qv)
{
    __m256 r2;
    if (full) {
        *dx = _mm256_sub_ps(X, _mm256_loadu_ps(sx));
        *dy = _mm256_sub_ps(Y, _mm256_loadu_ps(sy));
        *dz = _mm256_sub_ps(Z, _mm256_loadu_ps(sz));
        *qv = _mm256_loadu_ps(q);
    } else {
        *dx = _mm256_sub_ps(X, _mm256_maskload_ps(sx, m));
        *dy = _mm256_sub_ps(Y, _mm256_maskload_ps(sy, m));
        *dz = _mm256_sub_ps(Z, _mm256_maskload_ps(sz, m));
        *qv = _mm256_maskload_ps(q, m); /* 0 past the end */
    }
    r2 = _mm256_fmadd_ps(*dz, *dz, _mm256_fmadd_ps(*dy, *dy, _mm256_mul_ps(*dx, *dx)));
    return kifmm_kernel__avx2_rinvf(r2);
}

static inline void kifmm_kernel_laplace_p2pf(const double *param, const float *tx,
                                             const float *ty, const float *tz, int64_t nt,
                                             const float *sx, const float *sy, const float *sz,
                                             const float *q, int64_t ns, float scale, float *out)
{
    const float s = scale * (float)KIFMM_INV_4PI;
    const __m256i tail = kifmm_kernel__first8i(ns & 7);
    const int64_t nv = ns & ~(int64_t)7;
    int64_t i, j;
    (void)param;
    for (i = 0; i < nt; i++) {
        const __m256 X = _mm256_set1_ps(tx[i]), Y = _mm256_set1_ps(ty[i]), Z = _mm256_set1_ps(tz[i]);
        __m256 acc = _mm256_setzero_ps(), dx, dy, dz, qv, inv;
        for (j = 0; j < nv; j += 8) {
            inv = kifmm_kernel__avx2_pairf(X, Y, Z, sx + j, sy + j, sz + j, q + j, tail, 1, &dx,
                                           &dy, &dz, &qv);
            acc = _mm256_fmadd_ps(inv, qv, acc);
        }
        if (nv < ns) {
            inv = kifmm_kernel__avx2_pairf(X, Y, Z, sx + nv, sy + nv, sz + nv, q + nv, tail, 0,
                                           &dx, &dy, &dz, &qv);
            acc = _mm256_fmadd_ps(inv, qv, acc);
        }
        out[i] += s * kifmm_kernel__avx2_sumf(acc);
    }
}

static inline void kifmm_kernel_laplace_grad_p2pf(const double *param, const float *tx,
                                                  const float *ty, const float *tz, int64_t nt,
                                                  const float *sx, const float *sy,
                                                  const float *sz, const float *q, int64_t ns,
                                                  float scale, float *out)
{
    const float s = scale * (float)KIFMM_INV_4PI;
    const __m256i tail = kifmm_kernel__first8i(ns & 7);
    const int64_t nv = ns & ~(int64_t)7;
    int64_t i, j;
    (void)param;
    for (i = 0; i < nt; i++) {
        const __m256 X = _mm256_set1_ps(tx[i]), Y = _mm256_set1_ps(ty[i]), Z = _mm256_set1_ps(tz[i]);
        __m256 a0 = _mm256_setzero_ps(), a1 = a0, a2 = a0, a3 = a0, dx, dy, dz, qv, inv, qi, qi3;
        for (j = 0; j < ns; j += 8) {
            inv = kifmm_kernel__avx2_pairf(X, Y, Z, sx + j, sy + j, sz + j, q + j, tail, j < nv,
                                           &dx, &dy, &dz, &qv);
            qi = _mm256_mul_ps(qv, inv);
            qi3 = _mm256_mul_ps(_mm256_mul_ps(qi, inv), inv);
            a0 = _mm256_add_ps(a0, qi);
            a1 = _mm256_fnmadd_ps(qi3, dx, a1);
            a2 = _mm256_fnmadd_ps(qi3, dy, a2);
            a3 = _mm256_fnmadd_ps(qi3, dz, a3);
        }
        out[4 * i + 0] += s * kifmm_kernel__avx2_sumf(a0);
        out[4 * i + 1] += s * kifmm_kernel__avx2_sumf(a1);
        out[4 * i + 2] += s * kifmm_kernel__avx2_sumf(a2);
        out[4 * i + 3] += s * kifmm_kernel__avx2_sumf(a3);
    }
}
#endif /* AVX2 without AVX-512 */

/* B's gradient sums at o, o + SB, o + 2 SB += w0 d0 + w1 d1 (two points of
 * A with differences dx0 .. dz1), and A's two points' sums added to outa
 * (the gradient's four through RED2, or the potential's one through HSUM):
 * steps shared by the mutual bodies below. */
#define KIFMM_KERNEL__ADD_B3(o, w0, w1, SB, LOAD, STORE, FMADD)                                \
    STORE(o, FMADD(w0, dx0, FMADD(w1, dx1, LOAD(o))));                                         \
    STORE(o + (SB), FMADD(w0, dy0, FMADD(w1, dy1, LOAD(o + (SB)))));                           \
    STORE(o + 2 * (SB), FMADD(w0, dz0, FMADD(w1, dz1, LOAD(o + 2 * (SB)))))
/* A's two points' gradient sums -= w0 d0 and w1 d1 */
#define KIFMM_KERNEL__SUB_A2(w0, w1, FNMADD)                                                   \
    a1 = FNMADD(w0, dx0, a1);                                                                  \
    a2 = FNMADD(w0, dy0, a2);                                                                  \
    a3 = FNMADD(w0, dz0, a3);                                                                  \
    c1 = FNMADD(w1, dx1, c1);                                                                  \
    c2 = FNMADD(w1, dy1, c2);                                                                  \
    c3 = FNMADD(w1, dz1, c3)
#define KIFMM_KERNEL__ADD_A2(RED2, HSUM, GRAD)                                                 \
    if (GRAD) {                                                                                \
        RED2(a0, a1, a2, a3, c0, c1, c2, c3, s, outa + 4 * i, i1 > i);                         \
    } else {                                                                                   \
        outa[i] += s * HSUM(a0);                                                               \
        if (i1 > i) outa[i1] += s * HSUM(c0);                                                  \
    }

/* ------------------------------------------------------------------------ */
/* Many-vector near-field hooks (kifmm_kernel_NAME_P2PN / _p2pn, and      */
/* _P2PNF / _p2pnf in float)                                               */
/* ------------------------------------------------------------------------ */
/* kifmm_kernel_NAME_p2pn(param, tx, ty, tz, nt, sx, sy, sz, q, ns, nrhs, qld,
 *                        scale, out, old):
 * for r < nrhs, out[r * old + i * TRG_DIM + k] += scale * sum_j K_k(t_i - s_j)
 * q[r * qld + j * SRC_DIM + s]: the _p2p contract for nrhs density vectors at
 * once, with the pair geometry and 1 / r computed once for all of them. Used
 * by evaluate_many; evaluate calls _p2p. AVX2 + FMA, up to 8 vectors per
 * pass; the double loops use the same correctly rounded 1 / sqrt as the AVX2
 * _p2p (the potential sums are then bitwise those of _p2p), the float loops
 * rsqrt and one Newton step, as _p2pf. AVX-512: the same loops in 8 (double)
 * or 16 (float) lanes with kifmm_kernel__rinv8 / 16. Without AVX2, _p2p is
 * called once per vector. */
#if defined(__AVX2__) && defined(__FMA__)
#include <float.h>
#include <immintrin.h>

#define KIFMM_KERNEL__NV 8 /* density vectors per pass of the many-vector loops */

/* Lanes [0, n) set, 0 <= n <= 4 (double) / 8 (float). */
static inline __m256d kifmm_kernel__nmask(int64_t n) { return _mm256_castsi256_pd(kifmm_kernel__first4i(n)); }
static inline __m256 kifmm_kernel__nmaskf(int64_t n) { return _mm256_castsi256_ps(kifmm_kernel__first8i(n)); }

/* 4 sources from j on (the lanes of m, the rest 0): differences to (X, Y, Z)
 * and 1 / r (0 where r = 0 or the lane is off). */
/* The same from the sources' coordinates already loaded (sx, sy, sz). */
static inline __m256d kifmm_kernel__geomv(__m256d X, __m256d Y, __m256d Z, __m256d sx,
                                          __m256d sy, __m256d sz, __m256d m, __m256d *dx,
                                          __m256d *dy, __m256d *dz)
{
    __m256d r2;
    *dx = _mm256_sub_pd(X, sx);
    *dy = _mm256_sub_pd(Y, sy);
    *dz = _mm256_sub_pd(Z, sz);
    r2 = _mm256_fmadd_pd(*dz, *dz, _mm256_fmadd_pd(*dy, *dy, _mm256_mul_pd(*dx, *dx)));
    m = _mm256_and_pd(m, _mm256_cmp_pd(r2, _mm256_setzero_pd(), _CMP_GT_OQ));
    return _mm256_and_pd(_mm256_div_pd(_mm256_set1_pd(1.0), _mm256_sqrt_pd(r2)), m);
}
static inline __m256d kifmm_kernel__geomn(__m256d X, __m256d Y, __m256d Z, const double *sx,
                                          const double *sy, const double *sz, __m256d m,
                                          __m256d *dx, __m256d *dy, __m256d *dz)
{
    const __m256i mi = _mm256_castpd_si256(m);
    return kifmm_kernel__geomv(X, Y, Z, _mm256_maskload_pd(sx, mi), _mm256_maskload_pd(sy, mi),
                               _mm256_maskload_pd(sz, mi), m, dx, dy, dz);
}

static inline __m256 kifmm_kernel__geomvf(__m256 X, __m256 Y, __m256 Z, __m256 sx, __m256 sy,
                                          __m256 sz, __m256 m, __m256 *dx, __m256 *dy,
                                          __m256 *dz)
{
    __m256 r2, y, e;
    *dx = _mm256_sub_ps(X, sx);
    *dy = _mm256_sub_ps(Y, sy);
    *dz = _mm256_sub_ps(Z, sz);
    r2 = _mm256_fmadd_ps(*dz, *dz, _mm256_fmadd_ps(*dy, *dy, _mm256_mul_ps(*dx, *dx)));
    m = _mm256_and_ps(m, _mm256_and_ps(_mm256_cmp_ps(r2, _mm256_set1_ps(FLT_MIN), _CMP_GE_OQ),
                                       _mm256_cmp_ps(r2, _mm256_set1_ps(FLT_MAX), _CMP_LE_OQ)));
    y = _mm256_rsqrt_ps(r2);
    e = _mm256_fnmadd_ps(_mm256_mul_ps(r2, y), y, _mm256_set1_ps(1.0f));
    y = _mm256_fmadd_ps(_mm256_mul_ps(_mm256_set1_ps(0.5f), y), e, y);
    return _mm256_and_ps(y, m);
}
static inline __m256 kifmm_kernel__geomnf(__m256 X, __m256 Y, __m256 Z, const float *sx,
                                          const float *sy, const float *sz, __m256 m,
                                          __m256 *dx, __m256 *dy, __m256 *dz)
{
    const __m256i mi = _mm256_castps_si256(m);
    return kifmm_kernel__geomvf(X, Y, Z, _mm256_maskload_ps(sx, mi), _mm256_maskload_ps(sy, mi),
                                _mm256_maskload_ps(sz, mi), m, dx, dy, dz);
}

static inline double kifmm_kernel__hsumn(__m256d v)
{
    __m128d s = _mm_add_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1));
    return _mm_cvtsd_f64(_mm_add_sd(s, _mm_unpackhi_pd(s, s)));
}
static inline float kifmm_kernel__hsumnf(__m256 v)
{
    __m128 s = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));
    s = _mm_add_ps(s, _mm_movehl_ps(s, s));
    return _mm_cvtss_f32(_mm_add_ss(s, _mm_movehdup_ps(s)));
}

static inline void kifmm_kernel__red4f(__m256 a0, __m256 a1, __m256 a2, __m256 a3, float s,
                                       float t, float *o)
{
    const __m256 v = _mm256_hadd_ps(_mm256_hadd_ps(a0, a1), _mm256_hadd_ps(a2, a3));
    const __m128 w = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));
    _mm_storeu_ps(o, _mm_fmadd_ps(_mm_setr_ps(s, t, t, t), w, _mm_loadu_ps(o)));
}

/* Two points' sums: o[k] += s (sum of the lanes of ak), and if both,
 * o[4 + k] += s (sum of ck), k = 0..3. */
static inline void kifmm_kernel__red2(__m256d a0, __m256d a1, __m256d a2, __m256d a3,
                                      __m256d c0, __m256d c1, __m256d c2, __m256d c3, double s,
                                      double *o, int both)
{
    kifmm_kernel__red4(a0, a1, a2, a3, s, s, o);
    if (both) kifmm_kernel__red4(c0, c1, c2, c3, s, s, o + 4);
}
static inline void kifmm_kernel__red2f(__m256 a0, __m256 a1, __m256 a2, __m256 a3, __m256 c0,
                                       __m256 c1, __m256 c2, __m256 c3, float s, float *o,
                                       int both)
{
    /* lanes 0..3: a0..a3 of the low halves, 4..7: c0..c3 of the low halves;
     * the same of the high halves, added */
    const __m256 a = _mm256_hadd_ps(_mm256_hadd_ps(a0, a1), _mm256_hadd_ps(a2, a3));
    const __m256 c = _mm256_hadd_ps(_mm256_hadd_ps(c0, c1), _mm256_hadd_ps(c2, c3));
    const __m256 v = _mm256_add_ps(_mm256_permute2f128_ps(a, c, 0x20),
                                   _mm256_permute2f128_ps(a, c, 0x31));
    const __m256 sv = _mm256_set1_ps(s);
    if (both)
        _mm256_storeu_ps(o, _mm256_fmadd_ps(sv, v, _mm256_loadu_ps(o)));
    else
        _mm_storeu_ps(o, _mm_fmadd_ps(_mm256_castps256_ps128(sv), _mm256_castps256_ps128(v),
                                      _mm_loadu_ps(o)));
}

/* Lane l < n of c0..c3 belongs to point l: o[4 l + k] += s ck[l]. */
static inline void kifmm_kernel__tadd(__m256d c0, __m256d c1, __m256d c2, __m256d c3, double s,
                                      double *o, int64_t n)
{
    const __m256d t0 = _mm256_unpacklo_pd(c0, c1), t1 = _mm256_unpackhi_pd(c0, c1);
    const __m256d t2 = _mm256_unpacklo_pd(c2, c3), t3 = _mm256_unpackhi_pd(c2, c3);
    const __m256d sv = _mm256_set1_pd(s);
    __m256d row[4];
    int64_t l;
    row[0] = _mm256_permute2f128_pd(t0, t2, 0x20);
    row[1] = _mm256_permute2f128_pd(t1, t3, 0x20);
    row[2] = _mm256_permute2f128_pd(t0, t2, 0x31);
    row[3] = _mm256_permute2f128_pd(t1, t3, 0x31);
    for (l = 0; l < n; l++)
        _mm256_storeu_pd(o + 4 * l, _mm256_fmadd_pd(sv, row[l], _mm256_loadu_pd(o + 4 * l)));
}
static inline void kifmm_kernel__taddf(__m256 c0, __m256 c1, __m256 c2, __m256 c3, float s,
                                       float *o, int64_t n)
{
    const __m128 sv = _mm_set1_ps(s);
    int64_t h, l;
    for (h = 0; h < 2 && 4 * h < n; h++) {
        __m128 r0 = h ? _mm256_extractf128_ps(c0, 1) : _mm256_castps256_ps128(c0);
        __m128 r1 = h ? _mm256_extractf128_ps(c1, 1) : _mm256_castps256_ps128(c1);
        __m128 r2 = h ? _mm256_extractf128_ps(c2, 1) : _mm256_castps256_ps128(c2);
        __m128 r3 = h ? _mm256_extractf128_ps(c3, 1) : _mm256_castps256_ps128(c3);
        __m128 row[4];
        _MM_TRANSPOSE4_PS(r0, r1, r2, r3);
        row[0] = r0; row[1] = r1; row[2] = r2; row[3] = r3;
        for (l = 0; l < 4 && 4 * h + l < n; l++) {
            float *p = o + 4 * (4 * h + l);
            _mm_storeu_ps(p, _mm_fmadd_ps(sv, row[l], _mm_loadu_ps(p)));
        }
    }
}

/* o[l] += s a[l] for the lanes l < n. */
static inline void kifmm_kernel__addn(__m256d a, double s, double *o, int64_t n)
{
    double t[4];
    int64_t l;
    if (n == 4) {
        _mm256_storeu_pd(o, _mm256_fmadd_pd(_mm256_set1_pd(s), a, _mm256_loadu_pd(o)));
        return;
    }
    _mm256_storeu_pd(t, a);
    for (l = 0; l < n; l++) o[l] += s * t[l];
}
static inline void kifmm_kernel__addnf(__m256 a, float s, float *o, int64_t n)
{
    float t[8];
    int64_t l;
    if (n == 8) {
        _mm256_storeu_ps(o, _mm256_fmadd_ps(_mm256_set1_ps(s), a, _mm256_loadu_ps(o)));
        return;
    }
    _mm256_storeu_ps(t, a);
    for (l = 0; l < n; l++) o[l] += s * t[l];
}

/* The four loops below share one shape. Per target, sources go in chunks of
 * KIFMM_KERNEL__CH: first the geometry of the chunk once (g0 = 1 / r, and for
 * GRAD g1..3 = d / r^3, 0 in lanes that do not count), then every vector
 * against it, two (GRAD) or four at a time with their sums in registers.
 * GRAD gives the potential q / r and the gradient -q d / r^3 (TRG_DIM 4). */
#define KIFMM_KERNEL__CH 128
#define KIFMM_KERNEL__P2PN_BODY(T, V, W, GEOM, MASK, SET1, ZERO, LOADU, STOREU, MLOAD, MUL,     \
                                FMADD, FNMADD, HSUM, GRAD)                                     \
    {                                                                                          \
        const int td = (GRAD) ? 4 : 1;                                                         \
        const T s = (T)scale * (T)KIFMM_INV_4PI;                                               \
        V acc[KIFMM_KERNEL__NV * 4];                                                           \
        T g[4][KIFMM_KERNEL__CH];                                                              \
        int r, r0, nr, k;                                                                      \
        int64_t i, j, j0;                                                                      \
        (void)param;                                                                           \
        for (r0 = 0; r0 < nrhs; r0 += KIFMM_KERNEL__NV) /* passes of up to 8 vectors */      \
        for (i = 0; i < nt; i++) {                                                             \
            const V X = SET1(tx[i]), Y = SET1(ty[i]), Z = SET1(tz[i]);                         \
            const T *qq = q + (size_t)r0 * qld;                                                \
            T *oo = out + (size_t)r0 * old;                                                    \
            nr = nrhs - r0 < KIFMM_KERNEL__NV ? nrhs - r0 : KIFMM_KERNEL__NV;                  \
            for (k = 0; k < 4 * nr; k++) acc[k] = ZERO;                                        \
            for (j0 = 0; j0 < ns; j0 += KIFMM_KERNEL__CH) {                                    \
                const int64_t nj = ns - j0 < KIFMM_KERNEL__CH ? ns - j0 : KIFMM_KERNEL__CH;    \
                const int64_t nf = nj / (W) * (W);  /* full blocks of W */                     \
                const V mt = MASK(nj - nf);         /* the tail block */                       \
                for (j = 0; j < nj; j += (W)) {                                                \
                    V dx, dy, dz;                                                              \
                    const V inv = GEOM(X, Y, Z, sx + j0 + j, sy + j0 + j, sz + j0 + j,          \
                                       j < nf ? MASK(W) : mt, &dx, &dy, &dz);                  \
                    STOREU(g[0] + j, inv);                                                     \
                    if (GRAD) {                                                                \
                        const V inv3 = MUL(MUL(inv, inv), inv);                                \
                        STOREU(g[1] + j, MUL(inv3, dx));                                       \
                        STOREU(g[2] + j, MUL(inv3, dy));                                       \
                        STOREU(g[3] + j, MUL(inv3, dz));                                       \
                    }                                                                          \
                }                                                                              \
                for (r = 0; r < nr; r += (GRAD) ? 2 : 4) {                                   \
                    const int two = (GRAD) ? r + 1 < nr : 0;                                    \
                    const T *qa = qq + (size_t)r * qld + j0;                                    \
                    if (GRAD) {                                                                \
                        const T *qb = two ? qa + qld : qa;                                     \
                        V a0 = acc[4 * r], a1 = acc[4 * r + 1], a2 = acc[4 * r + 2],           \
                          a3 = acc[4 * r + 3], b0 = ZERO, b1 = ZERO, b2 = ZERO, b3 = ZERO;     \
                        if (two) {                                                             \
                            b0 = acc[4 * r + 4]; b1 = acc[4 * r + 5];                          \
                            b2 = acc[4 * r + 6]; b3 = acc[4 * r + 7];                          \
                        }                                                                      \
                        for (j = 0; j < nj; j += (W)) {                                        \
                            const V G0 = LOADU(g[0] + j), G1 = LOADU(g[1] + j),                \
                                    G2 = LOADU(g[2] + j), G3 = LOADU(g[3] + j);                \
                            const V u = j < nf ? LOADU(qa + j) : MLOAD(qa + j, mt);            \
                            const V v = j < nf ? LOADU(qb + j) : MLOAD(qb + j, mt);            \
                            a0 = FMADD(u, G0, a0); a1 = FNMADD(u, G1, a1);                     \
                            a2 = FNMADD(u, G2, a2); a3 = FNMADD(u, G3, a3);                    \
                            b0 = FMADD(v, G0, b0); b1 = FNMADD(v, G1, b1);                     \
                            b2 = FNMADD(v, G2, b2); b3 = FNMADD(v, G3, b3);                    \
                        }                                                                      \
                        acc[4 * r] = a0; acc[4 * r + 1] = a1;                                  \
                        acc[4 * r + 2] = a2; acc[4 * r + 3] = a3;                              \
                        if (two) {                                                             \
                            acc[4 * r + 4] = b0; acc[4 * r + 5] = b1;                          \
                            acc[4 * r + 6] = b2; acc[4 * r + 7] = b3;                          \
                        }                                                                      \
                    } else {                                                                   \
                        const int nu = nr - r < 4 ? nr - r : 4;                                \
                        const T *q1 = nu > 1 ? qa + qld : qa, *q2 = nu > 2 ? qa + 2 * qld : qa, \
                                *q3 = nu > 3 ? qa + 3 * qld : qa;                              \
                        V a0 = acc[r], a1 = nu > 1 ? acc[r + 1] : ZERO,                        \
                          a2 = nu > 2 ? acc[r + 2] : ZERO, a3 = nu > 3 ? acc[r + 3] : ZERO;    \
                        for (j = 0; j < nj; j += (W)) {                                        \
                            const V G0 = LOADU(g[0] + j);                                      \
                            if (j < nf) {                                                      \
                                a0 = FMADD(LOADU(qa + j), G0, a0);                             \
                                a1 = FMADD(LOADU(q1 + j), G0, a1);                             \
                                a2 = FMADD(LOADU(q2 + j), G0, a2);                             \
                                a3 = FMADD(LOADU(q3 + j), G0, a3);                             \
                            } else {                                                           \
                                a0 = FMADD(MLOAD(qa + j, mt), G0, a0);                         \
                                a1 = FMADD(MLOAD(q1 + j, mt), G0, a1);                         \
                                a2 = FMADD(MLOAD(q2 + j, mt), G0, a2);                         \
                                a3 = FMADD(MLOAD(q3 + j, mt), G0, a3);                         \
                            }                                                                  \
                        }                                                                      \
                        acc[r] = a0;                                                           \
                        if (nu > 1) acc[r + 1] = a1;                                           \
                        if (nu > 2) acc[r + 2] = a2;                                           \
                        if (nu > 3) acc[r + 3] = a3;                                           \
                    }                                                                          \
                }                                                                              \
            }                                                                                  \
            for (r = 0; r < nr; r++)                                                           \
                for (k = 0; k < td; k++)                                                       \
                    oo[(size_t)r * old + (size_t)i * td + k] +=                                \
                        s * HSUM(acc[(GRAD) ? 4 * r + k : r]);                                 \
        }                                                                                      \
    }

#if defined(__AVX512F__)
/* AVX-512 helpers of the many-vector loops: masks held as vectors (all bits
 * of a lane set) as the loop bodies expect, turned into mask registers where
 * they are used. */
static inline __m512d kifmm_kernel__nmask8(int64_t n)
{
    return _mm512_castsi512_pd(_mm512_maskz_set1_epi64(kifmm_kernel__first8(n), -1));
}
static inline __m512 kifmm_kernel__nmask16(int64_t n)
{
    return _mm512_castsi512_ps(_mm512_maskz_set1_epi32(kifmm_kernel__first16(n), -1));
}
static inline __mmask8 kifmm_kernel__km8(__m512d m)
{
    return _mm512_test_epi64_mask(_mm512_castpd_si512(m), _mm512_castpd_si512(m));
}
static inline __mmask16 kifmm_kernel__km16(__m512 m)
{
    return _mm512_test_epi32_mask(_mm512_castps_si512(m), _mm512_castps_si512(m));
}
static inline __m512d kifmm_kernel__mload8(const double *p, __m512d m)
{
    return _mm512_maskz_loadu_pd(kifmm_kernel__km8(m), p);
}
static inline __m512 kifmm_kernel__mload16(const float *p, __m512 m)
{
    return _mm512_maskz_loadu_ps(kifmm_kernel__km16(m), p);
}
/* Differences to the sources in the lanes of m and 1 / r there (0 elsewhere). */
static inline __m512d kifmm_kernel__geom8(__m512d X, __m512d Y, __m512d Z, const double *sx,
                                          const double *sy, const double *sz, __m512d m,
                                          __m512d *dx, __m512d *dy, __m512d *dz)
{
    const __mmask8 k = kifmm_kernel__km8(m);
    *dx = _mm512_sub_pd(X, _mm512_maskz_loadu_pd(k, sx));
    *dy = _mm512_sub_pd(Y, _mm512_maskz_loadu_pd(k, sy));
    *dz = _mm512_sub_pd(Z, _mm512_maskz_loadu_pd(k, sz));
    return _mm512_maskz_mov_pd(k, kifmm_kernel__rinv8(_mm512_fmadd_pd(
                                      *dz, *dz, _mm512_fmadd_pd(*dy, *dy, _mm512_mul_pd(*dx, *dx)))));
}
static inline __m512 kifmm_kernel__geom16(__m512 X, __m512 Y, __m512 Z, const float *sx,
                                          const float *sy, const float *sz, __m512 m, __m512 *dx,
                                          __m512 *dy, __m512 *dz)
{
    const __mmask16 k = kifmm_kernel__km16(m);
    *dx = _mm512_sub_ps(X, _mm512_maskz_loadu_ps(k, sx));
    *dy = _mm512_sub_ps(Y, _mm512_maskz_loadu_ps(k, sy));
    *dz = _mm512_sub_ps(Z, _mm512_maskz_loadu_ps(k, sz));
    return _mm512_maskz_mov_ps(k, kifmm_kernel__rinv16(_mm512_fmadd_ps(
                                      *dz, *dz, _mm512_fmadd_ps(*dy, *dy, _mm512_mul_ps(*dx, *dx)))));
}
/* o[0] += s (sum of the lanes of a0), o[k] += t (sum of ak), k = 1..3. */
static inline void kifmm_kernel__red4x8(__m512d a0, __m512d a1, __m512d a2, __m512d a3, double s,
                                        double t, double *o)
{
    const __m512d s0 = _mm512_add_pd(_mm512_unpacklo_pd(a0, a1), _mm512_unpackhi_pd(a0, a1));
    const __m512d s1 = _mm512_add_pd(_mm512_unpacklo_pd(a2, a3), _mm512_unpackhi_pd(a2, a3));
    const __m512d v = _mm512_add_pd(_mm512_shuffle_f64x2(s0, s1, 0x88),
                                    _mm512_shuffle_f64x2(s0, s1, 0xDD));
    /* blocks of v: (a0 a1) twice and (a2 a3) twice, halves of the sums */
    const __m512d u = _mm512_add_pd(v, _mm512_shuffle_f64x2(v, v, 0xB1));
    const __m256d w = _mm512_castpd512_pd256(_mm512_permutexvar_pd(
        _mm512_setr_epi64(0, 1, 4, 5, 0, 1, 4, 5), u));
    _mm256_storeu_pd(o, _mm256_fmadd_pd(_mm256_setr_pd(s, t, t, t), w, _mm256_loadu_pd(o)));
}
static inline void kifmm_kernel__red4x16(__m512 a0, __m512 a1, __m512 a2, __m512 a3, float s,
                                         float t, float *o)
{
    const __m512 s0 = _mm512_add_ps(_mm512_unpacklo_ps(a0, a1), _mm512_unpackhi_ps(a0, a1));
    const __m512 s1 = _mm512_add_ps(_mm512_unpacklo_ps(a2, a3), _mm512_unpackhi_ps(a2, a3));
    /* per 128-bit block: a0..a3 */
    const __m512 v = _mm512_add_ps(_mm512_shuffle_ps(s0, s1, 0x44), _mm512_shuffle_ps(s0, s1, 0xEE));
    const __m512 u = _mm512_add_ps(v, _mm512_shuffle_f32x4(v, v, 0x4E));
    const __m512 x = _mm512_add_ps(u, _mm512_shuffle_f32x4(u, u, 0xB1));
    _mm_storeu_ps(o, _mm_fmadd_ps(_mm_setr_ps(s, t, t, t), _mm512_castps512_ps128(x),
                                  _mm_loadu_ps(o)));
}
/* Lane l < n of c0..c3 belongs to point l: o[4 l + k] += s ck[l]. */
static inline void kifmm_kernel__tadd8(__m512d c0, __m512d c1, __m512d c2, __m512d c3, double s,
                                       double *o, int64_t n)
{
    kifmm_kernel__tadd(_mm512_castpd512_pd256(c0), _mm512_castpd512_pd256(c1),
                       _mm512_castpd512_pd256(c2), _mm512_castpd512_pd256(c3), s, o,
                       n < 4 ? n : 4);
    if (n > 4)
        kifmm_kernel__tadd(_mm512_extractf64x4_pd(c0, 1), _mm512_extractf64x4_pd(c1, 1),
                           _mm512_extractf64x4_pd(c2, 1), _mm512_extractf64x4_pd(c3, 1), s,
                           o + 16, n - 4);
}
static inline void kifmm_kernel__tadd16(__m512 c0, __m512 c1, __m512 c2, __m512 c3, float s,
                                        float *o, int64_t n)
{
    kifmm_kernel__taddf(_mm512_castps512_ps256(c0), _mm512_castps512_ps256(c1),
                        _mm512_castps512_ps256(c2), _mm512_castps512_ps256(c3), s, o,
                        n < 8 ? n : 8);
    if (n > 8) /* the high halves, through the double view of the registers */
        kifmm_kernel__taddf(
            _mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(c0), 1)),
            _mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(c1), 1)),
            _mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(c2), 1)),
            _mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(c3), 1)), s, o + 32, n - 8);
}
/* o[l] += s a[l] for the lanes l < n. */
static inline void kifmm_kernel__addn8(__m512d a, double s, double *o, int64_t n)
{
    const __mmask8 m = kifmm_kernel__first8(n);
    _mm512_mask_storeu_pd(o, m, _mm512_fmadd_pd(_mm512_set1_pd(s), a, _mm512_maskz_loadu_pd(m, o)));
}
static inline void kifmm_kernel__addn16(__m512 a, float s, float *o, int64_t n)
{
    const __mmask16 m = kifmm_kernel__first16(n);
    _mm512_mask_storeu_ps(o, m, _mm512_fmadd_ps(_mm512_set1_ps(s), a, _mm512_maskz_loadu_ps(m, o)));
}
#endif

#if defined(__AVX512F__)
/* One side's sums for one lane group: over the other side's no points j,
 * the geometry G[c cs + 2 j] times the broadcast densities qu[u][j]
 * of 4 vectors (gradient: 16 sums) or 8 (potential), then added to
 * o[u old + ...] for the nu vectors and nl lanes present. */
#define KIFMM_KERNEL__SUMS4G(name, T, V, SET1, ZERO, FMADD, TADD)                               \
    static inline void name(const V *G, int64_t cs, int64_t no, const T *const *qu, T s, T *o,  \
                            size_t old, int nu, int64_t nl)                                     \
    {                                                                                           \
        V a0 = ZERO, a1 = ZERO, a2 = ZERO, a3 = ZERO, b0 = ZERO, b1 = ZERO, b2 = ZERO, b3 = ZERO; \
        V c0 = ZERO, c1 = ZERO, c2 = ZERO, c3 = ZERO, d0 = ZERO, d1 = ZERO, d2 = ZERO, d3 = ZERO; \
        int64_t j;                                                                              \
        for (j = 0; j < no; j++, G += 2) {                                                      \
            const V g0 = G[0], g1 = G[cs], g2 = G[2 * cs], g3 = G[3 * cs];                      \
            V x = SET1(qu[0][j]);                                                               \
            a0 = FMADD(x, g0, a0); a1 = FMADD(x, g1, a1); a2 = FMADD(x, g2, a2); a3 = FMADD(x, g3, a3); \
            x = SET1(qu[1][j]);                                                                 \
            b0 = FMADD(x, g0, b0); b1 = FMADD(x, g1, b1); b2 = FMADD(x, g2, b2); b3 = FMADD(x, g3, b3); \
            x = SET1(qu[2][j]);                                                                 \
            c0 = FMADD(x, g0, c0); c1 = FMADD(x, g1, c1); c2 = FMADD(x, g2, c2); c3 = FMADD(x, g3, c3); \
            x = SET1(qu[3][j]);                                                                 \
            d0 = FMADD(x, g0, d0); d1 = FMADD(x, g1, d1); d2 = FMADD(x, g2, d2); d3 = FMADD(x, g3, d3); \
        }                                                                                       \
        TADD(a0, a1, a2, a3, s, o, nl);                                                         \
        if (nu > 1) TADD(b0, b1, b2, b3, s, o + old, nl);                                       \
        if (nu > 2) TADD(c0, c1, c2, c3, s, o + 2 * old, nl);                                   \
        if (nu > 3) TADD(d0, d1, d2, d3, s, o + 3 * old, nl);                                   \
    }
#define KIFMM_KERNEL__SUMS8P(name, T, V, SET1, ZERO, FMADD, ADDN)                                 \
    static inline void name(const V *G, int64_t cs, int64_t no, const T *const *qu, T s, T *o,  \
                            size_t old, int nu, int64_t nl)                                     \
    {                                                                                           \
        V a[8];                                                                                 \
        int64_t j;                                                                              \
        int u;                                                                                  \
        (void)cs;                                                                               \
        for (u = 0; u < 8; u++) a[u] = ZERO;                                                    \
        for (j = 0; j < no; j++, G += 2) {                                                      \
            const V g0 = G[0];                                                                  \
            a[0] = FMADD(SET1(qu[0][j]), g0, a[0]); a[1] = FMADD(SET1(qu[1][j]), g0, a[1]);     \
            a[2] = FMADD(SET1(qu[2][j]), g0, a[2]); a[3] = FMADD(SET1(qu[3][j]), g0, a[3]);     \
            a[4] = FMADD(SET1(qu[4][j]), g0, a[4]); a[5] = FMADD(SET1(qu[5][j]), g0, a[5]);     \
            a[6] = FMADD(SET1(qu[6][j]), g0, a[6]); a[7] = FMADD(SET1(qu[7][j]), g0, a[7]);     \
        }                                                                                       \
        for (u = 0; u < nu; u++) ADDN(a[u], s, o + (size_t)u * old, nl);                        \
    }
KIFMM_KERNEL__SUMS4G(kifmm_kernel__sums4g8, double, __m512d, _mm512_set1_pd,
                     _mm512_setzero_pd(), _mm512_fmadd_pd, kifmm_kernel__tadd8)
KIFMM_KERNEL__SUMS4G(kifmm_kernel__sums4g16, float, __m512, _mm512_set1_ps,
                     _mm512_setzero_ps(), _mm512_fmadd_ps, kifmm_kernel__tadd16)
KIFMM_KERNEL__SUMS8P(kifmm_kernel__sums8p8, double, __m512d, _mm512_set1_pd,
                     _mm512_setzero_pd(), _mm512_fmadd_pd, kifmm_kernel__addn8)
KIFMM_KERNEL__SUMS8P(kifmm_kernel__sums8p16, float, __m512, _mm512_set1_ps,
                     _mm512_setzero_ps(), _mm512_fmadd_ps, kifmm_kernel__addn16)
#undef KIFMM_KERNEL__SUMS4G
#undef KIFMM_KERNEL__SUMS8P
/* AVX-512: targets in groups of W lanes (two groups per block), sources in
 * blocks of 64: the geometry of the block once, with the lanes on the
 * targets (so the sums need no reduction across lanes), then every vector
 * against it with its sums in registers (kifmm_kernel__sums*) and one
 * transpose per group to store them. */
#define KIFMM_KERNEL__P2PN5_BODY(T, V, W, M, MASKN, MLOADZ, RINV, SET1, ZERO, SUB, MUL, FMADD,  \
                                 MASKZ, SUMS, GRAD)                                             \
    {                                                                                           \
        enum { TB_ = 2 * (W), SB_ = 64, NC_ = (GRAD) ? 4 : 1, RT_ = (GRAD) ? 4 : 8 };           \
        const T s = (T)(scale * KIFMM_INV_4PI);                                                 \
        V gs[NC_ * SB_ * 2]; /* [(c SB_ + source) 2 + lane group] */                            \
        const T zq[SB_] = {0}; /* the densities of missing vectors */                           \
        int64_t i0, j0, ni, nj, j;                                                              \
        int g, u, nu, r;                                                                        \
        (void)param;                                                                            \
        for (i0 = 0; i0 < nt; i0 += TB_) {                                                      \
            ni = nt - i0 < TB_ ? nt - i0 : (int64_t)TB_;                                        \
            for (j0 = 0; j0 < ns; j0 += SB_) {                                                  \
                nj = ns - j0 < SB_ ? ns - j0 : (int64_t)SB_;                                    \
                for (g = 0; g < 2 && g * (W) < ni; g++) {                                       \
                    const M m = MASKN(ni - g * (W));                                            \
                    const V X = MLOADZ(m, tx + i0 + g * (W));                                   \
                    const V Y = MLOADZ(m, ty + i0 + g * (W));                                   \
                    const V Z = MLOADZ(m, tz + i0 + g * (W));                                   \
                    for (j = 0; j < nj; j++) {                                                  \
                        /* s - t: the gradient -q (t - s) / r^3 is q (s - t) / r^3 */           \
                        const V dx = SUB(SET1(sx[j0 + j]), X), dy = SUB(SET1(sy[j0 + j]), Y);   \
                        const V dz = SUB(SET1(sz[j0 + j]), Z);                                  \
                        const V inv =                                                           \
                            MASKZ(m, RINV(FMADD(dz, dz, FMADD(dy, dy, MUL(dx, dx)))));          \
                        V *G = gs + j * 2 + g;                                                  \
                        G[0] = inv;                                                             \
                        if (GRAD) {                                                             \
                            const V w = MUL(MUL(inv, inv), inv);                                \
                            G[SB_ * 2] = MUL(w, dx);                                            \
                            G[2 * SB_ * 2] = MUL(w, dy);                                        \
                            G[3 * SB_ * 2] = MUL(w, dz);                                        \
                        }                                                                       \
                    }                                                                           \
                }                                                                               \
                for (r = 0; r < nrhs; r += RT_) {                                               \
                    const T *qu[RT_];                                                           \
                    nu = nrhs - r < RT_ ? nrhs - r : RT_;                                       \
                    for (u = 0; u < RT_; u++)                                                   \
                        qu[u] = u < nu ? q + (size_t)(r + u) * qld + j0 : zq;                   \
                    for (g = 0; g < 2 && g * (W) < ni; g++)                                     \
                        SUMS(gs + g, (int64_t)SB_ * 2, nj, qu, s,                               \
                             out + (size_t)r * old + (size_t)((GRAD) ? 4 : 1) * (i0 + g * (W)), \
                             old, nu, ni - g * (W) < (W) ? ni - g * (W) : (W));                 \
                }                                                                               \
            }                                                                                   \
        }                                                                                       \
    }
#define KIFMM_KERNEL__P2PN_D(GRAD)                                                                \
    KIFMM_KERNEL__P2PN5_BODY(double, __m512d, 8, __mmask8, kifmm_kernel__first8,                  \
                             _mm512_maskz_loadu_pd, kifmm_kernel__rinv8, _mm512_set1_pd,          \
                             _mm512_setzero_pd(), _mm512_sub_pd, _mm512_mul_pd, _mm512_fmadd_pd,  \
                             _mm512_maskz_mov_pd,                                                 \
                             ((GRAD) ? kifmm_kernel__sums4g8 : kifmm_kernel__sums8p8), GRAD)
#define KIFMM_KERNEL__P2PN_F(GRAD)                                                                \
    KIFMM_KERNEL__P2PN5_BODY(float, __m512, 16, __mmask16, kifmm_kernel__first16,                 \
                             _mm512_maskz_loadu_ps, kifmm_kernel__rinv16, _mm512_set1_ps,         \
                             _mm512_setzero_ps(), _mm512_sub_ps, _mm512_mul_ps, _mm512_fmadd_ps,  \
                             _mm512_maskz_mov_ps,                                                 \
                             ((GRAD) ? kifmm_kernel__sums4g16 : kifmm_kernel__sums8p16), GRAD)
#else
#define KIFMM_KERNEL__MLOADN(p, m) _mm256_maskload_pd((p), _mm256_castpd_si256(m))
#define KIFMM_KERNEL__MLOADNF(p, m) _mm256_maskload_ps((p), _mm256_castps_si256(m))
#define KIFMM_KERNEL__P2PN_D(GRAD)                                                                \
    KIFMM_KERNEL__P2PN_BODY(double, __m256d, 4, kifmm_kernel__geomn, kifmm_kernel__nmask,        \
                            _mm256_set1_pd, _mm256_setzero_pd(), _mm256_loadu_pd,                \
                            _mm256_storeu_pd, KIFMM_KERNEL__MLOADN, _mm256_mul_pd,               \
                            _mm256_fmadd_pd, _mm256_fnmadd_pd, kifmm_kernel__hsumn, GRAD)
#define KIFMM_KERNEL__P2PN_F(GRAD)                                                                \
    KIFMM_KERNEL__P2PN_BODY(float, __m256, 8, kifmm_kernel__geomnf, kifmm_kernel__nmaskf,        \
                            _mm256_set1_ps, _mm256_setzero_ps(), _mm256_loadu_ps,                \
                            _mm256_storeu_ps, KIFMM_KERNEL__MLOADNF, _mm256_mul_ps,              \
                            _mm256_fmadd_ps, _mm256_fnmadd_ps, kifmm_kernel__hsumnf, GRAD)
#endif

static inline void kifmm_kernel_laplace_p2pn(const double *param, const double *tx,
                                             const double *ty, const double *tz, int64_t nt,
                                             const double *sx, const double *sy,
                                             const double *sz, const double *q, int64_t ns,
                                             int nrhs, size_t qld, double scale, double *out,
                                             size_t old)
#if defined(__AVX512F__)
/* Double potential on AVX-512: per target, its sums in the order of the
 * AVX-512 _p2p (8 lanes over the sources, reduced at the end), so that each
 * vector's sums are bitwise those of _p2p. This hook is the P2M of evaluate_many,
 * whose results the float FFT M2L spectra (orders <= 6) would otherwise turn
 * from last-bit differences into differences of float rounding (1e-7) between
 * evaluate_many and evaluate; it is 2.0-3.7 times _p2p against 5.1-5.5 with
 * the lanes on the targets. */
KIFMM_KERNEL__P2PN_BODY(double, __m512d, 8, kifmm_kernel__geom8, kifmm_kernel__nmask8,
                        _mm512_set1_pd, _mm512_setzero_pd(), _mm512_loadu_pd, _mm512_storeu_pd,
                        kifmm_kernel__mload8, _mm512_mul_pd, _mm512_fmadd_pd, _mm512_fnmadd_pd,
                        kifmm_kernel__hsum8, 0)
#else
KIFMM_KERNEL__P2PN_D(0)
#endif

static inline void kifmm_kernel_laplace_grad_p2pn(const double *param, const double *tx,
                                                  const double *ty, const double *tz,
                                                  int64_t nt, const double *sx,
                                                  const double *sy, const double *sz,
                                                  const double *q, int64_t ns, int nrhs,
                                                  size_t qld, double scale, double *out,
                                                  size_t old)
KIFMM_KERNEL__P2PN_D(1)

static inline void kifmm_kernel_laplace_p2pnf(const double *param, const float *tx,
                                              const float *ty, const float *tz, int64_t nt,
                                              const float *sx, const float *sy, const float *sz,
                                              const float *q, int64_t ns, int nrhs, size_t qld,
                                              float scale, float *out, size_t old)
#if defined(__AVX512F__)
/* Float potential on AVX-512: bitwise the sums of _p2pf, as the double one. */
KIFMM_KERNEL__P2PN_BODY(float, __m512, 16, kifmm_kernel__geom16, kifmm_kernel__nmask16,
                        _mm512_set1_ps, _mm512_setzero_ps(), _mm512_loadu_ps, _mm512_storeu_ps,
                        kifmm_kernel__mload16, _mm512_mul_ps, _mm512_fmadd_ps, _mm512_fnmadd_ps,
                        kifmm_kernel__hsum16, 0)
#else
KIFMM_KERNEL__P2PN_F(0)
#endif

static inline void kifmm_kernel_laplace_grad_p2pnf(const double *param, const float *tx,
                                                   const float *ty, const float *tz, int64_t nt,
                                                   const float *sx, const float *sy,
                                                   const float *sz, const float *q, int64_t ns,
                                                   int nrhs, size_t qld, float scale,
                                                   float *out, size_t old)
KIFMM_KERNEL__P2PN_F(1)

/* ------------------------------------------------------------------------ */
/* Mutual near-field hooks (kifmm_kernel_NAME_P2PS / _p2ps, _P2PSF / _p2psf) */
/* ------------------------------------------------------------------------ */
/* kifmm_kernel_NAME_p2ps(param, ax, ay, az, qa, na, bx, by, bz, qb, nb, scale,
 * outa, outb): both directions between two disjoint point sets A and B, for
 * a kernel with K(-d) = K(d) in the potential (and -K(d) in the gradient):
 *   outa[i * TRG_DIM + k] += scale * sum_j K_k(a_i - b_j) qb_j,
 *   outb[j * TRG_DIM + k] += scale * sum_i K_k(b_j - a_i) qa_i,
 * with each pair's 1 / r computed once.  When the sources are the targets,
 * kifmm.h calls it once per pair of neighbouring leaves instead of _p2p
 * twice.  B goes in blocks of KIFMM_KERNEL__SB points whose sums sit in a
 * structure-of-arrays block on the stack; two points of A at a time share
 * each load and store of those sums, with their own sums in registers (AMD
 * Zen 3, laplace_grad: 2.72 -> 2.30 ns per pair in 30 x 30 blocks; near
 * field at 1M points, p = 6, 0.57-0.59 -> 0.46-0.47 s). Their gradient sums
 * are reduced together (RED2: 2.10 -> 2.00 ns per pair in double, 0.90 ->
 * 0.83 in float, best of five). */
#define KIFMM_KERNEL__SB 64
/* One step of the mutual loops below, for targets i, i1 of A against W points
 * of B (densities q, element type T): given both targets' 1 / r (inv0, inv1)
 * and differences (dx0 .. dz1), adds q / r (and the gradient's -q d / r^3) to
 * their sums a0..a3, c0..c3, and qa / r (qa d / r^3) to B's sums pb[k SB +
 * j], k = 0..3. With the gradient, q / r is formed once, added, and
 * multiplied by 1 / r^2: on AMD Zen 4 that keeps the additions off the FMA
 * pipes; without it, one FMA per sum has fewer operations (potential, one
 * core: 1.8-2.1e9 pairs/s against 1.7-2.0e9 on AVX-512). */
#define KIFMM_KERNEL__MUTUAL_STEP(T, V, LOAD, STORE, ADD, MUL, FMADD, FNMADD, SB, GRAD)         \
    if (!(GRAD)) {                                                                             \
        a0 = FMADD(q, inv0, a0);                                                               \
        c0 = FMADD(q, inv1, c0);                                                               \
        STORE(pb + j, FMADD(QA0, inv0, FMADD(QA1, inv1, LOAD(pb + j))));                       \
    } else {                                                                                   \
        const V qb0 = MUL(q, inv0), qb1 = MUL(q, inv1);                                        \
        const V qa0 = MUL(QA0, inv0), qa1 = MUL(QA1, inv1);                                    \
        const V e0 = MUL(inv0, inv0), e1 = MUL(inv1, inv1);                                    \
        const V qb30 = MUL(qb0, e0), qb31 = MUL(qb1, e1);                                      \
        const V qa30 = MUL(qa0, e0), qa31 = MUL(qa1, e1);                                      \
        T *o = pb + (SB) + j;                                                                  \
        a0 = ADD(a0, qb0);                                                                     \
        c0 = ADD(c0, qb1);                                                                     \
        STORE(pb + j, ADD(LOAD(pb + j), ADD(qa0, qa1)));                                       \
        KIFMM_KERNEL__SUB_A2(qb30, qb31, FNMADD);                                              \
        KIFMM_KERNEL__ADD_B3(o, qa30, qa31, SB, LOAD, STORE, FMADD);                           \
    }
#define KIFMM_KERNEL__P2PS_BODY(T, V, W, GEOMV, MASK, SET1, ZERO, LOADU, STOREU, ADD, MUL, \
                                FMADD, FNMADD, HSUM, RED2, GRAD)                               \
    {                                                                                          \
        const T s = (T)scale * (T)KIFMM_INV_4PI;                                               \
        T pb[(GRAD ? 4 : 1) * KIFMM_KERNEL__SB], qp[KIFMM_KERNEL__SB];                          \
        T px[KIFMM_KERNEL__SB], py[KIFMM_KERNEL__SB], pz[KIFMM_KERNEL__SB];                    \
        const V all = MASK(W);                                                                 \
        int64_t i, j, j0, jb, jw, k;                                                           \
        (void)param;                                                                           \
        for (j0 = 0; j0 < nb; j0 += KIFMM_KERNEL__SB) {                                        \
            jb = nb - j0 < KIFMM_KERNEL__SB ? nb - j0 : KIFMM_KERNEL__SB;                      \
            jw = (jb + (W) - 1) / (W) * (W); /* lanes touched */                               \
            for (k = 0; k < (GRAD ? 4 : 1) * KIFMM_KERNEL__SB; k++) pb[k] = 0;                 \
            /* B's block, padded with points at 0 of density 0: the padding lanes   \
             * add nothing to A, and to B only in pb's padding */                   \
            for (k = 0; k < jw; k++) {                                                         \
                qp[k] = k < jb ? qb[j0 + k] : 0;                                               \
                px[k] = k < jb ? bx[j0 + k] : 0;                                               \
                py[k] = k < jb ? by[j0 + k] : 0;                                               \
                pz[k] = k < jb ? bz[j0 + k] : 0;                                               \
            }                                                                                  \
            for (i = 0; i < na; i += 2) {                                                      \
                /* targets i and i + 1 (a copy of i with no density if i is the last) */      \
                const int64_t i1 = i + 1 < na ? i + 1 : i;                                     \
                const V X0 = SET1(ax[i]), Y0 = SET1(ay[i]), Z0 = SET1(az[i]), QA0 = SET1(qa[i]); \
                const V X1 = SET1(ax[i1]), Y1 = SET1(ay[i1]), Z1 = SET1(az[i1]);               \
                const V QA1 = SET1(i1 > i ? qa[i1] : (T)0);                                    \
                V a0 = ZERO, a1 = ZERO, a2 = ZERO, a3 = ZERO;                                  \
                V c0 = ZERO, c1 = ZERO, c2 = ZERO, c3 = ZERO;                                  \
                for (j = 0; j < jw; j += W) {                                                  \
                    const V sx = LOADU(px + j), sy = LOADU(py + j), sz = LOADU(pz + j);        \
                    const V q = LOADU(qp + j);                                                 \
                    V dx0, dy0, dz0, dx1, dy1, dz1;                                            \
                    const V inv0 = GEOMV(X0, Y0, Z0, sx, sy, sz, all, &dx0, &dy0, &dz0);         \
                    const V inv1 = GEOMV(X1, Y1, Z1, sx, sy, sz, all, &dx1, &dy1, &dz1);         \
                    KIFMM_KERNEL__MUTUAL_STEP(T, V, LOADU, STOREU, ADD, MUL, FMADD, FNMADD,      \
                                              KIFMM_KERNEL__SB, GRAD)                          \
                }                                                                              \
                KIFMM_KERNEL__ADD_A2(RED2, HSUM, GRAD)                                         \
            }                                                                                  \
            for (j = 0; j < jb; j++) {                                                         \
                if (GRAD)                                                                      \
                    for (k = 0; k < 4; k++)                                                    \
                        outb[4 * (j0 + j) + k] += s * pb[k * KIFMM_KERNEL__SB + j];            \
                else                                                                           \
                    outb[j0 + j] += s * pb[j];                                                 \
            }                                                                                  \
        }                                                                                      \
    }

#define KIFMM_KERNEL__P2PS_D(GRAD)                                                                \
    KIFMM_KERNEL__P2PS_BODY(double, __m256d, 4, kifmm_kernel__geomv, kifmm_kernel__nmask,        \
                            _mm256_set1_pd, _mm256_setzero_pd(), _mm256_loadu_pd,                \
                            _mm256_storeu_pd, _mm256_add_pd, _mm256_mul_pd, _mm256_fmadd_pd,       \
                            _mm256_fnmadd_pd, kifmm_kernel__hsumn, kifmm_kernel__red2, GRAD)
#define KIFMM_KERNEL__P2PS_F(GRAD)                                                                \
    KIFMM_KERNEL__P2PS_BODY(float, __m256, 8, kifmm_kernel__geomvf, kifmm_kernel__nmaskf,        \
                            _mm256_set1_ps, _mm256_setzero_ps(), _mm256_loadu_ps,                \
                            _mm256_storeu_ps, _mm256_add_ps, _mm256_mul_ps, _mm256_fmadd_ps,       \
                            _mm256_fnmadd_ps, kifmm_kernel__hsumnf, kifmm_kernel__red2f, GRAD)

#define KIFMM_KERNEL__P2PS_SIG(name, T)                                                        \
    static inline void name(const double *param, const T *ax, const T *ay, const T *az,        \
                            const T *qa, int64_t na, const T *bx, const T *by, const T *bz,    \
                            const T *qb, int64_t nb, T scale, T *outa, T *outb)

/* AVX-512 mutual hooks: the same contract and block structure as above, with
 * 8 (double) or 16 (float) lanes and 1 / r from kifmm_kernel__rinv8 / 16
 * (no division). Each target's sums take one FMA per component (the
 * potential's q / r, the gradient's q d / r^3 from the one r^-3), and the two
 * targets' eight sums are reduced across the lanes together. */
#if defined(__AVX512F__)
/* B's sums back: o[4 l + k] += s pb[k sb + l] (grad: potential and gradient,
 * sb apart, four points at a time through a 4 x 4 transpose) or o[l] += s
 * pb[l], l < n; pb 64-byte aligned. */
static inline void kifmm_kernel__addb8(const double *pb, int sb, double s, double *o, int64_t n,
                                       int grad)
{
    int64_t j;
    if (grad) {
        for (j = 0; j < n; j += 4)
            kifmm_kernel__tadd(_mm256_load_pd(pb + j), _mm256_load_pd(pb + sb + j),
                               _mm256_load_pd(pb + 2 * sb + j), _mm256_load_pd(pb + 3 * sb + j),
                               s, o + 4 * j, n - j < 4 ? n - j : 4);
        return;
    }
    for (j = 0; j < n; j += 8) {
        const __mmask8 m = kifmm_kernel__first8(n - j);
        _mm512_mask_storeu_pd(o + j, m, _mm512_fmadd_pd(_mm512_set1_pd(s), _mm512_load_pd(pb + j),
                                                         _mm512_maskz_loadu_pd(m, o + j)));
    }
}
static inline void kifmm_kernel__addb16(const float *pb, int sb, float s, float *o, int64_t n,
                                        int grad)
{
    int64_t j;
    if (grad) {
        for (j = 0; j < n; j += 8)
            kifmm_kernel__taddf(_mm256_load_ps(pb + j), _mm256_load_ps(pb + sb + j),
                                _mm256_load_ps(pb + 2 * sb + j), _mm256_load_ps(pb + 3 * sb + j),
                                s, o + 4 * j, n - j < 8 ? n - j : 8);
        return;
    }
    for (j = 0; j < n; j += 16) {
        const __mmask16 m = kifmm_kernel__first16(n - j);
        _mm512_mask_storeu_ps(o + j, m, _mm512_fmadd_ps(_mm512_set1_ps(s), _mm512_load_ps(pb + j),
                                                         _mm512_maskz_loadu_ps(m, o + j)));
    }
}

#define KIFMM_KERNEL__SB5 64
#define KIFMM_KERNEL__P2PS5_BODY(T, V, W, M, MASKN, MLOADZ, RINV, SET1, ZERO, LOAD, STORE, SUB,  \
                                 ADD, MUL, FMADD, FNMADD, HSUM, RED8, ADDB, GRAD)                    \
    {                                                                                          \
        enum { SB_ = KIFMM_KERNEL__SB5, NB_ = KIFMM_KERNEL__SB5 / (W) };                       \
        const T s = (T)scale * (T)KIFMM_INV_4PI;                                               \
        /* B's block and its sums, in vectors for their alignment */                          \
        V vb[((GRAD) ? 4 : 1) * NB_], vx[NB_], vy[NB_], vz[NB_], vq[NB_];                      \
        T *pb = (T *)vb, *px = (T *)vx, *py = (T *)vy, *pz = (T *)vz, *qp = (T *)vq;           \
        int64_t i, j, j0, jb, jw, k;                                                           \
        (void)param;                                                                           \
        for (j0 = 0; j0 < nb; j0 += SB_) {                                                     \
            jb = nb - j0 < SB_ ? nb - j0 : (int64_t)SB_;                                       \
            jw = (jb + (W) - 1) / (W) * (W); /* lanes touched */                               \
            /* padded with points at 0 of density 0: they add nothing to A, and to   \
             * B only in the padding of pb */                                       \
            for (k = 0; k < jw / (W); k++) {                                                   \
                const M m = MASKN(jb - k * (W));                                               \
                vq[k] = MLOADZ(m, qb + j0 + k * (W));                                          \
                vx[k] = MLOADZ(m, bx + j0 + k * (W));                                          \
                vy[k] = MLOADZ(m, by + j0 + k * (W));                                          \
                vz[k] = MLOADZ(m, bz + j0 + k * (W));                                          \
                vb[k] = ZERO;                                                                  \
                if (GRAD) vb[NB_ + k] = vb[2 * NB_ + k] = vb[3 * NB_ + k] = ZERO;              \
            }                                                                                  \
            for (i = 0; i < na; i += 2) {                                                      \
                /* targets i and i + 1 (a copy of i with no density if i is the last) */      \
                const int64_t i1 = i + 1 < na ? i + 1 : i;                                     \
                const V X0 = SET1(ax[i]), Y0 = SET1(ay[i]), Z0 = SET1(az[i]);                  \
                const V X1 = SET1(ax[i1]), Y1 = SET1(ay[i1]), Z1 = SET1(az[i1]);               \
                const V QA0 = SET1(qa[i]), QA1 = SET1(i1 > i ? qa[i1] : (T)0);                 \
                V a0 = ZERO, a1 = ZERO, a2 = ZERO, a3 = ZERO;                                  \
                V c0 = ZERO, c1 = ZERO, c2 = ZERO, c3 = ZERO;                                  \
                for (j = 0; j < jw; j += (W)) {                                                \
                    const V sx = LOAD(px + j), sy = LOAD(py + j), sz = LOAD(pz + j);           \
                    const V q = LOAD(qp + j);                                                  \
                    const V dx0 = SUB(X0, sx), dy0 = SUB(Y0, sy), dz0 = SUB(Z0, sz);        \
                    const V dx1 = SUB(X1, sx), dy1 = SUB(Y1, sy), dz1 = SUB(Z1, sz);        \
                    const V inv0 = RINV(FMADD(dz0, dz0, FMADD(dy0, dy0, MUL(dx0, dx0))));      \
                    const V inv1 = RINV(FMADD(dz1, dz1, FMADD(dy1, dy1, MUL(dx1, dx1))));      \
                    KIFMM_KERNEL__MUTUAL_STEP(T, V, LOAD, STORE, ADD, MUL, FMADD, FNMADD, SB_,   \
                                              GRAD)                                            \
                }                                                                              \
                KIFMM_KERNEL__ADD_A2(RED8, HSUM, GRAD)                                         \
            }                                                                                  \
            ADDB(pb, SB_, s, outb + ((GRAD) ? 4 : 1) * j0, jb, GRAD);                         \
        }                                                                                      \
    }

#define KIFMM_KERNEL__P2PS5_D(GRAD)                                                               \
    KIFMM_KERNEL__P2PS5_BODY(double, __m512d, 8, __mmask8, kifmm_kernel__first8,                \
                             _mm512_maskz_loadu_pd, kifmm_kernel__rinv8, _mm512_set1_pd,         \
                             _mm512_setzero_pd(), _mm512_load_pd, _mm512_store_pd, _mm512_sub_pd, \
                             _mm512_add_pd, _mm512_mul_pd, _mm512_fmadd_pd, _mm512_fnmadd_pd,                   \
                             kifmm_kernel__hsum8, kifmm_kernel__red8x8, kifmm_kernel__addb8, GRAD)
#define KIFMM_KERNEL__P2PS5_F(GRAD)                                                               \
    KIFMM_KERNEL__P2PS5_BODY(float, __m512, 16, __mmask16, kifmm_kernel__first16,               \
                             _mm512_maskz_loadu_ps, kifmm_kernel__rinv16, _mm512_set1_ps,        \
                             _mm512_setzero_ps(), _mm512_load_ps, _mm512_store_ps, _mm512_sub_ps, \
                             _mm512_add_ps, _mm512_mul_ps, _mm512_fmadd_ps, _mm512_fnmadd_ps,                   \
                             kifmm_kernel__hsum16, kifmm_kernel__red8x16, kifmm_kernel__addb16,  \
                             GRAD)
KIFMM_KERNEL__P2PS_SIG(kifmm_kernel_laplace_p2ps, double)
KIFMM_KERNEL__P2PS5_D(0)
KIFMM_KERNEL__P2PS_SIG(kifmm_kernel_laplace_grad_p2ps, double)
KIFMM_KERNEL__P2PS5_D(1)
KIFMM_KERNEL__P2PS_SIG(kifmm_kernel_laplace_p2psf, float)
KIFMM_KERNEL__P2PS5_F(0)
KIFMM_KERNEL__P2PS_SIG(kifmm_kernel_laplace_grad_p2psf, float)
KIFMM_KERNEL__P2PS5_F(1)
#undef KIFMM_KERNEL__P2PS5_D
#undef KIFMM_KERNEL__P2PS5_F
#undef KIFMM_KERNEL__P2PS5_BODY
#undef KIFMM_KERNEL__SB5
#else
KIFMM_KERNEL__P2PS_SIG(kifmm_kernel_laplace_p2ps, double)
KIFMM_KERNEL__P2PS_D(0)
KIFMM_KERNEL__P2PS_SIG(kifmm_kernel_laplace_grad_p2ps, double)
KIFMM_KERNEL__P2PS_D(1)
KIFMM_KERNEL__P2PS_SIG(kifmm_kernel_laplace_p2psf, float)
KIFMM_KERNEL__P2PS_F(0)
KIFMM_KERNEL__P2PS_SIG(kifmm_kernel_laplace_grad_p2psf, float)
KIFMM_KERNEL__P2PS_F(1)
#endif

/* ------------------------------------------------------------------------ */
/* Mutual many-vector hooks (_P2PSN / _p2psn, _P2PSNF / _p2psnf)            */
/* ------------------------------------------------------------------------ */
/* kifmm_kernel_NAME_p2psn(param, ax, ay, az, qa, na, bx, by, bz, qb, nb, nrhs,
 * qld, scale, outa, outb, old): _p2ps for nrhs density vectors at once,
 * vector r's densities at qa + r qld and qb + r qld, its outputs at
 * outa + r old and outb + r old; each pair's geometry computed once for all
 * of them. Used by evaluate_many when the sources are the targets.
 * Per block of IB x SB pairs: the geometry G (1 / r, and for GRAD d / r^3)
 * into a block on the stack; then, per tile of vectors (two for GRAD, four
 * otherwise), A's sums as rows of G times B's densities (in registers over
 * a row, reduced across the lanes once per row) and B's sums as columns of
 * G times A's densities (lanes are B's points, no reduction). No sums go
 * through memory inside the loops (AMD Zen 3, laplace_grad, 8 vectors, against
 * B's sums loaded and stored per pair: 8.8-11.0 -> 5.7-5.9 ns per pair in
 * 30 x 30 blocks; near field at 1M points, p = 4, 2.33 -> 1.81 s). */
#define KIFMM_KERNEL__IB 16
#define KIFMM_KERNEL__P2PSN_BODY(T, V, W, GEOM, MASK, SET1, ZERO, LOADU, STOREU, MUL, FMADD,       \
                                 RED4, TADD, ADDN, GRAD)                                           \
    {                                                                                              \
        enum { SB_ = 32, IB_ = KIFMM_KERNEL__IB, NC_ = (GRAD) ? 4 : 1, RT_ = (GRAD) ? 2 : 4 };     \
        const T s = (T)scale * (T)KIFMM_INV_4PI;                                                   \
        T G[NC_ * IB_ * SB_], qp[RT_ * SB_], t4[4];                                                \
        int64_t i, i0, ib, j, j0, jb, jw, k;                                                       \
        int r, u, nu;                                                                              \
        (void)param;                                                                               \
        for (j0 = 0; j0 < nb; j0 += SB_) {                                                         \
            jb = nb - j0 < SB_ ? nb - j0 : (int64_t)SB_;                                           \
            jw = (jb + (W) - 1) / (W) * (W); /* lanes touched */                                   \
            for (i0 = 0; i0 < na; i0 += IB_) {                                                     \
                ib = na - i0 < IB_ ? na - i0 : (int64_t)IB_;                                       \
                for (i = 0; i < ib; i++) {                                                         \
                    const V X = SET1(ax[i0 + i]), Y = SET1(ay[i0 + i]), Z = SET1(az[i0 + i]);      \
                    T *g = G + i * SB_;                                                            \
                    for (j = 0; j < jw; j += W) {                                                  \
                        V dx, dy, dz;                                                              \
                        const V inv = GEOM(X, Y, Z, bx + j0 + j, by + j0 + j, bz + j0 + j,         \
                                           MASK(jb - j), &dx, &dy, &dz);                           \
                        STOREU(g + j, inv);                                                        \
                        if (GRAD) {                                                                \
                            const V i3 = MUL(MUL(inv, inv), inv);                                  \
                            STOREU(g + IB_ * SB_ + j, MUL(i3, dx));                                \
                            STOREU(g + 2 * IB_ * SB_ + j, MUL(i3, dy));                            \
                            STOREU(g + 3 * IB_ * SB_ + j, MUL(i3, dz));                            \
                        }                                                                          \
                    }                                                                              \
                }                                                                                  \
                for (r = 0; r < nrhs; r += RT_) {                                                  \
                    const T *qk[RT_];                                                              \
                    nu = nrhs - r < RT_ ? nrhs - r : RT_;                                          \
                    for (u = 0; u < RT_; u++) {                                                    \
                        /* B's densities, 0 past the block and for missing vectors */              \
                        const T *q = qb + (size_t)(r + (u < nu ? u : 0)) * qld + j0;               \
                        for (k = 0; k < jw; k++) qp[u * SB_ + k] = u < nu && k < jb ? q[k] : 0;    \
                        qk[u] = qa + (size_t)(r + (u < nu ? u : 0)) * qld + i0;                    \
                    }                                                                              \
                    for (i = 0; i < ib; i++) {                                                     \
                        const T *g = G + i * SB_;                                                  \
                        V a0 = ZERO, a1 = ZERO, a2 = ZERO, a3 = ZERO;                              \
                        V b0 = ZERO, b1 = ZERO, b2 = ZERO, b3 = ZERO;                              \
                        if (GRAD) {                                                                \
                            for (j = 0; j < jw; j += W) {                                          \
                                const V g0 = LOADU(g + j), g1 = LOADU(g + IB_ * SB_ + j);          \
                                const V g2 = LOADU(g + 2 * IB_ * SB_ + j);                         \
                                const V g3 = LOADU(g + 3 * IB_ * SB_ + j);                         \
                                const V x = LOADU(qp + j), y = LOADU(qp + SB_ + j);                \
                                a0 = FMADD(x, g0, a0); a1 = FMADD(x, g1, a1);                      \
                                a2 = FMADD(x, g2, a2); a3 = FMADD(x, g3, a3);                      \
                                b0 = FMADD(y, g0, b0); b1 = FMADD(y, g1, b1);                      \
                                b2 = FMADD(y, g2, b2); b3 = FMADD(y, g3, b3);                      \
                            }                                                                      \
                            RED4(a0, a1, a2, a3, s, -s, outa + (size_t)r * old + 4 * (i0 + i));    \
                            if (nu > 1)                                                            \
                                RED4(b0, b1, b2, b3, s, -s,                                        \
                                     outa + (size_t)(r + 1) * old + 4 * (i0 + i));                 \
                        } else {                                                                   \
                            for (j = 0; j < jw; j += W) {                                          \
                                const V g0 = LOADU(g + j);                                         \
                                a0 = FMADD(LOADU(qp + j), g0, a0);                                 \
                                a1 = FMADD(LOADU(qp + SB_ + j), g0, a1);                           \
                                a2 = FMADD(LOADU(qp + 2 * SB_ + j), g0, a2);                       \
                                a3 = FMADD(LOADU(qp + 3 * SB_ + j), g0, a3);                       \
                            }                                                                      \
                            t4[0] = t4[1] = t4[2] = t4[3] = 0;                                     \
                            RED4(a0, a1, a2, a3, s, s, t4);                                        \
                            for (u = 0; u < nu; u++)                                               \
                                outa[(size_t)(r + u) * old + i0 + i] += t4[u];                     \
                        }                                                                          \
                    }                                                                              \
                    for (j = 0; j < jw; j += W) {                                                  \
                        const int64_t nj = jb - j < (W) ? jb - j : (W);                            \
                        const T *g = G + j;                                                        \
                        V a0 = ZERO, a1 = ZERO, a2 = ZERO, a3 = ZERO;                              \
                        V b0 = ZERO, b1 = ZERO, b2 = ZERO, b3 = ZERO;                              \
                        if (GRAD) {                                                                \
                            for (i = 0; i < ib; i++, g += SB_) {                                   \
                                const V g0 = LOADU(g), g1 = LOADU(g + IB_ * SB_);                  \
                                const V g2 = LOADU(g + 2 * IB_ * SB_);                             \
                                const V g3 = LOADU(g + 3 * IB_ * SB_);                             \
                                const V x = SET1(qk[0][i]), y = SET1(qk[1][i]);                    \
                                a0 = FMADD(x, g0, a0); a1 = FMADD(x, g1, a1);                      \
                                a2 = FMADD(x, g2, a2); a3 = FMADD(x, g3, a3);                      \
                                b0 = FMADD(y, g0, b0); b1 = FMADD(y, g1, b1);                      \
                                b2 = FMADD(y, g2, b2); b3 = FMADD(y, g3, b3);                      \
                            }                                                                      \
                            TADD(a0, a1, a2, a3, s, outb + (size_t)r * old + 4 * (j0 + j), nj);    \
                            if (nu > 1)                                                            \
                                TADD(b0, b1, b2, b3, s,                                            \
                                     outb + (size_t)(r + 1) * old + 4 * (j0 + j), nj);             \
                        } else {                                                                   \
                            for (i = 0; i < ib; i++, g += SB_) {                                   \
                                const V g0 = LOADU(g);                                             \
                                a0 = FMADD(SET1(qk[0][i]), g0, a0);                                \
                                a1 = FMADD(SET1(qk[RT_ > 1 ? 1 : 0][i]), g0, a1);                  \
                                a2 = FMADD(SET1(qk[RT_ > 2 ? 2 : 0][i]), g0, a2);                  \
                                a3 = FMADD(SET1(qk[RT_ > 3 ? 3 : 0][i]), g0, a3);                  \
                            }                                                                      \
                            ADDN(a0, s, outb + (size_t)r * old + j0 + j, nj);                      \
                            if (nu > 1) ADDN(a1, s, outb + (size_t)(r + 1) * old + j0 + j, nj);    \
                            if (nu > 2) ADDN(a2, s, outb + (size_t)(r + 2) * old + j0 + j, nj);    \
                            if (nu > 3) ADDN(a3, s, outb + (size_t)(r + 3) * old + j0 + j, nj);    \
                        }                                                                          \
                        (void)b0; (void)b1; (void)b2; (void)b3;                                    \
                    }                                                                              \
                }                                                                                  \
            }                                                                                      \
        }                                                                                          \
    }

#if !defined(__AVX512F__)
#define KIFMM_KERNEL__P2PSN_D(GRAD)                                                               \
    KIFMM_KERNEL__P2PSN_BODY(double, __m256d, 4, kifmm_kernel__geomn, kifmm_kernel__nmask,       \
                             _mm256_set1_pd, _mm256_setzero_pd(), _mm256_loadu_pd,               \
                             _mm256_storeu_pd, _mm256_mul_pd, _mm256_fmadd_pd,                   \
                             kifmm_kernel__red4, kifmm_kernel__tadd, kifmm_kernel__addn, GRAD)
#define KIFMM_KERNEL__P2PSN_F(GRAD)                                                               \
    KIFMM_KERNEL__P2PSN_BODY(float, __m256, 8, kifmm_kernel__geomnf, kifmm_kernel__nmaskf,       \
                             _mm256_set1_ps, _mm256_setzero_ps(), _mm256_loadu_ps,               \
                             _mm256_storeu_ps, _mm256_mul_ps, _mm256_fmadd_ps,                   \
                             kifmm_kernel__red4f, kifmm_kernel__taddf, kifmm_kernel__addnf, GRAD)
#endif

#define KIFMM_KERNEL__P2PSN_SIG(name, T)                                                       \
    static inline void name(const double *param, const T *ax, const T *ay, const T *az,        \
                            const T *qa, int64_t na, const T *bx, const T *by, const T *bz,    \
                            const T *qb, int64_t nb, int nrhs, size_t qld, T scale, T *outa,   \
                            T *outb, size_t old)

#if defined(__AVX512F__)
/* AVX-512: the two directions as two calls of the many-vector one-way hook,
 * whose sums need no reduction across lanes. Its geometry computed once for
 * both sides would need its transpose for the second side's sums; computed
 * per side, blocks of 2W x 2W pairs with both sides' sums in their own lanes
 * measured 3.5-3.7 ns per pair for 8 vectors with the gradient (one core,
 * blocks of 30 to 244 points), against 2.8-3.0 ns for the two calls. */
#define KIFMM_KERNEL__P2PSN_TWO(name, T, oneway)                                                \
    KIFMM_KERNEL__P2PSN_SIG(name, T)                                                           \
    {                                                                                          \
        oneway(param, ax, ay, az, na, bx, by, bz, qb, nb, nrhs, qld, scale, outa, old);        \
        oneway(param, bx, by, bz, nb, ax, ay, az, qa, na, nrhs, qld, scale, outb, old);        \
    }
KIFMM_KERNEL__P2PSN_TWO(kifmm_kernel_laplace_p2psn, double, kifmm_kernel_laplace_p2pn)
KIFMM_KERNEL__P2PSN_TWO(kifmm_kernel_laplace_grad_p2psn, double, kifmm_kernel_laplace_grad_p2pn)
KIFMM_KERNEL__P2PSN_TWO(kifmm_kernel_laplace_p2psnf, float, kifmm_kernel_laplace_p2pnf)
KIFMM_KERNEL__P2PSN_TWO(kifmm_kernel_laplace_grad_p2psnf, float, kifmm_kernel_laplace_grad_p2pnf)
#undef KIFMM_KERNEL__P2PSN_TWO
#else
KIFMM_KERNEL__P2PSN_SIG(kifmm_kernel_laplace_p2psn, double)
KIFMM_KERNEL__P2PSN_D(0)
KIFMM_KERNEL__P2PSN_SIG(kifmm_kernel_laplace_grad_p2psn, double)
KIFMM_KERNEL__P2PSN_D(1)
KIFMM_KERNEL__P2PSN_SIG(kifmm_kernel_laplace_p2psnf, float)
KIFMM_KERNEL__P2PSN_F(0)
KIFMM_KERNEL__P2PSN_SIG(kifmm_kernel_laplace_grad_p2psnf, float)
KIFMM_KERNEL__P2PSN_F(1)
#endif

#undef KIFMM_KERNEL__P2PSN_SIG
#undef KIFMM_KERNEL__P2PSN_D
#undef KIFMM_KERNEL__P2PSN_F
#undef KIFMM_KERNEL__P2PSN_BODY
#undef KIFMM_KERNEL__IB
#undef KIFMM_KERNEL__P2PS_SIG
#undef KIFMM_KERNEL__P2PS_D
#undef KIFMM_KERNEL__P2PS_F
#undef KIFMM_KERNEL__P2PS_BODY
#undef KIFMM_KERNEL__MUTUAL_STEP
#undef KIFMM_KERNEL__SB
#undef KIFMM_KERNEL__P2PN_D
#undef KIFMM_KERNEL__P2PN_F
#undef KIFMM_KERNEL__MLOADN
#undef KIFMM_KERNEL__MLOADNF
#undef KIFMM_KERNEL__P2PN_BODY
#ifdef KIFMM_KERNEL__P2PN5_BODY
#undef KIFMM_KERNEL__P2PN5_BODY
#endif
#undef KIFMM_KERNEL__CH
#endif

/* ------------------------------------------------------------------------ */
/* The vectorised exp of the Yukawa hooks (AVX-512 or AVX2 + FMA)          */
/* ------------------------------------------------------------------------ */
/* exp(-lambda r) / (4 pi r) and its gradient, with exp computed in the
 * vector registers: x = n ln2 + r, |r| <= ln2 / 2, n = x / ln2 rounded to
 * the nearest integer (by adding 1.5 2^52 in one fused multiply-add), r from
 * ln2 in two parts (the first with 32 significant bits, so n ln2_hi is
 * exact for any n here), exp(r) by a polynomial of degree 11 (below),
 * and 2^n as 2^n1 2^n2 with n1 = floor(n / 2), both normal numbers, so that
 * results in the subnormal range round once, as a scalar exp's do. Within
 * 2 ulp of exp over [-745, 0] (tests/test_p2p.c checks every exponent); x
 * below -746 gives 0, and so does a NaN x (a lane of a pair at infinite
 * distance, whose 1 / r is 0 anyway). Domain: x <= 0. */
#define KIFMM_KERNEL__LN2_HI 6.93147180369123816490e-01 /* 32 significant bits */
#define KIFMM_KERNEL__LN2_LO 1.90821492927058770002e-10
#if defined(__AVX512F__)

/* With AVX-512, a table of 16 entries in two registers shortens the series:
 * n = x 16 / ln2 rounded, r = x - n ln2 / 16, |r| <= ln2 / 32, and exp(x) =
 * 2^floor(n / 16) 2^(j / 16) exp(r), j = n mod 16 (the low bits of the
 * rounding sum, which select the table entry), exp(r) - 1 to degree 7 (the
 * remainder, r^8 / 8!, is below 2e-18), 2^(j / 16) in two parts (hi + lo,
 * the sum of the two exact to 2^-106), and the power of two by scalef, which
 * rounds once also in the subnormal range. It takes y = -x >= 0 (the
 * hooks' lambda r): exp(-y), with y above 746 or NaN giving 0, as above. */
static inline __m512d kifmm_kernel__expn8(__m512d y)
{
    const __m512d big = _mm512_set1_pd(6755399441055744.0 /* 1.5 2^52 */);
    const __m512d h0 = _mm512_setr_pd(1.0, 1.0442737824274138, 1.0905077326652577,
                                      1.1387886347566916, 1.189207115002721, 1.241857812073484,
                                      1.2968395546510096, 1.3542555469368927);
    const __m512d h1 = _mm512_setr_pd(1.4142135623730951, 1.4768261459394993,
                                      1.5422108254079407, 1.6104903319492543, 1.681792830507429,
                                      1.7562521603732995, 1.8340080864093424, 1.9152065613971474);
    const __m512d l0 = _mm512_setr_pd(0.0, 8.551889705537965e-17, -3.046782079812471e-17,
                                      8.912812676025408e-17, 3.982015231465646e-17,
                                      4.658027591836937e-17, 2.5382502794888315e-17,
                                      7.70094837980299e-17);
    const __m512d l1 = _mm512_setr_pd(-9.667293313452913e-17, -3.483994556892796e-17,
                                      7.949834809697621e-17, 2.4707192569797888e-17,
                                      8.199010020581497e-17, 2.960140695448873e-17,
                                      3.283107224245627e-17, -1.0619946056195963e-16);
    __m512d t, n, r, c, th;
    __m512i j;
    y = _mm512_min_pd(y, _mm512_set1_pd(746.0)); /* NaN -> 746 */
    t = _mm512_fmadd_pd(y, _mm512_set1_pd(-23.083120654223414 /* -16 / ln2 */), big);
    n = _mm512_sub_pd(t, big);
    r = _mm512_fmadd_pd(n, _mm512_set1_pd(KIFMM_KERNEL__LN2_HI / 16), y); /* exact */
    r = _mm512_fnmsub_pd(n, _mm512_set1_pd(KIFMM_KERNEL__LN2_LO / 16), r); /* -y - n ln2 / 16 */
    c = _mm512_fmadd_pd(_mm512_set1_pd(1.0 / 5040.0), r, _mm512_set1_pd(1.0 / 720.0));
    c = _mm512_fmadd_pd(c, r, _mm512_set1_pd(1.0 / 120.0));
    c = _mm512_fmadd_pd(c, r, _mm512_set1_pd(1.0 / 24.0));
    c = _mm512_fmadd_pd(c, r, _mm512_set1_pd(1.0 / 6.0));
    c = _mm512_fmadd_pd(c, r, _mm512_set1_pd(0.5));
    c = _mm512_fmadd_pd(c, r, _mm512_set1_pd(1.0));
    c = _mm512_mul_pd(c, r); /* exp(r) - 1 */
    j = _mm512_castpd_si512(t); /* the low 4 bits pick the entry */
    th = _mm512_permutex2var_pd(h0, j, h1);
    c = _mm512_add_pd(th, _mm512_fmadd_pd(th, c, _mm512_permutex2var_pd(l0, j, l1)));
    return _mm512_scalef_pd(c, _mm512_mul_pd(n, _mm512_set1_pd(1.0 / 16.0))); /* 2^floor(n/16) */
}


#elif defined(__AVX2__) && defined(__FMA__)

/* exp(r) on |r| <= ln2 / 2 by the minimax polynomial of degree 11 (least
 * relative error, 3.1e-18, found by Remez's exchange in 60 digits; the
 * coefficients rounded to double): the terms from r^3 on in Estrin's form
 * (pairs of terms, then pairs of pairs with r^2 and r^4), the last three
 * steps of Horner's rule after them (1 + r (1 + r (c2 + r S)), whose
 * rounding keeps the result within the 1 ulp of the plain Horner form).
 * Seven operations deep, as the Taylor series of degree 13 in the same
 * form that it replaced, with two fewer in all (that series, yukawa_grad's
 * one-way AVX2 hook, 64 x 512 pairs, one core of an AVX-512 Xeon built with
 * -mno-avx512f: Horner's rule 3.37, Estrin's form 3.28 ns a pair) */
#define KIFMM_KERNEL__EXP_C(k) _mm256_set1_pd(k)
static inline __m256d kifmm_kernel__exp_series4(__m256d r)
{
    const __m256d r2 = _mm256_mul_pd(r, r), r4 = _mm256_mul_pd(r2, r2);
    const __m256d p3 = _mm256_fmadd_pd(r, KIFMM_KERNEL__EXP_C(0.04166666666649277), KIFMM_KERNEL__EXP_C(0.1666666666666617));
    const __m256d p5 = _mm256_fmadd_pd(r, KIFMM_KERNEL__EXP_C(0.0013888888951223987), KIFMM_KERNEL__EXP_C(0.00833333333355927));
    const __m256d p7 = _mm256_fmadd_pd(r, KIFMM_KERNEL__EXP_C(2.4801486521427463e-05), KIFMM_KERNEL__EXP_C(0.00019841269432679237));
    const __m256d p9 = _mm256_fmadd_pd(r, KIFMM_KERNEL__EXP_C(2.7632293279459877e-07), KIFMM_KERNEL__EXP_C(2.7557622530872255e-06));
    const __m256d q3 = _mm256_fmadd_pd(p5, r2, p3);
    const __m256d q7 = _mm256_fmadd_pd(_mm256_fmadd_pd(KIFMM_KERNEL__EXP_C(2.4994304884817207e-08), r2, p9), r2, p7);
    const __m256d s = _mm256_fmadd_pd(q7, r4, q3); /* r^3 .. r^11, over r^3 */
    const __m256d h = _mm256_fmadd_pd(r, s, KIFMM_KERNEL__EXP_C(0.5000000000000018));
    return _mm256_fmadd_pd(r, _mm256_fmadd_pd(r, h, KIFMM_KERNEL__EXP_C(1.0)), KIFMM_KERNEL__EXP_C(1.0));
}
#undef KIFMM_KERNEL__EXP_C

static inline __m256d kifmm_kernel__exp4(__m256d x)
{
    const __m256d big = _mm256_set1_pd(6755399441055744.0 /* 1.5 2^52 */), bias = _mm256_set1_pd(1023.0 + 4503599627370496.0 /* 2^52 */);
    __m256d t, n, r, p, n1;
    __m256i b1, b2;
    x = _mm256_max_pd(x, _mm256_set1_pd(-746.0)); /* NaN -> -746 */
    t = _mm256_fmadd_pd(x, _mm256_set1_pd(1.4426950408889634), big);
    n = _mm256_sub_pd(t, big);
    r = _mm256_fnmadd_pd(n, _mm256_set1_pd(KIFMM_KERNEL__LN2_HI), x);
    r = _mm256_fnmadd_pd(n, _mm256_set1_pd(KIFMM_KERNEL__LN2_LO), r);
    p = kifmm_kernel__exp_series4(r);
    n1 = _mm256_round_pd(_mm256_mul_pd(n, _mm256_set1_pd(0.5)),
                         _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
    b1 = _mm256_slli_epi64(_mm256_castpd_si256(_mm256_add_pd(n1, bias)), 52);
    b2 = _mm256_slli_epi64(_mm256_castpd_si256(_mm256_add_pd(_mm256_sub_pd(n, n1), bias)), 52);
    return _mm256_mul_pd(_mm256_mul_pd(p, _mm256_castsi256_pd(b1)), _mm256_castsi256_pd(b2));
}
/* exp(-y), as kifmm_kernel__expn8 */
static inline __m256d kifmm_kernel__expn4(__m256d y)
{
    return kifmm_kernel__exp4(_mm256_sub_pd(_mm256_setzero_pd(), y));
}

#endif

/* ------------------------------------------------------------------------ */
/* The vectorised sin and cos (AVX-512 or AVX2 + FMA)                       */
/* ------------------------------------------------------------------------ */
/* sin x and cos x together, for the oscillating kernels' near field: x = n
 * pi / 2 + r, n = x 2 / pi rounded to the nearest integer (by adding 1.5
 * 2^52 in one fused multiply-add: its low bits are n's), r from pi / 2 in
 * four parts (fdlibm's: the first three with at most 33 significant bits,
 * so that their products with |n| < 2^20 are exact, the fourth the rest of
 * pi / 2 to double precision), one fused multiply-add each, |r| <= pi / 4
 * (to an ulp); then sin r = r + r^3 S(r^2) and cos r = 1 - r^2 / 2 + r^4
 * C(r^2), S and C of degree 5 in r^2 (the minimax coefficients of fdlibm's
 * kernels, errors below 2^-58 on |r| <= pi / 4), and the pair rotated to
 * the quadrant n mod 4. For |x| up to KIFMM_KERNEL__SINCOS_MAX, measured
 * against a quad-precision reference: at most 2.5 ulp (2.0 from the C
 * library's sin and cos) and 2^-52 absolutely over random arguments in
 * every binade, 1 ulp at the doubles next to every multiple of pi / 2
 * (tests/test_sincos.c bounds them at 3 ulp of the C library's and 1.5
 * 2^-52); lanes beyond it, infinite or NaN take the C library's sin and
 * cos one lane at a time (a NaN gives NaN, as there). */
#define KIFMM_KERNEL__SINCOS_MAX 1.6e6 /* below 2^20 pi / 2 */
#define KIFMM_KERNEL__PIO2_1 1.57079632673412561417e+00 /* 31 significant bits */
#define KIFMM_KERNEL__PIO2_2 6.07710050630396597660e-11 /* 32 significant bits */
#define KIFMM_KERNEL__PIO2_3 2.02226624871116645580e-21 /* 28 significant bits */
#define KIFMM_KERNEL__PIO2_4 8.47842766036889956997e-32
#define KIFMM_KERNEL__SINCOS_POLY(V, FMA, MUL, SUB, SET1, r, s, c)                               \
    do {                                                                                       \
        const V z_ = MUL(r, r);                                                                \
        V p_ = FMA(FMA(FMA(FMA(SET1(1.58969099521155010221e-10), z_,                            \
                               SET1(-2.50507602534068634195e-08)), z_,                          \
                           SET1(2.75573137070700676789e-06)), z_,                               \
                       SET1(-1.98412698298579493134e-04)), z_, SET1(8.33333333332248946124e-03)); \
        V q_ = FMA(FMA(FMA(FMA(FMA(SET1(-1.13596475577881948265e-11), z_,                       \
                                   SET1(2.08757232129817482790e-09)), z_,                       \
                               SET1(-2.75573143513906633035e-07)), z_,                          \
                           SET1(2.48015872894767294178e-05)), z_,                               \
                       SET1(-1.38888888888741095749e-03)), z_, SET1(4.16666666666666019037e-02)); \
        p_ = FMA(p_, z_, SET1(-1.66666666666666324348e-01));                                   \
        s = FMA(MUL(p_, z_), r, r); /* +0 at r = -0: COPYSIGN below */                        \
        c = SUB(SET1(1.0), FMA(SET1(0.5), z_, MUL(SET1(-1.0), MUL(MUL(z_, z_), q_))));        \
    } while (0)

/* the lanes k < n of mask far: the C library's sin and cos */
static inline void kifmm_kernel__sincos_lanes(int n, int far, const double *x, double *s, double *c)
{
    int k;
    for (k = 0; k < n; k++)
        if (far >> k & 1) s[k] = sin(x[k]), c[k] = cos(x[k]);
}

#if defined(__AVX512F__)
/* x = n pi / 2 + r for the lanes |x| <= KIFMM_KERNEL__SINCOS_MAX (the
 * others wrong): sin r and cos r, and n in the low bits of the result */
static inline __m512i kifmm_kernel__sincos8_red(__m512d x, __m512d *sin_r, __m512d *cos_r)
{
    const __m512d big = _mm512_set1_pd(6755399441055744.0 /* 1.5 2^52 */);
    __m512d t = _mm512_fmadd_pd(x, _mm512_set1_pd(0.63661977236758134308 /* 2 / pi */), big);
    __m512d n = _mm512_sub_pd(t, big), r, s, c;
    r = _mm512_fnmadd_pd(n, _mm512_set1_pd(KIFMM_KERNEL__PIO2_1), x);
    r = _mm512_fnmadd_pd(n, _mm512_set1_pd(KIFMM_KERNEL__PIO2_2), r);
    r = _mm512_fnmadd_pd(n, _mm512_set1_pd(KIFMM_KERNEL__PIO2_3), r);
    r = _mm512_fnmadd_pd(n, _mm512_set1_pd(KIFMM_KERNEL__PIO2_4), r);
    KIFMM_KERNEL__SINCOS_POLY(__m512d, _mm512_fmadd_pd, _mm512_mul_pd, _mm512_sub_pd, _mm512_set1_pd,
                              r, s, c);
    *sin_r = _mm512_castsi512_pd(_mm512_ternarylogic_epi64(/* s with the sign of r */
        _mm512_castpd_si512(s), _mm512_castpd_si512(r), _mm512_set1_epi64(INT64_MIN), 0xd8));
    *cos_r = c;
    return _mm512_castpd_si512(t);
}
/* i^n (n in q's low bits, as kifmm_kernel__sincos8_red gives it): its real
 * and imaginary parts, 1, 0, -1 or 0 and 0, 1, 0 or -1 (a table lookup) */
static inline void kifmm_kernel__quarter8(__m512i q, __m512d *re, __m512d *im)
{
    *re = _mm512_permutexvar_pd(q, _mm512_setr_pd(1.0, 0.0, -1.0, 0.0, 1.0, 0.0, -1.0, 0.0));
    *im = _mm512_permutexvar_pd(q, _mm512_setr_pd(0.0, 1.0, 0.0, -1.0, 0.0, 1.0, 0.0, -1.0));
}
/* the lanes |x| <= KIFMM_KERNEL__SINCOS_MAX (the others wrong) */
static inline void kifmm_kernel__sincos8_in(__m512d x, __m512d *sin_x, __m512d *cos_x)
{
    const __m512i one = _mm512_set1_epi64(1), two = _mm512_set1_epi64(2);
    __m512d s, c, u;
    const __m512i q = kifmm_kernel__sincos8_red(x, &s, &c);
    const __mmask8 swap = _mm512_test_epi64_mask(q, one); /* odd quadrants: sin <-> cos */
    u = _mm512_mask_blend_pd(swap, s, c);
    c = _mm512_mask_blend_pd(swap, c, s);
    /* sin changes sign in quadrants 2, 3; cos in 1, 2 */
    u = _mm512_castsi512_pd(_mm512_xor_si512(_mm512_castpd_si512(u),
                                             _mm512_slli_epi64(_mm512_and_si512(q, two), 62)));
    c = _mm512_castsi512_pd(_mm512_xor_si512(
        _mm512_castpd_si512(c), _mm512_slli_epi64(_mm512_and_si512(_mm512_add_epi64(q, one), two), 62)));
    *sin_x = u, *cos_x = c;
}
/* every lane */
static inline void kifmm_kernel__sincos8(__m512d x, __m512d *sin_x, __m512d *cos_x)
{
    const __mmask8 far = _mm512_cmp_pd_mask(_mm512_abs_pd(x), _mm512_set1_pd(KIFMM_KERNEL__SINCOS_MAX),
                                            _CMP_NLE_UQ); /* also NaN */
    kifmm_kernel__sincos8_in(x, sin_x, cos_x);
    if (far) {
        double xs[8], ss[8], cs[8];
        _mm512_storeu_pd(xs, x), _mm512_storeu_pd(ss, *sin_x), _mm512_storeu_pd(cs, *cos_x);
        kifmm_kernel__sincos_lanes(8, far, xs, ss, cs);
        *sin_x = _mm512_loadu_pd(ss), *cos_x = _mm512_loadu_pd(cs);
    }
}
#elif defined(__AVX2__) && defined(__FMA__)
/* as kifmm_kernel__sincos8_red */
static inline __m256i kifmm_kernel__sincos4_red(__m256d x, __m256d *sin_r, __m256d *cos_r)
{
    const __m256d big = _mm256_set1_pd(6755399441055744.0 /* 1.5 2^52 */);
    __m256d t = _mm256_fmadd_pd(x, _mm256_set1_pd(0.63661977236758134308 /* 2 / pi */), big);
    __m256d n = _mm256_sub_pd(t, big), r, s, c;
    r = _mm256_fnmadd_pd(n, _mm256_set1_pd(KIFMM_KERNEL__PIO2_1), x);
    r = _mm256_fnmadd_pd(n, _mm256_set1_pd(KIFMM_KERNEL__PIO2_2), r);
    r = _mm256_fnmadd_pd(n, _mm256_set1_pd(KIFMM_KERNEL__PIO2_3), r);
    r = _mm256_fnmadd_pd(n, _mm256_set1_pd(KIFMM_KERNEL__PIO2_4), r);
    KIFMM_KERNEL__SINCOS_POLY(__m256d, _mm256_fmadd_pd, _mm256_mul_pd, _mm256_sub_pd, _mm256_set1_pd,
                              r, s, c);
    *sin_r = _mm256_or_pd(_mm256_andnot_pd(_mm256_set1_pd(-0.0), s), /* s with the sign of r */
                          _mm256_and_pd(_mm256_set1_pd(-0.0), r));
    *cos_r = c;
    return _mm256_castpd_si256(t);
}
/* as kifmm_kernel__quarter8: 1 with the sign of n's bit 1, in re for even
 * n and in im for odd n */
static inline void kifmm_kernel__quarter4(__m256i q, __m256d *re, __m256d *im)
{
    const __m256i one = _mm256_set1_epi64x(1);
    const __m256d odd = _mm256_castsi256_pd(_mm256_cmpeq_epi64(_mm256_and_si256(q, one), one));
    const __m256d sg = _mm256_xor_pd(_mm256_set1_pd(1.0),
                                     _mm256_and_pd(_mm256_set1_pd(-0.0),
                                                   _mm256_castsi256_pd(_mm256_slli_epi64(q, 62))));
    *re = _mm256_andnot_pd(odd, sg), *im = _mm256_and_pd(odd, sg);
}
/* the lanes |x| <= KIFMM_KERNEL__SINCOS_MAX (the others wrong) */
static inline void kifmm_kernel__sincos4_in(__m256d x, __m256d *sin_x, __m256d *cos_x)
{
    const __m256i one = _mm256_set1_epi64x(1), two = _mm256_set1_epi64x(2);
    __m256d s, c, u, swap;
    const __m256i q = kifmm_kernel__sincos4_red(x, &s, &c);
    swap = _mm256_castsi256_pd(_mm256_cmpeq_epi64(_mm256_and_si256(q, one), one));
    u = _mm256_blendv_pd(s, c, swap);
    c = _mm256_blendv_pd(c, s, swap);
    u = _mm256_xor_pd(u, _mm256_castsi256_pd(_mm256_slli_epi64(_mm256_and_si256(q, two), 62)));
    c = _mm256_xor_pd(c, _mm256_castsi256_pd(
                             _mm256_slli_epi64(_mm256_and_si256(_mm256_add_epi64(q, one), two), 62)));
    *sin_x = u, *cos_x = c;
}
/* every lane */
static inline void kifmm_kernel__sincos4(__m256d x, __m256d *sin_x, __m256d *cos_x)
{
    const __m256d ax = _mm256_andnot_pd(_mm256_set1_pd(-0.0), x);
    const int far = _mm256_movemask_pd(_mm256_cmp_pd(ax, _mm256_set1_pd(KIFMM_KERNEL__SINCOS_MAX),
                                                     _CMP_NLE_UQ)); /* also NaN */
    kifmm_kernel__sincos4_in(x, sin_x, cos_x);
    if (far) {
        double xs[4], ss[4], cs[4];
        _mm256_storeu_pd(xs, x), _mm256_storeu_pd(ss, *sin_x), _mm256_storeu_pd(cs, *cos_x);
        kifmm_kernel__sincos_lanes(4, far, xs, ss, cs);
        *sin_x = _mm256_loadu_pd(ss), *cos_x = _mm256_loadu_pd(cs);
    }
}
#endif
#undef KIFMM_KERNEL__SINCOS_POLY
#undef KIFMM_KERNEL__PIO2_1
#undef KIFMM_KERNEL__PIO2_2
#undef KIFMM_KERNEL__PIO2_3
#undef KIFMM_KERNEL__PIO2_4

/* ------------------------------------------------------------------------ */
/* Helmholtz near-field hooks (helmholtz, _grad, _cd_grad; double)          */
/* ------------------------------------------------------------------------ */
/* outa[TD i ..] += scale sum_j G q_j (mode 0), and A q_j d (mode 1), or
 * with dipoles v_j (mode 2, helmholtz_cd_grad) q_j G - A (v_j . d) and
 * (q_j A - B (v_j . d)) d - A v_j; complex values as (re, im) pairs (the
 * kernels' formulas, "Helmholtz" above): the sources in blocks of 128
 * points copied once into structure-of-arrays on the stack (densities
 * deinterleaved, zero past the block's end), 1 / r (AVX-512: rinv8, no
 * square root or division) zeroed where r = 0 (coincident points add
 * nothing), exp(-Im k r) by the vectorised exp (skipped for Im k = 0) and
 * sin, cos of Re k r by the vectorised sin and cos above. Mutual hooks
 * (_p2ps) for modes 0 and 1: the same rows, each adding the target's
 * density's field at the block's points to their sums as well. Where no
 * lane needs the C library's sin and cos, the quadrant's turn i^n is not
 * applied to sin and cos but folded into G's amplitude (a table lookup and
 * two products instead of blends and sign flips), the sums at the block's
 * points are fused multiply-adds into memory, and without damping A's
 * factor i k r - 1 is -1 + i Re k r (the same roundings, three operations
 * fewer). One core, 244 x 244 points a box apart, 2 wavelengths a unit,
 * best of 5 (-std=c99 -O3), before -> after those three: AVX-512
 * helmholtz_grad 1.96 -> 1.75 ns a pair and direction mutual, 2.93 -> 2.64
 * one way, helmholtz one way 1.99 -> 1.84; AVX2 4.04 -> 3.36, 5.70 ->
 * 5.10, 3.97 -> 3.59. AVX-512 or AVX2 + FMA builds; others take the
 * kernels' eval pair by pair. */
#if defined(__AVX512F__) || (defined(__AVX2__) && defined(__FMA__))
#define KIFMM_KERNEL__HELM_HOOKS (KIFMM_HAS_P2P | KIFMM_HAS_P2PF)
#if defined(__GNUC__) /* inlined into each hook, so that its mode is a constant */
#define KIFMM_KERNEL__HINLINE static inline __attribute__((always_inline))
#else
#define KIFMM_KERNEL__HINLINE static inline
#endif
#if defined(__AVX512F__)
#define KIFMM_KERNEL__HV __m512d
#define KIFMM_KERNEL__HW 8
#define KIFMM_KERNEL__HSET1 _mm512_set1_pd
#define KIFMM_KERNEL__HLOAD _mm512_loadu_pd
#define KIFMM_KERNEL__HSTORE _mm512_storeu_pd
#define KIFMM_KERNEL__HACCF(a, u, v) _mm512_storeu_pd((a), _mm512_fmadd_pd((u), (v), _mm512_loadu_pd(a)))
#define KIFMM_KERNEL__HSUB _mm512_sub_pd
#define KIFMM_KERNEL__HMUL _mm512_mul_pd
#define KIFMM_KERNEL__HFMA _mm512_fmadd_pd
#define KIFMM_KERNEL__HFNMA _mm512_fnmadd_pd
#define KIFMM_KERNEL__HINV kifmm_kernel__rinv8 /* no square root or division */
#define KIFMM_KERNEL__HEXPN kifmm_kernel__expn8
#define KIFMM_KERNEL__HSINCOS kifmm_kernel__sincos8
#define KIFMM_KERNEL__HSINCOS_RED kifmm_kernel__sincos8_red
#define KIFMM_KERNEL__HQUARTER kifmm_kernel__quarter8
#define KIFMM_KERNEL__HFMS _mm512_fmsub_pd
#define KIFMM_KERNEL__HSUM _mm512_reduce_add_pd
#else
#define KIFMM_KERNEL__HV __m256d
#define KIFMM_KERNEL__HW 4
#define KIFMM_KERNEL__HSET1 _mm256_set1_pd
#define KIFMM_KERNEL__HLOAD _mm256_loadu_pd
#define KIFMM_KERNEL__HSTORE _mm256_storeu_pd
#define KIFMM_KERNEL__HACCF(a, u, v) _mm256_storeu_pd((a), _mm256_fmadd_pd((u), (v), _mm256_loadu_pd(a)))
#define KIFMM_KERNEL__HSUB _mm256_sub_pd
#define KIFMM_KERNEL__HMUL _mm256_mul_pd
#define KIFMM_KERNEL__HFMA _mm256_fmadd_pd
#define KIFMM_KERNEL__HFNMA _mm256_fnmadd_pd
#define KIFMM_KERNEL__HINV(r2)                                                                  \
    _mm256_and_pd(_mm256_cmp_pd(r2, _mm256_setzero_pd(), _CMP_GT_OQ),                            \
                  _mm256_div_pd(_mm256_set1_pd(1.0), _mm256_sqrt_pd(r2)))
#define KIFMM_KERNEL__HEXPN kifmm_kernel__expn4
#define KIFMM_KERNEL__HSINCOS kifmm_kernel__sincos4
#define KIFMM_KERNEL__HSINCOS_RED kifmm_kernel__sincos4_red
#define KIFMM_KERNEL__HQUARTER kifmm_kernel__quarter4
#define KIFMM_KERNEL__HFMS _mm256_fmsub_pd
static inline double kifmm_kernel__hsum4(__m256d v)
{
    const __m128d a = _mm_add_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1));
    return _mm_cvtsd_f64(_mm_add_sd(a, _mm_unpackhi_pd(a, a)));
}
#define KIFMM_KERNEL__HSUM kifmm_kernel__hsum4
#endif
/* mode 2's terms of one block of lanes: the dipoles' (pv: re, im of v_x,
 * v_y, v_z, each SB_ long) and the charges' gradient, given G (gr, gi), A
 * (ar, ai) and q (qr, qi), into o[0..7] */
#define KIFMM_KERNEL__HELM_CD(pv, j, u)                                                            \
    do {                                                                                       \
        const V zr = KIFMM_KERNEL__HFNMA(KI, r[u], ZERO), zi = t1[u], ir4 = KIFMM_KERNEL__HMUL(ir2[u], ir2[u]); \
        const V br = KIFMM_KERNEL__HFMA(zr, zr, KIFMM_KERNEL__HFNMA(zi, zi, KIFMM_KERNEL__HFNMA(THREE, zr, THREE))); \
        const V bi = KIFMM_KERNEL__HMUL(zi, KIFMM_KERNEL__HFMA(TWO, zr, NTHREE));            \
        const V bbr = KIFMM_KERNEL__HMUL(KIFMM_KERNEL__HFNMA(gi[u], bi, KIFMM_KERNEL__HMUL(gr[u], br)), ir4); \
        const V bbi = KIFMM_KERNEL__HMUL(KIFMM_KERNEL__HFMA(gi[u], br, KIFMM_KERNEL__HMUL(gr[u], bi)), ir4); \
        const V vxr = KIFMM_KERNEL__HLOAD((pv) + (j)), vxi = KIFMM_KERNEL__HLOAD((pv) + SB_ + (j)); \
        const V vyr = KIFMM_KERNEL__HLOAD((pv) + 2 * SB_ + (j));                             \
        const V vyi = KIFMM_KERNEL__HLOAD((pv) + 3 * SB_ + (j));                             \
        const V vzr = KIFMM_KERNEL__HLOAD((pv) + 4 * SB_ + (j));                             \
        const V vzi = KIFMM_KERNEL__HLOAD((pv) + 5 * SB_ + (j));                             \
        const V vdr = KIFMM_KERNEL__HFMA(vzr, dz[u], KIFMM_KERNEL__HFMA(vyr, dy[u], KIFMM_KERNEL__HMUL(vxr, dx[u]))); \
        const V vdi = KIFMM_KERNEL__HFMA(vzi, dz[u], KIFMM_KERNEL__HFMA(vyi, dy[u], KIFMM_KERNEL__HMUL(vxi, dx[u]))); \
        const V cr = KIFMM_KERNEL__HSUB(aqr[u], KIFMM_KERNEL__HFNMA(bbi, vdi, KIFMM_KERNEL__HMUL(bbr, vdr))); \
        const V ci = KIFMM_KERNEL__HSUB(aqi[u], KIFMM_KERNEL__HFMA(bbi, vdr, KIFMM_KERNEL__HMUL(bbr, vdi))); \
        o[0] = KIFMM_KERNEL__HSUB(o[0], KIFMM_KERNEL__HFNMA(ai[u], vdi, KIFMM_KERNEL__HMUL(ar[u], vdr))); \
        o[1] = KIFMM_KERNEL__HSUB(o[1], KIFMM_KERNEL__HFMA(ai[u], vdr, KIFMM_KERNEL__HMUL(ar[u], vdi))); \
        o[2] = KIFMM_KERNEL__HFMA(cr, dx[u], KIFMM_KERNEL__HSUB(o[2], KIFMM_KERNEL__HFNMA(ai[u], vxi, KIFMM_KERNEL__HMUL(ar[u], vxr)))); \
        o[3] = KIFMM_KERNEL__HFMA(ci, dx[u], KIFMM_KERNEL__HSUB(o[3], KIFMM_KERNEL__HFMA(ai[u], vxr, KIFMM_KERNEL__HMUL(ar[u], vxi)))); \
        o[4] = KIFMM_KERNEL__HFMA(cr, dy[u], KIFMM_KERNEL__HSUB(o[4], KIFMM_KERNEL__HFNMA(ai[u], vyi, KIFMM_KERNEL__HMUL(ar[u], vyr)))); \
        o[5] = KIFMM_KERNEL__HFMA(ci, dy[u], KIFMM_KERNEL__HSUB(o[5], KIFMM_KERNEL__HFMA(ai[u], vyr, KIFMM_KERNEL__HMUL(ar[u], vyi)))); \
        o[6] = KIFMM_KERNEL__HFMA(cr, dz[u], KIFMM_KERNEL__HSUB(o[6], KIFMM_KERNEL__HFNMA(ai[u], vzi, KIFMM_KERNEL__HMUL(ar[u], vzr)))); \
        o[7] = KIFMM_KERNEL__HFMA(ci, dz[u], KIFMM_KERNEL__HSUB(o[7], KIFMM_KERNEL__HFMA(ai[u], vzr, KIFMM_KERNEL__HMUL(ar[u], vzi)))); \
    } while (0)
/* the mutual hooks' gradient terms of the block's points (their sums pb,
 * lanes from j): -A qa d, d the other way for them */
#define KIFMM_KERNEL__HELM_BACK(pb, j, u)                                                          \
    do {                                                                                       \
        const V bqr = KIFMM_KERNEL__HFNMA(ar[u], QAR, KIFMM_KERNEL__HMUL(ai[u], QAI));               \
        const V bqi = KIFMM_KERNEL__HFNMA(ai[u], QAR, KIFMM_KERNEL__HFNMA(ar[u], QAI, ZERO));        \
        KIFMM_KERNEL__HACCF((pb)[2] + (j), bqr, dx[u]);                                           \
        KIFMM_KERNEL__HACCF((pb)[3] + (j), bqi, dx[u]);                                           \
        KIFMM_KERNEL__HACCF((pb)[4] + (j), bqr, dy[u]);                                           \
        KIFMM_KERNEL__HACCF((pb)[5] + (j), bqi, dy[u]);                                           \
        KIFMM_KERNEL__HACCF((pb)[6] + (j), bqr, dz[u]);                                           \
        KIFMM_KERNEL__HACCF((pb)[7] + (j), bqi, dz[u]);                                           \
    } while (0)
enum { KIFMM_KERNEL__HSB = 128, KIFMM_KERNEL__HU = 4 };
/* a block of up to 128 sources (of nb from j0; double or float, the other
 * pointer NULL) into structure-of-arrays, padded past nb up to a whole
 * number of vectors with zero densities at the block's first point (so no
 * lane's r leaves the bound kifmm_kernel__helm_wide takes; at the origin a
 * lane's Re k |x| could, and its sin and cos overflow to 0 times infinity):
 * positions p[0..2], densities p[3] (re), p[4] (im)
 * and, in mode 2, p[5..10] (re, im of v_x, v_y, v_z); the count padded */
static inline int64_t kifmm_kernel__helm_fill(const double *const *bd, const float *const *bf,
                                              const double *qd, const float *qf, int64_t nb,
                                              int64_t j0, int mode, double (*p)[KIFMM_KERNEL__HSB])
{
    const int sd = mode == 2 ? 8 : 2;
    const int64_t jb = nb - j0 < KIFMM_KERNEL__HSB ? nb - j0 : (int64_t)KIFMM_KERNEL__HSB;
    const int64_t jp = (jb + KIFMM_KERNEL__HW - 1) / KIFMM_KERNEL__HW * KIFMM_KERNEL__HW;
    int64_t k;
    int c;
    for (k = 0; k < jp; k++)
        for (c = 0; c < (mode == 2 ? 11 : 5); c++) {
            const int64_t at = sd * (j0 + k) + c - 3;
            p[c][k] = k >= jb ? (c < 3 ? p[c][0] : 0.0) /* at the block's first point: r within */
                      : c < 3 ? (bd ? bd[c][j0 + k] : (double)bf[c][j0 + k])  /* kifmm_kernel__helm_wide's */
                              : (qd ? qd[at] : (double)qf[at]);
        }
    return jp;
}

#define KIFMM_KERNEL__HEACH for (u = 0; u < nu; u++) /* (the steps below, vector by vector) */
#define KIFMM_KERNEL__HLANE (j + (int64_t)u * KIFMM_KERNEL__HW)
/* the lanes j .. j + nu W - 1 of a filled block against the target (x, y,
 * z): d = target - source, 1 / r (0 at r = 0), r, Re k r and G */
KIFMM_KERNEL__HINLINE void kifmm_kernel__helm_g(const double *param, double x, double y, double z,
                                        double (*p)[KIFMM_KERNEL__HSB], int64_t j, int nu, int wide,
                                        int damped, KIFMM_KERNEL__HV *dx, KIFMM_KERNEL__HV *dy,
                                        KIFMM_KERNEL__HV *dz, KIFMM_KERNEL__HV *inv,
                                        KIFMM_KERNEL__HV *r, KIFMM_KERNEL__HV *t1,
                                        KIFMM_KERNEL__HV *gr, KIFMM_KERNEL__HV *gi)
{
    typedef KIFMM_KERNEL__HV V;
    const V KR = KIFMM_KERNEL__HSET1(param[0]), KI = KIFMM_KERNEL__HSET1(param[1]);
    const V X = KIFMM_KERNEL__HSET1(x), Y = KIFMM_KERNEL__HSET1(y), Z = KIFMM_KERNEL__HSET1(z);
    V r2[KIFMM_KERNEL__HU], e[KIFMM_KERNEL__HU];
    int u;
    KIFMM_KERNEL__HEACH dx[u] = KIFMM_KERNEL__HSUB(X, KIFMM_KERNEL__HLOAD(p[0] + KIFMM_KERNEL__HLANE));
    KIFMM_KERNEL__HEACH dy[u] = KIFMM_KERNEL__HSUB(Y, KIFMM_KERNEL__HLOAD(p[1] + KIFMM_KERNEL__HLANE));
    KIFMM_KERNEL__HEACH dz[u] = KIFMM_KERNEL__HSUB(Z, KIFMM_KERNEL__HLOAD(p[2] + KIFMM_KERNEL__HLANE));
    KIFMM_KERNEL__HEACH r2[u] = KIFMM_KERNEL__HFMA(dz[u], dz[u],
                                                 KIFMM_KERNEL__HFMA(dy[u], dy[u], KIFMM_KERNEL__HMUL(dx[u], dx[u])));
    KIFMM_KERNEL__HEACH inv[u] = KIFMM_KERNEL__HINV(r2[u]);
    KIFMM_KERNEL__HEACH r[u] = KIFMM_KERNEL__HMUL(r2[u], inv[u]), t1[u] = KIFMM_KERNEL__HMUL(KR, r[u]);
    KIFMM_KERNEL__HEACH e[u] = damped ? KIFMM_KERNEL__HMUL(KIFMM_KERNEL__HEXPN(KIFMM_KERNEL__HMUL(KI, r[u])), inv[u])
                                    : inv[u];
    KIFMM_KERNEL__HEACH {
        V sn, cs;
        if (wide) {
            KIFMM_KERNEL__HSINCOS(t1[u], &sn, &cs);
            gr[u] = KIFMM_KERNEL__HMUL(e[u], cs), gi[u] = KIFMM_KERNEL__HMUL(e[u], sn); /* G */
        } else { /* the quadrant's turn i^n folded into e: G = e i^n (cos + i sin)(t1 - n pi / 2) */
            V er, ei;
            KIFMM_KERNEL__HQUARTER(KIFMM_KERNEL__HSINCOS_RED(t1[u], &sn, &cs), &er, &ei);
            er = KIFMM_KERNEL__HMUL(e[u], er), ei = KIFMM_KERNEL__HMUL(e[u], ei);
            gr[u] = KIFMM_KERNEL__HFNMA(ei, sn, KIFMM_KERNEL__HMUL(er, cs));
            gi[u] = KIFMM_KERNEL__HFMA(er, sn, KIFMM_KERNEL__HMUL(ei, cs));
        }
    }
}

/* one target (x, y, z) against the lanes j .. j + nu W - 1 of a filled
 * block, into o[0 .. td - 1] (a vector of sums each); with pb (modes 0 and
 * 1, the mutual hooks), the target's density qa (re, im) as a source of the
 * block's points as well, added to their sums pb[c][j]. Each step below is
 * taken for the nu vectors in turn (nu a constant where inlined), so that
 * their independent chains (1 / r, then sin and cos: some 150 cycles deep,
 * against some 40 of arithmetic a vector) interleave and the scheduler
 * always holds work that can start; the sums take the lanes in the order
 * that one vector a step would (outputs bitwise those of one vector a step).
 * One core, 244 x 244 points a box apart, best of 15, one vector a step ->
 * 4 (gcc -O3): AVX-512 helmholtz_grad 3.58 -> 2.77 ns a pair mutual, 2.75
 * -> 2.36 one way; AVX2 6.62 -> 5.06, 4.99 -> 4.21; helmholtz_cd_grad one
 * way (bench_p2p, 256) 4.3 -> 3.6. */
KIFMM_KERNEL__HINLINE void kifmm_kernel__helm_step(const double *param, double x, double y, double z,
                                           double (*p)[KIFMM_KERNEL__HSB], int64_t j, int nu,
                                           int mode, int wide, int damped, const double *qa,
                                           double (*pb)[KIFMM_KERNEL__HSB], KIFMM_KERNEL__HV *o)
{
    typedef KIFMM_KERNEL__HV V;
    enum { SB_ = KIFMM_KERNEL__HSB, U_ = KIFMM_KERNEL__HU };
    const V KI = KIFMM_KERNEL__HSET1(param[1]);
    const V ONE = KIFMM_KERNEL__HSET1(1.0), ZERO = KIFMM_KERNEL__HSET1(0.0);
    const V TWO = KIFMM_KERNEL__HSET1(2.0), THREE = KIFMM_KERNEL__HSET1(3.0);
    const V NTHREE = KIFMM_KERNEL__HSET1(-3.0);
    const V QAR = KIFMM_KERNEL__HSET1(qa ? qa[0] : 0.0), QAI = KIFMM_KERNEL__HSET1(qa ? qa[1] : 0.0);
    V dx[U_], dy[U_], dz[U_], inv[U_], r[U_], t1[U_], gr[U_], gi[U_], qr[U_], qi[U_];
    V ir2[U_], ar[U_], ai[U_], aqr[U_], aqi[U_];
    int u;
    kifmm_kernel__helm_g(param, x, y, z, p, j, nu, wide, damped, dx, dy, dz, inv, r, t1, gr, gi);
    KIFMM_KERNEL__HEACH {
        qr[u] = KIFMM_KERNEL__HLOAD(p[3] + KIFMM_KERNEL__HLANE);
        qi[u] = KIFMM_KERNEL__HLOAD(p[4] + KIFMM_KERNEL__HLANE);
    }
#define KIFMM_KERNEL__HGQ /* o[0..1] += G q */                                               \
    o[0] = KIFMM_KERNEL__HFMA(gr[u], qr[u], KIFMM_KERNEL__HFNMA(gi[u], qi[u], o[0]));           \
    o[1] = KIFMM_KERNEL__HFMA(gr[u], qi[u], KIFMM_KERNEL__HFMA(gi[u], qr[u], o[1]))
    if (mode != 2) KIFMM_KERNEL__HEACH { KIFMM_KERNEL__HGQ; } /* (mode 2: with its other terms) */
    if (pb) KIFMM_KERNEL__HEACH { /* G qa */
        double *b0 = pb[0] + KIFMM_KERNEL__HLANE, *b1 = pb[1] + KIFMM_KERNEL__HLANE;
        const V v0 = KIFMM_KERNEL__HLOAD(b0), v1 = KIFMM_KERNEL__HLOAD(b1);
        KIFMM_KERNEL__HSTORE(b0, KIFMM_KERNEL__HFMA(gr[u], QAR, KIFMM_KERNEL__HFNMA(gi[u], QAI, v0)));
        KIFMM_KERNEL__HSTORE(b1, KIFMM_KERNEL__HFMA(gr[u], QAI, KIFMM_KERNEL__HFMA(gi[u], QAR, v1)));
    }
    if (!mode) return;
    KIFMM_KERNEL__HEACH ir2[u] = KIFMM_KERNEL__HMUL(inv[u], inv[u]); /* A q, A = G (i k r - 1) / r^2 */
    if (damped) KIFMM_KERNEL__HEACH {
        const V t0 = KIFMM_KERNEL__HFNMA(KI, r[u], KIFMM_KERNEL__HSUB(ZERO, ONE));
        ar[u] = KIFMM_KERNEL__HMUL(KIFMM_KERNEL__HFNMA(gi[u], t1[u], KIFMM_KERNEL__HMUL(gr[u], t0)), ir2[u]);
        ai[u] = KIFMM_KERNEL__HMUL(KIFMM_KERNEL__HFMA(gi[u], t0, KIFMM_KERNEL__HMUL(gr[u], t1[u])), ir2[u]);
    } else KIFMM_KERNEL__HEACH { /* i k r - 1 = -1 + i t1: the same roundings, fewer operations */
        ar[u] = KIFMM_KERNEL__HFNMA(KIFMM_KERNEL__HFMA(gi[u], t1[u], gr[u]), ir2[u], ZERO);
        ai[u] = KIFMM_KERNEL__HMUL(KIFMM_KERNEL__HFMS(gr[u], t1[u], gi[u]), ir2[u]);
    }
    KIFMM_KERNEL__HEACH {
        aqr[u] = KIFMM_KERNEL__HFNMA(ai[u], qi[u], KIFMM_KERNEL__HMUL(ar[u], qr[u]));
        aqi[u] = KIFMM_KERNEL__HFMA(ai[u], qr[u], KIFMM_KERNEL__HMUL(ar[u], qi[u]));
    }
    if (mode == 2) {
        KIFMM_KERNEL__HEACH {
            KIFMM_KERNEL__HGQ;
            KIFMM_KERNEL__HELM_CD(p[5], KIFMM_KERNEL__HLANE, u);
        }
        return;
    }
    KIFMM_KERNEL__HEACH {
        o[2] = KIFMM_KERNEL__HFMA(aqr[u], dx[u], o[2]), o[3] = KIFMM_KERNEL__HFMA(aqi[u], dx[u], o[3]);
        o[4] = KIFMM_KERNEL__HFMA(aqr[u], dy[u], o[4]), o[5] = KIFMM_KERNEL__HFMA(aqi[u], dy[u], o[5]);
        o[6] = KIFMM_KERNEL__HFMA(aqr[u], dz[u], o[6]), o[7] = KIFMM_KERNEL__HFMA(aqi[u], dz[u], o[7]);
    }
    if (pb) KIFMM_KERNEL__HEACH KIFMM_KERNEL__HELM_BACK(pb, KIFMM_KERNEL__HLANE, u);
#undef KIFMM_KERNEL__HGQ
}

/* one target (x, y, z) against a filled block of jp sources: the sums of
 * the mode's td outputs, without scale and 1 / (4 pi); KIFMM_KERNEL__HU
 * vectors a step, then one (kifmm_kernel__helm_step) */
KIFMM_KERNEL__HINLINE void kifmm_kernel__helm_row(const double *param, double x, double y, double z,
                                          double (*p)[KIFMM_KERNEL__HSB], int64_t jp, int mode,
                                          int wide, int damped, const double *qa,
                                          double (*pb)[KIFMM_KERNEL__HSB], double *sums)
{
    enum { W_ = KIFMM_KERNEL__HW, U_ = KIFMM_KERNEL__HU };
    KIFMM_KERNEL__HV o[8];
    int64_t j = 0;
    int c;
    for (c = 0; c < 8; c++) o[c] = KIFMM_KERNEL__HSET1(0.0);
    for (; j + U_ * W_ <= jp; j += U_ * W_)
        kifmm_kernel__helm_step(param, x, y, z, p, j, U_, mode, wide, damped, qa, pb, o);
    for (; j < jp; j += W_) kifmm_kernel__helm_step(param, x, y, z, p, j, 1, mode, wide, damped, qa, pb, o);
    for (c = 0; c < (mode ? 8 : 2); c++) sums[c] = KIFMM_KERNEL__HSUM(o[c]);
}
#undef KIFMM_KERNEL__HEACH
#undef KIFMM_KERNEL__HLANE

/* 1 where Re k r may exceed KIFMM_KERNEL__SINCOS_MAX between a point of A
 * and one of B (their joint bounding box's diagonal), or a coordinate is
 * not finite: the rows then check each lane for the C library's sin and
 * cos. Else 0: the rows without that check, whose call (never taken there)
 * kept the rows' sums out of registers (Intel Xeon, one core, 244 x 244
 * points, helmholtz_grad mutual: AVX-512 2.14 -> 1.98 ns a pair and
 * direction, AVX2 3.97 -> 3.88, best of 5 each, with the rows inlined into
 * each hook so that mode is a constant). */
static inline int kifmm_kernel__helm_wide(const double *param, const double *const *ad,
                                          const float *const *af, int64_t na,
                                          const double *const *bd, const float *const *bf,
                                          int64_t nb)
{
    double lo[3], hi[3], d2 = 0.0, bad = 0.0;
    int64_t i;
    int c, side;
    for (c = 0; c < 3; c++) {
        lo[c] = HUGE_VAL, hi[c] = -HUGE_VAL;
        for (side = 0; side < 2; side++)
            for (i = 0; i < (side ? nb : na); i++) {
                const double v = side ? (bd ? bd[c][i] : (double)bf[c][i])
                                      : (ad ? ad[c][i] : (double)af[c][i]);
                lo[c] = v < lo[c] ? v : lo[c], hi[c] = v > hi[c] ? v : hi[c];
                bad += v - v; /* NaN for an infinite or NaN v */
            }
        if (hi[c] > lo[c]) d2 += (hi[c] - lo[c]) * (hi[c] - lo[c]);
    }
    return !(bad == 0.0 && fabs(param[0]) * sqrt(d2) <= KIFMM_KERNEL__SINCOS_MAX);
}

/* the hooks: double (the float pointers NULL) or float (the double ones
 * NULL) inputs and outputs, sums in double either way; a, b: x, y, z */
KIFMM_KERNEL__HINLINE void kifmm_kernel__helm_p2p(const double *param, const double *const *ad,
                                          const float *const *af, int64_t na,
                                          const double *const *bd, const float *const *bf,
                                          int64_t nb, const double *qd, const float *qf,
                                          double scale, double *od, float *of, int mode)
{
    const double s = scale * KIFMM_INV_4PI;
    const int td = mode ? 8 : 2, wide = kifmm_kernel__helm_wide(param, ad, af, na, bd, bf, nb);
    const int damped = param[1] != 0.0; /* each row's exp and A take constant paths */
    double p[11][KIFMM_KERNEL__HSB], sums[8];
    int64_t i, j0, jp;
    int c;
    for (j0 = 0; j0 < nb; j0 += KIFMM_KERNEL__HSB) {
        jp = kifmm_kernel__helm_fill(bd, bf, qd, qf, nb, j0, mode, p);
        for (i = 0; i < na; i++) {
            const double x = ad ? ad[0][i] : (double)af[0][i], y = ad ? ad[1][i] : (double)af[1][i];
            const double z = ad ? ad[2][i] : (double)af[2][i];
            if (wide) kifmm_kernel__helm_row(param, x, y, z, p, jp, mode, 1, damped, NULL, NULL, sums);
            else if (damped) kifmm_kernel__helm_row(param, x, y, z, p, jp, mode, 0, 1, NULL, NULL, sums);
            else kifmm_kernel__helm_row(param, x, y, z, p, jp, mode, 0, 0, NULL, NULL, sums);
            for (c = 0; c < td; c++) {
                if (od) od[td * i + c] += s * sums[c];
                else of[td * i + c] += (float)(s * sums[c]);
            }
        }
    }
}

/* the mutual hooks (modes 0 and 1: G(-d) = G(d), A(-d) (-d) = -A(d) d):
 * both directions between the disjoint sets A (a, qa) and B, each pair's
 * sin, cos and exp once; B in blocks as above, the block's sums in pb,
 * added to outb after the block has met every point of A */
KIFMM_KERNEL__HINLINE void kifmm_kernel__helm_p2ps(const double *param, const double *const *ad,
                                           const float *const *af, const double *qad,
                                           const float *qaf, int64_t na,
                                           const double *const *bd, const float *const *bf,
                                           int64_t nb, const double *qbd, const float *qbf,
                                           double scale, double *oad, float *oaf, double *obd,
                                           float *obf, int mode)
{
    const double s = scale * KIFMM_INV_4PI;
    const int td = mode ? 8 : 2, wide = kifmm_kernel__helm_wide(param, ad, af, na, bd, bf, nb);
    const int damped = param[1] != 0.0; /* each row's exp and A take constant paths */
    double p[11][KIFMM_KERNEL__HSB], pb[8][KIFMM_KERNEL__HSB], sums[8], qa[2];
    int64_t i, j0, jp, k;
    int c;
    for (j0 = 0; j0 < nb; j0 += KIFMM_KERNEL__HSB) {
        jp = kifmm_kernel__helm_fill(bd, bf, qbd, qbf, nb, j0, mode, p);
        for (c = 0; c < td; c++)
            for (k = 0; k < jp; k++) pb[c][k] = 0.0;
        for (i = 0; i < na; i++) {
            const double x = ad ? ad[0][i] : (double)af[0][i], y = ad ? ad[1][i] : (double)af[1][i];
            const double z = ad ? ad[2][i] : (double)af[2][i];
            qa[0] = qad ? qad[2 * i] : (double)qaf[2 * i];
            qa[1] = qad ? qad[2 * i + 1] : (double)qaf[2 * i + 1];
            if (wide) kifmm_kernel__helm_row(param, x, y, z, p, jp, mode, 1, damped, qa, pb, sums);
            else if (damped) kifmm_kernel__helm_row(param, x, y, z, p, jp, mode, 0, 1, qa, pb, sums);
            else kifmm_kernel__helm_row(param, x, y, z, p, jp, mode, 0, 0, qa, pb, sums);
            for (c = 0; c < td; c++) {
                if (oad) oad[td * i + c] += s * sums[c];
                else oaf[td * i + c] += (float)(s * sums[c]);
            }
        }
        for (k = 0; k < jp && j0 + k < nb; k++)
            for (c = 0; c < td; c++) {
                if (obd) obd[td * (j0 + k) + c] += s * pb[c][k];
                else obf[td * (j0 + k) + c] += (float)(s * pb[c][k]);
            }
    }
}
#undef KIFMM_KERNEL__HINLINE
#undef KIFMM_KERNEL__HV
#undef KIFMM_KERNEL__HW
#undef KIFMM_KERNEL__HSET1
#undef KIFMM_KERNEL__HLOAD
#undef KIFMM_KERNEL__HSTORE
#undef KIFMM_KERNEL__HSUB
#undef KIFMM_KERNEL__HMUL
#undef KIFMM_KERNEL__HFMA
#undef KIFMM_KERNEL__HFNMA
#undef KIFMM_KERNEL__HINV
#undef KIFMM_KERNEL__HEXPN
#undef KIFMM_KERNEL__HSINCOS
#undef KIFMM_KERNEL__HSINCOS_RED
#undef KIFMM_KERNEL__HQUARTER
#undef KIFMM_KERNEL__HFMS
#undef KIFMM_KERNEL__HACCF
#undef KIFMM_KERNEL__HSUM
#undef KIFMM_KERNEL__HELM_CD
#undef KIFMM_KERNEL__HELM_BACK
/* the hooks of kernel NAME (mode M): one-way in double and float, and the
 * mutual ones (modes 0 and 1) */
#define KIFMM_KERNEL__HELM_ONEWAY(NAME, M)                                                     \
    static inline void NAME##_p2p(const double *param, const double *ax, const double *ay,     \
                                  const double *az, int64_t na, const double *bx,              \
                                  const double *by, const double *bz, const double *qb,        \
                                  int64_t nb, double scale, double *outa)                      \
    {                                                                                          \
        const double *a[3] = {ax, ay, az}, *b[3] = {bx, by, bz};                               \
        kifmm_kernel__helm_p2p(param, a, NULL, na, b, NULL, nb, qb, NULL, scale, outa, NULL, M); \
    }                                                                                          \
    static inline void NAME##_p2pf(const double *param, const float *ax, const float *ay,      \
                                   const float *az, int64_t na, const float *bx,               \
                                   const float *by, const float *bz, const float *qb,          \
                                   int64_t nb, float scale, float *outa)                       \
    {                                                                                          \
        const float *a[3] = {ax, ay, az}, *b[3] = {bx, by, bz};                                \
        kifmm_kernel__helm_p2p(param, NULL, a, na, NULL, b, nb, NULL, qb, scale, NULL, outa, M); \
    }
#define KIFMM_KERNEL__HELM_MUTUAL_FNS(NAME, M)                                                 \
    static inline void NAME##_p2ps(const double *param, const double *ax, const double *ay,    \
                                   const double *az, const double *qa, int64_t na,             \
                                   const double *bx, const double *by, const double *bz,       \
                                   const double *qb, int64_t nb, double scale, double *outa,   \
                                   double *outb)                                               \
    {                                                                                          \
        const double *a[3] = {ax, ay, az}, *b[3] = {bx, by, bz};                               \
        kifmm_kernel__helm_p2ps(param, a, NULL, qa, NULL, na, b, NULL, nb, qb, NULL, scale, outa, \
                                NULL, outb, NULL, M);                                          \
    }                                                                                          \
    static inline void NAME##_p2psf(const double *param, const float *ax, const float *ay,     \
                                    const float *az, const float *qa, int64_t na,              \
                                    const float *bx, const float *by, const float *bz,         \
                                    const float *qb, int64_t nb, float scale, float *outa,     \
                                    float *outb)                                               \
    {                                                                                          \
        const float *a[3] = {ax, ay, az}, *b[3] = {bx, by, bz};                                \
        kifmm_kernel__helm_p2ps(param, NULL, a, NULL, qa, na, NULL, b, nb, NULL, qb, scale, NULL, \
                                outa, NULL, outb, M);                                          \
    }
KIFMM_KERNEL__HELM_ONEWAY(kifmm_kernel_helmholtz, 0)
KIFMM_KERNEL__HELM_ONEWAY(kifmm_kernel_helmholtz_grad, 1)
KIFMM_KERNEL__HELM_ONEWAY(kifmm_kernel_helmholtz_cd_grad, 2)
KIFMM_KERNEL__HELM_MUTUAL_FNS(kifmm_kernel_helmholtz, 0)
KIFMM_KERNEL__HELM_MUTUAL_FNS(kifmm_kernel_helmholtz_grad, 1)
#undef KIFMM_KERNEL__HELM_ONEWAY
#undef KIFMM_KERNEL__HELM_MUTUAL_FNS
/* mutual hooks: helmholtz and helmholtz_grad (a dipole's potential is odd in d) */
#define KIFMM_KERNEL__HELM_MUTUAL (KIFMM_HAS_P2PS | KIFMM_HAS_P2PSF)
#else
#define KIFMM_KERNEL__HELM_HOOKS 0
#define KIFMM_KERNEL__HELM_MUTUAL 0
#endif

/* ------------------------------------------------------------------------ */
/* Stokes near-field hooks (stokes): one-way and mutual, double and float   */
/* ------------------------------------------------------------------------ */
/* u_i += s sum_j (f_i / r + d_i (d . f) / r^3), s = scale / (8 pi mu). The
 * sources come in blocks of KIFMM_KERNEL__SSB points, copied once into
 * structure-of-arrays on the stack (positions and the three force
 * components: the densities arrive interleaved, f[3 j + k]), so that each
 * target's loop loads whole vectors; lanes past a block's end get 1 / r = 0
 * (and so add nothing, whatever their padding). The mutual hooks use
 * G(-d) = G(d): each pair's d and 1 / r serve both directions, B's sums kept
 * in a stack block. One body, with the vector operations of the build: AVX-512
 * (8 or 16 lanes, 1 / r from rsqrt14 with a correction, as the Laplace
 * hooks), AVX2 + FMA (4 or 8 lanes, a division in double), or portable C
 * (one lane, 1 / sqrt). Pairs at distance 0 are skipped; in float, pairs
 * closer than sqrt(FLT_MIN) count as coincident, as in the Laplace loops. */
#define KIFMM_KERNEL__SSB 64
#define KIFMM_KERNEL__STOKES_BODY(T, V, W, SET1, ZERO, LOAD, STORE, SUB, MUL, FMADD, RINVM,      \
                                  HSUM, MUTUAL)                                                 \
    {                                                                                          \
        enum { SB_ = KIFMM_KERNEL__SSB, NB_ = KIFMM_KERNEL__SSB / (W) };                       \
        const T s = (T)((double)scale * (0.5 * KIFMM_INV_4PI / param[0]));                     \
        V vx[NB_], vy[NB_], vz[NB_], vf[3 * NB_], vo[3 * NB_];                                 \
        T *px = (T *)vx, *py = (T *)vy, *pz = (T *)vz, *pf = (T *)vf, *po = (T *)vo;           \
        int64_t i, j, j0, jb, k;                                                               \
        for (j0 = 0; j0 < nb; j0 += SB_) {                                                     \
            jb = nb - j0 < SB_ ? nb - j0 : (int64_t)SB_;                                       \
            for (k = 0; k < SB_; k++) {                                                        \
                const int in = k < jb;                                                         \
                px[k] = in ? bx[j0 + k] : (T)0;                                                \
                py[k] = in ? by[j0 + k] : (T)0;                                                \
                pz[k] = in ? bz[j0 + k] : (T)0;                                                \
                pf[k] = in ? qb[3 * (j0 + k)] : (T)0;                                          \
                pf[SB_ + k] = in ? qb[3 * (j0 + k) + 1] : (T)0;                                \
                pf[2 * SB_ + k] = in ? qb[3 * (j0 + k) + 2] : (T)0;                            \
                po[k] = po[SB_ + k] = po[2 * SB_ + k] = (T)0;                                  \
            }                                                                                  \
            for (i = 0; i < na; i++) {                                                         \
                const V X = SET1(ax[i]), Y = SET1(ay[i]), Z = SET1(az[i]);                     \
                const V g0 = (MUTUAL) ? SET1(qa[3 * i]) : ZERO;                                \
                const V g1 = (MUTUAL) ? SET1(qa[3 * i + 1]) : ZERO;                            \
                const V g2 = (MUTUAL) ? SET1(qa[3 * i + 2]) : ZERO;                            \
                V u0 = ZERO, u1 = ZERO, u2 = ZERO;                                             \
                for (j = 0; j < jb; j += (W)) {                                                \
                    const V dx = SUB(X, LOAD(px + j)), dy = SUB(Y, LOAD(py + j));              \
                    const V dz = SUB(Z, LOAD(pz + j));                                         \
                    const V inv = RINVM(FMADD(dz, dz, FMADD(dy, dy, MUL(dx, dx))), jb - j);    \
                    const V i3 = MUL(inv, MUL(inv, inv));                                      \
                    const V f0 = LOAD(pf + j), f1 = LOAD(pf + SB_ + j);                        \
                    const V f2 = LOAD(pf + 2 * SB_ + j);                                       \
                    const V t = MUL(i3, FMADD(dz, f2, FMADD(dy, f1, MUL(dx, f0))));            \
                    u0 = FMADD(f0, inv, FMADD(dx, t, u0));                                     \
                    u1 = FMADD(f1, inv, FMADD(dy, t, u1));                                     \
                    u2 = FMADD(f2, inv, FMADD(dz, t, u2));                                     \
                    if (MUTUAL) {                                                              \
                        const V w = MUL(i3, FMADD(dz, g2, FMADD(dy, g1, MUL(dx, g0))));        \
                        STORE(po + j, FMADD(g0, inv, FMADD(dx, w, LOAD(po + j))));             \
                        STORE(po + SB_ + j, FMADD(g1, inv, FMADD(dy, w, LOAD(po + SB_ + j)))); \
                        STORE(po + 2 * SB_ + j,                                                \
                              FMADD(g2, inv, FMADD(dz, w, LOAD(po + 2 * SB_ + j))));           \
                    }                                                                          \
                }                                                                              \
                outa[3 * i] += s * HSUM(u0);                                                   \
                outa[3 * i + 1] += s * HSUM(u1);                                               \
                outa[3 * i + 2] += s * HSUM(u2);                                               \
            }                                                                                  \
            if (MUTUAL)                                                                        \
                for (j = 0; j < jb; j++)                                                       \
                    for (k = 0; k < 3; k++) outb[3 * (j0 + j) + k] += s * po[k * SB_ + j];     \
        }                                                                                      \
    }

#if defined(__AVX512F__)
#define KIFMM_KERNEL__SRINV8(r2, n) _mm512_maskz_mov_pd(kifmm_kernel__first8(n), kifmm_kernel__rinv8(r2))
#define KIFMM_KERNEL__SRINV16(r2, n) _mm512_maskz_mov_ps(kifmm_kernel__first16(n), kifmm_kernel__rinv16(r2))
#define KIFMM_KERNEL__STOKES_D(M)                                                              \
    KIFMM_KERNEL__STOKES_BODY(double, __m512d, 8, _mm512_set1_pd, _mm512_setzero_pd(),         \
                              _mm512_load_pd, _mm512_store_pd, _mm512_sub_pd, _mm512_mul_pd,   \
                              _mm512_fmadd_pd, KIFMM_KERNEL__SRINV8, kifmm_kernel__hsum8, M)
#define KIFMM_KERNEL__STOKES_F(M)                                                              \
    KIFMM_KERNEL__STOKES_BODY(float, __m512, 16, _mm512_set1_ps, _mm512_setzero_ps(),          \
                              _mm512_load_ps, _mm512_store_ps, _mm512_sub_ps, _mm512_mul_ps,   \
                              _mm512_fmadd_ps, KIFMM_KERNEL__SRINV16, kifmm_kernel__hsum16, M)
#elif defined(__AVX2__) && defined(__FMA__)
/* 1 / sqrt(r2) in the first n lanes where r2 > 0 (float: FLT_MIN <= r2 <=
 * FLT_MAX, rsqrt and one Newton step), 0 elsewhere */
static inline __m256d kifmm_kernel__srinv4(__m256d r2, int64_t n)
{
    const __m256d live = _mm256_and_pd(_mm256_cmp_pd(r2, _mm256_setzero_pd(), _CMP_GT_OQ),
                                       _mm256_castsi256_pd(kifmm_kernel__first4i(n)));
    return _mm256_and_pd(_mm256_div_pd(_mm256_set1_pd(1.0), _mm256_sqrt_pd(r2)), live);
}
static inline __m256 kifmm_kernel__srinv8f(__m256 r2, int64_t n)
{
    const __m256 live = _mm256_and_ps(
        _mm256_and_ps(_mm256_cmp_ps(r2, _mm256_set1_ps(FLT_MIN), _CMP_GE_OQ),
                      _mm256_cmp_ps(r2, _mm256_set1_ps(FLT_MAX), _CMP_LE_OQ)),
        _mm256_castsi256_ps(kifmm_kernel__first8i(n)));
    const __m256 y = _mm256_rsqrt_ps(r2);
    const __m256 e = _mm256_fnmadd_ps(_mm256_mul_ps(r2, y), y, _mm256_set1_ps(1.0f));
    return _mm256_and_ps(_mm256_fmadd_ps(_mm256_mul_ps(_mm256_set1_ps(0.5f), y), e, y), live);
}
static inline double kifmm_kernel__shsum4(__m256d v)
{
    __m128d h = _mm_add_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1));
    return _mm_cvtsd_f64(_mm_add_sd(h, _mm_unpackhi_pd(h, h)));
}
static inline float kifmm_kernel__shsum8f(__m256 v)
{
    __m128 h = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));
    h = _mm_add_ps(h, _mm_movehl_ps(h, h));
    return _mm_cvtss_f32(_mm_add_ss(h, _mm_shuffle_ps(h, h, 1)));
}
#define KIFMM_KERNEL__STOKES_D(M)                                                              \
    KIFMM_KERNEL__STOKES_BODY(double, __m256d, 4, _mm256_set1_pd, _mm256_setzero_pd(),         \
                              _mm256_load_pd, _mm256_store_pd, _mm256_sub_pd, _mm256_mul_pd,   \
                              _mm256_fmadd_pd, kifmm_kernel__srinv4, kifmm_kernel__shsum4, M)
#define KIFMM_KERNEL__STOKES_F(M)                                                              \
    KIFMM_KERNEL__STOKES_BODY(float, __m256, 8, _mm256_set1_ps, _mm256_setzero_ps(),           \
                              _mm256_load_ps, _mm256_store_ps, _mm256_sub_ps, _mm256_mul_ps,   \
                              _mm256_fmadd_ps, kifmm_kernel__srinv8f, kifmm_kernel__shsum8f, M)
#else
/* one lane: the scalar kernel's 1 / r */
static inline double kifmm_kernel__srinv1(double r2, int64_t n)
{
    (void)n;
    return r2 > 0.0 ? 1.0 / sqrt(r2) : 0.0;
}
static inline float kifmm_kernel__srinv1f(float r2, int64_t n)
{
    (void)n;
    return r2 >= FLT_MIN && r2 <= FLT_MAX ? 1.0f / sqrtf(r2) : 0.0f;
}
#define KIFMM_KERNEL__S_SET1(x) (x)
#define KIFMM_KERNEL__S_LOAD(p) (*(p))
#define KIFMM_KERNEL__S_STORE(p, v) (*(p) = (v))
#define KIFMM_KERNEL__S_SUB(a, b) ((a) - (b))
#define KIFMM_KERNEL__S_MUL(a, b) ((a) * (b))
#define KIFMM_KERNEL__S_FMADD(a, b, c) ((a) * (b) + (c))
#define KIFMM_KERNEL__STOKES_D(M)                                                              \
    KIFMM_KERNEL__STOKES_BODY(double, double, 1, KIFMM_KERNEL__S_SET1, 0.0, KIFMM_KERNEL__S_LOAD, \
                              KIFMM_KERNEL__S_STORE, KIFMM_KERNEL__S_SUB, KIFMM_KERNEL__S_MUL, \
                              KIFMM_KERNEL__S_FMADD, kifmm_kernel__srinv1, KIFMM_KERNEL__S_SET1, M)
#define KIFMM_KERNEL__STOKES_F(M)                                                              \
    KIFMM_KERNEL__STOKES_BODY(float, float, 1, KIFMM_KERNEL__S_SET1, 0.0f, KIFMM_KERNEL__S_LOAD, \
                              KIFMM_KERNEL__S_STORE, KIFMM_KERNEL__S_SUB, KIFMM_KERNEL__S_MUL, \
                              KIFMM_KERNEL__S_FMADD, kifmm_kernel__srinv1f, KIFMM_KERNEL__S_SET1, M)
#endif

/* The one-way hooks run the mutual body without B's sums (targets as A). */
#define KIFMM_KERNEL__STOKES_P2P(name, T, BODY)                                                \
    static inline void name(const double *param, const T *ax, const T *ay, const T *az,        \
                            int64_t na, const T *bx, const T *by, const T *bz, const T *qb,    \
                            int64_t nb, T scale, T *outa)                                      \
    {                                                                                          \
        const T *qa = NULL;                                                                    \
        T *outb = NULL;                                                                        \
        BODY(0)                                                                                \
        (void)qa;                                                                              \
        (void)outb;                                                                            \
    }
#define KIFMM_KERNEL__STOKES_P2PS(name, T, BODY)                                               \
    static inline void name(const double *param, const T *ax, const T *ay, const T *az,        \
                            const T *qa, int64_t na, const T *bx, const T *by, const T *bz,    \
                            const T *qb, int64_t nb, T scale, T *outa, T *outb)                \
        BODY(1)
KIFMM_KERNEL__STOKES_P2P(kifmm_kernel_stokes_p2p, double, KIFMM_KERNEL__STOKES_D)
KIFMM_KERNEL__STOKES_P2P(kifmm_kernel_stokes_p2pf, float, KIFMM_KERNEL__STOKES_F)
KIFMM_KERNEL__STOKES_P2PS(kifmm_kernel_stokes_p2ps, double, KIFMM_KERNEL__STOKES_D)
KIFMM_KERNEL__STOKES_P2PS(kifmm_kernel_stokes_p2psf, float, KIFMM_KERNEL__STOKES_F)
#undef KIFMM_KERNEL__STOKES_P2P
#undef KIFMM_KERNEL__STOKES_P2PS
#undef KIFMM_KERNEL__STOKES_D
#undef KIFMM_KERNEL__STOKES_F
#undef KIFMM_KERNEL__STOKES_BODY

/* ------------------------------------------------------------------------ */
/* Yukawa near-field hooks (yukawa, yukawa_grad): one-way and mutual, double */
/* ------------------------------------------------------------------------ */
/* Both directions of the contract of the _p2ps hooks above: with e =
 * exp(-lambda r), outa_i += s sum_j qb_j e / r and, with the gradient,
 * -= s sum_j qb_j e (1 + lambda r) d / r^3 (d = a_i - b_j), and B's sums
 * the same with d = b_j - a_i; each pair's r and exp computed once. B goes
 * in blocks of KIFMM_KERNEL__SSB points, copied into structure-of-arrays on
 * the stack with their sums; two points of A at a time share each load and
 * store of those (i1 = i for the last of an odd count, with no density and
 * its sums not stored). Lanes past the block's end get 1 / r = 0, so e / r
 * = 0 (exp(0) = 1). One body over the build's vectors: AVX-512 and AVX2 +
 * FMA with the vectorised exp above, portable C with the C library's exp;
 * RED2 adds two points' four sums to outa (the gradient), HSUM one sum.
 *
 * Where both points of A lie within KIFMM_KERNEL__YSHORT / lambda of the
 * block's farthest corner, every lambda r of the pass is below YSHORT and
 * exp(-lambda r) is a polynomial of degree 6 (EXPS, below), without the
 * range reduction, the table and the scaling: 6 instead of 18 vector
 * operations per exp; below KIFMM_KERNEL__YMID, of degree 8 (EXPM); below
 * KIFMM_KERNEL__YLONG, of degree 9 (EXPL). This is the near field of boxes
 * small against the screening length 1 / lambda (at lambda 1: 1M uniform
 * points, whose leaves are 1/32 wide, clustered points, deep levels; 200,000
 * uniform points, whose leaves are 1/16 wide and whose pairs are at most
 * 0.22 apart); one core, 64 x 512 pairs, lambda 1, yukawa_grad one-way, with
 * the Taylor series of degrees 7 and 10 first: in a cube of side 0.01, 1.56
 * -> 1.21 ns per pair with AVX-512, 3.19 -> 1.94 with AVX2; side 0.05, 1.56
 * -> 1.35 and 3.19 -> 2.20; side 1, 1.56 (the full exp); with the series of
 * degree 13 below YLONG, two leaves of 49 points side by side, yukawa_grad
 * mutual: AVX-512 2.47 -> 2.27 ns a pair and direction, AVX2 4.74 -> 2.96.
 * The minimax polynomials in place of the series of degrees 7, 10 and 13
 * took yukawa_grad's near field at 200,000 uniform points, p = 6, 2 threads
 * (Intel Xeon with AVX-512, best of 5 evaluates, two runs) from 0.105 and
 * 0.106 s to 0.095 and 0.093 s with AVX-512 and from 0.147 to 0.136 s with
 * AVX2 (-mno-avx512f). */
#define KIFMM_KERNEL__YSHORT 0.03125
#define KIFMM_KERNEL__YMID 0.125
#define KIFMM_KERNEL__YLONG 0.25
/* exp(-y) = a0 - y (a1 - y (a2 - ...)): the minimax polynomials of least
 * relative error on [0, YSHORT] (degree 6, error 7.1e-19), [0, YMID] (degree
 * 8, 1.6e-19) and [0, YLONG] (degree 9, 5.0e-19), found by Remez's exchange
 * in 60 digits; a_k = |c_k| rounded to double. By Horner's rule with fused
 * multiply-adds, within 0.53, 0.59 and 0.76 ulp of exp(-y) (every y of a
 * 2e6-point grid on each interval, against long double). KIFMM_KERNEL__HN
 * is one step: acc -> a - acc y. */
#define KIFMM_KERNEL__HN(FNMADD, SET1, y, acc, a) FNMADD(acc, y, SET1(a))
#define KIFMM_KERNEL__EXP5(FNMADD, SET1, y, acc, a0, a1, a2, a3, a4)                           \
    KIFMM_KERNEL__HN(FNMADD, SET1, y, KIFMM_KERNEL__HN(FNMADD, SET1, y,                        \
    KIFMM_KERNEL__HN(FNMADD, SET1, y, KIFMM_KERNEL__HN(FNMADD, SET1, y,                        \
    KIFMM_KERNEL__HN(FNMADD, SET1, y, acc, a4), a3), a2), a1), a0)
#define KIFMM_KERNEL__EXPS(FNMADD, SET1, y)                                                     \
    KIFMM_KERNEL__EXP5(FNMADD, SET1, y, KIFMM_KERNEL__HN(FNMADD, SET1, y,                      \
                       SET1(0.0013673457311960359), 0.008332409093226282), 1.0,                  \
                       0.9999999999999978, 0.49999999999887507, 0.16666666645105052,              \
                       0.04166664697237952)
#define KIFMM_KERNEL__EXPM(FNMADD, SET1, y)                                                     \
    KIFMM_KERNEL__EXP5(FNMADD, SET1, y, KIFMM_KERNEL__HN(FNMADD, SET1, y,                      \
                       KIFMM_KERNEL__HN(FNMADD, SET1, y, KIFMM_KERNEL__HN(FNMADD, SET1, y,       \
                       SET1(2.3296659944779405e-05), 0.00019806256034475786),                    \
                       0.0013888446918701304), 0.008333330072549777), 1.0, 0.9999999999999998,   \
                       0.4999999999999576, 0.16666666666320729, 0.0416666665250766)
#define KIFMM_KERNEL__EXPL(FNMADD, SET1, y)                                                     \
    KIFMM_KERNEL__EXP5(FNMADD, SET1, y, KIFMM_KERNEL__HN(FNMADD, SET1, y,                      \
                       KIFMM_KERNEL__HN(FNMADD, SET1, y, KIFMM_KERNEL__HN(FNMADD, SET1, y,       \
                       KIFMM_KERNEL__HN(FNMADD, SET1, y, SET1(2.4310614421534472e-06),           \
                       2.463176290854282e-05), 0.0001983629315253075), 0.0013888800276068603),   \
                       0.008333332353464583), 1.0, 0.9999999999999996, 0.4999999999999491,      \
                       0.16666666666409533, 0.041666666600522456)
/* The squared distance from (x, y, z) to the farthest corner of the box
 * [lo, hi] */
static inline double kifmm_kernel__far2(const double *lo, const double *hi, double x, double y,
                                        double z)
{
    const double dx = x - lo[0] > hi[0] - x ? x - lo[0] : hi[0] - x;
    const double dy = y - lo[1] > hi[1] - y ? y - lo[1] : hi[1] - y;
    const double dz = z - lo[2] > hi[2] - z ? z - lo[2] : hi[2] - z;
    return dx * dx + dy * dy + dz * dz;
}
/* One pass of two points of A over the block, exp by EXPF */
#define KIFMM_KERNEL__YUKAWA_PASS(V, W, LOAD, STORE, SUB, MUL, FMADD, FNMADD, RINVM, EXPF, GRAD, \
                                  MUTUAL)                                                       \
    for (j = 0; j < jb; j += (W)) {                                                            \
        const V sx = LOAD(px + j), sy = LOAD(py + j), sz = LOAD(pz + j);                       \
        const V q = LOAD(pq + j);                                                              \
        const V dx0 = SUB(X0, sx), dy0 = SUB(Y0, sy), dz0 = SUB(Z0, sz);                       \
        const V dx1 = SUB(X1, sx), dy1 = SUB(Y1, sy), dz1 = SUB(Z1, sz);                       \
        const V r20 = FMADD(dz0, dz0, FMADD(dy0, dy0, MUL(dx0, dx0)));                         \
        const V r21 = FMADD(dz1, dz1, FMADD(dy1, dy1, MUL(dx1, dx1)));                         \
        const V inv0 = RINVM(r20, jb - j), lr0 = MUL(lam, MUL(r20, inv0));                     \
        const V inv1 = RINVM(r21, jb - j), lr1 = MUL(lam, MUL(r21, inv1));                     \
        const V e0 = MUL(inv0, EXPF(lr0)); /* e^(-lambda r) / r */                            \
        const V e1 = MUL(inv1, EXPF(lr1));                                                     \
        a0 = FMADD(q, e0, a0);                                                                 \
        c0 = FMADD(q, e1, c0);                                                                 \
        if (MUTUAL) STORE(po + j, FMADD(QA0, e0, FMADD(QA1, e1, LOAD(po + j))));               \
        if (GRAD) {                                                                            \
            const V f0 = MUL(e0, MUL(inv0, inv0)), g0 = FMADD(lr0, f0, f0);                    \
            const V f1 = MUL(e1, MUL(inv1, inv1)), g1 = FMADD(lr1, f1, f1);                    \
            const V gb0 = MUL(q, g0), gb1 = MUL(q, g1);                                        \
            const V ga0 = MUL(QA0, g0), ga1 = MUL(QA1, g1);                                    \
            KIFMM_KERNEL__SUB_A2(gb0, gb1, FNMADD);                                            \
            if (MUTUAL) {                                                                      \
                KIFMM_KERNEL__ADD_B3(po + SB_ + j, ga0, ga1, SB_, LOAD, STORE, FMADD);         \
            }                                                                                  \
        }                                                                                      \
    }
#define KIFMM_KERNEL__YUKAWA_BODY(V, W, SET1, ZERO, LOAD, STORE, SUB, MUL, FMADD, FNMADD,        \
                                  RINVM, EXPNV, EXPS, EXPM, EXPL, HSUM, RED2, GRAD, MUTUAL)     \
    {                                                                                          \
        enum { SB_ = KIFMM_KERNEL__SSB, NB_ = KIFMM_KERNEL__SSB / (W), TD_ = (GRAD) ? 4 : 1 };  \
        const double s = scale * KIFMM_INV_4PI, ys = KIFMM_KERNEL__YSHORT / param[0];          \
        const double ym = KIFMM_KERNEL__YMID / param[0], yl = KIFMM_KERNEL__YLONG / param[0];   \
        const V lam = SET1(param[0]);                                                          \
        V vx[NB_], vy[NB_], vz[NB_], vq[NB_], vo[TD_ * NB_];                                   \
        double *px = (double *)vx, *py = (double *)vy, *pz = (double *)vz;                     \
        double *pq = (double *)vq, *po = (double *)vo, lo[3], hi[3];                           \
        int64_t i, j, j0, jb, k;                                                               \
        for (j0 = 0; j0 < nb; j0 += SB_) {                                                     \
            jb = nb - j0 < SB_ ? nb - j0 : (int64_t)SB_;                                       \
            lo[0] = hi[0] = bx[j0];                                                            \
            lo[1] = hi[1] = by[j0];                                                            \
            lo[2] = hi[2] = bz[j0];                                                            \
            for (k = 0; k < SB_; k++) {                                                        \
                const int in = k < jb;                                                         \
                px[k] = in ? bx[j0 + k] : 0.0;                                                 \
                py[k] = in ? by[j0 + k] : 0.0;                                                 \
                pz[k] = in ? bz[j0 + k] : 0.0;                                                 \
                pq[k] = in ? qb[j0 + k] : 0.0;                                                 \
                if (in) {                                                                      \
                    lo[0] = px[k] < lo[0] ? px[k] : lo[0];                                     \
                    hi[0] = px[k] > hi[0] ? px[k] : hi[0];                                     \
                    lo[1] = py[k] < lo[1] ? py[k] : lo[1];                                     \
                    hi[1] = py[k] > hi[1] ? py[k] : hi[1];                                     \
                    lo[2] = pz[k] < lo[2] ? pz[k] : lo[2];                                     \
                    hi[2] = pz[k] > hi[2] ? pz[k] : hi[2];                                     \
                }                                                                              \
            }                                                                                  \
            for (k = 0; k < TD_ * SB_; k++) po[k] = 0.0;                                       \
            for (i = 0; i < na; i += 2) {                                                      \
                const int64_t i1 = i + 1 < na ? i + 1 : i;                                     \
                const V X0 = SET1(ax[i]), Y0 = SET1(ay[i]), Z0 = SET1(az[i]);                  \
                const V X1 = SET1(ax[i1]), Y1 = SET1(ay[i1]), Z1 = SET1(az[i1]);               \
                const V QA0 = (MUTUAL) ? SET1(qa[i]) : ZERO;                                   \
                const V QA1 = (MUTUAL) && i1 > i ? SET1(qa[i1]) : ZERO;                        \
                V a0 = ZERO, a1 = ZERO, a2 = ZERO, a3 = ZERO;                                  \
                V c0 = ZERO, c1 = ZERO, c2 = ZERO, c3 = ZERO;                                  \
                const double f0 = kifmm_kernel__far2(lo, hi, ax[i], ay[i], az[i]);            \
                const double f1 = kifmm_kernel__far2(lo, hi, ax[i1], ay[i1], az[i1]);          \
                const double fm = f0 > f1 ? f0 : f1;                                           \
                if (fm <= ys * ys) {                                                           \
                    KIFMM_KERNEL__YUKAWA_PASS(V, W, LOAD, STORE, SUB, MUL, FMADD, FNMADD, RINVM, \
                                              EXPS, GRAD, MUTUAL)                              \
                } else if (fm <= ym * ym) {                                                    \
                    KIFMM_KERNEL__YUKAWA_PASS(V, W, LOAD, STORE, SUB, MUL, FMADD, FNMADD, RINVM, \
                                              EXPM, GRAD, MUTUAL)                              \
                } else if (fm <= yl * yl) {                                                    \
                    KIFMM_KERNEL__YUKAWA_PASS(V, W, LOAD, STORE, SUB, MUL, FMADD, FNMADD, RINVM, \
                                              EXPL, GRAD, MUTUAL)                              \
                } else {                                                                       \
                    KIFMM_KERNEL__YUKAWA_PASS(V, W, LOAD, STORE, SUB, MUL, FMADD, FNMADD, RINVM, \
                                              EXPNV, GRAD, MUTUAL)                             \
                }                                                                              \
                KIFMM_KERNEL__ADD_A2(RED2, HSUM, GRAD)                                         \
            }                                                                                  \
            for (j = 0; (MUTUAL) && j < jb; j++)                                               \
                for (k = 0; k < TD_; k++) outb[TD_ * (j0 + j) + k] += s * po[k * SB_ + j];     \
        }                                                                                      \
    }
#if defined(__AVX512F__)
#define KIFMM_KERNEL__YUKAWA_D(G, M)                                                              \
    KIFMM_KERNEL__YUKAWA_BODY(__m512d, 8, _mm512_set1_pd, _mm512_setzero_pd(), _mm512_load_pd,  \
                              _mm512_store_pd, _mm512_sub_pd, _mm512_mul_pd, _mm512_fmadd_pd,  \
                              _mm512_fnmadd_pd, KIFMM_KERNEL__SRINV8, kifmm_kernel__expn8,     \
                              KIFMM_KERNEL__EXPS8, KIFMM_KERNEL__EXPM8, KIFMM_KERNEL__EXPL8,   \
                              kifmm_kernel__hsum8, kifmm_kernel__red8x8, G, M)
#define KIFMM_KERNEL__EXPS8(y) KIFMM_KERNEL__EXPS(_mm512_fnmadd_pd, _mm512_set1_pd, y)
#define KIFMM_KERNEL__EXPM8(y) KIFMM_KERNEL__EXPM(_mm512_fnmadd_pd, _mm512_set1_pd, y)
#define KIFMM_KERNEL__EXPL8(y) KIFMM_KERNEL__EXPL(_mm512_fnmadd_pd, _mm512_set1_pd, y)
#elif defined(__AVX2__) && defined(__FMA__)
#define KIFMM_KERNEL__YUKAWA_D(G, M)                                                              \
    KIFMM_KERNEL__YUKAWA_BODY(__m256d, 4, _mm256_set1_pd, _mm256_setzero_pd(), _mm256_load_pd,  \
                              _mm256_store_pd, _mm256_sub_pd, _mm256_mul_pd, _mm256_fmadd_pd,  \
                              _mm256_fnmadd_pd, kifmm_kernel__srinv4, kifmm_kernel__expn4,     \
                              KIFMM_KERNEL__EXPS4, KIFMM_KERNEL__EXPM4, KIFMM_KERNEL__EXPL4,   \
                              kifmm_kernel__shsum4, kifmm_kernel__red2, G, M)
#define KIFMM_KERNEL__EXPS4(y) KIFMM_KERNEL__EXPS(_mm256_fnmadd_pd, _mm256_set1_pd, y)
#define KIFMM_KERNEL__EXPM4(y) KIFMM_KERNEL__EXPM(_mm256_fnmadd_pd, _mm256_set1_pd, y)
#define KIFMM_KERNEL__EXPL4(y) KIFMM_KERNEL__EXPL(_mm256_fnmadd_pd, _mm256_set1_pd, y)
#else
#define KIFMM_KERNEL__S_FNMADD(a, b, c) ((c) - (a) * (b))
static inline double kifmm_kernel__expn1(double y) { return exp(-y); }
/* two points' four sums, one lane each */
static inline void kifmm_kernel__sred2(double a0, double a1, double a2, double a3, double c0,
                                       double c1, double c2, double c3, double s, double *o,
                                       int both)
{
    o[0] += s * a0;
    o[1] += s * a1;
    o[2] += s * a2;
    o[3] += s * a3;
    if (both) {
        o[4] += s * c0;
        o[5] += s * c1;
        o[6] += s * c2;
        o[7] += s * c3;
    }
}
#define KIFMM_KERNEL__YUKAWA_D(G, M)                                                           \
    KIFMM_KERNEL__YUKAWA_BODY(double, 1, KIFMM_KERNEL__S_SET1, 0.0, KIFMM_KERNEL__S_LOAD,        \
                              KIFMM_KERNEL__S_STORE, KIFMM_KERNEL__S_SUB, KIFMM_KERNEL__S_MUL, \
                              KIFMM_KERNEL__S_FMADD, KIFMM_KERNEL__S_FNMADD,                   \
                              kifmm_kernel__srinv1, kifmm_kernel__expn1, KIFMM_KERNEL__EXPS1,  \
                              KIFMM_KERNEL__EXPM1, KIFMM_KERNEL__EXPL1, KIFMM_KERNEL__S_SET1,  \
                              kifmm_kernel__sred2, G, M)
#define KIFMM_KERNEL__EXPS1(y) KIFMM_KERNEL__EXPS(KIFMM_KERNEL__S_FNMADD, KIFMM_KERNEL__S_SET1, y)
#define KIFMM_KERNEL__EXPM1(y) KIFMM_KERNEL__EXPM(KIFMM_KERNEL__S_FNMADD, KIFMM_KERNEL__S_SET1, y)
#define KIFMM_KERNEL__EXPL1(y) KIFMM_KERNEL__EXPL(KIFMM_KERNEL__S_FNMADD, KIFMM_KERNEL__S_SET1, y)
#endif
#define KIFMM_KERNEL__YUKAWA_HAS (KIFMM_HAS_SETUP | KIFMM_HAS_P2P | KIFMM_HAS_P2PS)
/* The one-way hooks run the mutual body without B's sums (targets as A). */
#define KIFMM_KERNEL__YUKAWA_P2P(name, G)                                                      \
    static inline void name(const double *param, const double *ax, const double *ay,           \
                            const double *az, int64_t na, const double *bx, const double *by,  \
                            const double *bz, const double *qb, int64_t nb, double scale,      \
                            double *outa)                                                      \
    {                                                                                          \
        const double *qa = NULL;                                                               \
        double *outb = NULL;                                                                   \
        KIFMM_KERNEL__YUKAWA_D(G, 0)                                                           \
        (void)qa;                                                                              \
        (void)outb;                                                                            \
    }
#define KIFMM_KERNEL__YUKAWA_P2PS(name, G)                                                     \
    static inline void name(const double *param, const double *ax, const double *ay,           \
                            const double *az, const double *qa, int64_t na, const double *bx,  \
                            const double *by, const double *bz, const double *qb, int64_t nb,  \
                            double scale, double *outa, double *outb)                          \
        KIFMM_KERNEL__YUKAWA_D(G, 1)
KIFMM_KERNEL__YUKAWA_P2P(kifmm_kernel_yukawa_p2p, 0)
KIFMM_KERNEL__YUKAWA_P2P(kifmm_kernel_yukawa_grad_p2p, 1)
KIFMM_KERNEL__YUKAWA_P2PS(kifmm_kernel_yukawa_p2ps, 0)
KIFMM_KERNEL__YUKAWA_P2PS(kifmm_kernel_yukawa_grad_p2ps, 1)
#undef KIFMM_KERNEL__YUKAWA_P2P
#undef KIFMM_KERNEL__YUKAWA_P2PS
#undef KIFMM_KERNEL__YUKAWA_D
#undef KIFMM_KERNEL__YUKAWA_BODY
#undef KIFMM_KERNEL__YUKAWA_PASS
#undef KIFMM_KERNEL__ADD_B3
#undef KIFMM_KERNEL__ADD_A2
#undef KIFMM_KERNEL__SUB_A2

/* ------------------------------------------------------------------------ */
/* One-way hooks of the Laplace family (charges, dipoles, Hessians), of the */
/* Yukawa dipole kernels, of the Stokes family and of Biot-Savart           */
/* ------------------------------------------------------------------------ */
/* outa[i * TD + k] += scale / (4 pi) sum_j (terms of pair (i, j))_k: the
 * sources in blocks of KIFMM_KERNEL__SSB points copied once into
 * structure-of-arrays on the stack (the densities arrive interleaved, QD_
 * per point); lanes past a block's end and coincident pairs get 1 / r = 0,
 * which zeroes every term. Each target keeps TD_ (<= 12) sums o0, o1, ... in
 * registers; PAIR
 * (with its flags P1, P2, P3) adds one vector of sources to them, from
 * d = a_i - b_j, 1 / r and the densities at q (component c at q + c SB). One body over the build's
 * vectors, as the Stokes hooks (AVX-512, AVX2 + FMA, portable C). */
#define KIFMM_KERNEL__OW_BODY(T, V, W, SET1, ZERO, LOAD, SUB, MUL, FMADD, FNMADD, RINVM, HSUM,    \
                              QD_, TD_, PAIR, P1, P2, P3)                                      \
    {                                                                                          \
        enum { SB_ = KIFMM_KERNEL__SSB, NB_ = KIFMM_KERNEL__SSB / (W) };                       \
        const T s = (T)((double)scale * KIFMM_INV_4PI);                                        \
        V vx[NB_], vy[NB_], vz[NB_], vq[(QD_) * NB_];                                          \
        T *px = (T *)vx, *py = (T *)vy, *pz = (T *)vz, *pq = (T *)vq;                          \
        int64_t i, j, j0, jb, k;                                                               \
        int c;                                                                                 \
        (void)param;                                                                           \
        for (j0 = 0; j0 < nb; j0 += SB_) {                                                     \
            jb = nb - j0 < SB_ ? nb - j0 : (int64_t)SB_;                                       \
            for (k = 0; k < SB_; k++) {                                                        \
                const int in = k < jb;                                                         \
                px[k] = in ? bx[j0 + k] : (T)0;                                                \
                py[k] = in ? by[j0 + k] : (T)0;                                                \
                pz[k] = in ? bz[j0 + k] : (T)0;                                                \
                for (c = 0; c < (QD_); c++) pq[c * SB_ + k] = in ? qb[(QD_) * (j0 + k) + c] : (T)0; \
            }                                                                                  \
            for (i = 0; i < na; i++) {                                                         \
                const V X = SET1(ax[i]), Y = SET1(ay[i]), Z = SET1(az[i]);                     \
                V o0 = ZERO, o1 = ZERO, o2 = ZERO, o3 = ZERO, o4 = ZERO, o5 = ZERO, o6 = ZERO; \
                V o7 = ZERO, o8 = ZERO, o9 = ZERO, o10 = ZERO, o11 = ZERO;                     \
                for (j = 0; j < jb; j += (W)) {                                                \
                    const V dx = SUB(X, LOAD(px + j)), dy = SUB(Y, LOAD(py + j));              \
                    const V dz = SUB(Z, LOAD(pz + j));                                         \
                    const V inv = RINVM(FMADD(dz, dz, FMADD(dy, dy, MUL(dx, dx))), jb - j);    \
                    PAIR(P1, P2, P3, T, V, dx, dy, dz, inv, pq + j, SB_, SET1, LOAD, SUB, MUL,  \
                         FMADD, FNMADD)                                                        \
                }                                                                              \
                {                                                                              \
                    T *oi = outa + (TD_) * i;                                                  \
                    const V ov[12] = {o0, o1, o2, o3, o4, o5, o6, o7, o8, o9, o10, o11};       \
                    for (c = 0; c < (TD_); c++) oi[c] += s * HSUM(ov[c]);                      \
                }                                                                              \
            }                                                                                  \
        }                                                                                      \
    }

/* A pair of the Laplace family (times 4 pi): charge q (CH) and dipole v
 * (DIP), ROWS outputs (1, 4, 10). With i3 = 1 / r^3, i5 = 1 / r^5:
 * potential q / r + (v . d) i3; gradient v i3 - d m1; Hessian d_a d_b m2 -
 * delta_ab m1 - 3 i5 (v_a d_b + v_b d_a), where m1 = q i3 + 3 (v . d) i5,
 * m2 = 3 q i5 + 15 (v . d) i7. */
#define KIFMM_KERNEL__LAP_PAIR(CH, DIP, ROWS, T, V, dx, dy, dz, inv, q, SB, SET1, LOAD, SUB,    \
                               MUL, FMADD, FNMADD)                                             \
    {                                                                                          \
        const V i2 = MUL(inv, inv), i3 = MUL(inv, i2);                                         \
        const V qc = (CH) ? LOAD(q) : SET1((T)0);                                              \
        const V v0 = (DIP) ? LOAD(q + (CH) * SB) : SET1((T)0);                                 \
        const V v1 = (DIP) ? LOAD(q + ((CH) + 1) * SB) : SET1((T)0);                           \
        const V v2 = (DIP) ? LOAD(q + ((CH) + 2) * SB) : SET1((T)0);                           \
        const V vd = (DIP) ? FMADD(dz, v2, FMADD(dy, v1, MUL(dx, v0))) : v0;                   \
        o0 = (DIP) ? FMADD(vd, i3, (CH) ? FMADD(qc, inv, o0) : o0) : FMADD(qc, inv, o0); \
        if ((ROWS) > 1) {                                                                      \
            const V m1 = (DIP) ? MUL(i3, FMADD(MUL(SET1((T)3), vd), i2, qc)) : MUL(qc, i3);    \
            o1 = FNMADD(dx, m1, (DIP) ? FMADD(v0, i3, o1) : o1);                         \
            o2 = FNMADD(dy, m1, (DIP) ? FMADD(v1, i3, o2) : o2);                         \
            o3 = FNMADD(dz, m1, (DIP) ? FMADD(v2, i3, o3) : o3);                         \
            if ((ROWS) > 4) {                                                                  \
                const V i5 = MUL(i3, i2), t3 = MUL(SET1((T)3), i5);                            \
                const V m2 = (DIP) ? MUL(i5, FMADD(MUL(SET1((T)15), vd), i2, MUL(SET1((T)3), qc))) \
                                   : MUL(MUL(SET1((T)3), qc), i5);                             \
                const V mx = MUL(m2, dx), my = MUL(m2, dy);                                    \
                o4 = SUB(FMADD(mx, dx, o4), m1);                                           \
                o5 = SUB(FMADD(my, dy, o5), m1);                                           \
                o6 = SUB(FMADD(MUL(m2, dz), dz, o6), m1);                                  \
                o7 = FMADD(mx, dy, o7);                                                    \
                o8 = FMADD(mx, dz, o8);                                                    \
                o9 = FMADD(my, dz, o9);                                                    \
                if (DIP) { /* - 3 i5 (v_a d_b + v_b d_a) */                                   \
                    const V w0 = MUL(t3, v0), w1 = MUL(t3, v1), w2 = MUL(t3, v2);              \
                    o4 = FNMADD(MUL(SET1((T)2), w0), dx, o4);                              \
                    o5 = FNMADD(MUL(SET1((T)2), w1), dy, o5);                              \
                    o6 = FNMADD(MUL(SET1((T)2), w2), dz, o6);                              \
                    o7 = FNMADD(w0, dy, FNMADD(w1, dx, o7));                               \
                    o8 = FNMADD(w0, dz, FNMADD(w2, dx, o8));                               \
                    o9 = FNMADD(w1, dz, FNMADD(w2, dy, o9));                               \
                }                                                                              \
            }                                                                                  \
        }                                                                                      \
    }

/* A pair of Biot-Savart (times 4 pi): strength a, c = a x d; velocity c i3;
 * with GRAD its gradient du_i/dy_j = eps_ilj a_l i3 - 3 c_i d_j i5 */
#define KIFMM_KERNEL__BS_PAIR(GRAD, U1, U2, T, V, dx, dy, dz, inv, q, SB, SET1, LOAD, SUB,      \
                              MUL, FMADD, FNMADD)                                              \
    {                                                                                          \
        const V a0 = LOAD(q), a1 = LOAD(q + (SB)), a2 = LOAD(q + 2 * (SB));                    \
        const V i2 = MUL(inv, inv), i3 = MUL(inv, i2);                                         \
        const V cx = FNMADD(a2, dy, MUL(a1, dz)), cy = FNMADD(a0, dz, MUL(a2, dx));            \
        const V cz = FNMADD(a1, dx, MUL(a0, dy));                                              \
        o0 = FMADD(cx, i3, o0);                                                            \
        o1 = FMADD(cy, i3, o1);                                                            \
        o2 = FMADD(cz, i3, o2);                                                            \
        if (GRAD) {                                                                            \
            const V i5 = MUL(MUL(SET1((T)3), i3), i2);                                         \
            const V tx = MUL(cx, i5), ty = MUL(cy, i5), tz = MUL(cz, i5);                      \
            o3 = FNMADD(tx, dx, o3);                                                       \
            o4 = FNMADD(tx, dy, FNMADD(a2, i3, o4));                                       \
            o5 = FNMADD(tx, dz, FMADD(a1, i3, o5));                                        \
            o6 = FNMADD(ty, dx, FMADD(a2, i3, o6));                                        \
            o7 = FNMADD(ty, dy, o7);                                                       \
            o8 = FNMADD(ty, dz, FNMADD(a0, i3, o8));                                       \
            o9 = FNMADD(tz, dx, FNMADD(a1, i3, o9));                                       \
            o10 = FNMADD(tz, dy, FMADD(a0, i3, o10));                                      \
            o11 = FNMADD(tz, dz, o11);                                                     \
        }                                                                                      \
    }
/* Pairs of the Stokes family (times 4 pi; hv = 1 / (2 mu), mu = param[0], or
 * 1 / 2 where the kernel fixes mu = 1): G f = hv (f / r + d (f . d) / r^3).
 *   PVEL  f -> (p, u): p = f . d / r^3 (MU: mu = param[0], else 1)
 *   SGRAD f -> (u, du_i/dy_j): hv ((delta_ij (f . d) + d_i f_j - f_i d_j) /
 *         r^3 - 3 (f . d) d_i d_j / r^5)
 *   DL    D = q n (9) -> u = -3 (d . D d) d / r^5
 *   PLST  (c, f) -> (c / r, G f) (MODE 0, stokes_pvel's surfaces) or
 *         -c d / r^3 + G f at mu = 1 (MODE 1, stokes_dl's)
 *   DLQC  D -> (tr D / r, -3 (d . D d) d / r^5 + tr D d / r^3)
 *   L3    a -> a / r (three Laplace charges) */
#define KIFMM_KERNEL__STK_F3(V, q, SB, LOAD)                                                     \
    const V f0 = LOAD(q), f1 = LOAD((q) + (SB)), f2 = LOAD((q) + 2 * (SB))
#define KIFMM_KERNEL__PVEL_PAIR(MU, U1, U2, T, V, dx, dy, dz, inv, q, SB, SET1, LOAD, SUB, MUL,  \
                                FMADD, FNMADD)                                                 \
    {                                                                                          \
        KIFMM_KERNEL__STK_F3(V, q, SB, LOAD);                                                     \
        const V i3 = MUL(inv, MUL(inv, inv)), fd = FMADD(dz, f2, FMADD(dy, f1, MUL(dx, f0)));  \
        const V hv = SET1((T)((MU) ? 0.5 / param[0] : 0.5));                                   \
        const V t = MUL(hv, MUL(fd, i3)), hi = MUL(hv, inv);                                   \
        o0 = FMADD(fd, i3, o0);                                                                \
        o1 = FMADD(f0, hi, FMADD(dx, t, o1));                                                  \
        o2 = FMADD(f1, hi, FMADD(dy, t, o2));                                                  \
        o3 = FMADD(f2, hi, FMADD(dz, t, o3));                                                  \
    }
#define KIFMM_KERNEL__SGRAD_PAIR(U0, U1, U2, T, V, dx, dy, dz, inv, q, SB, SET1, LOAD, SUB, MUL, \
                                 FMADD, FNMADD)                                                \
    {                                                                                          \
        KIFMM_KERNEL__STK_F3(V, q, SB, LOAD);                                                     \
        const V i2 = MUL(inv, inv), fd = FMADD(dz, f2, FMADD(dy, f1, MUL(dx, f0)));            \
        const V hv = SET1((T)(0.5 / param[0]));                                                \
        const V a = MUL(hv, MUL(inv, i2)), hi = MUL(hv, inv), afd = MUL(a, fd);                \
        const V b = MUL(MUL(SET1((T)3), afd), i2);                                             \
        const V bx = MUL(b, dx), by = MUL(b, dy), bz = MUL(b, dz);                             \
        const V w01 = FNMADD(f0, dy, MUL(dx, f1)), w02 = FNMADD(f0, dz, MUL(dx, f2));          \
        const V w12 = FNMADD(f1, dz, MUL(dy, f2));                                             \
        o0 = FMADD(f0, hi, FMADD(dx, afd, o0));                                                \
        o1 = FMADD(f1, hi, FMADD(dy, afd, o1));                                                \
        o2 = FMADD(f2, hi, FMADD(dz, afd, o2));                                                \
        o3 = FNMADD(bx, dx, FMADD(a, fd, o3));                                                 \
        o4 = FNMADD(bx, dy, FMADD(a, w01, o4));                                                \
        o5 = FNMADD(bx, dz, FMADD(a, w02, o5));                                                \
        o6 = FNMADD(bx, dy, FNMADD(a, w01, o6));                                               \
        o7 = FNMADD(by, dy, FMADD(a, fd, o7));                                                 \
        o8 = FNMADD(by, dz, FMADD(a, w12, o8));                                                \
        o9 = FNMADD(bx, dz, FNMADD(a, w02, o9));                                               \
        o10 = FNMADD(by, dz, FNMADD(a, w12, o10));                                             \
        o11 = FNMADD(bz, dz, FMADD(a, fd, o11));                                               \
    }
/* s = d . D d and tr D of the 9 products at q (D_jk at q + (3 j + k) SB) */
#define KIFMM_KERNEL__DDD(V, q, SB, LOAD, MUL, FMADD)                                           \
    const V e0 = FMADD(LOAD((q) + 2 * (SB)), dz, FMADD(LOAD((q) + (SB)), dy, MUL(LOAD(q), dx))); \
    const V e1 = FMADD(LOAD((q) + 5 * (SB)), dz,                                              \
                       FMADD(LOAD((q) + 4 * (SB)), dy, MUL(LOAD((q) + 3 * (SB)), dx)));         \
    const V e2 = FMADD(LOAD((q) + 8 * (SB)), dz,                                              \
                       FMADD(LOAD((q) + 7 * (SB)), dy, MUL(LOAD((q) + 6 * (SB)), dx)));         \
    const V sd = FMADD(dz, e2, FMADD(dy, e1, MUL(dx, e0)))
#define KIFMM_KERNEL__DL_PAIR(QC, U1, U2, T, V, dx, dy, dz, inv, q, SB, SET1, LOAD, SUB, MUL,    \
                              FMADD, FNMADD)                                                   \
    {                                                                                          \
        KIFMM_KERNEL__DDD(V, q, SB, LOAD, MUL, FMADD);                                            \
        const V i2 = MUL(inv, inv), i3 = MUL(inv, i2);                                         \
        const V tr = (QC) ? FMADD(SET1((T)1), LOAD((q) + 8 * (SB)),                            \
                                  FMADD(SET1((T)1), LOAD((q) + 4 * (SB)), LOAD(q)))            \
                          : SET1((T)0);                                                        \
        /* -3 s / r^5, and with QC + tr D / r^3 */                                             \
        const V m = (QC) ? FNMADD(MUL(SET1((T)3), sd), MUL(i3, i2), MUL(tr, i3))               \
                         : MUL(MUL(SET1((T)-3), sd), MUL(i3, i2));                             \
        if (QC) {                                                                              \
            o0 = FMADD(tr, inv, o0);                                                           \
            o1 = FMADD(m, dx, o1);                                                             \
            o2 = FMADD(m, dy, o2);                                                             \
            o3 = FMADD(m, dz, o3);                                                             \
        } else {                                                                               \
            o0 = FMADD(m, dx, o0);                                                             \
            o1 = FMADD(m, dy, o1);                                                             \
            o2 = FMADD(m, dz, o2);                                                             \
        }                                                                                      \
        (void)e0, (void)e1, (void)e2;                                                          \
    }
#define KIFMM_KERNEL__PLST_PAIR(MODE, U1, U2, T, V, dx, dy, dz, inv, q, SB, SET1, LOAD, SUB, MUL, \
                                FMADD, FNMADD)                                                 \
    {                                                                                          \
        const V c = LOAD(q);                                                                   \
        KIFMM_KERNEL__STK_F3(V, (q) + (SB), SB, LOAD);                                            \
        const V i3 = MUL(inv, MUL(inv, inv)), fd = FMADD(dz, f2, FMADD(dy, f1, MUL(dx, f0)));  \
        const V hv = SET1((T)((MODE) ? 0.5 : 0.5 / param[0]));                                 \
        const V hi = MUL(hv, inv);                                                             \
        const V t = (MODE) ? FNMADD(c, i3, MUL(hv, MUL(fd, i3))) : MUL(hv, MUL(fd, i3));       \
        if (MODE) {                                                                            \
            o0 = FMADD(f0, hi, FMADD(dx, t, o0));                                              \
            o1 = FMADD(f1, hi, FMADD(dy, t, o1));                                              \
            o2 = FMADD(f2, hi, FMADD(dz, t, o2));                                              \
        } else {                                                                               \
            o0 = FMADD(c, inv, o0);                                                            \
            o1 = FMADD(f0, hi, FMADD(dx, t, o1));                                              \
            o2 = FMADD(f1, hi, FMADD(dy, t, o2));                                              \
            o3 = FMADD(f2, hi, FMADD(dz, t, o3));                                              \
        }                                                                                      \
    }
#define KIFMM_KERNEL__L3_PAIR(U0, U1, U2, T, V, dx, dy, dz, inv, q, SB, SET1, LOAD, SUB, MUL,    \
                              FMADD, FNMADD)                                                   \
    {                                                                                          \
        o0 = FMADD(LOAD(q), inv, o0);                                                          \
        o1 = FMADD(LOAD((q) + (SB)), inv, o1);                                                 \
        o2 = FMADD(LOAD((q) + 2 * (SB)), inv, o2);                                             \
    }
/* A pair of yukawa_cd (ROWS 1) or yukawa_cd_grad (ROWS 4), times 4 pi, in
 * double (EXPN(y) = exp(-y) over the build's vectors), lambda = param[0]:
 * with e = exp(-lambda r), c1 = e (1 + lambda r) / r^3 and c3 = e (3 + 3
 * lambda r + lambda^2 r^2) / r^5: potential q e / r + (v . d) c1, gradient
 * v c1 - d (q c1 + (v . d) c3). Lanes with 1 / r = 0 give r = 0, e = 1 and
 * every term 0. */
#define KIFMM_KERNEL__YCD_PAIR(ROWS, EXPN, U2, T, V, dx, dy, dz, inv, q, SB, SET1, LOAD, SUB,  \
                               MUL, FMADD, FNMADD)                                             \
    {                                                                                          \
        const V qc = LOAD(q), v0 = LOAD((q) + (SB)), v1 = LOAD((q) + 2 * (SB));                \
        const V v2 = LOAD((q) + 3 * (SB)), i2 = MUL(inv, inv);                                 \
        const V lr = MUL(SET1((T)param[0]), MUL(FMADD(dz, dz, FMADD(dy, dy, MUL(dx, dx))), inv)); \
        const V ei = MUL(EXPN(lr), inv), one = SET1((T)1);                                     \
        const V c1 = MUL(MUL(ei, i2), FMADD(one, lr, one));                                    \
        const V vd = FMADD(dz, v2, FMADD(dy, v1, MUL(dx, v0)));                                \
        o0 = FMADD(vd, c1, FMADD(qc, ei, o0));                                                 \
        if ((ROWS) > 1) {                                                                      \
            const V c3 = MUL(MUL(ei, MUL(i2, i2)),                                             \
                             FMADD(lr, FMADD(one, lr, SET1((T)3)), SET1((T)3)));               \
            const V m = FMADD(vd, c3, MUL(qc, c1));                                            \
            o1 = FNMADD(dx, m, FMADD(v0, c1, o1));                                             \
            o2 = FNMADD(dy, m, FMADD(v1, c1, o2));                                             \
            o3 = FNMADD(dz, m, FMADD(v2, c1, o3));                                             \
        }                                                                                      \
    }
#if defined(__AVX512F__)
#define KIFMM_KERNEL__EXPN kifmm_kernel__expn8
#define KIFMM_KERNEL__OW_D(QD, TD, PAIR, P1, P2, P3)                                            \
    KIFMM_KERNEL__OW_BODY(double, __m512d, 8, _mm512_set1_pd, _mm512_setzero_pd(),             \
                          _mm512_load_pd, _mm512_sub_pd, _mm512_mul_pd, _mm512_fmadd_pd,       \
                          _mm512_fnmadd_pd, KIFMM_KERNEL__SRINV8, kifmm_kernel__hsum8, QD, TD, \
                          PAIR, P1, P2, P3)
#define KIFMM_KERNEL__OW_F(QD, TD, PAIR, P1, P2, P3)                                            \
    KIFMM_KERNEL__OW_BODY(float, __m512, 16, _mm512_set1_ps, _mm512_setzero_ps(),              \
                          _mm512_load_ps, _mm512_sub_ps, _mm512_mul_ps, _mm512_fmadd_ps,       \
                          _mm512_fnmadd_ps, KIFMM_KERNEL__SRINV16, kifmm_kernel__hsum16, QD,   \
                          TD, PAIR, P1, P2, P3)
#elif defined(__AVX2__) && defined(__FMA__)
#define KIFMM_KERNEL__EXPN kifmm_kernel__expn4
#define KIFMM_KERNEL__OW_D(QD, TD, PAIR, P1, P2, P3)                                            \
    KIFMM_KERNEL__OW_BODY(double, __m256d, 4, _mm256_set1_pd, _mm256_setzero_pd(),             \
                          _mm256_load_pd, _mm256_sub_pd, _mm256_mul_pd, _mm256_fmadd_pd,       \
                          _mm256_fnmadd_pd, kifmm_kernel__srinv4, kifmm_kernel__shsum4, QD,    \
                          TD, PAIR, P1, P2, P3)
#define KIFMM_KERNEL__OW_F(QD, TD, PAIR, P1, P2, P3)                                            \
    KIFMM_KERNEL__OW_BODY(float, __m256, 8, _mm256_set1_ps, _mm256_setzero_ps(),               \
                          _mm256_load_ps, _mm256_sub_ps, _mm256_mul_ps, _mm256_fmadd_ps,       \
                          _mm256_fnmadd_ps, kifmm_kernel__srinv8f, kifmm_kernel__shsum8f, QD,  \
                          TD, PAIR, P1, P2, P3)
#else
#define KIFMM_KERNEL__EXPN kifmm_kernel__expn1
#define KIFMM_KERNEL__OW_D(QD, TD, PAIR, P1, P2, P3)                                            \
    KIFMM_KERNEL__OW_BODY(double, double, 1, KIFMM_KERNEL__S_SET1, 0.0, KIFMM_KERNEL__S_LOAD,   \
                          KIFMM_KERNEL__S_SUB, KIFMM_KERNEL__S_MUL, KIFMM_KERNEL__S_FMADD,     \
                          KIFMM_KERNEL__S_FNMADD, kifmm_kernel__srinv1, KIFMM_KERNEL__S_SET1,  \
                          QD, TD, PAIR, P1, P2, P3)
#define KIFMM_KERNEL__OW_F(QD, TD, PAIR, P1, P2, P3)                                            \
    KIFMM_KERNEL__OW_BODY(float, float, 1, KIFMM_KERNEL__S_SET1, 0.0f, KIFMM_KERNEL__S_LOAD,    \
                          KIFMM_KERNEL__S_SUB, KIFMM_KERNEL__S_MUL, KIFMM_KERNEL__S_FMADD,     \
                          KIFMM_KERNEL__S_FNMADD, kifmm_kernel__srinv1f, KIFMM_KERNEL__S_SET1, \
                          QD, TD, PAIR, P1, P2, P3)
#endif
#define KIFMM_KERNEL__OW_P2P(name, T, BODY)                                                    \
    static inline void name(const double *param, const T *ax, const T *ay, const T *az,        \
                            int64_t na, const T *bx, const T *by, const T *bz, const T *qb,    \
                            int64_t nb, T scale, T *outa)                                      \
        BODY
#define KIFMM_KERNEL__OW_BOTH(name, QD, TD, PAIR, P1, P2, P3)                                  \
    KIFMM_KERNEL__OW_P2P(name##_p2p, double, KIFMM_KERNEL__OW_D(QD, TD, PAIR, P1, P2, P3))    \
    KIFMM_KERNEL__OW_P2P(name##_p2pf, float, KIFMM_KERNEL__OW_F(QD, TD, PAIR, P1, P2, P3))
KIFMM_KERNEL__OW_BOTH(kifmm_kernel_laplace_dipole, 3, 1, KIFMM_KERNEL__LAP_PAIR, 0, 1, 1)
KIFMM_KERNEL__OW_BOTH(kifmm_kernel_laplace_dipole_grad, 3, 4, KIFMM_KERNEL__LAP_PAIR, 0, 1, 4)
KIFMM_KERNEL__OW_BOTH(kifmm_kernel_laplace_cd, 4, 1, KIFMM_KERNEL__LAP_PAIR, 1, 1, 1)
KIFMM_KERNEL__OW_BOTH(kifmm_kernel_laplace_cd_grad, 4, 4, KIFMM_KERNEL__LAP_PAIR, 1, 1, 4)
KIFMM_KERNEL__OW_BOTH(kifmm_kernel_laplace_hess, 1, 10, KIFMM_KERNEL__LAP_PAIR, 1, 0, 10)
KIFMM_KERNEL__OW_BOTH(kifmm_kernel_laplace_cd_hess, 4, 10, KIFMM_KERNEL__LAP_PAIR, 1, 1, 10)
KIFMM_KERNEL__OW_BOTH(kifmm_kernel_biot_savart, 3, 3, KIFMM_KERNEL__BS_PAIR, 0, 0, 0)
KIFMM_KERNEL__OW_BOTH(kifmm_kernel_biot_savart_grad, 3, 12, KIFMM_KERNEL__BS_PAIR, 1, 0, 0)
KIFMM_KERNEL__OW_BOTH(kifmm_kernel__laplace3, 3, 3, KIFMM_KERNEL__L3_PAIR, 0, 0, 0)
KIFMM_KERNEL__OW_P2P(kifmm_kernel_yukawa_cd_p2p, double,
                     KIFMM_KERNEL__OW_D(4, 1, KIFMM_KERNEL__YCD_PAIR, 1, KIFMM_KERNEL__EXPN, 0))
KIFMM_KERNEL__OW_P2P(kifmm_kernel_yukawa_cd_grad_p2p, double,
                     KIFMM_KERNEL__OW_D(4, 4, KIFMM_KERNEL__YCD_PAIR, 4, KIFMM_KERNEL__EXPN, 0))
KIFMM_KERNEL__OW_BOTH(kifmm_kernel_stokes_pvel, 3, 4, KIFMM_KERNEL__PVEL_PAIR, 1, 0, 0)
KIFMM_KERNEL__OW_BOTH(kifmm_kernel__stokes_pvel_qc, 3, 4, KIFMM_KERNEL__PVEL_PAIR, 0, 0, 0)
KIFMM_KERNEL__OW_BOTH(kifmm_kernel__stokes_pvel_st, 4, 4, KIFMM_KERNEL__PLST_PAIR, 0, 0, 0)
KIFMM_KERNEL__OW_BOTH(kifmm_kernel__stokes_dl_st, 4, 3, KIFMM_KERNEL__PLST_PAIR, 1, 0, 0)
KIFMM_KERNEL__OW_BOTH(kifmm_kernel_stokes_grad, 3, 12, KIFMM_KERNEL__SGRAD_PAIR, 0, 0, 0)
KIFMM_KERNEL__OW_BOTH(kifmm_kernel_stokes_dl, 9, 3, KIFMM_KERNEL__DL_PAIR, 0, 0, 0)
KIFMM_KERNEL__OW_BOTH(kifmm_kernel__stokes_dl_qc, 9, 4, KIFMM_KERNEL__DL_PAIR, 1, 0, 0)
#undef KIFMM_KERNEL__OW_BOTH
#undef KIFMM_KERNEL__OW_P2P
#undef KIFMM_KERNEL__OW_D
#undef KIFMM_KERNEL__OW_F
#undef KIFMM_KERNEL__BS_PAIR
#undef KIFMM_KERNEL__STK_F3
#undef KIFMM_KERNEL__PVEL_PAIR
#undef KIFMM_KERNEL__SGRAD_PAIR
#undef KIFMM_KERNEL__DDD
#undef KIFMM_KERNEL__DL_PAIR
#undef KIFMM_KERNEL__PLST_PAIR
#undef KIFMM_KERNEL__L3_PAIR
#undef KIFMM_KERNEL__YCD_PAIR
#undef KIFMM_KERNEL__EXPN
#undef KIFMM_KERNEL__LAP_PAIR
#undef KIFMM_KERNEL__OW_BODY
#define KIFMM_KERNEL__OW_HAS (KIFMM_HAS_P2P | KIFMM_HAS_P2PF)

/* The Laplace kernels' hooks that this build compiled: all of them with
 * AVX2 and FMA (or AVX-512), the one-way double and float hooks of the vector
 * layer on aarch64, the one-way double loop otherwise. */
#if defined(__AVX2__) && defined(__FMA__)
#define KIFMM_KERNEL__LAPLACE_HAS                                                            \
    (KIFMM_HAS_P2P | KIFMM_HAS_P2PF | KIFMM_HAS_P2PN | KIFMM_HAS_P2PNF | KIFMM_HAS_P2PS |     \
     KIFMM_HAS_P2PSF | KIFMM_HAS_P2PSN | KIFMM_HAS_P2PSNF)
#elif defined(KIFMM_KERNEL__NEON)
#define KIFMM_KERNEL__LAPLACE_HAS (KIFMM_HAS_P2P | KIFMM_HAS_P2PF) /* the vector layer's */
#else
#define KIFMM_KERNEL__LAPLACE_HAS (KIFMM_HAS_P2P)
#endif
#define kifmm_kernel_laplace_HAS (KIFMM_KERNEL__LAPLACE_HAS | KIFMM_HAS_RADIAL | KIFMM_KERNEL__PER)
#define kifmm_kernel_laplace_grad_HAS (KIFMM_KERNEL__LAPLACE_HAS | KIFMM_HAS_BACKGROUND | KIFMM_HAS_TOL)
#define kifmm_kernel_laplace_grad_TOL_ERRORS KIFMM_KERNEL__TOL_GRAD

#if defined(__GNUC__) && !defined(__clang__) && defined(__cplusplus)
#pragma GCC diagnostic pop
#endif

#endif /* KIFMM_KERNELS_H */
