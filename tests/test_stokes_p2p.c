/* test_stokes_p2p.c - the Stokeslet's near-field hooks (one-way and mutual,
 * double and float) against sums in long double written here from the
 * formula u_i = sum_j (f_i / r + d_i (d . f) / r^3) / (8 pi mu), on blocks
 * of every size around the vector widths, with coincident pairs (skipped)
 * and two calls adding up. */
#include "kifmm.h"
#define KIFMM_KERNEL stokes
#include "kifmm.h"

#include "test.h"

/* out[3 i + k] += scale u_k(t_i) from sources s with forces f, long double;
 * mag: the sums of |terms| */
static void ref(double mu, int64_t nt, const double *t, int64_t ns, const double *s,
                const double *f, double scale, long double *out, long double *mag)
{
    const long double c = scale / (8.0L * 3.14159265358979323846264L * mu);
    int64_t i, j;
    int k;
    for (i = 0; i < nt; i++)
        for (j = 0; j < ns; j++) {
            long double d[3], r2 = 0, ri, df = 0;
            for (k = 0; k < 3; k++) {
                d[k] = (long double)t[3 * i + k] - (long double)s[3 * j + k];
                r2 += d[k] * d[k];
                df += d[k] * f[3 * j + k];
            }
            if (r2 == 0) continue;
            ri = 1.0L / sqrtl(r2);
            for (k = 0; k < 3; k++) {
                long double a = c * f[3 * j + k] * ri, b = c * d[k] * df * ri * ri * ri;
                out[3 * i + k] += a + b;
                mag[3 * i + k] += fabsl(a) + fabsl(b);
            }
        }
}

/* points: 3 n coordinates in [-0.5, 0.5), as doubles (xyz) and structure of
 * arrays in T; every third target on a source */
typedef struct {
    int64_t n;
    double *x, *f;
} blk;

static blk make_blk(t_rng *r, int64_t n)
{
    blk b;
    int64_t i;
    b.n = n;
    b.x = t_doubles(3 * n + 3);
    b.f = t_doubles(3 * n + 3);
    for (i = 0; i < 3 * n; i++) {
        b.x[i] = t_uniform(r, -0.5, 0.5);
        b.f[i] = t_uniform(r, -1.0, 1.0);
    }
    return b;
}

#define SOA(T, b, out)                                                                     \
    do {                                                                                   \
        int64_t i_;                                                                        \
        int k_;                                                                            \
        for (k_ = 0; k_ < 3; k_++)                                                         \
            for (i_ = 0; i_ < (b).n; i_++) (out)[k_ * (b).n + i_] = (T)(b).x[3 * i_ + k_];  \
    } while (0)

/* largest |hook - 2 ref| / (2 mag + tiny) over the outputs */
static double worst_of(int64_t n, const double *out, const long double *ro, const long double *rm)
{
    double w = 0.0;
    int64_t i;
    for (i = 0; i < 3 * n; i++) {
        double e = (double)(fabsl((long double)out[i] - 2.0L * ro[i]) / (2.0L * rm[i] + 1e-300L));
        if (!(e <= w)) w = e; /* NaN sticks */
    }
    return w;
}

/* T = double or float: one-way (targets a, sources b) and mutual (a <-> b) */
#define DEFINE_CASE(T, SUF)                                                                \
    static void case_##SUF(double mu, const blk *a, const blk *b, double *w1, double *w2)   \
    {                                                                                      \
        T *pa = (T *)calloc((size_t)(3 * a->n + 3), sizeof(T));                            \
        T *pb = (T *)calloc((size_t)(3 * b->n + 3), sizeof(T));                            \
        T *fa = (T *)calloc((size_t)(3 * a->n + 3), sizeof(T));                            \
        T *fb = (T *)calloc((size_t)(3 * b->n + 3), sizeof(T));                            \
        T *oa = (T *)calloc((size_t)(3 * a->n + 3), sizeof(T));                            \
        T *ob = (T *)calloc((size_t)(3 * b->n + 3), sizeof(T));                            \
        double *da = t_doubles(3 * a->n + 3), *db = t_doubles(3 * b->n + 3);               \
        long double *ra = (long double *)calloc((size_t)(3 * a->n + 3), sizeof(long double)); \
        long double *ma = (long double *)calloc((size_t)(3 * a->n + 3), sizeof(long double)); \
        long double *rb = (long double *)calloc((size_t)(3 * b->n + 3), sizeof(long double)); \
        long double *mb = (long double *)calloc((size_t)(3 * b->n + 3), sizeof(long double)); \
        double *ax = t_doubles(3 * a->n + 3), *bx = t_doubles(3 * b->n + 3);              \
        double w1a;                                                                        \
        int64_t i;                                                                         \
        int k;                                                                             \
        SOA(T, *a, pa);                                                                    \
        SOA(T, *b, pb);                                                                    \
        /* the reference sees the coordinates and forces as the hook does */               \
        for (i = 0; i < 3 * a->n; i++) { ax[i] = (double)(T)a->x[i]; fa[i] = (T)a->f[i]; }  \
        for (i = 0; i < 3 * b->n; i++) { bx[i] = (double)(T)b->x[i]; fb[i] = (T)b->f[i]; }  \
        for (i = 0; i < 3 * a->n; i++) da[i] = (double)fa[i];                              \
        for (i = 0; i < 3 * b->n; i++) db[i] = (double)fb[i];                              \
        ref(mu, a->n, ax, b->n, bx, db, 1.5, ra, ma);                                      \
        ref(mu, b->n, bx, a->n, ax, da, 1.5, rb, mb);                                      \
        for (k = 0; k < 2; k++)                                                            \
            kifmm_kernel_stokes_p2p##SUF(&mu, pa, pa + a->n, pa + 2 * a->n, a->n, pb,      \
                                         pb + b->n, pb + 2 * b->n, fb, b->n, (T)1.5, oa);  \
        for (i = 0; i < 3 * a->n; i++) da[i] = (double)oa[i];                              \
        w1a = worst_of(a->n, da, ra, ma);                                                  \
        for (i = 0; i < 3 * a->n; i++) oa[i] = 0;                                          \
        for (k = 0; k < 2; k++)                                                            \
            kifmm_kernel_stokes_p2ps##SUF(&mu, pa, pa + a->n, pa + 2 * a->n, fa, a->n, pb, \
                                          pb + b->n, pb + 2 * b->n, fb, b->n, (T)1.5, oa, ob); \
        for (i = 0; i < 3 * a->n; i++) da[i] = (double)oa[i];                              \
        for (i = 0; i < 3 * b->n; i++) db[i] = (double)ob[i];                              \
        *w2 = worst_of(a->n, da, ra, ma);                                                  \
        *w1 = worst_of(b->n, db, rb, mb); /* B's side, NaN sticks */                       \
        if (!(*w1 <= *w2)) *w2 = *w1;                                                      \
        *w1 = w1a;                                                                         \
        free(pa); free(pb); free(fa); free(fb); free(oa); free(ob); free(da); free(db);    \
        free(ra); free(ma); free(rb); free(mb); free(ax); free(bx);                        \
    }
DEFINE_CASE(double, )
DEFINE_CASE(float, f)

static void test_hooks(int fl, double bound)
{
    static const int64_t sizes[] = {0, 1, 3, 4, 5, 7, 8, 9, 15, 16, 17, 63, 64, 65, 129};
    static const double mus[] = {1.0, 0.01};
    const int nsz = (int)(sizeof sizes / sizeof sizes[0]);
    t_rng r = t_rng_seed(fl ? 23 : 21);
    double w1 = 0.0, w2 = 0.0;
    int a, b, m;
    t_group(fl ? "stokes float hooks against long double" : "stokes double hooks against long double");
    for (m = 0; m < 2; m++)
        for (a = 0; a < nsz; a++)
            for (b = 0; b < nsz; b++) {
                blk A = make_blk(&r, sizes[a]), B = make_blk(&r, sizes[b]);
                double e1, e2;
                int64_t i;
                int k;
                for (i = 0; i < A.n && i < B.n; i += 3) /* coincident pairs */
                    for (k = 0; k < 3; k++) A.x[3 * i + k] = B.x[3 * i + k];
                if (fl) case_f(mus[m], &A, &B, &e1, &e2);
                else case_(mus[m], &A, &B, &e1, &e2);
                if (!(e1 <= w1)) w1 = e1;
                if (!(e2 <= w2)) w2 = e2;
                free(A.x); free(A.f); free(B.x); free(B.f);
            }
    CHECK_ERR(w1, bound, "one-way: largest error relative to the sum of |terms| (blocks of 0 "
                         "to 129, two calls adding up, mu 1 and 0.01)");
    CHECK_ERR(w2, bound, "mutual: the same, both directions");
}

int main(void)
{
    CHECK((kifmm_kernel_stokes_HAS & (KIFMM_HAS_P2P | KIFMM_HAS_P2PS | KIFMM_HAS_P2PF |
                                      KIFMM_HAS_P2PSF)) ==
              (KIFMM_HAS_P2P | KIFMM_HAS_P2PS | KIFMM_HAS_P2PF | KIFMM_HAS_P2PSF),
          "the hooks are announced");
    /* a few units of rounding per term: 8 times the machine epsilon */
    test_hooks(0, 8.0 * DBL_EPSILON);
    test_hooks(1, 8.0 * FLT_EPSILON);
    return t_finish();
}
