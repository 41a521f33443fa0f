"""Output of ``fsmctl prove``: a text table, JSON, and a Markdown report with LaTeX.

Liang, Sun & Wang (2012), Section 3: one row per claim (id, equations, verdict, seconds),
the detail of each claim indented below it.
"""

from __future__ import annotations

import json
import textwrap
from collections.abc import Sequence
from pathlib import Path

from fsmctl.model.scenario import Scenario
from fsmctl.proofs.claims import CLAIMS, ClaimResult

__all__ = ["format_list", "format_table", "summary_line", "to_json", "to_markdown", "write_report"]


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
    return "\n".join(rows)


def summary_line(results: Sequence[ClaimResult]) -> str:
    """One line counting the verdicts.

    Parameters
    ----------
    results : sequence of ClaimResult
        Checked claims (Liang et al. 2012, Section 3).

    Returns
    -------
    str
        ``N claims: a proved, b erratum, ... (t s of checks); ...`` naming the claims not as expected.
    """
    counts: dict[str, int] = {}
    for r in results:
        counts[r.verdict] = counts.get(r.verdict, 0) + 1
    parts = ", ".join(f"{n} {v}" for v, n in counts.items())
    total = sum(r.seconds for r in results)
    bad = [r.id for r in results if not r.expected]
    tail = f"; not as expected: {', '.join(bad)}" if bad else "; every claim as expected"
    noun = "claim" if len(results) == 1 else "claims"
    return f"{len(results)} {noun}: {parts} ({total:.1f} s of checks){tail}"


def format_table(results: Sequence[ClaimResult], scenario: Scenario | None = None, *, width: int = 120) -> str:
    """Plain-text table: one line per claim (id, equations of Liang et al. 2012, verdict, seconds), then its detail.

    Parameters
    ----------
    results : sequence of ClaimResult
        Checked claims.
    scenario : Scenario, optional
        Named in the heading.
    width : int
        Column at which the detail is wrapped.

    Returns
    -------
    str
        The table, ending with :func:`summary_line`.

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
    2 claims: 2 proved (... s of checks); every claim as expected
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
            lines.extend(textwrap.wrap(para, width=width, initial_indent="    ", subsequent_indent="      ") or [""])
    lines.append(summary_line(results))
    return "\n".join(lines)


def to_json(results: Sequence[ClaimResult]) -> str:
    """JSON array, one object per claim.

    Parameters
    ----------
    results : sequence of ClaimResult
        Checked claims (Liang et al. 2012, Section 3).

    Returns
    -------
    str
        Objects with ``id``, ``equations``, ``verdict``, ``detail``, ``seconds`` and also ``title``,
        ``latex``, ``expected`` and ``data`` (the numbers of the scenario checks).
    """
    return json.dumps([r.to_dict() for r in results], indent=2, allow_nan=False, default=_default)


def _default(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return str(x)


def to_markdown(results: Sequence[ClaimResult], scenario: Scenario | None = None) -> str:
    """Markdown report with the LaTeX of each checked statement (``$$ ... $$``).

    Parameters
    ----------
    results : sequence of ClaimResult
        Checked claims (Liang et al. 2012, Section 3).
    scenario : Scenario, optional
        Named in the heading.

    Returns
    -------
    str
        A summary table, then one section per claim: equations, verdict, LaTeX, detail.
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
        out += [f"- {line}" for line in r.detail.splitlines()]
        out.append("")
    return "\n".join(out)


def write_report(path: str | Path, results: Sequence[ClaimResult], scenario: Scenario | None = None) -> Path:
    """Write :func:`to_markdown` (Liang et al. 2012, Section 3) to a file.

    Parameters
    ----------
    path : str or Path
        Destination ``.md`` file.
    results : sequence of ClaimResult
        Checked claims.
    scenario : Scenario, optional
        Named in the heading.

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

    return write_text(path, to_markdown(results, scenario))
