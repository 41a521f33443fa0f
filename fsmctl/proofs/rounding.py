"""Printed bounds rounded outward: what a report may state about a proved bound.

One rule for every report of :mod:`fsmctl.proofs` (a certificate's lines, Theorem 2's certified intervals, the
uncertainty's description): an upper bound is printed rounded up, a lower bound down, so that the printed statement is
never tighter than the proved one.
"""

from __future__ import annotations

import math
from decimal import ROUND_CEILING, ROUND_FLOOR, Decimal

__all__ = ["round_outward"]


def round_outward(x: float, direction: str, digits: int = 3) -> str:
    """``x`` with ``digits`` significant digits, rounded down or up: a printed interval still encloses the exact one.

    The one outward-rounding formatter of the proofs' reports (Theorem 2's tables, :mod:`fsmctl.proofs.theorem2_report`,
    and every bound, level, rate and time in a certificate's report, :class:`fsmctl.proofs.certificate.Certificate`): an upper bound is printed
    rounded up, a lower bound down, so the printed statement is never tighter than the proved one.  The decimal
    rounded is the shortest one that reads back as ``x`` (``0.1`` for the double nearest 0.1): the printed bound,
    read as a double, is never tighter than ``x``.

    Parameters
    ----------
    x : float
        The bound (``inf``: unbounded; ``nan``: printed ``nan``).
    direction : {"down", "up"}
        Round towards -inf (a lower bound) or +inf (an upper bound).
    digits : int
        Significant digits.

    Returns
    -------
    str

    Raises
    ------
    ValueError
        ``direction`` is neither ``"down"`` nor ``"up"``.

    Examples
    --------
    >>> round_outward(0.30032, "down"), round_outward(1.8461, "up"), round_outward(0.3, "down")
    ('0.3', '1.85', '0.3')
    >>> round_outward(9.9961, "up"), round_outward(0.0, "down"), round_outward(float("inf"), "up")
    ('10', '0', 'inf')
    >>> round_outward(0.15625, "up", 4), round_outward(0.15625, "down", 4), round_outward(-0.15625, "up", 4)
    ('0.1563', '0.1562', '-0.1562')
    """
    if direction not in ("down", "up"):
        raise ValueError(f"direction must be 'down' or 'up', got {direction!r}")
    if math.isnan(x):
        return "nan"
    if not math.isfinite(x):
        return "inf" if x > 0 else "-inf"
    if x == 0:
        return "0"
    d = Decimal(repr(float(x)))  # the shortest decimal that reads back as x
    step = Decimal(1).scaleb(d.adjusted() - (digits - 1))
    q = d.quantize(step, rounding=ROUND_FLOOR if direction == "down" else ROUND_CEILING)
    return f"{float(q):.{digits}g}"
