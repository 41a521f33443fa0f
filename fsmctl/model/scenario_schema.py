"""The scenario file format, described from the same types that validate it.

:func:`file_schema` builds a JSON Schema (draft 2020-12) of a scenario TOML file from the pydantic
dataclasses of :mod:`fsmctl.model.scenario` (their types, ranges, defaults, units and descriptions), adding
the file's shorthands (``[controller]`` defaults for every agent, ``delta_J = {scale = ...}``, law parameters as
further keys of ``[controller]`` and ``[[agents]]``, ``kind`` of sinusoids, the topology tables, one value for every wheel, ``"inf"`` limits,
``extends``, ``[cases]``).  The hardware sections (``[actuator]``, ``[sensors.star_tracker]``,
``[sensors.gyro]``, ``[links]``) and ``simulation.seed`` come from their dataclasses like the others.  :func:`reference_markdown`
turns it into the reference page of every key.  Both are written by::

    python -m fsmctl.model.scenario_schema            # writes docs/scenario-reference.md and the schema
    python -m fsmctl.model.scenario_schema --check    # exit 1 with a diff when they are stale (run by the tests)

The JSON Schema (``fsmctl/scenarios/scenario.schema.json``, shipped in the wheel) can be used by
editors: with Taplo / "Even Better TOML", put ``#:schema ./scenario.schema.json`` on a scenario
file's first line.  The schema checks types, shapes, enums and ranges; the physics checks (SPD and
realizable inertia, grids that are multiples of dt, topology vs agent count, wheel axes spanning 3-D,
per-wheel lists of one value or one per wheel, link tables n x n with a value on every link, sensors
and links only with a control period) run when fsmctl loads the file.
"""

from __future__ import annotations

import argparse
import copy
import difflib
import inspect
import json
import re
import sys
from importlib import resources
from pathlib import Path
from typing import Any

from pydantic import TypeAdapter

import fsmctl.model.scenario as sc

__all__ = ["file_schema", "reference_markdown", "SCHEMA_PATH", "REFERENCE_PATH", "main"]

ROOT = Path(__file__).resolve().parents[2]
SCHEMA_PATH = Path("fsmctl") / "scenarios" / "scenario.schema.json"
REFERENCE_PATH = Path("docs") / "scenario-reference.md"
SCHEMA_ID = "https://fsmctl.invalid/scenario.schema.json"
REQUIRED_SECTIONS = ("controller", "reference", "agents", "topology")
"""the tables a file needs unless it ``extends`` another"""


def _section(cls) -> dict[str, Any]:
    """The JSON Schema of one dataclass, inlined (no ``$defs``), units kept."""
    schema = TypeAdapter(cls).json_schema(mode="validation")
    defs = schema.pop("$defs", {})

    # pydantic leaves the range of an optional number as its own keywords (gt/ge/lt/le) inside anyOf
    names = {"gt": "exclusiveMinimum", "ge": "minimum", "lt": "exclusiveMaximum", "le": "maximum"}

    def inline(node):
        if isinstance(node, dict):
            if "$ref" in node:
                target = copy.deepcopy(defs[node["$ref"].split("/")[-1]])
                extra = {k: v for k, v in node.items() if k != "$ref"}
                return inline({**target, **extra})
            typed = node.get("type") in ("number", "integer")
            return {(names[k] if typed and k in names else k): inline(v) for k, v in node.items()}
        if isinstance(node, list):
            return [inline(v) for v in node]
        return node

    schema = inline(schema)
    schema.pop("title", None)
    for prop in schema.get("properties", {}).values():
        prop.pop("title", None)
    schema["additionalProperties"] = False
    return schema


def _vec3(description: str, unit: str | None = None) -> dict:
    out = {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3, "description": description}
    if unit:
        out["unit"] = unit
    return out


def _mat3(description: str, unit: str | None = None) -> dict:
    out = {"type": "array", "items": _vec3("row"), "minItems": 3, "maxItems": 3, "description": description}
    out["items"].pop("description")
    if unit:
        out["unit"] = unit
    return out


def _sinusoid_table(description: str, unit: str) -> dict:
    s = _section(sc.Sinusoid)
    s["description"] = (
        f"{description}: v_k(t) = amplitude_k cos(frequency_k t + phase_k) + offset_k (k = 1..3), or sin per `kind`"
    )
    s["unit"] = unit
    s["properties"]["kind"] = {
        "type": "array",
        "items": {"enum": ["cos", "sin"]},
        "minItems": 3,
        "maxItems": 3,
        "default": ["cos", "cos", "cos"],
        "description": "per axis: 'cos' as above, or 'sin' for amplitude_k sin(frequency_k t + phase_k) + offset_k",
    }
    return s


def _delta_j_schema() -> dict:
    return {
        "description": "inertia perturbation (eq 29), the plant has J = J0 + delta_J: a 3x3 matrix, or "
        "{scale = s} for delta_J = s J0",
        "unit": "kg m^2",
        "default": {"scale": 0.0},
        "anyOf": [
            _mat3("matrix"),
            {
                "type": "object",
                "properties": {"scale": {"type": "number", "description": "delta_J = scale * J0", "default": 0.0}},
                "additionalProperties": False,
            },
        ],
    }


def _schedule_schema() -> dict:
    return {
        "description": "piecewise-constant weight k^j(t): a number (constant), or a table; segments are "
        "left-closed, value m on [breakpoints[m], breakpoints[m+1]), periodic with `period`",
        "anyOf": [
            {"type": "number", "minimum": 0},
            {
                "type": "object",
                "properties": {
                    "breakpoints": {
                        "type": "array",
                        "items": {"type": "number"},
                        "default": [0.0],
                        "description": "strictly increasing segment starts (periodic: from 0, below the period)",
                        "unit": "s",
                    },
                    "values": {"type": "array", "items": {"type": "number", "minimum": 0}, "description": "weights"},
                    "period": {"type": "number", "exclusiveMinimum": 0, "description": "period", "unit": "s"},
                },
                "required": ["values"],
                "additionalProperties": False,
            },
        ],
    }


def _topology_schema() -> dict:
    sched = _schedule_schema()
    return {
        "type": "object",
        "description": "communication graph of eq 19: exactly one of phase_table, links or kind",
        "properties": {
            "k_i": {"type": "number", "minimum": 0, "default": 0.0, "description": "k^i_ij of every link"},
            "schedule": {**sched, "description": "k^j_ij(t) of every link (before its phase): " + sched["description"]},
            "k_j": {**sched, "description": "synonym of schedule (give one of them)"},
            "phase_table": {
                "type": "array",
                "items": {"type": "array", "items": {"type": "number"}},
                "description": "n x n table: entry [i][j] is the phase phi_ij of the link i <- j (agent i receives "
                "s_j with weight k^j(t + phi_ij)); nan = no link; diagonal nan",
                "unit": "s",
            },
            "links": {
                "type": "array",
                "description": "explicit links",
                "items": {
                    "type": "object",
                    "properties": {
                        "receiver": {"type": "integer", "minimum": 1, "description": "agent i (1-based)"},
                        "sender": {"type": "integer", "minimum": 1, "description": "agent j (1-based)"},
                        "k_i": {"type": "number", "minimum": 0, "description": "k^i_ij (default: the table's k_i)"},
                        "k_j": {**sched, "description": "k^j_ij(t) (default: the table's schedule)"},
                        "phase": {"type": "number", "default": 0.0, "unit": "s", "description": "phase phi_ij"},
                    },
                    "required": ["receiver", "sender"],
                    "additionalProperties": False,
                },
            },
            "kind": {"enum": ["ring", "all-to-all", "k-nearest"], "description": "a generated graph"},
            "neighbours": {"type": "integer", "minimum": 1, "description": "k of kind = 'k-nearest'"},
            "directed": {
                "type": "boolean",
                "default": False,
                "description": "kind = 'ring' only: true = one way, agent i receives from agent i-1 (the cycle 1 -> "
                "2 -> ... -> n -> 1, n links); false = both ways (2n links)",
            },
        },
        "additionalProperties": False,
    }


def _class_doc(cls) -> str:
    """A dataclass's docstring as Markdown-friendly text: up to its Examples, ``code`` as `code`, lines re-flowed
    (paragraphs separated by a blank line, ``* `` bullets on their own lines)."""
    text = inspect.cleandoc(cls.__doc__ or "").split("\nExamples\n")[0].replace("``", "`")
    text = re.sub(r":\w+:`", "`", text)  # Sphinx roles (:mod:`x`) as plain code
    paragraphs = []
    for block in re.split(r"\n\s*\n", text.strip()):
        items: list[str] = []
        for line in block.splitlines():
            line = line.strip()
            if line.startswith("* ") or not items:
                items.append(line)
            else:
                items[-1] += " " + line
        paragraphs.append("\n".join(items))
    return "\n\n".join(paragraphs)


_INF_WORDS = {"enum": ["inf", "infinity", "none"]}


def _per_wheel(node: dict, value: dict, default: Any) -> dict:
    """One value for every wheel, or an array of one value per wheel (the file's shorthand)."""
    return {
        "description": node["description"],
        **({"unit": node["unit"]} if "unit" in node else {}),
        "default": default,
        "anyOf": [value, {"type": "array", "minItems": 1, "items": value}],
    }


def _actuator_schema() -> dict:
    actuator = _section(sc.ActuatorSettings)
    actuator["description"] = _class_doc(sc.ActuatorSettings)
    props = actuator["properties"]
    axes = props["axes"]
    props["axes"] = {
        "type": "array",
        "minItems": 3,
        "maxItems": 3,
        "items": {"type": "array", "minItems": 1, "items": {"type": "number"}},
        "description": axes["description"] + "; rows are body x, y, z, e.g. [[1, 0, 0, 0.577], [0, 1, 0, 0.577], "
        "[0, 0, 1, 0.577]] for 3 orthogonal wheels and a skewed fourth",
        "unit": axes["unit"],
    }
    limit = {"anyOf": [{"type": "number", "exclusiveMinimum": 0}, _INF_WORDS]}
    for name, value in (
        ("spin_inertia", {"type": "number", "exclusiveMinimum": 0}),
        ("max_torque", limit),
        ("max_speed", limit),
        ("viscous_friction", {"type": "number", "minimum": 0}),
        ("coulomb_friction", {"type": "number", "minimum": 0}),
        ("initial_speed", {"type": "number"}),
    ):
        default = getattr(sc.ActuatorSettings(), name)
        default = [("inf" if x == float("inf") else x) for x in default]
        props[name] = _per_wheel(props[name], value, default[0] if len(default) == 1 else default)
    props["wheel_commands"] = _wheel_commands_schema(props["wheel_commands"]["description"])
    return actuator


def _wheel_commands_schema(description: str) -> dict:
    """``[actuator.wheel_commands]``: a table (no null: an unset table is left out), its rows one per time."""
    table = _section(sc.WheelCommandSettings)
    table["description"] = description + "\n\n" + _class_doc(sc.WheelCommandSettings)
    number = {"type": "number"}
    torque = table["properties"]["motor_torque"]
    torque["minItems"] = 1
    torque["items"] = {  # a row: a torque per wheel, or per spacecraft a torque per wheel
        "type": "array",
        "minItems": 1,
        "items": {"anyOf": [number, {"type": "array", "minItems": 1, "items": number}]},
    }
    table["properties"]["time"]["minItems"] = 1
    return table


def _sensors_schema() -> dict:
    sensors = _section(sc.SensorSettings)
    sensors["description"] = _class_doc(sc.SensorSettings)
    for name, cls in (("star_tracker", sc.StarTrackerSettings), ("gyro", sc.GyroSettings)):
        table = _section(cls)
        table["description"] = sensors["properties"][name]["description"] + "\n\n" + _class_doc(cls)
        sensors["properties"][name] = table
    noise = sensors["properties"]["star_tracker"]["properties"]["noise_std"]
    new = _vec3(noise["description"], noise["unit"])
    new["items"]["minimum"] = 0
    sensors["properties"]["star_tracker"]["properties"]["noise_std"] = new
    gyro_bias = sensors["properties"]["gyro"]["properties"]["bias"]
    sensors["properties"]["gyro"]["properties"]["bias"] = {
        **_vec3(gyro_bias["description"], gyro_bias["unit"]),
        "default": gyro_bias["default"],
    }
    return sensors


def _links_schema() -> dict:
    links = _section(sc.LinkSettings)
    links["description"] = _class_doc(sc.LinkSettings)
    props = links["properties"]
    for name in ("good_to_bad", "bad_to_good", "loss_good", "loss_bad"):  # unset: the model's default (described)
        props[name].pop("default", None)
    probability = {"type": "number", "minimum": 0, "maximum": 1}
    for name, value in (
        ("delay_table", {"type": "number", "minimum": 0}),
        ("loss_table", probability),
        *((f"{key}_table", probability) for key in ("good_to_bad", "bad_to_good", "loss_good", "loss_bad")),
    ):
        node = props[name]
        props[name] = {
            "type": "array",
            "items": {"type": "array", "items": value},
            "description": node["description"] + "; nan where there is no link (every link of the topology needs a "
            "value: the tables are checked against it when the file is loaded)",
            "unit": node["unit"],
        }
    return links


def _partial(schema: dict) -> dict:
    """A section as a case overrides it: nothing required, in its sub-tables neither (they are merged too)."""
    out = copy.deepcopy(schema)

    def loosen(node: dict) -> None:
        node.pop("required", None)
        for sub in (node.get("properties") or {}).values():
            if sub.get("type") == "object":
                loosen(sub)

    loosen(out)
    return out


def file_schema() -> dict:
    """JSON Schema of a scenario TOML file (types, shapes, enums, ranges, defaults, units, meanings).

    The same schema is shipped as ``fsmctl/scenarios/scenario.schema.json`` (for editors and validators) and is
    the source of the scenario file reference page (:func:`reference_markdown`).

    Returns
    -------
    dict
        A JSON Schema (draft 2020-12) object; every key carries a ``description`` and, where it has one, a
        ``unit`` and a ``default``.

    Examples
    --------
    >>> from fsmctl.model import file_schema
    >>> schema = file_schema()
    >>> sorted(schema["properties"])[:5]
    ['actuator', 'agents', 'cases', 'choices', 'controller']
    >>> schema["properties"]["controller"]["properties"]["torque_limit"]["unit"]
    'N m'
    """
    controller = _section(sc.ControllerSettings)
    controller["description"] = (
        "what every law shares: the law, the torque limit, the error model, on/off; further keys are the law's "
        "parameters and preset choices by name (fsmctl laws NAME lists them; see Law parameters below), e.g. "
        "c1 = 0.6 for law = 'fsm', K = 2.0 for law = 'pid'"
    )
    law_value = {
        "anyOf": [{"type": "number"}, {"type": "array", "items": {"type": "number"}}, {"type": "string"}],
        "description": "a parameter of the law, by name (number, vector or option string)",
    }
    controller["properties"]["parameters"] = {
        "type": "object",
        "additionalProperties": law_value,
        "description": "the law's named parameters (the same as giving them as further [controller] keys)",
    }
    limit = controller["properties"]["torque_limit"]
    controller["properties"]["torque_limit"] = {
        "description": limit["description"],
        "unit": limit["unit"],
        "default": "inf",
        "anyOf": [{"type": "number", "exclusiveMinimum": 0}, {"enum": ["inf", "infinity", "none"]}],
    }
    controller["properties"]["delta_J"] = {
        **_delta_j_schema(),
        "description": "default of agents' delta_J: " + _delta_j_schema()["description"],
    }
    controller["properties"]["disturbance"] = _sinusoid_table("default of agents' disturbance torque d_i(t)", "N m")
    controller["additionalProperties"] = law_value
    simulation = _section(sc.SimulationSettings)
    simulation["description"] = sc.SimulationSettings.__doc__.split("\n\n")[0].strip() + (
        " t_final, output_interval and control_period are multiples of dt; t_final is a multiple of output_interval"
    )
    simulation["properties"]["seed"]["minimum"] = 0
    agent = _section(sc.Agent)
    agent["description"] = "one spacecraft ([[agents]], in order: agent 1, 2, ...)"
    agent["properties"]["parameters"] = {
        "type": "object",
        "additionalProperties": law_value,
        "description": "this agent's own law parameters (the same as giving them as further [[agents]] keys); "
        "they take precedence over [controller]'s",
    }
    agent["additionalProperties"] = law_value
    agent["properties"]["delta_J"] = _delta_j_schema()
    agent["properties"]["disturbance"] = _sinusoid_table("disturbance torque d_i(t)", "N m")
    agent["required"] = ["J0", "sigma0", "omega0"]
    reference = _section(sc.Reference)
    reference["description"] = "reference attitude sigma_d(0) and rate omega_d(t) (Sec. 4)"
    reference["properties"]["omega"] = _sinusoid_table("reference body rate omega_d(t)", "rad/s")
    topology = _topology_schema()
    sections = {
        "simulation": simulation,
        "controller": controller,
        "actuator": _actuator_schema(),
        "sensors": _sensors_schema(),
        "links": _links_schema(),
        "reference": reference,
        "topology": topology,
    }
    case = {
        "type": "object",
        "description": "a named case: partial overrides of the sections above (not of the agent list)",
        "properties": {
            "description": {"type": "string", "description": "what the case is"},
            **{k: _partial(v) for k, v in sections.items()},
        },
        "additionalProperties": False,
    }
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": SCHEMA_ID,
        "title": "fsmctl scenario file",
        "description": "A formation scenario for fsmctl (Liang, Sun & Wang 2012, Section 4). Units: inertia kg m^2, "
        "angles rad, rates rad/s, torques N m, time s. Generated by `python -m fsmctl.model.scenario_schema`.",
        "type": "object",
        "properties": {
            "extends": {
                "type": "string",
                "description": "start from another scenario file: a built-in name ("
                + ", ".join(f"'{b}'" for b in sc.BUILTIN_SCENARIOS)
                + ") or a TOML file (relative to this one); this file's tables are merged over it key by key, an "
                "array (such as [[agents]]) replaces the base's; the base gives the keys required here",
            },
            "name": {"type": "string", "default": "scenario", "description": "label of the results"},
            "description": {"type": "string", "default": "", "description": "free text, printed with results"},
            **sections,
            "agents": {"type": "array", "minItems": 1, "items": agent, "description": agent["description"]},
            "cases": {
                "type": "object",
                "additionalProperties": case,
                "description": "named cases (the first is the default of --case; without [cases] the file is one "
                "scenario)",
            },
            "choices": {
                "type": "object",
                "additionalProperties": {"type": "string"},
                "description": "what the source leaves open and why each value was chosen (printed with results)",
            },
        },
        "anyOf": [{"required": ["extends"]}, {"required": list(REQUIRED_SECTIONS)}],
        "allOf": _builtin_law_rules(controller, agent),
        "additionalProperties": False,
    }


def _parameter_schema(p) -> dict:
    """A declared law parameter's schema: an option, a number in its range, or (a vector) one or ``size`` of them."""
    if p.choices:
        return {"enum": list(p.choices), "description": p.doc}
    number: dict[str, Any] = {"type": "number"}
    if p.minimum is not None:
        number["exclusiveMinimum" if p.exclusive_minimum else "minimum"] = p.minimum
    if p.maximum is not None:
        number["exclusiveMaximum" if p.exclusive_maximum else "maximum"] = p.maximum
    if p.size == 1:
        return {**number, "description": p.doc}
    vector = {"type": "array", "items": number, "minItems": p.size, "maxItems": p.size}
    return {"anyOf": [number, vector], "description": p.doc}


def _builtin_law_rules(controller: dict, agent: dict) -> list[dict]:
    """One ``if law = NAME then ...`` rule per built-in law: the keys it declares, with their types and ranges.

    A file's law parameters are checked against the flown law's declarations (the loader's rule); for a law given
    by a path the schema cannot know them, and only the generic shape (a number, a vector or an option) is checked.
    """
    from fsmctl.model.laws import builtin_laws

    default = sc.ControllerSettings.__pydantic_fields__["law"].default
    out = []
    for name, law in builtin_laws().items():
        keys = {p.name: _parameter_schema(p) for p in law.parameters}
        keys |= {g.name: {"enum": list(g.options), "description": g.doc} for g in law.presets}
        when: dict[str, Any] = {"properties": {"law": {"const": name}}}
        if name != default:
            when["required"] = ["law"]
        written = {"type": "object", "properties": keys, "additionalProperties": False}
        out.append(
            {
                "if": {"properties": {"controller": when}, "required": ["controller"]},
                "then": {
                    "properties": {
                        "controller": {
                            "properties": {**keys, "parameters": written},
                            "propertyNames": {"enum": sorted({*controller["properties"], *keys})},
                        },
                        "agents": {
                            "items": {
                                "properties": {**keys, "parameters": written},
                                "propertyNames": {"enum": sorted({*agent["properties"], *keys})},
                            }
                        },
                    }
                },
            }
        )
    return out


# ----------------------------------------------------------------------------- Markdown


def _type(node: dict) -> str:
    options = node.get("anyOf", [])
    if len(options) == 2 and options[1].get("type") == "array" and options[1].get("items") == options[0]:
        return f"{_type(options[0])}, or an array of them"  # one value for every wheel, or one per wheel
    if "anyOf" in node:  # null (an unset optional key) has no TOML spelling: leave the key out instead
        return " or ".join(_type(n) for n in node["anyOf"] if n.get("type") != "null")
    if "enum" in node:
        return " \\| ".join(f"`{json.dumps(v)}`" for v in node["enum"])
    if "const" in node:
        return f"`{json.dumps(node['const'])}`"
    t = node.get("type")
    if t == "array" and "prefixItems" in node:
        first = node["prefixItems"][0]
        inner = "3 numbers" if first.get("type") == "array" else _type(first) + "s"
        return "3x3 matrix" if first.get("type") == "array" else f"{len(node['prefixItems'])} {inner}"
    if t == "array":
        items = node.get("items") or {}
        n = node.get("minItems") if node.get("minItems") == node.get("maxItems") else None
        if items.get("type") == "array" and n == 3:
            return "3x3 matrix" if items.get("minItems") == items.get("maxItems") == 3 else "3 x N matrix"
        if items.get("type") == "array" and n is None:
            inner = items.get("items") or {}
            return "n x n table of " + _type(inner) + "s" if "type" in inner else "table of rows"
        if items.get("enum"):
            return f"array of {_type(items)}" + (f" ({n})" if n else "")
        inner = _type(items) if items else "value"
        return f"{n} {inner}s" if n else f"array of {inner}"
    if t == "object":
        return "table"
    if t == "number":
        return "number"
    return str(t or "value")


def _range(node: dict) -> str:
    parts = []
    for key, sym in (("exclusiveMinimum", ">"), ("minimum", ">="), ("exclusiveMaximum", "<"), ("maximum", "<=")):
        if key in node:
            parts.append(f"{sym} {node[key]:g}" if isinstance(node[key], (int, float)) else f"{sym} {node[key]}")
    for sub in node.get("anyOf", []):
        r = _range(sub)
        if r and r not in parts:
            parts.append(r)
    items = node.get("items")
    if isinstance(items, dict):  # the range of every element (of a vector, a per-wheel array, a table's rows)
        r = _range(items)
        if r and r not in parts:
            parts.append(r)
    return ", ".join(parts)


def _default(node: dict, required: bool) -> str:
    if required:
        return "required"
    if "default" not in node:
        return "optional"
    if node["default"] is None:  # an unset optional table (its description says what unset means)
        return "optional"
    return f"`{json.dumps(node['default'])}`"


_SUBTABLES = {"actuator": ("wheel_commands",), "sensors": ("star_tracker", "gyro")}
"""the sub-tables of a section that the reference describes in a section of their own (``[sensors.gyro]``)"""


def _rows(props: dict, required: set[str], prefix: str, *, subtables: tuple[str, ...] = ()) -> list[str]:
    rows = []
    for key, node in props.items():
        rng = _range(node)
        desc = node.get("description", "")
        if key in subtables:  # a sub-table described in a section of its own
            desc = desc.split("\n\n")[0] + f" (`[{prefix}{key}]` below)"
        desc = desc.replace("|", "\\|").replace("\n", " ")
        rows.append(
            f"| `{prefix}{key}` | {_type(node)}{' (' + rng + ')' if rng else ''} | {node.get('unit', '')} "
            f"| {_default(node, key in required)} | {desc} |"
        )
    return rows


def reference_markdown(schema: dict | None = None) -> str:
    """The scenario file reference page (Markdown), generated from :func:`file_schema`.

    Parameters
    ----------
    schema : dict or None, optional
        The schema to describe; None for :func:`file_schema`.

    Returns
    -------
    str
        The page: one table per section (key, type, unit, default, meaning) and examples.

    Examples
    --------
    >>> from fsmctl.model.scenario_schema import reference_markdown
    >>> reference_markdown().splitlines()[1]
    '# Scenario file reference'
    """
    schema = schema or file_schema()
    props = schema["properties"]
    head = "| key | type | unit | default | meaning |\n|---|---|---|---|---|"
    out = [
        "<!-- generated by `python -m fsmctl.model.scenario_schema` from fsmctl/model/scenario.py: do not edit -->",
        "# Scenario file reference",
        "",
        "A scenario is a TOML file (UTF-8) read by `fsmctl simulate --scenario FILE`, `fsmctl prove --scenario FILE`, "
        "`fsmctl montecarlo --scenario FILE`, ... and by `fsmctl.load_scenario(FILE)`. The built-in "
        "`fsmctl/scenarios/paper.toml` (Liang, Sun & Wang 2012, Section 4) is a complete example. "
        "Every value is checked when the file is loaded: a bad one is reported as one line naming the file and the key "
        "(`my.toml: controller.alpha: must be < 1.0, got 1.2`). The same rules apply to scenarios built in Python "
        "(`Scenario(...)`, `scenario.replace(...)`, `dataclasses.replace`).",
        "",
        f"Editors: the JSON Schema `{SCHEMA_PATH.as_posix()}` describes this format (Taplo / Even Better TOML: "
        "`#:schema ./scenario.schema.json` on the first line). Units: inertia kg m^2, angles rad, rates rad/s, "
        "torques N m, time s; `1` means dimensionless.",
        "",
        "Rules checked beyond single values: inertias symmetric positive definite (a warning when not physically "
        "realizable, J1 + J2 < J3); `t_final`, `output_interval` and `control_period` multiples of `dt`; `t_final` "
        "a multiple of `output_interval` (the output grid ends at `t_final`); the topology's agent numbers within "
        "the agent list; every law parameter within the range its law declares; `[sensors]` and imperfect `[links]` "
        "only with `simulation.control_period > 0` (they act at the control instants); the wheel spin axes span "
        '3-D (`layout = "custom"` needs `axes`, the other layouts refuse them); a per-wheel array has one value or '
        "one per wheel; `links.delay_table`/`loss_table` are n x n with a value on every link of the topology.",
        "",
        "Hardware (all off by default, so a file without these tables flies the paper's ideal loop): `[actuator]` "
        "chooses reaction wheels instead of the ideal torque source, `[sensors.star_tracker]` and `[sensors.gyro]` "
        "make the law see measured instead of true states, `[links]` delays and loses the neighbours' broadcasts; "
        "`simulation.seed` seeds every random process of a run (the same seed gives the same run). "
        "`fsmctl/scenarios/paper-hardware.toml` is a complete example.",
        "",
        "## Top level",
        "",
        head,
        *_rows({k: v for k, v in props.items() if k in ("extends", "name", "description")}, set(), ""),
        "",
        "Without `extends` a file needs `[controller]`, `[reference]`, `[[agents]]` and `[topology]`.",
        "",
    ]
    for section in ("simulation", "controller", "actuator", "sensors", "links", "reference", "topology"):
        node = props[section]
        out += [f"## `[{section}]`", "", node.get("description", ""), "", head]
        subtables = _SUBTABLES.get(section, ())
        out += _rows(node["properties"], set(node.get("required", [])), f"{section}.", subtables=subtables)
        out.append("")
        for key in subtables:
            sub = node["properties"][key]
            out += [f"### `[{section}.{key}]`", "", sub.get("description", "").split("\n\n", 1)[-1], "", head]
            out += _rows(sub["properties"], set(sub.get("required", [])), f"{section}.{key}.")
            out.append("")
    agent = props["agents"]["items"]
    out += ["## `[[agents]]`", "", agent["description"], "", head]
    out += _rows(agent["properties"], set(agent.get("required", [])), "agents[i].")
    out += ["", "Every further key of an `[[agents]]` table is a law parameter of that agent (below).", ""]
    out += _law_parameters_section()
    sin = agent["properties"]["disturbance"]
    out += ["## Sinusoid tables (`disturbance`, `reference.omega`)", "", sin["description"], "", head]
    out += _rows(sin["properties"], set(), "")
    out.append("")
    link = props["topology"]["properties"]["links"]["items"]
    out += ["## `topology.links` entries", "", head, *_rows(link["properties"], set(link["required"]), ""), ""]
    out += [
        "## `[cases.NAME]`",
        "",
        props["cases"]["additionalProperties"]["description"]
        + ". A case may hold `description` and any keys of `[simulation]`, `[controller]`, `[actuator]`, "
        '`[sensors]`, `[links]`, `[reference]` and `[topology]` (e.g. `[cases."wheels".actuator]`); they are merged '
        "into the base tables key by key. " + props["cases"]["description"] + ".",
        "",
        "## `[choices]`",
        "",
        props["choices"]["description"] + ': `key = "text"` pairs.',
        "",
    ]
    return "\n".join(out)


def _law_parameters_section() -> list[str]:
    """The rule of law parameters and the table of every built-in law's declared parameters and presets."""
    from fsmctl.model.laws import builtin_laws

    out = [
        "## Law parameters",
        "",
        "A law declares its parameters (name, default, unit, range) in its derivation script; `fsmctl laws NAME` "
        "prints them for any law, built-in or yours. A scenario writes them as further keys of `[controller]` (every "
        "agent) or of an `[[agents]]` table (that agent); for each agent and parameter the value flown is the "
        "agent's own, else `[controller]`'s, else **the flown law's declared default**. A number given for a vector "
        "parameter sets every component. A law may declare preset groups (the paper's `surface`): one key whose "
        "value names a preset that fixes some parameters, over the values written for them. A written key the "
        "law does not declare is an error that names the law and its parameters.",
        "",
        'Flying another law on a scenario (`--law`, `scenario.replace(controller={"law": ...})`) keeps the written '
        "keys that are the same parameter of the new law (the same name, unit and size) and drops the others; one "
        "warning line says which "
        "(`LawSwitchWarning`). `--set KEY=VALUE` sets a parameter for every agent (the agents' own values of it "
        "give way).",
        "",
    ]
    head = "| parameter | default | unit | range | meaning |\n|---|---|---|---|---|"
    for name, law in builtin_laws().items():
        out += [f'### `law = "{name}"`', "", law.doc.split("\n")[0], "", head]
        for p in law.parameters:
            out.append(f"| `{p.name}` | {p.default_text()} | {p.unit} | {p.range_text()} | {p.doc} |")
        for g in law.presets:
            options = ", ".join(
                f"`{k}`" + (" (" + ", ".join(f"{n} = {v[0]:g}" for n, v in o.items()) + ")" if o else "")
                for k, o in g.options.items()
            )
            out.append(f"| `{g.name}` (preset) | {g.default} | | {options} | {g.doc} |")
        out.append("")
    return out


# ----------------------------------------------------------------------------- writing / checking


def _outputs() -> dict[Path, str]:
    schema = file_schema()
    return {
        SCHEMA_PATH: json.dumps(schema, indent=2, allow_nan=False) + "\n",
        REFERENCE_PATH: reference_markdown(schema),
    }


def shipped_schema() -> dict:
    """The JSON Schema shipped with the package (``fsmctl/scenarios/scenario.schema.json``).

    Returns
    -------
    dict
        The parsed file (equal to :func:`file_schema` unless the file is stale).
    """
    return json.loads(resources.files("fsmctl").joinpath("scenarios", "scenario.schema.json").read_text("utf-8"))


def main(argv: list[str] | None = None) -> int:
    """Write (or ``--check``) the scenario reference page and JSON Schema; returns an exit code.

    Parameters
    ----------
    argv : list of str or None, optional
        Command-line arguments (``--check``, ``--root DIR``); None for ``sys.argv[1:]``.

    Returns
    -------
    int
        0 when written or up to date, 1 when ``--check`` finds a stale file.
    """
    parser = argparse.ArgumentParser(
        prog="python -m fsmctl.model.scenario_schema", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--check", action="store_true", help="exit 1 with a diff when the files are stale")
    parser.add_argument("--root", type=Path, default=ROOT, help="repository root (default: this checkout)")
    args = parser.parse_args(argv)
    stale = []
    for rel, text in _outputs().items():
        path = args.root / rel
        current = path.read_text("utf-8") if path.exists() else ""
        if current == text:
            continue
        if args.check:
            stale.append(rel)
            sys.stdout.writelines(
                difflib.unified_diff(current.splitlines(True), text.splitlines(True), str(rel), "new")
            )
        else:
            from fsmctl.outputs import write_text

            write_text(path, text)
            print(f"wrote {rel}")
    if stale:
        print(f"stale: {', '.join(map(str, stale))}; run `python -m fsmctl.model.scenario_schema`", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
