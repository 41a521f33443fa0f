"""Internal-consistency checks of the independent NumPy oracle (tests/oracle_numpy.py).

These tests do not import fsmctl: they check the oracle against textbook facts (Schaub & Junkins
closed-form MRP formulas, DCM kinematics, rigid-body momentum conservation), against finite
differences, and against itself along two independent routes (Lagrange model vs dynamic inversion).
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from scipy.linalg import expm


def _load_oracle():
    name = "oracle_numpy"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, Path(__file__).with_name("oracle_numpy.py"))
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


o = _load_oracle()

SETTINGS = settings(derandomize=True, deadline=None, max_examples=60, database=None)
SETTINGS_FEW = settings(derandomize=True, deadline=None, max_examples=15, database=None)


def vec3(lo: float, hi: float):
    f = st.floats(lo, hi, allow_nan=False, allow_infinity=False)
    return st.tuples(f, f, f).map(lambda t: np.array(t, dtype=np.float64))


def inertia():
    moments = st.tuples(*(st.floats(50.0, 300.0),) * 3)
    return st.tuples(moments, vec3(-0.8, 0.8)).map(
        lambda mr: o.mrp_to_dcm(mr[1]) @ np.diag(mr[0]) @ o.mrp_to_dcm(mr[1]).T
    )


def schaub_closed_form_dcm(s: np.ndarray) -> np.ndarray:
    x = o.skew(s)
    n2 = s @ s
    return np.eye(3) + (8.0 * x @ x - 4.0 * (1.0 - n2) * x) / (1.0 + n2) ** 2


def schaub_mrp_subtraction(s: np.ndarray, sd: np.ndarray) -> np.ndarray:
    """Schaub & Junkins relative MRP sigma_{B/D} (no shadow switching)."""
    num = (1.0 - sd @ sd) * s - (1.0 - s @ s) * sd + 2.0 * np.cross(s, sd)
    den = 1.0 + (sd @ sd) * (s @ s) + 2.0 * (sd @ s)
    return num / den


# ----------------------------------------------------------------------------------------------
# Algebra, DCM, MRP
# ----------------------------------------------------------------------------------------------
@SETTINGS
@given(vec3(-5, 5), vec3(-5, 5))
def test_skew_is_cross_product(v, w):
    S = o.skew(v)
    np.testing.assert_allclose(S @ w, np.cross(v, w), atol=1e-12)
    np.testing.assert_array_equal(S, -S.T)


@SETTINGS
@given(vec3(-3, 3))
def test_dcm_orthonormal_det1_and_matches_schaub_closed_form(s):
    C = o.mrp_to_dcm(s)
    np.testing.assert_allclose(C @ C.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(C) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(C, schaub_closed_form_dcm(s), atol=1e-12)


def test_dcm_maps_n_components_to_b_components():
    # rotation of +90 deg about z: sigma = tan(pi/8) e3; inertial x axis is body -y
    C = o.mrp_to_dcm(np.array([0.0, 0.0, np.tan(np.pi / 8)]))
    np.testing.assert_allclose(C @ np.array([1.0, 0.0, 0.0]), [0.0, -1.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(C @ np.array([0.0, 1.0, 0.0]), [1.0, 0.0, 0.0], atol=1e-15)


@SETTINGS
@given(vec3(-4, 4))
def test_dcm_to_mrp_roundtrip_is_shadow_consistent(s):
    assume(abs(np.linalg.norm(s) - 1.0) > 1e-6)
    back = o.dcm_to_mrp(o.mrp_to_dcm(s))
    assert np.linalg.norm(back) <= 1.0 + 1e-12
    np.testing.assert_allclose(back, o.mrp_shadow(s), atol=1e-10)
    # shadow set describes the same attitude
    np.testing.assert_allclose(o.mrp_to_dcm(o.mrp_shadow(s)), o.mrp_to_dcm(s), atol=1e-12)


@SETTINGS
@given(vec3(-1.5, 1.5), vec3(-1.5, 1.5))
def test_mrp_error_convention(s, sd):
    se = o.mrp_error(s, sd)
    assert np.linalg.norm(se) <= 1.0 + 1e-12
    np.testing.assert_allclose(o.mrp_to_dcm(se), o.mrp_to_dcm(s) @ o.mrp_to_dcm(sd).T, atol=1e-12)
    ref = schaub_mrp_subtraction(s, sd)
    assume(np.all(np.isfinite(ref)) and abs(np.linalg.norm(ref) - 1.0) > 1e-6 and np.linalg.norm(ref) < 1e6)
    np.testing.assert_allclose(se, o.mrp_shadow(ref), atol=1e-9)


@SETTINGS
@given(vec3(-0.577, 0.577))
def test_principal_angle_equals_4_atan_norm(s):
    assume(np.linalg.norm(s) <= 1.0)
    assert o.principal_angle(s) == pytest.approx(4.0 * np.arctan(np.linalg.norm(s)), abs=1e-7)


@SETTINGS
@given(vec3(-3, 3))
def test_principal_angle_in_range_and_shadow_invariant(s):
    th = o.principal_angle(s)
    assert 0.0 <= th <= np.pi
    assert th == pytest.approx(o.principal_angle(o.mrp_shadow(s)), abs=1e-7)


# ----------------------------------------------------------------------------------------------
# G(sigma), kinematics, plant
# ----------------------------------------------------------------------------------------------
@SETTINGS
@given(vec3(-2, 2), vec3(-1, 1))
def test_G_textbook_properties_and_G_dot(s, sd):
    G = o.mrp_G(s)
    n2 = s @ s
    np.testing.assert_allclose(G @ G.T, ((1.0 + n2) / 4.0) ** 2 * np.eye(3), atol=1e-12)
    np.testing.assert_allclose(o.mrp_G_inv(s) @ G, np.eye(3), atol=1e-10)
    h = 1e-6
    fd = (o.mrp_G(s + h * sd) - o.mrp_G(s - h * sd)) / (2 * h)
    np.testing.assert_allclose(o.mrp_G_dot(s, sd), fd, atol=1e-8)


@SETTINGS
@given(vec3(-0.5, 0.5), vec3(-1, 1))
def test_mrp_kinematics_consistent_with_dcm_kinematics(s, w):
    # C(t) = expm(-w^x t) C0 solves C_dot = -w^x C for a constant body rate w
    C0 = o.mrp_to_dcm(s)
    h = 1e-5
    sp = o.dcm_to_mrp(expm(-o.skew(w) * h) @ C0)
    sm = o.dcm_to_mrp(expm(o.skew(w) * h) @ C0)
    np.testing.assert_allclose((sp - sm) / (2 * h), o.mrp_G(s) @ w, atol=1e-8)
    # and the other way: DCM along sigma_dot = G w has derivative -w^x C
    sdot = o.mrp_G(s) @ w
    dC = (o.mrp_to_dcm(s + h * sdot) - o.mrp_to_dcm(s - h * sdot)) / (2 * h)
    np.testing.assert_allclose(dC, -o.skew(w) @ C0, atol=1e-8)


@SETTINGS
@given(inertia(), vec3(-0.8, 0.8), vec3(-1, 1), vec3(-2, 2))
def test_plant_rhs_euler_and_inertial_momentum(J, s, w, tau):
    sd, wd = o.plant_rhs(s, w, tau, J)
    np.testing.assert_allclose(sd, o.mrp_G(s) @ w, atol=1e-14)
    np.testing.assert_allclose(J @ wd + np.cross(w, J @ w), tau, atol=1e-9)
    # torque-free: inertial angular momentum H_N = C^T J w is constant
    sd0, wd0 = o.plant_rhs(s, w, np.zeros(3), J)
    h = 1e-6

    def H(k):
        return o.mrp_to_dcm(s + k * h * sd0).T @ J @ (w + k * h * wd0)

    np.testing.assert_allclose((H(1) - H(-1)) / (2 * h), 0.0, atol=1e-6 * np.abs(J).max())


@SETTINGS
@given(vec3(-0.5, 0.5), vec3(-0.5, 0.5), vec3(-1, 1), vec3(-0.5, 0.5))
def test_error_rate_models_against_true_relative_kinematics(s, sdes, w, wd):
    """exact: sigma_e_dot = G(sigma_e)(w - R w_d) along the true motion; paper: only if R w_d = w_d."""
    se0 = o.mrp_error(s, sdes)
    assume(np.linalg.norm(se0) < 0.95)
    h = 1e-5

    def se(k):
        C = expm(-o.skew(w) * k * h) @ o.mrp_to_dcm(s)
        Cd = expm(-o.skew(wd) * k * h) @ o.mrp_to_dcm(sdes)
        return o.dcm_to_mrp(C @ Cd.T)

    fd = (se(1) - se(-1)) / (2 * h)
    sig_e, w_e, w_r = o.error_rates(s, w, sdes, wd, "exact")
    np.testing.assert_allclose(sig_e, se0)
    np.testing.assert_allclose(w_r, o.mrp_to_dcm(se0) @ wd, atol=1e-14)
    np.testing.assert_allclose(fd, o.mrp_G(sig_e) @ w_e, atol=1e-7)
    _, w_e_p, w_r_p = o.error_rates(s, w, sdes, wd, "paper")
    np.testing.assert_allclose(w_r_p, wd)
    gap = o.mrp_G(sig_e) @ (w_e - w_e_p)  # = G (w_d - R w_d): what eqs 7-8 miss
    np.testing.assert_allclose(fd - o.mrp_G(sig_e) @ w_e_p, gap, atol=1e-7)


def test_paper_error_model_is_wrong_for_generic_state():
    s, sdes = np.array([0.3, 0.2, -0.3]), np.array([-0.3, -0.4, 0.4])
    w, wd = np.array([0.35, -0.13, 0.27]), np.array([0.1, 0.0, -0.1])
    _, we_p, _ = o.error_rates(s, w, sdes, wd, "paper")
    _, we_x, _ = o.error_rates(s, w, sdes, wd, "exact")
    assert np.linalg.norm(we_p - we_x) > 0.05


# ----------------------------------------------------------------------------------------------
# Lagrange-like model (9)
# ----------------------------------------------------------------------------------------------
def _lagrange_residuals(J, se0, sed, sedd, wd0, wdd):
    """Return (lhs_euler - rhs, lhs_printed - rhs, missing-term prediction, scale) at t = 0.

    The motion is sigma_e(t) = se0 + sed t + sedd t^2/2, omega_d(t) = wd0 + wdd t (paper error model),
    omega(t) = G(sigma_e)^-1 sigma_e_dot + omega_d; omega_dot is taken by central differences, so it does
    not use the oracle's analytic G_dot.
    """

    def omega(t):
        s_ = se0 + sed * t + 0.5 * sedd * t * t
        sd_ = sed + sedd * t
        return np.linalg.solve(o.mrp_G(s_), sd_) + wd0 + wdd * t

    h = 1e-4
    w = omega(0.0)
    wdot = (omega(h) - omega(-h)) / (2 * h)
    GiT = o.mrp_G_inv(se0).T
    rhs = GiT @ (J @ wdot + np.cross(w, J @ w))
    out = []
    for variant in ("euler", "printed"):
        M, C, E = o.lagrange_M_C_E(J, se0, sed, wd0, wdd, variant)
        out.append(M @ sedd + C @ sed + GiT @ E - rhs)
    w_e = o.mrp_G_inv(se0) @ sed
    predicted = GiT @ np.cross(J @ wd0, w_e)
    scale = np.linalg.norm(GiT) * np.linalg.norm(J) * (1.0 + np.linalg.norm(wdot) + np.linalg.norm(w) ** 2)
    return out[0], out[1], predicted, scale


@SETTINGS
@given(inertia(), vec3(-0.6, 0.6), vec3(-0.3, 0.3), vec3(-0.3, 0.3), vec3(-0.5, 0.5), vec3(-0.1, 0.1))
def test_euler_C_reproduces_euler_equation(J, se0, sed, sedd, wd0, wdd):
    r_euler, r_printed, predicted, scale = _lagrange_residuals(J, se0, sed, sedd, wd0, wdd)
    assert np.linalg.norm(r_euler) <= 1e-7 * scale
    # the printed C is off by exactly the missing cross-coupling term G^-T ((J w_d) x w_e)
    assert np.linalg.norm(r_printed - predicted) <= 1e-7 * scale


def test_printed_C_does_not_reproduce_euler_equation():
    """Finding: the C printed under eq 9 is wrong whenever omega_d x-couples with omega_e."""
    J = o.paper_scenario()["J0"][0]
    se0 = np.array([0.2, -0.3, 0.1])
    sed = np.array([0.05, 0.02, -0.04])
    sedd = np.array([0.01, -0.02, 0.03])
    wd0 = np.array([0.1, -0.05, -0.1])
    wdd = np.array([0.001, 0.0, -0.002])
    r_euler, r_printed, predicted, scale = _lagrange_residuals(J, se0, sed, sedd, wd0, wdd)
    assert np.linalg.norm(r_euler) <= 1e-7 * scale
    assert np.linalg.norm(r_printed) > 1e3 * np.linalg.norm(r_euler) + 1e-3
    np.testing.assert_allclose(r_printed, predicted, atol=1e-7 * scale)
    # and with omega_d = 0 the two variants coincide
    r_e0, r_p0, _, _ = _lagrange_residuals(J, se0, sed, sedd, np.zeros(3), wdd)
    np.testing.assert_allclose(r_e0, r_p0, atol=1e-12)


# ----------------------------------------------------------------------------------------------
# Control law (16)-(20)
# ----------------------------------------------------------------------------------------------
GAINS = {"c1": 0.6, "c2": 0.8, "alpha": 0.7}


@SETTINGS
@given(
    inertia(),
    vec3(-0.6, 0.6),
    vec3(-0.5, 0.5),
    vec3(-0.6, 0.6),
    vec3(-0.2, 0.2),
    vec3(-0.01, 0.01),
    vec3(0.01, 0.5),
    vec3(-1, 1),
)
def test_eqs_16_19_euler_equals_dynamic_inversion_paper(J0, s, w, sdes, wd, wdd, delta, coord):
    se, _, _ = o.error_rates(s, w, sdes, wd, "paper")
    assume(np.all(np.abs(se) > 1e-3))
    args = (J0, s, w, sdes, wd, wdd, GAINS["c1"], GAINS["c2"], GAINS["alpha"], delta, coord)
    law = o.control_law_eqs_16_19(*args, variant="euler")
    u_inv = o.control_by_dynamic_inversion(*args, error_model="paper")
    scale = 1.0 + np.linalg.norm(J0) * (1.0 + np.abs(se).min() ** (GAINS["alpha"] - 1.0))
    np.testing.assert_allclose(law["u"], u_inv, atol=1e-9 * scale)
    np.testing.assert_allclose(law["u"], -law["uF"] - law["uD"] - law["uC"], atol=1e-12 * scale)
    # printed C changes u by exactly (J0 w_d) x w_e
    law_p = o.control_law_eqs_16_19(*args, variant="printed")
    np.testing.assert_allclose(law_p["u"] - law["u"], np.cross(J0 @ wd, w - wd), atol=1e-9 * scale)
    # plugging u into the (euler) Lagrange model gives the closed loop (20)
    G = o.mrp_G(se)
    sed = G @ (w - wd)
    M, C, E = o.lagrange_M_C_E(J0, se, sed, wd, wdd, "euler")
    GiT = o.mrp_G_inv(se).T
    sedd = np.linalg.solve(M, GiT @ law["u"] - C @ sed - GiT @ E)
    target = o.closed_loop_eq20(se, sed, GAINS["c1"], GAINS["c2"], GAINS["alpha"], delta, coord)
    np.testing.assert_allclose(sedd, target, atol=1e-7 * (1.0 + np.linalg.norm(target)))


def _true_sigma_e_ddot(J, s, w, sdes, wd0, wdd, u, h=2e-3):
    """sigma_e_ddot(0) on the true rigid body with u held constant; omega_d in desired-frame components."""

    def rhs(t, y):
        sd_, wd_ = o.plant_rhs(y[0:3], y[3:6], u, J)
        return np.concatenate([sd_, wd_, o.mrp_G(y[6:9]) @ (wd0 + wdd * t)])

    y0 = np.concatenate([s, w, sdes])

    def se_at(t):
        if t == 0.0:
            y = y0
        else:
            y = solve_ivp(rhs, (0.0, t), y0, method="DOP853", rtol=1e-13, atol=1e-14).y[:, -1]
        return o.mrp_error(y[0:3], y[6:9])

    return (se_at(h) - 2.0 * se_at(0.0) + se_at(-h)) / h**2


@SETTINGS_FEW
@given(inertia(), vec3(-0.4, 0.4), vec3(-0.3, 0.3), vec3(-0.4, 0.4), vec3(-0.2, 0.2), vec3(-0.01, 0.01))
def test_exact_dynamic_inversion_realises_eq20_on_true_plant(J, s, w, sdes, wd, wdd):
    se, _, _ = o.error_rates(s, w, sdes, wd, "exact")
    assume(np.linalg.norm(se) < 0.9 and np.all(np.abs(se) > 0.05))
    delta, coord = np.array([0.1, 0.2, 0.15]), np.array([0.05, -0.02, 0.03])
    u = o.control_by_dynamic_inversion(
        J, s, w, sdes, wd, wdd, GAINS["c1"], GAINS["c2"], GAINS["alpha"], delta, coord, error_model="exact"
    )
    sig_e, w_e, _ = o.error_rates(s, w, sdes, wd, "exact")
    target = o.closed_loop_eq20(sig_e, o.mrp_G(sig_e) @ w_e, GAINS["c1"], GAINS["c2"], GAINS["alpha"], delta, coord)
    got = _true_sigma_e_ddot(J, s, w, sdes, wd, wdd, u)
    np.testing.assert_allclose(got, target, atol=2e-5 * (1.0 + np.linalg.norm(target)))


def test_paper_dynamic_inversion_misses_eq20_on_true_plant():
    sc = o.paper_scenario()
    J = sc["J0"][0]
    s, w, sdes = sc["sigma0"][0], sc["omega0"][0], sc["sigma_d0"]
    wd, wdd = sc["omega_d"](0.0), sc["omega_d_dot"](0.0)
    delta, coord = np.array([0.1, 0.1, 0.1]), np.zeros(3)
    args = (J, s, w, sdes, wd, wdd, GAINS["c1"], GAINS["c2"], GAINS["alpha"], delta, coord)
    sig_e, w_e, _ = o.error_rates(s, w, sdes, wd, "exact")
    target = o.closed_loop_eq20(sig_e, o.mrp_G(sig_e) @ w_e, GAINS["c1"], GAINS["c2"], GAINS["alpha"], delta, coord)
    got_exact = _true_sigma_e_ddot(J, s, w, sdes, wd, wdd, o.control_by_dynamic_inversion(*args, error_model="exact"))
    got_paper = _true_sigma_e_ddot(J, s, w, sdes, wd, wdd, o.control_by_dynamic_inversion(*args, error_model="paper"))
    np.testing.assert_allclose(got_exact, target, atol=1e-4)
    assert np.linalg.norm(got_paper - target) > 1e-2


@SETTINGS
@given(vec3(-2, 2), st.floats(0.5, 1.0, exclude_min=True, exclude_max=True))
def test_sigpow_and_sliding_variable(x, a):
    np.testing.assert_allclose(o.sigpow(x, a), np.sign(x) * np.abs(x) ** a)
    np.testing.assert_allclose(o.sigpow(-x, a), -o.sigpow(x, a))
    s = o.sliding_variable(x, 0.5 * x, 0.6, 0.8, a)
    np.testing.assert_allclose(s, 0.5 * x + 0.6 * x + 0.8 * o.sigpow(x, a))


# ----------------------------------------------------------------------------------------------
# Theorem 3 settling times, metrics
# ----------------------------------------------------------------------------------------------
@SETTINGS
@given(
    st.floats(0.05, 5.0),
    st.floats(0.05, 5.0),
    st.floats(0.51, 0.99),
    st.floats(1e-3, 1.0),
    st.floats(1.01, 100.0),
)
def test_settling_times_satisfy_their_odes_and_theorem3(c1, c2, alpha, tau, ratio):
    x0 = tau * ratio
    args = (c1, c2, alpha)
    assert o.settling_time_fsm(*args, tau, tau) == pytest.approx(0.0, abs=1e-12)
    assert o.settling_time_tsm(*args, tau, tau) == pytest.approx(0.0, abs=1e-12)
    assert o.settling_time_lsm(*args, tau, tau) == pytest.approx(0.0, abs=1e-12)
    # dT/dx0 = 1/|xdot(x0)| for each scalar sliding mode
    h = 1e-6 * x0
    for fn, speed in (
        (o.settling_time_fsm, c1 * x0 + c2 * x0**alpha),
        (o.settling_time_tsm, c2 * x0**alpha),
        (o.settling_time_lsm, c1 * x0),
    ):
        d = (fn(*args, x0 + h, tau) - fn(*args, x0 - h, tau)) / (2 * h)
        assert d == pytest.approx(1.0 / speed, rel=1e-5)
    # sign of x0 is irrelevant
    assert o.settling_time_fsm(*args, -x0, tau) == pytest.approx(o.settling_time_fsm(*args, x0, tau))
    # Theorem 3
    tf = o.settling_time_fsm(*args, x0, tau)
    assert tf < o.settling_time_tsm(*args, x0, tau)
    assert tf < o.settling_time_lsm(*args, x0, tau)


def test_fsm_settling_time_by_integration():
    c1, c2, alpha, x0, tau = 0.6, 0.8, 0.7, 2.0, 0.01

    def ev(t, x):
        return abs(x[0]) - tau

    ev.terminal = True
    sol = solve_ivp(lambda t, x: -c1 * x - c2 * o.sigpow(x, alpha), (0, 100), [x0], events=ev, rtol=1e-11, atol=1e-13)
    assert sol.t_events[0][0] == pytest.approx(o.settling_time_fsm(c1, c2, alpha, x0, tau), rel=1e-7)


def test_metrics_hand_values():
    assert o.aaem_deg(np.full(6, np.pi / 2)) == pytest.approx(90.0)
    assert o.aaem_deg([np.pi, 0, 0, 0, 0, 0]) == pytest.approx(180.0 / np.sqrt(6))
    th = np.full((6, 6), np.pi / 4)
    np.fill_diagonal(th, 123.0)  # ignored
    assert o.raem_deg(th) == pytest.approx(45.0)
    th = np.zeros((6, 6))
    th[0, 1] = th[1, 0] = np.pi
    assert o.raem_deg(th) == pytest.approx(180.0 * np.sqrt(2.0 / 30.0))
    sig = [np.zeros(3), np.array([0.0, 0.0, np.tan(np.pi / 8)])]
    rel = o.relative_angle_matrix(sig)
    np.testing.assert_allclose(rel, [[0.0, np.pi / 2], [np.pi / 2, 0.0]], atol=1e-7)


# ----------------------------------------------------------------------------------------------
# Section 4 scenario
# ----------------------------------------------------------------------------------------------
def test_table2_schedule_hand_checked():
    k = o.paper_scenario()["k_j"]
    assert k(1, 2, 0.0) == 5.0  # phase 0, mod = 0
    assert k(1, 2, 6.5) == 5.0  # boundary: mod(t, 8) <= 6.5 is on
    assert k(1, 2, 6.75) == 0.0
    assert k(1, 2, 8.0) == 5.0
    assert k(1, 2, 15.0) == 0.0  # mod = 7
    assert k(2, 1, 5.0) == 5.0  # 5 + 1.5 = 6.5
    assert k(2, 1, 5.25) == 0.0  # 6.75
    assert k(4, 2, 1.0) == 0.0  # 1 + 6 = 7
    assert k(4, 2, 2.5) == 5.0  # 8.5 -> 0.5
    assert k(1, 3, 6.0) == 0.0  # 7.0
    assert k(3, 1, 6.0) == 0.0  # 6.9
    assert k(3, 1, 5.5) == 5.0  # 6.4
    assert k(6, 5, 2.0) == 0.0  # 7.3
    assert k(5, 6, 0.25) == 5.0  # 6.45
    assert k(5, 6, 0.5) == 0.0  # 6.7
    assert k(3, 3, 0.0) == 0.0  # no self link
    ph = o.paper_scenario()["phases"]
    assert ph[1, 2] == 0.5 and ph[4, 2] == 0.9 and ph[5, 2] == 4.8  # rejoined entries 2-3, 5-3, 6-3
    # duty cycle: on for 6.5 of every 8 s
    ts = np.arange(0.0, 800.0, 0.01) + 0.005
    assert np.mean([k(1, 2, t) > 0 for t in ts]) == pytest.approx(6.5 / 8.0, abs=1e-3)


def test_paper_scenario_data():
    sc = o.paper_scenario()
    assert len(sc["J0"]) == 6 and len(sc["sigma0"]) == 6 and len(sc["omega0"]) == 6
    for J, dJ in zip(sc["J0"], sc["delta_J"], strict=True):
        np.testing.assert_array_equal(J, J.T)
        assert np.all(np.linalg.eigvalsh(J) > 0)
        np.testing.assert_allclose(dJ, 0.3 * J)
    np.testing.assert_array_equal(sc["J0"][2], [[80, 0.5, 2], [0.5, 180, 0], [2, 0, 180]])
    np.testing.assert_array_equal(sc["sigma0"][3], [0.4, 0.4, -0.2])
    np.testing.assert_array_equal(sc["omega0"][5], [-0.36, 0.17, 0.41])
    np.testing.assert_array_equal(sc["sigma_d0"], [-0.3, -0.4, 0.4])
    assert (sc["c1"], sc["c2"], sc["k_i"], sc["torque_limit"]) == (0.6, 0.8, 8.0, 2.0)
    np.testing.assert_allclose(sc["omega_d"](0.0), [0.1, 0.0, -0.1])
    t = 7.3
    np.testing.assert_allclose(sc["omega_d"](t), [0.1 * np.cos(t / 40), -0.1 * np.sin(t / 50), -0.1 * np.cos(t / 60)])
    h = 1e-6
    np.testing.assert_allclose(
        sc["omega_d_dot"](t), (sc["omega_d"](t + h) - sc["omega_d"](t - h)) / (2 * h), atol=1e-10
    )
    np.testing.assert_allclose(sc["disturbance"](1, 0.0), [0.2 * np.cos(1), -0.24 * np.sin(1), 0.22 * np.cos(1)])
    np.testing.assert_allclose(sc["disturbance"](4, 10.0), [0.2 * np.cos(5.0), -0.24 * np.sin(5.5), 0.22 * np.cos(5.2)])
    # Theorem 1 condition holds for the Case 1 / Case 3 weights with eta = k_i / 2
    for ki, kj in sc["case3_weights"]:
        eta = ki / 2
        assert ki > eta and 4 * eta * (ki - eta) >= kj**2


def test_table2_exact_weights():
    """``k_j_exact`` is Table 2's rule in exact arithmetic: the float ``k_j`` away from the switches, the paper's
    ``<=`` at an exact instant, and the side of the switch the double really lies on next to one."""
    sc = o.paper_scenario()
    for t in np.arange(0.0, 16.0, 0.05) + 0.0123:  # 0.0123 s away from every switch (phases are multiples of 0.1)
        for i in range(1, 7):
            for j in range(1, 7):
                assert o.k_j_exact(i, j, t) == sc["k_j"](i, j, t)
    assert o.k_j_exact(1, 2, 6.5) == 5.0 and o.k_j_exact(1, 2, 8.0) == 5.0  # phi_12 = 0: mod 6.5 and 0 are on
    assert o.k_j_exact(2, 1, 5.0) == 5.0  # phi_21 = 1.5: exactly 6.5
    assert o.k_j_exact(1, 4, 3.7) == 0.0  # phi_14 = 2.8: the double 3.7 is 1.8e-16 above 3.7, so mod > 6.5
    assert sc["k_j"](1, 4, 3.7) == 5.0  # (the float rule rounds 3.7 + 2.8 to 6.5 and says on)
    assert o.k_j_exact(3, 3, 1.0) == 0.0 and o.k_j_exact(1, 2, 1.0, on=0.6) == 0.6
