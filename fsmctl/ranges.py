"""The range rule of a law's declared parameters, written once.

Used by the symbolic law API (:class:`fsmctl.symbolic.law.LawParameter`, when a script declares a default), the
run-time law description (:class:`fsmctl.model.laws.LawParameterInfo`, when a scenario sets a value) and the
command line's tables.  Plain Python (no SymPy, no NumPy), so the simulator can use it without importing SymPy.
"""

from __future__ import annotations

import math

__all__ = ["ParameterRange"]


class ParameterRange:
    """Mixin for a parameter record with the fields ``default`` (tuple of floats; an option's index),
    ``minimum``, ``maximum`` (float or None), ``exclusive_minimum``, ``exclusive_maximum`` (bool) and
    ``choices`` (tuple of option strings, empty for a number).

    Examples
    --------
    >>> from fsmctl.model import resolve_law
    >>> alpha = resolve_law("fsm").parameter("alpha")  # a LawParameterInfo, a ParameterRange
    >>> alpha.range_text(), alpha.default_text(), alpha.problem(1.2)
    ('0.5 < x < 1', '0.7', 'must be < 1, got 1.2')
    """

    __slots__ = ()

    @property
    def size(self) -> int:
        """The number of components (``len(default)``)."""
        return len(self.default)

    def range_text(self) -> str:
        """``"0 < x <= 1"``, ``"any"``, or the options ``"none | switch | clamp"``."""
        if self.choices:
            return " | ".join(self.choices)
        lo = "" if self.minimum is None else f"{self.minimum:g} {'<' if self.exclusive_minimum else '<='} "
        hi = "" if self.maximum is None else f" {'<' if self.exclusive_maximum else '<='} {self.maximum:g}"
        return f"{lo}x{hi}" if (lo or hi) else "any"

    def default_text(self) -> str:
        """The default as a scenario file writes it (an option by name, a vector in brackets)."""
        if self.choices:
            return self.choices[int(self.default[0])]
        return f"{self.default[0]:g}" if self.size == 1 else "[" + ", ".join(f"{v:g}" for v in self.default) + "]"

    def problem(self, value: float) -> str | None:
        """Why ``value`` (one component) is outside the range, or None.

        Parameters
        ----------
        value : float
            One component of a value.

        Returns
        -------
        str or None
            The reason (``"must be > 0, got -1"``), or None when it is in the range.
        """
        if not math.isfinite(value):
            return f"must be finite, got {value!r}"
        if self.minimum is not None and (value <= self.minimum if self.exclusive_minimum else value < self.minimum):
            return f"must be {'>' if self.exclusive_minimum else '>='} {self.minimum:g}, got {value:g}"
        if self.maximum is not None and (value >= self.maximum if self.exclusive_maximum else value > self.maximum):
            return f"must be {'<' if self.exclusive_maximum else '<='} {self.maximum:g}, got {value:g}"
        return None
