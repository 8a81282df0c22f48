/* double_layer.c - a boundary-integral identity with the dipole kernel.
 *
 *   make double_layer ARGS="[n_theta] [order]"    defaults 64 nodes, order 6
 *   (or: cc -O2 -march=native -fopenmp -I. examples/double_layer.c
 *        -o double_layer -llapacke -lopenblas -lm)
 *
 * The Laplace double-layer potential of a density mu on a closed surface S
 * with outward normals n,
 *     D[mu](x) = integral over S of mu(y) n(y) . (x - y) / (4 pi |x - y|^3) dA(y),
 * is, for mu = 1, -1 inside S and 0 outside (Gauss's integral; -1/2 on S).
 * On the unit sphere a Gauss-Legendre rule in cos(theta) times the
 * trapezoid rule in phi turns the integral into a sum over nodes y_j with
 * weights w_j, which is the field of point dipoles v_j = mu(y_j) n(y_j) w_j:
 * the `laplace_dipole` kernel. The program evaluates it at targets inside
 * (radius 0.1 to 0.7) and outside (1.4 to 3), prints the errors against -1
 * and 0, and returns nonzero if the RMS error is above 1e-5 (order >= 6) or
 * 1e-3. On the surface the integrand is singular at the target; at the
 * poles (0, 0, +-1) it is mu / (8 pi |x - y|), and |x - y| = 2 sin(theta /
 * 2) or 2 cos(theta / 2) cancels against dA = sin(theta) dtheta dphi, so a
 * Gauss-Legendre rule in theta (not cos theta) integrates it to rounding:
 * the poles are checked against -1/2 with a second set of nodes.
 *
 * A boundary-element code needs the single layer on the same nodes too,
 *     S[mu](x) = integral over S of mu(y) / (4 pi |x - y|) dA(y),
 * for mu = 1 on the unit sphere 1 inside (gradient 0) and 1 / |x| outside
 * (gradient -x / |x|^3): charges q_j = w_j through `laplace_grad`. Its
 * handle is made on the double layer's tree (kifmm_laplace_grad_create_on_tree
 * with kifmm_laplace_dipole_tree): the nodes are not sorted again. Its
 * RMS errors (potential, and gradient relative to 1 / |x|^2) share the bound.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#define KIFMM_KERNEL laplace_dipole
#include "kifmm.h"
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"

#define PI 3.14159265358979323846

/* Gauss-Legendre nodes x[i] and weights w[i] on [-1, 1] (Newton on P_n) */
static void gauss_legendre(int n, double *x, double *w)
{
    int i, k, it;
    for (i = 0; i < n; i++) {
        double t = cos(PI * (i + 0.75) / (n + 0.5)), p0 = 1.0, p1 = 0.0, dp = 1.0;
        for (it = 0; it < 100; it++) {
            double dt;
            p0 = 1.0;
            p1 = 0.0;
            for (k = 1; k <= n; k++) { /* P_k(t) from P_(k-1), P_(k-2) */
                const double p2 = p1;
                p1 = p0;
                p0 = ((2.0 * k - 1.0) * t * p1 - (k - 1.0) * p2) / k;
            }
            dp = n * (t * p0 - p1) / (t * t - 1.0);
            dt = p0 / dp;
            t -= dt;
            if (fabs(dt) < 1e-16) break;
        }
        x[i] = t;
        w[i] = 2.0 / ((1.0 - t * t) * dp * dp);
    }
}

/* a random point at distance in [r0, r1] from the origin */
static void random_point(uint64_t *s, double r0, double r1, double *p)
{
    double u[3], len = 0.0;
    int k;
    do {
        len = 0.0;
        for (k = 0; k < 3; k++) {
            *s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
            u[k] = 2.0 * ((double)(*s >> 11) * 0x1p-53) - 1.0;
            len += u[k] * u[k];
        }
    } while (len > 1.0 || len < 1e-6);
    *s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
    len = (r0 + (r1 - r0) * ((double)(*s >> 11) * 0x1p-53)) / sqrt(len);
    for (k = 0; k < 3; k++) p[k] = u[k] * len;
}

/* nt x 2 nt nodes y of the unit sphere with dipoles v = w n (mu = 1);
 * Gauss-Legendre in cos(theta) (in_theta = 0) or in theta (1) */
static void sphere_nodes(int nt, int in_theta, const double *gx, const double *gw, double *y,
                         double *v)
{
    const int np = 2 * nt;
    int i, j, k;
    for (i = 0; i < nt; i++)
        for (j = 0; j < np; j++) {
            const int64_t a = (int64_t)i * np + j;
            const double th = in_theta ? 0.5 * PI * (gx[i] + 1.0) : acos(gx[i]);
            const double ph = 2.0 * PI * j / np;
            /* dA = d(cos theta) dphi, or sin(theta) dtheta dphi */
            const double w = (in_theta ? 0.5 * PI * sin(th) : 1.0) * gw[i] * 2.0 * PI / np;
            y[3 * a] = sin(th) * cos(ph);
            y[3 * a + 1] = sin(th) * sin(ph);
            y[3 * a + 2] = cos(th);
            /* mu = 1, outward normal = the position on the unit sphere */
            for (k = 0; k < 3; k++) v[3 * a + k] = w * y[3 * a + k];
        }
}

/* The largest error against -1/2 at the two poles (nodes in theta) */
static double on_surface(int nt, int order, const double *gx, const double *gw, double *y,
                         double *v)
{
    const double pole[6] = {0.0, 0.0, 1.0, 0.0, 0.0, -1.0};
    double u[2] = {0.0, 0.0};
    kifmm_laplace_dipole *h = NULL;
    kifmm_opts o = {0};
    int rc;
    sphere_nodes(nt, 1, gx, gw, y, v);
    o.order = order;
    rc = kifmm_laplace_dipole_create(&h, &o, (int64_t)nt * 2 * nt, y, 2, pole);
    if (rc == KIFMM_SUCCESS) rc = kifmm_laplace_dipole_evaluate(h, v, u);
    kifmm_laplace_dipole_destroy(h);
    if (rc != KIFMM_SUCCESS) return HUGE_VAL;
    printf("  on S (the poles): %.9f %.9f, error against -1/2: %.2e %.2e\n", u[0], u[1],
           fabs(u[0] + 0.5), fabs(u[1] + 0.5));
    return fabs(u[0] + 0.5) > fabs(u[1] + 0.5) ? fabs(u[0] + 0.5) : fabs(u[1] + 0.5);
}

/* The single layer of mu = 1 (charges w_j = |v_j|) at the ntrg targets x of
 * the double layer's handle h (the first half inside), on h's tree: *err,
 * the largest RMS error of the potential and of the gradient. */
static int single_layer(kifmm_laplace_dipole *h, const kifmm_opts *o, int64_t ns, const double *v,
                        int ntrg, const double *x, double *err)
{
    kifmm_laplace_grad *s = NULL;
    double *q = malloc(sizeof(double) * (size_t)ns), *g = malloc(sizeof(double) * 4 * (size_t)ntrg);
    double e[4] = {0.0, 0.0, 0.0, 0.0};
    int64_t j;
    int i, k, rc = q && g ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM;
    for (j = 0; j < ns && q; j++)
        q[j] = sqrt(v[3 * j] * v[3 * j] + v[3 * j + 1] * v[3 * j + 1] + v[3 * j + 2] * v[3 * j + 2]);
    if (!rc) rc = kifmm_laplace_grad_create_on_tree(&s, o, kifmm_laplace_dipole_tree(h));
    if (!rc) rc = kifmm_laplace_grad_evaluate(s, q, g);
    if (rc) fprintf(stderr, "kifmm: %s\n", kifmm_strerror(rc));
    for (i = 0; i < ntrg && !rc; i++) { /* e: inside potential, gradient; outside the same */
        const double *p = x + 3 * i, r = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        const int in = i < ntrg / 2;
        double d = g[4 * i] - (in ? 1.0 : 1.0 / r), dg = 0.0;
        for (k = 0; k < 3; k++) {
            const double want = in ? 0.0 : -p[k] / (r * r * r), sc = in ? 1.0 : r * r;
            dg += (g[4 * i + 1 + k] - want) * (g[4 * i + 1 + k] - want) * sc * sc;
        }
        e[in ? 0 : 2] += d * d / (ntrg / 2);
        e[in ? 1 : 3] += dg / (ntrg / 2);
    }
    if (!rc) {
        printf("single layer of mu = 1, on the double layer's tree (create_on_tree):\n");
        printf("  inside:  RMS error against 1: %.2e, gradient against 0: %.2e\n", sqrt(e[0]),
               sqrt(e[1]));
        printf("  outside: RMS error against 1/|x|: %.2e, gradient against -x/|x|^3 (times "
               "|x|^2): %.2e\n", sqrt(e[2]), sqrt(e[3]));
        *err = 0.0;
        for (k = 0; k < 4; k++) *err = sqrt(e[k]) > *err ? sqrt(e[k]) : *err;
    }
    kifmm_laplace_grad_destroy(s);
    free(q);
    free(g);
    return rc;
}

int main(int argc, char **argv)
{
    const int nt = argc > 1 ? atoi(argv[1]) : 64, order = argc > 2 ? atoi(argv[2]) : 6;
    const int np = 2 * nt, ntrg = 2000;
    const int64_t ns = (int64_t)nt * np;
    double *ct = malloc(sizeof(double) * (size_t)nt), *wt = malloc(sizeof(double) * (size_t)nt);
    double *y = malloc(sizeof(double) * 3 * (size_t)ns), *v = malloc(sizeof(double) * 3 * (size_t)ns);
    double *x = malloc(sizeof(double) * 3 * ntrg), *u = malloc(sizeof(double) * ntrg);
    double ein = 0.0, eout = 0.0, eon, mean = 0.0, bound = order >= 6 ? 1e-5 : 1e-3;
    uint64_t seed = 2026;
    kifmm_laplace_dipole *h = NULL;
    kifmm_opts o = {0};
    int i, rc;
    if (nt < 2 || !ct || !wt || !y || !v || !x || !u) {
        fprintf(stderr, "usage: %s [n_theta >= 2] [order]\n", argv[0]);
        return 2;
    }
    gauss_legendre(nt, ct, wt);
    sphere_nodes(nt, 0, ct, wt, y, v);
    for (i = 0; i < ntrg; i++)
        random_point(&seed, i < ntrg / 2 ? 0.1 : 1.4, i < ntrg / 2 ? 0.7 : 3.0, x + 3 * i);
    o.order = order;
    rc = kifmm_laplace_dipole_create(&h, &o, ns, y, ntrg, x);
    if (rc == KIFMM_SUCCESS) rc = kifmm_laplace_dipole_evaluate(h, v, u);
    if (rc != KIFMM_SUCCESS) {
        fprintf(stderr, "kifmm: %s\n", kifmm_strerror(rc));
        return 1;
    }
    for (i = 0; i < ntrg; i++) {
        const double e = i < ntrg / 2 ? u[i] + 1.0 : u[i];
        if (i < ntrg / 2) {
            ein += e * e;
            mean += u[i] / (ntrg / 2);
        } else
            eout += e * e;
    }
    ein = sqrt(ein / (ntrg / 2));
    eout = sqrt(eout / (ntrg / 2));
    printf("double layer of mu = 1 on the unit sphere, %ld nodes, order %d\n", (long)ns, order);
    printf("  inside  (%d targets): mean %.9f, RMS error against -1: %.2e\n", ntrg / 2,
           mean, ein);
    printf("  outside (%d targets): RMS error against 0: %.2e\n", ntrg / 2, eout);
    if (single_layer(h, &o, ns, v, ntrg, x, &eout) != KIFMM_SUCCESS) return 1;
    ein = ein > eout ? ein : eout; /* the single layer's worst, with the double layer's */
    kifmm_laplace_dipole_destroy(h);
    eon = on_surface(nt, order, ct, wt, y, v);
    printf("  %s (bound %.0e)\n", ein <= bound && eout <= bound && eon <= bound ? "ok" : "FAILED",
           bound);
    free(ct);
    free(wt);
    free(y);
    free(v);
    free(x);
    free(u);
    return ein <= bound && eout <= bound && eon <= bound ? 0 : 1;
}
