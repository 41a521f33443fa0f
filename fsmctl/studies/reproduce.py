"""``fsmctl reproduce``: the Section 4 reproduction report of Liang, Sun & Wang (2012).

Runs the paper's Cases 1, 2, 3a-3c and the diagnostic runs that isolate the cause of each difference
(:func:`~fsmctl.studies.paper_runs.run_plan`: Case 1 with the exact error kinematics, without the torque limit, with
pure sgn; Case 2 without the limit; Cases 3a-3c without the limit; Cases 1 and 2 on a three times longer horizon),
then grades every Section 4 claim (:data:`fsmctl.studies.claims.CLAIMS`) as

``reproduced``
    this run shows what the paper states;
``differs``
    it does not, and the reason (with the diagnostic run that shows it) is given;
``impossible (bound)``
    no controller respecting the paper's torque limit can do what the paper states:
    a lower bound on the time needed to remove each spacecraft's angular momentum
    relative to the reference (:func:`~fsmctl.studies.momentum.angular_momentum_bound`), computed independently of
    the closed-loop simulation, exceeds the paper's number.

With ``explain=True`` (``fsmctl reproduce`` by default) every claim that does not reproduce is explained
(:mod:`fsmctl.studies.explain`): the smallest change of a setting the paper leaves open or may have misprinted that
makes the claim's test (:meth:`~fsmctl.studies.claims.StudyClaim.holds`) pass, or "no setting in the searched ranges
reproduces it"; the evidence runs are written as scenario files (``DIR/explain/*.toml``) and the report gains the
section "What would reproduce each claim".  The default scenario is never changed.

Writes ``DIR/report.md``, ``DIR/claims.csv``, ``DIR/claims.json`` (:mod:`fsmctl.studies.report`), one NetCDF per run
(``DIR/runs/<run>.nc``) and the figures (``DIR/figures/*.png|svg``, analogues of Figs 1-9).
Verdicts are results: the exit code is 0 whenever the report was written.  The runs, the overlay figures and the
explanations' runs are tasks of one campaign runner (:class:`fsmctl.studies.campaign.Runner`, set up in
:func:`_orchestrate`): ``workers`` processes, a worker that dies replaced and its task retried.
"""

from __future__ import annotations

import shlex
import sys
import time as _time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from fsmctl.errors import InputError
from fsmctl.outputs import environment_problem
from fsmctl.parallel import resolve_workers
from fsmctl.studies.campaign import Runner, Task
from fsmctl.studies.claims import evaluate_claims
from fsmctl.studies.explain import explain as explain_claims
from fsmctl.studies.figure_marks import metric_marks, paper_marks
from fsmctl.studies.momentum import angular_momentum_bound
from fsmctl.studies.paper_runs import (
    PAPER_CASES,
    RunSpec,
    execute_run,
    load_case,
    run_plan,
    run_scenario,
    scenario_overrides,
)
from fsmctl.studies.records import RunRecord, scenario_fingerprint
from fsmctl.studies.report import Reproduction, write_outputs

__all__ = ["reproduce", "overlay_figures", "documented_findings_apply"]


def _check_source(source: str) -> None:
    from fsmctl.model.scenario import load_scenario

    base = load_scenario(source)
    missing = [c for c in PAPER_CASES if c not in base.cases]
    if missing:
        raise InputError(
            f"scenario {source!r} lacks case(s) {', '.join(missing)}: fsmctl reproduce needs the paper's cases "
            f"{', '.join(PAPER_CASES)} (Sec. 4)"
        )


def documented_findings_apply(source: str, fast: bool = False) -> bool:
    """Whether the documented findings (``docs/findings.md``) apply to a reproduction of ``source``.

    They do for the paper's own scenario, unchanged in every case, at its full horizon: then ``fsmctl reproduce``
    compares each verdict with the documented one (:meth:`fsmctl.studies.report.Reproduction.differences`).

    Parameters
    ----------
    source : str
        ``"paper"`` or a scenario TOML file, as :func:`reproduce` takes it.
    fast : bool
        Whether the reproduction uses the short horizon (then no finding is documented).

    Returns
    -------
    bool
        True for the paper's scenario at its full horizon.

    Examples
    --------
    >>> documented_findings_apply("paper"), documented_findings_apply("paper", fast=True)
    (True, False)
    """
    from fsmctl.model.scenario import load_scenario

    if fast:
        return False
    paper = load_scenario("paper")
    base = load_scenario(source)
    return set(base.cases) == set(paper.cases) and all(
        load_scenario(source, case=c) == load_scenario("paper", case=c) for c in paper.cases
    )


def _inertia_check(scenario) -> list[dict]:
    rows = []
    for i, a in enumerate(scenario.agents):
        for which, J in (("J0", a.J0_array), ("J0 + ΔJ", a.J_true)):
            eig = np.linalg.eigvalsh(J)
            rows.append(
                {
                    "agent": i + 1,
                    "inertia": which,
                    "principal_moments_kg_m2": [float(x) for x in eig],
                    "J1_plus_J2_minus_J3_kg_m2": float(eig[0] + eig[1] - eig[2]),
                }
            )
    return rows


_NO_LIMIT_KEYS = (
    "case1_no_torque_limit",
    "case2_no_torque_limit",
    "case3a_no_torque_limit",
    "case3b_no_torque_limit",
    "case3c_no_torque_limit",
)
_OVERLAYS: tuple[tuple[str, tuple[str, ...], str, str, bool], ...] = (
    # (file stem, runs, metric, title, log scale); linear plots get the paper's inset (Figs 5-6, 8-9)
    ("fig05_aaem_case2_vs_case1", ("case2", "case1"), "aaem", "AAEM without coordination (Case 2) vs Case 1", False),
    ("fig06_raem_case2_vs_case1", ("case2", "case1"), "raem", "RAEM without coordination (Case 2) vs Case 1", False),
    ("fig08_aaem_case3", ("case3a", "case3b", "case3c"), "aaem", "AAEM with different weights (Cases 3a-3c)", False),
    ("fig09_raem_case3", ("case3a", "case3b", "case3c"), "raem", "RAEM with different weights (Cases 3a-3c)", False),
    (
        "diag_aaem_case1_variants",
        ("case1", "case1_exact_error_model", "case1_pure_sgn", "case1_no_torque_limit"),
        "aaem",
        "Case 1 and its diagnostic runs",
        True,
    ),
    ("diag_aaem_no_torque_limit", _NO_LIMIT_KEYS, "aaem", "without the torque limit", True),
    ("diag_raem_no_torque_limit", _NO_LIMIT_KEYS, "raem", "without the torque limit", True),
    (
        "diag_aaem_long_horizon",
        ("case1_long", "case2_long"),
        "aaem",
        "Cases 1 and 2 with the torque limit, long horizon",
        True,
    ),
)


def overlay_figures(records: Mapping[str, RunRecord]) -> dict[str, Any]:
    """The multi-run figures (Figs 5-6: Case 2 vs Case 1, Figs 8-9: Cases 3a-3c, and the diagnostics).

    Parameters
    ----------
    records : mapping run key -> RunRecord
        The runs of :func:`~fsmctl.studies.paper_runs.run_plan` (as in :attr:`fsmctl.studies.report.Reproduction.records`).

    Returns
    -------
    dict of str -> matplotlib.figure.Figure
        Keyed by file stem (``fig05_aaem_case2_vs_case1``, ...), the paper's Figs 5, 6, 8, 9 first.

    Examples
    --------
    >>> records = one_second_records()  # conftest.py: the plan's runs, 1 s each (shared; the reproduction flies 100 s)
    >>> figures = overlay_figures(records)
    >>> list(figures)[:4]
    ['fig05_aaem_case2_vs_case1', 'fig06_raem_case2_vs_case1', 'fig08_aaem_case3', 'fig09_raem_case3']
    >>> [line.get_label().split(" (")[0] for line in figures["fig08_aaem_case3"].axes[0].lines]
    ['Case 3a', 'Case 3b', 'Case 3c']
    """
    return {name: _overlay_figure(*_overlay_arguments(records, name)) for name, *_ in _OVERLAYS}


def _overlay_arguments(records: Mapping[str, RunRecord], name: str) -> tuple[dict, dict]:
    _, keys, metric, title, log = next(o for o in _OVERLAYS if o[0] == name)
    curves = {records[k].title: (records[k].time, getattr(records[k], f"{metric}_deg")) for k in keys}
    equation = "eq 42" if metric == "aaem" else "eq 43"
    # the paper's Figs 5-6, 8-9: their stated values, printed axes and inset range (the inset spans the run, as the
    # paper's); the diagnostics: the statements about their metric
    marks = paper_marks(int(name[3:5])) if name.startswith("fig") else metric_marks(metric)
    options = {"ylabel": f"{metric.upper()} (deg), {equation}", "title": title, "log": log, "marks": marks}
    return curves, options


def _overlay_figure(curves: dict, options: dict):
    import fsmctl.studies.figures as figs

    return figs.overlay_figure(curves, **options)


def _render_overlay(curves: dict, options: dict, stem: str) -> list[str]:
    import fsmctl.studies.figures as figs

    return [str(p) for p in figs.save_figure(_overlay_figure(curves, options), stem)]


def reproduce(
    source: str = "paper",
    out_dir: str | Path = "reproduction",
    *,
    fast: bool = False,
    workers: int | None = None,
    progress: bool | None = None,
    figures: bool = True,
    log: Callable[[str], None] | None = None,
    explain: bool = False,
    command: Sequence[str] | str | None = None,
) -> Reproduction:
    """Run the Section 4 reproduction of Liang et al. (2012) and write its report.

    Parameters
    ----------
    source : str
        ``"paper"`` or a scenario TOML file with cases ``1, 2, 3a, 3b, 3c``.
    out_dir : str or Path
        Output folder (created).
    fast : bool
        Short horizon (10 s; long runs 30 s) and coarser output: for tests and quick looks.
    workers : int, optional
        Worker processes (1: in this process).  Default: one per CPU, at most one per run of the plan
        (:func:`fsmctl.policy.default_workers` of the number of runs).  The results do not depend on it.
    progress : bool, optional
        tqdm bar over the runs; default: when stderr is a terminal.
    figures : bool
        Write the figures (PNG + SVG).
    log : callable, optional
        Receives progress lines (e.g. ``print``).
    explain : bool
        Search, for every claim not reproduced, the smallest change of an open setting that reproduces it
        (:func:`fsmctl.studies.explain.explain`; separate runs, the scenario is unchanged), at the same horizon
        (``fast``: the short one).  ``fsmctl reproduce`` does by default.
    command : sequence of str or str, optional
        The command line (``sys.argv``), embedded in every run's NetCDF file with its scenario, law and versions
        (:func:`fsmctl.simulation.results_io.provenance`).

    Returns
    -------
    Reproduction
        Records, bounds, claims, explanations and the list of written files (:class:`fsmctl.studies.report.Reproduction`).

    Raises
    ------
    InputError
        If ``source`` cannot be read or lacks one of the paper's cases, or ``workers`` is not a whole number >= 1.
    OSError
        If ``out_dir`` cannot be created (:func:`fsmctl.outputs.environment_problem` names it).

    Examples
    --------
    The whole reproduction takes about 1.5 minutes on 2 cores, its fast mode (10 s horizon, no explanations)
    10-25 s; neither runs here:

    >>> from fsmctl.studies.report_text import format_claims
    >>> rep = reproduce("paper", "reproduction", fast=True, figures=False)  # doctest: +SKIP
    >>> print(format_claims(rep))  # doctest: +SKIP

    What it returns is read as follows, here on a :class:`~fsmctl.studies.report.Reproduction` assembled from 1 s
    runs of its plan (the same :func:`~fsmctl.studies.paper_runs.run_plan`,
    :func:`~fsmctl.studies.paper_runs.run_record`, :func:`~fsmctl.studies.claims.evaluate_claims` it calls):

    >>> rep = one_second_reproduction()  # conftest.py: the Reproduction example's 1 s runs (shared)
    >>> [(c.id, c.verdict) for c in rep.claims][:2]
    [('settling_27s', 'impossible (bound)'), ('tracking_accuracy', 'impossible (bound)')]
    >>> rep.records["case1"].t_final
    1.0
    """
    started = _time.perf_counter()
    workers = resolve_workers(workers, len(run_plan()), "reproduce")
    _check_source(source)
    if command is not None and not isinstance(command, str):
        command = shlex.join(str(c) for c in command)  # one picklable string for the workers
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise environment_problem("create output folder", out, exc) from None
    case1 = run_scenario(source, RunSpec("case1", "1", "Case 1", ""), fast)  # its settings as flown (fast: 10 s)
    plan = [s if figures else replace(s, figures=()) for s in run_plan()]
    say = log or (lambda _line: None)
    described = case1.describe()
    choices = [line for line in described if line.lstrip().startswith("choice ")]
    say(
        f"reproduce: {len(plan)} runs, the paper's Cases {', '.join(PAPER_CASES)} and {len(plan) - len(PAPER_CASES)} "
        "diagnostic runs (each run's settings in the report); Case 1's settings:"
    )
    say("\n".join("  " + line for line in described if line not in choices))
    if choices:  # their reasons are paragraphs: the report holds them ("Settings and the choices ...")
        say(
            f"    choices the paper leaves open: {len(choices)} ({', '.join(c.split()[1].rstrip(':') for c in choices)}), their reasons in the report"
        )
    study = _Study(
        source, plan, fast, out, command, figures, explain, sys.stderr.isatty() if progress is None else progress, log
    )
    records, bounds, claims, files, explanations, explain_s = _orchestrate(study, case1, workers)
    for rec in records.values():
        files += [*([] if rec.same_as else [rec.netcdf]), *rec.figures]
    if explanations:
        files += sorted(str(p) for p in (out / "explain").glob("*") if p.is_file())
    result = Reproduction(
        out_dir=out,
        fast=fast,
        scenario_lines=case1.describe(),
        records=records,
        bounds=bounds,
        claims=claims,
        inertia_check=_inertia_check(case1),
        files=sorted(files),
        wall_time_s=0.0,
        explanations=explanations,
        explain_wall_time_s=explain_s,
        documented_applies=documented_findings_apply(source, fast),
    )
    result.wall_time_s = _time.perf_counter() - started
    write_outputs(result)
    result.wall_time_s = _time.perf_counter() - started
    return result


@dataclass(frozen=True)
class _Study:
    """What one reproduction flies and where (the arguments of :func:`reproduce` the runs need)."""

    source: str
    plan: list[RunSpec]
    fast: bool
    out: Path
    command: str | None
    figures: bool
    explain: bool
    progress: bool
    log: Callable[[str], None] | None

    def say(self, line: str) -> None:
        if self.log is not None:
            self.log(line)

    def reuse(self) -> tuple[list[RunSpec], dict[str, tuple[str, Any]]]:
        """The runs to simulate, and the runs whose settings coincide with an earlier one (the paper's Case 3c is
        Case 1): key -> (the earlier run's key, its own scenario)."""
        first_of: dict[str, str] = {}
        reuse: dict[str, tuple[str, Any]] = {}
        for spec in self.plan:
            scenario = run_scenario(self.source, spec, self.fast)
            fingerprint = scenario_fingerprint(scenario)
            if fingerprint in first_of and not spec.figures:
                reuse[spec.key] = (first_of[fingerprint], scenario)
            else:
                first_of.setdefault(fingerprint, spec.key)
        return [s for s in self.plan if s.key not in reuse], reuse


def _orchestrate(study: _Study, case1, workers: int):
    """The reproduction on the campaign runner: the runs, the overlay figures, the explanations.

    One :class:`~fsmctl.studies.campaign.Runner` (its process pool when ``workers > 1``) flies the runs, draws the
    overlay figures and the explanations' runs; a worker that dies is replaced and its task retried
    (:class:`~fsmctl.studies.campaign.Runner`).  Ctrl-C (``KeyboardInterrupt``) or ``SIGTERM`` (the command line's
    exception) leaves the runner, which cancels the queue and stops the workers; the exit code stays the command
    line's (130, 143).
    """
    simulated, reuse = study.reuse()
    with Runner(workers=workers, name="reproduce", interrupts=False) as runner:
        total = len(simulated) + (len(_OVERLAYS) if study.figures else 0)
        runner.progress(total, unit="task", enabled=study.progress)
        bounds = angular_momentum_bound(case1)
        records = _simulate_runs(study, simulated, runner)
        _reuse_records(records, reuse, study.plan, study.source)
        files = _render_overlays(records, study.out, runner) if study.figures else []
        records = {s.key: records[s.key] for s in study.plan}
        claims = evaluate_claims(records, bounds)
        explanations, explain_s = None, 0.0
        if study.explain:
            explain_started = _time.perf_counter()
            explanations = explain_claims(
                study.source,
                claims,
                study.out,
                fast=study.fast,
                runner=runner,
                progress=study.progress,
                log=study.log,
            )
            explain_s = _time.perf_counter() - explain_started
    return records, bounds, claims, files, explanations, explain_s


def _simulate_runs(study: _Study, simulated: Sequence[RunSpec], runner: Runner) -> dict[str, RunRecord]:
    """Fly the runs (:func:`~fsmctl.studies.paper_runs.execute_run`: each writes its NetCDF file and figures)."""
    args = (study.fast, str(study.out), study.command)
    tasks = [Task(spec.key, execute_run, (study.source, spec, *args)) for spec in simulated]

    def done(_task: Task, rec: RunRecord) -> None:
        study.say(f"  run {rec.key}: {rec.wall_time_s:.1f} s")

    return {rec.key: rec for rec in runner.run(tasks, on_done=done)}


def _reuse_records(
    records: dict[str, RunRecord],
    reuse: Mapping[str, tuple[str, Any]],
    plan: Sequence[RunSpec],
    source: str | Mapping[str, Any],
):
    """The records of the runs identical to an earlier one: its results under their own names."""
    by_key = {s.key: s for s in plan}
    for key, (original, scenario) in reuse.items():
        spec = by_key[key]
        records[key] = replace(
            records[original],
            key=key,
            title=spec.title,
            purpose=spec.purpose,
            overrides=scenario_overrides(load_case(source, spec.case), scenario),
            case=spec.case,
            label=scenario.label,
            describe=scenario.describe(),
            figures=[],
            wall_time_s=0.0,
            same_as=original,
        )


def _render_overlays(records: Mapping[str, RunRecord], out: Path, runner: Runner) -> list[str]:
    """Write the overlay figures (one task each); returns the files."""
    tasks = [
        Task(name, _render_overlay, (*_overlay_arguments(records, name), str(out / "figures" / name)))
        for name, *_ in _OVERLAYS
    ]
    return [path for paths in runner.run(tasks) for path in paths]
