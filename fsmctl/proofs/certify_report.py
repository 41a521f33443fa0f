"""What ``fsmctl certify`` reports while it runs and in its Markdown file, beyond the certificate's own lines.

:class:`CertifyStage` is what :func:`fsmctl.proofs.certificate.certify_law` passes to its ``stage`` callback when the
work moves on (:data:`STEPS`; each candidate named by :func:`candidate_label`), so that a caller can label a progress
bar per candidate and show the steps that have no progress of their own (the origin's argument and the boundary level,
the levels); :class:`StageReporter` turns the search's ``progress`` calls into those reports.
:func:`counterexample_table` is the Markdown section that shows a counterexample's point.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from fsmctl.proofs.certify_problem import Candidate

__all__ = [
    "CHOOSING",
    "LEVELS",
    "ORIGIN",
    "POINT_COLUMNS",
    "SEARCH",
    "STEPS",
    "CertifyStage",
    "StageReporter",
    "candidate_label",
    "counterexample_table",
]

CHOOSING = "choosing the candidates"
ORIGIN = "the origin's argument and the boundary level"
SEARCH = "branch and bound"
LEVELS = "the levels"
STEPS = (CHOOSING, ORIGIN, SEARCH, LEVELS)
"""the steps :func:`fsmctl.proofs.certificate.certify_law` reports to its ``stage`` callback, in order (the last
three once per candidate)"""


@dataclass(frozen=True)
class CertifyStage:
    """Where :func:`fsmctl.proofs.certificate.certify_law` is: its ``stage`` callback's argument.

    Parameters
    ----------
    step : str
        One of :data:`STEPS`.
    candidate : str
        The candidate's label (:func:`candidate_label`); empty while the candidates are chosen.
    index, count : int
        The candidate's number (1-based) and how many are lined up (the first certified one ends the run).

    Examples
    --------
    >>> from fsmctl.proofs.certify_report import SEARCH, CertifyStage
    >>> CertifyStage(SEARCH, "declared V", 1, 3).title()
    'candidate 1/3: declared V'
    """

    step: str
    candidate: str = ""
    index: int = 0
    count: int = 0

    def title(self) -> str:
        """What is being searched: the candidate and its number, or the step before the candidates."""
        return f"candidate {self.index}/{self.count}: {self.candidate}" if self.candidate else self.step


def candidate_label(candidate: Candidate) -> str:
    """A short label of a candidate, e.g. for a progress bar.

    Parameters
    ----------
    candidate : Candidate
        The candidate.

    Returns
    -------
    str
        ``"declared V"``, ``"declared V + cross term (eps 0.316)"`` or ``"quadratic"``.

    Examples
    --------
    >>> import sympy as sp
    >>> from fsmctl.proofs.certify_report import candidate_label
    >>> from fsmctl.proofs.certify_problem import Candidate
    >>> candidate_label(Candidate("declared + cross term", sp.Integer(0), epsilon=10 ** -0.5))
    'declared V + cross term (eps 0.316)'
    """
    if candidate.kind == "declared":
        return "declared V"
    if candidate.kind == "declared + cross term":
        return f"declared V + cross term (eps {candidate.epsilon:.3g})"
    return candidate.kind


class StageReporter:
    """Turns a certify run into :class:`CertifyStage` reports: one before each step, the search's progress passed on.

    The branch and bound of a candidate begins at its first ``progress`` call (the origin's argument and the
    boundary level come before it) and ends when the whole box is decided (the levels follow); a search that stops on
    its budget or on a counterexample goes on to the levels without a report.

    Parameters
    ----------
    stage : callable or None
        ``stage(CertifyStage)``.
    progress : callable or None
        ``progress(boxes, fraction_decided)``, passed on from :meth:`progress`.

    Examples
    --------
    >>> from fsmctl.proofs.certify_report import StageReporter
    >>> seen = []
    >>> r = StageReporter(lambda s: seen.append((s.title(), s.step)), None)
    >>> r.choosing(); r.candidate("quadratic", 1, 1); r.progress(10, 0.5); r.progress(20, 1.0)
    >>> seen[-3:]
    [('candidate 1/1: quadratic', "the origin's argument and the boundary level"), ('candidate 1/1: quadratic', 'branch and bound'), ('candidate 1/1: quadratic', 'the levels')]
    """

    def __init__(self, stage: Callable[[CertifyStage], None] | None, progress: Callable[[int, float], None] | None):
        self._stage, self._progress = stage, progress
        self._current = CertifyStage(CHOOSING)

    def _report(self, step: str) -> None:
        c = self._current
        self._current = CertifyStage(step, c.candidate, c.index, c.count)
        if self._stage is not None:
            self._stage(self._current)

    def choosing(self) -> None:
        """Report that the candidates are being chosen."""
        self._report(CHOOSING)

    def candidate(self, label: str, index: int, count: int) -> None:
        """Report a candidate's first step (its origin's argument and boundary level)."""
        self._current = CertifyStage(ORIGIN, label, index, count)
        if self._stage is not None:
            self._stage(self._current)

    def progress(self, boxes: int, fraction: float) -> None:
        """The search's ``progress`` callback (see the class docstring)."""
        if self._current.step == ORIGIN:
            self._report(SEARCH)
        if self._progress is not None:
            self._progress(boxes, fraction)
        if fraction >= 1.0 and self._current.step == SEARCH:
            self._report(LEVELS)


POINT_COLUMNS = (
    ("sigma_e", "sigma_e (MRP)"),
    ("omega_e", "omega_e (rad/s)"),
    ("z", "z (the law's states)"),
    ("theta", "theta (relative inertia)"),
    ("d", "d (N m)"),
    ("omega_d", "omega_d (rad/s)"),
    ("omega_d_dot", "omega_d_dot (rad/s^2)"),
)
"""the inputs of a counterexample's point (:attr:`fsmctl.proofs.certify_problem.CertifyProblem.names`, ``name[k]``)
and their columns in the Markdown report, units in the names"""


def counterexample_table(counterexample: dict) -> list[str]:
    """The Markdown section that shows a counterexample: ``V_dot`` and ``V`` there, and its point as a table (one
    column per input vector, units in the column names, one row per component ``k``; vectors that are 0 at the point
    are named below the table instead).

    Parameters
    ----------
    counterexample : dict
        ``outcome.counterexample`` of a certificate: ``point`` (by input name), ``V_dot``, ``V_dot_ball``, ``V``.

    Returns
    -------
    list of str
        Lines, ending with an empty one.

    Examples
    --------
    >>> from fsmctl.proofs.certify_report import counterexample_table
    >>> point = {"sigma_e[0]": 0.05, "sigma_e[1]": -0.05, "omega_e[0]": 0.01, "omega_e[1]": 0.0, "d[0]": 0.0}
    >>> print("\\n".join(counterexample_table({"point": point, "V_dot": 3e-4, "V_dot_ball": "[0.0003 +/- 1e-20]",
    ...                                        "V": 0.04})))
    ## Counterexample
    <BLANKLINE>
    V_dot = 0.0003 > 0 (ball arithmetic: [0.0003 +/- 1e-20]), V = 0.04 at this point of the region x uncertainty (`outcome.counterexample.point` in the JSON file holds it to the last bit):
    <BLANKLINE>
    | k | sigma_e (MRP) | omega_e (rad/s) |
    |---|---|---|
    | 0 | 0.05 | 0.01 |
    | 1 | -0.05 | 0 |
    <BLANKLINE>
    0 at the point: d.
    <BLANKLINE>
    """
    point = counterexample["point"]
    values: dict[str, list[float]] = {}
    for name, v in point.items():
        values.setdefault(name.split("[")[0], []).append(float(v))
    shown = [
        (k, title) for k, title in POINT_COLUMNS if k in values and (k in ("sigma_e", "omega_e") or any(values[k]))
    ]
    zero = [k for k, _ in POINT_COLUMNS if k in values and (k, dict(POINT_COLUMNS)[k]) not in shown]
    rows = max((len(values[k]) for k, _ in shown), default=0)
    text = [
        "## Counterexample",
        "",
        f"V_dot = {counterexample['V_dot']:.6g} > 0 (ball arithmetic: {counterexample['V_dot_ball']}), V = "
        f"{counterexample.get('V', math.nan):.6g} at this point of the region x uncertainty "
        "(`outcome.counterexample.point` in the JSON file holds it to the last bit):",
        "",
        "| k | " + " | ".join(title for _, title in shown) + " |",
        "|---" * (len(shown) + 1) + "|",
    ]
    for r in range(rows):
        cells = [f"{values[k][r]:.6g}" if r < len(values[k]) else "" for k, _ in shown]
        text.append(f"| {r} | " + " | ".join(cells) + " |")
    text.append("")
    if zero:
        text += [f"0 at the point: {', '.join(zero)}.", ""]
    return text
