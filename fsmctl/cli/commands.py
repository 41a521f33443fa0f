"""``fsmctl simulate``: run one scenario case and write its results (Liang, Sun & Wang 2012, Section 4).

Writes ``DIR/<label>.nc`` (``--format netcdf``, the default: compressed NetCDF-4, units in the variable names and
attributes) or ``DIR/<label>.csv`` (``--format csv``: one row per output time, one named column per signal with
its unit), in double or, with ``--precision float32``, single precision; ``DIR/summary.json`` (the result line,
settling times of AAEM eq 42 and RAEM eq 43, steady-state accuracy, torque statistics, the scenario's settings and
documented choices) and, unless ``--no-figures``, ``DIR/<label>_{aaem,raem,theta_e,torques}.{png,svg}`` (analogues of
Figs 1-4).  Every result file embeds the full scenario, the law, the versions and the command line
(:mod:`fsmctl.simulation.results_io`), so ``--from RESULT`` flies it again (instead of ``--scenario``/``--case``;
the other options still override it, and the summary records them).

``--law NAME|FILE.py|DIR`` flies another control law and ``--set KEY=VALUE`` sets its parameters
(:mod:`fsmctl.cli.law_options`); ``--control-period SECONDS`` (0 = continuous) and ``--seed N`` (the run's noise
seed) set the sampled control (:mod:`fsmctl.cli.run_options`); the summary records them all.

The printed result starts with one line (:func:`convergence_line`): ``converged: AAEM <= 0.01 deg from 13.30 s on,
...`` or ``not converged: AAEM 28.7 deg at t = 40 s``, "converged" as :data:`fsmctl.policy.CONVERGED_RULE` defines
it at :data:`fsmctl.policy.TOLERANCE_DEG`; then the final values and the steady maxima over the window the policy
gives (:func:`fsmctl.policy.default_steady_window`, stated with them: "the last 16 s (40 % of the 40 s horizon)").

Exit codes (:data:`EXIT_CODES`, :mod:`fsmctl.cli.exit_codes`): 0 the run finished, 1 the simulation failed
(non-finite state, ...), 2 usage or input error (one line on stderr).
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from pathlib import Path

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
    add_t_final_option,
    add_torque_limit_option,
)
from fsmctl.cli.run_options import add_run_options, simulation_changes
from fsmctl.cli.types import nonnegative_float
from fsmctl.outputs import output_folder, write_json
from fsmctl.policy import CONVERGED_RULE, SETTLING_TOLERANCES_DEG, steady_window_text
from fsmctl.studies.wording import duration_phrase, value_range

__all__ = ["add_parser", "run", "convergence_line", "EXIT_CODES"]

EXIT_CODES = {
    0: "the run finished and its files were written",
    1: "the simulation failed (a non-finite state, ...)",
}
"""What ``fsmctl simulate``'s exit codes 0 and 1 mean (the others: :data:`fsmctl.cli.exit_codes.MEANINGS`)."""

FORMATS = {"netcdf": ".nc", "csv": ".csv"}
"""``--format`` choices and the suffix of the result file each writes."""


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``fsmctl simulate`` (one case of Liang et al. 2012, Section 4, or of a scenario file).

    Parameters
    ----------
    subparsers : argparse subparsers action
        From :func:`fsmctl.cli.main.build_parser`.

    Returns
    -------
    argparse.ArgumentParser
        The ``simulate`` parser, with ``func = run``.
    """
    p = subparsers.add_parser(
        "simulate",
        help="simulate one scenario case; write the result (NetCDF or CSV), summary.json and figures",
        description="Simulate one case of a formation scenario with the compiled generated code "
        "(Liang, Sun & Wang 2012) and write DIR/<label>.nc (or .csv), DIR/summary.json and the figures (PNG + SVG). "
        "Every result file embeds the scenario, the law, the versions and the command line: --from RESULT flies "
        "it again.",
        epilog=epilog(EXIT_CODES),
    )
    source = p.add_argument_group("what to fly (--from, or --scenario and --case)")
    add_scenario_option(source, default=None)
    add_case_option(source)
    source.add_argument(
        "--from",
        dest="from_result",
        type=Path,
        default=None,
        metavar="RESULT",
        help="fly again the scenario embedded in a result file written by fsmctl (.nc or .csv); the options below "
        "still override it",
    )
    add_out_option(p, "simulation")
    p.add_argument(
        "--format",
        choices=tuple(FORMATS),
        default="netcdf",
        help="result file: netcdf = DIR/<label>.nc (compressed NetCDF-4), csv = DIR/<label>.csv (one row per "
        "output time, one column per signal, units in the column names) (default: netcdf)",
    )
    p.add_argument(
        "--precision",
        choices=("float64", "float32"),
        default="float64",
        help="storage of the time series: float32 halves the file, time stays float64 (default: float64)",
    )
    add_figures_option(p)
    add_progress_option(p, "of the time loop")
    g = p.add_argument_group("overrides of the scenario's settings")
    add_t_final_option(g)
    add_dt_option(g)
    add_output_interval_option(g)
    g.add_argument("--integrator", choices=("rk4", "dopri45"), help="time integrator (default: the scenario's)")
    add_run_options(g)
    g.add_argument(
        "--error-model",
        choices=("paper", "exact"),
        help="controller error kinematics: eqs 7-8 (paper) or exact (default: the scenario's)",
    )
    add_torque_limit_option(g)
    g.add_argument(
        "--boundary-layer",
        type=nonnegative_float,
        metavar="PHI",
        help="boundary layer phi of sat(s/phi), 0 = sgn (Remark 7) (default: the scenario's)",
    )
    add_law_options(p, what="the formation")
    p.set_defaults(func=run)
    return p


def _file_label(label: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", label).strip("_") or "run"


def run(args: argparse.Namespace) -> int:
    """Run ``fsmctl simulate``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options (``args.argv``, set by :func:`fsmctl.cli.main.main`, is the command line the result
        file records).

    Returns
    -------
    int
        0 when the run finished and its files were written, 1 when the simulation failed;
        bad input raises :class:`fsmctl.model.scenario.ScenarioError`, :class:`fsmctl.model.laws.LawError`,
        :class:`fsmctl.simulation.results_io.ResultFileError` (``--from``) or :class:`fsmctl.cli.main.UsageError`
        (exit 2).
    """
    from fsmctl.simulation.simulator import SimulationError, simulate

    scenario = _base_scenario(args)
    law, parameters, controller = law_changes(args)  # --law, --set
    if args.boundary_layer is not None:
        parameters["boundary_layer"] = args.boundary_layer
    controller |= {
        k: v for k, v in (("error_model", args.error_model), ("torque_limit", args.torque_limit)) if v is not None
    }
    simulation = {
        k: v
        for k, v in (
            ("t_final", args.t_final),
            ("dt", args.dt),
            ("output_interval", args.output_interval),
            ("integrator", args.integrator),
        )
        if v is not None
    }
    simulation |= simulation_changes(args)  # --control-period, --seed
    t_final = simulation.get("t_final")
    if t_final is not None and t_final > 0 and "output_interval" not in simulation:
        # keep the scenario's output spacing unless it no longer fits the horizon
        interval = min(scenario.simulation.output_interval, t_final)
        simulation["output_interval"] = interval
    # the run settings first: a law switched to may need them (an event-triggered law needs a control period)
    scenario = scenario.replace(simulation=simulation).with_law(law, parameters).replace(controller=controller)
    with output_folder(args.out) as out:
        if args.from_result is not None:
            print(f"from {args.from_result}:")
        for line in scenario.describe():
            print(line)
        try:
            result = simulate(scenario, progress=args.progress)
        except SimulationError as exc:
            print(f"fsmctl simulate: {exc}", file=sys.stderr)
            return 1
        label = _file_label(scenario.label)
        result_path = out / f"{label}{FORMATS[args.format]}"
        command = getattr(args, "argv", None) or ["fsmctl", *sys.argv[1:]]
        result.save(result_path, format=args.format, precision=args.precision, command=command)  # atomic
        summary = result.summary(tolerances_deg=SETTLING_TOLERANCES_DEG)
        files = [str(result_path)]
        if not args.no_figures:
            from fsmctl.studies.figures import save_figure, simulation_figures

            for name, fig in simulation_figures(result, tolerances_deg=(0.03, 0.01)).items():
                files += [str(p) for p in save_figure(fig, out / f"{label}_{name}")]
        overrides = {**({"law": law} if law is not None else {}), **controller, **parameters}
        return _write_summary(args, scenario, overrides, simulation, summary, files, out, result_path)


def _base_scenario(args: argparse.Namespace):
    """The scenario before the overrides: ``--from RESULT``'s embedded one, or ``--scenario``/``--case``."""
    from fsmctl.model.scenario import load_scenario

    if args.from_result is None:
        return load_scenario(args.scenario or "paper", case=args.case)
    from fsmctl.cli.main import UsageError
    from fsmctl.simulation.results_io import scenario_from_result

    given = [name for name, value in (("--scenario", args.scenario), ("--case", args.case)) if value is not None]
    if given:
        raise UsageError(f"--from cannot be combined with {' or '.join(given)}: the result's own scenario is flown")
    return scenario_from_result(args.from_result)


def _write_summary(args, scenario, controller, simulation, summary, files, out: Path, result_path: Path) -> int:
    payload = {
        "source": "Liang, Sun & Wang, Acta Astronautica 81 (2012) 445-455",
        "scenario": scenario.label,
        "from": None if args.from_result is None else str(args.from_result),
        "format": args.format,
        "precision": args.precision,
        "law": scenario.controller.law,
        "description": scenario.description,
        "settings": scenario.describe(),
        "choices": dict(scenario.choices),
        "overrides": {"controller": controller, "simulation": simulation},
        "result": convergence_line(summary),
        "settling_tolerances_deg": list(SETTLING_TOLERANCES_DEG),
        "summary": summary,
        "files": [str(Path(f).relative_to(out)) if Path(f).is_relative_to(out) else f for f in files],
    }
    summary_path = write_json(out / "summary.json", payload)  # last: its presence marks a complete run
    print(_format_summary(summary))
    print(f"wrote {result_path}, {summary_path}" + ("" if args.no_figures else f" and {len(files) - 1} figure files"))
    return 0


def convergence_line(summary: dict) -> str:
    """``simulate``'s first line: converged (from when) or not, by the one rule (:data:`fsmctl.policy.CONVERGED_RULE`).

    Parameters
    ----------
    summary : dict
        :meth:`fsmctl.simulation.result.SimulationResult.summary` (its ``converged``, final values and settling
        times at :data:`fsmctl.policy.SETTLING_TOLERANCES_DEG`).

    Returns
    -------
    str
        ``converged: AAEM and RAEM stay <= 1 deg from T s on (finest: AAEM <= B deg from T s, ...)`` or
        ``not converged within H s: AAEM X deg, RAEM Y deg at the end (converged = ...)``.
    """
    tol = summary["convergence_tolerance_deg"]
    if summary["converged"]:
        since = max(summary[f"{m}_settling_s"][f"{tol:g}"] for m in ("aaem", "raem"))
        finest = [f"{m.upper()} <= {band:g} deg from {t:.2f} s" for m, (band, t) in _finest_bands(summary).items()]
        return f"converged: AAEM and RAEM stay <= {tol:g} deg from {since:.2f} s on (finest: {', '.join(finest)})"
    values = ", ".join(f"{m.upper()} {summary[f'{m}_final_deg']:.4g} deg" for m in ("aaem", "raem"))
    rule = CONVERGED_RULE.format(tolerance=f"{tol:g} deg")
    return f"not converged within {summary['horizon_s']:g} s: {values} at the end (converged = {rule})"


def _finest_bands(summary: dict) -> dict[str, tuple[float, float]]:
    """Per metric, the finest settling band it reaches and from when (metrics that reach none are left out)."""
    out = {}
    for metric in ("aaem", "raem"):
        settled = [(float(b), t) for b, t in summary[f"{metric}_settling_s"].items() if math.isfinite(t)]
        if settled:
            out[metric] = min(settled)
    return out


def steady_line(summary: dict) -> str:
    """``simulate``'s steady-state line: the maxima over the one window, and whether the window holds a transient.

    Parameters
    ----------
    summary : dict
        :meth:`fsmctl.simulation.result.SimulationResult.summary`.

    Returns
    -------
    str
        ``steady: max over the last W s (...): AAEM X deg, RAEM Y deg`` and, when the window starts before the run
        has settled to its finest band, a note that the maxima include the transient.
    """
    window = steady_window_text(summary["steady_window_s"], summary["horizon_s"])
    line = (
        f"steady: max over {window}: AAEM {summary['aaem_steady_max_deg']:.4g} deg, "
        f"RAEM {summary['raem_steady_max_deg']:.4g} deg"
    )
    start = summary["horizon_s"] - summary["steady_window_s"]
    if not summary["converged"]:
        return line + " (not converged: the window holds no steady state)"
    settled = max(t for _, t in _finest_bands(summary).values())
    if start < settled:
        return (
            line + f" (the window starts at {start:g} s, before the run settles at {settled:.2f} s: transient included)"
        )
    return line


def _format_summary(summary: dict) -> str:
    def fmt_time(x: float) -> str:
        return "not settled" if not math.isfinite(x) else f"{x:.2f} s"

    lines = [
        convergence_line(summary),
        f"  final (t = {summary['horizon_s']:g} s): AAEM {summary['aaem_final_deg']:.4g} deg, "
        f"RAEM {summary['raem_final_deg']:.4g} deg",
        f"  {steady_line(summary)}",
        f"  AAEM (eq 42): initial {summary['aaem_initial_deg']:.3f} deg, peak {summary['aaem_peak_deg']:.3f} deg",
        f"  RAEM (eq 43): initial {summary['raem_initial_deg']:.3f} deg, peak {summary['raem_peak_deg']:.3f} deg",
    ]
    for metric in ("aaem", "raem"):
        times = ", ".join(f"{tol} deg: {fmt_time(t)}" for tol, t in summary[f"{metric}_settling_s"].items())
        lines.append(f"  {metric.upper()} settling: {times}")
    sat = summary["saturated_time_s"]
    last = summary["last_saturation_s"]
    # a span of durations is the least and the most saturated agent's (a reader took "2.40–5.00 s" for an interval)
    who = "from the least to the most saturated agent" if "–" in value_range(sat, 2) else "every agent"
    lines.append(
        f"  torque: max applied {summary['u_max_abs_N_m']:.4g} N m, max commanded {summary['u_unsaturated_max_N_m']:.4g} N m, "
        f"saturated {duration_phrase(sat, summary['horizon_s'], digits=2)} ({who}; any axis at its limit, checked at "
        "every step), "
        + ("never at an output sample" if not math.isfinite(last) else f"last at the output sample t = {last:.2f} s")
    )
    if summary.get("messages_line"):  # a run with a control period: its messages (event-triggered or periodic)
        lines.append(f"  {summary['messages_line']}")
    lines.append(f"  {summary['scenario']}: {summary['backend']} backend, {summary['wall_time_s']:.2f} s")
    return "\n".join(lines)
