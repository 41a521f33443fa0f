""":class:`ParameterizedSystem`: a python-control nonlinear system on CasADi functions, with typed parameters.

The right-hand side and output are CasADi functions of flat arguments (:class:`_FlatCall`); the system checks its
parameters when they are given (:mod:`fsmctl.plugin.parameters`), linearises with the generated Jacobians
(:meth:`ParameterizedSystem.linearize`) and pickles as the factory call that made it.  The factories are in
:mod:`fsmctl.plugin.iosys`.
"""

from __future__ import annotations

import copy
import uuid
import warnings
from collections.abc import Callable, Mapping, MutableMapping, Sequence
from typing import Any

import casadi as ca
import control as ct
import numpy as np

from fsmctl.errors import InputError
from fsmctl.plugin.jacobians import (
    Derivatives,
    Kink,
    NonDifferentiableError,
    symbolic_graph,
)
from fsmctl.plugin.parameters import (
    _MIN_QUATERNION_NORM2,
    _PICKLED,
    _ambiguous,
    _foreign_params,
    _invalid_quaternion,
    _KnownKeys,
    _LocalParams,
    _Merged,
    _Owner,
    _owners_of,
    _Params,
    _rebuild,
    _unknown_keys,
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


_Model = Callable[[float, np.ndarray, np.ndarray, Mapping[str, Any]], np.ndarray]


class QuaternionNormWarning(UserWarning):
    """A state handed to an fsmctl system holds an attitude quaternion whose norm is far from 1 (``|q|`` outside
    0.71 to 1.22): probably not the state meant, since python-control pads a short ``X0`` with zeros.  Shown once
    per system.

    Examples
    --------
    >>> import warnings, numpy as np, fsmctl
    >>> sc = fsmctl.spacecraft(np.eye(3), name="sc")
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     _ = sc.output(0.0, [0.1, 0.2, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0])  # an MRP state given for q
    >>> caught[0].category.__name__, str(caught[0].message)[:54]
    ('QuaternionNormWarning', "spacecraft 'sc': the attitude quaternion q = [0.1, 0.2")
    """


_FAR_FROM_UNIT = 0.5
"""``| |q|^2 - 1 |`` above which a state's quaternion is taken for a mistake (|q| outside [0.71, 1.22]; the
normalisation-drift control keeps a flown ``|q|`` within 1e-6 of 1)."""


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

    def _check_state(self, x) -> None:
        """Refuse ``q ~ 0`` (no rotation); warn once when ``|q|`` is far from 1: a state that is not this system's
        (python-control pads a short ``X0`` with zeros; an MRP state ``[sigma, omega]`` given for ``[q, omega]``)."""
        n2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3]
        if n2 < _MIN_QUATERNION_NORM2:
            raise _invalid_quaternion(self._where, self._kind, x[:4])
        if abs(n2 - 1.0) > _FAR_FROM_UNIT and not self.__dict__.get("_norm_warned"):
            self._norm_warned = True
            shown = ", ".join(f"{float(v):.3g}" for v in x[:4])
            warnings.warn(
                f"{self._where}: the attitude quaternion q = [{shown}] has |q| = {float(n2) ** 0.5:.3g}, far from 1: "
                "the system flies q / |q|, which is probably not the attitude meant (a short X0 padded with zeros, "
                "or an MRP state?); build states with quaternion_from_mrp or fsmctl.initial_state",
                QuaternionNormWarning,
                stacklevel=2,
            )

    def _updfcn(self, t, x, u, params):
        if self._attitude:
            self._check_state(x)
        return self._model_update(t, x, u, self._resolve(params))

    def _outfcn(self, t, x, u, params):
        if self._attitude:
            self._check_state(x)
        return self._model_output(t, x, u, self._resolve(params))

    def sample(self, Ts, method=None, alpha=None, prewarp_frequency=None, name=None, copy_names=True, **kwargs):
        """python-control's :func:`control.sample_system` of a nonlinear fsmctl system: refused with the route.

        A nonlinear system has no exact discretization; :func:`fsmctl.plugin.sampled.zoh` samples it with a
        zero-order hold (its state advanced by RK4 over the period, the compiled simulator's rule).

        Parameters
        ----------
        Ts, method, alpha, prewarp_frequency, name, copy_names, **kwargs
            Those of :func:`control.sample_system`.

        Raises
        ------
        fsmctl.errors.InputError
            Always, naming :func:`fsmctl.plugin.sampled.zoh` (or its linearization, for a linear design).
        """
        raise InputError(
            f"{self._where}: control.sample_system needs a linear system; sample this nonlinear one with "
            f"fsmctl.plugin.zoh(sys, {Ts!r}, step=...) (zero-order hold, RK4 over the period), or sample its "
            "linearization (control.linearize / fsmctl.plugin.mrp_linearization)"
        )

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
