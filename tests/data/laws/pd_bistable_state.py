"""A law with a known region of attraction (``pd_bistable_state``) for ``fsmctl certify``'s tests.

MRP PD ``u = -K sigma_e - P omega_e`` plus one law state ``x`` (``z[0]``) with ``z_dot = -a z (1 - z^2)`` (it does not act on the
attitude): the origin ``z = 0`` attracts exactly the interval ``|z| < 1`` (``z = +-1`` are equilibria).  The declared
candidate is the strict PD function with a cross term plus ``z^2 / 2``::

    V = 2K ln(1 + |sigma|^2) + omega^T J0 omega / 2 + eps sigma^T J0 omega + z^2 / 2,

whose ``z`` part has ``d/dt (z^2/2) = -a z^2 (1 - z^2)``: negative for ``0 < |z| < 1``, positive for ``|z| > 1``.  So
``V_dot < 0`` holds on a region ``|z| <= r`` (with the attitude part small) exactly when ``r < 1``: the analytic
boundary the certificate must find.

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

import sympy as sp

from fsmctl.symbolic.law import Law, LawBuilder


def law(error_model) -> Law:
    b = LawBuilder("pd_bistable_state", error_model, doc="MRP PD plus a bistable law state (known region)")
    K = b.parameter("K", 4.0, unit="N m", minimum=0.0, exclusive_minimum=True, doc="attitude gain")
    P = b.parameter("P", 12.0, unit="N m s", minimum=0.0, exclusive_minimum=True, doc="rate gain")
    a = b.parameter("a", 1.0, unit="1/s", minimum=0.0, exclusive_minimum=True, doc="rate of the law state")
    eps = b.parameter("eps", 0.05, unit="1/s", minimum=0.0, doc="cross-term weight of the candidate")
    e = b.error_state()
    b.broadcast("sigma_e", e.sigma_e)
    z = b.state("x", 1, initial=0.0, unit="1", doc="a bistable state: attracted to 0 from |z| < 1")
    b.derivative(z, sp.ImmutableMatrix([-a * z[0] * (1 - z[0] ** 2)]))
    b.torque(-K * e.sigma_e - P * e.omega_e)
    s, w = b.sigma, b.omega
    V = 2 * K * sp.log(1 + (s.T * s)[0]) + (w.T * b.J0 * w)[0] / 2 + eps * (s.T * b.J0 * w)[0] + z[0] ** 2 / 2
    b.lyapunov(V, doc="strict PD candidate with a cross term, plus z^2/2")
    return b.build()
