"""The closed loop as exact polynomials: the model of the sum-of-squares route of ``fsmctl certify``.

The route (:mod:`fsmctl.proofs.certify_sos`) needs ``V_dot`` as a polynomial in the state and in the uncertain
inputs, each in a symmetric box.  With the reference at rest (``omega = omega_e``), no torque limit and a law whose
reduced torque (:func:`fsmctl.proofs.certify_symbolic.reduced_torque`) is a polynomial, eqs 3-4 with eq 29's
``J omega_dot = -omega^x J omega + u + d`` (:func:`fsmctl.symbolic.model.plant_rhs`, every float taken as its exact
rational) give that polynomial for the inertia sets of :class:`fsmctl.proofs.certify_problem.Uncertainty`:

- **nominal** (``J = J0``): the inputs are ``d[k]``, ``|d_k| <= D_k``.
- **proportional** (``J = (1 + theta) J0``, ``|theta| <= a``): ``omega_dot = J0^-1 (r (u + d) - omega^x J0 omega)``
  exactly, with ``r = 1 / (1 + theta)`` in ``[1/(1+a), 1/(1-a)]``.  The input ``q[0] = r - r_m`` is centred:
  ``r_m = 1/(1 - a^2)``, ``|q| <= a/(1 - a^2)``.
- **entries with a diagonal J0** (``J_kk = J0_kk (1 + theta_k)``): ``omega_dot_k = r_k [J0^-1 (u + d' - omega^x J0
  omega)]_k`` exactly, with ``r_k = 1/(1 + theta_k)`` (inputs ``q[k]`` as above) and ``d' = d - omega^x dJ omega``,
  ``dJ = J - J0``.  The gyroscopic error ``(omega^x dJ omega)_k = omega_i omega_j (dJ_jj - dJ_ii)`` (``i, j`` the
  other two axes) is bounded on the region by ``E_k = a W_i W_j (J0_ii + J0_jj)`` (``W`` the region's ``omega_e``
  half-widths), so ``d'`` is a disturbance with ``|d'_k| <= D_k + E_k``: an over-approximation (every true
  trajectory is one of the widened model's; the certificate is sound, possibly conservative).

Each box half-width is rounded up to a float (a larger box only weakens the certified statement).  An inertia set
with a non-diagonal ``J0`` and independent entries gives a rational ``J^-1`` (not handled: the branch and bound
answers those questions).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
import sympy as sp

from fsmctl.proofs.certify_sos import exact_polynomial
from fsmctl.proofs.certify_symbolic import ReducedTorque, state_symbols
from fsmctl.symbolic.law import Law
from fsmctl.symbolic.model import plant_rhs

__all__ = ["PolynomialLoop", "disturbance_symbols", "inertia_factor_symbols", "polynomial_loop"]


def disturbance_symbols() -> sp.Matrix:
    """The SymPy column ``d[0:3]`` (N m) of :attr:`PolynomialLoop.field`."""
    return sp.Matrix(sp.symbols("d[0:3]", real=True))


def inertia_factor_symbols(n: int) -> sp.Matrix:
    """The SymPy column ``q[0:n]``: ``1/(1 + theta_k)`` minus its midpoint (see the module docstring)."""
    return sp.Matrix(sp.symbols(f"q[0:{n}]", real=True)) if n else sp.zeros(0, 1)


def _float_up(x: Fraction) -> float:
    f = float(x)
    return f if Fraction(f) >= x else math.nextafter(f, math.inf)


@dataclass(frozen=True)
class PolynomialLoop:
    """The closed loop ``(sigma_e_dot, omega_e_dot, z_dot)`` as exact SymPy polynomials (see the module docstring).

    Examples
    --------
    >>> import numpy as np
    >>> from fsmctl.proofs.certify_polynomial import PolynomialLoop
    >>> loop = PolynomialLoop(None, ("d[0]", "d[1]", "d[2]", "q[0]"), (0.2, 0.2, 0.2, 0.1 / 0.99), "",
    ...                       np.diag([20.0, 25.0, 30.0]), "proportional", 0.1)
    >>> loop.inputs_at(np.zeros(3), np.array([0.1]), np.array([0.2, 0.0, 0.0]))[3].round(6)  # 1/1.1 - 1/0.99
    -0.10101
    """

    field: sp.ImmutableMatrix
    """``(sigma_e_dot, omega_e_dot, z_dot)`` in the state symbols and :attr:`inputs`"""
    inputs: tuple[str, ...]
    """the uncertain inputs' names: ``d[0..2]`` (N m; ``d'`` with the gyroscopic error for the entries set), then
    ``q[k]`` (one per uncertain inertia factor)"""
    half_widths: tuple[float, ...]
    """``|input| <= half_width``, each rounded up to a float"""
    how: str
    """one line: the model and what it over-approximates"""
    J0: np.ndarray
    inertia_set: str
    inertia: float

    def symbols(self) -> list[sp.Symbol]:
        """The SymPy symbols of :attr:`inputs`, in order."""
        n_q = len(self.inputs) - 3
        return [*disturbance_symbols(), *inertia_factor_symbols(n_q)]

    def inputs_at(self, omega_e: np.ndarray, theta: np.ndarray, d: np.ndarray) -> np.ndarray:
        """The values of :attr:`inputs` that reproduce the true loop at a point (the reference at rest).

        Parameters
        ----------
        omega_e : numpy.ndarray
            ``(3,)``, rad/s.
        theta : numpy.ndarray
            The relative inertia errors (none for the nominal inertia).
        d : numpy.ndarray
            ``(3,)``, N m.

        Returns
        -------
        numpy.ndarray
            ``d`` (or ``d'``), then ``q``.
        """
        a = self.inertia
        n_q = len(self.inputs) - 3
        if n_q == 0:
            return np.asarray(d, float)
        r_m = 1.0 / (1.0 - a * a)
        q = 1.0 / (1.0 + np.asarray(theta, float)[:n_q]) - r_m
        if self.inertia_set == "proportional":
            return np.concatenate([d, q])
        dJ = np.diag(np.diag(self.J0) * np.asarray(theta, float))
        return np.concatenate([np.asarray(d, float) - np.cross(omega_e, dJ @ omega_e), q])


def _inertia_factors(J0: np.ndarray, inertia: float, inertia_set: str) -> tuple[int, str] | str:
    """``(number of factors q, the set's words)`` or why the loop is not polynomial."""
    if inertia == 0:
        return 0, "the nominal inertia"
    a = f"{inertia:g}"
    if inertia_set == "proportional":
        return 1, (
            f"J = (1 + theta) J0, |theta| <= a = {a}, exactly: the factor 1/(1 + theta) enters as the variable "
            "q = 1/(1 + theta) - 1/(1 - a^2), |q| <= a/(1 - a^2)"
        )
    if np.count_nonzero(J0 - np.diag(np.diag(J0))):
        return "the inertia's entries vary independently around a non-diagonal J0 (J^-1 is rational in theta)"
    return 3, (
        f"J_kk = J0_kk (1 + theta_k), |theta_k| <= a = {a}, exactly: the factors 1/(1 + theta_k) enter as the "
        "variables q_k = 1/(1 + theta_k) - 1/(1 - a^2), |q_k| <= a/(1 - a^2)"
    )


def polynomial_loop(
    law: Law,
    reduced: ReducedTorque | None,
    J0: np.ndarray,
    omega_half_widths: Sequence[float],
    *,
    inertia: float,
    inertia_set: str,
    disturbance: Sequence[float],
    reference_at_rest: bool,
    torque_limit: float,
) -> PolynomialLoop | str:
    """The closed loop as exact polynomials (see the module docstring), or why it is not one here.

    Parameters
    ----------
    law : fsmctl.symbolic.law.Law
        The law's symbols.
    reduced : ReducedTorque or None
        Its torque at ``sigma_d = 0`` (``sigma_e = sigma``); None when it could not be reduced.
    J0 : numpy.ndarray
        3x3, kg m^2.
    omega_half_widths : sequence of float
        The region's ``|omega_e,k|`` bounds, rad/s (for the gyroscopic error's bound).
    inertia : float
        The relative inertia bound ``a``.
    inertia_set : str
        ``"entries"`` or ``"proportional"``.
    disturbance : sequence of float
        ``D_k``, N m.
    reference_at_rest : bool
        Whether ``omega_d = omega_d_dot = 0``.
    torque_limit : float
        Must be infinite.

    Returns
    -------
    PolynomialLoop or str
        The reason (one condition) when the loop is not polynomial.
    """
    if not reference_at_rest:
        return "the reference moves"
    if math.isfinite(torque_limit):
        return "the torque is limited (a saturation)"
    if reduced is None:
        return "the law's torque could not be reduced symbolically"
    J0 = np.asarray(J0, dtype=float)
    factors = _inertia_factors(J0, inertia, inertia_set)
    if isinstance(factors, str):
        return factors
    n_q, words = factors
    s, w, z = state_symbols(law.n_states)
    sym = law.symbols
    rep = dict(zip(list(sym["sigma"]), list(s), strict=True))
    rep.update(zip(list(sym["omega"]), list(w), strict=True))
    rep.update(zip(list(sym["z"]), list(z), strict=True))

    def rational(e: sp.Expr) -> sp.Expr:
        e = sp.sympify(e).xreplace(rep)
        return e.xreplace({f: sp.Rational(f) for f in e.atoms(sp.Float)})

    u = sp.Matrix(reduced.u).applyfunc(rational)
    if any(exact_polynomial(uk, [*s, *w, *z]) is None for uk in u):
        return "the law's torque is not a polynomial in the state"
    z_dot = sp.Matrix(reduced.z_dot).applyfunc(rational) if reduced.z_dot.rows else sp.zeros(0, 1)
    J = sp.Matrix(3, 3, [sp.Rational(float(v)) for v in J0.ravel()])
    d, q = disturbance_symbols(), inertia_factor_symbols(n_q)
    a = Fraction(float(inertia))
    r_m = sp.Rational(1) / (1 - sp.Rational(a) ** 2)
    half_d = [Fraction(float(v)) for v in disturbance]
    if n_q == 0:
        sigma_dot, omega_dot = plant_rhs(J, s, w, u + d)
    elif n_q == 1:
        sigma_dot, omega_dot = plant_rhs(J, s, w, (r_m + q[0]) * (u + d))
    else:
        sigma_dot, nominal = plant_rhs(J, s, w, u + d)
        omega_dot = sp.Matrix([(r_m + q[k]) * nominal[k] for k in range(3)])
        W = [Fraction(float(v)) for v in omega_half_widths]
        Jd = [Fraction(float(J0[k, k])) for k in range(3)]
        for k in range(3):
            i, j = (k + 1) % 3, (k + 2) % 3
            half_d[k] += a * W[i] * W[j] * (Jd[i] + Jd[j])
        words += (
            "; the disturbance widened to d' = d - omega^x (J - J0) omega, |d'_k| <= D_k + a W_i W_j (J0_ii + J0_jj) "
            "(D the disturbance's bounds, W the region's omega_e bounds, i, j the other two axes) = "
            + ", ".join(f"{float(h):.4g}" for h in half_d)
            + " N m on the region (an over-approximation)"
        )
    half_q = [a / (1 - a * a)] * n_q
    field = sp.ImmutableMatrix(sp.Matrix.vstack(sp.Matrix(sigma_dot), sp.Matrix(omega_dot), z_dot))
    names = tuple([f"d[{k}]" for k in range(3)] + [f"q[{k}]" for k in range(n_q)])
    half = tuple(_float_up(h) for h in [*half_d, *half_q])
    return PolynomialLoop(field, names, half, words, J0, inertia_set, float(inertia))
