"""``fsmctl tune``: search a law's declared parameters for designs that work under the scenario's actuator limits.

The library is :mod:`fsmctl.studies.tune` (:func:`~fsmctl.studies.tune.tune`); this module only reads the options,
prints the outcome and names the files written to ``DIR`` (``study.log``, ``trials.csv``, ``pareto.csv``,
``pareto.png``, ``best.toml``, ``tune.json``).

Exit codes: 0 the search finished and the files were written (also when no design is feasible: the files say so),
2 usage or input error (one line on stderr), 130 interrupted (``--resume`` continues).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from fsmctl.cli.types import nonnegative_int, positive_float, positive_int

__all__ = ["add_parser", "run"]

EPILOG = """objectives (all minimised; --objectives a,b,...):
  aaem_settling, raem_settling  settling time of AAEM (eq 42) / RAEM (eq 43) to --tolerance-deg, s; a run that never
                                settles within the horizon T scores T * (2 + min(1, decades of its steady error
                                above the tolerance))
  aaem_steady, raem_steady      max over the steady window, deg
  peak_torque, rms_torque       N m
  chattering                    total variation of u per second, N m/s
  wheel_momentum                peak wheel momentum, N m s (scenarios with reaction wheels)

constraints (a trial is feasible when all hold): both metrics settle within the horizon (for the --quantile member
of the ensemble); for the fsm law, Theorem 1's topology conditions on the scenario's topology.

search space: every tunable numeric parameter of the law (fsmctl laws lists them; --parameters chooses) within its
declared range; a side the law leaves unbounded needs --range NAME=LOW,HIGH.  Ranges with LOW > 0 and HIGH/LOW >= 100
are searched log-uniformly; a vector parameter (delta) is one value for every axis and agent.

the same options give the same trials; an interrupted search continues with --resume to --budget trials in total.

exit codes: 0 the search finished and the files were written, 2 usage or input error, 130 interrupted."""


def _names(text: str) -> tuple[str, ...]:
    items = tuple(x.strip() for x in text.split(","))
    if not all(items):
        raise argparse.ArgumentTypeError(f"expected comma-separated names, got {text!r}")
    return items


def _quantile(text: str) -> float:
    try:
        q = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number in [0, 1], got {text!r}") from None
    if not 0 <= q <= 1:
        raise argparse.ArgumentTypeError(f"must be in [0, 1] (1 = worst case, 0.5 = median), got {text!r}")
    return q


def _range(text: str) -> tuple[str, float, float]:
    name, sep, rest = text.partition("=")
    parts = [p.strip() for p in rest.split(",")]
    if not sep or not name.strip() or len(parts) != 2:
        raise argparse.ArgumentTypeError(f"expected NAME=LOW,HIGH, got {text!r}")
    try:
        return name.strip(), float(parts[0]), float(parts[1])
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected NAME=LOW,HIGH with numbers, got {text!r}") from None


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``fsmctl tune`` (search a law's parameters with Optuna).

    Parameters
    ----------
    subparsers : argparse subparsers action
        From :func:`fsmctl.cli.main.build_parser`.

    Returns
    -------
    argparse.ArgumentParser
        The ``tune`` parser, with ``func = run``.
    """
    p = subparsers.add_parser(
        "tune",
        help="search a law's parameters for designs that converge under the actuator limits (Optuna)",
        description="Search the law's declared tunable parameters within their ranges (Optuna: TPE for one "
        "objective, NSGA-II for several), scoring each candidate on the scenario or a seeded ensemble; write "
        "DIR/trials.csv, pareto.csv, pareto.png, best.toml (a scenario file for fsmctl simulate) and tune.json.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--scenario", default="paper", metavar="paper|FILE.toml", help="built-in name or a TOML file")
    p.add_argument("--case", default=None, help="case name (paper: 1, 2, 3a, 3b, 3c; default: the file's first case)")
    p.add_argument(
        "--law",
        required=True,
        metavar="NAME|FILE.py|DIR",
        help="the law to tune: a built-in name (fsmctl laws), a derivation script or a derived folder",
    )
    p.add_argument("--budget", type=positive_int, default=50, metavar="N", help="trials in total (default: 50)")
    p.add_argument("--seed", type=nonnegative_int, default=0, metavar="S", help="seed of the search and the ensemble")
    p.add_argument(
        "--ensemble",
        type=positive_int,
        default=1,
        metavar="M",
        help="members per candidate: 1 = the scenario itself (default); M > 1 = seeded Monte Carlo draws of it",
    )
    p.add_argument(
        "--quantile",
        type=_quantile,
        default=1.0,
        metavar="Q",
        help="aggregate over the members: 1 = worst case (default), 0.5 = median",
    )
    p.add_argument(
        "--objectives",
        type=_names,
        default=("aaem_settling", "peak_torque"),
        metavar="A,B,...",
        help="objectives to minimise (default: aaem_settling,peak_torque; see below)",
    )
    p.add_argument(
        "--parameters",
        type=_names,
        default=(),
        metavar="P1,P2,...",
        help="parameters to search (default: every tunable numeric parameter of the law)",
    )
    p.add_argument(
        "--range",
        dest="ranges",
        type=_range,
        action="append",
        default=[],
        metavar="NAME=LOW,HIGH",
        help="search range of a parameter (within its declared range); repeatable",
    )
    p.add_argument(
        "--tolerance-deg", type=positive_float, default=1.0, metavar="T", help="settling tolerance (default: 1 deg)"
    )
    p.add_argument(
        "--t-final", type=positive_float, default=None, metavar="S", help="horizon in s (default: the scenario's)"
    )
    p.add_argument("--out", type=Path, default=Path("tune"), metavar="DIR", help="output folder (default: ./tune)")
    p.add_argument("--resume", action="store_true", help="continue the study in DIR to --budget trials in total")
    p.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bar over the trials (default: on a terminal)",
    )
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run ``fsmctl tune``; bad input raises :class:`fsmctl.errors.InputError` (one line, exit 2)."""
    from fsmctl.studies.tune import TuneSettings, tune

    settings = TuneSettings(
        scenario=str(args.scenario),
        case=args.case,
        law=args.law,
        budget=args.budget,
        seed=args.seed,
        ensemble=args.ensemble,
        quantile=args.quantile,
        objectives=args.objectives,
        tolerance_deg=args.tolerance_deg,
        t_final=args.t_final,
        parameters=args.parameters,
        ranges=tuple(args.ranges),
    )
    result = tune(settings, args.out, resume=args.resume, progress=args.progress)
    print(result.to_text())
    print(f"wrote {len(result.paths)} files to {args.out}", file=sys.stderr)
    return 0
