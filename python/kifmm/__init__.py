"""kifmm: the kernel-independent fast multipole method in three dimensions.

Python bindings of kifmm.h's compiled library (libkifmm, every shipped
kernel in double and float), through ctypes: calls into the library release
the GIL.

    import numpy as np, kifmm
    x = np.random.rand(100000, 3)
    q = np.random.rand(100000) - 0.5
    fmm = kifmm.FMM("laplace_grad", x, order=6)
    out = fmm.evaluate(q)                 # (100000, 4): potential, gradient
    ref = kifmm.direct("laplace_grad", x, q, x[:100])   # the first 100 rows
    need = kifmm.estimate_bytes("laplace_grad", 10**7, order=6)  # before any point

Kernels (source and target dimensions) are listed in ``kifmm.KERNELS``,
and ``print(kifmm.kernel_help(name))`` gives each one's formula, signs,
layouts and parameter (help(kifmm.FMM) lists them). ``python -m kifmm``
prints the build: the library, its code paths, threads and BLAS.
"""

import ctypes
import math
import numbers
import os
import threading
from pathlib import Path

import numpy as np

from . import _kernels

__all__ = ["FMM", "Plan", "direct", "estimate_bytes", "kernel_help", "KERNELS", "COMPLEX", "KifmmError",
           "OptionError", "MAX_ORDER", "MAX_DEPTH", "MAX_THREADS", "MAX_POINTS"]
__version__ = "0.2.0"

# name: (density components per source, output components per target;
# complex numbers for the complex kernels, kifmm.COMPLEX)
KERNELS = {k.name: (_kernels.src_dim(k), _kernels.trg_dim(k)) for k in _kernels.KERNEL_TABLE}
# the kernels whose densities and outputs are complex (helmholtz)
COMPLEX = frozenset(k.name for k in _kernels.KERNEL_TABLE if k.value == "complex")

# kifmm.h's limits, as the library was compiled with them (a test compares
# them with kifmm.h)
MAX_ORDER = 12
MAX_DEPTH = 20
MAX_THREADS = 1024
MAX_POINTS = (2**63 - 1) // 1024  # PTRDIFF_MAX / 1024
_INT_MAX = 2**31 - 1  # the C options are ints

# kifmm.h's result codes that the checks made here stand for
_ERR_COUNT, _ERR_ORDER, _ERR_LEAF_SIZE, _ERR_DEPTH, _ERR_NTHREADS, _ERR_PARAM = -2, -4, -5, -6, -7, -8
_ERR_PERIOD, _ERR_TOL, _ERR_DOMAIN, _ERR_TREE = -13, -16, -22, -23


def kernel_help(kernel):
    """The description of one kernel (a str): its densities per source and
    outputs per target with their offsets in a row, the formula with its
    signs and 1 / (4 pi) factors, and its kernel_param. print() it."""
    _kernel(kernel)
    return _kernels.help_text(kernel)


def _rebuild_error(cls, args, state):
    e = cls.__new__(cls, *args)
    e.args = args
    e.__dict__.update(state)
    return e


class KifmmError(RuntimeError):
    """A library call failed: ``code`` is its result code (kifmm.h), the
    message the library's own."""

    def __init__(self, code, what, detail=None):
        self.code = code
        super().__init__(f"{what}: {detail or _strerror(code)} (kifmm code {code})")

    def __reduce__(self):
        # the default would call KifmmError(message), which needs two
        # arguments: unpickling failed, and multiprocessing.Pool hung on
        # an error raised in a worker
        return (_rebuild_error, (type(self), self.args, self.__dict__))


class OptionError(KifmmError, ValueError):
    """An argument out of range, found before the library is called: a
    ValueError whose message names the Python argument, and a KifmmError
    whose ``code`` is the one the library would have returned."""


class _Opts(ctypes.Structure):
    _fields_ = [
        ("order", ctypes.c_int),
        ("leaf_size", ctypes.c_int),
        ("max_depth", ctypes.c_int),
        ("nthreads", ctypes.c_int),
        ("kernel_param", ctypes.c_double * 4),
        ("period", ctypes.c_double * 3),
        ("tol", ctypes.c_double),
        ("verbose", ctypes.c_int),
        ("domain", ctypes.c_double * 4),
        ("operator_cache", ctypes.c_char_p),
    ]


class _Stats(ctypes.Structure):
    _fields_ = [
        ("levels", ctypes.c_int),
        ("boxes", ctypes.c_int64),
        ("leaves", ctypes.c_int64),
        ("t_tree", ctypes.c_double),
        ("t_operators", ctypes.c_double),
        ("t_p2m", ctypes.c_double),
        ("t_m2m", ctypes.c_double),
        ("t_m2l", ctypes.c_double),
        ("t_l2l", ctypes.c_double),
        ("t_p2l", ctypes.c_double),
        ("t_l2p", ctypes.c_double),
        ("t_m2p", ctypes.c_double),
        ("t_p2p", ctypes.c_double),
        ("t_evaluate", ctypes.c_double),
        ("bytes", ctypes.c_double),
        ("max_leaf", ctypes.c_int64),
        ("crowded", ctypes.c_int64),
        ("threads", ctypes.c_int),
        ("simd", ctypes.c_int),
        ("build", ctypes.c_char * 256),
        ("t_plan", ctypes.c_double),
        ("t_points", ctypes.c_double),
        ("t_workspace", ctypes.c_double),
        ("t_update", ctypes.c_double),
        ("plan_bytes", ctypes.c_double),
        ("tree_bytes", ctypes.c_double),
        ("mpi_ranks", ctypes.c_int),
        ("mpi_sources", ctypes.c_int64),
        ("mpi_targets", ctypes.c_int64),
        ("mpi_ghost_points", ctypes.c_int64),
        ("mpi_ghost_boxes", ctypes.c_int64),
        ("mpi_bytes_sent", ctypes.c_double),
        ("mpi_bytes_recv", ctypes.c_double),
        ("mpi_ghost_bytes", ctypes.c_double),
        ("t_mpi_wait", ctypes.c_double),
        ("t_mpi_work", ctypes.c_double),
        ("cache_read", ctypes.c_int),
        ("cache_written", ctypes.c_int),
    ]


def _load():
    path = os.environ.get("KIFMM_LIBRARY") or str(Path(__file__).with_name("libkifmm.so"))
    try:
        return ctypes.CDLL(path)
    except OSError as e:
        raise ImportError(
            f"kifmm: cannot load the compiled library {path} ({e}); install the package with "
            "pip install ./python from a kifmm.h checkout, or set KIFMM_LIBRARY to a libkifmm.so"
        ) from None


_lib = _load()
_lib.kifmm_lib_strerror.restype = ctypes.c_char_p
_lib.kifmm_lib_strerror.argtypes = [ctypes.c_int]


def _strerror(code):
    return _lib.kifmm_lib_strerror(code).decode()


_P = ctypes.c_void_p
_I64 = ctypes.c_int64
_funcs = {}
_funcs_lock = threading.Lock()


# ---- MPI mode (comm=): libkifmm_mpi.so (make lib-mpi: the same instances
# compiled with KIFMM_MPI by mpicc), loaded and mpi4py imported only when an
# FMM is given a communicator, so that nothing else needs MPI.
_mpi_state = {}


def _mpi():
    """mpi4py's MPI module and libkifmm_mpi.so, checked to be on one MPI."""
    with _funcs_lock:
        if "lib" in _mpi_state:
            return _mpi_state["MPI"], _mpi_state["lib"]
        try:
            from mpi4py import MPI
        except ImportError as e:
            raise ImportError("kifmm.FMM(comm=...): mpi4py is needed (pip install mpi4py)") from e
        path = os.environ.get("KIFMM_MPI_LIBRARY") or str(Path(__file__).with_name("libkifmm_mpi.so"))
        try:
            lib = ctypes.CDLL(path, mode=ctypes.RTLD_GLOBAL)
        except OSError as e:
            raise ImportError(
                f"kifmm.FMM(comm=...): cannot load {path} ({e}); install the package where mpicc "
                "is on the PATH (it then builds the MPI library too), or set KIFMM_MPI_LIBRARY to a "
                "libkifmm_mpi.so (make lib-mpi)") from None
        buf, n = ctypes.create_string_buffer(8192), ctypes.c_int(0)
        lib.MPI_Get_library_version(buf, ctypes.byref(n))
        ours, theirs = buf.value.decode(errors="replace"), MPI.Get_library_version()
        if ours.split(",")[0].strip() != theirs.split(",")[0].strip():
            raise ImportError(f"kifmm.FMM(comm=...): {path} is built on {ours.split(',')[0]!r} "
                              f"but mpi4py runs on {theirs.split(',')[0]!r}")
        _mpi_state["MPI"], _mpi_state["lib"] = MPI, lib
        return MPI, lib


def _comm_type(MPI):
    """The ctypes type of an MPI_Comm (a pointer in Open MPI, an int in MPICH)."""
    return ctypes.c_void_p if MPI._sizeof(MPI.Comm) == ctypes.sizeof(ctypes.c_void_p) else ctypes.c_int


def _comm(MPI, comm):
    """comm's C handle as ctypes passes an MPI_Comm."""
    if not isinstance(comm, MPI.Comm) or not isinstance(comm, MPI.Intracomm):
        raise TypeError(f"kifmm.FMM: comm must be an mpi4py intracommunicator, not {_show(comm)}")
    if comm == MPI.COMM_NULL:
        raise ValueError("kifmm.FMM: comm is MPI.COMM_NULL")
    return _comm_type(MPI)(MPI._handleof(comm))


def _api(kernel, dtype, mpi=False):
    """The instance's functions: kifmm_<kernel>[f]_*, from libkifmm or, for
    MPI handles, libkifmm_mpi (whose handles only its own functions take)."""
    key = (kernel, dtype, mpi)
    MPI, lib = _mpi() if mpi else (None, _lib)
    with _funcs_lock:
        if key not in _funcs:
            pre = "kifmm_" + kernel + ("f" if dtype == np.float32 else "")
            f = {n: getattr(lib, f"{pre}_{n}") for n in
                 ("create", "evaluate", "evaluate_many", "destroy", "stats", "options", "direct",
                  "estimate_bytes", "update_points", "plan_create", "plan_destroy",
                  "create_with_plan", "tree", "create_on_tree", "create_with_plan_on_tree",
                  "update_on_tree") + (("create_mpi",) if mpi else ())}
            f["create"].argtypes = [ctypes.POINTER(_P), ctypes.POINTER(_Opts), _I64, _P, _I64, _P]
            f["update_points"].argtypes = [_P, _I64, _P, _I64, _P]
            f["plan_create"].argtypes = [ctypes.POINTER(_P), ctypes.POINTER(_Opts)]
            f["plan_destroy"].argtypes = [_P]
            f["plan_destroy"].restype = None
            f["create_with_plan"].argtypes = [ctypes.POINTER(_P), _P, _I64, _P, _I64, _P]
            f["tree"].argtypes = [_P]
            f["tree"].restype = _P
            f["create_on_tree"].argtypes = [ctypes.POINTER(_P), ctypes.POINTER(_Opts), _P]
            f["create_with_plan_on_tree"].argtypes = [ctypes.POINTER(_P), _P, _P]
            f["update_on_tree"].argtypes = [_P, _P]
            f["evaluate"].argtypes = [_P, _P, _P]
            f["evaluate_many"].argtypes = [_P, ctypes.c_int, _P, _P]
            f["destroy"].argtypes = [_P]
            f["destroy"].restype = None
            f["stats"].argtypes = [_P, ctypes.POINTER(_Stats)]
            f["options"].argtypes = [_P, ctypes.POINTER(_Opts)]
            f["direct"].argtypes = [ctypes.POINTER(_Opts), _I64, _P, _P, _I64, _P, _P]
            f["estimate_bytes"].argtypes = [ctypes.POINTER(_Opts), _I64, _I64,
                                            ctypes.POINTER(ctypes.c_double)]
            if mpi:
                f["create_mpi"].argtypes = [ctypes.POINTER(_P), _comm_type(MPI), ctypes.POINTER(_Opts),
                                            _I64, _P, _I64, _P]
            _funcs[key] = f
        return _funcs[key]


def _kernel(kernel):
    if kernel not in KERNELS:
        raise ValueError(f"kifmm: unknown kernel {kernel!r}; kifmm.KERNELS lists {sorted(KERNELS)}")
    return KERNELS[kernel]


def _dtype(dtype):
    """the instance's real type: float64 or float32 (complex128 and complex64
    name them too, for the complex kernels' sake)"""
    dt = np.dtype(dtype)
    if dt == np.dtype(np.complex128):
        dt = np.dtype(np.float64)
    elif dt == np.dtype(np.complex64):
        dt = np.dtype(np.float32)
    if dt not in (np.dtype(np.float64), np.dtype(np.float32)):
        raise TypeError(f"kifmm: dtype must be float64 or float32 (or complex128, complex64), "
                        f"not {dt}")
    return dt.type


def _values(kernel, dtype):
    """the type of the kernel's densities and outputs: dtype, or its complex
    type for a complex kernel"""
    if kernel not in COMPLEX:
        return dtype
    return np.complex128 if dtype == np.float64 else np.complex64


def _real(a, dtype, what):
    """a as a C-contiguous array of dtype (a copy only if needed); real
    numbers only."""
    arr = np.asarray(a)
    if arr.dtype.kind not in "fiub":
        raise TypeError(f"kifmm: {what} must be real numbers, not {arr.dtype}")
    return np.ascontiguousarray(arr, dtype=dtype)


def _points(x, dtype, what):
    arr = _real(x, dtype, what)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"kifmm: {what} must be shaped (n, 3), not {arr.shape}")
    return arr


# ctypes would store order=2**32+8 as 8 and order=6.7 as 6 without a word,
# so every option is checked here, and refused with the Python argument's
# name, before it reaches a C field.

def _show(v):
    return f"{v} ({type(v).__name__})" if isinstance(v, np.generic) else repr(v)


def _is_int(v):
    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))


def _is_real(v):
    return isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_))


def _int(v, name, lo, hi, where, code, none=" (or None)"):
    """v as a Python int in lo..hi; None is 0 (the C default) when `none`
    says what it means, else refused"""
    want = f"{name} must be an integer in {lo}..{hi}{none or ''}"
    if v is None and none:
        return 0
    if not _is_int(v):
        raise TypeError(f"{where}: {want}, not {_show(v)}")
    if not lo <= int(v) <= hi:
        raise OptionError(code, where, f"{want}, not {int(v)}")
    return int(v)


def _order(v, where):
    # 0 is the C default, as None
    if _is_int(v) and int(v) == 0:
        return 0
    return _int(v, "order", 2, MAX_ORDER, where, _ERR_ORDER)


def _reals(v, name, where, shapes, code):
    """v as a float64 array shaped one of shapes; TypeError for anything
    but real numbers (bools and strings included)"""
    arr = np.asarray(v)
    if arr.dtype.kind not in "iuf":
        raise TypeError(f"{where}: {name} must be real numbers, not {_show(v)}")
    if arr.shape not in shapes:
        raise OptionError(code, where, f"{name} must be a number or up to "
                          f"{max(s[0] for s in shapes if s)} of them, not shaped {arr.shape}")
    return arr.astype(np.float64).reshape(-1)


def _kernel_param(kernel, v, where):
    """kernel_param (None: the kernel's default) as 4 doubles. An explicit 0
    would be the C default, not a zero screening or viscosity, and a value
    given to a kernel without parameters would be ignored: both refused."""
    out = [0.0] * 4
    if kernel in COMPLEX:
        return _wavenumber(kernel, v, where)
    if v is None:
        return out
    prm = _reals(v, "kernel_param", where, [(), (1,), (2,), (3,), (4,)], _ERR_PARAM)
    if not np.all(np.isfinite(prm)):
        raise OptionError(_ERR_PARAM, where, f"kernel_param must be finite, not {prm.tolist()}")
    k = _kernels.BY_NAME[kernel]
    p = k.param
    if p is None:
        if np.any(prm != 0.0):
            raise OptionError(_ERR_PARAM, where, f"kernel {kernel!r} takes no kernel_param "
                              f"(give None), not {prm.tolist()}")
        return out
    if np.any(prm[1:] != 0.0):
        raise OptionError(_ERR_PARAM, where, f"kernel {kernel!r} takes one kernel_param "
                          f"({p.symbol}), not {prm.tolist()}")
    x = float(prm[0])
    if x == 0.0:
        raise OptionError(_ERR_PARAM, where, f"kernel_param: {kernel!r} needs {p.valid}, not 0 "
                          f"(None gives the default {p.symbol} = {p.default:g})")
    if not p.lo <= x <= p.hi:
        raise OptionError(_ERR_PARAM, where, f"kernel_param: {kernel!r} needs {p.valid}, not {x!r}")
    out[0] = x
    return out


def _tol(v, order, where):
    if v is None:
        return 0.0
    want = "tol must be a finite number > 0 (or None)"
    if not _is_real(v):
        raise TypeError(f"{where}: {want}, not {_show(v)}")
    t = float(v)
    if not (t > 0.0 and math.isfinite(t)):
        raise OptionError(_ERR_TOL, where, f"{want}, not {t!r}")
    if order:
        raise OptionError(_ERR_TOL, where, f"give tol or order, not both (tol={t!r}, order={order})")
    return t


def _period(v, where):
    if v is None:
        return [0.0] * 3
    per = _reals(v, "period", where, [(), (1,), (3,)], _ERR_PERIOD)
    per = np.broadcast_to(per, (3,))
    if not np.all(np.isfinite(per) & (per >= 0.0)):
        raise OptionError(_ERR_PERIOD, where, f"period must be finite and >= 0 (0: free), not "
                          f"{per.tolist()}")
    if len(set(per[per > 0.0].tolist())) > 1:
        raise OptionError(_ERR_PERIOD, where, f"every periodic direction must have the same "
                          f"period, not {per.tolist()}")
    return per.tolist()


def _domain(v, period, where):
    """domain: None (the box from the points) or (centre x, y, z, half-width)"""
    if v is None:
        return [0.0] * 4
    dom = _reals(v, "domain", where, [(4,)], _ERR_DOMAIN)
    if not (np.all(np.isfinite(dom)) and dom[3] > 0.0):
        raise OptionError(_ERR_DOMAIN, where, f"domain must be (x, y, z, half-width), finite, "
                          f"with a half-width > 0, not {dom.tolist()}")
    if any(x > 0.0 for x in period):
        raise OptionError(_ERR_DOMAIN, where, "domain cannot be set together with period")
    return dom.tolist()


def _verbose(v, where):
    if not isinstance(v, (bool, np.bool_)):
        raise TypeError(f"{where}: verbose must be True or False, not {_show(v)}")
    return 1 if v else 0


def _operator_cache(v, where):
    """operator_cache: None, or an existing directory (str, bytes or os.PathLike)"""
    if v is None:
        return None
    if not isinstance(v, (str, bytes, os.PathLike)):
        raise TypeError(f"{where}: operator_cache must be a directory's path, not {_show(v)}")
    path = os.fsencode(v)
    if not path or b"\0" in path or not os.path.isdir(path):
        raise ValueError(f"{where}: operator_cache must name an existing directory, not {v!r}")
    return path


def _opts(where, kernel, order=None, nthreads=None, kernel_param=None, leaf_size=None,
          period=None, tol=None, verbose=False, max_depth=None, domain=None,
          operator_cache=None):
    o = _Opts()
    o.order = _order(order, where)
    o.tol = _tol(tol, o.order, where)
    o.nthreads = _int(nthreads, "nthreads", 0, MAX_THREADS, where, _ERR_NTHREADS,
                      " (None or 0: all)")
    o.leaf_size = _int(leaf_size, "leaf_size", 0, _INT_MAX, where, _ERR_LEAF_SIZE,
                       " (None or 0: chosen per order)")
    o.max_depth = _int(max_depth, "max_depth", 0, MAX_DEPTH, where, _ERR_DEPTH,
                       " (None or 0: 16)")
    o.verbose = _verbose(verbose, where)
    for i, x in enumerate(_kernel_param(kernel, kernel_param, where)):
        o.kernel_param[i] = x
    per = _period(period, where)
    for i, x in enumerate(per):
        o.period[i] = x
    for i, x in enumerate(_domain(domain, per, where)):
        o.domain[i] = x
    o.operator_cache = _operator_cache(operator_cache, where)  # (o keeps the bytes alive)
    return o


def _wavenumber(kernel, v, where):
    """a complex kernel's kernel_param, the wavenumber k, as (Re k, Im k, 0,
    0): a complex or real number (or a 0-d array of one), or C's layout, up
    to 4 reals (Re k, Im k, 0, 0), as options["kernel_param"] gives it.
    Needed."""
    p = _kernels.BY_NAME[kernel].param
    if v is None:
        raise OptionError(_ERR_PARAM, where, f"kernel {kernel!r} needs kernel_param, "
                          f"{p.symbol}: {p.meaning} ({p.valid})")
    arr = None if isinstance(v, numbers.Complex) else np.asarray(v)
    if arr is not None and arr.ndim == 0 and arr.dtype.kind in "iufc":
        v, arr = arr.item(), None
    if isinstance(v, (bool, np.bool_)) or (arr is not None and (
            arr.ndim != 1 or not 1 <= arr.shape[0] <= 4 or arr.dtype.kind not in "iuf")):
        raise TypeError(f"{where}: kernel_param of {kernel!r} must be the wavenumber, a complex "
                        f"or real number, or up to 4 reals (Re k, Im k, 0, 0), not {_show(v)}")
    if arr is not None:
        prm = arr.astype(np.float64)
        if np.any(prm[2:] != 0.0):
            raise OptionError(_ERR_PARAM, where, f"kernel_param of {kernel!r}: (Re k, Im k) "
                              f"and zeros, not {prm.tolist()}")
        v = complex(prm[0], prm[1] if prm.shape[0] > 1 else 0.0)
    k = complex(v)
    if not (np.isfinite(k.real) and np.isfinite(k.imag) and abs(k.real) <= p.hi
            and 0.0 <= k.imag <= p.hi):
        raise OptionError(_ERR_PARAM, where, f"kernel_param: {kernel!r} needs {p.valid}, not {v!r}")
    return [k.real, k.imag, 0.0, 0.0]


def _count(v, name, where):
    return _int(v, name, 0, MAX_POINTS, where, _ERR_COUNT, None)


def _densities(d, dtype, ns, sd):
    """(arr, nrhs, lead): the densities as a C-contiguous block of nrhs
    vectors; lead is the leading axis's length or None. dtype complex: real
    or complex numbers, as complex ones (their (re, im) pairs are C's)."""
    if np.issubdtype(dtype, np.complexfloating):
        arr = np.asarray(d)
        if arr.dtype.kind not in "fiubc":
            raise TypeError(f"kifmm: densities must be numbers, not {arr.dtype}")
        arr = np.ascontiguousarray(arr, dtype=dtype)
    else:
        arr = _real(d, dtype, "densities")
    shapes = [(ns, sd)] + ([(ns,)] if sd == 1 else [])
    if arr.shape in shapes:
        return arr, 1, None
    if arr.ndim >= 2 and arr.shape[1:] in shapes:
        return arr, arr.shape[0], arr.shape[0]
    want = " or ".join(str(s) for s in shapes)
    raise ValueError(f"kifmm: densities must be shaped {want}, or with a leading axis, not {arr.shape}")


def _ptr(a):
    return a.ctypes.data_as(_P)


class Plan:
    """Options and operators that several FMMs share: kifmm.Plan(kernel,
    order=..., ...) takes FMM's options (not sources or targets), and
    FMM(kernel, sources, plan=p) builds only its tree and workspace on it.
    The operators are built once (scale-invariant kernels: here) and held
    once, however many FMMs use the plan, from however many threads; the
    plan lives while an FMM uses it. close() lets go of this object's
    reference."""

    def __init__(self, kernel, *, order=None, tol=None, dtype=np.float64, nthreads=None,
                 kernel_param=None, leaf_size=None, period=None, verbose=False, max_depth=None,
                 domain=None, operator_cache=None):
        self._p = None
        self.kernel = kernel
        _kernel(kernel)
        self._rtype = _dtype(dtype)
        self.dtype = _values(kernel, self._rtype)
        self._f = _api(kernel, self._rtype)
        self._destroy = self._f["plan_destroy"]
        opts = _opts("kifmm.Plan", kernel, order, nthreads, kernel_param, leaf_size, period, tol,
                     verbose, max_depth, domain, operator_cache)
        p = _P()
        rc = self._f["plan_create"](ctypes.byref(p), ctypes.byref(opts))
        if rc != 0:
            raise KifmmError(rc, f"kifmm_{kernel}_plan_create")
        self._p = p

    def __repr__(self):
        return f"kifmm.Plan({self.kernel!r}, {np.dtype(self.dtype).name})"

    def close(self):
        """Let go of the plan (the FMMs made on it keep it)."""
        if self._p is not None:
            self._destroy(self._p)
            self._p = None

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass


_NO_COPY = ("kifmm.FMM cannot be copied or pickled: it owns a C handle; create another FMM on "
            "the same points")


class FMM:
    """An FMM for one kernel on fixed sources and targets (the tree and the
    operators are built here, once); ``evaluate`` as often as needed.

    kernel        a name from kifmm.KERNELS (the list below;
                  kifmm.kernel_help(name) gives its formula and layouts)
    sources       (nsources, 3) points
    targets       (ntargets, 3) points; None: the sources themselves
    order         expansion order, an integer 2 to 12 (None: 6): about
                  ``order`` digits
    tol           instead of order: the relative L2 error wanted, a finite
                  number > 0 (below), ``options["order"]`` reports the
                  order picked
    dtype         numpy.float64 or numpy.float32 (the float instances);
                  complex128 and complex64 name the same two. Complex
                  kernels (kifmm.COMPLEX: helmholtz) take complex densities
                  (real ones are read as complex) and return complex
                  outputs, of the matching complex type, which the FMM's
                  dtype attribute then is (points stay real)
    nthreads      OpenMP threads, 0 to 1024 (None or 0: all)
    kernel_param  the kernel's parameter (yukawa kernels: lambda > 0;
                  stokes, stokes_grad, stokes_pvel: the viscosity mu > 0),
                  a number or a list of up to 4; None: the default (1). An
                  explicit 0 is refused, and so is a nonzero value for a
                  kernel without parameters. Helmholtz kernels: the
                  wavenumber k, a complex (or real) number with Im k >= 0
                  (damped waves), or up to 4 reals (Re k, Im k, 0, 0) as
                  options gives them, needed; the boxes that carry
                  expansions may be at most 1.6 wavelengths wide (levels
                  too wide for the order take a higher one; else
                  KifmmError, code -25; docs/kernels.md);
                  tol picks the order from the root's width in
                  wavelengths (update_points picks again; a Plan with tol
                  needs domain)
    leaf_size     points per leaf, an integer >= 1 (None or 0: chosen per
                  order)
    max_depth     deepest tree level, 1 to 20 (None or 0: 16); boxes there
                  stay leaves whatever they hold
    period        a period L (or 3 of them, 0 = free) for periodic
                  boundaries; finite, >= 0, every nonzero one the same
    domain        (x, y, z, h): a fixed root box, centre and half-width,
                  holding every point (else KifmmError, code -22); points
                  moved by update_points inside it keep every operator (None:
                  the box from the points; not with period)
    verbose       True: one line per stage of create and evaluate, with its
                  time and the memory held, on stderr
    operator_cache  an existing directory: each operator set built is
                  written there (one file each) and read back by later
                  FMMs of any process instead of being built again (see
                  docs/api.md, "Operator cache"); stats() counts the sets
                  read and written. None: no cache
    plan          a kifmm.Plan of this kernel and dtype: its options and
                  operators, shared (then no option may be given here)
    tree          another FMM (any kernel, the same dtype) whose points and
                  tree this one shares: sources and targets are then not
                  given (they are that FMM's, in its order), nothing is
                  sorted or refined again, and period, domain, leaf_size and
                  max_depth must be that FMM's, or None to take that FMM's
                  (period and domain both None); KifmmError (code -23)
                  otherwise. The tree stays while an FMM uses it.
                  Boundary-element codes: the single and double layer on one
                  geometry
    comm          an mpi4py intracommunicator: one FMM over the points of
                  every rank of comm (MPI mode, docs/api.md "MPI"). Each
                  rank passes its own sources and targets (any share, in
                  any order; none on some ranks is fine) and evaluate
                  returns the outputs at its own targets, in its order,
                  from the densities of its own sources. The constructor,
                  evaluate, update_points and close are collective: every
                  rank of comm calls them, with the same count of density
                  sets. Needs mpi4py (imported only here) and the package's
                  libkifmm_mpi.so (built when mpicc was found at install;
                  KIFMM_MPI_LIBRARY to name another). Not with plan= or
                  tree=; periodic options raise KifmmError (-14). Close
                  the FMM (or leave a with block) on every rank before MPI
                  is finalized

    tol: the order is picked so that every output of the kernel (potential,
    gradient, Hessian, velocity, pressure, velocity gradient) meets tol in
    relative L2 error on the measured distributions; the worst output is
    then at most 30x more accurate than asked, the others (the potential of
    the gradient kernels, say) up to about 100x; see docs/api.md, Tolerance.
    A tol below what the largest order reaches raises KifmmError.

    Integers must be Python or numpy integers and numbers real (bools,
    strings and floats where an integer is wanted raise TypeError); values
    out of range raise kifmm.OptionError, a ValueError naming the argument
    (and a KifmmError with the library's code). Errors of the library
    itself raise KifmmError.

    Arrays are converted to C-contiguous ``dtype`` once, when they are not
    already; the library keeps no reference to them.

    Threads: one FMM may be shared between threads. Every method that uses
    the library's handle (evaluate, stats, options, close) holds the
    object's lock, so concurrent calls on one object run one after the
    other (each releases the GIL while it runs); close() waits for a running
    call. For parallel evaluations create one FMM per thread. After close(),
    evaluate, stats and options raise ValueError. An FMM cannot be copied or
    pickled (TypeError): it owns a C handle.

    Kernels (in: densities per source, out: outputs per target; param: the
    meaning of kernel_param; kifmm.kernel_help(name) for the formula):

"""

    __doc__ += _kernels.summary_table() + "\n"

    def __init__(self, kernel, sources=None, targets=None, *, order=None, tol=None,
                 dtype=np.float64, nthreads=None, kernel_param=None, leaf_size=None, period=None,
                 verbose=False, max_depth=None, domain=None, plan=None, tree=None, comm=None,
                 operator_cache=None):
        self._lock = threading.Lock()
        self._h = None
        self.kernel = kernel
        self.comm = comm
        self.src_dim, self.trg_dim = _kernel(kernel)
        if comm is not None:
            if plan is not None or tree is not None:
                raise TypeError("kifmm.FMM: comm= cannot be given with plan= or tree=")
            self._create_mpi(kernel, sources, targets, dtype,
                             _opts("kifmm.FMM", kernel, order, nthreads, kernel_param, leaf_size,
                                   period, tol, verbose, max_depth, domain, operator_cache))
            return
        if tree is not None:
            if not isinstance(tree, FMM):
                raise TypeError(f"kifmm.FMM: tree must be a kifmm.FMM, not {_show(tree)}")
            if sources is not None or targets is not None:
                raise TypeError("kifmm.FMM: with tree=, the points are the tree's: sources and "
                                "targets cannot be given")
            if tree._rtype != _dtype(dtype):
                raise ValueError(f"kifmm.FMM: the tree is {np.dtype(tree._rtype).name}, not "
                                 f"{np.dtype(_dtype(dtype)).name}")
        elif sources is None:
            raise TypeError("kifmm.FMM: sources are needed (or tree=, another FMM)")
        if plan is not None:
            if not isinstance(plan, Plan):
                raise TypeError(f"kifmm.FMM: plan must be a kifmm.Plan, not {_show(plan)}")
            given = [n for n, v in (("order", order), ("tol", tol), ("nthreads", nthreads),
                                    ("kernel_param", kernel_param), ("leaf_size", leaf_size),
                                    ("period", period), ("max_depth", max_depth),
                                    ("domain", domain), ("operator_cache", operator_cache))
                     if v is not None]
            if given or verbose:
                raise TypeError(f"kifmm.FMM: the plan holds the options; {given or ['verbose']} "
                                "cannot be given with it")
            if plan.kernel != kernel or plan._rtype != _dtype(dtype):
                raise ValueError(f"kifmm.FMM: the plan is for {plan.kernel!r} "
                                 f"{np.dtype(plan.dtype).name}, not {kernel!r} "
                                 f"{np.dtype(_values(kernel, _dtype(dtype))).name}")
            if plan._p is None:
                raise ValueError("kifmm.FMM: the plan is closed")
        self._rtype = _dtype(dtype)
        self.dtype = _values(kernel, self._rtype)
        self._f = _api(kernel, self._rtype)
        self._destroy = self._f["destroy"]
        if plan is None:
            opts = _opts("kifmm.FMM", kernel, order, nthreads, kernel_param, leaf_size, period,
                         tol, verbose, max_depth, domain, operator_cache)
        h = _P()
        if tree is not None:
            with tree._lock:  # the tree is the other FMM's until this one holds it too
                t = tree._f["tree"](tree._handle())
                if plan is None:
                    rc = self._f["create_on_tree"](ctypes.byref(h), ctypes.byref(opts), t)
                else:
                    rc = self._f["create_with_plan_on_tree"](ctypes.byref(h), plan._p, t)
                self.nsources, self.ntargets = tree.nsources, tree.ntargets
            if rc != 0:
                raise KifmmError(rc, f"kifmm_{kernel}_create_on_tree")
            self._h = h
            return
        src = _points(sources, self._rtype, "sources")
        trg = src if targets is None else _points(targets, self._rtype, "targets")
        self.nsources, self.ntargets = src.shape[0], trg.shape[0]
        if plan is None:
            rc = self._f["create"](ctypes.byref(h), ctypes.byref(opts), self.nsources, _ptr(src),
                                   self.ntargets, _ptr(trg))
        else:
            rc = self._f["create_with_plan"](ctypes.byref(h), plan._p, self.nsources, _ptr(src),
                                             self.ntargets, _ptr(trg))
        if rc != 0:
            raise KifmmError(rc, f"kifmm_{kernel}_create")
        self._h = h

    def _create_mpi(self, kernel, sources, targets, dtype, opts):
        """create_mpi on comm: this rank's points (collective)."""
        if sources is None:
            raise TypeError("kifmm.FMM: sources are needed (this rank's; may be empty)")
        MPI, _ = _mpi()
        handle = _comm(MPI, self.comm)
        self._rtype = _dtype(dtype)
        self.dtype = _values(kernel, self._rtype)
        self._f = _api(kernel, self._rtype, mpi=True)
        self._destroy = self._f["destroy"]
        f = self._f["create_mpi"]
        src = _points(sources, self._rtype, "sources")
        trg = src if targets is None else _points(targets, self._rtype, "targets")
        self.nsources, self.ntargets = src.shape[0], trg.shape[0]
        h = _P()
        rc = f(ctypes.byref(h), handle, ctypes.byref(opts), self.nsources, _ptr(src),
               self.ntargets, _ptr(trg))
        if rc != 0:
            raise KifmmError(rc, f"kifmm_{kernel}_create_mpi")
        self._h = h

    def __repr__(self):
        state = "closed" if self._h is None else "open"
        return (f"kifmm.FMM({self.kernel!r}, {self.nsources} sources, {self.ntargets} targets, "
                f"{np.dtype(self.dtype).name}, {state})")

    def _handle(self):
        """The C handle; the caller holds self._lock."""
        if self._h is None:
            raise ValueError(f"kifmm.FMM({self.kernel!r}) is closed: create another FMM")
        return self._h

    @property
    def closed(self):
        """True after close()."""
        return self._h is None

    def evaluate(self, densities):
        """The outputs at every target, (ntargets, trg_dim), from densities
        shaped (nsources, src_dim) (or (nsources,) for one component); with
        a leading axis of k density sets, k output blocks (k, ntargets,
        trg_dim), computed together. Calls on one object from several
        threads run one after the other."""
        with self._lock:
            # the counts are read under the lock: update_points may change them
            h = self._handle()
            vt = self.dtype
            d, nrhs, lead = _densities(densities, vt, self.nsources, self.src_dim)
            shape = (self.ntargets, self.trg_dim) if lead is None else (lead, self.ntargets,
                                                                        self.trg_dim)
            out = np.empty(shape, dtype=vt)
            if nrhs == 0:
                return out
            if nrhs == 1:
                rc = self._f["evaluate"](h, _ptr(d), _ptr(out))
            else:
                rc = self._f["evaluate_many"](h, nrhs, _ptr(d), _ptr(out))
        if rc != 0:
            raise KifmmError(rc, f"kifmm_{self.kernel}_evaluate")
        return out

    def update_points(self, sources, targets=None):
        """New points for this FMM (counts may change; targets None: the
        sources themselves), keeping its options and the operators that
        still apply: a time step costs the tree and the lists, not the
        operators. The results are those of a new FMM on the same points.
        On an error (KifmmError) the FMM keeps its old points and stays
        usable. The GIL is released while the library runs."""
        src = _points(sources, self._rtype, "sources")
        trg = src if targets is None else _points(targets, self._rtype, "targets")
        with self._lock:
            h = self._handle()
            rc = self._f["update_points"](h, src.shape[0], _ptr(src), trg.shape[0], _ptr(trg))
            if rc == 0:
                self.nsources, self.ntargets = src.shape[0], trg.shape[0]
        if rc != 0:
            raise KifmmError(rc, f"kifmm_{self.kernel}_update_points")

    def update_on_tree(self, other):
        """This FMM moved onto the points and tree of another FMM (any
        kernel, the same dtype), keeping its options and operators, as
        update_points on that FMM's points would, without sorting or
        refining them again: after a.update_points(x), b.update_on_tree(a).
        KifmmError (code -23) if the tree does not fit (FMM's tree=); then
        this FMM keeps its old points."""
        if not isinstance(other, FMM):
            raise TypeError(f"kifmm.FMM.update_on_tree: other must be a kifmm.FMM, not "
                            f"{_show(other)}")
        if other._rtype != self._rtype:
            raise ValueError(f"kifmm.FMM.update_on_tree: the tree is "
                             f"{np.dtype(other._rtype).name}, not {np.dtype(self._rtype).name}")
        # both locks, in one order whoever calls (a.update_on_tree(b) against
        # b.update_on_tree(a) on another thread)
        locks = [self._lock] if other is self else sorted((self._lock, other._lock), key=id)
        for lk in locks:
            lk.acquire()
        try:
            h, oh = self._handle(), other._handle()
            rc = self._f["update_on_tree"](h, other._f["tree"](oh))
            if rc == 0:
                self.nsources, self.ntargets = other.nsources, other.ntargets
        finally:
            for lk in reversed(locks):
                lk.release()
        if rc != 0:
            raise KifmmError(rc, f"kifmm_{self.kernel}_update_on_tree")

    @property
    def stats(self):
        """The tree, the memory held and the last evaluate's times (dict)."""
        s = _Stats()
        with self._lock:
            rc = self._f["stats"](self._handle(), ctypes.byref(s))
        if rc != 0:
            raise KifmmError(rc, f"kifmm_{self.kernel}_stats")
        out = {name: getattr(s, name) for name, _ in _Stats._fields_}
        out["build"] = s.build.decode()
        return out

    @property
    def options(self):
        """The options in use, every default resolved (dict)."""
        o = _Opts()
        with self._lock:
            rc = self._f["options"](self._handle(), ctypes.byref(o))
        if rc != 0:
            raise KifmmError(rc, f"kifmm_{self.kernel}_options")
        return {"order": o.order, "leaf_size": o.leaf_size, "max_depth": o.max_depth,
                "nthreads": o.nthreads, "kernel_param": list(o.kernel_param),
                "period": list(o.period), "tol": o.tol, "verbose": bool(o.verbose),
                "domain": list(o.domain) if any(o.domain) else None,
                "operator_cache": os.fsdecode(o.operator_cache) if o.operator_cache else None}

    def close(self):
        """Free the library's handle now (also done when the object goes);
        waits for a call running in another thread. Closing twice is
        harmless."""
        with self._lock:
            if self._h is not None:
                self._destroy(self._h)
                self._h = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        # No other thread can hold a reference, so the lock is free unless
        # this thread collects the object inside one of its own calls; a
        # blocking acquire there would deadlock, so the handle is left.
        # Exceptions are swallowed: at interpreter exit ctypes may be gone.
        lock, h = getattr(self, "_lock", None), getattr(self, "_h", None)
        if lock is None or h is None:
            return
        try:
            if lock.acquire(blocking=False):
                try:
                    if self._h is not None:
                        self._destroy(self._h)
                        self._h = None
                finally:
                    lock.release()
        except Exception:
            pass

    def __copy__(self):
        """Refused (TypeError): a copy would share the C handle, and both
        would free it."""
        raise TypeError(_NO_COPY)

    def __deepcopy__(self, memo):
        """Refused (TypeError), as __copy__."""
        raise TypeError(_NO_COPY)

    def __reduce_ex__(self, protocol):
        """Refused (TypeError): a pickle cannot carry the C handle."""
        raise TypeError(_NO_COPY)

    def __getstate__(self):
        """Refused (TypeError), as __reduce_ex__."""
        raise TypeError(_NO_COPY)


def direct(kernel, sources, densities, targets, kernel_param=None, *, dtype=np.float64,
           nthreads=None):
    """The same sums as FMM(kernel, sources, targets).evaluate(densities),
    computed directly (every source at every target, from the kernel's own
    definition, in double); (ntargets, trg_dim). The reference to check an
    FMM against, at a few targets. One density set. kernel_param and
    nthreads as FMM's."""
    sd, td = _kernel(kernel)
    dt = _dtype(dtype)
    f = _api(kernel, dt)
    opts = _opts("kifmm.direct", kernel, nthreads=nthreads, kernel_param=kernel_param)
    src = _points(sources, dt, "sources")
    trg = _points(targets, dt, "targets")
    d, nrhs, lead = _densities(densities, _values(kernel, dt), src.shape[0], sd)
    if lead is not None:
        raise ValueError("kifmm.direct: one density set (no leading axis)")
    out = np.empty((trg.shape[0], td), dtype=_values(kernel, dt))
    rc = f["direct"](ctypes.byref(opts), src.shape[0], _ptr(src), _ptr(d), trg.shape[0],
                     _ptr(trg), _ptr(out))
    if rc != 0:
        raise KifmmError(rc, f"kifmm_{kernel}_direct")
    return out


def estimate_bytes(kernel, nsources, ntargets=None, *, order=None, tol=None, dtype=np.float64,
                   nthreads=None, kernel_param=None, leaf_size=None, period=None, max_depth=None):
    """The memory, in bytes, that FMM(kernel, sources, targets, ...) would
    hold (its stats["bytes"]) for nsources sources and ntargets targets
    (None: the targets are the sources), before any point exists. A model
    of the tree of points spread through a volume: points on surfaces or in
    clusters make other trees (docs/api.md, "Memory", gives the ratios
    measured). The counts are integers in 0..kifmm.MAX_POINTS; options as
    FMM's."""
    where = "kifmm.estimate_bytes"
    _kernel(kernel)
    dt = _dtype(dtype)
    f = _api(kernel, dt)
    ns = _count(nsources, "nsources", where)
    nt = -1 if ntargets is None else _count(ntargets, "ntargets", where)
    o = _opts(where, kernel, order=order, tol=tol, nthreads=nthreads, kernel_param=kernel_param,
              leaf_size=leaf_size, period=period, max_depth=max_depth)
    out = ctypes.c_double(0.0)
    rc = f["estimate_bytes"](ctypes.byref(o), ns, nt, ctypes.byref(out))
    if rc != 0:
        raise KifmmError(rc, f"kifmm_{kernel}_estimate_bytes")
    return out.value
