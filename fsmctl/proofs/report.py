"""Output of ``fsmctl prove``: a text table, JSON, and a Markdown report with LaTeX.

Liang, Sun & Wang (2012), Section 3: one row per claim (id, equations, verdict, seconds),
the detail of each claim indented below it; after a full check, one row per erratum of the printed paper
(:func:`fsmctl.proofs.errata.all_errata`: id, equations, whether it was confirmed, the claim that examines it).
"""

from __future__ import annotations

import json
import textwrap
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from fsmctl.model.scenario import Scenario
from fsmctl.proofs.claims import CLAIMS, ClaimResult
from fsmctl.proofs.theorem2_report import PREFORMATTED

if TYPE_CHECKING:
    from fsmctl.proofs.errata import Erratum

__all__ = [
    "outcome",
    "errata_summary_line",
    "format_errata",
    "format_list",
    "format_table",
    "summary_line",
    "to_json",
    "to_markdown",
    "write_report",
]


def format_list() -> str:
    """The claim ids, their equations and titles (``fsmctl prove --list``).

    Returns
    -------
    str
        One line per claim of Liang et al. 2012, Section 3 (eqs 10-41, Remarks 4 and 6); ``*`` marks
        the claims that depend on the scenario.
    """
    w = max(len(c.id) for c in CLAIMS)
    e = max(len(c.equations) for c in CLAIMS)
    rows = [f"{'id':{w}}  {'equations':{e}}  title (* uses the scenario)"]
    rows += [f"{c.id:{w}}  {c.equations:{e}}  {c.title}{' *' if c.uses_scenario else ''}" for c in CLAIMS]
    rows.append("without CLAIM_ID, every erratum of the printed paper is checked and reported too")
    return "\n".join(rows)


def _claims_of(results: Sequence[ClaimResult]) -> dict[str, str]:
    """Erratum id -> the id of the claim that examines it (the claim's ``data["erratum"]``)."""
    return {r.data["erratum"]: r.id for r in results if "erratum" in r.data}


def errata_summary_line(errata: Sequence[Erratum]) -> str:
    """One line counting the errata of the printed paper that were confirmed.

    Parameters
    ----------
    errata : sequence of Erratum
        The checked errata of Liang et al. 2012 (:func:`fsmctl.proofs.errata.all_errata`).

    Returns
    -------
    str
        ``N errata of the printed paper: c confirmed ...``, naming those that could not be confirmed.

    Examples
    --------
    >>> from fsmctl.proofs.seed_audit import erratum_skew_sign
    >>> errata_summary_line([erratum_skew_sign()])
    '1 erratum of the printed paper: 1 confirmed (printed form refuted, correction checked)'
    """
    bad = [e.id for e in errata if not e.checked]
    noun = "erratum" if len(errata) == 1 else "errata"
    line = f"{len(errata)} {noun} of the printed paper: {len(errata) - len(bad)} confirmed"
    if bad:
        return f"{line}; UNCHECKED (the printed form not refuted or the correction not checked): {', '.join(bad)}"
    return f"{line} (printed form refuted, correction checked)"


def format_errata(errata: Sequence[Erratum], results: Sequence[ClaimResult] = (), *, width: int = 120) -> str:
    """Plain-text table of the errata of the printed paper: id, equations, status, the claim that examines it.

    Parameters
    ----------
    errata : sequence of Erratum
        The checked errata of Liang et al. 2012 (:func:`fsmctl.proofs.errata.all_errata`).
    results : sequence of ClaimResult
        The checked claims: an erratum that one of them examines names it (else ``-``: the erratum's own
        check is the only one, as for those found by the re-audit of the printed text).
    width : int
        Column at which the printed and corrected statements are wrapped.

    Returns
    -------
    str
        A heading, one row per erratum (``confirmed`` or ``UNCHECKED``) with the statement as printed and the
        correct one indented below it, and :func:`errata_summary_line`.

    Examples
    --------
    The sign error in the skew matrix of eq 6, found by the re-audit of the printed text (no claim examines it):

    >>> from fsmctl.proofs.seed_audit import erratum_skew_sign
    >>> print(format_errata([erratum_skew_sign()]))
    errata of the printed paper (fsmctl.proofs.errata.all_errata): each printed form refuted, its correction checked
    erratum        eqs  status     claim
    ---...
    eq6-skew-sign  6    confirmed  -
        as printed: v^x = [[0, -(v)_3, (v)_2], [(v)_3, 0, -(v)_1], [-(v)_2, -(v)_1, 0]]
        correct: v^x = [[0, -(v)_3, (v)_2], [(v)_3, 0, -(v)_1], [-(v)_2, (v)_1, 0]] (fsmctl.symbolic.mrp.skew)
    1 erratum of the printed paper: 1 confirmed (printed form refuted, correction checked)
    """
    claims = _claims_of(results)
    w = max([len(e.id) for e in errata] + [7])
    q = max([len(e.equation) for e in errata] + [3])
    lines = [
        "errata of the printed paper (fsmctl.proofs.errata.all_errata): each printed form refuted, its correction "
        "checked",
        f"{'erratum':{w}}  {'eqs':{q}}  status     claim",
        "-" * min(width, w + q + 40),
    ]
    for e in errata:
        status = "confirmed" if e.checked else "UNCHECKED"
        lines.append(f"{e.id:{w}}  {e.equation:{q}}  {status:9}  {claims.get(e.id, '-')}")
        for label, text in (("as printed", e.as_printed), ("correct", e.correct)):
            lines.extend(
                textwrap.wrap(f"{label}: {text}", width=width, initial_indent="    ", subsequent_indent="      ")
            )
    lines.append(errata_summary_line(errata))
    return "\n".join(lines)


def summary_line(results: Sequence[ClaimResult]) -> str:
    """One line counting the verdicts.

    Parameters
    ----------
    results : sequence of ClaimResult
        Checked claims (Liang et al. 2012, Section 3).

    Returns
    -------
    str
        ``N claims: a proved, b erratum, ... (t s of checks); ...`` naming the claims that differ from the
        documented finding (:attr:`fsmctl.proofs.claims.Claim.expected`) and the documented failures.
    """
    counts: dict[str, int] = {}
    for r in results:
        counts[r.verdict] = counts.get(r.verdict, 0) + 1
    parts = ", ".join(f"{n} {v}" for v, n in counts.items())
    total = sum(r.seconds for r in results)
    bad = [r.id for r in results if not r.as_documented]
    known = [r.id for r in results if r.as_documented and not r.holds]
    tail = f"; differ from the documented finding: {', '.join(bad)}" if bad else "; every claim as documented"
    tail += f"; known failures (documented): {', '.join(known)}" if known else ""
    noun = "claim" if len(results) == 1 else "claims"
    return f"{len(results)} {noun}: {parts} ({total:.1f} s of checks){tail}"


def outcome(results: Sequence[ClaimResult], errata: Sequence[Erratum] | None = None) -> dict:
    """Whether the checks came out as documented, and the one line that says so (``fsmctl prove``'s first line).

    A claim is as documented when its verdict is the registry's (:attr:`fsmctl.proofs.claims.Claim.expected`; a
    claim without a documented finding when it holds); an erratum when it is confirmed.

    Parameters
    ----------
    results : sequence of ClaimResult
        Checked claims.
    errata : sequence of Erratum, optional
        The checked errata of the printed paper.

    Returns
    -------
    dict
        ``checks`` (claims + errata), ``as_documented`` (bool), ``differ`` (ids of the checks that differ from the
        documented finding), ``known_failures`` (documented failures, found again), ``failing`` (every check that
        fails or is not confirmed: ``--strict``), ``line``.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.proofs import ProofContext, run_claims
    >>> results = run_claims(["lemma2-sqrt-sum", "theorem2-delta"], ProofContext(fsmctl.paper_scenario()), workers=1)
    >>> o = outcome(results)
    >>> o["as_documented"], o["failing"], o["line"]
    (True, ['theorem2-delta'], 'all 2 checks as documented (1 known failure of the paper: theorem2-delta)')
    """
    errata = list(errata or ())
    unconfirmed = [e.id for e in errata if not e.checked]
    differ = [r.id for r in results if not r.as_documented] + unconfirmed
    known = [r.id for r in results if r.as_documented and not r.holds]
    n = len(results) + len(errata)
    if differ:
        shown = [f"{r.id} ({r.verdict}; documented: {r.documented or 'holds'})" for r in results if r.id in differ]
        shown += [f"{e} (erratum not confirmed)" for e in unconfirmed]
        line = f"{len(differ)} of {n} checks differ from the documented finding: {', '.join(shown)}"
    else:
        noun = "failure" if len(known) == 1 else "failures"
        line = (
            ("all " if n > 1 else "")
            + f"{n} check{'s' if n != 1 else ''} as documented"
            + (f" ({len(known)} known {noun} of the paper: {', '.join(known)})" if known else "")
        )
    return {
        "checks": n,
        "as_documented": not differ,
        "differ": differ,
        "known_failures": known,
        "failing": [r.id for r in results if not r.holds] + unconfirmed,
        "line": line,
    }


def format_table(
    results: Sequence[ClaimResult],
    scenario: Scenario | None = None,
    *,
    errata: Sequence[Erratum] | None = None,
    width: int = 120,
) -> str:
    """Plain-text table: one line per claim (id, equations of Liang et al. 2012, verdict, seconds), then its detail.

    Parameters
    ----------
    results : sequence of ClaimResult
        Checked claims.
    scenario : Scenario, optional
        Named in the heading.
    errata : sequence of Erratum, optional
        The checked errata of the printed paper (:func:`fsmctl.proofs.errata.all_errata`), shown after the
        claims (:func:`format_errata`).
    width : int
        Column at which the detail is wrapped.

    Returns
    -------
    str
        The table, ending with :func:`summary_line` (and :func:`errata_summary_line` when ``errata`` is given).

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.proofs import ProofContext, run_claims
    >>> results = run_claims(["lemma2-sqrt-sum", "theorem1-gains"], ProofContext(fsmctl.paper_scenario()))
    >>> table = format_table(results)
    >>> for line in table.splitlines():
    ...     if not line.startswith(" "):  # the detail lines are indented
    ...         print(line)
    claim            eqs               verdict  seconds  title
    ---...
    lemma2-sqrt-sum  11-12             proved   ...  Lemma 2: sum V_i^(1/2) >= (sum V_i)^(1/2)
    theorem1-gains   Theorem 1, 25-27  proved   ...  Theorem 1's conditions for the scenario's gains and topology
    2 claims: 2 proved (... s of checks); every claim as documented
    """
    w = max([len(r.id) for r in results] + [5])
    e = max([len(r.equations) for r in results] + [3])
    v = max([len(r.verdict) for r in results] + [7])
    lines = []
    if scenario is not None:
        lines.append(f"fsmctl prove: Liang, Sun & Wang (2012), Section 3; scenario {scenario.label}")
    lines.append(f"{'claim':{w}}  {'eqs':{e}}  {'verdict':{v}}  seconds  title")
    lines.append("-" * min(width, w + e + v + 40))
    for r in results:
        lines.append(f"{r.id:{w}}  {r.equations:{e}}  {r.verdict:{v}}  {r.seconds:7.2f}  {r.title}")
        for para in r.detail.splitlines():
            if para.startswith(PREFORMATTED) and para.strip():  # a table's row: aligned, never wrapped
                lines.append(f"    {para}")
                continue
            lines.extend(textwrap.wrap(para, width=width, initial_indent="    ", subsequent_indent="      ") or [""])
    if errata is not None:
        lines += ["", *format_errata(errata, results, width=width).splitlines()[:-1]]
    lines.append(summary_line(results))
    if errata is not None:
        lines.append(errata_summary_line(errata))
    return "\n".join(lines)


def to_json(results: Sequence[ClaimResult], errata: Sequence[Erratum] | None = None) -> str:
    """JSON object: ``{"outcome": {...}, "claims": [...], "errata": [...]}``, one object per claim and per erratum.

    Parameters
    ----------
    results : sequence of ClaimResult
        Checked claims (Liang et al. 2012, Section 3).
    errata : sequence of Erratum, optional
        The checked errata of the printed paper (:func:`fsmctl.proofs.errata.all_errata`); None when they
        were not checked (``fsmctl prove CLAIM_ID...`` checks only the claims named).

    Returns
    -------
    str
        ``claims``: objects with ``id``, ``equations``, ``verdict``, ``detail``, ``seconds`` and also ``title``,
        ``latex``, ``holds``, ``documented``, ``as_documented`` and ``data`` (the numbers of the scenario checks;
        their ``agent`` and ``agents`` count from 1, as the paper's agents 1..n and the text).
        ``outcome``: :func:`outcome` (``as_documented``, ``line``, ...).  ``errata``: null, or objects
        with the fields of ``generated/errata.json`` (``id``, ``equation``, ``as_printed``, ``correct``,
        ``residual``, ``consequence``, the LaTeX, ``checked``) and ``claim``, the id of the claim that examines
        the erratum (null for those found by the re-audit of the printed text).

    Examples
    --------
    >>> import json
    >>> import fsmctl
    >>> from fsmctl.proofs import ProofContext, run_claims
    >>> from fsmctl.proofs.seed_audit import erratum_skew_sign
    >>> results = run_claims(["lemma2-sqrt-sum"], ProofContext(fsmctl.paper_scenario()))
    >>> doc = json.loads(to_json(results, [erratum_skew_sign()]))
    >>> [c["id"] for c in doc["claims"]], [(e["id"], e["equation"], e["claim"]) for e in doc["errata"]]
    (['lemma2-sqrt-sum'], [('eq6-skew-sign', '6', None)])
    >>> json.loads(to_json(results))["errata"] is None
    True
    """
    claims = _claims_of(results)
    doc = {
        "outcome": outcome(results, errata),
        "claims": [r.to_dict() for r in results],
        "errata": None if errata is None else [{**e.to_dict(), "claim": claims.get(e.id)} for e in errata],
    }
    return json.dumps(doc, indent=2, allow_nan=False, default=_default)


def _default(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return str(x)


def to_markdown(
    results: Sequence[ClaimResult], scenario: Scenario | None = None, errata: Sequence[Erratum] | None = None
) -> str:
    """Markdown report with the LaTeX of each checked statement (``$$ ... $$``).

    Parameters
    ----------
    results : sequence of ClaimResult
        Checked claims (Liang et al. 2012, Section 3).
    scenario : Scenario, optional
        Named in the heading.
    errata : sequence of Erratum, optional
        The checked errata of the printed paper (:func:`fsmctl.proofs.errata.all_errata`).

    Returns
    -------
    str
        A summary table, then one section per claim: equations, verdict, LaTeX, detail; with ``errata``, a
        section listing them (equations, status, claim, the printed and the correct statement in LaTeX).
    """
    out = ["# fsmctl prove: Liang, Sun & Wang (2012), Section 3", ""]
    if scenario is not None:
        out += [f"Scenario: **{scenario.label}** ({scenario.description})", ""]
    out += [
        "Verdicts: **proved** (symbolic, SymPy on the model of `derive/`), **numeric** (sampling only: not a proof), "
        "**erratum** (the printed statement is false; the corrected one is checked), **fails for this scenario**.",
        "",
        "| claim | equations | verdict | seconds |",
        "|---|---|---|---|",
    ]
    out += [f"| [`{r.id}`](#{r.id}) | {r.equations} | {r.verdict} | {r.seconds:.2f} |" for r in results]
    out += ["", summary_line(results), ""]
    for r in results:
        out += [f"## {r.id}", "", f"*Eq. {r.equations}* — {r.title}. Verdict: **{r.verdict}**.", ""]
        if r.latex:
            out += ["$$", r.latex, "$$", ""]
        out += _markdown_detail(r.detail)
        out.append("")
    if errata is not None:
        claims = _claims_of(results)
        out += [
            "## Errata of the printed paper",
            "",
            errata_summary_line(errata) + ".",
            "",
            "| erratum | equations | status | claim |",
            "|---|---|---|---|",
        ]
        for e in errata:
            claim = claims.get(e.id)
            shown = f"[`{claim}`](#{claim})" if claim else "-"
            out.append(f"| `{e.id}` | {e.equation} | {'confirmed' if e.checked else 'UNCHECKED'} | {shown} |")
        out.append("")
        for e in errata:
            out += [f"- `{e.id}` (eq. {e.equation}): printed ${e.as_printed_latex}$, correct ${e.correct_latex}$"]
        out.append("")
    return "\n".join(out)


def _markdown_detail(detail: str) -> list[str]:
    """A claim's detail as Markdown: one bullet per line; a run of lines indented by two spaces (a table, e.g.
    :func:`fsmctl.proofs.theorem2_report.requirement_table`) as a fenced block, its alignment kept."""
    out: list[str] = []
    block: list[str] = []
    for line in [*detail.splitlines(), None]:
        if line is not None and line.startswith(PREFORMATTED) and line.strip():
            block.append(line[len(PREFORMATTED) :])
            continue
        if block:
            out += ["", "```text", *block, "```", ""]
            block = []
        if line is not None:
            out.append(f"- {line}")
    return out


def write_report(
    path: str | Path,
    results: Sequence[ClaimResult],
    scenario: Scenario | None = None,
    errata: Sequence[Erratum] | None = None,
) -> Path:
    """Write :func:`to_markdown` (Liang et al. 2012, Section 3) to a file.

    Parameters
    ----------
    path : str or Path
        Destination ``.md`` file.
    results : sequence of ClaimResult
        Checked claims.
    scenario : Scenario, optional
        Named in the heading.
    errata : sequence of Erratum, optional
        The checked errata of the printed paper (:func:`fsmctl.proofs.errata.all_errata`).

    Returns
    -------
    Path
        The file written (atomically, :func:`fsmctl.outputs.write_text`).

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.proofs import ProofContext, run_claims
    >>> results = run_claims(["lemma2-sqrt-sum", "theorem1-gains"], ProofContext(fsmctl.paper_scenario()))
    >>> path = write_report("proof.md", results, fsmctl.paper_scenario())
    >>> text = path.read_text()
    >>> print(text.splitlines()[0])
    # fsmctl prove: Liang, Sun & Wang (2012), Section 3
    >>> "theorem1-gains" in text, "$$" in text  # each claim, with the LaTeX of what was checked
    (True, True)
    """
    from fsmctl.outputs import write_text

    return write_text(path, to_markdown(results, scenario, errata))
