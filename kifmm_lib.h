/* kifmm_lib.h - the compiled library's instances: every kernel shipped in
 * kifmm_kernels.h, in double (kifmm_<kernel>_*) and in float
 * (kifmm_<kernel>f_*), declared with KIFMM_DECLARE (docs/api.md,
 * "Linkage"). A program that links libkifmm (pkg-config kifmm, or CMake's
 * kifmm::kifmm) includes this header instead of kifmm.h and compiles none
 * of the library; src/kifmm_lib.c, the library's one source file, defines
 * KIFMM_LIB_IMPLEMENT before including it and so compiles the instances
 * (KIFMM_IMPLEMENT); with KIFMM_LIB_PART 1 (or 2) as well it compiles the
 * double (or the float) half only, so that make builds the two halves at
 * once (two objects). make lib compiles them once per instruction-set
 * level and src/kifmm_dispatch.c picks a level at run time (docs/api.md,
 * "The compiled library's levels"). Kernels of your own: include kifmm.h (header-only),
 * beside this header if you like. MPI mode: make lib-mpi builds
 * libkifmm_mpi.so from the same file with KIFMM_MPI; a host that defines
 * KIFMM_MPI (and includes <mpi.h>) before this header sees its
 * <prefix>_create_mpi declarations and links that library. */
#ifndef KIFMM_LIB_H
#define KIFMM_LIB_H

/* kifmm_strerror is static in every translation unit (kifmm.h); the library
 * exports it under this name for hosts that cannot compile the header
 * (bindings through a foreign-function interface). */
#ifdef __cplusplus
extern "C" const char *kifmm_lib_strerror(int code);
#else
const char *kifmm_lib_strerror(int code);
#endif

#if !defined(KIFMM_LIB_IMPLEMENT) || !defined(KIFMM_LIB_PART)
#define KIFMM__LIB_HALVES 3
#elif KIFMM_LIB_PART == 1 || KIFMM_LIB_PART == 2
#define KIFMM__LIB_HALVES KIFMM_LIB_PART
#else
#error "KIFMM_LIB_PART: 1 (the double instances) or 2 (the float ones)"
#endif

/* ---- double ---- */
#if KIFMM__LIB_HALVES & 1
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL laplace
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL laplace_grad
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL laplace_hess
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL laplace_dipole
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL laplace_dipole_grad
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL laplace_cd
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL laplace_cd_grad
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL laplace_cd_hess
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL yukawa
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL yukawa_grad
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL yukawa_cd
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL yukawa_cd_grad
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL stokes
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL stokes_grad
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL stokes_pvel
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL stokes_dl
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL biot_savart
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL biot_savart_grad
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL helmholtz
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL helmholtz_grad
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL helmholtz_cd_grad
#include "kifmm.h"
#endif

/* ---- float ---- */
#if KIFMM__LIB_HALVES & 2
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL laplace
#define KIFMM_REAL float
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL laplace_grad
#define KIFMM_REAL float
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL laplace_hess
#define KIFMM_REAL float
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL laplace_dipole
#define KIFMM_REAL float
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL laplace_dipole_grad
#define KIFMM_REAL float
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL laplace_cd
#define KIFMM_REAL float
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL laplace_cd_grad
#define KIFMM_REAL float
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL laplace_cd_hess
#define KIFMM_REAL float
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL yukawa
#define KIFMM_REAL float
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL yukawa_grad
#define KIFMM_REAL float
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL yukawa_cd
#define KIFMM_REAL float
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL yukawa_cd_grad
#define KIFMM_REAL float
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL stokes
#define KIFMM_REAL float
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL stokes_grad
#define KIFMM_REAL float
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL stokes_pvel
#define KIFMM_REAL float
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL stokes_dl
#define KIFMM_REAL float
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL biot_savart
#define KIFMM_REAL float
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL biot_savart_grad
#define KIFMM_REAL float
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL helmholtz
#define KIFMM_REAL float
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL helmholtz_grad
#define KIFMM_REAL float
#include "kifmm.h"
#ifdef KIFMM_LIB_IMPLEMENT
#define KIFMM_IMPLEMENT
#else
#define KIFMM_DECLARE
#endif
#define KIFMM_KERNEL helmholtz_cd_grad
#define KIFMM_REAL float
#include "kifmm.h"
#endif
#undef KIFMM__LIB_HALVES

#endif
