"""Monte Carlo robustness campaigns: ``fsmctl montecarlo`` and a Python API.

Each run perturbs a base scenario (Liang et al. 2012, Sec. 4) with

* an inertia perturbation ``Delta_J_i`` that is itself the inertia tensor of an added
  rigid mass distribution: symmetric positive definite *and* physically realizable
  (principal moments ``b + c, a + c, a + b`` with ``a, b, c > 0`` second moments, uniformly
  random principal axes), scaled so that ``0 < Delta_J_i <= rho_i J0_i`` in the Loewner order with
  ``rho_i ~ U(0, inertia_bound]`` (the paper's ``Delta_J = 0.3 J0`` is the extreme
  ``rho = 0.3``).  The true inertia ``J0_i + Delta_J_i`` is then SPD and, whenever ``J0_i`` is,
  realizable too (a sum of mass distributions);
* disturbance amplitudes ``U(0, disturbance_scale |a_k|)`` (signs and frequencies of the
  scenario's ``a_k``) and phases ``U(0, 2 pi)`` (eq 1's ``d_i(t)``);
* initial attitudes uniform over SO(3) (Haar measure), optionally restricted to principal angles
  ``<= attitude_bound_deg``, as MRPs of the shadow set ``|sigma| <= 1`` (eq 2), and rates with
  ``|omega_k(0)| <= rate_bound`` uniformly;
* a random switching topology: every directed link of the scenario's graph is kept with probability
  ``1 - link_dropout``, its schedule ``k^j_ij(t)`` gets a uniform random phase over its period and
  its non-zero values a factor ``U(coupling_low, coupling_high)`` (Table 2, eq 19).  The default
  factor range ``[0.5, 1]`` only lowers ``k^j``: Theorem 1 needs ``k^i_ij >= k^j_ij(t)`` for every
  link (eq 27's ``eta`` interval is empty otherwise, :func:`fsmctl.proofs.theorem1.eta_interval`) and
  a lower ``k^j`` widens that interval, so a run keeps every ``eta`` the scenario admits.  The paper's
  Table 2 has ``k^i / k^j = 8 / 5 = 1.6``; the former hidden range ``[0.5, 1.7]`` broke Theorem 1 in
  about 90 % of the runs, which then said nothing about the theorem.  Removing single directed links
  can still make eq 26's balance infeasible in a few runs; ``theorem1_holds`` reports every run.

Every range is a :class:`CampaignSettings` field and a command-line option whose ``--help`` shows the
default; the settings are printed when a campaign starts and stored in ``campaign.json``,
``summary.json`` and the dataset's attributes.

Flight hardware (issue 13: ``[actuator]``, ``[sensors]``, ``[links]``, ``simulation.control_period``,
``simulation.seed``; :data:`HARDWARE_RANGES`):

* **noise seeds**: every run flies its own ``simulation.seed`` (the seed of its sensor noise and packet
  losses), :func:`run_noise_seed` of the run's seed sequence: the first 53 bits of
  ``SeedSequence(seed).spawn(runs)[run].spawn(1)[0].generate_state(1, numpy.uint64)``.  It depends on the
  campaign seed and the run's index only (not on the workers, the chunking, the backend or the number of
  runs) and is stored per run in the dataset (``noise_seed``, a float64 holding the integer exactly: NetCDF 3
  has no 64-bit integers), so ``scenario.replace(simulation={"seed": int(ds.noise_seed[k])})`` flies run
  ``k``'s noise again.
* ``vary = "all"`` (default, ``--vary all``): the ranges above and below are drawn and the noise seed is
  set.  ``vary = "noise"`` (``--vary noise``): every run is the base scenario (initial attitudes and rates,
  inertia, disturbances, topology, hardware) with only its noise seed changed, the Monte Carlo over the
  noise of "the paper's law on real hardware"; it refuses a scenario without a random process (every run
  would be the same) and sampling ranges that differ from their defaults (they would not be used).
* hardware ranges, drawn only when given (``None``, the default, keeps the scenario's values, so a
  scenario without hardware is flown exactly as before): ``link_delay = (low, high)`` s and
  ``loss_probability = (low, high)`` draw an independent ``U(low, high)`` per directed link and run (written
  as ``links.delay_table`` / ``links.loss_table``; the draws of link ``i <- j`` do not depend on which other
  links the run keeps); they need ``simulation.control_period > 0`` (links act at the control instants).
  ``sensor_noise_scale = (low, high)`` multiplies the star tracker's ``noise_std`` and the gyro's angle and
  rate random walks ``N``, ``K`` (not its constant bias) by one ``U(low, high)`` factor per run; it needs
  ``[sensors]``.  These draws come from children of the run's seed sequence of their own, after and apart
  from the draws above, so adding a range changes no other draw.  The per-run values are in the dataset
  (``link_delay_max_s``, ``loss_probability_max``, ``sensor_noise_scale``), with the wheels' peak speed and
  momentum (``wheel_speed_peak_rad_per_s``, ``wheel_momentum_peak_N_m_s``; NaN without wheels).
* ``control_period`` (``--control-period``) sets the base scenario's ``simulation.control_period``
  through ``scenario.replace`` (``None``: the scenario's).

Per run the dataset holds settling times of AAEM/RAEM (eqs 42-43), steady-state accuracy, peak
torques, saturation time, whether Theorem 1's topology conditions hold for the run's graph
(:func:`fsmctl.proofs.theorem1.analyze_topology`), whether the configured ``delta_i`` exceeds
Theorem 2's requirement at the reference (``sigma_e = 0, omega_e = 0``, bound boxes of the
disturbance and the reference; :func:`fsmctl.proofs.theorem2.delta_requirements`), whether it
converged, and a status (``ok``, ``failed`` with the error, ``worker-died``).  The "final" values are
those at ``t_final``: the campaign's output grid divides the horizon, and a run whose last sample is
not at ``t_final`` is ``failed``, never ``ok``.

Per-run seeds come from ``numpy.random.SeedSequence(seed).spawn(runs)``, so a seeded campaign
gives the same runs (perturbations and noise seeds) whatever the number of workers, chunking or backend
(process pool or Dask); run ``k``'s seed is built for its chunk alone (``spawn_key`` ``(k,)``, the same
sequence without spawning the other runs'), so nothing of the campaign grows with ``runs`` before it starts
except what :func:`check_campaign_memory` checks against the available memory first.
Runs are grouped in chunks; every finished chunk is written to ``OUT/chunks/chunk_NNNNN.nc`` at
once, so an interrupted campaign resumes (``--resume``) with only the missing chunks.  The settings are
in ``OUT/campaign.json`` and in every chunk file (attribute ``settings``), with the fingerprint of the
problem they name (``problem``: :func:`fsmctl.simulation.results_io.problem_fingerprint`, the base scenario as
flown, the law's content hash, the fsmctl version): a resumed campaign must have the same ones (a scenario
file or law changed since is refused, naming what changed), and a ``campaign.json`` that is damaged (cut short, not JSON) or missing is rebuilt from
the chunk files when they all record this campaign's settings (a warning on the ``fsmctl`` logger names
the file); otherwise the error says which settings the chunks record.

Outputs are written atomically (a hidden temporary file, then a rename) and ``OUT/complete.json`` is
written last: a folder without it holds an unfinished campaign.  A campaign that fails or is
interrupted before any chunk is written leaves no folder behind (only what it created is removed).
JSON files are strict (NaN is ``null``, infinities are the strings ``"inf"``/``"-inf"``).

Interrupts: ``SIGINT`` (Ctrl-C) and ``SIGTERM`` stop the workers at once (queued chunks cancelled,
running ones terminated), keep the finished chunks, and :func:`run_campaign` raises
:class:`~fsmctl.studies.parallel.CampaignInterrupted`; ``fsmctl montecarlo`` prints one line and exits with
``128 + signal``: **130 for SIGINT, 143 for SIGTERM**.  Local workers die with the campaign even when it
is killed (``SIGKILL``): see :func:`fsmctl.studies.parallel.worker_pool`.
"""

from __future__ import annotations

import contextlib
import errno
import json
import logging
import math
import os
import socket
import struct
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from fsmctl.errors import EnvironmentProblem, InputError, ResourceLimitError
from fsmctl.model.scenario import Agent, Scenario, Sinusoid, load_scenario
from fsmctl.model.topology import Link, Topology
from fsmctl.outputs import jsonable, temporary_files, write_json
from fsmctl.studies.parallel import CampaignInterrupted, interrupt_guard, single_threaded_workers, worker_pool

__all__ = [
    "CampaignSettings",
    "CampaignResult",
    "CampaignInterrupted",
    "SAMPLING_RANGES",
    "HARDWARE_RANGES",
    "VARY",
    "sample_inertia_perturbation",
    "sample_attitudes_mrp",
    "sample_run_scenario",
    "run_noise_seed",
    "random_processes",
    "check_campaign",
    "check_campaign_memory",
    "campaign_base",
    "describe_campaign",
    "theorem1_factor_limit",
    "run_one",
    "run_campaign",
    "finish_campaign",
    "summarize",
    "plot_histograms",
]

STATUS_OK, STATUS_FAILED, STATUS_DIED = "ok", "failed", "worker-died"
TIMING_VARIABLES = ("wall_time_s", "cpu_time_s")
"""per-run variables that depend on the machine (excluded from reproducibility comparisons)"""
COMPLETE_MARKER = "complete.json"
"""written last: its presence means the campaign in the folder finished"""
_CAMPAIGN_FILE = "campaign.json"  # the settings; every chunk file records them too (attribute "settings")
_CAMPAIGN_KEYS = ("runs", "seed", "chunk_size")  # in every campaign.json that fsmctl wrote
DASK_TIMEOUT_S = 10.0
"""default wait for a Dask scheduler to accept a connection and send its handshake"""
_DASK_HANDSHAKE_MAX_BYTES = 1 << 16  # a scheduler's handshake is ~60 bytes
_log = logging.getLogger(__name__)


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
        Converged: AAEM and RAEM (eqs 42-43) below this at the end, and settled.
    steady_window : float, optional
        The final window (s) of the steady-state statistics.
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
    tolerance_deg: float = 1.0
    """converged: AAEM and RAEM below this at the end and settled (eqs 42-43)"""
    steady_window: float = 20.0
    chunk_size: int = 10
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
            ("steady_window", self.steady_window > 0, "> 0"),
        ]
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


def _child(seed: np.random.SeedSequence, *key: int) -> np.random.SeedSequence:
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
    state = int(_child(seed, 0).generate_state(1, np.uint64)[0])
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
        if np.any(links.per_link(receivers, senders, "loss_probability") > 0):
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
    return float(np.random.default_rng(_child(seed, 1, 2)).uniform(low, high))


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
        draws = np.random.default_rng(_child(seed, 1, k)).uniform(bounds[0], bounds[1], (n, n))
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


def _base_scenario(settings: CampaignSettings) -> Scenario:
    return campaign_base(settings)[1]


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
    'montecarlo: paper case 1: 6 agents, 30 links; 100 runs, seed 0, chunks of 10'
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
        f"  converged: AAEM and RAEM < {s.tolerance_deg:g} deg at t_final and settled; "
        f"steady window {s.steady_window:g} s"
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

_SCALARS = (
    "aaem_settling_s",
    "raem_settling_s",
    "aaem_settling_tight_s",
    "raem_settling_tight_s",
    "aaem_final_deg",
    "raem_final_deg",
    "aaem_steady_max_deg",
    "raem_steady_max_deg",
    "u_max_abs_N_m",
    "u_unsaturated_max_N_m",
    "saturated_time_max_s",
    "last_saturation_s",
    "theorem1_lambda_min",
    "theorem2_margin",
    "inertia_rho_max",
    "initial_angle_max_deg",
    "initial_rate_max_rad_per_s",
    "disturbance_amplitude_max_N_m",
    "n_links",
    "link_delay_max_s",
    "loss_probability_max",
    "sensor_noise_scale",
    "wheel_speed_peak_rad_per_s",
    "wheel_momentum_peak_N_m_s",
    "wall_time_s",
    "cpu_time_s",
)
_FLAGS = ("converged", "theorem1_holds", "theorem2_at_reference_holds")
_PER_AGENT = ("saturated_time_s", "theta_e_final_deg")


def _nan_record(n_agents: int) -> dict:
    rec: dict[str, Any] = {k: math.nan for k in _SCALARS}
    rec.update({k: False for k in _FLAGS})
    rec.update({k: np.full(n_agents, np.nan) for k in _PER_AGENT})
    return rec


def _check_final_sample(time_s: np.ndarray, t_final: float) -> None:
    """Raise unless the last output sample is at ``t_final`` (within rounding): "final" means at t_final."""
    t_end = float(time_s[-1]) if len(time_s) else math.nan
    if not math.isclose(t_end, t_final, rel_tol=1e-9, abs_tol=1e-12):
        raise RuntimeError(
            f"the output grid ends at t = {t_end:.9g} s, not at t_final = {t_final:.9g} s: "
            "the final values would come from the wrong sample"
        )


def run_one(base: Scenario, settings: CampaignSettings, index: int, seed: np.random.SeedSequence) -> dict:
    """Simulate run ``index`` and return its summary record (raises on failure: the caller records it).

    The "final" values (``aaem_final_deg``, ``theta_e_final_deg``, ``converged``) are taken at
    ``t_final``; a result whose last sample is elsewhere raises, so the run is ``failed``.
    (:func:`_run_chunk` flies a chunk's runs together, :func:`fsmctl.simulation.simulator.simulate_many`, with the
    same records.)

    Parameters
    ----------
    base : Scenario
        The campaign's base scenario.
    settings : CampaignSettings
        The campaign's settings.
    index : int
        The run's index.
    seed : numpy.random.SeedSequence
        The run's seed (:func:`sample_run_scenario`).

    Returns
    -------
    dict
        The run's summary: settling times, final errors, Theorem 1 and 2 checks, torques, what was drawn.

    Examples
    --------
    >>> import numpy as np
    >>> from fsmctl.studies import CampaignSettings
    >>> from fsmctl.studies.montecarlo import campaign_base, run_one
    >>> settings, base = campaign_base(CampaignSettings(t_final=0.5))
    >>> record = run_one(base, settings, 0, np.random.SeedSequence(0).spawn(1)[0])
    >>> record["converged"], record["u_max_abs_N_m"] <= base.controller.torque_limit
    (False, True)
    """
    from fsmctl.simulation.simulator import simulate

    wall, cpu = time.perf_counter(), time.process_time()
    scenario = sample_run_scenario(base, settings, seed)
    result = simulate(scenario, progress=False)
    rec = run_record(scenario, settings, seed, result)
    rec["wall_time_s"] = time.perf_counter() - wall
    rec["cpu_time_s"] = time.process_time() - cpu
    return rec


def run_record(scenario: Scenario, settings: CampaignSettings, seed: np.random.SeedSequence, result) -> dict:
    """The summary record of a run of ``scenario`` (drawn from ``seed``) from its result (raises on a bad result).

    Parameters
    ----------
    scenario : Scenario
        The run's scenario (:func:`sample_run_scenario`).
    settings : CampaignSettings
        The campaign (tolerance, steady window, noise ranges).
    seed : numpy.random.SeedSequence
        The run's seed.
    result : SimulationResult
        Its result (:func:`fsmctl.simulate`, or one entry of :func:`fsmctl.simulate_many`).

    Returns
    -------
    dict
        The record :func:`run_one` returns, with ``wall_time_s`` and ``cpu_time_s`` left NaN for the caller.

    Examples
    --------
    >>> import numpy as np, fsmctl
    >>> from fsmctl.studies.montecarlo import CampaignSettings, campaign_base, run_record, sample_run_scenario
    >>> settings, base = campaign_base(CampaignSettings(runs=1, t_final=0.5))
    >>> seed = np.random.SeedSequence(settings.seed).spawn(1)[0]
    >>> scenario = sample_run_scenario(base, settings, seed)
    >>> rec = run_record(scenario, settings, seed, fsmctl.simulate(scenario))
    >>> rec["converged"], bool(np.isnan(rec["wall_time_s"]))
    (False, True)
    """
    from fsmctl.proofs.theorem1 import analyze_topology
    from fsmctl.proofs.theorem2 import Region, delta_requirements
    from fsmctl.simulation.metrics import principal_angles

    _check_final_sample(np.asarray(result.time), scenario.simulation.t_final)
    tol = settings.tolerance_deg
    summary = result.summary(tolerances_deg=(tol, 0.1 * tol), steady_window=settings.steady_window)
    aaem, raem = result.aaem_deg, result.raem_deg
    t1 = analyze_topology(scenario.topology, scenario.simulation.t_final)
    paper_law = scenario.law.paper_theorems is not None  # Theorems 1-2 apply to a law that declares them
    t2 = (
        delta_requirements(scenario, Region(0.0, 0.0), n_random=0, dt_reference=None, search_scale=False)
        if paper_law
        else None
    )
    margins = (
        [c / r if r > 0 else math.inf for a in t2.agents for c, r in zip(a.configured, a.reference_bound, strict=True)]
        if t2 is not None
        else [math.nan]
    )
    rec = _nan_record(scenario.n_agents)
    rec.update(
        aaem_settling_s=summary["aaem_settling_s"][f"{tol:g}"],
        raem_settling_s=summary["raem_settling_s"][f"{tol:g}"],
        aaem_settling_tight_s=summary["aaem_settling_s"][f"{0.1 * tol:g}"],
        raem_settling_tight_s=summary["raem_settling_s"][f"{0.1 * tol:g}"],
        aaem_final_deg=float(aaem[-1]),
        raem_final_deg=float(raem[-1]),
        aaem_steady_max_deg=summary["aaem_steady_max_deg"],
        raem_steady_max_deg=summary["raem_steady_max_deg"],
        u_max_abs_N_m=summary["u_max_abs_N_m"],
        u_unsaturated_max_N_m=summary["u_unsaturated_max_N_m"],
        saturated_time_max_s=float(np.max(result.saturated_time)),
        last_saturation_s=summary["last_saturation_s"],
        theorem1_lambda_min=float(t1.lambda_min),
        theorem2_margin=float(min(margins)),
        inertia_rho_max=max(_relative_perturbation(a) for a in scenario.agents),
        initial_angle_max_deg=float(np.degrees(principal_angles(np.array([a.sigma0 for a in scenario.agents]))).max()),
        initial_rate_max_rad_per_s=float(np.abs([a.omega0 for a in scenario.agents]).max()),
        disturbance_amplitude_max_N_m=float(np.abs([a.disturbance.amplitude for a in scenario.agents]).max()),
        n_links=float(len(scenario.topology.links)),
        **_hardware_record(scenario, sampled_noise_scale(settings, seed)),
        **{k: summary[k] for k in ("wheel_speed_peak_rad_per_s", "wheel_momentum_peak_N_m_s") if k in summary},
        converged=bool(
            aaem[-1] < tol
            and raem[-1] < tol
            and math.isfinite(summary["aaem_settling_s"][f"{tol:g}"])
            and math.isfinite(summary["raem_settling_s"][f"{tol:g}"])
        ),
        theorem1_holds=bool(t1.holds) and paper_law,
        theorem2_at_reference_holds=bool(t2 is not None and t2.ok),
        saturated_time_s=np.asarray(result.saturated_time, dtype=float),
        theta_e_final_deg=np.degrees(result.theta_e[-1]),
    )
    return rec


def _hardware_record(scenario: Scenario, noise_scale: float) -> dict[str, float]:
    """The run's link delay and loss (largest over its links; 0 without links or a control period) and the factor
    on its sensor noise (NaN without sensors)."""
    links = scenario.topology.links
    out = {"link_delay_max_s": 0.0, "loss_probability_max": 0.0}
    if links and scenario.simulation.control_period > 0:
        receivers, senders = [lk.receiver for lk in links], [lk.sender for lk in links]
        out["link_delay_max_s"] = float(np.max(scenario.links.per_link(receivers, senders, "delay")))
        out["loss_probability_max"] = float(np.max(scenario.links.per_link(receivers, senders, "loss_probability")))
    out["sensor_noise_scale"] = noise_scale if scenario.sensors.enabled else math.nan
    return out


def _relative_perturbation(agent: Agent) -> float:
    J0, dJ = agent.J0_array, np.array(agent.delta_J)
    w, V = np.linalg.eigh(J0)
    inv_sqrt = V @ np.diag(w**-0.5) @ V.T
    return float(np.linalg.eigvalsh(inv_sqrt @ dJ @ inv_sqrt)[-1])


RunFunction = Callable[[Scenario, CampaignSettings, int, np.random.SeedSequence], dict]


def _failed(k: int, exc: BaseException, n_agents: int) -> tuple[int, str, str, dict]:
    return (k, STATUS_FAILED, f"{type(exc).__name__}: {exc}".splitlines()[0][:500], _nan_record(n_agents))


def _run_chunk(
    base: Scenario, settings: CampaignSettings, indices: Sequence[int], run_fn: RunFunction | None = None
) -> list[tuple[int, str, str, dict]]:
    """Runs ``indices``; each gives ``(index, status, message, record)``; a failing run does not stop the chunk.

    Without ``run_fn`` the chunk's runs fly together (:func:`fsmctl.simulation.simulator.simulate_many`: batches in
    one compiled loop, each run's results those of its run alone, bit for bit) and each gets :func:`run_record`;
    ``wall_time_s``/``cpu_time_s`` are then its own drawing and summary plus its share of the batch's flight.
    ``run_fn`` (e.g. :func:`run_one`) runs them one by one.
    """
    # Reaches only BLAS libraries loaded after this point (e.g. SciPy's, at the first linprog). The local
    # pool's workers get one thread from their environment at start (parallel.single_threaded_workers).
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    # run k's seed is SeedSequence(seed).spawn(runs)[k], built for this chunk's runs alone (spawning all the
    # campaign's seeds in every chunk would cost O(runs) per chunk)
    seeds = {k: _child(np.random.SeedSequence(settings.seed), k) for k in indices}
    if run_fn is not None:
        out = []
        for k in indices:
            try:
                out.append((k, STATUS_OK, "", run_fn(base, settings, k, seeds[k])))
            except Exception as exc:  # a failed run is reported in the dataset, never dropped
                out.append(_failed(k, exc, base.n_agents))
        return out
    return _run_chunk_together(base, settings, indices, seeds)


def _run_chunk_together(
    base: Scenario, settings: CampaignSettings, indices: Sequence[int], seeds: Mapping[int, np.random.SeedSequence]
) -> list[tuple[int, str, str, dict]]:
    from fsmctl.simulation.simulator import SimulationError, simulate_many

    rows: dict[int, tuple[int, str, str, dict]] = {}
    drawn: dict[int, Scenario] = {}
    own = {}  # per run: (wall, cpu) of its own work
    for k in indices:
        wall, cpu = time.perf_counter(), time.process_time()
        try:
            drawn[k] = sample_run_scenario(base, settings, seeds[k])
        except Exception as exc:
            rows[k] = _failed(k, exc, base.n_agents)
        own[k] = (time.perf_counter() - wall, time.process_time() - cpu)
    flying = list(drawn)
    wall, cpu = time.perf_counter(), time.process_time()
    try:
        results = simulate_many([drawn[k] for k in flying], errors="return")
    except Exception:  # not one run's failure (e.g. memory): one by one, so each run gets its own outcome
        return _run_chunk(base, settings, indices, run_one)
    share = ((time.perf_counter() - wall) / max(1, len(flying)), (time.process_time() - cpu) / max(1, len(flying)))
    for k, result in zip(flying, results, strict=True):
        wall, cpu = time.perf_counter(), time.process_time()
        try:
            if isinstance(result, SimulationError):
                raise result
            rec = run_record(drawn[k], settings, seeds[k], result)
        except Exception as exc:  # a failed run is reported in the dataset, never dropped
            rows[k] = _failed(k, exc, base.n_agents)
            continue
        rec["wall_time_s"] = own[k][0] + share[0] + time.perf_counter() - wall
        rec["cpu_time_s"] = own[k][1] + share[1] + time.process_time() - cpu
        rows[k] = (k, STATUS_OK, "", rec)
    return [rows[k] for k in indices]


# ----------------------------------------------------------------------------- files


def _environment_problem(what: str, exc: OSError) -> EnvironmentProblem:
    if isinstance(exc, EnvironmentProblem):
        return exc
    return EnvironmentProblem(exc.errno or errno.EIO, f"{what}: {exc.strerror or exc}")


def _write_netcdf(ds, path: Path, *, compress: bool = True) -> None:
    from fsmctl.simulation.results_io import write_netcdf

    write_netcdf(ds, path, compress=compress)


def _chunk_path(out: Path, c: int) -> Path:
    return out / "chunks" / f"chunk_{c:05d}.nc"


def _chunk_dataset(rows: list[tuple[int, str, str, dict]], n_agents: int, seed: int | None = None):
    """One chunk's runs as a dataset; with the campaign's ``seed``, every run's ``noise_seed`` (its
    :func:`run_noise_seed`, drawn for this chunk's runs alone: ``SeedSequence(seed).spawn(runs)[run]`` without
    spawning the others)."""
    import xarray as xr

    rows = sorted(rows, key=lambda r: r[0])
    run = np.array([r[0] for r in rows], dtype=np.int64)
    data: dict[str, Any] = {}
    units = {"_N_m_s": "N m s", "_s": "s", "_deg": "deg", "_N_m": "N m", "_rad_per_s": "rad/s"}

    def unit(name: str) -> str:
        return next((u for suffix, u in units.items() if name.endswith(suffix)), "1")

    for k in _SCALARS:
        data[k] = xr.Variable(("run",), np.array([r[3][k] for r in rows], dtype=float), {"units": unit(k)})
    for k in _FLAGS:
        data[k] = xr.Variable(("run",), np.array([bool(r[3][k]) for r in rows], dtype=np.int8), {"units": "1 = true"})
    for k in _PER_AGENT:
        arr = np.array([np.asarray(r[3][k], dtype=float) for r in rows]).reshape(len(rows), n_agents)
        data[k] = xr.Variable(("run", "agent"), arr, {"units": unit(k)})
    if seed is not None:
        root = np.random.SeedSequence(seed)
        data["noise_seed"] = xr.Variable(
            ("run",),
            np.array([float(run_noise_seed(_child(root, r[0]))) for r in rows], dtype=float),
            {
                "units": "1",
                "long_name": "the run's simulation.seed (an integer below 2**53, exact in float64: NetCDF 3 has no int64)",
            },
        )
    data["status"] = xr.Variable(("run",), np.array([r[1] for r in rows], dtype=object))
    data["message"] = xr.Variable(("run",), np.array([r[2] for r in rows], dtype=object))
    return xr.Dataset(data, coords={"run": run, "agent": np.arange(1, n_agents + 1, dtype=np.int32)})


class _OutputFolder:
    """``OUT``: created on demand, checked against a resumed campaign, removed again if nothing was written."""

    def __init__(self, out: Path):
        self.out = out
        self.chunks = out / "chunks"
        self._created_dirs: list[Path] = []  # deepest first
        self._created_meta = False

    def prepare(self, ident: dict, resume: bool) -> None:
        """Create ``OUT`` and write ``campaign.json`` (``ident``: :func:`_campaign_record`), or check a resumed one."""
        out = self.out
        if out.exists() and not out.is_dir():
            raise EnvironmentProblem(
                errno.ENOTDIR, f"--out {out}: cannot create the output folder (a file is in the way)"
            )
        missing = []
        p = out.absolute()
        while not os.path.lexists(p) and p.parent != p:
            missing.append(p)
            p = p.parent
        chunks_missing = not self.chunks.is_dir()
        self._created_dirs = [self.chunks.absolute(), *missing] if chunks_missing else missing
        try:
            out.mkdir(parents=True, exist_ok=True)
            self.chunks.mkdir(exist_ok=True)
        except OSError as exc:
            self._remove_created()
            raise EnvironmentProblem(
                exc.errno or errno.EIO, f"--out {out}: cannot create the output folder ({exc.strerror or exc})"
            ) from None
        meta = out / _CAMPAIGN_FILE
        if meta.is_file():
            if not resume:
                raise InputError(
                    f"{out} already holds a campaign; pass --resume to continue it or choose another --out"
                )
            old, damage = _read_campaign_file(meta)
            if damage is not None:
                self._recover(meta, f"{meta} is damaged ({damage})", ident)
            elif old != ident:
                kind, detail = _difference(old, ident)
                raise InputError(f"{out} holds a campaign {kind} ({detail}); cannot resume")
        elif any(self.chunks.glob("chunk_*.nc")):
            if not resume:
                raise InputError(
                    f"{out}/chunks holds chunk files but no {_CAMPAIGN_FILE}; pass --resume to rebuild it from them "
                    "or choose another --out"
                )
            self._recover(meta, f"{meta} is missing", ident)
        self._created_meta = not meta.exists()
        marker = out / COMPLETE_MARKER
        try:
            marker.unlink(missing_ok=True)  # the campaign in the folder is (again) under way
        except OSError as exc:
            raise _environment_problem(f"cannot remove {marker}", exc) from exc
        try:
            write_json(meta, ident)
        except BaseException:
            self.discard_if_empty()
            raise

    def _recover(self, meta: Path, what: str, ident: dict) -> None:
        """``campaign.json`` is damaged or missing: resume if the chunk files record these settings, else explain.

        Every chunk file records the settings of its campaign (attribute ``settings``).  When the readable
        chunk files all record ``ident``, the campaign is this one and ``prepare`` rewrites ``campaign.json``;
        without a readable chunk nothing of the old campaign is kept and this one starts afresh.  Unreadable
        chunk files (cut short by an interrupt) are flown again anyway.
        """
        recorded = {}
        for path in self.chunk_files():
            try:
                recorded[path.name] = _chunk_settings(path)
            except Exception:  # unreadable: the chunk is flown again and its file replaced
                continue
        fix = f"start afresh in another --out or after removing {self.out}"
        if any(v is None for v in recorded.values()):
            unrecorded = sorted(k for k, v in recorded.items() if v is None)
            raise InputError(
                f"{what}; cannot resume: the chunk files do not record the campaign's settings ({unrecorded[0]} "
                f"records none: an older fsmctl wrote it); {fix}"
            )
        different = {k: v for k, v in recorded.items() if v != ident}
        if different:
            name, other = sorted(different.items())[0]
            kind, detail = _difference(other, ident)
            raise InputError(
                f"{what}; cannot resume: the chunk files record a campaign {kind} ({name}: {detail}); resume with "
                f"what they record, or {fix}"
            )
        if recorded:
            _log.warning("%s; rebuilt from the %d chunk files, which record these settings", what, len(recorded))
        else:
            _log.warning("%s; no chunk file to keep: the campaign starts afresh", what)

    def chunk_files(self) -> list[Path]:
        try:
            return sorted(self.chunks.glob("chunk_*.nc"))
        except OSError:
            return []

    def discard_if_empty(self) -> int:
        """After a failure: remove what this campaign created unless a chunk exists; returns the chunks kept."""
        kept = len(self.chunk_files())
        if kept:
            return kept
        for folder in (self.chunks, self.out):
            with contextlib.suppress(OSError):
                for tmp in temporary_files(folder):
                    tmp.unlink()
        if self._created_meta:
            with contextlib.suppress(OSError):
                (self.out / _CAMPAIGN_FILE).unlink()
        self._remove_created()
        return 0

    def _remove_created(self) -> None:
        for d in self._created_dirs:
            try:
                d.rmdir()  # only if empty: never removes anything else
            except FileNotFoundError:
                continue  # mkdir failed before reaching it
            except OSError:
                break
        self._created_dirs = []


def _campaign_record(settings: CampaignSettings, base: Scenario) -> dict:
    """What ``campaign.json`` and every chunk file record: the settings and, under ``problem``, the fingerprint of
    the problem they name (:func:`fsmctl.simulation.results_io.problem_fingerprint`: the base scenario as flown,
    the law's content hash, the fsmctl version).  A resumed campaign must record the same."""
    from fsmctl.simulation.results_io import problem_fingerprint

    return {**jsonable(settings.identity()), "problem": problem_fingerprint(base)}


def _difference(old: Mapping, ident: Mapping) -> tuple[str, str]:
    """How a recorded campaign differs from this one: ``("with different settings", names)`` or ``("of another
    problem", what changed)``."""
    from fsmctl.simulation.results_io import fingerprint_change

    keys = sorted(k for k in {*old, *ident} if k != "problem" and old.get(k) != ident.get(k))
    if keys:
        return "with different settings", ", ".join(keys)
    return "of another problem", str(fingerprint_change(old.get("problem"), ident["problem"]))


def _existing_chunk(path: Path, indices: Sequence[int]) -> bool:
    if not path.is_file():
        return False
    try:
        import xarray as xr

        with xr.open_dataset(path) as ds:
            # a chunk with a failed or died run is not done: --resume tries those runs again
            return [int(r) for r in ds.run.values] == list(indices) and all(
                str(v) == STATUS_OK for v in ds.status.values
            )
    except Exception:  # unreadable partial file: rerun the chunk
        return False


def _read_campaign_file(meta: Path) -> tuple[dict, str | None]:
    """``(settings, None)`` from ``campaign.json``, or ``({}, what is wrong)`` when it is not a campaign's settings."""
    try:
        text = meta.read_bytes().decode("utf-8")
    except UnicodeDecodeError:
        return {}, "not UTF-8 text"
    except OSError as exc:
        raise _environment_problem(f"cannot read {meta}", exc) from exc
    try:
        old = json.loads(text)
    except ValueError as exc:
        return {}, f"not valid JSON: {exc}"
    if not isinstance(old, dict) or not all(k in old for k in _CAMPAIGN_KEYS):
        return {}, "not a JSON object holding a campaign's settings (" + ", ".join(_CAMPAIGN_KEYS) + ")"
    return old, None


def _chunk_settings(path: Path) -> dict | None:
    """The campaign settings a chunk file records (its ``settings`` attribute); None if it records none."""
    import xarray as xr

    with xr.open_dataset(path) as ds:
        text = ds.attrs.get("settings")
    return None if text is None else json.loads(text)


# ----------------------------------------------------------------------------- campaign


@dataclass
class CampaignResult:
    """Outcome of :func:`run_campaign`: the merged dataset and where everything was written.

    Parameters
    ----------
    dataset : xarray.Dataset
        Per-run results, dimension ``run`` (and ``agent``): status, settling times, final errors, Theorem checks.
    summary : dict
        Counts, fractions and statistics (what ``summary.json`` holds).
    out_dir : pathlib.Path
        The campaign folder.
    wall_time_s : float
        Wall time of the campaign (s).
    resumed_chunks : int, optional
        Chunks found done in ``out_dir`` and not run again.
    files : dict, optional
        Name -> path of the files written (``dataset``, ``summary``, ``complete``, figures).
    settings : CampaignSettings or None, optional
        The settings that ran (the case made explicit).

    Examples
    --------
    >>> from fsmctl.studies import CampaignSettings, run_campaign
    >>> result = run_campaign(CampaignSettings(runs=2, t_final=0.5, steady_window=0.2), "mc", workers=1,
    ...                       progress=False, figures=False)
    >>> dict(result.dataset.sizes), sorted(result.files)
    ({'run': 2, 'agent': 6}, ['complete', 'dataset', 'summary'])
    >>> result.settings.case
    '1'
    """

    dataset: Any
    """xarray.Dataset with dimension ``run`` (and ``agent``)"""
    summary: dict
    out_dir: Path
    wall_time_s: float
    resumed_chunks: int = 0
    files: dict = field(default_factory=dict)
    settings: CampaignSettings | None = None
    """the settings that ran (the case made explicit)"""

    @property
    def failed_runs(self) -> list[int]:
        """The indices of the runs whose status is not ``ok``."""
        return [
            int(r) for r, s in zip(self.dataset.run.values, self.dataset.status.values, strict=True) if s != STATUS_OK
        ]


def _n_chunks(settings: CampaignSettings) -> int:
    return -(-settings.runs // settings.chunk_size)


def _chunk_runs(settings: CampaignSettings, c: int) -> list[int]:
    """The runs of chunk ``c``."""
    start = c * settings.chunk_size
    return list(range(start, min(settings.runs, start + settings.chunk_size)))


RUN_RECORD_BYTES = 8 * (len(_SCALARS) + len(_FLAGS) + 1) + 2 * 64
"""Bytes of one run in the merged dataset besides its per-agent values: the scalars, the flags and the noise
seed (float64 or smaller) and the status and message strings (NumPy object arrays: a pointer and a short
string each, counted as 64 bytes)"""

CAMPAIGN_MEMORY_FACTOR = 4.0
"""Peak memory of the merged campaign as a multiple of its dataset: the chunk files read back, their
concatenation, the compressed NetCDF encoded in memory and the summary's copies"""


def check_campaign_memory(settings: CampaignSettings, base: Scenario, *, available: int | None = None) -> int:
    """Refuse (:class:`~fsmctl.errors.ResourceLimitError`) a campaign whose merged results would not fit in memory.

    :func:`finish_campaign` holds every run's record at once (``montecarlo.nc`` and the summary): per run
    :data:`RUN_RECORD_BYTES` plus 8 bytes per agent and per-agent statistic, times
    :data:`CAMPAIGN_MEMORY_FACTOR`.  It is compared with ``available`` (default:
    :func:`fsmctl.simulation.simulator.available_memory`; None: no check) before anything of the campaign is
    drawn, flown or written, as ``fsmctl simulate`` checks a run's results (:func:`~fsmctl.simulation.simulator.
    check_output_memory`).

    Parameters
    ----------
    settings : CampaignSettings
        The campaign (its ``runs``).
    base : Scenario
        The base scenario (its number of agents).
    available : int, optional
        Bytes available; default: what the machine has now.

    Returns
    -------
    int
        The estimate in bytes.

    Raises
    ------
    fsmctl.errors.ResourceLimitError
        The estimate exceeds ``available``.

    Examples
    --------
    >>> from fsmctl.studies import CampaignSettings
    >>> from fsmctl.studies.montecarlo import campaign_base, check_campaign_memory
    >>> settings, base = campaign_base(CampaignSettings(runs=10**9))
    >>> try:
    ...     check_campaign_memory(settings, base, available=16 * 10**9)
    ... except ValueError as exc:
    ...     print(str(exc).split(" but")[0])
    montecarlo: the results of 1,000,000,000 runs would need ~1.86 TB of memory
    """
    from fsmctl.simulation.simulator import _fmt_bytes, available_memory

    per_run = RUN_RECORD_BYTES + 8 * len(_PER_AGENT) * base.n_agents
    needed = int(CAMPAIGN_MEMORY_FACTOR * per_run * settings.runs)
    if available is None:
        available = available_memory()
    if available is not None and needed > available:
        fit = max(0, int(available // (CAMPAIGN_MEMORY_FACTOR * per_run)))
        raise ResourceLimitError(
            f"montecarlo: the results of {settings.runs:,} runs would need ~{_fmt_bytes(needed)} of memory but only "
            f"{_fmt_bytes(available)} is available: use --runs {fit:,} or fewer"
        )
    return needed


def _progress(total: int, initial: int, enabled: bool | None):
    from tqdm.auto import tqdm

    if enabled is None:
        enabled = sys.stderr.isatty()
    return tqdm(total=total, initial=initial, unit="run", desc="montecarlo", disable=not enabled, file=sys.stderr)


def _run_local(base, settings, todo, workers, run_fn, on_chunk) -> None:
    """Process pool; a chunk whose worker died is retried in a fresh pool, then run by run in isolation.

    The workers run with one BLAS/OpenMP thread each (:func:`fsmctl.studies.parallel.single_threaded_workers`)
    and die with this process (:func:`fsmctl.studies.parallel.worker_pool`).
    """
    if workers <= 1:
        for c, idx in todo:
            on_chunk(c, idx, _run_chunk(base, settings, idx, run_fn))
        return
    with single_threaded_workers():  # every pool of _run_pools starts its workers inside
        _run_pools(base, settings, todo, workers, run_fn, on_chunk)


def _run_pools(base, settings, todo, workers, run_fn, on_chunk) -> None:
    pending = list(todo)
    for _attempt in range(2):
        if not pending:
            return
        failed = []
        with worker_pool(workers) as ex:  # an exception in here (interrupt, full disk) stops the workers
            futures = {ex.submit(_run_chunk, base, settings, idx, run_fn): (c, idx) for c, idx in pending}
            not_done = set(futures)
            while not_done:
                done, not_done = wait(not_done, return_when=FIRST_COMPLETED)
                for f in sorted(done, key=lambda f: futures[f][0]):
                    c, idx = futures[f]
                    try:
                        rows = f.result()
                    except BrokenProcessPool:
                        failed.append((c, idx))
                        continue
                    on_chunk(c, idx, rows)
        pending = sorted(failed)
    # isolate: one run per single-worker pool; a run that kills it is reported
    for c, idx in pending:
        rows = []
        for k in idx:
            with worker_pool(1) as ex:
                try:
                    rows += ex.submit(_run_chunk, base, settings, [k], run_fn).result()
                except BrokenProcessPool:
                    rows.append((k, STATUS_DIED, "the worker process died", _nan_record(base.n_agents)))
        on_chunk(c, idx, rows)


# ----------------------------------------------------------------------------- Dask


def _recv_exact(sock: socket.socket, n: int, deadline: float) -> bytes:
    buf = bytearray()
    while len(buf) < n:
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            raise TimeoutError
        sock.settimeout(remaining)
        part = sock.recv(n - len(buf))
        if not part:
            raise ConnectionResetError(errno.ECONNRESET, "closed the connection")
        buf += part
    return bytes(buf)


def _dask_handshake(sock: socket.socket, deadline: float) -> str | None:
    """Read the handshake a Dask scheduler sends on connect; None if it is one, else what is wrong.

    distributed's TCP framing: an 8-byte length ``N``, then ``N`` bytes holding the frame count, the
    frame lengths (8 bytes each) and the frames; the first frame is a msgpack mapping with ``python``
    and ``pickle-protocol``.  Reading it here, with bounded sizes and a deadline, keeps distributed's own
    reader from trusting a garbage length (it allocates whatever the first 8 bytes say: exabytes for
    ``HTTP/1.1``) or waiting forever on a silent endpoint.
    """
    head = _recv_exact(sock, 8, deadline)
    (n,) = struct.unpack("Q", head)
    if not 16 <= n <= _DASK_HANDSHAKE_MAX_BYTES:
        return f"its first bytes {head[:8]!r} are not a Dask message header"
    body = _recv_exact(sock, n, deadline)
    (n_frames,) = struct.unpack_from("Q", body)
    if not 1 <= n_frames <= 64 or 8 * (1 + n_frames) > n:
        return "its first message is not in Dask's frame format"
    lengths = struct.unpack_from(f"{n_frames}Q", body, 8)
    start = 8 * (1 + n_frames)
    if start + sum(lengths) != n:
        return "its first message is not in Dask's frame format"
    try:
        import msgpack

        info = msgpack.loads(body[start : start + lengths[0]], raw=False)
    except Exception:
        return "its first message is not a Dask handshake"
    if not isinstance(info, dict) or "python" not in info or "pickle-protocol" not in info:
        return "its first message is not a Dask handshake"
    return None


def _probe_dask_comm(address: str, timeout_s: float) -> None:
    """Open and close a connection to ``address`` with distributed's own ``connect`` (a fresh event loop).

    Runs in a thread of its own, so it works whether or not the caller's thread runs an event loop (a
    notebook).  The connection arguments are the ones a :class:`distributed.Client` without ``security``
    uses (:class:`distributed.security.Security` from the Dask configuration).  Raises what ``connect``
    raises.
    """
    import asyncio
    import threading

    from distributed.comm import connect
    from distributed.security import Security

    async def probe() -> None:
        comm = await connect(address, timeout=timeout_s, **Security().get_connection_args("client"))
        await comm.close()

    failure: list[BaseException] = []

    def target() -> None:
        try:
            asyncio.run(probe())
        except BaseException as exc:  # handed to the caller's thread
            failure.append(exc)

    thread = threading.Thread(target=target, name="fsmctl-dask-probe", daemon=True)
    thread.start()
    thread.join(timeout_s + 5.0)  # connect() gives up after timeout_s; the margin covers closing
    if thread.is_alive():
        raise TimeoutError
    if failure:
        raise failure[0]


def _check_dask_endpoint(address: str, timeout_s: float) -> None:
    """Pre-flight of a scheduler address, so that a bad one is a one-line error at once.

    The address must be one that distributed accepts: a scheme that one of its registered comm backends
    serves (``tcp``, ``tls``, ``inproc``, ``ws``, ... and those that plug-ins register), default ``tcp``,
    and a location in that scheme's syntax (``host:port`` for ``tcp``, port included); otherwise
    :class:`~fsmctl.errors.InputError`.  A ``tcp://`` endpoint must then accept a connection and send a
    Dask handshake, read here with bounded sizes (distributed's own reader allocates whatever the first 8
    bytes say); any other scheme must accept a connection through distributed's ``connect``.  Otherwise
    :class:`~fsmctl.errors.EnvironmentProblem` (nothing listening, no answer within ``timeout_s``, an
    answer that is not Dask's, a backend that cannot work here, such as ``tls`` without certificates).

    Without this check, an address that distributed refuses by a ``ValueError`` or ``TypeError`` leaves a
    half-started :class:`distributed.Client` whose finalizer waits twice the timeout and prints a traceback.
    """
    import warnings

    from distributed.comm.addressing import parse_address
    from distributed.comm.registry import get_backend

    with warnings.catch_warnings(record=True) as caught:  # a deprecated backend (ucx) warns when it loads
        warnings.simplefilter("always")
        try:
            scheme, loc = parse_address(address)
            backend = get_backend(scheme)
            host_port = backend.get_address_host_port(loc) if scheme == "tcp" else None
        except (ValueError, TypeError) as exc:
            raise InputError(f"--dask {address}: not a scheduler address ({exc})") from None
        except ImportError as exc:  # a plug-in's backend that does not load
            raise EnvironmentProblem(errno.ENOENT, f"--dask {address}: {type(exc).__name__}: {exc}") from None
    what = f"--dask {address}: cannot connect to a Dask scheduler"
    if host_port is None:
        try:
            with warnings.catch_warnings(record=True) as more:
                warnings.simplefilter("always")
                _probe_dask_comm(address, timeout_s)
        except ValueError as exc:  # the backend's own address syntax (inproc://host/pid/n)
            raise InputError(f"--dask {address}: not a scheduler address ({exc})") from None
        except TimeoutError:
            raise EnvironmentProblem(errno.ETIMEDOUT, f"{what} (no answer within {timeout_s:g} s)") from None
        except Exception as exc:  # OSError, or a backend that cannot work here (TypeError: tls without ssl context)
            notes = [str(w.message).splitlines()[0] for w in (*caught, *more)]
            text = " ".join(f"{type(exc).__name__}: {exc}".split())[:300]
            raise EnvironmentProblem(
                getattr(exc, "errno", None) or errno.EPROTO, f"{what} ({'; '.join([text, *notes])})"
            ) from None
        return
    host, port = host_port
    deadline = time.monotonic() + timeout_s
    try:
        sock = socket.create_connection((host, int(port)), timeout=timeout_s)
    except TimeoutError:
        raise EnvironmentProblem(errno.ETIMEDOUT, f"{what} (no answer within {timeout_s:g} s)") from None
    except OSError as exc:
        raise EnvironmentProblem(exc.errno or errno.EIO, f"{what} ({exc.strerror or exc})") from None
    with sock:
        try:
            problem = _dask_handshake(sock, deadline)
        except TimeoutError:
            problem = f"it accepted the connection but sent no Dask handshake within {timeout_s:g} s"
        except OSError as exc:
            problem = f"it {exc.strerror or exc} before sending a Dask handshake"
    if problem is not None:
        raise EnvironmentProblem(
            errno.EPROTO, f"--dask {address}: the endpoint answers but is not a Dask scheduler ({problem})"
        )


def _connect_dask(address_or_client: Any, timeout_s: float):
    """``(client, owned)``: the given client, or a new one to the checked address (closed by the caller)."""
    try:
        from distributed import Client
    except ImportError:
        raise EnvironmentProblem(
            errno.ENOPKG if hasattr(errno, "ENOPKG") else errno.ENOENT,
            "--dask needs the 'distributed' package (pip install 'fsmctl[dask]')",
        ) from None
    if isinstance(address_or_client, Client):
        return address_or_client, False
    if not isinstance(address_or_client, str) or not address_or_client.strip():
        raise InputError(f"--dask: expected a scheduler address or a distributed.Client, got {address_or_client!r}")
    address = address_or_client.strip()
    _check_dask_endpoint(address, timeout_s)
    import dask

    try:
        with dask.config.set({"distributed.comm.timeouts.connect": f"{timeout_s}s"}):
            client = Client(address, timeout=f"{timeout_s}s", set_as_default=False)
    except Exception as exc:  # MemoryError, ValueError, OSError, TimeoutError: the endpoint is not usable
        text = " ".join(f"{type(exc).__name__}: {exc}".split())[:300]
        raise EnvironmentProblem(
            getattr(exc, "errno", None) or errno.EPROTO,
            f"--dask {address}: cannot connect to a Dask scheduler ({text})",
        ) from None
    return client, True


def _run_dask(base, settings, todo, client, run_fn, on_chunk) -> None:
    from distributed import as_completed

    futures = {}
    try:
        for c, idx in todo:
            f = client.submit(
                _run_chunk,
                base,
                settings,
                idx,
                run_fn,
                pure=False,
                key=f"fsmctl-mc-{settings.seed}-{c}-{os.getpid()}-{time.time_ns()}",
            )
            futures[f] = (c, idx)
        for f in as_completed(list(futures), loop=client.loop):  # the client need not be the default one
            c, idx = futures[f]
            try:
                rows = f.result()
            except Exception as exc:  # KilledWorker and friends: every run of the chunk is reported
                msg = f"{type(exc).__name__}: {exc}".splitlines()[0][:500]
                rows = [(k, STATUS_DIED, msg, _nan_record(base.n_agents)) for k in idx]
            on_chunk(c, idx, rows)
    except BaseException:
        with contextlib.suppress(Exception):
            client.cancel(list(futures), force=True)
        raise


# ----------------------------------------------------------------------------- the campaign


def run_campaign(
    settings: CampaignSettings,
    out_dir: str | Path,
    *,
    workers: int | None = None,
    dask: Any = None,
    resume: bool = False,
    progress: bool | None = None,
    run_fn: RunFunction | None = None,
    figures: bool = True,
    base: Scenario | None = None,
    log: Callable[[str], None] | None = None,
    dask_timeout: float = DASK_TIMEOUT_S,
    command: Sequence[str] | str | None = None,
) -> CampaignResult:
    """Run (or resume) a Monte Carlo campaign and write ``out_dir``.

    Parameters
    ----------
    settings : CampaignSettings
        Scenario, number of runs, seed, perturbation bounds, horizon.
    out_dir : str or Path
        Receives ``campaign.json``, ``chunks/*.nc`` (one per chunk, written as soon as it is done),
        ``montecarlo.nc`` (all runs), ``summary.json``, ``histograms.png``/``.svg`` and, last,
        ``complete.json``.  Created if needed; removed again if the campaign ends before any chunk.
    workers : int, optional
        Local worker processes (default: the number of CPUs); 1 runs in this process.
    dask : str or distributed.Client, optional
        Address of (or a client to) an existing Dask distributed cluster; replaces the local pool.
        An address must be one that distributed accepts (a scheme of one of its comm backends: ``tcp``,
        the default, ``tls``, ``inproc``, ``ws``, ...; ``host:port`` with the port for ``tcp``), else
        :class:`~fsmctl.errors.InputError` before any connection; a ``tcp://`` address must answer with a
        Dask handshake within ``dask_timeout``.
    resume : bool
        Continue a campaign already in ``out_dir`` (same settings), running only missing chunks.
    progress : bool, optional
        Progress bar (default: when stderr is a terminal).
    run_fn : callable, optional
        Replaces :func:`run_one` (same signature); used to test failure handling.
    figures : bool
        Write the histogram figure.
    base : Scenario, optional
        Use this scenario instead of loading ``settings.scenario``/``case`` (a :class:`Scenario` built in code).
    log : callable, optional
        Receives the lines of :func:`describe_campaign` before the first run (``fsmctl montecarlo`` prints them).
    dask_timeout : float
        Seconds a Dask scheduler gets to accept the connection and answer.
    command : sequence of str or str, optional
        The command line (``sys.argv``), embedded in ``montecarlo.nc`` with the base scenario, the law and the
        versions (:func:`fsmctl.simulation.results_io.provenance`).

    Returns
    -------
    CampaignResult
        The merged dataset, the summary and the files written.

    Raises
    ------
    fsmctl.errors.InputError
        A bad setting, a ``dask`` address that distributed does not accept, or ``out_dir`` holds another campaign.
    fsmctl.errors.EnvironmentProblem
        ``out_dir`` cannot be created or written (read-only, full), or ``dask`` is not a reachable scheduler.
    CampaignInterrupted
        ``SIGINT``/``SIGTERM`` (in the main thread): the workers were stopped and the finished chunks
        kept (``exc.detail`` says how many); ``exc.exit_code`` is 130 or 143.

    Examples
    --------
    Two runs of the paper's Case 1 on a 0.5 s horizon, in this process (a real campaign has hundreds of runs
    on the full horizon, ``fsmctl montecarlo``):

    >>> from fsmctl.studies import CampaignSettings, run_campaign
    >>> settings = CampaignSettings(runs=2, seed=1, t_final=0.5, steady_window=0.2, chunk_size=2)
    >>> result = run_campaign(settings, "campaign", workers=1, progress=False, figures=False)
    >>> result.summary["runs"], result.summary["ok"], result.failed_runs
    (2, 2, [])
    >>> sorted(p.name for p in result.out_dir.iterdir())
    ['campaign.json', 'chunks', 'complete.json', 'montecarlo.nc', 'summary.json']
    """
    settings.validate()
    t_start = time.perf_counter()
    out = Path(out_dir)
    with interrupt_guard() as guard:
        if base is None:
            settings, base = campaign_base(settings)
        check_campaign(settings, base)
        check_campaign_memory(settings, base)
        if log is not None:
            for line in describe_campaign(settings, base):
                log(line)
        client, own_client = _connect_dask(dask, dask_timeout) if dask is not None else (None, False)
        folder = _OutputFolder(out)
        n_chunks = _n_chunks(settings)
        try:
            ident = _campaign_record(settings, base)
            folder.prepare(ident, resume)
            todo, resumed = [], 0
            for c in range(n_chunks):
                idx = _chunk_runs(settings, c)
                if resume and _existing_chunk(_chunk_path(out, c), idx):
                    resumed += 1
                else:
                    todo.append((c, idx))
            bar = _progress(settings.runs, settings.runs - sum(len(i) for _, i in todo), progress)

            recorded = json.dumps(ident, allow_nan=False)  # what rebuilds campaign.json

            def on_chunk(c: int, idx: Sequence[int], rows) -> None:
                ds = _chunk_dataset(rows, base.n_agents, settings.seed)
                ds.attrs["settings"] = recorded
                with guard.deferred():  # an interrupt waits until the chunk file is complete
                    # an intermediate file: NetCDF-3, which the parent writes ~5x faster than compressed
                    # NetCDF-4 (whose CPU time would compete with the workers'); montecarlo.nc is compressed
                    _write_netcdf(ds, _chunk_path(out, c), compress=False)
                bar.update(len(idx))

            try:
                if client is not None:
                    _run_dask(base, settings, todo, client, run_fn, on_chunk)
                else:
                    n = workers or os.cpu_count() or 1
                    _run_local(base, settings, todo, min(n, max(1, len(todo))), run_fn, on_chunk)
            finally:
                bar.close()
            result = finish_campaign(out, settings, base, t_start, resumed, figures=figures, command=command)
        except BaseException as exc:
            guard.closing()
            kept = folder.discard_if_empty()
            if isinstance(exc, CampaignInterrupted):
                exc.detail = (
                    f"{kept} of {n_chunks} chunk files kept in {out}; --resume with the same options continues"
                    if kept
                    else "nothing was written"
                )
            raise
        finally:
            if own_client:
                with contextlib.suppress(Exception):
                    client.close(timeout=dask_timeout)
    return result


def finish_campaign(
    out: Path,
    settings: CampaignSettings,
    base: Scenario,
    t_start: float,
    resumed: int = 0,
    *,
    figures: bool = True,
    command: Sequence[str] | str | None = None,
) -> CampaignResult:
    """Merge the chunk files into ``montecarlo.nc``, write ``summary.json``, the histograms and, last, ``complete.json``.

    Parameters
    ----------
    out : pathlib.Path
        The campaign folder (its ``chunks/`` are complete).
    settings : CampaignSettings
        The campaign's settings.
    base : Scenario
        The base scenario.
    t_start : float
        :func:`time.perf_counter` at the start of the campaign (for the wall time).
    resumed : int, optional
        Chunks that were resumed.
    figures : bool, optional
        Write the histograms.
    command : sequence of str or str, optional
        The command line, embedded in ``montecarlo.nc`` with the base scenario, the law and the versions
        (:func:`fsmctl.simulation.results_io.provenance`).

    Returns
    -------
    CampaignResult
        The merged result.
    """
    import xarray as xr

    from fsmctl.simulation.results_io import provenance

    out = Path(out)
    parts = []
    for c in range(_n_chunks(settings)):
        with xr.open_dataset(_chunk_path(out, c)) as ds:
            parts.append(ds.load())
    ds = xr.concat(parts, dim="run")
    for var in ds.variables.values():
        var.encoding = {}  # string widths differ between chunks
    ident = _campaign_record(settings, base)  # as campaign.json and every chunk file record it
    # the base scenario, law, versions and command line (scenario_from_result re-runs the base scenario)
    ds.attrs.update(provenance(base, command=command))
    ds.attrs.update(
        {
            "title": f"fsmctl Monte Carlo campaign: {base.label}, {settings.runs} runs, seed {settings.seed}",
            "settings": json.dumps(ident, allow_nan=False),
            "scenario": "\n".join(base.describe()),
            "campaign": "\n".join(describe_campaign(settings, base)),
            "source": "Liang, Sun & Wang, Acta Astronautica 81 (2012) 445-455",
            "seeds": "numpy.random.SeedSequence(seed).spawn(runs)[run]; noise_seed (the run's simulation.seed): its "
            "first child's generate_state(1, uint64) >> 11",
            "vary": settings.vary,
            "random_processes": ", ".join(random_processes(base)) or "none",
            "law": base.law.name,
            # 1: the law declares it is the paper's eqs 13-19 (LawBuilder.paper_theorems), so Theorems 1-2 apply
            "paper_theorems": int(base.law.paper_theorems is not None),
        }
    )
    _write_netcdf(ds, out / "montecarlo.nc")
    summary = summarize(ds, settings)
    summary["campaign_wall_time_s"] = time.perf_counter() - t_start
    summary["resumed_chunks"] = resumed
    summary["settings"] = ident
    summary["output_interval_s"] = base.simulation.output_interval
    summary["campaign"] = describe_campaign(settings, base)
    files = {"dataset": out / "montecarlo.nc", "summary": out / "summary.json"}
    if figures:
        files.update(plot_histograms(ds, out / "histograms", settings))
    write_json(out / "summary.json", summary)
    for tmp in temporary_files(out / "chunks"):  # left by an interrupted earlier attempt
        with contextlib.suppress(OSError):
            tmp.unlink()
    marker = {
        "complete": True,
        "runs": summary["runs"],
        "ok": summary["ok"],
        "files": sorted(str(p.relative_to(out)) for p in files.values()),
    }
    write_json(out / COMPLETE_MARKER, marker)
    files["complete"] = out / COMPLETE_MARKER
    return CampaignResult(ds, summary, out, summary["campaign_wall_time_s"], resumed, files, settings)


def summarize(ds, settings: CampaignSettings) -> dict:
    """Counts, fractions and statistics (finite values only) of every per-run variable.

    Parameters
    ----------
    ds : xarray.Dataset
        The merged per-run dataset.
    settings : CampaignSettings
        The campaign's settings.

    Returns
    -------
    dict
        ``runs``, ``ok``, ``failed``, ``converged_fraction``, the Theorem checks' fractions, ``statistics`` per
        variable, ... (written as ``summary.json``).
    """
    status = [str(s) for s in ds.status.values]
    ok = np.array([s == STATUS_OK for s in status])
    out: dict[str, Any] = {
        "runs": len(status),
        "ok": int(ok.sum()),
        "failed": int(sum(s == STATUS_FAILED for s in status)),
        "worker_died": int(sum(s == STATUS_DIED for s in status)),
        "failures": [
            {"run": int(r), "status": s, "message": str(m)}
            for r, s, m in zip(ds.run.values, status, ds.message.values, strict=True)
            if s != STATUS_OK
        ],
        "tolerance_deg": settings.tolerance_deg,
        "law": str(ds.attrs["law"]),
        "paper_theorems": bool(int(ds.attrs["paper_theorems"])),
    }
    for k in _FLAGS:
        v = ds[k].values.astype(bool)[ok]
        applies = k == "converged" or out["paper_theorems"]  # Theorems 1-2 apply to a law that declares them
        out[f"{k}_fraction"] = float(v.mean()) if v.size and applies else math.nan
    stats = {}
    for k in _SCALARS:
        v = ds[k].values[ok]
        fin = v[np.isfinite(v)]
        entry = {"finite": int(fin.size), "nan": int(v.size - fin.size)}
        if fin.size:
            q = np.percentile(fin, [5, 50, 95])
            entry.update(
                mean=float(fin.mean()), std=float(fin.std()), min=float(fin.min()), p5=float(q[0]),
                median=float(q[1]), p95=float(q[2]), max=float(fin.max()),
            )  # fmt: skip
        stats[k] = entry
    out["statistics"] = stats
    out["cpu_time_s_total"] = float(np.nansum(ds["cpu_time_s"].values))
    return out


def plot_histograms(ds, stem: str | Path, settings: CampaignSettings) -> dict:
    """Histograms of the main per-run results (PNG and SVG, each written atomically).

    Parameters
    ----------
    ds : xarray.Dataset
        The merged per-run dataset.
    stem : str or pathlib.Path
        The files' path without suffix.
    settings : CampaignSettings
        The campaign's settings (tolerances in the titles).

    Returns
    -------
    dict
        ``{"png": path, "svg": path}``.
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    from fsmctl.studies.figures import save_figure

    ok = np.array([str(s) == STATUS_OK for s in ds.status.values])
    panels = [
        ("aaem_settling_s", f"AAEM settling time to {settings.tolerance_deg:g} deg (s)"),
        ("aaem_steady_max_deg", "AAEM steady-state max (deg)"),
        ("raem_steady_max_deg", "RAEM steady-state max (deg)"),
        ("u_unsaturated_max_N_m", "max |commanded torque| (N m)"),
        ("saturated_time_max_s", "saturation time, worst agent (s)"),
        ("theorem2_margin", "Theorem 2 margin min delta/required"),
    ]
    fig, axes = plt.subplots(2, 3, figsize=(13, 7), constrained_layout=True)
    for ax, (k, label) in zip(axes.ravel(), panels, strict=True):
        v = ds[k].values[ok]
        fin = v[np.isfinite(v)]
        if fin.size:
            positive = fin[fin > 0]
            log = positive.size == fin.size and fin.size > 1 and fin.max() / max(fin.min(), 1e-300) > 1e3
            bins = np.geomspace(positive.min(), positive.max(), 30) if log else 30
            ax.hist(fin, bins=bins, color="tab:blue", alpha=0.8)
            if log:
                ax.set_xscale("log")
        ax.set_xlabel(label)
        ax.set_ylabel("runs")
        ax.set_title(f"{fin.size} finite of {v.size} ok runs", fontsize=9)
    n_conv = int(ds.converged.values[ok].sum())
    fig.suptitle(
        f"Monte Carlo: {ds.attrs.get('title', '')}\nconverged {n_conv}/{int(ok.sum())}, "
        f"Theorem 1 held {int(ds.theorem1_holds.values[ok].sum())}, Theorem 2 (at reference) held "
        f"{int(ds.theorem2_at_reference_holds.values[ok].sum())}; {int((~ok).sum())} failed/died",
        fontsize=10,
    )
    try:
        png, svg = save_figure(fig, stem, dpi=110)
    finally:
        plt.close(fig)
    return {"png": png, "svg": svg}
