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

/* The structure factors (sr, si)[nw at + c] = sum_j w[nw j + c] e^{-i
 * k.x_j} of ns sources (k = 2 pi m / L, |m_a| <= mm, at = the index of m),
 * from one table of e^{-i k_a x_a} per source and axis; the sources in the
 * inner loop, so that each factor is summed in registers; half of them,
 * the others conjugate (S(-m) = conj S(m), at -> nm^3 - 1 - at). */
static inline void t_ew_factors(int64_t ns, const double *xs, double L, int mm, const double *w,
                                int nw, long double *sr, long double *si)
{
    const int nm = 2 * mm + 1;
    const size_t half = ((size_t)nm * nm * nm - 1) / 2, n3 = (size_t)nm * nm * nm;
    long double *ec = (long double *)malloc((6 * (size_t)nm + 4) * (size_t)ns * sizeof(long double));
    long double *es = ec + 3 * (size_t)nm * ns, *r1 = es + 3 * (size_t)nm * ns, *i1 = r1 + ns;
    long double *pr = i1 + ns, *pi = pr + ns;
    int64_t j;
    int a, mx, my, mz, c;
    size_t at;
    for (j = 0; j < ns; j++) /* ec[(a nm + m) ns + j] */
        for (a = 0; a < 3; a++)
            for (mx = -mm; mx <= mm; mx++) {
                const long double ph = 2.0L * T_EW_PI / L * mx * (long double)xs[3 * j + a];
                ec[((size_t)a * nm + mx + mm) * ns + j] = cosl(ph);
                es[((size_t)a * nm + mx + mm) * ns + j] = -sinl(ph);
            }
    for (mx = 0; mx < nm; mx++)
        for (my = 0; my < nm && (at = ((size_t)mx * nm + my) * nm) <= half; my++) {
            const long double *cx = ec + (size_t)mx * ns, *sx = es + (size_t)mx * ns;
            const long double *cy = ec + (size_t)(nm + my) * ns, *sy = es + (size_t)(nm + my) * ns;
            for (j = 0; j < ns; j++) {
                r1[j] = cx[j] * cy[j] - sx[j] * sy[j];
                i1[j] = cx[j] * sy[j] + sx[j] * cy[j];
            }
            for (mz = 0; mz < nm && at <= half; mz++, at++) {
                const long double *cz = ec + (size_t)(2 * nm + mz) * ns, *sz = es + (size_t)(2 * nm + mz) * ns;
                for (j = 0; j < ns; j++) {
                    pr[j] = r1[j] * cz[j] - i1[j] * sz[j];
                    pi[j] = r1[j] * sz[j] + i1[j] * cz[j];
                }
                for (c = 0; c < nw; c++) {
                    long double re = 0.0L, im = 0.0L;
                    for (j = 0; j < ns; j++) {
                        re += w[nw * j + c] * pr[j];
                        im += w[nw * j + c] * pi[j];
                    }
                    sr[nw * at + c] = re;
                    si[nw * at + c] = im;
                    sr[nw * (n3 - 1 - at) + c] = re;
                    si[nw * (n3 - 1 - at) + c] = -im;
                }
            }
        }
    free(ec);
}

/* The index of the derivative d_a d_b among the Hessian's six entries (xx,
 * yy, zz, xy, xz, yz) and of d_a d_b d_c among the ten third derivatives
 * (xxx, xxy, xxz, xyy, xyz, xzz, yyy, yyz, yzz, zzz: a <= b <= c in
 * lexicographic order), in any order of a, b, c. */
static inline int t_ew_h2(int a, int b)
{
    return a == b ? a : 2 + a + b;
}
static inline int t_ew_h3(int a, int b, int c)
{
    static const int at[3][3][3] = {{{0, 1, 2}, {1, 3, 4}, {2, 4, 5}},
                                    {{1, 3, 4}, {3, 6, 7}, {4, 7, 8}},
                                    {{2, 4, 5}, {4, 7, 8}, {5, 8, 9}}};
    return at[a][b][c];
}

/* t_ewald_laplace_deriv: the potential and its derivatives with respect to
 * the target up to the third, of nq sets of charges (q[nq j + u]), nd (4,
 * 10 or 20) of them per target and set into out[nd (nq i + u) ..]: the
 * potential, the gradient (3), the Hessian (6, as
 * t_ew_h2), the third derivatives (10, as t_ew_h3). Real space: with F_0 =
 * erfc(alpha r) / r and F_{n+1} = -F_n' / r = ((2 n + 1) F_n + (2
 * alpha^2)^(n + 1) / (alpha sqrt(pi)) exp(-alpha^2 r^2)) / r^2, d_a F_0 =
 * -x_a F_1, d_ab F_0 = x_a x_b F_2 - delta_ab F_1, d_abc F_0 = (delta_ab x_c
 * + delta_ac x_b + delta_bc x_a) F_2 - x_a x_b x_c F_3; reciprocal space:
 * each derivative d_a multiplies the term S(k) e^{i k.x} by i k_a. A target
 * at a source: the smooth part erf(alpha r) / r of that source's own term,
 * in the reciprocal sum, is taken out: 2 alpha / sqrt(pi) from the
 * potential, -4 alpha^3 / (3 sqrt(pi)) delta_ab from the Hessian (its odd
 * derivatives are 0 there). */
static inline void t_ewald_laplace_deriv(int64_t ns, const double *xs, const double *q, int nq,
                                         int64_t nt, const double *xt, double L, t_ewald_split sp,
                                         int nd, double *out)
{
    const long double a = sp.alpha, V = (long double)L * L * L, four_pi = 4.0L * T_EW_PI;
    const long double spi = sqrtl(T_EW_PI);
    const int mm = sp.mmax, nm = 2 * mm + 1;
    long double *Q = (long double *)calloc((size_t)nq, sizeof(long double));
    long double *o = (long double *)malloc(20 * (size_t)nq * sizeof(long double));
    long double *sr = (long double *)calloc((size_t)nm * nm * nm * nq, sizeof(long double));
    long double *si = (long double *)calloc((size_t)nm * nm * nm * nq, sizeof(long double));
    int64_t i, j;
    const size_t nb = (size_t)(2 * sp.nimg + 1) * (2 * sp.nimg + 1) * (2 * sp.nimg + 1);
    long double *dv = (long double *)malloc(3 * nb * sizeof(long double));
    int mx, my, mz, b, c, d, e, u;
    for (j = 0; j < ns * nq; j++) Q[j % nq] += q[j];
    /* structure factors S(m) = sum_j q_j e^{-i k.x_j}, nq per m */
    t_ew_factors(ns, xs, L, mm, q, nq, sr, si);
    for (i = 0; i < nt; i++) {
        const double *x = xt + 3 * i;
        for (u = 0; u < 20 * nq; u++) o[u] = 0.0L;
        /* real space: g, the derivatives of one unit charge's term */
        for (j = 0; j < ns; j++) {
            int self, k;
            const int nk = t_ew_near(x, xs + 3 * j, L, sp, dv, &self);
            long double g[20] = {0.0L};
            if (self) { /* its smeared part */
                g[0] -= 2.0L * a / spi;
                for (d = 0; d < 3; d++) g[4 + d] += 4.0L * a * a * a / (3.0L * spi);
            }
            for (k = 0; k < nk; k++) {
                const long double *v = dv + 3 * k, r2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
                const long double ex = expl(-a * a * r2) / (a * spi);
                long double F[4];
                F[0] = erfcl(a * sqrtl(r2)) / sqrtl(r2);
                for (e = 0; e < 3; e++) F[e + 1] = ((2 * e + 1) * F[e] + powl(2.0L * a * a, e + 1) * ex) / r2;
                g[0] += F[0];
                for (b = 0; b < 3; b++) {
                    g[1 + b] -= v[b] * F[1];
                    for (c = b; c < 3; c++) {
                        g[4 + t_ew_h2(b, c)] += v[b] * v[c] * F[2] - (b == c) * F[1];
                        for (d = c; d < 3; d++)
                            g[10 + t_ew_h3(b, c, d)] +=
                                ((b == c) * v[d] + (b == d) * v[c] + (c == d) * v[b]) * F[2] -
                                v[b] * v[c] * v[d] * F[3];
                    }
                }
            }
            for (u = 0; u < nq; u++)
                for (d = 0; d < nd; d++) o[20 * u + d] += q[nq * j + u] / four_pi * g[d];
        }
        /* reciprocal space: Re and Im of S e^{i k.x}, times (i k)^n: the
         * even orders take Re, the odd ones Im */
        for (mx = -mm; mx <= mm; mx++)
            for (my = -mm; my <= mm; my++)
                for (mz = -mm; mz <= mm; mz++) {
                    const size_t at = ((size_t)(mx + mm) * nm + (size_t)(my + mm)) * nm + (size_t)(mz + mm);
                    const long double k[3] = {2.0L * T_EW_PI / L * mx, 2.0L * T_EW_PI / L * my,
                                              2.0L * T_EW_PI / L * mz};
                    const long double k2 = k[0] * k[0] + k[1] * k[1] + k[2] * k[2];
                    long double w, ph, cs, sn, g[20];
                    if (mx == 0 && my == 0 && mz == 0) continue;
                    w = expl(-k2 / (4.0L * a * a)) / k2 / V;
                    ph = k[0] * x[0] + k[1] * x[1] + k[2] * x[2];
                    cs = cosl(ph), sn = sinl(ph);
                    g[0] = w;
                    for (b = 0; b < 3; b++) {
                        g[1 + b] = -w * k[b];
                        for (c = b; c < 3; c++) {
                            g[4 + t_ew_h2(b, c)] = -w * k[b] * k[c];
                            for (d = c; d < 3; d++) g[10 + t_ew_h3(b, c, d)] = w * k[b] * k[c] * k[d];
                        }
                    }
                    for (u = 0; u < nq; u++) {
                        const long double re = sr[nq * at + u] * cs - si[nq * at + u] * sn;
                        const long double im = sr[nq * at + u] * sn + si[nq * at + u] * cs;
                        for (d = 0; d < nd; d++) o[20 * u + d] += g[d] * (d == 0 || (d >= 4 && d < 10) ? re : im);
                    }
                }
        for (u = 0; u < nq; u++) {
            o[20 * u] -= Q[u] / (4.0L * a * a * V); /* the background */
            for (d = 0; d < nd; d++) out[nd * (nq * i + u) + d] = (double)o[20 * u + d];
        }
    }
    free(Q);
    free(o);
    free(sr);
    free(si);
    free(dv);
}

/* The potential and gradient (4 per target, out[4 i ..]) at a given split. */
static inline void t_ewald_laplace_split(int64_t ns, const double *xs, const double *q, int64_t nt,
                                         const double *xt, double L, t_ewald_split sp, double *out)
{
    t_ewald_laplace_deriv(ns, xs, q, 1, nt, xt, L, sp, 4, out);
}

/* The potential and its derivatives of nq sets of charges (q[nq j + u]),
 * nd (4, 10 or 20) per target and set (out[nd (nq i + u) ..]), at the
 * default split. */
static inline void t_ewald_laplace_d(int64_t ns, const double *xs, const double *q, int nq,
                                     int64_t nt, const double *xt, double L, int nd, double *out)
{
    t_ewald_laplace_deriv(ns, xs, q, nq, nt, xt, L, t_ewald_plan(L, 5.0, 1e-15), nd, out);
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
 * the smooth part's value at 0; its gradient there is 0).
 * t_ewald_stokes_deriv: nf sets of forces (f[3 (nf j + u) ..]), nd = 3
 * (the velocity) or 12 (and its gradient du_a / dx_m at 3 + 3 a + m) per
 * target and set (out[nd (nf i + u) ..]); real space with A = erfc(xi r) /
 * r - E, B = (erfc(xi r) / r + E) / r^2 (the two coefficients above),
 * d_m (A f_a + B d_a (d . f)) = A' d_m / r f_a + B' d_m / r d_a (d . f) + B
 * (delta_am (d . f) + d_a f_m), A' / r = -C / r^2 + 2 xi^2 E, B' / r = -3 C
 * / r^4 - 2 xi^2 E / r^2, C = erfc(xi r) / r + E; Fourier space: i k_m. */
static inline void t_ewald_stokes_deriv(int64_t ns, const double *xs, const double *f, int nf,
                                        int64_t nt, const double *xt, double L, t_ewald_split sp,
                                        int nd, double *out)
{
    const long double xi = sp.alpha, V = (long double)L * L * L, e8p = 8.0L * T_EW_PI;
    const int mm = sp.mmax, nm = 2 * mm + 1;
    const size_t nk = (size_t)nm * nm * nm;
    long double *sr = (long double *)calloc(3 * nk * nf, sizeof(long double));
    long double *si = (long double *)calloc(3 * nk * nf, sizeof(long double));
    long double *u = (long double *)malloc(12 * (size_t)nf * sizeof(long double));
    int64_t i, j;
    const size_t nb = (size_t)(2 * sp.nimg + 1) * (2 * sp.nimg + 1) * (2 * sp.nimg + 1);
    long double *dv = (long double *)malloc(3 * nb * sizeof(long double));
    int mx, my, mz, a, b, m, s;
    t_ew_factors(ns, xs, L, mm, f, 3 * nf, sr, si); /* S(m) */
    for (i = 0; i < nt; i++) {
        const double *x = xt + 3 * i;
        for (a = 0; a < 12 * nf; a++) u[a] = 0.0L;
        for (j = 0; j < ns; j++) {
            int self, k;
            const int nk = t_ew_near(x, xs + 3 * j, L, sp, dv, &self);
            for (s = 0; s < nf; s++) {
                const double *fj = f + 3 * (nf * j + s);
                long double *us = u + 12 * s;
                for (a = 0; a < 3 && self; a++) /* the target's own source */
                    us[a] -= 4.0L * xi / sqrtl(T_EW_PI) * fj[a] / e8p;
            }
            for (k = 0; k < nk; k++) {
                const long double *v = dv + 3 * k, r2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
                const long double r = sqrtl(r2), E = 2.0L * xi / sqrtl(T_EW_PI) * expl(-xi * xi * r2);
                const long double C = erfcl(xi * r) / r + E, ca = C - 2.0L * E, cb = C / r2;
                /* A'(r) / r and B'(r) / r of A = ca, B = cb */
                const long double da = -C / r2 + 2.0L * xi * xi * E;
                const long double db = -3.0L * C / (r2 * r2) - 2.0L * xi * xi * E / r2;
                for (s = 0; s < nf; s++) {
                    const double *fj = f + 3 * (nf * j + s);
                    const long double fd = v[0] * fj[0] + v[1] * fj[1] + v[2] * fj[2];
                    long double *us = u + 12 * s;
                    for (a = 0; a < 3; a++) {
                        us[a] += (ca * fj[a] + cb * v[a] * fd) / e8p;
                        for (m = 0; m < 3 && nd > 3; m++)
                            us[3 + 3 * a + m] += (da * v[m] * fj[a] + db * v[m] * v[a] * fd +
                                                  cb * ((a == m) * fd + v[a] * fj[m])) / e8p;
                    }
                }
            }
        }
        for (mx = -mm; mx <= mm; mx++)
            for (my = -mm; my <= mm; my++)
                for (mz = -mm; mz <= mm; mz++) {
                    const size_t at = ((size_t)(mx + mm) * nm + (size_t)(my + mm)) * nm + (size_t)(mz + mm);
                    const long double k[3] = {2.0L * T_EW_PI / L * mx, 2.0L * T_EW_PI / L * my,
                                              2.0L * T_EW_PI / L * mz};
                    const long double k2 = k[0] * k[0] + k[1] * k[1] + k[2] * k[2];
                    long double w, ph, cs, sn;
                    if (mx == 0 && my == 0 && mz == 0) continue;
                    w = 8.0L * T_EW_PI * (1.0L / (k2 * k2) + 1.0L / (4.0L * xi * xi * k2)) *
                        expl(-k2 / (4.0L * xi * xi)) / V / e8p;
                    ph = k[0] * x[0] + k[1] * x[1] + k[2] * x[2];
                    cs = cosl(ph), sn = sinl(ph);
                    for (s = 0; s < nf; s++) {
                        const long double *Sr = sr + 3 * (nf * at + s), *Si = si + 3 * (nf * at + s);
                        long double *us = u + 12 * s;
                        for (a = 0; a < 3; a++)
                            for (b = 0; b < 3; b++) {
                                const long double g = w * ((a == b ? k2 : 0.0L) - k[a] * k[b]);
                                us[a] += g * (Sr[b] * cs - Si[b] * sn);
                                for (m = 0; m < 3 && nd > 3; m++) us[3 + 3 * a + m] -= g * k[m] * (Sr[b] * sn + Si[b] * cs);
                            }
                    }
                }
        for (s = 0; s < nf; s++)
            for (a = 0; a < nd; a++) out[nd * (nf * i + s) + a] = (double)u[12 * s + a];
    }
    free(sr);
    free(si);
    free(u);
    free(dv);
}

/* The velocity (3 per target, out[3 i ..]) at a given split. */
static inline void t_ewald_stokes_split(int64_t ns, const double *xs, const double *f, int64_t nt,
                                        const double *xt, double L, t_ewald_split sp, double *out)
{
    t_ewald_stokes_deriv(ns, xs, f, 1, nt, xt, L, sp, 3, out);
}

/* The velocity and its gradient (nd = 12) or the velocity alone (nd = 3)
 * of nf sets of forces (f[3 (nf j + u) ..]), per target and set (out[nd
 * (nf i + u) ..]), at the default split. */
static inline void t_ewald_stokes_d(int64_t ns, const double *xs, const double *f, int nf,
                                    int64_t nt, const double *xt, double L, int nd, double *out)
{
    t_ewald_stokes_deriv(ns, xs, f, nf, nt, xt, L, t_ewald_plan(L, 5.0, 1e-15), nd, out);
}

/* The sums at the default split (xi L = 5, relative accuracy 1e-15). */
static inline void t_ewald_stokes(int64_t ns, const double *xs, const double *f, int64_t nt,
                                  const double *xt, double L, double *out)
{
    t_ewald_stokes_split(ns, xs, f, nt, xt, L, t_ewald_plan(L, 5.0, 1e-15), out);
}

#endif
