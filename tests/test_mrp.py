"""MRP helpers (generated code and symbolic) against SciPy's Rotation and known identities."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from fsmctl.model.generated_code import casadi_function
from fsmctl.symbolic.mrp import mrp_compose, mrp_G, mrp_G_inverse
from fsmctl.symbolic.symbols import vector_symbols

component = st.floats(-3, 3, allow_nan=False)
mrp = st.tuples(component, component, component).map(np.array)
SETTINGS = settings(max_examples=200, derandomize=True, deadline=None)


def dcm(sigma):
    return np.asarray(casadi_function("mrp_to_dcm")(sigma))


def error(sigma, sigma_d):
    return np.asarray(casadi_function("mrp_error")(sigma, sigma_d)).ravel()


def angle(sigma):
    return float(casadi_function("mrp_principal_angle")(sigma))


def shadow(sigma):
    return np.asarray(casadi_function("mrp_shadow")(sigma)).ravel()


@SETTINGS
@given(mrp)
def test_dcm_is_the_passive_rotation_of_scipy(sigma):
    # [BN] maps N-frame components to B-frame components: the transpose of SciPy's active matrix
    np.testing.assert_allclose(dcm(sigma), Rotation.from_mrp(sigma).as_matrix().T, atol=1e-12)


@SETTINGS
@given(mrp, mrp)
def test_error_is_relative_attitude_in_the_shadow_set(sigma, sigma_d):
    se = error(sigma, sigma_d)
    assert np.linalg.norm(se) <= 1 + 1e-12
    np.testing.assert_allclose(dcm(se), dcm(sigma) @ dcm(sigma_d).T, atol=1e-11)


@SETTINGS
@given(mrp)
def test_principal_angle_and_shadow(sigma):
    s = shadow(sigma)
    assert np.linalg.norm(s) <= 1 + 1e-12
    np.testing.assert_allclose(dcm(s), dcm(sigma), atol=1e-11)
    assert angle(s) == pytest.approx(Rotation.from_mrp(sigma).magnitude(), abs=1e-10)
    assert angle(s) == pytest.approx(4 * np.arctan(np.linalg.norm(s)), abs=1e-14)


def test_error_edge_cases():
    z = np.zeros(3)
    np.testing.assert_array_equal(error(z, z), z)
    s = np.array([0.3, -0.2, 0.5])
    np.testing.assert_allclose(error(s, s), z, atol=1e-15)
    # sigma and its shadow are the same attitude: zero error, no division by zero
    far = np.array([0.0, 0.0, 1.0])  # 180 deg: |sigma| = 1, shadow = -sigma
    np.testing.assert_allclose(error(far, -far), z, atol=1e-15)
    # a half turn relative to the reference has |sigma_e| = 1 and theta = pi
    assert angle(error(far, z)) == pytest.approx(np.pi)


@SETTINGS
@given(mrp, st.tuples(component, component, component).map(np.array))
def test_kinematics_match_dcm_kinematics(sigma, omega):
    # sigma_dot = G(sigma) omega (eq 3) must give d/dt [BN] = -omega^x [BN]
    sigma_dot = np.asarray(casadi_function("plant_rhs")(sigma, omega, np.zeros(3), np.eye(3))[0]).ravel()
    h = 1e-6
    dR = (dcm(sigma + h * sigma_dot) - dcm(sigma - h * sigma_dot)) / (2 * h)
    wx = np.array([[0, -omega[2], omega[1]], [omega[2], 0, -omega[0]], [-omega[1], omega[0], 0]])
    np.testing.assert_allclose(dR, -wx @ dcm(sigma), atol=1e-6 * (1 + np.linalg.norm(sigma_dot)))


def test_direct_composition_formula_agrees_with_the_quaternion_route():
    a, b = vector_symbols("a"), vector_symbols("b")
    direct = sp.lambdify([a, b], mrp_compose(a, b), "numpy")
    rng = np.random.default_rng(1)
    for _ in range(200):
        x, y = rng.uniform(-1, 1, 3), rng.uniform(-1, 1, 3)
        d = np.asarray(direct(x, y), dtype=float).ravel()
        # [FN] = [FB][BN]: same attitude as mrp_error(outer, inverse(inner)) with inverse = -sigma
        np.testing.assert_allclose(dcm(d), dcm(x) @ dcm(y), atol=1e-10)
        np.testing.assert_allclose(shadow(d), error(x, -y), atol=1e-10)


def test_closed_form_G_inverse():
    s = vector_symbols("s")
    G = sp.lambdify([s], mrp_G(s), "numpy")
    Gi = sp.lambdify([s], mrp_G_inverse(s), "numpy")
    rng = np.random.default_rng(2)
    for _ in range(100):
        x = rng.uniform(-2, 2, 3)
        np.testing.assert_allclose(
            np.asarray(Gi(x), float), np.linalg.inv(np.asarray(G(x), float)), rtol=1e-12, atol=1e-12
        )
