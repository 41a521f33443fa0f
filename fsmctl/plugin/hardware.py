"""python-control plug-in: the flight hardware (reaction wheels, star tracker, rate gyro, imperfect link) as systems.

Each factory returns a :class:`control.NonlinearIOSystem` a user wires into :func:`control.interconnect` with the
systems of :mod:`fsmctl.plugin.iosys`, and each evaluates the generated functions the compiled simulator flies
(:mod:`fsmctl.symbolic.hardware`): ``gyrostat_rhs``, ``wheel_torque``, ``wheel_acceleration`` and
``sensor_measurement``; the torque distribution is :func:`fsmctl.model.actuators.distribute` and the noise is
:func:`fsmctl.model.noise.hardware_noise`, drawn from the seed the way :func:`fsmctl.simulate` draws it.

* :func:`reaction_wheel_spacecraft`: a rigid hub with balanced reaction wheels (continuous time).  Its input is
  the body torque the law asks for; the plant distributes it to the wheels continuously, so a sampled law (the
  compiled loop holds the wheel commands over each control period) is a held input.
* :func:`star_tracker`, :func:`rate_gyro`: the measurement of each sample instant ``t_q = q period`` (discrete
  time, ``dt = period``; or, with ``dt=0``, continuous time with each sample's noise held until the next; ``dt``
  means what it means to python-control).
* :func:`link`: one communication link's delay and packet loss (discrete time), the rule of the compiled loop.

Parameters follow :class:`fsmctl.plugin.iosys.ParameterizedSystem` (keys ``f"{name}_J"``, ... and an owner tag);
the sensors and the link carry no parameters (their noise is drawn when they are made).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import casadi as ca
import control as ct
import numpy as np

from fsmctl.errors import InputError
from fsmctl.model.actuators import distribute, distribution_matrix, hub_inertia_problem, spin_inertia_matrix
from fsmctl.model.attitude import mrp_of_quaternion_expression, quaternion_from_mrp, quaternion_rate_expression
from fsmctl.model.scenario import ActuatorSettings, ScenarioError, Sinusoid
from fsmctl.plugin.arguments import (
    _inertia,
    _labels,
    _numbers,
    _scalar,
    _show,
    _signal_names,
    _sinusoid,
    _system_name,
    _twelve,
)
from fsmctl.plugin.iosys import DEFAULT_NORMALIZATION_GAIN
from fsmctl.plugin.jacobians import _Generated
from fsmctl.plugin.parameters import _factory_call, _finish, _rebuilt
from fsmctl.plugin.system import ParameterizedSystem, _FlatCall

__all__ = [
    "reaction_wheel_spacecraft",
    "reaction_wheel_state",
    "star_tracker",
    "rate_gyro",
    "link",
]


# ----------------------------------------------------------------------------- reaction wheels

_WHEEL_VECTORS = ("spin_inertia", "max_torque", "max_speed", "viscous_friction", "coulomb_friction")
"""Per-wheel settings of :class:`ActuatorSettings` that are parameters of the plant (one value per wheel)."""


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


def _read_only(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


def _check_hub_inertia(J: np.ndarray, J_spin: np.ndarray, where: str) -> None:
    """``J - J_spin`` (the hub's inertia without the wheels' spin) must be positive definite."""
    problem = hub_inertia_problem(J, J_spin)
    if problem:
        raise ScenarioError(f"{where}: the wheels' spin inertia exceeds the spacecraft's: {problem}")


class _WheelArray:
    """Quantities derived from the plant's checked parameters, recomputed only when one of them changes."""

    def __init__(self, where: str):
        self._where = where
        self._key: tuple = ()

    def __call__(self, p: Mapping[str, Any]) -> _WheelArray:
        key = (p["J"], p["axes"], *(p[k] for k in _WHEEL_VECTORS), p["coulomb_band"])
        if len(key) == len(self._key) and all(a is b for a, b in zip(key, self._key, strict=True)):
            return self
        G, Js = p["axes"], p["spin_inertia"]
        J_spin = spin_inertia_matrix(G, Js)
        _check_hub_inertia(p["J"], J_spin, self._where)
        self.J_spin = J_spin
        self.pinv = distribution_matrix(G)
        self.max_torque = p["max_torque"]
        n = G.shape[1]
        # the generated layout [speed_max, viscous, coulomb, coulomb_band], one column per wheel
        self.wheel = np.stack(
            [p["max_speed"], p["viscous_friction"], p["coulomb_friction"], np.full(n, p["coulomb_band"])]
        )
        self._key = key
        return self


def reaction_wheel_spacecraft(
    J,
    actuator: ActuatorSettings | Mapping[str, Any],
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
    """A rigid hub with balanced reaction wheels (Schaub & Junkins eq 4.146) as a python-control system.

    The compiled simulator's wheel plant (``actuator.kind = "reaction_wheels"``), evaluating its generated
    functions: the body-torque command ``u_command`` is distributed to the wheels by
    :func:`fsmctl.model.actuators.distribute` (minimum norm, all wheel torques scaled by one factor when a wheel
    would exceed ``max_torque``); each wheel's motor torque after the speed limit and its net torque with friction
    come from ``wheel_torque``; the hub from ``gyrostat_rhs`` (``(J - J_spin) omega_dot = -omega x (J omega +
    h_wheels) - tau_wheels + L``, ``L`` the external torque); the wheel speeds from ``wheel_acceleration``.  The attitude is integrated as
    Euler parameters with the normalisation-drift control of :func:`fsmctl.plugin.iosys.spacecraft`.

    The distribution acts continuously on the input: the compiled loop computes the wheel commands at the
    control instants and holds them, which is this plant with a held (piecewise-constant) ``u_command``.

    Parameters
    ----------
    J : array_like, shape (3, 3)
        Inertia of the whole spacecraft, wheels included (kg m^2): finite, symmetric positive definite, and
        ``J - J_spin`` positive definite (``J_spin = sum_k J_s,k g_k g_k^T``).
    actuator : ActuatorSettings or mapping
        The wheel array (``kind = "reaction_wheels"``; a mapping is read as :class:`ActuatorSettings` with that
        kind by default): spin axes, spin inertia, torque and speed limits, friction.  Its ``initial_speed`` is
        not used here: the initial state is given to :func:`control.input_output_response`
        (:func:`reaction_wheel_state` builds it).
    disturbance : Sinusoid, optional
        Disturbance torque ``d(t)`` (N m), as in :func:`fsmctl.plugin.iosys.spacecraft`; none by default.  The
        external torque is ``L = d(t) + `` the input ``d``.
    normalization_gain : float
        ``k`` >= 0 (1/s) of the quaternion normalisation-drift control; it does not change the attitude.
    name : str, optional
        System name (no ``'.'``); default python-control's unique ``sys[<id>]``.

    inputs, outputs, states : int, str or list of str, optional
        New signal names (python-control's forms; their number must be the system's); default the names below.
    params : mapping, optional
        Initial parameter values, by local name (``"max_torque"``) or key, validated like the arguments (they win).
    dt : 0 or None
        python-control's timebase: this is a continuous-time system (``None``, unspecified, is taken as 0); a
        discrete ``dt`` raises (sample the loop instead, the plug-in guide's "Sampled-data loops").

    Returns
    -------
    ParameterizedSystem
        States ``q[0..3]`` (Euler parameters, scalar first, N -> B), ``omega[0..2]`` (rad/s, body frame),
        ``Omega[0..N-1]`` (wheel speeds relative to the hub, rad/s).  Inputs ``u_command[0..2]`` (the body torque
        the law asks for, N m) and ``d[0..2]`` (external torque added to the ``disturbance``, N m).  Outputs ``sigma[0..2]`` (MRP,
        ``|sigma| <= 1``), ``omega[0..2]``, ``Omega[0..N-1]``, ``tau[0..2]`` (the wheels' reaction on the body,
        ``-sum_k u_net,k g_k``, N m), ``h_wheels[0..2]`` (``sum_k J_s,k Omega_k g_k``, N m s) and
        ``wheel_torque[0..N-1]`` (motor torques after the speed limit, N m: the compiled result's
        ``wheel_torque``).  Parameters ``f"{name}_J"``, ``_axes`` (3 x N unit columns), ``_spin_inertia``,
        ``_max_torque``, ``_max_speed``, ``_viscous_friction``, ``_coulomb_friction`` (N each),
        ``_coulomb_band``, ``_disturbance`` (12: amplitude, frequency, phase, offset) and the owner tag.

    Raises
    ------
    fsmctl.ScenarioError
        A bad ``J``, ``actuator`` (invalid, or not reaction wheels), a hub inertia ``J - J_spin`` that is not
        positive definite, a bad ``disturbance``, ``normalization_gain`` or ``name`` (one line, an :class:`fsmctl.errors.InputError`).

    Notes
    -----
    Without external torque the total angular momentum ``[NB]^T (J omega + h_wheels)`` is constant (friction and motor
    torques are internal).  The speed limit switches a wheel's motor off: an adaptive solver resolves the switch
    by shrinking its steps.

    Examples
    --------
    >>> import control as ct, numpy as np
    >>> from fsmctl.plugin.hardware import reaction_wheel_spacecraft, reaction_wheel_state
    >>> wheels = {"layout": "orthogonal", "spin_inertia": 0.05, "max_torque": 0.1}
    >>> sc = reaction_wheel_spacecraft(np.diag([100.0, 150.0, 200.0]), wheels, name="sc")
    >>> sc.state_labels[7:], sc.output_labels[9:12]
    (['Omega[0]', 'Omega[1]', 'Omega[2]'], ['tau[0]', 'tau[1]', 'tau[2]'])
    >>> x0 = reaction_wheel_state(sc, sigma0=[0.1, 0.0, 0.0])
    >>> (sc.output(0.0, x0, [0.0, 0.0, 0.5, 0, 0, 0])[9:12].round(12) + 0.0).tolist()  # asks 0.5 N m, gets max_torque
    [0.0, 0.0, 0.1]
    >>> U = np.zeros((6, 2))
    >>> U[2] = 0.05  # 0.05 N m about z for 10 s, taken from the wheels
    >>> r = ct.input_output_response(sc, [0.0, 10.0], U, x0)
    >>> round(float(r.outputs[5, -1]), 9)  # the hub's rate: 0.5 N m s / (J_z - J_s)
    0.002500625
    >>> bool(abs(200.0 * r.outputs[5, -1] + r.outputs[14, -1]) < 1e-12)  # the total momentum J omega + h is kept
    True
    """
    call = _factory_call(reaction_wheel_spacecraft, locals())
    name = _system_name(name, "reaction_wheel_spacecraft")
    where = f"reaction_wheel_spacecraft {name!r}" if name else "reaction_wheel_spacecraft"
    J = _inertia(J, f"{where}: J")
    act = _actuator(actuator, where)
    gain = _scalar(normalization_gain, f"{where}: normalization_gain", minimum=0.0)
    G = _read_only(act.spin_axes())
    n = G.shape[1]
    values: dict[str, Any] = {"J": J, "axes": G}
    values.update({k: _read_only(act.per_wheel(k)) for k in _WHEEL_VECTORS})
    values["coulomb_band"] = float(act.coulomb_band)
    values["disturbance"] = np.zeros(12) if disturbance is None else _sinusoid(disturbance, f"{where}: disturbance")
    values["disturbance"].setflags(write=False)
    validators = {
        "J": _inertia,
        "axes": _axes_check(n),
        "spin_inertia": _per_wheel_check(n, positive=True, inf=False),
        "max_torque": _per_wheel_check(n, positive=True, inf=True),
        "max_speed": _per_wheel_check(n, positive=True, inf=True),
        "viscous_friction": _per_wheel_check(n, positive=False, inf=False),
        "coulomb_friction": _per_wheel_check(n, positive=False, inf=False),
        "coulomb_band": lambda v, w: _scalar(v, w, minimum=0.0),
        "disturbance": _twelve,
    }
    derived = _WheelArray(where)
    derived(values)  # the hub-inertia check at construction

    torque = _Generated("wheel_torque")
    accel = _Generated("wheel_acceleration")
    gyrostat = _Generated("gyrostat_rhs")
    dist = _Generated("disturbance_torque")
    zero3 = ca.DM.zeros(3, 1)  # gyrostat_rhs's sigma_dot is not used: the attitude is integrated as q

    def wheels(Om, uw, G, Js, W):
        pairs = [torque(uw[k], Om[k], W[:, k]) for k in range(n)]
        motor = ca.vertcat(*[m for m, _ in pairs])
        net = ca.vertcat(*[u for _, u in pairs])
        # the wheels' momentum relative to the hub and the torques on them (formation.c wheel_torques)
        return motor, net, ca.mtimes(G, Js * Om), ca.mtimes(G, net)

    def rhs_graph(t, x, uw, d, dp, J, J_spin, G, Js, W):
        q, omega, Om = x[:4], x[4:7], x[7:]
        _, net, h, tau_w = wheels(Om, uw, G, Js, W)
        omega_dot = gyrostat(zero3, omega, h, tau_w, d + dist(t, dp), J, J_spin)[1]
        Om_dot = ca.vertcat(*[accel(G[:, k], Js[k], net[k], omega_dot) for k in range(n)])
        return [quaternion_rate_expression(q, omega, gain), omega_dot, Om_dot]

    def out_graph(x, uw, G, Js, W):
        q, omega, Om = x[:4], x[4:7], x[7:]
        motor, _, h, tau_w = wheels(Om, uw, G, Js, W)
        return [mrp_of_quaternion_expression(q), omega, Om, -tau_w, h, motor]

    x_u, wheel_arrays = [(7 + n, 1), (n, 1)], [(3, n), (n, 1), (4, n)]
    rhs = _FlatCall(rhs_graph, [(1, 1), *x_u, (3, 1), (12, 1), (3, 3), (3, 3), *wheel_arrays], "reaction_wheel_rhs")
    out = _FlatCall(out_graph, [*x_u, *wheel_arrays], "reaction_wheel_out")

    def commands(u, a: _WheelArray) -> np.ndarray:
        return distribute(u[:3], a.pinv, a.max_torque)[0]

    # the exact Jacobian: the distribution's rule as a graph (its derivative and switches), chained into the plant's
    dist_graph = _FlatCall(lambda u, P, m: [_distribution_graph(u, P, m)], [(3, 1), (n, 3), (n, 1)], "wheel_dist")
    state_names = _signal_names(states, _labels("q", 4) + _labels("omega") + _labels("Omega", n), "states", where)
    wheel_labels = _labels("u_wheel", n)

    def jacobian(t, x, u, p):
        a = derived(p)
        uw = commands(u, a)
        (du,) = dist_graph.jacobian(u[:3], a.pinv, a.max_torque, wrt=(0,), labels=(_labels("u_command"),))
        A, B_w, B_d = rhs.jacobian(
            t,
            x,
            uw,
            u[3:6],
            p["disturbance"],
            p["J"],
            a.J_spin,
            p["axes"],
            p["spin_inertia"],
            a.wheel,
            wrt=(1, 2, 3),
            labels=(state_names, wheel_labels, _labels("d")),
        )
        C, D_w = out.jacobian(
            x, uw, p["axes"], p["spin_inertia"], a.wheel, wrt=(0, 1), labels=(state_names, wheel_labels)
        )
        return A, np.hstack([B_w @ du, B_d]), C, np.hstack([D_w @ du, np.zeros((C.shape[0], 3))])

    def update(t, x, u, p):
        a = derived(p)
        uw = commands(u, a)
        return rhs(t, x, uw, u[3:6], p["disturbance"], p["J"], a.J_spin, p["axes"], p["spin_inertia"], a.wheel)

    def output(t, x, u, p):
        a = derived(p)
        return out(x, commands(u, a), p["axes"], p["spin_inertia"], a.wheel)

    output_labels = (
        _labels("sigma") + _labels("omega") + _labels("Omega", n) + _labels("tau") + _labels("h_wheels")
    ) + _labels("wheel_torque", n)

    # the MRP-state model (gyrostat_rhs's own kinematics) for fsmctl.plugin.mrp_linearization
    def mrp_graph(t, x, uw, d, dp, J, J_spin, G, Js, W):
        sigma, omega, Om = x[:3], x[3:6], x[6:]
        _, net, h, tau_w = wheels(Om, uw, G, Js, W)
        sigma_dot, omega_dot = gyrostat(sigma, omega, h, tau_w, d + dist(t, dp), J, J_spin)
        Om_dot = ca.vertcat(*[accel(G[:, k], Js[k], net[k], omega_dot) for k in range(n)])
        return [sigma_dot, omega_dot, Om_dot]

    mrp_rhs = _FlatCall(
        mrp_graph, [(1, 1), (6 + n, 1), (n, 1), (3, 1), (12, 1), (3, 3), (3, 3), *wheel_arrays], "wheel_mrp_rhs"
    )
    mrp_states = _labels("sigma") + _labels("omega") + _labels("Omega", n)

    def mrp_jacobian(t, x, u, p):
        a = derived(p)
        uw = commands(u, a)
        (du,) = dist_graph.jacobian(u[:3], a.pinv, a.max_torque, wrt=(0,), labels=(_labels("u_command"),))
        A, B_w = mrp_rhs.jacobian(
            t,
            x,
            uw,
            u[3:6],
            p["disturbance"],
            p["J"],
            a.J_spin,
            p["axes"],
            p["spin_inertia"],
            a.wheel,
            wrt=(1, 2),
            labels=(mrp_states, wheel_labels),
        )
        return A, B_w @ du

    system = ParameterizedSystem(
        "reaction_wheel_spacecraft",
        update,
        output,
        values,
        validators,
        inputs=_signal_names(inputs, _labels("u_command") + _labels("d"), "inputs", where),
        outputs=_signal_names(outputs, output_labels, "outputs", where),
        states=state_names,
        name=name,
        attitude=True,
        jacobian=jacobian,
    )
    system._mrp_model = (mrp_jacobian, mrp_states, _labels("u_command"), 6)
    return _finish(system, call, params, dt)


def _distribution_graph(u, P, m):
    """:func:`fsmctl.model.actuators.distribute`'s wheel torques as a CasADi graph (for its derivative):
    ``u_w* = -P u``, divided by ``max(1, max_i |u_w*_i| / max_torque_i)``."""
    uw = -ca.mtimes(P, u)
    r = ca.DM(0.0)
    for i in range(uw.shape[0]):
        r = ca.fmax(r, ca.fabs(uw[i]) / m[i])
    return uw / ca.fmax(1.0, r)


def reaction_wheel_state(plant: ct.NonlinearIOSystem, sigma0=(0.0, 0.0, 0.0), omega0=(0.0, 0.0, 0.0), Omega0=None):
    """The state vector ``[q, omega, Omega]`` of a :func:`reaction_wheel_spacecraft` from an MRP, a rate and the
    wheel speeds (default zero).

    Parameters
    ----------
    plant : ParameterizedSystem
        A system made by :func:`reaction_wheel_spacecraft` (its number of wheels ``N`` sizes ``Omega0``).
    sigma0 : array_like, shape (3,)
        Initial attitude, MRP of N -> B (any set: converted to Euler parameters).
    omega0 : array_like, shape (3,)
        Initial body rate (rad/s).
    Omega0 : array_like, shape (N,), optional
        Initial wheel speeds relative to the hub (rad/s); zero by default.

    Returns
    -------
    numpy.ndarray, shape (7 + N,)
        ``[q[0..3], omega[0..2], Omega[0..N-1]]``, the plant's state order.

    Raises
    ------
    fsmctl.ScenarioError
        ``plant`` is not a wheel plant, or a vector has the wrong length or a value that is not a finite number.

    Examples
    --------
    >>> import numpy as np
    >>> from fsmctl.plugin.hardware import reaction_wheel_spacecraft, reaction_wheel_state
    >>> sc = reaction_wheel_spacecraft(np.diag([100.0, 150.0, 200.0]), {"layout": "pyramid"})
    >>> reaction_wheel_state(sc, [0.0, 0.0, 1.0], Omega0=[10.0, 0, 0, 0]).round(12).tolist()
    [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 10.0, 0.0, 0.0, 0.0]
    """
    if not isinstance(plant, ParameterizedSystem) or plant._kind != "reaction_wheel_spacecraft":
        raise ScenarioError(f"reaction_wheel_state: expected a reaction_wheel_spacecraft, got {_show(plant)}")
    n = plant.nstates - 7
    where = f"reaction_wheel_state {plant.name!r}"
    sigma = _numbers(sigma0, (3,), "three real numbers", f"{where}: sigma0")
    omega = _numbers(omega0, (3,), "three real numbers", f"{where}: omega0")
    Om = np.zeros(n) if Omega0 is None else _numbers(Omega0, (n,), f"{n} real numbers", f"{where}: Omega0")
    return np.concatenate([quaternion_from_mrp(sigma), omega, Om])


# ----------------------------------------------------------------------------- sampled noise


def _count(value: Any, where: str, minimum: int) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ScenarioError(f"{where}: expected an integer, got {_describe(value)}")
    if value < minimum:
        raise ScenarioError(f"{where}: must be >= {minimum}, got {int(value)}")
    return int(value)


def _describe(value: Any) -> str:
    return f"{_show(value)} ({type(value).__name__})"


def _timebase(dt: Any, period: float, where: str, *, stateful: bool = False) -> float | None:
    """The system's ``dt`` in python-control's meaning: ``0`` continuous time (the samples held), ``None``
    unspecified (a static sensor's held samples are right in either timebase; a link, which has discrete states,
    is discrete), ``True`` or ``period`` discrete time with ``dt = period``; another period is refused."""
    if dt is None and not stateful:
        return None
    if dt is None or dt is True or (isinstance(dt, np.bool_) and bool(dt)):
        return period
    if isinstance(dt, (bool, np.bool_)) or not isinstance(dt, (int, float, np.integer, np.floating)):
        raise ScenarioError(f"{where}: dt: expected None, True, 0 or the period {period}, got {_show(dt)}")
    if dt == 0 and not stateful:
        return 0
    if dt > 0 and math.isclose(float(dt), period, rel_tol=1e-9, abs_tol=0.0):
        return period
    accepted = "None, True or the period" if stateful else "None, True, 0 or the period"
    raise ScenarioError(
        f"{where}: dt = {_show(dt)}: expected {accepted} {period} (python-control's dt: a sensor sampled every "
        f"{period} s is discrete time with that period)"
    )


class _Samples:
    """A table of ``Q`` samples at the instants ``t_q = q period`` and the rule that reads it at a time ``t``.

    Discrete time: ``q = round(t / period)``, ``t`` must be an instant.  Continuous time: the latest instant at or
    before ``t`` (``floor``, forgiving float rounding of an instant), the sample held until the next.
    """

    def __init__(self, table: np.ndarray, period: float, held: bool, where: str):
        self.table = table
        self.table.setflags(write=False)
        self.period = period
        self.held = held
        self.where = where

    @property
    def horizon(self) -> float:
        return (self.table.shape[0] - 1) * self.period

    def index(self, t: float) -> int:
        x = float(t) / self.period
        q = math.floor(x + 1e-9 * max(1.0, abs(x))) if self.held else round(x)
        if not self.held and abs(x - q) > 1e-9 * max(1.0, abs(x)):
            raise InputError(f"{self.where}: t = {float(t)} s is not a sample instant (a multiple of {self.period} s)")
        if q < 0 or q >= self.table.shape[0]:
            raise InputError(
                f"{self.where}: t = {float(t)} s is outside the drawn samples [0, {self.horizon}] s (make the "
                "system with a longer horizon)"
            )
        return q

    def __call__(self, t: float) -> np.ndarray:
        return self.table[self.index(t)]


def _samples(horizon: Any, period: Any, where: str) -> tuple[float, int]:
    """The period and the number of instants ``Q = floor(horizon / period) + 1`` (that of the compiled loop)."""
    period = _scalar(period, f"{where}: period", minimum=0.0, strict=True)
    horizon = _scalar(horizon, f"{where}: horizon", minimum=0.0)
    x = horizon / period
    return period, math.floor(x + 1e-9 * max(1.0, x)) + 1


def _noise(where: str, **kwargs) -> dict[str, np.ndarray]:
    from fsmctl.model.noise import hardware_noise

    try:
        return hardware_noise(**kwargs)
    except ValueError as exc:  # a value only the noise module refuses
        raise ScenarioError(f"{where}: {exc}") from None


def _sensor(kind: str, name: str | None, noise_std=None, gyro=None, *, period, horizon, seed, agent, dt):
    name = _system_name(name, kind)
    where = f"{kind} {name!r}" if name else kind
    period, Q = _samples(horizon, period, where)
    seed = _count(seed, f"{where}: seed", 0)
    agent = _count(agent, f"{where}: agent", 0)
    timebase = _timebase(dt, period, where)
    held = timebase != period  # continuous or unspecified time: the latest sample at or before t
    common = {"seed": seed, "n_agents": agent + 1, "n_samples": Q, "period": period}
    measure = _Generated("sensor_measurement")
    zero3 = np.zeros(3)
    if kind == "star_tracker":
        table = _noise(where, star_tracker_std=noise_std, **common)["dtheta"][:, agent].copy()
        call = _FlatCall(lambda u, n: [measure(u, zero3, n, zero3)[0]], [(3, 1), (3, 1)], "star_tracker_out")
        inputs, outputs = _labels("sigma"), _labels("sigma_measured")
    else:
        table = _noise(where, gyro=gyro, **common)["gyro_error"][:, agent].copy()
        call = _FlatCall(lambda u, n: [measure(zero3, u, zero3, n)[1]], [(3, 1), (3, 1)], "rate_gyro_out")
        inputs, outputs = _labels("omega"), _labels("omega_measured")
    samples = _Samples(table, period, held, where)
    sys = ct.nlsys(
        None,
        lambda t, x, u, p: call(u, samples(t)),
        inputs=inputs,
        outputs=outputs,
        dt=timebase,
        name=name,
    )
    sys.samples = samples.table  # the drawn noise of the instants 0 .. Q-1 (read-only)
    return sys


def star_tracker(
    noise_std,
    period: float,
    *,
    horizon: float,
    seed: int = 0,
    agent: int = 0,
    dt: float | bool | None = True,
    name: str | None = None,
) -> ct.NonlinearIOSystem:
    """A star tracker: the attitude rotated by a small random body-frame rotation at each sample instant.

    ``sigma_measured = compose(dtheta_q / 4, sigma)`` (the generated ``sensor_measurement``; small-angle form, shadow
    set) with ``dtheta_q`` drawn by :func:`fsmctl.model.noise.hardware_noise` from ``seed`` for the star tracker of
    agent ``agent``: the noise :func:`fsmctl.simulate` applies to that agent at the control instant ``q`` of a
    run with ``simulation.seed = seed`` and ``control_period = period`` (whatever the number of agents and the
    other sensors: each has its own stream).

    Parameters
    ----------
    noise_std : array_like, shape (3,)
        Per-axis standard deviation of the rotation noise about body x, y, z (rad, >= 0).
    period : float
        Sample period ``T`` (s, > 0): the control period of the loop.
    horizon : float
        Time (s, >= 0) up to which noise is drawn: the instants ``t_q = q T``, ``q = 0 .. floor(horizon / T)``.
    seed : int
        The run's seed (``simulation.seed``, >= 0).
    agent : int
        Index (0-based, >= 0) of the agent whose noise stream is used.
    dt : {True, period, 0, None}
        python-control's timebase.  ``True`` (default) or the period itself: a discrete-time system with
        ``dt = period`` (evaluated at the instants; for the sampled-data loops of :mod:`fsmctl.plugin.sampled`).
        ``0``: a continuous-time system that applies the noise of the latest instant at or before ``t`` (for
        :func:`control.interconnect` with the continuous-time plants and laws of :mod:`fsmctl.plugin`).
        ``None``: unspecified (``sys.dt is None``), the same held rule, which is right in either timebase.
        Another period is refused.
    name : str, optional
        System name; default python-control's unique ``sys[<id>]``.

    Returns
    -------
    control.NonlinearIOSystem
        Static; input ``sigma[0..2]`` (true MRP), output ``sigma_measured[0..2]`` (``|sigma_measured| <= 1``).
        Attribute ``samples``: the drawn ``dtheta`` of the instants, ``(Q, 3)`` rad.  Evaluating it at a time
        outside ``[0, horizon]`` (or, in discrete time, not at an instant) raises :class:`fsmctl.errors.InputError`.

    Raises
    ------
    fsmctl.ScenarioError
        A bad ``noise_std``, ``period``, ``horizon``, ``seed``, ``agent``, ``dt`` or ``name`` (one line).

    Examples
    --------
    >>> import control as ct, numpy as np
    >>> from fsmctl.plugin.hardware import star_tracker
    >>> st = star_tracker([1e-4, 1e-4, 2e-4], 0.1, horizon=1.0, seed=3, name="st")
    >>> st.dt, st.samples.shape
    (0.1, (11, 3))
    >>> r = ct.input_output_response(st, np.arange(11) * 0.1, np.zeros((3, 11)))
    >>> bool(np.allclose(4 * r.outputs.T, st.samples, rtol=1e-12, atol=0))  # at identity: dtheta / 4
    True
    """
    call = _factory_call(star_tracker, locals())
    name = _system_name(name, "star_tracker")
    where = f"star_tracker {name!r}" if name else "star_tracker"
    std = _numbers(noise_std, (3,), "three real numbers", f"{where}: noise_std")
    if np.any(std < 0):
        raise ScenarioError(f"{where}: noise_std: must be >= 0, got {std.tolist()}")
    sensor = _sensor("star_tracker", name, noise_std=std, period=period, horizon=horizon, seed=seed, agent=agent, dt=dt)
    return _rebuilt(sensor, call)


def rate_gyro(
    angle_random_walk: float,
    rate_random_walk: float,
    bias,
    period: float,
    *,
    horizon: float,
    seed: int = 0,
    agent: int = 0,
    dt: float | bool | None = True,
    name: str | None = None,
) -> ct.NonlinearIOSystem:
    """A rate gyro: the body rate plus Farrenkopf's error (bias, bias random walk, white noise) at each instant.

    ``omega_measured = omega + error_q`` (the generated ``sensor_measurement``) with ``error_q`` drawn by
    :func:`fsmctl.model.noise.hardware_noise` from ``seed`` for the gyro of agent ``agent``: the error
    :func:`fsmctl.simulate` applies to that agent at control instant ``q`` (``simulation.seed = seed``,
    ``control_period = period``, :class:`fsmctl.model.scenario.GyroSettings` with these values).

    Parameters
    ----------
    angle_random_walk : float
        ``N`` (rad/s^0.5, >= 0).
    rate_random_walk : float
        ``K`` (rad/s^1.5, >= 0): the bias's random walk.
    bias : array_like, shape (3,)
        Constant bias ``b_0`` about body x, y, z (rad/s).
    period, horizon, seed, agent, dt, name
        As in :func:`star_tracker`.

    Returns
    -------
    control.NonlinearIOSystem
        Static; input ``omega[0..2]`` (rad/s), output ``omega_measured[0..2]``.  Attribute ``samples``: the drawn
        error of the instants, ``(Q, 3)`` rad/s.

    Raises
    ------
    fsmctl.ScenarioError
        A bad argument (one line).

    Examples
    --------
    >>> import numpy as np
    >>> from fsmctl.plugin.hardware import rate_gyro
    >>> g = rate_gyro(0.0, 0.0, [1e-3, 0.0, 0.0], 0.5, horizon=10.0, dt=0, name="gyro")
    >>> g.dt, g.output(0.7, [], [0.1, 0.0, 0.0]).round(12).tolist()  # continuous time: the sample of t = 0.5 held
    (0, [0.101, 0.0, 0.0])
    """
    call = _factory_call(rate_gyro, locals())
    name = _system_name(name, "rate_gyro")
    where = f"rate_gyro {name!r}" if name else "rate_gyro"
    N = _scalar(angle_random_walk, f"{where}: angle_random_walk", minimum=0.0)
    K = _scalar(rate_random_walk, f"{where}: rate_random_walk", minimum=0.0)
    b0 = _numbers(bias, (3,), "three real numbers", f"{where}: bias")
    gyro = {"angle_random_walk": N, "rate_random_walk": K, "bias": np.array(b0)}
    sensor = _sensor("rate_gyro", name, gyro=gyro, period=period, horizon=horizon, seed=seed, agent=agent, dt=dt)
    return _rebuilt(sensor, call)


# ----------------------------------------------------------------------------- communication link


def link(
    delay: float,
    loss_probability: float,
    period: float,
    *,
    horizon: float,
    seed: int = 0,
    index: int = 0,
    size: int = 3,
    signal: str = "b",
    dt: float | bool | None = True,
    name: str | None = None,
) -> ct.NonlinearIOSystem:
    """One communication link (discrete time, ``dt = period``): transport delay and packet loss.

    The rule of the compiled loop (``fsmctl/csrc/formation.c``, ``deliver_links``): at instant ``q`` the receiver
    gets the sender's broadcast of instant ``q - D``, ``D = ceil(delay / period)``
    (:func:`fsmctl.model.problem.delay_instants`; before instant 0: the value of instant 0), unless the packet
    of instant ``q`` is lost, when it keeps the value it holds (at instant 0 it holds the value of instant 0).
    The losses are those :func:`fsmctl.simulate` draws for link number ``index`` of the topology
    (``scenario.topology.links[index]``, :func:`fsmctl.model.noise.hardware_noise`) with ``simulation.seed =
    seed``: independent Bernoulli(``loss_probability``) per instant.

    Parameters
    ----------
    delay : float
        Transport delay (s, >= 0).
    loss_probability : float
        Probability of losing the packet of an instant, in ``[0, 1]``.
    period : float
        Control period ``T`` (s, > 0).
    horizon : float
        Time (s, >= 0) up to which losses are drawn (instants ``0 .. floor(horizon / T)``).
    seed : int
        The run's seed (>= 0).
    index : int
        Link number (0-based) whose loss stream is used.
    size : int
        Number of components of the broadcast (>= 1).
    signal : str
        Name of the broadcast: input ``<signal>[k]``, output ``<signal>_received[k]``.
    dt : {True, period, None}
        python-control's timebase: the link has discrete states, so ``True``, ``None`` (unspecified) and the
        period itself all give ``dt = period``; ``0`` (continuous time) and another period are refused.
    name : str, optional
        System name; default python-control's unique ``sys[<id>]``.

    Returns
    -------
    control.NonlinearIOSystem
        Discrete time, ``dt = period``; states ``first``, ``held`` and the last ``D`` inputs (``size`` each; their
        initial value is not used: start the response at ``t = 0``).  Attribute ``lost``: the drawn losses
        ``(Q,)`` uint8 (1: lost).

    Raises
    ------
    fsmctl.ScenarioError
        A bad argument (one line).

    Examples
    --------
    >>> import control as ct, numpy as np
    >>> from fsmctl.plugin.hardware import link
    >>> ln = link(0.25, 0.0, 0.1, horizon=1.0, size=1, signal="clock", name="l")
    >>> T = np.arange(11) * 0.1
    >>> r = ct.input_output_response(ln, T, T[None, :], np.zeros(ln.nstates))
    >>> r.outputs.round(12).tolist()  # the clock of 3 instants before (0.25 s: ceil(2.5) = 3), 0 before
    [0.0, 0.0, 0.0, 0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7]
    """
    call = _factory_call(link, locals())  # first: the arguments only
    from fsmctl.model.problem import delay_instants

    name = _system_name(name, "link")
    where = f"link {name!r}" if name else "link"
    delay = _scalar(delay, f"{where}: delay", minimum=0.0)
    p = _scalar(loss_probability, f"{where}: loss_probability", minimum=0.0)
    if p > 1:
        raise ScenarioError(f"{where}: loss_probability: must be <= 1, got {p}")
    period, Q = _samples(horizon, period, where)
    _timebase(dt, period, where, stateful=True)
    seed = _count(seed, f"{where}: seed", 0)
    index = _count(index, f"{where}: index", 0)
    m = _count(size, f"{where}: size", 1)
    if not isinstance(signal, str) or not signal or any(c in signal for c in ".[]"):
        raise ScenarioError(f"{where}: signal: must be a non-empty name without '.', '[' or ']', got {_show(signal)}")
    D = int(delay_instants(np.array([delay]), period)[0])
    lost = _noise(where, seed=seed, n_agents=1, n_samples=Q, period=period, loss_probability=[0.0] * index + [p])[
        "lost"
    ][:, index].copy()
    samples = _Samples(lost, period, False, where)

    def deliver(t, x, u):
        q = samples.index(t)
        if q == 0:
            return np.array(u[:m], dtype=float)  # formation.c: at instant 0 every link holds the value of 0
        if samples.table[q]:
            return x[m : 2 * m]  # lost: hold
        if q - D < 0:
            return x[:m]  # the constant initial history
        return np.array(u[:m], dtype=float) if D == 0 else x[2 * m + (D - 1) * m : 2 * m + D * m]

    def update(t, x, u, params):
        y = deliver(t, x, u)
        first = np.array(u[:m], dtype=float) if samples.index(t) == 0 else x[:m]
        history = np.concatenate([np.asarray(u[:m], dtype=float), x[2 * m : 2 * m + (D - 1) * m]]) if D else []
        return np.concatenate([first, y, history])

    sys = ct.nlsys(
        update,
        lambda t, x, u, params: deliver(t, x, u),
        inputs=_labels(signal, m),
        outputs=_labels(f"{signal}_received", m),
        states=_labels("first", m) + _labels("held", m) + [f"past{j}[{k}]" for j in range(1, D + 1) for k in range(m)],
        dt=period,
        name=name,
    )
    sys.lost = samples.table
    return _rebuilt(sys, call)
