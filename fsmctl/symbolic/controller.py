"""Fast-sliding-mode control law (Liang et al. 2012, eqs 1, 13-20, Remarks 6-7).

The paper's law is kept in two equivalent forms:

* :func:`control_law_pieces` builds ``u^F``, ``u^D``, ``u^C`` (eqs 17-19) literally
  from ``M``, ``C``, ``E`` of the Lagrange-like model, and ``u = -u^F - u^D - u^C`` (eq 16);
* :func:`computed_torque_control` is the same torque written without ``M`` and ``C``
  (``u = omega^x J0 omega + J0 (omega_r_dot - G^-1 (G_dot omega_e + a))``), which is what
  the code generator emits because it costs a fraction of the flops.
  :func:`fsmctl.proofs.identities.verify_computed_torque_form` proves the two equal.

Two numerical devices the paper only mentions are made explicit and selectable:

* Remark 6 (``alpha |sigma_e|^(alpha-1)`` is singular at ``sigma_e = 0`` off the
  surface): :class:`SingularityFix`.  ``switch`` (default) replaces ``sig(x)^alpha``
  inside ``|x| < epsilon`` by the C^1 extension ``r1 x + r2 x|x|`` so the surface
  stays differentiable and its derivative bounded; ``clamp`` keeps the surface and
  bounds the gain by ``alpha max(|x|, epsilon)^(alpha-1)``; ``none`` is the law as
  printed.
* Remark 7 (chattering): ``sgn(s)`` or the saturation ``sat(s/phi)`` with boundary
  layer ``phi > 0``.

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import sympy as sp

from fsmctl.symbolic.model import LagrangeModel
from fsmctl.symbolic.mrp import mrp_G, mrp_G_dot, mrp_G_inverse, skew
from fsmctl.symbolic.symbols import DerivationInputError, as_matrix3, as_scalar, as_vector3, check_alpha

__all__ = [
    "SingularityFix",
    "sigpow",
    "surface_term",
    "surface_term_slope",
    "sliding_variable",
    "switching_function",
    "coordination_term",
    "ControlLawPieces",
    "control_law_pieces",
    "computed_torque_control",
    "computed_torque_pieces",
    "closed_loop_acceleration",
    "saturate",
    "scalar_sliding_mode",
    "share_fractional_powers",
]


class SingularityFix(IntEnum):
    """Treatment of the ``alpha |sigma_e|^(alpha-1)`` term of eq 17 (Remark 6).

    The integer values are what the generated code receives in ``gains[5]``.  ``SWITCH`` replaces
    ``sig(x)^alpha`` inside ``|x| < epsilon`` by a C^1 polynomial, ``CLAMP`` bounds the gain by
    ``alpha max(|x|, epsilon)^(alpha-1)``, ``NONE`` is the law as printed.

    Examples
    --------
    >>> from fsmctl.symbolic.controller import SingularityFix
    >>> SingularityFix.parse("clamp"), int(SingularityFix.SWITCH)
    (<SingularityFix.CLAMP: 2>, 1)
    """

    NONE = 0
    SWITCH = 1
    CLAMP = 2

    @classmethod
    def parse(cls, value) -> SingularityFix:
        """The member for ``value``: a member, its integer value or its name (any case).

        Parameters
        ----------
        value : SingularityFix, int or str
            What to parse (``"none"``, ``"switch"``, ``"clamp"``, 0, 1, 2).

        Returns
        -------
        SingularityFix
            The member.

        Raises
        ------
        fsmctl.symbolic.symbols.DerivationInputError
            ``value`` names no fix.
        """
        if isinstance(value, cls):
            return value
        if isinstance(value, int) and not isinstance(value, bool) and value in cls._value2member_map_:
            return cls(value)
        if isinstance(value, str):
            try:
                return cls[value.upper()]
            except KeyError:
                pass
        raise DerivationInputError(f"singularity fix must be one of {[m.name.lower() for m in cls]}, got {value!r}")


def sigpow(v, a) -> sp.ImmutableMatrix:
    """``sig(v)^a = [sgn(v_1)|v_1|^a, ...]^T`` (eq 1), elementwise."""
    v = sp.ImmutableMatrix(v) if isinstance(v, sp.MatrixBase) else sp.ImmutableMatrix([v])
    a = as_scalar(a, "a")
    return sp.ImmutableMatrix(v.applyfunc(lambda x: sp.sign(x) * sp.Abs(x) ** a))


def _clip(x, bound):
    """``min(bound, max(-bound, x))``, built unevaluated (SymPy's Min/Max simplification is slow and not needed)."""
    return sp.Min(bound, sp.Max(-bound, x, evaluate=False), evaluate=False)


def _switch_coefficients(alpha, epsilon):
    r1 = (2 - alpha) * epsilon ** (alpha - 1)
    r2 = (alpha - 1) * epsilon ** (alpha - 2)
    return r1, r2


def _fix_branches(fix):
    """Either one fix (an enum) or a symbol selecting among all three at run time."""
    if isinstance(fix, sp.Basic) and not fix.is_number:
        return None
    return SingularityFix.parse(fix if not isinstance(fix, sp.Basic) else int(fix))


def surface_term(x, alpha, fix=SingularityFix.SWITCH, epsilon=sp.Rational(1, 10**4)) -> sp.Expr:
    """Scalar terminal term ``phi(x)`` of the surface: ``sig(x)^alpha`` or its Remark 6 variant.

    With ``fix = switch``, for ``|x| < epsilon`` it is ``r1 x + r2 x|x|`` with
    ``r1 = (2-alpha) epsilon^(alpha-1)``, ``r2 = (alpha-1) epsilon^(alpha-2)``,
    which matches ``sig(x)^alpha`` in value and slope at ``|x| = epsilon``.
    ``fix`` may be a SymPy symbol taking the :class:`SingularityFix` values, in
    which case the result is a ``Piecewise`` over all three.
    """
    x = as_scalar(x, "x")
    alpha = as_scalar(alpha, "alpha")
    eps = as_scalar(epsilon, "epsilon")
    raw = sp.sign(x) * sp.Abs(x) ** alpha
    r1, r2 = _switch_coefficients(alpha, eps)
    switched = sp.Piecewise((raw, sp.Abs(x) >= eps), (r1 * x + r2 * x * sp.Abs(x), True))
    chosen = _fix_branches(fix)
    if chosen is None:
        return sp.Piecewise((switched, sp.Eq(fix, int(SingularityFix.SWITCH))), (raw, True))
    return switched if chosen is SingularityFix.SWITCH else raw


def surface_term_slope(x, alpha, fix=SingularityFix.SWITCH, epsilon=sp.Rational(1, 10**4)) -> sp.Expr:
    """The gain multiplying ``x_dot`` in eq 17: ``alpha |x|^(alpha-1)`` or its Remark 6 variant.

    ``switch``: the exact derivative of :func:`surface_term` (``r1 + 2 r2 |x|`` inside
    the band); ``clamp``: ``alpha max(|x|, epsilon)^(alpha-1)``; ``none``: as printed.
    """
    x = as_scalar(x, "x")
    alpha = as_scalar(alpha, "alpha")
    eps = as_scalar(epsilon, "epsilon")
    raw = alpha * sp.Abs(x) ** (alpha - 1)
    r1, r2 = _switch_coefficients(alpha, eps)
    switched = sp.Piecewise((raw, sp.Abs(x) >= eps), (r1 + 2 * r2 * sp.Abs(x), True))
    # alpha max(|x|, eps)^(alpha-1), written as a Piecewise so it shares the powers above
    clamped = sp.Piecewise((raw, sp.Abs(x) >= eps), (alpha * eps ** (alpha - 1), True))
    chosen = _fix_branches(fix)
    if chosen is None:
        return sp.Piecewise(
            (switched, sp.Eq(fix, int(SingularityFix.SWITCH))),
            (clamped, sp.Eq(fix, int(SingularityFix.CLAMP))),
            (raw, True),
        )
    return {SingularityFix.NONE: raw, SingularityFix.SWITCH: switched, SingularityFix.CLAMP: clamped}[chosen]


def _check_gains(c1, c2, alpha):
    c1 = as_scalar(c1, "c1")
    c2 = as_scalar(c2, "c2")
    for name, c in (("c1", c1), ("c2", c2)):
        if c.is_number and c < 0:
            raise DerivationInputError(f"{name} must be non-negative (positive for the fast sliding surface), got {c}")
    return c1, c2, check_alpha(alpha) if alpha is not None else None


def sliding_variable(
    sigma_e, sigma_e_dot, c1, c2, alpha, fix=SingularityFix.SWITCH, epsilon=sp.Rational(1, 10**4)
) -> sp.ImmutableMatrix:
    """Fast sliding surface ``s = sigma_e_dot + c1 sigma_e + c2 sig(sigma_e)^alpha`` (Liang et al. 2012, eq 13).

    ``c2 = 0`` gives the linear surface (LSM) and ``c1 = 0`` the terminal one (TSM)
    of Section 3.3.

    Parameters
    ----------
    sigma_e, sigma_e_dot : sequence or Matrix
        The attitude error (MRP) and its time derivative.
    c1, c2 : number or Expr
        The surface gains (``>= 0``).
    alpha : number or Expr
        The exponent, ``0.5 < alpha < 1`` (eq 13).
    fix : SingularityFix or str
        Remark 6's treatment of ``sig(x)^alpha`` near ``x = 0`` (default ``switch``).
    epsilon : number or Expr
        Half-width of the band the fix acts in.

    Returns
    -------
    sympy.ImmutableMatrix
        ``s`` (3 components, 1/s).

    Raises
    ------
    fsmctl.symbolic.symbols.DerivationInputError
        A negative gain, ``alpha`` outside ``(0.5, 1)``, malformed vectors.

    Examples
    --------
    ``(1/16)^(3/4) = 1/8``, so at rest with ``c1 = c2 = 1``:

    >>> import sympy as sp
    >>> from fsmctl.symbolic import sliding_variable, vector_symbols
    >>> sliding_variable([sp.Rational(1, 16), -sp.Rational(1, 16), 0], [0, 0, 0], 1, 1, sp.Rational(3, 4)).T
    Matrix([[3/16, -3/16, 0]])

    The linear surface (LSM, ``c2 = 0``):

    >>> x, x_dot = vector_symbols("x"), vector_symbols("x_dot")
    >>> sliding_variable(x, x_dot, sp.Symbol("c1"), 0, sp.Rational(3, 4)).T
    Matrix([[c1*x[0] + x_dot[0], c1*x[1] + x_dot[1], c1*x[2] + x_dot[2]]])
    """
    sigma_e = as_vector3(sigma_e, "sigma_e")
    sigma_e_dot = as_vector3(sigma_e_dot, "sigma_e_dot")
    c1, c2, alpha = _check_gains(c1, c2, alpha)
    phi = sp.ImmutableMatrix([surface_term(x, alpha, fix, epsilon) for x in sigma_e])
    return sp.ImmutableMatrix(sigma_e_dot + c1 * sigma_e + c2 * phi)


def switching_function(s, boundary_layer=0) -> sp.ImmutableMatrix:
    """``sgn(s)`` (eq 18) or, for a boundary layer ``phi > 0``, ``sat(s/phi)`` (Remark 7), elementwise.

    ``boundary_layer`` may be a symbol; then the result is a ``Piecewise`` that is
    ``sgn`` at ``phi = 0``.
    """
    s = as_vector3(s, "s")
    phi = as_scalar(boundary_layer, "boundary_layer")
    if phi.is_number:
        if phi < 0:
            raise DerivationInputError(f"boundary layer must be >= 0, got {phi}")
        if phi == 0:
            return sp.ImmutableMatrix(s.applyfunc(sp.sign))
        return sp.ImmutableMatrix(s.applyfunc(lambda x: _clip(x / phi, 1)))
    return sp.ImmutableMatrix(
        s.applyfunc(lambda x: sp.Piecewise((sp.sign(x), sp.Eq(phi, 0)), (_clip(x / phi, 1), True)))
    )


def coordination_term(s_i, k_i_sum, received) -> sp.ImmutableMatrix:
    """``sum_j (k^i_ij s_i - k^j_ij s_j) = (sum_j k^i_ij) s_i - sum_j k^j_ij s_j`` (eq 19).

    ``received = sum_j k^j_ij s_j`` is what agent i gets from its neighbours.
    """
    return sp.ImmutableMatrix(as_scalar(k_i_sum, "k_i_sum") * as_vector3(s_i, "s_i") - as_vector3(received, "received"))


@dataclass(frozen=True)
class ControlLawPieces:
    """The three pieces of eq 16 and their sum ``u = -u_F - u_D - u_C``."""

    u_F: sp.ImmutableMatrix
    u_D: sp.ImmutableMatrix
    u_C: sp.ImmutableMatrix

    @property
    def u(self) -> sp.ImmutableMatrix:
        return sp.ImmutableMatrix(-self.u_F - self.u_D - self.u_C)


def _rate_terms(sigma_e, sigma_e_dot, c1, c2, alpha, fix, epsilon):
    """``c1 sigma_e_dot + c2 alpha|sigma_e|^(alpha-1) o sigma_e_dot`` (the bracket of eqs 17, 20)."""
    slope = sp.ImmutableMatrix([surface_term_slope(x, alpha, fix, epsilon) for x in sigma_e])
    return sp.ImmutableMatrix(c1 * sigma_e_dot + c2 * sp.matrix_multiply_elementwise(slope, sigma_e_dot))


def control_law_pieces(
    model: LagrangeModel,
    sigma_e,
    sigma_e_dot,
    s,
    c1,
    c2,
    alpha,
    delta,
    coordination,
    *,
    boundary_layer=0,
    fix=SingularityFix.SWITCH,
    epsilon=sp.Rational(1, 10**4),
) -> ControlLawPieces:
    """``u^F``, ``u^D``, ``u^C`` exactly as Liang et al. 2012, eqs 17-19, build them from ``M``, ``C``, ``E``.

    ``u^F = -(G^T C sigma_e_dot + E) + G^T M (c1 sigma_e_dot + c2 alpha |sigma_e|^(alpha-1) o sigma_e_dot)`` (17),
    ``u^D = G^T M diag(delta) sgn(s)`` (18), ``u^C = G^T M coordination`` (19); ``u = -u^F - u^D - u^C``
    (eq 16) is the result's ``.u``.

    Parameters
    ----------
    model : LagrangeModel
        From :func:`lagrange_model` (eq 9) at the same ``sigma_e``, ``sigma_e_dot``.
    sigma_e, sigma_e_dot : sequence or Matrix
        The attitude error and its derivative.
    s : sequence or Matrix
        The sliding variable (:func:`sliding_variable`, eq 13).
    c1, c2, alpha : number or Expr
        The surface's gains and exponent.
    delta : sequence or Matrix
        The switching gains ``delta_i`` (eq 18), each ``> 0``.
    coordination : sequence or Matrix
        ``sum_j (k^i_ij s_i - k^j_ij s_j)`` (eq 19).
    boundary_layer : number or Expr
        0 for ``sgn(s)``; ``phi > 0`` for ``sat(s/phi)`` (Remark 7).
    fix : SingularityFix or str
        Remark 6's treatment of the singular term.
    epsilon : number or Expr
        Half-width of the band the fix acts in.

    Returns
    -------
    ControlLawPieces
        ``u_F``, ``u_D``, ``u_C`` and their combination ``u`` (N m).

    Raises
    ------
    fsmctl.symbolic.symbols.DerivationInputError
        A non-positive ``delta``, a negative gain, a bad ``alpha`` or malformed vectors.

    Examples
    --------
    The torque makes the model (eq 9) follow the closed loop (eq 20), checked at an exact point:

    >>> import sympy as sp
    >>> from fsmctl.symbolic import closed_loop_acceleration, control_law_pieces, lagrange_model, sliding_variable
    >>> R = sp.Rational
    >>> J = sp.Matrix([[100, 1, 2], [1, 150, 1], [2, 1, 200]])
    >>> se, sed = [R(1, 10), R(1, 5), R(-1, 10)], [R(1, 100), 0, R(-1, 50)]
    >>> m = lagrange_model(J, se, sed, [0, 0, R(1, 100)], [0, 0, 0])
    >>> c1, c2, alpha, delta, coord = 1, R(1, 2), R(3, 4), [R(1, 10)] * 3, [R(1, 10), 0, 0]
    >>> s = sliding_variable(se, sed, c1, c2, alpha)
    >>> u = control_law_pieces(m, se, sed, s, c1, c2, alpha, delta, coord).u
    >>> acc = closed_loop_acceleration(se, sed, s, c1, c2, alpha, delta, coord)
    >>> residual = m.M * acc + m.C * sp.Matrix(sed) + m.G_inverse.T * (m.E - u)
    >>> max(abs(r) for r in residual.evalf(30)) < 1e-25
    True
    """
    sigma_e = as_vector3(sigma_e, "sigma_e")
    sigma_e_dot = as_vector3(sigma_e_dot, "sigma_e_dot")
    c1, c2, alpha = _check_gains(c1, c2, alpha)
    delta = as_vector3(delta, "delta")
    for k, dk in enumerate(delta):
        if dk.is_number and dk <= 0:
            raise DerivationInputError(f"delta[{k}] must be positive (eq 18), got {dk}")
    GtM = model.G.T * model.M
    u_F = -(model.G.T * model.C * sigma_e_dot + model.E) + GtM * _rate_terms(
        sigma_e, sigma_e_dot, c1, c2, alpha, fix, epsilon
    )
    u_D = GtM * sp.matrix_multiply_elementwise(delta, switching_function(s, boundary_layer))
    u_C = GtM * as_vector3(coordination, "coordination")
    return ControlLawPieces(sp.ImmutableMatrix(u_F), sp.ImmutableMatrix(u_D), sp.ImmutableMatrix(u_C))


def computed_torque_pieces(
    J0,
    sigma_e,
    omega_e,
    omega_r,
    omega_r_dot,
    s,
    c1,
    c2,
    alpha,
    delta,
    coordination,
    *,
    boundary_layer=0,
    fix=SingularityFix.SWITCH,
    epsilon=sp.Rational(1, 10**4),
    G_inverse=None,
) -> ControlLawPieces:
    """The pieces of eq 16 without ``M`` and ``C``, using ``G^T M = J0 G^-1`` and ``sigma_e_dot = G omega_e``.

    ``u^D = J0 G^-1 (delta o sgn(s))``, ``u^C = J0 G^-1 coordination``,
    ``u^F = -omega^x J0 omega - J0 (omega_r_dot - G^-1 (G_dot omega_e + c1 sigma_e_dot + c2 alpha|sigma_e|^(alpha-1) o sigma_e_dot))``
    with ``omega = omega_e + omega_r`` and ``omega_r_dot`` the body-frame derivative
    of the reference rate (:func:`fsmctl.symbolic.model.reference_acceleration_in_body`).
    ``G_inverse`` may be an opaque matrix in proofs.
    """
    J0 = as_matrix3(J0, "J0")
    sigma_e = as_vector3(sigma_e, "sigma_e")
    omega_e = as_vector3(omega_e, "omega_e")
    omega_r = as_vector3(omega_r, "omega_r")
    c1, c2, alpha = _check_gains(c1, c2, alpha)
    G = mrp_G(sigma_e)
    Gi = mrp_G_inverse(sigma_e) if G_inverse is None else sp.ImmutableMatrix(G_inverse)
    sigma_e_dot = G * omega_e
    Gd = mrp_G_dot(sigma_e, sigma_e_dot)
    omega = omega_e + omega_r
    J0Gi = J0 * Gi
    u_F = (
        -skew(omega) * J0 * omega
        - J0 * as_vector3(omega_r_dot, "omega_r_dot")
        + J0Gi * (Gd * omega_e + _rate_terms(sigma_e, sigma_e_dot, c1, c2, alpha, fix, epsilon))
    )
    u_D = J0Gi * sp.matrix_multiply_elementwise(as_vector3(delta, "delta"), switching_function(s, boundary_layer))
    u_C = J0Gi * as_vector3(coordination, "coordination")
    return ControlLawPieces(sp.ImmutableMatrix(u_F), sp.ImmutableMatrix(u_D), sp.ImmutableMatrix(u_C))


def computed_torque_control(*args, **kwargs) -> sp.ImmutableMatrix:
    """``u = -u^F - u^D - u^C`` from :func:`computed_torque_pieces` (same arguments)."""
    return computed_torque_pieces(*args, **kwargs).u


def closed_loop_acceleration(
    sigma_e,
    sigma_e_dot,
    s,
    c1,
    c2,
    alpha,
    delta,
    coordination,
    *,
    boundary_layer=0,
    fix=SingularityFix.SWITCH,
    epsilon=sp.Rational(1, 10**4),
) -> sp.ImmutableMatrix:
    """Closed loop (Liang et al. 2012, eq 20): the error acceleration the law (eqs 16-19) imposes.

    ``sigma_e_ddot = -(c1 sigma_e_dot + c2 alpha|sigma_e|^(alpha-1) o sigma_e_dot) - delta o sgn(s) - coordination``.

    Parameters
    ----------
    sigma_e, sigma_e_dot : sequence or Matrix
        The attitude error and its derivative.
    s : sequence or Matrix
        The sliding variable (eq 13).
    c1, c2, alpha : number or Expr
        The surface's gains and exponent.
    delta : sequence or Matrix
        The switching gains (eq 18).
    coordination : sequence or Matrix
        ``sum_j (k^i_ij s_i - k^j_ij s_j)`` (eq 19).
    boundary_layer : number or Expr
        0 for ``sgn(s)``; ``phi > 0`` for ``sat(s/phi)`` (Remark 7).
    fix : SingularityFix or str
        Remark 6's treatment of the singular term.
    epsilon : number or Expr
        Half-width of the band the fix acts in.

    Returns
    -------
    sympy.ImmutableMatrix
        ``sigma_e_ddot`` (3 components, 1/s^2).

    Examples
    --------
    At ``sigma_e = 0``, at rest, only the switching and coordination terms act:

    >>> import sympy as sp
    >>> from fsmctl.symbolic import closed_loop_acceleration
    >>> s = sp.Matrix([1, -1, 0])
    >>> closed_loop_acceleration([0, 0, 0], [0, 0, 0], s, 1, 1, sp.Rational(3, 4), [2, 2, 2], [0, 0, 1]).T
    Matrix([[-2, 2, -1]])

    :func:`control_law_pieces` shows that the law's torque produces it in the model of eq 9.
    """
    sigma_e = as_vector3(sigma_e, "sigma_e")
    sigma_e_dot = as_vector3(sigma_e_dot, "sigma_e_dot")
    c1, c2, alpha = _check_gains(c1, c2, alpha)
    return sp.ImmutableMatrix(
        -_rate_terms(sigma_e, sigma_e_dot, c1, c2, alpha, fix, epsilon)
        - sp.matrix_multiply_elementwise(as_vector3(delta, "delta"), switching_function(s, boundary_layer))
        - as_vector3(coordination, "coordination")
    )


def saturate(u, u_max) -> sp.ImmutableMatrix:
    """Per-component torque saturation ``min(max(u_k, -u_max), u_max)`` (the ideal actuator's limit).

    Built unevaluated (fast for large expressions); ``.doit()`` evaluates numbers.

    Parameters
    ----------
    u : sequence or Matrix
        The commanded torque (3 components, N m).
    u_max : number or Expr
        The per-axis limit (N m), positive.

    Returns
    -------
    sympy.ImmutableMatrix
        The applied torque.

    Raises
    ------
    fsmctl.symbolic.symbols.DerivationInputError
        A numeric ``u_max <= 0``.

    Examples
    --------
    >>> from fsmctl.symbolic import saturate
    >>> saturate([3, -1, -5], 2).doit().T
    Matrix([[2, -1, -2]])
    """
    u = as_vector3(u, "u")
    u_max = as_scalar(u_max, "u_max")
    if u_max.is_number and u_max <= 0:
        raise DerivationInputError(f"torque limit must be positive, got {u_max}")
    return sp.ImmutableMatrix(u.applyfunc(lambda x: _clip(x, u_max)))


def scalar_sliding_mode(x, c1, c2, alpha) -> sp.Expr:
    """Scalar sliding mode of Section 3.3: ``x_dot = -c1 x - c2 sig(x)^alpha``.

    FSM for ``c1, c2 > 0``; TSM for ``c1 = 0``; LSM for ``c2 = 0``.
    """
    x = as_scalar(x, "x")
    c1, c2, alpha = _check_gains(c1, c2, alpha)
    return -c1 * x - c2 * sp.sign(x) * sp.Abs(x) ** alpha


def share_fractional_powers(exprs, sigma_e, alpha, epsilon, p, q):
    """Rewrite the fractional powers of eq 13/17 in terms of precomputed ones (fewer ``pow`` calls).

    ``|x_k|^alpha -> p_k``, ``|x_k|^(alpha-1) -> p_k/|x_k|``, ``epsilon^(alpha-1) -> q``,
    ``epsilon^(alpha-2) -> q/epsilon``: equal wherever the original is finite.
    """
    rep = {}
    for k in range(3):
        ax = sp.Abs(sigma_e[k])
        rep[ax**alpha] = p[k]
        rep[ax ** (alpha - 1)] = p[k] / ax
    rep[epsilon ** (alpha - 1)] = q
    rep[epsilon ** (alpha - 2)] = q / epsilon
    return sp.ImmutableMatrix(exprs).xreplace(rep)
