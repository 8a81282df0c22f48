#!/usr/bin/env python3
"""bench/fmm3d_kernels.py - FMM3D (fmm3dpy) on the points and densities of a
kifmm case dumped by bench_kernels --dump, at matching error.

    fmm3d_kernels.py DATA.bin ...     one table row per file

Kinds: 0, the Stokeslet (stfmm3d, velocities); 1, Laplace charges and
dipoles with the potential and its gradient (lfmm3d, pg=2); 2, Helmholtz
charges with the potential and its gradient (hfmm3d, pg=2; complex values
as (re, im) pairs, the wavenumber after the dump's usual end:
bench/bench_helmholtz.c). FMM3D's kernels are scaled differently from
kifmm's ((delta_ij / r + d_i d_j / r^3) / (8 pi); 1 / (4 pi r) and v . d /
(4 pi r^3); exp(i k r) / (4 pi r)): a calibration on 300 points against
direct sums in numpy finds the factor, prints it, and FMM3D's outputs are
multiplied by it before their errors are computed against the same direct
sums as kifmm's (the sample targets of the dump). eps runs over 1e-3 ...
1e-12; the row printed is the largest eps whose errors are not worse than
kifmm's (every output group: "match"), or eps = 1e-12 ("best") if none. The
time is the wall time of one FMM3D call after a small warm-up call; threads
follow OMP_NUM_THREADS. ratio = fmm3d_s / kifmm_s.
"""
import math
import sys
import time


def read_dump(path, np):
    raw = open(path, "rb").read()
    off = 0

    def take(dtype, count):
        nonlocal off
        a = np.frombuffer(raw, dtype=dtype, count=count, offset=off)
        off += 8 * count
        return a

    kind, n, ns = (int(v) for v in take("<i8", 3))
    xyz = take("<f8", 3 * n).reshape(n, 3)
    sd = int(take("<i8", 1)[0])
    dens = take("<f8", sd * n).reshape(n, sd)
    idx = take("<i8", ns).copy()
    td = int(take("<i8", 1)[0])
    ref = take("<f8", td * ns).reshape(ns, td)
    e0, e1, sec = take("<f8", 3)
    zk = complex(*take("<f8", 2)) if kind == 2 else None
    return kind, n, xyz, dens, idx, ref, (e0, e1), sec, zk


def direct_numpy(kind, x, g, zk=None):
    """kifmm's kernels on 300 points, sources = targets, in numpy"""
    d = x[:, None, :] - x[None, :, :]
    r = np.sqrt((d * d).sum(axis=2))
    np.fill_diagonal(r, np.inf)
    if kind == 2:
        q = g[:, 0] + 1j * g[:, 1]
        r = np.where(np.isinf(r), 1.0, r)
        gq = np.exp(1j * zk * r) / r * q[None, :]
        np.fill_diagonal(gq, 0.0)
        pot = gq.sum(axis=1)
        grad = (d * (gq * (1j * zk * r - 1.0) / r ** 2)[:, :, None]).sum(axis=1)
        out = np.column_stack([pot, grad]) / (4 * math.pi)
        return np.column_stack([out.real, out.imag])[:, [0, 4, 1, 5, 2, 6, 3, 7]]
    if kind == 0:
        dg = (d * g[None, :, :]).sum(axis=2)
        return ((g[None, :, :] / r[:, :, None]).sum(axis=1)
                + (d * (dg / r ** 3)[:, :, None]).sum(axis=1)) / (8 * math.pi)
    q, v = g[:, 0], g[:, 1:]
    vd = (d * v[None, :, :]).sum(axis=2)
    pot = (q[None, :] / r + vd / r ** 3).sum(axis=1)
    m = (q[None, :] + 3.0 * vd / r ** 2) / r ** 3
    grad = (v[None, :, :] / r[:, :, None] ** 3 - d * m[:, :, None]).sum(axis=1)
    return np.column_stack([pot, grad]) / (4 * math.pi)


def run_fmm3d(kind, eps, src, dens, zk=None):
    """FMM3D's outputs as an (n, td) array"""
    if kind == 2:
        out = fmm3dpy.hfmm3d(eps=eps, zk=zk, sources=src,
                             charges=np.ascontiguousarray(dens[:, 0] + 1j * dens[:, 1]), pg=2)
        v = np.column_stack([np.asarray(out.pot), np.asarray(out.grad).reshape(3, -1).T])
        return np.column_stack([v.real, v.imag])[:, [0, 4, 1, 5, 2, 6, 3, 7]]
    if kind == 0:
        out = fmm3dpy.stfmm3d(eps=eps, sources=src, stoklet=np.asfortranarray(dens.T), ifppreg=1)
        return np.asarray(out.pot).reshape(3, -1).T
    out = fmm3dpy.lfmm3d(eps=eps, sources=src, charges=np.ascontiguousarray(dens[:, 0]),
                         dipvec=np.asfortranarray(dens[:, 1:].T), pg=2)
    return np.column_stack([np.asarray(out.pot), np.asarray(out.grad).reshape(3, -1).T])


def errors(kind, v, ref):
    def rel(a, b):
        return float(np.linalg.norm(a - b) / np.linalg.norm(b))
    if kind == 0:
        return rel(v, ref), 0.0
    if kind == 2:
        return rel(v[:, :2], ref[:, :2]), rel(v[:, 2:], ref[:, 2:])
    return rel(v[:, 0], ref[:, 0]), rel(v[:, 1:], ref[:, 1:])


def one(path):
    kind, n, xyz, dens, idx, ref, kerr, ksec, zk = read_dump(path, np)
    src = np.asfortranarray(xyz.T)
    rng = np.random.default_rng(7)
    x = rng.random((300, 3))
    g = rng.uniform(-1.0, 1.0, (300, dens.shape[1]))
    u = direct_numpy(kind, x, g, zk)
    fu = run_fmm3d(kind, 1e-12, np.asfortranarray(x.T), g, zk)
    scale = float(np.sum(fu * u) / np.sum(fu * fu))
    run_fmm3d(kind, 1e-6, src[:, :2000].copy(order="F"), dens[:2000], zk)  # warm-up
    best = None
    for k in range(3, 13):
        eps = 10.0 ** -k
        t0 = time.perf_counter()
        out = run_fmm3d(kind, eps, src, dens, zk)
        t = time.perf_counter() - t0
        e = errors(kind, out[idx] * scale, ref)
        ok = e[0] <= kerr[0] and e[1] <= kerr[1]
        best = (eps, e, t, "match" if ok else "best")
        if ok:
            break
    eps, e, t, note = best
    name = ("stokes", "laplace_cd_grad", "helmholtz_grad")[kind]
    print("%-15s %8d  kifmm_err %.2e/%.2e kifmm_s %.3f | eps %.0e fmm3d_err %.2e/%.2e "
          "fmm3d_s %.3f ratio %.2f %s" % (name, n, kerr[0], kerr[1], ksec, eps, e[0], e[1], t,
                                           t / ksec, note))
    print("# FMM3D calibration (%s, 300 points, eps 1e-12, vs numpy): outputs multiplied by "
          "%.8g (%s: %.8g)" % (name, scale, "8 pi" if kind == 0 else "1 / (4 pi)",
                               8 * math.pi if kind == 0 else 1 / (4 * math.pi)))
    if kind == 2:
        print("# FMM3D hfmm3d zk = %g (%.3g wavelengths across the unit cube)"
              % (zk.real, zk.real / (2 * math.pi)))


def main():
    global np, fmm3dpy
    import numpy as np
    import fmm3dpy
    if len(sys.argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    for path in sys.argv[1:]:
        one(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
