"""``fsmctl simulate``: run one scenario case and write its results (Liang, Sun & Wang 2012, Section 4).

Writes ``DIR/<label>.nc`` (NetCDF, units in the variable names and attributes),
``DIR/summary.json`` (settling times of AAEM eq 42 and RAEM eq 43, steady-state accuracy,
torque statistics, the scenario's settings and documented choices) and, unless
``--no-figures``, ``DIR/<label>_{aaem,raem,theta_e,torques}.{png,svg}`` (analogues of Figs 1-4).

``--law NAME|FILE.py|DIR`` flies another control law and ``--set KEY=VALUE`` sets its parameters
(:mod:`fsmctl.cli.law_options`); ``--control-period SECONDS`` (0 = continuous) and ``--seed N`` (the run's noise
seed) set the sampled control (:mod:`fsmctl.cli.run_options`); the summary records them all.

Exit codes: 0 the run finished, 1 the simulation failed (non-finite state, ...),
2 usage or input error (one line on stderr).
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from pathlib import Path

from fsmctl.cli.law_options import add_law_options, controller_changes
from fsmctl.cli.run_options import add_run_options, simulation_changes
from fsmctl.cli.types import nonnegative_float, positive_float, torque_limit
from fsmctl.outputs import output_folder, write_json
from fsmctl.studies.reproduce import SETTLING_TOLERANCES_DEG

__all__ = ["add_parser", "run", "SETTLING_TOLERANCES_DEG"]


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
        help="simulate one scenario case; write NetCDF, summary.json and figures",
        description="Simulate one case of a formation scenario with the compiled generated code "
        "(Liang, Sun & Wang 2012) and write DIR/<label>.nc, DIR/summary.json and the figures (PNG + SVG).",
        epilog="exit codes: 0 finished, 1 the simulation failed, 2 usage or input error.",
    )
    p.add_argument(
        "--scenario",
        default="paper",
        metavar="paper|FILE.toml",
        help="built-in 'paper' or a TOML file (default: paper)",
    )
    p.add_argument("--case", default=None, help="case name (paper: 1, 2, 3a, 3b, 3c; default: the file's first case)")
    p.add_argument(
        "--out", default=Path("simulation"), type=Path, metavar="DIR", help="output folder (default: ./simulation)"
    )
    p.add_argument("--no-figures", action="store_true", help="skip the PNG/SVG figures")
    p.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bar of the time loop (default: on a terminal, for long runs)",
    )
    g = p.add_argument_group("overrides of the scenario's settings")
    g.add_argument("--t-final", type=positive_float, metavar="S", help="horizon (s)")
    g.add_argument("--dt", type=positive_float, metavar="S", help="integration step (s)")
    g.add_argument("--output-interval", type=positive_float, metavar="S", help="output sample spacing (s)")
    g.add_argument("--integrator", choices=("rk4", "dopri45"), help="time integrator")
    add_run_options(g)
    g.add_argument("--error-model", choices=("paper", "exact"), help="controller error kinematics (eqs 7-8 or exact)")
    g.add_argument("--torque-limit", type=torque_limit, metavar="N_M", help="per-axis torque bound (N m) or 'inf'")
    g.add_argument(
        "--boundary-layer",
        type=nonnegative_float,
        metavar="PHI",
        help="boundary layer phi of sat(s/phi), 0 = sgn (Remark 7)",
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
        Parsed options.

    Returns
    -------
    int
        0 when the run finished and its files were written, 1 when the simulation failed;
        bad input raises :class:`fsmctl.model.scenario.ScenarioError`, :class:`fsmctl.model.laws.LawError` or
        :class:`fsmctl.cli.main.UsageError` (exit 2).
    """
    from fsmctl.model.scenario import load_scenario
    from fsmctl.simulation.simulator import SimulationError, simulate

    scenario = load_scenario(args.scenario, case=args.case)
    controller = controller_changes(args, scenario)  # --law, --set
    controller |= {
        k: v
        for k, v in (
            ("error_model", args.error_model),
            ("torque_limit", args.torque_limit),
            ("boundary_layer", args.boundary_layer),
        )
        if v is not None
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
    if simulation.get("t_final") is not None and "output_interval" not in simulation:
        # keep the scenario's output spacing unless it no longer fits the horizon
        interval = min(scenario.simulation.output_interval, simulation["t_final"])
        simulation["output_interval"] = interval
    scenario = scenario.replace(controller=controller, simulation=simulation)
    with output_folder(args.out) as out:
        for line in scenario.describe():
            print(line)
        if controller.keys() & {"law", "parameters"}:
            law = scenario.law
            given = ", ".join(f"{k}={v}" for k, v in dict(scenario.controller.parameters).items())
            print(f"  law: {law.name} ({law.folder})" + (f", parameters {given}" if given else ""))
        try:
            result = simulate(scenario, progress=args.progress)
        except SimulationError as exc:
            print(f"fsmctl simulate: {exc}", file=sys.stderr)
            return 1
        label = _file_label(scenario.label)
        nc_path = out / f"{label}.nc"
        result.save(nc_path)  # atomic
        summary = result.summary(tolerances_deg=SETTLING_TOLERANCES_DEG)
        files = [str(nc_path)]
        if not args.no_figures:
            from fsmctl.studies.figures import save_figure, simulation_figures

            for name, fig in simulation_figures(result, tolerances_deg=(0.03, 0.01)).items():
                files += [str(p) for p in save_figure(fig, out / f"{label}_{name}")]
        return _write_summary(args, scenario, controller, simulation, summary, files, out, nc_path)


def _write_summary(args, scenario, controller, simulation, summary, files, out: Path, nc_path: Path) -> int:
    payload = {
        "source": "Liang, Sun & Wang, Acta Astronautica 81 (2012) 445-455",
        "scenario": scenario.label,
        "law": scenario.controller.law,
        "description": scenario.description,
        "settings": scenario.describe(),
        "choices": dict(scenario.choices),
        "overrides": {"controller": controller, "simulation": simulation},
        "settling_tolerances_deg": list(SETTLING_TOLERANCES_DEG),
        "summary": summary,
        "files": [str(Path(f).relative_to(out)) if Path(f).is_relative_to(out) else f for f in files],
    }
    summary_path = write_json(out / "summary.json", payload)  # last: its presence marks a complete run
    print(_format_summary(summary))
    print(f"wrote {nc_path}, {summary_path}" + ("" if args.no_figures else f" and {len(files) - 1} figure files"))
    return 0


def _format_summary(summary: dict) -> str:
    def fmt_time(x: float) -> str:
        return "not settled" if not math.isfinite(x) else f"{x:.2f} s"

    lines = [
        f"{summary['scenario']}: {summary['backend']} backend, {summary['wall_time_s']:.2f} s",
        f"  AAEM (eq 42): initial {summary['aaem_initial_deg']:.3f} deg, peak {summary['aaem_peak_deg']:.3f} deg, "
        f"max over the last {summary['steady_window_s']:g} s {summary['aaem_steady_max_deg']:.4g} deg",
        f"  RAEM (eq 43): initial {summary['raem_initial_deg']:.3f} deg, peak {summary['raem_peak_deg']:.3f} deg, "
        f"max over the last {summary['steady_window_s']:g} s {summary['raem_steady_max_deg']:.4g} deg",
    ]
    for metric in ("aaem", "raem"):
        times = ", ".join(f"{tol} deg: {fmt_time(t)}" for tol, t in summary[f"{metric}_settling_s"].items())
        lines.append(f"  {metric.upper()} settling: {times}")
    sat = summary["saturated_time_s"]
    last = summary["last_saturation_s"]
    lines.append(
        f"  torque: max applied {summary['u_max_abs_N_m']:.4g} N m, max commanded {summary['u_unsaturated_max_N_m']:.4g} N m, "
        f"saturated {min(sat):.2f}-{max(sat):.2f} s per agent, last saturation "
        + ("never" if not math.isfinite(last) else f"{last:.2f} s")
    )
    return "\n".join(lines)
