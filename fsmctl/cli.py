"""The ``fsmctl`` command line.

Subcommands live in their own modules, each exposing ``add_parser(subparsers)``
(which sets ``func`` on its parser) so this file only dispatches:

========================  ===============================================
``fsmctl prove``          proof check of Section 3 (:mod:`fsmctl.proofs.cli`)
``fsmctl simulate``       one scenario/case (:mod:`fsmctl.commands`)
``fsmctl reproduce``      Section 4 reproduction report (:mod:`fsmctl.reproduce`)
``fsmctl compare-surfaces``  FSM vs TSM vs LSM (:mod:`fsmctl.surfaces`)
``fsmctl montecarlo``     robustness campaigns (:mod:`fsmctl.montecarlo`)
========================  ===============================================

Exit codes: 0 success, 1 a check failed or a run did not meet its claim,
2 usage or input error (one line on stderr, never a traceback).
"""

from __future__ import annotations

import argparse
import importlib
import sys
import warnings

__all__ = ["main", "UsageError", "SUBCOMMAND_MODULES"]

SUBCOMMAND_MODULES = (
    "fsmctl.proofs.cli",
    "fsmctl.commands",
    "fsmctl.reproduce",
    "fsmctl.surfaces",
    "fsmctl.montecarlo",
)


class UsageError(Exception):
    """Bad input detected by a subcommand: printed as one line, exit code 2."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2 (argparse's default prints usage too)
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="fsmctl",
        description="Fast-sliding-mode formation attitude control (Liang, Sun & Wang 2012): prove, simulate, reproduce.",
    )
    from . import __version__

    parser.add_argument("--version", action="version", version=f"fsmctl {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name in SUBCOMMAND_MODULES:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name == name:
                continue  # subcommand not present in this build
            raise
        module.add_parser(sub)
    return parser


def _input_errors() -> tuple[type[BaseException], ...]:
    from derive.symbols import DerivationInputError

    from .scenario import ScenarioError
    from .topology import TopologyError

    return (UsageError, ScenarioError, TopologyError, DerivationInputError, FileNotFoundError)


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "func", None) is None:
        parser.print_help()
        return 2
    errors = _input_errors()
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("once")
            return int(args.func(args) or 0)
    except errors as exc:
        print(f"fsmctl {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"fsmctl {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
