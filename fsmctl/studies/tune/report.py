"""A finished study's result and files: ``trials.csv``, ``pareto.csv``, ``pareto.png``, ``best.toml``, ``tune.json``."""

from __future__ import annotations

import csv
import dataclasses
import os
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from fsmctl.model.laws import LawSwitchWarning
from fsmctl.model.scenario import Scenario
from fsmctl.model.toml_writer import toml_table, toml_value
from fsmctl.studies.tune.evaluation import coupling_scales
from fsmctl.studies.tune.settings import (
    CONSTRAINTS,
    DIMENSIONLESS,
    OBJECTIVES,
    STUDY_FILE,
    SearchParameter,
    TuneSettings,
    search_space_lines,
)

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
    horizon_s : float
        The horizon ``T`` the candidates were flown over (s): a settling objective above it is the
        never-settles score (:func:`~fsmctl.studies.tune.unsettled_score`, at least ``2 T``), not a settling time.
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
    no feasible design found: of 2 complete trials, converged failed in 2 (widen the ranges, raise the budget or the horizon)
    >>> sorted(p.name for p in result.paths)  # no feasible design: no best.toml
    ['pareto.csv', 'pareto.png', 'study.log', 'trials.csv', 'tune.json']
    """

    settings: TuneSettings
    space: list[SearchParameter]
    constraints: tuple[str, ...]
    trials: list[dict]
    pareto: list[int]
    best: int | None
    theorem1: bool | None
    horizon_s: float
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
        head = (
            f"tune: law {s.law} on {s.scenario}" + (f" case {s.case}" if s.case else "") + f", {len(self.trials)} "
            f"trials ({n_pruned} pruned, {n_failed} failed), {n_feasible} feasible"
        )
        if len(s.objectives) > 1 and self.pareto:
            head += ", " + _front_words(len(self.pareto))
        lines = [head, search_space_lines(s, self.space, done=True)[0], "constraints: " + ", ".join(self.constraints)]
        lines += self._unsettled_lines()
        lines += self._flat_lines()
        if self.best is None:
            lines.append(
                f"no feasible design found{self._failed_constraints()} (widen the ranges, raise the budget or "
                "the horizon)"
            )
        else:
            t = self.trials[self.best]
            params = ", ".join(f"{p.name}={p.quantity(t['params'][p.name])}" for p in self.space)
            objs = ", ".join(f"{k}={self.objective_text(k, v)}" for k, v in t["objectives"].items())
            lines.append(f"best: trial {self.best}: {params}; {objs}" + (f" ({self.tie()})" if self.tie() else ""))
        return "\n".join(lines + [f"note: {n}" for n in self.notes])

    def settled(self, objective: str, value: float) -> bool | None:
        """Whether a settling objective's value is a settling time (True) or the never-settles score (False).

        Parameters
        ----------
        objective : str
            A name of :data:`~fsmctl.studies.tune.OBJECTIVES`.
        value : float
            Its value for a complete trial (aggregated over the ensemble).

        Returns
        -------
        bool or None
            ``value <= horizon_s`` for a settling objective (a settling time is within the horizon, the score of
            a run that never settles is at least twice it); None for the other objectives.
        """
        if OBJECTIVES[objective].metric is not None:
            return None
        return bool(value <= self.horizon_s)

    def objective_text(self, objective: str, value: float) -> str:
        """One objective's value with its unit, and for a run that did not settle what it was scored.

        Parameters
        ----------
        objective : str
            A name of :data:`~fsmctl.studies.tune.OBJECTIVES`.
        value : float
            Its value for a complete trial.

        Returns
        -------
        str
            ``"72.6 s"``, or ``"not settled within 100 s (scored 263 s = 2.63 x horizon)"``.
        """
        if self.settled(objective, value) is False:
            return (
                f"not settled within {self.horizon_s:g} s (scored {value:.6g} s = {value / self.horizon_s:.3g} x "
                "horizon)"
            )
        unit = OBJECTIVES[objective].unit
        return f"{value:.6g}" + (f" {unit}" if unit not in DIMENSIONLESS else "")  # "92", not "92 1" (a count)

    def _unsettled_lines(self) -> list[str]:
        """How many complete trials did not settle, and how such a trial is scored (one line per objective)."""
        done = [t for t in self.trials if t["state"] == "complete"]
        lines = []
        for name in self.settings.objectives:
            n = sum(self.settled(name, t["objectives"][name]) is False for t in done)
            if n:
                rule = UNSETTLED_RULE.format(
                    T=self.horizon_s, low=2 * self.horizon_s, high=3 * self.horizon_s, name=name
                )
                lines.append(f"{name}: {n} of {len(done)} complete trials {rule}")
        return lines

    def _failed_constraints(self) -> str:
        """``": of N complete trials, torque failed in 6, converged in 4"``: which constraints ruled the trials out
        (a value > 0, ``trials.csv``'s ``constraint_*`` columns), most often first; "" without complete trials."""
        done = [t for t in self.trials if t["state"] == "complete"]
        counts = [(c, sum(1 for t in done if (t["constraints"].get(c) or 0.0) > 0)) for c in self.constraints]
        failed = [f"{c} failed in {n}" for c, n in sorted(counts, key=lambda cn: -cn[1]) if n]
        return f": of {len(done)} complete trials, {', '.join(failed)}" if done and failed else ""

    def _flat_lines(self) -> list[str]:
        """An objective with the same value in every complete trial (two or more) told the designs apart nowhere: one
        line each (e.g. the peak torque at the torque limit in every design, or every settling score the maximum on a
        short horizon), so a search steered by nothing is not taken for a search that found nothing better."""
        done = [t for t in self.trials if t["state"] == "complete"]
        lines = []
        for name in self.settings.objectives:
            values = {t["objectives"][name] for t in done}
            if len(done) > 1 and len(values) == 1:
                lines.append(
                    f"{name}: {self.objective_text(name, values.pop())} in every one of the {len(done)} complete "
                    "trials: it did not tell the designs apart (other objectives, other ranges or a longer horizon "
                    "would)"
                )
        return lines

    def tie(self) -> str:
        """``"tied: ..."`` when every feasible trial (two or more) has the best one's value of every objective: the
        best is then the first of equals, no better than the others (the summary and ``best.toml`` say so); else
        ``""``.

        Returns
        -------
        str
            The sentence, or ``""``.
        """
        feasible = [t for t in self.trials if t["feasible"]]
        if self.best is None or len(feasible) < 2:
            return ""
        best = self.trials[self.best]["objectives"]
        if any(t["objectives"] != best for t in feasible):
            return ""
        return (
            f"tied: all {len(feasible)} feasible trials scored the same on every objective, so this one, the first "
            "feasible, is no better than the others"
        )

    def figure(self):
        """The figure of ``pareto.png``: every complete trial, the feasible ones, the non-dominated ones, the choice.

        One objective: the objective against the trial number (integer ticks); several: the first two objectives
        against each other, with the Pareto front drawn as a staircase when it has two or more trials (one
        non-dominated trial is a marker).  A settling objective's axis marks the horizon: a point beyond it did not
        settle and shows its score.

        Returns
        -------
        matplotlib.figure.Figure
            A figure not attached to pyplot.
        """
        return _figure(self)


UNSETTLED_RULE = (
    "not settled within the horizon T = {T:g} s: scored T * (2 + d), d = min(1, decades of the steady error above the "
    "tolerance), i.e. {low:g} to {high:g} s; trials.csv leaves the settling time empty and gives the score in "
    "{name}_score"
)
"""How a settling objective scores a run that never settles (:func:`~fsmctl.studies.tune.unsettled_score`), as the
summary and ``trials.csv`` state it."""


def _front_words(n: int) -> str:
    return "one non-dominated trial" if n == 1 else f"{n} non-dominated trials (the Pareto front)"


def pareto_front(trials: Sequence[dict], objectives: Sequence[str]) -> list[int]:
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


def _objective_columns(result: TuneResult, name: str) -> list[str]:
    """A settling objective has two columns (its settling time, empty when unsettled, and the value minimised)."""
    unit = OBJECTIVES[name].unit
    return (
        [f"{name} [{unit}]"] if OBJECTIVES[name].metric is not None else [f"{name} [{unit}]", f"{name}_score [{unit}]"]
    )


def _columns(result: TuneResult) -> list[str]:
    cols = ["trial", "state", "feasible"]
    cols += [p.column for p in result.space]
    for k in result.settings.objectives:
        cols += _objective_columns(result, k)
    cols += [f"constraint_{c} [{CONSTRAINTS[c][0]}]" for c in result.constraints]
    return [*cols, "pruned_at [s]", "error"]


def _row(result: TuneResult, t: dict) -> list:
    row: list[Any] = [t["index"], t["state"], int(t["feasible"])]
    row += [t["params"].get(p.name, "") for p in result.space]
    for k in result.settings.objectives:
        value = t["objectives"].get(k, "")
        settled = None if value == "" else result.settled(k, value)
        if OBJECTIVES[k].metric is None:
            row.append(value if settled else "")  # a settling time, or empty: never the penalty
        row.append(value)
    row += [t["constraints"].get(c, "") for c in result.constraints]
    return [*row, "" if t["pruned_at"] is None else t["pruned_at"], t["error"]]


def _csv_comments(result: TuneResult) -> list[str]:
    """What the columns of ``trials.csv`` / ``pareto.csv`` mean: the ``#`` lines above the header."""
    s, T = result.settings, result.horizon_s
    what = f"law {s.law} on {s.scenario}" + (f" case {s.case}" if s.case else "")
    aggregate = "" if s.ensemble == 1 else f"; values over {s.ensemble} members aggregated by quantile {s.quantile:g}"
    lines = [f"horizon T = {T:g} s, settling tolerance {s.tolerance_deg:g} deg{aggregate}"]
    lines.append("trial: the trial's number, in the order the search proposed them")
    rows = search_space_lines(s, result.space)[1:]  # "  name: low .. high unit, sampling (where the range comes from)"
    for p, row in zip(result.space, rows, strict=True):
        lines.append(f"{p.column}: searched, {row.split(': ', 1)[1]}")
    for k in s.objectives:
        o = OBJECTIVES[k]
        if o.metric is None:
            lines.append(f"{k} [{o.unit}]: {o.description}; empty when it did not settle within T")
            lines.append(
                f"{k}_score [{o.unit}]: the value minimised: the settling time, or for a run that did not settle "
                f"T * (2 + d), d = min(1, decades of the steady error above the tolerance): {2 * T:g} to {3 * T:g} s"
            )
        else:
            lines.append(f"{k} [{o.unit}]: {o.description} (minimised)")
    for c in result.constraints:
        lines.append(f"constraint_{c} [{CONSTRAINTS[c][0]}]: {CONSTRAINTS[c][1]}")
    lines.append("feasible: 1 when the trial is complete and every constraint is <= 0")
    lines.append("state: complete, pruned (stopped at pruned_at [s] by the pruner) or failed (see error)")
    lines.append("pruned_at [s]: the simulated time at which the pruner stopped a pruned trial; empty otherwise")
    lines.append("error: why a failed trial failed (the simulation's or the evaluation's message); empty otherwise")
    first = (
        f"fsmctl tune: trials of {what}; {len(lines) + 1} comment lines, then the header; read with "
        'pandas.read_csv(path, comment="#")'
    )
    return [f"# {line}" for line in (first, *lines)]


def _write_csv(path: Path, result: TuneResult, indices: Sequence[int]) -> None:
    from fsmctl.outputs import atomic_path

    with atomic_path(path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as f:
        f.write("\n".join(_csv_comments(result)) + "\n")
        w = csv.writer(f, lineterminator="\n")
        w.writerow(_columns(result))
        for i in indices:
            w.writerow(_row(result, result.trials[i]))


def _figure(result: TuneResult):
    from matplotlib.figure import Figure
    from matplotlib.ticker import MaxNLocator

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
    if len(objs) > 1:  # one objective has no front to draw: the chosen design is its best trial
        front = sorted(xy(result.trials[i]) for i in result.pareto)
        if len(front) > 1:
            ax.plot(
                *zip(*front, strict=True),
                color="C3",
                marker="o",
                drawstyle="steps-post",
                label=f"Pareto front ({len(front)} non-dominated feasible trials)",
            )
        elif front:
            ax.scatter(*front[0], s=40, color="C3", zorder=3, label="the one non-dominated feasible trial")
    if result.best is not None:
        ax.scatter(*xy(result.trials[result.best]), s=120, facecolor="none", edgecolor="k", label="chosen design")
    if len(objs) == 1:
        ax.set_xlabel("trial")
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        axes = {"y": objs[0]}
    else:
        axes = {"x": objs[0], "y": objs[1]}
    for side, name in axes.items():
        label = f"{name} [{OBJECTIVES[name].unit}]"
        if any(result.settled(name, t["objectives"][name]) is False for t in done):
            label += " (beyond the horizon: not settled, penalty score)"
            mark = ax.axhline if side == "y" else ax.axvline
            mark(
                result.horizon_s,
                color="0.3",
                linestyle=":",
                linewidth=1,
                label=f"horizon {result.horizon_s:g} s: beyond it not settled (scored 2-3 x horizon)",
            )
        (ax.set_ylabel if side == "y" else ax.set_xlabel)(label)
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


def _path_from(target: str, folder: Path | None) -> str:
    """``target`` (a file) as ``best.toml`` in ``folder`` names it: relative to ``folder`` when both lie under a
    common folder other than the file system's root (the output moves with the scenario), else absolute."""
    path = Path(target).expanduser().resolve()
    if folder is None:
        return str(path)
    folder = Path(folder).expanduser().resolve()
    common = Path(os.path.commonpath([path, folder]))
    if common == Path(common.anchor):
        return str(path)
    return Path(os.path.relpath(path, folder)).as_posix()


def _best_path_text(folder: str | Path | None) -> str:
    """``best.toml`` in ``folder`` as a command line would name it from where the study ran (``best.toml`` without
    a folder)."""
    return "best.toml" if folder is None else str(Path(folder) / "best.toml")


def best_scenario_text(
    result: TuneResult, base: Scenario, *, comments: Sequence[str] = (), folder: str | Path | None = None
) -> str:
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
    folder : str or Path, optional
        The folder the text is written to: the scenario file it ``extends`` and a law script are named relative to
        it when they share a folder other than the root (so the study's folder can move with them), else by
        absolute path (also without ``folder``).

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
    >>> for line in text.splitlines()[2:5]:  # at 1 s every design reaches the torque limit
    ...     print(line)
    # tied: all 2 feasible trials scored the same on every objective, so this one, the first feasible, is no better than the others
    # run it (from where the study ran): fsmctl simulate --scenario best.toml
    extends = "paper"
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
        law = _path_from(law, Path(folder) if folder is not None else None)
    controller: dict[str, Any] = {"law": law}
    for p in result.space:
        if not p.coupling:
            controller[p.name] = p.scenario_value(t["params"][p.name])
    overlay: dict[str, Any] = {"controller": controller}
    scales = coupling_scales(result.space, t["params"])
    if scales:
        overlay["topology"] = _topology_overlay(base, scales)
    if s.t_final is not None:
        overlay["simulation"] = {
            "t_final": base.simulation.t_final,
            "output_interval": base.simulation.output_interval,
        }
    extends = s.scenario if s.scenario in BUILTIN_SCENARIOS else _path_from(s.scenario, folder)
    cases = base.source.get("cases") or {}
    summary = ", ".join(f"{p.name} = {p.quantity(t['params'][p.name])}" for p in result.space)
    lines = [
        f"# written by fsmctl tune: trial {t['index']} of {len(result.trials)}, law {s.law}, seed {s.seed}",
        f"# {summary}",
        *([f"# {result.tie()}"] if result.tie() else []),
        *comments,
        f"# run it (from where the study ran): fsmctl simulate --scenario {_best_path_text(folder)}",
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
        at = next(i for i, line in enumerate(lines) if line.startswith("extends = ")) + 1
        lines.insert(at, f"description = {toml_value(f'{base.name}, tuned by fsmctl tune ({summary})')}")
        toml_table([], overlay, lines)
    return "\n".join(lines) + "\n"


def _same_design(a: Scenario, b: Scenario) -> bool:
    """Whether two scenarios fly the same design: equal sections, the law compared as the law read (a relative
    and an absolute path to one script are one law)."""
    keys = ("agents", "reference", "topology", "simulation", "actuator", "sensors", "links")
    if not all(getattr(a, k) == getattr(b, k) for k in keys) or a.law.folder != b.law.folder:
        return False
    return dataclasses.replace(a.controller, law=b.controller.law) == b.controller


def write_outputs(result: TuneResult, base: Scenario, out: Path, expected: Scenario | None, extra: dict) -> None:
    import optuna

    from fsmctl.model.scenario import load_scenario
    from fsmctl.outputs import atomic_path, write_json, write_text
    from fsmctl.simulation.results_io import versions

    paths = [out / STUDY_FILE, out / "trials.csv", out / "pareto.csv", out / "pareto.png"]  # every file written
    _write_csv(paths[1], result, range(len(result.trials)))
    _write_csv(paths[2], result, result.pareto)
    fig = result.figure()
    with atomic_path(paths[3]) as tmp:
        fig.savefig(tmp, format="png", dpi=120)
    best: dict[str, Any] | None = None
    if result.best is not None:
        path = out / "best.toml"
        provenance = [
            f"# versions: {', '.join(f'{k} {v}' for k, v in versions().items())}, optuna {optuna.__version__}"
        ]
        if extra.get("command"):
            provenance.append(f"# command: {extra['command']}")
        write_text(path, best_scenario_text(result, base, comments=provenance, folder=out))
        paths.append(path)
        with warnings.catch_warnings():  # best.toml flies the tuned law over the base scenario's: as intended
            warnings.simplefilter("ignore", LawSwitchWarning)
            verified = expected is not None and _same_design(load_scenario(path), expected)
        if not verified:
            result.notes.append(
                f"{path} does not reproduce the chosen design exactly (the base scenario's agents or cases override "
                "it); the design is in tune.json"
            )
        t = result.trials[result.best]
        best = {**t, "scenario_file": "best.toml", "scenario_file_verified": verified, "tie": result.tie()}
    payload = {
        "settings": asdict(result.settings),
        "versions": {**versions(), "optuna": optuna.__version__},
        "scenario": base.label,
        "horizon_s": base.simulation.t_final,
        "torque_limit_N_m": base.controller.torque_limit,
        "search_space": [asdict(p) for p in result.space],
        "objectives": {
            k: {"unit": OBJECTIVES[k].unit, "description": OBJECTIVES[k].description}
            for k in result.settings.objectives
        },
        "constraints": {c: {"unit": CONSTRAINTS[c][0], "description": CONSTRAINTS[c][1]} for c in result.constraints},
        "theorem1_holds": result.theorem1,
        **extra,
        "trials": len(result.trials),
        "pruned": sum(t["state"] == "pruned" for t in result.trials),
        "failed": sum(t["state"] == "failed" for t in result.trials),
        "feasible": sum(t["feasible"] for t in result.trials),
        "pareto": result.pareto,
        "not_settled": {
            k: UNSETTLED_RULE.format(T=result.horizon_s, low=2 * result.horizon_s, high=3 * result.horizon_s, name=k)
            for k in result.settings.objectives
            if OBJECTIVES[k].metric is None
        },
        "best": best,
        "notes": result.notes,
    }
    paths.append(write_json(out / "tune.json", payload))
    result.paths = paths
