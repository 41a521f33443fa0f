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

Units: inertia kg m^2, angles rad, rates rad/s, torques N m, time s.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import inspect
import math
import re
import sys
import textwrap
import tomllib
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import field
from importlib import resources
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BeforeValidator, ConfigDict, Field, ValidationError, model_validator
from pydantic.dataclasses import dataclass

from fsmctl.errors import InputError
from fsmctl.model.laws import (
    AGENT_KEYS,
    CONTROLLER_KEYS,
    LawCode,
    LawError,
    LawSwitchWarning,
    carried_keys,
    check_written_parameters,
    parameter_matrix,
    resolve_law,
)
from fsmctl.model.topology import Topology, TopologyError

__all__ = [
    "ScenarioError",
    "InertiaWarning",
    "Sinusoid",
    "Agent",
    "Reference",
    "ControllerSettings",
    "SimulationSettings",
    "ActuatorSettings",
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

BUILTIN_SCENARIOS = ("paper", "paper-hardware")
ERROR_MODELS = ("paper", "exact")
INTEGRATORS = ("rk4", "dopri45")
GRID_RTOL = 1e-9
"""relative tolerance of "a multiple of dt" (float rounding only: 0.1 / 0.001 = 99.999...)"""


class ScenarioError(InputError):
    """A scenario (file or object) is malformed; the message names the key path.

    Examples
    --------
    >>> import fsmctl
    >>> try:
    ...     fsmctl.paper_scenario("1").replace(controller={"alpha": 1.5})
    ... except ScenarioError as exc:
    ...     print(exc)
    controller.alpha: must be < 1, got 1.5
    """


class InertiaWarning(UserWarning):
    """An inertia matrix is positive definite but not physically realizable (J1 + J2 < J3).

    Examples
    --------
    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     check_inertia([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 5.0]], "J0")
    >>> caught[0].category.__name__
    'InertiaWarning'
    """


# ----------------------------------------------------------------------------- value types
# Each rule about a single value is written here, once; the dataclasses below and the file schema use these types.


def _is_real(v: Any) -> bool:
    return not isinstance(v, (bool, np.bool_)) and isinstance(v, (int, float, np.integer, np.floating))


def _real(v: Any) -> float:
    """A real number: int or float (Python or NumPy); never a bool or a string."""
    if not _is_real(v):
        raise ValueError(f"expected a number, got {v!r}")
    return float(v)


def _real_array(v: Any, shape: tuple[int, ...], what: str) -> np.ndarray:
    """A strictly numeric array of the given shape: bools, strings and None are refused element by element."""
    if isinstance(v, np.ndarray):
        if v.dtype.kind not in "iuf":
            raise ValueError(f"expected {what}, got an array of dtype {v.dtype}")
        a = v.astype(float)
    else:
        if isinstance(v, (str, bytes, Mapping)) or not isinstance(v, Sequence):
            raise ValueError(f"expected {what}, got {v!r}")

        def conv(x, depth):
            if depth == len(shape):
                if not _is_real(x):
                    raise ValueError(f"expected {what}, got the element {x!r}")
                return float(x)
            if isinstance(x, np.ndarray):
                return conv(x.tolist(), depth)
            if isinstance(x, (str, bytes, Mapping)) or not isinstance(x, Sequence):
                raise ValueError(f"expected {what}, got {v!r}")
            return [conv(y, depth + 1) for y in x]

        nested = conv(v, 0)
        try:
            a = np.array(nested, dtype=float)
        except ValueError:
            raise ValueError(f"expected {what}, got a ragged array {v!r}") from None
    if a.shape != shape:
        raise ValueError(f"expected {what}, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"values must be finite, got {a.tolist()}")
    return a


def _vec3(v: Any) -> tuple[float, float, float]:
    return tuple(float(x) for x in _real_array(v, (3,), "3 numbers"))


def _mat3(v: Any) -> tuple[tuple[float, ...], ...]:
    return tuple(tuple(float(x) for x in row) for row in _real_array(v, (3, 3), "a 3x3 matrix"))


def _numbers(v: Any) -> tuple[float, ...]:
    """One finite number or a flat array of them (a per-wheel value): a tuple, scalars as a 1-tuple."""
    if _is_real(v):
        v = [v]
    if isinstance(v, np.ndarray):
        v = v.tolist()
    if isinstance(v, (str, bytes, Mapping)) or not isinstance(v, Sequence) or not len(v):
        raise ValueError(f"expected a number or an array of numbers, got {v!r}")
    return tuple(float(x) for x in _real_array(list(v), (len(v),), "numbers"))


def _limits(v: Any) -> tuple[float, ...]:
    """Like :func:`_numbers`, where ``inf`` (or ``"inf"``, ``"none"``) means no limit."""
    items = v.tolist() if isinstance(v, np.ndarray) else v
    if _is_real(items) or isinstance(items, str):
        items = [items]
    if isinstance(items, (bytes, Mapping)) or not isinstance(items, Sequence) or not len(items):
        raise ValueError(f"expected a number or an array of numbers, got {v!r}")
    out = []
    for x in items:
        x = _inf_words(x)
        if not (math.isfinite(x) or x == math.inf):
            raise ValueError(f"expected finite numbers or inf, got {v!r}")
        out.append(float(x))
    return tuple(out)


def _matrix(v: Any) -> tuple[tuple[float, ...], ...]:
    """A 3 x N matrix of finite numbers (rows: body axes x, y, z; columns: wheels)."""
    if isinstance(v, np.ndarray):
        v = v.tolist()
    if isinstance(v, (str, bytes, Mapping)) or not isinstance(v, Sequence) or len(v) != 3:
        raise ValueError(f"expected a 3 x N matrix (three rows: body x, y, z; a column per wheel), got {v!r}")
    width = len(v[0]) if isinstance(v[0], Sequence) else 0
    return tuple(tuple(float(x) for x in row) for row in _real_array(v, (3, width), "a 3 x N matrix"))


def _table(v: Any) -> tuple[tuple[float, ...], ...]:
    """A square table of numbers where NaN marks "no link" (checked against the topology by the scenario)."""
    if isinstance(v, np.ndarray):
        v = v.tolist()
    if isinstance(v, (str, bytes, Mapping)) or not isinstance(v, Sequence):
        raise ValueError(f"expected an n x n table, got {v!r}")
    rows = []
    for row in v:
        if isinstance(row, (str, bytes, Mapping)) or not isinstance(row, Sequence) or len(row) != len(v):
            raise ValueError(f"expected an n x n table, got {v!r}")
        if any(not _is_real(x) for x in row):
            raise ValueError(f"expected numbers (nan: no link), got {list(row)!r}")
        rows.append(tuple(float(x) for x in row))
    return tuple(rows)


def _count(v: Any) -> int:
    """A non-negative integer (never a bool or a float)."""
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
        raise ValueError(f"expected a whole number, got {v!r}")
    if v < 0:
        raise ValueError(f"must be >= 0, got {v!r}")
    return int(v)


def _lower(v: Any) -> Any:
    return v.lower() if isinstance(v, str) else v


def _strict_bool(v: Any) -> bool:
    if not isinstance(v, (bool, np.bool_)):
        raise ValueError(f"expected true or false, got {v!r}")
    return bool(v)


def _strict_str(v: Any) -> str:
    if not isinstance(v, str):
        raise ValueError(f"expected a string, got {v!r}")
    return v


def _inf_words(v: Any) -> Any:
    """``"inf"``, ``"infinity"``, ``"none"`` (any case) mean no limit; everything else is checked as a number."""
    if isinstance(v, str) and v.strip().lower() in ("inf", "infinity", "none"):
        return math.inf
    if isinstance(v, float) and math.isinf(v) and v > 0:
        return v
    return _real(v)


class LawParameters(Mapping):
    """A law's named parameters as given in a scenario: a read-only, hashable mapping (vectors are tuples).

    The values are checked against the law's declared ranges by :func:`fsmctl.model.laws.parameter_matrix`.
    """

    __slots__ = ("_items",)

    def __init__(self, items: Mapping[str, Any] | None = None):
        self._items = tuple(sorted((items or {}).items()))

    def __getitem__(self, key: str) -> Any:
        for k, v in self._items:
            if k == key:
                return v
        raise KeyError(key)

    def __iter__(self):
        return (k for k, _ in self._items)

    def __len__(self) -> int:
        return len(self._items)

    def __hash__(self) -> int:
        return hash(self._items)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Mapping) and dict(self._items) == dict(other)

    def __repr__(self) -> str:
        return f"LawParameters({dict(self._items)!r})"

    def __deepcopy__(self, memo: dict) -> LawParameters:
        return self


def _law_parameter_value(key: str, v: Any) -> Any:
    """One written law parameter: a number (float), a vector (tuple of floats) or an option (lower case)."""
    if isinstance(v, str):
        return v.lower()  # option names are case-insensitive, stored and printed in lower case
    if isinstance(v, (list, tuple, np.ndarray)):
        items = list(np.asarray(v, dtype=object).ravel()) if isinstance(v, np.ndarray) else list(v)
        if any(
            isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, float, np.integer, np.floating)) for x in items
        ):
            raise ValueError(f"{key}: a vector parameter holds numbers, got {list(v)!r}")
        return tuple(float(x) for x in items)
    if isinstance(v, (bool, np.bool_)):
        raise ValueError(f"{key}: expected a number, got {v!r}")
    if not isinstance(v, (int, float, np.integer, np.floating)):
        raise ValueError(f"{key}: expected a number, a vector of numbers or an option name, got {v!r}")
    return float(v)


def _law_parameters(value: Any) -> LawParameters:
    """A mapping of written law parameters -> :class:`LawParameters` (numbers as floats, vectors as tuples)."""
    if isinstance(value, LawParameters):
        return value
    if not isinstance(value, Mapping):
        raise ValueError(f"expected a table of the law's parameters by name, got {value!r}")
    out = {}
    for key, v in value.items():
        if not isinstance(key, str):
            raise ValueError(f"parameter names are strings, got {key!r}")
        out[key] = _law_parameter_value(key, v)
    return LawParameters(out)


def _doc(description: str, unit: str | None = None, **kw) -> Any:
    extra = {"unit": unit} if unit else None
    return Field(description=description, json_schema_extra=extra, **kw)


Real = Annotated[float, BeforeValidator(_real)]
Vec3 = Annotated[tuple[float, float, float], BeforeValidator(_vec3)]
Mat3 = Annotated[
    tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]], BeforeValidator(_mat3)
]
Bool = Annotated[bool, BeforeValidator(_strict_bool)]
Text = Annotated[str, BeforeValidator(_strict_str)]
ErrorModel = Annotated[Literal["paper", "exact"], BeforeValidator(_lower)]
Integrator = Annotated[Literal["rk4", "dopri45"], BeforeValidator(_lower)]
TorqueLimit = Annotated[float, Field(gt=0, allow_inf_nan=True), BeforeValidator(_inf_words)]
Numbers = Annotated[tuple[float, ...], BeforeValidator(_numbers)]
LinkTable = Annotated[
    tuple[tuple[Annotated[float, Field(allow_inf_nan=True)], ...], ...], BeforeValidator(_table)
]  # nan: no link
Limits = Annotated[tuple[Annotated[float, Field(allow_inf_nan=True)], ...], BeforeValidator(_limits)]
Matrix3N = Annotated[tuple[tuple[float, ...], ...], BeforeValidator(_matrix)]
ActuatorKind = Annotated[Literal["ideal", "reaction_wheels"], BeforeValidator(_lower)]
WheelLayout = Annotated[Literal["pyramid", "orthogonal", "custom"], BeforeValidator(_lower)]

_CONFIG = ConfigDict(extra="forbid", allow_inf_nan=False, arbitrary_types_allowed=True)
ZERO3 = (0.0, 0.0, 0.0)


# ----------------------------------------------------------------------------- error messages

_PREFIXES = ("Value error, ", "Assertion failed, ")


def _loc(loc: Sequence[Any]) -> str:
    out = ""
    for i, part in enumerate(loc):
        if isinstance(part, int):
            # agents are numbered from 1 in messages (as in the paper and the file's [[agents]] order)
            out += f"[{part + 1}]" if out.endswith("agents") else f"[{part}]"
        else:
            out += ("." if i else "") + str(part)
    return out


_BOUNDS = {
    "greater_than": (">", "gt"),
    "greater_than_equal": (">=", "ge"),
    "less_than": ("<", "lt"),
    "less_than_equal": ("<=", "le"),
}
"""pydantic's range errors: comparison symbol and the key of the bound in the error's context"""


def _message(err: Mapping[str, Any]) -> str:
    kind, ctx, value = err["type"], err.get("ctx") or {}, err.get("input")
    if kind in ("value_error", "assertion_error"):
        msg = str(err["msg"])
        for p in _PREFIXES:
            msg = msg.removeprefix(p)
        return msg
    if kind in _BOUNDS:
        symbol, key = _BOUNDS[kind]
        return f"must be {symbol} {ctx[key]}, got {value!r}"
    if kind == "finite_number":
        return f"must be finite, got {value!r}"
    if kind == "literal_error":
        return f"must be one of {ctx.get('expected', '')}, got {value!r}"
    if kind == "missing" or kind == "missing_argument":
        return "missing"
    if kind in ("unexpected_keyword_argument", "extra_forbidden"):
        return "unknown key"
    if kind in ("dataclass_type", "dataclass_exact_type", "dict_type", "model_type"):
        return f"expected a table, got {value!r}"
    if kind in ("tuple_type", "list_type"):
        return f"expected an array, got {value!r}"
    if kind == "is_instance_of":
        return f"expected {ctx.get('class', 'an instance')}, got {type(value).__name__}"
    return f"{err['msg']} (got {value!r})"


_KEY_FIRST = re.compile(r"^\w+(\[\d+\])*(: | = )")
"""a message that starts with the key it is about"""


def _scenario_error(exc: ValidationError, where: str = "") -> ScenarioError:
    errors = exc.errors(include_url=False)
    first = errors[0]
    path = _loc(first["loc"])
    unknown = [e for e in errors if e["type"] in ("unexpected_keyword_argument", "extra_forbidden")]
    if unknown and first in unknown and len(unknown) > 1:
        keys = sorted(str(e["loc"][-1]) for e in unknown)
        parent = _loc(first["loc"][:-1])
        msg = f"{parent + ': ' if parent else ''}unknown keys {keys}"
    else:
        text = _message(first)
        # a section's own check names its key ("max_torque: ...", "t_final = ..."): report it as a file does
        # ("actuator.max_torque: ...")
        joined = first["type"] in ("value_error", "assertion_error") and _KEY_FIRST.match(text)
        if joined and path.endswith("parameters"):  # a law parameter: named as the file writes it
            path = path.removesuffix("parameters").rstrip(".")
        msg = (f"{path}.{text}" if joined else f"{path}: {text}") if path else text
    if len(errors) > 1 and not (unknown and first in unknown):
        msg += f" (and {len(errors) - 1} more error{'s' if len(errors) > 2 else ''})"
    return ScenarioError(f"{where}: {msg}" if where else msg)


def _type_label(annotation: Any) -> str:
    """A numpydoc type for a field's annotation (``float``, ``tuple of 3 float``, ``{'rk4', 'dopri45'}``, ...)."""
    import typing

    origin, args = typing.get_origin(annotation), typing.get_args(annotation)
    if origin is Annotated:
        return _type_label(args[0])
    if origin is Literal:
        return "{" + ", ".join(repr(a) for a in args) + "}"
    if origin in (typing.Union, __import__("types").UnionType):
        named = [_type_label(a) for a in args if a is not type(None)]
        return " or ".join(named) + (" or None" if type(None) in args else "")
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            inner = _type_label(args[0])
            return f"tuple of ({inner})" if inner.startswith("tuple") else f"tuple of {inner}"
        inner = {_type_label(a) for a in args}
        if len(inner) == 1:
            (one,) = inner
            return f"{len(args)}x3 tuple of float" if one == "tuple of 3 float" else f"tuple of {len(args)} {one}"
        return "tuple"
    if annotation is Any:
        return "mapping"
    return getattr(annotation, "__name__", str(annotation))


def _default_label(info: Any) -> str | None:
    """How a field's default reads in its docstring (None: required)."""
    from pydantic_core import PydanticUndefined

    if info.default_factory is not None:
        value = info.default_factory()
        if dataclasses.is_dataclass(value):
            return f"``{type(value).__name__}()``"
        if isinstance(value, Mapping) and not value:
            return "empty"
    elif info.default is PydanticUndefined:
        return None
    else:
        value = info.default
    if value is None:
        return "None (unset)"
    if isinstance(value, float) and math.isinf(value):
        return "inf"
    return f"``{value!r}``"


_BOUND_WORDS = {"gt": ">", "ge": ">=", "lt": "<", "le": "<="}


def _parameters_section(cls) -> str:
    """The numpydoc "Parameters" section of a settings class, generated from its fields (the schema).

    Each field's type comes from its annotation, its text from its ``description``, its unit from
    ``json_schema_extra``, its bounds from its constraints and its default from the field: the fields are
    written once, where they are declared (the same source :mod:`fsmctl.model.scenario_schema` reads).
    """
    lines = ["Parameters", "----------"]
    for name, info in cls.__pydantic_fields__.items():
        default = _default_label(info)
        head = f"{name} : {_type_label(info.annotation)}" + (", optional" if default is not None else "")
        # |x| is a substitution reference in reStructuredText: shown as literal text in the docs
        text = re.sub(r"\|([^|\s][^|]*?)\|", r"``|\1|``", (info.description or "").strip())
        unit = (info.json_schema_extra or {}).get("unit") if isinstance(info.json_schema_extra, dict) else None
        extras = [f"unit {unit}"] if unit else []
        for meta in info.metadata:
            for key, word in _BOUND_WORDS.items():
                bound = getattr(meta, key, None)
                if bound is not None:
                    extras.append(f"{word} {bound}")
        if default is not None:
            extras.append(f"default {default}")
        body = text[:1].upper() + text[1:] + (" (" + "; ".join(extras) + ")" if extras else "") + "."
        lines += [head, *("    " + ln for ln in textwrap.wrap(body, 110))]
    return "\n".join(lines)


def _with_parameters(cls) -> None:
    """Append the generated "Parameters" section to the class docstring.

    It goes after the hand-written text and Examples: numpydoc renders the sections in its own order
    (Parameters first), and :mod:`fsmctl.model.scenario_schema` takes a class's text up to its Examples for
    the scenario reference, which therefore stays the hand-written text.
    """
    doc = inspect.cleandoc(cls.__doc__ or "")
    cls.__doc__ = doc.rstrip() + "\n\n" + _parameters_section(cls) + "\n"


def _validated(cls):
    """A frozen pydantic dataclass whose construction raises :class:`ScenarioError` (one line, with the key path).

    ``dataclasses.replace`` calls ``__init__``, so copies are validated too.  Settings classes (every field
    declared with :func:`_doc`) get their docstring's "Parameters" section generated from the fields.
    """
    cls = dataclass(frozen=True, config=_CONFIG)(cls)
    if all(info.description for info in cls.__pydantic_fields__.values()):
        _with_parameters(cls)
    init = cls.__init__

    @functools.wraps(init)
    def __init__(self, *args, **kwargs):
        try:
            init(self, *args, **kwargs)
        except ValidationError as exc:
            raise _scenario_error(exc) from None

    cls.__init__ = __init__
    return cls


# ----------------------------------------------------------------------------- physics checks


def check_inertia(J, where: str, *, physical: bool = True) -> None:
    """Raise :class:`ScenarioError` unless ``J`` is symmetric positive definite (and warn unless realizable).

    Parameters
    ----------
    J : array_like, shape (3, 3)
        Inertia matrix (kg m^2).
    where : str
        Key path used in the message.
    physical : bool
        Warn (:class:`InertiaWarning`) when the principal moments violate the triangle inequality.

    Raises
    ------
    ScenarioError
        ``J`` is not a symmetric positive definite 3x3 matrix of finite numbers.

    Examples
    --------
    >>> check_inertia([[100.0, 1.0, 2.0], [1.0, 150.0, 1.0], [2.0, 1.0, 200.0]], "J0")  # fine: no output
    >>> try:
    ...     check_inertia([[1.0, 0, 0], [0, -1.0, 0], [0, 0, 1.0]], "agents[1].J0")
    ... except ScenarioError as exc:
    ...     print(exc)
    agents[1].J0: not positive definite (eigenvalues [-1.0, 1.0, 1.0])
    """
    try:
        a = _real_array(J, (3, 3), "a 3x3 matrix")
    except ValueError as exc:
        raise ScenarioError(f"{where}: {exc}") from None
    problem = _inertia_problem(a, where, physical=physical)
    if problem:
        raise ScenarioError(problem)


def _inertia_problem(a: np.ndarray, where: str, *, physical: bool = True) -> str | None:
    scale = max(1.0, float(np.max(np.abs(a))))
    if np.max(np.abs(a - a.T)) > 1e-9 * scale:
        i, j = np.unravel_index(np.argmax(np.abs(a - a.T)), a.shape)
        return f"{where}: not symmetric ({where}[{i}][{j}] = {a[i, j]}, {where}[{j}][{i}] = {a[j, i]})"
    eig = np.linalg.eigvalsh(0.5 * (a + a.T))
    if eig[0] <= 0:
        return f"{where}: not positive definite (eigenvalues {np.round(eig, 6).tolist()})"
    # A flat plate has J1 + J2 = J3; violations below 1e-3 relative are rounding of such bodies
    # (the paper's J0_4 is one: 1.9e-5) and are reported by `fsmctl reproduce`, not warned about.
    if physical and eig[0] + eig[1] < eig[2] * (1 - 1e-3):
        warnings.warn(
            f"{where}: principal moments {np.round(eig, 6).tolist()} violate the triangle inequality "
            f"J1 + J2 >= J3 of a rigid body by {eig[2] - eig[0] - eig[1]:.3g} kg m^2 (not physically realizable; "
            "simulated as given)",
            InertiaWarning,
            stacklevel=2,
        )
    return None


def _is_multiple(value: float, step: float) -> bool:
    ratio = value / step
    return abs(ratio - round(ratio)) <= GRID_RTOL * max(1.0, ratio) and round(ratio) >= 1


# ----------------------------------------------------------------------------- data classes


@_validated
class Sinusoid:
    """``v_k(t) = amplitude_k cos(frequency_k t + phase_k) + offset_k``, k = 1..3.

    Examples
    --------
    >>> from fsmctl import Sinusoid
    >>> Sinusoid(amplitude=[0.1, 0, 0], frequency=[0.025, 0, 0]).bound().tolist()
    [0.1, 0.0, 0.0]
    """

    amplitude: Vec3 = _doc(
        "amplitude per axis (the unit of the signal: N m for torques, rad/s for rates)", default=ZERO3
    )
    frequency: Vec3 = _doc("angular frequency per axis", "rad/s", default=ZERO3)
    phase: Vec3 = _doc("phase per axis (of the cosine)", "rad", default=ZERO3)
    offset: Vec3 = _doc("constant offset per axis (the unit of the signal)", default=ZERO3)

    def params(self) -> np.ndarray:
        """Packed ``[amplitude, frequency, phase, offset]`` (the generated code's layout)."""
        return np.array([*self.amplitude, *self.frequency, *self.phase, *self.offset], dtype=float)

    def __call__(self, t) -> np.ndarray:
        """Values at time(s) ``t``: shape ``(..., 3)``.

        Evaluated by the generated ``disturbance_torque`` function (the same sinusoid layout), so the
        formula exists once, in ``derive/``.
        """
        from fsmctl.model.casadi_eval import evaluate_mapped
        from fsmctl.model.generated_code import casadi_function

        t = np.asarray(t, dtype=float)
        flat = t.reshape(-1)
        if flat.size == 0:
            return np.zeros((*t.shape, 3))
        (values,) = evaluate_mapped(
            casadi_function("disturbance_torque"), flat.size, [flat, self.params()], shared=(1,)
        )
        values = np.ascontiguousarray(values.T).T  # (m, 3) view of a (3, m) array, the layout callers always had
        return values.reshape(*t.shape, 3)

    def bound(self) -> np.ndarray:
        """Componentwise bound ``|amplitude| + |offset|`` on ``|v_k(t)|``."""
        return np.abs(self.amplitude) + np.abs(self.offset)

    def rate_bound(self) -> np.ndarray:
        """Componentwise bound ``|amplitude frequency|`` on ``|dv_k/dt|``."""
        return np.abs(np.asarray(self.amplitude) * np.asarray(self.frequency))

    @classmethod
    def from_mapping(cls, d: Mapping, where: str = "sinusoid") -> Sinusoid:
        """From a file table with ``amplitude``, ``frequency``, ``phase``, ``offset``, optional ``kind``.

        ``kind = ["cos"|"sin", ...]`` per axis: a ``sin`` component ``a sin(w t + p)`` is stored as
        ``a cos(w t + p - pi/2)``.

        Parameters
        ----------
        d : Mapping
            The table.
        where : str
            Key path used in error messages.

        Returns
        -------
        Sinusoid
            The validated sinusoid.
        """
        if not isinstance(d, Mapping):
            raise ScenarioError(f"{where}: expected a table, got {d!r}")
        d = dict(d)
        kind = d.pop("kind", ["cos", "cos", "cos"])
        if isinstance(kind, str) or not isinstance(kind, Sequence) or len(kind) != 3:
            raise ScenarioError(f"{where}.kind: expected three of 'cos'/'sin', got {kind!r}")
        kinds = [_lower(k) for k in kind]
        for k, kd in enumerate(kinds):
            if kd not in ("cos", "sin"):
                raise ScenarioError(f"{where}.kind[{k}]: must be 'cos' or 'sin', got {kind[k]!r}")
        try:
            s = cls(**d)
        except ScenarioError as exc:
            raise ScenarioError(f"{where}.{exc}") from None
        if "sin" in kinds:
            phase = [p - (math.pi / 2 if kd == "sin" else 0.0) for p, kd in zip(s.phase, kinds, strict=True)]
            s = dataclasses.replace(s, phase=tuple(phase))
        return s


@_validated
class Agent:
    """One spacecraft: inertia, initial state, disturbance and its own law parameters (Liang et al. 2012, eqs 9, 29).

    Examples
    --------
    >>> from fsmctl import Agent
    >>> a = Agent(J0=[[100.0, 0, 0], [0, 150.0, 0], [0, 0, 200.0]], delta_J=[[30.0, 0, 0], [0, 45.0, 0], [0, 0, 60.0]],
    ...           sigma0=[0.3, 0.2, -0.3], omega0=[0.35, -0.13, 0.27])
    >>> a.J_true.diagonal().tolist(), dict(a.parameters)
    ([130.0, 195.0, 260.0], {})
    """

    J0: Mat3 = _doc("nominal inertia, used by the controller (symmetric positive definite)", "kg m^2")
    delta_J: Mat3 = _doc("inertia perturbation: the plant has J = J0 + delta_J (eq 29)", "kg m^2")
    sigma0: Vec3 = _doc("initial attitude (MRP, inertial to body)", "1")
    omega0: Vec3 = _doc("initial body angular velocity", "rad/s")
    parameters: Annotated[Any, BeforeValidator(_law_parameters)] = _doc(
        "this agent's own values of law parameters, by name (in a TOML file: further [[agents]] keys, e.g. the "
        "paper's switching gain delta = [0.005, 0.005, 0.005] of eq 18); they take precedence over [controller]'s",
        default_factory=lambda: LawParameters(),
    )
    disturbance: Sinusoid = _doc("disturbance torque d_i(t)", "N m", default_factory=Sinusoid)

    @model_validator(mode="after")
    def _physics(self) -> Agent:
        for where, J in (("J0", np.array(self.J0)), ("J0 + delta_J", np.array(self.J0) + np.array(self.delta_J))):
            problem = _inertia_problem(J, where)
            if problem:
                raise ValueError(problem)
        if np.linalg.norm(self.sigma0) > 1e6:
            raise ValueError(f"sigma0: |sigma0| = {np.linalg.norm(self.sigma0):.3g} is beyond any attitude")
        return self

    @property
    def J0_array(self) -> np.ndarray:
        """(3, 3) kg m^2: the nominal inertia ``J0`` as an array (what the controller uses)."""
        return np.array(self.J0)

    @property
    def J_true(self) -> np.ndarray:
        """(3, 3) kg m^2: the plant's inertia ``J = J0 + delta_J`` (eq 29)."""
        return np.array(self.J0) + np.array(self.delta_J)


_AGENT_FIELDS = frozenset(f.name for f in dataclasses.fields(Agent))


@_validated
class Reference:
    """Reference attitude ``sigma_d(0)`` and rate ``omega_d(t)`` (Sec. 4).

    Examples
    --------
    >>> import fsmctl
    >>> ref = fsmctl.paper_scenario("1").reference
    >>> ref.sigma0, ref.omega(0.0).round(6).tolist()
    ((-0.3, -0.4, 0.4), [0.1, -0.0, -0.1])
    """

    sigma0: Vec3 = _doc("reference attitude at t = 0 (MRP)", "1")
    omega: Sinusoid = _doc("reference body rate omega_d(t)", "rad/s")


@_validated
class ControllerSettings:
    """What every law shares: the law, its written parameters, the torque limit, the error model, on/off.

    ``law`` names a built-in law (``fsmctl laws``), a derivation script (``.py``) or a derived law folder; a
    relative path in a scenario file is relative to the file's folder (elsewhere: to the current folder).
    Every other ``[controller]`` key of a file (and every other key given to :meth:`Scenario.replace`) is a
    parameter of the law, or the name of one of its preset groups (the paper's law: ``surface = "tsm"``), gathered
    in ``parameters`` and checked against what the law declares (:func:`fsmctl.model.laws.parameter_matrix`).
    A parameter nobody wrote takes the flown law's declared default; an agent's own value (``[[agents]]``) takes
    precedence over ``[controller]``'s.

    Examples
    --------
    >>> import fsmctl
    >>> c = fsmctl.paper_scenario("1").controller
    >>> c.law, c.parameters["c1"], c.parameters["alpha"], c.torque_limit
    ('fsm', 0.6, 0.7, 2.0)
    >>> pid = fsmctl.paper_scenario("1").replace(controller={"law": "pid", "K": 10.0})
    >>> dict(pid.controller.parameters)
    {'K': 10.0}
    """

    law: Text = _doc(
        "control law: a built-in name (fsmctl laws), a derivation script FILE.py or a derived folder", default="fsm"
    )
    parameters: Annotated[Any, BeforeValidator(_law_parameters)] = _doc(
        "the law's parameters and preset choices as written, by name (in a TOML file: further [controller] keys, "
        "e.g. c1 = 0.6 or K = 2.0); unwritten ones take the law's declared defaults",
        default_factory=lambda: LawParameters(),
    )
    torque_limit: TorqueLimit = _doc('per-component torque bound; inf (or "inf") for none', "N m", default=math.inf)
    error_model: ErrorModel = _doc(
        "controller's error kinematics: 'paper' (eqs 7-8 as printed) or 'exact'", default="paper"
    )
    enabled: Bool = _doc(
        "false: the torque is not applied (u = 0, open loop); the law is still evaluated and reported as "
        "u_unsaturated (torque-free and disturbance-only runs)",
        default=True,
    )

    @model_validator(mode="after")
    def _declared(self) -> ControllerSettings:
        for key in self.parameters:
            if key in _CONTROLLER_FIELDS:
                raise ValueError(f"parameters: {key!r} is a [controller] key of its own")
        law = resolve_law(self.law)  # a law that cannot be found is a LawError
        try:
            check_written_parameters(law, self.parameters, "controller")
        except LawError as exc:
            raise ValueError(str(exc).removeprefix("controller.")) from None
        return self

    @property
    def effective_torque_limit(self) -> float:
        """Per-component bound the plant sees: ``torque_limit``, or 0 when the controller is disabled."""
        return self.torque_limit if self.enabled else 0.0


_CONTROLLER_FIELDS = frozenset(f.name for f in dataclasses.fields(ControllerSettings))
if _CONTROLLER_FIELDS != {*CONTROLLER_KEYS, "parameters"}:  # checked at load: the two lists are one rule
    raise ImportError("fsmctl.model.laws.CONTROLLER_KEYS does not list ControllerSettings' fields")


@_validated
class SimulationSettings:
    """Horizon, integrator, step and output grid.

    The grid rule: ``t_final``, ``output_interval`` and ``control_period`` are multiples of ``dt``, and
    ``t_final`` is a multiple of ``output_interval``, so the last output sample is the state at ``t_final``.

    Examples
    --------
    >>> from fsmctl import SimulationSettings
    >>> sim = SimulationSettings(t_final=2.0, dt=0.01, output_interval=0.1, control_period=0.1)
    >>> sim.n_steps, sim.output_every, sim.n_outputs, sim.hold_steps
    (200, 10, 21, 10)
    """

    t_final: Real = _doc("horizon", "s", gt=0, default=100.0)
    dt: Real = _doc("integration step (rk4) or initial step (dopri45)", "s", gt=0, default=1e-3)
    integrator: Integrator = _doc(
        "'rk4' (fixed step, default: sgn defeats adaptive steps) or 'dopri45' (adaptive)", default="rk4"
    )
    output_interval: Real = _doc(
        "spacing of the output samples (a multiple of dt dividing t_final)", "s", gt=0, default=0.01
    )
    control_period: Real = _doc(
        "0: continuous control; > 0: the law runs at the instants k control_period (a multiple of dt: the "
        "integrator steps on them) and its torque is held in between (zero-order hold); sensors and imperfect "
        "links need it",
        "s",
        ge=0,
        default=0.0,
    )
    seed: Annotated[int, BeforeValidator(_count)] = _doc(
        "seed of the run's random processes (sensor noise, packet loss); the same seed gives the same run", default=0
    )
    rtol: Real = _doc("relative tolerance (dopri45)", "1", gt=0, default=1e-8)
    atol: Real = _doc("absolute tolerance (dopri45)", "1", gt=0, default=1e-10)

    @model_validator(mode="after")
    def _grid(self) -> SimulationSettings:
        if self.dt > self.t_final:
            raise ValueError(f"dt = {self.dt} exceeds t_final = {self.t_final}")
        for name in ("t_final", "output_interval") + (("control_period",) if self.control_period > 0 else ()):
            if not _is_multiple(getattr(self, name), self.dt):
                raise ValueError(f"{name} = {getattr(self, name)} must be a multiple of dt = {self.dt}")
        if not _is_multiple(self.t_final, self.output_interval):
            raise ValueError(
                f"t_final = {self.t_final} must be a multiple of output_interval = {self.output_interval} "
                "(the output grid must end at t_final)"
            )
        return self

    @property
    def n_steps(self) -> int:
        """Integration steps of ``dt`` to ``t_final`` (rk4)."""
        return round(self.t_final / self.dt)

    @property
    def output_every(self) -> int:
        """Steps between two output samples."""
        return max(1, round(self.output_interval / self.dt))

    @property
    def n_outputs(self) -> int:
        """Number of output samples, ``t = 0`` and ``t_final`` included."""
        return self.n_steps // self.output_every + 1

    @property
    def hold_steps(self) -> int:
        """Steps between two control instants (0: continuous control)."""
        return round(self.control_period / self.dt) if self.control_period > 0 else 0


@_validated
class ActuatorSettings:
    """How the law's torque reaches the body: an ideal torque source with a per-axis clip, or reaction wheels.

    ``kind = "ideal"`` (default, the paper's actuator): the body receives the law's torque, clipped per axis by
    ``controller.torque_limit``.  ``kind = "reaction_wheels"``: every spacecraft carries the same array of
    balanced wheels (:mod:`fsmctl.symbolic.hardware`; the spacecraft inertia ``J0 + delta_J`` includes them).
    At each control instant the law's torque command (clipped per axis by ``controller.torque_limit``) is
    distributed to the wheels by the minimum-norm rule ``u_w = -pinv(G_s) u``; when a wheel's share exceeds
    ``max_torque`` every wheel torque is scaled by the same factor, so the body torque keeps its direction
    and one wheel sits at its limit.  Between instants the wheel torques are held; a wheel at ``max_speed``
    is not driven further (its torque is 0 while the command would speed it up), and friction acts
    continuously.

    Examples
    --------
    >>> from fsmctl.model.scenario import ActuatorSettings
    >>> ActuatorSettings(kind="reaction_wheels", layout="pyramid").spin_axes().shape
    (3, 4)
    """

    kind: ActuatorKind = _doc("'ideal' (torque source, per-axis clip) or 'reaction_wheels'", default="ideal")
    layout: WheelLayout = _doc(
        "wheel spin axes: 'pyramid' (4 wheels at pyramid_angle from body z, azimuths 45, 135, 225, 315 deg), "
        "'orthogonal' (3 wheels along body x, y, z) or 'custom' (axes)",
        default="pyramid",
    )
    pyramid_angle: Real = _doc(
        "angle between each spin axis and body z (pyramid); 54.7356 deg gives axes (+-1, +-1, 1)/sqrt(3)",
        "deg",
        gt=0,
        lt=90,
        default=54.735610317245346,
    )
    axes: Matrix3N | None = _doc(
        "spin axes of layout = 'custom': a 3 x N matrix, one column per wheel (normalised), spanning 3-D",
        "1",
        default=None,
    )
    spin_inertia: Numbers = _doc("wheel spin-axis inertia J_s: one value, or one per wheel", "kg m^2", default=(0.01,))
    max_torque: Limits = _doc("motor torque limit per wheel (inf: none)", "N m", default=(math.inf,))
    max_speed: Limits = _doc(
        "wheel speed limit relative to the hub (momentum limit J_s max_speed; inf: none)", "rad/s", default=(math.inf,)
    )
    viscous_friction: Numbers = _doc("viscous friction coefficient per wheel", "N m s", default=(0.0,))
    coulomb_friction: Numbers = _doc("Coulomb friction torque per wheel", "N m", default=(0.0,))
    coulomb_band: Real = _doc(
        "speed below which the Coulomb torque is linear in the speed (stiction band; 0: sgn)",
        "rad/s",
        ge=0,
        default=0.1,
    )
    initial_speed: Numbers = _doc("wheel speeds at t = 0: one value, or one per wheel", "rad/s", default=(0.0,))

    @model_validator(mode="after")
    def _wheels(self) -> ActuatorSettings:
        if self.layout == "custom" and self.axes is None:
            raise ValueError("axes: layout = 'custom' needs axes (a 3 x N matrix, one column per wheel)")
        if self.layout != "custom" and self.axes is not None:
            raise ValueError(f"axes: given with layout = {self.layout!r}; set layout = 'custom' to use them")
        G = self._raw_axes()
        norms = np.linalg.norm(G, axis=0)
        if np.any(norms == 0):
            raise ValueError(f"axes: wheel {int(np.argmin(norms)) + 1} has a zero spin axis")
        if np.linalg.matrix_rank(G / norms, tol=1e-9) < 3:
            raise ValueError(
                "axes: the spin axes do not span 3-D, so some body torques cannot be produced (give at least "
                "three axes that are not coplanar)"
            )
        n = G.shape[1]
        for name in (
            "spin_inertia",
            "max_torque",
            "max_speed",
            "viscous_friction",
            "coulomb_friction",
            "initial_speed",
        ):
            v = getattr(self, name)
            if len(v) not in (1, n):
                raise ValueError(f"{name}: give one value or one per wheel ({n}), got {len(v)}")
        for name in ("spin_inertia", "max_torque", "max_speed"):
            if not all(x > 0 for x in getattr(self, name)):
                raise ValueError(f"{name}: every value must be > 0, got {list(getattr(self, name))}")
        for name in ("viscous_friction", "coulomb_friction"):
            if not all(x >= 0 for x in getattr(self, name)):
                raise ValueError(f"{name}: every value must be >= 0, got {list(getattr(self, name))}")
        return self

    def _raw_axes(self) -> np.ndarray:
        if self.layout == "orthogonal":
            return np.eye(3)
        if self.layout == "pyramid":
            b = math.radians(self.pyramid_angle)
            az = np.radians([45.0, 135.0, 225.0, 315.0])
            return np.array([math.sin(b) * np.cos(az), math.sin(b) * np.sin(az), np.full(4, math.cos(b))])
        return np.array(self.axes, dtype=float)

    @property
    def enabled(self) -> bool:
        """Whether the spacecraft fly reaction wheels (else the ideal torque source)."""
        return self.kind == "reaction_wheels"

    @property
    def n_wheels(self) -> int:
        """Wheels per spacecraft (0 for the ideal actuator)."""
        return self._raw_axes().shape[1] if self.enabled else 0

    def spin_axes(self) -> np.ndarray:
        """``(3, N)`` unit spin axes ``G_s`` in the body frame, one column per wheel."""
        G = self._raw_axes()
        return G / np.linalg.norm(G, axis=0)

    def spin_inertia_matrix(self) -> np.ndarray:
        """``J_spin = sum_k J_s,k g_k g_k^T`` (3, 3) of the wheels (zero for the ideal actuator)."""
        from fsmctl.model.actuators import spin_inertia_matrix

        if not self.enabled:
            return np.zeros((3, 3))
        return spin_inertia_matrix(self.spin_axes(), self.per_wheel("spin_inertia"))

    def per_wheel(self, name: str) -> np.ndarray:
        """``(N,)`` values of a per-wheel setting (one value broadcast to every wheel).

        Parameters
        ----------
        name : str
            A per-wheel field (``"spin_inertia"``, ``"max_torque"``, ``"max_speed"``, ...).

        Returns
        -------
        numpy.ndarray
            One value per wheel.
        """
        v = np.array(getattr(self, name), dtype=float)
        return np.broadcast_to(v, (self._raw_axes().shape[1],)).copy()


@_validated
class StarTrackerSettings:
    """Attitude sensor: the measured attitude is the true one rotated by a small body-frame rotation
    ``dtheta`` drawn at each control instant, independent, zero-mean Gaussian with per-axis standard
    deviation ``noise_std`` (white noise in small-angle form; :func:`fsmctl.symbolic.hardware.star_tracker_measurement`).

    Examples
    --------
    >>> from fsmctl import StarTrackerSettings
    >>> StarTrackerSettings(noise_std=[2.424e-5, 2.424e-5, 4.848e-5]).noise_std
    (2.424e-05, 2.424e-05, 4.848e-05)
    """

    noise_std: Vec3 = _doc("1-sigma of the measurement error about body x, y, z (5 arcsec = 2.424e-5 rad)", "rad")

    @model_validator(mode="after")
    def _positive(self) -> StarTrackerSettings:
        if not all(x >= 0 for x in self.noise_std):
            raise ValueError(f"noise_std: must be >= 0, got {list(self.noise_std)}")
        return self


@_validated
class GyroSettings:
    """Rate gyro: ``omega_measured = omega + b + eta_v`` with ``b_dot = eta_u`` (Farrenkopf's model, sampled at
    the control instants; :mod:`fsmctl.model.noise`): angle random walk ``N`` (the density of eta_v), rate
    random walk ``K`` (the density of eta_u: the bias drift) and a constant bias ``b_0``.

    Examples
    --------
    >>> import fsmctl
    >>> gyro = fsmctl.load_scenario("paper-hardware").sensors.gyro
    >>> gyro.angle_random_walk, gyro.bias
    (4.363e-05, (4.848e-06, -4.848e-06, 2.424e-06))
    """

    angle_random_walk: Real = _doc(
        "angle random walk N (0.1 deg/sqrt(h) = 2.909e-5 rad/sqrt(s))", "rad/s^0.5", ge=0, default=0.0
    )
    rate_random_walk: Real = _doc(
        "rate random walk K: the bias's random walk (1 deg/h/sqrt(h) = 8.08e-8 rad/s^1.5)",
        "rad/s^1.5",
        ge=0,
        default=0.0,
    )
    bias: Vec3 = _doc("constant bias b_0 about body x, y, z (1 deg/h = 4.848e-6 rad/s)", "rad/s", default=ZERO3)


@_validated
class SensorSettings:
    """What the law sees.  Unset sensors are perfect; a configured sensor is sampled at the control instants
    (``simulation.control_period > 0``), its noise drawn from ``simulation.seed``.  The metrics always see
    the true state.

    Examples
    --------
    >>> import fsmctl
    >>> fsmctl.paper_scenario("1").sensors.enabled, fsmctl.load_scenario("paper-hardware").sensors.enabled
    (False, True)
    """

    star_tracker: StarTrackerSettings | None = _doc("attitude sensor (unset: the true attitude)", default=None)
    gyro: GyroSettings | None = _doc("rate gyro (unset: the true rate)", default=None)

    @property
    def enabled(self) -> bool:
        """Whether any sensor is configured (else the law sees the true state)."""
        return self.star_tracker is not None or self.gyro is not None


@_validated
class LinkSettings:
    """Imperfect communication links, applied at the control instants (``simulation.control_period > 0``).

    * Delay: the receiver gets the neighbour's broadcast as it was ``delay`` seconds earlier (its value at the
      latest control instant at or before ``t - delay``; before ``t = 0`` the broadcast's initial value,
      the constant initial history of delay equations).
    * Loss: at each control instant each link independently loses its packet with ``loss_probability``; the
      receiver then holds the last value it received on that link.

    ``delay_table`` / ``loss_table`` (n x n, row = receiver, column = sender, like ``topology.phase_table``)
    set a value per link and override the scalars.

    Examples
    --------
    >>> from fsmctl import LinkSettings
    >>> links = LinkSettings(delay=0.1, loss_table=[[0.0, 0.05], [0.2, 0.0]])
    >>> links.enabled, links.per_link([0, 1], [1, 0], "loss_probability").tolist()
    (True, [0.05, 0.2])
    """

    delay: Real = _doc("transport delay of every link", "s", ge=0, default=0.0)
    loss_probability: Real = _doc(
        "probability that a link loses its packet at a control instant", "1", ge=0, le=1, default=0.0
    )
    delay_table: LinkTable | None = _doc(
        "per-link delay, n x n (row receiver, column sender; entries without a link are ignored)", "s", default=None
    )
    loss_table: LinkTable | None = _doc(
        "per-link loss probability, n x n (row receiver, column sender)", "1", default=None
    )

    @property
    def enabled(self) -> bool:
        """Whether any delay or loss is set (tables count only where a value is > 0)."""

        def any_table(tab, floor):
            return tab is not None and any(math.isfinite(x) and x > floor for row in tab for x in row)

        return (
            self.delay > 0
            or self.loss_probability > 0
            or any_table(self.delay_table, 0.0)
            or any_table(self.loss_table, 0.0)
        )

    def per_link(self, receivers, senders, which: str) -> np.ndarray:
        """Values of ``"delay"`` or ``"loss_probability"`` for the links ``receivers[e] <- senders[e]`` (0-based).

        Parameters
        ----------
        receivers, senders : sequence of int
            The links' agents, 0-based.
        which : {"delay", "loss_probability"}
            The setting.

        Returns
        -------
        numpy.ndarray
            One value per link (the table's entry, else the scalar).
        """
        table = self.delay_table if which == "delay" else self.loss_table
        scalar = self.delay if which == "delay" else self.loss_probability
        if table is None:
            return np.full(len(receivers), scalar, dtype=float)
        tab = np.array(table, dtype=float)
        return np.array([tab[i, j] for i, j in zip(receivers, senders, strict=True)], dtype=float)


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
        if self.actuator.enabled:  # the hub inertia J - J_spin must be a rigid body's
            from fsmctl.model.actuators import hub_inertia_problem

            J_spin = self.actuator.spin_inertia_matrix()
            for i, agent in enumerate(self.agents, start=1):
                problem = hub_inertia_problem(agent.J_true, J_spin)
                if problem:
                    raise ValueError(f"actuator.spin_inertia: the wheels' spin inertia exceeds agent {i}'s: {problem}")
        linked = {(lk.receiver, lk.sender) for lk in self.topology.links}
        for name, upper in (("delay_table", math.inf), ("loss_table", 1.0)):
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
        if self.links_active and not period > 0:
            raise ValueError(
                "links: sensors and imperfect links act at the control instants; set "
                "simulation.control_period > 0 (e.g. 0.1 for 10 Hz control)"
            )
        law = resolve_law(self.controller.law)  # a law that cannot be found is a LawError
        try:
            parameter_matrix(law, self)  # the written keys against the law's declarations and ranges
        except LawError as exc:
            raise ValueError(str(exc)) from None
        return self

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
        if given & {k for k, _ in self.choices}:  # a choice's reason is about the value it replaces
            changes["choices"] = tuple((k, v) for k, v in self.choices if k not in given)
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
            np.any(lk.per_link(receivers, senders, "delay") > 0)
            or np.any(lk.per_link(receivers, senders, "loss_probability") > 0)
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
                + f" coulomb_band={a.coulomb_band}"
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
            lines.append(
                f"  links: delay={'per link' if lk.delay_table is not None else f'{lk.delay} s'} loss_probability="
                + ("per link" if lk.loss_table is not None else f"{lk.loss_probability}")
            )
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
            f"  law: {law.name} ({law.source or law.folder})"
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


def _outside() -> int:
    """The ``stacklevel`` of the first caller outside this module (a warning points at the user's line)."""
    frame, level = sys._getframe(1), 1
    while frame is not None and frame.f_code.co_filename == __file__:
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
    if isinstance(out.get("choices"), dict):
        for k in ignored:
            out["choices"].pop(k, None)  # the reason of a value no longer flown
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
    out["choices"] = tuple((k, v) for k, v in changes.get("choices", scenario.choices) if k not in written or k in keys)
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
        raise ScenarioError(f"{where}: unknown key(s) {unknown} (known: {sorted(known)})")


def _within(where: str, build, *args, **kwargs):
    """Call a constructor and prefix its one-line error with the file's key path."""
    try:
        return build(*args, **kwargs)
    except (ScenarioError, TopologyError) as exc:
        msg = str(exc)
        raise ScenarioError(msg if msg.startswith(where) else f"{where}.{msg}") from None


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
    return _deep_merge(_switched_tables(dict(data), override, f"cases.{case}"), override)


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
    merged = _deep_merge(_switched_tables(base, own, where), own)
    return merged


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
