"""The settings of a scenario, one frozen pydantic dataclass per table of the scenario file.

:class:`Sinusoid`, :class:`Agent`, :class:`Reference`, :class:`ControllerSettings` and :class:`SimulationSettings`;
:class:`~fsmctl.model.scenario.Scenario` holds them, with the flight-hardware tables of
:mod:`fsmctl.model.hardware_settings`.  Every class runs the validators of
:mod:`fsmctl.model.scenario_values` however it is built (keywords, a TOML table, ``dataclasses.replace``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Annotated, Any

import numpy as np
from pydantic import BeforeValidator, model_validator

from fsmctl.model.laws import (
    CONTROLLER_KEYS,
    LawError,
    check_written_parameters,
    resolve_law,
)
from fsmctl.model.scenario_values import (
    ZERO3,
    Bool,
    ErrorModel,
    Integrator,
    LawParameters,
    Mat3,
    Real,
    ScenarioError,
    Text,
    TorqueLimit,
    Vec3,
    _count,
    _doc,
    _inertia_problem,
    _is_multiple,
    _law_parameters,
    _lower,
    _validated,
)

# ----------------------------------------------------------------------------- data classes


@_validated
class Sinusoid:
    """``v_k(t) = amplitude_k cos(frequency_k t + phase_k) + offset_k``, k = 1..3.

    Examples
    --------
    >>> from fsmctl import Sinusoid
    >>> Sinusoid(amplitude=[0.1, 0, 0], frequency=[0.025, 0, 0]).bound().tolist()
    [0.1, 0.0, 0.0]
    """

    amplitude: Vec3 = _doc(
        "amplitude per axis (the unit of the signal: N m for torques, rad/s for rates)", default=ZERO3
    )
    frequency: Vec3 = _doc("angular frequency per axis", "rad/s", default=ZERO3)
    phase: Vec3 = _doc("phase per axis (of the cosine)", "rad", default=ZERO3)
    offset: Vec3 = _doc("constant offset per axis (the unit of the signal)", default=ZERO3)

    def params(self) -> np.ndarray:
        """Packed ``[amplitude, frequency, phase, offset]`` (the generated code's layout)."""
        return np.array([*self.amplitude, *self.frequency, *self.phase, *self.offset], dtype=float)

    def __call__(self, t) -> np.ndarray:
        """Values at time(s) ``t``: shape ``(..., 3)``.

        Evaluated by the generated ``disturbance_torque`` function (the same sinusoid layout), so the
        formula exists once, in ``derive/``.
        """
        from fsmctl.model.casadi_eval import evaluate_mapped
        from fsmctl.model.generated_code import casadi_function

        t = np.asarray(t, dtype=float)
        flat = t.reshape(-1)
        if flat.size == 0:
            return np.zeros((*t.shape, 3))
        (values,) = evaluate_mapped(
            casadi_function("disturbance_torque"), flat.size, [flat, self.params()], shared=(1,)
        )
        values = np.ascontiguousarray(values.T).T  # (m, 3) view of a (3, m) array, the layout callers always had
        return values.reshape(*t.shape, 3)

    def bound(self) -> np.ndarray:
        """Componentwise bound ``|amplitude| + |offset|`` on ``|v_k(t)|``."""
        return np.abs(self.amplitude) + np.abs(self.offset)

    def rate_bound(self) -> np.ndarray:
        """Componentwise bound ``|amplitude frequency|`` on ``|dv_k/dt|``."""
        return np.abs(np.asarray(self.amplitude) * np.asarray(self.frequency))

    @classmethod
    def from_mapping(cls, d: Mapping, where: str = "sinusoid") -> Sinusoid:
        """From a file table with ``amplitude``, ``frequency``, ``phase``, ``offset``, optional ``kind``.

        ``kind = ["cos"|"sin", ...]`` per axis: a ``sin`` component ``a sin(w t + p)`` is stored as
        ``a cos(w t + p - pi/2)``.

        Parameters
        ----------
        d : Mapping
            The table.
        where : str
            Key path used in error messages.

        Returns
        -------
        Sinusoid
            The validated sinusoid.
        """
        if not isinstance(d, Mapping):
            raise ScenarioError(f"{where}: expected a table, got {d!r}")
        d = dict(d)
        kind = d.pop("kind", ["cos", "cos", "cos"])
        if isinstance(kind, str) or not isinstance(kind, Sequence) or len(kind) != 3:
            raise ScenarioError(f"{where}.kind: expected three of 'cos'/'sin', got {kind!r}")
        kinds = [_lower(k) for k in kind]
        for k, kd in enumerate(kinds):
            if kd not in ("cos", "sin"):
                raise ScenarioError(f"{where}.kind[{k}]: must be 'cos' or 'sin', got {kind[k]!r}")
        try:
            s = cls(**d)
        except ScenarioError as exc:
            raise ScenarioError(f"{where}.{exc}") from None
        if "sin" in kinds:
            phase = [p - (math.pi / 2 if kd == "sin" else 0.0) for p, kd in zip(s.phase, kinds, strict=True)]
            s = dataclasses.replace(s, phase=tuple(phase))
        return s


@_validated
class Agent:
    """One spacecraft: inertia, initial state, disturbance and its own law parameters (Liang et al. 2012, eqs 9, 29).

    Examples
    --------
    >>> from fsmctl import Agent
    >>> a = Agent(J0=[[100.0, 0, 0], [0, 150.0, 0], [0, 0, 200.0]], delta_J=[[30.0, 0, 0], [0, 45.0, 0], [0, 0, 60.0]],
    ...           sigma0=[0.3, 0.2, -0.3], omega0=[0.35, -0.13, 0.27])
    >>> a.J_true.diagonal().tolist(), dict(a.parameters)
    ([130.0, 195.0, 260.0], {})
    """

    J0: Mat3 = _doc("nominal inertia, used by the controller (symmetric positive definite)", "kg m^2")
    delta_J: Mat3 = _doc("inertia perturbation: the plant has J = J0 + delta_J (eq 29)", "kg m^2")
    sigma0: Vec3 = _doc("initial attitude (MRP, inertial to body)", "1")
    omega0: Vec3 = _doc("initial body angular velocity", "rad/s")
    parameters: Annotated[Any, BeforeValidator(_law_parameters)] = _doc(
        "this agent's own values of law parameters, by name (in a TOML file: further [[agents]] keys, e.g. the "
        "paper's switching gain delta = [0.005, 0.005, 0.005] of eq 18); they take precedence over [controller]'s",
        default_factory=lambda: LawParameters(),
    )
    disturbance: Sinusoid = _doc("disturbance torque d_i(t)", "N m", default_factory=Sinusoid)

    @model_validator(mode="after")
    def _physics(self) -> Agent:
        for where, J in (("J0", np.array(self.J0)), ("J0 + delta_J", np.array(self.J0) + np.array(self.delta_J))):
            problem = _inertia_problem(J, where)
            if problem:
                raise ValueError(problem)
        if np.linalg.norm(self.sigma0) > 1e6:
            raise ValueError(f"sigma0: |sigma0| = {np.linalg.norm(self.sigma0):.3g} is beyond any attitude")
        return self

    @property
    def J0_array(self) -> np.ndarray:
        """(3, 3) kg m^2: the nominal inertia ``J0`` as an array (what the controller uses)."""
        return np.array(self.J0)

    @property
    def J_true(self) -> np.ndarray:
        """(3, 3) kg m^2: the plant's inertia ``J = J0 + delta_J`` (eq 29)."""
        return np.array(self.J0) + np.array(self.delta_J)


_AGENT_FIELDS = frozenset(f.name for f in dataclasses.fields(Agent))


@_validated
class Reference:
    """Reference attitude ``sigma_d(0)`` and rate ``omega_d(t)`` (Sec. 4).

    Examples
    --------
    >>> import fsmctl
    >>> ref = fsmctl.paper_scenario("1").reference
    >>> ref.sigma0, ref.omega(0.0).round(6).tolist()
    ((-0.3, -0.4, 0.4), [0.1, -0.0, -0.1])
    """

    sigma0: Vec3 = _doc("reference attitude at t = 0 (MRP)", "1")
    omega: Sinusoid = _doc("reference body rate omega_d(t)", "rad/s")


@_validated
class ControllerSettings:
    """What every law shares: the law, its written parameters, the torque limit, the error model, on/off.

    ``law`` names a built-in law (``fsmctl laws``), a derivation script (``.py``) or a derived law folder; a
    relative path in a scenario file is relative to the file's folder (elsewhere: to the current folder).
    Every other ``[controller]`` key of a file (and every other key given to :meth:`Scenario.replace`) is a
    parameter of the law, or the name of one of its preset groups (the paper's law: ``surface = "tsm"``), gathered
    in ``parameters`` and checked against what the law declares (:func:`fsmctl.model.laws.parameter_matrix`).
    A parameter nobody wrote takes the flown law's declared default; an agent's own value (``[[agents]]``) takes
    precedence over ``[controller]``'s.

    Examples
    --------
    >>> import fsmctl
    >>> c = fsmctl.paper_scenario("1").controller
    >>> c.law, c.parameters["c1"], c.parameters["alpha"], c.torque_limit
    ('fsm', 0.6, 0.7, 2.0)
    >>> pid = fsmctl.paper_scenario("1").replace(controller={"law": "pid", "K": 10.0})
    >>> dict(pid.controller.parameters)
    {'K': 10.0}
    """

    law: Text = _doc(
        "control law: a built-in name (fsmctl laws), a derivation script FILE.py or a derived folder", default="fsm"
    )
    parameters: Annotated[Any, BeforeValidator(_law_parameters)] = _doc(
        "the law's parameters and preset choices as written, by name (in a TOML file: further [controller] keys, "
        "e.g. c1 = 0.6 or K = 2.0); unwritten ones take the law's declared defaults",
        default_factory=lambda: LawParameters(),
    )
    torque_limit: TorqueLimit = _doc('per-component torque bound; inf (or "inf") for none', "N m", default=math.inf)
    error_model: ErrorModel = _doc(
        "controller's error kinematics: 'paper' (eqs 7-8 as printed) or 'exact'", default="paper"
    )
    enabled: Bool = _doc(
        "false: the torque is not applied (u = 0, open loop); the law is still evaluated and reported as "
        "u_unsaturated (torque-free and disturbance-only runs)",
        default=True,
    )

    @model_validator(mode="after")
    def _declared(self) -> ControllerSettings:
        for key in self.parameters:
            if key in _CONTROLLER_FIELDS:
                raise ValueError(f"parameters: {key!r} is a [controller] key of its own")
        law = resolve_law(self.law)  # a law that cannot be found is a LawError
        try:
            check_written_parameters(law, self.parameters, "controller")
        except LawError as exc:
            raise ValueError(str(exc).removeprefix("controller.")) from None
        return self

    @property
    def effective_torque_limit(self) -> float:
        """Per-component bound the plant sees: ``torque_limit``, or 0 when the controller is disabled."""
        return self.torque_limit if self.enabled else 0.0


_CONTROLLER_FIELDS = frozenset(f.name for f in dataclasses.fields(ControllerSettings))
if _CONTROLLER_FIELDS != {*CONTROLLER_KEYS, "parameters"}:  # checked at load: the two lists are one rule
    raise ImportError("fsmctl.model.laws.CONTROLLER_KEYS does not list ControllerSettings' fields")


@_validated
class SimulationSettings:
    """Horizon, integrator, step and output grid.

    The grid rule: ``t_final``, ``output_interval`` and ``control_period`` are multiples of ``dt``, and
    ``t_final`` is a multiple of ``output_interval``, so the last output sample is the state at ``t_final``.

    Examples
    --------
    >>> from fsmctl import SimulationSettings
    >>> sim = SimulationSettings(t_final=2.0, dt=0.01, output_interval=0.1, control_period=0.1)
    >>> sim.n_steps, sim.output_every, sim.n_outputs, sim.hold_steps
    (200, 10, 21, 10)
    """

    t_final: Real = _doc("horizon", "s", gt=0, default=100.0)
    dt: Real = _doc("integration step (rk4) or initial step (dopri45)", "s", gt=0, default=1e-3)
    integrator: Integrator = _doc(
        "'rk4' (fixed step, default: sgn defeats adaptive steps) or 'dopri45' (adaptive)", default="rk4"
    )
    output_interval: Real = _doc(
        "spacing of the output samples (a multiple of dt dividing t_final)", "s", gt=0, default=0.01
    )
    control_period: Real = _doc(
        "0: continuous control; > 0: the law runs at the instants k control_period (a multiple of dt: the "
        "integrator steps on them) and its torque is held in between (zero-order hold); sensors and imperfect "
        "links need it",
        "s",
        ge=0,
        default=0.0,
    )
    seed: Annotated[int, BeforeValidator(_count)] = _doc(
        "seed of the run's random processes (sensor noise, packet loss); the same seed gives the same run", default=0
    )
    rtol: Real = _doc("relative tolerance (dopri45)", "1", gt=0, default=1e-8)
    atol: Real = _doc("absolute tolerance (dopri45)", "1", gt=0, default=1e-10)

    @model_validator(mode="after")
    def _grid(self) -> SimulationSettings:
        if self.dt > self.t_final:
            raise ValueError(f"dt = {self.dt} exceeds t_final = {self.t_final}")
        for name in ("t_final", "output_interval") + (("control_period",) if self.control_period > 0 else ()):
            if not _is_multiple(getattr(self, name), self.dt):
                raise ValueError(f"{name} = {getattr(self, name)} must be a multiple of dt = {self.dt}")
        if not _is_multiple(self.t_final, self.output_interval):
            raise ValueError(
                f"t_final = {self.t_final} must be a multiple of output_interval = {self.output_interval} "
                "(the output grid must end at t_final)"
            )
        return self

    @property
    def n_steps(self) -> int:
        """Integration steps of ``dt`` to ``t_final`` (rk4)."""
        return round(self.t_final / self.dt)

    @property
    def output_every(self) -> int:
        """Steps between two output samples."""
        return max(1, round(self.output_interval / self.dt))

    @property
    def n_outputs(self) -> int:
        """Number of output samples, ``t = 0`` and ``t_final`` included."""
        return self.n_steps // self.output_every + 1

    @property
    def hold_steps(self) -> int:
        """Steps between two control instants (0: continuous control)."""
        return round(self.control_period / self.dt) if self.control_period > 0 else 0
