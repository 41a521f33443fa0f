"""python-control interfaces: actuator and sensor blocks in ``fsmctl.formation``, the law's gains as named
parameters, the grouped ``FormationResponse.plot()``, and the top-level names.

Oracles: the interconnection a python-control user wires by hand today (``ct.interconnect`` of
``spacecraft``, ``law_controller``, ``reference_generator`` and the blocks, every connection written out, other
system names), the formation of a scenario built with the changed gain, and the response's own arrays.
"""

from __future__ import annotations

import importlib
import subprocess
import sys
import warnings

import control as ct
import numpy as np
import pytest
from formations import with_agents

import fsmctl
from fsmctl.errors import InputError
from fsmctl.model.laws import parameter_matrix, resolve_law
from fsmctl.model.time_response import FormationResponse, agent_color, formation_response
from fsmctl.model.topology import ring
from fsmctl.plugin import FormationSystem
from fsmctl.plugin.hardware import rate_gyro
from fsmctl.plugin.iosys import (
    Neighbour,
    initial_state,
    law_controller,
    law_parameter_values,
    reference_generator,
)

TIGHT = {"solve_ivp_method": "RK45", "solve_ivp_kwargs": {"rtol": 1e-8, "atol": 1e-10}}
T = np.linspace(0.0, 1.0, 11)


def names(base: str, n: int = 3) -> list[str]:
    return [f"{base}[{k}]" for k in range(n)]


@pytest.fixture(scope="module")
def two():
    """Two agents of the paper's Case 1 on a ring, boundary layer 0.05 (so SciPy's RK45 copes), 1 N m limit."""
    paper = fsmctl.paper_scenario("1")
    return with_agents(
        paper, paper.agents[:2], ring(2, 8.0, 5.0), controller={"boundary_layer": 0.05, "torque_limit": 1.0}
    )


def lag_actuator(tau: float = 0.2, damping: float = 0.0, limit: float = 0.5) -> ct.NonlinearIOSystem:
    """A torque actuator: saturation at ``limit``, first-order lag ``tau``, minus ``damping * omega``.

    Inputs ``tau_command`` and ``omega`` (from the plant), outputs ``tau`` and an extra ``power``.
    """

    def update(t, x, u, params):
        return (np.clip(u[:3], -limit, limit) - x) / tau

    def output(t, x, u, params):
        applied = x - damping * u[3:6]
        return np.concatenate([applied, [applied @ u[3:6]]])

    return ct.nlsys(
        update,
        output,
        inputs=names("tau_command") + names("omega"),
        outputs=[*names("tau"), "power"],
        states=names("x"),
        name="my_actuator",
    )


def biased_star_tracker(bias) -> ct.NonlinearIOSystem:
    b = np.asarray(bias, dtype=float)
    return ct.nlsys(None, lambda t, x, u, p: u + b, inputs=names("sigma"), outputs=names("sigma_measured"))


def hand_wired(s, actuator=None, star=None, gyro=None):
    """The closed loop as a python-control user wires it today: every system and connection by hand.

    Names differ from ``formation``'s (``ref``, ``p<i>``, ``c<i>``, ``a<i>``, ``st<i>``, ``g<i>``); the system
    order is the same (reference, plants, controllers, then the blocks), so the state vectors line up.
    ``actuator``, ``star`` and ``gyro`` are callables ``i -> system`` (``i`` 0-based) or None.
    """
    law = resolve_law("fsm")
    rows = parameter_matrix(law, s)
    plants, controllers, blocks, conns = [], [], [], []
    for i, agent in enumerate(s.agents, start=1):
        plants.append(fsmctl.spacecraft(agent.J_true, disturbance=agent.disturbance, name=f"p{i}"))
        nbrs = [
            Neighbour(f"p{ln.sender + 1}", ln.k_i, ln.k_j, ln.phase) for ln in s.topology.links if ln.receiver == i - 1
        ]
        controllers.append(
            law_controller(
                law,
                agent.J0_array,
                parameters=law_parameter_values(law, rows[i - 1]),
                u_max=s.controller.torque_limit,
                neighbours=nbrs,
                name=f"c{i}",
            )
        )
        conns += [[f"c{i}.{sig}", f"ref.{sig}"] for sig in ("sigma_d", "omega_d", "omega_d_dot")]
        conns += [[f"c{i}.s_{nb.name}", f"c{nb.name[1:]}.s"] for nb in nbrs]
        if actuator is None:
            conns.append([f"p{i}.tau", f"c{i}.tau"])
        else:
            blocks.append(actuator(i - 1).copy(name=f"a{i}"))
            conns += [[f"a{i}.tau_command", f"c{i}.tau"], [f"a{i}.omega", f"p{i}.omega"], [f"p{i}.tau", f"a{i}.tau"]]
    for i in range(1, s.n_agents + 1):  # the sensors after the actuators, as formation() orders them
        if star is None:
            conns.append([f"c{i}.sigma", f"p{i}.sigma"])
        else:
            blocks.append(star(i - 1).copy(name=f"st{i}"))
            conns += [[f"st{i}.sigma", f"p{i}.sigma"], [f"c{i}.sigma", f"st{i}.sigma_measured"]]
        if gyro is None:
            conns.append([f"c{i}.omega", f"p{i}.omega"])
        else:
            blocks.append(gyro(i - 1).copy(name=f"g{i}"))
            conns += [[f"g{i}.omega", f"p{i}.omega"], [f"c{i}.omega", f"g{i}.omega_measured"]]
    torque = "a" if actuator is not None else "c"
    outlist = [
        f"{sys_}{i}.{sig}"
        for i in range(1, s.n_agents + 1)
        for sys_, sig in (("p", "sigma"), ("p", "omega"), (torque, "tau"))
    ]
    return ct.interconnect(
        [reference_generator(s.reference.omega, name="ref"), *plants, *controllers, *blocks],
        connections=conns,
        outlist=outlist,
        inputs=[],
        ignore_outputs=[f"a{i}.power" for i in range(1, s.n_agents + 1)] if actuator is not None else None,
    )


def respond(sys_, s, **kwargs):
    x0 = initial_state(s)
    x0 = [x0, 0] if sys_.nstates > x0.size else x0  # the blocks' states start at zero
    r = ct.input_output_response(sys_, T, 0, x0, **TIGHT, **kwargs)
    assert r.success
    return r


def assert_same_response(a, b, tol=1e-12):
    assert a.outputs.shape == b.outputs.shape and a.states.shape == b.states.shape
    assert np.abs(a.outputs - b.outputs).max() <= tol
    assert np.abs(a.states - b.states).max() <= tol


# ----------------------------------------------------------------------------- actuator and sensor blocks


def test_actuator_blocks_are_the_hand_wired_interconnection(two):
    """``formation(s, actuators=block)`` flies the loop a user wires by hand: the same states and outputs; the
    block (saturation 0.5 N m, 0.2 s lag, omega damping) changes the response, and ``sc<i>_tau`` is its output."""
    block = lag_actuator(damping=3.0)
    loop = fsmctl.formation(two, actuators=block)
    assert isinstance(loop, FormationSystem)
    assert loop.nstates == 4 + 7 * 2 + 3 * 2 and loop.state_labels[-6:] == [
        f"actuator{i}_x[{k}]" for i in (1, 2) for k in range(3)
    ]
    assert block.name == "my_actuator"  # the user's block is copied, not renamed
    ours = respond(loop, two)
    theirs = respond(hand_wired(two, actuator=lambda i: lag_actuator(damping=3.0)), two)
    assert_same_response(ours, theirs)
    plain = respond(fsmctl.formation(two), two)
    torque = ours.outputs.reshape(2, 3, 3, -1)[:, 2]
    assert np.abs(torque).max() <= 0.5 + 3.0 * np.abs(ours.outputs.reshape(2, 3, 3, -1)[:, 1]).max()
    assert np.abs(torque - plain.outputs.reshape(2, 3, 3, -1)[:, 2]).max() > 0.1
    # the applied torque (sc<i>_tau) is the block's state x minus the damping: the state at t = 1 s
    x_act = ours.states[-6:, -1].reshape(2, 3)
    omega = ours.outputs.reshape(2, 3, 3, -1)[:, 1, :, -1]
    assert np.allclose(torque[:, :, -1], x_act - 3.0 * omega, rtol=0, atol=1e-15)


def test_actuators_per_agent_by_sequence_and_by_hook(two):
    """A sequence gives one entry per agent (None: no block); a hook ``(i, agent)`` makes each agent's block."""
    seen = []

    def hook(i, agent):
        seen.append((i, agent))
        return lag_actuator(tau=0.1 + 0.1 * i)

    by_hook = respond(fsmctl.formation(two, actuators=hook), two)
    assert [i for i, _ in seen] == [0, 1] and seen[1][1] is two.agents[1]
    theirs = respond(hand_wired(two, actuator=lambda i: lag_actuator(tau=0.1 + 0.1 * i)), two)
    assert_same_response(by_hook, theirs)
    by_list = respond(fsmctl.formation(two, actuators=[lag_actuator(tau=0.1), lag_actuator(tau=0.2)]), two)
    assert_same_response(by_list, theirs)
    # agent 1 without a block: its torque is the law's (1 N m limit reached), agent 2's is held back by the lag
    half = fsmctl.formation(two, actuators=[None, lag_actuator()])
    assert half.nstates == 4 + 14 + 3
    r = respond(half, two)
    assert np.abs(r.outputs[6:9, 1]).max() == pytest.approx(1.0)
    assert np.abs(r.outputs[15:18, 1]).max() < 0.5


def test_sensor_blocks_are_the_hand_wired_interconnection(two):
    """A star-tracker-like block (a fixed attitude bias) and fsmctl's rate gyro (``dt=0``, a constant bias) per
    agent: the hand-wired loop's response; the law sees the measured signals, the outputs stay the true ones."""

    def star(i):
        return biased_star_tracker([0.01 * (i + 1), 0.0, -0.005])

    def gyro(i):
        return rate_gyro(0.0, 0.0, [0.0, 2e-3 * (i + 1), 0.0], 0.1, horizon=1.0, agent=i, dt=0)

    loop = fsmctl.formation(two, sensors=lambda i, agent: (star(i), gyro(i)))
    ours = respond(loop, two)
    theirs = respond(hand_wired(two, star=star, gyro=gyro), two)
    assert_same_response(ours, theirs)
    plain = respond(fsmctl.formation(two), two)
    assert np.abs(ours.outputs - plain.outputs).max() > 1e-3  # the biases change what the law does
    # one sensor only: the rate comes from the plant
    only_star = respond(fsmctl.formation(two, sensors=[star(0), star(1)]), two)
    assert_same_response(only_star, respond(hand_wired(two, star=star), two))
    both = respond(fsmctl.formation(two, actuators=lag_actuator(), sensors=star(0)), two)
    assert_same_response(both, respond(hand_wired(two, actuator=lambda i: lag_actuator(), star=lambda i: star(0)), two))


def _static(inputs, outputs, dt=0):
    return ct.nlsys(None, lambda t, x, u, p: np.zeros(len(outputs)), inputs=inputs, outputs=outputs, dt=dt, name="blk")


@pytest.mark.parametrize(
    ("kind", "spec", "match"),
    [
        ("actuators", _static(names("u"), names("tau")), r"needs the input tau_command\[0\.\.2\].*inputs are \['u'\]"),
        (
            "actuators",
            _static(names("tau_command"), names("y")),
            r"needs the output tau\[0\.\.2\].*outputs are \['y'\]",
        ),
        (
            "actuators",
            _static(names("tau_command", 2), names("tau")),
            r"tau_command\[0\.\.2\].*it has \['tau_command\[0\]', 'tau_command\[1\]'\]",
        ),
        (
            "actuators",
            _static(names("tau_command") + names("wind"), names("tau")),
            "input 'wind', which is neither tau_command",
        ),
        ("actuators", _static(names("tau_command") + names("omega", 2), names("tau")), "input 'omega' has components"),
        ("actuators", _static(names("tau_command"), names("tau"), dt=0.1), r"discrete time \(dt = 0\.1\).*dt=0"),
        ("actuators", [None], r"one entry per agent \(2\), got 1"),
        ("actuators", "lag", "expected None, a python-control system"),
        ("actuators", [None, (_static(names("tau_command"), names("tau")),) * 2], "one actuator block per agent"),
        ("actuators", lambda i, agent: "lag", r"agent 1: expected None, a python-control system"),
        (
            "sensors",
            _static(names("sigma"), names("y")),
            r"needs the output sigma_measured\[0\.\.2\] or omega_measured",
        ),
        (
            "sensors",
            _static(names("sigma_d"), names("sigma_measured")),
            "input 'sigma_d', which is neither a plant output",
        ),
        ("sensors", _static(names("sigma"), names("sigma_measured", 4)), r"sigma_measured\[0\.\.2\]"),
        (
            "sensors",
            lambda i, a: (
                _static(names("sigma"), names("sigma_measured")),
                _static(names("sigma"), names("sigma_measured")),
            ),
            "both output sigma_measured",
        ),
    ],
)
def test_blocks_whose_signals_do_not_fit_are_refused_in_one_line(two, kind, spec, match):
    with pytest.raises(InputError, match=match) as exc:
        fsmctl.formation(two, **{kind: spec})
    assert isinstance(exc.value, fsmctl.ScenarioError) and "\n" not in str(exc.value)
    assert str(exc.value).startswith(f"formation: {kind}")


# ----------------------------------------------------------------------------- the law's gains as parameters


def test_a_gain_by_name_in_params_is_the_formation_built_with_that_gain(two):
    """``params={"c1": ..., "alpha": ..., "delta": ...}`` in ``ct.input_output_response`` (the keys of a scenario's
    ``[controller]`` table, every agent) flies exactly the formation of the scenario with those values."""
    loop = fsmctl.formation(two)
    base = respond(loop, two)
    changed = respond(loop, two, params={"c1": 1.3, "alpha": 0.6})
    built = respond(fsmctl.formation(two.replace(controller={"c1": 1.3, "alpha": 0.6})), two)
    assert np.array_equal(changed.outputs, built.outputs) and np.array_equal(changed.states, built.states)
    assert np.abs(changed.outputs - base.outputs).max() > 1e-4
    # per-agent delta (eq 18) by name, for every agent, is the scenario whose agents carry it
    d = [0.02, 0.01, 0.03]
    built = respond(fsmctl.formation(two.replace(agents=[{"delta": d}] * two.n_agents)), two)
    assert np.array_equal(respond(loop, two, params={"delta": d}).outputs, built.outputs)
    # the prefixed key of one agent wins over the bare name for that agent
    mixed = respond(loop, two, params={"c1": 1.3, "ctrl2_c1": 0.6, "alpha": 0.6})
    explicit = respond(loop, two, params={"ctrl1_c1": 1.3, "ctrl2_c1": 0.6, "ctrl1_alpha": 0.6, "ctrl2_alpha": 0.6})
    assert np.array_equal(mixed.outputs, explicit.outputs) and not np.array_equal(mixed.outputs, changed.outputs)
    # the system keeps its own values afterwards
    assert np.array_equal(respond(loop, two).outputs, base.outputs)


def test_a_gain_by_name_is_checked_like_a_scenario_file(two):
    loop = fsmctl.formation(two)
    with pytest.raises(fsmctl.ScenarioError, match=r"alpha'?: must be < 1") as from_params:
        loop.dynamics(0.0, initial_state(two), [], params={"alpha": 1.2})
    with pytest.raises(fsmctl.ScenarioError, match="alpha: must be < 1"):
        two.replace(controller={"alpha": 1.2})
    assert "'ctrl1_alpha'" in str(from_params.value)
    with pytest.raises(fsmctl.ScenarioError, match=r"singularity_fix.*must be one of"):
        loop.dynamics(0.0, initial_state(two), [], params={"singularity_fix": "sometimes"})
    with pytest.raises(fsmctl.ScenarioError, match=r"delta.*expected 3 numbers"):
        loop.dynamics(0.0, initial_state(two), [], params={"delta": [0.1, 0.1]})


def test_fsm_controller_gains_are_named_parameters():
    paper = fsmctl.paper_scenario("1")
    a = paper.agents[0]
    delta = paper.law_parameters()[0]["delta"]
    ctrl = fsmctl.fsm_controller(a.J0_array, paper.controller, delta, name="k")
    assert {"k_c1", "k_c2", "k_alpha", "k_boundary_layer", "k_epsilon", "k_singularity_fix", "k_delta"} < set(
        ctrl.params
    )
    assert ctrl.params["k_c1"] == paper.controller.parameters["c1"] == 0.6
    assert ctrl.params["k_alpha"] == paper.controller.parameters["alpha"] == 0.7
    lsm = fsmctl.fsm_controller(a.J0_array, paper.replace(controller={"surface": "lsm"}).controller, delta, name="k")
    assert lsm.params["k_c2"] == 0.0  # the surface's zeroed gain is the parameter's value


# ----------------------------------------------------------------------------- FormationResponse.plot()


def _synthetic(n_agents=3, extra=()):
    labels = [f"sc{i}_{g}[{k}]" for i in range(1, n_agents + 1) for g in ("sigma", "omega", "tau") for k in range(3)]
    labels += [f"sc{i}_sigma_e[{k}]" for i in range(1, n_agents + 1) for k in range(3)]
    labels += [f"sc{i}_theta_e_deg" for i in range(1, n_agents + 1)] + ["aaem_deg", "raem_deg", *extra]
    t = np.linspace(0.0, 2.0, 21)
    y = np.sin(np.outer(np.arange(1, len(labels) + 1), t))  # every row different
    return FormationResponse(t, y, output_labels=labels, issiso=False, title="synthetic"), labels, y


@pytest.fixture
def plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as pyplot

    yield pyplot
    pyplot.close("all")


def test_plot_groups_signals_colours_agents_and_styles_components(plt):
    r, labels, y = _synthetic()
    cplt = r.plot()
    titles = [ax.get_title() for ax in cplt.axes[:, 0]]
    assert titles == [
        "σ: attitude (MRP)",
        "ω: body rate (rad/s)",
        "u: torque on the body (N m)",
        "σ_e: attitude error (MRP, eqs 5-6)",
        "θ_e: attitude error angle (deg)",
        "AAEM, RAEM: attitude error metrics (deg, eqs 42-43)",
    ]
    assert cplt.axes.shape == (6, 1) and [len(lines) for lines in cplt.lines[:, 0]] == [9, 9, 9, 9, 3, 2]
    assert cplt.figure.get_suptitle() == "synthetic"
    drawn = 0
    for lines in cplt.lines[:, 0]:
        for line in lines:
            label = line.get_label()
            assert np.array_equal(line.get_xdata(), r.time)
            assert np.array_equal(line.get_ydata(), y[labels.index(label)])  # the response's own row
            if label.startswith("sc"):
                agent = int(label[2]) - 1
                assert line.get_color() == agent_color(agent)
                k = int(label[-2]) if label.endswith("]") else 0
                assert line.get_linestyle() == ("-", "--", ":")[k]
            else:
                assert line.get_color() == "black"
            drawn += 1
    assert drawn == len(labels)
    assert [t.get_text() for t in cplt.legend.get_texts()] == ["sc1", "sc2", "sc3", "[0]", "[1]", "[2]"]
    colours = [h.get_color() for h in cplt.legend.legend_handles[:3]]
    assert colours == [agent_color(0), agent_color(1), agent_color(2)]
    metrics = cplt.axes[5, 0].get_legend()
    assert [t.get_text() for t in metrics.get_texts()] == ["aaem_deg", "raem_deg"]


def test_plot_limits_the_axes_and_chooses_groups(plt):
    r, _, _ = _synthetic(extra=[f"sc{i}_omega_e[{k}]" for i in (1, 2, 3) for k in range(3)])
    with pytest.warns(UserWarning, match="7 signal groups, drawing the first 6; left out: omega_e"):
        cplt = r.plot()
    assert cplt.axes.shape == (6, 1)
    cplt = r.plot(groups=["omega_e", "tau"], title="two groups")
    assert [ax.get_title() for ax in cplt.axes[:, 0]] == [
        "ω_e: rate error (rad/s, eq 7)",
        "u: torque on the body (N m)",
    ]
    assert [line.get_label() for line in cplt.lines[0, 0]][:2] == ["sc1_omega_e[0]", "sc1_omega_e[1]"]
    assert cplt.figure.get_suptitle() == "two groups"
    with warnings.catch_warnings(record=True) as caught:  # every group drawn: fsmctl does not warn (what
        warnings.simplefilter("always")  # matplotlib says about its own API depends on its version: not tested)
        assert r.plot(max_axes=7).axes.shape == (7, 1)
    assert not [w for w in caught if "FormationResponse.plot" in str(w.message)], [str(w.message) for w in caught]
    with pytest.raises(InputError, match="no signal group 'nu'; the groups are sigma, omega, tau"):
        r.plot(groups=["nu"])
    with pytest.raises(InputError, match="max_axes must be an integer >= 1"):
        r.plot(max_axes=0)


def test_signal_names_of_both_conventions_are_parsed(plt):
    labels = ["sigma_1[0]", "sigma_1[1]", "sigma_2[0]", "sc1.omega[2]", "reference_sigma_d[0]", "ctrl2_s[1]"]
    r = FormationResponse(np.arange(3.0), np.arange(18.0).reshape(6, 3), output_labels=labels, issiso=False)
    assert r.signal_groups() == {
        "sigma": ["sigma_1[0]", "sigma_1[1]", "sigma_2[0]"],
        "omega": ["sc1.omega[2]"],
        "reference_sigma_d": ["reference_sigma_d[0]"],
        "s": ["ctrl2_s[1]"],
    }
    cplt = r.plot()
    assert [line.get_color() for line in cplt.lines[0, 0]] == [agent_color(0), agent_color(0), agent_color(1)]
    assert [line.get_linestyle() for line in cplt.lines[0, 0]] == ["-", "--", "-"]
    assert cplt.lines[3, 0][0].get_color() == agent_color(1) and cplt.lines[3, 0][0].get_linestyle() == "--"
    assert cplt.lines[2, 0][0].get_color() == "black"


def test_formation_response_wraps_a_plug_in_response(two, plt):
    raw = ct.input_output_response(fsmctl.formation(two), [0.0, 0.05, 0.1], 0, initial_state(two))
    r = formation_response(raw)
    assert isinstance(r, FormationResponse) and formation_response(r) is r
    assert np.array_equal(r.outputs, raw.outputs) and r.output_labels == raw.output_labels
    cplt = r.plot()
    assert cplt.axes.shape == (3, 1) and [len(lines) for lines in cplt.lines[:, 0]] == [6, 6, 6]
    assert np.array_equal(cplt.lines[1, 0][4].get_ydata(), raw.outputs[raw.output_labels.index("sc2_omega[1]")])
    assert cplt.lines[1, 0][4].get_color() == agent_color(1)
    with pytest.raises(InputError, match=r"expected a control\.TimeResponseData"):
        formation_response(np.zeros(3))


# ----------------------------------------------------------------------------- the top-level names


def test_import_fsmctl_stays_light():
    """``import fsmctl`` loads neither CasADi, python-control, SymPy nor matplotlib (SPEC 1 lazy loading)."""
    code = (
        "import sys, fsmctl, fsmctl.plugin\n"
        "heavy = [m for m in ('casadi', 'control', 'sympy', 'matplotlib', 'scipy') if m in sys.modules]\n"
        "print(','.join(heavy))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    assert out.stdout.strip() == ""


def test_the_names_a_python_control_user_needs_are_top_level():
    for name in ("formation", "law_controller", "Neighbour", "mrp_state", "FormationResponse", "formation_response"):
        assert name in fsmctl.__all__ and name in dir(fsmctl)
    assert fsmctl.law_controller is law_controller and fsmctl.FormationResponse is FormationResponse
    assert fsmctl.initial_state is initial_state
    plugin = importlib.import_module("fsmctl.plugin")
    for name in plugin.__all__:
        assert getattr(plugin, name) is not None
    assert {"formation", "law_controller", "reaction_wheel_spacecraft", "star_tracker"} <= set(plugin.__all__)
    assert set(plugin.__all__) <= set(dir(plugin))
