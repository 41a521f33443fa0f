"""python-control plug-in: exact linearizations for control design.

:func:`linearize` is :func:`control.linearize` with exact Jacobians also for a plain :func:`control.interconnect`
that holds fsmctl systems (every fsmctl system and :class:`fsmctl.plugin.formation_system.FormationSystem` is exact under
``control.linearize`` itself, :mod:`fsmctl.plugin.jacobians`).  :func:`mrp_linearization` gives the six-state
linearization in the MRP and the body rate, for control design, and :func:`mrp_estimator` the static system that
closes such a design around the quaternion plant with :func:`control.create_statefbk_iosystem`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import control as ct
import numpy as np

from fsmctl.model.scenario import ScenarioError
from fsmctl.plugin.arguments import _numbers
from fsmctl.plugin.formation_system import FormationSystem, linearize_interconnection
from fsmctl.plugin.jacobians import Kink, NonDifferentiableError

__all__ = ["linearize", "mrp_linearization", "mrp_estimator"]


def linearize(sys: Any, xeq: Any, ueq: Any = None, t: float = 0, params: Mapping[str, Any] | None = None, **kw):
    """:func:`control.linearize` with exact Jacobians also for a plain :func:`control.interconnect` of fsmctl
    systems.

    An fsmctl system, or a :func:`fsmctl.formation`, linearizes exactly through :func:`control.linearize`
    itself; an interconnection made by :func:`control.interconnect` (e.g. by
    :func:`control.create_statefbk_iosystem`) is python-control's class, whose ``linearize`` takes finite
    differences: this function composes its subsystems' exact Jacobians instead (linear blocks by their matrices,
    other nonlinear blocks by python-control's finite differences, step ``eps``).

    Parameters
    ----------
    sys : control.InputOutputSystem
        The system.
    xeq : array_like or control.OperatingPoint
        The state (or an operating point).
    ueq : array_like, optional
        The input; 0 by default.
    t : float
        The time.
    params : dict, optional
        Parameter values, as for :func:`control.linearize`.
    **kw
        ``eps``, ``copy_names``, ``name``, ``inputs``, ``outputs``, ``states``, as for :func:`control.linearize`.

    Returns
    -------
    control.StateSpace
        The linearization.

    Raises
    ------
    NonDifferentiableError
        A subsystem is not differentiable at its operating point.

    Examples
    --------
    A PD law ``tau = -4 sigma - 40 omega`` around a spacecraft; about each axis ``J s^2 + 40 s + 1 = 0``
    (``sigma_dot = omega / 4`` at the identity), and the quaternion norm's decay at ``-2``:

    >>> import control as ct, numpy as np, fsmctl
    >>> from fsmctl.plugin import linearize
    >>> sc = fsmctl.spacecraft(np.diag([100.0, 150.0, 200.0]), name="sc")
    >>> pd = ct.ss([], [], [], -np.hstack([4 * np.eye(3), 40 * np.eye(3)]), inputs=sc.output_labels,
    ...            outputs=sc.input_labels, name="pd")
    >>> lin = linearize(ct.interconnect([sc, pd], inputs=[], outputs=sc.output_labels), [1, 0, 0, 0, 0, 0, 0])
    >>> poles = np.sort(np.linalg.eigvals(lin.A).real)
    >>> analytic = np.sort([-2.0] + [r.real for J in (100.0, 150.0, 200.0) for r in np.roots([J, 40.0, 1.0])])
    >>> bool(np.allclose(poles, analytic, rtol=1e-9, atol=0))
    True
    """
    if not isinstance(sys, ct.InterconnectedSystem) or isinstance(sys, FormationSystem):
        return ct.linearize(sys, xeq, ueq, t=t, params=params, **kw)
    return linearize_interconnection(sys, xeq, ueq, t, params, **kw)


def _mrp_plant(plant: Any, where: str) -> tuple:
    model = getattr(plant, "_mrp_model", None)
    if model is None:
        raise ScenarioError(
            f"{where}: expected a plant made by fsmctl.spacecraft or fsmctl.reaction_wheel_spacecraft, got "
            f"{type(plant).__name__} {getattr(plant, 'name', '')!r}"
        )
    return model


def mrp_linearization(
    plant: Any,
    sigma0: Any = (0.0, 0.0, 0.0),
    omega0: Any = (0.0, 0.0, 0.0),
    tau0: Any = None,
    *,
    Omega0: Any = None,
    t: float = 0.0,
    params: Mapping[str, Any] | None = None,
    name: str | None = None,
):
    """The exact linearization of a spacecraft in MRP coordinates: states ``sigma``, ``omega``, for control design.

    The plant's states are Euler parameters (seven, with the norm's decay at ``-2 k`` as a spurious pole), its
    outputs MRPs: a gain designed on the quaternion linearization and applied to ``sigma`` is the wrong gain
    (``d sigma = d q_v / 2`` at the identity: half the attitude gain).  This model has the MRP and the body rate
    as its states, from the MRP kinematics of the generated ``plant_rhs`` (``gyrostat_rhs`` with wheels),
    differentiated exactly; close a design on it around the nonlinear plant with :func:`mrp_estimator` and
    :func:`control.create_statefbk_iosystem`.

    Parameters
    ----------
    plant : ParameterizedSystem
        A :func:`fsmctl.spacecraft` or :func:`fsmctl.reaction_wheel_spacecraft`.
    sigma0 : array_like, shape (3,)
        The operating point's MRP (any set; the model is that set's).
    omega0 : array_like, shape (3,)
        The body rate (rad/s).
    tau0 : array_like, optional
        The torque input (``tau`` of a spacecraft, ``u_command`` of a wheel plant; N m); zero by default.
    Omega0 : array_like, optional
        A wheel plant's wheel speeds (rad/s); zero by default.
    t : float
        The time (the disturbance depends on it).
    params : dict, optional
        The plant's parameter values for this call (its prefixed keys), as for :func:`control.linearize`.
    name : str, optional
        The name of the returned system.

    Returns
    -------
    control.StateSpace
        States and outputs ``sigma[0..2]``, ``omega[0..2]`` (and ``Omega[k]`` with wheels; ``C = I``, ``D =
        0``), inputs ``tau[0..2]`` (``u_command[0..2]`` with wheels).

    Raises
    ------
    fsmctl.ScenarioError
        ``plant`` is not an fsmctl spacecraft, or a vector is not of finite numbers of the right length.
    NonDifferentiableError
        The plant is not differentiable there (a wheel exactly at its speed limit, ...).

    Examples
    --------
    >>> import control as ct, numpy as np, fsmctl
    >>> from fsmctl.plugin import mrp_linearization
    >>> sc = fsmctl.spacecraft(np.diag([100.0, 150.0, 200.0]), name="sc")
    >>> lin = mrp_linearization(sc)
    >>> lin.A[:3, 3:].diagonal().tolist(), lin.B[3:].diagonal().tolist()  # sigma_dot = omega / 4, J^-1
    ([0.25, 0.25, 0.25], [0.01, 0.006666666666666667, 0.005])
    >>> np.linalg.eigvals(lin.A).real.tolist()  # six poles at 0: no spurious pole at -2
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    """
    where = f"mrp_linearization {getattr(plant, 'name', '')!r}"
    jacobian, states, controls, ninputs = _mrp_plant(plant, where)
    sigma = _numbers(sigma0, (3,), "three real numbers", f"{where}: sigma0")
    omega = _numbers(omega0, (3,), "three real numbers", f"{where}: omega0")
    n_extra = len(states) - 6
    extra = (
        np.zeros(n_extra) if Omega0 is None else _numbers(Omega0, (n_extra,), f"{n_extra} numbers", f"{where}: Omega0")
    )
    u = np.zeros(ninputs)
    if tau0 is not None:
        u[:3] = _numbers(tau0, (3,), "three real numbers", f"{where}: tau0")
    plant._update_params(params)
    try:
        A, B = jacobian(float(t), np.concatenate([sigma, omega, extra]), u, plant._resolve(plant._current_params))
    except Kink as exc:
        raise NonDifferentiableError(f"{where}: not differentiable at the operating point: {exc}") from None
    n = len(states)
    return ct.ss(A, B, np.eye(n), np.zeros((n, 3)), states=states, outputs=states, inputs=controls, name=name)


def mrp_estimator(plant: Any, name: str = "mrp_state"):
    """The static system that gives :func:`control.create_statefbk_iosystem` the MRP state of a quaternion plant.

    Its inputs are the plant's outputs (``sigma``, ``omega``, ...), its outputs ``xhat[k]``, the state of
    :func:`mrp_linearization` (``sigma``, ``omega``, and the wheel speeds with wheels), picked from them.  Pass it as
    ``estimator=`` with ``state_indices=`` the number of MRP states and, for a wheel plant,
    ``control_indices=3`` (the torque command ``u_command``; the external torque ``d`` stays an input)::

        K, _, _ = ct.lqr(mrp_linearization(plant), Q, R)
        ctrl, loop = ct.create_statefbk_iosystem(plant, K, estimator=mrp_estimator(plant), state_indices=6)

    Parameters
    ----------
    plant : ParameterizedSystem
        A :func:`fsmctl.spacecraft` or :func:`fsmctl.reaction_wheel_spacecraft`.
    name : str
        The system's name.

    Returns
    -------
    control.StateSpace
        Static (no states): ``xhat = S y`` with ``S`` selecting the MRP state from the plant's outputs.

    Raises
    ------
    fsmctl.ScenarioError
        ``plant`` is not an fsmctl spacecraft.

    Examples
    --------
    >>> import control as ct, numpy as np, fsmctl
    >>> from fsmctl.plugin import mrp_estimator, mrp_linearization
    >>> sc = fsmctl.spacecraft(np.diag([100.0, 150.0, 200.0]), name="sc")
    >>> K, _, _ = ct.lqr(mrp_linearization(sc), np.diag([100.0] * 3 + [1000.0] * 3), np.eye(3))
    >>> ctrl, loop = ct.create_statefbk_iosystem(sc, K, estimator=mrp_estimator(sc), state_indices=6)
    >>> loop.nstates, loop.input_labels[:2]
    (7, ['xd[0]', 'xd[1]'])
    """
    _, states, _, _ = _mrp_plant(plant, f"mrp_estimator {getattr(plant, 'name', '')!r}")
    outputs = list(plant.output_labels)
    # the plant's first outputs are its MRP state, in that order (sigma, omega, and the wheel speeds): by position,
    # so that renamed outputs (spacecraft(..., outputs=[...])) select the same signals
    S = np.eye(len(states), len(outputs))
    return ct.ss(
        np.zeros((0, 0)),
        np.zeros((0, len(outputs))),
        np.zeros((len(states), 0)),
        S,
        inputs=outputs,
        outputs=[f"xhat[{i}]" for i in range(len(states))],
        name=name,
    )
