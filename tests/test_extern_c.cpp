// test_extern_c.cpp - a C++ host that wraps the includes in extern "C", as
// C++ projects often do with C headers: the instances build, run and agree
// with a direct sum written here in C++ (double and float, Laplace with the
// gradient). Built and run only in the C++ configuration of tests/run.sh.
extern "C" {
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"
#define KIFMM_KERNEL laplace
#define KIFMM_REAL float
#include "kifmm.h"
}

#include <cmath>
#include <cstdio>
#include <vector>

static long passed = 0, failed = 0;

static void check(bool ok, const char *what, double v, double bound)
{
    std::printf("  %-4s %-50s %.3e  bound %.1e\n", ok ? "ok" : "FAIL", what, v, bound);
    if (ok) passed++;
    else failed++;
}

int main()
{
    const int n = 3000;
    std::vector<double> x(3 * n), q(n), out(4 * n), ref(4 * n);
    std::vector<float> xf(3 * n), qf(n), outf(n);
    unsigned long long s = 88172645463325252ULL;
    for (int i = 0; i < 3 * n; i++) {
        s ^= s << 13, s ^= s >> 7, s ^= s << 17;
        x[i] = (double)(s >> 11) / 9007199254740992.0;
        xf[i] = (float)x[i];
        x[i] = (double)xf[i]; // the same points in both instances
    }
    for (int i = 0; i < n; i++) {
        s ^= s << 13, s ^= s >> 7, s ^= s << 17;
        q[i] = (double)(s >> 11) / 9007199254740992.0 - 0.5;
        qf[i] = (float)q[i];
        q[i] = (double)qf[i];
    }
    for (int j = 0; j < n; j++) {
        double p = 0, g[3] = {0, 0, 0};
        for (int i = 0; i < n; i++) {
            double d[3] = {x[3 * j] - x[3 * i], x[3 * j + 1] - x[3 * i + 1],
                           x[3 * j + 2] - x[3 * i + 2]};
            double r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            if (r2 == 0) continue;
            double r = std::sqrt(r2);
            p += q[i] / r;
            for (int k = 0; k < 3; k++) g[k] -= q[i] * d[k] / (r2 * r);
        }
        ref[4 * j] = p / (4 * 3.14159265358979323846);
        for (int k = 0; k < 3; k++) ref[4 * j + 1 + k] = g[k] / (4 * 3.14159265358979323846);
    }

    kifmm_opts o = {};
    o.order = 6;
    kifmm_laplace_grad *h = nullptr;
    int rc = kifmm_laplace_grad_create(&h, &o, n, x.data(), n, x.data());
    if (rc == KIFMM_SUCCESS) rc = kifmm_laplace_grad_evaluate(h, q.data(), out.data());
    kifmm_laplace_grad_destroy(h);
    check(rc == KIFMM_SUCCESS, "double create + evaluate: result code", rc, 0);
    double num = 0, den = 0;
    for (int j = 0; j < n; j++) {
        num += (out[4 * j] - ref[4 * j]) * (out[4 * j] - ref[4 * j]);
        den += ref[4 * j] * ref[4 * j];
    }
    check(std::sqrt(num / den) <= 5e-6, "laplace_grad p=6 potential, rel L2 error",
          std::sqrt(num / den), 5e-6);

    o.order = 4;
    kifmm_laplacef *hf = nullptr; // the float instance's default name
    rc = kifmm_laplacef_create(&hf, &o, n, xf.data(), n, xf.data());
    if (rc == KIFMM_SUCCESS) rc = kifmm_laplacef_evaluate(hf, qf.data(), outf.data());
    kifmm_laplacef_destroy(hf);
    check(rc == KIFMM_SUCCESS, "float create + evaluate: result code", rc, 0);
    num = den = 0;
    for (int j = 0; j < n; j++) {
        num += ((double)outf[j] - ref[4 * j]) * ((double)outf[j] - ref[4 * j]);
        den += ref[4 * j] * ref[4 * j];
    }
    check(std::sqrt(num / den) <= 1e-3, "laplacef p=4 potential, rel L2 error",
          std::sqrt(num / den), 1e-3);
    std::printf("RESULT %ld %ld\n", passed, failed);
    return failed != 0;
}
