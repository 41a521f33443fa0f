"""fsmctl.enclosures.intervals: every enclosure contains the exact real value (mpmath, exact rationals, arb)."""

from __future__ import annotations

import functools
import itertools
import math
from fractions import Fraction

import casadi as ca
import flint
import mpmath
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import fsmctl
from fsmctl.enclosures.intervals import Enclosure, IntervalFunction
from fsmctl.model.generated_code import default_law_dir, law_sx_function
from fsmctl.proofs.theorem2 import fsm_parameters

mpmath.mp.dps = 60
M = mpmath.mpf


def _domain(ok: bool, value):
    return value if ok else None


def _pow(x: float, y: float):
    if x > 0:
        return M(x) ** M(y)
    if y == int(y):  # integer exponent: defined for x < 0; 0**0 = 1 (C); 0**negative undefined
        return None if (x == 0 and y < 0) else M(x) ** int(y)
    return M(0) if (x == 0 and y > 0) else None


def _modulo(x: float, y: float, rounding):
    if y == 0:
        return None
    n = rounding(Fraction(x) / Fraction(y))
    return Fraction(x) - n * Fraction(y)


# name: (CasADi expression, exact real value at a point or None outside the domain)
UNARY = {
    "neg": (lambda x: -x, lambda x: -M(x)),
    "inv": (lambda x: 1 / x, lambda x: _domain(x != 0, 1 / M(x) if x != 0 else 0)),
    "sq": (lambda x: x * x, lambda x: M(x) ** 2),
    "twice": (lambda x: x + x, lambda x: 2 * M(x)),
    "sqrt": (ca.sqrt, lambda x: _domain(x >= 0, mpmath.sqrt(max(x, 0.0)))),
    "exp": (ca.exp, lambda x: mpmath.exp(x)),
    "log": (ca.log, lambda x: _domain(x > 0, mpmath.log(x) if x > 0 else 0)),
    "sin": (ca.sin, lambda x: mpmath.sin(x)),
    "cos": (ca.cos, lambda x: mpmath.cos(x)),
    "tan": (ca.tan, lambda x: mpmath.tan(x)),
    "atan": (ca.atan, lambda x: mpmath.atan(x)),
    "asin": (ca.asin, lambda x: _domain(abs(x) <= 1, mpmath.asin(x) if abs(x) <= 1 else 0)),
    "acos": (ca.acos, lambda x: _domain(abs(x) <= 1, mpmath.acos(x) if abs(x) <= 1 else 0)),
    "tanh": (ca.tanh, lambda x: mpmath.tanh(x)),
    "sinh": (ca.sinh, lambda x: mpmath.sinh(x)),
    "cosh": (ca.cosh, lambda x: mpmath.cosh(x)),
    "fabs": (ca.fabs, lambda x: abs(M(x))),
    "sign": (ca.sign, lambda x: M((x > 0) - (x < 0))),
    "floor": (ca.floor, lambda x: M(math.floor(x))),
    "ceil": (ca.ceil, lambda x: M(math.ceil(x))),
    "log1p": (ca.log1p, lambda x: _domain(x > -1, mpmath.log1p(x) if x > -1 else 0)),
    "expm1": (ca.expm1, lambda x: mpmath.expm1(x)),
    "erf": (ca.erf, lambda x: mpmath.erf(x)),
    "not": (ca.logic_not, lambda x: M(x == 0)),
    "constpow_2.5": (lambda x: x**2.5, lambda x: _pow(x, 2.5)),
    "constpow_0.7": (lambda x: x**0.7, lambda x: _pow(x, 0.7)),
    "constpow_-1.5": (lambda x: x**-1.5, lambda x: _pow(x, -1.5)),
}
BINARY = {
    "add": (lambda x, y: x + y, lambda x, y: M(x) + M(y)),
    "sub": (lambda x, y: x - y, lambda x, y: M(x) - M(y)),
    "mul": (lambda x, y: x * y, lambda x, y: M(x) * M(y)),
    "div": (lambda x, y: x / y, lambda x, y: _domain(y != 0, M(x) / M(y) if y != 0 else 0)),
    "pow": (ca.power, _pow),
    "atan2": (ca.atan2, lambda y, x: mpmath.atan2(y, x)),
    "hypot": (ca.hypot, lambda x, y: mpmath.hypot(x, y)),
    "fmin": (ca.fmin, lambda x, y: M(min(x, y))),
    "fmax": (ca.fmax, lambda x, y: M(max(x, y))),
    "copysign": (ca.copysign, lambda x, y: abs(M(x)) if y >= 0 else -abs(M(x))),
    "fmod": (ca.fmod, lambda x, y: _modulo(x, y, math.trunc)),
    "remainder": (ca.remainder, lambda x, y: _modulo(x, y, round)),  # round(Fraction): half to even
    "lt": (lambda x, y: x < y, lambda x, y: M(x < y)),
    "le": (lambda x, y: x <= y, lambda x, y: M(x <= y)),
    "eq": (lambda x, y: x == y, lambda x, y: M(x == y)),
    "ne": (lambda x, y: x != y, lambda x, y: M(x != y)),
    "and": (ca.logic_and, lambda x, y: M(x != 0 and y != 0)),
    "or": (ca.logic_or, lambda x, y: M(x != 0 or y != 0)),
    "if_else_zero": (lambda c, x: ca.if_else(c, x, 0, True), lambda c, x: M(x) if c != 0 else M(0)),
}
TRI_VALUED = {"sign", "not", "lt", "le", "eq", "ne", "and", "or"}


@functools.cache
def _function(name: str) -> IntervalFunction:
    x, y = ca.SX.sym("x"), ca.SX.sym("y")
    if name in UNARY:
        return IntervalFunction(ca.Function("f", [x], [UNARY[name][0](x)]))
    return IntervalFunction(ca.Function("f", [x, y], [BINARY[name][0](x, y)]))


def _ops(f: ca.Function) -> set[str]:
    names = {getattr(ca, n): n[3:] for n in dir(ca) if n.startswith("OP_")}
    return {names[f.instruction_id(k)] for k in range(f.n_instructions())}


def test_every_supported_operation_is_exercised():
    required = (
        "ADD SUB MUL DIV NEG INV SQ TWICE SQRT EXP LOG POW CONSTPOW SIN COS TAN ATAN ASIN ACOS TANH SINH COSH ATAN2 "
        "FABS SIGN COPYSIGN FMIN FMAX FLOOR CEIL FMOD REMAINDER LT LE EQ NE NOT AND OR IF_ELSE_ZERO LOG1P EXPM1 "
        "HYPOT ERF"
    ).split()
    seen: set[str] = set()
    for name in list(UNARY) + list(BINARY):
        seen |= _ops(_function(name)._function)
    assert set(required) <= seen


@st.composite
def _box(draw, integer_exponent: bool = False):
    """An interval: straddling 0, tiny, degenerate, large, near multiples of pi/2 (critical points)."""
    if integer_exponent and draw(st.booleans()):
        n = float(draw(st.integers(-5, 5)))
        return n, n
    special = [0.0, -0.0, 1.0, -1.0, 0.5, math.pi / 2, math.pi, -math.pi / 2, 3 * math.pi / 2, 2 * math.pi]
    centre = draw(
        st.one_of(
            st.sampled_from(special),
            st.floats(-4, 4),
            st.floats(-1e6, 1e6),
            st.floats(-1e300, 1e300),
            st.floats(-1e-300, 1e-300),
        )
    )
    width = draw(st.one_of(st.just(0.0), st.floats(0, 1e-12), st.floats(0, 1), st.floats(0, 10)))
    shift = draw(st.floats(0, 1))
    lo = centre - width * shift
    return lo, max(lo + width, lo)


def _points(lo: float, hi: float, ts: list[float]) -> list[float]:
    return [lo, hi] + [min(max(lo + t * (hi - lo), lo), hi) for t in ts]


def _check_contains(name, lo_bound, hi_bound, value):
    if value is None:
        return
    assert lo_bound <= value <= hi_bound, f"{name}: {value} not in [{lo_bound!r}, {hi_bound!r}]"


def _check_op(name: str, oracle, boxes: list[list[tuple[float, float]]], ts: list[float]) -> None:
    f = _function(name)
    lo = np.array([[b[i][0] for b in boxes] for i in range(f.n_in)])
    hi = np.array([[b[i][1] for b in boxes] for i in range(f.n_in)])
    e = f.enclose(lo, hi)
    assert e.lo.shape == (1, len(boxes)) and e.continuous.shape == (len(boxes),)
    assert not np.isnan(e.lo).any() and not np.isnan(e.hi).any() and np.all(e.lo <= e.hi)
    if name in TRI_VALUED:
        assert set(e.lo.ravel()) | set(e.hi.ravel()) <= {-1.0, 0.0, 1.0}
    for j, box in enumerate(boxes):
        arb_lo, arb_hi = f.enclose_arb(lo[:, j], hi[:, j]) if j < 3 else (None, None)
        grids = [_points(a, b, ts) for a, b in box]
        points = list(zip(*grids, strict=True)) if len(grids) == 1 else [(p, q) for p in grids[0] for q in grids[1]]
        for point in points:
            value = oracle(*point)
            _check_contains(name, e.lo[0, j], e.hi[0, j], value)
            if arb_lo is not None:
                _check_contains(name + " (arb)", arb_lo[0], arb_hi[0], value)


@pytest.mark.parametrize("name", sorted(UNARY))
@settings(max_examples=40)
@given(data=st.data())
def test_unary_enclosures_contain_the_exact_value(name, data):
    boxes = [[data.draw(_box())] for _ in range(6)]
    ts = data.draw(st.lists(st.floats(0, 1), min_size=1, max_size=3))
    _check_op(name, UNARY[name][1], boxes, ts)


@pytest.mark.parametrize("name", sorted(BINARY))
@settings(max_examples=30)
@given(data=st.data())
def test_binary_enclosures_contain_the_exact_value(name, data):
    boxes = [[data.draw(_box()), data.draw(_box(integer_exponent=name == "pow"))] for _ in range(5)]
    ts = data.draw(st.lists(st.floats(0, 1), min_size=1, max_size=2))
    _check_op(name, BINARY[name][1], boxes, ts)


def _one(name: str, *bounds: tuple[float, float]) -> tuple[float, float, bool]:
    e = _function(name).enclose(np.array([b[0] for b in bounds]), np.array([b[1] for b in bounds]))
    return float(e.lo[0, 0]), float(e.hi[0, 0]), bool(e.continuous[0])


def test_tri_valued_operations_are_decided_when_certain():
    assert _one("lt", (0, 1), (2, 3)) == (1.0, 1.0, True)
    assert _one("lt", (2, 3), (0, 2)) == (0.0, 0.0, True)
    assert _one("le", (0, 2), (2, 3)) == (1.0, 1.0, True)
    assert _one("lt", (0, 2.5), (2, 3)) == (0.0, 1.0, False)
    assert _one("eq", (2, 2), (2, 2)) == (1.0, 1.0, True)
    assert _one("ne", (0, 1), (1.5, 2)) == (1.0, 1.0, True)
    assert _one("sign", (-2, -1)) == (-1.0, -1.0, True)
    assert _one("sign", (0, 0)) == (0.0, 0.0, True)
    assert _one("sign", (0, 1)) == (0.0, 1.0, False)
    assert _one("sign", (-1, 1)) == (-1.0, 1.0, False)
    assert _one("if_else_zero", (1, 2), (3, 4)) == (3.0, 4.0, True)
    assert _one("if_else_zero", (0, 0), (3, 4)) == (0.0, 0.0, True)
    assert _one("if_else_zero", (0, 1), (3, 4)) == (0.0, 4.0, False)
    assert _one("and", (1, 2), (0, 0))[:2] == (0.0, 0.0)
    assert _one("or", (1, 2), (-1, 1)) == (1.0, 1.0, True)


def test_exact_rules_are_tight():
    lo, hi, _ = _one("sq", (-1, 2))
    assert lo == 0.0 and 4.0 <= hi <= 4.0 + 1e-14
    lo, hi, _ = _one("sin", (0.0, 3.0))
    assert hi == 1.0 and -1e-15 <= lo <= 0.0
    lo, hi, _ = _one("cos", (-0.5, 0.5))
    assert hi == 1.0 and lo > 0.87
    assert _one("fabs", (-3, 2)) == (0.0, 3.0, True)
    assert _one("fmin", (0, 5), (1, 2)) == (0.0, 2.0, True)
    lo, hi, _ = _one("add", (0, 1), (0, 1))
    assert lo == 0.0  # a sum of nonnegatives stays nonnegative (sqrt of a sum of squares stays finite)


def test_domain_violations_give_infinite_enclosures():
    whole = (-math.inf, math.inf)
    assert _one("sqrt", (-1e-300, 1))[:2] == whole
    assert _one("log", (-1, 1))[:2] == whole
    assert _one("log", (0, 1))[0] == -math.inf and _one("log", (0, 1))[1] < 1e-15
    assert _one("constpow_0.7", (-1e-9, 1))[:2] == whole
    assert _one("pow", (-1, 1), (0.5, 0.5))[:2] == whole
    assert _one("pow", (-2, -1), (3, 3))[1] < -0.99  # integer exponent: negative base allowed
    assert _one("div", (1, 2), (-1, 1))[:2] == whole
    assert _one("div", (1, 2), (0, 1))[:2] == whole
    assert _one("div", (0, 0), (-1, 1))[:2] == (0.0, 0.0)
    assert _one("asin", (0.5, 1.5))[:2] == whole
    assert _one("tan", (1.5, 1.6))[:2] == whole
    assert _one("fmod", (1, 2), (-1, 1))[:2] == whole
    f = _function("sqrt")
    assert tuple(f.enclose_arb([-1.0], [1.0])) == (np.array([-math.inf]), np.array([math.inf]))


def test_continuous_flag_marks_boxes_where_a_switch_may_happen():
    s = ca.SX.sym("s")
    f = IntervalFunction(ca.Function("f", [s], [ca.sign(s) * ca.fabs(s) ** 0.7 + ca.if_else(s > 0.5, s, -s)]))
    e = f.enclose(np.array([[-0.1, 0.1, 0.4, 0.6]]), np.array([[0.1, 0.3, 0.6, 0.9]]))
    assert e.continuous.tolist() == [False, True, False, True]
    assert isinstance(e, Enclosure)


def _mrp_graph() -> tuple[ca.Function, callable]:
    sigma, omega, s = ca.SX.sym("sigma", 3), ca.SX.sym("omega", 3), ca.SX.sym("s")
    G = 0.25 * ((1 - ca.dot(sigma, sigma)) * ca.SX.eye(3) + 2 * ca.skew(sigma) + 2 * sigma @ sigma.T)
    outputs = ca.vertcat(
        G @ omega,
        ca.fmin(ca.fmax(s, -1), 1),
        ca.sign(s) * ca.fabs(s) ** 0.7,
        ca.if_else(s > 0.2, s**2, -s),
        ca.sqrt(ca.sumsqr(sigma)),
    )
    f = ca.Function("mrp", [sigma, omega, s], [outputs, ca.SX(2, 1)])

    def exact(x):
        sg, om, sv = [M(v) for v in x[:3]], [M(v) for v in x[3:6]], M(x[6])
        n2 = sum(v * v for v in sg)
        cross = [sg[1] * om[2] - sg[2] * om[1], sg[2] * om[0] - sg[0] * om[2], sg[0] * om[1] - sg[1] * om[0]]
        dot = sum(a * b for a, b in zip(sg, om, strict=True))
        kin = [((1 - n2) * om[i] + 2 * cross[i] + 2 * sg[i] * dot) / 4 for i in range(3)]
        power = mpmath.sign(sv) * abs(sv) ** M("0.7") if sv != 0 else M(0)
        return [*kin, min(max(sv, -1), 1), power, sv**2 if sv > M("0.2") else -sv, mpmath.sqrt(n2), M(0), M(0)]

    return f, exact


def test_composed_graph_contains_exact_values_and_converges_at_order_one():
    f, exact = _mrp_graph()
    F = IntervalFunction(f)
    assert (F.n_in, F.n_out) == (7, 9)
    rng = np.random.default_rng(2)
    centres = rng.uniform(-1, 1, size=(7, 40))
    widths = []
    for r in (1e-1, 1e-3, 1e-5):
        lo, hi = centres - r, centres + r
        e = F.enclose(lo, hi)
        assert np.all(e.lo[7:] == 0) and np.all(e.hi[7:] == 0)  # structural zeros
        for j in range(0, 40, 4):
            for x in rng.uniform(lo[:, j], hi[:, j], size=(3, 7)):
                for k, v in enumerate(exact(x)):
                    assert e.lo[k, j] <= v <= e.hi[k, j], (k, x)
            a_lo, a_hi = F.enclose_arb(lo[:, j], hi[:, j])
            assert np.all(a_lo <= exact(centres[:, j])) and np.all(np.array(exact(centres[:, j])) <= a_hi)
        widths.append((e.hi[:7] - e.lo[:7], e.continuous))
    for (wide, c_wide), (narrow, c_narrow) in itertools.pairwise(widths):
        both = c_wide & c_narrow  # order 1: a box 100x smaller gives an enclosure ~100x narrower
        assert both.sum() > 20 and np.all(narrow[:, both] <= 0.05 * wide[:, both] + 1e-12)


@functools.cache
def _closed_loop_law() -> ca.Function:
    """The paper's law_control_exact as a function of (sigma, omega), the rest at the paper's values."""
    law_dir = default_law_dir()
    paper = fsmctl.paper_scenario("1")
    J0, params = paper.agents[0].J0_array, fsm_parameters(paper)[0]
    constants = law_sx_function(law_dir, "law_constants")(params)
    sigma, omega = ca.SX.sym("sigma", 3), ca.SX.sym("omega", 3)
    z, z0 = ca.DM.zeros(3), ca.DM.zeros(0)
    sd, wd = ca.DM([0.1, -0.2, 0.05]), ca.DM([0.001, 0.0, -0.002])
    _, cache = law_sx_function(law_dir, "law_local_exact")(0, sigma, omega, z0, sd, wd, z, J0, params, constants)
    u = law_sx_function(law_dir, "law_control_exact")(
        0, sigma, omega, z0, sd, wd, z, J0, params, constants, cache, 1.0, z, 0.0, 0.05
    )
    return ca.Function("closed_loop", [ca.vertcat(sigma, omega)], [ca.vertcat(u[0], u[1])])


def test_paper_law_enclosures_contain_arb_point_values_and_shrink():
    f = _closed_loop_law()
    F = IntervalFunction(f)
    rng = np.random.default_rng(3)
    centres = np.vstack([rng.uniform(-0.5, 0.5, (3, 12)), rng.uniform(-0.05, 0.05, (3, 12))])
    prev = None
    for r in (1e-3, 1e-5):
        lo, hi = centres - r, centres + r
        e = F.enclose(lo, hi)
        assert np.all(np.isfinite(e.lo)) and np.all(np.isfinite(e.hi))
        for j in range(12):
            x = rng.uniform(lo[:, j], hi[:, j])
            balls = F.evaluate_ball(x)
            double = np.asarray(f(x)).ravel()
            for k, ball in enumerate(balls):
                assert flint.arb(e.lo[k, j]) <= ball <= flint.arb(e.hi[k, j])
                assert abs(float(ball.mid()) - double[k]) <= 1e-9 * (1 + abs(double[k]))
        width = (e.hi - e.lo, e.continuous)
        if prev is not None:
            both = width[1] & prev[1]
            assert both.sum() >= 6 and np.all(width[0][:, both] <= 0.05 * prev[0][:, both] + 1e-15)
        prev = width
    a_lo, a_hi = F.enclose_arb(lo[:, 0], hi[:, 0])
    mid = np.asarray(f(centres[:, 0])).ravel()
    assert np.all(a_lo <= mid) and np.all(mid <= a_hi)
    assert np.all(a_hi - a_lo <= 1.1 * (e.hi[:, 0] - e.lo[:, 0]) + 1e-12)  # both routes: the same dependency


def test_layout_errors_and_unsupported_operations():
    A = ca.SX.sym("A", ca.Sparsity.lower(2))  # 3 nonzeros; dense layout (0,0), (1,0), (0,1), (1,1)
    F = IntervalFunction(ca.Function("f", [A], [A[1, 0] * 2]))
    assert F.n_in == 4
    e = F.enclose(np.array([0.0, 1.0, 0.0, 0.0]), np.array([0.0, 2.0, 0.0, 0.0]))
    assert 2.0 >= e.lo[0, 0] > 1.99 and 4.0 <= e.hi[0, 0] < 4.01
    with pytest.raises(ValueError):
        F.enclose(np.ones(4), np.zeros(4))
    with pytest.raises(ValueError):
        F.enclose(np.zeros(3), np.ones(3))
    x = ca.SX.sym("x")
    with pytest.raises(NotImplementedError, match="ASINH"):
        IntervalFunction(ca.Function("f", [x], [ca.asinh(x)]))
    m = ca.MX.sym("m")
    with pytest.raises(TypeError):
        IntervalFunction(ca.Function("f", [m], [ca.sin(m)]))
