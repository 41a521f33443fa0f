"""A scenario with every value spelled out and where each came from (``fsmctl scenario show``).

:func:`show_scenario` builds the scenario by the one validation path every command takes
(:func:`~fsmctl.model.scenario.load_scenario`, then :meth:`~fsmctl.model.scenario.Scenario.with_law` and
:meth:`~fsmctl.model.scenario.Scenario.replace` for ``--law``/``--set``), flies nothing, and reports each value of
:meth:`~fsmctl.model.scenario.Scenario.to_dict` (the law's parameters as each agent flies them) with its origin:

=====================  =========================================================================================
origin                 the value was ...
=====================  =========================================================================================
``--set``              given on the command line (``--set KEY=VALUE``, ``--law``)
``case NAME``          written in the selected case's table of the file (``[cases.NAME]``)
``file``               written in the file itself (a built-in scenario: its file, e.g. ``paper.toml``)
``extends``            inherited from the file's base (``extends = "paper"``)
``law default``        not written anywhere: the flown law's declared default (its ``law.json``)
``default``            not written anywhere: fsmctl's built-in default of the setting (``docs/scenario-reference.md``)
=====================  =========================================================================================

A key of an ``[[agents]]`` table that its file leaves out but ``[controller]`` writes (``delta_J``,
``disturbance``: the defaults of every agent) has the origin of that ``[controller]`` key.
"""

from __future__ import annotations

import copy
import warnings
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from fsmctl.model.scenario import Scenario, load_scenario
from fsmctl.model.scenario_files import (
    AGENT_DEFAULT_KEYS,
    BUILTIN_SCENARIOS,
    _builtin_data,
    _read_toml,
    _resolve_extends,
)

__all__ = ["ORIGINS", "ShownValue", "ShownScenario", "show_scenario"]

ORIGINS = ("--set", "case", "file", "extends", "law default", "default")
"""The origins of a value, the strongest first (``case`` is shown as ``case NAME``)."""

_SECTIONS = ("simulation", "reference", "actuator", "sensors", "links")
"""Sections shown key by key (the controller, the agents and the topology have their own rules)."""


@dataclass(frozen=True)
class ShownValue:
    """One value of a scenario and its origin.

    Parameters
    ----------
    key : str
        Its dotted path (``simulation.t_final``, ``controller.c1``, ``agents[2].sigma0``).
    value : Any
        The value flown (plain Python: numbers, lists, strings, tables).
    origin : str
        One of :data:`ORIGINS` (``case NAME`` for a case).
    """

    key: str
    value: Any
    origin: str


@dataclass(frozen=True)
class ShownScenario:
    """A validated scenario and every value of it with its origin (:func:`show_scenario`).

    Parameters
    ----------
    scenario : Scenario
        The scenario, as a command would fly it.
    values : tuple of ShownValue
        Every value, in the order of the scenario file's sections.
    """

    scenario: Scenario
    values: tuple[ShownValue, ...]

    def to_text(self) -> list[str]:
        """One line per value: ``key = value  (origin)``, aligned.

        Returns
        -------
        list of str
            A heading line, then the values.
        """
        width = max(len(v.key) for v in self.values)
        lines = [f"scenario {self.scenario.label}: every value and where it came from (nothing flown)"]
        for v in self.values:
            lines.append(f"  {v.key:{width}} = {_text(v.value)}  ({v.origin})")
        return lines

    def to_dict(self) -> dict[str, Any]:
        """The scenario file's mapping (:meth:`Scenario.to_dict`) and the value and origin of every key.

        Returns
        -------
        dict
            ``scenario`` (the label), ``file`` (the self-contained scenario mapping), ``values`` (``{key: {"value":
            ..., "origin": ...}}``).
        """
        return {
            "scenario": self.scenario.label,
            "file": self.scenario.to_dict(),
            "values": {v.key: {"value": v.value, "origin": v.origin} for v in self.values},
        }


def _text(value: Any) -> str:
    """A value as the listing prints it: floats to 15 significant digits (``0.44999999999999996`` is ``0.45``; two
    floats that differ in the first 15 digits still print differently), strings quoted, lists element by element."""
    if isinstance(value, float):
        return _number(value)
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_text(v) for v in value) + "]"
    if isinstance(value, Mapping):
        return "{" + ", ".join(f"{k!r}: {_text(v)}" for k, v in value.items()) + "}"
    return str(value)


def _number(x: float) -> str:
    text = f"{x:.15g}"
    return text if any(c in text for c in ".eni") else text + ".0"  # 100.0 stays a float, inf and nan as they are


def _has(table: Any, path: Sequence[str]) -> bool:
    for part in path:
        if not isinstance(table, Mapping) or part not in table:
            return False
        table = table[part]
    return True


def _leaves(table: Mapping[str, Any], prefix: tuple[str, ...] = ()) -> Iterator[tuple[tuple[str, ...], Any]]:
    for key, value in table.items():
        if isinstance(value, Mapping) and value:
            yield from _leaves(value, (*prefix, key))
        else:
            yield (*prefix, key), value


class _Written:
    """The tables a scenario's values may come from, strongest first: the case's, the file's own, its base's."""

    def __init__(self, source: str | Path, case: str | None) -> None:
        if isinstance(source, str) and source in BUILTIN_SCENARIOS:
            own, folder = _builtin_data(source), None
        else:
            own, folder = _read_toml(Path(source)), Path(source).parent
        with warnings.catch_warnings():  # load_scenario has said it once (a law switch over the base)
            warnings.simplefilter("ignore")
            resolved = _resolve_extends(copy.deepcopy(own), str(source), folder)
        cases = resolved.get("cases") if isinstance(resolved.get("cases"), Mapping) else {}
        self.case = case if case is not None else next(iter(cases), None)
        self.layers = [(f"case {self.case}", cases.get(self.case) or {}), ("file", own), ("extends", resolved)]

    def origin(self, *paths: Sequence[str]) -> str | None:
        """The first layer that writes one of ``paths`` (None: none writes it)."""
        for name, table in self.layers:
            if any(_has(table, p) for p in paths):
                return name
        return None


def show_scenario(
    source: str | Path = "paper",
    case: str | None = None,
    *,
    law: str | Path | None = None,
    parameters: Mapping[str, Any] | None = None,
    controller: Mapping[str, Any] | None = None,
) -> ShownScenario:
    """The scenario a command would fly, with every default filled in and the origin of each value; flies nothing.

    Parameters
    ----------
    source : str or Path
        A built-in scenario name (``"paper"``, ``"paper-hardware"``) or a TOML file.
    case : str, optional
        The case (default: the file's first, as :func:`~fsmctl.model.scenario.load_scenario`).
    law : str or Path, optional
        ``--law``: the law flown instead of the scenario's.
    parameters : mapping, optional
        ``--set``: law parameters set for every agent.
    controller : mapping, optional
        ``--set``: ``[controller]`` keys of its own (``torque_limit``, ``error_model``, ``enabled``).

    Returns
    -------
    ShownScenario
        The validated scenario and its values (:data:`ORIGINS`).

    Raises
    ------
    fsmctl.model.scenario.ScenarioError
        The file or a value is not valid (the same one-line error as every command's).

    Examples
    --------
    >>> from fsmctl.model.scenario_origin import show_scenario
    >>> shown = {v.key: (v.value, v.origin) for v in show_scenario("paper", "2", parameters={"c1": 0.5}).values}
    >>> shown["controller.c1"], shown["controller.c2"], shown["simulation.t_final"], shown["simulation.seed"]
    ((0.5, '--set'), (0.8, 'file'), (100.0, 'file'), (0, 'default'))
    >>> shown["topology"][1]  # case 2 writes its own topology weights
    'case 2'
    """
    parameters, controller = dict(parameters or {}), dict(controller or {})
    scenario = load_scenario(source, case)
    if law is not None or parameters:
        scenario = scenario.with_law(law, parameters)
    if controller:
        scenario = scenario.replace(controller=controller)
    written = _Written(source, case)
    full = scenario.to_dict()
    values: list[ShownValue] = []
    for section in _SECTIONS:
        for path, value in _leaves(full.get(section) or {}):
            origin = written.origin((section, *path)) or "default"
            values.append(ShownValue(".".join((section, *path)), value, origin))
    values += _controller_values(scenario, full, written, law, parameters, controller)
    values += _agent_values(full, written)
    origin = written.origin(("topology",)) or "default"
    values.append(ShownValue("topology", _topology_text(scenario), origin))
    return ShownScenario(scenario, tuple(values))


def _controller_values(scenario, full, written, law, parameters, controller) -> list[ShownValue]:
    """``[controller]``'s own keys, then each law parameter as the agents fly it (one value, or one per agent)."""
    out = []
    for key, value in full["controller"].items():
        if key == "parameters" or (isinstance(value, Mapping) and key in AGENT_DEFAULT_KEYS):
            continue
        given = key in controller or (key == "law" and law is not None)
        origin = "--set" if given else written.origin(("controller", key)) or "default"
        out.append(ShownValue(f"controller.{key}", value, origin))
    flown = scenario.law_parameters()
    for name in flown[0]:
        per_agent = [_plain(p[name]) for p in flown]
        value = per_agent[0] if all(v == per_agent[0] for v in per_agent) else per_agent
        origin = (
            "--set" if name in parameters else written.origin(("controller", name)) or _agents_origin(written, name)
        )
        out.append(ShownValue(f"controller.{name}", value, origin or "law default"))
    return out


def _agents_origin(written: _Written, key: str) -> str | None:
    """The first layer whose ``[[agents]]`` writes ``key`` for some agent."""
    for name, table in written.layers:
        agents = table.get("agents") if isinstance(table, Mapping) else None
        if isinstance(agents, list) and any(isinstance(a, Mapping) and key in a for a in agents):
            return name
    return None


def _agent_values(full: Mapping[str, Any], written: _Written) -> list[ShownValue]:
    out = []
    for i, agent in enumerate(full["agents"]):
        for key, value in agent.items():
            if key == "parameters":
                continue
            origin = _agents_origin(written, key)
            if origin is None and key in AGENT_DEFAULT_KEYS:
                origin = written.origin(("controller", key))
            out.append(ShownValue(f"agents[{i + 1}].{key}", value, origin or "default"))
    return out


def _topology_text(scenario: Scenario) -> str:
    """``30 directed links among 6 agents, k_i 0..8, k_j 0..5 (--json lists every link)``: the range of the
    weights over every link and, for ``k_j``, over its schedule; ``all weights 0: no coordination`` when they
    vanish."""
    topo = scenario.topology
    head = f"{len(topo.links)} directed links among {topo.n_agents} agents"
    if not topo.links:
        return head
    k_i = [float(link.k_i) for link in topo.links]
    k_j = [float(v) for link in topo.links for v in link.k_j.values]
    if not any(k_i) and not any(k_j):
        weights = "all weights 0: no coordination"
    else:
        weights = ", ".join(f"{name} {_span(values)}" for name, values in (("k_i", k_i), ("k_j", k_j)))
    return f"{head}, {weights} (--json lists every link)"


def _span(values: list[float]) -> str:
    lo, hi = min(values), max(values)
    return _short(lo) if lo == hi else f"{_short(lo)}..{_short(hi)}"


def _short(x: float) -> str:
    return f"{x:.15g}"


def _plain(value: Any) -> Any:
    """A law parameter as plain Python (a vector as a list of floats)."""
    return list(value) if isinstance(value, tuple) else value
