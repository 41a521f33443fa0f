"""The constraints of ``fsmctl tune`` (:mod:`fsmctl.studies.tune`), each against an independent computation, and each
failing when it should: Theorem 2's margin (:func:`fsmctl.proofs.theorem2.reference_delta_requirement`,
:func:`~fsmctl.proofs.theorem2.delta_margin`), Theorem 1 with the tuned coupling weights, the torque limit after the
transient and the reaction wheels' momentum capacity.  Short horizons and tiny budgets."""

from __future__ import annotations

import itertools
import math
from types import SimpleNamespace

import numpy as np
import pytest

from fsmctl.errors import InputError
from fsmctl.model.scenario import load_scenario
from fsmctl.model.topology import Link, Topology
from fsmctl.proofs.theorem1 import analyze_topology
from fsmctl.proofs.theorem2 import _reference_signals, delta_margin, reference_delta_requirement
from fsmctl.simulation.simulator import simulate
from fsmctl.studies import tune as tn
from fsmctl.studies.tune import TuneSettings, tune
from fsmctl.studies.tune import evaluation as tune_eval


def _independent_requirement(scenario, dt: float = 0.05) -> np.ndarray:
    """Theorem 2 at the reference (sigma_e = 0, omega_e = 0) for Delta_J = kappa J0, written out by hand.

    There the sliding variable's rate with delta = 0 and no coordination is ``G(0) J^-1 (d - w x dJ w - dJ w_dot)``
    with ``G(0) = I/4`` and ``w = omega_d`` (the body is on the reference), so the requirement is ``(1 + kappa) / 4``
    times its absolute value: along the actual trajectory (max over t), and over the bound boxes (the disturbance
    and ``omega_d_dot`` enter affinely, ``omega_d`` at the corners and the centre of its box).
    """
    t = np.arange(0.0, scenario.simulation.t_final + 0.5 * dt, dt)
    wd, wdd = _reference_signals(scenario, t)
    w_box, wd_box = np.asarray(scenario.reference.omega.bound()), np.asarray(scenario.reference.omega.rate_bound())
    corners = [np.zeros(3)] + [np.array(c) * w_box for c in itertools.product((-1, 1), repeat=3)]
    out = []
    for agent in scenario.agents:
        J0, dJ = np.array(agent.J0), np.array(agent.delta_J)
        kappa = float(np.trace(dJ) / np.trace(J0))
        assert np.allclose(dJ, kappa * J0)
        J = J0 + dJ
        rate = np.linalg.solve(J, agent.disturbance(t).T - np.cross(wd.T, (dJ @ wd).T).T - dJ @ wdd)
        along = (1 + kappa) / 4 * np.abs(rate).max(axis=1)
        inv = np.linalg.inv(J0)
        bound = np.zeros(3)
        for w in corners:
            gyro = kappa * inv @ np.cross(w, J0 @ w)
            bound = np.maximum(bound, 0.25 * (np.abs(gyro) + np.abs(inv) @ agent.disturbance.bound() + kappa * wd_box))
        out.append(np.maximum(along, bound))
    return np.array(out)


def test_theorem2_requirement_and_margin_match_an_independent_computation():
    scenario = load_scenario("paper", "1")
    required = reference_delta_requirement(scenario)
    assert required == pytest.approx(_independent_requirement(scenario), rel=1e-9)
    deltas = np.full((6, 3), 0.005)
    assert delta_margin(deltas, required) == pytest.approx(0.005 - required.max())
    assert delta_margin(np.full((6, 3), required.max()), required) == 0.0
    with pytest.raises(ValueError, match="shape"):
        delta_margin(deltas[:2], required)


def test_a_delta_below_theorem2s_requirement_is_infeasible(tmp_path):
    settings = TuneSettings(
        scenario="paper",
        law="fsm",
        budget=8,
        seed=2,
        objectives=("peak_torque",),
        t_final=1.0,
        parameters=("delta",),
        ranges=(("delta", 1e-5, 5e-3),),
        constraints=("theorem2",),
        pruner="none",
    )
    result = tune(settings, tmp_path)
    need = _independent_requirement(load_scenario("paper", "1").replace(simulation={"t_final": 1.0})).max()
    verdicts = set()
    for t in result.trials:
        delta = t["params"]["delta"]
        assert t["constraints"]["theorem2"] == pytest.approx(need - delta, rel=1e-9, abs=1e-15)
        assert t["feasible"] == (delta >= need)
        verdicts.add(t["feasible"])
    assert verdicts == {True, False}


def _scaled_by_hand(topology: Topology, si: float, sj: float) -> Topology:
    return Topology(
        topology.n_agents,
        tuple(Link(k.receiver, k.sender, k.k_i * si, k.k_j.scaled(sj), k.phase) for k in topology.links),
    )


def test_theorem1_follows_the_tuned_coupling_weights(tmp_path):
    # the paper's Table 2 graph has k^i = 8 and k^j = 5 (when on) on every link: with both scaled, Theorem 1 holds
    # exactly when eq 27's k^i >= k^j does, i.e. 5 k_j_scale <= 8 k_i_scale (every pair then has a symmetric eta)
    top = load_scenario("paper", "1").topology
    for si, sj in ((1.0, 1.0), (0.5, 1.0), (1.0, 1.6), (1.0, 1.7), (0.0, 0.0)):
        scaled = tn.scaled_topology(top, si, sj)
        assert scaled == _scaled_by_hand(top, si, sj)
        holds = 5 * sj <= 8 * si
        assert analyze_topology(scaled, 100.0).holds == holds
        assert tn.theorem1_constraint(scaled, 100.0) == (0.0 if holds else pytest.approx(1 + 5 * sj - 8 * si))
    settings = TuneSettings(
        scenario="paper",
        law="fsm",
        budget=8,
        seed=5,
        objectives=("peak_torque",),
        t_final=0.5,
        parameters=("k_i_scale", "k_j_scale"),
        ranges=(("k_i_scale", 0.2, 2.0), ("k_j_scale", 0.2, 2.0)),
        constraints=("theorem1",),
        pruner="none",
    )
    result = tune(settings, tmp_path)
    verdicts = set()
    for t in result.trials:
        si, sj = t["params"]["k_i_scale"], t["params"]["k_j_scale"]
        holds = 5 * sj <= 8 * si
        assert t["constraints"]["theorem1"] == (0.0 if holds else pytest.approx(1 + 5 * sj - 8 * si))
        assert t["feasible"] == holds
        verdicts.add(holds)
    assert verdicts == {True, False}


def test_torque_excess_is_taken_after_the_transient():
    t = np.arange(0.0, 10.01, 0.5)  # 21 samples over 10 s: the steady window is the last 4 s
    u = np.zeros((t.size, 2, 3))
    u[t < 3.0, 0, 1] = -7.0  # saturated during the transient
    u[t >= 3.0, 1, 2] = 1.5
    u[t == 5.0, 0, 0] = 2.5  # one sample above the limit after the transient
    run = SimpleNamespace(
        time=t, u_unsaturated=u, scenario=SimpleNamespace(controller=SimpleNamespace(torque_limit=2.0))
    )
    assert tn.torque_excess(run, since=4.0) == pytest.approx(0.5)  # max over t >= 4 s
    assert tn.torque_excess(run, since=6.0) == pytest.approx(-0.5)
    assert tn.torque_excess(run, since=1.0) == pytest.approx(5.0)
    assert tn.torque_excess(run) == pytest.approx(-0.5)  # unsettled: the last 4 s


def test_torque_constraint_of_a_run_still_saturated_at_the_end(tmp_path):
    # the paper's 2 N m limit, 5 s: nothing settles and the commanded torque is far above the limit at the end
    settings = TuneSettings(
        scenario="paper",
        law="pid",
        budget=2,
        objectives=("peak_torque",),
        t_final=5.0,
        parameters=("K", "P"),
        ranges=(("K", 5.0, 50.0), ("P", 10.0, 100.0)),
        pruner="none",
    )
    result = tune(settings, tmp_path)
    assert result.constraints == ("converged", "torque")
    base = load_scenario("paper", "1").replace(simulation={"t_final": 5.0})
    for t in result.trials:
        run = simulate(tune_eval.trial_scenario(base, "pid", tn.search_space(settings), t["params"]), progress=False)
        last = run.time >= 5.0 - 2.0 - 1e-12  # unsettled: the steady window, the last 40 % of 5 s
        expected = np.abs(run.u_unsaturated[last]).max() - 2.0
        assert t["constraints"]["torque"] == pytest.approx(expected, rel=1e-12) and expected > 0
        assert not t["feasible"]


@pytest.fixture(scope="module")
def wheels(tmp_path_factory):
    """The paper's Case 1 on reaction wheels of 0.01 kg m^2 whose speed limit (30 rad/s: 0.3 N m s) the transient
    reaches, and the same wheels with room to spare (3000 rad/s)."""
    folder = tmp_path_factory.mktemp("wheels")
    paths = {}
    for name, speed in (("small", 30.0), ("large", 3000.0)):
        paths[name] = folder / f"{name}.toml"
        paths[name].write_text(
            'extends = "paper"\n[actuator]\nkind = "reaction_wheels"\nlayout = "pyramid"\nspin_inertia = 0.01\n'
            f"max_torque = 2.0\nmax_speed = {speed}\n",
            encoding="utf-8",
        )
    return paths


def test_wheel_momentum_must_stay_inside_the_capacity(wheels, tmp_path):
    feasible = {}
    for name, path in wheels.items():
        settings = TuneSettings(
            scenario=str(path),
            law="pid",
            budget=2,
            objectives=("wheel_momentum",),
            t_final=1.0,
            parameters=("K", "P"),
            ranges=(("K", 50.0, 100.0), ("P", 100.0, 200.0)),
            constraints=("wheels",),
            pruner="none",
        )
        result = tune(settings, tmp_path / name)
        base = load_scenario(path).replace(simulation={"t_final": 1.0})
        for t in result.trials:
            run = simulate(
                tune_eval.trial_scenario(base, "pid", tn.search_space(settings), t["params"]), progress=False
            )
            speed = 30.0 if name == "small" else 3000.0
            expected = np.abs(run.wheel_speed).max() / speed - tn.WHEEL_CAPACITY_FRACTION
            assert t["constraints"]["wheels"] == pytest.approx(expected, rel=1e-12)
            feasible[name] = t["feasible"]
    assert feasible == {"small": False, "large": True}


def test_which_constraints_apply(wheels):
    paper = load_scenario("paper", "1")
    assert {k for k, why in tn.available_constraints("fsm", paper).items() if not why} == {
        "converged",
        "theorem1",
        "theorem2",
        "torque",
    }
    why = tn.available_constraints("pid", load_scenario(wheels["small"]))
    assert not why["wheels"] and not why["torque"] and "paper's law" in why["theorem1"]
    unlimited = paper.replace(controller={"torque_limit": math.inf})
    assert "no torque limit" in tn.available_constraints("fsm", unlimited)["torque"]
    with pytest.raises(InputError, match="constraint wheels cannot be evaluated"):
        tune(TuneSettings(law="pid", parameters=("K",), ranges=(("K", 1.0, 2.0),), constraints=("wheels",)), "unused")
