"""python-control plug-in: the spacecraft, any control law and the formation as ``NonlinearIOSystem``.

Every callback evaluates the generated per-agent functions (the same code the compiled simulator runs): the
model's, and the law's contract functions (:func:`law_controller`; :func:`fsm_controller` is the paper's law),
with the neighbour aggregation of :func:`fsmctl.model.coupling.aggregate`; so
``ct.input_output_response(fsmctl.formation(s), ...)`` and :func:`fsmctl.simulate` integrate the same model.

Signal names follow python-control conventions: ``sigma[0..2]``, ``omega[0..2]``, ``tau[0..2]`` and the law's
broadcast (``s[0..2]`` for the paper's law); in a formation the agents are ``sc1, sc2, ...`` (plants),
``ctrl1, ...`` (controllers) and ``reference``.

Parameters and ownership
------------------------
:func:`control.interconnect` merges the ``params`` dicts of all subsystems into one namespace and hands that
merged dict back to every subsystem, so two subsystems with a common key would silently fly with one value.
Every system made here is a :class:`ParameterizedSystem`: its parameters live under keys prefixed with the
system's name (``"sc1_J"``, ``"ctrl1_J0"``, ...), together with an owner tag (``"sc1_owner"``) that is unique
to the instance.  A system that is handed another instance's tag (two systems made with one ``name`` in one
interconnection) raises :class:`fsmctl.errors.InputError` on its first evaluation instead of using foreign
values; ``sys.copy()`` (also used by :func:`control.interconnect` for a system listed twice) gives the copy its
new name's keys and its own tag; without a ``name`` a factory uses python-control's unique ``sys[<id>]``.
Parameter values passed explicitly (``params=`` of :func:`control.input_output_response`, ``dynamics``,
``output`` or ``interconnect``) are used as given, after the same validation as the factory arguments; a key
addresses every system whose parameters carry that prefix (an explicit ``interconnect(..., params={"x_J": J})``
sets ``J`` of every system made with ``name="x"``: python-control then does not merge the subsystems' params).

Parameters also go by their local names, as in python-control's own examples: ``params={"J": J}`` given to a
spacecraft (``dynamics``, ``output``, :func:`control.input_output_response`, :func:`control.linearize`, or its
factory) sets its ``J``, and :attr:`ParameterizedSystem.local_params` reads and sets them by local name.  In an
interconnection a local name is the parameter of the one fsmctl system that has it; when several have it (``J`` of
``sc1..scn``) it is an error naming their keys, never a silent pick (a formation's bare law names, ``c1``, are the
exception :class:`FormationSystem` documents).  Passing another system's ``params`` dict on (``sys_b.dynamics(...,
params=sys_a.params)``) is an error that says so, distinct from two systems of one name in one interconnection.

Pickling
--------
Every system made here can be pickled (:mod:`pickle`, :mod:`multiprocessing`, Dask): a system records the
factory call that made it, the unpickled system is rebuilt by that call and gets back its name, signal names,
current parameter values and owner tag, so an unpickled :func:`formation` (or another interconnection holding
fsmctl systems, pickled by cloudpickle) stays consistent and evaluates bit for bit like the original.  An
unpickled system is the same system (same tag): for an independent twin in one process use ``sys.copy(name)``.

Attitude states
---------------
A continuous-time system cannot jump its state, so MRPs cannot be shadow-switched inside
:func:`control.input_output_response`, and unswitched MRPs diverge at a 360 deg rotation.  The plant and the
reference therefore integrate Euler parameters (unit quaternions, scalar first, ``q = (cos(phi/2),
e sin(phi/2))`` of the principal rotation ``(e, phi)`` from the inertial frame N to the body frame B), which are
valid at every attitude, and output the MRPs of the shadow set, ``|sigma| <= 1`` (Schaub & Junkins, Analytical
Mechanics of Space Systems, Sec. 3.5-3.7).  The kinematics carry a normalisation-drift control term
``k (1 - q.q) q``; it changes only ``|q|`` (``q`` and ``c q`` are the same attitude, and every output is formed
from ``q / |q|``), so it keeps ``|q| -> 1`` without touching the attitude.  The controller forms its error in the
shadow set, exactly like the compiled simulator, whose MRPs are shadow-switched.
"""

from __future__ import annotations

import copy
import difflib
import math
import uuid
import warnings
from collections.abc import Callable, Mapping, MutableMapping, Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import control as ct
import numpy as np

from fsmctl.errors import InputError
from fsmctl.model.coupling import aggregate
from fsmctl.model.laws import (
    LawCode,
    LawError,
    LawParameterInfo,
    initial_law_states,
    resolve_law,
)
from fsmctl.model.scenario import ControllerSettings, Scenario, ScenarioError, Sinusoid, check_inertia
from fsmctl.model.topology import Schedule, Topology, schedule_weight
from fsmctl.plugin.jacobians import (
    Derivatives,
    Kink,
    NonDifferentiableError,
    _Generated,
    symbolic_graph,
)

__all__ = [
    "Neighbour",
    "ParameterizedSystem",
    "spacecraft",
    "reference_generator",
    "fsm_controller",
    "law_controller",
    "law_parameter_values",
    "initial_state",
    "mrp_state",
    "quaternion_from_mrp",
    "mrp_from_quaternion",
    "DEFAULT_NORMALIZATION_GAIN",
    "InvalidStateError",
    "ParameterKeyError",
]

DEFAULT_NORMALIZATION_GAIN = 1.0
"""Gain ``k`` (1/s) of the quaternion normalisation-drift control ``k (1 - q.q) q``."""


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


# ----------------------------------------------------------------------------- attitude kinematics
# Euler parameters q = (q0, q1, q2, q3), scalar first, of the rotation N -> B; sigma = (q1, q2, q3) / (1 + q0).
from fsmctl.model.attitude import (  # noqa: E402  (the conversions live in the model layer)
    mrp_from_quaternion,
    mrp_of_quaternion_expression,
    quaternion_from_mrp,
    quaternion_rate_expression,
)

# ----------------------------------------------------------------------------- CasADi calls


class _FlatCall:
    """Evaluate a CasADi function through one flat input and one flat output buffer.

    Calling a :class:`casadi.Function` with NumPy arguments converts every
    argument to a ``DM`` (about 20 us each); a solver calls the right-hand side
    tens of thousands of times.  This wrapper builds, once, a function of a
    single stacked input vector (each argument flattened column-major) returning
    the stacked selected outputs, and evaluates it through a
    :meth:`casadi.Function.buffer` on preallocated NumPy arrays (about 2 us).
    The result is the same generated code; only the calling convention differs.
    Not thread-safe (one buffer per instance), like python-control's callbacks.
    """

    def __init__(self, build: Callable[..., Sequence], shapes: Sequence[tuple[int, int]], name: str):
        self._build, self._shapes, self._name = build, list(shapes), name
        self._sizes = [r * c for r, c in shapes]
        self._fn = self._graph()
        self._offsets = np.cumsum([0, *self._sizes])
        self._in = np.zeros(int(self._offsets[-1]))
        self._out = np.zeros(self._fn.nnz_out(0))
        self._buffer, self._eval = self._fn.buffer()
        self._buffer.set_arg(0, memoryview(self._in))
        self._buffer.set_res(0, memoryview(self._out))
        self._derivatives: dict[tuple[int, ...], Derivatives] = {}  # built at the first jacobian()

    def _graph(self) -> ca.Function:
        z = ca.MX.sym("z", sum(self._sizes))
        args, offset = [], 0
        for (r, c), size in zip(self._shapes, self._sizes, strict=True):
            args.append(ca.reshape(z[offset : offset + size], r, c))
            offset += size
        out = ca.vertcat(*[ca.vec(o) for o in self._build(*args)])
        return ca.Function(self._name, [z], [out])

    def _stack(self, values) -> np.ndarray:
        o = self._offsets
        for k, v in enumerate(values):
            # column-major flattening (CasADi's layout); inertias are symmetric anyway
            self._in[o[k] : o[k + 1]] = np.ravel(v, order="F")
        return self._in

    def __call__(self, *values) -> np.ndarray:
        self._stack(values)
        self._eval()
        return self._out.copy()

    def jacobian(self, *values, wrt: Sequence[int], labels: Sequence[Sequence[str]]) -> list[np.ndarray]:
        """The exact Jacobian blocks of the outputs with respect to the arguments ``wrt`` (vectors) at ``values``.

        The graph is rebuilt once (per ``wrt``) on the ``SX`` graphs of the generated functions and differentiated
        by CasADi; ``labels`` name each ``wrt`` argument's entries for messages.  Raises
        :class:`fsmctl.plugin.jacobians.Kink` where the graph is not differentiable.
        """
        key = tuple(wrt)
        if key not in self._derivatives:
            entries = np.concatenate([np.arange(self._offsets[k], self._offsets[k + 1]) for k in key] or [[]])
            names = [name for k, group in zip(key, labels, strict=True) for name in group]
            if len(names) != entries.size:
                names = [f"argument {k}[{j}]" for k in key for j in range(self._sizes[k])]
            fn = symbolic_graph(self._graph)
            self._derivatives[key] = Derivatives(fn.expand(), entries.astype(int), names)
        jac = self._derivatives[key](self._stack(values).copy())
        return np.split(jac, np.cumsum([self._sizes[k] for k in key])[:-1], axis=1)


def _scalar_schedule(schedule: Schedule, phase: float) -> Callable[[float], float]:
    """``t -> k^j_ij(t) = schedule(t + phase)`` for a scalar ``t``, without NumPy overhead.

    The rule of :func:`fsmctl.model.topology.schedule_weight` (the compiled driver's ``link_weight``).
    """
    breakpoints = list(schedule.breakpoints)
    values = list(schedule.values)
    period = schedule.period

    if len(set(values)) == 1:
        constant = float(values[0])
        return lambda t: constant

    return lambda t: schedule_weight(breakpoints, values, period, t + phase)


# ----------------------------------------------------------------------------- parameter ownership


@dataclass(frozen=True)
class _Owner:
    """The tag under ``f"{prefix}_owner"``: which instance the ``f"{prefix}_..."`` parameters belong to."""

    kind: str
    prefix: str
    serial: str

    def __repr__(self) -> str:
        return f"<fsmctl {self.kind} {self.prefix!r} #{self.serial[:8]}>"


class InvalidStateError(InputError):
    """A state python-control handed an fsmctl system is not a state of it: a quaternion ``q`` of (near-)zero norm.

    ``x = 0``, python-control's default ``X0`` (and the start of :func:`control.find_operating_point`), holds
    ``q = 0``, which is no rotation.  A one-line :class:`fsmctl.errors.InputError` (a :class:`ValueError`).

    Examples
    --------
    >>> import numpy as np, fsmctl
    >>> from fsmctl.plugin.iosys import InvalidStateError
    >>> sc = fsmctl.spacecraft(np.eye(3), name="sc")
    >>> try:
    ...     sc.output(0.0, np.zeros(7), np.zeros(3))
    ... except InvalidStateError as exc:
    ...     print(str(exc)[:60])
    spacecraft 'sc': the attitude quaternion q = [0, 0, 0, 0] is
    """


class ParameterKeyError(InputError):
    """A ``params`` key no part of an fsmctl system uses (a typo would otherwise run with the defaults).

    Raised by ``params=`` of :func:`control.input_output_response`, :meth:`~control.NonlinearIOSystem.dynamics`,
    :meth:`~control.NonlinearIOSystem.output`, ... of an fsmctl system, and by adding a key to its ``params``.

    Examples
    --------
    >>> import numpy as np, fsmctl
    >>> from fsmctl.plugin.iosys import ParameterKeyError
    >>> sc = fsmctl.spacecraft(np.eye(3), name="sc")
    >>> try:
    ...     sc.dynamics(0.0, [1, 0, 0, 0, 0, 0, 0], np.zeros(3), params={"j": np.eye(3)})
    ... except ParameterKeyError as exc:
    ...     print(exc)
    spacecraft 'sc': unknown parameter 'j' (known: J, sc_J, disturbance, sc_disturbance)
    """


_MIN_QUATERNION_NORM2 = 1e-12
"""``|q|^2`` below which a state's quaternion is refused (``|q| < 1e-6``; a flown state keeps ``|q|`` near 1)."""

_STATE_HINTS = {
    "spacecraft": "np.concatenate([quaternion_from_mrp(sigma0), omega0])",
    "reference_generator": "quaternion_from_mrp(sigma_d0)",
    "reaction_wheel_spacecraft": "reaction_wheel_state(plant, sigma0, omega0)",
}


def _invalid_quaternion(where: str, kind: str, q: Any) -> InvalidStateError:
    shown = ", ".join(f"{float(v):.3g}" for v in q)
    return InvalidStateError(
        f"{where}: the attitude quaternion q = [{shown}] is not a rotation (|q| < 1e-6; x = 0 is python-control's "
        f"default X0): start from fsmctl.initial_state(scenario) for a formation, {_STATE_HINTS[kind]} for this "
        "system (fsmctl.plugin.iosys / hardware; the identity attitude is q = [1, 0, 0, 0])"
    )


def _unknown_keys(params: Mapping[str, Any], known: Any, where: str) -> None:
    """Raise :class:`ParameterKeyError` for the first key of ``params`` not in ``known`` (closest known first)."""
    for key in params:
        if key not in known:
            listed = [k for k in known if not (isinstance(k, str) and k.endswith("_owner"))]
            text = str(key).lower()

            def score(
                k: Any, text: str = text
            ) -> float:  # the full key or its local part after the system prefix ("ctrl1_c1")
                k = str(k).lower()
                return max(difflib.SequenceMatcher(None, text, part).ratio() for part in (k, k.split("_", 1)[-1]))

            order = sorted(listed, key=lambda k: -score(k))  # stable: ties keep the system's order
            raise ParameterKeyError(
                f"{where}: unknown parameter {key!r} (known: {', '.join(map(str, order)) or 'none'})"
            )


class _KnownKeys:
    """The keys of ``params`` followed by extra accepted keys (a formation's bare law names), in that order."""

    def __init__(self, params: Mapping[str, Any], extra: Sequence[str]):
        self._keys = dict.fromkeys([*extra, *params])

    def __contains__(self, key: Any) -> bool:
        return key in self._keys

    def __iter__(self):
        return iter(self._keys)


class _Merged(dict):
    """A copy of an fsmctl system's ``params`` (:meth:`_Params.copy`).

    python-control's :class:`~control.InterconnectedSystem` hands each subsystem ``sys.params.copy()`` updated with
    the interconnection's params: a ``_Merged`` dict is such a merged namespace, any other dict was given to the
    system itself (``params=`` of ``dynamics``, ``input_output_response``, ...).
    """


class _Params(dict):
    """The ``params`` of an fsmctl system: the value of a key can be replaced, a new key is refused
    (:class:`ParameterKeyError`), since no part of the system would read it."""

    def __init__(self, values: Mapping[str, Any], where: str, extra: tuple[str, ...] = ()):
        super().__init__(values)
        self._where = where
        self._extra = extra  # keys that are taken by params= but are not stored (a formation's bare law names)

    def __reduce__(self):
        return (type(self), (dict(self), self._where, self._extra))

    def copy(self) -> _Merged:
        return _Merged(self)

    def _check(self, keys: Any) -> None:
        for key in keys:
            if key not in self:
                hint = (
                    f"; {key!r} is taken by params= (input_output_response, dynamics, ...), not stored"
                    if key in self._extra
                    else ""
                )
                try:
                    _unknown_keys({key: None}, self, f"{self._where}: params")
                except ParameterKeyError as exc:
                    raise ParameterKeyError(f"{exc}{hint}") from None

    def __setitem__(self, key, value):
        self._check((key,))
        super().__setitem__(key, value)

    def update(self, *args, **kwargs):
        other = dict(*args, **kwargs)
        self._check(other)
        super().update(other)

    def setdefault(self, key, default=None):
        self._check((key,))
        return super().setdefault(key, default)

    def __ior__(self, other):
        self.update(other)
        return self


def _owners_of(params: Mapping[str, Any], local: str) -> list[str]:
    """The keys ``f"{prefix}_{local}"`` of every fsmctl system whose owner tag is in ``params`` and that has ``local``.

    Every fsmctl system's parameters carry its owner tag, so the tags in a (merged) params dict list the fsmctl
    systems present; the order is the dict's.
    """
    keys = []
    for value in params.values():
        if isinstance(value, _Owner):
            key = f"{value.prefix}_{local}"
            if key in params and key not in keys:
                keys.append(key)
    return keys


def _ambiguous(where: str, local: str, keys: Sequence[str]) -> InputError:
    return InputError(
        f"{where}: parameter {local!r} given by its local name, which several fsmctl systems here have "
        f"({', '.join(keys)}); give the key of the one you mean (a system of your own that stores a parameter "
        f"{local!r} makes it ambiguous too: rename it)"
    )


def _foreign_params(where: str, owner: _Owner, what: str) -> InputError:
    return InputError(
        f"{where}: params= holds the parameters of another system ({owner!r}), such as another system's "
        f"sys.params passed on; pass only the values to change, {what}"
    )


def _rebuild(factory: Callable[..., Any], arguments: Mapping[str, Any]) -> Any:
    """Unpickling: the system the factory makes from the recorded arguments (its state is restored afterwards)."""
    return factory(**arguments)


_REBUILT_STATE = ("name", "input_index", "output_index", "state_index", "dt", "params")
"""What a pickle of a :class:`_Rebuilt` carries besides its factory call (the rest is rebuilt: a sensor's noise is
drawn again, identically, from its seed)."""


class _Rebuilt(ct.NonlinearIOSystem):
    """A python-control ``nlsys`` made by an fsmctl function (a sensor, a link, a sampled system: callbacks that are
    closures), pickled as the call that made it, so that multiprocessing and Dask can ship it; copies stay copies."""

    _factory: tuple

    def __reduce__(self):
        return (_rebuild, self._factory, {k: self.__dict__[k] for k in _REBUILT_STATE if k in self.__dict__})

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)

    def __copy__(self) -> _Rebuilt:
        new = type(self).__new__(type(self))
        new.__dict__.update(self.__dict__)
        return new

    def __deepcopy__(self, memo: dict) -> _Rebuilt:
        new = type(self).__new__(type(self))
        memo[id(self)] = new
        for key, value in self.__dict__.items():
            new.__dict__[key] = copy.deepcopy(value, memo)
        return new


def _rebuilt(system: ct.NonlinearIOSystem, call: tuple) -> _Rebuilt:
    """``system`` (made by the factory call ``call``) as a :class:`_Rebuilt`, which pickles."""
    system.__class__ = _Rebuilt
    system._factory = call
    return system


def _factory_call(factory: Callable[..., Any], arguments: Mapping[str, Any]) -> tuple[Callable[..., Any], dict]:
    """The call that rebuilds a system: the public factory and its arguments (a law as its folder, which
    :func:`fsmctl.model.laws.resolve_law` reads again)."""
    return factory, {k: (str(v.folder) if isinstance(v, LawCode) else v) for k, v in arguments.items()}


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


def _finish(system: ParameterizedSystem, call: tuple, params: Any, dt: Any) -> ParameterizedSystem:
    """A factory's last step: the timebase, the initial parameter values (``params=``) and the recorded call."""
    system.dt = _timebase(dt, system._model_update is None, system._where)
    if params is not None:
        if not isinstance(params, Mapping):
            raise ScenarioError(
                f"{system._where}: params: expected a mapping of parameter names to values, got {_show(params)}"
            )
        for key, value in system._explicit(params).items():
            if key != system._owner_key:
                system.local_params[key[len(system._prefix) + 1 :]] = value
    system._factory = call
    return system


class _LocalParams(MutableMapping):
    """The live view ``sys.local_params`` of a :class:`ParameterizedSystem`'s parameters by local name."""

    def __init__(self, system: ParameterizedSystem):
        self._system = system

    def __getitem__(self, local: str) -> Any:
        keys = self._system._keys
        if local not in keys:
            raise KeyError(local)
        return self._system.params[keys[local]]

    def __setitem__(self, local: str, value: Any) -> None:
        system = self._system
        if local not in system._keys:
            _unknown_keys({local: None}, system._locals, f"{system._where}: local_params")
        key = system._keys[local]
        checked = system._validators[local](value, f"{system._where}: parameter {local!r}")
        if isinstance(checked, np.ndarray) and not isinstance(value, str) and np.shape(value) == checked.shape:
            value = checked  # the read-only checked copy of an array, as the factories store them
        elif isinstance(value, str):
            value = value.lower()  # an option's name, as law_controller stores it
        system.params[key] = value

    def __delitem__(self, local: str) -> None:
        raise TypeError(f"{self._system._where}: a parameter cannot be deleted (assign a new value)")

    def __iter__(self):
        return iter(self._system._keys)

    def __len__(self) -> int:
        return len(self._system._keys)

    def __repr__(self) -> str:
        return repr(dict(self))


_PICKLED = (
    "name",
    "params",
    "_prefix",
    "_keys",
    "_owner_key",
    "_owner",
    "input_index",
    "output_index",
    "state_index",
    "dt",
)
"""What a pickle of a :class:`ParameterizedSystem` carries besides its factory call (the rest is rebuilt)."""


_Model = Callable[[float, np.ndarray, np.ndarray, Mapping[str, Any]], np.ndarray]


class ParameterizedSystem(ct.NonlinearIOSystem):
    """A :class:`control.NonlinearIOSystem` whose parameters are owned by the instance (what the factories return).

    The model callbacks see parameters by their local names (``"J"``, ``"disturbance"``, ...); in ``params``
    they are stored under ``f"{prefix}_{local}"`` plus the owner tag ``f"{prefix}_owner"``, where ``prefix``
    is the system's name when it was made or copied (:meth:`param_key` gives the key).  On every evaluation the
    system reads its keys from the params python-control hands it (its own ``params``, updated by an
    interconnection's merged ``params`` and by any ``params=`` passed explicitly), so explicit values win;
    each value is validated once per object (again when a writeable array's contents change).

    Parameters
    ----------
    kind : str
        The factory's name, for messages (``"spacecraft"``, ...).
    update : callable or None
        ``update(t, x, u, p)``: the state derivative, with ``p`` the validated parameters by local name; ``None``
        for a static system.
    output : callable
        ``output(t, x, u, p)``: the outputs.
    values : mapping of str to object
        The parameters' initial values by local name (already validated).
    validators : mapping of str to callable
        ``validator(value, where) -> checked value`` per local name, applied to values given at evaluation time.
    name : str, optional
        System name, and the prefix of the parameter keys; default python-control's unique ``sys[<id>]``.
    attitude : bool, optional
        Whether the state starts with an attitude quaternion ``q``: a state whose ``q`` has (near-)zero norm, such
        as python-control's default ``X0 = 0``, is then refused with :class:`InvalidStateError`.
    jacobian : callable, optional
        ``jacobian(t, x, u, p) -> (A, B, C, D)``: the exact Jacobians of ``update`` and ``output`` (what
        :meth:`linearize` returns); without it, :meth:`linearize` takes python-control's finite differences.
    **kwargs
        Passed to :class:`control.NonlinearIOSystem` (``inputs``, ``outputs``, ``states``, ...).

    Raises
    ------
    fsmctl.errors.InputError
        On evaluation, when the owner tag in the params is another instance's: two systems made with one name
        were merged into one parameter namespace (give each a unique ``name``), or the params of another
        system were passed explicitly (pass only the values to change); a local name that several fsmctl
        systems of an interconnection have.
    fsmctl.model.scenario.ScenarioError
        On evaluation, when a parameter value is invalid (for example a non-finite inertia).

    Notes
    -----
    ``sys.copy(name)`` (python-control's duplication, also used by :func:`control.interconnect` for a system
    listed twice) re-keys the copy to its new name with a new owner tag, carrying the current values.
    ``copy.deepcopy(sys)`` and ``copy.copy(sys)`` give a twin with the same name and keys but its own tag, so
    twin and original in one interconnection raise; a deep copy of a container (an interconnection) keeps the
    tags, so the copied container stays consistent.  A pickle records the factory call: unpickling rebuilds the
    system by it and restores its name, signal names, parameter values and tag (see the module docstring).

    Examples
    --------
    >>> import numpy as np
    >>> import fsmctl
    >>> a = fsmctl.spacecraft(np.diag([100.0, 150.0, 200.0]), name="a")
    >>> b = a.copy("b")
    >>> b.param_key("J")
    'b_J'
    >>> b.params["b_J"] = np.diag([10.0, 15.0, 20.0])  # b only; a keeps its inertia
    >>> sorted(a.params)
    ['a_J', 'a_disturbance', 'a_owner']
    """

    def __init__(
        self,
        kind: str,
        update: _Model | None,
        output: _Model,
        values: Mapping[str, Any],
        validators: Mapping[str, Callable[[Any, str], Any]],
        *,
        name: str | None = None,
        attitude: bool = False,
        jacobian: Callable[..., tuple[np.ndarray, ...]] | None = None,
        **kwargs,
    ):
        self._kind = kind
        self._model_update = update
        self._model_output = output
        self._model_jacobian = jacobian
        self._validators = dict(validators)
        self._attitude = attitude
        super().__init__(self._updfcn if update is not None else None, self._outfcn, name=name, **kwargs)
        self._locals = tuple(values)
        self.params = {}
        self._bind(self.name, dict(values))

    # -- keys

    def param_key(self, local: str) -> str:
        """The ``params`` key of the parameter ``local`` (``"J"`` -> ``"sc1_J"``).

        Parameters
        ----------
        local : str
            The parameter's local name (``"J"``, ``"J0"``, ``"c1"``, ...).

        Returns
        -------
        str
            ``f"{prefix}_{local}"``, the prefix being the system's name when it was made or copied.

        Raises
        ------
        KeyError
            The system has no parameter ``local``.

        Examples
        --------
        >>> import fsmctl, numpy as np
        >>> fsmctl.spacecraft(np.eye(3), name="sc1").param_key("J")
        'sc1_J'
        """
        if local not in self._keys:
            raise KeyError(f"{self._where}: no parameter {local!r} (has {list(self._keys)})")
        return self._keys[local]

    @property
    def _where(self) -> str:
        return f"{self._kind} {self._prefix!r}"

    def _bind(self, prefix: str, values: dict[str, Any] | None = None) -> None:
        """Store the parameters under ``f"{prefix}_..."`` keys with a new owner tag (other keys are kept)."""
        params = dict(self.params)
        if values is None:
            values = {local: params.pop(key, None) for local, key in self._keys.items()}
            params.pop(self._owner_key, None)
        self._prefix = prefix
        self._keys = {local: f"{prefix}_{local}" for local in self._locals}
        self._owner_key = f"{prefix}_owner"
        self._owner = _Owner(self._kind, prefix, uuid.uuid4().hex)
        for local in self._locals:
            params[self._keys[local]] = values[local]
        params[self._owner_key] = self._owner
        self.params = _Params(params, self._where)
        self._current_params = self.params.copy()
        self._seen: dict[str, tuple[Any, Any]] = {}
        self._last: tuple[Any, Any] = (None, None)

    def _retag(self) -> None:
        self._owner = _Owner(self._kind, self._prefix, uuid.uuid4().hex)
        self.params[self._owner_key] = self._owner
        self._current_params = self.params.copy()
        self._last = (None, None)

    # -- copies

    def copy(self, name: str | None = None, use_prefix_suffix: bool = True) -> ParameterizedSystem:
        """A copy with a new name (python-control's rule), its parameters re-keyed to that name, its own tag.

        Parameters
        ----------
        name : str, optional
            Name of the copy; by default the name with python-control's duplicate prefix/suffix (``"a$copy"``).
        use_prefix_suffix : bool
            As in :meth:`control.InputOutputSystem.copy`.

        Examples
        --------
        >>> import fsmctl, numpy as np
        >>> sorted(fsmctl.spacecraft(np.eye(3), name="a").copy().params)
        ['a$copy_J', 'a$copy_disturbance', 'a$copy_owner']
        """
        new = super().copy(name=name, use_prefix_suffix=use_prefix_suffix)
        new._bind(new.name)
        return new

    def __deepcopy__(self, memo: dict) -> ParameterizedSystem:
        top_level = not memo  # copy.deepcopy(sys) itself, not a deep copy of a container holding sys
        new = type(self).__new__(type(self))
        memo[id(self)] = new
        for key, value in self.__dict__.items():
            new.__dict__[key] = copy.deepcopy(value, memo)
        for key in (*self._keys.values(), self._owner_key):
            # NumPy's deep copy of a read-only array is writeable: keep checked values read-only
            old, value = self.params.get(key), new.params.get(key)
            if isinstance(old, np.ndarray) and not old.flags.writeable and isinstance(value, np.ndarray):
                value.setflags(write=False)
        new._last = (None, None)
        if top_level:
            new._retag()
        return new

    def __copy__(self) -> ParameterizedSystem:
        # a shallow copy would share the params dict with the original: copy everything, as a top-level deep copy
        return self.__deepcopy__({})

    # -- evaluation

    def _resolve(self, params: Mapping[str, Any]) -> dict[str, Any]:
        # python-control hands every call of one simulation the same dict (a new one per _update_params)
        if params is self._last[0]:
            return self._last[1]
        owner = params.get(self._owner_key)
        if owner is not self._owner and owner != self._owner:
            if owner is None:
                raise InputError(
                    f"{self._where}: params lack {self._owner_key!r} (the tag of which system the "
                    f"'{self._prefix}_*' parameters belong to); was sys.params replaced?"
                )
            raise InputError(
                f"{self._where}: the '{self._prefix}_*' parameters of this interconnection belong to another system "
                f"({owner!r}): two systems made with name={self._prefix!r} are in one interconnection, which merges "
                "their params into one namespace; give each fsmctl system a unique name (sys.copy(name) renames and "
                "re-keys; if another system's params were passed to the interconnection, pass only the values to change)"
            )
        out = {}
        for local, key in self._keys.items():
            if key not in params:
                raise InputError(f"{self._where}: parameter {key!r} is missing from params")
            value = params[key]
            seen = self._seen.get(local)
            if seen is not None and seen[0] is value and _unchanged(value, seen[1]):
                out[local] = seen[1]
                continue
            checked = self._validators[local](value, f"{self._where}: parameter {key!r}")
            self._seen[local] = (value, checked)
            out[local] = checked
        self._last = (params, out)
        return out

    def _update_params(self, params):
        # python-control calls this with the params given to this system (dynamics, output,
        # input_output_response, ...), or, from an interconnection, with the merged params (a copy of this
        # system's params, _Merged, updated with every other subsystem's keys): only the former are checked for
        # unknown keys and foreign tags; local names are taken in both
        if params:
            params = self._merged(params) if isinstance(params, _Merged) else self._explicit(params)
        super()._update_params(params)

    def _explicit(self, params: Mapping[str, Any]) -> dict[str, Any]:
        """Params given to this system itself: local names as keys, checked for foreign tags and unknown keys."""
        for value in params.values():
            if isinstance(value, _Owner) and value != self._owner:
                raise _foreign_params(
                    self._where, value, f"by local name ({', '.join(self._keys)}) or by this system's keys"
                )
        out = {}
        for key, value in params.items():
            if key in self._keys:
                full = self._keys[key]
                if full in params:
                    raise InputError(f"{self._where}: parameter {key!r} given twice, as {key!r} and {full!r}")
                out[full] = value
            else:
                out[key] = value
        _unknown_keys(out, _KnownKeys(self.params, self._locals), self._where)
        return out

    def _merged(self, params: _Merged) -> _Merged:
        """A merged namespace: a local name of this system (``"J"``) is this system's value when no other fsmctl
        system here has that parameter, an error naming the candidates otherwise."""
        present = [local for local in self._locals if local in params]
        if not present:
            return params
        out = _Merged(params)
        for local in present:
            keys = _owners_of(params, local)
            if len(keys) > 1:
                raise _ambiguous(self._where, local, keys)
            out[self._keys[local]] = params[local]
        return out

    # -- local names, pickling

    @property
    def local_params(self) -> MutableMapping[str, Any]:
        """The system's parameters by local name (``"J"``), a live view of ``params`` (``"sc1_J"``).

        Reading gives the stored value; assigning validates the value like the factory's argument and stores it
        under the system's key (a new name raises :class:`ParameterKeyError`).  The same local names are taken
        by ``params=`` of :func:`control.input_output_response`, ``dynamics``, ``output``, ``linearize``, ... of
        this system, and of an interconnection in which no other fsmctl system has that parameter.

        Examples
        --------
        >>> import numpy as np, fsmctl
        >>> sc = fsmctl.spacecraft(np.eye(3))
        >>> list(sc.local_params)
        ['J', 'disturbance']
        >>> sc.local_params["J"] = np.diag([1.0, 2.0, 3.0])
        >>> sc.params[sc.param_key("J")].diagonal().tolist()
        [1.0, 2.0, 3.0]
        """
        return _LocalParams(self)

    def __reduce__(self):
        call = getattr(self, "_factory", None)
        if call is None:
            raise TypeError(f"{self._where}: cannot be pickled: not made by an fsmctl factory")
        return (_rebuild, call, {key: self.__dict__[key] for key in _PICKLED if key in self.__dict__})

    def __setstate__(self, state: dict[str, Any]) -> None:
        # the factory rebuilt the model; restore its identity (name, keys, owner tag: an unpickled interconnection
        # holding it stays consistent), its current values and its signal names
        self.__dict__.update(state)
        for key in self._keys.values():
            value = self.params.get(key)
            if isinstance(value, np.ndarray):
                value.setflags(write=False)  # stored values are checked, read-only (NumPy unpickles them writeable)
        self._current_params = self.params.copy()
        self._seen = {}
        self._last = (None, None)

    def _updfcn(self, t, x, u, params):
        if self._attitude and x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3] < _MIN_QUATERNION_NORM2:
            raise _invalid_quaternion(self._where, self._kind, x[:4])
        return self._model_update(t, x, u, self._resolve(params))

    def _outfcn(self, t, x, u, params):
        if self._attitude and x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3] < _MIN_QUATERNION_NORM2:
            raise _invalid_quaternion(self._where, self._kind, x[:4])
        return self._model_output(t, x, u, self._resolve(params))

    # -- linearization

    def _jacobians(self, t: float, x: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, ...]:
        """``(A, B, C, D)`` at ``(t, x, u)`` with the current parameters (exact; see :meth:`linearize`)."""
        x = np.asarray(x, dtype=float).reshape(-1)
        u = np.asarray(u, dtype=float).reshape(-1)
        if self._attitude and float(x[:4] @ x[:4]) < _MIN_QUATERNION_NORM2:
            raise _invalid_quaternion(self._where, self._kind, x[:4])
        try:
            A, B, C, D = self._model_jacobian(float(t), x, u, self._resolve(self._current_params))
        except Kink as exc:
            raise NonDifferentiableError(
                f"{self._where}: not differentiable at the operating point: {exc}; {self._kink_hint}"
            ) from None
        shapes = ((self.nstates, self.nstates), (self.nstates, self.ninputs))
        shapes += ((self.noutputs, self.nstates), (self.noutputs, self.ninputs))
        return tuple(np.asarray(m, dtype=float).reshape(s) for m, s in zip((A, B, C, D), shapes, strict=True))

    _kink_hint = "linearize at another operating point"

    def linearize(self, x0, u0=None, t=0, params=None, eps=1e-6, copy_names=False, **kwargs):
        """The exact linearization at an operating point, as python-control's :func:`control.linearize` returns it.

        The Jacobians are CasADi's automatic derivatives of the generated functions the callbacks evaluate
        (:mod:`fsmctl.plugin.jacobians`), not finite differences.

        Parameters
        ----------
        x0 : array_like or control.OperatingPoint
            The state (or an operating point with its input).
        u0 : array_like, optional
            The input; 0 by default.
        t : float
            The time (the disturbance, the reference and the neighbours' weights depend on it).
        params : dict, optional
            Parameter values for this call, as for :meth:`dynamics` (unknown keys raise
            :class:`ParameterKeyError`).
        eps : float
            Not used (python-control's finite-difference step; kept for its signature).
        copy_names : bool
            As python-control: copy the signal names, name the system ``<name>$linearized``.
        **kwargs
            ``name``, ``inputs``, ``outputs``, ``states`` of the returned system.

        Returns
        -------
        control.StateSpace
            ``A = df/dx``, ``B = df/du``, ``C = dh/dx``, ``D = dh/du`` at the point.

        Raises
        ------
        NonDifferentiableError
            The system is not differentiable there (a switch of its graph at the point, see
            :mod:`fsmctl.plugin.jacobians`).
        InvalidStateError
            The state's quaternion has (near-)zero norm.

        Examples
        --------
        >>> import numpy as np, fsmctl
        >>> sc = fsmctl.spacecraft(np.diag([100.0, 150.0, 200.0]), name="sc")
        >>> lin = sc.linearize([1, 0, 0, 0, 0, 0, 0], [0, 0, 0])
        >>> lin.B[4:, :].diagonal().tolist()  # J^-1
        [0.01, 0.006666666666666667, 0.005]
        """
        if isinstance(x0, ct.OperatingPoint):
            u0 = x0.inputs if u0 is None else u0
            x0 = x0.states
        elif u0 is None:
            u0 = 0
        if self._model_jacobian is None:
            return super().linearize(x0, u0, t=t, params=params, eps=eps, copy_names=copy_names, **kwargs)
        x0 = _operating_vector(x0, "x0", self.nstates)
        u0 = _operating_vector(u0, "u0", self.ninputs)
        self._update_params(params)
        return _state_space(self, *self._jacobians(t, x0, u0), copy_names=copy_names, **kwargs)


def _operating_vector(arg: Any, name: str, size: int) -> np.ndarray:
    """An operating point's ``x0`` or ``u0`` as python-control's ``linearize`` reads it: a flat vector of ``size``.

    Nested lists and arrays are flattened, a scalar (or None) fills the vector, a shorter vector is padded with
    zeros (with python-control's ``UserWarning`` when its last value is not 0); any other length raises
    python-control's ``ValueError``.
    """
    if arg is None:
        return np.zeros(size)
    if isinstance(arg, (tuple, list)):
        val = np.array([x for v in arg for x in np.array(v).reshape(-1).tolist()])
    elif np.isscalar(arg):
        val = np.ones((size,)) * arg
    else:
        val = np.asarray(arg).reshape(-1)
    if val.size < size:
        if val.size and val[-1] != 0:
            warnings.warn(f"{name} too short; padding with zeros", UserWarning, stacklevel=3)
        val = np.hstack([val, np.zeros(size - val.size)])
    if val.size != size:
        raise ValueError(
            f"inconsistent information to determine size of {name}; expected {size} values, received {val.size}"
        )
    return val


def _state_space(sys: ct.InputOutputSystem, A, B, C, D, *, copy_names: bool = False, **kwargs) -> ct.StateSpace:
    """The :class:`control.StateSpace` python-control's ``linearize`` returns, with these matrices."""
    lin = ct.StateSpace(A, B, C, D, sys.dt, remove_useless_states=False)
    if copy_names:
        lin._copy_names(sys, prefix_suffix_name="linearized")
    return ct.StateSpace(lin, **kwargs)


def _unchanged(value: Any, checked: Any) -> bool:
    """Whether a value seen before still holds what was validated (immutable, ours, or equal contents)."""
    if value is checked or isinstance(value, (float, int, str)):
        return True
    if isinstance(value, np.ndarray):
        return value.shape == np.shape(checked) and bool(np.array_equal(value, checked))
    return False  # lists and other containers may have been modified in place: validate again


# ----------------------------------------------------------------------------- factories


def spacecraft(
    J,
    *,
    disturbance: Sinusoid | None = None,
    normalization_gain: float = DEFAULT_NORMALIZATION_GAIN,
    name: str | None = None,
    inputs: Any = None,
    outputs: Any = None,
    states: Any = None,
    params: Mapping[str, Any] | None = None,
    dt: Any = 0,
) -> ParameterizedSystem:
    """A rigid spacecraft (Liang et al. 2012, eqs 3-4) as a python-control system, valid at every attitude.

    ``J omega_dot = -omega x J omega + tau + d(t)`` (the generated ``plant_rhs``), attitude integrated as Euler
    parameters ``q`` (``q_dot = 1/2 B(q) omega + k (1 - q.q) q``), output as shadow-set MRPs.

    Parameters
    ----------
    J : array_like, shape (3, 3)
        True inertia (kg m^2): finite, symmetric positive definite.
    disturbance : Sinusoid, optional
        Disturbance torque ``d(t)`` added to the input (N m); none by default (stored as zero amplitudes).
    normalization_gain : float
        ``k`` >= 0 (1/s) of the normalisation-drift control; it does not change the attitude.
    name : str, optional
        System name (no ``'.'``); default python-control's unique ``sys[<id>]``.

    inputs, outputs, states : int, str or list of str, optional
        New signal names (python-control's forms; their number must be the system's); default the names below.
    params : mapping, optional
        Initial parameter values, by local name (``"J"``) or key, validated like the arguments (they win).
    dt : 0 or None
        python-control's timebase: this is a continuous-time system (``None``, unspecified, is taken as 0); a
        discrete ``dt`` raises (sample the loop instead, the plug-in guide's "Sampled-data loops").

    Returns
    -------
    ParameterizedSystem
        Inputs ``tau[0..2]`` (N m); states ``q[0..3]`` (Euler parameters, scalar first, N -> B) and
        ``omega[0..2]`` (rad/s, body frame); outputs ``sigma[0..2]`` (MRP, ``|sigma| <= 1``) and ``omega[0..2]``.
        ``sigma`` switches set at 180 deg (a jump of 2): compare attitudes with :func:`fsmctl.attitude_error_angle`,
        not by differences of ``sigma``.
        Parameters ``f"{name}_J"`` (3x3), ``f"{name}_disturbance"`` (12: amplitude, frequency, phase, offset)
        and the owner tag ``f"{name}_owner"``; values passed with ``params=`` replace them for that call.

    Raises
    ------
    fsmctl.ScenarioError
        ``J`` not a finite symmetric positive-definite 3x3 matrix of numbers (bools and strings are not
        numbers), ``disturbance`` not a Sinusoid, a bad ``normalization_gain`` or ``name``.

    Notes
    -----
    Initial states take quaternions: :func:`quaternion_from_mrp` converts an MRP.  A linearization has seven
    states; the direction of ``q`` itself (its norm) is the drift control's decay ``-2 k``.

    Examples
    --------
    >>> import control as ct, numpy as np
    >>> import fsmctl
    >>> from fsmctl.plugin.iosys import quaternion_from_mrp
    >>> sc = fsmctl.spacecraft(np.diag([100.0, 150.0, 200.0]), name="sc")
    >>> sc.state_labels[:4], sc.output_labels[:3]
    (['q[0]', 'q[1]', 'q[2]', 'q[3]'], ['sigma[0]', 'sigma[1]', 'sigma[2]'])
    >>> x0 = np.concatenate([quaternion_from_mrp([0.1, 0.0, 0.0]), [0.0, 0.0, 1.0]])
    >>> r = ct.input_output_response(sc, np.linspace(0, 10, 11), 0, x0)
    >>> bool(np.linalg.norm(r.outputs[:3], axis=0).max() <= 1)
    True
    >>> float(sc.dynamics(0.0, x0, [0, 0, 1.0], params={"sc_J": np.eye(3)})[6])  # J = I: 1 rad/s^2
    1.0
    """
    call = _factory_call(spacecraft, locals())
    name = _system_name(name, "spacecraft")
    where = f"spacecraft {name!r}" if name else "spacecraft"
    J = _inertia(J, f"{where}: J")
    d = np.zeros(12) if disturbance is None else _sinusoid(disturbance, f"{where}: disturbance")
    d.setflags(write=False)
    gain = _scalar(normalization_gain, f"{where}: normalization_gain", minimum=0.0)
    plant = _Generated("plant_rhs")
    dist = _Generated("disturbance_torque")
    zero3 = ca.DM.zeros(3, 1)  # plant_rhs's sigma_dot is not used: the attitude is integrated as q
    rhs = _FlatCall(
        lambda t, x, u, J, d: [
            quaternion_rate_expression(x[:4], x[4:], gain),
            plant(zero3, x[4:], u + dist(t, d), J)[1],
        ],
        [(1, 1), (7, 1), (3, 1), (3, 3), (12, 1)],
        "spacecraft_rhs",
    )
    out = _FlatCall(lambda x: [mrp_of_quaternion_expression(x[:4]), x[4:]], [(7, 1)], "spacecraft_out")
    state_names = _signal_names(states, _labels("q", 4) + _labels("omega"), "states", where)
    input_names = _signal_names(inputs, _labels("tau"), "inputs", where)

    def jacobian(t, x, u, p):
        A, B = rhs.jacobian(t, x, u, p["J"], p["disturbance"], wrt=(1, 2), labels=(state_names, input_names))
        (C,) = out.jacobian(x, wrt=(0,), labels=(state_names,))
        return A, B, C, np.zeros((6, 3))

    # the MRP-state model (plant_rhs's own kinematics) for fsmctl.plugin.mrp_linearization
    mrp_rhs = _FlatCall(
        lambda t, sigma, omega, u, J, d: plant(sigma, omega, u + dist(t, d), J),
        [(1, 1), (3, 1), (3, 1), (3, 1), (3, 3), (12, 1)],
        "spacecraft_mrp_rhs",
    )
    mrp_states = _labels("sigma") + _labels("omega")

    def mrp_jacobian(t, x, u, p):
        d_sigma, d_omega, d_u = mrp_rhs.jacobian(
            t,
            x[:3],
            x[3:6],
            u,
            p["J"],
            p["disturbance"],
            wrt=(1, 2, 3),
            labels=(mrp_states[:3], mrp_states[3:], input_names),
        )
        return np.hstack([d_sigma, d_omega]), d_u

    system = ParameterizedSystem(
        "spacecraft",
        lambda t, x, u, p: rhs(t, x, u, p["J"], p["disturbance"]),
        lambda t, x, u, p: out(x),
        {"J": J, "disturbance": d},
        {"J": _inertia, "disturbance": _twelve},
        inputs=input_names,
        outputs=_signal_names(outputs, _labels("sigma") + _labels("omega"), "outputs", where),
        states=state_names,
        name=name,
        attitude=True,
        jacobian=jacobian,
    )
    system._mrp_model = (mrp_jacobian, mrp_states, _labels("tau"), 3)
    return _finish(system, call, params, dt)


def reference_generator(
    omega_d: Sinusoid,
    *,
    normalization_gain: float = DEFAULT_NORMALIZATION_GAIN,
    name: str | None = None,
    inputs: Any = None,
    outputs: Any = None,
    states: Any = None,
    params: Mapping[str, Any] | None = None,
    dt: Any = 0,
) -> ParameterizedSystem:
    """Reference attitude driven by a sinusoidal ``omega_d(t)`` (Sec. 4), valid at every attitude.

    Parameters
    ----------
    omega_d : Sinusoid
        Reference body rate (rad/s); ``omega_d`` and ``omega_d_dot`` come from the generated ``reference_rhs``.
    normalization_gain : float
        ``k`` >= 0 (1/s) of the normalisation-drift control, as in :func:`spacecraft`.
    name : str, optional
        System name; default python-control's unique ``sys[<id>]``.

    inputs, outputs, states : int, str or list of str, optional
        New signal names (python-control's forms; their number must be the system's); default the names below.
    params : mapping, optional
        Initial parameter values, by local name (``"omega_d"``) or key, validated like the arguments (they win).
    dt : 0 or None
        python-control's timebase: this is a continuous-time system (``None``, unspecified, is taken as 0); a
        discrete ``dt`` raises (sample the loop instead, the plug-in guide's "Sampled-data loops").

    Returns
    -------
    ParameterizedSystem
        No inputs; states ``q_d[0..3]`` (Euler parameters, scalar first); outputs ``sigma_d`` (MRP,
        ``|sigma_d| <= 1``), ``omega_d``, ``omega_d_dot`` (rad/s, rad/s^2). Parameter ``f"{name}_omega_d"`` (12).

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.plugin.iosys import quaternion_from_mrp
    >>> ref = fsmctl.reference_generator(fsmctl.Sinusoid(offset=(0.0, 0.0, 0.1)), name="reference")
    >>> ref.output(0.0, quaternion_from_mrp([0.0, 0.0, 0.5]), []).round(12).tolist()[:6]
    [0.0, 0.0, 0.5, 0.0, 0.0, 0.1]
    """
    call = _factory_call(reference_generator, locals())
    name = _system_name(name, "reference_generator")
    where = f"reference_generator {name!r}" if name else "reference_generator"
    p = _sinusoid(omega_d, f"{where}: omega_d")
    gain = _scalar(normalization_gain, f"{where}: normalization_gain", minimum=0.0)
    ref = _Generated("reference_rhs")
    rhs = _FlatCall(
        lambda t, x, p: [quaternion_rate_expression(x, ref(t, mrp_of_quaternion_expression(x), p)[1], gain)],
        [(1, 1), (4, 1), (12, 1)],
        "reference_rhs",
    )

    def output_graph(t, x, p):
        sigma = mrp_of_quaternion_expression(x)
        return [sigma, *ref(t, sigma, p)[1:]]

    out = _FlatCall(output_graph, [(1, 1), (4, 1), (12, 1)], "reference_out")
    state_names = _signal_names(states, _labels("q_d", 4), "states", where)

    def jacobian(t, x, u, prm):
        (A,) = rhs.jacobian(t, x, prm["omega_d"], wrt=(1,), labels=(state_names,))
        (C,) = out.jacobian(t, x, prm["omega_d"], wrt=(1,), labels=(state_names,))
        return A, np.zeros((4, 0)), C, np.zeros((9, 0))

    system = ParameterizedSystem(
        "reference_generator",
        lambda t, x, u, prm: rhs(t, x, prm["omega_d"]),
        lambda t, x, u, prm: out(t, x, prm["omega_d"]),
        {"omega_d": p},
        {"omega_d": _twelve},
        inputs=_signal_names(inputs, [], "inputs", where),
        outputs=_signal_names(
            outputs, _labels("sigma_d") + _labels("omega_d") + _labels("omega_d_dot"), "outputs", where
        ),
        states=state_names,
        name=name,
        attitude=True,
        jacobian=jacobian,
    )
    return _finish(system, call, params, dt)


@dataclass(frozen=True)
class Neighbour:
    """A neighbour ``j`` of agent ``i``: weights ``k^i_ij`` and ``k^j_ij(t) = k_j(t + phase)`` (eq 19).

    Parameters
    ----------
    name : str
        Suffix of the controller inputs ``<broadcast>_<name>[k]`` that carry the neighbour's broadcast ``b_j``
        (``s_<name>[0..2]`` for the paper's law, which broadcasts its sliding variable ``s``).
    k_i : float
        ``k^i_ij >= 0``, finite.
    k_j : Schedule
        ``k^j_ij`` as a schedule of time.
    phase : float
        Finite time shift of the schedule (s).

    Examples
    --------
    >>> from fsmctl.plugin.iosys import Neighbour
    >>> from fsmctl.model.topology import Schedule
    >>> Neighbour("sc2", 8.0, Schedule.constant(5.0)).k_i
    8.0
    """

    name: str
    k_i: float
    k_j: Schedule
    phase: float = 0.0

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name or "." in self.name:
            raise ScenarioError(f"Neighbour: name must be a non-empty string without '.', got {_show(self.name)}")
        where = f"Neighbour {self.name!r}"
        object.__setattr__(self, "k_i", _scalar(self.k_i, f"{where}: k_i", minimum=0.0))
        if not isinstance(self.k_j, Schedule):
            raise ScenarioError(f"{where}: k_j: expected a fsmctl.Schedule, got {type(self.k_j).__name__}")
        object.__setattr__(self, "phase", _scalar(self.phase, f"{where}: phase"))


def _neighbours(neighbours: Any, where: str) -> tuple[Neighbour, ...]:
    if isinstance(neighbours, (str, bytes)) or not isinstance(neighbours, Sequence):
        raise ScenarioError(f"{where}: neighbours: expected a sequence of Neighbour, got {_show(neighbours)}")
    nbrs = tuple(neighbours)
    for nb in nbrs:
        if not isinstance(nb, Neighbour):
            raise ScenarioError(f"{where}: neighbours: expected Neighbour, got {type(nb).__name__}")
    names = [nb.name for nb in nbrs]
    if len(set(names)) != len(names):
        raise ScenarioError(f"{where}: neighbours: names must be unique, got {names}")
    return nbrs


def _law_parameter(info: LawParameterInfo) -> Callable[[Any, str], np.ndarray]:
    """Validator of one law parameter's value (a number, ``size`` numbers, or one of its options by name)."""

    def check(value: Any, where: str) -> np.ndarray:
        if isinstance(value, np.ndarray) and value.shape == ():
            value = value[()]
        try:
            packed = np.array(info.values(value, where), dtype=float)
        except LawError as exc:
            raise ScenarioError(str(exc)) from None
        except TypeError:
            raise ScenarioError(f"{where}: expected {info.size} real number(s), got {_show(value)}") from None
        packed.setflags(write=False)
        return packed

    return check


def _parameter_value(info: LawParameterInfo, packed: Sequence[float]) -> Any:
    """The user-facing value of a packed law parameter (an option's name, a number, or a read-only array)."""
    if info.choices:
        return info.choices[int(packed[0])]
    if info.size == 1:
        return float(packed[0])
    a = np.array(packed, dtype=float)
    a.setflags(write=False)
    return a


def law_parameter_values(law: LawCode | str, packed: Sequence[float]) -> dict[str, Any]:
    """A law's packed parameter vector (a row of :func:`fsmctl.model.laws.parameter_matrix`) by parameter name.

    Parameters
    ----------
    law : LawCode or str
        The law (or a name :func:`fsmctl.model.laws.resolve_law` accepts).
    packed : sequence of float
        Its ``law.n_params`` packed values, in the order of ``law.parameters`` (an option as its index).

    Returns
    -------
    dict of str to object
        Each parameter by name: a float, a read-only array (a vector parameter such as ``delta``) or an option's
        name; what :func:`law_controller` takes as ``parameters``.

    Raises
    ------
    fsmctl.ScenarioError
        ``packed`` does not have ``law.n_params`` values.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.model.laws import parameter_matrix
    >>> from fsmctl.plugin.iosys import law_parameter_values
    >>> law = fsmctl.resolve_law("fsm")
    >>> law_parameter_values(law, parameter_matrix(law, fsmctl.paper_scenario("1"))[0])["singularity_fix"]
    'switch'
    """
    law = resolve_law(law)
    row = np.asarray(packed, dtype=float).reshape(-1)
    if row.size != law.n_params:
        raise ScenarioError(f"law {law.name!r}: expected {law.n_params} packed parameters, got {row.size}")
    out, k = {}, 0
    for info in law.parameters:
        out[info.name] = _parameter_value(info, row[k : k + info.size])
        k += info.size
    return out


@dataclass(frozen=True)
class _ParameterScheme:
    """How a controller's python-control parameters (local names) become the law's packed parameter vector."""

    values: dict[str, Any]
    validators: dict[str, Callable[[Any, str], Any]]
    pack: Callable[[Mapping[str, Any]], np.ndarray]


def _law_scheme(law: LawCode, given: Mapping[str, Any], where: str) -> _ParameterScheme:
    """One python-control parameter per law parameter, named like it (``K``, ``P``, ...)."""
    names = [p.name for p in law.parameters]
    unknown = sorted(set(given) - set(names))
    if unknown:
        raise ScenarioError(
            f"{where}: parameters: the law {law.name!r} has no parameter {unknown[0]!r} "
            f"(its parameters: {', '.join(names) or 'none'})"
        )
    clash = sorted(set(names) & {"J0", "u_max", "owner"})
    if clash:
        raise ScenarioError(f"{where}: the law's parameter {clash[0]!r} clashes with the controller's own parameter")
    values, validators = {}, {}
    for info in law.parameters:
        check = _law_parameter(info)
        validators[info.name] = check
        if info.name in given:
            check(given[info.name], f"{where}: parameters: {info.name}")  # fail at construction, not at first use
            value = given[info.name]
            values[info.name] = value.lower() if isinstance(value, str) else value
        else:
            values[info.name] = _parameter_value(info, info.default)

    def pack(checked: Mapping[str, Any]) -> np.ndarray:
        return np.concatenate([np.zeros(0)] + [checked[name] for name in names])

    return _ParameterScheme(values, validators, pack)


def _controller(
    kind: str,
    law: LawCode,
    J0: np.ndarray,
    scheme: _ParameterScheme,
    u_max: float,
    error_model: str,
    nbrs: tuple[Neighbour, ...],
    name: str | None,
    factory: tuple,
    signals: Mapping[str, Any],
    params: Any,
    dt: Any,
) -> ParameterizedSystem:
    """One agent's law (the contract of :mod:`fsmctl.symbolic.law`) as a python-control system."""
    where = f"{kind} {name!r}" if name else kind
    nz, nb, bname = law.n_states, law.n_broadcast, law.broadcast_name
    if bname == "tau":
        raise ScenarioError(f"{where}: the law's broadcast is named 'tau', the controller's torque output")
    local = _Generated(
        f"law_local_{error_model}", law.folder
    )  # the contract's names (fsmctl.symbolic.law.contract_names)
    control = _Generated(f"law_control_{error_model}", law.folder)
    constants = _Generated("law_constants", law.folder)
    k_i = [nb_.k_i for nb_ in nbrs]
    weights = [_scalar_schedule(nb_.k_j, nb_.phase) for nb_ in nbrs]
    inputs = _labels("sigma") + _labels("omega") + _labels("sigma_d") + _labels("omega_d") + _labels("omega_d_dot")
    for nb_ in nbrs:
        inputs += _labels(f"{bname}_{nb_.name}", nb)

    # one flat call: (t, own/reference signals, z, params, J0, aggregates, u_max) -> (torque, broadcast, z_dot);
    # the law's constants are computed from the parameters inside the call, so params= values are used consistently
    def build(t, y, z, prm, J, k_sum, received, k_received_sum, um):
        agent = (t, y[0:3], y[3:6], z, y[6:9], y[9:12], y[12:15], J, prm, constants(prm))
        b, cache = local(*agent)
        u, _, z_dot = control(*agent, cache, k_sum, received, k_received_sum, um)
        return [u, b, z_dot]

    shapes = [(1, 1), (15, 1), (nz, 1), (law.n_params, 1), (3, 3), (1, 1), (nb, 1), (1, 1), (1, 1)]
    call = _FlatCall(build, shapes, f"{kind}_law")
    zero = np.zeros(nb)

    def evaluate(t, x, u, p):
        # eq 19: the agent knows only what it receives, sum_j k^j_ij(t) b_j, from the b_j on its inputs; the
        # rule is fsmctl.model.coupling.aggregate, here with the agent as receiver 0 and its neighbours 1..m
        broadcasts = [zero] + [u[15 + nb * m : 15 + nb * (m + 1)] for m in range(len(nbrs))]
        received, k_sum, k_received_sum = aggregate(
            broadcasts, [w(t) for w in weights], [0] * len(nbrs), range(1, len(nbrs) + 1), k_i, zero=lambda: zero
        )
        prm = scheme.pack(p)
        return call(t, u[:15], x, prm, p["J0"], k_sum[0], received[0], k_received_sum[0], p["u_max"])

    update = None if nz == 0 else (lambda t, x, u, p: evaluate(t, x, u, p)[3 + nb :])
    m = len(nbrs)
    states = _signal_names(signals["states"], law.state_labels() if nz else [], "states", where)
    basis = [np.zeros((nb, nb * m))] + [np.eye(nb, nb * m, nb * j) for j in range(m)]

    def jacobian(t, x, u, p):
        # the aggregation is linear in the broadcasts: d received / d [b_1 .. b_m] is the same rule applied to
        # the unit broadcasts (the weights at t)
        weight = aggregate(
            basis, [w(t) for w in weights], [0] * m, range(1, m + 1), k_i, zero=lambda: np.zeros((nb, nb * m))
        )[0][0]
        received, k_sum, k_received_sum = aggregate(
            [zero] + [u[15 + nb * j : 15 + nb * (j + 1)] for j in range(m)],
            [w(t) for w in weights],
            [0] * m,
            range(1, m + 1),
            k_i,
            zero=lambda: zero,
        )
        d_y, d_z, d_received = call.jacobian(
            t,
            u[:15],
            x,
            scheme.pack(p),
            p["J0"],
            k_sum[0],
            received[0],
            k_received_sum[0],
            p["u_max"],
            wrt=(1, 2, 6),
            labels=(inputs[:15], states, [f"received[{k}]" for k in range(nb)]),
        )
        d_u = np.hstack([d_y, d_received @ weight])
        return d_z[3 + nb :], d_u[3 + nb :], d_z[: 3 + nb], d_u[: 3 + nb]

    system = ParameterizedSystem(
        kind,
        update,
        lambda t, x, u, p: evaluate(t, x, u, p)[: 3 + nb],
        {"J0": J0, **scheme.values, "u_max": u_max},
        {"J0": _inertia, **scheme.validators, "u_max": _torque_limit},
        inputs=_signal_names(signals["inputs"], inputs, "inputs", where),
        outputs=_signal_names(signals["outputs"], _labels("tau") + _labels(bname, nb), "outputs", where),
        name=name,
        jacobian=jacobian,
        **({"states": states} if nz else {}),
    )
    if law.discontinuity is not None and law.discontinuity.smoothed_by:
        system._kink_hint = (
            f"linearize at another operating point (the law's {law.discontinuity.where} is smoothed by its "
            f"parameter {law.discontinuity.smoothed_by!r} > 0)"
        )
    return _finish(system, factory, params, dt)


def law_controller(
    law: LawCode | str,
    J0,
    *,
    parameters: Mapping[str, Any] | None = None,
    u_max: float = math.inf,
    error_model: str = "paper",
    neighbours: Sequence[Neighbour] = (),
    name: str | None = None,
    inputs: Any = None,
    outputs: Any = None,
    states: Any = None,
    params: Mapping[str, Any] | None = None,
    dt: Any = 0,
) -> ParameterizedSystem:
    """One agent's control law, any law (built-in, derived folder or derivation script), as a python-control system.

    The system evaluates the law's generated contract functions (``law_constants``, ``law_local_<model>``,
    ``law_control_<model>``, :mod:`fsmctl.symbolic.law`): the same code the compiled simulator flies.  What the
    agent receives from its neighbours is aggregated by :func:`fsmctl.model.coupling.aggregate` (the engine's
    rule: ``received = sum_j k^j_ij(t) b_j``, ``k_sum = sum_j k^i_ij``, ``k_received_sum = sum_j k^j_ij(t)``).

    Parameters
    ----------
    law : LawCode or str
        A built-in law's name (``"fsm"``, the paper's), a derived folder or a derivation script
        (:func:`fsmctl.model.laws.resolve_law`).
    J0 : array_like, shape (3, 3)
        Nominal inertia used by the law: finite, symmetric positive definite.
    parameters : mapping, optional
        The law's parameters by name (an option by its name, e.g. ``singularity_fix="switch"``); the others
        take the law's defaults.  Checked against the law's declared ranges.
    u_max : float
        Per-axis torque limit (N m) of the ideal actuator, ``>= 0`` (``inf``: none).
    error_model : {"paper", "exact"}
        The error kinematics the law uses.
    neighbours : sequence of Neighbour
        Agents whose broadcasts this one receives (unique names); each adds inputs
        ``<broadcast>_<name>[k]`` (e.g. ``s_sc2[0..2]`` for the paper's law).
    name : str, optional
        System name; default python-control's unique ``sys[<id>]``.

    inputs, outputs, states : int, str or list of str, optional
        New signal names (python-control's forms; their number must be the system's); default the names below.
    params : mapping, optional
        Initial parameter values, by local name (``"c1"``, ``"J0"``, ``"u_max"``) or key, validated like the
        arguments (they win).
    dt : 0, None, True or float
        python-control's timebase.  A law with states is continuous time (``None`` is taken as 0, a discrete
        ``dt`` raises); a static law (no states) is a memoryless map and takes any timebase (``None``:
        unspecified, ``True`` or a sampling period: discrete).

    Returns
    -------
    ParameterizedSystem
        States: the law's states ``z`` (labels of :meth:`LawCode.state_labels`; none: a static system).
        Inputs ``sigma``, ``omega`` (own state), ``sigma_d``, ``omega_d``, ``omega_d_dot`` (reference) and each
        neighbour's broadcast.  Outputs ``tau[0..2]`` (the applied, limited torque: the plant's input) and the
        broadcast ``<broadcast>[k]``.  Parameters ``f"{name}_J0"``, one per law parameter under its name
        (``f"{name}_K"``, ...), ``f"{name}_u_max"`` and the owner tag.  Initial law states:
        :func:`fsmctl.model.laws.initial_law_states`.

    Raises
    ------
    fsmctl.ScenarioError
        A bad ``J0``, parameter, ``u_max``, ``error_model``, ``neighbours`` or ``name``.
    fsmctl.model.laws.LawError
        An unknown law.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.plugin.iosys import law_controller
    >>> paper = fsmctl.paper_scenario("1")
    >>> ctrl = law_controller("fsm", paper.agents[0].J0_array, parameters={"c1": 0.5}, u_max=2.0, name="c")
    >>> ctrl.nstates, ctrl.output_labels
    (0, ['tau[0]', 'tau[1]', 'tau[2]', 's[0]', 's[1]', 's[2]'])
    >>> float(ctrl.params["c_c1"]), ctrl.params["c_singularity_fix"]
    (0.5, 'switch')
    """
    call = _factory_call(law_controller, locals())
    name = _system_name(name, "law_controller")
    where = f"law_controller {name!r}" if name else "law_controller"
    law = resolve_law(law)
    J0 = _inertia(J0, f"{where}: J0")
    if parameters is None:
        parameters = {}
    if not isinstance(parameters, Mapping):
        raise ScenarioError(
            f"{where}: parameters: expected a mapping of parameter names to values, got {_show(parameters)}"
        )
    if error_model not in ("paper", "exact"):
        raise ScenarioError(f"{where}: error_model: must be 'paper' or 'exact', got {_show(error_model)}")
    scheme = _law_scheme(law, parameters, where)
    u_max = _torque_limit(u_max, f"{where}: u_max")
    nbrs = _neighbours(neighbours, where)
    signals = {"inputs": inputs, "outputs": outputs, "states": states}
    return _controller("law_controller", law, J0, scheme, u_max, error_model, nbrs, name, call, signals, params, dt)


def _flown_parameters(
    law: LawCode, controller: ControllerSettings, J0: np.ndarray, delta: np.ndarray, where: str
) -> dict[str, Any]:
    """The parameters ``law`` flies under ``controller`` for an agent with this ``J0`` and ``delta`` (written,
    preset or default), as a one-agent scenario's :meth:`fsmctl.Scenario.law_parameters` gives them: the path
    every scenario takes."""
    from fsmctl.model.scenario import Agent, Reference

    zero = (0.0, 0.0, 0.0)
    agent = Agent(J0=J0.tolist(), delta_J=np.zeros((3, 3)).tolist(), sigma0=zero, omega0=zero)
    try:
        one = Scenario(
            name=where,
            agents=(agent,),
            reference=Reference(sigma0=zero, omega=Sinusoid()),
            topology=Topology(1, ()),
            controller=controller,
        ).with_law(law.name, {"delta": delta.tolist()})
        return one.law_parameters()[0]
    except (ScenarioError, LawError) as exc:
        raise ScenarioError(f"{where}: controller: {exc}") from None


def fsm_controller(
    J0,
    controller: ControllerSettings,
    delta: Sequence[float],
    *,
    neighbours: Sequence[Neighbour] = (),
    name: str | None = None,
    inputs: Any = None,
    outputs: Any = None,
    states: Any = None,
    params: Mapping[str, Any] | None = None,
    dt: Any = 0,
) -> ParameterizedSystem:
    """One agent's fast-sliding-mode controller (eqs 13, 16-19): :func:`law_controller` of the paper's law.

    Parameters
    ----------
    J0 : array_like, shape (3, 3)
        Nominal inertia used by the law: finite, symmetric positive definite.
    controller : ControllerSettings
        The paper's law's parameters as a scenario's ``[controller]`` sets them (the law's defaults for those
        it leaves unset; the ``surface`` preset applied), torque limit (0, i.e. no torque, when ``enabled`` is
        False) and error model; its ``law`` is not read (this is the paper's law).
    delta : sequence of 3 floats
        Switching gain of eq 18 (finite, positive); wins over the controller's.
    neighbours : sequence of Neighbour
        Agents whose sliding variables this one receives (unique names); each adds inputs ``s_<name>[0..2]``.
    name : str, optional
        System name; default python-control's unique ``sys[<id>]``.

    inputs, outputs, states : int, str or list of str, optional
        New signal names (python-control's forms; their number must be the system's); default the names below.
    params : mapping, optional
        Initial parameter values, by local name (``"c1"``, ``"J0"``, ``"u_max"``) or key, validated like the
        arguments (they win).
    dt : 0, None, True or float
        python-control's timebase.  A law with states is continuous time (``None`` is taken as 0, a discrete
        ``dt`` raises); a static law (no states) is a memoryless map and takes any timebase (``None``:
        unspecified, ``True`` or a sampling period: discrete).

    Returns
    -------
    ParameterizedSystem
        Static.  Inputs ``sigma``, ``omega`` (own state), ``sigma_d``, ``omega_d``, ``omega_d_dot`` (reference)
        and ``s_<neighbour>``; outputs ``tau[0..2]`` (saturated torque) and ``s[0..2]``.  Parameters: the law's,
        by the paper's names, ``f"{name}_c1"``, ``_c2``, ``_alpha`` (eq 13), ``_boundary_layer`` (Remark 7),
        ``_epsilon``, ``_singularity_fix`` (Remark 6), ``_delta`` (eq 18), then ``_J0``, ``_u_max`` and the
        owner tag: the system of :func:`law_controller` ``("fsm", ...)`` with these values.

    Raises
    ------
    fsmctl.ScenarioError
        A bad ``J0``, ``delta``, ``controller``, ``neighbours`` or ``name``.

    Examples
    --------
    >>> import fsmctl
    >>> paper = fsmctl.paper_scenario("1")
    >>> a, delta = paper.agents[0], paper.law_parameters()[0]["delta"]
    >>> ctrl = fsmctl.fsm_controller(a.J0_array, paper.controller, delta, name="ctrl1")
    >>> ctrl.output_labels
    ['tau[0]', 'tau[1]', 'tau[2]', 's[0]', 's[1]', 's[2]']
    >>> float(ctrl.params["ctrl1_u_max"]), float(ctrl.params["ctrl1_c1"]), ctrl.params["ctrl1_delta"].tolist()
    (2.0, 0.6, [0.005, 0.005, 0.005])
    """
    call = _factory_call(fsm_controller, locals())
    name = _system_name(name, "fsm_controller")
    where = f"fsm_controller {name!r}" if name else "fsm_controller"
    J0 = _inertia(J0, f"{where}: J0")
    delta = _positive3(delta, f"{where}: delta")
    if not isinstance(controller, ControllerSettings):
        raise ScenarioError(f"{where}: controller: expected ControllerSettings, got {type(controller).__name__}")
    u_max = _torque_limit(controller.effective_torque_limit, f"{where}: controller torque limit")
    nbrs = _neighbours(neighbours, where)
    law = resolve_law("fsm")
    parameters = _flown_parameters(law, controller, J0, delta, where)
    parameters["delta"] = delta  # the argument itself, as given (validated above)
    scheme = _law_scheme(law, parameters, where)
    signals = {"inputs": inputs, "outputs": outputs, "states": states}
    return _controller(
        "fsm_controller", law, J0, scheme, u_max, controller.error_model, nbrs, name, call, signals, params, dt
    )


def initial_state(scenario: Scenario) -> np.ndarray:
    """The formation's initial state vector (order of :func:`formation`'s states): quaternions from the MRPs,
    then the law's initial states of every agent (none for the paper's law).

    Parameters
    ----------
    scenario : Scenario
        The formation: the reference's and the agents' initial MRPs and rates (and wheel speeds), the law.

    Returns
    -------
    numpy.ndarray
        ``[q_d, q_1, omega_1 (, Omega_1), ..., q_n, omega_n (, Omega_n), z_1, ..., z_n]``; with actuator or sensor
        blocks in :func:`formation`, pass ``[initial_state(s), x_blocks]`` (or ``[initial_state(s), 0]``).

    Raises
    ------
    fsmctl.ScenarioError
        ``scenario`` is not a :class:`fsmctl.Scenario`.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.plugin.iosys import initial_state
    >>> initial_state(fsmctl.paper_scenario("1")).shape
    (46,)
    """
    if not isinstance(scenario, Scenario):
        raise ScenarioError(f"initial_state: expected a Scenario, got {type(scenario).__name__}")
    x = [quaternion_from_mrp(scenario.reference.sigma0)]
    wheels = scenario.actuator.per_wheel("initial_speed") if scenario.actuator.enabled else np.zeros(0)
    for a in scenario.agents:
        x += [quaternion_from_mrp(a.sigma0), np.asarray(a.omega0, dtype=float), wheels]
    z0 = initial_law_states(scenario.law)
    x += [z0] * scenario.n_agents
    return np.concatenate(x)


def mrp_state(x, n_agents: int | None = None, n_wheels: int = 0) -> np.ndarray:
    """Formation states (of :func:`formation`) in the compiled simulator's MRP layout.

    Parameters
    ----------
    x : array_like, shape (4 + 7 n [+ law states], ...)
        ``[q_d, q_1, omega_1, ..., q_n, omega_n]`` along the first axis (e.g. ``response.states``), optionally
        followed by the controllers' law states (then give ``n_agents``).
    n_agents : int, optional
        The number of agents ``n``; by default ``(len(x) - 4) / (7 + n_wheels)`` (a law without states).
    n_wheels : int
        Reaction wheels per agent (their speeds follow each agent's rate; they are dropped here).

    Returns
    -------
    numpy.ndarray, shape (3 + 6 n, ...)
        ``[sigma_d, sigma_1, omega_1, ..., sigma_n, omega_n]`` with every MRP in the shadow set ``|sigma| <= 1``
        (the layout of :func:`fsmctl.simulate`'s ``sigma_d``, ``sigma``, ``omega``).

    Raises
    ------
    ValueError
        ``x`` is too short along its first axis for ``n_agents`` (or, without ``n_agents``, its length is not
        ``4 + (7 + n_wheels) n``).

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.plugin.iosys import initial_state, mrp_state
    >>> s = fsmctl.paper_scenario("1")
    >>> mrp_state(initial_state(s))[:3].round(12).tolist() == list(s.reference.sigma0)
    True
    """
    a = np.asarray(x, dtype=float)
    w = 7 + int(n_wheels)
    if n_agents is None:
        if a.ndim == 0 or (a.shape[0] - 4) % w or a.shape[0] < 4:
            raise ValueError(f"expected formation states of length 4 + {w} n along the first axis, got shape {a.shape}")
        n = (a.shape[0] - 4) // w
    else:
        n = int(n_agents)
        if a.ndim == 0 or n < 0 or a.shape[0] < 4 + w * n:
            raise ValueError(
                f"expected formation states of length >= 4 + {w} * {n} along the first axis, got {a.shape}"
            )
    rows = [mrp_from_quaternion(np.moveaxis(a[:4], 0, -1))]
    for i in range(n):
        o = 4 + w * i
        rows += [mrp_from_quaternion(np.moveaxis(a[o : o + 4], 0, -1)), np.moveaxis(a[o + 4 : o + 7], 0, -1)]
    return np.moveaxis(np.concatenate(rows, axis=-1), -1, 0)
