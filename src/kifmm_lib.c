/* src/kifmm_lib.c - the one source file of libkifmm: the instances of
 * kifmm_lib.h (every shipped kernel, double and float) with external
 * linkage. make lib builds it into build/lib/libkifmm.a and libkifmm.so;
 * make install installs them (Makefile). Compiled with -DKIFMM_LIB_PART=1
 * it holds the double instances and kifmm_lib_strerror, with
 * -DKIFMM_LIB_PART=2 the float instances: make builds the two objects at
 * once; without the macro, everything (one object). make lib compiles it
 * once per instruction-set level, renames each level's symbols and links
 * src/kifmm_dispatch.c, which defines the public ones. */
#define KIFMM_LIB_IMPLEMENT
#include "kifmm_lib.h"

#if !defined(KIFMM_LIB_PART) || KIFMM_LIB_PART == 1
const char *kifmm_lib_strerror(int code) { return kifmm_strerror(code); }
#endif
