/* tests/ewald.h - Ewald sums, the references of the periodic tests
 *
 * t_ewald_laplace: the potential of charges q_j at x_j and all their images
 * x_j + n L (n in Z^3, a cubic cell of side L) under K = 1 / (4 pi r), and
 * its gradient with respect to the target, at nt targets: out[4 i] the
 * potential, out[4 i + 1 .. 3] the gradient. Conventions:
 *   - tin-foil (conducting) boundary: the reciprocal sum leaves out k = 0,
 *     so no term depends on the dipole moment of the cell;
 *   - a nonzero total charge Q gets a uniform neutralising background of
 *     density -Q / L^3 (its potential, -Q / (4 alpha^2 L^3) after the
 *     splitting, makes the sum independent of alpha);
 *   - so the potential has zero mean over the cell;
 *   - a target at a source's position leaves that source's own term (n = 0)
 *     out; its images stay.
 * Split at alpha: real space sum_{j, n} q_j erfc(alpha r) / (4 pi r) over
 * r = |x - x_j - n L| < rc, erfc(alpha rc) ~ tol; reciprocal space
 * (1 / L^3) sum_{k != 0} exp(-k^2 / (4 alpha^2)) / k^2 Re(S(k) e^{i k.x}),
 * S(k) = sum_j q_j e^{-i k.x_j}, k = 2 pi m / L, |m_a| <= mmax. The sums
 * run in long double. Written from the formulas (Ewald 1921; e.g. Frenkel
 * and Smit, Understanding Molecular Simulation, ch. 12, with 1 / (4 pi r)
 * in place of 1 / r). */
#ifndef KIFMM_TESTS_EWALD_H
#define KIFMM_TESTS_EWALD_H

#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#define T_EW_PI 3.141592653589793238462643383279503L

/* alpha * L and the reach of both sums for a relative accuracy tol */
typedef struct {
    double alpha, rc;
    int mmax, nimg; /* |m_a| <= mmax; real-space images |n_a| <= nimg */
} t_ewald_split;

static inline t_ewald_split t_ewald_plan(double L, double aL, double tol)
{
    t_ewald_split s;
    const double x = sqrt(-log(tol)); /* erfc(x) ~ exp(-x^2) / (x sqrt(pi)) */
    s.alpha = aL / L;
    s.rc = (x + 0.5) / s.alpha;
    s.mmax = (int)ceil(2.0 * s.alpha * (x + 0.5) * L / (2.0 * (double)T_EW_PI)) + 1;
    s.nimg = (int)ceil(s.rc / L) + 1;
    return s;
}

/* The offsets x - y - n L over the split's block of images n (|n_a| <=
 * nimg) that are shorter than rc, into dv[3 k ..] (room for (2 nimg + 1)^3);
 * returns their number; *self is set if one of them is 0 (left out). */
static inline int t_ew_near(const double *x, const double *y, double L, t_ewald_split sp,
                            long double *dv, int *self)
{
    int nx, ny, nz, k = 0;
    *self = 0;
    for (nx = -sp.nimg; nx <= sp.nimg; nx++)
        for (ny = -sp.nimg; ny <= sp.nimg; ny++)
            for (nz = -sp.nimg; nz <= sp.nimg; nz++) {
                const long double d0 = (long double)x[0] - y[0] - (long double)nx * L;
                const long double d1 = (long double)x[1] - y[1] - (long double)ny * L;
                const long double d2 = (long double)x[2] - y[2] - (long double)nz * L;
                const long double r2 = d0 * d0 + d1 * d1 + d2 * d2;
                if (r2 == 0.0L) *self = 1;
                if (r2 == 0.0L || r2 >= (long double)sp.rc * sp.rc) continue;
                dv[3 * k] = d0, dv[3 * k + 1] = d1, dv[3 * k + 2] = d2;
                k++;
            }
    return k;
}

/* Adds w[0 .. nw - 1] e^{-i k.x} (k = 2 pi m / L, |m_a| <= mm) to the
 * structure factors (sr, si)[nw at + c], at = the index of m; the phases
 * from one table of e^{-i k_a x_a} per axis. */
static inline void t_ew_factor(const double *x, double L, int mm, const double *w, int nw,
                               long double *sr, long double *si)
{
    const int nm = 2 * mm + 1;
    long double *ec = (long double *)malloc(6 * (size_t)nm * sizeof(long double)), *es = ec + 3 * nm;
    int a, mx, my, mz, c;
    size_t at = 0;
    for (a = 0; a < 3; a++)
        for (mx = -mm; mx <= mm; mx++) {
            const long double ph = 2.0L * T_EW_PI / L * mx * (long double)x[a];
            ec[a * nm + mx + mm] = cosl(ph);
            es[a * nm + mx + mm] = -sinl(ph);
        }
    for (mx = 0; mx < nm; mx++)
        for (my = 0; my < nm; my++) {
            const long double r1 = ec[mx] * ec[nm + my] - es[mx] * es[nm + my];
            const long double i1 = ec[mx] * es[nm + my] + es[mx] * ec[nm + my];
            for (mz = 0; mz < nm; mz++, at++) {
                const long double re = r1 * ec[2 * nm + mz] - i1 * es[2 * nm + mz];
                const long double im = r1 * es[2 * nm + mz] + i1 * ec[2 * nm + mz];
                for (c = 0; c < nw; c++) {
                    sr[nw * at + c] += w[c] * re;
                    si[nw * at + c] += w[c] * im;
                }
            }
        }
    free(ec);
}

static inline void t_ewald_laplace_split(int64_t ns, const double *xs, const double *q, int64_t nt,
                                  const double *xt, double L, t_ewald_split sp, double *out)
{
    const long double a = sp.alpha, V = (long double)L * L * L, four_pi = 4.0L * T_EW_PI;
    const int mm = sp.mmax, nm = 2 * mm + 1;
    long double Q = 0.0L;
    long double *sr = (long double *)calloc((size_t)nm * nm * nm, sizeof(long double));
    long double *si = (long double *)calloc((size_t)nm * nm * nm, sizeof(long double));
    int64_t i, j;
    const size_t nb = (size_t)(2 * sp.nimg + 1) * (2 * sp.nimg + 1) * (2 * sp.nimg + 1);
    long double *dv = (long double *)malloc(3 * nb * sizeof(long double));
    int mx, my, mz, d;
    for (j = 0; j < ns; j++) Q += q[j];
    /* structure factors S(m) = sum_j q_j e^{-i k.x_j} */
    for (j = 0; j < ns; j++) t_ew_factor(xs + 3 * j, L, mm, q + j, 1, sr, si);
    for (i = 0; i < nt; i++) {
        const double *x = xt + 3 * i;
        long double p = 0.0L, g[3] = {0.0L, 0.0L, 0.0L};
        /* real space */
        for (j = 0; j < ns; j++) {
            int self, k;
            const int nk = t_ew_near(x, xs + 3 * j, L, sp, dv, &self);
            if (self) p -= q[j] * 2.0L * a / sqrtl(T_EW_PI) / four_pi; /* its smeared part */
            for (k = 0; k < nk; k++) {
                const long double *v = dv + 3 * k, r2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
                const long double r = sqrtl(r2), e = erfcl(a * r) / r;
                const long double c = (e + 2.0L * a / sqrtl(T_EW_PI) * expl(-a * a * r2)) / r2;
                p += q[j] * e / four_pi;
                for (d = 0; d < 3; d++) g[d] -= q[j] * c * v[d] / four_pi;
            }
        }
        /* reciprocal space */
        for (mx = -mm; mx <= mm; mx++)
            for (my = -mm; my <= mm; my++)
                for (mz = -mm; mz <= mm; mz++) {
                    const size_t at = ((size_t)(mx + mm) * nm + (size_t)(my + mm)) * nm + (size_t)(mz + mm);
                    const long double kx = 2.0L * T_EW_PI / L * mx, ky = 2.0L * T_EW_PI / L * my;
                    const long double kz = 2.0L * T_EW_PI / L * mz, k2 = kx * kx + ky * ky + kz * kz;
                    long double w, ph, re, im;
                    if (mx == 0 && my == 0 && mz == 0) continue;
                    w = expl(-k2 / (4.0L * a * a)) / k2 / V;
                    ph = kx * x[0] + ky * x[1] + kz * x[2];
                    re = sr[at] * cosl(ph) - si[at] * sinl(ph); /* Re(S e^{i k.x}) */
                    im = sr[at] * sinl(ph) + si[at] * cosl(ph);
                    p += w * re;
                    g[0] -= w * kx * im;
                    g[1] -= w * ky * im;
                    g[2] -= w * kz * im;
                }
        p -= Q / (4.0L * a * a * V); /* the background */
        out[4 * i] = (double)p;
        for (d = 0; d < 3; d++) out[4 * i + 1 + d] = (double)g[d];
    }
    free(sr);
    free(si);
    free(dv);
}

/* The sums at the default split (alpha L = 5, relative accuracy 1e-15). */
static inline void t_ewald_laplace(int64_t ns, const double *xs, const double *q, int64_t nt,
                            const double *xt, double L, double *out)
{
    t_ewald_laplace_split(ns, xs, q, nt, xt, L, t_ewald_plan(L, 5.0, 1e-15), out);
}

/* t_ewald2d_laplace: the potential, under K = 1 / (4 pi r), of charges q_j
 * at x_j summing to zero and all their images x_j + (n1 L, n2 L, 0) (a
 * square cell of side L, periodic in x and y, free in z), at nt targets
 * (out[i]); a target at a source's position leaves that source's own term
 * out. Ewald's split for two periodic directions (Parry 1975; e.g. Frenkel
 * and Smit, ch. 12, or Grzybowski et al. 2000), at alpha: real space
 * sum erfc(alpha r) / r over in-plane images within rc; reciprocal space
 * (pi / A) sum_{k != 0} cos(k.rho) / |k| [e^{|k| z} erfc(|k| / (2 alpha) +
 * alpha z) + e^{-|k| z} erfc(|k| / (2 alpha) - alpha z)] with rho, z the
 * in-plane and normal parts of the offset, k = 2 pi m / L; and the k = 0
 * term of a neutral cell, -(2 pi / A) [z erf(alpha z) + e^{-alpha^2 z^2} /
 * (alpha sqrt(pi))]. The sums run in long double. */
static inline void t_ewald2d_split(int64_t ns, const double *xs, const double *q, int64_t nt,
                            const double *xt, double L, t_ewald_split sp, double *out)
{
    const long double a = sp.alpha, A = (long double)L * L, pi = T_EW_PI;
    const long double spi = sqrtl(pi);
    long double *br = (long double *)calloc((size_t)2 * sp.mmax * sp.mmax + 1, sizeof(long double));
    long double *cx = (long double *)calloc((size_t)4 * (sp.mmax + 1), sizeof(long double));
    long double *sx = cx + sp.mmax + 1, *cy = sx + sp.mmax + 1, *sy = cy + sp.mmax + 1;
    int64_t i, j;
    for (i = 0; i < nt; i++) {
        long double p = 0.0L;
        for (j = 0; j < ns; j++) {
            const long double dx = (long double)xt[3 * i] - xs[3 * j];
            const long double dy = (long double)xt[3 * i + 1] - xs[3 * j + 1];
            const long double z = (long double)xt[3 * i + 2] - xs[3 * j + 2];
            long double s = 0.0L;
            int n1, n2;
            for (n1 = -sp.nimg; n1 <= sp.nimg; n1++)
                for (n2 = -sp.nimg; n2 <= sp.nimg; n2++) {
                    const long double ux = dx + n1 * (long double)L, uy = dy + n2 * (long double)L;
                    const long double r = sqrtl(ux * ux + uy * uy + z * z);
                    if (r == 0.0L) s -= 2.0L * a / spi; /* the source's own term left out */
                    else if (r < sp.rc) s += erfcl(a * r) / r;
                }
            /* cos(k.rho) from the cosines and sines of each direction; the
             * bracket depends on |k| alone: once per n1^2 + n2^2 */
            for (n1 = 0; n1 <= 2 * sp.mmax * sp.mmax; n1++) br[n1] = -1.0L;
            for (n1 = 0; n1 <= sp.mmax; n1++) {
                cx[n1] = cosl(2.0L * pi * n1 * dx / L);
                sx[n1] = sinl(2.0L * pi * n1 * dx / L);
                cy[n1] = cosl(2.0L * pi * n1 * dy / L);
                sy[n1] = sinl(2.0L * pi * n1 * dy / L);
            }
            for (n1 = -sp.mmax; n1 <= sp.mmax; n1++)
                for (n2 = -sp.mmax; n2 <= sp.mmax; n2++) {
                    const int kk = n1 * n1 + n2 * n2, m1 = n1 < 0 ? -n1 : n1, m2 = n2 < 0 ? -n2 : n2;
                    const long double sg = (n1 < 0) == (n2 < 0) ? 1.0L : -1.0L;
                    if (kk == 0) continue;
                    if (br[kk] < 0.0L) {
                        const long double k = 2.0L * pi * sqrtl((long double)kk) / L;
                        br[kk] = pi / A / k *
                                 (expl(k * z) * erfcl(k / (2.0L * a) + a * z) +
                                  expl(-k * z) * erfcl(k / (2.0L * a) - a * z));
                    }
                    /* cos(u + v) = cos u cos v - sin u sin v, sines odd in n */
                    s += br[kk] * (cx[m1] * cy[m2] - sg * sx[m1] * sy[m2]);
                }
            s -= 2.0L * pi / A * (z * erfl(a * z) + expl(-a * a * z * z) / (a * spi));
            p += q[j] * s;
        }
        out[i] = (double)(p / (4.0L * pi));
    }
    free(br);
    free(cx);
}

/* The sums at the default split (alpha L = 5, relative accuracy 1e-15). */
static inline void t_ewald2d_laplace(int64_t ns, const double *xs, const double *q, int64_t nt,
                              const double *xt, double L, double *out)
{
    t_ewald2d_split(ns, xs, q, nt, xt, L, t_ewald_plan(L, 5.0, 1e-15), out);
}

/* t_ewald_stokes: the velocity u_i = sum_j G_ij f_j, G = (delta_ij / r +
 * d_i d_j / r^3) / (8 pi) (viscosity 1), of forces f_j at x_j and all their
 * images in a cubic cell of side L, at nt targets (out[3 i ..]): Hasimoto's
 * sum (Hasimoto 1959; the split as in Lindbo and Tornberg, J. Comput. Phys.
 * 229, 2010): the Stokeslet (delta lap - grad grad) r with r = r erfc(xi r)
 * - exp(-xi^2 r^2) / (xi sqrt(pi)) + [r erf(xi r) + exp(-xi^2 r^2) / (xi
 * sqrt(pi))], real space
 *   (erfc(xi r) / r - E) delta_ij + (erfc(xi r) / r + E) d_i d_j / r^2,
 *   E = 2 xi / sqrt(pi) exp(-xi^2 r^2),
 * Fourier space (1 / L^3) sum_{k != 0} 8 pi (1 / k^4 + 1 / (4 xi^2 k^2))
 * (k^2 delta - k k) exp(-k^2 / (4 xi^2)) Re(S(k) e^{i k.x}). Conventions: a
 * net force is balanced by a mean pressure gradient, the velocity has zero
 * mean over the cell (the real part integrates to zero), a target at a
 * source leaves that source's own term out (-4 xi / sqrt(pi) f / (8 pi),
 * the smooth part's value at 0). */
static inline void t_ewald_stokes_split(int64_t ns, const double *xs, const double *f, int64_t nt,
                                        const double *xt, double L, t_ewald_split sp, double *out)
{
    const long double xi = sp.alpha, V = (long double)L * L * L, e8p = 8.0L * T_EW_PI;
    const int mm = sp.mmax, nm = 2 * mm + 1;
    const size_t nk = (size_t)nm * nm * nm;
    long double *sr = (long double *)calloc(3 * nk, sizeof(long double));
    long double *si = (long double *)calloc(3 * nk, sizeof(long double));
    int64_t i, j;
    const size_t nb = (size_t)(2 * sp.nimg + 1) * (2 * sp.nimg + 1) * (2 * sp.nimg + 1);
    long double *dv = (long double *)malloc(3 * nb * sizeof(long double));
    int mx, my, mz, a, b;
    for (j = 0; j < ns; j++) t_ew_factor(xs + 3 * j, L, mm, f + 3 * j, 3, sr, si); /* S(m) */
    for (i = 0; i < nt; i++) {
        const double *x = xt + 3 * i;
        long double u[3] = {0.0L, 0.0L, 0.0L};
        for (j = 0; j < ns; j++) {
            int self, k;
            const int nk = t_ew_near(x, xs + 3 * j, L, sp, dv, &self);
            for (a = 0; a < 3 && self; a++) /* the target's own source */
                u[a] -= 4.0L * xi / sqrtl(T_EW_PI) * f[3 * j + a] / e8p;
            for (k = 0; k < nk; k++) {
                const long double *v = dv + 3 * k, r2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
                const long double r = sqrtl(r2), E = 2.0L * xi / sqrtl(T_EW_PI) * expl(-xi * xi * r2);
                const long double ca = erfcl(xi * r) / r - E, cb = (erfcl(xi * r) / r + E) / r2;
                const long double fd = v[0] * f[3 * j] + v[1] * f[3 * j + 1] + v[2] * f[3 * j + 2];
                for (a = 0; a < 3; a++) u[a] += (ca * f[3 * j + a] + cb * v[a] * fd) / e8p;
            }
        }
        for (mx = -mm; mx <= mm; mx++)
            for (my = -mm; my <= mm; my++)
                for (mz = -mm; mz <= mm; mz++) {
                    const size_t at = ((size_t)(mx + mm) * nm + (size_t)(my + mm)) * nm + (size_t)(mz + mm);
                    const long double k[3] = {2.0L * T_EW_PI / L * mx, 2.0L * T_EW_PI / L * my,
                                              2.0L * T_EW_PI / L * mz};
                    const long double k2 = k[0] * k[0] + k[1] * k[1] + k[2] * k[2];
                    long double w, ph, re[3];
                    if (mx == 0 && my == 0 && mz == 0) continue;
                    w = 8.0L * T_EW_PI * (1.0L / (k2 * k2) + 1.0L / (4.0L * xi * xi * k2)) *
                        expl(-k2 / (4.0L * xi * xi)) / V / e8p;
                    ph = k[0] * x[0] + k[1] * x[1] + k[2] * x[2];
                    for (a = 0; a < 3; a++) re[a] = sr[3 * at + a] * cosl(ph) - si[3 * at + a] * sinl(ph);
                    for (a = 0; a < 3; a++)
                        for (b = 0; b < 3; b++) u[a] += w * ((a == b ? k2 : 0.0L) - k[a] * k[b]) * re[b];
                }
        for (a = 0; a < 3; a++) out[3 * i + a] = (double)u[a];
    }
    free(sr);
    free(si);
    free(dv);
}

/* The sums at the default split (xi L = 5, relative accuracy 1e-15). */
static inline void t_ewald_stokes(int64_t ns, const double *xs, const double *f, int64_t nt,
                                  const double *xt, double L, double *out)
{
    t_ewald_stokes_split(ns, xs, f, nt, xt, L, t_ewald_plan(L, 5.0, 1e-15), out);
}

#endif
