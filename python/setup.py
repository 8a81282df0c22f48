"""Builds libkifmm.so (src/kifmm_lib.c of the kifmm.h checkout this
directory sits in) into the package, then installs it with the Python code.

    pip install ./python          from the checkout's root
    pip install -v ./python       the same, with the compiler's full log

Needs a C compiler with OpenMP, OpenBLAS and LAPACKE (Debian: apt-get install
build-essential libopenblas-dev liblapacke-dev). Environment: CC (default
cc) and KIFMM_CFLAGS (default "-O2 -march=native -fopenmp"; "-O2 -fopenmp"
for a build to copy to other machines); KIFMM_PREBUILT, the path of a
libkifmm.so already built from the same checkout (make lib), to package
that one instead of compiling again.

Where mpicc is on the PATH (or MPICC names one) it also builds
libkifmm_mpi.so, the same instances with KIFMM_MPI, for FMM(comm=...)
(another minute or two; KIFMM_PREBUILT_MPI: one built by make lib-mpi;
KIFMM_NO_MPI=1: none). Without it the package works as before and comm=
says what is missing.

Nothing is written into the checkout: setuptools' build and egg-info
directories go to a temporary directory, so a read-only checkout installs."""
import atexit
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


TTY = "/dev/tty"


def announce(line, first=True):
    """One line for the person waiting: pip captures a build's stdout and
    stderr and shows them only with -v (or on failure), but the terminal
    itself stays reachable through /dev/tty. The first line leaves pip's
    spinner line; a later one starts with a carriage return so that it
    covers the spinner's character."""
    try:
        with open(TTY, "a") as tty:
            tty.write(("\n" if first else "\r") + line + "\n")
            return
    except OSError:
        pass
    print(line, file=sys.stderr, flush=True)


def compile_library(cmd, say=announce, name="libkifmm.so"):
    """Run the compiler command cmd, saying before that it runs and after
    how long it took (a minute or two: every kernel in two precisions)."""
    say(f"kifmm: compiling {name} (about 1-2 minutes) ...")
    print(" ".join(cmd), flush=True)
    t0 = time.monotonic()
    subprocess.check_call(cmd)
    say(f"kifmm: compiled in {time.monotonic() - t0:.0f} s", first=False)


def library_command(out, mpi=False):
    src = ROOT / "src" / "kifmm_lib.c"
    if not src.exists():
        raise RuntimeError(f"{src} not found: install from a kifmm.h checkout (pip install ./python)")
    cflags = shlex.split(os.environ.get("KIFMM_CFLAGS", "-O2 -march=native -fopenmp"))
    cc = [mpi, "-DKIFMM_MPI"] if mpi else [os.environ.get("CC", "cc")]
    return [*cc, "-std=c99", *cflags, "-fPIC", "-shared", f"-I{ROOT}",
            str(src), "-o", str(out), "-llapacke", "-lopenblas", "-lm"]


def mpi_compiler():
    """The MPI compiler wrapper for libkifmm_mpi.so, or None."""
    if os.environ.get("KIFMM_NO_MPI"):
        return None
    return shutil.which(os.environ.get("MPICC", "mpicc"))


if __name__ == "__main__":
    from setuptools import setup
    from setuptools.command.build_py import build_py
    from setuptools.dist import Distribution

    class BuildWithLibrary(build_py):
        def run(self):
            super().run()
            out = Path(self.build_lib) / "kifmm" / "libkifmm.so"
            out.parent.mkdir(parents=True, exist_ok=True)
            if os.environ.get("KIFMM_PREBUILT"):
                shutil.copyfile(os.environ["KIFMM_PREBUILT"], out)
            else:
                compile_library(library_command(out))
            out_mpi = out.with_name("libkifmm_mpi.so")
            if os.environ.get("KIFMM_PREBUILT_MPI"):
                shutil.copyfile(os.environ["KIFMM_PREBUILT_MPI"], out_mpi)
            elif mpi_compiler():
                compile_library(library_command(out_mpi, mpi_compiler()), name="libkifmm_mpi.so")

    try:
        from setuptools.command.bdist_wheel import bdist_wheel
    except ImportError:  # setuptools before 70.1
        from wheel.bdist_wheel import bdist_wheel

    class PlatformWheel(bdist_wheel):
        """py3-none-<platform>: the package loads its library with ctypes, so
        one wheel serves every Python 3 on the platform."""

        def get_tag(self):
            return ("py3", "none", super().get_tag()[2])

    class BinaryDistribution(Distribution):
        """A wheel for this platform: it carries a compiled library."""

        def has_ext_modules(self):
            return True

    # setuptools writes build/ and kifmm.egg-info beside setup.py unless
    # told otherwise, which fails in a read-only checkout; pip runs each
    # build step in a process of its own, so each gets its own directory.
    scratch = tempfile.mkdtemp(prefix="kifmm-build-")
    atexit.register(shutil.rmtree, scratch, ignore_errors=True)
    setup(cmdclass={"build_py": BuildWithLibrary, "bdist_wheel": PlatformWheel},
          distclass=BinaryDistribution,
          options={"build": {"build_base": os.path.join(scratch, "build")},
                   "egg_info": {"egg_base": scratch}})
