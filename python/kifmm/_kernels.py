"""The shipped kernels, written once: kifmm.KERNELS, kifmm.kernel_help,
the kernel list in kifmm.FMM's docstring and the generated table of
docs/kernels.md (python -m kifmm --kernels-md) all come from KERNEL_TABLE.
The formulas are those of the _eval functions of kifmm_kernels.h."""
from collections import namedtuple

Param = namedtuple("Param", "symbol meaning default lo hi valid")
Kernel = namedtuple("Kernel", "name summary densities outputs formula param degree value",
                    defaults=("real",))
# densities: ((symbol, count, meaning), ...) in the order they are passed per
# source; outputs: ((label, count, meaning), ...) in the order they come per
# target;
# degree: the surface kernel's degree of homogeneity (-1), None when it is
# not scale invariant (operators built per tree level); value: "real", or
# "complex" (densities, outputs and the counts above are complex numbers,
# (re, im) pairs of reals in C: SRC_DIM and TRG_DIM are twice the counts)

# lo and hi are the bounds of kifmm_kernels.h's setup functions, inclusive
LAMBDA = Param("lambda", "the screening constant (an inverse length)", 1.0, 5e-324, 1e300,
               "0 < lambda <= 1e300")
MU = Param("mu", "the viscosity", 1.0, 1e-150, 1e150, "1e-150 <= mu <= 1e150")
# a complex number: kernel_param[0] its real part, kernel_param[1] its
# imaginary part; no default (None is refused); lo, hi bound |Re k| and Im k
WAVENUMBER = Param("k", "the wavenumber, complex (Im k > 0: damped waves)", None, 0.0, 1e150,
                   "a complex number, |Re k| <= 1e150, 0 <= Im k <= 1e150")

_Q = (("q", 1, "charge"),)
_V = (("v", 3, "dipole moment"),)
_QV = (("q", 1, "charge"), ("v", 3, "dipole moment"))
_F = (("f", 3, "force"),)
_A = (("a", 3, "vortex strength"),)
_PHI = ("phi", 1, "potential")
_GRAD = ("grad phi", 3, "gradient of the potential with respect to the target (not the field "
         "-grad phi)")
_HESS = ("Hessian (xx, yy, zz, xy, xz, yz)", 6, "d2 phi / dy_i dy_j")
_U = ("u", 3, "velocity")
_DU = ("du_i/dy_j at 3 + 3 i + j", 9, "velocity gradient, row-major after u")

_LAP_GRAD = "grad phi = -sum q d / (4 pi r^3)"
_LAP_HESS = "d2 phi / dy_i dy_j = sum q (3 d_i d_j - r^2 delta_ij) / (4 pi r^5)"
_DIP_SIGN = ("a dipole's potential is positive on the side v points to (v = (0, 0, 1) at the "
             "origin, target (0, 0, 2): phi = 1 / (16 pi))")
_DIP_GRAD = "a dipole's grad phi = (v - 3 (v . d) d / r^2) / (4 pi r^3)"
_DIP_HESS = ("a dipole's d2 phi / dy_i dy_j = (15 (v . d) d_i d_j / r^2 - 3 (v_i d_j + v_j d_i "
             "+ (v . d) delta_ij)) / (4 pi r^5)")
_YUK = "phi = sum q exp(-lambda r) / (4 pi r)"
_YUK_GRAD = "grad phi = -sum q (1 + lambda r) exp(-lambda r) d / (4 pi r^3)"
_YUK_CD = ("phi = sum q G + v . grad_source G, G = exp(-lambda r) / (4 pi r), that is q G + "
           "(v . d) (1 + lambda r) exp(-lambda r) / (4 pi r^3); at lambda -> 0 the Laplace "
           "family's, with the same sign convention")
_YUK_CD_GRAD = ("grad phi: a charge's -q (1 + lambda r) exp(-lambda r) d / (4 pi r^3), a "
                "dipole's (v (1 + lambda r) - (v . d) d (3 + 3 lambda r + lambda^2 r^2) / r^2) "
                "exp(-lambda r) / (4 pi r^3)")
_STOKESLET = "u_i = sum (delta_ij / r + d_i d_j / r^3) f_j / (8 pi mu)"
_STOKES_DU = ("du_i/dy_j = sum ((delta_ij d_k + delta_jk d_i - delta_ik d_j) / r^3 - "
              "3 d_i d_j d_k / r^5) f_k / (8 pi mu)")
_BS = ("u = sum a x d / (4 pi r^3), the curl of a / (4 pi r) (a = (0, 0, 1) at the origin, "
       "target (1, 0, 0): u = (0, 1 / (4 pi), 0))")
_BS_DU = "du_i/dy_j = sum (eps_ilj a_l / r^3 - 3 (a x d)_i d_j / r^5) / (4 pi)"
_CQ = (("q", 1, "complex charge"),)
_CQV = (("q", 1, "complex charge"), ("v", 3, "complex dipole moment"))
_HELM = "phi = sum q G, G = exp(i k r) / (4 pi r)"
_HELM_GRAD = "grad phi = sum q (i k r - 1) G d / r^2"
_HELM_CD = ("phi = sum q G + v . grad_source G = q G - (i k r - 1) G (v . d) / r^2; grad phi: a "
            "charge's q A d, a dipole's -A v - B (v . d) d, A = (i k r - 1) G / r^2, "
            "B = (3 - 3 i k r - k^2 r^2) G / r^4 (the combined field of boundary integral "
            "equations)")

KERNEL_TABLE = (
    Kernel("laplace", "Laplace potential of charges", _Q, (_PHI,),
           "phi = sum q / (4 pi r)", None, -1),
    Kernel("laplace_grad", "Laplace potential of charges and its gradient", _Q, (_PHI, _GRAD),
           "phi = sum q / (4 pi r); " + _LAP_GRAD, None, -1),
    Kernel("laplace_hess", "Laplace potential of charges, its gradient and Hessian", _Q,
           (_PHI, _GRAD, _HESS),
           "phi = sum q / (4 pi r); " + _LAP_GRAD + "; " + _LAP_HESS, None, -1),
    Kernel("laplace_dipole", "Laplace potential of dipoles (the double layer's kernel)", _V,
           (_PHI,), "phi = sum v . d / (4 pi r^3); " + _DIP_SIGN, None, -1),
    Kernel("laplace_dipole_grad", "Laplace potential of dipoles and its gradient", _V,
           (_PHI, _GRAD),
           "phi = sum v . d / (4 pi r^3); grad phi = sum (v - 3 (v . d) d / r^2) / (4 pi r^3); "
           + _DIP_SIGN, None, -1),
    Kernel("laplace_cd", "Laplace potential of charges and dipoles together", _QV, (_PHI,),
           "phi = sum q / (4 pi r) + v . d / (4 pi r^3); " + _DIP_SIGN
           + "; a source of one kind passes 0 for the other", None, -1),
    Kernel("laplace_cd_grad", "Laplace potential of charges and dipoles and its gradient", _QV,
           (_PHI, _GRAD),
           "phi = sum q / (4 pi r) + v . d / (4 pi r^3); a charge's grad phi = -q d / (4 pi r^3), "
           + _DIP_GRAD + "; " + _DIP_SIGN, None, -1),
    Kernel("laplace_cd_hess", "Laplace potential of charges and dipoles, its gradient and Hessian",
           _QV, (_PHI, _GRAD, _HESS),
           "phi = sum q / (4 pi r) + v . d / (4 pi r^3); a charge's grad phi = -q d / (4 pi r^3) "
           "and Hessian q (3 d_i d_j - r^2 delta_ij) / (4 pi r^5); " + _DIP_GRAD + "; "
           + _DIP_HESS + "; " + _DIP_SIGN, None, -1),
    Kernel("yukawa", "screened Coulomb (modified Helmholtz) potential of charges", _Q, (_PHI,),
           _YUK, LAMBDA, None),
    Kernel("yukawa_grad", "screened Coulomb potential of charges and its gradient", _Q,
           (_PHI, _GRAD), _YUK + "; " + _YUK_GRAD, LAMBDA, None),
    Kernel("yukawa_cd", "screened Coulomb potential of charges and dipoles", _QV, (_PHI,),
           _YUK_CD, LAMBDA, None),
    Kernel("yukawa_cd_grad", "screened Coulomb potential of charges and dipoles and its gradient",
           _QV, (_PHI, _GRAD), _YUK_CD + "; " + _YUK_CD_GRAD, LAMBDA, None),
    Kernel("stokes", "Stokeslet: velocity of point forces in Stokes flow", _F, (_U,),
           _STOKESLET, MU, -1),
    Kernel("stokes_grad", "Stokeslet velocity and its gradient", _F, (_U, _DU),
           _STOKESLET + "; " + _STOKES_DU, MU, -1),
    Kernel("stokes_pvel", "Stokeslet pressure and velocity", _F, (("p", 1, "pressure"), _U),
           "p = sum f . d / (4 pi r^3) (independent of mu); " + _STOKESLET, MU, -1),
    Kernel("stokes_dl", "Stokes double layer (stresslet)",
           (("q", 3, "density (times the quadrature weight, for a surface's double layer)"),
            ("n", 3, "unit normal")), (_U,),
           "u_i = sum T_ijk q_j n_k, T_ijk = -3 d_i d_j d_k / (4 pi r^5), independent of the "
           "viscosity (q = n = (0, 0, 1) at the origin, target (0, 0, 1): u = (0, 0, -3 / (4 pi)))",
           None, -1),
    Kernel("biot_savart", "Biot-Savart: velocity of vortex particles", _A, (_U,), _BS, None, -1),
    Kernel("biot_savart_grad", "Biot-Savart velocity and its gradient", _A, (_U, _DU),
           _BS + "; " + _BS_DU, None, -1),
    Kernel("helmholtz", "Helmholtz potential of complex charges", _CQ, (_PHI,), _HELM,
           WAVENUMBER, None, "complex"),
    Kernel("helmholtz_grad", "Helmholtz potential of complex charges and its gradient", _CQ,
           (_PHI, _GRAD), _HELM + "; " + _HELM_GRAD, WAVENUMBER, None, "complex"),
    Kernel("helmholtz_cd_grad", "Helmholtz potential of complex charges and dipoles and its "
           "gradient", _CQV, (_PHI, _GRAD), _HELM_CD, WAVENUMBER, None, "complex"),
)

BY_NAME = {k.name: k for k in KERNEL_TABLE}

COMPLEX = ("Complex kernels (helmholtz): densities and outputs are complex numbers, in C (re, im) "
           "pairs of reals (SRC_DIM and TRG_DIM count reals; the offsets above count complex "
           "values), in Python complex128 or complex64 arrays.")

CONVENTIONS = ("d = y - x, the target y minus the source x, r = |d|; sums over every source "
               "(a source at a target's position adds nothing); derivatives with respect to "
               "the target y.")


def src_dim(k):
    return sum(n for _, n, _ in k.densities)


def trg_dim(k):
    return sum(n for _, n, _ in k.outputs)


def reals(k):
    """reals per value: 2 for a complex kernel, else 1"""
    return 2 if k.value == "complex" else 1


def _layout(items):
    """'[0] q, [1:4] v' style offsets of consecutive groups"""
    out, at = [], 0
    for label, n in items:
        out.append(f"[{at}] {label}" if n == 1 else f"[{at}:{at + n}] {label}")
        at += n
    return out


def _param_text(k):
    p = k.param
    if p is None:
        return "none (kernel_param must be None or zeros)"
    if p.default is None:
        return f"kernel_param = {p.symbol}, {p.meaning}: {p.valid}; needed (no default)"
    return (f"kernel_param = {p.symbol}, {p.meaning}: {p.valid}; None gives the default "
            f"{p.symbol} = {p.default:g} (an explicit 0 is refused)")


def help_text(name):
    """The description of one kernel: densities, outputs with their
    offsets in a row, formula and signs, parameter."""
    k = BY_NAME[name]
    dens = _layout([(f"{s}: {m}", n) for s, n, m in k.densities])
    outs = _layout([(f"{s}: {m}", n) for s, n, m in k.outputs])
    kind = ", complex" if k.value == "complex" else ""
    lines = [f"{k.name}: {k.summary}",
             f"  densities per source ({src_dim(k)}{kind}, a row of the densities array):"]
    lines += [f"    {t}" for t in dens]
    lines.append(f"  outputs per target ({trg_dim(k)}{kind}, a row of evaluate's result):")
    lines += [f"    {t}" for t in outs]
    lines.append(f"  formula: {k.formula}")
    lines.append(f"  ({CONVENTIONS})")
    lines.append(f"  parameter: {_param_text(k)}")
    return "\n".join(lines)


def summary_table():
    """A short table for FMM's docstring: name, numbers of densities and
    outputs, parameter, densities -> outputs."""
    rows = []
    for k in KERNEL_TABLE:
        dens = ", ".join(s if n == 1 else f"{s}({n})" for s, n, _ in k.densities)
        outs = ", ".join(s for s, _, _ in k.outputs)
        prm = k.param.symbol if k.param else "-"
        rows.append(f"    {k.name:<20s} {src_dim(k):>2d} {trg_dim(k):>3d}  {prm:<7s} {dens} -> {outs}")
    head = f"    {'kernel':<20s} {'in':>2s} {'out':>3s}  {'param':<7s} densities -> outputs"
    return "\n".join([head] + rows)


MD_BEGIN = ("<!-- kernels table: generated by python -m kifmm --kernels-md from "
            "python/kifmm/_kernels.py; do not edit -->")
MD_END = "<!-- end of the generated kernels table -->"


def markdown():
    """The section of docs/kernels.md between MD_BEGIN and MD_END, both
    included."""
    def cell(t):
        return t.replace("|", "\\|")

    out = [MD_BEGIN, "",
           "| name | SRC_DIM | TRG_DIM | invariant | param[0] | densities per source | outputs per target |",
           "|---|---|---|---|---|---|---|"]
    for k in KERNEL_TABLE:
        inv = f"yes ({k.degree})" if k.degree is not None else "no"
        if k.param is None:
            prm = "unused"
        elif k.param.default is None:
            prm = f"Re {k.param.symbol} (param[1]: Im {k.param.symbol}): {k.param.valid}"
        else:
            prm = f"{k.param.symbol}: {k.param.valid}, default {k.param.default:g}"
        dens = ", ".join(f"{s} ({n}): {m}" if n > 1 else f"{s}: {m}" for s, n, m in k.densities)
        outs = ", ".join(cell(t) for t in _layout([(s, n) for s, n, _ in k.outputs]))
        out.append(f"| `{k.name}` | {src_dim(k) * reals(k)} | {trg_dim(k) * reals(k)} | {inv} | "
                   f"{cell(prm)} | {cell(dens)} | {outs} |")
    out += ["", CONVENTIONS, "", COMPLEX, ""]
    out += [f"- `{k.name}`: {k.formula}." for k in KERNEL_TABLE]
    out += ["", MD_END]
    return "\n".join(out) + "\n"
