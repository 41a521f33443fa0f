"""What would reproduce each claim of Liang, Sun & Wang (2012), Section 4: ``fsmctl reproduce``'s explanations.

For every claim that :func:`fsmctl.studies.claims.evaluate_claims` does not grade ``reproduced``, and for the
figure-level checks :data:`~fsmctl.studies.figure_checks.FIGURE_CHECKS` (what the printed Figs 1-9 show: axis ranges, the saturation level, the
insets), this module searches the settings the paper leaves open or may have misprinted (:func:`~fsmctl.studies.explain_settings.search_settings`)
for the **smallest change** that makes the claim's own test (:meth:`fsmctl.studies.claims.StudyClaim.holds`) pass:

* the torque limit (the paper's 2 N m: a misprint?), alpha, delta, the boundary layer phi;
* the error kinematics (``error_model = "exact"``), the error MRP not switched to the shadow set (the FSM law of
  ``fsmctl/studies/explain_laws/fsm_unswitched.py``), the integrator and its step;
* the tolerance behind "settles" (a grading setting: no new runs).

Distance.  A continuous setting's change is measured on its scale (log, or linear for alpha) as the fraction of the
searched range moved from the scenario's value towards the end of the range on that side, in ``(0, 1]``; a discrete
choice (error kinematics, error MRP, integrator / step) counts 1; a pair adds its two distances.  The smallest
change is the one of least distance (ties: the order of :func:`~fsmctl.studies.explain_settings.search_settings`).

Search (best-first, per claim).  The grid values of every setting (:attr:`~fsmctl.studies.explain_settings.Setting.grid`) are tried in order of
distance, level by level (:data:`~fsmctl.studies.explain_search.LEVELS`); a reproducing grid value and the nearest tried value towards the default
(which fails, or the default itself) bracket a threshold, bisected to :attr:`Setting.resolution`.  The search stops
when no untried value can be nearer than the change found (the grid spacing is the resolution elsewhere: a window of
success narrower than a grid step can be missed), then tries the grid values beyond the threshold on its axis, so
that "reproduced if torque limit >= 47.7 N m (bisected to 0.1 N m; 47.6 N m does not)" is checked over the whole
range, and "fails again at ..." is said when it is not.  A claim no single change reproduces is searched in pairs
(one modelling choice of :data:`~fsmctl.studies.explain_search.PAIRED_CHOICES` held, every other setting varied) within :data:`PAIR_BUDGET_RUNS`
runs; so are the figure checks that only the unswitched error MRP can reach (in the shadow set every principal angle
is at most 180°).

Runs.  Every candidate run is a run of :func:`fsmctl.studies.paper_runs.run_plan` (same key, case, horizon and
output grid) flown on the candidate scenario: the base scenario with the change, as the mapping of a scenario file
``{"extends": <base>, <section>: {<key>: <value>}}``.  Identical scenarios are simulated once; a claim that fails on
its first run does not fly the others; the runs of a round go to the campaign runner together
(:class:`fsmctl.studies.campaign.Runner`: ``fsmctl reproduce``'s worker processes), and the result
does not depend on the order in which they finish or on the number of workers.  The evidence of each explanation is
written as a scenario file (``extends`` the base with just the change), re-loaded from that file and simulated
again, and its numbers must equal the search's.

The default scenario is never changed: every explanation is a separate run.
"""

from __future__ import annotations

import shutil
import time as _time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from fsmctl.errors import InputError
from fsmctl.outputs import write_text
from fsmctl.studies.campaign import Runner
from fsmctl.studies.claim_types import ClaimVerdict, StudyClaim
from fsmctl.studies.claims import claim_ids, get_claim
from fsmctl.studies.explain_laws import UNSWITCHED_LAW, law_script
from fsmctl.studies.explain_report import ALREADY_REPRODUCED, EXPLAINED, NOT_EXPLAINED, Evidence, Explanation
from fsmctl.studies.explain_runs import RUN_SPECS, CandidateRuns, Check, fly
from fsmctl.studies.explain_search import (
    LEVELS,
    PAIR_LEVELS,
    Axis,
    CheckSearch,
    drive,
    pair_axes,
    rank,
    searched_ranges,
    single_axes,
    statement,
)
from fsmctl.studies.explain_settings import Candidate, Setting, candidate_source, scenario_text, search_settings
from fsmctl.studies.figure_checks import FIGURE_CHECKS
from fsmctl.studies.paper_runs import load_case, run_scenario

__all__ = ["PAIR_BUDGET_RUNS", "EXPLAIN_DIR", "explain"]

PAIR_BUDGET_RUNS = 60
"""Pairs start no new distance level once this many runs have been spent on them (all claims together)."""

EXPLAIN_DIR = "explain"
"""Sub-folder of the report with the evidence scenario files."""


def explain(
    source: str,
    claims: Sequence[ClaimVerdict],
    out_dir: str | Path,
    *,
    fast: bool = False,
    runner: Runner | None = None,
    progress: bool | None = None,
    log: Callable[[str], None] | None = None,
    settings: Sequence[str] | None = None,
    checks: Sequence[str] | None = None,
    pair_budget_runs: int = PAIR_BUDGET_RUNS,
) -> list[Explanation]:
    """Search, for each claim not reproduced, the smallest change of an open setting that reproduces it.

    Parameters
    ----------
    source : str
        ``"paper"`` or a scenario TOML file with the paper's cases (as :func:`fsmctl.studies.reproduce.reproduce`).
    claims : sequence of ClaimVerdict
        :func:`fsmctl.studies.claims.evaluate_claims` of the base runs.
    out_dir : str or Path
        The report folder: the evidence scenario files go to ``out_dir/explain/``.
    fast : bool
        The short horizon of ``fsmctl reproduce --fast`` (the runs are those of
        :func:`~fsmctl.studies.paper_runs.run_plan` in fast mode).
    runner : fsmctl.studies.campaign.Runner, optional
        The campaign runner that flies the runs (``fsmctl reproduce``'s, with its worker processes); default: one
        in this process.
    progress : bool, optional
        Progress bar over the runs, attached to the runner (default: when stderr is a terminal).
    log : callable, optional
        Receives progress lines.
    settings : sequence of str, optional
        Search only these settings (names of :func:`~fsmctl.studies.explain_settings.search_settings`); default all.
    checks : sequence of str, optional
        Explain only these claims / figure checks (ids); default all.
    pair_budget_runs : int
        Most runs spent on pairs of changes (0: no pairs).

    Returns
    -------
    list of Explanation
        One per claim in the paper's order (:func:`~fsmctl.studies.claims.claim_ids`), then one per figure-level
        check (:data:`~fsmctl.studies.figure_checks.FIGURE_CHECKS`).

    Raises
    ------
    InputError
        ``settings`` names a setting :func:`~fsmctl.studies.explain_settings.search_settings` does not have (a
        ``ValueError``).

    See Also
    --------
    fsmctl.studies.explain_report.Explanation : how to read the result (with an example).
    """
    if runner is None:
        with Runner(workers=1, name="explain", interrupts=False) as own:
            return explain(
                source, claims, out_dir, fast=fast, runner=own, progress=progress, log=log, settings=settings,
                checks=checks, pair_budget_runs=pair_budget_runs,
            )  # fmt: skip
    say = log or (lambda _line: None)
    started = _time.perf_counter()
    base, chosen, by_name = _settings(source, settings)
    order = {cid: i for i, cid in enumerate(claim_ids())}
    claims = sorted(claims, key=lambda c: order.get(c.id, len(order)))
    all_checks = [ch for ch in _checks(claims) if checks is None or ch.id in checks]
    bar = runner.progress(0, unit="run", enabled=progress, desc="explain")
    runs = CandidateRuns(base, by_name, fast, runner, bar)
    state = _search(all_checks, chosen, by_name, runs, pair_budget_runs, say)
    evidence = _write_evidence(base, state, runs, by_name, Path(out_dir), fast)
    bar.close()
    verdicts = {c.id: c.verdict for c in claims}
    out = [_explanation(ch, verdicts.get(ch.id), state, evidence, runs, chosen, by_name) for ch in all_checks]
    say(
        f"  explain: {runs.simulated} runs ({runs.cpu_s:.0f} s of simulation) in {_time.perf_counter() - started:.1f} s"
    )
    return out


def _settings(source: str, settings: Sequence[str] | None) -> tuple[str, list[Setting], dict[str, Setting]]:
    """The base scenario's source, the settings searched and all settings by name."""
    from fsmctl.model.laws import resolve_law
    from fsmctl.model.scenario import BUILTIN_SCENARIOS

    base = source if source in BUILTIN_SCENARIOS else str(Path(source).expanduser().resolve())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        all_settings = search_settings(load_case(base, "1"))
    unknown = sorted(set(settings or ()) - {s.name for s in all_settings})
    if unknown:
        raise InputError(f"unknown setting(s) {unknown} (settings: {[s.name for s in all_settings]})")
    chosen = [s for s in all_settings if settings is None or s.name in settings]
    if "error_mrp" in {s.name for s in chosen}:
        resolve_law(str(law_script(UNSWITCHED_LAW)))  # derived once (cached) before the workers need it
    return base, chosen, {s.name: s for s in all_settings}


def _checks(claims: Sequence[ClaimVerdict]) -> list[Check]:
    """The claims graded (their registry entries, with the text as graded), then every figure-level check."""
    return [Check(c.id, c.claim, get_claim(c.id)) for c in claims] + [Check(f.id, f.text, f) for f in FIGURE_CHECKS]


@dataclass
class _State:
    """Where the search ended: the verdicts at the base scenario, the searches of the failing checks, the pairs."""

    baseline: dict[str, bool]
    failing: list[Check]
    searches: dict[str, CheckSearch]
    left: list[CheckSearch] = field(default_factory=list)
    pair_note: str = ""

    def best(self, check_id: str) -> Axis | None:
        search = self.searches.get(check_id)
        return search.best if search is not None else None


def _search(checks, chosen, by_name, runner: CandidateRuns, pair_budget_runs: int, say) -> _State:
    """Judge every check at the base scenario, search single changes for the failing ones, then pairs."""
    base_c = Candidate()
    runner.complete([(base_c, ch) for ch in checks])
    baseline = {ch.id: runner.judge(ch, base_c) for ch in checks}
    failing = [ch for ch in checks if not baseline[ch.id]]
    searches = {ch.id: CheckSearch(ch, single_axes(ch, chosen, by_name), LEVELS) for ch in failing}
    say(f"  explain: {len(failing)} claims / figure checks not reproduced; single changes of {len(chosen)} settings")
    drive(list(searches.values()), runner)
    say(f"  explain: single changes: {runner.simulated} runs ({runner.cpu_s:.0f} s of simulation)")
    state = _State(baseline, failing, searches)
    state.left = [
        s for s in searches.values() if s.best is None and (isinstance(s.check.rule, StudyClaim) or s.check.requires)
    ]
    if state.left and pair_budget_runs > 0:
        for s in state.left:
            s.extend(pair_axes(s.check, chosen, by_name), PAIR_LEVELS)
        spent = drive(state.left, runner, budget=pair_budget_runs)
        reached = max((s.level for s in state.left), default=0.0)
        state.pair_note = (
            f"pairs (a discrete choice held, each other setting searched) tried for {len(state.left)} checks with "
            f"{spent} runs, up to distance {reached:g}"
            + (f" (budget {pair_budget_runs} runs)" if any(s.capped for s in state.left) else "")
        )
        say(f"  explain: {state.pair_note} ({runner.cpu_s:.0f} s of simulation so far)")
    shown = [(a.candidate(a.best()), s.check) for s in searches.values() if (a := s.best)]
    shown += [
        (a.candidate(a.bracket_of(a.best())[0]), s.check)
        for s in searches.values()
        if (a := s.best) and a.setting.continuous
    ]
    runner.complete(shown)
    return state


def _explanation(ch: Check, verdict, state: _State, evidence, runner, chosen, by_name) -> Explanation:
    """The explanation of one check from the search's result."""
    base_c = Candidate()
    verdict = verdict or ("fits" if state.baseline[ch.id] else "does not fit")
    base_numbers = runner.numbers(ch, base_c)
    if state.baseline[ch.id]:
        return Explanation(ch.id, ch.text, verdict, ALREADY_REPRODUCED, "no change needed", baseline=base_numbers)
    search = state.searches[ch.id]
    searched = searched_ranges(chosen, ch)
    req = ch.requires
    if req:
        searched = [f"only with the {by_name[req[0]].value_text(req[1])} ({ch.rule.why})", *searched]
    searched.append(f"best-first by distance up to {search.level:g}")
    a = search.best
    if a is None:
        pairs = state.pair_note if search in state.left else ""
        return Explanation(
            ch.id, ch.text, verdict, NOT_EXPLAINED, NOT_EXPLAINED, baseline=base_numbers, searched=searched, pairs=pairs
        )
    value = a.best()
    cand = a.candidate(value)
    outside = ""
    if a.setting.continuous:
        oc = a.candidate(a.bracket_of(value)[0])
        outside = f"at {oc.text(by_name) if oc.changes else 'the default'}: {runner.numbers(ch, oc)}"
    others = sorted((x for x in search.axes if x.best() is not None and x is not a), key=rank)
    return Explanation(
        ch.id,
        ch.text,
        verdict,
        EXPLAINED,
        statement(a),
        change=cand.text(by_name),
        distance=a.d(value),
        baseline=base_numbers,
        numbers=runner.numbers(ch, cand),
        outside=outside,
        evidence=evidence[cand],
        alternatives=[f"{statement(x)} (distance {x.d(x.best()):.2f})" for x in others],
        searched=searched,
        pairs=state.pair_note if a.fixed.changes else "",
    )


def _evidence_runs(state: _State, runner: CandidateRuns) -> dict[Candidate, list[str]]:
    """The runs of each evidence candidate: every run of the checks it explains, and Case 1 (its figures)."""
    keys: dict[Candidate, list[str]] = {}
    for ch in state.failing:
        a = state.best(ch.id)
        if a is None:
            continue
        cand = a.candidate(a.best())
        ks = keys.setdefault(cand, [])
        for k in (*runner.all_runs(ch, cand), "case1"):
            if k not in ks:
                ks.append(k)
    return keys


def _evidence_comments(
    cand: Candidate, explains: list[str], runs: list[str], settings, data, law_path, fast
) -> list[str]:
    """The comment lines at the top of an evidence scenario file; ``data``: its source with the law where this process
    finds it (the runs' horizons and output grids are read from the scenarios :func:`run_scenario` builds of it)."""
    cases = list(dict.fromkeys(RUN_SPECS[k].case for k in runs))
    comments = [
        f"written by fsmctl reproduce: the evidence run of {', '.join(explains)}",
        f"change: {cand.text(settings)} (everything else as the base scenario)",
        "run it: " + "; ".join(f"fsmctl simulate --scenario {cand.key()}.toml --case {c}" for c in cases),
    ]
    if law_path:
        comments.append(
            "the figure checks read theta = 4 atan|sigma_e| of the law's unswitched error MRP (up to 360 deg); "
            "fsmctl simulate reports the shadow-set metrics"
        )
    if cand.tolerance() is not None:
        comments.append(f"grading: settling tolerance {cand.tolerance():g} deg (not a scenario setting)")
    flown: dict[tuple[float, float], list[str]] = {}  # the horizon and output grid of each run, as it was flown
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the scenarios' warnings (the law's switch) were shown when the runs flew
        for k in runs:
            sim = run_scenario(data, RUN_SPECS[k], fast).simulation
            flown.setdefault((sim.t_final, sim.output_interval), []).append(k)
    comments.append(
        f"fsmctl reproduce{' --fast' if fast else ''} flew "
        + "; ".join(f"{', '.join(ks)} for {t:g} s, output every {dt:g} s" for (t, dt), ks in flown.items())
    )
    return comments


def _write_evidence(base, state: _State, runner: CandidateRuns, settings, out: Path, fast: bool):
    """Write each evidence candidate's scenario file, re-run it from the file and compare the numbers."""
    folder = out / EXPLAIN_DIR
    keys = _evidence_runs(state, runner)
    runner.run([(cand, k) for cand, ks in keys.items() for k in ks])
    files: dict[Candidate, Path] = {}
    for cand in sorted(keys):
        explains = [ch.id for ch in state.failing if (a := state.best(ch.id)) and a.candidate(a.best()) == cand]
        law_path = None
        if any(n == "error_mrp" for n, _ in cand.changes):
            folder.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(law_script(UNSWITCHED_LAW), folder / UNSWITCHED_LAW)
            law_path = UNSWITCHED_LAW
        data = candidate_source(base, cand.simulated(), settings, law_path)
        path = folder / f"{cand.key()}.toml"
        found = candidate_source(base, cand.simulated(), settings)  # the law at its installed path: loadable here
        write_text(
            path, scenario_text(data, _evidence_comments(cand, explains, keys[cand], settings, found, law_path, fast))
        )
        files[cand] = path
    tasks = {(c, k): (str(files[c]), c, RUN_SPECS[k], fast) for c in sorted(keys) for k in keys[c]}
    reruns = fly(tasks, runner.runner, runner.bar)
    return {
        cand: _evidence(cand, keys[cand], files[cand].relative_to(out).as_posix(), reruns, runner, settings)
        for cand in sorted(keys)
    }


_CASE1_FIGURES = [f for f in FIGURE_CHECKS if f.runs == ("case1",)]
"""The figure checks of Case 1 alone (Figs 1-4): every evidence run shows them."""


def _evidence(cand: Candidate, runs: list[str], scenario_file: str, reruns: Mapping, runner, settings) -> Evidence:
    """The evidence of one candidate: its file, its Figs 1-4, whether the re-run from the file is identical."""
    c1 = {"case1": runner.get(cand, "case1")}
    failed = f"case1: {c1['case1'].error}" if c1["case1"].error else ""
    return Evidence(
        key=cand.key(),
        change=cand.text(settings),
        scenario_file=scenario_file,
        runs=list(runs),
        figures=[f"Case 1 failed ({failed})"]
        if failed
        else [f"{f.id.split('_')[0].replace('fig', 'Fig ')}: {f.numbers(c1)}" for f in _CASE1_FIGURES],
        figures_fit=[] if failed else [f.id for f in _CASE1_FIGURES if f.decide(c1) is True],
        rerun_identical=all(runner.get(cand, k).same_numbers(reruns[(cand, k)]) for k in runs),
        warnings=sorted({w for k in runs for w in runner.get(cand, k).warnings}),
    )
