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

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import casadi as ca
import control as ct
import numpy as np

from .generated_code import casadi_function
from .scenario import ControllerSettings, Scenario, Sinusoid, check_inertia
from .topology import Schedule, schedule_weight

__all__ = ["Neighbour", "spacecraft", "reference_generator", "fsm_controller", "formation", "initial_state"]


def _labels(name: str, n: int = 3) -> list[str]:
    return [f"{name}[{k}]" for k in range(n)]


def _np(x) -> np.ndarray:
    return np.asarray(x, dtype=float).ravel()


class _FlatCall:
    """Evaluate a CasADi function through one flat input and one flat output buffer.

    Calling a :class:`casadi.Function` with NumPy arguments converts every
    argument to a ``DM`` (about 20 us each); a solver calls the right-hand side
    tens of thousands of times.  This wrapper builds, once, a function of a
    single stacked input vector (each argument flattened column-major) returning
    the stacked selected outputs, and evaluates it through a
    :meth:`casadi.Function.buffer` on preallocated NumPy arrays (about 2 us).
    The result is the same generated code; only the calling convention differs.
    Not thread-safe (one buffer per instance), like python-control's callbacks.
    """

    def __init__(self, build: Callable[..., Sequence], shapes: Sequence[tuple[int, int]], name: str):
        sizes = [r * c for r, c in shapes]
        z = ca.MX.sym("z", sum(sizes))
        args, offset = [], 0
        for (r, c), size in zip(shapes, sizes, strict=True):
            args.append(ca.reshape(z[offset : offset + size], r, c))
            offset += size
        out = ca.vertcat(*[ca.vec(o) for o in build(*args)])
        self._fn = ca.Function(name, [z], [out])
        self._offsets = np.cumsum([0, *sizes])
        self._in = np.zeros(int(self._offsets[-1]))
        self._out = np.zeros(out.numel())
        self._buffer, self._eval = self._fn.buffer()
        self._buffer.set_arg(0, memoryview(self._in))
        self._buffer.set_res(0, memoryview(self._out))

    def __call__(self, *values) -> np.ndarray:
        o = self._offsets
        for k, v in enumerate(values):
            # column-major flattening (CasADi's layout); inertias are symmetric anyway
            self._in[o[k] : o[k + 1]] = np.ravel(v, order="F")
        self._eval()
        return self._out.copy()


def _scalar_schedule(schedule: Schedule, phase: float) -> Callable[[float], float]:
    """``t -> k^j_ij(t) = schedule(t + phase)`` for a scalar ``t``, without NumPy overhead.

    The rule of :func:`fsmctl.topology.schedule_weight` (the compiled driver's ``link_weight``).
    """
    breakpoints = list(schedule.breakpoints)
    values = list(schedule.values)
    period = schedule.period

    if len(set(values)) == 1:
        constant = float(values[0])
        return lambda t: constant

    return lambda t: schedule_weight(breakpoints, values, period, t + phase)


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
    no_disturbance = np.zeros(12)
    rhs = _FlatCall(
        lambda t, x, u, J, d: plant(x[:3], x[3:], u + dist(t, d), J),
        [(1, 1), (6, 1), (3, 1), (3, 3), (12, 1)],
        f"{name}_rhs",
    )

    def updfcn(t, x, u, params):
        d = params.get(kd)
        return rhs(t, x, u, params[kJ], no_disturbance if d is None else d)

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
    rhs = _FlatCall(lambda t, x, p: ref(t, x, p), [(1, 1), (3, 1), (12, 1)], f"{name}_rhs")

    def updfcn(t, x, u, params):
        return rhs(t, x, params[key])[:3]

    def outfcn(t, x, u, params):
        return np.concatenate([x, rhs(t, x, params[key])[3:]])

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
        Gains, boundary layer, Remark 6 fix, torque limit (0, i.e. no torque, when ``enabled`` is False),
        error model, surface.
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
    weights = [_scalar_schedule(nb.k_j, nb.phase) for nb in nbrs]
    inputs = _labels("sigma") + _labels("omega") + _labels("sigma_d") + _labels("omega_d") + _labels("omega_d_dot")
    for nb in nbrs:
        inputs += _labels(f"s_{nb.name}")
    keys = {k: f"{name}_{k}" for k in ("J0", "gains", "delta", "u_max")}
    # one flat call: (own/reference signals, gains, J0, delta, k_sum, received, u_max) -> (tau, s)
    call = _FlatCall(
        lambda y, g, J, d, ks, r, um: law(y[0:3], y[3:6], y[6:9], y[9:12], y[12:15], g, gc, J, d, ks, r, um)[:2],
        [(15, 1), (6, 1), (3, 3), (3, 1), (1, 1), (3, 1), (1, 1)],
        f"{name}_law",
    )

    def outfcn(t, x, u, params):
        # eq 19: agent i only knows sum_j k^j_ij(t) s_j, built from the s_j it receives
        received = np.zeros(3)
        for m, weight in enumerate(weights):
            kj = weight(t)
            if kj:
                received += kj * u[15 + 3 * m : 18 + 3 * m]
        return call(
            u[:15],
            params[keys["gains"]],
            params[keys["J0"]],
            params[keys["delta"]],
            k_sum,
            received,
            params[keys["u_max"]],
        )

    return ct.nlsys(
        None,
        outfcn,
        inputs=inputs,
        outputs=_labels("tau") + _labels("s"),
        params={
            keys["J0"]: J0,
            keys["gains"]: gains,
            keys["delta"]: delta,
            keys["u_max"]: controller.effective_torque_limit,
        },
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
        systems.append(
            fsm_controller(agent.J0_array, scenario.controller, agent.delta, neighbours=nbrs, name=f"ctrl{i}")
        )
        connections += [
            [f"ctrl{i}.sigma", f"sc{i}.sigma"],
            [f"ctrl{i}.omega", f"sc{i}.omega"],
            [f"ctrl{i}.sigma_d", "reference.sigma_d"],
            [f"ctrl{i}.omega_d", "reference.omega_d"],
            [f"ctrl{i}.omega_d_dot", "reference.omega_d_dot"],
            [f"sc{i}.tau", f"ctrl{i}.tau"],
        ]
        connections += [[f"ctrl{i}.s_{nb.name}", f"ctrl{nb.name[2:]}.s"] for nb in nbrs]
    outlist = [
        f"{sys}{i}.{sig}" for i in range(1, n + 1) for sys, sig in (("sc", "sigma"), ("sc", "omega"), ("ctrl", "tau"))
    ]
    outputs = [f"sc{i}_{sig}[{k}]" for i in range(1, n + 1) for sig in ("sigma", "omega", "tau") for k in range(3)]
    return ct.interconnect(systems, connections=connections, outlist=outlist, outputs=outputs, name=name, inputs=[])


def initial_state(scenario: Scenario) -> np.ndarray:
    """The formation's initial state vector (order of :func:`formation`'s states)."""
    x = [np.asarray(scenario.reference.sigma0)]
    for a in scenario.agents:
        x += [np.asarray(a.sigma0), np.asarray(a.omega0)]
    return np.concatenate(x)
