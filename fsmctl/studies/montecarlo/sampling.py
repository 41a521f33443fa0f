"""What a Monte Carlo run draws from its seed: attitudes, inertia, disturbances, topology and hardware."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from fsmctl.model.scenario import Agent, Scenario, Sinusoid
from fsmctl.model.topology import Link, Topology
from fsmctl.studies.montecarlo.settings import CampaignSettings, check_campaign, child_seed, run_noise_seed


def _theta_minus_sin(t: np.ndarray) -> np.ndarray:
    """``t - sin t`` without cancellation for small ``t`` (the Haar CDF of the principal angle times pi)."""
    t = np.asarray(t, dtype=float)
    t2 = t * t
    series = t * t2 / 6.0 * (1.0 - t2 / 20.0 * (1.0 - t2 / 42.0 * (1.0 - t2 / 72.0)))
    return np.where(t < 0.05, series, t - np.sin(t))


def sample_attitudes_mrp(rng: np.random.Generator, count: int, max_angle_deg: float = 180.0) -> np.ndarray:
    """``count`` attitudes uniform over SO(3) (Haar measure) as MRPs of the shadow set, shape ``(count, 3)``.

    A 4-D standard normal vector normalized to the unit sphere is a uniformly distributed unit
    quaternion; with the scalar part made non-negative, ``sigma = q_v / (1 + q_0)`` (Liang et al.
    2012, eq 2) has ``|sigma| <= 1``.  The principal angle ``theta = 4 atan|sigma|`` then has the
    density ``(1 - cos theta) / pi`` on ``[0, pi]``.

    With ``max_angle_deg < 180`` the Haar measure is conditioned on ``theta <= max_angle_deg``: the
    angle is drawn by inverting its CDF ``(theta - sin theta) / pi`` on the truncated range and the
    axis uniformly on the sphere (``sigma = axis tan(theta / 4)``).

    Parameters
    ----------
    rng : numpy.random.Generator
        The random generator.
    count : int
        Number of attitudes.
    max_angle_deg : float, optional
        Bound on the principal angle (deg); 180 (default): all of SO(3).

    Returns
    -------
    numpy.ndarray
        ``(count, 3)`` MRPs with ``|sigma| <= 1``.

    Examples
    --------
    >>> import numpy as np
    >>> from fsmctl.studies.montecarlo import sample_attitudes_mrp
    >>> sigma = sample_attitudes_mrp(np.random.default_rng(0), 1000, max_angle_deg=30.0)
    >>> theta_deg = np.degrees(4 * np.arctan(np.linalg.norm(sigma, axis=1)))
    >>> sigma.shape, bool(theta_deg.max() <= 30.0)
    ((1000, 3), True)
    """
    if max_angle_deg >= 180.0:
        q = rng.standard_normal((count, 4))
        q /= np.linalg.norm(q, axis=1, keepdims=True)
        q *= np.where(q[:, :1] < 0, -1.0, 1.0)
        return q[:, 1:] / (1.0 + q[:, :1])
    bound = math.radians(max_angle_deg)
    target = rng.uniform(0.0, 1.0, count) * _theta_minus_sin(bound)
    lo, hi = np.zeros(count), np.full(count, bound)
    for _ in range(64):  # bisection: t - sin t is increasing on [0, pi]
        mid = 0.5 * (lo + hi)
        below = _theta_minus_sin(mid) < target
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    theta = 0.5 * (lo + hi)
    axis = rng.standard_normal((count, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    return axis * np.tan(theta / 4.0)[:, None]


def _random_rotation(rng: np.random.Generator) -> np.ndarray:
    q = rng.standard_normal(4)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def sample_inertia_perturbation(rng: np.random.Generator, J0: np.ndarray, bound: float) -> np.ndarray:
    """A random ``Delta_J`` (kg m^2): SPD, realizable, ``0 < Delta_J <= rho J0`` with ``rho ~ U(0, bound]``.

    ``Delta_J = R diag(b + c, a + c, a + b) R^T`` is the inertia of a mass distribution with
    principal second moments ``a, b, c ~ U(0, 1)`` (so it satisfies the triangle inequality of a
    rigid body) about uniformly random axes ``R``; it is scaled so that the largest eigenvalue of
    ``J0^-1/2 Delta_J J0^-1/2`` equals ``rho``.  Liang et al. 2012, eq 29 (``J = J0 + Delta_J``).

    Parameters
    ----------
    rng : numpy.random.Generator
        The random generator.
    J0 : numpy.ndarray
        ``(3, 3)`` nominal inertia (kg m^2), symmetric positive definite.
    bound : float
        ``rho_max`` (> 0).

    Returns
    -------
    numpy.ndarray
        ``(3, 3)`` symmetric positive definite ``Delta_J`` (kg m^2).

    Examples
    --------
    >>> import numpy as np
    >>> from fsmctl.studies.montecarlo import sample_inertia_perturbation
    >>> J0 = np.diag([20.0, 25.0, 30.0])
    >>> dJ = sample_inertia_perturbation(np.random.default_rng(1), J0, 0.3)
    >>> S = np.diag(np.diag(J0) ** -0.5)
    >>> bool(np.linalg.eigvalsh(dJ).min() > 0), bool(np.linalg.eigvalsh(S @ dJ @ S).max() <= 0.3)
    (True, True)
    """
    J0 = np.asarray(J0, dtype=float)
    a, b, c = rng.uniform(0.0, 1.0, 3)
    R = _random_rotation(rng)
    rho = bound * (1.0 - rng.uniform(0.0, 1.0))  # (0, bound]
    D = R @ np.diag([b + c, a + c, a + b]) @ R.T
    w, V = np.linalg.eigh(J0)
    inv_sqrt = V @ np.diag(w**-0.5) @ V.T
    top = float(np.linalg.eigvalsh(inv_sqrt @ D @ inv_sqrt)[-1])
    D = D * (rho / top) if top > 0 else np.zeros((3, 3))
    return 0.5 * (D + D.T)


def _random_topology(rng: np.random.Generator, topology: Topology, s: CampaignSettings) -> Topology:
    links = []
    for link in topology.links:
        keep = rng.uniform() >= s.link_dropout
        factor = rng.uniform(s.coupling_low, s.coupling_high)
        period = link.k_j.period
        phase = rng.uniform(0.0, period) if period else link.phase
        if keep:
            links.append(Link(link.receiver, link.sender, link.k_i, link.k_j.scaled(factor), float(phase)))
    return Topology(topology.n_agents, tuple(links))


def sample_run_scenario(base: Scenario, settings: CampaignSettings, seed: np.random.SeedSequence) -> Scenario:
    """The perturbed scenario of one run (everything drawn from ``seed``, in a fixed order).

    Its ``simulation.seed`` is :func:`run_noise_seed` of ``seed``; with ``settings.vary = "noise"`` that is the only
    change to ``base``.  Otherwise the attitudes, rates, inertia, disturbances and topology are drawn from
    ``seed`` (as before the hardware existed, draw for draw), then the hardware ranges that are given from
    children of ``seed`` of their own (:func:`_sample_hardware`).

    Parameters
    ----------
    base : Scenario
        The campaign's base scenario.
    settings : CampaignSettings
        The sampling ranges.
    seed : numpy.random.SeedSequence
        The run's seed (``SeedSequence(settings.seed).spawn(runs)[run]``).

    Returns
    -------
    Scenario
        The run's scenario.

    Raises
    ------
    fsmctl.errors.InputError
        The settings do not fit the scenario (:func:`check_campaign`).

    Examples
    --------
    >>> import numpy as np, fsmctl
    >>> from fsmctl.studies import CampaignSettings
    >>> from fsmctl.studies.montecarlo import sample_run_scenario
    >>> base = fsmctl.paper_scenario("1")
    >>> run = sample_run_scenario(base, CampaignSettings(), np.random.SeedSequence(0))
    >>> run.n_agents == base.n_agents, run.agents[0].sigma0 != base.agents[0].sigma0
    (True, True)
    """
    check_campaign(settings, base)
    noise = {"seed": run_noise_seed(seed)}
    if settings.vary == "noise":
        return base.replace(simulation=noise)
    rng = np.random.default_rng(seed)
    agents = []
    for agent in base.agents:
        sigma0 = sample_attitudes_mrp(rng, 1, settings.attitude_bound_deg)[0]
        omega0 = rng.uniform(-settings.rate_bound, settings.rate_bound, 3)
        delta_J = sample_inertia_perturbation(rng, agent.J0_array, settings.inertia_bound)
        d = agent.disturbance
        amplitude = np.asarray(d.amplitude) * settings.disturbance_scale * rng.uniform(0.0, 1.0, 3)
        phase = rng.uniform(0.0, 2 * math.pi, 3)
        disturbance = Sinusoid(tuple(amplitude.tolist()), d.frequency, tuple(phase.tolist()), d.offset)
        agents.append(
            Agent(
                J0=agent.J0,
                delta_J=tuple(tuple(row) for row in delta_J.tolist()),
                sigma0=tuple(sigma0.tolist()),
                omega0=tuple(omega0.tolist()),
                disturbance=disturbance,
                parameters=agent.parameters,
            )
        )
    topology = _random_topology(rng, base.topology, settings)
    hardware = _sample_hardware(base, settings, topology, seed)
    return base.replace(agents=tuple(agents), topology=topology, simulation=noise, **hardware)  # validated once


def sampled_noise_scale(settings: CampaignSettings, seed: np.random.SeedSequence) -> float:
    """The run's factor on the sensor noise: ``U(low, high)`` of ``settings.sensor_noise_scale`` (1 when unset)."""
    if settings.sensor_noise_scale is None or settings.vary == "noise":
        return 1.0
    low, high = settings.sensor_noise_scale
    return float(np.random.default_rng(child_seed(seed, 1, 2)).uniform(low, high))


def _sample_hardware(
    base: Scenario, settings: CampaignSettings, topology: Topology, seed: np.random.SeedSequence
) -> dict[str, Any]:
    """The ``links``/``sensors`` changes of one run's hardware ranges (children ``(1, 0..2)`` of the run's seed).

    Link values are drawn for the whole n x n table, so the value of link ``i <- j`` does not depend on the other
    links the run keeps; the table holds them on the run's links and NaN elsewhere.
    """
    out: dict[str, Any] = {}
    n = base.n_agents
    links = {}
    for k, (name, key) in enumerate((("link_delay", "delay_table"), ("loss_probability", "loss_table"))):
        bounds = getattr(settings, name)
        if bounds is None:
            continue
        draws = np.random.default_rng(child_seed(seed, 1, k)).uniform(bounds[0], bounds[1], (n, n))
        table = np.full((n, n), np.nan)
        for link in topology.links:
            table[link.receiver, link.sender] = draws[link.receiver, link.sender]
        links[key] = table.tolist()
    if links:
        out["links"] = links
    if settings.sensor_noise_scale is not None:
        factor = sampled_noise_scale(settings, seed)
        star, gyro = base.sensors.star_tracker, base.sensors.gyro
        sensors: dict[str, Any] = {}
        if star is not None:
            sensors["star_tracker"] = replace(star, noise_std=tuple(factor * x for x in star.noise_std))
        if gyro is not None:
            sensors["gyro"] = replace(
                gyro,
                angle_random_walk=factor * gyro.angle_random_walk,
                rate_random_walk=factor * gyro.rate_random_walk,
            )
        out["sensors"] = sensors
    return out
