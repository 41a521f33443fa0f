"""One function to generate: named symbolic inputs, intermediate stages and outputs.

The unit that :mod:`fsmctl.codegen` turns into a CasADi function, C source and manifest entry, for the
project's model catalogue (``derive/catalogue.py``) and for every control law (:mod:`fsmctl.symbolic.law`).

Pure SymPy: no NumPy, no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

__all__ = ["FunctionSpec"]


@dataclass(frozen=True)
class FunctionSpec:
    """One generated function: named inputs, intermediate stages, named outputs."""

    name: str
    doc: str
    inputs: tuple[tuple[str, sp.ImmutableMatrix], ...]
    outputs: tuple[tuple[str, sp.ImmutableMatrix], ...]
    stages: tuple[tuple[sp.ImmutableMatrix, sp.ImmutableMatrix], ...] = field(default=())
    batched: bool = False
    """also emit a lane-batched kernel (fsmctl.codegen.batched) for the simulator's per-agent hot loop"""
