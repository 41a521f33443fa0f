"""python-control plug-in: the flight hardware (reaction wheels, star tracker, rate gyro, imperfect link) as systems.

Each factory returns a :class:`control.NonlinearIOSystem` a user wires into :func:`control.interconnect` with the
systems of :mod:`fsmctl.plugin.iosys`, and each evaluates the generated functions the compiled simulator flies
(:mod:`fsmctl.symbolic.hardware`): ``gyrostat_rhs``, ``wheel_torque``, ``wheel_acceleration`` and
``sensor_measurement``; the torque distribution is :func:`fsmctl.model.actuators.distribute` and the noise is
:func:`fsmctl.model.noise.hardware_noise`, drawn from the seed the way :func:`fsmctl.simulate` draws it.

* :func:`reaction_wheel_spacecraft`: a rigid hub with balanced reaction wheels (continuous time).  Its input is
  the body torque the law asks for; the plant distributes it to the wheels continuously, so a sampled law (the
  compiled loop holds the wheel commands over each control period) is a held input.
* :func:`star_tracker`, :func:`rate_gyro` (:mod:`fsmctl.plugin.sensors`): the measurement of each sample instant ``t_q = q period`` (discrete
  time, ``dt = period``; or, with ``dt=0``, continuous time with each sample's noise held until the next; ``dt``
  means what it means to python-control).
* :func:`link` (:mod:`fsmctl.plugin.sensors`): one communication link's delay and packet loss (discrete time), the rule of the compiled loop.

Parameters follow :class:`fsmctl.plugin.iosys.ParameterizedSystem` (keys ``f"{name}_J"``, ... and an owner tag);
the sensors and the link carry no parameters (their noise is drawn when they are made).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import casadi as ca
import control as ct
import numpy as np

from fsmctl.model.actuators import distribute, distribution_matrix, hub_inertia_problem, spin_inertia_matrix
from fsmctl.model.attitude import mrp_of_quaternion_expression, quaternion_from_mrp, quaternion_rate_expression
from fsmctl.model.scenario import ActuatorSettings, ScenarioError, Sinusoid
from fsmctl.plugin.arguments import (
    _actuator,
    _axes_check,
    _inertia,
    _labels,
    _numbers,
    _per_wheel_check,
    _scalar,
    _show,
    _signal_names,
    _sinusoid,
    _system_name,
    _twelve,
)
from fsmctl.plugin.iosys import DEFAULT_NORMALIZATION_GAIN
from fsmctl.plugin.jacobians import _Generated
from fsmctl.plugin.parameters import _factory_call, _finish
from fsmctl.plugin.sensors import link, rate_gyro, star_tracker
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
    :func:`fsmctl.model.actuators.distribute` (minimum norm, plus the per-wheel motor torque commands ``u_wheels``,
    then the torque limit ``actuator.allocation``: all wheel torques scaled by one factor when a wheel would
    exceed ``max_torque``, or each wheel clipped); each wheel's motor torque after the speed limit and its net torque with friction
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
        (:func:`reaction_wheel_state` builds it).  Its ``allocation`` is the torque-limit rule; its ``speed_gate``
        must be ``"continuous"`` (a continuous-time plant has no step to hold the speed limit over); its
        ``wheel_commands`` table is not used (the input ``u_wheels`` is this plant's open-loop command).
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
        the law asks for, N m), ``d[0..2]`` (external torque added to the ``disturbance``, N m) and
        ``u_wheels[0..N-1]`` (per-wheel motor torque commands added before the torque limit, N m, positive spinning
        the wheel up along its axis: Basilisk's ``motorTorque``).  Outputs ``sigma[0..2]`` (MRP,
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
    >>> (sc.output(0.0, x0, [0.0, 0.0, 0.5, 0, 0, 0, 0, 0, 0])[9:12].round(12) + 0.0).tolist()  # asks 0.5 N m, gets max_torque
    [0.0, 0.0, 0.1]
    >>> U = np.zeros((sc.ninputs, 2))  # u_command, d, u_wheels
    >>> U[2] = 0.05  # 0.05 N m about z for 10 s, taken from the wheels
    >>> r = ct.input_output_response(sc, [0.0, 10.0], U, x0)
    >>> round(float(r.outputs[5, -1]), 9)  # the hub's rate: 0.5 N m s / (J_z - J_s)
    0.002500625
    >>> bool(abs(200.0 * r.outputs[5, -1] + r.outputs[14, -1]) < 1e-12)  # the total momentum J omega + h is kept
    True

    A per-wheel command: 0.02 N m spinning wheel 3 (along z) up; the hub turns the other way:

    >>> U = np.zeros((sc.ninputs, 2))
    >>> U[sc.input_labels.index("u_wheels[2]")] = 0.02
    >>> r = ct.input_output_response(sc, [0.0, 10.0], U, x0)
    >>> round(float(r.outputs[5, -1]), 9)
    -0.00100025
    """
    call = _factory_call(reaction_wheel_spacecraft, locals())
    name = _system_name(name, "reaction_wheel_spacecraft")
    where = f"reaction_wheel_spacecraft {name!r}" if name else "reaction_wheel_spacecraft"
    J = _inertia(J, f"{where}: J")
    act = _actuator(actuator, where)
    if act.speed_gate != "continuous":
        raise ScenarioError(
            f"{where}: actuator: speed_gate = {act.speed_gate!r} decides the speed limit at the start of each step of "
            "the compiled loop; this continuous-time plant evaluates it continuously (speed_gate = 'continuous')"
        )
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

    clipped = act.allocation == "clipped"

    def commands(u, a: _WheelArray) -> np.ndarray:
        return distribute(u[:3], a.pinv, a.max_torque, command=u[6:], allocation=act.allocation)[0]

    # the exact Jacobian: the distribution's rule as a graph (its derivative and switches), chained into the plant's
    dist_graph = _FlatCall(
        lambda u, c, P, m: [_distribution_graph(u, c, P, m, clipped)], [(3, 1), (n, 1), (n, 3), (n, 1)], "wheel_dist"
    )
    u_wheels = _labels("u_wheels", n)
    state_names = _signal_names(states, _labels("q", 4) + _labels("omega") + _labels("Omega", n), "states", where)
    wheel_labels = _labels("u_wheel", n)

    def jacobian(t, x, u, p):
        a = derived(p)
        uw = commands(u, a)
        du, dc = dist_graph.jacobian(
            u[:3], u[6:], a.pinv, a.max_torque, wrt=(0, 1), labels=(_labels("u_command"), u_wheels)
        )
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
        return (
            A,
            np.hstack([B_w @ du, B_d, B_w @ dc]),
            C,
            np.hstack([D_w @ du, np.zeros((C.shape[0], 3)), D_w @ dc]),
        )

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
        du, _ = dist_graph.jacobian(
            u[:3], u[6:], a.pinv, a.max_torque, wrt=(0, 1), labels=(_labels("u_command"), u_wheels)
        )
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
        inputs=_signal_names(inputs, _labels("u_command") + _labels("d") + u_wheels, "inputs", where),
        outputs=_signal_names(outputs, output_labels, "outputs", where),
        states=state_names,
        name=name,
        attitude=True,
        jacobian=jacobian,
    )
    system._mrp_model = (mrp_jacobian, mrp_states, _labels("u_command"), 6 + n)
    return _finish(system, call, params, dt)


def _distribution_graph(u, c, P, m, clipped: bool):
    """:func:`fsmctl.model.actuators.distribute`'s wheel torques as a CasADi graph (for its derivative):
    ``u_w* = -P u + c``, clipped to ``+-max_torque_i`` (``clipped``) or divided by
    ``max(1, max_i |u_w*_i| / max_torque_i)``."""
    uw = -ca.mtimes(P, u) + c
    if clipped:
        return ca.fmin(ca.fmax(uw, -m), m)
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
