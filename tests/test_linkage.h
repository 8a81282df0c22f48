/* tests/test_linkage.h - the header of a small library of kifmm.h instances,
 * written as a project that ships one would write it (the pattern of STC's
 * linkage modes): every program includes it for the declarations; exactly
 * one translation unit of the library, tests/linkage_lib.c, defines
 * TEST_LINKAGE_IMPLEMENT before including it and so compiles the instances.
 *
 *   kifmm_laplace        Laplace potential, double
 *   kifmm_laplace_grad   Laplace potential and gradient, double
 *   lib_stokes           Stokeslet, float (a prefix of its own)
 *
 * tests/run.sh builds tests/linkage_lib.c into a static library
 * (libkifmm_linkage.a) and links test_linkage_a and test_linkage_b against
 * it; neither program compiles any of kifmm.h's implementation. */
#ifndef TEST_LINKAGE_H
#define TEST_LINKAGE_H

#ifdef TEST_LINKAGE_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL laplace
#include "kifmm.h"

#ifdef TEST_LINKAGE_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"

#ifdef TEST_LINKAGE_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL stokes
#define KIFMM_REAL float
#define KIFMM_NAME lib_stokes
#include "kifmm.h"

#endif
