/* bench/bench.c - one benchmark case of kifmm.h (kernel laplace_grad)
 *
 *   bench --info                 BLAS library, OpenBLAS core and threads, OpenMP settings
 *   bench --header               the column header of the table (and its legend with -v)
 *   bench DIST N P [options]     run one case, print one table row on stdout
 *
 * DIST is cube (uniform in the unit cube), sphere (uniform on the unit sphere
 * surface), clustered (Gaussian blobs, see make_points) or plummer (Plummer's
 * sphere, make_plummer).  Sources = targets,
 * charges uniform in [-1, 1], potential and gradient (laplace_grad).
 *
 * Options:
 *   --sample S     targets checked against direct summation (default 1000)
 *   --leaf L       leaf size (default 0: the library's default for the order)
 *   --repeat R     evaluate R times, report the fastest (default 1)
 *   --dump FILE    write points, charges, sample indices and the direct sums
 *                  there (input of bench/fmm3d_run.py; format in write_dump)
 *   --result FILE  write the row's numbers as key=value text there
 *   --float        use the single-precision instance (KIFMM_REAL float); the
 *                  points and charges are rounded to float, the error is
 *                  still against the double direct sums
 *   --nrhs K       evaluate K density vectors in one evaluate_many call (the
 *                  first is the one checked); "evaluate" is the whole call
 *   --cache DIR    opts.operator_cache = DIR: the operators are read from
 *                  DIR where an earlier run wrote them (create's "ops" is
 *                  then the reading), else built and written there
 *
 * Each case should run in its own process: the peak memory reported is the
 * process's high-water mark (getrusage ru_maxrss), read right after evaluate.
 * The direct sums run afterwards over the sample targets, in parallel with
 * OpenMP; "direct s" is their time scaled by N / sample, an estimate of a
 * full direct summation with the same threads.
 */
#define _GNU_SOURCE /* dladdr */

#include <dlfcn.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"
#define KIFMM_KERNEL laplace_grad
#define KIFMM_REAL float
#define KIFMM_NAME kifmm_laplace_gradf
#include "kifmm.h"

#include <omp.h>

#define DIST_NAME(d) ((d) == NDIST ? "plummer" : dist_names[d])

/* OpenBLAS extensions (declared in OpenBLAS's cblas.h).  Weak, so that the
 * program also links against another BLAS: they are then NULL. */
#pragma weak openblas_get_config
#pragma weak openblas_get_corename
#pragma weak openblas_get_num_threads
#pragma weak openblas_get_parallel
extern char *openblas_get_config(void);
extern char *openblas_get_corename(void);
extern int openblas_get_num_threads(void);
extern int openblas_get_parallel(void);
/* The Fortran LAPACK routine behind LAPACKE (declared by lapack.h), to report
 * which library serves it. */
#pragma weak dgesvd_

#include "points.h"

/* ------------------------------------------------------------------------ */
/* Direct summation at sample targets                                       */
/* ------------------------------------------------------------------------ */
/* ref[4s..4s+3] = potential and gradient at target idx[s], kifmm's convention
 * (1/(4 pi r), gradient with respect to the target, self pair skipped). */
static void direct_sums(int64_t n, const double *xyz, const double *q, int64_t ns,
                        const int64_t *idx, double *ref)
{
    double *x = malloc((size_t)n * sizeof(double));
    double *y = malloc((size_t)n * sizeof(double));
    double *z = malloc((size_t)n * sizeof(double));
    int64_t i, s;
    if (!x || !y || !z) {
        fprintf(stderr, "bench: out of memory (direct sums)\n");
        exit(1);
    }
#pragma omp parallel for schedule(static)
    for (i = 0; i < n; i++) {
        x[i] = xyz[3 * i];
        y[i] = xyz[3 * i + 1];
        z[i] = xyz[3 * i + 2];
    }
#pragma omp parallel for schedule(dynamic, 1)
    for (s = 0; s < ns; s++) {
        const double tx = xyz[3 * idx[s]], ty = xyz[3 * idx[s] + 1], tz = xyz[3 * idx[s] + 2];
        double p = 0, gx = 0, gy = 0, gz = 0;
        int64_t j;
        /* clang keeps sqrt's errno and cannot vectorise this loop (it warns
         * when asked); gcc can */
#if !defined(__clang__)
#pragma omp simd reduction(+ : p, gx, gy, gz)
#endif
        for (j = 0; j < n; j++) {
            double dx = tx - x[j], dy = ty - y[j], dz = tz - z[j];
            double r2 = dx * dx + dy * dy + dz * dz;
            double rinv = r2 > 0.0 ? 1.0 / sqrt(r2) : 0.0;
            double qr = q[j] * rinv;
            double qr3 = qr * rinv * rinv;
            p += qr;
            gx -= qr3 * dx;
            gy -= qr3 * dy;
            gz -= qr3 * dz;
        }
        ref[4 * s] = p / (4 * PI);
        ref[4 * s + 1] = gx / (4 * PI);
        ref[4 * s + 2] = gy / (4 * PI);
        ref[4 * s + 3] = gz / (4 * PI);
    }
    free(x);
    free(y);
    free(z);
}

/* ------------------------------------------------------------------------ */
/* Settings report                                                          */
/* ------------------------------------------------------------------------ */
/* The library that holds function fn. ISO C has no conversion from a
 * function pointer to void *, which dladdr takes; POSIX gives them the same
 * representation, so the bytes are copied. */
typedef void (*bench_fn)(void);
static const char *lib_of(bench_fn fn)
{
    static char buf[4][1024];
    static int k = 0;
    Dl_info info;
    void *sym = NULL;
    char *r;
    if (sizeof sym == sizeof fn) memcpy(&sym, &fn, sizeof sym);
    if (!sym || !dladdr(sym, &info) || !info.dli_fname) return "(not found)";
    k = (k + 1) % 4;
    r = realpath(info.dli_fname, buf[k]);
    return r ? r : info.dli_fname;
}

static const char *env_or(const char *name, const char *dflt)
{
    const char *v = getenv(name);
    return v ? v : dflt;
}

static void print_info(void)
{
    char line[512], model[256] = "?";
    FILE *f = fopen("/proc/cpuinfo", "r");
    if (f) {
        while (fgets(line, sizeof line, f)) {
            if (!strncmp(line, "model name", 10)) {
                char *c = strchr(line, ':');
                if (c) {
                    snprintf(model, sizeof model, "%s", c + 2);
                    model[strcspn(model, "\n")] = 0;
                }
                break;
            }
        }
        fclose(f);
    }
    printf("cpu:         %s, %d processors online\n", model, omp_get_num_procs());
    printf("compiler:    %s\n", __VERSION__);
    printf("kifmm.h:     %d.%d.%d, kernel laplace_grad\n", KIFMM_VERSION_MAJOR,
           KIFMM_VERSION_MINOR, KIFMM_VERSION_PATCH);
    printf("BLAS:        cblas_dgemm from %s\n", lib_of((bench_fn)&cblas_dgemm));
    printf("LAPACK:      LAPACKE_dgesvd_work from %s\n", lib_of((bench_fn)&LAPACKE_dgesvd_work));
    printf("             dgesvd_ from %s\n", lib_of((bench_fn)&dgesvd_));
    if (openblas_get_config) {
        int par = openblas_get_parallel ? openblas_get_parallel() : -1;
        printf("OpenBLAS:    %s\n", openblas_get_config());
        printf("             core %s, %d threads, threading %s\n",
               openblas_get_corename ? openblas_get_corename() : "?",
               openblas_get_num_threads ? openblas_get_num_threads() : -1,
               par == 0 ? "sequential" : par == 1 ? "pthreads" : par == 2 ? "OpenMP" : "?");
    } else {
        printf("OpenBLAS:    not in use (no openblas_get_config)\n");
    }
    printf("environment: OMP_NUM_THREADS=%s OPENBLAS_NUM_THREADS=%s OPENBLAS_CORETYPE=%s\n",
           env_or("OMP_NUM_THREADS", "<unset>"), env_or("OPENBLAS_NUM_THREADS", "<unset>"),
           env_or("OPENBLAS_CORETYPE", "<unset>"));
    printf("OpenMP:      omp_get_max_threads() = %d, OMP_PROC_BIND=%s, OMP_DYNAMIC=%s\n",
           omp_get_max_threads(), env_or("OMP_PROC_BIND", "<unset>"),
           env_or("OMP_DYNAMIC", "<unset>"));
}

/* ------------------------------------------------------------------------ */
/* Table                                                                    */
/* ------------------------------------------------------------------------ */
#define ROW_FMT                                                                              \
    "%-15s %8s %2s %4s %3s %8s %8s %8s | %7s %7s %7s %7s %7s %7s %7s %7s %7s %7s | %7s %7s | " \
    "%8s %8s %9s\n"

static void print_header(int legend)
{
    printf(ROW_FMT, "dist", "N", "p", "leaf", "lev", "create", "evaluate", "total", "tree",
           "ops", "P2M", "M2M", "M2L", "L2L", "P2L", "L2P", "M2P", "P2P", "peakMiB",
           "fmmMiB", "err_pot", "err_grad", "direct");
    if (legend) {
        printf("# times in seconds (wall); create = tree + ops (+ setup), evaluate = P2M..P2P "
               "(+ copies)\n");
        printf("# peakMiB = process high-water mark after evaluate (points, charges, outputs "
               "included); fmmMiB = memory the handle holds\n");
        printf("# err = relative L2 error vs direct summation on the sample targets; direct = "
               "direct summation time for all N targets, estimated from the sample\n");
        printf("# dist/f32 = single-precision instance; dist/xK = K density vectors in one "
               "evaluate_many call (evaluate and stage times for all K)\n");
    }
}

static void fmt_n(char *buf, size_t len, int64_t n)
{
    snprintf(buf, len, "%lld", (long long)n);
}

static void write_dump(const char *path, int64_t n, const double *xyz, const double *q,
                       int64_t ns, const int64_t *idx, const double *ref)
{
    /* Little-endian binary: int64 n, int64 ns, double xyz[3n], double q[n],
     * int64 idx[ns], double ref[4ns] (potential, gradient; 1/(4 pi r) kernel). */
    FILE *f = fopen(path, "wb");
    int ok;
    if (!f) {
        perror(path);
        exit(1);
    }
    ok = fwrite(&n, sizeof n, 1, f) == 1 && fwrite(&ns, sizeof ns, 1, f) == 1 &&
         fwrite(xyz, sizeof(double), (size_t)(3 * n), f) == (size_t)(3 * n) &&
         fwrite(q, sizeof(double), (size_t)n, f) == (size_t)n &&
         fwrite(idx, sizeof(int64_t), (size_t)ns, f) == (size_t)ns &&
         fwrite(ref, sizeof(double), (size_t)(4 * ns), f) == (size_t)(4 * ns);
    if (fclose(f) != 0 || !ok) {
        fprintf(stderr, "bench: cannot write %s\n", path);
        exit(1);
    }
}

/* create + evaluate (or evaluate_many) of one instance on double inputs;
 * float instances get rounded copies, their first output vector is widened
 * into out. */
typedef struct {
    double t_create, t_eval;
    kifmm_stats st;
    kifmm_opts used;
} run_result;

#define DEFINE_RUN(P, R)                                                                     \
    static int run_##P(int64_t n, const double *xyz, const double *q, int nrhs,              \
                       const kifmm_opts *opts, int repeat, double *out, run_result *res)     \
    {                                                                                        \
        P *fmm = NULL;                                                                       \
        R *x = (R *)xyz, *qq = (R *)q, *o = (R *)out;                                        \
        int64_t i, nq = (int64_t)nrhs * n, no = (int64_t)nrhs * n * 4;                       \
        double t0;                                                                           \
        int rc, r;                                                                           \
        if (sizeof(R) != sizeof(double)) {                                                   \
            x = (R *)malloc((size_t)(3 * n) * sizeof(R));                                    \
            qq = (R *)malloc((size_t)nq * sizeof(R));                                        \
            o = (R *)malloc((size_t)no * sizeof(R));                                         \
            if (!x || !qq || !o) return KIFMM_ERR_NOMEM;                                     \
            for (i = 0; i < 3 * n; i++) x[i] = (R)xyz[i];                                    \
            for (i = 0; i < nq; i++) qq[i] = (R)q[i];                                        \
            memset(o, 0, (size_t)no * sizeof(R));                                            \
        }                                                                                    \
        t0 = omp_get_wtime();                                                                \
        rc = P##_create(&fmm, opts, n, x, n, x);                                             \
        res->t_create = omp_get_wtime() - t0;                                                \
        for (r = 0; r < repeat && rc == KIFMM_SUCCESS; r++) {                                \
            double te;                                                                       \
            t0 = omp_get_wtime();                                                            \
            rc = nrhs == 1 ? P##_evaluate(fmm, qq, o) : P##_evaluate_many(fmm, nrhs, qq, o); \
            te = omp_get_wtime() - t0;                                                       \
            if (rc == KIFMM_SUCCESS && (r == 0 || te < res->t_eval)) {                       \
                res->t_eval = te; /* the fastest run, with its stage times */                \
                P##_stats(fmm, &res->st);                                                    \
            }                                                                                \
        }                                                                                    \
        if (rc == KIFMM_SUCCESS) P##_options(fmm, &res->used);                               \
        P##_destroy(fmm);                                                                    \
        if (sizeof(R) != sizeof(double)) {                                                   \
            for (i = 0; i < 4 * n; i++) out[i] = (double)o[i];                               \
            free(x);                                                                         \
            free(qq);                                                                        \
            free(o);                                                                         \
        }                                                                                    \
        return rc;                                                                           \
    }

DEFINE_RUN(kifmm_laplace_grad, double)
DEFINE_RUN(kifmm_laplace_gradf, float)

static void usage(const char *argv0)
{
    fprintf(stderr,
            "usage: %s --info | --header [-v] | DIST N P [--sample S] [--leaf L] [--repeat R]\n"
            "       [--dump FILE] [--result FILE] [--float] [--nrhs K] [--cache DIR]\n"
            "       DIST: cube, sphere, clustered or plummer\n",
            argv0);
    exit(2);
}

int main(int argc, char **argv)
{
    int dist = -1, order, leaf = 0, repeat = 1, rc, a, single = 0, nrhs = 1;
    int64_t n, ns = 1000, i, s;
    const char *dump = NULL, *result = NULL, *cache = NULL;
    double *xyz, *q, *out, *ref;
    int64_t *idx;
    double t0, t_create, t_eval, t_direct, peak_mib;
    double num_p = 0, den_p = 0, num_g = 0, den_g = 0, err_p, err_g;
    kifmm_opts opts = {0}, used;
    kifmm_stats st;
    run_result res;
    struct rusage ru;
    char nbuf[32], pbuf[8], lbuf[16], vbuf[8], c[13][16];

    if (argc >= 2 && !strcmp(argv[1], "--info")) {
        print_info();
        return 0;
    }
    if (argc >= 2 && !strcmp(argv[1], "--header")) {
        print_header(argc >= 3 && !strcmp(argv[2], "-v"));
        return 0;
    }
    if (argc < 4) usage(argv[0]);
    for (a = 0; a < NDIST; a++)
        if (!strcmp(argv[1], dist_names[a])) dist = a;
    if (!strcmp(argv[1], "plummer")) dist = NDIST;
    n = (int64_t)atof(argv[2]); /* accepts 1e6 */
    order = atoi(argv[3]);
    if (dist < 0 || n < 1) usage(argv[0]);
    for (a = 4; a < argc; a++) {
        if (!strcmp(argv[a], "--float")) {
            single = 1;
            continue;
        }
        if (a + 1 >= argc) usage(argv[0]);
        if (!strcmp(argv[a], "--sample")) ns = (int64_t)atof(argv[++a]);
        else if (!strcmp(argv[a], "--leaf")) leaf = atoi(argv[++a]);
        else if (!strcmp(argv[a], "--repeat")) repeat = atoi(argv[++a]);
        else if (!strcmp(argv[a], "--dump")) dump = argv[++a];
        else if (!strcmp(argv[a], "--result")) result = argv[++a];
        else if (!strcmp(argv[a], "--float")) single = 1;
        else if (!strcmp(argv[a], "--nrhs")) nrhs = atoi(argv[++a]);
        else if (!strcmp(argv[a], "--cache")) cache = argv[++a];
        else usage(argv[0]);
    }
    if (ns > n) ns = n;
    if (ns < 1 || repeat < 1 || nrhs < 1) usage(argv[0]);

    xyz = malloc((size_t)n * 3 * sizeof(double));
    q = malloc((size_t)n * nrhs * sizeof(double));
    out = malloc((size_t)n * 4 * nrhs * sizeof(double));
    idx = malloc((size_t)ns * sizeof(int64_t));
    ref = malloc((size_t)ns * 4 * sizeof(double));
    if (!xyz || !q || !out || !idx || !ref) {
        fprintf(stderr, "bench: out of memory\n");
        return 1;
    }
    /* The points and charges depend on (DIST, N) only, not on the order. */
    if (dist == NDIST)
        make_plummer(n, 1, UINT64_C(0x5eed) + 1000003 * (uint64_t)dist + (uint64_t)n, xyz, q);
    else
        make_points(dist, n, 1, UINT64_C(0x5eed) + 1000003 * (uint64_t)dist + (uint64_t)n, xyz, q);
    /* further density vectors: more charges of the same kind */
    {
        uint64_t st2 = UINT64_C(0xC0FFEE);
        for (i = n; i < n * nrhs; i++) q[i] = 2.0 * random01(&st2) - 1.0;
    }
    /* touch the output array so its first-touch cost is not timed */
    memset(out, 0, (size_t)n * 4 * nrhs * sizeof(double));

    opts.order = order;
    opts.leaf_size = leaf;
    opts.nthreads = omp_get_max_threads();
    opts.operator_cache = cache;
    memset(&res, 0, sizeof res);
    rc = single ? run_kifmm_laplace_gradf(n, xyz, q, nrhs, &opts, repeat, out, &res)
                : run_kifmm_laplace_grad(n, xyz, q, nrhs, &opts, repeat, out, &res);
    if (rc != KIFMM_SUCCESS) {
        fprintf(stderr, "bench: %s, N=%lld, p=%d: %s\n", DIST_NAME(dist), (long long)n, order,
                kifmm_strerror(rc));
        return 1;
    }
    getrusage(RUSAGE_SELF, &ru);
    peak_mib = (double)ru.ru_maxrss / 1024.0; /* Linux: kilobytes */
    t_create = res.t_create;
    t_eval = res.t_eval;
    st = res.st;
    used = res.used;

    /* Sample targets: evenly strided through the (randomly generated) set. */
    for (s = 0; s < ns; s++) idx[s] = (s * n) / ns + (n / ns) / 2;
    t0 = omp_get_wtime();
    direct_sums(n, xyz, q, ns, idx, ref);
    t_direct = (omp_get_wtime() - t0) * (double)n / (double)ns;
    for (s = 0; s < ns; s++) {
        const double *o = out + 4 * idx[s], *e = ref + 4 * s;
        num_p += (o[0] - e[0]) * (o[0] - e[0]);
        den_p += e[0] * e[0];
        for (i = 1; i < 4; i++) {
            num_g += (o[i] - e[i]) * (o[i] - e[i]);
            den_g += e[i] * e[i];
        }
    }
    err_p = sqrt(num_p / den_p);
    err_g = sqrt(num_g / den_g);
    if (dump) write_dump(dump, n, xyz, q, ns, idx, ref);

    fmt_n(nbuf, sizeof nbuf, n);
    snprintf(pbuf, sizeof pbuf, "%d", used.order);
    snprintf(lbuf, sizeof lbuf, "%d", used.leaf_size);
    snprintf(vbuf, sizeof vbuf, "%d", st.levels);
    {
        const double v[13] = {t_create, t_eval, t_create + t_eval, st.t_tree, st.t_operators,
                              st.t_p2m, st.t_m2m, st.t_m2l, st.t_l2l, st.t_p2l, st.t_l2p,
                              st.t_m2p, st.t_p2p};
        for (a = 0; a < 13; a++) snprintf(c[a], sizeof c[a], "%.3f", v[a]);
    }
    {
        char pk[16], hb[16], ep[16], eg[16], dt[16];
        snprintf(pk, sizeof pk, "%.0f", peak_mib);
        snprintf(hb, sizeof hb, "%.0f", st.bytes / 1048576.0);
        snprintf(ep, sizeof ep, "%.2e", err_p);
        snprintf(eg, sizeof eg, "%.2e", err_g);
        snprintf(dt, sizeof dt, t_direct < 1000 ? "%.2f" : "%.3g", t_direct);
        char lab[40];
        snprintf(lab, sizeof lab, "%s%s", DIST_NAME(dist), single ? "/f32" : "");
        if (nrhs > 1) snprintf(lab + strlen(lab), sizeof lab - strlen(lab), "/x%d", nrhs);
        printf(ROW_FMT, lab, nbuf, pbuf, lbuf, vbuf, c[0], c[1], c[2], c[3], c[4],
               c[5], c[6], c[7], c[8], c[9], c[10], c[11], c[12], pk, hb, ep, eg, dt);
    }
    fflush(stdout);

    if (result) {
        FILE *f = fopen(result, "w");
        if (!f) {
            perror(result);
            return 1;
        }
        fprintf(f,
                "dist=%s n=%lld p=%d leaf=%d levels=%d boxes=%lld leaves=%lld create=%.6f "
                "evaluate=%.6f total=%.6f tree=%.6f operators=%.6f p2m=%.6f m2m=%.6f m2l=%.6f "
                "l2l=%.6f p2l=%.6f l2p=%.6f m2p=%.6f p2p=%.6f peak_mib=%.1f handle_mib=%.1f "
                "err_pot=%.6e err_grad=%.6e direct_est=%.6f sample=%lld threads=%d precision=%s "
                "nrhs=%d\n",
                DIST_NAME(dist), (long long)n, used.order, used.leaf_size, st.levels,
                (long long)st.boxes, (long long)st.leaves, t_create, t_eval, t_create + t_eval,
                st.t_tree, st.t_operators, st.t_p2m, st.t_m2m, st.t_m2l, st.t_l2l, st.t_p2l,
                st.t_l2p, st.t_m2p, st.t_p2p, peak_mib, st.bytes / 1048576.0, err_p, err_g,
                t_direct, (long long)ns, omp_get_max_threads(), single ? "float" : "double",
                nrhs);
        fclose(f);
    }
    free(xyz);
    free(q);
    free(out);
    free(idx);
    free(ref);
    return 0;
}
