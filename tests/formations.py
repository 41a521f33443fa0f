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


OPEN_LOOP_LAW = str(__import__("pathlib").Path(__file__).parent / "data" / "laws" / "open_loop_torque.py")
"""A test law flying the open-loop torque ``bias + amplitude sin(frequency t)`` (per axis)."""


def single_spacecraft(
    *,
    J=((100.0, 1.0, 2.0), (1.0, 150.0, 1.0), (2.0, 1.0, 200.0)),
    sigma0=(0.1, -0.2, 0.3),
    omega0=(0.01, -0.02, 0.03),
    t_final=10.0,
    dt=1e-3,
    control_period=0.1,
    law=OPEN_LOOP_LAW,
    law_parameters=None,
    torque_limit=float("inf"),
    actuator=None,
    sensors=None,
    links=None,
    seed=0,
    n_agents=1,
    topology=None,
):
    """Identical spacecraft (default one), no disturbance, no uncertainty, no links unless ``topology`` (a file
    table) is given: a scenario for actuator, sensor and link tests."""
    from fsmctl.model.scenario import scenario_from_dict

    data = {
        "name": "single",
        "simulation": {
            "t_final": t_final,
            "dt": dt,
            "output_interval": control_period or dt,
            "control_period": control_period,
            "seed": seed,
        },
        "controller": {"law": law, "torque_limit": torque_limit, **(law_parameters or {})},
        "reference": {"sigma0": [0.0, 0.0, 0.0], "omega": {"amplitude": [0.0, 0.0, 0.0]}},
        "topology": topology or {"links": []},
        "agents": [{"J0": [list(r) for r in J], "sigma0": list(sigma0), "omega0": list(omega0)}] * n_agents,
    }
    for key, value in (("actuator", actuator), ("sensors", sensors), ("links", links)):
        if value is not None:
            data[key] = value
    return scenario_from_dict(data)
