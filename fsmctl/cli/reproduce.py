"""``fsmctl reproduce``: the Section 4 reproduction report (:mod:`fsmctl.studies.reproduce`) from the command line.

Exit codes: 0 the report was written (the verdicts are results, not failures), 2 usage or input error.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from fsmctl.studies.reproduce import FAST_T_FINAL_S

__all__ = ["add_parser", "run"]


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``fsmctl reproduce`` (Liang et al. 2012, Section 4 and Figs 1-9).

    Parameters
    ----------
    subparsers : argparse subparsers action
        From :func:`fsmctl.cli.main.build_parser`.

    Returns
    -------
    argparse.ArgumentParser
        The ``reproduce`` parser, with ``func = run``.
    """
    p = subparsers.add_parser(
        "reproduce",
        help="run every Section 4 case plus diagnostics and grade the paper's claims",
        description="Reproduction of Liang, Sun & Wang (2012), Section 4: Cases 1, 2, 3a-3c, diagnostic runs, the "
        "angular-momentum bound, and a report grading every claim as reproduced / differs / impossible (bound), "
        "with, for each claim not reproduced, the smallest change of an open setting that would reproduce it. "
        "It flies the paper's law (fsm); fsmctl simulate --law flies others.",
        epilog="exit codes: 0 the report was written (verdicts are results), 2 usage or input error.",
    )
    p.add_argument(
        "--scenario",
        default="paper",
        metavar="FILE",
        help="'paper' (built in) or a TOML file with cases 1, 2, 3a, 3b, 3c (default: paper)",
    )
    p.add_argument(
        "--out", default=Path("reproduction"), type=Path, metavar="DIR", help="output folder (default: ./reproduction)"
    )
    p.add_argument(
        "--fast", action="store_true", help=f"short horizon ({FAST_T_FINAL_S:g} s) for tests and quick looks"
    )
    p.add_argument("--jobs", type=int, default=2, metavar="N", help="worker processes (default: %(default)s)")
    p.add_argument("--no-figures", action="store_true", help="skip the PNG/SVG figures")
    p.add_argument(
        "--explain",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="search, for each claim not reproduced, the smallest change of a setting the paper leaves open that "
        "reproduces it (separate runs written as scenario files in DIR/explain/; --fast: at the short horizon) "
        "(default: on)",
    )
    p.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bar over the runs (default: on a terminal)",
    )
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run ``fsmctl reproduce``; print the choices, the claims table and where the report is.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options.

    Returns
    -------
    int
        0 when the report was written; bad input raises :class:`fsmctl.cli.main.UsageError` or
        :class:`fsmctl.errors.InputError` (exit 2).
    """
    from fsmctl.cli.main import UsageError
    from fsmctl.outputs import output_folder
    from fsmctl.studies.reproduce import format_claims, reproduce

    if args.jobs < 1:
        raise UsageError(f"--jobs must be >= 1, got {args.jobs}")
    with output_folder(args.out):  # a run that fails before writing anything leaves no empty folder
        rep = reproduce(
            args.scenario,
            args.out,
            fast=args.fast,
            jobs=args.jobs,
            progress=args.progress,
            figures=not args.no_figures,
            log=print,
            explain=args.explain,
        )
    print()
    print(format_claims(rep))
    print()
    explained = f"; explanations {rep.explain_wall_time_s:.1f} s" if rep.explanations is not None else ""
    print(f"report: {rep.out_dir / 'report.md'} ({len(rep.records)} runs, {rep.wall_time_s:.1f} s{explained})")
    return 0
