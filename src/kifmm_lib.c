/* src/kifmm_lib.c - the one source file of libkifmm: the instances of
 * kifmm_lib.h (every shipped kernel, double and float) with external
 * linkage. make lib builds it into build/lib/libkifmm.a and libkifmm.so;
 * make install installs them (Makefile). */
#define KIFMM_LIB_IMPLEMENT
#include "kifmm_lib.h"

const char *kifmm_lib_strerror(int code) { return kifmm_strerror(code); }
