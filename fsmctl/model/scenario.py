"""Typed, validated formation scenarios, loadable from TOML (Liang et al. 2012, Section 4).

A :class:`Scenario` fixes everything a run needs: the agents (nominal inertia
``J0``, perturbation ``delta_J``, initial attitude and rate, disturbance torque, own law
parameters), the reference (``sigma_d(0)`` and a sinusoidal
``omega_d(t)``), the communication topology (:class:`~fsmctl.model.topology.Topology`),
the controller settings and the numerical settings.  Named *cases* are partial
overrides of the base scenario (the paper's Cases 1, 2, 3a-3c).

One validation path
-------------------
Every class here is a frozen pydantic dataclass: constructing one, by keyword
arguments, from a TOML file (:func:`load_scenario`), through :meth:`Scenario.replace`,
:meth:`Scenario.with_agents`, :meth:`Scenario.with_topology` or ``dataclasses.replace``,
runs the same validators.  Types are strict (a bool, a string or NaN is never a
number), option strings are normalised to lower case (``"DOPRI45"`` is stored and run as
``"dopri45"``), and the physics checks (SPD and realizable inertia, the alpha range,
grids that are multiples of dt and end at t_final, topology vs agent count) are
code called from the validators.  A failure is one :class:`ScenarioError` whose
message names the key path (``agents[2].J0: ...``), never a traceback from deep
inside NumPy or pydantic.

The scenario *file* format is described by the same field types
(:mod:`fsmctl.model.scenario_schema` adds the file's shorthands and writes the reference page
``docs/scenario-reference.md`` and the JSON Schema ``fsmctl/scenarios/scenario.schema.json``).

The pieces live in their own modules and are re-exported here, the public home of every scenario name:
the value types, :class:`ScenarioError` and the physics checks (:mod:`fsmctl.model.scenario_values`), the
settings classes (:mod:`fsmctl.model.settings`) and the file format's tables, ``extends`` and cases
(:mod:`fsmctl.model.scenario_files`).

Units: inertia kg m^2, angles rad, rates rad/s, torques N m, time s.

Size: one concept, the Scenario type: the class (its validation across tables, replace / with_* and its
conversions to a dict and to TOML) and its three constructors from a mapping, a file and the paper; each is
documented with runnable examples, which make up most of the length.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import field
from pathlib import Path
from typing import Annotated, Any

import numpy as np
from pydantic import BeforeValidator, model_validator

from fsmctl.model.hardware_settings import (
    ActuatorSettings,
    GyroSettings,
    LinkSettings,
    SensorSettings,
    StarTrackerSettings,
    WheelCommandSettings,
)
from fsmctl.model.laws import (
    LawCode,
    LawError,
    LawSwitchWarning,
    parameter_matrix,
    resolve_law,
)
from fsmctl.model.noise import GILBERT_ELLIOTT_KEYS, gilbert_elliott_problem
from fsmctl.model.scenario_files import (
    AGENT_DEFAULT_KEYS,
    BUILTIN_SCENARIOS,
    TOP_KEYS,
    _agent_changes,
    _agent_from_table,
    _builtin_data,
    _controller_changes,
    _current_choices,
    _description,
    _hardware_settings,
    _laws_relative_to,
    _outside,
    _read_toml,
    _resolve_extends,
    _switch_law,
    _unknown,
    _warnings_after,
    _with_case,
    _within,
    _written_parameters,
)
from fsmctl.model.scenario_values import (
    InertiaWarning,
    ScenarioError,
    Text,
    UncoupledTopologyWarning,
    _strict_str,
    _validated,
    check_inertia,
)
from fsmctl.model.settings import (
    _AGENT_FIELDS,
    _CONTROLLER_FIELDS,
    Agent,
    ControllerSettings,
    Reference,
    SimulationSettings,
    Sinusoid,
)
from fsmctl.model.topology import Topology, TopologyError

__all__ = [
    "ScenarioError",
    "InertiaWarning",
    "UncoupledTopologyWarning",
    "Sinusoid",
    "Agent",
    "Reference",
    "ControllerSettings",
    "SimulationSettings",
    "ActuatorSettings",
    "WheelCommandSettings",
    "StarTrackerSettings",
    "GyroSettings",
    "SensorSettings",
    "LinkSettings",
    "Scenario",
    "load_scenario",
    "paper_scenario",
    "scenario_from_dict",
    "check_inertia",
    "BUILTIN_SCENARIOS",
]


def _weights_defaulted(table: Mapping[str, Any]) -> bool:
    """Whether some link of a ``[topology]`` table takes ``k_i`` or ``k_j`` from the default (0), not from a key."""
    k_i, k_j = "k_i" in table, "schedule" in table or "k_j" in table
    links = table.get("links")
    if isinstance(links, Sequence) and not isinstance(links, str):
        return any(not (k_i or "k_i" in item) or not (k_j or "k_j" in item) for item in links)
    return not (k_i and k_j)


def _link_weights(topology: Topology) -> list[float]:
    return [w for link in topology.links for w in (link.k_i, *link.k_j.values)]


def _is_topology(v: Any) -> Topology:
    if not isinstance(v, Topology):
        raise ValueError(f"expected a fsmctl.model.topology.Topology, got {type(v).__name__}")
    return v


def _choices(v: Any) -> tuple[tuple[str, str], ...]:
    items = v.items() if isinstance(v, Mapping) else v
    try:
        pairs = tuple((k, t) for k, t in items)
    except (TypeError, ValueError):
        raise ValueError(f"expected a table of strings, got {v!r}") from None
    if not all(isinstance(k, str) and isinstance(t, str) for k, t in pairs):
        raise ValueError("expected a table of strings")
    return pairs


@_validated
class Scenario:
    """A complete formation scenario (one case).

    Made by :func:`load_scenario` / :func:`paper_scenario` (a TOML file) or :func:`scenario_from_dict`, and
    changed by :meth:`replace`; every construction runs the same validators.  :meth:`to_toml` writes it back
    as a self-contained file.

    Parameters
    ----------
    name : str
        Label of the results.
    agents : tuple of Agent
        The spacecraft, agent 1 first.
    reference : Reference
        ``sigma_d(0)`` and ``omega_d(t)``.
    topology : Topology
        The communication graph of eq 19 (:class:`~fsmctl.model.topology.Topology`).
    controller : ControllerSettings
        The law and its parameters.
    simulation : SimulationSettings, optional
        Horizon, step, integrator, output grid, control period, seed.
    actuator : ActuatorSettings, optional
        Ideal torque source (default) or reaction wheels.
    sensors : SensorSettings, optional
        Star tracker and gyro (default: perfect).
    links : LinkSettings, optional
        Link delay and packet loss (default: perfect).
    case : str or None, optional
        The case of the source file applied (``"1"``, ...).
    description : str, optional
        Free text, printed with the results.
    choices : mapping of str to str, optional
        What the source leaves open and why each value was chosen.
    cases : tuple of str, optional
        Names of the cases the source file defines (not compared by ``==``).
    source : dict, optional
        The raw mapping the scenario was built from (not compared).

    Examples
    --------
    >>> import fsmctl
    >>> s = fsmctl.paper_scenario("1").replace(simulation={"t_final": 1.0, "integrator": "DOPRI45"})
    >>> s.simulation.integrator
    'dopri45'
    """

    name: Text
    agents: tuple[Agent, ...]
    reference: Reference
    topology: Annotated[Topology, BeforeValidator(_is_topology)]
    controller: ControllerSettings
    simulation: SimulationSettings = field(default_factory=SimulationSettings)
    actuator: ActuatorSettings = field(default_factory=ActuatorSettings)
    sensors: SensorSettings = field(default_factory=SensorSettings)
    links: LinkSettings = field(default_factory=LinkSettings)
    case: Annotated[str | None, BeforeValidator(lambda v: v if v is None else _strict_str(v))] = None
    description: Text = ""
    choices: Annotated[tuple[tuple[str, str], ...], BeforeValidator(_choices)] = ()
    """what the source leaves open, and why each value was chosen (printed with every result)"""
    cases: tuple[Text, ...] = field(default=(), compare=False)
    """names of the cases defined by the source file (not compared: two scenarios that fly the same run from
    different files are equal)"""
    source: dict = field(default_factory=dict, compare=False, repr=False)
    """the merged raw mapping this scenario was built from"""

    @model_validator(mode="after")
    def _formation(self) -> Scenario:
        if not self.agents:
            raise ValueError("agents: at least one agent is required")
        if self.topology.n_agents != len(self.agents):
            raise ValueError(
                f"topology: describes {self.topology.n_agents} agents but the scenario has {len(self.agents)}"
            )
        period = self.simulation.control_period
        if self.sensors.enabled and not period > 0:
            raise ValueError(
                "sensors: sensors and imperfect links act at the control instants; set "
                "simulation.control_period > 0 (e.g. 0.1 for 10 Hz control)"
            )
        n = len(self.agents)
        act = self.actuator
        if act.enabled and not period > 0 and (act.speed_gate == "step_start" or act.wheel_commands is not None):
            what = "wheel_commands" if act.wheel_commands is not None else "speed_gate"
            raise ValueError(
                f"actuator.{what}: wheel commands held over each step (speed_gate = 'step_start') and open-loop wheel "
                "commands act at the control instants; set simulation.control_period > 0 (e.g. 0.1 for 10 Hz control)"
            )
        table = act.wheel_commands.table(n) if act.enabled and act.wheel_commands is not None else None
        if table is not None and table.shape[1] != n:
            raise ValueError(
                f"actuator.wheel_commands.motor_torque: a row per wheel, or {n} rows (one per agent) per time; got "
                f"{table.shape[1]} rows per time"
            )
        if self.actuator.enabled:  # the hub inertia J - J_spin must be a rigid body's
            from fsmctl.model.actuators import hub_inertia_problem

            J_spin = self.actuator.spin_inertia_matrix()
            for i, agent in enumerate(self.agents, start=1):
                problem = hub_inertia_problem(agent.J_true, J_spin)
                if problem:
                    raise ValueError(f"actuator.spin_inertia: the wheels' spin inertia exceeds agent {i}'s: {problem}")
        linked = {(lk.receiver, lk.sender) for lk in self.topology.links}
        tables = ("loss_table", "good_to_bad_table", "bad_to_good_table", "loss_good_table", "loss_bad_table")
        for name, upper in (("delay_table", math.inf), *((t, 1.0) for t in tables)):
            tab = getattr(self.links, name)
            if tab is None:
                continue
            if len(tab) != n:
                raise ValueError(f"links.{name}: expected a {n} x {n} table (one row per agent), got {len(tab)} rows")
            for i, j in sorted(linked):
                v = tab[i][j]
                if not (math.isfinite(v) and 0 <= v <= upper):
                    raise ValueError(
                        f"links.{name}[{i + 1}][{j + 1}]: the link {i + 1} <- {j + 1} needs a value in [0, {upper:g}], "
                        f"got {v!r}"
                    )
        self._gilbert_elliott_links()
        if self.links_active and not period > 0:
            raise ValueError(
                "links: sensors and imperfect links act at the control instants; set "
                "simulation.control_period > 0 (e.g. 0.1 for 10 Hz control)"
            )
        law = resolve_law(self.controller.law)  # a law that cannot be found is a LawError
        # a law that commands its wheels flies on an array of its own size
        if law.n_wheels and self.actuator.enabled and self.actuator.n_wheels != law.n_wheels:
            raise ValueError(
                f"actuator: the law {law.name} commands {law.n_wheels} reaction wheels, the actuator has "
                f"{self.actuator.n_wheels}; give it {law.n_wheels} wheels or fly another law"
            )
        try:
            parameter_matrix(law, self)  # the written keys against the law's declarations and ranges
        except LawError as exc:
            raise ValueError(str(exc)) from None
        if law.trigger is not None:  # event-triggered: checked at the control instants (or a multiple of them)
            try:
                law.trigger.check_every(period)
            except LawError as exc:
                raise ValueError(f"controller.law = {law.name}: {exc}") from None
        return self

    def _gilbert_elliott_links(self) -> None:
        """Each link's Gilbert-Elliott parameters valid together (p + r > 0), the tables' entries merged."""
        lk = self.links
        if lk.loss_model != "gilbert_elliott":
            return

        for link in self.topology.links:
            i, j = link.receiver, link.sender
            values = [float(lk.per_link([i], [j], key)[0]) for key in GILBERT_ELLIOTT_KEYS]
            problem = gilbert_elliott_problem(*values)
            if problem:
                raise ValueError(f"links: the link {i + 1} <- {j + 1}: {problem}")

    @property
    def law(self) -> LawCode:
        """The :class:`~fsmctl.model.laws.LawCode` this scenario flies (``controller.law``)."""
        return resolve_law(self.controller.law)

    @property
    def n_agents(self) -> int:
        """Number of agents ``n``."""
        return len(self.agents)

    @property
    def label(self) -> str:
        """``"<name>"`` or ``"<name> case <case>"``: how results name the scenario."""
        return f"{self.name}" + (f" case {self.case}" if self.case else "")

    def to_dict(self) -> dict[str, Any]:
        """This scenario as the mapping of a self-contained scenario file (the selected case, resolved).

        The mapping is what :func:`scenario_from_dict` reads, with every value spelled out: every section's
        every field (defaults included, so a later fsmctl with other defaults flies the same run), each agent's
        full ``delta_J`` matrix and disturbance, the topology as an explicit ``links`` array (1-based agents, each
        link's ``k_i``, phase and ``k_j`` schedule), the law by the name or path given in ``controller.law``, the
        written law parameters in ``[controller.parameters]`` and each agent's own in its ``parameters`` table, and
        the ``[choices]``.  A law parameter nobody wrote is not spelled out: it is the law's declared default (the
        law's folder, recorded with a result file's provenance, holds it).  Floats keep their bits (written with
        ``repr`` by :meth:`to_toml`).

        Only the flown case is written: the other cases of the source file are overrides of *its* base, which
        this scenario may no longer be (after :meth:`replace`).  A scenario with a case gets a ``[cases]`` table
        holding that one case with no overrides, so :func:`load_scenario` of the file selects it and keeps the
        label.  Round trip: ``scenario_from_dict(s.to_dict(), case=s.case) == s`` and ``load_scenario`` of the
        file written by :meth:`to_toml` equals ``s`` (equality ignores :attr:`cases`, the source file's names).

        Returns
        -------
        dict
            Plain Python values (dicts, lists, floats, ints, strings, bools); ``inf``/``nan`` as floats.

        Examples
        --------
        >>> import fsmctl
        >>> from fsmctl.model.scenario import scenario_from_dict
        >>> s = fsmctl.paper_scenario("2")
        >>> d = s.to_dict()
        >>> d["topology"]["links"][0]
        {'receiver': 1, 'sender': 2, 'k_i': 0.0, 'phase': 0.0, 'k_j': {'breakpoints': [0.0, 6.5], 'values': [0.0, 0.0], 'period': 8.0}}
        >>> scenario_from_dict(d, case="2") == s
        True
        """

        def plain(v: Any) -> Any:
            if isinstance(v, (tuple, list)):
                return [plain(x) for x in v]
            if isinstance(v, Mapping):
                return {str(k): plain(x) for k, x in v.items()}
            if isinstance(v, (np.floating, np.integer, np.bool_)):
                return v.item()
            return v

        def section(obj: Any, skip: tuple[str, ...] = ()) -> dict[str, Any]:
            out = {}
            for f in dataclasses.fields(obj):
                v = getattr(obj, f.name)
                if f.name in skip or v is None:  # None: an unset optional key (TOML has no null)
                    continue
                out[f.name] = section(v) if dataclasses.is_dataclass(v) else plain(v)
            return out

        def schedule(sch: Any) -> dict[str, Any]:
            out = {"breakpoints": plain(sch.breakpoints), "values": plain(sch.values)}
            if sch.period is not None:
                out["period"] = float(sch.period)
            return out

        controller = section(self.controller, skip=("parameters",))
        if self.controller.parameters:
            controller["parameters"] = plain(dict(self.controller.parameters))
        agents = []
        for a in self.agents:
            agents.append(section(a, skip=("parameters",)))
            if a.parameters:
                agents[-1]["parameters"] = plain(dict(a.parameters))
        links = [
            {
                "receiver": lk.receiver + 1,
                "sender": lk.sender + 1,
                "k_i": float(lk.k_i),
                "phase": float(lk.phase),
                "k_j": schedule(lk.k_j),
            }
            for lk in self.topology.links
        ]
        out: dict[str, Any] = {
            "name": self.name,
            "description": self.description,
            "simulation": section(self.simulation),
            "controller": controller,
            "actuator": section(self.actuator),
            "sensors": section(self.sensors),
            "links": section(self.links),
            "reference": section(self.reference),
            "topology": {"links": links},
            "agents": agents,
            "choices": dict(self.choices),
        }
        if self.case is not None:
            out["cases"] = {self.case: {}}
        return out

    def to_toml(self) -> str:
        """This scenario as a self-contained TOML scenario file (:meth:`to_dict`, written by
        :mod:`fsmctl.model.toml_writer`).

        Returns
        -------
        str
            TOML text; :func:`load_scenario` of a file holding it gives back this scenario (floats keep their
            bits; a law given by a relative path is looked up relative to the file's folder first, then to the
            current folder).

        Examples
        --------
        >>> import fsmctl
        >>> s = fsmctl.paper_scenario("3b")
        >>> text = s.to_toml()
        >>> print(text.splitlines()[0])
        # fsmctl scenario (self-contained): paper case 3b
        >>> _ = open("case3b.toml", "w").write(text)
        >>> fsmctl.load_scenario("case3b.toml") == s
        True
        """
        from fsmctl.model.toml_writer import scenario_toml

        return scenario_toml(self.to_dict(), title=f"fsmctl scenario (self-contained): {self.label}")

    def with_case(self, case: str) -> Scenario:
        """The scenario with the named case's overrides applied to the base (of the source file).

        Parameters
        ----------
        case : str
            One of :attr:`cases`.

        Returns
        -------
        Scenario
            The source file's base with that case applied (changes made by :meth:`replace` are not kept).
        """
        if case not in self.cases:
            raise ScenarioError(f"scenario {self.name!r} has no case {case!r} (cases: {list(self.cases)})")
        return scenario_from_dict(self.source, case=case)

    def replace(self, **sections: Any) -> Scenario:
        """A validated copy with fields of a section replaced.

        The copy goes through the same validators as a file: a bad value raises :class:`ScenarioError` naming
        ``section.key``.  ``controller={...}`` works as a file's ``[controller]`` table does: its own keys
        (``law``, ``torque_limit``, ``error_model``, ``enabled``, ``parameters``) replace theirs, every other key
        writes a law parameter or preset choice (None removes a written one, so that the law's default applies).
        ``parameters=`` replaces the whole written set.

        Switching the law (``controller={"law": ...}`` without ``parameters``) keeps the written keys, in
        ``[controller]`` and in the agents, that are the same parameter of the new law
        (:func:`~fsmctl.model.laws.carried_keys`: the same name, unit and size) and drops the others, and says which in one
        :class:`~fsmctl.model.laws.LawSwitchWarning`.

        Parameters
        ----------
        **sections
            ``controller``, ``simulation``, ``reference``, ``actuator``, ``sensors``, ``links`` (mappings of
            field names to new values, or a whole section object), ``agents`` (a sequence of :class:`Agent`, or
            one mapping per agent of changes: its fields, or its own law parameters such as ``{"delta": 0.01}``)
            and ``topology`` (a :class:`~fsmctl.model.topology.Topology`; give both when the agent count changes).

        Returns
        -------
        Scenario
            The validated copy.

        Raises
        ------
        ScenarioError
            An unknown section, a bad value or a key the law does not declare.

        Examples
        --------
        >>> import fsmctl
        >>> s = fsmctl.paper_scenario("1")
        >>> s.replace(controller={"boundary_layer": 0.0}, simulation={"t_final": 10}).simulation.t_final
        10.0
        >>> s.replace(actuator={"kind": "reaction_wheels", "layout": "pyramid"}).actuator.n_wheels
        4
        >>> fast = s.replace(agents=[{"delta": 0.05}] + [{}] * 5)  # agent 1's own switching gain (eq 18)
        >>> fast.law_parameters()[0]["delta"], fast.law_parameters()[1]["delta"]
        ((0.05, 0.05, 0.05), (0.005, 0.005, 0.005))
        """
        known = ("controller", "simulation", "reference", "actuator", "sensors", "links", "agents", "topology")
        unknown = sorted(set(sections) - set(known))
        if unknown:
            raise ScenarioError(f"replace: cannot replace {unknown} (known: {', '.join(known)})")
        agents, topology = sections.get("agents"), sections.get("topology")
        changes: dict[str, Any] = {}
        for section in known[:6]:
            values = sections.get(section)
            if values is None:
                continue
            current_section = getattr(self, section)
            if isinstance(values, type(current_section)):
                changes[section] = values
                continue
            if not isinstance(values, Mapping):
                raise ScenarioError(f"replace({section}=...): expected a mapping of field names to values")
            current = {f.name: getattr(current_section, f.name) for f in dataclasses.fields(current_section)}
            if section == "controller":
                values = _controller_changes(current, values)
            changes[section] = {**current, **dict(values)}
        if agents is not None:
            changes["agents"] = _agent_changes(self.agents, agents)
        if topology is not None:
            changes["topology"] = topology
        asked = sections.get("controller")
        given = {k for k in asked if k not in _CONTROLLER_FIELDS} if isinstance(asked, Mapping) else set()
        if isinstance(agents, Sequence):
            given |= {k for a in agents if isinstance(a, Mapping) for k in a if k not in _AGENT_FIELDS}
        kept = _current_choices(self.choices, given)
        if kept != self.choices:
            changes["choices"] = kept
        note = None
        if isinstance(asked, Mapping) and "parameters" not in asked:
            changes, note = _switch_law(self, changes, given=given)
        out = dataclasses.replace(self, **changes)
        if note:  # said once the copy is valid: a bad value is one line, never a warning and then the error
            warnings.warn(note, LawSwitchWarning, stacklevel=_outside())
        return out

    def with_law(self, law: str | Path | None = None, parameters: Mapping[str, Any] | None = None) -> Scenario:
        """A validated copy flying ``law`` with ``parameters`` set for every agent (``--law``, ``--set``).

        Switching the law follows the rule of :meth:`replace` (the written keys that are the same parameter of the new law carry over,
        the others are dropped, one :class:`~fsmctl.model.laws.LawSwitchWarning` says which); then each of
        ``parameters`` is written in ``[controller]`` and the agents' own values of it give way, so that every
        agent flies it.

        Parameters
        ----------
        law : str, pathlib.Path or None, optional
            A built-in law name, a derivation script or a derived folder; None keeps the scenario's law.
        parameters : mapping, optional
            Law parameters or preset choices by name, as a ``[controller]`` table writes them.

        Returns
        -------
        Scenario
            The validated copy.

        Raises
        ------
        ScenarioError
            A key the law does not declare, or a value outside its declared range.

        Examples
        --------
        >>> import fsmctl
        >>> s = fsmctl.paper_scenario("1").replace(agents=[{"delta": 0.05}] + [{}] * 5)
        >>> {p["delta"][0] for p in s.with_law(parameters={"delta": 0.01}).law_parameters()}
        {0.01}
        """
        values = dict(parameters or {})
        own = sorted(set(values) & _CONTROLLER_FIELDS)
        if own:
            raise ScenarioError(f"controller.{own[0]}: a [controller] key of its own, not a law parameter")
        flown = self.law if law is None else resolve_law(str(law))
        for group in flown.presets:  # a preset fixes its parameters: giving both is a contradiction
            option = values.get(group.name)
            fixed = group.options.get(option.lower(), {}) if isinstance(option, str) else {}
            clash = sorted(set(fixed) & set(values))
            if clash:
                raise ScenarioError(
                    f"controller.{clash[0]}: fixed by {group.name} = {option.lower()} ({clash[0]} = "
                    f"{fixed[clash[0]][0]:g}); set one of them"
                )
        agents = [{k: None for k in values if k in a.parameters} for a in self.agents]
        controller = values if law is None else {"law": str(law), **values}
        if not controller:
            return self
        return self.replace(controller=controller, **({"agents": agents} if any(agents) else {}))

    def with_agents(self, agents: Sequence[Agent]) -> Scenario:
        """A validated copy with another agent list (same count as the topology).

        Parameters
        ----------
        agents : sequence of Agent
            The new agents.

        Returns
        -------
        Scenario
            The validated copy.
        """
        return self.replace(agents=agents)

    def with_topology(self, topology: Topology) -> Scenario:
        """A validated copy with another communication topology.

        Parameters
        ----------
        topology : Topology
            The new graph (same number of agents).

        Returns
        -------
        Scenario
            The validated copy.
        """
        return self.replace(topology=topology)

    def law_parameters(self) -> list[dict[str, Any]]:
        """The law's parameters by name for every agent, as flown (:func:`fsmctl.model.laws.parameter_matrix`).

        Returns
        -------
        list of dict
            One dict per agent: a number, a tuple (a vector parameter) or an option's name, per parameter.

        Examples
        --------
        >>> import fsmctl
        >>> fsmctl.paper_scenario("1").replace(controller={"surface": "tsm"}).law_parameters()[0]["c1"]
        0.0
        """
        law = self.law
        rows, out = parameter_matrix(law, self), []
        for row in rows:
            values, k = {}, 0
            for p in law.parameters:
                v = row[k : k + p.size]
                values[p.name] = (
                    p.choices[int(v[0])] if p.choices else (float(v[0]) if p.size == 1 else tuple(map(float, v)))
                )
                k += p.size
            out.append(values)
        return out

    @property
    def links_active(self) -> bool:
        """Whether an existing link of the topology is delayed or lossy (table entries without a link do not count)."""
        lk = self.links
        if not lk.enabled:
            return False
        receivers = [link.receiver for link in self.topology.links]
        senders = [link.sender for link in self.topology.links]
        return bool(
            np.any(lk.per_link(receivers, senders, "delay") > 0) or np.any(lk.loss_rates(receivers, senders) > 0)
        )

    def hardware_lines(self) -> list[str]:
        """The actuator, sensors and links, one line each (part of :meth:`describe`)."""
        a, se, lk = self.actuator, self.sensors, self.links
        lines = []
        if a.enabled:
            per = {k: list(getattr(a, k)) if len(getattr(a, k)) > 1 else getattr(a, k)[0] for k in (
                "spin_inertia", "max_torque", "max_speed", "viscous_friction", "coulomb_friction", "initial_speed")}  # fmt: skip
            lines.append(
                f"  actuator: {a.n_wheels} reaction wheels ({a.layout}"
                + (f" {a.pyramid_angle:g} deg" if a.layout == "pyramid" else "")
                + "), "
                + " ".join(f"{k}={v}" for k, v in per.items())
                + f" coulomb_band={a.coulomb_band} allocation={a.allocation} speed_gate={a.speed_gate}"
                + (
                    ""
                    if a.wheel_commands is None
                    else f" wheel_commands: {len(a.wheel_commands.time)} rows from t = {a.wheel_commands.time[0]:g} s"
                )
            )
        else:
            lines.append("  actuator: ideal torque source (per-axis clip at torque_limit)")
        if se.star_tracker is not None:
            lines.append(f"  star tracker: noise_std={list(se.star_tracker.noise_std)} rad")
        if se.gyro is not None:
            g = se.gyro
            lines.append(
                f"  gyro: angle_random_walk={g.angle_random_walk} rad/s^0.5 rate_random_walk={g.rate_random_walk} "
                f"rad/s^1.5 bias={list(g.bias)} rad/s"
            )
        if self.links_active:
            delay = f"  links: delay={'per link' if lk.delay_table is not None else f'{lk.delay} s'} "
            if lk.loss_model == "bernoulli":
                lines.append(
                    delay
                    + "loss_model=bernoulli loss_probability="
                    + ("per link" if lk.loss_table is not None else f"{lk.loss_probability}")
                )
            else:
                values = " ".join(
                    f"{k}={'per link' if getattr(lk, f'{k}_table') is not None else lk._scalar(k)}"
                    for k in ("good_to_bad", "bad_to_good", "loss_good", "loss_bad")
                )
                lines.append(delay + f"loss_model=gilbert_elliott {values}")
        return lines

    def describe(self) -> list[str]:
        """Human-readable lines: the law flown with its parameters as resolved, settings and the documented choices."""
        c, s = self.controller, self.simulation
        law = self.law
        per_agent = self.law_parameters()
        common = {k: v for k, v in per_agent[0].items() if all(a[k] == v for a in per_agent)}
        differing = sorted(set(per_agent[0]) - set(common))
        lines = [
            f"scenario {self.label}: {self.n_agents} agents, {len(self.topology.links)} links",
            f"  law: {law.name} ({law.script(portable=True) or law.folder})"
            + "".join(
                f", {g.name}={c.parameters[g.name]}"
                for g in law.presets
                if g.name in c.parameters and c.parameters[g.name] != g.default
            ),
            "  law parameters: " + " ".join(f"{k}={v}" for k, v in common.items()),
            *(
                ["  per agent (1, 2, ...): " + "; ".join(f"{k} = {[a[k] for a in per_agent]}" for k in differing)]
                if differing
                else []
            ),
            f"  controller: torque_limit={c.torque_limit} error_model={c.error_model}"
            + ("" if c.enabled else " enabled=False (open loop, u = 0)"),
            f"  simulation: t_final={s.t_final} s, dt={s.dt} s, integrator={s.integrator}, "
            f"output_interval={s.output_interval} s, control_period={s.control_period} s, seed={s.seed}",
            *self.hardware_lines(),
        ]
        lines += [f"  choice {k}: {v}" for k, v in self.choices]
        return lines


def scenario_from_dict(data: Mapping, case: str | None = None, *, where: str = "scenario") -> Scenario:
    """Build a validated :class:`Scenario` from a mapping (a parsed TOML file), optionally applying a case.

    The file's shorthands (``delta_J``/``disturbance`` defaults in ``[controller]``,
    ``delta_J = {scale = ...}``, ``kind = ["cos"|"sin", ...]`` of sinusoids, the
    topology tables) are expanded here; every value is then checked by the dataclasses' validators.

    Parameters
    ----------
    data : Mapping
        The file's tables (``extends`` is resolved against the built-in scenarios).
    case : str, optional
        A case of ``data["cases"]`` to apply; None: the base (unlike :func:`load_scenario`, which picks the
        first case).
    where : str
        Prefix of error messages (the file's name).

    Returns
    -------
    Scenario
        The validated scenario.

    Raises
    ------
    ScenarioError
        A malformed table, an unknown key or case, or a value a validator refuses; one line naming the key path.

    Examples
    --------
    >>> import fsmctl
    >>> s = fsmctl.paper_scenario("3b")
    >>> scenario_from_dict(s.to_dict(), case="3b") == s
    True
    >>> try:
    ...     scenario_from_dict({**s.to_dict(), "colour": "red"})
    ... except ScenarioError as exc:
    ...     print(str(exc)[:40])
    scenario: unknown key(s) ['colour'] (kno
    """
    return _warnings_after(_scenario_from_dict, data, case, where=where)


def _scenario_from_dict(data: Mapping, case: str | None = None, *, where: str = "scenario") -> Scenario:
    if isinstance(data, Mapping) and "extends" in data:
        data = _resolve_extends(dict(data), where, None)
    _unknown(data, TOP_KEYS, where)
    cases = data.get("cases", {})
    if not isinstance(cases, Mapping):
        raise ScenarioError(f"{where}.cases: expected a table of named cases")
    merged = dict(data) if case is None else _with_case(data, cases, case)
    for key in ("controller", "reference", "agents", "topology"):
        if key not in merged:
            raise ScenarioError(f"{key}: missing")
    ctrl = merged["controller"]
    if not isinstance(ctrl, Mapping):
        raise ScenarioError("controller: expected a table")
    known = {*(f.name for f in dataclasses.fields(ControllerSettings)), *AGENT_DEFAULT_KEYS}
    # further keys are the law's parameters (checked against the law's declarations by the Scenario)
    controller = _within(
        "controller",
        ControllerSettings,
        **{k: v for k, v in ctrl.items() if k in known and k not in AGENT_DEFAULT_KEYS and k != "parameters"},
        parameters=_written_parameters(ctrl, tuple(known), "controller"),
    )
    defaults = {k: ctrl[k] for k in AGENT_DEFAULT_KEYS if k in ctrl}
    sim = merged.get("simulation", {})
    _unknown(sim, [f.name for f in dataclasses.fields(SimulationSettings)], "simulation")
    simulation = _within("simulation", SimulationSettings, **sim)
    ref = merged["reference"]
    _unknown(ref, ("sigma0", "omega"), "reference")
    if "sigma0" not in ref or "omega" not in ref:
        raise ScenarioError("reference: needs sigma0 and omega")
    reference = _within(
        "reference", Reference, sigma0=ref["sigma0"], omega=Sinusoid.from_mapping(ref["omega"], "reference.omega")
    )
    agents_raw = merged["agents"]
    if not isinstance(agents_raw, Sequence) or isinstance(agents_raw, (str, bytes)) or not agents_raw:
        raise ScenarioError("agents: expected a non-empty array of tables ([[agents]])")
    agents = tuple(_agent_from_table(a, i, defaults) for i, a in enumerate(agents_raw))
    try:
        topology = Topology.from_mapping(merged["topology"], len(agents), where="topology")
    except TopologyError as exc:
        raise ScenarioError(str(exc)) from None
    if topology.links and _weights_defaulted(merged["topology"]) and not any(_link_weights(topology)):
        warnings.warn(
            "topology: every link has k_i = k_j = 0: the agents do not coordinate (write k_i and k_j in [topology];"
            " write them as 0 to fly an uncoupled formation without this warning)",
            UncoupledTopologyWarning,
            stacklevel=_outside(),
        )
    hardware = _hardware_settings(merged)
    choices = merged.get("choices", {})
    if not isinstance(choices, Mapping):
        raise ScenarioError("choices: expected a table of strings")
    return Scenario(
        name=merged.get("name", "scenario"),
        agents=agents,
        reference=reference,
        topology=topology,
        controller=controller,
        simulation=simulation,
        **hardware,
        case=case,
        description=_description(merged, cases, case),
        choices=choices,
        cases=tuple(str(k) for k in cases),
        source=dict(data),
    )


def load_scenario(source: str | Path = "paper", case: str | None = None) -> Scenario:
    """Load a built-in scenario by name (``"paper"``, ``"paper-hardware"``) or a TOML file, optionally selecting a case.

    Without ``case`` a file that defines cases gets its first one (for the paper: Case 1); a file
    without ``[cases]`` is its own single scenario.  A file may start from another with ``extends = "paper"`` (a
    built-in name or a path relative to the file) and change only what differs.

    Parameters
    ----------
    source : str or Path
        A built-in name (:data:`BUILTIN_SCENARIOS`) or a TOML file.
    case : str, optional
        The case to apply; None: the file's first case (if it has any).

    Returns
    -------
    Scenario
        The validated scenario.

    Raises
    ------
    ScenarioError
        The file cannot be read, is not TOML, or is not a valid scenario; one line naming the file and key path.

    Examples
    --------
    >>> from fsmctl import load_scenario
    >>> load_scenario("paper", case="2").label
    'paper case 2'
    >>> load_scenario("paper-hardware").actuator.kind
    'reaction_wheels'
    """
    return _warnings_after(_load_scenario, source, case)


def _load_scenario(source: str | Path = "paper", case: str | None = None) -> Scenario:
    if isinstance(source, str) and source in BUILTIN_SCENARIOS:
        data = _builtin_data(source)
        where = f"built-in scenario {source!r}"
        data = _resolve_extends(data, where, None)
    else:
        if not isinstance(source, (str, Path)):
            raise ScenarioError(f"scenario: expected 'paper' or a path to a TOML file, got {source!r}")
        path = Path(source)
        data = _read_toml(path)
        where = str(path)
        _laws_relative_to(data, path.parent)
        data = _resolve_extends(data, where, path.parent)
    if case is None and isinstance(data.get("cases"), Mapping) and data["cases"]:
        case = next(iter(data["cases"]))
    try:
        return scenario_from_dict(data, case=None if case is None else str(case), where=where)
    except ScenarioError as exc:
        msg = str(exc)
        raise ScenarioError(msg if msg.startswith(where) else f"{where}: {msg}") from None


def paper_scenario(case: str = "1") -> Scenario:
    """The built-in Section 4 scenario (Liang et al. 2012) for Case ``"1"``, ``"2"``, ``"3a"``, ``"3b"`` or ``"3c"``.

    Parameters
    ----------
    case : str
        The paper's case.

    Returns
    -------
    Scenario
        Six spacecraft, 100 s, the paper's law and the case's topology weights.

    Examples
    --------
    >>> from fsmctl import paper_scenario
    >>> paper_scenario("1").n_agents
    6
    """
    return load_scenario("paper", case=str(case))
