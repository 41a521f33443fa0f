"""The search (:func:`tune`): batches of trials proposed, flown on the campaign runner and told in order."""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import json
import logging
import os
import shlex
import sys
import time
import warnings
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from fsmctl.errors import InputError
from fsmctl.model.scenario import Scenario
from fsmctl.policy import BATCH_AGENTS, DASK_TIMEOUT_S
from fsmctl.studies.campaign import Runner, Task
from fsmctl.studies.tune.evaluation import (
    EvaluationContext,
    base_scenario,
    ensemble_members,
    evaluate_candidates,
    portable_law,
    theorem1_constraint,
    trial_scenario,
    worker_died,
)
from fsmctl.studies.tune.report import TuneResult, pareto_front, write_outputs
from fsmctl.studies.tune.settings import (
    CONSTRAINTS,
    OBJECTIVES,
    STUDY_FILE,
    STUDY_NAME,
    TuneSettings,
    available_constraints,
    identity_changes,
    search_space,
    search_space_lines,
)
from fsmctl.studies.tune.storage import (
    BufferedJournal,
    counted_trial,
    pending_trials,
    pruner_snapshot,
    tell_trial,
    trial_rows,
    trial_sampler,
    trial_seed,
)
from fsmctl.studies.wording import RESUME_HINT

_log = logging.getLogger(__name__)


def tune(
    settings: TuneSettings,
    out_dir: str | Path,
    *,
    resume: bool = False,
    progress: bool | None = None,
    workers: int | None = None,
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
    workers : int, optional
        Local worker processes evaluating a batch's candidates (1: in this process; at most ``settings.batch`` are
        used).  Default: one per CPU, at most one per trial of a batch (:func:`fsmctl.policy.default_workers` of
        ``settings.batch``).  The results do not depend on it.
    dask : str or distributed.Client, optional
        Address of (or a client to) a Dask distributed scheduler, instead of the local workers (checked as
        ``fsmctl montecarlo --dask`` checks it).
    dask_timeout : float, optional
        Seconds a Dask scheduler gets to accept the connection and answer (default: :data:`fsmctl.policy.DASK_TIMEOUT_S`).
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
    fsmctl.parallel.CampaignInterrupted
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
    >>> sorted(p.name for p in result.paths)  # every file written
    ['best.toml', 'pareto.csv', 'pareto.png', 'study.log', 'trials.csv', 'tune.json']
    """
    import optuna  # noqa: F401  (loaded first: study.log follows the folder at once, as a reader polling it expects)

    from fsmctl.outputs import output_folder
    from fsmctl.parallel import CampaignInterrupted, resolve_workers

    settings.validate()
    workers = resolve_workers(workers, settings.batch, "tune")
    plan = _plan(settings, out_dir, command)
    out = Path(out_dir)
    timeout = DASK_TIMEOUT_S if dask_timeout is None else dask_timeout
    batches = _Batches(plan, out)
    with Runner(workers=min(workers, plan.settings.batch), dask=dask, dask_timeout=timeout, name="tune") as runner:
        runner.start()  # a bad --dask is an error before the folder is touched
        try:
            with output_folder(out):
                trials = batches.run(runner, resume, progress)
                result = _result(plan, trials)
                expected = (
                    trial_scenario(plan.base, plan.settings.law, plan.space, result.trials[result.best]["params"])
                    if result.best is not None
                    else None
                )
                with runner.deferred():
                    write_outputs(result, plan.base, out, expected, plan.extra)
        except CampaignInterrupted as exc:
            runner.guard.closing()
            budget = plan.settings.budget
            exc.detail = f"{batches.told} of {budget} trials told, kept in {out / STUDY_FILE}; {RESUME_HINT}"
            raise
    return result


@dataclasses.dataclass
class _Plan:
    """A study's problem, checked before anything is flown or written."""

    settings: TuneSettings
    base: Scenario
    space: list
    constraints: tuple[str, ...]
    problem: dict
    ctx: EvaluationContext
    theorem1: bool | None
    notes: list[str]
    extra: dict[str, Any]


def _plan(settings: TuneSettings, out_dir: str | Path, command: Sequence[str] | str | None) -> _Plan:
    """Resolve the settings (case, constraints), check the law, the objectives and the constraints on the scenario,
    and build what every evaluation needs."""
    from fsmctl.simulation.results_io import problem_fingerprint

    base = base_scenario(settings)
    settings = dataclasses.replace(settings, case=base.case)
    space = search_space(settings, base)
    for name in settings.objectives:
        if OBJECTIVES[name].needs_wheels and not base.actuator.enabled:
            raise InputError(f"tune: objective {name} needs a scenario with reaction wheels; {base.label} has none")
        if OBJECTIVES[name].needs_control_period and not base.simulation.control_period > 0:
            raise InputError(
                f"tune: objective {name} needs a control period (messages are sent at control instants); "
                f"{base.label} is flown in continuous control: set simulation.control_period in the scenario file"
            )
    why = available_constraints(settings.law, base)
    for name in settings.constraints:
        if why[name]:
            raise InputError(f"tune: constraint {name} cannot be evaluated: {why[name]}")
    constraints = tuple(c for c in CONSTRAINTS if (c in settings.constraints if settings.constraints else not why[c]))
    settings = dataclasses.replace(settings, constraints=constraints)
    law = portable_law(settings.law)
    trial_scenario(base, law, space, {p.name: p.low for p in space})  # the law and its values fit the scenario
    members = ensemble_members(base, settings)
    problem = problem_fingerprint(base, law)  # a resumed study must be of the same problem
    t_final = base.simulation.t_final
    notes: list[str] = []
    theorem1 = theorem1_constraint(base.topology, t_final) == 0 if declares_paper_theorems(settings.law) else None
    theorem1_fixed: float | None = None
    if "theorem1" in constraints and not any(p.coupling for p in space):
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
        requirements = tuple(reference_delta_requirement(trial_scenario(m, law, space, lows)) for m in members)
        extra["theorem2_required_delta_max_1_per_s2"] = float(max(r.max() for r in requirements))
    ctx = EvaluationContext(
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
    return _Plan(settings, base, space, constraints, problem, ctx, theorem1, notes, extra)


@contextlib.contextmanager
def _quiet_optuna() -> Iterator[None]:
    """Optuna's log at ERROR and its experimental warnings (the journal storage) silenced inside the block."""
    import optuna

    level = optuna.logging.get_verbosity()
    optuna.logging.set_verbosity(optuna.logging.ERROR)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
            yield
    finally:
        optuna.logging.set_verbosity(level)


def _compact(value: Any) -> str:
    """A setting's value as one short JSON text (``[["K",1.0,20.0],["P",2.0,60.0]]``)."""
    text = json.dumps(value, separators=(",", ":"))
    return text if len(text) <= 120 else text[:117] + "..."


def _open_study(out: Path, resume: bool, plan: _Plan) -> tuple[Any, Any, Any]:
    """``(journal, storage, study)`` of ``out/study.log``: created, or resumed with the same settings and problem."""
    import optuna
    from optuna.storages import JournalStorage

    from fsmctl.simulation.results_io import fingerprint_change

    log = out / STUDY_FILE
    if log.exists() and not resume:
        raise InputError(f"tune: {log} exists: continue it with --resume or choose another --out")
    if resume and not log.exists():
        raise InputError(f"tune: nothing to resume in {out} (no {STUDY_FILE})")
    journal = BufferedJournal(log)
    storage = JournalStorage(journal)
    study = optuna.create_study(
        study_name=STUDY_NAME,
        storage=storage,
        directions=["minimize"] * len(plan.settings.objectives),
        load_if_exists=True,
    )
    identity = plan.settings.identity()
    told_before = bool(study.get_trials(deepcopy=False))
    old = study.user_attrs.get("settings")
    if old is None:
        study.set_user_attr("settings", identity)
    elif diff := identity_changes(old, identity):
        said = "; ".join(f"{k} {_compact(was)}, now {_compact(now)}" for k, (was, now) in diff.items())
        raise InputError(
            f"tune: the study in {out} was run with other settings ({said}); resume it with the same ones "
            "or choose another --out"
        )
    if "problem" in study.user_attrs or told_before:
        change = fingerprint_change(study.user_attrs.get("problem"), plan.problem)
        if change is not None:
            raise InputError(
                f"tune: the study in {out} was run on another problem: {change}; its trials would mix two problems: "
                "start afresh in another --out"
            )
    else:
        study.set_user_attr("problem", plan.problem)
    return journal, storage, study


class _Batches:
    """Trials asked, flown (on the campaign runner) and told batch by batch; ``told`` counts the told ones."""

    def __init__(self, plan: _Plan, out: Path):
        self.plan, self.out = plan, out
        self.told = 0
        # without a pruner, the candidates of a task share the simulator's batches (as many as fill one); with one,
        # a candidate flies alone, so that its runs stop where it is pruned
        agents = sum(m.n_agents for m in plan.ctx.members)
        self.per_task = max(1, BATCH_AGENTS // agents) if plan.ctx.pruner == "none" else 1

    def run(self, runner: Runner, resume: bool, progress: bool | None) -> list:
        """Continue the study to its budget; its counted trials in index order."""
        s = self.plan.settings
        with _quiet_optuna():
            journal, storage, study = _open_study(self.out, resume, self.plan)
            for line in search_space_lines(s, self.plan.space):  # once the study is open: what is searched, and why
                _log.info("tune: %s", line)
            self.told = sum(counted_trial(t) for t in study.get_trials(deepcopy=False))
            pending = pending_trials(study, storage, self.plan.space, self.told, s.batch, s.budget)
            show = sys.stderr.isatty() if progress is None else progress
            runner.progress(s.budget, initial=self.told, unit="trial", enabled=show and self.told < s.budget)
            ctx = runner.share(self.plan.ctx)
            sampler = None
            while self.told < s.budget:
                start = (self.told // s.batch) * s.batch
                indices = range(max(self.told, start), min(start + s.batch, s.budget))
                with runner.deferred(), journal.buffered():  # a batch is proposed whole (or resumed as proposed)
                    sampler = self._propose(study, indices, pending, sampler)
                snapshot = pruner_snapshot(study.get_trials(deepcopy=False), start) if s.pruner != "none" else None
                snapshot = runner.share(snapshot, broadcast=False) if snapshot else snapshot
                tasks = [
                    _candidates_task(ctx, group, [pending[j][1] for j in group], snapshot)
                    for group in candidate_groups(indices, runner.slots, self.per_task)
                ]
                results = [r for task_results in runner.run(tasks) for r in task_results]
                with runner.deferred(), journal.buffered():  # told whole, in trial order
                    for j, result in zip(indices, results, strict=True):
                        tell_trial(study, pending.pop(j)[0], result, self.plan.constraints, len(s.objectives))
                        self.told += 1
            trials = [t for t in study.get_trials(deepcopy=False) if counted_trial(t)]
            return sorted(trials, key=lambda t: t.user_attrs.get("index", t.number))[: s.budget]

    def _propose(self, study: Any, indices: range, pending: dict, sampler: Any) -> Any:
        """Ask the trials of ``indices`` not yet proposed (each with its own seeded sampler); the last sampler."""
        s, space = self.plan.settings, self.plan.space
        for j in indices:
            if j in pending:
                continue
            sampler = trial_sampler(len(s.objectives), trial_seed(s.seed, j), sampler)
            study.sampler = sampler
            trial = study.ask()
            values = {p.name: trial.suggest_float(p.name, p.low, p.high, log=p.log) for p in space}
            trial.set_user_attr("index", j)
            pending[j] = (trial._trial_id, values)
        return sampler


def candidate_groups(indices: range, slots: int, most: int) -> list[range]:
    """The trials of a batch, split into the runner's tasks: consecutive groups of at most ``most`` trials, about
    one per slot (the trials' results do not depend on the split).

    Examples
    --------
    >>> [list(g) for g in candidate_groups(range(8, 16), slots=2, most=10)]
    [[8, 9, 10, 11], [12, 13, 14, 15]]
    >>> [len(g) for g in candidate_groups(range(8), slots=1, most=1)]
    [1, 1, 1, 1, 1, 1, 1, 1]
    """
    per = max(1, min(most, -(-len(indices) // max(1, slots))))
    return [indices[i : i + per] for i in range(0, len(indices), per)]


def _lost(count: int, message: str) -> list[dict]:
    return [worker_died(message) for _ in range(count)]


def _candidates_task(ctx: Any, group: range, values: list[dict], snapshot: Any) -> Task:
    """The task flying ``group``'s candidates together; its parts fly them one by one (a candidate that kills its
    worker is then lost alone)."""
    parts = tuple(
        Task(j, evaluate_candidates, (ctx, [v], snapshot), lost=functools.partial(_lost, 1))
        for j, v in zip(group, values, strict=True)
    )
    if len(parts) == 1:
        return parts[0]
    return Task(
        tuple(group),
        evaluate_candidates,
        (ctx, values, snapshot),
        weight=len(group),
        lost=functools.partial(_lost, len(group)),
        parts=parts,
    )


def _result(plan: _Plan, trials: Sequence) -> TuneResult:
    """The result of the counted trials: rows, the feasible Pareto front and the chosen design."""
    s = plan.settings
    rows = trial_rows(trials, plan.space, s, plan.constraints)
    pareto = pareto_front(rows, s.objectives)
    feasible = [r for r in rows if r["feasible"]]
    best = min(feasible, key=lambda r: (r["objectives"][s.objectives[0]], r["index"]))["index"] if feasible else None
    horizon = float(plan.base.simulation.t_final)
    return TuneResult(s, plan.space, plan.constraints, rows, pareto, best, plan.theorem1, horizon, plan.notes)


def declares_paper_theorems(law: str) -> bool:
    """Whether a law spec declares it is the paper's eqs 13-19, so that Theorems 1-2 apply to it."""
    from fsmctl.model.laws import resolve_law

    return resolve_law(law).paper_theorems is not None
