"""Strict C99 for one CasADi ``SX`` function: the instruction list of CasADi's own scalar C, printed for a flight
computer.

:mod:`fsmctl.codegen.batched` prints a function's instruction list on a vector type for the engine; this module
prints the *same instruction list* once more as plain scalar C99 statements on a real type of the caller's choice
(``double`` or ``float``), one operation per statement, with no library call: ``pow``, ``sqrt`` and ``exp`` are the
exported law's own (``fsmctl/csrc/export/export_math.c``, named ``<prefix>_math_pow`` ...), ``fabs``, ``fmin``,
``fmax``, ``sign``, comparisons and ``if_else`` are written out with the C99 semantics of CasADi's scalar helpers
(and of the engine's batched kernels).  So in double precision, compiled without FMA contraction, the function's
results are the engine's bits (``fsmctl export --verify`` checks it on whole flights).

In ``float`` the arithmetic is single precision; the elementary functions are evaluated in double and rounded, and
every conversion is written as a cast (the output compiles with ``-Wconversion``).

Pure: builds strings, no I/O (:mod:`fsmctl.export.c_library` writes them).
"""

from __future__ import annotations

import math

import casadi as ca

__all__ = ["UnsupportedExportInstructionError", "EXPORT_OPERATIONS", "c99_function", "c99_signature"]


class UnsupportedExportInstructionError(ValueError):
    """The CasADi graph holds an operation the C99 export has no library-free rule for."""


def _literal(value: float, real: str) -> str:
    if math.isnan(value):
        return "(0.0 / 0.0)"  # never in a law's graph: an exact constant NaN is refused below
    text = repr(float(value))
    if real == "double":
        return f"({text})" if text.startswith("-") else text
    return f"(({real}){text})"


# C templates per operation ({a}, {b}: operands; {r}: the real type; {m}: the math prefix); CasADi's scalar rule in
# the comment where it is not plain C.
_BINARY = {
    ca.OP_ADD: "{a} + {b}",
    ca.OP_SUB: "{a} - {b}",
    ca.OP_MUL: "{a} * {b}",
    ca.OP_DIV: "{a} / {b}",
    ca.OP_LT: "({a} < {b}) ? {one} : {zero}",
    ca.OP_LE: "({a} <= {b}) ? {one} : {zero}",
    ca.OP_EQ: "({a} == {b}) ? {one} : {zero}",
    ca.OP_NE: "({a} != {b}) ? {one} : {zero}",
    ca.OP_AND: "({a} != {zero} && {b} != {zero}) ? {one} : {zero}",  # x && y
    ca.OP_OR: "({a} != {zero} || {b} != {zero}) ? {one} : {zero}",  # x || y
    ca.OP_IF_ELSE_ZERO: "({a} != {zero}) ? {b} : {zero}",  # x ? y : 0 (NaN is true)
    # C99 fmax/fmin: a NaN argument is ignored; equal arguments (+0/-0) give the second (the engine's kernels)
    ca.OP_FMIN: "({a} < {b} || {b} != {b}) ? {a} : {b}",
    ca.OP_FMAX: "({a} > {b} || {b} != {b}) ? {a} : {b}",
    ca.OP_POW: "{cast}{m}_math_pow((double){a}, (double){b})",
    ca.OP_CONSTPOW: "{cast}{m}_math_pow((double){a}, (double){b})",
}
_UNARY = {
    ca.OP_NEG: "-{a}",
    ca.OP_SQ: "{a} * {a}",  # casadi_sq(x) = x*x
    ca.OP_TWICE: "{two} * {a}",  # 2.*x
    ca.OP_INV: "{one} / {a}",  # 1./x
    ca.OP_NOT: "({a} == {zero}) ? {one} : {zero}",  # !x
    ca.OP_FABS: "({a} < {zero}) ? -{a} : ({a} == {zero} ? {zero} : {a})",  # clears the sign of -0 too
    ca.OP_SIGN: "({a} < {zero}) ? -{one} : (({a} > {zero}) ? {one} : {a})",  # casadi_sign: x<0 ? -1 : x>0 ? 1 : x
    ca.OP_SQRT: "{cast}{m}_math_sqrt((double){a})",
    ca.OP_EXP: "{cast}{m}_math_exp((double){a})",
}

EXPORT_OPERATIONS = tuple(
    sorted(name for name in dir(ca) if name.startswith("OP_") and getattr(ca, name) in {**_BINARY, **_UNARY})
)
"""The CasADi operations the C99 export prints (besides inputs, outputs and constants)."""


def c99_signature(name: str, real: str) -> str:
    """The C declaration of an exported function: ``void name(const real *const *arg, real *const *res)``."""
    return f"void {name}(const {real} *const *arg, {real} *const *res)"


def _statement(op: int, ins, real: str, math_prefix: str) -> str | None:
    words = {
        "zero": _literal(0.0, real),
        "one": _literal(1.0, real),
        "two": _literal(2.0, real),
        "r": real,
        "m": math_prefix,
        "cast": "" if real == "double" else f"({real})",
    }
    if op in _BINARY:
        return _BINARY[op].format(a=f"w{ins[0]}", b=f"w{ins[1]}", **words)
    if op in _UNARY:
        return _UNARY[op].format(a=f"w{ins[0]}", **words)
    return None


def c99_function(name: str, function: ca.Function, *, real: str = "double", math_prefix: str = "fsmctl") -> str:
    """Print a CasADi ``SX`` function as one strict C99 function.

    Parameters
    ----------
    name : str
        The C function's name.
    function : casadi.Function
        An ``SXFunction`` (every law function of :func:`fsmctl.codegen.laws.law_functions`).
    real : {"double", "float"}
        The arithmetic type.
    math_prefix : str
        The prefix of the elementary functions (``<math_prefix>_math_pow`` ...).

    Returns
    -------
    str
        The C function ``void name(const real *const *arg, real *const *res)``: argument ``i`` element ``k`` is
        ``arg[i][k]`` (CasADi's dense column-major order), results likewise; the same instruction list as CasADi's
        scalar C.

    Raises
    ------
    UnsupportedExportInstructionError
        An operation outside :data:`EXPORT_OPERATIONS` (e.g. ``sin``: the export has no library-free rule for it yet).

    Examples
    --------
    >>> import casadi as ca
    >>> x = ca.SX.sym("x", 2)
    >>> f = ca.Function("f", [x], [ca.fmax(x[0], 0) * ca.sqrt(x[1])])
    >>> print(c99_function("f", f), end="")
    void f(const double *const *arg, double *const *res) {
      double w0, w1;
      (void)arg;
      (void)res;
      w0 = arg[0][0];
      w1 = 0.0;
      w0 = (w0 > w1 || w1 != w1) ? w0 : w1;
      w1 = arg[0][1];
      w1 = fsmctl_math_sqrt((double)w1);
      w0 = w0 * w1;
      res[0][0] = w0;
    }
    """
    if real not in ("double", "float"):
        raise ValueError(f"real must be 'double' or 'float', not {real!r}")
    if not function.is_a("SXFunction"):
        raise UnsupportedExportInstructionError(f"{name}: the C99 export needs an SX function")
    op_names = {getattr(ca, n): n for n in dir(ca) if n.startswith("OP_")}
    body: list[str] = []
    used: set[int] = set()
    for k in range(function.n_instructions()):
        op = function.instruction_id(k)
        ins, outs = function.instruction_input(k), function.instruction_output(k)
        if op == ca.OP_INPUT:
            body.append(f"  w{outs[0]} = arg[{ins[0]}][{ins[1]}];")
            used.add(outs[0])
        elif op == ca.OP_OUTPUT:
            body.append(f"  res[{outs[0]}][{outs[1]}] = w{ins[0]};")
        elif op == ca.OP_CONST:
            value = function.instruction_constant(k)
            if math.isnan(value):
                raise UnsupportedExportInstructionError(f"{name}: instruction {k} is a NaN constant")
            if math.isinf(value):
                body.append(f"  w{outs[0]} = {'' if value > 0 else '-'}{real}_infinity();")
            else:
                body.append(f"  w{outs[0]} = {_literal(value, real)};")
            used.add(outs[0])
        else:
            expr = _statement(op, ins, real, math_prefix)
            if expr is None:
                raise UnsupportedExportInstructionError(
                    f"{name}: instruction {k} is {op_names.get(op, op)}, which the C99 export cannot print without "
                    f"the C library (supported: {', '.join(n[3:].lower() for n in EXPORT_OPERATIONS)})"
                )
            body.append(f"  w{outs[0]} = {expr};")
            used.add(outs[0])
    lines = [f"{c99_signature(name, real)} {{"]
    names = [f"w{k}" for k in sorted(used)]
    for start in range(0, len(names), 16):
        lines.append(f"  {real} {', '.join(names[start : start + 16])};")
    lines += ["  (void)arg;", "  (void)res;", *body, "}", ""]
    return "\n".join(lines)
