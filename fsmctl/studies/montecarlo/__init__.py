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
  (``link_delay_max_s``, ``loss_probability_max`` -- the stationary loss rate for Gilbert-Elliott links --,
  ``sensor_noise_scale``), with the wheels' peak speed and
  momentum (``wheel_speed_peak_rad_per_s``, ``wheel_momentum_peak_N_m_s``; NaN without wheels).
* ``control_period`` (``--control-period``) sets the base scenario's ``simulation.control_period``
  through ``scenario.replace`` (``None``: the scenario's).

Per run the dataset holds settling times of AAEM/RAEM (eqs 42-43), steady-state accuracy, peak
torques, saturation time, whether Theorem 1's topology conditions hold for the run's graph
(:func:`fsmctl.proofs.theorem1.analyze_topology`), whether the configured ``delta_i`` exceeds
Theorem 2's requirement at the reference (``sigma_e = 0, omega_e = 0``, bound boxes of the
disturbance and the reference; :func:`fsmctl.proofs.theorem2.delta_requirements`), whether it
converged, the messages its agents sent (``messages_count``, ``messages_per_agent_per_s``:
:func:`fsmctl.simulation.message_metrics`, the same definition as ``fsmctl compare``'s columns; NaN for continuous
control, and ``summary.json`` then says ``messages``: not applicable), and a status (``ok``, ``failed`` with the
error, ``worker-died``).  The "final" values are
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

Modules: :mod:`~fsmctl.studies.montecarlo.settings` (:class:`CampaignSettings`, the checks, the description),
:mod:`~fsmctl.studies.montecarlo.sampling` (what a run draws), :mod:`~fsmctl.studies.montecarlo.runs` (flying a
chunk, a run's record), :mod:`~fsmctl.studies.montecarlo.store` (the folder, chunk files, merging, summary,
histograms) and :mod:`~fsmctl.studies.montecarlo.run` (:func:`run_campaign`: the chunks as tasks of the campaign
runner, :mod:`fsmctl.studies.campaign`, which flies them in this process, on a local process pool or a Dask cluster).

Interrupts: ``SIGINT`` (Ctrl-C) and ``SIGTERM`` stop the workers at once (queued chunks cancelled,
running ones terminated), keep the finished chunks, and :func:`run_campaign` raises
:class:`~fsmctl.parallel.CampaignInterrupted`; ``fsmctl montecarlo`` prints one line and exits with
``128 + signal``: **130 for SIGINT, 143 for SIGTERM**.  Local workers die with the campaign even when it
is killed (``SIGKILL``): see :func:`fsmctl.parallel.worker_pool`.
"""

from __future__ import annotations

from fsmctl.parallel import CampaignInterrupted
from fsmctl.studies.montecarlo.run import check_campaign_memory, run_campaign
from fsmctl.studies.montecarlo.runs import run_one, run_record
from fsmctl.studies.montecarlo.sampling import (
    sample_attitudes_mrp,
    sample_inertia_perturbation,
    sample_run_scenario,
    sampled_noise_scale,
)
from fsmctl.studies.montecarlo.settings import (
    COMPLETE_MARKER,
    HARDWARE_RANGES,
    SAMPLING_RANGES,
    STATUS_DIED,
    STATUS_FAILED,
    STATUS_OK,
    TIMING_VARIABLES,
    VARY,
    CampaignSettings,
    campaign_base,
    check_campaign,
    describe_campaign,
    random_processes,
    run_noise_seed,
    theorem1_factor_limit,
)
from fsmctl.studies.montecarlo.store import CampaignResult, finish_campaign, plot_histograms, summarize

__all__ = [
    "CampaignSettings",
    "CampaignResult",
    "CampaignInterrupted",
    "COMPLETE_MARKER",
    "SAMPLING_RANGES",
    "HARDWARE_RANGES",
    "STATUS_OK",
    "STATUS_FAILED",
    "STATUS_DIED",
    "TIMING_VARIABLES",
    "VARY",
    "sample_inertia_perturbation",
    "sample_attitudes_mrp",
    "sample_run_scenario",
    "sampled_noise_scale",
    "run_noise_seed",
    "random_processes",
    "check_campaign",
    "check_campaign_memory",
    "campaign_base",
    "describe_campaign",
    "theorem1_factor_limit",
    "run_one",
    "run_record",
    "run_campaign",
    "finish_campaign",
    "summarize",
    "plot_histograms",
]
