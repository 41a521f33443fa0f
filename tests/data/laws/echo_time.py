"""A probe of the links (law name ``echo_time``): each agent broadcasts its clock ``[t]`` and commands
``u = gain [received, k_received_sum, 0]``, so the recorded command shows exactly which broadcast each link
delivered (``received = sum_j k^j_ij t_j``).  A test law: ``gain`` (default 1e-6) keeps the motion negligible.

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

import sympy as sp

from fsmctl.symbolic.law import Law, LawBuilder


def law(error_model) -> Law:
    b = LawBuilder("echo_time", error_model, doc="broadcasts t, commands what it received (link probe)")
    gain = b.parameter("gain", 1e-6, unit="N m / s", minimum=0.0, doc="torque per second of received clock")
    b.error_state()
    b.broadcast("clock", sp.ImmutableMatrix([b.t]), unit="s")
    b.torque(gain * sp.ImmutableMatrix([b.received[0], b.k_received_sum, 0]))
    return b.build()
