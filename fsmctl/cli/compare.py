"""``fsmctl compare``: fly several laws (or settings of one law) on one scenario and compare their metrics.

The library is :mod:`fsmctl.studies.compare` (:func:`~fsmctl.studies.compare.compare_laws`); this module only
reads the options, prints the table and writes ``DIR/comparison.{csv,json,md,png,svg}``.  ``--control-period`` and
``--seed`` (:mod:`fsmctl.cli.run_options`) set the scenario's sampled control and noise seed for every run, so the
laws meet the same sensor noise and packet losses.

Exit codes: 0 every run finished, 1 a run's simulation failed (the others are still reported and written),
2 usage or input error (one line on stderr).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from fsmctl.cli.run_options import add_run_options, simulation_changes
from fsmctl.cli.types import positive_float, positive_int, torque_limit

__all__ = ["add_parser", "run"]

EPILOG = """runs file (TOML), for variants of a law:
  [[run]]
  label = "TSM"
  law = "fsm"
  parameters = { surface = "tsm", c2 = 0.8 }
  controller = { torque_limit = "inf" }

metrics: settling times of AAEM (eq 42) and RAEM (eq 43) to each tolerance (first time after which the metric
stays within it; "not settled" within the horizon), steady mean/max over the last window, peak applied and
commanded |u_k|, RMS torque, effort sum_i int sum_k |u_ik| dt, chattering = total variation of u (engine, every
step), saturated time, wall time.

exit codes: 0 every run finished, 1 a simulation failed (the other runs are still written), 2 usage or input error."""


def _tolerances(text: str) -> tuple[float, ...]:
    items = [x for x in text.split(",") if x.strip()]
    if not items:
        raise argparse.ArgumentTypeError(f"expected comma-separated tolerances in deg, got {text!r}")
    return tuple(positive_float(x.strip()) for x in items)


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``fsmctl compare`` (laws or law settings side by side on one scenario).

    Parameters
    ----------
    subparsers : argparse subparsers action
        From :func:`fsmctl.cli.main.build_parser`.

    Returns
    -------
    argparse.ArgumentParser
        The ``compare`` parser, with ``func = run``.
    """
    p = subparsers.add_parser(
        "compare",
        help="compare laws (or settings of one law) on one scenario: settling, accuracy, torque, chattering",
        description="Simulate one scenario case with each law (or law variant) and compare settling times, steady "
        "accuracy, torque, control effort, chattering and saturation; print the table and write "
        "DIR/comparison.csv, .json, .md and a figure (PNG + SVG).",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--scenario",
        default="paper",
        metavar="paper|FILE.toml",
        help="built-in 'paper' or a TOML file (default: paper)",
    )
    p.add_argument("--case", default=None, help="case name (paper: 1, 2, 3a, 3b, 3c; default: the file's first case)")
    p.add_argument(
        "--laws",
        default=None,
        metavar="L1,L2,...",
        help="laws to compare, comma-separated: built-in names (fsmctl laws), derivation scripts FILE.py, derived folders",
    )
    p.add_argument(
        "--runs-file",
        type=Path,
        default=None,
        metavar="RUNS.toml",
        help="[[run]] tables (label, law, parameters, controller) for variants of a law; added after --laws",
    )
    p.add_argument(
        "--torque-limit",
        type=torque_limit,
        default=None,
        metavar="N_M|inf",
        help="per-axis torque bound of the scenario (a run's own controller override wins)",
    )
    p.add_argument(
        "--with-and-without-limit",
        action="store_true",
        help="fly each run twice: with the (scenario's or --torque-limit) limit and without a limit",
    )
    p.add_argument(
        "--out", type=Path, default=Path("comparison"), metavar="DIR", help="output folder (default: ./comparison)"
    )
    p.add_argument("--no-figures", action="store_true", help="skip the PNG/SVG figure")
    g = p.add_argument_group("simulation and metrics")
    g.add_argument("--t-final", type=positive_float, metavar="S", help="horizon in s (default: the scenario's)")
    g.add_argument("--dt", type=positive_float, metavar="S", help="integration step in s (default: the scenario's)")
    g.add_argument("--output-interval", type=positive_float, metavar="S", help="output sample spacing in s")
    add_run_options(g)  # every run flies the same control period and the same noise (a fair comparison)
    g.add_argument(
        "--tolerances",
        type=_tolerances,
        default=None,
        metavar="DEG,...",
        help="AAEM/RAEM settling tolerances in deg (default: 1,0.1,0.01)",
    )
    g.add_argument(
        "--steady-window",
        type=positive_float,
        default=None,
        metavar="S",
        help="final window of the steady statistics (default: last 40%% of the horizon, at most 40 s)",
    )
    g.add_argument("--workers", type=positive_int, default=1, metavar="N", help="simultaneous runs (default: 1)")
    g.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bar over the runs (default: on a terminal)",
    )
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run ``fsmctl compare``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options.

    Returns
    -------
    int
        0 when every run finished and the files were written, 1 when a simulation failed; bad input raises
        :class:`fsmctl.errors.InputError` (one line, exit 2).
    """
    from fsmctl.errors import InputError as UsageError  # one line, exit 2
    from fsmctl.model.scenario import load_scenario
    from fsmctl.outputs import output_folder
    from fsmctl.studies.compare import (
        DEFAULT_TOLERANCES_DEG,
        LawRun,
        compare_laws,
        read_runs_file,
        with_and_without_limit,
    )

    runs: list = []
    if args.laws is not None:
        specs = [x.strip() for x in args.laws.split(",")]
        if not any(specs) or not all(specs):
            raise UsageError(f"--laws: expected comma-separated law names or paths, got {args.laws!r}")
        runs += [LawRun.from_spec(x) for x in specs]
    if args.runs_file is not None:
        runs += read_runs_file(args.runs_file)
    if not runs:
        raise UsageError("nothing to compare: give --laws L1,L2,... and/or --runs-file RUNS.toml")
    scenario = load_scenario(args.scenario, case=args.case)
    simulation = {
        k: v
        for k, v in (("t_final", args.t_final), ("dt", args.dt), ("output_interval", args.output_interval))
        if v is not None
    }
    sampled = simulation_changes(args)  # --control-period, --seed
    simulation |= sampled
    if "t_final" in simulation and "output_interval" not in simulation:
        simulation["output_interval"] = min(scenario.simulation.output_interval, simulation["t_final"])
    controller = {} if args.torque_limit is None else {"torque_limit": args.torque_limit}
    scenario = scenario.replace(controller=controller, simulation=simulation)
    if args.with_and_without_limit:
        limit = scenario.controller.torque_limit
        if not math.isfinite(limit):
            raise UsageError(
                "--with-and-without-limit needs a finite torque limit: the scenario has none, give --torque-limit N_M"
            )
        runs = with_and_without_limit(runs, limit)
    progress = sys.stderr.isatty() if args.progress is None else args.progress
    if sampled:
        sim = scenario.simulation
        print(
            f"compare: every run with control_period={sim.control_period:g} s, seed={sim.seed} (--control-period, --seed)"
        )
    with output_folder(args.out) as out:
        comparison = compare_laws(
            scenario,
            runs,
            tolerances_deg=args.tolerances or DEFAULT_TOLERANCES_DEG,
            steady_window_s=args.steady_window,
            workers=args.workers,
            progress=progress,
        )
        paths = comparison.save(out, figures=not args.no_figures)
    print(comparison.to_text())
    print(f"wrote {len(paths)} files to {out}", file=sys.stderr)
    for label, reason in comparison.failures:
        print(f"fsmctl compare: run {label!r} failed: {reason}", file=sys.stderr)
    return 1 if comparison.failures else 0
