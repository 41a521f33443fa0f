"""Evaluate a CasADi function on many samples with NumPy arrays and no ``DM`` conversions.

``Function.map(n)`` evaluates a function ``n`` times in C, but calling it from Python converts every
argument to a ``DM`` and every result back to NumPy, which for the metrics of one run (15 000 relative
attitudes of eq 43) costs several times the evaluation itself.  :func:`evaluate_mapped` binds NumPy
buffers directly (``casadi.FunctionBuffer``): the same compiled or virtual-machine code on the same
doubles, so the results are bit-identical to ``np.asarray(fn.map(n)(...))``.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

import casadi as ca
import numpy as np

__all__ = ["evaluate_mapped"]


@functools.lru_cache(maxsize=256)
def _plan(fn: ca.Function, n: int, shared: tuple[int, ...]) -> tuple[ca.Function, tuple[int, ...], tuple[tuple, ...]]:
    """The mapped function, the number of values of each input and the NumPy shape of each output."""
    if not (
        all(fn.sparsity_in(i).is_dense() for i in range(fn.n_in()))
        and all(fn.sparsity_out(i).is_dense() for i in range(fn.n_out()))
    ):
        raise ValueError(f"evaluate_mapped: {fn.name()} has a sparse input or output (dense ones are required)")
    mapped = fn if n == 1 else fn.map(f"map{n}_{fn.name()}", "serial", n, list(shared), [])
    sizes = tuple(fn.nnz_in(i) * (1 if i in shared else n) for i in range(fn.n_in()))
    shapes = []
    for i in range(fn.n_out()):
        r, c = fn.size1_out(i), fn.size2_out(i)
        shapes.append((n, r) if c == 1 else (n, c, r))  # per sample: the column-major nonzeros
    return mapped, sizes, tuple(shapes)


def evaluate_mapped(
    fn: ca.Function, n: int, args: Sequence[np.ndarray], shared: Sequence[int] = ()
) -> list[np.ndarray]:
    """Evaluate ``fn`` on ``n`` samples (``fn.map(n, "serial")``) through bound NumPy buffers.

    Parameters
    ----------
    fn : casadi.Function
        Function with dense inputs and outputs (a generated function, or Theorem 2's drift).
    n : int
        Number of evaluations (``>= 1``).
    args : sequence of array_like
        One per input.  A mapped input is given per sample, sample-major: the C-order memory must be
        the samples one after the other, each in column-major order, i.e. shape ``(n, rows)`` for a
        column input (the transpose of the ``(rows, n)`` array ``map`` takes) and ``(n, cols, rows)``
        for a matrix.  An input listed in ``shared`` is one value for every sample (column-major).
        Arrays are copied only when they are not already contiguous float64.
    shared : sequence of int
        Indices of the inputs that are the same for every sample (not widened by the map).

    Returns
    -------
    list of numpy.ndarray
        One per output, shape ``(n, rows)`` for a column output and ``(n, cols, rows)`` otherwise
        (sample ``k`` of a matrix output ``M_k`` is ``out[k].T``).

    Raises
    ------
    ValueError
        When an argument has the wrong number of elements, or ``fn`` has a sparse input or output.
    RuntimeError
        When the evaluation returns a nonzero status.
    """
    if n < 1:
        raise ValueError(f"evaluate_mapped: need n >= 1 evaluations, got {n}")
    mapped, sizes, shapes = _plan(fn, int(n), tuple(sorted(int(i) for i in shared)))
    if len(args) != len(sizes):
        raise ValueError(f"evaluate_mapped: {fn.name()} takes {len(sizes)} inputs, got {len(args)}")
    inputs = [np.ascontiguousarray(a, dtype=float) for a in args]
    for i, (a, want) in enumerate(zip(inputs, sizes, strict=True)):
        if a.size != want:
            raise ValueError(f"evaluate_mapped: input {fn.name_in(i)} of {fn.name()} needs {want} values, got {a.size}")
    outputs = [np.empty(s) for s in shapes]
    fb, evaluate = mapped.buffer()
    for i, a in enumerate(inputs):
        fb.set_arg(i, memoryview(a))
    for i, o in enumerate(outputs):
        fb.set_res(i, memoryview(o))
    evaluate()
    if fb.ret() != 0:
        raise RuntimeError(f"evaluate_mapped: {fn.name()} returned status {fb.ret()}")
    return outputs
