"""The package around the bindings: the kernel table (kifmm.KERNELS,
kernel_help, FMM's docstring, docs/kernels.md) and its formulas against
the library's sums, python -m kifmm, the build's messages, and an install
from a read-only checkout."""
import importlib.util
import os
import pwd
import re
import shutil
import stat
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

import kifmm
from kifmm import _kernels

CHECKOUT = Path(__file__).resolve().parents[2]
PI4 = 4.0 * np.pi


# --- the kernel table --------------------------------------------------------

def test_kernel_table_is_the_source():
    assert list(kifmm.KERNELS) == [k.name for k in _kernels.KERNEL_TABLE]
    assert len(kifmm.KERNELS) == 21
    assert kifmm.COMPLEX == {"helmholtz", "helmholtz_grad", "helmholtz_cd_grad"}
    for name, (sd, td) in kifmm.KERNELS.items():
        text = kifmm.kernel_help(name)
        assert text.startswith(name + ":")
        assert f"densities per source ({sd}," in text and f"outputs per target ({td}," in text
        assert "formula:" in text and "parameter:" in text
        assert name in kifmm.FMM.__doc__
    with pytest.raises(ValueError):
        kifmm.kernel_help("no_such_kernel")
    assert "kifmm.kernel_help" in kifmm.FMM.__doc__
    assert "Hessian (xx, yy, zz, xy, xz, yz)" in kifmm.kernel_help("laplace_hess")
    assert "8 pi mu" in kifmm.kernel_help("stokes")
    assert "an explicit 0 is refused" in kifmm.kernel_help("yukawa")
    assert "(4, complex," in kifmm.kernel_help("helmholtz_cd_grad")
    assert "needed (no default)" in kifmm.kernel_help("helmholtz")


def test_tol_docstring():
    doc = " ".join(kifmm.FMM.__doc__.split())
    assert ("tol: the order is picked so that every output of the kernel (potential, gradient, "
            "Hessian, velocity, pressure, velocity gradient) meets tol in relative L2 error on "
            "the measured distributions; the worst output is then at most 30x more accurate "
            "than asked, the others (the potential of the gradient kernels, say) up to about "
            "100x; see docs/api.md, Tolerance") in doc


def test_docs_kernels_md_is_generated():
    md = CHECKOUT / "docs" / "kernels.md"
    if not md.exists():
        pytest.skip(f"{md} not found (the tests run from a kifmm.h checkout)")
    text = md.read_text()
    a = text.index(_kernels.MD_BEGIN)
    b = text.index(_kernels.MD_END) + len(_kernels.MD_END) + 1
    assert text[a:b] == _kernels.markdown(), (
        "docs/kernels.md's kernels table differs from python/kifmm/_kernels.py: replace the "
        "section with the output of python -m kifmm --kernels-md")


def _at(kernel, src, dens, trg, prm=None):
    return kifmm.direct(kernel, np.atleast_2d(src), np.atleast_2d(dens), np.atleast_2d(trg),
                        kernel_param=prm)[0]


def test_kernel_formulas_and_signs():
    """the checks by hand that the table states, and a few values of its
    formulas, against the library's direct sums"""
    o = [0.0, 0.0, 0.0]
    assert np.allclose(_at("laplace_dipole", o, [0, 0, 1], [0, 0, 2]), [1 / (16 * np.pi)])
    assert np.allclose(_at("stokes_dl", o, [0, 0, 1, 0, 0, 1], [0, 0, 1]), [0, 0, -3 / PI4])
    assert np.allclose(_at("biot_savart", o, [0, 0, 1], [1, 0, 0]), [0, 1 / PI4, 0])
    # the gradient is of the potential: toward a positive charge
    assert np.allclose(_at("laplace_grad", o, [1.0], [2, 0, 0]), [1 / (2 * PI4), -1 / (4 * PI4), 0, 0])
    y, r = np.array([0.3, -0.5, 0.7]), np.sqrt(0.83)
    lam, mu = 2.0, 0.7
    assert np.allclose(_at("yukawa", o, [1.0], y, lam), [np.exp(-lam * r) / (PI4 * r)])
    f = np.array([0.2, -1.0, 0.4])
    u = (f / r + y * (y @ f) / r**3) / (2 * PI4 * mu)
    assert np.allclose(_at("stokes", o, f, y, mu), u)
    assert np.allclose(_at("stokes_pvel", o, f, y, mu), np.r_[(f @ y) / (PI4 * r**3), u])
    h = 3 * np.outer(y, y) / (PI4 * r**5) - np.eye(3) / (PI4 * r**3)
    hess = [h[0, 0], h[1, 1], h[2, 2], h[0, 1], h[0, 2], h[1, 2]]
    assert np.allclose(_at("laplace_hess", o, [1.0], y)[4:], hess)


@pytest.mark.parametrize("kernel,base,prm", [
    ("laplace_hess", "laplace_grad", None),     # the Hessian: the gradient's derivative
    ("laplace_cd_grad", "laplace_cd", None),
    ("yukawa_cd_grad", "yukawa_cd", 1.5),
    ("stokes_grad", "stokes", 0.7),
    ("biot_savart_grad", "biot_savart", None),
    ("helmholtz_grad", "helmholtz", 7.0 + 0.4j),
    ("helmholtz_cd_grad", "helmholtz_cd_grad", 3.0 + 0.5j),
])
def test_derivative_layouts(kernel, base, prm):
    """each derivative output, at the offset the table gives, is the
    central difference of the outputs it differentiates (complex kernels:
    complex densities; helmholtz_cd_grad's gradient, of its own potential)"""
    rng = np.random.default_rng(50)
    sd = kifmm.KERNELS[kernel][0]
    src, dens = rng.random((3, 3)), rng.random((3, sd)) - 0.5
    if kernel in kifmm.COMPLEX:
        dens = dens + 1j * (rng.random((3, sd)) - 0.5)
    y, eps = np.array([1.3, 0.9, 1.1]), 1e-5
    nb = 1 if base == kernel else kifmm.KERNELS[base][1]
    out = kifmm.direct(kernel, src, dens, y[None], kernel_param=prm)[0]
    jac = np.empty((nb, 3), dtype=out.dtype)
    for j in range(3):
        e = np.eye(3)[j] * eps
        hi = kifmm.direct(base, src, dens, (y + e)[None], kernel_param=prm)[0][:nb]
        lo = kifmm.direct(base, src, dens, (y - e)[None], kernel_param=prm)[0][:nb]
        jac[:, j] = (hi - lo) / (2 * eps)
    assert np.allclose(out[:nb], kifmm.direct(base, src, dens, y[None], kernel_param=prm)[0][:nb])
    if kernel == "laplace_hess":
        full = jac[1:4]  # d(grad phi)_i / dy_j
        want = [full[0, 0], full[1, 1], full[2, 2], full[0, 1], full[0, 2], full[1, 2]]
        got = out[4:10]
    elif nb == 1:
        want, got = jac[0], out[1:4]
    else:
        want, got = jac.reshape(-1), out[nb:]  # du_i/dy_j at nb + 3 i + j
    assert np.allclose(got, want, rtol=1e-6, atol=1e-8 * np.abs(want).max()), (got, want)


# --- python -m kifmm ---------------------------------------------------------

def test_main_prints_the_build():
    r = subprocess.run([sys.executable, "-m", "kifmm"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    fields = dict(line.split(": ", 1) for line in r.stdout.splitlines() if ": " in line)
    assert fields["kifmm (Python) version"] == kifmm.__version__
    assert fields["library"] == kifmm._lib._name
    assert fields["build"] and fields["simd"].split()[0] in ("0", "256", "512")
    assert fields["threads"].split()[0].isdigit()
    assert "blas" in fields
    r = subprocess.run([sys.executable, "-m", "kifmm", "--kernels-md"], capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 0 and r.stdout == _kernels.markdown()


# --- the build's messages ----------------------------------------------------

def _setup_module():
    path = CHECKOUT / "python" / "setup.py"
    if not path.exists():
        pytest.skip(f"{path} not found (the tests run from a kifmm.h checkout)")
    spec = importlib.util.spec_from_file_location("kifmm_setup", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)  # not __main__: setup() is not run
    return mod


def test_compile_says_what_it_does_and_how_long(tmp_path, capfd, monkeypatch):
    setup = _setup_module()
    tty = tmp_path / "tty"
    tty.write_text("")
    monkeypatch.setattr(setup, "TTY", str(tty))  # a terminal: the lines go there, past pip
    setup.compile_library([sys.executable, "-c", "pass"])
    text = tty.read_text()
    assert "kifmm: compiling libkifmm.so (about 1-2 minutes) ..." in text
    assert re.search(r"kifmm: compiled in \d+ s\n$", text), text
    monkeypatch.setattr(setup, "TTY", str(tmp_path / "no" / "tty"))  # none: stderr
    setup.compile_library([sys.executable, "-c", "pass"])
    err = capfd.readouterr().err
    assert "kifmm: compiling libkifmm.so" in err and "kifmm: compiled in" in err


# --- pip install from a read-only checkout -----------------------------------

def _unprivileged():
    """a command prefix that runs as uid/gid 65534, or the reason why none"""
    if os.geteuid() != 0:
        return None, "not root: no other user to switch to"
    try:
        pwd.getpwuid(65534)
    except KeyError:
        return None, "no user 65534 (nobody)"
    if shutil.which("setpriv"):
        return ["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups"], None
    return None, "setpriv not found"


def _python_for(prefix, env):
    """an interpreter with venv that the unprivileged user can run"""
    for py in ("/usr/bin/python3", shutil.which("python3"), getattr(sys, "_base_executable", None)):
        if py and subprocess.run(prefix + [py, "-c", "import venv, ensurepip"], env=env,
                                 capture_output=True).returncode == 0:
            return py
    return None


@pytest.mark.skipif(os.environ.get("KIFMM_TEST_INSTALL") != "1",
                    reason="runs pip install (about 5-10 s): tests/python.sh sets KIFMM_TEST_INSTALL=1")
def test_pip_install_from_read_only_checkout():
    """pip install ./python by a user who cannot write to the checkout (root
    writes through any mode, so the install runs as another user)"""
    prefix, why = _unprivileged()
    if prefix is None:
        pytest.skip(why)
    prebuilt = os.environ.get("KIFMM_PREBUILT") or kifmm._lib._name
    tmp = Path(tempfile.mkdtemp(prefix="kifmm-ro-"))
    try:
        os.chmod(tmp, 0o755)
        src = tmp / "src"
        ignore = shutil.ignore_patterns("build", "*.egg-info", "__pycache__", ".pytest_cache")
        shutil.copytree(CHECKOUT / "python", src / "python", ignore=ignore)
        shutil.copytree(CHECKOUT / "src", src / "src", ignore=ignore)
        for h in ("kifmm.h", "kifmm_kernels.h", "kifmm_lib.h"):
            shutil.copy(CHECKOUT / h, src / h)
        shutil.copy(prebuilt, tmp / "libkifmm.so")
        for p in [tmp / "libkifmm.so", src, *src.rglob("*")]:
            os.chmod(p, 0o755 if p.is_dir() else 0o644)
        before = sorted(p.relative_to(src) for p in src.rglob("*"))
        home = tmp / "home"
        home.mkdir()
        os.chown(home, 65534, 65534)
        env = {k: v for k, v in os.environ.items()
               if k.startswith("PIP_") or k.lower() in ("http_proxy", "https_proxy", "no_proxy")}
        env.update(PATH="/usr/local/bin:/usr/bin:/bin", HOME=str(home), TMPDIR=str(home),
                   KIFMM_PREBUILT=str(tmp / "libkifmm.so"), KIFMM_NO_MPI="1", LANG="C.UTF-8")
        py = _python_for(prefix, env)
        if py is None:
            pytest.skip("no Python with venv that user 65534 can run")
        venv = home / "venv"
        r = subprocess.run(prefix + [py, "-m", "venv", str(venv)], env=env, capture_output=True,
                           text=True, timeout=120)
        if r.returncode != 0:  # not what this test is about
            pytest.skip(f"user 65534 cannot make a virtual environment with {py}: {r.stderr}")
        r = subprocess.run(prefix + [str(venv / "bin" / "pip"), "install", "--no-deps", "-q",
                                     str(src / "python")], env=env, capture_output=True,
                           text=True, timeout=300, cwd=home)
        assert r.returncode == 0, r.stdout + r.stderr
        assert sorted(p.relative_to(src) for p in src.rglob("*")) == before
        libs = list(venv.glob("lib/python*/site-packages/kifmm/libkifmm.so"))
        assert len(libs) == 1 and libs[0].stat().st_size == (tmp / "libkifmm.so").stat().st_size
        assert stat.S_IMODE(src.stat().st_mode) == 0o755 and src.stat().st_uid == 0
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
