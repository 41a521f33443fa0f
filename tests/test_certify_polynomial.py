"""The sum-of-squares route's polynomial model of the closed loop (fsmctl.proofs.certify_polynomial).

Oracle: Euler's equations ``J omega_dot = u + d - omega x J omega`` written out in NumPy with the true inertia, and
the documented PD example's torque ``u = -K sigma_e - P omega_e`` (isolated agent: the consensus term vanishes).
The model must reproduce the true loop exactly at the inputs ``inputs_at`` gives, and those inputs must lie in the
model's boxes for every admissible inertia and disturbance (otherwise the certificate would not cover the true
loop): the widened disturbance ``d'`` of the independent principal moments reaches its bound at the corners.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from fsmctl.proofs.certify_polynomial import polynomial_loop
from fsmctl.proofs.certify_symbolic import reduced_torque, state_symbols
from fsmctl.proofs.law_check import load_law_variants

MY_LAW = Path(__file__).resolve().parents[1] / "docs" / "examples" / "my_law.py"
K, P = 4.0, 12.0
PARAMS = np.array([K, P, 1.0])
W = (0.1, 0.08, 0.12)  # the region's omega_e half-widths (unequal: each axis' bound uses the other two)


@pytest.fixture(scope="module")
def pd_law():
    return load_law_variants(str(MY_LAW)).exact


_LOOPS: dict = {}


def _cached(law, a, inertia_set):
    """The diagonal example's model and its field as a NumPy function, built once per set."""
    key = (a, inertia_set)
    if key not in _LOOPS:
        loop = _loop(law, np.diag([20.0, 25.0, 30.0]), a, inertia_set)
        _LOOPS[key] = loop, _field_function(loop)
    return _LOOPS[key]


def _loop(law, J0, a, inertia_set, D=(0.2, 0.24, 0.22)):
    reduced = reduced_torque(law, PARAMS, J0, at_rest=True)
    return polynomial_loop(
        law, reduced, J0, W, inertia=a, inertia_set=inertia_set, disturbance=D, reference_at_rest=True,
        torque_limit=np.inf,
    )  # fmt: skip


def _field_function(loop):
    s, w, _ = state_symbols(0)
    return sp.lambdify([*s, *w, *loop.symbols()], list(loop.field), "numpy")


def _euler(J, se, we, d):
    u = -K * se - P * we
    s2 = se @ se
    S = np.array([[0, -se[2], se[1]], [se[2], 0, -se[0]], [-se[1], se[0], 0]])
    G = 0.25 * ((1 - s2) * np.eye(3) + 2 * S + 2 * np.outer(se, se))
    return np.concatenate([G @ we, np.linalg.solve(J, u + d - np.cross(we, J @ we))])


unit = st.floats(-1.0, 1.0)
vec = st.tuples(unit, unit, unit).map(np.array)


@pytest.mark.parametrize("inertia_set", ["proportional", "entries"])
@settings(max_examples=60, deadline=None)
@given(a=st.sampled_from([0.05, 0.1, 0.3]), s=vec, w=vec, th=vec, dd=vec, corner=st.booleans())
def test_model_is_the_true_loop_inside_its_boxes(pd_law, inertia_set, a, s, w, th, dd, corner):
    J0 = np.diag([20.0, 25.0, 30.0])
    loop, f = _cached(pd_law, a, inertia_set)
    D = np.array([0.2, 0.24, 0.22])
    if corner:  # the gyroscopic error is largest at the box's corners
        w, th, dd = np.sign(w) + (w == 0), np.sign(th) + (th == 0), np.sign(dd) + (dd == 0)
    se, we, d = 0.5 * s, np.array(W) * w, D * dd
    theta = a * th
    if inertia_set == "proportional":
        theta = theta[:1]
        J = (1 + theta[0]) * J0
    else:
        J = J0 * (1 + np.diag(theta))
    inputs = loop.inputs_at(we, theta, d)
    # the boxes' edges are reached exactly at the corners: a relative 1e-12 for inputs_at's own float rounding
    assert np.all(np.abs(inputs) <= np.array(loop.half_widths) * (1 + 1e-12))
    got = np.array(f(*se, *we, *inputs), dtype=float)
    np.testing.assert_allclose(got, _euler(J, se, we, d), rtol=1e-12, atol=1e-15)


def test_entries_widen_the_disturbance_by_the_gyroscopic_error_bound(pd_law):
    a = 0.1
    loop = _loop(pd_law, np.diag([20.0, 25.0, 30.0]), a, "entries")
    # |omega_i omega_j (dJ_jj - dJ_ii)| <= a W_i W_j (J0_ii + J0_jj), reached at a corner
    E = [a * W[1] * W[2] * 55.0, a * W[2] * W[0] * 50.0, a * W[0] * W[1] * 45.0]
    np.testing.assert_allclose(loop.half_widths[:3], np.array([0.2, 0.24, 0.22]) + E, rtol=1e-15)
    np.testing.assert_allclose(loop.half_widths[3:], [a / (1 - a * a)] * 3, rtol=1e-15)
    assert loop.inputs == ("d[0]", "d[1]", "d[2]", "q[0]", "q[1]", "q[2]")
    # the proportional set needs no widening (the gyroscopic term scales with r exactly) and one factor
    prop = _loop(pd_law, np.diag([20.0, 25.0, 30.0]), a, "proportional")
    assert prop.half_widths[:3] == (0.2, 0.24, 0.22) and prop.inputs[3:] == ("q[0]",)
    nominal = _loop(pd_law, np.diag([20.0, 25.0, 30.0]), 0.0, "entries")
    assert nominal.inputs == ("d[0]", "d[1]", "d[2]") and nominal.how == "the nominal inertia"


def test_why_a_loop_is_not_polynomial(pd_law):
    J0 = np.array([[20.0, 1.0, 0.0], [1.0, 25.0, 0.0], [0.0, 0.0, 30.0]])
    why = _loop(pd_law, J0, 0.1, "entries")
    assert isinstance(why, str) and "non-diagonal" in why
    assert not isinstance(_loop(pd_law, J0, 0.1, "proportional"), str)  # the proportional set stays exact
    reduced = reduced_torque(pd_law, PARAMS, J0, at_rest=True)
    common = dict(inertia=0.0, inertia_set="entries", disturbance=(0.1, 0.1, 0.1))
    assert polynomial_loop(pd_law, reduced, J0, W, reference_at_rest=False, torque_limit=np.inf, **common) == (
        "the reference moves"
    )
    assert "limited" in polynomial_loop(pd_law, reduced, J0, W, reference_at_rest=True, torque_limit=1.0, **common)
    assert "reduced" in polynomial_loop(pd_law, None, J0, W, reference_at_rest=True, torque_limit=np.inf, **common)
