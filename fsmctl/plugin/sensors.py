"""python-control plug-in: the sampled hardware: star tracker, rate gyro and imperfect link, as discrete-time systems.

Each returns the measurement (or the received signal) of each sample instant ``t_q = q period``, with the noise
(or the losses) drawn from the seed the way :func:`fsmctl.simulate` draws it (:func:`fsmctl.model.noise.hardware_noise`)
and the measurement the compiled simulator makes (the generated ``sensor_measurement``).  The continuous-time
reaction-wheel plant is in :mod:`fsmctl.plugin.hardware`, which also exports these factories.
"""

from __future__ import annotations

import math
from typing import Any

import control as ct
import numpy as np

from fsmctl.errors import InputError
from fsmctl.model.hardware_settings import LinkSettings
from fsmctl.model.noise import GILBERT_ELLIOTT_KEYS
from fsmctl.model.scenario import ScenarioError
from fsmctl.plugin.arguments import (
    _labels,
    _numbers,
    _scalar,
    _show,
    _system_name,
)
from fsmctl.plugin.jacobians import _Generated
from fsmctl.plugin.parameters import _factory_call, _rebuilt
from fsmctl.plugin.system import _FlatCall

__all__ = ["star_tracker", "rate_gyro", "link"]


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


def _loss_model(where: str, p: float, loss_model, *gilbert_elliott):
    """The link's loss model checked as a scenario's ``[links]`` are; returns ``index ->`` the keywords of
    :func:`fsmctl.model.noise.hardware_noise` for links ``0 .. index`` (the earlier ones lossless, unused)."""

    written = {k: v for k, v in zip(GILBERT_ELLIOTT_KEYS, gilbert_elliott, strict=True) if v is not None}
    try:
        settings = LinkSettings(loss_probability=p, loss_model=loss_model, **written)
    except ScenarioError as exc:
        raise ScenarioError(f"{where}: {exc}") from None
    if settings.loss_model == "bernoulli":
        return lambda index: {"loss_probability": [0.0] * index + [p]}
    values = {k: float(settings.per_link([0], [0], k)[0]) for k in GILBERT_ELLIOTT_KEYS}
    lossless = {"good_to_bad": 0.0, "bad_to_good": 1.0, "loss_good": 0.0, "loss_bad": 0.0}
    return lambda index: {"gilbert_elliott": {k: [lossless[k]] * index + [values[k]] for k in GILBERT_ELLIOTT_KEYS}}


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
    loss_model: str = "bernoulli",
    good_to_bad: float | None = None,
    bad_to_good: float | None = None,
    loss_good: float | None = None,
    loss_bad: float | None = None,
) -> ct.NonlinearIOSystem:
    """One communication link (discrete time, ``dt = period``): transport delay and packet loss.

    The rule of the compiled loop (``fsmctl/csrc/formation.c``, ``deliver_links``): at instant ``q`` the receiver
    gets the sender's broadcast of instant ``q - D``, ``D = ceil(delay / period)``
    (:func:`fsmctl.model.problem.delay_instants`; before instant 0: the value of instant 0), unless the packet
    of instant ``q`` is lost, when it keeps the value it holds (at instant 0 it holds the value of instant 0).
    The losses are those :func:`fsmctl.simulate` draws for link number ``index`` of the topology
    (``scenario.topology.links[index]``, :func:`fsmctl.model.noise.hardware_noise`) with ``simulation.seed =
    seed``: independent Bernoulli(``loss_probability``) per instant, or, with ``loss_model = "gilbert_elliott"``,
    the bursty losses of a good/bad Markov chain started in its stationary distribution (the scenario's
    ``[links]`` keys of the same names, :class:`fsmctl.model.hardware_settings.LinkSettings`, checked by it).

    Parameters
    ----------
    delay : float
        Transport delay (s, >= 0).
    loss_probability : float
        Bernoulli model: probability of losing the packet of an instant, in ``[0, 1]`` (0 with
        ``loss_model = "gilbert_elliott"``).
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
    loss_model : {"bernoulli", "gilbert_elliott"}
        The loss model (:mod:`fsmctl.model.noise`).
    good_to_bad, bad_to_good : float, optional
        ``loss_model = "gilbert_elliott"``: the transition probabilities ``p`` and ``r`` per instant (both needed,
        ``p + r > 0``).
    loss_good, loss_bad : float, optional
        ``loss_model = "gilbert_elliott"``: loss probabilities in the good (``1 - k``, default 0) and bad
        (``1 - h``, default 1) states.

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
    >>> bursty = link(0.0, 0.0, 0.1, horizon=1.5, seed=1, size=1, loss_model="gilbert_elliott", good_to_bad=0.15,
    ...               bad_to_good=0.3)
    >>> bursty.lost.tolist()  # one burst of 8 lost packets
    [0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1, 0, 0, 0]
    """
    call = _factory_call(link, locals())  # first: the arguments only
    from fsmctl.model.problem import delay_instants

    name = _system_name(name, "link")
    where = f"link {name!r}" if name else "link"
    delay = _scalar(delay, f"{where}: delay", minimum=0.0)
    p = _scalar(loss_probability, f"{where}: loss_probability", minimum=0.0)
    if p > 1:
        raise ScenarioError(f"{where}: loss_probability: must be <= 1, got {p}")
    losses = _loss_model(where, p, loss_model, good_to_bad, bad_to_good, loss_good, loss_bad)
    period, Q = _samples(horizon, period, where)
    _timebase(dt, period, where, stateful=True)
    seed = _count(seed, f"{where}: seed", 0)
    index = _count(index, f"{where}: index", 0)
    m = _count(size, f"{where}: size", 1)
    if not isinstance(signal, str) or not signal or any(c in signal for c in ".[]"):
        raise ScenarioError(f"{where}: signal: must be a non-empty name without '.', '[' or ']', got {_show(signal)}")
    D = int(delay_instants(np.array([delay]), period)[0])
    lost = _noise(where, seed=seed, n_agents=1, n_samples=Q, period=period, **losses(index))["lost"][:, index].copy()
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
