"""Tune a law's declared parameters for designs that work under the scenario's actuator limits (``fsmctl tune``).

A search is an `Optuna <https://optuna.org>`_ study over the law's declared tunable parameters, each within its
declared range (:func:`search_space`); every candidate is flown on the scenario (or a seeded ensemble drawn from it)
by the compiled simulator, with the scenario's torque limit applied, and scored by the chosen objectives (all
minimised), aggregated over the ensemble by a quantile.

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

Constraints (Optuna's ``Trial.set_constraint``: a trial is feasible when every value is ``<= 0``):

* ``converged`` (s): ``max(aaem_settling, raem_settling) - T``, aggregated like the objectives: feasible when both
  metrics settle within the horizon (for the quantile member of the ensemble);
* ``theorem1`` (only for the ``fsm`` law): 0 when Theorem 1's topology conditions hold for the scenario's topology
  over its horizon (:func:`fsmctl.proofs.theorem1.analyze_topology`), 1 when they do not.  They do not depend on the
  tuned parameters, so either every trial meets them or none does; the latter is reported once
  (:attr:`TuneResult.notes`).

Ensemble (``TuneSettings.ensemble``): 1 flies the scenario itself; ``M > 1`` flies ``M`` members drawn as Monte Carlo
runs are (:func:`fsmctl.studies.montecarlo.sample_run_scenario` with the default
:class:`~fsmctl.studies.montecarlo.CampaignSettings` sampling ranges, member ``m`` from
``SeedSequence(seed).spawn(M)[m]``); every candidate meets the same members.  The aggregate of a value over the
members is ``numpy.quantile(values, quantile, method="higher")``: 1.0 is the worst member, 0.5 the median (rounded
up to a member's value).

Search space: each parameter's declared range, or the ``ranges`` override (which must lie within the declared
range); a side the law leaves unbounded must be given by ``ranges``.  A range with ``low > 0`` and
``high / low >= 100`` is searched log-uniformly, any other uniformly; an exclusive declared bound is moved inwards
by one floating-point step.  A vector parameter (``delta``: one value per axis) is searched as one scalar applied
to every component (and, for ``delta``, to every agent).  Parameters with named options (``singularity_fix``) are
not searched.

Determinism and resumption: trials run one after another; trial ``i`` is proposed by a sampler seeded from
``(seed, i)`` (``TPESampler`` for one objective, ``NSGAIISampler`` with a population of :data:`POPULATION` for
several) reading the earlier trials from the journal ``study.log``, so the same settings give the same trials, and
an interrupted study resumed (``resume=True``) continues to ``budget`` trials exactly as an uninterrupted one would.
A trial interrupted mid-flight is discarded and flown again.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import re
import sys
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from fsmctl.errors import InputError
from fsmctl.model.scenario import Scenario

__all__ = [
    "OBJECTIVES",
    "POPULATION",
    "SearchParameter",
    "TuneSettings",
    "TuneResult",
    "search_space",
    "tune",
    "unsettled_score",
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

_METRIC = {
    "aaem_steady": "aaem_steady_max_deg",
    "raem_steady": "raem_steady_max_deg",
    "peak_torque": "peak_torque_N_m",
    "rms_torque": "rms_torque_N_m",
    "chattering": "chattering_N_m_per_s",
    "wheel_momentum": "peak_wheel_momentum_N_m_s",
}

POPULATION = 24
"""population size of the NSGA-II sampler (fixed, so a resumed study proposes what an uninterrupted one would)"""

LOG_RATIO = 100.0
"""a range with ``low > 0`` and ``high / low >= LOG_RATIO`` is searched log-uniformly"""

STUDY_NAME = "fsmctl-tune"
STUDY_FILE = "study.log"


# ----------------------------------------------------------------------------- settings


@dataclass(frozen=True)
class TuneSettings:
    """What to tune, how hard, and how candidates are scored (see the module docstring).

    ``ranges``: ``(name, low, high)`` triples (or a mapping ``name -> (low, high)``) overriding declared ranges.
    ``parameters``: names to search; empty = every tunable numeric parameter of the law.  ``t_final`` (s): the
    horizon, None = the scenario's.  ``tolerance_deg``: the settling tolerance of AAEM and RAEM.
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

    def __post_init__(self) -> None:
        if isinstance(self.objectives, str):
            object.__setattr__(self, "objectives", tuple(x.strip() for x in self.objectives.split(",")))
        else:
            object.__setattr__(self, "objectives", tuple(self.objectives))
        if isinstance(self.parameters, str):
            object.__setattr__(self, "parameters", tuple(x.strip() for x in self.parameters.split(",") if x.strip()))
        else:
            object.__setattr__(self, "parameters", tuple(self.parameters))
        ranges = self.ranges
        if isinstance(ranges, Mapping):
            ranges = tuple((k, *v) if isinstance(v, (list, tuple)) else (k, v) for k, v in ranges.items())
        object.__setattr__(self, "ranges", tuple(tuple(r) for r in ranges))
        object.__setattr__(self, "scenario", str(self.scenario))
        object.__setattr__(self, "law", str(self.law))

    def validate(self) -> None:
        """Raise :class:`~fsmctl.errors.InputError` (one line naming the setting) on a bad setting, an unknown law or
        parameter, or a range that cannot be searched."""

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
        search_space(self)

    def identity(self) -> dict:
        """Everything that determines the trials except the budget (a resumed study must match it)."""
        out = asdict(self)
        out.pop("budget")
        return json.loads(json.dumps(out))


@dataclass(frozen=True)
class SearchParameter:
    """One searched parameter: ``[low, high]`` in ``unit``, log-uniform or uniform; ``size`` components set alike."""

    name: str
    unit: str
    low: float
    high: float
    log: bool
    size: int

    @property
    def column(self) -> str:
        return f"{self.name} [{self.unit}]"

    def scenario_value(self, value: float) -> float | list[float]:
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


def search_space(settings: TuneSettings) -> list[SearchParameter]:
    """The searched parameters of ``settings.law`` with their ranges (see the module docstring).

    Raises
    ------
    InputError
        Unknown law or parameter, a parameter with options or not tunable, an override outside the declared range,
        or a side left unbounded by both the law and ``ranges``.
    """
    from fsmctl.model.laws import resolve_law

    law = resolve_law(settings.law)
    declared = {p.name: p for p in law.parameters}
    given = _ranges(settings)
    names = list(settings.parameters) or [p.name for p in law.parameters if p.tunable and not p.choices]
    if len(set(names)) != len(names):
        raise InputError(f"tune: parameters: each may be named once, got {','.join(names)}")
    if not names:
        raise InputError(f"tune: the law {law.name!r} declares no tunable numeric parameter")
    for name in [*names, *given]:
        if name not in declared:
            raise InputError(
                f"tune: the law {law.name!r} has no parameter {name!r} (its parameters: {', '.join(declared)})"
            )
    extra = sorted(set(given) - set(names))
    if extra:
        raise InputError(
            f"tune: a range is given for {extra[0]!r}, which is not searched (parameters: {', '.join(names)})"
        )
    out = []
    for name in names:
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


def unsettled_score(t_final: float, steady_max_deg: float, tolerance_deg: float) -> float:
    """The score of a metric that never settles within the horizon ``t_final`` (see the module docstring).

    Examples
    --------
    >>> unsettled_score(10.0, 1.0, 1.0), unsettled_score(10.0, 100.0, 1.0), unsettled_score(10.0, float("nan"), 1.0)
    (20.0, 30.0, 30.0)
    """
    ratio = steady_max_deg / tolerance_deg
    decades = 1.0 if not math.isfinite(ratio) else min(1.0, max(0.0, math.log10(max(ratio, 1e-300))))
    return float(t_final) * (2.0 + decades)


# ----------------------------------------------------------------------------- evaluation


def _member_scores(metrics: Mapping[str, float], objectives: Sequence[str], t_final: float, tol: float) -> list[float]:
    """``[*objectives, converged]`` of one run."""
    settle = {}
    for which in ("aaem", "raem"):
        t = metrics[f"{which}_settling_{tol:g}deg_s"]
        settle[which] = t if math.isfinite(t) else unsettled_score(t_final, metrics[f"{which}_steady_max_deg"], tol)
    values = [settle[name[:4]] if name.endswith("_settling") else metrics[_METRIC[name]] for name in objectives]
    return [*values, max(settle.values()) - t_final]


def _quantile(values: Sequence[float], q: float) -> float:
    return float(np.quantile(np.asarray(values, dtype=float), q, method="higher"))


def _trial_scenario(member: Scenario, settings: TuneSettings, space: Sequence[SearchParameter], values: Mapping):
    from fsmctl.studies.compare import LawRun, run_scenario

    params = {p.name: p.scenario_value(values[p.name]) for p in space}
    return run_scenario(member, LawRun("tune", settings.law, params))


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


# ----------------------------------------------------------------------------- result


@dataclass
class TuneResult:
    """A finished (or resumed and finished) search: every trial, the feasible Pareto front and the chosen design.

    ``trials``: one dict per trial in order (``index``, ``state`` "complete" | "failed", ``feasible``,
    ``params`` by name, ``objectives`` by name, ``constraints`` by name, ``error``).  ``pareto``: indices of the
    feasible non-dominated trials.  ``best``: index of the feasible trial with the smallest first objective (None:
    no feasible trial).  ``paths``: the files written.  ``notes``: what the user must know (one line each).
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
        s = self.settings
        n_feasible = sum(t["feasible"] for t in self.trials)
        lines = [
            f"tune: law {s.law} on {s.scenario}" + (f" case {s.case}" if s.case else "") + f", {len(self.trials)} "
            f"trials, {n_feasible} feasible, {len(self.pareto)} on the Pareto front"
        ]
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
    cols += [f"constraint_{c} [{'s' if c == 'converged' else '1'}]" for c in result.constraints]
    return [*cols, "error"]


def _row(result: TuneResult, t: dict) -> list:
    row: list[Any] = [t["index"], t["state"], int(t["feasible"])]
    row += [t["params"].get(p.name, "") for p in result.space]
    row += [t["objectives"].get(k, "") for k in result.settings.objectives]
    row += [t["constraints"].get(c, "") for c in result.constraints]
    return [*row, t["error"]]


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
    ax.set_title(
        f"fsmctl tune: {s.law} on {Path(s.scenario).name}" + (f" case {s.case}" if s.case else ""), fontsize=10
    )
    if ax.has_data():
        ax.legend(fontsize=8)
    return fig


_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def _toml_key(k: str) -> str:
    return k if _BARE.match(k) else json.dumps(k)


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        x = float(v)
        if math.isnan(x):
            return "nan"
        return repr(x) if math.isfinite(x) else ("inf" if x > 0 else "-inf")
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, Mapping):
        return "{ " + ", ".join(f"{_toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) + " }"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise InputError(f"cannot write {v!r} to a scenario file")


def _toml_table(path: Sequence[str], table: Mapping, lines: list[str]) -> None:
    scalars = {k: v for k, v in table.items() if not isinstance(v, Mapping)}
    tables = {k: v for k, v in table.items() if isinstance(v, Mapping)}
    if path and (scalars or not tables):
        lines += ["", "[" + ".".join(_toml_key(k) for k in path) + "]"]
    lines += [f"{_toml_key(k)} = {_toml_value(v)}" for k, v in scalars.items()]
    for k, v in tables.items():
        _toml_table([*path, k], v, lines)


def _merge(base: dict, over: Mapping) -> dict:
    out = dict(base)
    for k, v in over.items():
        out[k] = _merge(out[k], v) if isinstance(v, Mapping) and isinstance(out.get(k), Mapping) else v
    return out


def best_scenario_text(result: TuneResult, base: Scenario) -> str:
    """``best.toml``: the base scenario (``extends``) with the chosen design, for ``fsmctl simulate --scenario``.

    The design (``[controller]`` keys: the law, its tuned parameters; the horizon when ``t_final`` was set) goes
    where loading the file applies it last: the table of the scenario's first case when it has cases (loading a
    file without ``--case`` selects its first case), with the tuned case's own overrides copied there when the tuned
    case is another one; else the top-level tables.
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
        controller[p.name] = p.scenario_value(t["params"][p.name])
    overlay: dict[str, Any] = {"controller": controller}
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
        "# run it: fsmctl simulate --scenario best.toml",
        f"extends = {_toml_value(extends)}",
        f"name = {_toml_value(f'{base.name}-tuned')}",
    ]
    if cases and base.case is not None:
        first = next(iter(cases))
        own = {k: v for k, v in dict(cases[base.case]).items() if k != "description"} if base.case != first else {}
        table = _merge(own, overlay)
        table = {"description": f"case {base.case} of {base.name}, tuned by fsmctl tune ({summary})", **table}
        _toml_table(["cases", first], table, lines)
    else:
        lines.insert(4, f"description = {_toml_value(f'{base.name}, tuned by fsmctl tune ({summary})')}")
        _toml_table([], overlay, lines)
    return "\n".join(lines) + "\n"


def _same_design(a: Scenario, b: Scenario) -> bool:
    keys = ("agents", "reference", "topology", "controller", "simulation", "actuator", "sensors", "links")
    return all(getattr(a, k) == getattr(b, k) for k in keys)


def _write_outputs(result: TuneResult, base: Scenario, out: Path, expected: Scenario | None) -> None:
    import optuna

    from fsmctl import __version__
    from fsmctl.model.scenario import load_scenario
    from fsmctl.outputs import atomic_path, write_json, write_text

    paths = [out / "trials.csv", out / "pareto.csv", out / "pareto.png"]
    _write_csv(paths[0], result, range(len(result.trials)))
    _write_csv(paths[1], result, result.pareto)
    fig = _figure(result)
    with atomic_path(paths[2]) as tmp:
        fig.savefig(tmp, format="png", dpi=120)
    best: dict[str, Any] | None = None
    if result.best is not None:
        path = out / "best.toml"
        write_text(path, best_scenario_text(result, base))
        paths.append(path)
        verified = expected is not None and _same_design(load_scenario(path), expected)
        if not verified:
            result.notes.append(
                f"{path} does not reproduce the chosen design exactly (the base scenario's agents or cases override "
                "it); the design is in tune.json"
            )
        t = result.trials[result.best]
        best = {**t, "scenario_file": "best.toml", "scenario_file_verified": verified}
    n_feasible = sum(t["feasible"] for t in result.trials)
    payload = {
        "settings": asdict(result.settings),
        "versions": {
            "fsmctl": __version__,
            "optuna": optuna.__version__,
            "numpy": np.__version__,
            "python": sys.version.split()[0],
        },
        "scenario": base.label,
        "horizon_s": base.simulation.t_final,
        "torque_limit_N_m": base.controller.torque_limit,
        "search_space": [asdict(p) for p in result.space],
        "objectives": {
            k: {"unit": OBJECTIVES[k][0], "description": OBJECTIVES[k][1]} for k in result.settings.objectives
        },
        "constraints": list(result.constraints),
        "theorem1_holds": result.theorem1,
        "trials": len(result.trials),
        "feasible": n_feasible,
        "pareto": result.pareto,
        "best": best,
        "notes": result.notes,
    }
    paths.append(write_json(out / "tune.json", payload))
    result.paths = paths


# ----------------------------------------------------------------------------- the search


def _trial_seed(seed: int, index: int) -> int:
    return int(np.random.SeedSequence([seed, index]).generate_state(1, np.uint32)[0])


def _sampler(n_objectives: int, seed: int):
    """Optuna >= 5: the samplers read the constraints a trial sets (``Trial.set_constraint``)."""
    import optuna

    if n_objectives == 1:
        return optuna.samplers.TPESampler(seed=seed)
    return optuna.samplers.NSGAIISampler(seed=seed, population_size=POPULATION)


def _counted(trial) -> bool:
    from optuna.trial import TrialState

    if trial.state == TrialState.COMPLETE:
        return True
    return trial.state == TrialState.FAIL and "simulation_error" in trial.user_attrs


def tune(
    settings: TuneSettings, out_dir: str | Path, *, resume: bool = False, progress: bool | None = None
) -> TuneResult:
    """Search ``settings.law``'s parameters on ``settings.scenario`` and write the results to ``out_dir``.

    Writes ``study.log`` (Optuna's journal; ``resume=True`` continues it to ``settings.budget`` trials in total),
    ``trials.csv`` (every trial: parameters, objectives, constraints, state), ``pareto.csv`` (the feasible
    non-dominated trials), ``pareto.png``, ``best.toml`` (the feasible trial with the smallest first objective, as a
    scenario file; not written when no trial is feasible) and ``tune.json`` (settings, versions, best).

    Raises
    ------
    InputError
        Bad settings, an existing study without ``resume``, a resumed study with other settings, or an objective the
        scenario cannot measure (``wheel_momentum`` without wheels).
    """
    import optuna
    from optuna.storages import JournalStorage
    from optuna.storages.journal import JournalFileBackend
    from optuna.trial import TrialState

    from fsmctl.outputs import output_folder
    from fsmctl.simulation.simulator import SimulationError, simulate
    from fsmctl.studies.compare import run_metrics

    settings.validate()
    space = search_space(settings)
    base = _base_scenario(settings)
    settings = dataclasses.replace(settings, case=base.case)
    if "wheel_momentum" in settings.objectives and not base.actuator.enabled:
        raise InputError(f"tune: objective wheel_momentum needs a scenario with reaction wheels; {base.label} has none")
    _trial_scenario(base, settings, space, {p.name: p.low for p in space})  # the law and its values fit the scenario
    members = _members(base, settings)
    t_final, tol, q = base.simulation.t_final, settings.tolerance_deg, settings.quantile
    notes: list[str] = []
    constraints = ["converged"]
    theorem1: bool | None = None
    if _law_name(settings.law) == "fsm":
        from fsmctl.proofs.theorem1 import analyze_topology

        theorem1 = bool(analyze_topology(base.topology, t_final).holds)
        constraints.append("theorem1")
        if not theorem1:
            notes.append(
                f"Theorem 1's topology conditions fail for {base.label} (`fsmctl prove theorem1-gains` explains); "
                "they do not depend on the tuned parameters, so every trial is infeasible"
            )
    out = Path(out_dir)
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
                storage = JournalStorage(JournalFileBackend(str(log)))
                study = optuna.create_study(
                    study_name=STUDY_NAME,
                    storage=storage,
                    directions=["minimize"] * len(settings.objectives),
                    load_if_exists=True,
                )
                identity = settings.identity()
                if "settings" in study.user_attrs:
                    if study.user_attrs["settings"] != identity:
                        old = study.user_attrs["settings"]
                        diff = sorted(k for k in set(old) | set(identity) if old.get(k) != identity.get(k))
                        raise InputError(
                            f"tune: the study in {out} was run with other settings ({', '.join(diff)}); resume it "
                            "with the same ones or choose another --out"
                        )
                else:
                    study.set_user_attr("settings", identity)
                for t in study.get_trials(deepcopy=False):  # trials cut off by an interruption are flown again
                    if not _counted(t) and t.state in (TrialState.RUNNING, TrialState.WAITING):
                        storage.set_trial_state_values(t._trial_id, TrialState.FAIL)

                def objective(trial) -> tuple[float, ...]:
                    values = {p.name: trial.suggest_float(p.name, p.low, p.high, log=p.log) for p in space}
                    scores = []
                    try:
                        for member in members:
                            result = simulate(_trial_scenario(member, settings, space, values), progress=False)
                            m = run_metrics(result, tolerances_deg=(tol,))
                            scores.append(_member_scores(m, settings.objectives, t_final, tol))
                    except SimulationError as exc:
                        trial.set_user_attr("simulation_error", " ".join(str(exc).split()))
                        return tuple(math.nan for _ in settings.objectives)
                    agg = [_quantile(col, q) for col in zip(*scores, strict=True)]
                    cons = [agg[-1]] + ([0.0 if theorem1 else 1.0] if theorem1 is not None else [])
                    for name, value in zip(constraints, cons, strict=True):
                        trial.set_constraint(name, value)
                    trial.set_user_attr("members", scores)
                    return tuple(agg[:-1])

                done = sum(_counted(t) for t in study.get_trials(deepcopy=False))
                bar = None
                show = sys.stderr.isatty() if progress is None else progress
                if show and done < settings.budget:
                    from tqdm.auto import tqdm

                    bar = tqdm(total=settings.budget, initial=done, desc="tune", unit="trial", file=sys.stderr)
                try:
                    while done < settings.budget:
                        study.sampler = _sampler(len(settings.objectives), _trial_seed(settings.seed, done))
                        study.optimize(objective, n_trials=1, n_jobs=1, catch=())
                        done = sum(_counted(t) for t in study.get_trials(deepcopy=False))
                        if bar is not None:
                            bar.update(done - bar.n)
                finally:
                    if bar is not None:
                        bar.close()
                trials = [t for t in study.get_trials(deepcopy=False) if _counted(t)]
        finally:
            optuna.logging.set_verbosity(level)
        rows = []
        for index, t in enumerate(trials[: settings.budget]):
            complete = t.state == TrialState.COMPLETE
            cons = {c: float(t.constraints.get(c, math.inf)) for c in constraints}
            rows.append(
                {
                    "index": index,
                    "state": "complete" if complete else "failed",
                    "feasible": complete and all(v <= 0 for v in cons.values()),
                    "params": {p.name: float(t.params[p.name]) for p in space if p.name in t.params},
                    "objectives": dict(zip(settings.objectives, t.values, strict=True)) if complete else {},
                    "constraints": cons,
                    "error": t.user_attrs.get("simulation_error", ""),
                }
            )
        pareto = _pareto(rows, settings.objectives)
        feasible = [r for r in rows if r["feasible"]]
        best = (
            min(feasible, key=lambda r: (r["objectives"][settings.objectives[0]], r["index"]))["index"]
            if feasible
            else None
        )
        result = TuneResult(settings, space, tuple(constraints), rows, pareto, best, theorem1, notes)
        expected = None
        if best is not None:
            expected = _trial_scenario(base, settings, space, rows[best]["params"])
        _write_outputs(result, base, out, expected)
    return result


def _law_name(law: str) -> str:
    """The resolved name of a law spec (``fsm`` for the built-in FSM law)."""
    from fsmctl.model.laws import resolve_law

    return resolve_law(law).name
