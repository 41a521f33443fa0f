"""Write scenario data as TOML text: the one writer behind every scenario file fsmctl writes.

Used by ``fsmctl tune`` (``best.toml``), ``fsmctl reproduce``'s explanations (``explain/<key>.toml``) and
:meth:`fsmctl.model.scenario.Scenario.to_toml` (:func:`scenario_toml`, the scenario embedded in every result
file); the files are read back by :func:`fsmctl.model.scenario.load_scenario`.  Floats are written with ``repr`` (they
reload to the same bits), ``inf``/``nan`` as TOML's ``inf``/``nan``, strings as JSON-escaped basic strings.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from fsmctl.errors import InputError

__all__ = ["toml_key", "toml_table", "toml_value", "scenario_toml"]

_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def toml_key(k: str) -> str:
    """A TOML key: bare when it may be, else quoted.

    Examples
    --------
    >>> toml_key("c1"), toml_key("a b")
    ('c1', '"a b"')
    """
    return k if _BARE.match(k) else json.dumps(k)


def toml_value(v: Any) -> str:
    """A TOML value (bool, int, float, str, inline table, array).

    Raises
    ------
    InputError
        ``v`` has no TOML form.

    Examples
    --------
    >>> toml_value([0.1, float("inf")]), toml_value({"scale": 0.3})
    ('[0.1, inf]', '{ scale = 0.3 }')
    """
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        x = float(v)
        if math.isnan(x):
            return "nan"
        return repr(x) if math.isfinite(x) else ("inf" if x > 0 else "-inf")
    if isinstance(v, str):  # JSON's escapes are TOML's; DEL must be escaped too, and astral characters stay
        return json.dumps(v, ensure_ascii=False).replace("\x7f", "\\u007f")  # literal (no surrogate pairs)
    if isinstance(v, Mapping):
        return "{ " + ", ".join(f"{toml_key(k)} = {toml_value(x)}" for k, x in v.items()) + " }"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    raise InputError(f"cannot write {v!r} to a scenario file")


def toml_table(path: Sequence[str], table: Mapping, lines: list[str]) -> None:
    """Append ``table`` at ``path`` (``[a.b]`` header, its scalars, then its sub-tables) to ``lines``.

    Examples
    --------
    >>> lines = []
    >>> toml_table(["controller"], {"c1": 0.5, "delta_J": {"scale": 0.3}}, lines)
    >>> lines
    ['', '[controller]', 'c1 = 0.5', '', '[controller.delta_J]', 'scale = 0.3']
    """
    scalars = {k: v for k, v in table.items() if not isinstance(v, Mapping)}
    tables = {k: v for k, v in table.items() if isinstance(v, Mapping)}
    if path and (scalars or not tables):
        lines += ["", "[" + ".".join(toml_key(k) for k in path) + "]"]
    lines += [f"{toml_key(k)} = {toml_value(v)}" for k, v in scalars.items()]
    for k, v in tables.items():
        toml_table([*path, k], v, lines)


def scenario_toml(data: Mapping[str, Any], *, title: str | None = None) -> str:
    """A whole scenario file from the mapping of :meth:`fsmctl.model.scenario.Scenario.to_dict`.

    Top-level keys first, then each section as a table, ``[[agents]]`` as an array of tables (their
    sub-tables inline), arrays of tables such as ``topology.links`` one element per line.

    Parameters
    ----------
    data : Mapping
        The file's tables, as :func:`fsmctl.model.scenario.scenario_from_dict` reads them.
    title : str, optional
        Written as a leading ``#`` comment line.

    Returns
    -------
    str
        TOML text ending with a newline.

    Examples
    --------
    >>> text = scenario_toml({"name": "x", "topology": {"links": [{"receiver": 1, "sender": 2}]},
    ...                       "agents": [{"J0": [[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]]}]}, title="demo")
    >>> print(text)
    # demo
    name = "x"
    <BLANKLINE>
    [topology]
    links = [
      { receiver = 1, sender = 2 },
    ]
    <BLANKLINE>
    [[agents]]
    J0 = [[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]]
    <BLANKLINE>
    """
    lines = [f"# {title}"] if title else []
    lines += [f"{toml_key(k)} = {toml_value(v)}" for k, v in data.items() if not isinstance(v, (Mapping, list))]
    for key, value in data.items():
        if isinstance(value, list) and all(isinstance(x, Mapping) for x in value) and value:
            for item in value:
                lines += ["", f"[[{toml_key(key)}]]"]
                lines += [f"{toml_key(k)} = {toml_value(v)}" for k, v in item.items()]
        elif isinstance(value, list):
            lines.append(f"{toml_key(key)} = {toml_value(value)}")
        elif isinstance(value, Mapping):
            arrays = {k: v for k, v in value.items() if _table_array(v)}
            if not arrays:
                toml_table([key], value, lines)
                continue
            lines += ["", f"[{toml_key(key)}]"]  # scalars and arrays of tables, then the sub-tables
            for k, v in value.items():
                if k in arrays:
                    lines += [f"{toml_key(k)} = [", *(f"  {toml_value(x)}," for x in v), "]"]
                elif not isinstance(v, Mapping):
                    lines.append(f"{toml_key(k)} = {toml_value(v)}")
            for k, v in value.items():
                if isinstance(v, Mapping):
                    toml_table([key, k], v, lines)
    return "\n".join(lines) + "\n"


def _table_array(v: Any) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, Mapping) for x in v)
