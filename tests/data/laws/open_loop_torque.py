"""Open-loop body torque u(t) = bias + amplitude * sin(frequency t) per axis (law name ``open_loop_torque``).

A test law: it ignores the state, so a run flies a known torque profile through the actuator (the reaction-wheel
distribution, its limits, the hold), which independent references (Basilisk, a SciPy transcription of the
gyrostat) can fly too.  It broadcasts its attitude error (unused).

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

import sympy as sp

from fsmctl.symbolic.law import Law, LawBuilder


def law(error_model) -> Law:
    b = LawBuilder("open_loop_torque", error_model, doc="open-loop torque bias + amplitude sin(frequency t)")
    bias = b.parameter("bias", [0.0, 0.0, 0.0], unit="N m", doc="constant part per axis")
    amplitude = b.parameter("amplitude", [0.0, 0.0, 0.0], unit="N m", doc="sinusoid amplitude per axis")
    frequency = b.parameter("frequency", 0.1, unit="rad/s", minimum=0.0, doc="sinusoid angular frequency")
    e = b.error_state()
    b.broadcast("sigma_e", e.sigma_e)
    b.torque(sp.ImmutableMatrix([bias[k] + amplitude[k] * sp.sin(frequency * b.t) for k in range(3)]))
    return b.build()
