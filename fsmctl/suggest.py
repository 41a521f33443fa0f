"""Suggestions for a misspelled name: the one rule behind every "did you mean ...?" of fsmctl.

A name nobody knows (a scenario key, a ``--set`` key, a command-line option or subcommand, a parameter of a
plug-in system) is compared with the known names by :func:`similarity`; :func:`ranked` orders the known names
closest first (an error that lists them all) and :func:`did_you_mean` names the close ones (a ratio of at least
:data:`CUTOFF`) first in an error message.  Plain Python (``difflib``): the bottom layer, importable by every other.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable

__all__ = ["CUTOFF", "TIE", "similarity", "ranked", "close_matches", "did_you_mean"]

CUTOFF = 0.6
"""The least :func:`similarity` of a suggested name (``difflib.get_close_matches``'s default cutoff)."""

TIE = 0.05
"""A suggested name is at most this much less similar than the closest one (``delt``: ``delta``, not also
``error_model``)."""


def similarity(name: str, known: str) -> float:
    """How close ``name`` is to the known name ``known``, in [0, 1] (1: equal, ignoring case).

    The :class:`difflib.SequenceMatcher` ratio against the whole known name or against its part after the first
    ``_`` (a prefixed key, ``ctrl1_c1``, is close to ``c1``), whichever is higher; leading dashes are ignored
    (``--t-finall`` against ``--t-final``).

    Parameters
    ----------
    name : str
        The name that was written.
    known : str
        A name that exists.

    Returns
    -------
    float
        The ratio.

    Examples
    --------
    >>> from fsmctl.suggest import similarity
    >>> similarity("t_finall", "t_final") > 0.9, similarity("c1", "ctrl1_c1"), similarity("dt", "seed") < 0.6
    (True, 1.0, True)
    """
    text, other = str(name).lower().lstrip("-"), str(known).lower().lstrip("-")
    return max(difflib.SequenceMatcher(None, text, part).ratio() for part in (other, other.split("_", 1)[-1]))


def ranked(name: str, known: Iterable[str]) -> list[str]:
    """Every known name, the closest to ``name`` first (ties keep their order).

    Parameters
    ----------
    name : str
        The name that was written.
    known : iterable of str
        The names that exist.

    Returns
    -------
    list of str
        ``known`` sorted by decreasing :func:`similarity`.

    Examples
    --------
    >>> from fsmctl.suggest import ranked
    >>> ranked("j", ["disturbance", "J", "sc_J"])
    ['J', 'sc_J', 'disturbance']
    """
    return sorted(known, key=lambda k: -similarity(name, k))


def close_matches(name: str, known: Iterable[str], *, limit: int = 3) -> list[str]:
    """The known names close to ``name`` (:func:`similarity` at least :data:`CUTOFF`, and within :data:`TIE` of the
    closest), the closest first.

    Parameters
    ----------
    name : str
        The name that was written.
    known : iterable of str
        The names that exist.
    limit : int
        At most this many.

    Returns
    -------
    list of str
        Possibly empty.

    Examples
    --------
    >>> from fsmctl.suggest import close_matches
    >>> close_matches("--t-finall", ["--dt", "--t-final", "--out"])
    ['--t-final']
    """
    names = [k for k in ranked(name, dict.fromkeys(known)) if similarity(name, k) >= CUTOFF]
    best = similarity(name, names[0]) if names else 1.0
    return [k for k in names if similarity(name, k) >= best - TIE][:limit]


def did_you_mean(name: str, known: Iterable[str]) -> str:
    """``"did you mean X?"`` (or ``"X or Y?"``) for the close known names, or ``""`` when none is close.

    Parameters
    ----------
    name : str
        The name that was written.
    known : iterable of str
        The names that exist.

    Returns
    -------
    str
        The phrase, without brackets, or the empty string.

    Examples
    --------
    >>> from fsmctl.suggest import did_you_mean
    >>> did_you_mean("t_finall", ["dt", "t_final", "seed"])
    'did you mean t_final?'
    >>> did_you_mean("zzz", ["dt", "t_final"])
    ''
    """
    matches = close_matches(name, known, limit=2)
    return f"did you mean {' or '.join(matches)}?" if matches else ""
