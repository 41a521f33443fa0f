"""``fsmctl certify``: a machine-checked Lyapunov certificate for a law, over a region, with the uncertainty.

``fsmctl certify --law L`` asks, for one agent of a scenario flying the law (isolated, in error coordinates), whether
``V_dot < 0`` holds at every point of a region for every true inertia, disturbance and reference motion in the
stated sets (:func:`fsmctl.proofs.certificate.certify_law`, :mod:`fsmctl.proofs.certify`), and answers
``certified`` (asymptotic or ultimately bounded), ``counterexample`` or ``inconclusive``.  The certificate is written
as JSON (everything needed to re-check it) and Markdown; ``fsmctl certify --check FILE.json`` re-checks a file
(:func:`fsmctl.proofs.certificate.check_certificate`).

Exit codes: 0 certified (``--check``: every statement re-proved and the file certifies); 1 a counterexample or
inconclusive (``--check``: a statement did not re-check, or the file certifies nothing); 2 usage or input error.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from fsmctl.cli.exit_codes import epilog
from fsmctl.cli.options import add_case_option, add_out_option, add_progress_option, add_scenario_option

__all__ = ["EXIT_CODES", "add_parser", "run"]

EXIT_CODES = {
    0: "certified (with --check: every statement of the file re-proved, and the file certifies)",
    1: "a counterexample, or inconclusive (with --check: a statement did not re-check, or the file certifies nothing)",
}
"""What ``fsmctl certify``'s exit codes 0 and 1 mean."""

EPILOG = epilog(
    EXIT_CODES,
    text="""verdicts: certified (asymptotic: V_dot < 0 on the region but the origin, for every admissible
uncertainty; ultimately bounded: V_dot < 0 outside an inner sublevel set, when a disturbance or a moving reference
keeps the error from vanishing), counterexample (a point where V_dot > 0, confirmed in ball arithmetic),
inconclusive (the budget ran out, or boxes too small to split; the report says where).  A certificate is never
upgraded from one kind to another; numeric evidence is never called a certificate.

the uncertainty defaults to the scenario's: its delta_J as a set around J0, its disturbance's and its reference's
bounds; each option below overrides one part (0 removes it).""",
)


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register the ``certify`` subcommand.

    Parameters
    ----------
    subparsers : argparse subparsers action
        From :func:`fsmctl.cli.main.build_parser`.

    Returns
    -------
    argparse.ArgumentParser
        The ``certify`` parser, with ``func = run``.
    """
    from fsmctl.proofs.certify import CANDIDATE_CHOICES, SearchSettings
    from fsmctl.proofs.certify_problem import INERTIA_SETS, StateRegion

    region, search = StateRegion(), SearchSettings()
    p = subparsers.add_parser(
        "certify",
        help="prove a law stable over a region with the uncertainty (a Lyapunov certificate), or refute it",
        description="A rigorous Lyapunov certificate for one agent's closed loop: certified, counterexample or "
        "inconclusive.",
        epilog=EPILOG,
    )
    p.add_argument("--law", metavar="NAME|FILE.py|DIR", help="the law: a built-in name or a derivation script")
    p.add_argument("--check", metavar="FILE.json", type=Path, dest="certificate_file",
                   help="re-check a certificate file instead")  # fmt: skip
    add_scenario_option(p, default=None, note="supplying J0, the parameters, the torque limit and the uncertainty")
    add_case_option(p)
    p.add_argument("--agent", type=int, default=1, metavar="I", help="which agent of the scenario (default: 1)")
    g = p.add_argument_group("the region (error coordinates)")
    g.add_argument("--region-sigma", type=float, default=region.sigma, metavar="R",
                   help=f"every component of sigma_e within [-R, R] (default: {region.sigma:g})")  # fmt: skip
    g.add_argument("--region-omega", type=float, default=region.omega, metavar="R",
                   help=f"every component of omega_e within [-R, R] rad/s (default: {region.omega:g})")  # fmt: skip
    g.add_argument("--region-z", type=float, default=region.z, metavar="R",
                   help=f"every component of the law's own states z within [-R, R] (default: {region.z:g})")  # fmt: skip
    u = p.add_argument_group("the uncertainty (default: the scenario's)")
    u.add_argument("--inertia-uncertainty", type=float, default=None, metavar="REL",
                   help="the true inertia J_kl = J0_kl (1 + theta_kl) with theta_kl within [-REL, REL] (0: J = J0)")  # fmt: skip
    u.add_argument("--inertia-set", choices=INERTIA_SETS, default=None,
                   help="each non-zero entry of J0 on its own (entries) or J = (1 + theta) J0 (proportional)")  # fmt: skip
    u.add_argument("--disturbance", type=float, nargs="+", default=None, metavar="N_M",
                   help="each disturbance component within [-N_M, N_M] N m: one bound for all three axes or one per axis "
                   "(e.g. the paper's 0.2 0.24 0.22); 0: none")  # fmt: skip
    u.add_argument("--reference-rate", type=float, nargs="+", default=None, metavar="RAD_S",
                   help="each reference rate component within [-RAD_S, RAD_S] rad/s (one or three bounds; 0 with "
                   "--reference-acceleration 0: the reference at rest)")  # fmt: skip
    u.add_argument("--reference-acceleration", type=float, nargs="+", default=None, metavar="RAD_S2",
                   help="each reference acceleration component within [-RAD_S2, RAD_S2] rad/s^2 (one or three bounds)")  # fmt: skip
    s = p.add_argument_group("the search and the files")
    s.add_argument("--candidate", choices=CANDIDATE_CHOICES, default="auto",
                   help="auto: the law's declared V, then the V fsmctl finds (cross term, quadratic); declared: only "
                   "the law's own V (default: auto)")  # fmt: skip
    s.add_argument("--seconds", type=float, default=search.max_seconds, metavar="S",
                   help=f"budget of the branch and bound per candidate V (default: {search.max_seconds:g}); up to 5 "
                        "candidates, plus each one's boundary level, sum of squares, origin's argument and levels: the run takes longer")  # fmt: skip
    add_out_option(p, None, help="output folder: certificate.json, certificate.md and, for a counterexample, its "
                   "flight's figure (default: ./certify-<law>)")  # fmt: skip
    s.add_argument("--report", type=Path, default=None, metavar="FILE.md",
                   help="write the Markdown report here instead (default: certificate.md in the output folder)")  # fmt: skip
    s.add_argument("--json", action="store_true", help="print the certificate's summary as JSON (no leaves)")
    s.add_argument("--fly", type=float, default=20.0, metavar="S",
                   help="fly a counterexample for S seconds and plot V along it beside the certificate (0: do not; "
                   "default: 20)")  # fmt: skip
    add_progress_option(p, what="of the branch and bound")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run ``fsmctl certify`` (see the module docstring).

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options.

    Returns
    -------
    int
        0 certified / re-checked, 1 otherwise; bad input raises :class:`fsmctl.cli.main.UsageError` or the library's
        :class:`fsmctl.errors.InputError` (exit 2).
    """
    from fsmctl.cli.main import UsageError
    from fsmctl.proofs.certify_problem import Uncertainty

    if args.certificate_file is not None:
        if args.law is not None:
            raise UsageError("--check re-checks a file: it takes no --law")
        return _check(args)
    if args.law is None:
        raise UsageError("give --law NAME|FILE.py (or --check FILE.json)")
    if not (math.isfinite(args.fly) and args.fly >= 0):
        raise UsageError(f"--fly must be a finite number >= 0, got {args.fly}")
    for name in Uncertainty.BOUND_UNITS:  # the library's one check, before any work, naming the option
        v = getattr(args, name)
        if v is not None:
            Uncertainty.axis_bounds(name, v, label=f"--{name.replace('_', '-')}")
    for name in ("region_sigma", "region_omega", "region_z", "seconds"):
        v = getattr(args, name)
        if not (math.isfinite(v) and v > 0):
            raise UsageError(f"--{name.replace('_', '-')} must be a finite number > 0, got {v}")
    return _certify(args)


def _uncertainty(args, scenario, agent: int):
    from fsmctl.proofs.certificate import scenario_uncertainty
    from fsmctl.proofs.certify_problem import Uncertainty

    base = scenario_uncertainty(scenario, agent)
    return Uncertainty(
        inertia=base.inertia if args.inertia_uncertainty is None else args.inertia_uncertainty,
        inertia_set=args.inertia_set or base.inertia_set,
        disturbance=base.disturbance if args.disturbance is None else tuple(args.disturbance),
        reference_rate=base.reference_rate if args.reference_rate is None else tuple(args.reference_rate),
        reference_acceleration=(
            base.reference_acceleration if args.reference_acceleration is None else tuple(args.reference_acceleration)
        ),
    )


def _certify(args) -> int:
    from fsmctl.cli.main import UsageError
    from fsmctl.errors import InputError
    from fsmctl.model.laws import resolve_law
    from fsmctl.model.scenario import load_scenario
    from fsmctl.proofs.certificate import certify_law
    from fsmctl.proofs.certify import SearchSettings
    from fsmctl.proofs.certify_problem import StateRegion
    from fsmctl.studies.certify_flight import flight_scenario

    region = StateRegion(args.region_sigma, args.region_omega, args.region_z)  # bad input first, before any work
    code = resolve_law(args.law)
    folder = args.out or Path(f"certify-{code.name}")
    out, report = folder / "certificate.json", args.report or folder / "certificate.md"
    _check_targets(args, folder, report)
    scenario = load_scenario(args.scenario or "paper", case=args.case)
    if code.name != scenario.law.name:
        scenario = scenario.with_law(args.law)
    if not 1 <= args.agent <= scenario.n_agents:
        raise UsageError(f"--agent must be in 1..{scenario.n_agents}, got {args.agent}")
    uncertainty = _uncertainty(args, scenario, args.agent - 1)
    if args.fly > 0:  # a horizon the scenario cannot fly: refused now, not after the search
        try:
            flight_scenario(scenario, args.fly)
        except InputError as exc:
            raise UsageError(f"--fly {args.fly:g}: {exc}") from None
    settings = SearchSettings(max_seconds=args.seconds)
    print(f"certify {code.name}: region {region.describe(code.n_states)}; {uncertainty.describe()}", file=sys.stderr)
    with _Bars(sys.stderr.isatty() if args.progress is None else args.progress) as bars:
        cert = certify_law(
            args.law, scenario=scenario, agent=args.agent - 1, region=region, uncertainty=uncertainty,
            settings=settings, candidates=args.candidate, progress=bars.progress, stage=bars.stage,
        )  # fmt: skip
    return _write(args, cert, scenario, folder, out, report)


def _check_targets(args, folder: Path, report: Path) -> None:
    """``--out`` must be a folder (or a path to make one) and ``--report`` a file: refused before the search."""
    from fsmctl.cli.main import UsageError

    if folder.exists() and not folder.is_dir():
        raise UsageError(
            f"--out {folder} is an existing file; --out names a folder (certificate.json and certificate.md are written "
            f"in it): give a new or existing folder, or remove {folder}"
        )
    if args.out is not None and not folder.exists() and folder.suffix.lower() in (".json", ".md"):
        raise UsageError(
            f"--out {folder}: --out names a folder (certificate.json and certificate.md are written in it), not a "
            f"file: give e.g. --out {folder.with_suffix('')}"
        )
    if report.is_dir():
        raise UsageError(f"--report {report}: a folder exists there; --report names the Markdown file: give FILE.md")


def _write(args, cert, scenario, folder: Path, out: Path, report: Path) -> int:
    """Fly a counterexample, write the files (saying which earlier ones were replaced) and print the report."""
    from fsmctl.studies.certify_flight import fly_counterexample
    from fsmctl.studies.figures import save_figure

    replaced = [p for p in (out, report) if p.is_file()]
    # an earlier certificate's flight (the figure's files are the tool's own, beside its certificate)
    stale = [p for p in (folder / "counterexample.png", folder / "counterexample.svg") if p.is_file() and out.is_file()]
    figure = None
    if cert.verdict == "counterexample" and args.fly > 0:
        flight = fly_counterexample(cert, scenario, t_final=args.fly)
        cert.notes.append(flight.summary())
        cert.notes.extend(flight.notes)
        figure = save_figure(flight.figure(), folder / "counterexample")[0]
    else:
        for p in stale:  # an earlier run's flight: it does not belong to the new certificate
            p.unlink()
    cert.write(out, report)
    said = ""
    if replaced:
        removed = f"; its flight's figure removed ({', '.join(p.name for p in stale)})" if stale and not figure else ""
        said = f"an earlier certificate was replaced: {' and '.join(map(str, replaced))}{removed}"
    if args.json:
        d = cert.as_dict()
        d.pop("tree")
        print(json.dumps(d, indent=1, default=str))
        if said:
            print(said, file=sys.stderr)  # stdout holds the JSON alone
        return 0 if cert.verdict == "certified" else 1
    print("\n".join(cert.lines()))
    if said:
        print(said)
    print(f"certificate written to {out} and {report}; re-check: fsmctl certify --check {out}")
    if figure is not None:
        print(f"the counterexample's flight: {figure}")
    return 0 if cert.verdict == "certified" else 1


class _Bars:
    """The progress bars on stderr: one per candidate, labelled with it, its step after the label (the origin's argument
    and the boundary level, the branch and bound with its boxes, the levels); none when not ``shown``."""

    def __init__(self, shown: bool):
        self.shown = shown
        self.bar = None
        self.title = None

    def __enter__(self) -> _Bars:
        return self

    def __exit__(self, *exc) -> None:
        if self.bar is not None:
            self.bar.close()

    def stage(self, s) -> None:
        """``certify_law``'s ``stage`` callback (a :class:`fsmctl.proofs.certificate.CertifyStage`)."""
        from tqdm.auto import tqdm

        if s.title() != self.title:
            if self.bar is not None:
                self.bar.close()
            self.title = s.title()
            # a step before the candidates has no progress of its own: its name and the time it takes
            plain = {} if s.candidate else {"bar_format": "{desc} [{elapsed}]"}
            self.bar = tqdm(total=100.0, unit="%", desc=self.title, disable=not self.shown, file=sys.stderr, **plain)
        if s.candidate:
            self.bar.set_postfix_str(s.step, refresh=True)

    def progress(self, boxes: int, fraction: float) -> None:
        """``certify_law``'s ``progress`` callback."""
        self.bar.n = round(100 * fraction, 1)
        self.bar.set_postfix_str(f"branch and bound, {boxes} boxes", refresh=True)


def _check(args) -> int:
    from fsmctl.proofs.certificate import check_certificate

    result = check_certificate(args.certificate_file)
    if not result.ok:
        first = "NOT re-checked: a statement fails"
    elif result.certified:
        first = "re-checked: every statement holds; the file certifies its law"
    else:
        first = f"re-checked: every statement holds, but the file's verdict is {result.verdict}: it certifies nothing"
    print(first)
    print("\n".join(result.lines))
    return 0 if result.certified else 1
