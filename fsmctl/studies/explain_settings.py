"""The settings an explanation may change, and a candidate change of them (:mod:`fsmctl.studies.explain`).

:func:`search_settings` lists the settings the paper leaves open or may have misprinted, each a :class:`Setting` with
the range searched and how a change of it is measured (its distance); a :class:`Candidate` is a set of changes, and
:func:`candidate_source` / :func:`scenario_text` turn it into the scenario file of its evidence run.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from fsmctl.model.toml_writer import toml_table, toml_value
from fsmctl.policy import FAST_OUTPUT_INTERVAL_S, FAST_T_FINAL_S, SETTLING_TOLERANCES_DEG
from fsmctl.studies.explain_laws import UNSWITCHED_LAW, law_script

__all__ = [
    "SETTING_ORDER",
    "Setting",
    "Candidate",
    "search_settings",
    "candidate_source",
    "scenario_text",
    "number_text",
]

SETTING_ORDER = (
    "torque_limit",
    "alpha",
    "delta",
    "boundary_layer",
    "error_model",
    "error_mrp",
    "integration",
    "tolerance",
)
"""Every setting :func:`search_settings` may return, in its order (the order of preference for equal distances)."""


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
    >>> from fsmctl.studies.explain_settings import search_settings
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
        return f"{self.label} = {number_text(value)} {self.unit}".strip()

    def range_text(self) -> str:
        """What was searched: ``"torque limit 2-1e+05 N m (log grid of 14 values, bisected to 0.1 N m)"``."""
        if not self.continuous:
            return f"{self.label}: {' / '.join(str(v) for v in self.grid)} (default {self.default})"
        unit = f" {self.unit}" if self.unit else ""
        return (
            f"{self.label} {number_text(self.low)}-{number_text(self.high)}{unit} (default {number_text(self.default)}; "
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


def number_text(x: Any) -> str:
    """A setting's value as text: six significant digits, ``inf``, or the choice's label.

    Parameters
    ----------
    x : float or str
        The value.

    Returns
    -------
    str
        The text.

    Examples
    --------
    >>> number_text(47.7), number_text(float("inf")), number_text("unswitched")
    ('47.7', 'inf', 'unswitched')
    """
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
    >>> from fsmctl.studies.explain_settings import search_settings
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
    >>> from fsmctl.studies.explain_settings import Candidate, search_settings
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
        parts = [f"{n}_{number_text(v)}" for n, v in self.changes]
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
        Loadable with :func:`fsmctl.studies.paper_runs.load_case` and writable with :func:`scenario_text`.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.studies.explain_settings import Candidate, candidate_source, search_settings
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
    >>> from fsmctl.studies.explain_settings import scenario_text
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
