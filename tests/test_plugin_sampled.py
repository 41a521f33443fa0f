"""Sampled-data loops in python-control (issue 24): the discrete-time loop of a scenario with
``simulation.control_period > 0`` against the compiled simulator's ``control_period``, and python-control's ``dt``.

Why the tolerances: the sampled loop and :func:`fsmctl.simulate` hold the same torque over each period and take
the same RK4 steps of ``simulation.dt``; they differ only in how the attitude is carried (quaternions here, MRPs
there) and in summation order.  Measured over 5 s: 3e-15 (sigma), 2e-16 (omega), 4e-14 (torque), 2e-12 (an
integral law state, summed once per period here, once per step there).  The bounds below are 1e-10 / 1e-8:
far above that rounding, far below any modelling difference (one period of hold is ~1e-3 in sigma).
"""

from __future__ import annotations

import control as ct
import numpy as np
import pytest

import fsmctl
from fsmctl.errors import InputError
from fsmctl.model.laws import LawSwitchWarning
from fsmctl.plugin import discrete_law_controller, link, rate_gyro, sampled_formation, star_tracker, zoh
from fsmctl.plugin.iosys import quaternion_from_mrp


def _agreement(s):
    loop = fsmctl.formation(s)
    T = s.simulation.control_period
    N = round(s.simulation.t_final / T)
    r = ct.input_output_response(loop, np.arange(N + 1) * T, 0, fsmctl.initial_state(s), return_x=True)
    eng = fsmctl.simulate(s.replace(simulation={"output_interval": T}))
    labels = list(loop.output_labels)

    def rows(sig):
        return [labels.index(f"sc{i}_{sig}[{k}]") for i in range(1, s.n_agents + 1) for k in range(3)]

    out = {
        "sigma": np.abs(r.outputs[rows("sigma")].T - eng.sigma.reshape(N + 1, -1)).max(),
        "omega": np.abs(r.outputs[rows("omega")].T - eng.omega.reshape(N + 1, -1)).max(),
        "tau": np.abs(r.outputs[rows("tau")].T - eng.u.reshape(N + 1, -1)).max(),
    }
    if s.law.n_states:
        z = [k for k, label in enumerate(loop.state_labels) if label.startswith("ctrl")]
        out["z"] = np.abs(r.states[z].T - eng.z.reshape(N + 1, -1)).max()
    return loop, out


def test_the_sampled_loop_of_a_scenario_is_the_compiled_control_period():
    s = fsmctl.paper_scenario("1").replace(simulation={"t_final": 3.0, "control_period": 0.1})
    loop, err = _agreement(s)
    assert loop.dt == 0.1 and loop.nstates == 46
    assert err["sigma"] < 1e-10 and err["omega"] < 1e-10 and err["tau"] < 1e-8


def test_law_states_are_stepped_as_the_compiled_loop_steps_them():
    with pytest.warns(LawSwitchWarning):
        s = fsmctl.paper_scenario("1").with_law("adaptive_fsm")  # the paper's delta is not adaptive_fsm's
    s = s.replace(simulation={"t_final": 3.0, "control_period": 0.05})
    _, err = _agreement(s)
    assert s.law.n_states > 0
    assert err["sigma"] < 1e-10 and err["omega"] < 1e-10 and err["tau"] < 1e-8 and err["z"] < 1e-8


def test_the_scenarios_sensors_and_wheels_are_in_the_sampled_loop():
    s = fsmctl.load_scenario("paper-hardware").replace(
        simulation={"t_final": 2.0}, links={"delay": 0.0, "loss_probability": 0.0}
    )
    loop, err = _agreement(s)
    assert any(name.startswith("sensor") for name in loop.syslist_index)
    assert err["sigma"] < 1e-10 and err["omega"] < 1e-10 and err["tau"] < 1e-8


def test_what_the_sampled_loop_refuses_is_one_line():
    hw = fsmctl.load_scenario("paper-hardware")
    with pytest.raises(InputError, match="imperfect links"):
        fsmctl.formation(hw)
    s = fsmctl.paper_scenario("1").replace(simulation={"control_period": 0.1})
    lag = ct.ss(
        -np.eye(3),
        np.eye(3),
        np.eye(3),
        0,
        inputs=[f"tau_command[{k}]" for k in range(3)],
        outputs=[f"tau[{k}]" for k in range(3)],
    )
    with pytest.raises(InputError, match="discrete time"):
        fsmctl.formation(s, actuators=lag)
    with pytest.raises(InputError, match="control_period is 0"):
        sampled_formation(fsmctl.paper_scenario("1"))


def test_zoh_holds_the_input_and_keeps_the_parameters():
    J = np.diag([2.0, 3.0, 4.0])
    sc = fsmctl.spacecraft(J, name="sc")
    d = zoh(sc, 0.1, step=0.01, name="sc")
    assert d.dt == 0.1 and sorted(d.params) == ["sc_J", "sc_disturbance", "sc_owner"]
    x0 = np.concatenate([quaternion_from_mrp([0.0, 0.0, 0.0]), [0.0, 0.0, 0.5]])
    # a torque about a principal axis while spinning about it: omega_z grows linearly, exactly (RK4 is exact there)
    x1 = d.dynamics(0.0, x0, [0.0, 0.0, 2.0])
    assert x1[6] == pytest.approx(0.5 + 2.0 / 4.0 * 0.1, abs=1e-15)
    # the rotation about z by the integral of omega_z: 0.05 + 0.0025 rad (RK4 error at h = 0.01 s far below 1e-9)
    assert 2 * np.arctan2(x1[3], x1[0]) == pytest.approx(0.0525, abs=1e-9)
    assert zoh(sc, 0.1).name == "sc$sampled"
    with pytest.raises(InputError, match="multiple"):
        zoh(sc, 0.1, step=0.03)
    with pytest.raises(InputError, match="period"):
        zoh(sc, True)
    with pytest.raises(InputError, match="not continuous"):
        zoh(d, 0.1)


def test_a_discrete_law_advances_its_states_by_the_held_rate():
    ctrl = discrete_law_controller("pid", np.eye(3), dt=0.1, name="c")
    cont = fsmctl.law_controller("pid", np.eye(3), name="c")
    u = np.concatenate([[0.1, -0.2, 0.05], np.zeros(12)])
    z = np.array([0.01, 0.02, 0.03])
    assert ctrl.dt == 0.1
    np.testing.assert_array_equal(ctrl.dynamics(0.0, z, u), z + 0.1 * cont.dynamics(0.0, z, u))
    np.testing.assert_array_equal(ctrl.output(0.0, z, u), cont.output(0.0, z, u))


def test_sensor_and_link_dt_mean_what_python_control_means():
    assert star_tracker([1e-4] * 3, 0.1, horizon=1.0, dt=0.1).dt == 0.1  # the period itself: accepted
    assert star_tracker([1e-4] * 3, 0.1, horizon=1.0, dt=True).dt == 0.1
    assert star_tracker([1e-4] * 3, 0.1, horizon=1.0).dt == 0.1
    unspecified = rate_gyro(0.0, 0.0, [1e-3, 0.0, 0.0], 0.1, horizon=1.0, dt=None)
    assert unspecified.dt is None
    # unspecified: the held rule, which is the sample at an instant and held between instants
    assert unspecified.output(0.15, [], [0.0, 0.0, 0.0])[0] == pytest.approx(1e-3, abs=1e-15)
    assert rate_gyro(0.0, 0.0, [0.0] * 3, 0.1, horizon=1.0, dt=0).dt == 0
    assert link(0.0, 0.0, 0.1, horizon=1.0, dt=0.1).dt == 0.1
    assert link(0.0, 0.0, 0.1, horizon=1.0, dt=None).dt == 0.1
    with pytest.raises(InputError, match="dt"):
        link(0.0, 0.0, 0.1, horizon=1.0, dt=0)
    with pytest.raises(InputError, match="dt"):
        rate_gyro(0.0, 0.0, [0.0] * 3, 0.1, horizon=1.0, dt=0.2)
