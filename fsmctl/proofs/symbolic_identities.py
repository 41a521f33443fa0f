"""Exact symbolic checks shared by the law check (``fsmctl prove --law``) and the certificates (``fsmctl certify``).

* :func:`identically_zero`: every expression is identically zero as a rational function, with its non-rational
  pieces (``Piecewise``, ``sign``, ``Abs``, ``Min``, ``Max``, non-integer powers, ...) held as free symbols, so an
  identity it accepts holds for every value those pieces take;
* :func:`resolve_branches_on_unit_ball`: an expression in the MRP ``sigma`` with each ``Piecewise`` replaced by the
  branch taken on ``|sigma| <= 1`` and each ``Abs(a)`` by ``+-a`` where the sign of ``a`` is fixed there (the
  shadow-set switch of the MRPs), with how each was shown: symbolically, or sampled at :data:`UNIT_BALL_SAMPLES`
  seeded points of :func:`uniform_ball_points` (then said so);
Used by :mod:`fsmctl.proofs.law_check` and :mod:`fsmctl.proofs.certify_symbolic`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import sympy as sp

__all__ = [
    "UNIT_BALL_SAMPLES",
    "identically_zero",
    "resolve_branches_on_unit_ball",
    "uniform_ball_points",
]

UNIT_BALL_SAMPLES = 512
"""seeded points of ``|sigma| <= 1`` at which a condition is sampled when it cannot be decided symbolically"""

_OPAQUE = (sp.Piecewise, sp.sign, sp.Abs, sp.Min, sp.Max, sp.Heaviside, sp.DiracDelta)


# ----------------------------------------------------------------------------------------------- rational identity


def _canonical(expr: sp.Expr, table: dict) -> sp.Expr:
    """``expr`` with ``|x|`` written ``x sgn(x)`` (real ``x``), non-integer powers split as ``P * b^n`` (``P`` a
    symbol standing for ``b^(e - n)``, ``n`` the integer part of ``e``) and the branches of each ``Piecewise`` put
    in a canonical form (cancel), so that equal pieces written differently (``eps^(alpha-2)`` and
    ``eps^(alpha-1)/eps``) become the same expression."""

    memo = table.setdefault("memo", {})

    def rebuild(e):
        if e in memo:
            return memo[e]
        if e.is_Atom:
            out = e
        else:
            args = tuple(rebuild(a) for a in e.args)
            out = e.func(*args) if args != e.args else e
            if isinstance(out, sp.Abs) and out.args[0].is_extended_real:
                out = out.args[0] * sp.sign(out.args[0])  # |x| = x sgn(x): sign terms of V_dot meet Abs of a claim
            if out.is_Pow and not out.exp.is_Integer:
                c, _ = out.exp.as_coeff_Add()
                n = math.floor(c) if c.is_Rational else 0
                key = ("pow", out.base, out.exp - n)
                if key not in table:
                    table[key] = sp.Symbol(f"_pow{len(table)}", positive=True)
                out = table[key] * out.base**n
            elif isinstance(out, sp.Piecewise):
                out = sp.Piecewise(*((sp.cancel(sp.expand(v)), c) for v, c in out.args), evaluate=False)
        memo[e] = out
        return out

    return rebuild(expr)


def _opaque(exprs: Sequence[sp.Expr], table: dict) -> list[sp.Expr]:
    """Replace non-rational pieces (Piecewise, sign, Abs, Min, Max, non-integer powers) by fresh symbols.

    The same piece becomes the same symbol in every expression (``table`` is shared), so an identity that holds
    with them free holds for every value they take.
    """
    out = []
    for e in exprs:
        e = _canonical(sp.sympify(e), table)
        pieces = set(e.atoms(*_OPAQUE))
        for p in pieces:
            if p not in table:
                table[p] = sp.Symbol(f"_opaque{len(table)}", real=True)
        out.append(e.xreplace({p: table[p] for p in pieces}))
    return out


def identically_zero(exprs: Sequence[sp.Expr]) -> bool:
    """Whether every expression is identically zero as a rational function of its symbols.

    Each ``|x|`` of a real ``x`` is first written ``x sgn(x)``, each non-integer power ``b^e`` as ``P b^n``
    (``n`` the integer part of ``e``), the branches of each ``Piecewise`` cancelled; then the non-rational pieces
    (``Piecewise``, ``sign``, ``Abs``, ``Min``, ``Max``, ``Heaviside``, ``DiracDelta``, ``P``) become free symbols,
    the same piece the same symbol in every expression, and each expression is expanded and cancelled.  True is a
    proof (the identity holds whatever values those pieces take); False only says this test did not show it
    (``sin(x)**2 + cos(x)**2 - 1`` is not recognised).

    Parameters
    ----------
    exprs : sequence of sympy.Expr
        The expressions (anything :func:`sympy.sympify` takes).

    Returns
    -------
    bool
        True when every one cancels to 0.

    Examples
    --------
    >>> import sympy as sp
    >>> x, eps = sp.Symbol("x", real=True), sp.Symbol("eps", positive=True)
    >>> identically_zero([(x**2 - 1) / (x - 1) - (x + 1), sp.Abs(x) - x * sp.sign(x)])
    True
    >>> identically_zero([eps ** (sp.Rational(1, 3) - 2) - eps ** (sp.Rational(1, 3) - 1) / eps])
    True
    >>> identically_zero([x - 1])
    False
    """
    table: dict = {}
    for e in _opaque(list(exprs), table):
        if sp.cancel(sp.together(sp.expand(e))) != 0:
            return False
    return True


# ----------------------------------------------------------------------------------------------- unit ball


def uniform_ball_points(rng: np.random.Generator, n: int, dim: int, radius: float) -> np.ndarray:
    """``n`` points uniform in the ``dim``-dimensional ball of ``radius`` (centred at the origin).

    Parameters
    ----------
    rng : numpy.random.Generator
        The random source (seeded by the caller).
    n : int
        Number of points.
    dim : int
        Dimension (0 gives ``n`` empty rows).
    radius : float
        Radius of the ball.

    Returns
    -------
    numpy.ndarray
        ``(n, dim)``, one point a row.

    Examples
    --------
    >>> import numpy as np
    >>> pts = uniform_ball_points(np.random.default_rng(0), 1000, 3, 2.0)
    >>> pts.shape, bool(np.all(np.linalg.norm(pts, axis=1) <= 2.0))
    ((1000, 3), True)
    >>> uniform_ball_points(np.random.default_rng(0), 2, 0, 1.0).shape
    (2, 0)
    """
    if dim == 0:
        return np.zeros((n, 0))
    x = rng.normal(size=(n, dim))
    x /= np.maximum(np.linalg.norm(x, axis=1, keepdims=True), 1e-300)
    return x * radius * rng.uniform(size=(n, 1)) ** (1.0 / dim)


def _holds_on_unit_ball(cond, sigma: sp.ImmutableMatrix) -> tuple[bool, str]:
    """Whether a condition in ``sigma`` holds on all of ``|sigma| <= 1``: ``(holds, how)``.

    Symbolic when the condition is a function of ``r2 = |sigma|^2`` alone (``solve_univariate_inequality``
    on ``[0, 1]``), else sampled at :data:`UNIT_BALL_SAMPLES` points (said so in ``how``).
    """
    if cond is sp.true:
        return True, "always"
    if not isinstance(cond, sp.core.relational.Relational) or cond.free_symbols - set(sigma):
        return False, "not a condition on sigma"
    r2 = sp.Symbol("r2", nonnegative=True)
    gap = cond.lhs - cond.rhs
    try:
        g = sp.cancel(gap.xreplace({sigma[0]: sp.sqrt(r2 - sigma[1] ** 2 - sigma[2] ** 2)}))
        if g.free_symbols <= {r2}:
            solution = sp.solve_univariate_inequality(cond.func(g, 0), r2, relational=False)
            return bool(sp.Interval(0, 1).is_subset(solution)), f"{cond} on |sigma|^2 in [0, 1] (symbolic)"
    except (NotImplementedError, ValueError, TypeError):
        pass
    f = sp.lambdify(list(sigma), cond, modules="numpy")
    pts = uniform_ball_points(np.random.default_rng(0), UNIT_BALL_SAMPLES, 3, 1.0)
    with np.errstate(all="ignore"):
        ok = np.all(np.asarray(f(*pts.T), dtype=bool))
    return bool(ok), f"{cond} at {UNIT_BALL_SAMPLES} points of |sigma| <= 1 (sampled)"


def resolve_branches_on_unit_ball(expr: sp.Basic, sigma: sp.ImmutableMatrix) -> tuple[sp.Basic, list[str]]:
    """``expr`` with its branches resolved on the unit ball ``|sigma| <= 1`` of the MRPs, and how.

    Each ``Piecewise`` is replaced by its first branch whose condition holds on all of ``|sigma| <= 1``, then each
    ``Abs(a)`` by ``a`` or ``-a`` where ``a >= 0`` or ``a <= 0`` holds there.  A condition that is a function of
    ``|sigma|^2`` alone is decided symbolically; any other is sampled at :data:`UNIT_BALL_SAMPLES` seeded points
    (evidence, not proof: the text says ``sampled``).  A piece whose branch or sign is not shown is kept.

    Parameters
    ----------
    expr : sympy.Basic
        An expression or matrix in ``sigma`` (and other symbols).
    sigma : sympy.ImmutableMatrix
        The three MRP symbols.

    Returns
    -------
    resolved : sympy.Basic
        ``expr`` with the resolved pieces replaced.
    how : list of str
        For each replaced piece, the condition that selected it and whether it was shown ``(symbolic)`` or
        ``(sampled)``.

    Examples
    --------
    >>> import sympy as sp
    >>> sigma = sp.ImmutableMatrix(sp.symbols("s0:3", real=True))
    >>> r2 = sigma.dot(sigma)
    >>> expr = sp.Piecewise((sigma[0], r2 <= 1), (-sigma[0] / r2, True)) + sp.Abs(r2 - 2)
    >>> resolved, how = resolve_branches_on_unit_ball(expr, sigma)
    >>> resolved
    -s0**2 + s0 - s1**2 - s2**2 + 2
    >>> [text.endswith("(symbolic)") for text in how]
    [True, True]
    """
    how: list[str] = []
    rep = {}
    for pw in expr.atoms(sp.Piecewise):
        for value, cond in pw.args:
            ok, text = _holds_on_unit_ball(cond, sigma)
            if ok:
                rep[pw] = value
                how.append(text)
                break
    expr = expr.xreplace(rep)
    rep = {}
    for ab in expr.atoms(sp.Abs):
        a = ab.args[0]
        for sign, cond in ((1, sp.GreaterThan(a, 0)), (-1, sp.LessThan(a, 0))):
            ok, text = _holds_on_unit_ball(cond, sigma)
            if ok:
                rep[ab] = sign * a
                how.append(text)
                break
    return expr.xreplace(rep), how
