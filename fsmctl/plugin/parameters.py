"""Who owns a parameter of a plug-in system, and how a system is rebuilt with new ones.

A system's ``params`` are its own (``J``, ``c1``, ...); in an interconnection each key is owned by one block
(``sc2_J``), and a key no block owns, or that two blocks could own, is refused with
:class:`ParameterKeyError` naming it.  :class:`InvalidStateError` refuses a state python-control would
integrate into nonsense (a quaternion of norm ~0).  The factories' calls are recorded (:func:`_factory_call`) so
that a system pickles, and rebuilds with new parameters, as the call that made it (:func:`_rebuilt`).
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping, MutableMapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import control as ct
import numpy as np

from fsmctl.errors import InputError
from fsmctl.model.laws import (
    LawCode,
    LawError,
    LawParameterInfo,
    resolve_law,
)
from fsmctl.model.scenario import ScenarioError
from fsmctl.plugin.arguments import _show, _timebase
from fsmctl.suggest import ranked

if TYPE_CHECKING:  # pragma: no cover
    from fsmctl.plugin.system import ParameterizedSystem

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
    spacecraft 'sc': unknown parameter 'j' (known, closest first: J, sc_J, disturbance, sc_disturbance)
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
            order = ranked(str(key), listed)  # closest first (fsmctl.suggest: the one rule of suggestions)
            shown = ", ".join(map(str, order[:_KNOWN_SHOWN])) or "none"
            if len(order) > _KNOWN_SHOWN:
                shown += f", ... ({len(order) - _KNOWN_SHOWN} more: the keys of the system's params)"
            raise ParameterKeyError(f"{where}: unknown parameter {key!r} (known, closest first: {shown})")


_KNOWN_SHOWN = 24
"""How many known keys an unknown-parameter error lists (the closest first: every key of one system; a formation has about 70)."""


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


# ----------------------------------------------------------------------------- a law's parameters


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
