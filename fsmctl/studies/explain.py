"""What would reproduce each claim of Liang, Sun & Wang (2012), Section 4: ``fsmctl reproduce``'s explanations.

For every claim that :func:`fsmctl.studies.reproduce.evaluate_claims` does not grade ``reproduced``, and for the
figure-level checks :data:`FIGURE_CHECKS` (what the printed Figs 1-9 show: axis ranges, the saturation level, the
insets), this module searches the settings the paper leaves open or may have misprinted (:func:`search_settings`)
for the **smallest change** that makes the claim's own test (:func:`fsmctl.studies.reproduce.claim_holds`) pass:

* the torque limit (the paper's 2 N m: a misprint?), alpha, delta, the boundary layer phi;
* the error kinematics (``error_model = "exact"``), the error MRP not switched to the shadow set (the FSM law of
  ``fsmctl/studies/explain_laws/fsm_unswitched.py``), the integrator and its step;
* the tolerance behind "settles" (a grading setting: no new runs).

Distance.  A continuous setting's change is measured on its scale (log, or linear for alpha) as the fraction of the
searched range moved from the scenario's value towards the end of the range on that side, in ``(0, 1]``; a discrete
choice (error kinematics, error MRP, integrator / step) counts 1; a pair adds its two distances.  The smallest
change is the one of least distance (ties: the order of :func:`search_settings`).

Search (best-first, per claim).  The grid values of every setting (:attr:`Setting.grid`) are tried in order of
distance, level by level (:data:`LEVELS`); a reproducing grid value and the nearest tried value towards the default
(which fails, or the default itself) bracket a threshold, bisected to :attr:`Setting.resolution`.  The search stops
when no untried value can be nearer than the change found (the grid spacing is the resolution elsewhere: a window of
success narrower than a grid step can be missed), then tries the grid values beyond the threshold on its axis, so
that "reproduced if torque limit >= 47.7 N m (bisected to 0.1 N m; 47.6 N m does not)" is checked over the whole
range, and "fails again at ..." is said when it is not.  A claim no single change reproduces is searched in pairs
(one modelling choice of :data:`PAIRED_CHOICES` held, every other setting varied) within :data:`PAIR_BUDGET_RUNS`
runs; so are the figure checks that only the unswitched error MRP can reach (in the shadow set every principal angle
is at most 180°).

Runs.  Every candidate run is a run of :func:`fsmctl.studies.reproduce.run_plan` (same key, case, horizon and
output grid) flown on the candidate scenario: the base scenario with the change, as the mapping of a scenario file
``{"extends": <base>, <section>: {<key>: <value>}}``.  Identical scenarios are simulated once; a claim that fails on
its first run does not fly the others; the runs of a round go to the caller's process pool together, and the result
does not depend on the order in which they finish or on the number of workers.  The evidence of each explanation is
written as a scenario file (``extends`` the base with just the change), re-loaded from that file and simulated
again, and its numbers must equal the search's.

The default scenario is never changed: every explanation is a separate run.
"""

from __future__ import annotations

import concurrent.futures as cf
import math
import re
import shutil
import sys
import time as _time
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from fsmctl.errors import InputError
from fsmctl.model.laws import LawSwitchWarning
from fsmctl.model.toml_writer import toml_table, toml_value
from fsmctl.outputs import write_text
from fsmctl.studies.explain_laws import UNSWITCHED_LAW, law_script
from fsmctl.studies.reproduce import (
    CLAIM_IDS,
    CLAIM_RUNS,
    CLAIM_USES_TOLERANCE,
    SETTLING_TOLERANCES_DEG,
    ClaimVerdict,
    RunRecord,
    RunSpec,
    claim_holds,
    run_plan,
    run_record,
    run_scenario,
)

__all__ = [
    "EXPLAINED",
    "NOT_EXPLAINED",
    "ALREADY_REPRODUCED",
    "FIGURE_CHECKS",
    "PAIR_BUDGET_RUNS",
    "PAIRED_CHOICES",
    "LEVELS",
    "PAIR_LEVELS",
    "Setting",
    "Candidate",
    "ExplainRun",
    "Evidence",
    "Explanation",
    "search_settings",
    "candidate_source",
    "figure_numbers",
    "explain",
    "scenario_text",
    "markdown_section",
    "text_lines",
]

EXPLAINED = "reproduced if"
NOT_EXPLAINED = "no setting in the searched ranges reproduces it"
ALREADY_REPRODUCED = "already reproduced"

PAIR_BUDGET_RUNS = 60
"""Pairs start no new distance level once this many runs have been spent on them (all claims together)."""

EXPLAIN_DIR = "explain"
"""Sub-folder of the report with the evidence scenario files."""

_RUN_SPECS = {s.key: s for s in run_plan()}


# ----------------------------------------------------------------------------- settings


@dataclass(frozen=True)
class Setting:
    """One setting the paper leaves open (or may have misprinted), with the range searched.

    Parameters
    ----------
    name : str
        Identifier (``torque_limit``, ``alpha``, ``delta``, ``boundary_layer``, ``error_model``, ``error_mrp``,
        ``integration``, ``tolerance``).
    label : str
        Human-readable name.
    unit : str
        Unit of the value ("" for choices).
    kind : str
        ``"log"`` or ``"linear"`` (continuous, bisected), ``"choice"`` (discrete alternatives).
    default : float or str
        The base scenario's value (choices: the label of the default option).
    low, high : float
        Searched range of a continuous setting.
    grid : tuple
        Continuous: the values tried before bisecting (the default excluded); choice: the alternative labels.
    resolution : float
        Bisection stops when the bracket is this narrow: absolute (``relative=False``) or relative.
    relative : bool
        Whether ``resolution`` is relative.
    grading : bool
        A grading setting (the tolerance): changes how runs are judged, not what is simulated.
    why : str
        What the paper says about it.
    options : tuple of (str, mapping)
        Choice: the TOML tables of each alternative label (``"@law"`` stands for the unswitched law's path).

    Examples
    --------
    The paper's torque limit (2 N m, Case 1), searched on a log scale and bisected to 0.1 N m:

    >>> import fsmctl
    >>> from fsmctl.studies.explain import search_settings
    >>> limit = search_settings(fsmctl.paper_scenario("1"))[0]
    >>> limit.name, limit.kind, limit.default, limit.low, limit.high
    ('torque_limit', 'log', 2.0, 2.0, 100000.0)
    >>> limit.midpoint(2.0, 200.0), limit.resolved(47.6, 47.7), limit.value_text(47.7)
    (20.0, True, 'torque limit = 47.7 N m')
    """

    name: str
    label: str
    unit: str
    kind: str
    default: Any
    low: float = math.nan
    high: float = math.nan
    grid: tuple = ()
    resolution: float = 0.0
    relative: bool = True
    grading: bool = False
    why: str = ""
    options: tuple[tuple[str, Mapping[str, Any]], ...] = ()

    @property
    def continuous(self) -> bool:
        """Whether the setting is bisected (log or linear scale)."""
        return self.kind in ("log", "linear")

    def _f(self, x: float) -> float:
        return math.log(x) if self.kind == "log" else float(x)

    def distance(self, value: Any) -> float:
        """The size of the change to ``value``: a fraction of the searched range (continuous) or 1 (choice).

        Parameters
        ----------
        value : float or str
            A value of the setting.

        Returns
        -------
        float
            0 for the default, in ``(0, 1]`` otherwise.
        """
        if not self.continuous:
            return 0.0 if value == self.default else 1.0
        x0 = float(self.default)
        end = self.high if value > x0 else self.low
        span = abs(self._f(end) - self._f(x0))
        return 0.0 if value == x0 else min(1.0, abs(self._f(value) - self._f(x0)) / span) if span > 0 else 1.0

    def midpoint(self, a: float, b: float) -> float:
        """The bisection point of ``[a, b]`` on the setting's scale (geometric for ``log``), rounded to its resolution.

        Parameters
        ----------
        a, b : float
            The bracket.

        Returns
        -------
        float
            The rounded midpoint.
        """
        m = math.sqrt(a * b) if self.kind == "log" else 0.5 * (a + b)
        return self.rounded(m)

    def rounded(self, x: float) -> float:
        """``x`` on the resolution grid: a multiple of an absolute resolution, else 3 significant digits.

        Parameters
        ----------
        x : float
            A value of the setting.

        Returns
        -------
        float
            The rounded value.
        """
        if not self.relative:
            digits = max(0, -math.floor(math.log10(self.resolution) + 1e-12))
            return round(round(x / self.resolution) * self.resolution, digits)
        return float(f"{x:.3g}")

    def resolved(self, a: float, b: float) -> bool:
        """Whether the bracket ``[a, b]`` is within the resolution.

        Parameters
        ----------
        a, b : float
            The bracket (in either order).

        Returns
        -------
        bool
            True when bisecting further is pointless.
        """
        lo, hi = min(a, b), max(a, b)
        if not self.relative:
            return hi - lo <= self.resolution * (1 + 1e-9)
        return hi <= lo * (1 + self.resolution) * (1 + 1e-12)

    def resolution_text(self) -> str:
        """``"0.1 N m"`` or ``"1 %"``."""
        if self.relative:
            return f"{self.resolution * 100:g} %"
        return f"{self.resolution:g} {self.unit}".strip()

    def value_text(self, value: Any) -> str:
        """``"torque limit = 37.3 N m"``, ``"error MRP: unswitched"``.

        Parameters
        ----------
        value : float or str
            A value of the setting (a choice's label).

        Returns
        -------
        str
            The setting and value, with its unit.
        """
        if not self.continuous:
            return f"{self.label}: {value}"
        return f"{self.label} = {_num(value)} {self.unit}".strip()

    def range_text(self) -> str:
        """What was searched: ``"torque limit 2-1e+05 N m (log grid of 14 values, bisected to 0.1 N m)"``."""
        if not self.continuous:
            return f"{self.label}: {' / '.join(str(v) for v in self.grid)} (default {self.default})"
        unit = f" {self.unit}" if self.unit else ""
        return (
            f"{self.label} {_num(self.low)}-{_num(self.high)}{unit} (default {_num(self.default)}; "
            f"{self.kind} grid of {len(self.grid)} values, bisected to {self.resolution_text()})"
        )

    def tables(self, value: Any, law_path: str | None = None) -> dict[str, dict[str, Any]]:
        """The scenario tables that set ``value`` (``{}`` for a grading setting).

        Parameters
        ----------
        value : float or str
            The value (a choice's label).
        law_path : str, optional
            What ``"@law"`` stands for (the unswitched law's script); default: its installed path.

        Returns
        -------
        dict
            ``{section: {key: value}}``.
        """
        if self.grading:
            return {}
        if not self.continuous:
            tables = dict(self.options)[value]
            law = law_path if law_path is not None else str(law_script(UNSWITCHED_LAW))
            return {s: {k: (law if v == "@law" else v) for k, v in t.items()} for s, t in tables.items()}
        return {"controller": {self.name: float(value)}}  # a number sets every component of a vector


def _num(x: Any) -> str:
    if isinstance(x, str):
        return x
    x = float(x)
    if not math.isfinite(x):
        return "inf"
    return f"{x:.6g}"


def _grid_125(low: float, high: float, default: float) -> tuple[float, ...]:
    """The 1-2-5 values of each decade within ``[low, high]``, the ends included, the default excluded."""
    out = {low, high}
    for e in range(math.floor(math.log10(low)) - 1, math.ceil(math.log10(high)) + 1):
        for m in (1, 2, 5):
            v = float(f"{m}e{e}")
            if low <= v <= high:
                out.add(v)
    return tuple(sorted(v for v in out if not math.isclose(v, default, rel_tol=1e-12)))


def search_settings(scenario) -> tuple[Setting, ...]:
    """The settings searched for explanations, with their ranges, around the values of ``scenario``.

    Parameters
    ----------
    scenario : Scenario
        The base scenario (Case 1): its torque limit, alpha, delta (agent 1, first axis), boundary layer, error
        model, integrator and step are the defaults.

    Returns
    -------
    tuple of Setting
        In the order of preference for equal distances: torque limit, alpha, delta, boundary layer, error model,
        error MRP, integration, tolerance.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.studies.explain import search_settings
    >>> [s.name for s in search_settings(fsmctl.paper_scenario("1"))]
    ['torque_limit', 'alpha', 'delta', 'boundary_layer', 'error_model', 'error_mrp', 'integration', 'tolerance']
    """
    c, sim = scenario.controller, scenario.simulation
    params = scenario.law_parameters()[0]  # agent 1, as flown
    alpha = float(params.get("alpha", 0.7))
    delta = float(np.asarray(params.get("delta", 0.005), float).ravel()[0])
    phi = float(params.get("boundary_layer", 0.0))
    u_max = float(c.torque_limit)
    tol = SETTLING_TOLERANCES_DEG[0]
    out: list[Setting] = []
    if math.isfinite(u_max) and u_max > 0:
        top = 1e5
        out.append(
            Setting(
                "torque_limit",
                "torque limit",
                "N m",
                "log",
                u_max,
                u_max,
                top,
                _grid_125(u_max, top, u_max),
                0.1,
                False,
                why=f"printed as |(u_i)_k| <= 2 N m; searched upwards only (a lower limit removes torque), up to "
                f"{top:g} N m, above every commanded peak (the same as no limit)",
            )
        )
    alpha_grid = tuple(v for v in (0.51, 0.55, 0.6, 0.65, 0.7, 0.75, 0.8, 0.85, 0.9, 0.95, 0.99) if v != alpha)
    out += [
        Setting(
            "alpha",
            "alpha",
            "",
            "linear",
            alpha,
            0.51,
            0.99,
            alpha_grid,
            0.001,
            False,
            why="not given (0.5 < alpha < 1, eq 13)",
        ),
        Setting(
            "delta",
            "delta",
            "1/s^2",
            "log",
            delta,
            5e-5,
            5.0,
            _grid_125(5e-5, 5.0, delta),
            0.01,
            True,
            why="not given ((delta_i)_k > 0, eq 18); the same value on every axis and agent",
        ),
    ]
    if phi > 0:
        out.append(
            Setting(
                "boundary_layer",
                "boundary layer phi",
                "1/s",
                "log",
                phi,
                1e-5,
                1.0,
                _grid_125(1e-5, 1.0, phi),
                0.01,
                True,
                why="not given (Remark 7: a saturation function replaces sgn); phi = 0 (sgn) is a "
                "diagnostic run of the report",
            )
        )
    other_model = "exact" if str(c.error_model) == "paper" else "paper"
    out.append(
        Setting(
            "error_model",
            "error kinematics",
            "",
            "choice",
            str(c.error_model),
            grid=(other_model,),
            options=((other_model, {"controller": {"error_model": other_model}}),),
            why="eqs 7-8 as printed drop the rotation of omega_d into the body frame",
        )
    )
    if scenario.law.paper_theorems is not None:  # the law is eqs 13-19: fsm_unswitched is its unswitched twin
        out.append(
            Setting(
                "error_mrp",
                "error MRP",
                "",
                "choice",
                "shadow set",
                grid=("unswitched",),
                options=(("unswitched", {"controller": {"law": "@law"}}),),
                why="the paper does not say whether sigma_e is switched to the shadow set (|sigma_e| <= 1); its "
                "figure axes reach beyond 180 deg",
            )
        )
    steps = [dt for dt in (0.0005, 0.002, 0.005, 0.01) if dt != sim.dt and _divides(dt, sim)]
    options = [(f"rk4 dt = {dt:g} s", {"simulation": {"integrator": "rk4", "dt": dt}}) for dt in steps]
    if sim.integrator != "dopri45":
        options.append((f"dopri45 (rtol {sim.rtol:g}, atol {sim.atol:g})", {"simulation": {"integrator": "dopri45"}}))
    out.append(
        Setting(
            "integration",
            "integrator / step",
            "",
            "choice",
            f"{sim.integrator} dt = {sim.dt:g} s",
            grid=tuple(o[0] for o in options),
            options=tuple(options),
            why="not given",
        )
    )
    out.append(
        Setting(
            "tolerance",
            "settling tolerance",
            "deg",
            "log",
            tol,
            0.01,
            10.0,
            _grid_125(0.01, 10.0, tol),
            0.01,
            True,
            grading=True,
            why='"fall to the tolerance in 27 s": the tolerance is not stated',
        )
    )
    return tuple(out)


def _divides(dt: float, sim) -> bool:
    """Whether ``dt`` divides the base grid (output interval, horizon, fast horizon and output)."""
    from fsmctl.studies.reproduce import FAST_OUTPUT_INTERVAL_S, FAST_T_FINAL_S

    def multiple(x: float) -> bool:
        k = round(x / dt)
        return k >= 1 and abs(k * dt - x) <= 1e-9 * max(1.0, x)

    return all(multiple(x) for x in (sim.output_interval, sim.t_final, FAST_T_FINAL_S, FAST_OUTPUT_INTERVAL_S))


# ----------------------------------------------------------------------------- candidates


@dataclass(frozen=True, order=True)
class Candidate:
    """A set of changes to the base scenario: ``((setting name, value), ...)`` in the order of the settings.

    The empty candidate is the base scenario itself.

    Parameters
    ----------
    changes : tuple of (str, object), optional
        ``(setting name, value)`` pairs (:func:`search_settings` names the settings).

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.studies.explain import Candidate, search_settings
    >>> settings = {s.name: s for s in search_settings(fsmctl.paper_scenario("1"))}
    >>> c = Candidate((("torque_limit", 47.7), ("tolerance", 0.1)))
    >>> c.key(), c.tolerance(), c.simulated().changes
    ('explain_torque_limit_47.7__tolerance_0.1', 0.1, (('torque_limit', 47.7),))
    >>> c.text(settings)
    'torque limit = 47.7 N m and settling tolerance = 0.1 deg'
    """

    changes: tuple[tuple[str, Any], ...] = ()

    def tolerance(self) -> float | None:
        """The settling tolerance it sets (deg), or None."""
        return next((float(v) for n, v in self.changes if n == "tolerance"), None)

    def simulated(self) -> Candidate:
        """The candidate without its grading changes (what is simulated)."""
        return Candidate(tuple((n, v) for n, v in self.changes if n != "tolerance"))

    def key(self) -> str:
        """File-safe name: ``explain_torque_limit_37.3`` (``explain_paper`` for no change)."""
        if not self.changes:
            return "explain_paper"
        parts = [f"{n}_{_num(v)}" for n, v in self.changes]
        return "explain_" + re.sub(r"[^A-Za-z0-9_.+-]+", "_", "__".join(parts)).strip("_")

    def text(self, settings: Mapping[str, Setting]) -> str:
        """``"torque limit = 37.3 N m and alpha = 0.9"`` (``"no change"`` for the empty candidate).

        Parameters
        ----------
        settings : Mapping of str to Setting
            The settings by name.

        Returns
        -------
        str
            The changes, joined by ``and``.
        """
        return " and ".join(settings[n].value_text(v) for n, v in self.changes) or "no change"


def candidate_source(base: str, candidate: Candidate, settings: Mapping[str, Setting], law_path: str | None = None):
    """The candidate scenario as a TOML mapping: ``{"extends": base, <section>: {<key>: <value>}, ...}``.

    Parameters
    ----------
    base : str
        ``"paper"`` or the absolute path of the base scenario file.
    candidate : Candidate
        The changes.
    settings : mapping name -> Setting
        From :func:`search_settings`.
    law_path : str, optional
        The unswitched law's script (default: its installed path).

    Returns
    -------
    dict
        Loadable with :func:`fsmctl.studies.reproduce.load_case` and writable with :func:`scenario_text`.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.studies.explain import Candidate, candidate_source, search_settings
    >>> settings = {s.name: s for s in search_settings(fsmctl.paper_scenario("1"))}
    >>> candidate_source("paper", Candidate((("torque_limit", 47.7),)), settings)
    {'extends': 'paper', 'controller': {'torque_limit': 47.7}}
    """
    data: dict[str, Any] = {"extends": base}
    for name, value in candidate.changes:
        for section, table in settings[name].tables(value, law_path).items():
            data.setdefault(section, {}).update(table)
    return data


def scenario_text(data: Mapping[str, Any], comments: Sequence[str] = ()) -> str:
    """A scenario file (TOML) from a :func:`candidate_source` mapping.

    Parameters
    ----------
    data : mapping
        ``{"extends": ..., <section>: {<key>: <value>}}``.
    comments : sequence of str
        Lines written as ``# ...`` at the top.

    Returns
    -------
    str
        ``extends = "paper"`` then one table per changed section.

    Examples
    --------
    >>> from fsmctl.studies.explain import scenario_text
    >>> print(scenario_text({"extends": "paper", "controller": {"torque_limit": 47.7}}, ["torque limit 47.7 N m"]))
    # torque limit 47.7 N m
    extends = "paper"
    <BLANKLINE>
    [controller]
    torque_limit = 47.7
    <BLANKLINE>
    """
    lines = [f"# {c}" if c else "#" for c in comments]
    lines.append(f"extends = {toml_value(data['extends'])}")
    for section, table in data.items():
        if section == "extends":
            continue
        toml_table([section], table, lines)
    return "\n".join(lines) + "\n"


# ----------------------------------------------------------------------------- runs


@dataclass
class ExplainRun:
    """One simulated run of a candidate: the :class:`~fsmctl.studies.reproduce.RunRecord` and figure-level numbers.

    Parameters
    ----------
    candidate : Candidate
        The candidate flown.
    record : RunRecord or None
        The run's record (None when the simulation failed).
    figures : dict
        :func:`figure_numbers` of the run.
    warnings : list of str, optional
        Warnings of the run.
    error : str, optional
        Why the simulation failed ("" if it did not; then ``record`` is None and every check fails on it).

    Examples
    --------
    >>> from fsmctl.studies.explain import Candidate, ExplainRun
    >>> failed = ExplainRun(Candidate((("alpha", 0.99),)), None, {}, error="the step size is too large")
    >>> failed.record is None, failed.error
    (True, 'the step size is too large')
    """

    candidate: Candidate
    record: RunRecord | None
    figures: dict
    """:func:`figure_numbers` of the run"""
    warnings: list[str] = field(default_factory=list)
    error: str = ""
    """why the simulation failed ("" if it did not; then ``record`` is None and every check fails on it)"""


def _compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``mrp_compose(a, b)`` (direct formula, no shadow switch) on arrays ``(..., 3)``."""
    a2, b2 = np.sum(a * a, -1), np.sum(b * b, -1)
    num = (1 - b2)[..., None] * a + (1 - a2)[..., None] * b - 2 * np.cross(a, b)
    den = 1 + a2 * b2 - 2 * np.sum(a * b, -1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return num / den[..., None]


def _angle_deg(sigma: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore"):
        theta = np.degrees(4 * np.arctan(np.linalg.norm(sigma, axis=-1)))
    return np.where(np.isfinite(theta), theta, 360.0)


def figure_numbers(result, unswitched: bool, plotted_agents: int = 4) -> dict:
    """The peaks the paper's figures would show for one run (Figs 1-4 for Case 1, 5-7 for Case 2).

    ``theta_ei = 4 atan|sigma_ei|`` (eq 2) of the error MRP the law uses: the shadow set (the simulator's
    ``sigma_e``), or, for the unswitched law, the direct composition ``sigma_i (x) sigma_d^-1`` of the (switched)
    attitudes, whose angle reaches 360 deg; AAEM and RAEM (eqs 42-43) from those angles (the relative MRPs
    ``sigma_ei (x) sigma_ej^-1`` composed the same way).

    Parameters
    ----------
    result : SimulationResult
        The run.
    unswitched : bool
        Whether the law's error MRP is unswitched.
    plotted_agents : int
        The agents plotted in Figs 3 and 7 (the first four).

    Returns
    -------
    dict
        ``aaem_peak_deg``, ``raem_peak_deg``, ``theta_plotted_peak_deg`` (agents 1-4), ``u_peak_N_m`` (applied),
        ``error_mrp`` (``"shadow set"`` / ``"unswitched"``).

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.studies.explain import figure_numbers
    >>> result = fsmctl.simulate(fsmctl.paper_scenario("1").replace(simulation={"t_final": 2.0}))
    >>> numbers = figure_numbers(result, unswitched=False)
    >>> numbers["u_peak_N_m"], numbers["error_mrp"]  # saturated at the 2 N m limit (Fig 4)
    (2.0, 'shadow set')
    """
    if unswitched:
        se = _compose(result.sigma, -result.sigma_d[:, None, :])
        theta = _angle_deg(se)
        aaem = np.sqrt(np.mean(theta**2, axis=1))
        n = se.shape[1]
        iu, ju = np.triu_indices(n, k=1)
        rel = _angle_deg(_compose(se[:, iu, :], -se[:, ju, :]))
        raem = np.sqrt(2 * np.sum(rel**2, axis=1) / (n * (n - 1)))  # eq 43: both orders of each pair, / n(n-1)
    else:
        theta = np.degrees(result.theta_e)
        aaem, raem = result.aaem_deg, result.raem_deg
    return {
        "aaem_peak_deg": float(np.max(aaem)),
        "raem_peak_deg": float(np.max(raem)),
        "theta_plotted_peak_deg": float(np.max(theta[:, :plotted_agents])),
        "u_peak_N_m": float(np.max(np.abs(result.u))),
        "error_mrp": "unswitched" if unswitched else "shadow set",
    }


def _candidate_scenario(data: Mapping[str, Any] | str, spec: RunSpec, fast: bool):
    """The scenario of a candidate's run; a candidate that flies another law (error MRP: unswitched) is that
    candidate, named in its label, so its :class:`~fsmctl.model.laws.LawSwitchWarning` is not repeated."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LawSwitchWarning)
        return run_scenario(data, spec, fast)


def _simulate(data: Mapping[str, Any] | str, candidate: Candidate, spec: RunSpec, fast: bool) -> ExplainRun:
    """Worker: fly ``spec`` on the candidate scenario ``data``; no file is written."""
    from fsmctl.simulation.simulator import SimulationError, simulate

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scenario = _candidate_scenario(data, spec, fast)
        started, cpu = _time.perf_counter(), _time.process_time()
        try:
            result = simulate(scenario, progress=False)
        except SimulationError as exc:  # a candidate the integrator cannot fly: it reproduces nothing
            return ExplainRun(candidate, None, {}, [], f"{type(exc).__name__}: {str(exc).splitlines()[0]}")
    record = run_record(spec, scenario, result, wall_time_s=_time.perf_counter() - started)
    record.summary["cpu_time_s"] = _time.process_time() - cpu
    unswitched = any(n == "error_mrp" for n, _ in candidate.changes)
    messages = sorted({str(w.message).splitlines()[0] for w in caught if "triangle inequality" not in str(w.message)})
    return ExplainRun(candidate, record, figure_numbers(result, unswitched), messages)


class _Runner:
    """Simulates (candidate, run key) pairs once each, in parallel rounds; identical scenarios share one run."""

    def __init__(self, base, settings, fast, executor, bar):
        self.base, self.settings, self.fast = base, settings, fast
        self.executor, self.bar = executor, bar
        self.runs: dict[tuple[Candidate, str], ExplainRun] = {}
        self._by_print: dict[Any, ExplainRun] = {}
        self.simulated = 0
        self.cpu_s = 0.0

    def _fingerprint(self, data, spec):
        s = _candidate_scenario(data, spec, self.fast)
        return (s.agents, s.reference, s.topology, s.controller, s.simulation, s.actuator, s.sensors, s.links)

    def run(self, wanted: Iterable[tuple[Candidate, str]]) -> None:
        todo = sorted({(c.simulated(), k) for c, k in wanted} - set(self.runs))
        if not todo:
            return
        jobs: dict[Any, tuple[dict, Candidate, RunSpec]] = {}
        waiting: dict[Any, list[tuple[Candidate, str]]] = {}
        for cand, key in todo:
            data = candidate_source(self.base, cand, self.settings)
            spec = _RUN_SPECS[key]
            fp = self._fingerprint(data, spec)
            if fp in self._by_print:
                self.runs[(cand, key)] = self._by_print[fp]
                continue
            jobs.setdefault(fp, (data, cand, spec))
            waiting.setdefault(fp, []).append((cand, key))
        if not jobs:
            return
        self.bar.total = (self.bar.total or 0) + len(jobs)
        self.bar.refresh()
        if self.executor is None:
            done = {}
            for fp, (data, cand, spec) in jobs.items():
                done[fp] = _simulate(data, cand, spec, self.fast)
                self.bar.update(1)
        else:
            futures = {
                self.executor.submit(_simulate, data, cand, spec, self.fast): fp
                for fp, (data, cand, spec) in jobs.items()
            }
            done = {}
            for fut in cf.as_completed(futures):
                done[futures[fut]] = fut.result()
                self.bar.update(1)
        self.simulated += len(jobs)
        for fp, run in done.items():
            self.cpu_s += run.record.summary["cpu_time_s"] if run.record is not None else 0.0
            self._by_print[fp] = run
            for pair in waiting[fp]:
                self.runs[pair] = run

    def get(self, candidate: Candidate, key: str) -> ExplainRun:
        return self.runs[(candidate.simulated(), key)]


# ----------------------------------------------------------------------------- what is checked


@dataclass(frozen=True)
class _Check:
    """A claim (or figure-level check) as the search sees it.

    ``decide(runs, tol)`` returns the verdict, or the run keys it still needs (so that a claim that already fails on
    its first run does not fly the others); ``runs`` lists every run its numbers may show.
    """

    id: str
    text: str
    runs: tuple[str, ...]
    uses_tolerance: bool
    decide: Callable[[Mapping[str, ExplainRun], float], bool | list[str]]
    numbers: Callable[[Mapping[str, ExplainRun], float], str]


def _peak(key: str, run: str) -> Callable[[Mapping[str, ExplainRun]], float]:
    return lambda runs: runs[run].figures[key]


def _steady(*keys: str) -> Callable[[Mapping[str, ExplainRun]], float]:
    return lambda runs: max(
        max(runs[k].record.aaem_steady_max_deg, runs[k].record.raem_steady_max_deg) for k in keys if k in runs
    )


FIGURE_CHECKS: dict[str, dict[str, Any]] = {
    "fig1_axis": {
        "text": "Fig 1: Case 1 AAEM plotted on a 0-300° axis (ticks every 50°)",
        "runs": ("case1",),
        "value": _peak("aaem_peak_deg", "case1"),
        "what": "AAEM peak",
        "interval": (250.0, 300.0),
        "requires": ("error_mrp", "unswitched"),
        "why": "in the shadow set every θ_ei <= 180°, so AAEM <= 180°",
    },
    "fig2_axis": {
        "text": "Fig 2: Case 1 RAEM plotted on a 0-140° axis (ticks every 20°)",
        "runs": ("case1",),
        "value": _peak("raem_peak_deg", "case1"),
        "what": "RAEM peak",
        "interval": (120.0, 140.0),
    },
    "fig3_axis": {
        "text": "Fig 3: Case 1 θ_1-θ_4 plotted on a 0-200° axis (ticks every 20°)",
        "runs": ("case1",),
        "value": _peak("theta_plotted_peak_deg", "case1"),
        "what": "θ_1-4 peak",
        "interval": (180.0, 200.0),
        "requires": ("error_mrp", "unswitched"),
        "why": "in the shadow set every θ_ei <= 180°",
    },
    "fig4_axis": {
        "text": "Fig 4: applied torques plotted on ±2 N m axes, the bound reached",
        "runs": ("case1",),
        "value": _peak("u_peak_N_m", "case1"),
        "what": "applied |u_k| peak",
        "unit": "N m",
        "interval": (2.0 * (1 - 1e-6), 2.0 * (1 + 1e-6)),
    },
    "fig5_axis": {
        "text": "Fig 5: Case 2 AAEM plotted on a 0-300° axis (ticks every 50°)",
        "runs": ("case2",),
        "value": _peak("aaem_peak_deg", "case2"),
        "what": "AAEM peak",
        "interval": (250.0, 300.0),
        "requires": ("error_mrp", "unswitched"),
        "why": "in the shadow set every θ_ei <= 180°, so AAEM <= 180°",
    },
    "fig6_axis": {
        "text": "Fig 6: Case 2 RAEM plotted on a 0-140° axis (ticks every 20°)",
        "runs": ("case2",),
        "value": _peak("raem_peak_deg", "case2"),
        "what": "RAEM peak",
        "interval": (120.0, 140.0),
    },
    "fig7_axis": {
        "text": "Fig 7: Case 2 θ_1-θ_4 plotted on a 0-160° axis (ticks every 20°)",
        "runs": ("case2",),
        "value": _peak("theta_plotted_peak_deg", "case2"),
        "what": "θ_1-4 peak",
        "interval": (140.0, 160.0),
    },
    "fig5_6_insets": {
        "text": "Figs 5-6 insets (0-0.1°): Case 2's AAEM and RAEM end within 0.1° in the 100 s",
        "runs": ("case2",),
        "value": _steady("case2"),
        "what": "max steady AAEM / RAEM",
        "interval": (0.0, 0.1),
    },
    "fig8_9_insets": {
        "text": "Figs 8-9 insets (0-0.04°): Cases 3a-3c's AAEM and RAEM end within 0.04° in the 100 s",
        "runs": ("case3c", "case3a", "case3b"),
        "value": _steady("case3c", "case3a", "case3b"),
        "what": "max steady AAEM / RAEM",
        "interval": (0.0, 0.04),
    },
}
"""Figure-level checks (Figs 1-9 as printed, ``../shared/seed``).  An autoscaled axis ends at the first tick above the
data, so a peak lies in the top tick interval ``(top - tick, top]``; Fig 4's axes are ±2 N m and the text says the
bound is reached; the insets span the whole 100 s, so their limits are set by hand and bound the final errors from
above (Figs 1-2's insets, 0-0.04° and 0-0.02°, are the accuracy claims').  ``θ`` is the principal angle of the error
MRP the law uses (:func:`figure_numbers`)."""


def _s(x: float) -> str:
    return "–" if not math.isfinite(x) else f"{x:.2f} s"


def _d(x: float) -> str:
    return f"{x:.3g}°"


def _figure_number_text(spec: Mapping[str, Any], value: float) -> str:
    lo, hi = spec["interval"]
    unit = spec.get("unit", "°")
    fmt = f"{value:.4g} {unit}" if unit != "°" else (f"{value:.1f}°" if value >= 1 else _d(value))
    where = f"= {0.5 * (lo + hi):.4g} {unit}" if hi - lo < 1e-3 * hi else f"in ({lo:g}, {hi:g}]"
    return f"{spec['what']} {fmt} ({'' if lo < value <= hi else 'not '}{where})"


def _claim_numbers(cid: str, runs: Mapping[str, ExplainRun], tol: float) -> str:
    R = {k: r.record for k, r in runs.items()}
    if cid == "settling_27s":
        c1 = R["case1"]
        return f"Case 1 settles to {tol:g}°: AAEM {_s(c1.settling('aaem', tol))}, RAEM {_s(c1.settling('raem', tol))}"
    if cid in ("tracking_accuracy", "relative_accuracy"):
        c1 = R["case1"]
        m = "AAEM" if cid == "tracking_accuracy" else "RAEM"
        v = c1.aaem_steady_max_deg if m == "AAEM" else c1.raem_steady_max_deg
        return f"Case 1 max {m} over the last {c1.steady_window_s:g} s: {_d(v)}"
    if cid == "saturation_at_start":
        c1 = R["case1"]
        last = c1.last_saturation_s
        sat = c1.saturated_time_s
        return (
            f"Case 1 last saturation {'never' if not math.isfinite(last) else f'at {last:.2f} s'}, saturated "
            f"{min(sat):.1f}-{max(sat):.1f} s per agent"
        )
    if cid == "case2_slower":
        s1, s2 = R["case1"].settling("aaem", tol), R["case2"].settling("aaem", tol)
        return f"AAEM settles to {tol:g}°: Case 1 {_s(s1)}, Case 2 {_s(s2)} (horizon {R['case2'].t_final:g} s)"
    if cid == "case2_accuracy":
        c2 = R["case2"]
        r = c2 if c2.settled(tol) or "case2_long" not in R else R["case2_long"]
        return (
            f"{r.title}: settles to {tol:g}° at {_s(r.settling('aaem', tol))}; max over the last "
            f"{r.steady_window_s:g} s: AAEM {_d(r.aaem_steady_max_deg)}, RAEM {_d(r.raem_steady_max_deg)}"
        )
    if cid == "case3_ordering":
        return "; ".join(
            f"Case {R[k].case if k != 'case3c' else '3c'}: AAEM {_d(R[k].aaem_steady_max_deg)}, RAEM "
            f"{_d(R[k].raem_steady_max_deg)}" + ("" if R[k].settled(tol) else " (not settled)")
            for k in ("case3a", "case3b", "case3c")
            if k in R
        )
    spec = FIGURE_CHECKS[cid]
    if not all(k in runs for k in spec["runs"]):
        return "not all runs flown"
    angles = spec.get("unit", "°") == "°" and "peak" in spec["what"]  # θ, AAEM, RAEM from the law's error MRP
    return _figure_number_text(spec, spec["value"](runs)) + (
        f", θ of the {runs[spec['runs'][0]].figures['error_mrp']} error MRP" if angles else ""
    )


def _decide_claim(cid: str, runs: Mapping[str, ExplainRun], tol: float) -> bool | list[str]:
    if cid == "case2_accuracy":
        if "case2" not in runs:
            return ["case2"]
        if not runs["case2"].record.settled(tol) and "case2_long" not in runs:
            return ["case2_long"]
    elif cid == "case3_ordering":
        for k in ("case3c", "case3a", "case3b"):  # Case 3c is Case 1: usually flown already
            if k not in runs:
                return [k]
            if not runs[k].record.settled(tol):
                return False
    else:
        missing = [k for k in CLAIM_RUNS[cid] if k not in runs]
        if missing:
            return missing
    return claim_holds(cid, {k: r.record for k, r in runs.items()}, tol)


def _decide_figure(spec: Mapping[str, Any], runs: Mapping[str, ExplainRun]) -> bool | list[str]:
    lo, hi = spec["interval"]
    for i, k in enumerate(spec["runs"]):
        if k not in runs:
            return [k]
        if hi < spec["value"]({r: runs[r] for r in spec["runs"][: i + 1]}):  # a bound exceeded already
            return False
    return lo < spec["value"](runs) <= hi


def _checks(claims: Sequence[ClaimVerdict]) -> list[_Check]:
    out = []
    for c in claims:
        out.append(
            _Check(
                c.id,
                c.claim,
                tuple(dict.fromkeys((*CLAIM_RUNS[c.id], "case3c") if c.id == "case3_ordering" else CLAIM_RUNS[c.id])),
                c.id in CLAIM_USES_TOLERANCE,
                lambda runs, tol, cid=c.id: _decide_claim(cid, runs, tol),
                lambda runs, tol, cid=c.id: _claim_numbers(cid, runs, tol),
            )
        )
    for cid, spec in FIGURE_CHECKS.items():
        out.append(
            _Check(
                cid,
                spec["text"],
                spec["runs"],
                False,
                lambda runs, tol, spec=spec: _decide_figure(spec, runs),
                lambda runs, tol, cid=cid: _claim_numbers(cid, runs, tol),
            )
        )
    return out


def _tol(candidate: Candidate) -> float:
    t = candidate.tolerance()
    return SETTLING_TOLERANCES_DEG[0] if t is None else t


def _available(candidate: Candidate, keys: Iterable[str], runner: _Runner) -> dict[str, ExplainRun]:
    return {k: runner.get(candidate, k) for k in keys if (candidate.simulated(), k) in runner.runs}


def _failed(runs: Mapping[str, ExplainRun]) -> str:
    return next((f"{k}: {r.error}" for k, r in runs.items() if r.error), "")


def _needed(check: _Check, candidate: Candidate, runner: _Runner) -> list[str]:
    """The run keys still missing to judge ``check`` at ``candidate`` (none once a run has failed)."""
    runs = _available(candidate, (*check.runs, "case2_long"), runner)
    if _failed(runs):
        return []
    verdict = check.decide(runs, _tol(candidate))
    return verdict if isinstance(verdict, list) else []


def _judge(check: _Check, candidate: Candidate, runner: _Runner) -> bool:
    runs = _available(candidate, (*check.runs, "case2_long"), runner)
    if _failed(runs):
        return False
    verdict = check.decide(runs, _tol(candidate))
    if isinstance(verdict, list):
        raise RuntimeError(f"{check.id}: runs {verdict} missing")
    return bool(verdict)


def _all_runs(check: _Check, candidate: Candidate, runner: _Runner) -> list[str]:
    """Every run of the check's numbers (Case 2's long run only when Case 2 has not settled)."""
    keys = [k for k in check.runs if k != "case2_long"]
    if "case2_long" in check.runs:
        c2 = (candidate.simulated(), "case2")
        if c2 not in runner.runs or runner.runs[c2].error:
            return [*keys]
        if not runner.runs[c2].record.settled(_tol(candidate)):
            keys.append("case2_long")
    return keys


def _numbers(check: _Check, candidate: Candidate, runner: _Runner) -> str:
    runs = _available(candidate, (*check.runs, "case2_long"), runner)
    failed = _failed(runs)
    return f"the run failed ({failed})" if failed else check.numbers(runs, _tol(candidate))


# ----------------------------------------------------------------------------- the search


PAIRED_CHOICES = ("error_model", "error_mrp")
"""The discrete choices held in pairs: the two modelling choices (the integrator and step change no single claim)."""
LEVELS = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.8, 1.0)
"""Distance levels of the best-first search of single changes (a discrete choice is at 1)."""
PAIR_LEVELS = (1.2, 1.4, 1.6, 1.8, 2.0)
"""Distance levels of pairs (a discrete choice, 1, plus the other change)."""


class _Axis:
    """One line of the search for one check: one setting varied, ``fixed`` changes held.

    Grid values are tried in order of distance; a reproducing grid value brackets a threshold with the nearest tried
    value towards the default (which fails), and the bracket is bisected to the setting's resolution.
    """

    def __init__(self, check: _Check, setting: Setting, by_name: Mapping[str, Setting], fixed: Candidate):
        self.check, self.setting, self.by_name, self.fixed = check, setting, by_name, fixed
        self.base_d = sum(by_name[n].distance(v) for n, v in fixed.changes)
        self.trials: dict[Any, bool] = {}
        self.brackets: dict[bool, list[Any]] = {}  # side (value > default) -> [fails, holds]

    def candidate(self, value: Any) -> Candidate:
        changes = dict(self.fixed.changes)
        changes[self.setting.name] = value
        return Candidate(tuple(sorted(changes.items(), key=lambda kv: _ORDER.get(kv[0], 99))))

    def d(self, value: Any) -> float:
        return self.base_d + self.setting.distance(value)

    def _side(self, value: Any) -> bool:
        return bool(self.setting.continuous and value > float(self.setting.default))

    def _sides(self) -> list[bool]:
        return sorted({self._side(v) for v in self.setting.grid})

    def _side_lower(self, side: bool) -> float:
        """No untried threshold on ``side`` (without a bracket) is nearer than this."""
        if not self.setting.continuous:
            return min((self.d(v) for v in self.setting.grid if v not in self.trials), default=math.inf)
        return max((self.d(v) for v in self.trials if self._side(v) == side), default=self.base_d)

    def untried(self, level: float, bound: float = math.inf) -> list[Any]:
        """Grid values within ``level`` not tried yet, on sides without a bracket that could still beat ``bound``."""
        return [
            v
            for v in self.setting.grid
            if v not in self.trials
            and self.d(v) <= level + 1e-12
            and self._side(v) not in self.brackets
            and self._side_lower(self._side(v)) < bound
        ]

    def record(self, value: Any, ok: bool) -> None:
        """The verdict at ``value``: a grid value opens a bracket on its side; a bisection point narrows it."""
        self.trials[value] = ok
        side = self._side(value)
        if side in self.brackets:
            b = self.brackets[side]
            if b[0] != value and b[1] != value and min(b, key=float) < value < max(b, key=float):
                b[1 if ok else 0] = value
            return
        if ok and self.setting.continuous:
            tried = [v for v in self.trials if self._side(v) == side and self.d(v) < self.d(value)]
            inner = max(tried, key=self.d) if tried else self.setting.default
            self.brackets[side] = [inner, value]

    def upper(self) -> float:
        """Distance of the nearest reproducing value found (inf if none)."""
        hits = [self.d(b[1]) for b in self.brackets.values()]
        if not self.setting.continuous:
            hits += [self.d(v) for v, ok in self.trials.items() if ok]
        return min(hits, default=math.inf)

    def frontier(self) -> float:
        """No untried threshold of this axis is nearer than this."""
        if not self.setting.continuous:
            return min((self.d(v) for v in self.setting.grid if v not in self.trials), default=math.inf)
        out = math.inf
        for side in self._sides():
            if side in self.brackets:  # a bisected bracket is known to the resolution: its threshold is the value
                fails, holds = self.brackets[side]
                out = min(out, self.d(holds if self.resolved(holds) else fails))
                continue
            if any(self._side(v) == side and v not in self.trials for v in self.setting.grid):
                out = min(out, self._side_lower(side))
        return out

    def open_bracket(self, bound: float) -> Any | None:
        """The next bisection point of a bracket that could still beat ``bound``, or None."""
        s = self.setting
        for side in sorted(self.brackets, key=lambda k: self.d(self.brackets[k][1])):
            fails, holds = self.brackets[side]
            if self.d(fails) >= bound:
                continue
            mid = s.midpoint(fails, holds)
            if not s.resolved(fails, holds) and mid not in (fails, holds) and mid not in self.trials:
                return mid
        return None

    def best(self) -> Any | None:
        """The reproducing value of least distance."""
        if self.setting.continuous:
            if not self.brackets:
                return None
            return min((b[1] for b in self.brackets.values()), key=self.d)
        hits = [v for v, ok in self.trials.items() if ok]
        return min(hits, key=lambda v: (self.d(v), str(v))) if hits else None

    def bracket_of(self, value: Any) -> list[Any]:
        return self.brackets[self._side(value)]

    def resolved(self, value: Any) -> bool:
        fails, holds = self.bracket_of(value)
        return self.setting.resolved(fails, holds) or self.setting.midpoint(fails, holds) in (fails, holds)


class _CheckSearch:
    """Best-first search of one check over its axes: grid levels by distance, bisection, then the values beyond.

    The search stops when the nearest reproducing change found is no farther than any change not yet tried could
    be (its bracket bisected to the resolution), then tries the grid values beyond it on its axis (to say whether
    the claim keeps holding, ">= threshold").
    """

    def __init__(self, check: _Check, axes: Sequence[_Axis], levels: Sequence[float]):
        self.check = check
        self.axes = list(axes)
        self.levels = list(levels)
        self.level = 0.0
        self.pending: list[tuple[_Axis, Any]] = []
        self.phase = "search"
        self.best: _Axis | None = None
        self.capped = False

    @property
    def done(self) -> bool:
        return self.phase == "done"

    def extend(self, axes: Sequence[_Axis], levels: Sequence[float]) -> None:
        """Continue with more axes (pairs) on further levels."""
        self.axes += list(axes)
        self.levels = list(levels)
        self.phase = "search"

    def wanted(self, runner: _Runner) -> list[tuple[Candidate, str]]:
        """Runs of the pending values: stage by stage on the grid, all at once for a bisection point."""
        out = []
        for axis, v in self.pending:
            cand = axis.candidate(v)
            needed = _needed(self.check, cand, runner)
            if needed and v not in axis.setting.grid:
                needed = [k for k in self.check.runs if (cand.simulated(), k) not in runner.runs]
            out += [(cand, k) for k in needed]
        return out

    def advance(self, runner: _Runner, level_cap: float = math.inf) -> None:
        """Judge the pending values whose runs are in; choose what to try next (no level above ``level_cap``)."""
        while not self.done:
            for axis, v in list(self.pending):
                cand = axis.candidate(v)
                if _needed(self.check, cand, runner):
                    continue
                self.pending.remove((axis, v))
                axis.record(v, _judge(self.check, cand, runner))
            if self.pending:
                return
            if self.phase == "beyond":
                self.phase = "done"
                return
            upper = min((a.upper() for a in self.axes), default=math.inf)
            self.pending = [(a, m) for a in self.axes if (m := a.open_bracket(upper)) is not None]
            if self.pending:
                continue
            lower = min((a.frontier() for a in self.axes), default=math.inf)
            if upper > lower:  # a nearer change may hide in the next level
                nxt = [lv for lv in self.levels if self.level + 1e-12 < lv <= level_cap + 1e-12]
                while nxt and not self.pending:
                    self.level = nxt.pop(0)
                    self.pending = [(a, v) for a in self.axes for v in a.untried(self.level, upper)]
                if self.pending:
                    continue
                if any(a.untried(math.inf) for a in self.axes):
                    self.capped = True  # levels left that the cap (the pair budget) does not allow
            if upper == math.inf:
                self.phase = "done"
                return
            self.best = min((a for a in self.axes if a.best() is not None), key=_rank)
            b = self.best.best()
            side = self.best._side(b)
            s = self.best.setting
            beyond = sorted(
                (v for v in s.grid if s.continuous and self.best._side(v) == side and self.best.d(v) > self.best.d(b)),
                key=self.best.d,
            )
            self.pending = [(self.best, v) for v in beyond if v not in self.best.trials]
            self.phase = "beyond"


_ORDER = {
    n: i
    for i, n in enumerate(
        ("torque_limit", "alpha", "delta", "boundary_layer", "error_model", "error_mrp", "integration", "tolerance")
    )
}


# ----------------------------------------------------------------------------- results


@dataclass
class Evidence:
    """The evidence run of an explanation: its scenario file and numbers.

    Parameters
    ----------
    key : str
        The candidate's key (``explain_torque_limit_47.7``).
    change : str
        The change, as ``setting = value``.
    scenario_file : str
        The scenario file, relative to the report folder (``explain/<key>.toml``).
    runs : list of str
        The runs of :func:`~fsmctl.studies.reproduce.run_plan` flown on it.
    figures : list of str
        The Figs 1-4 checks of its Case 1 run (:data:`FIGURE_CHECKS`), one line each.
    figures_fit : list of str
        The ids of the Figs 1-4 checks its Case 1 run passes.
    rerun_identical : bool
        The file, re-loaded and simulated again, gives the same numbers.
    warnings : list of str, optional
        Warnings of the evidence runs.

    Examples
    --------
    >>> from fsmctl.studies import Evidence
    >>> ev = Evidence(key="explain_torque_limit_47.7", change="torque limit = 47.7 N m",
    ...               scenario_file="explain/explain_torque_limit_47.7.toml", runs=["case1"], figures=[],
    ...               figures_fit=[], rerun_identical=True)
    >>> ev.scenario_file.startswith("explain/"), ev.rerun_identical
    (True, True)
    """

    key: str
    """candidate key (``explain_torque_limit_47.7``)"""
    change: str
    scenario_file: str
    """the scenario file, relative to the report folder (``explain/<key>.toml``)"""
    runs: list[str]
    """the runs of :func:`~fsmctl.studies.reproduce.run_plan` flown on it"""
    figures: list[str]
    """the Figs 1-4 checks of its Case 1 run (:data:`FIGURE_CHECKS`), one line each"""
    figures_fit: list[str]
    """the ids of the Figs 1-4 checks its Case 1 run passes"""
    rerun_identical: bool
    """the file, re-loaded and simulated again, gives the same numbers"""
    warnings: list[str] = field(default_factory=list)


@dataclass
class Explanation:
    """What would reproduce one claim (or figure-level check): the smallest change found, or none in the ranges.

    :func:`explain` returns them (it flies the reproduction's runs again for every candidate change, minutes to hours:
    ``fsmctl reproduce --explain``); this shows how to read one.

    Parameters
    ----------
    id : str
        The claim's id (:data:`~fsmctl.studies.reproduce.CLAIM_IDS`) or the figure check's.
    claim : str
        What the paper claims.
    verdict : str
        ``fsmctl reproduce``'s verdict (figure checks: ``fits`` / ``does not fit``).
    status : str
        :data:`EXPLAINED`, :data:`NOT_EXPLAINED` or :data:`ALREADY_REPRODUCED`.
    reproduced_if : str
        The statement of the smallest change (``torque limit >= 47.7 N m (bisected to 0.1 N m; ...)``).
    change : str, optional
        The change, as ``setting = value`` (``and`` for a pair).
    distance : float, optional
        Its distance (:meth:`Setting.distance`; NaN: none found).
    baseline : str, optional
        The claim's numbers on the base scenario.
    numbers : str, optional
        The claim's numbers on the evidence run.
    outside : str, optional
        For a bisected threshold: the value just outside it and the numbers there (it fails).
    evidence : Evidence or None, optional
        The evidence run.
    alternatives : list of str, optional
        Other changes that also reproduce it, by distance.
    searched : list of str, optional
        What was searched.
    pairs : str, optional
        What was tried in pairs, when no single change reproduces it.

    Examples
    --------
    >>> from fsmctl.studies import Evidence, Explanation
    >>> from fsmctl.studies.explain import EXPLAINED
    >>> ev = Evidence("explain_torque_limit_47.7", "torque limit = 47.7 N m", "explain/explain_torque_limit_47.7.toml",
    ...               ["case1"], [], [], True)
    >>> e = Explanation(id="settling_27s", claim="the formation settles in 27 s", verdict="differs", status=EXPLAINED,
    ...                 reproduced_if="torque limit >= 47.7 N m", change="torque limit = 47.7 N m", distance=0.29,
    ...                 evidence=ev)
    >>> e.status, e.to_dict()["evidence"]["key"]
    ('reproduced if', 'explain_torque_limit_47.7')
    """

    id: str
    claim: str
    verdict: str
    """``fsmctl reproduce``'s verdict (figure checks: ``fits`` / ``does not fit``)"""
    status: str
    """:data:`EXPLAINED`, :data:`NOT_EXPLAINED` or :data:`ALREADY_REPRODUCED`"""
    reproduced_if: str
    change: str = ""
    """the change, as ``setting = value`` (``and`` for a pair)"""
    distance: float = math.nan
    baseline: str = ""
    """the claim's numbers on the base scenario"""
    numbers: str = ""
    """the claim's numbers on the evidence run"""
    outside: str = ""
    """for a bisected threshold: the value just outside it and the numbers there (it fails)"""
    evidence: Evidence | None = None
    alternatives: list[str] = field(default_factory=list)
    """other changes that also reproduce it, by distance"""
    searched: list[str] = field(default_factory=list)
    pairs: str = ""
    """what was tried in pairs, when no single change reproduces it"""

    def to_dict(self) -> dict:
        """JSON-ready (non-finite numbers as None).

        Returns
        -------
        dict
            The fields, the evidence as a nested dict.
        """
        d = asdict(self)
        d["distance"] = self.distance if math.isfinite(self.distance) else None
        return d


def _statement(axis: _Axis) -> str:
    """``"torque limit >= 47.7 N m (bisected to 0.1 N m; 47.6 N m does not)"``."""
    s, v = axis.setting, axis.best()
    fixed = axis.fixed.text(axis.by_name) + " and " if axis.fixed.changes else ""
    if not s.continuous:
        return fixed + s.value_text(v)
    unit = f" {s.unit}" if s.unit else ""
    fails, holds = axis.bracket_of(v)
    if not axis.resolved(v):
        return f"{fixed}{s.label} between {_num(fails)} and {_num(holds)}{unit} (grid bracket, not bisected)"
    side = axis._side(v)
    beyond = [g for g in s.grid if axis._side(g) == side and axis.d(g) > axis.d(v)]
    failing = [g for g in beyond if axis.trials.get(g) is False]
    note = f"bisected to {s.resolution_text()}; {_num(fails)}{unit} does not"
    if failing:
        return (
            f"{fixed}{s.label} = {_num(v)}{unit} (the threshold nearest the default, {note}; fails again at "
            f"{', '.join(_num(g) for g in failing)}{unit})"
        )
    untried = [g for g in beyond if g not in axis.trials]
    if untried:
        note += "; the values beyond were not all tried"
    return f"{fixed}{s.label} {'>=' if side else '<='} {_num(v)}{unit} ({note})"


def _rank(axis: _Axis) -> tuple:
    return (len(axis.fixed.changes), axis.d(axis.best()), _ORDER[axis.setting.name], axis.fixed.changes)


def _searched(settings: Sequence[Setting], check: _Check) -> list[str]:
    return [s.range_text() for s in settings if not s.grading or check.uses_tolerance]


def _single_axes(check: _Check, settings: Sequence[Setting], by_name) -> list[_Axis]:
    req = FIGURE_CHECKS.get(check.id, {}).get("requires")
    if req:
        return [_Axis(check, by_name[req[0]], by_name, Candidate())] if req[0] in {s.name for s in settings} else []
    return [_Axis(check, s, by_name, Candidate()) for s in settings if not s.grading or check.uses_tolerance]


def _pair_axes(check: _Check, settings: Sequence[Setting], by_name) -> list[_Axis]:
    """A discrete choice held, every other setting varied (choices once per pair)."""
    req = FIGURE_CHECKS.get(check.id, {}).get("requires")
    out = []
    for held in settings:
        if held.name not in PAIRED_CHOICES or (req and held.name != req[0]):
            continue
        for value in held.grid if not req else (req[1],):
            for other in settings:
                if other.name == held.name or (other.grading and not check.uses_tolerance):
                    continue
                if not other.continuous and not req and _ORDER[other.name] < _ORDER[held.name]:
                    continue  # the pair (other, held) is tried with other held
                out.append(_Axis(check, other, by_name, Candidate(((held.name, value),))))
    return out


def explain(
    source: str,
    claims: Sequence[ClaimVerdict],
    out_dir: str | Path,
    *,
    fast: bool = False,
    executor: cf.Executor | None = None,
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
        :func:`fsmctl.studies.reproduce.evaluate_claims` of the base runs.
    out_dir : str or Path
        The report folder: the evidence scenario files go to ``out_dir/explain/``.
    fast : bool
        The short horizon of ``fsmctl reproduce --fast`` (the runs are those of :func:`run_plan` in fast mode).
    executor : concurrent.futures.Executor, optional
        Worker pool for the runs (None: run in this process).
    progress : bool, optional
        tqdm bar over the runs (default: when stderr is a terminal).
    log : callable, optional
        Receives progress lines.
    settings : sequence of str, optional
        Search only these settings (names of :func:`search_settings`); default all.
    checks : sequence of str, optional
        Explain only these claims / figure checks (ids); default all.
    pair_budget_runs : int
        Most runs spent on pairs of changes (0: no pairs).

    Returns
    -------
    list of Explanation
        One per claim in the paper's order (:data:`~fsmctl.studies.reproduce.CLAIM_IDS`), then one per figure-level
        check (:data:`FIGURE_CHECKS`).

    Raises
    ------
    InputError
        ``settings`` names a setting :func:`search_settings` does not have (a ``ValueError``).

    See Also
    --------
    Explanation : how to read the result (with an example).
    """
    from tqdm.auto import tqdm

    from fsmctl.model.laws import resolve_law
    from fsmctl.model.scenario import BUILTIN_SCENARIOS
    from fsmctl.studies.reproduce import load_case

    say = log or (lambda _line: None)
    started = _time.perf_counter()
    base = source if source in BUILTIN_SCENARIOS else str(Path(source).expanduser().resolve())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        all_settings = search_settings(load_case(base, "1"))
    unknown = sorted(set(settings or ()) - {s.name for s in all_settings})
    if unknown:
        raise InputError(f"unknown setting(s) {unknown} (settings: {[s.name for s in all_settings]})")
    chosen = [s for s in all_settings if settings is None or s.name in settings]
    by_name = {s.name: s for s in all_settings}
    if "error_mrp" in {s.name for s in chosen}:
        resolve_law(str(law_script(UNSWITCHED_LAW)))  # derived once (cached) before the workers need it
    order = {cid: i for i, cid in enumerate(CLAIM_IDS)}
    claims = sorted(claims, key=lambda c: order.get(c.id, len(order)))
    all_checks = [ch for ch in _checks(claims) if checks is None or ch.id in checks]
    verdicts = {c.id: c.verdict for c in claims}
    if progress is None:
        progress = sys.stderr.isatty()
    bar = tqdm(total=0, desc="explain", unit="run", disable=not progress, file=sys.stderr)
    runner = _Runner(base, by_name, fast, executor, bar)
    base_c = Candidate()
    pair_note = ""
    try:
        _complete(runner, [(base_c, ch) for ch in all_checks])
        baseline = {ch.id: _judge(ch, base_c, runner) for ch in all_checks}
        failing = [ch for ch in all_checks if not baseline[ch.id]]
        searches = {ch.id: _CheckSearch(ch, _single_axes(ch, chosen, by_name), LEVELS) for ch in failing}
        say(
            f"  explain: {len(failing)} claims / figure checks not reproduced; single changes of {len(chosen)} settings"
        )
        _drive(list(searches.values()), runner)
        say(f"  explain: single changes: {runner.simulated} runs ({runner.cpu_s:.0f} s of simulation)")
        left = [
            s
            for s in searches.values()
            if s.best is None and (s.check.id in CLAIM_IDS or FIGURE_CHECKS.get(s.check.id, {}).get("requires"))
        ]
        if left and pair_budget_runs > 0:
            for s in left:
                s.extend(_pair_axes(s.check, chosen, by_name), PAIR_LEVELS)
            spent = _drive(left, runner, budget=pair_budget_runs)
            reached = max((s.level for s in left), default=0.0)
            pair_note = (
                f"pairs (a discrete choice held, each other setting searched) tried for {len(left)} checks with "
                f"{spent} runs, up to distance {reached:g}"
                + (f" (budget {pair_budget_runs} runs)" if any(s.capped for s in left) else "")
            )
            say(f"  explain: {pair_note} ({runner.cpu_s:.0f} s of simulation so far)")
        best = {cid: s.best for cid, s in searches.items() if s.best is not None}
        shown = [(a.candidate(a.best()), s.check) for s in searches.values() if (a := s.best)]
        shown += [
            (a.candidate(a.bracket_of(a.best())[0]), s.check)
            for s in searches.values()
            if (a := s.best) and a.setting.continuous
        ]
        _complete(runner, shown)
        evidence = _write_evidence(base, best, failing, runner, by_name, Path(out_dir), fast)
    finally:
        bar.close()
    out = []
    for ch in all_checks:
        verdict = verdicts.get(ch.id) or ("fits" if baseline[ch.id] else "does not fit")
        base_numbers = _numbers(ch, base_c, runner)
        if baseline[ch.id]:
            out.append(
                Explanation(ch.id, ch.text, verdict, ALREADY_REPRODUCED, "no change needed", baseline=base_numbers)
            )
            continue
        search = searches[ch.id]
        searched = _searched(chosen, ch)
        req = FIGURE_CHECKS.get(ch.id, {}).get("requires")
        if req:
            searched = [
                f"only with the {by_name[req[0]].value_text(req[1])} ({FIGURE_CHECKS[ch.id]['why']})",
                *searched,
            ]
        searched.append(f"best-first by distance up to {search.level:g}")
        a = search.best
        if a is None:
            out.append(
                Explanation(
                    ch.id,
                    ch.text,
                    verdict,
                    NOT_EXPLAINED,
                    NOT_EXPLAINED,
                    baseline=base_numbers,
                    searched=searched,
                    pairs=pair_note if search in left else "",
                )
            )
            continue
        value = a.best()
        cand = a.candidate(value)
        outside = ""
        if a.setting.continuous:
            oc = a.candidate(a.bracket_of(value)[0])
            outside = f"at {oc.text(by_name) if oc.changes else 'the default'}: {_numbers(ch, oc, runner)}"
        others = sorted((x for x in search.axes if x.best() is not None and x is not a), key=_rank)
        out.append(
            Explanation(
                ch.id,
                ch.text,
                verdict,
                EXPLAINED,
                _statement(a),
                change=cand.text(by_name),
                distance=a.d(value),
                baseline=base_numbers,
                numbers=_numbers(ch, cand, runner),
                outside=outside,
                evidence=evidence[cand],
                alternatives=[f"{_statement(x)} (distance {x.d(x.best()):.2f})" for x in others],
                searched=searched,
                pairs=pair_note if a.fixed.changes else "",
            )
        )
    say(
        f"  explain: {runner.simulated} runs ({runner.cpu_s:.0f} s of simulation) in "
        f"{_time.perf_counter() - started:.1f} s"
    )
    return out


def _complete(runner: _Runner, pairs: Sequence[tuple[Candidate, _Check]]) -> None:
    """Fly every run the checks' numbers show at the candidates (rounds: Case 2's long run depends on Case 2)."""
    while wanted := [
        (c, k) for c, ch in pairs for k in _all_runs(ch, c, runner) if (c.simulated(), k) not in runner.runs
    ]:
        runner.run(wanted)


def _drive(searches: Sequence[_CheckSearch], runner: _Runner, budget: int | None = None) -> int:
    """Advance the searches round by round (each round's runs go to the pool together); returns the runs flown.

    With a ``budget`` no search starts a new distance level once that many runs have been flown.
    """
    start = runner.simulated
    while True:
        cap = math.inf
        if budget is not None and runner.simulated - start >= budget:
            cap = -math.inf
        for s in searches:
            s.advance(runner, cap)
        wanted = [w for s in searches if not s.done for w in s.wanted(runner)]
        if not wanted:
            if all(s.done for s in searches):
                return runner.simulated - start
            continue
        runner.run(wanted)


def _write_evidence(base, best, failing, runner, settings, out: Path, fast: bool):
    """Write each evidence candidate's scenario file, re-run it from the file and compare the numbers."""
    folder = out / EXPLAIN_DIR
    keys: dict[Candidate, list[str]] = {}
    for ch in failing:
        a = best.get(ch.id)
        if a is None:
            continue
        cand = a.candidate(a.best())
        ks = keys.setdefault(cand, [])
        for k in (*_all_runs(ch, cand, runner), "case1"):
            if k not in ks:
                ks.append(k)
    runner.run([(cand, k) for cand, ks in keys.items() for k in ks])
    files: dict[Candidate, Path] = {}
    for cand in sorted(keys):
        explains = [ch.id for ch in failing if (a := best.get(ch.id)) and a.candidate(a.best()) == cand]
        law_path = None
        if any(n == "error_mrp" for n, _ in cand.changes):
            folder.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(law_script(UNSWITCHED_LAW), folder / UNSWITCHED_LAW)
            law_path = UNSWITCHED_LAW
        data = candidate_source(base, cand.simulated(), settings, law_path)
        cases = list(dict.fromkeys(_RUN_SPECS[k].case for k in keys[cand]))
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
        if fast:
            comments.append("fsmctl reproduce --fast flew it for 10 s with output every 0.05 s")
        if "case2_long" in keys[cand]:
            comments.append("Case 2 was also flown on a 3x longer horizon (t_final x3, output every 0.05 s)")
        path = folder / f"{cand.key()}.toml"
        write_text(path, scenario_text(data, comments))
        files[cand] = path
    tasks = [(cand, k) for cand in sorted(keys) for k in keys[cand]]
    reruns: dict[tuple[Candidate, str], ExplainRun] = {}
    runner.bar.total = (runner.bar.total or 0) + len(tasks)
    runner.bar.refresh()
    if runner.executor is None:
        for cand, k in tasks:
            reruns[(cand, k)] = _simulate(str(files[cand]), cand, _RUN_SPECS[k], fast)
            runner.bar.update(1)
    else:
        futs = {runner.executor.submit(_simulate, str(files[c]), c, _RUN_SPECS[k], fast): (c, k) for c, k in tasks}
        for fut in cf.as_completed(futs):
            reruns[futs[fut]] = fut.result()
            runner.bar.update(1)
    figure_checks = [k for k, spec in FIGURE_CHECKS.items() if spec["runs"] == ("case1",)]
    out_map = {}
    for cand in sorted(keys):
        c1 = {"case1": runner.get(cand, "case1")}
        failed = _failed(c1)
        out_map[cand] = Evidence(
            key=cand.key(),
            change=cand.text(settings),
            scenario_file=files[cand].relative_to(out).as_posix(),
            runs=list(keys[cand]),
            figures=[f"Case 1 failed ({failed})"]
            if failed
            else [
                f"{k.split('_')[0].replace('fig', 'Fig ')}: {_claim_numbers(k, c1, _tol(cand))}" for k in figure_checks
            ],
            figures_fit=[] if failed else [k for k in figure_checks if _decide_figure(FIGURE_CHECKS[k], c1) is True],
            rerun_identical=all(
                _same_numbers(runner.get(cand, k).record, reruns[(cand, k)].record) for k in keys[cand]
            ),
            warnings=sorted({w for k in keys[cand] for w in runner.get(cand, k).warnings}),
        )
    return out_map


def _same_numbers(a: RunRecord | None, b: RunRecord | None) -> bool:
    """Bit-identical metric series and saturation time (NaN = never); two failed runs count as the same."""
    if a is None or b is None:
        return a is b
    la, lb = a.summary["last_saturation_s"], b.summary["last_saturation_s"]
    return (
        np.array_equal(a.time, b.time)
        and np.array_equal(a.aaem_deg, b.aaem_deg)
        and np.array_equal(a.raem_deg, b.raem_deg)
        and (la == lb or (math.isnan(la) and math.isnan(lb)))
    )


# ----------------------------------------------------------------------------- texts


def _md(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def _searched_cell(e: Explanation) -> str:
    if e.status == NOT_EXPLAINED:
        return "; ".join([*e.searched, *([e.pairs] if e.pairs else [])])
    level = e.searched[-1] if e.searched else ""
    return f"the settings listed below, {level}" + (f"; {e.pairs}" if e.pairs else "")


def _row(e: Explanation) -> str:
    if e.status == ALREADY_REPRODUCED:
        row = [f"**{e.id}**: {e.claim}", e.verdict, "no change needed", "-", "-", e.baseline, "-", "-", "-"]
    elif e.status == NOT_EXPLAINED:
        row = [f"**{e.id}**: {e.claim}", e.verdict, f"**{NOT_EXPLAINED}**", "-", "-", e.baseline, "-", "-"]
        row.append(_searched_cell(e))
    else:
        ev = e.evidence
        run = f"`{ev.key}` ([{ev.scenario_file}]({ev.scenario_file}); runs {', '.join(ev.runs)}"
        run += "; re-run from the file: identical)" if ev.rerun_identical else "; **re-run from the file differs**)"
        if ev.warnings:
            run += " warnings: " + "; ".join(ev.warnings)
        numbers = f"{e.baseline} → **{e.numbers}**" + (f" ({e.outside})" if e.outside else "")
        fits = ", ".join(k.split("_")[0].replace("fig", "Fig ") for k in ev.figures_fit) or "none"
        row = [
            f"**{e.id}**: {e.claim}",
            e.verdict,
            f"**{EXPLAINED} {e.reproduced_if}**",
            f"{e.distance:.2f}",
            run,
            numbers,
            f"fits {fits} of Figs 1-4: " + "; ".join(ev.figures),
            "; ".join(e.alternatives) or "-",
            _searched_cell(e),
        ]
    return "| " + " | ".join(_md(x) for x in row) + " |"


def markdown_section(explanations: Sequence[Explanation], fast: bool = False) -> list[str]:
    """The report section "What would reproduce each claim" (Markdown lines).

    Parameters
    ----------
    explanations : sequence of Explanation
        From :func:`explain`.
    fast : bool
        Whether the runs had the short horizon of ``--fast``.

    Returns
    -------
    list of str
        The section: the claims in the paper's order, then the figure-level checks, then the searched ranges.

    Examples
    --------
    >>> from fsmctl.studies import Evidence, Explanation, markdown_section
    >>> ev = Evidence("explain_torque_limit_47.7", "torque limit = 47.7 N m", "explain/explain_torque_limit_47.7.toml",
    ...               ["case1"], [], [], True)
    >>> e = Explanation("settling_27s", "the formation settles in 27 s", "differs", "reproduced if",
    ...                 "torque limit >= 47.7 N m", "torque limit = 47.7 N m", 0.29, evidence=ev)
    >>> lines = markdown_section([e])
    >>> lines[0]
    '## What would reproduce each claim'
    >>> row = [line for line in lines if line.startswith("| **settling_27s**")][0]
    >>> [cell.strip() for cell in row.split("|")[2:5]]
    ['differs', '**reproduced if torque limit >= 47.7 N m**', '0.29']
    """
    claims = [e for e in explanations if e.id in CLAIM_IDS]
    figs = [e for e in explanations if e.id not in CLAIM_IDS]
    L = [
        "## What would reproduce each claim",
        "",
        "For each claim that does not reproduce, the smallest change of one setting the paper leaves open (or may "
        "have misprinted) that makes the claim's own test pass (`fsmctl.studies.explain`). The default scenario is "
        "not changed: every explanation is a separate run, written as a scenario file (`extends` the paper's "
        "scenario with just the change) that `fsmctl simulate --scenario FILE --case 1` flies; `fsmctl reproduce` "
        "re-loads each file and checks that it gives the numbers below.",
        "",
        "*Distance* of a change: for a continuous setting, the fraction of the searched range moved from the "
        "scenario's value towards the end of the range (on a log scale for the torque limit, delta, phi and the "
        "tolerance, linear for alpha), in (0, 1]; a discrete choice (error kinematics, error MRP, integrator / step) "
        "counts 1; a pair adds its two distances. *Search*: grid values in order of distance until no untried value "
        "can be nearer than the change found; the bracket around a reproducing grid value is bisected to the "
        "setting's resolution; then the grid values beyond it are tried (whether the claim keeps holding). Pairs (one "
        "modelling choice held) only when no single change reproduces a claim, within a run budget."
        + (" **Fast mode: short horizon; these are not the explanations of the paper's 100 s runs.**" if fast else ""),
        "",
    ]
    todo = [e for e in claims if e.status != ALREADY_REPRODUCED]
    done = [e for e in todo if e.status == EXPLAINED]
    if todo:
        kinds: dict[str, list[str]] = {}
        for e in done:
            kinds.setdefault(e.change, []).append(e.id)
        fig4 = [e.id for e in done if "fig4_axis" in e.evidence.figures_fit]
        L += [
            f"In short: {len(done)} of the {len(todo)} claims not reproduced are reproduced by the changes below ("
            + "; ".join(f"{change}: {', '.join(ids)}" for change, ids in kinds.items())
            + f"); the evidence runs of {', '.join(fig4) if fig4 else 'none of them'} keep the applied torques within "
            "the ±2 N m that Fig 4 prints.",
            "",
        ]
    header = [
        "| {what} | verdict | reproduced if (smallest change) | distance | evidence run | default → evidence "
        "(just outside the threshold) | Figs 1-4 with the evidence | other changes that reproduce it | searched |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    L += [header[0].format(what="claim"), header[1], *(_row(e) for e in claims)]
    if figs:
        L += [
            "",
            "### Figure-level evidence",
            "",
            "What the printed Figs 1-9 show (axis ranges, the saturation level, the insets), checked like the claims: "
            "which change makes the printed figure possible.",
            "",
            header[0].format(what="figure check"),
            header[1],
            *(_row(e) for e in figs),
        ]
    ranges = list(dict.fromkeys(r for e in explanations for r in e.searched))
    if ranges:
        L += ["", "Searched settings and ranges:", ""]
        L += [f"- {r}" for r in ranges if not r.startswith(("best-first", "only with"))]
    L += [
        "",
        "Figure-level checks read the printed figures (`../shared/seed`): an autoscaled axis ends at the first tick "
        "above the data, so the peak lies in the top tick interval; θ is the principal angle of the error MRP the law "
        "uses (with the unswitched error MRP, `4 atan|σ_i ⊗ σ_d^-1|` up to 360°); the insets span the whole 100 s, so "
        "their ranges are set by hand and only bound the final errors.",
        "",
    ]
    return L


def text_lines(e: Explanation, indent: int, width: int = 110) -> list[str]:
    """Plain-text lines of one explanation for the terminal summary.

    Parameters
    ----------
    e : Explanation
        From :func:`explain`.
    indent : int
        Left margin.
    width : int
        Wrap width.

    Returns
    -------
    list of str
        ``reproduced if ...`` with the evidence file, or the searched ranges.

    Examples
    --------
    >>> from fsmctl.studies import Evidence, Explanation
    >>> from fsmctl.studies.explain import text_lines
    >>> ev = Evidence("explain_torque_limit_47.7", "torque limit = 47.7 N m", "explain/explain_torque_limit_47.7.toml",
    ...               ["case1"], [], [], True)
    >>> e = Explanation("settling_27s", "the formation settles in 27 s", "differs", "reproduced if",
    ...                 "torque limit >= 47.7 N m", "torque limit = 47.7 N m", 0.29, evidence=ev)
    >>> text_lines(e, indent=2)
    ['  explain: reproduced if torque limit >= 47.7 N m:  [explain/explain_torque_limit_47.7.toml]']
    """
    import textwrap

    if e.status == ALREADY_REPRODUCED:
        return []
    if e.status == EXPLAINED:
        text = f"{EXPLAINED} {e.reproduced_if}: {e.numbers} [{e.evidence.scenario_file}]"
    else:
        ranges = [s.split(" (")[0] for s in e.searched if not s.startswith("best-first")]
        text = f"{NOT_EXPLAINED} ({'; '.join(ranges)}; ranges in the report)"
    return textwrap.wrap(f"explain: {text}", width, initial_indent=" " * indent, subsequent_indent=" " * (indent + 2))
