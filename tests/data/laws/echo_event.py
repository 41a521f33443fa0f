"""An event-triggered link probe (law name ``echo_event``): each agent broadcasts its clock ``[t]`` and sends it when
it has advanced by more than ``gap`` since the last message; it commands ``u = gain [received, k_received_sum, 0]``,
so the recorded command shows exactly which message each link holds (``tests/data/laws/echo_time.py`` with a
trigger).  ``gap`` < 0 sends at every check (periodic broadcasting through the trigger).

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

import sympy as sp

from fsmctl.symbolic.law import Law, LawBuilder


def law(error_model) -> Law:
    b = LawBuilder("echo_event", error_model, doc="broadcasts t when it advanced by gap, commands what it received")
    gain = b.parameter("gain", 1e-6, unit="N m / s", minimum=0.0, doc="torque per second of received clock")
    gap = b.parameter("gap", 0.25, unit="s", doc="clock advance that triggers a message")
    b.error_state()
    b.broadcast("clock", sp.ImmutableMatrix([b.t]), unit="s")
    b.trigger(b.broadcast_now[0] - b.broadcast_sent[0] > gap, doc="clock advanced by more than gap")
    b.torque(gain * sp.ImmutableMatrix([b.received[0], b.k_received_sum, 0]))
    return b.build()
