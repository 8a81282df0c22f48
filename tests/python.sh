#!/usr/bin/env bash
# tests/python.sh - the Python package (python/), as its users install it:
# a virtual environment build/pyvenv (python3 -m venv; PYTHON= another
# interpreter) with numpy and pytest from PyPI; pip install ./python,
# packaging the libkifmm.so that make lib built (KIFMM_PREBUILT, python/
# setup.py) instead of compiling it a second time, checking that the build
# wrote nothing into python/ (with libkifmm_mpi.so and mpi4py where mpicc
# exists, for the MPI tests); pytest python/tests, from outside the source
# tree so that the installed package is the one imported, with
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
make --no-print-directory -j2 lib > /dev/null || fail "make lib"
[ -x "$VENV/bin/python" ] || "$PY" -m venv "$VENV" || fail "python3 -m venv"
"$VENV/bin/pip" install -q numpy pytest || fail "pip install numpy pytest"
LIB=$(ls "$(pwd)"/build/lib/libkifmm.so.*.*.*)
# MPI mode (FMM(comm=...), python/tests/test_mpi.py) where mpicc exists:
# libkifmm_mpi.so from make lib-mpi, mpi4py from PyPI (its wheel runs on the
# system's MPI)
export KIFMM_NO_MPI=1
if command -v mpicc > /dev/null; then
    make --no-print-directory -j2 lib-mpi > /dev/null || fail "make lib-mpi"
    "$VENV/bin/pip" install -q mpi4py || fail "pip install mpi4py"
    export KIFMM_PREBUILT_MPI=$(pwd)/build/lib/libkifmm_mpi.so
    unset KIFMM_NO_MPI
fi
rm -rf python/build python/*.egg-info   # left by older versions of setup.py
KIFMM_PREBUILT=$LIB "$VENV/bin/pip" install -q --force-reinstall --no-deps ./python \
    || fail "pip install ./python"
for d in python/build python/*.egg-info; do
    [ -e "$d" ] && fail "pip install ./python wrote $d into the checkout"
done
(cd build && KIFMM_TEST_INSTALL=1 KIFMM_PREBUILT=$LIB "../$VENV/bin/python" -m pytest -q -rs \
    ../python/tests) || fail "pytest"
"$VENV/bin/python" python/examples/nbody.py 20000 2 || fail "examples/nbody.py"
echo "python: ok"
