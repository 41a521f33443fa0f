"""The runs of an explanation: candidate scenarios flown once each, and the checks judged on them.

A :class:`Check` is a claim (:class:`~fsmctl.studies.claims.StudyClaim`) or a figure-level check
(:class:`~fsmctl.studies.figure_checks.FigureCheck`) as the search sees it.  :class:`CandidateRuns` keeps every run
flown for a candidate change (:class:`~fsmctl.studies.explain_settings.Candidate`), each a
:class:`~fsmctl.studies.records.RunRecord`; identical scenarios (the same
:func:`~fsmctl.studies.records.scenario_fingerprint`) share one run.  :func:`fly` is the one place that sends runs to
the campaign runner (:class:`fsmctl.studies.campaign.Runner`: ``fsmctl reproduce``'s worker processes).
"""

from __future__ import annotations

import time as _time
import warnings
from collections.abc import Hashable, Iterable, Mapping
from dataclasses import dataclass
from functools import partial
from typing import Any

from fsmctl.model.laws import LawSwitchWarning
from fsmctl.policy import SETTLING_TOLERANCES_DEG
from fsmctl.studies.campaign import Runner, Task
from fsmctl.studies.claim_types import StudyClaim
from fsmctl.studies.claims import CLAIMS
from fsmctl.studies.explain_settings import Candidate, Setting, candidate_source
from fsmctl.studies.figure_checks import FigureCheck, figure_numbers
from fsmctl.studies.paper_runs import RunSpec, run_plan, run_record, run_scenario
from fsmctl.studies.records import RunRecord, scenario_fingerprint

__all__ = ["RUN_SPECS", "Check", "CandidateRuns", "candidate_scenario", "simulate_candidate", "fly", "tolerance_of"]

RUN_SPECS = {s.key: s for s in run_plan()}
"""The runs of :func:`~fsmctl.studies.paper_runs.run_plan` by key: a candidate flies the same runs."""

_LATER_RUNS = tuple(c.later[1] for c in CLAIMS if c.later)
"""The runs flown only when a shorter one has not settled: read with every check once flown."""


@dataclass(frozen=True)
class Check:
    """A claim or a figure-level check as the search sees it: its id, its text and its registry entry.

    Parameters
    ----------
    id : str
        The claim's or figure check's id.
    text : str
        What the paper states (a claim's text as graded).
    rule : StudyClaim or FigureCheck
        The registry entry: its runs, its test (``decide``) and its numbers.

    Examples
    --------
    >>> from fsmctl.studies.claims import get_claim
    >>> check = Check("case2_accuracy", "Case 2 errors", get_claim("case2_accuracy"))
    >>> check.runs, check.uses_tolerance, check.later
    (('case2', 'case2_long'), True, ('case2', 'case2_long'))
    """

    id: str
    text: str
    rule: StudyClaim | FigureCheck

    @property
    def runs(self) -> tuple[str, ...]:
        """tuple of str: Every run its numbers may show."""
        return self.rule.runs

    @property
    def uses_tolerance(self) -> bool:
        """bool: Whether the settling tolerance is searched too."""
        return self.rule.uses_tolerance

    @property
    def later(self) -> tuple[str, str] | None:
        """(str, str) or None: A run flown only when a shorter one has not settled (:attr:`StudyClaim.later`)."""
        return self.rule.later

    @property
    def requires(self) -> tuple[str, str] | None:
        """(str, str) or None: The only setting and value that can reproduce it (None: any)."""
        return self.rule.requires


def tolerance_of(candidate: Candidate) -> float:
    """The settling tolerance a candidate grades with (deg): its own, or the reproduction's.

    Parameters
    ----------
    candidate : Candidate
        The candidate.

    Returns
    -------
    float
        The tolerance (deg).

    Examples
    --------
    >>> tolerance_of(Candidate()), tolerance_of(Candidate((("tolerance", 0.1),)))
    (1.0, 0.1)
    """
    t = candidate.tolerance()
    return SETTLING_TOLERANCES_DEG[0] if t is None else t


def candidate_scenario(data: Mapping[str, Any] | str, spec: RunSpec, fast: bool):
    """The scenario of a candidate's run (:func:`~fsmctl.studies.paper_runs.run_scenario` of its source).

    A candidate that flies another law (error MRP: unswitched) is that candidate, named in its label, so its
    :class:`~fsmctl.model.laws.LawSwitchWarning` is not repeated.

    Parameters
    ----------
    data : mapping or str
        The candidate's source (:func:`~fsmctl.studies.explain_settings.candidate_source`) or a scenario file.
    spec : RunSpec
        The run.
    fast : bool
        The short horizon of ``fsmctl reproduce --fast``.

    Returns
    -------
    Scenario
        Validated.

    Examples
    --------
    >>> scenario = candidate_scenario({"extends": "paper", "controller": {"torque_limit": 47.7}},
    ...                               RUN_SPECS["case1"], fast=True)
    >>> scenario.controller.torque_limit, scenario.simulation.t_final
    (47.7, 10.0)
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LawSwitchWarning)
        return run_scenario(data, spec, fast)


def simulate_candidate(data: Mapping[str, Any] | str, candidate: Candidate, spec: RunSpec, fast: bool) -> RunRecord:
    """Worker: fly ``spec`` on the candidate scenario ``data``; no file is written.

    Parameters
    ----------
    data : mapping or str
        The candidate's source or its scenario file.
    candidate : Candidate
        The candidate (whether its law's error MRP is unswitched).
    spec : RunSpec
        The run.
    fast : bool
        The short horizon of ``fsmctl reproduce --fast``.

    Returns
    -------
    RunRecord
        With the figure-level peaks (:func:`~fsmctl.studies.figure_checks.figure_numbers`) in its metrics, its
        warnings and CPU time; :meth:`RunRecord.failed` when the integrator cannot fly it (it reproduces nothing).
    """
    from fsmctl.simulation.simulator import SimulationError, simulate

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scenario = candidate_scenario(data, spec, fast)
        started, cpu = _time.perf_counter(), _time.process_time()
        try:
            result = simulate(scenario, progress=False)
        except SimulationError as exc:
            return RunRecord.failed(spec.key, f"{type(exc).__name__}: {str(exc).splitlines()[0]}")
    wall = _time.perf_counter() - started
    unswitched = any(n == "error_mrp" for n, _ in candidate.changes)
    peaks = {k: v for k, v in figure_numbers(result, unswitched).items() if k != "error_mrp"}
    messages = sorted({str(w.message).splitlines()[0] for w in caught if "triangle inequality" not in str(w.message)})
    with warnings.catch_warnings():  # the record reads the case from the same source: the same deliberate law switch
        warnings.simplefilter("ignore", LawSwitchWarning)
        return run_record(
            spec,
            scenario,
            result,
            source=data,
            wall_time_s=wall,
            cpu_time_s=_time.process_time() - cpu,
            metrics=peaks,
            warnings=messages,
        )


def fly(tasks: Mapping[Hashable, tuple], runner: Runner, bar) -> dict[Hashable, RunRecord]:
    """Fly the tasks on the campaign runner: the orchestration of the explanations.

    A run whose worker process keeps dying (the runner retries it, then flies it alone) counts as a failed run
    (:meth:`RunRecord.failed <fsmctl.studies.records.RunRecord.failed>`): it reproduces nothing, the search goes on.

    Parameters
    ----------
    tasks : mapping key -> arguments of :func:`simulate_candidate`
        The runs.
    runner : fsmctl.studies.campaign.Runner
        The campaign runner (in this process, or its worker processes).
    bar : tqdm
        The runner's progress bar (:meth:`~fsmctl.studies.campaign.Runner.progress`); its total grows by the number
        of tasks.

    Returns
    -------
    dict
        Key -> the run's record, in the order of ``tasks``.

    Examples
    --------
    >>> from fsmctl.studies.campaign import Runner
    >>> from fsmctl.studies.explain_settings import Candidate
    >>> spec = RUN_SPECS["case1"]
    >>> with Runner(workers=1) as runner:
    ...     bar = runner.progress(0, enabled=False)
    ...     done = fly({"base": ("paper", Candidate(), spec, True)}, runner, bar)
    >>> done["base"].key, done["base"].t_final, bar.total
    ('case1', 10.0, 1)
    """
    bar.total = (bar.total or 0) + len(tasks)
    bar.refresh()
    runs = [
        Task(key, simulate_candidate, args, lost=partial(RunRecord.failed, args[2].key)) for key, args in tasks.items()
    ]
    return dict(zip(tasks, runner.run(runs), strict=True))


class CandidateRuns:
    """The runs flown for candidate changes, once each, in parallel rounds; identical scenarios share one run.

    Parameters
    ----------
    base : str
        ``"paper"`` or the absolute path of the base scenario file.
    settings : mapping name -> Setting
        :func:`~fsmctl.studies.explain_settings.search_settings` by name.
    fast : bool
        The short horizon of ``fsmctl reproduce --fast``.
    runner : fsmctl.studies.campaign.Runner
        The campaign runner that flies them (:func:`fly`).
    bar : tqdm
        The runner's progress bar over the runs.
    """

    def __init__(self, base: str, settings: Mapping[str, Setting], fast: bool, runner: Runner, bar):
        self.base, self.settings, self.fast = base, settings, fast
        self.runner, self.bar = runner, bar
        self.runs: dict[tuple[Candidate, str], RunRecord] = {}
        self._by_print: dict[str, RunRecord] = {}
        self.simulated = 0
        self.cpu_s = 0.0

    def run(self, wanted: Iterable[tuple[Candidate, str]]) -> None:
        """Fly the ``(candidate, run key)`` pairs not flown yet (one round: all of them go to the pool together).

        Parameters
        ----------
        wanted : iterable of (Candidate, str)
            The pairs (grading changes are ignored: what is simulated).
        """
        todo = sorted({(c.simulated(), k) for c, k in wanted} - set(self.runs))
        jobs: dict[str, tuple] = {}
        waiting: dict[str, list[tuple[Candidate, str]]] = {}
        for cand, key in todo:
            data = candidate_source(self.base, cand, self.settings)
            spec = RUN_SPECS[key]
            fp = scenario_fingerprint(candidate_scenario(data, spec, self.fast))
            if fp in self._by_print:
                self.runs[(cand, key)] = self._by_print[fp]
                continue
            jobs.setdefault(fp, (data, cand, spec, self.fast))
            waiting.setdefault(fp, []).append((cand, key))
        if not jobs:
            return
        done = fly(jobs, self.runner, self.bar)
        self.simulated += len(jobs)
        for fp, record in done.items():
            self.cpu_s += record.cpu_time_s
            self._by_print[fp] = record
            for pair in waiting[fp]:
                self.runs[pair] = record

    def get(self, candidate: Candidate, key: str) -> RunRecord:
        """The record of run ``key`` at ``candidate`` (flown).

        Parameters
        ----------
        candidate : Candidate
            The candidate.
        key : str
            The run.

        Returns
        -------
        RunRecord
            The run (a failed one has :attr:`RunRecord.error`).
        """
        return self.runs[(candidate.simulated(), key)]

    def available(self, candidate: Candidate, check: Check) -> dict[str, RunRecord]:
        """The runs of ``check`` flown so far at ``candidate`` (the longer runs too, once flown).

        Parameters
        ----------
        candidate : Candidate
            The candidate.
        check : Check
            The check.

        Returns
        -------
        dict
            Run key -> record.
        """
        keys = (*check.runs, *_LATER_RUNS)
        return {k: self.get(candidate, k) for k in keys if (candidate.simulated(), k) in self.runs}

    def needed(self, check: Check, candidate: Candidate) -> list[str]:
        """The run keys still missing to judge ``check`` at ``candidate`` (none once a run has failed).

        Parameters
        ----------
        check : Check
            The check.
        candidate : Candidate
            The candidate.

        Returns
        -------
        list of str
            Run keys.
        """
        runs = self.available(candidate, check)
        if _failed(runs):
            return []
        verdict = check.rule.decide(runs, tolerance_of(candidate))
        return verdict if isinstance(verdict, list) else []

    def judge(self, check: Check, candidate: Candidate) -> bool:
        """Whether ``check`` passes at ``candidate`` (False when a run failed).

        Parameters
        ----------
        check : Check
            The check.
        candidate : Candidate
            The candidate (its runs flown: :meth:`needed` is empty).

        Returns
        -------
        bool
            The verdict.
        """
        runs = self.available(candidate, check)
        if _failed(runs):
            return False
        verdict = check.rule.decide(runs, tolerance_of(candidate))
        if isinstance(verdict, list):
            raise RuntimeError(f"{check.id}: runs {verdict} missing")
        return bool(verdict)

    def all_runs(self, check: Check, candidate: Candidate) -> list[str]:
        """Every run of the check's numbers (a longer run only when the shorter has not settled).

        Parameters
        ----------
        check : Check
            The check.
        candidate : Candidate
            The candidate.

        Returns
        -------
        list of str
            Run keys.
        """
        later = check.later
        keys = [k for k in check.runs if not (later and k == later[1])]
        if later:
            first = (candidate.simulated(), later[0])
            if first not in self.runs or self.runs[first].error:
                return [*keys]
            if not self.runs[first].settled(tolerance_of(candidate)):
                keys.append(later[1])
        return keys

    def numbers(self, check: Check, candidate: Candidate) -> str:
        """The check's numbers at ``candidate``, or why its run failed.

        Parameters
        ----------
        check : Check
            The check.
        candidate : Candidate
            The candidate.

        Returns
        -------
        str
            The text of an explanation.
        """
        runs = self.available(candidate, check)
        failed = _failed(runs)
        return f"the run failed ({failed})" if failed else check.rule.numbers(runs, tolerance_of(candidate))

    def complete(self, pairs: Iterable[tuple[Candidate, Check]]) -> None:
        """Fly every run the checks' numbers show at the candidates (rounds: a longer run depends on a shorter).

        Parameters
        ----------
        pairs : iterable of (Candidate, Check)
            The candidates and checks.
        """
        pairs = list(pairs)
        while wanted := [
            (c, k) for c, ch in pairs for k in self.all_runs(ch, c) if (c.simulated(), k) not in self.runs
        ]:
            self.run(wanted)


def _failed(runs: Mapping[str, RunRecord]) -> str:
    return next((f"{k}: {r.error}" for k, r in runs.items() if r.error), "")
