/* test_ewald.c - the Ewald reference of the periodic tests (tests/ewald.h)
 * against what does not come from it: published lattice constants (the
 * NaCl Madelung constant, the simple cubic lattice in a neutralising
 * background), the independence of its split alpha, the periodicity of
 * the result, and direct sums over the image lattice in growing cubes for a
 * cell without charge or dipole moment. And the path of the far images'
 * exchange that kernels without the symmetry K(-d) = K(d)^T take (its down
 * fit from its own SVD, KIFMM_EWALD_OWN_FIT), with laplace in three
 * periodic directions against these sums. */
#define KIFMM_EWALD_OWN_FIT 1
#include "kifmm.h"

#include "ewald.h"
#include "test.h"

#define PI4 (4.0 * 3.14159265358979323846)

static double max_abs(int n, const double *v)
{
    double m = 0.0;
    int i;
    for (i = 0; i < n; i++) m = fabs(v[i]) > m ? fabs(v[i]) : m;
    return m;
}

/* the largest |a - b| over n values of stride 4 from offset k, over the
 * largest |b| of them */
static double rel_diff(int n, const double *a, const double *b, int k, int kn)
{
    double num = 0.0, den = 0.0;
    int i, c;
    for (i = 0; i < n; i++)
        for (c = k; c < k + kn; c++) {
            num = fabs(a[4 * i + c] - b[4 * i + c]) > num ? fabs(a[4 * i + c] - b[4 * i + c]) : num;
            den = fabs(b[4 * i + c]) > den ? fabs(b[4 * i + c]) : den;
        }
    return num / den;
}

/* NaCl, side 1: Na at the face centres and corner, Cl at the edge centres
 * and body centre; at a Na site, -M / (4 pi r0) with r0 = 1/2 and M the
 * Madelung constant 1.747564594633182... (rock salt), and no field. */
static void test_madelung(void)
{
    static const double x[24] = {0, 0, 0, 0, .5, .5, .5, 0, .5, .5, .5, 0,
                                 .5, 0, 0, 0, .5, 0, 0, 0, .5, .5, .5, .5};
    static const double q[8] = {1, 1, 1, 1, -1, -1, -1, -1};
    const double M = 1.7475645946331821906;
    double out[8];
    t_ewald_laplace(8, x, q, 2, x, 1.0, out);
    CHECK_ERR(fabs(out[0] + M / (PI4 * 0.5)) / (M / (PI4 * 0.5)), 1e-13,
              "NaCl: potential at a Na site against the Madelung constant");
    CHECK_ERR(max_abs(3, out + 1) / (M / (PI4 * 0.5)), 1e-13, "NaCl: no field at a Na site");
    CHECK_ERR(fabs(out[4] - out[0]) / (M / (PI4 * 0.5)), 1e-13,
              "NaCl: the same potential at every Na site");
}

/* One unit charge per cell of side L in a neutralising background: at the
 * charge, its images and the background give -xi / (4 pi L), xi =
 * 2.837297479480619... (the simple cubic Wigner lattice constant, the
 * finite-size correction of Ewald sums for a single ion). */
static void test_wigner(void)
{
    const double xi = 2.8372974794806195, L = 2.5, x[3] = {0.3, 1.1, 2.0}, q = 1.0;
    double out[4];
    t_ewald_laplace(1, x, &q, 1, x, L, out);
    CHECK_ERR(fabs(out[0] + xi / (PI4 * L)) / (xi / (PI4 * L)), 1e-13,
              "one charge, background: potential at the charge against the cubic lattice constant");
}

/* 40 charges (not neutral), 12 targets (4 at sources): two splits agree;
 * shifting everything by a vector and wrapping the sources leaves all as it
 * is. */
static void test_split_and_shift(void)
{
    enum { NS = 40, NT = 12 };
    const double L = 1.3;
    t_rng r = t_rng_seed(41);
    double xs[3 * NS], q[NS], xt[3 * NT], a[4 * NT], b[4 * NT], xs2[3 * NS], xt2[3 * NT],
        sh[3] = {0.71, -2.2, 0.05}, qs = 0.0;
    int i, k;
    for (i = 0; i < 3 * NS; i++) xs[i] = t_uniform(&r, 0.0, L);
    for (i = 0; i < NS; i++) qs += q[i] = t_uniform(&r, -1.0, 1.0);
    for (i = 0; i < 3 * NT; i++) xt[i] = i < 12 ? xs[i + 30] : t_uniform(&r, 0.0, L);
    t_ewald_laplace_split(NS, xs, q, NT, xt, L, t_ewald_plan(L, 4.0, 1e-15), a);
    t_ewald_laplace_split(NS, xs, q, NT, xt, L, t_ewald_plan(L, 7.5, 1e-15), b);
    CHECK_ERR(rel_diff(NT, a, b, 0, 1), 1e-12, "alpha L 4 against 7.5: potential, net charge %.2f",
              qs);
    CHECK_ERR(rel_diff(NT, a, b, 1, 3), 1e-12, "alpha L 4 against 7.5: gradient");
    for (i = 0; i < NS; i++)
        for (k = 0; k < 3; k++) {
            double v = fmod(xs[3 * i + k] + sh[k], L);
            xs2[3 * i + k] = v < 0 ? v + L : v;
        }
    for (i = 0; i < NT; i++)
        for (k = 0; k < 3; k++) xt2[3 * i + k] = xt[3 * i + k] + sh[k];
    for (i = 0; i < 4; i++) /* targets at sources stay at them */
        for (k = 0; k < 3; k++) xt2[3 * i + k] = xs2[3 * (i + 10) + k];
    t_ewald_laplace(NS, xs2, q, NT, xt2, L, b);
    CHECK_ERR(rel_diff(NT, b, a, 0, 1), 1e-12, "shifted by (%.2f, %.2f, %.2f), sources wrapped: potential",
              sh[0], sh[1], sh[2]);
    CHECK_ERR(rel_diff(NT, b, a, 1, 3), 1e-12, "shifted: gradient");
}

/* The sums over the images in cubes |n|_max <= R of a neutral cell
 * without dipole moment, at the targets (interleaved as the Ewald sums). */
static void cube_sums(int ns, const double *xs, const double *q, int nt, const double *xt,
                      double L, int R, double *out)
{
    int i, j, k, nx, ny, nz;
    for (i = 0; i < nt; i++) {
        long double p = 0, g[3] = {0, 0, 0};
        for (j = 0; j < ns; j++)
            for (nx = -R; nx <= R; nx++)
                for (ny = -R; ny <= R; ny++)
                    for (nz = -R; nz <= R; nz++) {
                        const long double d[3] = {xt[3 * i] - xs[3 * j] - (long double)nx * L,
                                                  xt[3 * i + 1] - xs[3 * j + 1] - (long double)ny * L,
                                                  xt[3 * i + 2] - xs[3 * j + 2] - (long double)nz * L};
                        const long double r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                        const long double rr = sqrtl(r2);
                        p += q[j] / rr;
                        for (k = 0; k < 3; k++) g[k] -= q[j] * d[k] / (r2 * rr);
                    }
        out[4 * i] = (double)(p / PI4);
        for (k = 0; k < 3; k++) out[4 * i + 1 + k] = (double)(g[k] / PI4);
    }
}

/* Neutral, without dipole moment (pairs mirrored through the cell's
 * centre): the cube sums converge to the tin-foil field and, up to one
 * constant (which depends on how the lattice is summed), potential, with
 * errors a / R^2 + b / R^3 + ... (measured for the field: 5.1e-5, 1.4e-5,
 * 3.5e-6 at R = 8, 16, 32; 1.9e-5 and 2.5e-6 after removing R^-2 from 8
 * and 16, 16 and 32), which Richardson's extrapolation over R = 8, 16, 32
 * removes to 1e-8. */
static void test_direct_lattice(void)
{
    enum { NH = 6, NS = 2 * NH, NT = 5 };
    const double L = 1.0;
    t_rng r = t_rng_seed(43);
    double xs[3 * NS], q[NS], xt[3 * NT], ew[4 * NT], d8[4 * NT], d16[4 * NT], d32[4 * NT];
    double ex[4 * NT];
    double qs = 0.0, off;
    int i, k;
    for (i = 0; i < NH; i++) {
        q[i] = q[i + NH] = t_uniform(&r, -1.0, 1.0);
        qs += 2.0 * q[i];
        for (k = 0; k < 3; k++) {
            xs[3 * i + k] = t_uniform(&r, 0.05, 0.95);
            xs[3 * (i + NH) + k] = L - xs[3 * i + k];
        }
    }
    q[0] -= qs / 2.0; /* neutral, and still mirrored */
    q[NH] -= qs / 2.0;
    for (i = 0; i < 3 * NT; i++) xt[i] = t_uniform(&r, 0.1, 0.9);
    t_ewald_laplace(NS, xs, q, NT, xt, L, ew);
    cube_sums(NS, xs, q, NT, xt, L, 8, d8);
    cube_sums(NS, xs, q, NT, xt, L, 16, d16);
    cube_sums(NS, xs, q, NT, xt, L, 32, d32);
    for (i = 0; i < 4 * NT; i++) {
        const double t1 = (4.0 * d16[i] - d8[i]) / 3.0, t2 = (4.0 * d32[i] - d16[i]) / 3.0;
        ex[i] = (8.0 * t2 - t1) / 7.0;
    }
    off = ex[0] - ew[0];
    for (i = 0; i < NT; i++) ex[4 * i] -= off;
    printf("  |n| <= 32 alone: field %.2e\n", rel_diff(NT, d32, ew, 1, 3));
    CHECK_ERR(rel_diff(NT, ex, ew, 1, 3), 1e-7,
              "cube sums, |n| <= 8, 16, 32 extrapolated, against Ewald: field (no charge, no dipole)");
    CHECK_ERR(rel_diff(NT, ex, ew, 0, 1), 1e-7,
              "the same: potential up to one constant (%.4f)", off);
}

/* The largest |a - b| over the largest |b|, n values of stride st from
 * offset k, kn of each */
static double rel_diff_st(int n, int st, const double *a, const double *b, int k, int kn)
{
    double num = 0.0, den = 0.0;
    int i, c;
    for (i = 0; i < n; i++)
        for (c = k; c < k + kn; c++) {
            num = fabs(a[st * i + c] - b[st * i + c]) > num ? fabs(a[st * i + c] - b[st * i + c]) : num;
            den = fabs(b[st * i + c]) > den ? fabs(b[st * i + c]) : den;
        }
    return num / den;
}

/* nt targets at least 0.1 L from every source and its images */
static void far_targets(t_rng *r, int ns, const double *xs, int nt, double *xt, double L)
{
    int i = 0, j, k;
    while (i < nt) {
        double m = L;
        for (k = 0; k < 3; k++) xt[3 * i + k] = t_uniform(r, 0.0, L);
        for (j = 0; j < ns; j++) {
            double d2 = 0.0;
            for (k = 0; k < 3; k++) {
                double d = fabs(xt[3 * i + k] - xs[3 * j + k]);
                d = d > L / 2 ? L - d : d;
                d2 += d * d;
            }
            m = sqrt(d2) < m ? sqrt(d2) : m;
        }
        i += m >= 0.1 * L;
    }
}

/* The derivatives: the Laplace sums' Hessian and third derivatives, the
 * Stokes sums' velocity gradient. Two splits agree (also at targets on
 * sources, where the smooth part of the source's own term is taken out of
 * the Hessian), and each order against central differences of fourth
 * order of the order below (step 1e-4 L; targets 0.1 L from the sources, so
 * that the step's error, about (h / r)^4, stays below 1e-10). 30 charges
 * and forces, not neutral, in a cell of side 1.3. */
static void test_derivatives(void)
{
    enum { NS = 30, NT = 6 };
    static const double w[4] = {1.0, -8.0, 8.0, -1.0}, st[4] = {-2.0, -1.0, 1.0, 2.0};
    const double L = 1.3, h = 1e-4 * L;
    t_rng r = t_rng_seed(47);
    double xs[3 * NS], q[NS], f[3 * NS], xt[3 * NT], tt[3 * NT], a[20 * NT], b[20 * NT];
    double fd[20 * NT], sa[12 * NT], sb[12 * NT], sf[12 * NT], lo[20 * NT];
    int i, k, j, c, m;
    for (i = 0; i < 3 * NS; i++) xs[i] = t_uniform(&r, 0.0, L);
    for (i = 0; i < NS; i++) q[i] = t_uniform(&r, -1.0, 1.0);
    for (i = 0; i < 3 * NS; i++) f[i] = t_uniform(&r, -1.0, 1.0);
    far_targets(&r, NS, xs, NT, xt, L);
    memcpy(tt, xt, sizeof tt);
    memcpy(tt, xs, 6 * sizeof(double)); /* two targets on sources */
    t_ewald_laplace_deriv(NS, xs, q, 1, NT, tt, L, t_ewald_plan(L, 4.0, 1e-15), 20, a);
    t_ewald_laplace_deriv(NS, xs, q, 1, NT, tt, L, t_ewald_plan(L, 7.5, 1e-15), 20, b);
    CHECK_ERR(rel_diff_st(NT, 20, a, b, 4, 6), 1e-12, "alpha L 4 against 7.5: Hessian (2 targets on sources)");
    CHECK_ERR(rel_diff_st(NT, 20, a, b, 10, 10), 1e-12, "alpha L 4 against 7.5: third derivatives");
    t_ewald_stokes_deriv(NS, xs, f, 1, NT, tt, L, t_ewald_plan(L, 4.0, 1e-15), 12, sa);
    t_ewald_stokes_deriv(NS, xs, f, 1, NT, tt, L, t_ewald_plan(L, 7.5, 1e-15), 12, sb);
    CHECK_ERR(rel_diff_st(NT, 12, sa, sb, 3, 9), 1e-12, "xi L 4 against 7.5: Stokes velocity gradient");
    /* several sets at once: the charges and the forces' x components; two
     * copies of the forces */
    {
        double q2[2 * NS], f2[6 * NS], a2[40 * NT], s2[24 * NT], e = 0.0;
        for (i = 0; i < NS; i++) {
            q2[2 * i] = q[i], q2[2 * i + 1] = f[3 * i];
            for (k = 0; k < 3; k++) f2[6 * i + k] = f[3 * i + k], f2[6 * i + 3 + k] = -f[3 * i + k];
        }
        t_ewald_laplace_d(NS, xs, q2, 2, NT, tt, L, 20, a2);
        t_ewald_laplace_d(NS, xs, q, 1, NT, tt, L, 20, a);
        t_ewald_stokes_d(NS, xs, f2, 2, NT, tt, L, 12, s2);
        t_ewald_stokes_d(NS, xs, f, 1, NT, tt, L, 12, sa);
        for (i = 0; i < 20 * NT; i++) e = fmax(e, fabs(a2[40 * (i / 20) + i % 20] - a[i]));
        for (i = 0; i < 12 * NT; i++)
            e = fmax(e, fabs(s2[24 * (i / 12) + i % 12] - sa[i]) + fabs(s2[24 * (i / 12) + 12 + i % 12] + sa[i]));
        CHECK(e == 0.0, "two sets at once: the same sums as each alone (%.1e)", e);
    }
    /* central differences */
    t_ewald_laplace_d(NS, xs, q, 1, NT, xt, L, 20, a);
    t_ewald_stokes_d(NS, xs, f, 1, NT, xt, L, 12, sa);
    memset(fd, 0, sizeof fd);
    memset(sf, 0, sizeof sf);
    for (j = 0; j < 3; j++)
        for (k = 0; k < 4; k++) {
            memcpy(tt, xt, sizeof tt);
            for (i = 0; i < NT; i++) tt[3 * i + j] += st[k] * h;
            t_ewald_laplace_d(NS, xs, q, 1, NT, tt, L, 20, lo);
            t_ewald_stokes_d(NS, xs, f, 1, NT, tt, L, 3, sb);
            for (i = 0; i < NT; i++)
                for (c = 0; c < 3; c++) {
                    /* d_j of d_c (c <= j) and of d_c d_m (c <= m <= j): each entry once */
                    if (c <= j) fd[20 * i + 4 + t_ew_h2(c, j)] += w[k] * lo[20 * i + 1 + c] / (12.0 * h);
                    for (m = c; m <= j; m++)
                        fd[20 * i + 10 + t_ew_h3(c, m, j)] += w[k] * lo[20 * i + 4 + t_ew_h2(c, m)] / (12.0 * h);
                    sf[12 * i + 3 + 3 * c + j] += w[k] * sb[3 * i + c] / (12.0 * h);
                }
        }
    CHECK_ERR(rel_diff_st(NT, 20, fd, a, 4, 6), 1e-8, "Hessian against differences of the gradient");
    CHECK_ERR(rel_diff_st(NT, 20, fd, a, 10, 10), 1e-8, "third derivatives against differences of the Hessian");
    CHECK_ERR(rel_diff_st(NT, 12, sf, sa, 3, 9), 1e-8, "Stokes gradient against differences of the velocity");
}

/* laplace, three periodic directions, p = 6 and 10, the exchange's down
 * fit from its own SVD: 1,000 points (not neutral), 16 of them checked */
static void test_own_fit(int p, double bound)
{
    enum { N = 1000, NC = 16 };
    t_rng r = t_rng_seed(53 + (uint64_t)p);
    double *x = t_doubles(3 * N), *q = t_doubles(N), *out = t_doubles(N), t[3 * NC], ref[4 * NC];
    double num = 0.0, den = 0.0;
    kifmm_opts o;
    kifmm_laplace *h = NULL;
    int i, rc;
    for (i = 0; i < 3 * N; i++) x[i] = t_rand01(&r);
    for (i = 0; i < N; i++) q[i] = t_rand01(&r) - 0.5;
    memset(&o, 0, sizeof o);
    o.order = p;
    o.period[0] = o.period[1] = o.period[2] = 1.0;
    rc = kifmm_laplace_create(&h, &o, N, x, N, x);
    if (!rc) rc = kifmm_laplace_evaluate(h, q, out);
    kifmm_laplace_destroy(h);
    CHECK(rc == KIFMM_SUCCESS, "create and evaluate: %s", kifmm_strerror(rc));
    for (i = 0; i < NC; i++) memcpy(t + 3 * i, x + 3 * (i * N / NC), 3 * sizeof(double));
    t_ewald_laplace(N, x, q, NC, t, 1.0, ref);
    for (i = 0; i < NC; i++) {
        num += (out[i * N / NC] - ref[4 * i]) * (out[i * N / NC] - ref[4 * i]);
        den += ref[4 * i] * ref[4 * i];
    }
    CHECK_ERR(rc ? 1.0 : sqrt(num / den), bound, "laplace, p = %d, the down fit from its own SVD", p);
    free(x);
    free(q);
    free(out);
}

int main(void)
{
    t_group("Ewald sums against lattice constants");
    test_madelung();
    test_wigner();
    t_group("Ewald sums: split, periodicity");
    test_split_and_shift();
    t_group("Ewald sums: derivatives");
    test_derivatives();
    t_group("Ewald sums against direct lattice sums");
    test_direct_lattice();
    t_group("the far images' exchange without the transposed fit, against Ewald sums");
    test_own_fit(6, 1e-5);
    test_own_fit(10, 1e-8);
    return t_finish();
}
