#!/usr/bin/env bash
# tests/python.sh - the Python package (python/), as its users install it:
# the self-contained wheel of python/build_wheel.sh (make wheel: the library
# of every instruction-set level that make lib built, with OpenBLAS,
# LAPACKE and OpenMP inside), checked to load those from the wheel and to
# have written nothing into python/, installed into a virtual environment
# build/pyvenv (python3 -m venv, kept between runs; PYTHON= another interpreter) with numpy and
# pytest from PyPI (libkifmm_mpi.so from make lib-mpi, KIFMM_MPI_LIBRARY,
# and mpi4py where mpicc exists, for the MPI tests); pytest python/tests,
# from outside the source tree so that the installed package is the one
# imported, with KIFMM_PREBUILT for the tests that pip install ./python and
# KIFMM_TEST_INSTALL=1: one test also installs a read-only copy of the
# checkout as an unprivileged user (about 10 s; skipped, with the reason
# printed, where no such user can be switched to); and the N-body example
# at 20,000 bodies. The last line is "python: ok" or "python: FAILED"; the
# exit status is nonzero on failure.
set -u
cd "$(dirname "$0")/.." || exit 1
PY=${PYTHON:-python3}
VENV=build/pyvenv
fail() { echo "python: FAILED ($1)"; exit 1; }
rm -rf python/build python/*.egg-info   # left by older versions of setup.py
out=$(bash python/build_wheel.sh 2>&1) || { echo "$out" | tail -20; fail "python/build_wheel.sh"; }
echo "$out" | tail -1
for d in python/build python/*.egg-info; do
    [ -e "$d" ] && fail "building the wheel wrote $d into the checkout"
done
WHEEL=$(ls build/wheelhouse/kifmm-*.whl) || fail "no wheel in build/wheelhouse"
case "$WHEEL" in *-py3-none-manylinux_*) ;; *) fail "the wheel's tag: $WHEEL" ;; esac
[ -x "$VENV/bin/python" ] || "$PY" -m venv "$VENV" || fail "python3 -m venv"
"$VENV/bin/pip" install -q numpy pytest || fail "pip install numpy pytest"
"$VENV/bin/pip" install -q --force-reinstall --no-deps "$WHEEL" || fail "pip install $WHEEL"
# the installed library finds BLAS, LAPACKE, libgfortran and OpenMP in the
# wheel (kifmm.libs/), none of them in the system's directories
SITE=$("$VENV/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["platlib"])')
ldd "$SITE/kifmm/libkifmm.so" > build/.ldd || fail "ldd of the installed library"
sed 's/^/    /' build/.ldd
grep -Eq 'not found' build/.ldd && fail "the installed library misses a dependency"
grep -E 'openblas|lapack|blas|gfortran|gomp|quadmath' build/.ldd | grep -vq 'kifmm.libs/' \
    && fail "the installed library takes a dependency from outside the wheel"
for dep in openblas lapacke gfortran gomp; do
    grep -q "lib$dep[^ ]* => .*/kifmm.libs/" build/.ldd || fail "lib$dep is not taken from the wheel"
done
LIB=$(ls -t "$(pwd)"/build/lib/libkifmm.so.*.*.* | head -1)
# MPI mode (FMM(comm=...), python/tests/test_mpi.py) where mpicc exists:
# libkifmm_mpi.so from make lib-mpi, mpi4py from PyPI (its wheel runs on the
# system's MPI)
if command -v mpicc > /dev/null; then
    make --no-print-directory -j2 lib-mpi > /dev/null || fail "make lib-mpi"
    "$VENV/bin/pip" install -q mpi4py || fail "pip install mpi4py"
    export KIFMM_MPI_LIBRARY=$(pwd)/build/lib/libkifmm_mpi.so
else
    export KIFMM_NO_MPI=1
fi
(cd build && KIFMM_TEST_INSTALL=1 KIFMM_PREBUILT=$LIB "../$VENV/bin/python" -m pytest -q -rs \
    ../python/tests) || fail "pytest"
"$VENV/bin/python" python/examples/nbody.py 20000 2 || fail "examples/nbody.py"
echo "python: ok"
