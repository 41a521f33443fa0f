"""The ``fsmctl`` command line.

Subcommands live in their own modules, each exposing ``add_parser(subparsers)``
(which sets ``func`` on its parser) so this file only dispatches:

============================  ======================================================================
``fsmctl prove``              proof check of Section 3, or of a law (``--law``) (:mod:`fsmctl.cli.prove`)
``fsmctl certify``            a Lyapunov certificate for a law over a region (:mod:`fsmctl.cli.certify`)
``fsmctl simulate``           one scenario/case, any law (:mod:`fsmctl.cli.commands`)
``fsmctl reproduce``          Section 4 reproduction report (:mod:`fsmctl.cli.reproduce`)
``fsmctl compare-surfaces``   FSM vs TSM vs LSM, Theorem 3 (:mod:`fsmctl.cli.surfaces`)
``fsmctl compare``            laws compared on one scenario (:mod:`fsmctl.cli.compare`)
``fsmctl montecarlo``         robustness campaigns (:mod:`fsmctl.cli.montecarlo`)
``fsmctl tune``               search a law's parameters under the actuator limits (:mod:`fsmctl.cli.tune`)
``fsmctl laws``               the built-in laws and their parameters (:mod:`fsmctl.cli.laws`)
``fsmctl derive``             check and generate a law from a derivation script (:mod:`fsmctl.cli.derive`)
``fsmctl export``             a law as C99 or an FMU, checked in the loop; results as CCSDS AEM (:mod:`fsmctl.cli.export`)
``fsmctl scenario show``      a scenario with every default and where each value came from (:mod:`fsmctl.cli.scenario`)
============================  ======================================================================

The library below (:mod:`fsmctl.studies` and down) never imports this package; it raises
:class:`fsmctl.errors.InputError` (and subclasses), which :func:`main` turns into one line and exit code 2.
:class:`UsageError` is for the command-line modules only (``.importlinter``, ``tests/test_layers.py``).

Exit codes: :func:`main` decides them (the one place), :mod:`fsmctl.cli.exit_codes` names them and says what each
one means (:data:`~fsmctl.cli.exit_codes.MEANINGS`); every subcommand's ``--help`` ends with that list, in the
command's own words where they differ (:func:`fsmctl.cli.exit_codes.epilog`).

====  =========================================================================================
0     success (every check as documented, the run finished, the files were written, the law
      folder is up to date)
1     a check differs from the documented finding (``prove --strict``: fails; a law check fails),
      a simulation failed (non-finite state, ...), a law folder
      is stale (``fsmctl derive --check``), or an internal error (one line; ``--debug`` shows
      the traceback)
2     usage, input or environment error: a bad option or scenario file, an unknown law or a
      derivation script that does not derive, a file that is not UTF-8 or not an fsmctl result
      (``--from``), an unusable output folder (read-only, full, or an existing folder that is not
      a law's for ``fsmctl derive``), a run that would exceed the memory, an address that is not
      a Dask scheduler (one line on stderr, never a traceback)
130   interrupted (Ctrl-C / SIGINT); finished outputs are kept, partial files are not written
143   terminated (SIGTERM); as for 130
====  =========================================================================================

Messages: the library reports what it is doing on the ``fsmctl`` logger (e.g. the one-time notice that the
generated C is being compiled, ~10 s); :func:`main` shows its INFO records as one line each on stderr, prefixed
``fsmctl: `` (``--debug``: DEBUG records too; ``--quiet``: warnings and errors only).

``--debug`` (or ``FSMCTL_DEBUG=1``) lets every exception propagate with its traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import importlib
import logging
import os
import signal
import sys
import warnings

from fsmctl.cli.exit_codes import EXIT_FAILED, EXIT_INPUT, EXIT_INTERRUPTED, EXIT_OK, EXIT_TERMINATED, epilog
from fsmctl.cli.options import HelpFormatter
from fsmctl.errors import EnvironmentProblem, InputError
from fsmctl.suggest import did_you_mean

__all__ = [
    "main",
    "build_parser",
    "UsageError",
    "SUBCOMMAND_MODULES",
    "EXIT_OK",
    "EXIT_FAILED",
    "EXIT_INPUT",
    "EXIT_INTERRUPTED",
    "EXIT_TERMINATED",
]

SUBCOMMAND_MODULES = (
    "fsmctl.cli.prove",
    "fsmctl.cli.certify",
    "fsmctl.cli.commands",
    "fsmctl.cli.reproduce",
    "fsmctl.cli.surfaces",
    "fsmctl.cli.compare",
    "fsmctl.cli.montecarlo",
    "fsmctl.cli.tune",
    "fsmctl.cli.laws",
    "fsmctl.cli.derive",
    "fsmctl.cli.export",
    "fsmctl.cli.scenario",
)
"""Modules of the subcommands, in the order ``fsmctl --help`` lists them; each has ``add_parser(subparsers)``
(which sets ``func`` on its parser).  A module missing from a build is skipped."""


class UsageError(InputError):
    """Bad command-line input detected by a subcommand: printed as one line, exit code 2.

    Only the command-line modules raise it; library code raises :class:`fsmctl.errors.InputError`.
    """


class Terminated(BaseException):
    """SIGTERM, turned into an exception so that ``finally`` blocks (temporary files, workers) run."""


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (exit 2), "did you mean" for a misspelled subcommand or option
    (:mod:`fsmctl.suggest`), and :class:`fsmctl.cli.options.HelpFormatter` for every ``--help``."""

    def __init__(self, *args, formatter_class=HelpFormatter, **kwargs):
        kwargs.setdefault("allow_abbrev", False)  # --scenari is a misspelling, not --scenario
        super().__init__(*args, formatter_class=formatter_class, **kwargs)

    def error(self, message):  # one line, exit 2 (argparse's default prints usage too)
        self.exit(EXIT_INPUT, f"{self.prog}: error: {message}\n")

    def parse_args(self, args=None, namespace=None):  # the top-level parser: its subparsers parse_known_args
        args = list(sys.argv[1:] if args is None else args)
        self._check_subcommands(args)
        parsed, extras = self.parse_known_args(args, namespace)
        if extras:
            sub = self._subcommands().get(getattr(parsed, "command", None), self)
            while (inner := sub._subcommands()) and (chosen := getattr(parsed, sub._subcommand_dest(), None)):
                sub = inner[chosen]  # fsmctl scenario show: the innermost subcommand's options
            self.exit(EXIT_INPUT, f"{sub.prog}: {_unknown_argument(extras[0], sub)}\n")
        return parsed

    def _check_subcommands(self, args: list[str]) -> None:
        """A misspelled subcommand, at any depth (``fsmctl simulat``, ``fsmctl scenario shw``): one line, exit 2.

        The top-level options are flags, and a command with subcommands takes no positional argument before its
        subcommand: at each level the first word that is not an option names the subcommand."""
        parser, rest = self, args
        while commands := parser._subcommands():
            at = next((i for i, a in enumerate(rest) if not a.startswith("-")), None)
            if at is None:
                return
            word = rest[at]
            if word not in commands:
                hint = did_you_mean(word, commands)
                self.exit(EXIT_INPUT, f"{parser.prog}: unknown command {word!r}{f' ({hint})' if hint else ''}\n")
            parser, rest = commands[word], rest[at + 1 :]

    def _subcommands(self) -> dict[str, argparse.ArgumentParser]:
        """The subcommands' parsers by name (empty for a parser without subcommands)."""
        for action in self._actions:
            if isinstance(action, argparse._SubParsersAction):
                return dict(action.choices)
        return {}

    def _subcommand_dest(self) -> str:
        """Where the chosen subcommand's name goes (``command``, ``scenario_command``)."""
        return next(a.dest for a in self._actions if isinstance(a, argparse._SubParsersAction))


def _unknown_argument(word: str, parser: argparse.ArgumentParser) -> str:
    """``unknown option --t-finall (did you mean --t-final?)``, or ``unexpected argument 'x'``."""
    if not word.startswith("-"):
        return f"unexpected argument {word!r}"
    option = word.split("=", 1)[0]
    hint = did_you_mean(option, [o for a in parser._actions for o in a.option_strings if o.startswith("--")])
    return f"unknown option {option}{f' ({hint})' if hint else ''}"


def build_parser() -> argparse.ArgumentParser:
    """The ``fsmctl`` parser with every subcommand of :data:`SUBCOMMAND_MODULES` (each sets ``func``).

    Returns
    -------
    argparse.ArgumentParser
        The parser; its subcommands are the choices of its subparsers action.  The documentation's command
        pages are generated from it (sphinx-argparse).
    """
    parser = _Parser(
        prog="fsmctl",
        description="Spacecraft-formation attitude control laws, from Liang, Sun & Wang (2012)'s fast sliding mode: "
        "prove, simulate, reproduce, compare; list the laws, derive your own.",
        epilog=epilog({0: "success (what success is: see the command's --help)", 1: "the command reports a failure"}),
    )
    from fsmctl import __version__

    parser.add_argument("--version", action="version", version=f"fsmctl {__version__}")
    parser.add_argument(
        "--debug",
        action="store_true",
        default=os.environ.get("FSMCTL_DEBUG", "") not in ("", "0"),
        help="show tracebacks instead of one-line errors, and the library's DEBUG messages (also FSMCTL_DEBUG=1)",
    )
    parser.add_argument(
        "--quiet",
        action="store_true",
        help="show only warnings and errors on stderr, not the library's notices (such as the first compile of "
        "the generated C)",
    )
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
    """Exceptions that are the user's input or environment: one line, exit 2."""
    from fsmctl.errors import InputError
    from fsmctl.symbolic.symbols import DerivationInputError

    return (InputError, DerivationInputError, OSError, MemoryError, UnicodeError)


def _one_line(exc: BaseException) -> str:
    if isinstance(exc, MemoryError):
        return f"out of memory{': ' + str(exc) if str(exc) else ''} (shorten t_final or enlarge output_interval)"
    if isinstance(exc, EnvironmentProblem) and exc.strerror:
        return exc.strerror  # already "cannot <action> <path>: <reason>"
    if isinstance(exc, OSError) and exc.strerror:
        if exc.filename:
            return f"{exc.strerror}: {exc.filename}"
        return (
            f"cannot write output: {exc.strerror}"
            if exc.errno in (errno.ENOSPC, errno.EROFS, errno.EIO)
            else exc.strerror
        )
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text


_handler_pid: int | None = None
"""the process that installed :func:`_raise_terminated` (a forked worker inherits the handler, not the role)"""


def _raise_terminated(signum, frame):
    if os.getpid() != _handler_pid:  # a forked child (a worker) inherited the handler: die as SIGTERM would
        os._exit(128 + signum)
    raise Terminated


class _StderrHandler(logging.Handler):
    """Writes each record as one line to the current ``sys.stderr`` (pytest and callers may swap it)."""

    def emit(self, record: logging.LogRecord) -> None:
        try:
            sys.stderr.write(self.format(record) + "\n")
            sys.stderr.flush()
        except Exception:  # a closed stderr must not turn a notice into a failure
            self.handleError(record)


class _OneLineFormatter(logging.Formatter):
    """``fsmctl: <message>`` on one line (``fsmctl: warning: ...`` at WARNING and above); no timestamps."""

    def __init__(self, *, tracebacks: bool) -> None:
        super().__init__()
        self.tracebacks = tracebacks

    def format(self, record: logging.LogRecord) -> str:
        text = " ".join(record.getMessage().split())
        if record.levelno >= logging.ERROR:
            text = f"error: {text}"
        elif record.levelno >= logging.WARNING:
            text = f"warning: {text}"
        line = f"fsmctl: {text}"
        if self.tracebacks and record.exc_info:
            line += "\n" + self.formatException(record.exc_info)
        return line


@contextlib.contextmanager
def _library_messages(*, debug: bool, quiet: bool):
    """Show the ``fsmctl`` logger's records on stderr for the duration of a command, then restore it.

    INFO and above by default (e.g. "compiling the generated C ... (first use, ~10 s)"), DEBUG with ``--debug``,
    WARNING and above with ``--quiet``.
    """
    logger = logging.getLogger("fsmctl")
    handler = _StderrHandler()
    handler.setFormatter(_OneLineFormatter(tracebacks=debug))
    previous = logger.level
    logger.setLevel(logging.DEBUG if debug else logging.WARNING if quiet else logging.INFO)
    logger.addHandler(handler)
    try:
        yield
    finally:
        logger.removeHandler(handler)
        logger.setLevel(previous)


def main(argv: list[str] | None = None) -> int:
    """Run the ``fsmctl`` command line; returns the exit code (see the module docstring).

    Parameters
    ----------
    argv : list of str, optional
        The arguments after ``fsmctl`` (default: ``sys.argv[1:]``); recorded as ``args.argv`` (with ``fsmctl``
        first) for the files that embed their command line.

    Returns
    -------
    int
        The exit code (:mod:`fsmctl.cli.exit_codes`).
    """
    parser = build_parser()
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parser.parse_args(argv)
    if getattr(args, "func", None) is None:
        parser.print_help()
        return EXIT_INPUT
    args.argv = ["fsmctl", *argv]
    with _library_messages(debug=args.debug, quiet=args.quiet):
        return _run(args)


def _warning_line(message, category, filename, lineno, file=None, line=None) -> None:
    """A Python warning during a command: one line through the ``fsmctl`` logger (``fsmctl: warning: ...``), where
    it comes from only with ``--debug``."""
    text = " ".join(str(message).split())
    logging.getLogger("fsmctl").warning("%s: %s", category.__name__, text)
    logging.getLogger("fsmctl").debug("  (raised at %s:%s)", filename, lineno)


def _run(args: argparse.Namespace) -> int:
    """Run the chosen subcommand and turn what it raises into one line and an exit code."""
    errors = _input_errors()
    name = f"fsmctl {args.command}"
    previous = None
    with contextlib.suppress(ValueError):  # not the main thread: leave SIGTERM alone
        global _handler_pid
        _handler_pid = os.getpid()
        previous = signal.signal(signal.SIGTERM, _raise_terminated)
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("once")
            # an unclosed file or socket collected during the command is the developer's notice, not the user's
            warnings.filterwarnings("ignore", category=ResourceWarning)
            warnings.showwarning = _warning_line  # one line on stderr, as the library's notices
            code = int(args.func(args) or 0)
        try:
            sys.stdout.flush()  # a full or closed stdout is reported here, not at exit
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise EnvironmentProblem(exc.errno, f"cannot write to standard output: {exc.strerror}") from None
        return code
    except KeyboardInterrupt:
        if args.debug:
            raise
        print(f"{name}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Terminated:
        if args.debug:
            raise
        print(f"{name}: terminated", file=sys.stderr)
        return EXIT_TERMINATED
    except BrokenPipeError:
        # the reader went away (`fsmctl prove --list | head -1`): stop quietly
        with contextlib.suppress(OSError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_FAILED
    except errors as exc:
        if args.debug:
            raise
        print(f"{name}: error: {_one_line(exc)}", file=sys.stderr)
        return EXIT_INPUT
    except Exception as exc:  # a bug: one line, and the traceback behind --debug
        if args.debug:
            raise
        print(
            f"{name}: internal error: {type(exc).__name__}: {_one_line(exc)} (run with --debug for the traceback)",
            file=sys.stderr,
        )
        return EXIT_FAILED
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def console_main() -> None:
    """Entry point of the ``fsmctl`` console script: exit with :func:`main`'s code, stdout flushed safely."""
    code = main()
    try:
        sys.stdout.flush()
    except OSError:
        with contextlib.suppress(OSError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        code = code or EXIT_INPUT
    sys.exit(code)


if __name__ == "__main__":
    console_main()
