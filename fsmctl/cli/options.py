"""Options several ``fsmctl`` subcommands share, defined once: one name, metavar, type and help wording each.

=======================  ==========================================================================================
option                   meaning (the same in every subcommand that has it)
=======================  ==========================================================================================
``--scenario``           a built-in scenario name or a TOML file (``NAME|FILE.toml``)
``--case``               a case of the scenario (default: its first)
``--out DIR``            the output folder
``--no-figures``         skip the PNG/SVG figures
``--progress``           progress bar on stderr (``--no-progress``: none; default: on a terminal)
``--t-final S``          horizon in s
``--dt S``               integration step in s
``--output-interval S``  spacing of the output samples in s
``--torque-limit N_M``   per-axis torque bound in N m (``inf``: none)
``--steady-window S``    final window of the steady-state statistics in s
``--tolerance-deg DEG``  AAEM/RAEM tolerance in deg
``--seed N``             a seed (an integer >= 0) of the command's own random draws
=======================  ==========================================================================================

The other shared options live with their kind: ``--law``/``--set`` in :mod:`fsmctl.cli.law_options`,
``--control-period`` and a run's noise ``--seed`` in :mod:`fsmctl.cli.run_options`, ``--workers``, ``--dask`` and
``--dask-timeout`` in :mod:`fsmctl.cli.parallel_options`.  Numbers of the scenario's settings are parsed here
(finite numbers, ``inf`` spelled out) and judged by the layer that owns them (the scenario, the campaign, the
study), whose one-line error names the key.

:class:`HelpFormatter` lays out every ``--help`` (descriptions wrapped, indented epilog lines kept as lists).
An option has one spelling (fsmctl is 0.x: a renamed option is renamed everywhere, with no hidden alias).
"""

from __future__ import annotations

import argparse
import re
import textwrap
from pathlib import Path
from typing import Any

from fsmctl.cli.types import finite_or_inf_float, nonnegative_int, torque_limit
from fsmctl.policy import STEADY_WINDOW_FRACTION, STEADY_WINDOW_MAX_S

__all__ = [
    "STEADY_WINDOW_TEXT",
    "HelpFormatter",
    "add_scenario_option",
    "add_case_option",
    "add_out_option",
    "add_figures_option",
    "add_progress_option",
    "add_t_final_option",
    "add_dt_option",
    "add_output_interval_option",
    "add_torque_limit_option",
    "add_steady_window_option",
    "add_tolerance_deg_option",
    "add_seed_option",
]

STEADY_WINDOW_TEXT = (
    f"the last {100 * STEADY_WINDOW_FRACTION:g} percent of the horizon, at most {STEADY_WINDOW_MAX_S:g} s"
)
"""How a help states the default steady window (:func:`fsmctl.policy.default_steady_window`; no ``%``: argparse
formats help texts)."""

_TERM_GAP = re.compile(r"\s{2,}")


class HelpFormatter(argparse.HelpFormatter):
    """argparse's formatter, with descriptions and epilogs laid out as short plain text.

    Paragraphs (separated by blank lines) are wrapped to the terminal (a final ``::``, which introduces a literal
    block in reStructuredText, reads ``:`` as it does there).  A bullet (a line starting with ``- ``) is
    wrapped on its own, its continuation lines under its text; an indented line is a list item, wrapped on its
    own with its continuation lines aligned after the item's term (the last run of two or more spaces within
    the first 40 columns), and a more indented line that follows continues it; so the ``exit codes:`` list and
    tables of terms stay readable.
    """

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        width = max(width, 20)
        out: list[str] = []
        paragraph: list[str] = []
        item: list = []  # [lead, hang, text]: the list item being collected

        def flush() -> None:
            if paragraph:
                text = " ".join(paragraph)
                text = text[:-1] if text.endswith("::") else text  # reStructuredText's "text::" reads "text:"
                out.append(textwrap.fill(text, width, initial_indent=indent, subsequent_indent=indent))
                paragraph.clear()
            if item:
                lead, hang, body = item
                out.append(
                    textwrap.fill(
                        body,
                        width,
                        initial_indent=indent + " " * lead,
                        subsequent_indent=indent + " " * min(hang, width // 2),
                        break_on_hyphens=False,
                        break_long_words=False,
                    )
                )
                item.clear()

        for block in re.split(r"\n[ \t]*\n", text.strip("\n")):
            for line in block.splitlines():
                if not line.strip():
                    continue
                body = line.strip()
                lead = len(line) - len(line.lstrip())
                if not lead and body.startswith("- "):  # a bullet
                    flush()
                    item.extend([0, 2, body])
                    continue
                if not lead:
                    if item:
                        flush()
                    paragraph.append(body)
                    continue
                if item and lead > item[0] and lead >= item[1]:  # a continuation line of the item
                    item[2] += " " + body
                    continue
                flush()
                gaps = [m.end() for m in _TERM_GAP.finditer(body) if m.end() <= 40]
                item.extend([lead, lead + (gaps[-1] if gaps else 0), line.lstrip()])
            flush()
            out.append("")
        return "\n".join(out).rstrip("\n")


def add_scenario_option(
    parser: argparse.ArgumentParser | Any, *, default: str | None = "paper", note: str = ""
) -> None:
    """Add ``--scenario NAME|FILE.toml`` (a built-in scenario or a TOML file; shown default: paper).

    Parameters
    ----------
    parser : argparse.ArgumentParser or argument group
        Where the option goes.
    default : str or None
        The parsed default (None lets the command tell "not given" from ``paper``; it then uses ``paper``).
    note : str
        What the scenario must hold for this command, appended to the help.
    """
    from fsmctl.model.scenario import BUILTIN_SCENARIOS

    names = ", ".join(BUILTIN_SCENARIOS)
    parser.add_argument(
        "--scenario",
        default=default,
        metavar="NAME|FILE.toml",
        help=f"a built-in scenario ({names}) or a scenario file{' ' + note if note else ''} (default: paper)",
    )


def add_case_option(parser: argparse.ArgumentParser | Any) -> None:
    """Add ``--case CASE`` (a case of the scenario; default: its first).

    Parameters
    ----------
    parser : argparse.ArgumentParser or argument group
        Where the option goes.
    """
    parser.add_argument(
        "--case",
        default=None,
        metavar="CASE",
        help="case of the scenario (default: its first case; the paper's are 1, 2, 3a, 3b, 3c; a file without "
        "[cases] is used as it is)",
    )


def add_out_option(
    parser: argparse.ArgumentParser | Any, default: str | None, *, help: str | None = None
) -> argparse.Action:
    """Add ``--out DIR``, the output folder.

    Parameters
    ----------
    parser : argparse.ArgumentParser or argument group
        Where the option goes.
    default : str or None
        The default folder, relative to the current one (None: the command chooses; give ``help`` then).
    help : str, optional
        The help text (default: "output folder (default: ./DEFAULT)").

    Returns
    -------
    argparse.Action
        The option.
    """
    return parser.add_argument(
        "--out",
        type=Path,
        default=None if default is None else Path(default),
        metavar="DIR",
        help=help or f"output folder (default: ./{default})",
    )


def add_figures_option(parser: argparse.ArgumentParser | Any) -> None:
    """Add ``--no-figures`` (skip the PNG/SVG figures; ``args.no_figures``).

    Parameters
    ----------
    parser : argparse.ArgumentParser or argument group
        Where the option goes.
    """
    parser.add_argument("--no-figures", action="store_true", help="skip the PNG/SVG figures")


def add_progress_option(parser: argparse.ArgumentParser | Any, what: str = "over the runs") -> None:
    """Add ``--progress/--no-progress`` (``args.progress``: True, False or None = on a terminal).

    Parameters
    ----------
    parser : argparse.ArgumentParser or argument group
        Where the option goes.
    what : str
        What the bar follows, e.g. "over the runs".
    """
    parser.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help=f"progress bar {what} on stderr (default: on a terminal)",
    )


def _scenario_number(parser, flag: str, metavar: str, what: str, default: Any, default_text: str | None) -> None:
    parser.add_argument(
        flag,
        type=finite_or_inf_float,
        default=default,
        metavar=metavar,
        help=f"{what} (default: {default_text or default})",
    )


def add_t_final_option(parser: argparse.ArgumentParser | Any, default_text: str = "the scenario's") -> None:
    """Add ``--t-final S``, the horizon in s (``args.t_final``, None: the scenario's).

    Parameters
    ----------
    parser : argparse.ArgumentParser or argument group
        Where the option goes.
    default_text : str
        What None means for this command.
    """
    _scenario_number(parser, "--t-final", "S", "horizon in s", None, default_text)


def add_dt_option(parser: argparse.ArgumentParser | Any) -> None:
    """Add ``--dt S``, the integration step in s (``args.dt``, None: the scenario's).

    Parameters
    ----------
    parser : argparse.ArgumentParser or argument group
        Where the option goes.
    """
    _scenario_number(parser, "--dt", "S", "integration step in s", None, "the scenario's")


def add_output_interval_option(
    parser: argparse.ArgumentParser | Any, default: float | None = None, note: str = ""
) -> None:
    """Add ``--output-interval S``, the spacing of the output samples in s.

    Parameters
    ----------
    parser : argparse.ArgumentParser or argument group
        Where the option goes.
    default : float or None
        The default (None: the scenario's, or its horizon if shorter).
    note : str
        How the command adjusts it, appended to the help.
    """
    what = "spacing of the output samples in s" + (f", {note}" if note else "")
    _scenario_number(parser, "--output-interval", "S", what, default, None if default is not None else "the scenario's")


def add_torque_limit_option(parser: argparse.ArgumentParser | Any, note: str = "") -> None:
    """Add ``--torque-limit N_M|inf``, the per-axis torque bound (``args.torque_limit``, None: the scenario's).

    Parameters
    ----------
    parser : argparse.ArgumentParser or argument group
        Where the option goes.
    note : str
        A remark appended to the help.
    """
    parser.add_argument(
        "--torque-limit",
        type=torque_limit,
        default=None,
        metavar="N_M|inf",
        help="per-axis torque bound in N m, inf for none"
        + (f"; {note}" if note else "")
        + " (default: the scenario's)",
    )


def add_steady_window_option(
    parser: argparse.ArgumentParser | Any, default: float | None, default_text: str | None = None
) -> None:
    """Add ``--steady-window S``, the final window of the steady-state statistics in s.

    Parameters
    ----------
    parser : argparse.ArgumentParser or argument group
        Where the option goes.
    default : float or None
        The default.
    default_text : str, optional
        How the help states the default (default: the number; for None, :data:`STEADY_WINDOW_TEXT`).
    """
    what = "final window of the steady-state statistics in s"
    text = default_text or (STEADY_WINDOW_TEXT if default is None else f"{default:g}")
    _scenario_number(parser, "--steady-window", "S", what, default, text)


def add_tolerance_deg_option(parser: argparse.ArgumentParser | Any, what: str, default: float) -> None:
    """Add ``--tolerance-deg DEG``, an AAEM/RAEM tolerance in deg.

    Parameters
    ----------
    parser : argparse.ArgumentParser or argument group
        Where the option goes.
    what : str
        What the tolerance decides for this command.
    default : float
        The default, in deg.
    """
    _scenario_number(parser, "--tolerance-deg", "DEG", f"{what}, in deg", default, f"{default:g}")


def add_seed_option(parser: argparse.ArgumentParser | Any, what: str, default: int = 0) -> None:
    """Add ``--seed N`` (``args.seed``), the seed of the command's own random draws (an integer >= 0).

    A run's noise seed (``simulation.seed``) is :mod:`fsmctl.cli.run_options`'s ``--seed`` (``args.noise_seed``).

    Parameters
    ----------
    parser : argparse.ArgumentParser or argument group
        Where the option goes.
    what : str
        What the seed draws, e.g. "the search and the ensemble".
    default : int
        The default seed.
    """
    parser.add_argument(
        "--seed",
        type=nonnegative_int,
        default=default,
        metavar="N",
        help=f"seed of {what} (an integer >= 0; the same seed gives the same result; default: {default})",
    )
