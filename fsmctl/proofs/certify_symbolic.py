"""The law's torque for ``fsmctl certify``, reduced symbolically so that its enclosures are tight.

Interval arithmetic pays for every repeated occurrence of an input (the dependency problem): the generated code
computes ``sigma_e`` from ``sigma`` through the quaternion and the shadow-set switch, which is ``sigma`` itself on
``|sigma| < 1`` at ``sigma_d = 0`` but encloses poorly.  :func:`reduced_torque` substitutes the law's SymPy stages
(:class:`fsmctl.symbolic.law.Law`) at ``sigma_d = 0`` without neighbours, replaces the ``sigma_e`` stage by
``sigma`` when that is *proved* (the branch of each ``Piecewise`` and the sign of each ``Abs`` fixed on
``|sigma| <= 1`` symbolically, then a rational identity, as ``fsmctl prove --law`` does) and cancels each
component, within a time budget.  It returns None when it cannot (the certificate then encloses the generated
graph itself); :func:`fsmctl.proofs.certify_problem.build_problem` checks the reduced torque against the generated
code at seeded random points before it uses it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp

from fsmctl.parallel import run_with_time_limit
from fsmctl.proofs.symbolic_identities import identically_zero, resolve_branches_on_unit_ball
from fsmctl.symbolic.law import Law

__all__ = ["SYMBOLIC_SECONDS", "ReducedTorque", "reduced_torque", "state_symbols"]

SYMBOLIC_SECONDS = 20.0
"""the budget of the symbolic reduction (it runs in a forked child that is stopped at the limit)"""


@dataclass(frozen=True)
class ReducedTorque:
    """The isolated agent's commanded torque and state derivative at ``sigma_d = 0`` in the law's symbols
    ``sigma`` (= ``sigma_e``), ``omega``, ``z``, ``omega_d``, ``omega_d_dot`` (parameters and ``J0`` as numbers)."""

    u: sp.ImmutableMatrix
    z_dot: sp.ImmutableMatrix
    how: str


def _reduce(law: Law, params: np.ndarray, J0: np.ndarray, at_rest: bool) -> ReducedTorque | str:
    sym = law.symbols
    numbers = dict(zip(list(sym["params"]), [sp.Float(float(v), 17) for v in params], strict=True))
    numbers.update(zip(list(sym["J0"]), [sp.Float(float(v), 17) for v in np.asarray(J0, float).ravel()], strict=True))
    zero = ["sigma_d", "k_sum", "received", "k_received_sum"] + (["omega_d", "omega_d_dot"] if at_rest else [])
    rest = {s: sp.S.Zero for n in zero for s in sym[n]}
    rest[sym["t"][0]] = sp.S.Zero
    sigma = sym["sigma"]
    stages: dict = {}
    how = "the generated law's stages"
    for name, syms, value in (*law.constants, *law.local_stages, *law.control_stages):
        v = sp.ImmutableMatrix(value).xreplace(numbers).xreplace(rest).xreplace(stages)
        if name == "sigma_e":
            reduced, why = resolve_branches_on_unit_ball(v, sigma)
            if any("sampl" in w for w in why) or not identically_zero(list(reduced - sigma)):
                return "sigma_e at sigma_d = 0 could not be reduced to sigma symbolically"
            v = sigma
            how = "sigma_e = sigma at sigma_d = 0 on |sigma| <= 1 (" + "; ".join(why or ["no branch"]) + ")"
        stages.update(zip(syms, v, strict=True))
    u = sp.ImmutableMatrix(law.torque).xreplace(numbers).xreplace(rest).xreplace(stages)
    z_dot = sp.ImmutableMatrix(law.state_derivative).xreplace(numbers).xreplace(rest).xreplace(stages)
    u = u.applyfunc(lambda e: sp.cancel(sp.expand(e)) if not e.has(sp.Piecewise, sp.sign, sp.Abs) else e)
    return ReducedTorque(u, z_dot, how)


def reduced_torque(
    law: Law, params: np.ndarray, J0: np.ndarray, *, at_rest: bool, seconds: float = SYMBOLIC_SECONDS
) -> ReducedTorque | None:
    """The law's torque reduced at ``sigma_d = 0`` (see the module docstring), or None within the budget.

    Parameters
    ----------
    law : fsmctl.symbolic.law.Law
        The law (one error model's variant).
    params : numpy.ndarray
        Its packed parameters.
    J0 : numpy.ndarray
        3x3.
    at_rest : bool
        Also set ``omega_d = omega_d_dot = 0``.
    seconds : float
        Budget.

    Returns
    -------
    ReducedTorque or None
    """
    finished, value = run_with_time_limit(lambda: _reduce(law, params, J0, at_rest), seconds)
    if not finished or not isinstance(value, ReducedTorque):
        return None
    return value


def state_symbols(n_states: int) -> tuple[sp.Matrix, sp.Matrix, sp.Matrix]:
    """The SymPy columns ``sigma_e``, ``omega_e``, ``z`` a candidate is written in."""
    s = sp.Matrix(sp.symbols("sigma_e[0:3]", real=True))
    w = sp.Matrix(sp.symbols("omega_e[0:3]", real=True))
    z = sp.Matrix(sp.symbols(f"z[0:{n_states}]", real=True)) if n_states else sp.zeros(0, 1)
    return s, w, z
