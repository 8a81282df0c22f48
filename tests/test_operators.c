/* White-box tests of the pieces: each translation operator on its own against
 * direct summation, the transfer-vector numbering, and the tree (2:1 balance,
 * list bounds, and that the lists of a leaf and its ancestors account for
 * every source exactly once). */
#include "kifmm.h"
/* the same kernel with the dense M2L (stacked GEMMs), for comparison */
#define KIFMM_M2L_DENSE
#define KIFMM_NAME kifmm_laplace_dense
#include "kifmm.h"
#include "test.h"
#include <float.h>

/* Equivalent density -> potential at points y (interleaved), with the test's
 * own direct sum from the surface points. */
static void eval_equiv(const kifmm_laplace *c, int n, const double *surf_soa, const double *dens,
                       int ny, const double *y, double *pot)
{
    double *pts = t_doubles(3 * n);
    int i, d;
    for (i = 0; i < n; i++)
        for (d = 0; d < 3; d++) pts[3 * i + d] = surf_soa[d * n + i];
    for (i = 0; i < ny; i++) {
        double r[4];
        t_direct_laplace(n, pts, dens, y + 3 * i, r);
        pot[i] = r[0];
    }
    (void)c;
    free(pts);
}

static double rel_err_at(int ny, const double *y, const double *pot, int ns, const double *x,
                         const double *q)
{
    double num = 0, den = 0;
    int i;
    for (i = 0; i < ny; i++) {
        double r[4];
        t_direct_laplace(ns, x, q, y + 3 * i, r);
        num += (pot[i] - r[0]) * (pot[i] - r[0]);
        den += r[0] * r[0];
    }
    return sqrt(num / den);
}

static void soa(int n, const double *xyz, double *s)
{
    int i, d;
    for (i = 0; i < n; i++)
        for (d = 0; d < 3; d++) s[d * n + i] = xyz[3 * i + d];
}

/* Check vector -> equivalent density with the handle's two factors (a
 * downward density ends with its anchors' values: surf.nde of them). */
static void solve(const kifmm_laplace *c, int up, const double *chk, double *eq)
{
    const kifmm_laplace__ops *o = c->lv[0];
    const int k = up ? o->ku : o->kd, ne = up ? c->pl->surf.ne : c->pl->surf.nde;
    double *tmp = t_doubles(k);
    kifmm__gemm(0, 0, k, 1, c->pl->surf.nc, 1.0, up ? o->ut_up : o->ut_dn, k, chk, c->pl->surf.nc, 0.0, tmp, k);
    kifmm__gemm(0, 0, ne, 1, k, 1.0, up ? o->vs_up : o->vs_dn, ne, tmp, k, 0.0, eq, ne);
    free(tmp);
}

/* the points of a downward density: the surface's, then the anchors' */
static int down_points(const kifmm_laplace *c, const double *ctr, double r, double *pe)
{
    kifmm_laplace__place_down(&c->pl->surf, ctr, c->pl->surf.ao * r, r, pe);
    return c->pl->surf.nse + c->pl->surf.nsa;
}

/* P2M: sources -> check potentials (scaled by the half-width, Laplace being
 * homogeneous of degree -1, and by the operators' sigma) -> upward
 * equivalent density. */
static void p2m(const kifmm_laplace *c, const double *ctr, double r, int ns, const double *x,
                const double *q, double *ue)
{
    double *pc = t_doubles(3 * c->pl->surf.nsc), *chk = t_doubles(c->pl->surf.nc), *xs = t_doubles(3 * ns);
    kifmm__surf_place(c->pl->surf.unit_c, c->pl->surf.nsc, ctr, c->pl->surf.ao * r, pc);
    soa(ns, x, xs);
    t_fill(c->pl->surf.nc, chk, 0.0);
    kifmm_laplace__p2p_qc(c->opts.kernel_param, pc, pc + c->pl->surf.nsc, pc + 2 * c->pl->surf.nsc, c->pl->surf.nsc, xs, xs + ns,
                             xs + 2 * ns, q, ns, 1, 0, r * c->lv[0]->sigma, chk, 0);
    solve(c, 1, chk, ue);
    free(pc);
    free(chk);
    free(xs);
}

/* mp[i]: the point of unit surface u (n points, SoA) at point i's place
 * mirrored in the axes of octant m (4: x, 2: y, 1: z), found by its
 * coordinates */
static void mirror_points(const double *u, int n, int m, int *mp)
{
    int i, j, d;
    for (i = 0; i < n; i++) {
        mp[i] = -1;
        for (j = 0; j < n && mp[i] < 0; j++) {
            int same = 1;
            for (d = 0; d < 3; d++)
                same &= fabs(u[d * n + j] - ((m >> (2 - d) & 1) ? -1.0 : 1.0) * u[d * n + i]) < 1e-12;
            if (same) mp[i] = j;
        }
        CHECK(mp[i] >= 0, "unit surface point %d mirrored in octant %d's axes is a point of it", i, m);
    }
}

/* The eight octants' M2M (nc x 8 ne) and L2L (8 nc x nde, the anchors' last)
 * of the handle's set: where it keeps octant 0's only (mir), octant m's
 * entry (i, j) is octant 0's at the mirror images of points i and j (a
 * radial kernel's: laplace mirrored is laplace), the anchors' columns kept
 * for every octant after octant 0's nc x ne */
static void family_octants(const kifmm_laplace *c, double *m2m, double *l2l)
{
    const kifmm_laplace__ops *e = c->lv[0];
    const int nc = c->pl->surf.nc, ne = c->pl->surf.ne, nd = c->pl->surf.nde;
    int *mc = (int *)malloc(sizeof(int) * (size_t)(nc + ne)), *me = mc + nc, m, i, j;
    if (!e->mir) {
        memcpy(m2m, e->m2m, sizeof(double) * (size_t)nc * 8 * ne);
        memcpy(l2l, e->l2l, sizeof(double) * (size_t)8 * nc * nd);
        free(mc);
        return;
    }
    for (m = 0; m < 8; m++) {
        mirror_points(c->pl->surf.unit_c, c->pl->surf.nsc, m, mc);
        mirror_points(c->pl->surf.unit_e, c->pl->surf.nse, m, me);
        for (j = 0; j < ne; j++)
            for (i = 0; i < nc; i++) {
                m2m[i + (size_t)(m * ne + j) * nc] = e->m2m[mc[i] + (size_t)me[j] * nc];
                l2l[m * nc + i + (size_t)j * 8 * nc] = e->l2l[mc[i] + (size_t)me[j] * nc];
            }
        for (j = ne; j < nd; j++)
            for (i = 0; i < nc; i++)
                l2l[m * nc + i + (size_t)j * 8 * nc] = e->l2l[(size_t)nc * ne + m * nc + i + (size_t)(j - ne) * 8 * nc];
    }
    free(mc);
}

static void points_in_box(t_rng *g, int n, const double *ctr, double r, double *x)
{
    int i, d;
    for (i = 0; i < n; i++)
        for (d = 0; d < 3; d++) x[3 * i + d] = ctr[d] + t_uniform(g, -r, r);
}

/* Targets in a shell around ctr: cube distance between a and b half-widths. */
static void points_far(t_rng *g, int n, const double *ctr, double r, double a, double b,
                       double *y)
{
    int i, d;
    for (i = 0; i < n; i++) {
        double v[3], m = 0, s = t_uniform(g, a, b);
        for (d = 0; d < 3; d++) {
            v[d] = t_uniform(g, -1, 1);
            if (fabs(v[d]) > m) m = fabs(v[d]);
        }
        for (d = 0; d < 3; d++) y[3 * i + d] = ctr[d] + r * s * v[d] / m;
    }
}

/* A handle whose operators are built: a handle builds only what its tree
 * uses, so the tree needs levels 2 and deeper, and V lists. */
static double *ops_points(int *n)
{
    static double x[3 * 1000];
    t_rng r = t_rng_seed(8);
    t_gen_cube(&r, 1000, x, 0.0, 1.0);
    *n = 1000;
    return x;
}

static kifmm_laplace *handle(int order)
{
    kifmm_laplace *h = NULL;
    int n;
    double *x = ops_points(&n);
    kifmm_opts o = t_opts(order, 8, 0);
    CHECK(kifmm_laplace_create(&h, &o, n, x, n, x) == 0 && h->lv[0]->khat != NULL,
          "create order %d, operators built", order);
    return h;
}

/* Bounds for one operator alone, per order 4, 6, 8, 10: a few times the
 * worst case measured, which is the nearest transfer vector (2,0,0) with
 * sources filling the whole box (1.3e-3, 3.0e-5, 8.4e-8, 1.4e-8 for L2L). */
static double bound_for(int p)
{
    return p <= 4 ? 5e-3 : p <= 6 ? 1.5e-4 : p <= 8 ? 4e-7 : 6e-8;
}

static void test_upward(int p)
{
    kifmm_laplace *h = handle(p);
    const kifmm_laplace *c = h;
    t_rng g = t_rng_seed(11 + p);
    double ctr[3] = {0.3, -0.2, 0.1}, r = 0.25, *x, *q, *y, *pot, *ue, *uec, *chk, *pe, *m2m, *l2l;
    int ns = 400, ny = 300, o;
    x = t_doubles(3 * ns); q = t_doubles(ns); y = t_doubles(3 * ny); pot = t_doubles(ny);
    m2m = t_doubles(8 * (size_t)c->pl->surf.nc * c->pl->surf.ne);
    l2l = t_doubles(8 * (size_t)c->pl->surf.nc * c->pl->surf.nde);
    ue = t_doubles(c->pl->surf.ne); uec = t_doubles(8 * c->pl->surf.ne); chk = t_doubles(c->pl->surf.nc);
    pe = t_doubles(3 * c->pl->surf.nse);

    /* P2M alone, evaluated where M2L would use it (beyond the check surface) */
    points_in_box(&g, ns, ctr, r, x);
    t_gen_charges(&g, ns, q, -1, 1);
    points_far(&g, ny, ctr, r, 3.0, 7.0, y);
    p2m(c, ctr, r, ns, x, q, ue);
    kifmm__surf_place(c->pl->surf.unit_e, c->pl->surf.nse, ctr, c->pl->surf.ai * r, pe);
    eval_equiv(c, c->pl->surf.nse, pe, ue, ny, y, pot);
    CHECK_ERR(rel_err_at(ny, y, pot, ns, x, q), bound_for(p), "P2M p=%d, far field", p);

    /* M2M: eight children, each P2M'd alone, shifted to the parent */
    for (o = 0; o < 8; o++) {
        double cc[3] = {ctr[0] + (o >> 2 & 1 ? 0.5 : -0.5) * r, ctr[1] + (o >> 1 & 1 ? 0.5 : -0.5) * r,
                        ctr[2] + (o & 1 ? 0.5 : -0.5) * r};
        points_in_box(&g, ns / 8, cc, 0.5 * r, x + 3 * (ns / 8) * o);
        p2m(c, cc, 0.5 * r, ns / 8, x + 3 * (ns / 8) * o, q + (ns / 8) * o, uec + o * c->pl->surf.ne);
    }
    family_octants(c, m2m, l2l);
    kifmm__gemm(0, 0, c->pl->surf.nc, 1, 8 * c->pl->surf.ne, 1.0, m2m, c->pl->surf.nc, uec, 8 * c->pl->surf.ne, 0.0, chk,
                c->pl->surf.nc);
    solve(c, 1, chk, ue);
    eval_equiv(c, c->pl->surf.nse, pe, ue, ny, y, pot);
    CHECK_ERR(rel_err_at(ny, y, pot, ns, x, q), bound_for(p), "M2M p=%d, far field", p);
    free(x); free(q); free(y); free(pot); free(ue); free(uec); free(chk); free(pe); free(m2m); free(l2l);
    kifmm_laplace_destroy(h);
}

/* M2L of one box pair through the FFT path: the source density moved to the
 * check-order lattice, its spectrum times the kernel spectrum of transfer
 * vector tv, inverse onto the downward check surface, then the downward
 * solve. */
/* Transfer vector tv's kernel spectrum at frequency f: kept as such, or
 * turned from one of the 16 (ktab: pi, s, the slot, the turn's number,
 * then the component and its sign; laplace has one component) */
static void spectrum(const kifmm_laplace__ops *o, const kifmm__fft *pl, int f, int tv, double *k)
{
    if (!o->ktab) {
        k[0] = o->khat[((size_t)f * KIFMM__NT + tv) * 2];
        k[1] = o->khat[((size_t)f * KIFMM__NT + tv) * 2 + 1];
    } else {
        const int *e = o->ktab + (size_t)KIFMM__KTAB_W(1) * tv;
        const int kk[3] = {f / (pl->n * pl->nh), f / pl->nh % pl->n, f % pl->nh};
        double cj;
        const size_t g = kifmm__fft_turned(pl, e, e + 3, kk, &cj);
        k[0] = e[9] * o->khat[(g * 16 + (size_t)e[6]) * 2];
        k[1] = e[9] * cj * o->khat[(g * 16 + (size_t)e[6]) * 2 + 1];
    }
}

static void m2l_fft(const kifmm_laplace *c, int tv, const double *ue, double *de)
{
    kifmm__fft plan = c->pl->fft; /* this helper works in double throughout */
    const kifmm__fft *pl = &plan;
    const kifmm_laplace__ops *o = c->lv[0];
    const size_t cs = 16 * KIFMM__FFT_F;
    double *spec = t_doubles(16 * pl->nfp), *prod = t_doubles(16 * pl->nfp);
    double *work = t_doubles((int64_t)kifmm__fft_work8(pl)), *chk = t_doubles(8 * c->pl->surf.nc);
    double *m = t_doubles(c->pl->surf.nc), *m8 = t_doubles(8 * c->pl->surf.nc);
    int f, i;
    plan.single = 0;
    t_fill(16 * pl->nfp, spec, 0.0);
    t_fill(16 * pl->nfp, prod, 0.0);
    if (o->conv) kifmm__gemm(0, 0, c->pl->surf.nc, 1, c->pl->surf.ne, 1.0, o->conv, c->pl->surf.nc, ue, c->pl->surf.ne, 0.0, m, c->pl->surf.nc);
    else memcpy(m, ue, (size_t)c->pl->surf.nc * sizeof(double)); /* lattice = equivalent surface */
    /* lane 3 of the batched transforms carries the density, the others 0 */
    t_fill(8 * c->pl->surf.nc, m8, 0.0);
    for (i = 0; i < c->pl->surf.nc; i++) m8[8 * i + 3] = m[i];
    kifmm__fft_forward8d(pl, m8, 1, 0, spec, cs, work);
    for (f = 0; f < pl->nf; f++) {
        size_t a = (size_t)(f / KIFMM__FFT_F) * cs + (size_t)(f % KIFMM__FFT_F) * 16 + 3;
        double k[2];
        spectrum(o, pl, f, tv, k);
        prod[a] = spec[a] * k[0] - spec[a + 8] * k[1];
        prod[a + 8] = spec[a] * k[1] + spec[a + 8] * k[0];
    }
    kifmm__fft_inverse8d(pl, prod, cs, 1, 0, chk, work);
    for (i = 0; i < c->pl->surf.nc; i++) m[i] = chk[8 * i + 3];
    solve(c, 0, m, de);
    free(spec); free(prod); free(work); free(chk); free(m); free(m8);
}

/* Sources in the box at transfer vector d from the target box (centre ctr,
 * half-width r), P2M, M2L by FFT, the downward solve, evaluated at targets
 * in the target box: the relative error against the direct sum. x, q, y,
 * pot, ue, de, pe keep this case's values. */
static double m2l_case(const kifmm_laplace *c, t_rng *g, const int *d, const double *ctr, double r,
                       int ns, int ny, double *x, double *q, double *y, double *pot, double *ue,
                       double *de, double *pe)
{
    double cs[3];
    int k;
    for (k = 0; k < 3; k++) cs[k] = ctr[k] + 2 * r * d[k];
    points_in_box(g, ns, cs, r, x);
    t_gen_charges(g, ns, q, -1, 1);
    points_in_box(g, ny, ctr, r, y);
    p2m(c, cs, r, ns, x, q, ue);
    m2l_fft(c, kifmm__transfer_index(d[0], d[1], d[2]), ue, de);
    eval_equiv(c, down_points(c, ctr, r, pe), pe, de, ny, y, pot);
    return rel_err_at(ny, y, pot, ns, x, q);
}

static void test_downward(int p)
{
    kifmm_laplace *h = handle(p);
    kifmm_laplace_dense *hd = NULL;
    const kifmm_laplace *c = h;
    t_rng g = t_rng_seed(23 + p);
    double ctr[3] = {-0.1, 0.2, 0.05}, r = 0.125, *x, *q, *y, *pot, *ue, *de, *dec, *chk, *pe,
           *pc, *xs, *m2m, *l2l;
    int ns = 300, ny = 300, tv, o, k;
    static const int vecs[4][3] = {{2, 0, 0}, {3, -2, 1}, {-3, -3, -3}, {0, 2, -2}};
    x = t_doubles(3 * ns); q = t_doubles(ns); y = t_doubles(3 * ny); pot = t_doubles(ny);
    m2m = t_doubles(8 * (size_t)c->pl->surf.nc * c->pl->surf.ne);
    l2l = t_doubles(8 * (size_t)c->pl->surf.nc * c->pl->surf.nde);
    ue = t_doubles(c->pl->surf.ne); de = t_doubles(c->pl->surf.nde); dec = t_doubles(c->pl->surf.nde);
    chk = t_doubles(8 * c->pl->surf.nc); pc = t_doubles(3 * c->pl->surf.nsc);
    pe = t_doubles(3 * (c->pl->surf.nse + c->pl->surf.nsa));
    xs = t_doubles(3 * ns);
    {
        int n;
        double *xo = ops_points(&n);
        kifmm_opts o = t_opts(p, 8, 0);
        CHECK(kifmm_laplace_dense_create(&hd, &o, n, xo, n, xo) == 0 && hd->lv[0]->m2l != NULL,
              "dense create %d, operators built", p);
    }

    /* M2L: source box at transfer vector d (in box widths), P2M there, M2L,
     * solve, evaluate at targets inside the target box */
    for (k = 0; k < 4; k++) {
        const int *d = vecs[k];
        tv = kifmm__transfer_index(d[0], d[1], d[2]);
        CHECK_ERR(m2l_case(c, &g, d, ctr, r, ns, ny, x, q, y, pot, ue, de, pe), bound_for(p),
                  "M2L (FFT) p=%d, transfer vector (%d,%d,%d)", p, d[0], d[1], d[2]);
        /* dense path: the stored matrices include the first factor of the
         * solve; its downward equivalent surface has its own radius (hd->pl->surf.ao:
         * the dense instance checks on order p + 1) */
        {
            const kifmm_laplace_dense__ops *od = hd->lv[0];
            kifmm__gemm(0, 0, od->kd, 1, c->pl->surf.ne, 1.0, od->m2l + (size_t)tv * c->pl->surf.ne * od->kd,
                        od->kd, ue, c->pl->surf.ne, 0.0, chk, od->kd);
            kifmm__gemm(0, 0, hd->pl->surf.nde, 1, od->kd, 1.0, od->vs_dn, hd->pl->surf.nde, chk, od->kd, 0.0,
                        de, hd->pl->surf.nde);
        }
        kifmm_laplace_dense__place_down(&hd->pl->surf, ctr, hd->pl->surf.ao * r, r, pe);
        eval_equiv(c, hd->pl->surf.nse + hd->pl->surf.nsa, pe, de, ny, y, pot);
        CHECK_ERR(rel_err_at(ny, y, pot, ns, x, q), bound_for(p),
                  "M2L (dense) p=%d, transfer vector (%d,%d,%d)", p, d[0], d[1], d[2]);
    }
    /* the FFT path at every transfer vector: laplace's spectra are built for
     * 16 of them and turned to the others by the cube's symmetries (the same
     * errors, to the printed digits, as with all 316 built). The worst of
     * them, two box widths apart, is above the four above: 4.9e-7 at p = 8,
     * hence 1.5 times their bound */
    {
        double worst = 0.0;
        int wd[3] = {0, 0, 0};
        for (tv = 0; tv < KIFMM__NT; tv++) {
            int d[3];
            double e;
            kifmm__transfer_vector(tv, d);
            e = m2l_case(c, &g, d, ctr, r, ns, ny, x, q, y, pot, ue, de, pe);
            if (!(e <= worst)) {
                worst = e;
                memcpy(wd, d, sizeof wd);
            }
        }
        CHECK_ERR(worst, 1.5 * bound_for(p), "M2L (FFT) p=%d, all 316 transfer vectors (worst at %d,%d,%d)",
                  p, wd[0], wd[1], wd[2]);
    }

    /* P2L then L2L: sources well apart from a parent of half-width 2r; the
     * parent's local expansion moved to each child, evaluated inside it */
    {
        double cp[3] = {ctr[0], ctr[1], ctr[2]}, cs[3] = {ctr[0] + 8 * r, ctr[1] - 4 * r, ctr[2]};
        points_in_box(&g, ns, cs, 2 * r, x);
        t_gen_charges(&g, ns, q, -1, 1);
        soa(ns, x, xs);
        kifmm__surf_place(c->pl->surf.unit_c, c->pl->surf.nsc, cp, c->pl->surf.ai * 2 * r, pc);
        t_fill(c->pl->surf.nc, chk, 0.0);
        kifmm_laplace__p2p_qc(c->opts.kernel_param, pc, pc + c->pl->surf.nsc, pc + 2 * c->pl->surf.nsc, c->pl->surf.nsc, xs, xs + ns,
                                 xs + 2 * ns, q, ns, 1, 0, 2 * r * c->lv[0]->sigma, chk, 0);
        solve(c, 0, chk, de);
        points_in_box(&g, ny, cp, 2 * r, y);
        eval_equiv(c, down_points(c, cp, 2 * r, pe), pe, de, ny, y, pot);
        CHECK_ERR(rel_err_at(ny, y, pot, ns, x, q), bound_for(p), "P2L p=%d, inside the box", p);
        family_octants(c, m2m, l2l);
        kifmm__gemm(0, 0, 8 * c->pl->surf.nc, 1, c->pl->surf.nde, 1.0, l2l, 8 * c->pl->surf.nc, de,
                    c->pl->surf.nde, 0.0, chk, 8 * c->pl->surf.nc);
        for (o = 0; o < 8; o++) {
            double cc[3] = {cp[0] + (o >> 2 & 1 ? r : -r), cp[1] + (o >> 1 & 1 ? r : -r),
                            cp[2] + (o & 1 ? r : -r)};
            solve(c, 0, chk + (size_t)o * c->pl->surf.nc, dec);
            points_in_box(&g, ny, cc, r, y);
            eval_equiv(c, down_points(c, cc, r, pe), pe, dec, ny, y, pot);
            CHECK_ERR(rel_err_at(ny, y, pot, ns, x, q), bound_for(p), "L2L p=%d, child %d", p, o);
        }
    }
    free(x); free(q); free(y); free(pot); free(ue); free(de); free(dec); free(chk); free(m2m); free(l2l);
    free(pe); free(pc); free(xs);
    kifmm_laplace_destroy(h);
    kifmm_laplace_dense_destroy(hd);
}

static void test_transfer_vectors(void)
{
    int t, bad = 0, d[3];
    for (t = 0; t < KIFMM__NT; t++) {
        kifmm__transfer_vector(t, d);
        if (kifmm__transfer_index(d[0], d[1], d[2]) != t) bad++;
        if (abs(d[0]) <= 1 && abs(d[1]) <= 1 && abs(d[2]) <= 1) bad++;
    }
    CHECK(bad == 0, "%d transfer vectors misnumbered", bad);
}

/* Tree invariants on an adaptive tree. */
static void test_tree(const char *name, int64_t n, const double *xyz, int leaf)
{
    kifmm_laplace *h = NULL;
    kifmm_opts o = t_opts(4, leaf, 0);
    kifmm__tree tree;
    const kifmm__tree *t = &tree;
    int32_t b, a, i;
    int unbalanced = 0, badcover = 0, over = 0, maxu = 0, maxv = 0, maxw = 0, maxx = 0;
    int64_t *cover;
    CHECK(kifmm_laplace_create(&h, &o, n, xyz, n, xyz) == 0, "create %s", name);
    if (!h) return;
    /* the handle's tree again, with its V entries (the FFT M2L keeps only
     * their counts): the same builder, the same options */
    CHECK(kifmm__tree_build(&tree, n, xyz, n, xyz, h->opts.leaf_size, h->opts.max_depth,
                            h->opts.nthreads, 1, NULL, NULL) == 0,
          "tree with V entries, %s", name);
    CHECK(tree.nbox == h->tree->nbox && tree.nlev == h->tree->nlev &&
              !memcmp(tree.vo, h->tree->vo, ((size_t)tree.nbox + 1) * sizeof(int32_t)) &&
              !memcmp(tree.uo, h->tree->uo, ((size_t)tree.nbox + 1) * sizeof(int32_t)) &&
              h->tree->v == NULL,
          "%s: the handle's tree matches, without V entries", name);
    cover = (int64_t *)t_malloc_or_die((size_t)(t->ns + 1) * sizeof(int64_t));
    /* 2:1 balance: adjacent leaves differ by at most one level */
    for (b = 0; b < t->nbox; b++) {
        if (t->child[b] >= 0) continue;
        for (a = b + 1; a < t->nbox; a++)
            if (t->child[a] < 0 && abs(kifmm__level_of(t, a) - kifmm__level_of(t, b)) > 1 &&
                kifmm__adjacent(t, a, b))
                unbalanced++;
    }
    CHECK(unbalanced == 0, "%s: %d adjacent leaf pairs more than one level apart", name,
          unbalanced);
    /* every source once: U and W of the leaf, V and X of it and its ancestors */
    for (i = 0; i < t->nleaves; i++) {
        int32_t leafb = t->leaves[i], anc = leafb, e;
        int64_t s, run = 0;
        memset(cover, 0, (size_t)(t->ns + 1) * sizeof(int64_t));
#define COVER(box) (cover[t->s0[box]]++, cover[t->s1[box]]--)
        for (e = t->uo[leafb]; e < t->uo[leafb + 1]; e++) COVER(t->u[e]);
        for (e = t->wo[leafb]; e < t->wo[leafb + 1]; e++) COVER(t->w[e]);
        if (t->uo[leafb + 1] - t->uo[leafb] > maxu) maxu = t->uo[leafb + 1] - t->uo[leafb];
        if (t->wo[leafb + 1] - t->wo[leafb] > maxw) maxw = t->wo[leafb + 1] - t->wo[leafb];
        while (anc >= 0) {
            int l = kifmm__level_of(t, anc);
            for (e = t->vo[anc]; e < t->vo[anc + 1]; e++) COVER(t->v[e]);
            for (e = t->xo[anc]; e < t->xo[anc + 1]; e++) COVER(t->x[e]);
            if (t->vo[anc + 1] - t->vo[anc] > maxv) maxv = t->vo[anc + 1] - t->vo[anc];
            if (t->xo[anc + 1] - t->xo[anc] > maxx) maxx = t->xo[anc + 1] - t->xo[anc];
            if (l == 0) break;
            anc = kifmm__find(t, l - 1, t->key[anc] >> 3);
        }
#undef COVER
        for (s = 0; s < t->ns; s++) {
            run += cover[s];
            if (run != 1) { badcover++; break; }
        }
    }
    CHECK(badcover == 0, "%s: %d leaves whose lists miss or repeat a source", name, badcover);
    over = maxu > 60 || maxv > 189 || maxw > 148 || maxx > 19;
    CHECK(!over, "%s: list sizes U %d V %d W %d X %d above 60/189/148/19", name, maxu, maxv,
          maxw, maxx);
    printf("  ok   %-62s levels %d, boxes %d, max |U| %d |V| %d |W| %d |X| %d\n", name, t->nlev,
           (int)t->nbox, maxu, maxv, maxw, maxx);
    free(cover);
    kifmm__tree_free(&tree);
    kifmm_laplace_destroy(h);
}

/* The single-thread column GEMM of both precisions against long double
 * sums: row counts around the register tile (and below one vector), column
 * counts around the 6-column tile, depths across the cache block; columns at
 * scattered places with gaps that must stay untouched; set and accumulate. */
#define GC_TEST(T, SFX, EPS)                                                                   \
    static void test_gemm_cols##SFX(t_rng *g)                                                  \
    {                                                                                          \
        static const int ms[] = {1, 3, 4, 7, 8, 9, 15, 16, 17, 33, 218};                       \
        static const int ns[] = {1, 2, 5, 6, 7, 12, 13, 48};                                   \
        static const int ks[] = {1, 5, 255, 256, 257, 600};                                    \
        int im, in, ik, acc, worst_gap = 0, cases = 0;                                         \
        double worst = 0;                                                                      \
        for (im = 0; im < 11; im++)                                                            \
            for (in = 0; in < 8; in++)                                                         \
                for (ik = 0; ik < 6; ik++)                                                     \
                    for (acc = 0; acc < 2; acc++) {                                            \
                        const int m = ms[im], n = ns[in], k = ks[ik], lda = m + 3, gap = 5;    \
                        T *a = (T *)malloc(sizeof(T) * (size_t)lda * k);                       \
                        T *b = (T *)malloc(sizeof(T) * (size_t)(k + gap) * n);                 \
                        T *c = (T *)malloc(sizeof(T) * (size_t)(m + gap) * n);                 \
                        T *c0 = (T *)malloc(sizeof(T) * (size_t)(m + gap) * n);                \
                        const T *bp[48];                                                       \
                        T *cp[48];                                                             \
                        int i, j, q;                                                           \
                        for (i = 0; i < lda * k; i++) a[i] = (T)t_uniform(g, -1, 1);           \
                        for (i = 0; i < (k + gap) * n; i++) b[i] = (T)t_uniform(g, -1, 1);     \
                        for (i = 0; i < (m + gap) * n; i++) c[i] = c0[i] = (T)t_uniform(g, -1, 1); \
                        /* column j of B and C at slot n - 1 - j: pointers out of order */     \
                        for (j = 0; j < n; j++) {                                              \
                            bp[j] = b + (size_t)(n - 1 - j) * (k + gap);                       \
                            cp[j] = c + (size_t)(n - 1 - j) * (m + gap);                       \
                        }                                                                      \
                        T *wk = (T *)malloc(sizeof(T) * (size_t)(k + m) * n);                  \
                        kifmm__gemm_cols##SFX(m, k, a, lda, n, bp, cp, acc, wk);               \
                        free(wk);                                                              \
                        for (j = 0; j < n; j++) {                                              \
                            const size_t o = (size_t)(n - 1 - j) * (m + gap);                  \
                            for (i = 0; i < m; i++) {                                          \
                                long double s = acc ? (long double)c0[o + i] : 0.0L, mag = 0;  \
                                for (q = 0; q < k; q++) {                                      \
                                    long double t = (long double)a[i + (size_t)q * lda] *      \
                                                    (long double)bp[j][q];                     \
                                    s += t;                                                    \
                                    mag += t < 0 ? -t : t;                                     \
                                }                                                              \
                                mag += acc ? (c0[o + i] < 0 ? -c0[o + i] : c0[o + i]) : 0;     \
                                {                                                              \
                                    double e = (double)((c[o + i] - s) / (mag + 1e-300L));     \
                                    e = e < 0 ? -e : e;                                        \
                                    if (e > worst) worst = e;                                  \
                                }                                                              \
                            }                                                                  \
                            for (i = m; i < m + gap; i++) worst_gap += c[o + i] != c0[o + i];   \
                        }                                                                      \
                        cases++;                                                               \
                        free(a); free(b); free(c); free(c0);                                   \
                    }                                                                          \
        CHECK(worst <= 32.0 * (EPS) && worst_gap == 0,                                          \
              #T " column GEMM, %d shapes: worst error %.2e of sum |a b| (bound %.1e), %d gap entries written", \
              cases, worst, 32.0 * (EPS), worst_gap);                                          \
    }
GC_TEST(double, d, DBL_EPSILON)
GC_TEST(float, f, FLT_EPSILON)

/* A kernel matrix between the unit surfaces of orders pr (rows, radius ro)
 * and pc (columns, radius 1.05) about one centre: 1 / (4 pi r) (sd 1), or
 * exp(i k r) / (4 pi r) as real 2 x 2 blocks {re, -im; im, re} (sd 2), or
 * 3 x 3 blocks (sd 3): the Stokeslet (delta_ab / r + d_a d_b / r^3) / (8
 * pi) for k = 0, else that plus k d_a / r^2 in column b = 0 (no longer
 * turned as a vector by the cube's symmetries) */
static double *surf_matrix(int pr, int pc, double ro, int sd, double k)
{
    const int nr = kifmm__surf_count(pr), nc = kifmm__surf_count(pc), m = nr * sd;
    double *ur = t_doubles(3 * nr), *uc = t_doubles(3 * nc), *a = t_doubles(m * nc * sd);
    int i, j;
    kifmm__surf_unit(pr, ur);
    kifmm__surf_unit(pc, uc);
    for (j = 0; j < nc; j++)
        for (i = 0; i < nr; i++) {
            const double dx = ro * ur[i] - 1.05 * uc[j], dy = ro * ur[nr + i] - 1.05 * uc[nc + j];
            const double dz = ro * ur[2 * nr + i] - 1.05 * uc[2 * nc + j];
            const double r = sqrt(dx * dx + dy * dy + dz * dz), g = 1.0 / (4.0 * T_PI * r);
            if (sd == 1) {
                a[i + (size_t)j * m] = g;
            } else if (sd == 3) {
                const double d[3] = {dx, dy, dz};
                int p, q;
                for (p = 0; p < 3; p++)
                    for (q = 0; q < 3; q++)
                        a[3 * i + p + (size_t)(3 * j + q) * m] =
                            ((p == q) / r + d[p] * d[q] / (r * r * r) + (q == 0 ? k * d[p] / (r * r) : 0.0)) /
                            (8.0 * T_PI);
            } else {
                a[2 * i + (size_t)(2 * j) * m] = a[2 * i + 1 + (size_t)(2 * j + 1) * m] = g * cos(k * r);
                a[2 * i + 1 + (size_t)(2 * j) * m] = g * sin(k * r);
                a[2 * i + (size_t)(2 * j + 1) * m] = -g * sin(k * r);
            }
        }
    free(ur), free(uc);
    return a;
}

/* x = vs (ut y): the pseudo-inverse's factors (k of them) applied */
static void apply_pinv(int m, int n, int k, const double *ut, const double *vs, const double *y, double *x)
{
    double *t = t_doubles(k + 1);
    int i, j;
    for (i = 0; i < k; i++) {
        t[i] = 0.0;
        for (j = 0; j < m; j++) t[i] += ut[i + (size_t)j * k] * y[j];
    }
    for (j = 0; j < n; j++) {
        x[j] = 0.0;
        for (i = 0; i < k; i++) x[j] += vs[j + (size_t)i * n] * t[i];
    }
    free(t);
}

/* kifmm__pinv_cube against kifmm__pinv (one SVD of the whole matrix) on the
 * same matrix: the same rank, the same singular values (|vs e_j| = 1 / s_j,
 * both descending), and fits A pinv(A) y of y = A x as close to y; three
 * components (Stokeslets) turned as vectors */
static void test_pinv_cube(int pr, int pc, double ro, int sd, double k)
{
    const int m = kifmm__surf_count(pr) * sd, n = kifmm__surf_count(pc) * sd;
    double *a = surf_matrix(pr, pc, ro, sd, k), *a2 = t_doubles(m * n), *x = t_doubles(n);
    double *y = t_doubles(m), *z = t_doubles(n), *ut[2] = {NULL, NULL}, *vs[2] = {NULL, NULL};
    double sv = 0.0, s0 = 0.0, res[2] = {0.0, 0.0}, yy = 0.0;
    int rank[2] = {-1, -2}, rc[2], i, j, q;
    t_rng g = t_rng_seed(41);
    memcpy(a2, a, sizeof(double) * (size_t)m * n);
    rc[0] = kifmm__pinv(a2, m, n, 1e-15, &ut[0], &vs[0], &rank[0]);
    rc[1] = kifmm__pinv_cube(NULL, a, pr, pc, sd, sd == 3, 1e-15, &ut[1], &vs[1], &rank[1]);
    CHECK(rc[0] == KIFMM_SUCCESS && rc[1] == KIFMM_SUCCESS && rank[0] == rank[1],
          "orders %d <- %d, %d component(s): ranks %d (one SVD) and %d (by the cube's symmetries)", pr, pc, sd,
          rank[0], rank[1]);
    if (rc[0] || rc[1] || rank[0] != rank[1]) { /* (leaks what it has: the program stops at this failure) */
        free(a), free(a2), free(x), free(y), free(z);
        return;
    }
    for (j = 0; j < rank[0]; j++) {
        double nv[2] = {0.0, 0.0};
        for (q = 0; q < 2; q++)
            for (i = 0; i < n; i++) nv[q] += vs[q][i + (size_t)j * n] * vs[q][i + (size_t)j * n];
        if (j == 0) s0 = 1.0 / sqrt(nv[0]);
        sv = fmax(sv, fabs(1.0 / sqrt(nv[0]) - 1.0 / sqrt(nv[1])) / s0);
    }
    CHECK_ERR(sv, 1e-13, "orders %d <- %d, %d component(s): singular values, largest difference over s_0", pr, pc, sd);
    for (j = 0; j < n; j++) x[j] = t_uniform(&g, -1.0, 1.0);
    for (i = 0; i < m; i++) {
        y[i] = 0.0;
        for (j = 0; j < n; j++) y[i] += a[i + (size_t)j * m] * x[j];
        yy += y[i] * y[i];
    }
    for (q = 0; q < 2; q++) {
        apply_pinv(m, n, rank[q], ut[q], vs[q], y, z);
        for (i = 0; i < m; i++) {
            double f = -y[i];
            for (j = 0; j < n; j++) f += a[i + (size_t)j * m] * z[j];
            res[q] += f * f;
        }
        res[q] = sqrt(res[q] / yy);
    }
    CHECK_ERR(res[1], fmax(2.0 * res[0], 1e-14), "orders %d <- %d, %d component(s): |A pinv(A) y - y| / |y| "
              "(one SVD: %.1e)", pr, pc, sd, res[0]);
    for (q = 0; q < 2; q++) kifmm__free(ut[q]), kifmm__free(vs[q]);
    free(a), free(a2), free(x), free(y), free(z);
}

/* A matrix without the symmetries kifmm__pinv_cube takes: refused
 * (KIFMM__NOT_SYMMETRIC, so that the caller factors it whole), nothing
 * returned; with them, taken both ways for three Laplace charges. */
static void test_pinv_cube_refused(void)
{
    const int pr = 6, pc = 5, m = 3 * kifmm__surf_count(pr), n = 3 * kifmm__surf_count(pc);
    double *a = surf_matrix(pr, pc, 2.95, 3, 0.7), *ut = NULL, *vs = NULL;
    int rank = -1, rc, i, j, vec;
    rc = kifmm__pinv_cube(NULL, a, pr, pc, 3, 1, 1e-15, &ut, &vs, &rank);
    CHECK(rc == KIFMM__NOT_SYMMETRIC && ut == NULL && vs == NULL && rank == -1,
          "a 3-component kernel not turned as a vector: pinv_cube refused (%d), nothing returned", rc);
    rc = kifmm__pinv_cube(NULL, a, pr, pc, 3, 0, 1e-15, &ut, &vs, &rank);
    CHECK(rc == KIFMM__NOT_SYMMETRIC && ut == NULL && vs == NULL,
          "the same, each component as a value: refused (%d)", rc);
    free(a);
    a = surf_matrix(pr, pc, 2.95, 1, 0.0);
    {
        const int m1 = m / 3;
        double *a3 = t_doubles(m * n);
        for (j = 0; j < n; j++) /* three Laplace charges: block diagonal in the components */
            for (i = 0; i < m; i++) a3[i + (size_t)j * m] = i % 3 == j % 3 ? a[i / 3 + (size_t)(j / 3) * m1] : 0.0;
        for (vec = 0; vec < 2; vec++) {
            rc = kifmm__pinv_cube(NULL, a3, pr, pc, 3, vec, 1e-15, &ut, &vs, &rank);
            CHECK(rc == KIFMM_SUCCESS && rank > 0, "three Laplace charges, %s: pinv_cube %d, rank %d",
                  vec ? "as a vector" : "as values", rc, rank);
            kifmm__free(ut), kifmm__free(vs), ut = vs = NULL;
        }
        free(a3);
    }
    free(a);
}

int main(void)
{
    static const int orders[] = {4, 6, 8, 10};
    t_rng g = t_rng_seed(5);
    int i, n = 6000;
    double *x = t_doubles(3 * n);
    t_group("column GEMM of the level passes");
    test_gemm_colsd(&g);
    test_gemm_colsf(&g);
    t_group("transfer vectors");
    test_transfer_vectors();
    t_group("pseudo-inverses by the cube's symmetries against one SVD");
    test_pinv_cube(2, 2, 4.5, 1, 0.0);
    test_pinv_cube(6, 6, 4.5, 1, 0.0);
    test_pinv_cube(9, 8, 2.95, 1, 0.0);
    test_pinv_cube(5, 5, 4.5, 2, 3.0);
    test_pinv_cube(8, 7, 2.95, 2, 9.0);
    test_pinv_cube(6, 6, 4.5, 3, 0.0);
    test_pinv_cube(8, 7, 2.95, 3, 0.0);
    test_pinv_cube_refused();
#ifndef KIFMM_TEST_QUICK
    test_pinv_cube(12, 12, 4.5, 1, 0.0);
    test_pinv_cube(10, 9, 2.95, 2, 3.0);
#endif
    t_group("operators alone against direct sums");
    for (i = 0; i < 4; i++) {
        test_upward(orders[i]);
        test_downward(orders[i]);
    }
    t_group("tree: balance and lists");
    t_gen_cube(&g, n, x, 0, 1);
    test_tree("uniform cube", n, x, 16);
    t_gen_corner(&g, n, x);
    test_tree("clustered toward a corner", n, x, 8);
    t_gen_blobs(&g, n, x);
    test_tree("gaussian blobs", n, x, 8);
    t_gen_sphere(&g, n, x);
    test_tree("sphere surface", n, x, 8);
    t_gen_two_clusters(&g, n, x, 1e-3, 1e3);
    test_tree("two far clusters", n, x, 8);
    free(x);
    return t_finish();
}
