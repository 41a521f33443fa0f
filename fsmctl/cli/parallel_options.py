"""``--workers``, ``--dask`` and ``--dask-timeout``: where a command's runs are flown, defined once.

``--workers N`` (an integer >= 1) is the number of local workers of every command that runs things in parallel
(``prove``, ``reproduce``, ``compare-surfaces``, ``compare``, ``montecarlo``, ``tune``).  One rule for its default,
whatever the command: one worker per CPU this process may use (:func:`fsmctl.policy.default_workers`, resolved when
the command runs: :func:`chosen_workers`), and a study never starts more workers than it has tasks at once.  The
worker count changes the speed only, never a result.  ``--dask ADDRESS`` flies the runs on an existing Dask
distributed scheduler instead (``montecarlo``, ``tune``), and ``--dask-timeout S`` bounds how long the scheduler gets
to accept the connection and answer (:data:`fsmctl.policy.DASK_TIMEOUT_S` by default); an address that is not a
Dask scheduler is one line on stderr, exit 2.
"""

from __future__ import annotations

import argparse
from typing import Any

from fsmctl.cli.types import positive_float, positive_int
from fsmctl.policy import DASK_TIMEOUT_S, default_workers

__all__ = ["WORKERS_DEFAULT_TEXT", "add_workers_option", "chosen_workers", "add_dask_options"]

WORKERS_DEFAULT_TEXT = "one per CPU this process may use, at most one per task; the results do not depend on it"
"""How every ``--workers`` help states its default (:func:`fsmctl.policy.default_workers`)."""


def add_workers_option(parser: argparse.ArgumentParser | Any, *, what: str) -> argparse.Action:
    """Add ``--workers N`` (``args.workers``; None when not given: see :func:`chosen_workers`).

    Parameters
    ----------
    parser : argparse.ArgumentParser or argument group
        Where the option goes.
    what : str
        What the workers do, e.g. "local worker processes flying the runs".

    Returns
    -------
    argparse.Action
        The option.
    """
    return parser.add_argument(
        "--workers",
        type=positive_int,
        default=None,  # resolved when the command runs, so that --help and the docs do not show this machine's CPUs
        metavar="N",
        help=f"{what} (default: {WORKERS_DEFAULT_TEXT})",
    )


def chosen_workers(args: argparse.Namespace) -> int:
    """The number of workers a command starts: ``--workers N``, else :func:`fsmctl.policy.default_workers`.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options of a command with ``--workers``.

    Returns
    -------
    int
        A whole number >= 1.
    """
    return default_workers() if args.workers is None else args.workers


def add_dask_options(parser: argparse.ArgumentParser | Any, *, what: str) -> None:
    """Add ``--dask ADDRESS`` and ``--dask-timeout S`` (``args.dask``, ``args.dask_timeout``).

    Parameters
    ----------
    parser : argparse.ArgumentParser or argument group
        Where the options go.
    what : str
        What runs on the cluster, e.g. "the campaign's chunks".
    """
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
