"""``fsmctl tune``: search a law's declared parameters for designs that work under the scenario's actuator limits.

The library is :mod:`fsmctl.studies.tune` (:func:`~fsmctl.studies.tune.tune`); this module only reads the options,
states first what it searches and why (:func:`~fsmctl.studies.tune.search_space_lines`, on stderr), prints the
outcome and counts the files written to ``DIR`` (``TuneResult.paths``: ``study.log``, ``trials.csv``,
``pareto.csv``, ``pareto.png``, ``best.toml`` when a design is feasible, ``tune.json``).  ``--workers`` and ``--dask`` choose where a batch's candidates are
flown (the results do not depend on them); ``--batch``, ``--pruner`` and ``--constraints`` are part of the study.

Exit codes (:data:`EXIT_CODES`, :mod:`fsmctl.cli.exit_codes`): 0 the search finished and the files were written
(also when no design is feasible: the files say so), 2 usage or input error (one line on stderr), 130 interrupted
by SIGINT (Ctrl-C), 143 terminated by SIGTERM; the journal keeps every told trial and ``--resume`` continues.
"""

from __future__ import annotations

import argparse
import sys

from fsmctl.cli.exit_codes import epilog
from fsmctl.cli.options import (
    add_case_option,
    add_out_option,
    add_progress_option,
    add_scenario_option,
    add_seed_option,
    add_t_final_option,
    add_tolerance_deg_option,
)
from fsmctl.cli.parallel_options import add_dask_options, add_workers_option, chosen_workers
from fsmctl.cli.types import positive_int
from fsmctl.policy import STEADY_WINDOW_FRACTION, STEADY_WINDOW_MAX_S, TOLERANCE_DEG, TUNE_BATCH

__all__ = ["add_parser", "run", "EXIT_CODES"]

EXIT_CODES = {
    0: "the search finished and the files were written (also when no design is feasible: the files say so)",
    130: "interrupted (SIGINT, Ctrl-C): the journal keeps every told trial, --resume continues",
    143: "terminated (SIGTERM): as for 130",
}
"""What ``fsmctl tune``'s exit codes mean where they differ from :data:`fsmctl.cli.exit_codes.MEANINGS`."""

EPILOG_TEXT = f"""objectives (all minimised; --objectives a,b,...; aggregated over the ensemble by --quantile):

- aaem_settling, raem_settling (s): settling time of AAEM (eq 42) / RAEM (eq 43) to --tolerance-deg; a run that never settles within the horizon T scores T * (2 + min(1, decades of its steady error above the tolerance)), i.e. 2 T to 3 T: trials.csv leaves its settling time empty and gives the score in NAME_score, the summary says "not settled".
- aaem_steady, raem_steady (deg): max over the steady window (last {100 * STEADY_WINDOW_FRACTION:g} % of T, at most {STEADY_WINDOW_MAX_S:g} s)
- peak_torque, rms_torque (N m)
- chattering (N m/s): total variation of u per second
- wheel_momentum (N m s): peak wheel momentum (scenarios with reaction wheels)
- messages (1): messages sent by all agents over the run (needs a control period; an event-triggered law such as fsm_event sends fewer than one per agent and control instant): trade it against an accuracy objective, e.g. --objectives aaem_steady,messages

constraints (--constraints a,b,...; default: every one that applies; a trial is feasible when all are <= 0):

- converged (s): max(AAEM, RAEM settling time) - T: both settle within the horizon (--quantile member)
- theorem1 (1): fsm law: 0 when Theorem 1 (eqs 25-27, balanced time-varying eta) holds for the scenario's topology with the candidate's coupling weights over T, else 1 + max over links of (k^j - k^i)
- theorem2 (1/s^2): fsm law: max over agents, axes and members of (required delta - delta), the requirement of Theorem 2 at the reference (fsmctl prove theorem2-delta: along the reference trajectory and under the disturbance/reference bounds); feasible when delta covers it
- torque (N m): scenarios with a torque limit: the largest commanded (unsaturated) torque component after the transient (from the later AAEM/RAEM settling time; the steady window if unsettled) minus the limit: saturating during the transient is allowed, needing more than the limit once converged is not
- wheels (1): scenarios with reaction wheels and a max_speed: peak wheel momentum / (J_s max_speed) - 0.99

search space (stated first, on stderr: each parameter, its range and where the range comes from): every tunable
numeric parameter of the law (fsmctl laws lists them; --parameters chooses) within its declared range, and for the fsm law the coupling weights as two factors k_i_scale (on every k^i_ij) and k_j_scale
(on every k^j_ij(t) value), default range 0.1..10; a side the law leaves unbounded needs --range NAME=LOW,HIGH.
Ranges with LOW > 0 and HIGH/LOW >= 100 are searched log-uniformly; a vector parameter (delta) is one value for every
axis and agent.  best.toml holds the scaled [topology] weights.

pruning (--pruner; one objective only): each candidate is judged at 9 checkpoints (every T/10 of simulated time) by
an estimate of its first objective from the run so far (a settling time once settled, else T (2 + decades of the
current error above the tolerance); the other objectives' values so far); median = Optuna's
MedianPruner(n_startup_trials=5, n_warmup_steps=2), halving = SuccessiveHalvingPruner(min_resource=1,
reduction_factor=3); a pruned run is stopped there and its trial is PRUNED (counted in --budget, never feasible).
The pruner sees only the trials told before the candidate's batch.

determinism: trials are proposed, flown and told in batches of --batch (part of the study; trial i is proposed by a
sampler seeded from (--seed, i)), so the same options give the same trials whatever --workers or --dask; an
interrupted search continues with --resume exactly as if it had not been interrupted (raising --budget continues
exactly when the former budget was a multiple of --batch)."""


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
        "DIR/study.log (the journal), trials.csv, pareto.csv, pareto.png, best.toml (a scenario file for fsmctl "
        "simulate; when a design is feasible) and tune.json.",
        epilog=epilog(EXIT_CODES, text=EPILOG_TEXT),
    )
    add_scenario_option(p)
    add_case_option(p)
    p.add_argument(
        "--law",
        required=True,
        metavar="NAME|FILE.py|DIR",
        help="the law to tune: a built-in name (fsmctl laws), a derivation script or a derived folder",
    )
    p.add_argument("--budget", type=positive_int, default=50, metavar="N", help="trials in total (default: 50)")
    add_seed_option(p, "the search and the ensemble")
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
        help="parameters to search (default: every tunable numeric parameter of the law, and for fsm the coupling "
        "factors k_i_scale,k_j_scale)",
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
    add_tolerance_deg_option(p, "settling tolerance of AAEM and RAEM", TOLERANCE_DEG)
    add_t_final_option(p)
    p.add_argument(
        "--constraints",
        type=_names,
        default=(),
        metavar="A,B,...",
        help="constraints to apply: converged, theorem1, theorem2, torque, wheels (default: every one that applies to "
        "the law and scenario; see below)",
    )
    p.add_argument(
        "--pruner",
        choices=("auto", "none", "median", "halving"),
        default="auto",
        help="stop hopeless candidates early: auto = median with one objective, none with several (default: auto)",
    )
    p.add_argument(
        "--batch",
        type=positive_int,
        default=TUNE_BATCH,
        metavar="B",
        help=f"trials proposed, flown in parallel and told together; part of the study (default: {TUNE_BATCH})",
    )
    add_workers_option(p, what="local worker processes flying a batch, 1 = in this process")
    add_dask_options(p, what="the batches")
    add_out_option(p, "tune")
    p.add_argument("--resume", action="store_true", help="continue the study in DIR to --budget trials in total")
    add_progress_option(p, "over the trials")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run ``fsmctl tune``; bad input raises :class:`fsmctl.errors.InputError` (one line, exit 2).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of :func:`add_parser`.

    Returns
    -------
    int
        0, or ``CampaignInterrupted.exit_code`` (130 for SIGINT, 143 for SIGTERM) after one line on stderr.
    """
    from fsmctl.parallel import CampaignInterrupted
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
        batch=args.batch,
        pruner=args.pruner,
        constraints=args.constraints,
    )
    try:
        result = tune(
            settings,
            args.out,
            resume=args.resume,
            progress=args.progress,
            workers=chosen_workers(args),
            dask=args.dask,
            dask_timeout=args.dask_timeout,
            command=getattr(args, "argv", None) or ["fsmctl", *sys.argv[1:]],
        )
    except CampaignInterrupted as exc:  # the workers are stopped; one line, exit 130 (SIGINT) or 143 (SIGTERM)
        print(f"fsmctl tune: {exc}", file=sys.stderr, flush=True)
        return exc.exit_code
    print(result.to_text())
    print(f"wrote {len(result.paths)} files to {args.out}", file=sys.stderr)  # every file written, study.log included
    return 0
