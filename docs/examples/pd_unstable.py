"""A deliberately unstable law (``pd_unstable``) for ``fsmctl certify``'s tests: MRP PD with the rate term's sign
flipped, ``u = -K sigma_e + P omega_e``.  With the energy candidate ``V = 2K ln(1 + |sigma|^2) + omega^T J0 omega / 2``
the isolated agent at rest has ``V_dot = +P |omega|^2 > 0`` wherever ``omega != 0``: certify must refute it.

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

import sympy as sp

from fsmctl.symbolic.law import Law, LawBuilder


def law(error_model) -> Law:
    b = LawBuilder("pd_unstable", error_model, doc="MRP PD with negative damping (unstable on purpose)")
    K = b.parameter("K", 4.0, unit="N m", minimum=0.0, exclusive_minimum=True, doc="attitude gain")
    P = b.parameter("P", 2.0, unit="N m s", minimum=0.0, doc="rate gain, applied with the wrong sign")
    e = b.error_state()
    b.broadcast("sigma_e", e.sigma_e)
    b.torque(-K * e.sigma_e + P * e.omega_e)
    s, w = b.sigma, b.omega
    b.lyapunov(2 * K * sp.log(1 + (s.T * s)[0]) + (w.T * b.J0 * w)[0] / 2, doc="the PD energy: V_dot = +P |omega|^2")
    return b.build()
