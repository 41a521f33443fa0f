"""A scenario packed into the flat arrays the simulators consume.

:func:`pack` is the single place where a :class:`~fsmctl.model.scenario.Scenario`
becomes numbers: the law it flies, per-agent inertias, the law's packed parameters
(:func:`fsmctl.model.laws.parameter_matrix`), torque limits, sinusoid parameters, the link list with its
schedules, the flight hardware (:class:`HardwarePack`: wheels, the run's sensor noise and packet losses drawn
from ``simulation.seed`` by :mod:`fsmctl.model.noise`), and the initial state
``x0 = [sigma_d, (sigma_i, omega_i, z_i, Omega_i) for each agent]`` (``Omega_i``: wheel speeds, when the
spacecraft fly reaction wheels).
Both the compiled driver (:mod:`fsmctl.simulation.simulator`) and the CasADi fallback
(:mod:`fsmctl.simulation.casadi_formation`) read this object.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from fsmctl.errors import InputError
from fsmctl.model.actuators import distribution_matrix, sample_wheel_commands
from fsmctl.model.laws import LawCode, initial_law_states, parameter_matrix, resolve_law
from fsmctl.model.noise import GILBERT_ELLIOTT_KEYS
from fsmctl.model.scenario import Scenario
from fsmctl.model.topology import schedule_weight

__all__ = [
    "PackedProblem",
    "HardwarePack",
    "pack",
    "output_buffer_bytes",
    "pack_hardware",
    "batch_key",
    "stack",
    "wheel_command_samples",
]


def output_buffer_bytes(
    n_agents: int,
    n_rows: int,
    n_broadcast: int = 3,
    n_states: int = 0,
    n_wheels: int = 0,
    measured: bool = False,
    events: bool = False,
) -> int:
    """Bytes of a run's output buffers for ``n_rows`` output samples of ``n_agents`` agents (float64).

    Six ``(rows, n, 3)`` arrays (sigma, omega, sigma_e, omega_e, u, u_unsaturated), the broadcast
    ``(rows, n, n_broadcast)`` and law states ``(rows, n, n_states)``, wheel speeds and torques
    ``(rows, n, n_wheels)`` each, the measured attitude and rate ``(rows, n, 3)`` each when ``measured``, time
    ``(rows,)``, sigma_d ``(rows, 3)``, the messages per output row ``(rows, n)`` (int64) when ``events`` (a run with a
    control period: event-triggered or periodic broadcasting) and three ``(n,)`` statistics: what
    :func:`fsmctl.simulation.simulator.simulate_packed` allocates (with ``rows = n_outputs + 1``) before the loop
    starts.
    """
    n, rows = int(n_agents), int(n_rows)
    per_agent = 6 * 3 + int(n_broadcast) + int(n_states) + 2 * int(n_wheels) + (6 if measured else 0) + int(events)
    return 8 * (rows * (per_agent * n + 1 + 3) + 3 * n)


@dataclass(frozen=True)
class HardwarePack:
    """The flight hardware of a run as the compiled loop reads it (all empty: the ideal loop).

    Shapes (``n`` agents, ``N`` wheels per agent, ``Q`` control instants, ``L`` links): ``wheel_axes``,
    ``wheel_pinv`` (n, N, 3); ``wheel_Js``, ``wheel_torque_max`` (n, N); ``wheel_params`` (n, N, 4) in the
    generated layout ``[speed_max, viscous, coulomb, coulomb_band]``; ``J_spin`` (n, 3, 3); ``wheel_speed0``
    (n, N); ``sensor_dtheta``, ``sensor_gyro`` (Q, n, 3); ``link_delay`` (L,) in control instants;
    ``link_lost`` (Q, L) uint8; ``wheel_allocation`` (0: scaled, 1: clipped), ``wheel_gate`` (0: continuous, 1:
    step_start), ``wheel_command`` (Q, n, N) open-loop motor torques at the control instants, or None.
    """

    n_wheels: int = 0
    sensors: bool = False
    links_imperfect: bool = False
    n_samples: int = 0
    wheel_axes: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 3)))
    wheel_pinv: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 3)))
    wheel_Js: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    wheel_torque_max: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    wheel_params: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 4)))
    J_spin: np.ndarray = field(default_factory=lambda: np.zeros((0, 3, 3)))
    wheel_speed0: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    sensor_dtheta: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 3)))
    sensor_gyro: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 3)))
    link_delay: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int32))
    link_lost: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), dtype=np.uint8))
    # wheels as Basilisk flies them: the limit rules (0 scaled / 1 clipped; 0 continuous / 1 step_start) and the
    # open-loop motor torques at the control instants, (Q, n, N), or None
    wheel_allocation: int = 0
    wheel_gate: int = 0
    wheel_command: np.ndarray | None = None


def delay_instants(delay: np.ndarray, period: float) -> np.ndarray:
    """Link delays in control instants: the value delivered at ``t_q`` is the sender's broadcast of the latest
    instant at or before ``t_q - delay``, i.e. of instant ``q - ceil(delay / period)`` (float rounding of an exact
    multiple forgiven)."""
    d = np.asarray(delay, dtype=float) / period
    q = np.maximum(0, np.ceil(d - 1e-9 * np.maximum(1.0, d)))
    return np.minimum(q, np.iinfo(np.int32).max).astype(np.int32)


def wheel_command_samples(scenario: Scenario, n_steps: int, hold_steps: int, wheel_commands=None) -> np.ndarray | None:
    """The open-loop wheel motor torques at the control instants ``q * control_period``, ``(Q, n, N)``, or None.

    From the scenario's table (``actuator.wheel_commands``, zero-order hold) or from ``wheel_commands``: a callable
    ``f(t) -> (n_agents, n_wheels)`` sampled at each instant, or an array ``(Q, n_agents, n_wheels)`` of those samples.
    Both given, or a value of the wrong shape or not finite: :class:`~fsmctl.errors.InputError`.
    """

    act = scenario.actuator
    table = act.wheel_commands if act.enabled else None
    if wheel_commands is None and table is None:
        return None
    n, N = scenario.n_agents, act.n_wheels
    if not act.enabled:
        raise InputError("wheel_commands: the scenario flies no reaction wheels (actuator.kind = 'ideal')")
    if wheel_commands is not None and table is not None:
        raise InputError("wheel_commands: given both to simulate and in the scenario (actuator.wheel_commands)")
    period = scenario.simulation.control_period
    if not (period > 0 and hold_steps > 0):
        raise InputError("wheel_commands: act at the control instants; set simulation.control_period > 0")
    Q = n_steps // hold_steps + 1
    instants = np.arange(Q) * period
    if table is not None:
        return sample_wheel_commands(np.array(table.time), table.table(n), instants)
    if callable(wheel_commands):
        out = np.empty((Q, n, N))
        for q, t in enumerate(instants):
            v = np.asarray(wheel_commands(float(t)), dtype=float)
            if v.shape != (n, N):
                raise InputError(f"wheel_commands({float(t)!r}): expected an array of shape ({n}, {N}), got {v.shape}")
            out[q] = v
    else:
        out = np.asarray(wheel_commands, dtype=float)
        if out.shape != (Q, n, N):
            raise InputError(
                f"wheel_commands: expected a callable f(t) -> ({n}, {N}) or an array ({Q}, {n}, {N}) (one per control "
                f"instant), got shape {out.shape}"
            )
    if not np.all(np.isfinite(out)):
        q = int(np.argwhere(~np.isfinite(out))[0][0])
        raise InputError(f"wheel_commands: not finite at t = {float(instants[q])!r} s")
    return np.ascontiguousarray(out)


def pack_hardware(scenario: Scenario, n_steps: int, hold_steps: int, wheel_commands=None) -> HardwarePack:
    """The scenario's actuator, sensors and links as arrays (:class:`HardwarePack`); the noise of the run is
    drawn here, from ``simulation.seed`` (:func:`fsmctl.model.noise.hardware_noise`); ``wheel_commands``: as
    :func:`wheel_command_samples`."""
    act, sensors, links = scenario.actuator, scenario.sensors, scenario.links
    n = scenario.n_agents
    out: dict = {}
    command = wheel_command_samples(scenario, n_steps, hold_steps, wheel_commands)
    if act.enabled:
        out.update(
            wheel_allocation=1 if act.allocation == "clipped" else 0,
            wheel_gate=1 if act.speed_gate == "step_start" else 0,
            wheel_command=command,
        )
        if command is not None:
            out.update(n_samples=command.shape[0])
        G = act.spin_axes()
        N = G.shape[1]
        Js = act.per_wheel("spin_inertia")
        params = np.stack(
            [
                act.per_wheel("max_speed"),
                act.per_wheel("viscous_friction"),
                act.per_wheel("coulomb_friction"),
                np.full(N, act.coulomb_band),
            ],
            axis=1,
        )
        J_spin = act.spin_inertia_matrix()
        out.update(
            n_wheels=N,
            wheel_axes=np.broadcast_to(G.T, (n, N, 3)).copy(),
            wheel_pinv=np.broadcast_to(distribution_matrix(G), (n, N, 3)).copy(),
            wheel_Js=np.broadcast_to(Js, (n, N)).copy(),
            wheel_torque_max=np.broadcast_to(act.per_wheel("max_torque"), (n, N)).copy(),
            wheel_params=np.broadcast_to(params, (n, N, 4)).copy(),
            J_spin=np.broadcast_to(J_spin, (n, 3, 3)).copy(),
            wheel_speed0=np.broadcast_to(act.per_wheel("initial_speed"), (n, N)).copy(),
        )
    links_on = scenario.links_active
    if sensors.enabled or links_on:
        from fsmctl.model.noise import hardware_noise

        period = scenario.simulation.control_period
        Q = n_steps // hold_steps + 1
        topo = scenario.topology.links
        receivers = [lk.receiver for lk in topo]
        senders = [lk.sender for lk in topo]
        gyro = sensors.gyro
        noise = hardware_noise(
            scenario.simulation.seed,
            n,
            Q,
            period,
            star_tracker_std=None if sensors.star_tracker is None else np.array(sensors.star_tracker.noise_std),
            gyro=None
            if gyro is None
            else {
                "angle_random_walk": gyro.angle_random_walk,
                "rate_random_walk": gyro.rate_random_walk,
                "bias": np.array(gyro.bias),
            },
            **(_loss_model(links, receivers, senders) if links_on else {}),
        )
        out.update(n_samples=Q)
        if sensors.enabled:
            out.update(sensors=True, sensor_dtheta=noise["dtheta"], sensor_gyro=noise["gyro_error"])
        if links_on:
            lost = noise["lost"] if noise["lost"].shape[1] == len(topo) else np.zeros((Q, len(topo)), np.uint8)
            out.update(
                links_imperfect=True,
                # a delay beyond the run delivers the instant-0 value throughout: Q instants are as good as more
                link_delay=np.minimum(delay_instants(links.per_link(receivers, senders, "delay"), period), Q),
                link_lost=np.ascontiguousarray(lost, dtype=np.uint8),
            )
    return HardwarePack(**out)


def _loss_model(links, receivers, senders) -> dict:
    """The keyword of :func:`~fsmctl.model.noise.hardware_noise` that draws the links' losses, per the loss model."""
    if links.loss_model == "bernoulli":
        return {"loss_probability": links.per_link(receivers, senders, "loss_probability")}

    return {"gilbert_elliott": {k: links.per_link(receivers, senders, k) for k in GILBERT_ELLIOTT_KEYS}}


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
    x0: np.ndarray  # (3 + (6 + n_states + n_wheels) n,)
    hardware: HardwarePack = field(default_factory=HardwarePack)
    trigger_every: int = 0
    """event-triggered communication: 0 broadcasts at every control evaluation; m > 0 checks the law's trigger at
    every m-th control instant (:meth:`fsmctl.model.laws.LawTrigger.check_every`)"""

    @property
    def n_states(self) -> int:
        """Law states per agent."""
        return self.law.n_states

    @property
    def n_broadcast(self) -> int:
        return self.law.n_broadcast

    @property
    def n_wheels(self) -> int:
        """Reaction wheels per agent (0: the ideal torque source)."""
        return self.hardware.n_wheels

    @property
    def stride(self) -> int:
        """State components per agent: sigma (3), omega (3), the law's states, the wheel speeds."""
        return 6 + self.law.n_states + self.hardware.n_wheels

    def agent_slice(self, i: int) -> slice:
        """Where agent ``i``'s ``[sigma, omega, z, Omega]`` sits in the state vector."""
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
        return output_buffer_bytes(
            self.n_agents,
            self.n_outputs + 1,
            self.n_broadcast,
            self.n_states,
            self.n_wheels,
            self.hardware.sensors,
            self.hold_steps > 0,
        )

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


def pack(scenario: Scenario, law: LawCode | str | None = None, *, wheel_commands=None) -> PackedProblem:
    """Flatten a validated scenario (flying ``law``, default the scenario's ``controller.law``).

    ``wheel_commands``: open-loop wheel motor torques (:func:`wheel_command_samples`).  Another ``law`` is flown by the rule of :meth:`fsmctl.Scenario.replace`: the scenario's written keys that it
    declares apply, the others are dropped (one :class:`~fsmctl.model.laws.LawSwitchWarning` says which).
    """
    if law is not None and resolve_law(law).folder != scenario.law.folder:
        scenario = scenario.replace(controller={"law": str(resolve_law(law).folder)})
    law = resolve_law(scenario.controller.law)
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
    hardware = pack_hardware(scenario, sim.n_steps, sim.hold_steps, wheel_commands)
    nz, nw = law.n_states, hardware.n_wheels
    stride = 6 + nz + nw
    z0 = initial_law_states(law)
    x0 = np.empty(3 + stride * n)
    x0[:3] = scenario.reference.sigma0
    for i, a in enumerate(agents):
        x0[3 + stride * i : 6 + stride * i] = a.sigma0
        x0[6 + stride * i : 9 + stride * i] = a.omega0
        x0[9 + stride * i : 9 + nz + stride * i] = z0
        if nw:
            x0[9 + nz + stride * i : 3 + stride * (i + 1)] = hardware.wheel_speed0[i]
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
        hardware=hardware,
        trigger_every=0 if law.trigger is None else law.trigger.check_every(sim.control_period),
    )


def batch_key(p: PackedProblem) -> tuple | None:
    """What runs flown together in one compiled loop must share (:func:`stack`), or None for a run that flies alone.

    Same law (folder), error model, fixed-step RK4 with the same ``t0``, ``dt``, number of steps, output grid and
    control hold, the same reference (its sinusoid and ``sigma_d(0)``, bit for bit) and agents per run; no flight
    hardware (wheels, sensors, imperfect links), no event trigger, and the RK4 integrator only (dopri45's steps depend on every state).
    Gains, inertias, initial states, disturbances, torque limits and topologies may differ.

    Parameters
    ----------
    p : PackedProblem
        A packed run.

    Returns
    -------
    tuple or None
        Equal for runs that can fly together; None for a run that flies alone.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.model.problem import batch_key, pack
    >>> s = fsmctl.paper_scenario("1")
    >>> batch_key(pack(s)) == batch_key(pack(s.replace(controller={"c1": 1.0})))
    True
    >>> batch_key(pack(s.replace(simulation={"integrator": "dopri45"}))) is None
    True
    """
    hw = p.hardware
    if p.integrator != 0 or hw.n_wheels or hw.sensors or hw.links_imperfect or p.trigger_every:
        return None  # event-triggered runs fly alone: their per-link message counts are the run's own
    ref = np.ascontiguousarray(p.ref_params, dtype=float).tobytes() + np.ascontiguousarray(p.x0[:3]).tobytes()
    return (str(p.law.folder), p.error_model, p.n_agents, p.t0, p.dt, p.n_steps, p.output_every, p.hold_steps, ref)


def stack(problems) -> PackedProblem:
    """Several packed runs (equal :func:`batch_key`) as one problem of ``R n`` agents: a block-diagonal formation.

    Member ``m``'s agents are agents ``m n .. (m + 1) n - 1`` of the stack, its links come in their own order with
    the agent indices shifted by ``m n`` (so every receiver's neighbour sums add the same terms in the same order),
    and the reference ``sigma_d`` is shared.  Fixed-step RK4 is componentwise and no member's right-hand side reads
    another's agents, so each member's trajectory in the stack is its trajectory alone, bit for bit.

    Parameters
    ----------
    problems : iterable of PackedProblem
        Runs with equal :func:`batch_key` (else :class:`ValueError`).

    Returns
    -------
    PackedProblem
        The block-diagonal formation (the problem itself for one run).

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.model.problem import pack, stack
    >>> s = fsmctl.paper_scenario("1")
    >>> both = stack([pack(s), pack(s.replace(controller={"c1": 1.0}))])
    >>> both.n_agents, both.n_links
    (12, 60)
    """
    problems = list(problems)
    if not problems:
        raise ValueError("stack: no problems")
    first = problems[0]
    key = batch_key(first)
    if key is None or any(batch_key(q) != key for q in problems[1:]):
        raise ValueError("stack: the problems cannot fly together (see batch_key)")
    if len(problems) == 1:
        return first
    n = first.n_agents
    starts, offset = [], 0
    for q in problems:
        starts.append(q.sched_start + offset)
        offset += q.sched_times.size

    def cat(name, dtype=float):
        return np.concatenate([np.asarray(getattr(q, name), dtype=dtype) for q in problems])

    return replace(
        first,
        n_agents=n * len(problems),
        J_true=cat("J_true"),
        J0=cat("J0"),
        params=cat("params"),
        u_max=cat("u_max"),
        dist_params=cat("dist_params"),
        link_receiver=np.concatenate([q.link_receiver + m * n for m, q in enumerate(problems)]).astype(np.int32),
        link_sender=np.concatenate([q.link_sender + m * n for m, q in enumerate(problems)]).astype(np.int32),
        link_k_i=cat("link_k_i"),
        sched_period=cat("sched_period"),
        sched_phase=cat("sched_phase"),
        sched_start=np.concatenate(starts).astype(np.int32),
        sched_count=cat("sched_count", np.int32),
        sched_times=cat("sched_times"),
        sched_values=cat("sched_values"),
        x0=np.concatenate([first.x0[:3]] + [q.x0[3:] for q in problems]),
    )
