"""The exact symbolic checks shared by ``fsmctl prove --law`` and ``fsmctl certify``
(:mod:`fsmctl.proofs.symbolic_identities`), against independent oracles: numeric evaluation at seeded random points
(an identity it accepts must vanish there; a perturbed one must not be accepted), the analytic radius law of a
uniform ball, and a computation that outlives its time limit.
"""

from __future__ import annotations

import time

import numpy as np
import pytest
import sympy as sp
from scipy import stats

from fsmctl.parallel import run_with_time_limit
from fsmctl.proofs.symbolic_identities import (
    UNIT_BALL_SAMPLES,
    identically_zero,
    resolve_branches_on_unit_ball,
    uniform_ball_points,
)

X, Y = sp.symbols("x y", real=True)
EPS = sp.Symbol("eps", positive=True)
SIGMA = sp.ImmutableMatrix(sp.symbols("sigma[0:3]", real=True))
R2 = SIGMA.dot(SIGMA)


def _vanishes_numerically(expr: sp.Expr, symbols, seed: int = 0) -> bool:
    """``expr`` is 0 (to 1e-9 relative) at 50 seeded random points, evaluated by mpmath at 30 digits."""
    rng = np.random.default_rng(seed)
    for _ in range(50):
        point = {s: sp.Float(rng.uniform(0.2, 2.0) * rng.choice([-1, 1]) if not s.is_positive else rng.uniform(0.2, 2))
                 for s in symbols}  # fmt: skip
        value = complex(expr.xreplace(point).evalf(30))
        if abs(value) > 1e-9:
            return False
    return True


IDENTITIES = [
    (X**2 - 1) / (X - 1) - (X + 1),
    sp.Abs(X) - X * sp.sign(X),
    EPS ** (sp.Rational(1, 3) - 2) - EPS ** (sp.Rational(1, 3) - 1) / EPS,
    sp.Piecewise((X**2 / X, X > 0), (Y, True)) - sp.Piecewise((X, X > 0), (Y, True)),
    sp.sign(X) * (X + Y) ** 2 - sp.sign(X) * (X**2 + 2 * X * Y + Y**2),
]


@pytest.mark.parametrize("expr", IDENTITIES, ids=str)
def test_an_identity_is_recognised_and_vanishes(expr):
    assert identically_zero([expr])
    assert _vanishes_numerically(expr, sorted(expr.free_symbols, key=str))


@pytest.mark.parametrize("expr", IDENTITIES, ids=str)
def test_a_perturbed_identity_is_not_accepted(expr):
    wrong = expr + sp.Rational(1, 1000) * X * Y
    assert not _vanishes_numerically(wrong, sorted(wrong.free_symbols, key=str))
    assert not identically_zero([wrong])
    assert not identically_zero([IDENTITIES[0], wrong])  # one wrong expression among true ones


def test_false_means_not_shown_not_disproved():
    # true identities outside the rational test: a transcendental one, and sgn(x)^2 x^2 = x^2 with sgn(x) held free
    for expr in (sp.sin(X) ** 2 + sp.cos(X) ** 2 - 1, sp.sign(X) ** 2 * X**2 - X**2):
        assert _vanishes_numerically(expr, [X])
        assert not identically_zero([expr])


def test_branches_resolve_symbolically_on_the_unit_ball():
    # the MRP shadow-set switch: sigma on |sigma| <= 1, -sigma/|sigma|^2 outside
    switch = SIGMA.applyfunc(lambda s: sp.Piecewise((s, R2 <= 1), (-s / R2, True)))
    expr = switch + sp.ImmutableMatrix([sp.Abs(R2 - 2), sp.Abs(R2 + 1), 0])
    resolved, how = resolve_branches_on_unit_ball(expr, SIGMA)
    assert not resolved.has(sp.Piecewise, sp.Abs)
    assert identically_zero(list(resolved - SIGMA - sp.ImmutableMatrix([2 - R2, R2 + 1, 0])))
    assert how and all(text.endswith("(symbolic)") for text in how)
    # oracle: the original and the resolved agree at points of the ball
    pts = uniform_ball_points(np.random.default_rng(3), 200, 3, 1.0)
    f, g = sp.lambdify(list(SIGMA), expr), sp.lambdify(list(SIGMA), resolved)
    assert max(np.max(np.abs(f(*p) - g(*p))) for p in pts) < 1e-12


def test_a_condition_not_on_the_radius_is_sampled_and_said_so():
    expr = sp.Piecewise((SIGMA[0], SIGMA[0] + SIGMA[1] <= 2), (0, True))
    resolved, how = resolve_branches_on_unit_ball(expr, SIGMA)
    assert resolved == SIGMA[0]
    assert how == [f"{SIGMA[0] + SIGMA[1] <= 2} at {UNIT_BALL_SAMPLES} points of |sigma| <= 1 (sampled)"]


def test_a_branch_that_does_not_hold_on_all_of_the_ball_is_not_taken():
    # |sigma|^2 <= 1/2 fails on part of the ball: the next branch (always) is taken; sigma_0 >= 0 holds nowhere
    # on all of it: the Abs is kept
    expr = sp.Piecewise((SIGMA[0], R2 <= sp.Rational(1, 2)), (SIGMA[1], True)) + sp.Abs(SIGMA[0])
    resolved, how = resolve_branches_on_unit_ball(expr, SIGMA)
    assert resolved == SIGMA[1] + sp.Abs(SIGMA[0])
    assert how == ["always"]


def test_ball_points_follow_the_uniform_radius_law():
    # uniform in the d-ball of radius R: P(|x| <= r) = (r / R)^d, and the directions have mean 0
    for dim, radius in ((1, 0.5), (3, 2.0), (6, 1.0)):
        pts = uniform_ball_points(np.random.default_rng(7), 4000, dim, radius)
        r = np.linalg.norm(pts, axis=1)
        assert pts.shape == (4000, dim) and np.all(r <= radius)
        assert stats.kstest((r / radius) ** dim, "uniform").pvalue > 1e-3
        assert np.all(np.abs(pts.mean(axis=0)) < 5 * radius / np.sqrt(4000))
    assert uniform_ball_points(np.random.default_rng(0), 5, 0, 1.0).shape == (5, 0)


def test_symbolic_work_is_time_limited():
    t0 = time.perf_counter()
    finished, value = run_with_time_limit(lambda: time.sleep(30) or True, 0.5)
    assert (finished, value) == (False, None) and time.perf_counter() - t0 < 10
    assert run_with_time_limit(lambda: 1 + 1, 10) == (True, 2)


def test_an_error_in_the_computation_comes_back_as_text():
    assert run_with_time_limit(lambda: sp.Matrix([[1, 2], [2, 4]]).inv(), 10) == (
        True,
        "error: NonInvertibleMatrixError: Matrix det == 0; not invertible.",
    )
