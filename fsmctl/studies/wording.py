"""Generated phrases of the reports: counts with the right number, ranges whose ends may coincide, lists.

A report assembled from numbers reads as a bug when a phrase ignores them: "1 claims", "0 of the 0 claims",
"saturated for 100-100 s of 100 s".  Every such phrase of ``fsmctl reproduce``'s report is built here, once, so that
the singular, the empty case and a range whose ends are equal read naturally.
"""

from __future__ import annotations

from collections.abc import Sequence

__all__ = ["RESUME_HINT", "count", "verdict_count", "value_range", "duration_phrase", "join_words"]

RESUME_HINT = "resuming with the same settings (--resume, resume=True) continues"
"""What an interrupted campaign or study says of its kept work (the command's option and the Python argument)."""

# verdict -> (singular, plural) of the phrase "N <verdict>": "1 differs" / "2 differ"
_VERDICT_FORMS = {
    "differs": ("differs", "differ"),
    "fits": ("fits", "fit"),
    "does not fit": ("does not fit", "do not fit"),
}


def count(n: int, singular: str, plural: str | None = None) -> str:
    """``n`` with the noun in the number it takes: ``"1 claim"``, ``"0 claims"``, ``"7 claims"``.

    Parameters
    ----------
    n : int
        How many.
    singular : str
        The noun for one.
    plural : str, optional
        The noun for any other number (default: ``singular + "s"``).

    Returns
    -------
    str
        ``"<n> <noun>"``.

    Examples
    --------
    >>> count(1, "claim"), count(0, "claim"), count(9, "figure check")
    ('1 claim', '0 claims', '9 figure checks')
    >>> count(2, "agent is", "agents are")
    '2 agents are'
    """
    return f"{n} {singular if n == 1 else (plural or singular + 's')}"


def verdict_count(n: int, verdict: str) -> str:
    """``n`` followed by a verdict used as a verb: ``"1 differs"``, ``"5 differ"``, ``"2 impossible (bound)"``.

    Parameters
    ----------
    n : int
        How many have this verdict.
    verdict : str
        A verdict (``reproduced``, ``differs``, ``impossible (bound)``, ``fits``, ``does not fit``).

    Returns
    -------
    str
        The count and the verdict in its number.

    Examples
    --------
    >>> verdict_count(1, "differs"), verdict_count(5, "differs"), verdict_count(0, "reproduced")
    ('1 differs', '5 differ', '0 reproduced')
    >>> verdict_count(7, "does not fit"), verdict_count(1, "fits")
    ('7 do not fit', '1 fits')
    """
    one, many = _VERDICT_FORMS.get(verdict, (verdict, verdict))
    return f"{n} {one if n == 1 else many}"


def value_range(values: Sequence[float], digits: int = 1) -> str:
    """The range of ``values`` at ``digits`` decimals, one number when its ends are equal there.

    Parameters
    ----------
    values : sequence of float
        The values (one per agent, ...); not empty.
    digits : int
        Decimals.

    Returns
    -------
    str
        ``"31.4–73.1"``, or ``"100.0"`` when the smallest and the largest print the same.

    Examples
    --------
    >>> value_range([73.1, 31.4]), value_range([100.0, 99.98]), value_range([0.0, 0.0], digits=0)
    ('31.4–73.1', '100.0', '0')
    """
    lo, hi = f"{min(values):.{digits}f}", f"{max(values):.{digits}f}"
    return lo if lo == hi else f"{lo}–{hi}"


def duration_phrase(durations: Sequence[float], total: float, digits: int = 1) -> str:
    """How long each of several things lasted, out of ``total`` seconds: ``"for 31.4–73.1 s of 100 s"``.

    The ends are compared as printed: when every duration prints as ``total`` the phrase is ``"for the whole
    100 s"``, when they print the same ``"for 40.0 s of 100 s"``, when none lasted ``"never"``.

    Parameters
    ----------
    durations : sequence of float
        The durations (s), one per agent; not empty.
    total : float
        The time they are counted in (s), e.g. the horizon.
    digits : int
        Decimals of the durations.

    Returns
    -------
    str
        The phrase, to follow a verb ("saturated ...").

    Examples
    --------
    >>> duration_phrase([100.0, 99.99], 100.0)
    'for the whole 100 s'
    >>> duration_phrase([40.0, 40.0], 100.0), duration_phrase([31.4, 73.1], 100.0)
    ('for 40.0 s of 100 s', 'for 31.4–73.1 s of 100 s')
    >>> duration_phrase([0.0, 0.0], 100.0)
    'never'
    """
    span = value_range(durations, digits)
    if span == f"{0:.{digits}f}":
        return "never"
    if span == f"{total:.{digits}f}":
        return f"for the whole {total:g} s"
    return f"for {span} s of {total:g} s"


def join_words(items: Sequence[str]) -> str:
    """``"a"``, ``"a and b"``, ``"a, b and c"``.

    Parameters
    ----------
    items : sequence of str
        The words; not empty.

    Returns
    -------
    str
        The list as a reader says it.

    Examples
    --------
    >>> join_words(["case1"]), join_words(["a", "b"]), join_words(["a", "b", "c"])
    ('case1', 'a and b', 'a, b and c')
    """
    items = list(items)
    return items[0] if len(items) == 1 else f"{', '.join(items[:-1])} and {items[-1]}"
