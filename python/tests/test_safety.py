"""Every answer right or refused: one FMM shared by threads, close() during
a call, copies and pickles, the integers and numbers given as options
(type and range, before ctypes could wrap or truncate them), kernel_param
0, max_depth, and KifmmError across processes."""
import copy
import multiprocessing
import pickle
import re
import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import numpy as np
import pytest

import kifmm

CHECKOUT = Path(__file__).resolve().parents[2]


def points(n, seed):
    return np.random.default_rng(seed).random((n, 3))


def rel(a, b):
    return np.linalg.norm(a - b) / np.linalg.norm(b)


def run_python(code, timeout=120):
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True,
                          text=True, timeout=timeout)


# --- threads -----------------------------------------------------------------

def test_one_fmm_shared_by_threads():
    """4 threads evaluate different densities on one object at once: each
    gets its own sums (unlocked, the shared workspace mixed them up)"""
    n = 3000
    x = points(n, 30)
    fmm = kifmm.FMM("laplace", x, order=4, nthreads=1)
    dens = [np.random.default_rng(31 + k).random(n) - 0.5 for k in range(4)]
    ref = [fmm.evaluate(d) for d in dens]
    for k in range(4):
        assert rel(ref[k][:50], kifmm.direct("laplace", x, dens[k], x[:50])) < 1e-3
    errors = []
    barrier = threading.Barrier(4)

    def work(k):
        barrier.wait()
        for _ in range(8):
            out = fmm.evaluate(dens[k])
            errors.append(rel(out, ref[k]))
            fmm.stats, fmm.options  # also under the lock, between evaluations

    ths = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for th in ths:
        th.start()
    for th in ths:
        th.join()
    assert len(errors) == 32 and max(errors) < 1e-12, max(errors)


def test_close_waits_for_a_running_evaluate():
    """close() from another thread while evaluate runs: it waits, the
    evaluation completes correctly (or, if close came first, evaluate says
    the object is closed); unlocked, the handle was freed under the running
    call (a crash). In a child process, so that a crash fails only this
    test."""
    r = run_python("""
        import threading, time, numpy as np, kifmm
        x = np.random.default_rng(1).random((20000, 3))
        q = np.random.default_rng(2).random(20000) - 0.5
        ref = kifmm.FMM("laplace", x, order=4).evaluate(q)
        completed = 0
        for trial in range(4):
            fmm = kifmm.FMM("laplace", x, order=4)
            res = {}
            started = threading.Event()
            def work():
                started.set()
                try:
                    res["out"] = fmm.evaluate(q)
                except ValueError as e:
                    res["err"] = str(e)
            th = threading.Thread(target=work)
            th.start()
            started.wait()
            time.sleep(0.002)
            fmm.close()
            assert fmm.closed
            th.join()
            if "out" in res:
                err = np.linalg.norm(res["out"] - ref) / np.linalg.norm(ref)
                assert err < 1e-12, err
                completed += 1
            else:
                assert "closed" in res["err"], res
        print("completed", completed)
    """)
    assert r.returncode == 0, (r.returncode, r.stdout, r.stderr[-3000:])
    assert int(r.stdout.split()[-1]) >= 1, r.stdout  # at least one close met a running call


def test_closed_object_refuses_every_call():
    x = points(300, 32)
    fmm = kifmm.FMM("laplace", x)
    assert not fmm.closed
    fmm.close()
    fmm.close()  # twice is harmless
    assert fmm.closed and "closed" in repr(fmm)
    for call in (lambda: fmm.evaluate(np.ones(300)), lambda: fmm.stats, lambda: fmm.options):
        with pytest.raises(ValueError, match=r"kifmm\.FMM\('laplace'\) is closed"):
            call()


def test_del_safe_at_exit_and_after_failed_create():
    """objects alive at interpreter exit, in a reference cycle, closed, or
    whose create failed: no message on stderr, exit status 0"""
    r = run_python("""
        import gc, numpy as np, kifmm
        x = np.random.default_rng(3).random((500, 3))
        keep = kifmm.FMM("laplace", x)
        cyc = kifmm.FMM("stokes", x)
        cyc.me = cyc
        closed = kifmm.FMM("laplace", x)
        closed.close()
        for bad in ({"order": 50}, {"order": 6.5}):
            try:
                kifmm.FMM("laplace", x, **bad)
            except (ValueError, TypeError):
                pass
        try:
            kifmm.FMM("laplace", np.full((10, 3), np.nan))
        except kifmm.KifmmError:
            pass
        del cyc
        gc.collect()
        with kifmm.FMM("laplace", x) as f:
            f.evaluate(np.ones(500))
        print("done")
    """)
    assert r.returncode == 0 and r.stdout.strip() == "done", (r.returncode, r.stdout, r.stderr)
    assert r.stderr == "", r.stderr


# --- copies and pickles ------------------------------------------------------

@pytest.mark.parametrize("how", ["copy", "deepcopy"] + [f"pickle{p}" for p in
                                                       range(pickle.HIGHEST_PROTOCOL + 1)])
def test_fmm_cannot_be_copied_or_pickled(how):
    fmm = kifmm.FMM("laplace", points(200, 33))
    op = {"copy": copy.copy, "deepcopy": copy.deepcopy}.get(how)
    if op is None:
        def op(f):
            return pickle.dumps(f, protocol=int(how[6:]))
    with pytest.raises(TypeError, match="cannot be copied or pickled: it owns a C handle"):
        op(fmm)
    assert fmm.evaluate(np.ones(200)).shape == (200, 1)  # still usable


# --- integer and real options ------------------------------------------------

BAD_FMM_OPTIONS = [
    # ctypes would have wrapped or truncated every one of these
    ("order", 2**32 + 8, ValueError), ("order", 6.7, TypeError), ("order", 6.0, TypeError),
    ("order", "6", TypeError), ("order", True, TypeError), ("order", np.float64(6), TypeError),
    ("order", 1, ValueError), ("order", 13, ValueError), ("order", -1, ValueError),
    ("nthreads", 2**32, ValueError), ("nthreads", -1, ValueError), ("nthreads", 1025, ValueError),
    ("nthreads", 1.0, TypeError), ("nthreads", False, TypeError),
    ("leaf_size", 2**32 + 1, ValueError), ("leaf_size", -1, ValueError),
    ("leaf_size", 100.5, TypeError), ("leaf_size", np.bool_(True), TypeError),
    ("max_depth", 21, ValueError), ("max_depth", -1, ValueError), ("max_depth", 2**32 + 3, ValueError),
    ("max_depth", 5.0, TypeError),
    ("tol", 0, ValueError), ("tol", -1e-3, ValueError), ("tol", np.nan, ValueError),
    ("tol", np.inf, ValueError), ("tol", "1e-3", TypeError), ("tol", True, TypeError),
    ("tol", 1e-3 + 0j, TypeError),
    ("period", -1.0, ValueError), ("period", np.inf, ValueError), ("period", [1.0, 2.0, 0.0], ValueError),
    ("period", [1.0, 1.0], ValueError), ("period", "1", TypeError), ("period", True, TypeError),
    ("period", 1j, TypeError),
    ("verbose", 1, TypeError), ("verbose", "yes", TypeError), ("verbose", None, TypeError),
    ("kernel_param", "1", TypeError), ("kernel_param", [1.0, 2.0, 3.0, 4.0, 5.0], ValueError),
]


@pytest.mark.parametrize("name,value,exc", BAD_FMM_OPTIONS,
                         ids=[f"{n}={v!r}" for n, v, _ in BAD_FMM_OPTIONS])
def test_bad_options_refused_with_their_name(name, value, exc):
    x = points(100, 34)
    kernel = "yukawa" if name == "kernel_param" else "laplace"
    with pytest.raises(exc) as e:
        kifmm.FMM(kernel, x, **{name: value})
    assert name in str(e.value)
    if exc is ValueError:  # the code the library would have given
        assert isinstance(e.value, kifmm.KifmmError) and e.value.code < 0


def test_option_messages_name_the_argument():
    x = points(100, 35)
    with pytest.raises(TypeError, match=re.escape("order must be an integer in 2..12 (or None), not 6.7")):
        kifmm.FMM("laplace", x, order=6.7)
    with pytest.raises(ValueError, match=re.escape("order must be an integer in 2..12 (or None), "
                                                   "not 4294967304")):
        kifmm.FMM("laplace", x, order=2**32 + 8)
    with pytest.raises(ValueError, match="give tol or order, not both") as e:
        kifmm.FMM("laplace", x, tol=1e-4, order=5)
    assert e.value.code == -16


@pytest.mark.parametrize("name,value", [("order", np.int32(7)), ("order", 0), ("order", None),
                                        ("nthreads", np.uint8(1)), ("leaf_size", np.int64(64)),
                                        ("max_depth", np.int16(5)), ("tol", np.float32(1e-4)),
                                        ("tol", 1), ("period", np.float32(2.0)),
                                        ("period", [0, 0, 3]), ("verbose", np.bool_(False))])
def test_numpy_and_python_numbers_accepted(name, value):
    fmm = kifmm.FMM("laplace", points(200, 36), **{name: value})
    o = fmm.options
    if name in ("nthreads", "leaf_size", "max_depth") or (name == "order" and value):
        assert o[name] == int(value)
    if name == "period":
        assert o["period"] == list(np.broadcast_to(np.float64(value), (3,)))


def test_estimate_bytes_counts_checked():
    for bad in (2**70, 2**64 + 1000, -1, kifmm.MAX_POINTS + 1):
        with pytest.raises(ValueError, match="nsources"):
            kifmm.estimate_bytes("laplace", bad)
        with pytest.raises(ValueError, match="ntargets"):
            kifmm.estimate_bytes("laplace", 100, bad)
    for bad in (1e6, "1000", True, None):
        with pytest.raises(TypeError, match="nsources"):
            kifmm.estimate_bytes("laplace", bad)
    assert kifmm.estimate_bytes("laplace", np.int64(10**6)) == kifmm.estimate_bytes("laplace", 10**6)
    with pytest.raises(TypeError, match="order"):
        kifmm.estimate_bytes("laplace", 1000, order=6.7)
    with pytest.raises(ValueError, match="nthreads"):
        kifmm.estimate_bytes("laplace", 1000, nthreads=2**32)


def test_direct_options_checked():
    x = points(50, 37)
    with pytest.raises(ValueError, match="nthreads"):
        kifmm.direct("laplace", x, np.ones(50), x, nthreads=2**32)
    with pytest.raises(ValueError, match="kernel_param"):
        kifmm.direct("yukawa", x, np.ones(50), x, kernel_param=0)


def test_limits_are_kifmm_h_values():
    header = CHECKOUT / "kifmm.h"
    if not header.exists():
        pytest.skip(f"{header} not found (the tests run from a kifmm.h checkout)")
    text = header.read_text()

    def define(name):
        return re.search(rf"#define {name} (.+?)\s*(/\*|$)", text, re.M).group(1)

    assert int(define("KIFMM_MAX_ORDER")) == kifmm.MAX_ORDER
    assert int(define("KIFMM_MAX_DEPTH")) == kifmm.MAX_DEPTH
    assert int(define("KIFMM_MAX_THREADS")) == kifmm.MAX_THREADS
    assert define("KIFMM_MAX_POINTS") == "((int64_t)(PTRDIFF_MAX / 1024))"
    assert kifmm.MAX_POINTS == (2**63 - 1) // 1024
    assert int(define("KIFMM_DEFAULT_DEPTH")) == 16


# --- kernel_param ------------------------------------------------------------

@pytest.mark.parametrize("kernel", ["yukawa", "yukawa_grad", "yukawa_cd", "yukawa_cd_grad",
                                    "stokes", "stokes_grad", "stokes_pvel"])
def test_kernel_param_zero_refused_none_default(kernel):
    """0 would have become the default (lambda = 1, mu = 1) silently"""
    x = points(100, 38)
    for zero in (0, 0.0, [0.0], np.zeros(1)):
        with pytest.raises(ValueError, match="kernel_param") as e:
            kifmm.FMM(kernel, x, kernel_param=zero)
        assert e.value.code == -8
    with pytest.raises(ValueError, match="kernel_param"):
        kifmm.FMM(kernel, x, kernel_param=-2.0)
    with pytest.raises(ValueError, match="takes one kernel_param"):
        kifmm.FMM(kernel, x, kernel_param=[2.0, 1.0])
    assert kifmm.FMM(kernel, x).options["kernel_param"][0] == 1.0
    assert kifmm.FMM(kernel, x, kernel_param=2.5).options["kernel_param"][0] == 2.5


@pytest.mark.parametrize("kernel", ["laplace", "laplace_cd_hess", "stokes_dl", "biot_savart"])
def test_kernel_param_refused_by_kernels_without_one(kernel):
    x = points(100, 39)
    with pytest.raises(ValueError, match="takes no kernel_param"):
        kifmm.FMM(kernel, x, kernel_param=2.0)
    kifmm.FMM(kernel, x, kernel_param=[0.0, 0.0])  # zeros are what None gives


# --- max_depth ---------------------------------------------------------------

def test_max_depth_option():
    x = points(8000, 40)
    deep = kifmm.FMM("laplace", x, order=4, leaf_size=8)
    flat = kifmm.FMM("laplace", x, order=4, leaf_size=8, max_depth=3)
    assert deep.options["max_depth"] == 16 and flat.options["max_depth"] == 3
    assert flat.stats["levels"] < deep.stats["levels"]
    assert flat.stats["crowded"] > 0
    q = np.random.default_rng(41).random(8000)
    ref = kifmm.direct("laplace", x, q, x[:50])
    assert rel(flat.evaluate(q)[:50], ref) < 1e-3
    a = kifmm.estimate_bytes("laplace", 10**6, order=4, leaf_size=8, max_depth=3)
    b = kifmm.estimate_bytes("laplace", 10**6, order=4, leaf_size=8)
    assert a != b


# --- KifmmError across processes ---------------------------------------------

def _fails_in_a_worker(i):
    # a tol below what any order reaches: refused by the library itself
    return kifmm.estimate_bytes("laplace", 1000 + i, tol=1e-15)


def test_kifmm_error_pickles():
    with pytest.raises(kifmm.KifmmError) as e:
        _fails_in_a_worker(0)
    for err in (e.value, kifmm.KifmmError(-3, "kifmm_laplace_create")):
        back = pickle.loads(pickle.dumps(err))
        assert type(back) is kifmm.KifmmError and back.code == err.code
        assert str(back) == str(err) and "kifmm code" in str(back)
    with pytest.raises(kifmm.OptionError) as e:
        kifmm.FMM("laplace", points(10, 42), order=50)
    back = pickle.loads(pickle.dumps(e.value))
    assert type(back) is kifmm.OptionError and back.code == -4 and str(back) == str(e.value)
    assert isinstance(back, ValueError) and isinstance(back, kifmm.KifmmError)


def test_kifmm_error_from_a_pool_worker():
    """the error reaches the parent; unpicklable, it left pool.map waiting
    for ever"""
    ctx = multiprocessing.get_context("fork")  # the worker calls no OpenMP region
    with ctx.Pool(2) as pool:
        res = pool.map_async(_fails_in_a_worker, range(4))
        with pytest.raises(kifmm.KifmmError) as e:
            res.get(timeout=30)
    assert e.value.code == -16 and "tol" in str(e.value)
