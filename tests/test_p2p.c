/* test_p2p.c - the near-field hooks kifmm_kernel_laplace_p2p and
 * kifmm_kernel_laplace_grad_p2p against independent scalar sums (long double),
 * and whole FMM runs that go through them.
 *
 * The hooks are compiled for the ISA the compiler targets (AVX-512F, AVX2 +
 * FMA, or portable C); the first line of output names the body under test.
 */
#include "kifmm.h"
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"

#include "test.h"

#if !(kifmm_kernel_laplace_HAS & KIFMM_HAS_P2P) || !(kifmm_kernel_laplace_grad_HAS & KIFMM_HAS_P2P)
#error "test_p2p.c: kifmm_kernels.h defines no near-field hook"
#endif

#if defined(__AVX512F__)
#define BODY "AVX-512F"
#elif defined(__AVX2__) && defined(__FMA__)
#define BODY "AVX2 + FMA"
#elif defined(KIFMM_KERNEL__NEON)
#define BODY "NEON (laplace, laplace_grad; portable C for the rest)"
#else
#define BODY "portable C"
#endif

typedef void (*hook_fn)(const double *, const double *, const double *, const double *, int64_t,
                        const double *, const double *, const double *, const double *, int64_t,
                        double, double *);

#define PI_L 3.141592653589793238462643383279502884L

/* inc[i * td + k] = scale * sum_j K_k(t_i - s_j) q_j in long double, from the
 * double differences t - s (as any implementation forms them); td = 1: the
 * potential, td = 4: potential and gradient.  Pairs with r == 0 skipped.
 * mag[i * td + k]: the same sums of |terms|, the scale of rounding errors. */
static void ref_sum(int td, int64_t nt, const double *tx, const double *ty, const double *tz,
                    int64_t ns, const double *sx, const double *sy, const double *sz,
                    const double *q, double scale, long double *inc, long double *mag)
{
    int64_t i, j;
    int k;
    for (i = 0; i < nt; i++) {
        long double v[4] = {0, 0, 0, 0}, a[4] = {0, 0, 0, 0};
        for (j = 0; j < ns; j++) {
            double dx = tx[i] - sx[j], dy = ty[i] - sy[j], dz = tz[i] - sz[j];
            long double lx = dx, ly = dy, lz = dz, r2 = lx * lx + ly * ly + lz * lz, inv, qi3;
            long double term[4];
            if (r2 == 0) continue;
            inv = 1.0L / sqrtl(r2);
            qi3 = q[j] * inv * inv * inv;
            term[0] = q[j] * inv;
            term[1] = -qi3 * lx;
            term[2] = -qi3 * ly;
            term[3] = -qi3 * lz;
            for (k = 0; k < 4; k++) {
                v[k] += term[k];
                a[k] += fabsl(term[k]);
            }
        }
        for (k = 0; k < td; k++) {
            inc[i * td + k] = scale * v[k] / (4 * PI_L);
            mag[i * td + k] = fabsl(scale) * a[k] / (4 * PI_L);
        }
    }
}

/* A point set with structure-of-arrays coordinates, each array shifted by one
 * double from the malloc'ed block so that no pointer is 32-byte aligned. */
typedef struct pts {
    double *mem, *x, *y, *z;
} pts;

static pts pts_new(int64_t n)
{
    pts p;
    p.mem = t_doubles(3 * (n + 1));
    p.x = p.mem + 1;
    p.y = p.x + n + 1;
    p.z = p.y + n + 1;
    return p;
}

/* ------------------------------------------------------------------------ */
/* Sums over all block shapes                                               */
/* ------------------------------------------------------------------------ */

#define GUARD 8
#define SENTINEL 12345.678

static const int64_t sizes[] = {0, 1, 3, 7, 8, 9, 15, 16, 17, 63, 64, 65, 200};
#define NSIZES ((int)(sizeof sizes / sizeof sizes[0]))

/* One (nt, ns) block: targets and sources in the unit cube, every third
 * target placed on a source (coincident pairs), out prefilled with values in
 * [-0.01, 0.01] (about the size of one term) and guarded on both sides; ref =
 * prefill + the long double sum.  Two errors:
 *   err[0]: charges in (0, 1], max_i |out_i - ref_i| / max_i |ref_i|, the
 *           potential and the gradient (Euclidean norm over its 3 components)
 *           separately, the larger of the two;
 *   err[1]: charges in [-1, 1], each component's error relative to the max
 *           over targets of |prefill| + sum of |terms| (with mixed signs one
 *           target's sum may cancel to anything, whatever the summation order).
 * Both are 1 if nothing is to be added (every pair coincident, or nt or ns 0)
 * and out differs from the prefill in any bit.  *guards_ok is cleared when a
 * value around out[0 .. nt*td-1] changed. */
static void one_block(hook_fn hook, int td, int64_t nt, int64_t ns, double scale, t_rng *r,
                      double err[2], int *guards_ok)
{
    pts t = pts_new(nt), s = pts_new(ns);
    double *qm = t_doubles(ns + 1), *q = qm + 1;
    double *om = t_doubles(nt * td + 2 * GUARD), *out = om + GUARD, *pre = t_doubles(nt * td);
    size_t lbytes = (size_t)(nt * td + 1) * sizeof(long double);
    long double *inc = (long double *)t_malloc_or_die(lbytes);
    long double *mag = (long double *)t_malloc_or_die(lbytes);
    int64_t i, j;
    int k, pass;

    for (j = 0; j < ns; j++) {
        s.x[j] = t_rand01(r);
        s.y[j] = t_rand01(r);
        s.z[j] = t_rand01(r);
    }
    for (i = 0; i < nt; i++) {
        if (ns > 0 && i % 3 == 0) {
            j = (i * 7) % ns;
            t.x[i] = s.x[j];
            t.y[i] = s.y[j];
            t.z[i] = s.z[j];
        } else {
            t.x[i] = t_rand01(r);
            t.y[i] = t_rand01(r);
            t.z[i] = t_rand01(r);
        }
    }
    for (pass = 0; pass < 2; pass++) {
        long double num[2] = {0, 0}, den[2] = {0, 0};
        int bad = 0, zero = 1, same = 1;
        for (j = 0; j < ns; j++) q[j] = pass == 0 ? 1.0 - t_rand01(r) : t_uniform(r, -1.0, 1.0);
        for (i = 0; i < nt * td + 2 * GUARD; i++) om[i] = SENTINEL;
        for (i = 0; i < nt * td; i++) out[i] = pre[i] = t_uniform(r, -0.01, 0.01);

        hook(NULL, t.x, t.y, t.z, nt, s.x, s.y, s.z, q, ns, scale, out);
        ref_sum(td, nt, t.x, t.y, t.z, ns, s.x, s.y, s.z, q, scale, inc, mag);

        for (i = 0; i < GUARD; i++)
            if (om[i] != SENTINEL || out[nt * td + i] != SENTINEL) *guards_ok = 0;
        for (i = 0; i < nt; i++) {
            long double dd[2] = {0, 0}, rr[2] = {0, 0};
            for (k = 0; k < td; k++) {
                const int c = k > 0; /* 0: potential, 1: gradient */
                long double d = (long double)out[i * td + k] - (pre[i * td + k] + inc[i * td + k]);
                if (d != d) bad = 1;
                if (mag[i * td + k] != 0) zero = 0;
                if (out[i * td + k] != pre[i * td + k]) same = 0;
                if (pass == 0) {
                    long double ref = pre[i * td + k] + inc[i * td + k];
                    dd[c] += d * d;
                    rr[c] += ref * ref;
                } else {
                    long double m = fabsl((long double)pre[i * td + k]) + mag[i * td + k];
                    if (fabsl(d) > num[c]) num[c] = fabsl(d);
                    if (m > den[c]) den[c] = m;
                }
            }
            if (pass == 0)
                for (k = 0; k < 2; k++) {
                    if (sqrtl(dd[k]) > num[k]) num[k] = sqrtl(dd[k]);
                    if (sqrtl(rr[k]) > den[k]) den[k] = sqrtl(rr[k]);
                }
        }
        err[pass] = bad ? NAN : 0.0;
        for (k = 0; k < (td > 1 ? 2 : 1) && !bad; k++)
            if (den[k] > 0 && (double)(num[k] / den[k]) > err[pass])
                err[pass] = (double)(num[k] / den[k]);
        if (zero && !same) err[pass] = 1.0; /* nothing to add, yet out changed */
    }
    free(t.mem);
    free(s.mem);
    free(qm);
    free(om);
    free(pre);
    free(inc);
    free(mag);
}

static void test_blocks(const char *name, hook_fn hook, int td, uint64_t seed)
{
    t_rng r = t_rng_seed(seed);
    int a, b, p, guards_ok = 1;
    t_group(name);
    for (a = 0; a < NSIZES; a++) {
        double worst[2] = {0, 0};
        int64_t worst_ns[2] = {-1, -1};
        for (b = 0; b < NSIZES; b++) {
            double scale = 0.5 + 0.25 * (double)(b % 5); /* 0.5 .. 1.5 */
            double e[2];
            one_block(hook, td, sizes[a], sizes[b], scale, &r, e, &guards_ok);
            for (p = 0; p < 2; p++)
                if (!(e[p] <= worst[p])) {
                    worst[p] = e[p];
                    worst_ns[p] = sizes[b];
                }
        }
        CHECK_ERR(worst[0], 1e-14, "%s nt=%3ld, all ns: vs max|ref| (worst ns=%ld)", name,
                  (long)sizes[a], (long)worst_ns[0]);
        CHECK_ERR(worst[1], 1e-14, "%s nt=%3ld, all ns, q of both signs: vs sum|terms|", name,
                  (long)sizes[a]);
    }
    CHECK(guards_ok, "%s wrote outside out[0 .. nt*%d-1]", name, td);
}

/* ------------------------------------------------------------------------ */
/* Many-vector hooks (_p2pn): each vector against the same long double sums  */
/* ------------------------------------------------------------------------ */

#if (kifmm_kernel_laplace_HAS & KIFMM_HAS_P2PN) && (kifmm_kernel_laplace_grad_HAS & KIFMM_HAS_P2PN)
typedef void (*hookn_fn)(const double *, const double *, const double *, const double *,
                         int64_t, const double *, const double *, const double *,
                         const double *, int64_t, int, size_t, double, double *, size_t);

/* The many-vector hook under test, the number of vectors, the vector that
 * carries the block's charges and outputs (the others get random ones), and
 * the output components per target. */
static hookn_fn g_many;
static int g_nrhs, g_slot, g_td;
static t_rng g_rng;

/* A hook_fn for one_block: runs g_many on g_nrhs vectors (odd strides
 * between them) and hands back vector g_slot; the other vectors' outputs must
 * change only where their own charges say. */
static void many_as_one(const double *prm, const double *tx, const double *ty, const double *tz,
                        int64_t nt, const double *sx, const double *sy, const double *sz,
                        const double *q, int64_t ns, double scale, double *out)
{
    const size_t qld = (size_t)ns + 3, old = (size_t)nt * g_td + 5;
    double *qa = t_doubles((int64_t)(g_nrhs * qld + 1)), *oa = t_doubles((int64_t)(g_nrhs * old + 1));
    size_t i;
    int r;
    for (i = 0; i < g_nrhs * qld; i++) qa[i] = t_uniform(&g_rng, -1.0, 1.0);
    for (i = 0; i < g_nrhs * old; i++) oa[i] = SENTINEL;
    for (r = 0; r < g_nrhs; r++)
        for (i = 0; i < (size_t)nt * g_td; i++) oa[r * old + i] = t_uniform(&g_rng, -0.01, 0.01);
    for (i = 0; i < (size_t)ns; i++) qa[g_slot * qld + i] = q[i];
    for (i = 0; i < (size_t)nt * g_td; i++) oa[g_slot * old + i] = out[i];
    g_many(prm, tx, ty, tz, nt, sx, sy, sz, qa, ns, g_nrhs, qld, scale, oa, old);
    for (i = 0; i < (size_t)nt * g_td; i++) out[i] = oa[g_slot * old + i];
    for (r = 0; r < g_nrhs; r++) /* the gaps between output vectors are untouched */
        for (i = (size_t)nt * g_td; i < old; i++)
            if (oa[r * old + i] != SENTINEL) out[0] = NAN;
    free(qa);
    free(oa);
}

static void test_many(void)
{
    static const int cases[][2] = {{1, 0}, {2, 1}, {3, 0}, {5, 4}, {8, 6}, {11, 9}, {16, 8}};
    int c;
    g_rng = t_rng_seed(77);
    for (c = 0; c < (int)(sizeof cases / sizeof cases[0]); c++) {
        char name[64];
        g_nrhs = cases[c][0];
        g_slot = cases[c][1];
        g_many = kifmm_kernel_laplace_p2pn;
        g_td = 1;
        snprintf(name, sizeof name, "laplace_p2pn %d vectors, #%d", g_nrhs, g_slot);
        test_blocks(name, many_as_one, 1, 100 + (uint64_t)c);
        g_many = kifmm_kernel_laplace_grad_p2pn;
        g_td = 4;
        snprintf(name, sizeof name, "laplace_grad_p2pn %d vectors, #%d", g_nrhs, g_slot);
        test_blocks(name, many_as_one, 4, 200 + (uint64_t)c);
    }
}
#else
static void test_many(void)
{
    printf("many-vector hooks: not compiled for this target (%s), evaluate_many calls _p2p\n",
           BODY);
}
#endif

/* ------------------------------------------------------------------------ */
/* Mutual hooks (_p2ps): both directions of a pair of point sets at once    */
/* ------------------------------------------------------------------------ */

#if (kifmm_kernel_laplace_HAS & KIFMM_HAS_P2PS) && (kifmm_kernel_laplace_grad_HAS & KIFMM_HAS_P2PS)
typedef void (*hooks_fn)(const double *, const double *, const double *, const double *,
                         const double *, int64_t, const double *, const double *, const double *,
                         const double *, int64_t, double, double *, double *);

static hooks_fn g_mut;
static int g_mtd;
static t_rng g_mrng;
static double g_mut_err;    /* worst error of the B side, relative to max |ref| */
static int g_mut_guards = 1;

/* g_mut_err = max(g_mut_err, the worst error of n B-side outputs o against
 * pre + inc, relative to max(|pre| + mag)). */
static void b_side_err(int64_t n, const double *o, const double *pre, const long double *inc,
                       const long double *mag)
{
    long double num = 0, den = 0;
    int64_t i;
    for (i = 0; i < n; i++) {
        long double d = fabsl((long double)o[i] - (pre[i] + inc[i]));
        long double m = fabsl((long double)pre[i]) + mag[i];
        if (d != d) num = INFINITY;
        if (d > num) num = d;
        if (m > den) den = m;
    }
    if (den > 0 && (double)(num / den) > g_mut_err) g_mut_err = (double)(num / den);
    if (den == 0 && num > 0) g_mut_err = 1.0;
}

/* A hook_fn for one_block: A = the block's targets (random charges of their
 * own), B = its sources.  A's outputs go back to one_block; B's are checked
 * here against the long double sums of A's charges at B's points. */
static void mutual_as_one(const double *prm, const double *tx, const double *ty, const double *tz,
                          int64_t nt, const double *sx, const double *sy, const double *sz,
                          const double *q, int64_t ns, double scale, double *out)
{
    double *qa = t_doubles(nt + 1), *ob = t_doubles(ns * g_mtd + 2 * GUARD), *pre;
    size_t lbytes = (size_t)(ns * g_mtd + 1) * sizeof(long double);
    long double *inc = (long double *)t_malloc_or_die(lbytes);
    long double *mag = (long double *)t_malloc_or_die(lbytes);
    int64_t i;
    pre = t_doubles(ns * g_mtd + 1);
    for (i = 0; i < nt; i++) qa[i] = t_uniform(&g_mrng, -1.0, 1.0);
    for (i = 0; i < ns * g_mtd + 2 * GUARD; i++) ob[i] = SENTINEL;
    for (i = 0; i < ns * g_mtd; i++) ob[GUARD + i] = pre[i] = t_uniform(&g_mrng, -0.01, 0.01);
    g_mut(prm, tx, ty, tz, qa, nt, sx, sy, sz, q, ns, scale, out, ob + GUARD);
    ref_sum(g_mtd, ns, sx, sy, sz, nt, tx, ty, tz, qa, scale, inc, mag);
    for (i = 0; i < GUARD; i++)
        if (ob[i] != SENTINEL || ob[GUARD + ns * g_mtd + i] != SENTINEL) g_mut_guards = 0;
    b_side_err(ns * g_mtd, ob + GUARD, pre, inc, mag);
    free(qa);
    free(ob);
    free(pre);
    free(inc);
    free(mag);
}

/* The mutual hooks pair by pair over the exponent range and at subnormal
 * r^2 (A side per pair as in test_pairs, B side against long double sums),
 * and pairs that must add exactly 0 on both sides: coincident points and
 * r^2 = inf. */
static void pair_errors(hook_fn hook, int td, int e_lo, int e_hi, t_rng *r, double *e_ld,
                        double *e_d);
static void test_mutual_pairs(void)
{
    t_rng r = t_rng_seed(78);
    double e_ld, e_d, qa[5], q[9], oa[20], ob[36], pa[20], pb[36];
    pts t = pts_new(5), s = pts_new(9);
    int i, j, k, pass, same = 1;
    g_mut = kifmm_kernel_laplace_p2ps;
    g_mtd = 1;
    g_mut_err = 0.0;
    pair_errors(mutual_as_one, 1, -150, 153, &r, &e_ld, &e_d);
    CHECK_ERR(e_ld, 2e-15, "laplace_p2ps      e in [-150, 153], vs long double");
    pair_errors(mutual_as_one, 1, 20, 1, &r, &e_ld, &e_d);
    CHECK_ERR(e_ld, 2e-15, "laplace_p2ps      subnormal r^2, vs long double");
    CHECK_ERR(g_mut_err, 1e-14, "laplace_p2ps      single pairs, B side: vs sum|terms|");
    g_mut = kifmm_kernel_laplace_grad_p2ps;
    g_mtd = 4;
    g_mut_err = 0.0;
    pair_errors(mutual_as_one, 4, -90, 90, &r, &e_ld, &e_d);
    CHECK_ERR(e_ld, 2e-15, "laplace_grad_p2ps e in [-90, 90], vs long double (pot, |grad|)");
    CHECK_ERR(g_mut_err, 1e-14, "laplace_grad_p2ps single pairs, B side: vs sum|terms|");
    for (pass = 0; pass < 2; pass++) {
        for (j = 0; j < 9; j++) {
            s.x[j] = pass ? 1e155 * (j + 1) : 0.25;
            s.y[j] = pass ? -1e155 : -0.5;
            s.z[j] = pass ? 0.0 : 1e-300;
            q[j] = 1.0 + j;
        }
        for (i = 0; i < 5; i++) {
            t.x[i] = pass ? -1e154 * i : 0.25;
            t.y[i] = pass ? -1e154 * i : -0.5;
            t.z[i] = pass ? -1e154 * i : 1e-300;
            qa[i] = 2.0 - i;
        }
        for (k = 0; k < 36; k++) ob[k] = pb[k] = 0.1 * k - 1.0;
        for (k = 0; k < 20; k++) oa[k] = pa[k] = 0.2 * k - 1.0;
        kifmm_kernel_laplace_p2ps(NULL, t.x, t.y, t.z, qa, 5, s.x, s.y, s.z, q, 9, 2.0, oa, ob);
        kifmm_kernel_laplace_grad_p2ps(NULL, t.x, t.y, t.z, qa, 5, s.x, s.y, s.z, q, 9, 2.0, oa,
                                       ob);
        if (memcmp(oa, pa, sizeof oa) || memcmp(ob, pb, sizeof ob)) same = 0;
    }
    CHECK(same, "p2ps: coincident pairs or r^2 = inf changed an output");
    free(t.mem);
    free(s.mem);
}

static void test_mutual(void)
{
    g_mrng = t_rng_seed(91);
    g_mut = kifmm_kernel_laplace_p2ps;
    g_mtd = 1;
    g_mut_err = 0.0;
    test_blocks("laplace_p2ps, A side", mutual_as_one, 1, 301);
    CHECK_ERR(g_mut_err, 1e-14, "laplace_p2ps, B side, all shapes: vs sum|terms|");
    g_mut = kifmm_kernel_laplace_grad_p2ps;
    g_mtd = 4;
    g_mut_err = 0.0;
    test_blocks("laplace_grad_p2ps, A side", mutual_as_one, 4, 302);
    CHECK_ERR(g_mut_err, 1e-14, "laplace_grad_p2ps, B side, all shapes: vs sum|terms|");
    CHECK(g_mut_guards, "p2ps wrote outside outb[0 .. nb*td-1]");
    test_mutual_pairs();
}

/* Mutual many-vector hooks (_p2psn): vector g_slot through one_block, the
 * B side of every vector against long double sums. */
#if (kifmm_kernel_laplace_HAS & KIFMM_HAS_P2PSN) && (kifmm_kernel_laplace_grad_HAS & KIFMM_HAS_P2PSN)
typedef void (*hooksn_fn)(const double *, const double *, const double *, const double *,
                          const double *, int64_t, const double *, const double *,
                          const double *, const double *, int64_t, int, size_t, double, double *,
                          double *, size_t);
static hooksn_fn g_mutn;

/* A hook_fn for one_block: runs g_mutn on g_nrhs vectors (odd strides
 * between them). A = the block's targets, with random charges; B = its
 * sources, with the block's charges in vector g_slot and random ones in the
 * others. Vector g_slot's A outputs go back to one_block; the B outputs of
 * every vector are checked here, and the gaps between vectors must stay. */
static void mutualn_as_one(const double *prm, const double *tx, const double *ty,
                           const double *tz, int64_t nt, const double *sx, const double *sy,
                           const double *sz, const double *q, int64_t ns, double scale,
                           double *out)
{
    const int64_t big = nt > ns ? nt : ns;
    const size_t qld = (size_t)big + 3, old = (size_t)big * g_mtd + 5, tot = g_nrhs * old + 1;
    double *qa = t_doubles((int64_t)(g_nrhs * qld + 1)), *qb = t_doubles((int64_t)(g_nrhs * qld + 1));
    double *oa = t_doubles((int64_t)tot), *ob = t_doubles((int64_t)tot), *pre = t_doubles((int64_t)tot);
    size_t lbytes = (size_t)(ns * g_mtd + 1) * sizeof(long double), i;
    long double *inc = (long double *)t_malloc_or_die(lbytes);
    long double *mag = (long double *)t_malloc_or_die(lbytes);
    int r;
    for (i = 0; i < g_nrhs * qld; i++) {
        qa[i] = t_uniform(&g_mrng, -1.0, 1.0);
        qb[i] = t_uniform(&g_mrng, -1.0, 1.0);
    }
    for (i = 0; i < (size_t)ns; i++) qb[g_slot * qld + i] = q[i];
    for (i = 0; i < tot; i++) oa[i] = ob[i] = SENTINEL;
    for (r = 0; r < g_nrhs; r++) {
        for (i = 0; i < (size_t)nt * g_mtd; i++) oa[r * old + i] = t_uniform(&g_mrng, -0.01, 0.01);
        for (i = 0; i < (size_t)ns * g_mtd; i++)
            ob[r * old + i] = pre[r * old + i] = t_uniform(&g_mrng, -0.01, 0.01);
    }
    for (i = 0; i < (size_t)nt * g_mtd; i++) oa[g_slot * old + i] = out[i];
    g_mutn(prm, tx, ty, tz, qa, nt, sx, sy, sz, qb, ns, g_nrhs, qld, scale, oa, ob, old);
    for (i = 0; i < (size_t)nt * g_mtd; i++) out[i] = oa[g_slot * old + i];
    for (r = 0; r < g_nrhs; r++) {
        for (i = (size_t)nt * g_mtd; i < old; i++)
            if (oa[r * old + i] != SENTINEL) g_mut_guards = 0;
        for (i = (size_t)ns * g_mtd; i < old; i++)
            if (ob[r * old + i] != SENTINEL) g_mut_guards = 0;
        ref_sum(g_mtd, ns, sx, sy, sz, nt, tx, ty, tz, qa + r * qld, scale, inc, mag);
        b_side_err(ns * g_mtd, ob + r * old, pre + r * old, inc, mag);
    }
    free(qa);
    free(qb);
    free(oa);
    free(ob);
    free(pre);
    free(inc);
    free(mag);
}

static void test_mutual_many(void)
{
    static const int cases[][2] = {{1, 0}, {2, 1}, {3, 2}, {5, 4}, {8, 7}, {11, 9}};
    int c;
    g_mrng = t_rng_seed(93);
    g_mut_guards = 1;
    for (c = 0; c < (int)(sizeof cases / sizeof cases[0]); c++) {
        char name[64];
        g_nrhs = cases[c][0];
        g_slot = cases[c][1];
        g_mutn = kifmm_kernel_laplace_p2psn;
        g_mtd = 1;
        g_mut_err = 0.0;
        snprintf(name, sizeof name, "laplace_p2psn %d vectors, #%d, A side", g_nrhs, g_slot);
        test_blocks(name, mutualn_as_one, 1, 400 + (uint64_t)c);
        CHECK_ERR(g_mut_err, 1e-14, "laplace_p2psn %d vectors, B sides: vs sum|terms|", g_nrhs);
        g_mutn = kifmm_kernel_laplace_grad_p2psn;
        g_mtd = 4;
        g_mut_err = 0.0;
        snprintf(name, sizeof name, "laplace_grad_p2psn %d vectors, #%d, A side", g_nrhs, g_slot);
        test_blocks(name, mutualn_as_one, 4, 500 + (uint64_t)c);
        CHECK_ERR(g_mut_err, 1e-14, "laplace_grad_p2psn %d vectors, B sides: vs sum|terms|",
                  g_nrhs);
    }
    CHECK(g_mut_guards, "p2psn wrote outside its outputs or between vectors");
}
#else
static void test_mutual_many(void)
{
    printf("mutual many-vector hooks: not compiled for this target (%s)\n", BODY);
}
#endif

#else
static void test_mutual(void)
{
    printf("mutual hooks: not compiled for this target (%s), each leaf pair is computed twice\n",
           BODY);
}
static void test_mutual_many(void) {}
#endif

/* The float mutual many-vector hooks (_p2psnf): both sides of every vector
 * against long double sums over the same float points (ref_sum on their
 * exact double values), each output's error relative to the max over the
 * block of |prefill| + sum of |terms|. Blocks of 1 to 70 points (vector
 * tails), some B points on A points (those pairs skipped), 1 to 11 vectors
 * with gaps between them that must stay untouched. */
#if (kifmm_kernel_laplace_HAS & KIFMM_HAS_P2PSNF) && (kifmm_kernel_laplace_grad_HAS & KIFMM_HAS_P2PSNF)
typedef void (*hooksnf_fn)(const double *, const float *, const float *, const float *,
                           const float *, int64_t, const float *, const float *, const float *,
                           const float *, int64_t, int, size_t, float, float *, float *, size_t);

/* The worst error of n float outputs o against pre + inc (see above). */
static double f_side_err(int64_t n, const float *o, const float *pre, const long double *inc,
                         const long double *mag)
{
    long double num = 0, den = 0;
    int64_t i;
    for (i = 0; i < n; i++) {
        long double d = fabsl((long double)o[i] - ((long double)pre[i] + inc[i]));
        long double m = fabsl((long double)pre[i]) + mag[i];
        if (d != d) return INFINITY;
        if (d > num) num = d;
        if (m > den) den = m;
    }
    return den > 0 ? (double)(num / den) : (num > 0 ? 1.0 : 0.0);
}

static void test_mutual_many_float(void)
{
    static const int sizes[] = {1, 7, 8, 9, 33, 70}, vecs[] = {1, 2, 3, 8, 11};
    static const char *names[2] = {"laplace_p2psnf", "laplace_grad_p2psnf"};
    const hooksnf_fn fn[2] = {kifmm_kernel_laplace_p2psnf, kifmm_kernel_laplace_grad_p2psnf};
    t_rng r = t_rng_seed(97);
    int h;
    t_group("float mutual many-vector hooks (_p2psnf)");
    for (h = 0; h < 2; h++) {
        const int td = h ? 4 : 1;
        double worst = 0.0;
        int ia, ib, iv, guards = 1;
        for (ia = 0; ia < 6; ia++)
            for (ib = 0; ib < 6; ib++)
                for (iv = 0; iv < 5; iv++) {
                    const int64_t na = sizes[ia], nb = sizes[ib], big = na > nb ? na : nb;
                    const int nv = vecs[iv];
                    const size_t qld = (size_t)big + 3, old = (size_t)big * td + 5;
                    const size_t tot = (size_t)nv * old;
                    float *f = (float *)t_malloc_or_die(sizeof(float) * (6 * big + 2 * nv * qld + 3 * tot));
                    float *ax = f, *ay = ax + big, *az = ay + big, *bx = az + big, *by = bx + big;
                    float *bz = by + big, *qa = bz + big, *qb = qa + nv * qld, *oa = qb + nv * qld;
                    float *ob = oa + tot, *pre = ob + tot;
                    double *d = t_doubles(6 * big + 2 * big);
                    size_t lb = (size_t)(big * td + 1) * sizeof(long double);
                    long double *inc = (long double *)t_malloc_or_die(lb);
                    long double *mag = (long double *)t_malloc_or_die(lb);
                    int64_t i;
                    int v;
                    for (i = 0; i < na; i++) {
                        ax[i] = (float)t_rand01(&r);
                        ay[i] = (float)t_rand01(&r);
                        az[i] = (float)t_rand01(&r);
                    }
                    for (i = 0; i < nb; i++) {
                        const int on = i % 4 == 1 && i / 4 < na; /* B point on an A point */
                        bx[i] = on ? ax[i / 4] : (float)t_rand01(&r);
                        by[i] = on ? ay[i / 4] : (float)t_rand01(&r);
                        bz[i] = on ? az[i / 4] : (float)t_rand01(&r);
                    }
                    for (i = 0; i < (int64_t)(nv * qld); i++) {
                        qa[i] = (float)t_uniform(&r, -1.0, 1.0);
                        qb[i] = (float)t_uniform(&r, -1.0, 1.0);
                    }
                    for (i = 0; i < (int64_t)tot; i++) {
                        oa[i] = ob[i] = pre[i] = (float)SENTINEL;
                        if ((size_t)i % old < (size_t)big * td) /* the widest side's prefill */
                            pre[i] = (float)t_uniform(&r, -0.01, 0.01);
                        if ((size_t)i % old < (size_t)na * td) oa[i] = pre[i];
                        if ((size_t)i % old < (size_t)nb * td) ob[i] = pre[i];
                    }
                    fn[h](NULL, ax, ay, az, qa, na, bx, by, bz, qb, nb, nv, qld, 0.5f, oa, ob, old);
                    for (i = 0; i < big; i++) {
                        d[i] = ax[i]; d[big + i] = ay[i]; d[2 * big + i] = az[i];
                        d[3 * big + i] = bx[i]; d[4 * big + i] = by[i]; d[5 * big + i] = bz[i];
                    }
                    for (v = 0; v < nv; v++) {
                        double e;
                        for (i = 0; i < nb; i++) d[6 * big + i] = qb[v * qld + i];
                        ref_sum(td, na, d, d + big, d + 2 * big, nb, d + 3 * big, d + 4 * big,
                                d + 5 * big, d + 6 * big, 0.5, inc, mag);
                        e = f_side_err(na * td, oa + v * old, pre + v * old, inc, mag);
                        if (!(e <= worst)) worst = e;
                        for (i = 0; i < na; i++) d[7 * big + i] = qa[v * qld + i];
                        ref_sum(td, nb, d + 3 * big, d + 4 * big, d + 5 * big, na, d, d + big,
                                d + 2 * big, d + 7 * big, 0.5, inc, mag);
                        e = f_side_err(nb * td, ob + v * old, pre + v * old, inc, mag);
                        if (!(e <= worst)) worst = e;
                        for (i = (int64_t)na * td; i < (int64_t)old; i++)
                            if (oa[v * old + i] != (float)SENTINEL) guards = 0;
                        for (i = (int64_t)nb * td; i < (int64_t)old; i++)
                            if (ob[v * old + i] != (float)SENTINEL) guards = 0;
                    }
                    free(f);
                    free(d);
                    free(inc);
                    free(mag);
                }
        CHECK_ERR(worst, 2e-6, "%s, both sides, 1 to 11 vectors: vs sum|terms|", names[h]);
        CHECK(guards, "%s wrote outside its outputs or between vectors", names[h]);
    }
}
#else
static void test_mutual_many_float(void)
{
    printf("float mutual many-vector hooks: not compiled for this target (%s)\n", BODY);
}
#endif

/* ------------------------------------------------------------------------ */
/* Single pairs over the whole exponent range                               */
/* ------------------------------------------------------------------------ */

/* Pairs at distances ~10^e: 3 targets, 9 sources (vector lanes and tails of
 * every body, two-target and one-target passes), one charge 1 and the others
 * 0, so each output is one pair's value.  Relative error of the potential and
 * of the gradient vector per pair, against long double (*e_ld) and against
 * 1 / sqrt() in double (*e_d).  With e_lo > e_hi, the distances are instead
 * integer vectors (a, b, c) times 2^-537 with a, b, c < 2^20: r^2 is then
 * subnormal and exact in double, with or without FMA. */
static void pair_errors(hook_fn hook, int td, int e_lo, int e_hi, t_rng *r, double *e_ld,
                        double *e_d)
{
    const int subnormal = e_lo > e_hi;
    pts t = pts_new(3), s = pts_new(9);
    double q[9], out[12];
    int e, i, j, l, k, rep;
    *e_ld = *e_d = 0.0;
    if (subnormal) {
        int tmp = e_lo;
        e_lo = e_hi;
        e_hi = tmp;
    }
    for (e = e_lo; e <= e_hi; e++)
        for (rep = 0; rep < 4; rep++) {
            double S = pow(10.0, (double)e) * (1.0 + t_rand01(r));
            for (i = 0; i < 3; i++) {
                t.x[i] = subnormal ? 0.0 : t_uniform(r, -S, S);
                t.y[i] = subnormal ? 0.0 : t_uniform(r, -S, S);
                t.z[i] = subnormal ? 0.0 : t_uniform(r, -S, S);
            }
            for (j = 0; j < 9; j++) {
                if (subnormal) {
                    const double u = ldexp(1.0, -537);
                    s.x[j] = u * (double)(1 + (t_rng_next(r) >> 44));
                    s.y[j] = u * (double)(t_rng_next(r) >> 44);
                    s.z[j] = u * (double)(t_rng_next(r) >> 44);
                    continue;
                }
                s.x[j] = t_uniform(r, -S, S);
                s.y[j] = t_uniform(r, -S, S);
                s.z[j] = t_uniform(r, -S, S);
            }
            for (l = 0; l < 9; l++) {
                for (j = 0; j < 9; j++) q[j] = j == l ? 1.0 : 0.0;
                for (k = 0; k < 12; k++) out[k] = 0.0;
                hook(NULL, t.x, t.y, t.z, 3, s.x, s.y, s.z, q, 9, 1.0, out);
                for (i = 0; i < 3; i++) {
                    double dx = t.x[i] - s.x[l], dy = t.y[i] - s.y[l], dz = t.z[i] - s.z[l];
                    long double lx = dx, ly = dy, lz = dz, r2 = lx * lx + ly * ly + lz * lz;
                    long double inv = 1.0L / sqrtl(r2), ref[4], gn = 0, dn = 0;
                    double invd = 1.0 / sqrt(dx * dx + dy * dy + dz * dz), refd[4];
                    long double gd = 0;
                    double ep, epd;
                    ref[0] = inv / (4 * PI_L);
                    ref[1] = -lx * inv * inv * inv / (4 * PI_L);
                    ref[2] = -ly * inv * inv * inv / (4 * PI_L);
                    ref[3] = -lz * inv * inv * inv / (4 * PI_L);
                    refd[0] = KIFMM_INV_4PI * invd;
                    refd[1] = -dx * invd * invd * invd * KIFMM_INV_4PI;
                    refd[2] = -dy * invd * invd * invd * KIFMM_INV_4PI;
                    refd[3] = -dz * invd * invd * invd * KIFMM_INV_4PI;
                    ep = (double)(fabsl(out[i * td] - ref[0]) / ref[0]);
                    epd = fabs(out[i * td] - refd[0]) / refd[0];
                    if (!(ep <= *e_ld)) *e_ld = ep;
                    if (!(epd <= *e_d)) *e_d = epd;
                    if (td == 4) {
                        for (k = 1; k < 4; k++) {
                            long double d = out[i * td + k] - ref[k];
                            long double dd = (long double)out[i * td + k] - refd[k];
                            dn += d * d;
                            gn += ref[k] * ref[k];
                            gd += dd * dd;
                        }
                        ep = (double)sqrtl(dn / gn);
                        epd = (double)sqrtl(gd / gn);
                        if (!(ep <= *e_ld)) *e_ld = ep;
                        if (!(epd <= *e_d)) *e_d = epd;
                    }
                }
            }
        }
    free(t.mem);
    free(s.mem);
}

static void test_pairs(void)
{
    t_rng r = t_rng_seed(77);
    double e_ld, e_d;
    t_group("single pairs, distances 10^e (relative error per pair)");
    /* laplace: r^2 from 1e-300 to 5e307 (squares of the coordinate
     * differences stay normal, so r^2 is accurate in double) */
    pair_errors(kifmm_kernel_laplace_p2p, 1, -150, 153, &r, &e_ld, &e_d);
    CHECK_ERR(e_ld, 2e-15, "laplace      e in [-150, 153], vs long double");
    CHECK_ERR(e_d, 2e-15, "laplace      e in [-150, 153], vs 1/sqrt in double");
    /* laplace: subnormal r^2, exact in double (4 x 20 draws of 27 pairs) */
    pair_errors(kifmm_kernel_laplace_p2p, 1, 20, 1, &r, &e_ld, &e_d);
    CHECK_ERR(e_ld, 2e-15, "laplace      subnormal r^2, vs long double");
    CHECK_ERR(e_d, 2e-15, "laplace      subnormal r^2, vs 1/sqrt in double");
    /* laplace_grad: where 1/r^3 neither overflows nor underflows in double */
    pair_errors(kifmm_kernel_laplace_grad_p2p, 4, -90, 90, &r, &e_ld, &e_d);
    CHECK_ERR(e_ld, 2e-15, "laplace_grad e in [-90, 90], vs long double (pot, |grad|)");
    CHECK_ERR(e_d, 2e-15, "laplace_grad e in [-90, 90], vs 1/sqrt in double");
}

/* Pairs the scalar kernels send to exactly 0: r == 0, and r^2 overflowing to
 * inf (the scalar kernel's 1/sqrt(inf) = 0).  out must not change at all. */
static void test_special(void)
{
    pts t = pts_new(5), s = pts_new(9);
    double q[9], out[20], pre[20];
    int i, j, k, same;
    t_group("special pairs");
    for (j = 0; j < 9; j++) {
        s.x[j] = 0.25;
        s.y[j] = -0.5;
        s.z[j] = 1e-300;
        q[j] = 1.0 + j;
    }
    for (i = 0; i < 5; i++) {
        t.x[i] = 0.25;
        t.y[i] = -0.5;
        t.z[i] = 1e-300;
    }
    for (k = 0; k < 20; k++) out[k] = pre[k] = 0.1 * k - 1.0;
    kifmm_kernel_laplace_p2p(NULL, t.x, t.y, t.z, 5, s.x, s.y, s.z, q, 9, 2.0, out);
    kifmm_kernel_laplace_grad_p2p(NULL, t.x, t.y, t.z, 5, s.x, s.y, s.z, q, 9, 2.0, out);
    same = memcmp(out, pre, sizeof out) == 0;
    CHECK(same, "all pairs coincident: out changed");
    for (j = 0; j < 9; j++) {
        s.x[j] = 1e155 * (j + 1);
        s.y[j] = -1e155;
        s.z[j] = 0.0;
    }
    for (i = 0; i < 5; i++) t.x[i] = t.y[i] = t.z[i] = -1e154 * i;
    kifmm_kernel_laplace_p2p(NULL, t.x, t.y, t.z, 5, s.x, s.y, s.z, q, 9, 2.0, out);
    kifmm_kernel_laplace_grad_p2p(NULL, t.x, t.y, t.z, 5, s.x, s.y, s.z, q, 9, 2.0, out);
    same = memcmp(out, pre, sizeof out) == 0;
    CHECK(same, "r^2 = inf for all pairs: out changed");
    free(t.mem);
    free(s.mem);
}

/* The library's own near-field routines must be the hooks (bit for bit). */
static void test_wiring(void)
{
    t_rng r = t_rng_seed(5);
    const int64_t nt = 37, ns = 29;
    pts t = pts_new(nt), s = pts_new(ns);
    double q[29], a[4 * 37], b[4 * 37];
    int64_t i;
    t_group("kifmm.h calls the hooks");
    for (i = 0; i < nt; i++) {
        t.x[i] = t_rand01(&r);
        t.y[i] = t_rand01(&r);
        t.z[i] = t_rand01(&r);
    }
    for (i = 0; i < ns; i++) {
        s.x[i] = t_rand01(&r);
        s.y[i] = t_rand01(&r);
        s.z[i] = t_rand01(&r);
        q[i] = t_uniform(&r, -1, 1);
    }
    memset(a, 0, sizeof a);
    memset(b, 0, sizeof b);
    kifmm_laplace__p2p_qt(NULL, t.x, t.y, t.z, nt, s.x, s.y, s.z, q, ns, 1, 0, 0.7, a, 0);
    kifmm_kernel_laplace_p2p(NULL, t.x, t.y, t.z, nt, s.x, s.y, s.z, q, ns, 0.7, b);
    CHECK(memcmp(a, b, (size_t)nt * sizeof(double)) == 0, "kifmm_laplace__p2p");
    memset(a, 0, sizeof a);
    memset(b, 0, sizeof b);
    kifmm_laplace_grad__p2p_qt(NULL, t.x, t.y, t.z, nt, s.x, s.y, s.z, q, ns, 1, 0, 0.7, a, 0);
    kifmm_kernel_laplace_grad_p2p(NULL, t.x, t.y, t.z, nt, s.x, s.y, s.z, q, ns, 0.7, b);
    CHECK(memcmp(a, b, sizeof a) == 0, "kifmm_laplace_grad__p2p");
    memset(a, 0, sizeof a);
    memset(b, 0, sizeof b);
    kifmm_laplace_grad__p2p_qc(NULL, t.x, t.y, t.z, nt, s.x, s.y, s.z, q, ns, 1, 0, 0.7, a, 0);
    kifmm_kernel_laplace_p2p(NULL, t.x, t.y, t.z, nt, s.x, s.y, s.z, q, ns, 0.7, b);
    CHECK(memcmp(a, b, (size_t)nt * sizeof(double)) == 0,
          "kifmm_laplace_grad__p2p_qc (surface kernel laplace)");
#if kifmm_kernel_laplace_grad_HAS & KIFMM_HAS_P2PN
    { /* two vectors (the second = 0.5 q) go to the many-vector hook */
        double q2[2 * 29], a2[8 * 37], b2[8 * 37];
        for (i = 0; i < ns; i++) q2[i] = q[i], q2[ns + i] = 0.5 * q[i];
        memset(a2, 0, sizeof a2);
        memset(b2, 0, sizeof b2);
        kifmm_laplace_grad__p2p_qt(NULL, t.x, t.y, t.z, nt, s.x, s.y, s.z, q2, ns, 2, (size_t)ns,
                                0.7, a2, (size_t)(4 * nt));
        kifmm_kernel_laplace_grad_p2pn(NULL, t.x, t.y, t.z, nt, s.x, s.y, s.z, q2, ns, 2,
                                       (size_t)ns, 0.7, b2, (size_t)(4 * nt));
        CHECK(memcmp(a2, b2, sizeof a2) == 0, "kifmm_laplace_grad__p2p, 2 vectors (_p2pn)");
    }
#endif
    free(t.mem);
    free(s.mem);
}

/* ------------------------------------------------------------------------ */
/* Whole FMM                                                                */
/* ------------------------------------------------------------------------ */

#define N_FMM 20000
#define N_SAMPLE 500

/* Potential and gradient at x[3*i] from all points, double, r == 0 skipped. */
static void direct(int64_t n, const double *x, const double *q, int64_t i, double *res)
{
    double p = 0, gx = 0, gy = 0, gz = 0;
    int64_t j;
    for (j = 0; j < n; j++) {
        double dx = x[3 * i] - x[3 * j], dy = x[3 * i + 1] - x[3 * j + 1];
        double dz = x[3 * i + 2] - x[3 * j + 2], r2 = dx * dx + dy * dy + dz * dz, inv;
        if (r2 == 0.0) continue;
        inv = 1.0 / sqrt(r2);
        p += q[j] * inv;
        gx -= q[j] * inv * inv * inv * dx;
        gy -= q[j] * inv * inv * inv * dy;
        gz -= q[j] * inv * inv * inv * dz;
    }
    res[0] = p / (4.0 * T_PI);
    res[1] = gx / (4.0 * T_PI);
    res[2] = gy / (4.0 * T_PI);
    res[3] = gz / (4.0 * T_PI);
}

static void test_fmm(void)
{
    const int64_t n = N_FMM;
    double *x = t_doubles(3 * n), *q = t_doubles(n), *out = t_doubles(4 * n);
    double *pot = t_doubles(n);
    double num[2] = {0, 0}, den[2] = {0, 0}, num1 = 0, te = 0;
    kifmm_opts o = t_opts(6, 0, 0);
    kifmm_laplace_grad *hg = NULL;
    kifmm_laplace *hl = NULL;
    t_rng r = t_rng_seed(2024);
    int64_t m;
    int rc, k;

    t_group("whole FMM, 20000 uniform points, order 6");
    t_gen_cube(&r, n, x, 0.0, 1.0);
    t_gen_charges(&r, n, q, -1.0, 1.0);

    rc = kifmm_laplace_grad_create(&hg, &o, n, x, n, x);
    CHECK(rc == KIFMM_SUCCESS, "kifmm_laplace_grad_create rc=%d", rc);
    if (rc == KIFMM_SUCCESS) {
        t_fill(4 * n, out, NAN);
        te = t_wall();
        rc = kifmm_laplace_grad_evaluate(hg, q, out);
        te = t_wall() - te;
        CHECK(rc == KIFMM_SUCCESS, "kifmm_laplace_grad_evaluate rc=%d", rc);
        kifmm_laplace_grad_destroy(hg);
    }
    rc = kifmm_laplace_create(&hl, &o, n, x, n, x);
    CHECK(rc == KIFMM_SUCCESS, "kifmm_laplace_create rc=%d", rc);
    if (rc == KIFMM_SUCCESS) {
        t_fill(n, pot, NAN);
        rc = kifmm_laplace_evaluate(hl, q, pot);
        CHECK(rc == KIFMM_SUCCESS, "kifmm_laplace_evaluate rc=%d", rc);
        kifmm_laplace_destroy(hl);
    }
    for (m = 0; m < N_SAMPLE; m++) {
        int64_t i = t_sample_index(m, N_SAMPLE, n);
        double ref[4];
        direct(n, x, q, i, ref);
        for (k = 0; k < 4; k++) {
            double d = out[4 * i + k] - ref[k];
            num[k > 0] += d * d;
            den[k > 0] += ref[k] * ref[k];
            if (d != d) num[k > 0] = NAN;
        }
        num1 += (pot[i] - ref[0]) * (pot[i] - ref[0]);
        if (pot[i] != pot[i]) num1 = NAN;
    }
    CHECK_ERR(sqrt(num[0] / den[0]), 4e-6, "laplace_grad potential, 500 targets (eval %.2fs)", te);
    CHECK_ERR(sqrt(num[1] / den[1]), 4e-5, "laplace_grad gradient, 500 targets");
    CHECK_ERR(sqrt(num1 / den[0]), 4e-6, "laplace potential, 500 targets");
    free(x);
    free(q);
    free(out);
    free(pot);
}

/* laplace and laplace_grad at the target a from nb sources b (xyz
 * interleaved), in long double, with the sums of |terms| (t_check_hooks) */
static void ref_laplace_grad(int64_t nb, const double *b, const double *q, const double *a,
                             double *ref, double *mag)
{
    const long double c = 1.0L / (4.0L * PI_L);
    long double s[4] = {0.0L, 0.0L, 0.0L, 0.0L}, m[4] = {0.0L, 0.0L, 0.0L, 0.0L};
    int64_t j;
    int k;
    for (j = 0; j < nb; j++) {
        const long double d[3] = {(long double)a[0] - b[3 * j], (long double)a[1] - b[3 * j + 1],
                                  (long double)a[2] - b[3 * j + 2]};
        const long double r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        long double r, t;
        if (r2 == 0.0L) continue;
        r = sqrtl(r2);
        t = q[j] / r;
        s[0] += t;
        m[0] += fabsl(t);
        for (k = 0; k < 3; k++) {
            const long double g = -q[j] * d[k] / (r2 * r);
            s[1 + k] += g;
            m[1 + k] += fabsl(g);
        }
    }
    for (k = 0; k < 4; k++) {
        ref[k] = (double)(c * s[k]);
        mag[k] = (double)(c * m[k]);
    }
}

/* the one-way hooks in double and, where this build has them, float (the
 * vector layer's on every instruction set it covers) */
static void test_oneway_float(void)
{
    static const double prm[4] = {1.0, 0.0, 0.0, 0.0};
    t_group("one-way hooks in double and float, blocks of 0 to 129 (tests/test.h)");
#if (kifmm_kernel_laplace_HAS & KIFMM_HAS_P2PF)
    t_check_hooks("laplace", 1, 1, prm, 1e-14, kifmm_kernel_laplace_p2p, kifmm_kernel_laplace_p2pf,
                  ref_laplace_grad);
    t_check_hooks("laplace_grad", 1, 4, prm, 1e-14, kifmm_kernel_laplace_grad_p2p,
                  kifmm_kernel_laplace_grad_p2pf, ref_laplace_grad);
#else
    t_check_hooks("laplace", 1, 1, prm, 1e-14, kifmm_kernel_laplace_p2p, NULL, ref_laplace_grad);
    t_check_hooks("laplace_grad", 1, 4, prm, 1e-14, kifmm_kernel_laplace_grad_p2p, NULL,
                  ref_laplace_grad);
#endif
}

int main(void)
{
    printf("test_p2p: near-field hooks, body: %s\n", BODY);
    test_wiring();
    test_special();
    test_pairs();
    test_blocks("laplace", kifmm_kernel_laplace_p2p, 1, 11);
    test_blocks("laplace_grad", kifmm_kernel_laplace_grad_p2p, 4, 12);
    test_oneway_float();
    test_many();
    test_mutual();
    test_mutual_many();
    test_mutual_many_float();
    test_fmm();
    return t_finish();
}
