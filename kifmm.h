/* kifmm.h - v0.2.0 - kernel-independent fast multipole method in 3-D, header-only C
 *
 * CONTENTS (each section starts with a line "// >>name", so `grep -n '>>' kifmm.h`
 * prints the map)
 *   1. Quick start
 *   2. Template parameters, compile-time options, linkage modes
 *   3. Shared part, once per translation unit:
 *        >>config    linkage, OpenMP, portability macros
 *        >>results   result codes and messages, from one list
 *        >>options   kifmm_opts, kifmm_stats, defaults
 *        >>memory    the allocator, tallies of the bytes a handle holds
 *        >>files     hashes and whole-file writes for the operator cache
 *        >>linalg    GEMM, the pseudo-inverse, the column-GEMM micro-kernels
 *        >>tree      Morton keys, sort, then bounds / sort / refine / balance /
 *                    layout
 *        >>lists     U, V, W, X lists; what is derived from them
 *        >>surfaces  surface points, the cube's symmetries and the pseudo-inverse by
 *                    them, radii, transfer vectors
 *        >>fft       the FFT M2L's plan, kernel spectra and blocks
 *        >>prec      transforms, products and the column-GEMM driver, for
 *                    double and float (this file includes itself once for each)
 *        >>mpi (shared)  with KIFMM_MPI: agreement, the Morton partition,
 *                    routes, regions, messages to peers
 *   4. Kernel template, once per include, in the instance's precision:
 *        >>params    the instance's name, precision, kernel traits and roles
 *        >>api       the public functions' declarations
 *        >>handle    the plan (options, surfaces, operators) and the handle
 *                    (its plan, the points and tree, the workspace)
 *        >>kernels   the direct-interaction loops of the four kernel roles
 *        >>operators one builder per operator, called in order by ops_build
 *        >>cache     operator sets kept in files (opts.operator_cache): key,
 *                    read, write
 *        >>anchors   the downward densities' far points: their fit, their places
 *        >>workspace expansions and per-thread buffers
 *        >>upward    P2M, M2M, the upward solve
 *        >>downward  L2L, P2L, M2L (FFT or dense), the downward solve
 *        >>leaves    L2P, M2P, P2P
 *        >>create    create's steps (plan, points, workspace), create,
 *                    update_points, the shared plan and tree, evaluate,
 *                    destroy, stats, options
 *        >>mpi       with KIFMM_MPI: create_mpi and the collective calls on
 *                    its handles (docs/api.md, "MPI")
 *   5. >>epilogue: #undef of the template parameters; license
 *
 * 1. QUICK START
 *
 *   #include "kifmm.h"                      // Laplace 1/(4 pi r), double
 *   kifmm_opts opts = {0};                  // zero = default, or pass NULL
 *   opts.order = 6;
 *   kifmm_laplace *fmm = NULL;
 *   int rc = kifmm_laplace_create(&fmm, &opts, ns, src_xyz, nt, trg_xyz);
 *   if (rc < 0) fprintf(stderr, "kifmm: %s\n", kifmm_strerror(rc));
 *   rc = kifmm_laplace_evaluate(fmm, charges, pot);   // as often as needed
 *   rc = kifmm_laplace_evaluate_many(fmm, 4, q4, pot4); // 4 density vectors at once
 *   rc = kifmm_laplace_update_points(fmm, ns, moved_xyz, nt, moved_trg); // a time step:
 *                                           // a new tree, the operators kept
 *   kifmm_laplace_grad *g = NULL;           // another kernel (its own include) on
 *   rc = kifmm_laplace_grad_create_on_tree(&g, &opts, kifmm_laplace_tree(fmm)); // the same tree
 *   kifmm_laplace_destroy(fmm);
 *
 *   cc -O2 -march=native -fopenmp app.c -llapacke -lopenblas -lm
 *
 * 2. TEMPLATE PARAMETERS (set before an include; the header #undefs them)
 *
 *   KIFMM_KERNEL     kernel name from kifmm_kernels.h or one of your own
 *                    (docs/kernels.md); default laplace
 *   KIFMM_REAL       double (default) or float: coordinates, densities,
 *                    outputs and the arithmetic of the passes (operators are
 *                    built in double and rounded)
 *   KIFMM_NAME       prefix of the generated type and functions; default
 *                    kifmm_<KIFMM_KERNEL>, or kifmm_<KIFMM_KERNEL>f for float
 *   KIFMM_M2L_DENSE  dense M2L matrices instead of the FFT (for comparison)
 *
 *   e.g.  #define KIFMM_KERNEL stokes
 *         #define KIFMM_REAL float
 *         #include "kifmm.h"                 // kifmm_stokesf_create(..., const float *, ...)
 *
 *   COMPILE-TIME OPTIONS (before the first include in a translation unit;
 *   defaults and measurements in docs/api.md and docs/algorithm.md)
 *
 *   KIFMM_MALLOC(size), KIFMM_FREE(ptr)  allocator pair; define both or none
 *   KIFMM_SVD_CUTOFF            relative cutoff of the pseudo-inverses (1e-14)
 *   KIFMM_CHECK_ORDER_DIFF      check surfaces of order p + this at every order
 *                               (undefined: 0 up to KIFMM_SQUARE_MAX_ORDER for
 *                               kernels with the FFT M2L, 7 in float; else 1)
 *   KIFMM_SQUARE_MAX_ORDER      highest order with square systems (10; float
 *                               instances 7 at most)
 *   KIFMM_FFT_SINGLE_MAX_ORDER  double instances of scale-invariant kernels keep
 *                               the FFT spectra in float up to this order (4)
 *   KIFMM_FFT_SPEC_MB           MiB for the FFT spectra of a slab (64)
 *   KIFMM_MAX_THREADS           largest opts.nthreads accepted (1024)
 *   KIFMM_FREE_FRAME            0: the free-space root is always the tight
 *                               cube around the points (1: a wider one where
 *                               that keeps crowds off the boxes' faces)
 *   KIFMM_MONO_FIX              0: the upward densities keep their fitted
 *                               sums (1: set to their sources')
 *   KIFMM_NO_ANCHORS            downward densities without their far points
 *                               (for comparison: derivatives in deep trees
 *                               lose accuracy; docs/algorithm.md, "Anchors")
 *   KIFMM_RAISE_SLACK           an oscillating kernel's level takes a higher
 *                               order where its error would pass this many
 *                               times the order's on narrow boxes (3; 0: every
 *                               level at opts.order, refused past its limit)
 *
 *   LINKAGE MODES (per include, as in STC)
 *
 *   default            every function static: header-only use, any number of
 *                      instances and translation units
 *   KIFMM_DECLARE      the include emits only the instance's type and the
 *                      declarations of its public functions (needs neither
 *                      BLAS nor LAPACK headers)
 *   KIFMM_IMPLEMENT    the include emits the public functions with external
 *                      linkage (C linkage in C++), for a library that others
 *                      link; its internals stay static
 *
 *   THE PREPROCESSOR, TO DEBUG
 *
 *   cc -E -P -I. app.c | clang-format > app.i   shows every instance expanded;
 *   cc -dM -E -I. app.c | grep KIFMM            lists the macros in effect.
 *   Functions are ordinary functions with real line numbers; only a few
 *   SIMD micro-kernels are macros (each under 40 lines).
 *
 *   PERIODIC BOUNDARIES: opts.period (docs/api.md): one, two or three periodic
 *   directions for decaying kernels (Yukawa); one or two for scale-invariant
 *   ones with densities that sum to zero, three with Ewald's conventions
 *   (tin-foil, zero mean, a neutralising background; Hasimoto for Stokes)
 *   for kernels with the _ewald and _background hooks (every shipped one).
 *
 *   MPI: #define KIFMM_MPI before an include (and <mpi.h> on the path: mpicc)
 *   adds <prefix>_create_mpi(&h, comm, opts, ns_local, src, nt_local, trg):
 *   one FMM over every rank's points, evaluate, evaluate_many,
 *   update_points and destroy then collective (docs/api.md, "MPI").
 *
 *   DOES NOT DO: complex kernels (Helmholtz); MPI with periodic boundaries.
 *
 *   Documentation: docs/api.md (functions, options, errors, limits),
 *   docs/algorithm.md (how the method maps to this file), docs/kernels.md
 *   (writing a kernel, the kernel roles).
 */

#ifndef KIFMM__PREC_PASS /* the normal pass; see >>prec for the other one */

/* g++ 12 false positives inside its AVX-512 intrinsics (see kifmm_kernels.h):
 * silenced for this file's code, restored at its end. */
#if defined(__GNUC__) && !defined(__clang__) && defined(__cplusplus)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#endif

/* ======================================================================== */
/* 3. Shared part: types (every mode)                                       */
/* ======================================================================== */
#ifndef KIFMM_H_TYPES
#define KIFMM_H_TYPES

// >>config

#define KIFMM_VERSION_MAJOR 0
#define KIFMM_VERSION_MINOR 2
#define KIFMM_VERSION_PATCH 0

/* System headers with C++ linkage even inside a C++ host's extern "C". */
#ifdef __cplusplus
extern "C++" {
#endif
#include <stddef.h>
#include <stdint.h>
#ifdef __cplusplus
}
#endif

#define KIFMM_MAX_ORDER 12   /* largest expansion order accepted */
#define KIFMM_MAX_DEPTH 20   /* deepest tree level (Morton keys hold 3 x 20 bits) */
#define KIFMM_DEFAULT_ORDER 6
#define KIFMM_DEFAULT_DEPTH 16

/* Most threads a handle accepts (opts.nthreads): each thread has buffers of
 * its own (a few MiB at high orders), and starting thousands of threads
 * takes seconds. Define it before the first include to change it. */
#ifndef KIFMM_MAX_THREADS
#define KIFMM_MAX_THREADS 1024
#endif

/* Most points of one set: beyond this, 3 coordinates and 8 vectors of up to
 * 16 components of 8 bytes would not fit in any address space (far beyond
 * any memory; the check exists so that counts such as INT64_MAX give
 * KIFMM_ERR_COUNT instead of an overflow). */
#define KIFMM_MAX_POINTS ((int64_t)(PTRDIFF_MAX / 1024))

/* The range of coordinates and periods: squared distances stay within the
 * precision's range when every coordinate and period is at most
 * KIFMM_COORD_MAX in magnitude, and periods and the extent of a set of
 * distinct points are at least KIFMM_EXTENT_MIN (KIFMM_ERR_RANGE
 * otherwise). A kernel whose powers of 1 / r fall below the normal numbers
 * across the points' box (r^-5 beyond about 1e61 in double) gets
 * KIFMM_ERR_RANGE too (__check_far). Points closer together than about the
 * square root of the smallest normal number (1e-154 in double, 1e-19 in
 * float) count as coincident. */
#define KIFMM_COORD_MAX 1e150
#define KIFMM_EXTENT_MIN 1e-150
#define KIFMM_COORD_MAX_FLOAT 1e18
#define KIFMM_EXTENT_MIN_FLOAT 1e-15

/* <prefix>_estimate_bytes's ntargets when the targets will be the sources. */
#define KIFMM_SAME_POINTS ((int64_t)-1)

/* Internal functions are static, and marked unused so that a translation
 * unit may use only some of them. */
#if defined(__GNUC__) || defined(__clang__)
#define KIFMM__FN static __attribute__((unused))
#else
#define KIFMM__FN static
#endif

#define KIFMM__CAT_(a, b) a##b
#define KIFMM__CAT(a, b) KIFMM__CAT_(a, b)
#define KIFMM__STR_(a) #a
#define KIFMM__STR(a) KIFMM__STR_(a)
#define KIFMM__CAT3(a, b, c) KIFMM__CAT(KIFMM__CAT(a, b), c)

/* KIFMM_REAL must name one of these two types. */
#define KIFMM__REAL_IS_double 1
#define KIFMM__REAL_IS_float 2

// >>results

/* Every result code and its message, from one list: X(name, value, message),
 * in two parts: the arguments, options and internal limits (0 to -12),
 * then boundaries, ranges, data and trees (-13 on). */
#define KIFMM__RESULTS(X) KIFMM__RESULTS_ARGS(X) KIFMM__RESULTS_DATA(X)
#define KIFMM__RESULTS_ARGS(X)                                                                \
    X(KIFMM_SUCCESS, 0, "success")                                                            \
    X(KIFMM_ERR_NULL, -1, "a required pointer argument is NULL")                              \
    X(KIFMM_ERR_COUNT, -2,                                                                    \
      "a count is negative or too large for any array (see KIFMM_MAX_POINTS)")                \
    X(KIFMM_ERR_NONFINITE, -3, "a coordinate is NaN or infinite")                            \
    X(KIFMM_ERR_ORDER, -4, "expansion order out of range (2 to KIFMM_MAX_ORDER)")             \
    X(KIFMM_ERR_LEAF_SIZE, -5, "leaf size is negative")                                       \
    X(KIFMM_ERR_DEPTH, -6, "maximum depth out of range (0 to KIFMM_MAX_DEPTH)")               \
    X(KIFMM_ERR_NTHREADS, -7, "number of threads out of range (0 to KIFMM_MAX_THREADS)")      \
    X(KIFMM_ERR_PARAM, -8, "a kernel parameter is out of range")                              \
    X(KIFMM_ERR_NOMEM, -9, "memory allocation failed")                                        \
    X(KIFMM_ERR_LAPACK, -10, "a singular value decomposition did not converge")               \
    X(KIFMM_ERR_INTERNAL, -11, "an internal limit was exceeded (please report)")              \
    X(KIFMM_ERR_KERNEL, -12,                                                                  \
      "the kernel gave a NaN or infinite value on the expansion surfaces (check its "         \
      "parameters)")
#define KIFMM__RESULTS_DATA(X)                                                                \
    X(KIFMM_ERR_PERIOD, -13,                                                                  \
      "opts.period: a period is negative or not finite, the periodic directions have "        \
      "different periods, or the points span 1024 periods or more in a free direction")      \
    X(KIFMM_ERR_PERIODIC, -14,                                                                \
      "these periodic boundaries are not supported for this kernel: periodic directions "     \
      "need a scale-invariant or decaying kernel, and three of them for a scale-invariant "  \
      "one its _ewald and _background hooks (docs/api.md); direct sums are free space only")   \
    X(KIFMM_ERR_NEUTRAL, -15,                                                                 \
      "with these periodic directions and this kernel the densities must sum to zero "        \
      "(docs/api.md, \"Periodic boundaries\")")                                               \
    X(KIFMM_ERR_TOL, -16,                                                                     \
      "opts.tol is negative, not finite, set together with opts.order, below what the "       \
      "largest order reaches for the kernel (laplace: about 2.6e-11; docs/api.md, "           \
      "\"Tolerance\"; float instances 2e-5), or given for an oscillating kernel to a call "   \
      "that chooses the order before it sees every point (plan_create, estimate_bytes, "      \
      "create_mpi) without opts.domain")                                                      \
    X(KIFMM_ERR_VERBOSE, -17, "opts.verbose is neither 0 nor 1")                              \
    X(KIFMM_ERR_RANGE, -18,                                                                   \
      "a coordinate or period is beyond KIFMM_COORD_MAX (1e150; float 1e18), a period or "    \
      "the points' extent is below KIFMM_EXTENT_MIN (1e-150; float 1e-15), or the points are " \
      "so far apart that the kernel's powers of 1/r leave the number range (docs/api.md, "    \
      "\"Limits\")")                                                                          \
    X(KIFMM_ERR_DENSITY, -19, "a density is NaN or infinite")                                 \
    X(KIFMM_ERR_OVERLAP, -20, "direct: the output array overlaps the source or target points") \
    X(KIFMM_ERR_OVERFLOW, -21,                                                                \
      "an output is not finite: the densities are too large or points too close for the "     \
      "precision's range")                                                                    \
    X(KIFMM_ERR_DOMAIN, -22,                                                                  \
      "opts.domain: a point lies outside the box, or the box is not finite, its half-width "  \
      "not positive, or it is set together with opts.period")                                 \
    X(KIFMM_ERR_TREE, -23,                                                                    \
      "the tree does not fit this instance: built by one of the other precision, for "        \
      "another leaf size, depth, period or domain, or without the V lists of a dense M2L")   \
    X(KIFMM_ERR_MPI, -24,                                                                     \
      "MPI mode: MPI is not initialised or an MPI call failed, the ranks passed different "   \
      "counts of vectors, or this kernel has no MPI mode yet (docs/api.md, \"MPI\")")        \
    X(KIFMM_ERR_FREQUENCY, -25,                                                               \
      "the boxes that carry expansions are too many wavelengths wide for every order up to "  \
      "12 (for the order in MPI mode), or for any order that meets opts.tol (an oscillating " \
      "kernel: raise tol or use fewer wavelengths a box, docs/kernels.md, \"Helmholtz\")")

#define KIFMM__RESULT_ENUM(name, value, message) name = value,
#define KIFMM__RESULT_CASE(name, value, message)                                              \
    case value: return message;
enum { KIFMM__RESULTS(KIFMM__RESULT_ENUM) };

/* kifmm_strerror: a one-line message for a result code; never NULL. Static
 * in every mode: each translation unit has its own copy. */
KIFMM__FN const char *kifmm_strerror(int code)
{
    switch (code) {
        KIFMM__RESULTS(KIFMM__RESULT_CASE)
    default: return "unknown kifmm result code";
    }
}
#undef KIFMM__RESULT_ENUM
#undef KIFMM__RESULT_CASE

// >>options

/* Every field zero means its default, so {0} (or a NULL pointer) is valid. */
typedef struct kifmm_opts {
    int order;              /* expansion order p, 2..KIFMM_MAX_ORDER; 0 = 6 */
    int leaf_size;          /* max points per leaf; 0 = chosen per order */
    int max_depth;          /* deepest level, 1..KIFMM_MAX_DEPTH; 0 = 16 (periodic trees
                               wider than the cell: counted from the cell) */
    int nthreads;           /* OpenMP threads, 1..KIFMM_MAX_THREADS; 0 =
                               omp_get_max_threads(); always 1 without OpenMP */
    double kernel_param[4]; /* kernel parameters; 0 = the kernel's default */
    double period[3];       /* 0: free space in that direction (the default); L > 0:
                               periodic with period L, the unit cell [0, L) (points
                               outside it are wrapped in); every periodic direction
                               has the same L (docs/api.md, "Periodic boundaries") */
    double tol;             /* > 0: the order is chosen for a relative L2 error of at
                               most tol (order must then be 0; docs/api.md,
                               "Tolerance"); 0: order decides */
    int verbose;            /* 1: create and evaluate print one line per stage, with
                               its time, and the memory held, on stderr; 0: quiet */
    double domain[4];       /* free space: a fixed root box, centre x, y, z and
                               half-width h > 0, holding every point (|x - c| <= h
                               per axis, else KIFMM_ERR_DOMAIN), so that points
                               moved by update_points inside it keep every
                               operator; all 0: the box from the points (the
                               default). Not with opts.period (docs/api.md) */
    const char *operator_cache; /* a directory (existing) where create keeps each
                               operator set it builds, one file each, and reads
                               back those built before by any process (docs/api.md,
                               "Operator cache"); a file that cannot be read or
                               written is built or left, never an error; NULL or
                               "": none (the default). Copied: the string may go
                               once create returns */
} kifmm_opts;

/* A tree over one set of points (sorted points, boxes, interaction
 * lists) that handles of different kernels of one precision can share:
 * <prefix>_tree, <prefix>_create_on_tree (docs/api.md, "One tree for
 * several kernels"). Opaque; it lives while a handle uses it. */
typedef struct kifmm_tree kifmm_tree;

/* What a handle is made of and where the last evaluation spent its time. */
typedef struct kifmm_stats {
    int levels;                 /* tree levels */
    int64_t boxes, leaves;      /* boxes in the tree, leaves holding targets */
    double t_tree, t_operators; /* create: tree and lists, operators (seconds) */
    double t_p2m, t_m2m, t_m2l, t_l2l, t_p2l, t_l2p, t_m2p, t_p2p; /* last evaluate */
    double t_evaluate;          /* last evaluate, total */
    double bytes;               /* memory held by the handle */
    int64_t max_leaf;           /* most sources or targets in one leaf */
    int64_t crowded;            /* points in leaves holding more than leaf_size of
                                   them: leaves at max_depth, or of points that
                                   share one position at depth KIFMM_MAX_DEPTH;
                                   their near field is a direct sum, O(n^2) in
                                   such a leaf's n (docs/api.md, "Limits") */
    int threads;                /* threads the handle's loops run on */
    int simd;                   /* vector width the build's kernels use, in bits:
                                   512 (AVX-512), 256 (AVX2 + FMA), 0 (none:
                                   compiled without -march or -mavx2 -mfma) */
    char build[256];            /* the code paths of this instance, in words */
    double t_plan;              /* create: options, surfaces, operators (the plan) */
    double t_points;            /* create or the last update_points: the tree, the
                                   lists and what else the points decide */
    double t_workspace;         /* create or the last update_points: the workspace */
    double t_update;            /* the last update_points, total (0: none yet) */
    double plan_bytes;          /* memory held by the handle's plan (surfaces and
                                   operators), when the handle was made or moved;
                                   in bytes unless the plan came from plan_create
                                   and is shared */
    double tree_bytes;          /* memory held by the handle's tree (sorted points,
                                   boxes, lists); bytes leaves it out when the tree
                                   came from another handle (create_on_tree) */
    /* MPI mode (<prefix>_create_mpi; all 0 otherwise), of this rank: */
    int mpi_ranks;              /* ranks in the communicator */
    int64_t mpi_sources;        /* sources and targets it owns (the partition's) */
    int64_t mpi_targets;
    int64_t mpi_ghost_points;   /* other ranks' sources near its region that it holds */
    int64_t mpi_ghost_boxes;    /* boxes of other ranks whose equivalent densities it
                                   receives at each evaluate */
    double mpi_bytes_sent;      /* last evaluate: bytes it sent to and received from
                                   other ranks (the densities to their owners, the
                                   ghosts' and boxes' densities, the coarse levels'
                                   sum, the outputs back) */
    double mpi_bytes_recv;
    double mpi_ghost_bytes;     /* of the bytes received, the ghosts' and boxes' */
    double t_mpi_wait;          /* last evaluate: seconds in MPI calls */
    double t_mpi_work;          /* last evaluate: CPU seconds (all threads) outside
                                   them, the rank's work whether or not it shared its
                                   cores (the measure of balance) */
    int cache_read;             /* operator sets the handle's plan has read from
                                   opts.operator_cache, and written there (in MPI */
    int cache_written;          /* mode: this rank's); 0 without a cache */
} kifmm_stats;

#endif /* KIFMM_H_TYPES */

/* ======================================================================== */
/* 3. Shared part: implementation (once per translation unit, not in        */
/*    KIFMM_DECLARE mode)                                                   */
/* ======================================================================== */
#if !defined(KIFMM_DECLARE) && !defined(KIFMM_H_IMPL)
#define KIFMM_H_IMPL
#define KIFMM__PREC_NOW 1 /* instantiate >>prec below, once */

// >>config (implementation)

/* System headers with C++ linkage even inside a C++ host's extern "C". */
#ifdef __cplusplus
extern "C++" {
#endif
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <cblas.h>
#include <lapacke.h>
#ifdef _OPENMP
#include <omp.h>
#endif
#if defined(__AVX2__) && defined(__FMA__)
#include <immintrin.h>
#endif
#ifdef __cplusplus
}
#endif

#include "kifmm_kernels.h"

#if defined(KIFMM_MALLOC) && !defined(KIFMM_FREE)
#error "kifmm.h: KIFMM_MALLOC is defined but KIFMM_FREE is not; define both or neither"
#endif
#if defined(KIFMM_FREE) && !defined(KIFMM_MALLOC)
#error "kifmm.h: KIFMM_FREE is defined but KIFMM_MALLOC is not; define both or neither"
#endif
#ifndef KIFMM_MALLOC
#define KIFMM_MALLOC(size) malloc(size)
#define KIFMM_FREE(ptr) free(ptr)
#endif

#ifndef KIFMM_SVD_CUTOFF
#define KIFMM_SVD_CUTOFF 1e-14
#endif

/* KIFMM_CHECK_ORDER_DIFF: check surfaces use order p + this. Left undefined,
 * it is 0 up to order KIFMM_SQUARE_MAX_ORDER (float instances: 7 at most)
 * for kernels with the FFT M2L, and 1 above and for the others (see
 * kifmm__check_diff). */
#ifndef KIFMM_SQUARE_MAX_ORDER
#define KIFMM_SQUARE_MAX_ORDER 10
#endif

/* Double instances of scale-invariant kernels keep the FFT M2L's spectra
 * and products in float up to this order (float instances always do): half
 * the spectra's memory and products about 1.4 times faster. Float spectra
 * carry an error of about 1e-7 relative to each box's own field, not to the
 * total, and where the fields of many boxes cancel (charges that sum to
 * zero, seen from afar) that error can pass the truncation error: 20,000
 * neutral charges with targets 30 cloud sizes away give 3.9e-5 with float
 * spectra at p = 6 against 1.6e-6 in double, and at p = 5 anything from
 * 8.8e-7 to 2.2e-5 with float spectra (the rounding of the operators, which
 * OpenBLAS's kernel for the CPU sets, decides) against 5.2e-6 in double; at
 * p = 4 the truncation error dominates (1.8e-4 against 1.7e-4; at 300
 * sizes away 7.8e-4 both). Hence 4; 0 for double spectra at every order, 5
 * or more for speed where nothing cancels. */
#ifndef KIFMM_FFT_SINGLE_MAX_ORDER
#define KIFMM_FFT_SINGLE_MAX_ORDER 4
#endif

/* Memory for the spectra of the FFT M2L, in MiB: a level whose source
 * spectra do not fit is done in slabs of target parents, each with the
 * spectra of its own neighbours (some computed twice). A handle whose
 * expansion array (one of the two) takes more uses that much, up to 4 times
 * this. */
#ifndef KIFMM_FFT_SPEC_MB
#define KIFMM_FFT_SPEC_MB 64
#endif

/* OpenMP regions follow one rule, so that a reviewer can check it at a
 * glance: every variable a region writes is declared inside the region (the
 * index of a parallel loop in its for statement) or named in a reduction
 * clause; everything declared outside is only read. Shared arrays are
 * written at indices that belong to one iteration or one thread (each region
 * says which). */
#define KIFMM__PRAGMA(x) _Pragma(#x)
#ifdef _OPENMP
#define KIFMM__OMP(x) KIFMM__PRAGMA(omp x)
#else
#define KIFMM__OMP(x)
#endif

/* A lock for a plan that several handles share (>>handle): OpenMP's where
 * the build has OpenMP; else a spin lock on the compiler's atomic builtins
 * (gcc, clang), for hosts that run their own threads; else none (a plan
 * shared by threads then needs the host to order creates and destroys). */
#ifdef _OPENMP
typedef omp_lock_t kifmm__lock;
KIFMM__FN void kifmm__lock_init(kifmm__lock *l) { omp_init_lock(l); }
KIFMM__FN void kifmm__lock_fini(kifmm__lock *l) { omp_destroy_lock(l); }
KIFMM__FN void kifmm__lock_take(kifmm__lock *l) { omp_set_lock(l); }
KIFMM__FN void kifmm__lock_give(kifmm__lock *l) { omp_unset_lock(l); }
#elif defined(__GNUC__)
typedef struct { char v; } kifmm__lock;
KIFMM__FN void kifmm__lock_init(kifmm__lock *l) { __atomic_clear(&l->v, __ATOMIC_RELEASE); }
KIFMM__FN void kifmm__lock_fini(kifmm__lock *l) { (void)l; }
#if defined(__x86_64__) || defined(__i386__)
#define KIFMM__PAUSE() __builtin_ia32_pause()
#elif defined(__aarch64__)
#define KIFMM__PAUSE() __asm__ __volatile__("yield")
#else
#define KIFMM__PAUSE() ((void)0)
#endif
/* test and test-and-set: a waiting thread reads the flag (its cache line
 * stays shared) with the CPU's spin hint between reads, and tries to take
 * it only when it reads free */
KIFMM__FN void kifmm__lock_take(kifmm__lock *l)
{
    while (__atomic_test_and_set(&l->v, __ATOMIC_ACQUIRE))
        while (__atomic_load_n(&l->v, __ATOMIC_RELAXED)) KIFMM__PAUSE();
}
KIFMM__FN void kifmm__lock_give(kifmm__lock *l) { __atomic_clear(&l->v, __ATOMIC_RELEASE); }
#else
typedef struct { char v; } kifmm__lock;
KIFMM__FN void kifmm__lock_init(kifmm__lock *l) { (void)l; }
KIFMM__FN void kifmm__lock_fini(kifmm__lock *l) { (void)l; }
KIFMM__FN void kifmm__lock_take(kifmm__lock *l) { (void)l; }
KIFMM__FN void kifmm__lock_give(kifmm__lock *l) { (void)l; }
#endif

/* restrict in C99, its extension in C++ */
#if defined(__cplusplus)
#define KIFMM__RESTRICT __restrict
#else
#define KIFMM__RESTRICT restrict
#endif

/* Preprocessor tests on macros that may be undefined, without evaluating an
 * undefined name in #if (-Wundef clean): KIFMM__IS_ONE(x) is the token 1 if
 * x expands to 1, else 0; KIFMM__IS_PAREN(x) is 1 if x expands to something
 * in parentheses, else 0; KIFMM__IF(c)(a, b) is a if c is 1, else b. */
#define KIFMM__SECOND_(a, b, ...) b
#define KIFMM__SECOND(...) KIFMM__SECOND_(__VA_ARGS__, 0, 0)
#define KIFMM__PROBE ~, 1
#define KIFMM__ONE_1 KIFMM__PROBE
#define KIFMM__IS_ONE(x) KIFMM__SECOND(KIFMM__CAT(KIFMM__ONE_, x))
#define KIFMM__PAREN_PROBE(...) KIFMM__PROBE
#define KIFMM__IS_PAREN(x) KIFMM__SECOND(KIFMM__PAREN_PROBE x)
#define KIFMM__IF(c) KIFMM__CAT(KIFMM__IF_, c)
#define KIFMM__IF_1(a, b) a
#define KIFMM__IF_0(a, b) b

/* C99 static assert: a typedef'd array whose name is the message. */
#define KIFMM__STATIC_ASSERT(cond, msg) typedef char KIFMM__CAT(kifmm__assert_, msg)[(cond) ? 1 : -1]

/* The widest instruction set the build's own kernels use. */
#if defined(__AVX512F__)
#define KIFMM__SIMD_BITS 512
#define KIFMM__SIMD_NAME "AVX-512"
#elif defined(__AVX2__) && defined(__FMA__)
#define KIFMM__SIMD_BITS 256
#define KIFMM__SIMD_NAME "AVX2"
#else
#define KIFMM__SIMD_BITS 0
#define KIFMM__SIMD_NAME "portable C"
#endif

/* Keeps a loaded vector in a register: each block vector of the FFT
 * products is used by two FMAs, and compilers otherwise fold the load into
 * both as a memory operand, which doubles the loads of a loop that is bound
 * by them (float products 37 -> 45-55 Gflop/s on one core). KIFMM__PREFETCH:
 * a read prefetch hint. */
#if defined(__GNUC__) || defined(__clang__)
#define KIFMM__IN_REG(v) __asm__("" : "+x"(v))
#define KIFMM__PREFETCH(a) __builtin_prefetch((a), 0, 3)
#else
#define KIFMM__IN_REG(v) ((void)0)
#define KIFMM__PREFETCH(a) ((void)0)
#endif

/* Density vectors processed together by evaluate_many; more are done in
 * groups of this many, so the workspace stays bounded. */
#define KIFMM__RHS_MAX 8

/* The calling thread's number in the innermost parallel region (0 outside
 * one and without OpenMP): the index of its part of per-thread buffers. */
KIFMM__FN int kifmm__thread_num(void)
{
#ifdef _OPENMP
    return omp_get_thread_num();
#else
    return 0;
#endif
}

/* The calling thread's contiguous share [lo, hi) of n items; returns its
 * thread number (0 outside a parallel region or without OpenMP). */
KIFMM__FN int kifmm__thread_chunk(int64_t n, int64_t *lo, int64_t *hi)
{
    int me = 0, np = 1;
#ifdef _OPENMP
    me = omp_get_thread_num();
    np = omp_get_num_threads();
#endif
    *lo = n * me / np;
    *hi = n * (me + 1) / np;
    return me;
}

/* Wall-clock seconds (CPU seconds in builds without OpenMP, which run on one
 * thread; C99 has no portable wall clock). */
KIFMM__FN double kifmm__now(void)
{
#ifdef _OPENMP
    return omp_get_wtime();
#else
    return (double)clock() / (double)CLOCKS_PER_SEC;
#endif
}

// >>options (implementation)

KIFMM__FN int kifmm__default_leaf(int order, int kind)
{
    /* Larger expansions make the far field dearer per box, so leaves grow
     * with the number of surface points; from p = 7 on the M2L products run
     * in double and leaves of a few hundred points pay (measured: 1M uniform
     * points, p = 8: 5.8 s at 384 against 10.3 s at 192; 1M points on a
     * sphere: p = 4 1.4 s at 128 against 2.3 s at 64, p = 5 2.0 s at 128
     * against 2.8 s at 96); see docs/algorithm.md. */
    static const int leaf[KIFMM_MAX_ORDER + 1] = {0, 0, 32, 48, 128, 128, 128, 384, 384,
                                                  448, 512, 576, 640};
    /* Without AVX-512 the near field costs relatively more (4 lanes, a
     * square root and a division per pair), and from order 9 on smaller
     * leaves pay for kernels of one surface component in double (kind 2;
     * measured with laplace_grad, AVX2 build, 1M
     * points, 2 threads, best of two, create + evaluate summed over the
     * cube, a sphere, Plummer's sphere and clusters: p = 9 448 -> 384
     * 16.49 -> 15.71 s, p = 10 512 -> 384 21.32 -> 19.86 s with two cases
     * of 1e5 points (the sphere alone 3.60 -> 3.75 s), p = 11 576 -> 448
     * 25.61 -> 24.50 s, p = 12 640 -> 448 31.59 -> 29.93 s; at p = 8 leaves
     * of 256 and 320 won on Plummer's sphere and clusters and lost as much
     * on the sphere). */
    static const int leaf_narrow[KIFMM_MAX_ORDER + 1] = {0, 0, 32, 48, 128, 128, 128, 384, 384,
                                                         384, 384, 448, 448};
#if defined(__AVX512F__)
    const int *lf = leaf;
    (void)leaf_narrow;
#else
    const int *lf = kind == 2 ? leaf_narrow : leaf;
#endif
    /* kind 1: several surface density components and a near-field hook. The
     * M2L products grow as the square of the components, the hook's cost per
     * pair about as their number, and leaves 2x (p <= 4) or 4x larger pay
     * (Stokes, 1M points, p = 6: cube 12.4 s at 128 -> 4.1 s at 512, sphere
     * 6.7 -> 3.5 s, clustered 10.1 -> 6.0 s; p = 4: 2.4 / 2.4 / 2.8 s at 128,
     * 3.0 / 1.9 / 2.8 s at 256; docs/algorithm.md). */
    return kind == 1 ? lf[order] * (order <= 4 ? 2 : 4) : lf[order];
}

/* opts.tol: the smallest order whose error, 1.5 times the largest measured,
 * is at most tol; 0 if none is. err: the kernel's own measurements, those
 * of its worst output (KIFMM_HAS_TOL, kifmm_kernels.h), or NULL for
 * laplace's: its potential, relative L2 error at 300 targets against direct
 * sums, on uniform, sphere-surface and clustered points, 20,000 of them
 * (two seeds) and 200,000 (one; bench/bench_tol.c); consecutive orders
 * differ by 5x to 12x, so at tol = 1e-3 ... 1e-10 the largest error reached
 * lies between tol / 30 and tol (docs/api.md, "Tolerance"). */
KIFMM__FN int kifmm__order_for_tol(double tol, const double *err)
{
    static const double lap[KIFMM_MAX_ORDER + 1] = {0.0, 0.0, 4.5e-2, 2.4e-3, 2.1e-4,
                                                    1.9e-5, 2.2e-6, 2.4e-7, 4.2e-8, 6.4e-9,
                                                    7.9e-10, 1.4e-10, 1.7e-11};
    int p;
    if (!err) err = lap;
    for (p = 2; p <= KIFMM_MAX_ORDER; p++)
        if (err[p] > 0.0 && 1.5 * err[p] <= tol) return p; /* 0: not measured, not taken */
    return 0;
}

/* opts.tol for an oscillating kernel (KIFMM_HAS_WAVES and KIFMM_HAS_TOL):
 * err, order p's row of the kernel's table, its largest errors measured
 * with the widest expansions KIFMM_TOL_WAVES_WIDTHS[j] wavelengths wide (j <
 * KIFMM_TOL_WAVES_NW; those below the order's limit `most`) and at the
 * limit (j = KIFMM_TOL_WAVES_NW). The error taken at x wavelengths: the
 * largest at every width up to the first at or beyond x (the limit's where
 * no fixed width below it is), as the errors grow with the width (between
 * the resonances' bumps: docs/kernels.md); HUGE_VAL past the limit or
 * where a width it needs was not measured. */
KIFMM__FN double kifmm__waves_err(const double *err, double most, double x)
{
    static const double w[KIFMM_TOL_WAVES_NW] = KIFMM_TOL_WAVES_WIDTHS;
    double e = 0.0;
    int j;
    if (!(x >= 0.0 && x <= most)) return HUGE_VAL;
    for (j = 0; j < KIFMM_TOL_WAVES_NW && w[j] < most; j++) {
        if (!(err[j] > 0.0)) return HUGE_VAL;
        e = err[j] > e ? err[j] : e;
        if (w[j] >= x) return e;
    }
    if (!(err[KIFMM_TOL_WAVES_NW] > 0.0)) return HUGE_VAL;
    return err[KIFMM_TOL_WAVES_NW] > e ? err[KIFMM_TOL_WAVES_NW] : e;
}

/* The smallest order whose error at x wavelengths (kifmm__waves_err), 1.5
 * times the table's, is at most tol; 0 if none is. err: the kernel's table
 * (KIFMM_TOL_WAVES_NW + 1 a row), most: its limits per order. */
KIFMM__FN int kifmm__order_for_tol_waves(double tol, double x, const double *err, const double *most)
{
    int p;
    for (p = 2; p <= KIFMM_MAX_ORDER; p++)
        if (1.5 * kifmm__waves_err(err + p * (KIFMM_TOL_WAVES_NW + 1), most[p], x) <= tol) return p;
    return 0;
}

/* Resolve defaults and check ranges (err: opts.tol's table, see
 * kifmm__order_for_tol); *out gets the values actually used. */
KIFMM__FN int kifmm__resolve_opts(const kifmm_opts *in, int kind, const double *err,
                                  kifmm_opts *out)
{
    kifmm_opts o;
    double L = 0.0;
    int d;
    if (in) o = *in;
    else memset(&o, 0, sizeof o);
    if (o.tol != 0.0) {
        if (!(o.tol > 0.0 && o.tol <= DBL_MAX) || o.order != 0) return KIFMM_ERR_TOL;
        if (!(o.order = kifmm__order_for_tol(o.tol, err))) return KIFMM_ERR_TOL;
    }
    if (o.order == 0) o.order = KIFMM_DEFAULT_ORDER;
    if (o.order < 2 || o.order > KIFMM_MAX_ORDER) return KIFMM_ERR_ORDER;
    if (o.leaf_size < 0) return KIFMM_ERR_LEAF_SIZE;
    if (o.leaf_size == 0) o.leaf_size = kifmm__default_leaf(o.order, kind);
    if (o.max_depth < 0 || o.max_depth > KIFMM_MAX_DEPTH) return KIFMM_ERR_DEPTH;
    if (o.max_depth == 0) o.max_depth = KIFMM_DEFAULT_DEPTH;
    if (o.nthreads < 0 || o.nthreads > KIFMM_MAX_THREADS) return KIFMM_ERR_NTHREADS;
    if (o.verbose != 0 && o.verbose != 1) return KIFMM_ERR_VERBOSE;
    for (d = 0; d < 3; d++) {
        if (!(o.period[d] >= 0.0 && o.period[d] <= DBL_MAX)) return KIFMM_ERR_PERIOD;
        if (o.period[d] > 0.0 && L > 0.0 && o.period[d] != L) return KIFMM_ERR_PERIOD;
        if (o.period[d] > 0.0) L = o.period[d];
    }
    if (o.domain[0] != 0.0 || o.domain[1] != 0.0 || o.domain[2] != 0.0 || o.domain[3] != 0.0) {
        for (d = 0; d < 3; d++)
            if (!(fabs(o.domain[d]) <= DBL_MAX)) return KIFMM_ERR_DOMAIN;
        if (!(o.domain[3] > 0.0 && o.domain[3] <= DBL_MAX) || L > 0.0) return KIFMM_ERR_DOMAIN;
    }
#ifdef _OPENMP
    if (o.nthreads == 0) o.nthreads = omp_get_max_threads();
    if (o.nthreads > KIFMM_MAX_THREADS) o.nthreads = KIFMM_MAX_THREADS;
#else
    o.nthreads = 1; /* what really runs: a build without OpenMP has one thread */
#endif
    *out = o;
    return KIFMM_SUCCESS;
}

// >>memory

/* 64-byte aligned blocks through the user's allocator. Below the block sit
 * the raw pointer and the block's size in bytes (for the tallies below).
 * Returns NULL on overflow or failure. */
#define KIFMM__HEAD 16
KIFMM__STATIC_ASSERT(sizeof(void *) <= 8 && sizeof(size_t) <= 8, header_holds_two_words);

KIFMM__FN void *kifmm__alloc(size_t count, size_t size)
{
    size_t n;
    unsigned char *raw, *p;
    if (size && count > ((size_t)PTRDIFF_MAX - 128) / size) return NULL; /* no such object */
    n = count * size + 64 + KIFMM__HEAD;
    raw = (unsigned char *)KIFMM_MALLOC(n);
    if (!raw) return NULL;
    p = raw + KIFMM__HEAD;
    p += (64 - ((uintptr_t)p & 63)) & 63;
    memcpy(p - 16, &raw, sizeof raw);
    n = count * size;
    memcpy(p - 8, &n, sizeof n);
    return p;
}

KIFMM__FN void *kifmm__calloc(size_t count, size_t size)
{
    void *p = kifmm__alloc(count, size);
    if (p) memset(p, 0, count * size);
    return p;
}

KIFMM__FN void kifmm__free(void *p)
{
    void *raw;
    if (!p) return;
    memcpy(&raw, (unsigned char *)p - 16, sizeof raw);
    KIFMM_FREE(raw);
}

/* Bytes of a block from kifmm__alloc (0 for NULL). */
KIFMM__FN size_t kifmm__size(const void *p)
{
    size_t n = 0;
    if (p) memcpy(&n, (const unsigned char *)p - 8, sizeof n);
    return n;
}

/* A block that stays with a handle: its bytes are added to *held, the tally
 * that <prefix>_stats reports, so that memory is counted where it is
 * allocated. kifmm__drop frees such a block and takes its bytes off. */
KIFMM__FN void *kifmm__take(size_t *held, size_t count, size_t size)
{
    void *p = kifmm__alloc(count, size);
    if (p) *held += count * size;
    return p;
}

KIFMM__FN void *kifmm__takez(size_t *held, size_t count, size_t size)
{
    void *p = kifmm__take(held, count, size);
    if (p) memset(p, 0, count * size);
    return p;
}

KIFMM__FN void kifmm__drop(size_t *held, void *p)
{
    *held -= kifmm__size(p);
    kifmm__free(p);
}

/* Do the byte ranges [a, a + na) and [b, b + nb) overlap? */
KIFMM__FN int kifmm__overlap(const void *a, size_t na, const void *b, size_t nb)
{
    const uintptr_t x = (uintptr_t)a, y = (uintptr_t)b;
    return x < y + nb && y < x + na;
}

// >>files: reading and writing the operator cache's files (>>cache)

/* One 64-bit word mixed into a hash state (a bijection of h for each v). */
KIFMM__FN uint64_t kifmm__mix(uint64_t h, uint64_t v)
{
    h ^= v + 0x9E3779B97F4A7C15ull + (h << 6) + (h >> 2);
    h *= 0xBF58476D1CE4E5B9ull;
    return h ^ (h >> 31);
}

/* A 64-bit hash of n bytes, four words in flight (a few GB/s): it tells a
 * file as written from one cut short, overwritten or changed; it is not a
 * defence against a file made to pass it. */
KIFMM__FN uint64_t kifmm__hash_bytes(const void *p, size_t n)
{
    const unsigned char *b = (const unsigned char *)p;
    uint64_t s[4] = {1u, 2u, 3u, 4u}, w;
    size_t i = 0;
    int k;
    for (; i + 32 <= n; i += 32)
        for (k = 0; k < 4; k++) {
            memcpy(&w, b + i + 8 * (size_t)k, sizeof w);
            s[k] = (s[k] ^ w) * 0x9E3779B97F4A7C15ull;
            s[k] ^= s[k] >> 32;
        }
    for (; i < n; i++) s[0] = (s[0] ^ b[i]) * 0x100000001B3ull;
    return kifmm__mix(kifmm__mix(kifmm__mix(kifmm__mix((uint64_t)n, s[0]), s[1]), s[2]), s[3]);
}

/* A file read or written in pieces, with the hash of the pieces so far;
 * ok drops to 0 at the first failure, after which nothing more is done. */
typedef struct {
    FILE *f;
    uint64_t h;
    int ok;
} kifmm__file;

/* n bytes at p written (wr), or read into p; the hash takes them either way. */
KIFMM__FN void kifmm__fio(kifmm__file *f, int wr, void *p, size_t n)
{
    if (!f->ok || n == 0) return;
    if (wr) f->h = kifmm__mix(f->h, kifmm__hash_bytes(p, n));
    f->ok = wr ? fwrite(p, 1, n, f->f) == n : fread(p, 1, n, f->f) == n;
    if (!wr && f->ok) f->h = kifmm__mix(f->h, kifmm__hash_bytes(p, n));
}

/* dir "/" name (dir's own trailing separator kept), or NULL if out of
 * memory; kifmm__free it. */
KIFMM__FN char *kifmm__path(const char *dir, const char *name)
{
    const size_t nd = strlen(dir), nn = strlen(name);
    const int sep = nd > 0 && dir[nd - 1] != '/' && dir[nd - 1] != '\\';
    char *s = (char *)kifmm__alloc(nd + nn + 2, 1);
    if (!s) return NULL;
    memcpy(s, dir, nd);
    if (sep) s[nd] = '/';
    memcpy(s + nd + sep, name, nn + 1);
    return s;
}

/* A new file beside path under a name of its own (path ".tmp-" and 16 hex
 * digits from the clock and the calling thread's stack, opened
 * exclusively: a name taken already fails), for kifmm__fcommit; NULL if it
 * cannot be made. */
KIFMM__FN FILE *kifmm__fcreate(const char *path, char **tmp)
{
    const size_t n = strlen(path);
    uint64_t h = kifmm__mix((uint64_t)time(NULL), (uint64_t)clock());
    FILE *f = NULL;
    h = kifmm__mix(h, (uint64_t)(uintptr_t)&n);
    h = kifmm__mix(h, (uint64_t)(uintptr_t)tmp);
    *tmp = (char *)kifmm__alloc(n + 32, 1);
    if (!*tmp) return NULL;
    snprintf(*tmp, n + 32, "%s.tmp-%016llx", path, (unsigned long long)h);
    f = fopen(*tmp, "wbx");
    if (!f) {
        kifmm__free(*tmp);
        *tmp = NULL;
    }
    return f;
}

/* The file from kifmm__fcreate closed and, if everything was written
 * (ok), renamed to path (replacing a file there: readers see the old file
 * or the new one, whole), else removed. Returns whether path now holds it. */
KIFMM__FN int kifmm__fcommit(FILE *f, char *tmp, const char *path, int ok)
{
    ok = fflush(f) == 0 && ok;
    ok = fclose(f) == 0 && ok;
    ok = ok && rename(tmp, path) == 0;
    if (!ok) remove(tmp);
    kifmm__free(tmp);
    return ok;
}

// >>linalg

/* C = alpha op(A) op(B) + beta C, column major. Called outside parallel
 * regions, so a threaded BLAS uses its own threads on a large call, except
 * by the operators' solves where the BLAS runs one thread a call
 * (P__ops_solves_all, kifmm__blas_serial). */
KIFMM__FN void kifmm__gemm(int ta, int tb, int m, int n, int k, double alpha,
                           const double *a, int lda, const double *b, int ldb,
                           double beta, double *c, int ldc)
{
    if (m <= 0 || n <= 0) return;
    if (k <= 0) { /* C = beta C, and beta = 0 sets C (as in BLAS, C need not be
                     set on input: 0 times its NaN was NaN) */
        int i, j;
        for (j = 0; j < n; j++)
            for (i = 0; i < m; i++) {
                double *v = c + i + (size_t)j * ldc;
                *v = beta == 0.0 ? 0.0 : beta * *v;
            }
        return;
    }
    cblas_dgemm(CblasColMajor, ta ? CblasTrans : CblasNoTrans, tb ? CblasTrans : CblasNoTrans,
                m, n, k, alpha, a, lda, b, ldb, beta, c, ldc);
}

/* The factors of pinv(A) from A = U S V^T (the SVD of kifmm__pinv): ut =
 * U_k^T (k x m) and vs = V_k S_k^-1 (n x k). */
KIFMM__FN void kifmm__pinv_factors(int m, int n, int k, const double *u, const double *s,
                                   const double *vt, int mn, double *ut, double *vs)
{
    int i, j;
    for (i = 0; i < m; i++)
        for (j = 0; j < k; j++) ut[j + (size_t)i * k] = u[i + (size_t)j * m];
    for (j = 0; j < k; j++)
        for (i = 0; i < n; i++) vs[i + (size_t)j * n] = vt[j + (size_t)i * mn] / s[j];
}

/* The thin SVD of the m x n matrix A (destroyed), A = U S V^T: s (mn =
 * min(m, n) values, descending), u (m x mn) and vt (mn x n), by LAPACK's
 * dgesdd. */
KIFMM__FN int kifmm__svd(double *a, int m, int n, double *s, double *u, double *vt)
{
    const int mn = m < n ? m : n;
    lapack_int info, *iwork = (lapack_int *)kifmm__alloc((size_t)8 * mn, sizeof(lapack_int));
    double query, *work = NULL;
    int rc = KIFMM_SUCCESS;
    if (!iwork) return KIFMM_ERR_NOMEM;
    info = LAPACKE_dgesdd_work(LAPACK_COL_MAJOR, 'S', m, n, a, m, s, u, m, vt, mn, &query, -1,
                               iwork);
    if (info == 0) work = (double *)kifmm__alloc((size_t)query + 1, sizeof(double));
    if (info == 0 && !work) rc = KIFMM_ERR_NOMEM;
    else if (info == 0)
        info = LAPACKE_dgesdd_work(LAPACK_COL_MAJOR, 'S', m, n, a, m, s, u, m, vt, mn, work,
                                   (lapack_int)query + 1, iwork);
    if (!rc && info != 0) rc = KIFMM_ERR_LAPACK;
    kifmm__free(work);
    kifmm__free(iwork);
    return rc;
}

/* Pseudo-inverse of the m x n matrix A (destroyed) from its SVD, truncated at
 * s_i > cutoff * s_0, kept as two factors: pinv(A) = vs * ut with
 * ut = U_k^T (k x m) and vs = V_k S_k^-1 (n x k). Applying them one after the
 * other keeps the digits that forming the product would lose. A zero matrix
 * has rank 0 (a level whose far field is dropped). */
KIFMM__FN int kifmm__pinv(double *a, int m, int n, double cutoff, double **ut_out,
                          double **vs_out, int *rank)
{
    int mn = m < n ? m : n, k, rc = KIFMM_SUCCESS;
    double *s, *u, *vt, *ut = NULL, *vs = NULL;
    s = (double *)kifmm__alloc((size_t)mn, sizeof(double));
    u = (double *)kifmm__alloc((size_t)m * mn, sizeof(double));
    vt = (double *)kifmm__alloc((size_t)mn * n, sizeof(double));
    if (!s || !u || !vt) { rc = KIFMM_ERR_NOMEM; goto done; }
    if ((rc = kifmm__svd(a, m, n, s, u, vt)) != KIFMM_SUCCESS) goto done;
    for (k = 0; k < mn && s[k] > cutoff * s[0]; k++) {}
    ut = (double *)kifmm__alloc((size_t)k * m, sizeof(double));
    vs = (double *)kifmm__alloc((size_t)n * k, sizeof(double));
    if (!ut || !vs) { rc = KIFMM_ERR_NOMEM; goto done; }
    kifmm__pinv_factors(m, n, k, u, s, vt, mn, ut, vs);
    *ut_out = ut;
    *vs_out = vs;
    *rank = k;
    ut = vs = NULL;
done:
    kifmm__free(s);
    kifmm__free(u);
    kifmm__free(vt);
    kifmm__free(ut);
    kifmm__free(vs);
    return rc;
}

/* The factors of pinv(A^T) from those of pinv(A) (A m x n): A^T = V S U^T,
 * so ut' = V_k^T = S_k vs^T (k x n) and vs' = U_k S_k^-1 = ut^T S_k^-1
 * (m x k), with S_k from the norms of vs's columns (|V_k e_j| = 1). */
KIFMM__FN int kifmm__pinv_transposed(int m, int n, int k, const double *ut, const double *vs,
                                     double **ut_out, double **vs_out)
{
    double *u2 = (double *)kifmm__alloc((size_t)k * n, sizeof(double));
    double *v2 = (double *)kifmm__alloc((size_t)m * k, sizeof(double));
    int i, j;
    if (!u2 || !v2) {
        kifmm__free(u2);
        kifmm__free(v2);
        return KIFMM_ERR_NOMEM;
    }
    for (j = 0; j < k; j++) {
        double nv = 0.0, sj;
        for (i = 0; i < n; i++) nv += vs[i + (size_t)j * n] * vs[i + (size_t)j * n];
        sj = 1.0 / sqrt(nv); /* s_j: vs's column j is V e_j / s_j */
        for (i = 0; i < n; i++) u2[j + (size_t)i * k] = vs[i + (size_t)j * n] * sj;
        for (i = 0; i < m; i++) v2[i + (size_t)j * m] = ut[j + (size_t)i * k] / sj;
    }
    *ut_out = u2;
    *vs_out = v2;
    return KIFMM_SUCCESS;
}

/* GEMM over columns given by pointers: C(:, j) = A B(:, j), or += if acc,
 * for ncol columns (column j of B at bp[j], k values; of C at cp[j], m
 * values), A m x k column major (kifmm__gemm_colsd and _colsf, in >>prec).
 * The level passes (M2M, L2L, the solves) use it on pieces of KIFMM__GC_NC
 * columns, so their columns need not be contiguous (no gather into a
 * level-sized workspace, no scatter back).
 *
 * With AVX2 + FMA it runs on the calling thread alone and the passes split
 * their pieces over their own threads: no threaded BLAS runs beside or inside
 * their parallel regions, where it would nest, or contend with the waiting
 * OpenMP workers (measured at 1M points, p = 6: M2M 0.17 s -> 0.09..0.11 s,
 * L2L 0.16 s -> 0.10..0.11 s). Blocked for the caches: k in equal steps of
 * at most KC, a tile of MR rows x NR columns of C in registers. Without AVX2
 * the columns are gathered into `work` ((k + m) x ncol) for one BLAS call,
 * made by the passes outside parallel regions with pieces of 512 columns
 * (plain C tiles measured 3 to 5 times slower than OpenBLAS there).
 *
 * AVX-512: a tile of 3 vectors (24 doubles, 48 floats) x 8 columns of C in
 * 24 of the 32 registers; masked loads and stores for the rows past m. One
 * core, 48 columns, double: 50-54 Gflop/s for the shapes of M2M, L2L and
 * the solves at p = 6 and 12 (152 x 1216, 1216 x 152, 866 x 728), against
 * 34-42 with the AVX2 tile (2 vectors x 6 columns) and 46-56 for OpenBLAS's
 * dgemm (SkylakeX) on contiguous columns; k in blocks of 128 measured the
 * same or slower. */
#if defined(__AVX512F__)
#define KIFMM__GC_FAST 1
#define KIFMM__GC_NC 48
#define KIFMM__GC_NR 8
#define KIFMM__GC_KC 256
#define KIFMM__GC_MR_D 24
#define KIFMM__GC_MR_F 48
#elif defined(__AVX2__) && defined(__FMA__)
#define KIFMM__GC_FAST 1
#define KIFMM__GC_NC 48
#define KIFMM__GC_NR 6
#define KIFMM__GC_KC 256
#define KIFMM__GC_MR_D 8
#define KIFMM__GC_MR_F 16
#else
#define KIFMM__GC_FAST 0 /* the level passes call BLAS */
#define KIFMM__GC_NC 512
#endif

// >>tree

/* ---- Morton keys ------------------------------------------------------- */
/* A key at level l holds 3 l bits: bit 3i+2 is bit i of x, 3i+1 of y, 3i of z.
 * Children append three bits (octant c: x = c>>2 & 1, y = c>>1 & 1, z = c & 1). */
KIFMM__FN uint64_t kifmm__spread(uint64_t v)
{
    v &= 0x1fffff;
    v = (v | v << 32) & 0x1f00000000ffffULL;
    v = (v | v << 16) & 0x1f0000ff0000ffULL;
    v = (v | v << 8) & 0x100f00f00f00f00fULL;
    v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
    v = (v | v << 2) & 0x1249249249249249ULL;
    return v;
}

KIFMM__FN uint64_t kifmm__compact(uint64_t v)
{
    v &= 0x1249249249249249ULL;
    v = (v ^ (v >> 2)) & 0x10c30c30c30c30c3ULL;
    v = (v ^ (v >> 4)) & 0x100f00f00f00f00fULL;
    v = (v ^ (v >> 8)) & 0x1f0000ff0000ffULL;
    v = (v ^ (v >> 16)) & 0x1f00000000ffffULL;
    v = (v ^ (v >> 32)) & 0x1fffff;
    return v;
}

KIFMM__FN uint64_t kifmm__encode(int64_t x, int64_t y, int64_t z)
{
    return kifmm__spread((uint64_t)x) << 2 | kifmm__spread((uint64_t)y) << 1 |
           kifmm__spread((uint64_t)z);
}

KIFMM__FN void kifmm__decode(uint64_t key, int64_t *a)
{
    a[0] = (int64_t)kifmm__compact(key >> 2);
    a[1] = (int64_t)kifmm__compact(key >> 1);
    a[2] = (int64_t)kifmm__compact(key);
}

/* Stable LSD radix sort of (key, idx) pairs by key, 8 bits a pass, in
 * parallel: each thread counts its own contiguous chunk, the counts are
 * summed digit by digit and thread by thread, and each thread scatters its
 * chunk in order, so the result does not depend on the thread count. Passes
 * in which every key has the same digit are skipped. */

/* The digit counts of pass `shift`, per thread (cnt[th 256 + digit]); 1 if
 * every key has the same digit (the pass can be skipped). */
KIFMM__FN int kifmm__radix_count(const uint64_t *ka, int64_t n, int shift, int nth, int64_t *cnt)
{
    int64_t total0 = 0;
    int th;
    memset(cnt, 0, (size_t)nth * 256 * sizeof(int64_t));
    /* each thread counts its own chunk into its own row of cnt */
    KIFMM__OMP(parallel num_threads(nth))
    {
        int64_t i, lo, hi, *c = cnt + (size_t)kifmm__thread_chunk(n, &lo, &hi) * 256;
        for (i = lo; i < hi; i++) c[(ka[i] >> shift) & 255]++;
    }
    for (th = 0; th < nth; th++) total0 += cnt[(size_t)th * 256 + ((ka[0] >> shift) & 255)];
    return total0 == n;
}

/* Counts -> starting positions, digit by digit and thread by thread. */
KIFMM__FN void kifmm__radix_scan(int nth, int64_t *cnt)
{
    int64_t sum = 0;
    int b, th;
    for (b = 0; b < 256; b++)
        for (th = 0; th < nth; th++) {
            const int64_t c = cnt[(size_t)th * 256 + b];
            cnt[(size_t)th * 256 + b] = sum;
            sum += c;
        }
}

/* One pass: (ka, ia) scattered by digit into (kb, ib). */
KIFMM__FN void kifmm__radix_scatter(const uint64_t *ka, const int64_t *ia, int64_t n, int shift,
                                    int nth, int64_t *cnt, uint64_t *kb, int64_t *ib)
{
    (void)nth; /* used by the OpenMP pragmas only */
    /* each thread scatters its own chunk, from its own row of positions */
    KIFMM__OMP(parallel num_threads(nth))
    {
        int64_t i, lo, hi, *c = cnt + (size_t)kifmm__thread_chunk(n, &lo, &hi) * 256;
        for (i = lo; i < hi; i++) {
            const int64_t d = c[(ka[i] >> shift) & 255]++;
            kb[d] = ka[i];
            ib[d] = ia[i];
        }
    }
}

KIFMM__FN int kifmm__radix_sort(uint64_t *key, int64_t *idx, int64_t n, int nth)
{
    uint64_t *k2 = (uint64_t *)kifmm__alloc((size_t)n, sizeof(uint64_t)), *ka = key, *kb = k2;
    int64_t *i2 = (int64_t *)kifmm__alloc((size_t)n, sizeof(int64_t)), *ia = idx, *ib = i2;
    int64_t *cnt = (int64_t *)kifmm__alloc((size_t)nth * 256, sizeof(int64_t));
    int shift;
    if (!k2 || !i2 || !cnt) {
        kifmm__free(k2);
        kifmm__free(i2);
        kifmm__free(cnt);
        return KIFMM_ERR_NOMEM;
    }
    /* each pass scatters from (ka, ia) into (kb, ib), then the two swap */
    for (shift = 0; shift < 64 && n > 0; shift += 8) {
        uint64_t *kt = ka;
        int64_t *it = ia;
        if (kifmm__radix_count(ka, n, shift, nth, cnt)) continue;
        kifmm__radix_scan(nth, cnt);
        kifmm__radix_scatter(ka, ia, n, shift, nth, cnt, kb, ib);
        ka = kb;
        kb = kt;
        ia = ib;
        ib = it;
    }
    if (ka != key) {
        /* each i copies its own element back */
        KIFMM__OMP(parallel for schedule(static) num_threads(nth))
        for (int64_t i = 0; i < n; i++) {
            key[i] = ka[i];
            idx[i] = ia[i];
        }
    }
    kifmm__free(k2);
    kifmm__free(i2);
    kifmm__free(cnt);
    return KIFMM_SUCCESS;
}
/* First position in the sorted array a[0..n) holding a value >= v. */
KIFMM__FN int64_t kifmm__lower_bound(const uint64_t *a, int64_t n, uint64_t v)
{
    int64_t lo = 0, hi = n;
    while (lo < hi) {
        int64_t mid = lo + (hi - lo) / 2;
        if (a[mid] < v) lo = mid + 1;
        else hi = mid;
    }
    return lo;
}

/* ---- the adaptive octree ------------------------------------------------ */

#define KIFMM__D KIFMM_MAX_DEPTH /* level of the point keys */

/* Caps on the interaction lists of one box. With 2:1 balance the published
 * bounds are |U| <= 60, |V| <= 189, |W| <= 148, |X| <= 19. */
#define KIFMM__MAXU 128
#define KIFMM__MAXV 189
#define KIFMM__MAXW 208
#define KIFMM__MAXX 64

/* Boxes are stored level by level, sorted by key within a level; the eight
 * children of a box are consecutive, so the boxes of level l + 1 are exactly
 * the children of the internal boxes of level l, in order. Points are sorted
 * by key and each box owns a contiguous range of them. */
typedef struct kifmm__tree {
    size_t held;             /* bytes of the arrays below (see kifmm__take) */
    int64_t ns, nt;
    double *src, *trg;       /* sorted points, structure of arrays (x | y | z) */
    int64_t *sperm, *tperm;  /* sorted position -> caller's index */
    int same;                /* targets are the sources: trg = src, tperm = sperm */
    int per[3], periodic;    /* per[d]: periodic in direction d (period: cell);
                                periodic: any of them */
    int kc;                  /* levels above the cell: the root is 2^kc cells wide
                                (free directions spanning more than the period) */
    double cell;             /* periodic trees: the period L (the root's width / 2^kc) */
    double frame[3];         /* periodic directions: the frame's offset f, the root's
                                lower corner -f (kifmm__frame_offset), else 0 */
    int32_t *alias;          /* kc > 0: per box of levels 1 .. kc, the box whose image
                                it is (periodic anchors 0), or -1; else NULL */
    double origin[3];        /* shift of each axis: the root's centre where that is
                                exact, else 0 (see kifmm__tree_bounds) */
    double lo[3], width;     /* root cube: lower corner relative to origin, and edge */
    int nlev;                /* levels 0 .. nlev - 1 */
    int32_t nbox;
    int32_t loff[KIFMM__D + 2];   /* boxes of level l: [loff[l], loff[l+1]) */
    int32_t ioff[KIFMM__D + 2];   /* internal boxes of level l: inner[ioff[l] .. ioff[l+1]) */
    uint64_t *key;
    int32_t *child;               /* first of the 8 children, or -1 for a leaf */
    int32_t *parent;              /* -1 for the root */
    int32_t *anchor;              /* integer coordinates of each box at its level (3 per box) */
    unsigned char *lev;           /* level of each box */
    int32_t *inner;               /* internal boxes, level by level */
    int64_t *s0, *s1, *t0, *t1;   /* point ranges of each box */
    int32_t *uo, *u, *vo, *v, *wo, *w, *xo, *x; /* lists, offsets per box (v: NULL
                                                   unless built with V entries) */
    unsigned char *us, *ws, *xs;  /* periodic trees: the image of each U, W, X entry
                                     (kifmm__shift_code), else NULL */
    uint16_t *vt;                 /* transfer vector index of each V entry (or NULL) */
    int32_t *m2lo, *m2l;          /* per level: boxes with targets and a V list */
    int32_t *leaves;              /* leaves with targets, in Morton order */
    int32_t nleaves;
    int32_t *dix;                 /* while the lists are built: box of each key of the
                                     levels with dixo[l] >= 0 (-1 where none), or NULL */
    int64_t dixo[KIFMM__D + 2];
} kifmm__tree;

KIFMM__FN void kifmm__tree_free(kifmm__tree *t)
{
    void *p[] = {t->src, t->same ? NULL : t->trg, t->sperm, t->same ? NULL : t->tperm,
                 t->key, t->child, t->parent, t->anchor, t->lev, t->inner,
                 t->s0, t->s1, t->t0, t->t1, t->uo, t->u, t->vo, t->v, t->wo, t->w,
                 t->xo, t->x, t->vt, t->m2lo, t->m2l, t->leaves, t->us, t->ws, t->xs, t->alias};
    size_t i;
    for (i = 0; i < sizeof p / sizeof p[0]; i++) kifmm__free(p[i]);
    memset(t, 0, sizeof *t);
}

/* n added to *r atomically; the new value. */
KIFMM__FN int kifmm__refs_add(int *r, int n)
{
#if defined(__GNUC__) || defined(__clang__)
    return __atomic_add_fetch(r, n, __ATOMIC_ACQ_REL);
#else
    int v;
    KIFMM__OMP(critical(kifmm__refs))
    v = *r += n;
    return v;
#endif
}

/* The points' part that handles share (<prefix>_tree, <prefix>_create_on_tree):
 * the tree, its lists and the sorted points, with the options that shaped
 * them. Reference counted: it lives while a handle uses it. Its layout does
 * not depend on the translation unit's build options (no lock: the count
 * is atomic), so handles of instances compiled apart can share one. */
struct kifmm_tree {
    int refs;                  /* handles on it */
    void (*destroy)(struct kifmm_tree *); /* frees it with the allocator (KIFMM_FREE) of
                                  the translation unit that built it, whichever unit
                                  lets go of it last */
    int single;                /* the sorted points are float (fsrc, ftrg), else double
                                  (t.src, t.trg) */
    int vlists;                /* the lists hold V entries (the dense M2L's) */
    int leaf_size, max_depth;  /* the options that built it, resolved */
    double period[3], domain[4];
    float *fsrc, *ftrg;        /* float trees: the sorted points (ftrg = fsrc if same);
                                  counted in t.held */
    kifmm__tree t;
};

/* The tree and its arrays, freed (through tr->destroy: with this unit's
 * allocator, which allocated them). */
KIFMM__FN void kifmm__tree_destroy(kifmm_tree *tr)
{
    kifmm__free(tr->fsrc);
    if (tr->ftrg != tr->fsrc) kifmm__free(tr->ftrg);
    kifmm__tree_free(&tr->t);
    kifmm__free(tr);
}

/* A tree with nothing in it yet, one reference; NULL if out of memory. */
KIFMM__FN kifmm_tree *kifmm__tree_new(int64_t ns, int64_t nt)
{
    kifmm_tree *tr = (kifmm_tree *)kifmm__calloc(1, sizeof *tr);
    if (!tr) return NULL;
    tr->refs = 1;
    tr->destroy = kifmm__tree_destroy;
    tr->t.ns = ns;
    tr->t.nt = nt;
    return tr;
}

/* One reference let go; the tree freed with the last. NULL is a no-op. */
KIFMM__FN void kifmm__tree_release(kifmm_tree *tr)
{
    if (!tr || kifmm__refs_add(&tr->refs, -1) > 0) return;
    tr->destroy(tr);
}

KIFMM__FN int kifmm__level_of(const kifmm__tree *t, int32_t b)
{
    return t->lev[b];
}

/* Box index of (level, key), or -1. */
KIFMM__FN int32_t kifmm__find(const kifmm__tree *t, int l, uint64_t key)
{
    int32_t lo = t->loff[l], n = t->loff[l + 1] - lo;
    int64_t i;
    if (l >= t->nlev) return -1;
    if (t->dix && t->dixo[l] >= 0) return t->dix[t->dixo[l] + (int64_t)key];
    i = kifmm__lower_bound(t->key + lo, n, key);
    return (i < n && t->key[lo + i] == key) ? lo + (int32_t)i : -1;
}

/* The box of level <= l that contains the level-l position `key`, or -1. */
KIFMM__FN int32_t kifmm__find_cover(const kifmm__tree *t, int l, uint64_t key)
{
    int m;
    for (m = l < t->nlev - 1 ? l : t->nlev - 1; m >= 0; m--) {
        int32_t b = kifmm__find(t, m, key >> (3 * (l - m)));
        if (b >= 0) return b;
    }
    return -1;
}

/* The first level with expansions: 2 in free space (boxes of levels 0 and 1
 * have no well-separated boxes), 0 in a periodic tree (the root's far field
 * comes from the images beyond its neighbours). */
KIFMM__FN int kifmm__lmin(const kifmm__tree *t) { return t->periodic ? 0 : 2; }

/* Images of the unit cell: a code s = 9 (sx + 1) + 3 (sy + 1) + (sz + 1) for the
 * shift (sx, sy, sz) of one period, each -1, 0 or 1; 13 is no shift. */
#define KIFMM__NOSHIFT 13
/* The shift code of entry e of a list with shifts sh (NULL: free space). */
#define KIFMM__SH(sh, e) ((sh) ? (int)(sh)[e] : KIFMM__NOSHIFT)
KIFMM__FN int kifmm__shift_code(const int *s) { return 9 * (s[0] + 1) + 3 * (s[1] + 1) + s[2] + 1; }

KIFMM__FN void kifmm__shift_of(int code, int *s)
{
    s[0] = code / 9 - 1;
    s[1] = code / 3 % 3 - 1;
    s[2] = code % 3 - 1;
}

/* The period of level l in a periodic direction, in units of the finest
 * level (2^20 per root width): the cell's width below the cell (levels kc
 * on), and at coarser levels the box's own width, since a box of level l <
 * kc stands for the 2^(kc - l) images of the cell along each periodic
 * direction that it spans (its images are its neighbours). */
KIFMM__FN int32_t kifmm__period_units(const kifmm__tree *t, int l)
{
    return (int32_t)1 << (KIFMM__D - (l >= t->kc ? t->kc : l));
}

/* Do box a and box b moved by off (units of the finest level) touch or
 * overlap (closed cubes)? */
KIFMM__FN int kifmm__adjacent_o(const kifmm__tree *t, int32_t a, int32_t b, const int32_t *off)
{
    int sa = KIFMM__D - t->lev[a], sb = KIFMM__D - t->lev[b], d;
    const int32_t *xa = t->anchor + 3 * (size_t)a, *xb = t->anchor + 3 * (size_t)b;
    for (d = 0; d < 3; d++) {
        int32_t a0 = xa[d] << sa, a1 = (xa[d] + 1) << sa;
        int32_t b0 = (xb[d] << sb) + off[d], b1 = ((xb[d] + 1) << sb) + off[d];
        if (a0 > b1 || b0 > a1) return 0;
    }
    return 1;
}

/* Do box a and the image s (a shift code, in periods) of box b touch or
 * overlap? Coordinates in units of the finest level (2^20 per root width,
 * so an image's fit in int32). */
KIFMM__FN int kifmm__adjacent_s(const kifmm__tree *t, int32_t a, int32_t b, int s)
{
    int sh[3], d;
    int32_t off[3];
    kifmm__shift_of(s, sh);
    for (d = 0; d < 3; d++) off[d] = sh[d] * kifmm__period_units(t, t->kc);
    return kifmm__adjacent_o(t, a, b, off);
}

/* Do boxes a and b touch or overlap (closed cubes)? */
KIFMM__FN int kifmm__adjacent(const kifmm__tree *t, int32_t a, int32_t b)
{
    return kifmm__adjacent_s(t, a, b, KIFMM__NOSHIFT);
}

/* Anchor coordinate x of level l (side 2^l boxes) in direction d, wrapped
 * into the cell if d is periodic (*s gets the shift, in periods of level l:
 * kifmm__period_units); -1 if it lies outside the root in a free direction.
 * Shift codes hold -1 .. 1 (x at most one period outside the cell, as from
 * the boxes inside it). */
KIFMM__FN int64_t kifmm__wrap(const kifmm__tree *t, int d, int l, int64_t x, int *s)
{
    const int lp = t->per[d] ? (l >= t->kc ? l - t->kc : 0) : l;
    const int64_t side = (int64_t)1 << lp;
    *s = 0;
    if (x >= 0 && x < side) return x;
    if (!t->per[d]) return -1;
    *s = (int)(x >> lp); /* floor(x / side), also for negative x */
    return x - (int64_t)*s * side;
}

/* Does box b hold sources, or (kc > 0) is it the image of a box that does? */
KIFMM__FN int kifmm__has_src(const kifmm__tree *t, int32_t b)
{
    if (t->alias && t->alias[b] >= 0) b = t->alias[b];
    return t->s1[b] > t->s0[b];
}

KIFMM__FN void kifmm__box_center(const kifmm__tree *t, int32_t b, double *c, double *half)
{
    int l = kifmm__level_of(t, b), d;
    const int32_t *a = t->anchor + 3 * (size_t)b;
    double w = t->width / (double)((int64_t)1 << l);
    for (d = 0; d < 3; d++) c[d] = t->lo[d] + ((double)a[d] + 0.5) * w;
    *half = 0.5 * w;
}

/* c - fc into d, the centre of a surface in a frame */
KIFMM__FN void kifmm__sub3(const double *c, const double *fc, double *d)
{
    d[0] = c[0] - fc[0];
    d[1] = c[1] - fc[1];
    d[2] = c[2] - fc[2];
}

/* A growable array of keys. */
typedef struct { uint64_t *a; int64_t n, cap; } kifmm__keys;

KIFMM__FN int kifmm__keys_push(kifmm__keys *k, uint64_t v)
{
    if (k->n == k->cap) {
        int64_t cap = k->cap ? 2 * k->cap : 64;
        uint64_t *a = (uint64_t *)kifmm__alloc((size_t)cap, sizeof(uint64_t));
        if (!a) return KIFMM_ERR_NOMEM;
        if (k->n) memcpy(a, k->a, (size_t)k->n * sizeof *a);
        kifmm__free(k->a);
        k->a = a;
        k->cap = cap;
    }
    k->a[k->n++] = v;
    return KIFMM_SUCCESS;
}

KIFMM__FN int kifmm__cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* Sort and drop duplicates. */
KIFMM__FN void kifmm__keys_unique(kifmm__keys *k)
{
    int64_t i, m = 0;
    if (k->n < 2) return;
    qsort(k->a, (size_t)k->n, sizeof(uint64_t), kifmm__cmp_u64);
    for (i = 0; i < k->n; i++)
        if (m == 0 || k->a[i] != k->a[m - 1]) k->a[m++] = k->a[i];
    k->n = m;
}

/* Coordinate v of direction d in the tree's frame: relative to t->origin, or
 * in a periodic direction wrapped into the cell [-f, L - f), f the frame's
 * offset (kifmm__frame_offset): into [0, L) first, then [L - f, L) moved
 * down by L, which is exact (f <= L / 2: Sterbenz), so that points given in
 * the cell keep their coordinates and their digits. */
KIFMM__FN double kifmm__coord(const kifmm__tree *t, double v, int d)
{
    double w;
    if (!t->per[d]) return v - t->origin[d];
    w = v - t->cell * floor(v / t->cell);
    if (!(w >= 0.0 && w < t->cell)) w = 0.0; /* rounding can give L itself */
    return t->frame[d] > 0.0 && w >= t->cell - t->frame[d] ? w - t->cell : w;
}

/* Sort one point set by key: sorted SoA coordinates relative to t->origin,
 * permutation, keys. Every later step works in these coordinates: a cloud
 * far from the caller's origin keeps the digits of its own size (surface
 * points placed at c + r u would lose those of |c|). */
KIFMM__FN int kifmm__sort_points(kifmm__tree *t, int64_t n, const double *xyz, double **out,
                                 int64_t **perm, uint64_t **keys, int nth)
{
    double scale = (double)((int64_t)1 << KIFMM__D) / t->width;
    int64_t maxi = ((int64_t)1 << KIFMM__D) - 1;
    int rc;
    *out = (double *)kifmm__take(&t->held, (size_t)(3 * n), sizeof(double));
    *perm = (int64_t *)kifmm__take(&t->held, (size_t)n, sizeof(int64_t));
    *keys = (uint64_t *)kifmm__alloc((size_t)n, sizeof(uint64_t));
    if (!*out || !*perm || !*keys) return KIFMM_ERR_NOMEM;
    KIFMM__OMP(parallel for schedule(static) num_threads(nth))
    for (int64_t i = 0; i < n; i++) {
        int64_t a[3];
        int d;
        for (d = 0; d < 3; d++) {
            double f = (kifmm__coord(t, xyz[3 * i + d], d) - t->lo[d]) * scale;
            a[d] = f <= 0.0 ? 0 : (f >= (double)maxi ? maxi : (int64_t)f);
        }
        (*keys)[i] = kifmm__encode(a[0], a[1], a[2]);
        (*perm)[i] = i;
    }
    rc = kifmm__radix_sort(*keys, *perm, n, nth);
    if (rc) return rc;
    KIFMM__OMP(parallel for schedule(static) num_threads(nth))
    for (int64_t i = 0; i < n; i++) {
        int d;
        for (d = 0; d < 3; d++) (*out)[d * n + i] = kifmm__coord(t, xyz[3 * (*perm)[i] + d], d);
    }
    return KIFMM_SUCCESS;
}

/* ---- building the tree: bounds, sort, refine, balance, layout ------------ */

/* The smallest and largest coordinate d over the sources and targets. */
KIFMM__FN void kifmm__extent(int64_t ns, const double *src, int64_t nt, const double *trg, int d,
                             int nth, double *lo, double *hi)
{
    double mn = HUGE_VAL, mx = -HUGE_VAL;
    (void)nth; /* used by the OpenMP pragmas only */
    KIFMM__OMP(parallel for schedule(static) num_threads(nth) reduction(min : mn) reduction(max : mx))
    for (int64_t i = 0; i < ns + nt; i++) {
        const double v = i < ns ? src[3 * i + d] : trg[3 * (i - ns) + d];
        mn = v < mn ? v : mn;
        mx = v > mx ? v : mx;
    }
    *lo = mn;
    *hi = mx;
}

/* The root's axis d centred at c with half-width half, shifted by the
 * centre where that is exact (see kifmm__tree_bounds). */
KIFMM__FN void kifmm__centre_axis(kifmm__tree *t, int d, double c, double half)
{
    t->origin[d] = fabs(c) >= 2.0 * half ? c : 0.0;
    t->lo[d] = (c - t->origin[d]) - half;
}

/* Step 1 with periodic directions: the root is the unit cell, [0, L) in a
 * periodic direction, when the points span less than L in the free ones;
 * otherwise it is 2^kc cells wide (kc up to KIFMM__KC_MAX, the smallest
 * that holds them), [0, 2^kc L) in a periodic direction, where the points
 * still lie in [0, L) and the boxes of levels below kc stand for the cell's
 * images (kifmm__period_units). In a free direction the root is centred on
 * the points (shifted as below). */
#define KIFMM__KC_MAX 10

/* The offset f of a periodic direction's frame: the root's lower corner is
 * -f there (kifmm__coord). With f = 0 the cell's faces are box faces at
 * every level, and points crowding a face (a wall, an interface) sit at the
 * near face of their boxes at every level, facing their images across it
 * one box apart, the worst case of the M2L's separation (5,000 sources
 * crowding a face and a corner, 1,000 targets apart, laplace_grad p = 6:
 * potential 2.0e-5 and 3.3e-5, two seeds; see docs/algorithm.md). Each
 * candidate (0, L / 3, L / 7, 3 L / 7) is scored by the sources and the
 * targets within 1/8 of a box's width of a box face of levels 1 to 8, on a
 * sample of at most 4,096 of each (one per block of n / 4,096, at a hashed
 * place in the block, so that no period in the caller's order, such as
 * species interleaved, hides a crowd; targets crowding a corner of the
 * cell, sources spread, Laplace with two periodic directions, p = 6: 4.3e-5
 * counting the sources alone, 8.7e-6 with the targets). The frame moves
 * only where a candidate has a tenth fewer than 0: where the counts differ
 * by less, they differ by the sample's chance, not by a crowd. A third keeps the cell's faces and its dyadic planes
 * (centre, quarters) a third of a box from every box face; the sevenths
 * take over where sources crowd the planes that a third would align (2/3,
 * 1/6, ...). Results do not depend on the frame beyond the method's
 * error. */
KIFMM__FN double kifmm__frame_offset(const kifmm__tree *t, int64_t ns, const double *src,
                                     int64_t nt, const double *trg, int d)
{
    static const double cand[4] = {0.0, 1.0 / 3.0, 1.0 / 7.0, 3.0 / 7.0};
    const int sets = trg == src && nt == ns ? 1 : 2; /* the targets, unless they are the sources */
    int64_t cnt[4] = {0, 0, 0, 0}, k;
    int c, l, best = 0, set;
    for (set = 0; set < sets; set++) {
        const int64_t n = set ? nt : ns, ms = n < 4096 ? n : 4096;
        const double *x = set ? trg : src;
        for (k = 0; k < ms; k++) { /* block k: [b(k), b(k + 1)), b(k) = k n / ms */
            const int64_t b0 = k * (n / ms) + k * (n % ms) / ms;
            const int64_t b1 = (k + 1) * (n / ms) + (k + 1) * (n % ms) / ms;
            const int64_t i = b0 + (int64_t)(((uint64_t)k * 2654435761u) % (uint64_t)(b1 - b0));
            const double u0 = kifmm__coord(t, x[3 * i + d], d) / t->cell;
            for (c = 0; c < 4; c++)
                for (l = 1; l <= 8; l++) {
                    double f = (u0 + cand[c]) * (double)(1 << l); /* in the root of offset cand[c] */
                    f -= floor(f);
                    cnt[c] += f < 0.125 || f > 0.875;
                }
        }
    }
    for (c = 1; c < 4; c++)
        if (cnt[c] < cnt[best]) best = c;
    if (10 * cnt[best] > 9 * cnt[0]) best = 0;
    return cand[best] * t->cell;
}

KIFMM__FN int kifmm__tree_bounds_periodic(kifmm__tree *t, int64_t ns, const double *src,
                                          int64_t nt, const double *trg, int nth)
{
    double mn[3], mx[3], half;
    int d;
    t->kc = 0;
    for (d = 0; d < 3; d++) {
        if (t->per[d]) continue;
        kifmm__extent(ns, src, nt, trg, d, nth, &mn[d], &mx[d]);
        while (!(0.5 * (mx[d] - mn[d]) * (1.0 + 1e-10) < 0.5 * ldexp(t->cell, t->kc)))
            if (++t->kc > KIFMM__KC_MAX) return KIFMM_ERR_PERIOD;
    }
    t->width = ldexp(t->cell, t->kc);
    half = 0.5 * t->width;
    for (d = 0; d < 3; d++) {
        t->frame[d] = 0.0; /* kifmm__frame_offset reads the cell's frame */
        if (t->per[d]) t->frame[d] = kifmm__frame_offset(t, ns, src, nt, trg, d);
        t->origin[d] = 0.0;
        t->lo[d] = -t->frame[d];
        if (!t->per[d]) kifmm__centre_axis(t, d, 0.5 * (mn[d] + mx[d]), half);
    }
    return KIFMM_SUCCESS;
}

/* KIFMM_FREE_FRAME 0: the free-space root is always the tight cube (see
 * kifmm__free_frame) */
#ifndef KIFMM_FREE_FRAME
#define KIFMM_FREE_FRAME 1
#endif
/* The free-space root's frame. The smallest cube around the points, centred
 * on them, puts every point of a crowd at the points' centre (a body with
 * targets set around it symmetrically) on the boxes' faces at every level,
 * and a crowd at the points' edge on the root's faces: the equivalent
 * surfaces' worst place. 20,000 Laplace charges on a sphere of radius 1e-3,
 * 3,000 targets spread over [0, 1]^3, p = 6: 1.5e-7 with the sphere about
 * (0.3, 0.3, 0.3), 8.0e-5 about (0.5, 0.5, 0.5); laplace_dipole 1.1e-4 at
 * the corner (0, 0, 0). So a second frame is tried: a cube 1.5 times as
 * wide, its lower corner at lo - f slack in each axis (slack: its width
 * less the points' extent; f one of twelve fractions with odd denominators,
 * never a dyadic place), the best f per axis. As kifmm__frame_offset does
 * for the periodic cell, each frame counts sampled sources and targets (at
 * most 4096 of each, one per block of the array; a crowd of targets at the
 * centre gave 4.6e-5 in the gradient, 5.4e-7 with the frame moved) within
 * 1/8 of a box width of a box face at
 * levels 1 to 8, and the wider frame is taken only where it counts less
 * than half the tight one's: uniform points do not move (their counts
 * differ by a few per cent), nor do the Gaussian blobs of bench/points.h,
 * whose densest blobs sit at 0.75 and 0.5 (at 3/4 they moved, and the error
 * at 20,000 points went from 9.3e-7 to 1.1e-6 at p = 6 and from 1.8e-8 to
 * 1.3e-8 at p = 8). Where it moves for a crowd that needed it less, the
 * error can grow a little: counting sources alone, the sphere above about
 * (0.3, 0.3, 0.3) moved, laplace_grad potential 9.3e-8 -> 2.2e-7, gradient
 * 2.4e-6 -> 4.7e-6 (with the spread targets counted it stays). In: ns, src,
 * nt, trg (trg == src: counted once), lo, hi (the points' extent), *half
 * (the tight cube's padded half-width). Out: ctr (the root's centre),
 * *half. */
KIFMM__FN void kifmm__free_frame(int64_t ns, const double *src, int64_t nt, const double *trg,
                                 const double *lo, const double *hi, double *half, double *ctr)
{
    static const double cand[12] = {1.0 / 3.0, 2.0 / 3.0, 1.0 / 5.0, 2.0 / 5.0,
                                     3.0 / 5.0, 4.0 / 5.0, 1.0 / 7.0, 2.0 / 7.0,
                                     3.0 / 7.0, 4.0 / 7.0, 5.0 / 7.0, 6.0 / 7.0};
    const double h0 = *half, w1 = 3.0 * h0;
    const int sets = trg == src && nt == ns ? 1 : 2; /* the targets, unless they are the sources */
    int64_t ca = 0, cb = 0;
    double cw[3];
    int d;
    for (d = 0; d < 3; d++) {
        const double slack = w1 - (hi[d] - lo[d]), la = 0.5 * (lo[d] + hi[d]) - h0;
        int64_t cnt[13], k;
        int c, l, best = 1, set;
        ctr[d] = 0.5 * (lo[d] + hi[d]);
        for (c = 0; c < 13; c++) cnt[c] = 0;
        for (set = 0; set < sets; set++) {
            const int64_t n = set ? nt : ns, ms = n < 4096 ? n : 4096;
            const double *x = set ? trg : src;
            for (k = 0; k < ms; k++) { /* as in kifmm__frame_offset */
                const int64_t b0 = k * (n / ms) + k * (n % ms) / ms;
                const int64_t b1 = (k + 1) * (n / ms) + (k + 1) * (n % ms) / ms;
                const int64_t i = b0 + (int64_t)(((uint64_t)k * 2654435761u) % (uint64_t)(b1 - b0));
                const double v = x[3 * i + d];
                for (c = 0; c < 13; c++) {
                    /* c = 0: the tight cube; c >= 1: the wide one at cand[c - 1] */
                    const double u = c == 0 ? (v - la) / (2.0 * h0)
                                            : (v - (lo[d] - cand[c - 1] * slack)) / w1;
                    for (l = 1; l <= 8; l++) {
                        double f = u * (double)(1 << l); /* as ldexp(u, l), without the call */
                        f -= floor(f);
                        cnt[c] += f < 0.125 || f > 0.875;
                    }
                }
            }
        }
        for (c = 2; c < 13; c++)
            if (cnt[c] < cnt[best]) best = c;
        ca += cnt[0];
        cb += cnt[best];
        cw[d] = lo[d] - cand[best - 1] * slack + 0.5 * w1;
    }
    if (2 * cb < ca) {
        *half = 0.5 * w1;
        for (d = 0; d < 3; d++) ctr[d] = cw[d];
    }
}

/* Step 1, the root cube (opts.domain's box where one is given): the
 * smallest cube around every source and target,
 * padded so that no point sits on its outer faces, or a wider one where
 * that keeps crowds of points off the boxes' faces (kifmm__free_frame).
 * Each axis is shifted by
 * the cube's centre where that shift is exact: with |centre| >= the root's
 * width, every coordinate lies within a factor 2 of the centre, so x -
 * centre is exact (Sterbenz). Elsewhere the points keep their own
 * coordinates, whose differences are exact for nearby points, and the cloud
 * is within a width of the origin anyway, so surfaces lose at most a bit or
 * two there. */
KIFMM__FN int kifmm__tree_bounds(kifmm__tree *t, int64_t ns, const double *src, int64_t nt,
                                 const double *trg, int nth, const double *domain)
{
    double lo[3], hi[3], ctr[3], half = 0.0;
    int d;
    if (t->periodic) return kifmm__tree_bounds_periodic(t, ns, src, nt, trg, nth);
    if (domain && domain[3] > 0.0) { /* opts.domain: the caller's box, as it is */
        for (d = 0; d < 3; d++) kifmm__centre_axis(t, d, domain[d], domain[3]);
        t->width = 2.0 * domain[3];
        return KIFMM_SUCCESS;
    }
    for (d = 0; d < 3; d++) kifmm__extent(ns, src, nt, trg, d, nth, &lo[d], &hi[d]);
    for (d = 0; d < 3; d++)
        if (0.5 * (hi[d] - lo[d]) > half) half = 0.5 * (hi[d] - lo[d]);
    if (!(half > 0.0)) half = 0.5;
    half *= 1.0 + 1e-10;
#if KIFMM_FREE_FRAME
    kifmm__free_frame(ns, src, nt, trg, lo, hi, &half, ctr);
#else
    for (d = 0; d < 3; d++) ctr[d] = 0.5 * (lo[d] + hi[d]);
#endif
    for (d = 0; d < 3; d++) kifmm__centre_axis(t, d, ctr[d], half);
    t->width = 2.0 * half;
    return KIFMM_SUCCESS;
}

/* Step 2, the points sorted by key (kifmm__sort_points): when the targets
 * are the sources (same array and count), one sorted copy serves as both. */
KIFMM__FN int kifmm__tree_sort(kifmm__tree *t, int64_t ns, const double *src, int64_t nt,
                               const double *trg, int nth, uint64_t **skey, uint64_t **tkey)
{
    int rc = kifmm__sort_points(t, ns, src, &t->src, &t->sperm, skey, nth);
    if (rc) return rc;
    if (trg == src && nt == ns) {
        t->same = 1;
        t->trg = t->src;
        t->tperm = t->sperm;
        *tkey = *skey;
        return KIFMM_SUCCESS;
    }
    return kifmm__sort_points(t, nt, trg, &t->trg, &t->tperm, tkey, nth);
}

/* Does box `key` of the level with shift sh split? It holds more than leaf
 * sources or targets, unless all of them share one finest key (coincident
 * points never separate); leaf < 0: it holds any (boxes above the cell). */
KIFMM__FN int kifmm__box_splits(const kifmm__tree *t, const uint64_t *skey, const uint64_t *tkey,
                                uint64_t key, int sh, int leaf)
{
    const uint64_t k0 = key << sh, k1 = (key + 1) << sh;
    const int64_t fs = kifmm__lower_bound(skey, t->ns, k0), ft = kifmm__lower_bound(tkey, t->nt, k0);
    const int64_t cs = kifmm__lower_bound(skey, t->ns, k1) - fs;
    const int64_t ct = kifmm__lower_bound(tkey, t->nt, k1) - ft;
    if (leaf < 0) return cs > 0 || ct > 0;
    if (cs <= leaf && ct <= leaf) return 0;
    return !((cs == 0 || skey[fs] == skey[fs + cs - 1]) &&
             (ct == 0 || tkey[ft] == tkey[ft + ct - 1]) &&
             (cs == 0 || ct == 0 || skey[fs] == tkey[ft]));
}

/* Step 3, top-down refinement: in[l] gets the keys of the boxes of level l
 * that split, level by level, down to maxdepth. */
KIFMM__FN int kifmm__tree_refine(const kifmm__tree *t, const uint64_t *skey, const uint64_t *tkey,
                                 int leaf, int maxdepth, int nth, kifmm__keys *in)
{
    (void)nth; /* used by the OpenMP pragmas only */
    kifmm__keys cur = {0, 0, 0}, next = {0, 0, 0};
    unsigned char *split = NULL;
    int l, rc = kifmm__keys_push(&cur, 0);
    for (l = 0; l < maxdepth && cur.n > 0 && !rc; l++) {
        const int sh = 3 * (KIFMM__D - l);
        int64_t j;
        kifmm__free(split);
        split = (unsigned char *)kifmm__alloc((size_t)cur.n, 1);
        if (!split) { rc = KIFMM_ERR_NOMEM; break; }
        /* each j decides for its own box */
        KIFMM__OMP(parallel for schedule(dynamic, 256) num_threads(nth))
        for (int64_t jj = 0; jj < cur.n; jj++)
            /* boxes with points split down to the cell (kc): see kifmm__period_units */
            split[jj] = (unsigned char)kifmm__box_splits(t, skey, tkey, cur.a[jj], sh, l < t->kc ? -1 : leaf);
        next.n = 0;
        for (j = 0; j < cur.n && !rc; j++) {
            int o;
            if (!split[j]) continue;
            rc = kifmm__keys_push(&in[l], cur.a[j]);
            for (o = 0; o < 8 && !rc; o++) rc = kifmm__keys_push(&next, cur.a[j] << 3 | (uint64_t)o);
        }
        { kifmm__keys tmp = cur; cur = next; next = tmp; }
    }
    kifmm__free(split);
    kifmm__free(cur.a);
    kifmm__free(next.a);
    return rc;
}

/* For the 27 neighbours of the child j of in[l - 1] (j in 0 .. 8 n), the key
 * of the grandparent (level l - 2) it needs split, or UINT64_MAX where it is
 * already split or outside the cube; into need[27 j ..]. */
KIFMM__FN void kifmm__balance_needs(const kifmm__tree *t, const kifmm__keys *in, int l,
                                    int64_t j, uint64_t *need)
{
    const int64_t n0 = in[l - 2].n;
    int64_t a[3];
    int dx, dy, dz, m = 0, s;
    kifmm__decode(in[l - 1].a[j >> 3] << 3 | (uint64_t)(j & 7), a);
    for (dx = -1; dx <= 1; dx++)
        for (dy = -1; dy <= 1; dy++)
            for (dz = -1; dz <= 1; dz++) {
                /* neighbours across a periodic face wrap */
                const int64_t x = kifmm__wrap(t, 0, l, a[0] + dx, &s), y = kifmm__wrap(t, 1, l, a[1] + dy, &s);
                const int64_t z = kifmm__wrap(t, 2, l, a[2] + dz, &s);
                uint64_t g = UINT64_MAX;
                if (x >= 0 && y >= 0 && z >= 0) {
                    int64_t pos;
                    g = kifmm__encode(x, y, z) >> 6;
                    pos = kifmm__lower_bound(in[l - 2].a, n0, g);
                    if (pos < n0 && in[l - 2].a[pos] == g) g = UINT64_MAX;
                }
                need[27 * j + m++] = g;
            }
}

/* Step 4, 2:1 balance, finest level first: every neighbour of a box of level
 * l must lie in a box of level l - 1, i.e. its grandparent must split.
 * Missing grandparents are marked in parallel (one flag per box of level l
 * and neighbour), then appended in order. */
KIFMM__FN int kifmm__tree_balance(const kifmm__tree *t, kifmm__keys *in, int deepest, int nth)
{
    (void)nth; /* used by the OpenMP pragmas only */
    int l, rc = KIFMM_SUCCESS;
    for (l = deepest; l >= 2 && !rc; l--) {
        const int64_t n0 = in[l - 2].n, nb8 = 8 * in[l - 1].n;
        uint64_t *need = (uint64_t *)kifmm__alloc((size_t)nb8 * 27 + 1, sizeof(uint64_t));
        int64_t j;
        if (!need) return KIFMM_ERR_NOMEM;
        /* each j writes its own 27 entries of need */
        KIFMM__OMP(parallel for schedule(static) num_threads(nth))
        for (int64_t jj = 0; jj < nb8; jj++) kifmm__balance_needs(t, in, l, jj, need);
        for (j = 0; j < 27 * nb8 && !rc; j++)
            if (need[j] != UINT64_MAX) rc = kifmm__keys_push(&in[l - 2], need[j]);
        kifmm__free(need);
        if (!rc && in[l - 2].n > n0) kifmm__keys_unique(&in[l - 2]);
    }
    return rc;
}

/* The arrays of nbz boxes. */
KIFMM__FN int kifmm__tree_alloc_boxes(kifmm__tree *t, size_t nbz)
{
    size_t *h = &t->held;
    t->key = (uint64_t *)kifmm__take(h, nbz, sizeof(uint64_t));
    t->child = (int32_t *)kifmm__take(h, nbz, sizeof(int32_t));
    t->inner = (int32_t *)kifmm__take(h, nbz, sizeof(int32_t));
    t->parent = (int32_t *)kifmm__take(h, nbz, sizeof(int32_t));
    t->anchor = (int32_t *)kifmm__take(h, 3 * nbz, sizeof(int32_t));
    t->lev = (unsigned char *)kifmm__take(h, nbz, 1);
    t->s0 = (int64_t *)kifmm__take(h, nbz, sizeof(int64_t));
    t->s1 = (int64_t *)kifmm__take(h, nbz, sizeof(int64_t));
    t->t0 = (int64_t *)kifmm__take(h, nbz, sizeof(int64_t));
    t->t1 = (int64_t *)kifmm__take(h, nbz, sizeof(int64_t));
    return t->key && t->child && t->inner && t->parent && t->anchor && t->lev && t->s0 &&
                   t->s1 && t->t0 && t->t1
               ? KIFMM_SUCCESS
               : KIFMM_ERR_NOMEM;
}

/* Keys, children, parents and the internal boxes, level by level: the boxes
 * of level l + 1 are the 8 children of each key in in[l], in order. */
KIFMM__FN void kifmm__tree_links(kifmm__tree *t, const kifmm__keys *in)
{
    int32_t b;
    int l;
    t->loff[0] = 0;
    t->loff[1] = 1;
    t->key[0] = 0;
    t->parent[0] = -1;
    for (l = 1; l < t->nlev; l++) {
        int32_t c = t->loff[l];
        int64_t j;
        int o;
        for (j = 0; j < in[l - 1].n; j++)
            for (o = 0; o < 8; o++) t->key[c++] = in[l - 1].a[j] << 3 | (uint64_t)o;
        t->loff[l + 1] = c;
    }
    for (l = t->nlev + 1; l <= KIFMM__D + 1; l++) t->loff[l] = t->loff[t->nlev];
    t->ioff[0] = 0;
    for (l = 0; l < t->nlev; l++) {
        int64_t j = 0;
        t->ioff[l + 1] = t->ioff[l];
        for (b = t->loff[l]; b < t->loff[l + 1]; b++) {
            int o;
            while (j < in[l].n && in[l].a[j] < t->key[b]) j++;
            t->child[b] = -1;
            if (j >= in[l].n || in[l].a[j] != t->key[b]) continue;
            t->child[b] = t->loff[l + 1] + (int32_t)(8 * j);
            for (o = 0; o < 8; o++) t->parent[t->child[b] + o] = b;
            t->inner[t->ioff[l + 1]++] = b;
        }
    }
    for (l = t->nlev + 1; l <= KIFMM__D + 1; l++) t->ioff[l] = t->ioff[t->nlev];
}

/* Anchors, levels and point ranges of the boxes of level l. */
KIFMM__FN void kifmm__tree_ranges(kifmm__tree *t, int l, const uint64_t *skey,
                                  const uint64_t *tkey, int nth)
{
    (void)nth; /* used by the OpenMP pragmas only */
    const int sh = 3 * (KIFMM__D - l);
    /* each b writes its own box's entries */
    KIFMM__OMP(parallel for schedule(static) num_threads(nth))
    for (int32_t b = t->loff[l]; b < t->loff[l + 1]; b++) {
        const uint64_t k0 = t->key[b] << sh, k1 = (t->key[b] + 1) << sh;
        int64_t a[3];
        kifmm__decode(t->key[b], a);
        t->anchor[3 * (size_t)b] = (int32_t)a[0];
        t->anchor[3 * (size_t)b + 1] = (int32_t)a[1];
        t->anchor[3 * (size_t)b + 2] = (int32_t)a[2];
        t->lev[b] = (unsigned char)l;
        t->s0[b] = kifmm__lower_bound(skey, t->ns, k0);
        t->s1[b] = kifmm__lower_bound(skey, t->ns, k1);
        t->t0[b] = kifmm__lower_bound(tkey, t->nt, k0);
        t->t1[b] = kifmm__lower_bound(tkey, t->nt, k1);
    }
}

/* Above the cell (levels 1 .. kc, kc > 0) the boxes whose anchor is not 0
 * along a periodic direction hold no points: they are images of the
 * sibling at anchor 0 there (t->alias), whose upward densities they take
 * (__alias_fill) for the M2M and the M2L. */
KIFMM__FN int kifmm__tree_aliases(kifmm__tree *t)
{
    int32_t b;
    if (t->kc == 0) return KIFMM_SUCCESS;
    t->alias = (int32_t *)kifmm__take(&t->held, (size_t)t->nbox, sizeof(int32_t));
    if (!t->alias) return KIFMM_ERR_NOMEM;
    for (b = 0; b < t->nbox; b++) {
        const int l = t->lev[b];
        int64_t a[3];
        int d, img = 0;
        t->alias[b] = -1;
        if (l == 0 || l > t->kc) continue;
        for (d = 0; d < 3; d++) {
            a[d] = t->anchor[3 * (size_t)b + d];
            if (t->per[d] && a[d] != 0) img = 1, a[d] = 0;
        }
        if (img) t->alias[b] = kifmm__find(t, l, kifmm__encode(a[0], a[1], a[2]));
    }
    return KIFMM_SUCCESS;
}

/* Step 5, the boxes laid out level by level from the keys of the boxes that
 * split (in[0 .. deepest - 1]). */
KIFMM__FN int kifmm__tree_layout(kifmm__tree *t, const kifmm__keys *in, int deepest,
                                 const uint64_t *skey, const uint64_t *tkey, int nth)
{
    int64_t total = 1;
    int l, rc;
    for (l = 0; l < deepest; l++) total += 8 * in[l].n;
    if (total > INT32_MAX / 8) return KIFMM_ERR_NOMEM;
    t->nlev = deepest + 1;
    t->nbox = (int32_t)total;
    if ((rc = kifmm__tree_alloc_boxes(t, (size_t)total))) return rc;
    kifmm__tree_links(t, in);
    for (l = 0; l < t->nlev; l++) kifmm__tree_ranges(t, l, skey, tkey, nth);
    return kifmm__tree_aliases(t);
}

KIFMM__FN int kifmm__tree_lists(kifmm__tree *t, int nth, int vlists); /* >>lists */

/* The tree over these points: bounds, sorted points, refinement while a box
 * holds more than `leaf` sources or targets, 2:1 balance, layout, then the
 * interaction lists (kifmm__tree_lists, with V entries if vlists). */
KIFMM__FN int kifmm__tree_build(kifmm__tree *t, int64_t ns, const double *src, int64_t nt,
                                const double *trg, int leaf, int maxdepth, int nth, int vlists,
                                const double *period, const double *domain)
{
    uint64_t *skey = NULL, *tkey = NULL;
    kifmm__keys in[KIFMM__D + 1];
    int l, rc, deepest = 0;
    memset(in, 0, sizeof in);
    memset(t, 0, sizeof *t);
    t->ns = ns;
    t->nt = nt;
    for (l = 0; l < 3 && period; l++)
        if (period[l] > 0.0) {
            t->per[l] = t->periodic = 1;
            t->width = t->cell = period[l];
        }
    rc = kifmm__tree_bounds(t, ns, src, nt, trg, nth, domain);
    /* levels count from the cell */
    if (maxdepth + t->kc < KIFMM__D) maxdepth += t->kc;
    else maxdepth = KIFMM__D;
    if (!rc) rc = kifmm__tree_sort(t, ns, src, nt, trg, nth, &skey, &tkey);
    if (!rc) rc = kifmm__tree_refine(t, skey, tkey, leaf, maxdepth, nth, in);
    for (l = 0; l <= KIFMM__D; l++)
        if (in[l].n > 0) deepest = l + 1;
    if (!rc) rc = kifmm__tree_balance(t, in, deepest, nth);
    if (!rc) rc = kifmm__tree_layout(t, in, deepest, skey, tkey, nth);
    if (!rc) rc = kifmm__tree_lists(t, nth, vlists);
    for (l = 0; l <= KIFMM__D; l++) kifmm__free(in[l].a);
    kifmm__free(skey);
    if (tkey != skey) kifmm__free(tkey);
    return rc;
}
/* ---- transfer vectors ----------------------------------------------------- */

#define KIFMM__NT 316 /* M2L transfer vectors: 7^3 - 3^3 */

/* The near offsets (-1, 0 or 1: 3 of them) lexicographically before v in
 * [-3, 3]. */
#define KIFMM__CL3(v) ((v) < -1 ? 0 : (v) > 1 ? 3 : (v) + 1)

/* Index of the transfer vector (dx, dy, dz), each in [-3, 3] and not all in
 * [-1, 1], among the 316 in lexicographic order: minus the near offsets
 * (all |d| <= 1) before it, 9 per near x-slab before dx, 3 per near row
 * before dy in the same slab, then the near cells before dz in its row. */
KIFMM__FN int kifmm__transfer_index(int dx, int dy, int dz)
{
    int near = 9 * KIFMM__CL3(dx);
    if (dx >= -1 && dx <= 1) {
        near += 3 * KIFMM__CL3(dy);
        if (dy >= -1 && dy <= 1) near += KIFMM__CL3(dz);
    }
    return (dx + 3) * 49 + (dy + 3) * 7 + (dz + 3) - near;
}

KIFMM__FN void kifmm__transfer_vector(int t, int *d)
{
    int c = 0, i, j, k;
    for (i = -3; i <= 3; i++)
        for (j = -3; j <= 3; j++)
            for (k = -3; k <= 3; k++) {
                if (i >= -1 && i <= 1 && j >= -1 && j <= 1 && k >= -1 && k <= 1) continue;
                if (c++ == t) { d[0] = i; d[1] = j; d[2] = k; return; }
            }
}


// >>lists

/* ---- the interaction lists of one box ----------------------------------- */

/* The lists of one box: entries with their images (shift codes; all
 * KIFMM__NOSHIFT in free space) and the V entries' transfer vectors. */
typedef struct {
    int32_t u[KIFMM__MAXU], v[KIFMM__MAXV], w[KIFMM__MAXW], x[KIFMM__MAXX];
    unsigned char us[KIFMM__MAXU], ws[KIFMM__MAXW], xs[KIFMM__MAXX];
    uint16_t vt[KIFMM__MAXV];
    int nu, nv, nw, nx, overflow;
} kifmm__lists;

/* Append image s of box b to a list (and its shifts sh), once if dedupe. */
KIFMM__FN void kifmm__add(int32_t *list, unsigned char *sh, int *n, int cap, int32_t b, int s,
                          int *overflow, int dedupe)
{
    int i;
    if (dedupe)
        for (i = 0; i < *n; i++)
            if (list[i] == b && sh[i] == s) return;
    if (*n >= cap) { *overflow = 1; return; }
    sh[*n] = (unsigned char)s;
    list[(*n)++] = b;
}

/* U and W of leaf b from image s of box c, a colleague of b or a
 * descendant of one: adjacent leaves go to U, adjacent internal boxes are
 * opened, and boxes not adjacent to b (whose parent is) go to W. */
KIFMM__FN void kifmm__collect_uw(const kifmm__tree *t, int32_t b, int32_t c, int s, kifmm__lists *L)
{
    if (t->s1[c] == t->s0[c]) return;
    if (kifmm__adjacent_s(t, b, c, s)) {
        int o;
        if (t->child[c] < 0) {
            kifmm__add(L->u, L->us, &L->nu, KIFMM__MAXU, c, s, &L->overflow, 0);
            return;
        }
        for (o = 0; o < 8; o++) kifmm__collect_uw(t, b, t->child[c] + o, s, L);
    } else {
        kifmm__add(L->w, L->ws, &L->nw, KIFMM__MAXW, c, s, &L->overflow, 0);
    }
}

/* The box of level l at anchor a + (dx, dy, dz), wrapped across periodic
 * faces (*s: the image's shift code): its index, -1 if none of level l is
 * there (*k: the key to look for a coarser one), -2 outside the cell in a
 * free direction. */
KIFMM__FN int32_t kifmm__box_at(const kifmm__tree *t, int l, const int64_t *a, int dx, int dy,
                                int dz, uint64_t *k, int *s)
{
    int sh[3];
    const int64_t x = kifmm__wrap(t, 0, l, a[0] + dx, &sh[0]);
    const int64_t y = kifmm__wrap(t, 1, l, a[1] + dy, &sh[1]);
    const int64_t z = kifmm__wrap(t, 2, l, a[2] + dz, &sh[2]);
    if (x < 0 || y < 0 || z < 0) return -2;
    *s = kifmm__shift_code(sh);
    *k = kifmm__encode(x, y, z);
    return kifmm__find(t, l, *k);
}

/* U and W of leaf b: its colleagues and their descendants (kifmm__collect_uw),
 * and the coarser leaves that touch it. */
KIFMM__FN void kifmm__near_lists(const kifmm__tree *t, int32_t b, kifmm__lists *L)
{
    const int l = kifmm__level_of(t, b);
    const int32_t *ab = t->anchor + 3 * (size_t)b;
    const int64_t a[3] = {ab[0], ab[1], ab[2]};
    int dx, dy, dz, s = KIFMM__NOSHIFT;
    for (dx = -1; dx <= 1; dx++)
        for (dy = -1; dy <= 1; dy++)
            for (dz = -1; dz <= 1; dz++) {
                uint64_t k = 0;
                int32_t c = kifmm__box_at(t, l, a, dx, dy, dz, &k, &s);
                if (c >= 0) {
                    kifmm__collect_uw(t, b, c, s, L);
                } else if (c == -1) {
                    /* inside a coarser leaf, which touches b */
                    c = kifmm__find_cover(t, l, k);
                    if (c >= 0 && t->s1[c] > t->s0[c])
                        kifmm__add(L->u, L->us, &L->nu, KIFMM__MAXU, c, s, &L->overflow, 1);
                }
            }
}

/* V and X of box b: the children of its parent's colleagues that are apart
 * from b (V, with their transfer vectors), and leaves of the parent's level
 * or coarser that are apart from b (X). */
KIFMM__FN void kifmm__far_lists(const kifmm__tree *t, int32_t b, kifmm__lists *L)
{
    const int l = kifmm__level_of(t, b);
    const int32_t *ab = t->anchor + 3 * (size_t)b;
    const int64_t a[3] = {ab[0], ab[1], ab[2]}, pa[3] = {a[0] >> 1, a[1] >> 1, a[2] >> 1};
    const int32_t pu = kifmm__period_units(t, l - 1), fl = KIFMM__D - l;
    int dx, dy, dz, o, d, s = KIFMM__NOSHIFT, sh[3];
    for (dx = -1; dx <= 1; dx++)
        for (dy = -1; dy <= 1; dy++)
            for (dz = -1; dz <= 1; dz++) {
                uint64_t k = 0;
                int32_t c = kifmm__box_at(t, l - 1, pa, dx, dy, dz, &k, &s), off[3];
                if (c == -2) continue;
                kifmm__shift_of(s, sh);
                for (d = 0; d < 3; d++) off[d] = sh[d] * pu; /* the image, finest units */
                if (c >= 0 && t->child[c] >= 0) {
                    /* above the cell (kc > 0) children of c that hold no
                     * points can be images of their siblings (has_src) */
                    for (o = 0; o < 8; o++) {
                        const int32_t v = t->child[c] + o;
                        const int32_t *va = t->anchor + 3 * (size_t)v;
                        if (!kifmm__has_src(t, v) || kifmm__adjacent_o(t, b, v, off)) continue;
                        if (L->nv >= KIFMM__MAXV) { L->overflow = 1; continue; }
                        /* the transfer vector to the image */
                        L->vt[L->nv] = (uint16_t)kifmm__transfer_index(
                            (int)(va[0] + (off[0] >> fl) - a[0]), (int)(va[1] + (off[1] >> fl) - a[1]),
                            (int)(va[2] + (off[2] >> fl) - a[2]));
                        L->v[L->nv++] = v;
                    }
                    continue;
                }
                /* a leaf of the parent's level or coarser: X if apart from b
                 * (never above the cell, where boxes with points split) */
                if (c < 0) c = kifmm__find_cover(t, l - 1, k);
                if (c >= 0 && t->s1[c] > t->s0[c] && !kifmm__adjacent_o(t, b, c, off)) {
                    if (l - 1 < t->kc) L->overflow = 1;
                    else kifmm__add(L->x, L->xs, &L->nx, KIFMM__MAXX, c, s, &L->overflow, 1);
                }
            }
}

/* All four lists of box b (U and W only when b is a leaf). Only boxes that
 * hold sources enter a list. */
KIFMM__FN void kifmm__box_lists(const kifmm__tree *t, int32_t b, kifmm__lists *L)
{
    L->nu = L->nv = L->nw = L->nx = L->overflow = 0;
    if (t->child[b] < 0) kifmm__near_lists(t, b, L);
    if (kifmm__level_of(t, b) >= 1) kifmm__far_lists(t, b, L);
}

/* ---- the lists of all boxes ----------------------------------------------- */

/* The lists of a range of boxes, appended in box order: U, V, W, X, with
 * the transfer vectors of V (vt) and, in periodic trees, the shift codes of
 * U, W and X (sh[j]), growing by doubling. */
typedef struct {
    int32_t *a[4];
    uint16_t *vt;
    unsigned char *sh[4];
    size_t n[4], cap[4];
    int fail;
} kifmm__lbuf;

/* Grow array *p of n elements of size sz to cap of them; 0 if out of memory. */
KIFMM__FN int kifmm__grow(void **p, size_t n, size_t cap, size_t sz)
{
    void *a = kifmm__alloc(cap, sz);
    if (!a) return 0;
    if (n) memcpy(a, *p, n * sz);
    kifmm__free(*p);
    *p = a;
    return 1;
}

KIFMM__FN void kifmm__lbuf_put(kifmm__lbuf *B, int j, const int32_t *src, int cnt,
                               const uint16_t *vt, const unsigned char *sh)
{
    if (B->fail || cnt == 0) return;
    if (B->n[j] + (size_t)cnt > B->cap[j]) {
        size_t cap = 2 * (B->n[j] + (size_t)cnt) + 256;
        int ok = kifmm__grow((void **)&B->a[j], B->n[j], cap, sizeof(int32_t));
        if (ok && vt) ok = kifmm__grow((void **)&B->vt, B->n[j], cap, sizeof(uint16_t));
        if (ok && sh) ok = kifmm__grow((void **)&B->sh[j], B->n[j], cap, 1);
        if (!ok) { B->fail = 1; return; }
        B->cap[j] = cap;
    }
    memcpy(B->a[j] + B->n[j], src, (size_t)cnt * sizeof(int32_t));
    if (vt) memcpy(B->vt + B->n[j], vt, (size_t)cnt * sizeof(uint16_t));
    if (sh) memcpy(B->sh[j] + B->n[j], sh, (size_t)cnt);
    B->n[j] += (size_t)cnt;
}


/* A direct index (key -> box) for the levels where it costs at most 8
 * entries per box (all of them in a uniform tree): a neighbour found in one
 * load instead of a binary search (tree 0.19-0.21 s -> 0.15-0.17 s at 1M
 * uniform points); the other levels, and all of them if the index cannot be
 * allocated, search. Freed (t->dix = NULL) once the lists are built. */
KIFMM__FN void kifmm__lists_index(kifmm__tree *t, int nth)
{
    (void)nth; /* used by the OpenMP pragmas only */
    int64_t tot = 0;
    int32_t b;
    int l;
    for (l = 0; l < t->nlev; l++) {
        const int64_t full = (int64_t)1 << (3 * l), nl = t->loff[l + 1] - t->loff[l];
        t->dixo[l] = l <= 10 && full <= 8 * nl + 4096 ? tot : -1;
        if (t->dixo[l] >= 0) tot += full;
    }
    t->dix = tot > 0 ? (int32_t *)kifmm__alloc((size_t)tot, sizeof(int32_t)) : NULL;
    if (!t->dix) return;
    /* each e sets its own entry */
    KIFMM__OMP(parallel for schedule(static) num_threads(nth))
    for (int64_t e = 0; e < tot; e++) t->dix[e] = -1;
    for (l = 0; l < t->nlev; l++)
        if (t->dixo[l] >= 0)
            for (b = t->loff[l]; b < t->loff[l + 1]; b++) t->dix[t->dixo[l] + (int64_t)t->key[b]] = b;
}

/* Pass 1: the lists of every box with targets, in nk chunks of consecutive
 * boxes (many more than threads, for balance), each collected in buffer
 * buf[k]; the counts per box into t->uo .. t->xo[b + 1]. The V entries are
 * kept only if vlists (the dense M2L reads them; the FFT M2L works from the
 * colleagues and needs only their counts). Returns nonzero if a list
 * overflowed its cap. */
KIFMM__FN int kifmm__lists_collect(kifmm__tree *t, int nth, int vlists, int32_t nk,
                                   kifmm__lbuf *buf)
{
    (void)nth; /* used by the OpenMP pragmas only */
    const int32_t nb = t->nbox;
    int overflow = 0;
    /* chunk k writes its own buffer and the counts of its own boxes */
    KIFMM__OMP(parallel for schedule(dynamic, 1) num_threads(nth) reduction(| : overflow))
    for (int32_t k = 0; k < nk; k++) {
        const int32_t b0 = (int32_t)((int64_t)nb * k / nk), b1 = (int32_t)((int64_t)nb * (k + 1) / nk);
        int32_t c;
        for (c = b0; c < b1; c++) {
            kifmm__lists L;
            if (t->t1[c] == t->t0[c]) continue;
            kifmm__box_lists(t, c, &L);
            overflow |= L.overflow;
            t->uo[c + 1] = L.nu;
            t->vo[c + 1] = L.nv;
            t->wo[c + 1] = L.nw;
            t->xo[c + 1] = L.nx;
            kifmm__lbuf_put(&buf[k], 0, L.u, L.nu, NULL, t->periodic ? L.us : NULL);
            if (vlists) kifmm__lbuf_put(&buf[k], 1, L.v, L.nv, L.vt, NULL);
            kifmm__lbuf_put(&buf[k], 2, L.w, L.nw, NULL, t->periodic ? L.ws : NULL);
            kifmm__lbuf_put(&buf[k], 3, L.x, L.nx, NULL, t->periodic ? L.xs : NULL);
        }
    }
    return overflow;
}

/* Pass 2: counts -> offsets, and each chunk's lists copied into place. */
KIFMM__FN int kifmm__lists_assemble(kifmm__tree *t, int nth, int vlists, int32_t nk,
                                    const kifmm__lbuf *buf)
{
    (void)nth; /* used by the OpenMP pragmas only */
    const int32_t nb = t->nbox;
    int32_t *off[4], *dst[4], b;
    unsigned char *sdst[4];
    int j;
    off[0] = t->uo; off[1] = t->vo; off[2] = t->wo; off[3] = t->xo;
    for (j = 0; j < 4; j++)
        for (b = 0; b < nb; b++) off[j][b + 1] += off[j][b];
    t->u = (int32_t *)kifmm__take(&t->held, (size_t)t->uo[nb] + 1, sizeof(int32_t));
    if (vlists) {
        t->v = (int32_t *)kifmm__take(&t->held, (size_t)t->vo[nb] + 1, sizeof(int32_t));
        t->vt = (uint16_t *)kifmm__take(&t->held, (size_t)t->vo[nb] + 1, sizeof(uint16_t));
    }
    t->w = (int32_t *)kifmm__take(&t->held, (size_t)t->wo[nb] + 1, sizeof(int32_t));
    t->x = (int32_t *)kifmm__take(&t->held, (size_t)t->xo[nb] + 1, sizeof(int32_t));
    if (!t->u || (vlists && (!t->v || !t->vt)) || !t->w || !t->x) return KIFMM_ERR_NOMEM;
    if (t->periodic) {
        t->us = (unsigned char *)kifmm__take(&t->held, (size_t)t->uo[nb] + 1, 1);
        t->ws = (unsigned char *)kifmm__take(&t->held, (size_t)t->wo[nb] + 1, 1);
        t->xs = (unsigned char *)kifmm__take(&t->held, (size_t)t->xo[nb] + 1, 1);
        if (!t->us || !t->ws || !t->xs) return KIFMM_ERR_NOMEM;
    }
    dst[0] = t->u; dst[1] = t->v; dst[2] = t->w; dst[3] = t->x;
    sdst[0] = t->us; sdst[1] = NULL; sdst[2] = t->ws; sdst[3] = t->xs;
    /* chunk k copies into its own boxes' ranges */
    KIFMM__OMP(parallel for schedule(static) num_threads(nth))
    for (int32_t k = 0; k < nk; k++) {
        const int32_t b0 = (int32_t)((int64_t)nb * k / nk);
        int m;
        for (m = 0; m < 4; m++) {
            if (buf[k].n[m]) memcpy(dst[m] + off[m][b0], buf[k].a[m], buf[k].n[m] * sizeof(int32_t));
            if (buf[k].n[m] && sdst[m]) memcpy(sdst[m] + off[m][b0], buf[k].sh[m], buf[k].n[m]);
        }
        if (buf[k].n[1]) memcpy(t->vt + t->vo[b0], buf[k].vt, buf[k].n[1] * sizeof(uint16_t));
    }
    return KIFMM_SUCCESS;
}

/* dsrc (one per box): a box refits a local expansion only where its own level brings
 * new far-field content: a V list, or an X list when the box holds at least
 * `xdirect` targets (boxes with fewer take their X sources directly), or,
 * in a periodic tree, the far images (the root, and the boxes of level
 * `flev`).
 * Elsewhere it keeps its ancestor's, which is evaluated directly: a refit
 * adds an error of the fit order relative to the whole local field on the
 * box's own scale, which along a chain of boxes down to an isolated cluster
 * would swamp its gradient. */
KIFMM__FN void kifmm__tree_dsrc(const kifmm__tree *t, int32_t *dsrc, int64_t xdirect, int flev)
{
    int32_t b;
    for (b = 0; b < t->nbox; b++) {
        int fresh = t->vo[b + 1] > t->vo[b] || (t->periodic && (b == 0 || t->lev[b] == flev)) ||
                    (t->xo[b + 1] > t->xo[b] && t->t1[b] - t->t0[b] >= xdirect);
        if (b < t->loff[kifmm__lmin(t) < t->nlev ? kifmm__lmin(t) : t->nlev]) dsrc[b] = -1;
        else if (fresh) dsrc[b] = b;
        else dsrc[b] = dsrc[t->parent[b]];
    }
}

/* What the passes derive from the lists: per level, the boxes that receive
 * M2L (m2l, from m2lo[l]); the leaves with targets in Morton order (depth
 * first, children in key order, which is the order of their points). Which
 * box's local expansion serves each box depends on the handle's check
 * surface: the handle's (kifmm__tree_dsrc). */
KIFMM__FN int kifmm__lists_derived(kifmm__tree *t)
{
    const int32_t nb = t->nbox;
    int32_t b, stk[8 * (KIFMM__D + 2)], sp = 0;
    int l, o;
    t->m2lo = (int32_t *)kifmm__takez(&t->held, (size_t)t->nlev + 1, sizeof(int32_t));
    t->m2l = (int32_t *)kifmm__take(&t->held, (size_t)nb + 1, sizeof(int32_t));
    t->leaves = (int32_t *)kifmm__take(&t->held, (size_t)nb + 1, sizeof(int32_t));
    if (!t->m2lo || !t->m2l || !t->leaves) return KIFMM_ERR_NOMEM;
    for (l = 0; l < t->nlev; l++) {
        t->m2lo[l + 1] = t->m2lo[l];
        for (b = t->loff[l]; b < t->loff[l + 1]; b++)
            if (t->vo[b + 1] > t->vo[b]) t->m2l[t->m2lo[l + 1]++] = b;
    }
    t->nleaves = 0;
    if (nb > 0) stk[sp++] = 0;
    while (sp > 0) {
        b = stk[--sp];
        if (t->t1[b] == t->t0[b]) continue;
        if (t->child[b] < 0) t->leaves[t->nleaves++] = b;
        else
            for (o = 7; o >= 0; o--) stk[sp++] = t->child[b] + o;
    }
    return KIFMM_SUCCESS;
}

/* The lists of every box with targets (U, V, W, X as offsets and entries),
 * then what the passes derive from them. */
KIFMM__FN int kifmm__tree_lists(kifmm__tree *t, int nth, int vlists)
{
    const int32_t nb = t->nbox;
    int32_t nk = 16 * (nth > 0 ? nth : 1), k;
    int rc = KIFMM_SUCCESS, j;
    kifmm__lbuf *buf;
    if (nb < 1) return KIFMM_ERR_INTERNAL; /* a tree has its root (and gcc's
                                              -Wstringop-overflow then knows nb + 1 > 0) */
    if (nk > nb) nk = nb;
    t->uo = (int32_t *)kifmm__takez(&t->held, (size_t)nb + 1, sizeof(int32_t));
    t->vo = (int32_t *)kifmm__takez(&t->held, (size_t)nb + 1, sizeof(int32_t));
    t->wo = (int32_t *)kifmm__takez(&t->held, (size_t)nb + 1, sizeof(int32_t));
    t->xo = (int32_t *)kifmm__takez(&t->held, (size_t)nb + 1, sizeof(int32_t));
    buf = (kifmm__lbuf *)kifmm__calloc((size_t)nk, sizeof(kifmm__lbuf));
    if (!t->uo || !t->vo || !t->wo || !t->xo || !buf) {
        kifmm__free(buf);
        return KIFMM_ERR_NOMEM;
    }
    kifmm__lists_index(t, nth);
    if (kifmm__lists_collect(t, nth, vlists, nk, buf)) rc = KIFMM_ERR_INTERNAL;
    kifmm__free(t->dix);
    t->dix = NULL;
    for (k = 0; k < nk && !rc; k++)
        if (buf[k].fail) rc = KIFMM_ERR_NOMEM;
    if (!rc) rc = kifmm__lists_assemble(t, nth, vlists, nk, buf);
    for (k = 0; k < nk; k++) {
        for (j = 0; j < 4; j++) {
            kifmm__free(buf[k].a[j]);
            kifmm__free(buf[k].sh[j]);
        }
        kifmm__free(buf[k].vt);
    }
    kifmm__free(buf);
    return rc ? rc : kifmm__lists_derived(t);
}

/* Internal neighbours ("colleagues") of every internal box of level l - 1,
 * for the M2L into level l: for the j-th internal box of level l - 1, the
 * internal indices (relative to the level) of its adjacent internal boxes
 * at that level and their offset codes (not 13, the box itself). CSR over
 * all internal boxes in the order of t->inner. */
KIFMM__FN int kifmm__colleagues(const kifmm__tree *t, int nth, size_t *held, int32_t **co_out,
                                int32_t **cj_out, unsigned char **cc_out)
{
    int32_t ni = t->ioff[t->nlev], i, *co, *cj;
    unsigned char *cc;
    int pass;
    co = (int32_t *)kifmm__takez(held, (size_t)ni + 1, sizeof(int32_t));
    cj = (int32_t *)kifmm__take(held, (size_t)ni * 26 + 1, sizeof(int32_t));
    cc = (unsigned char *)kifmm__take(held, (size_t)ni * 26 + 1, 1);
    *co_out = co; *cj_out = cj; *cc_out = cc;
    if (!co || !cj || !cc) return KIFMM_ERR_NOMEM;
    (void)nth;
    for (pass = 0; pass < 2; pass++) {
        KIFMM__OMP(parallel for schedule(static) num_threads(nth))
        for (int32_t i = 0; i < ni; i++) {
            int32_t p = t->inner[i], m = 0;
            int l = t->lev[p], o, s;
            const int32_t *ap = t->anchor + 3 * (size_t)p;
            const int64_t a[3] = {ap[0], ap[1], ap[2]};
            for (o = 0; o < 27; o++) {
                /* o: the offset code; across a periodic face the colleague is
                 * a wrapped box's image, the offset that of the image */
                uint64_t k = 0;
                int32_t q = o == 13 ? -2 : kifmm__box_at(t, l, a, o / 9 - 1, o / 3 % 3 - 1, o % 3 - 1, &k, &s);
                if (q < 0 || t->child[q] < 0) continue;
                if (pass == 1) {
                    cj[co[i] + m] = (t->child[q] - t->loff[l + 1]) / 8;
                    cc[co[i] + m] = (unsigned char)o;
                }
                m++;
            }
            if (pass == 0) co[i + 1] = m;
        }
        if (pass == 0)
            for (i = 0; i < ni; i++) co[i + 1] += co[i];
    }
    return KIFMM_SUCCESS;
}

/* The most sources or targets in one leaf. */
KIFMM__FN int64_t kifmm__max_leaf(const kifmm__tree *t)
{
    int64_t m = 0;
    int32_t b;
    for (b = 0; b < t->nbox; b++) {
        if (t->child[b] >= 0) continue;
        if (t->s1[b] - t->s0[b] > m) m = t->s1[b] - t->s0[b];
        if (t->t1[b] - t->t0[b] > m) m = t->t1[b] - t->t0[b];
    }
    return m;
}

KIFMM__FN int kifmm__max_level_boxes(const kifmm__tree *t)
{
    int l, m = 1;
    for (l = 0; l < t->nlev; l++)
        if (t->loff[l + 1] - t->loff[l] > m) m = t->loff[l + 1] - t->loff[l];
    return m;
}

/* The boxes the equivalent-density solves visit: a[loff[l] ..] lists, by
 * index within level l, its boxes with sources (the upward solve: the others'
 * check potentials are zero), a[nbox + loff[l] ..] those with targets (the
 * downward solve: no target reads the others' local expansions), and
 * a[2 nbox + 2 l] and a[2 nbox + 2 l + 1] count them. On surfaces and in
 * clusters about half the boxes are empty. NULL if out of memory. */
KIFMM__FN int32_t *kifmm__active(const kifmm__tree *t, size_t *held)
{
    int32_t *a = (int32_t *)kifmm__take(held, 2 * (size_t)t->nbox + 2 * (size_t)t->nlev,
                                         sizeof(int32_t));
    int l;
    if (!a) return NULL;
    for (l = 0; l < t->nlev; l++) {
        int32_t b, nu = 0, nd = 0, o = t->loff[l];
        for (b = o; b < t->loff[l + 1]; b++) {
            if (t->s1[b] > t->s0[b]) a[o + nu++] = b - o;
            if (t->t1[b] > t->t0[b]) a[t->nbox + o + nd++] = b - o;
        }
        a[2 * t->nbox + 2 * l] = nu;
        a[2 * t->nbox + 2 * l + 1] = nd;
    }
    return a;
}

/* ---- the tree expected of points spread through a cube (estimate_bytes) -- */

/* P(N > s) for N Poisson with mean mu: one less the terms k = 0 .. s, each
 * from the one before in logs, stopped once past the mean they no longer
 * count; above a mean of 10^4, the normal law's tail (at most about 10^4
 * terms whatever s). */
KIFMM__FN double kifmm__poisson_above(double mu, int64_t s)
{
    double lt = -mu, sum = 0.0;
    int64_t k;
    if (!(mu > 0.0)) return 0.0;
    if (mu > 1e4) return 0.5 * erfc(((double)s + 0.5 - mu) / sqrt(2.0 * mu));
    for (k = 0; k <= s; k++) {
        const double term = exp(lt);
        sum += term;
        if ((double)k > mu && term < 1e-17 * sum) break;
        lt += log(mu / (double)(k + 1));
    }
    return sum >= 1.0 ? 0.0 : 1.0 - sum;
}

/* Expected figures of a tree (see kifmm__shape_uniform). */
typedef struct {
    double box, inner;       /* boxes, internal boxes */
    double u, v;             /* U list entries (leaves with targets), V list entries */
    double vlev, vany;       /* levels with V lists (how many, whether any), from the
                                chance that two colleagues of the level above split */
    double mb, mi, mc;       /* most boxes of a level; most internal boxes of a level
                                from 1 (0 periodic) to the last but one, and their
                                colleague entries */
    double maxleaf;          /* most sources or targets of a leaf */
    int nlev;
} kifmm__shape;

/* Neighbours of a box of a full level of m^3 boxes (itself included), and
 * children of its parent's neighbours (V candidates, adjacent ones included),
 * on average: per direction 3 - 2 / m and 6 - 8 / m, 3 and 6 across a
 * periodic one. */
KIFMM__FN void kifmm__shape_lists(double m, const int *per, double *fu, double *fv)
{
    int d;
    *fu = *fv = 1.0;
    for (d = 0; d < 3; d++) {
        *fu *= per[d] ? 3.0 : 3.0 - 2.0 / m;
        *fv *= per[d] || m < 2.0 ? 6.0 : 6.0 - 8.0 / m;
    }
}

/* The tree of ns sources and nt targets spread uniformly through a cube
 * (the targets the sources if same). A box of level l holds Poisson(ns /
 * 8^l) sources and Poisson(nt / 8^l) targets, and splits with probability q
 * that one count is above leaf; a box that holds that many has a parent
 * that does, so the level has 8^l q boxes that split and the next 8 times
 * as many boxes. Levels are kept while they expect half a box. */
KIFMM__FN void kifmm__shape_uniform(int64_t ns, int64_t nt, int same, int leaf, int maxdepth,
                                    const int *per, kifmm__shape *s)
{
    const int lv = per[0] || per[1] || per[2] ? 0 : 2; /* V lists from here (kifmm__lmin) */
    double at = 1.0, qp = 1.0, pairs = 0.0, fu, fv;
    int l;
    memset(s, 0, sizeof *s);
    s->maxleaf = (double)leaf;
    for (l = 0; l <= maxdepth && at >= 0.5; l++) {
        const double cells = ldexp(1.0, 3 * l);
        const double ps = kifmm__poisson_above((double)ns / cells, leaf);
        const double pt = same ? 0.0 : kifmm__poisson_above((double)nt / cells, leaf);
        const double split = l < maxdepth ? cells * (1.0 - (1.0 - ps) * (1.0 - pt)) : 0.0;
        const double leaves = (at - split) * (1.0 - exp(-(double)nt / cells));
        kifmm__shape_lists(ldexp(1.0, l), per, &fu, &fv);
        s->nlev = l + 1;
        s->box += at;
        s->inner += split;
        s->u += leaves * fu;
        if (l >= lv) {
            s->v += at * (fv - fu) * qp;
            s->vlev += 1.0 - exp(-pairs);
            s->vany += pairs;
        }
        pairs = 0.5 * split * (split / cells) * (fu - 1.0); /* pairs of colleagues that split */
        if (at > s->mb) s->mb = at;
        if (l >= (lv ? 1 : 0) && split >= 0.5 && split > s->mi) {
            s->mi = split;
            s->mc = split * (fu - 1.0);
        }
        if (l == maxdepth && (double)ns / cells > s->maxleaf) s->maxleaf = (double)ns / cells;
        qp = split / cells;
        at = 8.0 * split;
    }
    s->vany = 1.0 - exp(-s->vany);
}

// >>surfaces

/* Number of points on the surface of a p x p x p grid: 6 (p-1)^2 + 2. */
KIFMM__FN int kifmm__surf_count(int p) { return 6 * (p - 1) * (p - 1) + 2; }

/* The surface grid points on [-1, 1]^3, structure of arrays (x[n], y[n], z[n]). */
/* Is lattice point (i, j, k) of an order-p cube lattice on its surface? */
KIFMM__FN int kifmm__surf_on(int p, int i, int j, int k)
{
    return i == 0 || i == p - 1 || j == 0 || j == p - 1 || k == 0 || k == p - 1;
}

KIFMM__FN void kifmm__surf_unit(int p, double *s)
{
    int n = kifmm__surf_count(p), c = 0, i, j, k;
    for (i = 0; i < p; i++)
        for (j = 0; j < p; j++)
            for (k = 0; k < p; k++) {
                if (!kifmm__surf_on(p, i, j, k)) continue;
                s[c] = -1.0 + 2.0 * i / (p - 1);
                s[n + c] = -1.0 + 2.0 * j / (p - 1);
                s[2 * n + c] = -1.0 + 2.0 * k / (p - 1);
                c++;
            }
}

/* The cube's 48 symmetries, g(x)_d = s_d x_perm(d): perm kifmm__perm3[g >> 3]
 * (sign kifmm__perm3_sign), s_d = -1 where bit d of g is set. A kernel
 * matrix between two cube surfaces (kifmm__surf_unit, one centre) of a
 * kernel of |x - y| alone (KIFMM__FRADIAL: laplace, yukawa, helmholtz's
 * complex pairs) is unchanged when both surfaces' points move by any g. In
 * bases of the two surfaces adapted to the group (each the ranges of the
 * projectors (d / 48) sum_g chi(g) g of its 10 irreducible
 * representations) the matrix is block diagonal, one block per
 * representation (Schur's lemma), and its singular values are those of the
 * blocks: kifmm__pinv_cube. */
static const int kifmm__perm3[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
static const int kifmm__perm3_sign[6] = {1, -1, -1, 1, 1, -1};

/* The character of representation rho (0..4: A1, A2, E, T1, T2 of the
 * rotations, even under the inversion; 5..9 the same, odd) at g: from the
 * class of the rotation det(g) g, told by its trace (3: E, 0: C3, 1: C4,
 * -1: C4^2 if it permutes no axes, else C2'). */
KIFMM__FN double kifmm__cube_chi(int rho, int g)
{
    static const signed char chi[5][5] = {
        {1, 1, 1, 1, 1}, {1, 1, 1, -1, -1}, {2, -1, 2, 0, 0}, {3, 0, -1, 1, -1}, {3, 0, -1, -1, 1}};
    const int *pm = kifmm__perm3[g >> 3];
    int d, tr = 0, det = kifmm__perm3_sign[g >> 3], cls;
    for (d = 0; d < 3; d++) {
        const int s = g >> d & 1 ? -1 : 1;
        det *= s;
        if (pm[d] == d) tr += s;
    }
    tr *= det;
    cls = tr == 3 ? 0 : tr == 0 ? 1 : tr == 1 ? 3 : g >> 3 == 0 ? 2 : 4;
    return chi[rho % 5][cls] * (det < 0 && rho >= 5 ? -1.0 : 1.0);
}

/* The symmetry-adapted orthonormal basis Q (n x n) of the order-p unit
 * surface's n points, orbit by orbit: orbit o holds points pts[ost[o] ..
 * ost[o + 1]) (s of them) and s of Q's columns, nonzero on those points
 * alone: W_o (s x s, column major, at w + wo[o]), its column t being Q's
 * column col[ost[o] + t]. Q's columns are in representation order, cnt[rho]
 * of them for representation rho. */
typedef struct kifmm__symb {
    int n, no, cnt[10];
    int *ost, *pts, *col;
    size_t *wo;
    double *w;
} kifmm__symb;

KIFMM__FN void kifmm__symb_free(kifmm__symb *b)
{
    kifmm__free(b->ost), kifmm__free(b->pts), kifmm__free(b->col), kifmm__free(b->wo), kifmm__free(b->w);
    b->ost = b->pts = b->col = NULL, b->wo = NULL, b->w = NULL;
}

/* img[(g - g0) n + i]: the index of symmetry g (g0 <= g < g0 + ng) applied
 * to point i of the order-p unit surface (n points, kifmm__surf_unit's
 * order) */
KIFMM__FN int kifmm__surf_images(int p, int g0, int ng, int *img)
{
    const int n = kifmm__surf_count(p);
    int *at = (int *)kifmm__alloc((size_t)p * p * p + 3 * (size_t)n, sizeof(int)), *cr, c = 0, i, j, k, g;
    if (!at) return KIFMM_ERR_NOMEM;
    cr = at + (size_t)p * p * p;
    for (i = 0; i < p; i++)
        for (j = 0; j < p; j++)
            for (k = 0; k < p; k++)
                if (kifmm__surf_on(p, i, j, k)) {
                    at[(i * p + j) * p + k] = c;
                    cr[3 * c] = 2 * i - (p - 1), cr[3 * c + 1] = 2 * j - (p - 1), cr[3 * c + 2] = 2 * k - (p - 1);
                    c++;
                }
    for (g = g0; g < g0 + ng; g++)
        for (i = 0; i < n; i++) {
            int q[3], d;
            for (d = 0; d < 3; d++)
                q[d] = ((g >> d & 1 ? -1 : 1) * cr[3 * i + kifmm__perm3[g >> 3][d]] + p - 1) / 2;
            img[(size_t)(g - g0) * n + i] = at[(q[0] * p + q[1]) * p + q[2]];
        }
    kifmm__free(at);
    return KIFMM_SUCCESS;
}

/* The images of the order-p unit surface's n points' vectors (three
 * components each, element 3 i + a: component a at point i) under the 48
 * symmetries, from the points' images img (kifmm__surf_images): g maps
 * x to R x, (R x)_d = s_d x_perm(d), so a kernel with K(R x) = R K(x) R^T
 * (a Stokeslet) has K's entry (3 g(i) + d, 3 g(j) + e) equal to s_d s_e
 * times entry (3 i + perm(d), 3 j + perm(e)): element 3 i + perm(d) goes to
 * eimg[g 3n + 3 i + perm(d)] = 3 g(i) + d with sign esg[..] = s_d. */
KIFMM__FN void kifmm__vec_images(const int *img, int n, int *eimg, signed char *esg)
{
    int g, i, d;
    for (g = 0; g < 48; g++)
        for (i = 0; i < n; i++)
            for (d = 0; d < 3; d++) {
                const size_t at = (size_t)g * 3 * n + 3 * (size_t)i + (size_t)kifmm__perm3[g >> 3][d];
                eimg[at] = 3 * img[(size_t)g * n + i] + d;
                esg[at] = (signed char)(g >> d & 1 ? -1 : 1);
            }
}

/* Component a of a kernel with sd >= 3 components, the last three a
 * vector and the others values, under the signed permutation R, (R x)_d =
 * s[d] x_pm[d]: R's row for a has its one entry, *sgn, in column
 * kifmm__comp_turn(...) (the identity for a value). */
KIFMM__FN int kifmm__comp_turn(int sd, const int *pm, const int *s, int a, double *sgn)
{
    const int v = a - (sd - 3);
    *sgn = v >= 0 ? (double)s[v] : 1.0;
    return v < 0 ? a : sd - 3 + pm[v];
}

/* map[i]: the index of point i of the order-p unit surface mirrored in the
 * axes of mask m (4: x, 2: y, 1: z), in kifmm__surf_unit's order. */
KIFMM__FN int kifmm__surf_mirror(int p, int m, int *map)
{
    return kifmm__surf_images(p, (m >> 2 & 1) | (m & 2) | (m & 1) << 2, 1, map);
}

/* img: the images of n elements under all 48 symmetries (img[g n + i]);
 * orb: the elements orbit by orbit, orbit o from ost[o] to ost[o + 1]; the
 * number of orbits */
KIFMM__FN int kifmm__cube_orbits(const int *img, int n, int *orb, int *ost, int *seen)
{
    int no = 0, len = 0, i, g;
    for (i = 0; i < n; i++) seen[i] = 0;
    ost[0] = 0;
    for (i = 0; i < n; i++) {
        if (seen[i]) continue;
        for (g = 0; g < 48; g++) {
            const int q = img[(size_t)g * n + i];
            if (!seen[q]) seen[q] = 1, orb[len++] = q;
        }
        ost[++no] = len;
    }
    return no;
}

/* Representation rho's orthonormal vectors inside one orbit (mem, s
 * elements; pos[element]: its place there; chi: rho's characters; sg: the
 * images' signs, NULL for none): the projections of the orbit's unit
 * vectors, Gram-Schmidt twice, those not in the span of the ones before
 * kept, into the columns of w (s x s) from column na on; the new number of
 * columns */
KIFMM__FN int kifmm__symb_orbit(const double *chi, const int *mem, int s, const int *img,
                                const signed char *sg, int n, const int *pos, double *w, int na)
{
    const int na0 = na;
    int t, a, g, e, pass;
    for (t = 0; t < s && na < s; t++) {
        double *v = w + (size_t)s * na, n0 = 0.0, nv = 0.0;
        for (e = 0; e < s; e++) v[e] = 0.0;
        for (g = 0; g < 48; g++)
            v[pos[img[(size_t)g * n + mem[t]]]] += sg ? sg[(size_t)g * n + mem[t]] * chi[g] : chi[g];
        for (e = 0; e < s; e++) n0 += v[e] * v[e];
        for (pass = 0; pass < 2 && n0 > 0.0; pass++)
            for (a = na0; a < na; a++) {
                double dot = 0.0;
                for (e = 0; e < s; e++) dot += v[e] * w[(size_t)s * a + e];
                for (e = 0; e < s; e++) v[e] -= dot * w[(size_t)s * a + e];
            }
        for (e = 0; e < s; e++) nv += v[e] * v[e];
        if (!(n0 > 0.0) || nv <= 1e-16 * n0) continue; /* (exact integers: 0 or >= 1 / 48^2 of n0) */
        for (e = 0; e < s; e++) v[e] /= sqrt(nv);
        na++;
    }
    return na;
}

/* The basis of the order-p surface (kifmm__symb) into b, of its points'
 * values (vec 0) or of their vectors (vec 1: three components a point,
 * turned with the points, kifmm__vec_images): KIFMM_SUCCESS,
 * KIFMM_ERR_NOMEM, or KIFMM_ERR_LAPACK if an orbit's projections did not
 * give as many vectors as it has elements (never seen) */
KIFMM__FN int kifmm__symb_build(int p, int vec, kifmm__symb *b)
{
    const int np = kifmm__surf_count(p), n = vec ? 3 * np : np;
    int *img = (int *)kifmm__alloc((size_t)48 * np + (vec ? (size_t)48 * n : 0) + 3 * (size_t)n + 1, sizeof(int));
    signed char *sg = vec ? (signed char *)kifmm__alloc((size_t)48 * n, 1) : NULL;
    int *eimg = img, *pos, *rh, no, rho, o, t, g, off[11];
    double chi[10][48];
    size_t nw = 0;
    int rc = KIFMM_SUCCESS;
    memset(b, 0, sizeof *b);
    b->n = n;
    b->ost = (int *)kifmm__alloc((size_t)n + 1, sizeof(int));
    b->pts = (int *)kifmm__alloc((size_t)n, sizeof(int));
    b->col = (int *)kifmm__alloc((size_t)n, sizeof(int));
    b->wo = (size_t *)kifmm__alloc((size_t)n + 1, sizeof(size_t));
    b->w = (double *)kifmm__alloc((size_t)48 * n, sizeof(double)); /* sum s^2 <= 48 n */
    if (!img || (vec && !sg) || !b->ost || !b->pts || !b->col || !b->wo || !b->w) rc = KIFMM_ERR_NOMEM;
    pos = rh = NULL, no = 0;
    if (!rc) rc = kifmm__surf_images(p, 0, 48, img);
    if (!rc && vec) eimg = img + (size_t)48 * np, kifmm__vec_images(img, np, eimg, sg);
    if (!rc) pos = eimg + (size_t)48 * n, rh = pos + n, no = kifmm__cube_orbits(eimg, n, b->pts, b->ost, pos);
    for (rho = 0; rho < 10; rho++)
        for (g = 0; g < 48; g++) chi[rho][g] = kifmm__cube_chi(rho, g);
    for (o = 0; o < no && !rc; o++) { /* rh: each vector's representation, col: its place in it */
        const int *mem = b->pts + b->ost[o], s = b->ost[o + 1] - b->ost[o];
        int na = 0;
        b->wo[o] = nw;
        for (t = 0; t < s; t++) pos[mem[t]] = t;
        for (rho = 0; rho < 10; rho++) {
            const int na0 = na;
            na = kifmm__symb_orbit(chi[rho], mem, s, eimg, sg, n, pos, b->w + nw, na);
            for (t = na0; t < na; t++) rh[b->ost[o] + t] = rho, b->col[b->ost[o] + t] = b->cnt[rho]++;
        }
        if (na != s) rc = KIFMM_ERR_LAPACK;
        nw += (size_t)s * s;
    }
    for (off[0] = 0, rho = 0; rho < 10; rho++) off[rho + 1] = off[rho] + b->cnt[rho];
    for (t = 0; t < n && !rc; t++) b->col[t] += off[rh[t]];
    b->no = no;
    kifmm__free(img);
    kifmm__free(sg);
    if (rc) kifmm__symb_free(b);
    return rc;
}

/* The bases one operator build factors its matrices on, each built once
 * (laplace at p = 12 factors three matrices on the orders 12 and 13, five
 * bases to build, two of them different): kept by (order, vec) */
#define KIFMM__SYMBS 6
typedef struct kifmm__symbs {
    int n, key[KIFMM__SYMBS];
    kifmm__symb b[KIFMM__SYMBS];
} kifmm__symbs;

KIFMM__FN void kifmm__symbs_free(kifmm__symbs *y)
{
    int i;
    for (i = 0; i < y->n; i++) kifmm__symb_free(&y->b[i]);
    y->n = 0;
}

/* *out: the basis of order p (vec) from y, built there if new; with y
 * NULL (or full), built into own (the caller's to free). */
KIFMM__FN int kifmm__symb_get(kifmm__symbs *y, int p, int vec, kifmm__symb *own, const kifmm__symb **out)
{
    const int key = 2 * p + (vec != 0);
    int i, rc = KIFMM_SUCCESS, found = 0;
    if (y) { /* the solves' tasks share y (P__ops_solves_all): one at a time */
        KIFMM__OMP(critical(kifmm__symbs))
        {
            for (i = 0; i < y->n && !found; i++)
                if (y->key[i] == key) *out = &y->b[i], found = 1;
            if (!found && y->n < KIFMM__SYMBS) {
                rc = kifmm__symb_build(p, vec, &y->b[y->n]);
                if (!rc) y->key[y->n] = key, *out = &y->b[y->n++];
                found = 1;
            }
        }
        if (found) return rc;
    }
    *out = own;
    return kifmm__symb_build(p, vec, own);
}

/* Y = Q^T X (tr) or Q X: X and Y N x nc (N = n sd: rows point-major, sd
 * components each; column major), JB columns at a time (which stay in
 * cache while every orbit reads and writes its rows: laplace's solves at
 * p = 12, 728 columns all at once, spent 0.04 s of create here), orbit by
 * orbit: its rows of X gathered, times W_o or W_o^T (one GEMM), scattered;
 * g: 2 * 48 * nc scratch values */
KIFMM__FN void kifmm__symb_rows(const kifmm__symb *b, int sd, int tr, const double *x, int nc, double *y,
                                double *g)
{
    enum { JB = 16 };
    const size_t N = (size_t)b->n * sd;
    int o, e, c, j, j0;
    for (j0 = 0; j0 < nc; j0 += JB) {
        const int nj = nc - j0 < JB ? nc - j0 : JB;
        const double *xj = x + (size_t)j0 * N;
        double *yj = y + (size_t)j0 * N;
        for (o = 0; o < b->no; o++) {
            const int s = b->ost[o + 1] - b->ost[o], *pt = b->pts + b->ost[o], *cl = b->col + b->ost[o];
            double *h = g + (size_t)s * nj;
            for (c = 0; c < sd; c++) {
                for (j = 0; j < nj; j++)
                    for (e = 0; e < s; e++) g[e + (size_t)j * s] = xj[(size_t)(tr ? pt[e] : cl[e]) * sd + c + j * N];
                kifmm__gemm(tr, 0, s, nj, s, 1.0, b->w + b->wo[o], s, g, s, 0.0, h, s);
                for (j = 0; j < nj; j++)
                    for (e = 0; e < s; e++) yj[(size_t)(tr ? cl[e] : pt[e]) * sd + c + j * N] = h[e + (size_t)j * s];
            }
        }
    }
}

/* R = A Q (A m x N, N = n sd, columns point-major; R likewise, ld m): the
 * orbits' columns of A gathered, times W_o, scattered; g: 2 * 48 * m */
KIFMM__FN void kifmm__symb_cols(const kifmm__symb *b, int sd, const double *a, int m, double *r, double *g)
{
    int o, e, c;
    for (o = 0; o < b->no; o++) {
        const int s = b->ost[o + 1] - b->ost[o], *pt = b->pts + b->ost[o], *cl = b->col + b->ost[o];
        double *h = g + (size_t)s * m;
        for (c = 0; c < sd; c++) {
            for (e = 0; e < s; e++) memcpy(g + (size_t)e * m, a + (size_t)(pt[e] * sd + c) * m, sizeof(double) * (size_t)m);
            kifmm__gemm(0, 0, m, s, s, 1.0, g, m, b->w + b->wo[o], s, 0.0, h, m);
            for (e = 0; e < s; e++) memcpy(r + (size_t)(cl[e] * sd + c) * m, h + (size_t)e * m, sizeof(double) * (size_t)m);
        }
    }
}

/* a kept singular triplet: value, representation, place in its block */
typedef struct kifmm__svi {
    double s;
    int rho, i;
} kifmm__svi;

KIFMM__FN int kifmm__svi_cmp(const void *x, const void *y)
{
    const kifmm__svi *a = (const kifmm__svi *)x, *b = (const kifmm__svi *)y;
    if (a->s != b->s) return a->s > b->s ? -1 : 1;
    return a->rho != b->rho ? a->rho - b->rho : a->i - b->i;
}

/* Each representation's block of bf = Qr^T A Qc (m x n, the rows of
 * representation rho from sd r0[rho] on, its columns from sd c0[rho]): its
 * SVD into us, ss, vts[rho], and the triplets into kept (*nk of them) */
KIFMM__FN int kifmm__cube_blocks(const double *bf, int m, int sd, const int *r0, const int *c0, double **us,
                                 double **ss, double **vts, kifmm__svi *kept, int *nk, double *blk)
{
    int rho, i, j, rc = KIFMM_SUCCESS;
    for (rho = 0; rho < 10 && !rc; rho++) {
        const int mr = (r0[rho + 1] - r0[rho]) * sd, nc = (c0[rho + 1] - c0[rho]) * sd, kr = mr < nc ? mr : nc;
        if (kr == 0) continue;
        us[rho] = (double *)kifmm__alloc((size_t)mr * kr, sizeof(double));
        vts[rho] = (double *)kifmm__alloc((size_t)kr * nc, sizeof(double));
        ss[rho] = (double *)kifmm__alloc((size_t)kr, sizeof(double));
        if (!us[rho] || !vts[rho] || !ss[rho]) return KIFMM_ERR_NOMEM;
        for (j = 0; j < nc; j++)
            for (i = 0; i < mr; i++) blk[i + (size_t)j * mr] = bf[(size_t)r0[rho] * sd + i + ((size_t)c0[rho] * sd + j) * m];
        rc = kifmm__svd(blk, mr, nc, ss[rho], us[rho], vts[rho]);
        for (i = 0; !rc && i < kr; i++) kept[*nk].s = ss[rho][i], kept[*nk].rho = rho, kept[(*nk)++].i = i;
    }
    return rc;
}

/* The largest entry of B (m x n, rows and columns in the representations'
 * order: r0, c0 in units of sd rows) outside its diagonal blocks over its
 * largest entry inside them (1 if none is finite): rounding for a matrix
 * with the cube's symmetries. */
KIFMM__FN double kifmm__cube_offblock(const double *bf, int m, int n, int sd, const int *r0, const int *c0)
{
    double in = 0.0, out = 0.0;
    int i, j, ri, cj = 0;
    for (j = 0; j < n; j++) {
        while (j / sd >= c0[cj + 1]) cj++;
        for (ri = 0, i = 0; i < m; i++) {
            const double v = fabs(bf[i + (size_t)j * m]);
            while (i / sd >= r0[ri + 1]) ri++;
            if (!(v <= DBL_MAX)) return 1.0;
            if (ri == cj) in = v > in ? v : in;
            else out = v > out ? v : out;
        }
    }
    return in > 0.0 ? out / in : 1.0;
}

/* Where kifmm__pinv_cube finds that A does not have the symmetries it
 * takes (an entry of B outside the blocks above KIFMM__SYM_TOL of the
 * largest inside): the caller factors A as it would otherwise. */
#define KIFMM__NOT_SYMMETRIC 1
#define KIFMM__SYM_TOL 1e-12

/* The SVD of A (m x n, not destroyed) as kifmm__svd gives it (s
 * descending, u m x mn, vt mn x n, mn = min(m, n)), A a matrix that
 * commutes with the cube's symmetries: rows the points of the order-pr
 * unit surface, columns those of order pc, sd components each
 * (point-major), turned with the points (vec = 0: each component a value,
 * as a radial kernel's, or a complex one's (re, im) pairs) or as vectors
 * (vec = 1, sd = 3: K(R x) = R K(x) R^T, a Stokeslet's). B = Qr^T A Qc is
 * block diagonal; each block (about m / 5 x n / 5) has its own SVD, and U
 * = Qr U_B, V = Qc V_B. Where the blocks hold fewer than mn triplets, the
 * rest are s = 0 with zero columns. KIFMM__NOT_SYMMETRIC where B is not
 * block diagonal. */
KIFMM__FN int kifmm__svd_cube(kifmm__symbs *y, const double *a, int pr, int pc, int sd, int vec, double *s,
                              double *u, double *vt)
{
    kifmm__symb own_r, own_c;
    const kifmm__symb *br = &own_r, *bp = &own_c;
    const int m = kifmm__surf_count(pr) * sd, n = kifmm__surf_count(pc) * sd, mn = m < n ? m : n;
    const int big = m > n ? m : n;
    double *us[10] = {NULL}, *vts[10] = {NULL}, *ss[10] = {NULL};
    double *r = (double *)kifmm__alloc((size_t)m * n, sizeof(double));
    double *bf = (double *)kifmm__alloc((size_t)m * n, sizeof(double));
    double *g = (double *)kifmm__alloc((size_t)96 * big, sizeof(double));
    kifmm__svi *kept = (kifmm__svi *)kifmm__alloc((size_t)mn + 1, sizeof(kifmm__svi));
    int r0[11], c0[11], rho, i, j, nk = 0, rc = r && bf && g && kept ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM;
    memset(&own_r, 0, sizeof own_r), memset(&own_c, 0, sizeof own_c);
    if (vec && sd != 3) rc = KIFMM_ERR_INTERNAL;
    if (vec) sd = 1; /* the bases' elements are the points' components */
    if (!rc) rc = kifmm__symb_get(y, pr, vec, &own_r, &br);
    if (!rc && pc != pr) rc = kifmm__symb_get(y, pc, vec, &own_c, &bp);
    if (pc == pr) bp = br; /* (square: br twice) */
    for (r0[0] = c0[0] = 0, rho = 0; !rc && rho < 10; rho++)
        r0[rho + 1] = r0[rho] + br->cnt[rho], c0[rho + 1] = c0[rho] + bp->cnt[rho];
    if (!rc) {
        kifmm__symb_cols(bp, sd, a, m, r, g);
        kifmm__symb_rows(br, sd, 1, r, n, bf, g);
        if (!(kifmm__cube_offblock(bf, m, n, sd, r0, c0) <= KIFMM__SYM_TOL)) rc = KIFMM__NOT_SYMMETRIC;
        if (!rc) rc = kifmm__cube_blocks(bf, m, sd, r0, c0, us, ss, vts, kept, &nk, r);
    }
    if (!rc) { /* blkdiag(U) and blkdiag(V)'s columns, by s, into r (m x mn) and bf (n x mn) */
        qsort(kept, (size_t)nk, sizeof *kept, kifmm__svi_cmp);
        memset(r, 0, sizeof(double) * (size_t)m * mn), memset(bf, 0, sizeof(double) * (size_t)n * mn);
        for (j = 0; j < mn; j++) s[j] = j < nk ? kept[j].s : 0.0;
        for (j = 0; j < nk; j++) {
            const int rh = kept[j].rho, t = kept[j].i, mr = (r0[rh + 1] - r0[rh]) * sd;
            const int nc = (c0[rh + 1] - c0[rh]) * sd, kr = mr < nc ? mr : nc;
            for (i = 0; i < mr; i++) r[(size_t)r0[rh] * sd + i + (size_t)j * m] = us[rh][i + (size_t)t * mr];
            for (i = 0; i < nc; i++) bf[(size_t)c0[rh] * sd + i + (size_t)j * n] = vts[rh][t + (size_t)i * kr];
        }
        kifmm__symb_rows(br, sd, 0, r, mn, u, g); /* Qr U */
        kifmm__symb_rows(bp, sd, 0, bf, mn, r, g); /* Qc V, then its transpose */
        for (j = 0; j < mn; j++)
            for (i = 0; i < n; i++) vt[j + (size_t)i * mn] = r[i + (size_t)j * n];
    }
    for (rho = 0; rho < 10; rho++) kifmm__free(us[rho]), kifmm__free(vts[rho]), kifmm__free(ss[rho]);
    kifmm__free(r), kifmm__free(bf), kifmm__free(g), kifmm__free(kept);
    kifmm__symb_free(&own_r), kifmm__symb_free(&own_c);
    return rc;
}

/* kifmm__pinv's factors (the same truncation, s_i > cutoff * s_0) of A as
 * kifmm__svd_cube takes it (not destroyed). 2 threads, best of 3: 866 x
 * 728 (laplace's upward solve at p = 12) 0.133 s for dgesdd on A, 0.046 s
 * by blocks; 976 x 772 (helmholtz's lattice fit at p = 8) 0.166 and 0.050
 * s; 386 x 296 0.017 and 0.007 s. KIFMM__NOT_SYMMETRIC as there. */
KIFMM__FN int kifmm__pinv_cube(kifmm__symbs *y, const double *a, int pr, int pc, int sd, int vec,
                               double cutoff, double **ut_out, double **vs_out, int *rank)
{
    const int m = kifmm__surf_count(pr) * sd, n = kifmm__surf_count(pc) * sd, mn = m < n ? m : n;
    double *s = (double *)kifmm__alloc((size_t)mn + 1, sizeof(double));
    double *u = (double *)kifmm__alloc((size_t)m * mn + 1, sizeof(double));
    double *vt = (double *)kifmm__alloc((size_t)mn * n + 1, sizeof(double)), *ut = NULL, *vs = NULL;
    int k = 0, rc = s && u && vt ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM;
    if (!rc) rc = kifmm__svd_cube(y, a, pr, pc, sd, vec, s, u, vt);
    if (!rc) {
        for (k = 0; k < mn && s[k] > cutoff * s[0]; k++) {}
        ut = (double *)kifmm__alloc((size_t)k * m + 1, sizeof(double));
        vs = (double *)kifmm__alloc((size_t)n * k + 1, sizeof(double));
        if (!ut || !vs) rc = KIFMM_ERR_NOMEM;
    }
    if (!rc) {
        kifmm__pinv_factors(m, n, k, u, s, vt, mn, ut, vs);
        *ut_out = ut, *vs_out = vs, *rank = k, ut = vs = NULL;
    }
    kifmm__free(s), kifmm__free(u), kifmm__free(vt), kifmm__free(ut), kifmm__free(vs);
    return rc;
}

/* the most groups of components kifmm__pinv_groups takes */
#define KIFMM__GROUPS 8
/* Group g's block of A (m x n, components gr of rows i sd + a, gc of
 * columns j sd + b): its rows and columns in order, *bm x *bn, or NULL
 * (out of memory). */
KIFMM__FN double *kifmm__group_block(const double *a, int m, int n, int sd, const int *gr, const int *gc,
                                     int g, int *bm, int *bn)
{
    double *blk;
    int i, j, bi, bj;
    for (*bm = 0, i = 0; i < m; i++) *bm += gr[i % sd] == g;
    for (*bn = 0, j = 0; j < n; j++) *bn += gc[j % sd] == g;
    if (!(blk = (double *)kifmm__alloc((size_t)*bm * *bn + 1, sizeof(double)))) return NULL;
    for (bj = 0, j = 0; j < n; j++) {
        if (gc[j % sd] != g) continue;
        for (bi = 0, i = 0; i < m; i++)
            if (gr[i % sd] == g) blk[bi++ + (size_t)bj * *bm] = a[i + (size_t)j * m];
        bj++;
    }
    return blk;
}

/* The SVD (kifmm__svd) of one group's block of kifmm__pinv_groups (bm x
 * bn, destroyed) between the unit surfaces of orders pr and pc (pr = 0:
 * none): by the cube's symmetries where the block has them. */
KIFMM__FN int kifmm__svd_group(kifmm__symbs *y, double *blk, int bm, int bn, int pr, int pc, double *s,
                               double *u, double *vt)
{
    const int cr = pr > 0 ? kifmm__surf_count(pr) : 0, cc = pc > 0 ? kifmm__surf_count(pc) : 0;
    const int gs = cr > 0 ? bm / cr : 0; /* the group's components */
    int rc = KIFMM__NOT_SYMMETRIC;
    if (gs > 0 && gs * cr == bm && cc > 0 && gs * cc == bn)
        rc = kifmm__svd_cube(y, blk, pr, pc, gs, gs == 3, s, u, vt);
    return rc == KIFMM__NOT_SYMMETRIC ? kifmm__svd(blk, bm, bn, s, u, vt) : rc;
}

/* kifmm__pinv's factors (the same truncation, s_i > cutoff * s_0 over all
 * blocks) of A (m x n, rows i sd + a, columns j sd + b, not destroyed)
 * whose components fall into groups: entries between row component a and
 * column component b with gr[a] != gc[b] are exactly zero (stokes_dl's
 * surfaces: (c, f) -> (c / (4 pi r), G f)). Each group's block has its own
 * SVD, so that each singular vector lives on one group and the factors,
 * and every operator built from them, keep the groups apart exactly: one
 * SVD mixes them at its rounding, and where the groups' values differ by
 * a power of the box's size that rounding grows with it (stokes_dl, 2,000
 * points on a cube of side 1e-10, leaves of 40, p = 6: relative error 38.6,
 * 8.8e-6 at side 1). A nonzero entry between groups: one SVD of a copy.
 * A and its blocks between the unit surfaces of orders pr (rows) and pc
 * (columns), or pr = 0: a group with as many components in its rows as in
 * its columns has its SVD by the cube's symmetries where its block has
 * them (kifmm__svd_cube; three components turned as a vector, others each
 * as a value: stokes_dl's c and f, biot_savart's three charges). */
KIFMM__FN int kifmm__pinv_groups(kifmm__symbs *y, const double *a, int m, int n, int sd, int pr, int pc,
                                 const int *gr, const int *gc, int ng, double cutoff, double **ut_out,
                                 double **vs_out, int *rank)
{
    double *u[KIFMM__GROUPS] = {NULL}, *vt[KIFMM__GROUPS] = {NULL}, *s[KIFMM__GROUPS] = {NULL};
    double *ut = NULL, *vs = NULL, *blk, s0 = 0.0;
    int bm[KIFMM__GROUPS], bn[KIFMM__GROUPS], mk[KIFMM__GROUPS], bk[KIFMM__GROUPS];
    int g, i, j, t, k = 0, off, rc = KIFMM_SUCCESS, apart = 1;
    for (j = 0; j < n && apart; j++)
        for (i = 0; i < m && apart; i++) apart = gr[i % sd] == gc[j % sd] || a[i + (size_t)j * m] == 0.0;
    if (!apart) {
        if (!(blk = (double *)kifmm__alloc((size_t)m * n, sizeof(double)))) return KIFMM_ERR_NOMEM;
        memcpy(blk, a, (size_t)m * n * sizeof(double));
        rc = kifmm__pinv(blk, m, n, cutoff, ut_out, vs_out, rank);
        kifmm__free(blk);
        return rc;
    }
    for (g = 0; g < ng && !rc; g++) {
        blk = kifmm__group_block(a, m, n, sd, gr, gc, g, &bm[g], &bn[g]);
        mk[g] = bm[g] < bn[g] ? bm[g] : bn[g];
        u[g] = (double *)kifmm__alloc((size_t)bm[g] * mk[g] + 1, sizeof(double));
        vt[g] = (double *)kifmm__alloc((size_t)mk[g] * bn[g] + 1, sizeof(double));
        s[g] = (double *)kifmm__alloc((size_t)mk[g] + 1, sizeof(double));
        if (!blk || !u[g] || !vt[g] || !s[g]) rc = KIFMM_ERR_NOMEM;
        else if (mk[g] > 0) rc = kifmm__svd_group(y, blk, bm[g], bn[g], pr, pc, s[g], u[g], vt[g]);
        if (!rc && mk[g] > 0 && s[g][0] > s0) s0 = s[g][0];
        kifmm__free(blk);
    }
    for (g = 0; g < ng && !rc; k += bk[g], g++)
        for (bk[g] = 0; bk[g] < mk[g] && s[g][bk[g]] > cutoff * s0; bk[g]++) {}
    if (!rc) {
        ut = (double *)kifmm__calloc((size_t)k * m + 1, sizeof(double));
        vs = (double *)kifmm__calloc((size_t)n * k + 1, sizeof(double));
        if (!ut || !vs) rc = KIFMM_ERR_NOMEM;
    }
    for (g = 0, off = 0; g < ng && !rc; off += bk[g], g++)
        for (t = 0; t < bk[g]; t++) { /* U^T's rows and V S^-1's columns, scattered */
            int b = 0;
            for (i = 0; i < m; i++)
                if (gr[i % sd] == g) ut[(size_t)(off + t) + (size_t)i * k] = u[g][b++ + (size_t)t * bm[g]];
            for (b = 0, j = 0; j < n; j++)
                if (gc[j % sd] == g)
                    vs[(size_t)j + (size_t)(off + t) * n] = vt[g][t + (size_t)b++ * mk[g]] / s[g][t];
        }
    if (!rc) *ut_out = ut, *vs_out = vs, *rank = k, ut = vs = NULL;
    kifmm__free(ut), kifmm__free(vs);
    for (g = 0; g < ng; g++) kifmm__free(u[g]), kifmm__free(vt[g]), kifmm__free(s[g]);
    return rc;
}

/* Unit surface scaled by `radius` and moved to `c`, into out (SoA, n points). */
KIFMM__FN void kifmm__surf_place(const double *unit, int n, const double *c, double radius,
                                 double *out)
{
    int i, d;
    for (d = 0; d < 3; d++)
        for (i = 0; i < n; i++) out[d * n + i] = c[d] + radius * unit[d * n + i];
}

/* Anchors (>>anchors): n far points about a box, KIFMM__ANCHOR_RADIUS
 * half-widths from its centre, in the SoA layout of the unit surfaces: n =
 * 4, the directions of a regular tetrahedron's corners; n = 14
 * (KIFMM__ANCHOR_MAX), those of the cube's 6 faces and 8 corners. Their
 * fit is truncated at KIFMM__ANCHOR_CUTOFF of its largest singular value;
 * KIFMM__ANCHOR_FLOOR: see __anchor_pinv. */
#define KIFMM__ANCHOR_MAX 14
#ifndef KIFMM__ANCHOR_CUTOFF
#define KIFMM__ANCHOR_CUTOFF 1e-6
#endif
#define KIFMM__ANCHOR_FLOOR 1e-12
#ifndef KIFMM__ANCHOR_RADIUS
#define KIFMM__ANCHOR_RADIUS 100.0
#endif
KIFMM__FN void kifmm__anchor_unit(int n, double *a)
{
    const double f = KIFMM__ANCHOR_RADIUS, g = KIFMM__ANCHOR_RADIUS / 1.7320508075688772;
    int i, d;
    for (i = 0; i < n; i++)
        for (d = 0; d < 3; d++)
            a[d * n + i] = n == 4 ? (i == 0 || i == d + 1 ? g : -g) /* a tetrahedron's corners */
                           : i < 6 ? (i % 3 == d ? (i < 3 ? f : -f) : 0.0)
                                   : (((i - 6) >> (2 - d)) & 1 ? g : -g);
}

/* The smallest log2 |k2[i] / k1[i]| over the n entries nonzero in both (a
 * kernel's values at u and 2 u: its fastest power of r); HUGE_VAL if none. */
KIFMM__FN double kifmm__min_degree(const double *k1, const double *k2, int n)
{
    double m = HUGE_VAL;
    int i;
    for (i = 0; i < n; i++)
        if (k1[i] != 0.0 && k2[i] != 0.0 && log2(fabs(k2[i] / k1[i])) < m) m = log2(fabs(k2[i] / k1[i]));
    return m;
}

/* Each entry's degree of a kernel K (n entries from ev at parameters prm):
 * log2 |K(2 x) / K(x)| at the point x, NaN where K(x) is zero. 1 if every
 * entry not zero is a power of r there (its ratios between x, 2 x and 4 x
 * equal to 1e-9, with one sign), 0 if not (or on allocation failure). */
typedef void (*kifmm__ev_fn)(const double *, double, double, double, double *);
/* the point the kernels' degrees are read at (off the cube's symmetry planes) */
static const double kifmm__degree_x[3] = {0.61, -0.37, 0.23};
KIFMM__FN int kifmm__entry_degrees(kifmm__ev_fn ev, const double *prm, int n, const double *x, double *deg)
{
    double *q = (double *)kifmm__alloc((size_t)3 * n, sizeof(double));
    int k, i, ok = 1;
    if (!q) return 0;
    for (k = 0; k < 3; k++) {
        const double f = (double)(1 << k);
        ev(prm, x[0] * f, x[1] * f, x[2] * f, q + k * n);
    }
    for (i = 0; i < n; i++) {
        const double a = q[i] != 0.0 && q[n + i] / q[i] > 0.0 ? log2(q[n + i] / q[i]) : NAN;
        const double b = q[n + i] != 0.0 && q[2 * n + i] / q[n + i] > 0.0 ? log2(q[2 * n + i] / q[n + i]) : NAN;
        deg[i] = q[i] != 0.0 ? a : NAN;
        if (q[i] != 0.0) ok &= a == a && b == b && fabs(a - b) < 1e-9;
    }
    kifmm__free(q);
    return ok;
}

/* A kernel's degrees by rows and columns: K(2 x) = 2^(r[a] + c[s]) K(x)
 * entry by entry (K: nr x nc, row by row; kifmm__entry_degrees at one
 * point), c from the first row without zeros, r[a] 0 in a row of zeros
 * (the Laplace dipoles: r = 0, c = -2; stokes_pvel's pressure and velocity
 * rows: r = -2 and -1, c = 0). 1 if every entry is so, else 0. */
KIFMM__FN int kifmm__degrees(kifmm__ev_fn ev, const double *prm, int nr, int nc, double *r, double *c)
{
    double *e = (double *)kifmm__alloc((size_t)nr * nc, sizeof(double));
    int a, s, ok = e && kifmm__entry_degrees(ev, prm, nr * nc, kifmm__degree_x, e), a0 = -1;
    for (a = 0; a < nr && a0 < 0 && ok; a++) /* a row without zeros sets c */
        for (s = 0, a0 = a; s < nc; s++)
            if (e[(size_t)a * nc + s] != e[(size_t)a * nc + s]) a0 = -1;
    ok &= a0 >= 0;
    for (s = 0; s < nc && ok; s++) c[s] = e[(size_t)a0 * nc + s];
    for (a = 0; a < nr && ok; a++) {
        r[a] = NAN;
        for (s = 0; s < nc; s++) {
            const double d = e[(size_t)a * nc + s];
            if (d != d) continue;
            if (r[a] != r[a]) r[a] = d - c[s];
            ok &= fabs(d - r[a] - c[s]) < 1e-9;
        }
        if (r[a] != r[a]) r[a] = 0.0;
    }
    kifmm__free(e);
    return ok;
}

/* Surface radii in units of the box half-width, for kernels with one
 * surface density component: */
#define KIFMM__ALPHA_INNER 1.05 /* upward equivalent, downward check */
/* upward check, downward equivalent: 2.95 with check surfaces of order p + 1,
 * with order p 4.5 up to order 7 and kifmm__alpha_square's above (see
 * kifmm__check_diff) */
#define KIFMM__ALPHA_OUTER_LSQ 2.95
#define KIFMM__ALPHA_OUTER_SQUARE 4.5
/* the highest order with square systems in float instances (see
 * kifmm__check_diff) */
#define KIFMM__SQUARE_MAX_FLOAT 7
/* and with several (the Stokeslet's surfaces): inner surfaces on the box
 * itself, outer ones at 3.2. Measured on 20,000 uniform points with the
 * Stokeslet, relative L2 error of the velocity, with the 1.05 / 2.95 pair
 * and with this one: p = 4 5.4e-4 / 3.9e-4 (1.0 / 2.95), p = 6 8.0e-6 /
 * 3.5e-6, p = 8 1.7e-7 / 4.2e-8 (check order p + 2), p = 10 7.0e-9 /
 * 2.4e-9 (p + 2); for Laplace 1.0 measured no better. */
#define KIFMM__ALPHA_INNER_MULTI 1.0
#define KIFMM__ALPHA_OUTER_MULTI 3.2
/* A surface kernel that sets _INNER_NARROW to 1 (the Stokeslet) has its
 * inner surfaces just inside the box, at 0.95: on 20,000 points (uniform,
 * sphere, blobs) the Stokeslet's velocity error is 1.25 to 2.6 times
 * smaller than at 1.0 for p = 4 to 10 (blobs at p = 10: 6 % larger), and
 * 1.5 times with three periodic directions; three Laplace copies
 * (Biot-Savart) and the pressure-velocity surfaces measured the same or
 * worse (docs/algorithm.md). */
#define KIFMM__ALPHA_INNER_NARROW 0.95
/* A complex kernel (KIFMM_HAS_COMPLEX) takes a one-component kernel's
 * square systems (check order p, radii 1.05 and 4.5) up to this order, and
 * the two-component surfaces above. helmholtz, 20,000 uniform points,
 * level-2 boxes 0.03 to 1.15 wavelengths wide (bench/bench_waves.c): p = 5
 * and 6 0.82 to 0.98 and 0.68 to 0.96 times the two-component surfaces'
 * errors below 0.8 wavelengths, 1.0 to 1.27 and 1.0 to 1.17 times above;
 * p = 7 erratic (1.5e-5 at 0.35 wavelengths against 1.3e-7). The FFT grid
 * is then (2p - 1)^3 against (2p + 1)^3: evaluate 0.76 against 0.95 s at
 * 200,000 points, p = 6, 2 wavelengths. */
#define KIFMM__CPLX_SQUARE_MAX 6

/* The check surfaces' order minus the equivalent surfaces' order p, for an
 * instance with the FFT M2L (fft) or not, sd surface density components,
 * in float (single) or double. One component: with the FFT M2L up to order
 * KIFMM_SQUARE_MAX_ORDER (7 in float) 0, with the outer surfaces at 4.5 box
 * half-widths up to order 7 (kifmm__alpha_square above; check and
 * equivalent surfaces of the same order, square systems), whose
 * M2L runs on a (2p - 1)^3 grid instead of (2p + 1)^3: half the frequencies
 * at p = 4, 0.6 times at p = 6. Measured against order p + 1 at 2.95 on
 * uniform, sphere, clustered and separate point sets (p = 4, 6, 7; p = 2,
 * 3, 5 at radius 3.5), the errors are the same or smaller
 * (docs/algorithm.md). Orders 8 to 10 keep them with their own outer
 * radius (kifmm__alpha_square: errors 0.6 to 1.1 times order p + 1's, the
 * M2L about 35 % faster); from order 11 on every radius tried lost digits:
 * 1 there, and without the FFT M2L. Several components (the
 * Stokeslet's square systems lose digits at every order): 1 up to order 6,
 * 2 above (at p = 8 the Stokeslet's error 9.3e-8 with 1, 4.2e-8 with 2, for
 * 1.8 times the create time). Float instances keep order p + 1 above
 * order 7 (KIFMM__SQUARE_MAX_FLOAT): the wider square systems of orders 8
 * to 10 lost digits there (float laplace, 100,000 points, potential: p = 8
 * 1.0e-6 -> 6.8e-6 on the cube, 3.8e-7 -> 9.0e-6 on Plummer's sphere; p =
 * 10 1.0e-6 -> 1.2e-6). A definition of KIFMM_CHECK_ORDER_DIFF before
 * the include applies to every order and kernel (the outer radius
 * kifmm__alpha_square's when it is 0). */
KIFMM__FN int kifmm__check_diff(int p, int fft, int sd, int single)
{
#ifdef KIFMM_CHECK_ORDER_DIFF
    (void)p;
    (void)fft;
    (void)sd;
    (void)single;
    return KIFMM_CHECK_ORDER_DIFF;
#else
    if (sd > 1) return p <= 6 ? 1 : 2;
    return fft && p <= KIFMM_SQUARE_MAX_ORDER && (!single || p <= KIFMM__SQUARE_MAX_FLOAT) ? 0 : 1;
#endif
}

/* Periodic trees: the order of the far images' exchange about the root
 * (__far_root) for expansions of order p. Where every box of
 * the exchange's level that holds points splits, the boxes' own expansions
 * of order p carry it, and p + 1 and p + 2 gave the same errors to a few
 * per cent (docs/algorithm.md), p + 2 at 2 times the cost; where one is a
 * leaf (small sets), its points and targets meet the exchange directly and
 * its order is the error: eight charges, p = 6, gradient 2.4e-5 at p + 1,
 * 3.1e-6 at p + 2, 1.8e-6 at p + 3 (KIFMM_EWALD_RAISE_SMALL); p = 10 2.0e-8,
 * 6.2e-9, 9.1e-10; create at p = 10 1.45 s -> 2.8 s. */
/* KIFMM_MONO_FIX 0: the upward densities keep their fitted sums (see
 * __mono_fix) */
#ifndef KIFMM_MONO_FIX
#define KIFMM_MONO_FIX 1
#endif
/* KIFMM_RAISE_SLACK: an oscillating kernel's wide levels at a higher order
 * (>>orders); 0 for none (the measurements behind the tables per order) */
#ifndef KIFMM_RAISE_SLACK
#define KIFMM_RAISE_SLACK 3.0
#endif
#ifndef KIFMM_EWALD_RAISE
#define KIFMM_EWALD_RAISE 1
#endif
#ifndef KIFMM_EWALD_RAISE_SMALL
#define KIFMM_EWALD_RAISE_SMALL 3
#endif
KIFMM__FN int kifmm__ewald_order(int p, int small)
{
    return p + (small ? KIFMM_EWALD_RAISE_SMALL : KIFMM_EWALD_RAISE);
}
/* KIFMM_EWALD_OWN_FIT 1: the exchange's down fit from its own SVD even for
 * a kernel with K(-d) = K(d)^T, as for the kernels without that symmetry
 * (tests/test_ewald.c runs that path with laplace) */
#ifndef KIFMM_EWALD_OWN_FIT
#define KIFMM_EWALD_OWN_FIT 0
#endif

/* The outer radius of square systems of order p. Up to order 7 4.5; above,
 * the radius that gave the smallest errors (potential and gradient, relative
 * L2 against direct sums at 1,000 targets of 100,000 points, laplace_grad;
 * uniform, sphere-surface, Plummer and clustered points) among 2.5 to 7.0:
 * p = 8 5.0 to 6.0 (4.5 and 4.75 gave 1.6 to 2.2 times the error of order
 * p + 1 at 2.95, 5.0 to 6.0 0.70 to 0.79 times), p = 9 4.25 to 4.5 (0.67 to
 * 0.81 times), p = 10 3.75 to 4.0 (0.82 to 0.98 times the potential's error,
 * 0.70 to 0.98 the gradient's); at p = 11 and 12 none did as well (3.0:
 * 1.7 and 2.0 times; larger radii worse), so from order 11 on the systems
 * take order p + 1 (KIFMM_SQUARE_MAX_ORDER; 3.0 where KIFMM_CHECK_ORDER_DIFF
 * asks for square ones). docs/algorithm.md, "Surfaces and operators". */
KIFMM__FN double kifmm__alpha_square(int p)
{
    return p <= 7 ? KIFMM__ALPHA_OUTER_SQUARE : p == 8 ? 5.5 : p == 9 ? 4.5 : p == 10 ? 4.0 : 3.0;
}

KIFMM__FN double kifmm__alpha_outer(int p, int diff, int sd)
{
    return diff == 0 ? kifmm__alpha_square(p)
                     : sd > 1 ? KIFMM__ALPHA_OUTER_MULTI : KIFMM__ALPHA_OUTER_LSQ;
}

KIFMM__FN double kifmm__alpha_inner(int sd, int narrow)
{
    return narrow ? KIFMM__ALPHA_INNER_NARROW
                  : sd > 1 ? KIFMM__ALPHA_INNER_MULTI : KIFMM__ALPHA_INNER;
}

/* An oscillating kernel's inner surfaces, for boxes x wavelengths wide: the
 * check-to-equivalent solves determine nothing where the inner surface, a
 * cube a x wavelengths wide (a = the radius in half-widths), is at one of
 * its interior Dirichlet resonances, sqrt(i^2 + j^2 + k^2) / 2 wavelengths
 * wide (i, j, k >= 1: 0.866, 1.2247, 1.5, ...). The errors peak sharply
 * there (docs/kernels.md: p = 10 eleven times its neighbours' 0.02 % from
 * 1.2247, 1.2 times 0.4 % away; p = 8 within 10 % of smooth 0.5 % from
 * 0.866): the radius nearest `base` (in steps of 0.25 %, within 10 %) that
 * keeps 1.5 % from each of them; `base` wherever base x is below 0.85
 * wavelengths. */
#define KIFMM__WAVES_GAP 0.015
KIFMM__FN double kifmm__alpha_waves(double base, double x)
{
    static const unsigned char m[] = {3,  6,  9,  11, 12, 14, 17, 18, 19, 21, 22, 24, 26, 27, 29,
                                      30, 33, 34, 35, 36, 38, 41, 42, 43, 44, 45, 46, 48, 49, 50};
    int j, i, ok;
    if (base * x < 0.85) return base; /* below the first (0.866), the common case */
    for (j = 0; j <= 80; j++) {
        const double a = base * (1.0 + ((j & 1) ? 0.0025 : -0.0025) * ((j + 1) / 2));
        for (i = 0, ok = 1; i < (int)sizeof m && ok; i++) {
            const double s = 0.5 * sqrt((double)m[i]);
            ok = fabs(a * x - s) >= KIFMM__WAVES_GAP * s;
        }
        if (ok) return a;
    }
    return base; /* (boxes this wide are refused: KIFMM_ERR_FREQUENCY) */
}


/* The equivalent and check surfaces of one expansion order (kifmm__surf_unit
 * at p and p + cdiff, the anchors: >>anchors), in box half-widths: the plan
 * holds them, and each level of a handle reads its own (the handle's sf). */
typedef struct kifmm__surf {
    int nse, nsc;          /* points */
    int cdiff;             /* check order - equivalent order (kifmm__check_diff) */
    double ai, ao;         /* inner and outer surfaces' radii, in box half-widths */
    int ne, nc;            /* vector lengths: points x SD */
    double *unit_e, *unit_c; /* unit surfaces (SoA) */
    int nsa;               /* anchors of the downward densities (>>anchors) */
    int nde;               /* downward density length: (nse + nsa) x SD */
    int nsm;               /* max(nsc, nse + nsa): points of a scratch surface */
    double *unit_a;        /* the anchors, in box half-widths (SoA) */
} kifmm__surf;

/* 1 where the BLAS is a threaded OpenBLAS (pthreads or OpenMP: one that
 * takes calls from several threads at once) set to one thread a call
 * (openblas_get_parallel, openblas_get_num_threads, found at run time
 * through weak references: ELF objects built by gcc or clang), so that
 * LAPACK may run on several OpenMP threads at once without nesting
 * threads; 0 elsewhere (another BLAS, OpenBLAS with more threads, a
 * sequential OpenBLAS, which is safe from several threads only when built
 * with USE_LOCKING, other platforms, KIFMM_NO_BLAS_PROBE). */
#if defined(__ELF__) && defined(__GNUC__) && !defined(KIFMM_NO_BLAS_PROBE)
#ifdef __cplusplus
extern "C" {
#endif
int openblas_get_num_threads(void) __attribute__((weak));
int openblas_get_parallel(void) __attribute__((weak));
#ifdef __cplusplus
}
#endif
KIFMM__FN int kifmm__blas_serial(void)
{
    return openblas_get_parallel && openblas_get_num_threads && openblas_get_parallel() != 0 &&
           openblas_get_num_threads() == 1;
}
#else
KIFMM__FN int kifmm__blas_serial(void)
{
    return 0;
}
#endif

/* ---- operators in double (every instance builds its own) ------------------ */

/* Operators of one level, built with the target box's half-width. Check
 * vectors have nc entries, equivalent densities ne (points x components). */
typedef struct kifmm__ops {
    double sigma;           /* scale of the check potentials (see build_c2e) */
    int ku, kd;             /* ranks kept by the two pseudo-inverses */
    double *ut_up, *vs_up;  /* pinv K(up check <- up equiv) = vs_up ut_up */
    double *ut_dn, *vs_dn;  /* pinv K(down check <- down equiv) */
    double *m2m;            /* nc x 8 ne: children's equiv -> parent's check (mir: nc x ne) */
    double *l2l;            /* 8 nc x nde: parent's equiv (anchors last) -> children's check
                               (mir: nc x ne, then the anchors' 8 nc x (nde - ne)) */
    int mir;                /* m2m and l2l hold octant 0's only, the others its mirror
                               images (P__mirror_maps): 1 radial, 2 vector kernel; else 0 */
    int *mmap;              /* with mir: octants 1 to 7's maps of the check surface's
                               points (nsc) and the equivalent surface's (nse) */
    double *m2l;            /* kd x 316 ne: source equiv -> ut_dn (target check) */
    double *conv;           /* FFT M2L, nc x ne: upward equivalent density -> a density
                               on the check surface's lattice (ai r) with the same
                               field outside the upward check surface */
    double *khat;           /* FFT M2L: the kernel spectra on that lattice,
                               frequency-major: of the 316 transfer vectors,
                               khat[(f 316 + t) 2] (re, im), or, with ktab, of the
                               16 the others are turned from (P__build_m2l_fft) */
    int *ktab;              /* the turns from the 16 (P__khat_turns), or NULL */
    double *kup, *kdn;      /* the two check-to-equivalent matrices, times sigma,
                               from the kernel pass to the solves (then freed) */
    kifmm__symbs *sy;       /* the build's symmetry bases (NULL: none kept), not owned */
    const kifmm__surf *sc;  /* M2M's children's and L2L's parent's surfaces where their
                               order is not the level's (>>orders), else NULL */
    const kifmm__surf *sp;
} kifmm__ops;

KIFMM__FN void kifmm__ops_free(kifmm__ops *o)
{
    kifmm__free(o->ut_up); kifmm__free(o->vs_up);
    kifmm__free(o->ut_dn); kifmm__free(o->vs_dn);
    kifmm__free(o->m2m); kifmm__free(o->l2l); kifmm__free(o->m2l);
    kifmm__free(o->conv); kifmm__free(o->khat); kifmm__free(o->ktab);
    kifmm__free(o->kup); kifmm__free(o->kdn); kifmm__free(o->mmap);
    memset(o, 0, sizeof *o);
}


// >>lattice

/* ---- periodic trees: the far images ------------------------------------- */

/* A periodic tree's field from the images of the cell beyond its 26
 * neighbours (which the lists reach: the root's colleagues are its images),
 * as one operator T from the root's upward equivalent density to its
 * downward check potential, of order p (not applied to the root: the far
 * images are exchanged with the boxes of level 1 at a higher order, and
 * T(3 h) is the super-cell's part of that exchange, see __far_root; with
 * three periodic directions of a scale-invariant kernel Ewald sums take
 * its place), built from the kernel alone by recursion over
 * super-cells of 3 x 3 x 3 cells (3 or 3 x 3 along fewer periodic
 * directions). With a cell of half-width h and its super-cell of 3 h:
 *   A: the cell's own images in the super-cell's 26 neighbours (2 <= |n|
 *      <= 4: each at least a cell apart, the M2L's geometry) -> the cell's
 *      check potential, summed directly;
 *   C: the cell's density -> the super-cell's (the 27 copies summed, M2M);
 *   B: the super-cell's local expansion -> the cell's check potential (L2L);
 * and T(h) = A + B T(3 h) C: the images beyond the neighbours are those in
 * the super-cell's neighbours and, beyond those, the super-cell's own far
 * images. A kernel
 * of degree a has T(3 h) = 3^a T(h), and T is the fixed point of that map,
 * converging by about 1/3 per step; T of any other kernel is the sum of
 * its terms level by level while they matter (a Yukawa kernel's vanish
 * once lambda h reaches some tens). For scale-invariant kernels the
 * monopole (the densities' sum per component) is projected out: its image
 * sums diverge (docs/api.md: the densities must then sum to zero). */
typedef struct {
    int nc, ne, sd;
    double *a, *b, *c;   /* nc x ne, nc x nc, ne x ne (column major) */
    double *e;           /* scale-invariant kernels: ne x SD, the density of a
                            unit point source at the centre, with S e = I */
    double *mu;          /* SD x QD: the densities' sum per component of a unit
                            point source of each kind (kernel component) */
    kifmm__ops sup;      /* with e: the super-cell's two fits (for __far_pairs) */
} kifmm__lat;

KIFMM__FN void kifmm__lat_free(kifmm__lat *L)
{
    kifmm__free(L->a);
    kifmm__free(L->b);
    kifmm__free(L->c);
    kifmm__free(L->e);
    kifmm__free(L->mu);
    kifmm__ops_free(&L->sup);
    memset(L, 0, sizeof *L);
}

/* Image offsets n along the periodic directions only (0 along the free
 * ones), into m[3 i ..] (up to 729 of them); returns their number. kind 0:
 * the 3 x 3 x 3 block of cells, |n| <= 1; kind 1: the cell's images in its
 * super-cell's neighbours, 2 <= |n| <= 4 (max norm). */
KIFMM__FN int kifmm__lat_offsets(const kifmm__tree *t, int kind, int *m)
{
    const int r = kind ? 4 : 1;
    int n = 0, i, j, k;
    for (i = -r; i <= r; i++)
        for (j = -r; j <= r; j++)
            for (k = -r; k <= r; k++) {
                if ((i && !t->per[0]) || (j && !t->per[1]) || (k && !t->per[2])) continue;
                if (kind && i * i < 4 && j * j < 4 && k * k < 4) continue;
                m[3 * n] = i;
                m[3 * n + 1] = j;
                m[3 * n + 2] = k;
                n++;
            }
    return n;
}

/* x (rows x cols, column major, SD-component columns) minus the part along
 * e: x - (x e) S, where S sums a density's components (x P, P = I - e S). */
KIFMM__FN int kifmm__lat_project(double *x, int rows, int ne, int sd, const double *e)
{
    double *xe = (double *)kifmm__alloc((size_t)rows * sd, sizeof(double));
    int i, j;
    if (!xe) return KIFMM_ERR_NOMEM;
    kifmm__gemm(0, 0, rows, sd, ne, 1.0, x, rows, e, ne, 0.0, xe, rows);
    for (j = 0; j < ne; j++)
        for (i = 0; i < rows; i++) x[i + (size_t)j * rows] -= xe[i + (size_t)(j % sd) * rows];
    kifmm__free(xe);
    return KIFMM_SUCCESS;
}

/* Square matrix inverse in place by Gauss-Jordan without pivoting (the small
 * SD x SD S e, close to the identity). */
KIFMM__FN void kifmm__small_inverse(double *a, int n)
{
    int i, j, k;
    for (k = 0; k < n; k++) {
        const double p = a[k + k * n];
        a[k + k * n] = 1.0;
        for (j = 0; j < n; j++) a[k + j * n] /= p;
        for (i = 0; i < n; i++) {
            const double f = a[i + k * n];
            if (i == k) continue;
            a[i + k * n] = 0.0;
            for (j = 0; j < n; j++) a[i + j * n] -= f * a[k + j * n];
        }
    }
}

/* P x for each column of x (n x cols): x - e S x, S summing each of the sd
 * components over the points (e: n x sd with S e = I). */
KIFMM__FN void kifmm__lat_project_left(double *x, int n, int cols, int sd, const double *e)
{
    double sx[9];
    int i, j, b;
    for (j = 0; j < cols; j++) {
        double *xj = x + (size_t)j * n;
        for (b = 0; b < sd; b++) sx[b] = 0.0;
        for (i = 0; i < n; i++) sx[i % sd] += xj[i];
        for (i = 0; i < n; i++)
            for (b = 0; b < sd; b++) xj[i] -= e[i + (size_t)b * n] * sx[b];
    }
}

/* max |x_i| over n values */
KIFMM__FN double kifmm__max_abs(const double *x, size_t n)
{
    double m = 0.0;
    size_t i;
    for (i = 0; i < n; i++) m = fabs(x[i]) > m ? fabs(x[i]) : m;
    return m;
}

// >>fft

/* The downward check surface (order q = p + kifmm__check_diff, radius ai r,
 * ai = kifmm__alpha_inner) is the boundary of a q^3 lattice of spacing h =
 * 2 ai r / (q - 1). Each source multipole is first moved to a density on
 * the same lattice around its own box (conv, fitted on the upward check surface, so its field
 * outside is the multipole's); then K_t(i, j) = G(h (i - j) - 2 r t) depends
 * only on the lattice offset i - j, and the M2L of one box pair is a
 * circular convolution on an n^3 grid, n = 2q - 1: a pointwise product of
 * spectra, whose inverse gives the potentials on the check surface itself,
 * exactly the values the dense M2L computes. Spectra are real-to-complex (kz
 * in 0 .. n/2); the transforms are separable small DFTs pruned to the lattice
 * (n <= 25 here, where a radix FFT would gain little). Frequencies are
 * grouped in chunks of F; the products run per target parent over its
 * neighbouring source parents, one 8 x 8 complex block (child of source
 * parent -> child of target parent) per frequency, zero for adjacent child
 * pairs (those are not in the V list). A kernel with SD > 1 surface density
 * components has SD^2 such blocks per parent pair and frequency (target
 * component a, source component b), each component's spectra in a slot of
 * their own: SD forward and SD inverse transforms per parent, SD^2 times
 * the scalar products. A complex kernel (KIFMM_HAS_COMPLEX: SD = 2, the
 * real 2 x 2 form of one complex value) instead transforms its (re, im)
 * density as one complex lattice over the full grid (kz in 0 .. n - 1,
 * nh = n): one forward and one inverse transform and one block per
 * frequency, n^3 products against 4 n^2 (n/2 + 1). Below, p is the
 * lattice order q. */
#define KIFMM__FFT_F 4 /* frequencies per chunk (the AVX2 product kernels assume 4) */
#define KIFMM__FFT_KB_MB 8 /* the products' blocks are kept if they fit in this */
KIFMM__STATIC_ASSERT(KIFMM__FFT_F == 4, fft_product_kernels_take_4_frequencies_per_chunk);

typedef struct kifmm__fft {
    int p, n, nh, nf, nchunk, nfp, ne; /* nfp = nchunk * F */
    int single;                        /* spectra and products in float */
    int cplx;                          /* complex lattices, full spectra (nh = n) */
    int *ijk;                          /* lattice indices of the surface points */
    double *wr, *wi;                   /* exp(-2 pi i a b / n), [a * n + b] */
    double *wz;                        /* weights of the inverse real transform, / n^3 */
} kifmm__fft;

KIFMM__FN void kifmm__fft_free(kifmm__fft *pl)
{
    kifmm__free(pl->ijk); kifmm__free(pl->wr); kifmm__free(pl->wi); kifmm__free(pl->wz);
    memset(pl, 0, sizeof *pl);
}

KIFMM__FN int kifmm__fft_init(kifmm__fft *pl, int p, int cplx, size_t *held)
{
    int n = 2 * p - 1, nh = cplx ? n : n / 2 + 1, a, b, c = 0, i, j, k;
    memset(pl, 0, sizeof *pl);
    pl->p = p; pl->n = n; pl->nh = nh; pl->nf = n * n * nh; pl->cplx = cplx;
    pl->nchunk = (pl->nf + KIFMM__FFT_F - 1) / KIFMM__FFT_F;
    pl->nfp = pl->nchunk * KIFMM__FFT_F;
    pl->ne = kifmm__surf_count(p);
    pl->ijk = (int *)kifmm__take(held, (size_t)3 * pl->ne, sizeof(int));
    pl->wr = (double *)kifmm__take(held, (size_t)n * n, sizeof(double));
    pl->wi = (double *)kifmm__take(held, (size_t)n * n, sizeof(double));
    pl->wz = (double *)kifmm__take(held, (size_t)nh, sizeof(double));
    if (!pl->ijk || !pl->wr || !pl->wi || !pl->wz) return KIFMM_ERR_NOMEM;
    /* the order of kifmm__surf_unit */
    for (i = 0; i < p; i++)
        for (j = 0; j < p; j++)
            for (k = 0; k < p; k++) {
                if (!kifmm__surf_on(p, i, j, k)) continue;
                pl->ijk[3 * c] = i; pl->ijk[3 * c + 1] = j; pl->ijk[3 * c + 2] = k;
                c++;
            }
    for (a = 0; a < n; a++)
        for (b = 0; b < n; b++) {
            double ang = -6.283185307179586476925286766559 * (double)((a * b) % n) / n;
            pl->wr[a * n + b] = cos(ang);
            pl->wi[a * n + b] = sin(ang);
        }
    for (a = 0; a < nh; a++) pl->wz[a] = (a == 0 || cplx ? 1.0 : 2.0) / ((double)n * n * n);
    return KIFMM_SUCCESS;
}

/* Doubles of work space for kifmm__fft_grid. */
KIFMM__FN size_t kifmm__fft_work(const kifmm__fft *pl)
{
    return (size_t)4 * pl->n * pl->n * pl->nh + (size_t)pl->n * pl->n * pl->n;
}


/* Spectrum of an n^3 grid g ([(i n + j) n + k]; its imaginary part gi, or
 * NULL for a real grid) into khat (frequency f at 2 f, re and im), the
 * stored frequencies (kz below nh). */
KIFMM__FN void kifmm__fft_grid(const kifmm__fft *pl, const double *g, const double *gi,
                               double *khat, double *work)
{
    int n = pl->n, nh = pl->nh, i, j, k, kx, ky, kz;
    double *s1r = work, *s1i = s1r + n * n * nh, *s2r = s1i + n * n * nh, *s2i = s2r + n * n * nh;
    for (i = 0; i < n * n; i++)
        for (kz = 0; kz < nh; kz++) {
            double sr = 0, si = 0;
            for (k = 0; k < n; k++) {
                sr += g[i * n + k] * pl->wr[kz * n + k];
                si += g[i * n + k] * pl->wi[kz * n + k];
            }
            for (k = 0; gi && k < n; k++) {
                sr -= gi[i * n + k] * pl->wi[kz * n + k];
                si += gi[i * n + k] * pl->wr[kz * n + k];
            }
            s1r[i * nh + kz] = sr; s1i[i * nh + kz] = si;
        }
    for (i = 0; i < n; i++)
        for (ky = 0; ky < n; ky++)
            for (kz = 0; kz < nh; kz++) {
                double sr = 0, si = 0;
                for (j = 0; j < n; j++) {
                    double xr = s1r[(i * n + j) * nh + kz], xi = s1i[(i * n + j) * nh + kz];
                    double w0 = pl->wr[ky * n + j], w1 = pl->wi[ky * n + j];
                    sr += xr * w0 - xi * w1;
                    si += xr * w1 + xi * w0;
                }
                s2r[(i * n + ky) * nh + kz] = sr; s2i[(i * n + ky) * nh + kz] = si;
            }
    for (kx = 0; kx < n; kx++)
        for (ky = 0; ky < n; ky++)
            for (kz = 0; kz < nh; kz++) {
                double sr = 0, si = 0;
                size_t f = ((size_t)kx * n + ky) * nh + kz;
                for (i = 0; i < n; i++) {
                    double xr = s2r[(i * n + ky) * nh + kz], xi = s2i[(i * n + ky) * nh + kz];
                    double w0 = pl->wr[kx * n + i], w1 = pl->wi[kx * n + i];
                    sr += xr * w0 - xi * w1;
                    si += xr * w1 + xi * w0;
                }
                khat[2 * f] = sr; khat[2 * f + 1] = si;
            }
}

/* The cube's symmetries, for kernels with K(d) a function of |d|: a
 * transfer vector t is sigma c, c its magnitudes in descending order (one
 * of 16 vectors) and sigma a signed permutation, t_a = s_a c_pi(a).
 * Returns c's index. */
KIFMM__FN int kifmm__tv_turn(const int *t, int *pi, int *s)
{
    int a[3], o[3] = {0, 1, 2}, c[3], i, j;
    for (i = 0; i < 3; i++) a[i] = t[i] < 0 ? -t[i] : t[i];
    for (i = 1; i < 3; i++) /* axes by magnitude, descending, stable */
        for (j = i; j > 0 && a[o[j]] > a[o[j - 1]]; j--) {
            const int x = o[j];
            o[j] = o[j - 1];
            o[j - 1] = x;
        }
    for (i = 0; i < 3; i++) {
        c[i] = a[o[i]];
        pi[o[i]] = i;
        s[i] = t[i] < 0 ? -1 : 1;
    }
    return kifmm__transfer_index(c[0], c[1], c[2]);
}

/* The number of a turn (pi, s) of kifmm__tv_turn, below 72 */
KIFMM__FN int kifmm__turn_id(const int *pi, const int *s)
{
    return (pi[0] * 3 + pi[1]) * 8 + (s[0] < 0) * 4 + (s[1] < 0) * 2 + (s[2] < 0);
}

/* slot[t]: the place of transfer vector t among the 16 with t_x >= t_y >=
 * t_z >= 0 (those kifmm__tv_turn returns), in their order; -1 for the others */
KIFMM__FN void kifmm__tv_slots(int *slot)
{
    int tv, n = 0;
    for (tv = 0; tv < KIFMM__NT; tv++) {
        int d[3] = {0, 0, 0}, pi[3], sg[3];
        kifmm__transfer_vector(tv, d);
        slot[tv] = kifmm__tv_turn(d, pi, sg) == tv ? n++ : -1;
    }
}

/* The lattice offset e of a (2q - 1)^3 grid (components -(q - 1) .. q - 1)
 * as its absolute components sorted, a <= b <= c, into one index a q^2 + b
 * q + c: the same for the 48 images of e under the cube's symmetries (as
 * kifmm__tv_turn for the M2L's transfer vectors, over any range). */
KIFMM__FN int kifmm__lat_sorted(int64_t e, int q)
{
    const int w = 2 * q - 1;
    int a = abs((int)(e / (w * w)) - (q - 1)), b = abs((int)(e / w % w) - (q - 1));
    int c = abs((int)(e % w) - (q - 1)), t;
    if (a > b) t = a, a = b, b = t;
    if (b > c) t = b, b = c, c = t;
    if (a > b) t = a, a = b, b = t;
    return (a * q + b) * q + c;
}

/* The frequency of a grid's spectrum that gives frequency k of the grid
 * turned by sigma (kifmm__tv_turn): with G'[sigma x] = G[x], G'^[k] =
 * G^[k'], k'_pi(a) = s_a k_a (mod n); where k'_z is past the stored half,
 * G^[k'] = conj G^[-k'] (a real grid; a complex one stores every
 * frequency), and *conj is -1 (else 1). */
KIFMM__FN size_t kifmm__fft_turned(const kifmm__fft *pl, const int *pi, const int *s, const int *k, double *conj)
{
    const int n = pl->n, nh = pl->nh;
    int kp[3], a;
    for (a = 0; a < 3; a++) kp[pi[a]] = s[a] > 0 || k[a] == 0 ? k[a] : n - k[a];
    *conj = 1.0;
    if (kp[2] >= nh) {
        for (a = 0; a < 3; a++) kp[a] = kp[a] ? n - kp[a] : 0;
        *conj = -1.0;
    }
    return ((size_t)kp[0] * n + kp[1]) * nh + kp[2];
}

/* Ints per transfer vector of the FFT M2L's table of turns (P__khat_turns) */
#define KIFMM__KTAB_W(sd) (8 + 2 * (sd) * (sd))

/* Frequency chunk ch of the spectra of the 16 transfer vectors (khat,
 * P__khat_turned) and the table of turns ktab: for each turn (its number
 * t in ktab) and frequency fi of the chunk, the source frequency g[t F +
 * fi] and the conjugation cj[..] (kifmm__fft_turned; not for the padding
 * frequencies); with one component (sd 1) also the 316 spectra at the
 * chunk's frequencies, loc[(fi 316 + t) 2] (re, im; 0 at the padding). */
KIFMM__FN void kifmm__fft_chunk_turns(const kifmm__fft *pl, const double *khat, const int *ktab,
                                      int sd, int ch, size_t *g, double *cj, double *loc)
{
    const int w = KIFMM__KTAB_W(sd), nf = pl->nf - ch * KIFMM__FFT_F;
    unsigned char set[72];
    int t, fi;
    memset(set, 0, sizeof set);
    for (t = 0; t < KIFMM__NT; t++) {
        const int *e = ktab + (size_t)w * t;
        for (fi = 0; !set[e[7]] && fi < KIFMM__FFT_F && fi < nf; fi++) {
            const int f = ch * KIFMM__FFT_F + fi, n = pl->n, nh = pl->nh;
            const int k[3] = {f / (n * nh), f / nh % n, f % nh};
            g[e[7] * KIFMM__FFT_F + fi] = kifmm__fft_turned(pl, e, e + 3, k, &cj[e[7] * KIFMM__FFT_F + fi]);
        }
        set[e[7]] = 1;
        for (fi = 0; sd == 1 && fi < KIFMM__FFT_F; fi++) { /* turned once, here */
            const int at = e[7] * KIFMM__FFT_F + fi;
            const double *v = fi < nf ? khat + (g[at] * 16 + (size_t)e[6]) * 2 : NULL;
            loc[2 * ((size_t)fi * KIFMM__NT + t)] = v ? e[9] * v[0] : 0.0;
            loc[2 * ((size_t)fi * KIFMM__NT + t) + 1] = v ? e[9] * cj[at] * v[1] : 0.0;
        }
    }
}

/* Lanes of the batched transforms: the 8 children of one parent at once. */
#define KIFMM__FFT_L 8

/* Doubles of work space for one batched transform (forward or inverse). */
KIFMM__FN size_t kifmm__fft_work8(const kifmm__fft *pl)
{
    return (size_t)KIFMM__FFT_L * 2 * pl->nh * ((size_t)pl->n * pl->n + (size_t)pl->p * pl->n +
                                                 (size_t)pl->p * pl->p);
}

/* Transfer vector of each child pair of two parents at offset o (0..26,
 * (ox+1) 9 + (oy+1) 3 + (oz+1)): tv[(o 8 + cs) 8 + ct], -1 if adjacent. */
KIFMM__FN void kifmm__fft_tvmap(int *tv)
{
    int o, cs, ct;
    for (o = 0; o < 27; o++)
        for (cs = 0; cs < 8; cs++)
            for (ct = 0; ct < 8; ct++) {
                int dx = 2 * (o / 9 - 1) + (cs >> 2 & 1) - (ct >> 2 & 1);
                int dy = 2 * (o / 3 % 3 - 1) + (cs >> 1 & 1) - (ct >> 1 & 1);
                int dz = 2 * (o % 3 - 1) + (cs & 1) - (ct & 1);
                int near = dx >= -1 && dx <= 1 && dy >= -1 && dy <= 1 && dz >= -1 && dz <= 1;
                tv[(o * 8 + cs) * 8 + ct] = near ? -1 : kifmm__transfer_index(dx, dy, dz);
            }
}

/* STEP (a braced block) for each source child cs listed in h (count, then
 * which; variables cs and q of the caller). With all 8 the loop keeps its
 * fixed count: a loop over the list there took 15 % more time in the
 * uniform cube. */
#define KIFMM__FFT_CHILDREN(h, STEP)                                                          \
    if ((h)[0] == 8)                                                                          \
        for (cs = 0; cs < 8; cs++) STEP                                                       \
    else                                                                                      \
        for (q = 0; q < (h)[0]; q++) {                                                        \
            cs = (h)[1 + q];                                                                  \
            STEP                                                                              \
        }

/* One child cs and frequency fi of the products' accumulation for a vector
 * of 8 lanes (the 8 target children): R + i I += (kr + i ki) (xr + i xi),
 * with the block row k[fi 128 + cs 16] (re 8 | im 8) and the source
 * child's spectrum x[fi 16 + cs] (re), 8 further (im), in vectors V of 8
 * lanes (double with AVX-512, float with AVX2). */
#define KIFMM__FFT_STEP8(V, BCAST, LOAD, FMADD, FNMADD, R, I, fi)                              \
    {                                                                                          \
        const V xr = BCAST(x + (fi) * 16 + cs), xi = BCAST(x + (fi) * 16 + 8 + cs);            \
        V kr = LOAD(k + (fi) * 128 + cs * 16), ki = LOAD(k + (fi) * 128 + cs * 16 + 8);        \
        KIFMM__IN_REG(kr);                                                                     \
        KIFMM__IN_REG(ki);                                                                     \
        R = FMADD(kr, xr, R);                                                                  \
        R = FNMADD(ki, xi, R);                                                                 \
        I = FMADD(kr, xi, I);                                                                  \
        I = FMADD(ki, xr, I);                                                                  \
    }
/* The products of one target parent and chunk with the 4 frequencies at
 * once (8 accumulators over all e), then stored to oc; T, V as above. */
#define KIFMM__FFT_PRODUCTS8(T, V, ZERO, BCAST, LOAD, STORE, FMADD, FNMADD)                    \
    {                                                                                          \
        V r0 = ZERO, i0 = r0, r1 = r0, i1 = r0, r2 = r0, i2 = r0, r3 = r0, i3 = r0;            \
        for (e = 0; e < nn; e++) {                                                             \
            const T *x = sc + (size_t)nb[e] * KIFMM__FFT_F * 16;                               \
            const T *k = kb + (size_t)no[e] * KIFMM__FFT_F * 128;                              \
            const unsigned char *h = sch + 9 * (size_t)nb[e];                                  \
            int q;                                                                             \
            KIFMM__FFT_CHILDREN(h, {                                                           \
                KIFMM__FFT_STEP8(V, BCAST, LOAD, FMADD, FNMADD, r0, i0, 0)                     \
                KIFMM__FFT_STEP8(V, BCAST, LOAD, FMADD, FNMADD, r1, i1, 1)                     \
                KIFMM__FFT_STEP8(V, BCAST, LOAD, FMADD, FNMADD, r2, i2, 2)                     \
                KIFMM__FFT_STEP8(V, BCAST, LOAD, FMADD, FNMADD, r3, i3, 3)                     \
            })                                                                                 \
        }                                                                                      \
        STORE(oc, r0); STORE(oc + 8, i0); STORE(oc + 16, r1); STORE(oc + 24, i1);              \
        STORE(oc + 32, r2); STORE(oc + 40, i2); STORE(oc + 48, r3); STORE(oc + 56, i3);        \
    }
/* The AVX2 double products' step: child cs at two frequencies (fi and fi +
 * 1: x and x + 16) into the 8 accumulators a0..a3 (fi) and b0..b3 (fi + 1),
 * the 8 target children in two registers per part (variables of the
 * caller). */
#define KIFMM__FFT_STEP2D                                                                      \
    {                                                                                          \
        const __m256d xr = _mm256_broadcast_sd(x + cs), xi = _mm256_broadcast_sd(x + 8 + cs);  \
        const __m256d yr = _mm256_broadcast_sd(x + 16 + cs);                                   \
        const __m256d yi = _mm256_broadcast_sd(x + 24 + cs);                                   \
        const double *k0 = k + cs * 16, *k1 = k + 128 + cs * 16;                               \
        __m256d r0 = _mm256_load_pd(k0), r1 = _mm256_load_pd(k0 + 4);                          \
        __m256d i0 = _mm256_load_pd(k0 + 8), i1 = _mm256_load_pd(k0 + 12);                     \
        KIFMM__IN_REG(r0); KIFMM__IN_REG(r1); KIFMM__IN_REG(i0); KIFMM__IN_REG(i1);            \
        a0 = _mm256_fmadd_pd(r0, xr, a0); a1 = _mm256_fmadd_pd(r1, xr, a1);                    \
        a2 = _mm256_fmadd_pd(r0, xi, a2); a3 = _mm256_fmadd_pd(r1, xi, a3);                    \
        a0 = _mm256_fnmadd_pd(i0, xi, a0); a1 = _mm256_fnmadd_pd(i1, xi, a1);                  \
        a2 = _mm256_fmadd_pd(i0, xr, a2); a3 = _mm256_fmadd_pd(i1, xr, a3);                    \
        r0 = _mm256_load_pd(k1); r1 = _mm256_load_pd(k1 + 4);                                  \
        i0 = _mm256_load_pd(k1 + 8); i1 = _mm256_load_pd(k1 + 12);                             \
        KIFMM__IN_REG(r0); KIFMM__IN_REG(r1); KIFMM__IN_REG(i0); KIFMM__IN_REG(i1);            \
        b0 = _mm256_fmadd_pd(r0, yr, b0); b1 = _mm256_fmadd_pd(r1, yr, b1);                    \
        b2 = _mm256_fmadd_pd(r0, yi, b2); b3 = _mm256_fmadd_pd(r1, yi, b3);                    \
        b0 = _mm256_fnmadd_pd(i0, yi, b0); b1 = _mm256_fnmadd_pd(i1, yi, b1);                  \
        b2 = _mm256_fmadd_pd(i0, yr, b2); b3 = _mm256_fmadd_pd(i1, yr, b3);                    \
    }

/* The AVX-512 float products' step: a block row re|im in one register K
 * with A += K xr and B += K xi, for chunk frequency fi (variables of the
 * caller). */
#define KIFMM__FFT_STEP16(A, B, fi)                                                            \
    {                                                                                          \
        __m512 kk = _mm512_loadu_ps(k + (fi) * 128 + cs * 16);                                 \
        KIFMM__IN_REG(kk);                                                                     \
        A = _mm512_fmadd_ps(kk, _mm512_set1_ps(x[(fi) * 16 + cs]), A);                         \
        B = _mm512_fmadd_ps(kk, _mm512_set1_ps(x[(fi) * 16 + 8 + cs]), B);                     \
    }
#define KIFMM__FFT_STEPS16                                                                     \
    {                                                                                          \
        KIFMM__FFT_STEP16(a0, b0, 0) KIFMM__FFT_STEP16(a1, b1, 1)                              \
        KIFMM__FFT_STEP16(a2, b2, 2) KIFMM__FFT_STEP16(a3, b3, 3)                              \
    }
#if defined(__AVX512F__)
#define KIFMM__BCAST8D(p) _mm512_set1_pd(*(p))
#endif

#endif /* KIFMM_H_IMPL */

/* ======================================================================== */
/* 3b. MPI mode's shared part (KIFMM_MPI before an include; once per        */
/*     translation unit): docs/api.md, "MPI"                                */
/* ======================================================================== */
#if defined(KIFMM_MPI) && !defined(KIFMM_H_MPI_TYPES)
#define KIFMM_H_MPI_TYPES
#ifdef __cplusplus
extern "C++" {
#endif
#include <limits.h>
#include <mpi.h>
#ifdef __cplusplus
}
#endif
#endif

#if defined(KIFMM_MPI) && !defined(KIFMM_DECLARE) && !defined(KIFMM_H_MPI_IMPL)
#define KIFMM_H_MPI_IMPL
// >>mpi (shared): agreement, the partition, routes, regions

/* Every rank's result: its own if it failed, else the lowest (most
 * negative) of all ranks', so that every rank leaves a collective call
 * together. */
KIFMM__FN int kifmm__mpi_agree(MPI_Comm comm, int rc)
{
    int g = rc;
    if (MPI_Allreduce(&rc, &g, 1, MPI_INT, MPI_MIN, comm) != MPI_SUCCESS) return KIFMM_ERR_MPI;
    return rc ? rc : g;
}

/* The splitters of a Morton partition: rank j owns the keys in
 * [sp[j], sp[j + 1]), sp[0] = 0, sp[R] = 2^(3 KIFMM__D), each sp[j] the
 * smallest key below which at least j / R of the ranks' total weight lies.
 * k: this rank's n keys, sorted; cw: their weights' prefix sums (n + 1).
 * All R - 1 splitters are bisected together, one allreduce a step. */
KIFMM__FN int kifmm__mpi_split(MPI_Comm comm, int R, const uint64_t *k, const double *cw,
                               int64_t n, uint64_t *sp)
{
    const uint64_t top = (uint64_t)1 << (3 * KIFMM__D);
    double tot = 0.0, *c = (double *)kifmm__alloc((size_t)2 * R, sizeof(double));
    uint64_t *lo = (uint64_t *)kifmm__alloc((size_t)2 * R, sizeof(uint64_t)), *hi = lo + R;
    int j, it, rc = KIFMM_SUCCESS;
    if (!c || !lo) rc = KIFMM_ERR_NOMEM;
    rc = kifmm__mpi_agree(comm, rc); /* every rank bisects, or none */
    if (!rc && MPI_Allreduce((void *)&cw[n], &tot, 1, MPI_DOUBLE, MPI_SUM, comm) != MPI_SUCCESS)
        rc = KIFMM_ERR_MPI;
    for (j = 0; !rc && j < R; j++) lo[j] = 0, hi[j] = top;
    for (it = 0; !rc && it < 3 * KIFMM__D + 2; it++) {
        for (j = 1; j < R; j++) { /* the weight below the middle of each interval */
            const uint64_t mid = lo[j] + (hi[j] - lo[j]) / 2;
            int64_t a = 0, b = n;
            while (a < b) {
                const int64_t m = a + (b - a) / 2;
                if (k[m] < mid) a = m + 1;
                else b = m;
            }
            c[j] = cw[a];
        }
        if (MPI_Allreduce(MPI_IN_PLACE, c + 1, R - 1, MPI_DOUBLE, MPI_SUM, comm) != MPI_SUCCESS)
            rc = KIFMM_ERR_MPI;
        for (j = 1; !rc && j < R; j++) {
            const uint64_t mid = lo[j] + (hi[j] - lo[j]) / 2;
            if (c[j] >= tot * j / R) hi[j] = mid;
            else lo[j] = mid + 1;
        }
    }
    if (!rc) {
        sp[0] = 0;
        sp[R] = top;
        for (j = 1; j < R; j++) sp[j] = hi[j] > sp[j - 1] ? hi[j] : sp[j - 1];
    }
    kifmm__free(c);
    kifmm__free(lo);
    return rc;
}

/* The rank that owns key x (splitters sp of R ranks). */
KIFMM__FN int kifmm__mpi_owner(const uint64_t *sp, int R, uint64_t x)
{
    int a = 0, b = R - 1;
    while (a < b) {
        const int m = (a + b + 1) / 2;
        if (sp[m] <= x) a = m;
        else b = m - 1;
    }
    return a;
}

/* The key range [a, b) as aligned boxes, 4 values each (x, y, z of the
 * lower corner and the edge, in units of level KIFMM__D): at most
 * 14 KIFMM__D of them. */
KIFMM__FN int kifmm__mpi_range(uint64_t a, uint64_t b, int64_t *bx)
{
    int n = 0;
    while (a < b) {
        int k = 0;
        int64_t x[3];
        while (k < KIFMM__D && (a & ((8ULL << 3 * k) - 1)) == 0 && a + (8ULL << 3 * k) <= b) k++;
        kifmm__decode(a, x);
        bx[4 * n] = x[0], bx[4 * n + 1] = x[1], bx[4 * n + 2] = x[2];
        bx[4 * n + 3] = (int64_t)1 << k;
        n++;
        a += 1ULL << 3 * k;
    }
    return n;
}

/* 1 if the 3 x 3 x 3 boxes around the box of level l at anchor a meet one
 * of the nb boxes bx (kifmm__mpi_range): the box is then not well
 * separated from that region, whose points need its sources (or its
 * children's) rather than its equivalent density. */
KIFMM__FN int kifmm__mpi_near(int l, const int32_t *a, const int64_t *bx, int nb)
{
    const int64_t s = (int64_t)1 << (KIFMM__D - l);
    int i, d;
    for (i = 0; i < nb; i++) {
        int meet = 1;
        for (d = 0; d < 3; d++)
            meet &= bx[4 * i + d] < (a[d] + 2) * s && (a[d] - 1) * s < bx[4 * i + d] + bx[4 * i + 3];
        if (meet) return 1;
    }
    return 0;
}

/* Where the caller's points go: order (n: each point's index, grouped by
 * the rank it goes to), cnt and dsp (per rank, points sent), rcnt and rdsp
 * (per rank, points received); moved by kifmm__mpi_move. */
typedef struct {
    int64_t *order;
    int *cnt, *dsp, *rcnt, *rdsp;
    int64_t nrecv;
} kifmm__mpi_route;

KIFMM__FN void kifmm__mpi_route_free(kifmm__mpi_route *r)
{
    kifmm__free(r->order);
    kifmm__free(r->cnt);
    memset(r, 0, sizeof *r);
}

/* The route of n points whose owners are own[i] (R ranks); the result
 * agreed over comm (the caller frees r). */
KIFMM__FN int kifmm__mpi_route_make(MPI_Comm comm, int R, int64_t n, const int *own,
                                    kifmm__mpi_route *r)
{
    int64_t i, *pos = (int64_t *)kifmm__alloc((size_t)R + 1, sizeof(int64_t)), s = 0, t = 0;
    int j, rc = KIFMM_SUCCESS;
    memset(r, 0, sizeof *r);
    r->order = (int64_t *)kifmm__alloc((size_t)n + 1, sizeof(int64_t));
    r->cnt = (int *)kifmm__alloc((size_t)4 * R, sizeof(int));
    if (!pos || !r->order || !r->cnt) {
        kifmm__free(pos);
        return kifmm__mpi_agree(comm, KIFMM_ERR_NOMEM);
    }
    r->dsp = r->cnt + R, r->rcnt = r->cnt + 2 * R, r->rdsp = r->cnt + 3 * R;
    memset(pos, 0, ((size_t)R + 1) * sizeof(int64_t));
    for (i = 0; i < n; i++) pos[own[i] + 1]++;
    for (j = 0; j < R; j++) {
        if (pos[j + 1] > INT_MAX || s > INT_MAX - pos[j + 1]) rc = KIFMM_ERR_COUNT;
        r->cnt[j] = (int)pos[j + 1];
        r->dsp[j] = (int)s;
        s += pos[j + 1];
        pos[j + 1] += pos[j];
    }
    for (i = 0; i < n; i++) r->order[pos[own[i]]++] = i;
    kifmm__free(pos);
    if ((rc = kifmm__mpi_agree(comm, rc))) return rc; /* every rank exchanges counts, or none */
    if (MPI_Alltoall(r->cnt, 1, MPI_INT, r->rcnt, 1, MPI_INT, comm) != MPI_SUCCESS)
        return KIFMM_ERR_MPI;
    for (j = 0; j < R; j++) {
        if (t > INT_MAX - r->rcnt[j]) rc = KIFMM_ERR_COUNT;
        r->rdsp[j] = (int)t;
        t += r->rcnt[j];
    }
    r->nrecv = t;
    return rc;
}

/* Values of `per` bytes a point along route r (back: the other way),
 * from send (in route order) into recv. */
KIFMM__FN int kifmm__mpi_move(MPI_Comm comm, const kifmm__mpi_route *r, int back,
                              const void *send, void *recv, size_t per)
{
    MPI_Datatype ty;
    int rc;
    if (per > INT_MAX) return KIFMM_ERR_COUNT;
    if (MPI_Type_contiguous((int)per, MPI_BYTE, &ty) != MPI_SUCCESS) return KIFMM_ERR_MPI;
    if (MPI_Type_commit(&ty) != MPI_SUCCESS) {
        MPI_Type_free(&ty);
        return KIFMM_ERR_MPI;
    }
    if (back)
        rc = MPI_Alltoallv((void *)send, r->rcnt, r->rdsp, ty, recv, r->cnt, r->dsp, ty, comm);
    else
        rc = MPI_Alltoallv((void *)send, r->cnt, r->dsp, ty, recv, r->rcnt, r->rdsp, ty, comm);
    MPI_Type_free(&ty);
    return rc == MPI_SUCCESS ? KIFMM_SUCCESS : KIFMM_ERR_MPI;
}

/* The ranks a rank exchanges ghost points and equivalent densities with:
 * n of them, rank[i], and per rank the offsets of its ghost points and of
 * its boxes in the sender's or receiver's lists (g, p: n + 1 each). */
typedef struct {
    int n;
    int *rank;
    int64_t *g, *p;
    MPI_Request *req;
} kifmm__mpi_peers;

KIFMM__FN void kifmm__mpi_peers_free(kifmm__mpi_peers *p)
{
    kifmm__free(p->rank);
    kifmm__free(p->g);
    kifmm__free(p->req);
    memset(p, 0, sizeof *p);
}

/* Peers from per-rank counts c (2 per rank: ghost points, boxes), the
 * ranks with any. */
KIFMM__FN int kifmm__mpi_peers_make(int R, const int64_t *c, kifmm__mpi_peers *p)
{
    int j, n = 0;
    memset(p, 0, sizeof *p);
    for (j = 0; j < R; j++) n += c[2 * j] + c[2 * j + 1] > 0;
    p->rank = (int *)kifmm__alloc((size_t)n + 1, sizeof(int));
    p->g = (int64_t *)kifmm__alloc((size_t)2 * (n + 1), sizeof(int64_t));
    p->req = (MPI_Request *)kifmm__alloc((size_t)n + 1, sizeof(MPI_Request));
    if (!p->rank || !p->g || !p->req) {
        kifmm__mpi_peers_free(p);
        return KIFMM_ERR_NOMEM;
    }
    p->p = p->g + n + 1;
    p->g[0] = p->p[0] = 0;
    for (j = 0; j < R; j++)
        if (c[2 * j] + c[2 * j + 1] > 0) {
            p->rank[p->n] = j;
            p->g[p->n + 1] = p->g[p->n] + c[2 * j];
            p->p[p->n + 1] = p->p[p->n] + c[2 * j + 1];
            p->n++;
        }
    return KIFMM_SUCCESS;
}

/* One message of `bytes` bytes to or from each peer (recv: from), buffers
 * at buf + off[i]; the requests in p->req, waited on by kifmm__mpi_wait. */
KIFMM__FN int kifmm__mpi_post(MPI_Comm comm, kifmm__mpi_peers *p, int recv, char *buf,
                              const size_t *off)
{
    int i;
    for (i = 0; i < p->n; i++) {
        const size_t b = off[i + 1] - off[i];
        int rc;
        if (b > INT_MAX) return KIFMM_ERR_COUNT;
        rc = recv ? MPI_Irecv(buf + off[i], (int)b, MPI_BYTE, p->rank[i], 7, comm, &p->req[i])
                  : MPI_Isend(buf + off[i], (int)b, MPI_BYTE, p->rank[i], 7, comm, &p->req[i]);
        if (rc != MPI_SUCCESS) return KIFMM_ERR_MPI;
    }
    return KIFMM_SUCCESS;
}

KIFMM__FN int kifmm__mpi_wait(kifmm__mpi_peers *p)
{
    if (p->n && MPI_Waitall(p->n, p->req, MPI_STATUSES_IGNORE) != MPI_SUCCESS)
        return KIFMM_ERR_MPI;
    return KIFMM_SUCCESS;
}

/* First box of level l in the dense numbering of levels 2 .. lc. */
KIFMM__FN int32_t kifmm__mpi_coff(int l)
{
    int32_t o = 0;
    int k;
    for (k = 2; k < l; k++) o += (int32_t)1 << (3 * k);
    return o;
}

typedef struct {
    int32_t a[4]; /* level, anchor */
    int32_t k;    /* received box */
} kifmm__mpi_box;

KIFMM__FN int kifmm__mpi_box_cmp(const void *x, const void *y)
{
    const int32_t *a = ((const kifmm__mpi_box *)x)->a, *b = ((const kifmm__mpi_box *)y)->a;
    int i;
    for (i = 0; i < 4; i++)
        if (a[i] != b[i]) return a[i] < b[i] ? -1 : 1;
    return ((const kifmm__mpi_box *)x)->k - ((const kifmm__mpi_box *)y)->k;
}

/* Level and anchor of coarse box i (dense numbering). */
KIFMM__FN void kifmm__mpi_coarse_box(int32_t i, int32_t *a)
{
    int64_t x[3];
    int l = 2;
    while (kifmm__mpi_coff(l + 1) <= i) l++;
    kifmm__decode((uint64_t)(i - kifmm__mpi_coff(l)), x);
    a[0] = l, a[1] = (int32_t)x[0], a[2] = (int32_t)x[1], a[3] = (int32_t)x[2];
}

#endif /* KIFMM_H_MPI_IMPL */
#endif /* KIFMM__PREC_PASS, the normal pass's first part */

#ifdef KIFMM__PREC_PASS
// >>prec

/* The code that double and float share, compiled once for each: the header
 * includes itself with KIFMM__PREC_PASS 1 (double) and 2 (float), and only
 * this section is read then. KIFMM__T is the type, KIFMM__P(name) appends
 * the suffix (d or f). Functions here have real line numbers; the ISA's
 * vector types and intrinsics for T are named KIFMM__V* below. */
#if KIFMM__PREC_PASS == 1
#define KIFMM__T double
#define KIFMM__P(name) name##d
#else
#define KIFMM__T float
#define KIFMM__P(name) name##f
#endif

/* ---- column GEMM ----------------------------------------------------------- */

#if defined(__AVX512F__)
/* AVX-512: 3 vectors x 8 columns of C in registers, masked rows. */
#if KIFMM__PREC_PASS == 1
#define KIFMM__V __m512d
#define KIFMM__VL 8
#define KIFMM__VM __mmask8
#define KIFMM__VMLOAD(m, p) _mm512_maskz_loadu_pd(m, p)
#define KIFMM__VMSTORE(p, m, v) _mm512_mask_storeu_pd(p, m, v)
#define KIFMM__VFMA _mm512_fmadd_pd
#define KIFMM__VSET1 _mm512_set1_pd
#define KIFMM__VZERO _mm512_setzero_pd()
#define KIFMM__VADD _mm512_add_pd
#define KIFMM__GC_MR KIFMM__GC_MR_D
#else
#define KIFMM__V __m512
#define KIFMM__VL 16
#define KIFMM__VM __mmask16
#define KIFMM__VMLOAD(m, p) _mm512_maskz_loadu_ps(m, p)
#define KIFMM__VMSTORE(p, m, v) _mm512_mask_storeu_ps(p, m, v)
#define KIFMM__VFMA _mm512_fmadd_ps
#define KIFMM__VSET1 _mm512_set1_ps
#define KIFMM__VZERO _mm512_setzero_ps()
#define KIFMM__VADD _mm512_add_ps
#define KIFMM__GC_MR KIFMM__GC_MR_F
#endif

/* The rows [0, n) of a vector (all for n >= VL, none for n <= 0). */
KIFMM__FN KIFMM__VM KIFMM__P(kifmm__gc_mask)(int n)
{
    const unsigned all = (1u << KIFMM__VL) - 1u;
    return (KIFMM__VM)(n <= 0 ? 0u : n >= KIFMM__VL ? all : (1u << n) - 1u);
}

/* One row kk of B's column j into the three accumulators of that column. */
#define KIFMM__GC_ROW(j)                                                                       \
    x = KIFMM__VSET1(b[j][kk]);                                                                \
    s##j##0 = KIFMM__VFMA(a0, x, s##j##0);                                                     \
    s##j##1 = KIFMM__VFMA(a1, x, s##j##1);                                                     \
    s##j##2 = KIFMM__VFMA(a2, x, s##j##2);

/* One tile: C[0:mr, 0:nr] (+)= A[0:mr, 0:kc] B[0:kc, 0:nr], mr <= 3 VL,
 * nr <= 8 (the columns past nr repeat the last one and are not stored). */
KIFMM__FN void KIFMM__P(kifmm__gc_micro)(int mr, int nr, int kc, const KIFMM__T *a, int lda,
                                         const KIFMM__T *const *b, int acc, KIFMM__T *const *c)
{
    const KIFMM__VM m[3] = {KIFMM__P(kifmm__gc_mask)(mr), KIFMM__P(kifmm__gc_mask)(mr - KIFMM__VL),
                            KIFMM__P(kifmm__gc_mask)(mr - 2 * KIFMM__VL)};
    KIFMM__V s00 = KIFMM__VZERO, s01 = s00, s02 = s00, s10 = s00, s11 = s00, s12 = s00;
    KIFMM__V s20 = s00, s21 = s00, s22 = s00, s30 = s00, s31 = s00, s32 = s00;
    KIFMM__V s40 = s00, s41 = s00, s42 = s00, s50 = s00, s51 = s00, s52 = s00;
    KIFMM__V s60 = s00, s61 = s00, s62 = s00, s70 = s00, s71 = s00, s72 = s00;
    KIFMM__V all[8][3];
    int kk, j, h;
    for (kk = 0; kk < kc; kk++) {
        const KIFMM__T *ak = a + (size_t)kk * lda;
        const KIFMM__V a0 = KIFMM__VMLOAD(m[0], ak), a1 = KIFMM__VMLOAD(m[1], ak + KIFMM__VL);
        const KIFMM__V a2 = KIFMM__VMLOAD(m[2], ak + 2 * KIFMM__VL);
        KIFMM__V x;
        KIFMM__GC_ROW(0) KIFMM__GC_ROW(1) KIFMM__GC_ROW(2) KIFMM__GC_ROW(3)
        KIFMM__GC_ROW(4) KIFMM__GC_ROW(5) KIFMM__GC_ROW(6) KIFMM__GC_ROW(7)
    }
    all[0][0] = s00; all[0][1] = s01; all[0][2] = s02; all[1][0] = s10; all[1][1] = s11;
    all[1][2] = s12; all[2][0] = s20; all[2][1] = s21; all[2][2] = s22; all[3][0] = s30;
    all[3][1] = s31; all[3][2] = s32; all[4][0] = s40; all[4][1] = s41; all[4][2] = s42;
    all[5][0] = s50; all[5][1] = s51; all[5][2] = s52; all[6][0] = s60; all[6][1] = s61;
    all[6][2] = s62; all[7][0] = s70; all[7][1] = s71; all[7][2] = s72;
    for (j = 0; j < nr; j++)
        for (h = 0; h < 3 && h * KIFMM__VL < mr; h++) {
            KIFMM__T *cj = c[j] + h * KIFMM__VL;
            KIFMM__V v = all[j][h];
            if (acc) v = KIFMM__VADD(KIFMM__VMLOAD(m[h], cj), v);
            KIFMM__VMSTORE(cj, m[h], v);
        }
}
#undef KIFMM__GC_ROW
#elif defined(__AVX2__) && defined(__FMA__)
/* AVX2: 2 vectors x 6 columns of C in registers, masked rows. */
#if KIFMM__PREC_PASS == 1
#define KIFMM__V __m256d
#define KIFMM__VL 4
#define KIFMM__VLOADU _mm256_loadu_pd
#define KIFMM__VMLOAD(m, p) _mm256_maskload_pd(p, m)
#define KIFMM__VMSTORE(p, m, v) _mm256_maskstore_pd(p, m, v)
#define KIFMM__VFMA _mm256_fmadd_pd
#define KIFMM__VBCAST _mm256_broadcast_sd
#define KIFMM__VZERO _mm256_setzero_pd()
#define KIFMM__VADD _mm256_add_pd
#define KIFMM__GC_MR KIFMM__GC_MR_D
KIFMM__FN __m256i kifmm__gc_maskd(int n)
{
    return _mm256_cmpgt_epi64(_mm256_set1_epi64x(n), _mm256_setr_epi64x(0, 1, 2, 3));
}
#else
#define KIFMM__V __m256
#define KIFMM__VL 8
#define KIFMM__VLOADU _mm256_loadu_ps
#define KIFMM__VMLOAD(m, p) _mm256_maskload_ps(p, m)
#define KIFMM__VMSTORE(p, m, v) _mm256_maskstore_ps(p, m, v)
#define KIFMM__VFMA _mm256_fmadd_ps
#define KIFMM__VBCAST _mm256_broadcast_ss
#define KIFMM__VZERO _mm256_setzero_ps()
#define KIFMM__VADD _mm256_add_ps
#define KIFMM__GC_MR KIFMM__GC_MR_F
KIFMM__FN __m256i kifmm__gc_maskf(int n)
{
    return _mm256_cmpgt_epi32(_mm256_set1_epi32(n), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
}
#endif

/* One row kk of B's column j into the two accumulators of that column. */
#define KIFMM__GC_ROW(j)                                                                       \
    x = KIFMM__VBCAST(b##j + kk);                                                              \
    s##j##0 = KIFMM__VFMA(a0, x, s##j##0);                                                     \
    s##j##1 = KIFMM__VFMA(a1, x, s##j##1);

/* One tile: C[0:mr, 0:nr] (+)= A[0:mr, 0:kc] B[0:kc, 0:nr], mr <= 2 VL,
 * nr <= 6 (the columns past nr repeat the last one and are not stored). */
KIFMM__FN void KIFMM__P(kifmm__gc_micro)(int mr, int nr, int kc, const KIFMM__T *a, int lda,
                                         const KIFMM__T *const *b, int acc, KIFMM__T *const *c)
{
    const __m256i m0 = KIFMM__P(kifmm__gc_mask)(mr), m1 = KIFMM__P(kifmm__gc_mask)(mr - KIFMM__VL);
    KIFMM__V s00 = KIFMM__VZERO, s01 = s00, s10 = s00, s11 = s00, s20 = s00, s21 = s00;
    KIFMM__V s30 = s00, s31 = s00, s40 = s00, s41 = s00, s50 = s00, s51 = s00;
    KIFMM__V all[6][2];
    const KIFMM__T *b0 = b[0], *b1 = b[1], *b2 = b[2], *b3 = b[3], *b4 = b[4], *b5 = b[5];
    int kk, j, h;
    for (kk = 0; kk < kc; kk++) {
        const KIFMM__T *ak = a + (size_t)kk * lda;
        const int full = mr == 2 * KIFMM__VL;
        const KIFMM__V a0 = full ? KIFMM__VLOADU(ak) : KIFMM__VMLOAD(m0, ak);
        const KIFMM__V a1 = full ? KIFMM__VLOADU(ak + KIFMM__VL) : KIFMM__VMLOAD(m1, ak + KIFMM__VL);
        KIFMM__V x;
        KIFMM__GC_ROW(0) KIFMM__GC_ROW(1) KIFMM__GC_ROW(2)
        KIFMM__GC_ROW(3) KIFMM__GC_ROW(4) KIFMM__GC_ROW(5)
    }
    all[0][0] = s00; all[0][1] = s01; all[1][0] = s10; all[1][1] = s11;
    all[2][0] = s20; all[2][1] = s21; all[3][0] = s30; all[3][1] = s31;
    all[4][0] = s40; all[4][1] = s41; all[5][0] = s50; all[5][1] = s51;
    for (j = 0; j < nr; j++)
        for (h = 0; h < 2; h++) {
            KIFMM__T *cj = c[j] + h * KIFMM__VL;
            const __m256i mh = h ? m1 : m0;
            KIFMM__V v = all[j][h];
            if (acc) v = KIFMM__VADD(KIFMM__VMLOAD(mh, cj), v);
            KIFMM__VMSTORE(cj, mh, v);
        }
}
#undef KIFMM__GC_ROW
#undef KIFMM__VLOADU
#undef KIFMM__VBCAST
#endif

#if KIFMM__GC_FAST
/* C(:, j) (+)= A B(:, j) over ncol columns by pointers (see >>linalg): k in
 * equal blocks of at most KC (no short last block), tiles of MR x NR. */
KIFMM__FN void KIFMM__P(kifmm__gemm_cols)(int m, int k, const KIFMM__T *a, int lda, int ncol,
                                          const KIFMM__T *const *bp, KIFMM__T *const *cp, int acc,
                                          KIFMM__T *work)
{
    int k0, i0, j0, j, i, nkb, kb;
    (void)work;
    if (k <= 0) {
        if (!acc)
            for (j = 0; j < ncol; j++)
                for (i = 0; i < m; i++) cp[j][i] = 0;
        return;
    }
    nkb = (k + KIFMM__GC_KC - 1) / KIFMM__GC_KC;
    kb = (k + nkb - 1) / nkb;
    for (k0 = 0; k0 < k; k0 += kb) {
        const int kc = k - k0 < kb ? k - k0 : kb;
        for (i0 = 0; i0 < m; i0 += KIFMM__GC_MR)
            for (j0 = 0; j0 < ncol; j0 += KIFMM__GC_NR) {
                const KIFMM__T *bt[KIFMM__GC_NR];
                KIFMM__T *ct[KIFMM__GC_NR];
                const int nr = ncol - j0 < KIFMM__GC_NR ? ncol - j0 : KIFMM__GC_NR;
                for (j = 0; j < KIFMM__GC_NR; j++) {
                    const int jj = j0 + (j < nr ? j : nr - 1);
                    bt[j] = bp[jj] + k0;
                    ct[j] = cp[jj] + i0;
                }
                KIFMM__P(kifmm__gc_micro)(m - i0 < KIFMM__GC_MR ? m - i0 : KIFMM__GC_MR, nr, kc,
                                          a + i0 + (size_t)k0 * lda, lda, bt, acc || k0 > 0, ct);
            }
    }
}
#else
/* Without AVX2: the columns gathered into work ((k + m) x ncol) for one BLAS
 * call, the results added or copied back (see >>linalg). */
KIFMM__FN void KIFMM__P(kifmm__gemm_cols)(int m, int k, const KIFMM__T *a, int lda, int ncol,
                                          const KIFMM__T *const *bp, KIFMM__T *const *cp, int acc,
                                          KIFMM__T *work)
{
    KIFMM__T *bw = work, *cw = work + (size_t)k * ncol;
    int i, j;
    if (m <= 0 || ncol <= 0) return;
    for (j = 0; j < ncol; j++) memcpy(bw + (size_t)j * k, bp[j], (size_t)k * sizeof(KIFMM__T));
#if KIFMM__PREC_PASS == 1
    cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, m, ncol, k, 1.0, a, lda, bw,
                k > 0 ? k : 1, 0.0, cw, m);
#else
    cblas_sgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, m, ncol, k, 1.0f, a, lda, bw,
                k > 0 ? k : 1, 0.0f, cw, m);
#endif
    for (j = 0; j < ncol; j++)
        for (i = 0; i < m; i++)
            cp[j][i] = acc ? cp[j][i] + cw[(size_t)j * m + i] : cw[(size_t)j * m + i];
}
#endif

/* ---- FFT transforms (the spectra's precision) ------------------------------ */

/* d += x w over n complex values in split form (dr, di += (xr, xi) (w0 +
 * i w1)), the one step of every separable DFT stage; n is a multiple of the
 * 8 lanes, in blocks of which compilers vectorise it at -O2. */
KIFMM__FN void KIFMM__P(kifmm__caxpy)(int n, KIFMM__T w0, KIFMM__T w1,
                                      const KIFMM__T *KIFMM__RESTRICT xr,
                                      const KIFMM__T *KIFMM__RESTRICT xi,
                                      KIFMM__T *KIFMM__RESTRICT dr, KIFMM__T *KIFMM__RESTRICT di)
{
    int q, v;
    for (q = 0; q < n; q += KIFMM__FFT_L)
        for (v = q; v < q + KIFMM__FFT_L; v++) {
            dr[v] += xr[v] * w0 - xi[v] * w1;
            di[v] += xr[v] * w1 + xi[v] * w0;
        }
}

/* d = sum_j x_j (wr + i sg wi)[j ws] over nin inputs x_j = x + j xs (len values) */
KIFMM__FN void KIFMM__P(kifmm__dft_sum)(int len, int nin, const double *wr, const double *wi,
                                        int ws, double sg, const KIFMM__T *xr,
                                        const KIFMM__T *xi, size_t xs, KIFMM__T *dr,
                                        KIFMM__T *di)
{
    int j;
    memset(dr, 0, sizeof(KIFMM__T) * (size_t)len);
    memset(di, 0, sizeof(KIFMM__T) * (size_t)len);
    for (j = 0; j < nin; j++)
        KIFMM__P(kifmm__caxpy)(len, (KIFMM__T)wr[j * ws], (KIFMM__T)(sg * wi[j * ws]),
                               xr + j * xs, xi + j * xs, dr, di);
}

/* The first stage of the forward transforms: along z, each lattice point's
 * 8 lane values (component comp of sd: m[8 (s sd + comp) + v]; complex
 * lattices: components comp and comp + 1 its re and im) into the (x, y)
 * row of its kx = a, ky = b (s1 re, im). */
KIFMM__FN void KIFMM__P(kifmm__fft_zstage)(const kifmm__fft *pl, const double *m, int sd, int comp,
                                           KIFMM__T *s1r, KIFMM__T *s1i)
{
    const int L = KIFMM__FFT_L, p = pl->p, n = pl->n, nh = pl->nh;
    int s, kz, v;
    memset(s1r, 0, sizeof(KIFMM__T) * 2 * L * p * p * nh);
    for (s = 0; s < pl->ne; s++) {
        const int a = pl->ijk[3 * s], b = pl->ijk[3 * s + 1], c = pl->ijk[3 * s + 2];
        KIFMM__T mv[KIFMM__FFT_L], mi[KIFMM__FFT_L];
        KIFMM__T *r = s1r + L * (a * p + b) * nh, *im = s1i + L * (a * p + b) * nh;
        for (v = 0; v < L; v++) mv[v] = (KIFMM__T)m[L * (s * sd + comp) + v];
        if (pl->cplx) {
            for (v = 0; v < L; v++) mi[v] = (KIFMM__T)m[L * (s * sd + comp + 1) + v];
            for (kz = 0; kz < nh; kz++) /* (mv + i mi) (w0 + i w1) */
                KIFMM__P(kifmm__caxpy)(L, (KIFMM__T)pl->wr[kz * n + c], (KIFMM__T)pl->wi[kz * n + c],
                                       mv, mi, r + L * kz, im + L * kz);
            continue;
        }
        for (kz = 0; kz < nh; kz++) {
            const KIFMM__T w0 = (KIFMM__T)pl->wr[kz * n + c], w1 = (KIFMM__T)pl->wi[kz * n + c];
            for (v = 0; v < L; v++) {
                r[L * kz + v] += mv[v] * w0;
                im[L * kz + v] += mv[v] * w1;
            }
        }
    }
}

/* Spectra of 8 surface densities at once, m[(s sd + comp) 8 + v] (lane v =
 * child v; component comp of sd per lattice point), into out: frequency f of lane v goes to out[(f / F) cstride + (f % F) 16 +
 * v] (re) and 8 further (im), the layout of the products. Pruned: only the
 * p^3 lattice is nonzero. Every stage is a loop over the 8 lanes with the
 * same twiddle, which compilers vectorise. */
KIFMM__FN void KIFMM__P(kifmm__fft_forward8)(const kifmm__fft *pl, const double *m, int sd,
                                             int comp, KIFMM__T *out, size_t cstride,
                                             KIFMM__T *work)
{
    const int L = KIFMM__FFT_L, p = pl->p, n = pl->n, nh = pl->nh;
    int i, kx, ky, q, v;
    KIFMM__T *s1r = work, *s1i = s1r + L * p * p * nh, *s2r = s1i + L * p * p * nh;
    KIFMM__T *s2i = s2r + L * p * n * nh, *tr = s2i + L * p * n * nh, *ti = tr + L * n * nh;
    KIFMM__P(kifmm__fft_zstage)(pl, m, sd, comp, s1r, s1i);
    for (i = 0; i < p; i++)
        for (ky = 0; ky < n; ky++)
            KIFMM__P(kifmm__dft_sum)(L * nh, p, pl->wr + ky * n, pl->wi + ky * n, 1, 1.0,
                                     s1r + L * i * p * nh, s1i + L * i * p * nh, (size_t)L * nh,
                                     s2r + L * (i * n + ky) * nh, s2i + L * (i * n + ky) * nh);
    for (kx = 0; kx < n; kx++) {
        const int f0 = kx * n * nh;
        KIFMM__P(kifmm__dft_sum)(L * n * nh, p, pl->wr + kx * n, pl->wi + kx * n, 1, 1.0, s2r, s2i,
                                 (size_t)L * n * nh, tr, ti);
        for (q = 0; q < n * nh; q++) {
            const int f = f0 + q;
            KIFMM__T *o = out + (size_t)(f / KIFMM__FFT_F) * cstride + (size_t)(f % KIFMM__FFT_F) * 16;
            for (v = 0; v < L; v++) {
                o[v] = tr[L * q + v];
                o[8 + v] = ti[L * q + v];
            }
        }
    }
}

/* 8 half spectra addressed as in forward8 -> the values at the ne lattice
 * surface points, component comp of sd: chk[(s sd + comp) 8 + v]
 * (complex lattices: 8 full spectra -> re at comp, im at comp + 1). */
KIFMM__FN void KIFMM__P(kifmm__fft_inverse8)(const kifmm__fft *pl, const KIFMM__T *in,
                                             size_t cstride, int sd, int comp, double *chk,
                                             KIFMM__T *work)
{
    const int L = KIFMM__FFT_L, p = pl->p, n = pl->n, nh = pl->nh;
    int i, j, k, kz, q, s, v;
    KIFMM__T *yr = work, *yi = yr + L * n * n * nh, *t1r = yi + L * n * n * nh;
    KIFMM__T *t1i = t1r + L * p * n * nh, *t2r = t1i + L * p * n * nh, *t2i = t2r + L * p * p * nh;
    for (q = 0; q < pl->nf; q++) {
        const KIFMM__T *x = in + (size_t)(q / KIFMM__FFT_F) * cstride + (size_t)(q % KIFMM__FFT_F) * 16;
        for (v = 0; v < L; v++) {
            yr[L * q + v] = x[v];
            yi[L * q + v] = x[8 + v];
        }
    }
    for (i = 0; i < p; i++)
        KIFMM__P(kifmm__dft_sum)(L * n * nh, n, pl->wr + i, pl->wi + i, n, -1.0, yr, yi,
                                 (size_t)L * n * nh, t1r + L * i * n * nh, t1i + L * i * n * nh);
    for (i = 0; i < p; i++)
        for (j = 0; j < p; j++)
            KIFMM__P(kifmm__dft_sum)(L * nh, n, pl->wr + j, pl->wi + j, n, -1.0,
                                     t1r + L * i * n * nh, t1i + L * i * n * nh, (size_t)L * nh,
                                     t2r + L * (i * p + j) * nh, t2i + L * (i * p + j) * nh);
    for (s = 0; s < pl->ne; s++) {
        KIFMM__T acc[KIFMM__FFT_L], aci[KIFMM__FFT_L];
        const KIFMM__T *xr, *xi;
        i = pl->ijk[3 * s];
        j = pl->ijk[3 * s + 1];
        k = pl->ijk[3 * s + 2];
        xr = t2r + L * (i * p + j) * nh;
        xi = t2i + L * (i * p + j) * nh;
        for (v = 0; v < L; v++) acc[v] = 0, aci[v] = 0;
        if (pl->cplx) /* (xr + i xi) conj(w) */
            KIFMM__P(kifmm__dft_sum)(L, nh, pl->wr + k, pl->wi + k, n, -1.0, xr, xi, L, acc, aci);
        for (kz = 0; !pl->cplx && kz < nh; kz++) { /* its real part, twice for kz > 0 */
            const KIFMM__T w0 = (KIFMM__T)(pl->wz[kz] * pl->wr[kz * n + k]);
            const KIFMM__T w1 = (KIFMM__T)(pl->wz[kz] * pl->wi[kz * n + k]);
            for (v = 0; v < L; v++) acc[v] += xr[L * kz + v] * w0 + xi[L * kz + v] * w1;
        }
        for (v = 0; pl->cplx && v < L; v++) { /* wz = 1 / n^3 throughout */
            acc[v] *= (KIFMM__T)pl->wz[0];
            chk[L * (s * sd + comp + 1) + v] = (double)(aci[v] * (KIFMM__T)pl->wz[0]);
        }
        for (v = 0; v < L; v++) chk[L * (s * sd + comp) + v] = (double)acc[v];
    }
}

/* ---- FFT products ---------------------------------------------------------- */

/* The 8 x 8 blocks of frequency chunk ch for the 27 parent offsets and the
 * sd x sd kernel components (target a, source b), from the 316 spectra of
 * each component (khat[((f 316 + t) sd^2 + a sd + b) 2]) or, with ktab,
 * from the 16 they are turned from (P__khat_turned): block (a, o, b) at
 * kb[(((a 27 + o) sd + b) F + fi) 128 + cs 16 + ct] (re), + 8 (im); zero
 * for adjacent child pairs (tv[...] < 0). The turned values are those the
 * 316's would hold: a sign times the 16's, conjugated where the turned
 * frequency's mirror is stored. */
KIFMM__FN void KIFMM__P(kifmm__fft_blocks)(const kifmm__fft *pl, const double *khat, const int *ktab,
                                           const int *tv, int sd, int ch, KIFMM__T *kb)
{
    const int sd2 = sd * sd, w = KIFMM__KTAB_W(sd), nf = pl->nf - ch * KIFMM__FFT_F;
    const size_t bs = (size_t)27 * sd * KIFMM__FFT_F * 128; /* block (a, o, b) - (a - 1, o, b) */
    size_t g[72 * KIFMM__FFT_F];  /* ktab: each turn's source frequency and */
    double cj[72 * KIFMM__FFT_F]; /* conjugation (kifmm__fft_chunk_turns) */
    double loc[KIFMM__NT * KIFMM__FFT_F * 2]; /* one component: the chunk's 316 spectra */
    const double *kc = khat + (size_t)ch * KIFMM__FFT_F * KIFMM__NT * sd2 * 2; /* the chunk's */
    int o, fi, cs, ct, a, b, t;
    if (ktab) kifmm__fft_chunk_turns(pl, khat, ktab, sd, ch, g, cj, loc);
    if (ktab && sd == 1) ktab = NULL, kc = loc; /* then as the 316's */
    for (o = 0; o < 27; o++)
        for (cs = 0; cs < 8; cs++)
            for (ct = 0; ct < 8; ct++) {
                const int *e;
                KIFMM__T *k0 = kb + (size_t)o * sd * KIFMM__FFT_F * 128 + cs * 16 + ct; /* a = b = 0 */
                t = tv[(o * 8 + cs) * 8 + ct];
                e = ktab && t >= 0 ? ktab + (size_t)w * t : NULL;
                for (fi = 0; fi < KIFMM__FFT_F; fi++) {
                    const int at = e ? e[7] * KIFMM__FFT_F + fi : 0;
                    const double *s = t < 0 || (e && fi >= nf) ? NULL
                                      : e ? khat + (g[at] * 16 + (size_t)e[6]) * sd2 * 2
                                          : kc + ((size_t)fi * KIFMM__NT + t) * sd2 * 2;
                    KIFMM__T *kf = k0 + (size_t)fi * 128;
                    if (!s) { /* adjacent, or padding */
                        for (a = 0; a < sd; a++)
                            for (b = 0; b < sd; b++) {
                                KIFMM__T *z = kf + a * bs + (size_t)b * KIFMM__FFT_F * 128;
                                z[0] = z[8] = 0;
                            }
                    } else if (e) { /* a sign times the 16's component, conjugated or not */
                        const int *fr = e + 8, *sg = e + 8 + sd2;
                        const double c = cj[at];
                        for (a = 0; a < sd; a++)
                            for (b = 0; b < sd; b++) {
                                KIFMM__T *z = kf + a * bs + (size_t)b * KIFMM__FFT_F * 128;
                                const double *v = s + 2 * fr[a * sd + b], sv = sg[a * sd + b];
                                z[0] = (KIFMM__T)(sv * v[0]), z[8] = (KIFMM__T)(sv * c * v[1]);
                            }
                    } else {
                        for (a = 0; a < sd; a++)
                            for (b = 0; b < sd; b++) {
                                KIFMM__T *z = kf + a * bs + (size_t)b * KIFMM__FFT_F * 128;
                                z[0] = (KIFMM__T)s[2 * (a * sd + b)], z[8] = (KIFMM__T)s[2 * (a * sd + b) + 1];
                            }
                    }
                }
            }
}

/* The products of kifmm__fft_products (below) in portable C. */
KIFMM__FN void KIFMM__P(kifmm__fft_products_c)(int nn, const int32_t *nb, const unsigned char *no,
                                               const unsigned char *sch, const KIFMM__T *sc,
                                               const KIFMM__T *kb, KIFMM__T *oc)
{
    int e, fi, cs, ct, q;
    memset(oc, 0, sizeof(KIFMM__T) * 16 * KIFMM__FFT_F);
    for (e = 0; e < nn; e++)
        for (fi = 0; fi < KIFMM__FFT_F; fi++) {
            const KIFMM__T *x = sc + ((size_t)nb[e] * KIFMM__FFT_F + fi) * 16;
            const KIFMM__T *k = kb + ((size_t)no[e] * KIFMM__FFT_F + fi) * 128;
            const unsigned char *h = sch + 9 * (size_t)nb[e];
            KIFMM__T *acc = oc + fi * 16;
            for (q = 0; q < h[0]; q++)
                for (cs = h[1 + q], ct = 0; ct < 8; ct++) {
                    const KIFMM__T kr = k[cs * 16 + ct], ki = k[cs * 16 + 8 + ct];
                    acc[ct] += kr * x[cs] - ki * x[8 + cs];
                    acc[8 + ct] += kr * x[8 + cs] + ki * x[cs];
                }
        }
}

/* One target parent, one chunk: oc[fi 16 ..] = sum over its nn source
 * parents e of K[no[e]][fi] (8 x 8 complex) times the 8 child spectra
 * sc[nb[e]] at fi (re 8 | im 8). Only the children listed in sch[9 nb[e]]
 * (count, then which) have sources: the others' spectra are zero and are
 * skipped (on surfaces and clusters about half of them). */
KIFMM__FN void KIFMM__P(kifmm__fft_products)(int nn, const int32_t *nb, const unsigned char *no,
                                             const unsigned char *sch, const KIFMM__T *sc,
                                             const KIFMM__T *kb, KIFMM__T *oc)
{
    int e, cs;
#if defined(__AVX512F__) && KIFMM__PREC_PASS == 1
    /* the 4 frequencies of the chunk at once, the 8 target children in one
     * register: 8 accumulators over all e, 4 FMAs per child and frequency
     * with the child's spectrum broadcast from memory */
    KIFMM__FFT_PRODUCTS8(double, __m512d, _mm512_setzero_pd(), KIFMM__BCAST8D, _mm512_load_pd,
                         _mm512_store_pd, _mm512_fmadd_pd, _mm512_fnmadd_pd)
#elif defined(__AVX512F__)
    /* a block row, re 8 | im 8, in one register K: per child and frequency
     * one load and two FMAs, A += K xr and B += K xi, and the complex product
     * formed once at the end, re = A.lo - B.hi and im = A.hi + B.lo (the
     * AVX2 kernel needs two loads and two broadcasts for four FMAs of half
     * the width, which kept it bound by the loads) */
    __m512 a0 = _mm512_setzero_ps(), b0 = a0, a1 = a0, b1 = a0, a2 = a0, b2 = a0, a3 = a0, b3 = a0;
    const __m512 sg = _mm512_setr_ps(-1.0f, -1.0f, -1.0f, -1.0f, -1.0f, -1.0f, -1.0f, -1.0f, 1.0f,
                                     1.0f, 1.0f, 1.0f, 1.0f, 1.0f, 1.0f, 1.0f);
    for (e = 0; e < nn; e++) {
        const float *x = sc + (size_t)nb[e] * KIFMM__FFT_F * 16;
        const float *k = kb + (size_t)no[e] * KIFMM__FFT_F * 128;
        const unsigned char *h = sch + 9 * (size_t)nb[e];
        int q;
        KIFMM__FFT_CHILDREN(h, KIFMM__FFT_STEPS16)
    }
    /* B with its halves swapped is (ki xi | kr xi) */
    _mm512_storeu_ps(oc, _mm512_fmadd_ps(sg, _mm512_shuffle_f32x4(b0, b0, 0x4E), a0));
    _mm512_storeu_ps(oc + 16, _mm512_fmadd_ps(sg, _mm512_shuffle_f32x4(b1, b1, 0x4E), a1));
    _mm512_storeu_ps(oc + 32, _mm512_fmadd_ps(sg, _mm512_shuffle_f32x4(b2, b2, 0x4E), a2));
    _mm512_storeu_ps(oc + 48, _mm512_fmadd_ps(sg, _mm512_shuffle_f32x4(b3, b3, 0x4E), a3));
#elif defined(__AVX2__) && defined(__FMA__) && KIFMM__PREC_PASS == 1
    int fi;
    /* two frequencies at a time: 8 accumulators in registers over all e */
    for (fi = 0; fi < KIFMM__FFT_F; fi += 2) {
        __m256d a0 = _mm256_setzero_pd(), a1 = a0, a2 = a0, a3 = a0, b0 = a0, b1 = a0, b2 = a0, b3 = a0;
        for (e = 0; e < nn; e++) {
            const double *x = sc + ((size_t)nb[e] * KIFMM__FFT_F + fi) * 16;
            const double *k = kb + ((size_t)no[e] * KIFMM__FFT_F + fi) * 128;
            const unsigned char *h = sch + 9 * (size_t)nb[e];
            int q;
            KIFMM__FFT_CHILDREN(h, KIFMM__FFT_STEP2D)
        }
        _mm256_store_pd(oc + fi * 16, a0); _mm256_store_pd(oc + fi * 16 + 4, a1);
        _mm256_store_pd(oc + fi * 16 + 8, a2); _mm256_store_pd(oc + fi * 16 + 12, a3);
        _mm256_store_pd(oc + fi * 16 + 16, b0); _mm256_store_pd(oc + fi * 16 + 20, b1);
        _mm256_store_pd(oc + fi * 16 + 24, b2); _mm256_store_pd(oc + fi * 16 + 28, b3);
    }
#elif defined(__AVX2__) && defined(__FMA__)
    /* the 4 frequencies of a chunk at once: 8 accumulators over all e */
    KIFMM__FFT_PRODUCTS8(float, __m256, _mm256_setzero_ps(), _mm256_broadcast_ss, _mm256_load_ps,
                         _mm256_store_ps, _mm256_fmadd_ps, _mm256_fnmadd_ps)
#else
    (void)e;
    (void)cs;
    KIFMM__P(kifmm__fft_products_c)(nn, nb, no, sch, sc, kb, oc);
#endif
}

#undef KIFMM__T
#undef KIFMM__P
#undef KIFMM__V
#undef KIFMM__VL
#undef KIFMM__VM
#undef KIFMM__VMLOAD
#undef KIFMM__VMSTORE
#undef KIFMM__VFMA
#undef KIFMM__VSET1
#undef KIFMM__VZERO
#undef KIFMM__VADD
#undef KIFMM__GC_MR
#endif /* KIFMM__PREC_PASS */

#ifndef KIFMM__PREC_PASS /* the normal pass, continued */
#ifdef KIFMM__PREC_NOW
/* >>prec for double, then for float */
#undef KIFMM__PREC_NOW
#define KIFMM__PREC_PASS 1
#include "kifmm.h"
#undef KIFMM__PREC_PASS
#define KIFMM__PREC_PASS 2
#include "kifmm.h"
#undef KIFMM__PREC_PASS
#endif

/* ======================================================================== */
/* 4. Kernel template (once per include)                                    */
/* ======================================================================== */

// >>params

#ifndef KIFMM_KERNEL
#define KIFMM_KERNEL laplace
#endif
#ifndef KIFMM_REAL
#define KIFMM_REAL double
#endif

#if KIFMM__CAT(KIFMM__REAL_IS_, KIFMM_REAL) == 1
#define KIFMM__FLOAT 0
#define KIFMM__CMAX KIFMM_COORD_MAX
#define KIFMM__EMIN KIFMM_EXTENT_MIN
#elif KIFMM__CAT(KIFMM__REAL_IS_, KIFMM_REAL) == 2
#define KIFMM__FLOAT 1
#define KIFMM__CMAX KIFMM_COORD_MAX_FLOAT
#define KIFMM__EMIN KIFMM_EXTENT_MIN_FLOAT
#else
#error "kifmm.h: KIFMM_REAL must be double or float"
#endif

/* default names: kifmm_<kernel>, and kifmm_<kernel>f for float instances */
#ifndef KIFMM_NAME
#if KIFMM__FLOAT
#define KIFMM_NAME KIFMM__CAT3(kifmm_, KIFMM_KERNEL, f)
#else
#define KIFMM_NAME KIFMM__CAT(kifmm_, KIFMM_KERNEL)
#endif
#endif

#define KIFMM__K(suffix) KIFMM__CAT3(kifmm_kernel_, KIFMM_KERNEL, suffix)
#define KIFMM__F(suffix) KIFMM__CAT(KIFMM_NAME, suffix)
#define KIFMM__R KIFMM_REAL

/* The linkage of this instance's public functions (see LINKAGE MODES). */
#if defined(KIFMM_DECLARE) && defined(KIFMM_IMPLEMENT)
#error "kifmm.h: define KIFMM_DECLARE or KIFMM_IMPLEMENT before an include, not both"
#endif
#if defined(KIFMM_DECLARE) || defined(KIFMM_IMPLEMENT)
#ifdef __cplusplus
#define KIFMM__API extern "C"
#else
#define KIFMM__API extern
#endif
#else
#define KIFMM__API KIFMM__FN
#endif

// >>api

/* The handle: opaque to the caller; defined in >>handle. */
typedef struct KIFMM_NAME KIFMM_NAME;

/* A plan: options, surfaces and operators that several handles share
 * (<prefix>_plan_create); opaque, defined in >>handle. */
typedef struct KIFMM__F(_plan) KIFMM__F(_plan);

/* <prefix>_create: build the tree and the operators for these points.
 *   out      (out) the new handle; NULL on failure
 *   opts     (in)  options, NULL for all defaults (see kifmm_opts)
 *   nsources, src_xyz  (in) source points, x[3*i+k]
 *   ntargets, trg_xyz  (in) target points, x[3*j+k]
 * Coordinates, densities and outputs are KIFMM_REAL (double unless the
 * instance was made with KIFMM_REAL float). The handle keeps no pointer to the
 * caller's arrays. Returns KIFMM_SUCCESS or a negative kifmm result; on
 * failure nothing is leaked. Thread safe: distinct handles may be created
 * concurrently. */
KIFMM__API int KIFMM__F(_create)(KIFMM_NAME **out, const kifmm_opts *opts, int64_t nsources,
                                 const KIFMM__R *src_xyz, int64_t ntargets,
                                 const KIFMM__R *trg_xyz);

/* <prefix>_update_points: new points for the handle, as create would take
 * them (counts may change; targets may be the sources, the same array),
 * keeping its options and its operators: the tree, the lists and the
 * workspace are built anew; the operators are kept where they still apply
 * (scale-invariant kernels: always; others: the levels whose box width is
 * unchanged, all of them with opts.domain; periodic trees: the far images
 * unless the root or the level-1 leaves change). Results are those of a
 * handle created afresh on the same points with the same options. Returns
 * KIFMM_SUCCESS, or create's errors for the points (KIFMM_ERR_NULL,
 * KIFMM_ERR_COUNT, KIFMM_ERR_NONFINITE, KIFMM_ERR_RANGE, KIFMM_ERR_DOMAIN,
 * KIFMM_ERR_PERIOD, KIFMM_ERR_NOMEM, ...), and then the handle is as it was,
 * valid for its old points. Not thread safe on one handle. */
KIFMM__API int KIFMM__F(_update_points)(KIFMM_NAME *h, int64_t nsources, const KIFMM__R *src_xyz,
                                        int64_t ntargets, const KIFMM__R *trg_xyz);

/* <prefix>_plan_create: a plan for the options opts (NULL: the defaults),
 * to share between handles (<prefix>_create_with_plan): the surfaces, the
 * FFT's transforms, and the operators each handle's tree needs, built by
 * the first handle that needs them and kept while a handle uses them
 * (scale-invariant kernels: their one set, built here and kept with the
 * plan). The options are checked as create checks them. Returns
 * KIFMM_SUCCESS or create's errors for options; *out is NULL on failure.
 * Thread safe. */
KIFMM__API int KIFMM__F(_plan_create)(KIFMM__F(_plan) **out, const kifmm_opts *opts);

/* <prefix>_create_with_plan: a handle on these points (as create) that
 * takes its options and operators from plan and holds its own tree and
 * workspace; stats.bytes leaves the plan out. Handles on one plan may be
 * created, updated, evaluated and destroyed from different threads at once
 * (each handle used by one thread at a time). Returns create's errors for
 * points, KIFMM_ERR_NULL for a NULL plan. */
KIFMM__API int KIFMM__F(_create_with_plan)(KIFMM_NAME **out, KIFMM__F(_plan) *plan, int64_t nsources,
                                           const KIFMM__R *src_xyz, int64_t ntargets,
                                           const KIFMM__R *trg_xyz);

/* <prefix>_plan_destroy: the caller's reference to the plan let go; the
 * plan lives until its last handle is destroyed too. NULL is a no-op. */
KIFMM__API void KIFMM__F(_plan_destroy)(KIFMM__F(_plan) *plan);

/* <prefix>_tree: the handle's tree (its sorted points, boxes and
 * interaction lists), for handles of other kernels of the same precision
 * to be made on (<prefix>_create_on_tree) without sorting and refining the
 * points again, by this translation unit or another (each tree is freed
 * with the allocator of the unit that built it). Borrowed: valid while the
 * handle keeps it (until it is destroyed or given other points by
 * update_points or update_on_tree); a handle made on it holds it from then
 * on. NULL for a NULL handle. */
KIFMM__API kifmm_tree *KIFMM__F(_tree)(const KIFMM_NAME *h);

/* <prefix>_create_on_tree: a handle on the points of tree (as create on
 * the points the tree was built for, in the same order), sharing the
 * tree: the sorted points, boxes and lists are not copied. Its own
 * options opts (NULL: the defaults), but those that shape the tree must
 * be the tree's: period and domain equal, or all 0 (both) to take the
 * tree's; leaf_size and max_depth equal, or 0 to take the tree's (the
 * handle keeps them: options reports them, and its update_points builds
 * trees with them). The tree must come from an instance of the
 * same precision, and carry V lists if this instance's M2L is the dense
 * one (KIFMM_M2L_DENSE, or more than 9 surface components). Its own
 * operators, near-field plan and workspace; stats.bytes leaves the tree
 * out. Returns create's errors for options, KIFMM_ERR_NULL (out or tree),
 * KIFMM_ERR_TREE (the tree does not fit) or KIFMM_ERR_NOMEM. Thread safe:
 * handles on one tree may be made, used and destroyed from different
 * threads at once (each handle by one thread at a time). */
KIFMM__API int KIFMM__F(_create_on_tree)(KIFMM_NAME **out, const kifmm_opts *opts, kifmm_tree *tree);

/* <prefix>_create_with_plan_on_tree: create_on_tree with the options and
 * operators of plan (see create_with_plan): the plan's period and domain
 * must be the tree's; its leaf size and depth are the tree's where
 * plan_create was given 0. */
KIFMM__API int KIFMM__F(_create_with_plan_on_tree)(KIFMM_NAME **out, KIFMM__F(_plan) *plan,
                                                   kifmm_tree *tree);

/* <prefix>_update_on_tree: the handle moved onto the points of tree, as
 * update_points would move it onto the points the tree was built for
 * (keeping its options, plan and operators), sharing the tree: after
 * <other>_update_points(a, ...), b follows a with
 * <prefix>_update_on_tree(b, <other>_tree(a)). Returns KIFMM_ERR_NULL,
 * KIFMM_ERR_TREE (as create_on_tree, against the handle's options: its
 * period and domain must be the tree's) or KIFMM_ERR_NOMEM, and then the
 * handle is as it was. */
KIFMM__API int KIFMM__F(_update_on_tree)(KIFMM_NAME *h, kifmm_tree *tree);

/* <prefix>_evaluate: out[j*TRG_DIM + k] for every target, in the caller's
 * order, from densities[i*SRC_DIM + d]. Outputs are overwritten. Returns
 * KIFMM_SUCCESS; KIFMM_ERR_NULL, KIFMM_ERR_DENSITY (a density NaN or
 * infinite) or KIFMM_ERR_NEUTRAL (periodic, see kifmm_opts.period), and
 * then out is untouched; or KIFMM_ERR_OVERFLOW, an output not finite though
 * the inputs are (densities near the precision's largest value, points a
 * hair apart), and then out holds the outputs as computed. The handle holds
 * the workspace and the timings: not thread safe on one handle (use one
 * handle per thread). */
KIFMM__API int KIFMM__F(_evaluate)(KIFMM_NAME *h, const KIFMM__R *densities, KIFMM__R *out);

/* <prefix>_evaluate_many: nrhs density vectors at once, densities as nrhs
 * consecutive blocks of nsources*SRC_DIM, outputs as nrhs consecutive blocks
 * of ntargets*TRG_DIM (each block laid out as in evaluate). The kernel is
 * evaluated once per point pair for up to 8 vectors (generic kernel loops)
 * and the translations run as GEMMs over boxes and vectors together. Outputs
 * are overwritten; out may be the densities' own array (in place) or overlap
 * it. Returns KIFMM_SUCCESS, KIFMM_ERR_NULL, KIFMM_ERR_COUNT (nrhs < 0, or
 * more vectors than any array holds), KIFMM_ERR_NOMEM (workspace for more
 * vectors than before, or the copy of overlapping densities), and those of
 * evaluate, with out untouched except after KIFMM_ERR_OVERFLOW. nrhs == 0
 * does nothing. Not thread safe on one handle. */
KIFMM__API int KIFMM__F(_evaluate_many)(KIFMM_NAME *h, int nrhs, const KIFMM__R *densities,
                                        KIFMM__R *out);

#if defined(KIFMM_MPI)
/* <prefix>_create_mpi (KIFMM_MPI defined before the include): a handle
 * over the points of every rank of comm, each rank passing any of them
 * (its own sources and targets, in any order, none at all included): one
 * FMM over all the points, whose evaluate gives each rank the outputs at
 * the targets it passed, in its order, from the densities of the sources
 * it passed. Collective over comm, as are evaluate, evaluate_many,
 * update_points and destroy on the handle (every rank calls them, with its
 * own points and arrays, the same count of vectors); stats reports this
 * rank's part (mpi_* fields). Each rank returns its own error if it met
 * one, else the lowest of the other ranks' (every rank leaves together);
 * KIFMM_ERR_PERIODIC for periodic options, KIFMM_ERR_MPI where MPI is not
 * initialised or a kernel has no MPI mode yet. With one rank the handle is
 * create's, bit for bit. Destroy it before MPI_Finalize. docs/api.md, "MPI". */
KIFMM__API int KIFMM__F(_create_mpi)(KIFMM_NAME **out, MPI_Comm comm, const kifmm_opts *opts,
                                     int64_t nsources_local, const KIFMM__R *src_xyz,
                                     int64_t ntargets_local, const KIFMM__R *trg_xyz);
#endif

/* <prefix>_destroy: free a handle and everything it owns. NULL is a no-op. */
KIFMM__API void KIFMM__F(_destroy)(KIFMM_NAME *h);

/* <prefix>_stats: tree size, memory held, the code paths of the build, and
 * the time of create's stages and of the last evaluate's passes (see
 * kifmm_stats). */
KIFMM__API int KIFMM__F(_stats)(const KIFMM_NAME *h, kifmm_stats *out);

/* <prefix>_options: the options the handle uses, defaults resolved (kernel
 * parameters included). */
KIFMM__API int KIFMM__F(_options)(const KIFMM_NAME *h, kifmm_opts *used);

/* <prefix>_direct: the sums over all nsources sources at each of ntargets
 * targets, computed directly from the kernel's _eval (no tree, no
 * expansions, no hooks), in double whatever KIFMM_REAL: out[j*TRG_DIM + k]
 * from densities[i*SRC_DIM + d], laid out as in evaluate; a target at a
 * source's position gets nothing from it (as in evaluate). The reference to
 * check a kernel or a handle against: pass the handle's options and a
 * subset of its targets (O(nsources * ntargets) work). Of opts (NULL: the
 * defaults) it uses kernel_param and nthreads; periodic options are
 * refused (KIFMM_ERR_PERIODIC: the sums are those of free space). out may
 * overlap the densities (they are copied first) but not the points
 * (KIFMM_ERR_OVERLAP). With no targets nothing is read but the points.
 * Returns KIFMM_SUCCESS, KIFMM_ERR_NULL, KIFMM_ERR_COUNT,
 * KIFMM_ERR_NONFINITE, KIFMM_ERR_RANGE, KIFMM_ERR_PARAM, an option's error,
 * KIFMM_ERR_PERIODIC, KIFMM_ERR_DENSITY, KIFMM_ERR_OVERLAP,
 * KIFMM_ERR_OVERFLOW or KIFMM_ERR_NOMEM; out is written only on success.
 * Thread safe. */
KIFMM__API int KIFMM__F(_direct)(const kifmm_opts *opts, int64_t nsources, const KIFMM__R *src_xyz,
                                 const KIFMM__R *densities, int64_t ntargets,
                                 const KIFMM__R *trg_xyz, KIFMM__R *out);

/* <prefix>_estimate_bytes: *bytes gets an estimate of what create would
 * hold (stats.bytes) for nsources sources and ntargets targets, before any
 * point exists: a model of the tree that points spread through a volume
 * give, with create's own sizes of operators, buffers and workspace. Pass
 * ntargets = KIFMM_SAME_POINTS when the targets will be the sources (the
 * same array for both). Points on surfaces or in clusters make other trees:
 * docs/api.md, "Memory", gives the ratios measured. One vector's
 * workspace: evaluate_many with more vectors adds to it. Options are
 * checked as create checks them. An oscillating kernel's wide levels at a
 * higher order (>>orders) are counted where opts.domain gives the root,
 * else every level at opts.order. Returns KIFMM_SUCCESS, KIFMM_ERR_NULL,
 * KIFMM_ERR_COUNT, an option's error, KIFMM_ERR_PARAM, KIFMM_ERR_PERIODIC,
 * KIFMM_ERR_FREQUENCY (with opts.domain, as create) or KIFMM_ERR_NOMEM;
 * *bytes is written only on success. Thread safe. */
KIFMM__API int KIFMM__F(_estimate_bytes)(const kifmm_opts *opts, int64_t nsources, int64_t ntargets,
                                         double *bytes);

#ifndef KIFMM_DECLARE /* the implementation, from here to >>epilogue */

// >>params (the kernel)

#if !KIFMM__K(_SRC_DIM) || !KIFMM__K(_TRG_DIM)
#error "kifmm.h: the kernel named by KIFMM_KERNEL must define kifmm_kernel_<name>_SRC_DIM and _TRG_DIM (see docs/kernels.md)"
#endif

/* A role kernel's optional features: its _HAS mask (in parentheses, of
 * KIFMM_HAS_* bits: a misspelt bit name stops the build, see below), or,
 * for kernels written before the mask, the flags _SETUP, _P2P, _P2PF, ...
 * each defined as 1. */
#define KIFMM__LEGACY_HAS(k)                                                                \
    (KIFMM__IS_ONE(KIFMM__CAT3(kifmm_kernel_, k, _SETUP)) * KIFMM_HAS_SETUP |               \
     KIFMM__IS_ONE(KIFMM__CAT3(kifmm_kernel_, k, _P2P)) * KIFMM_HAS_P2P |                   \
     KIFMM__IS_ONE(KIFMM__CAT3(kifmm_kernel_, k, _P2PF)) * KIFMM_HAS_P2PF |                 \
     KIFMM__IS_ONE(KIFMM__CAT3(kifmm_kernel_, k, _P2PN)) * KIFMM_HAS_P2PN |                 \
     KIFMM__IS_ONE(KIFMM__CAT3(kifmm_kernel_, k, _P2PNF)) * KIFMM_HAS_P2PNF |               \
     KIFMM__IS_ONE(KIFMM__CAT3(kifmm_kernel_, k, _P2PS)) * KIFMM_HAS_P2PS |                 \
     KIFMM__IS_ONE(KIFMM__CAT3(kifmm_kernel_, k, _P2PSF)) * KIFMM_HAS_P2PSF |               \
     KIFMM__IS_ONE(KIFMM__CAT3(kifmm_kernel_, k, _P2PSN)) * KIFMM_HAS_P2PSN |               \
     KIFMM__IS_ONE(KIFMM__CAT3(kifmm_kernel_, k, _P2PSNF)) * KIFMM_HAS_P2PSNF)
#define KIFMM__HAS_OF(k)                                                                    \
    KIFMM__IF(KIFMM__IS_PAREN(KIFMM__CAT3(kifmm_kernel_, k, _HAS)))(                        \
        KIFMM__CAT3(kifmm_kernel_, k, _HAS), KIFMM__LEGACY_HAS(k))

/* The kernel's traits, resolved once. UD: density components per source
 * point in the caller's array; QD: the components the kernel is linear in
 * (UD, or _DENSITY_DIM for a kernel with KIFMM_HAS_DENSITY, whose _density
 * function maps the caller's UD to them when they are gathered: the
 * q_j n_k of stokes_dl); TD: outputs per target; SD: density components per
 * point of the equivalent surfaces (the surface kernel's). */
#define KIFMM__UD KIFMM__K(_SRC_DIM)
#if KIFMM__HAS_OF(KIFMM_KERNEL) & KIFMM_HAS_DENSITY
#define KIFMM__QD KIFMM__K(_DENSITY_DIM)
#else
#define KIFMM__QD KIFMM__UD
#endif
#define KIFMM__TD KIFMM__K(_TRG_DIM)

/* The four kernel roles (docs/kernels.md), each a kernel name:
 *   QT  points -> targets (TD x QD): the kernel itself;
 *   SC  surface -> check surface (SD x SD): the surface kernel, _EQUIV, or
 *       the kernel itself when TD == QD (unless it sets _USE_EQUIV to 1:
 *       laplace_cd_grad, 4 densities and 4 outputs, on Laplace surfaces);
 *   ST  surface -> targets (TD x SD): the kernel itself when QD == SD,
 *       else _SURFACE;
 *   QC  points -> check surface (SD x QD): SC when QD == SD, the kernel
 *       itself when TD == SD (unless it sets _USE_CHECK to 1: stokes_pvel,
 *       whose outputs are not its check potentials), else _CHECK.
 * The Laplace dipole kernels of kifmm_kernels.h name all three. */
#define KIFMM__ROLE_QT KIFMM_KERNEL
#if KIFMM__TD == KIFMM__QD && !KIFMM__IS_ONE(KIFMM__K(_USE_EQUIV))
#define KIFMM__ROLE_SC KIFMM_KERNEL
#else
#define KIFMM__ROLE_SC KIFMM__K(_EQUIV)
#endif
/* kifmm_kernel_<the role's kernel><suffix>; a concatenation of its own, as
 * the role's name may itself expand through KIFMM__CAT */
#define KIFMM__RCAT_(a, b, c) a##b##c
#define KIFMM__RCAT(a, b, c) KIFMM__RCAT_(a, b, c)
#define KIFMM__R_(role, suffix) KIFMM__RCAT(kifmm_kernel_, KIFMM__ROLE_##role, suffix)
#define KIFMM__SD KIFMM__R_(SC, _SRC_DIM)
/* ST_IN, QC_IN: the density components ST and QC take (QD when the role is
 * the kernel itself, whose _SRC_DIM counts the caller's densities) */
#if KIFMM__QD == KIFMM__SD
#define KIFMM__ROLE_ST KIFMM_KERNEL
#define KIFMM__ROLE_QC KIFMM__ROLE_SC
#define KIFMM__ST_IN KIFMM__QD
#define KIFMM__QC_IN KIFMM__R_(QC, _SRC_DIM)
#elif KIFMM__TD == KIFMM__SD && !KIFMM__IS_ONE(KIFMM__K(_USE_CHECK))
#define KIFMM__ROLE_ST KIFMM__K(_SURFACE)
#define KIFMM__ROLE_QC KIFMM_KERNEL
#define KIFMM__ST_IN KIFMM__R_(ST, _SRC_DIM)
#define KIFMM__QC_IN KIFMM__QD
#else
#define KIFMM__ROLE_ST KIFMM__K(_SURFACE)
#define KIFMM__ROLE_QC KIFMM__K(_CHECK)
#define KIFMM__ST_IN KIFMM__R_(ST, _SRC_DIM)
#define KIFMM__QC_IN KIFMM__R_(QC, _SRC_DIM)
#endif
KIFMM__STATIC_ASSERT(KIFMM__R_(SC, _TRG_DIM) == KIFMM__SD && KIFMM__ST_IN == KIFMM__SD &&
                         KIFMM__R_(ST, _TRG_DIM) == KIFMM__TD && KIFMM__QC_IN == KIFMM__QD &&
                         KIFMM__R_(QC, _TRG_DIM) == KIFMM__SD,
                     KIFMM__CAT(KIFMM_NAME, _kernel_roles_must_have_matching_dimensions));

/* Scale invariance and degree are the surface kernel's (SC): they decide
 * whether the operators, all built from SC, serve every level, and how check
 * potentials scale with the box size. The degree is read only when SC is
 * invariant. */
#define KIFMM__SI KIFMM__R_(SC, _SCALE_INVARIANT)
#if KIFMM__SI
#define KIFMM__DEGREE KIFMM__R_(SC, _DEGREE)
#else
#define KIFMM__DEGREE 0
#endif

#define KIFMM__HAS_QT KIFMM__HAS_OF(KIFMM__ROLE_QT)
#define KIFMM__HAS_ST KIFMM__HAS_OF(KIFMM__ROLE_ST)
#define KIFMM__HAS_QC KIFMM__HAS_OF(KIFMM__ROLE_QC)
#define KIFMM__HAS_SC KIFMM__HAS_OF(KIFMM__ROLE_SC)
/* in C, where a misspelt KIFMM_HAS_ name is an undeclared identifier */
KIFMM__STATIC_ASSERT(((KIFMM__HAS_QT | KIFMM__HAS_ST | KIFMM__HAS_QC | KIFMM__HAS_SC) &
                      ~KIFMM_HAS_ALL) == 0,
                     KIFMM__CAT(KIFMM_NAME, _kernel_HAS_mask_has_unknown_bits));
/* A one-component surface kernel that depends on |d| alone: the M2L's
 * spectra of the 316 transfer vectors are those of 16, turned, and the M2M
 * and L2L of the 8 octants those of one, mirrored. */
#define KIFMM__RADIAL (KIFMM__SD == 1 && (KIFMM__HAS_SC & KIFMM_HAS_RADIAL) != 0)
/* A complex surface kernel (KIFMM_HAS_COMPLEX, SD = 2): the FFT M2L's
 * lattices are complex, FSD = 1 component of them; the M2L's spectra are
 * turned from 16 transfer vectors for a radial complex kernel as well
 * (FRADIAL). */
#define KIFMM__CPLX (KIFMM__SD == 2 && (KIFMM__HAS_SC & KIFMM_HAS_COMPLEX) != 0)
KIFMM__STATIC_ASSERT(KIFMM__SD == 2 || (KIFMM__HAS_SC & KIFMM_HAS_COMPLEX) == 0,
                     KIFMM__CAT(KIFMM_NAME, _complex_kernel_must_have_two_components));
#define KIFMM__FSD (KIFMM__CPLX ? 1 : KIFMM__SD)
/* Anchors of the downward densities (>>anchors), complex kernels' too
 * (their operators are real matrices over the (re, im) pairs); none in
 * float (or with KIFMM_NO_ANCHORS): there the anchors' own densities, each
 * about the field times 100 half-widths, carry float's rounding into the
 * gradient, about 6e-8 times the sources' distance over 100 half-widths,
 * which the anchors do not cure (docs/algorithm.md, "Anchors"), and their
 * distance would cut float's range. */
#if defined(KIFMM_NO_ANCHORS)
#define KIFMM__ANCHORS 0
#else
#define KIFMM__ANCHORS (KIFMM__FLOAT ? 0 : KIFMM__ANCHOR_MAX)
#endif
#define KIFMM__FRADIAL (KIFMM__RADIAL || (KIFMM__CPLX && (KIFMM__HAS_SC & KIFMM_HAS_RADIAL) != 0))
/* Three periodic directions of a scale-invariant kernel: its surface
 * kernel's Ewald split and the background of it and of the kernel. */
#if KIFMM__SI && (KIFMM__HAS_SC & KIFMM_HAS_EWALD) && (KIFMM__HAS_SC & KIFMM_HAS_BACKGROUND) && \
    (KIFMM__HAS_QT & KIFMM_HAS_BACKGROUND)
#define KIFMM__EWALD 1
#else
#define KIFMM__EWALD 0
#endif

/* The hook bits of this precision: one-way, many-vector, mutual, mutual
 * many-vector; and the suffix of the hooks' names. */
#if KIFMM__FLOAT
#define KIFMM__B_P2P KIFMM_HAS_P2PF
#define KIFMM__B_P2PN KIFMM_HAS_P2PNF
#define KIFMM__B_P2PS KIFMM_HAS_P2PSF
#define KIFMM__B_P2PSN KIFMM_HAS_P2PSNF
#define KIFMM__HOOK(role, h) KIFMM__R_(role, KIFMM__CAT3(_, h, f))
#else
#define KIFMM__B_P2P KIFMM_HAS_P2P
#define KIFMM__B_P2PN KIFMM_HAS_P2PN
#define KIFMM__B_P2PS KIFMM_HAS_P2PS
#define KIFMM__B_P2PSN KIFMM_HAS_P2PSN
#define KIFMM__HOOK(role, h) KIFMM__R_(role, KIFMM__CAT(_, h))
#endif

/* Resolved to 0 / 1 for use in C expressions. */
#if KIFMM__HAS_QT & KIFMM__B_P2P
#define KIFMM__NEAR_HOOK 1
#else
#define KIFMM__NEAR_HOOK 0
#endif
#if KIFMM__HAS_QT & KIFMM__B_P2PS
#define KIFMM__MUTUAL 1
#else
#define KIFMM__MUTUAL 0
#endif
/* kifmm__default_leaf's kind of this instance. 1: kernels whose surfaces
 * carry several components and which have a near-field hook of this
 * precision get larger default leaves
 * (kifmm__default_leaf); not the oscillating ones, whose hooks' pairs cost
 * several times a Stokeslet's (helmholtz_grad, 200,000 uniform points, p =
 * 6: evaluate 2.82 s at leaves of 512, 1.16 s at 128) */
#if KIFMM__SD > 1 && (KIFMM__NEAR_HOOK || KIFMM__MUTUAL) && !(KIFMM__HAS_QT & KIFMM_HAS_WAVES)
#define KIFMM__LEAF_KIND 1
#elif KIFMM__SD == 1 && !KIFMM__FLOAT
#define KIFMM__LEAF_KIND 2 /* one surface component in double: kifmm__default_leaf's narrower
                               leaves without AVX-512 */
#else
#define KIFMM__LEAF_KIND 0
#endif
/* The single-thread column GEMM of this precision. */
#if KIFMM__FLOAT
#define KIFMM__GEMM_COLS kifmm__gemm_colsf
#else
#define KIFMM__GEMM_COLS kifmm__gemm_colsd
#endif

/* M2L by FFT (kifmm__fft), for any number of surface density components up
 * to 9 (the products' block codes are bytes), unless KIFMM_M2L_DENSE is
 * defined; dense stacked GEMMs otherwise. */
#if !defined(KIFMM_M2L_DENSE) && KIFMM__SD <= 9
#define KIFMM__FFT 1
#else
#define KIFMM__FFT 0
#endif
/* The values of the thread's FFT buffer before the products and before the
 * transform work: the blocks of a chunk (SD^2 x 27 of them), and the
 * products of ftb parents (SD components each). Spectra and products keep
 * one slot per parent and component: slot b SD + j, F 16 values per chunk. */
#define KIFMM__FFT_KBN ((size_t)27 * 128 * KIFMM__FFT_F * KIFMM__FSD * KIFMM__FSD)
#define KIFMM__FFT_PN ((size_t)KIFMM__FFT_F * 16 * KIFMM__FSD)
#define KIFMM__FFT_OUTN(c) ((size_t)KIFMM__F(__ftmax)(c)->nfp * (size_t)(c)->fft.ftb * 16 * KIFMM__FSD)

/* Singular value cutoff of the check-to-equivalent pseudo-inverses; the
 * smallest kernel magnitude on the surfaces for which a level keeps its far
 * field (see build_c2e). */
#if KIFMM__FLOAT
#define KIFMM__CUTOFF (KIFMM_SVD_CUTOFF > 1e-7 ? KIFMM_SVD_CUTOFF : 1e-7)
#define KIFMM__TINY ((double)FLT_MIN)
#else
#define KIFMM__CUTOFF KIFMM_SVD_CUTOFF
#define KIFMM__TINY DBL_MIN
#endif


// >>handle

/* One set of operators in the instance's precision (see kifmm__ops), built
 * at half-width r: a plan's entry, shared by the handles whose levels have
 * that half-width (all levels of a scale-invariant kernel: r = 1). Never
 * changed once in a plan; freed when no handle uses it. */
typedef struct {
    double r;     /* the half-width it was built at */
    int p[3];     /* and the orders of its level, of the parent's (its L2L) and of the
                     children's (its M2M): the handle's order, or raised (>>orders) */
    int has_m2l;  /* it has the M2L's operators */
    int refs;     /* handles that use it, and 1 for a plan_create's own */
    size_t held;  /* bytes of the arrays below */
    double sigma; /* scale of the level's check potentials (see build_c2e) */
    int ku, kd;
    KIFMM__R *ut_up, *vs_up, *ut_dn, *vs_dn, *m2m, *l2l, *m2l, *conv;
    int mir;      /* and mmap: as kifmm__ops's (M2M and L2L: octant 0's, P__family_mirror) */
    int *mmap;
    double *khat; /* and ktab: as kifmm__ops's */
    int *ktab;
    float *kbf;   /* FFT M2L: the 8 x 8 blocks of every chunk (kifmm__fft_blocks), in */
    double *kbd;  /* the spectra's precision, or NULL when they would take too much
                     memory and are built per task */
    unsigned char nz[KIFMM__SD * KIFMM__SD]; /* kernel components (a, b) whose spectra
                     are not all zero: only those are multiplied (the blocks of
                     _laplace3 off the diagonal are zero, those between the
                     Stokeslet and the charge of _stokes_pl too) */
    int mono_on;  /* scale-invariant kernels: the upward densities' sums are set */
    double mono[KIFMM__SD * KIFMM__QD]; /* (__mono_fix): density kind s -> sum of the
                     surface component a of its equivalent density, at a + s SD */
} KIFMM__F(__ops);

/* A periodic tree's far images (kifmm__lat): a plan's entry for the roots
 * of one width and levels above the cell whose level zl (0 or 1) is, or is
 * not, made of leaves (zsmall), shared as the operator sets are. */
typedef struct {
    double width;          /* the key: the root's width, */
    int kc, zl, zsmall;    /* levels above the cell, the exchange's level, its leaves */
    int refs;              /* handles that use it */
    size_t held;           /* bytes of the arrays below */
    double *mu;            /* scale-invariant kernels: SD x QD monopole map, and */
    int neutral;           /* whether the densities must sum to zero */
    double *bq;            /* three periodic directions of a scale-invariant kernel:
                              the background's quadratic (__background_fit), */
    KIFMM__R *zu, *zm, *zd; /* the far images' exchange (__far_root): its three
                              factors (zku x SD nzu, zkd x zku, SD nzu x zkd), */
    KIFMM__R *zp;          /* U's points (D's too) about the root's centre, */
    double *zunit, zrad;   /* and on the unit surface, and their radius */
    int nzu, zku, zkd;     /* points of U (and D); the factors' ranks */
} KIFMM__F(__far);

/* Expansions and workspace for up to `nrhs` density vectors, rhs-major:
 * vector r of an array starts at r times the array's per-vector size. */
typedef struct {
    size_t held;             /* bytes of the arrays below */
    int nrhs;
    KIFMM__R *ue, *de;       /* nbox x ne, nbox x nde (anchors: >>anchors) per vector */
    KIFMM__R *chk;           /* check vectors of one level: nc x (boxes of the level) */
    KIFMM__R *tmp;           /* dense M2L: max(nc, nde) x (boxes of a level) */
    KIFMM__R *stack;         /* 316 ne x (M2L block columns) */
    KIFMM__R *m2l_out;       /* kd x (M2L block columns) */
    KIFMM__R *qs;            /* densities in sorted order */
#if defined(KIFMM_MPI)
    KIFMM__R *qp;            /* MPI mode's main: the proxies' densities, SD each, by
                                px.cum (px.n SD per vector), or NULL */
#endif
    KIFMM__R *lat;           /* periodic trees: U's potentials, D's densities
                                (__far_apply) */
    /* Outputs: either all of them in sorted order (outs), gathered into the
     * caller's order at the end; or, when that saves memory, each task sums
     * its targets in its thread's part of lbuf (lbuf_per values) and adds
     * them to the caller's out (dst, set during an evaluate) itself. */
    KIFMM__R *outs, *lbuf, *dst;
    size_t lbuf_per;
} KIFMM__F(__work);

/* The plan: what depends on the options alone and, for kernels that are
 * not scale invariant, on the box widths (and for periodic trees on the
 * root's width and whether level 1 holds leaves): the surfaces, the FFT's
 * transforms, and a cache of operator sets (one per half-width) and of
 * far images (one per root), each shared by the handles that use it and
 * freed with the last of them. create makes a plan for its handle alone;
 * plan_create one for several (create_with_plan). The passes only read it
 * (a handle reads the entries it holds, which nobody changes); entries are
 * added and dropped under the lock, by create, update_points and destroy.
 * Every block it allocates is counted in its held (entries in theirs too). */
struct KIFMM__F(_plan) {
    size_t held;               /* bytes of the plan and of its entries */
    int refs;                  /* handles that use it, and 1 for plan_create's caller */
    kifmm__lock lock;          /* over refs, the entries and held */
    kifmm_opts opts;           /* the options it was built for, defaults resolved */
    int shape[2];              /* leaf size and depth as given (0: chosen; a handle on a
                                  tree takes the tree's: __tree_fits) */
    kifmm__surf surf;          /* the equivalent and check surfaces */
    struct {                   /* the operator sets */
        KIFMM__F(__ops) **set; /* n of them (cap allocated) */
        int n, cap;
        double degree;
        double qlo[KIFMM__QD], qhi[KIFMM__QD]; /* __density_degrees */
        size_t kept;           /* bytes of the products' blocks kept (__keep_blocks) */
    } ops;
    struct {                   /* the periodic far images */
        KIFMM__F(__far) **set;
        int n, cap;
    } far;
    kifmm__fft fft;            /* the FFT M2L's transforms of the check-order lattice */
    struct {                   /* >>cache: opts.operator_cache's directory (opts points */
        char *dir;             /* to this copy), and the sets read from it and written */
        int read, written;     /* there (under the lock) */
    } cache;
};

/* The handle: its plan (its own, or shared: create_with_plan) and the
 * plan's entries it uses, the points and what is built from them (tree,
 * lists, FFT slabs, near-field chunks), and the workspace. Every block it
 * allocates is counted where it is allocated (kifmm__take): in held,
 * tree.held, the plan's and the workspace's held. */
#if defined(KIFMM_MPI)
/* MPI mode (>>mpi): a handle from create_mpi holds only this. */
typedef struct KIFMM__F(__mpi) KIFMM__F(__mpi);
#endif

struct KIFMM_NAME {
#if defined(KIFMM_MPI)
    KIFMM__F(__mpi) *mpi;      /* create_mpi's handle: its ranks' state, else NULL */
#endif
    size_t held;               /* bytes of the blocks below, plan, tree and workspace apart */
    kifmm_opts opts;           /* options, defaults resolved (with the kernel's
                                  parameters in opts.kernel_param) */
    KIFMM__F(_plan) *pl;       /* surfaces and operator sets */
    int shared;                /* pl came from plan_create (stats.bytes leave it out) */
    KIFMM__F(__ops) *lv[KIFMM__D + 2]; /* the operator set of each level that has
                                  one (pl's entries, one reference each) */
    KIFMM__F(__far) *far;      /* periodic trees: the far images (pl's), else NULL */
    struct {                   /* the levels' orders (>>orders): an oscillating kernel's
                                  wide levels take a higher one than pl's */
        int up;                /* whether any level does (raise: whether they may) */
        int raise, pmax;       /* pmax: the highest order of the levels */
        KIFMM__F(_plan) *pl[KIFMM__D + 2]; /* the plan of each level's order: NULL, pl; else
                                  one of own (its surfaces and lattice; the sets are pl's) */
        KIFMM__F(_plan) *own[KIFMM_MAX_ORDER + 1]; /* the handle's plans of the raised orders */
        size_t eo[2][KIFMM__D + 3]; /* where the upward and downward densities of each
                                  level start in a vector of expansions (see __eo) */
    } ord;
    unsigned char nz[KIFMM__SD * KIFMM__SD]; /* the union of lv's nz */
    double pbytes;             /* the plan's bytes when the handle was built */
    kifmm_tree *tr;            /* the points' part: its own, or shared (create_on_tree) */
    const kifmm__tree *tree;   /* &tr->t: boxes, lists, and the sorted points in double */
    int tshared;               /* tr came from another handle (stats.bytes leave it out) */
    int shape[2];              /* leaf size and depth as given (see the plan's) */
    struct {                   /* the sorted points in the instance's precision */
        const KIFMM__R *src, *trg; /* structure of arrays: tr's (t.src or fsrc) */
    } pts;
    int32_t *dsrc;             /* per box: the box whose local expansion serves it, or
                                  -1 (kifmm__tree_dsrc, with this handle's check surface) */
    struct {                   /* the FFT M2L */
        int32_t *co, *cj;      /* internal colleagues of internal boxes, and */
        unsigned char *cc;     /* their offset codes */
        float *specf;          /* child spectra of one slab, in the spectra's */
        double *specd;         /* precision (one of the two) */
        int32_t slots;         /* parents whose spectra fit in spec */
        int32_t m, mc;         /* sizes of loc/need and cjl */
        int32_t *loc, *need, *cjl; /* slab: slot of a parent, parents, local colleagues */
        unsigned char *sch;    /* per slot: number of children with sources, then which */
        float *bf;             /* per thread: blocks, products, transform work (fper */
        double *bd;            /* values of the spectra's type) */
        double *mbuf;          /* per thread: one lattice density of 8 lanes, 8 nc */
        size_t per;
        int ftb;               /* target parents per task (products buffer) */
        float *foutf;          /* without kept blocks: products of a slab's target */
        double *foutd;         /* parents (slots of them), chunk-major; or NULL */
    } fft;
    struct {                   /* periodic trees: the far images' points */
        KIFMM__R *zt;          /* U's points in the tree's frame (D's field at the
                                  targets of the leaves of level zl, in __leaf) */
        int zl;                /* the level whose boxes the exchange reaches (0 or 1) */
        int zsmall;            /* a box of level zl with points is a leaf (kifmm__ewald_order) */
    } lat;
    struct {                   /* the mutual near field (sources = targets) */
        int32_t *chunk;        /* chunks of leaves, or NULL */
        int nchunk;
    } near;
    struct {                   /* workspace */
        KIFMM__F(__work) *w;   /* grows to the largest nrhs evaluated (<= RHS_MAX) */
        KIFMM__R *scratch;     /* per thread: see __scratch_per */
        size_t fpts;           /* points of the float instances' frame buffers */
        size_t ipts;           /* points of the periodic trees' image buffers */
        KIFMM__R *gbuf;        /* column GEMM passes: see __gbuf_per */
        size_t gbuf_n;
        int32_t *act;          /* boxes of each level the solves visit (kifmm__active) */
        int mb;                /* most boxes on one level */
        int m2l_cols;          /* dense M2L: columns (box x vector) per GEMM */
    } work;
    kifmm_stats stats;         /* written by create and evaluate */
#if defined(KIFMM_MPI)
    struct {                   /* MPI mode's main handle: proxies among the sources
                                  (__mpi_roles), else cum NULL */
        int64_t *cum;          /* proxies before each sorted position (ns + 1) */
        int64_t n;             /* proxies */
    } px;
#endif
};

#if defined(KIFMM_MPI)
/* MPI mode's entry points (>>mpi), which the public functions hand an
 * MPI handle to. */
KIFMM__FN int KIFMM__F(__mpi_evaluate)(KIFMM_NAME *h, int nrhs, const KIFMM__R *d, KIFMM__R *out);
KIFMM__FN int KIFMM__F(__mpi_update)(KIFMM_NAME *h, int64_t ns, const KIFMM__R *src, int64_t nt,
                                     const KIFMM__R *trg);
KIFMM__FN void KIFMM__F(__mpi_stats)(const KIFMM_NAME *h, kifmm_stats *out);
KIFMM__FN void KIFMM__F(__mpi_destroy)(KIFMM_NAME *h);
#endif

/* C = A B (+ C if beta), column major, no transposes, in the instance's
 * precision. Outside parallel regions only. */
KIFMM__FN void KIFMM__F(__gemm)(int m, int n, int k, const KIFMM__R *a, int lda,
                                const KIFMM__R *b, int ldb, int beta, KIFMM__R *c, int ldc)
{
    if (m <= 0 || n <= 0) return;
    if (k <= 0) {
        int i, j;
        if (!beta)
            for (j = 0; j < n; j++)
                for (i = 0; i < m; i++) c[i + (size_t)j * ldc] = 0;
        return;
    }
#if KIFMM__FLOAT
    cblas_sgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, m, n, k, 1.0f, a, lda, b, ldb,
                beta ? 1.0f : 0.0f, c, ldc);
#else
    cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, m, n, k, 1.0, a, lda, b, ldb,
                beta ? 1.0 : 0.0, c, ldc);
#endif
}

/* A copy of n doubles in the instance's precision, counted in *held (the
 * array itself for double, which then changes owner). NULL on allocation
 * failure. */
KIFMM__FN KIFMM__R *KIFMM__F(__own)(size_t *held, double **d, size_t n)
{
#if KIFMM__FLOAT
    KIFMM__R *f = (KIFMM__R *)kifmm__take(held, n, sizeof(KIFMM__R));
    size_t i;
    if (f)
        for (i = 0; i < n; i++) f[i] = (KIFMM__R)(*d)[i];
    kifmm__free(*d);
    *d = NULL;
    return f;
#else
    KIFMM__R *f = *d;
    if (f) *held += kifmm__size(f);
    (void)n;
    *d = NULL;
    return f;
#endif
}

/* Unit surface scaled by `radius` and moved to `c`, into out (SoA, n points). */
KIFMM__FN void KIFMM__F(__place)(const double *unit, int n, const double *c, double radius,
                                 KIFMM__R *out)
{
    int i, d;
    for (d = 0; d < 3; d++)
        for (i = 0; i < n; i++) out[d * n + i] = (KIFMM__R)(c[d] + radius * unit[d * n + i]);
}

/* The inner surfaces' radius (upward equivalent, downward check) of boxes of
 * half-width r: ai r, for an oscillating kernel moved off the resonances
 * (kifmm__alpha_waves). Every surface, operator and grid of a level takes
 * it from here. */
KIFMM__FN double KIFMM__F(__rin)(const KIFMM__F(_plan) *pl, const kifmm__surf *sf, double r)
{
#if KIFMM__HAS_QT & KIFMM_HAS_WAVES
    const double x = KIFMM__K(_wavenumber)(pl->opts.kernel_param) * r / 3.14159265358979323846;
    return kifmm__alpha_waves(sf->ai, x) * r;
#else
    (void)pl;
    return sf->ai * r;
#endif
}

/* The plan of level l's order (>>orders): the handle's, or one of its own
 * for a raised level. Every pass takes a level's surfaces (__sf) and
 * lattice (__ft) from here; the buffers sized for any level take the
 * highest order's (__smax, __ftmax). */
KIFMM__FN const KIFMM__F(_plan) *KIFMM__F(__lpl)(const KIFMM_NAME *c, int l)
{
    return c->ord.up && c->ord.pl[l] ? c->ord.pl[l] : c->pl;
}

KIFMM__FN const kifmm__surf *KIFMM__F(__sf)(const KIFMM_NAME *c, int l)
{
    return &KIFMM__F(__lpl)(c, l)->surf;
}

KIFMM__FN const kifmm__fft *KIFMM__F(__ft)(const KIFMM_NAME *c, int l)
{
    return &KIFMM__F(__lpl)(c, l)->fft;
}

KIFMM__FN const kifmm__surf *KIFMM__F(__smax)(const KIFMM_NAME *c)
{
    return c->ord.up ? &c->ord.own[c->ord.pmax]->surf : &c->pl->surf;
}

KIFMM__FN const kifmm__fft *KIFMM__F(__ftmax)(const KIFMM_NAME *c)
{
    return c->ord.up ? &c->ord.own[c->ord.pmax]->fft : &c->pl->fft;
}

/* Where box b's upward (down = 0) or downward (down = 1) density starts in
 * one vector's expansions (ue, de); b = nbox: a vector's length. The boxes
 * in order, each its level's length. Every pass finds a box's expansion
 * here. */
KIFMM__FN size_t KIFMM__F(__eo)(const KIFMM_NAME *c, int down, int32_t b)
{
    const kifmm__tree *t = c->tree;
    const kifmm__surf *s;
    int l;
    if (!c->ord.up) return (size_t)b * (size_t)(down ? c->pl->surf.nde : c->pl->surf.ne);
    if (b >= t->nbox) return c->ord.eo[down][t->nlev];
    l = t->lev[b];
    s = KIFMM__F(__sf)(c, l);
    return c->ord.eo[down][l] + (size_t)(b - t->loff[l]) * (size_t)(down ? s->nde : s->ne);
}

// >>kernels

/* The signature of the instance's direct-interaction loops below. */
#define KIFMM__P2P_SIG(fname)                                                                \
    KIFMM__FN void fname(const double *prm, const KIFMM__R *tx, const KIFMM__R *ty,          \
                         const KIFMM__R *tz, int64_t nt, const KIFMM__R *sx,                 \
                         const KIFMM__R *sy, const KIFMM__R *sz, const KIFMM__R *q,          \
                         int64_t ns, int nrhs, size_t qld, double scale, KIFMM__R *out,      \
                         size_t old)

/* out[r*old + i*dim + a] += scale * sum_j K(t_i - s_j) q[r*qld + j*qdim + s]
 * for nrhs density vectors; targets and sources as structure-of-arrays
 * coordinates; `kfun` has `dim` output and `qdim` density components. The
 * kernel is evaluated once per pair for all vectors. */
#define KIFMM__DEFINE_P2P(fname, kfun, dim, qdim)                                            \
    KIFMM__P2P_SIG(fname)                                                                    \
    {                                                                                        \
        int64_t i, j;                                                                        \
        int a, s, r;                                                                         \
        for (i = 0; i < nt; i++) {                                                           \
            double acc[KIFMM__RHS_MAX * (dim)], k[(dim) * (qdim)];                           \
            for (a = 0; a < nrhs * (dim); a++) acc[a] = 0.0;                                 \
            for (j = 0; j < ns; j++) {                                                       \
                kfun(prm, (double)tx[i] - (double)sx[j], (double)ty[i] - (double)sy[j],      \
                     (double)tz[i] - (double)sz[j], k);                                      \
                for (r = 0; r < nrhs; r++) {                                                 \
                    const KIFMM__R *qj = q + r * qld + j * (qdim);                           \
                    for (a = 0; a < (dim); a++)                                              \
                        for (s = 0; s < (qdim); s++)                                         \
                            acc[r * (dim) + a] += k[a * (qdim) + s] * (double)qj[s];         \
                }                                                                            \
            }                                                                                \
            for (r = 0; r < nrhs; r++)                                                       \
                for (a = 0; a < (dim); a++)                                                  \
                    out[r * old + i * (dim) + a] += (KIFMM__R)(scale * acc[r * (dim) + a]);  \
        }                                                                                    \
    }

/* The same through a kernel's hand-written hook, one vector at a time. */
#define KIFMM__DEFINE_P2P_HOOK(fname, hook)                                                  \
    KIFMM__P2P_SIG(fname)                                                                    \
    {                                                                                        \
        int r;                                                                               \
        for (r = 0; r < nrhs; r++)                                                           \
            hook(prm, tx, ty, tz, nt, sx, sy, sz, q + r * qld, ns, (KIFMM__R)scale,          \
                 out + r * old);                                                             \
    }

/* The same through a kernel's many-vector hook when nrhs > 1. */
#define KIFMM__DEFINE_P2P_HOOKN(fname, hook, hookn)                                          \
    KIFMM__P2P_SIG(fname)                                                                    \
    {                                                                                        \
        if (nrhs > 1)                                                                        \
            hookn(prm, tx, ty, tz, nt, sx, sy, sz, q, ns, nrhs, qld, (KIFMM__R)scale, out,   \
                  old);                                                                      \
        else                                                                                 \
            hook(prm, tx, ty, tz, nt, sx, sy, sz, q, ns, (KIFMM__R)scale, out);              \
    }

/* One loop per kernel role (see the roles above): the role kernel's hooks
 * where it has them (one-way, and many-vector for nrhs > 1), else the
 * generic loop over its eval.
 *   __p2p_qt  points -> targets: U lists, and W and X sources taken directly
 *   __p2p_st  surface densities -> targets: L2P, M2P
 *   __p2p_qc  points -> check surfaces: P2M, P2L
 *   __p2p_sc  surface densities -> check surfaces: L2L from a far ancestor */
#if (KIFMM__HAS_QT & KIFMM__B_P2P) && (KIFMM__HAS_QT & KIFMM__B_P2PN)
KIFMM__DEFINE_P2P_HOOKN(KIFMM__F(__p2p_qt), KIFMM__HOOK(QT, p2p), KIFMM__HOOK(QT, p2pn))
#elif KIFMM__HAS_QT & KIFMM__B_P2P
KIFMM__DEFINE_P2P_HOOK(KIFMM__F(__p2p_qt), KIFMM__HOOK(QT, p2p))
#else
KIFMM__DEFINE_P2P(KIFMM__F(__p2p_qt), KIFMM__R_(QT, _eval), KIFMM__TD, KIFMM__QD)
#endif
#if (KIFMM__HAS_ST & KIFMM__B_P2P) && (KIFMM__HAS_ST & KIFMM__B_P2PN)
KIFMM__DEFINE_P2P_HOOKN(KIFMM__F(__p2p_st), KIFMM__HOOK(ST, p2p), KIFMM__HOOK(ST, p2pn))
#elif KIFMM__HAS_ST & KIFMM__B_P2P
KIFMM__DEFINE_P2P_HOOK(KIFMM__F(__p2p_st), KIFMM__HOOK(ST, p2p))
#else
KIFMM__DEFINE_P2P(KIFMM__F(__p2p_st), KIFMM__R_(ST, _eval), KIFMM__TD, KIFMM__SD)
#endif
#if (KIFMM__HAS_QC & KIFMM__B_P2P) && (KIFMM__HAS_QC & KIFMM__B_P2PN)
KIFMM__DEFINE_P2P_HOOKN(KIFMM__F(__p2p_qc), KIFMM__HOOK(QC, p2p), KIFMM__HOOK(QC, p2pn))
#elif KIFMM__HAS_QC & KIFMM__B_P2P
KIFMM__DEFINE_P2P_HOOK(KIFMM__F(__p2p_qc), KIFMM__HOOK(QC, p2p))
#else
KIFMM__DEFINE_P2P(KIFMM__F(__p2p_qc), KIFMM__R_(QC, _eval), KIFMM__SD, KIFMM__QD)
#endif
#if (KIFMM__HAS_SC & KIFMM__B_P2P) && (KIFMM__HAS_SC & KIFMM__B_P2PN)
KIFMM__DEFINE_P2P_HOOKN(KIFMM__F(__p2p_sc), KIFMM__HOOK(SC, p2p), KIFMM__HOOK(SC, p2pn))
#elif KIFMM__HAS_SC & KIFMM__B_P2P
KIFMM__DEFINE_P2P_HOOK(KIFMM__F(__p2p_sc), KIFMM__HOOK(SC, p2p))
#else
KIFMM__DEFINE_P2P(KIFMM__F(__p2p_sc), KIFMM__R_(SC, _eval), KIFMM__SD, KIFMM__SD)
#endif

/* any of the four loops above */
typedef void (*KIFMM__F(__p2p_fn))(const double *, const KIFMM__R *, const KIFMM__R *,
                                    const KIFMM__R *, int64_t, const KIFMM__R *, const KIFMM__R *,
                                    const KIFMM__R *, const KIFMM__R *, int64_t, int, size_t,
                                    double, KIFMM__R *, size_t);

#if defined(KIFMM_MPI)
/* MPI mode's main handle may hold sources of two roles: the kernel's, and
 * proxies (points of other ranks' equivalent surfaces carrying densities of
 * the surface kernel; last in each leaf, __mpi_roles). The sorted sources
 * [s0, s0 + n) (coordinates x, ld values a coordinate) to the ny points tx,
 * ty, tz: runs of the kernel's through fq (densities in qs), runs of
 * proxies through fs (densities in qp). */
KIFMM__FN void KIFMM__F(__p2p_roles)(const KIFMM_NAME *c, const KIFMM__F(__work) *w,
                                     KIFMM__F(__p2p_fn) fq, KIFMM__F(__p2p_fn) fs,
                                     const KIFMM__R *tx, const KIFMM__R *ty, const KIFMM__R *tz,
                                     int64_t ny, const KIFMM__R *x, size_t ld, int64_t s0,
                                     int64_t n, int nrhs, double scale,
                                     KIFMM__R *out, size_t old)
{
    const int64_t *cum = c->px.cum + s0;
    const double *prm = c->opts.kernel_param;
    int64_t i = 0, j;
    while (i < n) {
        const int64_t p = cum[i + 1] - cum[i];
        for (j = i + 1; j < n && cum[j + 1] - cum[j] == p; j++) continue;
        if (p)
            fs(prm, tx, ty, tz, ny, x + i, x + ld + i, x + 2 * ld + i,
               w->qp + cum[i] * KIFMM__SD, j - i, nrhs, (size_t)c->px.n * KIFMM__SD, scale, out, old);
        else
            fq(prm, tx, ty, tz, ny, x + i, x + ld + i, x + 2 * ld + i,
               w->qs + (s0 + i) * KIFMM__QD, j - i, nrhs, (size_t)c->tree->ns * KIFMM__QD, scale, out,
               old);
        i = j;
    }
}
#endif


// >>operators

/* Matrix of the surface kernel from sources s (SoA, nsp points) to targets tp
 * (SoA, ntp points), times sigma: row i*SD + a, column j*SD + b, leading
 * dimension ld. Returns the largest |entry| before sigma, or NaN if the
 * kernel gave a value that is not finite (nothing then reaches LAPACK). */
KIFMM__FN double KIFMM__F(__kmat)(const double *prm, const double *tp, int ntp,
                                  const double *sp, int nsp, double sigma, double *m, size_t ld)
{
    int i, j, a, b;
    double k[KIFMM__SD * KIFMM__SD], big = 0.0;
    for (j = 0; j < nsp; j++)
        for (i = 0; i < ntp; i++) {
            KIFMM__R_(SC, _eval)(prm, tp[i] - sp[j], tp[ntp + i] - sp[nsp + j],
                         tp[2 * ntp + i] - sp[2 * nsp + j], k);
            for (b = 0; b < KIFMM__SD; b++)
                for (a = 0; a < KIFMM__SD; a++) {
                    const double v = k[a * KIFMM__SD + b];
                    if (!(fabs(v) <= DBL_MAX)) return NAN;
                    big = fabs(v) > big ? fabs(v) : big;
                    m[(size_t)(i * KIFMM__SD + a) + (size_t)(j * KIFMM__SD + b) * ld] = sigma * v;
                }
        }
    return big;
}

/* K(check <- equivalent) times sigma into m (leading dimension ld): the
 * check surface of order ordc... placed at centre cc with radius crad (unit
 * surface uc, nc points), the equivalent one likewise. *big (if not NULL)
 * gets the largest |entry| before sigma. KIFMM_ERR_KERNEL if the kernel gave
 * a value that is not finite, KIFMM_ERR_NOMEM. */
KIFMM__FN int KIFMM__F(__surf_kmat)(const KIFMM_NAME *c, const double *uc, int nc,
                                    const double *cc, double crad, const double *ue, int ne,
                                    const double *ec, double erad, double sigma, double *m,
                                    size_t ld, double *big)
{
    double *pc = (double *)kifmm__alloc((size_t)3 * (nc + ne), sizeof(double)), b;
    if (!pc) return KIFMM_ERR_NOMEM;
    kifmm__surf_place(uc, nc, cc, crad, pc);
    kifmm__surf_place(ue, ne, ec, erad, pc + 3 * nc);
    b = KIFMM__F(__kmat)(c->opts.kernel_param, pc, nc, pc + 3 * nc, ne, sigma, m, ld);
    kifmm__free(pc);
    if (big) *big = b;
    return b == b ? KIFMM_SUCCESS : KIFMM_ERR_KERNEL;
}

/* UC2E and DC2E, the check-to-equivalent solves of boxes of half-width r:
 * pseudo-inverses of K(up check at ao r <- up equiv at ai r) and K(down
 * check at ai r <- down equiv at ao r). Float instances truncate at float
 * resolution: factors that resolve singular values below it would amplify
 * the rounding of the passes.
 *
 * Every operator that yields check potentials of boxes of this size is
 * scaled by sigma = 1 / (the largest entry of the first matrix), and so are
 * the check potentials the passes compute from points (kifmm__level_scale):
 * the pseudo-inverses see matrices of norm about 1 whatever the kernel's
 * magnitude (a Yukawa kernel at exp(-300), a Stokeslet with viscosity 1e100),
 * and the densities they give are the true ones. Where that largest entry is
 * below the smallest normal number of the instance's precision (a Yukawa
 * kernel whose lambda times the box size is in the hundreds), sigma is 0:
 * every operator of the level is zero (ranks 0) and its far field, smaller
 * still, is dropped. Here the two matrices (kernel values only, so that
 * levels can build them side by side); their pseudo-inverses in c2e_solve. */
KIFMM__FN int KIFMM__F(__c2e_kernels)(const KIFMM_NAME *c, double r, double ao, kifmm__ops *o)
{
    const double zero[3] = {0.0, 0.0, 0.0};
    const size_t nn = (size_t)c->pl->surf.nc * (size_t)c->pl->surf.ne;
    double big = 0.0;
    size_t i;
    int rc;
    o->kup = (double *)kifmm__alloc(nn, sizeof(double));
    o->kdn = (double *)kifmm__alloc(nn, sizeof(double));
    if (!o->kup || !o->kdn) return KIFMM_ERR_NOMEM;
    rc = KIFMM__F(__surf_kmat)(c, c->pl->surf.unit_c, c->pl->surf.nsc, zero, ao * r, c->pl->surf.unit_e,
                               c->pl->surf.nse, zero, KIFMM__F(__rin)(c->pl, &c->pl->surf, r), 1.0, o->kup,
                               (size_t)c->pl->surf.nc, &big);
    if (rc) return rc;
    o->sigma = big >= KIFMM__TINY ? 1.0 / big : 0.0;
    for (i = 0; i < nn; i++) o->kup[i] *= o->sigma;
    return KIFMM__F(__surf_kmat)(c, c->pl->surf.unit_c, c->pl->surf.nsc, zero, KIFMM__F(__rin)(c->pl, &c->pl->surf, r),
                                 c->pl->surf.unit_e, c->pl->surf.nse, zero, ao * r, o->sigma, o->kdn,
                                 (size_t)c->pl->surf.nc, NULL);
}

/* The groups of the surface kernel's components at parameters prm: row
 * component a (check) and column b (density) share a group where K_ab is
 * not zero at two offsets, and gr, gc get each one's group; returns the
 * number of groups (1: none to split, or more than KIFMM__GROUPS). */
KIFMM__FN int KIFMM__F(__sc_groups)(const double *prm, int *gr, int *gc)
{
    static const double off[2][3] = {{0.61, -0.37, 0.23}, {-0.29, 0.71, 0.53}};
    double kv[KIFMM__SD * KIFMM__SD];
    int nz[KIFMM__SD * KIFMM__SD], lab[2 * KIFMM__SD], id[2 * KIFMM__SD], a, b, t, ch = 1, ng = 0;
    for (a = 0; a < KIFMM__SD * KIFMM__SD; a++) nz[a] = 0;
    for (t = 0; t < 2; t++) {
        KIFMM__R_(SC, _eval)(prm, off[t][0], off[t][1], off[t][2], kv);
        for (a = 0; a < KIFMM__SD * KIFMM__SD; a++) nz[a] |= kv[a] != 0.0;
    }
    /* rows 0 .. SD - 1, columns SD .. 2 SD - 1: each gets the smallest
     * label of its connected set */
    for (a = 0; a < 2 * KIFMM__SD; a++) lab[a] = a, id[a] = -1;
    while (ch)
        for (ch = 0, a = 0; a < KIFMM__SD; a++)
            for (b = 0; b < KIFMM__SD; b++)
                if (nz[a * KIFMM__SD + b] && lab[a] != lab[KIFMM__SD + b]) {
                    lab[a] = lab[KIFMM__SD + b] = lab[a] < lab[KIFMM__SD + b] ? lab[a] : lab[KIFMM__SD + b];
                    ch = 1;
                }
    for (a = 0; a < 2 * KIFMM__SD; a++) {
        if (id[lab[a]] < 0) id[lab[a]] = ng++;
        if (a < KIFMM__SD) gr[a] = id[lab[a]];
        else gc[a - KIFMM__SD] = id[lab[a]];
    }
    return ng <= KIFMM__GROUPS ? ng : 1;
}

/* 1 if the surface kernel (SD >= 3 components) has its last three turned
 * as a vector and the others kept by the cube's symmetries, K(R x) = R'
 * K(x) R'^T for R' = diag(1, .., 1, R) and the 48 signed permutations R (a
 * Stokeslet; three Laplace charges; stokes_dl's (c, f)), each entry to
 * rounding (1e-12 of its size) at four points off every symmetry plane,
 * 0.16 to 4.2 from the origin; else 0. */
KIFMM__FN int KIFMM__F(__sc_vector)(const double *prm)
{
    enum { SD = KIFMM__SD, NP = 4 };
    static const double at[NP][3] = {
        {0.61, -0.37, 0.23}, {-0.29, 0.71, 0.53}, {0.131, -0.077, 0.052}, {-2.3, 3.1, 1.7}};
    double kv[SD * SD], kg[SD * SD], x[3], big, sd_, se_;
    int t, g, d, e, sg[3];
    if (SD < 3) return 0;
    for (t = 0; t < NP; t++) {
        KIFMM__R_(SC, _eval)(prm, at[t][0], at[t][1], at[t][2], kv);
        for (big = 0.0, d = 0; d < SD * SD; d++) big = fabs(kv[d]) > big ? fabs(kv[d]) : big;
        if (!(big > 0.0 && big <= DBL_MAX)) return 0;
        for (g = 0; g < 48; g++) {
            const int *pm = kifmm__perm3[g >> 3];
            for (d = 0; d < 3; d++) sg[d] = g >> d & 1 ? -1 : 1, x[d] = sg[d] * at[t][pm[d]];
            KIFMM__R_(SC, _eval)(prm, x[0], x[1], x[2], kg);
            for (d = 0; d < SD; d++)
                for (e = 0; e < SD; e++) {
                    const int pd = kifmm__comp_turn(SD, pm, sg, d, &sd_), pe = kifmm__comp_turn(SD, pm, sg, e, &se_);
                    const double a = kg[d * SD + e], b = sd_ * se_ * kv[pd * SD + pe];
                    if (!(fabs(a - b) <= 1e-12 * (fabs(a) + fabs(b)))) return 0;
                }
        }
    }
    return 1;
}

/* pinv(A) as kifmm__pinv's factors, A (m x n) a kernel matrix
 * (KIFMM__CUTOFF) of the surface kernel between the unit surfaces of orders
 * pr (rows) and pc (columns) about one centre: a radial kernel's by the
 * cube's symmetries (kifmm__pinv_cube, A kept) where m and n are those
 * surfaces' sizes; one whose components fall into groups (__sc_groups) by
 * groups (kifmm__pinv_groups, A kept; each group's block by the cube's
 * symmetries where P__sc_vector finds the kernel turned by them); a
 * three-component one that it finds so by the symmetries turning its
 * components as vectors (a Stokeslet's); else by one SVD (A destroyed). */
KIFMM__FN int KIFMM__F(__pinv_surf)(kifmm__symbs *y, const double *prm, double *a, int m, int n, int pr, int pc,
                                    double **ut, double **vs, int *k)
{
    const int cube = kifmm__surf_count(pr) * KIFMM__SD == m && kifmm__surf_count(pc) * KIFMM__SD == n;
    int rc = KIFMM__NOT_SYMMETRIC;
#if KIFMM__FRADIAL
    (void)prm;
    if (cube) rc = kifmm__pinv_cube(y, a, pr, pc, KIFMM__SD, 0, KIFMM__CUTOFF, ut, vs, k);
#else
    int gr[KIFMM__SD], gc[KIFMM__SD], ng = KIFMM__F(__sc_groups)(prm, gr, gc);
    const int sym = cube && KIFMM__F(__sc_vector)(prm); /* the blocks only where the probe finds them */
    if (ng > 1)
        return kifmm__pinv_groups(y, a, m, n, KIFMM__SD, sym ? pr : 0, pc, gr, gc, ng, KIFMM__CUTOFF, ut, vs, k);
    if (sym && KIFMM__SD == 3) rc = kifmm__pinv_cube(y, a, pr, pc, 3, 1, KIFMM__CUTOFF, ut, vs, k);
#endif
    if (rc != KIFMM__NOT_SYMMETRIC) return rc;
    return kifmm__pinv(a, m, n, KIFMM__CUTOFF, ut, vs, k);
}

/* The sign of row or column i in KIFMM__F(__c2e_solve): -1 for the
 * imaginary parts of a complex kernel's pairs. */
#define KIFMM__C2E_SIGN(i) (KIFMM__CPLX && ((i) & 1) ? -1.0 : 1.0)
/* The two pseudo-inverses of those matrices (which they destroy). With the
 * same points on both surfaces and a kernel with K(-d) = K(d)^T (Laplace,
 * Yukawa, Stokes) the downward matrix is the transpose of the upward one,
 * exactly (the offsets are negated, not recomputed): its factors then come
 * from the upward SVD (p = 6, 152 x 152: a level's two matrices and solves
 * took 4.2 ms, now 0.5 ms for the matrices and 2.4 ms for the one SVD). */
KIFMM__FN int KIFMM__F(__c2e_solve)(const KIFMM_NAME *c, kifmm__ops *o)
{
    const int nc = c->pl->surf.nc, ne = c->pl->surf.ne, pc = c->opts.order + c->pl->surf.cdiff;
    int i, j, tr = nc == ne, rc;
    /* a complex kernel's downward matrix is the upward one's complex
     * transpose (blocks moved, not turned): J kup^T J, J = diag(1, -1, 1,
     * -1, ...) (the conjugation of (re, im) pairs), exactly; its factors
     * then come from the upward SVD's turned, signs flipped by J */
    for (j = 0; j < ne && tr; j++)
        for (i = 0; i < nc && tr; i++)
            tr = o->kdn[i + (size_t)j * nc] == KIFMM__C2E_SIGN(i) * KIFMM__C2E_SIGN(j) * o->kup[j + (size_t)i * nc];
    rc = KIFMM__F(__pinv_surf)(o->sy, c->opts.kernel_param, o->kup, nc, ne, pc, c->opts.order, &o->ut_up, &o->vs_up,
                               &o->ku);
    if (!rc && tr) {
        o->kd = o->ku;
        rc = kifmm__pinv_transposed(nc, nc, o->ku, o->ut_up, o->vs_up, &o->ut_dn, &o->vs_dn);
        for (j = 0; !rc && KIFMM__CPLX && j < o->kd; j++)
            for (i = 1; i < nc; i += 2) {
                o->vs_dn[i + (size_t)j * nc] = -o->vs_dn[i + (size_t)j * nc];
                o->ut_dn[j + (size_t)i * o->kd] = -o->ut_dn[j + (size_t)i * o->kd];
            }
    } else if (!rc) {
        rc = KIFMM__F(__pinv_surf)(o->sy, c->opts.kernel_param, o->kdn, nc, ne, pc, c->opts.order, &o->ut_dn,
                                   &o->vs_dn, &o->kd);
    }
    kifmm__free(o->kup);
    kifmm__free(o->kdn);
    o->kup = o->kdn = NULL;
    return rc;
}

/* A radial kernel's (one component, or a complex kernel's pair) or a
 * vector one's (vec, P__sc_vector) M2M and L2L of octants 1 to 7 are octant
 * 0's mirrored: octant m is octant 0 mirrored in the axes of m (R, a
 * diagonal of signs), and so are the surfaces' points, so entry (i, j) of
 * octant m is entry (mirror i, mirror j) of octant 0, times the signs of R's
 * rows for the components of i and j where they are a vector's (K(R x) = R
 * K(x) R^T). The operators keep octant 0's matrices and these maps, o->mmap:
 * per octant m from 1, the check surface's points mirrored (nsc), then the
 * equivalent surface's (nse); P__family_mirror applies them (laplace, p =
 * 12: 2 x 4.2 MB kept instead of 2 x 34 MB, and none of the 7/8 written). */
KIFMM__FN int KIFMM__F(__mirror_maps)(const KIFMM_NAME *c, int vec, kifmm__ops *o)
{
    const int nsc = c->pl->surf.nsc, nse = c->pl->surf.nse, p = c->opts.order;
    int m;
    o->mmap = (int *)kifmm__alloc((size_t)7 * (nsc + nse), sizeof(int));
    if (!o->mmap) return KIFMM_ERR_NOMEM;
    for (m = 1; m < 8; m++) {
        int *mc = o->mmap + (size_t)(m - 1) * (nsc + nse);
        if (kifmm__surf_mirror(p + c->pl->surf.cdiff, m, mc) || kifmm__surf_mirror(p, m, mc + nsc))
            return KIFMM_ERR_NOMEM;
    }
    o->mir = vec ? 2 : 1;
    return KIFMM_SUCCESS;
}

/* M2M and L2L, per child octant: a child's upward equivalent density (half
 * r / 2, centre r / 2 sgn) -> the parent's upward check potential (half r);
 * the parent's downward equivalent density (half 2 r, centre -r sgn) -> a
 * child's downward check potential (half r). Times sigma. A radial or
 * vector kernel's, where the children and the parent have the level's order
 * (o->sc, o->sp NULL), octant 0's and the maps to the others
 * (P__mirror_maps); the anchors' columns of L2L for every octant. */
KIFMM__FN int KIFMM__F(__build_m2m_l2l)(const KIFMM_NAME *c, double r, kifmm__ops *o)
{
    const double zero[3] = {0.0, 0.0, 0.0};
    const kifmm__surf *s = &c->pl->surf, *sc = o->sc ? o->sc : s, *sp = o->sp ? o->sp : s;
    const size_t nc = (size_t)s->nc, ne = (size_t)sc->ne, nd = (size_t)sp->nde, np = (size_t)sp->ne;
    const int vec = !KIFMM__FRADIAL && KIFMM__F(__sc_vector)(c->opts.kernel_param);
    const int mirror = (KIFMM__FRADIAL || vec) && !o->sc && !o->sp;
    const size_t ldl = mirror ? nc : 8 * nc; /* L2L's equivalent columns */
    double *anc;                             /* and its anchors' */
    int oct, d, rc = KIFMM_SUCCESS;
    o->m2m = (double *)kifmm__alloc(nc * (mirror ? 1 : 8) * ne, sizeof(double));
    o->l2l = (double *)kifmm__alloc(ldl * np + 8 * nc * (nd - np), sizeof(double));
    if (!o->m2m || !o->l2l) return KIFMM_ERR_NOMEM;
    anc = o->l2l + ldl * np;
    for (oct = 0; oct < (mirror ? 1 : 8) && !rc; oct++) {
        const double sgn[3] = {(oct >> 2 & 1) ? 1.0 : -1.0, (oct >> 1 & 1) ? 1.0 : -1.0,
                               (oct & 1) ? 1.0 : -1.0};
        double cm[3], cl[3];
        for (d = 0; d < 3; d++) {
            cm[d] = 0.5 * r * sgn[d];
            cl[d] = -r * sgn[d];
        }
        rc = KIFMM__F(__surf_kmat)(c, s->unit_c, s->nsc, zero, s->ao * r, sc->unit_e, sc->nse, cm,
                                   KIFMM__F(__rin)(c->pl, sc, 0.5 * r), o->sigma,
                                   o->m2m + (size_t)oct * ne * nc, nc, NULL);
        if (!rc)
            rc = KIFMM__F(__surf_kmat)(c, s->unit_c, s->nsc, zero, KIFMM__F(__rin)(c->pl, s, r), sp->unit_e,
                                       sp->nse, cl, sp->ao * 2.0 * r, o->sigma, o->l2l + (size_t)oct * nc,
                                       ldl, NULL);
    }
    if (!rc && mirror) rc = KIFMM__F(__mirror_maps)(c, vec, o);
    /* the parent's anchors (>>anchors), every octant */
    for (oct = 0; oct < 8 && !rc && nd > np; oct++) {
        double cl[3];
        for (d = 0; d < 3; d++) cl[d] = -r * ((oct >> (2 - d) & 1) ? 1.0 : -1.0);
        rc = KIFMM__F(__surf_kmat)(c, s->unit_c, s->nsc, zero, KIFMM__F(__rin)(c->pl, s, r), sp->unit_a,
                                   sp->nsa, cl, 2.0 * r, o->sigma, anc + (size_t)oct * nc, 8 * nc, NULL);
    }
    return rc;
}

#if KIFMM__FFT
/* The FFT M2L's lattice density: conv (nc x ne) maps the order-p upward
 * equivalent density to a density on the check-order lattice at the same
 * radius with the same field outside (fitted on the upward check surface).
 * With check surfaces of order p the lattice is the equivalent surface
 * itself and conv the identity, exactly: none is built (the fit gave it
 * with max |conv - I| 7e-11 at p = 4, 8e-6 at p = 6, 3e-2 at p = 7). The
 * fit is square (check order points) for one component; with more, on a
 * surface one order finer, in least squares: square, the Stokeslet's fit
 * gave 10 times the dense M2L's error at p = 6 (5.6e-5 against 5.6e-6,
 * 30,000 uniform points); one order finer, the same error as the dense
 * M2L. (For Laplace, one order finer measured 10 % worse at p = 8, 10.) */
KIFMM__FN int KIFMM__F(__build_conv)(const KIFMM_NAME *c, double r, kifmm__ops *o)
{
    const double zero[3] = {0.0, 0.0, 0.0};
    const int nc = c->pl->surf.nc, ne = c->pl->surf.ne, qf = c->opts.order + c->pl->surf.cdiff + (KIFMM__SD > 1);
    const int nsf = kifmm__surf_count(qf), nf = nsf * KIFMM__SD;
    double *kb, *a, *ut = NULL, *vs = NULL, *tmp = NULL, *uf;
    int k = 0, rc = KIFMM_SUCCESS;
    if (c->pl->surf.cdiff == 0) return KIFMM_SUCCESS;
    kb = (double *)kifmm__alloc((size_t)nf * ne, sizeof(double));
    a = (double *)kifmm__alloc((size_t)nf * nc, sizeof(double));
    uf = (double *)kifmm__alloc((size_t)3 * nsf, sizeof(double));
    if (!kb || !a || !uf) { rc = KIFMM_ERR_NOMEM; goto done; }
    kifmm__surf_unit(qf, uf);
    rc = KIFMM__F(__surf_kmat)(c, uf, nsf, zero, c->pl->surf.ao * r, c->pl->surf.unit_e, c->pl->surf.nse, zero,
                               KIFMM__F(__rin)(c->pl, &c->pl->surf, r), 1.0, kb, (size_t)nf, NULL);
    if (!rc)
        rc = KIFMM__F(__surf_kmat)(c, uf, nsf, zero, c->pl->surf.ao * r, c->pl->surf.unit_c, c->pl->surf.nsc,
                                   zero, KIFMM__F(__rin)(c->pl, &c->pl->surf, r), 1.0, a, (size_t)nf, NULL);
    if (!rc)
        rc = KIFMM__F(__pinv_surf)(o->sy, c->opts.kernel_param, a, nf, nc, qf, c->opts.order + c->pl->surf.cdiff, &ut,
                                   &vs, &k);
    if (rc) goto done;
    tmp = (double *)kifmm__alloc((size_t)k * ne, sizeof(double));
    o->conv = (double *)kifmm__alloc((size_t)nc * ne, sizeof(double));
    if (!tmp || !o->conv) { rc = KIFMM_ERR_NOMEM; goto done; }
    kifmm__gemm(0, 0, k, ne, nf, 1.0, ut, k, kb, nf, 0.0, tmp, k);
    kifmm__gemm(0, 0, nc, ne, k, 1.0, vs, nc, tmp, k, 0.0, o->conv, nc);
done:
    kifmm__free(kb);
    kifmm__free(a);
    kifmm__free(uf);
    kifmm__free(ut);
    kifmm__free(vs);
    kifmm__free(tmp);
    return rc;
}

/* The 316 lattice grids of the FFT M2L's kernel for boxes of half-width r,
 * times sigma, each component ab (target a, source b) transformed
 * (kifmm__fft_grid) into kt[(t FSD^2 + ab) 2 nfp]: the kernel at the
 * lattice offsets h (i - j) - 2 r t on the (2q - 1)^3 grid (a complex
 * kernel: one complex grid, k[0] + i k[2]); if turned (a radial or
 * vector kernel) only the 16 transfer vectors with t_x >= t_y >= t_z >= 0
 * (the others are these turned, P__khat_turned), vector t in place
 * kifmm__tv_slots(t) of kt. *big gets the largest |value| (the same over
 * the 16). KIFMM_ERR_KERNEL if a value was not finite, or a complex
 * kernel's block not of the form {a, -b, b, a}. */
KIFMM__FN int KIFMM__F(__m2l_grids)(const KIFMM_NAME *c, double r, double sigma, int nth, int turned,
                                    double *kt, double *big)
{
    enum { SD2 = KIFMM__SD * KIFMM__SD };
    const kifmm__fft *pl = &c->pl->fft;
    const int n = pl->n, p = pl->p;
    const size_t nnn = (size_t)n * n * n, per = SD2 * nnn + kifmm__fft_work(pl);
    const double h = 2.0 * KIFMM__F(__rin)(c->pl, &c->pl->surf, r) / (p - 1);
    double *gall = (double *)kifmm__alloc((size_t)nth * per, sizeof(double)), mx = 0.0;
    int bad = 0, slot[KIFMM__NT];
    if (!gall) return KIFMM_ERR_NOMEM;
    kifmm__tv_slots(slot);
    /* each transfer vector writes its own spectra; g is the thread's grids */
    KIFMM__OMP(parallel for schedule(dynamic, 1) num_threads(nth) if(nth > 1) \
               reduction(| : bad) reduction(max : mx))
    for (int tv = 0; tv < KIFMM__NT; tv++) {
        double *g = gall + (size_t)kifmm__thread_num() * per, kv[SD2];
        const int at_t = turned ? slot[tv] : tv;
        int d[3] = {0, 0, 0}, i, j, k, ab;
        if (at_t < 0) continue; /* turned from the 16 */
        kifmm__transfer_vector(tv, d);
        memset(g, 0, sizeof(double) * SD2 * nnn);
        for (i = 1 - p; i < p; i++)
            for (j = 1 - p; j < p; j++)
                for (k = 1 - p; k < p; k++) {
                    const size_t at = ((size_t)(i + n) % n * n + (size_t)(j + n) % n) * n + (size_t)(k + n) % n;
                    KIFMM__R_(SC, _eval)(c->opts.kernel_param, h * i - 2.0 * r * d[0], h * j - 2.0 * r * d[1],
                                         h * k - 2.0 * r * d[2], kv);
                    for (ab = 0; ab < SD2; ab++) {
                        bad |= !(fabs(kv[ab]) <= DBL_MAX);
                        mx = fabs(sigma * kv[ab]) > mx ? fabs(sigma * kv[ab]) : mx;
                        g[ab * nnn + at] = sigma * kv[ab];
                    }
#if KIFMM__CPLX
                    bad |= kv[0] != kv[3] || kv[1] != -kv[2];
#endif
                }
        if (KIFMM__CPLX)
            kifmm__fft_grid(pl, g, g + 2 * nnn, kt + (size_t)at_t * 2 * pl->nfp, g + SD2 * nnn);
        for (ab = 0; !KIFMM__CPLX && ab < SD2; ab++)
            kifmm__fft_grid(pl, g + ab * nnn, NULL, kt + ((size_t)at_t * SD2 + ab) * 2 * pl->nfp,
                            g + SD2 * nnn);
    }
    kifmm__free(gall);
    *big = mx;
    return bad ? KIFMM_ERR_KERNEL : KIFMM_SUCCESS;
}

/* The turns of the FFT M2L's spectra: each of the 316 transfer vectors t is
 * turned from its vector c among the 16 with t_x >= t_y >= t_z >= 0 (R c,
 * R_{a, pi a} = s_a: kifmm__tv_turn), each kernel component ab its own (a
 * radial kernel, vec 0) or, for a vector kernel (vec 1, P__sc_vector),
 * component (d, e) s_d s_e times c's component (pi d, pi e) on the last
 * three (kifmm__comp_turn). tab[t KIFMM__KTAB_W(FSD) ..]: pi[3], s[3], c's
 * slot (kifmm__tv_slots), the turn's number (kifmm__turn_id), then for each
 * ab c's component and its sign (+1 or -1). */
KIFMM__FN void KIFMM__F(__khat_turns)(int vec, int *tab)
{
    enum { SD = KIFMM__FSD, SD2 = KIFMM__FSD * KIFMM__FSD, W = KIFMM__KTAB_W(KIFMM__FSD) };
    int slot[KIFMM__NT], tv, a, b;
    kifmm__tv_slots(slot);
    for (tv = 0; tv < KIFMM__NT; tv++) {
        int d[3] = {0, 0, 0}, *tt = tab + (size_t)W * tv;
        kifmm__transfer_vector(tv, d);
        tt[6] = slot[kifmm__tv_turn(d, tt, tt + 3)];
        tt[7] = kifmm__turn_id(tt, tt + 3);
        for (a = 0; a < SD; a++)
            for (b = 0; b < SD; b++) {
                double sa = 1.0, sb = 1.0;
                const int pa = vec ? kifmm__comp_turn(SD, tt, tt + 3, a, &sa) : a;
                const int pb = vec ? kifmm__comp_turn(SD, tt, tt + 3, b, &sb) : b;
                tt[8 + a * SD + b] = pa * SD + pb;
                tt[8 + SD2 + a * SD + b] = sa * sb < 0.0 ? -1 : 1;
            }
    }
}

/* The spectra kt of the 16 transfer vectors (P__m2l_grids, at kt + (slot
 * FSD^2 + ab) 2 nfp) frequency-major into khat[((f 16 + slot) FSD^2 + ab)
 * 2] (the padding frequencies 0), and the table of turns into ktab: the
 * others' spectra are read from them (kifmm__fft_blocks). Kept instead of
 * the 316's, a twentieth of their memory (stokes, p = 6: 1.7 against 33
 * MB), and none of their writes. */
KIFMM__FN void KIFMM__F(__khat_turned)(const KIFMM_NAME *c, const double *kt, int vec, int nth,
                                       double *khat, int *ktab)
{
    enum { SD2 = KIFMM__FSD * KIFMM__FSD };
    const kifmm__fft *pl = &c->pl->fft;
    const int nfp = pl->nfp;
    (void)nth; /* (without OpenMP) */
    KIFMM__F(__khat_turns)(vec, ktab);
    /* each (frequency, slot) writes its own block of khat */
    KIFMM__OMP(parallel for schedule(static) num_threads(nth) if(nth > 1))
    for (int64_t fs = 0; fs < (int64_t)16 * nfp; fs++) {
        const int64_t f = fs / 16, sl = fs % 16;
        for (int ab = 0; ab < SD2; ab++) {
            const double *in = kt + ((size_t)sl * SD2 + ab) * 2 * nfp + 2 * (size_t)f;
            const int pad = f >= pl->nf;
            khat[((size_t)fs * SD2 + ab) * 2] = pad ? 0.0 : in[0];
            khat[((size_t)fs * SD2 + ab) * 2 + 1] = pad ? 0.0 : in[1];
        }
    }
}

/* khat (P__build_m2l_fft's layout) from the spectra kt of all 316 transfer
 * vectors (P__m2l_grids), moved frequency-major */
KIFMM__FN void KIFMM__F(__khat_moved)(const KIFMM_NAME *c, const double *kt, int nth, double *khat)
{
    enum { SD2 = KIFMM__FSD * KIFMM__FSD };
    const kifmm__fft *pl = &c->pl->fft;
    (void)nth; /* (without OpenMP) */
    /* each frequency f writes its own row of khat */
    KIFMM__OMP(parallel for schedule(static) num_threads(nth) if(nth > 1))
    for (int32_t f = 0; f < pl->nfp; f++)
        for (int tab = 0; tab < KIFMM__NT * SD2; tab++) {
            khat[((size_t)f * KIFMM__NT * SD2 + tab) * 2] = kt[(size_t)tab * 2 * pl->nfp + 2 * f];
            khat[((size_t)f * KIFMM__NT * SD2 + tab) * 2 + 1] = kt[(size_t)tab * 2 * pl->nfp + 2 * f + 1];
        }
}

/* The FFT M2L's kernel spectra for boxes of half-width r, times sigma
 * (kifmm__m2l_grids), stored frequency-major (khat[((f 316 + t) FSD^2 +
 * ab) 2], re and im) so that the blocks of a chunk of frequencies read one
 * contiguous piece: 316 FSD^2 nfp complex values, independent of the tree. */
/* Whether the FFT M2L's spectra are the 16's turned (a radial or vector
 * kernel), with ktab, for build_m2l_fft and the memory estimate alike */
KIFMM__FN int KIFMM__F(__m2l_turned)(const KIFMM_NAME *c)
{
    return KIFMM__FRADIAL || KIFMM__F(__sc_vector)(c->opts.kernel_param);
}

KIFMM__FN int KIFMM__F(__build_m2l_fft)(const KIFMM_NAME *c, double r, int nth, kifmm__ops *o)
{
    enum { SD2 = KIFMM__FSD * KIFMM__FSD };
    const kifmm__fft *pl = &c->pl->fft;
    const int vec = !KIFMM__FRADIAL && KIFMM__F(__sc_vector)(c->opts.kernel_param);
    const int turned = KIFMM__F(__m2l_turned)(c);
    const size_t nk = (size_t)(turned ? 16 : KIFMM__NT) * SD2 * 2 * pl->nfp; /* turned: the 16's */
    double *kt; /* spectra per transfer vector */
    double big = 0.0;
    int rc;
    o->khat = (double *)kifmm__alloc(nk, sizeof(double));
    kt = (double *)kifmm__alloc(nk, sizeof(double));
    if (turned) o->ktab = (int *)kifmm__alloc((size_t)KIFMM__NT * KIFMM__KTAB_W(KIFMM__FSD), sizeof(int));
    if (!o->khat || !kt || (turned && !o->ktab)) {
        kifmm__free(kt);
        return KIFMM_ERR_NOMEM;
    }
    if (!turned) memset(kt, 0, sizeof(double) * nk); /* the padding frequencies stay 0 */
    rc = KIFMM__F(__m2l_grids)(c, r, o->sigma, nth, turned, kt, &big);
    if (rc == KIFMM_ERR_NOMEM) {
        kifmm__free(kt);
        return KIFMM_ERR_NOMEM;
    }
    if (turned) KIFMM__F(__khat_turned)(c, kt, vec, nth, o->khat, o->ktab);
    else KIFMM__F(__khat_moved)(c, kt, nth, o->khat);
    kifmm__free(kt);
    /* The M2L's kernel values reach those at the nearest lattice points of
     * well separated boxes (1.9 r apart), sigma is scaled to those of the
     * solves' surfaces (3.45 r): for a Yukawa kernel their ratio is
     * exp(1.55 lambda r), which passes the range of float spectra (float
     * instances) beyond lambda r = 45. The level's M2L is then left out: it
     * carries interactions at 1.9 r and more, where that kernel is below
     * exp(-85) / (4 pi r), under float's normal range for r >= 1e-2. Double
     * spectra would need lambda r > 445, past the point where the level's
     * surfaces already drop it (build_c2e). */
    if (big > (pl->single ? 1e30 : 1e300)) memset(o->khat, 0, sizeof(double) * nk);
    return rc;
}

#else
/* The dense M2L for boxes of half-width r: per transfer vector t, the
 * source box's upward equivalent density (centre 2 r t) -> the target box's
 * downward check potential, times sigma and times ut_dn (the first factor
 * of the downward solve): m2l = [ut_dn K_1 ... ut_dn K_316], kd x 316 ne.
 * Assembled CH transfer vectors at a time (in parallel), then one GEMM. */
KIFMM__FN int KIFMM__F(__build_m2l_dense)(const KIFMM_NAME *c, double r, kifmm__ops *o)
{
    enum { CH = 16 };
    const double zero[3] = {0.0, 0.0, 0.0};
    const int nc = c->pl->surf.nc, ne = c->pl->surf.ne;
    double *kall = (double *)kifmm__alloc((size_t)nc * CH * ne, sizeof(double));
    int bad = 0;
    o->m2l = (double *)kifmm__alloc((size_t)o->kd * KIFMM__NT * ne, sizeof(double));
    if (!o->m2l || !kall) {
        kifmm__free(kall);
        return KIFMM_ERR_NOMEM;
    }
    for (int tv = 0; tv < KIFMM__NT && !bad; tv += CH) {
        const int nch = KIFMM__NT - tv < (int)CH ? KIFMM__NT - tv : (int)CH;
        /* each k fills its own block of kall */
        KIFMM__OMP(parallel for schedule(dynamic, 1) num_threads(c->opts.nthreads) reduction(| : bad))
        for (int k = 0; k < nch; k++) {
            int d[3] = {0, 0, 0};
            double cs[3];
            kifmm__transfer_vector(tv + k, d);
            cs[0] = 2.0 * r * d[0];
            cs[1] = 2.0 * r * d[1];
            cs[2] = 2.0 * r * d[2];
            bad |= KIFMM__F(__surf_kmat)(c, c->pl->surf.unit_c, c->pl->surf.nsc, zero, KIFMM__F(__rin)(c->pl, &c->pl->surf, r),
                                         c->pl->surf.unit_e, c->pl->surf.nse, cs, KIFMM__F(__rin)(c->pl, &c->pl->surf, r),
                                         o->sigma, kall + (size_t)k * nc * ne, (size_t)nc,
                                         NULL) != KIFMM_SUCCESS;
        }
        kifmm__gemm(0, 0, o->kd, nch * ne, nc, 1.0, o->ut_dn, o->kd, kall, nc, 0.0,
                    o->m2l + (size_t)tv * ne * o->kd, o->kd);
    }
    kifmm__free(kall);
    return bad ? KIFMM_ERR_KERNEL : KIFMM_SUCCESS;
}
#endif

KIFMM__FN int KIFMM__F(__anchor_fit)(const KIFMM_NAME *c, double r, kifmm__ops *o); /* >>anchors */

/* The operators for target boxes of half-width r (see kifmm__ops), in
 * double, in two steps: first what takes kernel values only (the solves'
 * matrices, M2M and L2L, the M2L's spectra on nth threads), which levels
 * can build side by side; then what calls LAPACK or BLAS (the solves, the
 * FFT M2L's lattice fit, the dense M2L: P__ops_solves_all), side by side
 * only where the BLAS runs one thread a call, so that no threaded BLAS runs
 * inside a parallel region. The M2L's only if m2l (a level that has boxes
 * with V lists). */
KIFMM__FN int KIFMM__F(__ops_kernels)(const KIFMM_NAME *c, double r, int m2l, int nth,
                                      kifmm__ops *o)
{
    int rc = KIFMM__F(__c2e_kernels)(c, r, c->pl->surf.ao, o);
    if (!rc) rc = KIFMM__F(__build_m2m_l2l)(c, r, o);
#if KIFMM__FFT
    if (!rc && m2l) rc = KIFMM__F(__build_m2l_fft)(c, r, nth, o);
#else
    (void)m2l;
    (void)nth;
#endif
    return rc;
}

/* The solves of one set in two parts that read and write apart: part 0
 * the check-to-equivalent factors and the anchors' fit, part 1 the FFT
 * M2L's lattice fit (kernel values only). (The dense M2L, which reads
 * part 0's factors, follows in P__ops_solves_all.) */
KIFMM__FN int KIFMM__F(__ops_solves)(const KIFMM_NAME *c, double r, int m2l, int part, kifmm__ops *o)
{
    int rc = KIFMM_SUCCESS;
    if (part == 0) {
        rc = KIFMM__F(__c2e_solve)(c, o);
        if (!rc) rc = KIFMM__F(__anchor_fit)(c, r, o);
    }
#if KIFMM__FFT
    if (part == 1 && m2l) rc = KIFMM__F(__build_conv)(c, r, o);
#endif
    (void)m2l;
    return rc;
}

/* Every new set's solves (__ops_solves, the sets where from[l] < 0 and
 * rc[l] is 0), their two parts per level side by side on the build's
 * threads where the BLAS runs one thread a call (kifmm__blas_serial;
 * laplace_grad at p = 12: 0.148 -> 0.092 s a create, docs/api.md), else
 * one after the other, so that no threaded BLAS runs inside a parallel
 * region; rc[l] gets the first error of level l. */
KIFMM__FN void KIFMM__F(__ops_solves_all)(const KIFMM_NAME *v, int nlev, const double *r, const int *m2l,
                                          const int *from, kifmm__ops *o, int *rc)
{
    const int nth = v[0].opts.nthreads, par = nth > 1 && kifmm__blas_serial();
    int *rp = (int *)kifmm__calloc((size_t)2 * nlev, sizeof(int)), l;
    (void)par; /* (without OpenMP) */
    if (!rp) {
        for (l = 0; l < nlev; l++) rc[l] = rc[l] ? rc[l] : KIFMM_ERR_NOMEM;
        return;
    }
    /* task t writes rp[t] and part t % 2 of level t / 2's set (o[l]'s
     * fields of that part; the symmetry bases' cache under
     * kifmm__symb_get's critical section) */
    KIFMM__OMP(parallel for schedule(dynamic, 1) num_threads(nth) if(par))
    for (int t = 0; t < 2 * nlev; t++)
        if (from[t / 2] < 0 && !rc[t / 2])
            rp[t] = KIFMM__F(__ops_solves)(&v[t / 2], r[t / 2], m2l[t / 2], t % 2, &o[t / 2]);
    for (l = 0; l < nlev; l++)
        if (!rc[l]) rc[l] = rp[2 * l] ? rp[2 * l] : rp[2 * l + 1];
    kifmm__free(rp);
#if !KIFMM__FFT
    /* the dense M2L after them, its kernel matrices on the threads */
    for (l = 0; l < nlev; l++)
        if (from[l] < 0 && !rc[l] && m2l[l]) rc[l] = KIFMM__F(__build_m2l_dense)(&v[l], r[l], &o[l]);
#endif
}

/* nz[ab] = 1 for the kernel components ab with a nonzero value in
 * the spectra khat (kifmm__build_m2l_fft's layout; with ktab, in one of
 * the 16's components that ab of a transfer vector is turned from) */
KIFMM__FN void KIFMM__F(__m2l_nonzero)(const KIFMM_NAME *c, const double *khat, const int *ktab,
                                       unsigned char *nz)
{
    enum { SD2 = KIFMM__FSD * KIFMM__FSD };
    const size_t n = (size_t)c->pl->fft.nfp * (ktab ? 16 : KIFMM__NT) * SD2;
    unsigned char any[16 * SD2];
    size_t f;
    int ab, t;
    if (SD2 == 1) return; /* one block: always multiplied */
    memset(any, 0, sizeof any);
    for (f = 0; f < n; f++) /* f = (frequency 316 + t) SD2 + ab, or 16 + slot */
        if (khat[2 * f] != 0.0 || khat[2 * f + 1] != 0.0) any[f % (ktab ? 16 * SD2 : SD2)] = 1;
    for (ab = 0; ab < SD2; ab++)
        if (!ktab) nz[ab] |= any[ab];
        else
            for (t = 0; t < KIFMM__NT; t++) {
                const int *e = ktab + (size_t)KIFMM__KTAB_W(KIFMM__FSD) * t;
                nz[ab] |= any[e[6] * SD2 + e[8 + ab]];
            }
}

/* Keep one level's operators (built in double, freed here) in the
 * instance's precision, counted in the entry's held. */
KIFMM__FN int KIFMM__F(__ops_keep)(const KIFMM_NAME *c, kifmm__ops *o, KIFMM__F(__ops) *out)
{
    const size_t ne = (size_t)c->pl->surf.ne, nc = (size_t)c->pl->surf.nc;
    const size_t nec = (size_t)(o->sc ? o->sc : &c->pl->surf)->ne; /* M2M's children's */
    const size_t ndp = (size_t)(o->sp ? o->sp : &c->pl->surf)->nde; /* L2L's parent's */
    size_t *held = &out->held;
    int rc = KIFMM_SUCCESS;
    out->sigma = o->sigma;
    out->ku = o->ku;
    out->kd = o->kd;
    out->ut_up = KIFMM__F(__own)(held, &o->ut_up, (size_t)o->ku * nc);
    out->vs_up = KIFMM__F(__own)(held, &o->vs_up, ne * (size_t)o->ku);
    out->ut_dn = KIFMM__F(__own)(held, &o->ut_dn, (size_t)o->kd * nc);
    out->vs_dn = KIFMM__F(__own)(held, &o->vs_dn, (size_t)c->pl->surf.nde * (size_t)o->kd);
    out->m2m = KIFMM__F(__own)(held, &o->m2m, o->mir ? nc * ne : nc * 8 * nec);
    out->l2l = KIFMM__F(__own)(held, &o->l2l, o->mir ? nc * ne + 8 * nc * (ndp - ne) : 8 * nc * ndp);
    out->mir = o->mir;
    if (o->mmap) *held += kifmm__size(o->mmap);
    out->mmap = o->mmap;
    o->mmap = NULL;
    if (o->conv && !(out->conv = KIFMM__F(__own)(held, &o->conv, nc * ne))) rc = KIFMM_ERR_NOMEM;
    if (o->m2l && !(out->m2l = KIFMM__F(__own)(held, &o->m2l, (size_t)o->kd * KIFMM__NT * ne)))
        rc = KIFMM_ERR_NOMEM;
    if (o->khat) {
        *held += kifmm__size(o->khat);
        if (o->ktab) *held += kifmm__size(o->ktab);
        KIFMM__F(__m2l_nonzero)(c, o->khat, o->ktab, out->nz);
    }
    out->khat = o->khat, out->ktab = o->ktab;
    o->khat = NULL, o->ktab = NULL;
    if (!out->ut_up || !out->vs_up || !out->ut_dn || !out->vs_dn || !out->m2m || !out->l2l)
        rc = KIFMM_ERR_NOMEM;
    kifmm__ops_free(o);
    return rc;
}

KIFMM__FN void KIFMM__F(__ops_free)(KIFMM__F(__ops) *o)
{
    kifmm__free(o->ut_up); kifmm__free(o->vs_up);
    kifmm__free(o->ut_dn); kifmm__free(o->vs_dn);
    kifmm__free(o->m2m); kifmm__free(o->l2l); kifmm__free(o->m2l);
    kifmm__free(o->conv); kifmm__free(o->khat); kifmm__free(o->ktab);
    kifmm__free(o->kbf); kifmm__free(o->kbd); kifmm__free(o->mmap);
    memset(o, 0, sizeof *o);
}

#if KIFMM__FFT
/* The products' blocks of every chunk (kifmm__fft_blocks) for the n new
 * operator sets e, built once when they all fit, with the blocks the plan
 * keeps already, in KIFMM__FFT_KB_MB, and so would the blocks of all ntot
 * sets with M2L the tree uses (so that a tree keeps what create would
 * keep for it, whatever the plan held before) (float spectra, one set of operators:
 * 5.6 MiB at p = 4); otherwise the products build each chunk's blocks once
 * per slab, in the thread's cache. Kept blocks larger than that are read
 * from memory by every task: uniform points, 2 threads, M2L by chunks
 * against kept blocks: the same at p = 4 and 5 (kept: less memory, no slab
 * outputs), 0.68 against 0.81 s at p = 6 (16 MiB, 1M points; 0.07 against
 * 0.08 s at 200k), 3.3 against 4.8 s at p = 8 (72 MiB, 2M points). Under
 * the plan's lock. */
KIFMM__FN int KIFMM__F(__keep_blocks)(const KIFMM_NAME *c, KIFMM__F(__ops) **e, int n, int ntot)
{
    const kifmm__fft *pl = &c->pl->fft;
    const size_t per = KIFMM__FFT_KBN, all = per * (size_t)pl->nchunk;
    const size_t bytes = all * (pl->single ? sizeof(float) : sizeof(double));
    const size_t cap = (size_t)KIFMM__FFT_KB_MB << 20;
    int tvm[27 * 64], nk = 0, k;
    /* (the sets of raised levels, >>orders, build theirs per slab) */
    for (k = 0; k < n; k++) nk += e[k]->khat != NULL && e[k]->p[0] == c->pl->opts.order;
    if (nk == 0 || c->pl->ops.kept + bytes * (size_t)nk > cap || bytes * (size_t)ntot > cap)
        return KIFMM_SUCCESS;
    kifmm__fft_tvmap(tvm);
    for (k = 0; k < n; k++) {
        KIFMM__F(__ops) *o = e[k];
        if (!o->khat || o->p[0] != c->pl->opts.order) continue;
        if (pl->single) o->kbf = (float *)kifmm__take(&o->held, all, sizeof(float));
        else o->kbd = (double *)kifmm__take(&o->held, all, sizeof(double));
        if (!o->kbf && !o->kbd) return KIFMM_ERR_NOMEM;
        /* each chunk writes its own blocks */
        KIFMM__OMP(parallel for schedule(static) num_threads(c->opts.nthreads))
        for (int ch = 0; ch < pl->nchunk; ch++) {
            if (o->kbf) kifmm__fft_blocksf(pl, o->khat, o->ktab, tvm, KIFMM__FSD, ch, o->kbf + per * (size_t)ch);
            else kifmm__fft_blocksd(pl, o->khat, o->ktab, tvm, KIFMM__FSD, ch, o->kbd + per * (size_t)ch);
        }
    }
    return KIFMM_SUCCESS;
}
#endif

/* The kernel values of the levels from l0 on (half-widths r[l]) into o[l],
 * rc[l] each: with at least one level per thread, the levels side by side
 * (one thread each), otherwise one after the other on all threads (Yukawa,
 * 100k uniform points, levels 2 to 4 on 2 threads: 0.04 s side by side,
 * 0.05 s one after the other). v[l]: level l's handle (__ops_view). */
KIFMM__FN void KIFMM__F(__ops_levels)(const KIFMM_NAME *v, int l0, int nl, const double *r,
                                      const int *m2l, const int *from, kifmm__ops *o, int *rc)
{
    int l, todo = 0;
    for (l = l0; l < nl; l++) todo += from[l] < 0;
    const int nth = v[0].opts.nthreads, outer = todo >= nth;
    /* each level l writes its own o[l] and rc[l]; levels the plan holds
     * already (from[l] >= 0) are skipped */
    KIFMM__OMP(parallel for schedule(dynamic, 1) num_threads(nth) if(outer))
    for (int k = l0; k < nl; k++)
        if (from[k] < 0) rc[k] = KIFMM__F(__ops_kernels)(&v[k], r[k], m2l[k], outer ? 1 : nth, &o[k]);
}

/* The monopole map of a scale-invariant kernel whose surfaces carry 1 / r
 * sources (charges, Stokeslets: degree -1): e->mono[a + s SD], the sum
 * over the surface points of component a of the upward equivalent density
 * fitted to one unit density of kind s at a box's centre (o: the unit box's
 * operators, in double). The sums of a density are its far field's leading
 * term, and the surfaces' sources are 1 / r points, so the sum of their
 * densities is theirs; kinds without a monopole (dipoles, the double layer's
 * Stokeslet part) sum to rounding, set to 0. */
KIFMM__FN int KIFMM__F(__mono_map)(const KIFMM_NAME *c, const kifmm__ops *o, KIFMM__F(__ops) *e)
{
    const int nc = c->pl->surf.nc, ne = c->pl->surf.ne, nsc = c->pl->surf.nsc;
    double *pc = (double *)kifmm__alloc((size_t)3 * nsc, sizeof(double));
    double *k = (double *)kifmm__alloc((size_t)nc * KIFMM__QD, sizeof(double));
    double *t = (double *)kifmm__alloc((size_t)o->ku * KIFMM__QD + 1, sizeof(double));
    double *x = (double *)kifmm__alloc((size_t)ne * KIFMM__QD, sizeof(double));
    double kv[KIFMM__SD * KIFMM__QD];
    const double zero[3] = {0.0, 0.0, 0.0};
    int i, a, s, ok = 1, rc = KIFMM_SUCCESS;
    if (!pc || !k || !t || !x) { rc = KIFMM_ERR_NOMEM; goto done; }
    kifmm__surf_place(c->pl->surf.unit_c, nsc, zero, c->pl->surf.ao, pc);
    for (i = 0; i < nsc; i++) {
        KIFMM__R_(QC, _eval)(c->opts.kernel_param, pc[i], pc[nsc + i], pc[2 * nsc + i], kv);
        for (a = 0; a < KIFMM__SD; a++)
            for (s = 0; s < KIFMM__QD; s++)
                k[i * KIFMM__SD + a + (size_t)s * nc] = kv[a * KIFMM__QD + s];
    }
    kifmm__gemm(0, 0, o->ku, KIFMM__QD, nc, 1.0, o->ut_up, o->ku, k, nc, 0.0, t, o->ku);
    kifmm__gemm(0, 0, ne, KIFMM__QD, o->ku, o->sigma, o->vs_up, ne, t, o->ku, 0.0, x, ne);
    for (s = 0; s < KIFMM__QD; s++) {
        double m[KIFMM__SD];
        for (a = 0; a < KIFMM__SD; a++) m[a] = 0.0;
        for (i = 0; i < ne; i++) m[i % KIFMM__SD] += x[i + (size_t)s * ne];
        for (a = 0; a < KIFMM__SD; a++) {
            e->mono[a + s * KIFMM__SD] = fabs(m[a]) > 1e-6 ? m[a] : 0.0;
            ok &= isfinite(m[a]) != 0;
        }
    }
    e->mono_on = ok; /* a map that is not finite: the densities keep their fit */
done:
    kifmm__free(pc);
    kifmm__free(k);
    kifmm__free(t);
    kifmm__free(x);
    return rc;
}

// >>cache: operator sets kept in files (opts.operator_cache)

/* A set built once is read back by later creates, in this process or any
 * other, from the directory opts.operator_cache names: one file per set,
 * named after the instance's kernel, precision and order and a hash of the
 * set's key. The key holds every input the set's values depend on: the
 * file format and the library's version, the kernel's name, parameters and
 * values at three points (a kernel changed under the same name gives other
 * values), the precision, the half-width and the orders, the surfaces'
 * sizes and radii, the FFT lattice, the cutoffs. A file is taken only if
 * its key is this one, every array's length is the one these surfaces and
 * ranks give, and the hash of its contents matches; else the set is built
 * and its file written again. Files are written under a name of their own
 * and renamed into place, so that readers (threads, processes, MPI ranks)
 * see a whole file or none. Failures to read or write are never errors:
 * the set is then built, or not kept. The products' blocks (__keep_blocks)
 * and the periodic far images are not kept: they are built from a set. */
#define KIFMM__CACHE_FORMAT 1 /* raise with any change to a set's contents or build */

/* The key: room for the fixed fields, the kernel's name and its values. */
enum { KIFMM__F(__CKEY_BYTES) = 1024 + 3 * 8 * KIFMM__SD * (KIFMM__SD + KIFMM__QD) };
typedef struct {
    size_t n;
    unsigned char b[KIFMM__F(__CKEY_BYTES)];
} KIFMM__F(__ckey);

KIFMM__FN void KIFMM__F(__ckey_put)(KIFMM__F(__ckey) *k, const void *p, size_t n)
{
    if (k->n + n <= sizeof k->b) memcpy(k->b + k->n, p, n);
    k->n += n; /* past the room: no key (__cache_key) */
}
KIFMM__FN void KIFMM__F(__ckey_int)(KIFMM__F(__ckey) *k, int64_t v) { KIFMM__F(__ckey_put)(k, &v, sizeof v); }
KIFMM__FN void KIFMM__F(__ckey_dbl)(KIFMM__F(__ckey) *k, double v) { KIFMM__F(__ckey_put)(k, &v, sizeof v); }

/* A surface's fields in the key (s NULL: the level's own, marked 0). */
KIFMM__FN void KIFMM__F(__ckey_surf)(KIFMM__F(__ckey) *k, const kifmm__surf *s)
{
    KIFMM__F(__ckey_int)(k, s != NULL);
    if (!s) return;
    KIFMM__F(__ckey_int)(k, s->nse), KIFMM__F(__ckey_int)(k, s->nsc);
    KIFMM__F(__ckey_int)(k, s->cdiff), KIFMM__F(__ckey_int)(k, s->nsa);
    KIFMM__F(__ckey_int)(k, s->nde);
    KIFMM__F(__ckey_dbl)(k, s->ai), KIFMM__F(__ckey_dbl)(k, s->ao);
}

/* The key of the set of level view v (nb: its neighbours' surfaces, from
 * __ops_view) at half-width r, orders p, with the M2L's if m2l; 0 if it
 * does not fit (then nothing is cached). */
KIFMM__FN int KIFMM__F(__cache_key)(const KIFMM_NAME *v, const kifmm__ops *nb, double r, const int *p,
                                    int m2l, KIFMM__F(__ckey) *k)
{
    static const double at[3][3] = {{0.61, 0.29, -0.23}, {1.73, -1.09, 0.87}, {-2.93, 0.41, 3.37}};
    const char *name = KIFMM__STR(KIFMM_KERNEL);
    const double *prm = v->opts.kernel_param;
    double kv[KIFMM__SD * (KIFMM__SD > KIFMM__QD ? KIFMM__SD : KIFMM__QD)];
    int i, j;
    k->n = 0;
    KIFMM__F(__ckey_put)(k, "KIFMMOPS", 8);
    KIFMM__F(__ckey_int)(k, KIFMM__CACHE_FORMAT);
    KIFMM__F(__ckey_int)(k, KIFMM_VERSION_MAJOR * 10000 + KIFMM_VERSION_MINOR * 100 + KIFMM_VERSION_PATCH);
    KIFMM__F(__ckey_int)(k, (int64_t)0x0102030405060708ll); /* byte order */
    KIFMM__F(__ckey_int)(k, (int64_t)(strlen(name)));
    KIFMM__F(__ckey_put)(k, name, strlen(name));
    KIFMM__F(__ckey_int)(k, (int64_t)sizeof(KIFMM__R));
    KIFMM__F(__ckey_int)(k, KIFMM__SD), KIFMM__F(__ckey_int)(k, KIFMM__QD);
    KIFMM__F(__ckey_int)(k, KIFMM__TD), KIFMM__F(__ckey_int)(k, KIFMM__FSD);
    KIFMM__F(__ckey_int)(k, KIFMM__SI), KIFMM__F(__ckey_int)(k, KIFMM__DEGREE);
    KIFMM__F(__ckey_int)(k, KIFMM__RADIAL), KIFMM__F(__ckey_int)(k, KIFMM__CPLX);
    KIFMM__F(__ckey_int)(k, KIFMM__FFT), KIFMM__F(__ckey_int)(k, KIFMM__ANCHORS);
    KIFMM__F(__ckey_int)(k, KIFMM_MONO_FIX);
    KIFMM__F(__ckey_dbl)(k, KIFMM__CUTOFF), KIFMM__F(__ckey_dbl)(k, KIFMM__TINY);
    KIFMM__F(__ckey_dbl)(k, KIFMM__ANCHOR_RADIUS), KIFMM__F(__ckey_dbl)(k, KIFMM__ANCHOR_CUTOFF);
    KIFMM__F(__ckey_dbl)(k, KIFMM__ANCHOR_FLOOR);
    for (i = 0; i < 4; i++) KIFMM__F(__ckey_dbl)(k, prm[i]);
    KIFMM__F(__ckey_dbl)(k, r);
    for (i = 0; i < 3; i++) KIFMM__F(__ckey_int)(k, p[i]);
    KIFMM__F(__ckey_int)(k, m2l);
    KIFMM__F(__ckey_surf)(k, &v->pl->surf);
    KIFMM__F(__ckey_surf)(k, nb->sc);
    KIFMM__F(__ckey_surf)(k, nb->sp);
#if KIFMM__FFT
    {
        const kifmm__fft *f = &v->pl->fft;
        KIFMM__F(__ckey_int)(k, f->p), KIFMM__F(__ckey_int)(k, f->n), KIFMM__F(__ckey_int)(k, f->nh);
        KIFMM__F(__ckey_int)(k, f->nfp), KIFMM__F(__ckey_int)(k, f->single);
        KIFMM__F(__ckey_int)(k, f->cplx), KIFMM__F(__ckey_int)(k, KIFMM__F(__m2l_turned)(v));
    }
#endif
    /* the kernel's values at three points r apart: the surface kernel's and
     * the points-to-check kernel's (the monopole map's) */
    for (j = 0; j < 3; j++) {
        KIFMM__R_(SC, _eval)(prm, at[j][0] * r, at[j][1] * r, at[j][2] * r, kv);
        for (i = 0; i < KIFMM__SD * KIFMM__SD; i++) KIFMM__F(__ckey_dbl)(k, kv[i]);
        KIFMM__R_(QC, _eval)(prm, at[j][0] * r, at[j][1] * r, at[j][2] * r, kv);
        for (i = 0; i < KIFMM__SD * KIFMM__QD; i++) KIFMM__F(__ckey_dbl)(k, kv[i]);
    }
    return k->n <= sizeof k->b;
}

/* The file of key k in opts.operator_cache (kifmm__free it), or NULL. */
KIFMM__FN char *KIFMM__F(__cache_path)(const KIFMM_NAME *v, const int *p, const KIFMM__F(__ckey) *k)
{
    char name[160];
    snprintf(name, sizeof name, "kifmm-%.64s-%s-p%d-%016llx.ops", KIFMM__STR(KIFMM_KERNEL),
             KIFMM__FLOAT ? "f" : "d", p[0], (unsigned long long)kifmm__hash_bytes(k->b, k->n));
    return kifmm__path(v->pl->cache.dir, name);
}

/* The lengths of a set's arrays (in elements: ut_up, vs_up, ut_dn, vs_dn,
 * m2m, l2l, conv, m2l, mmap, khat, ktab) from its ranks and mirror kind,
 * as __ops_keep keeps them for these surfaces (nb: the neighbours'). */
KIFMM__FN void KIFMM__F(__cache_lengths)(const KIFMM_NAME *v, const kifmm__ops *nb, const KIFMM__F(__ops) *x,
                                         int m2l, size_t *len)
{
    const kifmm__surf *s = &v->pl->surf;
    const size_t ne = (size_t)s->ne, nc = (size_t)s->nc, nde = (size_t)s->nde;
    const size_t nec = (size_t)(nb->sc ? nb->sc : s)->ne, ndp = (size_t)(nb->sp ? nb->sp : s)->nde;
    const size_t ku = (size_t)x->ku, kd = (size_t)x->kd;
    len[0] = ku * nc, len[1] = ne * ku, len[2] = kd * nc, len[3] = nde * kd;
    len[4] = x->mir ? nc * ne : nc * 8 * nec;
    len[5] = x->mir ? nc * ne + 8 * nc * (ndp - ne) : 8 * nc * ndp;
    len[6] = KIFMM__FFT && m2l && s->cdiff > 0 ? nc * ne : 0; /* (square systems: none) */
    len[7] = !KIFMM__FFT && m2l ? kd * KIFMM__NT * ne : 0;
    len[8] = x->mir ? (size_t)7 * (size_t)(s->nsc + s->nse) : 0;
    len[9] = len[10] = 0;
#if KIFMM__FFT
    if (m2l) {
        const int turned = KIFMM__F(__m2l_turned)(v);
        len[9] = (size_t)(turned ? 16 : KIFMM__NT) * KIFMM__FSD * KIFMM__FSD * 2 * (size_t)v->pl->fft.nfp;
        len[10] = turned ? (size_t)KIFMM__NT * KIFMM__KTAB_W(KIFMM__FSD) : 0;
    }
#endif
}

/* Array i of set x (the order of __cache_lengths) and its element size. */
KIFMM__FN void *KIFMM__F(__cache_arr)(const KIFMM__F(__ops) *x, int i, size_t *es)
{
    const KIFMM__R *ra[8];
    ra[0] = x->ut_up, ra[1] = x->vs_up, ra[2] = x->ut_dn, ra[3] = x->vs_dn;
    ra[4] = x->m2m, ra[5] = x->l2l, ra[6] = x->conv, ra[7] = x->m2l;
    *es = i == 9 ? sizeof(double) : i >= 8 ? sizeof(int) : sizeof(KIFMM__R);
    return (void *)(uintptr_t)(i < 8 ? (const void *)ra[i] : i == 8 ? (const void *)x->mmap
                                                          : i == 9 ? (const void *)x->khat
                                                                   : (const void *)x->ktab);
}

/* Array i of set x set to q (from kifmm__alloc). */
KIFMM__FN void KIFMM__F(__cache_set)(KIFMM__F(__ops) *x, int i, void *q)
{
    switch (i) {
    case 0: x->ut_up = (KIFMM__R *)q; break;
    case 1: x->vs_up = (KIFMM__R *)q; break;
    case 2: x->ut_dn = (KIFMM__R *)q; break;
    case 3: x->vs_dn = (KIFMM__R *)q; break;
    case 4: x->m2m = (KIFMM__R *)q; break;
    case 5: x->l2l = (KIFMM__R *)q; break;
    case 6: x->conv = (KIFMM__R *)q; break;
    case 7: x->m2l = (KIFMM__R *)q; break;
    case 8: x->mmap = (int *)q; break;
    case 9: x->khat = (double *)q; break;
    default: x->ktab = (int *)q; break;
    }
}

/* A set read: its tables of indices made again, not taken from the file
 * (the M2L's turns), or checked (the mirror maps' points); 0 if one is out
 * of range. */
KIFMM__FN int KIFMM__F(__cache_tables)(const KIFMM_NAME *v, KIFMM__F(__ops) *x)
{
    const int nsc = v->pl->surf.nsc, nse = v->pl->surf.nse;
    int i, ok = 1;
#if KIFMM__FFT
    if (x->ktab) KIFMM__F(__khat_turns)(!KIFMM__FRADIAL && KIFMM__F(__sc_vector)(v->opts.kernel_param), x->ktab);
#endif
    for (i = 0; ok && x->mmap && i < 7 * (nsc + nse); i++) {
        const int m = x->mmap[i];
        ok = m >= 0 && m < (i % (nsc + nse) < nsc ? nsc : nse);
    }
    return ok;
}

/* The set's file written (wr) from x, or read into x (a zeroed set whose
 * arrays it allocates, counted in x->held), field by field through the
 * same calls, so that the two agree; returns whether every field was
 * written, or read and found to be what key k and these surfaces give. */
KIFMM__FN int KIFMM__F(__cache_io)(const KIFMM_NAME *v, const kifmm__ops *nb, int m2l,
                                   const KIFMM__F(__ckey) *k, kifmm__file *f, int wr, KIFMM__F(__ops) *x)
{
    unsigned char *kb = (unsigned char *)kifmm__alloc(k->n, 1);
    int32_t sc[4];
    double sig = x->sigma, mono[KIFMM__SD * KIFMM__QD];
    uint64_t u = k->n, h;
    size_t len[11], es;
    int i, ok = kb != NULL;
    sc[0] = x->ku, sc[1] = x->kd, sc[2] = x->mir, sc[3] = x->mono_on;
    memcpy(mono, x->mono, sizeof mono);
    if (kb && wr) memcpy(kb, k->b, k->n);
    /* the key, whole */
    kifmm__fio(f, wr, &u, sizeof u);
    ok = ok && f->ok && u == k->n;
    if (ok) kifmm__fio(f, wr, kb, k->n);
    ok = ok && f->ok && memcmp(kb, k->b, k->n) == 0;
    kifmm__free(kb);
    /* the scalars, then the arrays with their lengths */
    if (ok) kifmm__fio(f, wr, sc, sizeof sc);
    if (ok) kifmm__fio(f, wr, &sig, sizeof sig);
    if (ok) kifmm__fio(f, wr, mono, sizeof mono);
    ok = ok && f->ok;
    if (ok && !wr) {
        const kifmm__surf *s = &v->pl->surf;
        x->ku = sc[0], x->kd = sc[1], x->mir = sc[2], x->mono_on = sc[3], x->sigma = sig;
        memcpy(x->mono, mono, sizeof mono);
        const int mn = s->nc < s->ne ? s->nc : s->ne;
        const int vec = !KIFMM__FRADIAL && KIFMM__F(__sc_vector)(v->opts.kernel_param);
        /* the ranks the solves give (the downward one with the anchors'
         * columns), the mirror kind the build chooses (__build_m2m_l2l) */
        ok = x->ku >= 0 && x->ku <= mn && x->kd >= 0 && x->kd <= mn + s->nsa * KIFMM__SD &&
             x->mir == ((KIFMM__FRADIAL || vec) && !nb->sc && !nb->sp ? (vec ? 2 : 1) : 0) &&
             (x->mono_on == 0 || x->mono_on == 1) && isfinite(sig);
    }
    if (ok) KIFMM__F(__cache_lengths)(v, nb, x, m2l, len);
    for (i = 0; ok && i < 11; i++) {
        void *q = KIFMM__F(__cache_arr)(x, i, &es);
        u = len[i];
        kifmm__fio(f, wr, &u, sizeof u);
        /* (the factors and M2M, L2L of rank 0, a level whose kernel
         * underflows, are blocks of no elements: NULL would be no array) */
        ok = f->ok && u == len[i] && (!wr || q != NULL || len[i] == 0);
        if (ok && !wr && (len[i] || i < 6 || (i == 7 && m2l && !KIFMM__FFT))) {
            if ((q = kifmm__take(&x->held, len[i], es)) != NULL) KIFMM__F(__cache_set)(x, i, q);
            else ok = 0;
        }
        if (ok) kifmm__fio(f, wr, q, len[i] * es);
        ok = ok && f->ok;
    }
    if (ok && !wr) ok = KIFMM__F(__cache_tables)(v, x);
    /* the hash of all that, and then the file's end */
    h = f->h;
    if (ok && wr) ok = fwrite(&h, sizeof h, 1, f->f) == 1;
    if (ok && !wr) ok = fread(&u, sizeof u, 1, f->f) == 1 && u == h && fgetc(f->f) == EOF;
    return ok;
}

/* Level view v's set at half-width r, orders p (with the M2L's if m2l),
 * read from opts.operator_cache, or NULL (no such file, or not one to
 * take). */
KIFMM__FN KIFMM__F(__ops) *KIFMM__F(__cache_read)(const KIFMM_NAME *v, const kifmm__ops *nb, double r,
                                                   const int *p, int m2l)
{
    KIFMM__F(__ckey) *k = (KIFMM__F(__ckey) *)kifmm__alloc(1, sizeof *k);
    KIFMM__F(__ops) *x = (KIFMM__F(__ops) *)kifmm__calloc(1, sizeof *x);
    char *path = NULL;
    kifmm__file f;
    int ok = k && x && KIFMM__F(__cache_key)(v, nb, r, p, m2l, k) && (path = KIFMM__F(__cache_path)(v, p, k));
    f.f = ok ? fopen(path, "rb") : NULL;
    f.h = 0, f.ok = f.f != NULL;
    ok = f.ok && KIFMM__F(__cache_io)(v, nb, m2l, k, &f, 0, x);
    if (f.f) fclose(f.f);
    if (ok) {
        x->r = r, x->has_m2l = m2l;
        memcpy(x->p, p, sizeof x->p);
#if KIFMM__FFT
        if (x->khat) KIFMM__F(__m2l_nonzero)(v, x->khat, x->ktab, x->nz);
#endif
    } else if (x) {
        KIFMM__F(__ops_free)(x);
        kifmm__free(x);
        x = NULL;
    }
    if (v->opts.verbose && path && x)
        fprintf(stderr, "%s create: operator set read from %s\n", KIFMM__STR(KIFMM_NAME), path);
    kifmm__free(path);
    kifmm__free(k);
    return x;
}

/* Set x (just built) written to opts.operator_cache; returns whether it was. */
KIFMM__FN int KIFMM__F(__cache_write)(const KIFMM_NAME *v, const kifmm__ops *nb, const KIFMM__F(__ops) *x)
{
    KIFMM__F(__ckey) *k = (KIFMM__F(__ckey) *)kifmm__alloc(1, sizeof *k);
    KIFMM__F(__ops) y = *x; /* (__cache_io only reads y's arrays) */
    char *path = NULL, *tmp = NULL;
    kifmm__file f;
    int ok = k && KIFMM__F(__cache_key)(v, nb, x->r, x->p, x->has_m2l, k) &&
             (path = KIFMM__F(__cache_path)(v, x->p, k));
    f.f = ok ? kifmm__fcreate(path, &tmp) : NULL;
    f.h = 0, f.ok = f.f != NULL;
    if (f.f) ok = kifmm__fcommit(f.f, tmp, path, KIFMM__F(__cache_io)(v, nb, x->has_m2l, k, &f, 1, &y));
    else ok = 0;
    if (v->opts.verbose && path)
        fprintf(stderr, "%s create: operator set %s %s\n", KIFMM__STR(KIFMM_NAME),
                ok ? "written to" : "could not be written to", path);
    kifmm__free(path);
    kifmm__free(k);
    return ok;
}

// >>operators (the plan's sets: find, add, drop, build, precompute)

/* ---- the plan's operator sets ------------------------------------------ */

/* The set of plan pl built at half-width r for orders p (pp, pc: the
 * parent's and children's levels'), with the M2L's operators if m2l, or
 * NULL. Under the plan's lock. */
KIFMM__FN KIFMM__F(__ops) *KIFMM__F(__ops_find)(const KIFMM__F(_plan) *pl, double r, const int *p, int m2l)
{
    int j;
    for (j = 0; j < pl->ops.n; j++) {
        const KIFMM__F(__ops) *e = pl->ops.set[j];
        if (e->r == r && e->p[0] == p[0] && e->p[1] == p[1] && e->p[2] == p[2] && (!m2l || e->has_m2l))
            return pl->ops.set[j];
    }
    return NULL;
}

/* Bytes of the products' blocks a set keeps (__keep_blocks). */
KIFMM__FN size_t KIFMM__F(__ops_kept)(const KIFMM__F(__ops) *e)
{
    return kifmm__size(e->kbf) + kifmm__size(e->kbd);
}

/* A new set e (refs 1) into plan pl; on failure e is freed. Under the lock. */
KIFMM__FN int KIFMM__F(__ops_add)(KIFMM__F(_plan) *pl, KIFMM__F(__ops) *e)
{
    if (pl->ops.n == pl->ops.cap) {
        const int cap = 2 * pl->ops.cap + 4;
        KIFMM__F(__ops) **set = (KIFMM__F(__ops) **)kifmm__alloc((size_t)cap, sizeof *set);
        if (!set) {
            KIFMM__F(__ops_free)(e);
            kifmm__free(e);
            return KIFMM_ERR_NOMEM;
        }
        if (pl->ops.n) memcpy(set, pl->ops.set, (size_t)pl->ops.n * sizeof *set);
        pl->held += (size_t)(cap - pl->ops.cap) * sizeof *set;
        kifmm__free(pl->ops.set);
        pl->ops.set = set;
        pl->ops.cap = cap;
    }
    e->refs = 1;
    pl->ops.set[pl->ops.n++] = e;
    pl->held += sizeof *e + e->held;
    pl->ops.kept += KIFMM__F(__ops_kept)(e);
    return KIFMM_SUCCESS;
}

/* One user of set e lets go: freed, and out of the plan, with its last.
 * Under the lock. */
KIFMM__FN void KIFMM__F(__ops_drop)(KIFMM__F(_plan) *pl, KIFMM__F(__ops) *e)
{
    int j;
    if (--e->refs > 0) return;
    for (j = 0; j < pl->ops.n && pl->ops.set[j] != e; j++) {
    }
    if (j < pl->ops.n) pl->ops.set[j] = pl->ops.set[--pl->ops.n];
    pl->held -= sizeof *e + e->held;
    pl->ops.kept -= KIFMM__F(__ops_kept)(e);
    KIFMM__F(__ops_free)(e);
    kifmm__free(e);
}

/* The half-width (r) and the M2L's need (m2l) of the operator set of each
 * of the tree's nlev levels (r = 0: none at that level; scale-invariant
 * kernels: one set at half-width 1, wanted at level 0, with the M2L's if any
 * level has V lists); 0 when the tree uses none (a direct sum). */
KIFMM__FN int KIFMM__F(__ops_wanted)(const kifmm__tree *t, double *r, int *m2l)
{
    int l, l0 = KIFMM__SI ? 0 : kifmm__lmin(t);
    const int n = KIFMM__SI ? 1 : t->nlev;
    for (l = 0; l < t->nlev; l++) r[l] = 0.0, m2l[l] = 0;
    if (t->nlev <= kifmm__lmin(t)) return 0;
    for (l = 1; l < t->nlev; l++) m2l[KIFMM__SI ? 0 : l] |= t->m2lo[l + 1] > t->m2lo[l];
    for (l = l0; l < n; l++) r[l] = KIFMM__SI ? 1.0 : 0.5 * t->width / (double)((int64_t)1 << l);
    return 1;
}

/* The orders of the set of level l of handle c (p[0]; p[1], p[2]: its
 * parent's and children's levels', where its L2L and M2M reach them, else
 * p[0]). A handle without a tree (a plan's own set): the plan's. */
KIFMM__FN void KIFMM__F(__set_orders)(const KIFMM_NAME *c, int l, int *p)
{
    const kifmm__tree *t = c->tree;
    p[0] = p[1] = p[2] = KIFMM__F(__lpl)(c, l)->opts.order;
    if (t && l > kifmm__lmin(t)) p[1] = KIFMM__F(__lpl)(c, l - 1)->opts.order;
    if (t && l + 1 < t->nlev) p[2] = KIFMM__F(__lpl)(c, l + 1)->opts.order;
}

/* Level l's handle for the builders: c on the plan of the level's order
 * (whose surfaces and lattice they read), and in o the surfaces of its
 * neighbours of other orders. */
KIFMM__FN void KIFMM__F(__ops_view)(const KIFMM_NAME *c, int l, KIFMM_NAME *v, kifmm__ops *o)
{
    int p[3];
    KIFMM__F(__set_orders)(c, l, p);
    *v = *c;
    v->pl = (KIFMM__F(_plan) *)KIFMM__F(__lpl)(c, l);
    v->opts.order = p[0];
    v->ord.up = 0;
    o->sp = l > 0 && p[1] != p[0] ? KIFMM__F(__sf)(c, l - 1) : NULL;
    o->sc = p[2] != p[0] ? KIFMM__F(__sf)(c, l + 1) : NULL;
}

/* The new sets of handle c: for each level l < nlev with from[l] < 0, one
 * at half-width r[l] (with the M2L's if m2l[l]) for the level's orders,
 * read from opts.operator_cache (>>cache) or built (the kernel values of
 * the levels side by side, __ops_levels) and written there, into e[0..)
 * in level order (NULL where it failed). Under the plan's lock. */
KIFMM__FN int KIFMM__F(__ops_build)(const KIFMM_NAME *c, int nlev, const double *r, const int *m2l,
                                    const int *from, KIFMM__F(__ops) **e)
{
    kifmm__ops *o = (kifmm__ops *)kifmm__calloc((size_t)nlev, sizeof(kifmm__ops));
    int *rcs = (int *)kifmm__calloc((size_t)nlev, sizeof(int));
    KIFMM_NAME *v = (KIFMM_NAME *)kifmm__alloc((size_t)nlev, sizeof *v);
    KIFMM__F(__ops) **got = (KIFMM__F(__ops) **)kifmm__calloc((size_t)nlev, sizeof *got);
    int *fr = (int *)kifmm__alloc((size_t)nlev, sizeof(int)); /* from, the sets read marked built */
    const int cache = c->pl->cache.dir != NULL;
    int l, rc = o && rcs && v && got && fr ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM, k = 0;
    kifmm__symbs sy; /* the levels' factorisations share their bases */
    sy.n = 0;
    for (l = 0; !rc && l < nlev; l++) KIFMM__F(__ops_view)(c, l, &v[l], &o[l]);
    for (l = 0; !rc && l < nlev; l++) {
        int p[3];
        KIFMM__F(__set_orders)(c, l, p);
        got[l] = cache && from[l] < 0 ? KIFMM__F(__cache_read)(&v[l], &o[l], r[l], p, m2l[l]) : NULL;
        fr[l] = got[l] ? l : from[l];
        c->pl->cache.read += got[l] != NULL;
    }
    if (!rc) KIFMM__F(__ops_levels)(v, 0, nlev, r, m2l, fr, o, rcs);
    for (l = 0; o && l < nlev; l++) o[l].sy = &sy;
    if (!rc) KIFMM__F(__ops_solves_all)(v, nlev, r, m2l, fr, o, rcs);
    for (l = 0; l < nlev; l++) {
        KIFMM__F(__ops) *x;
        kifmm__ops nb; /* the neighbours' surfaces (o[l]'s, which __ops_keep clears) */
        if (from[l] >= 0) continue;
        memset(&nb, 0, sizeof nb);
        if (o) nb.sc = o[l].sc, nb.sp = o[l].sp;
        if (got && got[l]) { /* read: as built */
            e[k++] = got[l];
            got[l] = NULL;
            continue;
        }
        x = rc ? NULL : (KIFMM__F(__ops) *)kifmm__calloc(1, sizeof *x);
        if (!rc && !x) rc = KIFMM_ERR_NOMEM;
        if (!rc) rc = rcs[l];
#if KIFMM__SI && KIFMM__DEGREE == -1 && KIFMM_MONO_FIX
        if (!rc) rc = KIFMM__F(__mono_map)(&v[l], &o[l], x); /* before __ops_keep takes o's factors */
#endif
        if (!rc) rc = KIFMM__F(__ops_keep)(&v[l], &o[l], x);
        if (x) {
            x->r = r[l], x->has_m2l = m2l[l];
            KIFMM__F(__set_orders)(c, l, x->p);
        }
        if (rc && x) {
            KIFMM__F(__ops_free)(x);
            kifmm__free(x);
            x = NULL;
        }
        if (x && cache) c->pl->cache.written += KIFMM__F(__cache_write)(&v[l], &nb, x);
        e[k++] = x;
    }
    for (l = 0; got && l < nlev; l++)
        if (got[l]) KIFMM__F(__ops_free)(got[l]), kifmm__free(got[l]);
    for (l = 0; o && l < nlev; l++) kifmm__ops_free(&o[l]);
    kifmm__free(o);
    kifmm__free(rcs);
    kifmm__free(v);
    kifmm__free(got);
    kifmm__free(fr);
    kifmm__symbs_free(&sy);
    return rc;
}

/* The operator sets the handle's tree needs, c->lv[l] for each level that
 * has one: the plan's where it holds one built at the same half-width (and
 * with the M2L's where the level needs them), else built and added to it.
 * Scale-invariant kernels: one set at half-width 1, rescaled per level.
 * Others: one set per level that uses operators (levels 2 and deeper, all
 * in a periodic tree), their kernel values built side by side (Yukawa, p =
 * 6, 1M clustered points, 10 levels, 2 threads: operators 0.16 -> 0.11 s,
 * 0.05 s with the symmetries of c2e_solve and KIFMM__RADIAL). Only what the
 * tree uses: none for a tree of fewer than 3 levels (a direct sum), and the
 * M2L's only for levels with boxes that have V lists. Under the plan's
 * lock; on failure the sets taken stay in c->lv (the handle's destroy lets
 * them go). */
KIFMM__FN int KIFMM__F(__precompute)(KIFMM_NAME *c)
{
    const kifmm__tree *t = c->tree;
    const int nl = t->nlev, n = KIFMM__SI ? 1 : nl;
    double r[KIFMM__D + 2];
    int m2l[KIFMM__D + 2], from[KIFMM__D + 2], l, k, nb = 0, rc = KIFMM_SUCCESS;
    KIFMM__F(__ops) *e[KIFMM__D + 2] = {NULL};
    if (!KIFMM__F(__ops_wanted)(t, r, m2l)) return KIFMM_SUCCESS;
    for (l = 0; l < nl; l++) {
        int p[3];
        KIFMM__F(__ops) *x;
        KIFMM__F(__set_orders)(c, l, p);
        x = l < n && r[l] > 0.0 ? KIFMM__F(__ops_find)(c->pl, r[l], p, m2l[l]) : NULL;
        from[l] = x || !(l < n && r[l] > 0.0) ? l : -1; /* -1: to build */
        if (x) x->refs++;
        c->lv[l] = x;
        nb += from[l] < 0;
    }
    if (nb) rc = KIFMM__F(__ops_build)(c, n, r, m2l, from, e);
#if KIFMM__FFT
    if (!rc && nb) {
        int ntot = 0;
        /* (the sets of raised levels keep none: __keep_blocks) */
        for (l = 0; l < n; l++) ntot += c->lv[l] && c->lv[l]->khat && c->lv[l]->p[0] == c->pl->opts.order;
        for (k = 0; k < nb; k++) ntot += e[k] && e[k]->khat && e[k]->p[0] == c->pl->opts.order;
        rc = KIFMM__F(__keep_blocks)(c, e, nb, ntot);
    }
#endif
    for (l = 0, k = 0; l < n; l++) {
        if (from[l] >= 0) continue;
        c->lv[l] = e[k++];
        if (!c->lv[l]) continue;
        if (rc) { /* not in the plan: freed here */
            KIFMM__F(__ops_free)(c->lv[l]);
            kifmm__free(c->lv[l]);
            c->lv[l] = NULL;
        } else if ((rc = KIFMM__F(__ops_add)(c->pl, c->lv[l]))) {
            c->lv[l] = NULL;
        }
    }
    for (l = 1; l < nl && KIFMM__SI; l++) c->lv[l] = c->lv[0]; /* one reference, the first */
    return rc;
}

#if KIFMM__EWALD
/* ---- three periodic directions: the far images by Ewald sums ------------- */

/* The surface kernel's lattice sum over a cubic cell of side L, split at
 * alpha = 4 / L (the kernel's _ewald hook, kifmm_kernels.h): real space to
 * alpha r = 6.5 and Fourier space to k^2 / (4 alpha^2) = 46 (the terms left
 * out below 1e-18 of the sum), the wave vectors k = 2 pi m / L of one half
 * space (cos(k . d) is even in k) with their coefficients times 2 / V. */
typedef struct {
    double L, alpha, rc, c0[KIFMM__SD * KIFMM__SD];
    int nk, *m;  /* nk wave vectors, m[3 i ..] */
    double *f;   /* SD^2 per wave vector */
} KIFMM__F(__ewald);

KIFMM__FN int KIFMM__F(__ewald_plan)(const KIFMM_NAME *c, double L, KIFMM__F(__ewald) *e)
{
    enum { SD2 = KIFMM__SD * KIFMM__SD, MM = 9 };
    const double tp = 2.0 * 3.14159265358979323846 / L, V = L * L * L;
    int i, j, k, ab;
    e->L = L;
    e->alpha = 4.0 / L;
    e->rc = 6.5 / e->alpha;
    e->nk = 0;
    e->m = (int *)kifmm__alloc((size_t)3 * (2 * MM + 1) * (2 * MM + 1) * (2 * MM + 1), sizeof(int));
    e->f = (double *)kifmm__alloc((size_t)SD2 * (2 * MM + 1) * (2 * MM + 1) * (2 * MM + 1), sizeof(double));
    if (!e->m || !e->f) return KIFMM_ERR_NOMEM;
    KIFMM__R_(SC, _ewald)(c->opts.kernel_param, e->alpha, KIFMM_EWALD_MEAN, 0.0, 0.0, 0.0, e->c0);
    for (i = 0; i <= MM; i++)
        for (j = -MM; j <= MM; j++)
            for (k = -MM; k <= MM; k++) {
                const double k2 = tp * tp * (double)(i * i + j * j + k * k);
                if ((i == 0 && (j < 0 || (j == 0 && k <= 0))) || k2 > 184.0 * e->alpha * e->alpha)
                    continue; /* the other half space, k = 0, or beyond the reach */
                KIFMM__R_(SC, _ewald)(c->opts.kernel_param, e->alpha, KIFMM_EWALD_FOURIER, tp * i,
                                      tp * j, tp * k, e->f + (size_t)e->nk * SD2);
                for (ab = 0; ab < SD2; ab++) e->f[(size_t)e->nk * SD2 + ab] *= 2.0 / V;
                e->m[3 * e->nk] = i, e->m[3 * e->nk + 1] = j, e->m[3 * e->nk + 2] = k;
                e->nk++;
            }
    return KIFMM_SUCCESS;
}

/* gs[i SD^2 + ab] = the lattice sum of the surface kernel at the offsets
 * d[3 i ..] (i < n) less the 27 nearest images (n in {-1, 0, 1}^3, which the
 * lists reach) and less the background B(d) / V: the images at |n| >= 2 in
 * real space, minus the smooth part of the near ones, the Fourier sum, the
 * mean c0 / V. */
KIFMM__FN int KIFMM__F(__ewald_far)(const KIFMM_NAME *c, const KIFMM__F(__ewald) *e, int64_t n,
                                    const double *d, double *gs)
{
    enum { SD2 = KIFMM__SD * KIFMM__SD, MM = 9 };
    const double L = e->L, V = L * L * L, tp = 2.0 * 3.14159265358979323846 / L;
    int bad = 0;
    /* each offset writes its own sums */
    KIFMM__OMP(parallel for schedule(dynamic, 8) num_threads(c->opts.nthreads) reduction(| : bad))
    for (int64_t i = 0; i < n; i++) {
        const double *x = d + 3 * i;
        const int ni = (int)ceil((e->rc + fabs(x[0]) + fabs(x[1]) + fabs(x[2])) / L);
        double acc[SD2], kv[SD2], cs[3][2 * MM + 1][2];
        int a, b, q, ab;
        for (ab = 0; ab < SD2; ab++) acc[ab] = e->c0[ab] / V;
        for (a = -ni; a <= ni; a++)
            for (b = -ni; b <= ni; b++)
                for (q = -ni; q <= ni; q++) {
                    const double v0 = x[0] + L * a, v1 = x[1] + L * b, v2 = x[2] + L * q;
                    const int near = a * a <= 1 && b * b <= 1 && q * q <= 1;
                    if (!near && v0 * v0 + v1 * v1 + v2 * v2 >= e->rc * e->rc) continue;
                    KIFMM__R_(SC, _ewald)(c->opts.kernel_param, e->alpha,
                                          near ? KIFMM_EWALD_SMOOTH : KIFMM_EWALD_REAL, v0, v1, v2, kv);
                    for (ab = 0; ab < SD2; ab++) acc[ab] += near ? -kv[ab] : kv[ab];
                }
        for (a = 0; a < 3; a++) /* e^{i k_a x_a} for m = -MM .. MM */
            for (q = -MM; q <= MM; q++) {
                cs[a][q + MM][0] = cos(tp * q * x[a]);
                cs[a][q + MM][1] = sin(tp * q * x[a]);
            }
        for (q = 0; q < e->nk; q++) {
            const double *p0 = cs[0][e->m[3 * q] + MM], *p1 = cs[1][e->m[3 * q + 1] + MM];
            const double *p2 = cs[2][e->m[3 * q + 2] + MM];
            const double re01 = p0[0] * p1[0] - p0[1] * p1[1], im01 = p0[0] * p1[1] + p0[1] * p1[0];
            const double re = re01 * p2[0] - im01 * p2[1];
            for (ab = 0; ab < SD2; ab++) acc[ab] += e->f[(size_t)q * SD2 + ab] * re;
        }
        KIFMM__R_(SC, _background)(c->opts.kernel_param, x[0], x[1], x[2], kv);
        for (ab = 0; ab < SD2; ab++) {
            gs[i * SD2 + ab] = acc[ab] - kv[ab] / V;
            bad |= !(fabs(gs[i * SD2 + ab]) <= DBL_MAX);
        }
    }
    return bad ? KIFMM_ERR_KERNEL : KIFMM_SUCCESS;
}

/* The far sums at offsets d (3 x n, in cell widths) for a cell of
 * half-width h: summed for a cell of width 1 and scaled by (2 h)^DEGREE (the
 * surface kernel is scale invariant), since V = L^3 and the wave numbers
 * leave double's range for periods beyond about 1e100 or below 1e-100. */
KIFMM__FN int KIFMM__F(__ewald_at)(const KIFMM_NAME *c, double h, int64_t n, const double *d, double *gs)
{
    const double s = pow(2.0 * h, (double)(KIFMM__DEGREE));
    KIFMM__F(__ewald) e;
    int rc;
    memset(&e, 0, sizeof e);
    rc = KIFMM__F(__ewald_plan)(c, 1.0, &e);
    if (!rc) rc = KIFMM__F(__ewald_far)(c, &e, n, d, gs);
    for (int64_t i = 0; i < n * KIFMM__SD * KIFMM__SD && !rc; i++) gs[i] *= s;
    kifmm__free(e.m);
    kifmm__free(e.f);
    return rc;
}

#endif /* KIFMM__EWALD */

/* ---- periodic trees: the far images' operator (see kifmm__lat) ----------- */

/* out (nc x ne) = the sum over image offsets m[3 i ..] (nm of them) of
 * K(check surface at radius crad <- equivalent surface at radius erad and
 * centre 2 sp m). */
KIFMM__FN int KIFMM__F(__lat_kmat)(const KIFMM_NAME *c, double crad, double erad, double sp,
                                   const int *m, int nm, double *out)
{
    const double zero[3] = {0.0, 0.0, 0.0};
    const size_t nn = (size_t)c->pl->surf.nc * c->pl->surf.ne;
    double *k = (double *)kifmm__alloc(nn, sizeof(double));
    int i, rc = k ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM;
    size_t j;
    memset(out, 0, nn * sizeof(double));
    for (i = 0; i < nm && !rc; i++) {
        const double ec[3] = {2.0 * sp * m[3 * i], 2.0 * sp * m[3 * i + 1], 2.0 * sp * m[3 * i + 2]};
        rc = KIFMM__F(__surf_kmat)(c, c->pl->surf.unit_c, c->pl->surf.nsc, zero, crad, c->pl->surf.unit_e,
                                   c->pl->surf.nse, ec, erad, 1.0, k, (size_t)c->pl->surf.nc, NULL);
        for (j = 0; j < nn && !rc; j++) out[j] += k[j];
    }
    kifmm__free(k);
    return rc;
}

/* The sum over the images n of a cell of half-width h in the super-cell's
 * neighbours (2 <= |n| <= 4 along the periodic directions, 0 along the
 * others; 702 of them with three) of K(d - 2 h n), for the offsets d
 * between two order-q lattices on the surface of radius ai h: at the
 * (2q - 1)^3 lattice offsets, gs[e SD^2 + ab]. */
KIFMM__FN int KIFMM__F(__lat_ring_sums)(const KIFMM_NAME *c, double h, int q, double *gs)
{
    enum { SD2 = KIFMM__SD * KIFMM__SD };
    const int w = 2 * q - 1;
    const double g = 2.0 * c->pl->surf.ai * h / (q - 1);
    int bad = 0, m[3 * 729];
    const int nm = kifmm__lat_offsets(c->tree, 1, m);
    /* each offset e writes its own sum */
    KIFMM__OMP(parallel for schedule(dynamic, 16) num_threads(c->opts.nthreads) reduction(| : bad))
    for (int64_t e = 0; e < (int64_t)w * w * w; e++) {
        const double d0 = g * (double)(e / (w * w) - (q - 1)), d1 = g * (double)(e / w % w - (q - 1));
        const double d2 = g * (double)(e % w - (q - 1));
        double kv[SD2], acc[SD2];
        int i, ab;
        for (ab = 0; ab < SD2; ab++) acc[ab] = 0.0;
        for (i = 0; i < nm; i++) {
            KIFMM__R_(SC, _eval)(c->opts.kernel_param, d0 - 2.0 * h * m[3 * i],
                                 d1 - 2.0 * h * m[3 * i + 1], d2 - 2.0 * h * m[3 * i + 2], kv);
            for (ab = 0; ab < SD2; ab++) acc[ab] += kv[ab];
        }
        for (ab = 0; ab < SD2; ab++) {
            bad |= !(fabs(acc[ab]) <= DBL_MAX);
            gs[e * SD2 + ab] = acc[ab];
        }
    }
    return bad ? KIFMM_ERR_KERNEL : KIFMM_SUCCESS;
}

#if !KIFMM__FFT
/* The same pair by pair (the dense M2L's check surfaces have order p + 1). */
KIFMM__FN int KIFMM__F(__lat_ring_pairs)(const KIFMM_NAME *c, double h, double *a)
{
    int m[3 * 729];
    const int nm = kifmm__lat_offsets(c->tree, 1, m);
    return KIFMM__F(__lat_kmat)(c, c->pl->surf.ai * h, c->pl->surf.ai * h, h, m, nm, a);
}
#endif

/* a (SD n x SD n, leading dimension lda) from the sums per lattice offset gs
 * (__lat_ring_sums, __lat_ewald_sums) for the n points of the order-q unit
 * surface u, which lie on the order-q lattice: entry (i a, j b) is the sum
 * at the offset of point i from point j. */
KIFMM__FN int KIFMM__F(__lat_gather)(int q, const double *u, int n, const double *gs, double *a,
                                     size_t lda)
{
    enum { SD2 = KIFMM__SD * KIFMM__SD };
    const int w = 2 * q - 1;
    int *ix = (int *)kifmm__alloc((size_t)3 * n, sizeof(int)), i, j, a0, b0;
    if (!ix) return KIFMM_ERR_NOMEM;
    for (i = 0; i < n; i++) /* lattice indices 0 .. q - 1 */
        for (j = 0; j < 3; j++) ix[3 * i + j] = (int)lround(0.5 * (u[j * n + i] + 1.0) * (q - 1));
    for (j = 0; j < n; j++)
        for (i = 0; i < n; i++) {
            const int *xc = ix + 3 * i, *xe = ix + 3 * j;
            const int64_t e = ((int64_t)(xc[0] - xe[0] + q - 1) * w + (xc[1] - xe[1] + q - 1)) * w +
                              (xc[2] - xe[2] + q - 1);
            for (a0 = 0; a0 < KIFMM__SD; a0++)
                for (b0 = 0; b0 < KIFMM__SD; b0++)
                    a[(size_t)(i * KIFMM__SD + a0) + (size_t)(j * KIFMM__SD + b0) * lda] =
                        gs[e * SD2 + a0 * KIFMM__SD + b0];
        }
    kifmm__free(ix);
    return KIFMM_SUCCESS;
}

/* a (nc x ne) = K(the cell's check surface <- its images' equivalent
 * surfaces) summed over the images in the super-cell's neighbours, through
 * the sums per lattice offset (__lat_ring_sums) on the check surface's
 * lattice: directly when the equivalent surface lies on it (check order
 * p), else for densities on the check lattice, moved there by the FFT
 * M2L's fit conv (kifmm__ops), whose lattice density has the same field. */
KIFMM__FN int KIFMM__F(__lat_ring)(const KIFMM_NAME *c, double h, double *a)
{
    enum { SD2 = KIFMM__SD * KIFMM__SD };
    const int q = c->opts.order + c->pl->surf.cdiff, w = 2 * q - 1, nc = c->pl->surf.nc;
    double *gs = (double *)kifmm__alloc((size_t)w * w * w * SD2, sizeof(double));
    double *acc = c->pl->surf.cdiff ? (double *)kifmm__alloc((size_t)nc * nc, sizeof(double)) : a;
    const int pairs = c->pl->surf.cdiff && !KIFMM__FFT; /* pair by pair, below */
    int rc;
    kifmm__ops o;
    memset(&o, 0, sizeof o);
    if (!gs || !acc) rc = KIFMM_ERR_NOMEM;
    else if (pairs) rc = KIFMM_SUCCESS;
    else rc = KIFMM__F(__lat_ring_sums)(c, h, q, gs);
    if (!rc && !pairs) rc = KIFMM__F(__lat_gather)(q, c->pl->surf.unit_c, c->pl->surf.nsc, gs, acc, (size_t)nc);
#if KIFMM__FFT
    if (!rc && c->pl->surf.cdiff) rc = KIFMM__F(__build_conv)(c, h, &o);
    if (!rc && c->pl->surf.cdiff)
        kifmm__gemm(0, 0, nc, c->pl->surf.ne, nc, 1.0, acc, nc, o.conv, nc, 0.0, a, nc);
#else
    if (!rc && c->pl->surf.cdiff) rc = KIFMM__F(__lat_ring_pairs)(c, h, a);
#endif
    kifmm__ops_free(&o);
    if (acc != a) kifmm__free(acc);
    kifmm__free(gs);
    return rc;
}

/* The densities (ne x QD) of unit point sources of each kind at the cell's
 * centre, from the super-cell's solve o at half-width H: e (ne x SD, the
 * surface kernel's, normalised so that S e = I) and mu = S (those of the
 * kernel's own kinds, SD x QD). Scale-invariant kernels only, whose
 * densities do not depend on the size. */
KIFMM__FN int KIFMM__F(__lat_centre)(const KIFMM_NAME *c, const kifmm__ops *o, double H,
                                     kifmm__lat *L)
{
    const int nc = c->pl->surf.nc, ne = c->pl->surf.ne, nsc = c->pl->surf.nsc;
    double *pc = (double *)kifmm__alloc((size_t)3 * nsc, sizeof(double));
    double *k = (double *)kifmm__alloc((size_t)nc * (KIFMM__SD + KIFMM__QD), sizeof(double));
    double *t = (double *)kifmm__alloc((size_t)o->ku * (KIFMM__SD + KIFMM__QD) + 1, sizeof(double));
    double *x = (double *)kifmm__alloc((size_t)ne * (KIFMM__SD + KIFMM__QD), sizeof(double));
    double kv[KIFMM__SD * (KIFMM__SD > KIFMM__QD ? KIFMM__SD : KIFMM__QD)], se[81];
    const double zero[3] = {0.0, 0.0, 0.0};
    int i, a, s, b, rc = KIFMM_SUCCESS;
    L->e = (double *)kifmm__alloc((size_t)ne * KIFMM__SD, sizeof(double));
    L->mu = (double *)kifmm__alloc((size_t)KIFMM__SD * KIFMM__QD, sizeof(double));
    if (!pc || !k || !t || !x || !L->e || !L->mu) { rc = KIFMM_ERR_NOMEM; goto done; }
    kifmm__surf_place(c->pl->surf.unit_c, nsc, zero, c->pl->surf.ao * H, pc);
    for (i = 0; i < nsc; i++) {
        KIFMM__R_(SC, _eval)(c->opts.kernel_param, pc[i], pc[nsc + i], pc[2 * nsc + i], kv);
        for (a = 0; a < KIFMM__SD; a++)
            for (s = 0; s < KIFMM__SD; s++) k[i * KIFMM__SD + a + (size_t)s * nc] = kv[a * KIFMM__SD + s];
        KIFMM__R_(QC, _eval)(c->opts.kernel_param, pc[i], pc[nsc + i], pc[2 * nsc + i], kv);
        for (a = 0; a < KIFMM__SD; a++)
            for (s = 0; s < KIFMM__QD; s++)
                k[i * KIFMM__SD + a + (size_t)(KIFMM__SD + s) * nc] = kv[a * KIFMM__QD + s];
    }
    kifmm__gemm(0, 0, o->ku, KIFMM__SD + KIFMM__QD, nc, 1.0, o->ut_up, o->ku, k, nc, 0.0, t, o->ku);
    kifmm__gemm(0, 0, ne, KIFMM__SD + KIFMM__QD, o->ku, o->sigma, o->vs_up, ne, t, o->ku, 0.0, x, ne);
    for (s = 0; s < KIFMM__SD * KIFMM__SD; s++) se[s] = 0.0;
    for (s = 0; s < KIFMM__SD; s++)
        for (i = 0; i < ne; i++) se[i % KIFMM__SD + s * KIFMM__SD] += x[i + (size_t)s * ne];
    kifmm__small_inverse(se, KIFMM__SD);
    kifmm__gemm(0, 0, ne, KIFMM__SD, KIFMM__SD, 1.0, x, ne, se, KIFMM__SD, 0.0, L->e, ne);
    for (s = 0; s < KIFMM__QD; s++) {
        double m[KIFMM__SD];
        for (b = 0; b < KIFMM__SD; b++) m[b] = 0.0;
        for (i = 0; i < ne; i++) m[i % KIFMM__SD] += x[i + (size_t)(KIFMM__SD + s) * ne];
        /* a kind without a monopole (a dipole) sums to rounding: 0 */
        for (b = 0; b < KIFMM__SD; b++) L->mu[b + s * KIFMM__SD] = fabs(m[b]) > 1e-6 ? m[b] : 0.0;
    }
done:
    kifmm__free(pc);
    kifmm__free(k);
    kifmm__free(t);
    kifmm__free(x);
    return rc;
}

/* A, B and C of the recursion for a cell of half-width h (kifmm__lat), and
 * (want_e) the centre's densities. */
KIFMM__FN int KIFMM__F(__lat_level)(const KIFMM_NAME *c, double h, int want_e, kifmm__lat *L)
{
    const int nc = c->pl->surf.nc, ne = c->pl->surf.ne, big = nc > ne ? nc : ne;
    const double H = 3.0 * h, ai = c->pl->surf.ai, ao = c->pl->surf.ao;
    const int zero[3] = {0, 0, 0};
    int m[27 * 3], nm, rc;
    kifmm__ops o;
    double *k = (double *)kifmm__alloc((size_t)nc * ne, sizeof(double));
    double *t = (double *)kifmm__alloc((size_t)big * big, sizeof(double));
    memset(&o, 0, sizeof o);
    L->nc = nc;
    L->ne = ne;
    L->sd = KIFMM__SD;
    if (!L->a) L->a = (double *)kifmm__alloc((size_t)nc * ne, sizeof(double));
    if (!L->b) L->b = (double *)kifmm__alloc((size_t)nc * nc, sizeof(double));
    if (!L->c) L->c = (double *)kifmm__alloc((size_t)ne * ne, sizeof(double));
    rc = k && t && L->a && L->b && L->c ? KIFMM__F(__c2e_kernels)(c, H, ao, &o) : KIFMM_ERR_NOMEM;
    if (!rc) rc = KIFMM__F(__c2e_solve)(c, &o);
    /* C: the 27 (9, 3) cells' densities -> the super-cell's check -> density */
    nm = kifmm__lat_offsets(c->tree, 0, m);
    if (!rc) rc = KIFMM__F(__lat_kmat)(c, ao * H, ai * h, h, m, nm, k);
    if (!rc) {
        kifmm__gemm(0, 0, o.ku, ne, nc, 1.0, o.ut_up, o.ku, k, nc, 0.0, t, o.ku);
        kifmm__gemm(0, 0, ne, ne, o.ku, o.sigma, o.vs_up, ne, t, o.ku, 0.0, L->c, ne);
    }
    /* A: the cell's images in the super-cell's neighbours -> its check
     * potential (each at least one cell apart: the M2L's geometry) */
    if (!rc) rc = KIFMM__F(__lat_ring)(c, h, L->a);
    /* B: the super-cell's check potential -> its density -> the cell's check */
    if (!rc) rc = KIFMM__F(__lat_kmat)(c, ai * h, ao * H, H, zero, 1, k);
    if (!rc) {
        kifmm__gemm(0, 0, nc, o.kd, ne, 1.0, k, nc, o.vs_dn, ne, 0.0, t, nc);
        kifmm__gemm(0, 0, nc, nc, o.kd, o.sigma, t, nc, o.ut_dn, o.kd, 0.0, L->b, nc);
    }
    if (!rc && want_e) rc = KIFMM__F(__lat_centre)(c, &o, H, L);
    if (!rc && want_e) { /* kept */
        kifmm__ops_free(&L->sup);
        L->sup = o;
        memset(&o, 0, sizeof o);
    }
    kifmm__ops_free(&o);
    kifmm__free(k);
    kifmm__free(t);
    return rc;
}

/* T of a scale-invariant kernel of degree a at half-width 1: the fixed point
 * of T = A P + 3^a B T P C P (P = I - e S: no monopole). With one or two
 * periodic directions every other mode contracts or stays put (dipole to
 * constant: 1/3 or 1 per step); with three, the dipoles' images would grow
 * a constant by 3 per step, one reason those wait (see __lattice_build). */
KIFMM__FN int KIFMM__F(__lat_fixed)(const KIFMM_NAME *c, kifmm__lat *L, double *T)
{
    const int nc = L->nc, ne = L->ne, sd = L->sd;
    const double beta = pow(3.0, c->pl->ops.degree);
    double dprev = HUGE_VAL;
    double *x = (double *)kifmm__alloc((size_t)nc * ne, sizeof(double));
    double *y = (double *)kifmm__alloc((size_t)nc * ne, sizeof(double));
    int it;
    if (!x || !y || kifmm__lat_project(L->a, nc, ne, sd, L->e) ||
        kifmm__lat_project(L->c, ne, ne, sd, L->e)) {
        kifmm__free(x);
        kifmm__free(y);
        return KIFMM_ERR_NOMEM;
    }
    kifmm__lat_project_left(L->c, ne, ne, sd, L->e);
    memcpy(T, L->a, (size_t)nc * ne * sizeof(double));
    for (it = 0; it < 200; it++) {
        double d = 0.0, big;
        size_t i;
        /* d contracts by about 3 per step down to the rounding of the
         * products (3e-16 of T's largest entry with one periodic direction,
         * 3e-13 with two, where the modes that stay put carry it), and then
         * stays: the stop where it no longer contracts saves the 200 steps
         * (stokes, p = 10: create 101 s -> s) */
        kifmm__gemm(0, 0, nc, ne, ne, 1.0, T, nc, L->c, ne, 0.0, x, nc);
        memcpy(y, L->a, (size_t)nc * ne * sizeof(double));
        kifmm__gemm(0, 0, nc, ne, nc, beta, L->b, nc, x, nc, 1.0, y, nc);
        for (i = 0; i < (size_t)nc * ne; i++) {
            d = fabs(y[i] - T[i]) > d ? fabs(y[i] - T[i]) : d;
            T[i] = y[i];
        }
        big = kifmm__max_abs(T, (size_t)nc * ne);
        if (it > 2 && (d <= 1e-16 * big || (d <= 1e-11 * big && d > 0.7 * dprev))) break;
        dprev = d;
    }
    kifmm__free(x);
    kifmm__free(y);
    return KIFMM_SUCCESS;
}

/* T of any other kernel at the root's half-width h: the sum over levels j of
 * B_0 .. B_(j-1) A_j C_(j-1) .. C_0, with the operators of each super-cell
 * size, until a level's term is below 1e-17 of the sum (a Yukawa kernel
 * at lambda = 1e-3 / h: 12 levels); KIFMM_ERR_PERIODIC if 20 levels do not
 * get there (a kernel that does not decay). */
KIFMM__FN int KIFMM__F(__lat_sum)(const KIFMM_NAME *c, double h, double *T)
{
    const int nc = c->pl->surf.nc, ne = c->pl->surf.ne;
    double *bacc = (double *)kifmm__calloc((size_t)nc * nc, sizeof(double));
    double *cacc = (double *)kifmm__calloc((size_t)ne * ne, sizeof(double));
    double *x = (double *)kifmm__alloc((size_t)nc * (nc > ne ? nc : ne), sizeof(double));
    double *y = (double *)kifmm__alloc((size_t)(nc > ne ? nc : ne) * (nc > ne ? nc : ne), sizeof(double));
    kifmm__lat L;
    int j, i, rc = bacc && cacc && x && y ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM;
    memset(&L, 0, sizeof L);
    memset(T, 0, (size_t)nc * ne * sizeof(double));
    for (i = 0; i < nc && !rc; i++) bacc[i + (size_t)i * nc] = 1.0;
    for (i = 0; i < ne && !rc; i++) cacc[i + (size_t)i * ne] = 1.0;
    for (j = 0; !rc; j++, h *= 3.0) {
        double tb, sb;
        if (j == 20) { rc = KIFMM_ERR_PERIODIC; break; }
        if ((rc = KIFMM__F(__lat_level)(c, h, 0, &L))) break;
        kifmm__gemm(0, 0, nc, ne, ne, 1.0, L.a, nc, cacc, ne, 0.0, x, nc);
        kifmm__gemm(0, 0, nc, ne, nc, 1.0, bacc, nc, x, nc, 0.0, y, nc); /* the level's term */
        for (i = 0; i < nc * ne; i++) T[i] += y[i];
        tb = kifmm__max_abs(y, (size_t)nc * ne);
        sb = kifmm__max_abs(T, (size_t)nc * ne);
        if (j > 0 && tb <= 1e-17 * sb) break;
        if (sb == 0.0 && j > 0) break; /* nothing reaches past the neighbours */
        kifmm__gemm(0, 0, nc, nc, nc, 1.0, bacc, nc, L.b, nc, 0.0, y, nc);
        memcpy(bacc, y, (size_t)nc * nc * sizeof(double));
        kifmm__gemm(0, 0, ne, ne, ne, 1.0, L.c, ne, cacc, ne, 0.0, y, ne);
        memcpy(cacc, y, (size_t)ne * ne * sizeof(double));
    }
    kifmm__lat_free(&L);
    kifmm__free(bacc);
    kifmm__free(cacc);
    kifmm__free(x);
    kifmm__free(y);
    return rc;
}

#if KIFMM__EWALD
/* The uniform density's field of the kernel's outputs (its _background
 * hook) as a quadratic about 0: bq[(t QD + b) 10 + j], j = 0 the value, 1 ..
 * 3 the gradient, 4 .. 9 the second derivatives xx, yy, zz, xy, xz, yz;
 * central differences of step 1 (exact for a quadratic). */
KIFMM__FN int KIFMM__F(__background_fit)(KIFMM_NAME *c)
{
    enum { TQ = KIFMM__TD * KIFMM__QD };
    static const int pq[6][2] = {{0, 0}, {1, 1}, {2, 2}, {0, 1}, {0, 2}, {1, 2}};
    double b0[TQ], bp[TQ], bm[TQ], bpp[TQ], bpm[TQ], bmp[TQ], bmm[TQ], *bq;
    const double *prm = c->opts.kernel_param;
    int j, i;
    bq = (double *)kifmm__alloc((size_t)TQ * 10, sizeof(double));
    if (!bq) return KIFMM_ERR_NOMEM;
    KIFMM__R_(QT, _background)(prm, 0.0, 0.0, 0.0, b0);
    for (i = 0; i < TQ; i++) bq[10 * i] = b0[i];
    for (j = 0; j < 3; j++) {
        const double u[3] = {j == 0 ? 1.0 : 0.0, j == 1 ? 1.0 : 0.0, j == 2 ? 1.0 : 0.0};
        KIFMM__R_(QT, _background)(prm, u[0], u[1], u[2], bp);
        KIFMM__R_(QT, _background)(prm, -u[0], -u[1], -u[2], bm);
        for (i = 0; i < TQ; i++) {
            bq[10 * i + 1 + j] = 0.5 * (bp[i] - bm[i]);
            bq[10 * i + 4 + j] = bp[i] - 2.0 * b0[i] + bm[i];
        }
    }
    for (j = 3; j < 6; j++) {
        double u[3] = {0.0, 0.0, 0.0}, v[3] = {0.0, 0.0, 0.0};
        u[pq[j][0]] = 1.0, v[pq[j][1]] = 1.0;
        KIFMM__R_(QT, _background)(prm, u[0] + v[0], u[1] + v[1], u[2] + v[2], bpp);
        KIFMM__R_(QT, _background)(prm, u[0] - v[0], u[1] - v[1], u[2] - v[2], bpm);
        KIFMM__R_(QT, _background)(prm, v[0] - u[0], v[1] - u[1], v[2] - u[2], bmp);
        KIFMM__R_(QT, _background)(prm, -u[0] - v[0], -u[1] - v[1], -u[2] - v[2], bmm);
        for (i = 0; i < TQ; i++) bq[10 * i + 4 + j] = 0.25 * (bpp[i] - bpm[i] - bmp[i] + bmm[i]);
    }
    c->far->bq = bq;
    c->far->held += kifmm__size(bq);
    return KIFMM_SUCCESS;
}

/* The Ewald far sums (__ewald_far) at the (2q - 1)^3 offsets between two
 * order-q lattices on the surface of radius ai h, as __lat_ring_sums. A
 * radial kernel's sums (KIFMM__RADIAL) are the same at the 48 images of an
 * offset under the cube's symmetries, which map the lattice of images to
 * itself: only the offsets with sorted absolute components are summed
 * (84 of 2,197 at q = 7) and copied to the others. */
KIFMM__FN int KIFMM__F(__lat_ewald_sums)(const KIFMM_NAME *c, double h, int q, double *gs)
{
    enum { SD2 = KIFMM__SD * KIFMM__SD };
    const int w = 2 * q - 1, sym = KIFMM__RADIAL;
    const int64_t nw = (int64_t)w * w * w;
    const double g = c->pl->surf.ai / (q - 1); /* in cell widths, 2 h */
    double *d = (double *)kifmm__alloc((size_t)3 * nw, sizeof(double));
    double *gc = sym ? (double *)kifmm__alloc((size_t)nw * SD2, sizeof(double)) : gs;
    int *slot = sym ? (int *)kifmm__alloc((size_t)q * q * q, sizeof(int)) : NULL;
    int64_t e, n = 0;
    int rc = d && gc && (slot || !sym) ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM, k;
    for (k = 0; k < q * q * q && sym && !rc; k++) slot[k] = -1;
    for (e = 0; e < nw && !rc; e++) { /* the offsets summed, slot[]: where */
        if (sym && slot[k = kifmm__lat_sorted(e, q)] >= 0) continue;
        if (sym) slot[k] = (int)n;
        d[3 * n] = g * (double)(e / (w * w) - (q - 1));
        d[3 * n + 1] = g * (double)(e / w % w - (q - 1));
        d[3 * n + 2] = g * (double)(e % w - (q - 1));
        n++;
    }
    if (!rc) rc = KIFMM__F(__ewald_at)(c, h, n, d, gc);
    for (e = 0; e < nw && sym && !rc; e++)
        memcpy(gs + e * SD2, gc + (size_t)slot[kifmm__lat_sorted(e, q)] * SD2, SD2 * sizeof(double));
    kifmm__free(d);
    if (sym) kifmm__free(gc);
    kifmm__free(slot);
    return rc;
}

#endif /* KIFMM__EWALD */

/* The pseudo-inverse of K(check surface uc, nsc points at radius rc <-
 * equivalent surface ue, nse points at radius re), both about 0 at
 * half-width 1, as its two factors (kifmm__pinv) of K / big, *big the
 * largest |entry|: K^+ = vs ut / big. With sym, *sym = 1 if K(ue <- uc) is
 * K's transpose to rounding, 1e-14 big (a kernel with K(-d) = K(d)^T:
 * Laplace, Stokes; the Stokeslet's entries differ in the last bit). */
KIFMM__FN int KIFMM__F(__ewald_fit)(const KIFMM_NAME *c, const double *uc, int nsc, double rc,
                                    const double *ue, int nse, double re, double **ut, double **vs,
                                    int *rank, double *big, int *sym)
{
    const int nc = nsc * KIFMM__SD, ne = nse * KIFMM__SD;
    const double zero[3] = {0.0, 0.0, 0.0};
    double *k = (double *)kifmm__alloc((size_t)nc * ne, sizeof(double));
    double *kt = sym ? (double *)kifmm__alloc((size_t)nc * ne, sizeof(double)) : NULL;
    int err = k && (kt || !sym) ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM, i, j;
    if (!err) err = KIFMM__F(__surf_kmat)(c, uc, nsc, zero, rc, ue, nse, zero, re, 1.0, k, (size_t)nc, big);
    if (!err && sym)
        err = KIFMM__F(__surf_kmat)(c, ue, nse, zero, re, uc, nsc, zero, rc, 1.0, kt, (size_t)ne, NULL);
    if (!err && sym)
        for (*sym = 1, j = 0; j < ne && *sym; j++)
            for (i = 0; i < nc && *sym; i++) /* to rounding (FMA contractions) */
                *sym = fabs(kt[j + (size_t)i * ne] - k[i + (size_t)j * nc]) <= 1e-14 * *big;
    if (!err && !(*big > 0.0)) err = KIFMM_ERR_KERNEL;
    for (i = 0; i < nc && !err; i++)
        for (j = 0; j < ne; j++) k[i + (size_t)j * nc] /= *big; /* entries of size 1 */
    if (!err) err = kifmm__pinv(k, nc, ne, KIFMM__CUTOFF, ut, vs, rank);
    kifmm__free(k);
    kifmm__free(kt);
    return err;
}

/* G (me x me, me = SD ne): the far images' field (the images of the cell
 * of half-width h beyond its 26 neighbours) between the ne points of the
 * order-q unit surface ue placed at radius ai h, E's images -> E's points.
 * Three periodic directions of a scale-invariant kernel: the Ewald far
 * sums (__lat_ewald_sums, h = 1). Any other periodic tree: the recursion
 * of kifmm__lat with E in place of the cell's surfaces,
 *   G = A_q + B' T(3 h) C',
 * A_q the cell's images in the super-cell's neighbours summed directly
 * between E's points (__lat_ring_sums: the ring, which the order-p T
 * carried through the root's expansions, largest at its corners), C' E's
 * 27 (9, 3) copies -> the super-cell's upward density and B' its downward
 * density -> E's points, both of order p at 3 h, and T(3 h) the super-cell's
 * far images of order p (given: __lattice_build; sup, where not NULL, the
 * super-cell's fits at 3 h, else built here): their field at the
 * cell, a third of the super-cell, carries a small part of the order-p
 * error at the super-cell's corners. __far_super adds B' T(3 h) C' to g. */
KIFMM__FN int KIFMM__F(__far_super)(const KIFMM_NAME *c, double h, const double *ue, int ne,
                                    const double *T, const kifmm__ops *sup, double *g)
{
    const int me = ne * KIFMM__SD, nc = c->pl->surf.nc, nq = c->pl->surf.ne, nsc = c->pl->surf.nsc;
    const double H = 3.0 * h, ai = c->pl->surf.ai, ao = c->pl->surf.ao, zero[3] = {0.0, 0.0, 0.0};
    double *k1 = (double *)kifmm__alloc((size_t)nc * me, sizeof(double));
    double *k2 = (double *)kifmm__alloc((size_t)me * (nc > nq ? nc : nq), sizeof(double));
    double *cq = (double *)kifmm__alloc((size_t)nq * me, sizeof(double));
    double *bq = (double *)kifmm__alloc((size_t)me * nc, sizeof(double));
    double *x = (double *)kifmm__alloc((size_t)(nc > me ? nc : me) * (nc > nq ? nc : nq) + 1, sizeof(double));
    double *y = (double *)kifmm__alloc((size_t)nc * me, sizeof(double));
    int m[27 * 3], nm, i, rc = T && k1 && k2 && cq && bq && x && y ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM;
    kifmm__ops own;
    const kifmm__ops *o = sup ? sup : &own;
    memset(&own, 0, sizeof own);
    /* the super-cell's two fits (given, or built here) */
    if (!rc && !sup) rc = KIFMM__F(__c2e_kernels)(c, H, ao, &own);
    if (!rc && !sup) rc = KIFMM__F(__c2e_solve)(c, &own);
    /* C': E's copies -> the super-cell's check (k1, nc x me) -> its density */
    nm = kifmm__lat_offsets(c->tree, 0, m);
    if (!rc) memset(k1, 0, (size_t)nc * me * sizeof(double));
    for (i = 0; i < nm && !rc; i++) {
        const double ec[3] = {2.0 * h * m[3 * i], 2.0 * h * m[3 * i + 1], 2.0 * h * m[3 * i + 2]};
        size_t j;
        rc = KIFMM__F(__surf_kmat)(c, c->pl->surf.unit_c, nsc, zero, ao * H, ue, ne, ec, ai * h, 1.0, y,
                                   (size_t)nc, NULL);
        for (j = 0; j < (size_t)nc * me && !rc; j++) k1[j] += y[j];
    }
    if (!rc) {
        kifmm__gemm(0, 0, o->ku, me, nc, 1.0, o->ut_up, o->ku, k1, nc, 0.0, x, o->ku);
        kifmm__gemm(0, 0, nq, me, o->ku, o->sigma, o->vs_up, nq, x, o->ku, 0.0, cq, nq);
    }
    /* B': the super-cell's check -> its downward density -> E's points */
    if (!rc) rc = KIFMM__F(__surf_kmat)(c, ue, ne, zero, ai * h, c->pl->surf.unit_e, c->pl->surf.nse, zero,
                                        ao * H, 1.0, k2, (size_t)me, NULL);
    if (!rc) {
        kifmm__gemm(0, 0, me, o->kd, nq, 1.0, k2, me, o->vs_dn, nq, 0.0, x, me);
        kifmm__gemm(0, 0, me, nc, o->kd, o->sigma, x, me, o->ut_dn, o->kd, 0.0, bq, me);
        kifmm__gemm(0, 0, nc, me, nq, 1.0, T, nc, cq, nq, 0.0, y, nc);
        kifmm__gemm(0, 0, me, me, nc, 1.0, bq, me, y, nc, 1.0, g, me); /* G += B' T C' */
    }
    kifmm__ops_free(&own);
    kifmm__free(k1);
    kifmm__free(k2);
    kifmm__free(cq);
    kifmm__free(bq);
    kifmm__free(x);
    kifmm__free(y);
    return rc;
}

KIFMM__FN int KIFMM__F(__far_pairs)(const KIFMM_NAME *c, double h, int q, const double *ue, int ne,
                                    const double *T, const kifmm__ops *sup, double *g)
{
    enum { SD2 = KIFMM__SD * KIFMM__SD };
    const int w = 2 * q - 1, me = ne * KIFMM__SD;
    double *gs = (double *)kifmm__alloc((size_t)w * w * w * SD2, sizeof(double));
    int i, rc = gs ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM;
#if KIFMM__EWALD
    if (c->tree->per[0] + c->tree->per[1] + c->tree->per[2] == 3) { /* a scale-invariant kernel: Ewald */
        if (!rc) rc = KIFMM__F(__lat_ewald_sums)(c, h, q, gs);
        if (!rc) rc = KIFMM__F(__lat_gather)(q, ue, ne, gs, g, (size_t)me);
        kifmm__free(gs);
        return rc;
    }
#endif
    if (!rc) rc = KIFMM__F(__lat_ring_sums)(c, h, q, gs);
    if (!rc) rc = KIFMM__F(__lat_gather)(q, ue, ne, gs, g, (size_t)me);
    kifmm__free(gs);
    if (!rc) rc = KIFMM__F(__far_super)(c, h, ue, ne, T, sup, g);
    for (i = 0; i < me * me && !rc; i++)
        if (!(fabs(g[i]) <= DBL_MAX)) rc = KIFMM_ERR_KERNEL;
    return rc;
}

/* The far images' exchange with the boxes of level 1 (the root when it is
 * a leaf), every periodic tree. Through the root's own expansions of order
 * p (the operator T of kifmm__lat, once applied to the root's density) the
 * far images' field carried the root's truncation error, largest in its
 * corners: with targets crowding a corner of the cell at p = 6, 5.7e-5
 * (Laplace, three directions), 1.7e-5 (two; with the frame of the sources
 * alone 1.1e-4). So they are exchanged through surfaces
 * about the root of order q = p + KIFMM_EWALD_RAISE (kifmm__ewald_order):
 *   U: check surface at ao (order q + cd), the boxes' upward densities'
 *      potentials there, directly (at evaluate);
 *   E: equivalent surface at ai (order q), fitted to those: Kup^+;
 *   G: the far images' field between E's points (__far_pairs);
 *   D: equivalent surface at ao on U's points (more than E's: the fit is
 *      underdetermined, its minimum-norm density smooth, D being far from
 *      E), fitted to that: Kdn^+; with it q = p + 1 gives the errors q = p
 *      + 2 gave with D of order q - cd, at less than half the cost
 *      (docs/algorithm.md). For a kernel with K(-d) = K(d)^T, Kdn =
 *      Kup^T, its factors from Kup's SVD; else from its own;
 * and D's field at the boxes' downward check surfaces (directly). Kept:
 * Kdn^+ G Kup^+ (U -> D) as three factors, ut of Kup^+ (zu), the middle
 * ut G vs (zm) and vs of Kdn^+ (zd), built at half-width 1 and scaled to
 * the root's (h^-a for a kernel of degree a; a kernel that is not scale
 * invariant at the root's own). Applied one after the other, each
 * pseudo-inverse's rounding stays in the directions its other factor
 * brings back (formed into one matrix, p = 10 lost all digits); and the
 * placed points of U and D about the root's centre. T3, sup: the
 * super-cell's far images, T(3 h), and its fits (unused with Ewald sums). A G of zeros (a kernel that
 * has decayed below double's range one period away), or fits whose
 * kernel is below the instance's smallest normal number (Yukawa, lambda
 * 100 in a float instance with a period of 1), leave the exchange out: the
 * far images' field is below the instance's resolution of the near one. */
KIFMM__FN int KIFMM__F(__far_root)(KIFMM_NAME *c, const double *T3, const kifmm__ops *sup)
{
    const int q = kifmm__ewald_order(c->opts.order, c->lat.zsmall), cd = kifmm__check_diff(q, 0, KIFMM__SD, KIFMM__FLOAT);
    const int nu = kifmm__surf_count(q + cd), ne = kifmm__surf_count(q);
    const int mu = nu * KIFMM__SD, me = ne * KIFMM__SD;
    const double h = 0.5 * c->tree->width, hf = KIFMM__SI ? 1.0 : h;
    const double ao = kifmm__alpha_outer(q, cd, KIFMM__SD) * hf, ai = c->pl->surf.ai * hf;
    const double zero[3] = {0.0, 0.0, 0.0};
    double *uu = (double *)kifmm__alloc((size_t)3 * (nu + ne), sizeof(double));
    double *g = (double *)kifmm__alloc((size_t)me * me, sizeof(double));
    double *x = (double *)kifmm__alloc((size_t)me * me, sizeof(double)), *ue = uu + 3 * nu;
    double *utu = NULL, *vsu = NULL, *utd = NULL, *vsd = NULL, *m = NULL, bu = 0.0, bd = 0.0;
    int rc = uu && g && x ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM, ku = 0, kd = 0, sym = 0;
    if (!rc) {
        kifmm__surf_unit(q + cd, uu);
        kifmm__surf_unit(q, ue);
        rc = KIFMM__F(__far_pairs)(c, hf, q, ue, ne, T3, sup, g);
    }
    if (!rc && !(kifmm__max_abs(g, (size_t)me * me) > 0.0)) goto done; /* nothing reaches */
    if (!rc)
        rc = KIFMM__F(__ewald_fit)(c, uu, nu, ao, ue, ne, ai, &utu, &vsu, &ku, &bu,
                                   KIFMM_EWALD_OWN_FIT ? NULL : &sym);
    if (!rc && sym) { /* Kdn = Kup^T: the factors from Kup's SVD */
        kd = ku, bd = bu;
        rc = kifmm__pinv_transposed(mu, me, ku, utu, vsu, &utd, &vsd);
    } else if (!rc) {
        rc = KIFMM__F(__ewald_fit)(c, ue, ne, ai, uu, nu, ao, &utd, &vsd, &kd, &bd, NULL);
    }
    /* as a level's operators (__c2e_kernels): a kernel below the instance's
     * smallest normal number at the surfaces' distance gives no far field */
    if (!rc && !(bu >= KIFMM__TINY && bd >= KIFMM__TINY)) goto done;
    if (!rc && !(m = (double *)kifmm__alloc((size_t)kd * ku + 1, sizeof(double)))) rc = KIFMM_ERR_NOMEM;
    if (!rc) {
        kifmm__gemm(0, 0, me, ku, me, 1.0 / bu, g, me, vsu, me, 0.0, x, me);
        kifmm__gemm(0, 0, kd, ku, me, (KIFMM__SI ? pow(h, -c->pl->ops.degree) : 1.0) / bd, utd, kd, x,
                    me, 0.0, m, kd);
        /* and the middle factor (about 1 / bd) within the instance's range */
        if (!(kifmm__max_abs(m, (size_t)kd * ku) <= 1e-6 * (KIFMM__FLOAT ? FLT_MAX : DBL_MAX)))
            goto done;
        c->far->nzu = nu, c->far->zku = ku, c->far->zkd = kd;
        c->far->zp = (KIFMM__R *)kifmm__take(&c->far->held, (size_t)3 * nu, sizeof(KIFMM__R));
        c->far->zunit = (double *)kifmm__take(&c->far->held, (size_t)3 * nu, sizeof(double));
        c->far->zu = KIFMM__F(__own)(&c->far->held, &utu, (size_t)ku * mu);
        c->far->zm = KIFMM__F(__own)(&c->far->held, &m, (size_t)kd * ku);
        c->far->zd = KIFMM__F(__own)(&c->far->held, &vsd, (size_t)mu * kd);
        if (!c->far->zp || !c->far->zunit || !c->far->zu || !c->far->zm || !c->far->zd)
            rc = KIFMM_ERR_NOMEM;
    }
    if (!rc) {
        c->far->zrad = kifmm__alpha_outer(q, cd, KIFMM__SD) * h;
        memcpy(c->far->zunit, uu, (size_t)3 * nu * sizeof(double));
        KIFMM__F(__place)(uu, nu, zero, c->far->zrad, c->far->zp);
    }
done:
    kifmm__free(uu);
    kifmm__free(g);
    kifmm__free(x);
    kifmm__free(utu);
    kifmm__free(vsu);
    kifmm__free(utd);
    kifmm__free(vsd);
    kifmm__free(m);
    return rc;
}

/* The periodic tree's far images: the exchange with level 1 (__far_root),
 * and for scale-invariant kernels the monopole map c->far->mu. */
KIFMM__FN int KIFMM__F(__lattice_build)(KIFMM_NAME *c)
{
    const size_t nn = (size_t)c->pl->surf.nc * c->pl->surf.ne;
    double *T;
    kifmm__lat L;
    size_t i;
    int rc, d, np = 0;
    for (d = 0; d < 3; d++) np += c->tree->per[d];
    if (KIFMM__SI && np == 3) { /* Ewald sums (__far_pairs) */
#if KIFMM__EWALD
        rc = KIFMM__F(__far_root)(c, NULL, NULL);
        return rc ? rc : KIFMM__F(__background_fit)(c);
#else
        return KIFMM_ERR_PERIODIC; /* the kernel has no Ewald split or background */
#endif
    }
    /* T(3 h), the super-cell's far images, for __far_pairs */
    T = (double *)kifmm__alloc(nn, sizeof(double));
    rc = T ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM;
    memset(&L, 0, sizeof L);
    if (!rc && KIFMM__SI) { /* at h = 1: 3^a T(1) */
        rc = KIFMM__F(__lat_level)(c, 1.0, 1, &L);
        if (!rc) rc = KIFMM__F(__lat_fixed)(c, &L, T);
        if (!rc) {
            c->far->mu = L.mu;
            L.mu = NULL;
            c->far->held += kifmm__size(c->far->mu);
        }
        for (i = 0; i < nn && !rc; i++) T[i] *= pow(3.0, c->pl->ops.degree);
    } else if (!rc) {
        rc = KIFMM__F(__lat_sum)(c, 1.5 * c->tree->width, T);
    }
    if (!rc) rc = KIFMM__F(__far_root)(c, T, KIFMM__SI ? &L.sup : NULL);
    kifmm__free(T);
    kifmm__lat_free(&L);
    return rc;
}

/* The operator set of level l (c->lv: one set for all levels of a
 * scale-invariant kernel). */
KIFMM__FN const KIFMM__F(__ops) *KIFMM__F(__ops_at)(const KIFMM_NAME *c, int l)
{
    return c->lv[l];
}


/* Factor multiplying check potentials computed directly from points at
 * level l: the level's sigma (see build_c2e), times (half-width)^(-degree)
 * for a scale-invariant kernel, whose operators are built once at
 * half-width 1. */
KIFMM__FN double KIFMM__F(__level_scale)(const KIFMM_NAME *c, int l)
{
    double half = 0.5 * c->tree->width / (double)((int64_t)1 << l);
    return KIFMM__SI ? pow(half, -c->pl->ops.degree) * c->lv[l]->sigma : c->lv[l]->sigma;
}

// >>anchors

/* Anchors. A downward density fitted on a box's check surface misses the
 * field there by about the order's truncation error times the field's size.
 * In a box far below the sources that make most of its field, that field
 * is nearly constant across the box, while the miss varies on the box's
 * scale: its gradient is the miss over the box's size, its Hessian over the
 * size squared, and l levels below those sources the gradient's and the
 * Hessian's errors are 2^l and 4^l times the potential's (laplace_hess, p =
 * 6, 2,000 points of zero charge in a cube of side 1e-2 and 5 unit charges
 * 1 away, leaves of 1 point, 16 levels: relative errors 3.5e-5 in the
 * gradient and 0.83 in the Hessian, against 1.4e-7 and 1.4e-6 with
 * max_depth 6). So a downward density has nsa more points, the anchors,
 * about the box at KIFMM__ANCHOR_RADIUS half-widths (kifmm__anchor_unit;
 * how many: __st_derivative), fitted first: their least-squares fit on the
 * check surface takes the field's nearly constant and linear parts (4
 * anchors) or its quadratic part too (14), and the surface density fits
 * what is left, whose size is the field's variation across the box. Both in
 * one pair of factors, with P_a = pinv(G_a), G_a = K(check <- anchors) times
 * sigma (pinv(K_down) = vs ut):
 *   ut' = [ut (I - G_a P_a); P_a],  vs' = [vs 0; 0 I],
 * so that the passes use them as they used the plain ones (the dense M2L's
 * matrices, which include ut_dn, too). L2L carries the parent's anchors to
 * the children's check surfaces; L2P and L2L from a far ancestor evaluate
 * them with the surface points. */
/* G_a = K(check <- anchors) times sigma (nc x na, into g) and P_a =
 * pinv(G_a) (na x nc, into pa, zeroed by the caller), truncated at
 * KIFMM__ANCHOR_CUTOFF, by component groups where the surface kernel has
 * them (as __pinv_surf); *ka its rank. Anchors whose fields are below
 * KIFMM__ANCHOR_FLOOR of the kernel's size on the surfaces (sigma makes it
 * 1) take nothing (rank 0): a Yukawa kernel at lambda r above about 0.25,
 * whose far field such a box does not see. */
KIFMM__FN int KIFMM__F(__anchor_pinv)(const KIFMM_NAME *c, double r, double sigma, double *g, double *pa,
                                      int *ka)
{
    const int nc = c->pl->surf.nc, na = c->pl->surf.nsa * KIFMM__SD;
    const double zero[3] = {0.0, 0.0, 0.0};
    double *g2 = (double *)kifmm__alloc((size_t)nc * na, sizeof(double)), *uta = NULL, *vsa = NULL, gmax = 0.0;
    int rc = g2 ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM, i;
    *ka = 0;
    if (!rc)
        rc = KIFMM__F(__surf_kmat)(c, c->pl->surf.unit_c, c->pl->surf.nsc, zero, KIFMM__F(__rin)(c->pl, &c->pl->surf, r),
                                   c->pl->surf.unit_a, c->pl->surf.nsa, zero, r, sigma, g, (size_t)nc, NULL);
    for (i = 0; !rc && i < nc * na; i++)
        if (fabs(g[i]) > gmax) gmax = fabs(g[i]);
    if (!rc && gmax >= KIFMM__ANCHOR_FLOOR) {
#if !KIFMM__FRADIAL
        int gr[KIFMM__SD], gc[KIFMM__SD], ng = KIFMM__F(__sc_groups)(c->opts.kernel_param, gr, gc);
#else
        const int ng = 1;
        int *gr = NULL, *gc = NULL;
#endif
        memcpy(g2, g, (size_t)nc * na * sizeof(double));
        rc = ng > 1 ? kifmm__pinv_groups(NULL, g2, nc, na, KIFMM__SD, 0, 0, gr, gc, ng, KIFMM__ANCHOR_CUTOFF, &uta,
                                         &vsa, ka)
                    : kifmm__pinv(g2, nc, na, KIFMM__ANCHOR_CUTOFF, &uta, &vsa, ka);
    }
    if (!rc && *ka > 0) kifmm__gemm(0, 0, na, nc, *ka, 1.0, vsa, na, uta, *ka, 0.0, pa, na);
    kifmm__free(g2);
    kifmm__free(uta);
    kifmm__free(vsa);
    return rc;
}

KIFMM__FN int KIFMM__F(__anchor_fit)(const KIFMM_NAME *c, double r, kifmm__ops *o)
{
    const int nc = c->pl->surf.nc, ne = c->pl->surf.ne, na = c->pl->surf.nsa * KIFMM__SD;
    const int kd = o->kd, nd = ne + na;
    double *g = (double *)kifmm__alloc((size_t)nc * na, sizeof(double));
    double *pa = (double *)kifmm__calloc((size_t)na * nc, sizeof(double)), *x = NULL, *ut = NULL, *vs = NULL;
    int ka = 0, k2, i, j, rc = g && pa ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM;
    if (na == 0) goto done;
    if (!rc) rc = KIFMM__F(__anchor_pinv)(c, r, o->sigma, g, pa, &ka);
    /* without anchors that take anything, the plain factors with zero rows
     * for the anchors' values (the layout stays nde per box) */
    k2 = kd + (ka > 0 ? na : 0);
    x = (double *)kifmm__calloc((size_t)kd * na + 1, sizeof(double));
    ut = (double *)kifmm__calloc((size_t)k2 * nc + 1, sizeof(double));
    vs = (double *)kifmm__calloc((size_t)nd * k2 + 1, sizeof(double));
    if (!rc && !(x && ut && vs)) rc = KIFMM_ERR_NOMEM;
    if (rc) goto done;
    for (i = 0; i < nc; i++) {
        for (j = 0; j < kd; j++) ut[j + (size_t)i * k2] = o->ut_dn[j + (size_t)i * kd];
        for (j = 0; j < k2 - kd; j++) ut[kd + j + (size_t)i * k2] = pa[j + (size_t)i * na];
    }
    if (kd > 0 && ka > 0) { /* ut (I - G_a P_a) */
        kifmm__gemm(0, 0, kd, na, nc, 1.0, o->ut_dn, kd, g, nc, 0.0, x, kd);
        kifmm__gemm(0, 0, kd, nc, na, -1.0, x, kd, pa, na, 1.0, ut, k2);
    }
    for (i = 0; i < kd; i++) memcpy(vs + (size_t)i * nd, o->vs_dn + (size_t)i * ne, (size_t)ne * sizeof(double));
    for (j = 0; j < k2 - kd; j++) vs[ne + j + (size_t)(kd + j) * nd] = 1.0;
    kifmm__free(o->ut_dn);
    kifmm__free(o->vs_dn);
    o->ut_dn = ut;
    o->vs_dn = vs;
    o->kd = k2;
    ut = vs = NULL;
done:
    kifmm__free(g);
    kifmm__free(pa);
    kifmm__free(x);
    kifmm__free(ut);
    kifmm__free(vs);
    return rc;
}

/* The points of a downward density of a box (centre ctr, half-width
 * half) into pe, SoA over nse + nsa points: its outer surface (at radius),
 * then its anchors. */
KIFMM__FN void KIFMM__F(__place_down)(const kifmm__surf *sf, const double *ctr, double radius, double half,
                                      KIFMM__R *pe)
{
    const int n = sf->nse, m = n + sf->nsa;
    int i, d;
    for (d = 0; d < 3; d++) {
        for (i = 0; i < n; i++) pe[d * m + i] = (KIFMM__R)(ctr[d] + radius * sf->unit_e[d * n + i]);
        for (i = 0; i < sf->nsa; i++)
            pe[d * m + n + i] = (KIFMM__R)(ctr[d] + half * sf->unit_a[d * sf->nsa + i]);
    }
}

// >>workspace

KIFMM__FN void KIFMM__F(__work_free)(KIFMM__F(__work) *w)
{
    if (!w) return;
    kifmm__free(w->ue); kifmm__free(w->de); kifmm__free(w->chk); kifmm__free(w->tmp);
    kifmm__free(w->stack); kifmm__free(w->m2l_out); kifmm__free(w->qs); kifmm__free(w->outs);
    kifmm__free(w->lbuf); kifmm__free(w->lat);
#if defined(KIFMM_MPI)
    kifmm__free(w->qp);
#endif
    kifmm__free(w);
}

/* Per-vector sizes of the workspace arrays, in elements. */
KIFMM__FN void KIFMM__F(__work_sizes)(const KIFMM_NAME *c, size_t *sz)
{
    const kifmm__surf *sm = KIFMM__F(__smax)(c);
    size_t big = (size_t)(sm->nc > sm->nde ? sm->nc : sm->nde);
    sz[0] = KIFMM__F(__eo)(c, 0, c->tree->nbox);                  /* ue */
    sz[5] = KIFMM__F(__eo)(c, 1, c->tree->nbox);                  /* de */
    sz[1] = (size_t)c->work.mb * (size_t)sm->nc;                  /* chk */
#if KIFMM__FFT
    sz[2] = 0;
    (void)big;
#else
    sz[2] = (size_t)c->work.mb * big; /* tmp: the first solve step and the dense M2L, a level */
#endif
    sz[3] = (size_t)c->tree->ns * KIFMM__QD;                        /* qs */
    sz[4] = (size_t)c->tree->nt * KIFMM__TD;                        /* outs */
}

/* Values per thread of the task output buffers for up to nrhs vectors: the
 * targets of a leaf, of a box with X sources evaluated directly (fewer than
 * nsc) and of a chunk of the mutual near field, a multiple of 16 (64-byte
 * parts for double); 0 when all threads' parts would take more than half
 * of the sorted output array. */
KIFMM__FN size_t KIFMM__F(__lbuf_per)(const KIFMM_NAME *c, int nrhs)
{
    const kifmm__tree *t = c->tree;
    int64_t m = KIFMM__F(__smax)(c)->nsc, all = t->nt * (int64_t)nrhs * KIFMM__TD;
    int32_t i;
    for (i = 0; i < t->nleaves; i++)
        if (t->t1[t->leaves[i]] - t->t0[t->leaves[i]] > m)
            m = t->t1[t->leaves[i]] - t->t0[t->leaves[i]];
    for (i = 0; c->near.chunk && i < c->near.nchunk; i++) {
        const int32_t i0 = c->near.chunk[i], i1 = c->near.chunk[i + 1];
        const int64_t lo = i0 < t->nleaves ? t->t0[t->leaves[i0]] : t->nt;
        const int64_t hi = i1 < t->nleaves ? t->t0[t->leaves[i1]] : t->nt;
        if (hi - lo > m) m = hi - lo;
    }
    m = (m * (int64_t)nrhs * KIFMM__TD + 15) / 16 * 16;
    return 2 * (int64_t)c->opts.nthreads * m <= all ? (size_t)m : 0;
}

/* out[r dst + tperm[t0 + i] TD + k] += b[r ld + i TD + k]: a task's sums for
 * its n targets from sorted position t0 on, added to the caller's outputs. */
KIFMM__FN void KIFMM__F(__put)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs,
                               int64_t t0, int64_t n, const KIFMM__R *b, size_t ld)
{
    const kifmm__tree *t = c->tree;
    const size_t oper = (size_t)t->nt * KIFMM__TD;
    int64_t i;
    int r, k;
    for (r = 0; r < nrhs; r++)
        for (i = 0; i < n; i++) {
            KIFMM__R *d = w->dst + r * oper + (size_t)t->tperm[t0 + i] * KIFMM__TD;
            const KIFMM__R *s = b + r * ld + (size_t)i * KIFMM__TD;
            for (k = 0; k < KIFMM__TD; k++) d[k] += s[k];
        }
}

/* The calling thread's task output buffer, zeroed for nrhs x n targets. */
KIFMM__FN KIFMM__R *KIFMM__F(__lbuf)(const KIFMM__F(__work) *w, int nrhs, int64_t n)
{
#ifdef _OPENMP
    KIFMM__R *b = w->lbuf + (size_t)omp_get_thread_num() * w->lbuf_per;
#else
    KIFMM__R *b = w->lbuf;
#endif
    memset(b, 0, (size_t)nrhs * (size_t)n * KIFMM__TD * sizeof(KIFMM__R));
    return b;
}

/* The solves skip boxes without sources (ue) or targets (de): their
 * expansions are zero once and for all. */
KIFMM__FN void KIFMM__F(__work_zero)(const KIFMM_NAME *c, KIFMM__F(__work) *w)
{
    const kifmm__tree *t = c->tree;
    const size_t pu = KIFMM__F(__eo)(c, 0, t->nbox), pd = KIFMM__F(__eo)(c, 1, t->nbox);
    int32_t b;
    int r;
    for (r = 0; r < w->nrhs; r++)
        for (b = 0; b < t->nbox; b++) {
            const kifmm__surf *sf = KIFMM__F(__sf)(c, t->lev[b]);
            if (t->s1[b] == t->s0[b])
                memset(w->ue + r * pu + KIFMM__F(__eo)(c, 0, b), 0, (size_t)sf->ne * sizeof(KIFMM__R));
            if (t->t1[b] == t->t0[b])
                memset(w->de + r * pd + KIFMM__F(__eo)(c, 1, b), 0, (size_t)sf->nde * sizeof(KIFMM__R));
        }
}

/* The expansions and buffers of the passes for up to nrhs vectors, counted
 * in w->held; NULL if out of memory. */
KIFMM__FN KIFMM__F(__work) *KIFMM__F(__work_new)(const KIFMM_NAME *c, int nrhs)
{
    KIFMM__F(__work) *w = (KIFMM__F(__work) *)kifmm__calloc(1, sizeof *w);
    size_t sz[6], n = (size_t)nrhs, *held;
    const kifmm__surf *sm = KIFMM__F(__smax)(c);
    const size_t big = (size_t)(sm->nc > sm->nde ? sm->nc : sm->nde);
    if (!w) return NULL;
    held = &w->held;
    KIFMM__F(__work_sizes)(c, sz);
    w->nrhs = nrhs;
    w->ue = (KIFMM__R *)kifmm__take(held, n * sz[0], sizeof(KIFMM__R));
    w->de = (KIFMM__R *)kifmm__take(held, n * sz[5], sizeof(KIFMM__R));
    w->chk = (KIFMM__R *)kifmm__take(held, n * sz[1], sizeof(KIFMM__R));
    w->qs = (KIFMM__R *)kifmm__take(held, n * sz[3], sizeof(KIFMM__R));
#if defined(KIFMM_MPI)
    if (c->px.n > 0 && !(w->qp = (KIFMM__R *)kifmm__take(held, n * (size_t)c->px.n * KIFMM__SD, sizeof(KIFMM__R)))) {
        KIFMM__F(__work_free)(w);
        return NULL;
    }
#endif
    if (c->far && c->far->zu)
        w->lat = (KIFMM__R *)kifmm__take(held, n * ((size_t)2 * c->far->nzu * KIFMM__SD +
                                         (size_t)c->far->zku + (size_t)c->far->zkd), sizeof(KIFMM__R));
    if (!KIFMM__FFT) {
        w->tmp = (KIFMM__R *)kifmm__take(held, n * sz[2], sizeof(KIFMM__R));
        w->stack = (KIFMM__R *)kifmm__take(held, (size_t)c->work.m2l_cols * KIFMM__NT * (size_t)sm->ne,
                                           sizeof(KIFMM__R));
        w->m2l_out = (KIFMM__R *)kifmm__take(held, (size_t)c->work.m2l_cols * big, sizeof(KIFMM__R));
    }
    w->lbuf_per = KIFMM__F(__lbuf_per)(c, nrhs);
    if (w->lbuf_per)
        w->lbuf = (KIFMM__R *)kifmm__take(held, (size_t)c->opts.nthreads * w->lbuf_per, sizeof(KIFMM__R));
    else w->outs = (KIFMM__R *)kifmm__take(held, n * sz[4], sizeof(KIFMM__R));
    if (!w->ue || !w->de || !w->chk || !w->qs || (!w->outs && !w->lbuf) || (c->far && c->far->zu && !w->lat) ||
        (!KIFMM__FFT && (!w->tmp || !w->stack || !w->m2l_out))) {
        KIFMM__F(__work_free)(w);
        return NULL;
    }
    KIFMM__F(__work_zero)(c, w);
    return w;
}

/* Values per buffer of the column GEMM passes: the solve's intermediate
 * (ne x KIFMM__GC_NC), the mirrored M2M's and L2L's densities and products
 * (P__family_mirror: ne and nc x KIFMM__GC_NC, taken as nde and max(nc,
 * nde)), and without AVX2 the gather
 * workspace of the largest
 * product ((k + m) x KIFMM__GC_NC, k + m <= 9 max(nc, ne)). One buffer per
 * thread with AVX2 (the passes run in parallel), else one. */
KIFMM__FN size_t KIFMM__F(__gbuf_big)(const KIFMM_NAME *c) /* max(nc, nde) of the largest surfaces */
{
    const kifmm__surf *sm = KIFMM__F(__smax)(c);
    return (size_t)(sm->nc > sm->nde ? sm->nc : sm->nde);
}

KIFMM__FN size_t KIFMM__F(__gbuf_per)(const KIFMM_NAME *c)
{
    const size_t big = KIFMM__F(__gbuf_big)(c);
    return ((size_t)KIFMM__F(__smax)(c)->nde + big + (KIFMM__GC_FAST ? 0 : 9 * big)) * KIFMM__GC_NC;
}

/* The calling thread's buffer (thread 0 outside parallel regions). */
KIFMM__FN KIFMM__R *KIFMM__F(__gbuf)(const KIFMM_NAME *c)
{
#ifdef _OPENMP
    return c->work.gbuf + (size_t)omp_get_thread_num() * KIFMM__F(__gbuf_per)(c);
#else
    return c->work.gbuf;
#endif
}

/* Values per thread of the scratch: three surfaces of max(nsc, nse)
 * points, then (float instances) a frame of c->work.fpts points, then
 * (periodic trees) the image of a box's sources, c->work.ipts points. */
KIFMM__FN size_t KIFMM__F(__scratch_per)(const KIFMM_NAME *c)
{
    return 9 * (size_t)KIFMM__F(__smax)(c)->nsm + 3 * c->work.fpts + 3 * c->work.ipts;
}

/* The calling thread's scratch (see __scratch_per). */
KIFMM__FN KIFMM__R *KIFMM__F(__scratch)(const KIFMM_NAME *c)
{
    return c->work.scratch + (size_t)kifmm__thread_num() * KIFMM__F(__scratch_per)(c);
}

/* The calling thread's frame buffer: after its three surfaces. */
KIFMM__FN KIFMM__R *KIFMM__F(__framebuf)(const KIFMM_NAME *c)
{
    return KIFMM__F(__scratch)(c) + 9 * (size_t)KIFMM__F(__smax)(c)->nsm;
}

/* The sources of box a moved by image s (a shift code) into the thread's
 * image buffer (structure of arrays, its count apart); the sorted sources
 * themselves for s = KIFMM__NOSHIFT. *ld: values per coordinate. */
KIFMM__FN const KIFMM__R *KIFMM__F(__image)(const KIFMM_NAME *c, int32_t a, int s, size_t *ld)
{
    const kifmm__tree *t = c->tree;
    const int64_t s0 = t->s0[a], n = t->s1[a] - s0;
    KIFMM__R *buf = KIFMM__F(__framebuf)(c) + 3 * c->work.fpts;
    int64_t i;
    int d, sh[3];
    *ld = (size_t)t->ns;
    if (s == KIFMM__NOSHIFT) return c->pts.src + s0;
    kifmm__shift_of(s, sh);
    for (d = 0; d < 3; d++)
        for (i = 0; i < n; i++)
            buf[(size_t)d * n + i] = (KIFMM__R)((double)c->pts.src[(size_t)d * t->ns + s0 + i] + sh[d] * t->cell);
    *ld = (size_t)n;
    return buf;
}

/* The n points of a sorted set from position p0 on (structure of arrays,
 * *ld values per coordinate) in a frame centred at fc. Float instances
 * shift them in double and round them into buf (3 n values, *ld becomes n):
 * coordinates relative to the root keep float's digits of the root's size,
 * and a surface placed next to points of a box 1e-4 of the root wide would be
 * off by 1e-4 of the box; in the box's own frame both keep the digits of its
 * size. Double instances use the points in place, in the frame centred at
 * the origin (fc is zeroed). Surfaces are then placed at (centre - fc). */
KIFMM__FN const KIFMM__R *KIFMM__F(__frame)(const KIFMM__R *pts, size_t *ld, int64_t p0,
                                           int64_t n, double *fc, KIFMM__R *buf)
{
#if KIFMM__FLOAT
    int64_t i;
    int d;
    for (d = 0; d < 3; d++)
        for (i = 0; i < n; i++)
            buf[(size_t)d * n + i] = (KIFMM__R)((double)pts[(size_t)d * *ld + p0 + i] - fc[d]);
    *ld = (size_t)n;
    return buf;
#else
    (void)ld;
    (void)n;
    (void)buf;
    fc[0] = fc[1] = fc[2] = 0.0;
    return pts + p0;
#endif
}


// >>upward

/* Layout of the per-level arrays chk and tmp: vector r, box b of level l, with
 * `rows` entries per box: [(r * n_l + (b - loff[l])) * rows]. */
#define KIFMM__LVL(c, l) ((c)->tree->loff[(l) + 1] - (c)->tree->loff[(l)])

/* Check vectors -> equivalent densities for every box of level l: per piece
 * of KIFMM__GC_NC columns (box x vector; chk holds them in that order),
 * t = ut chk into the thread's own buffer, then equiv = vs t (the two
 * factors of the pseudo-inverse, one after the other). */
KIFMM__FN void KIFMM__F(__solve)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs, int l,
                                 int up)
{
    const kifmm__tree *t = c->tree;
    const KIFMM__F(__ops) *o = KIFMM__F(__ops_at)(c, l);
    const int n = KIFMM__LVL(c, l), k = up ? o->ku : o->kd;
    const int32_t *ai = c->work.act + (up ? 0 : t->nbox) + t->loff[l];
    const int na = c->work.act[2 * t->nbox + 2 * l + !up];
    const int ppv = (na + KIFMM__GC_NC - 1) / KIFMM__GC_NC, np = ppv * nrhs;
    const kifmm__surf *sf = KIFMM__F(__sf)(c, l);
    const int ne = up ? sf->ne : sf->nde, nc = sf->nc;
    const size_t per = KIFMM__F(__eo)(c, !up, t->nbox);
    KIFMM__R *eq = up ? w->ue : w->de;
    KIFMM__OMP(parallel for schedule(dynamic, 1) num_threads(c->opts.nthreads) if (KIFMM__GC_FAST))
    for (int p = 0; p < np; p++) {
        /* pieces of one vector each, cut as for evaluate: without AVX2 each is a
         * BLAS call, whose result for a column can depend on the call's other
         * columns, and the float FFT spectra turn last-bit differences into
         * float rounding ones between evaluate_many and evaluate */
        const KIFMM__R *bp[KIFMM__GC_NC], *tb[KIFMM__GC_NC];
        KIFMM__R *tp[KIFMM__GC_NC], *cp[KIFMM__GC_NC];
        KIFMM__R *buf = KIFMM__F(__gbuf)(c);
        const size_t per_t = (size_t)KIFMM__F(__smax)(c)->nde * KIFMM__GC_NC;
        const int r = p / ppv, j0 = (p % ppv) * KIFMM__GC_NC;
        int q, nq = na - j0;
        if (nq > KIFMM__GC_NC) nq = KIFMM__GC_NC;
        for (q = 0; q < nq; q++) {
            const size_t b = (size_t)ai[j0 + q]; /* within the level */
            bp[q] = w->chk + ((size_t)r * n + b) * nc;
            tb[q] = tp[q] = buf + (size_t)q * k;
            cp[q] = eq + (size_t)r * per + KIFMM__F(__eo)(c, !up, t->loff[l] + (int32_t)b);
        }
        KIFMM__GEMM_COLS(k, nc, up ? o->ut_up : o->ut_dn, k, nq, bp, tp, 0, buf + per_t);
        KIFMM__GEMM_COLS(ne, k, up ? o->vs_up : o->vs_dn, ne, nq, tb, cp, 0, buf + per_t);
    }
}

/* Octant m (1 to 7) of P__family_mirror over nq columns: x (bp, the
 * child's or the parent's density) gathered mirrored into yp (y[k] = s_k
 * x[mirror k], s_k the sign of component k's axis where it is a vector's),
 * zp = op yp (octant 0's matrix, nc x ne), then c[i] (+)= s_i z[mirror i]
 * into cp (the parent's or the child's check vector; added if acc). */
KIFMM__FN void KIFMM__F(__mirror_octant)(const KIFMM__F(__ops) *e, const kifmm__surf *sf, int m, int nq,
                                         const KIFMM__R *op, const KIFMM__R *const *bp, KIFMM__R *const *cp,
                                         int acc, KIFMM__R *const *yp, KIFMM__R *const *zp, KIFMM__R *work)
{
    enum { SD = KIFMM__SD };
    const int nsc = sf->nsc, nse = sf->nse, *mc = e->mmap + (size_t)(m - 1) * (nsc + nse), *me = mc + nsc;
    KIFMM__R sg[SD];
    int q, i, a;
    for (a = 0; a < SD; a++) /* the axes of m, for a vector's last three components */
        sg[a] = e->mir == 2 && a >= SD - 3 && (m >> (2 - (a - (SD - 3))) & 1) ? (KIFMM__R)-1 : (KIFMM__R)1;
    for (q = 0; q < nq; q++)
        for (i = 0; i < nse; i++)
            for (a = 0; a < SD; a++) yp[q][i * SD + a] = sg[a] * bp[q][me[i] * SD + a];
    KIFMM__GEMM_COLS(sf->nc, sf->ne, op, sf->nc, nq, (const KIFMM__R *const *)yp, zp, 0, work);
    for (q = 0; q < nq; q++)
        for (i = 0; i < nsc; i++)
            for (a = 0; a < SD; a++)
                cp[q][i * SD + a] = (acc ? cp[q][i * SD + a] : 0) + sg[a] * zp[q][mc[i] * SD + a];
}

/* __family_level with octant 0's M2M or L2L (e->mir, P__mirror_maps), per
 * piece of parents: the anchors' part of L2L first (one product over the
 * eight children), then octant 0's product in place and the other
 * octants' mirrored (P__mirror_octant) through the thread's buffer. */
KIFMM__FN void KIFMM__F(__family_mirror)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs, int lp,
                                         int down, const KIFMM__F(__ops) *e)
{
    const kifmm__tree *t = c->tree;
    const int ni = t->ioff[lp + 1] - t->ioff[lp], n = KIFMM__LVL(c, lp + down);
    const int ppv = (ni + KIFMM__GC_NC - 1) / KIFMM__GC_NC, np = ppv * nrhs;
    const kifmm__surf *sf = KIFMM__F(__sf)(c, lp);
    const int nc = sf->nc, ne = sf->ne, na = down ? sf->nde - ne : 0;
    const size_t per = KIFMM__F(__eo)(c, down, t->nbox);
    const size_t off_z = (size_t)KIFMM__F(__smax)(c)->nde * KIFMM__GC_NC; /* see __gbuf_per */
    const size_t off_w = off_z + KIFMM__F(__gbuf_big)(c) * KIFMM__GC_NC;
    const KIFMM__R *op = down ? e->l2l : e->m2m;
    KIFMM__OMP(parallel for schedule(dynamic, 1) num_threads(c->opts.nthreads) if (KIFMM__GC_FAST))
    for (int p = 0; p < np; p++) {
        const KIFMM__R *xb[KIFMM__GC_NC], *bp[KIFMM__GC_NC];
        KIFMM__R *cb[KIFMM__GC_NC], *cp[KIFMM__GC_NC], *yp[KIFMM__GC_NC], *zp[KIFMM__GC_NC];
        KIFMM__R *buf = KIFMM__F(__gbuf)(c);
        const int jr = p / ppv, j0 = (p % ppv) * KIFMM__GC_NC; /* as in __solve */
        int q, m, nq = ni - j0;
        if (nq > KIFMM__GC_NC) nq = KIFMM__GC_NC;
        for (q = 0; q < nq; q++) {
            const int jb = j0 + q;
            const int32_t b = t->inner[t->ioff[lp] + jb];
            if (down) { /* the parent's density; the eight children's check vectors */
                xb[q] = w->de + jr * per + KIFMM__F(__eo)(c, 1, b);
                cb[q] = w->chk + ((size_t)jr * n + 8 * (size_t)jb) * nc;
            } else { /* the eight children's densities; the parent's check vector */
                xb[q] = w->ue + jr * per + KIFMM__F(__eo)(c, 0, t->loff[lp + 1] + 8 * jb);
                cb[q] = w->chk + ((size_t)jr * n + (size_t)(b - t->loff[lp])) * nc;
            }
            yp[q] = buf + (size_t)q * ne;
            zp[q] = buf + off_z + (size_t)q * nc;
        }
        if (na > 0) {
            for (q = 0; q < nq; q++) bp[q] = xb[q] + ne;
            KIFMM__GEMM_COLS(8 * nc, na, op + (size_t)nc * ne, 8 * nc, nq, bp, cb, 0, buf + off_w);
        }
        for (m = 0; m < 8; m++) {
            for (q = 0; q < nq; q++) {
                bp[q] = down ? xb[q] : xb[q] + (size_t)m * ne;
                cp[q] = down ? cb[q] + (size_t)m * nc : cb[q];
            }
            if (m == 0)
                KIFMM__GEMM_COLS(nc, ne, op, nc, nq, bp, cp, !down || na > 0, buf + off_w);
            else
                KIFMM__F(__mirror_octant)(e, sf, m, nq, op, bp, cp, !down || na > 0, yp, zp, buf + off_w);
        }
    }
}

/* Between the internal boxes of level lp and their children, whose boxes are
 * 8j..8j+7 of level lp + 1 for the j-th internal box: M2M (down = 0) adds
 * the children's equivalent densities, one column of 8 ne values, to the
 * parent's check vector; L2L (down = 1) sets the children's check vectors,
 * one column of 8 nc values, from the parent's equivalent density. Columns
 * (box x vector) in pieces of KIFMM__GC_NC over the threads. */
KIFMM__FN void KIFMM__F(__family_level)(const KIFMM_NAME *c, const KIFMM__F(__work) *w,
                                        int nrhs, int lp, int down)
{
    const kifmm__tree *t = c->tree;
    const int ni = t->ioff[lp + 1] - t->ioff[lp], n = KIFMM__LVL(c, lp + down);
    const int ppv = (ni + KIFMM__GC_NC - 1) / KIFMM__GC_NC, np = ppv * nrhs;
    const kifmm__surf *sp = KIFMM__F(__sf)(c, lp), *sc = KIFMM__F(__sf)(c, lp + 1);
    const int m = down ? 8 * sc->nc : sp->nc, k = down ? sp->nde : 8 * sc->ne;
    const size_t per = KIFMM__F(__eo)(c, down, t->nbox);
    const KIFMM__F(__ops) *e = down ? KIFMM__F(__ops_at)(c, lp + 1) : KIFMM__F(__ops_at)(c, lp);
    const KIFMM__R *op = down ? e->l2l : e->m2m;
    if (ni == 0 || lp + 1 >= t->nlev) return;
    if (e->mir) {
        KIFMM__F(__family_mirror)(c, w, nrhs, lp, down, e);
        return;
    }
    KIFMM__OMP(parallel for schedule(dynamic, 1) num_threads(c->opts.nthreads) if (KIFMM__GC_FAST))
    for (int p = 0; p < np; p++) {
        const KIFMM__R *bp[KIFMM__GC_NC];
        KIFMM__R *cp[KIFMM__GC_NC];
        const int jr = p / ppv, j0 = (p % ppv) * KIFMM__GC_NC; /* as in __solve */
        int q, nq = ni - j0;
        if (nq > KIFMM__GC_NC) nq = KIFMM__GC_NC;
        for (q = 0; q < nq; q++) {
            const int jb = j0 + q;
            const int32_t b = t->inner[t->ioff[lp] + jb];
            if (down) {
                bp[q] = w->de + jr * per + KIFMM__F(__eo)(c, 1, b);
                cp[q] = w->chk + ((size_t)jr * n + 8 * (size_t)jb) * sc->nc;
            } else {
                bp[q] = w->ue + jr * per + KIFMM__F(__eo)(c, 0, t->loff[lp + 1] + 8 * jb);
                cp[q] = w->chk + ((size_t)jr * n + (size_t)(b - t->loff[lp])) * sp->nc;
            }
        }
        KIFMM__GEMM_COLS(m, k, op, m, nq, bp, cp, !down,
                         KIFMM__F(__gbuf)(c) + (size_t)KIFMM__F(__smax)(c)->nde * KIFMM__GC_NC);
    }
}

/* Above the cell (kc > 0): the boxes of level l that are images of a
 * sibling (t->alias) take its upward densities. */
KIFMM__FN void KIFMM__F(__alias_fill)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs, int l)
{
    const kifmm__tree *t = c->tree;
    const size_t ne = (size_t)KIFMM__F(__sf)(c, l)->ne, per = KIFMM__F(__eo)(c, 0, t->nbox);
    int32_t b;
    int r;
    for (r = 0; r < nrhs; r++)
        for (b = t->loff[l]; b < t->loff[l + 1]; b++)
            if (t->alias[b] >= 0)
                memcpy(w->ue + r * per + KIFMM__F(__eo)(c, 0, b),
                       w->ue + r * per + KIFMM__F(__eo)(c, 0, t->alias[b]), ne * sizeof(KIFMM__R));
}

/* After the upward solve of level l: each box's equivalent density gets the
 * sums of its sources' (c->pl->ops.mono times the densities: a leaf) or of its
 * children's densities (an internal box), by a uniform shift of each
 * component over the surface points. The fit leaves a relative error in
 * those sums, and where a box's sources cancel (dipoles, force pairs, a
 * double layer: no monopole) that error is a monopole whose field, against
 * the true one, grows twice per level up: a cluster of force dipoles
 * 1e-5 wide with targets spread over 1 (stokes, p = 6) measured 4e-2, and
 * 2.5e-5 with the sums set. A box whose sums do not come out finite keeps
 * its fit. */
KIFMM__FN void KIFMM__F(__mono_fix)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs,
                                    int l)
{
    const kifmm__tree *t = c->tree;
    const int32_t *ai = c->work.act + t->loff[l];
    const int na = c->work.act[2 * t->nbox + 2 * l], nse = KIFMM__F(__sf)(c, l)->nse;
    const int ne = KIFMM__F(__sf)(c, l)->ne;
    const size_t per = KIFMM__F(__eo)(c, 0, t->nbox), ldq = (size_t)t->ns * KIFMM__QD;
    const KIFMM__F(__ops) *e = c->lv[l];
    if (!e || !e->mono_on) return;
    KIFMM__OMP(parallel for schedule(static) num_threads(c->opts.nthreads))
    for (int j = 0; j < na * nrhs; j++) {
        const int r = j / na;
        const int32_t b = t->loff[l] + ai[j % na];
        KIFMM__R *x = w->ue + (size_t)r * per + KIFMM__F(__eo)(c, 0, b);
        double m[KIFMM__SD], sx[KIFMM__SD], dm[KIFMM__SD];
        int a, i, ok = 1;
        if (t->alias && t->alias[b] >= 0) continue;
        for (a = 0; a < KIFMM__SD; a++) m[a] = sx[a] = 0.0;
        if (t->child[b] < 0) {
            const KIFMM__R *q = w->qs + (size_t)r * ldq;
            double sq[KIFMM__QD];
            int64_t s;
            int k;
            for (k = 0; k < KIFMM__QD; k++) sq[k] = 0.0;
            for (s = t->s0[b]; s < t->s1[b]; s++) {
#if defined(KIFMM_MPI)
                if (c->px.cum && c->px.cum[s + 1] > c->px.cum[s]) { /* a proxy: the surface's */
                    for (a = 0; a < KIFMM__SD; a++)
                        m[a] += (double)w->qp[((size_t)r * c->px.n + c->px.cum[s]) * KIFMM__SD + a];
                    continue;
                }
#endif
                for (k = 0; k < KIFMM__QD; k++) sq[k] += (double)q[(size_t)s * KIFMM__QD + k];
            }
            for (k = 0; k < KIFMM__QD; k++)
                for (a = 0; a < KIFMM__SD; a++) m[a] += e->mono[a + k * KIFMM__SD] * sq[k];
        } else {
            const int nch = KIFMM__F(__sf)(c, l + 1)->ne;
            int ch;
            /* every child: those without sources hold zeros, and above the
             * cell an image's densities are its sibling's (__alias_fill) */
            for (ch = 0; ch < 8; ch++) {
                const KIFMM__R *y = w->ue + (size_t)r * per + KIFMM__F(__eo)(c, 0, t->child[b] + ch);
                for (i = 0; i < nch; i++) m[i % KIFMM__SD] += (double)y[i];
            }
        }
        for (i = 0; i < ne; i++) sx[i % KIFMM__SD] += (double)x[i];
        for (a = 0; a < KIFMM__SD; a++) {
            dm[a] = (m[a] - sx[a]) / (double)nse;
            ok &= isfinite(dm[a]) != 0;
        }
        if (ok)
            for (i = 0; i < ne; i++) x[i] = (KIFMM__R)((double)x[i] + dm[i % KIFMM__SD]);
    }
}

/* Upward pass at level l: P2M into the leaves' check vectors, M2M into the
 * internal boxes', then the solve for the equivalent densities. */
KIFMM__FN void KIFMM__F(__upward)(KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs, int l)
{
    const kifmm__tree *t = c->tree;
    const kifmm__surf *sf = KIFMM__F(__sf)(c, l);
    const int nsc = sf->nsc;
    const size_t nc = (size_t)sf->nc;
    int nl = KIFMM__LVL(c, l);
    double scale = KIFMM__F(__level_scale)(c, l), t0 = kifmm__now(), t1;
    memset(w->chk, 0, (size_t)nl * nrhs * nc * sizeof(KIFMM__R));
    /* each leaf b writes its own check vector (its thread's scratch) */
    KIFMM__OMP(parallel for schedule(dynamic, 8) num_threads(c->opts.nthreads))
    for (int32_t b = t->loff[l]; b < t->loff[l + 1]; b++) {
        const int64_t s0 = t->s0[b], ns = t->s1[b] - s0;
        KIFMM__R *pc = KIFMM__F(__scratch)(c);
        const KIFMM__R *xs;
        double ctr[3], fc[3], rc[3], half;
        size_t ld = (size_t)t->ns;
        if (t->child[b] >= 0 || ns == 0) continue;
        kifmm__box_center(t, b, ctr, &half);
        memcpy(fc, ctr, sizeof fc);
        xs = KIFMM__F(__frame)(c->pts.src, &ld, s0, ns, fc, KIFMM__F(__framebuf)(c));
        kifmm__sub3(ctr, fc, rc);
        KIFMM__F(__place)(sf->unit_c, nsc, rc, sf->ao * half, pc);
#if defined(KIFMM_MPI)
        if (c->px.cum) {
            KIFMM__F(__p2p_roles)(c, w, KIFMM__F(__p2p_qc), KIFMM__F(__p2p_sc), pc, pc + nsc, pc + 2 * nsc,
                                  nsc, xs, ld, s0, ns, nrhs, scale, w->chk + (size_t)(b - t->loff[l]) * nc,
                                  (size_t)nl * nc);
            continue;
        }
#endif
        KIFMM__F(__p2p_qc)(c->opts.kernel_param, pc, pc + nsc, pc + 2 * nsc, nsc, xs, xs + ld, xs + 2 * ld,
                           w->qs + s0 * KIFMM__QD, ns, nrhs, (size_t)t->ns * KIFMM__QD, scale,
                           w->chk + (size_t)(b - t->loff[l]) * nc, (size_t)nl * nc);
    }
    t1 = kifmm__now();
    c->stats.t_p2m += t1 - t0;
    KIFMM__F(__family_level)(c, w, nrhs, l, 0); /* M2M */
    KIFMM__F(__solve)(c, w, nrhs, l, 1);
    KIFMM__F(__mono_fix)(c, w, nrhs, l);
    if (t->alias && l >= 1 && l <= t->kc) KIFMM__F(__alias_fill)(c, w, nrhs, l);
    c->stats.t_m2m += kifmm__now() - t1;
}

// >>downward

#if !KIFMM__FFT
/* The downward solve around the dense M2L, which adds its results between
 * the two factors (its matrices include ut_dn): step 0, tmp = ut chk (one GEMM
 * over boxes and vectors); step 1, equiv = vs tmp. */
KIFMM__FN void KIFMM__F(__solve_step)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs,
                                      int l, int up, int step)
{
    const kifmm__tree *t = c->tree;
    const KIFMM__F(__ops) *o = KIFMM__F(__ops_at)(c, l);
    const kifmm__surf *sf = KIFMM__F(__sf)(c, l);
    int n = KIFMM__LVL(c, l), k = up ? o->ku : o->kd, r;
    const int ne = up ? sf->ne : sf->nde;
    size_t per = KIFMM__F(__eo)(c, !up, t->nbox);
    if (step == 0) {
        KIFMM__F(__gemm)(k, n * nrhs, sf->nc, up ? o->ut_up : o->ut_dn, k, w->chk, sf->nc, 0, w->tmp, k);
        return;
    }
    for (r = 0; r < nrhs; r++)
        KIFMM__F(__gemm)(ne, n, k, up ? o->vs_up : o->vs_dn, ne, w->tmp + (size_t)r * n * k, k, 0,
                         (up ? w->ue : w->de) + r * per + KIFMM__F(__eo)(c, !up, t->loff[l]), ne);
}

KIFMM__FN void KIFMM__F(__m2l_level)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs,
                                     int l)
{
    const kifmm__tree *t = c->tree;
    const KIFMM__F(__ops) *o = KIFMM__F(__ops_at)(c, l);
    int32_t n = t->m2lo[l + 1] - t->m2lo[l], b0, blk = c->work.m2l_cols / nrhs;
    int nl = KIFMM__LVL(c, l);
    const size_t ne = (size_t)KIFMM__F(__sf)(c, l)->ne;
    size_t col = (size_t)KIFMM__NT * ne, per = KIFMM__F(__eo)(c, 0, t->nbox);
    if (blk < 1) blk = 1;
    for (b0 = 0; b0 < n; b0 += blk) {
        int32_t nb = n - b0 < blk ? n - b0 : blk;
        KIFMM__OMP(parallel for schedule(dynamic, 4) num_threads(c->opts.nthreads))
        for (int32_t j = 0; j < nb * nrhs; j++) {
            int32_t b = t->m2l[t->m2lo[l] + b0 + j / nrhs], e;
            const KIFMM__R *ue = w->ue + (size_t)(j % nrhs) * per;
            KIFMM__R *st = w->stack + (size_t)j * col;
            memset(st, 0, col * sizeof(KIFMM__R));
            for (e = t->vo[b]; e < t->vo[b + 1]; e++)
                memcpy(st + (size_t)t->vt[e] * ne, ue + KIFMM__F(__eo)(c, 0, t->v[e]), ne * sizeof(KIFMM__R));
        }
        KIFMM__F(__gemm)(o->kd, nb * nrhs, (int)col, o->m2l, o->kd, w->stack, (int)col, 0,
                         w->m2l_out, o->kd);
        KIFMM__OMP(parallel for schedule(static) num_threads(c->opts.nthreads))
        for (int32_t j = 0; j < nb * nrhs; j++) {
            int32_t b = t->m2l[t->m2lo[l] + b0 + j / nrhs];
            KIFMM__R *dst = w->tmp + ((size_t)(j % nrhs) * nl + (size_t)(b - t->loff[l])) * o->kd;
            const KIFMM__R *s = w->m2l_out + (size_t)j * o->kd;
            int i;
            for (i = 0; i < o->kd; i++) dst[i] += s[i];
        }
    }
}
#endif

#if KIFMM__FFT
/* A pair of typed pointers into a buffer of the FFT's spectra, whose values
 * are float or double (plan.single): one of the two is set. Offsets are
 * counted in values. */
typedef struct {
    float *f;
    double *d;
} KIFMM__F(__sp);

KIFMM__FN KIFMM__F(__sp) KIFMM__F(__sp_at)(float *f, double *d, size_t off)
{
    KIFMM__F(__sp) s;
    s.f = f ? f + off : NULL;
    s.d = d ? d + off : NULL;
    return s;
}

/* The calling thread's FFT buffer (blocks, products, transform work: fft.per
 * values of the spectra's type) from value off on, and its lattice density
 * (8 nc doubles). */
KIFMM__FN KIFMM__F(__sp) KIFMM__F(__fbuf)(const KIFMM_NAME *c, size_t off)
{
    return KIFMM__F(__sp_at)(c->fft.bf, c->fft.bd, (size_t)kifmm__thread_num() * c->fft.per + off);
}

KIFMM__FN double *KIFMM__F(__mbuf)(const KIFMM_NAME *c)
{
    return c->fft.mbuf + (size_t)kifmm__thread_num() * 8 * (size_t)KIFMM__F(__smax)(c)->nc;
}

/* The densities of 8 multipoles u_v (ne values each, consecutive) on the
 * check-order lattice: m[i 8 + v] = sum_j conv[j nc + i] u_v[j] (conv NULL:
 * the identity). */
KIFMM__FN void KIFMM__F(__conv8)(const KIFMM__R *conv, int nc, int ne, const KIFMM__R *u,
                                 double *m)
{
    int i, j, v;
    if (!conv) {
        /* the identity (nc = ne): interleave the 8 densities */
        for (i = 0; i < nc; i++)
            for (v = 0; v < 8; v++) m[8 * i + v] = (double)u[(size_t)v * ne + i];
        return;
    }
#if defined(__AVX2__) && defined(__FMA__)
    for (i = 0; i < 8 * nc; i++) m[i] = 0.0;
    for (j = 0; j < ne; j += 4) {
        /* four columns of conv per sweep over m; the 8 lanes in two registers */
        const int nj = ne - j < 4 ? ne - j : 4;
        __m256d ua[4], ub[4];
        const KIFMM__R *cj[4];
        double t[8];
        int a;
        for (a = 0; a < 4; a++) {
            for (v = 0; v < 8; v++) t[v] = a < nj ? (double)u[(size_t)v * ne + j + a] : 0.0;
            ua[a] = _mm256_loadu_pd(t);
            ub[a] = _mm256_loadu_pd(t + 4);
            cj[a] = conv + (size_t)(a < nj ? j + a : j) * nc;
        }
        for (i = 0; i < nc; i++) {
            __m256d x = _mm256_loadu_pd(m + 8 * i), y = _mm256_loadu_pd(m + 8 * i + 4);
            for (a = 0; a < 4; a++) {
                const __m256d c = _mm256_set1_pd((double)cj[a][i]);
                x = _mm256_fmadd_pd(c, ua[a], x);
                y = _mm256_fmadd_pd(c, ub[a], y);
            }
            _mm256_storeu_pd(m + 8 * i, x);
            _mm256_storeu_pd(m + 8 * i + 4, y);
        }
    }
#else
    for (i = 0; i < 8 * nc; i++) m[i] = 0.0;
    for (j = 0; j < ne; j++)
        for (v = 0; v < 8; v++) {
            const double uj = (double)u[(size_t)v * ne + j];
            for (i = 0; i < nc; i++) m[8 * i + v] += (double)conv[(size_t)j * nc + i] * uj;
        }
#endif
}

/* Does any child of the j-th internal box of level l - 1 receive M2L? */
KIFMM__FN int KIFMM__F(__fft_wanted)(const kifmm__tree *t, int l, int32_t j)
{
    int32_t b = t->loff[l] + 8 * j, c;
    for (c = 0; c < 8; c++)
        if (t->vo[b + c + 1] > t->vo[b + c]) return 1;
    return 0;
}

/* The products of one target parent for frequency chunk ch (see
 * kifmm__fft_products): its nn source parents at parent slots nbr, offsets
 * cc, with the chunk's blocks kb, into out (component a at out + a F 16).
 * With SD > 1 each target component a sums over the pairs (source parent,
 * source component b): slot nbr SD + b, block (a, cc, b). The spectra at
 * chunk chx of the nx source parents at slots nxt (the next target
 * parent's) are prefetched meanwhile: they lie scattered over the spectra
 * buffer, out of reach of the hardware prefetchers. */
KIFMM__FN void KIFMM__F(__fft_products)(const KIFMM_NAME *c, int ch, const int32_t *nbr, int nn,
                                        const unsigned char *cc, KIFMM__F(__sp) kb,
                                        KIFMM__F(__sp) out, int chx, const int32_t *nxt, int nx)
{
    const size_t cs = (size_t)c->fft.slots * KIFMM__FFT_F * 16, at = (size_t)ch * cs;
    const size_t ax = (size_t)chx * cs, esz = c->fft.specf ? sizeof(float) : sizeof(double);
    int32_t nb2[27 * KIFMM__FSD];
    unsigned char no2[27 * KIFMM__FSD];
    const int32_t *nbs = nbr;
    const unsigned char *nos = cc;
    int e, q, a, b, m = nn;
    for (e = 0; e < nx; e++) {
        const size_t v = ax + (size_t)nxt[e] * KIFMM__FFT_PN;
        const char *p = c->fft.specf ? (const char *)(c->fft.specf + v) : (const char *)(c->fft.specd + v);
        for (q = 0; q < (int)(KIFMM__FFT_PN * esz); q += 64) KIFMM__PREFETCH(p + q);
    }
    for (a = 0; a < KIFMM__FSD; a++) {
        const size_t ka = (size_t)a * 27 * KIFMM__FSD * KIFMM__FFT_F * 128, oa = (size_t)a * KIFMM__FFT_F * 16;
        if (KIFMM__FSD > 1) { /* the (parent, component) pairs of row a's nonzero blocks */
            for (m = 0, e = 0; e < nn; e++)
                for (b = 0; b < KIFMM__FSD; b++)
                    if (c->nz[a * KIFMM__FSD + b]) {
                        nb2[m] = nbr[e] * KIFMM__FSD + b;
                        no2[m++] = (unsigned char)(cc[e] * KIFMM__FSD + b);
                    }
            nbs = nb2;
            nos = no2;
        }
        if (c->fft.specf)
            kifmm__fft_productsf(m, nbs, nos, c->fft.sch, c->fft.specf + at, kb.f + ka, out.f + oa);
        else
            kifmm__fft_productsd(m, nbs, nos, c->fft.sch, c->fft.specd + at, kb.d + ka, out.d + oa);
    }
}

/* The inverse transforms of the products of the j-th target parent of level
 * l - 1 (op: its first chunk, chunks ocs values apart), added to the check
 * vectors chk of its children that have a V list. */
KIFMM__FN void KIFMM__F(__fft_finish)(const KIFMM_NAME *c, int l, int32_t j, KIFMM__F(__sp) op,
                                      size_t ocs, KIFMM__R *chk)
{
    const kifmm__tree *t = c->tree;
    const int nc = KIFMM__F(__sf)(c, l)->nc;
    const size_t woff = KIFMM__FFT_KBN + KIFMM__FFT_OUTN(c);
    double *dchk = KIFMM__F(__mbuf)(c);
    KIFMM__F(__sp) work = KIFMM__F(__fbuf)(c, woff);
    int q, i, a;
    for (a = 0; a < KIFMM__FSD; a++) { /* (a complex lattice: both components) */
        const size_t oa = (size_t)a * KIFMM__FFT_F * 16;
        if (op.f) kifmm__fft_inverse8f(KIFMM__F(__ft)(c, l), op.f + oa, ocs, KIFMM__SD, a, dchk, work.f);
        else kifmm__fft_inverse8d(KIFMM__F(__ft)(c, l), op.d + oa, ocs, KIFMM__SD, a, dchk, work.d);
    }
    for (q = 0; q < 8; q++) {
        const int32_t lb = 8 * j + q, box = t->loff[l] + lb;
        KIFMM__R *dst = chk + (size_t)lb * nc;
        if (t->vo[box + 1] == t->vo[box]) continue;
        for (i = 0; i < nc; i++) dst[i] += (KIFMM__R)dchk[8 * i + q];
    }
}

/* A slab of target parents [s0, return) (internal boxes of level l - 1,
 * numbered from the level's first) whose source parents fit in the spectra
 * buffer's slots: those get slots loc[] in order (need[0 .. *nneed)), and
 * cjl the slots of each target parent's colleagues. Without kept blocks the
 * slab's outputs must also fit in fout (slots parents). */
KIFMM__FN int32_t KIFMM__F(__fft_slab)(const KIFMM_NAME *c, int l, int kept, int32_t s0,
                                       int32_t *nneed)
{
    const kifmm__tree *t = c->tree;
    const int32_t ni = t->ioff[l] - t->ioff[l - 1], base = t->ioff[l - 1];
    const int32_t *co = c->fft.co, *cj = c->fft.cj;
    int32_t *loc = c->fft.loc, s1, e;
    *nneed = 0;
    for (s1 = s0; s1 < ni; s1++) {
        const int32_t g = base + s1;
        int32_t add = 0;
        if (!kept && (s1 - s0 + 1) * KIFMM__FSD > c->fft.slots) break;
        if (!KIFMM__F(__fft_wanted)(t, l, s1)) continue; /* no child has a V list */
        for (e = co[g]; e < co[g + 1]; e++) add += loc[cj[e]] < 0;
        if (s1 > s0 && (*nneed + add) * KIFMM__FSD > c->fft.slots) break;
        for (e = co[g]; e < co[g + 1]; e++) {
            if (loc[cj[e]] < 0) {
                loc[cj[e]] = *nneed;
                c->fft.need[(*nneed)++] = cj[e];
            }
            c->fft.cjl[e - co[base + s0]] = loc[cj[e]];
        }
    }
    return s1;
}

/* The spectra of the slab's nneed source parents (the 8 children of each,
 * ue: the level's first upward density of vector r): their lattice
 * densities (conv) transformed into the spectra buffer, slot b at value b F
 * 16 of every chunk; sch[9 b] lists the children that have sources. */
KIFMM__FN void KIFMM__F(__fft_forward)(const KIFMM_NAME *c, int l, const KIFMM__F(__ops) *o,
                                       const KIFMM__R *ue, int32_t nneed)
{
    const kifmm__tree *t = c->tree;
    const kifmm__fft *pl = KIFMM__F(__ft)(c, l);
    const int ne = KIFMM__F(__sf)(c, l)->ne, nc = KIFMM__F(__sf)(c, l)->nc;
    const size_t cstride = (size_t)c->fft.slots * KIFMM__FFT_F * 16;
    const size_t woff = KIFMM__FFT_KBN + KIFMM__FFT_OUTN(c);
    /* each b writes its own slot and its own sch entry */
    KIFMM__OMP(parallel for schedule(static) num_threads(c->opts.nthreads))
    for (int32_t b = 0; b < nneed; b++) {
        const int32_t ch0 = t->loff[l] + 8 * c->fft.need[b];
        const KIFMM__F(__sp) s = KIFMM__F(__sp_at)(c->fft.specf, c->fft.specd, (size_t)b * KIFMM__FFT_PN);
        const KIFMM__F(__sp) work = KIFMM__F(__fbuf)(c, woff);
        double *m = KIFMM__F(__mbuf)(c);
        unsigned char *h = c->fft.sch + 9 * (size_t)b * KIFMM__FSD;
        int q, j;
        for (h[0] = 0, q = 0; q < 8; q++)
            if (kifmm__has_src(t, ch0 + q)) h[1 + h[0]++] = (unsigned char)q;
        for (j = 1; j < KIFMM__FSD; j++) memcpy(h + 9 * j, h, 9);
        KIFMM__F(__conv8)(o->conv, nc, ne, ue + (size_t)8 * c->fft.need[b] * ne, m);
        for (j = 0; j < KIFMM__FSD; j++) { /* (a complex lattice: both components) */
            const size_t sj = (size_t)j * KIFMM__FFT_F * 16;
            if (s.f) kifmm__fft_forward8f(pl, m, KIFMM__SD, j, s.f + sj, cstride, work.f);
            else kifmm__fft_forward8d(pl, m, KIFMM__SD, j, s.d + sj, cstride, work.d);
        }
    }
}

/* Products and inverses of the slab [s0, s1) when the blocks are not kept:
 * tasks over chunks, all target parents of the slab in each, so that each
 * chunk's blocks are built once, into fout; then one task per target parent
 * for the inverse transforms. */
KIFMM__FN void KIFMM__F(__fft_by_chunks)(const KIFMM_NAME *c, int l, const KIFMM__F(__ops) *o,
                                         const int *tv, int32_t s0, int32_t s1, KIFMM__R *chk)
{
    const kifmm__tree *t = c->tree;
    const int32_t base = t->ioff[l - 1], *co = c->fft.co, *cjl = c->fft.cjl;
    const size_t fcs = (size_t)c->fft.slots * KIFMM__FFT_F * 16; /* fout chunk */
    /* chunk ch writes its own part of fout (its thread's blocks) */
    KIFMM__OMP(parallel for schedule(dynamic, 2) num_threads(c->opts.nthreads))
    for (int ch = 0; ch < KIFMM__F(__ft)(c, l)->nchunk; ch++) {
        const KIFMM__F(__sp) kb = KIFMM__F(__fbuf)(c, 0);
        int32_t P;
        if (kb.f) kifmm__fft_blocksf(KIFMM__F(__ft)(c, l), o->khat, o->ktab, tv, KIFMM__FSD, ch, kb.f);
        else kifmm__fft_blocksd(KIFMM__F(__ft)(c, l), o->khat, o->ktab, tv, KIFMM__FSD, ch, kb.d);
        for (P = s0; P < s1; P++) {
            /* (slots are set only for wanted target parents) */
            const int32_t g = base + P;
            const int32_t nx =
                P + 1 < s1 && KIFMM__F(__fft_wanted)(t, l, P + 1) ? co[g + 2] - co[g + 1] : 0;
            if (!KIFMM__F(__fft_wanted)(t, l, P)) continue;
            KIFMM__F(__fft_products)(c, ch, cjl + (co[g] - co[base + s0]), co[g + 1] - co[g],
                                     c->fft.cc + co[g], kb,
                                     KIFMM__F(__sp_at)(c->fft.foutf, c->fft.foutd,
                                                       ch * fcs + (size_t)(P - s0) * KIFMM__FFT_PN),
                                     ch, cjl + (co[g + 1] - co[base + s0]), nx);
        }
    }
    /* target parent b adds to the check vectors of its own children */
    KIFMM__OMP(parallel for schedule(dynamic, 4) num_threads(c->opts.nthreads))
    for (int32_t b = s0; b < s1; b++)
        if (KIFMM__F(__fft_wanted)(t, l, b))
            KIFMM__F(__fft_finish)(c, l, b,
                                   KIFMM__F(__sp_at)(c->fft.foutf, c->fft.foutd,
                                                     (size_t)(b - s0) * KIFMM__FFT_PN),
                                   fcs, chk);
}

/* The products of the nb target parents from p0 on, at every chunk, with
 * the blocks kept, into the thread's buffer (chunks ocs values apart). */
KIFMM__FN void KIFMM__F(__fft_task)(const KIFMM_NAME *c, int l, const KIFMM__F(__ops) *o,
                                    int32_t s0, int32_t p0, int32_t nb, size_t ocs)
{
    const kifmm__tree *t = c->tree;
    const int32_t base = t->ioff[l - 1], *co = c->fft.co, *cjl = c->fft.cjl;
    const int nchunk = KIFMM__F(__ft)(c, l)->nchunk;
    int ch;
    int32_t P;
    for (ch = 0; ch < nchunk; ch++) {
        const KIFMM__F(__sp) kc = KIFMM__F(__sp_at)(o->kbf, o->kbd, KIFMM__FFT_KBN * (size_t)ch);
        for (P = 0; P < nb; P++) {
            /* prefetched: the next target parent's sources, or after the
             * last the first's at the next chunk */
            const int32_t g = base + p0 + P, last = P + 1 == nb;
            const int32_t gx = last ? base + p0 : g + 1;
            const int chx = last ? ch + 1 : ch;
            const int nx = chx < nchunk && KIFMM__F(__fft_wanted)(t, l, gx - base)
                               ? co[gx + 1] - co[gx]
                               : 0;
            if (!KIFMM__F(__fft_wanted)(t, l, p0 + P)) continue;
            KIFMM__F(__fft_products)(c, ch, cjl + (co[g] - co[base + s0]), co[g + 1] - co[g],
                                     c->fft.cc + co[g], kc,
                                     KIFMM__F(__fbuf)(c, KIFMM__FFT_KBN + (size_t)ch * ocs +
                                                             (size_t)P * KIFMM__FFT_PN),
                                     chx, cjl + (co[gx] - co[base + s0]), nx);
        }
    }
}

/* Products and inverses of the slab [s0, s1) with the blocks kept: tasks of
 * up to ftb target parents (but at least 4 tasks per thread), each with its
 * products in its thread's buffer. */
KIFMM__FN void KIFMM__F(__fft_by_parents)(const KIFMM_NAME *c, int l, const KIFMM__F(__ops) *o,
                                          int32_t s0, int32_t s1, KIFMM__R *chk)
{
    const kifmm__tree *t = c->tree;
    int32_t tb = (s1 - s0) / (4 * c->opts.nthreads), nblk;
    size_t ocs;
    tb = tb < 1 ? 1 : tb > c->fft.ftb ? c->fft.ftb : tb;
    ocs = (size_t)tb * KIFMM__FFT_PN;
    nblk = (s1 - s0 + tb - 1) / tb;
    /* task blk adds to the check vectors of its own target parents' children */
    KIFMM__OMP(parallel for schedule(dynamic, 1) num_threads(c->opts.nthreads))
    for (int32_t blk = 0; blk < nblk; blk++) {
        const int32_t p0 = s0 + blk * tb, nb = s1 - p0 < tb ? s1 - p0 : tb;
        int32_t P;
        KIFMM__F(__fft_task)(c, l, o, s0, p0, nb, ocs);
        for (P = 0; P < nb; P++)
            if (KIFMM__F(__fft_wanted)(t, l, p0 + P))
                KIFMM__F(__fft_finish)(c, l, p0 + P,
                                       KIFMM__F(__fbuf)(c, KIFMM__FFT_KBN + (size_t)P * KIFMM__FFT_PN),
                                       ocs, chk);
    }
}

/* M2L into level l by FFT (see kifmm__fft): the level's multipoles
 * (children of the internal boxes of level l - 1) moved to the check
 * surface's lattice (conv) and transformed, products per target parent over
 * its internal colleagues, inverse transforms added to the downward check
 * vectors of the boxes with a V list, before the downward solve. Target
 * parents are processed in slabs whose source spectra fit the spectra buffer;
 * within a slab each target parent belongs to one task, so no output is
 * written by two threads. */
KIFMM__FN void KIFMM__F(__m2l_fft)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs,
                                   int l)
{
    const kifmm__tree *t = c->tree;
    const KIFMM__F(__ops) *o = KIFMM__F(__ops_at)(c, l);
    const int32_t ni = t->ioff[l] - t->ioff[l - 1];
    const int kept = o->kbf || o->kbd;
    const size_t per = KIFMM__F(__eo)(c, 0, t->nbox), nc = (size_t)KIFMM__F(__sf)(c, l)->nc;
    int32_t s0, s1, e, nneed;
    int tv[27 * 64], r;
    kifmm__fft_tvmap(tv);
    for (s0 = 0; s0 < ni; s0 = s1) {
        s1 = KIFMM__F(__fft_slab)(c, l, kept, s0, &nneed);
        for (r = 0; r < nrhs; r++) {
            KIFMM__R *chk = w->chk + (size_t)r * KIFMM__LVL(c, l) * nc;
            KIFMM__F(__fft_forward)(c, l, o, w->ue + r * per + KIFMM__F(__eo)(c, 0, t->loff[l]), nneed);
            if (kept) KIFMM__F(__fft_by_parents)(c, l, o, s0, s1, chk);
            else KIFMM__F(__fft_by_chunks)(c, l, o, tv, s0, s1, chk);
        }
        for (e = 0; e < nneed; e++) c->fft.loc[c->fft.need[e]] = -1;
    }
}
#endif

/* out += the field, at nt targets, of the sources of image s of box a
 * (vector r's outputs from out + r old on). */
KIFMM__FN void KIFMM__F(__from_sources)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs,
                                        int32_t a, int s, const KIFMM__R *tx,
                                        const KIFMM__R *ty, const KIFMM__R *tz, int64_t nt,
                                        KIFMM__R *out, size_t old)
{
    const kifmm__tree *t = c->tree;
    const int64_t s0 = t->s0[a];
    size_t ld;
    const KIFMM__R *xs = KIFMM__F(__image)(c, a, s, &ld);
#if defined(KIFMM_MPI)
    if (c->px.cum) {
        KIFMM__F(__p2p_roles)(c, w, KIFMM__F(__p2p_qt), KIFMM__F(__p2p_st), tx, ty, tz, nt, xs, ld, s0,
                              t->s1[a] - s0, nrhs, 1.0, out, old);
        return;
    }
#endif
    KIFMM__F(__p2p_qt)(c->opts.kernel_param, tx, ty, tz, nt, xs, xs + ld, xs + 2 * ld,
                       w->qs + s0 * KIFMM__QD, t->s1[a] - s0, nrhs, (size_t)t->ns * KIFMM__QD,
                       1.0, out, old);
}


/* Box b with fewer targets than check points: its X sources go straight to
 * its targets (only this task writes them; the leaves' pass runs after the
 * downward pass), and it does not refit for them (dsrc). */
KIFMM__FN void KIFMM__F(__x_direct)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs,
                                    int32_t b)
{
    const kifmm__tree *t = c->tree;
    const int64_t tb0 = t->t0[b], ntb = t->t1[b] - tb0;
    KIFMM__R *o = w->outs ? w->outs + tb0 * KIFMM__TD : KIFMM__F(__lbuf)(w, nrhs, ntb);
    const size_t old = w->outs ? (size_t)t->nt * KIFMM__TD : (size_t)ntb * KIFMM__TD;
    int32_t e;
    for (e = t->xo[b]; e < t->xo[b + 1]; e++)
        KIFMM__F(__from_sources)(c, w, nrhs, t->x[e], KIFMM__SH(t->xs, e), c->pts.trg + tb0,
                                 c->pts.trg + t->nt + tb0, c->pts.trg + 2 * t->nt + tb0, ntb, o,
                                 old);
    if (!w->outs) KIFMM__F(__put)(c, w, nrhs, tb0, ntb, o, old);
}

/* The check potentials of box b (of level l) that come from points or far
 * surfaces, added to chk (vector stride cst): L2L from an ancestor above
 * the parent (a = dsrc of the parent), by direct evaluation of its
 * equivalent density, and P2L from the sources of its X list. In the frame
 * of box b (float instances; see __frame). */
KIFMM__FN void KIFMM__F(__p2l_box)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs,
                                   int l, int32_t b, double scale, KIFMM__R *chk, size_t cst)
{
    const kifmm__tree *t = c->tree;
    const double zero[3] = {0.0, 0.0, 0.0};
    const int32_t a = l >= 1 ? c->dsrc[t->parent[b]] : -1;
    const kifmm__surf *sf = KIFMM__F(__sf)(c, l);
    const int nsc = sf->nsc;
    KIFMM__R *pc = KIFMM__F(__scratch)(c), *pe = pc + 3 * (size_t)KIFMM__F(__smax)(c)->nsm;
    double ctr[3], half;
    int32_t e;
    kifmm__box_center(t, b, ctr, &half);
    KIFMM__F(__place)(sf->unit_c, nsc, KIFMM__FLOAT ? zero : ctr, KIFMM__F(__rin)(c->pl, sf, half), pc);
    if (a >= 0 && a != t->parent[b]) {
        const kifmm__surf *sa = KIFMM__F(__sf)(c, t->lev[a]);
        const int nd = sa->nse + sa->nsa;
        double ac[3], ah;
        kifmm__box_center(t, a, ac, &ah);
        if (KIFMM__FLOAT) kifmm__sub3(ac, ctr, ac);
        KIFMM__F(__place_down)(sa, ac, sa->ao * ah, ah, pe);
        KIFMM__F(__p2p_sc)(c->opts.kernel_param, pc, pc + nsc, pc + 2 * nsc, nsc, pe, pe + nd,
                           pe + 2 * nd, w->de + KIFMM__F(__eo)(c, 1, a), nd, nrhs,
                           KIFMM__F(__eo)(c, 1, t->nbox), scale, chk, cst);
    }
    for (e = t->xo[b]; e < t->xo[b + 1] && t->t1[b] - t->t0[b] >= nsc; e++) {
        const int32_t xb = t->x[e];
        const int64_t s0 = t->s0[xb];
        double fc[3], cs[3];
        size_t ld = (size_t)t->ns;
        const KIFMM__R *xs;
        int sh[3], d;
        /* image s of the X box: the box's frame (float) or its check surface
         * (double) moved by -s instead */
        kifmm__shift_of(KIFMM__SH(t->xs, e), sh);
        for (d = 0; d < 3; d++) fc[d] = cs[d] = ctr[d] - sh[d] * t->cell;
        xs = KIFMM__F(__frame)(c->pts.src, &ld, s0, t->s1[xb] - s0, fc, KIFMM__F(__framebuf)(c));
        if (!KIFMM__FLOAT && t->periodic)
            KIFMM__F(__place)(sf->unit_c, nsc, cs, KIFMM__F(__rin)(c->pl, sf, half), pc);
#if defined(KIFMM_MPI)
        if (c->px.cum) {
            KIFMM__F(__p2p_roles)(c, w, KIFMM__F(__p2p_qc), KIFMM__F(__p2p_sc), pc, pc + nsc, pc + 2 * nsc,
                                  nsc, xs, ld, s0, t->s1[xb] - s0, nrhs, scale, chk, cst);
            continue;
        }
#endif
        KIFMM__F(__p2p_qc)(c->opts.kernel_param, pc, pc + nsc, pc + 2 * nsc, nsc, xs, xs + ld,
                           xs + 2 * ld, w->qs + s0 * KIFMM__QD, t->s1[xb] - s0, nrhs,
                           (size_t)t->ns * KIFMM__QD, scale, chk, cst);
    }
}

/* The M2L into level l and the downward solve, after L2L and P2L: the FFT
 * adds potentials on the check surface itself to chk before the two solve
 * steps; the dense M2L adds its results between them (its matrices include
 * the first step). Timed as M2L and L2L (the solve). */
KIFMM__FN void KIFMM__F(__m2l_solve)(KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs, int l)
{
    const double t0 = kifmm__now();
    double t1, t2;
#if KIFMM__FFT
    t1 = t0;
    if (c->tree->m2lo[l + 1] > c->tree->m2lo[l]) KIFMM__F(__m2l_fft)(c, w, nrhs, l);
    t2 = kifmm__now();
    KIFMM__F(__solve)(c, w, nrhs, l, 0);
#else
    KIFMM__F(__solve_step)(c, w, nrhs, l, 0, 0);
    t1 = kifmm__now();
    KIFMM__F(__m2l_level)(c, w, nrhs, l); /* into the first step's result */
    t2 = kifmm__now();
    KIFMM__F(__solve_step)(c, w, nrhs, l, 0, 1);
#endif
    c->stats.t_m2l += t2 - t1;
    c->stats.t_l2l += (t1 - t0) + (kifmm__now() - t2);
}

/* A periodic tree: the far images' field at the check surfaces of the
 * boxes of level l = lat.zl, added (__far_root): the boxes' upward
 * densities' potentials at U (each block of U's points its own rows), Z,
 * then D's field at the check surfaces of the boxes that split (each box
 * its own). A leaf's points give their potentials at U themselves, and its
 * targets take D's field directly (in __leaf), not through expansions of
 * order p at both ends, whose error at a leaf's corners (the whole cell's,
 * when the root is a leaf) was most of the error of a few charges: eight,
 * three on a face, at p = 6 potential 2.0e-5 and gradient 9.4e-5. */
KIFMM__FN void KIFMM__F(__far_apply)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs,
                                     int l)
{
    enum { BLK = 32 };
    const kifmm__tree *t = c->tree;
    const int nu = c->far->nzu, mu = nu * KIFMM__SD; /* D shares U's points */
    const kifmm__surf *sf = KIFMM__F(__sf)(c, l);
    const int nse = sf->nse, nsc = sf->nsc;
    const size_t per = KIFMM__F(__eo)(c, 0, t->nbox), cst = (size_t)KIFMM__LVL(c, l) * sf->nc;
    const double scale = KIFMM__F(__level_scale)(c, l);
    const KIFMM__R *pu = c->far->zp;
    const int ku = c->far->zku, kd = c->far->zkd;
    KIFMM__R *phi = w->lat, *psi = phi + (size_t)nrhs * mu, *t1 = psi + (size_t)nrhs * mu;
    KIFMM__R *t2 = t1 + (size_t)nrhs * ku;
    double c0[3], h0;
    kifmm__box_center(t, 0, c0, &h0);
    memset(phi, 0, (size_t)nrhs * mu * sizeof(KIFMM__R));
    KIFMM__OMP(parallel for schedule(dynamic, 1) num_threads(c->opts.nthreads))
    for (int i0 = 0; i0 < nu; i0 += BLK) {
        const int n = nu - i0 < BLK ? nu - i0 : BLK;
        KIFMM__R *pe = KIFMM__F(__scratch)(c);
        double cb[3], hb;
        int32_t b;
        for (b = t->loff[l]; b < t->loff[l + 1]; b++) {
            const int img = t->alias && t->alias[b] >= 0; /* an image above the cell */
            if (!kifmm__has_src(t, b)) continue;
            if (t->child[b] < 0 && !img) { /* a leaf's points themselves */
                const int64_t s0 = t->s0[b], ns = t->s1[b] - s0;
                size_t ld = (size_t)t->ns;
                double f0[3] = {0.0, 0.0, 0.0};
                const KIFMM__R *xs = KIFMM__F(__frame)(c->pts.src, &ld, s0, ns, f0, KIFMM__F(__framebuf)(c));
                KIFMM__F(__p2p_qc)(c->opts.kernel_param, c->lat.zt + i0, c->lat.zt + nu + i0,
                                   c->lat.zt + 2 * nu + i0, n, xs, xs + ld, xs + 2 * ld,
                                   w->qs + s0 * KIFMM__QD, ns, nrhs, (size_t)t->ns * KIFMM__QD, 1.0,
                                   phi + (size_t)i0 * KIFMM__SD, (size_t)mu);
                continue;
            }
            kifmm__box_center(t, b, cb, &hb);
            kifmm__sub3(cb, c0, cb);
            KIFMM__F(__place)(sf->unit_e, nse, cb, KIFMM__F(__rin)(c->pl, sf, hb), pe);
            KIFMM__F(__p2p_sc)(c->opts.kernel_param, pu + i0, pu + nu + i0, pu + 2 * nu + i0, n, pe,
                               pe + nse, pe + 2 * nse, w->ue + KIFMM__F(__eo)(c, 0, b), nse, nrhs, per, 1.0,
                               phi + (size_t)i0 * KIFMM__SD, (size_t)mu);
        }
    }
    KIFMM__F(__gemm)(ku, nrhs, mu, c->far->zu, ku, phi, mu, 0, t1, ku);
    KIFMM__F(__gemm)(kd, nrhs, ku, c->far->zm, kd, t1, ku, 0, t2, kd);
    KIFMM__F(__gemm)(mu, nrhs, kd, c->far->zd, mu, t2, kd, 0, psi, mu);
    KIFMM__OMP(parallel for schedule(dynamic, 1) num_threads(c->opts.nthreads))
    for (int32_t b = t->loff[l]; b < t->loff[l + 1]; b++) {
        KIFMM__R *pc = KIFMM__F(__scratch)(c);
        double cb[3], hb;
        /* a leaf's targets take D's field directly (in __leaf) */
        if (t->t1[b] == t->t0[b] || t->child[b] < 0) continue;
        kifmm__box_center(t, b, cb, &hb);
        kifmm__sub3(cb, c0, cb);
        KIFMM__F(__place)(sf->unit_c, nsc, cb, KIFMM__F(__rin)(c->pl, sf, hb), pc);
        KIFMM__F(__p2p_sc)(c->opts.kernel_param, pc, pc + nsc, pc + 2 * nsc, nsc, pu, pu + nu, pu + 2 * nu,
                           psi, nu, nrhs, (size_t)mu, scale, w->chk + (size_t)(b - t->loff[l]) * sf->nc, cst);
    }
}

/* Downward pass at level l: L2L from the parents, X sources and far
 * ancestors per box (__x_direct, __p2l_box; a box served by an ancestor's
 * expansion does not refit), then the M2L and the solve. Timed as L2L (with
 * the solve), P2L and M2L. */
KIFMM__FN void KIFMM__F(__downward)(KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs, int l)
{
    const kifmm__tree *t = c->tree;
    const kifmm__surf *sf = KIFMM__F(__sf)(c, l);
    const size_t cst = (size_t)KIFMM__LVL(c, l) * sf->nc;
    const double scale = KIFMM__F(__level_scale)(c, l), t0 = kifmm__now();
    double t1;
    if (l > kifmm__lmin(t)) KIFMM__F(__family_level)(c, w, nrhs, l - 1, 1); /* L2L */
    else memset(w->chk, 0, (size_t)nrhs * cst * sizeof(KIFMM__R));
    if (c->far && c->far->zu && l == c->lat.zl) KIFMM__F(__far_apply)(c, w, nrhs, l); /* the far images */
    t1 = kifmm__now();
    /* box b writes its own check vectors and its own targets' outputs */
    KIFMM__OMP(parallel for schedule(dynamic, 8) num_threads(c->opts.nthreads))
    for (int32_t b = t->loff[l]; b < t->loff[l + 1]; b++) {
        KIFMM__R *chk = w->chk + (size_t)(b - t->loff[l]) * sf->nc;
        int r;
        if (t->t1[b] - t->t0[b] < sf->nsc && t->xo[b + 1] > t->xo[b])
            KIFMM__F(__x_direct)(c, w, nrhs, b);
        if (c->dsrc[b] == b) {
            KIFMM__F(__p2l_box)(c, w, nrhs, l, b, scale, chk, cst);
            continue;
        }
        for (r = 0; r < nrhs; r++) memset(chk + r * cst, 0, (size_t)sf->nc * sizeof(KIFMM__R));
    }
    c->stats.t_l2l += t1 - t0;
    c->stats.t_p2l += kifmm__now() - t1;
    KIFMM__F(__m2l_solve)(c, w, nrhs, l);
}

// >>leaves

/* out += the field, at nt targets (coordinates in the frame centred at fc,
 * see __frame), of densities on the surface of image s of box a: its
 * inner one, the upward density (a vector: __eo(c, 0, nbox) values), or where inner is
 * 0 its outer one and its anchors, the downward (__eo(c, 1, nbox));
 * pe holds the placed surface;
 * vector r's outputs from out + r old on. */
KIFMM__FN void KIFMM__F(__from_surface)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs,
                                        int32_t a, int s, int inner, const KIFMM__R *dens,
                                        const double *fc, const KIFMM__R *tx,
                                        const KIFMM__R *ty, const KIFMM__R *tz, int64_t nt,
                                        KIFMM__R *pe, KIFMM__R *out, size_t old)
{
    const kifmm__surf *sf = KIFMM__F(__sf)(c, c->tree->lev[a]);
    const int n = inner ? sf->nse : sf->nse + sf->nsa;
    double ctr[3], half;
    int sh[3], d;
    kifmm__box_center(c->tree, a, ctr, &half);
    kifmm__shift_of(s, sh);
    for (d = 0; d < 3; d++) ctr[d] += sh[d] * c->tree->cell - fc[d]; /* in the targets' frame */
    if (inner) KIFMM__F(__place)(sf->unit_e, n, ctr, KIFMM__F(__rin)(c->pl, sf, half), pe); /* M2P */
    else KIFMM__F(__place_down)(sf, ctr, sf->ao * half, half, pe); /* L2P, anchors last */
    KIFMM__F(__p2p_st)(c->opts.kernel_param, tx, ty, tz, nt, pe, pe + n, pe + 2 * n, dens, n, nrhs,
                       KIFMM__F(__eo)(c, !inner, c->tree->nbox), 1.0, out, old);
    (void)w;
}

#if KIFMM__MUTUAL
/* Both directions between the points of leaf a and those of image s of
 * leaf b (the sources are the targets; a != b), outputs at oa and ob
 * (vector stride old), through the kernel's mutual hooks. */
KIFMM__FN void KIFMM__F(__p2p_pair)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs,
                                    int32_t a, int32_t b, int s, KIFMM__R *oa, KIFMM__R *ob,
                                    size_t old)
{
    const kifmm__tree *t = c->tree;
    const size_t n = (size_t)t->ns, qld = n * KIFMM__QD;
    const int64_t a0 = t->s0[a], na = t->s1[a] - a0, b0 = t->s0[b], nb = t->s1[b] - b0;
    const KIFMM__R *x = c->pts.src + a0, *qa = w->qs + a0 * KIFMM__QD, *qb = w->qs + b0 * KIFMM__QD;
    const double *prm = c->opts.kernel_param;
    size_t lb;
    const KIFMM__R *y = KIFMM__F(__image)(c, b, s, &lb);
    int r;
    if (nrhs == 1) {
        KIFMM__HOOK(QT, p2ps)(prm, x, x + n, x + 2 * n, qa, na, y, y + lb, y + 2 * lb, qb, nb,
                              (KIFMM__R)1, oa, ob);
        return;
    }
#if KIFMM__HAS_QT & KIFMM__B_P2PSN
    (void)r;
    KIFMM__HOOK(QT, p2psn)(prm, x, x + n, x + 2 * n, qa, na, y, y + lb, y + 2 * lb, qb, nb, nrhs,
                           qld, (KIFMM__R)1, oa, ob, old);
#else
    for (r = 0; r < nrhs; r++)
        KIFMM__HOOK(QT, p2ps)(prm, x, x + n, x + 2 * n, qa + r * qld, na, y, y + lb, y + 2 * lb,
                              qb + r * qld, nb, (KIFMM__R)1, oa + r * old, ob + r * old);
#endif
}
#endif

/* The U list of leaf b (targets tx.. from sorted position t0, ntb of them,
 * outputs at out, vector stride old): P2P from each U leaf. With the mutual
 * near field (lo < hi: the points [lo, hi) of the leaf's chunk), a U leaf of
 * the same chunk is computed once for both leaves, by the one first in
 * Morton order, and skipped by the other; its outputs go to ob + (its first
 * target - base) TD. */
KIFMM__FN void KIFMM__F(__p2p_u)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs,
                                 int32_t b, int64_t lo, int64_t hi, KIFMM__R *ob, int64_t base,
                                 size_t old)
{
    const kifmm__tree *t = c->tree;
    const int64_t t0 = t->t0[b], ntb = t->t1[b] - t0;
    const KIFMM__R *tx = c->pts.trg + t0, *ty = c->pts.trg + t->nt + t0;
    const KIFMM__R *tz = c->pts.trg + 2 * t->nt + t0;
    KIFMM__R *out = ob + (t0 - base) * KIFMM__TD;
    int32_t e;
    for (e = t->uo[b]; e < t->uo[b + 1]; e++) {
        const int32_t a = t->u[e];
        const int s = KIFMM__SH(t->us, e);
#if KIFMM__MUTUAL
        const int64_t ta = t->t0[a];
        if (a != b && ta >= lo && ta < hi) {
            /* sources are the targets: s0 = t0, src = trg; a's entry for b
             * has the opposite image */
            if (ta > t0)
                KIFMM__F(__p2p_pair)(c, w, nrhs, b, a, s, out, ob + (ta - base) * KIFMM__TD, old);
            continue;
        }
#endif
        KIFMM__F(__from_sources)(c, w, nrhs, a, s, tx, ty, tz, ntb, out, old);
    }
    (void)lo;
    (void)hi;
}

/* Leaf i of t->leaves: L2P, M2P over W (direct when the box holds fewer
 * sources than its surface has points), P2P over U (__p2p_u). The outputs
 * of sorted target j go to ob + (j - base) TD, vector r's old further on.
 * tm[0..2] += the time of the three. */
KIFMM__FN void KIFMM__F(__leaf)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs,
                                int32_t i, int64_t lo, int64_t hi, double *tm, KIFMM__R *ob,
                                int64_t base, size_t old)
{
    const kifmm__tree *t = c->tree;
    const int32_t b = t->leaves[i];
    const int64_t t0 = t->t0[b], ntb = t->t1[b] - t0;
    const KIFMM__R *tx = c->pts.trg + t0, *ty = c->pts.trg + t->nt + t0;
    const KIFMM__R *tz = c->pts.trg + 2 * t->nt + t0, *xf = NULL;
    KIFMM__R *out = ob + (t0 - base) * KIFMM__TD, *pe = KIFMM__F(__scratch)(c);
    double c0 = kifmm__now(), c1, c2, fc[3] = {0.0, 0.0, 0.0}, half;
    size_t ld = (size_t)t->nt;
    int32_t e;
    if (c->far && c->far->zu && t->lev[b] == c->lat.zl) { /* before xf: it takes the frame buffer */
        const KIFMM__R *xt;
        double f0[3] = {0.0, 0.0, 0.0};
        const int nu = c->far->nzu;
        const KIFMM__R *psi = w->lat + (size_t)nrhs * nu * KIFMM__SD;
        size_t l2 = (size_t)t->nt;
        xt = KIFMM__F(__frame)(c->pts.trg, &l2, t0, ntb, f0, KIFMM__F(__framebuf)(c));
        KIFMM__F(__p2p_st)(c->opts.kernel_param, xt, xt + l2, xt + 2 * l2, ntb, c->lat.zt,
                           c->lat.zt + nu, c->lat.zt + 2 * nu, psi, nu, nrhs, (size_t)nu * KIFMM__SD, 1.0,
                           out, old);
    }
    if (c->dsrc[b] >= 0 || t->wo[b + 1] > t->wo[b]) {
        /* the targets in the leaf's frame, for the surfaces */
        kifmm__box_center(t, b, fc, &half);
        xf = KIFMM__F(__frame)(c->pts.trg, &ld, t0, ntb, fc, KIFMM__F(__framebuf)(c));
    }
    if (c->dsrc[b] >= 0)
        KIFMM__F(__from_surface)(c, w, nrhs, c->dsrc[b], KIFMM__NOSHIFT, 0,
                                 w->de + KIFMM__F(__eo)(c, 1, c->dsrc[b]), fc, xf, xf + ld,
                                 xf + 2 * ld, ntb, pe, out, old);
    c1 = kifmm__now();
    for (e = t->wo[b]; e < t->wo[b + 1]; e++) {
        const int32_t a = t->w[e];
        const int s = KIFMM__SH(t->ws, e);
        if (t->s1[a] - t->s0[a] <= KIFMM__F(__sf)(c, t->lev[a])->nse)
            KIFMM__F(__from_sources)(c, w, nrhs, a, s, tx, ty, tz, ntb, out, old);
        else
            KIFMM__F(__from_surface)(c, w, nrhs, a, s, 1, w->ue + KIFMM__F(__eo)(c, 0, a), fc, xf,
                                     xf + ld, xf + 2 * ld, ntb, pe, out, old);
    }
    c2 = kifmm__now();
    KIFMM__F(__p2p_u)(c, w, nrhs, b, lo, hi, ob, base, old);
    tm[0] += c1 - c0;
    tm[1] += c2 - c1;
    tm[2] += kifmm__now() - c2;
}

/* The leaves of one chunk of the mutual near field (leaves i0 .. i1 - 1,
 * whose targets are the contiguous [lo, hi)), outputs summed in the
 * thread's buffer and added to the caller's, or into outs. */
KIFMM__FN void KIFMM__F(__leaf_chunk)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs,
                                      int32_t i0, int32_t i1, double *tm)
{
    const kifmm__tree *t = c->tree;
    const int64_t lo = t->t0[t->leaves[i0]];
    const int64_t hi = i1 < t->nleaves ? t->t0[t->leaves[i1]] : t->nt;
    const size_t old = (size_t)(hi - lo) * KIFMM__TD;
    int32_t j;
    if (w->outs) {
        for (j = i0; j < i1; j++)
            KIFMM__F(__leaf)(c, w, nrhs, j, lo, hi, tm, w->outs, 0, (size_t)t->nt * KIFMM__TD);
    } else {
        KIFMM__R *ob = KIFMM__F(__lbuf)(w, nrhs, hi - lo);
        double p0;
        for (j = i0; j < i1; j++) KIFMM__F(__leaf)(c, w, nrhs, j, lo, hi, tm, ob, lo, old);
        p0 = kifmm__now();
        KIFMM__F(__put)(c, w, nrhs, lo, hi - lo, ob, old);
        tm[2] += kifmm__now() - p0; /* counted as near field */
    }
}

/* One leaf alone (no mutual near field): its outputs in the thread's buffer
 * and added to the caller's, or into outs. */
KIFMM__FN void KIFMM__F(__leaf_alone)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs,
                                      int32_t i, double *tm)
{
    const kifmm__tree *t = c->tree;
    const int64_t t0 = t->t0[t->leaves[i]], n = t->t1[t->leaves[i]] - t0;
    if (w->outs) {
        KIFMM__F(__leaf)(c, w, nrhs, i, 0, 0, tm, w->outs, 0, (size_t)t->nt * KIFMM__TD);
    } else if (n > 0) {
        KIFMM__R *ob = KIFMM__F(__lbuf)(w, nrhs, n);
        double p0;
        KIFMM__F(__leaf)(c, w, nrhs, i, 0, 0, tm, ob, t0, (size_t)n * KIFMM__TD);
        p0 = kifmm__now();
        KIFMM__F(__put)(c, w, nrhs, t0, n, ob, (size_t)n * KIFMM__TD);
        tm[2] += kifmm__now() - p0; /* counted as near field */
    }
}

/* The leaves' passes. With the mutual near field (sources = targets, a
 * kernel with a mutual hook: near.chunk), the leaves go in chunks of
 * consecutive leaves, one chunk per task, so that both leaves of a pair
 * computed once belong to the thread that writes their outputs. */
KIFMM__FN void KIFMM__F(__leaves)(KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs)
{
    const int32_t *ch = c->near.chunk;
    double tl = 0.0, tw = 0.0, tu = 0.0;
    if (ch) {
        /* chunk i writes the outputs of its own leaves */
        KIFMM__OMP(parallel for schedule(dynamic, 1) num_threads(c->opts.nthreads) reduction(+ : tl, tw, tu))
        for (int32_t i = 0; i < c->near.nchunk; i++) {
            double tm[3] = {0.0, 0.0, 0.0};
            if (ch[i] < ch[i + 1]) KIFMM__F(__leaf_chunk)(c, w, nrhs, ch[i], ch[i + 1], tm);
            tl += tm[0];
            tw += tm[1];
            tu += tm[2];
        }
    } else {
        /* leaf i writes its own outputs */
        KIFMM__OMP(parallel for schedule(dynamic, 4) num_threads(c->opts.nthreads) reduction(+ : tl, tw, tu))
        for (int32_t i = 0; i < c->tree->nleaves; i++) {
            double tm[3] = {0.0, 0.0, 0.0};
            KIFMM__F(__leaf_alone)(c, w, nrhs, i, tm);
            tl += tm[0];
            tw += tm[1];
            tu += tm[2];
        }
    }
    c->stats.t_l2p += tl / c->opts.nthreads;
    c->stats.t_m2p += tw / c->opts.nthreads;
    c->stats.t_p2p += tu / c->opts.nthreads;
}

/* Three periodic directions of a scale-invariant kernel: the field of the
 * densities' uniform background, (1 / V) sum_j B(x - y_j) q_j with B the
 * kernel's quadratic (lat.bq), added at the targets. From the densities'
 * moments about the cell's centre (per kind: sum q, sum q y, sum q y y^T),
 * per output P(a) = P0 + P1 . a + a^T P2 a / 2 at a = x - centre. */
/* The moments of vector r's densities about cen, in the cell's width:
 * mo[10 b ..] = sum q_b, sum q_b y (3), sum q_b y y^T (xx, yy, zz, xy, xz,
 * yz) per kind b, y = (point - cen) / width. */
KIFMM__FN void KIFMM__F(__moments)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int r,
                                   const double *cen, double *mo)
{
    static const int pq[6][2] = {{0, 0}, {1, 1}, {2, 2}, {0, 1}, {0, 2}, {1, 2}};
    const int64_t ns = c->tree->ns;
    const double wd = c->tree->width;
    int b, j;
    memset(mo, 0, (size_t)KIFMM__QD * 10 * sizeof(double));
    for (int64_t i = 0; i < ns; i++) {
        const double a[3] = {(c->pts.src[i] - cen[0]) / wd, (c->pts.src[ns + i] - cen[1]) / wd,
                             (c->pts.src[2 * ns + i] - cen[2]) / wd};
        for (b = 0; b < KIFMM__QD; b++) {
            const double q = w->qs[(size_t)r * ns * KIFMM__QD + (size_t)i * KIFMM__QD + b];
            mo[10 * b] += q;
            for (j = 0; j < 3; j++) mo[10 * b + 1 + j] += q * a[j];
            for (j = 0; j < 6; j++) mo[10 * b + 4 + j] += q * a[pq[j][0]] * a[pq[j][1]];
        }
    }
}

KIFMM__FN void KIFMM__F(__background)(const KIFMM_NAME *c, const KIFMM__F(__work) *w, int nrhs)
{
    static const int pq[6][2] = {{0, 0}, {1, 1}, {2, 2}, {0, 1}, {0, 2}, {1, 2}};
    const kifmm__tree *t = c->tree;
    const double wd = t->width;
    const size_t oper = (size_t)t->nt * KIFMM__TD;
    double cen[3];
    int r, d;
    for (d = 0; d < 3; d++) cen[d] = t->lo[d] + 0.5 * t->width;
    for (r = 0; r < nrhs; r++) {
        double mo[KIFMM__QD * 10], P[KIFMM__TD * 10];
        int b, o, j;
        memset(P, 0, sizeof P);
        KIFMM__F(__moments)(c, w, r, cen, mo);
        for (o = 0; o < KIFMM__TD; o++)
            for (b = 0; b < KIFMM__QD; b++) {
                /* B / V in the cell's width: B's terms of degree k in the
                 * offset times width^(k - 3), divided one width at a time
                 * (a cube of the width leaves double's range first) */
                const double *B0 = c->far->bq + 10 * ((size_t)o * KIFMM__QD + b), *m = mo + 10 * b;
                double *p = P + 10 * o, B[10];
                B[0] = B0[0] / wd / wd / wd;
                for (j = 1; j < 4; j++) B[j] = B0[j] / wd / wd;
                for (j = 4; j < 10; j++) B[j] = B0[j] / wd;
                p[0] += m[0] * B[0];
                for (j = 0; j < 3; j++) p[0] -= m[1 + j] * B[1 + j];
                for (j = 0; j < 6; j++) p[0] += (j < 3 ? 0.5 : 1.0) * m[4 + j] * B[4 + j];
                for (j = 0; j < 3; j++) p[1 + j] += m[0] * B[1 + j];
                for (j = 0; j < 6; j++) { /* - H M */
                    p[1 + pq[j][0]] -= B[4 + j] * m[1 + pq[j][1]];
                    if (j >= 3) p[1 + pq[j][1]] -= B[4 + j] * m[1 + pq[j][0]];
                }
                for (j = 0; j < 6; j++) p[4 + j] += m[0] * B[4 + j];
            }
        /* each sorted target i writes its own outputs */
        KIFMM__OMP(parallel for schedule(static) num_threads(c->opts.nthreads))
        for (int64_t i = 0; i < t->nt; i++) {
            const double a[3] = {(c->pts.trg[i] - cen[0]) / wd, (c->pts.trg[t->nt + i] - cen[1]) / wd,
                                 (c->pts.trg[2 * t->nt + i] - cen[2]) / wd};
            KIFMM__R *out = w->outs ? w->outs + r * oper + (size_t)i * KIFMM__TD
                                    : w->dst + r * oper + (size_t)t->tperm[i] * KIFMM__TD;
            int k;
            for (k = 0; k < KIFMM__TD; k++) {
                const double *p = P + 10 * k;
                const double v = p[0] + p[1] * a[0] + p[2] * a[1] + p[3] * a[2] +
                                 0.5 * (p[4] * a[0] * a[0] + p[5] * a[1] * a[1] + p[6] * a[2] * a[2]) +
                                 p[7] * a[0] * a[1] + p[8] * a[0] * a[2] + p[9] * a[1] * a[2];
                out[k] += (KIFMM__R)v;
            }
        }
    }
}

/* The chunks of the mutual near field: the leaves in Morton order cut into
 * KIFMM__PAIR_CHUNKS chunks per thread of about equal estimated work (U
 * pairs counted half, and the surface evaluations). A pair of leaves in two
 * chunks is computed by each for its own targets, so fewer, larger chunks
 * compute fewer pairs twice; several per thread keep the threads balanced.
 * One thread: one chunk. */
#ifndef KIFMM__PAIR_CHUNKS
#define KIFMM__PAIR_CHUNKS 4
#endif
KIFMM__FN int KIFMM__F(__pair_plan)(KIFMM_NAME *c)
{
    const kifmm__tree *t = c->tree;
    int32_t nk = c->opts.nthreads > 1 ? KIFMM__PAIR_CHUNKS * c->opts.nthreads : 1, i, k = 0;
    double total = 0.0, acc = 0.0;
    int pass;
    if (nk > t->nleaves) nk = t->nleaves;
    if (nk < 1) return KIFMM_SUCCESS;
    c->near.chunk = (int32_t *)kifmm__alloc((size_t)nk + 1, sizeof(int32_t));
    if (!c->near.chunk) return KIFMM_ERR_NOMEM;
    for (pass = 0; pass < 2; pass++) {
        for (i = 0; i < t->nleaves; i++) {
            int32_t b = t->leaves[i], e;
            double wk = (double)c->pl->surf.nse * (1 + t->wo[b + 1] - t->wo[b]);
            for (e = t->uo[b]; e < t->uo[b + 1]; e++)
                wk += 0.5 * (double)(t->s1[t->u[e]] - t->s0[t->u[e]]);
            wk *= (double)(t->t1[b] - t->t0[b]);
            if (pass == 0) {
                total += wk;
                continue;
            }
            while (k < nk && acc >= total * k / nk) c->near.chunk[k++] = i;
            acc += wk;
        }
    }
    while (k <= nk) c->near.chunk[k++] = t->nleaves; /* any empty chunks last */
    c->near.nchunk = nk;
    return KIFMM_SUCCESS;
}


// >>create

/* Bytes held by the handle: counted where they were allocated; a plan from
 * plan_create is left out (plan_bytes snapshots the plan's, taken under its
 * lock when the handle was built). */
KIFMM__FN double KIFMM__F(__held)(const KIFMM_NAME *h, double plan_bytes)
{
    return (double)h->held + (h->tshared ? 0.0 : (double)h->tree->held) +
           (double)(h->work.w ? h->work.w->held : 0) + (h->shared ? 0.0 : plan_bytes);
}

/* A far-images entry, freed. */
KIFMM__FN void KIFMM__F(__far_free)(KIFMM__F(__far) *f)
{
    if (!f) return;
    kifmm__free(f->mu);
    kifmm__free(f->bq);
    kifmm__free(f->zu);
    kifmm__free(f->zm);
    kifmm__free(f->zd);
    kifmm__free(f->zp);
    kifmm__free(f->zunit);
    kifmm__free(f);
}

KIFMM__FN void KIFMM__F(__plan_free)(KIFMM__F(_plan) *pl)
{
    int i;
    if (!pl) return;
    for (i = 0; i < pl->ops.n; i++) {
        KIFMM__F(__ops_free)(pl->ops.set[i]);
        kifmm__free(pl->ops.set[i]);
    }
    for (i = 0; i < pl->far.n; i++) KIFMM__F(__far_free)(pl->far.set[i]);
    kifmm__free(pl->ops.set);
    kifmm__free(pl->far.set);
    kifmm__free(pl->surf.unit_e);
    kifmm__free(pl->surf.unit_c);
    kifmm__free(pl->surf.unit_a);
    kifmm__free(pl->cache.dir);
    kifmm__fft_free(&pl->fft);
    kifmm__lock_fini(&pl->lock);
    kifmm__free(pl);
}

/* One user of far-images entry f lets go: freed with its last. Under the
 * plan's lock. */
KIFMM__FN void KIFMM__F(__far_drop)(KIFMM__F(_plan) *pl, KIFMM__F(__far) *f)
{
    int j;
    if (--f->refs > 0) return;
    for (j = 0; j < pl->far.n && pl->far.set[j] != f; j++) {
    }
    if (j < pl->far.n) pl->far.set[j] = pl->far.set[--pl->far.n];
    pl->held -= sizeof *f + f->held;
    KIFMM__F(__far_free)(f);
}

/* A handle lets go of its operator sets, its far images and its plan,
 * freed with their last user. */
KIFMM__FN void KIFMM__F(__plan_release)(KIFMM_NAME *h)
{
    KIFMM__F(_plan) *pl = h->pl;
    int l, last;
    if (!pl) return;
    kifmm__lock_take(&pl->lock);
    for (l = 0; l < KIFMM__D + 2; l++) /* the same set at consecutive levels: one reference */
        if (h->lv[l] && (l == 0 || h->lv[l] != h->lv[l - 1])) KIFMM__F(__ops_drop)(pl, h->lv[l]);
    if (h->far) KIFMM__F(__far_drop)(pl, h->far);
    last = --pl->refs == 0;
    kifmm__lock_give(&pl->lock);
    memset(h->lv, 0, sizeof h->lv);
    h->far = NULL;
    h->pl = NULL;
    if (last) KIFMM__F(__plan_free)(pl);
}

/* The handle's plans of raised orders (>>orders) let go. */
KIFMM__FN void KIFMM__F(__orders_free)(KIFMM_NAME *h)
{
    int q;
    for (q = 0; q <= KIFMM_MAX_ORDER; q++) KIFMM__F(__plan_free)(h->ord.own[q]);
    memset(h->ord.own, 0, sizeof h->ord.own);
    memset(h->ord.pl, 0, sizeof h->ord.pl);
    h->ord.up = 0;
    h->ord.pmax = 0;
}

/* What a handle holds beside its plan: the points, the tree and what is
 * built from them, the workspace. */
KIFMM__FN void KIFMM__F(__points_free)(KIFMM_NAME *h)
{
    kifmm__tree_release(h->tr);
    kifmm__free(h->dsrc);
    kifmm__free(h->work.scratch);
    kifmm__free(h->work.gbuf);
    kifmm__free(h->work.act);
    KIFMM__F(__work_free)(h->work.w);
    kifmm__free(h->fft.co); kifmm__free(h->fft.cj); kifmm__free(h->fft.cc);
    kifmm__free(h->fft.specf); kifmm__free(h->fft.specd);
    kifmm__free(h->fft.bf); kifmm__free(h->fft.bd); kifmm__free(h->fft.mbuf);
    kifmm__free(h->fft.foutf); kifmm__free(h->fft.foutd);
    kifmm__free(h->fft.loc); kifmm__free(h->fft.need); kifmm__free(h->fft.cjl);
    kifmm__free(h->fft.sch);
    kifmm__free(h->near.chunk);
    kifmm__free(h->lat.zt);
    KIFMM__F(__orders_free)(h);
#if defined(KIFMM_MPI)
    kifmm__free(h->px.cum);
    h->px.cum = NULL;
    h->px.n = 0;
#endif
}

KIFMM__API void KIFMM__F(_destroy)(KIFMM_NAME *h)
{
    if (!h) return;
#if defined(KIFMM_MPI)
    if (h->mpi) {
        KIFMM__F(__mpi_destroy)(h);
        return;
    }
#endif
    KIFMM__F(__points_free)(h);
    KIFMM__F(__plan_release)(h);
    kifmm__free(h);
}

/* A point set: a count that an array can hold, a pointer if there are
 * points, finite coordinates of at most KIFMM__CMAX in magnitude; lo and hi
 * (3 each) widened to the set's bounds. */
KIFMM__FN int KIFMM__F(__check_points)(int64_t n, const KIFMM__R *xyz, int nth, double *lo,
                                       double *hi)
{
    int bad = 0, d;
    if (n < 0 || n > KIFMM_MAX_POINTS) return KIFMM_ERR_COUNT;
    if (n > 0 && !xyz) return KIFMM_ERR_NULL;
    KIFMM__OMP(parallel for schedule(static) num_threads(nth) reduction(| : bad) if (n > 65536))
    for (int64_t i = 0; i < 3 * n; i++)
        bad |= !isfinite(xyz[i]) ? 1 : !(fabs((double)xyz[i]) <= KIFMM__CMAX) ? 2 : 0;
    (void)nth;
    if (bad) return bad & 1 ? KIFMM_ERR_NONFINITE : KIFMM_ERR_RANGE;
    for (d = 0; d < 3; d++) {
        double mn = lo[d], mx = hi[d];
        KIFMM__OMP(parallel for schedule(static) num_threads(nth) reduction(min : mn) reduction(max : mx) if (n > 65536))
        for (int64_t i = 0; i < n; i++) {
            const double v = (double)xyz[3 * i + d];
            mn = v < mn ? v : mn;
            mx = v > mx ? v : mx;
        }
        lo[d] = mn;
        hi[d] = mx;
    }
    return KIFMM_SUCCESS;
}

/* The kernel's parameters with defaults resolved, or KIFMM_ERR_PARAM. */
KIFMM__FN int KIFMM__F(__params)(const double *in, double *out)
{
    int d;
    for (d = 0; d < 4; d++) {
        if (!isfinite(in[d])) return KIFMM_ERR_PARAM;
        out[d] = in[d];
    }
#if KIFMM__HAS_QT & KIFMM_HAS_SETUP
    if (KIFMM__K(_setup)(in, out) != 0) return KIFMM_ERR_PARAM;
#endif
#if KIFMM__FLOAT
    {
        /* float instances: the kernel at unit distance at most 1e30 in
         * magnitude. A Stokeslet's 1 / (8 pi mu) with mu below about 1e-30
         * overflows float in the hooks' factor, and outputs that are exactly
         * zero (coincident points only) came out NaN (inf times 0) */
        double kv[KIFMM__TD * KIFMM__QD];
        int i;
        KIFMM__K(_eval)(out, 1.0, 0.0, 0.0, kv);
        for (i = 0; i < KIFMM__TD * KIFMM__QD; i++)
            if (!(fabs(kv[i]) <= 1e30)) return KIFMM_ERR_PARAM;
    }
#endif
    return KIFMM_SUCCESS;
}

/* opts.tol's table: the kernel's own errors per order (KIFMM_HAS_TOL; an
 * oscillating kernel's per order and width, KIFMM_TOL_WAVES_NW + 1 a row),
 * or NULL for laplace's (kifmm__order_for_tol). */
KIFMM__FN const double *KIFMM__F(__tol_errors)(void)
{
#if (KIFMM__HAS_QT & KIFMM_HAS_TOL) && (KIFMM__HAS_QT & KIFMM_HAS_WAVES)
    static const double err[KIFMM_MAX_ORDER + 1][KIFMM_TOL_WAVES_NW + 1] = KIFMM__K(_TOL_ERRORS);
    return &err[0][0];
#elif KIFMM__HAS_QT & KIFMM_HAS_TOL
    static const double err[KIFMM_MAX_ORDER + 1] = KIFMM__K(_TOL_ERRORS);
    return err;
#else
    return NULL;
#endif
}

/* Far pairs. A scale-invariant kernel's loops form a power of 1 / r before
 * multiplying by the offsets (r^-3 for gradients, r^-5 for Hessians and
 * stokes_dl): where that power falls below the precision's smallest normal
 * number the pairs' terms come out zero, although the outputs, r^-2 or
 * r^-3 times densities the passes scale to about 1, are in range (stokes_dl
 * on points 1e70 apart gave zeros with success). 1 if the loop f (od
 * outputs, qd densities) gives each entry's value at distance dist (on one
 * pair, one unit density at a time) within 1e-3 of its value at distance 1
 * times dist to the entry's degree (read off the kernel ev at 1 and 2),
 * and that product at least e^10 times the smallest normal number; 0 if
 * not. Entries whose degree there is not an integer (a role kernel that is
 * not a power of r at that size: a blob's near field) are not checked. */
#define KIFMM__FAR_K                                                                                 \
    ((KIFMM__TD > KIFMM__SD ? KIFMM__TD : KIFMM__SD) * (KIFMM__QD > KIFMM__SD ? KIFMM__QD : KIFMM__SD))
KIFMM__FN int KIFMM__F(__far_role)(const double *prm, double dist, KIFMM__F(__p2p_fn) f,
                                   void (*ev)(const double *, double, double, double, double *),
                                   int od, int qd)
{
    static const double u[3] = {0.61 / 0.7495998932764065, -0.37 / 0.7495998932764065,
                                0.23 / 0.7495998932764065}; /* |u| = 1 */
    const double lo = log(KIFMM__FLOAT ? FLT_MIN : DBL_MIN) + 10.0;
    const double hi = log(KIFMM__FLOAT ? FLT_MAX : DBL_MAX);
    const KIFMM__R tx = (KIFMM__R)(dist * u[0]), ty = (KIFMM__R)(dist * u[1]), tz = (KIFMM__R)(dist * u[2]);
    const KIFMM__R z = 0;
    double k1[KIFMM__FAR_K], k2[KIFMM__FAR_K];
    KIFMM__R q[KIFMM__FAR_K], out[KIFMM__FAR_K];
    int a, s;
    ev(prm, u[0], u[1], u[2], k1);
    ev(prm, 2.0 * u[0], 2.0 * u[1], 2.0 * u[2], k2);
    for (s = 0; s < qd; s++) {
        for (a = 0; a < qd; a++) q[a] = (KIFMM__R)(a == s);
        for (a = 0; a < od; a++) out[a] = 0;
        f(prm, &tx, &ty, &tz, 1, &z, &z, &z, q, 1, 1, (size_t)qd, 1.0, out, (size_t)od);
        for (a = 0; a < od; a++) {
            const double v1 = k1[a * qd + s], v2 = k2[a * qd + s];
            double lp, deg;
            if (!(v1 != 0.0 && v2 / v1 > 0.0 && isfinite(v2 / v1))) continue; /* no degree */
            deg = log2(v2 / v1);
            if (!(fabs(deg - floor(deg + 0.5)) < 1e-6)) continue; /* not a power of r here */
            lp = log(fabs(v1)) + deg * log(dist);
            if (lp > hi) continue; /* growing with distance: not this check's */
            if (lp < lo) return 0; /* the term itself at the range's lower edge */
            if (!(fabs((double)out[a] - v1 * exp(lp - log(fabs(v1)))) <= 1e-3 * exp(lp))) return 0;
        }
    }
    return 1;
}

/* The anchors the downward densities need (>>anchors), from whether the
 * targets get derivatives of the surface kernel's field: where some entry
 * of ST (surface -> targets) falls off faster with distance than every
 * entry of SC (the surface kernel), between the offsets u and 2 u, by
 * about one power of r, 4 (a field's constant and linear parts), by two or
 * more, KIFMM__ANCHOR_MAX (its quadratic part too); else 0: a potential's
 * error does not grow with the depth, and anchors would only cost time (14
 * points on a surface of 56 at p = 4). The most of |u| = 1e-3, 1e-6 and
 * 1e-9: a kernel that is not scale invariant shows its powers of r where
 * its other lengths do not reach (helmholtz_grad at k = 2e4 oscillates
 * between 1e-3 and 2e-3, and had none). */
KIFMM__FN int KIFMM__F(__st_derivative)(const double *param)
{
    static const double u[3] = {0.6, 0.48, 0.64};
    double prm[4], ks[2][KIFMM__TD * KIFMM__SD], kc[2][KIFMM__SD * KIFMM__SD], dst, dsc, f;
    int t, na, n = 0;
    if (KIFMM__F(__params)(param, prm) != KIFMM_SUCCESS) return 0;
    for (f = 1e-3; f > 1e-10; f *= 1e-3) {
        for (t = 0; t < 2; t++) {
            const double g = (1 + t) * f;
            KIFMM__R_(ST, _eval)(prm, g * u[0], g * u[1], g * u[2], ks[t]);
            KIFMM__R_(SC, _eval)(prm, g * u[0], g * u[1], g * u[2], kc[t]);
        }
        dst = kifmm__min_degree(ks[0], ks[1], KIFMM__TD * KIFMM__SD);
        dsc = kifmm__min_degree(kc[0], kc[1], KIFMM__SD * KIFMM__SD);
        na = dst < dsc - 1.5 ? KIFMM__ANCHOR_MAX : dst < dsc - 0.5 ? 4 : 0;
        n = na > n ? na : n;
    }
    return n;
}

/* r, c: the degrees of QC's rows and columns (kifmm__degrees); 0 where QC
 * is not so or SC not scale invariant. */
KIFMM__FN int KIFMM__F(__qc_degrees)(const double *prm, double *r, double *c)
{
    return KIFMM__SI && kifmm__degrees(KIFMM__R_(QC, _eval), prm, KIFMM__SD, KIFMM__QD, r, c);
}

/* lo[s], hi[s]: the least and greatest power of the box half-width h that
 * density component s's part of a box's equivalent densities grows with,
 * in the passes' units (check potentials times h^-DEGREE, __level_scale):
 * the degrees of QC's column s less SC's. A charge under the Laplace
 * kernel 0, a dipole -1 (its check potentials fall as r^-2, SC's as
 * r^-1); 0 where QC's entries are not powers of r, or SC is not scale
 * invariant. */
KIFMM__FN void KIFMM__F(__density_degrees)(const double *prm, double *lo, double *hi)
{
    double e[KIFMM__SD * KIFMM__QD] = {0.0};
    int a, s, ok = KIFMM__SI && !KIFMM__CPLX &&
                   kifmm__entry_degrees(KIFMM__R_(QC, _eval), prm, KIFMM__SD * KIFMM__QD, kifmm__degree_x, e);
    for (s = 0; s < KIFMM__QD; s++) {
        lo[s] = HUGE_VAL, hi[s] = -HUGE_VAL;
        for (a = 0; a < KIFMM__SD && ok; a++) {
            const double d = e[a * KIFMM__QD + s] - (double)(KIFMM__DEGREE);
            if (d != d) continue; /* a zero entry */
            lo[s] = d < lo[s] ? d : lo[s], hi[s] = d > hi[s] ? d : hi[s];
        }
        if (lo[s] > hi[s]) lo[s] = hi[s] = 0.0;
    }
}

/* KIFMM_ERR_RANGE where the passes' loops on points (near field, P2M, L2P,
 * L2L from a far ancestor) lose pairs dist apart (__far_role): dist is
 * twice the diagonal of the points' box or of the cell. */
KIFMM__FN int KIFMM__F(__check_far)(const double *prm, double dist)
{
#if KIFMM__SI
    double p[4], ds;
    /* the powers grow: close pairs give KIFMM_ERR_OVERFLOW; parameters the
     * kernel refuses, KIFMM_ERR_PARAM after this */
    if (!(dist > 1.0) || KIFMM__F(__params)(prm, p) != KIFMM_SUCCESS) return KIFMM_SUCCESS;
    prm = p;
    /* the surface loops also reach the anchors (>>anchors), up to about
     * KIFMM__ANCHOR_RADIUS times the root's half-width away */
    ds = KIFMM__ANCHORS && KIFMM__F(__st_derivative)(prm) ? dist * KIFMM__ANCHOR_RADIUS : dist;
    if (!KIFMM__F(__far_role)(prm, dist, KIFMM__F(__p2p_qt), KIFMM__R_(QT, _eval), KIFMM__TD, KIFMM__QD) ||
        !KIFMM__F(__far_role)(prm, dist, KIFMM__F(__p2p_qc), KIFMM__R_(QC, _eval), KIFMM__SD, KIFMM__QD) ||
        !KIFMM__F(__far_role)(prm, ds, KIFMM__F(__p2p_st), KIFMM__R_(ST, _eval), KIFMM__TD, KIFMM__SD) ||
        !KIFMM__F(__far_role)(prm, ds, KIFMM__F(__p2p_sc), KIFMM__R_(SC, _eval), KIFMM__SD, KIFMM__SD))
        return KIFMM_ERR_RANGE;
#else
    (void)prm, (void)dist;
#endif
    return KIFMM_SUCCESS;
}

/* The checks of create and update_points on both point sets, for options
 * o (resolved): counts, pointers, finite coordinates in range, opts.domain
 * holding every point (KIFMM_ERR_DOMAIN), and in free space an extent the
 * squared distances can hold. */
KIFMM__FN int KIFMM__F(__check_sets)(const kifmm_opts *o, int64_t ns, const KIFMM__R *src,
                                     int64_t nt, const KIFMM__R *trg)
{
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    int d, rc = KIFMM__F(__check_points)(ns, src, o->nthreads, lo, hi);
    if (!rc) rc = KIFMM__F(__check_points)(nt, trg, o->nthreads, lo, hi);
    if (rc) return rc;
    if (o->domain[3] > 0.0) {
        /* the box in range as the points are, and every point in it */
        for (d = 0; d < 3; d++)
            if (!(fabs(o->domain[d]) + o->domain[3] <= KIFMM__CMAX) || !(o->domain[3] >= KIFMM__EMIN))
                return KIFMM_ERR_RANGE;
        for (d = 0; d < 3; d++)
            if (lo[d] <= hi[d] && !(lo[d] >= o->domain[d] - o->domain[3] && hi[d] <= o->domain[d] + o->domain[3]))
                return KIFMM_ERR_DOMAIN;
        return KIFMM__F(__check_far)(o->kernel_param, 4.0 * sqrt(3.0) * o->domain[3]);
    }
    /* squared distances must stay in range: periods of KIFMM__EMIN to
     * KIFMM__CMAX, and in free space a spread set's extent of at least
     * KIFMM__EMIN (a periodic tree's root is the cell) */
    for (d = 0; d < 3; d++)
        if (o->period[d] > 0.0 && !(o->period[d] >= KIFMM__EMIN && o->period[d] <= KIFMM__CMAX))
            return KIFMM_ERR_RANGE;
    {
        double ext = 0.0, cell = 0.0; /* the free directions' extent, the largest period */
        for (d = 0; d < 3; d++) {
            if (o->period[d] > 0.0) cell = o->period[d] > cell ? o->period[d] : cell;
            else if (hi[d] - lo[d] > ext) ext = hi[d] - lo[d];
        }
        if (cell == 0.0 && ext > 0.0 && ext < KIFMM__EMIN) return KIFMM_ERR_RANGE;
        return KIFMM__F(__check_far)(o->kernel_param, 2.0 * sqrt(3.0) * (ext > cell ? ext : cell));
    }
}

#if (KIFMM__HAS_QT & KIFMM_HAS_WAVES) && (KIFMM__HAS_QT & KIFMM_HAS_TOL)
/* The root's width a tree on these points would take (kifmm__tree_bounds;
 * float points through a double copy, as __tree_build does); 0 on
 * allocation failure. */
KIFMM__FN double KIFMM__F(__root_width)(const kifmm_opts *o, int64_t ns, const KIFMM__R *src,
                                        int64_t nt, const KIFMM__R *trg)
{
    kifmm__tree t;
    memset(&t, 0, sizeof t);
#if KIFMM__FLOAT
    {
        const int same = src == trg && ns == nt; /* (zeroed: gcc 12 takes them for unset) */
        double *s = (double *)kifmm__calloc((size_t)(3 * ns) + 1, sizeof(double));
        double *g = same ? s : (double *)kifmm__calloc((size_t)(3 * nt) + 1, sizeof(double));
        int64_t i;
        if (s && g) {
            for (i = 0; i < 3 * ns; i++) s[i] = src[i];
            for (i = 0; i < 3 * nt && !same; i++) g[i] = trg[i];
            kifmm__tree_bounds(&t, ns, s, nt, g, o->nthreads, o->domain);
        }
        kifmm__free(s);
        if (!same) kifmm__free(g);
    }
#else
    kifmm__tree_bounds(&t, ns, src, nt, trg, o->nthreads, o->domain);
#endif
    return t.width;
}

/* opts.tol (o->tol) for an oscillating kernel: o->order, the smallest
 * whose measured error (the kernel's table, kifmm__order_for_tol_waves) at
 * the widest boxes that can carry expansions, a quarter of a root `width`
 * wide (0: the narrowest), meets it, and the leaf size for it (`leaf`, the
 * caller's, or its default). KIFMM_ERR_TOL where no order meets tol even
 * at the narrowest. Where none does at this width, the narrowest's: a tree
 * of direct sums runs at any width, and __orders refuses the others
 * (KIFMM_ERR_FREQUENCY) once the tree is built. */
KIFMM__FN int KIFMM__F(__tol_root)(kifmm_opts *o, int leaf, double width)
{
    static const double most[KIFMM_MAX_ORDER + 1] = KIFMM__K(_WAVES_MAX);
    const double *err = KIFMM__F(__tol_errors)();
    const double x = 0.25 * width * KIFMM__K(_wavenumber)(o->kernel_param) / (2.0 * 3.14159265358979323846);
    int p = kifmm__order_for_tol_waves(o->tol, x, err, most);
    if (!p && !(p = kifmm__order_for_tol_waves(o->tol, 0.0, err, most))) return KIFMM_ERR_TOL;
    o->order = p;
    o->leaf_size = leaf ? leaf : kifmm__default_leaf(p, KIFMM__LEAF_KIND);
    return KIFMM_SUCCESS;
}
/* opts.tol without a root: a call that does not see every point */
#define KIFMM__TOL_UNROOTED(o) ((o).tol != 0.0 && !((o).domain[3] > 0.0))

/* create and update_points: opts.tol's order (__tol_root) for the root of
 * tree, if not NULL, else of these points, where opts.domain gives none */
KIFMM__FN int KIFMM__F(__tol_points)(kifmm_opts *o, int leaf, const kifmm_tree *tree, int64_t ns,
                                     const KIFMM__R *src, int64_t nt, const KIFMM__R *trg)
{
    double w;
    if (!KIFMM__TOL_UNROOTED(*o)) return KIFMM_SUCCESS;
    w = tree ? tree->t.width : KIFMM__F(__root_width)(o, ns, src, nt, trg);
    return w > 0.0 ? KIFMM__F(__tol_root)(o, leaf, w) : KIFMM_ERR_NOMEM;
}
#else
/* (other kernels: opts.tol resolved with the options; an oscillating one
 * without a table has no opts.tol) */
KIFMM__FN int KIFMM__F(__tol_root)(kifmm_opts *o, int leaf, double width)
{
    (void)o, (void)leaf, (void)width;
    return (KIFMM__HAS_QT & KIFMM_HAS_WAVES) ? KIFMM_ERR_TOL : KIFMM_SUCCESS;
}
#define KIFMM__TOL_UNROOTED(o) 0
#define KIFMM__TOL_POINTS(o, leaf, tree, ns, src, nt, trg) KIFMM_SUCCESS
#endif
#ifndef KIFMM__TOL_POINTS
#define KIFMM__TOL_POINTS KIFMM__F(__tol_points)
#endif

/* Create's checks: the options, both point sets and the kernel's
 * parameters; *o gets the options with every default resolved. */
KIFMM__FN int KIFMM__F(__validate)(const kifmm_opts *opts, int64_t ns, const KIFMM__R *src,
                                   int64_t nt, const KIFMM__R *trg, kifmm_opts *o)
{
    const double tol = opts ? opts->tol : 0.0;
    double param[4];
    kifmm_opts in;
    int rc;
    if (opts) in = *opts;
    else memset(&in, 0, sizeof in);
#if KIFMM__HAS_QT & KIFMM_HAS_WAVES
    /* an oscillating kernel's opts.tol: its order comes from the root's
     * width (__tol_root, below); the other options are resolved first */
    if (tol != 0.0 && (!(tol > 0.0 && tol <= DBL_MAX) || in.order != 0)) return KIFMM_ERR_TOL;
    if (tol != 0.0) in.tol = 0.0, in.order = 2;
#endif
    rc = kifmm__resolve_opts(&in, KIFMM__LEAF_KIND, KIFMM__F(__tol_errors)(), o);
    /* float's floor: at order 6 laplacef measured up to 1.05e-5 */
    if (!rc && KIFMM__FLOAT && tol != 0.0 && tol < 2e-5) rc = KIFMM_ERR_TOL;
    if (!rc) rc = KIFMM__F(__check_sets)(o, ns, src, nt, trg);
    if (!rc) rc = KIFMM__F(__params)(o->kernel_param, param);
    if (!rc) memcpy(o->kernel_param, param, sizeof param);
#if KIFMM__HAS_QT & KIFMM_HAS_WAVES
    /* oscillating kernels: free space only (no quasi-periodic boundaries
     * yet); opts.tol's order for the root opts.domain gives, else for the
     * narrowest (create and update_points choose again from the points'
     * root; the calls that do not see every point refuse it,
     * KIFMM__TOL_UNROOTED) */
    if (!rc && (o->period[0] > 0.0 || o->period[1] > 0.0 || o->period[2] > 0.0)) rc = KIFMM_ERR_PERIODIC;
    if (!rc && tol != 0.0) {
        o->tol = tol;
        rc = KIFMM__F(__tol_root)(o, in.leaf_size, o->domain[3] > 0.0 ? 2.0 * o->domain[3] : 0.0);
    }
#endif
    return rc;
}

/* A new plan for options o (resolved): the surfaces (their orders, radii
 * and unit points) and the FFT's transforms; the operators come with the
 * first tree (__plan_ops). NULL on allocation failure. */
KIFMM__FN KIFMM__F(_plan) *KIFMM__F(__plan_new)(const kifmm_opts *o)
{
    KIFMM__F(_plan) *pl = (KIFMM__F(_plan) *)kifmm__calloc(1, sizeof *pl);
    int p, sd, rc = KIFMM_SUCCESS;
    if (!pl) return NULL;
    kifmm__lock_init(&pl->lock);
    pl->held = sizeof *pl;
    pl->refs = 1;
    pl->opts = *o;
    pl->opts.operator_cache = NULL;
    if (o->operator_cache && o->operator_cache[0]) { /* >>cache: the plan's copy */
        const size_t n = strlen(o->operator_cache) + 1;
        if ((pl->cache.dir = (char *)kifmm__take(&pl->held, n, 1)) == NULL) rc = KIFMM_ERR_NOMEM;
        else memcpy(pl->cache.dir, o->operator_cache, n);
        pl->opts.operator_cache = pl->cache.dir;
    }
    pl->ops.degree = (double)(KIFMM__DEGREE);
    KIFMM__F(__density_degrees)(o->kernel_param, pl->ops.qlo, pl->ops.qhi);
    p = o->order;
    /* a complex kernel's surfaces up to order KIFMM__CPLX_SQUARE_MAX: a
     * one-component kernel's square systems (where the build's options
     * give those), else two components' */
    sd = KIFMM__CPLX && KIFMM__FFT && p <= KIFMM__CPLX_SQUARE_MAX && kifmm__check_diff(p, 1, 1, KIFMM__FLOAT) == 0
             ? 1
             : KIFMM__SD;
    pl->surf.cdiff = kifmm__check_diff(p, KIFMM__FFT, sd, KIFMM__FLOAT);
    pl->surf.ao = kifmm__alpha_outer(p, pl->surf.cdiff, sd);
    pl->surf.ai = kifmm__alpha_inner(sd, KIFMM__IS_ONE(KIFMM__R_(SC, _INNER_NARROW)));
    pl->surf.nse = kifmm__surf_count(p);
    pl->surf.nsc = kifmm__surf_count(p + pl->surf.cdiff);
    pl->surf.ne = pl->surf.nse * KIFMM__SD;
    pl->surf.nc = pl->surf.nsc * KIFMM__SD;
    pl->surf.unit_e = (double *)kifmm__take(&pl->held, (size_t)3 * pl->surf.nse, sizeof(double));
    pl->surf.unit_c = (double *)kifmm__take(&pl->held, (size_t)3 * pl->surf.nsc, sizeof(double));
    pl->surf.nsa = KIFMM__ANCHORS ? KIFMM__F(__st_derivative)(o->kernel_param) : 0; /* >>anchors */
    pl->surf.nde = (pl->surf.nse + pl->surf.nsa) * KIFMM__SD;
    pl->surf.nsm = pl->surf.nsc > pl->surf.nse + pl->surf.nsa ? pl->surf.nsc : pl->surf.nse + pl->surf.nsa;
    pl->surf.unit_a = (double *)kifmm__take(&pl->held, (size_t)3 * KIFMM__ANCHOR_MAX, sizeof(double));
    if (!pl->surf.unit_e || !pl->surf.unit_c || !pl->surf.unit_a) rc = KIFMM_ERR_NOMEM;
    if (!rc) {
        kifmm__surf_unit(p, pl->surf.unit_e);
        kifmm__surf_unit(p + pl->surf.cdiff, pl->surf.unit_c);
        kifmm__anchor_unit(pl->surf.nsa, pl->surf.unit_a);
    }
#if KIFMM__FFT
    if (!rc) rc = kifmm__fft_init(&pl->fft, p + pl->surf.cdiff, KIFMM__CPLX, &pl->held);
    /* float spectra for float instances, and on request for double
     * instances of scale-invariant kernels (whose spectra's range fits float
     * at every level, unlike those of a Yukawa kernel at large lambda r) */
    pl->fft.single = KIFMM__FLOAT || (KIFMM__SI && p <= KIFMM_FFT_SINGLE_MAX_ORDER);
#endif
    if (rc) {
        KIFMM__F(__plan_free)(pl);
        return NULL;
    }
    return pl;
}

/* A tree over the points given in the instance's precision, into tr
 * (__tree_own's): double goes straight in, float through a double copy
 * whose sorted points then change into float ones (tr->fsrc, tr->ftrg). */
KIFMM__FN int KIFMM__F(__tree_build)(kifmm_tree *tr, const kifmm_opts *o, int64_t ns,
                                     const KIFMM__R *src, int64_t nt, const KIFMM__R *trg)
{
    kifmm__tree *t = &tr->t;
    int rc;
#if KIFMM__FLOAT
    {
        const int same = src == trg && ns == nt; /* one copy, and the tree sorts once */
        double *s = (double *)kifmm__calloc((size_t)(3 * ns) + 1, sizeof(double));
        double *g = same ? s : (double *)kifmm__calloc((size_t)(3 * nt) + 1, sizeof(double));
        if (!s || !g) {
            kifmm__free(s);
            if (!same) kifmm__free(g);
            return KIFMM_ERR_NOMEM;
        }
        /* each i copies its own value */
        KIFMM__OMP(parallel for schedule(static) num_threads(o->nthreads))
        for (int64_t i = 0; i < 3 * ns; i++) s[i] = src[i];
        if (!same) {
            KIFMM__OMP(parallel for schedule(static) num_threads(o->nthreads))
            for (int64_t i = 0; i < 3 * nt; i++) g[i] = trg[i];
        }
        rc = kifmm__tree_build(t, ns, s, nt, g, o->leaf_size, o->max_depth, o->nthreads,
                               !KIFMM__FFT, o->period, o->domain);
        kifmm__free(s);
        if (!same) kifmm__free(g);
    }
    if (rc) return rc;
    /* the double copies change into float ones */
    t->held -= kifmm__size(t->src) + (t->same ? 0 : kifmm__size(t->trg));
    tr->fsrc = KIFMM__F(__own)(&t->held, &t->src, (size_t)(3 * ns));
    if (t->same) {
        tr->ftrg = tr->fsrc;
        t->trg = NULL;
    } else {
        tr->ftrg = KIFMM__F(__own)(&t->held, &t->trg, (size_t)(3 * nt));
    }
    return tr->fsrc && tr->ftrg ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM;
#else
    rc = kifmm__tree_build(t, ns, src, nt, trg, o->leaf_size, o->max_depth, o->nthreads,
                           !KIFMM__FFT, o->period, o->domain);
    return rc;
#endif
}

/* The handle's side of its tree (built here unless it is shared): the
 * sorted points in the instance's precision, the level the far images
 * reach, and which local expansion serves each box (dsrc). */
KIFMM__FN int KIFMM__F(__points_tree)(KIFMM_NAME *c, int64_t ns, const KIFMM__R *src, int64_t nt,
                                    const KIFMM__R *trg)
{
    int rc;
    if (!c->tshared && (rc = KIFMM__F(__tree_build)(c->tr, &c->opts, ns, src, nt, trg))) return rc;
#if KIFMM__FLOAT
    c->pts.src = c->tr->fsrc;
    c->pts.trg = c->tr->ftrg;
#else
    c->pts.src = c->tree->src;
    c->pts.trg = c->tree->trg;
#endif
    /* the far images reach level 1 (__far_root) */
    c->lat.zl = c->tree->periodic && c->tree->nlev > 1;
    {
        int32_t b;
        for (b = c->tree->loff[c->lat.zl]; b < c->tree->loff[c->lat.zl + 1]; b++)
            if (c->tree->child[b] < 0 && (c->tree->s1[b] > c->tree->s0[b] || c->tree->t1[b] > c->tree->t0[b]))
                c->lat.zsmall = 1;
    }
    c->dsrc = (int32_t *)kifmm__take(&c->held, (size_t)c->tree->nbox + 1, sizeof(int32_t));
    if (!c->dsrc) return KIFMM_ERR_NOMEM;
    kifmm__tree_dsrc(c->tree, c->dsrc, c->pl->surf.nsc, c->lat.zl); /* X lists of boxes with
                                                                        few targets go direct */
    return KIFMM_SUCCESS;
}

/* The points of the scratch's frames for a largest leaf of maxleaf points
 * (see __scratch_per): float instances' frame, periodic trees' image (at
 * least a surface). */
KIFMM__FN void KIFMM__F(__frame_points)(KIFMM_NAME *h, size_t maxleaf)
{
    const size_t nse = (size_t)KIFMM__F(__smax)(h)->nse;
    h->work.fpts = KIFMM__FLOAT ? maxleaf : 0;
    h->work.ipts = h->tree->periodic ? maxleaf : 0;
    if (h->tree->periodic && h->work.ipts < nse) h->work.ipts = nse;
}

/* Per-thread buffers of the passes: three surfaces and, for float
 * instances, the frame of the largest leaf (see __frame); and the level
 * passes' column buffers, for trees that have levels 2 and deeper. */
KIFMM__FN int KIFMM__F(__work_buffers)(KIFMM_NAME *h)
{
    const size_t nth = (size_t)h->opts.nthreads;
    KIFMM__F(__frame_points)(h, (size_t)kifmm__max_leaf(h->tree));
    h->work.scratch = (KIFMM__R *)kifmm__take(&h->held, nth * KIFMM__F(__scratch_per)(h),
                                              sizeof(KIFMM__R));
    h->work.gbuf_n = h->tree->nlev > kifmm__lmin(h->tree) ? (KIFMM__GC_FAST ? nth : 1) * KIFMM__F(__gbuf_per)(h) : 0;
    h->work.gbuf = (KIFMM__R *)kifmm__take(&h->held, h->work.gbuf_n, sizeof(KIFMM__R));
    return h->work.scratch && h->work.gbuf ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM;
}

#if KIFMM__FFT
/* The spectra buffer: KIFMM_FFT_SPEC_MB, or as much as one expansion array of
 * the handle when that is larger, up to 4 times that (fewer slabs and fewer
 * spectra computed twice where the handle is big anyway; two arrays' worth
 * measured no faster at 1M uniform points, p = 6, for 23 MiB more), at
 * least 256 parents' (at high orders: few slabs per level), at most the
 * largest level's; returns the parents (slots) it holds. A periodic tree
 * has no faces: every slab has neighbours on all sides, and with the same
 * budget its slabs held fewer target parents (270 against 450 of 720 slots
 * at level 5, 1M uniform points, p = 6), 1.5 times the forward transforms
 * and an evaluate 1.19 to 1.25 times the free one's; it gets 4 arrays'
 * worth (there 180 MiB, and as much again for the products without kept
 * blocks: 1.09 to 1.11 times, for a handle of 539 MB against 316 MB; 2
 * arrays' worth gave 1.18 times for 365 MB). KIFMM_FFT_SPEC_MB lowers
 * both caps. */
KIFMM__FN int32_t KIFMM__F(__fft_slots)(const KIFMM_NAME *h, size_t esz, int32_t m)
{
    const size_t slot = (size_t)KIFMM__F(__ftmax)(h)->nfp * 16 * esz * KIFMM__FSD;
    const size_t lo = (size_t)KIFMM_FFT_SPEC_MB << 20;
    size_t budget = (size_t)h->tree->nbox * (size_t)KIFMM__F(__smax)(h)->ne * sizeof(KIFMM__R);
    int32_t slots;
    if (h->tree->periodic) budget *= 4; /* see above */
    budget = budget < lo ? lo : budget > 4 * lo ? 4 * lo : budget;
    slots = (int32_t)(budget / slot);
    if (slots < 256) slots = 256;
    return (slots > m ? m : slots) * KIFMM__FSD;
}

/* The FFT M2L's slab bookkeeping: the largest level's internal boxes (m) and
 * colleague entries (mc), the spectra buffer's slots, their index arrays. */
KIFMM__FN int KIFMM__F(__points_slabs)(KIFMM_NAME *h, size_t esz)
{
    const kifmm__tree *t = h->tree;
    size_t *held = &h->held;
    int32_t l, i, m = 1, mc = 1;
    for (l = kifmm__lmin(t) > 0 ? 1 : 0; l + 1 < t->nlev; l++) {
        if (t->ioff[l + 1] - t->ioff[l] > m) m = t->ioff[l + 1] - t->ioff[l];
        if (h->fft.co[t->ioff[l + 1]] - h->fft.co[t->ioff[l]] > mc)
            mc = h->fft.co[t->ioff[l + 1]] - h->fft.co[t->ioff[l]];
    }
    h->fft.m = m;
    h->fft.mc = mc;
    h->fft.slots = KIFMM__F(__fft_slots)(h, esz, m);
    h->fft.loc = (int32_t *)kifmm__take(held, (size_t)m, sizeof(int32_t));
    h->fft.need = (int32_t *)kifmm__take(held, (size_t)m, sizeof(int32_t));
    h->fft.cjl = (int32_t *)kifmm__take(held, (size_t)mc, sizeof(int32_t));
    h->fft.sch = (unsigned char *)kifmm__take(held, (size_t)h->fft.slots, 9);
    if (!h->fft.loc || !h->fft.need || !h->fft.cjl || !h->fft.sch) return KIFMM_ERR_NOMEM;
    for (i = 0; i < m; i++) h->fft.loc[i] = -1;
    return KIFMM_SUCCESS;
}

/* The FFT M2L's buffers in the spectra's precision (__fft_per: the values
 * per thread, and the target parents per task): the spectra of a slab
 * (forward transforms write every frequency below nf of a slot; only the
 * last chunk, whose padding frequencies must read 0, is zeroed here:
 * zeroing all of it, 45 MiB at 1M points, p = 6, took 0.05 s of one thread
 * in create), and per thread the blocks of a chunk, the products of up to
 * ftb target parents (128, at most about 4 MiB) and the transform work. */
KIFMM__FN void KIFMM__F(__fft_per)(KIFMM_NAME *h, size_t esz)
{
    const kifmm__fft *pl = KIFMM__F(__ftmax)(h);
    h->fft.ftb = (int)((size_t)(4u << 20) / ((size_t)pl->nfp * 16 * esz * KIFMM__FSD));
    h->fft.ftb = h->fft.ftb > 128 ? 128 : h->fft.ftb < 1 ? 1 : h->fft.ftb;
    h->fft.per = KIFMM__FFT_KBN + KIFMM__FFT_OUTN(h) + kifmm__fft_work8(pl);
    h->fft.per = (h->fft.per + 15) / 16 * 16; /* each thread's part 64-byte aligned */
}

KIFMM__FN int KIFMM__F(__work_fft)(KIFMM_NAME *h, size_t esz)
{
    const kifmm__fft *pl = KIFMM__F(__ftmax)(h);
    const size_t nth = (size_t)h->opts.nthreads, chunk = (size_t)h->fft.slots * KIFMM__FFT_F * 16;
    const size_t nspec = (size_t)h->fft.slots * (size_t)pl->nfp * 16;
    /* the padding frequencies of the last chunk are never written: zeros
     * (with levels of several orders, every lattice's last chunk: all) */
    const size_t z0 = h->ord.up ? 0 : nspec - chunk, zn = pl->nfp > pl->nf || h->ord.up ? nspec - z0 : 0;
    size_t *held = &h->held;
    KIFMM__F(__fft_per)(h, esz);
    if (pl->single) {
        h->fft.specf = (float *)kifmm__take(held, nspec, sizeof(float));
        h->fft.bf = (float *)kifmm__take(held, nth * h->fft.per, sizeof(float));
        if (h->fft.specf && zn) memset(h->fft.specf + z0, 0, zn * esz);
    } else {
        h->fft.specd = (double *)kifmm__take(held, nspec, sizeof(double));
        h->fft.bd = (double *)kifmm__take(held, nth * h->fft.per, sizeof(double));
        if (h->fft.specd && zn) memset(h->fft.specd + z0, 0, zn * esz);
    }
    h->fft.mbuf = (double *)kifmm__take(held, nth * 8 * (size_t)KIFMM__F(__smax)(h)->nc, sizeof(double));
    return (h->fft.specf || h->fft.specd) && (h->fft.bf || h->fft.bd) && h->fft.mbuf
               ? KIFMM_SUCCESS
               : KIFMM_ERR_NOMEM;
}

/* The FFT M2L's colleagues and slabs. */
KIFMM__FN int KIFMM__F(__points_fft)(KIFMM_NAME *h)
{
    const size_t esz = h->pl->fft.single ? sizeof(float) : sizeof(double);
    int rc = kifmm__colleagues(h->tree, h->opts.nthreads, &h->held, &h->fft.co, &h->fft.cj,
                               &h->fft.cc);
    return rc ? rc : KIFMM__F(__points_slabs)(h, esz);
}

/* A level whose products' blocks are not kept runs its products over chunks
 * of frequencies (each chunk's blocks built once per slab), into one output
 * buffer for the slab's target parents. */
KIFMM__FN int KIFMM__F(__work_fout)(KIFMM_NAME *h)
{
    const size_t n = (size_t)h->fft.slots * (size_t)KIFMM__F(__ftmax)(h)->nfp * 16;
    int l;
    for (l = 0; l < h->tree->nlev; l++)
        if (h->lv[l] && h->lv[l]->khat && !h->lv[l]->kbf && !h->lv[l]->kbd) break;
    if (l == h->tree->nlev) return KIFMM_SUCCESS;
    if (h->pl->fft.single) h->fft.foutf = (float *)kifmm__take(&h->held, n, sizeof(float));
    else h->fft.foutd = (double *)kifmm__take(&h->held, n, sizeof(double));
    return h->fft.foutf || h->fft.foutd ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM;
}
#endif

/* The dense M2L's columns per GEMM: about 64 MB of stacked multipoles, at
 * most RHS_MAX per box of the largest level. */
KIFMM__FN int KIFMM__F(__m2l_cols)(const KIFMM_NAME *h)
{
    size_t cols = (size_t)(64u << 20) / (sizeof(KIFMM__R) * KIFMM__NT * (size_t)KIFMM__F(__smax)(h)->ne);
    if (cols < KIFMM__RHS_MAX) cols = KIFMM__RHS_MAX;
    if (cols > (size_t)h->work.mb * KIFMM__RHS_MAX) cols = (size_t)h->work.mb * KIFMM__RHS_MAX;
    return (int)cols;
}

/* The workspace of the passes for one vector, and what it is sized by: the
 * boxes the solves visit, the largest level, the dense M2L's columns. */
KIFMM__FN int KIFMM__F(__work_solves)(KIFMM_NAME *h, int nrhs)
{
    h->work.mb = kifmm__max_level_boxes(h->tree);
    if (!(h->work.act = kifmm__active(h->tree, &h->held))) return KIFMM_ERR_NOMEM;
    /* none in a tree without M2L */
    h->work.m2l_cols = h->tree->m2lo[h->tree->nlev] ? KIFMM__F(__m2l_cols)(h) : 0;
    h->work.w = KIFMM__F(__work_new)(h, nrhs);
    return h->work.w ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM;
}

/* What the handle is made of, for <prefix>_stats: the largest leaf, the
 * points of crowded leaves, and the code paths of this build. */
KIFMM__FN void KIFMM__F(__describe)(KIFMM_NAME *h)
{
    const kifmm__tree *t = h->tree;
    kifmm_stats *st = &h->stats;
    const char *near =
        KIFMM__NEAR_HOOK ? (KIFMM__MUTUAL && t->same ? "kernel hooks, each pair once"
                                                     : "kernel hooks")
                         : "generic loop over the kernel's eval";
    int32_t b;
    st->max_leaf = st->crowded = 0;
    for (b = 0; b < t->nbox; b++) {
        const int64_t ns = t->s1[b] - t->s0[b], nt = t->same ? 0 : t->t1[b] - t->t0[b];
        if (t->child[b] >= 0) continue;
        if (ns > st->max_leaf) st->max_leaf = ns;
        if (nt > st->max_leaf) st->max_leaf = nt;
        if (ns > h->opts.leaf_size || nt > h->opts.leaf_size) st->crowded += ns + nt;
    }
    st->threads = h->opts.nthreads;
    st->simd = KIFMM__SIMD_BITS;
    snprintf(st->build, sizeof st->build,
             "near field: %s, %s; level passes: %s; M2L: %s%s; %s %d thread%s", KIFMM__SIMD_NAME,
             near, KIFMM__GC_FAST ? KIFMM__SIMD_NAME " column GEMM" : "BLAS",
             KIFMM__FFT ? "FFT, " KIFMM__SIMD_NAME " products, " : "dense BLAS",
             KIFMM__FFT ? (h->pl->fft.single ? (KIFMM__CPLX ? "complex lattices, float spectra" : "float spectra")
                                             : (KIFMM__CPLX ? "complex lattices, double spectra" : "double spectra"))
                        : "",
#ifdef _OPENMP
             "OpenMP,",
#else
             "no OpenMP (built without -fopenmp):",
#endif
             h->opts.nthreads, h->opts.nthreads == 1 ? "" : "s");
    if (h->ord.up) { /* >>orders */
        size_t n = strlen(st->build);
        int l;
        n += (size_t)snprintf(st->build + n, sizeof st->build - n, "; wide levels (level:order)");
        for (l = 0; l < t->nlev && n < sizeof st->build; l++)
            if (h->ord.pl[l])
                n += (size_t)snprintf(st->build + n, sizeof st->build - n, " %d:%d", l, h->ord.pl[l]->opts.order);
    }
}

/* opts.verbose: create's stages (stage 1, after create), update_points'
 * (2) or evaluate's passes (0, after an evaluate), one line each on stderr,
 * with the memory held. */
KIFMM__FN void KIFMM__F(__report)(const KIFMM_NAME *h, int stage)
{
    static const char *pass[8] = {"P2M", "M2M and upward solves", "M2L", "L2L and downward solves",
                                  "P2L (X lists)", "L2P", "M2P (W lists)", "P2P (U lists)"};
    static const char *what[3] = {"evaluate", "create", "update_points"};
    const kifmm_stats *s = &h->stats;
    const double t[8] = {s->t_p2m, s->t_m2m, s->t_m2l, s->t_l2l, s->t_p2l, s->t_l2p, s->t_m2p, s->t_p2p};
    const char *name = KIFMM__STR(KIFMM_NAME);
    int k;
    if (stage) {
        fprintf(stderr, "%s %s: points: %s %.4f s (%d levels, %lld boxes, %lld leaves)\n", name,
                what[stage], h->tshared ? "on a shared tree" : "tree and lists", s->t_points,
                s->levels, (long long)s->boxes, (long long)s->leaves);
        fprintf(stderr, "%s %s: plan: surfaces and operators %.4f s (order %d, leaf size %d)\n",
                name, what[stage], s->t_plan, h->opts.order,
                h->opts.leaf_size);
        fprintf(stderr, "%s %s: workspace %.4f s\n", name, what[stage], s->t_workspace);
    } else {
        for (k = 0; k < 8; k++) fprintf(stderr, "%s evaluate: %s %.4f s\n", name, pass[k], t[k]);
    }
    fprintf(stderr, "%s %s: %.4f s, %.1f MiB held\n", name, what[stage],
            stage == 1 ? s->t_plan + s->t_points + s->t_workspace : stage == 2 ? s->t_update : s->t_evaluate,
            s->bytes / 1048576.0);
}

// >>orders: an oscillating kernel's wide levels at a higher order

#if KIFMM__HAS_QT & KIFMM_HAS_WAVES
/* An oscillating kernel's error grows with the boxes' width in wavelengths
 * (docs/kernels.md: helmholtz at p = 8, 1.3e-8 up to 0.75 wavelengths,
 * 6.9e-8 at 1.25, the gradient's 1.9e-6 there): a level whose boxes are too
 * wide for the handle's order takes a higher one (with create or
 * update_points; not in MPI mode, opts.tol, whose order is chosen for the
 * widest boxes already, or a kernel without an error table beyond its
 * order's limit); KIFMM_ERR_FREQUENCY where none reaches it. Its plan of
 * that order (the handle's own: surfaces, lattice) is where its operators'
 * builders and passes read them (__lpl); its sets are the handle's plan's,
 * keyed by the orders of the level and its neighbours (__set_orders); the
 * expansions of each level have its length (__eo). */

/* The first level whose expansions the passes use: the first with M2L,
 * of a box of a W list or of an owner of an X list (nlev: none). */
KIFMM__FN int KIFMM__F(__waves_lmin)(const kifmm__tree *t)
{
    int l, lmin = t->nlev;
    int32_t b, e;
    for (l = 0; l < t->nlev && lmin == t->nlev; l++)
        if (t->m2lo[l + 1] > t->m2lo[l]) lmin = l;
    for (b = 0; b < t->nbox; b++) {
        if (t->xo[b + 1] > t->xo[b] && t->lev[b] < lmin) lmin = t->lev[b];
        for (e = t->wo[b]; e < t->wo[b + 1]; e++)
            if (t->lev[t->w[e]] < lmin) lmin = t->lev[t->w[e]];
    }
    return lmin;
}

/* The order of a level whose boxes are x wavelengths wide (the
 * wavenumber's real part), or 0 if none serves it. The handle's order p
 * where that is within the most it takes (the kernel's _WAVES_MAX,
 * measured: docs/kernels.md) and, with the kernel's error table, its
 * error there (kifmm__waves_err) at most KIFMM_RAISE_SLACK times its
 * error at the narrowest width; else, where the handle may raise (raise),
 * the lowest higher order that is. opts.tol: p where its error at x, 1.5
 * times the table's, is within tol (as __tol_root chose it). */
KIFMM__FN int KIFMM__F(__level_order)(const KIFMM_NAME *h, double x)
{
    static const double most[KIFMM_MAX_ORDER + 1] = KIFMM__K(_WAVES_MAX);
    const int p = h->opts.order;
    const int top = h->ord.raise && h->opts.tol == 0.0 && KIFMM_RAISE_SLACK > 0 ? KIFMM_MAX_ORDER : p;
    int q;
#if KIFMM__HAS_QT & KIFMM_HAS_TOL
    const int w = KIFMM_TOL_WAVES_NW + 1;
    const double *err = KIFMM__F(__tol_errors)();
    if (h->opts.tol != 0.0) return 1.5 * kifmm__waves_err(err + p * w, most[p], x) <= h->opts.tol ? p : 0;
    if (err[p * w] > 0.0 && top > p) {
        for (q = p; q <= top; q++)
            if (kifmm__waves_err(err + q * w, most[q], x) <= KIFMM_RAISE_SLACK * err[p * w]) return q;
        return x <= most[p] ? p : 0; /* (none meets it: p within its limit, as unraised) */
    }
#endif
    for (q = p; q <= top; q++)
        if (x <= most[q]) return q;
    return 0;
}

/* The orders q[l] of the levels of a tree of the handle's width and nlev
 * levels whose expansions are used from level lmin; KIFMM_ERR_FREQUENCY
 * where a level's boxes are too wide for every order it may take. */
KIFMM__FN int KIFMM__F(__orders_of)(const KIFMM_NAME *h, int lmin, int *q)
{
    const kifmm__tree *t = h->tree;
    const double k = KIFMM__K(_wavenumber)(h->opts.kernel_param) / (2.0 * 3.14159265358979323846);
    int l;
    for (l = 0; l < t->nlev; l++) {
        q[l] = h->opts.order;
        if (l >= lmin && !(q[l] = KIFMM__F(__level_order)(h, t->width / (double)((int64_t)1 << l) * k)))
            return KIFMM_ERR_FREQUENCY;
    }
    return KIFMM_SUCCESS;
}

/* The handle takes the orders q (a plan of its own per raised order) and
 * the expansions' offsets of levels of n[l] boxes. */
KIFMM__FN int KIFMM__F(__orders_take)(KIFMM_NAME *h, const int *q, const double *n)
{
    const int p = h->opts.order, nl = h->tree->nlev;
    int l, d;
    for (l = 0; l < nl; l++) {
        kifmm_opts o = h->pl->opts;
        if (q[l] == p) continue;
        o.order = q[l];
        if (!h->ord.own[q[l]]) {
            if (!(h->ord.own[q[l]] = KIFMM__F(__plan_new)(&o))) return KIFMM_ERR_NOMEM;
            h->held += h->ord.own[q[l]]->held;
        }
        h->ord.pl[l] = h->ord.own[q[l]];
        if (q[l] > h->ord.pmax) h->ord.pmax = q[l];
        h->ord.up = 1;
    }
    for (d = 0; d < 2 && h->ord.up; d++)
        for (h->ord.eo[d][0] = 0, l = 0; l < nl; l++) {
            const kifmm__surf *s = KIFMM__F(__sf)(h, l);
            h->ord.eo[d][l + 1] = h->ord.eo[d][l] + (size_t)n[l] * (size_t)(d ? s->nde : s->ne);
        }
    return KIFMM_SUCCESS;
}

/* Each level's order for the handle's tree (ord), before the FFT's slabs
 * and the operators. */
KIFMM__FN int KIFMM__F(__orders)(KIFMM_NAME *h)
{
    const kifmm__tree *t = h->tree;
    double n[KIFMM__D + 2];
    int q[KIFMM__D + 2], l, rc = KIFMM__F(__orders_of)(h, KIFMM__F(__waves_lmin)(t), q);
    for (l = 0; l < t->nlev; l++) n[l] = (double)(t->loff[l + 1] - t->loff[l]);
    return rc ? rc : KIFMM__F(__orders_take)(h, q, n);
}
#endif

/* The points' part of a handle: the tree over them and what it decides
 * (the levels' orders, the FFT M2L's colleagues and slabs, the mutual near
 * field's chunks). */
KIFMM__FN int KIFMM__F(__points_build)(KIFMM_NAME *h, int64_t ns, const KIFMM__R *src, int64_t nt,
                                       const KIFMM__R *trg)
{
    int rc = KIFMM__F(__points_tree)(h, ns, src, nt, trg);
#if KIFMM__HAS_QT & KIFMM_HAS_WAVES
    if (!rc) rc = KIFMM__F(__orders)(h); /* before the slabs and the operators */
#endif
#if KIFMM__FFT
    if (!rc) rc = KIFMM__F(__points_fft)(h);
#endif
    if (!rc && KIFMM__MUTUAL && h->tree->same) rc = KIFMM__F(__pair_plan)(h);
    return rc;
}

/* The far images of the handle's periodic tree: the plan's entry built for
 * the same root (width, levels above the cell, the exchange's level and
 * whether its boxes are leaves), else built and added. Under the lock. */
KIFMM__FN int KIFMM__F(__plan_far)(KIFMM_NAME *h)
{
    KIFMM__F(_plan) *pl = h->pl;
    const kifmm__tree *t = h->tree;
    KIFMM__F(__far) *f;
    int j, rc;
    for (j = 0; j < pl->far.n; j++) {
        f = pl->far.set[j];
        if (f->width == t->width && f->kc == t->kc && f->zl == h->lat.zl && f->zsmall == h->lat.zsmall) {
            f->refs++;
            h->far = f;
            return KIFMM_SUCCESS;
        }
    }
    if (pl->far.n == pl->far.cap) {
        const int cap = 2 * pl->far.cap + 2;
        KIFMM__F(__far) **set = (KIFMM__F(__far) **)kifmm__alloc((size_t)cap, sizeof *set);
        if (!set) return KIFMM_ERR_NOMEM;
        if (pl->far.n) memcpy(set, pl->far.set, (size_t)pl->far.n * sizeof *set);
        pl->held += (size_t)(cap - pl->far.cap) * sizeof *set;
        kifmm__free(pl->far.set);
        pl->far.set = set;
        pl->far.cap = cap;
    }
    if (!(f = (KIFMM__F(__far) *)kifmm__calloc(1, sizeof *f))) return KIFMM_ERR_NOMEM;
    f->width = t->width, f->kc = t->kc, f->zl = h->lat.zl, f->zsmall = h->lat.zsmall;
    h->far = f; /* the builders write into h->far */
    rc = KIFMM__F(__lattice_build)(h);
    f->neutral = KIFMM__SI && !f->bq;
    if (rc) {
        KIFMM__F(__far_free)(f);
        h->far = NULL;
        return rc;
    }
    f->refs = 1;
    pl->far.set[pl->far.n++] = f;
    pl->held += sizeof *f + f->held;
    return KIFMM_SUCCESS;
}

/* The handle's operator sets (__precompute) and a periodic tree's far
 * images (__plan_far) from its plan, built into it where it lacks them;
 * *bytes: the plan's size after. Under the plan's lock. */
KIFMM__FN int KIFMM__F(__plan_ops)(KIFMM_NAME *h, double *bytes)
{
    int rc, l, a;
    kifmm__lock_take(&h->pl->lock);
    rc = KIFMM__F(__precompute)(h);
    if (!rc && h->tree->periodic) rc = KIFMM__F(__plan_far)(h);
    *bytes = (double)h->pl->held;
    h->stats.cache_read = h->pl->cache.read;
    h->stats.cache_written = h->pl->cache.written;
    kifmm__lock_give(&h->pl->lock);
    for (l = 0; l < h->tree->nlev; l++)
        for (a = 0; h->lv[l] && a < KIFMM__SD * KIFMM__SD; a++) h->nz[a] |= h->lv[l]->nz[a];
    return rc;
}

/* U's points (__far_root) in the tree's frame: about the root's centre. */
KIFMM__FN int KIFMM__F(__points_lattice)(KIFMM_NAME *h)
{
    const KIFMM__F(__far) *f = h->far;
    double c0[3], h0;
    if (!f || !f->zu) return KIFMM_SUCCESS;
    h->lat.zt = (KIFMM__R *)kifmm__take(&h->held, (size_t)3 * f->nzu, sizeof(KIFMM__R));
    if (!h->lat.zt) return KIFMM_ERR_NOMEM;
    kifmm__box_center(h->tree, 0, c0, &h0);
    KIFMM__F(__place)(f->zunit, f->nzu, c0, f->zrad, h->lat.zt);
    return KIFMM_SUCCESS;
}

/* The workspace: per-thread buffers, the FFT M2L's spectra and products,
 * the solves' boxes and the expansions of nrhs vectors. */
KIFMM__FN int KIFMM__F(__work_build)(KIFMM_NAME *h, int nrhs)
{
    int rc = KIFMM__F(__work_buffers)(h);
#if KIFMM__FFT
    if (!rc) rc = KIFMM__F(__work_fft)(h, h->pl->fft.single ? sizeof(float) : sizeof(double));
    if (!rc) rc = KIFMM__F(__work_fout)(h);
#endif
    if (!rc) rc = KIFMM__F(__work_solves)(h, nrhs);
    return rc;
}

/* The handle's figures for <prefix>_stats after create or update_points. */
KIFMM__FN void KIFMM__F(__stats_set)(KIFMM_NAME *h)
{
    KIFMM__F(__describe)(h);
    h->stats.levels = h->tree->nlev;
    h->stats.boxes = h->tree->nbox;
    h->stats.leaves = h->tree->nleaves;
    h->stats.bytes = KIFMM__F(__held)(h, h->pbytes);
    h->stats.plan_bytes = h->pbytes;
    h->stats.tree_bytes = (double)h->tree->held;
}

/* A handle's own tree, empty, with the options that shape it (which a
 * handle made on it must share: __tree_fits); NULL if out of memory. */
KIFMM__FN kifmm_tree *KIFMM__F(__tree_own)(const kifmm_opts *o, int64_t ns, int64_t nt)
{
    kifmm_tree *tr = kifmm__tree_new(ns, nt);
    if (!tr) return NULL;
    tr->single = KIFMM__FLOAT;
    tr->vlists = !KIFMM__FFT;
    tr->leaf_size = o->leaf_size;
    tr->max_depth = o->max_depth;
    memcpy(tr->period, o->period, sizeof tr->period);
    memcpy(tr->domain, o->domain, sizeof tr->domain);
    return tr;
}

/* Whether a handle with options o, whose leaf size and depth were given as
 * shape (0: chosen), can use the tree tr: the same precision, period and
 * domain (adopt: o's all 0 take the tree's), V lists if the M2L is dense,
 * the leaf size and depth given or left to the tree (then o takes the
 * tree's). */
KIFMM__FN int KIFMM__F(__tree_fits)(const kifmm_tree *tr, const int *shape, int adopt,
                                    kifmm_opts *o)
{
    int d, fits = tr->single == KIFMM__FLOAT && (KIFMM__FFT || tr->vlists);
    if (adopt && !o->period[0] && !o->period[1] && !o->period[2] && !o->domain[0] &&
        !o->domain[1] && !o->domain[2] && !o->domain[3]) {
        memcpy(o->period, tr->period, sizeof o->period);
        memcpy(o->domain, tr->domain, sizeof o->domain);
    }
    for (d = 0; d < 3; d++) fits &= tr->period[d] == o->period[d];
    for (d = 0; d < 4; d++) fits &= tr->domain[d] == o->domain[d];
    fits &= (!shape[0] || shape[0] == tr->leaf_size) && (!shape[1] || shape[1] == tr->max_depth);
    if (!fits) return KIFMM_ERR_TREE;
    o->leaf_size = tr->leaf_size;
    o->max_depth = tr->max_depth;
    /* the tree's points were checked for its kernel, not this one's */
    return KIFMM__F(__check_far)(o->kernel_param, 2.0 * sqrt(3.0) * tr->t.width);
}

/* A handle on plan pl (one more of its handles) for these points, checked
 * (options o, pl's), or on the tree tr (fitting o: __tree_fits) if not
 * NULL: the points' part; the operator sets and far images the tree needs,
 * from pl where it has them, else built into it; the workspace for nrhs
 * vectors. raise: whether wide levels may take a higher order (>>orders;
 * not in MPI mode). *out is NULL on failure, with nothing of pl or tr
 * taken. */
KIFMM__FN int KIFMM__F(__build)(KIFMM_NAME **out, KIFMM__F(_plan) *pl, int shared, int raise, int nrhs,
                                const kifmm_opts *o, const int *shape, kifmm_tree *tr,
                                int64_t ns, const KIFMM__R *src, int64_t nt, const KIFMM__R *trg)
{
    KIFMM_NAME *h;
    double t0 = kifmm__now(), t1, t2;
    int rc = KIFMM_SUCCESS;
    *out = NULL;
    if (!(h = (KIFMM_NAME *)kifmm__calloc(1, sizeof *h))) return KIFMM_ERR_NOMEM;
    h->held = sizeof *h;
    h->opts = *o;
    h->opts.operator_cache = pl->opts.operator_cache; /* the plan's copy */
    h->shared = shared;
    h->ord.raise = raise;
    h->shape[0] = shape[0], h->shape[1] = shape[1];
    kifmm__lock_take(&pl->lock);
    pl->refs++;
    h->pbytes = (double)pl->held;
    kifmm__lock_give(&pl->lock);
    h->pl = pl;
    if (tr) {
        kifmm__refs_add(&tr->refs, 1);
        h->tshared = 1;
        ns = tr->t.ns;
        nt = tr->t.nt;
    } else if (!(tr = KIFMM__F(__tree_own)(o, ns, nt))) {
        KIFMM__F(_destroy)(h);
        return KIFMM_ERR_NOMEM;
    }
    h->tr = tr;
    h->tree = &tr->t;
    t1 = t2 = t0;
    if (ns > 0 && nt > 0) {
        rc = KIFMM__F(__points_build)(h, ns, src, nt, trg);
        t1 = kifmm__now();
        if (!rc) rc = KIFMM__F(__plan_ops)(h, &h->pbytes);
        t2 = kifmm__now();
        if (!rc) rc = KIFMM__F(__points_lattice)(h);
        if (!rc) rc = KIFMM__F(__work_build)(h, nrhs);
    }
    if (rc) {
        KIFMM__F(_destroy)(h);
        return rc;
    }
    h->stats.t_points = t1 - t0;
    h->stats.t_plan = t2 - t1;
    h->stats.t_workspace = kifmm__now() - t2;
    KIFMM__F(__stats_set)(h);
    *out = h;
    return KIFMM_SUCCESS;
}

/* create, on these points or (if not NULL) on tree's. */
KIFMM__FN int KIFMM__F(__create)(KIFMM_NAME **out, const kifmm_opts *opts, kifmm_tree *tree,
                                 int64_t nsources, const KIFMM__R *src_xyz, int64_t ntargets,
                                 const KIFMM__R *trg_xyz)
{
    KIFMM__F(_plan) *pl;
    KIFMM_NAME tmp;
    kifmm_opts o;
    const int shape[2] = {opts ? opts->leaf_size : 0, opts ? opts->max_depth : 0};
    double t0 = kifmm__now();
    int rc;
    if (!out) return KIFMM_ERR_NULL;
    *out = NULL;
    if ((rc = KIFMM__F(__validate)(opts, nsources, src_xyz, ntargets, trg_xyz, &o))) return rc;
    if (tree && (rc = KIFMM__F(__tree_fits)(tree, shape, 1, &o))) return rc;
    if ((rc = KIFMM__TOL_POINTS(&o, tree ? o.leaf_size : shape[0], tree, nsources, src_xyz, ntargets,
                                trg_xyz)))
        return rc;
    if (!(pl = KIFMM__F(__plan_new)(&o))) return KIFMM_ERR_NOMEM;
    rc = KIFMM__F(__build)(out, pl, 0, 1, 1, &o, shape, tree, nsources, src_xyz, ntargets, trg_xyz);
    memset(&tmp, 0, sizeof tmp); /* the plan is the handle's alone now, or freed */
    tmp.pl = pl;
    KIFMM__F(__plan_release)(&tmp);
    if (rc) return rc;
    (*out)->stats.t_plan += kifmm__now() - t0 - (*out)->stats.t_points - (*out)->stats.t_plan -
                            (*out)->stats.t_workspace; /* the checks and the plan's surfaces */
    (*out)->stats.t_tree = (*out)->stats.t_points;
    (*out)->stats.t_operators = (*out)->stats.t_plan + (*out)->stats.t_workspace;
    if (o.verbose) KIFMM__F(__report)(*out, 1);
    return KIFMM_SUCCESS;
}

KIFMM__API int KIFMM__F(_create)(KIFMM_NAME **out, const kifmm_opts *opts, int64_t nsources,
                                 const KIFMM__R *src_xyz, int64_t ntargets,
                                 const KIFMM__R *trg_xyz)
{
    return KIFMM__F(__create)(out, opts, NULL, nsources, src_xyz, ntargets, trg_xyz);
}

KIFMM__API int KIFMM__F(_create_on_tree)(KIFMM_NAME **out, const kifmm_opts *opts, kifmm_tree *tree)
{
    if (out) *out = NULL;
    if (!out || !tree) return KIFMM_ERR_NULL;
    return KIFMM__F(__create)(out, opts, tree, 0, NULL, 0, NULL);
}

KIFMM__API kifmm_tree *KIFMM__F(_tree)(const KIFMM_NAME *h) { return h ? h->tr : NULL; }

/* update_points, onto these points or (if not NULL) onto tree's. */
KIFMM__FN int KIFMM__F(__update)(KIFMM_NAME *h, kifmm_tree *tree, int64_t nsources,
                                 const KIFMM__R *src_xyz, int64_t ntargets, const KIFMM__R *trg_xyz)
{
    KIFMM_NAME *n, tmp;
    KIFMM__F(_plan) *pl;
    kifmm_opts o;
    kifmm_stats st;
    double t0 = kifmm__now();
    int rc;
    if (!h) return KIFMM_ERR_NULL;
#if defined(KIFMM_MPI)
    if (h->mpi) return tree ? KIFMM_ERR_TREE : KIFMM__F(__mpi_update)(h, nsources, src_xyz, ntargets, trg_xyz);
#endif
    o = h->opts;
    pl = h->pl;
    if (tree && (rc = KIFMM__F(__tree_fits)(tree, h->shape, 0, &o))) return rc;
    if (!tree && (rc = KIFMM__F(__check_sets)(&o, nsources, src_xyz, ntargets, trg_xyz))) return rc;
    /* opts.tol's order for the new root, on a plan of its own if it moves
     * (a shared plan's has opts.domain's root) */
    if (!h->shared && (rc = KIFMM__TOL_POINTS(&o, tree ? o.leaf_size : h->shape[0], tree, nsources,
                                               src_xyz, ntargets, trg_xyz)))
        return rc;
    if (o.order != pl->opts.order && !(pl = KIFMM__F(__plan_new)(&o))) return KIFMM_ERR_NOMEM;
    /* on the same plan, which keeps the operator sets both trees use; as
     * many vectors' workspace as the handle has grown to */
    rc = KIFMM__F(__build)(&n, pl, h->shared, h->ord.raise, h->work.w ? h->work.w->nrhs : 1, &o, h->shape,
                           tree, nsources, src_xyz, ntargets, trg_xyz);
    if (pl != h->pl) { /* the new plan is the new state's alone, or freed */
        memset(&tmp, 0, sizeof tmp);
        tmp.pl = pl;
        KIFMM__F(__plan_release)(&tmp);
    }
    if (rc) return rc;
    /* the new state into the caller's handle, the old one freed (and the
     * plan's entries only it used) */
    st = h->stats;
    tmp = *h;
    *h = *n;
    *n = tmp;
    KIFMM__F(_destroy)(n);
    kifmm__lock_take(&h->pl->lock); /* the plan without the sets only the old tree used */
    h->pbytes = (double)h->pl->held;
    kifmm__lock_give(&h->pl->lock);
    KIFMM__F(__stats_set)(h);
    h->stats.t_tree = st.t_tree; /* create's, and the last evaluate's */
    h->stats.t_operators = st.t_operators;
    h->stats.t_p2m = st.t_p2m, h->stats.t_m2m = st.t_m2m, h->stats.t_m2l = st.t_m2l;
    h->stats.t_l2l = st.t_l2l, h->stats.t_p2l = st.t_p2l, h->stats.t_l2p = st.t_l2p;
    h->stats.t_m2p = st.t_m2p, h->stats.t_p2p = st.t_p2p, h->stats.t_evaluate = st.t_evaluate;
    h->stats.t_update = kifmm__now() - t0;
    if (h->opts.verbose) KIFMM__F(__report)(h, 2);
    return KIFMM_SUCCESS;
}

KIFMM__API int KIFMM__F(_update_points)(KIFMM_NAME *h, int64_t nsources, const KIFMM__R *src_xyz,
                                        int64_t ntargets, const KIFMM__R *trg_xyz)
{
    return KIFMM__F(__update)(h, NULL, nsources, src_xyz, ntargets, trg_xyz);
}

KIFMM__API int KIFMM__F(_update_on_tree)(KIFMM_NAME *h, kifmm_tree *tree)
{
    if (!h || !tree) return KIFMM_ERR_NULL;
    return KIFMM__F(__update)(h, tree, 0, NULL, 0, NULL);
}

KIFMM__API int KIFMM__F(_plan_create)(KIFMM__F(_plan) **out, const kifmm_opts *opts)
{
    KIFMM__F(_plan) *pl;
    kifmm_opts o;
    int rc;
    if (!out) return KIFMM_ERR_NULL;
    *out = NULL;
    if ((rc = KIFMM__F(__validate)(opts, 0, NULL, 0, NULL, &o))) return rc;
    if (KIFMM__TOL_UNROOTED(o)) return KIFMM_ERR_TOL;
    if (KIFMM__SI && !KIFMM__EWALD && o.period[0] > 0.0 && o.period[1] > 0.0 && o.period[2] > 0.0)
        return KIFMM_ERR_PERIODIC; /* as create: __lattice_build */
    if (!(pl = KIFMM__F(__plan_new)(&o))) return KIFMM_ERR_NOMEM;
    pl->shape[0] = opts ? opts->leaf_size : 0;
    pl->shape[1] = opts ? opts->max_depth : 0;
#if KIFMM__SI
    { /* the one set of every tree, with the M2L's: built now, kept with the plan */
        KIFMM_NAME *c = (KIFMM_NAME *)kifmm__calloc(1, sizeof *c);
        KIFMM__F(__ops) *e = NULL;
        const double r = 1.0;
        const int m2l = 1, from = -1;
        rc = c ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM;
        if (c) c->opts = o, c->pl = pl;
        if (!rc) rc = KIFMM__F(__ops_build)(c, 1, &r, &m2l, &from, &e);
#if KIFMM__FFT
        if (!rc) rc = KIFMM__F(__keep_blocks)(c, &e, 1, 1);
#endif
        if (!rc) rc = KIFMM__F(__ops_add)(pl, e);
        else if (e) KIFMM__F(__ops_free)(e), kifmm__free(e);
        kifmm__free(c);
        if (rc) {
            KIFMM__F(__plan_free)(pl);
            return rc;
        }
    }
#endif
    *out = pl;
    return KIFMM_SUCCESS;
}

/* create_with_plan, on these points or (if not NULL) on tree's. */
KIFMM__FN int KIFMM__F(__with_plan)(KIFMM_NAME **out, KIFMM__F(_plan) *plan, kifmm_tree *tree,
                                    int64_t nsources, const KIFMM__R *src_xyz, int64_t ntargets,
                                    const KIFMM__R *trg_xyz)
{
    kifmm_opts o;
    int rc;
    if (!out) return KIFMM_ERR_NULL;
    *out = NULL;
    if (!plan) return KIFMM_ERR_NULL;
    o = plan->opts;
    if (tree && (rc = KIFMM__F(__tree_fits)(tree, plan->shape, 0, &o))) return rc;
    if (!tree && (rc = KIFMM__F(__check_sets)(&o, nsources, src_xyz, ntargets, trg_xyz))) return rc;
    rc = KIFMM__F(__build)(out, plan, 1, 1, 1, &o, plan->shape, tree, nsources, src_xyz, ntargets,
                           trg_xyz);
    if (!rc) {
        (*out)->stats.t_tree = (*out)->stats.t_points;
        (*out)->stats.t_operators = (*out)->stats.t_plan + (*out)->stats.t_workspace;
        if (plan->opts.verbose) KIFMM__F(__report)(*out, 1);
    }
    return rc;
}

KIFMM__API int KIFMM__F(_create_with_plan)(KIFMM_NAME **out, KIFMM__F(_plan) *plan, int64_t nsources,
                                           const KIFMM__R *src_xyz, int64_t ntargets,
                                           const KIFMM__R *trg_xyz)
{
    return KIFMM__F(__with_plan)(out, plan, NULL, nsources, src_xyz, ntargets, trg_xyz);
}

KIFMM__API int KIFMM__F(_create_with_plan_on_tree)(KIFMM_NAME **out, KIFMM__F(_plan) *plan,
                                                   kifmm_tree *tree)
{
    if (out) *out = NULL;
    if (!out || !tree) return KIFMM_ERR_NULL;
    return KIFMM__F(__with_plan)(out, plan, tree, 0, NULL, 0, NULL);
}

KIFMM__API void KIFMM__F(_plan_destroy)(KIFMM__F(_plan) *plan)
{
    KIFMM_NAME tmp;
    if (!plan) return;
    memset(&tmp, 0, sizeof tmp);
    tmp.pl = plan;
    KIFMM__F(__plan_release)(&tmp);
}

/* evaluate_many's checks; 1 for a call with nothing to compute (outputs
 * zeroed where there are targets but no sources). */
KIFMM__FN int KIFMM__F(__eval_check)(const KIFMM_NAME *h, int nrhs, const KIFMM__R *densities,
                                     KIFMM__R *out, int *rc)
{
    const kifmm__tree *t;
    size_t qper, oper;
    *rc = KIFMM_SUCCESS;
    if (!h) return *rc = KIFMM_ERR_NULL;
    if (nrhs < 0) return *rc = KIFMM_ERR_COUNT;
    t = h->tree;
    if ((t->ns > 0 && nrhs > 0 && !densities) || (t->nt > 0 && nrhs > 0 && !out))
        return *rc = KIFMM_ERR_NULL;
    if (t->nt == 0 || nrhs == 0) return 1;
    qper = (size_t)t->ns * KIFMM__UD;
    oper = (size_t)t->nt * KIFMM__TD;
    if ((size_t)nrhs > (size_t)PTRDIFF_MAX / sizeof(KIFMM__R) / (qper > oper ? qper : oper))
        return *rc = KIFMM_ERR_COUNT; /* no array holds that many vectors */
    if (t->ns > 0) return 0;
    memset(out, 0, (size_t)nrhs * oper * sizeof(KIFMM__R));
    return 1;
}

/* The workspace for cap vectors, if it has fewer (the first call with more
 * vectors than any before grows it). */
KIFMM__FN int KIFMM__F(__eval_grow)(KIFMM_NAME *h, int cap)
{
    KIFMM__F(__work) *nw;
    if (h->work.w->nrhs >= cap) return KIFMM_SUCCESS;
    if (!(nw = KIFMM__F(__work_new)(h, cap))) return KIFMM_ERR_NOMEM;
    KIFMM__F(__work_free)(h->work.w);
    h->work.w = nw;
    h->stats.bytes = KIFMM__F(__held)(h, h->pbytes);
    return KIFMM_SUCCESS;
}

/* The QD densities the kernel is linear in, from one source's UD values
 * (through the kernel's _density map, if it has one, at parameters prm). */
KIFMM__FN void KIFMM__F(__density_of)(const double *prm, const KIFMM__R *in, double *lin)
{
    int k;
#if KIFMM__HAS_QT & KIFMM_HAS_DENSITY
    double u[KIFMM__UD];
    for (k = 0; k < KIFMM__UD; k++) u[k] = (double)in[k];
    KIFMM__K(_density)(prm, u, lin);
#else
    (void)prm;
    for (k = 0; k < KIFMM__QD; k++) lin[k] = (double)in[k];
#endif
}

/* w[k], *g: density component k's weight in __density_scale, 2^(gk - g),
 * where 2^gk is the largest factor its equivalent densities gain in the
 * tree's boxes (h^qlo or h^qhi at the root's half-width h or the deepest
 * level's, __density_degrees: a dipole's d / h in the smallest boxes), and
 * g the largest gk rounded up. All 1 for kernels whose components all
 * scale as the surface kernel's (g = 0). */
KIFMM__FN void KIFMM__F(__density_weights)(const KIFMM_NAME *h, double *w, int *g)
{
    const double l0 = log2(0.5 * h->tree->width), lf = l0 - (double)(h->tree->nlev - 1);
    double gk[KIFMM__QD], gm = 0.0;
    int k;
    for (k = 0; k < KIFMM__QD; k++) {
        const double lo = h->pl->ops.qlo[k], hi = h->pl->ops.qhi[k];
        const double a = lo * l0 > lo * lf ? lo * l0 : lo * lf, b = hi * l0 > hi * lf ? hi * l0 : hi * lf;
        gk[k] = a > b ? a : b;
        gm = k == 0 || gk[k] > gm ? gk[k] : gm;
    }
    *g = (int)ceil(gm);
    for (k = 0; k < KIFMM__QD; k++) w[k] = pow(2.0, gk[k] - (double)*g);
}

/* e[r]: the power of two that brings vector r's largest equivalent density
 * into about [0.5, 1): its densities (after the kernel's _density map, if
 * it has one: stokes_dl's products), each times its component's largest
 * gain in the tree's boxes (__density_weights). The passes run on
 * densities scaled by 2^-e and the outputs are scaled back: exact (powers
 * of two), and no float M2L spectra or float instance overflow or lose
 * digits to subnormals on densities far from 1 (masses of 1e40 kg,
 * charges of 1e-19 C) or on dipoles in boxes far from unit size (d / h at
 * h = 1e-36: the float spectra's range). A map's products beyond the range
 * leave e = 0: the outputs then come out infinite (KIFMM_ERR_OVERFLOW). */
KIFMM__FN void KIFMM__F(__density_scale)(const KIFMM_NAME *h, int nr, const KIFMM__R *d, int *e)
{
    const int64_t ns = h->tree->ns;
    const size_t uper = (size_t)ns * KIFMM__UD;
#if defined(KIFMM_MPI)
    const int64_t p0 = h->px.cum ? ns - h->px.n : ns; /* proxies from p0 on: their own values */
#else
    const int64_t p0 = ns;
#endif
    double wk[KIFMM__QD];
    int r, g;
    KIFMM__F(__density_weights)(h, wk, &g);
    for (r = 0; r < nr; r++) {
        double m = 0.0;
        KIFMM__OMP(parallel for schedule(static) num_threads(h->opts.nthreads) reduction(max : m) if (uper > 65536))
        for (int64_t i = 0; i < ns; i++) {
            const KIFMM__R *u = d + r * uper + (size_t)i * KIFMM__UD;
            double lin[KIFMM__QD > KIFMM__UD ? KIFMM__QD : KIFMM__UD];
            int k;
            if (i < p0) {
                KIFMM__F(__density_of)(h->opts.kernel_param, u, lin);
                for (k = 0; k < KIFMM__QD; k++) {
                    const double v = fabs(lin[k]) * wk[k];
                    m = v > m ? v : m;
                }
            } else {
                /* the proxies' surface densities: as the surface kernel's */
                for (k = 0; k < KIFMM__UD; k++) {
                    const double v = ldexp(fabs((double)u[k]), -g);
                    m = v > m ? v : m;
                }
            }
        }
        e[r] = 0;
        if (m > 0.0 && m <= DBL_MAX) (void)frexp(m, &e[r]), e[r] += g;
        /* subnormal largest densities (from 2^-1074): 2^-e would overflow;
         * 2^1000 brings them to 2^-74 or more, normal in float too */
        if (e[r] < -1000) e[r] = -1000;
    }
}

/* The densities of nr vectors in sorted order, each sorted source writing
 * its own (through the kernel's _density map, if it has one), times 2^-e[r]
 * (__density_scale). */
KIFMM__FN void KIFMM__F(__gather_densities)(const KIFMM_NAME *h, KIFMM__F(__work) *w, int nr,
                                            const KIFMM__R *d, const int *e)
{
    const kifmm__tree *t = h->tree;
    const size_t qper = (size_t)t->ns * KIFMM__QD, uper = (size_t)t->ns * KIFMM__UD;
    KIFMM__OMP(parallel for schedule(static) num_threads(h->opts.nthreads))
    for (int64_t i = 0; i < t->ns; i++) {
        int k, r;
        for (r = 0; r < nr; r++) {
            KIFMM__R *q = w->qs + r * qper + i * KIFMM__QD;
            const double sc = ldexp(1.0, -e[r]);
            double lin[KIFMM__QD];
            KIFMM__F(__density_of)(h->opts.kernel_param, d + r * uper + t->sperm[i] * KIFMM__UD, lin);
            for (k = 0; k < KIFMM__QD; k++) q[k] = (KIFMM__R)(lin[k] * sc);
        }
    }
#if defined(KIFMM_MPI)
    /* MPI mode's proxies: their first SD values are the surface kernel's
     * densities (__p2p_roles) */
    if (!h->px.cum) return;
    KIFMM__OMP(parallel for schedule(static) num_threads(h->opts.nthreads))
    for (int64_t i = 0; i < t->ns; i++) {
        const int64_t p = h->px.cum[i];
        int k, r;
        for (r = 0; r < nr && h->px.cum[i + 1] > p; r++) {
            const double sc = ldexp(1.0, -e[r]);
            const KIFMM__R *u = d + r * uper + t->sperm[i] * KIFMM__UD;
            for (k = 0; k < KIFMM__SD; k++)
                w->qp[((size_t)r * h->px.n + p) * KIFMM__SD + k] = (KIFMM__R)(u[k] * sc);
        }
    }
#endif
}

/* One group of nr vectors (densities d, outputs o: the group's first
 * vectors): the densities in sorted order, the passes, the outputs in the
 * caller's order. Outputs are summed in sorted order (outs) and gathered
 * at the end, or added by each task to the caller's out (dst, see the
 * workspace). */
KIFMM__FN void KIFMM__F(__eval_group)(KIFMM_NAME *h, int nr, const KIFMM__R *d, KIFMM__R *o)
{
    const kifmm__tree *t = h->tree;
    KIFMM__F(__work) *w = h->work.w;
    const size_t oper = (size_t)t->nt * KIFMM__TD;
    int l, e[KIFMM__RHS_MAX], r, scaled = 0;
    KIFMM__F(__density_scale)(h, nr, d, e);
    for (r = 0; r < nr; r++) scaled |= e[r] != 0;
    KIFMM__F(__gather_densities)(h, w, nr, d, e);
    w->dst = o;
    memset(w->outs ? w->outs : w->dst, 0, (size_t)nr * oper * sizeof(KIFMM__R));
    for (l = t->nlev - 1; l >= kifmm__lmin(t); l--) KIFMM__F(__upward)(h, w, nr, l);
    for (l = kifmm__lmin(t); l < t->nlev; l++) KIFMM__F(__downward)(h, w, nr, l);
    KIFMM__F(__leaves)(h, w, nr);
    if (h->far && h->far->bq) KIFMM__F(__background)(h, w, nr);
    w->dst = NULL;
    if (!w->outs) {
        for (r = 0; r < nr && scaled; r++) {
            /* 2^e in two factors: 2^1024 (densities near DBL_MAX) is not a double */
            const double ua = ldexp(1.0, e[r] / 2), ub = ldexp(1.0, e[r] - e[r] / 2);
            KIFMM__OMP(parallel for schedule(static) num_threads(h->opts.nthreads))
            for (size_t j = 0; j < oper; j++) o[r * oper + j] = (KIFMM__R)(o[r * oper + j] * ua * ub);
        }
        return;
    }
    /* each sorted target i writes its own outputs */
    KIFMM__OMP(parallel for schedule(static) num_threads(h->opts.nthreads))
    for (int64_t i = 0; i < t->nt; i++) {
        int k, rr;
        for (rr = 0; rr < nr; rr++) {
            const double ua = ldexp(1.0, e[rr] / 2), ub = ldexp(1.0, e[rr] - e[rr] / 2); /* as above */
            for (k = 0; k < KIFMM__TD; k++)
                o[rr * oper + t->tperm[i] * KIFMM__TD + k] =
                    (KIFMM__R)(w->outs[rr * oper + i * KIFMM__TD + k] * ua * ub);
        }
    }
}

/* Periodic trees of scale-invariant kernels: KIFMM_ERR_NEUTRAL unless every
 * vector's densities sum to zero per surface component (through lat.mu: a
 * dipole's kinds carry none), to 1e-10 (float: 1e-4) of the sum of their
 * magnitudes. */
KIFMM__FN int KIFMM__F(__check_neutral)(const KIFMM_NAME *h, int nrhs, const KIFMM__R *d)
{
    const kifmm__tree *t = h->tree;
    const double tol = KIFMM__FLOAT ? 1e-4 : 1e-10;
    int r, b, bad = 0;
    if (!h->far || !h->far->neutral) return KIFMM_SUCCESS;
    for (r = 0; r < nrhs; r++) {
        double q[KIFMM__SD], m[KIFMM__SD];
        for (b = 0; b < KIFMM__SD; b++) q[b] = m[b] = 0.0;
        for (int64_t i = 0; i < t->ns; i++) {
            double lin[KIFMM__QD];
            int k;
            KIFMM__F(__density_of)(h->opts.kernel_param,
                                   d + (size_t)r * t->ns * KIFMM__UD + (size_t)i * KIFMM__UD, lin);
            for (b = 0; b < KIFMM__SD; b++)
                for (k = 0; k < KIFMM__QD; k++) {
                    q[b] += h->far->mu[b + k * KIFMM__SD] * lin[k];
                    m[b] += fabs(h->far->mu[b + k * KIFMM__SD] * lin[k]);
                }
        }
        for (b = 0; b < KIFMM__SD; b++) bad |= !(fabs(q[b]) <= tol * m[b]);
    }
    return bad ? KIFMM_ERR_NEUTRAL : KIFMM_SUCCESS;
}

/* n values, KIFMM_ERR_DENSITY or KIFMM_ERR_OVERFLOW (code) if one is not
 * finite. */
KIFMM__FN int KIFMM__F(__check_finite)(size_t n, const KIFMM__R *v, int nth, int code)
{
    int bad = 0;
    KIFMM__OMP(parallel for schedule(static) num_threads(nth) reduction(| : bad) if (n > 65536))
    for (size_t i = 0; i < n; i++) bad |= !isfinite(v[i]);
    (void)nth;
    return bad ? code : KIFMM_SUCCESS;
}

KIFMM__API int KIFMM__F(_evaluate_many)(KIFMM_NAME *h, int nrhs, const KIFMM__R *densities,
                                        KIFMM__R *out)
{
    KIFMM__R *dcopy = NULL;
    size_t qper, oper;
    int r0, nr, cap, rc;
    double t0;
#if defined(KIFMM_MPI)
    if (h && h->mpi) return KIFMM__F(__mpi_evaluate)(h, nrhs, densities, out);
#endif
    if (KIFMM__F(__eval_check)(h, nrhs, densities, out, &rc)) return rc;
    if ((rc = KIFMM__F(__check_finite)((size_t)nrhs * h->tree->ns * KIFMM__UD, densities,
                                       h->opts.nthreads, KIFMM_ERR_DENSITY)))
        return rc;
    if ((rc = KIFMM__F(__check_neutral)(h, nrhs, densities))) return rc;
    qper = (size_t)h->tree->ns * KIFMM__UD;
    oper = (size_t)h->tree->nt * KIFMM__TD;
    cap = nrhs < KIFMM__RHS_MAX ? nrhs : KIFMM__RHS_MAX;
    if (nrhs > cap && kifmm__overlap(densities, (size_t)nrhs * qper * sizeof(KIFMM__R), out,
                                     (size_t)nrhs * oper * sizeof(KIFMM__R))) {
        /* in place (out over densities): each group of up to RHS_MAX
         * vectors reads its densities before it writes its outputs, so only
         * a later group's densities could be overwritten; those are copied */
        dcopy = (KIFMM__R *)kifmm__alloc((size_t)nrhs * qper, sizeof(KIFMM__R));
        if (!dcopy) return KIFMM_ERR_NOMEM;
        memcpy(dcopy, densities, (size_t)nrhs * qper * sizeof(KIFMM__R));
        densities = dcopy;
    }
    if ((rc = KIFMM__F(__eval_grow)(h, cap))) {
        kifmm__free(dcopy);
        return rc;
    }
    t0 = kifmm__now();
    h->stats.t_p2m = h->stats.t_m2m = h->stats.t_m2l = h->stats.t_l2l = h->stats.t_p2l = 0.0;
    h->stats.t_l2p = h->stats.t_m2p = h->stats.t_p2p = 0.0;
    for (r0 = 0; r0 < nrhs; r0 += nr) {
        nr = nrhs - r0 < cap ? nrhs - r0 : cap;
        KIFMM__F(__eval_group)(h, nr, densities + (size_t)r0 * qper, out + (size_t)r0 * oper);
    }
    h->stats.t_evaluate = kifmm__now() - t0;
    if (h->opts.verbose) KIFMM__F(__report)(h, 0);
    kifmm__free(dcopy);
    /* finite inputs in range can still overflow (huge densities, points a
     * hair apart): never a non-finite output with success */
    return KIFMM__F(__check_finite)((size_t)nrhs * oper, out, h->opts.nthreads, KIFMM_ERR_OVERFLOW);
}

KIFMM__API int KIFMM__F(_evaluate)(KIFMM_NAME *h, const KIFMM__R *densities, KIFMM__R *out)
{
    return KIFMM__F(_evaluate_many)(h, 1, densities, out);
}

KIFMM__API int KIFMM__F(_stats)(const KIFMM_NAME *h, kifmm_stats *out)
{
    if (!h || !out) return KIFMM_ERR_NULL;
#if defined(KIFMM_MPI)
    if (h->mpi) {
        KIFMM__F(__mpi_stats)(h, out);
        return KIFMM_SUCCESS;
    }
#endif
    *out = h->stats;
    return KIFMM_SUCCESS;
}

KIFMM__API int KIFMM__F(_options)(const KIFMM_NAME *h, kifmm_opts *used)
{
    if (!h || !used) return KIFMM_ERR_NULL;
    *used = h->opts;
    return KIFMM_SUCCESS;
}

/* direct's outputs at one target x from ns sources with lin, their QD
 * densities each (the kernel's _density map applied), summed in double */
KIFMM__FN void KIFMM__F(__direct_at)(const double *prm, const KIFMM__R *x, int64_t ns,
                                     const KIFMM__R *src, const double *lin, KIFMM__R *o)
{
    double acc[KIFMM__TD], k[KIFMM__TD * KIFMM__QD];
    int a, b;
    for (a = 0; a < KIFMM__TD; a++) acc[a] = 0.0;
    for (int64_t j = 0; j < ns; j++) {
        const KIFMM__R *y = src + 3 * j;
        KIFMM__K(_eval)(prm, (double)x[0] - (double)y[0], (double)x[1] - (double)y[1],
                        (double)x[2] - (double)y[2], k);
        for (a = 0; a < KIFMM__TD; a++)
            for (b = 0; b < KIFMM__QD; b++) acc[a] += k[a * KIFMM__QD + b] * lin[j * KIFMM__QD + b];
    }
    for (a = 0; a < KIFMM__TD; a++) o[a] = (KIFMM__R)acc[a];
}

KIFMM__API int KIFMM__F(_direct)(const kifmm_opts *opts, int64_t nsources, const KIFMM__R *src_xyz,
                                 const KIFMM__R *densities, int64_t ntargets,
                                 const KIFMM__R *trg_xyz, KIFMM__R *out)
{
    kifmm_opts o;
    double *lin;
    KIFMM__R *res;
    const size_t no = (size_t)(ntargets > 0 ? ntargets : 0) * KIFMM__TD * sizeof(KIFMM__R);
    int rc = KIFMM__F(__validate)(opts, nsources, src_xyz, ntargets, trg_xyz, &o), d;
    if (rc) return rc;
    if ((nsources > 0 && ntargets > 0 && !densities) || (ntargets > 0 && !out)) return KIFMM_ERR_NULL;
    for (d = 0; d < 3; d++)
        if (o.period[d] != 0.0) return KIFMM_ERR_PERIODIC;
    if (ntargets == 0) return KIFMM_SUCCESS; /* the densities are not read */
    if ((rc = KIFMM__F(__check_finite)((size_t)nsources * KIFMM__UD, densities, o.nthreads,
                                       KIFMM_ERR_DENSITY)))
        return rc;
    /* the densities are copied (lin) before out is written; the points are
     * read throughout */
    if (kifmm__overlap(out, no, src_xyz, (size_t)nsources * 3 * sizeof(KIFMM__R)) ||
        kifmm__overlap(out, no, trg_xyz, (size_t)ntargets * 3 * sizeof(KIFMM__R)))
        return KIFMM_ERR_OVERLAP;
    lin = (double *)kifmm__alloc((size_t)nsources * KIFMM__QD + 1, sizeof(double));
    res = (KIFMM__R *)kifmm__alloc((size_t)ntargets * KIFMM__TD, sizeof(KIFMM__R));
    if (!lin || !res) {
        kifmm__free(lin);
        kifmm__free(res);
        return KIFMM_ERR_NOMEM;
    }
    for (int64_t j = 0; j < nsources; j++)
        KIFMM__F(__density_of)(o.kernel_param, densities + j * KIFMM__UD, lin + j * KIFMM__QD);
    KIFMM__OMP(parallel for schedule(dynamic, 8) num_threads(o.nthreads))
    for (int64_t i = 0; i < ntargets; i++)
        KIFMM__F(__direct_at)(o.kernel_param, trg_xyz + 3 * i, nsources, src_xyz, lin,
                              res + i * KIFMM__TD);
    kifmm__free(lin);
    /* out is written only on success */
    rc = KIFMM__F(__check_finite)((size_t)ntargets * KIFMM__TD, res, o.nthreads, KIFMM_ERR_OVERFLOW);
    if (!rc) memcpy(out, res, no);
    kifmm__free(res);
    return rc;
}

/* ---- estimate_bytes: the memory of a handle before it is created ---- */

#if KIFMM__HAS_QT & KIFMM_HAS_WAVES
/* An oscillating kernel's levels' orders (>>orders) in the model's tree,
 * where its width is known (opts.domain; else every level has opts.order):
 * from level 2, where uniform points' trees start their M2L, each level
 * of 8^l boxes up to the model's count. */
KIFMM__FN int KIFMM__F(__model_orders)(KIFMM_NAME *h, const kifmm__shape *s)
{
    double n[KIFMM__D + 2], left = s->box, full = 1.0;
    int q[KIFMM__D + 2], l, rc;
    if (!(h->tree->width > 0.0) || h->tree->nlev > KIFMM__D + 1) return KIFMM_SUCCESS;
    if ((rc = KIFMM__F(__orders_of)(h, kifmm__lmin(h->tree), q))) return rc;
    for (l = 0; l < h->tree->nlev; l++, full *= 8.0) {
        n[l] = l + 1 < h->tree->nlev && full < left ? full : left;
        left -= n[l];
    }
    return KIFMM__F(__orders_take)(h, q, n);
}
#endif

/* A model of the handle create would build over points spread through a
 * cube: the expected tree's figures (kifmm__shape_uniform) where create has
 * the tree's, then what create derives from them alone, through its own
 * functions: surfaces, FFT plan, spectra slots, per-thread buffers, dense
 * M2L columns. Counts past the int32 fields are capped (create's tree could
 * not hold them either). */
KIFMM__FN int KIFMM__F(__model)(KIFMM_NAME *h, const kifmm__shape *s)
{
    kifmm__tree *t = &h->tr->t; /* the model writes the figures a tree would have */
    const double cap = 2e9;
    int rc = KIFMM_SUCCESS;
    t->nlev = s->nlev;
    t->nbox = (int32_t)(s->box < cap ? s->box : cap);
    h->work.mb = (int)(s->mb < cap ? s->mb : cap);
#if KIFMM__HAS_QT & KIFMM_HAS_WAVES
    if ((rc = KIFMM__F(__model_orders)(h, s))) return rc; /* before the buffers' sizes */
#endif
    KIFMM__F(__frame_points)(h, (size_t)s->maxleaf);
    h->work.m2l_cols = KIFMM__F(__m2l_cols)(h);
#if KIFMM__FFT
    h->fft.m = (int32_t)(s->mi < 1.0 ? 1.0 : s->mi < cap ? s->mi : cap);
    h->fft.slots = KIFMM__F(__fft_slots)(h, h->pl->fft.single ? 4 : 8, h->fft.m);
    KIFMM__F(__fft_per)(h, h->pl->fft.single ? 4 : 8);
#endif
    return rc;
}

/* The points' coordinates and permutations (one set when the targets are
 * the sources), and the tree's arrays: per box 105 bytes (key, child,
 * parent, anchor, level, point ranges, the lists' offsets, the internal,
 * M2L, leaf, dsrc and active boxes' indices), per U entry 4 (5 periodic:
 * the image), per V entry 6 (dense M2L: the transfer vector), per internal
 * box 134 (FFT M2L: 26 colleague entries), and the slabs' bookkeeping. */
KIFMM__FN double KIFMM__F(__bytes_tree)(const KIFMM_NAME *h, const kifmm__shape *s)
{
    const kifmm__tree *t = h->tree;
    const double sets = t->same ? (double)t->ns : (double)t->ns + (double)t->nt;
    double b = sets * (3.0 * sizeof(KIFMM__R) + sizeof(int64_t));
    b += 105.0 * s->box + (t->periodic ? 5.0 : 4.0) * s->u;
#if KIFMM__FFT
    b += 134.0 * s->inner + 8.0 * h->fft.m + 4.0 * s->mc + 9.0 * h->fft.slots;
#else
    b += 6.0 * s->v;
#endif
    return b;
}

/* M2M and L2L of a set of surfaces o whose children's are sc and parent's
 * sp (P__build_m2m_l2l): octant 0's, the anchors' columns and the mirror
 * maps where the three have one order and the kernel is radial or a vector
 * one, else all eight octants' */
KIFMM__FN double KIFMM__F(__bytes_family)(const KIFMM_NAME *h, const kifmm__surf *o, const kifmm__surf *sc,
                                          const kifmm__surf *sp)
{
    const double nc = o->nc, ne = o->ne, nd = o->nde;
    if ((KIFMM__FRADIAL || KIFMM__F(__sc_vector)(h->opts.kernel_param)) && sc->ne == o->ne && sp->nde == o->nde)
        return sizeof(KIFMM__R) * (2.0 * nc * ne + 8.0 * nc * (nd - ne)) + 7.0 * (o->nsc + o->nse) * sizeof(int);
    return sizeof(KIFMM__R) * 8.0 * nc * (sc->ne + sp->nde);
}

/* The solves, M2M, L2L and check-to-equivalent map of level l's set, with
 * the surfaces of its order and its neighbours' (>>orders) */
KIFMM__FN double KIFMM__F(__bytes_set)(const KIFMM_NAME *h, int l)
{
    const int nl = h->tree->nlev, lmin = kifmm__lmin(h->tree);
    const kifmm__surf *o = KIFMM__F(__sf)(h, l), *sc = KIFMM__F(__sf)(h, l + 1 < nl ? l + 1 : l);
    const kifmm__surf *sp = KIFMM__F(__sf)(h, l > lmin ? l - 1 : l);
    const double ne = o->ne, nc = o->nc, nd = o->nde, c2e = o->cdiff ? nc * ne : 0.0;
    return sizeof(KIFMM__R) * (ne * (nc + ne) + nd * (nc + nd) + c2e) + KIFMM__F(__bytes_family)(h, o, sc, sp);
}

#if KIFMM__FFT
/* The M2L spectra of a set whose lattice is f (blocks apart) */
KIFMM__FN double KIFMM__F(__bytes_spectra)(const KIFMM_NAME *h, const kifmm__fft *f)
{
    const int turned = KIFMM__F(__m2l_turned)(h);
    return (turned ? 16.0 : (double)KIFMM__NT) * KIFMM__FSD * KIFMM__FSD * 2.0 * f->nfp * sizeof(double) +
           (turned ? (double)KIFMM__NT * KIFMM__KTAB_W(KIFMM__FSD) * sizeof(int) : 0.0); /* __khat_turned */
}
#endif

/* The operators (__precompute), one set for a scale-invariant kernel, else
 * one per level from kifmm__lmin, none in a tree without M2L: the solves'
 * factors (ranks at most ne and nde), M2M and L2L, the check-to-equivalent map when
 * the check surface is larger, and at the levels with V lists (from 2, from
 * 1 in a periodic tree) the M2L's: the kernel's spectra (in double) with
 * the products' blocks where all of them fit in KIFMM__FFT_KB_MB
 * (__keep_blocks), or the dense matrix. Levels with V lists are expected
 * ones (kifmm__shape), so are these sets. *fout: the chance that the
 * products need a slab's output buffer (blocks not kept). */
KIFMM__FN double KIFMM__F(__bytes_ops)(const KIFMM_NAME *h, const kifmm__shape *s, double *fout)
{
    const double ne = h->pl->surf.ne, nc = h->pl->surf.nc, r = sizeof(KIFMM__R), nd = h->pl->surf.nde;
    const int lmin = kifmm__lmin(h->tree), n = KIFMM__SI ? 1 : h->tree->nlev > 1 ? h->tree->nlev : 1;
    const double sets = h->tree->nlev <= lmin ? 0.0 : KIFMM__SI ? 1.0 : (double)(n - lmin);
    const double m2ls = KIFMM__SI ? s->vany : s->vlev;
    const double c2e = h->pl->surf.cdiff ? nc * ne : 0.0; /* the check-to-equivalent map */
    const double per = r * (ne * (nc + ne) + nd * (nc + nd) + c2e) +
                       KIFMM__F(__bytes_family)(h, &h->pl->surf, &h->pl->surf, &h->pl->surf);
    double m2l;
#if KIFMM__FFT
    const kifmm__fft *pl = &h->pl->fft;
    const double kb = (double)KIFMM__FFT_KBN * pl->nchunk * (pl->single ? 4.0 : 8.0);
    double up = 0.0;
    int l;
    m2l = KIFMM__F(__bytes_spectra)(h, pl);
    if (kb * (m2ls > 1.0 ? m2ls : 1.0) <= (double)((size_t)KIFMM__FFT_KB_MB << 20)) {
        m2l += kb;
        *fout = 0.0;
    } else {
        *fout = m2ls < 1.0 ? m2ls : 1.0; /* __work_fout */
    }
#else
    double up = 0.0;
    int l;
    m2l = (double)KIFMM__NT * nd * ne * r;
    *fout = 0.0;
#endif
    /* levels of other orders or next to them (>>orders): their own sets, a
     * raised level's M2L (FFT: without blocks, __keep_blocks) where it has
     * one (the first m2ls levels from lmin) */
    for (l = lmin; h->ord.up && l < n && sets > 0.0; l++) {
        const kifmm__surf *o = KIFMM__F(__sf)(h, l);
        up += KIFMM__F(__bytes_set)(h, l) - per;
        if (KIFMM__F(__lpl)(h, l) == h->pl || !(l - lmin < m2ls)) continue;
#if KIFMM__FFT
        up += KIFMM__F(__bytes_spectra)(h, KIFMM__F(__ft)(h, l)) - m2l;
#else
        up += (double)KIFMM__NT * o->nde * o->ne * r - m2l;
#endif
        (void)o;
    }
    return (double)n * (sizeof(KIFMM__F(__ops)) + sizeof(double)) + sets * per + m2ls * m2l + up;
}

/* A periodic tree's far images (__lattice_build): the exchange (__far_root):
 * U's points (placed, in the tree's frame, and on the unit surface), its
 * three factors (ranks at most SD times the points of its equivalent
 * surface) and their workspace. */
KIFMM__FN double KIFMM__F(__bytes_lattice)(const KIFMM_NAME *h)
{
    const double r = sizeof(KIFMM__R);
    const int q = kifmm__ewald_order(h->opts.order, h->lat.zsmall), cd = kifmm__check_diff(q, 0, KIFMM__SD, KIFMM__FLOAT);
    const double nu = kifmm__surf_count(q + cd), mu = nu * KIFMM__SD;
    const double me = (double)kifmm__surf_count(q) * KIFMM__SD;
    if (!h->tree->periodic) return 0.0;
    return (6.0 * nu + 2.0 * mu * me + me * me + 2.0 * (mu + me)) * r + 3.0 * nu * sizeof(double);
}

/* One vector's workspace (__work_new): the expansions, the check vectors of
 * a level, the dense M2L's level buffer, the sorted densities and the
 * outputs (all of them, or per thread a leaf's or a mutual chunk's:
 * __lbuf_per); per thread the scratch and the column GEMMs' buffer
 * (__work_buffers); the dense M2L's stacked columns and products (in a tree
 * with V lists); the FFT M2L's spectra of a slab, the products of one
 * without kept blocks, and per thread its blocks, products and transforms
 * (__work_fft). */
KIFMM__FN double KIFMM__F(__bytes_work)(const KIFMM_NAME *h, const kifmm__shape *s, double fout)
{
    const kifmm__tree *t = h->tree;
    const double r = sizeof(KIFMM__R), nth = h->opts.nthreads;
    double sz[6], b, m = s->maxleaf > KIFMM__F(__smax)(h)->nsc ? s->maxleaf : KIFMM__F(__smax)(h)->nsc;
    size_t z[6];
    int k;
    KIFMM__F(__work_sizes)(h, z);
    for (k = 0; k < 6; k++) sz[k] = (double)z[k];
    if (KIFMM__MUTUAL && t->same && nth > 1 && (double)t->nt / (KIFMM__PAIR_CHUNKS * nth) > m)
        m = (double)t->nt / (KIFMM__PAIR_CHUNKS * nth);
    m = ceil(m * KIFMM__TD / 16.0) * 16.0;
    b = (sz[0] + sz[5] + sz[1] + sz[2] + sz[3] + (2.0 * nth * m <= sz[4] ? nth * m : sz[4])) * r;
    b += nth * (double)KIFMM__F(__scratch_per)(h) * r;
    if (t->nlev > kifmm__lmin(t))
        b += (KIFMM__GC_FAST ? nth : 1.0) * (double)KIFMM__F(__gbuf_per)(h) * r;
#if KIFMM__FFT
    {
        const double esz = h->pl->fft.single ? 4.0 : 8.0;
        const double spec = (double)h->fft.slots * KIFMM__F(__ftmax)(h)->nfp * 16.0 * esz;
        b += spec * (1.0 + fout) + nth * ((double)h->fft.per * esz + 64.0 * KIFMM__F(__smax)(h)->nc);
    }
#else
    b += s->vany * h->work.m2l_cols * r *
         (KIFMM__NT * h->pl->surf.ne + (h->pl->surf.nc > h->pl->surf.nde ? h->pl->surf.nc : h->pl->surf.nde));
    (void)fout;
#endif
    return b;
}

KIFMM__API int KIFMM__F(_estimate_bytes)(const kifmm_opts *opts, int64_t nsources, int64_t ntargets,
                                         double *bytes)
{
    const int same = ntargets == KIFMM_SAME_POINTS;
    const int64_t nt = same ? nsources : ntargets;
    kifmm_opts o;
    kifmm__shape s;
    KIFMM_NAME *h;
    int rc, d;
    double b, fout = 0.0;
    if (!bytes) return KIFMM_ERR_NULL;
    if (nsources < 0 || nsources > KIFMM_MAX_POINTS || nt < 0 || nt > KIFMM_MAX_POINTS)
        return KIFMM_ERR_COUNT;
    if ((rc = KIFMM__F(__validate)(opts, 0, NULL, 0, NULL, &o))) return rc;
    if (KIFMM__TOL_UNROOTED(o)) return KIFMM_ERR_TOL;
    if (KIFMM__SI && !KIFMM__EWALD && o.period[0] > 0.0 && o.period[1] > 0.0 && o.period[2] > 0.0)
        return KIFMM_ERR_PERIODIC; /* as create: __lattice_build */
    if (!(h = (KIFMM_NAME *)kifmm__calloc(1, sizeof *h))) return KIFMM_ERR_NOMEM;
    h->held = sizeof *h;
    h->opts = o;
    if (!(h->tr = kifmm__tree_new(nsources, nt))) {
        kifmm__free(h);
        return KIFMM_ERR_NOMEM;
    }
    h->tree = &h->tr->t;
    h->tr->t.same = same;
    for (d = 0; d < 3; d++) h->tr->t.periodic |= h->tr->t.per[d] = o.period[d] > 0.0;
    if (o.domain[3] > 0.0) h->tr->t.width = 2.0 * o.domain[3]; /* (>>orders: the levels' widths) */
    h->ord.raise = 1; /* as create */
    /* as __points_tree finds on uniform points: leaves at level 1 */
    h->lat.zsmall = nsources / 8 <= o.leaf_size && nt / 8 <= o.leaf_size;
    b = 0.0;
    if (!(h->pl = KIFMM__F(__plan_new)(&o))) rc = KIFMM_ERR_NOMEM; /* as create: the surfaces */
    if (!rc && nsources > 0 && nt > 0) {
        kifmm__shape_uniform(nsources, nt, same, o.leaf_size, o.max_depth, h->tree->per, &s);
        rc = KIFMM__F(__model)(h, &s);
        if (!rc) {
            b = KIFMM__F(__bytes_tree)(h, &s) + KIFMM__F(__bytes_ops)(h, &s, &fout);
            b += KIFMM__F(__bytes_lattice)(h) + KIFMM__F(__bytes_work)(h, &s, fout);
        }
    }
    b += (double)h->held + (h->pl ? (double)h->pl->held : 0.0);
    KIFMM__F(_destroy)(h);
    if (!rc) *bytes = b;
    return rc;
}


#if defined(KIFMM_MPI)
// >>mpi: MPI mode (create_mpi; evaluate, update_points, stats, destroy collective)

/* The ranks' points are partitioned by Morton key at level KIFMM__D of a
 * global root box (weighted bisection, kifmm__mpi_split); each rank owns a
 * key range, its region. A rank's handle is two local handles on one plan:
 * up, over the sources it owns in the global root (its upward pass gives
 * every box's equivalent density), and main, which evaluates at the targets
 * it owns the field of its own sources, of other ranks' sources near its
 * region (ghosts: the sources of leaves of their up trees not well
 * separated from it) and of the equivalent densities of their boxes that
 * are separated from it while the parent is not (proxies: each box's
 * equivalent surface as sources, with its densities where the kernel's
 * sources carry the surface kernel's, else with densities fitted to them,
 * __mpi_fit). Boxes of levels 2 to lc come summed over all ranks (one
 * allreduce) instead of from each rank. Kernels with a density map
 * (stokes_dl) take the proxies as a second role of main's sources instead,
 * with the surface kernel's densities (__mpi_roles; stokes_dl's sources
 * with densities fitted to a box's, three at each point, came to 12 times
 * one process's error at p = 10); they need as many density values a
 * source as the surface kernel's (UD >= SD), else KIFMM_ERR_MPI. */
#define KIFMM__MPI_ROLES (KIFMM__HAS_OF(KIFMM_KERNEL) & KIFMM_HAS_DENSITY)
#define KIFMM__MPI_KERNEL (!KIFMM__MPI_ROLES || KIFMM__UD >= KIFMM__SD)

struct KIFMM__F(__mpi) {
    MPI_Comm comm;
    int rank, size, same, lc, shape[2];
    kifmm_opts o;              /* options, resolved */
    KIFMM__F(_plan) *pl;       /* up's and main's */
    KIFMM_NAME *up, *main;     /* up: NULL when the rank owns no sources */
    double root[4];            /* the global root: centre, half-width */
    uint64_t *split;           /* size + 1 splitters: rank j owns [split[j], split[j + 1]) */
    int64_t *nto_all;          /* targets each rank owns */
    int64_t ns, nt;            /* the caller's points on this rank */
    kifmm__mpi_route rs, rt;   /* the caller's sources and targets to their owners */
    int64_t nso, nto;          /* owned */
    KIFMM__R *so, *to;         /* owned points (to == so when same) */
    kifmm__mpi_peers dst, src; /* the ranks this one sends ghosts and proxies to, and from */
    int64_t *gidx;             /* sources sent as ghosts, by destination (so's order) */
    int32_t *pbox;             /* boxes of up's tree sent as proxies, by destination */
    int64_t ng, np, npx;       /* ghosts and boxes received; proxies (distinct boxes) */
    int32_t *pslot;            /* each received box's proxy */
    int32_t *cbox, ncb, ncoarse; /* coarse boxes used: index of each in the levels 2..lc */
    unsigned char *plev;       /* the level of each proxy, then of each coarse box used */
    double *fit[KIFMM_MAX_DEPTH + 1]; /* the proxies' densities from a box's, by level (__mpi_fit) */
    int picked, sel[KIFMM__SD]; /* 1: a selection does instead (__mpi_pick's sel), 2: not, 0: unknown */
    double *fut, *fvs;         /* pinv(K_QC) at half-width 1 (__mpi_fit), fk its rank, */
    int fk;                    /* fr, fc the degrees of K_QC's rows and columns */
    double fr[KIFMM__SD], fc[KIFMM__QD];
    size_t *off;               /* message offsets, destinations then sources */
    kifmm_stats st;            /* the MPI fields */
    double cpu_mpi;            /* CPU seconds in MPI calls in the last evaluate */
};

/* Time in MPI calls: t (2) gets the wall and CPU clocks, __mpi_waited adds
 * what passed since to stats.t_mpi_wait and to m->cpu_mpi. */
KIFMM__FN void KIFMM__F(__mpi_clock)(double *t)
{
    t[0] = kifmm__now();
    t[1] = (double)clock() / CLOCKS_PER_SEC;
}

KIFMM__FN void KIFMM__F(__mpi_waited)(KIFMM__F(__mpi) *m, const double *t)
{
    m->st.t_mpi_wait += kifmm__now() - t[0];
    m->cpu_mpi += (double)clock() / CLOCKS_PER_SEC - t[1];
}

/* kifmm__mpi_agree, its time counted as time in MPI */
KIFMM__FN int KIFMM__F(__mpi_agree)(KIFMM__F(__mpi) *m, int rc)
{
    double t[2];
    KIFMM__F(__mpi_clock)(t);
    rc = kifmm__mpi_agree(m->comm, rc);
    KIFMM__F(__mpi_waited)(m, t);
    return rc;
}

/* Free the parts a partition built (not comm, plan or options). */
KIFMM__FN void KIFMM__F(__mpi_points_free)(KIFMM__F(__mpi) *m)
{
    KIFMM__F(_destroy)(m->up);
    KIFMM__F(_destroy)(m->main);
    m->up = m->main = NULL;
    kifmm__free(m->split);
    kifmm__free(m->nto_all);
    kifmm__mpi_route_free(&m->rs);
    kifmm__mpi_route_free(&m->rt);
    if (m->to != m->so) kifmm__free(m->to);
    kifmm__free(m->so);
    kifmm__mpi_peers_free(&m->dst);
    kifmm__mpi_peers_free(&m->src);
    kifmm__free(m->gidx);
    kifmm__free(m->pbox);
    kifmm__free(m->pslot);
    kifmm__free(m->cbox);
    kifmm__free(m->off);
    kifmm__free(m->plev);
    for (int l = 0; l <= KIFMM_MAX_DEPTH; l++) kifmm__free(m->fit[l]), m->fit[l] = NULL;
    m->split = NULL, m->nto_all = NULL, m->so = m->to = NULL, m->gidx = NULL;
    m->pbox = NULL, m->pslot = m->cbox = NULL, m->off = NULL, m->plev = NULL;
}

/* The global root: opts.domain, or the cube around every rank's points. */
KIFMM__FN int KIFMM__F(__mpi_root)(KIFMM__F(__mpi) *m, int64_t ns, const KIFMM__R *src,
                                   int64_t nt, const KIFMM__R *trg)
{
    double e[6] = {HUGE_VAL, HUGE_VAL, HUGE_VAL, HUGE_VAL, HUGE_VAL, HUGE_VAL}, half = 0.0;
    int64_t i;
    int d;
    if (m->o.domain[3] > 0.0) {
        memcpy(m->root, m->o.domain, sizeof m->root);
        return KIFMM_SUCCESS;
    }
    for (d = 0; d < 3; d++) { /* e: the lowest coordinates, then minus the highest */
        for (i = 0; i < ns; i++)
            e[d] = fmin(e[d], (double)src[3 * i + d]), e[d + 3] = fmin(e[d + 3], -(double)src[3 * i + d]);
        for (i = 0; i < nt; i++)
            e[d] = fmin(e[d], (double)trg[3 * i + d]), e[d + 3] = fmin(e[d + 3], -(double)trg[3 * i + d]);
    }
    if (MPI_Allreduce(MPI_IN_PLACE, e, 6, MPI_DOUBLE, MPI_MIN, m->comm) != MPI_SUCCESS) return KIFMM_ERR_MPI;
    for (d = 0; d < 3; d++) {
        if (!(e[d] <= -e[d + 3])) e[d] = e[d + 3] = 0.0; /* no points anywhere */
        m->root[d] = 0.5 * (e[d] - e[d + 3]);
        half = fmax(half, 0.5 * (-e[d + 3] - e[d]));
    }
    m->root[3] = half > 0.0 ? half * (1.0 + 1e-10) : 0.5;
    /* every rank's points were in range; all of them together must be too */
    if (half > 0.0 && 2.0 * half < KIFMM__EMIN) return KIFMM_ERR_RANGE;
    return KIFMM__F(__check_far)(m->o.kernel_param, 4.0 * sqrt(3.0) * half);
}

/* Level-KIFMM__D keys of n points in the global root. */
KIFMM__FN void KIFMM__F(__mpi_keys)(const double *root, int64_t n, const KIFMM__R *x, uint64_t *k)
{
    const int64_t top = ((int64_t)1 << KIFMM__D) - 1;
    const double sc = (double)((int64_t)1 << KIFMM__D) / (2.0 * root[3]);
    for (int64_t i = 0; i < n; i++) {
        int64_t q[3];
        int d;
        for (d = 0; d < 3; d++) {
            const double v = floor(((double)x[3 * i + d] - (root[d] - root[3])) * sc);
            q[d] = v < 0.0 ? 0 : v > (double)top ? top : (int64_t)v;
        }
        k[i] = kifmm__encode(q[0], q[1], q[2]);
    }
}

/* The splitters of these points (targets weigh as sources; the same
 * points twice when they are both). */
KIFMM__FN int KIFMM__F(__mpi_splitters)(KIFMM__F(__mpi) *m, int64_t ns, const KIFMM__R *src,
                                        int64_t nt, const KIFMM__R *trg)
{
    const int64_t n = ns + (m->same ? 0 : nt);
    uint64_t *k = (uint64_t *)kifmm__alloc((size_t)n + 1, sizeof(uint64_t));
    int64_t *ix = (int64_t *)kifmm__alloc((size_t)n + 1, sizeof(int64_t));
    double *cw = (double *)kifmm__alloc((size_t)n + 1, sizeof(double));
    int rc = KIFMM_SUCCESS;
    m->split = (uint64_t *)kifmm__alloc((size_t)m->size + 1, sizeof(uint64_t));
    if (!k || !ix || !cw || !m->split) rc = KIFMM_ERR_NOMEM;
    if (!rc) {
        KIFMM__F(__mpi_keys)(m->root, ns, src, k);
        if (!m->same) KIFMM__F(__mpi_keys)(m->root, nt, trg, k + ns);
        for (int64_t i = 0; i < n; i++) ix[i] = i;
        rc = kifmm__radix_sort(k, ix, n, m->o.nthreads);
    }
    if (!rc) {
        cw[0] = 0.0;
        for (int64_t i = 0; i < n; i++) cw[i + 1] = cw[i] + (m->same ? 2.0 : 1.0);
    }
    rc = KIFMM__F(__mpi_agree)(m, rc);
    if (!rc) rc = kifmm__mpi_split(m->comm, m->size, k, cw, n, m->split);
    kifmm__free(k);
    kifmm__free(ix);
    kifmm__free(cw);
    return rc;
}

/* n points to their owners along a new route r: *own gets the owned ones. */
KIFMM__FN int KIFMM__F(__mpi_send_points)(KIFMM__F(__mpi) *m, int64_t n, const KIFMM__R *x,
                                          kifmm__mpi_route *r, KIFMM__R **own)
{
    uint64_t *k = (uint64_t *)kifmm__alloc((size_t)n + 1, sizeof(uint64_t));
    int *to = (int *)kifmm__alloc((size_t)n + 1, sizeof(int));
    KIFMM__R *buf = (KIFMM__R *)kifmm__alloc((size_t)3 * n + 1, sizeof(KIFMM__R));
    int rc = !k || !to || !buf ? KIFMM_ERR_NOMEM : KIFMM_SUCCESS;
    if (!rc) {
        KIFMM__F(__mpi_keys)(m->root, n, x, k);
        for (int64_t i = 0; i < n; i++) to[i] = kifmm__mpi_owner(m->split, m->size, k[i]);
    }
    if ((rc = KIFMM__F(__mpi_agree)(m, rc)) == KIFMM_SUCCESS)
        rc = KIFMM__F(__mpi_agree)(m, kifmm__mpi_route_make(m->comm, m->size, n, to, r));
    if (!rc) {
        for (int64_t i = 0; i < n; i++) memcpy(buf + 3 * i, x + 3 * r->order[i], 3 * sizeof(KIFMM__R));
        *own = (KIFMM__R *)kifmm__alloc((size_t)3 * r->nrecv + 1, sizeof(KIFMM__R));
        rc = KIFMM__F(__mpi_agree)(m, *own ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM);
    }
    if (!rc) rc = kifmm__mpi_move(m->comm, r, 0, buf, *own, 3 * sizeof(KIFMM__R));
    kifmm__free(k);
    kifmm__free(to);
    kifmm__free(buf);
    return rc;
}

/* What this rank's up tree sends to a rank whose region is the nb boxes
 * bx: the sources of leaves not well separated from it, and of separated
 * boxes below level lc with no more sources than a surface has points
 * (ghosts, gidx: so's indices), and separated boxes below level lc whose
 * parent is not (pbox); counts in *ng and *np (NULL lists: count only). */
KIFMM__FN void KIFMM__F(__mpi_walk)(const KIFMM__F(__mpi) *m, const int64_t *bx, int nb,
                                    int64_t *ng, int64_t *np, int64_t *gidx, int32_t *pbox)
{
    const kifmm__tree *t = m->up->tree;
    int32_t stack[8 * (KIFMM__D + 2)];
    int top = 0, c;
    stack[top++] = 0;
    while (top) {
        const int32_t b = stack[--top];
        const int l = t->lev[b];
        const int64_t s0 = t->s0[b], n = t->s1[b] - s0;
        if (n == 0) continue;
        if (l >= 2 && !kifmm__mpi_near(l, t->anchor + 3 * (size_t)b, bx, nb)) {
            if (l <= m->lc) continue; /* in the coarse levels' sum */
            if (n > m->pl->surf.nse) {
                if (pbox) pbox[*np] = b;
                (*np)++;
                continue;
            }
        } else if (t->child[b] >= 0) {
            for (c = 7; c >= 0; c--) stack[top++] = t->child[b] + c;
            continue;
        }
        if (gidx)
            for (int64_t i = 0; i < n; i++) gidx[*ng + i] = t->sperm[s0 + i];
        *ng += n;
    }
}

/* The ghosts and proxies this rank sends to each rank with targets (a walk
 * that counts, then one that fills), and the peers both ways (the counts
 * exchanged with one alltoall of two numbers a rank). */
KIFMM__FN int KIFMM__F(__mpi_lists)(KIFMM__F(__mpi) *m)
{
    const int R = m->size;
    int64_t *c = (int64_t *)kifmm__calloc((size_t)4 * R, sizeof(int64_t)), ng, np;
    int64_t *bx = (int64_t *)kifmm__alloc((size_t)4 * 14 * KIFMM__D, sizeof(int64_t));
    int i, j, rc = !c || !bx ? KIFMM_ERR_NOMEM : KIFMM_SUCCESS;
    for (j = 0; j < R && !rc && m->up; j++)
        if (j != m->rank && m->nto_all[j] > 0)
            KIFMM__F(__mpi_walk)(m, bx, kifmm__mpi_range(m->split[j], m->split[j + 1], bx),
                                 &c[2 * j], &c[2 * j + 1], NULL, NULL);
    if (!rc) rc = kifmm__mpi_peers_make(R, c, &m->dst);
    if (!rc) {
        m->gidx = (int64_t *)kifmm__alloc((size_t)m->dst.g[m->dst.n] + 1, sizeof(int64_t));
        m->pbox = (int32_t *)kifmm__alloc((size_t)m->dst.p[m->dst.n] + 1, sizeof(int32_t));
        if (!m->gidx || !m->pbox) rc = KIFMM_ERR_NOMEM;
    }
    for (i = 0; i < m->dst.n && !rc; i++) {
        j = m->dst.rank[i];
        ng = np = 0;
        KIFMM__F(__mpi_walk)(m, bx, kifmm__mpi_range(m->split[j], m->split[j + 1], bx), &ng, &np,
                             m->gidx + m->dst.g[i], m->pbox + m->dst.p[i]);
    }
    rc = KIFMM__F(__mpi_agree)(m, rc);
    if (!rc && MPI_Alltoall(c, 2, MPI_INT64_T, c + 2 * R, 2, MPI_INT64_T, m->comm) != MPI_SUCCESS)
        rc = KIFMM_ERR_MPI;
    if (!rc) rc = kifmm__mpi_peers_make(R, c + 2 * R, &m->src);
    rc = KIFMM__F(__mpi_agree)(m, rc);
    kifmm__free(c);
    kifmm__free(bx);
    return rc;
}

/* m->off (dst.n + 1, then src.n + 1): each peer's message, perg bytes a
 * ghost point and perp a box. */
KIFMM__FN void KIFMM__F(__mpi_offsets)(KIFMM__F(__mpi) *m, size_t perg, size_t perp)
{
    const kifmm__mpi_peers *p[2] = {&m->dst, &m->src};
    size_t *off[2] = {m->off, m->off + m->dst.n + 1};
    int i, k;
    for (k = 0; k < 2; k++) {
        off[k][0] = 0;
        for (i = 0; i < p[k]->n; i++)
            off[k][i + 1] = off[k][i] + (size_t)(p[k]->g[i + 1] - p[k]->g[i]) * perg +
                            (size_t)(p[k]->p[i + 1] - p[k]->p[i]) * perp;
    }
}

/* One message to and from each peer (m->off: __mpi_offsets). */
KIFMM__FN int KIFMM__F(__mpi_exchange)(KIFMM__F(__mpi) *m, char *sbuf, char *rbuf)
{
    double t[2];
    int rc;
    KIFMM__F(__mpi_clock)(t);
    rc = kifmm__mpi_post(m->comm, &m->src, 1, rbuf, m->off + m->dst.n + 1);
    if (!rc) rc = kifmm__mpi_post(m->comm, &m->dst, 0, sbuf, m->off);
    if (!rc) rc = kifmm__mpi_wait(&m->src);
    if (!rc) rc = kifmm__mpi_wait(&m->dst);
    KIFMM__F(__mpi_waited)(m, t);
    return rc;
}

/* Total bytes of the messages to (k = 0) or from (1) the peers. */
KIFMM__FN size_t KIFMM__F(__mpi_bytes)(const KIFMM__F(__mpi) *m, int k, size_t perg, size_t perp)
{
    const kifmm__mpi_peers *p = k ? &m->src : &m->dst;
    return (size_t)p->g[p->n] * perg + (size_t)p->p[p->n] * perp;
}

/* The coarse boxes this rank takes from the levels' sum: boxes of levels 2
 * to lc with sources on some rank, separated from its region while their
 * parent is not (none without targets). */
KIFMM__FN int KIFMM__F(__mpi_coarse)(KIFMM__F(__mpi) *m)
{
    const int32_t nc = kifmm__mpi_coff(m->lc + 1);
    double *n = (double *)kifmm__calloc((size_t)nc, sizeof(double));
    int64_t *bx = (int64_t *)kifmm__alloc((size_t)4 * 14 * KIFMM__D, sizeof(int64_t)), x[3];
    int rc = !n || !bx ? KIFMM_ERR_NOMEM : KIFMM_SUCCESS, l, nb;
    m->ncoarse = nc;
    m->cbox = (int32_t *)kifmm__alloc((size_t)nc, sizeof(int32_t));
    if (!m->cbox) rc = KIFMM_ERR_NOMEM;
    for (l = 2; !rc && m->up && l <= m->lc && l < m->up->tree->nlev; l++) {
        const kifmm__tree *t = m->up->tree;
        for (int32_t b = t->loff[l]; b < t->loff[l + 1]; b++) {
            const int32_t *a = t->anchor + 3 * (size_t)b;
            n[kifmm__mpi_coff(l) + (int32_t)kifmm__encode(a[0], a[1], a[2])] += (double)(t->s1[b] - t->s0[b]);
        }
    }
    if ((rc = KIFMM__F(__mpi_agree)(m, rc)) == KIFMM_SUCCESS &&
        MPI_Allreduce(MPI_IN_PLACE, n, nc, MPI_DOUBLE, MPI_SUM, m->comm) != MPI_SUCCESS)
        rc = KIFMM_ERR_MPI;
    nb = rc ? 0 : kifmm__mpi_range(m->split[m->rank], m->split[m->rank + 1], bx);
    for (l = 2, m->ncb = 0; !rc && m->nto > 0 && l <= m->lc; l++)
        for (int32_t i = 0; i < (int32_t)1 << (3 * l); i++) {
            int32_t a[3], pa[3];
            if (n[kifmm__mpi_coff(l) + i] == 0.0) continue;
            kifmm__decode((uint64_t)i, x);
            a[0] = (int32_t)x[0], a[1] = (int32_t)x[1], a[2] = (int32_t)x[2];
            pa[0] = a[0] >> 1, pa[1] = a[1] >> 1, pa[2] = a[2] >> 1;
            if (!kifmm__mpi_near(l, a, bx, nb) && kifmm__mpi_near(l - 1, pa, bx, nb))
                m->cbox[m->ncb++] = kifmm__mpi_coff(l) + i;
        }
    kifmm__free(n);
    kifmm__free(bx);
    return rc;
}

/* The received boxes, each distinct one a proxy (pslot), then the coarse
 * ones: their level and anchor into *pa (4 each). */
KIFMM__FN int KIFMM__F(__mpi_proxies)(KIFMM__F(__mpi) *m, const char *rb, int32_t **pa)
{
    const size_t rg = 3 * sizeof(KIFMM__R), *off = m->off + m->dst.n + 1;
    kifmm__mpi_box *bs = (kifmm__mpi_box *)kifmm__alloc((size_t)m->np + 1, sizeof *bs);
    int64_t k;
    int i;
    m->pslot = (int32_t *)kifmm__alloc((size_t)m->np + 1, sizeof(int32_t));
    *pa = (int32_t *)kifmm__alloc((size_t)4 * (m->np + m->ncb) + 4, sizeof(int32_t));
    if (!bs || !m->pslot || !*pa) {
        kifmm__free(bs);
        return KIFMM_ERR_NOMEM;
    }
    for (i = 0; i < m->src.n; i++) {
        const char *base = rb + off[i] + (size_t)(m->src.g[i + 1] - m->src.g[i]) * rg;
        for (k = m->src.p[i]; k < m->src.p[i + 1]; k++) {
            memcpy(bs[k].a, base + (size_t)(k - m->src.p[i]) * sizeof bs[k].a, sizeof bs[k].a);
            bs[k].k = (int32_t)k;
        }
    }
    qsort(bs, (size_t)m->np, sizeof *bs, kifmm__mpi_box_cmp);
    for (k = 0, m->npx = 0; k < m->np; k++) {
        if (k == 0 || memcmp(bs[k].a, bs[k - 1].a, sizeof bs[k].a))
            memcpy(*pa + 4 * m->npx++, bs[k].a, sizeof bs[k].a);
        m->pslot[bs[k].k] = (int32_t)(m->npx - 1);
    }
    for (i = 0; i < m->ncb; i++) kifmm__mpi_coarse_box(m->cbox[i], *pa + 4 * (m->npx + i));
    kifmm__free(bs);
    return KIFMM_SUCCESS;
}

#if KIFMM__QD != KIFMM__SD
/* Kernels whose sources carry other densities than the equivalent surfaces
 * (the Laplace dipole and charge-and-dipole kernels, yukawa_cd, stokes_pvel):
 * a box from another rank enters main as sources of the kernel on its
 * equivalent surface's points, with densities F times the box's equivalent
 * density. F picks components where the kernel has one that is the surface
 * kernel (the charge of laplace_cd: its columns of QT and QC equal those of
 * ST and SC at three offsets, __mpi_pick), else F = pinv(K_QC(check <-
 * points)) K_SC(check <- equivalent) at the box's size: the kernel's
 * densities with the box's check potentials, so its field outside the check
 * surface, where every target of main is (a proxy's box is separated from
 * the rank's region). One F (nse QD x ne) a level, made with main. */
KIFMM__FN int KIFMM__F(__mpi_same)(const double *a, const double *b, int n, int la, int lb)
{
    int t, same = 1;
    for (t = 0; t < n; t++) {
        const double x = a[t * la], y = b[t * lb];
        same &= fabs(x - y) <= 1e-12 * (fabs(x) > fabs(y) ? fabs(x) : fabs(y));
    }
    return same;
}

KIFMM__FN int KIFMM__F(__mpi_pick)(const double *prm, int *sel)
{
#if KIFMM__IS_ONE(KIFMM__K(_MPI_PICK))
    (void)prm; /* the kernel says which component carries each (-1: none) */
    KIFMM__K(_mpi_pick)(sel);
    return 1;
#else
    static const double x[3][3] = {{0.61, -0.37, 0.23}, {-1.3, 0.4, 2.1}, {0.05, 0.9, -0.33}};
    double qt[KIFMM__TD * KIFMM__QD], st[KIFMM__TD * KIFMM__SD];
    double qc[KIFMM__SD * KIFMM__QD], sc[KIFMM__SD * KIFMM__SD];
    int b, s, i, same;
    for (b = 0; b < KIFMM__SD; b++) {
        for (s = 0, sel[b] = -1; s < KIFMM__QD && sel[b] < 0; s++) {
            for (i = 0, same = 1; i < 3 && same; i++) {
                KIFMM__R_(QT, _eval)(prm, x[i][0], x[i][1], x[i][2], qt);
                KIFMM__R_(ST, _eval)(prm, x[i][0], x[i][1], x[i][2], st);
                KIFMM__R_(QC, _eval)(prm, x[i][0], x[i][1], x[i][2], qc);
                KIFMM__R_(SC, _eval)(prm, x[i][0], x[i][1], x[i][2], sc);
                same = KIFMM__F(__mpi_same)(qt + s, st + b, KIFMM__TD, KIFMM__QD, KIFMM__SD) &&
                       KIFMM__F(__mpi_same)(qc + s, sc + b, KIFMM__SD, KIFMM__QD, KIFMM__SD);
            }
            if (same) sel[b] = s;
        }
        if (sel[b] < 0) return 0;
    }
    return 1;
#endif
}

/* K_QC(check <- equivalent points) of boxes of half-width w into a (nc x nq). */
KIFMM__FN int KIFMM__F(__mpi_qc)(const KIFMM_NAME *c, double w, double *a)
{
    const int nse = c->pl->surf.nse, nsc = c->pl->surf.nsc, nc = c->pl->surf.nc;
    const double zero[3] = {0.0, 0.0, 0.0};
    double *pc = (double *)kifmm__alloc((size_t)3 * (nsc + nse), sizeof(double)), *pe = pc + 3 * nsc;
    double kv[KIFMM__SD * KIFMM__QD];
    int i, j, q, s, ok = 1;
    if (!pc) return KIFMM_ERR_NOMEM;
    kifmm__surf_place(c->pl->surf.unit_c, nsc, zero, c->pl->surf.ao * w, pc);
    kifmm__surf_place(c->pl->surf.unit_e, nse, zero, KIFMM__F(__rin)(c->pl, &c->pl->surf, w), pe);
    for (j = 0; j < nse; j++)
        for (i = 0; i < nsc; i++) {
            KIFMM__R_(QC, _eval)(c->opts.kernel_param, pc[i] - pe[j], pc[nsc + i] - pe[nse + j],
                                 pc[2 * nsc + i] - pe[2 * nse + j], kv);
            for (q = 0; q < KIFMM__SD; q++)
                for (s = 0; s < KIFMM__QD; s++) {
                    ok &= fabs(kv[q * KIFMM__QD + s]) <= DBL_MAX;
                    a[(size_t)(i * KIFMM__SD + q) + (size_t)(j * KIFMM__QD + s) * nc] = kv[q * KIFMM__QD + s];
                }
        }
    kifmm__free(pc);
    return ok ? KIFMM_SUCCESS : KIFMM_ERR_KERNEL;
}

/* pinv(K_QC(check <- equivalent points)) at half-width w, as its factors
 * (kifmm__pinv), truncated at 1e-7 of the largest singular value up to
 * order 10, 1e-9 above (float: KIFMM__CUTOFF): a box's
 * equivalent density has parts the kernel's sources cannot make (the net
 * charge of a box of dipoles), as large as the upward pass's error, which
 * singular values far below the largest turn into huge densities whose
 * rounding main's FMM then carries; too high a cutoff loses what they can
 * make (laplace_dipole_grad, 60,000 uniform points, 4 ranks, against one
 * process: p = 10, 6.3e-10: 1.8e-7 truncated at 1e-14, 6.5e-10 at 1e-7;
 * p = 12, 1.5e-11: 4.4e-11 at 1e-7, 1.6e-11 at 1e-9). */
#define KIFMM__MPI_CUTOFF(p) (KIFMM__FLOAT || (p) <= 10 ? 1e-7 : 1e-9)
KIFMM__FN int KIFMM__F(__mpi_qc_pinv)(const KIFMM_NAME *c, double w, double **ut, double **vs, int *k)
{
    const int nc = c->pl->surf.nc, nq = c->pl->surf.nse * KIFMM__QD;
    double *a = (double *)kifmm__alloc((size_t)nc * nq, sizeof(double));
    int rc = a ? KIFMM__F(__mpi_qc)(c, w, a) : KIFMM_ERR_NOMEM;
    if (!rc) rc = kifmm__pinv(a, nc, nq, KIFMM__MPI_CUTOFF(c->opts.order), ut, vs, k);
    kifmm__free(a);
    return rc;
}

/* f (nq x ne) = diag(cs) vs ut diag(rs) K_SC(check <- equivalent) at
 * half-width w: the fit, from the factors of pinv(K_QC) at w (rs = cs = 1)
 * or at half-width 1 with the degrees' powers of w (rs: rows of the check
 * surface, cs: density components): the least-squares fit with the check
 * potentials weighted as at half-width 1, one SVD for every level. */
KIFMM__FN int KIFMM__F(__mpi_apply)(const KIFMM_NAME *c, double w, const double *ut, const double *vs, int k,
                                    const double *rs, const double *cs, double *f)
{
    const int nse = c->pl->surf.nse, nsc = c->pl->surf.nsc, ne = c->pl->surf.ne, nc = c->pl->surf.nc;
    const int nq = nse * KIFMM__QD;
    const double zero[3] = {0.0, 0.0, 0.0};
    double *b = (double *)kifmm__alloc((size_t)nc * ne, sizeof(double));
    double *t = (double *)kifmm__alloc((size_t)k * ne + 1, sizeof(double));
    size_t i;
    int rc = b && t ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM;
    if (!rc) rc = KIFMM__F(__surf_kmat)(c, c->pl->surf.unit_c, nsc, zero, c->pl->surf.ao * w, c->pl->surf.unit_e,
                                        nse, zero, KIFMM__F(__rin)(c->pl, &c->pl->surf, w), 1.0, b, (size_t)nc, NULL);
    if (!rc) {
        for (i = 0; i < (size_t)nc * ne; i++) b[i] *= rs[i % (size_t)nc % KIFMM__SD];
        memset(f, 0, (size_t)nq * ne * sizeof(double));
        if (k > 0) {
            kifmm__gemm(0, 0, k, ne, nc, 1.0, ut, k, b, nc, 0.0, t, k);
            kifmm__gemm(0, 0, nq, ne, k, 1.0, vs, nq, t, k, 0.0, f, nq);
        }
        for (i = 0; i < (size_t)nq * ne; i++) f[i] *= cs[i % (size_t)nq % KIFMM__QD];
    }
    kifmm__free(b);
    kifmm__free(t);
    return rc;
}

/* F of level l: picked; or from the factors at half-width 1 (m->fut,
 * m->fvs, kept for the handle's life) where the degrees allow; or from an
 * SVD at the level's size. */
KIFMM__FN int KIFMM__F(__mpi_fit)(KIFMM__F(__mpi) *m, int l)
{
    const KIFMM_NAME *c = m->main;
    const int nse = c->pl->surf.nse, ne = c->pl->surf.ne, nq = nse * KIFMM__QD;
    const double w = m->root[3] / (double)((int64_t)1 << l);
    double *f, rs[KIFMM__SD], cs[KIFMM__QD], *ut = NULL, *vs = NULL;
    int sel[KIFMM__SD], q, k = 0, rc;
    if (!m->picked) {
        m->picked = KIFMM__F(__mpi_pick)(c->opts.kernel_param, sel) ? 1 : 2;
        memcpy(m->sel, sel, sizeof sel);
    }
    if (m->picked == 1 || m->fit[l]) return KIFMM_SUCCESS; /* __mpi_expand copies */
    if (!(f = m->fit[l] = (double *)kifmm__calloc((size_t)nq * ne, sizeof(double)))) return KIFMM_ERR_NOMEM;
    if (KIFMM__F(__qc_degrees)(c->opts.kernel_param, m->fr, m->fc)) {
        if (!m->fut && (rc = KIFMM__F(__mpi_qc_pinv)(c, 1.0, &m->fut, &m->fvs, &m->fk)) != KIFMM_SUCCESS) {
            kifmm__free(m->fut), kifmm__free(m->fvs);
            m->fut = m->fvs = NULL;
            return rc;
        }
        for (q = 0; q < KIFMM__SD; q++) rs[q] = pow(w, -m->fr[q]);
        for (q = 0; q < KIFMM__QD; q++) cs[q] = pow(w, -m->fc[q]);
        return KIFMM__F(__mpi_apply)(c, w, m->fut, m->fvs, m->fk, rs, cs, f);
    }
    for (q = 0; q < KIFMM__SD; q++) rs[q] = 1.0;
    for (q = 0; q < KIFMM__QD; q++) cs[q] = 1.0;
    rc = KIFMM__F(__mpi_qc_pinv)(c, w, &ut, &vs, &k);
    if (!rc) rc = KIFMM__F(__mpi_apply)(c, w, ut, vs, k, rs, cs, f);
    kifmm__free(ut);
    kifmm__free(vs);
    return rc;
}

/* The proxies' densities (nr vectors, nse QD each) from their boxes' (pb:
 * nr x (npx + ncb) x ne) into dm at p0: the picked components copied, or
 * F (nq x ne, by columns) applied 64 rows at a time. */
KIFMM__FN void KIFMM__F(__mpi_expand)(const KIFMM__F(__mpi) *m, int nr, const KIFMM__R *pb, KIFMM__R *dm,
                                      size_t nsm, size_t p0)
{
    const int ne = m->pl->surf.ne, nse = m->pl->surf.nse, nq = nse * KIFMM__QD;
    const int64_t n = m->npx + m->ncb;
    for (int r = 0; r < nr; r++)
        for (int64_t k = 0; k < n; k++) {
            const double *f = m->fit[m->plev[k]];
            const KIFMM__R *x = pb + ((size_t)r * n + (size_t)k) * ne;
            KIFMM__R *v = dm + ((size_t)r * nsm + p0) * KIFMM__QD + (size_t)k * nq;
            if (m->picked == 1) {
                memset(v, 0, (size_t)nq * sizeof(KIFMM__R));
                for (int j = 0; j < nse; j++)
                    for (int q = 0; q < KIFMM__SD; q++)
                        if (m->sel[q] >= 0) v[j * KIFMM__QD + m->sel[q]] += x[j * KIFMM__SD + q];
                continue;
            }
            for (int i0 = 0; i0 < nq; i0 += 64) {
                const int bi = nq - i0 < 64 ? nq - i0 : 64;
                double acc[64] = {0.0};
                for (int j = 0; j < ne; j++) {
                    const double xj = (double)x[j], *fj = f + i0 + (size_t)j * nq;
                    for (int i = 0; i < bi; i++) acc[i] += fj[i] * xj;
                }
                for (int i = 0; i < bi; i++) v[i0 + i] = (KIFMM__R)acc[i];
            }
        }
}
#endif

#if KIFMM__MPI_ROLES
/* main's sources given from index p0 on are proxies (__p2p_roles): within
 * each leaf they move after the kernel's, both in their sorted order;
 * px.cum counts them, and the workspace gets room for their densities. */
KIFMM__FN int KIFMM__F(__mpi_roles)(KIFMM_NAME *c, int64_t p0)
{
    kifmm__tree *t = &c->tr->t;
    const int64_t ns = t->ns;
#if KIFMM__FLOAT
    float *x = c->tr->fsrc;
#else
    double *x = t->src;
#endif
    KIFMM__R *tx = (KIFMM__R *)kifmm__alloc((size_t)(3 * ns) + 1, sizeof(KIFMM__R));
    int64_t *tp = (int64_t *)kifmm__alloc((size_t)ns + 1, sizeof(int64_t));
    KIFMM__F(__work) *nw = NULL;
    int rc = KIFMM_SUCCESS;
    c->px.cum = (int64_t *)kifmm__take(&c->held, (size_t)ns + 1, sizeof(int64_t));
    if (!tx || !tp || !c->px.cum || t->same) rc = tx && tp && c->px.cum ? KIFMM_ERR_INTERNAL : KIFMM_ERR_NOMEM;
    if (!rc) { /* each leaf writes its own range */
        KIFMM__OMP(parallel for schedule(dynamic, 64) num_threads(c->opts.nthreads))
        for (int32_t b = 0; b < t->nbox; b++) {
            int64_t i, j = t->s0[b];
            int pass, d;
            if (t->child[b] >= 0) continue;
            for (pass = 0; pass < 2; pass++)
                for (i = t->s0[b]; i < t->s1[b]; i++)
                    if ((t->sperm[i] >= p0) == pass) {
                        for (d = 0; d < 3; d++) tx[d * ns + j] = x[d * ns + i];
                        tp[j++] = t->sperm[i];
                    }
            for (i = t->s0[b]; i < t->s1[b]; i++) {
                for (d = 0; d < 3; d++) x[d * ns + i] = tx[d * ns + i];
                t->sperm[i] = tp[i];
            }
        }
        c->px.cum[0] = 0;
        for (int64_t i = 0; i < ns; i++) c->px.cum[i + 1] = c->px.cum[i] + (t->sperm[i] >= p0);
        c->px.n = c->px.cum[ns];
        if (!(nw = KIFMM__F(__work_new)(c, c->work.w->nrhs))) rc = KIFMM_ERR_NOMEM;
    }
    if (nw) {
        KIFMM__F(__work_free)(c->work.w);
        c->work.w = nw;
        c->stats.bytes = KIFMM__F(__held)(c, c->pbytes);
    }
    kifmm__free(tx);
    kifmm__free(tp);
    return rc;
}

/* The proxies' densities (pb: nr x (npx + ncb) x ne) into dm at p0, each
 * point's SD values first of its UD (__gather_densities' proxies). */
KIFMM__FN void KIFMM__F(__mpi_pad)(const KIFMM__F(__mpi) *m, int nr, const KIFMM__R *pb, KIFMM__R *dm,
                                   size_t nsm, size_t p0)
{
    const size_t np = (size_t)(m->npx + m->ncb) * (size_t)m->pl->surf.nse;
    for (int r = 0; r < nr; r++)
        for (size_t j = 0; j < np; j++) {
            KIFMM__R *v = dm + ((size_t)r * nsm + p0 + j) * KIFMM__UD;
            memset(v, 0, KIFMM__UD * sizeof(KIFMM__R));
            memcpy(v, pb + ((size_t)r * np + j) * KIFMM__SD, KIFMM__SD * sizeof(KIFMM__R));
        }
}
#endif

/* main: the owned sources, the ghosts, the proxies' surfaces (the
 * equivalent surface of each box, at the radius of the upward pass) as
 * sources; the owned targets. */
KIFMM__FN int KIFMM__F(__mpi_main)(KIFMM__F(__mpi) *m, const char *rb)
{
    const int nse = m->pl->surf.nse;
    const size_t rg = 3 * sizeof(KIFMM__R), *off = m->off + m->dst.n + 1;
    kifmm_opts om = m->o;
    int32_t *pa = NULL;
    KIFMM__R *xs = NULL;
    int64_t nsm, k, j = m->nso;
    int i, rc;
    m->ng = m->src.g[m->src.n];
    m->np = m->src.p[m->src.n];
    if ((rc = KIFMM__F(__mpi_proxies)(m, rb, &pa))) {
        kifmm__free(pa);
        return rc;
    }
    nsm = m->nso + m->ng + (m->npx + m->ncb) * nse;
    if (!(m->plev = (unsigned char *)kifmm__alloc((size_t)(m->npx + m->ncb) + 1, 1))) {
        kifmm__free(pa);
        return KIFMM_ERR_NOMEM;
    }
    for (k = 0; k < m->npx + m->ncb; k++) m->plev[k] = (unsigned char)pa[4 * k];
    /* the global root as a box of level 2 of main's (4 times as wide, the
     * surfaces of the boxes on its faces inside): main's boxes are the
     * global tree's, refined as one process would refine them, not a frame
     * of their own whose levels half refine (many W and X lists) */
    for (i = 0; i < 3; i++) om.domain[i] = m->root[i] + m->root[3];
    om.domain[3] = 4.0 * m->root[3];
    om.max_depth = om.max_depth + 2 < KIFMM_MAX_DEPTH ? om.max_depth + 2 : KIFMM_MAX_DEPTH;
    if (nsm == m->nso) { /* nothing from the others: main is up's points */
        kifmm__free(pa);
        return KIFMM__F(__build)(&m->main, m->pl, 1, 0, 1, &om, m->shape, NULL, m->nso, m->so, m->nto, m->to);
    }
    if (!(xs = (KIFMM__R *)kifmm__alloc((size_t)3 * nsm, sizeof(KIFMM__R)))) {
        kifmm__free(pa);
        return KIFMM_ERR_NOMEM;
    }
    memcpy(xs, m->so, (size_t)3 * m->nso * sizeof(KIFMM__R));
    for (i = 0; i < m->src.n; i++) {
        memcpy(xs + 3 * j, rb + off[i], (size_t)(m->src.g[i + 1] - m->src.g[i]) * rg);
        j += m->src.g[i + 1] - m->src.g[i];
    }
    for (k = 0; k < m->npx + m->ncb; k++, j += nse) {
        const int32_t *a = pa + 4 * k;
        const double w = 2.0 * m->root[3] / (double)((int64_t)1 << a[0]);
        int d, q;
        for (d = 0; d < 3; d++) {
            const double c = m->root[d] - m->root[3] + (a[d + 1] + 0.5) * w;
            for (q = 0; q < nse; q++)
                xs[3 * (j + q) + d] = (KIFMM__R)(c + KIFMM__F(__rin)(m->pl, &m->pl->surf, 0.5 * w) * m->pl->surf.unit_e[d * nse + q]);
        }
    }
    rc = KIFMM__F(__build)(&m->main, m->pl, 1, 0, 1, &om, m->shape, NULL, nsm, xs, m->nto, m->to);
#if KIFMM__MPI_ROLES
    if (!rc && m->npx + m->ncb > 0) rc = KIFMM__F(__mpi_roles)(m->main, m->nso + m->ng);
#elif KIFMM__QD != KIFMM__SD
    for (k = 0; k < m->npx + m->ncb && !rc; k++) rc = KIFMM__F(__mpi_fit)(m, m->plev[k]);
#endif
    kifmm__free(xs);
    kifmm__free(pa);
    return rc;
}

/* The coordinates of the ghosts and the boxes of the proxies, to and from
 * the peers; then main. */
KIFMM__FN int KIFMM__F(__mpi_let)(KIFMM__F(__mpi) *m)
{
    const size_t rg = 3 * sizeof(KIFMM__R), rp = 4 * sizeof(int32_t);
    char *sb = NULL, *rb = NULL;
    int i, rc;
    m->off = (size_t *)kifmm__alloc((size_t)m->dst.n + m->src.n + 2, sizeof(size_t));
    sb = (char *)kifmm__alloc(KIFMM__F(__mpi_bytes)(m, 0, rg, rp) + 1, 1);
    rb = (char *)kifmm__alloc(KIFMM__F(__mpi_bytes)(m, 1, rg, rp) + 1, 1);
    rc = KIFMM__F(__mpi_agree)(m, !m->off || !sb || !rb ? KIFMM_ERR_NOMEM : KIFMM_SUCCESS);
    if (!rc) {
        KIFMM__F(__mpi_offsets)(m, rg, rp);
        for (i = 0; i < m->dst.n; i++) {
            char *g = sb + m->off[i], *p = g + (size_t)(m->dst.g[i + 1] - m->dst.g[i]) * rg;
            for (int64_t k = m->dst.g[i]; k < m->dst.g[i + 1]; k++, g += rg)
                memcpy(g, m->so + 3 * m->gidx[k], rg);
            for (int64_t k = m->dst.p[i]; k < m->dst.p[i + 1]; k++, p += rp) {
                const kifmm__tree *t = m->up->tree;
                const int32_t b = m->pbox[k], a[4] = {t->lev[b], t->anchor[3 * (size_t)b],
                                                      t->anchor[3 * (size_t)b + 1], t->anchor[3 * (size_t)b + 2]};
                memcpy(p, a, rp);
            }
        }
        rc = KIFMM__F(__mpi_agree)(m, KIFMM__F(__mpi_exchange)(m, sb, rb));
    }
    if (!rc) rc = KIFMM__F(__mpi_agree)(m, KIFMM__F(__mpi_main)(m, rb));
    kifmm__free(sb);
    kifmm__free(rb);
    return rc;
}

/* The partition of these points and everything built on it, into m (whose
 * comm, plan and options are set; on failure the caller frees the rest). */
KIFMM__FN int KIFMM__F(__mpi_build)(KIFMM__F(__mpi) *m, int64_t ns, const KIFMM__R *src,
                                    int64_t nt, const KIFMM__R *trg)
{
    kifmm_opts ou = m->o;
    int rc, same = ns == nt && src == trg;
    m->ns = ns, m->nt = nt;
    if (MPI_Allreduce(MPI_IN_PLACE, &same, 1, MPI_INT, MPI_MIN, m->comm) != MPI_SUCCESS)
        return KIFMM_ERR_MPI;
    m->same = same;
    if ((rc = KIFMM__F(__mpi_root)(m, ns, src, nt, trg))) return rc;
    if ((rc = KIFMM__F(__mpi_splitters)(m, ns, src, nt, trg))) return rc;
    if ((rc = KIFMM__F(__mpi_send_points)(m, ns, src, &m->rs, &m->so))) return rc;
    m->nso = m->rs.nrecv;
    if (same) m->to = m->so, m->nto = m->nso;
    else if ((rc = KIFMM__F(__mpi_send_points)(m, nt, trg, &m->rt, &m->to))) return rc;
    else m->nto = m->rt.nrecv;
    m->nto_all = (int64_t *)kifmm__alloc((size_t)m->size, sizeof(int64_t));
    if ((rc = KIFMM__F(__mpi_agree)(m, m->nto_all ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM))) return rc;
    if (MPI_Allgather(&m->nto, 1, MPI_INT64_T, m->nto_all, 1, MPI_INT64_T, m->comm) != MPI_SUCCESS)
        return KIFMM_ERR_MPI;
    memcpy(ou.domain, m->root, sizeof m->root);
    ou.verbose = 0;
    if (m->nso > 0)
        rc = KIFMM__F(__build)(&m->up, m->pl, 1, 0, 1, &ou, m->shape, NULL, m->nso, m->so, m->nso, m->so);
    if ((rc = KIFMM__F(__mpi_agree)(m, rc))) return rc;
    if ((rc = KIFMM__F(__mpi_coarse)(m))) return rc;
    if ((rc = KIFMM__F(__mpi_lists)(m))) return rc;
    return KIFMM__F(__mpi_let)(m);
}

#define KIFMM__MPI_REAL (sizeof(KIFMM__R) == sizeof(double) ? MPI_DOUBLE : MPI_FLOAT)

/* The caller's densities (nr vectors) to the owners: dq (nr x nso x UD). */
KIFMM__FN int KIFMM__F(__mpi_forward)(KIFMM__F(__mpi) *m, int nr, const KIFMM__R *d,
                                      KIFMM__R *dq)
{
    const size_t per = (size_t)nr * KIFMM__UD, uper = (size_t)m->ns * KIFMM__UD;
    KIFMM__R *sb = (KIFMM__R *)kifmm__alloc((size_t)m->ns * per + 1, sizeof(KIFMM__R));
    KIFMM__R *rb = (KIFMM__R *)kifmm__alloc((size_t)m->nso * per + 1, sizeof(KIFMM__R));
    double t[2];
    int rc = KIFMM__F(__mpi_agree)(m, !sb || !rb ? KIFMM_ERR_NOMEM : KIFMM_SUCCESS);
    if (!rc) {
        for (int64_t i = 0; i < m->ns; i++)
            for (int r = 0; r < nr; r++)
                memcpy(sb + i * per + (size_t)r * KIFMM__UD, d + r * uper + m->rs.order[i] * KIFMM__UD,
                       KIFMM__UD * sizeof(KIFMM__R));
        KIFMM__F(__mpi_clock)(t);
        rc = kifmm__mpi_move(m->comm, &m->rs, 0, sb, rb, per * sizeof(KIFMM__R));
        KIFMM__F(__mpi_waited)(m, t);
    }
    if (!rc)
        for (int64_t i = 0; i < m->nso; i++)
            for (int r = 0; r < nr; r++)
                memcpy(dq + ((size_t)r * m->nso + i) * KIFMM__UD, rb + i * per + (size_t)r * KIFMM__UD,
                       KIFMM__UD * sizeof(KIFMM__R));
    kifmm__free(sb);
    kifmm__free(rb);
    return rc;
}

/* up's upward pass on dq; e: each vector's scale (__density_scale). */
KIFMM__FN int KIFMM__F(__mpi_upward)(KIFMM__F(__mpi) *m, int nr, const KIFMM__R *dq, int *e)
{
    KIFMM_NAME *up = m->up;
    int l, rc;
    if (!up) return KIFMM_SUCCESS;
    if ((rc = KIFMM__F(__eval_grow)(up, nr))) return rc;
    KIFMM__F(__density_scale)(up, nr, dq, e);
    KIFMM__F(__gather_densities)(up, up->work.w, nr, dq, e);
    for (l = up->tree->nlev - 1; l >= kifmm__lmin(up->tree); l--) KIFMM__F(__upward)(up, up->work.w, nr, l);
    return KIFMM_SUCCESS;
}

/* v += box b's equivalent density of vector r (up's, scaled back). */
KIFMM__FN void KIFMM__F(__mpi_ue)(const KIFMM__F(__mpi) *m, int r, int32_t b, const int *e, KIFMM__R *v)
{
    const int ne = m->pl->surf.ne; /* (MPI mode: every level has the plan's order) */
    const KIFMM__R *u = m->up->work.w->ue + (size_t)r * KIFMM__F(__eo)(m->up, 0, m->up->tree->nbox) +
                        KIFMM__F(__eo)(m->up, 0, b);
    const double s = ldexp(1.0, e[r]);
    int i;
    for (i = 0; i < ne; i++) v[i] = (KIFMM__R)((double)v[i] + s * (double)u[i]);
}

/* co (nr x ncoarse x ne): every rank's equivalent densities of the boxes of
 * levels 2 .. lc, summed. */
KIFMM__FN int KIFMM__F(__mpi_coarse_sum)(KIFMM__F(__mpi) *m, int nr, const int *e, KIFMM__R *co)
{
    const int ne = m->pl->surf.ne;
    const size_t n = (size_t)nr * m->ncoarse * ne;
    double t[2];
    int l, r, rc;
    memset(co, 0, n * sizeof(KIFMM__R));
    for (l = 2; m->up && l <= m->lc && l < m->up->tree->nlev; l++) {
        const kifmm__tree *t = m->up->tree;
        for (int32_t b = t->loff[l]; b < t->loff[l + 1]; b++) {
            const int32_t *a = t->anchor + 3 * (size_t)b;
            const size_t i = (size_t)kifmm__mpi_coff(l) + (size_t)kifmm__encode(a[0], a[1], a[2]);
            for (r = 0; r < nr; r++) KIFMM__F(__mpi_ue)(m, r, b, e, co + ((size_t)r * m->ncoarse + i) * ne);
        }
    }
    if (n > INT_MAX) return KIFMM_ERR_COUNT;
    KIFMM__F(__mpi_clock)(t);
    rc = MPI_Allreduce(MPI_IN_PLACE, co, (int)n, KIFMM__MPI_REAL, MPI_SUM, m->comm);
    KIFMM__F(__mpi_waited)(m, t);
    return rc == MPI_SUCCESS ? KIFMM_SUCCESS : KIFMM_ERR_MPI;
}

/* vector r's equivalent densities of the proxies' boxes, in order: where
 * main's proxies take them (QD == SD), else in pb (nr x (npx + ncb) x ne) */
#if KIFMM__QD != KIFMM__SD
#define KIFMM__MPI_BOXES(r) (pb + (size_t)(r) * (size_t)(m->npx + m->ncb) * ne)
#else
#define KIFMM__MPI_BOXES(r) (dm + ((size_t)(r) * nsm + p0) * U)
#endif

/* dm (nr x nsm x UD): the owned densities (dq), the ghosts' and proxies'
 * from the peers, the coarse boxes' (co). */
KIFMM__FN int KIFMM__F(__mpi_sources)(KIFMM__F(__mpi) *m, int nr, const KIFMM__R *dq, const int *e,
                                      const KIFMM__R *co, KIFMM__R *pb, KIFMM__R *dm)
{
    const int ne = m->pl->surf.ne, U = KIFMM__UD;
    const size_t pg = (size_t)nr * U * sizeof(KIFMM__R), pp = (size_t)nr * ne * sizeof(KIFMM__R);
    const size_t nsm = (size_t)(m->nso + m->ng + (m->npx + m->ncb) * m->pl->surf.nse);
    const size_t p0 = (size_t)(m->nso + m->ng);
    char *sb = (char *)kifmm__alloc(KIFMM__F(__mpi_bytes)(m, 0, pg, pp) + 1, 1);
    char *rb = (char *)kifmm__alloc(KIFMM__F(__mpi_bytes)(m, 1, pg, pp) + 1, 1);
    int i, r, rc = KIFMM__F(__mpi_agree)(m, !sb || !rb ? KIFMM_ERR_NOMEM : KIFMM_SUCCESS);
    int64_t k, j = m->nso;
    if (!rc) {
        KIFMM__F(__mpi_offsets)(m, pg, pp);
        for (i = 0; i < m->dst.n; i++) {
            KIFMM__R *g = (KIFMM__R *)(void *)(sb + m->off[i]), *p = g + (m->dst.g[i + 1] - m->dst.g[i]) * nr * U;
            for (k = m->dst.g[i]; k < m->dst.g[i + 1]; k++)
                for (r = 0; r < nr; r++, g += U)
                    memcpy(g, dq + ((size_t)r * m->nso + (size_t)m->gidx[k]) * U, U * sizeof(KIFMM__R));
            memset(p, 0, (size_t)(m->dst.p[i + 1] - m->dst.p[i]) * pp);
            for (k = m->dst.p[i]; k < m->dst.p[i + 1]; k++)
                for (r = 0; r < nr; r++, p += ne) KIFMM__F(__mpi_ue)(m, r, m->pbox[k], e, p);
        }
        rc = KIFMM__F(__mpi_agree)(m, KIFMM__F(__mpi_exchange)(m, sb, rb));
    }
    for (r = 0; r < nr && !rc; r++) { /* the owned; the proxies' boxes, summed below */
        memcpy(dm + (size_t)r * nsm * U, dq + (size_t)r * m->nso * U, (size_t)m->nso * U * sizeof(KIFMM__R));
        memset(KIFMM__MPI_BOXES(r), 0, (size_t)(m->npx + m->ncb) * ne * sizeof(KIFMM__R));
    }
    for (i = 0; i < m->src.n && !rc; i++) {
        const KIFMM__R *g = (const KIFMM__R *)(const void *)(rb + m->off[m->dst.n + 1 + i]);
        const KIFMM__R *p = g + (m->src.g[i + 1] - m->src.g[i]) * nr * U;
        for (k = m->src.g[i]; k < m->src.g[i + 1]; k++, j++)
            for (r = 0; r < nr; r++, g += U) memcpy(dm + ((size_t)r * nsm + (size_t)j) * U, g, U * sizeof(KIFMM__R));
        for (k = m->src.p[i]; k < m->src.p[i + 1]; k++)
            for (r = 0; r < nr; r++, p += ne) {
                KIFMM__R *v = KIFMM__MPI_BOXES(r) + (size_t)m->pslot[k] * ne;
                for (int q = 0; q < ne; q++) v[q] += p[q];
            }
    }
    for (i = 0; i < m->ncb && !rc; i++)
        for (r = 0; r < nr; r++)
            memcpy(KIFMM__MPI_BOXES(r) + (size_t)(m->npx + i) * ne,
                   co + ((size_t)r * m->ncoarse + (size_t)m->cbox[i]) * ne, (size_t)ne * sizeof(KIFMM__R));
#if KIFMM__MPI_ROLES
    if (!rc) KIFMM__F(__mpi_pad)(m, nr, pb, dm, nsm, p0);
#elif KIFMM__QD != KIFMM__SD
    if (!rc) KIFMM__F(__mpi_expand)(m, nr, pb, dm, nsm, p0);
#else
    (void)pb;
#endif
    kifmm__free(sb);
    kifmm__free(rb);
    return rc;
}

/* main's outputs (om: nr x nto x TD) back to the callers' targets, into
 * out in their order. */
KIFMM__FN int KIFMM__F(__mpi_backward)(KIFMM__F(__mpi) *m, int nr, const KIFMM__R *om,
                                       KIFMM__R *out)
{
    const kifmm__mpi_route *rt = m->same ? &m->rs : &m->rt;
    const size_t per = (size_t)nr * KIFMM__TD, oper = (size_t)m->nt * KIFMM__TD;
    KIFMM__R *sb = (KIFMM__R *)kifmm__alloc((size_t)m->nto * per + 1, sizeof(KIFMM__R));
    KIFMM__R *rb = (KIFMM__R *)kifmm__alloc((size_t)m->nt * per + 1, sizeof(KIFMM__R));
    double t[2];
    int rc = KIFMM__F(__mpi_agree)(m, !sb || !rb ? KIFMM_ERR_NOMEM : KIFMM_SUCCESS);
    if (!rc) {
        for (int64_t i = 0; i < m->nto; i++)
            for (int r = 0; r < nr; r++)
                memcpy(sb + i * per + (size_t)r * KIFMM__TD, om + ((size_t)r * m->nto + i) * KIFMM__TD,
                       KIFMM__TD * sizeof(KIFMM__R));
        KIFMM__F(__mpi_clock)(t);
        rc = kifmm__mpi_move(m->comm, rt, 1, sb, rb, per * sizeof(KIFMM__R));
        KIFMM__F(__mpi_waited)(m, t);
    }
    if (!rc)
        for (int64_t i = 0; i < m->nt; i++)
            for (int r = 0; r < nr; r++)
                memcpy(out + r * oper + rt->order[i] * KIFMM__TD, rb + i * per + (size_t)r * KIFMM__TD,
                       KIFMM__TD * sizeof(KIFMM__R));
    kifmm__free(sb);
    kifmm__free(rb);
    return rc;
}

/* One group of nr vectors: forward, upward, the coarse sum, the exchange
 * with the peers, main's evaluation, back. */
KIFMM__FN int KIFMM__F(__mpi_group)(KIFMM__F(__mpi) *m, int nr, const KIFMM__R *d, KIFMM__R *out)
{
    const size_t nsm = (size_t)(m->nso + m->ng + (m->npx + m->ncb) * m->pl->surf.nse);
    KIFMM__R *dq = (KIFMM__R *)kifmm__alloc((size_t)nr * m->nso * KIFMM__UD + 1, sizeof(KIFMM__R));
    KIFMM__R *co = (KIFMM__R *)kifmm__alloc((size_t)nr * m->ncoarse * m->pl->surf.ne + 1, sizeof(KIFMM__R));
    KIFMM__R *dm = (KIFMM__R *)kifmm__alloc((size_t)nr * nsm * KIFMM__UD + 1, sizeof(KIFMM__R));
    KIFMM__R *om = (KIFMM__R *)kifmm__alloc((size_t)nr * m->nto * KIFMM__TD + 1, sizeof(KIFMM__R));
    KIFMM__R *pb = KIFMM__QD == KIFMM__SD ? NULL
                 : (KIFMM__R *)kifmm__alloc((size_t)nr * (m->npx + m->ncb) * m->pl->surf.ne + 1, sizeof(KIFMM__R));
    int e[KIFMM__RHS_MAX] = {0}, rc, rm = KIFMM_SUCCESS;
    rc = !dq || !co || !dm || !om || (KIFMM__QD != KIFMM__SD && !pb) ? KIFMM_ERR_NOMEM : KIFMM_SUCCESS;
    rc = KIFMM__F(__mpi_agree)(m, rc);
    if (!rc) rc = KIFMM__F(__mpi_forward)(m, nr, d, dq);
    if (!rc) rc = KIFMM__F(__mpi_agree)(m, KIFMM__F(__mpi_upward)(m, nr, dq, e));
    if (!rc) rc = KIFMM__F(__mpi_coarse_sum)(m, nr, e, co);
    if (!rc) rc = KIFMM__F(__mpi_sources)(m, nr, dq, e, co, pb, dm);
    if (!rc) rm = KIFMM__F(_evaluate_many)(m->main, nr, dm, om);
    if (!rc) rc = KIFMM__F(__mpi_agree)(m, rm == KIFMM_ERR_OVERFLOW ? KIFMM_SUCCESS : rm);
    if (!rc) rc = KIFMM__F(__mpi_backward)(m, nr, om, out);
    if (!rc) { /* bytes to and from other ranks: densities in, the peers', the coarse sum, outputs back */
        const kifmm__mpi_route *rt = m->same ? &m->rs : &m->rt;
        const double u = sizeof(KIFMM__R) * (double)nr, c = u * (double)m->ncoarse * m->pl->surf.ne;
        const double g = u * KIFMM__UD, p = u * m->pl->surf.ne, o = u * KIFMM__TD;
        const double let = (double)KIFMM__F(__mpi_bytes)(m, 1, (size_t)g, (size_t)p);
        m->st.mpi_bytes_sent += g * (double)(m->ns - m->rs.cnt[m->rank]) + c +
                                (double)KIFMM__F(__mpi_bytes)(m, 0, (size_t)g, (size_t)p) +
                                o * (double)(m->nto - rt->rcnt[m->rank]);
        m->st.mpi_bytes_recv += g * (double)(m->nso - m->rs.rcnt[m->rank]) + c + let +
                                o * (double)(m->nt - rt->cnt[m->rank]);
        m->st.mpi_ghost_bytes += let;
    }
    kifmm__free(dq);
    kifmm__free(co);
    kifmm__free(pb);
    kifmm__free(dm);
    kifmm__free(om);
    return rc ? rc : rm;
}

/* evaluate_many on an MPI handle: the arguments checked on every rank and
 * agreed (the counts of vectors too), then groups of up to RHS_MAX. */
KIFMM__FN int KIFMM__F(__mpi_evaluate)(KIFMM_NAME *h, int nrhs, const KIFMM__R *d, KIFMM__R *out)
{
    KIFMM__F(__mpi) *m = h->mpi;
    const size_t uper = (size_t)m->ns * KIFMM__UD, oper = (size_t)m->nt * KIFMM__TD;
    KIFMM__R *copy = NULL;
    double t0 = kifmm__now(), c0;
    int n[2] = {nrhs, -nrhs}, r0, nr, rc = KIFMM_SUCCESS;
    if (nrhs < 0) rc = KIFMM_ERR_COUNT;
    else if (nrhs > 0 && ((m->ns > 0 && !d) || (m->nt > 0 && !out))) rc = KIFMM_ERR_NULL;
    else if ((size_t)nrhs > (size_t)PTRDIFF_MAX / sizeof(KIFMM__R) / (uper > oper ? uper + 1 : oper + 1))
        rc = KIFMM_ERR_COUNT;
    if (!rc && nrhs > 0) rc = KIFMM__F(__check_finite)((size_t)nrhs * uper, d, m->o.nthreads, KIFMM_ERR_DENSITY);
    if (MPI_Allreduce(MPI_IN_PLACE, n, 2, MPI_INT, MPI_MIN, m->comm) != MPI_SUCCESS) return KIFMM_ERR_MPI;
    if (!rc && n[0] != -n[1]) rc = KIFMM_ERR_MPI; /* the ranks passed different counts */
    if ((rc = KIFMM__F(__mpi_agree)(m, rc)) || nrhs == 0) return rc;
    c0 = (double)clock() / CLOCKS_PER_SEC;
    if (m->size == 1) {
        rc = KIFMM__F(_evaluate_many)(m->main, nrhs, d, out);
        m->st.t_evaluate = kifmm__now() - t0;
        m->st.t_mpi_work = (double)clock() / CLOCKS_PER_SEC - c0;
        return rc;
    }
    if (kifmm__overlap(d, (size_t)nrhs * uper * sizeof(KIFMM__R), out, (size_t)nrhs * oper * sizeof(KIFMM__R))) {
        copy = (KIFMM__R *)kifmm__alloc((size_t)nrhs * uper + 1, sizeof(KIFMM__R));
        if (copy) memcpy(copy, d, (size_t)nrhs * uper * sizeof(KIFMM__R));
        if ((rc = KIFMM__F(__mpi_agree)(m, copy ? KIFMM_SUCCESS : KIFMM_ERR_NOMEM))) return rc;
        d = copy;
    }
    m->st.t_mpi_wait = m->st.mpi_bytes_sent = m->st.mpi_bytes_recv = m->st.mpi_ghost_bytes = 0.0;
    m->cpu_mpi = 0.0;
    for (r0 = 0; r0 < nrhs && !rc; r0 += nr) {
        nr = nrhs - r0 < KIFMM__RHS_MAX ? nrhs - r0 : KIFMM__RHS_MAX;
        rc = KIFMM__F(__mpi_group)(m, nr, d + (size_t)r0 * uper, out + (size_t)r0 * oper);
    }
    kifmm__free(copy);
    m->st.t_evaluate = kifmm__now() - t0;
    m->st.t_mpi_work = (double)clock() / CLOCKS_PER_SEC - c0 - m->cpu_mpi;
    return rc;
}

/* Bytes of the MPI layer's own arrays (owned points, routes, lists). */
KIFMM__FN double KIFMM__F(__mpi_held)(const KIFMM__F(__mpi) *m)
{
    const double wr = (double)sizeof(KIFMM__R), wi = (double)sizeof(int64_t);
    double b = (double)sizeof *m + 3.0 * wr * (double)(m->nso + (m->same ? 0 : m->nto));
    b += wi * (double)(m->rs.order ? m->ns : 0) + wi * (double)(m->rt.order ? m->nt : 0);
    b += 8.0 * sizeof(int) * (double)m->size + 2.0 * wi * (double)m->size; /* counts, splits */
    b += wi * (double)m->dst.g[m->dst.n] + 4.0 * (double)m->dst.p[m->dst.n] + 4.0 * (double)m->np;
    b += 4.0 * (double)m->ncoarse + 3.0 * wi * (double)(m->dst.n + m->src.n + 2);
    b += (double)(m->npx + m->ncb); /* plev */
    for (int l = 0; l <= KIFMM_MAX_DEPTH; l++) /* the fits */
        if (m->fit[l]) b += 8.0 * (double)m->pl->surf.nse * KIFMM__QD * (double)m->pl->surf.ne;
    if (m->fut) b += 8.0 * (double)m->fk * (m->pl->surf.nc + m->pl->surf.nse * KIFMM__QD);
    return b;
}

KIFMM__FN void KIFMM__F(__mpi_stats)(const KIFMM_NAME *h, kifmm_stats *out)
{
    const KIFMM__F(__mpi) *m = h->mpi;
    *out = m->main->stats;
    if (m->size > 1) /* main and up are on the layer's own plan: it counts once */
        out->bytes += out->plan_bytes + KIFMM__F(__mpi_held)(m);
    out->mpi_ranks = m->size;
    out->mpi_sources = m->size == 1 ? m->ns : m->nso;
    out->mpi_targets = m->size == 1 ? m->nt : m->nto;
    out->mpi_ghost_points = m->ng;
    out->mpi_ghost_boxes = m->npx + m->ncb;
    out->mpi_bytes_sent = m->st.mpi_bytes_sent;
    out->mpi_bytes_recv = m->st.mpi_bytes_recv;
    out->mpi_ghost_bytes = m->st.mpi_ghost_bytes;
    out->t_mpi_wait = m->st.t_mpi_wait;
    out->t_mpi_work = m->st.t_mpi_work;
    out->t_evaluate = m->st.t_evaluate;
    if (m->up) out->bytes += m->up->stats.bytes;
    out->t_update = m->st.t_update;
}

/* A new partition of these points (R = 1: main's update_points); on
 * failure, on every rank, the handle is as it was. */
KIFMM__FN int KIFMM__F(__mpi_update)(KIFMM_NAME *h, int64_t ns, const KIFMM__R *src, int64_t nt,
                                     const KIFMM__R *trg)
{
    KIFMM__F(__mpi) *m = h->mpi, n;
    double t0 = kifmm__now();
    int rc = KIFMM__F(__check_sets)(&m->o, ns, src, nt, trg);
    if ((rc = KIFMM__F(__mpi_agree)(m, rc))) return rc;
    if (m->size == 1) {
        rc = KIFMM__F(__mpi_agree)(m, KIFMM__F(_update_points)(m->main, ns, src, nt, trg));
        if (!rc) m->ns = ns, m->nt = nt;
        m->st.t_update = kifmm__now() - t0;
        return rc;
    }
    memset(&n, 0, sizeof n);
    n.comm = m->comm, n.rank = m->rank, n.size = m->size, n.lc = m->lc, n.o = m->o, n.pl = m->pl;
    n.shape[0] = m->shape[0], n.shape[1] = m->shape[1], n.fut = m->fut, n.fvs = m->fvs, n.fk = m->fk;
    if ((rc = KIFMM__F(__mpi_build)(&n, ns, src, nt, trg))) {
        KIFMM__F(__mpi_points_free)(&n);
        if (n.fut != m->fut) kifmm__free(n.fut), kifmm__free(n.fvs);
        return rc;
    }
    KIFMM__F(__mpi_points_free)(m);
    *m = n;
    m->st.t_update = kifmm__now() - t0;
    return KIFMM_SUCCESS;
}

KIFMM__FN void KIFMM__F(__mpi_free)(KIFMM__F(__mpi) *m)
{
    KIFMM_NAME tmp;
    int fin = 1;
    if (!m) return;
    KIFMM__F(__mpi_points_free)(m);
    if (m->pl) {
        memset(&tmp, 0, sizeof tmp);
        tmp.pl = m->pl;
        KIFMM__F(__plan_release)(&tmp);
    }
    kifmm__free(m->fut);
    kifmm__free(m->fvs);
    /* after MPI_Finalize (a handle a garbage collector frees late) the
     * communicator went with MPI */
    if (m->comm != MPI_COMM_NULL && MPI_Finalized(&fin) == MPI_SUCCESS && !fin) MPI_Comm_free(&m->comm);
    kifmm__free(m);
}

KIFMM__FN void KIFMM__F(__mpi_destroy)(KIFMM_NAME *h)
{
    KIFMM__F(__mpi_free)(h->mpi);
    kifmm__free(h);
}

KIFMM__API int KIFMM__F(_create_mpi)(KIFMM_NAME **out, MPI_Comm comm, const kifmm_opts *opts,
                                     int64_t nsources_local, const KIFMM__R *src_xyz,
                                     int64_t ntargets_local, const KIFMM__R *trg_xyz)
{
    KIFMM__F(__mpi) *m = NULL;
    KIFMM_NAME *h = NULL;
    kifmm_opts o;
    int rc, on = 0, off = 0;
    if (out) *out = NULL;
    if (MPI_Initialized(&on) != MPI_SUCCESS || !on || MPI_Finalized(&off) != MPI_SUCCESS || off)
        return KIFMM_ERR_MPI;
    rc = out ? KIFMM__F(__validate)(opts, nsources_local, src_xyz, ntargets_local, trg_xyz, &o) : KIFMM_ERR_NULL;
    if (!rc && (o.period[0] > 0.0 || o.period[1] > 0.0 || o.period[2] > 0.0)) rc = KIFMM_ERR_PERIODIC;
    if (!rc && KIFMM__TOL_UNROOTED(o)) rc = KIFMM_ERR_TOL;
#if KIFMM__HAS_QT & KIFMM_HAS_WAVES
    if (!rc && o.tol != 0.0) {
        /* opts.tol, on several ranks: a rank's evaluating tree may take
         * expansions of boxes half the root wide (docs/kernels.md, MPI) */
        int size = 1;
        if (MPI_Comm_size(comm, &size) != MPI_SUCCESS) rc = KIFMM_ERR_MPI;
        else if (size > 1) rc = KIFMM__F(__tol_root)(&o, opts->leaf_size, 4.0 * o.domain[3]);
    }
#endif
    if (!rc && !(KIFMM__MPI_KERNEL)) rc = KIFMM_ERR_MPI; /* not yet for this kernel */
    if (!rc) {
        h = (KIFMM_NAME *)kifmm__calloc(1, sizeof *h);
        m = (KIFMM__F(__mpi) *)kifmm__calloc(1, sizeof *m);
        if (m) m->comm = MPI_COMM_NULL;
        if (!h || !m || !(m->pl = KIFMM__F(__plan_new)(&o))) rc = KIFMM_ERR_NOMEM;
    }
    /* every rank dups, or none */
    if (!(rc = kifmm__mpi_agree(comm, rc)) && MPI_Comm_dup(comm, &m->comm) != MPI_SUCCESS) rc = KIFMM_ERR_MPI;
    if (!rc && (MPI_Comm_rank(m->comm, &m->rank) != MPI_SUCCESS || MPI_Comm_size(m->comm, &m->size) != MPI_SUCCESS))
        rc = KIFMM_ERR_MPI;
    if ((rc = kifmm__mpi_agree(comm, rc)) == KIFMM_SUCCESS) {
        m->o = o;
        m->o.operator_cache = m->pl->opts.operator_cache; /* the plan's copy */
        m->shape[0] = opts ? opts->leaf_size : 0, m->shape[1] = opts ? opts->max_depth : 0;
        for (m->lc = 2; m->lc < 4 && ((int64_t)1 << (3 * (m->lc - 1))) < m->size; m->lc++) {}
        if (m->size == 1) { /* the handle create would make, on the caller's points */
            m->ns = m->nso = nsources_local, m->nt = m->nto = ntargets_local;
            rc = KIFMM__F(__build)(&m->main, m->pl, 0, 0, 1, &o, m->shape, NULL, nsources_local, src_xyz,
                                   ntargets_local, trg_xyz);
        } else {
            rc = KIFMM__F(__mpi_build)(m, nsources_local, src_xyz, ntargets_local, trg_xyz);
        }
        rc = kifmm__mpi_agree(comm, rc);
    }
    if (rc) {
        KIFMM__F(__mpi_free)(m);
        kifmm__free(h);
        return rc;
    }
    h->mpi = m;
    h->opts = m->o; /* the caller's, resolved (main's has its own root and depth) */
    *out = h;
    return KIFMM_SUCCESS;
}

#undef KIFMM__MPI_REAL
#undef KIFMM__MPI_KERNEL
#undef KIFMM__MPI_ROLES
#undef KIFMM__MPI_BOXES
#undef KIFMM__MPI_CUTOFF
#endif /* KIFMM_MPI */

#endif /* KIFMM_DECLARE */

// >>epilogue: the next include starts clean

#ifndef KIFMM_DECLARE
#undef KIFMM__LVL
#undef KIFMM__FFT_KBN
#undef KIFMM__FFT_OUTN
#undef KIFMM__FFT_PN
#undef KIFMM__NEAR_HOOK
#undef KIFMM__MUTUAL
#undef KIFMM__LEAF_KIND
#undef KIFMM__TOL_UNROOTED
#undef KIFMM__TOL_POINTS
#undef KIFMM__GEMM_COLS
#undef KIFMM__FFT
#undef KIFMM__CUTOFF
#undef KIFMM__TINY
#undef KIFMM__DEFINE_P2P_HOOKN
#undef KIFMM__P2P_SIG
#undef KIFMM__DEFINE_P2P_HOOK
#undef KIFMM__DEFINE_P2P
#undef KIFMM__QD
#undef KIFMM__UD
#undef KIFMM__ST_IN
#undef KIFMM__QC_IN
#undef KIFMM__TD
#undef KIFMM__SD
#undef KIFMM__SI
#undef KIFMM__RADIAL
#undef KIFMM__CPLX
#undef KIFMM__ANCHORS
#undef KIFMM__C2E_SIGN
#undef KIFMM__FSD
#undef KIFMM__FRADIAL
#undef KIFMM__EWALD
#undef KIFMM__DEGREE
#undef KIFMM__ROLE_QT
#undef KIFMM__ROLE_SC
#undef KIFMM__ROLE_ST
#undef KIFMM__ROLE_QC
#undef KIFMM__R_
#undef KIFMM__RCAT
#undef KIFMM__RCAT_
#undef KIFMM__LEGACY_HAS
#undef KIFMM__HAS_OF
#undef KIFMM__HAS_QT
#undef KIFMM__HAS_ST
#undef KIFMM__HAS_QC
#undef KIFMM__HAS_SC
#undef KIFMM__B_P2P
#undef KIFMM__B_P2PN
#undef KIFMM__B_P2PS
#undef KIFMM__B_P2PSN
#undef KIFMM__HOOK
#endif /* KIFMM_DECLARE */
#undef KIFMM__API
#undef KIFMM__FLOAT
#undef KIFMM__CMAX
#undef KIFMM__EMIN
#undef KIFMM__R
#undef KIFMM__F
#undef KIFMM__K
#undef KIFMM_NAME
#undef KIFMM_REAL
#undef KIFMM_KERNEL

#undef KIFMM_M2L_DENSE
#undef KIFMM_DECLARE
#undef KIFMM_IMPLEMENT

#if defined(__GNUC__) && !defined(__clang__) && defined(__cplusplus)
#pragma GCC diagnostic pop
#endif
#endif /* KIFMM__PREC_PASS: the normal pass */

/* License: MIT. Copyright (c) 2026 the kifmm.h authors. Permission is hereby
 * granted, free of charge, to any person obtaining a copy of this software, to
 * deal in it without restriction, provided this notice is kept. THE SOFTWARE
 * IS PROVIDED "AS IS", WITHOUT WARRANTY OF ANY KIND. */
