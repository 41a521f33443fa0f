"""Argument types shared by the ``fsmctl`` subcommands: a bad value is a one-line argparse error (exit 2)."""

from __future__ import annotations

import argparse
import math

__all__ = [
    "finite_or_inf_float",
    "nonnegative_float",
    "nonnegative_int",
    "number",
    "number_range",
    "positive_float",
    "positive_int",
    "torque_limit",
]


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None


def _integer(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None


def positive_float(text: str) -> float:
    """A finite number > 0."""
    x = _number(text)
    if not (math.isfinite(x) and x > 0):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text!r}")
    return x


def nonnegative_float(text: str) -> float:
    """A finite number >= 0."""
    x = _number(text)
    if not (math.isfinite(x) and x >= 0):
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, got {text!r}")
    return x


def finite_or_inf_float(text: str) -> float:
    """A finite number, or ``inf`` spelled out (NaN is refused); the range is checked by the scenario."""
    x = _number(text)
    if not math.isfinite(x) and text.strip().lower() not in ("inf", "infinity"):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return x


def torque_limit(text: str) -> float:
    """A per-component torque bound in N m: a number > 0, or ``inf``/``none`` for no limit."""
    if text.strip().lower() in ("inf", "infinity", "none"):
        return math.inf
    x = _number(text)
    if not x > 0:
        raise argparse.ArgumentTypeError(f"must be > 0 (or inf), got {text!r}")
    return x


def positive_int(text: str) -> int:
    """An integer >= 1."""
    v = _integer(text)
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {v}")
    return v


def nonnegative_int(text: str) -> int:
    """An integer >= 0."""
    v = _integer(text)
    if v < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {v}")
    return v


def number(text: str) -> int | float:
    """Any number, as written: an integer stays an ``int`` (``3``), anything else is a ``float`` (``0.05``, ``1.5``,
    ``nan``); its range and kind are checked where it is used (the scenario's validators), so they report it."""
    try:
        return int(text)
    except ValueError:
        return _number(text)


def number_range(text: str) -> tuple[float, float]:
    """``LOW,HIGH`` (or one number ``X`` for ``X,X``): a sampling range; its bounds are checked by the campaign."""
    parts = [p.strip() for p in text.split(",")]
    if len(parts) not in (1, 2) or not all(parts):
        raise argparse.ArgumentTypeError(f"expected LOW,HIGH (or one number), got {text!r}")
    values = [_number(p) for p in parts]
    return (values[0], values[-1])
