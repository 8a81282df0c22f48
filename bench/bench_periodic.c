/* bench/bench_periodic.c - periodic boundaries against free space, same points
 *
 *   bench_periodic N P [--repeat R]
 *
 * N uniform points in the unit cube [0, 1)^3, sources = targets, charges in
 * [-0.5, 0.5] summing to zero; for laplace and yukawa (lambda 3), one row
 * per set of periodic directions (none, x, x y, x y z; period 1): create
 * time, the fastest of R evaluates, and the evaluate's ratio to the
 * free-space one of the same kernel, all in this process. Then a slab and a
 * channel of N points: uniform in [0, 1)^2 x [0, 3) periodic in x and y,
 * and in [0, 1) x [0, 3)^2 periodic in x (the free directions 3 periods
 * wide), each against free space on its own points.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "kifmm.h"
#define KIFMM_KERNEL yukawa
#include "kifmm.h"

#include <omp.h>

static double rnd(uint64_t *s)
{
    *s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(*s >> 11) / 9007199254740992.0;
}

/* create + the fastest of rep evaluates of one kernel and period mask */
#define RUN(P, param)                                                                            \
    static int run_##P(int64_t n, const double *x, const double *q, double *out, int p, int pm,  \
                       int rep, double *tc, double *te)                                          \
    {                                                                                            \
        kifmm_opts o;                                                                            \
        P *h = NULL;                                                                             \
        double t0;                                                                               \
        int d, r, rc;                                                                            \
        memset(&o, 0, sizeof o);                                                                 \
        o.order = p;                                                                             \
        o.kernel_param[0] = param;                                                               \
        for (d = 0; d < 3; d++) o.period[d] = pm >> d & 1 ? 1.0 : 0.0;                           \
        t0 = omp_get_wtime();                                                                    \
        rc = P##_create(&h, &o, n, x, n, x);                                                     \
        *tc = omp_get_wtime() - t0;                                                              \
        *te = 1e30;                                                                              \
        for (r = 0; r < rep && !rc; r++) {                                                       \
            t0 = omp_get_wtime();                                                                \
            rc = P##_evaluate(h, q, out);                                                        \
            if (omp_get_wtime() - t0 < *te) *te = omp_get_wtime() - t0;                          \
        }                                                                                        \
        P##_destroy(h);                                                                          \
        return rc;                                                                               \
    }
RUN(kifmm_laplace, 0.0)
RUN(kifmm_yukawa, 3.0)

/* the rows of one point set: free space, then each mask of masks[1 ..] */
static void rows(const char *set, int64_t n, const double *x, const double *q, double *out, int p,
                 int rep, const int *masks, const char **names, int nm)
{
    int a, k, rc;
    for (a = 0; a < 2; a++) {
        double free_e = 0.0;
        for (k = 0; k < nm; k++) {
            double tc = 0.0, te = 0.0;
            rc = a == 0 ? run_kifmm_laplace(n, x, q, out, p, masks[k], rep, &tc, &te)
                        : run_kifmm_yukawa(n, x, q, out, p, masks[k], rep, &tc, &te);
            if (rc) {
                printf("%-8s %-8s %-6s failed: %s\n", a ? "yukawa" : "laplace", set, names[k],
                       kifmm_strerror(rc));
                continue;
            }
            if (k == 0) free_e = te;
            printf("%-8s %-8s %-6s %9.3f %9.3f %9.2f\n", a ? "yukawa" : "laplace", set, names[k], tc,
                   te, te / free_e);
        }
    }
}

int main(int argc, char **argv)
{
    static const char *names[] = {"free", "x", "x y", "x y z"}, *sn[] = {"free", "x y"};
    static const char *cn[] = {"free", "x"};
    static const int masks[] = {0, 1, 3, 7}, sm[] = {0, 3}, cm[] = {0, 1};
    int64_t n, i;
    int p, rep = 3, a;
    double *x, *q, *out, m = 0.0;
    uint64_t s = 7;
    if (argc < 3) {
        fprintf(stderr, "usage: %s N P [--repeat R]\n", argv[0]);
        return 2;
    }
    n = (int64_t)atof(argv[1]);
    p = atoi(argv[2]);
    for (a = 3; a + 1 < argc; a++)
        if (!strcmp(argv[a], "--repeat")) rep = atoi(argv[++a]);
    x = (double *)malloc((size_t)n * 3 * sizeof(double));
    q = (double *)malloc((size_t)n * sizeof(double));
    out = (double *)malloc((size_t)n * sizeof(double));
    if (!x || !q || !out) return 2;
    for (i = 0; i < 3 * n; i++) x[i] = rnd(&s);
    for (i = 0; i < n; i++) m += (q[i] = rnd(&s) - 0.5);
    for (i = 0; i < n; i++) q[i] -= m / (double)n;
    printf("%-8s %-8s %-6s %9s %9s %9s\n", "kernel", "points", "period", "create_s", "eval_s",
           "x_free");
    rows("cube", n, x, q, out, p, rep, masks, names, 4);
    for (i = 0; i < n; i++) x[3 * i + 2] *= 3.0; /* z over 3 periods: a slab */
    rows("slab 3", n, x, q, out, p, rep, sm, sn, 2);
    for (i = 0; i < n; i++) x[3 * i + 1] *= 3.0; /* y and z: a channel */
    rows("chan 3", n, x, q, out, p, rep, cm, cn, 2);
    free(x);
    free(q);
    free(out);
    return 0;
}
