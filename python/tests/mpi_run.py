"""FMM(comm=...) on the ranks of MPI.COMM_WORLD, run by test_mpi.py under
mpirun: each rank passes a share of one global problem, and the outputs
gathered from every rank are compared with direct sums (kifmm.direct) at a
sample of the targets, and with one process's FMM on all the points. Prints
"mpi_run: N passed, M failed" on rank 0; exits nonzero on a failure."""
import sys

import numpy as np
from mpi4py import MPI

import kifmm

comm = MPI.COMM_WORLD
rank, size = comm.Get_rank(), comm.Get_size()
passed = failed = 0


def check(ok, what):
    global passed, failed
    ok = comm.allreduce(bool(ok), op=MPI.LAND)
    if rank == 0:
        print(("  ok   " if ok else "  FAIL ") + what, flush=True)
    passed, failed = passed + ok, failed + (not ok)


def points(kind, n, seed):
    g = np.random.default_rng(seed)
    if kind == "plummer":
        r = 1.0 / np.sqrt(g.uniform(0.01, 1.0, n) ** (-2.0 / 3.0) - 1.0)
        v = g.normal(size=(n, 3))
        return v / np.linalg.norm(v, axis=1)[:, None] * np.minimum(r, 20.0)[:, None]
    return g.uniform(0.0, 1.0, (n, 3))


def case(kernel, kind, n, nt, dtype, order, on_root, bound):
    """n sources of a kind; nt separate targets (0: the sources)."""
    sd, td = kifmm.KERNELS[kernel]
    X = points(kind, n, 5)
    Y = X if nt == 0 else points("cube", nt, 6)
    Q = np.random.default_rng(7).uniform(-1.0, 1.0, (n, sd))
    mine = lambda m, salt: (np.zeros(m, bool) if rank else np.ones(m, bool)) if on_root else \
        (np.arange(m) * 2654435761 + salt) % size == rank
    sid = np.flatnonzero(mine(n, 0))
    tid = sid if nt == 0 else np.flatnonzero(mine(nt, 1))
    x, y = X[sid], (X[sid] if nt == 0 else Y[tid])
    with kifmm.FMM(kernel, x, None if nt == 0 else y, order=order, dtype=dtype, comm=comm) as f:
        out = f.evaluate(Q[sid].astype(dtype))
        st = f.stats
        owned = comm.allreduce((st["mpi_sources"], st["mpi_targets"]))
        ids, outs = comm.gather(tid, root=0), comm.gather(out.reshape(len(tid), td), root=0)
        what = (f"{kernel} {np.dtype(dtype).name} {kind} {n}" + (f" + {nt} targets" if nt else "") +
                (", all on rank 0" if on_root else "") + f", {size} ranks, p = {order}")
        err = one = 0.0
        if rank == 0:
            full = np.zeros((len(Y), td))
            for i, o in zip(ids, outs):
                full[i] = o
            s = np.arange(0, len(Y), max(1, len(Y) // 300))
            ref = kifmm.direct(kernel, X, Q, Y[s])
            err = np.linalg.norm(full[s] - ref) / np.linalg.norm(ref)
            with kifmm.FMM(kernel, X, None if nt == 0 else Y, order=order, dtype=dtype) as g:
                one = np.linalg.norm(g.evaluate(Q.astype(dtype))[s] - ref) / np.linalg.norm(ref)
            print(f"       {what}: error {err:.2e} (one process {one:.2e})", flush=True)
        err, one = comm.bcast((err, one), root=0)
        check(err <= bound and err <= 3.0 * one + 1e-13, f"{what} within {bound:g} and 3x one process")
        check(st["mpi_ranks"] == size and owned[0] + owned[1] > 0, "stats: mpi_ranks, owned points")
        # a time step: other points, same FMM; equal to a new FMM there
        x2 = x + 0.01
        f.update_points(x2, None if nt == 0 else y)
        a = f.evaluate(Q[sid].astype(dtype))
        with kifmm.FMM(kernel, x2, None if nt == 0 else y, order=order, dtype=dtype, comm=comm) as g:
            b = g.evaluate(Q[sid].astype(dtype))
        check(np.array_equal(a, b), "update_points equals a new FMM, bit for bit")


case("laplace_grad", "plummer", 20000, 0, np.float64, 6, False, 3e-5)
case("laplace_grad", "cube", 12000, 8000, np.float64, 6, False, 3e-5)
case("laplace", "cube", 15000, 0, np.float32, 4, True, 1e-3)
case("laplace_dipole_grad", "plummer", 12000, 0, np.float64, 6, False, 3e-5)
case("stokes", "cube", 8000, 0, np.float64, 6, False, 3e-5)
case("stokes_dl", "plummer", 8000, 0, np.float64, 6, False, 3e-5)
case("stokes_dl", "cube", 6000, 4000, np.float32, 4, True, 2e-3)

# errors: every rank raises, none is left waiting
try:
    kifmm.FMM("laplace", points("cube", 100, rank), comm=comm, period=2.0)
    got = None
except kifmm.KifmmError as e:
    got = e.code
check(got == -14, f"periodic: KIFMM_ERR_PERIODIC ({got})")
try:
    kifmm.FMM("laplace", points("cube", 10, 0), comm="world")
    got = None
except TypeError:
    got = "TypeError"
check(got == "TypeError", "comm='world': TypeError")

if rank == 0:
    print(f"mpi_run: {passed} passed, {failed} failed", flush=True)
sys.exit(1 if failed else 0)
