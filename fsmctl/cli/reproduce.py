"""``fsmctl reproduce``: the Section 4 reproduction report (:mod:`fsmctl.studies.reproduce`) from the command line.

Exit codes (:data:`EXIT_CODES`, :mod:`fsmctl.cli.exit_codes`): 0 the report was written and every verdict is the
documented one (or no finding is documented for the run: another scenario, ``--fast``; with ``--strict``: every
claim is reproduced), 1 a verdict differs from the documented finding (``--strict``: a claim is not reproduced),
2 usage or input error.
"""

from __future__ import annotations

import argparse
import sys

from fsmctl.cli.exit_codes import epilog
from fsmctl.cli.options import add_figures_option, add_out_option, add_progress_option, add_scenario_option
from fsmctl.cli.parallel_options import add_workers_option, chosen_workers
from fsmctl.policy import FAST_T_FINAL_S, LONG_HORIZON_FACTOR

__all__ = ["add_parser", "run", "EXIT_CODES"]

EXIT_CODES = {
    0: "the report was written and every verdict is the documented one (docs/findings.md), or no finding is "
    "documented for this run (another scenario, --fast); with --strict: every claim is reproduced",
    1: "the report was written and a verdict differs from the documented finding (with --strict: a claim is not "
    "reproduced)",
}
"""What ``fsmctl reproduce``'s exit code 0 means (the others: :data:`fsmctl.cli.exit_codes.MEANINGS`)."""


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
        "It flies the paper's law (fsm), and its explanations also its variant without the shadow-set switch of the "
        "error MRP (fsm_unswitched, derived from fsmctl/studies/explain_laws/fsm_unswitched.py on first use); "
        "fsmctl simulate --law flies others.",
        epilog=epilog(EXIT_CODES),
    )
    add_scenario_option(p, note="with the paper's cases 1, 2, 3a, 3b, 3c")
    add_out_option(p, "reproduction")
    p.add_argument(
        "--fast",
        action="store_true",
        help=f"short horizons for tests and quick looks ({FAST_T_FINAL_S:g} s; the long runs "
        f"{LONG_HORIZON_FACTOR * FAST_T_FINAL_S:g} s)",
    )
    add_workers_option(p, what="worker processes flying the runs")
    add_figures_option(p)
    p.add_argument(
        "--explain",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="search, for each claim not reproduced, the smallest change of a setting the paper leaves open that "
        "reproduces it (separate runs written as scenario files in DIR/explain/; --fast: at the short horizon) "
        "(default: on)",
    )
    p.add_argument(
        "--strict",
        action="store_true",
        help="exit 1 unless every claim is reproduced (default: exit 1 only when a verdict differs from the "
        "documented finding of the paper's scenario at its full horizon)",
    )
    add_progress_option(p, "over the runs")
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
        0 when the report was written and its verdicts are the documented ones (``--strict``: every claim is
        reproduced), else 1; bad input raises :class:`fsmctl.errors.InputError` (exit 2).
    """
    from fsmctl.outputs import output_folder
    from fsmctl.studies.report_text import format_claims
    from fsmctl.studies.reproduce import reproduce

    with output_folder(args.out):  # a run that fails before writing anything leaves no empty folder
        rep = reproduce(
            args.scenario,
            args.out,
            fast=args.fast,
            workers=chosen_workers(args),
            progress=args.progress,
            figures=not args.no_figures,
            log=print,
            explain=args.explain,
            command=getattr(args, "argv", None) or ["fsmctl", *sys.argv[1:]],
        )
    print()
    print(format_claims(rep))
    print()
    explained = f", of which explanations {rep.explain_wall_time_s:.1f} s" if rep.explanations is not None else ""
    md, html = rep.out_dir / "report.md", rep.out_dir / "report.html"
    print(f"report: {md} and {html} ({rep.run_count}, {rep.wall_time_s:.1f} s wall time{explained})")
    return 0 if rep.as_expected(strict=args.strict) else 1
