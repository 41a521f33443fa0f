"""Argument checks of the plug-in's factories and systems: one line naming the argument, never a wrong result.

Numbers and arrays (:func:`_numbers`, :func:`_scalar`: a bool, a string, None or a complex number is refused),
inertias, limits and sinusoid parameters, system names, signal labels.  Used by :mod:`fsmctl.plugin.iosys`,
:mod:`fsmctl.plugin.hardware`, :mod:`fsmctl.plugin.sampled` and :mod:`fsmctl.plugin.formation`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from fsmctl.model.scenario import ActuatorSettings, ScenarioError, Sinusoid, check_inertia


def _labels(name: str, n: int = 3) -> list[str]:
    return [f"{name}[{k}]" for k in range(n)]


# ----------------------------------------------------------------------------- argument validation
# Factory arguments and parameter values passed at simulation time go through these checks; every failure is
# a ScenarioError with a one-line message that names the argument.

_OK = object()


def _show(value: Any) -> str:
    """A one-line, bounded description of a value for an error message."""
    if isinstance(value, np.ndarray):
        text = np.array2string(value, separator=", ", max_line_width=10**6, threshold=20)
    else:
        text = repr(value)
    text = " ".join(text.split())
    return text if len(text) <= 120 else text[:117] + "..."


def _first_non_number(value: Any) -> Any:
    """The first element of ``value`` that is not a real number (bools and strings are not), else ``_OK``."""
    if isinstance(value, np.ndarray):
        return _OK if value.dtype.kind in "iuf" else value
    if isinstance(value, (list, tuple)):
        for element in value:
            bad = _first_non_number(element)
            if bad is not _OK:
                return bad
        return _OK
    if isinstance(value, (bool, np.bool_)):
        return value
    if isinstance(value, (int, float, np.integer, np.floating)):
        return _OK
    return value


def _describe_non_number(bad: Any) -> str:
    if isinstance(bad, np.ndarray):
        return f"an array of dtype {bad.dtype}"
    return f"{_show(bad)} ({type(bad).__name__})"


def _numbers(value: Any, shape: tuple[int, ...], what: str, where: str) -> np.ndarray:
    """A finite float array of the given shape (read-only copy); bools, strings, None, complex are refused."""
    if (
        isinstance(value, np.ndarray)
        and value.dtype == np.float64
        and value.shape == shape
        and not value.flags.writeable
        and value.flags.owndata
        and np.isfinite(value).all()
    ):
        return value  # already checked (what this module stores): no copy, so later lookups are by identity
    bad = _first_non_number(value)
    if bad is not _OK:
        raise ScenarioError(f"{where}: expected {what}, got {_describe_non_number(bad)}")
    try:
        a = np.array(value, dtype=float)
    except ValueError:
        raise ScenarioError(f"{where}: expected {what}, got the ragged {_show(value)}") from None
    if a.shape != shape:
        raise ScenarioError(f"{where}: expected {what}, got shape {a.shape}")
    finite = np.isfinite(a)
    if not finite.all():
        index = np.unravel_index(np.argmin(finite), a.shape)
        raise ScenarioError(f"{where}: not finite (element {list(map(int, index))} is {a[index]})")
    a.setflags(write=False)
    return a


def _scalar(value: Any, where: str, *, minimum: float | None = None, strict: bool = False, inf: bool = False) -> float:
    """A real number (never a bool or a string), finite unless ``inf``, ``> minimum`` (strict) or ``>= minimum``."""
    if isinstance(value, np.ndarray) and value.shape == ():
        value = value[()]
    if _first_non_number(value) is not _OK or isinstance(value, (list, tuple, np.ndarray)):
        raise ScenarioError(f"{where}: expected a real number, got {_describe_non_number(value)}")
    x = float(value)
    if math.isnan(x) or (math.isinf(x) and not (inf and x > 0)):
        raise ScenarioError(f"{where}: must be {'a number or +inf' if inf else 'finite'}, got {x}")
    if minimum is not None and (x <= minimum if strict else x < minimum):
        raise ScenarioError(f"{where}: must be {'>' if strict else '>='} {minimum}, got {x}")
    return x


def _inertia(value: Any, where: str) -> np.ndarray:
    """A finite, symmetric positive-definite 3x3 matrix (read-only)."""
    a = _numbers(value, (3, 3), "a 3x3 matrix of real numbers", where)
    check_inertia(a, where, physical=False)  # the scenario's SPD rule, written once
    return a


def _positive3(value: Any, where: str) -> np.ndarray:
    a = _numbers(value, (3,), "three real numbers", where)
    if not np.all(a > 0):
        raise ScenarioError(f"{where}: every component must be > 0 (eq 18), got {a.tolist()}")
    return a


def _twelve(value: Any, where: str) -> np.ndarray:
    """The packed sinusoid ``[amplitude, frequency, phase, offset]`` (manifest layout ``sinusoid_params``)."""
    return _numbers(value, (12,), "12 real numbers [amplitude, frequency, phase, offset]", where)


def _torque_limit(value: Any, where: str) -> float:
    return _scalar(value, where, minimum=0.0, inf=True)


def _sinusoid(value: Any, where: str) -> np.ndarray:
    if not isinstance(value, Sinusoid):
        raise ScenarioError(f"{where}: expected a fsmctl.Sinusoid, got {type(value).__name__}")
    return _twelve(value.params(), where)


def _system_name(name: Any, kind: str) -> str | None:
    if name is None:
        return None
    if not isinstance(name, str) or not name or "." in name:
        raise ScenarioError(f"{kind}: name must be a non-empty string without '.', got {_show(name)}")
    return name


def _timebase(dt: Any, static: bool, where: str) -> float | bool | None:
    """python-control's ``dt`` for a continuous-time model (0, or None: unspecified) or a static map (any)."""
    if dt is None:
        return None if static else 0
    if isinstance(dt, (bool, np.bool_)):
        discrete = bool(dt)
    elif (
        _first_non_number(dt) is _OK and not isinstance(dt, (list, tuple, np.ndarray)) and math.isfinite(dt) and dt >= 0
    ):
        discrete = dt > 0
    else:
        raise ScenarioError(
            f"{where}: dt: expected 0 (continuous time), None (unspecified), True or a positive sampling period, "
            f"got {_show(dt)}"
        )
    if not discrete:
        return 0
    if static:
        return True if dt is True else float(dt)
    raise ScenarioError(
        f"{where}: dt={dt!r}: this is a continuous-time system (dt=0, or None); for a sampled-data loop use "
        "fsmctl.plugin.sampled: zoh(system, dt) samples a plant or the reference, discrete_law_controller(..., dt=) "
        "runs a law at its instants (the plug-in guide, 'Sampled-data loops')"
    )


_PREFIX = {"inputs": "u", "outputs": "y", "states": "x"}
"""python-control's default signal prefixes (``nlsys(..., inputs=3)`` names them ``u[0..2]``)."""


def _signal_names(given: Any, default: list[str], what: str, where: str) -> list[str]:
    """The signal names ``inputs=``, ``outputs=`` or ``states=`` give (python-control's forms), ``default`` if None."""
    if given is None:
        return default
    n = len(default)
    like = f"[{default[0]}, ..., {default[-1]}]" if n > 1 else f"[{default[0]}]" if n else "none"
    if isinstance(given, (int, np.integer)) and not isinstance(given, (bool, np.bool_)):
        labels = [f"{_PREFIX[what]}[{k}]" for k in range(int(given))]
    elif isinstance(given, str):
        labels = [given]
    elif isinstance(given, Sequence) and all(isinstance(label, str) for label in given):
        labels = list(given)
    else:
        raise ScenarioError(f"{where}: {what}: expected a list of {n} signal names, got {_show(given)}")
    if len(labels) != n:
        raise ScenarioError(f"{where}: {what}: expected {n} names (default {like}), got {len(labels)}")
    bad = [label for label in labels if not label or "." in label]
    if bad:
        raise ScenarioError(f"{where}: {what}: a signal name must be non-empty and without '.', got {bad[0]!r}")
    if len(set(labels)) != n:
        twice = next(label for label in labels if labels.count(label) > 1)
        raise ScenarioError(f"{where}: {what}: the name {twice!r} is given twice")
    return labels


# ----------------------------------------------------------------------------- reaction wheels


def _actuator(value: Any, where: str) -> ActuatorSettings:
    """An :class:`ActuatorSettings` of reaction wheels (a mapping is read as one, ``kind`` defaulting to wheels)."""
    if isinstance(value, Mapping):
        try:
            value = ActuatorSettings(**{"kind": "reaction_wheels", **value})
        except TypeError as exc:  # a non-string key
            raise ScenarioError(f"{where}: actuator: {exc}") from None
        except ScenarioError as exc:
            raise ScenarioError(f"{where}: actuator: {exc}") from None
    if not isinstance(value, ActuatorSettings):
        raise ScenarioError(
            f"{where}: actuator: expected ActuatorSettings or a mapping of its fields, got {type(value).__name__}"
        )
    if not value.enabled:
        raise ScenarioError(
            f"{where}: actuator: kind is {value.kind!r}; this plant flies reaction wheels (kind 'reaction_wheels'), "
            "the ideal torque source is fsmctl.spacecraft"
        )
    return value


def _axes_check(n: int):
    def check(value: Any, where: str) -> np.ndarray:
        G = _numbers(value, (3, n), f"a 3 x {n} matrix of spin axes (one column per wheel)", where)
        norms = np.linalg.norm(G, axis=0)
        if np.any(norms == 0):
            raise ScenarioError(f"{where}: wheel {int(np.argmin(norms)) + 1} has a zero spin axis")
        if np.linalg.matrix_rank(G / norms, tol=1e-9) < 3:
            raise ScenarioError(f"{where}: the spin axes do not span 3-D")
        if np.allclose(norms, 1.0, rtol=0, atol=1e-15):
            return G
        unit = G / norms
        unit.setflags(write=False)
        return unit

    return check


def _per_wheel_check(n: int, *, positive: bool, inf: bool):
    """Validator of a per-wheel setting: one number or ``n`` numbers, ``> 0`` (``positive``) or ``>= 0``."""

    def check(value: Any, where: str) -> np.ndarray:
        if isinstance(value, np.ndarray) and value.ndim == 0:
            value = value[()]
        items = list(value) if isinstance(value, (list, tuple, np.ndarray)) else [value]
        if (isinstance(value, np.ndarray) and value.ndim != 1) or len(items) not in (1, n):
            raise ScenarioError(f"{where}: expected one real number or {n} (one per wheel), got {_show(value)}")
        a = np.array([_scalar(v, where, minimum=0.0, strict=positive, inf=inf) for v in items])
        out = np.broadcast_to(a, (n,)).copy()
        out.setflags(write=False)
        return out

    return check
