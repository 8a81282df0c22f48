"""Builds libkifmm.so (src/kifmm_lib.c of the kifmm.h checkout this
directory sits in) into the package, then installs it with the Python code.

    pip install ./python          from the checkout's root

Needs a C compiler with OpenMP, OpenBLAS and LAPACKE (Debian: apt-get install
build-essential libopenblas-dev liblapacke-dev). Environment: CC (default
cc) and KIFMM_CFLAGS (default "-O2 -march=native -fopenmp"; "-O2 -fopenmp"
for a build to copy to other machines); KIFMM_PREBUILT, the path of a
libkifmm.so already built from the same checkout (make lib), to package
that one instead of compiling again."""
import os
import shlex
import shutil
import subprocess
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py
from setuptools.dist import Distribution

ROOT = Path(__file__).resolve().parent.parent


class BuildWithLibrary(build_py):
    def run(self):
        super().run()
        src = ROOT / "src" / "kifmm_lib.c"
        if not src.exists():
            raise RuntimeError(f"{src} not found: install from a kifmm.h checkout (pip install ./python)")
        out = Path(self.build_lib) / "kifmm" / "libkifmm.so"
        out.parent.mkdir(parents=True, exist_ok=True)
        if os.environ.get("KIFMM_PREBUILT"):
            shutil.copyfile(os.environ["KIFMM_PREBUILT"], out)
            return
        cflags = shlex.split(os.environ.get("KIFMM_CFLAGS", "-O2 -march=native -fopenmp"))
        cmd = [os.environ.get("CC", "cc"), "-std=c99", *cflags, "-fPIC", "-shared", f"-I{ROOT}",
               str(src), "-o", str(out), "-llapacke", "-lopenblas", "-lm"]
        print(" ".join(cmd), flush=True)
        subprocess.check_call(cmd)


class BinaryDistribution(Distribution):
    """A wheel for this platform: it carries a compiled library."""

    def has_ext_modules(self):
        return True


setup(cmdclass={"build_py": BuildWithLibrary}, distclass=BinaryDistribution)
