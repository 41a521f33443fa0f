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
(its ``theta_ei`` line, its torque line in each body axis' panel of Fig 4).  Formation-level metrics are black, and the
runs of an overlay use their own palette (:data:`RUN_COLORS`), which shares no colour with the agents'; a run hidden
under a later one (the same within the line width) is drawn wider beneath it and its legend entry says so.

The paper's statements (:mod:`fsmctl.studies.figure_marks`: the 27 s settling time, the accuracy bands, the ±2 N m
bound, the printed axes) are drawn as labelled reference marks when a builder gets ``marks``.  Zooms are placed where
the main curves and the marks' labels are not (the emptiest corner that holds the inset with its labels), else as a
panel below the axes; with ``marks.inset_ylim`` a zoom spans the whole run at the paper's printed inset range and says
inside when the run lies above it.

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
from fsmctl.studies.figure_marks import (
    CAPTION_KEY,
    ReferenceMarks,
    draw_box,
    draw_marks,
    figure_caption,
    include_levels,
    keep_coinciding_visible,
    note_above_range,
    span_text,
    zoom_on_transient,
)

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.text import Text

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
    span: tuple[float, float],
    tolerances: Sequence[float],
    small: bool,
    marks: ReferenceMarks | None,
) -> None:
    """Draw the part of every curve ``(time, values, color, linestyle, label)`` in the time ``span`` into ``zoom``.

    The y range is the data's, or ``marks.inset_ylim`` (the printed inset's) when given: then a note inside the
    zoom says when the runs lie above it.
    """
    start, t_end = span
    top, bottom = 0.0, 0.0
    shown = []
    for time, values, color, style, label in curves:
        sel = time >= start
        if np.count_nonzero(sel) < 2:
            continue
        v = values[sel]
        zoom.plot(time[sel], v, color=color, ls=style, lw=0.8, label=label)
        shown.append((label, v))
        finite = v[np.isfinite(v)]
        if finite.size:
            top, bottom = max(top, float(np.max(finite))), min(bottom, float(np.min(finite)))
    zoom.set_xlim(start, t_end)
    fixed = marks.inset_ylim if marks is not None else None
    zoom.set_ylim(fixed if fixed is not None else (bottom * 1.1, top * 1.1 if top > 0 else 1.0))
    for tol in tolerances:
        zoom.axhline(tol, color="gray", ls=":", lw=0.8)
    zoom.grid(True, alpha=0.3)
    labels = draw_marks(zoom, marks, small=small)
    if fixed is not None:
        note_above_range(zoom, shown, marks.unit, avoid=labels)
        what = f"zoom {span_text(*fixed, marks.unit)} (the paper's inset)"
    else:
        what = f"t ≥ {start:g} s" if small else f"zoom: t ≥ {start:g} s"
    if small:
        zoom.set_title(what, fontsize=8)
        zoom.tick_params(labelsize=7)
    else:
        zoom.set_title(what, fontsize=10)
        zoom.set_xlabel("time (s)")


def _text_boxes(ax: Axes, texts: Sequence[Text]) -> list[tuple[float, float, float, float]]:
    """The boxes ``(x0, y0, x1, y1)`` of ``texts`` in ``ax``'s axes fraction (after drawing)."""
    if not texts:
        return []
    ax.figure.draw_without_rendering()
    to_axes = ax.transAxes.inverted()
    boxes = []
    for text in texts:
        b = text.get_window_extent().transformed(to_axes)
        boxes.append((b.x0, b.y0, b.x1, b.y1))
    return boxes


def _add_zoom(
    ax: Axes,
    curves: Sequence[tuple[np.ndarray, np.ndarray, str, str, str]],
    start: float,
    tolerances: Sequence[float] = (),
    marks: ReferenceMarks | None = None,
    avoid: Sequence[Text] = (),
) -> Axes | None:
    """A zoom on ``t >= start`` of ``curves``: an inset where the main curves (and the texts ``avoid``) are not,
    else a panel below ``ax``.

    Returns the zoom's axes (``ax.child_axes[0]`` for an inset), or None when no curve has two samples after
    ``start``.
    """
    if not any(np.count_nonzero(time >= start) >= 2 for time, *_ in curves):
        return None
    t_end = max(float(time[-1]) for time, *_ in curves)
    ax.autoscale_view()
    occupied = _occupancy(ax, [(time, values) for time, values, *_ in curves])
    for x0, y0, x1, y1 in _text_boxes(ax, avoid):
        (c0, c1), (r0, r1) = _cells(x0, x1), _cells(y0, y1)
        occupied[c0:c1, r0:r1] = True
    for rect in _inset_candidates(occupied)[:3]:  # the first is nearly always clear; measure to be sure
        inset = ax.inset_axes(rect)
        _draw_zoom(inset, curves, (start, t_end), tolerances, True, marks)
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
    _draw_zoom(zoom, curves, (start, t_end), tolerances, False, marks)
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
    marks: ReferenceMarks | None = None,
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
        Start (s) of the zoom; default: the second half of the run, or its start when ``marks`` fix the zoom's
        y range (the paper's insets span the whole run). ``nan`` disables it.
    tolerances_deg : sequence of float
        Tolerance levels drawn as dotted lines in the zoom.
    marks : ReferenceMarks, optional
        Values to mark (:func:`fsmctl.studies.figure_marks.paper_marks`: the paper's Fig 1 or 2): stated times and
        bands, the printed axes as a dashed box, and the zoom's y range (the printed inset's), with a note inside
        the zoom when the run lies above it.

    Returns
    -------
    matplotlib.figure.Figure
        The metric in black on ``fig.axes[0]``.  The zoom is an inset (``fig.axes[0].child_axes[0]``) placed
        where the curve and the marks' labels are not, or, when no region of the axes is free, a second panel
        ``fig.axes[1]``.

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

    With the paper's Fig 1 marked: the zoom spans the whole run at the printed inset's 0-0.04°, with the 27 s
    settling time and the 0.03° accuracy band; a run that stays above the range says so inside the zoom.

    >>> from fsmctl.studies.figure_marks import ABOVE_RANGE_GID, paper_marks
    >>> fig = metric_figure(t, 100.0 + 0 * t, metric="AAEM", marks=paper_marks(1))
    >>> (inset,) = fig.axes[0].child_axes
    >>> inset.get_xlim(), inset.get_ylim()
    ((0.0, 100.0), (0.0, 0.04))
    >>> (note,) = [text for text in inset.texts if text.get_gid() == ABOVE_RANGE_GID]
    >>> print(note.get_text())
    ↑ always above: max 100°, min 100°
    """
    if metric not in METRIC_EQUATIONS:
        raise ValueError(f"metric must be one of {list(METRIC_EQUATIONS)}, got {metric!r}")
    time, metric_deg = _check_series(time, metric_deg, metric)
    fig = Figure(figsize=(7.0, 4.2), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(time, metric_deg, color=_METRIC_COLOR, lw=1.0)
    labels = draw_box(ax, marks)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(f"{metric} (deg), {METRIC_EQUATIONS[metric]}")
    ax.set_xlim(float(time[0]), float(time[-1]))
    ax.set_ylim(bottom=0.0)
    ax.grid(True, alpha=0.3)
    ax.set_title(title or f"{metric} ({METRIC_EQUATIONS[metric]})")
    labels += draw_marks(ax, marks)
    start = _zoom_start(time, inset_start, marks)
    if math.isfinite(start):
        _add_zoom(ax, [(time, metric_deg, _METRIC_COLOR, "-", metric)], start, tolerances_deg, marks, labels)
    return fig


def _zoom_start(time: np.ndarray, inset_start: float | None, marks: ReferenceMarks | None) -> float:
    """The zoom's start: given, else the run's start for a printed inset range (the paper's span the run), else
    the second half."""
    if inset_start is not None:
        return float(inset_start)
    if marks is not None and marks.inset_ylim is not None:
        return float(time[0])
    return float(0.5 * (time[0] + time[-1]))


def principal_angles_figure(
    time: np.ndarray,
    theta_e_deg: np.ndarray,
    *,
    agents: Sequence[int] | None = None,
    title: str | None = None,
    max_agents: int = MAX_AGENTS_DRAWN,
    marks: ReferenceMarks | None = None,
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
    marks : ReferenceMarks, optional
        Values to mark (:func:`fsmctl.studies.figure_marks.paper_marks` of Fig 3 or 7: the printed axes as a box).

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
    draw_box(ax, marks)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("θ_ei (deg), eq 2")
    ax.set_xlim(float(time[0]), float(time[-1]))
    ax.set_ylim(bottom=0.0)
    ax.grid(True, alpha=0.3)
    draw_marks(ax, marks)
    if len(chosen) <= max_agents:
        fig.legend(ncols=min(6, len(chosen) + 2 * summarised), fontsize=8, loc="outside lower center")
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
    max_agents: int = MAX_AGENTS_DRAWN,
    marks: ReferenceMarks | None = None,
) -> Figure:
    """Control torques ``u_i``: one panel per body axis, one colour per spacecraft, the limit drawn (Fig 4).

    Parameters
    ----------
    time : (T,) array
        Time (s).
    u : (T, n, 3) array
        Applied (or commanded) torque per body axis, N m.
    torque_limit : float
        Per-component bound ``|(u_i)_k| <= u_max`` (N m); drawn as labelled dashed lines ``±u_max`` when finite.
    title : str, optional
        Figure title; when not all agents are drawn a second line says which.
    ylim : (float, float), optional
        Common y range; default: 1.15 times the limit when finite, else the data range.
    rasterized : bool
        Rasterize the torque lines inside vector output (chattering torques make huge SVGs).
    max_agents : int
        Most agents drawn one by one (>= 2).  For ``n > max_agents`` agents the ``max_agents - 1`` agents with the
        largest RMS torque are drawn, and every panel shows the envelope of all ``n`` agents (min-max band).
    marks : ReferenceMarks, optional
        Levels to mark (:func:`fsmctl.studies.figure_marks.torque_marks`: the paper's ±2 N m); a mark at
        ``±torque_limit`` labels the limit's lines instead of drawing a line of its own.

    Returns
    -------
    matplotlib.figure.Figure
        Three axes sharing the time axis (``fig.axes``: body axes 1, 2, 3, top to bottom); agent ``i``'s line in
        :func:`~fsmctl.model.time_response.agent_color` ``(i - 1)`` in each, labelled ``u1``, ``u2``, ...; the
        limits black dashed; one figure legend (``fig.legends[0]``) beside the axes, off the data.

    Raises
    ------
    ValueError
        If ``u`` is not ``(T, n, 3)`` for the ``T`` times, or ``max_agents < 2``.

    Examples
    --------
    The torques of a short Case 1 run of the paper (Liang et al. 2012, Sec. 4), saturated at 2 N m at the start:

    >>> from fsmctl import paper_scenario, simulate
    >>> from fsmctl.model.time_response import agent_color
    >>> from fsmctl.studies.figure_marks import torque_marks
    >>> run = simulate(paper_scenario("1").replace(simulation={"t_final": 1.0}), progress=False)
    >>> fig = torques_figure(run.time, run.u, 2.0, marks=torque_marks())
    >>> [ax.get_ylabel() for ax in fig.axes]
    ['(u_i)_1 (N m)', '(u_i)_2 (N m)', '(u_i)_3 (N m)']
    >>> [(line.get_label(), line.get_color() == agent_color(i)) for i, line in enumerate(fig.axes[1].lines[:2])]
    [('u1', True), ('u2', True)]
    >>> sorted({line.get_label() for line in fig.axes[0].lines if line.get_gid() == "limit"})
    ['±u_max = 2 N m (paper: |u_k| ≤ 2 N m)']
    """
    time, u = _check_series(time, u, "u")
    if u.ndim != 3 or u.shape[2] != 3:
        raise ValueError(f"u must have shape (T, n, 3), got {u.shape}")
    if max_agents < 2:
        raise ValueError(f"max_agents must be >= 2, got {max_agents}")
    n = u.shape[1]
    summarised = n > max_agents
    shown = _worst_agents(np.sqrt(np.mean(np.square(u), axis=(0, 2))), max_agents - 1) if summarised else range(n)
    fig = Figure(figsize=(9.0, 6.6), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True)
    finite = math.isfinite(torque_limit)
    if ylim is None and finite:
        ylim = (-1.15 * torque_limit, 1.15 * torque_limit)
    for k, ax in enumerate(axes):
        if summarised:
            band_lo, band_hi = _envelope(u[:, :, k])[::2]
            ax.fill_between(time, band_lo, band_hi, color="0.85", lw=0, label=f"min-max of all {n}",
                            rasterized=rasterized)  # fmt: skip
        for i in shown:
            ax.plot(time, u[:, i, k], lw=0.7, color=agent_color(i), label=f"u{i + 1}", rasterized=rasterized)
        if ylim is not None:
            ax.set_ylim(*ylim)
        ax.set_ylabel(f"(u_i)_{k + 1} (N m)")
        ax.grid(True, alpha=0.3)
        _torque_limits(ax, torque_limit, marks)
    axes[-1].set_xlabel("time (s)")
    axes[-1].set_xlim(float(time[0]), float(time[-1]))
    if not finite:
        zoom_on_transient(axes, time, u, marks)
    entries = dict(zip(*reversed(axes[0].get_legend_handles_labels()), strict=True))  # label -> handle, once each
    fig.legend(entries.values(), entries.keys(), loc="outside right upper", fontsize=8)
    limit = f"|u_k| ≤ {torque_limit:g} N m" if finite else "no torque limit"
    title = title or f"control torques ({limit})"
    if summarised:  # always said, also under a caller's title
        title += f"\n{len(shown)} of {n} agents drawn (largest RMS torque); band: all {n}"
    fig.suptitle(title)
    return fig


def _torque_limits(ax: Axes, torque_limit: float, marks: ReferenceMarks | None) -> None:
    """The ``±torque_limit`` lines (labelled, ``gid="limit"``) and the marks' levels, each labelled at its line."""
    levels = list(marks.levels) if marks is not None else []
    if math.isfinite(torque_limit):
        same = [m for m in levels if abs(abs(m.value) - torque_limit) <= 1e-9 * torque_limit]
        label = f"±u_max = {torque_limit:g} N m" + (f" ({same[0].label})" if same else "")
        for sign in (1, -1):
            ax.axhline(sign * torque_limit, color="k", ls="--", lw=0.8, gid="limit", label=label)
        levels = [m for m in levels if m not in same]
    draw_marks(ax, ReferenceMarks(levels=tuple(levels)) if levels else None)


def overlay_figure(
    curves: Mapping[str, tuple[np.ndarray, np.ndarray]],
    *,
    ylabel: str,
    title: str,
    inset_start: float | None = None,
    log: bool = False,
    marks: ReferenceMarks | None = None,
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
        Start (s) of a zoom on the last part; default: none, or the runs' start when ``marks`` fix the zoom's y
        range (the paper's insets span the whole run).
    log : bool
        Logarithmic y axis (values <= 0 are not drawn).
    marks : ReferenceMarks, optional
        Values to mark (:func:`fsmctl.studies.figure_marks.paper_marks`, :func:`~fsmctl.studies.figure_marks.metric_marks`):
        stated times, levels and bands, the printed axes as a dashed box (linear axes), the zoom's y range.

    Returns
    -------
    matplotlib.figure.Figure
        One axes (``fig.axes[0]``) with one labelled line per run, run ``k`` in :data:`RUN_COLORS` ``[k]``
        with its own line style; the legend is below the axes (it never hides a curve).  A run whose curve
        coincides with a later one within the line width (it would be hidden under it) is drawn wider beneath it,
        and its legend entry says which run covers it.  The zoom is an inset (``fig.axes[0].child_axes[0]``)
        placed where the curves are not, or a second panel ``fig.axes[1]``.

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

    Two runs that coincide: the first is drawn wider beneath the second, and the legend says so.

    >>> fig = overlay_figure({"a": (t, 90 * np.exp(-t / 4)), "b": (t, 90 * np.exp(-t / 4))}, ylabel="x",
    ...                      title="same", log=True)
    >>> [text.get_text() for text in fig.legends[0].get_texts()]
    ['a (under b: the same within the line width)', 'b']
    """
    if not curves:
        raise ValueError("overlay_figure: no curves")
    fig = Figure(figsize=(7.0, 4.2), layout="constrained")
    ax = fig.add_subplot()
    lines = []
    for k, (label, (time, values)) in enumerate(curves.items()):
        time, values = _check_series(time, values, label)
        color, style = RUN_COLORS[k % len(RUN_COLORS)], _RUN_STYLES[(k // len(RUN_COLORS)) % len(_RUN_STYLES)]
        plot_values = np.where(values > 0, values, np.nan) if log else values
        lines.append((time, plot_values, color, style, label))
    drawn = [ax.plot(time, v, lw=1.0, color=c, ls=st, label=lab)[0] for time, v, c, st, lab in lines]
    if log:
        ax.set_yscale("log")
    labels = [] if log else draw_box(ax, marks)
    if not log:
        ax.set_ylim(bottom=0.0)
    ax.set_xlim(min(float(t[0]) for t, *_ in lines), max(float(t[-1]) for t, *_ in lines))
    ax.set_xlabel("time (s)")
    ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    ax.set_title(title)
    include_levels(ax, marks)
    labels += draw_marks(ax, marks)
    keep_coinciding_visible(ax, drawn)
    fig.legend(handles=drawn, fontsize=8, loc="outside lower center", ncols=min(len(lines), 3))
    if inset_start is None and marks is not None and marks.inset_ylim is not None and not log:
        inset_start = min(float(t[0]) for t, *_ in lines)  # the paper's insets span the whole run
    if inset_start is not None and math.isfinite(inset_start):
        _add_zoom(ax, lines, float(inset_start), (), marks, labels)
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
    >>> theta3.get_label(), theta3.get_color() == figs["torques"].axes[0].lines[2].get_color()
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

    Both files carry :func:`~fsmctl.studies.figure_marks.figure_caption` as metadata
    (:data:`~fsmctl.studies.figure_marks.CAPTION_KEY`), which a report shows as the caption.

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
    caption = figure_caption(fig)
    paths = []
    for suffix in (".png", ".svg"):
        path = stem.with_name(stem.name + suffix)
        with atomic_path(path) as tmp:  # written whole or not at all
            fig.savefig(tmp, dpi=dpi, format=suffix[1:], metadata={CAPTION_KEY: caption})
        paths.append(path)
    return paths
