"""Lane-batched C kernels: the same CasADi ``SX`` graph evaluated for several agents at once.

CasADi's own code generator prints one scalar statement per instruction of an
``SX`` function.  This module prints the *same instructions* once more, on
a C vector type of ``FSM_LANES`` doubles (GCC/Clang ``vector_size``
extension), so one call evaluates the function for ``FSM_LANES`` agents with SIMD
arithmetic.  Each instruction becomes one single-assignment statement; in a kernel
that calls ``pow``, ``sin`` or ``cos`` the statements are ordered to start the longest
dependency chains first (list scheduling by critical path), so that independent
``pow`` calls sit side by side, and two such ``pow`` are printed as one call
of ``fsm_pow2`` (``fsm_pow.h``: one function body interleaving their
chains, which the CPU overlaps); other kernels keep CasADi's order.  Reordering single
assignments and interleaving powers change no operation and no operand.  The
width is a compile-time constant of the C code, not of the printed text:
``fsmctl/csrc/fsm_pow.h`` defines it (4 unless the build says otherwise;
:func:`fsmctl.model.generated_code.compile_flags` asks for 8 on CPUs with 512-bit
vectors), so one generated file serves every width.  Every lane performs exactly
the scalar program: each value by the same IEEE operation on the same operands
(``+ - * /`` are correctly rounded per lane, ``pow``,
``sin`` and ``cos`` are fsmctl's (``fsmctl/csrc/fsm_pow.h`` and ``fsm_trig.h``, those of
every compiled path) on all lanes at once, the other library functions
(``sqrt``, ``exp``, ...) are called per lane, and
comparisons, ``if_else``, ``sign``, ``fmin``/``fmax`` and ``fabs`` are bit
selections with the C99 semantics of CasADi's scalar helpers), so with FMA
contraction off a lane's result is bit-identical to the scalar CasADi C
function, whatever the width.  The one latitude is the sign of a zero from ``fmin``/``fmax`` of
``+0`` and ``-0``, which C99 leaves unspecified (the compiler may resolve the
scalar call either way).  ``tests/test_batched_kernels.py`` checks this on
random and edge-case inputs and on whole simulations, at every width.

Memory layout ("lane-major"): argument ``i`` of a kernel is a block of
``nnz_i * FSM_LANES`` doubles with element ``(k, lane)`` at ``arg[i][FSM_LANES*k + lane]``;
results likewise.  Every argument and result pointer must be non-null.  The
last argument, ``lanes``, is the number of active lanes: the per-lane library
calls (the expensive part) skip the others, whose results are unspecified.

Pure: builds strings from CasADi functions, no I/O (``fsmctl.codegen.writer`` writes them).
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Sequence
from typing import NamedTuple

import casadi as ca

__all__ = ["LANE_WIDTHS", "UnsupportedInstructionError", "batched_source", "batched_header", "kernel_name"]

LANE_WIDTHS = (4, 8)
"""The values ``FSM_LANES`` may take (``fsmctl/csrc/fsm_pow.h`` refuses others): 4 doubles = one 256-bit AVX register
(two SSE2 registers without AVX), 8 = one AVX-512 register (two interleaved AVX registers without it)."""


class UnsupportedInstructionError(ValueError):
    """The CasADi graph holds an operation this printer has no exact lane-wise rule for."""


def kernel_name(function_name: str) -> str:
    """C name of the batched kernel of a generated function (``plant_rhs`` -> ``plant_rhs_batched``)."""
    return f"{function_name}_batched"


def _literal(value: float) -> str:
    if math.isnan(value):
        return "NAN"
    if math.isinf(value):
        return "INFINITY" if value > 0 else "(-INFINITY)"
    text = repr(float(value))  # shortest string that round-trips exactly
    return f"({text})" if text.startswith("-") else text


# Binary operations: C expression templates on vectors; the scalar CasADi rule in the comment.
_BINARY = {
    ca.OP_ADD: "{a} + {b}",
    ca.OP_SUB: "{a} - {b}",
    ca.OP_MUL: "{a} * {b}",
    ca.OP_DIV: "{a} / {b}",
    ca.OP_LT: "fsm_bool({a} < {b})",
    ca.OP_LE: "fsm_bool({a} <= {b})",
    ca.OP_EQ: "fsm_bool({a} == {b})",
    ca.OP_NE: "fsm_bool({a} != {b})",
    ca.OP_AND: "fsm_bool(({a} != 0) & ({b} != 0))",  # x && y
    ca.OP_OR: "fsm_bool(({a} != 0) | ({b} != 0))",  # x || y
    ca.OP_IF_ELSE_ZERO: "fsm_if_else_zero({a}, {b})",  # x ? y : 0
    ca.OP_FMIN: "fsm_fmin({a}, {b})",
    ca.OP_FMAX: "fsm_fmax({a}, {b})",
    ca.OP_POW: "fsm_pow({a}, {b}, lanes)",
    ca.OP_CONSTPOW: "fsm_pow({a}, {b}, lanes)",
    ca.OP_ATAN2: "fsm_atan2({a}, {b}, lanes)",
}
_UNARY = {
    ca.OP_NEG: "-{a}",
    ca.OP_SQ: "{a} * {a}",  # casadi_sq(x) = x*x
    ca.OP_TWICE: "2.0 * {a}",  # 2.*x
    ca.OP_INV: "1.0 / {a}",  # 1./x
    ca.OP_NOT: "fsm_bool({a} == 0)",  # !x
    ca.OP_FABS: "fsm_fabs({a})",
    ca.OP_SIGN: "fsm_sign({a})",
    ca.OP_SQRT: "fsm_sqrt({a}, lanes)",
    ca.OP_SIN: "fsm_sin({a}, lanes)",
    ca.OP_COS: "fsm_cos({a}, lanes)",
    ca.OP_EXP: "fsm_exp({a}, lanes)",
    ca.OP_LOG: "fsm_log({a}, lanes)",
    ca.OP_TAN: "fsm_tan({a}, lanes)",
    ca.OP_ASIN: "fsm_asin({a}, lanes)",
    ca.OP_ACOS: "fsm_acos({a}, lanes)",
    ca.OP_ATAN: "fsm_atan({a}, lanes)",
    ca.OP_SINH: "fsm_sinh({a}, lanes)",
    ca.OP_COSH: "fsm_cosh({a}, lanes)",
    ca.OP_TANH: "fsm_tanh({a}, lanes)",
    ca.OP_FLOOR: "fsm_floor({a}, lanes)",
    ca.OP_CEIL: "fsm_ceil({a}, lanes)",
}

_PRELUDE = """\
#include <math.h>
#include <string.h>

#include "fsm_pow.h"
#include "fsm_trig.h"
#include "{header}"

#ifdef FSM_HAVE_BATCHED
#ifdef __GNUC__
#pragma GCC diagnostic ignored "-Wpsabi" /* static helpers: the vector-ABI note does not apply */
#endif

typedef fsm_pow_v fsm_v; /* FSM_LANES doubles (fsm_pow.h) */
typedef fsm_pow_m fsm_m;

static inline fsm_v fsm_load(const double *p) {{ fsm_v v; memcpy(&v, p, sizeof v); return v; }}
static inline void fsm_store(double *p, fsm_v v) {{ memcpy(p, &v, sizeof v); }}
static inline fsm_v fsm_splat(double c) {{ return fsm_pow_splat(c); }}
/* mask (-1 / 0 per lane) -> 1.0 / 0.0, as C's comparison result converted to double */
static inline fsm_v fsm_bool(fsm_m m) {{ return (fsm_v)(m & (fsm_m)fsm_splat(1.0)); }}
static inline fsm_v fsm_select(fsm_m m, fsm_v a, fsm_v b) {{ return (fsm_v)(((fsm_m)a & m) | ((fsm_m)b & ~m)); }}
/* c ? x : 0 (c is true when nonzero, NaN included) */
static inline fsm_v fsm_if_else_zero(fsm_v c, fsm_v x) {{ return (fsm_v)((fsm_m)x & (c != 0)); }}
/* fabs: clear the sign bit */
static inline fsm_v fsm_fabs(fsm_v x) {{ return (fsm_v)((fsm_m)x & ~(fsm_m)fsm_splat(-0.0)); }}
/* casadi_sign: x<0 ? -1 : x>0 ? 1 : x */
static inline fsm_v fsm_sign(fsm_v x) {{
  return fsm_select(x < 0, fsm_splat(-1.0), fsm_select(x > 0, fsm_splat(1.0), x));
}}
/* C99 fmax/fmin: a NaN argument is ignored; equal arguments (+0/-0) give the second, as x86 maxsd/minsd */
static inline fsm_v fsm_fmax(fsm_v x, fsm_v y) {{ return fsm_select((x > y) | (y != y), x, y); }}
static inline fsm_v fsm_fmin(fsm_v x, fsm_v y) {{ return fsm_select((x < y) | (y != y), x, y); }}
/* pow: fsmctl's (fsmctl/csrc/fsm_pow.h, the pow of every compiled path: a lane gets exactly the scalar result),
 * FSM_LANES lanes at once */
static inline fsm_v fsm_pow(fsm_v x, fsm_v y, int lanes) {{ return fsm_pow_vec(x, y, lanes); }}
/* two independent powers at once, their chains interleaved (the same bits as fsm_pow of each) */
static inline void fsm_pow2(fsm_v x0, fsm_v y0, fsm_v x1, fsm_v y1, fsm_v *r0, fsm_v *r1, int lanes) {{
  fsm_pow_vec2(x0, y0, x1, y1, r0, r1, lanes);
}}
/* sin, cos: fsmctl's (fsmctl/csrc/fsm_trig.h, likewise), FSM_LANES lanes at once */
static inline fsm_v fsm_sin(fsm_v x, int lanes) {{ return fsm_sincos_vec(x, 1, lanes); }}
static inline fsm_v fsm_cos(fsm_v x, int lanes) {{ return fsm_sincos_vec(x, 0, lanes); }}
/* the other library functions: called per active lane (l < lanes), so every lane gets exactly the scalar libm
 * result; inactive lanes keep x (their results are unspecified and never read) */
#define FSM_LANEWISE(name, fn) \\
  static inline fsm_v name(fsm_v x, int lanes) {{ \\
    fsm_v r = x; \\
    for (int l = 0; l < lanes; ++l) r[l] = fn(x[l]); \\
    return r; \\
  }}
FSM_LANEWISE(fsm_sqrt, sqrt)
FSM_LANEWISE(fsm_exp, exp)
FSM_LANEWISE(fsm_log, log)
FSM_LANEWISE(fsm_tan, tan)
FSM_LANEWISE(fsm_asin, asin)
FSM_LANEWISE(fsm_acos, acos)
FSM_LANEWISE(fsm_atan, atan)
FSM_LANEWISE(fsm_sinh, sinh)
FSM_LANEWISE(fsm_cosh, cosh)
FSM_LANEWISE(fsm_tanh, tanh)
FSM_LANEWISE(fsm_floor, floor)
FSM_LANEWISE(fsm_ceil, ceil)
static inline fsm_v fsm_atan2(fsm_v y, fsm_v x, int lanes) {{
  fsm_v r = y;
  for (int l = 0; l < lanes; ++l) r[l] = atan2(y[l], x[l]);
  return r;
}}
"""

_EPILOGUE = "#endif /* FSM_HAVE_BATCHED */\n"

HEADER = """\
/*
 * DO NOT EDIT: generated by `{generator}` (fsmctl/codegen/batched.py) from the CasADi graphs of the
 * functions named below; the same instructions as their CasADi-generated scalar C (where a kernel calls
 * pow, sin or cos, ordered to start the long dependency chains first, independent pow two or three to one
 * interleaved call), evaluated for FSM_LANES agents per call (4 or 8: fsm_pow.h, set when the library is
 * compiled).
 * Regenerate with `{generator}`; `{generator} --check` verifies this file is current.
 *
 * Needs the GCC/Clang vector extension: other compilers get no kernels (FSM_HAVE_BATCHED undefined).
 * Layout: argument/result i is a block of nnz_i*FSM_LANES doubles, element (k, lane) at p[FSM_LANES*k + lane].
 * All pointers must be non-null.  `lanes` (1..FSM_LANES) is the number of active lanes: library functions
 * (pow, sin, ...) are evaluated for those only; results in the other lanes are unspecified.  Returns 0.
 */
"""


def _signature(name: str, groups: int = 1) -> str:
    if groups == 1:
        return f"int {kernel_name(name)}(const double *const *arg, double *const *res, int lanes)"
    return f"int {kernel_name(name)}_x{groups}(const double *const *const *arg, double *const *const *res, int lanes)"


# Latencies (cycles, rough) that rank the instructions for the scheduler below: only their order matters.
_LATENCY_POW = 150
_LATENCY_LIBRARY = 60
_LATENCY_DIVIDE = 20
_LATENCY_ARITHMETIC = 4
_SLOW_UNARY = {ca.OP_INV: _LATENCY_DIVIDE, ca.OP_SIN: _LATENCY_LIBRARY, ca.OP_COS: _LATENCY_LIBRARY}
_SLOW_BINARY = {ca.OP_DIV: _LATENCY_DIVIDE, ca.OP_POW: _LATENCY_POW, ca.OP_CONSTPOW: _LATENCY_POW}


def _latency(op: int) -> int:
    if op in _SLOW_BINARY:
        return _SLOW_BINARY[op]
    if op in _SLOW_UNARY:
        return _SLOW_UNARY[op]
    if op in _UNARY and "lanes" in _UNARY[op]:  # a library call per lane
        return _LATENCY_LIBRARY
    return _LATENCY_ARITHMETIC


_POW_OPS = (ca.OP_POW, ca.OP_CONSTPOW)


class _Statement(NamedTuple):
    """One single-assignment C statement of a kernel: it defines ``v{k}`` (``k`` its index; an output defines
    nothing) from the statements in ``operands``; ``latency`` ranks it for the scheduler; ``is_pow``: a ``pow``
    whose operands are ``(x, y)``, which :func:`_grouped_pows` may print in an interleaved call."""

    text: str
    operands: tuple[int, ...]
    latency: int
    is_pow: bool = False


def _statements(name: str, function: ca.Function, groups: int = 1) -> list[_Statement]:
    """The function's instructions as single-assignment C statements: statement ``k`` defines ``v{k}`` (outputs
    define nothing) and reads the statements in ``operands``.  With ``groups`` > 1 each
    instruction is printed once per lane group, side by side, group ``g`` reading ``arg[g]`` and writing ``res[g]``."""
    op_names = {getattr(ca, n): n for n in dir(ca) if n.startswith("OP_")}
    current: list[dict[int, int]] = [{} for _ in range(groups)]  # per group: CasADi work slot -> its last statement
    out: list[_Statement] = []
    for k in range(function.n_instructions()):
        op = function.instruction_id(k)
        ins, outs = function.instruction_input(k), function.instruction_output(k)
        if op not in (ca.OP_INPUT, ca.OP_OUTPUT, ca.OP_CONST) and op not in _BINARY and op not in _UNARY:
            raise UnsupportedInstructionError(
                f"{name}: instruction {k} is {op_names.get(op, op)}, which has no lane-wise rule in fsmctl/codegen/batched.py"
            )
        for g, slots in enumerate(current):
            arg, res = ("arg", "res") if groups == 1 else (f"arg[{g}]", f"res[{g}]")
            v = f"v{len(out)}"
            if op == ca.OP_INPUT:
                out.append(_Statement(f"  const fsm_v {v} = fsm_load({arg}[{ins[0]}] + FSM_LANES * {ins[1]});", (), 1))
            elif op == ca.OP_OUTPUT:
                a = slots[ins[0]]
                out.append(_Statement(f"  fsm_store({res}[{outs[0]}] + FSM_LANES * {outs[1]}, v{a});", (a,), 1))
                continue
            elif op == ca.OP_CONST:
                const = _literal(function.instruction_constant(k))
                out.append(_Statement(f"  const fsm_v {v} = fsm_splat({const});", (), 0))
            elif op in _BINARY:
                a, b = slots[ins[0]], slots[ins[1]]
                expr = _BINARY[op].format(a=f"v{a}", b=f"v{b}")
                out.append(_Statement(f"  const fsm_v {v} = {expr};", (a, b), _latency(op), op in _POW_OPS))
            else:
                a = slots[ins[0]]
                out.append(_Statement(f"  const fsm_v {v} = {_UNARY[op].format(a=f'v{a}')};", (a,), _latency(op)))
            slots[outs[0]] = len(out) - 1
    return out


def _schedule(statements: list[_Statement]) -> list[int]:
    """An order of the statements that starts the long dependency chains first (list scheduling by the latency
    of the longest path from a statement to the end; ties in program order): ``pow``'s of independent operands
    then sit side by side, so the CPU overlaps their chains.  Every statement still follows its operands, and each
    value is computed by the same operation from the same operands, so the order changes no result."""
    n = len(statements)
    users: list[list[int]] = [[] for _ in range(n)]
    for k, st in enumerate(statements):
        for a in st.operands:
            users[a].append(k)
    path = [0] * n
    for k in range(n - 1, -1, -1):
        path[k] = statements[k].latency + max((path[u] for u in users[k]), default=0)
    waiting = [len(set(st.operands)) for st in statements]
    ready = [(-path[k], k) for k in range(n) if waiting[k] == 0]
    heapq.heapify(ready)
    order: list[int] = []
    while ready:
        _, k = heapq.heappop(ready)
        order.append(k)
        for u in dict.fromkeys(users[k]):
            waiting[u] -= 1
            if waiting[u] == 0:
                heapq.heappush(ready, (-path[u], u))
    return order


_POW_GROUP = 2
"""Most independent ``pow`` calls printed as one interleaved call (``fsm_pow2`` of the prelude).  Two, not three:
the laws' three |sigma_e,k|^alpha as ``fsm_pow2`` and ``fsm_pow`` took 3-5 % less CPU per Monte Carlo chunk than as
one three-chain call (alternated A/B runs at 4 and 8 lanes on an AVX-512 core, the same bits; why is not
measured: the three-chain call spilled fewer values to the stack than the two-chain one)."""


def _grouped_pows(order: list[int], statements: list[_Statement]) -> list[str]:
    """The statements in ``order``, with runs of consecutive independent ``pow`` statements (as the scheduler places
    the law's three |sigma_e,k|^alpha) printed in pairs as calls of ``fsm_pow2``: one function body in which the CPU
    overlaps their long dependency chains.  Each power is computed by the same operations as alone, so the
    grouping changes no result."""
    lines: list[str] = []
    run: list[int] = []

    def flush() -> None:
        for start in range(0, len(run), _POW_GROUP):
            group = run[start : start + _POW_GROUP]
            if len(group) == 1:
                lines.append(statements[group[0]].text)
                continue
            args = [f"v{a}" for k in group for a in statements[k].operands]  # x, y of each
            outs = [f"&v{k}" for k in group]
            lines.append(f"  fsm_v {', '.join(f'v{k}' for k in group)};")
            lines.append(f"  fsm_pow{len(group)}({', '.join(args + outs)}, lanes);")
        run.clear()

    for k in order:
        if statements[k].is_pow and not any(a in run for a in statements[k].operands):
            run.append(k)
            continue
        flush()
        lines.append(statements[k].text)
    flush()
    return lines


def _kernel(name: str, function: ca.Function, groups: int = 1) -> str:
    if not function.is_a("SXFunction"):
        raise UnsupportedInstructionError(f"{name}: batched kernels need an SX function")
    lines = [
        f"{_signature(name, groups)} {{",
        "  if (lanes > FSM_LANES) lanes = FSM_LANES; /* never index past the vector */",
    ]
    statements = _statements(name, function, groups)
    if any(st.latency >= _LATENCY_LIBRARY for st in statements):
        lines += _grouped_pows(_schedule(statements), statements)
    else:  # short chains only: the CPU overlaps them in program order, which keeps fewer values alive
        lines += [st.text for st in statements]
    lines += ["  return 0;", "}", ""]
    return "\n".join(lines)


def batched_header(
    names: Sequence[str], guard: str = "FSMCTL_BATCHED_H", generator: str = "python -m derive", groups: int = 1
) -> str:
    """C header declaring the batched kernels of ``names`` (``groups``: as :func:`batched_source`)."""
    body = [HEADER.format(generator=generator), f"#ifndef {guard}", f"#define {guard}", ""]
    body += ['#include "fsm_pow.h" /* FSM_LANES */', ""]
    body += ["#if defined(__GNUC__) || defined(__clang__)", "#define FSM_HAVE_BATCHED 1", "#ifdef __cplusplus"]
    body += ['extern "C" {', "#endif"]
    body += [f"{_signature(n, _checked_groups(groups))};" for n in names]
    body += ["#ifdef __cplusplus", "}", "#endif", "#endif", "", f"#endif /* {guard} */", ""]
    return "\n".join(body)


def _checked_groups(groups: int) -> int:
    if isinstance(groups, bool) or not isinstance(groups, int) or groups < 1:
        raise ValueError(f"groups must be an integer >= 1, got {groups!r}")
    return groups


def batched_source(
    functions: Sequence[tuple[str, ca.Function]], header: str, generator: str = "python -m derive", groups: int = 1
) -> str:
    """C source with one batched kernel per ``(name, function)``, including ``header``.

    ``groups`` > 1 prints each kernel for that many lane groups at once, interleaved (issue 31's lever of published
    CPU ensemble solvers): ``int NAME_batched_xG(const double *const *const *arg, double *const *const *res, int
    lanes)``, where ``arg[g]`` and ``res[g]`` are group ``g``'s arguments and results (the layout above) and
    ``lanes`` is the number of active lanes of every group.  Each instruction is printed once per group, side by
    side (independent ``pow`` of all the groups grouped as above), so every lane still gets the scalar program's
    bits.  The library's kernels are printed with ``groups=1``; ``benchmarks/interleave.py`` measures the others
    against them."""
    groups = _checked_groups(groups)
    prelude = _PRELUDE.format(header=header)
    kernels = "\n".join(_kernel(n, f, groups) for n, f in functions)
    return HEADER.format(generator=generator) + prelude + "\n" + kernels + _EPILOGUE
