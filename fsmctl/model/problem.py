"""A scenario packed into the flat arrays the simulators consume.

:func:`pack` is the single place where a :class:`~fsmctl.model.scenario.Scenario`
becomes numbers: the law it flies, per-agent inertias, the law's packed parameters
(:func:`fsmctl.model.laws.parameter_matrix`), torque limits, sinusoid parameters, the link list with its
schedules, and the initial state ``x0 = [sigma_d, (sigma_i, omega_i, z_i) for each agent]``.
Both the compiled driver (:mod:`fsmctl.simulation.simulator`) and the CasADi fallback
(:mod:`fsmctl.simulation.casadi_formation`) read this object.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fsmctl.model.laws import LawCode, initial_law_states, parameter_matrix, resolve_law
from fsmctl.model.scenario import Scenario
from fsmctl.model.topology import schedule_weight

__all__ = ["PackedProblem", "pack", "output_buffer_bytes"]


def output_buffer_bytes(n_agents: int, n_rows: int, n_broadcast: int = 3, n_states: int = 0) -> int:
    """Bytes of a run's output buffers for ``n_rows`` output samples of ``n_agents`` agents (float64).

    Six ``(rows, n, 3)`` arrays (sigma, omega, sigma_e, omega_e, u, u_unsaturated), the broadcast
    ``(rows, n, n_broadcast)`` and law states ``(rows, n, n_states)``, time ``(rows,)``, sigma_d ``(rows, 3)``
    and three ``(n,)`` statistics: what :func:`fsmctl.simulation.simulator.simulate_packed` allocates (with
    ``rows = n_outputs + 1``) before the loop starts.
    """
    n, rows = int(n_agents), int(n_rows)
    return 8 * (rows * ((6 * 3 + int(n_broadcast) + int(n_states)) * n + 1 + 3) + 3 * n)


@dataclass(frozen=True)
class PackedProblem:
    n_agents: int
    error_model: int  # 0 paper, 1 exact
    integrator: int  # 0 rk4, 1 dopri45
    t0: float
    dt: float
    n_steps: int
    output_every: int
    hold_steps: int
    rtol: float
    atol: float
    J_true: np.ndarray  # (n, 3, 3)
    J0: np.ndarray  # (n, 3, 3)
    law: LawCode
    params: np.ndarray  # (n, law.n_params)
    u_max: np.ndarray  # (n,)
    dist_params: np.ndarray  # (n, 12)
    ref_params: np.ndarray  # (12,)
    link_receiver: np.ndarray  # (L,) int32
    link_sender: np.ndarray  # (L,) int32
    link_k_i: np.ndarray  # (L,)
    sched_period: np.ndarray  # (L,), <= 0 aperiodic
    sched_phase: np.ndarray  # (L,)
    sched_start: np.ndarray  # (L,) int32
    sched_count: np.ndarray  # (L,) int32
    sched_times: np.ndarray  # (sum counts,)
    sched_values: np.ndarray  # (sum counts,)
    x0: np.ndarray  # (3 + (6 + n_states) n,)

    @property
    def n_states(self) -> int:
        """Law states per agent."""
        return self.law.n_states

    @property
    def n_broadcast(self) -> int:
        return self.law.n_broadcast

    @property
    def stride(self) -> int:
        """State components per agent: sigma (3), omega (3), the law's states."""
        return 6 + self.law.n_states

    def agent_slice(self, i: int) -> slice:
        """Where agent ``i``'s ``[sigma, omega, z]`` sits in the state vector."""
        return slice(3 + self.stride * i, 3 + self.stride * (i + 1))

    @property
    def n_links(self) -> int:
        return int(self.link_receiver.size)

    @property
    def n_outputs(self) -> int:
        return self.n_steps // self.output_every + 1

    @property
    def output_bytes(self) -> int:
        """Bytes of the output buffers the simulator allocates (:func:`output_buffer_bytes`, ``n_outputs + 1`` rows)."""
        return output_buffer_bytes(self.n_agents, self.n_outputs + 1, self.n_broadcast, self.n_states)

    def link_weights(self, t: float | np.ndarray) -> np.ndarray:
        """``k^j_ij(t)`` of every link (same rule as the C driver): shape ``(n_links,)`` for a float ``t``, or
        ``(n_links, t.size)`` for an array of times (flattened; one vectorised evaluation per link)."""
        times = np.asarray(t, dtype=float) if isinstance(t, np.ndarray) else None
        out = np.empty(self.n_links if times is None else (self.n_links, times.size))
        for e in range(self.n_links):
            s, c = self.sched_start[e], self.sched_count[e]
            b, v = self.sched_times[s : s + c], self.sched_values[s : s + c]
            phase, period = float(self.sched_phase[e]), float(self.sched_period[e])
            if times is None:
                out[e] = schedule_weight(b, v, period, t + phase)
            else:
                out[e] = schedule_weight(b, v, period, times.ravel() + phase)
        return out


def pack(scenario: Scenario, law: LawCode | str | None = None) -> PackedProblem:
    """Flatten a validated scenario (flying ``law``, default the scenario's ``controller.law``)."""
    law = resolve_law(scenario.controller.law if law is None else law)
    agents = scenario.agents
    n = len(agents)
    c = scenario.controller
    sim = scenario.simulation
    links = scenario.topology.links
    times, values, starts, counts = [], [], [], []
    for link in links:
        starts.append(len(times))
        counts.append(len(link.k_j.breakpoints))
        times.extend(link.k_j.breakpoints)
        values.extend(link.k_j.values)
    stride = 6 + law.n_states
    z0 = initial_law_states(law)
    x0 = np.empty(3 + stride * n)
    x0[:3] = scenario.reference.sigma0
    for i, a in enumerate(agents):
        x0[3 + stride * i : 6 + stride * i] = a.sigma0
        x0[6 + stride * i : 9 + stride * i] = a.omega0
        x0[9 + stride * i : 3 + stride * (i + 1)] = z0
    return PackedProblem(
        n_agents=n,
        error_model=1 if c.error_model == "exact" else 0,
        integrator=1 if sim.integrator == "dopri45" else 0,
        t0=0.0,
        dt=sim.dt,
        n_steps=sim.n_steps,
        output_every=sim.output_every,
        hold_steps=sim.hold_steps,
        rtol=sim.rtol,
        atol=sim.atol,
        J_true=np.array([a.J_true for a in agents], dtype=float),
        J0=np.array([a.J0 for a in agents], dtype=float),
        law=law,
        params=parameter_matrix(law, scenario),
        u_max=np.full(n, c.effective_torque_limit, dtype=float),  # 0 when the controller is disabled
        dist_params=np.array([a.disturbance.params() for a in agents], dtype=float).reshape(n, 12),
        ref_params=scenario.reference.omega.params(),
        link_receiver=np.array([lk.receiver for lk in links], dtype=np.int32),
        link_sender=np.array([lk.sender for lk in links], dtype=np.int32),
        link_k_i=np.array([lk.k_i for lk in links], dtype=float),
        sched_period=np.array([lk.k_j.period or 0.0 for lk in links], dtype=float),
        sched_phase=np.array([lk.phase for lk in links], dtype=float),
        sched_start=np.array(starts, dtype=np.int32),
        sched_count=np.array(counts, dtype=np.int32),
        sched_times=np.array(times, dtype=float),
        sched_values=np.array(values, dtype=float),
        x0=x0,
    )
