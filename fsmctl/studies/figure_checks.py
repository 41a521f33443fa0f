"""The figure-level checks of Liang, Sun & Wang (2012), Figs 1-9, as a registry: what the printed figures show.

Each :class:`FigureCheck` of :data:`FIGURE_CHECKS` reads one number of the runs (a peak of :func:`figure_numbers`, or
the steady maxima) and checks that it lies where the printed figure puts it: an autoscaled axis ends at the first tick
above the data, so a peak lies in the top tick interval ``(top - tick, top]``; Fig 4's axes are ±2 N m and the text
says the bound is reached; the insets span the whole 100 s, so their limits are set by hand and bound the final errors
from above (Figs 1-2's insets are the accuracy claims').  The printed ranges are the records of
:data:`fsmctl.studies.paper_statements.PRINTED_AXES`.  ``θ`` is the principal angle of the
error MRP the law uses.  :mod:`fsmctl.studies.explain` searches the change that makes a check pass, like a claim's.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np

from fsmctl.studies.explain_laws import UNSWITCHED_LAW
from fsmctl.studies.paper_statements import TORQUE_BOUND, printed_axes
from fsmctl.studies.records import RunRecord

__all__ = ["FigureCheck", "FIGURE_CHECKS", "figure_numbers", "get_figure_check", "error_mrp"]

Runs = Mapping[str, RunRecord]


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


def error_mrp(record: RunRecord) -> str:
    """The error MRP of the law a run flew: ``"unswitched"`` (the unswitched twin of the paper's law) or ``"shadow set"``.

    Parameters
    ----------
    record : RunRecord
        The run.

    Returns
    -------
    str
        As :func:`figure_numbers` names it.

    Examples
    --------
    >>> error_mrp(RunRecord.failed("case1", "", law="fsm"))
    'shadow set'
    """
    return "unswitched" if record.law == Path(UNSWITCHED_LAW).stem else "shadow set"


@dataclass(frozen=True)
class FigureCheck:
    """One figure-level check: a number of the runs and the interval the printed figure puts it in.

    Parameters
    ----------
    id : str
        Identifier (``fig1_axis``).
    text : str
        What the printed figure shows.
    runs : tuple of str
        The runs of :func:`~fsmctl.studies.paper_runs.run_plan` it reads, in the order to fly them.
    value : callable
        ``value(records) -> float``: the number (of the runs flown so far: a steady maximum over them).
    what : str
        The number's name.
    interval : (float, float)
        ``(low, high]``: where the figure puts it.
    documented_fits : bool
        Whether the documentation states that the paper's own scenario at its full horizon fits the figure
        (``docs/findings.md``): what ``fsmctl reproduce`` checks its run against.
    unit : str
        The number's unit.
    requires : (str, str), optional
        What would reproduce it: the only setting and value that can (``("error_mrp", "unswitched")``: in the
        shadow set every principal angle is at most 180°); None: every setting is searched.
    why : str
        Why only ``requires`` can.

    Examples
    --------
    >>> check = get_figure_check("fig4_axis")
    >>> check.runs, check.interval[1] > 2.0, check.unit
    (('case1',), True, 'N m')
    """

    id: str
    text: str
    runs: tuple[str, ...]
    value: Callable[[Runs], float]
    what: str
    interval: tuple[float, float]
    documented_fits: bool
    unit: str = "°"
    requires: tuple[str, str] | None = None
    why: str = ""
    uses_tolerance: ClassVar[bool] = False
    """no figure check reads a settling tolerance"""
    later: ClassVar[tuple[str, str] | None] = None
    """no figure check has a longer run (:attr:`fsmctl.studies.claim_types.StudyClaim.later`)"""

    def decide(self, records: Runs, tolerance_deg: float = math.nan) -> bool | list[str]:
        """Whether the figure's interval holds the number, or the runs still needed (none once a bound is exceeded).

        Parameters
        ----------
        records : mapping run key -> RunRecord
            The runs flown so far.
        tolerance_deg : float
            Unused (the protocol of :meth:`fsmctl.studies.claims.StudyClaim.decide`).

        Returns
        -------
        bool or list of str
            The verdict, or the run keys to fly next.
        """
        lo, hi = self.interval
        for i, k in enumerate(self.runs):
            if k not in records:
                return [k]
            if hi < self.value({r: records[r] for r in self.runs[: i + 1]}):  # a bound exceeded already
                return False
        return lo < self.value(records) <= hi

    def numbers(self, records: Runs, tolerance_deg: float = math.nan) -> str:
        """The number and whether it lies in the interval, e.g. ``AAEM peak 135.2° (not in (250, 300])``.

        Parameters
        ----------
        records : mapping run key -> RunRecord
            The runs.
        tolerance_deg : float
            Unused.

        Returns
        -------
        str
            The text of an explanation.
        """
        if not all(k in records for k in self.runs):
            return "not all runs flown"
        value = self.value(records)
        lo, hi = self.interval
        unit = self.unit
        fmt = f"{value:.4g} {unit}" if unit != "°" else (f"{value:.1f}°" if value >= 1 else f"{value:.3g}°")
        if float(fmt.rstrip(" °" + unit)) in (lo, hi) and value not in (lo, hi):  # 179.97 is not "180.0"
            digits = next((p for p in range(4, 17) if float(f"{value:.{p}g}") not in (lo, hi)), 17)
            fmt = f"{value:.{digits}g}{'°' if unit == '°' else ' ' + unit}"
        inside = lo < value <= hi
        if hi - lo < 1e-3 * hi:  # a level, not an interval
            where = f"{'=' if inside else '≠'} {0.5 * (lo + hi):.4g} {unit}"
        else:
            where = f"{'' if inside else 'not '}in ({lo:g}, {hi:g}]"
        if unit == "°" and "peak" in self.what:  # θ, AAEM, RAEM from the law's error MRP
            where += f"; θ from the {error_mrp(records[self.runs[0]])} error MRP"
        return f"{self.what} {fmt} ({where})"


def _peak(key: str, run: str) -> Callable[[Runs], float]:
    return lambda runs: runs[run].metrics[key]


def _steady(*keys: str) -> Callable[[Runs], float]:
    return lambda runs: max(max(runs[k].aaem_steady_max_deg, runs[k].raem_steady_max_deg) for k in keys if k in runs)


_SHADOW_AAEM = "in the shadow set every θ_ei <= 180°, so AAEM <= 180°"
_UNSWITCHED = ("error_mrp", "unswitched")


def _axis(figure: int, runs: str) -> str:
    return f"Fig {figure}: {runs} plotted on a {printed_axes(figure).text}"


FIGURE_CHECKS: tuple[FigureCheck, ...] = (
    FigureCheck(
        "fig1_axis",
        _axis(1, "Case 1 AAEM"),
        ("case1",),
        _peak("aaem_peak_deg", "case1"),
        "AAEM peak",
        printed_axes(1).top_interval,
        documented_fits=False,
        requires=_UNSWITCHED,
        why=_SHADOW_AAEM,
    ),
    FigureCheck(
        "fig2_axis",
        _axis(2, "Case 1 RAEM"),
        ("case1",),
        _peak("raem_peak_deg", "case1"),
        "RAEM peak",
        printed_axes(2).top_interval,
        documented_fits=False,
    ),
    FigureCheck(
        "fig3_axis",
        _axis(3, "Case 1 θ_1-θ_4"),
        ("case1",),
        _peak("theta_plotted_peak_deg", "case1"),
        "θ_1-4 peak",
        printed_axes(3).top_interval,
        documented_fits=False,
        requires=_UNSWITCHED,
        why="in the shadow set every θ_ei <= 180°",
    ),
    FigureCheck(
        "fig4_axis",
        f"Fig 4: applied torques plotted on {printed_axes(4).text}, the bound reached",
        ("case1",),
        _peak("u_peak_N_m", "case1"),
        "applied |u_k| peak",
        (TORQUE_BOUND.value * (1 - 1e-6), TORQUE_BOUND.value * (1 + 1e-6)),
        documented_fits=True,
        unit="N m",
    ),
    FigureCheck(
        "fig5_axis",
        _axis(5, "Case 2 AAEM"),
        ("case2",),
        _peak("aaem_peak_deg", "case2"),
        "AAEM peak",
        printed_axes(5).top_interval,
        documented_fits=False,
        requires=_UNSWITCHED,
        why=_SHADOW_AAEM,
    ),
    FigureCheck(
        "fig6_axis",
        _axis(6, "Case 2 RAEM"),
        ("case2",),
        _peak("raem_peak_deg", "case2"),
        "RAEM peak",
        printed_axes(6).top_interval,
        documented_fits=False,
    ),
    FigureCheck(
        "fig7_axis",
        _axis(7, "Case 2 θ_1-θ_4"),
        ("case2",),
        _peak("theta_plotted_peak_deg", "case2"),
        "θ_1-4 peak",
        printed_axes(7).top_interval,
        documented_fits=False,
    ),
    FigureCheck(
        "fig5_6_insets",
        f"Figs 5-6 insets ({printed_axes(5).inset_text}): Case 2's AAEM and RAEM end within "
        f"{printed_axes(5).inset_ylim[1]:g}° in the 100 s",
        ("case2",),
        _steady("case2"),
        "max steady AAEM / RAEM",
        printed_axes(5).inset_ylim,
        documented_fits=False,
    ),
    FigureCheck(
        "fig8_9_insets",
        f"Figs 8-9 insets ({printed_axes(8).inset_text}): Cases 3a-3c's AAEM and RAEM end within "
        f"{printed_axes(8).inset_ylim[1]:g}° in the 100 s",
        ("case3c", "case3a", "case3b"),
        _steady("case3c", "case3a", "case3b"),
        "max steady AAEM / RAEM",
        printed_axes(8).inset_ylim,
        documented_fits=False,
    ),
)
"""Figure-level checks (Figs 1-9 as printed in Liang, Sun & Wang 2012, Section 4: their axis ranges, ticks and insets,
recorded here), in the order of the figures."""


def get_figure_check(check_id: str) -> FigureCheck:
    """The figure check of :data:`FIGURE_CHECKS` with this id.

    Parameters
    ----------
    check_id : str
        Its id (``fig1_axis``).

    Returns
    -------
    FigureCheck
        The registry entry.

    Raises
    ------
    KeyError
        If there is no such check.

    Examples
    --------
    >>> get_figure_check("fig1_axis").requires
    ('error_mrp', 'unswitched')
    """
    for c in FIGURE_CHECKS:
        if c.id == check_id:
            return c
    raise KeyError(f"unknown figure check {check_id!r} (checks: {', '.join(c.id for c in FIGURE_CHECKS)})")
