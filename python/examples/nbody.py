"""A gravitational N-body code's time step with kifmm: leapfrog (kick, drift,
kick) for N bodies, the accelerations from the laplace_grad kernel.

    python python/examples/nbody.py [N] [steps]      defaults 100000 and 5

With K = 1 / (4 pi r), the field of masses m is grad phi = -sum m d / (4 pi
r^3), so the acceleration a = -G sum m d / r^3 = 4 pi G grad phi, and the
potential energy is -G sum_{i<j} m_i m_j / r = -2 pi G sum_i m_i phi_i
(each pair once; a body on itself contributes nothing). One kifmm.FMM
serves every step: update_points gives it the moved bodies (a new tree, the
operators kept) and it evaluates once. The program checks the accelerations
against direct sums at 200 bodies (kifmm.direct), prints the time per step
against a step that creates a new FMM, and the energy's relative change,
and exits nonzero if the accelerations are off by more than the order's
accuracy.
"""
import sys
import time

import numpy as np

import kifmm

G = 1.0


def accelerations(fmm, x, m):
    """the accelerations and potentials at the bodies x, moved since the
    last call: the FMM's points updated, then one evaluation"""
    fmm.update_points(x)
    out = fmm.evaluate(m)
    return 4.0 * np.pi * G * out[:, 1:], out[:, 0]


def energy(v, m, phi):
    return 0.5 * (m * (v * v).sum(axis=1)).sum() - 2.0 * np.pi * G * (m * phi).sum()


def main():
    n = int(float(sys.argv[1])) if len(sys.argv) > 1 else 100000
    steps = int(sys.argv[2]) if len(sys.argv) > 2 else 5
    order, dt = 6, 1e-4
    rng = np.random.default_rng(1)
    # a Plummer-like sphere: positions from the cumulative mass, random directions
    r = 1.0 / np.sqrt(rng.random(n) ** (-2.0 / 3.0) - 1.0)
    r = np.minimum(r, 10.0)
    d = rng.normal(size=(n, 3))
    x = d / np.linalg.norm(d, axis=1)[:, None] * r[:, None]
    v = 0.1 * rng.normal(size=(n, 3))
    m = np.full(n, 1.0 / n)

    fmm = kifmm.FMM("laplace_grad", x, order=order)
    a, phi = accelerations(fmm, x, m)
    ref = 4.0 * np.pi * G * kifmm.direct("laplace_grad", x, m, x[:200])[:, 1:]
    err = np.linalg.norm(a[:200] - ref) / np.linalg.norm(ref)
    e0 = energy(v, m, phi)
    print(f"{n} bodies, order {order}: acceleration error against direct sums {err:.1e}")
    t0 = time.perf_counter()
    for _ in range(steps):
        v += 0.5 * dt * a
        x += dt * v
        a, phi = accelerations(fmm, x, m)
        v += 0.5 * dt * a
    t = (time.perf_counter() - t0) / max(steps, 1)
    e1 = energy(v, m, phi)
    t1 = time.perf_counter()
    kifmm.FMM("laplace_grad", x, order=order).evaluate(m)  # what a step costs without update_points
    tc = time.perf_counter() - t1
    print(f"{steps} leapfrog steps: {t:.3f} s per step (update_points + evaluate; create + "
          f"evaluate {tc:.3f} s), energy change {abs(e1 - e0) / abs(e0):.1e}")
    return 0 if err < 1e-4 else 1


if __name__ == "__main__":
    sys.exit(main())
