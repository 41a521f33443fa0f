"""The value types and validation machinery of the scenario classes (:mod:`fsmctl.model.scenario`).

:class:`ScenarioError` and :class:`InertiaWarning`; the strict field types (a bool, a string or NaN is never a
number; option strings normalised to lower case); the one-line messages made of pydantic's errors (the key path
first: ``agents[2].J0: ...``); the numpydoc ``Parameters`` sections written from the fields; and the physics
checks the validators call (:func:`check_inertia`).  The settings classes (:mod:`fsmctl.model.settings`) and
:class:`~fsmctl.model.scenario.Scenario` are built on them.
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
import math
import re
import textwrap
import warnings
from collections.abc import Mapping, Sequence
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BeforeValidator, ConfigDict, Field, ValidationError
from pydantic.dataclasses import dataclass

from fsmctl.errors import InputError

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


class UncoupledTopologyWarning(UserWarning):
    """A topology declares links but leaves every weight at its default 0: the agents do not coordinate.

    Said when no weight is written for some link (``[topology] kind = "ring"`` without ``k_i`` and ``k_j``); a file
    that writes the zeros (the paper's Case 2) means them and is not warned about.

    Examples
    --------
    >>> import warnings
    >>> import fsmctl
    >>> from fsmctl.model.scenario import scenario_from_dict
    >>> d = fsmctl.paper_scenario("1").to_dict()
    >>> d["topology"] = {"kind": "ring"}
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     _ = scenario_from_dict(d)
    >>> [str(w.message) for w in caught if w.category is UncoupledTopologyWarning][0][:56]
    'topology: every link has k_i = k_j = 0: the agents do no'
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


def _wheel_torque_table(v: Any) -> tuple:
    """Per-wheel torques over time: a T x N (every spacecraft alike) or T x n x N nested array of finite numbers."""
    if isinstance(v, np.ndarray):
        v = v.tolist()
    what = "a table of motor torques, one row per time (a row per wheel, or per spacecraft and wheel)"
    if isinstance(v, (str, bytes, Mapping)) or not isinstance(v, Sequence) or not len(v):
        raise ValueError(f"expected {what}, got {v!r}")
    shape: list[int] = []
    x = v
    while isinstance(x, Sequence) and not isinstance(x, (str, bytes)):
        if not len(x):
            raise ValueError(f"expected {what}, got an empty row")
        shape.append(len(x))
        x = x[0]
    if len(shape) not in (2, 3):
        raise ValueError(f"expected {what} (2 or 3 levels of nesting), got {len(shape)} level(s)")
    a = _real_array(v, tuple(shape), what)
    return tuple(map(tuple, a)) if a.ndim == 2 else tuple(tuple(map(tuple, b)) for b in a)


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
LossModel = Annotated[Literal["bernoulli", "gilbert_elliott"], BeforeValidator(_lower)]
WheelAllocation = Annotated[Literal["scaled", "clipped"], BeforeValidator(_lower)]
SpeedGate = Annotated[Literal["continuous", "step_start"], BeforeValidator(_lower)]
WheelTorqueTable = Annotated[tuple, BeforeValidator(_wheel_torque_table)]

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
    unknown = [e for e in errors if e["type"] in ("unexpected_keyword_argument", "extra_forbidden")]
    # an unknown key first: a misspelled key is usually why another is "missing", and the one line must name it
    first = unknown[0] if unknown else errors[0]
    path = _loc(first["loc"])
    if unknown:
        keys = sorted(str(e["loc"][-1]) for e in unknown if e["loc"][:-1] == first["loc"][:-1])
        parent = _loc(first["loc"][:-1])
        if len(keys) > 1:
            msg = f"{parent + ': ' if parent else ''}unknown keys {keys}"
        else:
            msg = f"{path}: {_message(first)}" if path else _message(first)
        rest = [e for e in errors if e is not first and not (e in unknown and e["loc"][:-1] == first["loc"][:-1])]
    else:
        text = _message(first)
        # a section's own check names its key ("max_torque: ...", "t_final = ..."): report it as a file does
        # ("actuator.max_torque: ...")
        joined = first["type"] in ("value_error", "assertion_error") and _KEY_FIRST.match(text)
        if joined and path.endswith("parameters"):  # a law parameter: named as the file writes it
            path = path.removesuffix("parameters").rstrip(".")
        msg = (f"{path}.{text}" if joined else f"{path}: {text}") if path else text
        rest = errors[1:]
    if rest:
        nxt = rest[0]
        msg += f" (and {len(rest)} more error{'s' if len(rest) > 1 else ''}, first {_loc(nxt['loc']) or 'the table'}: {_message(nxt)})"
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
