"""Exact translation of SymPy expressions into CasADi ``SX`` graphs.

SymPy's own printers are not used: they have no rule for ``sign`` and route
``tanh`` through exponentials that overflow to NaN in CasADi.  This module
walks the expression tree and maps each node to the CasADi operation with the
same meaning:

=====================  ==========================================
SymPy                  CasADi
=====================  ==========================================
``sign(x)``            ``sign(x)`` (``sign(0) = 0`` in both)
``Abs(x)``             ``fabs(x)``
``x**n`` (integer n)   squaring / products / ``1/x``
``x**(1/2)``           ``sqrt(x)``
``x**a``               ``pow(x, a)`` (``constpow`` for numbers)
``Piecewise``          nested ``if_else`` (last condition must be True)
``Min``/``Max``        ``fmin``/``fmax``
``Mod(x, y)``          ``x - y floor(x/y)`` (Python/SymPy semantics)
relationals, logic     ``<, <=, ==, !=, logic_and/or/not``
elementary functions   ``sin cos tan atan atan2 tanh exp log floor``
=====================  ==========================================

The one deliberate difference: ``atan2(0, 0)`` is ``nan`` in SymPy and ``0``
in C (and CasADi); no generated function evaluates it there.

Common subexpressions are shared by memoising on the (hashable) SymPy node,
so a subtree that occurs many times is translated once.
"""

from __future__ import annotations

import functools
import operator
from collections.abc import Mapping, Sequence

import casadi as ca
import sympy as sp

__all__ = ["UnsupportedExpressionError", "SympyToCasadi", "to_casadi_function"]


class UnsupportedExpressionError(TypeError):
    """A SymPy node has no exact CasADi counterpart in this translator."""


_UNARY = {
    sp.sin: ca.sin,
    sp.cos: ca.cos,
    sp.tan: ca.tan,
    sp.asin: ca.asin,
    sp.acos: ca.acos,
    sp.atan: ca.atan,
    sp.sinh: ca.sinh,
    sp.cosh: ca.cosh,
    sp.tanh: ca.tanh,
    sp.exp: ca.exp,
    sp.floor: ca.floor,
    sp.ceiling: ca.ceil,
    sp.sign: ca.sign,
    sp.Abs: ca.fabs,
}

# n-ary SymPy nodes: CasADi's binary operation folded left over the arguments
_FOLDS = (
    (sp.Add, operator.add),
    (sp.Mul, operator.mul),
    (sp.Min, ca.fmin),
    (sp.Max, ca.fmax),
    (sp.And, ca.logic_and),
    (sp.Or, ca.logic_or),
)

_RELATIONS = {
    "<": operator.lt,
    "<=": operator.le,
    ">": operator.gt,
    ">=": operator.ge,
    "==": operator.eq,
    "!=": operator.ne,
}


def _constant(e: sp.Basic) -> ca.SX | None:
    """A Boolean or finite numeric constant as CasADi ``SX``; None for any other expression."""
    if e is sp.true or e == sp.true:
        return ca.SX(1)
    if e is sp.false or e == sp.false:
        return ca.SX(0)
    if e.is_Number or e.is_NumberSymbol:
        if e in (sp.oo, -sp.oo, sp.zoo, sp.nan):
            raise UnsupportedExpressionError(f"non-finite constant {e}")
        return ca.SX(float(e))
    return None


class SympyToCasadi:
    """Translate SymPy expressions given a mapping from SymPy symbols to CasADi ``SX`` scalars."""

    def __init__(self, symbols: Mapping[sp.Symbol, ca.SX]):
        self._memo: dict[sp.Basic, ca.SX] = dict(symbols)

    def bind(self, symbol: sp.Symbol, value: ca.SX) -> None:
        """Make ``symbol`` stand for ``value`` in later translations."""
        if symbol in self._memo:
            raise UnsupportedExpressionError(f"symbol {symbol} is bound twice")
        self._memo[symbol] = value

    def __call__(self, expr) -> ca.SX:
        if isinstance(expr, sp.MatrixBase):
            rows = [[self(expr[i, j]) for j in range(expr.cols)] for i in range(expr.rows)]
            return ca.vertcat(*[ca.horzcat(*r) for r in rows]) if rows else ca.SX(0, 1)
        return self._translate(sp.sympify(expr))

    def _translate(self, e: sp.Basic) -> ca.SX:
        hit = self._memo.get(e)
        if hit is not None:
            return hit
        out = self._dispatch(e)
        self._memo[e] = out
        return out

    def _dispatch(self, e: sp.Basic) -> ca.SX:
        t = self._translate
        if e.is_Symbol:
            raise UnsupportedExpressionError(f"free symbol {e} is not an input of the function")
        constant = _constant(e)
        if constant is not None:
            return constant
        for kind, op in _FOLDS:
            if isinstance(e, kind):  # a left fold over the arguments, in SymPy's order
                return functools.reduce(op, [t(a) for a in e.args])
        if isinstance(e, sp.Pow):
            return self._pow(e)
        if isinstance(e, sp.Piecewise):
            return self._piecewise(e)
        if isinstance(e, sp.Mod):
            x, y = (t(a) for a in e.args)
            return x - y * ca.floor(x / y)
        if isinstance(e, sp.atan2):
            y, x = (t(a) for a in e.args)
            return ca.atan2(y, x)
        if isinstance(e, sp.log):
            if len(e.args) != 1:
                raise UnsupportedExpressionError("log with a base")
            return ca.log(t(e.args[0]))
        if isinstance(e, sp.Heaviside):
            x = t(e.args[0])
            h0 = float(e.args[1]) if len(e.args) > 1 else 0.5
            return ca.if_else(x > 0, 1, ca.if_else(x < 0, 0, h0))
        for fn, op in _UNARY.items():
            if isinstance(e, fn):
                return op(t(e.args[0]))
        if isinstance(e, sp.core.relational.Relational):
            return _RELATIONS[e.rel_op](t(e.lhs), t(e.rhs))
        if isinstance(e, sp.Not):
            return ca.logic_not(t(e.args[0]))
        raise UnsupportedExpressionError(f"no CasADi translation for {type(e).__name__}: {e}")

    def _pow(self, e: sp.Pow) -> ca.SX:
        base, exp = e.args
        b = self._translate(base)
        if exp.is_Integer:
            n = int(exp)
            if n == 0:
                return ca.SX(1)
            if n == 2:
                return b**2
            if n == -1:
                return 1 / b
            if n < 0:
                return 1 / self._int_power(b, -n)
            return self._int_power(b, n)
        if exp == sp.Rational(1, 2):
            return ca.sqrt(b)
        if exp == sp.Rational(-1, 2):
            return 1 / ca.sqrt(b)
        if base == sp.E:
            return ca.exp(self._translate(exp))
        return ca.power(b, self._translate(exp))

    @staticmethod
    def _int_power(b: ca.SX, n: int) -> ca.SX:
        # exponentiation by squaring keeps the graph small and exact
        result = None
        square = b
        while n:
            if n & 1:
                result = square if result is None else result * square
            n >>= 1
            if n:
                square = square**2
        return result

    def _piecewise(self, e: sp.Piecewise) -> ca.SX:
        pairs = list(e.args)
        last_expr, last_cond = pairs[-1]
        if last_cond is not sp.true:
            raise UnsupportedExpressionError(f"Piecewise without a final True branch: {e}")
        out = self._translate(last_expr)
        for expr, cond in reversed(pairs[:-1]):
            out = ca.if_else(self._translate(cond), self._translate(expr), out)
        return out


def to_casadi_function(
    name: str,
    inputs: Sequence[tuple[str, sp.MatrixBase]],
    outputs: Sequence[tuple[str, sp.MatrixBase]],
    stages: Sequence[tuple[sp.MatrixBase, sp.MatrixBase]] = (),
    *,
    cse: bool = True,
) -> ca.Function:
    """Build a CasADi ``Function`` from SymPy matrices (the exact translation of the module docstring).

    Parameters
    ----------
    name : str
        The function's name.
    inputs : sequence of (str, Matrix)
        ``(name, matrix of distinct symbols)`` pairs; a symmetric matrix may repeat a symbol (each occurrence
        maps to the first entry, in column-major order).
    outputs : sequence of (str, Matrix)
        ``(name, SymPy matrix)`` pairs.
    stages : sequence of (Matrix, Matrix)
        ``(symbols, expression)`` pairs translated in order, each binding its symbols to the translated
        expression for the stages and outputs after it (intermediate results computed once).
    cse : bool
        Run SymPy's common-subexpression elimination on each stage and on the outputs first, so shared
        products and quotients are computed once.

    Returns
    -------
    casadi.Function
        An ``SXFunction`` with the given input and output names.

    Raises
    ------
    UnsupportedExpressionError
        An input entry is not a symbol, a stage's symbols and expression differ in shape, or a node has no
        exact CasADi counterpart.

    Examples
    --------
    The terminal term ``sig(x)^alpha`` of the sliding surface (Liang et al. 2012, eqs 1 and 13), with
    ``sign(0) = 0`` as in SymPy:

    >>> import sympy as sp
    >>> from fsmctl.codegen import to_casadi_function
    >>> x, y = sp.symbols("x y", real=True)
    >>> f = to_casadi_function("f", [("x", sp.Matrix([x])), ("y", sp.Matrix([y]))],
    ...                        [("z", sp.Matrix([sp.sign(x) * sp.Abs(x) ** sp.Rational(3, 4) + y**2]))])
    >>> f
    Function(f:(x,y)->(z) SXFunction)
    >>> float(f(16, 3)), float(f(-16, 0)), float(f(0, 0))
    (17.0, -8.0, 0.0)
    """
    mapping: dict[sp.Symbol, ca.SX] = {}
    sx_inputs = []
    for in_name, m in inputs:
        m = sp.ImmutableMatrix(m)
        x = ca.SX.sym(in_name, m.rows, m.cols)
        for j in range(m.cols):
            for i in range(m.rows):
                symbol = m[i, j]
                if not symbol.is_Symbol:
                    raise UnsupportedExpressionError(f"input {in_name}[{i},{j}] is not a symbol: {symbol}")
                mapping.setdefault(symbol, x[i, j])
        sx_inputs.append(x)
    translate = SympyToCasadi(mapping)
    counter = iter(range(10**9))
    for symbols, expr in stages:
        symbols, expr = sp.ImmutableMatrix(symbols), sp.ImmutableMatrix(expr)
        if symbols.shape != expr.shape:
            raise UnsupportedExpressionError(f"stage shape mismatch {symbols.shape} vs {expr.shape}")
        (value,) = _translate_with_cse(translate, [expr], counter) if cse else [translate(expr)]
        for k, symbol in enumerate(symbols):
            translate.bind(symbol, value[k // symbols.cols, k % symbols.cols])
    matrices = [sp.ImmutableMatrix(m) for _, m in outputs]
    sx_outputs = _translate_with_cse(translate, matrices, counter) if cse else [translate(m) for m in matrices]
    return ca.Function(name, sx_inputs, sx_outputs, [n for n, _ in inputs], [n for n, _ in outputs])


def _translate_with_cse(translate: SympyToCasadi, matrices: list[sp.ImmutableMatrix], counter) -> list[ca.SX]:
    """Translate matrices after ``sympy.cse``; the replacement symbols are bound in order."""
    replacements, reduced = sp.cse(
        matrices, symbols=(sp.Symbol(f"_cse{next(counter)}", real=True) for _ in iter(int, 1)), order="canonical"
    )
    for symbol, sub in replacements:
        translate.bind(symbol, translate(sub))
    return [translate(sp.ImmutableMatrix(m)) for m in reduced]
