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

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from fsmctl.model.coupling import aggregate
from fsmctl.model.laws import LawCode, LawError, resolve_law
from fsmctl.model.scenario import ControllerSettings, Scenario, ScenarioError, Sinusoid
from fsmctl.model.topology import Schedule, Topology, schedule_weight
from fsmctl.plugin.arguments import (
    _actuator,
    _axes_check,
    _inertia,
    _labels,
    _per_wheel_check,
    _positive3,
    _scalar,
    _show,
    _signal_names,
    _sinusoid,
    _system_name,
    _torque_limit,
    _twelve,
)
from fsmctl.plugin.jacobians import _Generated
from fsmctl.plugin.parameters import (
    InvalidStateError,
    ParameterKeyError,
    _factory_call,
    _finish,
    _law_scheme,
    _ParameterScheme,
    law_parameter_values,
)
from fsmctl.plugin.states import initial_state, mrp_state
from fsmctl.plugin.system import ParameterizedSystem, _FlatCall

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


# ----------------------------------------------------------------------------- attitude kinematics
# Euler parameters q = (q0, q1, q2, q3), scalar first, of the rotation N -> B; sigma = (q1, q2, q3) / (1 + q0).
from fsmctl.model.attitude import (  # noqa: E402  (the conversions live in the model layer)
    mrp_from_quaternion,
    mrp_of_quaternion_expression,
    quaternion_from_mrp,
    quaternion_rate_expression,
)


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
    wheels: Mapping[str, np.ndarray] | None = None,
) -> ParameterizedSystem:
    """One agent's law (the contract of :mod:`fsmctl.symbolic.law`) as a python-control system; ``wheels``
    (``axes``, ``spin_inertia``) for a law that commands its wheels (:func:`_law_wheels`)."""
    where = f"{kind} {name!r}" if name else kind
    nz, nb, bname = law.n_states, law.n_broadcast, law.broadcast_name
    nw = law.n_wheels if wheels is not None else 0  # a law that commands its wheels: outputs u_wheels, inputs Omega
    if bname == "tau":
        raise ScenarioError(f"{where}: the law's broadcast is named 'tau', the controller's torque output")
    if law.trigger is not None:  # event-triggered communication is flown by the compiled loop only
        raise ScenarioError(
            f"{where}: the law {law.name} is event-triggered (it declares a trigger), which the python-control "
            "systems do not model (their broadcast output is continuous); fly it with fsmctl.simulate"
        )
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
    n_in = len(inputs)  # the wheel speeds Omega[0..nw-1] follow
    inputs += _labels("Omega", nw) if nw else []
    wheel_commands = _Generated(f"law_wheels_{error_model}", law.folder) if nw else None

    # one flat call: (t, own/reference signals, z, params, J0, aggregates, u_max[, axes, Omega, J_s]) -> (torque,
    # broadcast[, wheel commands], z_dot); the law's constants are computed from the parameters inside the call, so
    # params= values are used consistently
    def build(t, y, z, prm, J, k_sum, received, k_received_sum, um, *wheel_inputs):
        agent = (t, y[0:3], y[3:6], z, y[6:9], y[9:12], y[12:15], J, prm, constants(prm))
        b, cache = local(*agent)
        u, _, z_dot = control(*agent, cache, k_sum, received, k_received_sum, um)
        if not nw:
            return [u, b, z_dot]
        return [u, b, wheel_commands(*agent, cache, k_sum, received, k_received_sum, um, *wheel_inputs), z_dot]

    shapes = [(1, 1), (15, 1), (nz, 1), (law.n_params, 1), (3, 3), (1, 1), (nb, 1), (1, 1), (1, 1)]
    shapes += [(3, nw), (nw, 1), (nw, 1)] if nw else []
    call = _FlatCall(build, shapes, f"{kind}_law")
    zero = np.zeros(nb)
    n_out = 3 + nb + nw

    def wheel_args(u, p) -> tuple:
        return (p["axes"], u[n_in:], p["spin_inertia"]) if nw else ()

    def evaluate(t, x, u, p):
        # eq 19: the agent knows only what it receives, sum_j k^j_ij(t) b_j, from the b_j on its inputs; the
        # rule is fsmctl.model.coupling.aggregate, here with the agent as receiver 0 and its neighbours 1..m
        broadcasts = [zero] + [u[15 + nb * m : 15 + nb * (m + 1)] for m in range(len(nbrs))]
        received, k_sum, k_received_sum = aggregate(
            broadcasts, [w(t) for w in weights], [0] * len(nbrs), range(1, len(nbrs) + 1), k_i, zero=lambda: zero
        )
        prm = scheme.pack(p)
        return call(t, u[:15], x, prm, p["J0"], k_sum[0], received[0], k_received_sum[0], p["u_max"], *wheel_args(u, p))

    update = None if nz == 0 else (lambda t, x, u, p: evaluate(t, x, u, p)[n_out:])
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
        d_y, d_z, d_received, *d_wheels = call.jacobian(
            t,
            u[:15],
            x,
            scheme.pack(p),
            p["J0"],
            k_sum[0],
            received[0],
            k_received_sum[0],
            p["u_max"],
            *wheel_args(u, p),
            wrt=(1, 2, 6) + ((10,) if nw else ()),
            labels=(inputs[:15], states, [f"received[{k}]" for k in range(nb)]) + ((inputs[n_in:],) if nw else ()),
        )
        d_u = np.hstack([d_y, d_received @ weight, *d_wheels])
        return d_z[n_out:], d_u[n_out:], d_z[:n_out], d_u[:n_out]

    values, validators = {"J0": J0, **scheme.values, "u_max": u_max}, {"J0": _inertia, **scheme.validators}
    validators["u_max"] = _torque_limit
    if nw:
        values.update(wheels)
        validators.update(axes=_axes_check(nw), spin_inertia=_per_wheel_check(nw, positive=True, inf=False))
    outputs = _labels("tau") + _labels(bname, nb) + (_labels("u_wheels", nw) if nw else [])
    system = ParameterizedSystem(
        kind,
        update,
        lambda t, x, u, p: evaluate(t, x, u, p)[:n_out],
        values,
        validators,
        inputs=_signal_names(signals["inputs"], inputs, "inputs", where),
        outputs=_signal_names(signals["outputs"], outputs, "outputs", where),
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
    actuator: Any = None,
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
    actuator : ActuatorSettings or mapping, optional
        For a law that commands its reaction wheels (:attr:`LawCode.n_wheels`,
        :meth:`fsmctl.symbolic.law.LawBuilder.wheel_torques`): the wheel array (as for
        :func:`fsmctl.plugin.hardware.reaction_wheel_spacecraft`), whose spin axes and spin inertias the law reads;
        it must have the law's number of wheels.  Given, the system has the wheel speeds as inputs and the law's
        wheel commands as outputs; omitted, it is the law's body torque only (for an ideal torque source).

    Returns
    -------
    ParameterizedSystem
        States: the law's states ``z`` (labels of :meth:`LawCode.state_labels`; none: a static system).
        Inputs ``sigma``, ``omega`` (own state), ``sigma_d``, ``omega_d``, ``omega_d_dot`` (reference), each
        neighbour's broadcast and, with ``actuator``, the wheel speeds ``Omega[0..N-1]`` (rad/s, relative to the
        hub: the wheel spacecraft's outputs).  Outputs ``tau[0..2]`` (the applied, limited torque: the plant's
        input), the broadcast ``<broadcast>[k]`` and, with ``actuator``, the wheel motor torque commands
        ``u_wheels[0..N-1]`` (N m, before the wheels' limits).  Parameters ``f"{name}_J0"``, one per law parameter
        under its name (``f"{name}_K"``, ...), ``f"{name}_u_max"``, with ``actuator`` ``f"{name}_axes"`` (3 x N)
        and ``f"{name}_spin_inertia"`` (N), and the owner tag.  Initial law states:
        :func:`fsmctl.model.laws.initial_law_states`.

    Raises
    ------
    fsmctl.ScenarioError
        A bad ``J0``, parameter, ``u_max``, ``error_model``, ``neighbours`` or ``name``; an ``actuator`` for a law
        that commands no wheels, or with another number of wheels than the law's.
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

    A law that commands its four wheels (the built-in ``fsm_wheels``, null motion toward a speed bias):

    >>> rw = law_controller("fsm_wheels", paper.agents[0].J0_array, actuator={"layout": "pyramid"}, name="w")
    >>> rw.input_labels[-4:], rw.output_labels[-4:]
    (['Omega[0]', 'Omega[1]', 'Omega[2]', 'Omega[3]'], ['u_wheels[0]', 'u_wheels[1]', 'u_wheels[2]', 'u_wheels[3]'])
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
    wheels = None if actuator is None else _law_wheels(law, actuator, where)
    return _controller(
        "law_controller", law, J0, scheme, u_max, error_model, nbrs, name, call, signals, params, dt, wheels
    )


def _law_wheels(law: LawCode, actuator: Any, where: str) -> dict[str, np.ndarray]:
    """The ``axes`` and ``spin_inertia`` of ``actuator`` for a law that commands as many wheels."""
    act = _actuator(actuator, where)
    if not law.n_wheels:
        raise ScenarioError(
            f"{where}: actuator: the law {law.name} commands no wheels (reaction_wheel_spacecraft distributes its "
            "torque); give no actuator"
        )
    if act.n_wheels != law.n_wheels:
        raise ScenarioError(
            f"{where}: actuator: the law {law.name} commands {law.n_wheels} reaction wheels, the actuator has "
            f"{act.n_wheels}"
        )
    return {"axes": act.spin_axes(), "spin_inertia": np.asarray(act.per_wheel("spin_inertia"), dtype=float)}


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
