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
    """Eqs 34-36 for ``x0 = |x(0)| > tau > 0`` (positive symbols; the sign of x(0) does not matter by symmetry)."""
    t = sp.Symbol("t", nonnegative=True)
    c1, c2, tau, x0 = sp.symbols("c1 c2 tau x0", positive=True)
    q = sp.Symbol("q", positive=True)  # q = 1 - alpha in (0, 1/2)
    alpha = 1 - q
    T34 = 1 / (c1 * (1 - alpha)) * sp.log((c1 * x0 ** (1 - alpha) + c2) / (c1 * tau ** (1 - alpha) + c2))
    T35 = (x0 ** (1 - alpha) - tau ** (1 - alpha)) / (c2 * (1 - alpha))
    T36 = sp.log(x0 / tau) / c1
    return SettlingTimeClosedForms(t, c1, c2, tau, x0, q, alpha, T34, T35, T36)
