"""MPI mode from Python (FMM(comm=...)): python/tests/mpi_run.py under
mpirun on 1 and 3 ranks. Skipped, with the reason, where mpi4py, mpirun or
the package's libkifmm_mpi.so is missing."""
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import kifmm

HERE = Path(__file__).resolve().parent


def _why_not():
    try:
        import mpi4py  # noqa: F401  (only the package; MPI is not started here)
    except ImportError:
        return "mpi4py is not installed"
    if not shutil.which("mpirun"):
        return "no mpirun"
    lib = os.environ.get("KIFMM_MPI_LIBRARY") or Path(kifmm.__file__).with_name("libkifmm_mpi.so")
    if not Path(lib).exists():
        return f"no {lib} (the package was built without mpicc)"
    return None


@pytest.mark.skipif(_why_not() is not None, reason=str(_why_not()))
@pytest.mark.parametrize("ranks", [1, 3])
def test_fmm_with_comm(ranks):
    cmd = ["mpirun", "--oversubscribe", "--bind-to", "none"]
    if os.geteuid() == 0:
        cmd.append("--allow-run-as-root")
    env = dict(os.environ, OMP_NUM_THREADS="1", OMPI_MCA_btl_vader_single_copy_mechanism="none")
    run = cmd + ["-np", str(ranks), sys.executable, str(HERE / "mpi_run.py")]
    r = subprocess.run(run, capture_output=True, text=True, timeout=600, env=env)
    if "mpi_run:" not in r.stdout:  # MPI did not start (a container's small /dev/shm, as
        env["OMPI_MCA_btl"] = "self,tcp"  # tests/mpi.sh probes): again over TCP on loopback
        r = subprocess.run(run, capture_output=True, text=True, timeout=600, env=env)
    print(r.stdout[-6000:], r.stderr[-3000:])
    assert r.returncode == 0 and " 0 failed" in r.stdout, r.stdout[-6000:] + r.stderr[-3000:]


def test_comm_without_mpi4py_or_with_a_wrong_object():
    """comm= that is not a communicator is refused before anything runs;
    without mpi4py, ImportError says what to install."""
    try:
        import mpi4py  # noqa: F401
    except ImportError:
        with pytest.raises(ImportError, match="mpi4py"):
            kifmm.FMM("laplace", [[0.0, 0.0, 0.0]], comm=object())
        return
    pytest.skip("mpi4py is installed: mpi_run.py checks comm='world' under mpirun")
