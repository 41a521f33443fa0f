"""Theorem 3's settling times (Liang et al. 2012, eqs 34-36), as SymPy expressions (pure: no NumPy, no I/O).

The closed forms are stated here once, as the paper prints them; ``fsmctl prove`` (claims
``theorem3-*``) derives them by integrating the three scalar sliding modes and proves the
orderings (37-41), and :mod:`fsmctl.studies.theorem3` lambdifies them to compare with simulation.
"""

from __future__ import annotations

from typing import NamedTuple

import sympy as sp

__all__ = ["SettlingTimeClosedForms", "settling_time_closed_forms"]


class SettlingTimeClosedForms(NamedTuple):
    """Symbols and the three closed forms; ``alpha = 1 - q`` with ``q`` in (0, 1/2)."""

    t: sp.Symbol
    c1: sp.Symbol
    c2: sp.Symbol
    tau: sp.Symbol
    x0: sp.Symbol
    q: sp.Symbol
    alpha: sp.Expr
    T_fsm: sp.Expr
    """eq 34: ln((c1 |x0|^(1-alpha) + c2)/(c1 tau^(1-alpha) + c2)) / (c1 (1-alpha))"""
    T_tsm: sp.Expr
    """eq 35: (|x0|^(1-alpha) - tau^(1-alpha)) / (c2 (1-alpha))"""
    T_lsm: sp.Expr
    """eq 36: ln(|x0|/tau) / c1"""


def settling_time_closed_forms() -> SettlingTimeClosedForms:
    """Theorem 3's settling times (Liang et al. 2012, eqs 34-36) for ``x0 = |x(0)| > tau > 0``.

    The time each scalar sliding mode of Section 3.3 needs to bring ``|x|`` from ``x0`` to ``tau``:
    FSM ``x_dot = -c1 x - c2 sig(x)^alpha`` (eq 34), TSM ``c1 = 0`` (eq 35), LSM ``c2 = 0`` (eq 36).  The symbols
    are positive (the sign of ``x(0)`` does not matter by symmetry) and ``alpha = 1 - q`` with ``q`` in (0, 1/2).

    Returns
    -------
    SettlingTimeClosedForms
        The symbols ``t, c1, c2, tau, x0, q``, ``alpha`` and the expressions ``T_fsm``, ``T_tsm``, ``T_lsm``.

    Examples
    --------
    ``T_fsm`` is the integral of ``dx / (c1 x + c2 x^alpha)`` (its derivative in ``x0`` is ``1/|x_dot|``), and
    the fast mode is the fastest (eqs 37-41), here for ``c1 = c2 = 1``, ``alpha = 3/4``, from 1 to 0.01:

    >>> import sympy as sp
    >>> from fsmctl.symbolic import settling_time_closed_forms
    >>> f = settling_time_closed_forms()
    >>> sp.simplify(sp.diff(f.T_fsm, f.x0) * (f.c1 * f.x0 + f.c2 * f.x0**f.alpha))
    1
    >>> at = {f.c1: 1, f.c2: 1, f.tau: sp.Rational(1, 100), f.x0: 1, f.q: sp.Rational(1, 4)}
    >>> [round(float(T.subs(at)), 3) for T in (f.T_fsm, f.T_tsm, f.T_lsm)]
    [1.674, 2.735, 4.605]
    """
    t = sp.Symbol("t", nonnegative=True)
    c1, c2, tau, x0 = sp.symbols("c1 c2 tau x0", positive=True)
    q = sp.Symbol("q", positive=True)  # q = 1 - alpha in (0, 1/2)
    alpha = 1 - q
    T34 = 1 / (c1 * (1 - alpha)) * sp.log((c1 * x0 ** (1 - alpha) + c2) / (c1 * tau ** (1 - alpha) + c2))
    T35 = (x0 ** (1 - alpha) - tau ** (1 - alpha)) / (c2 * (1 - alpha))
    T36 = sp.log(x0 / tau) / c1
    return SettlingTimeClosedForms(t, c1, c2, tau, x0, q, alpha, T34, T35, T36)
