"""``fsmctl scenario show``: a scenario with every default filled in and where each value came from; flies nothing.

``fsmctl scenario show FILE|NAME [--case C] [--law L] [--set K=V ...] [--json]`` validates the scenario as
``simulate`` would (:func:`fsmctl.model.scenario_origin.show_scenario`: the same loading, ``--law`` and ``--set``)
and prints one line per value, ``key = value  (origin)``, the origin being ``--set``, ``case NAME``, ``file``,
``extends``, ``law default`` or ``default``; ``--json`` prints the self-contained scenario mapping and the value
and origin of every key.

Exit codes (:data:`EXIT_CODES`, :mod:`fsmctl.cli.exit_codes`): 0 the scenario is valid and was shown, 2 usage or
input error (an invalid scenario: the one-line error every command gives).
"""

from __future__ import annotations

import argparse
import json

from fsmctl.cli.exit_codes import epilog
from fsmctl.cli.law_options import add_law_options, law_changes
from fsmctl.cli.options import add_case_option

__all__ = ["add_parser", "run_show", "EXIT_CODES"]

EXIT_CODES = {0: "the scenario is valid and was shown (nothing is flown)"}
"""What ``fsmctl scenario``'s exit code 0 means (the others: :data:`fsmctl.cli.exit_codes.MEANINGS`)."""


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``fsmctl scenario`` and its subcommand ``show``.

    Parameters
    ----------
    subparsers : argparse subparsers action
        From :func:`fsmctl.cli.main.build_parser`.

    Returns
    -------
    argparse.ArgumentParser
        The ``scenario`` parser (its ``show`` subcommand sets ``func = run_show``).
    """
    p = subparsers.add_parser(
        "scenario",
        help="look at a scenario without flying it: every value and where it came from (scenario show)",
        description="Look at a scenario without flying it.",
        epilog=epilog(EXIT_CODES),
    )
    sub = p.add_subparsers(dest="scenario_command", metavar="SUBCOMMAND", parser_class=type(p))
    show = sub.add_parser(
        "show",
        help="the scenario with every default filled in and the origin of each value",
        description="Validate a scenario as fsmctl simulate would (the same --case, --law and --set) and print every "
        "value, defaults included, with where it came from: --set, the case, the file, its extends base, the law's "
        "declared default or fsmctl's built-in default. Nothing is flown.",
        epilog=epilog(EXIT_CODES),
    )
    show.add_argument(
        "source",
        metavar="FILE|NAME",
        help="a scenario file (TOML) or a built-in scenario name (paper, paper-hardware)",
    )
    add_case_option(show)
    show.add_argument("--json", action="store_true", help="print JSON: the scenario file's mapping and every origin")
    add_law_options(show, what="the scenario")
    show.set_defaults(func=run_show)
    p.set_defaults(func=_no_subcommand)
    return p


def _no_subcommand(args: argparse.Namespace) -> int:
    from fsmctl.cli.main import UsageError

    raise UsageError("which one? fsmctl scenario show FILE|NAME (see fsmctl scenario --help)")


def run_show(args: argparse.Namespace) -> int:
    """Run ``fsmctl scenario show``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options: ``source``, ``case``, ``law``, ``law_set``, ``json``.

    Returns
    -------
    int
        0; an invalid scenario raises :class:`fsmctl.model.scenario.ScenarioError` (exit 2).
    """
    from fsmctl.model.scenario_origin import show_scenario
    from fsmctl.outputs import jsonable

    law, parameters, controller = law_changes(args)
    shown = show_scenario(args.source, args.case, law=law, parameters=parameters, controller=controller)
    if args.json:
        print(json.dumps(jsonable(shown.to_dict()), indent=2, allow_nan=False))
    else:
        print("\n".join(shown.to_text()))
    return 0
