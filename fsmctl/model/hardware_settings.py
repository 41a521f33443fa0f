"""The flight-hardware settings of a scenario: the ``[actuator]`` (ideal torque source or reaction wheels, their
open-loop commands), ``[sensors]`` and ``[links]`` tables, one frozen pydantic dataclass per table.

:class:`WheelCommandSettings`, :class:`ActuatorSettings`, :class:`StarTrackerSettings`, :class:`GyroSettings`,
:class:`SensorSettings` and :class:`LinkSettings`; :class:`~fsmctl.model.scenario.Scenario` holds them beside the
settings of :mod:`fsmctl.model.settings`.  Every class runs the validators of :mod:`fsmctl.model.scenario_values`
however it is built (keywords, a TOML table, ``dataclasses.replace``).
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import model_validator

from fsmctl.model.actuators import spin_inertia_matrix
from fsmctl.model.noise import gilbert_elliott_problem
from fsmctl.model.scenario_values import (
    ZERO3,
    ActuatorKind,
    Limits,
    LinkTable,
    LossModel,
    Matrix3N,
    Numbers,
    Real,
    SpeedGate,
    Vec3,
    WheelAllocation,
    WheelLayout,
    WheelTorqueTable,
    _doc,
    _validated,
)

# ----------------------------------------------------------------------------- data classes


@_validated
class WheelCommandSettings:
    """Open-loop motor torque commands of the reaction wheels, a table held between its times (zero-order hold).

    Row ``m`` of ``motor_torque`` holds from ``time[m]`` to the next time (the last to the end of the run); before
    ``time[0]`` the commands are 0.  A row gives one torque per wheel (every spacecraft alike) or one row of wheel
    torques per spacecraft.  The sign is Basilisk's ``motorTorque``: positive spins the wheel up along its axis
    ``g`` (its reaction on the hub is ``-g``).  The commands are sampled at the control instants and added to
    what the wheels get from the law's body torque, before the torque limit (``actuator.allocation``): with
    ``controller.enabled = false`` the wheels fly exactly the table.

    Examples
    --------
    >>> from fsmctl.model.hardware_settings import WheelCommandSettings
    >>> WheelCommandSettings(time=[0.0, 10.0], motor_torque=[[0.01, 0.0, 0.0], [0.0, 0.0, 0.0]]).time
    (0.0, 10.0)
    """

    time: Numbers = _doc("start of each row of motor_torque, strictly increasing, >= 0", "s")
    motor_torque: WheelTorqueTable = _doc(
        "one row per time: a torque per wheel (every spacecraft alike), or per spacecraft a torque per wheel",
        "N m",
    )

    @model_validator(mode="after")
    def _rows(self) -> WheelCommandSettings:
        t = np.array(self.time)
        if t[0] < 0 or np.any(np.diff(t) <= 0):
            raise ValueError(f"time: must be >= 0 and strictly increasing, got {list(self.time)}")
        if len(self.motor_torque) != t.size:
            raise ValueError(f"motor_torque: one row per time ({t.size}), got {len(self.motor_torque)} rows")
        return self

    def table(self, n_agents: int) -> np.ndarray:
        """The table as ``(T, n_agents, N)`` torques, a per-wheel row repeated for every spacecraft.

        Parameters
        ----------
        n_agents : int
            Spacecraft of the scenario.

        Returns
        -------
        numpy.ndarray
            ``(T, n_agents, N)`` motor torques (N m), row ``m`` holding from ``time[m]``.

        Examples
        --------
        >>> from fsmctl.model.hardware_settings import WheelCommandSettings
        >>> WheelCommandSettings(time=[0.0], motor_torque=[[0.01, 0.0, 0.0]]).table(2).shape
        (1, 2, 3)
        """
        a = np.array(self.motor_torque, dtype=float)
        return np.repeat(a[:, None, :], n_agents, axis=1) if a.ndim == 2 else a


@_validated
class ActuatorSettings:
    """How the law's torque reaches the body: an ideal torque source with a per-axis clip, or reaction wheels.

    ``kind = "ideal"`` (default, the paper's actuator): the body receives the law's torque, clipped per axis by
    ``controller.torque_limit``.  ``kind = "reaction_wheels"``: every spacecraft carries the same array of
    balanced wheels (:mod:`fsmctl.symbolic.hardware`; the spacecraft inertia ``J0 + delta_J`` includes them).

    At each control instant the law's torque command (clipped per axis by ``controller.torque_limit``) is
    distributed to the wheels by the minimum-norm rule ``u_w = -pinv(G_s) u`` (a law that commands its wheels
    itself, such as ``fsm_wheels``, gives ``u_w`` instead); the open-loop ``wheel_commands`` of that instant, if
    any, are added.  Then the torque limit ``max_torque``, by the rule ``allocation``: ``"scaled"`` (default)
    divides every wheel torque by one factor when one exceeds its limit, so the body torque keeps its direction
    and the most loaded wheel sits at its limit; ``"clipped"`` clips each wheel to ``+-max_torque`` on its own
    (Basilisk's rule: the wheels inside their limit keep their command, the body torque may turn).

    Between instants the wheel torques are held; a wheel at ``max_speed`` is not driven further (its torque is 0
    while the command would speed it up), and friction acts continuously.  ``speed_gate`` says when that speed
    limit is decided: ``"continuous"`` (default) at every evaluation of the dynamics, ``"step_start"`` from the
    speeds at the start of each integrator step, held over the step's stages (Basilisk's timing; needs
    ``simulation.control_period > 0``).

    Examples
    --------
    >>> from fsmctl.model.scenario import ActuatorSettings
    >>> ActuatorSettings(kind="reaction_wheels", layout="pyramid").spin_axes().shape
    (3, 4)
    """

    kind: ActuatorKind = _doc("'ideal' (torque source, per-axis clip) or 'reaction_wheels'", default="ideal")
    layout: WheelLayout = _doc(
        "wheel spin axes: 'pyramid' (4 wheels at pyramid_angle from body z, azimuths 45, 135, 225, 315 deg), "
        "'orthogonal' (3 wheels along body x, y, z) or 'custom' (axes)",
        default="pyramid",
    )
    pyramid_angle: Real = _doc(
        "angle between each spin axis and body z (pyramid); 54.7356 deg gives axes (+-1, +-1, 1)/sqrt(3)",
        "deg",
        gt=0,
        lt=90,
        default=54.735610317245346,
    )
    axes: Matrix3N | None = _doc(
        "spin axes of layout = 'custom': a 3 x N matrix, one column per wheel (normalised), spanning 3-D",
        "1",
        default=None,
    )
    spin_inertia: Numbers = _doc("wheel spin-axis inertia J_s: one value, or one per wheel", "kg m^2", default=(0.01,))
    max_torque: Limits = _doc("motor torque limit per wheel (inf: none)", "N m", default=(math.inf,))
    max_speed: Limits = _doc(
        "wheel speed limit relative to the hub (momentum limit J_s max_speed; inf: none)", "rad/s", default=(math.inf,)
    )
    viscous_friction: Numbers = _doc("viscous friction coefficient per wheel", "N m s", default=(0.0,))
    coulomb_friction: Numbers = _doc("Coulomb friction torque per wheel", "N m", default=(0.0,))
    coulomb_band: Real = _doc(
        "speed below which the Coulomb torque is linear in the speed (stiction band; 0: sgn)",
        "rad/s",
        ge=0,
        default=0.1,
    )
    initial_speed: Numbers = _doc("wheel speeds at t = 0: one value, or one per wheel", "rad/s", default=(0.0,))
    allocation: WheelAllocation = _doc(
        "torque-limit rule: 'scaled' (when a wheel would exceed max_torque, every wheel is divided by one factor: "
        "the body torque keeps its direction) or 'clipped' (each wheel clipped to +-max_torque on its own: "
        "Basilisk's rule)",
        default="scaled",
    )
    speed_gate: SpeedGate = _doc(
        "when the speed limit is decided: 'continuous' (at every evaluation of the dynamics) or 'step_start' "
        "(from the speeds at the start of each integrator step, held over the step: Basilisk's timing; needs "
        "simulation.control_period > 0)",
        default="continuous",
    )
    wheel_commands: WheelCommandSettings | None = _doc(
        "open-loop motor torques per wheel, a table of times and torques added to the law's wheel torques before "
        "the torque limit; unset: none",
        default=None,
    )

    @model_validator(mode="after")
    def _wheels(self) -> ActuatorSettings:
        if self.layout == "custom" and self.axes is None:
            raise ValueError("axes: layout = 'custom' needs axes (a 3 x N matrix, one column per wheel)")
        if self.layout != "custom" and self.axes is not None:
            raise ValueError(f"axes: given with layout = {self.layout!r}; set layout = 'custom' to use them")
        G = self._raw_axes()
        norms = np.linalg.norm(G, axis=0)
        if np.any(norms == 0):
            raise ValueError(f"axes: wheel {int(np.argmin(norms)) + 1} has a zero spin axis")
        if np.linalg.matrix_rank(G / norms, tol=1e-9) < 3:
            raise ValueError(
                "axes: the spin axes do not span 3-D, so some body torques cannot be produced (give at least "
                "three axes that are not coplanar)"
            )
        n = G.shape[1]
        for name in (
            "spin_inertia",
            "max_torque",
            "max_speed",
            "viscous_friction",
            "coulomb_friction",
            "initial_speed",
        ):
            v = getattr(self, name)
            if len(v) not in (1, n):
                raise ValueError(f"{name}: give one value or one per wheel ({n}), got {len(v)}")
        for name in ("spin_inertia", "max_torque", "max_speed"):
            if not all(x > 0 for x in getattr(self, name)):
                raise ValueError(f"{name}: every value must be > 0, got {list(getattr(self, name))}")
        for name in ("viscous_friction", "coulomb_friction"):
            if not all(x >= 0 for x in getattr(self, name)):
                raise ValueError(f"{name}: every value must be >= 0, got {list(getattr(self, name))}")
        if self.wheel_commands is not None:
            if not self.enabled:
                raise ValueError("wheel_commands: given with kind = 'ideal'; set kind = 'reaction_wheels'")
            width = np.array(self.wheel_commands.motor_torque).shape[-1]
            if width != n:
                raise ValueError(f"wheel_commands.motor_torque: one torque per wheel ({n}), got {width} per row")
        return self

    def _raw_axes(self) -> np.ndarray:
        if self.layout == "orthogonal":
            return np.eye(3)
        if self.layout == "pyramid":
            b = math.radians(self.pyramid_angle)
            az = np.radians([45.0, 135.0, 225.0, 315.0])
            return np.array([math.sin(b) * np.cos(az), math.sin(b) * np.sin(az), np.full(4, math.cos(b))])
        return np.array(self.axes, dtype=float)

    @property
    def enabled(self) -> bool:
        """Whether the spacecraft fly reaction wheels (else the ideal torque source)."""
        return self.kind == "reaction_wheels"

    @property
    def n_wheels(self) -> int:
        """Wheels per spacecraft (0 for the ideal actuator)."""
        return self._raw_axes().shape[1] if self.enabled else 0

    def spin_axes(self) -> np.ndarray:
        """``(3, N)`` unit spin axes ``G_s`` in the body frame, one column per wheel."""
        G = self._raw_axes()
        return G / np.linalg.norm(G, axis=0)

    def spin_inertia_matrix(self) -> np.ndarray:
        """``J_spin = sum_k J_s,k g_k g_k^T`` (3, 3) of the wheels (zero for the ideal actuator)."""

        if not self.enabled:
            return np.zeros((3, 3))
        return spin_inertia_matrix(self.spin_axes(), self.per_wheel("spin_inertia"))

    def per_wheel(self, name: str) -> np.ndarray:
        """``(N,)`` values of a per-wheel setting (one value broadcast to every wheel).

        Parameters
        ----------
        name : str
            A per-wheel field (``"spin_inertia"``, ``"max_torque"``, ``"max_speed"``, ...).

        Returns
        -------
        numpy.ndarray
            One value per wheel.
        """
        v = np.array(getattr(self, name), dtype=float)
        return np.broadcast_to(v, (self._raw_axes().shape[1],)).copy()


@_validated
class StarTrackerSettings:
    """Attitude sensor: the measured attitude is the true one rotated by a small body-frame rotation
    ``dtheta`` drawn at each control instant, independent, zero-mean Gaussian with per-axis standard
    deviation ``noise_std`` (white noise in small-angle form; :func:`fsmctl.symbolic.hardware.star_tracker_measurement`).

    Examples
    --------
    >>> from fsmctl import StarTrackerSettings
    >>> StarTrackerSettings(noise_std=[2.424e-5, 2.424e-5, 4.848e-5]).noise_std
    (2.424e-05, 2.424e-05, 4.848e-05)
    """

    noise_std: Vec3 = _doc("1-sigma of the measurement error about body x, y, z (5 arcsec = 2.424e-5 rad)", "rad")

    @model_validator(mode="after")
    def _positive(self) -> StarTrackerSettings:
        if not all(x >= 0 for x in self.noise_std):
            raise ValueError(f"noise_std: must be >= 0, got {list(self.noise_std)}")
        return self


@_validated
class GyroSettings:
    """Rate gyro: ``omega_measured = omega + b + eta_v`` with ``b_dot = eta_u`` (Farrenkopf's model, sampled at
    the control instants; :mod:`fsmctl.model.noise`): angle random walk ``N`` (the density of eta_v), rate
    random walk ``K`` (the density of eta_u: the bias drift) and a constant bias ``b_0``.

    Examples
    --------
    >>> import fsmctl
    >>> gyro = fsmctl.load_scenario("paper-hardware").sensors.gyro
    >>> gyro.angle_random_walk, gyro.bias
    (4.363e-05, (4.848e-06, -4.848e-06, 2.424e-06))
    """

    angle_random_walk: Real = _doc(
        "angle random walk N (0.1 deg/sqrt(h) = 2.909e-5 rad/sqrt(s))", "rad/s^0.5", ge=0, default=0.0
    )
    rate_random_walk: Real = _doc(
        "rate random walk K: the bias's random walk (1 deg/h/sqrt(h) = 8.08e-8 rad/s^1.5)",
        "rad/s^1.5",
        ge=0,
        default=0.0,
    )
    bias: Vec3 = _doc("constant bias b_0 about body x, y, z (1 deg/h = 4.848e-6 rad/s)", "rad/s", default=ZERO3)


@_validated
class SensorSettings:
    """What the law sees.  Unset sensors are perfect; a configured sensor is sampled at the control instants
    (``simulation.control_period > 0``), its noise drawn from ``simulation.seed``.  The metrics always see
    the true state.

    Examples
    --------
    >>> import fsmctl
    >>> fsmctl.paper_scenario("1").sensors.enabled, fsmctl.load_scenario("paper-hardware").sensors.enabled
    (False, True)
    """

    star_tracker: StarTrackerSettings | None = _doc("attitude sensor (unset: the true attitude)", default=None)
    gyro: GyroSettings | None = _doc("rate gyro (unset: the true rate)", default=None)

    @property
    def enabled(self) -> bool:
        """Whether any sensor is configured (else the law sees the true state)."""
        return self.star_tracker is not None or self.gyro is not None


_PER_LINK = {  # a per-link setting: its scalar and the n x n table that overrides it
    "delay": ("delay", "delay_table"),
    "loss_probability": ("loss_probability", "loss_table"),
    "good_to_bad": ("good_to_bad", "good_to_bad_table"),
    "bad_to_good": ("bad_to_good", "bad_to_good_table"),
    "loss_good": ("loss_good", "loss_good_table"),
    "loss_bad": ("loss_bad", "loss_bad_table"),
}
_BERNOULLI_KEYS = ("loss_probability", "loss_table")
_GILBERT_ELLIOTT_KEYS = tuple(
    k for key in ("good_to_bad", "bad_to_good", "loss_good", "loss_bad") for k in _PER_LINK[key]
)


@_validated
class LinkSettings:
    """Imperfect communication links, applied at the control instants (``simulation.control_period > 0``).

    * Delay: the receiver gets the neighbour's broadcast as it was ``delay`` seconds earlier (its value at the
      latest control instant at or before ``t - delay``; before ``t = 0`` the broadcast's initial value,
      the constant initial history of delay equations).
    * Loss, ``loss_model = "bernoulli"`` (default): at each control instant each link independently loses its
      packet with ``loss_probability``; the receiver then holds the last value it received on that link.
    * Loss, ``loss_model = "gilbert_elliott"``: bursty losses (Gilbert 1960, Elliott 1963).  Each link is a
      good/bad Markov chain stepped at the control instants (``good_to_bad`` = p, ``bad_to_good`` = r, both
      needed), losing the packet with ``loss_good`` (1 - k, default 0) in the good state and ``loss_bad``
      (1 - h, default 1) in the bad one; it starts in its stationary distribution, so the loss rate is
      ``(r loss_good + p loss_bad) / (p + r)`` at every instant (Gilbert's channel, loss_good = 0 and
      loss_bad = 1: ``p / (p + r)``, mean burst ``1 / r`` instants;
      :func:`fsmctl.model.noise.gilbert_elliott_statistics`).  A lost packet is held as above.

    ``<key>_table`` (n x n, row = receiver, column = sender, like ``topology.phase_table``; ``loss_table`` for
    ``loss_probability``) sets a value per link and overrides the scalar ``<key>``.  The keys of the model not
    chosen are refused; the losses are drawn from ``simulation.seed``, one stream per link
    (:mod:`fsmctl.model.noise`).

    Examples
    --------
    >>> from fsmctl import LinkSettings
    >>> links = LinkSettings(delay=0.1, loss_table=[[0.0, 0.05], [0.2, 0.0]])
    >>> links.enabled, links.per_link([0, 1], [1, 0], "loss_probability").tolist()
    (True, [0.05, 0.2])
    >>> bursty = LinkSettings(loss_model="gilbert_elliott", good_to_bad=0.01, bad_to_good=0.25)
    >>> bursty.loss_rates([0], [1]).round(6).tolist()  # p / (p + r)
    [0.038462]
    """

    delay: Real = _doc("transport delay of every link", "s", ge=0, default=0.0)
    loss_probability: Real = _doc(
        "loss_model = 'bernoulli': probability that a link loses its packet at a control instant",
        "1",
        ge=0,
        le=1,
        default=0.0,
    )
    delay_table: LinkTable | None = _doc(
        "per-link delay, n x n (row receiver, column sender; entries without a link are ignored)", "s", default=None
    )
    loss_table: LinkTable | None = _doc(
        "per-link loss probability, n x n (row receiver, column sender)", "1", default=None
    )
    loss_model: LossModel = _doc(
        "packet-loss model: 'bernoulli' (independent losses) or 'gilbert_elliott' (bursty, a good/bad Markov chain)",
        default="bernoulli",
    )
    good_to_bad: Real | None = _doc(
        "loss_model = 'gilbert_elliott': p, probability of moving from the good to the bad state at a control "
        "instant (needed with that model, or good_to_bad_table)",
        "1",
        ge=0,
        le=1,
        default=None,
    )
    bad_to_good: Real | None = _doc(
        "loss_model = 'gilbert_elliott': r, probability of moving from the bad to the good state at a control instant "
        "(mean bad period 1/r instants; needed with that model, or bad_to_good_table)",
        "1",
        ge=0,
        le=1,
        default=None,
    )
    loss_good: Real | None = _doc(
        "loss_model = 'gilbert_elliott': 1 - k, probability of losing a packet in the good state (unset: 0)",
        "1",
        ge=0,
        le=1,
        default=None,
    )
    loss_bad: Real | None = _doc(
        "loss_model = 'gilbert_elliott': 1 - h, probability of losing a packet in the bad state (unset: 1)",
        "1",
        ge=0,
        le=1,
        default=None,
    )
    good_to_bad_table: LinkTable | None = _doc(
        "per-link good_to_bad, n x n (row receiver, column sender)", "1", default=None
    )
    bad_to_good_table: LinkTable | None = _doc(
        "per-link bad_to_good, n x n (row receiver, column sender)", "1", default=None
    )
    loss_good_table: LinkTable | None = _doc(
        "per-link loss_good, n x n (row receiver, column sender)", "1", default=None
    )
    loss_bad_table: LinkTable | None = _doc("per-link loss_bad, n x n (row receiver, column sender)", "1", default=None)

    @model_validator(mode="after")
    def _loss_model(self) -> LinkSettings:

        if self.loss_model == "bernoulli":
            written = [k for k in _GILBERT_ELLIOTT_KEYS if getattr(self, k) is not None]
            if written:
                raise ValueError(
                    f"{written[0]}: a parameter of loss_model = 'gilbert_elliott' (loss_model is 'bernoulli')"
                )
            return self
        if self.loss_probability != 0 or self.loss_table is not None:
            key = "loss_table" if self.loss_table is not None else "loss_probability"
            raise ValueError(
                f"{key}: a parameter of loss_model = 'bernoulli'; with loss_model = 'gilbert_elliott' the losses are "
                f"set by good_to_bad, bad_to_good, loss_good and loss_bad: remove {key}"
                + (" (or set loss_probability = 0 over a scenario it extends)" if key == "loss_probability" else "")
            )
        for key in ("good_to_bad", "bad_to_good"):
            if getattr(self, key) is None and getattr(self, f"{key}_table") is None:
                raise ValueError(f"{key}: loss_model = 'gilbert_elliott' needs {key} (or {key}_table)")
        scalars = [self._scalar(k) for k in ("good_to_bad", "bad_to_good", "loss_good", "loss_bad")]
        if self.good_to_bad is not None and self.bad_to_good is not None:
            problem = gilbert_elliott_problem(*scalars)
            if problem:
                raise ValueError(problem)
        return self

    def _scalar(self, key: str) -> float:
        """A per-link setting's scalar as flown (the Gilbert-Elliott defaults: p, r 0 -- then a table --, loss_good 0,
        loss_bad 1)."""
        value = getattr(self, key)
        if value is None:
            return 1.0 if key == "loss_bad" else 0.0
        return float(value)

    @property
    def enabled(self) -> bool:
        """Whether any delay or loss is set (tables count only where a value is > 0)."""

        def any_table(tab, floor):
            return tab is not None and any(math.isfinite(x) and x > floor for row in tab for x in row)

        return (
            self.delay > 0
            or self.loss_probability > 0
            or self.loss_model == "gilbert_elliott"
            or any_table(self.delay_table, 0.0)
            or any_table(self.loss_table, 0.0)
        )

    def loss_rates(self, receivers, senders) -> np.ndarray:
        """The stationary loss rate of the links ``receivers[e] <- senders[e]`` (0-based), whichever the model.

        Parameters
        ----------
        receivers, senders : sequence of int
            The links' agents, 0-based.

        Returns
        -------
        numpy.ndarray
            ``loss_probability`` per link (Bernoulli), or ``(r loss_good + p loss_bad) / (p + r)``
            (Gilbert-Elliott).
        """
        if self.loss_model == "bernoulli":
            return self.per_link(receivers, senders, "loss_probability")
        p, r, good, bad = (
            self.per_link(receivers, senders, k) for k in ("good_to_bad", "bad_to_good", "loss_good", "loss_bad")
        )
        return (r * good + p * bad) / (p + r)

    def per_link(self, receivers, senders, which: str) -> np.ndarray:
        """Values of a per-link setting for the links ``receivers[e] <- senders[e]`` (0-based).

        Parameters
        ----------
        receivers, senders : sequence of int
            The links' agents, 0-based.
        which : {"delay", "loss_probability", "good_to_bad", "bad_to_good", "loss_good", "loss_bad"}
            The setting.

        Returns
        -------
        numpy.ndarray
            One value per link (the table's entry, else the scalar; an unset Gilbert-Elliott scalar is its
            default: ``loss_good`` 0, ``loss_bad`` 1).
        """
        key, table_key = _PER_LINK[which]
        table = getattr(self, table_key)
        scalar = getattr(self, key) if key in ("delay", "loss_probability") else self._scalar(key)
        if table is None:
            return np.full(len(receivers), scalar, dtype=float)
        tab = np.array(table, dtype=float)
        return np.array([tab[i, j] for i, j in zip(receivers, senders, strict=True)], dtype=float)
