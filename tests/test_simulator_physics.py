"""Physics and numerics of the compiled whole-loop simulator (``fsmctl.simulate``, ``fsmctl/csrc/formation.c``).

Every oracle here is independent of the generated code: rigid-body conservation laws, a rotation-matrix
integration by SciPy, the paper's formulas for the disturbance d_i(t) (Sec. 4) and Euler's equation (eq 4)
written out in NumPy, SciPy's ``solve_ivp`` on the exported right-hand side, and the Lyapunov function of
Theorem 1 (eqs 21-22).  Liang, Sun & Wang, Acta Astronautica 81 (2012).
"""

from __future__ import annotations

import ctypes
import dataclasses
import itertools
import math
import warnings

import numpy as np
import oracle_numpy as oracle
import pytest
from formations import with_agents
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

import fsmctl
from fsmctl import Sinusoid, Topology
from fsmctl.model.laws import LawError
from fsmctl.model.problem import pack
from fsmctl.simulation.simulator import DiscontinuousControlWarning, SimulationError

ZERO3x3 = ((0.0, 0.0, 0.0),) * 3


# ----------------------------------------------------------------------------- independent helpers


def skew(v: np.ndarray) -> np.ndarray:
    """``v^x`` with ``skew(v) @ w == cross(v, w)`` (eq 6)."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def dcm(sigma: np.ndarray) -> np.ndarray:
    """Direction-cosine matrix [BN] of an MRP (Schaub & Junkins), written here, not taken from generated/."""
    s = np.asarray(sigma, dtype=float)
    s2 = s @ s
    X = skew(s)
    return np.eye(3) + (8.0 * X @ X - 4.0 * (1.0 - s2) * X) / (1.0 + s2) ** 2


def mrp_G(sigma: np.ndarray) -> np.ndarray:
    """``G(sigma) = 1/4 [(1 - sigma'sigma) I + 2 sigma^x + 2 sigma sigma']`` (eq 5)."""
    s = np.asarray(sigma, dtype=float)
    return 0.25 * ((1.0 - s @ s) * np.eye(3) + 2.0 * skew(s) + 2.0 * np.outer(s, s))


def shadow(sigma: np.ndarray) -> np.ndarray:
    s = np.asarray(sigma, dtype=float)
    n2 = s @ s
    return -s / n2 if n2 > 1.0 else s


def paper_disturbance(i: int, t: float) -> np.ndarray:
    """Case 1 disturbance of agent ``i`` (1-based), Sec. 4: [0.2cos(i+0.1t), -0.24sin(i+0.15t), 0.22cos(i+0.12t)] N m."""
    return np.array([0.2 * math.cos(i + 0.1 * t), -0.24 * math.sin(i + 0.15 * t), 0.22 * math.cos(i + 0.12 * t)])


def state_matrix(result) -> np.ndarray:
    """``(T, 3 + 6 n)`` rows ``[sigma_d, (sigma_i, omega_i) ...]`` (the packed state layout)."""
    T, n = result.time.size, result.n_agents
    agents = np.concatenate([result.sigma, result.omega], axis=2).reshape(T, 6 * n)
    return np.concatenate([result.sigma_d, agents], axis=1)


def shadow_states(X: np.ndarray, n: int) -> np.ndarray:
    """Map every MRP block of packed states to the shadow set |sigma| <= 1 (same attitude)."""
    X = np.array(X, dtype=float)
    for row in X:
        for o in [0] + [3 + 6 * i for i in range(n)]:
            row[o : o + 3] = shadow(row[o : o + 3])
    return X


class CompiledRHS:
    """The driver's exported ``fsm_rhs`` (one evaluation of the formation right-hand side)."""

    def __init__(self, scenario):
        from fsmctl.simulation.driver import _CProblem, _driver, _ptr

        self.dll = _driver()
        if self.dll is None:
            pytest.skip("no C compiler: the compiled driver is not available")
        self.p = pack(scenario)
        self.cp = _CProblem(self.p)
        self._ptr = _ptr
        self.calls = 0

    def __call__(self, t: float, x: np.ndarray, with_u: bool = False):
        x = np.ascontiguousarray(x, dtype=float)
        dx = np.zeros_like(x)
        u = np.zeros(3 * self.p.n_agents)
        rc = self.dll.fsm_rhs(ctypes.byref(self.cp.struct), float(t), self._ptr(x), self._ptr(dx), self._ptr(u))
        self.calls += 1
        assert rc == 0, f"fsm_rhs returned {rc}"
        return (dx, u.reshape(-1, 3)) if with_u else dx


@pytest.fixture(scope="module")
def paper():
    return fsmctl.paper_scenario("1")


# ----------------------------------------------------------------------------- the generated code runs in C


def test_default_backend_is_the_compiled_generated_code(paper):
    from fsmctl.simulation.driver import _driver

    dll = _driver()
    if dll is None:
        pytest.skip("no C compiler")
    # the per-agent functions of generated/c and of the flown law's folder are linked into the driver's library
    for name in ("plant_rhs", "law_local_paper", "law_control_exact", "mrp_shadow", "disturbance_torque"):
        assert hasattr(dll, name), name
    r = fsmctl.simulate(paper.replace(simulation={"t_final": 0.1}))
    assert r.backend == "compiled"
    assert r.steps_taken == 100


# ----------------------------------------------------------------------------- torque-free plant


@pytest.fixture(scope="module")
def torque_free(paper):
    """Case 1 agents (J = 1.3 J0, Table 1 initial states), no disturbance, controller disabled, 100 s at 1 ms."""
    agents = [dataclasses.replace(a, disturbance=Sinusoid()) for a in paper.agents]
    s = with_agents(
        paper,
        agents,
        controller={"enabled": False},
        simulation={"t_final": 100.0, "dt": 1e-3, "output_interval": 0.1},
    )
    return s, fsmctl.simulate(s)


def test_disabled_controller_applies_no_torque(torque_free):
    s, r = torque_free
    assert not s.controller.enabled
    assert np.all(r.u == 0.0)
    assert np.abs(r.u_unsaturated).max() > 1.0  # the law is evaluated (and reported), only not applied


def test_summary_of_the_disabled_controller_is_known_exactly(torque_free):
    """No torque is applied (effective limit 0) while the law still commands one: every agent is saturated for the
    whole 100 s, the last saturation is at the last output, and u has no variation (chattering index 0)."""
    s, r = torque_free
    summ = r.summary()
    # summed over 1e5 steps of dt: rounding of at most 1e5 * 2^-53 ~ 1e-11 relative
    assert summ["saturated_time_s"] == pytest.approx([s.simulation.t_final] * s.n_agents, rel=1e-10)
    assert summ["last_saturation_s"] == s.simulation.t_final
    assert summ["chattering_index_N_m_per_s"] == [0.0] * s.n_agents
    assert summ["u_max_abs_N_m"] == 0.0 and summ["u_unsaturated_max_N_m"] > 1.0


def test_torque_free_conserves_inertial_angular_momentum_and_energy(torque_free):
    """H_N = C(sigma)^T J omega and T = 1/2 omega' J omega are constants of the torque-free motion (eq 4, u = 0)."""
    s, r = torque_free
    for i, agent in enumerate(s.agents):
        J = agent.J_true
        H = np.array([dcm(sig).T @ J @ w for sig, w in zip(r.sigma[:, i], r.omega[:, i], strict=True)])
        E = 0.5 * np.einsum("ki,ij,kj->k", r.omega[:, i], J, r.omega[:, i])
        assert np.abs(H - H[0]).max() <= 1e-9 * np.linalg.norm(H[0]), f"agent {i + 1}: H_N drifts"
        assert np.abs(E - E[0]).max() <= 1e-9 * E[0], f"agent {i + 1}: kinetic energy drifts"
        # a real test: the body-frame momentum is NOT constant (the bodies tumble), only the inertial one is
        Hb = np.einsum("ij,kj->ki", J, r.omega[:, i])
        assert np.abs(Hb - Hb[0]).max() > 0.1 * np.linalg.norm(Hb[0])


def test_mrps_stay_in_the_shadow_set_and_do_switch(torque_free):
    _, r = torque_free
    norms = np.linalg.norm(r.sigma, axis=2)
    assert norms.max() <= 1.0 + 1e-12
    assert np.linalg.norm(r.sigma_e, axis=2).max() <= 1.0 + 1e-12
    assert np.linalg.norm(r.sigma_d, axis=1).max() <= 1.0 + 1e-12
    # the attitudes pass through 180 deg many times in 100 s, so switches must have happened
    jumps = np.linalg.norm(np.diff(r.sigma, axis=0), axis=2)
    assert (jumps > 1.0).sum() >= 6


def test_mrp_kinematics_match_an_independent_rotation_matrix_integration(torque_free):
    """sigma_dot = G(sigma) omega (eqs 3, 5) with shadow switching vs C_dot = -omega^x C integrated by SciPy."""
    s, r = torque_free
    for i in (1, 3):  # the two fastest tumblers (most shadow switches)
        J = s.agents[i].J_true
        Jinv = np.linalg.inv(J)
        C0 = dcm(np.array(s.agents[i].sigma0))

        def rhs(t, y, J=J, Jinv=Jinv):
            C, w = y[:9].reshape(3, 3), y[9:]
            return np.concatenate([(-skew(w) @ C).ravel(), Jinv @ (-np.cross(w, J @ w))])

        sol = solve_ivp(
            rhs,
            (0.0, r.time[-1]),
            np.concatenate([C0.ravel(), s.agents[i].omega0]),
            t_eval=r.time,
            method="DOP853",
            rtol=1e-12,
            atol=1e-13,
        )
        assert sol.success
        C_ref = sol.y[:9].T.reshape(-1, 3, 3)
        C_sim = np.array([dcm(sig) for sig in r.sigma[:, i]])
        assert np.abs(C_sim - C_ref).max() < 1e-8, f"agent {i + 1}"
        assert np.abs(r.omega[:, i] - sol.y[9:].T).max() < 1e-8


def _random_inertia(draw) -> np.ndarray:
    m1 = draw(st.floats(50.0, 300.0))
    m2 = draw(st.floats(50.0, 300.0))
    m3 = draw(st.floats(max(50.0, abs(m1 - m2) + 1.0), min(300.0, m1 + m2)))
    q = draw(st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4).filter(lambda v: np.linalg.norm(v) > 0.1))
    R = Rotation.from_quat(q).as_matrix()
    J = R @ np.diag([m1, m2, m3]) @ R.T
    return 0.5 * (J + J.T)


@st.composite
def rigid_bodies(draw):
    J = _random_inertia(draw)
    sigma0 = np.array(draw(st.lists(st.floats(-0.57, 0.57), min_size=3, max_size=3)))
    omega0 = np.array(draw(st.lists(st.floats(-0.6, 0.6), min_size=3, max_size=3)))
    return J, sigma0, omega0


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(body=rigid_bodies())
def test_torque_free_conservation_for_random_bodies(paper, body):
    J, sigma0, omega0 = body
    agent = fsmctl.Agent(
        J0=tuple(map(tuple, J)),
        delta_J=ZERO3x3,
        sigma0=tuple(sigma0),
        omega0=tuple(omega0),
        parameters={"delta": (0.01,) * 3},
    )
    s = with_agents(
        paper,
        [agent],
        topology=Topology(1, ()),
        controller={"enabled": False},
        simulation={"t_final": 20.0, "dt": 1e-3, "output_interval": 0.05},
    )
    r = fsmctl.simulate(s)
    H = np.array([dcm(sig).T @ J @ w for sig, w in zip(r.sigma[:, 0], r.omega[:, 0], strict=True)])
    E = 0.5 * np.einsum("ki,ij,kj->k", r.omega[:, 0], J, r.omega[:, 0])
    scale_H = max(np.linalg.norm(H[0]), 1e-6)
    assert np.abs(H - H[0]).max() <= 1e-9 * scale_H + 1e-15
    assert np.abs(E - E[0]).max() <= 1e-9 * max(E[0], 1e-9)
    assert np.linalg.norm(r.sigma[:, 0], axis=1).max() <= 1.0 + 1e-12


def test_shadow_switching_keeps_the_attitude_and_theta_continuous(paper):
    """A spin at 1 rad/s about a principal axis through 180 deg: sigma jumps to its shadow, the attitude does not."""
    J = np.diag([100.0, 150.0, 200.0])
    agent = fsmctl.Agent(
        J0=tuple(map(tuple, J)),
        delta_J=ZERO3x3,
        sigma0=(0.0, 0.0, 0.0),
        omega0=(0.0, 0.0, 1.0),
        parameters={"delta": (0.01,) * 3},
    )
    s = with_agents(
        paper,
        [agent],
        topology=Topology(1, ()),
        controller={"enabled": False},
        simulation={"t_final": 8.0, "dt": 1e-3, "output_interval": 1e-3},
    )
    r = fsmctl.simulate(s)
    t, sig = r.time, r.sigma[:, 0]
    # exact solution: rotation by t rad about body axis 3; sigma = (0, 0, tan(t/4)) switched to |sigma| <= 1
    expected = np.array([shadow(np.array([0.0, 0.0, math.tan(tk / 4.0)])) for tk in t])
    assert np.abs(sig - expected).max() < 1e-10
    assert np.linalg.norm(sig, axis=1).max() <= 1.0 + 1e-12
    # sigma itself jumps (from ~+1 to ~-1) when the angle passes 180 deg, ...
    step = np.linalg.norm(np.diff(sig, axis=0), axis=1)
    assert step.max() > 1.9
    # ... but the attitude and the principal angle theta = 4 atan|sigma| (eq 2) move by at most omega dt
    angle_step = np.array(
        [np.arccos(np.clip((np.trace(dcm(a) @ dcm(b).T) - 1) / 2, -1, 1)) for a, b in itertools.pairwise(sig)]
    )
    assert angle_step.max() < 1.0e-3 + 1e-9
    theta = 4.0 * np.arctan(np.linalg.norm(sig, axis=1))
    assert np.abs(np.diff(theta)).max() < 1.0e-3 + 1e-9
    assert theta.max() == pytest.approx(math.pi, abs=2e-3)
    # the metric of eq 42 uses the same continuous angle
    theta_e = r.theta_e[:, 0]
    assert np.abs(np.diff(theta_e)).max() < 2.0e-3


# ----------------------------------------------------------------------------- plant, controller, coordination


def test_plant_uses_true_inertia_and_disturbance_controller_uses_nominal(paper):
    """One evaluation of the formation RHS against Euler's equation (eq 4) with J = J0 + dJ (eq 29), d_i(t) of
    Sec. 4, and the controller's torque recomputed from the generated law with J0 (not J)."""
    from fsmctl.model.generated_code import casadi_function
    from fsmctl.model.laws import resolve_law

    rhs = CompiledRHS(paper)
    p = rhs.p
    rng = np.random.default_rng(7)
    x = p.x0 + 0.05 * rng.standard_normal(p.x0.size)
    t = 3.7
    dx, u = rhs(t, x, with_u=True)
    ref = casadi_function("reference_rhs")
    fsm = resolve_law("fsm")  # the paper's law, generated once in generated/laws/fsm
    local, control = fsm.casadi("law_local_paper"), fsm.casadi("law_control_paper")
    sd_dot, wd, wdd = (np.asarray(v).ravel() for v in ref(t, x[:3], p.ref_params))
    assert np.allclose(dx[:3], sd_dot, rtol=1e-13, atol=1e-15)

    def agent_in(j, J0):
        gc = fsm.casadi("law_constants")(p.params[j])
        return (t, x[3 + 6 * j : 6 + 6 * j], x[6 + 6 * j : 9 + 6 * j], np.zeros(0), x[:3], wd, wdd, J0, p.params[j], gc)

    s_all = [np.asarray(local(*agent_in(j, paper.agents[j].J0_array))[0]).ravel() for j in range(6)]
    # Table 2 (k^i = 8 on every link, k^j by the oracle's exact rule; 3.7 + phi_14 = 3.7 + 2.8 is a switching
    # instant, and the double 3.7 lies just after it: link 1 <- 4 is off)
    K = np.array([[oracle.k_j_exact(i, j, t) for j in range(1, 7)] for i in range(1, 7)])
    assert K[0, 3] == 0.0 and np.count_nonzero(K) == 24
    Ki = 8.0 * (1.0 - np.eye(6))
    for i, agent in enumerate(paper.agents):
        sigma, omega = x[3 + 6 * i : 6 + 6 * i], x[6 + 6 * i : 9 + 6 * i]
        # plant: J omega_dot = -omega x J omega + u + d, sigma_dot = G omega
        J = agent.J_true
        tau = u[i] + paper_disturbance(i + 1, t)
        assert np.allclose(
            dx[6 + 6 * i : 9 + 6 * i], np.linalg.solve(J, tau - np.cross(omega, J @ omega)), rtol=1e-12, atol=1e-14
        )
        assert np.allclose(dx[3 + 6 * i : 6 + 6 * i], mrp_G(sigma) @ omega, rtol=1e-12, atol=1e-15)
        # controller: nominal J0, and only sum_j k^j_ij(t) s_j from the neighbours
        received = sum(K[i, j] * s_all[j] for j in range(6))
        tail = (Ki[i].sum(), received, K[i].sum(), p.u_max[i])

        def commanded(J0, i=i, tail=tail):  # u_commanded (unsaturated): a sharper comparison
            args = agent_in(i, J0)
            return np.asarray(control(*args, local(*args)[1], *tail)[1]).ravel()

        u_J0, u_J = commanded(agent.J0_array), commanded(agent.J_true)
        assert np.allclose(np.clip(u_J0, -2, 2), u[i], rtol=1e-12, atol=1e-12)
        assert np.abs(u_J - u_J0).max() > 1e-3 * np.abs(u_J0).max()  # J0 and J give different commands


def test_disturbance_enters_the_plant_only(paper):
    """Same state, two times: the difference of omega_dot is exactly J^-1 (d(t1) - d(t2)) when u is unsaturated."""
    s = paper.replace(controller={"torque_limit": math.inf})
    rhs = CompiledRHS(s)
    x = rhs.p.x0
    # k^j_ij(t) is the same at both times for every link (checked), the reference moves, so compare
    # the plant part through u: omega_dot - J^-1 u
    for t in (0.0, 10.0):
        dx, u = rhs(t, x, with_u=True)
        for i, agent in enumerate(s.agents):
            J = agent.J_true
            w = x[6 + 6 * i : 9 + 6 * i]
            d_recovered = J @ dx[6 + 6 * i : 9 + 6 * i] + np.cross(w, J @ w) - u[i]
            assert np.allclose(d_recovered, paper_disturbance(i + 1, t), atol=1e-9 * np.abs(u).max())


def test_coordination_uses_only_what_the_agent_receives(paper):
    """Eq 19 through the driver: u_i depends on s_j only through links i <- j with k^j_ij(t) != 0."""
    s = paper.replace(controller={"torque_limit": math.inf})
    rhs = CompiledRHS(s)
    x = rhs.p.x0.copy()
    topo = s.topology
    # Table 2: at t = 1 s, k(t + phi) = 0 for phi in (5.5, 7): links 3<-4 (5.6), 4<-2 (6.0), 5<-6 (6.2)
    K1 = topo.k_j_matrix(1.0)
    assert K1[4, 5] == 0 and K1[2, 3] == 0 and K1[3, 1] == 0
    assert topo.k_j_matrix(0.0)[4, 5] == 5.0
    x_pert = x.copy()
    x_pert[3 + 6 * 5 : 9 + 6 * 5] += 0.05  # perturb agent 6's state (hence s_6)
    for t, affected in ((1.0, False), (0.0, True)):
        _, u0 = rhs(t, x, with_u=True)
        _, u1 = rhs(t, x_pert, with_u=True)
        change = np.abs(u1[4] - u0[4]).max()
        if affected:
            assert change > 1e-3
        else:
            assert change == 0.0, f"agent 5 reacts to agent 6 while k^6_56({t}) = 0"
        # agents 1-4 always receive from 6 at these times
        assert np.abs(u1[0] - u0[0]).max() > 1e-3
    # a sparse graph: in a ring of 6, agent 1 never hears agent 4
    ring = fsmctl.model.topology.ring(6, 8.0, 5.0)
    rr = CompiledRHS(s.with_topology(ring))
    x_pert = x.copy()
    x_pert[3 + 6 * 3 : 9 + 6 * 3] += 0.05
    _, u0 = rr(0.0, x, with_u=True)
    _, u1 = rr(0.0, x_pert, with_u=True)
    assert np.abs(u1[0] - u0[0]).max() == 0.0
    assert np.abs(u1[2] - u0[2]).max() > 1e-3 and np.abs(u1[4] - u0[4]).max() > 1e-3


# ----------------------------------------------------------------------------- saturation


def test_each_torque_component_saturates_at_the_limit(paper):
    r = fsmctl.simulate(paper.replace(simulation={"t_final": 2.0, "output_interval": 0.005}))
    assert np.abs(r.u).max() == 2.0
    assert np.array_equal(r.u, np.clip(r.u_unsaturated, -2.0, 2.0))
    assert np.abs(r.u_unsaturated).max() > 100.0  # the limit is active...
    inside = np.abs(r.u_unsaturated) < 2.0
    assert inside.any()  # ... componentwise: some components are inside the limit while others are clipped
    mixed = np.any(inside, axis=2) & np.any(~inside, axis=2)
    assert mixed.any()


# ----------------------------------------------------------------------------- sampled control


@pytest.mark.parametrize("integrator", ["rk4", "dopri45"])
def test_sampled_control_is_a_zero_order_hold(paper, integrator):
    period = 0.05
    s = paper.replace(
        controller={"boundary_layer": 0.05, "torque_limit": math.inf},
        simulation={
            "t_final": 1.0,
            "dt": 1e-3,
            "output_interval": 1e-3,
            "control_period": period,
            "integrator": integrator,
        },
    )
    r = fsmctl.simulate(s)
    hold = np.floor(r.time / period + 1e-9).astype(int)
    changed = 0
    for m in np.unique(hold):
        block = r.u[hold == m]
        assert np.array_equal(block, np.broadcast_to(block[0], block.shape)), f"u varies inside hold period {m}"
        if m > 0:
            changed += not np.array_equal(block[0], r.u[hold == m - 1][0])
    assert changed >= len(np.unique(hold)) - 2  # and it does change at (almost) every sample instant
    # the held value is the law evaluated at the sample instant: compare with a continuous run's first sample
    rc = fsmctl.simulate(s.replace(simulation={"control_period": 0.0}))
    assert np.allclose(r.u[0], rc.u[0], rtol=0, atol=0)
    assert np.abs(r.u - rc.u).max() > 1.0  # a hold of 50 ms is visible


# ----------------------------------------------------------------------------- RK4 and the adaptive option


@pytest.fixture(scope="module")
def smooth():
    """Case 1 without the torque limit, boundary layer 0.05, Remark 6 band 0.05: a right-hand side without
    jumps (the Table 2 switches fall on the 1 ms grid and the RK4 loop integrates them exactly)."""
    return fsmctl.paper_scenario("1").replace(
        controller={"torque_limit": math.inf, "boundary_layer": 0.05, "epsilon": 0.05},
        simulation={"t_final": 2.0, "dt": 1e-3, "output_interval": 0.1},
    )


def test_rk4_loop_matches_solve_ivp_on_the_exported_rhs(smooth):
    """The C time loop vs SciPy DOP853 (rtol 1e-10) on the same RHS (``fsm_rhs``).

    Measured: 1.3e-8 at dt = 1 ms.  RK4 is only ~2nd order here (error 1.3e-8, 2.1e-9, 1.6e-9 at dt = 1, 0.5,
    0.25 ms) because the Remark 6 extension r1 x + r2 x|x| makes the RHS merely continuous in its derivative
    at every zero crossing of a sigma_e component; 1e-7 leaves a margin of ~8.
    """
    rhs = CompiledRHS(smooth)
    r = fsmctl.simulate(smooth)
    sol = solve_ivp(rhs, (0.0, 2.0), rhs.p.x0, t_eval=r.time, method="DOP853", rtol=1e-10, atol=1e-12)
    assert sol.success
    err = np.abs(state_matrix(r) - shadow_states(sol.y.T, smooth.n_agents)).max()
    assert err < 1e-7
    assert np.abs(r.u).max() > 1e4  # unsaturated: the transient demands ~2.4e4 N m


def test_rk4_and_dopri45_agree_on_a_smooth_run(smooth):
    r = fsmctl.simulate(smooth)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DiscontinuousControlWarning)  # boundary layer > 0: no warning
        a = fsmctl.simulate(smooth.replace(simulation={"integrator": "dopri45", "rtol": 1e-11, "atol": 1e-13}))
    assert a.steps_taken > 100 and a.steps_rejected >= 0
    assert np.allclose(a.time, r.time, rtol=0, atol=1e-12)  # k dt vs m output_interval: rounding only
    assert np.abs(state_matrix(a) - state_matrix(r)).max() < 1e-7


def test_rk4_switching_weights_on_the_grid_converge_at_fourth_order():
    """Table 2 switches on the step grid are integrated exactly (link weights at the step midpoint):
    without saturation and with a large boundary layer (the sgn term stays linear) the RK4 error falls ~16x
    per halving of dt until the Remark 6 kinks show up."""
    base = fsmctl.paper_scenario("1").replace(
        controller={"torque_limit": math.inf, "boundary_layer": 10.0, "epsilon": 0.05},
        simulation={"t_final": 2.0, "output_interval": 0.1},
    )
    runs = {dt: fsmctl.simulate(base.replace(simulation={"dt": dt})) for dt in (2e-3, 1e-3, 1.25e-4)}
    ref = state_matrix(runs[1.25e-4])
    e1, e2 = (np.abs(state_matrix(runs[dt]) - ref).max() for dt in (2e-3, 1e-3))
    assert e1 < 1e-6
    assert e2 < e1 / 4  # at least second order; an O(dt) error per switch (the old stage-time rule) gives ~2


def test_adaptive_integrator_warns_for_the_discontinuous_law(paper):
    s = paper.replace(controller={"boundary_layer": 0.0}, simulation={"t_final": 0.2, "integrator": "dopri45"})
    with pytest.warns(DiscontinuousControlWarning, match="boundary_layer = 0"):
        try:
            fsmctl.simulate(s)
        except SimulationError as exc:  # the step size may collapse: a clear error, never a hang or NaN
            assert "simulation failed" in str(exc)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DiscontinuousControlWarning)
        fsmctl.simulate(s.replace(controller={"boundary_layer": 0.01}))  # continuous law: no warning
        fsmctl.simulate(s.replace(simulation={"integrator": "rk4"}))  # fixed step: no warning


# ----------------------------------------------------------------------------- Lyapunov function of Theorem 1


def _nominal(paper, error_model: str, t_final: float = 5.0):
    agents = [dataclasses.replace(a, delta_J=ZERO3x3, disturbance=Sinusoid()) for a in paper.agents]
    s = with_agents(
        paper,
        agents,
        controller={"torque_limit": math.inf, "boundary_layer": 0.0, "error_model": error_model},
        simulation={"t_final": t_final, "dt": 1e-3, "output_interval": 1e-3},
    )
    return s, fsmctl.simulate(s)


def test_lyapunov_function_is_non_increasing_in_the_nominal_case(paper):
    """V = sum_i 1/2 s_i's_i (eqs 21-22), nominal (dJ = 0, d = 0), unsaturated, sgn(s), exact error kinematics.

    Theorem 1 (corrected conditions, Table 2 gains k^i = 8, k^j in {0, 5}: eta = 4 works) gives
    dV/dt <= -sum_i delta_i' |s_i| <= 0.  In discrete time sgn(s) chatters once s ~ 0: s stays in a band of
    O(delta dt) = 5e-6 and V may rise by O((delta dt)^2) per step, which is what is allowed below.
    """
    s, r = _nominal(paper, "exact")
    delta, dt = 0.005, s.simulation.dt
    V = 0.5 * np.sum(r.s**2, axis=(1, 2))
    dV = np.diff(V)
    chatter = 3 * s.n_agents * (delta * dt) ** 2  # 4.5e-10
    assert dV.max() <= chatter
    assert np.all(dV[V[:-1] > 1e-8] <= 0.0), "V rises outside the chattering band"
    assert V[0] > 1.0 and V[-1] < 1e-10  # reaches the surface (within the O(dt) band) ...
    reached = np.argmax(V < 1e-10)
    assert r.time[reached] < 1.0
    assert np.abs(r.s[reached:]).max() <= 2 * delta * dt  # ... and stays in the O(delta dt) band (5.6e-6)
    assert np.isfinite(r.u).all()


def test_lyapunov_function_rises_with_the_paper_error_kinematics(paper):
    """Finding (erratum eq7-8): with the printed omega_e = omega - omega_d the controller does not produce the
    closed loop (20) on the true rigid body while omega_d != 0, so V of Theorem 1 is not monotone even in the
    nominal case.  Measured: V rises by 5.6e-7 at t ~ 0.48 s (V ~ 2.6e-5); it still converges."""
    _, r = _nominal(paper, "paper")
    V = 0.5 * np.sum(r.s**2, axis=(1, 2))
    dV = np.diff(V)
    assert dV.max() > 1e-7
    assert np.argmax(dV) > 0 and V[np.argmax(dV)] > 1e-6  # outside any chattering band
    assert V[-1] < 1e-10


# ----------------------------------------------------------------------------- sigma_e through zero


@pytest.mark.parametrize("fix", ["switch", "clamp"])
@pytest.mark.parametrize("error_model", ["paper", "exact"])
def test_no_nan_when_starting_exactly_on_the_reference(paper, fix, error_model):
    """sigma_i(0) = sigma_d(0), omega_i(0) = omega_d(0): sigma_e = 0 and s = 0 exactly at t = 0 (Remark 6)."""
    sd0 = paper.reference.sigma0
    wd0 = tuple(float(v) for v in paper.reference.omega(0.0))
    agents = [dataclasses.replace(a, sigma0=sd0, omega0=wd0) for a in paper.agents]
    s = with_agents(
        paper,
        agents,
        controller={"singularity_fix": fix, "error_model": error_model},
        simulation={"t_final": 2.0, "output_interval": 0.01},
    )
    r = fsmctl.simulate(s)
    assert np.abs(r.sigma_e[0]).max() < 1e-16 and np.sum(r.sigma_e[0] == 0.0) >= 6  # 0 up to rounding
    for name in ("sigma", "omega", "sigma_e", "omega_e", "s", "u", "u_unsaturated"):
        assert np.isfinite(getattr(r, name)).all(), name
    assert np.abs(r.sigma_e).max() < 1e-4  # stays at the reference despite dJ and d(t)


def test_singular_law_gives_a_clear_error_not_a_silent_torque(paper):
    """singularity_fix = 'none' (the law as printed) at sigma_e = 0: alpha|0|^(alpha-1) * 0 is NaN.  The
    saturation fmin(u_max, fmax(-u_max, NaN)) would apply -u_max silently; the run is refused before it starts,
    naming the agent and the Remark 6 device (the law is undefined at the initial state: an input error).  The
    reference starts at sigma_d = 0, so that every agent's sigma_e is exactly 0 in every component (from the paper's
    sigma_d(0) the error composition leaves ~1e-17 of rounding in some components)."""
    paper = paper.replace(reference={"sigma0": (0.0, 0.0, 0.0)})
    sd0 = paper.reference.sigma0
    wd0 = tuple(float(v) for v in paper.reference.omega(0.0))
    agents = [dataclasses.replace(a, sigma0=sd0, omega0=wd0) for a in paper.agents]
    s = with_agents(paper, agents, controller={"singularity_fix": "none"}, simulation={"t_final": 0.5})
    with pytest.raises(LawError, match=r"torque is not finite at the initial state of agent 1 .*Remark 6.*'switch'"):
        fsmctl.simulate(s)


@pytest.mark.parametrize(
    ("n_agents", "spinning", "named"), [(3, (0,), 1), (3, (1,), 2), (3, (2,), 3), (11, (9,), 10), (11, (9, 4), 5)]
)
def test_a_state_overflowing_is_reported_with_its_agent_and_time(n_agents, spinning, named):
    """A finite torque (an open-loop law) on a body spinning at 1e160 rad/s: omega x J omega overflows in the first
    step, the step's new state is not finite, and the run stops there naming the agent (the driver's branch-free
    finiteness pass, then the search for the first bad entry).  11 agents fill a lane group and part of the next at
    4 and at 8 lanes, where the loop keeps the state in lane rows: the first agent is named, whatever its group."""
    from formations import single_spacecraft

    s = single_spacecraft(n_agents=n_agents, t_final=0.01, control_period=0.0)
    agents = list(s.agents)
    for agent in spinning:
        agents[agent] = dataclasses.replace(agents[agent], omega0=(1e160, -1e160, 1e160))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the step-size advice for this rate
        with pytest.raises(SimulationError, match=rf"a state became non-finite at t = 0.001 s in agent {named} "):
            fsmctl.simulate(dataclasses.replace(s, agents=tuple(agents)))


def test_no_nan_when_sigma_e_components_cross_zero(paper):
    r = fsmctl.simulate(paper.replace(simulation={"t_final": 20.0, "output_interval": 0.01}))
    assert paper.simulation.integrator == "rk4"  # the default: fixed-step RK4 in C
    crossings = np.sum(np.diff(np.sign(r.sigma_e), axis=0) != 0)
    assert crossings >= 10
    assert np.linalg.norm(r.sigma_e, axis=2).max() <= 1.0 + 1e-12  # sigma_e in the shadow set under control
    for name in ("sigma", "omega", "sigma_e", "omega_e", "s", "u", "u_unsaturated"):
        assert np.isfinite(getattr(r, name)).all(), name


# ----------------------------------------------------------------------------- summary and files


@pytest.fixture(scope="module")
def converging(paper):
    """dJ = 0, 200 N m limit, exact kinematics, boundary layer 0.01: saturates ~3 s, settles in ~5 s; 50 s,
    output interval = step (so the driver's statistics can be recomputed from the outputs)."""
    agents = [dataclasses.replace(a, delta_J=ZERO3x3) for a in paper.agents]
    s = with_agents(
        paper,
        agents,
        controller={"torque_limit": 200.0, "boundary_layer": 0.01, "error_model": "exact"},
        simulation={"t_final": 50.0, "dt": 5e-3, "output_interval": 5e-3},
    )
    return fsmctl.simulate(s)


def test_summary_against_the_arrays(converging):
    """The summary against its definitions applied to the output arrays (output interval = step): the settling
    times and steady state by their definitions, and the time in saturation and the total variation of u, which
    the C loop accumulates at every step, recomputed here from the recorded torques (a second route)."""
    r = converging
    summ = r.summary(tolerances_deg=(1.0, 0.01))
    t, a, rel = r.time, r.aaem_deg, r.raem_deg
    for key, metric in (("aaem_settling_s", a), ("raem_settling_s", rel)):
        for tol in ("1", "0.01"):
            ts = summ[key][tol]
            assert math.isfinite(ts), (key, tol)
            k = int(np.searchsorted(t, ts))
            assert np.all(metric[k:] <= float(tol)) and metric[k - 1] > float(tol)
    last = t >= t[-1] - 20.0 - 1e-9
    assert summ["steady_window_s"] == 20.0  # the policy's: 40 % of the 50 s horizon
    assert summ["aaem_steady_max_deg"] == a[last].max() and summ["raem_steady_max_deg"] == rel[last].max()
    assert summ["aaem_steady_max_deg"] < 0.01
    assert summ["u_max_abs_N_m"] == np.abs(r.u).max() == 200.0
    assert summ["u_unsaturated_max_N_m"] == pytest.approx(np.abs(r.u_unsaturated).max(), rel=1e-12)
    # time in saturation and the chattering index, recomputed from the outputs (output interval = step)
    dt = r.scenario.simulation.dt
    sat = dt * np.any(np.abs(r.u_unsaturated[:-1]) > 200.0, axis=2).sum(axis=0)
    assert np.allclose(summ["saturated_time_s"], sat, atol=1e-9)
    assert 0 < max(summ["saturated_time_s"]) < 10
    tv = np.abs(np.diff(r.u[:-1], axis=0)).sum(axis=(0, 2))
    assert np.allclose(summ["chattering_index_N_m_per_s"], tv / 50.0, rtol=1e-9)
    assert math.isfinite(summ["last_saturation_s"]) and summ["last_saturation_s"] < 10.0


def test_netcdf_round_trip_with_units(converging, tmp_path):
    xr = pytest.importorskip("xarray")
    r = converging
    path = r.save(tmp_path / "run.nc")
    with xr.open_dataset(path) as ds:
        ds.load()
    assert np.array_equal(ds["time_s"].values, r.time)
    assert ds["time_s"].attrs["units"] == "s"
    expected = {
        "sigma": (r.sigma, "1"),
        "omega_rad_per_s": (r.omega, "rad/s"),
        "u_N_m": (r.u, "N m"),
        "u_unsaturated_N_m": (r.u_unsaturated, "N m"),
        "broadcast_s": (r.s, "1/s"),
        "aaem_deg": (r.aaem_deg, "deg"),
        "raem_deg": (r.raem_deg, "deg"),
        "saturated_time_s": (r.saturated_time, "s"),
    }
    for name, (values, units) in expected.items():
        assert np.array_equal(ds[name].values, values), name
        assert ds[name].attrs["units"] == units, name
    assert ds["sigma"].dims == ("time_s", "agent", "axis")
    assert list(ds["agent"].values) == [1, 2, 3, 4, 5, 6]
    assert "Liang" in ds.attrs["source"] and "alpha=0.7" in ds.attrs["scenario"]
    npz = np.load(r.save(tmp_path / "run.npz"))
    assert np.array_equal(npz["u_N_m"], r.u)


# ----------------------------------------------------------------------------- CasADi fallback


def _clear_backend_caches() -> None:
    from fsmctl.model import generated_code
    from fsmctl.simulation import simulator

    for cache in (generated_code.compiled_library, generated_code.casadi_function, simulator._driver):
        cache.cache_clear()


def _simulate_without_compiler(scenario, monkeypatch):
    """Run ``scenario`` with ``FSMCTL_NO_COMPILE=1`` (serialized CasADi functions), restoring the backend after."""
    from fsmctl.model.generated_code import CompilerUnavailableWarning

    monkeypatch.setenv("FSMCTL_NO_COMPILE", "1")
    _clear_backend_caches()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", CompilerUnavailableWarning)
            return fsmctl.simulate(scenario)
    finally:
        monkeypatch.delenv("FSMCTL_NO_COMPILE")
        _clear_backend_caches()


@pytest.mark.parametrize("control_period", [0.0, 0.01])
def test_casadi_fallback_agrees_with_the_compiled_loop(paper, monkeypatch, control_period):
    """``FSMCTL_NO_COMPILE=1``: the same loop on the serialized CasADi functions (generated/casadi)."""
    s = paper.replace(simulation={"t_final": 1.0, "output_interval": 0.05, "control_period": control_period})
    compiled = fsmctl.simulate(s)
    if compiled.backend != "compiled":
        pytest.skip("no C compiler to compare with")
    vm = _simulate_without_compiler(s, monkeypatch)
    assert vm.backend == "casadi-vm"
    for name in ("sigma", "omega", "sigma_e", "s", "u"):
        assert np.abs(getattr(vm, name) - getattr(compiled, name)).max() < 1e-12, name
    assert np.allclose(vm.u_unsaturated, compiled.u_unsaturated, rtol=1e-12, atol=1e-9)
    assert np.allclose(vm.saturated_time, compiled.saturated_time, atol=1e-9)
    assert np.allclose(vm.u_total_variation, compiled.u_total_variation, atol=1e-9)


def test_casadi_adaptive_fallback_records_the_shadow_set(torque_free, monkeypatch):
    """The no-compiler dopri45 path integrates unswitched MRPs but records |sigma| <= 1, the same attitudes."""
    s, compiled = torque_free
    short = s.replace(simulation={"t_final": 12.0, "output_interval": 0.1, "integrator": "dopri45"})
    vm = _simulate_without_compiler(short, monkeypatch)
    assert vm.backend == "casadi-vm"
    assert np.linalg.norm(vm.sigma, axis=-1).max() <= 1.0 + 1e-12
    assert np.linalg.norm(vm.sigma_d, axis=-1).max() <= 1.0 + 1e-12
    k = compiled.time <= 12.0 + 1e-9
    # same attitudes as the compiled RK4 run (|sigma| near 1 has two representations: compare rotations)
    crossed = np.linalg.norm(compiled.sigma[k], axis=-1).max()
    assert crossed > 0.9  # some agent turns past ~170 deg, so switching matters in this window
    np.testing.assert_allclose(np.abs(vm.theta_e - compiled.theta_e[k]).max(), 0.0, atol=1e-5)
