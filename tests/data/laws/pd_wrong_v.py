"""A stable law with a wrong Lyapunov candidate (``pd_wrong_v``) for ``fsmctl certify``'s tests.

The torque is the MRP PD ``u = -K sigma_e - P omega_e`` (stable), but the declared ``V = 6K ln(1 + |sigma|^2) +
omega^T J0 omega / 2`` weights the attitude three times too much: ``V_dot = 2K sigma^T omega - P |omega|^2``, positive
where ``sigma^T omega > P |omega|^2 / (2K)``.  Certify must refute the candidate (and say the law's V is wrong, not
the law).

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

import sympy as sp

from fsmctl.symbolic.law import Law, LawBuilder


def law(error_model) -> Law:
    b = LawBuilder("pd_wrong_v", error_model, doc="MRP PD with a wrongly weighted Lyapunov candidate")
    K = b.parameter("K", 4.0, unit="N m", minimum=0.0, exclusive_minimum=True, doc="attitude gain")
    P = b.parameter("P", 12.0, unit="N m s", minimum=0.0, exclusive_minimum=True, doc="rate gain")
    e = b.error_state()
    b.broadcast("sigma_e", e.sigma_e)
    b.torque(-K * e.sigma_e - P * e.omega_e)
    s, w = b.sigma, b.omega
    b.lyapunov(6 * K * sp.log(1 + (s.T * s)[0]) + (w.T * b.J0 * w)[0] / 2, doc="wrong: the attitude weight is 3K")
    return b.build()
