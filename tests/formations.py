"""Scenario helpers shared by the simulator tests (not a test module)."""

from __future__ import annotations

import dataclasses


def with_agents(scenario, agents, topology=None, **sections):
    """A validated scenario with other agents (and, for a different count, another topology)."""
    s = dataclasses.replace(scenario, agents=tuple(agents), topology=topology or scenario.topology)
    return s.replace(**sections) if sections else s


# A small law with a state of its own, written as a derivation script (tests of the fallback and the plug-in)
PI_LAW = """
from fsmctl.symbolic.law import LawBuilder


def law(error_model):
    b = LawBuilder("pi", error_model, doc="PI on the attitude error, consensus on it (test law)")
    K = b.parameter("K", 2.0, unit="N m", minimum=0.0, doc="attitude gain")
    P = b.parameter("P", 20.0, unit="N m s", minimum=0.0, doc="rate gain")
    Ki = b.parameter("Ki", 0.2, unit="N m / s", minimum=0.0, doc="integral gain")
    z = b.state("integral", 3, initial=0.01, doc="integral of sigma_e (with consensus)")
    e = b.error_state()
    b.broadcast("sigma_e", e.sigma_e)
    b.derivative(z, e.sigma_e + 0.1 * (b.k_received_sum * e.sigma_e - b.received))
    b.torque(-K * e.sigma_e - P * e.omega_e - Ki * z - K * (b.k_sum * e.sigma_e - b.received))
    return b.build()
"""
