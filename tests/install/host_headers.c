/* tests/install/host_headers.c - header-only use of the installed headers
 * (CMake's kifmm::headers): a kernel of its own, the Laplace potential
 * written here, on 3,000 points at p = 6 against sums written out here;
 * prints "RESULT <passed> <failed>". */
#include <math.h>
#include <stdio.h>

#define kifmm_kernel_mine_SRC_DIM 1
#define kifmm_kernel_mine_TRG_DIM 1
#define kifmm_kernel_mine_SCALE_INVARIANT 1
#define kifmm_kernel_mine_DEGREE (-1)
static inline void kifmm_kernel_mine_eval(const double *param, double dx, double dy, double dz,
                                          double *k)
{
    const double r2 = dx * dx + dy * dy + dz * dz;
    (void)param;
    k[0] = r2 > 0.0 ? 1.0 / (4.0 * 3.14159265358979323846 * sqrt(r2)) : 0.0;
}
#define KIFMM_KERNEL mine
#include "kifmm.h"

enum { N = 3000, NC = 50 };

static double rnd(unsigned long long *s)
{
    *s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(*s >> 11) / 9007199254740992.0;
}

int main(void)
{
    static double x[3 * N], q[N], u[N];
    unsigned long long s = 11;
    double num = 0, den = 0, e;
    kifmm_opts o = {0};
    kifmm_mine *h = NULL;
    int i, j, rc;
    for (i = 0; i < 3 * N; i++) x[i] = rnd(&s);
    for (i = 0; i < N; i++) q[i] = rnd(&s) - 0.5;
    o.order = 6;
    rc = kifmm_mine_create(&h, &o, N, x, N, x);
    if (!rc) rc = kifmm_mine_evaluate(h, q, u);
    kifmm_mine_destroy(h);
    for (j = 0; j < NC; j++) {
        double p = 0;
        for (i = 0; i < N; i++) {
            const double dx = x[3 * j] - x[3 * i], dy = x[3 * j + 1] - x[3 * i + 1], dz = x[3 * j + 2] - x[3 * i + 2];
            if (i != j) p += q[i] / (4.0 * 3.14159265358979323846 * sqrt(dx * dx + dy * dy + dz * dz));
        }
        num += (u[j] - p) * (u[j] - p);
        den += p * p;
    }
    e = rc ? 1.0 : sqrt(num / den);
    printf("  %s a kernel of its own, header-only, p = 6            err %.2e  bound 1e-05\n",
           e <= 1e-5 ? "ok  " : "FAIL", e);
    printf("RESULT %d %d\n", e <= 1e-5, e > 1e-5);
    return e > 1e-5;
}
