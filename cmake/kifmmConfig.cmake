# kifmmConfig.cmake - find_package(kifmm) for an installed kifmm.h (make install).
#
#   kifmm::kifmm    libkifmm, the shipped kernels compiled in double and float:
#                   #include "kifmm_lib.h" and call kifmm_laplace_create, ...
#   kifmm::headers  header-only use of kifmm.h and kifmm_kernels.h (any kernel,
#                   your own too): the include directory, OpenMP, OpenBLAS's
#                   CBLAS and LAPACKE; -O2 when the project sets no build type
#                   (an unoptimised FMM is 5 to 10 times slower)
#
# Relocatable: every path is found from this file's own place,
# <prefix>/lib/cmake/kifmm.

get_filename_component(_kifmm_prefix "${CMAKE_CURRENT_LIST_DIR}/../../.." ABSOLUTE)
set(kifmm_INCLUDE_DIR "${_kifmm_prefix}/include")

include(CMakeFindDependencyMacro)
find_dependency(OpenMP)
if(CMAKE_C_COMPILER_LOADED)
  set(_kifmm_omp OpenMP::OpenMP_C)
else()
  set(_kifmm_omp OpenMP::OpenMP_CXX)
endif()
find_library(KIFMM_OPENBLAS_LIBRARY NAMES openblas)
find_library(KIFMM_LAPACKE_LIBRARY NAMES lapacke)
find_path(KIFMM_CBLAS_INCLUDE_DIR cblas.h PATH_SUFFIXES openblas)
if(NOT KIFMM_OPENBLAS_LIBRARY OR NOT KIFMM_LAPACKE_LIBRARY OR NOT KIFMM_CBLAS_INCLUDE_DIR)
  set(kifmm_FOUND FALSE)
  set(kifmm_NOT_FOUND_MESSAGE
      "kifmm needs OpenBLAS (libopenblas, cblas.h) and LAPACKE (Debian: apt-get install libopenblas-dev liblapacke-dev)")
  return()
endif()
set(_kifmm_deps ${_kifmm_omp} ${KIFMM_LAPACKE_LIBRARY} ${KIFMM_OPENBLAS_LIBRARY} m)

if(NOT TARGET kifmm::headers)
  add_library(kifmm::headers INTERFACE IMPORTED)
  set_target_properties(kifmm::headers PROPERTIES
    INTERFACE_INCLUDE_DIRECTORIES "${kifmm_INCLUDE_DIR};${KIFMM_CBLAS_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${_kifmm_deps}")
  if(NOT CMAKE_BUILD_TYPE AND NOT CMAKE_CONFIGURATION_TYPES)
    set_property(TARGET kifmm::headers APPEND PROPERTY INTERFACE_COMPILE_OPTIONS -O2)
  endif()
endif()

if(NOT TARGET kifmm::kifmm)
  find_library(KIFMM_LIBRARY NAMES kifmm PATHS "${_kifmm_prefix}/lib" NO_DEFAULT_PATH)
  if(NOT KIFMM_LIBRARY)
    set(kifmm_FOUND FALSE)
    set(kifmm_NOT_FOUND_MESSAGE "libkifmm not found under ${_kifmm_prefix}/lib")
    return()
  endif()
  add_library(kifmm::kifmm UNKNOWN IMPORTED)
  set_target_properties(kifmm::kifmm PROPERTIES
    IMPORTED_LOCATION "${KIFMM_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${kifmm_INCLUDE_DIR}")
  if(KIFMM_LIBRARY MATCHES "\\.a$")
    # the static library: its dependencies are the host's to link
    set_property(TARGET kifmm::kifmm PROPERTY INTERFACE_LINK_LIBRARIES "${_kifmm_deps}")
  else()
    set_property(TARGET kifmm::kifmm PROPERTY INTERFACE_LINK_LIBRARIES m)
  endif()
endif()
set(kifmm_FOUND TRUE)
