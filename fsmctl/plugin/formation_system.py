"""python-control plug-in: :class:`FormationSystem`, the closed-loop formation :func:`fsmctl.plugin.formation`
returns: a :class:`control.InterconnectedSystem` whose law parameters also take their bare names, that pickles and
that linearizes exactly through its subsystems' Jacobians (:mod:`fsmctl.plugin.jacobians`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import control as ct
import numpy as np

from fsmctl.errors import InputError
from fsmctl.plugin.jacobians import interconnection_jacobians
from fsmctl.plugin.parameters import (
    _ambiguous,
    _foreign_params,
    _KnownKeys,
    _Merged,
    _Owner,
    _owners_of,
    _unknown_keys,
)
from fsmctl.plugin.system import ParameterizedSystem, _operating_vector, _state_space

__all__ = ["FormationSystem"]


class FormationSystem(ct.InterconnectedSystem):
    """The closed-loop formation :func:`formation` returns: a :class:`control.InterconnectedSystem` whose law
    parameters can also be given by their bare names.

    ``params={"c1": 0.3}`` (a name of :attr:`law_parameters`, the keys of a scenario's ``[controller]`` table)
    sets that parameter of every controller ``ctrl1..ctrln``, exactly as ``params={"ctrl1_c1": 0.3,
    "ctrl2_c1": 0.3, ...}`` would; a prefixed key (``"ctrl2_c1"``) passed with it wins for its agent.  Values are
    checked by the path scenario files take (:meth:`fsmctl.model.laws.LawParameterInfo.values`, the law's
    declared ranges).  Bare names are read from the ``params`` given to this system itself
    (:func:`control.input_output_response`, :meth:`dynamics`, :meth:`output`); inside a larger interconnection,
    use the prefixed keys.  Another local name (``"omega_d"``) is the parameter of the one subsystem that has it;
    one that several subsystems have (``"J"``: ``sc1_J, ..., scn_J``) raises :class:`fsmctl.errors.InputError`
    naming their keys.  A formation pickles (its subsystems are rebuilt by their factories).

    Parameters
    ----------
    *args
        The arguments of :class:`control.InterconnectedSystem` (:func:`formation` makes it).
    **kwargs
        The keyword arguments of :class:`control.InterconnectedSystem`.

    Attributes
    ----------
    law_parameters : tuple of str
        The law's parameter names (``("c1", "c2", "alpha", "boundary_layer", "epsilon", "singularity_fix",
        "delta")`` for the paper's law).
    controllers : tuple of str
        The controllers' names, ``("ctrl1", ..., "ctrln")``.

    Examples
    --------
    >>> import control as ct, numpy as np
    >>> import fsmctl
    >>> from fsmctl.plugin.iosys import initial_state
    >>> s = fsmctl.paper_scenario("1").replace(controller={"torque_limit": float("inf")})  # unsaturated
    >>> loop = fsmctl.formation(s)
    >>> loop.law_parameters[:3]
    ('c1', 'c2', 'alpha')
    >>> x0 = initial_state(s)
    >>> a = loop.dynamics(0.0, x0, [], params={"c1": 1.2})
    >>> b = loop.dynamics(0.0, x0, [], params={f"ctrl{i}_c1": 1.2 for i in range(1, 7)})
    >>> bool(np.array_equal(a, b)), bool(np.array_equal(a, loop.dynamics(0.0, x0, [])))
    (True, False)
    """

    law_parameters: tuple[str, ...] = ()
    controllers: tuple[str, ...] = ()

    def __init__(self, *args, **kwargs):
        """Made by :func:`formation` (the arguments are :class:`control.InterconnectedSystem`'s).

        Parameters
        ----------
        *args
            As :class:`control.InterconnectedSystem`.
        **kwargs
            As :class:`control.InterconnectedSystem`.
        """
        super().__init__(*args, **kwargs)

    def _update_params(self, params):
        if params and not isinstance(params, _Merged):  # given to this system, not merged by an outer interconnection
            params = self._explicit(params)
        super()._update_params(params)

    def _explicit(self, params: Mapping[str, Any]) -> dict[str, Any]:
        """Params given to the formation itself, by prefixed key: a bare law name set for every controller (a
        prefixed key given with it wins), another local name for the one subsystem that has it (several: error)."""
        where = f"formation {self.name!r}"
        own = {sub._owner for sub in self.syslist if isinstance(sub, ParameterizedSystem)}
        for value in params.values():
            if isinstance(value, _Owner) and value not in own:
                raise _foreign_params(where, value, "by bare law name (c1, ...) or by key (ctrl1_c1, sc2_J, ...)")
        out, bare = {}, {}
        for key, value in params.items():
            if key in self.law_parameters:
                bare[key] = value
            elif key in self.params or key in out:
                out[key] = value
            else:
                keys = _owners_of(self.params, key)
                if len(keys) > 1:
                    raise _ambiguous(where, key, keys)
                if keys and keys[0] in params:
                    raise InputError(f"{where}: parameter {key!r} given twice, as {key!r} and {keys[0]!r}")
                out[keys[0] if keys else key] = value
        _unknown_keys(out, _KnownKeys(self.params, self.law_parameters), where)
        for key, value in bare.items():
            for ctrl in self.controllers:
                out.setdefault(f"{ctrl}_{key}", value)
        return out

    def _ic_update(self, t, x, u, params):
        # python-control's InterconnectedSystem callbacks, as methods (its closures cannot be pickled)
        self._update_params(params)
        return self._rhs(t, x, u)

    def _ic_output(self, t, x, u, params):
        self._update_params(params)
        return self._out(t, x, u)

    def _jacobians(self, t: float, x: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, ...]:
        return interconnection_jacobians(self, t, np.asarray(x, dtype=float), np.asarray(u, dtype=float), 1e-6)

    def linearize(self, x0, u0=None, t=0, params=None, eps=1e-6, copy_names=False, **kwargs):
        """The exact linearization of the closed loop at an operating point (python-control's ``linearize``).

        The subsystems' exact Jacobians (:meth:`ParameterizedSystem.linearize`) composed through the
        interconnection's maps; a linear actuator or sensor block enters by its matrices, any other nonlinear
        block by python-control's finite differences with step ``eps``.  The neighbour aggregation is linear in the
        broadcasts, with the weights at ``t``.

        Parameters
        ----------
        x0 : array_like or control.OperatingPoint
            The closed loop's state (:func:`initial_state` builds one).
        u0 : array_like, optional
            The input (a formation has none).
        t : float
            The time (the reference and the links' weights depend on it).
        params : dict, optional
            As for :meth:`dynamics`: prefixed keys, or a law parameter's bare name for every agent.
        eps : float
            Finite-difference step for nonlinear blocks that are not fsmctl systems.
        copy_names : bool
            As python-control.
        **kwargs
            ``name``, ``inputs``, ``outputs``, ``states`` of the returned system.

        Returns
        -------
        control.StateSpace
            The linearization.

        Raises
        ------
        fsmctl.plugin.NonDifferentiableError
            A subsystem is not differentiable at its operating point (named in the message).

        Examples
        --------
        >>> import numpy as np, fsmctl
        >>> s = fsmctl.paper_scenario("1")
        >>> lin = fsmctl.formation(s).linearize(fsmctl.initial_state(s))
        >>> lin.A.shape, bool(np.isfinite(lin.A).all())
        ((46, 46), True)
        """
        return linearize_interconnection(self, x0, u0, t, params, eps, copy_names, **kwargs)


def linearize_interconnection(
    sys: ct.InterconnectedSystem, x0, u0=None, t=0, params=None, eps=1e-6, copy_names=False, **kwargs
) -> ct.StateSpace:
    """The exact linearization of any :class:`control.InterconnectedSystem` (python-control's ``linearize``
    arguments): its subsystems' Jacobians composed through its maps (:func:`fsmctl.plugin.jacobians.
    interconnection_jacobians`); :meth:`FormationSystem.linearize` and :func:`fsmctl.plugin.linearize` call it."""
    if isinstance(x0, ct.OperatingPoint):
        u0 = x0.inputs if u0 is None else u0
        x0 = x0.states
    elif u0 is None:
        u0 = 0
    x = _operating_vector(x0, "x0", sys.nstates)
    u = _operating_vector(u0, "u0", sys.ninputs)
    sys._update_params(params)
    return _state_space(sys, *interconnection_jacobians(sys, float(t), x, u, eps), copy_names=copy_names, **kwargs)
