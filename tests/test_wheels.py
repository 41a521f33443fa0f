"""Reaction wheels in the compiled loop, against closed forms, conservation laws and the NumPy distribution rule.

Independent routes: the closed-form spin-up and spin-down of a hub about a principal axis (derived in the
docstrings below from the gyrostat equations of Schaub & Junkins eq 4.146), the inertial angular momentum
``[NB] (J omega + sum_k J_s Omega_k g_k)`` with the DCM of the NumPy oracle (``tests/oracle_numpy.py``, through Euler
parameters, not the generated code), and :func:`fsmctl.model.actuators.distribute` (a NumPy transcription held bit-identical to the C rule).
The Basilisk cross-check is in ``tests/test_wheels_basilisk.py``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from formations import single_spacecraft
from oracle_numpy import mrp_to_dcm as dcm  # [BN] through Euler parameters (an independent route)

import fsmctl
from fsmctl.errors import EnvironmentProblem
from fsmctl.model.actuators import body_torque_capacity, distribute, distribution_matrix
from fsmctl.model.problem import pack
from fsmctl.model.scenario import ActuatorSettings, ScenarioError
from fsmctl.simulation import simulator

DIAG = ((100.0, 0.0, 0.0), (0.0, 150.0, 0.0), (0.0, 0.0, 200.0))


def inertial_momentum(result, agent: int) -> np.ndarray:
    """(T, 3) total angular momentum of one spacecraft in the inertial frame."""
    sc = result.scenario
    J = sc.agents[agent].J_true
    G = sc.actuator.spin_axes()
    Js = sc.actuator.per_wheel("spin_inertia")
    out = []
    for k in range(result.time.size):
        h_body = J @ result.omega[k, agent] + G @ (Js * result.wheel_speed[k, agent])
        out.append(dcm(result.sigma[k, agent]).T @ h_body)
    return np.array(out)


def test_distribution_in_the_loop_is_the_numpy_rule_bit_for_bit():
    """At every control instant the held wheel commands are distribute(law command), including one wheel at its
    limit (max_torque below the minimum-norm share: the scale factor > 1)."""
    s = single_spacecraft(
        law_parameters={"bias": [0.05, 0.0, -0.02], "amplitude": [0.0, 0.1, 0.05], "frequency": 0.5},
        actuator={"kind": "reaction_wheels", "spin_inertia": 0.1, "max_torque": 0.03},
    )
    r = fsmctl.simulate(s)
    P = distribution_matrix(s.actuator.spin_axes())
    limit = s.actuator.per_wheel("max_torque")
    scaled = 0
    for k in range(r.time.size):
        w, scale = distribute(r.u_unsaturated[k, 0], P, limit)
        np.testing.assert_array_equal(w, r.wheel_torque[k, 0])
        scaled += scale > 1
        assert np.all(np.abs(w) <= limit * (1 + 1e-15))
    assert scaled > r.time.size // 2  # the limit is active most of the time: the scaling path is exercised
    assert r.saturated_time[0] > 0  # ... and reported as saturation


def test_distribution_keeps_the_direction_and_realises_the_command():
    rng = np.random.default_rng(1)
    G = ActuatorSettings(kind="reaction_wheels").spin_axes()
    P = distribution_matrix(G)
    for _ in range(100):
        u = rng.normal(size=3)
        w, scale = distribute(u, P, np.full(4, 0.5))
        np.testing.assert_allclose(-G @ w, u / scale, atol=1e-14)  # the wheels' reaction is the (scaled) command
        if scale > 1:
            assert math.isclose(np.max(np.abs(w)), 0.5, rel_tol=1e-14)  # the most loaded wheel at its limit
    cap = body_torque_capacity(G, np.full(4, 0.2))
    # pyramid at 54.74 deg: along a body axis the minimum-norm split gives each wheel |u| sqrt(3)/4, so the axis
    # capacity is 0.2 * 4 / sqrt(3) = 0.4619 N m
    np.testing.assert_allclose(cap["per_axis"], [0.8 / math.sqrt(3)] * 3, rtol=1e-12)
    assert cap["min"] <= cap["per_axis"][0] <= cap["max"]


def _spin(t_final, *, torque_z=0.0, Js=0.05, max_speed="inf", viscous=0.0, coulomb=0.0, band=0.1, Omega0=0.0):
    return single_spacecraft(
        J=DIAG,
        sigma0=(0.0, 0.0, 0.0),
        omega0=(0.0, 0.0, 0.0),
        t_final=t_final,
        control_period=0.1,
        law_parameters={"bias": [0.0, 0.0, torque_z]},
        actuator={
            "kind": "reaction_wheels",
            "layout": "orthogonal",
            "spin_inertia": Js,
            "max_speed": max_speed,
            "viscous_friction": viscous,
            "coulomb_friction": coulomb,
            "coulomb_band": band,
            "initial_speed": [0.0, 0.0, Omega0],
        },
    )


def test_closed_form_spin_up_about_a_principal_axis():
    """Orthogonal wheels, body torque c about z from rest: wheel 3 gets u = -c.  Along z,
    (J_z - J_s) omega_dot = c, so omega_z = c t / (J_z - J_s); Omega_dot = u/J_s - omega_dot gives
    Omega_3 = -c t (1/J_s + 1/(J_z - J_s)); the hub turns by theta = c t^2 / (2 (J_z - J_s)), sigma = tan(theta/4) z."""
    c, Js, Jz = 0.2, 0.05, 200.0
    r = fsmctl.simulate(_spin(20.0, torque_z=c, Js=Js))
    t = r.time
    np.testing.assert_allclose(r.omega[:, 0, 2], c * t / (Jz - Js), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(r.wheel_speed[:, 0, 2], -c * t * (1 / Js + 1 / (Jz - Js)), rtol=1e-12, atol=1e-12)
    theta = c * t**2 / (2 * (Jz - Js))
    # RK4 on sigma_dot = G(sigma) omega with omega linear in t: local error O(dt^5), over 20 s ~1e-13
    np.testing.assert_allclose(r.sigma[:, 0, 2], np.tan(theta / 4), rtol=1e-9, atol=1e-13)
    np.testing.assert_array_equal(r.wheel_speed[:, 0, :2], 0.0)
    np.testing.assert_allclose(r.u[:, 0], np.tile([0.0, 0.0, c], (t.size, 1)), atol=1e-15)


def test_speed_limit_stops_the_wheel_and_the_hub():
    """With max_speed the wheel is not driven beyond it: its torque drops to 0, so (no friction, no disturbance)
    the hub's rate freezes too; the time at the limit counts as saturation."""
    c, Js, Jz, limit = 0.2, 0.05, 200.0, 20.0
    r = fsmctl.simulate(_spin(10.0, torque_z=c, Js=Js, max_speed=limit))
    Om = r.wheel_speed[:, 0, 2]
    rate = c * (1 / Js + 1 / (Jz - Js))  # rad/s^2 of spin-up before the limit
    t_hit = limit / rate
    before = r.time < t_hit - 1e-3
    np.testing.assert_allclose(Om[before], -rate * r.time[before], rtol=1e-12)
    after = r.time > t_hit + 1e-3
    # gated within one RK4 step of the crossing: the overshoot is at most one step's increment rate * dt
    assert np.all(np.abs(Om[after]) <= limit + rate * 1e-3 + 1e-12)
    assert np.all(np.abs(Om[after]) >= limit - 1e-12)
    np.testing.assert_allclose(r.omega[after, 0, 2], r.omega[after, 0, 2][0], rtol=1e-12)  # hub rate frozen
    np.testing.assert_array_equal(r.wheel_torque[after, 0, 2], 0.0)
    assert r.saturated_time[0] == pytest.approx(10.0 - t_hit, abs=0.11)


def test_viscous_spin_down_transfers_momentum_to_the_hub():
    """No command, wheel 3 spinning at Omega_0 with viscous friction b: u_net = -b Omega, so
    Omega = Omega_0 exp(-b t (1/J_s + 1/(J_z - J_s))) and J_z omega_z = J_s (Omega_0 - Omega) (momentum)."""
    b, Js, Jz, Om0 = 0.002, 0.05, 200.0, 100.0
    r = fsmctl.simulate(_spin(30.0, Js=Js, viscous=b, Omega0=Om0))
    decay = b * (1 / Js + 1 / (Jz - Js))
    np.testing.assert_allclose(r.wheel_speed[:, 0, 2], Om0 * np.exp(-decay * r.time), rtol=1e-10)
    np.testing.assert_allclose(Jz * r.omega[:, 0, 2], Js * (Om0 - r.wheel_speed[:, 0, 2]), rtol=1e-10, atol=1e-12)


def test_coulomb_spin_down_is_linear_outside_the_band_and_stops():
    """Coulomb friction c_f outside the band: Omega decreases linearly at c_f (1/J_s + 1/(J_z - J_s)); inside the
    band the torque is linear in Omega, so the wheel comes to rest without chattering through zero."""
    cf, Js, Jz, Om0, band = 0.005, 0.05, 200.0, 1.0, 0.1  # 9 s of linear decay, then e^-1 per second
    r = fsmctl.simulate(_spin(20.0, Js=Js, coulomb=cf, band=band, Omega0=Om0))
    slope = cf * (1 / Js + 1 / (Jz - Js))
    Om = r.wheel_speed[:, 0, 2]
    outside = Om0 - slope * r.time > band + 1e-3
    np.testing.assert_allclose(Om[outside], Om0 - slope * r.time[outside], rtol=1e-11)
    assert np.all(Om >= 0)  # never driven through zero
    assert Om[-1] < band * 1e-3


@pytest.mark.parametrize("law", ["fsm", "pid", "super_twisting", "adaptive_fsm"])
def test_every_law_conserves_the_inertial_momentum_through_the_wheels(law):
    """The wheels only exchange momentum with the hub: with no disturbance the inertial angular momentum of each
    spacecraft is constant (RK4 at 1 ms: relative drift ~1e-12 over 5 s), whatever the law and with the hold."""
    s = fsmctl.paper_scenario("1")
    quiet = [dataclasses.replace(a, disturbance=fsmctl.Sinusoid()) for a in s.agents]
    s = s.replace(
        agents=quiet,
        controller={"law": law},
        simulation={"t_final": 5.0, "control_period": 0.1},
        actuator={"kind": "reaction_wheels", "spin_inertia": 0.16, "max_torque": 0.2, "initial_speed": [10, -5, 3, 0]},
    )
    r = fsmctl.simulate(s)
    assert np.abs(r.wheel_speed).max() > 10.5  # the wheels did work
    for i in range(s.n_agents):
        H = inertial_momentum(r, i)
        drift = np.abs(H - H[0]).max() / np.linalg.norm(H[0])
        assert drift < 1e-9, (law, i, drift)


def test_wheel_outputs_and_dataset():
    s = single_spacecraft(
        law_parameters={"bias": [0.01, 0.0, 0.0]},
        actuator={"kind": "reaction_wheels", "spin_inertia": 0.1, "initial_speed": 2.0},
        t_final=1.0,
    )
    r = fsmctl.simulate(s)
    assert r.wheel_speed.shape == (r.time.size, 1, 4) and r.wheel_torque.shape == r.wheel_speed.shape
    np.testing.assert_array_equal(r.wheel_speed[0, 0], 2.0)
    np.testing.assert_allclose(r.wheel_momentum, 0.1 * r.wheel_speed)
    ds = r.to_dataset()
    assert ds["wheel_speed_rad_per_s"].attrs["units"] == "rad/s"
    assert ds["wheel_momentum_norm_N_m_s"].shape == (r.time.size, 1)
    summary = r.summary()
    assert summary["wheel_momentum_peak_N_m_s"] == pytest.approx(float(r.wheel_momentum_norm.max()))
    ideal = fsmctl.simulate(single_spacecraft(t_final=1.0))
    assert ideal.wheel_speed is None and "wheel_speed_rad_per_s" not in ideal.to_dataset()


def test_state_layout_and_initial_speeds():
    s = _spin(1.0, Omega0=7.0)
    p = pack(s)
    assert p.n_wheels == 3 and p.stride == 6 + p.n_states + 3
    np.testing.assert_array_equal(p.x0[p.agent_slice(0)][-3:], [0.0, 0.0, 7.0])
    np.testing.assert_allclose(p.hardware.J_spin[0], 0.05 * np.eye(3))


def test_bad_actuator_settings_are_one_line_errors():
    with pytest.raises(ScenarioError, match="do not span 3-D"):
        ActuatorSettings(kind="reaction_wheels", layout="custom", axes=[[1, 0], [0, 1], [0, 0]])
    with pytest.raises(ScenarioError, match="one per wheel"):
        ActuatorSettings(kind="reaction_wheels", spin_inertia=[0.1, 0.2])
    with pytest.raises(ScenarioError, match="must be > 0"):
        ActuatorSettings(kind="reaction_wheels", max_torque=0.0)


def test_without_a_compiler_the_hardware_is_refused(monkeypatch):
    """The no-compiler fallback flies the ideal loop only: hardware is refused with one line, never ignored."""
    monkeypatch.setattr(simulator, "_driver", lambda law=None: None)
    s = single_spacecraft(actuator={"kind": "reaction_wheels"}, t_final=0.2)
    with pytest.raises(EnvironmentProblem, match="compiled simulator only"):
        fsmctl.simulate(s)


def test_batched_and_scalar_wheel_kernels_fly_the_same_run():
    """The wheel kernels run FSM_LANES wheels per call (lanes across agents: 6 x 4 wheels = 6 groups, and a
    partial last group with 5 wheels per agent); the scalar CasADi functions give the same numbers."""
    from fsmctl.simulation.simulator import simulate_packed

    for layout in (
        {"layout": "pyramid"},
        {"layout": "custom", "axes": [[1, 0, 0, 1, 0], [0, 1, 0, 1, 1], [0, 0, 1, 0, 1]]},
    ):
        s = fsmctl.load_scenario("paper-hardware").replace(simulation={"t_final": 5.0}, actuator=layout)
        p = pack(s)
        if not simulator._driver(p.law).fsm_batched_available():
            pytest.skip("this build has no batched kernels")
        a, b = simulate_packed(p, kernels="batched"), simulate_packed(p, kernels="scalar")
        for k in ("sigma", "omega", "wheel_speed", "wheel_torque", "u", "sigma_measured", "omega_measured"):
            np.testing.assert_array_equal(a[k], b[k])


def test_wheels_heavier_than_the_spacecraft_are_refused():
    """J0 + delta_J is the whole spacecraft: the hub J - sum J_s g g^T must stay positive definite, else the
    gyrostat is no rigid body (a units slip in spin_inertia would otherwise fly silently)."""
    with pytest.raises(ScenarioError, match=r"^actuator\.spin_inertia: the wheels' spin inertia exceeds agent 1's"):
        single_spacecraft(J=DIAG, actuator={"kind": "reaction_wheels", "layout": "orthogonal", "spin_inertia": 150.0})
    with pytest.raises(ScenarioError, match="spin inertia exceeds"):
        single_spacecraft(J=((0.01, 0, 0), (0, 0.012, 0), (0, 0, 0.008)), actuator={"kind": "reaction_wheels"})
    single_spacecraft(J=DIAG, actuator={"kind": "reaction_wheels", "layout": "orthogonal", "spin_inertia": 99.0})


def test_adaptive_steps_with_a_wheel_speed_limit_are_warned_about():
    from fsmctl.simulation.simulator import DiscontinuousControlWarning

    s = _spin(0.5, torque_z=0.2, max_speed=20.0).replace(simulation={"integrator": "dopri45"})
    with pytest.warns(DiscontinuousControlWarning, match="wheel speed limit"):
        fsmctl.simulate(s)


def test_fsm_rhs_reports_the_wheels_torque_on_the_body():
    """The exported one-evaluation RHS returns the torque the body receives (the wheels' reaction, after the scale
    factor), the same as a run records at t = 0, not the law's command."""
    import ctypes

    from fsmctl.simulation.driver import _CProblem, _ptr

    s = fsmctl.paper_scenario("1").replace(
        simulation={"t_final": 0.01}, actuator={"kind": "reaction_wheels", "spin_inertia": 0.159, "max_torque": 0.2}
    )
    p = pack(s)
    dll = simulator._driver(p.law)
    if dll is None:
        pytest.skip("no C compiler")
    cp = _CProblem(p)
    x = np.ascontiguousarray(p.x0)
    dx, u = np.zeros_like(x), np.zeros(3 * p.n_agents)
    assert dll.fsm_rhs(ctypes.byref(cp.struct), 0.0, _ptr(x), _ptr(dx), _ptr(u)) == 0
    r = fsmctl.simulate(s)
    np.testing.assert_array_equal(u.reshape(-1, 3), r.u[0])
    assert not np.allclose(r.u[0], np.clip(r.u_unsaturated[0], -2.0, 2.0))  # the wheels deliver less


def test_dopri45_counts_wheel_saturation_at_each_step_start_like_rk4():
    """Saturation time is counted from the state at each step's start with both integrators.  A wheel chattering at
    its speed limit: RK4 at 1 ms gives 4.416 s; dopri45 (its own steps) 4.423 s.  Taking the flags at the step's end
    (the last stage) instead gave 4.433 s (hold) and 4.440 s (continuous): more than 0.01 s off."""
    s = single_spacecraft(
        law_parameters={"bias": [0.05, 0.0, 0.0]},
        actuator={
            "kind": "reaction_wheels", "layout": "orthogonal", "spin_inertia": 0.1, "max_speed": 2.0,
            "viscous_friction": 0.01,
        },
    )  # fmt: skip
    rk4 = fsmctl.simulate(s)
    with pytest.warns(simulator.DiscontinuousControlWarning):
        dopri = fsmctl.simulate(s.replace(simulation={"integrator": "dopri45"}))
    assert abs(dopri.saturated_time[0] - rk4.saturated_time[0]) < 0.01


def test_last_saturation_counts_a_wheel_at_its_torque_limit():
    """``docs/examples/wheels_and_sensors.toml``: the commands stay inside ``torque_limit`` (0.2 N m) but one wheel of
    agent 1 sits at its 0.1 N m limit for the first two control periods.  Independently of the summary's rule: the
    output times at which a recorded motor torque is at its limit (output grid = control grid here) are the
    saturated ones, their count times the control period is the engine's ``saturated_time``, and the last of them is
    the summary's ``last_saturation_s`` (the summary said ``never`` before it counted the wheels)."""
    sc = fsmctl.load_scenario("docs/examples/wheels_and_sensors.toml").replace(simulation={"t_final": 2.0})
    r = fsmctl.simulate(sc)
    assert float(np.abs(r.u_unsaturated).max()) < sc.controller.torque_limit  # the clip never acts
    max_torque = sc.actuator.per_wheel("max_torque")
    at_limit = np.isclose(np.abs(r.wheel_torque), max_torque, rtol=1e-12, atol=0.0).any(axis=2)  # (T, n)
    period = sc.simulation.control_period
    assert period == sc.simulation.output_interval
    np.testing.assert_allclose(at_limit[:-1].sum(axis=0) * period, r.saturated_time, atol=1e-9)
    hits = np.nonzero(at_limit.any(axis=1))[0]
    assert hits.size > 0
    assert r.summary()["last_saturation_s"] == pytest.approx(float(r.time[hits[-1]]), abs=1e-12)
    np.testing.assert_array_equal(r.saturated, at_limit)


def test_last_saturation_counts_a_wheel_at_its_speed_limit():
    """A wheel held at its speed limit from about 5.2 s to the end (no torque limit): the last saturation is the
    last output time, where the wheel's recorded torque is 0 and its speed at the limit."""
    r = fsmctl.simulate(_spin(10.0, torque_z=0.2, Js=0.05, max_speed=20.0))
    assert abs(r.wheel_speed[-1, 0, 2]) >= 20.0 and r.wheel_torque[-1, 0, 2] == 0.0
    assert r.summary()["last_saturation_s"] == float(r.time[-1])
