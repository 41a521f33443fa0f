"""The reproduction's result as ``fsmctl reproduce`` prints it: one plain line first, then one short row per claim.

The report itself (Markdown and HTML) is :mod:`fsmctl.studies.report`; this module only formats a
:class:`~fsmctl.studies.report.Reproduction` for a terminal.
"""

from __future__ import annotations

import textwrap

from fsmctl.studies.explain_report import change_cell
from fsmctl.studies.report import Reproduction

__all__ = ["format_claims"]


def format_claims(rep: Reproduction, width: int = 110) -> str:
    """The plain-text result: one line with the verdict counts and whether they are the documented ones, then one
    short row per claim and per figure check (the evidence is in ``report.md``).

    Parameters
    ----------
    rep : Reproduction
        From :func:`~fsmctl.studies.reproduce.reproduce`.
    width : int
        Wrap width of a row's text.

    Returns
    -------
    str
        :meth:`Reproduction.outcome_line`, then a table: claim, verdict, this run, what would reproduce it.

    Examples
    --------
    >>> rep = one_second_reproduction()  # conftest.py: the Reproduction example's 1 s runs (shared)
    >>> print(format_claims(rep).splitlines()[4])  # doctest: +ELLIPSIS
    settling_27s         impossible (bound)  not settled to 1° in 1 s
    """
    explained = {e.id: e for e in rep.explanations or ()}
    claim_ids = {c.id for c in rep.claims}
    checks = [e for e in rep.explanations or () if e.id not in claim_ids]
    w = max(len(r) for r in [*claim_ids, *(e.id for e in checks)])
    v = max(len(r) for r in [*(c.verdict for c in rep.claims), *(e.verdict for e in checks), "verdict"])
    head = f"{'claim':{w}}  {'verdict':{v}}  this run" + ("  (reproduces with)" if rep.explanations is not None else "")
    lines = [rep.outcome_line(), "", head, f"{'-' * w}  {'-' * v}  {'-' * 30}"]

    def row(rid: str, verdict_text: str, this_run: str, e) -> None:
        change = f"  ({change_cell(e)})" if rep.explanations is not None else ""
        lines.extend(
            textwrap.wrap(
                f"{rid:{w}}  {verdict_text:{v}}  {this_run}{change}",
                width,
                subsequent_indent=" " * (w + v + 6),
                break_long_words=False,
            )
        )

    for c in rep.claims:
        row(c.id, c.verdict, c.this_run_short, explained.get(c.id))
    if checks:
        lines.append("figure checks (the printed axes and insets of Figs 1-9):")
        for e in checks:
            row(e.id, e.verdict, e.baseline, e)
    bounds = ", ".join(f"{b.agent}: {b.min_time_s:.1f} s" for b in rep.bounds)
    lines.append(f"angular-momentum bound on the settling time per agent: {bounds}")
    return "\n".join(lines)
