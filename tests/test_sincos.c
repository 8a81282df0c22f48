/* test_sincos.c - the vectorised sin and cos of kifmm_kernels.h
 * (kifmm_kernel__sincos8 with AVX-512, kifmm_kernel__sincos4 with AVX2 +
 * FMA) against the C library's sin and cos: every binade of |x| from 2^-40
 * to the largest argument the vector path takes, uniform arguments on the
 * ranges an oscillating kernel's near field meets, arguments next to
 * multiples of pi / 2 (where the reduction cancels), and the special
 * arguments (signed zeros, subnormals, the lanes past the vector path's
 * range, infinities, NaN). Without AVX2 + FMA there is no vectorised sin
 * and cos to test, and the program says so. */
#include "kifmm.h"


#include "test.h"

#if defined(__AVX512F__)
#define BODY "AVX-512F"
#define VW 8
static void sincos_vec(const double *x, double *s, double *c)
{
    __m512d vs, vc;
    kifmm_kernel__sincos8(_mm512_loadu_pd(x), &vs, &vc);
    _mm512_storeu_pd(s, vs);
    _mm512_storeu_pd(c, vc);
}
#elif defined(__AVX2__) && defined(__FMA__)
#define BODY "AVX2 + FMA"
#define VW 4
static void sincos_vec(const double *x, double *s, double *c)
{
    __m256d vs, vc;
    kifmm_kernel__sincos4(_mm256_loadu_pd(x), &vs, &vc);
    _mm256_storeu_pd(s, vs);
    _mm256_storeu_pd(c, vc);
}
#else
#define BODY "portable C"
#define VW 0
#endif

#if VW
/* the worst errors over arguments from gen(i, lane): in ulp of the C
 * library's result, and absolute */
typedef struct {
    double ulp, abs, at;
} worst;

static void measure(int64_t n, double (*gen)(t_rng *, int64_t), t_rng *r, worst *w)
{
    double x[VW], s[VW], c[VW];
    int64_t i;
    int k;
    for (i = 0; i < n; i += VW) {
        for (k = 0; k < VW; k++) x[k] = gen(r, i + k);
        sincos_vec(x, s, c);
        for (k = 0; k < VW; k++) {
            const double rs = sin(x[k]), rc = cos(x[k]);
            const double u = fmax(t_ulps(s[k], rs), t_ulps(c[k], rc));
            const double a = isnan(s[k]) || isnan(c[k]) ? HUGE_VAL : fmax(fabs(s[k] - rs), fabs(c[k] - rc));
            if (u > w->ulp) w->ulp = u, w->at = x[k];
            if (a > w->abs) w->abs = a;
        }
    }
}

/* every binade of |x| from 2^-40 to 2^20 (the last one up to
 * KIFMM_KERNEL__SINCOS_MAX), both signs */
static double gen_binades(t_rng *r, int64_t i)
{
    const int e = (int)(i % 61) - 40;
    const double x = e < 20 ? ldexp(1.0 + t_rand01(r), e)
                            : 1048576.0 + (KIFMM_KERNEL__SINCOS_MAX - 1048576.0) * t_rand01(r);
    return i / 61 & 1 ? -x : x;
}

/* uniform on [-100, 100] (an oscillating kernel's k r near its sources) */
static double gen_near(t_rng *r, int64_t i)
{
    (void)i;
    return 200.0 * t_rand01(r) - 100.0;
}

/* uniform on [-KIFMM_KERNEL__SINCOS_MAX, KIFMM_KERNEL__SINCOS_MAX] */
static double gen_wide(t_rng *r, int64_t i)
{
    (void)i;
    return KIFMM_KERNEL__SINCOS_MAX * (2.0 * t_rand01(r) - 1.0);
}

/* every multiple m pi / 2 below KIFMM_KERNEL__SINCOS_MAX, as the doubles
 * nearest it and two on each side (i = 5 (m - 1) + k), signs alternating
 * with m: where x - n pi / 2 cancels to its last bits */
static double gen_multiples(t_rng *r, int64_t i)
{
    const int64_t m = i / 5 + 1;
    double x = (double)m * 1.5707963267948966;
    int k = (int)(i % 5) - 2;
    (void)r;
    for (; k > 0; k--) x = nextafter(x, HUGE_VAL);
    for (; k < 0; k++) x = nextafter(x, -HUGE_VAL);
    return m & 1 ? -x : x;
}

static void test_sincos(void)
{
    static const struct {
        const char *what;
        double (*gen)(t_rng *, int64_t);
        int64_t n;
        double bound; /* in ulp of the C library's; measured 2, 1, 2, 1 */
    } sets[] = {{"every binade of |x| from 2^-40 to 2^20", gen_binades, 1 << 20, 3.0},
                {"uniform on [-100, 100]", gen_near, 1 << 20, 1.5},
                {"uniform on [-1.6e6, 1.6e6]", gen_wide, 1 << 19, 3.0},
                {"the doubles next to every multiple of pi / 2 up to 1.6e6", gen_multiples,
                 5 * (int64_t)(KIFMM_KERNEL__SINCOS_MAX / 1.5707963267948966), 1.5}};
    t_rng r = t_rng_seed(7);
    int j;
    t_group("vectorised sin and cos (" BODY ") against the C library's");
    for (j = 0; j < (int)(sizeof sets / sizeof sets[0]); j++) {
        worst w = {0.0, 0.0, 0.0};
        measure(sets[j].n, sets[j].gen, &r, &w);
        CHECK_ERR(w.ulp, sets[j].bound, "%s: largest error in ulp (at x = %.17g)", sets[j].what, w.at);
        CHECK_ERR(w.abs, 3.0 * ldexp(1.0, -53), "  largest absolute error");
    }
    /* special arguments, one lane each, the others ordinary */
    {
        const double sx[] = {0.0, -0.0, 1e-300, -5e-324, 0.7853981633974483, 1.6e6, 1.7e6, -3e6, 1e300,
                             HUGE_VAL, -HUGE_VAL, NAN};
        double x[VW], s[VW], c[VW];
        int i, k, bad = 0;
        for (i = 0; i < (int)(sizeof sx / sizeof sx[0]); i++)
            for (j = 0; j < VW; j++) {
                for (k = 0; k < VW; k++) x[k] = 0.5 + k;
                x[j] = sx[i];
                sincos_vec(x, s, c);
                for (k = 0; k < VW; k++) {
                    const double rs = sin(x[k]), rc = cos(x[k]);
                    if (isnan(rs)) bad += !isnan(s[k]) || !isnan(c[k]);
                    else bad += t_ulps(s[k], rs) > 3.0 || t_ulps(c[k], rc) > 3.0 ||
                                (rs == 0.0 && signbit(s[k]) != signbit(rs));
                }
            }
        CHECK(bad == 0, "special arguments in every lane: +-0 (the sign of sin kept), tiny, subnormal, "
                        "pi / 4, the range's edge and past it, huge, +-inf, NaN (%d wrong)", bad);
    }
}
#endif

int main(void)
{
#if VW
    test_sincos();
#else
    t_group("no vectorised sin and cos in this build (" BODY "): nothing to test");
#endif
    return t_finish();
}
