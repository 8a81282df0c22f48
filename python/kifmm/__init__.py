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

Kernels (source and target dimensions) are listed in ``kifmm.KERNELS``;
docs/api.md in the source tree describes each, its layouts and parameters.
"""

import ctypes
import os
from pathlib import Path

import numpy as np

__all__ = ["FMM", "direct", "estimate_bytes", "KERNELS", "KifmmError"]
__version__ = "0.2.0"

# name: (density components per source, output components per target)
KERNELS = {
    "laplace": (1, 1),
    "laplace_grad": (1, 4),
    "laplace_hess": (1, 10),
    "laplace_dipole": (3, 1),
    "laplace_dipole_grad": (3, 4),
    "laplace_cd": (4, 1),
    "laplace_cd_grad": (4, 4),
    "laplace_cd_hess": (4, 10),
    "yukawa": (1, 1),
    "yukawa_grad": (1, 4),
    "yukawa_cd": (4, 1),
    "yukawa_cd_grad": (4, 4),
    "stokes": (3, 3),
    "stokes_grad": (3, 12),
    "stokes_pvel": (3, 4),
    "stokes_dl": (6, 3),
    "biot_savart": (3, 3),
    "biot_savart_grad": (3, 12),
}


class KifmmError(RuntimeError):
    """A library call failed: ``code`` is its result code (kifmm.h), the
    message the library's own."""

    def __init__(self, code, what):
        self.code = code
        super().__init__(f"{what}: {_strerror(code)} (kifmm code {code})")


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


def _api(kernel, dtype):
    """The instance's functions: kifmm_<kernel>[f]_*."""
    key = (kernel, dtype)
    if key not in _funcs:
        pre = "kifmm_" + kernel + ("f" if dtype == np.float32 else "")
        f = {n: getattr(_lib, f"{pre}_{n}") for n in
             ("create", "evaluate", "evaluate_many", "destroy", "stats", "options", "direct",
              "estimate_bytes")}
        f["create"].argtypes = [ctypes.POINTER(_P), ctypes.POINTER(_Opts), _I64, _P, _I64, _P]
        f["evaluate"].argtypes = [_P, _P, _P]
        f["evaluate_many"].argtypes = [_P, ctypes.c_int, _P, _P]
        f["destroy"].argtypes = [_P]
        f["destroy"].restype = None
        f["stats"].argtypes = [_P, ctypes.POINTER(_Stats)]
        f["options"].argtypes = [_P, ctypes.POINTER(_Opts)]
        f["direct"].argtypes = [ctypes.POINTER(_Opts), _I64, _P, _P, _I64, _P, _P]
        f["estimate_bytes"].argtypes = [ctypes.POINTER(_Opts), _I64, _I64,
                                        ctypes.POINTER(ctypes.c_double)]
        _funcs[key] = f
    return _funcs[key]


def _kernel(kernel):
    if kernel not in KERNELS:
        raise ValueError(f"kifmm: unknown kernel {kernel!r}; kifmm.KERNELS lists {sorted(KERNELS)}")
    return KERNELS[kernel]


def _dtype(dtype):
    dt = np.dtype(dtype)
    if dt not in (np.dtype(np.float64), np.dtype(np.float32)):
        raise TypeError(f"kifmm: dtype must be float64 or float32, not {dt}")
    return dt.type


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


def _opts(order=None, nthreads=None, kernel_param=None, leaf_size=None, period=None, tol=None,
          verbose=False):
    o = _Opts()
    o.verbose = 1 if verbose else 0
    o.order = 0 if order is None else int(order)
    o.tol = 0.0 if tol is None else float(tol)
    o.nthreads = 0 if nthreads is None else int(nthreads)
    o.leaf_size = 0 if leaf_size is None else int(leaf_size)
    if kernel_param is not None:
        prm = np.atleast_1d(np.asarray(kernel_param, dtype=np.float64))
        if prm.ndim != 1 or prm.size > 4:
            raise ValueError("kifmm: kernel_param holds at most 4 numbers")
        for i, v in enumerate(prm):
            o.kernel_param[i] = float(v)
    if period is not None:
        per = np.broadcast_to(np.asarray(period, dtype=np.float64), (3,))
        for i in range(3):
            o.period[i] = float(per[i])
    return o


def _densities(d, dtype, ns, sd):
    """(arr, nrhs, lead): the densities as a C-contiguous block of nrhs
    vectors; lead is the leading axis's length or None."""
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


class FMM:
    """An FMM for one kernel on fixed sources and targets (the tree and the
    operators are built here, once); ``evaluate`` as often as needed.

    kernel        a name from kifmm.KERNELS
    sources       (nsources, 3) points
    targets       (ntargets, 3) points; None: the sources themselves
    order         expansion order (2 to 12; None: 6): about ``order`` digits
    tol           instead of order: the relative L2 error wanted (1e-3 ...
                  1e-10; the order is picked from a measured table, and
                  ``options["order"]`` reports it)
    dtype         numpy.float64 or numpy.float32 (the float instances)
    nthreads      OpenMP threads (None: all)
    kernel_param  up to 4 numbers (yukawa: lambda; stokes kernels: viscosity)
    leaf_size     points per leaf (None: chosen per order)
    period        a period L (or 3 of them, 0 = free) for periodic boundaries
    verbose       True: one line per stage of create and evaluate, with its
                  time and the memory held, on stderr

    Arrays are converted to C-contiguous ``dtype`` once, when they are not
    already; the library keeps no reference to them.
    """

    def __init__(self, kernel, sources, targets=None, *, order=None, tol=None, dtype=np.float64,
                 nthreads=None, kernel_param=None, leaf_size=None, period=None, verbose=False):
        self.kernel = kernel
        self.src_dim, self.trg_dim = _kernel(kernel)
        self.dtype = _dtype(dtype)
        self._f = _api(kernel, self.dtype)
        src = _points(sources, self.dtype, "sources")
        trg = src if targets is None else _points(targets, self.dtype, "targets")
        self.nsources, self.ntargets = src.shape[0], trg.shape[0]
        opts = _opts(order, nthreads, kernel_param, leaf_size, period, tol, verbose)
        self._h = _P()
        rc = self._f["create"](ctypes.byref(self._h), ctypes.byref(opts), self.nsources, _ptr(src),
                               self.ntargets, _ptr(trg))
        if rc != 0:
            self._h = _P()
            raise KifmmError(rc, f"kifmm_{kernel}_create")

    def evaluate(self, densities):
        """The outputs at every target, (ntargets, trg_dim), from densities
        shaped (nsources, src_dim) (or (nsources,) for one component); with
        a leading axis of k density sets, k output blocks (k, ntargets,
        trg_dim), computed together."""
        if not self._h:
            raise ValueError("kifmm: this FMM is closed")
        d, nrhs, lead = _densities(densities, self.dtype, self.nsources, self.src_dim)
        shape = (self.ntargets, self.trg_dim) if lead is None else (lead, self.ntargets, self.trg_dim)
        out = np.empty(shape, dtype=self.dtype)
        if nrhs == 0:
            return out
        if nrhs == 1:
            rc = self._f["evaluate"](self._h, _ptr(d), _ptr(out))
        else:
            rc = self._f["evaluate_many"](self._h, nrhs, _ptr(d), _ptr(out))
        if rc != 0:
            raise KifmmError(rc, f"kifmm_{self.kernel}_evaluate")
        return out

    @property
    def stats(self):
        """The tree, the memory held and the last evaluate's times (dict)."""
        s = _Stats()
        rc = self._f["stats"](self._h, ctypes.byref(s))
        if rc != 0:
            raise KifmmError(rc, f"kifmm_{self.kernel}_stats")
        out = {name: getattr(s, name) for name, _ in _Stats._fields_}
        out["build"] = s.build.decode()
        return out

    @property
    def options(self):
        """The options in use, every default resolved (dict)."""
        o = _Opts()
        rc = self._f["options"](self._h, ctypes.byref(o))
        if rc != 0:
            raise KifmmError(rc, f"kifmm_{self.kernel}_options")
        return {"order": o.order, "leaf_size": o.leaf_size, "max_depth": o.max_depth,
                "nthreads": o.nthreads, "kernel_param": list(o.kernel_param),
                "period": list(o.period), "tol": o.tol, "verbose": bool(o.verbose)}

    def close(self):
        """Free the library's handle now (also done when the object goes)."""
        if getattr(self, "_h", None):
            self._f["destroy"](self._h)
            self._h = _P()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        self.close()


def direct(kernel, sources, densities, targets, kernel_param=None, *, dtype=np.float64,
           nthreads=None):
    """The same sums as FMM(kernel, sources, targets).evaluate(densities),
    computed directly (every source at every target, from the kernel's own
    definition, in double); (ntargets, trg_dim). The reference to check an
    FMM against, at a few targets. One density set."""
    sd, td = _kernel(kernel)
    dt = _dtype(dtype)
    f = _api(kernel, dt)
    src = _points(sources, dt, "sources")
    trg = _points(targets, dt, "targets")
    d, nrhs, lead = _densities(densities, dt, src.shape[0], sd)
    if lead is not None:
        raise ValueError("kifmm.direct: one density set (no leading axis)")
    out = np.empty((trg.shape[0], td), dtype=dt)
    rc = f["direct"](ctypes.byref(_opts(nthreads=nthreads, kernel_param=kernel_param)),
                     src.shape[0], _ptr(src), _ptr(d), trg.shape[0], _ptr(trg), _ptr(out))
    if rc != 0:
        raise KifmmError(rc, f"kifmm_{kernel}_direct")
    return out


def estimate_bytes(kernel, nsources, ntargets=None, *, order=None, tol=None, dtype=np.float64,
                   nthreads=None, kernel_param=None, leaf_size=None, period=None):
    """The memory, in bytes, that FMM(kernel, sources, targets, ...) would
    hold (its stats["bytes"]) for nsources sources and ntargets targets
    (None: the targets are the sources), before any point exists. A model
    of the tree of points spread through a volume: points on surfaces or in
    clusters make other trees (docs/api.md, "Memory", gives the ratios
    measured). Options as FMM's."""
    _kernel(kernel)
    dt = _dtype(dtype)
    f = _api(kernel, dt)
    ns, nt = int(nsources), -1 if ntargets is None else int(ntargets)
    if ns < 0 or (ntargets is not None and nt < 0):
        raise ValueError("kifmm.estimate_bytes: counts must not be negative")
    o = _opts(order=order, tol=tol, nthreads=nthreads, kernel_param=kernel_param,
              leaf_size=leaf_size, period=period)
    out = ctypes.c_double(0.0)
    rc = f["estimate_bytes"](ctypes.byref(o), ns, nt, ctypes.byref(out))
    if rc != 0:
        raise KifmmError(rc, f"kifmm_{kernel}_estimate_bytes")
    return out.value
