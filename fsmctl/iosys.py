"""python-control plug-in: the spacecraft, the FSM controller and the formation as ``NonlinearIOSystem``.

Every callback evaluates the generated per-agent functions (the same code the
compiled simulator runs), so ``ct.input_output_response(fsmctl.formation(s), ...)``
and :func:`fsmctl.simulate` integrate the same model.

Signal names follow python-control conventions: ``sigma[0..2]``,
``omega[0..2]``, ``tau[0..2]``, ``s[0..2]``; in a formation the agents are
``sc1, sc2, ...`` (plants), ``ctrl1, ...`` (controllers) and ``reference``.

``interconnect`` merges the ``params`` dicts of all subsystems into one, so
each system here stores its parameters under keys prefixed with its own name
(``"sc1_J"``, ``"ctrl1_J0"``, ...): agents never overwrite each other.

Note on MRP switching: python-control's solvers cannot reset states, so the
plant MRPs are integrated without shadow switching (they leave the unit ball
as attitudes pass 180 deg, which is harmless until 360 deg); the controller
always forms the error in the shadow set, exactly like the compiled simulator.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import control as ct
import numpy as np

from .generated_code import casadi_function
from .scenario import ControllerSettings, Scenario, Sinusoid, check_inertia
from .topology import Schedule

__all__ = ["Neighbour", "spacecraft", "reference_generator", "fsm_controller", "formation"]


def _labels(name: str, n: int = 3) -> list[str]:
    return [f"{name}[{k}]" for k in range(n)]


def _np(x) -> np.ndarray:
    return np.asarray(x, dtype=float).ravel()


def spacecraft(
    J,
    *,
    disturbance: Sinusoid | None = None,
    name: str = "spacecraft",
) -> ct.NonlinearIOSystem:
    """A rigid spacecraft (Liang et al. 2012, eqs 3-4) as a python-control system.

    Parameters
    ----------
    J : array_like, shape (3, 3)
        True inertia (kg m^2), symmetric positive definite.
    disturbance : Sinusoid, optional
        Disturbance torque ``d(t)`` added to the input (N m).
    name : str
        System name; parameters are stored as ``f"{name}_J"`` and ``f"{name}_disturbance"``.

    Returns
    -------
    control.NonlinearIOSystem
        Inputs ``tau[0..2]`` (N m); states and outputs ``sigma[0..2]`` (MRP), ``omega[0..2]`` (rad/s).
    """
    J = np.asarray(J, dtype=float)
    if J.shape != (3, 3):
        raise ValueError(f"spacecraft J: expected a 3x3 matrix, got shape {J.shape}")
    check_inertia(J, f"{name} J")
    plant = casadi_function("plant_rhs")
    dist = casadi_function("disturbance_torque")
    kJ, kd = f"{name}_J", f"{name}_disturbance"

    def updfcn(t, x, u, params):
        d = params.get(kd)
        tau = u if d is None else u + _np(dist(t, d))
        sd, wd = plant(x[:3], x[3:], tau, params[kJ])
        return np.concatenate([_np(sd), _np(wd)])

    params = {kJ: J}
    if disturbance is not None:
        params[kd] = disturbance.params()
    return ct.nlsys(
        updfcn,
        lambda t, x, u, params: x,
        inputs=_labels("tau"),
        outputs=_labels("sigma") + _labels("omega"),
        states=_labels("sigma") + _labels("omega"),
        params=params,
        name=name,
    )


def reference_generator(omega_d: Sinusoid, *, name: str = "reference") -> ct.NonlinearIOSystem:
    """Reference attitude ``sigma_d`` driven by a sinusoidal ``omega_d(t)`` (Sec. 4).

    States ``sigma_d[0..2]``; outputs ``sigma_d``, ``omega_d``, ``omega_d_dot`` (rad/s, rad/s^2); no inputs.
    """
    ref = casadi_function("reference_rhs")
    key = f"{name}_omega_d"

    def updfcn(t, x, u, params):
        return _np(ref(t, x, params[key])[0])

    def outfcn(t, x, u, params):
        _, w, wdot = ref(t, x, params[key])
        return np.concatenate([x, _np(w), _np(wdot)])

    return ct.nlsys(
        updfcn,
        outfcn,
        inputs=[],
        outputs=_labels("sigma_d") + _labels("omega_d") + _labels("omega_d_dot"),
        states=_labels("sigma_d"),
        params={key: omega_d.params()},
        name=name,
    )


@dataclass(frozen=True)
class Neighbour:
    """A neighbour ``j`` of agent ``i``: weights ``k^i_ij`` and ``k^j_ij(t) = k_j(t + phase)`` (eq 19)."""

    name: str
    k_i: float
    k_j: Schedule
    phase: float = 0.0


def fsm_controller(
    J0,
    controller: ControllerSettings,
    delta: Sequence[float],
    *,
    neighbours: Sequence[Neighbour] = (),
    name: str = "controller",
) -> ct.NonlinearIOSystem:
    """One agent's fast-sliding-mode controller (eqs 13, 16-19) as a static python-control system.

    Parameters
    ----------
    J0 : array_like, shape (3, 3)
        Nominal inertia used by the law.
    controller : ControllerSettings
        Gains, boundary layer, Remark 6 fix, torque limit, error model, surface.
    delta : sequence of 3 floats
        Switching gain of eq 18 (positive).
    neighbours : sequence of Neighbour
        Agents whose sliding variables this one receives; each adds inputs ``s_<name>[0..2]``.
    name : str
        System name; parameters are stored under ``f"{name}_..."`` keys.

    Returns
    -------
    control.NonlinearIOSystem
        Inputs ``sigma``, ``omega`` (own state), ``sigma_d``, ``omega_d``, ``omega_d_dot``
        (reference) and ``s_<neighbour>``; outputs ``tau[0..2]`` (saturated torque) and ``s[0..2]``.
    """
    J0 = np.asarray(J0, dtype=float)
    check_inertia(J0, f"{name} J0")
    delta = np.asarray(delta, dtype=float)
    if delta.shape != (3,) or not np.all(delta > 0):
        raise ValueError(f"{name}: delta must be three positive numbers (eq 18), got {delta.tolist()}")
    law = casadi_function(f"control_law_{controller.error_model}")
    consts = casadi_function("sliding_constants")
    gains = controller.gains_vector()
    gc = float(consts(gains))
    nbrs = tuple(neighbours)
    k_sum = float(sum(nb.k_i for nb in nbrs))
    inputs = (
        _labels("sigma") + _labels("omega") + _labels("sigma_d") + _labels("omega_d") + _labels("omega_d_dot")
    )
    for nb in nbrs:
        inputs += _labels(f"s_{nb.name}")
    keys = {k: f"{name}_{k}" for k in ("J0", "gains", "delta", "u_max")}

    def outfcn(t, x, u, params):
        received = np.zeros(3)
        for m, nb in enumerate(nbrs):
            kj = nb.k_j.value(t + nb.phase)
            if kj:
                received += kj * u[15 + 3 * m : 18 + 3 * m]
        out = law(
            u[0:3], u[3:6], u[6:9], u[9:12], u[12:15],
            params[keys["gains"]], gc, params[keys["J0"]], params[keys["delta"]], k_sum, received, params[keys["u_max"]],
        )
        return np.concatenate([_np(out[0]), _np(out[1])])

    return ct.nlsys(
        None,
        outfcn,
        inputs=inputs,
        outputs=_labels("tau") + _labels("s"),
        params={keys["J0"]: J0, keys["gains"]: gains, keys["delta"]: delta, keys["u_max"]: controller.torque_limit},
        name=name,
    )


def formation(scenario: Scenario, *, name: str = "formation") -> ct.InterconnectedSystem:
    """The closed-loop formation of a scenario, assembled with :func:`control.interconnect`.

    Subsystems: ``reference``, plants ``sc1..scn`` (true inertia ``J0 + delta_J`` and
    disturbance), controllers ``ctrl1..ctrln`` (nominal ``J0``). Controller ``i`` receives
    ``s_j`` from controller ``j`` for each link ``i <- j`` of the topology.

    Returns
    -------
    control.InterconnectedSystem
        No inputs. States ``reference_sigma_d[k]``, ``sc<i>_sigma[k]``, ``sc<i>_omega[k]``;
        outputs ``sc<i>_sigma[k]``, ``sc<i>_omega[k]``, ``sc<i>_tau[k]`` (the same labels as
        :meth:`fsmctl.simulator.SimulationResult.to_time_response`).
    """
    n = scenario.n_agents
    systems = [reference_generator(scenario.reference.omega, name="reference")]
    connections = []
    for i, agent in enumerate(scenario.agents, start=1):
        systems.append(spacecraft(agent.J_true, disturbance=agent.disturbance, name=f"sc{i}"))
        nbrs = [
            Neighbour(f"sc{link.sender + 1}", link.k_i, link.k_j, link.phase)
            for link in scenario.topology.links
            if link.receiver == i - 1
        ]
        systems.append(fsm_controller(agent.J0_array, scenario.controller, agent.delta, neighbours=nbrs, name=f"ctrl{i}"))
        connections += [
            [f"ctrl{i}.sigma", f"sc{i}.sigma"],
            [f"ctrl{i}.omega", f"sc{i}.omega"],
            [f"ctrl{i}.sigma_d", "reference.sigma_d"],
            [f"ctrl{i}.omega_d", "reference.omega_d"],
            [f"ctrl{i}.omega_d_dot", "reference.omega_d_dot"],
            [f"sc{i}.tau", f"ctrl{i}.tau"],
        ]
        connections += [[f"ctrl{i}.s_{nb.name}", f"ctrl{nb.name[2:]}.s"] for nb in nbrs]
    outlist = [f"{sys}{i}.{sig}" for i in range(1, n + 1) for sys, sig in (("sc", "sigma"), ("sc", "omega"), ("ctrl", "tau"))]
    outputs = [f"sc{i}_{sig}[{k}]" for i in range(1, n + 1) for sig in ("sigma", "omega", "tau") for k in range(3)]
    return ct.interconnect(systems, connections=connections, outlist=outlist, outputs=outputs, name=name, inputs=[])


def initial_state(scenario: Scenario) -> np.ndarray:
    """The formation's initial state vector (order of :func:`formation`'s states)."""
    x = [np.asarray(scenario.reference.sigma0)]
    for a in scenario.agents:
        x += [np.asarray(a.sigma0), np.asarray(a.omega0)]
    return np.concatenate(x)
