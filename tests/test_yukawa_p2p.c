/* test_yukawa_p2p.c - the vectorised exp of kifmm_kernels.h against the C
 * library's exp over its whole domain, and the Yukawa near-field hooks
 * (yukawa, yukawa_grad) against sums in long double written here from the
 * formulas, one-way and mutual, in every build (without AVX2 + FMA the
 * hooks use the C library's exp, and there is no vectorised exp to test). */
#include "kifmm.h"
#define KIFMM_KERNEL yukawa_grad
#include "kifmm.h"
#define KIFMM_KERNEL yukawa
#include "kifmm.h"

#include <float.h>

#include "test.h"

#if defined(__AVX512F__)
#define BODY "AVX-512F"
#define VW 8
static void exp_vec(const double *x, double *y)
{
    _mm512_storeu_pd(y, kifmm_kernel__expn8(_mm512_sub_pd(_mm512_setzero_pd(), _mm512_loadu_pd(x))));
}
static void exps_vec(const double *x, double *y, int mid) /* the short series, exp(-x) */
{
    const __m512d v = _mm512_loadu_pd(x);
    _mm512_storeu_pd(y, mid == 2 ? KIFMM_KERNEL__EXPL8(v) : mid ? KIFMM_KERNEL__EXPM8(v) : KIFMM_KERNEL__EXPS8(v));
}
#elif defined(__AVX2__) && defined(__FMA__)
#define BODY "AVX2 + FMA"
#define VW 4
static void exp_vec(const double *x, double *y)
{
    _mm256_storeu_pd(y, kifmm_kernel__expn4(_mm256_sub_pd(_mm256_setzero_pd(), _mm256_loadu_pd(x))));
}
static void exps_vec(const double *x, double *y, int mid)
{
    const __m256d v = _mm256_loadu_pd(x);
    _mm256_storeu_pd(y, mid == 2 ? KIFMM_KERNEL__EXPL4(v) : mid ? KIFMM_KERNEL__EXPM4(v) : KIFMM_KERNEL__EXPS4(v));
}
#else
#define BODY "portable C"
#define VW 0
#endif

#if VW
static void test_exp(void)
{
    const int64_t n = 1 << 20;
    double x[VW], y[VW], worst = 0.0, worst_sub = 0.0, at = 0.0;
    t_rng r = t_rng_seed(3);
    int64_t i;
    int k, e, bad = 0;
    t_group("vectorised exp against the C library's exp");
    /* every binade of |x| from 2^-30 to 2^9, then uniform on [-745.2, 0] */
    for (i = 0; i < n; i += VW) {
        for (k = 0; k < VW; k++) {
            e = (int)((i / VW) % 40) - 30;
            x[k] = (i < n / 2) ? -ldexp(1.0 + t_rand01(&r), e) : -745.2 * t_rand01(&r);
            if (x[k] < -745.2) x[k] = -745.2;
        }
        exp_vec(x, y);
        for (k = 0; k < VW; k++) {
            double ref = exp(x[k]), u = t_ulps(y[k], ref);
            if (ref >= DBL_MIN) {
                if (u > worst) {
                    worst = u;
                    at = x[k];
                }
            } else if (u > worst_sub)
                worst_sub = u;
        }
    }
    CHECK_ERR(worst, 2.0, "largest error in ulp, normal results (at x = %.17g)", at);
    CHECK_ERR(worst_sub, 1.0, "largest error in units of 2^-1074, subnormal results");
    /* special arguments, one lane each */
    {
        const double sx[] = {0.0, -0.0, -1e-300, -5e-324, -708.3964185322641, -708.4,
                             -745.1332191019411, -745.2, -746.0, -1000.0, -INFINITY, NAN};
        const double want[] = {1.0, 1.0, 1.0, 1.0, -1, -1, -1, -1, 0.0, 0.0, 0.0, 0.0};
        for (i = 0; i < (int64_t)(sizeof sx / sizeof sx[0]); i++) {
            for (k = 0; k < VW; k++) x[k] = sx[i];
            exp_vec(x, y);
            if (want[i] >= 0)
                bad += y[0] != want[i];
            else
                bad += t_ulps(y[0], exp(sx[i])) > 1.0;
        }
        CHECK(bad == 0, "special arguments: 0, -0, -tiny, the subnormal edge, below it, -inf, NaN "
                        "(%d wrong)", bad);
    }
    /* the polynomials of the hooks' small lambda r: degree 6 on [0, YSHORT],
     * degree 8 on [0, YMID], degree 9 on [0, YLONG] */
    for (e = 0; e < 3; e++) {
        const double top = e == 2 ? KIFMM_KERNEL__YLONG : e ? KIFMM_KERNEL__YMID : KIFMM_KERNEL__YSHORT;
        worst = 0.0;
        for (i = 0; i < n / 4; i += VW) {
            for (k = 0; k < VW; k++)
                x[k] = i < n / 8 ? ldexp(1.0 + t_rand01(&r), -(int)((i / VW) % 50) - 6) * top * 16.0
                                 : top * t_rand01(&r);
            if (i == 0) x[0] = 0.0, x[1] = top;
            exps_vec(x, y, e);
            for (k = 0; k < VW; k++) {
                const double u = t_ulps(y[k], exp(-x[k]));
                if (u > worst) {
                    worst = u;
                    at = x[k];
                }
            }
        }
        CHECK_ERR(worst, 2.0, "polynomial of degree %d on [0, %g], largest error in ulp (at y = %.17g)",
                  e == 2 ? 9 : e ? 8 : 6, top, at);
    }
}

#endif

/* out[i td + k] += scale sum_j K_k(t_i - s_j) q_j in long double, K the
 * Yukawa potential exp(-lam r) / (4 pi r) (k = 0) and its gradient
 * -(1 + lam r) exp(-lam r) d / (4 pi r^3) (k = 1..3); mag: sums of |terms| */
static void ref(int td, double lam, int64_t nt, const double *t, int64_t ns, const double *s,
                const double *q, double scale, long double *out, long double *mag)
{
    int64_t i, j;
    int k;
    for (i = 0; i < nt; i++)
        for (j = 0; j < ns; j++) {
            long double d[3], r2 = 0, rr, p, g;
            for (k = 0; k < 3; k++) {
                d[k] = (double)(t[3 * i + k] - s[3 * j + k]);
                r2 += d[k] * d[k];
            }
            if (r2 == 0) continue;
            rr = sqrtl(r2);
            p = scale * q[j] * expl(-(long double)lam * rr) / (4.0L * 3.14159265358979323846264L * rr);
            g = -p * (1.0L + (long double)lam * rr) / r2;
            out[i * td] += p;
            mag[i * td] += fabsl(p);
            for (k = 1; k < td; k++) {
                out[i * td + k] += g * d[k - 1];
                mag[i * td + k] += fabsl(g * d[k - 1]);
            }
        }
}

typedef void (*hook_fn)(const double *, const double *, const double *, const double *, int64_t,
                        const double *, const double *, const double *, const double *, int64_t,
                        double, double *);
typedef void (*mutual_fn)(const double *, const double *, const double *, const double *,
                          const double *, int64_t, const double *, const double *,
                          const double *, const double *, int64_t, double, double *, double *);

/* |out - 2 ref| / (2 mag) over n outputs (two calls added up), the worst so
 * far in *worst (NaN sticks); terms below the normal range (lambda r in the
 * hundreds) keep fewer digits in double: an absolute floor of 1e-286 */
static void worst_rel(int64_t n, const double *out, const long double *ro, const long double *rm,
                      double *worst)
{
    int64_t i;
    for (i = 0; i < n; i++) {
        double e = (double)(fabsl((long double)out[i] - 2.0L * ro[i]) / (2.0L * rm[i] + 1e-286L));
        if (!(e <= *worst)) *worst = e;
    }
}

/* One hook, one-way (`one`) or mutual (`mut`: A's sums from B and B's from
 * A), against the long double sums: blocks of every size around the vector
 * widths and the stack block (64), coincident pairs across A and B, two
 * calls adding up, guards after each output, lambda over its useful range. */
static void test_hook(const char *name, hook_fn one, mutual_fn mut, int td)
{
    static const int64_t sizes[] = {0, 1, 3, 4, 5, 7, 8, 9, 15, 16, 17, 63, 64, 65, 129};
    /* 1e-3 and 0.015: every pass by the polynomial of degree 6 (lambda
     * times the farthest distance, sqrt(3), below 1/32); 0.05: of degree 8
     * (below 1/8) or 6; 0.12: of degree 9 (below 1/4), 8 or 6; 1 and up:
     * the full exp */
    static const double lams[] = {1e-3, 0.015, 0.05, 0.12, 1.0, 30.0, 1e3};
    const int nsz = (int)(sizeof sizes / sizeof sizes[0]);
    t_rng r = t_rng_seed(mut ? 12 : 11);
    int a, b, l, k, guards = 1;
    t_group(name);
    for (l = 0; l < (int)(sizeof lams / sizeof lams[0]); l++) {
        double worst = 0.0;
        for (a = 0; a < nsz; a++)
            for (b = 0; b < nsz; b++) {
                const int64_t na = sizes[a], nb = sizes[b];
                double *pa = t_doubles(3 * na + 3), *pb = t_doubles(3 * nb + 3);
                double *qa = t_doubles(na + 1), *qb = t_doubles(nb + 1);
                double *soa = t_doubles(3 * (na + nb) + 6);
                double *oa = t_doubles(td * na + 1), *ob = t_doubles(td * nb + 1);
                long double *ra = (long double *)calloc((size_t)(td * na + 1), sizeof(long double));
                long double *ma = (long double *)calloc((size_t)(td * na + 1), sizeof(long double));
                long double *rb = (long double *)calloc((size_t)(td * nb + 1), sizeof(long double));
                long double *mb = (long double *)calloc((size_t)(td * nb + 1), sizeof(long double));
                int64_t i;
                for (i = 0; i < 3 * na; i++) pa[i] = t_uniform(&r, -0.5, 0.5);
                for (i = 0; i < 3 * nb; i++) pb[i] = t_uniform(&r, -0.5, 0.5);
                for (i = 0; i < na && i < nb; i += 3) /* coincident pairs */
                    for (k = 0; k < 3; k++) pa[3 * i + k] = pb[3 * i + k];
                for (i = 0; i < na; i++) qa[i] = t_uniform(&r, -1.0, 1.0);
                for (i = 0; i < nb; i++) qb[i] = t_uniform(&r, -1.0, 1.0);
                for (i = 0; i <= td * na; i++) oa[i] = i < td * na ? 0.0 : 7.0;
                for (i = 0; i <= td * nb; i++) ob[i] = i < td * nb ? 0.0 : 7.0;
                for (k = 0; k < 3; k++) {
                    for (i = 0; i < na; i++) soa[k * na + i] = pa[3 * i + k];
                    for (i = 0; i < nb; i++) soa[3 * na + k * nb + i] = pb[3 * i + k];
                }
                for (k = 0; k < 2; k++) {
                    if (mut)
                        mut(&lams[l], soa, soa + na, soa + 2 * na, qa, na, soa + 3 * na,
                            soa + 3 * na + nb, soa + 3 * na + 2 * nb, qb, nb, 1.5, oa, ob);
                    else
                        one(&lams[l], soa, soa + na, soa + 2 * na, na, soa + 3 * na,
                            soa + 3 * na + nb, soa + 3 * na + 2 * nb, qb, nb, 1.5, oa);
                }
                guards &= oa[td * na] == 7.0 && ob[td * nb] == 7.0;
                for (i = 0; !mut && i < td * nb; i++) guards &= ob[i] == 0.0; /* not passed */
                ref(td, lams[l], na, pa, nb, pb, qb, 1.5, ra, ma);
                worst_rel(td * na, oa, ra, ma, &worst);
                if (mut) {
                    ref(td, lams[l], nb, pb, na, pa, qa, 1.5, rb, mb);
                    worst_rel(td * nb, ob, rb, mb, &worst);
                }
                free(pa);
                free(pb);
                free(qa);
                free(qb);
                free(soa);
                free(oa);
                free(ob);
                free(ra);
                free(ma);
                free(rb);
                free(mb);
            }
        /* a relative error u of r (a few ulp) is one of lambda r u in exp(-lambda r):
         * the bound grows with lambda times the largest distance, sqrt(3) */
        CHECK_ERR(worst, 4.4e-16 * (10.0 + lams[l] * 1.7321),
                  "lambda %g: largest error relative to the sum of |terms|%s, blocks of 0 to "
                  "129, two calls adding up", lams[l], mut ? ", both sides" : "");
    }
    CHECK(guards, "nothing written past the outputs");
}

int main(void)
{
    printf("test_yukawa_p2p: body %s\n", BODY);
    CHECK((kifmm_kernel_yukawa_HAS & KIFMM_HAS_P2P) && (kifmm_kernel_yukawa_grad_HAS & KIFMM_HAS_P2P),
          "the one-way hooks are announced");
#if VW
    test_exp();
#endif
    test_hook("yukawa hook against long double", kifmm_kernel_yukawa_p2p, NULL, 1);
    test_hook("yukawa_grad hook against long double", kifmm_kernel_yukawa_grad_p2p, NULL, 4);
    CHECK((kifmm_kernel_yukawa_HAS & KIFMM_HAS_P2PS) &&
              (kifmm_kernel_yukawa_grad_HAS & KIFMM_HAS_P2PS),
          "the mutual hooks are announced");
    test_hook("yukawa mutual hook against long double", NULL, kifmm_kernel_yukawa_p2ps, 1);
    test_hook("yukawa_grad mutual hook against long double", NULL, kifmm_kernel_yukawa_grad_p2ps, 4);
    return t_finish();
}
