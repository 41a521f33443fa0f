"""``--control-period`` and ``--seed``: the sampled-control options shared by ``fsmctl simulate``, ``compare`` and
``montecarlo``.

``--control-period SECONDS`` sets ``simulation.control_period`` (0 = continuous control; > 0: the law runs every
``SECONDS`` and its torque is held in between, as flight software does; sensors and imperfect links need it).
``--seed N`` sets ``simulation.seed``, the seed of the run's random processes (sensor noise, packet losses).
Both are applied with ``scenario.replace(simulation=...)``, so the scenario's validators judge them (a multiple
of ``dt``, ``>= 0``, a whole number): a bad value is one line naming the key, exit 2.  ``fsmctl montecarlo`` keeps
its own ``--seed`` (the campaign seed, from which every run's noise seed derives) and takes ``--control-period``
from here.
"""

from __future__ import annotations

import argparse
from typing import Any

from fsmctl.cli.types import number

__all__ = ["add_run_options", "simulation_changes"]


def add_run_options(parser: argparse.ArgumentParser | Any, *, seed: bool = True) -> None:
    """Add ``--control-period`` (and ``--seed``) to a parser or an argument group.

    Parameters
    ----------
    parser : argparse.ArgumentParser or argument group
        Where the options go.
    seed : bool
        Add ``--seed`` (the run's noise seed); ``fsmctl montecarlo`` has a campaign seed of its own.
    """
    parser.add_argument(
        "--control-period",
        type=number,
        default=None,
        metavar="SECONDS",
        help="control period in s: 0 = continuous control, > 0 = the law runs every SECONDS (a multiple of dt) "
        "and its torque is held in between; sensors and imperfect links need it (default: the scenario's "
        "simulation.control_period)",
    )
    if seed:
        parser.add_argument(
            "--seed",
            dest="noise_seed",
            type=number,
            default=None,
            metavar="N",
            help="seed of the run's random processes: sensor noise, packet losses (an integer >= 0; the same seed "
            "gives the same run; default: the scenario's simulation.seed)",
        )


def simulation_changes(args: argparse.Namespace) -> dict[str, Any]:
    """The ``simulation`` changes ``--control-period``/``--seed`` ask for, for ``scenario.replace(simulation=...)``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options (``control_period`` and, where the command has it, ``noise_seed``).

    Returns
    -------
    dict
        ``control_period`` and ``seed`` as given (unchecked: the scenario checks them); empty when neither was given.
    """
    out: dict[str, Any] = {}
    if getattr(args, "control_period", None) is not None:
        out["control_period"] = args.control_period
    if getattr(args, "noise_seed", None) is not None:
        out["seed"] = args.noise_seed
    return out
