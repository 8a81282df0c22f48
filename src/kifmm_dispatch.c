/* src/kifmm_dispatch.c - the public functions of a libkifmm built for
 * several instruction-set levels (make lib, LIB_LEVELS). src/kifmm_lib.c is
 * compiled once per level (avx512: -march=x86-64-v4; avx2: -march=x86-64-v3;
 * base: the compiler's default target, SSE2 on x86-64) and the Makefile
 * renames each object's public symbols kifmm_<name> to
 * kifmm__<level>_kifmm_<name> (objcopy). This file defines every
 * kifmm_<name> of kifmm_lib.h: each calls the same function of one level,
 * the best this CPU runs, chosen at the first call and kept for the life of
 * the process. KIFMM_ISA=avx512, avx2 or base in the environment caps the
 * level (one higher than the CPU runs is not taken). <prefix>_stats appends
 * the level and why to stats.build. Compiled with -DKIFMM_LIB_HAS_AVX512,
 * -DKIFMM_LIB_HAS_AVX2 and -DKIFMM_LIB_HAS_BASE for the levels built.
 *
 * Contents:
 *   >>levels   detection, KIFMM_ISA, the level in words
 *   >>calls    the instances and their functions, one wrapper each */
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "kifmm_lib.h"

#if !defined(KIFMM_LIB_HAS_AVX512) && !defined(KIFMM_LIB_HAS_AVX2) && !defined(KIFMM_LIB_HAS_BASE)
#error "kifmm_dispatch.c: build at least one level (-DKIFMM_LIB_HAS_BASE; the Makefile's LIB_LEVELS)"
#endif
#if (defined(KIFMM_LIB_HAS_AVX512) || defined(KIFMM_LIB_HAS_AVX2)) && \
    !(defined(__x86_64__) || defined(__i386__))
#error "kifmm_dispatch.c: the avx512 and avx2 levels are x86 ones (LIB_LEVELS=base elsewhere)"
#endif
#if defined(__x86_64__) || defined(__i386__)
#include <cpuid.h>
#endif

// >>levels

enum { KIFMM__LV_BASE, KIFMM__LV_AVX2, KIFMM__LV_AVX512 };
static const char *const kifmm__lv_name[3] = {"base", "avx2", "avx512"};

/* The highest level this CPU (and its operating system, which must save the
 * wide registers) runs: avx512 is x86-64-v4 (AVX-512 F, BW, CD, DQ, VL) and
 * avx2 is x86-64-v3 (AVX2, FMA, BMI1, BMI2, F16C, LZCNT, MOVBE, and
 * x86-64-v2's POPCNT, SSE4.2, CMPXCHG16B and LAHF), as the levels' -march
 * flags assume. */
static int kifmm__lv_cpu(void)
{
#if defined(__x86_64__) || defined(__i386__)
    unsigned a, b, c, d, leaf1 = 0, ext = 0;
    __builtin_cpu_init();
    /* CPUID 1, ECX: F16C 29, MOVBE 22, CMPXCHG16B 13; 0x80000001, ECX: LZCNT 5, LAHF 0 */
    if (__get_cpuid(1, &a, &b, &c, &d)) leaf1 = (c >> 29 & 1) && (c >> 22 & 1) && (c >> 13 & 1);
    if (__get_cpuid(0x80000001u, &a, &b, &c, &d)) ext = (c >> 5 & 1) && (c & 1);
    if (!(__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") &&
          __builtin_cpu_supports("bmi") && __builtin_cpu_supports("bmi2") &&
          __builtin_cpu_supports("popcnt") && __builtin_cpu_supports("sse4.2") && leaf1 && ext))
        return KIFMM__LV_BASE;
    if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
        __builtin_cpu_supports("avx512cd") && __builtin_cpu_supports("avx512dq") &&
        __builtin_cpu_supports("avx512vl"))
        return KIFMM__LV_AVX512;
    return KIFMM__LV_AVX2;
#else
    return KIFMM__LV_BASE;
#endif
}

static int kifmm__lv_built(int lv)
{
    switch (lv) {
#ifdef KIFMM_LIB_HAS_AVX512
    case KIFMM__LV_AVX512: return 1;
#endif
#ifdef KIFMM_LIB_HAS_AVX2
    case KIFMM__LV_AVX2: return 1;
#endif
#ifdef KIFMM_LIB_HAS_BASE
    case KIFMM__LV_BASE: return 1;
#endif
    default: return 0;
    }
}

/* The best level built that the CPU runs, at most the one KIFMM_ISA names;
 * the lowest level built when none of them fits (a library built without
 * base on a CPU below its levels: the call then faults as any binary for a
 * newer CPU would). */
static int kifmm__lv_choose(char *why, size_t n)
{
    const char *env = getenv("KIFMM_ISA");
    int cpu = kifmm__lv_cpu(), cap = cpu, asked = -1, lv, l;
    for (l = 0; env && l < 3; l++)
        if (!strcmp(env, kifmm__lv_name[l])) asked = l;
    if (asked >= 0 && asked < cap) cap = asked;
    for (lv = cap; lv >= 0 && !kifmm__lv_built(lv); lv--) continue;
    if (lv < 0)
        for (lv = 0; !kifmm__lv_built(lv); lv++) continue;
    if (!env)
        snprintf(why, n, "library level %s (this CPU: %s)", kifmm__lv_name[lv], kifmm__lv_name[cpu]);
    else
        snprintf(why, n, "library level %s (this CPU: %s; KIFMM_ISA=%.16s%s)", kifmm__lv_name[lv],
                 kifmm__lv_name[cpu], env, asked < 0 ? " ignored: not a level" : "");
    return lv;
}

/* The level the calls take and the sentence stats.build gets: set once,
 * at the first call of any thread. */
static int kifmm__lv;
static char kifmm__lv_text[112];
static pthread_once_t kifmm__lv_once = PTHREAD_ONCE_INIT;

static void kifmm__lv_init(void) { kifmm__lv = kifmm__lv_choose(kifmm__lv_text, sizeof kifmm__lv_text); }

static int kifmm__level(void)
{
    pthread_once(&kifmm__lv_once, kifmm__lv_init);
    return kifmm__lv;
}

// >>calls

/* The instances of kifmm_lib.h: KIFMM__DK_KERNELS(X) calls X(kernel) for
 * each (the Makefile checks that every symbol of the level objects has its
 * wrapper here). */
#define KIFMM__DK_KERNELS(X)                                                                        \
    X(laplace) X(laplace_grad) X(laplace_hess) X(laplace_dipole) X(laplace_dipole_grad)             \
    X(laplace_cd) X(laplace_cd_grad) X(laplace_cd_hess) X(yukawa) X(yukawa_grad) X(yukawa_cd)       \
    X(yukawa_cd_grad) X(stokes) X(stokes_grad) X(stokes_pvel) X(stokes_dl) X(biot_savart)           \
    X(biot_savart_grad) X(helmholtz) X(helmholtz_grad) X(helmholtz_cd_grad)

/* One instance's functions, N its name (kifmm_laplace, kifmm_laplacef), P
 * its plan type, R its real: X(return type, N, suffix, parameters, the
 * call's arguments) for those that return a value, V(...) for the void
 * ones. The parameters are kifmm.h's (>>api); a difference stops the
 * compile, as the declarations of kifmm_lib.h are in scope. */
#define KIFMM__DK_FUNCS(X, V, N, P, R)                                                             \
    X(int, N, _create, (N **o, const kifmm_opts *op, int64_t ns, const R *s, int64_t nt, const R *t), \
      (o, op, ns, s, nt, t))                                                                        \
    X(int, N, _update_points, (N *h, int64_t ns, const R *s, int64_t nt, const R *t), (h, ns, s, nt, t)) \
    X(int, N, _plan_create, (P **o, const kifmm_opts *op), (o, op))                                 \
    X(int, N, _create_with_plan, (N **o, P *pl, int64_t ns, const R *s, int64_t nt, const R *t),    \
      (o, pl, ns, s, nt, t))                                                                        \
    V(N, _plan_destroy, (P *pl), (pl))                                                              \
    X(kifmm_tree *, N, _tree, (const N *h), (h))                                                    \
    X(int, N, _create_on_tree, (N **o, const kifmm_opts *op, kifmm_tree *tr), (o, op, tr))          \
    X(int, N, _create_with_plan_on_tree, (N **o, P *pl, kifmm_tree *tr), (o, pl, tr))               \
    X(int, N, _update_on_tree, (N *h, kifmm_tree *tr), (h, tr))                                     \
    X(int, N, _evaluate, (N *h, const R *q, R *u), (h, q, u))                                       \
    X(int, N, _evaluate_many, (N *h, int m, const R *q, R *u), (h, m, q, u))                        \
    V(N, _destroy, (N *h), (h))                                                                     \
    X(int, N, _options, (const N *h, kifmm_opts *used), (h, used))                                  \
    X(int, N, _direct, (const kifmm_opts *op, int64_t ns, const R *s, const R *q, int64_t nt,       \
                        const R *t, R *u),                                                          \
      (op, ns, s, q, nt, t, u))                                                                     \
    X(int, N, _estimate_bytes, (const kifmm_opts *op, int64_t ns, int64_t nt, double *b),           \
      (op, ns, nt, b))

#define KIFMM__DK_CAT_(a, b) a##b
#define KIFMM__DK_CAT(a, b) KIFMM__DK_CAT_(a, b)
/* kifmm_<name> -> kifmm__<level>_kifmm_<name>: the levels' symbols */
#define KIFMM__DK_AT(lv, N, sfx) KIFMM__DK_CAT(KIFMM__DK_CAT(kifmm__##lv##_, N), sfx)

/* each level's declaration (where built), under its renamed symbol */
#ifdef KIFMM_LIB_HAS_AVX512
#define KIFMM__DK_DECL_AVX512(ret, N, sfx, par) extern ret KIFMM__DK_AT(avx512, N, sfx) par;
#else
#define KIFMM__DK_DECL_AVX512(ret, N, sfx, par)
#endif
#ifdef KIFMM_LIB_HAS_AVX2
#define KIFMM__DK_DECL_AVX2(ret, N, sfx, par) extern ret KIFMM__DK_AT(avx2, N, sfx) par;
#else
#define KIFMM__DK_DECL_AVX2(ret, N, sfx, par)
#endif
#ifdef KIFMM_LIB_HAS_BASE
#define KIFMM__DK_DECL_BASE(ret, N, sfx, par) extern ret KIFMM__DK_AT(base, N, sfx) par;
#else
#define KIFMM__DK_DECL_BASE(ret, N, sfx, par)
#endif
#define KIFMM__DK_DECL(ret, N, sfx, par)                                                             \
    KIFMM__DK_DECL_AVX512(ret, N, sfx, par) KIFMM__DK_DECL_AVX2(ret, N, sfx, par)                  \
    KIFMM__DK_DECL_BASE(ret, N, sfx, par)

/* the call of the chosen level: a statement per built level */
#ifdef KIFMM_LIB_HAS_AVX512
#define KIFMM__DK_CASE_AVX512(rtn, N, sfx, arg) \
    case KIFMM__LV_AVX512: rtn KIFMM__DK_AT(avx512, N, sfx) arg; break;
#else
#define KIFMM__DK_CASE_AVX512(rtn, N, sfx, arg)
#endif
#ifdef KIFMM_LIB_HAS_AVX2
#define KIFMM__DK_CASE_AVX2(rtn, N, sfx, arg) case KIFMM__LV_AVX2: rtn KIFMM__DK_AT(avx2, N, sfx) arg; break;
#else
#define KIFMM__DK_CASE_AVX2(rtn, N, sfx, arg)
#endif
#ifdef KIFMM_LIB_HAS_BASE
#define KIFMM__DK_CASE_BASE(rtn, N, sfx, arg) case KIFMM__LV_BASE: rtn KIFMM__DK_AT(base, N, sfx) arg; break;
#else
#define KIFMM__DK_CASE_BASE(rtn, N, sfx, arg)
#endif
#define KIFMM__DK_SWITCH(rtn, N, sfx, arg)                                                           \
    switch (kifmm__level()) {                                                                       \
        KIFMM__DK_CASE_AVX512(rtn, N, sfx, arg)                                                     \
        KIFMM__DK_CASE_AVX2(rtn, N, sfx, arg) KIFMM__DK_CASE_BASE(rtn, N, sfx, arg) default: break; \
    }

#define KIFMM__DK_ONE(ret, N, sfx, par, arg)                                                         \
    KIFMM__DK_DECL(ret, N, sfx, par)                                                                \
    ret KIFMM__DK_CAT(N, sfx) par                                                                   \
    {                                                                                               \
        ret r_ = 0;                                                                                 \
        KIFMM__DK_SWITCH(r_ =, N, sfx, arg)                                                         \
        return r_;                                                                                  \
    }
#define KIFMM__DK_ONEV(N, sfx, par, arg)                                                             \
    KIFMM__DK_DECL(void, N, sfx, par)                                                               \
    void KIFMM__DK_CAT(N, sfx) par { KIFMM__DK_SWITCH(, N, sfx, arg) }

/* <prefix>_stats: the level's, then the level in words after its build */
#define KIFMM__DK_STATS(N)                                                                           \
    KIFMM__DK_DECL(int, N, _stats, (const N *h, kifmm_stats *st))                                   \
    int KIFMM__DK_CAT(N, _stats)(const N *h, kifmm_stats *st)                                       \
    {                                                                                               \
        int r_ = KIFMM_ERR_INTERNAL;                                                                \
        KIFMM__DK_SWITCH(r_ =, N, _stats, (h, st))                                                  \
        if (r_ == KIFMM_SUCCESS) kifmm__dk_build(st);                                               \
        return r_;                                                                                  \
    }

static void kifmm__dk_build(kifmm_stats *st)
{
    size_t n = strlen(st->build);
    snprintf(st->build + n, sizeof st->build - n, "; %s", kifmm__lv_text);
}

#define KIFMM__DK_INSTANCE(k)                                                                        \
    KIFMM__DK_FUNCS(KIFMM__DK_ONE, KIFMM__DK_ONEV, kifmm_##k, kifmm_##k##_plan, double)             \
    KIFMM__DK_STATS(kifmm_##k)                                                                      \
    KIFMM__DK_FUNCS(KIFMM__DK_ONE, KIFMM__DK_ONEV, kifmm_##k##f, kifmm_##k##f_plan, float)          \
    KIFMM__DK_STATS(kifmm_##k##f)

KIFMM__DK_KERNELS(KIFMM__DK_INSTANCE)

KIFMM__DK_DECL(const char *, kifmm_lib, _strerror, (int code))
const char *kifmm_lib_strerror(int code)
{
    const char *r_ = "";
    KIFMM__DK_SWITCH(r_ =, kifmm_lib, _strerror, (code))
    return r_;
}
