"""python-control plug-in: the closed-loop formation of a scenario, continuous time or sampled-data.

:func:`formation` interconnects the reference generator, the plants ``sc1..scn`` and the controllers
``ctrl1..ctrln`` of :mod:`fsmctl.plugin.iosys` (the wheel plants of :mod:`fsmctl.plugin.hardware` with
``[actuator] kind = "reaction_wheels"``), wired by the scenario's topology, into a :class:`FormationSystem`: a
:class:`control.InterconnectedSystem` whose law parameters also take their bare names, that pickles and that
linearizes exactly (:mod:`fsmctl.plugin.jacobians`).  A scenario with ``simulation.control_period > 0`` gives the
discrete-time loop of :func:`sampled_formation`, every block sampled at the control period
(:mod:`fsmctl.plugin.sampled`).
"""

from __future__ import annotations

import functools
import re
from collections.abc import Mapping, Sequence
from typing import Any

import control as ct
import numpy as np

from fsmctl.model.actuators import sample_wheel_commands
from fsmctl.model.laws import LawError, parameter_matrix
from fsmctl.model.scenario import Scenario, ScenarioError
from fsmctl.plugin.arguments import _labels, _show, _system_name, _timebase
from fsmctl.plugin.formation_system import FormationSystem
from fsmctl.plugin.hardware import reaction_wheel_spacecraft
from fsmctl.plugin.iosys import (
    DEFAULT_NORMALIZATION_GAIN,
    Neighbour,
    law_controller,
    reference_generator,
    spacecraft,
)
from fsmctl.plugin.parameters import (
    _Params,
    law_parameter_values,
)
from fsmctl.plugin.sampled import _discrete, zoh
from fsmctl.plugin.sensors import rate_gyro, star_tracker
from fsmctl.plugin.system import ParameterizedSystem

__all__ = ["formation", "sampled_formation"]

_BlockSpec = Any
"""``None``, a python-control system, a sequence with one entry per agent, or ``hook(i, agent)``."""


def _signal_bases(labels: Sequence[str]) -> dict[str, list[str]]:
    """Signal labels by base name (``"tau[0]"`` -> ``"tau"``; a label without an index is its own base)."""
    out: dict[str, list[str]] = {}
    for label in labels:
        m = re.fullmatch(r"(.+)\[(\d+)\]", label)
        out.setdefault(m.group(1) if m else label, []).append(label)
    return out


def _agent_blocks(spec: _BlockSpec, kind: str, scenario: Scenario) -> list[tuple[ct.InputOutputSystem, ...]]:
    """Each agent's blocks (a tuple, possibly empty) from ``formation``'s ``actuators``/``sensors`` argument."""
    n = scenario.n_agents
    where = f"formation: {kind}"
    if spec is None:
        return [()] * n
    if isinstance(spec, ct.InputOutputSystem):
        entries = [spec] * n
    elif callable(spec):
        entries = [spec(i, agent) for i, agent in enumerate(scenario.agents)]
    elif isinstance(spec, Sequence) and not isinstance(spec, (str, bytes)):
        if len(spec) != n:
            raise ScenarioError(f"{where}: expected one entry per agent ({n}), got {len(spec)}")
        entries = list(spec)
    else:
        raise ScenarioError(
            f"{where}: expected None, a python-control system, a sequence with one entry per agent or a callable "
            f"(i, agent) -> system, got {_show(spec)}"
        )
    out = []
    for i, entry in enumerate(entries):
        blocks = () if entry is None else (entry,) if isinstance(entry, ct.InputOutputSystem) else entry
        if (
            isinstance(blocks, (str, bytes))
            or not isinstance(blocks, Sequence)
            or not all(isinstance(b, ct.InputOutputSystem) for b in blocks)
        ):
            raise ScenarioError(
                f"{where}: agent {i + 1}: expected None, a python-control system or a sequence of them, got "
                f"{_show(entry)}"
            )
        if kind == "actuators" and len(blocks) > 1:
            raise ScenarioError(
                f"{where}: agent {i + 1}: one actuator block per agent, got {len(blocks)} (chain them into one "
                "with control.interconnect)"
            )
        for b in blocks:
            if b.isdtime(strict=True):
                raise ScenarioError(
                    f"{where}: agent {i + 1}: block {b.name!r} is discrete time (dt = {b.dt}); the formation is "
                    "continuous time: make it with dt=0 (e.g. star_tracker(..., dt=0))"
                )
        out.append(tuple(blocks))
    return out


def _check_from_plant(block: ct.InputOutputSystem, base: str, labels: list[str], plant, where: str, role: str) -> None:
    """A block input ``base`` that is not a law signal must be an output of the plant, with the same components."""
    have = _signal_bases(plant.output_labels)
    if base not in have:
        raise ScenarioError(
            f"{where}: block {block.name!r} has input {base!r}, which is neither {role} nor an output of the plant "
            f"(its outputs: {', '.join(have)})"
        )
    if labels != have[base]:
        raise ScenarioError(
            f"{where}: block {block.name!r}: input {base!r} has components {labels}, expected {have[base]}"
        )


def _expect(block: ct.InputOutputSystem, bases: dict[str, list[str]], base: str, side: str, where: str, why: str):
    want = _labels(base)
    if bases.get(base) != want:
        got = bases.get(base)
        raise ScenarioError(
            f"{where}: block {block.name!r} needs the {side} {want[0][:-3]}[0..2] ({why}); "
            + (f"it has {got}" if got else f"its {side}s are {list(bases) or 'none'}")
        )


def _wire_actuator(i: int, block, plant, torque_input: str, where: str):
    """Connections that put ``block`` between ``ctrl<i>.tau`` and the plant's torque input ``torque_input``."""
    b = block.copy(name=f"actuator{i}")
    ins, outs = _signal_bases(b.input_labels), _signal_bases(b.output_labels)
    _expect(block, ins, "tau_command", "input", where, "the law's torque command")
    _expect(block, outs, "tau", "output", where, "the torque applied to the spacecraft")
    connections = [[f"actuator{i}.tau_command", f"ctrl{i}.tau"], [f"sc{i}.{torque_input}", f"actuator{i}.tau"]]
    for base, labels in ins.items():
        if base != "tau_command":
            _check_from_plant(block, base, labels, plant, where, "tau_command (the law's torque)")
            connections.append([f"actuator{i}.{base}", f"sc{i}.{base}"])
    ignored = [f"actuator{i}.{base}" for base in outs if base != "tau"]
    return b, connections, ignored


_MEASURED = {"sigma_measured": "sigma", "omega_measured": "omega"}
"""A sensor block's outputs and the controller inputs they feed."""


def _wire_sensors(i: int, blocks, plant, where: str):
    """Connections that put each sensor block between the plant's outputs and ``ctrl<i>``'s ``sigma``/``omega``."""
    systems, connections, ignored, fed = [], [], [], {}
    for k, block in enumerate(blocks, start=1):
        sname = f"sensor{i}" if len(blocks) == 1 else f"sensor{i}_{k}"
        b = block.copy(name=sname)
        ins, outs = _signal_bases(b.input_labels), _signal_bases(b.output_labels)
        measured = [base for base in _MEASURED if base in outs]
        if not measured:
            raise ScenarioError(
                f"{where}: block {block.name!r} needs the output sigma_measured[0..2] or omega_measured[0..2] (what "
                f"the law receives); its outputs are {list(outs) or 'none'}"
            )
        for base in measured:
            _expect(block, outs, base, "output", where, "what the law receives")
            if base in fed:
                raise ScenarioError(f"{where}: blocks {fed[base]!r} and {block.name!r} both output {base}")
            fed[base] = block.name
            connections.append([f"ctrl{i}.{_MEASURED[base]}", f"{sname}.{base}"])
        for base, labels in ins.items():
            _check_from_plant(block, base, labels, plant, where, "a plant output")
            connections.append([f"{sname}.{base}", f"sc{i}.{base}"])
        ignored += [f"{sname}.{base}" for base in outs if base not in _MEASURED]
        systems.append(b)
    for base, signal in _MEASURED.items():
        if base not in fed:
            connections.append([f"ctrl{i}.{signal}", f"sc{i}.{signal}"])
    return systems, connections, ignored


def formation(
    scenario: Scenario,
    *,
    actuators: _BlockSpec = None,
    sensors: _BlockSpec = None,
    normalization_gain: float = DEFAULT_NORMALIZATION_GAIN,
    name: str = "formation",
    params: Mapping[str, Any] | None = None,
    dt: Any = None,
) -> FormationSystem:
    """The closed-loop formation of a scenario, flying its law (``scenario.law``), assembled with :func:`control.interconnect`.

    Subsystems: ``reference``, plants ``sc1..scn`` (true inertia ``J0 + delta_J`` and disturbance; with
    ``[actuator] kind = "reaction_wheels"`` the wheel plant of :func:`fsmctl.plugin.hardware.reaction_wheel_spacecraft`),
    controllers ``ctrl1..ctrln`` (:func:`law_controller` with the nominal ``J0`` and the agent's law parameters,
    :func:`fsmctl.model.laws.parameter_matrix`). Controller ``i`` receives the broadcast ``b_j`` of controller
    ``j`` (``s_j`` for the paper's law, eq 19) for each link ``i <- j`` of the topology.  Optional actuator and
    sensor blocks are inserted per agent and wired by their signal names.

    Reaction wheels: a law that commands its wheels (:attr:`fsmctl.model.laws.LawCode.n_wheels`, e.g.
    ``fsm_wheels``) drives ``sc<i>.u_wheels`` from ``ctrl<i>.u_wheels`` and reads the wheel speeds
    ``sc<i>.Omega`` (``sc<i>.u_command`` is then zero: the compiled loop's rule); any other law's torque is the
    plant's ``u_command``, split minimum-norm.  The inputs ``sc<i>_u_wheels[k]`` of the formation are open-loop
    per-wheel motor torques added to the law's before the torque limit, as :func:`fsmctl.simulate`'s
    ``wheel_commands`` (zero: none).  A scenario's table ``[actuator.wheel_commands]`` (it needs
    ``control_period > 0``) is the block ``wheel_commands`` of the sampled loop, held at the control instants as
    :func:`fsmctl.simulate` holds it; the inputs add to it.

    Parameters
    ----------
    scenario : Scenario
        The formation: agents, topology, reference, law.  With ``simulation.control_period > 0`` the loop is
        the discrete-time sampled-data loop of :func:`fsmctl.plugin.formation.sampled_formation` (the scenario's
        sensors included; imperfect links and ``actuators``/``sensors`` blocks refused).
    actuators : None, system, sequence or callable, optional
        A continuous-time python-control system inserted between controller ``i`` and plant ``i``: its inputs
        ``tau_command[0..2]`` receive the law's torque ``ctrl<i>.tau``, its outputs ``tau[0..2]`` drive the
        plant (``sc<i>.tau``; ``sc<i>.u_command`` of a wheel plant).  Further inputs named like a plant output
        (``sigma``, ``omega``, ...) are wired from that plant; further outputs are ignored.  One system: a copy
        for every agent; a sequence: one entry (a system or ``None``) per agent; a callable ``hook(i, agent)``
        (``i`` 0-based, ``agent`` the :class:`fsmctl.Agent`) returns the agent's block or ``None``.  The block
        of agent ``i`` is named ``actuator<i>``.
    sensors : None, system, sequence or callable, optional
        Continuous-time systems inserted between plant ``i`` and controller ``i``: inputs named like plant
        outputs (``sigma[0..2]``, ``omega[0..2]``) are wired from the plant, outputs ``sigma_measured[0..2]``
        and/or ``omega_measured[0..2]`` feed the controller's ``sigma``/``omega`` (the signals of
        :func:`fsmctl.plugin.hardware.star_tracker` and :func:`~fsmctl.plugin.hardware.rate_gyro` with
        ``dt=0``); what no block measures comes from the plant.  Given like ``actuators``, except that each
        agent's entry may also be a sequence of blocks (a star tracker and a gyro); named ``sensor<i>`` (or
        ``sensor<i>_<k>`` for several).
    normalization_gain : float
        Quaternion normalisation-drift gain of the plants and the reference (see :func:`spacecraft`).
    name : str
        Name of the interconnected system.
    params : mapping, optional
        Initial parameter values, as ``params=`` of :func:`control.input_output_response` takes them: a law
        parameter's bare name (every controller), a key (``"sc2_J"``, ``"ctrl1_c1"``) or the local name of the one
        subsystem that has it (``"omega_d"``); validated like the factories' arguments, stored in ``params``.
    dt : None, 0, True or float
        python-control's timebase.  ``None`` (default): the scenario's, continuous time (0) unless
        ``simulation.control_period = T > 0``, whose loop is discrete time with ``dt = T`` (the sampled-data loop
        of :func:`fsmctl.plugin.formation.sampled_formation`); a ``dt`` that is not the scenario's raises.

    Returns
    -------
    FormationSystem
        No inputs without reaction wheels (plot a response through :func:`fsmctl.formation_response`:
        python-control's own ``plot()`` asks for inputs); with them, the open-loop wheel commands
        ``sc<i>_u_wheels[k]`` (N m, Basilisk's ``motorTorque`` sign). States ``reference_q_d[0..3]``, then per agent ``sc<i>_q[0..3]``, ``sc<i>_omega[0..2]``
        (and the wheel speeds), then the controllers' law states ``ctrl<i>_<state>[k]`` if the law has any
        (:func:`initial_state` builds all of these from the scenario, :func:`mrp_state` maps them back to MRPs),
        then the states of the actuator and sensor blocks (pass ``[initial_state(s), x_blocks]``, or
        ``[initial_state(s), 0]`` for zeros).  Outputs ``sc<i>_sigma[k]`` (``|sigma| <= 1``: it jumps at 180 deg;
        compare two agents with :func:`fsmctl.attitude_error_angle`, not by differences),
        ``sc<i>_omega[k]``, ``sc<i>_tau[k]`` (the torque applied to the body: the actuator block's ``tau``,
        the wheels' reaction, else the law's output; the output labels of
        :meth:`fsmctl.simulation.result.SimulationResult.to_time_response`).  Parameters ``sc<i>_J``,
        ``ctrl<i>_J0``, ``ctrl<i>_<law parameter>``, ... of the subsystems; pass ``params={"sc2_J": ...}`` to
        change one agent, ``params={"c1": ...}`` (a law parameter's bare name) to change every agent's.

    Raises
    ------
    fsmctl.ScenarioError
        ``scenario`` not a :class:`fsmctl.Scenario`, or a sampled one with imperfect links or blocks; an actuator or sensor
        block whose signals do not fit (or any actuator block with a law that commands its wheels) (a missing ``tau_command``/``tau``/``*_measured`` signal, an input that
        is no plant output, the wrong number of components, two sensors measuring the same signal), a
        discrete-time block, or a sequence whose length is not the number of agents.

    Examples
    --------
    >>> import control as ct, numpy as np
    >>> import fsmctl
    >>> from fsmctl.plugin.iosys import initial_state
    >>> s = fsmctl.paper_scenario("1").replace(controller={"boundary_layer": 0.05})
    >>> loop = fsmctl.formation(s)
    >>> loop.nstates, loop.noutputs
    (46, 54)
    >>> float(loop.params["ctrl1_boundary_layer"])
    0.05
    >>> r = ct.input_output_response(loop, [0.0, 0.01], 0, initial_state(s))
    >>> r.outputs.shape
    (54, 2)

    A torque actuator with a first-order lag (0.1 s) for every agent, wired by its signal names:

    >>> names = lambda base: [f"{base}[{k}]" for k in range(3)]
    >>> lag = ct.ss(-10 * np.eye(3), 10 * np.eye(3), np.eye(3), 0, inputs=names("tau_command"), outputs=names("tau"))
    >>> lagged = fsmctl.formation(s, actuators=lag)
    >>> lagged.nstates, lagged.state_labels[46]
    (64, 'actuator1_x[0]')
    >>> r = ct.input_output_response(lagged, [0.0, 0.01], 0, [initial_state(s), 0])
    >>> r.outputs[6:9, -1].round(4).tolist()  # sc1_tau: 2 N m asked, 2 (1 - exp(-0.1)) applied after 0.01 s
    [0.1903, 0.1903, -0.1903]
    """
    if not isinstance(scenario, Scenario):
        raise ScenarioError(f"formation: expected a Scenario, got {type(scenario).__name__}")
    name = _system_name(name, "formation")
    if name is None:
        raise ScenarioError("formation: name must be a non-empty string without '.', got None")
    if scenario.simulation.control_period > 0:
        if actuators is not None or sensors is not None:
            raise ScenarioError(
                "formation: actuators= and sensors= blocks are continuous time; the loop of a scenario with "
                "simulation.control_period > 0 is discrete time (fsmctl.plugin.formation.sampled_formation): wire "
                "discrete-time blocks into it by hand"
            )
        if dt not in (None, True) and dt != scenario.simulation.control_period:
            raise ScenarioError(
                f"formation: dt={dt!r}: the loop of this scenario is discrete time with dt = simulation.control_period "
                f"= {scenario.simulation.control_period} (give None, True or that period)"
            )
        return sampled_formation(scenario, normalization_gain=normalization_gain, name=name, params=params)
    _timebase(dt, False, "formation")  # continuous time: 0 or None
    n = scenario.n_agents
    law = scenario.law
    wheels = scenario.actuator.enabled
    law_wheels = wheels and law.n_wheels > 0  # the law drives sc<i>.u_wheels, reads sc<i>.Omega
    if law_wheels and actuators is not None:
        raise ScenarioError(
            f"formation: actuators: the law {law.name} commands its reaction wheels (sc<i>.u_wheels), not a body "
            "torque: an actuator block between its torque and the plant would not act"
        )
    act_blocks = _agent_blocks(actuators, "actuators", scenario)
    sensor_blocks = _agent_blocks(sensors, "sensors", scenario)
    controller_list = _scenario_controllers(scenario)
    bname = law.broadcast_name
    plants, controllers, blocks, connections, ignored_outputs = [], [], [], [], []
    torque_from = []
    for i, agent in enumerate(scenario.agents, start=1):
        if wheels:
            plant = reaction_wheel_spacecraft(
                agent.J_true,
                scenario.actuator,
                disturbance=agent.disturbance,
                normalization_gain=normalization_gain,
                name=f"sc{i}",
            )
        else:
            plant = spacecraft(
                agent.J_true, disturbance=agent.disturbance, normalization_gain=normalization_gain, name=f"sc{i}"
            )
        plants.append(plant)
        nbrs = _agent_neighbours(scenario, i - 1)
        controllers.append(controller_list[i - 1])
        torque_input = "u_command" if wheels else "tau"
        connections += [
            [f"ctrl{i}.sigma_d", "reference.sigma_d"],
            [f"ctrl{i}.omega_d", "reference.omega_d"],
            [f"ctrl{i}.omega_d_dot", "reference.omega_d_dot"],
        ]
        if law_wheels:  # the engine's rule: the law's wheel commands, the minimum-norm split of no torque
            connections += [[f"sc{i}.u_wheels", f"ctrl{i}.u_wheels"], [f"ctrl{i}.Omega", f"sc{i}.Omega"]]
        elif act_blocks[i - 1]:
            b, conn, ign = _wire_actuator(
                i, act_blocks[i - 1][0], plant, torque_input, f"formation: actuators: agent {i}"
            )
            blocks.append(b)
            connections += conn
            ignored_outputs += ign
        else:
            connections.append([f"sc{i}.{torque_input}", f"ctrl{i}.tau"])
        sys_s, conn, ign = _wire_sensors(i, sensor_blocks[i - 1], plant, f"formation: sensors: agent {i}")
        blocks += sys_s
        connections += conn
        ignored_outputs += ign
        if law.n_broadcast:
            connections += [[f"ctrl{i}.{bname}_{nb.name}", f"ctrl{nb.name[2:]}.{bname}"] for nb in nbrs]
        # with wheels: their reaction on the body (SimulationResult.u); else what the actuator or the law applies
        torque_from.append("sc" if wheels else "actuator" if act_blocks[i - 1] else "ctrl")
    outlist = [
        f"{sys}{i}.{sig}"
        for i in range(1, n + 1)
        for sys, sig in (("sc", "sigma"), ("sc", "omega"), (torque_from[i - 1], "tau"))
    ]
    outputs = [f"sc{i}_{sig}[{k}]" for i in range(1, n + 1) for sig in ("sigma", "omega", "tau") for k in range(3)]
    # plants before controllers: the attitude states come first, in the layout of SimulationResult.to_time_response;
    # the blocks' states last, so that [initial_state(scenario), x_blocks] is the initial state
    systems = [reference_generator(scenario.reference.omega, normalization_gain=normalization_gain, name="reference")]
    ignored: dict[str, list[str]] = {}
    inplist, inputs = [], []
    if wheels:  # the wheel plants' extra signals (d: no external torque input; wheel speeds, momentum, torques)
        unused_in = ("d", "u_command") if law_wheels else ("d",)
        ignored["ignore_inputs"] = [f"sc{i}.{sig}" for i in range(1, n + 1) for sig in unused_in]
        unused_out = ("h_wheels", "wheel_torque") if law_wheels else ("Omega", "h_wheels", "wheel_torque")
        ignored_outputs += [f"sc{i}.{sig}" for i in range(1, n + 1) for sig in unused_out]
        if law_wheels:
            ignored_outputs += [f"ctrl{i}.tau" for i in range(1, n + 1)]
        # open-loop per-wheel commands, added to the law's (the engine's wheel_commands)
        nw = scenario.actuator.n_wheels
        inplist = [f"sc{i}.u_wheels[{k}]" for i in range(1, n + 1) for k in range(nw)]
        inputs = [f"sc{i}_u_wheels[{k}]" for i in range(1, n + 1) for k in range(nw)]
    if ignored_outputs:
        ignored["ignore_outputs"] = ignored_outputs
    loop = ct.interconnect(
        systems + plants + controllers + blocks,
        connections=connections,
        inplist=inplist,
        outlist=outlist,
        outputs=outputs,
        name=name,
        inputs=inputs,
        **ignored,
    )
    return _as_formation(loop, scenario, name, params)


def _as_formation(
    loop: ct.InterconnectedSystem, scenario: Scenario, name: str, params: Mapping[str, Any] | None = None
) -> FormationSystem:
    """``loop`` (the interconnection of ``scenario``'s reference, plants and ``ctrl<i>``) as a FormationSystem."""
    loop.__class__ = FormationSystem  # the same object, with bare law-parameter names in params
    loop.law_parameters = tuple(p.name for p in scenario.law.parameters)
    loop.controllers = tuple(f"ctrl{i}" for i in range(1, scenario.n_agents + 1))
    loop.scenario = scenario
    loop.updfcn, loop.outfcn = loop._ic_update, loop._ic_output
    loop.params = _Params(loop.params, f"formation {name!r}", loop.law_parameters)
    if params is not None:
        if not isinstance(params, Mapping):
            raise ScenarioError(
                f"formation: params: expected a mapping of parameter names to values, got {_show(params)}"
            )
        owners = {
            key: (sub, local)
            for sub in loop.syslist
            if isinstance(sub, ParameterizedSystem)
            for local, key in sub._keys.items()
        }
        for key, value in loop._explicit(params).items():
            if key in owners:  # validated like the factory's argument, stored in the subsystem and the loop
                sub, local = owners[key]
                sub.local_params[local] = value
                value = sub.params[key]
            loop.params[key] = value
    return loop


def _agent_neighbours(scenario: Scenario, i: int, phase_lead: float = 0.0) -> list[Neighbour]:
    """The links ``i <- j`` of agent ``i`` (0-based) as :class:`Neighbour` s, schedules read ``phase_lead`` later."""
    return [
        Neighbour(f"sc{link.sender + 1}", link.k_i, link.k_j, link.phase + phase_lead)
        for link in scenario.topology.links
        if link.receiver == i
    ]


def _scenario_controllers(scenario: Scenario, phase_lead: float = 0.0) -> list[ParameterizedSystem]:
    """The agents' controllers ``ctrl1..ctrln`` of :func:`formation` (a sampled loop reads the link weights of an
    instant ``phase_lead`` later, as the compiled loop does)."""
    law, c = scenario.law, scenario.controller
    try:
        rows = parameter_matrix(law, scenario)
    except LawError as exc:
        raise ScenarioError(str(exc)) from None
    act = scenario.actuator if scenario.actuator.enabled and law.n_wheels else None  # the law's wheels
    return [
        law_controller(
            law,
            agent.J0_array,
            parameters=law_parameter_values(law, rows[i]),
            u_max=c.effective_torque_limit,
            error_model=c.error_model,
            neighbours=_agent_neighbours(scenario, i, phase_lead),
            name=f"ctrl{i + 1}",
            actuator=act,
        )
        for i, agent in enumerate(scenario.agents)
    ]


def _stateless(t, x, u, params) -> np.ndarray:
    """The (empty) state update of a block without states, a module function so that the block pickles."""
    return np.zeros(0)


def _table_row(time: np.ndarray, torque: np.ndarray, t, x, u, params) -> np.ndarray:
    """The wheel commands of the table ``(time, torque)`` held at ``t`` (:func:`sample_wheel_commands`)."""
    return sample_wheel_commands(time, torque, np.array([t], dtype=float))[0].ravel()


def _wheel_command_table(scenario: Scenario) -> ct.NonlinearIOSystem:
    """The scenario's open-loop table ``actuator.wheel_commands`` as the discrete-time block ``wheel_commands``
    (``dt = control_period``, no inputs): its outputs ``sc<i>_u_wheels[k]`` at the instant ``t_q`` are the table's
    row held at ``t_q``, the commands :func:`fsmctl.simulate` adds at that instant (zero before the first time)."""
    act, n = scenario.actuator, scenario.n_agents
    table = act.wheel_commands
    return ct.nlsys(
        _stateless,
        functools.partial(_table_row, np.array(table.time, dtype=float), table.table(n)),
        inputs=0,
        states=0,
        outputs=[f"sc{i}_u_wheels[{k}]" for i in range(1, n + 1) for k in range(act.n_wheels)],
        dt=scenario.simulation.control_period,
        name="wheel_commands",
    )


def _flat_signals(syslist: Sequence[ct.InputOutputSystem], attr: str) -> list[str]:
    """``"<system>.<signal>"`` for every input (``attr="input_labels"``) or output of the stacked subsystems."""
    return [f"{sys.name}.{label}" for sys in syslist for label in getattr(sys, attr)]


def _sampled_subsystem(sys: ct.InputOutputSystem, scenario: Scenario, T: float, h: float) -> ct.InputOutputSystem:
    """The discrete-time twin of one subsystem of the continuous loop of ``scenario``."""
    if sys.name.startswith("ctrl"):
        i = int(sys.name[4:])
        return _controllers(scenario, T, h)[i - 1]
    if sys.name.startswith("sensor"):
        return _sensor(sys, scenario, T)
    return zoh(sys, T, step=h, name=sys.name)


def _controllers(scenario: Scenario, T: float, h: float) -> list[ParameterizedSystem]:
    """The agents' discrete laws, built like :func:`fsmctl.formation` builds them, weights read as the compiled
    loop reads them at an instant (at the midpoint ``t_k + h / 2`` of its first RK4 step)."""
    return [_discrete(c, T) for c in _scenario_controllers(scenario, phase_lead=h / 2)]


def _sensor(sys: ct.InputOutputSystem, scenario: Scenario, T: float) -> ct.InputOutputSystem:
    """The scenario's sensor block ``sensor<i>_<k>`` (held samples, continuous time) as a discrete-time twin."""
    i = int(sys.name[6:].split("_")[0])
    s = scenario.sensors
    common = {
        "horizon": scenario.simulation.t_final,
        "seed": scenario.simulation.seed,
        "agent": i - 1,
        "name": sys.name,
    }
    if "sigma_measured[0]" in sys.output_labels:
        return star_tracker(s.star_tracker.noise_std, T, **common)
    g = s.gyro
    return rate_gyro(g.angle_random_walk, g.rate_random_walk, g.bias, T, **common)


def _scenario_sensors(scenario: Scenario) -> list[tuple[ct.InputOutputSystem, ...]] | None:
    """Each agent's star tracker and rate gyro from ``scenario.sensors`` (continuous time, samples held)."""
    s = scenario.sensors
    if not s.enabled:
        return None
    T, sim = scenario.simulation.control_period, scenario.simulation
    out = []
    for i in range(scenario.n_agents):
        common = {"horizon": sim.t_final, "seed": sim.seed, "agent": i, "dt": 0}
        blocks = []
        if s.star_tracker is not None:
            blocks.append(star_tracker(s.star_tracker.noise_std, T, **common))
        if s.gyro is not None:
            g = s.gyro
            blocks.append(rate_gyro(g.angle_random_walk, g.rate_random_walk, g.bias, T, **common))
        out.append(tuple(blocks))
    return out


def _compiled_only(scenario: Scenario, where: str) -> None:
    """Refuse, naming the setting, what only the compiled loop flies (before the continuous copy is built, whose own
    checks would name the wrong cause)."""
    if scenario.actuator.enabled and scenario.actuator.speed_gate != "continuous":
        raise ScenarioError(
            f"{where}: actuator.speed_gate = {scenario.actuator.speed_gate!r} (the speed limit decided at the start "
            "of each step of the compiled loop, Basilisk's timing) is flown by fsmctl.simulate only; the "
            "python-control wheel plant models speed_gate = 'continuous'"
        )
    if scenario.law.trigger is not None:
        raise ScenarioError(
            f"{where}: the law {scenario.law.name} is event-triggered (it declares a trigger), which the "
            "python-control systems do not model (their broadcast is sent at every instant); fly it with "
            "fsmctl.simulate"
        )


def sampled_formation(
    scenario: Scenario,
    *,
    normalization_gain: float | None = None,
    name: str = "formation",
    params: Mapping[str, Any] | None = None,
) -> FormationSystem:
    """The sampled-data closed loop of a scenario with ``simulation.control_period = T > 0``, in discrete time.

    :func:`fsmctl.formation` returns it for such a scenario.  Every block is discrete time with ``dt = T``:
    the reference and the plants are :func:`zoh` samples of :func:`fsmctl.formation`'s continuous-time blocks
    (RK4 at ``simulation.dt`` inside each period, the law's torque held: the compiled simulator's rule), the
    controllers are :func:`discrete_law_controller` s (the law and its states at the instants), and the
    scenario's star tracker and rate gyro (``[sensors]``) are :func:`fsmctl.plugin.hardware.star_tracker` and
    :func:`~fsmctl.plugin.hardware.rate_gyro` with ``dt = T``, drawn from ``simulation.seed`` as
    :func:`fsmctl.simulate` draws them.  Signals, states, parameters and their names are those of the
    continuous-time :func:`fsmctl.formation` (states ``[initial_state(scenario), ...]``; with reaction wheels the
    inputs ``sc<i>_u_wheels[k]``, held over each period, and the scenario's ``[actuator.wheel_commands]`` table
    as the block ``wheel_commands``).

    Parameters
    ----------
    scenario : Scenario
        A formation with ``simulation.control_period > 0`` (a multiple of ``simulation.dt``).  Imperfect links
        (``[links]``) are refused: wire :func:`fsmctl.plugin.hardware.link` blocks by hand, or fly the scenario
        with :func:`fsmctl.simulate`.
    normalization_gain : float, optional
        Quaternion normalisation-drift gain of the plants and the reference (see :func:`fsmctl.spacecraft`).
    name : str
        Name of the interconnected system.
    params : mapping, optional
        Initial parameter values, as :func:`fsmctl.formation`'s ``params=`` (bare law names, full keys).

    Returns
    -------
    FormationSystem
        Discrete time, ``loop.dt == control_period``; run it with :func:`control.input_output_response` at the
        instants ``T = np.arange(N + 1) * control_period`` (outputs at the instants, the applied torque of each
        instant held until the next).

    Raises
    ------
    fsmctl.ScenarioError
        ``scenario`` not a Scenario, ``control_period = 0`` (use :func:`fsmctl.formation`), imperfect links, or what
        only the compiled loop flies: ``actuator.speed_gate = "step_start"`` or an event-triggered law.

    Examples
    --------
    >>> import control as ct, numpy as np, fsmctl
    >>> s = fsmctl.paper_scenario("1").replace(simulation={"t_final": 0.5, "control_period": 0.1})
    >>> loop = fsmctl.formation(s)  # control_period > 0: this function
    >>> loop.dt, loop.nstates
    (0.1, 46)
    >>> r = ct.input_output_response(loop, np.arange(6) * 0.1, 0, fsmctl.initial_state(s))
    >>> compiled = fsmctl.simulate(s.replace(simulation={"output_interval": 0.1}))
    >>> sigma = [list(loop.output_labels).index(f"sc{i}_sigma[{k}]") for i in range(1, 7) for k in range(3)]
    >>> bool(np.abs(r.outputs[sigma].T - compiled.sigma.reshape(6, -1)).max() < 1e-9)
    True
    """
    where = "sampled_formation"
    if not isinstance(scenario, Scenario):
        raise ScenarioError(f"{where}: expected a Scenario, got {type(scenario).__name__}")
    sim = scenario.simulation
    if not sim.control_period > 0:
        raise ScenarioError(
            f"{where}: simulation.control_period is 0 (continuous control): fsmctl.formation builds that loop"
        )
    if scenario.links_active:
        raise ScenarioError(
            f"{where}: imperfect links ([links]) are not part of the sampled loop: wire fsmctl.plugin.hardware.link "
            "blocks between the controllers by hand, or fly the scenario with fsmctl.simulate"
        )
    _compiled_only(scenario, where)
    T, h = sim.control_period, sim.dt
    gain = DEFAULT_NORMALIZATION_GAIN if normalization_gain is None else normalization_gain
    # the continuous-time loop gives the blocks and their wiring (one source of both); each block is then
    # replaced by its discrete-time twin, with the same name and signals, and the wiring is made again
    wheel_table = scenario.actuator.wheel_commands if scenario.actuator.enabled else None
    continuous = scenario.replace(
        simulation={"control_period": 0.0},
        sensors={"star_tracker": None, "gyro": None},
        **({"actuator": {"wheel_commands": None}} if wheel_table is not None else {}),
    )
    loop = formation(continuous, sensors=_scenario_sensors(scenario), normalization_gain=gain, name=name)
    syslist = [_sampled_subsystem(sys, scenario, T, h) for sys in loop.syslist]
    inputs, outputs = _flat_signals(loop.syslist, "input_labels"), _flat_signals(loop.syslist, "output_labels")
    connections = [
        [inputs[r], *[outputs[c] for c in np.flatnonzero(loop.connect_map[r])]]
        for r in range(len(inputs))
        if loop.connect_map[r].any()
    ]
    if wheel_table is not None:  # the scenario's open-loop table, a block feeding sc<i>.u_wheels
        table = _wheel_command_table(scenario)
        syslist.append(table)
        for label in table.output_labels:
            plant, k = label.split("_u_wheels")
            target = next((c for c in connections if c[0] == f"{plant}.u_wheels{k}"), None)
            if target is None:
                connections.append([f"{plant}.u_wheels{k}", f"wheel_commands.{label}"])
            else:
                target.append(f"wheel_commands.{label}")
    inplist = [[inputs[r] for r in np.flatnonzero(col)] for col in loop.input_map.T]
    stacked = outputs + inputs  # output_map reads the stacked subsystem outputs, then inputs
    outlist = [stacked[int(np.flatnonzero(row)[0])] for row in loop.output_map]
    sampled = ct.interconnect(
        syslist,
        connections=connections,
        inplist=inplist,
        outlist=outlist,
        outputs=list(loop.output_labels),
        inputs=list(loop.input_labels),
        dt=T,
        name=name,
        check_unused=False,
    )
    return _as_formation(sampled, scenario, name, params)
