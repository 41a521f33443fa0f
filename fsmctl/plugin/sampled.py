"""python-control plug-in: sampled-data loops (a discrete-time law flying continuous-time spacecraft).

python-control refuses to interconnect continuous- and discrete-time systems (``nlsys``/``interconnect`` need one
timebase).  The route is the one of digital control: sample the continuous-time parts at the controller's period
``T`` with a zero-order hold, so that every block of the loop is discrete time with ``dt = T``:

* :func:`zoh`: a continuous-time system (a spacecraft, the reference generator, a wheel-equipped spacecraft, any
  :class:`control.NonlinearIOSystem`) as a discrete-time system: its state advanced over one period with the input
  held, by fixed-step RK4 (the compiled simulator's rule, ``simulation.dt`` inside a ``control_period``);
* :func:`discrete_law_controller`, :func:`discrete_fsm_controller`: one agent's law as the flight software runs it
  (the compiled simulator's ``control_period``): at each instant ``t_k`` the torque and the broadcast from the
  sampled signals, the law's states advanced by the rate of that instant held over the period;
* :func:`sampled_formation`: the closed loop of a scenario with ``simulation.control_period > 0`` (what
  :func:`fsmctl.formation` returns for such a scenario), with the scenario's star tracker and rate gyro.

The loop then runs with :func:`control.input_output_response` at the instants ``T = k control_period`` and agrees
with :func:`fsmctl.simulate` to the integration error of RK4 (the plug-in integrates quaternions, the compiled loop
MRPs: the same RK4 step on two parametrizations of the attitude).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import control as ct
import numpy as np

from fsmctl.model.laws import LawCode
from fsmctl.model.scenario import ControllerSettings, ScenarioError
from fsmctl.plugin.arguments import _scalar, _show, _system_name
from fsmctl.plugin.iosys import Neighbour, fsm_controller, law_controller
from fsmctl.plugin.parameters import _rebuilt
from fsmctl.plugin.system import ParameterizedSystem

__all__ = ["zoh", "discrete_law_controller", "discrete_fsm_controller"]

_GRID_TOLERANCE = 1e-9
"""Relative tolerance of "``dt`` is a multiple of ``step``" (the scenario's grid rule is exact to rounding)."""

_INSTANT_LEAD = 1e-6
"""The link weights of a discrete law are read at ``t_k + _INSTANT_LEAD * dt`` (see :func:`discrete_law_controller`)."""


def _period(dt: Any, where: str) -> float:
    """A sampling period: a positive finite number (``True``, python-control's unspecified period, has none)."""
    if isinstance(dt, (bool, np.bool_)) or dt is None:
        raise ScenarioError(
            f"{where}: dt: expected the sampling period in s (a number > 0), got {_show(dt)}; a zero-order hold "
            "needs the period it holds over"
        )
    return _scalar(dt, f"{where}: dt", minimum=0.0, strict=True)


def _substeps(dt: float, step: Any, where: str) -> int:
    """The number of RK4 steps of length ``step`` in one period ``dt`` (``dt`` must be a multiple of ``step``)."""
    if step is None:
        return 1
    h = _scalar(step, f"{where}: step", minimum=0.0, strict=True)
    n = round(dt / h)
    if n < 1 or abs(n * h - dt) > _GRID_TOLERANCE * dt:
        raise ScenarioError(f"{where}: step: the period dt = {dt} s must be a multiple of step = {h} s")
    return n


def _rk4(f, t: float, x: np.ndarray, dt: float, n: int) -> np.ndarray:
    """``n`` classical RK4 steps of ``h = dt / n`` of ``x' = f(t, x)`` from ``t`` (the compiled loop's stages)."""
    h = dt / n
    x = np.array(x, dtype=float)
    for k in range(n):
        tk = t + k * h
        k1 = f(tk, x)
        k2 = f(tk + 0.5 * h, x + 0.5 * h * k1)
        k3 = f(tk + 0.5 * h, x + 0.5 * h * k2)
        k4 = f(tk + h, x + h * k3)
        x = x + h / 6.0 * (k1 + 2.0 * (k2 + k3) + k4)
    return x


def _parameterized_twin(
    sys: ParameterizedSystem, update, name: str | None, dt: float, call: tuple
) -> ParameterizedSystem:
    """A :class:`ParameterizedSystem` with ``sys``'s signals, parameters (values, validation, attitude check) and
    output, the discrete-time ``update(t, x, u, p)`` and ``dt``; pickled as ``call`` (the function and arguments
    that made it)."""
    values = {local: sys.params[key] for local, key in sys._keys.items()}
    twin = ParameterizedSystem(
        sys._kind,
        update,
        sys._model_output,
        values,
        sys._validators,
        name=name,
        attitude=sys._attitude,
        inputs=list(sys.input_labels),
        outputs=list(sys.output_labels),
        **({"states": list(sys.state_labels)} if sys.nstates else {}),
        dt=dt,
    )
    twin._factory = call
    return twin


def _default_name(sys: ct.InputOutputSystem) -> str:
    """python-control's name of a sampled system (:func:`control.sample_system`): prefix + name + suffix."""
    return (
        ct.config.defaults["iosys.sampled_system_name_prefix"]
        + sys.name
        + ct.config.defaults["iosys.sampled_system_name_suffix"]
    )


def zoh(
    sys: ct.NonlinearIOSystem, dt: float, *, step: float | None = None, name: str | None = None
) -> ct.NonlinearIOSystem:
    """A continuous-time system sampled with a zero-order hold: its state advanced over one period, input held.

    ``x[k+1] = Phi(t_k, x[k], u[k])``, the flow of ``x' = f(t, x, u[k])`` from ``t_k`` to ``t_k + dt`` by
    ``dt / step`` classical RK4 steps (the compiled simulator's rule: RK4 at ``simulation.dt`` inside each
    ``control_period``, the law's torque held), and ``y[k] = h(t_k, x[k], u[k])``.  A nonlinear
    :func:`control.sample_system`; for a linear system python-control's exact ``sample_system(sys, dt, "zoh")``
    is the better choice.

    Parameters
    ----------
    sys : control.NonlinearIOSystem
        A continuous-time system (``sys.dt == 0``): an fsmctl spacecraft, reference generator or wheel-equipped
        spacecraft, or any python-control system with states.
    dt : float
        The sampling period ``T`` (s, > 0): the discrete-time system's ``dt``.
    step : float, optional
        The RK4 step (s); ``dt`` must be a multiple of it.  Default ``dt`` (one step per period); pass the
        scenario's ``simulation.dt`` to advance the state as :func:`fsmctl.simulate` does.
    name : str, optional
        Name of the sampled system; default python-control's sampled name (``sys.name + "$sampled"``).

    Returns
    -------
    control.NonlinearIOSystem
        Discrete time with ``dt``; the inputs, outputs and states of ``sys``.  An fsmctl system stays a
        :class:`fsmctl.plugin.iosys.ParameterizedSystem` with the same parameters (keyed by the new name) and the
        same checks (a state with ``q = 0`` is refused); another system keeps its ``params``.

    Raises
    ------
    fsmctl.ScenarioError
        ``sys`` not a continuous-time python-control system with states, a bad ``dt`` (``True`` has no period),
        ``step`` or ``name``.

    Examples
    --------
    A spacecraft spun up by a held torque of 1 N m about z (J = I): after one period of 0.1 s, omega_z = 0.1 rad/s.

    >>> import numpy as np, fsmctl
    >>> from fsmctl.plugin.sampled import zoh
    >>> from fsmctl.plugin.iosys import quaternion_from_mrp
    >>> sc = zoh(fsmctl.spacecraft(np.eye(3), name="sc"), 0.1, step=0.01, name="sc")
    >>> sc.dt, sc.state_labels[4:]
    (0.1, ['omega[0]', 'omega[1]', 'omega[2]'])
    >>> x0 = np.concatenate([quaternion_from_mrp([0.0, 0.0, 0.0]), np.zeros(3)])
    >>> sc.dynamics(0.0, x0, [0.0, 0.0, 1.0])[4:].round(12).tolist()
    [0.0, 0.0, 0.1]
    """
    call = (zoh, {"sys": sys, "dt": dt, "step": step, "name": name})
    where = "zoh"
    if not isinstance(sys, ct.NonlinearIOSystem):
        raise ScenarioError(f"{where}: expected a python-control system, got {type(sys).__name__}")
    if not sys.isctime(strict=True):
        raise ScenarioError(f"{where}: system {sys.name!r} is not continuous time (dt = {sys.dt})")
    if not sys.nstates:
        raise ScenarioError(
            f"{where}: system {sys.name!r} has no states: a static system needs no hold (make it with the "
            "discrete dt directly)"
        )
    T = _period(dt, where)
    n = _substeps(T, step, where)
    name = _system_name(name, where) or _default_name(sys)
    if isinstance(sys, ParameterizedSystem):
        model = sys._model_update

        def update(t, x, u, p):
            return _rk4(lambda s, y: np.asarray(model(s, y, u, p), dtype=float), t, x, T, n)

        return _parameterized_twin(sys, update, name, T, call)

    inner = sys.copy(name=sys.name, use_prefix_suffix=False)

    def generic_update(t, x, u, params):
        return _rk4(lambda s, y: inner.dynamics(s, y, u, params=params), t, x, T, n)

    sampled = ct.nlsys(
        generic_update,
        lambda t, x, u, params: inner.output(t, x, u, params=params),
        inputs=list(sys.input_labels),
        outputs=list(sys.output_labels),
        states=list(sys.state_labels),
        params=dict(sys.params),
        dt=T,
        name=name,
    )
    return _rebuilt(sampled, call)


def _discrete(ctrl: ParameterizedSystem, T: float) -> ParameterizedSystem:
    """The law controller ``ctrl`` as the flight software runs it at the period ``T``: outputs at the instant, the
    law's states advanced by the rate of the instant held over the period (``z[k+1] = z[k] + T z_dot(t_k)``, what
    the compiled loop's RK4 does with a held rate)."""
    rate = ctrl._model_update
    update = None if rate is None else (lambda t, x, u, p: np.asarray(x, dtype=float) + T * rate(t, x, u, p))
    return _parameterized_twin(ctrl, update, ctrl.name, T, (_discrete, {"ctrl": ctrl, "T": T}))


def _led(neighbours: Any, lead: float) -> Any:
    """The neighbours with their schedules read ``lead`` seconds later (left unchecked: the factory checks)."""
    if isinstance(neighbours, Sequence) and not isinstance(neighbours, (str, bytes)):
        return [
            Neighbour(nb.name, nb.k_i, nb.k_j, nb.phase + lead) if isinstance(nb, Neighbour) else nb
            for nb in neighbours
        ]
    return neighbours


def discrete_law_controller(
    law: LawCode | str,
    J0,
    *,
    dt: float,
    parameters: Mapping[str, Any] | None = None,
    u_max: float = math.inf,
    error_model: str = "paper",
    neighbours: Sequence[Neighbour] = (),
    name: str | None = None,
    actuator: Any = None,
) -> ParameterizedSystem:
    """One agent's control law as a discrete-time system (sampled control at the period ``dt``).

    The system of :func:`fsmctl.plugin.iosys.law_controller` (same signals, parameters and generated code) run as
    the compiled simulator runs a law with ``simulation.control_period = dt``: at each instant ``t_k`` the torque
    and the broadcast from the signals of that instant, and the law's states (an integral, an adaptive gain)
    advanced by their rate at ``t_k`` held over the period, ``z[k+1] = z[k] + dt z_dot(t_k)``.  The coupling
    weights ``k^j_ij`` are held over the period at their value just after ``t_k`` (the schedules' segments are
    left-closed; they are read at ``t_k + 1e-6 dt`` so that a switch at an instant is not missed by the rounding
    of ``t_k``).

    Parameters
    ----------
    law, J0, parameters, u_max, error_model, neighbours, name, actuator
        As :func:`fsmctl.plugin.iosys.law_controller` (``actuator``: the wheel array of a law that commands its
        wheels; the system then has the wheel speeds ``Omega[k]`` as inputs and the commands ``u_wheels[k]``, held
        over the period, as outputs).
    dt : float
        The control period (s, > 0): python-control's ``dt`` of the system.

    Returns
    -------
    ParameterizedSystem
        Discrete time, ``dt``; the inputs, outputs, states and parameters of ``law_controller``.

    Raises
    ------
    fsmctl.ScenarioError
        A bad ``dt`` (``True`` has no period) or an argument ``law_controller`` refuses.

    Examples
    --------
    The ``pid`` law's integral state at 10 Hz: one period adds ``0.1`` times its rate at the instant.

    >>> import numpy as np, fsmctl
    >>> from fsmctl.plugin.sampled import discrete_law_controller
    >>> ctrl = discrete_law_controller("pid", np.eye(3), dt=0.1, name="c")
    >>> ctrl.dt, ctrl.state_labels
    (0.1, ['int_sigma[0]', 'int_sigma[1]', 'int_sigma[2]'])
    >>> u = np.concatenate([[0.1, 0.0, 0.0], np.zeros(12)])  # sigma = (0.1, 0, 0), everything else 0
    >>> rate = fsmctl.law_controller("pid", np.eye(3), name="c").dynamics(0.0, np.zeros(3), u)
    >>> bool(np.array_equal(ctrl.dynamics(0.0, np.zeros(3), u), 0.1 * rate)), bool(rate[0] > 0)
    (True, True)
    """
    T = _period(dt, "discrete_law_controller")
    ctrl = law_controller(
        law,
        J0,
        parameters=parameters,
        u_max=u_max,
        error_model=error_model,
        neighbours=_led(neighbours, _INSTANT_LEAD * T),
        name=name,
        actuator=actuator,
    )
    return _discrete(ctrl, T)


def discrete_fsm_controller(
    J0,
    controller: ControllerSettings,
    delta: Sequence[float],
    *,
    dt: float,
    neighbours: Sequence[Neighbour] = (),
    name: str | None = None,
) -> ParameterizedSystem:
    """The paper's fast-sliding-mode law (eqs 13, 16-19) as a discrete-time system (sampled control at ``dt``).

    :func:`fsmctl.plugin.iosys.fsm_controller` run as :func:`discrete_law_controller` runs a law: the torque and
    the sliding variable ``s`` of each instant, held over the period.

    Parameters
    ----------
    J0, controller, delta, neighbours, name
        As :func:`fsmctl.plugin.iosys.fsm_controller`.
    dt : float
        The control period (s, > 0).

    Returns
    -------
    ParameterizedSystem
        Static, discrete time with ``dt``; the signals and parameters of ``fsm_controller``.

    Raises
    ------
    fsmctl.ScenarioError
        A bad ``dt`` or an argument ``fsm_controller`` refuses.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.plugin.sampled import discrete_fsm_controller
    >>> paper = fsmctl.paper_scenario("1")
    >>> ctrl = discrete_fsm_controller(paper.agents[0].J0_array, paper.controller, [0.005] * 3, dt=0.1, name="c1")
    >>> ctrl.dt, ctrl.nstates, ctrl.output_labels[:3]
    (0.1, 0, ['tau[0]', 'tau[1]', 'tau[2]'])
    """
    T = _period(dt, "discrete_fsm_controller")
    ctrl = fsm_controller(J0, controller, delta, neighbours=_led(neighbours, _INSTANT_LEAD * T), name=name)
    return _discrete(ctrl, T)
