"""Compare control laws, or settings of one law, on the same scenario (``fsmctl compare``).

Each compared *run* is a :class:`~fsmctl.studies.compare_runs.LawRun` (:mod:`fsmctl.studies.compare_runs`): a label, a law (a built-in name, a derivation script ``FILE.py``
or a derived folder, as for ``[controller] law``), values of the law's parameters and overrides of the
scenario's ``[controller]`` (``torque_limit``, ``surface``, ``error_model``, ...).  The same law may be
compared with itself under different settings: the paper's FSM against TSM and LSM (Liang, Sun & Wang 2012,
Sec. 3.3, Theorem 3) are three runs of the law ``fsm`` with ``surface`` = ``fsm``/``tsm``/``lsm``
(:mod:`fsmctl.studies.surfaces` does exactly that), and "with and without the torque limit" are two runs
differing in ``torque_limit`` (:func:`with_and_without_limit`).  Every run is one
:func:`fsmctl.simulation.simulator.simulate` of ``scenario.replace(controller=...)``.

The metrics of a run are computed once, by :func:`run_metrics`, from its
:class:`~fsmctl.simulation.simulator.SimulationResult`; what the engine already computes is taken from it
(:meth:`~fsmctl.simulation.simulator.SimulationResult.summary`: settling times and steady maxima of AAEM
eq 42 / RAEM eq 43, the peak applied and commanded torque, the saturated time, the total variation of the
torque accumulated at every integration step, the wall time).  The column names carry their units:

=================================  ========================================================================
column                             meaning
=================================  ========================================================================
``converged_at_s``                 converged (:data:`fsmctl.policy.CONVERGED_RULE`: AAEM and RAEM stay <= 1 deg
                                   to the end) from this time on; NaN = not converged
``aaem_settling_<tol>deg_s``       first output time after which AAEM (eq 42) stays <= tol deg (the sample
                                   after the last one above it); NaN = not settled within the horizon
``raem_settling_<tol>deg_s``       the same for RAEM (eq 43)
``aaem_steady_mean_deg``, ``_max``  mean and max of AAEM over the last ``steady_window_s`` (RAEM likewise)
``peak_torque_N_m``                ``max |u_ik(t)|`` over agents i, axes k and output samples (applied)
``peak_commanded_torque_N_m``      the same for the commanded (unsaturated) torque, over every step
``rms_torque_N_m``                 ``sqrt(1/(n T) int sum_i |u_i|^2 dt)``: RMS of the torque vector's norm
``control_effort_N_m_s``           ``sum_i int sum_k |u_ik| dt`` (trapezoid rule on the output samples)
``chattering_N_m``                 total variation of u: ``sum_i sum_steps |u_i(t_k) - u_i(t_k-1)|_1``
``chattering_N_m_per_s``           the same per second of simulated time
``saturated_time_max_s``, ``_mean``  time with a torque component at the limit: max and mean over agents
``messages_count``                 messages sent by all agents (:func:`fsmctl.simulation.message_metrics`:
                                   periodic broadcasting one per agent and control instant, an
                                   event-triggered law as its trigger fired); NaN = continuous control
``messages_per_agent_per_s``       the same per agent and second of simulated time (NaN likewise)
``wall_time_s``                    wall time of the simulation (the compiled loop)
=================================  ========================================================================

In the text and Markdown tables a message column of a run without a control period reads "n/a (continuous)".

A run that fails (:class:`~fsmctl.simulation.simulator.SimulationError`: non-finite state, ...) keeps its row,
with ``status = "failed: <reason>"`` and NaN metrics, so the other runs are still reported.
"""

from __future__ import annotations

import csv
import dataclasses
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from fsmctl.errors import InputError
from fsmctl.model.scenario import Scenario
from fsmctl.parallel import resolve_workers
from fsmctl.policy import COMPARISON_TOLERANCES_DEG, TOLERANCE_DEG, default_steady_window, steady_window_text
from fsmctl.simulation.messages import MESSAGE_METRICS, message_metrics
from fsmctl.simulation.metrics import settling_time
from fsmctl.studies.campaign import Runner, Task
from fsmctl.studies.compare_runs import LawRun, as_runs, run_scenario
from fsmctl.studies.records import RunRecord

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from fsmctl.simulation.simulator import SimulationResult

__all__ = [
    "Comparison",
    "compare_laws",
    "run_metrics",
    "metric_columns",
]

_MESSAGE_COLUMNS = frozenset(name for name, _, _ in MESSAGE_METRICS)

SERIES_POINTS = 2000
"""At most about this many samples of AAEM/RAEM per run are kept for the figure."""

_trapezoid = getattr(np, "trapezoid", None) or np.trapz  # noqa: NPY201 (NumPy < 2 has only trapz)


# ----------------------------------------------------------------------------- metrics


def metric_columns(tolerances_deg: Sequence[float] = COMPARISON_TOLERANCES_DEG) -> list[tuple[str, str, str]]:
    """``(column, description, unit)`` of every metric :func:`run_metrics` returns, in table order.

    Parameters
    ----------
    tolerances_deg : sequence of float, optional
        The settling tolerances (deg): one AAEM and one RAEM settling column each.

    Returns
    -------
    list of tuple of str
        ``(column, description, unit)``; settling columns first, then steady statistics, torques and chattering.

    Examples
    --------
    >>> from fsmctl.studies import metric_columns
    >>> [c for c, _, _ in metric_columns((1.0,))][:3]
    ['converged_at_s', 'aaem_settling_1deg_s', 'raem_settling_1deg_s']
    """
    cols = [("converged_at_s", f"converged (AAEM, RAEM <= {TOLERANCE_DEG:g} deg to the end) from", "s")]
    for tol in tolerances_deg:
        cols.append((f"aaem_settling_{tol:g}deg_s", f"AAEM settling to {tol:g} deg", "s"))
    for tol in tolerances_deg:
        cols.append((f"raem_settling_{tol:g}deg_s", f"RAEM settling to {tol:g} deg", "s"))
    cols += [
        ("aaem_steady_mean_deg", "AAEM steady mean", "deg"),
        ("aaem_steady_max_deg", "AAEM steady max", "deg"),
        ("raem_steady_mean_deg", "RAEM steady mean", "deg"),
        ("raem_steady_max_deg", "RAEM steady max", "deg"),
        ("peak_torque_N_m", "peak |u_k| applied", "N m"),
        ("peak_commanded_torque_N_m", "peak |u_k| commanded", "N m"),
        ("rms_torque_N_m", "RMS torque", "N m"),
        ("control_effort_N_m_s", "effort int sum|u| dt", "N m s"),
        ("chattering_N_m", "chattering (total variation)", "N m"),
        ("chattering_N_m_per_s", "chattering per second", "N m/s"),
        ("saturated_time_max_s", "saturated time, max agent", "s"),
        ("saturated_time_mean_s", "saturated time, mean", "s"),
        ("peak_wheel_momentum_N_m_s", "peak |wheel momentum| (nan: no wheels)", "N m s"),
        ("peak_wheel_speed_rad_per_s", "peak |wheel speed| (nan: no wheels)", "rad/s"),
        *MESSAGE_METRICS,
        ("wall_time_s", "wall time", "s"),
    ]
    return cols


def run_metrics(
    result: SimulationResult,
    *,
    tolerances_deg: Sequence[float] = COMPARISON_TOLERANCES_DEG,
    steady_window_s: float | None = None,
) -> dict[str, float]:
    """Every metric of one run (the columns of :func:`metric_columns`), from its simulation result.

    Settling times, steady maxima, peak torques, saturated times, the total variation and the wall time come
    from :meth:`SimulationResult.summary <fsmctl.simulation.simulator.SimulationResult.summary>` (the engine's
    statistics); computed here are the steady means (over the same window), the RMS torque and the control
    effort (trapezoid rule on the output samples); the message counts are
    :func:`fsmctl.simulation.message_metrics`'s.

    Parameters
    ----------
    result : SimulationResult
        One simulated run.
    tolerances_deg : sequence of float
        AAEM/RAEM settling tolerances (deg).
    steady_window_s : float, optional
        Length of the final window of the steady-state statistics (default :func:`fsmctl.policy.default_steady_window`);
        clipped to the horizon.

    Returns
    -------
    dict
        Column name (with its unit) -> float; NaN for a settling time that is not reached within the horizon.

    Examples
    --------
    >>> import fsmctl
    >>> r = fsmctl.simulate(fsmctl.paper_scenario("1").replace(simulation={"t_final": 1.0, "output_interval": 0.1}))
    >>> m = run_metrics(r, tolerances_deg=(1.0,))
    >>> m["peak_torque_N_m"] <= 2.0, math.isnan(m["aaem_settling_1deg_s"])
    (True, True)
    """
    t = np.asarray(result.time, dtype=float)
    span = float(t[-1] - t[0])
    window = default_steady_window(span) if steady_window_s is None else float(steady_window_s)
    summary = result.summary(tolerances_deg=tuple(tolerances_deg), steady_window=window)
    window = summary["steady_window_s"]  # clipped to the horizon by the engine's summary
    steady = t >= t[-1] - window - 1e-12  # the window of fsmctl.simulation.metrics.steady_state_max
    u = np.asarray(result.u, dtype=float)
    n = u.shape[1]
    sq = np.sum(np.square(u), axis=(1, 2))  # sum_i |u_i|^2, (T,)
    abs_sum = np.sum(np.abs(u), axis=2)  # sum_k |u_ik|, (T, n)
    out: dict[str, float] = {"converged_at_s": math.nan}
    if summary["converged"]:  # the one rule (fsmctl.simulation.metrics.converged): from the later settling time on
        times = (settling_time(t, metric, TOLERANCE_DEG) for metric in (result.aaem_deg, result.raem_deg))
        out["converged_at_s"] = max(times)
    for tol in tolerances_deg:
        out[f"aaem_settling_{tol:g}deg_s"] = summary["aaem_settling_s"][f"{tol:g}"]
    for tol in tolerances_deg:
        out[f"raem_settling_{tol:g}deg_s"] = summary["raem_settling_s"][f"{tol:g}"]
    sat = np.asarray(summary["saturated_time_s"], dtype=float)
    out.update(
        {
            "aaem_steady_mean_deg": float(np.mean(result.aaem_deg[steady])),
            "aaem_steady_max_deg": summary["aaem_steady_max_deg"],
            "raem_steady_mean_deg": float(np.mean(result.raem_deg[steady])),
            "raem_steady_max_deg": summary["raem_steady_max_deg"],
            "peak_torque_N_m": summary["u_max_abs_N_m"],
            "peak_commanded_torque_N_m": summary["u_unsaturated_max_N_m"],
            "rms_torque_N_m": math.sqrt(float(_trapezoid(sq, t)) / (n * span)) if span > 0 else math.nan,
            "control_effort_N_m_s": float(np.sum(_trapezoid(abs_sum, t, axis=0))),
            "chattering_N_m": float(np.sum(result.u_total_variation)),
            "chattering_N_m_per_s": float(np.sum(summary["chattering_index_N_m_per_s"])),
            "saturated_time_max_s": float(sat.max()),
            "saturated_time_mean_s": float(sat.mean()),
            "peak_wheel_momentum_N_m_s": summary.get("wheel_momentum_peak_N_m_s", math.nan),
            "peak_wheel_speed_rad_per_s": summary.get("wheel_speed_peak_rad_per_s", math.nan),
            **message_metrics(result),
            "wall_time_s": float(summary["wall_time_s"]),
        }
    )
    return {k: float(v) for k, v in out.items()}


# ----------------------------------------------------------------------------- the comparison


def _fmt(v: Any, spec: str = ".4g") -> str:
    if isinstance(v, str):
        return v
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "nan"
    if isinstance(v, float) and math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return format(v, spec)


@dataclass
class Comparison:
    """The result of :func:`compare_laws`: one record per run, the AAEM/RAEM series, what the hook returned.

    Parameters
    ----------
    scenario_label : str
        The compared scenario (and case).
    settings : dict
        Tolerances, steady window, horizon and step, the scenario's controller.
    runs : list of LawRun
        The runs, in order.
    records : list of RunRecord
        One :class:`~fsmctl.studies.records.RunRecord` per run, in order (keyed by the run's label): its law, torque
        limit, summary and series, the metric columns (:func:`run_metrics`) in :attr:`RunRecord.metrics
        <fsmctl.studies.records.RunRecord.metrics>`; a run whose simulation failed has its reason in
        :attr:`RunRecord.error <fsmctl.studies.records.RunRecord.error>` and NaN metrics.  :attr:`table` is their
        rows.
    series : dict
        Label -> ``{"time_s", "aaem_deg", "raem_deg"}`` arrays (every sample up to ~2000 per run).
    extras : dict
        Label -> what ``on_result`` returned for the run (empty without a hook).
    wall_time_s : float
        Wall time of the whole comparison.

    Examples
    --------
    Two laws on a 1 s horizon of Case 1 (Liang et al. 2012, Section 4); read a row, write the files:

    >>> import fsmctl
    >>> from fsmctl.studies import compare_laws
    >>> s = fsmctl.paper_scenario("1").replace(simulation={"t_final": 1.0, "output_interval": 0.1})
    >>> c = compare_laws(s, ["fsm", "pid"], tolerances_deg=(1.0,))
    >>> [(r["label"], r["status"]) for r in c.table]
    [('fsm', 'ok'), ('pid', 'ok')]
    >>> c.tolerances_deg, c.row("fsm")["peak_torque_N_m"] == c.record("fsm").metrics["peak_torque_N_m"] > 0
    ((1.0,), True)
    >>> c.record("pid").law, c.record("pid").torque_limit
    ('pid', 2.0)
    >>> [p.name for p in c.save("out", figures=False)]
    ['comparison.csv', 'comparison.json', 'comparison.md']
    """

    scenario_label: str
    settings: dict
    runs: list[LawRun]
    records: list[RunRecord] = field(repr=False)
    series: dict = field(default_factory=dict, repr=False)
    extras: dict = field(default_factory=dict, repr=False)
    wall_time_s: float = 0.0

    @property
    def tolerances_deg(self) -> tuple[float, ...]:
        """The settling tolerances (deg) of the metric columns, in order."""
        return tuple(self.settings["tolerances_deg"])

    @property
    def table(self) -> list[dict]:
        """One JSON-able row per run (the tables' rows, :meth:`columns`), made from :attr:`runs` and :attr:`records`.

        ``label``, ``law`` (its name), ``spec`` (as given), ``settings`` (the run's parameters and overrides),
        ``torque_limit_N_m`` (the run's limit; ``inf`` for none), ``status`` (``ok`` or ``failed: <reason>``), then
        the metric columns (:func:`metric_columns`).
        """
        metrics = [c for c, _, _ in metric_columns(self.tolerances_deg)]
        return [
            {
                "label": run.label,
                "law": rec.law,
                "spec": str(run.law),
                "settings": run.settings_text(),
                "torque_limit_N_m": float(rec.torque_limit),
                "status": "ok" if rec.ok else f"failed: {rec.error}",
                **{c: rec.metrics[c] for c in metrics},
            }
            for run, rec in zip(self.runs, self.records, strict=True)
        ]

    def record(self, label: str) -> RunRecord:
        """The record of the run ``label``.

        Parameters
        ----------
        label : str
            The run's label.

        Returns
        -------
        RunRecord
            Its record (:attr:`records`).

        Raises
        ------
        KeyError
            No run has that label.
        """
        for rec in self.records:
            if rec.key == label:
                return rec
        raise KeyError(label)

    def row(self, label: str) -> dict:
        """The row of the run ``label``.

        Parameters
        ----------
        label : str
            The run's label.

        Returns
        -------
        dict
            The row of :attr:`table`.

        Raises
        ------
        KeyError
            No run has that label.
        """
        for r in self.table:
            if r["label"] == label:
                return r
        raise KeyError(label)

    @property
    def failures(self) -> list[tuple[str, str]]:
        """``(label, reason)`` of the runs whose simulation failed."""
        return [(rec.key, rec.error) for rec in self.records if not rec.ok]

    def columns(self) -> list[tuple[str, str, str]]:
        """``(column, description, unit)`` of every column of :attr:`table`."""
        head = [
            ("label", "run", ""),
            ("law", "law", ""),
            ("spec", "law as given", ""),
            ("settings", "settings", ""),
            ("torque_limit_N_m", "torque limit", "N m"),
            ("status", "status", ""),
        ]
        return head + metric_columns(self.tolerances_deg)

    def to_json(self) -> dict:
        """Scenario, settings, runs and rows (strict JSON through :func:`fsmctl.outputs.jsonable`)."""
        from fsmctl.outputs import jsonable

        return jsonable(
            {
                "scenario": self.scenario_label,
                "settings": self.settings,
                "runs": [r.to_dict() for r in self.runs],
                "columns": [{"name": c, "description": d, "unit": u} for c, d, u in self.columns()],
                "table": self.table,
                "wall_time_s": self.wall_time_s,
            }
        )

    def to_csv(self, path: str | Path) -> Path:
        """Write :attr:`table` as CSV (atomically); units are in the column names, NaN is ``nan``, no limit ``inf``.

        Parameters
        ----------
        path : str or pathlib.Path
            The CSV file to write.

        Returns
        -------
        pathlib.Path
            ``path``.
        """
        from fsmctl.outputs import atomic_path

        path = Path(path)
        names = [c for c, _, _ in self.columns()]
        with atomic_path(path) as tmp, tmp.open("w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh)
            w.writerow(names)
            for r in self.table:
                w.writerow([r[c] for c in names])  # str(float): shortest round trip, 'nan', 'inf'
        return path

    def _cells(self, settled_text: str) -> tuple[list[str], list[list[str]]]:
        """Header and rows of the transposed table: one row per quantity, one column per run."""
        header = ["quantity", "unit", *[r["label"] for r in self.table]]
        rows = [
            ["law", "", *[r["law"] for r in self.table]],
            ["settings", "", *[r["settings"] or "scenario's" for r in self.table]],
            ["torque limit", "N m", *[_fmt(r["torque_limit_N_m"], "g") for r in self.table]],
            ["status", "", *[r["status"] for r in self.table]],
        ]
        for col, desc, unit in metric_columns(self.tolerances_deg):
            cells = []
            for r in self.table:
                v = r[col]
                if col == "converged_at_s" and r["status"] == "ok" and math.isnan(v):
                    cells.append("not converged")
                elif "_settling_" in col and r["status"] == "ok" and math.isnan(v):
                    cells.append(settled_text)
                elif col in _MESSAGE_COLUMNS and r["status"] == "ok" and math.isnan(v):
                    cells.append("n/a (continuous)")
                else:
                    cells.append(_fmt(v, ".2f" if "_settling_" in col or col == "converged_at_s" else ".4g"))
            rows.append([desc, unit, *cells])
        return header, rows

    def to_markdown(self) -> str:
        """A Markdown table: one row per quantity (with its unit), one column per run.

        A settling time that is not reached within the horizon reads "not settled".
        """
        header, rows = self._cells("not settled")

        def esc(s: str) -> str:
            return s.replace("|", "\\|")

        lines = [
            f"# Law comparison: {self.scenario_label}",
            "",
            f"Horizon {self.settings['t_final_s']:g} s (dt {self.settings['dt_s']:g} s); steady statistics over "
            f"{self._window()}; settling = first time after which the metric stays within the tolerance.",
            "",
            "| " + " | ".join(esc(h) for h in header) + " |",
            "|" + "|".join(["---", "---"] + ["---:"] * len(self.table)) + "|",
        ]
        lines += ["| " + " | ".join(esc(c) for c in row) + " |" for row in rows]
        return "\n".join(lines) + "\n"

    def to_text(self) -> str:
        """The table as aligned plain text (what ``fsmctl compare`` prints)."""
        header, rows = self._cells("not settled")
        widths = [max(len(x[k]) for x in [header, *rows]) for k in range(len(header))]
        lines = [self.outcome_line(), f"compare: {self.scenario_label}"]
        for k, row in enumerate([header, *rows]):
            cells = [row[0].ljust(widths[0]), row[1].ljust(widths[1])]
            cells += [c.rjust(w) for c, w in zip(row[2:], widths[2:], strict=True)]
            lines.append("  ".join(cells).rstrip())
            if k == 0:
                lines.append("  ".join("-" * w for w in widths))
        lines.append(f"steady statistics over {self._window()}; wall time {self.wall_time_s:.1f} s")
        return "\n".join(lines)

    def outcome_line(self) -> str:
        """The result in one plain line: which runs converged, and from when (:data:`fsmctl.policy.CONVERGED_RULE`).

        Returns
        -------
        str
            E.g. ``"converged (AAEM, RAEM <= 1 deg to the end): fsm from 2.67 s; pd: not within 100 s"``.

        Examples
        --------
        >>> import fsmctl
        >>> s = fsmctl.paper_scenario("1").replace(simulation={"t_final": 1.0, "output_interval": 0.1})
        >>> compare_laws(s, ["fsm"]).outcome_line()
        'converged (AAEM, RAEM <= 1 deg to the end): fsm: not within 1 s'
        """
        horizon = self.settings["t_final_s"]
        parts = []
        for r in self.table:
            at = r.get("converged_at_s", math.nan)
            if r["status"] != "ok":
                parts.append(f"{r['label']}: {r['status']}")
            elif math.isnan(at):
                parts.append(f"{r['label']}: not within {horizon:g} s")
            else:
                parts.append(f"{r['label']} from {at:.2f} s")
        return f"converged (AAEM, RAEM <= {TOLERANCE_DEG:g} deg to the end): " + "; ".join(parts)

    def _window(self) -> str:
        """The steady window as every output states it (:func:`fsmctl.policy.steady_window_text`)."""
        return steady_window_text(self.settings["steady_window_s"], self.settings["t_final_s"])

    def figure(self) -> Figure:
        """AAEM (eq 42) and RAEM (eq 43) against time on log-y for every run, and bars of settling time (AAEM, per
        tolerance; hatched at the horizon = not settled), peak applied torque (commanded: black tick), chattering
        and messages sent (a run without a control period is marked "n/a": continuous control sends none).

        Returns
        -------
        matplotlib.figure.Figure
            Built without pyplot; save it with :func:`fsmctl.studies.figures.save_figure`.

        Examples
        --------
        >>> import fsmctl
        >>> s = fsmctl.paper_scenario("1").replace(simulation={"t_final": 1.0, "output_interval": 0.1})
        >>> len(compare_laws(s, ["fsm"]).figure().axes)
        6
        """
        from matplotlib.figure import Figure

        from fsmctl.studies.figures import RUN_COLORS

        fig = Figure(figsize=(13, 7.5), layout="constrained")
        gs = fig.add_gridspec(2, 8)
        ax_a = fig.add_subplot(gs[0, :4])
        ax_r = fig.add_subplot(gs[0, 4:], sharex=ax_a)
        ax_s, ax_p, ax_c, ax_m = (fig.add_subplot(gs[1, 2 * k : 2 * k + 2]) for k in range(4))
        colors = [RUN_COLORS[k % len(RUN_COLORS)] for k in range(len(self.table))]  # runs: never an agent's colour
        for row, color in zip(self.table, colors, strict=True):
            ser = self.series.get(row["label"])
            if ser is None:
                continue
            for ax, key in ((ax_a, "aaem_deg"), (ax_r, "raem_deg")):
                v = np.asarray(ser[key], dtype=float)
                ax.semilogy(ser["time_s"], np.where(v > 0, v, np.nan), color=color, lw=1.1, label=row["label"])
        for ax, name, eq in ((ax_a, "AAEM", "42"), (ax_r, "RAEM", "43")):
            for tol in self.tolerances_deg:
                ax.axhline(tol, color="k", lw=0.6, ls=":")
            ax.set_xlabel("t (s)")
            ax.set_ylabel(f"{name} (deg)")
            ax.set_title(f"{name} (eq {eq})", fontsize=10)
            ax.grid(True, which="both", alpha=0.3)
        ax_a.legend(fontsize=8)
        n = len(self.table)
        x = np.arange(len(self.tolerances_deg))
        width = 0.8 / max(n, 1)
        horizon = float(self.settings["t_final_s"])
        for k, (row, color) in enumerate(zip(self.table, colors, strict=True)):
            values = np.array([row[f"aaem_settling_{tol:g}deg_s"] for tol in self.tolerances_deg])
            pos = x - 0.4 + width * (k + 0.5)
            done = np.isfinite(values)
            ax_s.bar(pos[done], values[done], width, color=color, label=row["label"])
            if row["status"] == "ok" and np.any(~done):
                ax_s.bar(pos[~done], horizon, width, color=color, alpha=0.25, hatch="//", edgecolor=color)
        ax_s.axhline(horizon, color="k", lw=0.6, ls="--")
        ax_s.set_xticks(x, [f"{tol:g} deg" for tol in self.tolerances_deg])
        ax_s.set_ylabel("AAEM settling time (s)")
        ax_s.set_title("settling (hatched at the horizon: not settled)", fontsize=9)
        pos = np.arange(n)
        labels = [r["label"] for r in self.table]
        peak = np.array([r["peak_torque_N_m"] for r in self.table], dtype=float)
        commanded = np.array([r["peak_commanded_torque_N_m"] for r in self.table], dtype=float)
        ax_p.bar(pos, peak, color=colors)
        ax_p.plot(pos, commanded, "k_", ms=14, mew=2)
        _log_if_wide(ax_p, np.concatenate([peak, commanded]))
        ax_p.set_ylabel(r"peak $|u_k|$ (N m); $-$ commanded")
        ax_p.set_title("peak torque", fontsize=9)
        chat = np.array([r["chattering_N_m_per_s"] for r in self.table], dtype=float)
        ax_c.bar(pos, chat, color=colors)
        _log_if_wide(ax_c, chat)
        ax_c.set_ylabel("total variation of u per second (N m/s)")
        ax_c.set_title("chattering", fontsize=9)
        sent = np.array([r["messages_count"] for r in self.table], dtype=float)
        ax_m.bar(pos, np.where(np.isfinite(sent), sent, 0.0), color=colors)
        for k in np.flatnonzero(~np.isfinite(sent)):
            ax_m.text(pos[k], 0.0, "n/a", ha="center", va="bottom", fontsize=8)
        _log_if_wide(ax_m, sent)
        ax_m.set_ylabel("messages sent, all agents")
        ax_m.set_title("messages (n/a: continuous control)", fontsize=9)
        for ax in (ax_p, ax_c, ax_m):
            ax.set_xticks(pos, labels, rotation=20 if n > 2 else 0, ha="right" if n > 2 else "center", fontsize=8)
        for ax in (ax_s, ax_p, ax_c, ax_m):
            ax.grid(True, axis="y", alpha=0.3)
        fig.suptitle(f"{self.scenario_label}: law comparison", fontsize=11)
        return fig

    def save(self, out_dir: str | Path, *, figures: bool = True) -> list[Path]:
        """Write ``comparison.csv``, ``comparison.json``, ``comparison.md`` and ``comparison.png``/``.svg``.

        Every file is written atomically (:mod:`fsmctl.outputs`); the folder is created if needed.

        Parameters
        ----------
        out_dir : str or pathlib.Path
            The output folder.
        figures : bool, optional
            Also write the figure (:meth:`figure`), default True.

        Returns
        -------
        list of pathlib.Path
            The files written.
        """
        from fsmctl.outputs import environment_problem, write_json, write_text
        from fsmctl.studies.figures import save_figure

        out = Path(out_dir)
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise environment_problem("write to output folder", out, exc) from None
        paths = [
            self.to_csv(out / "comparison.csv"),
            write_json(out / "comparison.json", self.to_json(), indent=1),
            write_text(out / "comparison.md", self.to_markdown()),
        ]
        if figures:
            paths += save_figure(self.figure(), out / "comparison")
        return paths


def _log_if_wide(ax, values: np.ndarray) -> None:
    """Log scale when the positive values span more than two decades (e.g. with and without a torque limit)."""
    finite = values[np.isfinite(values) & (values > 0)]
    if finite.size and finite.max() / finite.min() > 100:
        ax.set_yscale("log")


def _failed_record(run: LawRun, scenario: Scenario, exc: Exception, tolerances: Sequence[float]) -> RunRecord:
    """The record of a run whose simulation failed: the reason on one line, NaN metrics."""
    reason = " ".join(str(exc).split()) or type(exc).__name__
    nan = dict.fromkeys((c for c, _, _ in metric_columns(tolerances)), math.nan)
    record = RunRecord.failed(run.label, reason, law=scenario.law.name, metrics=nan)
    return dataclasses.replace(record, label=scenario.label, torque_limit=float(scenario.controller.torque_limit))


def _series(result: SimulationResult) -> dict[str, np.ndarray]:
    step = max(1, len(result.time) // SERIES_POINTS)
    return {"time_s": result.time[::step], "aaem_deg": result.aaem_deg[::step], "raem_deg": result.raem_deg[::step]}


def compare_laws(
    scenario: Scenario,
    laws: Sequence[LawRun | str | Path],
    *,
    tolerances_deg: Sequence[float] = COMPARISON_TOLERANCES_DEG,
    steady_window_s: float | None = None,
    workers: int | None = None,
    progress: bool = False,
    on_result: Callable[[LawRun, SimulationResult], Any] | None = None,
) -> Comparison:
    """Simulate the scenario once per run and compare the runs' metrics (:func:`run_metrics`).

    Parameters
    ----------
    scenario : Scenario
        The common scenario (horizon, agents, topology, controller defaults).
    laws : sequence of LawRun or str
        The runs; a string is a law spec (name, ``FILE.py``, folder) flown with the scenario's settings
        (:meth:`LawRun.from_spec`).  Labels must be unique.
    tolerances_deg : sequence of float
        AAEM/RAEM settling tolerances (deg), each > 0.
    steady_window_s : float, optional
        Final window of the steady-state statistics (default: the last 40 % of the horizon, at most 40 s).
    workers : int, optional
        Runs simulated at the same time, in threads of the campaign runner (:class:`fsmctl.studies.campaign.Runner`;
        the compiled loop releases the GIL); 1 runs them in turn.  Default: one per CPU, at most one per run
        (:func:`fsmctl.policy.default_workers` of the number of runs).  The results do not depend on it.
    progress : bool
        Show a progress bar over the runs.
    on_result : callable, optional
        ``on_result(run, result)`` is called with each finished run's
        :class:`~fsmctl.simulation.simulator.SimulationResult` (in a worker thread when ``workers > 1``); what it
        returns is kept in :attr:`Comparison.extras` under the run's label (the results themselves are not kept).

    Returns
    -------
    Comparison

    Raises
    ------
    InputError
        A bad run (unknown law, parameter, value; duplicate label) or option, before anything is simulated.
        A run whose simulation fails is reported in its row (``status``), not raised.

    Examples
    --------
    >>> import fsmctl
    >>> s = fsmctl.paper_scenario("1").replace(simulation={"t_final": 2.0, "output_interval": 0.1})
    >>> from fsmctl.studies.compare_runs import LawRun, with_and_without_limit
    >>> runs = [LawRun("FSM", "fsm"), LawRun("TSM", "fsm", {"surface": "tsm"})]
    >>> c = compare_laws(s, with_and_without_limit(runs, 2.0), tolerances_deg=(1.0,))
    >>> [r["label"] for r in c.table]
    ['FSM (limit 2 N m)', 'FSM (no limit)', 'TSM (limit 2 N m)', 'TSM (no limit)']
    >>> c.row("FSM (limit 2 N m)")["peak_torque_N_m"] <= 2.0 < c.row("FSM (no limit)")["peak_torque_N_m"]
    True
    """
    from fsmctl.simulation.simulator import SimulationError, simulate

    tolerances = tuple(tolerances_deg)
    if not tolerances or not all(
        isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) and x > 0 for x in tolerances
    ):
        raise InputError(f"settling tolerances must be finite numbers > 0 (deg), got {list(tolerances)}")
    if len({f"{x:g}" for x in tolerances}) != len(tolerances):
        raise InputError(f"settling tolerances must differ, got {list(tolerances)}")
    if steady_window_s is not None and not (
        isinstance(steady_window_s, (int, float)) and math.isfinite(steady_window_s) and steady_window_s > 0
    ):
        raise InputError(f"steady window must be a finite number of seconds > 0, got {steady_window_s!r}")
    runs = as_runs(laws)
    workers = resolve_workers(workers, len(runs), "compare_laws")
    scenarios = [run_scenario(scenario, r) for r in runs]  # every input checked (and laws derived) first
    horizon = scenario.simulation.t_final
    window = default_steady_window(horizon) if steady_window_s is None else min(float(steady_window_s), horizon)
    start = time.perf_counter()

    def one(job: tuple[LawRun, Scenario]) -> tuple[RunRecord, dict | None, Any]:
        run, scn = job
        try:
            result = simulate(scn, progress=False)
        except SimulationError as exc:
            return _failed_record(run, scn, exc, tolerances), None, None
        metrics = run_metrics(result, tolerances_deg=tolerances, steady_window_s=window)
        record = RunRecord.from_result(
            run.label,
            scn,
            result,
            steady_window_s=window,
            tolerances_deg=tolerances,
            metrics=metrics,
            wall_time_s=metrics["wall_time_s"],
        )
        extra = on_result(run, result) if on_result is not None else None
        return record, _series(result), extra

    tasks = [Task(run.label, one, ((run, scn),)) for run, scn in zip(runs, scenarios, strict=True)]
    with Runner(workers=workers, threads=True, name="compare", interrupts=False) as runner:
        runner.progress(len(tasks), unit="run", enabled=progress)
        outcomes = runner.run(tasks)
    records, series, extras = [], {}, {}
    for run, (record, ser, extra) in zip(runs, outcomes, strict=True):
        records.append(record)
        if ser is not None:
            series[run.label] = ser
        if on_result is not None and ser is not None:
            extras[run.label] = extra
    sim = scenario.simulation
    settings = {
        "tolerances_deg": list(tolerances),
        "steady_window_s": window,
        "t_final_s": sim.t_final,
        "dt_s": sim.dt,
        "output_interval_s": sim.output_interval,
        "integrator": sim.integrator,
        "control_period_s": sim.control_period,
        "seed": sim.seed,
        "controller": dataclasses.asdict(scenario.controller),
        "hardware": scenario.hardware_lines(),
    }
    return Comparison(
        scenario_label=scenario.label,
        settings=settings,
        runs=runs,
        records=records,
        series=series,
        extras=extras,
        wall_time_s=time.perf_counter() - start,
    )
