"""The report of ``fsmctl reproduce``: ``report.md``, ``claims.csv``, ``claims.json`` and the terminal summary.

:class:`Reproduction` is everything :func:`fsmctl.studies.reproduce.reproduce` computed; :func:`write_outputs` writes
its files (each run's entry by :meth:`fsmctl.studies.records.RunRecord.to_json`), :func:`to_markdown` is the report
and :func:`fsmctl.studies.report_text.format_claims` the plain-text claims table.
"""

from __future__ import annotations

import csv
import math
import re
from collections import Counter
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

from fsmctl.outputs import atomic_path, write_json, write_text
from fsmctl.policy import SETTLING_TOLERANCES_DEG, STEADY_RULE, default_steady_window, steady_window_text
from fsmctl.studies.claim_types import (
    DIFFERS,
    IMPOSSIBLE,
    PAPER_SETTLING_TIME_S,
    REPRODUCED,
    VERDICTS,
    ClaimVerdict,
)
from fsmctl.studies.explain_report import change_cell, evidence_items, method_blocks
from fsmctl.studies.figure_checks import get_figure_check
from fsmctl.studies.momentum import MomentumBound
from fsmctl.studies.records import RunRecord
from fsmctl.studies.report_doc import (
    Block,
    Bullets,
    Code,
    Details,
    Document,
    Figure,
    Figures,
    Heading,
    Paragraph,
    Span,
    Table,
    Text,
    code,
    link,
    render_html,
    render_markdown,
    strong,
    verdict,
)
from fsmctl.studies.wording import count, join_words, value_range, verdict_count

__all__ = [
    "Reproduction",
    "write_outputs",
    "to_markdown",
    "to_html",
    "report_document",
    "figure_numbers",
]

FIGURE_VERDICTS = ("fits", "does not fit")
"""The verdicts of a figure-level check (:data:`fsmctl.studies.figure_checks.FIGURE_CHECKS`)."""


@dataclass
class Reproduction:
    """Everything ``fsmctl reproduce`` computed and wrote (:func:`~fsmctl.studies.reproduce.reproduce`).

    Parameters
    ----------
    out_dir : Path
        The output folder.
    fast : bool
        Whether the runs used the short horizon.
    scenario_lines : list of str
        Case 1's settings and the choices the paper leaves open, one per line.
    records : dict of str -> RunRecord
        Every run of :func:`~fsmctl.studies.paper_runs.run_plan`, in its order.
    bounds : list of MomentumBound
        :func:`~fsmctl.studies.momentum.angular_momentum_bound` of Case 1.
    claims : list of ClaimVerdict
        :func:`~fsmctl.studies.claims.evaluate_claims`.
    inertia_check : list of dict
        Principal moments of J0 and J0 + ΔJ per agent, with the triangle inequality.
    files : list of str
        Every written run and figure file.
    wall_time_s : float
        Wall time of the reproduction (s).
    explanations : list, optional
        :class:`fsmctl.studies.explain.Explanation` per claim and figure check (None: not searched).
    explain_wall_time_s : float
        Wall time of the explanations (s).
    documented_applies : bool
        Whether the documented findings apply (the paper's own scenario, unchanged, at its full horizon): then
        :meth:`differences` compares every verdict with the documented one.

    Examples
    --------
    :func:`~fsmctl.studies.reproduce.reproduce` returns one; here one assembled from 1 s runs, to read it:

    >>> from pathlib import Path
    >>> from fsmctl import paper_scenario, simulate
    >>> from fsmctl.studies.claims import evaluate_claims
    >>> from fsmctl.studies.momentum import angular_momentum_bound
    >>> from fsmctl.studies.paper_runs import run_plan, run_record, run_scenario
    >>> def one_second(spec):  # a run of the plan, 1 s long (the reproduction flies 100 s)
    ...     scenario = run_scenario("paper", spec, fast=True).replace(simulation={"t_final": 1.0})
    ...     return run_record(spec, scenario, simulate(scenario, progress=False))
    >>> records = {spec.key: one_second(spec) for spec in run_plan()}
    >>> bounds = angular_momentum_bound(paper_scenario("1"))
    >>> rep = Reproduction(Path("out"), True, ["paper case 1"], records, bounds, evaluate_claims(records, bounds),
    ...                    inertia_check=[], files=[], wall_time_s=0.0)
    >>> rep.claims_table()[0]["verdict"]
    'impossible (bound)'
    >>> list(rep.records)[:3]
    ['case1', 'case2', 'case3a']
    """

    out_dir: Path
    fast: bool
    scenario_lines: list[str]
    records: dict[str, RunRecord]
    bounds: list[MomentumBound]
    claims: list[ClaimVerdict]
    inertia_check: list[dict]
    files: list[str]
    wall_time_s: float
    explanations: list | None = None
    """:class:`fsmctl.studies.explain.Explanation` per claim and figure check (None: not searched)"""
    explain_wall_time_s: float = 0.0
    documented_applies: bool = False

    @property
    def run_count(self) -> str:
        """str: How many runs the report lists and how many were flown (a run with the settings of an earlier one
        reuses its result, :attr:`~fsmctl.studies.records.RunRecord.same_as`).

        Examples
        --------
        >>> from dataclasses import replace
        >>> rep = one_second_reproduction()  # conftest.py: the 1 s runs, each flown
        >>> rep.run_count
        '14 runs'
        >>> rep.records["case3c"] = replace(rep.records["case3c"], same_as="case1")
        >>> rep.run_count
        "14 runs (13 flown; case3c is case1's settings, not flown again)"
        """
        reused: dict[str, list[str]] = {}
        for key, record in self.records.items():
            if record.same_as:
                reused.setdefault(record.same_as, []).append(key)
        total = count(len(self.records), "run")
        if not reused:
            return total
        said = "; ".join(
            (f"{keys[0]} is" if len(keys) == 1 else f"{', '.join(keys[:-1])} and {keys[-1]} are")
            + f" {target}'s settings"
            for target, keys in reused.items()
        )
        return f"{total} ({len(self.records) - sum(map(len, reused.values()))} flown; {said}, not flown again)"

    def differences(self) -> list[str] | None:
        """The verdicts that differ from the documented findings (``docs/findings.md``).

        Returns
        -------
        list of str or None
            One ``"id: verdict (documented: verdict)"`` per claim or figure check whose verdict is not the
            documented one (:attr:`~fsmctl.studies.claim_types.StudyClaim.documented`,
            :attr:`~fsmctl.studies.figure_checks.FigureCheck.documented_fits`); empty when every verdict is as
            documented; None when no finding is documented for this run (another scenario, or ``fast``).

        Examples
        --------
        >>> rep = one_second_reproduction()  # conftest.py: 1 s runs, so no documented finding applies
        >>> rep.differences() is None
        True
        """
        if not self.documented_applies:
            return None
        found = [f"{c.id}: {c.verdict} (documented: {c.documented})" for c in self.claims if c.verdict != c.documented]
        claim_ids = {c.id for c in self.claims}
        for e in self.explanations or ():
            if e.id in claim_ids:
                continue
            documented = FIGURE_VERDICTS[0] if get_figure_check(e.id).documented_fits else FIGURE_VERDICTS[1]
            if e.verdict != documented:
                found.append(f"{e.id}: {e.verdict} (documented: {documented})")
        return found

    def as_expected(self, strict: bool = False) -> bool:
        """Whether the result is the expected one: ``fsmctl reproduce``'s exit code 0.

        Parameters
        ----------
        strict : bool
            Expect every claim reproduced (default: expect the documented verdicts, where they apply).

        Returns
        -------
        bool
            ``strict``: every claim is reproduced; else no verdict differs from the documented finding (True when
            none is documented for this run).

        Examples
        --------
        >>> rep = one_second_reproduction()  # conftest.py: 1 s runs
        >>> rep.as_expected(), rep.as_expected(strict=True)
        (True, False)
        """
        if strict:
            return all(c.verdict == REPRODUCED for c in self.claims)
        return not self.differences()

    def outcome_line(self) -> str:
        """The result in one plain line: the verdict counts and whether they are the documented ones.

        Returns
        -------
        str
            E.g. ``"7 claims: 0 reproduced, 5 differ, 2 impossible (bound); every verdict as documented"``.

        Examples
        --------
        >>> print(one_second_reproduction().outcome_line())  # doctest: +ELLIPSIS
        7 claims: ...; no documented finding for this run (the documented ones are of the paper's scenario at ...)
        """
        seen = Counter(c.verdict for c in self.claims)
        line = f"{count(len(self.claims), 'claim')}: " + ", ".join(verdict_count(seen[v], v) for v in VERDICTS)
        differ = self.differences()
        if differ is None:
            return (
                line + "; no documented finding for this run (the documented ones are of the paper's scenario at "
                "its full horizon)"
            )
        if not differ:
            return line + "; every verdict as documented"
        return line + f"; {count(len(differ), 'verdict')} not as documented: " + "; ".join(differ)

    def claims_table(self) -> list[dict]:
        """The claims as a list of dicts (one per claim).

        Returns
        -------
        list of dict
            The fields of each :class:`ClaimVerdict`.
        """
        return [asdict(c) for c in self.claims]

    def dataset(self, key: str):
        """The full time series of run ``key`` as an :class:`xarray.Dataset` (loaded from its NetCDF file).

        Parameters
        ----------
        key : str
            A run of :func:`~fsmctl.studies.paper_runs.run_plan` (``"case1"``, ``"case1_no_torque_limit"``, ...).

        Returns
        -------
        xarray.Dataset
            Variables with units in their names and attributes (see
            :meth:`fsmctl.simulation.simulator.SimulationResult.to_dataset`).

        Raises
        ------
        KeyError
            If there is no run ``key``.
        """
        import xarray as xr

        if key not in self.records:
            raise KeyError(f"no run {key!r} (runs: {list(self.records)})")
        with xr.open_dataset(self.records[key].netcdf) as ds:
            return ds.load()


def _relative(path: str | Path, out: Path) -> str:
    p = Path(path)
    return str(p.relative_to(out) if p.is_relative_to(out) else p)


def write_outputs(rep: Reproduction) -> list[Path]:
    """Write ``claims.csv``, ``claims.json``, ``report.md`` and ``report.html`` into ``rep.out_dir``.

    Parameters
    ----------
    rep : Reproduction
        From :func:`~fsmctl.studies.reproduce.reproduce`.

    Returns
    -------
    list of Path
        The four files (each written atomically; the reports last).

    Examples
    --------
    >>> from pathlib import Path
    >>> rep = one_second_reproduction()  # conftest.py: the Reproduction example's 1 s runs (shared)
    >>> [p.name for p in write_outputs(rep)]
    ['claims.csv', 'claims.json', 'report.md', 'report.html']
    >>> Path("out/claims.csv").read_text().splitlines()[1].split(",")[0]
    'settling_27s'
    """
    out = rep.out_dir
    csv_path, json_path = out / "claims.csv", out / "claims.json"
    md_path, html_path = out / "report.md", out / "report.html"
    fields = list(ClaimVerdict.__dataclass_fields__)
    with atomic_path(csv_path) as tmp, tmp.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields)
        writer.writeheader()
        for c in rep.claims:
            writer.writerow(asdict(c))
    runs = {k: r.to_json(out, SETTLING_TOLERANCES_DEG) for k, r in rep.records.items()}
    payload = {
        "source": "Liang, Sun & Wang, Acta Astronautica 81 (2012) 445-455, Section 4",
        "fast": rep.fast,
        "verdict_kinds": list(VERDICTS),
        "settling_tolerances_deg": list(SETTLING_TOLERANCES_DEG),
        "claims": rep.claims_table(),
        "angular_momentum_bound": [asdict(b) for b in rep.bounds],
        "inertia_check": rep.inertia_check,
        "scenario": rep.scenario_lines,
        "runs": runs,
        "wall_time_s": rep.wall_time_s,
    }
    if rep.explanations is not None:
        payload["explanations"] = [e.to_dict() for e in rep.explanations]
        payload["explain_wall_time_s"] = rep.explain_wall_time_s
    write_json(json_path, payload)
    doc = report_document(rep)
    write_text(md_path, render_markdown(doc))
    write_text(html_path, render_html(doc, out))
    return [csv_path, json_path, md_path, html_path]


def to_markdown(rep: Reproduction) -> str:
    """The reproduction report (Markdown), :func:`report_document` rendered.

    Parameters
    ----------
    rep : Reproduction
        From :func:`~fsmctl.studies.reproduce.reproduce`.

    Returns
    -------
    str
        The verdict summary first (the counts, one short row per claim), then each claim's evidence with its
        figures, the figure-level checks, how the explanations searched, the angular-momentum bound per agent, the
        numbers of every run, the choices, and the figures not shown with a claim.

    Examples
    --------
    >>> rep = one_second_reproduction()  # conftest.py: the Reproduction example's 1 s runs (shared)
    >>> lines = to_markdown(rep).splitlines()
    >>> print(lines[4])
    **7 claims:** **0 reproduced**, **3 differ**, **4 impossible (bound)**. No documented finding applies to this run: ...
    >>> [line for line in lines if line.startswith("## ")][:3]
    ['## Evidence per claim', '## Angular-momentum bound (independent of the controller)', '## Initial numbers (Table 1 and the reference, t = 0)']
    """
    return render_markdown(report_document(rep))


def to_html(rep: Reproduction) -> str:
    """The reproduction report as one self-contained HTML page (the content of :func:`to_markdown`).

    The figures are embedded (``data:`` URIs), the evidence of each claim is a collapsible ``<details>``; links to
    the run files and scenario files stay relative to the report's folder.

    Parameters
    ----------
    rep : Reproduction
        From :func:`~fsmctl.studies.reproduce.reproduce`.

    Returns
    -------
    str
        The page.

    Examples
    --------
    >>> rep = one_second_reproduction()  # conftest.py: the Reproduction example's 1 s runs (shared)
    >>> page = to_html(rep)
    >>> page.startswith("<!DOCTYPE html>"), page.count('<details class="claim">')
    (True, 7)
    """
    return render_html(report_document(rep), rep.out_dir)


# ----------------------------------------------------------------------------- the document


def report_document(rep: Reproduction) -> Document:
    """The report's content, once, for :func:`to_markdown` and :func:`to_html`.

    Parameters
    ----------
    rep : Reproduction
        From :func:`~fsmctl.studies.reproduce.reproduce`.

    Returns
    -------
    Document
        Blocks of :mod:`fsmctl.studies.report_doc`.

    Examples
    --------
    >>> rep = one_second_reproduction()  # conftest.py: the Reproduction example's 1 s runs (shared)
    >>> from fsmctl.studies.report_doc import plain
    >>> doc = report_document(rep)
    >>> doc.title
    'Reproduction of Liang, Sun & Wang (2012), Section 4'
    >>> [plain(cell) for cell in doc.blocks[2].rows[0]]
    ['Case 1 settling time', '27 s (tolerance not stated)', 'not settled to 1° in 1 s', 'impossible (bound)']
    """
    explained = {e.id: e for e in rep.explanations or ()}
    checks = [e for e in rep.explanations or () if e.id not in {c.id for c in rep.claims}]
    figures = _FigureShelf(rep)
    blocks: list[Block] = [*_summary_blocks(rep, explained, checks), Heading(2, "Evidence per claim")]
    for c in rep.claims:
        blocks += _claim_blocks(rep, c, explained.get(c.id), figures)
    if checks:
        blocks += [
            Heading(2, "Figure-level evidence"),
            Paragraph(
                (
                    "What the printed Figs 1-9 show (axis ranges, the saturation level, the insets), checked like the "
                    "claims: which change makes the printed figure possible.",
                )
            ),
        ]
        for e in checks:
            blocks += _check_blocks(e, figures)
    if rep.explanations is not None:
        blocks += method_blocks(rep.explanations, rep.fast)
    blocks += [*_bound_blocks(rep), *_initial_blocks(rep), *_run_blocks(rep), *_inertia_blocks(rep)]
    blocks += [Heading(2, "Settings and the choices the paper leaves open"), Code(rep.scenario_lines)]
    rest = figures.remaining()
    if rest:
        blocks += [
            Heading(2, "More figures"),
            Paragraph(("The diagnostic runs, and any of Figs 1-9 not shown with a claim above.",)),
            Figures(rest),
        ]
    return Document(TITLE, blocks)


TITLE = "Reproduction of Liang, Sun & Wang (2012), Section 4"

_VERDICT_LEGEND = (
    "Verdicts: ",
    verdict(REPRODUCED),
    " (this run shows what the paper states); ",
    verdict(DIFFERS),
    " (it does not; the evidence gives the reason and the diagnostic run that shows it); ",
    verdict(IMPOSSIBLE),
    " (no controller within the paper's torque limit can do it, by the angular-momentum bound below).",
)


def _counts(items: Sequence[str], kinds: Sequence[str]) -> list[str | Span]:
    seen = Counter(items)
    parts: list[str | Span] = []
    for kind in kinds:
        parts += [", " if parts else "", verdict(verdict_count(seen[kind], kind))]
    return parts


def _summary_blocks(rep: Reproduction, explained: dict, checks: list) -> list[Block]:
    """The verdict counts and one short row per claim: what a reader takes in at a glance."""
    line: list[str | Span] = [strong(f"{count(len(rep.claims), 'claim')}:"), " "]
    line += [*_counts([c.verdict for c in rep.claims], VERDICTS), "."]
    if checks:
        line += [" ", strong(f"{count(len(checks), 'figure check')}:"), " "]
        line += [*_counts([e.verdict for e in checks], FIGURE_VERDICTS), "."]
    blocks: list[Block] = []
    if rep.fast:
        blocks.append(
            Paragraph((strong("Fast mode: short horizon, the verdicts are not those of the paper's 100 s runs."),))
        )
    header = ["claim", "paper", "this run", "verdict"]
    rows = [
        [(link(c.title, f"#{c.id}"),), (c.paper_value,), (c.this_run_short,), (verdict(c.verdict),)] for c in rep.claims
    ]
    if rep.explanations is not None:
        header.append("reproduces with")
        for row, c in zip(rows, rep.claims, strict=True):
            row.append((change_cell(explained.get(c.id)),))
    command = f"fsmctl reproduce{' --fast' if rep.fast else ''}"
    timing = f"{rep.run_count} in {rep.wall_time_s:.1f} s wall time" + (
        f" (the explanations: {rep.explain_wall_time_s:.1f} s)" if rep.explanations is not None else ""
    )
    line += [" ", _documented_sentence(rep)]
    blocks += [Paragraph(tuple(line)), Table(header, rows, "summary")]
    if checks:
        blocks.append(
            Table(["printed figure", "this run", "verdict", "fits with"], [_check_row(e) for e in checks], "summary")
        )
    blocks += [
        Paragraph((code(command), f": {timing}. Each claim's evidence follows, with its figures.")),
        Paragraph(_VERDICT_LEGEND),
    ]
    return blocks


def _documented_sentence(rep: Reproduction) -> str:
    differ = rep.differences()
    if differ is None:
        return (
            "No documented finding applies to this run: the documented verdicts (docs/findings.md) are those of the "
            "paper's own scenario at its full horizon."
        )
    if not differ:
        return "Every verdict is the one documented (docs/findings.md)."
    return f"Not as documented (docs/findings.md): {'; '.join(differ)}."


def _check_row(e) -> list[Text]:
    return [(link(e.claim, f"#{e.id}"),), (e.baseline,), (verdict(e.verdict),), (change_cell(e),)]


class _FigureShelf:
    """The report's figures, each shown once: with the first claim or check that cites it, the rest at the end."""

    def __init__(self, rep: Reproduction) -> None:
        pngs = [_relative(f, rep.out_dir) for f in rep.files if f.endswith(".png")]
        self.out_dir = Path(rep.out_dir)
        self.left = _in_paper_order(pngs)

    def take(self, cited: str) -> list[Figure]:
        """The figures of the paper's figure numbers cited in ``cited`` (``"Figs 1-2"``) not shown yet."""
        wanted = figure_numbers(cited)
        taken = [f for f in self.left if _paper_number(f) in wanted]
        self.left = [f for f in self.left if f not in taken]
        return [Figure(f, _caption(f, self.out_dir)) for f in taken]

    def remaining(self) -> list[Figure]:
        return [Figure(f, _caption(f, self.out_dir)) for f in self.left]


def figure_numbers(cited: str) -> list[int]:
    """The paper's figure numbers a citation names: ``"Figs 1-2"`` -> ``[1, 2]``, ``"Fig 4: ..."`` -> ``[4]``.

    Parameters
    ----------
    cited : str
        Text that starts with, or contains, ``Fig N`` or ``Figs N-M`` (the first one counts).

    Returns
    -------
    list of int
        The numbers (empty when none is cited).

    Examples
    --------
    >>> figure_numbers("Figs 5-6"), figure_numbers("Fig 1 inset"), figure_numbers("Figs 8-9 insets (0-0.04°)")
    ([5, 6], [1], [8, 9])
    >>> figure_numbers("the bound")
    []
    """
    m = re.search(r"Figs? (\d+)(?:-(\d+))?", cited)
    if m is None:
        return []
    first = int(m.group(1))
    return list(range(first, int(m.group(2) or first) + 1))


def _paper_number(path: str) -> int:
    stem = Path(path).stem
    return int(stem[3:5]) if stem.startswith("fig") and stem[3:5].isdigit() else 0


def _caption(path: str, out_dir: Path) -> str:
    from fsmctl.studies.figure_marks import read_caption  # what the figure shows, as saved with it

    n, stem, shows = _paper_number(path), Path(path).stem, read_caption(out_dir / path)
    return (f"Fig {n}: {shows}" if n else f"{stem}: {shows}") if shows else (f"Fig {n} ({stem})" if n else stem)


def _runs_text(rep: Reproduction, keys: str) -> list[str | Span]:
    parts: list[str | Span] = []
    for key in (k.strip() for k in keys.split(",") if k.strip()):
        parts.append(", " if parts else "")
        r = rep.records.get(key)
        parts.append(link(key, _relative(r.netcdf, rep.out_dir)) if r is not None and r.netcdf else code(key))
    return parts


def _claim_blocks(rep: Reproduction, c: ClaimVerdict, e, figures: _FigureShelf) -> list[Block]:
    """One claim: what the paper states and the verdict (visible), its figures, its evidence (collapsible)."""
    items: list[Text] = [(strong("This run"), f": {c.this_run_value}")]
    if c.reason:
        items.append((strong("Why"), f": {c.reason}"))
    if c.diagnostic_runs:
        items.append((strong("Diagnostic runs"), ": ", *_runs_text(rep, c.diagnostic_runs)))
    if e is not None:
        items += evidence_items(e)
    shown = figures.take(c.figures)
    return [
        Heading(3, c.id, anchor=c.id),
        Paragraph(
            (
                strong(f"{c.title}."),
                f" The paper ({c.figures}): {c.claim}; {c.paper_value}. This run: {c.this_run_short}. Verdict: ",
                verdict(c.verdict),
                ".",
            )
        ),
        *([Figures(shown)] if shown else []),
        Details(("Evidence",), [Bullets(items)], "claim"),
    ]


def _check_blocks(e, figures: _FigureShelf) -> list[Block]:
    shown = figures.take(e.claim)
    return [
        Heading(3, e.id, anchor=e.id),
        Paragraph((f"The paper's {e.claim}. This run: {e.baseline}. Verdict: ", verdict(e.verdict), ".")),
        *([Figures(shown)] if shown else []),
        Details(("Evidence",), [Bullets(evidence_items(e))], "check"),
    ]


def _bound_blocks(rep: Reproduction) -> list[Block]:
    b0 = rep.bounds[0]
    rows = [
        [
            (str(b.agent),),
            (f"{b.torque_limit_N_m:g}",),
            (f"{b.H0_N_m_s:.2f}",),
            (f"{b.H0_minus_Hd0_N_m_s:.2f}",),
            (f"{b.naive_time_s:.2f}",),
            (f"{b.min_time_no_disturbance_s:.2f}",),
            (f"{b.min_time_s:.2f}",),
            ("exceeds" if b.min_time_s > PAPER_SETTLING_TIME_S else "below",),
        ]
        for b in rep.bounds
    ]
    return [
        Heading(2, "Angular-momentum bound (independent of the controller)"),
        Paragraph(
            (
                "In the inertial frame N the angular momentum of spacecraft i is H = [BN]^T J ω with the true inertia "
                "J = J0 + ΔJ (eq 29), and dH/dt = [BN]^T (u + d). With |u_k| ≤ u_max per body axis, "
                "|dH/dt| ≤ √3 u_max + |d(t)|. Tracking the reference at time T means H(T) = H_d(T) = [DN]^T J ω_d(T) "
                "(reference integrated open loop from σ_d(0), eq 3), so any settling time T satisfies "
                "|H_d(T) − H(0)| ≤ √3 u_max T + ∫₀ᵀ |d| dt. The table gives the smallest such T (to the grid step "
                f"{b0.grid_step_s:g} s, rounded down), without and with the disturbance helping at full magnitude, and "
                "the naive |J ω(0)| / (√3 u_max). 'Settled' here means ω_i = ω_d in the body frame, which a metric "
                "that stays within its tolerance requires up to a small residual rate.",
            )
        ),
        Table(
            [
                "agent",
                "u_max (N m)",
                "|H(0)| (N m s)",
                "|H(0) − H_d(0)| (N m s)",
                "naive (s)",
                "bound, no disturbance (s)",
                "bound with disturbance (s)",
                f"vs {PAPER_SETTLING_TIME_S:g} s",
            ],
            rows,
        ),
    ]


def _initial_blocks(rep: Reproduction) -> list[Block]:
    c1 = rep.records["case1"]
    return [
        Heading(2, "Initial numbers (Table 1 and the reference, t = 0)"),
        Bullets(
            [
                (
                    f"AAEM(0) = {c1.summary['aaem_initial_deg']:.2f}°, RAEM(0) = {c1.summary['raem_initial_deg']:.2f}°; "
                    f"peaks over Case 1: AAEM {c1.summary['aaem_peak_deg']:.2f}°, RAEM "
                    f"{c1.summary['raem_peak_deg']:.2f}°, θ_ei {c1.theta_e_peak_deg:.2f}°.",
                ),
                ("θ_ei(0) = " + ", ".join(f"{x:.2f}° (agent {i + 1})" for i, x in enumerate(c1.theta_e0_deg)) + ".",),
                (
                    "The paper's figure axes reach AAEM ≈ 300°, RAEM ≈ 140°, θ_i ≈ 200°. Here θ_ei = 4 atan|σ_ei| with "
                    "σ_ei in the shadow set (|σ| ≤ 1), so θ_ei ≤ 180° and AAEM ≤ 180°; axes beyond 180° suggest the "
                    "paper did not switch its error MRPs to the shadow set (then θ ranges up to 360°).",
                ),
            ]
        ),
    ]


def _settling_cell(r: RunRecord, metric: str) -> str:
    return " / ".join(
        "–" if not math.isfinite(x) else f"{x:.2f}" for x in (r.settling(metric, t) for t in SETTLING_TOLERANCES_DEG)
    )


def _steady_rule(records: Sequence[RunRecord]) -> str:
    """The steady window as the runs took it: the policy's rule, and each run whose window is not the rule's of its
    own horizon (a long run keeps the window of the horizon it lengthens: 4 s of the 30 s runs of ``--fast``)."""
    other: dict[tuple[float, float], list[str]] = {}
    for r in records:
        if not math.isclose(r.steady_window_s, default_steady_window(r.t_final)):
            other.setdefault((r.steady_window_s, r.t_final), []).append(r.key)
    return STEADY_RULE + "".join(
        f"; {join_words(keys)}: {steady_window_text(window, horizon)}" for (window, horizon), keys in other.items()
    )


def _run_blocks(rep: Reproduction) -> list[Block]:
    tolerances = " / ".join(f"{t:g}°" for t in SETTLING_TOLERANCES_DEG)
    rows = []
    for r in rep.records.values():
        last = r.last_saturation_s
        overrides = r.overrides + (f" (identical settings to {r.same_as}: not re-run)" if r.same_as else "")
        rel = _relative(r.netcdf, rep.out_dir)
        rows.append(
            [
                (r.key,),
                (overrides,),
                (f"{r.t_final:g}",),
                (_settling_cell(r, "aaem"),),
                (_settling_cell(r, "raem"),),
                (f"{r.aaem_steady_max_deg:.3g} / {r.raem_steady_max_deg:.3g}",),
                (value_range(r.saturated_time_s),),
                ("never" if not math.isfinite(last) else f"{last:.2f}",),
                (f"{r.commanded_peak_N_m:.4g}",),
                (link(rel, rel),),
            ]
        )
    return [
        Heading(2, "Runs"),
        Paragraph(
            (
                "Settling time to a tolerance: the first time after which the metric stays at or below it (",
                code("fsmctl.simulation.metrics.settling_time"),
                f"); the paper does not state its tolerance, so {', '.join(f'{t:g}°' for t in SETTLING_TOLERANCES_DEG)}"
                f" are reported. Steady-state accuracy: the maximum over {_steady_rule(list(rep.records.values()))}."
                " Saturated time: per agent, one number when every agent's prints the same.",
            )
        ),
        Table(
            [
                "run",
                "overrides",
                "horizon (s)",
                f"AAEM settling (s) at {tolerances}",
                "RAEM settling (s)",
                "steady AAEM / RAEM (deg)",
                "saturated time per agent (s)",
                "last saturation (s)",
                "peak commanded (N m)",
                "file",
            ],
            rows,
        ),
        Paragraph(("(– : not settled within the horizon.)",)),
    ]


def _inertia_blocks(rep: Reproduction) -> list[Block]:
    rows = []
    for row in rep.inertia_check:
        moments = ", ".join(f"{x:.4f}" for x in row["principal_moments_kg_m2"])
        gap = row["J1_plus_J2_minus_J3_kg_m2"]
        note = " (violates the rigid-body triangle inequality)" if gap < 0 else ""
        rows.append([(str(row["agent"]),), (row["inertia"],), (moments,), (f"{gap:.3g}{note}",)])
    if not rows:
        return []
    return [
        Heading(2, "Inertia check"),
        Table(["agent", "inertia", "principal moments (kg m²)", "J1 + J2 − J3 (kg m²)"], rows),
    ]


def _in_paper_order(paths) -> list[str]:
    """Figure files in the paper's order: ``figNN_*`` by NN (Figs 1-9), then the others (diagnostics) by name."""

    def key(path: str) -> tuple[int, int, str]:
        n = _paper_number(path)
        return (0, n, Path(path).stem) if n else (1, 0, Path(path).stem)

    return sorted(paths, key=key)


# ----------------------------------------------------------------------------- text
