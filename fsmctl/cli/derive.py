"""``fsmctl derive FILE.py``: check a derivation script against the law contract and generate its code.

A derivation script defines ``law(error_model) -> Law`` with :class:`fsmctl.symbolic.law.LawBuilder`.  The
command builds it for both error models (the contract checks of :meth:`LawBuilder.build
<fsmctl.symbolic.law.LawBuilder.build>` and :func:`fsmctl.symbolic.law.law_variants`), prints what it checked
and what the law declares, and writes the law folder (``law.json``, C sources, serialized CasADi functions,
``manifest.json``; :func:`fsmctl.codegen.laws.write_law`) with :func:`fsmctl.model.laws.derive_script`: into a
temporary sibling folder first, then renamed, so the folder is either the old one or the complete new one.

``--out DIR`` (default: ``./<law name>/``) names the folder; an existing folder that is not a law's is refused.
``--check`` writes nothing: it regenerates into a temporary folder and compares (:func:`fsmctl.codegen.laws.check_law`).
The folder then flies with ``fsmctl simulate --law DIR``.

Exit codes (:data:`EXIT_CODES`, :mod:`fsmctl.cli.exit_codes`): 0 written (or up to date with ``--check``), 1 the
folder is stale or missing (``--check``; the diff is printed), 2 the script does not derive (one line naming the
problem) or ``--out`` is unusable.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from pathlib import Path

from fsmctl.cli.exit_codes import epilog
from fsmctl.cli.options import add_out_option

__all__ = ["add_parser", "run", "verification_lines", "EXIT_CODES"]

EXIT_CODES = {
    0: "the law folder was written (with --check: it is up to date)",
    1: "with --check: the folder is stale or missing (the diff is printed)",
    2: "the script does not derive (one line naming the problem), --out is unusable, or another usage or input "
    "error (one line on stderr, never a traceback)",
}
"""What ``fsmctl derive``'s exit codes mean where they differ from :data:`fsmctl.cli.exit_codes.MEANINGS`."""


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``fsmctl derive`` (check a derivation script and generate its law folder).

    Parameters
    ----------
    subparsers : argparse subparsers action
        From :func:`fsmctl.cli.main.build_parser`.

    Returns
    -------
    argparse.ArgumentParser
        The ``derive`` parser, with ``func = run``.
    """
    p = subparsers.add_parser(
        "derive",
        help="check a law's derivation script and generate its code (a folder for --law)",
        description="Build the law of a derivation script (a Python file defining law(error_model) with "
        "fsmctl.symbolic.law.LawBuilder) for both error models, print what was checked (the law contract), the "
        "law's parameters, states and broadcast, and write its folder (law.json, C, CasADi, manifest.json) "
        "atomically. Fly it with: fsmctl simulate --law DIR.",
        epilog=epilog(EXIT_CODES),
    )
    p.add_argument("script", type=Path, metavar="FILE.py", help="the derivation script")
    add_out_option(
        p,
        None,
        help="law folder to write; an existing folder must be a law's (default: ./<law name> in the current folder)",
    )
    p.add_argument(
        "--check",
        action="store_true",
        help="write nothing: compare the folder with what the script generates now; exit 1 with the diff if stale",
    )
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run ``fsmctl derive``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options (``script``, ``out``, ``check``).

    Returns
    -------
    int
        0 written or up to date, 1 stale or missing (``--check``); a script that does not derive raises
        :class:`fsmctl.symbolic.law.LawDefinitionError` and an unusable ``--out`` :class:`fsmctl.cli.main.UsageError`
        or :class:`fsmctl.model.laws.LawError` (all :class:`fsmctl.errors.InputError`, exit 2).
    """
    from fsmctl.codegen.laws import LAW_FILE, check_law, load_derivation_script
    from fsmctl.errors import EnvironmentProblem
    from fsmctl.model.laws import derive_script
    from fsmctl.outputs import environment_problem

    script: Path = args.script
    start = time.perf_counter()
    variants = load_derivation_script(script)  # LawDefinitionError: one line, exit 2
    target = args.out if args.out is not None else Path.cwd() / variants.name
    _check_target(target, LAW_FILE, checking=args.check)
    for line in verification_lines(variants, script):
        print(line)
    generator = f"fsmctl derive {script.name}"
    if args.check:
        if not target.exists():
            print(
                f"fsmctl derive: {target} is missing; write it with: fsmctl derive {_q(script)} --out {_q(target)}",
                file=sys.stderr,
            )
            return 1
        identical, report = check_law(target, variants, source=script.name, generator=generator)
        if identical:
            print(f"{target} is up to date with {script}")
            return 0
        sys.stdout.write(report)
        print(
            f"fsmctl derive: {target} is stale; regenerate it with: fsmctl derive {_q(script)} --out {_q(target)}",
            file=sys.stderr,
        )
        return 1
    try:
        written = derive_script(script, target)  # temporary sibling folder, then renamed
    except EnvironmentProblem:
        raise
    except OSError as exc:  # read-only or full place, a file in the way: one line, exit 2
        raise environment_problem("write the law folder", target, exc) from None
    print(f"generated in {written}:")
    for line in _manifest_lines(written):
        print(line)
    print(f"wrote {written} ({time.perf_counter() - start:.1f} s); fly it with: fsmctl simulate --law {_q(written)}")
    return 0


def _q(path: Path) -> str:
    """A path as a shell word (quoted when it holds spaces or other special characters), for commands printed."""
    return shlex.quote(str(path))


def _check_target(target: Path, law_file: str, *, checking: bool) -> None:
    """Refuse a ``--out`` that is a file, or an existing non-empty folder that holds no law (exit 2)."""
    from fsmctl.cli.main import UsageError

    if not target.exists():
        return
    if not target.is_dir():
        raise UsageError(f"--out {target}: exists and is not a folder")
    if not (target / law_file).is_file() and any(target.iterdir()):
        what = "nothing to check" if checking else "choose another --out"
        raise UsageError(f"--out {target}: exists and is not a law folder (no {law_file}); {what}")


def verification_lines(variants, script: Path) -> list[str]:
    """What building the law checked, and what it declares (parameters, states, broadcast, stages).

    Parameters
    ----------
    variants : fsmctl.symbolic.law.LawVariants
        From :func:`fsmctl.codegen.laws.load_derivation_script`.
    script : Path
        The derivation script (for the header line).

    Returns
    -------
    list of str
        The lines ``fsmctl derive`` prints before writing.
    """
    from fsmctl.cli.laws import parameter_table

    law = variants.paper
    states = law.states
    n_u = law.torque.rows
    lines = [
        f"derive {script}: law {law.name!r}" + (f": {law.doc}" if law.doc else ""),
        "checked (the law contract, for the paper and the exact error kinematics):",
        f"  ok  broadcast {law.broadcast_name!r} ({law.n_broadcast} values) does not depend on what the agent receives",
        f"  ok  torque declared ({n_u} components); the generated u clips it per axis at u_max (ideal actuator)",
        "  ok  every law state has a derivative"
        + (f" ({', '.join(s.name for s in states)})" if states else " (the law has no states)"),
        "  ok  every stage, the broadcast, the torque and the state derivative use only the contract's inputs",
        "  ok  both error models give the same name, parameters, states, broadcast and constants",
    ]
    if law.reference:
        lines.append(f"reference: {law.reference}")
    lines.append(
        f"broadcast: {law.broadcast_name} ({law.n_broadcast}); the engine gives each agent "
        "received = sum_j k^j_ij(t) b_j, k_sum and k_received_sum"
    )
    if states:
        lines.append(
            "states: "
            + "; ".join(
                f"{s.name} ({s.size}{', ' + s.unit if s.unit else ''}, initial {', '.join(f'{v:g}' for v in s.initial)})"
                for s in states
            )
        )
    else:
        lines.append("states: none")
    if law.parameters:
        lines.append(f"parameters ({len(law.parameters)}, {law.n_params} values):")
        lines += parameter_table(law.parameters, indent="  ")
    else:
        lines.append("parameters: none")
    lines.append(
        "stages: local (law_local_*) "
        + (", ".join(n for n, _, _ in law.local_stages) or "none")
        + "; control (law_control_*) "
        + (", ".join(n for n, _, _ in law.control_stages) or "none")
        + "; constants (law_constants) "
        + (", ".join(n for n, _, _ in law.constants) or "none")
    )
    if law.wheel_torques is not None:
        lines.append(
            f"wheels: the law commands {law.n_wheels} reaction wheels itself (law_wheels_*; the scenario must have "
            f"{law.n_wheels} wheels; on an ideal actuator its torque is flown)"
        )
    if law.trigger is not None:
        every = "every control instant" if law.trigger.period is None else f"every {law.trigger.period:g} s"
        lines.append(
            f"trigger: sends its broadcast when {law.trigger.condition} (law_trigger, checked at {every}; needs a "
            "control period)"
        )
    lines.append(
        "lyapunov: "
        + (
            "none declared"
            if law.lyapunov is None
            else f"declared ({law.lyapunov.doc or 'V'}); fsmctl prove --law checks it"
        )
    )
    return lines


def _manifest_lines(folder: Path) -> list[str]:
    """One line per generated function: name, CasADi instruction count, batched kernel."""
    try:
        manifest = json.loads((folder / "manifest.json").read_text("utf-8"))
    except (OSError, ValueError):
        return ["  (no readable manifest.json)"]
    functions = manifest.get("functions", [])
    width = max((len(f["name"]) for f in functions), default=0)
    out = []
    for f in functions:
        kernel = f", batched kernel {f['batched_kernel']}" if f.get("batched_kernel") else ""
        out.append(f"  {f['name']:{width}}  {f.get('n_instructions', '?'):>6} instructions{kernel}")
    return out
