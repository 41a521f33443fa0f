"""Evaluate a derive.catalogue.FunctionSpec with SymPy's lambdify (the "SymPy-lambdified" route of the tests)."""

from __future__ import annotations

import numpy as np
import sympy as sp


class LambdifiedSpec:
    """Stage-by-stage ``sympy.lambdify`` of a function spec, called with numeric inputs by name."""

    def __init__(self, spec):
        self.spec = spec
        self.inputs = []  # (name, [(row, col, symbol)]) first occurrence per symbol, column-major like CasADi
        seen = set()
        args = []
        for name, m in spec.inputs:
            m = sp.ImmutableMatrix(m)
            entries = []
            for j in range(m.cols):
                for i in range(m.rows):
                    s = m[i, j]
                    if s not in seen:
                        seen.add(s)
                        entries.append((i, j, s))
                        args.append(s)
            self.inputs.append((name, m.shape, entries))
        self.stages = []
        for symbols, expr in spec.stages:
            symbols, expr = sp.ImmutableMatrix(symbols), sp.ImmutableMatrix(expr)
            self.stages.append((list(symbols), sp.lambdify(args, list(expr), "numpy", cse=True)))
            args = args + list(symbols)
        self.outputs = [
            (name, sp.ImmutableMatrix(m).shape, sp.lambdify(args, list(sp.ImmutableMatrix(m)), "numpy", cse=True))
            for name, m in spec.outputs
        ]

    def __call__(self, **values) -> dict[str, np.ndarray]:
        # NumPy evaluates every branch of a Piecewise: 1/x in a branch not taken at x = 0 is expected
        with np.errstate(divide="ignore", invalid="ignore"):
            return self._evaluate(values)

    def _evaluate(self, values) -> dict[str, np.ndarray]:
        vals = []
        for name, shape, entries in self.inputs:
            a = (
                np.asarray(values[name], dtype=float).reshape(shape)
                if shape != (1, 1)
                else np.asarray([[values[name]]], float).reshape(1, 1)
            )
            vals += [a[i, j] for i, j, _ in entries]
        for _, fn in self.stages:
            vals += [float(v) for v in fn(*vals)]
        return {name: np.asarray([float(v) for v in fn(*vals)]).reshape(shape) for name, shape, fn in self.outputs}
