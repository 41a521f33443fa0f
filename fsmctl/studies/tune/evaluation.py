"""Flying and scoring candidates (several together in one call of the simulator): their scenarios, objectives,
constraints and the pruner's checkpoints."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from fsmctl.model.scenario import Scenario
from fsmctl.model.topology import Link, Topology
from fsmctl.policy import default_steady_window
from fsmctl.studies.tune.settings import (
    CHECKPOINTS,
    HALVING_REDUCTION_FACTOR,
    MEDIAN_STARTUP_TRIALS,
    MEDIAN_WARMUP_STEPS,
    OBJECTIVES,
    SIMULATED_CONSTRAINTS,
    WHEEL_CAPACITY_FRACTION,
    SearchParameter,
    TuneSettings,
    progress_score,
    unsettled_score,
)

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

    if analyze_topology(topology, t_final, explain=False).holds:
        return 0.0
    excess = max((link.k_j.max - link.k_i for link in topology.links), default=0.0)
    return 1.0 + max(0.0, float(excess))


def coupling_scales(space: Sequence[SearchParameter], values: Mapping[str, float]) -> dict[str, float]:
    return {p.name: float(values[p.name]) for p in space if p.coupling}


def trial_scenario(member: Scenario, law: str, space: Sequence[SearchParameter], values: Mapping) -> Scenario:
    from fsmctl.studies.compare_runs import LawRun, run_scenario

    params = {p.name: p.scenario_value(values[p.name]) for p in space if not p.coupling}
    scenario = run_scenario(member, LawRun("tune", law, params))
    scales = coupling_scales(space, values)
    if scales:
        top = scaled_topology(scenario.topology, scales.get("k_i_scale"), scales.get("k_j_scale"))
        scenario = scenario.with_topology(top)
    return scenario


def base_scenario(settings: TuneSettings) -> Scenario:
    from fsmctl.model.scenario import load_scenario

    base = load_scenario(settings.scenario, settings.case)
    if settings.t_final is not None:
        sim = base.simulation
        base = base.replace(
            simulation={"t_final": settings.t_final, "output_interval": min(sim.output_interval, settings.t_final)}
        )
    return base


def ensemble_members(base: Scenario, settings: TuneSettings) -> list[Scenario]:
    if settings.ensemble == 1:
        return [base]
    from fsmctl.studies.montecarlo import CampaignSettings, sample_run_scenario

    campaign = CampaignSettings(scenario=settings.scenario, case=base.case, runs=settings.ensemble, seed=settings.seed)
    seeds = np.random.SeedSequence(settings.seed).spawn(settings.ensemble)
    return [sample_run_scenario(base, campaign, s) for s in seeds]


def portable_law(law: str) -> str:
    """A built-in name as it is; a script or folder as the absolute folder of its generated code (for the workers)."""
    from fsmctl.model.laws import resolve_law

    code = resolve_law(law)
    return code.name if code.builtin else str(code.folder)


# ----------------------------------------------------------------------------- evaluating candidates


@dataclass(frozen=True)
class EvaluationContext:
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


def _steady_mask(time: np.ndarray) -> np.ndarray:
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


def _run_scores(result, ctx: EvaluationContext) -> list[float]:
    """``[*objectives, *simulated constraints]`` of one complete run."""
    from fsmctl.studies.compare import run_metrics

    tol = ctx.tolerance_deg
    t_final = float(result.scenario.simulation.t_final)
    metrics = run_metrics(result, tolerances_deg=(tol,))
    settle = _settling_scores(metrics, t_final, tol)
    objectives = [OBJECTIVES[name] for name in ctx.objectives]
    values = [settle[o.error] if o.metric is None else metrics[o.metric] for o in objectives]
    extra = {"converged": lambda: max(settle.values()) - t_final}
    settled = [metrics[f"{w}_settling_{tol:g}deg_s"] for w in ("aaem", "raem")]
    extra["torque"] = lambda: torque_excess(result, max(settled) if all(map(math.isfinite, settled)) else math.nan)
    extra["wheels"] = lambda: wheel_load(result) - WHEEL_CAPACITY_FRACTION
    return [*values, *(extra[c]() for c in ctx.simulated)]


def _proof_constraints(
    ctx: EvaluationContext, scenarios: Sequence[Scenario], values: Mapping[str, float]
) -> dict[str, float]:
    out: dict[str, float] = {}
    if "theorem1" in ctx.constraints:
        if ctx.theorem1 is not None:
            out["theorem1"] = ctx.theorem1
        else:
            scales = coupling_scales(ctx.space, values)
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
            aaem = OBJECTIVES[self.objective].error == "aaem"
            ext = aaem_deg(principal_angles(new)) if aaem else streamed_raem_deg(new)
            self._metric = np.concatenate([self._metric, ext])
        return self._metric[:w]

    def score(self, result, w: int) -> float:
        from fsmctl.simulation.metrics import settling_time

        objective = OBJECTIVES[self.objective]
        if objective.error is None:
            return objective.partial(result, w)
        t = np.asarray(result.time[:w], dtype=float)
        metric = self._error_metric(result.sigma_e, w)
        steady = float(np.max(metric[_steady_mask(t)]))
        if objective.metric is not None:  # a steady maximum
            return steady
        s = settling_time(t, metric, self.tol)
        return s if math.isfinite(s) else progress_score(self.horizon, steady, self.tol)


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
    member's run up to that sample.  The simulator's monitor passes :meth:`watch` the candidate's runs it flies
    together (all members, or one batch of them after the other, beside other candidates' runs or not); the value of
    a step is decided, in step order, once every member has reached it, so a decision never depends on how the
    members were batched.  :meth:`replay` decides the steps the monitor did not reach on the complete runs, whose
    first samples are bit for bit the partial runs.
    """

    def __init__(self, ctx: EvaluationContext, snapshot: Snapshot, scenarios: Sequence[Scenario]):
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

    def watch(self, results: Sequence) -> None:
        """The partial runs of (some of) the candidate's members, as the simulator's monitor receives them."""
        if self.pruned_at is None:
            members = [self._member(r, k) for k, r in enumerate(results)]
            self._advance(results, members, min(len(r.time) for r in results))

    def replay(self, results: Sequence) -> None:
        """Decide the steps left on complete runs (every checkpoint before the last sample)."""
        if self.pruned_at is None:
            self._advance(results, range(len(results)), len(results[0].time) - 1)


def _fly(candidates: Sequence[Sequence[Scenario]], judges: Sequence[_Judge] | None) -> list[list]:
    """Simulate the candidates' members in one call of the simulator (their agents share the SIMD lanes, each run's
    results bit for bit those it has alone); one list per candidate of its members' results or
    :class:`~fsmctl.simulation.failures.SimulationError`.  The judges (one per candidate) watch their own members at
    their checkpoints; the flight stops when every candidate flying in it has been pruned."""
    from fsmctl.simulation.simulator import simulate_many

    flat = [s for members in candidates for s in members]
    owner = {id(s): k for k, members in enumerate(candidates) for s in members}
    if judges is None:
        results = simulate_many(flat, errors="return")
    else:

        def monitor(t: float, partial: Callable[[], Sequence]) -> bool:
            seen: dict[int, list] = {}
            for r in partial():
                seen.setdefault(owner[id(r.scenario)], []).append(r)
            for k, rs in seen.items():
                judges[k].watch(rs)
            return all(judges[k].pruned_at is not None for k in seen)

        results = simulate_many(flat, errors="return", monitor=monitor, monitor_interval=judges[0].interval)
    out, start = [], 0
    for k, members in enumerate(candidates):
        own = results[start : start + len(members)]
        start += len(members)
        if judges is not None and not any(isinstance(r, Exception) for r in own):
            judges[k].replay(own)
        out.append(own)
    return out


def _blank() -> dict[str, Any]:
    return {
        "state": "complete",
        "objectives": [],
        "constraints": {},
        "members": [],
        "intermediate": {},
        "pruner_attrs": {},
        "pruned_at": None,
        "error": "",
    }


def _outcome(ctx: EvaluationContext, results: Sequence, proof: dict[str, float], judge: _Judge | None) -> dict:
    """A candidate's result from its members' runs: pruned (where its judge pruned it, whatever its runs did after),
    failed (the first failed member's error, in member order), or complete with its objectives and constraints."""
    out = _blank()
    if judge is not None:
        out.update(intermediate=dict(judge.values), pruner_attrs=dict(judge.attrs))
        if judge.pruned_at is not None:  # alone, its runs would have stopped there
            out.update(state="pruned", pruned_at=judge.pruned_at, constraints=proof)
            return out
    failed = next((r for r in results if isinstance(r, Exception)), None)
    if failed is not None:
        out.update(state="failed", error=" ".join(str(failed).split()), constraints=proof)
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


def evaluate_candidates(
    ctx: EvaluationContext, candidates: Sequence[Mapping[str, float]], snapshot: Snapshot | None
) -> list[dict]:
    """Fly candidates together and score each: per candidate a dict with ``state`` ("complete", "pruned",
    "failed") and what was measured, the same whichever candidates share the flight (:func:`_fly`).

    Parameters
    ----------
    ctx : EvaluationContext
        The study's members, objectives, constraints and pruner.
    candidates : sequence of mapping
        Each candidate's parameter values (``name -> value``).
    snapshot : Snapshot, optional
        The trials told before the candidates' batch (for the pruner).

    Returns
    -------
    list of dict
        One result per candidate, in order.
    """
    scenarios = [[trial_scenario(m, ctx.law, ctx.space, values) for m in ctx.members] for values in candidates]
    proofs = [_proof_constraints(ctx, s, values) for s, values in zip(scenarios, candidates, strict=True)]
    judges = [_Judge(ctx, snapshot or (), s) for s in scenarios] if ctx.pruner != "none" else None
    flown = _fly(scenarios, judges)
    return [
        _outcome(ctx, results, proof, judges[k] if judges is not None else None)
        for k, (results, proof) in enumerate(zip(flown, proofs, strict=True))
    ]


def worker_died(message: str) -> dict:
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
