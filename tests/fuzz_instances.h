/* fuzz_instances.h - the kifmm.h instances of the fuzz target, in two halves
 * that compile in parallel (tests/fuzz.sh; one translation unit of all
 * thirteen took 180 s under clang -O1 with the sanitizers, 2 cores of an
 * AMD EPYC). FUZZ_PART 1 or 2 (tests/fuzz_instances.c, compiled twice)
 * implements that half (KIFMM_IMPLEMENT) and declares the other; undefined
 * (tests/fuzz_create.c, the harness) declares all (KIFMM_DECLARE). */
#ifndef FUZZ_INSTANCES_H
#define FUZZ_INSTANCES_H
#ifndef FUZZ_PART
#define FUZZ_PART 0
#endif

#define FUZZ_HALF 1
#include "fuzz_mode.h"
#include "kifmm.h" /* kifmm_laplace */
#include "fuzz_mode.h"
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"
#include "fuzz_mode.h"
#define KIFMM_KERNEL laplace_hess
#include "kifmm.h"
#include "fuzz_mode.h"
#define KIFMM_KERNEL laplace_dipole
#include "kifmm.h"
#include "fuzz_mode.h"
#define KIFMM_KERNEL laplace_cd
#include "kifmm.h"
#include "fuzz_mode.h"
#define KIFMM_KERNEL yukawa
#include "kifmm.h"
#include "fuzz_mode.h"
#define KIFMM_KERNEL yukawa_grad
#include "kifmm.h"

#undef FUZZ_HALF
#define FUZZ_HALF 2
#include "fuzz_mode.h"
#define KIFMM_KERNEL stokes
#include "kifmm.h"
#include "fuzz_mode.h"
#define KIFMM_KERNEL stokes_dl
#include "kifmm.h"
#include "fuzz_mode.h"
#define KIFMM_KERNEL biot_savart
#include "kifmm.h"
#include "fuzz_mode.h"
#define KIFMM_KERNEL laplace
#define KIFMM_REAL float
#include "kifmm.h" /* kifmm_laplacef */
#include "fuzz_mode.h"
#define KIFMM_KERNEL stokes
#define KIFMM_REAL float
#include "kifmm.h" /* kifmm_stokesf */
#include "fuzz_mode.h"
#define KIFMM_KERNEL yukawa
#define KIFMM_REAL float
#include "kifmm.h" /* kifmm_yukawaf */
#undef FUZZ_HALF

#endif
