"""The results of an explanation and their texts: :class:`Explanation`, its :class:`Evidence`, the report section.

:func:`fsmctl.studies.explain.explain` returns one :class:`Explanation` per claim and figure-level check; in
``fsmctl reproduce``'s report :func:`change_cell` is its cell of the summary table, :func:`evidence_items` its part
of the claim's evidence, :func:`method_blocks` the section "What would reproduce each claim" (with
:func:`summary_sentence`), and :func:`text_lines` its lines in the terminal summary.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field

from fsmctl.studies.claims import claim_ids
from fsmctl.studies.report_doc import Block, Bullets, Heading, Paragraph, Span, Text, code, link, strong
from fsmctl.studies.wording import count, join_words

__all__ = [
    "EXPLAINED",
    "NOT_EXPLAINED",
    "ALREADY_REPRODUCED",
    "METHOD_HEADING",
    "Evidence",
    "Explanation",
    "change_cell",
    "evidence_items",
    "summary_sentence",
    "method_blocks",
    "text_lines",
]

EXPLAINED = "reproduced if"
NOT_EXPLAINED = "no setting in the searched ranges reproduces it"
ALREADY_REPRODUCED = "already reproduced"


@dataclass
class Evidence:
    """The evidence run of an explanation: its scenario file and numbers.

    Parameters
    ----------
    key : str
        The candidate's key (``explain_torque_limit_47.7``).
    change : str
        The change, as ``setting = value``.
    scenario_file : str
        The scenario file, relative to the report folder (``explain/<key>.toml``).
    runs : list of str
        The runs of :func:`~fsmctl.studies.paper_runs.run_plan` flown on it.
    figures : list of str
        The Figs 1-4 checks of its Case 1 run (:data:`~fsmctl.studies.figure_checks.FIGURE_CHECKS`), one line each.
    figures_fit : list of str
        The ids of the Figs 1-4 checks its Case 1 run passes.
    rerun_identical : bool
        The file, re-loaded and simulated again, gives the same numbers.
    warnings : list of str, optional
        Warnings of the evidence runs.

    Examples
    --------
    >>> from fsmctl.studies import Evidence
    >>> ev = Evidence(key="explain_torque_limit_47.7", change="torque limit = 47.7 N m",
    ...               scenario_file="explain/explain_torque_limit_47.7.toml", runs=["case1"], figures=[],
    ...               figures_fit=[], rerun_identical=True)
    >>> ev.scenario_file.startswith("explain/"), ev.rerun_identical
    (True, True)
    """

    key: str
    """candidate key (``explain_torque_limit_47.7``)"""
    change: str
    scenario_file: str
    """the scenario file, relative to the report folder (``explain/<key>.toml``)"""
    runs: list[str]
    """the runs of :func:`~fsmctl.studies.paper_runs.run_plan` flown on it"""
    figures: list[str]
    """the Figs 1-4 checks of its Case 1 run (:data:`~fsmctl.studies.figure_checks.FIGURE_CHECKS`), one line each"""
    figures_fit: list[str]
    """the ids of the Figs 1-4 checks its Case 1 run passes"""
    rerun_identical: bool
    """the file, re-loaded and simulated again, gives the same numbers"""
    warnings: list[str] = field(default_factory=list)


@dataclass
class Explanation:
    """What would reproduce one claim (or figure-level check): the smallest change found, or none in the ranges.

    :func:`~fsmctl.studies.explain.explain` returns them (it flies the reproduction's runs again for every candidate change, minutes to hours:
    ``fsmctl reproduce --explain``); this shows how to read one.

    Parameters
    ----------
    id : str
        The claim's id (:func:`~fsmctl.studies.claims.claim_ids`) or the figure check's.
    claim : str
        What the paper claims.
    verdict : str
        ``fsmctl reproduce``'s verdict (figure checks: ``fits`` / ``does not fit``).
    status : str
        :data:`EXPLAINED`, :data:`NOT_EXPLAINED` or :data:`ALREADY_REPRODUCED`.
    reproduced_if : str
        The statement of the smallest change (``torque limit >= 47.7 N m (bisected to 0.1 N m; ...)``).
    change : str, optional
        The change, as ``setting = value`` (``and`` for a pair).
    distance : float, optional
        Its distance (:meth:`~fsmctl.studies.explain_settings.Setting.distance`; NaN: none found).
    baseline : str, optional
        The claim's numbers on the base scenario.
    numbers : str, optional
        The claim's numbers on the evidence run.
    outside : str, optional
        For a bisected threshold: the value just outside it and the numbers there (it fails).
    evidence : Evidence or None, optional
        The evidence run.
    alternatives : list of str, optional
        Other changes that also reproduce it, by distance.
    searched : list of str, optional
        What was searched.
    pairs : str, optional
        What was tried in pairs, when no single change reproduces it.

    Examples
    --------
    >>> from fsmctl.studies import Evidence, Explanation
    >>> from fsmctl.studies.explain_report import EXPLAINED
    >>> ev = Evidence("explain_torque_limit_47.7", "torque limit = 47.7 N m", "explain/explain_torque_limit_47.7.toml",
    ...               ["case1"], [], [], True)
    >>> e = Explanation(id="settling_27s", claim="the formation settles in 27 s", verdict="differs", status=EXPLAINED,
    ...                 reproduced_if="torque limit >= 47.7 N m", change="torque limit = 47.7 N m", distance=0.29,
    ...                 evidence=ev)
    >>> e.status, e.to_dict()["evidence"]["key"]
    ('reproduced if', 'explain_torque_limit_47.7')
    """

    id: str
    claim: str
    verdict: str
    """``fsmctl reproduce``'s verdict (figure checks: ``fits`` / ``does not fit``)"""
    status: str
    """:data:`EXPLAINED`, :data:`NOT_EXPLAINED` or :data:`ALREADY_REPRODUCED`"""
    reproduced_if: str
    change: str = ""
    """the change, as ``setting = value`` (``and`` for a pair)"""
    distance: float = math.nan
    baseline: str = ""
    """the claim's numbers on the base scenario"""
    numbers: str = ""
    """the claim's numbers on the evidence run"""
    outside: str = ""
    """for a bisected threshold: the value just outside it and the numbers there (it fails)"""
    evidence: Evidence | None = None
    alternatives: list[str] = field(default_factory=list)
    """other changes that also reproduce it, by distance"""
    searched: list[str] = field(default_factory=list)
    pairs: str = ""
    """what was tried in pairs, when no single change reproduces it"""

    def to_dict(self) -> dict:
        """JSON-ready (non-finite numbers as None).

        Returns
        -------
        dict
            The fields, the evidence as a nested dict.
        """
        d = asdict(self)
        d["distance"] = self.distance if math.isfinite(self.distance) else None
        return d


def _searched_text(e: Explanation) -> str:
    if e.status == NOT_EXPLAINED:
        return "; ".join([*e.searched, *([e.pairs] if e.pairs else [])])
    level = e.searched[-1] if e.searched else ""
    return f'the settings listed under "{METHOD_HEADING}", {level}' + (f"; {e.pairs}" if e.pairs else "")


def change_cell(e: Explanation | None) -> str:
    """The summary table's cell "reproduces with": the change found, in a few words.

    Parameters
    ----------
    e : Explanation or None
        The claim's explanation (None: not searched).

    Returns
    -------
    str
        ``"torque limit = 47.7 N m"``, ``"no change needed"``, ``"none found"`` or ``"not searched"``.

    Examples
    --------
    >>> e = Explanation("settling_27s", "settles in 27 s", "differs", EXPLAINED, "torque limit >= 47.7 N m",
    ...                 "torque limit = 47.7 N m", 0.29)
    >>> change_cell(e), change_cell(None)
    ('torque limit = 47.7 N m', 'not searched')
    """
    if e is None:
        return "not searched"
    return {ALREADY_REPRODUCED: "no change needed", NOT_EXPLAINED: "none found"}.get(e.status, e.change)


def evidence_items(e: Explanation) -> list[Text]:
    """What would reproduce one claim or figure check, one item per fact (the report's evidence of that claim).

    Parameters
    ----------
    e : Explanation
        From :func:`~fsmctl.studies.explain.explain`.

    Returns
    -------
    list of Text
        Running text (:mod:`fsmctl.studies.report_doc`): the change and its distance, the evidence run and its
        scenario file, the numbers before and after, the figures it fits, the other changes, what was searched.

    Examples
    --------
    >>> ev = Evidence("explain_torque_limit_47.7", "torque limit = 47.7 N m", "explain/explain_torque_limit_47.7.toml",
    ...               ["case1"], [], [], True)
    >>> e = Explanation("settling_27s", "the formation settles in 27 s", "differs", EXPLAINED,
    ...                 "torque limit >= 47.7 N m", "torque limit = 47.7 N m", 0.29, evidence=ev)
    >>> from fsmctl.studies.report_doc import plain
    >>> [plain(item) for item in evidence_items(e)][:2]
    ['Reproduced if torque limit >= 47.7 N m (distance 0.29)', 'Evidence run: explain_torque_limit_47.7 (explain/explain_torque_limit_47.7.toml; runs case1; re-run from the file: identical)']
    """
    if e.status == ALREADY_REPRODUCED:
        return [("What would reproduce it: no change needed (", e.baseline, ")")]
    if e.status == NOT_EXPLAINED:
        return [("What would reproduce it: ", strong(NOT_EXPLAINED)), (f"Searched: {_searched_text(e)}",)]
    ev = e.evidence
    run: list[str | Span] = ["Evidence run: ", code(ev.key), " (", link(ev.scenario_file, ev.scenario_file)]
    run.append(f"; runs {', '.join(ev.runs)}; ")
    run.append("re-run from the file: identical)" if ev.rerun_identical else strong("re-run from the file differs"))
    if not ev.rerun_identical:
        run.append(")")
    if ev.warnings:
        run.append(" warnings: " + "; ".join(ev.warnings))
    fits = join_words([k.split("_")[0].replace("fig", "Fig ") for k in ev.figures_fit]) if ev.figures_fit else "none"
    items: list[Text] = [
        (strong(f"Reproduced if {e.reproduced_if}"), f" (distance {e.distance:.2f})"),
        tuple(run),
        ("Default → evidence: ", e.baseline, " → ", strong(e.numbers)),
    ]
    if e.outside:
        items.append((f"Just outside the threshold: {e.outside}",))
    items.append((f"Figs 1-4 with the evidence: fits {fits}. " + "; ".join(ev.figures),))
    if e.alternatives:
        items.append(("Other changes that reproduce it: " + "; ".join(e.alternatives),))
    items.append((f"Searched: {_searched_text(e)}",))
    return items


def summary_sentence(explanations: Sequence[Explanation]) -> str:
    """What the changes found reproduce, in one or two sentences (empty when every claim reproduces).

    Parameters
    ----------
    explanations : sequence of Explanation
        From :func:`~fsmctl.studies.explain.explain` (the claims are read; the figure checks are not).

    Returns
    -------
    str
        For example ``"Each of the 2 claims that did not reproduce would reproduce with one change: torque limit =
        47.7 N m (settling_27s, saturation_at_start). None of these changes keeps the applied torques within the ±2 N m
        that Fig 4 prints."``

    Examples
    --------
    >>> e = Explanation("settling_27s", "settles in 27 s", "differs", EXPLAINED, "torque limit >= 47.7 N m",
    ...                 "torque limit = 47.7 N m", 0.29, evidence=Evidence("k", "", "f", [], [], [], True))
    >>> summary_sentence([e])
    'The one claim that did not reproduce would reproduce with this change: torque limit = 47.7 N m (settling_27s). It does not keep the applied torques within the ±2 N m that Fig 4 prints.'
    """
    ids = claim_ids()
    todo = [e for e in explanations if e.id in ids and e.status != ALREADY_REPRODUCED]
    done = [e for e in todo if e.status == EXPLAINED]
    if not todo:
        return ""
    if not done:
        if len(todo) == 1:
            return "The one claim that did not reproduce would not reproduce with any change in the searched ranges."
        return (
            f"None of the {len(todo)} claims that did not reproduce would reproduce with a change in the searched "
            "ranges."
        )
    changes: dict[str, list[str]] = {}
    for e in done:
        changes.setdefault(e.change, []).append(e.id)
    listed = "; ".join(f"{change} ({', '.join(cids)})" for change, cids in changes.items())
    if len(done) == len(todo):
        lead = "The one claim" if len(todo) == 1 else f"Each of the {len(todo)} claims"
    else:
        lead = f"{len(done)} of the {count(len(todo), 'claim')}"
        others = len(todo) - len(done)
        listed += f"; for the other {'one' if others == 1 else others}, {NOT_EXPLAINED}"
    verb = "this change" if len(done) == 1 else "one change"
    return f"{lead} that did not reproduce would reproduce with {verb}: {listed}. {_fig4_sentence(done)}"


def _fig4_sentence(done: Sequence[Explanation]) -> str:
    keep = [e.id for e in done if "fig4_axis" in e.evidence.figures_fit]
    where = "the applied torques within the ±2 N m that Fig 4 prints."
    if len(done) == 1:
        return f"It {'keeps' if keep else 'does not keep'} {where}"
    if not keep:
        return f"None of these changes keeps {where}"
    if len(keep) == len(done):
        return f"All of them keep {where}"
    return f"Only the change for {join_words(keep)} {'keeps' if len(keep) == 1 else 'keep'} {where}"


_NOT_RANGES = ("best-first", "only with")

METHOD_HEADING = "What would reproduce each claim"
"""The report section that states how the changes were searched (:func:`method_blocks`)."""


def method_blocks(explanations: Sequence[Explanation], fast: bool = False) -> list[Block]:
    """The report section "What would reproduce each claim": the summary, how the changes were searched, the ranges.

    Parameters
    ----------
    explanations : sequence of Explanation
        From :func:`~fsmctl.studies.explain.explain`.
    fast : bool
        Whether the runs had the short horizon of ``--fast``.

    Returns
    -------
    list of Block
        Blocks of :mod:`fsmctl.studies.report_doc`.

    Examples
    --------
    >>> from fsmctl.studies.report_doc import Document, render_markdown
    >>> text = render_markdown(Document("R", method_blocks([])))
    >>> text.splitlines()[2]
    '## What would reproduce each claim'
    >>> "shared/" in text
    False
    """
    L: list[Block] = [Heading(2, METHOD_HEADING)]
    sentence = summary_sentence(explanations)
    if sentence:
        L.append(Paragraph((sentence,)))
    L += [
        Paragraph(
            (
                "For each claim that does not reproduce, the smallest change of one setting the paper leaves open (or "
                "may have misprinted) that makes the claim's own test pass (",
                code("fsmctl.studies.explain"),
                "). The default scenario is not changed: every explanation is a separate run, written as a scenario "
                "file (",
                code("extends"),
                " the paper's scenario with just the change) that ",
                code("fsmctl simulate --scenario FILE --case 1"),
                " flies; ",
                code("fsmctl reproduce"),
                " re-loads each file and checks that it gives the numbers shown.",
                *(
                    [" ", strong("Fast mode: short horizon; these are not the explanations of the paper's 100 s runs.")]
                    if fast
                    else []
                ),
            )
        ),
        Paragraph(
            (
                strong("Distance"),
                " of a change: for a continuous setting, the fraction of the searched range moved from the scenario's "
                "value towards the end of the range (on a log scale for the torque limit, delta, phi and the "
                "tolerance, linear for alpha), in (0, 1]; a discrete choice (error kinematics, error MRP, integrator / "
                "step) counts 1; a pair adds its two distances. ",
                strong("Search"),
                ": grid values in order of distance until no untried value can be nearer than the change found; the "
                "bracket around a reproducing grid value is bisected to the setting's resolution; then the grid values "
                "beyond it are tried (whether the claim keeps holding). Pairs (one modelling choice held) only when no "
                "single change reproduces a claim, within a run budget.",
            )
        ),
    ]
    ranges = [r for r in dict.fromkeys(r for e in explanations for r in e.searched) if not r.startswith(_NOT_RANGES)]
    if ranges:
        L += [Paragraph(("Searched settings and ranges:",)), Bullets([(r,) for r in ranges])]
    L.append(
        Paragraph(
            (
                "Figure-level checks compare with the printed Figs 1-9 of Liang, Sun & Wang (2012), whose axis ranges "
                "and insets are recorded in ",
                code("fsmctl.studies.figure_checks.FIGURE_CHECKS"),
                ": an autoscaled axis ends at the first tick above the data, so the peak lies in the top tick "
                "interval; θ is the principal angle of the error MRP the law uses (with the unswitched error MRP, ",
                code("4 atan|σ_i ⊗ σ_d^-1|"),
                " up to 360°); the insets span the whole 100 s, so their ranges are set by hand and only bound the "
                "final errors.",
            )
        )
    )
    return L


def text_lines(e: Explanation, indent: int, width: int = 110) -> list[str]:
    """Plain-text lines of one explanation for the terminal summary.

    Parameters
    ----------
    e : Explanation
        From :func:`~fsmctl.studies.explain.explain`.
    indent : int
        Left margin.
    width : int
        Wrap width.

    Returns
    -------
    list of str
        ``reproduced if ...`` with the evidence file, or the searched ranges.

    Examples
    --------
    >>> from fsmctl.studies import Evidence, Explanation
    >>> from fsmctl.studies.explain_report import text_lines
    >>> ev = Evidence("explain_torque_limit_47.7", "torque limit = 47.7 N m", "explain/explain_torque_limit_47.7.toml",
    ...               ["case1"], [], [], True)
    >>> e = Explanation("settling_27s", "the formation settles in 27 s", "differs", "reproduced if",
    ...                 "torque limit >= 47.7 N m", "torque limit = 47.7 N m", 0.29, evidence=ev)
    >>> text_lines(e, indent=2)
    ['  explain: reproduced if torque limit >= 47.7 N m:  [explain/explain_torque_limit_47.7.toml]']
    """
    if e.status == ALREADY_REPRODUCED:
        return []
    if e.status == EXPLAINED:
        text = f"{EXPLAINED} {e.reproduced_if}: {e.numbers} [{e.evidence.scenario_file}]"
    else:
        ranges = [s.split(" (")[0] for s in e.searched if not s.startswith("best-first")]
        text = f"{NOT_EXPLAINED} ({'; '.join(ranges)}; ranges in the report)"
    return textwrap.wrap(f"explain: {text}", width, initial_indent=" " * indent, subsequent_indent=" " * (indent + 2))
