"""The results of an explanation and their texts: :class:`Explanation`, its :class:`Evidence`, the report section.

:func:`fsmctl.studies.explain.explain` returns one :class:`Explanation` per claim and figure-level check;
:func:`markdown_section` is the section "What would reproduce each claim" of ``fsmctl reproduce``'s report and
:func:`text_lines` its lines in the terminal summary.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field

from fsmctl.studies.claims import claim_ids

__all__ = [
    "EXPLAINED",
    "NOT_EXPLAINED",
    "ALREADY_REPRODUCED",
    "Evidence",
    "Explanation",
    "markdown_section",
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


def _md(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def _searched_cell(e: Explanation) -> str:
    if e.status == NOT_EXPLAINED:
        return "; ".join([*e.searched, *([e.pairs] if e.pairs else [])])
    level = e.searched[-1] if e.searched else ""
    return f"the settings listed below, {level}" + (f"; {e.pairs}" if e.pairs else "")


def _row(e: Explanation) -> str:
    if e.status == ALREADY_REPRODUCED:
        row = [f"**{e.id}**: {e.claim}", e.verdict, "no change needed", "-", "-", e.baseline, "-", "-", "-"]
    elif e.status == NOT_EXPLAINED:
        row = [f"**{e.id}**: {e.claim}", e.verdict, f"**{NOT_EXPLAINED}**", "-", "-", e.baseline, "-", "-"]
        row.append(_searched_cell(e))
    else:
        ev = e.evidence
        run = f"`{ev.key}` ([{ev.scenario_file}]({ev.scenario_file}); runs {', '.join(ev.runs)}"
        run += "; re-run from the file: identical)" if ev.rerun_identical else "; **re-run from the file differs**)"
        if ev.warnings:
            run += " warnings: " + "; ".join(ev.warnings)
        numbers = f"{e.baseline} → **{e.numbers}**" + (f" ({e.outside})" if e.outside else "")
        fits = ", ".join(k.split("_")[0].replace("fig", "Fig ") for k in ev.figures_fit) or "none"
        row = [
            f"**{e.id}**: {e.claim}",
            e.verdict,
            f"**{EXPLAINED} {e.reproduced_if}**",
            f"{e.distance:.2f}",
            run,
            numbers,
            f"fits {fits} of Figs 1-4: " + "; ".join(ev.figures),
            "; ".join(e.alternatives) or "-",
            _searched_cell(e),
        ]
    return "| " + " | ".join(_md(x) for x in row) + " |"


def markdown_section(explanations: Sequence[Explanation], fast: bool = False) -> list[str]:
    """The report section "What would reproduce each claim" (Markdown lines).

    Parameters
    ----------
    explanations : sequence of Explanation
        From :func:`~fsmctl.studies.explain.explain`.
    fast : bool
        Whether the runs had the short horizon of ``--fast``.

    Returns
    -------
    list of str
        The section: the claims in the paper's order, then the figure-level checks, then the searched ranges.

    Examples
    --------
    >>> from fsmctl.studies import Evidence, Explanation, markdown_section
    >>> ev = Evidence("explain_torque_limit_47.7", "torque limit = 47.7 N m", "explain/explain_torque_limit_47.7.toml",
    ...               ["case1"], [], [], True)
    >>> e = Explanation("settling_27s", "the formation settles in 27 s", "differs", "reproduced if",
    ...                 "torque limit >= 47.7 N m", "torque limit = 47.7 N m", 0.29, evidence=ev)
    >>> lines = markdown_section([e])
    >>> lines[0]
    '## What would reproduce each claim'
    >>> row = [line for line in lines if line.startswith("| **settling_27s**")][0]
    >>> [cell.strip() for cell in row.split("|")[2:5]]
    ['differs', '**reproduced if torque limit >= 47.7 N m**', '0.29']
    """
    ids = claim_ids()
    claims = [e for e in explanations if e.id in ids]
    figs = [e for e in explanations if e.id not in ids]
    L = [
        "## What would reproduce each claim",
        "",
        "For each claim that does not reproduce, the smallest change of one setting the paper leaves open (or may "
        "have misprinted) that makes the claim's own test pass (`fsmctl.studies.explain`). The default scenario is "
        "not changed: every explanation is a separate run, written as a scenario file (`extends` the paper's "
        "scenario with just the change) that `fsmctl simulate --scenario FILE --case 1` flies; `fsmctl reproduce` "
        "re-loads each file and checks that it gives the numbers below.",
        "",
        "*Distance* of a change: for a continuous setting, the fraction of the searched range moved from the "
        "scenario's value towards the end of the range (on a log scale for the torque limit, delta, phi and the "
        "tolerance, linear for alpha), in (0, 1]; a discrete choice (error kinematics, error MRP, integrator / step) "
        "counts 1; a pair adds its two distances. *Search*: grid values in order of distance until no untried value "
        "can be nearer than the change found; the bracket around a reproducing grid value is bisected to the "
        "setting's resolution; then the grid values beyond it are tried (whether the claim keeps holding). Pairs (one "
        "modelling choice held) only when no single change reproduces a claim, within a run budget."
        + (" **Fast mode: short horizon; these are not the explanations of the paper's 100 s runs.**" if fast else ""),
        "",
    ]
    todo = [e for e in claims if e.status != ALREADY_REPRODUCED]
    done = [e for e in todo if e.status == EXPLAINED]
    if todo:
        kinds: dict[str, list[str]] = {}
        for e in done:
            kinds.setdefault(e.change, []).append(e.id)
        fig4 = [e.id for e in done if "fig4_axis" in e.evidence.figures_fit]
        L += [
            f"In short: {len(done)} of the {len(todo)} claims not reproduced are reproduced by the changes below ("
            + "; ".join(f"{change}: {', '.join(ids)}" for change, ids in kinds.items())
            + f"); the evidence runs of {', '.join(fig4) if fig4 else 'none of them'} keep the applied torques within "
            "the ±2 N m that Fig 4 prints.",
            "",
        ]
    header = [
        "| {what} | verdict | reproduced if (smallest change) | distance | evidence run | default → evidence "
        "(just outside the threshold) | Figs 1-4 with the evidence | other changes that reproduce it | searched |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    L += [header[0].format(what="claim"), header[1], *(_row(e) for e in claims)]
    if figs:
        L += [
            "",
            "### Figure-level evidence",
            "",
            "What the printed Figs 1-9 show (axis ranges, the saturation level, the insets), checked like the claims: "
            "which change makes the printed figure possible.",
            "",
            header[0].format(what="figure check"),
            header[1],
            *(_row(e) for e in figs),
        ]
    ranges = list(dict.fromkeys(r for e in explanations for r in e.searched))
    if ranges:
        L += ["", "Searched settings and ranges:", ""]
        L += [f"- {r}" for r in ranges if not r.startswith(("best-first", "only with"))]
    L += [
        "",
        "Figure-level checks read the printed figures (`../shared/seed`): an autoscaled axis ends at the first tick "
        "above the data, so the peak lies in the top tick interval; θ is the principal angle of the error MRP the law "
        "uses (with the unswitched error MRP, `4 atan|σ_i ⊗ σ_d^-1|` up to 360°); the insets span the whole 100 s, so "
        "their ranges are set by hand and only bound the final errors.",
        "",
    ]
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
