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

#include <float.h>

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
/* |a - b| in units of the last place of b (2^-1074 below the normal range) */
static double ulps(double a, double b)
{
    int e;
    double u;
    if (a == b) return 0.0;
    if (b == 0.0 || fabs(b) < DBL_MIN) u = ldexp(1.0, -1074);
    else {
        frexp(b, &e);
        u = ldexp(1.0, e - 53);
    }
    return fabs(a - b) / u;
}

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
            const double u = fmax(ulps(s[k], rs), ulps(c[k], rc));
            const double a = fmax(fabs(s[k] - rs), fabs(c[k] - rc));
            if (u > w->ulp) w->ulp = u, w->at = x[k];
            if (a > w->abs) w->abs = a;
        }
    }
}

/* every binade of |x| from 2^-40 to 2^20, both signs */
static double gen_binades(t_rng *r, int64_t i)
{
    const int e = (int)(i % 61) - 40;
    const double x = ldexp(1.0 + t_rand01(r), e);
    return fabs(x) <= KIFMM_KERNEL__SINCOS_MAX ? (i & 1 ? -x : x) : 1.5e6;
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

/* the doubles next to m pi / 2, up to 2^20 of them: where x - n pi / 2
 * cancels to its last bits */
static double gen_multiples(t_rng *r, int64_t i)
{
    const double m = floor(t_rand01(r) * 1000000.0) + 1.0;
    double x = m * 1.5707963267948966;
    int k = (int)(i % 7) - 3;
    for (; k > 0; k--) x = nextafter(x, HUGE_VAL);
    for (; k < 0; k++) x = nextafter(x, -HUGE_VAL);
    return i & 1 ? -x : x;
}

static void test_sincos(void)
{
    static const struct {
        const char *what;
        double (*gen)(t_rng *, int64_t);
        int64_t n;
    } sets[] = {{"every binade of |x| from 2^-40 to 2^20", gen_binades, 1 << 20},
                {"uniform on [-100, 100]", gen_near, 1 << 20},
                {"uniform on [-1.6e6, 1.6e6]", gen_wide, 1 << 19},
                {"next to multiples of pi / 2 up to 1.6e6", gen_multiples, 1 << 18}};
    t_rng r = t_rng_seed(7);
    int j;
    t_group("vectorised sin and cos (" BODY ") against the C library's");
    for (j = 0; j < (int)(sizeof sets / sizeof sets[0]); j++) {
        worst w = {0.0, 0.0, 0.0};
        measure(sets[j].n, sets[j].gen, &r, &w);
        CHECK_ERR(w.ulp, 2.0, "%s: largest error in ulp (at x = %.17g)", sets[j].what, w.at);
        CHECK_ERR(w.abs, ldexp(1.0, -52), "  largest absolute error");
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
                    else bad += ulps(s[k], rs) > 2.0 || ulps(c[k], rc) > 2.0 ||
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
