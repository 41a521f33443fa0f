"""``fsmctl montecarlo``: robustness campaigns (:mod:`fsmctl.studies.montecarlo`) from the command line.

Every sampling range of :class:`~fsmctl.studies.montecarlo.CampaignSettings` is an option whose ``--help``
shows the default; ``--law``/``--set`` fly another control law or other law parameters
(:mod:`fsmctl.cli.law_options`).  Flight hardware: ``--control-period`` (:mod:`fsmctl.cli.run_options`) sets the
base scenario's control period, ``--link-delay``, ``--loss-probability`` and ``--sensor-noise-scale LOW,HIGH``
sample the hardware, and ``--vary noise`` runs the base scenario over noise seeds only (every run has its own
``simulation.seed``, derived from ``--seed``).

Exit codes (:data:`EXIT_CODES`, :mod:`fsmctl.cli.exit_codes`): 0 every run finished, 1 some run failed (they are
listed), 2 usage or input error, 130 interrupted (SIGINT), 143 terminated (SIGTERM); finished chunks are kept and
``--resume`` continues.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from collections.abc import Iterable
from dataclasses import replace

from fsmctl.cli.exit_codes import epilog
from fsmctl.cli.law_options import add_law_options, law_changes
from fsmctl.cli.options import (
    add_case_option,
    add_dt_option,
    add_figures_option,
    add_out_option,
    add_output_interval_option,
    add_progress_option,
    add_scenario_option,
    add_seed_option,
    add_steady_window_option,
    add_t_final_option,
    add_tolerance_deg_option,
    add_torque_limit_option,
)
from fsmctl.cli.parallel_options import add_dask_options, add_workers_option, chosen_workers
from fsmctl.cli.run_options import add_run_options
from fsmctl.cli.types import finite_or_inf_float, number_range, positive_int
from fsmctl.policy import steady_window_text
from fsmctl.studies.montecarlo import (
    COMPLETE_MARKER,
    HARDWARE_RANGES,
    SAMPLING_RANGES,
    VARY,
    CampaignInterrupted,
    CampaignResult,
    CampaignSettings,
)

__all__ = ["add_parser", "run", "report_lines", "EXIT_CODES"]

EXIT_CODES = {
    0: "every run finished and the files were written",
    1: "some run failed (they are listed; the others are written)",
    130: "interrupted (SIGINT, Ctrl-C): the workers are stopped, finished chunks are kept, --resume continues",
    143: "terminated (SIGTERM): as for 130",
}
"""What ``fsmctl montecarlo``'s exit codes mean where they differ from :data:`fsmctl.cli.exit_codes.MEANINGS`."""


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``fsmctl montecarlo`` (every sampling range is an option; ``--help`` shows the defaults).

    Parameters
    ----------
    subparsers : argparse subparsers action
        From :func:`fsmctl.cli.main.build_parser`.

    Returns
    -------
    argparse.ArgumentParser
        The ``montecarlo`` parser, with ``func = run``.
    """
    p = subparsers.add_parser(
        "montecarlo",
        help="robustness campaign: random inertia, disturbances, initial attitudes/rates and topologies",
        description=(
            "Monte Carlo campaign over random Delta_J (SPD, realizable, <= rho J0), disturbance amplitudes and phases, "
            "initial attitudes uniform over SO(3) and bounded rates, and random switching topologies (Liang et al. 2012). "
            "Writes OUT/montecarlo.nc, OUT/summary.json, OUT/histograms.png/.svg, one file per chunk (resumable) and, "
            "last, OUT/complete.json. The settings are printed first and stored in the outputs. "
            "Ctrl-C (SIGINT) or SIGTERM stops the workers and keeps the finished chunks; exit code 130 (SIGINT) or "
            "143 (SIGTERM); --resume continues."
        ),
        epilog=epilog(
            EXIT_CODES,
            text="--resume continues a campaign in --out: the finished chunks are kept and the remaining runs flown; "
            "its settings (campaign.json) must be the same, or it is refused (exit 2).",
        ),
    )
    d = CampaignSettings()
    add_scenario_option(p, default=d.scenario)
    add_case_option(p)
    p.add_argument("--runs", type=positive_int, default=d.runs, metavar="N", help=f"number of runs (default: {d.runs})")
    add_workers_option(p, what="local worker processes flying the chunks")
    add_seed_option(p, "the campaign; every run's perturbations and its noise seed (simulation.seed) derive from it")
    p.add_argument(
        "--vary",
        choices=VARY,
        default=d.vary,
        help="'all': every run draws the sampling ranges below and its own noise seed; 'noise': every run is the "
        f"base scenario with only its noise seed (sensor noise, packet losses) changed (default: {d.vary})",
    )
    add_dask_options(p, what="the campaign's chunks")
    add_out_option(p, "montecarlo_out")
    p.add_argument("--resume", action="store_true", help="continue the campaign already in --out")
    p.add_argument(
        "--chunk-size",
        type=positive_int,
        default=d.chunk_size,
        metavar="N",
        help=f"runs per chunk file (default: {d.chunk_size}); a chunk's runs fly together in one compiled loop "
        "(fsmctl.simulate_many), each with the results of its run alone",
    )
    add_t_final_option(p)
    add_dt_option(p)
    add_output_interval_option(p, d.output_interval, "lowered to the largest multiple of dt dividing t_final")
    add_torque_limit_option(p)
    add_run_options(p, seed=False)  # --control-period; --seed is the campaign's
    add_law_options(p, what="every run")  # before the sampling ranges: their group ends the help
    hardware = p.add_argument_group(
        "hardware sampling ranges (default: the scenario's values; links need a control period, the noise scale "
        "[sensors])"
    )
    for name, text in HARDWARE_RANGES:
        hardware.add_argument(
            "--" + name.replace("_", "-"),
            type=number_range,
            default=None,
            metavar="LOW,HIGH",
            help=_help_text(text),
        )
    sampling = p.add_argument_group("sampling ranges (every run draws from these)")
    for name, text in SAMPLING_RANGES:
        sampling.add_argument(
            "--" + name.replace("_", "-"),
            type=finite_or_inf_float,
            default=getattr(d, name),
            help=_help_text(text) + f" (default: {getattr(d, name)})",
        )
    add_tolerance_deg_option(
        p, "converged: AAEM and RAEM stay at or below it until the end of the run", d.tolerance_deg
    )
    add_steady_window_option(p, d.steady_window)
    add_figures_option(p)
    add_progress_option(p, "over the runs")
    p.set_defaults(func=run)
    return p


def _help_text(text: str) -> str:
    """A sampling range's description (:mod:`fsmctl.studies.montecarlo`) as option help: ``%`` escaped for argparse,
    ``|x|`` written ``abs(x)`` (the documentation renders help as reStructuredText, where ``|x|`` is markup)."""
    return re.sub(r"\|([^|\s][^|]*?)\|", r"abs(\1)", text).replace("%", "%%")


def _print_now(line: str) -> None:
    print(line, flush=True)


def run(args: argparse.Namespace) -> int:
    """Run ``fsmctl montecarlo``: print the settings, run (or resume) the campaign, print its summary.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options.

    Returns
    -------
    int
        0 when every run finished, 1 when some failed, ``CampaignInterrupted.exit_code`` (130 or 143) when
        interrupted; bad input raises :class:`fsmctl.errors.InputError` (exit 2).
    """
    from fsmctl.studies.montecarlo import campaign_base, describe_campaign, run_campaign

    settings = CampaignSettings(
        scenario=args.scenario,
        case=args.case,
        runs=args.runs,
        seed=args.seed,
        chunk_size=args.chunk_size,
        t_final=args.t_final,
        dt=args.dt,
        output_interval=args.output_interval,
        torque_limit=args.torque_limit,
        tolerance_deg=args.tolerance_deg,
        steady_window=args.steady_window,
        **{name: getattr(args, name) for name, _ in SAMPLING_RANGES},
        vary=args.vary,
        control_period=args.control_period,
        **{name: getattr(args, name) for name, _ in HARDWARE_RANGES},
    )
    base, log = None, _print_now
    if args.law is not None or args.law_set:
        # the law and its parameters are part of the campaign's settings (campaign.json): --resume checks them
        settings.validate()
        law, parameters, own = law_changes(args)
        changes = {**own, **parameters} | ({"law": _portable_law(law)} if law is not None else {})
        settings = replace(settings, controller=json.dumps(changes, sort_keys=True))
        settings, base = campaign_base(settings)
        for line in describe_campaign(settings, base):
            _print_now(line)
        law = base.law
        given = ", ".join(f"{k}={v}" for k, v in dict(base.controller.parameters).items())
        _print_now(f"  law: {law.name} ({law.folder})" + (f", parameters {given}" if given else "") + " (--law, --set)")
        log = None
    try:
        result = run_campaign(
            settings,
            args.out,
            workers=chosen_workers(args),
            dask=args.dask,
            resume=args.resume,
            progress=args.progress,
            figures=not args.no_figures,
            log=log,
            dask_timeout=args.dask_timeout,
            base=base,
            command=getattr(args, "argv", None) or ["fsmctl", *sys.argv[1:]],
        )
    except CampaignInterrupted as exc:  # the workers are stopped; one line, exit 130 (SIGINT) or 143 (SIGTERM)
        print(f"fsmctl montecarlo: {exc}", file=sys.stderr, flush=True)
        return exc.exit_code
    for line in report_lines(result):
        print(line)
    return 0 if not result.failed_runs else 1


def _portable_law(text: str) -> str:
    """A built-in name as it is; a script or folder as the absolute folder of its generated code.

    The workers (other processes, possibly a Dask cluster sharing the file system) then load the code
    without deriving the script again, whatever their working folder.
    """
    from fsmctl.model.laws import resolve_law

    law = resolve_law(text)
    return law.name if law.builtin else str(law.folder)


def report_lines(result: CampaignResult) -> Iterable[str]:
    """The campaign's summary as printed by ``fsmctl montecarlo``.

    Parameters
    ----------
    result : CampaignResult
        From :func:`fsmctl.studies.montecarlo.run_campaign`.

    Yields
    ------
    str
        One line at a time: counts, convergence and theorem fractions, medians, failures, files.
    """
    s = result.summary
    st = s["statistics"]

    def med(k: str) -> str:
        e = st[k]
        return f"median {e['median']:.4g} [p5 {e['p5']:.4g}, p95 {e['p95']:.4g}]" if e["finite"] else "no finite value"

    yield f"montecarlo: {s['runs']} runs in {result.wall_time_s:.1f} s ({result.resumed_chunks} chunks resumed): {s['ok']} ok, {s['failed']} failed, {s['worker_died']} worker died"
    theorems = (
        f"Theorem 1 held: {s['theorem1_holds_fraction']:.1%}; "
        f"Theorem 2 at the reference held: {s['theorem2_at_reference_holds_fraction']:.1%}"
        if s["paper_theorems"]
        else f"Theorems 1-2: not applicable (they are the paper's law's conditions; the law {s['law']} does not "
        "declare it is eqs 13-19)"
    )
    yield f"  converged (AAEM and RAEM stay <= {s['tolerance_deg']:g} deg until the end): {s['converged_fraction']:.1%}; {theorems}"
    settling = st["aaem_settling_s"]
    never = f"{settling['nan']} of {s['ok']} runs never settled"
    yield (
        f"  AAEM settling: {med('aaem_settling_s')} s ({never})" if settling["finite"] else f"  AAEM settling: {never}"
    )
    window = steady_window_text(s["steady_window_s"], s["horizon_s"])
    yield f"  AAEM steady max (over {window}): {med('aaem_steady_max_deg')} deg; max |u_unsat|: {med('u_unsaturated_max_N_m')} N m; saturation time: {med('saturated_time_max_s')} s"
    for f in s["failures"][:10]:
        yield f"  run {f['run']}: {f['status']}: {f['message']}"
    if len(s["failures"]) > 10:
        yield f"  ... {len(s['failures']) - 10} more in summary.json"
    yield f"  wrote {result.out_dir}/montecarlo.nc, summary.json, histograms.png/.svg, {COMPLETE_MARKER}"
