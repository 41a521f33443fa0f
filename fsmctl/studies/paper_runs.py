"""The runs of ``fsmctl reproduce``: the paper's Cases 1, 2, 3a-3c and the diagnostic runs, and how one is flown.

:func:`run_plan` lists the runs (:class:`RunSpec`: a paper case plus overrides); :func:`run_scenario` builds the
scenario a run flies from a source (``"paper"``, a scenario file or its mapping); :func:`execute_run` simulates it,
saves its NetCDF file and single-run figures and returns its :class:`~fsmctl.studies.records.RunRecord`
(:func:`run_record`).  The claims read these records (:mod:`fsmctl.studies.claims`).
"""

from __future__ import annotations

import math
import time as _time
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fsmctl.policy import (
    FAST_OUTPUT_INTERVAL_S,
    FAST_T_FINAL_S,
    LONG_HORIZON_FACTOR,
    SETTLING_TOLERANCES_DEG,
    default_steady_window,
)
from fsmctl.studies.records import RunRecord

__all__ = [
    "PAPER_CASES",
    "DIAGNOSTIC_OUTPUT_INTERVAL_S",
    "RunSpec",
    "run_plan",
    "load_case",
    "run_scenario",
    "scenario_overrides",
    "run_overrides",
    "run_record",
    "execute_run",
]

PAPER_CASES = ("1", "2", "3a", "3b", "3c")
DIAGNOSTIC_OUTPUT_INTERVAL_S = 0.02
"""Output grid of the diagnostic runs (the paper cases keep the scenario's; the integration step is unchanged)."""

# ----------------------------------------------------------------------------- the runs


@dataclass(frozen=True)
class RunSpec:
    """One simulation of the reproduction: a paper case plus overrides.

    Parameters
    ----------
    key : str
        File-safe name (``case1``, ``case1_no_torque_limit``, ...).
    case : str
        Paper case (``"1"``, ``"2"``, ``"3a"``, ``"3b"``, ``"3c"``).
    title : str
        Short human-readable name.
    purpose : str
        What the run shows.
    controller : tuple of (name, value)
        Overrides of :class:`~fsmctl.model.scenario.ControllerSettings`.
    simulation : tuple of (name, value)
        Overrides of :class:`~fsmctl.model.scenario.SimulationSettings`.
    horizon_factor : float
        Multiple of the scenario's ``t_final``.
    figures : tuple of str
        Single-run figures rendered by the worker: ``aaem``, ``raem``, ``theta_e``, ``torques``,
        ``torques_commanded``.

    Examples
    --------
    >>> spec = RunSpec("case1_no_torque_limit", "1", "Case 1, no torque limit", "the law without saturation",
    ...                controller=(("torque_limit", float("inf")),))
    >>> spec.controller
    (('torque_limit', inf),)

    What the run changes in its case, the diagnostic runs' output grid included, is :func:`run_overrides`.
    """

    key: str
    case: str
    title: str
    purpose: str
    controller: tuple[tuple[str, Any], ...] = ()
    simulation: tuple[tuple[str, Any], ...] = ()
    horizon_factor: float = 1.0
    figures: tuple[str, ...] = ()


def run_plan() -> tuple[RunSpec, ...]:
    """The runs of ``fsmctl reproduce``: the five paper cases and the diagnostic runs.

    Returns
    -------
    tuple of RunSpec
        Cases 1, 2, 3a-3c (Liang et al. 2012, Sec. 4) as specified, then the diagnostics.

    Examples
    --------
    >>> plan = run_plan()
    >>> [spec.key for spec in plan[:5]]
    ['case1', 'case2', 'case3a', 'case3b', 'case3c']
    >>> plan[0].figures  # the single-run analogues of Figs 1-4
    ('aaem', 'raem', 'theta_e', 'torques')
    >>> len(plan), plan[-1].key, plan[-1].horizon_factor
    (14, 'case2_long', 3.0)
    """
    inf = math.inf
    return (
        RunSpec(
            "case1", "1", "Case 1", "the paper's main case (Figs 1-4)", figures=("aaem", "raem", "theta_e", "torques")
        ),
        RunSpec("case2", "2", "Case 2", "no coordination (Figs 5-7)", figures=("theta_e",)),
        RunSpec("case3a", "3a", "Case 3a", "weights k^i = 2, k^j = 0.6 (Figs 8-9)"),
        RunSpec("case3b", "3b", "Case 3b", "weights k^i = 4, k^j = 2.8 (Figs 8-9)"),
        RunSpec("case3c", "3c", "Case 3c", "weights k^i = 8, k^j = 5 (Figs 8-9)"),
        RunSpec(
            "case1_exact_error_model",
            "1",
            "Case 1, exact error model",
            "controller with the exact error kinematics instead of the paper's eqs 7-8",
            controller=(("error_model", "exact"),),
        ),
        RunSpec(
            "case1_no_torque_limit",
            "1",
            "Case 1, no torque limit",
            "the same law without the 2 N m saturation",
            controller=(("torque_limit", inf),),
            figures=("torques_commanded",),
        ),
        RunSpec(
            "case2_no_torque_limit",
            "2",
            "Case 2, no torque limit",
            "Case 2 without the 2 N m saturation",
            controller=(("torque_limit", inf),),
        ),
        RunSpec(
            "case1_pure_sgn",
            "1",
            "Case 1, pure sgn",
            "sgn(s) instead of the boundary layer (Remark 7)",
            controller=(("boundary_layer", 0.0),),
        ),
        RunSpec(
            "case3a_no_torque_limit",
            "3a",
            "Case 3a, no torque limit",
            "weight ordering without saturation",
            controller=(("torque_limit", inf),),
        ),
        RunSpec(
            "case3b_no_torque_limit",
            "3b",
            "Case 3b, no torque limit",
            "weight ordering without saturation",
            controller=(("torque_limit", inf),),
        ),
        RunSpec(
            "case3c_no_torque_limit",
            "3c",
            "Case 3c, no torque limit",
            "weight ordering without saturation",
            controller=(("torque_limit", inf),),
        ),
        RunSpec(
            "case1_long",
            "1",
            "Case 1, long horizon",
            "does Case 1 converge at all with the torque limit?",
            horizon_factor=LONG_HORIZON_FACTOR,
        ),
        RunSpec(
            "case2_long",
            "2",
            "Case 2, long horizon",
            "when does Case 2 converge with the torque limit?",
            horizon_factor=LONG_HORIZON_FACTOR,
        ),
    )


def load_case(source: str | Mapping[str, Any], case: str):
    """The scenario of one paper case from a source: ``"paper"``, a TOML file, or the mapping of a TOML file.

    Parameters
    ----------
    source : str or mapping
        ``"paper"``, a scenario TOML file, or a parsed TOML mapping (e.g. ``{"extends": "paper", "controller":
        {...}}``: what an explanation's evidence file holds, :mod:`fsmctl.studies.explain`).
    case : str
        The case (``"1"``, ``"2"``, ``"3a"``, ...).

    Returns
    -------
    Scenario
        Validated.

    Examples
    --------
    >>> load_case("paper", "3a").controller.torque_limit
    2.0
    >>> load_case({"extends": "paper", "controller": {"torque_limit": 5.0}}, "1").controller.torque_limit
    5.0
    """
    from fsmctl.model.scenario import load_scenario, scenario_from_dict

    if isinstance(source, Mapping):
        return scenario_from_dict(dict(source), case=case, where="scenario")
    return load_scenario(source, case=case)


def _scenario_for(source: str | Mapping[str, Any], spec: RunSpec, fast: bool):
    scenario = load_case(source, spec.case)
    sim = dict(spec.simulation)
    t_final = FAST_T_FINAL_S if fast else scenario.simulation.t_final
    sim.setdefault("t_final", t_final * spec.horizon_factor)
    if fast:
        sim.setdefault("output_interval", max(FAST_OUTPUT_INTERVAL_S, scenario.simulation.output_interval))
    elif spec.key not in _PAPER_RUNS:
        # diagnostic runs: a coarser output grid (the loop step is unchanged) keeps the eq 43 pair metric cheap
        coarse = DIAGNOSTIC_OUTPUT_INTERVAL_S * (2.5 if spec.horizon_factor > 1 else 1.0)
        dt = float(sim.get("dt", scenario.simulation.dt))
        sim.setdefault("output_interval", max(dt * max(1, round(coarse / dt)), scenario.simulation.output_interval))
    return scenario.replace(controller=dict(spec.controller), simulation=sim)


_PAPER_RUNS = tuple(f"case{c}" for c in PAPER_CASES)


def run_scenario(source: str | Mapping[str, Any], spec: RunSpec, fast: bool):
    """The scenario a :class:`RunSpec` flies: the case of ``source`` with the spec's overrides and horizon.

    Parameters
    ----------
    source : str or mapping
        As :func:`load_case`.
    spec : RunSpec
        The run.
    fast : bool
        Short horizon (:data:`fsmctl.policy.FAST_T_FINAL_S`) and coarser output.

    Returns
    -------
    Scenario
        Validated (the paper's J0_4 inertia warning is silenced: the report's inertia check covers it).

    Examples
    --------
    >>> spec = run_plan()[-2]  # Case 1 on three times the horizon
    >>> spec.key, run_scenario("paper", spec, fast=False).simulation.t_final
    ('case1_long', 300.0)
    >>> run_scenario("paper", spec, fast=True).simulation.t_final  # fast mode: 10 s, x3
    30.0
    """
    from fsmctl.model.scenario import InertiaWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaWarning)  # reported in the report's inertia check instead
        return _scenario_for(source, spec, fast)


def _flat(value: Any, path: tuple = ()) -> dict[tuple, Any]:
    if isinstance(value, Mapping):
        return {k: v for key, item in value.items() for k, v in _flat(item, (*path, key)).items()}
    if isinstance(value, list) and value and all(isinstance(v, Mapping) for v in value):
        return {k: v for i, item in enumerate(value) for k, v in _flat(item, (*path, i + 1)).items()}
    return {path: value}


def _value_text(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.15g}"
    if isinstance(value, list):
        return "[" + ", ".join(_value_text(v) for v in value) + "]"
    return str(value)


def scenario_overrides(case, flown) -> str:
    """What a flown scenario changes in its case: ``name=value`` of every differing setting (one rule for every run).

    The settings are those that decide the run (:data:`~fsmctl.studies.records.FLOWN_SECTIONS`, as
    :meth:`~fsmctl.model.scenario.Scenario.to_dict` spells them out); a setting is named by its key, or by its
    path below the section (``agents.2.sigma0``) where the key alone is ambiguous.  Floats are written with 15
    significant digits (``repr``'s noise dropped, a real difference kept).

    Parameters
    ----------
    case : Scenario
        The case as its source gives it (:func:`load_case`).
    flown : Scenario
        The scenario the run flies (:func:`run_scenario`).

    Returns
    -------
    str
        ``"torque_limit=inf, output_interval=0.02"``; ``"none"`` when nothing differs.

    Examples
    --------
    >>> case = load_case("paper", "1")
    >>> scenario_overrides(case, case.replace(controller={"torque_limit": float("inf")}, simulation={"t_final": 300.0}))
    't_final=300, torque_limit=inf'
    >>> scenario_overrides(case, case)
    'none'
    """
    from fsmctl.studies.records import FLOWN_SECTIONS

    a, b = case.to_dict(), flown.to_dict()
    before = _flat({k: a.get(k) for k in FLOWN_SECTIONS})
    after = _flat({k: b.get(k) for k in FLOWN_SECTIONS})
    changed = [p for p in after if p not in before or before[p] != after[p]]
    changed += [p for p in before if p not in after]
    leaves = [str(p[-1]) for p in changed]

    def name(p: tuple) -> str:
        return str(p[-1]) if leaves.count(str(p[-1])) == 1 else ".".join(str(k) for k in p[1:])

    return ", ".join(f"{name(p)}={_value_text(after.get(p, '(unset)'))}" for p in changed) or "none"


def run_overrides(source: str | Mapping[str, Any], spec: RunSpec, fast: bool) -> str:
    """The settings a run changes in its case: :func:`scenario_overrides` of :func:`load_case` and
    :func:`run_scenario`.

    Parameters
    ----------
    source, spec, fast
        As :func:`run_scenario`.

    Returns
    -------
    str
        ``name=value, ...`` (``"none"``: the case as the source gives it).

    Examples
    --------
    The diagnostic runs are recorded on a coarser output grid:

    >>> plan = {spec.key: spec for spec in run_plan()}
    >>> run_overrides("paper", plan["case1_no_torque_limit"], fast=False)
    'output_interval=0.02, torque_limit=inf'
    >>> run_overrides("paper", plan["case1"], fast=False)
    'none'
    """
    return scenario_overrides(load_case(source, spec.case), run_scenario(source, spec, fast))


def run_record(
    spec: RunSpec, scenario, result, *, source: str | Mapping[str, Any] = "paper", **fields: Any
) -> RunRecord:
    """The :class:`~fsmctl.studies.records.RunRecord` of one simulated :class:`RunSpec` (eqs 42-43).

    Parameters
    ----------
    spec : RunSpec
        The run.
    scenario : Scenario
        What was flown (:func:`run_scenario`).
    result : SimulationResult
        Its simulation.
    source : str or mapping
        The source of the case (as :func:`run_scenario`); the record's ``overrides`` are what ``scenario`` changes
        in that case (:func:`scenario_overrides`).
    **fields
        Further fields of the record (``netcdf``, ``figures``, ``wall_time_s``, ``metrics``, ...).

    Returns
    -------
    RunRecord
        The summary at :data:`fsmctl.policy.SETTLING_TOLERANCES_DEG`; the steady window is
        :func:`fsmctl.policy.default_steady_window` of the run's nominal horizon (a long run's horizon divided by
        its factor: 40 s of the 300 s runs too).

    Examples
    --------
    >>> from fsmctl import simulate
    >>> spec = run_plan()[1]
    >>> scenario = run_scenario("paper", spec, fast=True).replace(simulation={"t_final": 2.0})
    >>> rec = run_record(spec, scenario, simulate(scenario, progress=False))
    >>> rec.key, rec.steady_window_s, len(rec.theta_e0_deg)  # 40 % of 2 s; one angle per spacecraft
    ('case2', 0.8, 6)
    >>> rec.overrides
    't_final=2, output_interval=0.05'
    """
    return RunRecord.from_result(
        spec.key,
        scenario,
        result,
        steady_window_s=default_steady_window(scenario.simulation.t_final / spec.horizon_factor),
        tolerances_deg=SETTLING_TOLERANCES_DEG,
        title=spec.title,
        purpose=spec.purpose,
        overrides=scenario_overrides(load_case(source, spec.case), scenario),
        case=spec.case,
        describe=scenario.describe(),
        **fields,
    )


def execute_run(
    source: str | Mapping[str, Any], spec: RunSpec, fast: bool, out_dir: str, command: str | None = None
) -> RunRecord:
    """Simulate one :class:`RunSpec`, save its NetCDF and single-run figures, return its :class:`RunRecord`.

    Parameters
    ----------
    source : str or mapping
        ``"paper"``, a scenario TOML file (Liang et al. 2012, Sec. 4 layout: cases 1, 2, 3a-3c) or its
        parsed mapping (:func:`load_case`).
    spec : RunSpec
        The run.
    fast : bool
        Short horizon (:data:`fsmctl.policy.FAST_T_FINAL_S`) and coarser output, for tests.
    out_dir : str
        Output folder (``runs/`` and ``figures/`` below it).
    command : str, optional
        The command line, embedded in the run's NetCDF file with its scenario, law and versions.

    Returns
    -------
    RunRecord
        Summary, AAEM/RAEM series (eqs 42-43) and the written files.

    Examples
    --------
    A short diagnostic run (Case 1 with pure sgn, no figures), written under ``out/``:

    >>> spec = RunSpec("sgn", "1", "Case 1, pure sgn", "", controller=(("boundary_layer", 0.0),),
    ...                simulation=(("t_final", 0.5),))
    >>> rec = execute_run("paper", spec, False, "out")
    >>> rec.netcdf, rec.figures, rec.t_final
    ('out/runs/sgn.nc', [], 0.5)
    """
    import fsmctl.studies.figures as figs
    from fsmctl.simulation.simulator import simulate

    scenario = run_scenario(source, spec, fast)
    started = _time.perf_counter()
    result = simulate(scenario, progress=False)
    out = Path(out_dir)
    nc = result.save(out / "runs" / f"{spec.key}.nc", command=command)
    theta_deg = np.degrees(result.theta_e)
    written = []
    title = f"{spec.title} ({scenario.label})"

    def marks(name: str):
        return _figure_marks(spec.key, name)

    builders: dict[str, Callable[[], Any]] = {
        "aaem": lambda: figs.metric_figure(
            result.time, result.aaem_deg, metric="AAEM", title=f"AAEM, {title}", marks=marks("aaem")
        ),
        "raem": lambda: figs.metric_figure(
            result.time, result.raem_deg, metric="RAEM", title=f"RAEM, {title}", marks=marks("raem")
        ),
        "theta_e": lambda: figs.principal_angles_figure(
            result.time, theta_deg, title=f"error principal angles, {title}", marks=marks("theta_e")
        ),
        "torques": lambda: figs.torques_figure(
            result.time,
            result.u,
            scenario.controller.torque_limit,
            title=f"applied torques, {title}",
            marks=marks("torques"),
        ),
        "torques_commanded": lambda: figs.torques_figure(
            result.time,
            result.u_unsaturated,
            scenario.controller.torque_limit,
            title=f"commanded torques, {title}",
            marks=marks("torques_commanded"),
        ),
    }
    for name in spec.figures:
        number = _FIGURE_NUMBER.get((spec.key, name))
        stem = out / "figures" / f"{f'fig{number:02d}' if number else 'diag'}_{name}_{spec.key}"
        written += [str(p) for p in figs.save_figure(builders[name](), stem)]
    return run_record(
        spec,
        scenario,
        result,
        source=source,
        netcdf=str(nc),
        figures=written,
        wall_time_s=_time.perf_counter() - started,
    )


_FIGURE_NUMBER = {  # the paper's figure of a single-run figure (the others are diagnostics)
    ("case1", "aaem"): 1,
    ("case1", "raem"): 2,
    ("case1", "theta_e"): 3,
    ("case1", "torques"): 4,
    ("case2", "theta_e"): 7,
}


def _figure_marks(key: str, name: str):
    """The reference marks of a single-run figure: its paper figure's (:func:`~fsmctl.studies.figure_marks.paper_marks`),
    else the paper's statements about its quantity (settling time and accuracy, the torque bound)."""
    from fsmctl.studies.figure_marks import metric_marks, paper_marks, torque_marks

    number = _FIGURE_NUMBER.get((key, name))
    if number is not None:
        return paper_marks(number)
    if name in ("aaem", "raem"):
        return metric_marks(name)
    return torque_marks() if name.startswith("torques") else None
