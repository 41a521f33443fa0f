"""The scenario file format, described from the same types that validate it.

:func:`file_schema` builds a JSON Schema (draft 2020-12) of a scenario TOML file from the pydantic
dataclasses of :mod:`fsmctl.model.scenario` (their types, ranges, defaults, units and descriptions), adding
the file's shorthands (``[controller]`` defaults for every agent, ``delta_J = {scale = ...}``, a scalar
``delta``, ``kind`` of sinusoids, the topology tables, ``[cases]``).  :func:`reference_markdown`
turns it into the reference page of every key.  Both are written by::

    python -m fsmctl.model.scenario_schema            # writes docs/scenario-reference.md and the schema
    python -m fsmctl.model.scenario_schema --check    # exit 1 with a diff when they are stale (run by the tests)

The JSON Schema (``fsmctl/scenarios/scenario.schema.json``, shipped in the wheel) can be used by
editors: with Taplo / "Even Better TOML", put ``#:schema ./scenario.schema.json`` on a scenario
file's first line.  The schema checks types, shapes, enums and ranges; the physics checks (SPD and
realizable inertia, grids that are multiples of dt, topology vs agent count) run when fsmctl loads
the file.
"""

from __future__ import annotations

import argparse
import copy
import difflib
import json
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


def _delta_schema() -> dict:
    return {
        "description": "switching gain delta_i of eq 18 (every component > 0): one number for all axes, or 3 numbers",
        "unit": "1/s^2",
        "anyOf": [{"type": "number", "exclusiveMinimum": 0}, _vec3("per axis")],
    }


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
        },
        "additionalProperties": False,
    }


def _partial(schema: dict) -> dict:
    out = copy.deepcopy(schema)
    out.pop("required", None)
    return out


def file_schema() -> dict:
    """JSON Schema of a scenario TOML file (types, shapes, enums, ranges, defaults, units, meanings)."""
    controller = _section(sc.ControllerSettings)
    controller["description"] = (
        "the control law, its parameters and the actuator limit; further keys are the law's named parameters "
        "(fsmctl laws lists them), e.g. K = 2.0 for law = 'pid'"
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
    controller["properties"]["delta"] = {
        **_delta_schema(),
        "description": "default of agents' delta: " + _delta_schema()["description"],
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
    agent = _section(sc.Agent)
    agent["description"] = "one spacecraft ([[agents]], in order: agent 1, 2, ...)"
    agent["properties"]["delta"] = _delta_schema()
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
        "required": ["controller", "reference", "agents", "topology"],
        "additionalProperties": False,
    }


# ----------------------------------------------------------------------------- Markdown


def _type(node: dict) -> str:
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
            return "3x3 matrix"
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
        if r:
            parts.append(r)
    return ", ".join(parts)


def _default(node: dict, required: bool) -> str:
    if required:
        return "required"
    if "default" not in node:
        return "optional"
    if node["default"] is None:
        return "the law's"
    return f"`{json.dumps(node['default'])}`"


def _rows(props: dict, required: set[str], prefix: str) -> list[str]:
    rows = []
    for key, node in props.items():
        rng = _range(node)
        desc = node.get("description", "").replace("|", "\\|").replace("\n", " ")
        rows.append(
            f"| `{prefix}{key}` | {_type(node)}{' (' + rng + ')' if rng else ''} | {node.get('unit', '')} "
            f"| {_default(node, key in required)} | {desc} |"
        )
    return rows


def reference_markdown(schema: dict | None = None) -> str:
    """The scenario file reference page (Markdown), generated from :func:`file_schema`."""
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
        "the agent list; `c1 > 0` for `fsm`/`lsm` and `c2 > 0` for `fsm`/`tsm`.",
        "",
        "## Top level",
        "",
        head,
        *_rows({k: v for k, v in props.items() if k in ("name", "description")}, set(), ""),
        "",
    ]
    for section in ("simulation", "controller", "reference", "topology"):
        node = props[section]
        out += [f"## `[{section}]`", "", node.get("description", ""), "", head]
        out += _rows(node["properties"], set(node.get("required", [])), f"{section}.")
        out.append("")
    agent = props["agents"]["items"]
    out += ["## `[[agents]]`", "", agent["description"], "", head]
    out += _rows(agent["properties"], set(agent.get("required", [])), "agents[i].")
    out.append("")
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
        + ". A case may hold `description` and any keys of `[simulation]`, `[controller]`, `[reference]` and "
        "`[topology]`; they are merged into the base tables. " + props["cases"]["description"] + ".",
        "",
        "## `[choices]`",
        "",
        props["choices"]["description"] + ': `key = "text"` pairs.',
        "",
    ]
    return "\n".join(out)


# ----------------------------------------------------------------------------- writing / checking


def _outputs() -> dict[Path, str]:
    schema = file_schema()
    return {
        SCHEMA_PATH: json.dumps(schema, indent=2, allow_nan=False) + "\n",
        REFERENCE_PATH: reference_markdown(schema),
    }


def shipped_schema() -> dict:
    """The JSON Schema shipped with the package (``fsmctl/scenarios/scenario.schema.json``)."""
    return json.loads(resources.files("fsmctl").joinpath("scenarios", "scenario.schema.json").read_text("utf-8"))


def main(argv: list[str] | None = None) -> int:
    """Write (or ``--check``) the scenario reference page and JSON Schema; returns an exit code."""
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
