/* bench/points.h - the point sets of the benchmarks (bench.c, bench_kernels.c):
 * splitmix64 random numbers and the cube, sphere and clustered distributions,
 * with densities uniform in [-1, 1] (dim per point). */
#ifndef BENCH_POINTS_H
#define BENCH_POINTS_H

#include <math.h>
#include <stdint.h>

#define PI 3.14159265358979323846

/* ------------------------------------------------------------------------ */
/* Random numbers: splitmix64                                               */
/* ------------------------------------------------------------------------ */
static double random01(uint64_t *state)
{
    uint64_t z = (*state += UINT64_C(0x9E3779B97F4A7C15));
    z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
    z ^= z >> 31;
    return (double)(z >> 11) * (1.0 / 9007199254740992.0);
}

static double random_normal(uint64_t *state)
{
    double u = 1.0 - random01(state); /* (0, 1] */
    double v = random01(state);
    return sqrt(-2.0 * log(u)) * cos(2.0 * PI * v);
}

/* ------------------------------------------------------------------------ */
/* Point sets                                                               */
/* ------------------------------------------------------------------------ */
enum { DIST_CUBE, DIST_SPHERE, DIST_CLUSTERED, NDIST };
static const char *dist_names[NDIST] = {"cube", "sphere", "clustered"};

/* clustered: 10% of the points uniform in the unit cube, 90% split evenly
 * between four Gaussian blobs of widths 0.1, 0.03, 0.01 and 0.003 (the
 * densest is about 10^5 times denser than the background). */
static const double blob_center[4][3] = {
    {0.30, 0.30, 0.30}, {0.70, 0.30, 0.60}, {0.40, 0.75, 0.50}, {0.75, 0.70, 0.25}};
static const double blob_sigma[4] = {0.1, 0.03, 0.01, 0.003};

static void make_points(int dist, int64_t n, int dim, uint64_t seed, double *xyz, double *q)
{
    uint64_t st = seed;
    int64_t i;
    int k;
    for (i = 0; i < n; i++) {
        double *x = xyz + 3 * i;
        if (dist == DIST_CUBE) {
            for (k = 0; k < 3; k++) x[k] = random01(&st);
        } else if (dist == DIST_SPHERE) {
            double r2;
            do {
                r2 = 0;
                for (k = 0; k < 3; k++) {
                    x[k] = random_normal(&st);
                    r2 += x[k] * x[k];
                }
            } while (r2 < 1e-20);
            for (k = 0; k < 3; k++) x[k] /= sqrt(r2);
        } else {
            double u = random01(&st);
            if (u < 0.1) {
                for (k = 0; k < 3; k++) x[k] = random01(&st);
            } else {
                int b = (int)((u - 0.1) / 0.9 * 4.0);
                if (b > 3) b = 3;
                for (k = 0; k < 3; k++)
                    x[k] = blob_center[b][k] + blob_sigma[b] * random_normal(&st);
            }
        }
    }
    for (i = 0; i < dim * n; i++) q[i] = 2.0 * random01(&st) - 1.0;
}

/* Plummer's sphere of scale radius 1 (radii from the cumulative mass, r =
 * (u^(-2/3) - 1)^(-1/2), directions uniform), the usual test of a galaxy
 * code: half the points within 1.3, a few hundred times that at the
 * largest radius of 1e5 to 1e6 points. */
static inline void make_plummer(int64_t n, int dim, uint64_t seed, double *xyz, double *q)
{
    uint64_t st = seed;
    int64_t i;
    int k;
    for (i = 0; i < n; i++) {
        double *x = xyz + 3 * i, u, r, r2;
        do u = random01(&st);
        while (u < 1e-12);
        r = 1.0 / sqrt(pow(u, -2.0 / 3.0) - 1.0 + 1e-300);
        do {
            r2 = 0;
            for (k = 0; k < 3; k++) {
                x[k] = random_normal(&st);
                r2 += x[k] * x[k];
            }
        } while (r2 < 1e-20);
        for (k = 0; k < 3; k++) x[k] *= r / sqrt(r2);
    }
    for (i = 0; i < dim * n; i++) q[i] = 2.0 * random01(&st) - 1.0;
}

#endif
