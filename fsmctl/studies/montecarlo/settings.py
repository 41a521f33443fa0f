"""A Monte Carlo campaign's settings, what it checks before it starts and the lines that describe it."""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np

from fsmctl.errors import InputError
from fsmctl.model.scenario import Scenario, load_scenario
from fsmctl.model.topology import Topology
from fsmctl.policy import CONVERGED_RULE, TOLERANCE_DEG, default_steady_window, steady_window_text

STATUS_OK, STATUS_FAILED, STATUS_DIED = "ok", "failed", "worker-died"
TIMING_VARIABLES = ("wall_time_s", "cpu_time_s")
"""per-run variables that depend on the machine (excluded from reproducibility comparisons)"""
COMPLETE_MARKER = "complete.json"
"""written last: its presence means the campaign in the folder finished"""
CAMPAIGN_FILE = "campaign.json"  # the settings; every chunk file records them too (attribute "settings")
CAMPAIGN_KEYS = ("runs", "seed", "chunk_size")  # in every campaign.json that fsmctl wrote


# ----------------------------------------------------------------------------- settings


@dataclass(frozen=True)
class CampaignSettings:
    """What a campaign perturbs, how it runs, and what counts as converged.

    Units: rad/s for ``rate_bound``, deg for ``attitude_bound_deg`` and ``tolerance_deg``, s for times,
    N m for ``torque_limit``.  ``None`` keeps the scenario's value.  :data:`SAMPLING_RANGES` and
    :data:`HARDWARE_RANGES` describe every sampling range (they are the command line's options).

    Parameters
    ----------
    scenario : str, optional
        A built-in scenario name (default ``"paper"``) or a scenario file.
    case : str or None, optional
        The scenario's case; None: its first case, or the file as it is when it defines no ``[cases]``.
    runs : int, optional
        Number of runs (default 100).
    seed : int, optional
        Seed of every draw (runs are reproducible one by one, whatever the workers).
    inertia_bound : float, optional
        ``rho_max``: ``0 < Delta_J <= rho J0`` with ``rho ~ U(0, rho_max]`` (default 0.3, the paper's).
    disturbance_scale : float, optional
        Disturbance amplitudes ``U(0, S |a_k|)`` of the scenario's ``a_k``, phases ``U(0, 2 pi)`` (eq 29).
    rate_bound : float, optional
        ``omega_i(0)``: every component uniform in ``[-B, B]`` rad/s.
    link_dropout : float, optional
        Probability that a directed link of the scenario's graph is removed.
    coupling_low, coupling_high : float, optional
        The factor ``U(low, high)`` on each link's ``k^j_ij(t)`` (Table 2); factors <= 1 only lower ``k^j``,
        which keeps Theorem 1's ``k^i >= k^j`` (eq 27) where the scenario has it.
    t_final, dt : float or None, optional
        Horizon and integration step (s); None: the scenario's.
    output_interval : float, optional
        Coarse output grid (s): only per-run summaries are kept; settling times are resolved to it.
    torque_limit : float or None, optional
        Torque limit (N m); None: the scenario's.
    tolerance_deg : float, optional
        Converged (:func:`fsmctl.simulation.metrics.converged`): AAEM and RAEM (eqs 42-43) each stay at or below
        this from some time until the end of the run.
    steady_window : float or None, optional
        The final window (s) of the steady-state statistics; None: the policy's
        (:func:`fsmctl.policy.default_steady_window` of the horizon: the last 40 % of it, at most 40 s).
    chunk_size : int, optional
        Runs per chunk file (the unit of resumption and of work sent to a worker).
    attitude_bound_deg : float, optional
        Principal angle bound of ``sigma_i(0)``; 180 = uniform over all of SO(3).
    controller : str, optional
        JSON of ``[controller]`` changes applied to the scenario (the law, its parameters, ...; ``--law``/``--set``).
    vary : {'all', 'noise'}, optional
        ``'all'``: every run draws the sampling ranges and its own noise seed; ``'noise'``: only the noise seed.
    control_period : float or None, optional
        ``simulation.control_period`` of the base scenario (s; 0: continuous control); None: the scenario's.
    link_delay : tuple of float or None, optional
        ``(low, high)`` s: every directed link's delay ``U(low, high)`` per run; None: the scenario's.
    loss_probability : tuple of float or None, optional
        ``(low, high)``: every directed link's packet-loss probability per run; None: the scenario's.
    sensor_noise_scale : tuple of float or None, optional
        ``(low, high)``: a factor per run on the star tracker's noise and the gyro's random walks.

    Examples
    --------
    >>> from fsmctl.studies import CampaignSettings
    >>> settings = CampaignSettings(runs=500, seed=7, loss_probability=[0.0, 0.1], control_period=0.01)
    >>> settings.loss_probability, settings.identity()["runs"]
    ((0.0, 0.1), 500)
    >>> try:
    ...     CampaignSettings(runs=0).validate()
    ... except ValueError as exc:
    ...     print(exc)
    montecarlo: runs must be >= 1, got 0
    """

    scenario: str = "paper"
    case: str | None = None
    """None: the scenario's first case, or the file as it is when it defines no ``[cases]``"""
    runs: int = 100
    seed: int = 0
    inertia_bound: float = 0.3
    """rho_max: 0 < Delta_J <= rho J0 with rho ~ U(0, rho_max]"""
    disturbance_scale: float = 1.0
    rate_bound: float = 0.5
    link_dropout: float = 0.2
    coupling_low: float = 0.5
    coupling_high: float = 1.0
    """factors <= 1 only lower k^j, which keeps Theorem 1's k^i >= k^j (eq 27) where the scenario has it"""
    t_final: float | None = None
    dt: float | None = None
    output_interval: float = 0.1
    """coarse output grid (only per-run summaries are kept; settling times resolved to it); lowered to
    the largest multiple of dt that divides t_final, so the last sample is at t_final"""
    torque_limit: float | None = None
    tolerance_deg: float = TOLERANCE_DEG
    """converged: AAEM and RAEM each stay at or below this from some time until the end (eqs 42-43)"""
    steady_window: float | None = None
    """s; None: :func:`fsmctl.policy.default_steady_window` of the horizon (the last 40 %, at most 40 s)"""
    chunk_size: int = 8
    """8 runs of any number of agents fill whole SIMD lane groups (4 or 8 lanes) when they fly together; 10 runs of
    the paper's 6 agents would leave 4 lanes idle at every step"""
    attitude_bound_deg: float = 180.0
    """principal angle bound of sigma_i(0); 180 = uniform over all of SO(3)"""
    controller: str = ""
    """JSON of ``[controller]`` changes applied to the scenario (the law, its parameters, ...; ``--law``/``--set``):
    part of the campaign's identity, so a resumed campaign flies the same law"""
    vary: str = "all"
    """'all': every run draws the sampling ranges and its own noise seed; 'noise': every run is the base scenario
    with only its noise seed (``simulation.seed``) changed"""
    control_period: float | None = None
    """``simulation.control_period`` of the base scenario in s (0: continuous control); None keeps the scenario's"""
    link_delay: tuple[float, float] | None = None
    """(low, high) s: every directed link's delay U(low, high) per run (``links.delay_table``); None: the scenario's"""
    loss_probability: tuple[float, float] | None = None
    """(low, high): every directed link's packet-loss probability U(low, high) per run (``links.loss_table``)"""
    sensor_noise_scale: tuple[float, float] | None = None
    """(low, high): a factor U(low, high) per run on the star tracker's noise_std and the gyro's N and K"""

    def __post_init__(self) -> None:
        for name, _ in HARDWARE_RANGES:  # [low, high] (JSON, Python lists) or one number: a tuple of floats
            value = getattr(self, name)
            if _is_number(value):
                value = (value, value)
            if isinstance(value, (list, tuple)) and len(value) == 2 and all(_is_number(x) for x in value):
                object.__setattr__(self, name, (float(value[0]), float(value[1])))

    def validate(self) -> None:
        """Raise :class:`~fsmctl.errors.InputError` on a bad setting (one line, names the option).

        Raises
        ------
        fsmctl.errors.InputError
            A setting out of its range.
        """
        if self.vary not in VARY:
            raise InputError(f"montecarlo: vary must be one of {', '.join(VARY)}, got {self.vary!r}")
        for name, _ in HARDWARE_RANGES:
            value = getattr(self, name)
            if value is None:
                continue
            upper = 1.0 if name == "loss_probability" else math.inf
            if not (
                isinstance(value, tuple)
                and len(value) == 2
                and all(math.isfinite(x) for x in value)
                and 0 <= value[0] <= value[1] <= upper
            ):
                need = "0 <= low <= high <= 1" if upper == 1.0 else "finite, 0 <= low <= high"
                raise InputError(f"montecarlo: {name} must be a range (low, high) with {need}, got {value!r}")
        checks = [
            ("runs", self.runs >= 1, ">= 1"),
            ("chunk_size", self.chunk_size >= 1, ">= 1"),
            ("seed", self.seed >= 0, ">= 0"),
            ("inertia_bound", 0 <= self.inertia_bound < 10, "in [0, 10)"),
            ("disturbance_scale", 0 <= self.disturbance_scale < 1e6, ">= 0"),
            ("rate_bound", 0 <= self.rate_bound <= 10, "in [0, 10] rad/s"),
            ("attitude_bound_deg", 0 < self.attitude_bound_deg <= 180, "in (0, 180] deg"),
            ("link_dropout", 0 <= self.link_dropout <= 1, "in [0, 1]"),
            ("coupling_low", 0 <= self.coupling_low <= self.coupling_high, "in [0, coupling_high]"),
            ("coupling_high", self.coupling_high < 1e6, "finite"),
            ("output_interval", self.output_interval > 0, "> 0"),
            ("tolerance_deg", self.tolerance_deg > 0, "> 0"),
        ]
        if self.steady_window is not None and not (self.steady_window > 0 and math.isfinite(self.steady_window)):
            raise InputError(f"montecarlo: steady_window must be > 0, got {self.steady_window!r}")
        for name, ok, need in checks:
            value = getattr(self, name)
            if not ok or (isinstance(value, float) and not math.isfinite(value)):
                raise InputError(f"montecarlo: {name} must be {need}, got {value!r}")
        for name in ("t_final", "dt"):
            value = getattr(self, name)
            if value is not None and not (value > 0 and math.isfinite(value)):
                raise InputError(f"montecarlo: {name} must be a finite number > 0, got {value!r}")
        if self.torque_limit is not None and not self.torque_limit > 0:
            raise InputError(f"montecarlo: torque_limit must be > 0 (or inf), got {self.torque_limit!r}")

    def identity(self) -> dict:
        """Everything that determines the runs' results (a resumed campaign must match it).

        Returns
        -------
        dict
            The settings as a dict.
        """
        return asdict(self)


SAMPLING_RANGES: tuple[tuple[str, str], ...] = (
    (
        "attitude_bound_deg",
        "sigma_i(0): uniform over SO(3) (Haar measure) restricted to principal angles <= this, in deg; "
        "180 = all attitudes",
    ),
    ("rate_bound", "omega_i(0): every component uniform in [-B, B] rad/s"),
    (
        "inertia_bound",
        "rho_max: 0 < Delta_J_i <= rho J0_i (Loewner order), rho ~ U(0, rho_max], a realizable mass "
        "distribution (the paper's Delta_J = 0.3 J0 is rho = 0.3)",
    ),
    ("disturbance_scale", "disturbance amplitudes U(0, S |a_k|) of the scenario's a_k, phases U(0, 2 pi)"),
    ("link_dropout", "probability that a directed link of the scenario's graph is removed"),
    ("coupling_low", "lower end of the factor U(low, high) on each link's k^j_ij(t) (Table 2)"),
    (
        "coupling_high",
        "upper end of that factor; 1 keeps Theorem 1 satisfiable: it needs k^i_ij >= k^j_ij(t) on every "
        "link (eq 27) and factors <= 1 only lower k^j (the paper has k^i/k^j = 1.6; the former 1.7 broke "
        "Theorem 1 in ~90 % of the runs)",
    ),
)
"""``(field, description)`` of every sampling range of :class:`CampaignSettings` (its CLI option is
``--field-with-dashes``)"""

HARDWARE_RANGES: tuple[tuple[str, str], ...] = (
    (
        "link_delay",
        "transport delay of every directed link, U(LOW, HIGH) s drawn per link and run (links.delay_table); "
        "needs a control period",
    ),
    (
        "loss_probability",
        "packet-loss probability of every directed link, U(LOW, HIGH) drawn per link and run (links.loss_table); "
        "needs a control period",
    ),
    (
        "sensor_noise_scale",
        "factor U(LOW, HIGH) per run on the star tracker's noise_std and the gyro's angle and rate random walks "
        "(not its bias); needs [sensors]",
    ),
)
"""``(field, description)`` of the hardware sampling ranges of :class:`CampaignSettings`: ``(low, high)`` or None
(the scenario's values); CLI ``--field-with-dashes LOW,HIGH``"""

VARY = ("all", "noise")
"""values of :attr:`CampaignSettings.vary`"""

NOISE_SEED_BITS = 53
"""a run's noise seed is below 2**53: the dataset stores it exactly as a float64 (NetCDF 3 has no int64)"""


def _is_number(value: Any) -> bool:
    return not isinstance(value, (bool, np.bool_)) and isinstance(value, (int, float, np.integer, np.floating))


def child_seed(seed: np.random.SeedSequence, *key: int) -> np.random.SeedSequence:
    """The child ``key`` of a seed sequence, without spawning (``seed`` is not changed; the same child every time)."""
    return np.random.SeedSequence(seed.entropy, spawn_key=(*seed.spawn_key, *key), pool_size=seed.pool_size)


def run_noise_seed(seed: np.random.SeedSequence) -> int:
    """The ``simulation.seed`` of the run whose seed sequence is ``seed`` (``SeedSequence(campaign seed).spawn(runs)
    [run]``): the first :data:`NOISE_SEED_BITS` bits of its first child's state, an integer in ``[0, 2**53)``.

    Parameters
    ----------
    seed : numpy.random.SeedSequence
        The run's seed sequence.

    Returns
    -------
    int
        The noise seed.

    Examples
    --------
    >>> import numpy as np
    >>> run = np.random.SeedSequence(0).spawn(3)[2]
    >>> run_noise_seed(run) == run_noise_seed(np.random.SeedSequence(0).spawn(10)[2])  # not the number of runs
    True
    """
    state = int(child_seed(seed, 0).generate_state(1, np.uint64)[0])
    return state >> (64 - NOISE_SEED_BITS)


def random_processes(scenario: Scenario) -> list[str]:
    """The random processes a run of ``scenario`` flies (what its ``simulation.seed`` draws); empty: none.

    Parameters
    ----------
    scenario : Scenario
        The scenario.

    Returns
    -------
    list of str
        Among ``"star tracker noise"``, ``"gyro noise"`` and ``"packet loss"``.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.studies.montecarlo import random_processes
    >>> random_processes(fsmctl.paper_scenario("1")), random_processes(fsmctl.load_scenario("paper-hardware"))
    ([], ['star tracker noise', 'gyro noise', 'packet loss'])
    """
    out = []
    star, gyro, links = scenario.sensors.star_tracker, scenario.sensors.gyro, scenario.links
    if star is not None and any(x > 0 for x in star.noise_std):
        out.append("star tracker noise")
    if gyro is not None and (gyro.angle_random_walk > 0 or gyro.rate_random_walk > 0):
        out.append("gyro noise")
    if scenario.simulation.control_period > 0 and scenario.topology.links:
        receivers = [link.receiver for link in scenario.topology.links]
        senders = [link.sender for link in scenario.topology.links]
        if np.any(links.loss_rates(receivers, senders) > 0):
            out.append("packet loss")
    return out


def check_campaign(settings: CampaignSettings, base: Scenario) -> None:
    """Raise :class:`~fsmctl.errors.InputError` when the settings ask for what ``base`` cannot fly.

    A link range without a control period, a sensor-noise range without ``[sensors]``, and ``vary = "noise"``
    with a sampling range changed from its default (it would not be used) or a scenario without a random
    process (every run would be the same).

    Parameters
    ----------
    settings : CampaignSettings
        The campaign's settings.
    base : Scenario
        The base scenario.

    Raises
    ------
    fsmctl.errors.InputError
        The first mismatch, naming the option to change.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.errors import InputError
    >>> from fsmctl.studies import CampaignSettings
    >>> from fsmctl.studies.montecarlo import check_campaign
    >>> try:
    ...     check_campaign(CampaignSettings(link_delay=(0.0, 0.01)), fsmctl.paper_scenario("1"))
    ... except InputError as exc:
    ...     print(str(exc).split(" (")[0])
    montecarlo: link_delay needs a scenario with a control period
    """
    period = base.simulation.control_period
    for name in ("link_delay", "loss_probability"):
        if getattr(settings, name) is not None and not period > 0:
            raise InputError(
                f"montecarlo: {name} needs a scenario with a control period (links act at the control instants); "
                f"{base.label} has simulation.control_period = 0: give --control-period SECONDS"
            )
    if settings.sensor_noise_scale is not None and not base.sensors.enabled:
        raise InputError(
            f"montecarlo: sensor_noise_scale needs a scenario with [sensors] (a star tracker or a gyro); "
            f"{base.label} has none"
        )
    if settings.vary == "noise":
        defaults = CampaignSettings()
        names = [n for n, _ in SAMPLING_RANGES] + [n for n, _ in HARDWARE_RANGES]
        changed = [n for n in names if getattr(settings, n) != getattr(defaults, n)]
        if changed:
            raise InputError(
                f"montecarlo: --vary noise keeps the base scenario, so {', '.join(changed)} would not be used; "
                f"drop {'it' if len(changed) == 1 else 'them'} or use --vary all"
            )
        if not random_processes(base):
            raise InputError(
                f"montecarlo: --vary noise: {base.label} has no random process (no sensor noise, no packet loss), "
                "so every run would be the same; give the scenario [sensors] or links.loss_probability > 0 "
                "(with a control period)"
            )


# ----------------------------------------------------------------------------- sampling


def theorem1_factor_limit(topology: Topology) -> float | None:
    """Largest ``k^j`` factor that keeps ``k^i_ij >= max_t k^j_ij(t)`` on every link (Theorem 1, eq 27).

    ``min`` over links with a non-zero ``k^j`` of ``k^i / max_t k^j`` (1.6 for the paper's Table 2);
    None when no link has a non-zero ``k^j`` (any factor keeps the condition).

    Parameters
    ----------
    topology : Topology
        The communication graph.

    Returns
    -------
    float or None
        The largest factor, or None.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.studies.montecarlo import theorem1_factor_limit
    >>> theorem1_factor_limit(fsmctl.paper_scenario("1").topology)  # k^i = 8, max k^j = 5 (Table 2)
    1.6
    """
    ratios = [link.k_i / link.k_j.max for link in topology.links if link.k_j.max > 0]
    return min(ratios) if ratios else None


def _fitting_output_interval(requested: float, dt: float, t_final: float) -> float:
    """The largest multiple of ``dt`` that is ``<= requested`` (at least ``dt``) and divides ``t_final``.

    So the output grid ends at ``t_final`` and the runs' "final" values are those at ``t_final``.  When
    ``t_final`` is not a multiple of ``dt`` the request is returned as it is (the scenario rejects it).
    """
    ratio = t_final / dt
    n = round(ratio)
    if n < 1 or abs(ratio - n) > 1e-9 * max(1.0, ratio):
        return requested
    k = max(1, min(n, round(requested / dt)))
    best = 1
    d = 1
    while d * d <= n:
        if n % d == 0:
            for m in (d, n // d):
                if best < m <= k:
                    best = m
        d += 1
    return best * dt


def campaign_base(settings: CampaignSettings) -> tuple[CampaignSettings, Scenario]:
    """The base scenario of a campaign and the settings with the case made explicit.

    ``settings.case = None`` selects the scenario's first case, or none when the file defines no
    ``[cases]``; the returned settings name it (so resuming with or without ``--case`` matches).
    The horizon, step and torque limit are the settings' where given, and the output interval is
    :func:`_fitting_output_interval` of the requested one.

    Parameters
    ----------
    settings : CampaignSettings
        The campaign's settings.

    Returns
    -------
    settings : CampaignSettings
        The settings with ``case`` explicit.
    base : Scenario
        The base scenario.

    Raises
    ------
    fsmctl.errors.InputError
        ``settings.controller`` is not a JSON object, or the scenario, its case or the changed settings are
        invalid (:class:`~fsmctl.model.scenario.ScenarioError`).

    Examples
    --------
    >>> from fsmctl.studies import CampaignSettings
    >>> from fsmctl.studies.montecarlo import campaign_base
    >>> settings, base = campaign_base(CampaignSettings(t_final=0.5))
    >>> settings.case, base.label, base.simulation.t_final
    ('1', 'paper case 1', 0.5)
    """
    base = load_scenario(settings.scenario, settings.case)
    sim: dict[str, Any] = {}
    if settings.t_final is not None:
        sim["t_final"] = settings.t_final
    if settings.dt is not None:
        sim["dt"] = settings.dt
    if settings.control_period is not None:
        sim["control_period"] = settings.control_period  # checked by the scenario (>= 0, a multiple of dt)
    ctrl = json.loads(settings.controller) if settings.controller else {}
    if not isinstance(ctrl, dict):
        raise InputError(f"controller: expected a JSON object of [controller] changes, got {settings.controller!r}")
    if settings.torque_limit is not None:
        ctrl["torque_limit"] = settings.torque_limit
    dt = sim.get("dt", base.simulation.dt)
    t_final = sim.get("t_final", base.simulation.t_final)
    sim["output_interval"] = _fitting_output_interval(settings.output_interval, dt, t_final)
    own = {k: ctrl.pop(k) for k in list(ctrl) if k in ("torque_limit", "error_model", "enabled")}
    base = base.with_law(ctrl.pop("law", None), ctrl).replace(simulation=sim, controller=own)
    settings = replace(settings, case=base.case)
    check_campaign(settings, base)
    return settings, base


def describe_campaign(settings: CampaignSettings, base: Scenario) -> list[str]:
    """Lines naming every setting of a campaign (printed when it starts; the option that sets each one).

    Parameters
    ----------
    settings : CampaignSettings
        The campaign's settings.
    base : Scenario
        The base scenario.

    Returns
    -------
    list of str
        One line per group of settings.

    Examples
    --------
    >>> from fsmctl.studies import CampaignSettings
    >>> from fsmctl.studies.montecarlo import campaign_base, describe_campaign
    >>> describe_campaign(*campaign_base(CampaignSettings()))[0]
    'montecarlo: paper case 1: 6 agents, 30 links; 100 runs, seed 0, chunks of 8'
    """
    s, sim = settings, base.simulation
    limit = theorem1_factor_limit(base.topology)
    if limit is None:
        t1 = "Theorem 1: no link has a non-zero k^j, so no factor matters"
    else:
        t1 = f"Theorem 1 (eq 27, k^i >= k^j): factors <= {limit:.4g} keep it on every link of this scenario"
        if s.coupling_high > limit:
            t1 += f"; runs drawing a factor above it fail it (--coupling-high {s.coupling_high:g})"
    torque = base.controller.torque_limit
    head = (
        f"montecarlo: {base.label}: {base.n_agents} agents, {len(base.topology.links)} links; "
        f"{s.runs} runs, seed {s.seed}, chunks of {s.chunk_size}"
    )
    processes = random_processes(base)
    if s.loss_probability is not None and "packet loss" not in processes:
        processes.append("packet loss")
    noise = (
        f"  noise: every run its own simulation.seed (from --seed {s.seed}; the scenario's {sim.seed} is not used); "
        + (f"random processes: {', '.join(processes)}" if processes else "no random process in this scenario")
    )
    period = f"control period {sim.control_period:g} s" if sim.control_period > 0 else "continuous control"
    simulation = (
        f"  simulation: t_final {sim.t_final:g} s, dt {sim.dt:g} s, output every {sim.output_interval:g} s"
        + (
            f" (not the requested {s.output_interval:g} s: the grid must divide t_final)"
            if not math.isclose(sim.output_interval, s.output_interval)
            else ""
        )
        + f", {period} (--control-period), torque limit {torque:g} N m"
    )
    converged = (
        f"  converged: {CONVERGED_RULE.format(tolerance=f'{s.tolerance_deg:g} deg')}; steady statistics over "
        f"{steady_window_text(campaign_steady_window(s, base), sim.t_final)}"
    )
    if s.vary == "noise":
        return [
            head,
            "  vary noise: every run is the base scenario (initial attitudes and rates, inertia, disturbances, "
            "topology, hardware) with only its noise seed changed (--vary noise)",
            noise,
            simulation,
            converged,
        ]
    hardware = [
        f"{what} U({getattr(s, name)[0]:g}, {getattr(s, name)[1]:g}){unit} (--{name.replace('_', '-')})"
        for name, what, unit in (
            ("link_delay", "link delay per link", " s"),
            ("loss_probability", "packet loss per link", ""),
            ("sensor_noise_scale", "sensor noise times", ""),
        )
        if getattr(s, name) is not None
    ]
    if hardware:
        hardware_line = ["  hardware: " + "; ".join(hardware)]
    elif base.actuator.enabled or base.sensors.enabled or base.links_active:
        hardware_line = [
            "  hardware: the scenario's (sample it: --link-delay, --loss-probability, --sensor-noise-scale)"
        ]
    else:
        hardware_line = []
    return [
        head,
        f"  attitude: sigma_i(0) uniform over SO(3), principal angle <= {s.attitude_bound_deg:g} deg "
        "(--attitude-bound-deg)",
        f"  rate: omega_i(0) components U(-{s.rate_bound:g}, {s.rate_bound:g}) rad/s (--rate-bound)",
        f"  inertia: 0 < Delta_J_i <= rho J0_i, rho ~ U(0, {s.inertia_bound:g}] (--inertia-bound)",
        f"  disturbance: amplitudes U(0, {s.disturbance_scale:g} |a_k|), phases U(0, 2 pi) (--disturbance-scale)",
        f"  links: each removed with probability {s.link_dropout:g} (--link-dropout); k^j_ij(t) times "
        f"U({s.coupling_low:g}, {s.coupling_high:g}) (--coupling-low, --coupling-high), random phase",
        f"  {t1}",
        *hardware_line,
        noise,
        simulation,
        converged,
    ]


# ----------------------------------------------------------------------------- one run


def campaign_steady_window(settings: CampaignSettings, base: Scenario) -> float:
    """The steady window (s) of a campaign's runs: ``settings.steady_window``, or the policy's for the horizon.

    Parameters
    ----------
    settings : CampaignSettings
        The campaign.
    base : Scenario
        Its base scenario (:func:`campaign_base`): the horizon.

    Returns
    -------
    float
        :func:`fsmctl.policy.default_steady_window` of ``base.simulation.t_final`` when ``settings.steady_window``
        is None, else that window clipped to the horizon (as every run's summary takes it).

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.studies.montecarlo import CampaignSettings
    >>> from fsmctl.studies.montecarlo.settings import campaign_steady_window
    >>> base = fsmctl.paper_scenario("1")
    >>> campaign_steady_window(CampaignSettings(), base), campaign_steady_window(CampaignSettings(steady_window=5.0), base)
    (40.0, 5.0)
    """
    horizon = base.simulation.t_final
    return default_steady_window(horizon) if settings.steady_window is None else min(settings.steady_window, horizon)
