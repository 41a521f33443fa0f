"""What ``fsmctl certify`` reports while it runs and in its Markdown file, beyond the certificate's own lines.

:class:`CertifyStage` is what :func:`fsmctl.proofs.certificate.certify_law` passes to its ``stage`` callback when the
work moves on (:data:`STEPS`; each candidate named by :func:`candidate_label`), so that a caller can label a progress
bar per candidate and show the steps that have no progress of their own (the boundary level, the sum of squares,
the origin's argument, the levels); :class:`StageReporter` passes them on with the search's progress.
:func:`counterexample_table` is the Markdown section that shows a counterexample's point.  The rest are the pieces
of a certificate's report lines (:class:`fsmctl.proofs.certificate.Certificate`): every printed bound, level, rate and
time rounded outward (:func:`bound_up`, :func:`bound_down`; :func:`fsmctl.proofs.rounding.round_outward`), the
ultimate bound and extents as boxes, the origin's argument and the search in words.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from fsmctl.proofs.certify_problem import Candidate
from fsmctl.proofs.rounding import round_outward

__all__ = [
    "BOUND_DIGITS",
    "LEVEL_DIGITS",
    "TABLE_LEVEL_DIGITS",
    "annulus_text",
    "bound_down",
    "bound_up",
    "box_text",
    "core_fractions",
    "core_line",
    "extent_maxima",
    "search_line",
    "table_cell",
    "ultimate_text",
    "upper_sum_text",
    "BOUNDARY",
    "CHOOSING",
    "LEVELS",
    "ORIGIN",
    "POINT_COLUMNS",
    "SEARCH",
    "SOS",
    "STEPS",
    "CertifyStage",
    "StageReporter",
    "candidate_label",
    "counterexample_table",
]

CHOOSING = "choosing the candidates"
BOUNDARY = "the boundary level"
SOS = "sum of squares"
ORIGIN = "the origin's argument"
SEARCH = "branch and bound"
LEVELS = "the levels"
STEPS = (CHOOSING, BOUNDARY, SOS, ORIGIN, SEARCH, LEVELS)
"""the steps :func:`fsmctl.proofs.certificate.certify_law` reports to its ``stage`` callback, in order (all but the
first once per candidate, as :func:`fsmctl.proofs.certify.certify_candidate` reaches them; the sum-of-squares step
only for an ultimately bounded question, the later ones only when it does not certify)"""


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

    Parameters
    ----------
    stage : callable or None
        ``stage(CertifyStage)``.
    progress : callable or None
        ``progress(boxes, fraction_decided)``, passed on from :meth:`progress`.

    Examples
    --------
    >>> from fsmctl.proofs.certify_report import BOUNDARY, SEARCH, StageReporter
    >>> seen = []
    >>> r = StageReporter(lambda s: seen.append((s.title(), s.step)), None)
    >>> r.choosing(); r.candidate("quadratic", 1, 1); r.step(BOUNDARY); r.step(SEARCH)
    >>> seen[-2:]
    [('candidate 1/1: quadratic', 'the boundary level'), ('candidate 1/1: quadratic', 'branch and bound')]
    """

    def __init__(self, stage: Callable[[CertifyStage], None] | None, progress: Callable[[int, float], None] | None):
        self._stage, self._progress = stage, progress
        self._current = CertifyStage(CHOOSING)

    def step(self, step: str) -> None:
        """Report that the current candidate (or the run) has reached ``step`` (one of :data:`STEPS`)."""
        if step not in STEPS:
            raise ValueError(f"step must be one of {STEPS}, got {step!r}")
        c = self._current
        self._current = CertifyStage(step, c.candidate, c.index, c.count)
        if self._stage is not None:
            self._stage(self._current)

    def choosing(self) -> None:
        """Report that the candidates are being chosen."""
        self.step(CHOOSING)

    def candidate(self, label: str, index: int, count: int) -> None:
        """Make ``label`` the current candidate (its steps follow through :meth:`step`)."""
        self._current = CertifyStage(CHOOSING, label, index, count)

    def progress(self, boxes: int, fraction: float) -> None:
        """The search's ``progress`` callback, passed on."""
        if self._progress is not None:
            self._progress(boxes, fraction)


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


BOUND_DIGITS = 4
"""significant digits of the bounds, rates, times and shares in a certificate's report, each rounded outward (an
upper bound up, a lower bound down: :func:`fsmctl.proofs.rounding.round_outward`); the JSON keeps full
precision"""
LEVEL_DIGITS = 6
"""significant digits of the levels ``c`` and ``c_in`` of ``V`` in a certificate's report lines, rounded outward"""
TABLE_LEVEL_DIGITS = 9
"""significant digits of the levels in the table of a certificate's Markdown report, rounded outward"""


def core_fractions(core: dict) -> str:
    """The core box's size: one fraction of the region, or one per state input."""
    f = core.get("fractions") or [core["fraction"]]
    return f"{f[0]:g}" if len(set(f)) == 1 else "(" + ", ".join(f"{v:g}" for v in f) + ")"


def bound_up(x: float, digits: int = BOUND_DIGITS) -> str:
    """An upper bound as printed: rounded up (:func:`fsmctl.proofs.rounding.round_outward`)."""
    return round_outward(float(x), "up", digits)


def bound_down(x: float, digits: int = BOUND_DIGITS) -> str:
    """A lower bound as printed: rounded down."""
    return round_outward(float(x), "down", digits)


def annulus_text(c_in: float, c: float) -> str:
    """``{c_in <= V <= c}`` rounded inward (a statement on it holds on the printed, smaller set)."""
    return f"{{{bound_up(c_in, LEVEL_DIGITS)} <= V <= {bound_down(c, LEVEL_DIGITS)}}}"


def ultimate_text(o: dict, attitude: bool = True) -> str:
    """The ultimate bound of an outcome: the box that contains the inner set ``{V <= c_in}``, rounded up."""
    return box_text(o.get("ultimate_bound") or {}, "sigma_e_max", "omega_e_max_rad_s", attitude=attitude)


def extent_maxima(extent: dict) -> dict:
    """The largest ``|sigma_e,k|`` and ``|omega_e,k|`` of a :func:`fsmctl.proofs.certify.sublevel_extent` dict."""
    return {
        "sigma": max(v for k, v in extent.items() if k.startswith("sigma_e")),
        "omega": max(v for k, v in extent.items() if k.startswith("omega_e")),
    }


def box_text(bounds: dict, sigma: str = "sigma", omega: str = "omega", attitude: bool = False) -> str:
    """``|sigma_e,k| <= s, |omega_e,k| <= w rad/s`` (with the attitude error in degrees), each bound rounded up."""
    deg = f" (attitude error <= {bound_up(bounds.get('attitude_error_max_deg', math.nan), 3)} deg)" if attitude else ""
    return (
        f"|sigma_e,k| <= {bound_up(bounds.get(sigma, math.nan))}{deg}, "
        f"|omega_e,k| <= {bound_up(bounds.get(omega, math.nan))} rad/s"
    )


def upper_sum_text(terms: list[tuple[float, str]]) -> str:
    """``a0 + a1 m1 - a2 m2``: an upper bound written out, each coefficient rounded up, its zero terms dropped."""
    out = ""
    for a, monomial in terms:
        if a == 0:
            continue
        text = bound_up(a)
        sign, size = ("-", text[1:]) if text.startswith("-") else ("+", text)
        term = f"{size} {monomial}".rstrip()
        out = f"{out} {sign} {term}" if out else ("-" if sign == "-" else "") + term
    return out or "0"


def core_line(core: dict) -> str:
    """The bound of ``V_dot`` on the core (the origin's argument), ``y`` the state scaled to the region."""
    terms = [(core.get("w0", 0.0), ""), (core.get("G", 0.0), "|y|"), (-core["mu"], "|y|^2")]
    text = f"on the core V_dot <= {upper_sum_text(terms)}, y = (sigma_e, omega_e) divided by the region's half-widths"
    if not core.get("r_star"):
        return text
    return (
        f"{text}: V_dot < 0 outside |y| <= {bound_up(core['r_star'])}, and on each box of the core where "
        f"V_dot(c) + grad V_dot(c).(y - c) - mu |y - c|^2 < 0 about its centre c (mu = {bound_down(core['mu'])})"
    )


def search_line(o: dict) -> str:
    """What the branch and bound covered, as shares of the region x uncertainty (a share proved rounded down)."""
    v, boxes = o.get("volume") or {}, o.get("boxes", 0)

    def pct(key: str, direction: str) -> str:
        return round_outward(100 * v.get(key, 0.0), direction, BOUND_DIGITS) + " %"

    return (
        f"branch and bound: {boxes} box{'' if boxes == 1 else 'es'} in {o.get('seconds', 0):.1f} s; of the region x "
        f"uncertainty, V_dot < 0 proved box by box on {pct('proved', 'down')}, covered by the origin's argument or "
        f"the inner set {pct('excluded', 'down')}, undecided {pct('undecided', 'up')}, V_dot > 0 on "
        f"{pct('positive', 'down')}"
    )


def table_cell(text: str) -> str:
    """A Markdown table cell: its ``|`` escaped (``|sigma_e,k|`` would split the row)."""
    return text.replace("|", r"\|")
