"""Ultimately bounded certificates by sum of squares, checked in exact rational arithmetic.

For a polynomial closed loop (:mod:`fsmctl.proofs.certify_polynomial`: the law's torque a polynomial, the reference
at rest, no torque limit) and a polynomial candidate ``V`` (a quadratic ``x^T P x``), the question "``V_dot < 0`` on
``{c_in <= V <= c}`` for every disturbance ``|d_k| <= D_k``" is a polynomial inequality on a semialgebraic set.
A Positivstellensatz identity (Putinar's form) answers it for the whole set at once, with no box splitting:

    -V_dot(x, d) = s0(x, d) + sum_k s_k(x, d) g_k(x, d) + lambda (V(x) - c_in) + mu (c - V(x))

with ``g_k = h_k^2 - x_k^2`` (the region's box), ``g = D_k^2 - d_k^2`` (the disturbance's box), ``s0`` and ``s_k``
sums of squares (``m^T Q m`` with ``Q`` positive semidefinite, ``m`` a vector of monomials) and ``lambda > 0``,
``mu >= 0``.  Wherever ``g_k >= 0``, ``|d_k| <= D_k`` and ``c_in <= V <= c`` it gives
``V_dot <= -lambda (V - c_in)``: ``V`` decreases on the annulus, every trajectory from ``{V <= c}`` (inside the
region when ``c`` is below ``V`` on the region's boundary) enters ``{V <= c_in + e}`` within ``ln((c - c_in)/e) /
lambda`` and stays in ``{V <= c}``: an **ultimately bounded** certificate with a decay rate.

The semidefinite program (cvxpy, Clarabel) is only the search.  Its Gram matrices are rounded to exact dyadic
rationals; the multipliers' ``Q_k`` are checked positive definite exactly; ``s0``'s Gram matrix is then projected
**exactly** onto the affine set where the identity holds coefficient by coefficient (Peyrl & Parrilo 2008: each
monomial's residual is shared equally by the Gram entries that produce it) and checked positive definite exactly
(:func:`fsmctl.proofs.quadratic_forms.positive_definite_exact`).  Only that exact check certifies; the file records
every rational so that ``fsmctl certify --check`` repeats it from the law's equations.

References
----------
M. Putinar, "Positive polynomials on compact semi-algebraic sets", Indiana Univ. Math. J. 42(3), 969-984, 1993.

H. Peyrl, P. A. Parrilo, "Computing sum of squares decompositions with rational coefficients", Theoretical
Computer Science 409(2), 269-281, 2008.

P. A. Parrilo, "Semidefinite programming relaxations for semialgebraic problems", Math. Programming 96, 2003.
"""

from __future__ import annotations

import itertools
import math
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction

import cvxpy as cp
import numpy as np
import scipy.sparse as sps
import sympy as sp

from fsmctl.proofs.quadratic_forms import positive_definite_exact, round_dyadic

__all__ = [
    "SOS_BISECTION_STEPS",
    "SOS_FIRST_FRACTION",
    "SOS_GRAM_LIMIT",
    "SOS_LARGER_FRACTIONS",
    "SOS_MARGIN",
    "SOS_ROUND_BITS",
    "SosResult",
    "exact_polynomial",
    "float_above",
    "float_below",
    "sos_decrease",
    "sos_ultimate_bound",
    "verify_sos",
]

SOS_MARGIN = 1e-7
"""Gram matrices are asked to be ``>= SOS_MARGIN * I`` (relative to the largest coefficient of ``-V_dot``): room
for the rounding and the exact projection, so that the rounded matrices stay positive definite"""
SOS_ROUND_BITS = 40
"""significant bits kept when a Gram matrix is rounded to exact dyadic rationals (relative to its largest entry)"""
SOS_FIRST_FRACTION = 0.5
"""the inner level tried first, as a fraction ``c_in / c`` (the branch and bound's :data:`INNER_FRACTION`)"""
SOS_BISECTION_STEPS = 2
"""after a certified first fraction: bisection steps towards a smaller inner level (a tighter ultimate bound)"""
SOS_LARGER_FRACTIONS = (0.75, 0.9)
"""tried in turn when the first fraction is not certified"""
SOS_GRAM_LIMIT = 120
"""the largest Gram matrix (monomials of ``s0``) the search attempts: beyond it the program is too large for a
quick answer and the branch and bound is used"""

Monomial = tuple[int, ...]
Polynomial = dict[Monomial, Fraction]


def exact_polynomial(expr: sp.Expr, variables: Sequence[sp.Symbol]) -> Polynomial | None:
    """``expr`` as ``{exponents: Fraction}`` with every float taken as the exact binary rational it is, or None
    when it is not a polynomial in ``variables``.

    Examples
    --------
    >>> import sympy as sp
    >>> x, y = sp.symbols("x y")
    >>> exact_polynomial(0.5 * x**2 - 3 * x * y, [x, y]) == {(2, 0): Fraction(1, 2), (1, 1): Fraction(-3)}
    True
    >>> exact_polynomial(sp.log(1 + x**2), [x]) is None
    True
    """
    e = sp.sympify(expr)
    e = e.xreplace({f: sp.Rational(f) for f in e.atoms(sp.Float)})
    try:
        poly = sp.Poly(sp.expand(e), *variables, domain="QQ")
    except (sp.PolynomialError, sp.GeneratorsNeeded, sp.CoercionFailed):
        return None
    out: Polynomial = {}
    for monomial, c in poly.terms():
        if c != 0:
            out[tuple(int(k) for k in monomial)] = Fraction(int(c.p), int(c.q))
    return out


def _monomials(n: int, degree: int) -> list[Monomial]:
    out = []
    for k in range(degree + 1):
        for combo in itertools.combinations_with_replacement(range(n), k):
            e = [0] * n
            for i in combo:
                e[i] += 1
            out.append(tuple(e))
    return out


def _add(a: Monomial, b: Monomial) -> Monomial:
    return tuple(i + j for i, j in zip(a, b, strict=True))


def _degree(p: Polynomial) -> int:
    return max((sum(m) for m in p), default=0)


def _poly_add(*terms: tuple[Fraction, Polynomial]) -> Polynomial:
    out: Polynomial = {}
    for c, p in terms:
        for m, v in p.items():
            out[m] = out.get(m, Fraction(0)) + c * v
    return {m: v for m, v in out.items() if v != 0}


@dataclass
class SosResult:
    """A Positivstellensatz identity (see the module docstring) and whether its exact check passed.

    Attributes
    ----------
    verified : bool
        The exact checks passed: the identity holds coefficient by coefficient and every Gram matrix is positive
        definite.
    inner_level, level : Fraction
        ``c_in`` and ``c``.
    rate : Fraction
        ``lambda``: ``V_dot <= -lambda (V - c_in)`` on the annulus.
    record : dict
        Everything the exact check needs, as exact rationals (strings ``"p/q"``): written to the certificate.
    detail : str
        One line: what was solved and checked.
    seconds : float
    """

    verified: bool
    inner_level: Fraction
    level: Fraction
    rate: Fraction
    record: dict
    detail: str
    seconds: float = 0.0


@dataclass(frozen=True)
class _Setup:
    """The polynomials of one question: ``-V_dot``, ``V``, the constraints ``g_k >= 0`` and the monomial bases of
    ``s0`` and of each constraint's multiplier."""

    target: Polynomial
    V: Polynomial
    constraints: list[Polynomial]
    basis0: list[Monomial]
    bases: list[list[Monomial]]
    n: int


def _setup(V: Polynomial, V_dot: Polynomial, half_widths: Sequence[Fraction], n: int) -> _Setup | str:
    """``half_widths``: one per variable (each constrained to ``|x_k| <= h_k``)."""
    target = {m: -v for m, v in V_dot.items()}
    degree = max(_degree(target), _degree(V), 2)
    half = (degree + 1) // 2
    basis0 = _monomials(n, half)
    basis1 = _monomials(n, max(half - 1, 0))
    constraints, bases = [], []
    for k, h in enumerate(half_widths):
        if h > 0:
            e = [0] * n
            e[k] = 2
            constraints.append({tuple([0] * n): h * h, tuple(e): Fraction(-1)})
            bases.append(basis1)
    if len(basis0) > SOS_GRAM_LIMIT:
        return f"the sum of squares would need a {len(basis0)}x{len(basis0)} Gram matrix (limit {SOS_GRAM_LIMIT})"
    return _Setup(target, V, constraints, basis0, bases, n)


def _scaled(V: Polynomial, V_dot: Polynomial, half_widths: Sequence[float], level: Fraction):
    """The question in ``y_k = x_k / h_k`` (every variable in ``[-1, 1]``) with ``V`` and ``V_dot`` divided by ``c``
    (the level becomes 1): exact, and far better conditioned for the solver.  ``lambda`` keeps its meaning."""
    hw = [Fraction(float(h)) for h in half_widths]

    def scale(p: Polynomial) -> Polynomial:
        out = {}
        for m, v in p.items():
            f = v / level
            for k, e in enumerate(m):
                f *= hw[k] ** e
            out[m] = f
        return out

    return _setup(scale(V), scale(V_dot), [Fraction(1)] * len(hw), len(hw))


def _gram_operator(basis: list[Monomial], multiplier: Polynomial, index: dict[Monomial, int]) -> sps.csr_matrix:
    rows, cols, vals = [], [], []
    nb = len(basis)
    for i in range(nb):
        for j in range(nb):
            base = _add(basis[i], basis[j])
            for m, c in multiplier.items():
                key = _add(base, m)
                if key not in index:
                    index[key] = len(index)
                rows.append(index[key])
                cols.append(i * nb + j)
                vals.append(float(c))
    return rows, cols, vals


class _Program:
    """The semidefinite program of one question with ``c_in`` as a parameter (compiled once, solved per level)."""

    def __init__(self, s: _Setup, level: Fraction, solver: str) -> None:
        self.s, self.solver = s, solver
        one = tuple([0] * s.n)
        index: dict[Monomial, int] = {}
        ops = [_gram_operator(s.basis0, {one: Fraction(1)}, index)]
        ops += [_gram_operator(b, g, index) for b, g in zip(s.bases, s.constraints, strict=True)]
        for p in (s.target, s.V):
            for m in p:
                index.setdefault(m, len(index))
        index.setdefault(one, len(index))
        rows = len(index)
        scale = max(float(abs(v)) for v in s.target.values())
        self.Q0 = cp.Variable((len(s.basis0), len(s.basis0)), PSD=True)
        self.Qk = [cp.Variable((len(b), len(b)), PSD=True) for b in s.bases]
        self.lam, self.mu = cp.Variable(nonneg=True), cp.Variable(nonneg=True)
        self.c_in = cp.Parameter(nonneg=True)
        vec_V = np.zeros(rows)
        for m, v in s.V.items():
            vec_V[index[m]] = float(v)
        vec_t = np.zeros(rows)
        for m, v in s.target.items():
            vec_t[index[m]] = float(v)
        e1 = np.zeros(rows)
        e1[index[one]] = 1.0
        expr = 0
        for (r, c, v), Q in zip(ops, [self.Q0, *self.Qk], strict=True):
            A = sps.csr_matrix((v, (r, c)), shape=(rows, Q.shape[0] * Q.shape[1]))
            expr = expr + A @ cp.vec(Q, order="C")
        expr = expr + self.lam * vec_V - self.lam * self.c_in * e1 + self.mu * (float(level) * e1 - vec_V)
        margin = SOS_MARGIN * scale
        cons = [expr == vec_t, self.Q0 >> margin * np.eye(len(s.basis0))]
        cons += [Q >> margin * np.eye(Q.shape[0]) for Q in self.Qk]
        cons.append(self.lam >= margin)
        self.problem = cp.Problem(cp.Maximize(self.lam), cons)

    def solve(self, c_in: float) -> bool:
        """Solve at ``c_in``: True when the solver reports a solution (a failure counts as no identity: SCS, the
        fallback of the quadratic search, is too slow at this size to be worth waiting for)."""
        self.c_in.value = c_in
        try:
            with warnings.catch_warnings():  # "may be inaccurate": the exact check decides
                warnings.simplefilter("ignore", UserWarning)
                self.problem.solve(solver=self.solver)
        except (cp.error.SolverError, ValueError):
            return False
        return self.problem.status in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) and self.Q0.value is not None


def _round(M: np.ndarray) -> list[list[Fraction]]:
    return [[Fraction(float(v)) for v in row] for row in round_dyadic(np.asarray(M, float), SOS_ROUND_BITS)]


def _gram_polynomial(basis: list[Monomial], Q: list[list[Fraction]], multiplier: Polynomial) -> Polynomial:
    out: Polynomial = {}
    for i, mi in enumerate(basis):
        for j, mj in enumerate(basis):
            q = Q[i][j]
            if q == 0:
                continue
            base = _add(mi, mj)
            for m, c in multiplier.items():
                key = _add(base, m)
                out[key] = out.get(key, Fraction(0)) + q * c
    return out


def _project(basis: list[Monomial], Q: list[list[Fraction]], residual: Polynomial) -> list[list[Fraction]] | None:
    """``Q`` moved exactly onto ``m^T Q m = residual`` (each monomial's defect shared by the entries producing it);
    None when ``residual`` has a monomial the basis cannot produce."""
    pairs: dict[Monomial, list[tuple[int, int]]] = {}
    for i, mi in enumerate(basis):
        for j, mj in enumerate(basis):
            pairs.setdefault(_add(mi, mj), []).append((i, j))
    if any(m not in pairs for m, v in residual.items() if v != 0):
        return None
    out = [row[:] for row in Q]
    for m, entries in pairs.items():
        current = sum((Q[i][j] for i, j in entries), Fraction(0))
        defect = (residual.get(m, Fraction(0)) - current) / len(entries)
        if defect:
            for i, j in entries:
                out[i][j] += defect
    return out


def _fraction_text(v: Fraction) -> str:
    return f"{v.numerator}/{v.denominator}"


def _check(s: _Setup, Q0, Qk, lam: Fraction, mu: Fraction, c_in: Fraction, level: Fraction) -> tuple[bool, str, list]:
    """The exact check; returns ``(ok, why, Q0 projected)``."""
    if not lam > 0 or mu < 0:
        return False, "lambda > 0 and mu >= 0 fail", Q0
    for k, Q in enumerate(Qk):
        if not positive_definite_exact(Q):
            return False, f"the multiplier of constraint {k} is not positive definite", Q0
    one = tuple([0] * s.n)
    terms = [(Fraction(1), s.target)]
    terms += [(Fraction(-1), _gram_polynomial(b, Q, g)) for b, Q, g in zip(s.bases, Qk, s.constraints, strict=True)]
    terms += [(-lam, s.V), (lam * c_in, {one: Fraction(1)}), (mu, s.V), (-mu * level, {one: Fraction(1)})]
    residual = _poly_add(*terms)
    projected = _project(s.basis0, Q0, residual)
    if projected is None:
        return False, "the identity needs monomials beyond the basis of s0", Q0
    if not positive_definite_exact(projected):
        return False, "s0's Gram matrix, projected exactly onto the identity, is not positive definite", projected
    return True, "", projected


def _record(s: _Setup, Q0, Qk, lam, mu, c_in, level, variables: Sequence[str]) -> dict:
    def mat(Q):
        return [[_fraction_text(v) for v in row] for row in Q]

    return {
        "variables": list(variables),
        "basis_s0": [list(m) for m in s.basis0],
        "basis_multipliers": [[list(m) for m in b] for b in s.bases],
        "scaling": "y_k = x_k / h_k, V and V_dot divided by c (the level)",
        "constraints": "g_k = 1 - y_k^2 >= 0 for every variable, in order",
        "Q0": mat(Q0),
        "Q_constraints": [mat(Q) for Q in Qk],
        "lambda": _fraction_text(lam),
        "mu": _fraction_text(mu),
        "inner_level": _fraction_text(c_in),
        "level": _fraction_text(level),
    }


def sos_ultimate_bound(
    V: Polynomial,
    V_dot: Polynomial,
    half_widths: Sequence[float],
    level: float,
    variables: Sequence[str],
    *,
    solver: str = "CLARABEL",
) -> SosResult | str:
    """An identity (module docstring) with an inner level as small as a short search finds: ``c_in =``
    :data:`SOS_FIRST_FRACTION` ``c``, then bisection towards 0 (:data:`SOS_BISECTION_STEPS`), or larger fractions
    (:data:`SOS_LARGER_FRACTIONS`) when the first is not certified.

    Parameters
    ----------
    V, V_dot : dict
        Exact polynomials (:func:`exact_polynomial`) in the variables (state, then disturbance).
    half_widths : sequence of float
        Per variable: ``|x_k| <= h_k`` (the region, the disturbance's bound); 0 for a variable fixed at 0.
    level : float
        ``c``: at most ``V``'s minimum on the region's boundary (so that ``{V <= c}`` lies in the region).
    variables : sequence of str
        Their names (recorded).
    solver : str
        The cvxpy solver.

    Returns
    -------
    SosResult or str
        The certified identity with the smallest inner level, or why none was found.

    Examples
    --------
    ``x' = -x + d`` with ``|d| <= 0.3``, ``V = x^2``: ``V_dot = -2 x^2 + 2 x d < 0`` once ``|x| > 0.3``, so on
    ``|x| <= 2`` (``c = 4``) every inner level above ``0.09`` can be certified (how far the bisection gets depends on the solver):

    >>> from fractions import Fraction as F
    >>> V = {(2, 0): F(1)}
    >>> V_dot = {(2, 0): F(-2), (1, 1): F(2)}
    >>> r = sos_ultimate_bound(V, V_dot, [2.0, 0.3], 4.0, ["x", "d"])
    >>> r.verified, 0.09 <= float(r.inner_level) <= 2.0  # never below the true 0.09; c / 2 or smaller
    (True, True)
    """
    t0 = time.perf_counter()
    c = Fraction(float(level))
    s = _scaled(V, V_dot, half_widths, c)
    if isinstance(s, str):
        return s
    program = _Program(s, Fraction(1), solver)
    why = "the semidefinite program found no identity"
    best, why = _attempt(program, s, SOS_FIRST_FRACTION, c, variables, solver, why)
    if best is None:
        for f in SOS_LARGER_FRACTIONS:
            best, why = _attempt(program, s, f, c, variables, solver, why)
            if best is not None:
                break
    else:
        lo, hi = 0.0, SOS_FIRST_FRACTION
        for _ in range(SOS_BISECTION_STEPS):
            mid = 0.5 * (lo + hi)
            found, _ = _attempt(program, s, mid, c, variables, solver, why)
            if found is None:
                lo = mid
            else:
                best, hi = found, mid
    if best is None:
        return why
    best.seconds = time.perf_counter() - t0
    return best


def _attempt(program: _Program, s: _Setup, fraction: float, c: Fraction, variables, solver: str, why: str):
    """``(SosResult or None, why)`` at ``c_in = fraction c``."""
    f = Fraction(float(fraction))
    if not program.solve(float(f)):
        return None, f"the semidefinite program found no identity for c_in = {fraction:g} c"
    Q0 = _round(program.Q0.value)
    Qk = [_round(Q.value) for Q in program.Qk]
    lam = Fraction(float(np.float32(max(program.lam.value, 0.0))))
    mu = Fraction(float(np.float32(max(program.mu.value, 0.0))))
    ok, reason, projected = _check(s, Q0, Qk, lam, mu, f, Fraction(1))
    if not ok:
        return None, f"c_in = {fraction:g} c: {reason}"
    detail = (
        f"Putinar identity of degree {2 * max(map(sum, s.basis0))}, Gram matrices {len(s.basis0)}x{len(s.basis0)} and "
        f"{len(s.constraints)} multipliers of sizes {sorted({len(b) for b in s.bases})} ({solver}), rounded to "
        f"{SOS_ROUND_BITS} bits and "
        "checked in exact rational arithmetic"
    )
    record = _record(s, projected, Qk, lam, mu, f * c, c, variables)
    return SosResult(True, f * c, c, lam, record, detail), why


def verify_sos(V: Polynomial, V_dot: Polynomial, half_widths: Sequence[float], record: dict) -> tuple[bool, str]:
    """Repeat the exact check of a recorded identity (``fsmctl certify --check``): ``(ok, one line)``.

    Parameters
    ----------
    V, V_dot : dict
        The exact polynomials, rebuilt from the law's equations.
    half_widths : sequence of float
        As for :func:`sos_ultimate_bound`.
    record : dict
        :attr:`SosResult.record`.
    """
    c_in, c = Fraction(record["inner_level"]), Fraction(record["level"])
    if not 0 < c_in < c:
        return False, "the recorded levels are not 0 < c_in < c"
    s = _scaled(V, V_dot, half_widths, c)
    if isinstance(s, str):
        return False, s
    bases = [[list(m) for m in b] for b in s.bases]
    if [list(m) for m in s.basis0] != record["basis_s0"] or bases != record["basis_multipliers"]:
        return False, "the recorded monomial bases differ from the question's"

    def mat(rows):
        return [[Fraction(v) for v in row] for row in rows]

    Q0, Qk = mat(record["Q0"]), [mat(Q) for Q in record["Q_constraints"]]
    if len(Qk) != len(s.constraints):
        return False, "the recorded multipliers do not match the constraints"
    lam, mu = Fraction(record["lambda"]), Fraction(record["mu"])
    ok, why, projected = _check(s, Q0, Qk, lam, mu, c_in / c, Fraction(1))
    if ok and projected != Q0:
        return False, "the recorded s0 does not satisfy the identity exactly"
    return ok, why or (
        f"-V_dot/c = s0 + sum s_k g_k + lambda (V - c_in)/c + mu (1 - V/c) in y_k = x_k/h_k holds exactly, every "
        "Gram matrix positive definite "
        f"(lambda = {float(lam):.6g}, c_in = {float(c_in):.9g}, c = {float(c):.9g})"
    )


def float_above(x: Fraction) -> float:
    """The least float ``>= x`` (a level that must not be understated)."""
    f = float(x)
    return f if Fraction(f) >= x else math.nextafter(f, math.inf)


def float_below(x: Fraction) -> float:
    """The greatest float ``<= x`` (a rate that must not be overstated)."""
    f = float(x)
    return f if Fraction(f) <= x else math.nextafter(f, -math.inf)


def sos_decrease(rate: float, c_in: float, level: float) -> tuple[float, float | None]:
    """``(m, T)`` of a sum-of-squares certificate: ``V_dot <= -lambda (V - c_in) <= -m`` on ``{c_mid <= V <= c}``,
    ``c_mid`` the annulus' middle, and ``T = (c - c_mid) / m`` (None when ``m <= 0``), each rounded towards the weaker
    statement by ``1e-12`` relative, as :func:`fsmctl.proofs.certify.sos_outcome` states them.

    Examples
    --------
    >>> from fsmctl.proofs.certify_sos import sos_decrease
    >>> m, T = sos_decrease(2.0, 1.0, 3.0)  # m = 2 (2 - 1), T = (3 - 2) / m
    >>> round(m, 9), round(T, 9)
    (2.0, 0.5)
    """
    c_mid = 0.5 * (c_in + level)
    decrease = rate * (c_mid - c_in) * (1 - 1e-12)
    return decrease, (level - c_mid) / decrease * (1 + 1e-12) if decrease > 0 else None
