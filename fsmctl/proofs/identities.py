"""Symbolic proofs of the identities the model and the control law rest on.

Each ``verify_*`` function proves one identity with exact SymPy algebra and
returns an :class:`IdentityResult`.  Brute-force ``simplify`` of the full model
takes minutes, so the proofs use structure instead:

* the closed-form inverse ``G^-1 = 16 G^T / (1 + sigma^T sigma)^2`` is proved once
  from the polynomial identity ``16 G G^T = (1 + sigma^T sigma)^2 I``;
* ``d/dt G^-1 = -G^-1 G_dot G^-1`` and ``d/dt R = -omega^x R`` are proved once;
* after that, ``G^-1`` and ``R`` enter the larger identities as *opaque* matrices
  of symbols, which turns them into polynomial identities that ``expand``
  decides in about a second;
* control-law identities are proved for arbitrary ``M``, ``C``, ``E`` (free
  matrices and vectors), which is a stronger statement than for the model's.

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import sympy as sp

from fsmctl.symbolic.controller import (
    SingularityFix,
    closed_loop_acceleration,
    computed_torque_pieces,
    control_law_pieces,
    surface_term,
    surface_term_slope,
)
from fsmctl.symbolic.model import (
    ErrorModel,
    LagrangeModel,
    lagrange_C_as_printed,
    lagrange_model,
    reference_acceleration_in_body,
    reference_rate_in_body,
)
from fsmctl.symbolic.mrp import mrp_G, mrp_G_dot, mrp_G_inverse, mrp_to_dcm, skew
from fsmctl.symbolic.symbols import matrix_symbols, symmetric_matrix_symbols, vector_symbols

__all__ = [
    "IdentityResult",
    "ModelSymbols",
    "model_symbols",
    "verify_G_inverse",
    "verify_G_inverse_derivative",
    "verify_dcm_kinematics",
    "verify_lagrange_form",
    "verify_M_symmetric_positive_definite",
    "verify_closed_loop",
    "verify_computed_torque_form",
    "verify_sigpow_derivative",
    "verify_singularity_fix",
    "lagrange_residual_of_printed_C",
    "all_identities",
]


@dataclass(frozen=True)
class IdentityResult:
    """Outcome of one symbolic proof."""

    id: str
    equations: str
    statement: str
    holds: bool
    method: str
    residual: object = field(default=0, compare=False)
    seconds: float = 0.0


@dataclass(frozen=True)
class ModelSymbols:
    """The free symbols the proofs are stated in."""

    sigma_e: sp.ImmutableMatrix
    sigma_e_dot: sp.ImmutableMatrix
    sigma_e_ddot: sp.ImmutableMatrix
    omega_e: sp.ImmutableMatrix
    omega_d: sp.ImmutableMatrix
    omega_d_dot: sp.ImmutableMatrix
    J: sp.ImmutableMatrix
    G_inverse: sp.ImmutableMatrix
    """Opaque 3x3 stand-in for ``G^-1`` (entries ``Ginv[i,j]``)."""
    R: sp.ImmutableMatrix
    """Opaque 3x3 stand-in for the error DCM ``R(sigma_e)``."""
    s: sp.ImmutableMatrix
    delta: sp.ImmutableMatrix
    coordination: sp.ImmutableMatrix
    c1: sp.Symbol
    c2: sp.Symbol
    alpha: sp.Symbol
    epsilon: sp.Symbol
    boundary_layer: sp.Symbol
    fix_mode: sp.Symbol


def model_symbols() -> ModelSymbols:
    """Fresh free symbols for the proofs (names follow the paper)."""
    return ModelSymbols(
        sigma_e=vector_symbols("sigma_e"),
        sigma_e_dot=vector_symbols("sigma_e_dot"),
        sigma_e_ddot=vector_symbols("sigma_e_ddot"),
        omega_e=vector_symbols("omega_e"),
        omega_d=vector_symbols("omega_d"),
        omega_d_dot=vector_symbols("omega_d_dot"),
        J=symmetric_matrix_symbols("J"),
        G_inverse=matrix_symbols("Ginv"),
        R=matrix_symbols("R"),
        s=vector_symbols("s"),
        delta=sp.ImmutableMatrix([sp.Symbol(f"delta[{k}]", positive=True) for k in range(3)]),
        coordination=vector_symbols("coordination"),
        c1=sp.Symbol("c1", positive=True),
        c2=sp.Symbol("c2", positive=True),
        alpha=sp.Symbol("alpha", positive=True),
        epsilon=sp.Symbol("epsilon", positive=True),
        boundary_layer=sp.Symbol("phi", nonnegative=True),
        fix_mode=sp.Symbol("fix_mode", integer=True),
    )


def _timed(fn: Callable[[], IdentityResult]) -> Callable[[], IdentityResult]:
    def wrapper(*args, **kwargs) -> IdentityResult:
        t0 = time.perf_counter()
        result = fn(*args, **kwargs)
        return IdentityResult(**{**result.__dict__, "seconds": time.perf_counter() - t0})

    wrapper.__name__ = fn.__name__
    wrapper.__doc__ = fn.__doc__
    return wrapper


def _is_zero_polynomial(m: sp.MatrixBase) -> bool:
    return all(sp.expand(x) == 0 for x in m)


def _is_zero_rational(m: sp.MatrixBase) -> bool:
    return all(sp.cancel(sp.together(x)) == 0 for x in m)


def _sq(v):
    return (v.T * v)[0, 0]


@_timed
def verify_G_inverse() -> IdentityResult:
    """``16 G G^T = (1 + sigma^T sigma)^2 I`` and ``det G = (1 + sigma^T sigma)^3 / 64`` (eq 5)."""
    sym = model_symbols()
    sigma = sym.sigma_e
    G = mrp_G(sigma)
    rho = 1 + _sq(sigma)
    orth = 16 * G * G.T - rho**2 * sp.eye(3)
    det = sp.expand(G.det() - rho**3 / 64)
    inv = mrp_G_inverse(sigma) * G - sp.eye(3)
    holds = _is_zero_polynomial(orth) and det == 0 and _is_zero_rational(inv)
    return IdentityResult(
        id="G-inverse",
        equations="5",
        statement="G G^T = ((1+|sigma|^2)/4)^2 I, so G^-1 = 16 G^T/(1+|sigma|^2)^2 and det G = (1+|sigma|^2)^3/64 > 0",
        holds=holds,
        method="polynomial identity (expand)",
        residual=orth,
    )


@_timed
def verify_G_inverse_derivative() -> IdentityResult:
    """``d/dt G^-1(sigma(t)) = -G^-1 G_dot G^-1`` for the closed-form inverse."""
    sym = model_symbols()
    sigma, sigma_dot = sym.sigma_e, sym.sigma_e_dot
    Gi = mrp_G_inverse(sigma)
    # Directional derivative of the closed form along sigma_dot (chain rule).
    dGi = sum((Gi.diff(sigma[k]) * sigma_dot[k] for k in range(3)), sp.zeros(3, 3))
    residual = dGi + Gi * mrp_G_dot(sigma, sigma_dot) * Gi
    return IdentityResult(
        id="G-inverse-derivative",
        equations="9",
        statement="d/dt G^-1 = -G^-1 G_dot G^-1 (used in C of eq 9)",
        holds=_is_zero_rational(residual),
        method="rational identity (cancel)",
        residual=residual,
    )


@_timed
def verify_dcm_kinematics() -> IdentityResult:
    """``d/dt R(sigma) = -omega^x R(sigma)`` when ``sigma_dot = G(sigma) omega``."""
    sym = model_symbols()
    sigma, omega = sym.sigma_e, sym.omega_e
    R = mrp_to_dcm(sigma)
    sigma_dot = mrp_G(sigma) * omega
    dR = sum((R.diff(sigma[k]) * sigma_dot[k] for k in range(3)), sp.zeros(3, 3))
    residual = dR + skew(omega) * R
    return IdentityResult(
        id="dcm-kinematics",
        equations="3, 7",
        statement="with sigma_dot = G(sigma) omega, d/dt R(sigma) = -omega^x R(sigma); hence d/dt(R omega_d) = R omega_d_dot + (R omega_d)^x omega_e",
        holds=_is_zero_rational(residual),
        method="rational identity (cancel)",
        residual=residual,
    )


def _euler_residual(model: LagrangeModel, sym: ModelSymbols, J, error_model: ErrorModel, C=None):
    """``M sigma_ddot + C sigma_dot + G^-T E - G^-T (J omega_dot + omega^x J omega)`` with opaque ``G^-1`` and ``R``."""
    Gi = sym.G_inverse
    sd, sdd = sym.sigma_e_dot, sym.sigma_e_ddot
    Gd = mrp_G_dot(sym.sigma_e, sd)
    omega_e = Gi * sd
    omega_r = reference_rate_in_body(error_model, sym.sigma_e, sym.omega_d, dcm=sym.R)
    omega = omega_e + omega_r
    # d/dt(G^-1 sigma_dot) = -G^-1 G_dot G^-1 sigma_dot + G^-1 sigma_ddot  (verify_G_inverse_derivative)
    omega_e_dot = -Gi * Gd * Gi * sd + Gi * sdd
    omega_r_dot = reference_acceleration_in_body(
        error_model, sym.sigma_e, omega_e, sym.omega_d, sym.omega_d_dot, dcm=sym.R
    )
    euler_torque = J * (omega_e_dot + omega_r_dot) + skew(omega) * J * omega
    C = model.C if C is None else C
    return model.M * sdd + C * sd + Gi.T * model.E - Gi.T * euler_torque


@_timed
def verify_lagrange_form(error_model: str | ErrorModel = ErrorModel.PAPER) -> IdentityResult:
    """Eq 9 with the derived ``M, C, E`` equals ``G^-T`` times Euler's equation (4) under eqs 7-8 (or exact kinematics)."""
    model_kind = ErrorModel.parse(error_model)
    sym = model_symbols()
    J = sym.J
    model = lagrange_model(
        J, sym.sigma_e, sym.sigma_e_dot, sym.omega_d, sym.omega_d_dot, model_kind, G_inverse=sym.G_inverse, dcm=sym.R
    )
    residual = _euler_residual(model, sym, J, model_kind)
    return IdentityResult(
        id=f"lagrange-form-{model_kind.value}",
        equations="4, 7, 8, 9",
        statement=(
            "M sigma_e_ddot + C sigma_e_dot + G^-T E = G^-T (J omega_dot + omega^x J omega) identically, "
            f"for the {model_kind.value} error kinematics"
        ),
        holds=_is_zero_polynomial(residual),
        method="polynomial identity with opaque G^-1 and R (expand)",
        residual=residual,
    )


def lagrange_residual_of_printed_C() -> sp.ImmutableMatrix:
    """``(C_printed - C) sigma_e_dot`` with opaque ``G^-1``: the torque the printed eq 9 gets wrong.

    Equals ``G^-T (J omega_d)^x G^-1 sigma_e_dot = G^-T (J omega_d) x omega_e``.
    """
    sym = model_symbols()
    model = lagrange_model(
        sym.J, sym.sigma_e, sym.sigma_e_dot, sym.omega_d, sym.omega_d_dot, ErrorModel.PAPER, G_inverse=sym.G_inverse
    )
    C_printed = lagrange_C_as_printed(sym.J, sym.sigma_e, sym.sigma_e_dot, sym.omega_d, G_inverse=sym.G_inverse)
    return sp.ImmutableMatrix(((C_printed - model.C) * sym.sigma_e_dot).applyfunc(sp.expand))


@_timed
def verify_M_symmetric_positive_definite() -> IdentityResult:
    """``M = G^-T J G^-1`` is symmetric, and positive definite because ``det G > 0`` (congruence)."""
    sym = model_symbols()
    M = sym.G_inverse.T * sym.J * sym.G_inverse
    x = vector_symbols("x")
    y = sym.G_inverse * x
    symmetric = _is_zero_polynomial(M - M.T)
    congruence = sp.expand((x.T * M * x)[0, 0] - (y.T * sym.J * y)[0, 0]) == 0
    rho = 1 + _sq(sym.sigma_e)
    det_positive = sp.expand(mrp_G(sym.sigma_e).det() - rho**3 / 64) == 0
    return IdentityResult(
        id="M-spd",
        equations="9",
        statement=(
            "M = M^T; x^T M x = (G^-1 x)^T J (G^-1 x) with det G = (1+|sigma_e|^2)^3/64 > 0, so M > 0 whenever J > 0"
        ),
        holds=symmetric and congruence and det_positive,
        method="polynomial identities (expand)",
        residual=M - M.T,
    )


def _free_model(sym: ModelSymbols) -> LagrangeModel:
    """A Lagrange model with free ``M``, ``C``, ``E`` and the true ``G``, ``G^-1``."""
    G = mrp_G(sym.sigma_e)
    return LagrangeModel(
        M=matrix_symbols("M"),
        C=matrix_symbols("C"),
        E=vector_symbols("E"),
        G=G,
        G_inverse=mrp_G_inverse(sym.sigma_e),
        G_dot=mrp_G_dot(sym.sigma_e, sym.sigma_e_dot),
        omega_r=sym.omega_d,
        error_model=ErrorModel.PAPER,
    )


def _opaque(expr_matrix: sp.MatrixBase, prefix: str):
    """Replace non-polynomial atoms (Piecewise, sign, Abs, Min/Max, symbolic powers) by fresh symbols."""
    mapping: dict = {}

    def visit(e):
        if isinstance(e, (sp.Piecewise, sp.sign, sp.Abs, sp.Min, sp.Max)) or (
            isinstance(e, sp.Pow) and not e.exp.is_Integer
        ):
            if e not in mapping:
                mapping[e] = sp.Symbol(f"{prefix}{len(mapping)}")
            return mapping[e]
        if e.args:
            return e.func(*[visit(a) for a in e.args])
        return e

    return expr_matrix.applyfunc(visit), mapping


@_timed
def verify_closed_loop(fix: SingularityFix | str = SingularityFix.SWITCH) -> IdentityResult:
    """Substituting ``u = -u^F - u^D - u^C`` (eqs 16-19) into eq 9 gives eq 20, for any ``M`` (invertible), ``C``, ``E``."""
    sym = model_symbols()
    model = _free_model(sym)
    kwargs = dict(boundary_layer=sym.boundary_layer, fix=fix, epsilon=sym.epsilon)
    pieces = control_law_pieces(
        model, sym.sigma_e, sym.sigma_e_dot, sym.s, sym.c1, sym.c2, sym.alpha, sym.delta, sym.coordination, **kwargs
    )
    lhs = model.M * sym.sigma_e_ddot + model.C * sym.sigma_e_dot + model.G_inverse.T * model.E
    rhs = model.G_inverse.T * pieces.u
    sigma_ddot_20 = closed_loop_acceleration(
        sym.sigma_e, sym.sigma_e_dot, sym.s, sym.c1, sym.c2, sym.alpha, sym.delta, sym.coordination, **kwargs
    )
    residual = (lhs - rhs) - model.M * (sym.sigma_e_ddot - sigma_ddot_20)
    opaque, _ = _opaque(residual, "_nl")
    return IdentityResult(
        id="closed-loop",
        equations="9, 16-20",
        statement="with u = -u^F - u^D - u^C, eq 9 reads M (sigma_e_ddot - f_20) = 0, i.e. eq 20 since M is invertible",
        holds=_is_zero_rational(opaque),
        method="rational identity in free M, C, E (cancel)",
        residual=residual,
    )


@_timed
def verify_computed_torque_form(error_model: str | ErrorModel = ErrorModel.PAPER) -> IdentityResult:
    """The generated (computed-torque) law is eqs 16-19: proved as a chain of cheap identities.

    (i) ``G^T M = J0 G^-1`` for the derived ``M`` (so ``u^D`` and ``u^C`` agree piece by piece);
    (ii) with ``sigma_e_dot = G omega_e`` and ``sigma_e_ddot = G_dot omega_e + G omega_e_dot``, the
    torque that Euler's equation (4) needs to realise the closed loop (20) is exactly the
    generated ``u`` (polynomial identity, opaque ``G^-1``).  The literal law also realises
    eq 20 (:func:`verify_closed_loop`) through eq 9, which equals Euler's equation
    (:func:`verify_lagrange_form`); since ``u -> sigma_e_ddot`` is injective (``J``, ``G``
    invertible), the two laws are the same torque, and so are their ``u^F`` pieces.
    """
    model_kind = ErrorModel.parse(error_model)
    sym = model_symbols()
    J0, sigma_e, omega_e = sym.J, sym.sigma_e, sym.omega_e
    G, Gi = mrp_G(sigma_e), mrp_G_inverse(sigma_e)
    sigma_e_dot = G * omega_e
    model = lagrange_model(J0, sigma_e, sigma_e_dot, sym.omega_d, sym.omega_d_dot, model_kind)
    gtm = G.T * model.M - J0 * Gi
    piece_ok = _is_zero_rational(gtm)
    # (ii) torque realisation with an opaque inverse.
    Go = sym.G_inverse
    kwargs = dict(boundary_layer=sym.boundary_layer, fix=sym.fix_mode, epsilon=sym.epsilon)
    omega_r = reference_rate_in_body(model_kind, sigma_e, sym.omega_d, dcm=sym.R)
    omega_r_dot = reference_acceleration_in_body(model_kind, sigma_e, omega_e, sym.omega_d, sym.omega_d_dot, dcm=sym.R)
    fast = computed_torque_pieces(
        J0,
        sigma_e,
        omega_e,
        omega_r,
        omega_r_dot,
        sym.s,
        sym.c1,
        sym.c2,
        sym.alpha,
        sym.delta,
        sym.coordination,
        G_inverse=Go,
        **kwargs,
    )
    sigma_ddot_20 = closed_loop_acceleration(
        sigma_e, sigma_e_dot, sym.s, sym.c1, sym.c2, sym.alpha, sym.delta, sym.coordination, **kwargs
    )
    Gd = mrp_G_dot(sigma_e, sigma_e_dot)
    omega_e_dot = Go * (sigma_ddot_20 - Gd * omega_e)
    omega = omega_e + omega_r
    u_required = J0 * (omega_r_dot + omega_e_dot) + skew(omega) * J0 * omega
    opaque, _ = _opaque(u_required - fast.u, "_nl")
    realise_ok = _is_zero_polynomial(opaque)
    return IdentityResult(
        id=f"computed-torque-form-{model_kind.value}",
        equations="4, 16-20",
        statement=(
            "G^T M = J0 G^-1, and the generated u = omega^x J0 omega + J0 (omega_r_dot - G^-1 (G_dot omega_e + a)) "
            "is the torque that realises eq 20 through Euler's equation; with closed-loop and lagrange-form "
            f"this equals u = -u^F - u^D - u^C of eqs 16-19 ({model_kind.value} error kinematics)"
        ),
        holds=piece_ok and realise_ok,
        method="rational identity (cancel) + polynomial identity with opaque G^-1 (expand)",
        residual=opaque,
    )


@_timed
def verify_sigpow_derivative() -> IdentityResult:
    """``d/dt sig(x)^alpha = alpha |x|^(alpha-1) x_dot`` on both branches ``x > 0`` and ``x < 0`` (eqs 17, 23)."""
    alpha = sp.Symbol("alpha", positive=True)
    p = sp.Symbol("p", positive=True)
    t = sp.Symbol("t", real=True)
    ok = True
    for sgn in (1, -1):
        xt = sgn * sp.Function("p", positive=True)(t)
        sig = sp.sign(xt) * sp.Abs(xt) ** alpha
        lhs = sp.diff(sig, t)
        rhs = alpha * sp.Abs(xt) ** (alpha - 1) * sp.diff(xt, t)
        ok &= sp.simplify((lhs - rhs).subs(sp.Function("p", positive=True)(t), p)) == 0
    return IdentityResult(
        id="sigpow-derivative",
        equations="1, 13, 17, 23",
        statement="for x != 0, d/dt sig(x)^alpha = alpha |x|^(alpha-1) x_dot, elementwise (the printed alpha sigma^(alpha-1) sigma_dot is not defined for negative components)",
        holds=bool(ok),
        method="differentiation on each sign branch (simplify)",
    )


@_timed
def verify_singularity_fix() -> IdentityResult:
    """The ``switch`` extension matches ``sig(x)^alpha`` in value and slope at ``|x| = epsilon``, and its slope is bounded."""
    alpha = sp.Symbol("alpha", positive=True)
    eps = sp.Symbol("epsilon", positive=True)
    x = sp.Symbol("x", real=True)
    inner = surface_term(x, alpha, SingularityFix.SWITCH, eps).args[1][0]
    outer = sp.sign(x) * sp.Abs(x) ** alpha
    inner_slope = surface_term_slope(x, alpha, SingularityFix.SWITCH, eps).args[1][0]
    ok = True
    for edge in (eps, -eps):
        ok &= sp.simplify(inner.subs(x, edge) - outer.subs(x, edge)) == 0
        ok &= sp.simplify(sp.diff(inner, x).subs(x, edge) - (alpha * sp.Abs(x) ** (alpha - 1)).subs(x, edge)) == 0
    xp = sp.Symbol("xp", positive=True)
    ok &= sp.simplify(sp.diff(inner.subs(x, xp), xp) - inner_slope.subs(x, xp)) == 0
    bound = inner_slope.subs(x, 0)
    return IdentityResult(
        id="singularity-fix",
        equations="Remark 6",
        statement=(
            "inside |x| < epsilon the surface term r1 x + r2 x|x| (r1 = (2-alpha) eps^(alpha-1), r2 = (alpha-1) eps^(alpha-2)) "
            f"is C^1-continuous with sig(x)^alpha and its slope is bounded by {sp.simplify(bound)}"
        ),
        holds=bool(ok),
        method="value and slope matching (simplify)",
    )


def all_identities() -> list[IdentityResult]:
    """Every identity of the model and control law, in dependency order."""
    return [
        verify_G_inverse(),
        verify_G_inverse_derivative(),
        verify_dcm_kinematics(),
        verify_lagrange_form(ErrorModel.PAPER),
        verify_lagrange_form(ErrorModel.EXACT),
        verify_M_symmetric_positive_definite(),
        verify_closed_loop(SingularityFix.NONE),
        verify_computed_torque_form(ErrorModel.PAPER),
        verify_computed_torque_form(ErrorModel.EXACT),
        verify_sigpow_derivative(),
        verify_singularity_fix(),
    ]
