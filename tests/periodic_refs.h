/* periodic_refs.h - the references that test_periodic.c and test_slab.c
 * share: options, charges, the checked targets and direct image sums
 * (Yukawa converged in N; Laplace and Stokes along one direction,
 * extrapolated in N). The including file defines NCHK (targets checked
 * per case) and includes test.h first. Everything here is computed without
 * the library. */
#ifndef KIFMM_TESTS_PERIODIC_REFS_H
#define KIFMM_TESTS_PERIODIC_REFS_H

#include <math.h>
#include <string.h>

#define PI4 (4.0 * T_PI)

/* options: order, periodic mask pm (bit d: direction d, period 1) */
static kifmm_opts popts(int order, int pm)
{
    kifmm_opts o;
    int d;
    memset(&o, 0, sizeof o);
    o.order = order;
    for (d = 0; d < 3; d++) o.period[d] = pm >> d & 1 ? 1.0 : 0.0;
    return o;
}

/* n charges in [-0.5, 0.5], made to sum to zero (neutral) or not */
static void gen_q(t_rng *r, int64_t n, double *q, int neutral)
{
    double m = 0.0;
    int64_t i;
    for (i = 0; i < n; i++) m += (q[i] = t_rand01(r) - 0.5);
    for (i = 0; i < n && neutral; i++) q[i] -= m / (double)n;
}

/* the checked targets: NCHK spread over the nt, and their coordinates */
static int64_t chk_index(int c, int64_t nt) { return (int64_t)c * nt / NCHK; }

static void chk_points(int64_t nt, const double *xt, double *t)
{
    int c;
    for (c = 0; c < NCHK; c++) memcpy(t + 3 * c, xt + 3 * chk_index(c, nt), 3 * sizeof(double));
}

/* relative L2 difference of out (stride st, component k) at the checked
 * targets and ref (stride rs) */
static double rel_l2(int64_t nt, const double *out, int st, int k, const double *ref, int rs)
{
    double e = 0.0, s = 0.0;
    int c;
    for (c = 0; c < NCHK; c++) {
        const double d = out[st * chk_index(c, nt) + k] - ref[rs * c];
        e += d * d;
        s += ref[rs * c] * ref[rs * c];
    }
    return sqrt(e / s);
}

/* sum over the images |n_a| <= N along the periodic directions of pm of
 * q_j K(t - x_j - n), K = exp(-lam r) / (4 pi r) (lam = 0: 1 / (4 pi r)),
 * the source's own term left out; each image's sum in double, their sum in
 * long double */
static double image_sum(int pm, int N, double lam, int64_t ns, const double *xs, const double *q,
                        const double *t)
{
    const int n0 = pm & 1 ? N : 0, n1 = pm & 2 ? N : 0, n2 = pm & 4 ? N : 0;
    long double s = 0.0L;
    int a, b, c;
    int64_t j;
    for (a = -n0; a <= n0; a++)
        for (b = -n1; b <= n1; b++)
            for (c = -n2; c <= n2; c++) {
                double cell = 0.0; /* one image of the cell, in double */
                for (j = 0; j < ns; j++) {
                    const double dx = t[0] - xs[3 * j] - a, dy = t[1] - xs[3 * j + 1] - b;
                    const double dz = t[2] - xs[3 * j + 2] - c, rr = sqrt(dx * dx + dy * dy + dz * dz);
                    if (rr == 0.0) continue;
                    cell += q[j] * (lam > 0.0 ? exp(-lam * rr) : 1.0) / rr;
                }
                s += cell;
            }
    return (double)(s / (long double)PI4);
}

/* Yukawa at the checked targets t (NCHK), |n| <= N and N - 2: ref[c];
 * returns the largest relative change between them */
static double ref_yukawa(int pm, int N, double lam, int64_t ns, const double *xs, const double *q,
                         const double *t, double *ref)
{
    double ch = 0.0, big = 0.0;
    int c;
    for (c = 0; c < NCHK; c++) {
        const double lo = image_sum(pm, N - 2, lam, ns, xs, q, t + 3 * c);
        ref[c] = image_sum(pm, N, lam, ns, xs, q, t + 3 * c);
        ch = fabs(ref[c] - lo) > ch ? fabs(ref[c] - lo) : ch;
        big = fabs(ref[c]) > big ? fabs(ref[c]) : big;
    }
    return ch / big;
}

/* Richardson steps over R[k][0] at N0 << k, k = 0 .. lv - 1 (lv <= 5), of
 * nv values each: in 1/N^2, 1/N^4, ... (base 4: the error of a symmetric
 * image sum along one direction) or 1/N, 1/N^2, ... (base 2: over squares
 * of images along two); the result into out, the last step's squared
 * change added to *ch and the result's squares to *big */
static void extrapolate(double R[5][5][3], int lv, double base, int nv, double *out, double *ch,
                        double *big)
{
    const int m = lv - 1;
    int a, k, d;
    for (a = 1; a < lv; a++)
        for (k = a; k < lv; k++)
            for (d = 0; d < nv; d++)
                R[k][a][d] = (pow(base, a) * R[k][a - 1][d] - R[k - 1][a - 1][d]) / (pow(base, a) - 1.0);
    for (d = 0; d < nv; d++) {
        out[d] = R[m][m][d];
        *ch += (R[m][m][d] - R[m][m - 1][d]) * (R[m][m][d] - R[m][m - 1][d]);
        *big += R[m][m][d] * R[m][m][d];
    }
}

/* Laplace, one periodic direction (mask pm), neutral charges, at the
 * checked targets t: the symmetric image sums at N0, 2 N0, 4 N0, 8 N0
 * extrapolated; returns the last step's relative change (L2) */
static double ref_laplace1d(int pm, int N0, int64_t ns, const double *xs, const double *q,
                            const double *t, double *ref)
{
    double ch = 0.0, big = 0.0;
    int c, k;
    for (c = 0; c < NCHK; c++) {
        double R[5][5][3];
        for (k = 0; k < 4; k++) R[k][0][0] = image_sum(pm, N0 << k, 0.0, ns, xs, q, t + 3 * c);
        extrapolate(R, 4, 4.0, 1, ref + c, &ch, &big);
    }
    return sqrt(ch / big);
}

/* the Stokeslet (mu 1) summed over the images |n_a| <= N along the periodic
 * directions of pm (1: x; 3: x and y), at t: u[3]; each image's sum in
 * double, their sum in long double */
static void stokes_images(int pm, int N, int64_t ns, const double *xs, const double *f,
                          const double *t, double *u)
{
    const int n1 = pm & 2 ? N : 0;
    long double s[3] = {0.0L, 0.0L, 0.0L};
    int a, b, k;
    int64_t j;
    for (a = -N; a <= N; a++)
        for (b = -n1; b <= n1; b++) {
            double cell[3] = {0.0, 0.0, 0.0};
            for (j = 0; j < ns; j++) {
                const double d[3] = {t[0] - xs[3 * j] - a, t[1] - xs[3 * j + 1] - b, t[2] - xs[3 * j + 2]};
                const double r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2], r = sqrt(r2);
                const double df = d[0] * f[3 * j] + d[1] * f[3 * j + 1] + d[2] * f[3 * j + 2];
                if (r2 == 0.0) continue;
                for (k = 0; k < 3; k++) cell[k] += f[3 * j + k] / r + d[k] * df / (r2 * r);
            }
            for (k = 0; k < 3; k++) s[k] += cell[k];
        }
    for (k = 0; k < 3; k++) u[k] = (double)(s[k] / (2.0L * (long double)PI4));
}

#endif
