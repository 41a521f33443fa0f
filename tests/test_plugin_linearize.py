"""Exact linearization of the python-control plug-in (issue 24): Jacobians by CasADi's automatic derivatives, a
plain error at non-differentiable operating points, and the MRP-state linearization for control design.

Oracles: the analytic rigid-body linearization, central finite differences at smooth points (to their accuracy),
the LQR design's own poles.
"""

from __future__ import annotations

import control as ct
import numpy as np
import pytest

import fsmctl
from fsmctl.plugin import (
    NonDifferentiableError,
    ParameterKeyError,
    linearize,
    mrp_estimator,
    mrp_linearization,
    quaternion_from_mrp,
    reaction_wheel_spacecraft,
    reaction_wheel_state,
)

J = np.array([[100.0, 1.0, 2.0], [1.0, 150.0, 1.0], [2.0, 1.0, 200.0]])


def _cross(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _central(f, x, h):
    """Central differences of ``f`` at ``x`` (error O(h^2))."""
    cols = []
    for i in range(x.size):
        dx = np.zeros(x.size)
        dx[i] = h
        cols.append((f(x + dx) - f(x - dx)) / (2 * h))
    return np.array(cols).T


def _controller(boundary_layer, name="ctrl1", neighbours=()):
    # no torque limit: the points below are inside the unsaturated region, where the law's slopes show
    paper = fsmctl.paper_scenario("1").replace(
        controller={"boundary_layer": boundary_layer, "torque_limit": float("inf")}
    )
    return fsmctl.fsm_controller(
        paper.agents[0].J0_array, paper.controller, [0.005] * 3, name=name, neighbours=neighbours
    )


# a point inside the boundary layer (0.05), unsaturated, sigma_e away from 0 on every axis
U_SMOOTH = np.r_[[0.01, -0.02, 0.015], [-0.003, 0.002, -0.001], [0.012, -0.018, 0.02], [0.0, 0.0, 0.001], [0.0] * 3]


def test_spacecraft_is_the_analytic_rigid_body():
    sc = fsmctl.spacecraft(J, name="sc")
    omega = np.array([0.02, -0.01, 0.03])
    x0 = np.concatenate([[1.0, 0.0, 0.0, 0.0], omega])
    lin = ct.linearize(sc, x0, [0.1, -0.2, 0.3])
    Ji = np.linalg.inv(J)
    expected = Ji @ (-_cross(omega) @ J + _cross(J @ omega))  # d/d omega of J^-1 (-omega x J omega + tau)
    assert np.allclose(lin.A[4:, 4:], expected, rtol=1e-12, atol=1e-15)
    assert np.allclose(lin.B[4:], Ji, rtol=1e-12, atol=1e-17)
    assert np.allclose(lin.A[:4, 4:], 0.5 * np.vstack([np.zeros(3), np.eye(3)]), rtol=0, atol=1e-15)
    assert np.allclose(lin.C[:3, 1:4], 0.5 * np.eye(3), rtol=0, atol=1e-15)  # d sigma / d q_v at the identity


def test_linearize_keeps_python_control_conventions():
    sc = fsmctl.spacecraft(J, name="sc")
    x0 = np.concatenate([quaternion_from_mrp([0.1, 0.0, 0.0]), [0.0, 0.0, 0.0]])
    lin = sc.linearize(x0, [0, 0, 0], copy_names=True, params={"sc_J": np.eye(3)})
    assert isinstance(lin, ct.StateSpace)
    assert lin.name == "sc$linearized" and lin.state_labels == sc.state_labels
    assert lin.input_labels == sc.input_labels and lin.output_labels == sc.output_labels
    assert np.allclose(lin.B[4:], np.eye(3), rtol=1e-13, atol=1e-15)  # params= honoured
    x1 = np.concatenate([x0[:4], [0.02, -0.01, 0.03]])
    assert np.array_equal(sc.linearize(x1, eps=1e-3).A, sc.linearize(x1, eps=1e-8).A)  # eps is not a step
    local = sc.linearize(x0, [0, 0, 0], params={"J": np.eye(3)})  # the local name, as python-control's examples
    assert np.allclose(local.B[4:], np.eye(3), rtol=1e-13, atol=1e-15)
    with pytest.raises(ParameterKeyError, match="unknown parameter 'Jx'"):
        sc.linearize(x0, [0, 0, 0], params={"Jx": np.eye(3)})


@pytest.mark.parametrize("system", ["spacecraft", "formation"])
def test_operating_points_are_read_as_python_control_reads_them(system):
    """x0 and u0 as python-control's own linearize reads them, for a generated-Jacobian system and a formation:
    nested lists flattened, a scalar filling the vector, a short vector padded with zeros (a warning when its last
    value is not 0), a long one refused with python-control's ValueError naming the argument and both sizes."""
    if system == "spacecraft":
        sys = fsmctl.spacecraft(J, name="sc")
    else:
        sys = fsmctl.formation(fsmctl.paper_scenario("1").replace(controller={"boundary_layer": 0.05}))
    x0 = np.asarray(fsmctl.initial_state(fsmctl.paper_scenario("1")) if system == "formation" else [1.0, *[0.0] * 6])
    u0 = np.zeros(sys.ninputs)
    reference = sys.linearize(x0, u0)
    nested = sys.linearize([x0[:4].tolist(), x0[4:]], [u0[: sys.ninputs // 2], u0[sys.ninputs // 2 :]])
    assert np.array_equal(nested.A, reference.A) and np.array_equal(nested.B, reference.B)
    assert np.array_equal(sys.linearize(x0, 0).A, reference.A)  # a scalar u0 fills the inputs
    if sys.ninputs:
        with pytest.warns(UserWarning, match="u0 too short; padding with zeros"):
            sys.linearize(x0, [1.0])
    with pytest.raises(ValueError, match=rf"size of x0; expected {sys.nstates} values, received {sys.nstates + 1}"):
        sys.linearize(np.r_[x0, 1.0], u0)
    with pytest.raises(ValueError, match=rf"size of u0; expected {sys.ninputs} values, received {sys.ninputs + 2}"):
        sys.linearize(x0, np.zeros(sys.ninputs + 2))


def test_a_sliding_mode_law_linearizes_independently_of_the_step():
    ctrl = _controller(0.05)
    rough, fine = (ctrl.linearize([], U_SMOOTH, eps=eps) for eps in (1e-4, 1e-8))
    assert np.array_equal(rough.D, fine.D)
    fd = _central(lambda u: ctrl.output(0.0, [], u), U_SMOOTH, 1e-7)
    assert np.allclose(fine.D, fd, rtol=1e-6, atol=1e-6 * np.abs(fd).max())


def test_the_law_linearizes_at_its_equilibrium_on_a_nonzero_reference():
    """sigma = sigma_d != 0, omega = omega_d: sigma_e is zero up to rounding (1e-17), and the |sigma_e| corner of the
    near-zero form multiplies a factor that is zero there too: the law is smooth, its Jacobian the central
    differences' (a fresh user's case: the paper's formation linearized about its own reference)."""
    ctrl = _controller(0.05)
    sigma_d, omega_d = np.array([-0.3, -0.4, 0.4]), np.array([0.01, 0.0, -0.01])
    for omega in (np.zeros(3), omega_d):
        u0 = np.r_[sigma_d, omega, sigma_d, omega, [0.0] * 3]
        D = ctrl.linearize([], u0).D
        # the near-zero form has sigma_e |sigma_e|-like terms: central differences converge to the slope only at
        # O(h) (about 2e4 h here), so two steps show the convergence to D rather than a tolerance hiding it
        coarse, fine = (_central(lambda u: ctrl.output(0.0, [], u), u0, h) for h in (1e-6, 1e-8))
        scale = np.abs(D).max()
        assert np.abs(fine - D).max() < 0.05 * np.abs(coarse - D).max() + 1e-9 * scale
        assert np.allclose(D, fine, rtol=1e-4, atol=1e-4 * scale)


def test_the_law_at_s_zero_without_boundary_layer_is_not_linearized():
    with pytest.raises(NonDifferentiableError, match=r"ctrl1.*sign\(a\) jumps.*'boundary_layer' > 0"):
        _controller(0.0).linearize([], np.zeros(15))
    assert np.isfinite(_controller(0.05).linearize([], np.zeros(15)).D).all()  # with a layer, s = 0 is smooth


def test_the_edge_of_the_boundary_layer_is_not_linearized():
    ctrl = _controller(0.05)
    u = np.zeros(15)
    u[:3] = [0.01, -0.02, 0.015]  # sigma_e away from 0 (|sigma_e| sigma_e_dot has a corner there)
    slope = ctrl.linearize([], u).D[3, 3]  # s is linear in omega: one Newton step puts s_0 on the edge 0.05
    u[3] -= (ctrl.output(0.0, [], u)[3] - 0.05) / slope
    assert abs(ctrl.output(0.0, [], u)[3] - 0.05) < 1e-12
    with pytest.raises(NonDifferentiableError, match=r"has a corner there"):
        ctrl.linearize([], u)
    u[3] -= 0.01 / slope  # s_0 = 0.04: inside the layer
    assert np.isfinite(ctrl.linearize([], u).D).all()


def test_neighbour_broadcasts_enter_with_the_weights_at_t():
    from fsmctl.model.topology import Schedule

    nb = fsmctl.Neighbour("sc2", 8.0, Schedule((0.0, 1.0), (5.0, 2.0), 2.0), 0.0)
    ctrl = _controller(0.05, neighbours=[nb])
    u = np.r_[U_SMOOTH, [0.001, -0.002, 0.003]]
    for t in (0.5, 1.5):
        lin = ctrl.linearize([], u, t=t)
        fd = _central(lambda v, t=t: ctrl.output(t, [], v), u, 1e-7)
        assert np.allclose(lin.D, fd, rtol=1e-6, atol=1e-6 * np.abs(fd).max())
    assert not np.allclose(ctrl.linearize([], u, t=0.5).D[:, 15:], ctrl.linearize([], u, t=1.5).D[:, 15:])


def test_wheel_plant_is_exact():
    wheels = {"layout": "pyramid", "spin_inertia": 0.05, "max_torque": 0.1, "viscous_friction": 0.001}
    w = np.r_[0.02, -0.01, 0.0, 0.03]  # per-wheel commands u_wheels (one of them pushing a wheel to its limit below)
    for allocation in ("scaled", "clipped"):
        sc = reaction_wheel_spacecraft(J, {**wheels, "allocation": allocation}, name="sc")
        x0 = reaction_wheel_state(sc, [0.1, 0.2, -0.1], [0.01, 0.02, -0.01], Omega0=[10.0, 5.0, -3.0, 2.0])
        for u0 in (
            np.r_[0.01, 0.02, 0.03, 0.1, 0.0, 0.0, 0.0 * w],  # free
            np.r_[0.2, 0.1, 0.05, 0.0, 0.0, 0.0, 0.0 * w],  # a wheel at its limit
            np.r_[0.01, 0.02, 0.03, 0.1, 0.0, 0.0, w],  # with per-wheel commands, free
            np.r_[0.05, 0.02, 0.03, 0.0, 0.0, 0.0, 2.0 * w],  # ... and a wheel at its limit
        ):
            rough, fine = (sc.linearize(x0, u0, eps=eps) for eps in (1e-4, 1e-8))
            assert np.array_equal(rough.A, fine.A) and np.array_equal(rough.B, fine.B)
            fd = _central(lambda u, sc=sc, x0=x0: sc.dynamics(0.0, x0, u), u0, 1e-7)
            assert np.allclose(fine.B, fd, rtol=1e-6, atol=1e-7 * np.abs(fd).max())
            assert np.abs(fine.B[:, 6:]).max() > 0  # the u_wheels columns


def test_formation_composes_the_exact_jacobians():
    s = fsmctl.paper_scenario("1").replace(controller={"boundary_layer": 0.05, "torque_limit": float("inf")})
    loop = fsmctl.formation(s)
    x0 = fsmctl.initial_state(s)
    rough, fine = (loop.linearize(x0, t=0.3, eps=eps) for eps in (1e-4, 1e-8))
    assert np.array_equal(rough.A, fine.A) and np.array_equal(rough.C, fine.C)
    fd = _central(lambda x: loop.dynamics(0.3, x, []), x0, 1e-6)
    assert np.allclose(fine.A, fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max())
    # bare law names in params= reach every controller
    assert not np.allclose(loop.linearize(x0, t=0.3, params={"c1": 1.2}).A, fine.A)


def test_formation_names_the_controller_that_is_not_differentiable():
    s = fsmctl.paper_scenario("1").replace(controller={"boundary_layer": 0.0})
    x0 = np.concatenate([np.tile([1.0, 0, 0, 0], 1)] + [np.r_[1.0, 0, 0, 0, 0, 0, 0]] * s.n_agents)
    loop = fsmctl.formation(s.replace(reference={"omega": fsmctl.Sinusoid()}))
    with pytest.raises(NonDifferentiableError, match=r"controller 'ctrl1'.*sign"):
        loop.linearize(x0)


def test_mrp_linearization_is_the_analytic_six_state_model():
    sc = fsmctl.spacecraft(J, name="sc")
    lin = mrp_linearization(sc)
    assert lin.nstates == 6 and lin.state_labels == [
        "sigma[0]",
        "sigma[1]",
        "sigma[2]",
        "omega[0]",
        "omega[1]",
        "omega[2]",
    ]
    assert lin.input_labels == sc.input_labels
    expected_A = np.block([[np.zeros((3, 3)), 0.25 * np.eye(3)], [np.zeros((3, 6))]])
    assert np.allclose(lin.A, expected_A, rtol=0, atol=1e-15)
    assert np.allclose(lin.B[3:], np.linalg.inv(J), rtol=1e-12, atol=1e-17)
    wheels = reaction_wheel_spacecraft(J, {"layout": "orthogonal", "spin_inertia": 0.05}, name="rw")
    lw = mrp_linearization(wheels)
    assert lw.nstates == 9 and lw.input_labels == ["u_command[0]", "u_command[1]", "u_command[2]"]
    assert np.allclose(lw.A[:3, 3:6], 0.25 * np.eye(3), rtol=0, atol=1e-15)


def _lqr_loop(sc, K):
    return ct.create_statefbk_iosystem(sc, K, estimator=mrp_estimator(sc), state_indices=6)[1]


def test_lqr_on_the_mrp_linearization_closes_with_the_designed_poles():
    sc = fsmctl.spacecraft(J, name="sc")
    Q, R = np.diag([100.0] * 3 + [1000.0] * 3), np.eye(3)
    K, _, designed = ct.lqr(mrp_linearization(sc), Q, R)
    loop = _lqr_loop(sc, K)
    x0 = np.r_[1.0, 0, 0, 0, 0, 0, 0]
    closed = np.linalg.eigvals(linearize(loop, x0, np.zeros(loop.ninputs)).A)
    expected = np.r_[designed, -2.0]  # the quaternion norm's decay, outside the attitude
    assert np.allclose(np.sort_complex(closed), np.sort_complex(expected), rtol=1e-9, atol=1e-12)
    # the nonlinear loop from 20 deg converges at the slowest designed rate
    slow = -np.max(designed.real)
    start = np.r_[quaternion_from_mrp([np.tan(np.radians(20) / 4), 0, 0]), 0, 0, 0]
    T = np.linspace(0.0, 80.0, 801)
    r = ct.input_output_response(loop, T, 0, start, solve_ivp_kwargs={"rtol": 1e-9, "atol": 1e-12})
    norm = np.linalg.norm(r.outputs[:3], axis=0)
    late = norm[300:] / norm[300]
    assert np.all(late <= 2.0 * np.exp(-slow * (T[300:] - T[300])))  # within a factor of the design's envelope
    assert norm[-1] < 0.01 * norm[0]


def test_quaternion_state_lqr_applied_to_sigma_is_not_the_design():
    """The mistake the MRP model avoids: gains on q_v applied to sigma (d sigma = d q_v / 2) halve the attitude gain."""
    sc = fsmctl.spacecraft(J, name="sc")
    x0 = np.r_[1.0, 0, 0, 0, 0, 0, 0]
    lq = ct.linearize(sc, x0, [0, 0, 0])
    reduced = ct.ss(lq.A[1:, 1:], lq.B[1:], np.eye(6), 0)  # q_v, omega (q0 is second order)
    Q, R = np.diag([100.0] * 3 + [1000.0] * 3), np.eye(3)
    Kq, _, designed = ct.lqr(reduced, Q, R)
    closed = np.linalg.eigvals(linearize(_lqr_loop(sc, Kq), x0, np.zeros(9)).A)
    slow_designed, slow_closed = np.max(designed.real), np.max(closed.real)
    assert slow_closed > 0.6 * slow_designed  # markedly slower than designed (about half)
    K, _, mrp_designed = ct.lqr(mrp_linearization(sc), Q, R)
    mrp_closed = np.linalg.eigvals(linearize(_lqr_loop(sc, K), x0, np.zeros(9)).A)
    assert np.isclose(np.max(mrp_closed.real), np.max(mrp_designed.real), rtol=1e-9)


def test_mrp_linearization_refuses_other_systems():
    with pytest.raises(fsmctl.ScenarioError, match=r"expected a plant made by fsmctl\.spacecraft"):
        mrp_linearization(fsmctl.reference_generator(fsmctl.Sinusoid(), name="reference"))
