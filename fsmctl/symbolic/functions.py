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
    """One generated function: named inputs, intermediate stages, named outputs.

    Parameters
    ----------
    name : str
        The C and CasADi name of the function.
    doc : str
        One line for the do-not-edit header and the manifest.
    inputs : tuple of (str, sympy.ImmutableMatrix)
        ``(name, matrix of symbols)`` per input, in order.
    outputs : tuple of (str, sympy.ImmutableMatrix)
        ``(name, expression matrix)`` per output, in order.
    stages : tuple of (sympy.ImmutableMatrix, sympy.ImmutableMatrix)
        ``(symbols, expression)`` intermediate results, computed once, in order.
    batched : bool
        Also emit a lane-batched kernel (:mod:`fsmctl.codegen.batched`) for the simulator's per-agent hot loop.

    Examples
    --------
    The MRP kinematics (Liang et al. 2012, eq 3) as a function, translated and evaluated at ``sigma = 0``:

    >>> from fsmctl.codegen import build_functions
    >>> from fsmctl.symbolic import FunctionSpec, mrp_kinematics, vector_symbols
    >>> sigma, omega = vector_symbols("sigma"), vector_symbols("omega")
    >>> spec = FunctionSpec("sigma_dot", "MRP kinematics (eq 3)", inputs=(("sigma", sigma), ("omega", omega)),
    ...                     outputs=(("sigma_dot", mrp_kinematics(sigma, omega)),))
    >>> (fn,) = build_functions([spec])
    >>> print(fn.function([0, 0, 0], [0.4, 0.8, 1.2]))
    [0.1, 0.2, 0.3]
    """

    name: str
    doc: str
    inputs: tuple[tuple[str, sp.ImmutableMatrix], ...]
    outputs: tuple[tuple[str, sp.ImmutableMatrix], ...]
    stages: tuple[tuple[sp.ImmutableMatrix, sp.ImmutableMatrix], ...] = field(default=())
    batched: bool = False
    """also emit a lane-batched kernel (fsmctl.codegen.batched) for the simulator's per-agent hot loop"""
