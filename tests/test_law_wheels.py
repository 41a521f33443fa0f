"""A law that commands its reaction wheels itself (``LawBuilder.reaction_wheels`` / ``wheel_torques``).

Independent routes: the commands the engine flew are recomputed in NumPy from the recorded wheel speeds and the
law's recorded body torque (``numpy.linalg.pinv``, an SVD, against the law's closed-form ``G^T (G G^T)^-1``); the
body torque of the wheels is ``-G u_w`` with the scenario's axes; the null space of the axes from NumPy's SVD.
"""

from __future__ import annotations

import hashlib
import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from formations import single_spacecraft

import fsmctl
from fsmctl.cli.derive import verification_lines
from fsmctl.model.generated_code import law_defines
from fsmctl.model.laws import LawError, LawSwitchWarning, builtin_laws, resolve_law
from fsmctl.model.scenario import ScenarioError
from fsmctl.symbolic import LawBuilder, LawDefinitionError
from fsmctl.symbolic.law import law_variants

PYRAMID = {"kind": "reaction_wheels", "layout": "pyramid", "spin_inertia": 0.05}


def _null_vector(G: np.ndarray) -> np.ndarray:
    """The unit vector spanning the null space of a 3 x 4 axis matrix (NumPy's SVD)."""
    return np.linalg.svd(G)[2][-1]


def _wheels_run(t_final=60.0, **law_parameters):
    s = single_spacecraft(
        law="fsm_wheels",
        law_parameters={"boundary_layer": 0.01, **law_parameters},
        t_final=t_final,
        dt=0.01,
        control_period=0.1,
        actuator=PYRAMID,
    )
    return s, fsmctl.simulate(s)


# ----------------------------------------------------------------------------- declarations


def _builder():
    b = LawBuilder("rw", doc="test")
    e = b.error_state()
    b.broadcast("sigma_e", e.sigma_e)
    b.torque(-e.sigma_e)
    return b


@pytest.mark.parametrize(
    ("misuse", "says"),
    [
        (lambda b: b.wheel_torques([0, 0, 0, 0]), "wheel_torques() needs reaction_wheels(n) first"),
        (
            lambda b: (b.reaction_wheels(4), b.wheel_torques([0, 0, 0])),
            "has 3 components, reaction_wheels() declared 4",
        ),
        (lambda b: (b.reaction_wheels(4), b.reaction_wheels(4)), "reaction_wheels() is declared twice"),
        (lambda b: b.reaction_wheels(0), "n must be a positive integer, got 0"),
        (lambda b: b.reaction_wheels(True), "n must be a positive integer, got True"),
        (
            lambda b: (b.reaction_wheels(3), b.wheel_torques([0, 0, 0]), b.wheel_torques([0, 0, 0])),
            "wheel_torques() is declared twice",
        ),
        (lambda b: b.u_max, "u_max is read by wheel_torques() only"),
    ],
)
def test_misuse_of_the_wheel_declarations_is_a_one_line_error(misuse, says):
    with pytest.raises(LawDefinitionError, match=r"^rw: .*" + re.escape(says)):
        misuse(_builder())


def test_wheels_declared_without_commands_or_read_by_the_body_torque_are_refused():
    b = _builder()
    b.reaction_wheels(4)
    with pytest.raises(LawDefinitionError, match=r"reaction_wheels\(4\) is declared but no wheel_torques\(\)"):
        b.build()
    b = LawBuilder("rw", doc="test")
    e = b.error_state()
    b.broadcast("sigma_e", e.sigma_e)
    w = b.reaction_wheels(4)
    h = b.stage("h", w.momentum)  # a wheel stage: the body torque may not read it
    b.torque(-e.sigma_e - h)
    b.wheel_torques(w.speed)
    with pytest.raises(LawDefinitionError, match=r"rw: torque reads the wheels \(reaction_wheels\(\)\)"):
        b.build()


def test_the_wheel_function_evaluates_the_declared_commands():
    """law_wheels_<model>: the control inputs, then axes (3 x N, column k = g_k), speeds, spin inertias."""
    from fsmctl.codegen.laws import law_functions

    def law(error_model):
        b = LawBuilder("rw", error_model, doc="test")
        e = b.error_state()
        b.broadcast("sigma_e", e.sigma_e)
        b.torque(-e.sigma_e)
        w = b.reaction_wheels(2)
        b.wheel_torques(sp.Matrix([w.spin_axes[2, 1] * w.speed[0], w.spin_inertia[1] + b.u_max]))
        return b.build()

    functions = {f.spec.name: f.function for f in law_functions(law_variants(law))}
    assert list(functions)[-2:] == ["law_wheels_paper", "law_wheels_exact"]
    f = functions["law_wheels_exact"]
    args = [0, [0.1, 0.2, 0.3], 0, [], 0, 0, 0, np.eye(3), [], [], np.zeros(3), 0, np.zeros(3), 0, 0.5]
    axes = np.array([[1.0, 0.0], [0.0, 0.6], [0.0, 0.8]])
    out = np.asarray(f(*args, axes, [3.0, 5.0], [0.01, 0.02])).ravel()
    np.testing.assert_array_equal(out, [0.8 * 3.0, 0.02 + 0.5])


# ----------------------------------------------------------------------------- the folder


def test_laws_without_wheel_outputs_keep_format_1_and_compile_as_before():
    """Format 2 and a flag exactly for the laws that need them (fsm_wheels: wheels; fsm_event: a trigger)."""
    for name, law in builtin_laws().items():
        meta = json.loads((law.folder / "law.json").read_text())
        if name == "fsm_wheels":
            assert meta["format"] == 2 and meta["wheels"] == {"count": 4, "function": "law_wheels", "unit": "N m"}
            assert law.n_wheels == 4 and law_defines(law.folder) == ("-DFSM_LAW_WHEELS",)
        elif name == "fsm_event":
            assert meta["format"] == 2 and "wheels" not in meta and law.n_wheels == 0
            assert law_defines(law.folder) == ("-DFSM_LAW_TRIGGER",)
        else:
            assert meta["format"] == 1 and "wheels" not in meta and law.n_wheels == 0
            assert law_defines(law.folder) == ()


def test_a_folder_whose_format_does_not_describe_its_wheels_is_refused(tmp_path):
    """Wheel outputs in a format-1 folder would be ignored by an fsmctl that knows only format 1: refused."""
    folder = tmp_path / "w"
    shutil.copytree(resolve_law("fsm_wheels").folder, folder)
    meta = json.loads((folder / "law.json").read_text())
    meta["format"] = 1
    (folder / "law.json").write_text(json.dumps(meta, indent=2) + "\n")
    manifest = json.loads((folder / "manifest.json").read_text())
    manifest["sha256"]["law.json"] = hashlib.sha256((folder / "law.json").read_bytes()).hexdigest()
    (folder / "manifest.json").write_text(json.dumps(manifest, indent=2) + "\n")
    with pytest.raises(LawError, match=r"law\.json: format 1 does not describe this law \(format 2 does\)"):
        resolve_law(folder)


# ----------------------------------------------------------------------------- the engine


def test_the_wheels_fly_the_law_s_commands_and_the_body_feels_the_law_s_torque():
    """At every control instant: u_w = -pinv(G) u + (I - pinv(G) G) v, v = -k_h J_s (Omega - bias) (NumPy's SVD
    pinv), and -G u_w = u (the law's body torque, recorded as u_commanded): the null motion changes nothing on
    the body."""
    bias = [40.0, -40.0, 40.0, -40.0]
    s, r = _wheels_run(t_final=20.0, momentum_gain=0.2, speed_bias=bias)
    G = s.actuator.spin_axes()
    Js = s.actuator.per_wheel("spin_inertia")
    P = np.linalg.pinv(G)
    null = np.eye(4) - P @ G
    assert np.linalg.norm(null) > 0.5  # a 4-wheel pyramid has a null space
    moved = 0.0
    for k in range(r.time.size - 1):  # the last sample: the final state, no command computed there
        u = r.u_unsaturated[k, 0]
        v = -0.2 * Js * (r.wheel_speed[k, 0] - bias)
        expected = -P @ u + null @ v
        scale = np.abs(expected).max()
        np.testing.assert_allclose(r.wheel_torque[k, 0], expected, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(-G @ r.wheel_torque[k, 0], u, rtol=0, atol=1e-12 * scale)
        moved = max(moved, np.abs(null @ v).max())
    assert moved > 0.1  # the null motion was large (N m), and the body did not feel it


def test_null_motion_drives_the_wheels_to_the_bias_while_the_attitude_converges_as_with_fsm():
    """No disturbance, the reference at rest, the body and wheels at rest at t = 0: the total angular momentum is
    0, so at rest again the wheel momentum G J_s Omega is 0 too; Omega then lies in the null space, where null
    motion drives it to a bias chosen there (at the rate momentum_gain).  Without null motion (momentum_gain = 0)
    the wheels end at rest."""
    s0 = single_spacecraft(omega0=(0.0, 0.0, 0.0), actuator=PYRAMID)
    null = _null_vector(s0.actuator.spin_axes())
    bias = (30.0 * null).tolist()
    runs = {}
    for law, extra in (("fsm", {}), ("fsm_wheels", {"momentum_gain": 0.1, "speed_bias": bias})):
        s = single_spacecraft(
            law=law,
            law_parameters={"boundary_layer": 0.01, **extra},
            omega0=(0.0, 0.0, 0.0),
            t_final=150.0,
            dt=0.01,
            control_period=0.1,
            actuator=PYRAMID,
        )
        runs[law] = fsmctl.simulate(s)
    plain, managed = runs["fsm"], runs["fsm_wheels"]
    for r in (plain, managed):
        assert np.linalg.norm(r.sigma_e[-1, 0]) < 1e-4 and np.linalg.norm(r.omega_e[-1, 0]) < 1e-5
    assert np.abs(plain.wheel_speed[-1, 0]).max() < 1e-2  # minimum norm: no momentum left on the wheels
    start = np.linalg.norm(managed.wheel_speed[0, 0] - bias)
    end = np.linalg.norm(managed.wheel_speed[-1, 0] - bias)
    assert start == pytest.approx(30.0) and end < 1e-3 * start  # e^(-0.1 * 150) of the null part, and the rest 0


def test_with_zero_gain_the_commands_are_the_minimum_norm_distribution():
    from fsmctl.model.actuators import distribute, distribution_matrix

    s, r = _wheels_run(t_final=5.0, momentum_gain=0.0)
    P = distribution_matrix(s.actuator.spin_axes())
    for k in range(r.time.size - 1):
        w, scale = distribute(r.u_unsaturated[k, 0], P, s.actuator.per_wheel("max_torque"))
        assert scale == 1.0
        np.testing.assert_allclose(r.wheel_torque[k, 0], w, rtol=0, atol=1e-12 * np.abs(w).max())


def test_the_wheel_count_must_be_the_law_s():
    with pytest.raises(ScenarioError, match=r"the law fsm_wheels commands 4 reaction wheels, the actuator has 3"):
        single_spacecraft(law="fsm_wheels", actuator={"kind": "reaction_wheels", "layout": "orthogonal"})


def test_on_an_ideal_actuator_the_law_flies_its_body_torque():
    """The wheel commands are unused; the body torque is the paper's law, as fsm flies it."""
    runs = [
        fsmctl.simulate(single_spacecraft(law=law, law_parameters={"boundary_layer": 0.01}, t_final=5.0))
        for law in ("fsm", "fsm_wheels")
    ]
    np.testing.assert_array_equal(runs[0].sigma, runs[1].sigma)
    np.testing.assert_array_equal(runs[0].u, runs[1].u)


def test_batched_and_scalar_kernels_fly_the_same_wheel_commands():
    """The batched path gathers each agent's cache and received sum from the lane rows (3 agents in a ring)."""
    from fsmctl.model.problem import pack
    from fsmctl.simulation import simulator

    with pytest.warns(LawSwitchWarning, match="law 'fsm_wheels' flown instead of 'fsm'"):
        s = (
            fsmctl.load_scenario("paper-hardware")
            .replace(simulation={"t_final": 3.0})
            .with_law("fsm_wheels", {"momentum_gain": 0.1, "speed_bias": [10.0, -10.0, 10.0, -10.0]})
        )
    p = pack(s)
    if not simulator._driver(p.law).fsm_batched_available():
        pytest.skip("this build has no batched kernels")
    a, b = simulator.simulate_packed(p, kernels="batched"), simulator.simulate_packed(p, kernels="scalar")
    for k in ("sigma", "omega", "wheel_speed", "wheel_torque", "u"):
        np.testing.assert_array_equal(a[k], b[k])


# ----------------------------------------------------------------------------- python-control


def _controllers(bias, gain):
    from fsmctl.plugin.iosys import law_controller

    J0 = fsmctl.paper_scenario("1").agents[0].J0_array
    parameters = {"boundary_layer": 0.01}
    rw = law_controller(
        "fsm_wheels",
        J0,
        parameters={**parameters, "momentum_gain": gain, "speed_bias": bias},
        u_max=0.5,
        actuator=PYRAMID,
        name="w",
    )
    return rw, law_controller("fsm", J0, parameters=parameters, u_max=0.5, name="p")


def test_the_controller_outputs_the_law_s_wheel_commands():
    """Outputs tau (as the fsm controller's), s, u_wheels; inputs ..., Omega.  The commands against NumPy's pinv,
    and d u_wheels / d Omega = (I - pinv(G) G) diag(-k_h J_s) from the linearisation."""
    bias, gain = [5.0, -3.0, 2.0, 1.0], 0.2
    rw, plain = _controllers(bias, gain)
    assert rw.output_labels[6:] == [f"u_wheels[{k}]" for k in range(4)]
    assert rw.input_labels[15:] == [f"Omega[{k}]" for k in range(4)]
    y = np.random.default_rng(1).uniform(-0.2, 0.2, 15)
    Omega = np.array([30.0, -10.0, 4.0, 12.0])
    out = rw.output(0.0, [], np.r_[y, Omega])
    tau = plain.output(0.0, [], y)[:3]
    np.testing.assert_allclose(out[:3], tau, rtol=0, atol=1e-15)
    assert np.abs(tau).max() == 0.5  # a torque at the limit: the commands realise the limited torque
    act = fsmctl.model.scenario.ActuatorSettings(**PYRAMID)
    G, Js = act.spin_axes(), act.per_wheel("spin_inertia")
    P = np.linalg.pinv(G)
    null = np.eye(4) - P @ G
    expected = -P @ tau + null @ (-gain * Js * (Omega - bias))
    np.testing.assert_allclose(out[6:], expected, rtol=0, atol=1e-13)
    np.testing.assert_allclose(-G @ out[6:], tau, rtol=0, atol=1e-13)
    D = rw.linearize([], np.r_[y, Omega]).D
    np.testing.assert_allclose(D[6:, 15:], null @ np.diag(-gain * Js), rtol=0, atol=1e-13)


def test_the_controller_s_actuator_must_match_the_law():
    from fsmctl.plugin.iosys import law_controller

    J0 = np.diag([10.0, 20.0, 30.0])
    with pytest.raises(ScenarioError, match=r"the law fsm_wheels commands 4 reaction wheels, the actuator has 3"):
        law_controller("fsm_wheels", J0, actuator={"layout": "orthogonal"})
    with pytest.raises(ScenarioError, match=r"the law pid commands no wheels"):
        law_controller("pid", J0, actuator=PYRAMID)
    body_only = law_controller("fsm_wheels", J0)  # without an actuator: the body torque, for an ideal source
    assert body_only.noutputs == 6 and body_only.ninputs == 15


def test_derive_says_the_law_commands_its_wheels():
    """What ``fsmctl derive`` prints of a law that commands its wheels: how many, and what the scenario needs."""

    def law(error_model):
        b = LawBuilder("rw", error_model, doc="test")
        e = b.error_state()
        b.broadcast("sigma_e", e.sigma_e)
        b.torque(-e.sigma_e)
        w = b.reaction_wheels(3)
        b.wheel_torques(-w.spin_axes.T * (-e.sigma_e))
        return b.build()

    (line,) = [x for x in verification_lines(law_variants(law), Path("rw.py")) if x.startswith("wheels: ")]
    assert "commands 3 reaction wheels" in line and "must have 3 wheels" in line
