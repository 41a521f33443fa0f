"""The paper's fast sliding surface as stages of a law, for every law built on it.

:func:`fast_sliding_surface` declares, on a :class:`~fsmctl.symbolic.law.LawBuilder`, the surface
``s = sigma_e_dot + c1 sigma_e + c2 sig(sigma_e)^alpha`` (Liang et al. 2012, eq 13, with the Remark 6 fix) and
the slope ``alpha |sigma_e|^(alpha-1)`` of eq 17, with the powers ``|sigma_e,k|^alpha`` computed once and shared
(three ``pow`` calls per agent instead of nine).  The built-in laws ``fsm``, ``adaptive_fsm`` and
``super_twisting`` use it; a user's sliding-mode law can too.

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from fsmctl.symbolic.controller import share_fractional_powers, sliding_variable, surface_term_slope
from fsmctl.symbolic.law import ErrorState, LawBuilder, LawDefinitionError
from fsmctl.symbolic.mrp import mrp_G

__all__ = ["FastSlidingSurface", "fast_sliding_surface"]


@dataclass(frozen=True)
class FastSlidingSurface:
    """The stages :func:`fast_sliding_surface` declared."""

    error: ErrorState
    s: sp.ImmutableMatrix
    """the sliding variable (eq 13), stage symbols"""
    slope: sp.ImmutableMatrix
    """the gain ``alpha |sigma_e|^(alpha-1)`` of eq 17 after the Remark 6 fix, stage symbols"""
    slope_expressions: sp.ImmutableMatrix
    """the same gain as :func:`~fsmctl.symbolic.controller.surface_term_slope` writes it in a torque formula"""
    alpha: sp.Expr

    def with_shared_slope(self, expr, what: str = "torque") -> sp.ImmutableMatrix:
        """``expr`` (e.g. from :func:`~fsmctl.symbolic.controller.computed_torque_pieces`) reading the slope stage,
        so that every fractional power comes from the shared powers.

        Raises
        ------
        LawDefinitionError
            A fractional power of ``alpha`` remains outside the slope.
        """
        out = sp.ImmutableMatrix(expr).xreplace(dict(zip(self.slope_expressions, self.slope, strict=True)))
        if self.alpha in out.free_symbols:
            raise LawDefinitionError(f"the {what} still depends on alpha after the slope substitution")
        return out


def fast_sliding_surface(b: LawBuilder, c1, c2, alpha, epsilon, fix) -> FastSlidingSurface:
    """Declare the error state, the shared powers, the eq 17 slope and the surface ``s`` (eq 13) on ``b``.

    Declares the constant ``epsilon_pow_alpha_minus_1`` and the stages ``sigma_e``, ``omega_r``, ``omega_e``,
    ``omega_r_dot`` (:meth:`LawBuilder.error_state`), ``abs_sigma_e_pow_alpha``, ``slope`` and ``s``; the
    surface is Liang et al. 2012, eq 13, ``s = sigma_e_dot + c1 sigma_e + c2 sig(sigma_e)^alpha`` with
    ``sigma_e_dot = G(sigma_e) omega_e`` (eq 7), and ``slope`` the gain ``alpha |sigma_e|^(alpha-1)`` of eq 17.

    Parameters
    ----------
    b : LawBuilder
        The law being built.
    c1, c2 : Expr
        The surface gains (usually parameter symbols of ``b``).
    alpha : Expr
        The exponent, ``0.5 < alpha < 1``.
    epsilon : Expr
        Half-width of the Remark 6 band.
    fix : Expr or SingularityFix or str
        Remark 6's device: a parameter symbol taking the index of ``"none"``, ``"switch"``, ``"clamp"``, or a
        fixed choice.

    Returns
    -------
    FastSlidingSurface
        The stages; the law decides what it broadcasts (usually ``s``).

    Examples
    --------
    A minimal sliding-mode law on the paper's surface:

    >>> from fsmctl.symbolic import LawBuilder, fast_sliding_surface
    >>> b = LawBuilder("sm", "paper", doc="sliding mode on the fast surface")
    >>> c1, c2 = b.parameter("c1", 1.0, minimum=0.0), b.parameter("c2", 0.5, minimum=0.0)
    >>> alpha = b.parameter("alpha", 0.75, minimum=0.5, maximum=1.0, exclusive_minimum=True, exclusive_maximum=True)
    >>> eps = b.parameter("epsilon", 1e-4, minimum=0.0, exclusive_minimum=True)
    >>> fix = b.parameter("fix", "switch", choices=("none", "switch", "clamp"))
    >>> surface = fast_sliding_surface(b, c1, c2, alpha, eps, fix)
    >>> surface.s.T
    Matrix([[s[0], s[1], s[2]]])
    >>> b.broadcast("s", surface.s, unit="1/s")
    >>> b.torque(-b.J0 * surface.s)
    >>> [name for name, _, _ in b.build().local_stages]
    ['sigma_e', 'omega_r', 'omega_e', 'omega_r_dot', 'abs_sigma_e_pow_alpha', 'slope', 's']
    """
    q = b.constant("epsilon_pow_alpha_minus_1", epsilon ** (alpha - 1))
    e = b.error_state()
    p = b.stage("abs_sigma_e_pow_alpha", e.sigma_e.applyfunc(lambda x: sp.Abs(x) ** alpha))

    def share(m):
        return share_fractional_powers(m, e.sigma_e, alpha, epsilon, p, q)

    slopes = sp.ImmutableMatrix([surface_term_slope(x, alpha, fix, epsilon) for x in e.sigma_e])
    slope = b.stage("slope", share(slopes))
    s = b.stage("s", share(sliding_variable(e.sigma_e, mrp_G(e.sigma_e) * e.omega_e, c1, c2, alpha, fix, epsilon)))
    return FastSlidingSurface(e, s, slope, slopes, alpha)
