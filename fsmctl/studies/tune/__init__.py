"""Tune a law's declared parameters for designs that work under the scenario's actuator limits (``fsmctl tune``).

A search is an `Optuna <https://optuna.org>`_ study over the law's declared tunable parameters (and, for the
paper's law, the coupling weights), each within its declared range (:func:`search_space`); every candidate is
flown on the scenario (or a seeded ensemble drawn from it) by the compiled simulator, with the scenario's actuators
(torque limit, reaction wheels), and scored by the chosen objectives (all minimised), aggregated over the ensemble by
a quantile, subject to constraints (:data:`CONSTRAINTS`).  Hopeless candidates are stopped early by an Optuna
pruner (:data:`PRUNERS`); candidates are evaluated in parallel (local processes or a Dask cluster) in batches whose
results do not depend on how they were computed.

Objectives (:data:`OBJECTIVES`, one :class:`Objective` each; ``TuneSettings.objectives``):

==================  =======  ==========================================================================================
name                unit     meaning (per run; :func:`fsmctl.studies.compare.run_metrics`)
==================  =======  ==========================================================================================
``aaem_settling``   s        AAEM (eq 42) settling time to ``tolerance_deg`` (see *never settles* below)
``raem_settling``   s        RAEM (eq 43) settling time to ``tolerance_deg``
``aaem_steady``     deg      AAEM maximum over the steady window (the last 40 % of the horizon, at most 40 s)
``raem_steady``     deg      RAEM maximum over the steady window
``peak_torque``     N m      peak applied ``|u_ik|``
``rms_torque``      N m      RMS of the torque vector's norm
``chattering``      N m/s    total variation of u per second of simulated time
``wheel_momentum``  N m s    peak wheel angular momentum (only for a scenario with reaction wheels)
``messages``        1        messages sent by all agents (:func:`fsmctl.simulation.message_metrics`; only with a
                             control period: a continuous-control scenario is refused)
==================  =======  ==========================================================================================

**Never settles**: a run whose metric does not settle within the horizon ``T`` scores
``T * (2 + min(1, max(0, log10(steady_max / tolerance_deg))))``: at least twice the horizon (so it is never mistaken
for a settled run), growing by up to one more horizon with how many decades the steady error stays above the
tolerance (so the sampler can still tell a near miss from a divergence).  That score is never shown as a settling
time: ``trials.csv`` leaves the settling column empty and gives the score in ``<objective>_score``, its ``#`` lines
state the rule, and the summary prints "not settled within T s (scored ... = ... x horizon)"
(:meth:`TuneResult.objective_text`).

Constraints (:data:`CONSTRAINTS`, ``TuneSettings.constraints``; Optuna's ``Trial.set_constraint``: a trial is
feasible when every value is ``<= 0``; default: every constraint that can be evaluated for the law and scenario):

* ``converged`` (s): ``max(aaem_settling, raem_settling) - T``: both metrics settle within the horizon.
* ``theorem1`` (a law that declares the paper's theorems, ``LawBuilder.paper_theorems``): 0 when Theorem 1's conditions (eqs 25-27 in the form the proof needs: a balanced,
  possibly time-varying ``eta`` with ``gamma_ij >= 0``; :func:`fsmctl.proofs.theorem1.analyze_topology`) hold for
  the scenario's time-varying topology with the candidate's coupling weights over the horizon; else ``1 + e`` with
  ``e >= 0`` the largest excess ``max_t k^j_ij(t) - k^i_ij`` over the links (eq 27 needs ``k^i >= k^j``), so the
  sampler is steered towards the condition.  It is evaluated on the design's topology, not on the ensemble's
  perturbed graphs (robustness draws whose dropped links are not the design).
* ``theorem2`` (1/s^2, a law that declares the paper's theorems): ``max`` over agents, axes and ensemble members of ``required_ik -
  delta_ik``, i.e. minus Theorem 2's margin (:func:`fsmctl.proofs.theorem2.delta_margin`): feasible when the
  candidate's switching gain ``delta`` covers the requirement at the reference ``sigma_e = 0, omega_e = 0`` for
  every agent and axis.  The requirement (:func:`fsmctl.proofs.theorem2.reference_delta_requirement`) is the larger
  of its values along the scenario's reference trajectory and under the bound boxes of disturbance and reference
  (the two reference numbers of ``fsmctl prove theorem2-delta``); it depends on the inertia, its uncertainty, the
  disturbance and the reference, not on the tuned gains, so it is computed once per ensemble member.
* ``torque`` (N m, a scenario with a finite ``controller.torque_limit``): ``max |u_unsat,ik(t)| - torque_limit``
  over the agents, axes and output samples ``t >= t_s`` after the transient, with ``u_unsat`` the law's commanded
  torque before saturation and ``t_s`` the later of the AAEM and RAEM settling times (to ``tolerance_deg``); for a
  run that does not settle, over the steady window (the last 40 % of the horizon, at most 40 s).  The design may
  saturate during the transient but must hold the formation within the limit once it has converged (a run still
  saturated at the end is infeasible).
* ``wheels`` (1, a scenario with reaction wheels and a finite ``max_speed``): ``max |h_ik(t)| / h_max,k -``
  :data:`WHEEL_CAPACITY_FRACTION` over agents, wheels and samples, with ``h_ik = J_s,k Omega_ik`` a wheel's momentum
  relative to the hub and ``h_max,k = J_s,k max_speed_k`` its capacity: feasible when every wheel stays below 99 %
  of its capacity (the simulator holds a wheel that reaches ``max_speed``, which shows as 100 %).

``converged``, ``torque`` and ``wheels`` are aggregated over the ensemble like the objectives (the quantile member);
``theorem1`` and ``theorem2`` are proof conditions and hold for the design or not (worst member).

Ensemble (``TuneSettings.ensemble``): 1 flies the scenario itself; ``M > 1`` flies ``M`` members drawn as Monte Carlo
runs are (:func:`fsmctl.studies.montecarlo.sample_run_scenario` with the default
:class:`~fsmctl.studies.montecarlo.CampaignSettings` sampling ranges, member ``m`` from
``SeedSequence(seed).spawn(M)[m]``); every candidate meets the same members, flown together by one call of the
simulator.  The aggregate of a value over the members is ``numpy.quantile(values, quantile, method="higher")``: 1.0
is the worst member, 0.5 the median (rounded up to a member's value).

Search space: each parameter's declared range, or the ``ranges`` override (which must lie within the declared
range); a side the law leaves unbounded must be given by ``ranges``.  A range with ``low > 0`` and
``high / low >= 100`` is searched log-uniformly, any other uniformly; an exclusive declared bound is moved inwards
by one floating-point step.  A vector parameter (``delta``: one value per axis) is searched as one scalar applied
to every component (and, for ``delta``, to every agent).  Parameters with named options (``singularity_fix``) are
not searched.  The coupling weights are two factors (:data:`COUPLING`, unit 1, declared range ``0 <= x``, default
range ``[0.1, 10]``): ``k_i_scale`` multiplies every link's ``k^i_ij`` and ``k_j_scale`` every value of every
``k^j_ij(t)`` schedule of the scenario's topology (and of each ensemble member's); they are searched by default for
a law that declares it is the paper's eqs 13-19 (``LawBuilder.paper_theorems``, as ``fsm`` does) when the scenario
has non-zero weights (Theorem 1 is about them), for other laws when named in ``parameters``.  The chosen design is written with its scaled ``[topology]`` weights.

Pruning (``TuneSettings.pruner``, :data:`PRUNERS`; Optuna's pruners judge one objective, so with several objectives
only ``none`` applies; ``auto`` = ``median`` for one objective, ``none`` for several): a candidate's runs are watched
at :data:`CHECKPOINTS` - 1 checkpoints, every ``T / CHECKPOINTS`` of simulated time rounded to whole output
intervals (step ``k`` at the ``k``-th).  Its intermediate value at step ``k`` estimates the first objective from each
member's run up to the checkpoint ``t_k`` (its output samples so far), aggregated over the members by the quantile:
a settling objective is the settling time when the metric has settled within ``[0, t_k]``, else ``T (2 + d)`` with
``d >= 0`` the decades of the steady error (over the last 40 % of ``[0, t_k]``) above the tolerance, i.e. the
never-settles score if the run stayed where it is, not capped at one decade (:func:`progress_score`); the other
objectives are their values over ``[0, t_k]`` (steady maximum over its last 40 %, peak or RMS torque, the output
samples' total variation of ``u`` per second, peak wheel momentum).  The pruner (``median``:
``MedianPruner(n_startup_trials=5, n_warmup_steps=2)``; ``halving``: ``SuccessiveHalvingPruner(min_resource=1,
reduction_factor=3)``) is asked at every checkpoint; when it prunes, the runs are stopped there (the simulator's
monitor) and the trial is told as ``PRUNED``: it counts in the budget, is never feasible, and carries its
intermediate values (reported to Optuna; every trial keeps them in its ``intermediate`` user attribute,
:func:`intermediate_values`), the proof constraints and ``pruned_at``.  The pruner judges a candidate against a frozen
snapshot of the trials told before its batch was asked (what an Optuna study holding those trials and this
candidate would show it), so its decisions depend neither on timing nor on the number of workers, nor on how the
simulator batches the members (a step is decided once every member has reached it).  Without a pruner, no
intermediate values are computed.

Determinism, batches and parallel evaluation: trials are asked, evaluated and told in batches of
``TuneSettings.batch`` (default :data:`fsmctl.policy.TUNE_BATCH`, part of the settings, independent of the workers): trial ``i`` (0-based)
belongs to batch ``i // batch``; its parameters are proposed by a sampler seeded from ``(seed, i)`` (``TPESampler`` for
one objective, ``NSGAIISampler`` with a population of :data:`POPULATION` for several) that reads the trials told
before the batch (and, as Optuna's constant liar, the batch's trials asked before it); the batch is then evaluated
in this process, a local process pool (:func:`fsmctl.parallel.worker_pool`, one BLAS thread per worker) or a
Dask cluster, and told in trial order.  So the same settings give the same trials whatever the workers.  Without a
pruner, a task flies several of the batch's candidates together (:func:`~fsmctl.studies.tune.search.candidate_groups`:
about one task per worker, at most as many candidates as fill one batch of :func:`fsmctl.simulate_many`,
:data:`~fsmctl.policy.BATCH_AGENTS` agents): their agents share the SIMD lanes and each run's results
are those it has alone, bit for bit.
With a pruner a candidate flies alone, so that its runs stop where it is pruned.  The journal
``study.log`` (Optuna's ``JournalStorage``) receives a batch's proposals in one write before the batch is flown and
its results in one write after: an interrupted study resumed (``resume=True``) flies the trials of the unfinished
batch with the parameters already proposed and continues to ``budget`` trials exactly as an uninterrupted study
would.  Raising the budget of a finished study continues it exactly when its former budget was a multiple of the
batch size (else the last, partial batch was told before the trials that complete it were asked).  A study
records its settings and the fingerprint of its problem (:func:`fsmctl.simulation.results_io.problem_fingerprint`:
the scenario as flown, the law's content hash, the fsmctl version); a resume with other settings, or after the
scenario file or the law changed, is refused (one line naming what changed), so its trials never mix two problems.
The journal's lock (``study.log.lock``, held while a write is appended) records the process holding it; a lock
left by a process that was killed (dead, or of unknown owner for :data:`STALE_LOCK_S`) is broken with a warning,
a lock of a live process is waited for :data:`LOCK_WAIT_S` and then refused.
Ctrl-C (``SIGINT``) or ``SIGTERM`` stop the workers (:func:`fsmctl.parallel.interrupt_guard`) after the
proposals or results being written, and :func:`tune` raises
:class:`~fsmctl.parallel.CampaignInterrupted` (exit code 130 or 143 for ``fsmctl tune``).

Modules: :mod:`~fsmctl.studies.tune.settings` (settings, objectives, constraints, search space),
:mod:`~fsmctl.studies.tune.evaluation` (flying and scoring candidates, the pruner's checkpoints),
:mod:`~fsmctl.studies.tune.storage` (the journal, its lock, samplers, telling trials),
:mod:`~fsmctl.studies.tune.report` (:class:`TuneResult` and the files) and :mod:`~fsmctl.studies.tune.search`
(:func:`tune`: the batches, flown as tasks of the campaign runner :mod:`fsmctl.studies.campaign`).

Cost in this process: Optuna's TPE reads every told trial for each proposal, so its time per trial grows linearly
with the study (about 18 ms of CPU per trial on average over a 2500-trial study with 5 parameters, measured with the
flights replaced by a formula); the sampler's search-space cache is carried from one trial's sampler to the next
(:func:`trial_sampler`), and the journal is written twice per batch (:class:`BufferedJournal`).
"""

from __future__ import annotations

from fsmctl.studies.tune.evaluation import scaled_topology, theorem1_constraint, torque_excess, wheel_load
from fsmctl.studies.tune.report import TuneResult, best_scenario_text
from fsmctl.studies.tune.search import tune
from fsmctl.studies.tune.settings import (
    CHECKPOINTS,
    CONSTRAINTS,
    COUPLING,
    OBJECTIVES,
    POPULATION,
    PRUNERS,
    STUDY_FILE,
    WHEEL_CAPACITY_FRACTION,
    Objective,
    SearchParameter,
    TuneSettings,
    available_constraints,
    progress_score,
    search_space,
    search_space_lines,
    unsettled_score,
)
from fsmctl.studies.tune.storage import LOCK_WAIT_S, STALE_LOCK_S, intermediate_values

__all__ = [
    "CHECKPOINTS",
    "CONSTRAINTS",
    "COUPLING",
    "OBJECTIVES",
    "POPULATION",
    "PRUNERS",
    "STUDY_FILE",
    "LOCK_WAIT_S",
    "STALE_LOCK_S",
    "WHEEL_CAPACITY_FRACTION",
    "Objective",
    "SearchParameter",
    "TuneResult",
    "TuneSettings",
    "available_constraints",
    "best_scenario_text",
    "intermediate_values",
    "progress_score",
    "scaled_topology",
    "search_space",
    "search_space_lines",
    "theorem1_constraint",
    "torque_excess",
    "tune",
    "unsettled_score",
    "wheel_load",
]
