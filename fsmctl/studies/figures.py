"""Figures of a formation run: analogues of Figs 1-9 of Liang, Sun & Wang (2012), Section 4.

Every builder returns a :class:`matplotlib.figure.Figure` created without
:mod:`matplotlib.pyplot` (no global figure registry, no GUI backend, safe in
worker processes and headless CI); :func:`save_figure` writes it as PNG and SVG.

============================  =====================================================
paper figure                  builder
============================  =====================================================
Fig 1 (AAEM, eq 42)           :func:`metric_figure` with ``metric="AAEM"``
Fig 2 (RAEM, eq 43)           :func:`metric_figure` with ``metric="RAEM"``
Figs 3 and 7 (theta_ei)       :func:`principal_angles_figure`
Fig 4 (torques u_i)           :func:`torques_figure`
Figs 5-6 (Case 2 vs Case 1)   :func:`overlay_figure`
Figs 8-9 (Cases 3a-3c)        :func:`overlay_figure`
============================  =====================================================

Arrays use the layout of :class:`fsmctl.simulation.simulator.SimulationResult`: ``time`` (T,) s,
metrics (T,) deg, ``theta_e_deg`` (T, n) deg, ``u`` (T, n, 3) N m.

Large formations: per-agent drawing is capped at :data:`MAX_AGENTS_DRAWN` (12) agents.  Beyond that the
figures draw the agents with the largest values individually (the title says which and how many of how
many) and summarise all agents by an envelope (min-max band, median), so a 200-agent figure has the size
and drawing time of a 12-agent one.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.figure import Figure

if TYPE_CHECKING:
    from fsmctl.simulation.simulator import SimulationResult

__all__ = [
    "MAX_AGENTS_DRAWN",
    "METRIC_EQUATIONS",
    "metric_figure",
    "principal_angles_figure",
    "torques_figure",
    "overlay_figure",
    "simulation_figures",
    "save_figure",
]

METRIC_EQUATIONS = {"AAEM": "eq 42", "RAEM": "eq 43"}
"""The paper's equation of each formation error metric."""

MAX_AGENTS_DRAWN = 12
"""Most agents drawn one by one (lines of Figs 3/7, panels of Fig 4); beyond it the figures summarise."""

_AXIS_COLORS = ("tab:blue", "tab:orange", "tab:green")


def _check_series(time: np.ndarray, values: np.ndarray, name: str) -> tuple[np.ndarray, np.ndarray]:
    time = np.asarray(time, dtype=float)
    values = np.asarray(values, dtype=float)
    if time.ndim != 1 or time.size < 2:
        raise ValueError(f"{name}: time must be a 1-D array of at least 2 samples, got shape {time.shape}")
    if values.shape[0] != time.size:
        raise ValueError(f"{name}: {values.shape[0]} samples for {time.size} time points")
    return time, values


def _add_inset(ax, time: np.ndarray, curves: Sequence[tuple[np.ndarray, str, str]], inset_start: float) -> None:
    """Zoomed inset of ``t >= inset_start`` (the paper's insets show the last part of each metric)."""
    sel = time >= inset_start
    if np.count_nonzero(sel) < 2:
        return
    inset = ax.inset_axes((0.45, 0.42, 0.52, 0.5))
    top = 0.0
    for values, color, label in curves:
        v = values[sel]
        inset.plot(time[sel], v, color=color, lw=0.8, label=label)
        if np.all(np.isfinite(v)):
            top = max(top, float(np.max(v)))
    inset.set_xlim(float(time[sel][0]), float(time[-1]))
    inset.set_ylim(0.0, top * 1.1 if top > 0 else 1.0)
    inset.set_title(f"t ≥ {inset_start:g} s", fontsize=8)
    inset.tick_params(labelsize=7)
    inset.grid(True, alpha=0.3)


def _worst_agents(score: np.ndarray, count: int) -> list[int]:
    """0-based indices of the ``count`` largest scores (NaN counts as largest), in agent order."""
    score = np.where(np.isnan(score), np.inf, score)
    top = np.argsort(-score, kind="stable")[:count]
    return sorted(int(i) for i in top)


def _envelope(values: np.ndarray, block: int = 2048) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-sample min, median and max over the trailing axes of ``(T, ...)`` values, in blocks of samples."""
    T = values.shape[0]
    lo, mid, hi = np.empty(T), np.empty(T), np.empty(T)
    for start in range(0, T, block):
        v = values[start : start + block].reshape(min(block, T - start), -1)
        lo[start : start + block] = np.min(v, axis=1)
        hi[start : start + block] = np.max(v, axis=1)
        mid[start : start + block] = np.median(v, axis=1)
    return lo, mid, hi


def metric_figure(
    time: np.ndarray,
    metric_deg: np.ndarray,
    *,
    metric: str = "AAEM",
    title: str | None = None,
    inset_start: float | None = None,
    tolerances_deg: Sequence[float] = (),
) -> Figure:
    """A formation error metric against time with a zoomed inset of its last part (Figs 1-2).

    Parameters
    ----------
    time : (T,) array
        Time (s).
    metric_deg : (T,) array
        AAEM (Liang et al. 2012, eq 42) or RAEM (eq 43), in degrees.
    metric : {"AAEM", "RAEM"}
        Which metric (labels the axis with its equation).
    title : str, optional
        Figure title.
    inset_start : float, optional
        Start (s) of the zoomed inset; default: the second half of the run. ``nan`` disables it.
    tolerances_deg : sequence of float
        Tolerance levels drawn as dotted lines in the inset.

    Returns
    -------
    matplotlib.figure.Figure
        One axes (``fig.axes[0]``) plus the inset axes.
    """
    if metric not in METRIC_EQUATIONS:
        raise ValueError(f"metric must be one of {list(METRIC_EQUATIONS)}, got {metric!r}")
    time, metric_deg = _check_series(time, metric_deg, metric)
    fig = Figure(figsize=(7.0, 4.2), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(time, metric_deg, color="tab:blue", lw=1.0)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(f"{metric} (deg), {METRIC_EQUATIONS[metric]}")
    ax.set_xlim(float(time[0]), float(time[-1]))
    ax.set_ylim(bottom=0.0)
    ax.grid(True, alpha=0.3)
    ax.set_title(title or f"{metric} ({METRIC_EQUATIONS[metric]})")
    start = 0.5 * (time[0] + time[-1]) if inset_start is None else inset_start
    if math.isfinite(start):
        _add_inset(ax, time, [(metric_deg, "tab:blue", metric)], start)
        inset = ax.child_axes[-1] if ax.child_axes else None
        if inset is not None:
            for tol in tolerances_deg:
                inset.axhline(tol, color="gray", ls=":", lw=0.8)
    return fig


def principal_angles_figure(
    time: np.ndarray,
    theta_e_deg: np.ndarray,
    *,
    agents: Sequence[int] | None = None,
    title: str | None = None,
    max_agents: int = MAX_AGENTS_DRAWN,
) -> Figure:
    """Error principal angle ``theta_ei`` of each spacecraft against time (Figs 3 and 7).

    Parameters
    ----------
    time : (T,) array
        Time (s).
    theta_e_deg : (T, n) array
        ``theta_ei = 4 atan|sigma_ei|`` (Liang et al. 2012, eq 2), degrees.
    agents : sequence of int, optional
        1-based agents to draw (the paper draws four); default all, or, for more than ``max_agents``
        agents, the ``max_agents`` agents with the largest ``theta_ei`` over the second half of the run.
    title : str, optional
        Figure title; when not all agents are drawn a second line says which.
    max_agents : int
        Most agents drawn as individual lines by default; the legend lists at most this many.

    Returns
    -------
    matplotlib.figure.Figure
        One axes with one line per drawn agent, labelled ``θ1``, ``θ2``, ...; with more than ``max_agents``
        agents and no ``agents``, also the min-max band and the median over all agents.
    """
    time, theta_e_deg = _check_series(time, theta_e_deg, "theta_e")
    n = theta_e_deg.shape[1]
    summarised = agents is None and n > max_agents
    if agents is not None:
        chosen = list(agents)
    elif summarised:
        late = theta_e_deg[time >= 0.5 * (time[0] + time[-1])]
        chosen = [i + 1 for i in _worst_agents(np.max(late, axis=0), max_agents)]
    else:
        chosen = list(range(1, n + 1))
    if any(not 1 <= a <= n for a in chosen):
        raise ValueError(f"agents must lie in 1..{n}, got {chosen}")
    fig = Figure(figsize=(7.0, 4.2), layout="constrained")
    ax = fig.add_subplot()
    if summarised:
        lo, mid, hi = _envelope(theta_e_deg)
        ax.fill_between(time, lo, hi, color="0.85", lw=0, label=f"min-max of all {n}")
        ax.plot(time, mid, color="0.35", lw=1.0, ls="--", label="median")
    for a in chosen:
        ax.plot(time, theta_e_deg[:, a - 1], lw=1.0, label=f"θ{a}")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("θ_ei (deg), eq 2")
    ax.set_xlim(float(time[0]), float(time[-1]))
    ax.set_ylim(bottom=0.0)
    ax.grid(True, alpha=0.3)
    if len(chosen) <= max_agents:
        ax.legend(ncol=min(6, len(chosen) + 2 * summarised), fontsize=8, loc="upper right")
    title = title or "error principal angle of each spacecraft"
    if summarised:  # always said, also under a caller's title
        title += f"\n{len(chosen)} of {n} spacecraft drawn (largest θ_ei in the second half), band: all {n}"
    ax.set_title(title, fontsize=10 if summarised else None)
    return fig


def torques_figure(
    time: np.ndarray,
    u: np.ndarray,
    torque_limit: float,
    *,
    title: str | None = None,
    ylim: tuple[float, float] | None = None,
    rasterized: bool = True,
    max_panels: int = MAX_AGENTS_DRAWN,
) -> Figure:
    """Control torques ``u_i`` of every spacecraft, one panel per agent, with the limit drawn (Fig 4).

    Parameters
    ----------
    time : (T,) array
        Time (s).
    u : (T, n, 3) array
        Applied (or commanded) torque per body axis, N m.
    torque_limit : float
        Per-component bound ``|(u_i)_k| <= u_max`` (N m); drawn as dashed lines when finite.
    title : str, optional
        Figure title; when not all agents are drawn a second line says which.
    ylim : (float, float), optional
        Common y range; default: 1.15 times the limit when finite, else the data range.
    rasterized : bool
        Rasterize the torque lines inside vector output (chattering torques make huge SVGs).
    max_panels : int
        Most panels (>= 2).  For ``n > max_panels`` agents the ``max_panels - 1`` agents with the largest RMS
        torque get a panel each and the last panel is the envelope of all ``n`` agents (min-max band over
        agents and axes, and the median of ``|u|``).

    Returns
    -------
    matplotlib.figure.Figure
        ``min(n, max_panels)`` axes (``fig.axes``): agent i in panel i, or the drawn agents in increasing
        order followed by the envelope panel.
    """
    time, u = _check_series(time, u, "u")
    if u.ndim != 3 or u.shape[2] != 3:
        raise ValueError(f"u must have shape (T, n, 3), got {u.shape}")
    if max_panels < 2:
        raise ValueError(f"max_panels must be >= 2, got {max_panels}")
    n = u.shape[1]
    summarised = n > max_panels
    shown = _worst_agents(np.sqrt(np.mean(np.square(u), axis=(0, 2))), max_panels - 1) if summarised else range(n)
    panels = len(shown) + summarised
    cols = 2 if panels > 1 else 1
    rows = math.ceil(panels / cols)
    fig = Figure(figsize=(9.0, 2.1 * rows + 0.6), layout="constrained")
    axes = fig.subplots(rows, cols, sharex=True, squeeze=False).ravel()
    finite = math.isfinite(torque_limit)
    if ylim is None:
        ylim = (-1.15 * torque_limit, 1.15 * torque_limit) if finite else None

    def decorate(ax, ylabel):
        if finite:
            for sign in (-1, 1):
                ax.axhline(sign * torque_limit, color="k", ls="--", lw=0.8)
        if ylim is not None:
            ax.set_ylim(*ylim)
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, ncol=3, loc="upper right")

    for ax, i in zip(axes, shown, strict=False):
        for k in range(3):
            ax.plot(time, u[:, i, k], lw=0.6, color=_AXIS_COLORS[k], label=f"u{i + 1},{k + 1}", rasterized=rasterized)
        decorate(ax, f"u{i + 1} (N m)")
    if summarised:
        ax = axes[len(shown)]
        lo, _, hi = _envelope(u)
        _, med, _ = _envelope(np.abs(u))
        ax.fill_between(time, lo, hi, color="0.8", lw=0, label="min-max", rasterized=rasterized)
        ax.plot(time, med, color="0.3", lw=0.6, label="median |u|", rasterized=rasterized)
        decorate(ax, f"all {n} (N m)")
    for ax in axes[panels:]:
        fig.delaxes(ax)
    for ax in axes[max(0, panels - cols) : panels]:
        ax.set_xlabel("time (s)")
    limit = f"|u_k| ≤ {torque_limit:g} N m" if finite else "no torque limit"
    title = title or f"control torques ({limit})"
    if summarised:  # always said, also under a caller's title
        title += f"\n{len(shown)} of {n} agents drawn (largest RMS torque); last panel: all {n}"
    fig.suptitle(title)
    return fig


def overlay_figure(
    curves: Mapping[str, tuple[np.ndarray, np.ndarray]],
    *,
    ylabel: str,
    title: str,
    inset_start: float | None = None,
    log: bool = False,
) -> Figure:
    """Several runs of one quantity on common axes (Figs 5-6: Case 2 vs Case 1; Figs 8-9: Cases 3a-3c).

    Parameters
    ----------
    curves : mapping label -> (time, values)
        One line per run (time in s).
    ylabel : str
        Axis label, e.g. ``"AAEM (deg), eq 42"``.
    title : str
        Figure title.
    inset_start : float, optional
        Start (s) of a zoomed inset of the last part; default: none.
    log : bool
        Logarithmic y axis (values <= 0 are not drawn).

    Returns
    -------
    matplotlib.figure.Figure
        One axes with one labelled line per run.
    """
    if not curves:
        raise ValueError("overlay_figure: no curves")
    fig = Figure(figsize=(7.0, 4.2), layout="constrained")
    ax = fig.add_subplot()
    colors = [f"C{k}" for k in range(10)]
    lines = []
    t_end = -math.inf
    t_start = math.inf
    for k, (label, (time, values)) in enumerate(curves.items()):
        time, values = _check_series(time, values, label)
        color = colors[k % len(colors)]
        plot_values = np.where(values > 0, values, np.nan) if log else values
        ax.plot(time, plot_values, lw=1.0, color=color, label=label)
        lines.append((time, values, color, label))
        t_end = max(t_end, float(time[-1]))
        t_start = min(t_start, float(time[0]))
    if log:
        ax.set_yscale("log")
    else:
        ax.set_ylim(bottom=0.0)
    ax.set_xlim(t_start, t_end)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper left" if inset_start is not None else "best")
    ax.set_title(title)
    if inset_start is not None and math.isfinite(inset_start):
        inset = ax.inset_axes((0.45, 0.42, 0.52, 0.5))
        top = 0.0
        for time, values, color, label in lines:
            sel = time >= inset_start
            if np.count_nonzero(sel) >= 2:
                inset.plot(time[sel], values[sel], lw=0.8, color=color, label=label)
                if np.all(np.isfinite(values[sel])):
                    top = max(top, float(np.max(values[sel])))
        inset.set_xlim(inset_start, t_end)
        inset.set_ylim(0.0, top * 1.1 if top > 0 else 1.0)
        inset.set_title(f"t ≥ {inset_start:g} s", fontsize=8)
        inset.tick_params(labelsize=7)
        inset.grid(True, alpha=0.3)
    return fig


def simulation_figures(result: SimulationResult, *, tolerances_deg: Sequence[float] = ()) -> dict[str, Figure]:
    """The single-run figures of one :class:`~fsmctl.simulation.simulator.SimulationResult` (analogues of Figs 1-4).

    Parameters
    ----------
    result : SimulationResult
        A finished run.
    tolerances_deg : sequence of float
        Tolerances drawn in the metric insets.

    Returns
    -------
    dict of str -> Figure
        ``"aaem"`` (eq 42), ``"raem"`` (eq 43), ``"theta_e"`` (eq 2), ``"torques"`` (applied u_i).
    """
    label = result.scenario.label
    t = result.time
    return {
        "aaem": metric_figure(t, result.aaem_deg, metric="AAEM", title=f"AAEM, {label}", tolerances_deg=tolerances_deg),
        "raem": metric_figure(t, result.raem_deg, metric="RAEM", title=f"RAEM, {label}", tolerances_deg=tolerances_deg),
        "theta_e": principal_angles_figure(t, np.degrees(result.theta_e), title=f"error principal angles, {label}"),
        "torques": torques_figure(
            t, result.u, result.scenario.controller.torque_limit, title=f"control torques, {label}"
        ),
    }


def save_figure(fig: Figure, stem: str | Path, *, dpi: int = 130) -> list[Path]:
    """Write ``fig`` as ``stem.png`` and ``stem.svg`` (parent folders are created).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    stem : str or Path
        Path without suffix.
    dpi : int
        Resolution of the PNG (and of rasterized parts of the SVG).

    Returns
    -------
    list of Path
        The PNG and SVG paths.
    """
    from fsmctl.outputs import atomic_path

    stem = Path(stem)
    paths = []
    for suffix in (".png", ".svg"):
        path = stem.with_name(stem.name + suffix)
        with atomic_path(path) as tmp:  # written whole or not at all
            fig.savefig(tmp, dpi=dpi, format=suffix[1:])
        paths.append(path)
    return paths
