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

Colours: agent ``i`` (0-based) is drawn in :func:`fsmctl.model.time_response.agent_color` ``(i)`` in every figure
(its ``theta_ei`` line, its torque panel), so an agent keeps its colour from one figure to the next; the three body
axes of one agent's torque differ by line style.  Formation-level metrics are black, and the runs of an overlay use
their own palette (:data:`RUN_COLORS`), which shares no colour with the agents'.

Zoomed insets (the paper's Figs 1-2, 5-6, 8-9 zoom on the last part of each metric) are placed where the main
curves are not: the emptiest corner of the axes that holds the inset with its tick labels and title.  When no part
of the axes is free the zoom becomes a separate panel below the main axes instead of hiding the curves.

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

from fsmctl.model.time_response import agent_color

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from fsmctl.simulation.simulator import SimulationResult

__all__ = [
    "MAX_AGENTS_DRAWN",
    "METRIC_EQUATIONS",
    "COMPONENT_STYLES",
    "RUN_COLORS",
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

COMPONENT_STYLES = ("-", "--", ":")
"""Line styles of the body axes 1, 2, 3 of one agent's vector (the colour is the agent's)."""

RUN_COLORS = ("#000000", "#1b9e77", "#d95f02", "#7570b3", "#e7298a", "#66a61e", "#a6761d", "#e6ab02")
"""Colours of the runs of an overlay (black, then ColorBrewer's "Dark2"): distinct from the agents' colours."""

_RUN_STYLES = ("-", "--", "-.", ":")
_METRIC_COLOR = "k"

# inset placement (axes fraction): candidate sizes, largest first, and the room its labels take outside its box
_INSET_SIZES = ((0.52, 0.5), (0.44, 0.42), (0.36, 0.36), (0.3, 0.3))
_INSET_ROOM = (0.09, 0.09, 0.015, 0.1)  # left (y tick labels), bottom (x tick labels), right, top (title)
_GRID = 60  # cells per side of the occupancy grid


def _check_series(time: np.ndarray, values: np.ndarray, name: str) -> tuple[np.ndarray, np.ndarray]:
    time = np.asarray(time, dtype=float)
    values = np.asarray(values, dtype=float)
    if time.ndim != 1 or time.size < 2:
        raise ValueError(f"{name}: time must be a 1-D array of at least 2 samples, got shape {time.shape}")
    if values.shape[0] != time.size:
        raise ValueError(f"{name}: {values.shape[0]} samples for {time.size} time points")
    return time, values


# ----------------------------------------------------------------------------- zoomed insets


def _occupancy(ax: Axes, curves: Sequence[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """``(G, G)`` booleans ``[column, row]``: the cells of ``ax`` (axes fraction) that a curve passes through.

    Every segment between two finite samples marks the cells of its bounding box, so a curve cannot cross a free
    cell between two samples (conservative for steep or sparse curves).  Points outside the view count at its edge.
    """
    G = _GRID
    occupied = np.zeros((G, G), dtype=bool)
    to_axes = ax.transData + ax.transAxes.inverted()
    rows = np.arange(G)
    for x, y in curves:
        with np.errstate(all="ignore"):
            p = to_axes.transform(np.column_stack([np.asarray(x, float), np.asarray(y, float)]))
        finite = np.all(np.isfinite(p), axis=1)
        p = np.clip(np.where(finite[:, None], p, 0.0), 0.0, 1.0 - 1e-9)
        pair = finite[:-1] & finite[1:]
        alone = finite & ~np.concatenate([[False], pair]) & ~np.concatenate([pair, [False]])
        a = np.vstack([p[:-1][pair], p[alone]])
        b = np.vstack([p[1:][pair], p[alone]])
        if not a.size:
            continue
        c0, c1 = (np.minimum(a[:, 0], b[:, 0]) * G).astype(int), (np.maximum(a[:, 0], b[:, 0]) * G).astype(int)
        r0, r1 = (np.minimum(a[:, 1], b[:, 1]) * G).astype(int), (np.maximum(a[:, 1], b[:, 1]) * G).astype(int)
        span = c1 - c0 + 1
        first = np.repeat(np.cumsum(span) - span, span)
        cols = np.repeat(c0, span) + np.arange(int(span.sum())) - first
        lo, hi = np.full(G, G), np.full(G, -1)
        np.minimum.at(lo, cols, np.repeat(r0, span))
        np.maximum.at(hi, cols, np.repeat(r1, span))
        occupied |= (rows[None, :] >= lo[:, None]) & (rows[None, :] <= hi[:, None])
    return occupied


def _cells(lo: float, hi: float) -> tuple[int, int]:
    """Cell index range ``[first, last)`` of the axes-fraction interval ``[lo, hi]``."""
    return max(0, math.floor(lo * _GRID)), min(_GRID, math.ceil(hi * _GRID))


def _is_free(table: np.ndarray, x0: float, y0: float, x1: float, y1: float) -> bool:
    """Whether no occupied cell lies in the axes-fraction box, from the summed-area ``table`` of the occupancy."""
    if x0 < 0 or y0 < 0 or x1 > 1 or y1 > 1:
        return False
    (c0, c1), (r0, r1) = _cells(x0, x1), _cells(y0, y1)
    return table[c1, r1] - table[c0, r1] - table[c1, r0] + table[c0, r0] == 0


def _inset_candidates(occupied: np.ndarray) -> list[tuple[float, float, float, float]]:
    """Free inset rectangles ``(x0, y0, w, h)`` in axes fraction, largest first, then nearest the top right.

    A rectangle is free when the box around it that its tick labels and title take (:data:`_INSET_ROOM`)
    holds no curve.
    """
    table = np.zeros((_GRID + 1, _GRID + 1), dtype=int)
    table[1:, 1:] = np.cumsum(np.cumsum(occupied, axis=0), axis=1)
    left, bottom, right, top = _INSET_ROOM
    found = []
    for w, h in _INSET_SIZES:
        spots = []
        for x0 in np.arange(left, 1.0 - w - right + 1e-9, 1.0 / _GRID):
            for y0 in np.arange(bottom, 1.0 - h - top + 1e-9, 1.0 / _GRID):
                if _is_free(table, x0 - left, y0 - bottom, x0 + w + right, y0 + h + top):
                    spots.append((float(x0), float(y0), w, h))
        found += sorted(spots, key=lambda s: -(s[0] + s[1]))
    return found


def _inset_is_clear(ax: Axes, inset: Axes, occupied: np.ndarray) -> bool:
    """Whether the drawn ``inset`` (with its tick labels and title) covers no occupied cell of ``ax``."""
    ax.figure.draw_without_rendering()
    box = inset.get_tightbbox().transformed(ax.transAxes.inverted())
    table = np.zeros((_GRID + 1, _GRID + 1), dtype=int)
    table[1:, 1:] = np.cumsum(np.cumsum(occupied, axis=0), axis=1)
    return _is_free(table, box.x0, box.y0, box.x1, box.y1)


def _draw_zoom(
    zoom: Axes,
    curves: Sequence[tuple[np.ndarray, np.ndarray, str, str, str]],
    start: float,
    t_end: float,
    tolerances: Sequence[float],
    small: bool,
) -> None:
    """Draw the ``t >= start`` part of every curve ``(time, values, color, linestyle, label)`` into ``zoom``."""
    top, bottom = 0.0, 0.0
    for time, values, color, style, label in curves:
        sel = time >= start
        if np.count_nonzero(sel) < 2:
            continue
        v = values[sel]
        zoom.plot(time[sel], v, color=color, ls=style, lw=0.8, label=label)
        finite = v[np.isfinite(v)]
        if finite.size:
            top, bottom = max(top, float(np.max(finite))), min(bottom, float(np.min(finite)))
    zoom.set_xlim(start, t_end)
    zoom.set_ylim(bottom * 1.1, top * 1.1 if top > 0 else 1.0)
    for tol in tolerances:
        zoom.axhline(tol, color="gray", ls=":", lw=0.8)
    zoom.grid(True, alpha=0.3)
    if small:
        zoom.set_title(f"t ≥ {start:g} s", fontsize=8)
        zoom.tick_params(labelsize=7)
    else:
        zoom.set_title(f"zoom: t ≥ {start:g} s", fontsize=10)
        zoom.set_xlabel("time (s)")


def _add_zoom(
    ax: Axes,
    curves: Sequence[tuple[np.ndarray, np.ndarray, str, str, str]],
    start: float,
    tolerances: Sequence[float] = (),
) -> Axes | None:
    """A zoom on ``t >= start`` of ``curves``: an inset where the main curves are not, else a panel below ``ax``.

    Returns the zoom's axes (``ax.child_axes[0]`` for an inset), or None when no curve has two samples after
    ``start``.
    """
    if not any(np.count_nonzero(time >= start) >= 2 for time, *_ in curves):
        return None
    t_end = max(float(time[-1]) for time, *_ in curves)
    ax.autoscale_view()
    occupied = _occupancy(ax, [(time, values) for time, values, *_ in curves])
    for rect in _inset_candidates(occupied)[:3]:  # the first is nearly always clear; measure to be sure
        inset = ax.inset_axes(rect)
        _draw_zoom(inset, curves, start, t_end, tolerances, small=True)
        if _inset_is_clear(ax, inset, occupied):
            return inset
        inset.remove()
    # no free region: the zoom as a separate panel below, never on top of the curves
    fig = ax.figure
    grid = fig.add_gridspec(2, 1, height_ratios=(3, 2))
    ax.set_subplotspec(grid[0])
    zoom = fig.add_subplot(grid[1])
    width, height = fig.get_size_inches()
    fig.set_size_inches(width, height * 1.6)
    _draw_zoom(zoom, curves, start, t_end, tolerances, small=False)
    return zoom


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


# ----------------------------------------------------------------------------- the builders


def metric_figure(
    time: np.ndarray,
    metric_deg: np.ndarray,
    *,
    metric: str = "AAEM",
    title: str | None = None,
    inset_start: float | None = None,
    tolerances_deg: Sequence[float] = (),
) -> Figure:
    """A formation error metric against time with a zoom on its last part (Figs 1-2).

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
        Start (s) of the zoom; default: the second half of the run. ``nan`` disables it.
    tolerances_deg : sequence of float
        Tolerance levels drawn as dotted lines in the zoom.

    Returns
    -------
    matplotlib.figure.Figure
        The metric in black on ``fig.axes[0]``.  The zoom is an inset (``fig.axes[0].child_axes[0]``) placed
        where the curve is not, or, when no region of the axes is free, a second panel ``fig.axes[1]``.

    Raises
    ------
    ValueError
        If ``metric`` is not ``"AAEM"`` or ``"RAEM"``, or ``time`` and ``metric_deg`` do not match.

    Examples
    --------
    A metric that decays from 100 deg: the inset zooms on the second half, in the upper right where the
    curve is not.

    >>> import numpy as np
    >>> t = np.linspace(0.0, 100.0, 1001)
    >>> fig = metric_figure(t, 100.0 * np.exp(-t / 5.0), metric="AAEM", tolerances_deg=(0.03,))
    >>> ax = fig.axes[0]
    >>> ax.get_ylabel()
    'AAEM (deg), eq 42'
    >>> (inset,) = ax.child_axes
    >>> inset.get_xlim()
    (50.0, 100.0)
    >>> bool(inset.get_position().x0 > 0.3 and inset.get_position().y0 > 0.3)
    True
    """
    if metric not in METRIC_EQUATIONS:
        raise ValueError(f"metric must be one of {list(METRIC_EQUATIONS)}, got {metric!r}")
    time, metric_deg = _check_series(time, metric_deg, metric)
    fig = Figure(figsize=(7.0, 4.2), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(time, metric_deg, color=_METRIC_COLOR, lw=1.0)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(f"{metric} (deg), {METRIC_EQUATIONS[metric]}")
    ax.set_xlim(float(time[0]), float(time[-1]))
    ax.set_ylim(bottom=0.0)
    ax.grid(True, alpha=0.3)
    ax.set_title(title or f"{metric} ({METRIC_EQUATIONS[metric]})")
    start = 0.5 * (time[0] + time[-1]) if inset_start is None else inset_start
    if math.isfinite(start):
        _add_zoom(ax, [(time, metric_deg, _METRIC_COLOR, "-", metric)], float(start), tolerances_deg)
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
        One axes with one line per drawn agent, labelled ``θ1``, ``θ2``, ..., agent ``i`` in
        :func:`~fsmctl.model.time_response.agent_color` ``(i - 1)``; with more than ``max_agents`` agents and no
        ``agents``, also the min-max band and the median over all agents (grey).

    Raises
    ------
    ValueError
        If an agent of ``agents`` is not in ``1..n``, or ``time`` and ``theta_e_deg`` do not match.

    Examples
    --------
    >>> import numpy as np
    >>> from fsmctl.model.time_response import agent_color
    >>> t = np.linspace(0.0, 10.0, 101)
    >>> theta = 90.0 * np.exp(-t[:, None] / np.arange(1.0, 4.0))  # three agents, deg
    >>> fig = principal_angles_figure(t, theta, agents=[1, 3])
    >>> [(line.get_label(), line.get_color() == agent_color(a - 1)) for line, a in zip(fig.axes[0].lines, [1, 3])]
    [('θ1', True), ('θ3', True)]
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
        ax.plot(time, theta_e_deg[:, a - 1], lw=1.0, color=agent_color(a - 1), label=f"θ{a}")
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
        order followed by the envelope panel.  Agent ``i``'s three components are drawn in its colour
        (:func:`~fsmctl.model.time_response.agent_color`), body axes 1-3 with the line styles
        :data:`COMPONENT_STYLES`; the limits are black dashed lines.

    Raises
    ------
    ValueError
        If ``u`` is not ``(T, n, 3)`` for the ``T`` times, or ``max_panels < 2``.

    Examples
    --------
    The torques of a short Case 1 run of the paper (Liang et al. 2012, Sec. 4), saturated at 2 N m at the start:

    >>> from fsmctl import paper_scenario, simulate
    >>> from fsmctl.model.time_response import agent_color
    >>> run = simulate(paper_scenario("1").replace(simulation={"t_final": 1.0}), progress=False)
    >>> fig = torques_figure(run.time, run.u, 2.0)
    >>> len(fig.axes), fig.axes[1].get_ylabel()
    (6, 'u2 (N m)')
    >>> [(line.get_color() == agent_color(1), line.get_linestyle()) for line in fig.axes[1].lines[:3]]
    [(True, '-'), (True, '--'), (True, ':')]
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
            ax.plot(
                time,
                u[:, i, k],
                lw=0.7,
                color=agent_color(i),
                ls=COMPONENT_STYLES[k],
                label=f"u{i + 1},{k + 1}",
                rasterized=rasterized,
            )
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
        Start (s) of a zoom on the last part; default: none.
    log : bool
        Logarithmic y axis (values <= 0 are not drawn).

    Returns
    -------
    matplotlib.figure.Figure
        One axes (``fig.axes[0]``) with one labelled line per run, run ``k`` in :data:`RUN_COLORS` ``[k]``
        with its own line style; the legend is below the axes (it never hides a curve).  The zoom is an inset
        (``fig.axes[0].child_axes[0]``) placed where the curves are not, or a second panel ``fig.axes[1]``.

    Raises
    ------
    ValueError
        If ``curves`` is empty, or a run's time and values do not match.

    Examples
    --------
    Two runs that decay at different rates, with a zoom on their second half:

    >>> import numpy as np
    >>> t = np.linspace(0.0, 100.0, 501)
    >>> fig = overlay_figure(
    ...     {"Case 1": (t, 90 * np.exp(-t / 4)), "Case 2": (t, 90 * np.exp(-t / 8))},
    ...     ylabel="AAEM (deg), eq 42", title="Case 2 vs Case 1", inset_start=50.0,
    ... )
    >>> [line.get_label() for line in fig.axes[0].lines]
    ['Case 1', 'Case 2']
    >>> fig.axes[0].child_axes[0].get_xlim()
    (50.0, 100.0)
    """
    if not curves:
        raise ValueError("overlay_figure: no curves")
    fig = Figure(figsize=(7.0, 4.2), layout="constrained")
    ax = fig.add_subplot()
    lines = []
    t_start, t_end = math.inf, -math.inf
    for k, (label, (time, values)) in enumerate(curves.items()):
        time, values = _check_series(time, values, label)
        color, style = RUN_COLORS[k % len(RUN_COLORS)], _RUN_STYLES[(k // len(RUN_COLORS)) % len(_RUN_STYLES)]
        plot_values = np.where(values > 0, values, np.nan) if log else values
        ax.plot(time, plot_values, lw=1.0, color=color, ls=style, label=label)
        lines.append((time, plot_values, color, style, label))
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
    ax.set_title(title)
    fig.legend(fontsize=8, loc="outside lower center", ncols=min(len(lines), 3))
    if inset_start is not None and math.isfinite(inset_start):
        _add_zoom(ax, lines, float(inset_start))
    return fig


def simulation_figures(result: SimulationResult, *, tolerances_deg: Sequence[float] = ()) -> dict[str, Figure]:
    """The single-run figures of one :class:`~fsmctl.simulation.simulator.SimulationResult` (analogues of Figs 1-4).

    Parameters
    ----------
    result : SimulationResult
        A finished run.
    tolerances_deg : sequence of float
        Tolerances drawn in the metric zooms.

    Returns
    -------
    dict of str -> Figure
        ``"aaem"`` (eq 42), ``"raem"`` (eq 43), ``"theta_e"`` (eq 2), ``"torques"`` (applied u_i); agent ``i``
        has the same colour in ``"theta_e"`` and ``"torques"``.

    Examples
    --------
    A 1 s run of the paper's Case 1: spacecraft 3 has one colour in both figures that show agents.

    >>> from fsmctl import paper_scenario, simulate
    >>> run = simulate(paper_scenario("1").replace(simulation={"t_final": 1.0}), progress=False)
    >>> figs = simulation_figures(run, tolerances_deg=(0.03,))
    >>> sorted(figs)
    ['aaem', 'raem', 'theta_e', 'torques']
    >>> theta3 = figs["theta_e"].axes[0].lines[2]
    >>> theta3.get_label(), theta3.get_color() == figs["torques"].axes[2].lines[0].get_color()
    ('θ3', True)
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
    """Write ``fig`` as ``stem.png`` and ``stem.svg`` (parent folders are created), each atomically.

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

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0.0, 10.0, 101)
    >>> paths = save_figure(metric_figure(t, 50 * np.exp(-t)), "figures/aaem")
    >>> [str(p) for p in paths]
    ['figures/aaem.png', 'figures/aaem.svg']
    >>> paths[0].read_bytes()[:4]
    b'\\x89PNG'
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
