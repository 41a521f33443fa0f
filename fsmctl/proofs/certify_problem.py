"""The question ``fsmctl certify`` answers, as CasADi graphs: an agent's closed loop with the model's uncertainty.

The isolated agent (no neighbours: ``k_sum = 0``, ``received = 0``) in error coordinates, Liang, Sun & Wang (2012)
eqs 4-8 with the uncertainty of eq 29, at an instant where the reference attitude is ``sigma_d = 0`` (the error
dynamics do not depend on ``sigma_d``; a law written on :meth:`fsmctl.symbolic.law.LawBuilder.error_state` sees
only the error state)::

    sigma = sigma_e,   omega = omega_e + C(sigma_e) omega_d,
    sigma_e_dot = G(sigma_e) omega_e                                   (eq 5)
    J omega_dot = -omega^x J omega + u + d                             (eqs 4, 29)
    omega_e_dot = omega_dot + omega_e^x C(sigma_e) omega_d - C(sigma_e) omega_d_dot
    z_dot = the law's state derivative,

``u`` the law's applied torque (its generated ``law_control_<model>`` with ``J0`` and the scenario's parameters and
torque limit), ``C`` the direction-cosine matrix of an MRP.  The uncertainty: the true inertia ``J`` with
``J_kl = J0_kl (1 + theta_kl)``, ``|theta_kl| <= inertia`` (``"entries"``: each distinct non-zero entry on its own,
``J`` symmetric; ``"proportional"``: one ``theta``, ``J = (1 + theta) J0``); the disturbance ``|d_k| <= d_k bound``;
the reference rate ``|omega_d,k|`` and acceleration ``|omega_d_dot,k|`` within their bounds.

Everything is one input vector ``x = (sigma_e, omega_e, z, theta, d, omega_d, omega_d_dot)`` so that the rigorous
evaluator (:class:`fsmctl.enclosures.intervals.IntervalFunction`) and the branch and bound see one box.  The
candidate ``V(sigma_e, omega_e, z)`` is written in SymPy (the law's :meth:`~fsmctl.symbolic.law.LawBuilder.lyapunov`,
optionally with a cross term, or a quadratic form) and translated by :mod:`fsmctl.codegen.casadi_bridge`;
``V_dot = grad V . f`` is formed here with CasADi.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import casadi as ca
import numpy as np
import sympy as sp

from fsmctl.codegen.casadi_bridge import SympyToCasadi
from fsmctl.errors import InputError
from fsmctl.model.generated_code import law_sx_function
from fsmctl.model.laws import LawCode
from fsmctl.proofs.certify_polynomial import PolynomialLoop, polynomial_loop
from fsmctl.proofs.certify_symbolic import ReducedTorque, state_symbols
from fsmctl.proofs.rounding import round_outward
from fsmctl.symbolic.law import Law, contract_names
from fsmctl.symbolic.mrp import mrp_G

__all__ = [
    "INERTIA_SETS",
    "Candidate",
    "CertifyProblem",
    "StateRegion",
    "Uncertainty",
    "build_problem",
    "candidate_expression",
    "candidate_from_record",
    "expression_tree",
]

INERTIA_SETS = ("entries", "proportional")
"""how the true inertia may differ from J0 (see the module docstring)"""


class CertifyInputError(InputError):
    """A region, an uncertainty or a law that ``fsmctl certify`` cannot take (one line, exit 2)."""


@dataclass(frozen=True)
class StateRegion:
    """The box of error states a certificate speaks about: ``|sigma_e,k| <= sigma``, ``|omega_e,k| <= omega``,
    ``|z_k| <= z`` (the law's own states).

    Parameters
    ----------
    sigma : float
        Bound of each MRP error component, in ``(0, 1)``.
    omega : float
        Bound of each rate error component (rad/s).
    z : float
        Bound of each of the law's own states (their units).

    Raises
    ------
    CertifyInputError
        A bound that is not a finite number > 0, or ``sigma >= 1``.

    Examples
    --------
    >>> from fsmctl.proofs.certify_problem import StateRegion
    >>> StateRegion(0.5, 0.1).describe(0)
    '|sigma_e,k| <= 0.5, |omega_e,k| <= 0.1 rad/s'
    >>> StateRegion(0.1234567, 0.05).describe(0)  # never rounded (0.123457 would claim a larger box)
    '|sigma_e,k| <= 0.1234567, |omega_e,k| <= 0.05 rad/s'
    """

    sigma: float = 0.5
    omega: float = 0.1
    """rad/s"""
    z: float = 1.0
    """in the law state's own units"""

    def __post_init__(self) -> None:
        for name in ("sigma", "omega", "z"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise CertifyInputError(f"region: {name} must be a finite number > 0, got {v!r}")
        if 3 * self.sigma**2 >= 1:
            raise CertifyInputError(
                f"region: sigma = {self.sigma:g} puts the box's corners at |sigma_e| = sqrt(3) sigma >= 1 (a rotation "
                "of 180 deg, where MRPs switch set and the law's torque changes form): take sigma < 0.577"
            )

    def describe(self, n_states: int) -> str:
        """One line naming the box.

        Parameters
        ----------
        n_states : int
            The law's number of states (0: no ``z`` bound is named).

        Returns
        -------
        str
        """
        # the bounds as given (shortest exact decimal): a rounded bound would state another region than the one proved
        text = f"|sigma_e,k| <= {float(self.sigma)!r}, |omega_e,k| <= {float(self.omega)!r} rad/s"
        return text + (f", |z_k| <= {float(self.z)!r}" if n_states else "")

    def bounds(self, n_states: int) -> np.ndarray:
        """``(6 + n_states,)``: the half-widths of the box.

        Parameters
        ----------
        n_states : int
            The law's number of states.

        Returns
        -------
        numpy.ndarray
        """
        return np.array([self.sigma] * 3 + [self.omega] * 3 + [self.z] * n_states, dtype=float)


def _triple(value, what: str, unit: str) -> tuple[float, float, float]:
    """One bound for the three axes, or one per axis, each finite and >= 0 (see :meth:`Uncertainty.axis_bounds`)."""
    try:
        v = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise CertifyInputError(f"{what} takes one bound or three numbers ({unit}), got {value!r}") from None
    if v.ndim > 1 or v.size not in (1, 3):
        got = str(v.size) if v.ndim <= 1 else f"an array of shape {v.shape}"
        raise CertifyInputError(f"{what} takes one bound or three ({unit}), got {got}")
    v = np.broadcast_to(v.reshape(-1), (3,))
    if not np.all(np.isfinite(v) & (v >= 0)):
        got = ", ".join(f"{x:g}" for x in np.asarray(value, dtype=float).reshape(-1))
        raise CertifyInputError(f"{what} must be finite and >= 0 ({unit}), got {got}")
    return (float(v[0]), float(v[1]), float(v[2]))


@dataclass(frozen=True)
class Uncertainty:
    """What the model may get wrong: the inertia, the disturbance, the reference's motion (eq 29).

    Parameters
    ----------
    inertia : float
        Relative bound: ``J_kl = J0_kl (1 + theta_kl)``, ``|theta_kl| <= inertia`` (0: ``J = J0``).
    inertia_set : str
        ``"entries"`` (each distinct non-zero entry independently) or ``"proportional"`` (``J = (1 + theta) J0``,
        the paper's ``Delta_J = 0.3 J0`` family).
    disturbance : float or 3 floats
        ``|d_k|`` bound, N m.
    reference_rate : float or 3 floats
        ``|omega_d,k|`` bound, rad/s (0: the reference at rest).
    reference_acceleration : float or 3 floats
        ``|omega_d_dot,k|`` bound, rad/s^2.

    Examples
    --------
    >>> from fsmctl.proofs.certify_problem import Uncertainty
    >>> Uncertainty(inertia=0.1).describe()
    'J_kl = J0_kl (1 + theta_kl), |theta_kl| <= 0.1; no disturbance; the reference at rest'
    >>> Uncertainty(disturbance=0.005).at_rest_and_undisturbed
    False
    """

    inertia: float = 0.0
    inertia_set: str = "entries"
    disturbance: tuple[float, float, float] | float = 0.0
    reference_rate: tuple[float, float, float] | float = 0.0
    reference_acceleration: tuple[float, float, float] | float = 0.0

    BOUND_UNITS: ClassVar[dict[str, str]] = {
        "disturbance": "N m",
        "reference_rate": "rad/s",
        "reference_acceleration": "rad/s^2",
    }
    """the per-axis bounds and their units"""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.inertia) and 0 <= self.inertia < 1):
            raise CertifyInputError(f"uncertainty: inertia must be in [0, 1), got {self.inertia!r}")
        if self.inertia_set not in INERTIA_SETS:
            raise CertifyInputError(f"uncertainty: inertia_set must be one of {INERTIA_SETS}, got {self.inertia_set!r}")
        for name in self.BOUND_UNITS:
            object.__setattr__(self, name, self.axis_bounds(name, getattr(self, name)))

    @classmethod
    def axis_bounds(cls, name: str, value, label: str | None = None) -> tuple[float, float, float]:
        """One of the per-axis bounds, checked: the one validation of every way of building an :class:`Uncertainty`.

        Parameters
        ----------
        name : {"disturbance", "reference_rate", "reference_acceleration"}
            Which bound (:attr:`BOUND_UNITS`).
        value : float or sequence of float
            One bound for the three axes, or three (one per axis), each finite and >= 0.
        label : str, optional
            How an error names the bound (e.g. a command-line option); default ``uncertainty: <name>``.

        Returns
        -------
        tuple of 3 float

        Raises
        ------
        CertifyInputError
            Not one or three numbers, or a bound that is negative or not finite (one line).

        Examples
        --------
        >>> from fsmctl.proofs.certify_problem import Uncertainty
        >>> Uncertainty.axis_bounds("disturbance", 0.2)
        (0.2, 0.2, 0.2)
        >>> Uncertainty.axis_bounds("disturbance", (0.2, 0.24))
        Traceback (most recent call last):
        ...
        fsmctl.proofs.certify_problem.CertifyInputError: uncertainty: disturbance takes one bound or three (N m), got 2
        """
        if name not in cls.BOUND_UNITS:
            raise ValueError(f"name must be one of {tuple(cls.BOUND_UNITS)}, got {name!r}")
        return _triple(value, label or f"uncertainty: {name}", cls.BOUND_UNITS[name])

    @property
    def at_rest_and_undisturbed(self) -> bool:
        """No disturbance and the reference at rest: the origin is an equilibrium for every inertia in the set."""
        return not any(self.disturbance) and not any(self.reference_rate) and not any(self.reference_acceleration)

    def describe(self) -> str:
        """One line naming the sets.

        Returns
        -------
        str
        """
        if self.inertia == 0:
            parts = ["J = J0"]
        elif self.inertia_set == "proportional":
            parts = [f"J = (1 + theta) J0, |theta| <= {_inside(self.inertia)}"]
        else:
            parts = [f"J_kl = J0_kl (1 + theta_kl), |theta_kl| <= {_inside(self.inertia)}"]
        d = self.disturbance
        parts.append(f"|d_k| <= {_fmt3(d)} N m" if any(d) else "no disturbance")
        if any(self.reference_rate) or any(self.reference_acceleration):
            parts.append(
                f"|omega_d,k| <= {_fmt3(self.reference_rate)} rad/s, "
                f"|omega_d_dot,k| <= {_fmt3(self.reference_acceleration)} rad/s^2"
            )
        else:
            parts.append("the reference at rest")
        return "; ".join(parts)

    def as_dict(self) -> dict:
        """The sets as a JSON-ready dict (units in the keys).

        Returns
        -------
        dict
        """
        return {
            "inertia": self.inertia,
            "inertia_set": self.inertia_set,
            "disturbance_N_m": list(self.disturbance),
            "reference_rate_rad_s": list(self.reference_rate),
            "reference_acceleration_rad_s2": list(self.reference_acceleration),
        }


def _inside(x: float) -> str:
    """A bound of a set the certificate covers, rounded down: the printed set lies inside the certified one."""
    return round_outward(x, "down", 6)


def _fmt3(v) -> str:
    """Per-axis bounds: one number when the three agree, each rounded down (:func:`_inside`)."""
    return _inside(v[0]) if v[0] == v[1] == v[2] else "(" + ", ".join(_inside(x) for x in v) + ")"


@dataclass(frozen=True)
class Candidate:
    """A Lyapunov candidate: how it was obtained and its SymPy expression in ``sigma_e, omega_e, z``.

    ``kind``: ``"declared"`` (the law's own), ``"declared + cross term"`` (``+ epsilon sigma_e^T J0 omega_e``) or
    ``"quadratic"`` (``x^T P x`` with ``P`` from :func:`fsmctl.proofs.quadratic_forms.quadratic_lyapunov`) or
    ``"invariant ellipsoid"`` (``x^T P x`` with ``P`` from :func:`fsmctl.proofs.quadratic_forms.invariant_ellipsoid`).
    """

    kind: str
    expression: sp.Expr
    """in the symbols ``sigma_e[k]``, ``omega_e[k]``, ``z[k]`` (numbers for parameters and J0)"""
    epsilon: float | None = None
    P: tuple[tuple[float, ...], ...] | None = None
    note: str = ""

    def describe(self) -> str:
        """One line."""
        if self.kind == "quadratic":
            return "V = x^T P x, x = (sigma_e, omega_e, z), P from a semidefinite program" + (
                f" ({self.note})" if self.note else ""
            )
        if self.kind == "invariant ellipsoid":
            return (
                "V = x^T P x, x = (sigma_e, omega_e, z), P of an attracting ellipsoid of the linearisation under the "
                + (f"bounded disturbance ({self.note})" if self.note else "bounded disturbance")
            )
        if self.kind == "declared + cross term":
            return f"the law's V + {self.epsilon:g} sigma_e^T J0 omega_e"
        return "the law's declared V"


def candidate_expression(
    law: Law, params: np.ndarray, J0: np.ndarray, *, epsilon: float | None = None, P: np.ndarray | None = None
) -> sp.Expr:
    """The candidate ``V(sigma_e, omega_e, z)`` with the parameters and ``J0`` as numbers.

    Parameters
    ----------
    law : fsmctl.symbolic.law.Law
        Its :meth:`~fsmctl.symbolic.law.LawBuilder.lyapunov` ``V`` (written for the isolated agent at rest, in
        ``sigma``, ``omega``, ``z``) is read as ``V(sigma_e, omega_e, z)``; unused when ``P`` is given.
    params : numpy.ndarray
        The packed parameters.
    J0 : numpy.ndarray
        3x3.
    epsilon : float, optional
        Adds ``epsilon sigma_e^T J0 omega_e``.
    P : numpy.ndarray, optional
        ``V = x^T P x`` instead, ``x = (sigma_e, omega_e, z)``.

    Returns
    -------
    sympy.Expr
    """
    n = law.n_states
    s, w, z = state_symbols(n)
    J0m = sp.Matrix(3, 3, [sp.Float(float(v), 17) for v in np.asarray(J0, float).ravel()])
    if P is not None:
        x = sp.Matrix.vstack(s, w, z)
        Pm = sp.Matrix(P.shape[0], P.shape[1], [sp.Float(float(v), 17) for v in np.asarray(P).ravel()])
        return sp.expand((x.T * Pm * x)[0, 0])
    if law.lyapunov is None:
        raise CertifyInputError(f"law {law.name!r} declares no Lyapunov candidate (LawBuilder.lyapunov)")
    sym = law.symbols
    rep = dict(zip(list(sym["sigma"]), list(s), strict=True))
    rep.update(zip(list(sym["omega"]), list(w), strict=True))
    rep.update(zip(list(sym["z"]), list(z), strict=True))
    rep.update(zip(list(sym["params"]), [sp.Float(float(v), 17) for v in params], strict=True))
    rep.update(zip(list(sym["J0"]), list(J0m), strict=True))
    V = law.expanded(law.lyapunov.V)[0, 0].xreplace(rep)
    if epsilon:
        V = V + sp.Float(float(epsilon), 17) * (s.T * J0m * w)[0, 0]
    left = V.free_symbols - set(s) - set(w) - set(z)
    if left:
        raise CertifyInputError(
            f"law {law.name!r}: its Lyapunov candidate depends on {sorted(map(str, left))}, not only on sigma, omega, "
            "z, the parameters and J0"
        )
    return V


_FUNCTIONS = {"Add": sp.Add, "Mul": sp.Mul, "Pow": sp.Pow, "log": sp.log, "exp": sp.exp, "Abs": sp.Abs,
              "sign": sp.sign}  # fmt: skip
"""the nodes a candidate's expression tree may hold (anything else in a certificate file is refused)"""


def expression_tree(expr: sp.Expr):
    """A JSON-ready tree of ``expr`` (exact: each float as its binary fraction and precision): read back by
    :func:`candidate_from_record` without evaluating any text."""
    if isinstance(expr, sp.Symbol):
        return ["Symbol", expr.name]
    if isinstance(expr, sp.Integer):
        return ["Integer", str(int(expr))]
    if isinstance(expr, sp.Rational):
        return ["Rational", str(expr.p), str(expr.q)]
    if isinstance(expr, sp.Float):  # exact: the binary fraction, and the precision it carries
        q = sp.Rational(expr)
        return ["Float", str(q.p), str(q.q), str(expr._prec)]
    name = type(expr).__name__
    if name not in _FUNCTIONS:
        raise CertifyInputError(f"a candidate may use + * ^ log exp Abs sign only, not {name}")
    return [name, *[expression_tree(a) for a in expr.args]]


def _from_tree(node, symbols: dict) -> sp.Expr:
    if not isinstance(node, list) or not node or not isinstance(node[0], str):
        raise ValueError("malformed node")
    kind, args = node[0], node[1:]
    if kind == "Symbol":
        return symbols[args[0]]
    if kind == "Integer":
        return sp.Integer(int(args[0]))
    if kind == "Rational":
        return sp.Rational(int(args[0]), int(args[1]))
    if kind == "Float":
        return sp.Float(sp.Rational(int(args[0]), int(args[1])), precision=int(args[2]))
    return _FUNCTIONS[kind](*[_from_tree(a, symbols) for a in args])


def candidate_from_record(record: dict, n_states: int) -> sp.Expr:
    """A candidate ``V`` from a certificate's ``candidate`` record (its exact expression ``tree``).

    Parameters
    ----------
    record : dict
        With ``"tree"`` (:func:`expression_tree` of the expression in :func:`fsmctl.proofs.certify_symbolic.state_symbols`).
    n_states : int
        The law's number of states.

    Returns
    -------
    sympy.Expr

    Raises
    ------
    CertifyInputError
        A record without a readable expression.

    Examples
    --------
    >>> from fsmctl.proofs.certify_problem import candidate_from_record, expression_tree
    >>> from fsmctl.proofs.certify_symbolic import state_symbols
    >>> s, w, z = state_symbols(0)
    >>> V = 2 * s[0] ** 2 + 0.5 * w[1] * s[2]
    >>> candidate_from_record({"tree": expression_tree(V)}, 0) == V
    True
    """
    s, w, z = state_symbols(n_states)
    symbols = {v.name: v for v in (*s, *w, *z)}
    try:
        return _from_tree(record["tree"], symbols)
    except (KeyError, TypeError, ValueError, IndexError) as exc:
        raise CertifyInputError(f"the certificate's candidate expression cannot be read ({exc!r})") from None


def _dcm(sigma: ca.SX) -> ca.SX:
    """Direction-cosine matrix of an MRP (Schaub & Junkins eq 3.147)."""
    s2 = ca.dot(sigma, sigma)
    S = ca.skew(sigma)
    return ca.SX.eye(3) + (8 * ca.mtimes(S, S) - 4 * (1 - s2) * S) / (1 + s2) ** 2


def _mrp_G(sigma: ca.SX) -> ca.SX:
    """``G(sigma)`` of ``sigma_dot = G(sigma) omega`` (eq 5)."""
    s2 = ca.dot(sigma, sigma)
    return 0.25 * ((1 - s2) * ca.SX.eye(3) + 2 * ca.skew(sigma) + 2 * ca.mtimes(sigma, sigma.T))


def _inertia(J0: np.ndarray, theta: ca.SX, inertia_set: str) -> tuple[ca.SX, list[tuple[int, int]]]:
    J = ca.SX(J0)
    if inertia_set == "proportional":
        return (1 + theta[0]) * J, []
    pairs = [(i, j) for i in range(3) for j in range(i, 3) if J0[i, j] != 0]
    rows = [[J[i, j] for j in range(3)] for i in range(3)]
    for k, (i, j) in enumerate(pairs):
        rows[i][j] = J0[i, j] * (1 + theta[k])
        rows[j][i] = rows[i][j]
    return ca.vertcat(*[ca.horzcat(*r) for r in rows]), pairs


def _inverse(J0: np.ndarray, J: ca.SX, theta: ca.SX, inertia_set: str) -> ca.SX:
    """``J^-1``, written so that each uncertain input occurs as few times as possible (tighter enclosures):
    ``J0^-1 / (1 + theta)`` for the proportional set, ``diag(1 / J_kk)`` for a diagonal ``J0``, else adj / det."""
    if inertia_set == "proportional":
        return ca.SX(np.linalg.inv(J0)) / (1 + theta[0])
    if np.count_nonzero(J0 - np.diag(np.diag(J0))) == 0:
        return ca.diag(ca.vertcat(*[1 / J[k, k] for k in range(3)]))
    adj = ca.SX(3, 3)
    for i in range(3):
        for j in range(3):
            minor = [[J[r, c] for c in range(3) if c != i] for r in range(3) if r != j]
            adj[i, j] = (-1) ** (i + j) * (minor[0][0] * minor[1][1] - minor[0][1] * minor[1][0])
    return adj / (J[0, 0] * adj[0, 0] + J[0, 1] * adj[1, 0] + J[0, 2] * adj[2, 0])


@dataclass
class CertifyProblem:
    """One agent's closed loop with its uncertainty as CasADi graphs of ``x`` (see the module docstring)."""

    names: list[str]
    """name of each input of ``x``"""
    n_state: int
    """``6 + n_states``: the state part of ``x`` comes first"""
    lo: np.ndarray
    hi: np.ndarray
    x: ca.SX
    field: ca.SX
    """``(sigma_e_dot, omega_e_dot, z_dot)``"""
    torque: ca.SX
    inertia_pairs: list[tuple[int, int]] = field(default_factory=list)
    route: str = "the generated code's graphs"
    """how the law's torque enters: its generated graphs, or its SymPy stages reduced at sigma_d = 0"""
    polynomial: PolynomialLoop | str = "the law's torque was not reduced symbolically"
    """the closed loop as exact polynomials (:func:`fsmctl.proofs.certify_polynomial.polynomial_loop`): the
    sum-of-squares route's model, or why it is not one"""

    def state_slice(self) -> slice:
        return slice(0, self.n_state)

    def lyapunov(self, V: sp.Expr) -> tuple[ca.Function, ca.Function, ca.Function, ca.Function]:
        """``(V, grad V, V_dot, grad V_dot)`` as CasADi functions of ``x`` for a candidate in the state symbols."""
        n_z = self.n_state - 6
        s, w, z = state_symbols(n_z)
        xs = self.x[: self.n_state]
        translate = SympyToCasadi(dict(zip([*s, *w, *z], [xs[k] for k in range(self.n_state)], strict=True)))
        Vx = translate(V)
        gV = ca.gradient(Vx, self.x)
        # the kinematic part grad_sigma V . G(sigma_e) omega_e is simplified in SymPy (for the MRP energy
        # 2K ln(1 + |sigma|^2) it is K sigma^T omega exactly): fewer occurrences of each input, tighter enclosures
        G_omega = mrp_G(s) * w
        kinematic = sum(
            sp.cancel(sum(sp.diff(term, sk) * gk for sk, gk in zip(s, G_omega, strict=True)))
            for term in sp.Add.make_args(sp.expand(V))
        )
        rest = ca.gradient(Vx, xs)[3:]
        Vdot = translate(kinematic) + ca.dot(rest, self.field[3:])
        gVdot = ca.gradient(Vdot, self.x)
        f = [ca.Function(n, [self.x], [e]) for n, e in (("V", Vx), ("dV", gV), ("V_dot", Vdot), ("dV_dot", gVdot))]
        return tuple(f)


def build_problem(
    code: LawCode,
    error_model: str,
    J0: np.ndarray,
    params: np.ndarray,
    torque_limit: float,
    region: StateRegion,
    uncertainty: Uncertainty,
    *,
    law: Law | None = None,
    reduced: ReducedTorque | None = None,
) -> CertifyProblem:
    """The closed loop of one agent flying ``code`` with the uncertainty, as graphs of one input vector.

    Parameters
    ----------
    code : fsmctl.model.laws.LawCode
        The law's generated code (the graphs the engine flies).
    error_model : str
        ``"paper"`` or ``"exact"``.
    J0 : numpy.ndarray
        The nominal inertia (3x3).
    params : numpy.ndarray
        The law's packed parameters.
    torque_limit : float
        Per-component bound of the applied torque (``inf``: none).
    region : StateRegion
        The state box.
    uncertainty : Uncertainty
        The uncertainty box.
    law : fsmctl.symbolic.law.Law, optional
        The law's symbols, with ``reduced``.
    reduced : ReducedTorque, optional
        The torque reduced symbolically (:func:`fsmctl.proofs.certify_symbolic.reduced_torque`): used in place of
        the generated graph when it agrees with it at seeded random points of the box (to ``1e-9``).

    Returns
    -------
    CertifyProblem

    Raises
    ------
    CertifyInputError
        A law whose torque depends on time (certify treats time-invariant laws).
    """
    J0 = np.asarray(J0, dtype=float)
    nz = int(code.n_states)
    local = law_sx_function(code.folder, contract_names(error_model)[0])
    control = law_sx_function(code.folder, contract_names(error_model)[1])
    consts = law_sx_function(code.folder, "law_constants")
    se, we, z = ca.SX.sym("sigma_e", 3), ca.SX.sym("omega_e", 3), ca.SX.sym("z", nz)
    n_theta = (
        1 if uncertainty.inertia_set == "proportional" else len([1 for i in range(3) for j in range(i, 3) if J0[i, j]])
    )
    theta, d = ca.SX.sym("theta", n_theta), ca.SX.sym("d", 3)
    wd, wdd = ca.SX.sym("omega_d", 3), ca.SX.sym("omega_d_dot", 3)
    t = ca.SX.sym("t")
    J, pairs = _inertia(J0, theta, uncertainty.inertia_set)
    C = _dcm(se)
    omega = we + ca.mtimes(C, wd)
    p = ca.DM(np.asarray(params, float))
    g = consts(p)
    zero3 = ca.SX.zeros(3)
    _, cache = local(t, se, omega, z, zero3, wd, wdd, ca.DM(J0), p, g)
    received = ca.SX.zeros(local.size1_out(0))
    limit = torque_limit if math.isfinite(torque_limit) else 1e300
    u, _, z_dot = control(t, se, omega, z, zero3, wd, wdd, ca.DM(J0), p, g, cache, 0, received, 0, limit)
    if ca.depends_on(ca.vertcat(u, z_dot), t):
        raise CertifyInputError(
            f"law {code.name!r}: its torque depends on the time t; certify treats time-invariant laws"
        )
    u, z_dot = ca.substitute(u, t, 0), ca.substitute(z_dot, t, 0)
    x = ca.vertcat(se, we, z, theta, d, wd, wdd)
    route = "the generated code's graphs"
    if reduced is not None and law is not None:
        ur, zr = _reduced_graphs(law, reduced, se, omega, z, wd, wdd, torque_limit)
        if _agree(x, (u, z_dot), (ur, zr), region, uncertainty, nz, n_theta):
            u, z_dot, route = ur, zr, f"the law's SymPy stages reduced at sigma_d = 0: {reduced.how}"
    omega_dot = ca.mtimes(_inverse(J0, J, theta, uncertainty.inertia_set), u + d - ca.cross(omega, ca.mtimes(J, omega)))
    we_dot = omega_dot + ca.cross(we, ca.mtimes(C, wd)) - ca.mtimes(C, wdd)
    field_ = ca.vertcat(ca.mtimes(_mrp_G(se), we), we_dot, z_dot)
    half = region.bounds(nz)
    unc = np.concatenate(
        [
            np.full(n_theta, uncertainty.inertia),
            uncertainty.disturbance,
            uncertainty.reference_rate,
            uncertainty.reference_acceleration,
        ]
    )
    hi = np.concatenate([half, unc])
    names = (
        [f"sigma_e[{k}]" for k in range(3)]
        + [f"omega_e[{k}]" for k in range(3)]
        + [f"z[{k}]" for k in range(nz)]
        + [f"theta[{k}]" for k in range(n_theta)]
        + [f"d[{k}]" for k in range(3)]
        + [f"omega_d[{k}]" for k in range(3)]
        + [f"omega_d_dot[{k}]" for k in range(3)]
    )
    poly: PolynomialLoop | str = "the law's torque was not reduced symbolically (its generated graphs are enclosed)"
    if route != "the generated code's graphs" and law is not None:
        poly = polynomial_loop(
            law, reduced, J0, half[3:6], inertia=uncertainty.inertia, inertia_set=uncertainty.inertia_set,
            disturbance=uncertainty.disturbance, reference_at_rest=not any(uncertainty.reference_rate)
            and not any(uncertainty.reference_acceleration), torque_limit=torque_limit,
        )  # fmt: skip
    return CertifyProblem(names, 6 + nz, -hi, hi.copy(), x, field_, u, pairs, route, poly)


def _reduced_graphs(law: Law, reduced: ReducedTorque, se, omega, z, wd, wdd, torque_limit: float):
    sym = law.symbols
    pairs = [(sym["sigma"], se), (sym["omega"], omega), (sym["z"], z), (sym["omega_d"], wd), (sym["omega_d_dot"], wdd)]
    mapping = {}
    for symbols, values in pairs:
        mapping.update({a: values[k] for k, a in enumerate(list(symbols))})
    translate = SympyToCasadi(mapping)
    u = translate(reduced.u)
    if math.isfinite(torque_limit):
        u = ca.fmin(ca.fmax(u, -torque_limit), torque_limit)
    z_dot = translate(reduced.z_dot) if reduced.z_dot.rows else ca.SX(0, 1)
    return u, z_dot


AGREEMENT_POINTS = 64
"""seeded random points at which a reduced torque must agree with the generated one"""


def _agree(x, generated, reduced, region: StateRegion, uncertainty: Uncertainty, nz: int, n_theta: int) -> bool:
    f = ca.Function("agree", [x], [ca.vertcat(*generated), ca.vertcat(*reduced)])
    half = np.concatenate(
        [region.bounds(nz), np.full(n_theta, uncertainty.inertia), uncertainty.disturbance,
         uncertainty.reference_rate, uncertainty.reference_acceleration]
    )  # fmt: skip
    rng = np.random.default_rng(29)
    for _ in range(AGREEMENT_POINTS):
        a, b = (np.array(v, float).ravel() for v in f(rng.uniform(-half, half)))
        if not np.all(np.abs(a - b) <= 1e-9 * (1 + np.abs(a))):
            return False
    return True
