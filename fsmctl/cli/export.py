"""``fsmctl export``: a law as a C library for a flight computer, an FMU for another simulator, results as CCSDS AEM.

``--target c`` (default) writes one spacecraft's controller as a self-contained strict C99 library
(:func:`fsmctl.export.write_c_library`); ``--verify`` then flies the scenario (default: the paper's Case 1) in the
engine with the exported object code in the loop at the control period and compares it with the engine's own law
(:func:`fsmctl.export.verify_export`: bit-identical in float64, the measured differences in float32).
``--target fmu`` writes an FMI 2.0 co-simulation FMU of the controller (:mod:`fsmctl.export.fmu`); ``--target aem``
writes a result file's attitude histories as CCSDS Attitude Ephemeris Messages (:mod:`fsmctl.export.aem`).

Exit codes: 0 written (and, with ``--verify``, the check passed); 1 the software-in-the-loop check failed; 2 usage or
input error.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from fsmctl.cli.exit_codes import epilog
from fsmctl.cli.law_options import add_law_options, law_changes
from fsmctl.cli.options import add_case_option, add_out_option, add_scenario_option
from fsmctl.cli.types import number
from fsmctl.policy import EXPORT_CONTROL_PERIOD

__all__ = ["EXIT_CODES", "TARGETS", "add_parser", "run"]

EXIT_CODES = {
    0: "written (with --verify: the exported code flew as the engine's own law)",
    1: "with --verify: the software-in-the-loop check failed",
}
"""What ``fsmctl export``'s exit codes 0 and 1 mean."""

TARGETS = ("c", "fmu", "aem")
"""``--target`` choices."""

EPILOG = epilog(
    EXIT_CODES,
    text="""targets: c, a strict C99 library of one spacecraft's controller (no allocation, no globals, no libm;
init / broadcast / step; README.md with units and frames; manifest.json); fmu, an FMI 2.0 co-simulation FMU of the
same controller; aem, the attitude histories of a result file (--result) as CCSDS Attitude Ephemeris Messages.

--verify (target c): the scenario flies twice at the control period, with the engine's own law and with the exported
object code in the loop; float64 must be bit-identical, float32 is measured (torque, attitude, convergence).""",
)


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``fsmctl export``.

    Parameters
    ----------
    subparsers : argparse subparsers action
        From :func:`fsmctl.cli.main.build_parser`.

    Returns
    -------
    argparse.ArgumentParser
        The ``export`` parser, with ``func = run``.
    """
    from fsmctl.export import ERROR_MODELS, PRECISIONS

    p = subparsers.add_parser(
        "export",
        help="a law as a C99 library for a flight computer or an FMU, checked in the loop; results as CCSDS AEM",
        description="Export a law for one spacecraft as strict C99 (or an FMI 2.0 FMU), checked against the engine "
        "by software in the loop, or a result's attitudes as CCSDS AEM.",
        epilog=EPILOG,
    )
    add_law_options(p, what="the export holds and --verify")  # --set: the exported defaults (and what --verify flies)
    p.add_argument("--target", choices=TARGETS, default="c", help="what to write (default: c)")
    add_out_option(p, None, help="output folder (default: ./export-<law>-<target>)")
    g = p.add_argument_group("the exported controller (targets c and fmu)")
    g.add_argument("--precision", choices=tuple(PRECISIONS), default="float64",
                   help="the arithmetic of the exported code (default: float64)")  # fmt: skip
    g.add_argument("--error-model", choices=ERROR_MODELS, default=None,
                   help="the error kinematics of the exported law (default: the scenario's)")  # fmt: skip
    g.add_argument("--control-period", type=number, default=None, metavar="SECONDS",
                   help="the control period in s (> 0; default: the scenario's simulation.control_period, else "
                   f"{EXPORT_CONTROL_PERIOD:g})")  # fmt: skip
    g.add_argument("--prefix", default=None, metavar="NAME", help="prefix of every C name (default: the law's name)")
    g.add_argument("--verify", action="store_true",
                   help="fly the scenario with the exported code in the loop and compare with the engine (target c)")  # fmt: skip
    add_scenario_option(g, default=None, note="(--verify flies it; its controller gives the defaults)")
    add_case_option(g)
    f = p.add_argument_group("the FMUs (target fmu)")
    f.add_argument("--neighbours", type=int, default=None, metavar="N",
                   help="neighbour input slots of the controller FMU (default: 5)")  # fmt: skip
    f.add_argument("--with-plant", action="store_true",
                   help="also write plant.fmu: the scenario's first spacecraft (true inertia, initial state, "
                   "disturbance) integrated with RK4 at the scenario's dt")  # fmt: skip
    a = p.add_argument_group("results (target aem)")
    a.add_argument("--result", type=Path, default=None, metavar="FILE.nc",
                   help="a result file of fsmctl simulate (target aem)")  # fmt: skip
    a.add_argument("--aem-format", choices=("kvn", "xml"), default="kvn",
                   help="the AEM encoding: KVN text or XML (default: kvn)")  # fmt: skip
    a.add_argument("--epoch", default=None, metavar="YYYY-MM-DDTHH:MM:SS",
                   help="the UTC date and time of t = 0 (default: 2000-01-01T12:00:00)")  # fmt: skip
    a.add_argument("--inertial-frame", default=None, metavar="NAME",
                   help="the name of the scenario's inertial frame N in the files, REF_FRAME_A (default: EME2000)")  # fmt: skip
    p.set_defaults(func=run)
    return p


def _check_args(args: argparse.Namespace) -> None:
    from fsmctl.cli.main import UsageError

    period = args.control_period
    if period is not None and not (isinstance(period, (int, float)) and math.isfinite(period) and period > 0):
        raise UsageError(f"--control-period must be a finite number > 0 s, got {args.control_period}")
    if args.target == "aem":
        if args.result is None:
            raise UsageError("--target aem writes a result file's attitudes: give --result FILE.nc")
        if args.law or args.verify or args.law_set:
            raise UsageError("--target aem takes --result, --out, --aem-format, --epoch and --inertial-frame")
    elif args.result is not None or args.epoch is not None or args.inertial_frame is not None:
        raise UsageError("--result, --epoch and --inertial-frame are for --target aem")
    if args.verify and args.target != "c":
        raise UsageError("--verify checks --target c (the FMU is built from the same C)")
    if (args.neighbours is not None or args.with_plant) and args.target != "fmu":
        raise UsageError("--neighbours and --with-plant are for --target fmu")
    if args.neighbours is not None and args.neighbours < 0:
        raise UsageError(f"--neighbours must be >= 0, got {args.neighbours}")


def run(args: argparse.Namespace) -> int:
    """Run ``fsmctl export`` (see the module docstring).

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options.

    Returns
    -------
    int
        0 written (and verified), 1 the check failed; bad input raises :class:`fsmctl.cli.main.UsageError`.
    """
    _check_args(args)
    if args.target == "aem":
        return _aem(args)
    from fsmctl.model.laws import resolve_law
    from fsmctl.model.scenario import load_scenario

    law, parameters, controller = law_changes(args)
    scenario = load_scenario(args.scenario or "paper", case=args.case)
    code = resolve_law(law) if law else scenario.law
    period = args.control_period or scenario.simulation.control_period or EXPORT_CONTROL_PERIOD
    error_model = args.error_model or scenario.controller.error_model
    suffix = "" if args.precision == "float64" else f"-{args.precision}"
    folder = args.out or Path(f"export-{code.name}-{args.target}{suffix}")
    baked = _baked(code, parameters, controller, scenario)
    if args.target == "fmu":
        return _fmu(args, code, scenario, folder, period, error_model, baked)
    _check_folder(folder)
    flown = _verify_scenario(scenario, law, parameters, controller, period) if args.verify else None
    return _c(args, code, flown, folder, period, error_model, baked)


def _baked(code, parameters, controller, scenario) -> dict:
    """What ``--set`` bakes into the export: the law parameters as its defaults, checked now (one line, exit 2), and
    the torque limit (``--set torque_limit=...``, else none)."""
    from fsmctl.cli.main import UsageError
    from fsmctl.export import with_defaults
    from fsmctl.model.laws import LawError

    try:
        with_defaults(code, parameters)
    except LawError as exc:
        raise UsageError(f"--set: {exc}") from None
    limit = controller.get("torque_limit", math.inf) if controller else math.inf
    limit = math.inf if isinstance(limit, str) and limit.lower() == "inf" else limit
    if not (isinstance(limit, (int, float)) and limit > 0):
        raise UsageError(f"--set torque_limit: must be > 0 N m or 'inf', got {limit!r}")
    return {"parameters": parameters or None, "torque_limit": float(limit)}


def _check_folder(folder: Path) -> None:
    """An existing ``--out`` must be empty or an earlier export (its files are replaced)."""
    from fsmctl.cli.main import UsageError

    if folder.is_dir() and any(folder.iterdir()) and not (folder / "manifest.json").is_file():
        raise UsageError(f"--out {folder}: a folder that is neither empty nor an earlier export; give another one")


def _verify_scenario(scenario, law, parameters, controller, period: float):
    """The scenario ``--verify`` flies, checked before anything is written."""
    from fsmctl.cli.main import UsageError
    from fsmctl.model.scenario import ScenarioError

    if law or parameters:
        scenario = scenario.with_law(law, parameters)
    if controller:
        scenario = scenario.replace(controller=controller)
    try:
        return scenario.replace(simulation={"control_period": period})
    except ScenarioError as exc:
        raise UsageError(f"--control-period {period:g} s: {exc}") from None


def _c(args, code, flown, folder: Path, period: float, error_model: str, baked: dict) -> int:
    from fsmctl.export import strict_flags, verify_export, write_c_library

    command = "fsmctl " + " ".join(sys.argv[1:]) if sys.argv[1:] else "fsmctl export"
    lib = write_c_library(
        code, folder, control_period=period, precision=args.precision, error_model=error_model, prefix=args.prefix,
        command=command, **baked,
    )  # fmt: skip
    print(f"wrote {lib.folder}/: {', '.join(sorted([*lib.manifest['sha256'], 'manifest.json']))}")
    print(f"compile: cc {' '.join(strict_flags(lib.precision))} -O2 -c {' '.join(s.name for s in lib.sources)}")
    if flown is None:
        return 0
    check = verify_export(lib, flown, control_period=period)
    print("\n".join(check.report_lines()))
    return 0 if check.passed else 1


def _fmu(args, code, scenario, folder: Path, period: float, error_model: str, baked: dict) -> int:
    from fsmctl.export import DEFAULT_NEIGHBOURS, write_controller_fmu, write_plant_fmu
    from fsmctl.model.problem import pack

    path = write_controller_fmu(
        code, folder / f"{args.prefix or code.name}_controller.fmu", precision=args.precision,
        error_model=error_model, control_period=period, prefix=args.prefix,
        n_neighbours=DEFAULT_NEIGHBOURS if args.neighbours is None else args.neighbours, **baked,
    )  # fmt: skip
    print(f"wrote {path} (FMI 2.0 co-simulation, communication step {period:g} s)")
    if args.with_plant:
        p, agent = pack(scenario), scenario.agents[0]
        plant = write_plant_fmu(
            folder / "plant.fmu", dt=scenario.simulation.dt, inertia=p.J_true[0].reshape(3, 3),
            sigma0=agent.sigma0, omega0=agent.omega0, disturbance=p.dist_params[0],
        )  # fmt: skip
        print(f"wrote {plant} ({scenario.label}, agent 1; RK4 at dt = {scenario.simulation.dt:g} s)")
    return 0


def _aem(args) -> int:
    from datetime import datetime

    from fsmctl.cli.main import UsageError
    from fsmctl.export.aem import DEFAULT_EPOCH, INERTIAL_FRAME, write_aem
    from fsmctl.simulation import load_result

    result = load_result(args.result)
    folder = args.out or Path(f"export-{Path(args.result).stem}-aem")
    command = "fsmctl " + " ".join(sys.argv[1:]) if sys.argv[1:] else "fsmctl export --target aem"
    epoch = DEFAULT_EPOCH
    if args.epoch is not None:
        try:
            epoch = datetime.fromisoformat(args.epoch)
        except ValueError:
            raise UsageError(f"--epoch {args.epoch!r}: not a date and time such as 2026-11-28T12:00:00") from None
    frame = args.inertial_frame or INERTIAL_FRAME
    paths = write_aem(result, folder, format=args.aem_format, command=command, epoch=epoch, inertial_frame=frame)
    for p in paths:
        print(f"wrote {p}")
    print(
        f"{len(paths)} CCSDS AEM files (the agents, then the reference): quaternions Q1 Q2 Q3 QC (scalar last) from "
        f"{frame} (the scenario's inertial frame) to the body; t = 0 at {epoch.isoformat()} UTC"
    )
    return 0
