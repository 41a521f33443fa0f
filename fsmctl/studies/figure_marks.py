"""Reference marks on the figures: the paper's stated values drawn beside the reproduction, each with its label.

A :class:`ReferenceMarks` says what a figure marks: vertical lines at stated times (the 27 s settling time),
horizontal lines at stated levels (the ±2 N m torque bound, Case 2's errors), shaded accuracy bands (Case 1's
AAEM < 0.03°, RAEM < 0.01°), the printed axes as a dashed box, and the y range of the printed inset.  :func:`paper_marks` gives
those of the paper's Figs 1-9, :func:`metric_marks` those of a diagnostic figure of AAEM or RAEM, and
:func:`torque_marks` those of a torque figure; every number comes from :mod:`fsmctl.studies.paper_statements`.

The builders of :mod:`fsmctl.studies.figures` draw them with the helpers here.  Every drawn mark is an artist with
``gid`` :data:`REFERENCE_GID` and its label (``"paper: 27 s"``) as ``label``, and its label is written beside it as
a text with ``gid`` :data:`LABEL_GID`, so that a reader sees the claim and the reproduction on one axes and a test
can find each mark and its value.  :func:`keep_coinciding_visible` keeps every run of an overlay in view when two
coincide (the paper's Case 3c and Case 1 without the torque limit are the same run).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from fsmctl.studies.paper_statements import (
    CASE2_RELATIVE_ERROR,
    CASE2_TRACKING_ERROR,
    RELATIVE_ACCURACY,
    SETTLING_TIME,
    TORQUE_BOUND,
    TRACKING_ACCURACY,
    PaperStatement,
    printed_axes,
)

if TYPE_CHECKING:
    from collections.abc import Sequence

    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.text import Text

__all__ = [
    "REFERENCE_GID",
    "LABEL_GID",
    "ABOVE_RANGE_GID",
    "REFERENCE_COLOR",
    "Mark",
    "ReferenceMarks",
    "paper_marks",
    "metric_marks",
    "torque_marks",
    "keep_coinciding_visible",
    "text_box",
    "TAIL_GID",
    "zoom_on_transient",
    "CAPTION_KEY",
    "figure_caption",
    "read_caption",
]

REFERENCE_GID = "reference"
"""``gid`` of every drawn reference mark (line, band or box)."""
LABEL_GID = "reference-label"
"""``gid`` of the text that labels a reference mark."""
ABOVE_RANGE_GID = "above-range"
"""``gid`` of the note a zoom writes when the run lies above its fixed y range."""
REFERENCE_COLOR = "#b2182b"
"""The colour of the paper's marks (a dark red that is none of the agents' or runs' colours)."""
_BAND_ALPHA = 0.15


@dataclass(frozen=True)
class Mark:
    """One marked value and its label.

    Parameters
    ----------
    value : float
        Where the mark is (a time in s, or a value of the y axis).
    label : str
        What it says (``"paper: 27 s"``).
    """

    value: float
    label: str

    @classmethod
    def of(cls, statement: PaperStatement, sign: float = 1.0) -> Mark:
        """The mark of a paper statement (``sign=-1``: at minus its value, for a symmetric bound).

        Parameters
        ----------
        statement : PaperStatement
            The statement.
        sign : float
            ``1`` or ``-1``.

        Returns
        -------
        Mark
            At ``sign * statement.value``, labelled ``statement.label``.

        Examples
        --------
        >>> Mark.of(SETTLING_TIME)
        Mark(value=27.0, label='paper: 27 s')
        """
        return cls(sign * statement.value, statement.label)


@dataclass(frozen=True)
class ReferenceMarks:
    """What a figure marks for comparison.

    Parameters
    ----------
    times : tuple of Mark
        Vertical lines (s), in the axes and in the zoom.
    levels : tuple of Mark
        Horizontal lines (y unit), wherever they lie inside the y range (in the zoom, on the main axes when they
        are visible there: on a log axis, or more than 1 % of the y range above its bottom).
    bands : tuple of Mark
        Shaded bands from 0 to the value (an accuracy), like ``levels``.
    box : (x0, x1, y0, y1), optional
        The printed axes' ranges, drawn as a dashed box on the main axes (whose y range grows to hold it).
    box_label : str
        The box's label.
    inset_ylim : (float, float), optional
        The y range of the zoom (the printed inset's), which then spans the whole run as the paper's insets do.
    unit : str
        The unit of the y axis (for the zoom's note when the run lies above its range).

    Examples
    --------
    >>> marks = paper_marks(1)
    >>> [m.label for m in marks.times], [m.label for m in marks.bands], marks.inset_ylim
    (['paper: 27 s'], ['paper: Case 1 AAEM < 0.03°'], (0.0, 0.04))
    """

    times: tuple[Mark, ...] = ()
    levels: tuple[Mark, ...] = ()
    bands: tuple[Mark, ...] = ()
    box: tuple[float, float, float, float] | None = None
    box_label: str = ""
    inset_ylim: tuple[float, float] | None = None
    unit: str = "°"


_STATED = {  # the paper's Figs 1-9: what the text states about each (besides its printed axes)
    1: {"times": (Mark.of(SETTLING_TIME),), "bands": (Mark.of(TRACKING_ACCURACY),)},
    2: {"times": (Mark.of(SETTLING_TIME),), "bands": (Mark.of(RELATIVE_ACCURACY),)},
    4: {"levels": (Mark.of(TORQUE_BOUND), Mark.of(TORQUE_BOUND, -1.0))},
    5: {"levels": (Mark.of(CASE2_TRACKING_ERROR),)},
    6: {"levels": (Mark.of(CASE2_RELATIVE_ERROR),)},
}


def paper_marks(figure: int) -> ReferenceMarks:
    """The reference marks of the analogue of the paper's Fig ``figure``: its stated values and printed axes.

    Parameters
    ----------
    figure : int
        1-9.

    Returns
    -------
    ReferenceMarks
        Figs 1-2: the 27 s settling time and the accuracy band (Case 1's AAEM < 0.03°, RAEM < 0.01°); Fig 4: the ±2 N m
        bound; Figs 5-6: Case 2's stated errors; every figure but Fig 4 (whose printed axes are the bound): the
        printed axes as a box; Figs 1-2, 5-6, 8-9: the printed inset's y range.

    Raises
    ------
    KeyError
        If the paper has no such figure.

    Examples
    --------
    >>> paper_marks(4).levels[0]
    Mark(value=2.0, label='paper: |u_k| ≤ 2 N m')
    >>> paper_marks(8).box, paper_marks(8).inset_ylim
    ((0.0, 100.0, 0.0, 300.0), (0.0, 0.04))
    """
    axes = printed_axes(figure)
    box = None if figure == 4 else (*axes.xlim, *axes.ylim)
    return ReferenceMarks(
        **_STATED.get(figure, {}),
        box=box,
        box_label=f"paper's Fig {figure}: {axes.text}" if box else "",
        inset_ylim=axes.inset_ylim,
        unit=axes.unit,
    )


def metric_marks(metric: str) -> ReferenceMarks:
    """The reference marks of a diagnostic figure of AAEM or RAEM: the 27 s settling time and the metric's accuracy.

    Parameters
    ----------
    metric : {"aaem", "raem"}
        The metric (case-insensitive).

    Returns
    -------
    ReferenceMarks
        The settling time and the stated accuracy of the metric as a band.

    Raises
    ------
    ValueError
        If ``metric`` is neither.

    Examples
    --------
    >>> [m.label for m in metric_marks("raem").bands]
    ['paper: Case 1 RAEM < 0.01°']
    """
    accuracy = {"aaem": TRACKING_ACCURACY, "raem": RELATIVE_ACCURACY}.get(metric.lower())
    if accuracy is None:
        raise ValueError(f"metric must be 'aaem' or 'raem', got {metric!r}")
    return ReferenceMarks(times=(Mark.of(SETTLING_TIME),), bands=(Mark.of(accuracy),))


def torque_marks() -> ReferenceMarks:
    """The reference marks of a torque figure: the paper's bound ``|(u_i)_k| ≤ 2 N m`` at ±2 N m.

    Returns
    -------
    ReferenceMarks
        Two levels.

    Examples
    --------
    >>> [m.value for m in torque_marks().levels]
    [2.0, -2.0]
    """
    return ReferenceMarks(levels=paper_marks(4).levels, unit=printed_axes(4).unit)


# ----------------------------------------------------------------------------- drawing


def _label(ax: Axes, x: float, y: float, text: str, transform, **kw) -> Text:
    style = {"fontsize": 7, "color": REFERENCE_COLOR, "gid": LABEL_GID, "clip_on": True,
             "bbox": {"boxstyle": "square,pad=0.05", "fc": "white", "ec": "none", "alpha": 0.6}}  # fmt: skip
    return ax.text(x, y, text, transform=transform, **(style | kw))


def _visible(ax: Axes, value: float) -> bool:
    """Whether a level lies inside the y range and, on a linear axis, 1 % of the range above its bottom."""
    lo, hi = sorted(ax.get_ylim())
    if not lo <= value <= hi:
        return False
    return ax.get_yscale() == "log" or value - lo > 0.01 * (hi - lo)


def draw_box(ax: Axes, marks: ReferenceMarks | None) -> list[Text]:
    """The printed axes as a dashed box on ``ax`` (before autoscaling: the y range grows to hold it).

    Returns its label text (or nothing without a box).
    """
    if marks is None or marks.box is None:
        return []
    from matplotlib.patches import Rectangle

    x0, x1, y0, y1 = marks.box
    rect = Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, ls="--", lw=0.8, ec=REFERENCE_COLOR, alpha=0.7)
    rect.set(gid=REFERENCE_GID, label=marks.box_label)
    ax.add_patch(rect)
    return [_label(ax, x0, y1, f" {marks.box_label}", ax.transData, va="bottom", ha="left")]


def include_levels(ax: Axes, marks: ReferenceMarks | None) -> None:
    """On a log axis, extend the y range down to show the positive levels and bands of ``marks`` (the accuracy a
    run should reach is in view even when the run does not reach it)."""
    values = [m.value for m in (*marks.levels, *marks.bands) if m.value > 0] if marks is not None else []
    if values and ax.get_yscale() == "log":
        lo, hi = ax.get_ylim()
        ax.set_ylim(min(lo, 0.5 * min(values)), hi)


def draw_marks(ax: Axes, marks: ReferenceMarks | None, *, small: bool = False) -> list[Text]:
    """Draw the times, levels and bands of ``marks`` that are visible on ``ax`` (call after its limits are set).

    Returns the label texts (a zoom placed later must not hide them).
    """
    if marks is None:
        return []
    from matplotlib.transforms import offset_copy

    texts: list[Text] = []
    size = 6 if small else 7
    written: set[str] = set()  # a symmetric pair of levels (±2 N m) is labelled once
    for mark in marks.times:
        if ax.get_xlim()[0] <= mark.value <= ax.get_xlim()[1]:
            ax.axvline(mark.value, color=REFERENCE_COLOR, ls="-.", lw=0.9, gid=REFERENCE_GID, label=mark.label)
            texts.append(_label(ax, mark.value, 0.03, f"{mark.label} ", ax.get_xaxis_transform(), va="bottom",
                                ha="right", rotation=90, fontsize=size))  # fmt: skip
    for mark in marks.bands:
        if _visible(ax, mark.value):
            ax.axhspan(0.0, mark.value, color=REFERENCE_COLOR, alpha=_BAND_ALPHA, lw=0, gid=REFERENCE_GID,
                       label=mark.label)  # fmt: skip
            below = offset_copy(ax.get_yaxis_transform(), fig=ax.figure, y=-2.0, units="points")  # off the edge
            texts.append(_label(ax, 0.99, mark.value, mark.label, below, ha="right", va="top", fontsize=size))
    for mark in marks.levels:
        if _visible(ax, mark.value):
            ax.axhline(mark.value, color=REFERENCE_COLOR, ls=":", lw=1.0, gid=REFERENCE_GID, label=mark.label)
            if mark.label in written:
                continue
            written.add(mark.label)
            texts.append(_label(ax, 0.99, mark.value, mark.label, ax.get_yaxis_transform(), ha="right",
                                va="bottom" if mark.value >= 0 else "top", fontsize=size))  # fmt: skip
    return texts


def note_above_range(
    zoom: Axes, runs: Sequence[tuple[str, np.ndarray]], unit: str, avoid: Sequence[Text] = ()
) -> Text | None:
    """When a run (the zoomed part of its values) rises above ``zoom``'s fixed y range, say so inside it, per run.

    ``runs`` are ``(label, values)`` pairs.  One run: one line, ``"↑ always above: max 166°, min 83.3°"``;
    several: one line per run above the range, with its own largest (and, when always above,
    smallest) value, so that no number mixes two runs.  The note goes to the first corner of the zoom (top left,
    top right, bottom left, bottom right) where it covers none of the texts ``avoid`` (the marks' labels), else
    where it covers the least of them.

    Returns the note (``gid`` :data:`ABOVE_RANGE_GID`), or None when every value lies inside the range.
    """
    top = zoom.get_ylim()[1]
    lines = []
    for label, values in runs:
        finite = np.asarray(values, float)[np.isfinite(values)]
        if not finite.size or float(np.max(finite)) <= top:
            continue
        high, low = float(np.max(finite)), float(np.min(finite))
        always = low > top
        lines.append((label, always, f"max {high:.3g}{unit}" + (f", min {low:.3g}{unit}" if always else "")))
    if not lines:
        return None
    if len(runs) == 1:
        _, always, values_text = lines[0]
        text = f"↑ {'always' if always else 'partly'} above: {values_text}"  # one short line: room for the labels
    else:
        text = "↑ above this range:\n" + "\n".join(
            f"{label}: {'always' if always else 'partly'}, {values_text}" for label, always, values_text in lines
        )
    box = {"boxstyle": "round,pad=0.2", "fc": "white", "ec": "0.5", "alpha": 0.9}
    note = zoom.text(0.02, 0.96, text, transform=zoom.transAxes, ha="left", va="top", fontsize=6.5, color="0.15",
                     bbox=box, gid=ABOVE_RANGE_GID, zorder=5)  # fmt: skip
    if avoid:
        _place_clear_of(note, avoid)
    return note


def _place_clear_of(note: Text, avoid: Sequence[Text]) -> None:
    """Move ``note`` (axes fraction) to the first corner where its box overlaps none of ``avoid``, else the least."""
    corners = ((0.02, 0.96, "left", "top"), (0.98, 0.96, "right", "top"), (0.02, 0.04, "left", "bottom"),
               (0.98, 0.04, "right", "bottom"))  # fmt: skip
    best = None
    for x, y, ha, va in corners:
        note.set(x=x, y=y, ha=ha, va=va)
        covered = sum(_overlap_area(note, other) for other in avoid)
        if best is None or covered < best[0]:
            best = (covered, x, y, ha, va)
        if covered == 0.0:
            return
    _, x, y, ha, va = best
    note.set(x=x, y=y, ha=ha, va=va)


def text_box(text: Text):
    """The display box of a drawn ``text``, with its background box (``bbox``) when it has one.

    Parameters
    ----------
    text : matplotlib.text.Text
        A text of a figure.

    Returns
    -------
    matplotlib.transforms.Bbox
        In display units, after drawing the figure.

    Examples
    --------
    >>> from matplotlib.figure import Figure
    >>> ax = Figure().add_subplot()
    >>> small, boxed = ax.text(0.5, 0.5, "a"), ax.text(0.5, 0.5, "a", bbox={"pad": 5})
    >>> bool(text_box(boxed).width > text_box(small).width)
    True
    """
    fig = text.get_figure(root=True)
    fig.draw_without_rendering()
    patch = text.get_bbox_patch()
    box = text.get_window_extent()
    if patch is not None:
        from matplotlib.transforms import Bbox

        box = Bbox.union([box, patch.get_window_extent()])
    return box


def _overlap_area(a: Text, b: Text) -> float:
    """The display area where the box of ``a``, widened by 2 points, and the box of ``b`` overlap (0: they do not)."""
    p, q = text_box(a).padded(2.0 * a.get_figure(root=True).dpi / 72.0), text_box(b)
    w = min(p.x1, q.x1) - max(p.x0, q.x0)
    h = min(p.y1, q.y1) - max(p.y0, q.y0)
    return max(w, 0.0) * max(h, 0.0)


def span_text(lo: float, hi: float, unit: str) -> str:
    """``"0-0.04°"``: a y range in a title."""
    sep = "" if unit == "°" else " "
    return f"{lo:g}-{hi:g}{sep}{unit}" if math.isfinite(hi) else f"from {lo:g}{sep}{unit}"


TAIL_GID = "small-tail"
"""``gid`` of the note of a torque figure whose time axis ends before the run: the torques after it are small."""


def zoom_on_transient(axes: Sequence[Axes], time: np.ndarray, u: np.ndarray, marks: ReferenceMarks | None) -> None:
    """Without a torque limit: end the time axis at 3 times the time after which every ``|(u_i)_k|`` stays below
    the marks' level (the paper's 2 N m), when that is under a third of the run, and say so in the top panel;
    torques of more than 100 times the level get a symmetric-log y axis, linear within ``±level``.

    A commanded torque of 1e4 N m that decays in 3 s is otherwise a line at the start of a 100 s axis.

    Parameters
    ----------
    axes : sequence of Axes
        The panels of a torque figure (sharing the time axis; the note goes to the first).
    time : (T,) array
        Time (s).
    u : (T, n, 3) array
        The torques (N m).
    marks : ReferenceMarks, optional
        Their levels set the threshold (none: nothing changes).

    Examples
    --------
    >>> import numpy as np
    >>> from matplotlib.figure import Figure
    >>> t = np.linspace(0.0, 100.0, 1001)
    >>> u = 1e4 * np.exp(-t / 0.2)[:, None, None] * np.ones((1, 1, 3))  # below 2 N m after 1.8 s
    >>> ax = Figure().add_subplot()
    >>> zoom_on_transient([ax], t, u, torque_marks())
    >>> round(ax.get_xlim()[1], 6), ax.get_yscale(), [text.get_text() for text in ax.texts]
    (5.4, 'symlog', ['t > 1.8 s (to 100 s): |(u_i)_k| < 2 N m'])
    """
    level = max((abs(m.value) for m in marks.levels), default=0.0) if marks is not None else 0.0
    if level <= 0.0:
        return
    peak = np.max(np.abs(u), axis=(1, 2))
    above = np.flatnonzero(~(peak < level))  # NaN counts as above
    if above.size == 0 or above[-1] + 1 >= time.size:
        return
    t0, t_end = float(time[0]), float(time[-1])
    settled = float(time[above[-1] + 1])
    end = t0 + 3.0 * (settled - t0)
    if end >= t0 + (t_end - t0) / 3.0:
        return
    axes[-1].set_xlim(t0, end)
    if float(np.nanmax(peak)) > 100.0 * level:  # decades above the level: linear within it, logarithmic beyond
        for ax in axes:
            ax.set_yscale("symlog", linthresh=level)
    unit = marks.unit if marks is not None else "N m"
    axes[0].text(0.99, 0.96, f"t > {settled:.3g} s (to {t_end:g} s): |(u_i)_k| < {level:g} {unit}",
                 transform=axes[0].transAxes, ha="right", va="top", fontsize=8, gid=TAIL_GID,
                 bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": "0.5", "alpha": 0.9})  # fmt: skip


CAPTION_KEY = "Description"
"""The metadata key under which :func:`fsmctl.studies.figures.save_figure` stores :func:`figure_caption` in the PNG and the SVG."""


def figure_caption(fig: Figure) -> str:
    """What a figure shows, in one line: its title, its zoom's, and the paper's values it marks.

    The caption is read from the figure itself (its titles and the labels of its reference marks,
    :data:`REFERENCE_GID`), so that a report's caption and the figure say the same.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        A figure of :mod:`fsmctl.studies.figures`.

    Returns
    -------
    str
        ``"<title>; inset: <zoom title>. The paper's marks: <mark>, <mark>"`` (the parts a figure has).

    Examples
    --------
    >>> import numpy as np
    >>> from fsmctl.studies.figures import metric_figure
    >>> t = np.linspace(0.0, 100.0, 1001)
    >>> print(figure_caption(metric_figure(t, 0.02 + 0 * t, title="AAEM, Case 1", marks=paper_marks(1))))
    AAEM, Case 1; inset: zoom 0-0.04° (the paper's inset). The paper's marks: Fig 1: 0-300° axis (ticks every 50°), 27 s, Case 1 AAEM < 0.03°
    """
    suptitle = fig.get_suptitle()
    main = [ax for ax in fig.axes if ax.get_title()]
    title = suptitle or (main[0].get_title() if main else "")
    parts = [" ".join(title.split("\n")[0].split())] if title else []
    insets = [inset.get_title() for ax in fig.axes for inset in ax.child_axes if inset.get_title()]
    insets += [ax.get_title() for ax in main[1:] if not suptitle]
    parts += [f"inset: {text}" for text in insets[:1]]
    labels: list[str] = []
    for axes in [*fig.axes, *(inset for ax in fig.axes for inset in ax.child_axes)]:
        for artist in axes.get_children():
            label = artist.get_label() if artist.get_gid() == REFERENCE_GID else ""
            label = label.removeprefix("paper: ").removeprefix("paper's ")
            if label and label not in labels:
                labels.append(label)
    caption = "; ".join(parts)
    return caption + (f". The paper's marks: {', '.join(labels)}" if labels else "")


def read_caption(png: str | Path) -> str:
    """The caption :func:`fsmctl.studies.figures.save_figure` stored in a PNG (:data:`CAPTION_KEY`), or ``""``.

    Parameters
    ----------
    png : str or Path
        A PNG file.

    Returns
    -------
    str
        :func:`figure_caption` of the saved figure; ``""`` when the file is missing, unreadable or has none.

    Examples
    --------
    >>> import numpy as np
    >>> from fsmctl.studies.figures import metric_figure, save_figure
    >>> t = np.linspace(0.0, 10.0, 101)
    >>> png, _ = save_figure(metric_figure(t, 50 * np.exp(-t), title="AAEM, a test"), "figures/aaem")
    >>> read_caption(png), read_caption("figures/none.png")
    ('AAEM, a test; inset: t ≥ 5 s', '')
    """
    from PIL import Image

    try:
        with Image.open(png) as image:
            return str(getattr(image, "text", {}).get(CAPTION_KEY, ""))
    except OSError:
        return ""


# ----------------------------------------------------------------------------- runs that coincide


def _coincide(ax: Axes, a: Line2D, b: Line2D) -> bool:
    """Whether two lines of ``ax`` on one time grid lie within one line width of each other everywhere (display)."""
    (ta, ya), (tb, yb) = a.get_data(), b.get_data()
    if len(ta) != len(tb) or not np.array_equal(ta, tb):
        return False
    pa = ax.transData.transform(np.column_stack([ta, ya]))
    pb = ax.transData.transform(np.column_stack([tb, yb]))
    both = np.all(np.isfinite(pa), axis=1) & np.all(np.isfinite(pb), axis=1)
    if not both.any() or not np.array_equal(np.isfinite(pa[:, 1]), np.isfinite(pb[:, 1])):
        return False
    width_px = max(a.get_linewidth(), b.get_linewidth()) * ax.figure.dpi / 72.0
    return float(np.max(np.abs(pa[both, 1] - pb[both, 1]))) <= width_px


def keep_coinciding_visible(ax: Axes, lines: Sequence[Line2D]) -> None:
    """A line covered by later ones (the same within the line width) is drawn wider, beneath them, and its label
    says which lines cover it: every run listed in the legend stays visible."""
    ax.figure.draw_without_rendering()  # the final layout: the display distances are those of the figure
    for i, line in enumerate(lines):
        covers = [later.get_label() for later in lines[i + 1 :] if _coincide(ax, line, later)]
        if covers:
            line.set(lw=line.get_linewidth() + 2.2 * len(covers), alpha=0.55, zorder=line.get_zorder() - 0.1 * len(covers),
                     label=f"{line.get_label()} (under {', '.join(covers)}: the same within the line width)")  # fmt: skip
