/* tests/install/host.c - a program that uses the installed library: it
 * includes kifmm_lib.h and links libkifmm (pkg-config kifmm, or CMake's
 * kifmm::kifmm), compiling nothing of kifmm.h. The Laplace potential in
 * double and the Stokeslet in float on 3,000 points, p = 6, against sums
 * written out here and against the library's kifmm_*_direct, and under
 * KIFMM_ISA the library's level in stats.build; prints "RESULT <passed>
 * <failed>" and exits nonzero on a failure. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "kifmm_lib.h"

enum { N = 3000, NC = 50 };
static int passed, failed;

static void check(int ok, const char *what, double e, double bound)
{
    printf("  %s %-52s err %.2e  bound %.0e\n", ok && e <= bound ? "ok  " : "FAIL", what, e, bound);
    if (ok && e <= bound) passed++;
    else failed++;
}

static double rnd(unsigned long long *s)
{
    *s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(*s >> 11) / 9007199254740992.0;
}

/* stats.build, and the instruction-set level of the compiled library
 * (src/kifmm_dispatch.c): the one KIFMM_ISA names when it is set (the
 * caller sets only levels this CPU runs) */
static void check_level(const kifmm_laplace *h)
{
    kifmm_stats st;
    const char *isa = getenv("KIFMM_ISA");
    char want[64];
    int rc = kifmm_laplace_stats(h, &st);
    if (rc) {
        check(0, "kifmm_laplace_stats", 1, 0);
        return;
    }
    printf("  build: %s\n", st.build);
    if (!isa) return;
    snprintf(want, sizeof want, "library level %s (", isa);
    check(strstr(st.build, want) != NULL, "stats.build names the level KIFMM_ISA asks for", 0, 0);
}

int main(void)
{
    static double x[3 * N], q[3 * N], u[3 * N], ud[3 * NC];
    static float xf[3 * N], ff[3 * N], uf[3 * N];
    const double pi4 = 4.0 * 3.14159265358979323846;
    unsigned long long s = 7;
    double num = 0, den = 0, dnum = 0;
    kifmm_opts o = {0};
    kifmm_laplace *h = NULL;
    kifmm_stokesf *hf = NULL;
    int i, j, k, rc;
    for (i = 0; i < 3 * N; i++) x[i] = rnd(&s), q[i] = rnd(&s) - 0.5;
    o.order = 6;
    /* Laplace, double */
    rc = kifmm_laplace_create(&h, &o, N, x, N, x);
    if (!rc) rc = kifmm_laplace_evaluate(h, q, u);
    if (!rc) check_level(h);
    kifmm_laplace_destroy(h);
    if (!rc) rc = kifmm_laplace_direct(&o, N, x, q, NC, x, ud);
    for (j = 0; j < NC; j++) {
        double p = 0;
        for (i = 0; i < N; i++) {
            const double dx = x[3 * j] - x[3 * i], dy = x[3 * j + 1] - x[3 * i + 1], dz = x[3 * j + 2] - x[3 * i + 2];
            if (i != j) p += q[i] / (pi4 * sqrt(dx * dx + dy * dy + dz * dz));
        }
        num += (u[j] - p) * (u[j] - p);
        dnum += (ud[j] - p) * (ud[j] - p);
        den += p * p;
    }
    check(rc == 0, "kifmm_laplace, p = 6, against sums written here", sqrt(num / den), 1e-5);
    check(rc == 0, "kifmm_laplace_direct against the same sums", sqrt(dnum / den), 1e-13);
    /* the Stokeslet, float (viscosity 1) */
    for (i = 0; i < 3 * N; i++) xf[i] = (float)x[i], ff[i] = (float)q[i];
    rc = kifmm_stokesf_create(&hf, &o, N, xf, N, xf);
    if (!rc) rc = kifmm_stokesf_evaluate(hf, ff, uf);
    kifmm_stokesf_destroy(hf);
    num = den = 0;
    for (j = 0; j < NC; j++)
        for (k = 0; k < 3; k++) {
            double v = 0;
            for (i = 0; i < N; i++) {
                double d[3], r2 = 0, fd = 0;
                int a;
                for (a = 0; a < 3; a++) {
                    d[a] = (double)xf[3 * j + a] - (double)xf[3 * i + a];
                    r2 += d[a] * d[a];
                    fd += d[a] * ff[3 * i + a];
                }
                if (i != j) v += (ff[3 * i + k] / sqrt(r2) + d[k] * fd / (r2 * sqrt(r2))) / (2.0 * pi4);
            }
            num += (uf[3 * j + k] - v) * (uf[3 * j + k] - v);
            den += v * v;
        }
    check(rc == 0, "kifmm_stokesf, p = 6, against sums written here", sqrt(num / den), 1e-4);
    if (rc) printf("%s\n", kifmm_strerror(rc));
    printf("RESULT %d %d\n", passed, failed);
    return failed != 0;
}
