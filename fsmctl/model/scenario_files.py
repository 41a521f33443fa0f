"""The scenario file format below the :class:`~fsmctl.model.scenario.Scenario` class: TOML text to tables.

Reading a file (:func:`_read_toml`) or a built-in scenario (:data:`BUILTIN_SCENARIOS`), ``extends`` (a file over
its base, :func:`_resolve_extends`), named cases merged over the base (:func:`_with_case`), the tables of the
settings classes (``[actuator]``, ``[sensors]``, ``[[agents]]``, ...), and the rules shared with
:meth:`Scenario.replace <fsmctl.model.scenario.Scenario.replace>` (a table whose law changes drops the old law's
keys: :func:`_switched_tables`).  :mod:`fsmctl.model.scenario` makes the :class:`Scenario` of the tables
(:func:`~fsmctl.model.scenario.scenario_from_dict`, :func:`~fsmctl.model.scenario.load_scenario`).
"""

from __future__ import annotations

import copy
import dataclasses
import math
import re
import sys
import tomllib
import warnings
from collections.abc import Mapping, Sequence
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fsmctl.model.hardware_settings import (
    ActuatorSettings,
    GyroSettings,
    LinkSettings,
    SensorSettings,
    StarTrackerSettings,
)
from fsmctl.model.laws import (
    AGENT_KEYS,
    LawCode,
    LawError,
    LawSwitchWarning,
    carried_keys,
    resolve_law,
)
from fsmctl.model.scenario_values import _KEY_FIRST, ScenarioError, _is_real, _mat3
from fsmctl.model.settings import (
    _CONTROLLER_FIELDS,
    Agent,
    ControllerSettings,
    Sinusoid,
)
from fsmctl.model.topology import TopologyError
from fsmctl.suggest import did_you_mean

if TYPE_CHECKING:  # pragma: no cover
    from fsmctl.model.scenario import Scenario

BUILTIN_SCENARIOS = ("paper", "paper-hardware")


def _controller_changes(current: Mapping[str, Any], values: Mapping[str, Any]) -> dict[str, Any]:
    """``replace(controller=...)``: own keys replace theirs, the others write law parameters (None unwrites)."""
    out = {k: v for k, v in values.items() if k in _CONTROLLER_FIELDS}
    written = {k: v for k, v in values.items() if k not in _CONTROLLER_FIELDS}
    if written:
        base = dict(out.get("parameters", current["parameters"]))
        base.update(written)
        out["parameters"] = {k: v for k, v in base.items() if v is not None}
    return out


def _agent_changes(agents: tuple[Agent, ...], new: Any) -> tuple[Agent, ...]:
    """``replace(agents=...)``: a sequence of :class:`Agent`, or one mapping of changes per current agent."""
    if isinstance(new, (str, bytes, Mapping)) or not isinstance(new, Sequence):
        raise ScenarioError(f"agents: expected a sequence of Agent (or of mappings of changes), got {new!r}")
    if not any(isinstance(a, Mapping) for a in new):
        return tuple(new)
    if len(new) != len(agents):
        raise ScenarioError(f"agents: {len(new)} mappings of changes for {len(agents)} agents (give one per agent)")
    out = []
    for index, (agent, change) in enumerate(zip(agents, new, strict=True), start=1):
        if not isinstance(change, Mapping):
            raise ScenarioError(f"agents[{index}]: expected a mapping of changes, got {change!r}")
        fields = {f.name for f in dataclasses.fields(Agent)}
        own = {k: v for k, v in change.items() if k in fields and k != "parameters"}
        written = dict(change.get("parameters", agent.parameters))
        written.update({k: v for k, v in change.items() if k not in fields})
        written = {k: v for k, v in written.items() if v is not None}
        out.append(_within(f"agents[{index}]", dataclasses.replace, agent, **own, parameters=written))
    return tuple(out)


def _law_switch_note(old: LawCode, new: LawCode, applied: list[str], ignored: list[str]) -> str:
    """The one line that says which written keys another law flies with (a :class:`LawSwitchWarning`)."""
    return (
        f"law {new.name!r} flown instead of {old.name!r}: written keys applied: {', '.join(applied) or 'none'}; "
        f"ignored (not parameters of {new.name} of the same unit and size): {', '.join(ignored) or 'none'}"
    )


def _warnings_after(build, *args, **kwargs):
    """``build(*args, **kwargs)``, its warnings shown only once it has returned (a failing build is one error)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = build(*args, **kwargs)
    for w in caught:
        warnings.warn(w.message, stacklevel=_outside())
    return out


_SCENARIO_MODULES = frozenset(
    str(Path(__file__).with_name(name))
    for name in ("scenario.py", "scenario_files.py", "settings.py", "scenario_values.py")
)


def _outside() -> int:
    """The ``stacklevel`` of the first caller outside the scenario's modules (a warning points at the user's line)."""
    frame, level = sys._getframe(1), 1
    while frame is not None and frame.f_code.co_filename in _SCENARIO_MODULES:
        frame, level = frame.f_back, level + 1
    return level


def _shown(key: str, value: Any) -> str:
    """``key = value`` as a file writes it (a vector in brackets, an option by name)."""
    if isinstance(value, (tuple, list)):
        return f"{key} = [{', '.join(f'{v:g}' for v in value)}]"
    number = isinstance(value, (int, float)) and not isinstance(value, bool)
    return f"{key} = {value:g}" if number else f"{key} = {value}"


def _sorted_split(written: Mapping[str, Any], keys: set[str], prefix: str = "") -> tuple[list[str], list[str]]:
    """The written keys that carry over (with their values) and those dropped."""
    applied = [_shown(prefix + k, written[k]) for k in sorted(written) if k in keys]
    return applied, [prefix + k for k in sorted(written) if k not in keys]


def _drop_from_table(table: dict, own: set[str], keys: set[str], prefix: str = "") -> tuple[list[str], list[str]]:
    """A file's table (``[controller]``, an ``[[agents]]`` entry): its written law keys, flat or in its
    ``parameters`` sub-table, that are not ``keys`` removed in place; returns :func:`_sorted_split` of them."""
    nested = table.get("parameters") if isinstance(table.get("parameters"), dict) else {}
    written = {k: v for k, v in (table | nested).items() if k not in own and k != "parameters"}
    applied, ignored = _sorted_split(written, keys, prefix)
    for k in written:
        if k not in keys:
            table.pop(k, None)
            nested.pop(k, None)
    return applied, ignored


def _switched_tables(base: dict, over: Mapping, where: str) -> dict:
    """``base`` as the tables ``over`` is merged onto (``extends``, a case): when ``over`` sets another law, the
    base's written keys that the new law does not declare are dropped, as :meth:`Scenario.replace` drops them."""
    over_ctrl, base_ctrl = over.get("controller"), base.get("controller")
    if not isinstance(over_ctrl, Mapping) or "law" not in over_ctrl or not isinstance(base_ctrl, Mapping):
        return base
    default = ControllerSettings.__pydantic_fields__["law"].default
    try:
        old, new = resolve_law(base_ctrl.get("law", default)), resolve_law(over_ctrl["law"])
    except LawError as exc:
        raise ScenarioError(f"{where}.controller.law: {exc}") from None
    if old.folder == new.folder:
        return base
    mine = set(over_ctrl) | set(over_ctrl.get("parameters") or {})  # the overlay's own keys: its law's, checked
    keys = set(carried_keys(old, new)) | mine
    out = copy.deepcopy(base)
    applied, ignored = _drop_from_table(out["controller"], {*_CONTROLLER_FIELDS, *AGENT_DEFAULT_KEYS, *mine}, keys)
    if isinstance(out.get("choices"), dict):  # the reasons of values no longer flown
        out["choices"] = dict(_current_choices(tuple(out["choices"].items()), set(ignored)))
    agents = out.get("agents") if "agents" not in over and isinstance(out.get("agents"), list) else []
    for index, agent in enumerate(agents, start=1):
        if isinstance(agent, dict):
            more = _drop_from_table(agent, set(AGENT_KEYS), keys, f"agents[{index}].")
            applied, ignored = applied + more[0], ignored + more[1]
    if applied or ignored:
        warnings.warn(_law_switch_note(old, new, applied, ignored), LawSwitchWarning, stacklevel=2)
    return out


def _switch_law(scenario: Scenario, changes: dict[str, Any], given: set[str]) -> tuple[dict[str, Any], str | None]:
    """Flying another law: keep the scenario's written keys that are the same parameter of the new law, drop the
    others; returns the changes and the line that says which (None: nothing to say).  The keys ``given`` with the
    switch are the new law's own (checked as any written key)."""
    controller = changes["controller"]
    if not isinstance(controller, Mapping):
        return changes, None
    old, new = scenario.law, resolve_law(controller["law"])
    if old.folder == new.folder:
        return changes, None
    keys = set(carried_keys(old, new)) | given
    agents = changes.get("agents", scenario.agents)
    written = dict(controller["parameters"])
    applied, ignored = _sorted_split({k: v for k, v in written.items() if k not in given}, keys)
    for index, agent in enumerate(agents, start=1):
        more = _sorted_split(dict(agent.parameters), keys, f"agents[{index}].")
        applied, ignored = applied + more[0], ignored + more[1]
    if not (applied or ignored):
        return changes, None
    out = dict(changes)
    out["choices"] = _current_choices(tuple(changes.get("choices", scenario.choices)), set(written) - keys)
    out["controller"] = {**controller, "parameters": {k: v for k, v in written.items() if k in keys}}
    out["agents"] = tuple(
        a
        if all(k in keys for k in a.parameters)
        else dataclasses.replace(a, parameters={k: v for k, v in a.parameters.items() if k in keys})
        for a in agents
    )
    return out, _law_switch_note(old, new, applied, ignored)


# ----------------------------------------------------------------------------- the file format


def _deep_merge(base: dict, over: Mapping) -> dict:
    out = copy.deepcopy(base)
    for k, v in over.items():
        if isinstance(v, Mapping) and isinstance(out.get(k), Mapping):
            out[k] = _deep_merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


TOP_KEYS = (
    "extends",
    "name",
    "description",
    "simulation",
    "controller",
    "actuator",
    "sensors",
    "links",
    "reference",
    "agents",
    "topology",
    "cases",
    "choices",
)
AGENT_DEFAULT_KEYS = ("delta_J", "disturbance")
"""keys of ``[controller]`` that are defaults for every agent (the file's shorthand)"""


def _unknown(d: Mapping, known: Sequence[str], where: str) -> None:
    if not isinstance(d, Mapping):
        raise ScenarioError(f"{where}: expected a table, got {d!r}")
    unknown = sorted(set(d) - set(known))
    if unknown:
        hint = did_you_mean(unknown[0], known)  # fsmctl.suggest: the one rule of suggestions
        raise ScenarioError(f"{where}: unknown key(s) {unknown}{': ' + hint if hint else ''} (known: {sorted(known)})")


def _overlaid(base: dict, over: Mapping) -> dict:
    """``over`` merged onto ``base`` (``extends``, a case), with the base's ``[choices]`` reasons of the controller and
    simulation values ``over`` writes anew dropped (:func:`_current_choices`: a file that extends the paper and sets
    ``boundary_layer = 0.01`` does not fly the paper's reason for ``phi = 0.001``) and ``over``'s own reasons added."""
    merged = _deep_merge(base, over)
    changed: set[str] = set()
    for section in ("controller", "simulation"):
        old, new = base.get(section), over.get(section)
        if not isinstance(new, Mapping):
            continue
        old = old if isinstance(old, Mapping) else {}
        for key, value in new.items():
            if key == "parameters" and isinstance(value, Mapping):  # [controller.parameters]: keys of the law
                inner = old.get("parameters") if isinstance(old.get("parameters"), Mapping) else {}
                changed |= {k for k, v in value.items() if inner.get(k, old.get(k)) != v}
            elif old.get(key) != value:
                changed.add(key)
    reasons = base.get("choices")
    if changed and isinstance(reasons, Mapping):
        mine = over.get("choices")
        kept = dict(_current_choices(tuple(reasons.items()), changed))
        merged["choices"] = {**kept, **(mine if isinstance(mine, Mapping) else {})}
    return merged


def _current_choices(choices: tuple[tuple[str, str], ...], changed: set[str]) -> tuple[tuple[str, str], ...]:
    """The ``[choices]`` reasons that still explain the flown values once the keys ``changed`` are written again: a
    reason about a changed key, or one that names a changed key in its text (the boundary layer's reason quotes
    ``phi/delta``), is about values no longer flown and is dropped."""
    if not changed:
        return choices
    named = re.compile(r"\b(" + "|".join(re.escape(k) for k in sorted(changed)) + r")\b")
    return tuple((k, v) for k, v in choices if k not in changed and not (isinstance(v, str) and named.search(v)))


def _within(where: str, build, *args, **kwargs):
    """Call a constructor and prefix its one-line error with the file's key path."""
    try:
        return build(*args, **kwargs)
    except (ScenarioError, TopologyError) as exc:
        msg = str(exc)
        if msg.startswith(where):
            raise ScenarioError(msg) from None
        # a message about a key ("law: ...") continues the key path; any other (a file's, "/x/law.json: ...") follows it
        raise ScenarioError(f"{where}.{msg}" if _KEY_FIRST.match(msg) else f"{where}: {msg}") from None


def _agent_from_table(d: Mapping, i: int, defaults: Mapping) -> Agent:
    where = f"agents[{i + 1}]"
    if not isinstance(d, Mapping):
        raise ScenarioError(f"{where}: expected a table, got {d!r}")
    for key in ("J0", "sigma0", "omega0"):
        if key not in d:
            raise ScenarioError(f"{where}.{key}: missing")
    J0 = _within(where, lambda v: _mat3_or_error(v, "J0"), d["J0"])
    dJ = d.get("delta_J", defaults.get("delta_J", {"scale": 0.0}))
    src = "delta_J" if "delta_J" in d else "controller.delta_J"
    if isinstance(dJ, Mapping):
        _unknown(dJ, ("scale",), f"{where}.{src}" if src == "delta_J" else src)
        scale = dJ.get("scale", 0.0)
        if not _is_real(scale) or not math.isfinite(scale):
            raise ScenarioError(
                f"{where if src == 'delta_J' else 'controller'}.delta_J.scale: expected a finite number, got {scale!r}"
            )
        dJ = tuple(tuple(scale * x for x in row) for row in J0)
    dist = d.get("disturbance", defaults.get("disturbance"))
    disturbance = Sinusoid() if dist is None else Sinusoid.from_mapping(dist, f"{where}.disturbance")
    return _within(
        where,
        Agent,
        J0=J0,
        delta_J=dJ,
        sigma0=d["sigma0"],
        omega0=d["omega0"],
        disturbance=disturbance,
        parameters=_written_parameters(d, AGENT_KEYS, where),
    )


def _written_parameters(table: Mapping, own: Sequence[str], where: str) -> dict[str, Any]:
    """A table's law parameters: its keys that are not ``own``, merged with its ``parameters`` sub-table."""
    nested = table.get("parameters", {})
    if not isinstance(nested, Mapping):
        raise ScenarioError(f"{where}.parameters: expected a table of the law's parameters by name, got {nested!r}")
    flat = {k: v for k, v in table.items() if k not in own and k != "parameters"}
    twice = sorted(set(flat) & set(nested))
    if twice:
        raise ScenarioError(f"{where}: {twice[0]!r} is given twice (as a key and in {where}.parameters)")
    return {**flat, **nested}


def _mat3_or_error(v: Any, key: str) -> tuple[tuple[float, ...], ...]:
    try:
        return _mat3(v)
    except ValueError as exc:
        raise ScenarioError(f"{key}: {exc}") from None


def _laws_relative_to(data: dict, folder: Path) -> None:
    """A law named by a relative path in a scenario file is relative to the file's folder (in place)."""
    sections = [data.get("controller")] + [
        c.get("controller") for c in (data.get("cases") or {}).values() if isinstance(c, Mapping)
    ]
    for section in sections:
        if isinstance(section, dict) and isinstance(section.get("law"), str):
            law = Path(section["law"]).expanduser()
            if not law.is_absolute() and (law.suffix == ".py" or len(law.parts) > 1) and (folder / law).exists():
                section["law"] = str((folder / law).resolve())


def _with_case(data: Mapping, cases: Mapping, case: str) -> dict:
    """``data`` with ``cases.<case>`` merged over it (its ``description`` aside: :func:`_description` joins it)."""
    if not isinstance(case, str):
        raise ScenarioError(f"case: expected a case name (string), got {case!r}")
    if case not in cases:
        raise ScenarioError(f"no case {case!r} (cases: {list(cases)})")
    override = cases[case]
    if not isinstance(override, Mapping):
        raise ScenarioError(f"cases.{case}: expected a table")
    override = {k: v for k, v in override.items() if k != "description"}
    _unknown(override, TOP_KEYS, f"cases.{case}")
    if "agents" in override:
        raise ScenarioError(f"cases.{case}: cases cannot replace the agent list (override controller.* instead)")
    return _overlaid(_switched_tables(dict(data), override, f"cases.{case}"), override)


def _hardware_settings(merged: Mapping) -> dict[str, Any]:
    """The ``actuator``, ``sensors`` and ``links`` tables as their settings classes."""
    hardware = {}
    for key, cls in (("actuator", ActuatorSettings), ("sensors", SensorSettings), ("links", LinkSettings)):
        table = merged.get(key, {})
        _unknown(table, [f.name for f in dataclasses.fields(cls)], key)
        if key == "sensors":
            table = dict(table)
            for sensor, sensor_cls in (("star_tracker", StarTrackerSettings), ("gyro", GyroSettings)):
                if sensor in table:
                    _unknown(table[sensor], [f.name for f in dataclasses.fields(sensor_cls)], f"sensors.{sensor}")
                    table[sensor] = _within(f"sensors.{sensor}", sensor_cls, **table[sensor])
        hardware[key] = _within(key, cls, **table)
    return hardware


def _description(merged: Mapping, cases: Mapping, case: str | None) -> str:
    """The scenario's description, followed by the case's own (``"... / case 2: ..."``)."""
    description = merged.get("description", "")
    if not isinstance(description, str):
        raise ScenarioError(f"description: expected a string, got {description!r}")
    if case is not None and isinstance(cases[case], Mapping) and "description" in cases[case]:
        case_description = cases[case]["description"]
        if not isinstance(case_description, str):
            raise ScenarioError(f"cases.{case}.description: expected a string, got {case_description!r}")
        description = f"{description} / case {case}: {case_description}".strip(" /")
    return description


def _read_toml(path: Path) -> dict:
    try:
        raw = path.read_bytes()
    except IsADirectoryError:
        raise ScenarioError(f"cannot read scenario file {path}: it is a directory") from None
    except OSError as exc:
        raise ScenarioError(f"cannot read scenario file {path}: {exc.strerror or exc}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ScenarioError(
            f"{path}: not UTF-8 text (byte {exc.start}: {raw[exc.start : exc.start + 1]!r}); TOML files are UTF-8"
        ) from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: not valid TOML ({exc})") from None


def _builtin_data(name: str) -> dict:
    return tomllib.loads(resources.files("fsmctl").joinpath("scenarios", f"{name}.toml").read_text("utf-8"))


def _resolve_extends(data: dict, where: str, folder: Path | None, seen: tuple[str, ...] = ()) -> dict:
    """A file with ``extends = "paper"`` (a built-in name, or a TOML path relative to the file) is its base file
    with this file's tables merged over it (key by key; arrays such as ``[[agents]]`` replace the base's)."""
    base_name = data.get("extends")
    if base_name is None:
        return data
    if not isinstance(base_name, str):
        raise ScenarioError(f"{where}.extends: expected a built-in scenario name or a path, got {base_name!r}")
    if base_name in seen or len(seen) > 8:
        raise ScenarioError(f"{where}.extends: circular or too deep ({' -> '.join((*seen, base_name))})")
    if base_name in BUILTIN_SCENARIOS:
        base, base_folder = _builtin_data(base_name), None
    else:
        path = Path(base_name).expanduser()
        if not path.is_absolute() and folder is not None:
            path = folder / path
        base = _read_toml(path)
        base_folder = path.parent
        _laws_relative_to(base, base_folder)
    base = _resolve_extends(base, f"{where}.extends", base_folder, (*seen, base_name))
    own = {k: v for k, v in data.items() if k != "extends"}
    return _overlaid(_switched_tables(base, own, where), own)
