"""An event-triggered PD law with consensus on the attitude error (law name ``pd_event``; tests of the trigger).

Each agent broadcasts ``sigma_e`` only when ``|sigma_e - sigma_e,sent| > c0 + c1 exp(-lam t)`` (checked at the control
instants); the torque is ``-K sigma_e - P omega_e - K (k_received_sum sigma_e - received)``, ``received`` the
values last received.  ``tests/oracle_numpy.py`` (``event_triggered_pd_formation``) transcribes the same loop.

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

import sympy as sp

from fsmctl.symbolic.law import Law, LawBuilder


def law(error_model) -> Law:
    b = LawBuilder("pd_event", error_model, doc="PD with event-triggered consensus on sigma_e (test law)")
    K = b.parameter("K", 20.0, unit="N m", minimum=0.0, doc="attitude gain")
    P = b.parameter("P", 60.0, unit="N m s", minimum=0.0, doc="rate gain")
    c0 = b.parameter("c0", 0.002, minimum=0.0, doc="threshold floor")
    c1 = b.parameter("c1", 0.02, minimum=0.0, doc="threshold at t = 0, decaying part")
    lam = b.parameter("lam", 0.2, unit="1/s", minimum=0.0, doc="decay rate of the threshold")
    e = b.error_state()
    b.broadcast("sigma_e", e.sigma_e)
    b.trigger((e.sigma_e - b.broadcast_sent).norm() > c0 + c1 * sp.exp(-lam * b.t), doc="test trigger")
    b.torque(-K * e.sigma_e - P * e.omega_e - K * (b.k_received_sum * e.sigma_e - b.received))
    return b.build()
