"""``fsmctl prove``: check the claims of Liang, Sun & Wang (2012), Section 3, for a scenario; or a law's.

``fsmctl prove`` checks the paper's claims (:mod:`fsmctl.proofs.claims`) and, without ``CLAIM_ID``, every
erratum of the printed paper (:func:`fsmctl.proofs.errata.all_errata`); ``fsmctl prove --law L`` checks
what a law declares instead (:func:`fsmctl.proofs.law_check.check_law`: its contract, and its Lyapunov
candidate when it declares one).

The first line states the result: ``all N checks as documented (1 known failure of the paper: theorem2-delta)``
or ``K of N checks differ from the documented finding: ...`` (:func:`fsmctl.proofs.report.outcome`; ``--json``:
its ``outcome`` object).  The documented finding of each claim is its verdict on the paper's scenario, in the claims
registry (:attr:`fsmctl.proofs.claims.Claim.expected`): an erratum and Theorem 2's delta failing for the paper are
findings, not failures of the tool.

Exit codes (:data:`EXIT_CODES`, :mod:`fsmctl.cli.exit_codes`): 0 every check as documented (the errata and the
documented failure of Theorem 2's delta included; ``--strict``: every check passes) / with ``--law``, the law's
checks passed; 1 a check differs from the documented finding (``--strict``: any check fails, or is not confirmed) /
with ``--law``, a law check failed (a user's law has no documented finding); 2 usage or input error.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from fsmctl.cli.exit_codes import epilog
from fsmctl.cli.options import add_case_option, add_scenario_option, add_seed_option
from fsmctl.cli.parallel_options import add_workers_option, chosen_workers

__all__ = ["add_parser", "run", "EXIT_CODES"]

EXIT_CODES = {
    0: "every check as documented: the errata and the paper's known failure (Theorem 2's delta) included; with "
    "--strict, every check passes (with --law: the law's checks passed)",
    1: "a check differs from the documented finding (with --strict: any check fails); with --law, a law check "
    "failed (a user's law has no documented finding)",
}
"""What ``fsmctl prove``'s exit codes 0 and 1 mean (the others: :data:`fsmctl.cli.exit_codes.MEANINGS`)."""

EPILOG = epilog(
    EXIT_CODES,
    text="""result: the first line says whether every check came out as documented (the verdict of each claim on
the paper's scenario is recorded with the claim: 8 errata and Theorem 2's delta failing for the paper are findings);
a claim that uses the scenario has a documented finding only for the paper's scenario over the default region,
elsewhere it is expected to hold.

verdicts: proved (symbolic), numeric (sampling only, not a proof), erratum (the printed statement is
false; the corrected one is checked), fails for this scenario.

without CLAIM_ID, every erratum of the printed paper is also checked and reported after the claims, with its
equations and the claim that examines it (JSON: {"claims": [...], "errata": [...]}; "errata" is null when
CLAIM_IDs select claims).

--law NAME|FILE.py|DIR checks a law instead of the paper's claims (--error-model, --samples, --seed,
--json and --report apply).""",
)


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register the ``prove`` subcommand (proof check of Liang et al. 2012, Section 3, eqs 7-41).

    Parameters
    ----------
    subparsers : argparse subparsers action
        From :func:`fsmctl.cli.main.build_parser`.

    Returns
    -------
    argparse.ArgumentParser
        The ``prove`` parser, with ``func = run``.
    """
    from fsmctl.proofs.theorem2 import Region

    default = Region()
    p = subparsers.add_parser(
        "prove",
        help="check every step of Section 3 (symbolically) and Theorems 1-2 for a scenario, or a law (--law)",
        description="Proof check of Liang, Sun & Wang (2012), Section 3, on the model derived in derive/.",
        epilog=EPILOG,
    )
    p.add_argument("claims", nargs="*", metavar="CLAIM_ID", help="claims to check (default: all; see --list)")
    p.add_argument("--list", action="store_true", help="list the claim ids and exit")
    add_scenario_option(p, default=None)  # None: --law refuses a scenario given explicitly
    add_case_option(p)
    p.add_argument(
        "--json",
        action="store_true",
        help="print JSON: an object with the list of the claims and the list of the errata of the paper (one object "
        "each) "
        '(with --law: one object, the law report, its checks in "checks")',
    )
    p.add_argument("--report", metavar="FILE.md", type=Path, help="also write a Markdown report with LaTeX")
    p.add_argument(
        "--region-sigma",
        type=float,
        default=default.sigma,
        metavar="R",
        help=f"Theorem 2 region: every component sigma_e,k within [-R, R] (default: {default.sigma:g})",
    )
    p.add_argument(
        "--region-omega",
        type=float,
        default=default.omega,
        metavar="R",
        help=f"Theorem 2 region: every component omega_e,k within [-R, R] rad/s (default: {default.omega:g})",
    )
    p.add_argument(
        "--samples",
        type=int,
        default=3000,
        metavar="N",
        help="random state samples per agent for Theorem 2, added to the grid (default: 3000)",
    )
    add_seed_option(p, "the random state samples")
    g = p.add_argument_group("a law instead of the paper's claims")
    g.add_argument(
        "--law",
        default=None,
        metavar="NAME|FILE.py|DIR",
        help="check this law (a built-in name, a derivation script or a folder written by fsmctl derive); a law "
        "has no documented finding: exit 1 on any failed check",
    )
    g.add_argument(
        "--error-model",
        choices=("paper", "exact"),
        default=None,
        help="with --law: the error kinematics of the checked variant (default: paper)",
    )
    p.add_argument(
        "--strict",
        action="store_true",
        help="exit 1 when any check fails or is not confirmed, a documented failure of the paper included "
        "(default: exit 1 only when a check differs from the documented finding)",
    )
    add_workers_option(p, what="worker processes of the symbolic checks, 1 = sequential")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run the proof check of Liang et al. 2012, Section 3 (eqs 7-41) for the chosen scenario.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed ``fsmctl prove`` options.

    Without claim ids, every erratum of the printed paper (:func:`fsmctl.proofs.errata.all_errata`) is checked
    and reported after the claims.

    Returns
    -------
    int
        0 every check as documented (``--strict``: every check passes), 1 a check differs from the documented
        finding (``--strict``: any check fails or is not confirmed); bad input raises
        :class:`fsmctl.cli.main.UsageError` (exit code 2).
    """
    from fsmctl.cli.main import UsageError  # one line, exit 2
    from fsmctl.proofs import report
    from fsmctl.proofs.claims import ProofContext, claim_ids, run_claims
    from fsmctl.proofs.errata import all_errata
    from fsmctl.proofs.theorem2 import Region

    if args.law is not None:
        return _run_law(args)
    if args.error_model is not None:
        raise UsageError("--error-model applies to --law only (the paper's claims use the scenario's)")
    if args.list:
        print(report.format_list())
        return 0
    known = claim_ids()
    unknown = [c for c in args.claims if c not in known]
    if unknown:
        raise UsageError(f"unknown claim id(s) {', '.join(unknown)}; known: {', '.join(known)}")
    for name, value in (("--region-sigma", args.region_sigma), ("--region-omega", args.region_omega)):
        if not (math.isfinite(value) and value >= 0):
            raise UsageError(f"{name} must be a finite number >= 0, got {value}")
    if args.region_sigma > 1:
        raise UsageError(f"--region-sigma must be <= 1 (MRPs of the shadow set), got {args.region_sigma}")
    if args.samples < 0:
        raise UsageError(f"--samples must be >= 0, got {args.samples}")
    scenario = _load(args.scenario or "paper", args.case)
    ctx = ProofContext(scenario, Region(args.region_sigma, args.region_omega), args.samples, args.seed)
    ids = list(dict.fromkeys(args.claims))
    results = run_claims(ids or None, ctx, workers=chosen_workers(args))
    errata = None if ids else all_errata()  # the full check: every erratum of the paper, from the one registry
    result = report.outcome(results, errata)
    if args.json:
        print(report.to_json(results, errata))
    else:
        print(result["line"])
        print(report.format_table(results, scenario, errata=errata))
    if args.report is not None:
        try:
            report.write_report(args.report, results, scenario, errata)
        except OSError as exc:
            raise UsageError(f"cannot write report {args.report}: {exc.strerror or exc}") from None
        if not args.json:
            print(f"report written to {args.report}", file=sys.stderr)
    if args.strict:
        if result["failing"] and not args.json:
            failing = result["failing"]
            print(f"--strict: exit 1: {len(failing)} check{'s' if len(failing) != 1 else ''} not passing "
                  f"({', '.join(failing)})", file=sys.stderr)  # fmt: skip
        return 1 if result["failing"] else 0
    return 0 if result["as_documented"] else 1


def _load(source: str, case: str | None):
    from fsmctl.model.scenario import load_scenario

    return load_scenario(source, case=case)


def _run_law(args: argparse.Namespace) -> int:
    """``fsmctl prove --law L``: the law's checks (:func:`fsmctl.proofs.law_check.check_law`); 0 if they pass."""
    import json

    from fsmctl.cli.main import UsageError
    from fsmctl.outputs import jsonable, write_text

    refused = [
        option
        for option, given in (
            ("CLAIM_ID", bool(args.claims)),
            ("--list", args.list),
            ("--scenario", args.scenario is not None),
            ("--case", args.case is not None),
        )
        if given
    ]
    if refused:
        raise UsageError(f"{', '.join(refused)} cannot be combined with --law (they select the paper's claims)")
    if args.samples < 0:
        raise UsageError(f"--samples must be >= 0, got {args.samples}")
    from fsmctl.proofs.law_check import check_law

    rep = check_law(args.law, error_model=args.error_model or "paper", samples=args.samples, seed=args.seed)
    if args.json:
        print(json.dumps(jsonable(rep.to_dict()), indent=2, allow_nan=False))
    else:
        print(rep.to_text())
    if args.report is not None:
        write_text(args.report, rep.to_markdown())  # atomic; an unwritable place is EnvironmentProblem (exit 2)
        if not args.json:
            print(f"report written to {args.report}", file=sys.stderr)
    return 0 if rep.ok else 1
