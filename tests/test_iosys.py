"""The python-control plug-in (``fsmctl.spacecraft``, ``law_controller``, ``fsmctl.fsm_controller``,
``fsmctl.formation``).

Oracles: Euler's equation and the MRP kinematics (eqs 3-5) written out in NumPy, the paper's omega_d(t)
(Sec. 4), the generated control laws called directly (a law's contract functions, the paper's law's among them,
with the neighbour sums written out), and the compiled simulator.
Liang, Sun & Wang, Acta Astronautica 81 (2012).
"""

from __future__ import annotations

import math

import control as ct
import numpy as np
import pytest
from formations import PI_LAW
from hypothesis import given, settings
from hypothesis import strategies as st

import fsmctl
from fsmctl.model.laws import derive_script, initial_law_states, parameter_matrix, resolve_law
from fsmctl.model.topology import Schedule
from fsmctl.plugin.iosys import Neighbour, initial_state, law_controller, law_parameter_values, mrp_state

DELTA = (0.005, 0.005, 0.005)  # the paper scenario's switching gain (eq 18), [controller] delta of paper.toml


def skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def mrp_G(s):
    s = np.asarray(s, dtype=float)
    return 0.25 * ((1.0 - s @ s) * np.eye(3) + 2.0 * skew(s) + 2.0 * np.outer(s, s))


def shadow(s):
    s = np.asarray(s, dtype=float)
    return -s / (s @ s) if s @ s > 1.0 else s


def quat(s):
    """Euler parameters (scalar first) of an MRP (Schaub & Junkins eq 3.153)."""
    s = np.asarray(s, dtype=float)
    return np.concatenate([[1.0 - s @ s], 2.0 * s]) / (1.0 + s @ s)


def mrp_rate_from_quat_rate(q, qdot):
    """d/dt of sigma = q_v / (1 + q0) (the MRP of a quaternion with q0 > -1)."""
    return qdot[1:] / (1.0 + q[0]) - q[1:] * qdot[0] / (1.0 + q[0]) ** 2


def mrp_of_quat(q):
    """Shadow-set MRP of a (not necessarily unit) quaternion: normalise, then q_v / (1 + q0) or its shadow."""
    q = np.asarray(q, dtype=float) / np.linalg.norm(q)
    return shadow(q[1:] / (1.0 + q[0])) if q[0] > -1 + 1e-12 else -q[1:] / (1.0 - q[0])


@pytest.fixture(scope="module")
def paper():
    return fsmctl.paper_scenario("1")


@pytest.fixture(scope="module")
def pi_law(tmp_path_factory):
    folder = tmp_path_factory.mktemp("pi_law")
    (folder / "pi_law.py").write_text(PI_LAW)
    return resolve_law(str(derive_script(folder / "pi_law.py", out=folder / "pi")))


# ----------------------------------------------------------------------------- spacecraft


def test_spacecraft_signals():
    sc = fsmctl.spacecraft(np.diag([100.0, 150.0, 200.0]), name="bus")
    assert sc.name == "bus"
    assert sc.input_labels == ["tau[0]", "tau[1]", "tau[2]"]
    assert sc.state_labels == ["q[0]", "q[1]", "q[2]", "q[3]", "omega[0]", "omega[1]", "omega[2]"]
    assert sc.output_labels == ["sigma[0]", "sigma[1]", "sigma[2]", "omega[0]", "omega[1]", "omega[2]"]
    assert set(sc.params) == {"bus_J", "bus_disturbance", "bus_owner"}


@st.composite
def _plant_points(draw):
    m = sorted(draw(st.lists(st.floats(50.0, 300.0), min_size=3, max_size=3)))
    m[2] = min(m[2], m[0] + m[1])
    off = draw(st.floats(-5.0, 5.0))
    J = np.diag(m) + off * (np.ones((3, 3)) - np.eye(3)) / 3
    vec = st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3)
    return J, np.array(draw(vec)), np.array(draw(vec)), 10.0 * np.array(draw(vec)), draw(st.floats(0.0, 100.0))


@settings(max_examples=40, deadline=None)
@given(point=_plant_points())
def test_spacecraft_dynamics_are_euler_and_mrp_kinematics(point):
    """J omega_dot = -omega^x J omega + tau + d(t) (eqs 4, 29), sigma_dot = G(sigma) omega (eqs 3, 5).

    The plant integrates Euler parameters q: its q_dot, mapped to sigma_dot by the chain rule, must be eq 5's
    G(sigma) omega; its output is the shadow-set MRP of the attitude.
    """
    J, sigma, omega, tau, t = point
    dist = fsmctl.Sinusoid(amplitude=(0.2, -0.24, 0.22), frequency=(0.1, 0.15, 0.12), phase=(1.0, 1.0, 1.0))
    q = quat(sigma)
    for d in (None, dist):
        sc = fsmctl.spacecraft(J, disturbance=d, name="sc")
        dx = sc.dynamics(t, np.concatenate([q, omega]), tau)
        torque = tau + (0 if d is None else d(t))
        assert np.allclose(dx[4:], np.linalg.solve(J, torque - np.cross(omega, J @ omega)), rtol=1e-11, atol=1e-13)
        assert np.allclose(mrp_rate_from_quat_rate(q, dx[:4]), mrp_G(sigma) @ omega, rtol=1e-12, atol=1e-14)
        assert abs(q @ dx[:4]) < 1e-15  # |q| = 1 is kept
        y = sc.output(t, np.concatenate([q, omega]), tau)
        assert np.allclose(y[:3], shadow(sigma), rtol=1e-13, atol=1e-15) and np.array_equal(y[3:], omega)


def test_spacecraft_rejects_a_bad_inertia():
    with pytest.raises(fsmctl.ScenarioError, match="not symmetric"):
        fsmctl.spacecraft([[100.0, 1.0, 0.0], [0.0, 150.0, 0.0], [0.0, 0.0, 200.0]])
    with pytest.raises(fsmctl.ScenarioError, match="not positive definite"):
        fsmctl.spacecraft(np.diag([100.0, -1.0, 200.0]))
    with pytest.raises(ValueError, match="3x3"):
        fsmctl.spacecraft(np.eye(2))


def test_reference_generator_is_the_papers_omega_d(paper):
    ref = fsmctl.reference_generator(paper.reference.omega)
    assert ref.state_labels == ["q_d[0]", "q_d[1]", "q_d[2]", "q_d[3]"]
    q_d = quat(paper.reference.sigma0)
    for t in (0.0, 13.0, 77.7):
        y = ref.output(t, q_d, [])
        wd = [0.1 * math.cos(t / 40), -0.1 * math.sin(t / 50), -0.1 * math.cos(t / 60)]
        wdd = [-0.1 / 40 * math.sin(t / 40), -0.1 / 50 * math.cos(t / 50), 0.1 / 60 * math.sin(t / 60)]
        assert np.allclose(y[3:6], wd, atol=1e-15) and np.allclose(y[6:9], wdd, atol=1e-15)
        assert np.allclose(y[:3], paper.reference.sigma0, atol=1e-15)
        dx = ref.dynamics(t, q_d, [])
        assert np.allclose(mrp_rate_from_quat_rate(q_d, dx), mrp_G(paper.reference.sigma0) @ np.array(wd), atol=1e-15)


# ----------------------------------------------------------------------------- controller


def test_fsm_controller_is_the_generated_law_with_received_sliding_variables(paper):
    agent = paper.agents[0]
    c = paper.controller
    sched = Schedule((0.0, 6.5), (5.0, 0.0), period=8.0)
    nbrs = [Neighbour("a", 8.0, sched, phase=0.0), Neighbour("b", 8.0, sched, phase=6.0)]
    ctrl = fsmctl.fsm_controller(agent.J0_array, c, DELTA, neighbours=nbrs, name="ctrl")
    assert ctrl.input_labels[:3] == ["sigma[0]", "sigma[1]", "sigma[2]"]
    assert ctrl.input_labels[15:] == ["s_a[0]", "s_a[1]", "s_a[2]", "s_b[0]", "s_b[1]", "s_b[2]"]
    assert ctrl.output_labels == ["tau[0]", "tau[1]", "tau[2]", "s[0]", "s[1]", "s[2]"]
    assert ctrl.nstates == 0
    law = resolve_law("fsm")  # the paper's law, generated once in generated/laws/fsm
    params = parameter_matrix(law, paper)[0]
    constants = law.casadi("law_constants")(params)
    rng = np.random.default_rng(3)
    own = np.concatenate([[0.1, -0.2, 0.3], [0.01, 0.02, -0.03], paper.reference.sigma0, [0.1, 0, -0.1], [0, 0, 0]])
    s_a, s_b = rng.normal(size=3) * 1e-3, rng.normal(size=3) * 1e-3
    for t in (0.0, 1.0):  # at t = 1: k(1 + 6) = 0, neighbour b is silent
        k_a, k_b = sched.value(t), sched.value(t + 6.0)
        y = ctrl.output(t, [], np.concatenate([own, s_a, s_b]))
        sig, om, sig_d, om_d, om_d_dot = np.split(own, 5)
        agent_in = (t, sig, om, np.zeros(0), sig_d, om_d, om_d_dot, agent.J0_array, params, constants)
        s, cache = law.casadi("law_local_paper")(*agent_in)
        # k_sum = sum_j k^i_ij = 8 + 8; received = sum_j k^j_ij(t) s_j
        u = law.casadi("law_control_paper")(*agent_in, cache, 16.0, k_a * s_a + k_b * s_b, k_a + k_b, 2.0)[0]
        assert np.allclose(y[:3], np.asarray(u).ravel(), rtol=1e-13, atol=1e-13)
        assert np.allclose(y[3:], np.asarray(s).ravel(), rtol=1e-13, atol=1e-15)
    # neighbour b's sliding variable does not matter while its weight is 0 ...
    y1 = ctrl.output(1.0, [], np.concatenate([own, s_a, s_b]))
    y2 = ctrl.output(1.0, [], np.concatenate([own, s_a, 100 * s_b]))
    assert np.array_equal(y1, y2)
    # ... and does when it is on
    c_inf = paper.replace(controller={"torque_limit": math.inf}).controller
    ctrl_inf = fsmctl.fsm_controller(agent.J0_array, c_inf, DELTA, neighbours=nbrs, name="ctrl")
    y1 = ctrl_inf.output(0.0, [], np.concatenate([own, s_a, s_b]))
    y2 = ctrl_inf.output(0.0, [], np.concatenate([own, s_a, 100 * s_b]))
    assert np.abs(y1[:3] - y2[:3]).max() > 1e-3


def test_disabled_controller_outputs_zero_torque(paper):
    agent = paper.agents[0]
    off = paper.replace(controller={"enabled": False}).controller
    ctrl = fsmctl.fsm_controller(agent.J0_array, off, DELTA)
    own = np.concatenate([[0.1, -0.2, 0.3], [0.01, 0.02, -0.03], paper.reference.sigma0, [0.1, 0, -0.1], [0, 0, 0]])
    y = ctrl.output(0.0, [], own)
    assert np.all(y[:3] == 0.0) and np.abs(y[3:]).max() > 0


def _own_signals(paper):
    return np.concatenate([[0.1, -0.2, 0.3], [0.01, 0.02, -0.03], paper.reference.sigma0, [0.1, 0, -0.1], [0, 0, 0]])


def test_fsm_controller_is_law_controller_of_the_papers_law(paper):
    """``fsm_controller`` (gains and delta as today) and ``law_controller("fsm", ...)`` (one parameter per law
    parameter, by name): the same system, the same outputs."""
    agent = paper.agents[2]
    s = paper.replace(controller={"torque_limit": math.inf, "boundary_layer": 0.01})
    c = s.controller
    law = resolve_law("fsm")
    values = law_parameter_values(law, parameter_matrix(law, s)[2])
    assert values["singularity_fix"] == "switch" and np.array_equal(values["delta"], DELTA)
    sched = Schedule((0.0, 6.5), (5.0, 0.0), period=8.0)
    nbrs = [Neighbour("a", 8.0, sched), Neighbour("b", 3.0, sched, phase=6.0)]
    old = fsmctl.fsm_controller(agent.J0_array, c, DELTA, neighbours=nbrs, name="old")
    new = law_controller(law, agent.J0_array, parameters=values, neighbours=nbrs, name="new")
    assert old.input_labels == new.input_labels and old.output_labels == new.output_labels
    assert sorted(old.params) == sorted(f"old_{k}" for k in [*values, "J0", "u_max", "owner"])
    assert sorted(new.params) == sorted(f"new_{k}" for k in [*values, "J0", "u_max", "owner"])
    rng = np.random.default_rng(8)
    for t in (0.0, 1.0, 7.3):
        u = np.concatenate([_own_signals(paper), rng.normal(size=6) * 1e-2])
        assert np.array_equal(old.output(t, [], u), new.output(t, [], u))
    # a gain by name, at evaluation time, is the controller built with that gain: c1 = 0 is the TSM surface
    # (the surface preset "tsm" sets c1 = 0), fix "clamp" is singularity_fix = "clamp"
    u = np.concatenate([_own_signals(paper), rng.normal(size=6) * 1e-2])
    tsm = fsmctl.fsm_controller(
        agent.J0_array, s.replace(controller={"surface": "tsm"}).controller, DELTA, neighbours=nbrs
    )
    assert np.array_equal(tsm.output(1.0, [], u), new.output(1.0, [], u, params={"new_c1": 0.0}))
    assert np.array_equal(tsm.output(1.0, [], u), old.output(1.0, [], u, params={"old_c1": 0.0}))
    assert not np.array_equal(new.output(1.0, [], u), new.output(1.0, [], u, params={"new_c1": 0.0}))
    clamp = fsmctl.fsm_controller(
        agent.J0_array, s.replace(controller={"singularity_fix": "clamp"}).controller, DELTA, neighbours=nbrs
    )
    fix = new.output(1.0, [], u, params={"new_singularity_fix": "clamp"})
    assert np.array_equal(fix, clamp.output(1.0, [], u))
    delta = old.output(1.0, [], u, params={"old_delta": 2 * np.asarray(DELTA)})
    assert np.array_equal(
        delta, fsmctl.fsm_controller(agent.J0_array, c, 2 * np.asarray(DELTA), neighbours=nbrs).output(1.0, [], u)
    )
    assert not np.array_equal(delta, old.output(1.0, [], u))
    # validated by the scenario files' path (the law's declared range): alpha outside (0.5, 1)
    with pytest.raises(fsmctl.ScenarioError, match=r"'old_alpha'.*must be < 1"):
        old.output(1.0, [], u, params={"old_alpha": 1.2})
    with pytest.raises(fsmctl.ScenarioError, match="alpha: must be < 1"):
        s.replace(controller={"alpha": 1.2})


def test_law_controller_with_a_state_is_the_generated_law(paper, pi_law):
    """A law with a state: the system's states are the law's, its outputs and state derivative are the contract
    functions' with ``received = sum_j k^j_ij(t) b_j``, ``k_sum = sum_j k^i_ij``, ``k_received_sum = sum_j
    k^j_ij(t)`` written out."""
    agent = paper.agents[0]
    sched = Schedule((0.0, 6.5), (5.0, 0.0), period=8.0)
    nbrs = [Neighbour("sc2", 8.0, sched), Neighbour("sc3", 2.0, Schedule.constant(4.0), phase=6.0)]
    ctrl = law_controller(pi_law, agent.J0_array, parameters={"K": 3.0}, u_max=0.5, neighbours=nbrs, name="pi1")
    assert ctrl.nstates == 3 and ctrl.state_labels == ["integral[0]", "integral[1]", "integral[2]"]
    assert ctrl.input_labels[15:] == [f"sigma_e_sc{j}[{k}]" for j in (2, 3) for k in range(3)]
    assert ctrl.output_labels == ["tau[0]", "tau[1]", "tau[2]", "sigma_e[0]", "sigma_e[1]", "sigma_e[2]"]
    assert {"pi1_K", "pi1_P", "pi1_Ki", "pi1_J0", "pi1_u_max"} < set(ctrl.params)
    assert np.array_equal(initial_law_states(pi_law), [0.01] * 3)
    local, control = pi_law.casadi("law_local_paper"), pi_law.casadi("law_control_paper")
    rng = np.random.default_rng(2)
    own = _own_signals(paper)
    for t in (0.0, 1.0, 2.5):
        z = rng.normal(size=3) * 0.1
        b2, b3 = rng.normal(size=3) * 0.1, rng.normal(size=3) * 0.1
        u = np.concatenate([own, b2, b3])
        k2, k3 = sched.value(t), 4.0
        params = np.array([3.0, 20.0, 0.2])
        agent_in = (t, *np.split(own[:6], 2), z, *np.split(own[6:], 3), agent.J0_array, params, np.zeros(0))
        b, cache = local(*agent_in)
        out = control(*agent_in, cache, 10.0, k2 * b2 + k3 * b3, k2 + k3, 0.5)
        y = ctrl.output(t, z, u)
        assert np.allclose(y[:3], np.asarray(out[0]).ravel(), rtol=1e-14, atol=1e-15)
        assert np.abs(y[:3]).max() <= 0.5 and np.abs(np.asarray(out[1])).max() > 0.5  # the limit is applied
        assert np.allclose(y[3:], np.asarray(b).ravel(), rtol=1e-14, atol=1e-16)
        assert np.allclose(ctrl.dynamics(t, z, u), np.asarray(out[2]).ravel(), rtol=1e-14, atol=1e-16)


def test_law_controller_rejects_bad_parameters_in_one_line(paper, pi_law):
    J0 = paper.agents[0].J0_array
    cases = [
        (lambda: law_controller(pi_law, J0, parameters={"Kd": 1.0}), "has no parameter 'Kd'.*K, P, Ki"),
        (lambda: law_controller(pi_law, J0, parameters={"K": -1.0}), "K: must be >= 0"),
        (lambda: law_controller(pi_law, J0, parameters={"K": [1.0, 2.0]}), "K"),
        (lambda: law_controller(pi_law, J0, parameters=[("K", 1.0)]), "parameters: expected a mapping"),
        (lambda: law_controller("fsm", J0, parameters={"singularity_fix": "sometimes"}), "must be one of"),
        (lambda: law_controller("fsm", J0, parameters={"delta": [1.0, 1.0]}), "expected 3 numbers"),
        (lambda: law_controller("fsm", J0, error_model="approx"), "error_model"),
        (lambda: law_controller("fsm", J0, u_max=-1.0), "u_max: must be >= 0"),
        (lambda: law_controller("fsm", np.eye(2)), "J0"),
    ]
    for make, match in cases:
        with pytest.raises(fsmctl.ScenarioError, match=match) as exc:
            make()
        assert "\n" not in str(exc.value)
    ctrl = law_controller(pi_law, J0, name="pi")
    own = _own_signals(paper)
    with pytest.raises(fsmctl.ScenarioError, match=r"'pi_P'.*must be >= 0"):
        ctrl.output(0.0, np.zeros(3), own, params={"pi_P": -2.0})
    with pytest.raises(fsmctl.model.laws.LawError, match="not a built-in law"):
        law_controller("no-such-law", J0)


# ----------------------------------------------------------------------------- formation


def test_formation_structure_and_per_agent_params(paper):
    sys = fsmctl.formation(paper)
    assert isinstance(sys, ct.InterconnectedSystem)
    assert sys.ninputs == 0 and sys.nstates == 4 + 7 * 6 and sys.noutputs == 9 * 6
    # the compiled simulator's TimeResponseData uses the same output names
    r = fsmctl.simulate(paper.replace(simulation={"t_final": 0.05}))
    tr = r.to_time_response()
    assert list(tr.output_labels)[: sys.noutputs] == list(sys.output_labels)  # then the errors and metrics
    assert sys.state_labels[:5] == [f"reference_q_d[{k}]" for k in range(4)] + ["sc1_q[0]"]
    assert sys.state_labels[8:11] == ["sc1_omega[0]", "sc1_omega[1]", "sc1_omega[2]"]
    assert sys.output_labels[6:9] == ["sc1_tau[0]", "sc1_tau[1]", "sc1_tau[2]"]
    for i, agent in enumerate(paper.agents, start=1):
        assert np.array_equal(sys.params[f"sc{i}_J"], agent.J_true)  # plant: J = J0 + dJ
        assert np.array_equal(sys.params[f"ctrl{i}_J0"], agent.J0_array)  # controller: J0
        assert sys.params[f"ctrl{i}_u_max"] == 2.0
    # per-agent parameters can be overridden at simulation time without touching the others
    x0 = initial_state(paper)
    base = sys.dynamics(0.0, x0, [])
    J2 = 2.0 * paper.agents[1].J_true
    changed = sys.dynamics(0.0, x0, [], params={"sc2_J": J2})
    diff = np.abs(changed - base).reshape(-1)
    block2 = slice(4 + 7 + 4, 4 + 14)  # sc2's omega_dot
    assert diff[block2].max() > 1e-4
    assert np.delete(diff, np.r_[block2]).max() == 0.0


def test_compiled_time_response_uses_the_formation_state_layout(paper):
    """``SimulationResult.to_time_response()`` labels its states like :func:`fsmctl.formation` (quaternions).

    Needs the quaternion layout in ``fsmctl/simulator.py`` (see ``fsmctl.plugin.iosys.quaternion_from_mrp``).
    """
    sys = fsmctl.formation(paper)
    r = fsmctl.simulate(paper.replace(simulation={"t_final": 0.05}))
    tr = r.to_time_response()
    assert list(tr.state_labels) == list(sys.state_labels)
    # the same attitudes: the states' MRPs are the compiled simulator's
    for k in (0, -1):
        x = tr.states[:, k]
        assert np.allclose(mrp_of_quat(x[:4]), r.sigma_d[k], rtol=0, atol=1e-14)
        for i in range(paper.n_agents):
            o = 4 + 7 * i
            assert np.allclose(mrp_of_quat(x[o : o + 4]), r.sigma[k, i], rtol=0, atol=1e-14)
            assert np.array_equal(x[o + 4 : o + 7], r.omega[k, i])


def _mrp_states(states: np.ndarray, n: int) -> np.ndarray:
    """The python-control formation's states in the compiled simulator's layout [sigma_d, (sigma_i, omega_i)]."""
    X = np.asarray(states, dtype=float)
    rows = []
    for k in range(X.shape[1]):
        x = X[:, k]
        row = [mrp_of_quat(x[:4])]
        for i in range(n):
            o = 4 + 7 * i
            row += [mrp_of_quat(x[o : o + 4]), x[o + 4 : o + 7]]
        rows.append(np.concatenate(row))
    return np.array(rows).T


def _compiled_states(result) -> np.ndarray:
    return np.concatenate(
        [result.sigma_d.T]
        + [np.concatenate([result.sigma[:, i].T, result.omega[:, i].T]) for i in range(result.n_agents)]
    )


def test_input_output_response_agrees_with_the_compiled_simulator(paper):
    """``ct.input_output_response(formation(paper), ...)`` vs ``fsmctl.simulate``: Case 1 (2 N m limit), boundary
    layer 0.05 (so SciPy's adaptive RK45 copes), 2 s.

    Tolerances.  python-control's plants integrate quaternions (its solvers cannot reset MRP states), so states
    are compared after mapping to shadow-set MRPs (same attitude, the compiled simulator's layout).  Against the compiled *adaptive*
    loop (dopri45, rtol 1e-11) the difference is the two solvers' error: 1.5e-8 measured, 1e-6 allowed.
    Against the default fixed-step RK4 at 1 ms it is 7.0e-5: the command is ~1e4 N m and saturated, so a torque
    component flips between +2 and -2 N m within ~1e-5 s, a near-discontinuity in time that a fixed step
    integrates with an O(dt) error; 2e-4 allowed.  Applied torques at the output times agree exactly.
    """
    s = paper.replace(
        controller={"boundary_layer": 0.05}, simulation={"t_final": 2.0, "dt": 1e-3, "output_interval": 0.05}
    )
    rk4 = fsmctl.simulate(s)
    dopri = fsmctl.simulate(s.replace(simulation={"integrator": "dopri45", "rtol": 1e-11, "atol": 1e-13}))
    sys = fsmctl.formation(s)
    resp = ct.input_output_response(
        sys, rk4.time, 0, initial_state(s), solve_ivp_method="RK45", solve_ivp_kwargs={"rtol": 1e-9, "atol": 1e-11}
    )
    assert resp.success
    states = _mrp_states(resp.states, s.n_agents)
    assert np.allclose(fsmctl.plugin.iosys.mrp_state(resp.states), states, rtol=0, atol=1e-15)
    for result, tol in ((dopri, 1e-6), (rk4, 2e-4)):
        assert np.abs(states - _compiled_states(result)).max() < tol
        tr = result.to_time_response(errors=False)
        y_io = resp.outputs.reshape(s.n_agents, 3, 3, -1)
        y_c = tr.outputs.reshape(s.n_agents, 3, 3, -1)
        assert np.abs(y_io[:, 2] - y_c[:, 2]).max() <= 1e-9  # torques
        assert np.abs(y_io[:, 1] - y_c[:, 1]).max() < tol  # rates
        assert np.abs(y_io[:, 0] - y_c[:, 0]).max() < tol  # attitudes (both in the shadow set)
    err_dopri = np.abs(states - _compiled_states(dopri)).max()
    assert err_dopri < np.abs(states - _compiled_states(rk4)).max()


def test_formation_of_a_law_with_a_state_agrees_with_the_compiled_simulator(paper, pi_law):
    """``formation(scenario)`` flies ``scenario.law``: a PI law with a state (1 s of Case 1, 2 N m limit) against
    the compiled engine's adaptive loop (rtol 1e-11); 1.0e-6 measured (states), 1e-5 allowed."""
    s = paper.replace(
        controller={"law": str(pi_law.folder), "parameters": {"K": 3.0}},
        simulation={"t_final": 1.0, "output_interval": 0.05},
    )
    ref = fsmctl.simulate(s.replace(simulation={"integrator": "dopri45", "rtol": 1e-11, "atol": 1e-13}))
    loop = fsmctl.formation(s)
    n = s.n_agents
    assert loop.nstates == 4 + 7 * n + 3 * n
    assert loop.state_labels[4 + 7 * n :][:3] == ["ctrl1_integral[0]", "ctrl1_integral[1]", "ctrl1_integral[2]"]
    assert float(loop.params["ctrl1_K"]) == 3.0 and float(loop.params["ctrl1_Ki"]) == 0.2
    x0 = initial_state(s)
    assert np.array_equal(x0[4 + 7 * n :], np.full(3 * n, 0.01))
    resp = ct.input_output_response(
        loop, ref.time, 0, x0, solve_ivp_method="RK45", solve_ivp_kwargs={"rtol": 1e-9, "atol": 1e-11}
    )
    assert resp.success
    assert np.abs(mrp_state(resp.states, n) - _compiled_states(ref)).max() < 1e-5
    z = resp.states[4 + 7 * n :].reshape(n, 3, -1)
    assert np.abs(z - ref.z.transpose(1, 2, 0)).max() < 1e-5 and np.abs(ref.z).max() > 0.1
    torques = resp.outputs.reshape(n, 3, 3, -1)[:, 2]
    assert np.abs(torques - ref.u.transpose(1, 2, 0)).max() < 1e-4


@pytest.mark.filterwarnings("ignore:Tight layout not applied")
def test_time_response_plots(paper, tmp_path):
    """The compiled run's time response plots grouped (one axes per signal group, agents as colours), and
    python-control's own plot still shows one axes per signal."""
    import dataclasses

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from fsmctl.model.time_response import FormationResponse, agent_color, formation_response

    # two agents keep the full python-control plot fast; the paper's six agents plot the same way
    two = dataclasses.replace(paper, agents=paper.agents[:2], topology=fsmctl.model.topology.ring(2, 8.0, 5.0))
    r = fsmctl.simulate(two.replace(simulation={"t_final": 1.0, "output_interval": 0.01}))
    tr = formation_response(r.to_time_response(errors=False))
    assert isinstance(tr, ct.TimeResponseData) and isinstance(tr, FormationResponse)
    assert tr.time.shape == r.time.shape and tr.outputs.shape == (18, r.time.size)
    cplt = tr.plot()
    assert cplt.axes.shape == (3, 1) and [len(lines) for lines in cplt.lines[:, 0]] == [6, 6, 6]
    cplt.figure.savefig(tmp_path / "response.png")
    assert (tmp_path / "response.png").stat().st_size > 1000
    # axes 2 is the torque: its first line is sc1_tau[0], the applied torque, in agent 0's colour
    line = cplt.lines[2, 0][0]
    assert line.get_label() == "sc1_tau[0]" and line.get_color() == agent_color(0)
    assert np.array_equal(line.get_ydata(), r.u[:, 0, 0])
    plt.close("all")
    full = ct.time_response_plot(tr)  # python-control's plot: every output on its own axes
    assert full.axes.size == 18
    assert full.axes.ravel()[6].get_ylabel() == "sc1_tau[0]"
    assert np.array_equal(full.lines.ravel()[6][0].get_ydata(), r.u[:, 0, 0])
    plt.close("all")
