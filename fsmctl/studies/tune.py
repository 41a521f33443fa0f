"""Tune a law's declared parameters for designs that work under the scenario's actuator limits (``fsmctl tune``).

A search is an `Optuna <https://optuna.org>`_ study over the law's declared tunable parameters (and, for the
paper's law, the coupling weights), each within its declared range (:func:`search_space`); every candidate is
flown on the scenario (or a seeded ensemble drawn from it) by the compiled simulator, with the scenario's actuators
(torque limit, reaction wheels), and scored by the chosen objectives (all minimised), aggregated over the ensemble by
a quantile, subject to constraints (:data:`CONSTRAINTS`).  Hopeless candidates are stopped early by an Optuna
pruner (:data:`PRUNERS`); candidates are evaluated in parallel (local processes or a Dask cluster) in batches whose
results do not depend on how they were computed.

Objectives (:data:`OBJECTIVES`, ``TuneSettings.objectives``):

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
==================  =======  ==========================================================================================

**Never settles**: a run whose metric does not settle within the horizon ``T`` scores
``T * (2 + min(1, max(0, log10(steady_max / tolerance_deg))))``: at least twice the horizon (so it is never mistaken
for a settled run), growing by up to one more horizon with how many decades the steady error stays above the
tolerance (so the sampler can still tell a near miss from a divergence).

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
``TuneSettings.batch`` (default :data:`BATCH`, part of the settings, independent of the workers): trial ``i`` (0-based)
belongs to batch ``i // batch``; its parameters are proposed by a sampler seeded from ``(seed, i)`` (``TPESampler`` for
one objective, ``NSGAIISampler`` with a population of :data:`POPULATION` for several) that reads the trials told
before the batch (and, as Optuna's constant liar, the batch's trials asked before it); the batch is then evaluated
in this process, a local process pool (:func:`fsmctl.studies.parallel.worker_pool`, one BLAS thread per worker) or a
Dask cluster, and told in trial order.  So the same settings give the same trials whatever the workers.  The journal
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
Ctrl-C (``SIGINT``) or ``SIGTERM`` stop the workers (:func:`fsmctl.studies.parallel.interrupt_guard`) after the
proposals or results being written, and :func:`tune` raises
:class:`~fsmctl.studies.parallel.CampaignInterrupted` (exit code 130 or 143 for ``fsmctl tune``).

Cost in this process: Optuna's TPE reads every told trial for each proposal, so its time per trial grows linearly
with the study (about 18 ms of CPU per trial on average over a 2500-trial study with 5 parameters, measured with the
flights replaced by a formula); the sampler's search-space cache is carried from one trial's sampler to the next
(:func:`_sampler`), and the journal is written twice per batch (:class:`_BufferedJournal`).
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import errno
import json
import logging
import math
import os
import shlex
import socket
import stat
import sys
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from fsmctl.errors import EnvironmentProblem, InputError
from fsmctl.model.scenario import Scenario
from fsmctl.model.toml_writer import toml_table, toml_value
from fsmctl.model.topology import Link, Topology

__all__ = [
    "BATCH",
    "CHECKPOINTS",
    "CONSTRAINTS",
    "COUPLING",
    "OBJECTIVES",
    "POPULATION",
    "PRUNERS",
    "WHEEL_CAPACITY_FRACTION",
    "SearchParameter",
    "TuneResult",
    "TuneSettings",
    "available_constraints",
    "best_scenario_text",
    "intermediate_values",
    "progress_score",
    "scaled_topology",
    "search_space",
    "theorem1_constraint",
    "torque_excess",
    "tune",
    "unsettled_score",
    "wheel_load",
]

OBJECTIVES: dict[str, tuple[str, str]] = {
    "aaem_settling": ("s", "AAEM settling time to the tolerance"),
    "raem_settling": ("s", "RAEM settling time to the tolerance"),
    "aaem_steady": ("deg", "AAEM max over the steady window"),
    "raem_steady": ("deg", "RAEM max over the steady window"),
    "peak_torque": ("N m", "peak applied |u_ik|"),
    "rms_torque": ("N m", "RMS torque"),
    "chattering": ("N m/s", "total variation of u per second"),
    "wheel_momentum": ("N m s", "peak wheel angular momentum"),
}
"""objective name -> (unit, description); all are minimised"""

CONSTRAINTS: dict[str, tuple[str, str]] = {
    "converged": ("s", "max(AAEM, RAEM settling time) - horizon"),
    "theorem1": ("1", "0 when Theorem 1 holds for the topology with the candidate's weights, else 1 + max(k^j - k^i)"),
    "theorem2": ("1/s^2", "max over agents, axes, members of (Theorem 2's required delta - delta)"),
    "torque": ("N m", "max |commanded torque| after the settling time (else the steady window) - torque limit"),
    "wheels": ("1", "peak wheel momentum / capacity - 0.99"),
}
"""constraint name -> (unit, description); feasible when the value is <= 0 (see the module docstring)"""

SIMULATED_CONSTRAINTS = ("converged", "torque", "wheels")
"""constraints measured on the runs (aggregated by the quantile); the others are proof conditions"""

PRUNERS = ("none", "median", "halving")
"""``--pruner`` choices (``auto``: ``median`` for one objective, ``none`` for several)"""

BATCH = 8
"""default batch size: trials asked, evaluated (in parallel) and told together"""

CHECKPOINTS = 10
"""a pruned run is judged every ``T / CHECKPOINTS`` of simulated time (steps 1 .. CHECKPOINTS - 1)"""

MEDIAN_STARTUP_TRIALS = 5
MEDIAN_WARMUP_STEPS = 2
HALVING_REDUCTION_FACTOR = 3

POPULATION = 24
"""population size of the NSGA-II sampler (fixed, so a resumed study proposes what an uninterrupted one would)"""

LOG_RATIO = 100.0
"""a range with ``low > 0`` and ``high / low >= LOG_RATIO`` is searched log-uniformly"""

COUPLING: dict[str, str] = {
    "k_i_scale": "factor on every link's k^i_ij (Table 2, eq 19)",
    "k_j_scale": "factor on every value of every k^j_ij(t) schedule (Table 2, eq 19)",
}
"""the coupling-weight factors that can be searched (unit 1, declared range ``0 <= x``)"""

COUPLING_RANGE = (0.1, 10.0)
"""default search range of the coupling factors (log-uniform)"""

WHEEL_CAPACITY_FRACTION = 0.99
"""the ``wheels`` constraint: every wheel's peak momentum must stay below this fraction of ``J_s max_speed``"""

STUDY_NAME = "fsmctl-tune"
STUDY_FILE = "study.log"


# ----------------------------------------------------------------------------- settings


def _names(value: Any) -> tuple[str, ...]:
    if isinstance(value, str):
        return tuple(x.strip() for x in value.split(",") if x.strip())
    return tuple(value)


@dataclass(frozen=True)
class TuneSettings:
    """What to tune, how hard, and how candidates are scored (see the module docstring).

    Parameters
    ----------
    scenario : str, optional
        A built-in scenario name (default ``"paper"``) or a scenario file.
    case : str or None, optional
        The scenario's case; None: its first.
    law : str, optional
        The law to tune: a built-in name (default ``"fsm"``), a derivation script or a derived folder.
    budget : int, optional
        Number of trials in all (a resumed study continues to it).
    seed : int, optional
        Seed of the sampler and of the ensemble.
    ensemble : int, optional
        1 flies the scenario itself; ``M > 1`` flies ``M`` Monte Carlo members per candidate.
    quantile : float, optional
        Aggregate over the ensemble: 1.0 the worst member, 0.5 the median.
    objectives : tuple of str or str, optional
        Names of :data:`OBJECTIVES` to minimise (a comma-separated string is split).
    tolerance_deg : float, optional
        The settling tolerance of AAEM and RAEM (eqs 42-43), deg.
    t_final : float or None, optional
        The horizon (s); None: the scenario's.
    parameters : tuple of str, optional
        Names to search; empty: every tunable numeric parameter of the law (and the coupling factors for ``fsm``).
    ranges : tuple of (str, float, float) or Mapping, optional
        ``(name, low, high)`` triples (or ``name -> (low, high)``) overriding the declared ranges.
    batch : int, optional
        Trials asked, evaluated (in parallel) and told together (the results do not depend on the workers).
    pruner : str, optional
        One of :data:`PRUNERS` or ``"auto"`` (resolved here: ``median`` for one objective, ``none`` for several).
    constraints : tuple of str, optional
        Names of :data:`CONSTRAINTS`; empty: every one that can be evaluated (:func:`available_constraints`).

    Examples
    --------
    >>> from fsmctl.studies import TuneSettings
    >>> s = TuneSettings(objectives="aaem_settling,peak_torque", ranges={"c1": (0.1, 2.0)})
    >>> s.objectives, s.ranges, s.pruner
    (('aaem_settling', 'peak_torque'), (('c1', 0.1, 2.0),), 'none')
    >>> try:
    ...     TuneSettings(budget=0).validate()
    ... except ValueError as exc:
    ...     print(exc)
    tune: budget must be a whole number of trials >= 1, got 0
    """

    scenario: str = "paper"
    case: str | None = None
    law: str = "fsm"
    budget: int = 50
    seed: int = 0
    ensemble: int = 1
    quantile: float = 1.0
    objectives: tuple[str, ...] = ("aaem_settling", "peak_torque")
    tolerance_deg: float = 1.0
    t_final: float | None = None
    parameters: tuple[str, ...] = ()
    ranges: tuple[tuple[str, float, float], ...] = ()
    batch: int = BATCH
    pruner: str = "auto"
    constraints: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if isinstance(self.objectives, str):
            object.__setattr__(self, "objectives", tuple(x.strip() for x in self.objectives.split(",")))
        else:
            object.__setattr__(self, "objectives", tuple(self.objectives))
        object.__setattr__(self, "parameters", _names(self.parameters))
        object.__setattr__(self, "constraints", _names(self.constraints))
        ranges = self.ranges
        if isinstance(ranges, Mapping):
            ranges = tuple((k, *v) if isinstance(v, (list, tuple)) else (k, v) for k, v in ranges.items())
        object.__setattr__(self, "ranges", tuple(tuple(r) for r in ranges))
        object.__setattr__(self, "scenario", str(self.scenario))
        object.__setattr__(self, "law", str(self.law))
        if self.pruner == "auto":
            object.__setattr__(self, "pruner", "median" if len(self.objectives) == 1 else "none")

    def validate(self) -> None:
        """Raise :class:`~fsmctl.errors.InputError` (one line naming the setting) on a bad setting, an unknown law or
        parameter, or a range that cannot be searched.

        Raises
        ------
        fsmctl.errors.InputError
            The first bad setting found.
        """

        def whole(v: Any) -> bool:
            return isinstance(v, (int, np.integer)) and not isinstance(v, bool)

        def real(v: Any) -> bool:
            return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)

        if not self.objectives:
            raise InputError(f"tune: objectives: give at least one of {', '.join(OBJECTIVES)}")
        for name in self.objectives:
            if name not in OBJECTIVES:
                raise InputError(f"tune: unknown objective {name!r} (known: {', '.join(OBJECTIVES)})")
        if len(set(self.objectives)) != len(self.objectives):
            raise InputError(f"tune: objectives: each may be named once, got {','.join(self.objectives)}")
        if not whole(self.budget) or self.budget < 1:
            raise InputError(f"tune: budget must be a whole number of trials >= 1, got {self.budget!r}")
        if not whole(self.seed) or self.seed < 0:
            raise InputError(f"tune: seed must be a whole number >= 0, got {self.seed!r}")
        if not whole(self.ensemble) or self.ensemble < 1:
            raise InputError(f"tune: ensemble must be a whole number of members >= 1, got {self.ensemble!r}")
        if not real(self.quantile) or not 0 <= self.quantile <= 1:
            raise InputError(f"tune: quantile must be in [0, 1] (1 = worst case, 0.5 = median), got {self.quantile!r}")
        if not real(self.tolerance_deg) or not (math.isfinite(self.tolerance_deg) and self.tolerance_deg > 0):
            raise InputError(f"tune: tolerance_deg must be a finite number > 0, got {self.tolerance_deg!r}")
        if self.t_final is not None and not (real(self.t_final) and math.isfinite(self.t_final) and self.t_final > 0):
            raise InputError(f"tune: t_final must be a finite number > 0 (s), got {self.t_final!r}")
        if not whole(self.batch) or self.batch < 1:
            raise InputError(f"tune: batch must be a whole number of trials >= 1, got {self.batch!r}")
        if self.pruner not in PRUNERS:
            raise InputError(f"tune: unknown pruner {self.pruner!r} (known: auto, {', '.join(PRUNERS)})")
        if self.pruner != "none" and len(self.objectives) > 1:
            raise InputError(
                f"tune: pruner {self.pruner} judges one objective, got {len(self.objectives)} "
                f"({','.join(self.objectives)}); use pruner none with several objectives"
            )
        for name in self.constraints:
            if name not in CONSTRAINTS:
                raise InputError(f"tune: unknown constraint {name!r} (known: {', '.join(CONSTRAINTS)})")
        if len(set(self.constraints)) != len(self.constraints):
            raise InputError(f"tune: constraints: each may be named once, got {','.join(self.constraints)}")
        search_space(self)

    def identity(self) -> dict:
        """Everything that determines the trials except the budget (a resumed study must match it).

        Returns
        -------
        dict
            The settings as JSON-able data, without ``budget``.
        """
        out = asdict(self)
        out.pop("budget")
        return json.loads(json.dumps(out))


@dataclass(frozen=True)
class SearchParameter:
    """One searched parameter: ``[low, high]`` in ``unit``, log-uniform or uniform; ``size`` components set alike.

    Parameters
    ----------
    name : str
        The law parameter (or coupling factor) searched.
    unit : str
        Its unit.
    low, high : float
        The searched range.
    log : bool
        Searched log-uniformly (``low > 0`` and ``high / low >= 100``), else uniformly.
    size : int
        Number of components, all set to the searched value (``delta``: one value per axis).
    coupling : bool, optional
        A factor on the topology's weights (:data:`COUPLING`) rather than a law parameter.

    Examples
    --------
    >>> from fsmctl.studies import SearchParameter
    >>> delta = SearchParameter("delta", "1/s^2", 1e-4, 1e-1, log=True, size=3)
    >>> delta.column, delta.scenario_value(0.01)
    ('delta [1/s^2]', [0.01, 0.01, 0.01])
    """

    name: str
    unit: str
    low: float
    high: float
    log: bool
    size: int
    coupling: bool = False

    @property
    def column(self) -> str:
        """``name [unit]``: the parameter's column in ``trials.csv``."""
        return f"{self.name} [{self.unit}]"

    def scenario_value(self, value: float) -> float | list[float]:
        """The searched value as a scenario sets it: a number, or ``size`` equal numbers.

        Parameters
        ----------
        value : float
            The searched value.

        Returns
        -------
        float or list of float
            ``value`` for a scalar parameter, ``[value] * size`` for a vector.
        """
        return float(value) if self.size == 1 else [float(value)] * self.size


def _ranges(settings: TuneSettings) -> dict[str, tuple[float, float]]:
    out: dict[str, tuple[float, float]] = {}
    for item in settings.ranges:
        if len(item) != 3 or not isinstance(item[0], str):
            raise InputError(f"tune: a range is (name, low, high), got {item!r}")
        name, low, high = item
        try:
            low, high = float(low), float(high)
        except (TypeError, ValueError):
            raise InputError(f"tune: range of {name}: low and high must be numbers, got {item[1:]!r}") from None
        if not (math.isfinite(low) and math.isfinite(high) and low < high):
            raise InputError(f"tune: range of {name}: need finite low < high, got {low:g}, {high:g}")
        if name in out:
            raise InputError(f"tune: range of {name} given twice")
        out[name] = (low, high)
    return out


def _has_coupling(topology: Topology) -> bool:
    return any(link.k_i != 0 or link.k_j.max != 0 for link in topology.links)


def search_space(settings: TuneSettings, base: Scenario | None = None) -> list[SearchParameter]:
    """The searched parameters of ``settings.law`` with their ranges (see the module docstring).

    Parameters
    ----------
    settings : TuneSettings
        The law, ``parameters`` and ``ranges``.
    base : Scenario, optional
        The tuned scenario: without non-zero coupling weights the coupling factors are not searched by default.

    Returns
    -------
    list of SearchParameter
        In the order given (default: the law's declaration order, then :data:`COUPLING`).

    Raises
    ------
    InputError
        Unknown law or parameter, a parameter with options or not tunable, an override outside the declared range,
        or a side left unbounded by both the law and ``ranges``.

    Examples
    --------
    >>> from fsmctl.studies import TuneSettings, search_space
    >>> space = search_space(TuneSettings(parameters=("c1", "delta"), ranges={"c1": (0.1, 2.0), "delta": (1e-4, 0.1)}))
    >>> [(p.name, p.unit, p.low, p.high, p.log, p.size) for p in space]
    [('c1', '1/s', 0.1, 2.0, False, 1), ('delta', '1/s^2', 0.0001, 0.1, True, 3)]
    """
    from fsmctl.model.laws import resolve_law

    law = resolve_law(settings.law)
    declared = {p.name: p for p in law.parameters}
    given = _ranges(settings)
    names = list(settings.parameters)
    if not names:
        names = [p.name for p in law.parameters if p.tunable and not p.choices]
        if law.paper_theorems is not None and (base is None or _has_coupling(base.topology)):
            names += list(COUPLING)
    if len(set(names)) != len(names):
        raise InputError(f"tune: parameters: each may be named once, got {','.join(names)}")
    if not names:
        raise InputError(f"tune: the law {law.name!r} declares no tunable numeric parameter")
    for name in [*names, *given]:
        if name not in declared and name not in COUPLING:
            raise InputError(
                f"tune: the law {law.name!r} has no parameter {name!r} (its parameters: {', '.join(declared)}; "
                f"coupling factors: {', '.join(COUPLING)})"
            )
    extra = sorted(set(given) - set(names))
    if extra:
        raise InputError(
            f"tune: a range is given for {extra[0]!r}, which is not searched (parameters: {', '.join(names)})"
        )
    out = []
    for name in names:
        if name in COUPLING:
            low, high = given.get(name, COUPLING_RANGE)
            if low < 0:
                raise InputError(f"tune: range of {name}: must be >= 0, got {low:g} (declared range: 0 <= x)")
            out.append(SearchParameter(name, "1", low, high, low > 0 and high / low >= LOG_RATIO, 1, True))
            continue
        p = declared[name]
        if p.choices:
            raise InputError(f"tune: {name} has named options ({p.range_text()}), which are not searched")
        if not p.tunable:
            raise InputError(f"tune: the law {law.name!r} declares {name} not tunable")
        if name in given:
            low, high = given[name]
            for v in (low, high):
                why = p.problem(v)
                if why:
                    raise InputError(f"tune: range of {name}: {why} (declared range: {p.range_text()})")
        else:
            if p.minimum is None or p.maximum is None:
                raise InputError(
                    f"tune: {name} has no declared {'upper' if p.maximum is None else 'lower'} bound "
                    f"({p.range_text()}); give its range, e.g. --range {name}=LOW,HIGH"
                )
            low = float(np.nextafter(p.minimum, math.inf)) if p.exclusive_minimum else float(p.minimum)
            high = float(np.nextafter(p.maximum, -math.inf)) if p.exclusive_maximum else float(p.maximum)
            if not low < high:
                raise InputError(f"tune: {name}: the declared range {p.range_text()} is a single value")
        log = low > 0 and high / low >= LOG_RATIO
        out.append(SearchParameter(name, p.unit, low, high, log, p.size))
    return out


def available_constraints(law: str, base: Scenario) -> dict[str, str]:
    """Every constraint of :data:`CONSTRAINTS` with why it cannot be evaluated for ``law`` on ``base`` ("" = it can).

    Parameters
    ----------
    law : str
        A law spec (built-in name, script or folder).
    base : Scenario
        The tuned scenario (its torque limit and actuators).

    Returns
    -------
    dict
        Constraint name -> reason it cannot be evaluated, or "" when it can.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.studies import available_constraints
    >>> available_constraints("fsm", fsmctl.paper_scenario("1"))["wheels"]
    'paper case 1 has no reaction wheels with a finite max_speed'
    >>> available_constraints("pid", fsmctl.paper_scenario("1"))["torque"]
    ''
    """
    from fsmctl.model.laws import resolve_law

    law_code = resolve_law(law)
    paper = law_code.paper_theorems is not None  # the law declares it is eqs 13-19 (LawBuilder.paper_theorems)
    act = base.actuator
    limit = base.controller.torque_limit
    why_not = "is a condition of the paper's law (eqs 13-19), and the law {!r} does not declare it is that law"
    return {
        "converged": "",
        "theorem1": "" if paper else "Theorem 1 " + why_not.format(law_code.name),
        "theorem2": "" if paper else "Theorem 2 " + why_not.format(law_code.name),
        "torque": "" if math.isfinite(limit) else f"{base.label} has no torque limit (controller.torque_limit = inf)",
        "wheels": ""
        if act.enabled and bool(np.isfinite(act.per_wheel("max_speed")).any())
        else f"{base.label} has no reaction wheels with a finite max_speed",
    }


def unsettled_score(t_final: float, steady_max_deg: float, tolerance_deg: float) -> float:
    """The score of a metric that never settles within the horizon ``t_final`` (see the module docstring).

    Parameters
    ----------
    t_final : float
        The horizon (s).
    steady_max_deg : float
        The metric's maximum over the steady window (deg); NaN counts as a full decade above.
    tolerance_deg : float
        The settling tolerance (deg).

    Returns
    -------
    float
        ``t_final * (2 + min(1, max(0, log10(steady_max_deg / tolerance_deg))))`` (s).

    Examples
    --------
    >>> unsettled_score(10.0, 1.0, 1.0), unsettled_score(10.0, 100.0, 1.0), unsettled_score(10.0, float("nan"), 1.0)
    (20.0, 30.0, 30.0)
    """
    ratio = steady_max_deg / tolerance_deg
    decades = 1.0 if not math.isfinite(ratio) else min(1.0, max(0.0, math.log10(max(ratio, 1e-300))))
    return float(t_final) * (2.0 + decades)


def progress_score(t_final: float, steady_max_deg: float, tolerance_deg: float) -> float:
    """The intermediate value of a settling objective not yet settled at a checkpoint: ``t_final * (2 + d)``.

    ``d = max(0, log10(steady_max / tolerance_deg))``, with ``steady_max`` the steady error so far, estimates the
    never-settles score (:func:`unsettled_score`) the run would get if it stayed where it is; ``d`` is not capped at
    one, so the pruner can tell a run 10 times above the tolerance from one 1000 times above.  As a converging run's
    error falls, so does its value (Optuna's pruners compare each trial's best value so far).  NaN (a diverged run)
    stays NaN, which Optuna's pruners prune.

    Parameters
    ----------
    t_final : float
        The horizon (s).
    steady_max_deg : float
        The metric's maximum over the steady part of the run so far (deg).
    tolerance_deg : float
        The settling tolerance (deg).

    Returns
    -------
    float
        Seconds (NaN for a NaN error).

    Examples
    --------
    >>> progress_score(10.0, 1.0, 1.0), progress_score(10.0, 1000.0, 1.0)
    (20.0, 50.0)
    """
    ratio = steady_max_deg / tolerance_deg
    if math.isnan(ratio):
        return math.nan
    return float(t_final) * (2.0 + max(0.0, math.log10(max(ratio, 1e-300))))


# ----------------------------------------------------------------------------- topology and proof conditions


def scaled_topology(topology: Topology, k_i_scale: float | None = None, k_j_scale: float | None = None) -> Topology:
    """The topology with every ``k^i_ij`` multiplied by ``k_i_scale`` and every ``k^j_ij(t)`` value by ``k_j_scale``.

    Parameters
    ----------
    topology : Topology
        Graph, weights, schedules and phases (kept).
    k_i_scale, k_j_scale : float, optional
        Factors (>= 0); None leaves those weights as they are.

    Returns
    -------
    Topology

    Examples
    --------
    >>> from fsmctl.model.scenario import paper_scenario
    >>> t = scaled_topology(paper_scenario("1").topology, 0.5, 2.0)
    >>> t.links[0].k_i, t.links[0].k_j.max
    (4.0, 10.0)
    """
    links = []
    for link in topology.links:
        k_i = link.k_i if k_i_scale is None else link.k_i * float(k_i_scale)
        k_j = link.k_j if k_j_scale is None else link.k_j.scaled(float(k_j_scale))
        links.append(Link(link.receiver, link.sender, k_i, k_j, link.phase))
    return Topology(topology.n_agents, tuple(links))


def theorem1_constraint(topology: Topology, t_final: float) -> float:
    """The ``theorem1`` constraint: 0 when Theorem 1 holds for ``topology`` over ``[0, t_final]``, else ``1 + e``.

    ``e >= 0`` is the largest excess ``max_t k^j_ij(t) - k^i_ij`` over the links (Liang et al. 2012, eq 27 needs
    ``k^i_ij >= k^j_ij(t)``); the conditions are those of :func:`fsmctl.proofs.theorem1.analyze_topology`
    (``holds``).

    Parameters
    ----------
    topology : Topology
        Gains and schedules.
    t_final : float
        Horizon (s), for schedules without a common period.

    Returns
    -------
    float

    Examples
    --------
    >>> from fsmctl.model.scenario import paper_scenario
    >>> top = paper_scenario("1").topology  # k^i = 8, k^j = 5 when on
    >>> theorem1_constraint(top, 100.0), theorem1_constraint(scaled_topology(top, 0.5), 100.0)
    (0.0, 2.0)
    """
    from fsmctl.proofs.theorem1 import analyze_topology

    if analyze_topology(topology, t_final).holds:
        return 0.0
    excess = max((link.k_j.max - link.k_i for link in topology.links), default=0.0)
    return 1.0 + max(0.0, float(excess))


def _coupling_scales(space: Sequence[SearchParameter], values: Mapping[str, float]) -> dict[str, float]:
    return {p.name: float(values[p.name]) for p in space if p.coupling}


def _trial_scenario(member: Scenario, law: str, space: Sequence[SearchParameter], values: Mapping) -> Scenario:
    from fsmctl.studies.compare import LawRun, run_scenario

    params = {p.name: p.scenario_value(values[p.name]) for p in space if not p.coupling}
    scenario = run_scenario(member, LawRun("tune", law, params))
    scales = _coupling_scales(space, values)
    if scales:
        top = scaled_topology(scenario.topology, scales.get("k_i_scale"), scales.get("k_j_scale"))
        scenario = scenario.with_topology(top)
    return scenario


def _base_scenario(settings: TuneSettings) -> Scenario:
    from fsmctl.model.scenario import load_scenario

    base = load_scenario(settings.scenario, settings.case)
    if settings.t_final is not None:
        sim = base.simulation
        base = base.replace(
            simulation={"t_final": settings.t_final, "output_interval": min(sim.output_interval, settings.t_final)}
        )
    return base


def _members(base: Scenario, settings: TuneSettings) -> list[Scenario]:
    if settings.ensemble == 1:
        return [base]
    from fsmctl.studies.montecarlo import CampaignSettings, sample_run_scenario

    campaign = CampaignSettings(scenario=settings.scenario, case=base.case, runs=settings.ensemble, seed=settings.seed)
    seeds = np.random.SeedSequence(settings.seed).spawn(settings.ensemble)
    return [sample_run_scenario(base, campaign, s) for s in seeds]


def _portable_law(law: str) -> str:
    """A built-in name as it is; a script or folder as the absolute folder of its generated code (for the workers)."""
    from fsmctl.model.laws import resolve_law

    code = resolve_law(law)
    return code.name if code.builtin else str(code.folder)


# ----------------------------------------------------------------------------- evaluating one candidate


@dataclass(frozen=True)
class _Context:
    """What every evaluation needs (sent to the workers once per task, or scattered once to a Dask cluster)."""

    law: str
    space: tuple[SearchParameter, ...]
    members: tuple[Scenario, ...]
    objectives: tuple[str, ...]
    constraints: tuple[str, ...]
    tolerance_deg: float
    quantile: float
    pruner: str
    topology: Topology
    """the scenario's topology (Theorem 1 is evaluated on it with the candidate's weights)"""
    theorem1: float | None
    """the ``theorem1`` value when the weights are not searched (computed once)"""
    requirements: tuple[np.ndarray, ...] = ()
    """Theorem 2's requirement ``(n_agents, 3)`` per member"""
    study: str = ""
    """a key of this search (the workers cache the told trials under it)"""

    @property
    def simulated(self) -> tuple[str, ...]:
        return tuple(c for c in self.constraints if c in SIMULATED_CONSTRAINTS)


def _quantile(values: Sequence[float], q: float) -> float:
    return float(np.quantile(np.asarray(values, dtype=float), q, method="higher"))


def _settling_scores(metrics: Mapping[str, float], t_final: float, tol: float) -> dict[str, float]:
    settle = {}
    for which in ("aaem", "raem"):
        t = metrics[f"{which}_settling_{tol:g}deg_s"]
        settle[which] = t if math.isfinite(t) else unsettled_score(t_final, metrics[f"{which}_steady_max_deg"], tol)
    return settle


_METRIC = {
    "aaem_steady": "aaem_steady_max_deg",
    "raem_steady": "raem_steady_max_deg",
    "peak_torque": "peak_torque_N_m",
    "rms_torque": "rms_torque_N_m",
    "chattering": "chattering_N_m_per_s",
    "wheel_momentum": "peak_wheel_momentum_N_m_s",
}


def _steady_mask(time: np.ndarray) -> np.ndarray:
    from fsmctl.studies.compare import default_steady_window

    window = min(default_steady_window(float(time[-1] - time[0])), float(time[-1] - time[0]))
    return time >= time[-1] - window - 1e-12  # the window of run_metrics and steady_state_max


def torque_excess(result, since: float = math.nan) -> float:
    """The ``torque`` constraint of one run: ``max |u_unsat|`` after the transient minus the torque limit (N m).

    Parameters
    ----------
    result : SimulationResult
        A run of a scenario with a finite ``controller.torque_limit``.
    since : float
        The end of the transient (s): the maximum is taken over the output samples at ``t >= since``; NaN (a run
        that did not settle) takes the steady window (the last 40 % of the horizon, at most 40 s).

    Returns
    -------
    float
        N m; <= 0 when the formation is held within the limit after the transient.

    Examples
    --------
    On a 2 s horizon of Case 1 the formation has not converged and the law still asks for more than 2 N m:

    >>> import fsmctl
    >>> from fsmctl.studies.tune import torque_excess
    >>> result = fsmctl.simulate(fsmctl.paper_scenario("1").replace(simulation={"t_final": 2.0}))
    >>> torque_excess(result) > 0
    True
    """
    t = np.asarray(result.time, dtype=float)
    window = _steady_mask(t) if math.isnan(since) else t >= since - 1e-12
    u = np.asarray(result.u_unsaturated, dtype=float)[window]
    return float(np.max(np.abs(u))) - float(result.scenario.controller.torque_limit)


def wheel_load(result) -> float:
    """Peak wheel momentum as a fraction of the capacity ``J_s max_speed``, over agents, wheels and samples.

    Parameters
    ----------
    result : SimulationResult
        A run with reaction wheels (wheels without a speed limit count 0).

    Returns
    -------
    float
        ``max |J_s,k Omega_ik(t)| / (J_s,k max_speed_k)``; the ``wheels`` constraint is this minus
        :data:`WHEEL_CAPACITY_FRACTION`.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.studies.tune import wheel_load
    >>> result = fsmctl.simulate(fsmctl.load_scenario("paper-hardware").replace(simulation={"t_final": 1.0}))
    >>> 0 < wheel_load(result) < 0.99  # the wheels have barely spun up after 1 s
    True
    """
    act = result.scenario.actuator
    cap = act.per_wheel("spin_inertia") * act.per_wheel("max_speed")
    h = np.abs(np.asarray(result.wheel_speed, dtype=float)) * act.per_wheel("spin_inertia")
    frac = np.where(np.isfinite(cap), h / np.where(np.isfinite(cap), cap, 1.0), 0.0)
    return float(np.max(frac))


def _run_scores(result, ctx: _Context) -> list[float]:
    """``[*objectives, *simulated constraints]`` of one complete run."""
    from fsmctl.studies.compare import run_metrics

    tol = ctx.tolerance_deg
    t_final = float(result.scenario.simulation.t_final)
    metrics = run_metrics(result, tolerances_deg=(tol,))
    settle = _settling_scores(metrics, t_final, tol)
    values = [settle[name[:4]] if name.endswith("_settling") else metrics[_METRIC[name]] for name in ctx.objectives]
    extra = {"converged": lambda: max(settle.values()) - t_final}
    settled = [metrics[f"{w}_settling_{tol:g}deg_s"] for w in ("aaem", "raem")]
    extra["torque"] = lambda: torque_excess(result, max(settled) if all(map(math.isfinite, settled)) else math.nan)
    extra["wheels"] = lambda: wheel_load(result) - WHEEL_CAPACITY_FRACTION
    return [*values, *(extra[c]() for c in ctx.simulated)]


def _proof_constraints(ctx: _Context, scenarios: Sequence[Scenario], values: Mapping[str, float]) -> dict[str, float]:
    out: dict[str, float] = {}
    if "theorem1" in ctx.constraints:
        if ctx.theorem1 is not None:
            out["theorem1"] = ctx.theorem1
        else:
            scales = _coupling_scales(ctx.space, values)
            top = scaled_topology(ctx.topology, scales.get("k_i_scale"), scales.get("k_j_scale"))
            out["theorem1"] = theorem1_constraint(top, scenarios[0].simulation.t_final)
    if "theorem2" in ctx.constraints:
        from fsmctl.proofs.theorem2 import delta_margin, fsm_deltas

        out["theorem2"] = max(-delta_margin(fsm_deltas(s), r) for s, r in zip(scenarios, ctx.requirements, strict=True))
    return out


class _Series:
    """The intermediate value of one member: its first objective estimated from the run up to the checkpoint."""

    def __init__(self, objective: str, tolerance_deg: float, horizon: float):
        self.objective = objective
        self.tol = tolerance_deg
        self.horizon = horizon
        self._metric = np.zeros(0)

    def _error_metric(self, sigma_e: np.ndarray, w: int) -> np.ndarray:
        from fsmctl.simulation.metrics import aaem_deg, principal_angles, streamed_raem_deg

        n = self._metric.size
        if w > n:
            new = np.asarray(sigma_e[n:w], dtype=float)
            ext = aaem_deg(principal_angles(new)) if self.objective.startswith("aaem") else streamed_raem_deg(new)
            self._metric = np.concatenate([self._metric, ext])
        return self._metric[:w]

    def score(self, result, w: int) -> float:
        from fsmctl.simulation.metrics import settling_time

        t = np.asarray(result.time[:w], dtype=float)
        span = float(t[-1] - t[0])
        name = self.objective
        if name.endswith(("_settling", "_steady")):
            metric = self._error_metric(result.sigma_e, w)
            steady = float(np.max(metric[_steady_mask(t)]))
            if name.endswith("_steady"):
                return steady
            s = settling_time(t, metric, self.tol)
            return s if math.isfinite(s) else progress_score(self.horizon, steady, self.tol)
        if name == "wheel_momentum":
            act = result.scenario.actuator
            h = np.asarray(result.wheel_speed[:w], dtype=float) * act.per_wheel("spin_inertia")
            return float(np.max(np.linalg.norm(h @ act.spin_axes().T, axis=-1)))
        u = np.asarray(result.u[:w], dtype=float)
        if name == "peak_torque":
            return float(np.max(np.abs(u)))
        if span <= 0:
            return 0.0
        if name == "rms_torque":
            sq = np.sum(np.square(u), axis=(1, 2))
            area = float(np.sum(0.5 * (sq[1:] + sq[:-1]) * np.diff(t)))
            return math.sqrt(area / (u.shape[1] * span))
        return float(np.sum(np.abs(np.diff(u, axis=0)))) / span  # chattering


def _make_pruner(name: str):
    import optuna

    if name == "median":
        return optuna.pruners.MedianPruner(n_startup_trials=MEDIAN_STARTUP_TRIALS, n_warmup_steps=MEDIAN_WARMUP_STEPS)
    if name == "halving":
        return optuna.pruners.SuccessiveHalvingPruner(min_resource=1, reduction_factor=HALVING_REDUCTION_FACTOR)
    raise ValueError(f"no pruner {name!r}")


Snapshot = tuple[tuple[int, str, dict, dict], ...]
"""the told trials a pruner sees: ``(number, state name, intermediate values, pruner attributes)`` each"""


class _FrozenStudy:
    """A study as an Optuna pruner reads it, frozen: the trials told before the candidate's batch, and the candidate.

    Pruners read ``get_trials``, ``direction`` and write their bookkeeping through
    ``_storage.set_trial_system_attr`` (successive halving's rungs), which here lands in the candidate's attributes.
    """

    def __init__(self, told: list, probe):
        from optuna.study import StudyDirection

        self._trials = [*told, probe]
        self._probe = probe
        self.direction = StudyDirection.MINIMIZE
        self.directions = [self.direction]
        self._storage = self

    def get_trials(self, deepcopy: bool = True, states=None) -> list:
        return [t for t in self._trials if states is None or t.state in states]

    def set_trial_system_attr(self, trial_id: int, key: str, value: Any) -> None:
        if trial_id != self._probe._trial_id:
            raise RuntimeError("a pruner may only change the trial it judges")
        self._probe.system_attrs[key] = value


_TOLD: dict[str, dict[int, Any]] = {}
"""per study (its key): the told trials already rebuilt in this process, by number (a told trial never changes)"""


def _frozen_trials(snapshot: Snapshot, study: str = "") -> list:
    """The snapshot's trials as Optuna's ``FrozenTrial`` (what a pruner reads), rebuilt once per process and study."""
    from optuna.trial import FrozenTrial, TrialState

    cache = _TOLD.get(study) if study else None
    if cache is None:
        cache = {}
        if study:
            _TOLD.clear()  # one study at a time
            _TOLD[study] = cache
    out = []
    for n, state, values, attrs in snapshot:
        trial = cache.get(n)
        if trial is None:
            trial = cache[n] = FrozenTrial(
                number=n,
                state=TrialState[state],
                value=None,
                datetime_start=None,
                datetime_complete=None,
                params={},
                distributions={},
                user_attrs={},
                system_attrs=dict(attrs),
                intermediate_values={int(k): float(v) for k, v in values.items()},
                trial_id=n,
            )
        out.append(trial)
    return out


class _Judge:
    """Computes a candidate's intermediate values at the checkpoints and asks the pruner (see the module docstring).

    Step ``k`` is the output sample ``k * k_out`` (``k_out`` output intervals per checkpoint); its value needs every
    member's run up to that sample.  The simulator calls :meth:`monitor` with the runs it flies together (all
    members, or one batch of them after the other); the value of a step is decided, in step order, once every
    member has reached it, so a decision never depends on how the members were batched.  :meth:`replay` decides the
    steps the monitor did not reach (a simulator that flew the runs without calling it) on the complete runs, whose
    first samples are bit for bit the partial runs.
    """

    def __init__(self, ctx: _Context, snapshot: Snapshot, scenarios: Sequence[Scenario]):
        sim = scenarios[0].simulation
        self.k_out = max(1, round(sim.t_final / CHECKPOINTS / sim.output_interval))
        self.interval = self.k_out * sim.output_interval
        self.quantile = ctx.quantile
        self.scenarios = list(scenarios)
        self._ids = {id(sc): m for m, sc in enumerate(self.scenarios)}
        self.series = [_Series(ctx.objectives[0], ctx.tolerance_deg, sim.t_final) for _ in self.scenarios]
        self.member_values: list[dict[int, float]] = [{} for _ in self.scenarios]
        self.pruner = _make_pruner(ctx.pruner)
        self.told = _frozen_trials(snapshot, ctx.study)
        self.values: dict[int, float] = {}
        self.attrs: dict[str, Any] = {}
        self.pruned_at: float | None = None

    def _member(self, result, order: int) -> int:
        m = self._ids.get(id(result.scenario))
        if m is None:  # not the object we passed: the first member with an equal scenario that has not run yet
            free = [k for k, sc in enumerate(self.scenarios) if sc == result.scenario and not self.member_values[k]]
            m = free[0] if free else order
        return m

    def _advance(self, results: Sequence, members: Sequence[int], w: int) -> bool:
        """Record the members' values of every step within their first ``w`` samples, then decide the steps every
        member has reached, in order; True when the pruner stops the candidate."""
        from optuna.trial import FrozenTrial, TrialState

        last = (w - 1) // self.k_out
        for m, r in zip(members, results, strict=True):
            for step in range(1, last + 1):
                if step not in self.member_values[m]:
                    self.member_values[m][step] = self.series[m].score(r, step * self.k_out + 1)
        step = len(self.values) + 1
        while self.pruned_at is None and all(step in mv for mv in self.member_values):
            self.values[step] = _quantile([mv[step] for mv in self.member_values], self.quantile)
            probe = FrozenTrial(
                number=-1,
                state=TrialState.RUNNING,
                value=None,
                datetime_start=None,
                datetime_complete=None,
                params={},
                distributions={},
                user_attrs={},
                system_attrs=dict(self.attrs),
                intermediate_values=dict(self.values),
                trial_id=-1,
            )
            prune = bool(self.pruner.prune(_FrozenStudy(self.told, probe), probe))
            self.attrs = dict(probe.system_attrs)
            if prune:
                self.pruned_at = float(results[0].time[step * self.k_out])
            step += 1
        return self.pruned_at is not None

    def monitor(self, t: float, partial: Callable[[], Sequence]) -> bool:
        if self.pruned_at is not None:
            return True
        results = list(partial())
        members = [self._member(r, k) for k, r in enumerate(results)]
        return self._advance(results, members, min(len(r.time) for r in results))

    def replay(self, results: Sequence) -> None:
        """Decide the steps left on complete runs (every checkpoint before the last sample)."""
        if self.pruned_at is None:
            self._advance(results, range(len(results)), len(results[0].time) - 1)


def _fly(scenarios: Sequence[Scenario], judge: _Judge | None) -> list:
    """Simulate a candidate's members in one call; a judge watches them (and may stop them) at its checkpoints."""
    from fsmctl.simulation import simulator

    many = getattr(simulator, "simulate_many", None)
    if many is None:  # a simulator without simulate_many: the judge decides on the complete runs
        results = [simulator.simulate(s, progress=False) for s in scenarios]
    elif judge is None:
        results = list(many(list(scenarios)))
    else:
        results = list(many(list(scenarios), monitor=judge.monitor, monitor_interval=judge.interval))
    if judge is not None and judge.pruned_at is None:
        judge.replay(results)
    return results


def _evaluate(ctx: _Context, values: Mapping[str, float], snapshot: Snapshot | None) -> dict:
    """Fly one candidate and score it: a dict with ``state`` ("complete", "pruned", "failed") and what was measured."""
    from fsmctl.simulation.simulator import SimulationError

    out: dict[str, Any] = {
        "state": "complete",
        "objectives": [],
        "constraints": {},
        "members": [],
        "intermediate": {},
        "pruner_attrs": {},
        "pruned_at": None,
        "error": "",
    }
    scenarios = [_trial_scenario(m, ctx.law, ctx.space, values) for m in ctx.members]
    proof = _proof_constraints(ctx, scenarios, values)
    judge = _Judge(ctx, snapshot or (), scenarios) if ctx.pruner != "none" else None
    try:
        results = _fly(scenarios, judge)
    except SimulationError as exc:
        out.update(state="failed", error=" ".join(str(exc).split()), constraints=proof)
        return out
    if judge is not None:
        out.update(intermediate=dict(judge.values), pruner_attrs=dict(judge.attrs))
        if judge.pruned_at is not None:
            out.update(state="pruned", pruned_at=judge.pruned_at, constraints=proof)
            return out
    scores = [_run_scores(r, ctx) for r in results]
    agg = [_quantile(col, ctx.quantile) for col in zip(*scores, strict=True)]
    n = len(ctx.objectives)
    cons = dict(zip(ctx.simulated, agg[n:], strict=True))
    cons.update(proof)
    out.update(
        objectives=agg[:n],
        constraints={c: (math.inf if math.isnan(cons[c]) else cons[c]) for c in ctx.constraints},
        members=scores,
    )
    bad = [k for k, v in zip(ctx.objectives, agg[:n], strict=True) if math.isnan(v)]
    if bad:
        out.update(state="failed", error=f"objective {bad[0]} is NaN")
    return out


# ----------------------------------------------------------------------------- evaluating a batch


def _worker_died(message: str) -> dict:
    return {
        "state": "failed",
        "objectives": [],
        "constraints": {},
        "members": [],
        "intermediate": {},
        "pruner_attrs": {},
        "pruned_at": None,
        "error": message,
    }


class _Evaluator:
    """Evaluates batches of candidates: in this process, on a local process pool (kept for the whole study, replaced
    when a worker dies) or on a Dask cluster."""

    def __init__(self, ctx: _Context, workers: int, client: Any = None):
        self.ctx = ctx
        self.workers = workers
        self.client = client
        self._stack = contextlib.ExitStack()
        self._pool = None
        self._ctx_ref: Any = ctx

    def __enter__(self) -> _Evaluator:
        from fsmctl.studies.parallel import single_threaded_workers, worker_pool

        if self.client is not None:
            self._ctx_ref = self.client.scatter(self.ctx, broadcast=True, hash=False)
        elif self.workers > 1:
            self._stack.enter_context(single_threaded_workers())
            self._pool = self._stack.enter_context(worker_pool(self.workers))
        return self

    def __exit__(self, *exc) -> bool:
        return bool(self._stack.__exit__(*exc))

    def run(self, tasks: Sequence[Mapping[str, float]], snapshot: Snapshot | None, done: Callable[[], None]) -> list:
        """Results of ``_evaluate`` for every task, in order; ``done()`` after each one finishes."""
        if self.client is not None:
            return self._run_dask(tasks, snapshot, done)
        if self._pool is None:
            out = []
            for values in tasks:
                out.append(_evaluate(self.ctx, values, snapshot))
                done()
            return out
        return self._run_pool(tasks, snapshot, done)

    def _run_pool(self, tasks, snapshot, done) -> list:
        from concurrent.futures import FIRST_COMPLETED, wait
        from concurrent.futures.process import BrokenProcessPool

        from fsmctl.studies.parallel import stop_pool, worker_pool

        reported: set[int] = set()
        for _attempt in range(2):
            futures = [self._pool.submit(_evaluate, self.ctx, values, snapshot) for values in tasks]
            try:
                pending = set(futures)
                while pending:
                    finished, pending = wait(pending, return_when=FIRST_COMPLETED)
                    for f in finished:
                        i = futures.index(f)
                        if i not in reported and f.exception() is None:
                            reported.add(i)
                            done()
                return [f.result() for f in futures]
            except BrokenProcessPool:
                stop_pool(self._pool)  # a worker died: a fresh pool for the retry (the old one ends with the study)
                self._pool = self._stack.enter_context(worker_pool(self.workers))
        # still dying: one candidate per single-worker pool; one that kills its worker is a failed trial
        out = []
        for values in tasks:
            with worker_pool(1) as ex:
                try:
                    out.append(ex.submit(_evaluate, self.ctx, values, snapshot).result())
                except BrokenProcessPool:
                    out.append(_worker_died("the worker process died while flying this candidate"))
        return out

    def _run_dask(self, tasks, snapshot, done) -> list:
        from distributed import as_completed

        try:
            from distributed import KilledWorker
        except ImportError:  # older distributed
            from distributed.scheduler import KilledWorker

        snap = self.client.scatter([snapshot], hash=False)[0] if snapshot else snapshot
        stamp = f"{os.getpid()}-{time.time_ns()}"
        futures = [
            self.client.submit(_evaluate, self._ctx_ref, values, snap, pure=False, key=f"fsmctl-tune-{stamp}-{i}")
            for i, values in enumerate(tasks)
        ]
        try:
            for _ in as_completed(futures, loop=self.client.loop):
                done()
            out = []
            for f in futures:
                try:
                    out.append(f.result())
                except KilledWorker as exc:
                    out.append(_worker_died(f"{type(exc).__name__}: {exc}".splitlines()[0][:500]))
            return out
        except BaseException:
            with contextlib.suppress(Exception):
                self.client.cancel(futures, force=True)
            raise


# ----------------------------------------------------------------------------- result


@dataclass
class TuneResult:
    """A finished (or resumed and finished) search: every trial, the feasible Pareto front and the chosen design.

    Parameters
    ----------
    settings : TuneSettings
        The settings that ran.
    space : list of SearchParameter
        The searched parameters (:func:`search_space`).
    constraints : tuple of str
        The constraints that were applied.
    trials : list of dict
        One dict per trial in order (``index``, ``state`` "complete" | "pruned" | "failed", ``feasible``,
        ``params`` by name, ``objectives`` by name, ``constraints`` by name, ``pruned_at`` (s or None), ``error``).
    pareto : list of int
        Indices of the feasible non-dominated trials.
    best : int or None
        Index of the feasible trial with the smallest first objective (None: no feasible trial).
    theorem1 : bool or None
        Whether Theorem 1 holds for the scenario's own weights (None: not a condition of the law).
    notes : list of str, optional
        What the user must know (one line each).
    paths : list of pathlib.Path, optional
        The files written.

    Examples
    --------
    >>> from fsmctl.studies import TuneSettings
    >>> from fsmctl.studies.tune import tune
    >>> result = tune(TuneSettings(budget=2, batch=2, t_final=1.0, objectives=("peak_torque",), parameters=("c1",),
    ...                            ranges={"c1": (0.1, 2.0)}, constraints=("converged",)), "tuned", progress=False)
    >>> [t["state"] for t in result.trials], result.best  # 1 s is too short to converge: nothing feasible
    (['complete', 'complete'], None)
    >>> print(result.to_text().splitlines()[-1])
    no feasible design found (widen the ranges, raise the budget or the horizon)
    """

    settings: TuneSettings
    space: list[SearchParameter]
    constraints: tuple[str, ...]
    trials: list[dict]
    pareto: list[int]
    best: int | None
    theorem1: bool | None
    notes: list[str] = field(default_factory=list)
    paths: list[Path] = field(default_factory=list)

    def to_text(self) -> str:
        """The summary ``fsmctl tune`` prints: counts, constraints, the best design (or why there is none), the notes.

        Returns
        -------
        str
            Lines of text.
        """
        s = self.settings
        n_feasible = sum(t["feasible"] for t in self.trials)
        n_pruned = sum(t["state"] == "pruned" for t in self.trials)
        n_failed = sum(t["state"] == "failed" for t in self.trials)
        lines = [
            f"tune: law {s.law} on {s.scenario}" + (f" case {s.case}" if s.case else "") + f", {len(self.trials)} "
            f"trials ({n_pruned} pruned, {n_failed} failed), {n_feasible} feasible, {len(self.pareto)} on the "
            "Pareto front"
        ]
        lines.append("constraints: " + ", ".join(self.constraints))
        if self.best is None:
            lines.append("no feasible design found (widen the ranges, raise the budget or the horizon)")
        else:
            t = self.trials[self.best]
            params = ", ".join(f"{p.name}={t['params'][p.name]:.6g} {p.unit}" for p in self.space)
            objs = ", ".join(f"{k}={v:.6g} {OBJECTIVES[k][0]}" for k, v in t["objectives"].items())
            lines.append(f"best: trial {self.best}: {params}; {objs}")
        return "\n".join(lines + [f"note: {n}" for n in self.notes])


def _pareto(trials: Sequence[dict], objectives: Sequence[str]) -> list[int]:
    pts = [(t["index"], [t["objectives"][k] for k in objectives]) for t in trials if t["feasible"]]
    front = []
    for i, a in pts:
        dominated = any(
            all(x <= y for x, y in zip(b, a, strict=True)) and any(x < y for x, y in zip(b, a, strict=True))
            for _, b in pts
        )
        if not dominated:
            front.append(i)
    return front


# ----------------------------------------------------------------------------- outputs


def _columns(result: TuneResult) -> list[str]:
    cols = ["trial", "state", "feasible"]
    cols += [p.column for p in result.space]
    cols += [f"{k} [{OBJECTIVES[k][0]}]" for k in result.settings.objectives]
    cols += [f"constraint_{c} [{CONSTRAINTS[c][0]}]" for c in result.constraints]
    return [*cols, "pruned_at [s]", "error"]


def _row(result: TuneResult, t: dict) -> list:
    row: list[Any] = [t["index"], t["state"], int(t["feasible"])]
    row += [t["params"].get(p.name, "") for p in result.space]
    row += [t["objectives"].get(k, "") for k in result.settings.objectives]
    row += [t["constraints"].get(c, "") for c in result.constraints]
    return [*row, "" if t["pruned_at"] is None else t["pruned_at"], t["error"]]


def _write_csv(path: Path, result: TuneResult, indices: Sequence[int]) -> None:
    from fsmctl.outputs import atomic_path

    with atomic_path(path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(_columns(result))
        for i in indices:
            w.writerow(_row(result, result.trials[i]))


def _figure(result: TuneResult):
    from matplotlib.figure import Figure

    objs = result.settings.objectives
    fig = Figure(figsize=(6.4, 4.8), layout="constrained")
    ax = fig.add_subplot()

    def xy(t: dict) -> tuple[float, float]:
        if len(objs) == 1:
            return float(t["index"]), t["objectives"][objs[0]]
        return t["objectives"][objs[0]], t["objectives"][objs[1]]

    done = [t for t in result.trials if t["state"] == "complete"]
    for feasible, style in (
        (False, dict(marker="x", color="0.6", label="infeasible")),
        (True, dict(marker="o", color="C0", label="feasible")),
    ):
        pts = [xy(t) for t in done if t["feasible"] == feasible]
        if pts:
            ax.scatter(*zip(*pts, strict=True), s=18, **style)
    front = sorted(xy(result.trials[i]) for i in result.pareto)
    if front:
        ax.plot(
            *zip(*front, strict=True), color="C3", marker="o", drawstyle="steps-post", label="Pareto front (feasible)"
        )
    if result.best is not None:
        ax.scatter(*xy(result.trials[result.best]), s=120, facecolor="none", edgecolor="k", label="chosen design")
    if len(objs) == 1:
        ax.set_xlabel("trial")
        ax.set_ylabel(f"{objs[0]} [{OBJECTIVES[objs[0]][0]}]")
    else:
        ax.set_xlabel(f"{objs[0]} [{OBJECTIVES[objs[0]][0]}]")
        ax.set_ylabel(f"{objs[1]} [{OBJECTIVES[objs[1]][0]}]")
    s = result.settings
    n_pruned = sum(t["state"] == "pruned" for t in result.trials)
    ax.set_title(
        f"fsmctl tune: {s.law} on {Path(s.scenario).name}"
        + (f" case {s.case}" if s.case else "")
        + (f" ({n_pruned} pruned trials not shown)" if n_pruned else ""),
        fontsize=10,
    )
    if ax.has_data():
        ax.legend(fontsize=8)
    return fig


def _merge(base: dict, over: Mapping) -> dict:
    out = dict(base)
    for k, v in over.items():
        out[k] = _merge(out[k], v) if isinstance(v, Mapping) and isinstance(out.get(k), Mapping) else v
    return out


def _scaled_schedule(value: Any, factor: float) -> Any:
    if isinstance(value, Mapping):
        return {**value, "values": [factor * float(x) for x in value["values"]]}
    return factor * float(value)


def _topology_overlay(base: Scenario, scales: Mapping[str, float]) -> dict:
    """The ``[topology]`` keys of the base scenario's table (its case's overrides applied) with the weights scaled as
    :func:`scaled_topology` scales them."""
    src = base.source
    table = dict(src.get("topology", {}))
    case = (src.get("cases") or {}).get(base.case) if base.case is not None else None
    if isinstance(case, Mapping) and isinstance(case.get("topology"), Mapping):
        table = _merge(table, case["topology"])
    si, sj = scales.get("k_i_scale"), scales.get("k_j_scale")
    out: dict[str, Any] = {}
    if si is not None:
        out["k_i"] = float(table.get("k_i", 0.0)) * si
    if sj is not None:
        key = "k_j" if "k_j" in table else "schedule"
        out[key] = _scaled_schedule(table.get(key, 0.0), sj)
    if "links" in table:
        links = []
        for item in table["links"]:
            item = dict(item)
            if si is not None and "k_i" in item:
                item["k_i"] = float(item["k_i"]) * si
            if sj is not None and "k_j" in item:
                item["k_j"] = _scaled_schedule(item["k_j"], sj)
            links.append(item)
        out["links"] = links
    return out


def best_scenario_text(result: TuneResult, base: Scenario, *, comments: Sequence[str] = ()) -> str:
    """``best.toml``: the base scenario (``extends``) with the chosen design, for ``fsmctl simulate --scenario``.

    The design (``[controller]`` keys: the law, its tuned parameters; ``[topology]`` weights when the coupling
    factors were searched; the horizon when ``t_final`` was set) goes where loading the file applies it last: the
    table of the scenario's first case when it has cases (loading a file without ``--case`` selects its first case),
    with the tuned case's own overrides copied there when the tuned case is another one; else the top-level tables.

    Parameters
    ----------
    result : TuneResult
        A search with a feasible trial (``result.best``).
    base : Scenario
        The tuned scenario (its source tables and cases).
    comments : sequence of str, optional
        More ``#`` comment lines for the header (:func:`tune` adds the versions and the command line).

    Returns
    -------
    str
        The TOML text.

    Examples
    --------
    :func:`tune` writes it as ``best.toml``; loading that file flies the chosen design:

    >>> import fsmctl
    >>> from fsmctl.studies import TuneSettings
    >>> from fsmctl.studies.tune import best_scenario_text, tune
    >>> result = tune(TuneSettings(budget=2, batch=2, t_final=1.0, objectives=("peak_torque",), parameters=("c1",),
    ...                            ranges={"c1": (0.1, 2.0)}, constraints=("theorem1",)), "tuned", progress=False)
    >>> text = best_scenario_text(result, fsmctl.paper_scenario("1").replace(simulation={"t_final": 1.0}))
    >>> text.splitlines()[3]
    'extends = "paper"'
    >>> best = fsmctl.load_scenario("tuned/best.toml")
    >>> best.controller.parameters["c1"] == result.trials[result.best]["params"]["c1"], best.simulation.t_final
    (True, 1.0)
    """
    from fsmctl.model.scenario import BUILTIN_SCENARIOS

    s = result.settings
    t = result.trials[result.best]
    law = s.law
    law_path = Path(law).expanduser()
    if law.endswith(".py") or len(law_path.parts) > 1 or law_path.is_dir():
        law = str(law_path.resolve())
    controller: dict[str, Any] = {"law": law}
    for p in result.space:
        if not p.coupling:
            controller[p.name] = p.scenario_value(t["params"][p.name])
    overlay: dict[str, Any] = {"controller": controller}
    scales = _coupling_scales(result.space, t["params"])
    if scales:
        overlay["topology"] = _topology_overlay(base, scales)
    if s.t_final is not None:
        overlay["simulation"] = {
            "t_final": base.simulation.t_final,
            "output_interval": base.simulation.output_interval,
        }
    extends = s.scenario if s.scenario in BUILTIN_SCENARIOS else str(Path(s.scenario).expanduser().resolve())
    cases = base.source.get("cases") or {}
    summary = ", ".join(f"{p.name} = {t['params'][p.name]:.6g} {p.unit}" for p in result.space)
    lines = [
        f"# written by fsmctl tune: trial {t['index']} of {len(result.trials)}, law {s.law}, seed {s.seed}",
        f"# {summary}",
        *comments,
        "# run it: fsmctl simulate --scenario best.toml",
        f"extends = {toml_value(extends)}",
        f"name = {toml_value(f'{base.name}-tuned')}",
    ]
    if cases and base.case is not None:
        first = next(iter(cases))
        own = {k: v for k, v in dict(cases[base.case]).items() if k != "description"} if base.case != first else {}
        table = _merge(own, overlay)
        table = {"description": f"case {base.case} of {base.name}, tuned by fsmctl tune ({summary})", **table}
        toml_table(["cases", first], table, lines)
    else:
        lines.insert(4, f"description = {toml_value(f'{base.name}, tuned by fsmctl tune ({summary})')}")
        toml_table([], overlay, lines)
    return "\n".join(lines) + "\n"


def _same_design(a: Scenario, b: Scenario) -> bool:
    keys = ("agents", "reference", "topology", "controller", "simulation", "actuator", "sensors", "links")
    return all(getattr(a, k) == getattr(b, k) for k in keys)


def _write_outputs(result: TuneResult, base: Scenario, out: Path, expected: Scenario | None, extra: dict) -> None:
    import optuna

    from fsmctl.model.scenario import load_scenario
    from fsmctl.outputs import atomic_path, write_json, write_text
    from fsmctl.simulation.results_io import versions

    paths = [out / "trials.csv", out / "pareto.csv", out / "pareto.png"]
    _write_csv(paths[0], result, range(len(result.trials)))
    _write_csv(paths[1], result, result.pareto)
    fig = _figure(result)
    with atomic_path(paths[2]) as tmp:
        fig.savefig(tmp, format="png", dpi=120)
    best: dict[str, Any] | None = None
    if result.best is not None:
        path = out / "best.toml"
        provenance = [
            f"# versions: {', '.join(f'{k} {v}' for k, v in versions().items())}, optuna {optuna.__version__}"
        ]
        if extra.get("command"):
            provenance.append(f"# command: {extra['command']}")
        write_text(path, best_scenario_text(result, base, comments=provenance))
        paths.append(path)
        verified = expected is not None and _same_design(load_scenario(path), expected)
        if not verified:
            result.notes.append(
                f"{path} does not reproduce the chosen design exactly (the base scenario's agents or cases override "
                "it); the design is in tune.json"
            )
        t = result.trials[result.best]
        best = {**t, "scenario_file": "best.toml", "scenario_file_verified": verified}
    payload = {
        "settings": asdict(result.settings),
        "versions": {**versions(), "optuna": optuna.__version__},
        "scenario": base.label,
        "horizon_s": base.simulation.t_final,
        "torque_limit_N_m": base.controller.torque_limit,
        "search_space": [asdict(p) for p in result.space],
        "objectives": {
            k: {"unit": OBJECTIVES[k][0], "description": OBJECTIVES[k][1]} for k in result.settings.objectives
        },
        "constraints": {c: {"unit": CONSTRAINTS[c][0], "description": CONSTRAINTS[c][1]} for c in result.constraints},
        "theorem1_holds": result.theorem1,
        **extra,
        "trials": len(result.trials),
        "pruned": sum(t["state"] == "pruned" for t in result.trials),
        "failed": sum(t["state"] == "failed" for t in result.trials),
        "feasible": sum(t["feasible"] for t in result.trials),
        "pareto": result.pareto,
        "best": best,
        "notes": result.notes,
    }
    paths.append(write_json(out / "tune.json", payload))
    result.paths = paths


# ----------------------------------------------------------------------------- the search


LOCK_WAIT_S = 30.0
"""seconds a lock on ``study.log`` held by a live process is waited for before the study is refused"""

STALE_LOCK_S = 10.0
"""a lock on ``study.log`` that names no process of this host (Optuna's own symlink lock, a lock from another host,
or an unreadable one) is broken once it is this old: a write holds the lock for milliseconds"""

_log = logging.getLogger(__name__)


def _process_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    except OSError:
        return True
    return True


class _JournalLock:
    """The lock of ``study.log`` (an Optuna ``BaseJournalFileLock``): ``study.log.lock``, created exclusively and
    holding ``<pid> <host>`` of its holder, always at the journal's absolute path.

    Optuna's default lock is a symbolic link to the journal's path as given: for a relative ``--out`` it dangles
    (``out/study.log`` seen from ``out/``), and a lock left by a killed process then made the next ``--resume``
    spin at 100 % CPU without a word (the link's ``stat`` fails and the wait loop retries at once); for an absolute
    one it waited a silent 31 s.  Here a lock whose holder is a dead process of this host is broken at once, one of
    unknown holder once it is :data:`STALE_LOCK_S` old (both with a warning), and a live holder is waited for
    :data:`LOCK_WAIT_S`, then :class:`~fsmctl.errors.InputError` names it.
    """

    def __init__(self, journal: Path):
        self.path = Path(str(journal.absolute()) + ".lock")

    def _holder(self) -> tuple[str | None, str | None]:
        """``(None, None)`` while the lock is held by a live process (or is gone), else ``(None, why it is stale)``;
        ``(holder, None)`` names a live holder."""
        try:
            st = os.lstat(self.path)
        except FileNotFoundError:
            return None, None
        pid = host = None
        if stat.S_ISREG(st.st_mode):
            with contextlib.suppress(OSError, ValueError):
                text = self.path.read_text(encoding="utf-8").split()
                pid, host = int(text[0]), text[1]
        if pid is not None and host == socket.gethostname():
            if not _process_alive(pid):
                return None, f"its holder, process {pid}, is no longer running"
            return f"process {pid}", None
        age = time.time() - st.st_mtime
        if age > STALE_LOCK_S:
            owner = f"process {pid} on {host}" if pid is not None else "no process of this host"
            return None, f"it names {owner} and is {age:.0f} s old (a write holds it for milliseconds)"
        return (f"process {pid} on {host}" if pid is not None else "an unknown process"), None

    def acquire(self) -> bool:
        """Create the lock (blocking); break a stale one; :class:`~fsmctl.errors.InputError` after
        :data:`LOCK_WAIT_S` of a live holder."""
        record = f"{os.getpid()} {socket.gethostname()}\n".encode()
        deadline = time.monotonic() + LOCK_WAIT_S
        while True:
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                pass
            else:
                try:
                    os.write(fd, record)
                finally:
                    os.close(fd)
                return True
            holder, stale = self._holder()
            if stale is not None:
                _log.warning("tune: removed the stale lock %s: %s", self.path, stale)
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(self.path)
                continue
            if holder is not None and time.monotonic() > deadline:
                raise InputError(
                    f"tune: {self.path} has been held by {holder} for over {LOCK_WAIT_S:g} s (another fsmctl tune on "
                    "this study?): wait for it to end, or remove the lock if that process is not fsmctl"
                )
            time.sleep(0.01)

    def release(self) -> None:
        """Remove the lock."""
        with contextlib.suppress(FileNotFoundError):
            os.unlink(self.path)


def _check_journal(path: Path) -> None:
    """:class:`~fsmctl.errors.InputError` naming the file and line when ``study.log`` holds a line that is not a
    journal record (a JSON object on a line of its own), instead of Optuna's ``JSONDecodeError``."""
    try:
        with open(path, "rb") as fh:
            for number, line in enumerate(fh, start=1):
                problem = None
                if not line.endswith(b"\n"):
                    problem = "it is cut short (no end of line)"
                else:
                    try:
                        record = json.loads(line)
                    except ValueError as exc:
                        problem = f"not JSON: {exc}"
                    else:
                        if not isinstance(record, dict) or "op_code" not in record:
                            problem = "not an Optuna journal operation"
                if problem is not None:
                    raise InputError(
                        f"tune: {path}: line {number} is not a journal record ({problem}); the study's journal is "
                        "damaged: restore it, or start afresh in another --out"
                    )
    except FileNotFoundError:
        return
    except OSError as exc:
        raise EnvironmentProblem(exc.errno or errno.EIO, f"tune: cannot read {path}: {exc.strerror or exc}") from None


class _BufferedJournal:
    """Optuna's journal file (``JournalFileBackend``) whose writes inside :meth:`buffered` are appended at once.

    ``JournalStorage`` appends one log (one locked write and one ``fsync``) per operation, about 15 per trial, and
    reads every log back; on a busy disk the ``fsync`` calls cost milliseconds each and dominated a long study.
    Inside :meth:`buffered` (a batch's proposals, a batch's results) the logs wait in memory, where
    :meth:`read_logs` serves them after those in the file, and leave in one write when the block ends, so the journal
    gains a batch's proposals or results whole (an interrupt waits for the block to end:
    :meth:`fsmctl.studies.parallel.InterruptGuard.deferred`).  This process is the journal's only writer.
    """

    def __init__(self, path: Path):
        from optuna.storages.journal import JournalFileBackend

        path = Path(path).absolute()
        _check_journal(path)
        self._file = JournalFileBackend(str(path), lock_obj=_JournalLock(path))
        self._buffer: list[dict[str, Any]] = []
        self._on_disk: int | None = None
        """logs in the file (learnt at the first read; this process is its only writer)"""
        self._buffering = False

    def read_logs(self, log_number_from: int) -> list[dict[str, Any]]:
        """The logs numbered ``log_number_from`` on (``optuna.storages.journal.BaseJournalBackend``): the file's, then
        the buffered ones.  The file is read once (``JournalStorage`` reads on from where it stopped, and this process
        writes everything after that)."""
        if self._on_disk is not None and log_number_from >= self._on_disk:
            return self._buffer[log_number_from - self._on_disk :]
        logs = list(self._file.read_logs(log_number_from))
        if self._on_disk is None:
            self._on_disk = log_number_from + len(logs)
        return logs + self._buffer[max(0, log_number_from - self._on_disk) :]

    def append_logs(self, logs: list[dict[str, Any]]) -> None:
        """Append ``logs`` (``optuna.storages.journal.BaseJournalBackend``): to the buffer inside :meth:`buffered`."""
        if self._on_disk is None:
            self.read_logs(0)  # learn the file's length first
        if self._buffering:
            self._buffer.extend(logs)
        else:
            self._file.append_logs(logs)
            self._on_disk += len(logs)

    def flush(self) -> None:
        if self._buffer:
            logs, self._buffer = self._buffer, []
            self._file.append_logs(logs)
            self._on_disk += len(logs)

    @contextlib.contextmanager
    def buffered(self):
        """Logs written inside the block are appended to the file in one write when it ends."""
        self._buffering = True
        try:
            yield
        finally:
            self._buffering = False
            self.flush()


def _trial_seed(seed: int, index: int) -> int:
    return int(np.random.SeedSequence([seed, index]).generate_state(1, np.uint32)[0])


def _sampler(n_objectives: int, seed: int, previous=None):
    """The sampler of one trial, seeded from ``(seed, index)``.

    Optuna >= 5: the samplers read the constraints a trial sets (``Trial.set_constraint``).  TPE's search space
    (the intersection of the told trials' distributions, the same for every trial here) is carried over from the
    previous trial's sampler, which it caches incrementally: recomputing it over every told trial for each new
    sampler would cost O(trials) per trial (about a quarter of the sampler's time at 2500 trials).
    """
    import optuna

    if n_objectives > 1:
        return optuna.samplers.NSGAIISampler(seed=seed, population_size=POPULATION)
    sampler = optuna.samplers.TPESampler(seed=seed)
    cache = getattr(previous, "_search_space", None)
    if cache is not None and hasattr(sampler, "_search_space"):
        sampler._search_space = cache
    return sampler


def _counted(trial) -> bool:
    from optuna.trial import TrialState

    if trial.state in (TrialState.COMPLETE, TrialState.PRUNED):
        return True
    return trial.state == TrialState.FAIL and "simulation_error" in trial.user_attrs


def _snapshot(trials: Sequence, before: int) -> Snapshot:
    """What the pruner may see: the told (complete or pruned) trials with an index below ``before``."""
    from optuna.trial import TrialState

    return tuple(
        (t.number, t.state.name, intermediate_values(t), dict(t.user_attrs.get("pruner", {})))
        for t in trials
        if t.state in (TrialState.COMPLETE, TrialState.PRUNED) and t.user_attrs.get("index", -1) < before
    )


def intermediate_values(trial) -> dict[int, float]:
    """A told trial's intermediate values by step (:data:`CHECKPOINTS`), from its ``intermediate`` user attribute.

    Every step's value is kept there (one journal write); Optuna's own ``intermediate_values`` are reported only for
    pruned trials (the last one is how Optuna's samplers rank a pruned trial), which keeps a study of thousands of
    trials from spending its time on journal writes.

    Parameters
    ----------
    trial : optuna.trial.FrozenTrial
        A trial of a ``fsmctl tune`` study (``study.log``).

    Returns
    -------
    dict
        Step -> value; empty without a pruner.
    """
    return {int(k): float(v) for k, v in trial.user_attrs.get("intermediate", {}).items()}


def _tell(study, trial_id: int, result: dict, constraints: Sequence[str], n_objectives: int) -> None:
    """Record one evaluated trial in the journal (intermediate values, constraints, attributes, then its state)."""
    from optuna.trial import Trial, TrialState

    trial = Trial(study, trial_id)
    steps = sorted(result["intermediate"].items())
    if steps:
        trial.set_user_attr("intermediate", {str(k): float(v) for k, v in steps})
    if result["state"] == "pruned":
        for step, value in steps:
            trial.report(float(value), int(step))
    for name in constraints:
        if name in result["constraints"]:
            trial.set_constraint(name, float(result["constraints"][name]))
    if result["pruner_attrs"]:
        trial.set_user_attr("pruner", result["pruner_attrs"])
    if len(result["members"]) > 1:  # one member: its scores are the trial's
        trial.set_user_attr("members", result["members"])
    if result["state"] == "pruned":
        trial.set_user_attr("pruned_at", result["pruned_at"])
        study.tell(trial, state=TrialState.PRUNED)
    elif result["state"] == "failed":
        trial.set_user_attr("simulation_error", result["error"])
        study.tell(trial, state=TrialState.FAIL)
    else:
        study.tell(trial, list(result["objectives"][:n_objectives]))


def _rows(trials: Sequence, space, settings: TuneSettings, constraints: Sequence[str]) -> list[dict]:
    from optuna.trial import TrialState

    rows = []
    for index, t in enumerate(trials):
        complete = t.state == TrialState.COMPLETE
        state = "complete" if complete else ("pruned" if t.state == TrialState.PRUNED else "failed")
        given = t.constraints
        cons = {c: float(given[c]) for c in constraints if c in given}
        rows.append(
            {
                "index": index,
                "state": state,
                "feasible": complete and len(cons) == len(constraints) and all(v <= 0 for v in cons.values()),
                "params": {p.name: float(t.params[p.name]) for p in space if p.name in t.params},
                "objectives": dict(zip(settings.objectives, t.values, strict=True)) if complete else {},
                "constraints": cons,
                "pruned_at": t.user_attrs.get("pruned_at"),
                "error": t.user_attrs.get("simulation_error", ""),
            }
        )
    return rows


def tune(
    settings: TuneSettings,
    out_dir: str | Path,
    *,
    resume: bool = False,
    progress: bool | None = None,
    workers: int = 1,
    dask: Any = None,
    dask_timeout: float | None = None,
    command: Sequence[str] | str | None = None,
) -> TuneResult:
    """Search ``settings.law``'s parameters on ``settings.scenario`` and write the results to ``out_dir``.

    Writes ``study.log`` (Optuna's journal; ``resume=True`` continues it to ``settings.budget`` trials in total),
    ``trials.csv`` (every trial: parameters, objectives, constraints, state, pruning time), ``pareto.csv`` (the
    feasible non-dominated trials), ``pareto.png``, ``best.toml`` (the feasible trial with the smallest first
    objective, as a scenario file; not written when no trial is feasible) and ``tune.json`` (settings, versions,
    best).

    Parameters
    ----------
    settings : TuneSettings
        What to search and how (see the module docstring).
    out_dir : str or Path
        Output folder.
    resume : bool
        Continue the study in ``out_dir`` (same settings) to ``settings.budget`` trials.
    progress : bool, optional
        Progress bar over the trials (default: when stderr is a terminal).
    workers : int
        Local worker processes evaluating a batch's candidates (1: in this process; at most ``settings.batch`` are
        used).  The results do not depend on it.
    dask : str or distributed.Client, optional
        Address of (or a client to) a Dask distributed scheduler, instead of the local workers (checked as
        ``fsmctl montecarlo --dask`` checks it).
    dask_timeout : float, optional
        Seconds a Dask scheduler gets to accept the connection and answer (default: montecarlo's).
    command : sequence of str or str, optional
        The command line that started the search (``sys.argv``), recorded in ``tune.json`` and as a comment in
        ``best.toml``, next to the versions (:func:`fsmctl.simulation.versions`).

    Returns
    -------
    TuneResult
        Every trial, the feasible Pareto front, the chosen design and the files written.

    Raises
    ------
    InputError
        Bad settings, an existing study without ``resume``, a resumed study with other settings or of another
        problem (:func:`~fsmctl.simulation.results_io.problem_fingerprint`: the scenario's content, the law's code,
        the fsmctl version), a damaged ``study.log`` (a line that is not a journal record), an objective the
        scenario cannot measure (``wheel_momentum`` without wheels) or a constraint it cannot evaluate.
    fsmctl.errors.EnvironmentProblem
        ``out_dir`` cannot be written, or ``dask`` is not a reachable scheduler.
    fsmctl.studies.parallel.CampaignInterrupted
        ``SIGINT``/``SIGTERM`` (main thread): the workers were stopped, the journal keeps every told trial and the
        proposed ones of the unfinished batch (``exc.detail``); ``exc.exit_code`` is 130 or 143.

    Examples
    --------
    Four candidates of ``c1, c2`` on a 1 s horizon of Case 1, scored by the peak torque, under Theorem 1 only (a
    real search has a budget of hundreds on the full horizon, ``fsmctl tune``):

    >>> from fsmctl.studies import TuneSettings
    >>> from fsmctl.studies.tune import tune
    >>> settings = TuneSettings(budget=4, batch=4, t_final=1.0, objectives=("peak_torque",), parameters=("c1", "c2"),
    ...                         ranges={"c1": (0.1, 2.0), "c2": (0.1, 2.0)}, constraints=("theorem1",))
    >>> result = tune(settings, "tuned", progress=False)
    >>> len(result.trials), result.best in result.pareto
    (4, True)
    >>> sorted(p.name for p in result.paths)
    ['best.toml', 'pareto.csv', 'pareto.png', 'trials.csv', 'tune.json']
    """
    import optuna
    from optuna.storages import JournalStorage

    from fsmctl.outputs import output_folder
    from fsmctl.simulation.results_io import fingerprint_change, problem_fingerprint
    from fsmctl.studies.montecarlo import DASK_TIMEOUT_S, _connect_dask
    from fsmctl.studies.parallel import CampaignInterrupted, check_workers, interrupt_guard

    settings.validate()
    check_workers(workers, "tune")
    base = _base_scenario(settings)
    settings = dataclasses.replace(settings, case=base.case)
    space = search_space(settings, base)
    if "wheel_momentum" in settings.objectives and not base.actuator.enabled:
        raise InputError(f"tune: objective wheel_momentum needs a scenario with reaction wheels; {base.label} has none")
    why = available_constraints(settings.law, base)
    for name in settings.constraints:
        if why[name]:
            raise InputError(f"tune: constraint {name} cannot be evaluated: {why[name]}")
    constraints = tuple(c for c in CONSTRAINTS if (c in settings.constraints if settings.constraints else not why[c]))
    settings = dataclasses.replace(settings, constraints=constraints)
    law = _portable_law(settings.law)
    _trial_scenario(base, law, space, {p.name: p.low for p in space})  # the law and its values fit the scenario
    members = _members(base, settings)
    problem = problem_fingerprint(base, law)  # a resumed study must be of the same problem
    t_final, n_obj = base.simulation.t_final, len(settings.objectives)
    notes: list[str] = []
    theorem1: bool | None = None
    theorem1_fixed: float | None = None
    searched_coupling = any(p.coupling for p in space)
    if _declares_paper_theorems(settings.law):
        theorem1 = theorem1_constraint(base.topology, t_final) == 0
    if "theorem1" in constraints and not searched_coupling:
        theorem1_fixed = theorem1_constraint(base.topology, t_final)
        if theorem1_fixed > 0:
            notes.append(
                f"Theorem 1's topology conditions fail for {base.label} (`fsmctl prove theorem1-gains` explains) and "
                "the coupling weights are not searched, so every trial is infeasible"
            )
    requirements: tuple[np.ndarray, ...] = ()
    extra: dict[str, Any] = {"batch": settings.batch, "pruner": settings.pruner}
    if command is not None:
        extra["command"] = command if isinstance(command, str) else shlex.join(str(c) for c in command)
    if "theorem2" in constraints:
        from fsmctl.proofs.theorem2 import reference_delta_requirement

        lows = {p.name: p.low for p in space}
        requirements = tuple(reference_delta_requirement(_trial_scenario(m, law, space, lows)) for m in members)
        extra["theorem2_required_delta_max_1_per_s2"] = float(max(r.max() for r in requirements))
    ctx = _Context(
        law=law,
        space=tuple(space),
        members=tuple(members),
        objectives=settings.objectives,
        constraints=constraints,
        tolerance_deg=settings.tolerance_deg,
        quantile=settings.quantile,
        pruner=settings.pruner,
        topology=base.topology,
        theorem1=theorem1_fixed,
        requirements=requirements,
        study=f"{Path(out_dir).resolve()}:{os.getpid()}:{time.time_ns()}",
    )
    out = Path(out_dir)
    batch, budget = settings.batch, settings.budget
    timeout = DASK_TIMEOUT_S if dask_timeout is None else dask_timeout
    told = 0
    with interrupt_guard() as guard:
        client, own_client = _connect_dask(dask, timeout) if dask is not None else (None, False)
        try:
            with output_folder(out):
                log = out / STUDY_FILE
                if log.exists() and not resume:
                    raise InputError(f"tune: {log} exists: continue it with --resume or choose another --out")
                if resume and not log.exists():
                    raise InputError(f"tune: nothing to resume in {out} (no {STUDY_FILE})")
                level = optuna.logging.get_verbosity()
                optuna.logging.set_verbosity(optuna.logging.ERROR)
                try:
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
                        journal = _BufferedJournal(log)
                        storage = JournalStorage(journal)
                        study = optuna.create_study(
                            study_name=STUDY_NAME,
                            storage=storage,
                            directions=["minimize"] * n_obj,
                            load_if_exists=True,
                        )
                        identity = settings.identity()
                        told_before = bool(study.get_trials(deepcopy=False))
                        if "settings" in study.user_attrs:
                            if study.user_attrs["settings"] != identity:
                                old = study.user_attrs["settings"]
                                diff = sorted(k for k in set(old) | set(identity) if old.get(k) != identity.get(k))
                                raise InputError(
                                    f"tune: the study in {out} was run with other settings ({', '.join(diff)}); "
                                    "resume it with the same ones or choose another --out"
                                )
                        else:
                            study.set_user_attr("settings", identity)
                        if "problem" in study.user_attrs or told_before:
                            change = fingerprint_change(study.user_attrs.get("problem"), problem)
                            if change is not None:
                                raise InputError(
                                    f"tune: the study in {out} was run on another problem: {change}; its trials "
                                    "would mix two problems: start afresh in another --out"
                                )
                        else:
                            study.set_user_attr("problem", problem)
                        told = sum(_counted(t) for t in study.get_trials(deepcopy=False))
                        pending = _pending(study, storage, space, told, batch, budget)
                        bar = None
                        show = sys.stderr.isatty() if progress is None else progress
                        if show and told < budget:
                            from tqdm.auto import tqdm

                            bar = tqdm(total=budget, initial=told, desc="tune", unit="trial", file=sys.stderr)
                        sampler = None
                        try:
                            with _Evaluator(ctx, min(workers, batch), client) as evaluator:
                                while told < budget:
                                    start = (told // batch) * batch
                                    indices = range(max(told, start), min(start + batch, budget))
                                    # a batch is proposed whole (or resumed as proposed), in one write to the journal
                                    with guard.deferred(), journal.buffered():
                                        for j in indices:
                                            if j not in pending:
                                                sampler = _sampler(n_obj, _trial_seed(settings.seed, j), sampler)
                                                study.sampler = sampler
                                                trial = study.ask()
                                                values = {
                                                    p.name: trial.suggest_float(p.name, p.low, p.high, log=p.log)
                                                    for p in space
                                                }
                                                trial.set_user_attr("index", j)
                                                pending[j] = (trial._trial_id, values)
                                    snapshot = None
                                    if settings.pruner != "none":
                                        snapshot = _snapshot(study.get_trials(deepcopy=False), start)
                                    results = evaluator.run(
                                        [pending[j][1] for j in indices],
                                        snapshot,
                                        (lambda: bar.update(1)) if bar is not None else (lambda: None),
                                    )
                                    with guard.deferred(), journal.buffered():  # told whole, in trial order
                                        for j, result in zip(indices, results, strict=True):
                                            _tell(study, pending.pop(j)[0], result, constraints, n_obj)
                                            told += 1
                        finally:
                            if bar is not None:
                                bar.close()
                        trials = [t for t in study.get_trials(deepcopy=False) if _counted(t)]
                        trials = sorted(trials, key=lambda t: t.user_attrs.get("index", t.number))[:budget]
                finally:
                    optuna.logging.set_verbosity(level)
                rows = _rows(trials, space, settings, constraints)
                pareto = _pareto(rows, settings.objectives)
                feasible = [r for r in rows if r["feasible"]]
                best = (
                    min(feasible, key=lambda r: (r["objectives"][settings.objectives[0]], r["index"]))["index"]
                    if feasible
                    else None
                )
                result = TuneResult(settings, space, constraints, rows, pareto, best, theorem1, notes)
                expected = (
                    _trial_scenario(base, settings.law, space, rows[best]["params"]) if best is not None else None
                )
                with guard.deferred():
                    _write_outputs(result, base, out, expected, extra)
        except CampaignInterrupted as exc:
            guard.closing()
            exc.detail = (
                f"{told} of {budget} trials told, kept in {out / STUDY_FILE}; --resume with the same options continues"
            )
            raise
        finally:
            if own_client:
                with contextlib.suppress(Exception):
                    client.close(timeout=timeout)
    return result


def _pending(study, storage, space, told: int, batch: int, budget: int) -> dict[int, tuple[int, dict]]:
    """The proposed, not yet told trials of the unfinished batch (resumed as proposed); others in flight are failed.

    Trials are proposed and told in index order, so the ones to resume are the indices ``told, told + 1, ...`` of the
    batch of ``told``; a trial cut off while it was being proposed (no index, missing parameters) is failed and
    proposed again.
    """
    from optuna.trial import TrialState

    start = (told // batch) * batch
    names = {p.name for p in space}
    pending: dict[int, tuple[int, dict]] = {}
    stale = []
    running = [t for t in study.get_trials(deepcopy=False) if t.state in (TrialState.RUNNING, TrialState.WAITING)]
    for t in sorted(running, key=lambda t: t.user_attrs.get("index", -1)):
        j = t.user_attrs.get("index")
        ok = isinstance(j, int) and set(t.params) == names and told <= j < min(start + batch, budget)
        if ok and j == told + len(pending):
            pending[j] = (t._trial_id, {p.name: float(t.params[p.name]) for p in space})
        else:
            stale.append(t)
    for t in stale:
        storage.set_trial_state_values(t._trial_id, TrialState.FAIL)
    return pending


def _declares_paper_theorems(law: str) -> bool:
    """Whether a law spec declares it is the paper's eqs 13-19, so that Theorems 1-2 apply to it."""
    from fsmctl.model.laws import resolve_law

    return resolve_law(law).paper_theorems is not None
