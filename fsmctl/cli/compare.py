"""``fsmctl compare``: fly several laws (or settings of one law) on one scenario and compare their metrics.

The library is :mod:`fsmctl.studies.compare` (:func:`~fsmctl.studies.compare.compare_laws`); this module only
reads the options, prints the table and writes ``DIR/comparison.{csv,json,md,png,svg}``.  ``--control-period`` and
``--seed`` (:mod:`fsmctl.cli.run_options`) set the scenario's sampled control and noise seed for every run, so the
laws meet the same sensor noise and packet losses.

Exit codes (:data:`EXIT_CODES`, :mod:`fsmctl.cli.exit_codes`): 0 every run finished, 1 a run's simulation failed
(the others are still reported and written), 2 usage or input error (one line on stderr).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from fsmctl.cli.exit_codes import epilog
from fsmctl.cli.options import (
    STEADY_WINDOW_TEXT,
    add_case_option,
    add_dt_option,
    add_figures_option,
    add_out_option,
    add_output_interval_option,
    add_progress_option,
    add_scenario_option,
    add_steady_window_option,
    add_t_final_option,
    add_torque_limit_option,
)
from fsmctl.cli.parallel_options import add_workers_option, chosen_workers
from fsmctl.cli.run_options import add_run_options, simulation_changes
from fsmctl.cli.types import positive_float
from fsmctl.policy import COMPARISON_TOLERANCES_DEG

__all__ = ["add_parser", "run", "EXIT_CODES"]

EXIT_CODES = {
    0: "every run finished and the files were written",
    1: "a run's simulation failed (the other runs are still reported and written)",
}
"""What ``fsmctl compare``'s exit codes 0 and 1 mean (the others: :data:`fsmctl.cli.exit_codes.MEANINGS`)."""

EPILOG_TEXT = """runs file (TOML), for variants of a law::

  [[run]]
  label = "TSM"
  law = "fsm"
  parameters = { surface = "tsm", c2 = 0.8 }
  controller = { torque_limit = "inf" }

metrics: settling times of AAEM (eq 42) and RAEM (eq 43) to each tolerance (first time after which the metric
stays within it; "not settled" within the horizon), steady mean/max over the last window, peak applied and
commanded torque component, RMS torque, effort sum_i int sum_k abs(u_ik) dt, chattering = total variation of u (engine, every
step), saturated time, messages sent (all agents; per agent per second; n/a for continuous control), wall time."""


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
        epilog=epilog(EXIT_CODES, text=EPILOG_TEXT),
    )
    add_scenario_option(p)
    add_case_option(p)
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
    add_torque_limit_option(p, "a run's own controller override wins")
    p.add_argument(
        "--with-and-without-limit",
        action="store_true",
        help="fly each run twice: with the (scenario's or --torque-limit) limit and without a limit",
    )
    add_out_option(p, "comparison")
    add_figures_option(p)
    g = p.add_argument_group("simulation and metrics")
    add_t_final_option(g)
    add_dt_option(g)
    add_output_interval_option(g)
    add_run_options(g)  # every run flies the same control period and the same noise (a fair comparison)
    g.add_argument(
        "--tolerances",
        type=_tolerances,
        default=None,
        metavar="DEG,...",
        help=f"AAEM/RAEM settling tolerances in deg (default: {','.join(f'{t:g}' for t in COMPARISON_TOLERANCES_DEG)})",
    )
    add_steady_window_option(g, None, STEADY_WINDOW_TEXT)
    add_workers_option(g, what="worker threads flying the runs")
    add_progress_option(g, "over the runs")
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
    from fsmctl.studies.compare import compare_laws
    from fsmctl.studies.compare_runs import LawRun, read_runs_file, with_and_without_limit

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
    if simulation.get("t_final", 0) > 0 and "output_interval" not in simulation:
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
            tolerances_deg=args.tolerances or COMPARISON_TOLERANCES_DEG,
            steady_window_s=args.steady_window,
            workers=chosen_workers(args),
            progress=progress,
        )
        paths = comparison.save(out, figures=not args.no_figures)
    print(comparison.to_text())
    print(f"wrote {len(paths)} files to {out}", file=sys.stderr)
    for label, reason in comparison.failures:
        print(f"fsmctl compare: run {label!r} failed: {reason}", file=sys.stderr)
    return 1 if comparison.failures else 0
