"""The python-control plug-in's flight hardware (:mod:`fsmctl.plugin.hardware`).

Oracles: the compiled simulator (:func:`fsmctl.simulate`, which flies the same generated functions with its own
fixed-step RK4 and MRP state), the closed-form spin-up of a hub about a principal axis (as in
``tests/test_wheels.py``), the inertial angular momentum ``[NB]^T (J omega + h_wheels)`` with the DCM written
here from the textbook formula, and the noise the compiled loop draws (:func:`fsmctl.model.problem.pack_hardware`).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import control as ct
import numpy as np
import pytest
from formations import single_spacecraft, with_agents
from oracle_numpy import mrp_to_dcm as dcm  # [BN] through Euler parameters (an independent route)

import fsmctl
from fsmctl.errors import InputError
from fsmctl.model.problem import pack
from fsmctl.model.scenario import ActuatorSettings
from fsmctl.plugin.hardware import link, rate_gyro, reaction_wheel_spacecraft, reaction_wheel_state, star_tracker
from fsmctl.plugin.iosys import law_controller, quaternion_from_mrp, reference_generator, spacecraft

ECHO = str(Path(__file__).parent / "data" / "laws" / "echo_time.py")
J_FULL = np.array([[100.0, 1.0, 2.0], [1.0, 150.0, 1.0], [2.0, 1.0, 200.0]])
TIGHT = {"solve_ivp_method": "RK45", "solve_ivp_kwargs": {"rtol": 1e-11, "atol": 1e-13}}


def rows(sys: ct.InputOutputSystem, signal: str) -> list[int]:
    """Indices of the outputs ``signal[0..]`` of a system."""
    return [k for k, label in enumerate(sys.output_labels) if label.startswith(f"{signal}[")]


def one_line(exc: pytest.ExceptionInfo) -> str:
    text = str(exc.value)
    assert text and "\n" not in text, text
    return text


# ----------------------------------------------------------------------------- reaction wheels


@pytest.fixture(scope="module")
def flown():
    """The compiled loop flying an open-loop torque through a pyramid of four wheels, with a sinusoidal
    disturbance: the command exceeds the wheels' torque limit (the distribution scales it), viscous and Coulomb
    friction act, one wheel starts inside the Coulomb band and one crosses zero speed."""
    s = single_spacecraft(
        law_parameters={"bias": [0.05, 0.0, -0.02], "amplitude": [0.0, 0.1, 0.05], "frequency": 0.5},
        actuator={
            "kind": "reaction_wheels",
            "spin_inertia": 0.1,
            "max_torque": 0.03,
            "viscous_friction": 1e-3,
            "coulomb_friction": 2e-3,
            "coulomb_band": 0.5,
            "initial_speed": [40.0, -25.0, 3.0, 0.2],
        },
    )
    d = fsmctl.Sinusoid(amplitude=[0.01, 0.02, 0.0], frequency=[0.3, 0.7, 0.0], offset=[0.0, 0.0, 0.005])
    s = with_agents(s, [dataclasses.replace(s.agents[0], disturbance=d)])
    return s, fsmctl.simulate(s)


def test_wheel_plant_flies_like_the_compiled_simulator(flown):
    """Fed the compiled loop's held body-torque commands (and given the agent's disturbance) (piecewise constant: one response per control period,
    the state carried over), the plant follows the compiled run.  The compiled RK4 (dt = 1e-3) and SciPy's RK45
    (rtol 1e-11) each err by ~1e-13 on these slow dynamics: measured differences 5e-15 (sigma), 1e-16 rad/s
    (omega), 2e-13 rad/s (wheel speeds up to 40 rad/s); allowed 1e-12, 1e-13, 1e-10.  At the control instants the
    wheels' reaction ``tau`` and the motor torques are the compiled run's to rounding (same state, same functions)."""
    s, r = flown
    assert s.actuator.per_wheel("max_torque")[0] < np.abs(r.u_unsaturated).max()  # the scaling path is flown
    a = s.agents[0]
    plant = reaction_wheel_spacecraft(a.J_true, s.actuator, disturbance=a.disturbance, name="sc")
    x = reaction_wheel_state(plant, a.sigma0, a.omega0, s.actuator.per_wheel("initial_speed"))
    y = [plant.output(0.0, x, np.r_[r.u_unsaturated[0, 0], np.zeros(7)])]
    for k in range(r.time.size - 1):
        u = np.r_[r.u_unsaturated[k, 0], np.zeros(7)]  # the law's command at instant k, held to k + 1
        resp = ct.input_output_response(plant, r.time[k : k + 2], np.tile(u[:, None], 2), x, **TIGHT)
        x = resp.states[:, -1]
        y.append(resp.outputs[:, -1])
    y = np.array(y)
    np.testing.assert_allclose(y[:, 0:3], r.sigma[:, 0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(y[:, 3:6], r.omega[:, 0], rtol=0, atol=1e-13)
    np.testing.assert_allclose(y[:, 6:10], r.wheel_speed[:, 0], rtol=0, atol=1e-10)
    assert np.ptp(r.wheel_speed[:, 0, 3]) > 0.4 and r.wheel_speed[0, 0, 3] * r.wheel_speed[-1, 0, 3] < 0
    # outputs at the instants, from the compiled run's state and the new command
    for k in range(r.time.size):
        xk = reaction_wheel_state(plant, r.sigma[k, 0], r.omega[k, 0], r.wheel_speed[k, 0])
        out = plant.output(r.time[k], xk, np.r_[r.u_unsaturated[k, 0], np.zeros(7)])
        np.testing.assert_allclose(out[10:13], r.u[k, 0], rtol=1e-14, atol=1e-17)
        np.testing.assert_allclose(out[16:20], r.wheel_torque[k, 0], rtol=1e-14, atol=1e-17)
        G, Js = s.actuator.spin_axes(), s.actuator.per_wheel("spin_inertia")
        np.testing.assert_allclose(out[13:16], G @ (Js * r.wheel_speed[k, 0]), rtol=1e-14, atol=1e-15)


def test_angular_momentum_is_conserved_without_external_torque():
    """A tumbling hub (full inertia) driven by a varying command through a friction-loaded pyramid: the wheels
    trade momentum with the hub, the inertial total ``[NB]^T (J omega + h_wheels)`` stays (solver rtol 1e-11:
    1e-9 relative allowed); an external torque ``d`` fixed in the body changes it at the rate ``[NB]^T d``."""
    act = {"spin_inertia": 0.05, "max_torque": 0.04, "viscous_friction": 2e-3, "coulomb_friction": 1e-3}
    plant = reaction_wheel_spacecraft(J_FULL, act, name="sc")
    x0 = reaction_wheel_state(plant, [0.3, -0.2, 0.5], [0.05, -0.1, 0.08], [50.0, -30.0, 0.0, 10.0])
    T = np.linspace(0.0, 40.0, 401)
    U = np.zeros((plant.ninputs, T.size))
    U[:3] = 0.06 * np.sin(np.outer([0.3, 0.5, 0.7], T))
    r = ct.input_output_response(plant, T, U, x0, **TIGHT)
    h = rows(plant, "h_wheels")
    H = np.array([dcm(r.outputs[:3, k]).T @ (J_FULL @ r.outputs[3:6, k] + r.outputs[h, k]) for k in range(T.size)])
    assert np.ptp(np.linalg.norm(r.outputs[h], axis=0)) > 0.5  # the wheels exchanged momentum with the hub
    assert np.linalg.norm(r.outputs[:3], axis=0).max() <= 1 + 1e-12  # shadow set
    np.testing.assert_allclose(H, np.tile(H[0], (T.size, 1)), rtol=0, atol=1e-9 * np.linalg.norm(H[0]))
    # with d fixed in the inertial frame (here along N's x, fed in body components) H grows by d t
    d_n = np.array([0.02, 0.0, 0.0])
    closed = ct.interconnect(
        [
            plant,
            ct.nlsys(
                None,
                lambda t, x, u, p: np.r_[0.06 * np.sin(np.array([0.3, 0.5, 0.7]) * t), dcm(u[:3]) @ d_n],
                inputs=["sigma[0]", "sigma[1]", "sigma[2]"],
                outputs=["u_command[0]", "u_command[1]", "u_command[2]", "d[0]", "d[1]", "d[2]"],
                name="push",
            ),
        ],
        inputs=[],
        ignore_inputs=["sc.u_wheels"],
        outputs=plant.output_labels,
    )
    r = ct.input_output_response(closed, T[:101], 0, x0, **TIGHT)
    H = np.array([dcm(r.outputs[:3, k]).T @ (J_FULL @ r.outputs[3:6, k] + r.outputs[h, k]) for k in range(101)])
    np.testing.assert_allclose(H - H[0], np.outer(T[:101], d_n), rtol=0, atol=1e-9 * np.linalg.norm(H[0]))


def test_speed_limit_stops_the_wheel_and_the_hub():
    """Orthogonal wheels, body torque c about z from rest: ``Omega_3 = -c t (1/J_s + 1/(J_z - J_s))`` until the
    limit (closed form, tests/test_wheels.py), then the motor is off: the wheel holds the limit (to the solver's
    event resolution, 1e-6 allowed), the hub's rate freezes, the motor-torque output is 0."""
    c, Js, Jz, limit = 0.2, 0.05, 200.0, 20.0
    plant = reaction_wheel_spacecraft(
        np.diag([100.0, 150.0, Jz]), {"layout": "orthogonal", "spin_inertia": Js, "max_speed": limit}
    )
    T = np.linspace(0.0, 10.0, 101)
    U = np.zeros((plant.ninputs, T.size))
    U[2] = c
    r = ct.input_output_response(plant, T, U, reaction_wheel_state(plant), **TIGHT)
    Om, wz = r.outputs[8], r.outputs[5]
    rate = c * (1 / Js + 1 / (Jz - Js))
    before, after = T < limit / rate - 1e-3, T > limit / rate + 1e-3
    np.testing.assert_allclose(Om[before], -rate * T[before], rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(Om[after], -limit, rtol=0, atol=1e-6)
    np.testing.assert_allclose(wz[after], c * (limit / rate) / (Jz - Js), rtol=1e-6)
    np.testing.assert_array_equal(r.outputs[-1, after], 0.0)  # wheel_torque[2]: the motor is off
    np.testing.assert_allclose(r.outputs[-1, before], -c, rtol=1e-15)


def test_parameters_are_the_actuators_and_params_override_them():
    plant = reaction_wheel_spacecraft(
        np.diag([100.0, 150.0, 200.0]), {"layout": "orthogonal", "max_torque": 0.1}, name="w"
    )
    assert sorted(plant.params) == [
        "w_J",
        "w_axes",
        "w_coulomb_band",
        "w_coulomb_friction",
        "w_disturbance",
        "w_max_speed",
        "w_max_torque",
        "w_owner",
        "w_spin_inertia",
        "w_viscous_friction",
    ]
    np.testing.assert_array_equal(plant.params["w_max_torque"], [0.1, 0.1, 0.1])
    x = reaction_wheel_state(plant)
    u = [0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    np.testing.assert_allclose(plant.output(0.0, x, u)[9:12], [0.0, 0.0, 0.1], atol=1e-16)
    np.testing.assert_allclose(plant.output(0.0, x, u, params={"w_max_torque": 0.02})[9:12], [0, 0, 0.02], atol=1e-16)
    # a spinning wheel with viscous friction b: its reaction on the hub is +b Omega (u_net = -b Omega)
    x = reaction_wheel_state(plant, Omega0=[0.0, 0.0, 10.0])
    out = plant.output(0.0, x, np.zeros(9), params={"w_viscous_friction": [0.0, 0.0, 1e-3], "w_coulomb_friction": 0.0})
    np.testing.assert_allclose(out[9:12], [0.0, 0.0, 1e-2], rtol=1e-15)
    # the disturbance parameter adds d(t) to the input d (the generated disturbance_torque)
    d = fsmctl.Sinusoid(amplitude=[0.1, 0.0, 0.0], frequency=[2.0, 0.0, 0.0], offset=[0.0, 0.01, 0.0])
    pushed = reaction_wheel_spacecraft(
        np.diag([100.0, 150.0, 200.0]), {"layout": "orthogonal"}, disturbance=d, name="p"
    )
    plain = reaction_wheel_spacecraft(np.diag([100.0, 150.0, 200.0]), {"layout": "orthogonal"}, name="q")
    x = reaction_wheel_state(plain, [0.1, 0.2, 0.3], [0.01, 0.02, -0.03], [1.0, 2.0, 3.0])
    u = np.array([0.01, -0.02, 0.03, 0.001, 0.002, 0.003, 0.0, 0.0, 0.0])
    np.testing.assert_allclose(
        pushed.dynamics(0.5, x, u), plain.dynamics(0.5, x, u + np.r_[0, 0, 0, d(0.5), 0, 0, 0]), rtol=1e-14, atol=1e-18
    )
    np.testing.assert_array_equal(pushed.params["p_disturbance"], d.params())


# ----------------------------------------------------------------------------- interconnection


def test_wheel_plant_closes_the_loop_with_a_law_and_with_a_static_gain():
    """The plant wired with ``interconnect`` to the paper's law (``law_controller``, boundary layer 0.05) and to a
    python-control static PD gain: both bring the attitude to the (fixed) reference with the wheels' torque
    limit active, and the wheels end up holding the initial momentum (hub at rest, attitude near identity:
    ``h_wheels = [BN] H_N`` with ``H_N = [NB](sigma0) J omega0``; solver rtol 1e-8, 1e-6 relative allowed).

    The limit is checked where it acts, on the wheels: the minimum-norm wheel torques the command asks for
    (``pinv(G_s) u_command``, computed here) exceed 0.5 N m by a margin (law 0.65, static gain 4.5), and at
    every such sample the largest delivered wheel torque is the limit.  (The body torque is no test of the
    limit: the law's own ``u_max`` is also 0.5, so its largest body torque is 0.5 to the last bit.)"""
    J = np.diag([100.0, 150.0, 200.0])
    act = ActuatorSettings(kind="reaction_wheels", spin_inertia=0.05, max_torque=0.5)
    sigma0, omega0 = np.array([0.2, -0.1, 0.15]), np.array([0.01, -0.01, 0.005])
    H_N = dcm(sigma0).T @ (J @ omega0)  # wheels at rest
    T = np.linspace(0.0, 120.0, 241)
    pd = ct.ss(
        [],
        [],
        [],
        -np.hstack([20.0 * np.eye(3), 60.0 * np.eye(3)]),
        inputs=[*(f"sigma[{k}]" for k in range(3)), *(f"omega[{k}]" for k in range(3))],
        outputs=[f"tau[{k}]" for k in range(3)],
        name="ctrl",
    )
    fsm = law_controller("fsm", J, parameters={"boundary_layer": 0.05}, u_max=0.5, name="ctrl")
    for ctrl in (fsm, pd):
        plant = reaction_wheel_spacecraft(J, act, name="sc")
        x0 = reaction_wheel_state(plant, sigma0, omega0)
        systems = [plant, ctrl]
        connections = [["ctrl.sigma", "sc.sigma"], ["ctrl.omega", "sc.omega"], ["sc.u_command", "ctrl.tau"]]
        if ctrl is fsm:
            systems.append(reference_generator(fsmctl.Sinusoid(), name="reference"))
            connections += [[f"ctrl.{v}", f"reference.{v}"] for v in ("sigma_d", "omega_d", "omega_d_dot")]
            x0 = np.r_[x0, quaternion_from_mrp([0.0, 0.0, 0.0])]
        loop = ct.interconnect(
            systems,
            connections=connections,
            inputs=[],
            outlist=["sc.sigma", "sc.omega", "sc.h_wheels", "sc.wheel_torque", "ctrl.tau"],
            check_unused=False,
        )
        r = ct.input_output_response(
            loop, T, 0, x0, solve_ivp_method="RK45", solve_ivp_kwargs={"rtol": 1e-8, "atol": 1e-10}
        )
        sigma, omega, h = r.outputs[:3], r.outputs[3:6], r.outputs[6:9]
        wheel, command = np.abs(r.outputs[9:13]), r.outputs[13:16]
        which = "law" if ctrl is fsm else "static gain"
        # the wheels' limit shaped the manoeuvre (0.5 N m per wheel, 4 wheels): the command asks clearly more
        # than a wheel can give, and where it does, one wheel gives exactly its limit (the common scale factor;
        # 1e-12 relative: the rounding of one division), never more
        demand = np.abs(np.linalg.pinv(act.spin_axes()) @ command).max(axis=0)
        over = demand > 0.5 * (1 + 1e-6)
        assert demand.max() > 1.2 * 0.5 and over.sum() >= 5, which
        np.testing.assert_allclose(wheel[:, over].max(axis=0), 0.5, rtol=1e-12, atol=0, err_msg=which)
        assert wheel.max() <= 0.5 * (1 + 1e-12), which
        assert np.linalg.norm(sigma[:, -1]) < 1e-3 * np.linalg.norm(sigma0), which
        assert np.linalg.norm(omega[:, -1]) < 1e-3 * np.linalg.norm(omega0), which
        np.testing.assert_allclose(h[:, -1], dcm(sigma[:, -1]) @ H_N - J @ omega[:, -1], rtol=1e-6, atol=1e-9)


def test_sensors_with_dt_zero_close_the_loop_on_measurements():
    """A continuous-time star tracker and rate gyro (``dt=0``: each instant's noise held) between the wheel plant
    and a static PD gain: the loop settles to the noise floor (|dtheta| ~ 1e-4 rad: sigma ~ 2.5e-5), and what
    the controller saw differs from the truth by the noise, not more."""
    plant = reaction_wheel_spacecraft(
        np.diag([100.0, 150.0, 200.0]), {"spin_inertia": 0.05, "max_torque": 0.5}, name="sc"
    )
    st = star_tracker([1e-4] * 3, 1.0, horizon=120.0, seed=1, dt=0, name="st")
    gyro = rate_gyro(1e-5, 1e-6, [1e-5, 0.0, 0.0], 1.0, horizon=120.0, seed=1, dt=0, name="gyro")
    pd = ct.ss(
        [],
        [],
        [],
        -np.hstack([20.0 * np.eye(3), 60.0 * np.eye(3)]),
        inputs=[*(f"sigma_measured[{k}]" for k in range(3)), *(f"omega_measured[{k}]" for k in range(3))],
        outputs=[f"tau[{k}]" for k in range(3)],
        name="ctrl",
    )
    assert (st.dt, gyro.dt) == (0, 0)
    loop = ct.interconnect(
        [plant, st, gyro, pd],
        connections=[
            ["st.sigma", "sc.sigma"],
            ["gyro.omega", "sc.omega"],
            ["ctrl.sigma_measured", "st.sigma_measured"],
            ["ctrl.omega_measured", "gyro.omega_measured"],
            ["sc.u_command", "ctrl.tau"],
        ],
        inputs=[],
        outlist=["sc.sigma", "st.sigma_measured"],
        check_unused=False,
    )
    T = np.linspace(0.0, 120.0, 241)
    x0 = reaction_wheel_state(plant, [0.2, -0.1, 0.15], [0.01, -0.01, 0.005])
    r = ct.input_output_response(loop, T, 0, x0, solve_ivp_method="RK45", solve_ivp_kwargs={"rtol": 1e-6, "atol": 1e-9})
    sigma, measured = r.outputs[:3], r.outputs[3:6]
    assert np.abs(sigma[:, -20:]).max() < 5e-4  # from 0.27 to the noise floor
    miss = np.abs(measured - sigma).max(axis=0)
    assert np.all(miss > 0) and miss.max() < 5 * 2e-4 / 4  # the held noise, ~|dtheta| / 4


# ----------------------------------------------------------------------------- sensors and links


@pytest.fixture(scope="module")
def sensed():
    """Two agents with a star tracker and a rate gyro (bias, walks), a seed of 7: the compiled run and its noise."""
    std = [1e-3, 2e-3, 5e-4]
    gyro = {"angle_random_walk": 1e-4, "rate_random_walk": 1e-5, "bias": [1e-4, 0.0, -2e-4]}
    s = single_spacecraft(
        n_agents=2,
        t_final=10.0,
        dt=0.1,
        control_period=0.1,
        seed=7,
        law_parameters={"bias": [0.01, -0.02, 0.005]},
        sensors={"star_tracker": {"noise_std": std}, "gyro": gyro},
    )
    return s, fsmctl.simulate(s), pack(s).hardware, std, gyro


@pytest.mark.parametrize("agent", [0, 1])
def test_sensors_reproduce_the_simulators_noise(sensed, agent):
    """Made with the run's seed and period, the star tracker and the gyro of agent ``i`` draw the noise
    :func:`fsmctl.simulate` applied to agent ``i`` (bit for bit), and fed the run's true attitude and rate they
    output what the law saw (the same generated function: equal to rounding, 1e-15 allowed)."""
    _, r, hw, std, gyro = sensed
    st = star_tracker(std, 0.1, horizon=10.0, seed=7, agent=agent, name="st")
    g = rate_gyro(
        gyro["angle_random_walk"], gyro["rate_random_walk"], gyro["bias"], 0.1, horizon=10.0, seed=7, agent=agent
    )
    assert st.dt == 0.1 and st.samples.shape == (r.time.size, 3)
    np.testing.assert_array_equal(st.samples, hw.sensor_dtheta[:, agent])
    np.testing.assert_array_equal(g.samples, hw.sensor_gyro[:, agent])
    a = ct.input_output_response(st, r.time, r.sigma[:, agent].T)
    b = ct.input_output_response(g, r.time, r.omega[:, agent].T)
    np.testing.assert_allclose(a.outputs.T, r.sigma_measured[:, agent], rtol=0, atol=1e-15)
    np.testing.assert_allclose(b.outputs.T, r.omega_measured[:, agent], rtol=0, atol=1e-15)
    # the measurement sequence at identity is the drawn rotation: sigma_measured = dtheta / 4
    zero = ct.input_output_response(st, r.time, np.zeros((3, r.time.size)))
    np.testing.assert_allclose(4 * zero.outputs.T, hw.sensor_dtheta[:, agent], rtol=1e-14, atol=0)
    assert not np.array_equal(hw.sensor_dtheta[:, 0], hw.sensor_dtheta[:, 1])  # the agent index matters
    # another seed draws other noise; dt=0 holds the sample of the latest instant
    assert not np.array_equal(star_tracker(std, 0.1, horizon=10.0, seed=8, agent=agent).samples, st.samples)
    held = rate_gyro(0.0, 0.0, [0.0] * 3, 0.1, horizon=10.0, dt=0)
    assert held.dt == 0
    held = star_tracker(std, 0.1, horizon=10.0, seed=7, agent=agent, dt=0)
    np.testing.assert_array_equal(held.output(0.37, [], np.zeros(3)), st.output(0.3, [], np.zeros(3)))
    np.testing.assert_array_equal(held.output(0.3, [], np.zeros(3)), st.output(0.3, [], np.zeros(3)))


@pytest.mark.parametrize(("delay", "loss"), [(0.0, 0.3), (0.25, 0.3), (1.0, 0.0), (0.1, 1.0)])
def test_link_delivers_what_the_compiled_loop_delivers(delay, loss):
    """Two agents broadcasting their clocks (the probe law ``echo_time``, which commands what it received): fed
    the sender's broadcasts, the link block outputs, at every instant, the clock the compiled loop delivered on
    that link, with the same losses (bit for bit) and the same delay and hold rules."""
    s = single_spacecraft(
        law=ECHO,
        n_agents=2,
        topology={"kind": "all-to-all", "k_i": 1.0, "schedule": 1.0},
        t_final=20.0,
        dt=0.01,
        control_period=0.1,
        links={"delay": delay, "loss_probability": loss},
        seed=5,
    )
    r = fsmctl.simulate(s)
    lost = pack(s).hardware.link_lost
    for e, lk in enumerate(s.topology.links):
        ln = link(delay, loss, 0.1, horizon=20.0, seed=5, index=e, size=1, signal="clock", name=f"l{e}")
        np.testing.assert_array_equal(ln.lost, lost[:, e])
        resp = ct.input_output_response(ln, r.time, r.broadcast[:, lk.sender, 0][None, :], np.zeros(ln.nstates))
        delivered = r.u_unsaturated[:, lk.receiver, 0] / 1e-6  # the probe's gain
        np.testing.assert_allclose(resp.outputs, delivered, rtol=1e-12, atol=1e-12)
    if 0 < loss < 1:
        assert 0 < lost.mean() < 1


# ----------------------------------------------------------------------------- bad inputs

J3 = np.diag([100.0, 150.0, 200.0])


@pytest.mark.parametrize(
    ("make", "words"),
    [
        (lambda: reaction_wheel_spacecraft(-J3, {}), "positive definite"),
        (lambda: reaction_wheel_spacecraft(J3, {"kind": "ideal"}), "fsmctl.spacecraft"),
        (lambda: reaction_wheel_spacecraft(J3, {"spin_inertia": -1.0}), "spin_inertia"),
        (lambda: reaction_wheel_spacecraft(J3, {"bogus": 1}), "bogus"),
        (lambda: reaction_wheel_spacecraft(J3, "wheels"), "ActuatorSettings"),
        (lambda: reaction_wheel_spacecraft(np.eye(3) * 0.01, {"spin_inertia": 0.02}), "J - J_spin"),
        (lambda: reaction_wheel_spacecraft(J3, {}, name="a.b"), "name"),
        (lambda: reaction_wheel_spacecraft(J3, {}, normalization_gain=-1.0), "normalization_gain"),
        (lambda: reaction_wheel_state(spacecraft(J3)), "reaction_wheel_spacecraft"),
        (lambda: reaction_wheel_state(reaction_wheel_spacecraft(J3, {}), Omega0=[1.0, 2.0]), "Omega0"),
        (lambda: star_tracker([1e-4, 1e-4], 0.1, horizon=1.0), "noise_std"),
        (lambda: star_tracker([1e-4, -1e-4, 0.0], 0.1, horizon=1.0), "noise_std"),
        (lambda: star_tracker([1e-4] * 3, 0.0, horizon=1.0), "period"),
        (lambda: star_tracker([1e-4] * 3, 0.1, horizon=-1.0), "horizon"),
        (lambda: star_tracker([1e-4] * 3, 0.1, horizon=1.0, seed=-1), "seed"),
        (lambda: star_tracker([1e-4] * 3, 0.1, horizon=1.0, agent=True), "agent"),
        (lambda: star_tracker([1e-4] * 3, 0.1, horizon=1.0, dt=0.2), "dt"),
        (lambda: rate_gyro(-1.0, 0.0, [0.0] * 3, 0.1, horizon=1.0), "angle_random_walk"),
        (lambda: rate_gyro(0.0, float("nan"), [0.0] * 3, 0.1, horizon=1.0), "rate_random_walk"),
        (lambda: rate_gyro(0.0, 0.0, "bias", 0.1, horizon=1.0), "bias"),
        (lambda: link(-0.1, 0.0, 0.1, horizon=1.0), "delay"),
        (lambda: link(0.0, 1.5, 0.1, horizon=1.0), "loss_probability"),
        (lambda: link(0.0, 0.0, 0.1, horizon=1.0, size=0), "size"),
        (lambda: link(0.0, 0.0, 0.1, horizon=1.0, signal="s.x"), "signal"),
    ],
)
def test_bad_arguments_are_one_line_input_errors(make, words):
    with pytest.raises(InputError) as exc:
        make()
    assert words in one_line(exc)


def test_bad_values_at_evaluation_are_one_line_input_errors():
    plant = reaction_wheel_spacecraft(J3, {}, name="sc")
    x, u = reaction_wheel_state(plant), np.zeros(6)
    for params, words in [
        ({"sc_viscous_friction": -1.0}, "'sc_viscous_friction'"),
        ({"sc_spin_inertia": [1.0, 2.0]}, "'sc_spin_inertia'"),
        ({"sc_max_torque": "big"}, "'sc_max_torque'"),
        ({"sc_axes": np.zeros((3, 4))}, "zero spin axis"),
        ({"sc_spin_inertia": 1e3}, "J - J_spin"),
    ]:
        with pytest.raises(InputError) as exc:
            plant.dynamics(0.0, x, u, params=params)
        assert words in one_line(exc), params
    st = star_tracker([1e-4] * 3, 0.1, horizon=1.0, name="st")
    for t, words in [(1.1, "outside the drawn samples [0, 1.0] s"), (-0.1, "outside"), (0.05, "not a sample instant")]:
        with pytest.raises(InputError) as exc:
            st.output(t, [], np.zeros(3))
        assert words in one_line(exc), t
    with pytest.raises(InputError) as exc:  # a response beyond the horizon
        ct.input_output_response(link(0.0, 0.0, 0.1, horizon=1.0), np.arange(12) * 0.1, np.zeros((3, 12)), np.zeros(6))
    assert "outside" in one_line(exc)


def test_formation_flies_wheels_like_the_compiled_loop():
    """fsmctl.formation() of a wheel scenario (continuous control) integrates the same closed loop as the compiled
    simulator: attitudes agree to the solvers' tolerance, the torque output is the wheels' reaction."""
    import fsmctl
    from fsmctl.plugin.iosys import initial_state, mrp_state

    with pytest.warns(fsmctl.model.laws.LawSwitchWarning, match="law 'pid' flown instead of 'fsm'"):
        s = fsmctl.paper_scenario("1").replace(
            controller={"law": "pid"}, actuator={"kind": "reaction_wheels", "spin_inertia": 0.159, "max_torque": 0.5}
        )
    loop = fsmctl.formation(s)
    assert loop.nstates == 4 + 6 * (7 + 4) + 6 * 3  # quaternion, rate, 4 wheel speeds; 3 pid states
    T = np.linspace(0.0, 1.0, 101)
    r = ct.input_output_response(loop, T, 0, initial_state(s), solve_ivp_kwargs={"rtol": 1e-10, "atol": 1e-12})
    sim = fsmctl.simulate(s.replace(simulation={"t_final": 1.0}))
    y = r.outputs.reshape(6, 9, -1)
    # RK4 at 1 ms (local error ~1e-13 per step) against RK45 at rtol 1e-10: ~1e-10 over 1 s
    np.testing.assert_allclose(np.moveaxis(y[:, 0:3, :], -1, 0), sim.sigma, atol=1e-8)
    np.testing.assert_allclose(np.moveaxis(y[:, 6:9, :], -1, 0), sim.u, atol=1e-6)
    x = mrp_state(r.states[: 4 + 6 * 11], n_agents=6, n_wheels=4)
    np.testing.assert_allclose(x[3:6, -1], sim.sigma[-1, 0], atol=1e-8)


@pytest.mark.parametrize(
    "change",
    [
        {"simulation": {"control_period": 0.1}},
        {"simulation": {"control_period": 0.1}, "sensors": {"gyro": {"angle_random_walk": 1e-5}}},
    ],
)
def test_formation_of_a_sampled_scenario_is_discrete_time(change):
    import fsmctl

    assert fsmctl.formation(fsmctl.paper_scenario("1").replace(**change)).dt == 0.1


def test_formation_refuses_imperfect_links():
    import fsmctl
    from fsmctl.errors import InputError

    with pytest.raises(InputError, match="imperfect links"):
        fsmctl.formation(fsmctl.paper_scenario("1").replace(simulation={"control_period": 0.1}, links={"delay": 0.1}))
