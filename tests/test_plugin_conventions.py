"""The plug-in's factories follow python-control's conventions (issue 24, "Conventions to follow").

Signal names, ``params=`` and ``dt=`` keywords as :func:`control.nlsys` takes them; parameters by their local
names (``"J"``), with an error naming the candidates when several fsmctl systems of an interconnection have one;
systems that pickle (a process pool gives the serial numbers); ownership errors that tell a reused params dict
from two systems of one name.
"""

from __future__ import annotations

import multiprocessing
import pickle
import warnings
from concurrent.futures import ProcessPoolExecutor

import control as ct
import numpy as np
import pytest

import fsmctl
from fsmctl.errors import InputError
from fsmctl.model.scenario import ScenarioError
from fsmctl.model.topology import Schedule
from fsmctl.plugin import (
    Neighbour,
    ParameterKeyError,
    initial_state,
    law_controller,
    quaternion_from_mrp,
    reaction_wheel_spacecraft,
    reaction_wheel_state,
)

J1 = np.diag([100.0, 150.0, 200.0])
J2 = np.array([[20.0, 1.0, 0.0], [1.0, 30.0, 2.0], [0.0, 2.0, 40.0]])
X0 = np.concatenate([quaternion_from_mrp([0.1, -0.2, 0.3]), [0.01, -0.02, 0.03]])
TAU = np.array([0.1, -0.2, 0.3])
WHEELS = {"layout": "orthogonal", "spin_inertia": 0.05, "max_torque": 0.1}


def _euler(J: np.ndarray, w: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """The independent oracle: Euler's equation ``J w_dot = -w x J w + tau``."""
    return np.linalg.solve(J, tau - np.cross(w, J @ w))


def _ring() -> fsmctl.Scenario:
    return fsmctl.load_scenario("docs/examples/ring_of_three.toml")


# ----------------------------------------------------------------------------- keywords


def test_factories_rename_signals_and_refuse_a_wrong_count():
    sc = fsmctl.spacecraft(J1, inputs=["Tx", "Ty", "Tz"], states=7, name="sc")
    assert sc.input_labels == ["Tx", "Ty", "Tz"] and sc.state_labels[0] == "x[0]"
    assert np.array_equal(sc.dynamics(0.0, X0, TAU), fsmctl.spacecraft(J1, name="sc").dynamics(0.0, X0, TAU))
    ref = fsmctl.reference_generator(fsmctl.Sinusoid(), outputs=[f"r{k}" for k in range(9)], name="reference")
    assert ref.output_labels[-1] == "r8"
    ctrl = law_controller("fsm", J1, outputs=["ux", "uy", "uz", "s0", "s1", "s2"], name="c")
    assert ctrl.output_labels[:3] == ["ux", "uy", "uz"]
    plant = reaction_wheel_spacecraft(J1, WHEELS, states=[f"w{k}" for k in range(10)], name="rw")
    assert plant.state_labels[-1] == "w9"
    for make, match in [
        (lambda: fsmctl.spacecraft(J1, inputs=["a", "b"]), r"inputs: expected 3 names .*got 2"),
        (lambda: fsmctl.spacecraft(J1, states=["q"] * 7), "given twice"),
        (lambda: fsmctl.spacecraft(J1, outputs=["s.x"] * 6), "without '.'"),
        (lambda: law_controller("fsm", J1, states=["z"]), r"states: expected 0 names"),
        (lambda: fsmctl.spacecraft(J1, inputs=3.5), "expected a list of 3 signal names"),
    ]:
        with pytest.raises(ScenarioError, match=match) as info:
            make()
        assert "\n" not in str(info.value)


def test_dt_means_what_python_control_means():
    assert fsmctl.spacecraft(J1, dt=None).dt == 0 and fsmctl.spacecraft(J1, dt=0).dt == 0
    for make in (
        lambda dt: fsmctl.spacecraft(J1, dt=dt),
        lambda dt: fsmctl.reference_generator(fsmctl.Sinusoid(), dt=dt),
        lambda dt: reaction_wheel_spacecraft(J1, WHEELS, dt=dt),
        lambda dt: law_controller("adaptive_fsm", J1, dt=dt),  # a law with states
        lambda dt: fsmctl.formation(_ring(), dt=dt),
    ):
        for dt in (0.1, True):
            with pytest.raises(ScenarioError, match="continuous-time system") as info:
                make(dt)
            assert "\n" not in str(info.value)
        with pytest.raises(ScenarioError, match="dt: expected 0"):
            make(-1.0)
    # a static law is a memoryless map: any timebase, None unspecified
    assert law_controller("fsm", J1, dt=0.1).dt == 0.1
    assert law_controller("fsm", J1, dt=None).dt is None
    assert law_controller("fsm", J1, dt=True).dt is True


def test_params_at_construction_by_local_name_are_validated_and_used():
    sc = fsmctl.spacecraft(J1, params={"J": J2})
    assert np.allclose(sc.dynamics(0.0, X0, TAU)[4:], _euler(J2, X0[4:], TAU), rtol=1e-13)
    assert np.array_equal(fsmctl.spacecraft(J1, name="a", params={"a_J": J2}).local_params["J"], J2)
    with pytest.raises(ScenarioError, match="not positive definite"):
        fsmctl.spacecraft(J1, params={"J": -J2})
    with pytest.raises(ParameterKeyError, match="unknown parameter 'inertia'"):
        fsmctl.spacecraft(J1, params={"inertia": J2})
    ctrl = law_controller("fsm", J1, params={"c1": 0.25, "u_max": 1.5}, name="c")
    assert ctrl.params["c_c1"] == 0.25 and ctrl.params["c_u_max"] == 1.5
    with pytest.raises(ScenarioError, match="c1"):
        law_controller("fsm", J1, params={"c1": -1.0})
    s = _ring().replace(controller={"torque_limit": float("inf")})
    x = initial_state(s)
    loop = fsmctl.formation(s, params={"c1": 1.2, "ctrl2_c1": 0.3})
    expected = fsmctl.formation(s).dynamics(0.0, x, [], params={"c1": 1.2, "ctrl2_c1": 0.3})
    assert np.array_equal(loop.dynamics(0.0, x, []), expected)
    assert (loop.params["ctrl1_c1"], loop.params["ctrl2_c1"]) == (1.2, 0.3)
    with pytest.raises(InputError, match="sc1_J, sc2_J, sc3_J"):
        fsmctl.formation(s, params={"J": J2})


# ----------------------------------------------------------------------------- local names


def test_a_standalone_system_takes_its_local_names():
    for sc in (fsmctl.spacecraft(J1), fsmctl.spacecraft(J1, name="sc")):
        other = fsmctl.spacecraft(J2)
        assert np.array_equal(sc.dynamics(0.0, X0, TAU, params={"J": J2}), other.dynamics(0.0, X0, TAU))
        assert np.allclose(sc.dynamics(0.0, X0, TAU, params={"J": J2})[4:], _euler(J2, X0[4:], TAU), rtol=1e-13)
        U = np.outer(TAU, [1.0, 1.0])
        r = ct.input_output_response(sc, [0.0, 1.0], U, X0, params={"J": J2})
        assert np.array_equal(r.outputs, ct.input_output_response(other, [0.0, 1.0], U, X0).outputs)
        lin = ct.linearize(sc, X0, TAU, params={"J": J2})
        assert np.array_equal(lin.A, ct.linearize(other, X0, TAU).A)
        with pytest.raises(InputError, match="given twice"):
            sc.dynamics(0.0, X0, TAU, params={"J": J2, sc.param_key("J"): J2})
    # the view by local name: read, set (validated), unknown names refused
    sc = fsmctl.spacecraft(J1, name="sc")
    assert list(sc.local_params) == ["J", "disturbance"] and np.array_equal(sc.local_params["J"], J1)
    sc.local_params["J"] = J2
    assert np.array_equal(sc.params["sc_J"], J2)
    assert np.array_equal(sc.dynamics(0.0, X0, TAU), fsmctl.spacecraft(J2).dynamics(0.0, X0, TAU))
    with pytest.raises(ScenarioError, match="symmetric"):
        sc.local_params["J"] = np.triu(J2)
    with pytest.raises(ParameterKeyError):
        sc.local_params["inertia"] = J2
    assert "inertia" not in sc.local_params


@pytest.mark.filterwarnings("ignore:Unused output")
def test_a_local_name_several_fsmctl_systems_have_is_an_error_naming_them():
    a, b = fsmctl.spacecraft(J1, name="a"), fsmctl.spacecraft(J1, name="b")
    ic = ct.interconnect([a, b], inplist=["a.tau", "b.tau"], outlist=["a.omega", "b.omega"])
    x = np.concatenate([X0, X0])
    with pytest.raises(InputError, match=r"'J'.*\(a_J, b_J\)") as info:
        ic.dynamics(0.0, x, np.zeros(6), params={"J": J2})
    assert "\n" not in str(info.value)
    # one fsmctl system with that name in the interconnection: its parameter
    pd = ct.ss([], [], [], -np.hstack([np.eye(3), 10 * np.eye(3)]), inputs=6, outputs=3, name="pd")
    one = ct.interconnect(
        [a, pd],
        connections=[["a.tau", "pd.y"], ["pd.u[0:3]", "a.sigma"], ["pd.u[3:6]", "a.omega"]],
        outlist=["a.omega"],
    )
    assert np.array_equal(one.dynamics(0.0, X0, [], params={"J": J2}), one.dynamics(0.0, X0, [], params={"a_J": J2}))
    # a formation: J of six plants is ambiguous, omega_d is the reference's, c1 every controller's
    s = _ring()
    loop, x = fsmctl.formation(s), initial_state(s)
    with pytest.raises(InputError, match=r"sc1_J, sc2_J, sc3_J\)"):
        loop.dynamics(0.0, x, [], params={"J": J2})
    w = fsmctl.Sinusoid(offset=(0.0, 0.0, 0.2)).params()
    assert np.array_equal(
        loop.dynamics(0.0, x, [], params={"omega_d": w}), loop.dynamics(0.0, x, [], params={"reference_omega_d": w})
    )
    assert not np.array_equal(loop.dynamics(0.0, x, [], params={"omega_d": w}), loop.dynamics(0.0, x, []))
    # a formation nested in a larger interconnection: a bare law name reaches several controllers -> error
    outer = ct.interconnect([loop], inplist=[], outlist=["formation.sc1_sigma[0]"], name="outer")
    with pytest.raises(InputError, match="ctrl1_c1, ctrl2_c1, ctrl3_c1"):
        outer.dynamics(0.0, x, [], params={"c1": 1.0})


# ----------------------------------------------------------------------------- ownership messages


def test_a_reused_params_dict_is_not_blamed_on_two_systems_of_one_name():
    ref_a = fsmctl.reference_generator(fsmctl.Sinusoid(), name="reference")
    ref_b = fsmctl.reference_generator(fsmctl.Sinusoid(), name="reference")
    q = quaternion_from_mrp([0.1, 0.2, 0.3])
    for call in (
        lambda: ref_b.dynamics(0.0, q, [], params=ref_a.params),
        lambda: ref_b.output(0.0, q, [], params=dict(ref_a.params)),
        lambda: ct.input_output_response(ref_b, [0.0, 0.1], 0, q, params=ref_a.params),
    ):
        with pytest.raises(InputError, match="params= holds the parameters of another system") as info:
            call()
        assert "two systems" not in str(info.value) and "pass only the values to change" in str(info.value)
    s = _ring()
    loop_a, loop_b = fsmctl.formation(s), fsmctl.formation(s)
    with pytest.raises(InputError, match="params= holds the parameters of another system") as info:
        loop_b.dynamics(0.0, initial_state(s), [], params=loop_a.params)
    assert "two systems" not in str(info.value)
    # its own params are fine
    assert np.array_equal(
        loop_b.dynamics(0.0, initial_state(s), [], params=loop_b.params), loop_b.dynamics(0.0, initial_state(s), [])
    )
    # two systems of one name in one interconnection: that case, and its remedy
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # python-control: duplicate name
        ic = ct.interconnect([ref_a, ref_b], inplist=[], outlist=["reference.sigma_d"])
    with pytest.raises(InputError, match="two systems made with name='reference' are in one interconnection") as info:
        ic.dynamics(0.0, np.concatenate([q, q]), [])
    assert "unique name" in str(info.value)


# ----------------------------------------------------------------------------- pickling


def _systems() -> list[tuple[ct.NonlinearIOSystem, np.ndarray, np.ndarray]]:
    """Every kind of system the factories make, with a state and an input to evaluate it at."""
    paper = fsmctl.paper_scenario("1")
    a, delta = paper.agents[0], paper.law_parameters()[0]["delta"]
    nb = [Neighbour("sc2", 8.0, Schedule.constant(5.0))]
    u_law = np.concatenate([[0.1, -0.2, 0.3, 0.01, 0.0, -0.02], [0.0] * 3, [0.0, 0.0, 0.01], [0.0] * 3, [0.1] * 3])
    sc = fsmctl.spacecraft(J1, disturbance=fsmctl.Sinusoid(amplitude=(0.01, 0.0, 0.0), frequency=(0.5, 0, 0)))
    sc.local_params["J"] = J2  # a value changed after construction travels with the pickle
    renamed = fsmctl.spacecraft(J1, name="bus", inputs=["Tx", "Ty", "Tz"]).copy("bus2")
    plant = reaction_wheel_spacecraft(J1, WHEELS, name="rw")
    return [
        (sc, X0, TAU),
        (renamed, X0, TAU),
        (fsmctl.reference_generator(paper.reference.omega, name="reference"), X0[:4], np.zeros(0)),
        (fsmctl.fsm_controller(a.J0_array, paper.controller, delta, neighbours=nb, name="ctrl1"), np.zeros(0), u_law),
        (law_controller("adaptive_fsm", a.J0_array, neighbours=nb, params={"u_max": 1.0}), np.full(3, 0.01), u_law),
        (
            plant,
            reaction_wheel_state(plant, [0.1, 0.0, 0.0], [0.0, 0.01, 0.0], [10.0, 0.0, -5.0]),
            np.r_[TAU, 0, 0, 0, 0.01, 0.0, -0.02],
        ),
    ]


def test_every_system_pickles_and_evaluates_bit_for_bit():
    for sys, x, u in _systems():
        twin = pickle.loads(pickle.dumps(sys))
        assert type(twin) is type(sys) and twin.name == sys.name
        assert (twin.input_labels, twin.output_labels, twin.state_labels, twin.dt) == (
            sys.input_labels,
            sys.output_labels,
            sys.state_labels,
            sys.dt,
        )
        assert list(twin.params) == list(sys.params)
        for local in sys.local_params:
            assert np.array_equal(twin.local_params[local], sys.local_params[local])
        assert np.array_equal(twin.output(0.3, x, u), sys.output(0.3, x, u))
        if sys.nstates:
            assert np.array_equal(twin.dynamics(0.3, x, u), sys.dynamics(0.3, x, u))


def test_an_unpickled_formation_is_consistent_and_flies_bit_for_bit():
    s = _ring().replace(actuator={"kind": "reaction_wheels", "layout": "orthogonal", "spin_inertia": 0.05})
    loop = fsmctl.formation(s, params={"c1": 0.9})
    loop.params["sc2_J"] = 1.1 * np.asarray(loop.params["sc2_J"])  # changed after construction
    twin = pickle.loads(pickle.dumps(loop))
    x, u = initial_state(s), np.zeros(loop.ninputs)  # the wheels' open-loop inputs sc<i>_u_wheels: zero
    assert type(twin) is type(loop) and twin.law_parameters == loop.law_parameters
    assert np.array_equal(twin.dynamics(0.0, x, u), loop.dynamics(0.0, x, u))
    assert np.array_equal(twin.dynamics(0.0, x, u, params={"c1": 0.4}), loop.dynamics(0.0, x, u, params={"c1": 0.4}))
    T = [0.0, 0.02]
    options = {"solve_ivp_kwargs": {"max_step": 0.005}}
    r, r_twin = (ct.input_output_response(sys, T, 0, x, **options) for sys in (loop, twin))
    assert np.array_equal(r.outputs, r_twin.outputs)


def test_sensors_links_and_sampled_loops_pickle_bit_for_bit():
    """The hardware blocks and the sampled-data loop are closures over drawn noise and held inputs: they pickle as
    the call that made them, which draws the same noise again from the seed."""
    T = np.arange(11) * 0.1
    U = np.vstack([0.1 * np.sin(T), 0.2 * np.cos(T), T])
    blocks = [
        fsmctl.star_tracker([1e-3, 2e-3, 3e-3], 0.1, horizon=1.0, seed=3, name="st"),
        fsmctl.rate_gyro(1e-4, 1e-5, [1e-3, 0.0, 0.0], 0.1, horizon=1.0, dt=0, name="gyro"),
        fsmctl.link(0.25, 0.3, 0.1, horizon=1.0, seed=2, name="ln"),
    ]
    for block in blocks:
        twin = pickle.loads(pickle.dumps(block))
        assert twin.name == block.name and twin.dt == block.dt
        x0 = np.zeros(block.nstates)
        a, b = (ct.input_output_response(sys, T, U, x0).outputs for sys in (block, twin))
        assert np.array_equal(a, b) and np.ptp(a) > 0  # noise or delay acted, identically
    s = _ring().replace(
        simulation={"t_final": 0.3, "control_period": 0.1}, sensors={"star_tracker": {"noise_std": [1e-3] * 3}}
    )
    loop, x0 = fsmctl.formation(s), initial_state(s)
    twin = pickle.loads(pickle.dumps(loop))
    steps = np.arange(4) * 0.1
    a, b = (ct.input_output_response(sys, steps, 0, x0).outputs for sys in (loop, twin))
    assert twin.dt == loop.dt == 0.1 and np.array_equal(a, b)


def _sweep_point(loop: fsmctl.plugin.FormationSystem, x0: np.ndarray, c1: float) -> np.ndarray:
    return ct.input_output_response(
        loop, [0.0, 0.05], 0, x0, params={"c1": c1}, solve_ivp_kwargs={"max_step": 0.01}
    ).outputs[:, -1]


def test_a_process_pool_sweep_gives_the_serial_numbers():
    s = _ring().replace(controller={"torque_limit": float("inf")})  # unsaturated: c1 acts at once
    loop, x0 = fsmctl.formation(s), initial_state(s)
    gains = [0.4, 1.0]
    serial = [_sweep_point(loop, x0, c1) for c1 in gains]
    # spawn: fresh interpreters that only get what pickle carries (the default on macOS and Windows, and Dask's)
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as pool:
        pooled = list(pool.map(_sweep_point, [loop] * len(gains), [x0] * len(gains), gains))
    for a, b in zip(serial, pooled, strict=True):
        assert np.array_equal(a, b)
    assert not np.array_equal(serial[0], serial[1])  # the gain acts


def test_a_state_that_is_not_the_systems_warns_once_and_sample_system_names_the_route():
    """python-control pads a short X0 with zeros: the MRP state [sigma, omega] of a design handed to the quaternion
    plant flies q / |q|, another attitude.  A unit quaternion stays silent; ct.sample_system names fsmctl's zoh."""
    sc = fsmctl.spacecraft(np.diag([100.0, 150.0, 200.0]), name="sc")
    with pytest.warns(fsmctl.plugin.QuaternionNormWarning, match=r"\|q\| = 0.224, far from 1") as caught:
        ct.input_output_response(sc, [0.0, 1.0], 0, [0.1, 0.2, 0.0, 0.0, 0.0, 0.0])
    assert len(caught) == 1  # once per system, not once per solver step
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        x0 = np.concatenate([fsmctl.plugin.quaternion_from_mrp([0.1, 0.2, 0.0]), np.zeros(3)])
        ct.input_output_response(fsmctl.spacecraft(np.eye(3), name="ok"), [0.0, 1.0], 0, x0)
    with pytest.raises(InputError, match=r"fsmctl.plugin.zoh\(sys, 0.1, step=...\)"):
        ct.sample_system(sc, 0.1)
