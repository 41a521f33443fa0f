"""``fsmctl compare-surfaces``: FSM vs TSM vs LSM (:mod:`fsmctl.studies.surfaces`) from the command line.

Liang et al. 2012, Theorem 3 (eqs 34-41): the scalar sliding mode against the closed forms, and the
formation loop with and without the torque limit, the inertia uncertainty/disturbance and the coupling.

Exit codes (:data:`EXIT_CODES`, :mod:`fsmctl.cli.exit_codes`): 0 the tables and files were written, 2 usage or
input error.
"""

from __future__ import annotations

import argparse
import sys

from fsmctl.cli.exit_codes import epilog
from fsmctl.cli.options import (
    add_case_option,
    add_figures_option,
    add_out_option,
    add_scenario_option,
    add_t_final_option,
)
from fsmctl.cli.parallel_options import add_workers_option, chosen_workers
from fsmctl.policy import SURFACE_METRIC_TOLERANCE, SURFACE_REACH_THRESHOLD, SURFACE_SIGMA_TOLERANCE

__all__ = ["add_parser", "run", "EXIT_CODES"]

EXIT_CODES = {0: "the table was printed and the files were written"}
"""What ``fsmctl compare-surfaces``' exit code 0 means (the others: :data:`fsmctl.cli.exit_codes.MEANINGS`)."""


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``fsmctl compare-surfaces`` (FSM vs TSM vs LSM, Liang et al. 2012, Theorem 3, eqs 34-41).

    Parameters
    ----------
    subparsers : argparse subparsers action
        From :func:`fsmctl.cli.main.build_parser`.

    Returns
    -------
    argparse.ArgumentParser
        The parser, with ``func = run``.
    """
    p = subparsers.add_parser(
        "compare-surfaces",
        help="FSM vs TSM vs LSM: Theorem 3 in the scalar case and in the full loop",
        description="Compare the fast, terminal and linear sliding surfaces (Liang et al. 2012, Theorem 3) in the scalar "
        "sliding mode (simulation vs eqs 34-36) and in the formation loop, with and without the torque limit, the "
        "inertia uncertainty/disturbance and the coupling.",
        epilog=epilog(EXIT_CODES),
    )
    add_scenario_option(p)
    add_case_option(p)
    add_out_option(p, "compare-surfaces")
    p.add_argument("--fast", action="store_true", help="10 s horizon at dt = 2 ms and a small scalar grid")
    add_t_final_option(p)
    p.add_argument("--reach-threshold", type=float, default=SURFACE_REACH_THRESHOLD, metavar="S",
                   help=f"||s_i|| below which the surface counts as reached (default: {SURFACE_REACH_THRESHOLD:g})")  # fmt: skip
    p.add_argument("--sigma-tolerance", type=float, default=SURFACE_SIGMA_TOLERANCE, metavar="TAU",
                   help="Theorem 3 target: every MRP component sigma_e,k within [-TAU, TAU] "
                   f"(default: {SURFACE_SIGMA_TOLERANCE:g})")  # fmt: skip
    p.add_argument("--metric-tolerance", type=float, default=SURFACE_METRIC_TOLERANCE, metavar="DEG",
                   help=f"AAEM/RAEM settling tolerance in deg (default: {SURFACE_METRIC_TOLERANCE:g})")  # fmt: skip
    add_workers_option(p, what="worker threads flying the variants")
    add_figures_option(p)
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run ``fsmctl compare-surfaces``: print the table, write CSV/JSON/figures.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options.

    Returns
    -------
    int
        0 when the files were written; bad input raises :class:`fsmctl.errors.InputError` (exit 2), an unusable
        output folder :class:`fsmctl.errors.EnvironmentProblem` (exit 2).
    """
    from fsmctl.model.scenario import load_scenario
    from fsmctl.outputs import output_folder

    scenario = load_scenario(args.scenario, case=args.case)
    with output_folder(args.out):  # checked before the runs; removed again if nothing gets written
        return _compare(args, scenario)


def _compare(args: argparse.Namespace, scenario) -> int:
    import numpy as np

    from fsmctl.outputs import atomic_path, environment_problem
    from fsmctl.studies.surfaces import compare_surfaces
    from fsmctl.studies.theorem3 import plot_settling_time_against_initial_error, write_scalar_study_csv

    comp = compare_surfaces(
        scenario,
        fast=args.fast,
        t_final=args.t_final,
        reach_threshold=args.reach_threshold,
        sigma_tolerance=args.sigma_tolerance,
        metric_tolerance_deg=args.metric_tolerance,
        workers=chosen_workers(args),
    )
    try:
        paths = comp.write(args.out, figures=not args.no_figures)
        if comp.scalar_study is not None:
            paths.append(write_scalar_study_csv(comp.scalar_study, args.out / "theorem3_scalar.csv"))
        if not args.no_figures:
            flown = scenario.replace(controller={"law": "fsm"}).law_parameters()[0]  # compare-surfaces flies fsm
            c1, c2, alpha = (float(flown[name]) for name in ("c1", "c2", "alpha"))
            initial = np.geomspace(2 * args.sigma_tolerance, 1.0, 6 if args.fast else 12)
            fig = plot_settling_time_against_initial_error(c1, c2, alpha, args.sigma_tolerance, initial)
            for ext in ("png", "svg"):
                with atomic_path(args.out / f"theorem3_scalar.{ext}") as tmp:
                    fig.savefig(tmp, dpi=120, format=ext)
                paths.append(args.out / f"theorem3_scalar.{ext}")
    except OSError as exc:
        raise environment_problem("write to", args.out, exc) from None
    print(comp.table())
    print(f"wrote {len(paths)} files to {args.out}", file=sys.stderr)
    return 0
