"""What Liang, Sun & Wang (2012), Section 4, states in numbers: its stated values and the printed axes of Figs 1-9.

One record per number of the paper, read by everything that uses it: the claims (:mod:`fsmctl.studies.claims`,
:mod:`fsmctl.studies.claim_types`), the figure checks (:mod:`fsmctl.studies.figure_checks`) and the reference marks
of the reproduction's figures (:mod:`fsmctl.studies.figure_marks`), so that no number of the paper is typed twice.

* :class:`PaperStatement`: a value the text states (the 27 s settling time, the 0.03° / 0.01° accuracies, Case 2's
  errors, the ±2 N m torque bound);
* :class:`PrintedAxes`: the axis ranges of a printed figure (the main axes and the inset's), as the paper's tick
  labels give them.  The insets of Figs 1-2, 5-6 and 8-9 span the whole 100 s run (ticks 0, 50, 100 s) with a y
  range set by hand (0-0.04°, 0-0.02°, 0-0.1°, 0-0.04°).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "PaperStatement",
    "PrintedAxes",
    "SETTLING_TIME",
    "TRACKING_ACCURACY",
    "RELATIVE_ACCURACY",
    "CASE2_TRACKING_ERROR",
    "CASE2_RELATIVE_ERROR",
    "TORQUE_BOUND",
    "PRINTED_AXES",
    "printed_axes",
]


@dataclass(frozen=True)
class PaperStatement:
    """One value the paper states, with what it is of and where it says so.

    Parameters
    ----------
    quantity : str
        What the value is of (``"AAEM"``).
    value : float
        The stated number.
    unit : str
        Its unit (``"°"``, ``"s"``, ``"N m"``).
    relation : str
        How the quantity relates to the value (``"≤"``, ``">"``), or ``""`` for the value itself.
    source : str
        Where and in which words the paper states it.

    Examples
    --------
    >>> TRACKING_ACCURACY.value, TRACKING_ACCURACY.label
    (0.03, 'paper: Case 1 AAEM < 0.03°')
    >>> SETTLING_TIME.label
    'paper: 27 s'
    """

    quantity: str
    value: float
    unit: str
    relation: str
    source: str

    @property
    def text(self) -> str:
        """The value with its unit (``"0.03°"``, ``"27 s"``, ``"2 N m"``)."""
        return f"{self.value:g}{self.unit}" if self.unit == "°" else f"{self.value:g} {self.unit}"

    @property
    def label(self) -> str:
        """The label of a reference mark: ``"paper: "`` and the statement (``"paper: Case 1 AAEM < 0.03°"``)."""
        return f"paper: {self.quantity} {self.relation} {self.text}" if self.relation else f"paper: {self.text}"


SETTLING_TIME = PaperStatement(
    "settling time", 27.0, "s", "", "Sec. 4, Figs 1-2: 'both fall to the tolerance in 27 s' (tolerance not stated)"
)
TRACKING_ACCURACY = PaperStatement(
    "Case 1 AAEM", 0.03, "°", "<", "Sec. 4, Fig 1: 'the attitude tracking accuracy is higher than 0.03°'"
)
RELATIVE_ACCURACY = PaperStatement(
    "Case 1 RAEM", 0.01, "°", "<", "Sec. 4, Fig 2: 'the relative attitude control accuracy is able to reach 0.01°'"
)
CASE2_TRACKING_ERROR = PaperStatement(
    "Case 2 AAEM", 0.05, "°", ">", "Sec. 4, Fig 5: 'the tracking error is larger than 0.05°'"
)
CASE2_RELATIVE_ERROR = PaperStatement(
    "Case 2 RAEM", 0.03, "°", ">", "Sec. 4, Fig 6: 'the relative control error is larger than 0.03°'"
)
TORQUE_BOUND = PaperStatement(
    "|u_k|", 2.0, "N m", "≤", "Sec. 4, Fig 4: 'the control torques are bounded as |(u_i)_k| ≤ 2 N m'"
)


@dataclass(frozen=True)
class PrintedAxes:
    """The axis ranges of one printed figure of the paper (from its tick labels).

    Parameters
    ----------
    figure : int
        The figure's number (1-9).
    quantity : str
        What its y axis shows.
    ylim : (float, float)
        The main axes' y range.
    tick : float
        The spacing of its y ticks.
    xlim : (float, float)
        The time axis (s), the whole run: 0-100 s for every figure.
    inset_ylim : (float, float), optional
        The y range of the inset (which spans ``xlim`` too); None: no inset.
    unit : str
        The unit of the y axis.

    Examples
    --------
    >>> fig1 = printed_axes(1)
    >>> fig1.ylim, fig1.inset_ylim, fig1.top_interval
    ((0.0, 300.0), (0.0, 0.04), (250.0, 300.0))
    >>> fig1.text
    '0-300° axis (ticks every 50°)'
    """

    figure: int
    quantity: str
    ylim: tuple[float, float]
    tick: float
    xlim: tuple[float, float] = (0.0, 100.0)
    inset_ylim: tuple[float, float] | None = None
    unit: str = "°"

    @property
    def top_interval(self) -> tuple[float, float]:
        """``(top - tick, top)``: an autoscaled axis ends at the first tick above the data, so its peak lies here."""
        return (self.ylim[1] - self.tick, self.ylim[1])

    @property
    def text(self) -> str:
        """The main y range, e.g. ``"0-300° axis (ticks every 50°)"``."""
        lo, hi = self.ylim
        if lo == -hi:
            return f"±{hi:g} {self.unit} axes"
        return f"{lo:g}-{hi:g}{self.unit} axis (ticks every {self.tick:g}{self.unit})"

    @property
    def inset_text(self) -> str:
        """The inset's y range, e.g. ``"0-0.04°"`` (``""`` without an inset)."""
        if self.inset_ylim is None:
            return ""
        return f"{self.inset_ylim[0]:g}-{self.inset_ylim[1]:g}{self.unit}"


PRINTED_AXES: tuple[PrintedAxes, ...] = (
    PrintedAxes(1, "AAEM", (0.0, 300.0), 50.0, inset_ylim=(0.0, 0.04)),
    PrintedAxes(2, "RAEM", (0.0, 140.0), 20.0, inset_ylim=(0.0, 0.02)),
    PrintedAxes(3, "θ_1-θ_4", (0.0, 200.0), 20.0),
    # printed at the torque bound: ticks -2, 0, 2 N m
    PrintedAxes(4, "u_i", (-TORQUE_BOUND.value, TORQUE_BOUND.value), TORQUE_BOUND.value, unit="N m"),
    PrintedAxes(5, "AAEM", (0.0, 300.0), 50.0, inset_ylim=(0.0, 0.1)),
    PrintedAxes(6, "RAEM", (0.0, 140.0), 20.0, inset_ylim=(0.0, 0.1)),
    PrintedAxes(7, "θ_1-θ_4", (0.0, 160.0), 20.0),
    PrintedAxes(8, "AAEM", (0.0, 300.0), 50.0, inset_ylim=(0.0, 0.04)),
    PrintedAxes(9, "RAEM", (0.0, 140.0), 20.0, inset_ylim=(0.0, 0.04)),
)
"""The printed axes of Figs 1-9, in order (the paper's tick labels)."""


def printed_axes(figure: int) -> PrintedAxes:
    """The printed axes of Fig ``figure`` of the paper.

    Parameters
    ----------
    figure : int
        1-9.

    Returns
    -------
    PrintedAxes
        The record of :data:`PRINTED_AXES`.

    Raises
    ------
    KeyError
        If the paper has no such figure.

    Examples
    --------
    >>> printed_axes(4).ylim
    (-2.0, 2.0)
    """
    for axes in PRINTED_AXES:
        if axes.figure == figure:
            return axes
    raise KeyError(f"the paper has no Fig {figure!r} (Figs 1-{len(PRINTED_AXES)})")
