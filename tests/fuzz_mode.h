/* fuzz_mode.h - before each include of fuzz_instances.h: the linkage mode of
 * the next instance (kifmm.h undefines it after each), KIFMM_IMPLEMENT in
 * the translation unit of its half (FUZZ_HALF), KIFMM_DECLARE elsewhere.
 * No include guard: it is meant to be included again and again. */
#if FUZZ_PART == FUZZ_HALF
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
