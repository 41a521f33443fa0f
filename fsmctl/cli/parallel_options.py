"""``--workers``, ``--dask`` and ``--dask-timeout``: where a command's runs are flown, defined once.

``--workers N`` (an integer >= 1) is the number of local worker processes of every command that runs things in
parallel (``prove``, ``reproduce``, ``compare-surfaces``, ``compare``, ``montecarlo``, ``tune``); the former
``--jobs`` of ``prove``, ``reproduce`` and ``compare-surfaces`` still works (:class:`fsmctl.cli.options.DeprecatedAlias`).
``--dask ADDRESS`` flies the runs on an existing Dask distributed scheduler instead (``montecarlo``, ``tune``),
and ``--dask-timeout S`` bounds how long the scheduler gets to accept the connection and answer
(:data:`fsmctl.studies.campaign.DASK_TIMEOUT_S` by default); an address that is not a Dask scheduler is one
line on stderr, exit 2.
"""

from __future__ import annotations

import argparse
from typing import Any

from fsmctl.cli.options import add_deprecated_alias
from fsmctl.cli.types import positive_float, positive_int

__all__ = ["add_workers_option", "add_dask_options"]


def add_workers_option(
    parser: argparse.ArgumentParser | Any,
    *,
    default: int | None,
    what: str,
    default_text: str | None = None,
    former_jobs: bool = False,
) -> argparse.Action:
    """Add ``--workers N`` (``args.workers``), the number of local worker processes.

    Parameters
    ----------
    parser : argparse.ArgumentParser or argument group
        Where the option goes.
    default : int or None
        The default (None: the command decides, e.g. all CPUs; say how in ``default_text``).
    what : str
        What the workers do, e.g. "local worker processes flying the runs".
    default_text : str, optional
        How the help states the default (default: the number).
    former_jobs : bool
        Also accept the former spelling ``--jobs`` (hidden, with a notice on stderr).

    Returns
    -------
    argparse.Action
        The option.
    """
    action = parser.add_argument(
        "--workers",
        type=positive_int,
        default=default,
        metavar="N",
        help=f"{what} (default: {default_text or default})",
    )
    if former_jobs:
        add_deprecated_alias(parser, "--jobs", action)
    return action


def add_dask_options(parser: argparse.ArgumentParser | Any, *, what: str) -> None:
    """Add ``--dask ADDRESS`` and ``--dask-timeout S`` (``args.dask``, ``args.dask_timeout``).

    Parameters
    ----------
    parser : argparse.ArgumentParser or argument group
        Where the options go.
    what : str
        What runs on the cluster, e.g. "the campaign's chunks".
    """
    from fsmctl.studies.campaign import DASK_TIMEOUT_S

    parser.add_argument(
        "--dask",
        metavar="ADDRESS",
        default=None,
        help=f"fly {what} on the Dask distributed scheduler at ADDRESS (e.g. tcp://host:8786) instead of local "
        "worker processes (default: local)",
    )
    parser.add_argument(
        "--dask-timeout",
        type=positive_float,
        default=DASK_TIMEOUT_S,
        metavar="S",
        help=f"seconds the scheduler gets to accept the connection and answer (default: {DASK_TIMEOUT_S:g})",
    )
