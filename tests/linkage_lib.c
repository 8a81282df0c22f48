/* tests/linkage_lib.c - the one translation unit of libkifmm_linkage.a:
 * the instances of tests/test_linkage.h with external linkage. */
#define TEST_LINKAGE_IMPLEMENT
#include "test_linkage.h"
