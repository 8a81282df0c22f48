#!/usr/bin/env bash
# tests/python.sh - the Python package (python/), as its users install it:
# a virtual environment build/pyvenv (python3 -m venv; PYTHON= another
# interpreter) with numpy and pytest from PyPI; pip install ./python,
# packaging the libkifmm.so that make lib built (KIFMM_PREBUILT, python/
# setup.py) instead of compiling it a second time; pytest python/tests,
# from outside the source tree so that the installed package is the one
# imported; and the N-body example at 20,000 bodies. The last line is
# "python: ok" or "python: FAILED"; the exit status is nonzero on failure.
set -u
cd "$(dirname "$0")/.." || exit 1
PY=${PYTHON:-python3}
VENV=build/pyvenv
fail() { echo "python: FAILED ($1)"; exit 1; }
make --no-print-directory lib > /dev/null || fail "make lib"
[ -x "$VENV/bin/python" ] || "$PY" -m venv "$VENV" || fail "python3 -m venv"
"$VENV/bin/pip" install -q numpy pytest || fail "pip install numpy pytest"
KIFMM_PREBUILT=$(ls "$(pwd)"/build/lib/libkifmm.so.*.*.*) "$VENV/bin/pip" install -q --force-reinstall \
    --no-deps ./python || fail "pip install ./python"
rm -rf python/build python/*.egg-info
(cd build && "../$VENV/bin/python" -m pytest -q ../python/tests) || fail "pytest"
"$VENV/bin/python" python/examples/nbody.py 20000 2 || fail "examples/nbody.py"
echo "python: ok"
