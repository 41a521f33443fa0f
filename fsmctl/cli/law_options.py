"""``--law`` and ``--set KEY=VALUE``: the control-law options shared by ``fsmctl simulate`` and ``fsmctl montecarlo``.

``--law NAME|FILE.py|DIR`` sets ``[controller] law`` (:func:`fsmctl.model.laws.resolve_law`: a built-in name,
a derivation script or a folder written by ``fsmctl derive``; the scenario's written keys that are the same parameter of the new
law carry over, the others are dropped, and a warning says which).  ``--set KEY=VALUE`` (repeatable) sets a law
parameter or preset choice by name for every agent (checked against what the law declares) or one of the
``[controller]`` keys every law shares (``torque_limit``, ``error_model``, ``enabled``); the value is read as a
TOML value:
``--set K=2.0 --set delta=[0.01,0.01,0.01] --set singularity_fix=clamp`` (a bare word is a string).
"""

from __future__ import annotations

import argparse
import dataclasses
import re
import tomllib
from typing import Any

__all__ = ["add_law_options", "key_value", "law_changes"]

_KEY = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_BARE_WORD = re.compile(r"^[A-Za-z_][A-Za-z0-9_.-]*$")
_OWN_KEYS_REFUSED = {"law": "use --law", "parameters": "set each parameter with its own --set NAME=VALUE"}


def add_law_options(parser: argparse.ArgumentParser, *, what: str = "the run") -> None:
    """Add ``--law`` and ``--set`` to a subcommand's parser (group "control law").

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The subcommand's parser.
    what : str
        What the law flies, for the help text.
    """
    g = parser.add_argument_group("control law")
    g.add_argument(
        "--law",
        default=None,
        metavar="NAME|FILE.py|DIR",
        help=f"law {what} flies: a built-in name (fsmctl laws), a derivation script or a folder written by "
        "fsmctl derive (default: the scenario's controller.law, 'fsm' = Liang et al. 2012)",
    )
    g.add_argument(
        "--set",
        dest="law_set",
        action="append",
        default=[],
        type=key_value,
        metavar="KEY=VALUE",
        help="a law parameter (or [controller] key) as a TOML value, e.g. --set K=2.0 "
        "--set delta=[0.01,0.01,0.01]; repeatable, the last one of a key wins",
    )


def key_value(text: str) -> tuple[str, Any]:
    """Parse ``KEY=VALUE`` with a TOML value (an unquoted word is a string); an argparse ``type``.

    Parameters
    ----------
    text : str
        The option's argument.

    Returns
    -------
    tuple of (str, object)
        The key and the parsed value (number, list, string, boolean).

    Raises
    ------
    argparse.ArgumentTypeError
        No ``=``, a key that is not an identifier, or a value that is not a TOML value.
    """
    key, sep, raw = text.partition("=")
    key, raw = key.strip(), raw.strip()
    if not sep or not _KEY.match(key):
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE with KEY a parameter name, got {text!r}")
    if not raw:
        raise argparse.ArgumentTypeError(f"{key}: no value after '='")
    try:
        parsed = tomllib.loads(f"v = {raw}")
    except tomllib.TOMLDecodeError:
        parsed = None
    if parsed is None or set(parsed) != {"v"}:
        if _BARE_WORD.match(raw):
            return key, raw  # a choice such as clamp, without TOML's quotes
        raise argparse.ArgumentTypeError(
            f"{key}: {raw!r} is not a TOML value (a number, a [list] of numbers or a string)"
        )
    return key, parsed["v"]


def law_changes(args: argparse.Namespace) -> tuple[str | None, dict[str, Any], dict[str, Any]]:
    """What ``--law``/``--set`` ask for, for :meth:`fsmctl.model.scenario.Scenario.with_law` and ``replace``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options with ``law`` and ``law_set``.

    Returns
    -------
    law : str or None
        ``--law`` (None: the scenario's).
    parameters : dict
        The law parameters and preset choices ``--set`` names (set for every agent).
    controller : dict
        The ``[controller]`` keys of their own that ``--set`` names (``torque_limit``, ``error_model``, ``enabled``).

    Raises
    ------
    fsmctl.cli.main.UsageError
        ``--set law=...`` or ``--set parameters=...``.
    """
    from fsmctl.cli.main import UsageError
    from fsmctl.model.scenario import ControllerSettings

    own = {f.name for f in dataclasses.fields(ControllerSettings)}
    parameters, controller = {}, {}
    for key, value in dict(getattr(args, "law_set", None) or []).items():
        if key in _OWN_KEYS_REFUSED:
            raise UsageError(f"--set {key}=...: {_OWN_KEYS_REFUSED[key]}")
        (controller if key in own else parameters)[key] = value
    return getattr(args, "law", None), parameters, controller
