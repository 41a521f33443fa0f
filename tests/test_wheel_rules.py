"""The reaction wheels' limit rules and open-loop per-wheel commands (issue 28), through the public API.

* the NumPy transcription (:func:`fsmctl.model.actuators.distribute`) against the compiled loop, bit for bit, for
  both torque-limit rules, with the law's torque and open-loop commands together;
* the rules' properties (hypothesis), checked from their definitions, not from the implementation;
* the speed gate decided at the start of each step (``speed_gate = "step_start"``) against a closed form;
* the errors for bad settings and commands, and ``fsmctl simulate`` flying a scenario file with per-wheel commands.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from formations import single_spacecraft
from hypothesis import given, settings
from hypothesis import strategies as st

import fsmctl
from fsmctl.errors import InputError
from fsmctl.model.actuators import ALLOCATIONS, distribute, distribution_matrix, sample_wheel_commands
from fsmctl.model.scenario import ScenarioError

PYRAMID = fsmctl.ActuatorSettings(kind="reaction_wheels").spin_axes()
LAW = {"bias": [0.02, 0.0, -0.01], "amplitude": [0.0, 0.04, 0.02], "frequency": 0.5}


def commanded(t: float) -> np.ndarray:
    """Per-wheel open-loop commands (1, 4): a null-space part and a wheel-1 pulse."""
    null = np.array([1.0, -1.0, 1.0, -1.0]) * 0.01 * np.cos(0.4 * t)
    return (null + np.array([0.03 if 2.0 <= t < 4.0 else 0.0, 0.0, 0.0, 0.0]))[None, :]


@pytest.mark.parametrize("allocation", list(ALLOCATIONS))
def test_the_loop_flies_the_numpy_rules_bit_for_bit(allocation):
    """At every control instant the wheel torques are distribute(law command, per-wheel command, rule), with a
    wheel at its limit much of the time (max_torque below the loads)."""
    s = single_spacecraft(
        t_final=8.0,
        dt=0.01,
        law_parameters=LAW,
        actuator={"kind": "reaction_wheels", "spin_inertia": 0.1, "max_torque": 0.02, "allocation": allocation},
    )
    r = fsmctl.simulate(s, wheel_commands=commanded)
    P, limit = distribution_matrix(s.actuator.spin_axes()), s.actuator.per_wheel("max_torque")
    loaded = 0
    for k in range(r.time.size):  # the output samples are the control instants q * 0.1 (sampled so by the engine)
        w, scale = distribute(r.u_unsaturated[k, 0], P, limit, command=commanded(k * 0.1)[0], allocation=allocation)
        np.testing.assert_array_equal(w, r.wheel_torque[k, 0])
        loaded += scale > 1
    assert loaded > r.time.size // 4  # the limit acts (measured: about half the instants)
    other = "clipped" if allocation == "scaled" else "scaled"
    w_other = [distribute(r.u_unsaturated[k, 0], P, limit, commanded(k * 0.1)[0], other)[0] for k in range(40)]
    assert not np.array_equal(np.array(w_other), r.wheel_torque[:40, 0])  # the two rules differ on this run


finite = st.floats(-10.0, 10.0, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(
    u=st.lists(finite, min_size=3, max_size=3),
    c=st.lists(finite, min_size=4, max_size=4),
    lim=st.lists(st.floats(1e-3, 5.0), min_size=4, max_size=4),
)
def test_rule_properties(u, c, lim):
    """From the definitions: the raw torques are -pinv(G) u + c; "clipped" keeps every raw torque within its
    limit and puts the others at +-limit with their sign; "scaled" is the raw vector times one factor in (0, 1],
    with the most loaded wheel at its limit when a limit is exceeded; both stay within the limits."""
    u, c, lim = np.array(u), np.array(c), np.array(lim)
    P = distribution_matrix(PYRAMID)
    raw = -P @ u + c
    clip, s1 = distribute(u, P, lim, command=c, allocation="clipped")
    scal, s2 = distribute(u, P, lim, command=c, allocation="scaled")
    ratio = np.abs(raw) / lim
    assert s1 == s2 and np.isclose(s1, max(1.0, ratio.max()), rtol=1e-12)
    inside = np.abs(raw) <= lim * (1 - 1e-12)
    np.testing.assert_allclose(clip[inside], raw[inside], rtol=1e-12, atol=1e-15)
    outside = np.abs(raw) > lim * (1 + 1e-12)
    np.testing.assert_array_equal(clip[outside], np.sign(raw[outside]) * lim[outside])
    assert np.all(np.abs(clip) <= lim) and np.all(np.abs(scal) <= lim * (1 + 1e-15))
    np.testing.assert_allclose(scal, raw / max(1.0, ratio.max()), rtol=1e-12, atol=1e-15)
    if ratio.max() > 1:
        assert np.isclose(np.max(np.abs(scal) / lim), 1.0, rtol=1e-12)


def test_step_start_gate_holds_the_decision_over_the_step():
    """One wheel along the principal axis z of a hub at rest, driven at u from below its limit: the hub stays
    about z, and while the motor runs Omega grows by a = u Jz / (J_s (Jz - J_s)) per second (linear: RK4 exact).
    With the gate decided at each step's start the motor runs for whole steps only, so the wheel stops at the
    first step boundary at or beyond the limit: Omega_max + overshoot with overshoot in [0, a dt).  The
    continuous gate cuts the motor inside the step: its final speed differs."""
    u, Js, Jz, dt, speed = 0.05, 0.01, 200.0, 0.01, 10.0
    a = u * Jz / (Js * (Jz - Js))
    finals = {}
    for gate in ("step_start", "continuous"):
        s = single_spacecraft(
            J=((100.0, 0, 0), (0, 150.0, 0), (0, 0, Jz)),
            sigma0=(0.0, 0.0, 0.0),
            omega0=(0.0, 0.0, 0.0),
            t_final=3.0,
            dt=dt,
            law_parameters={"enabled": False},
            actuator={
                "kind": "reaction_wheels",
                "layout": "custom",
                "axes": [[1, 0, 0], [0, 1, 0], [0, 0, 1]],
                "spin_inertia": Js,
                "max_speed": speed,
                "initial_speed": [0.0, 0.0, 9.0],
                "speed_gate": gate,
                "wheel_commands": {"time": [0.0], "motor_torque": [[0.0, 0.0, u]]},
            },
        )
        r = fsmctl.simulate(s)
        finals[gate] = r.wheel_speed[-1, 0, 2]
    steps = (speed - 9.0) / (a * dt)  # steps of full torque to reach the limit
    expected = 9.0 + np.ceil(steps - 1e-9) * a * dt
    assert np.isclose(finals["step_start"], expected, rtol=1e-12)
    assert speed <= finals["step_start"] < speed + a * dt
    assert abs(finals["continuous"] - finals["step_start"]) > 1e-6


def test_sample_wheel_commands_is_a_zero_order_hold():
    out = sample_wheel_commands(np.array([0.0, 0.3]), np.array([[1.0], [2.0]]), np.arange(5) * 0.1)
    assert out.ravel().tolist() == [1.0, 1.0, 1.0, 2.0, 2.0]  # 3 * 0.1 = 0.30000000000000004 counts as 0.3


WHEELS = {"kind": "reaction_wheels", "layout": "orthogonal"}


@pytest.mark.parametrize(
    ("actuator", "simulation", "match"),
    [
        ({"allocation": "clip"}, {}, r"actuator\.allocation: must be one of 'scaled' or 'clipped', got 'clip'"),
        ({"speed_gate": "start"}, {}, r"actuator\.speed_gate: must be one of 'continuous' or 'step_start'"),
        ({"speed_gate": "step_start"}, {"control_period": 0.0}, r"speed_gate.*control_period > 0"),
        ({"wheel_commands": {"time": [0.0], "motor_torque": [[0.1, 0, 0]]}}, {"control_period": 0.0}, "control_period"),
        ({"wheel_commands": {"time": [0.0, 0.0], "motor_torque": [[0, 0, 0]] * 2}}, {}, "strictly increasing"),
        ({"wheel_commands": {"time": [-1.0], "motor_torque": [[0, 0, 0]]}}, {}, ">= 0"),
        ({"wheel_commands": {"time": [0.0, 1.0], "motor_torque": [[0, 0, 0]]}}, {}, r"one row per time \(2\)"),
        ({"wheel_commands": {"time": [0.0], "motor_torque": [[0, 0]]}}, {}, r"one torque per wheel \(3\)"),
        ({"wheel_commands": {"time": [0.0], "motor_torque": [[0, float("nan"), 0]]}}, {}, "finite"),
        ({"wheel_commands": {"time": [0.0], "motor_torque": [[[0, 0, 0]] * 2]}}, {}, r"or 1 rows \(one per agent\)"),
        ({"wheel_commands": {"time": [0.0], "motor_torque": [0.1, 0, 0]}}, {}, "2 or 3 levels"),
    ],
)
def test_bad_wheel_settings_are_one_line_errors(actuator, simulation, match):
    with pytest.raises(ScenarioError, match=match):
        single_spacecraft(actuator={**WHEELS, **actuator}, control_period=simulation.get("control_period", 0.1))


def test_bad_wheel_commands_to_simulate_are_input_errors():
    s = single_spacecraft(t_final=0.5, actuator=WHEELS)
    with pytest.raises(InputError, match=r"wheel_commands\(0\.0\): expected an array of shape \(1, 3\), got \(3,\)"):
        fsmctl.simulate(s, wheel_commands=lambda t: np.zeros(3))
    with pytest.raises(InputError, match=r"not finite at t = 0\.2"):
        fsmctl.simulate(s, wheel_commands=lambda t: np.full((1, 3), np.nan if t > 0.15 else 0.0))
    with pytest.raises(InputError, match=r"an array \(6, 1, 3\)"):
        fsmctl.simulate(s, wheel_commands=np.zeros((5, 1, 3)))
    table = s.replace(actuator={"wheel_commands": {"time": [0.0], "motor_torque": [[0.0, 0.0, 0.0]]}})
    with pytest.raises(InputError, match="given both"):
        fsmctl.simulate(table, wheel_commands=lambda t: np.zeros((1, 3)))
    with pytest.raises(InputError, match="no reaction wheels"):
        fsmctl.simulate(single_spacecraft(t_final=0.5), wheel_commands=lambda t: np.zeros((1, 3)))
    with pytest.raises(ScenarioError, match="kind = 'reaction_wheels'"):
        fsmctl.ActuatorSettings(wheel_commands={"time": [0.0], "motor_torque": [[0.0, 0.0, 0.0]]})
    with pytest.raises(ScenarioError, match="step_start"):
        fsmctl.reaction_wheel_spacecraft(np.diag([10.0, 10.0, 10.0]), {"speed_gate": "step_start"})


SCENARIO_FILE = """\
name = "open-loop wheels"
[simulation]
t_final = 2.0
dt = 0.01
control_period = 0.1
output_interval = 0.1
[controller]
enabled = false
[reference]
sigma0 = [0.0, 0.0, 0.0]
omega = {{ amplitude = [0.0, 0.0, 0.0] }}
[topology]
links = []
[[agents]]
J0 = [[20.0, 0.0, 0.0], [0.0, 17.0, 0.0], [0.0, 0.0, 15.0]]
sigma0 = [0.1, 0.0, 0.0]
omega0 = [0.0, 0.0, 0.0]
[actuator]
kind = "reaction_wheels"
layout = "pyramid"
spin_inertia = 0.05
max_torque = 0.05
max_speed = 3.0
allocation = "{allocation}"
speed_gate = "step_start"
[actuator.wheel_commands]
time = [0.0, 1.0]
motor_torque = [[0.08, -0.02, 0.02, -0.02], [-0.02, 0.0, 0.0, 0.0]]
"""


@pytest.mark.parametrize("allocation", list(ALLOCATIONS))
def test_cli_flies_a_scenario_file_with_wheel_commands(tmp_path, allocation):
    path = tmp_path / "wheels.toml"
    path.write_text(SCENARIO_FILE.format(allocation=allocation))
    s = fsmctl.load_scenario(path)
    r = fsmctl.simulate(s)
    first = r.wheel_torque[0, 0]
    expected = distribute(
        np.zeros(3), distribution_matrix(PYRAMID), np.full(4, 0.05), [0.08, -0.02, 0.02, -0.02], allocation
    )[0]
    np.testing.assert_array_equal(first, expected)
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "fsmctl",
            "simulate",
            "--scenario",
            str(path),
            "--out",
            str(tmp_path / "out"),
            "--no-figures",
            "--format",
            "netcdf",
        ],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    header = [line for line in done.stdout.splitlines() if line.strip().startswith("actuator:")]
    assert header and f"allocation={allocation} " in header[0] and "wheel_commands: 2 rows from t = 0 s" in header[0]
    (saved,) = list((tmp_path / "out").glob("*.nc"))
    np.testing.assert_array_equal(fsmctl.load_result(saved)["wheel_speed_rad_per_s"].values, r.wheel_speed)
    bad = tmp_path / "bad.toml"
    bad.write_text(SCENARIO_FILE.format(allocation="clip"))
    done = subprocess.run(
        [sys.executable, "-m", "fsmctl", "simulate", "--scenario", str(bad), "--out", str(tmp_path / "bad")],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 2 and "must be one of 'scaled' or 'clipped'" in done.stderr, done.stderr


def test_step_start_gate_batched_and_scalar_kernels_agree():
    """The held speed limit's inner stages (the generated wheel_net_torque, lane-batched or scalar) fly the same
    run; the paper's hardware scenario with its wheels driven to a speed limit at step starts."""
    from fsmctl.model.problem import pack
    from fsmctl.simulation import simulator

    s = fsmctl.load_scenario("paper-hardware").replace(
        simulation={"t_final": 5.0}, actuator={"speed_gate": "step_start", "allocation": "clipped", "max_speed": 5.0}
    )
    p = pack(s)
    if not simulator._driver(p.law).fsm_batched_available():
        pytest.skip("this build has no batched kernels")
    a, b = simulator.simulate_packed(p, kernels="batched"), simulator.simulate_packed(p, kernels="scalar")
    assert (a["wheel_torque"] == 0.0).any()  # the speed limit acted
    for k in ("sigma", "omega", "wheel_speed", "wheel_torque", "u"):
        np.testing.assert_array_equal(a[k], b[k])


def test_a_misspelled_key_is_named_first():
    """A misspelled key makes another "missing": the one line names the unknown key, then the other error."""
    s = single_spacecraft(actuator={"kind": "reaction_wheels"})
    with pytest.raises(ScenarioError) as info:
        s.replace(actuator={"wheel_commands": {"time": [0.0], "torque": [[0.0, 0.0, 0.0, 0.0]]}})
    message = str(info.value)
    assert message.startswith("actuator.wheel_commands.torque: "), message
    assert "more error, first actuator.wheel_commands.motor_torque: missing" in message
