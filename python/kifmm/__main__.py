"""python -m kifmm: the build this package runs (version, library, code
paths, threads, BLAS), to paste into a report or to check an install.

    python -m kifmm                  the build
    python -m kifmm --kernels        every kernel's description
    python -m kifmm --kernels-md     the kernels table of docs/kernels.md
"""
import ctypes
import os
import sys

import numpy as np

import kifmm
from kifmm import _kernels


def _blas():
    """OpenBLAS's own description of its build, when the library is
    OpenBLAS: looked up through libkifmm (whose dependencies dlsym
    searches), then the whole process."""
    for lib in (kifmm._lib, ctypes.CDLL(None)):
        try:
            f = lib.openblas_get_config
        except AttributeError:
            continue
        f.restype = ctypes.c_char_p
        f.argtypes = []
        return f().decode()
    return "unknown (openblas_get_config not found)"


def _mapped(words):
    """Shared libraries of this process whose names hold one of words."""
    try:
        with open("/proc/self/maps") as f:
            paths = {line.split()[-1] for line in f if "/" in line}
    except OSError:
        return []
    return sorted(p for p in paths if any(w in os.path.basename(p) for w in words))


def build_info():
    with kifmm.FMM("laplace", np.random.default_rng(0).random((64, 3)), order=2) as fmm:
        st = fmm.stats
    simd = {512: "AVX-512", 256: "AVX2 + FMA", 0: "none"}.get(st["simd"], str(st["simd"]))
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:
        cpus = os.cpu_count()
    libs = _mapped(("blas", "lapack", "mkl", "gomp", "libomp", "iomp"))
    lines = [
        f"kifmm (Python) version: {kifmm.__version__}",
        f"package: {os.path.dirname(os.path.abspath(kifmm.__file__))}",
        f"library: {kifmm._lib._name}",
        f"build: {st['build']}",
        f"simd: {st['simd']} bits ({simd})",
        f"threads: {st['threads']} by default (CPUs available to this process: {cpus}, "
        f"OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', 'unset')})",
        f"blas: {_blas()}",
    ]
    lines += [f"loaded: {p}" for p in libs]
    return "\n".join(lines)


def main(argv):
    if argv == ["--kernels-md"]:
        sys.stdout.write(_kernels.markdown())
    elif argv == ["--kernels"]:
        print("\n\n".join(_kernels.help_text(k.name) for k in _kernels.KERNEL_TABLE))
    elif not argv:
        print(build_info())
    else:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
