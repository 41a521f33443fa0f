"""The no-compiler fallback (:mod:`fsmctl.simulation.casadi_formation`) against the compiled engine.

The fallback flies any law through the law contract with ``formation.c``'s semantics (link weights at the RK4
step midpoint, zero-order hold, records, run statistics, the Dormand-Prince step control), so on the same
packed problem it must give the compiled engine's arrays: checked to 1e-9 relative on every array, for the
paper's law and for a law with a state (a PI law written in the test), with CasADi's virtual machine
(``FSMCTL_NO_COMPILE=1`` in a subprocess) and in-process (the loop logic on the compiled per-agent functions).
"""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from formations import PI_LAW

import fsmctl
from fsmctl.model.laws import derive_script, resolve_law
from fsmctl.model.problem import pack
from fsmctl.simulation.casadi_formation import RunStatistics, rk4_update, simulate_casadi, step_times
from fsmctl.simulation.simulator import SimulationError, simulate_packed

ARRAYS = (
    "t", "sigma_d", "sigma", "omega", "sigma_e", "omega_e", "broadcast", "z", "u", "u_unsat",
    "saturated_time", "u_total_variation", "u_unsat_max",
)  # fmt: skip

VM_RUN = textwrap.dedent(
    """
    import sys
    import numpy as np
    import fsmctl
    from fsmctl.model.problem import pack
    from fsmctl.simulation.simulator import simulate_packed

    law, t_final, out = sys.argv[1], float(sys.argv[2]), sys.argv[3]
    sc = fsmctl.paper_scenario("1").replace(simulation={"t_final": t_final, "output_interval": 0.1})
    raw = simulate_packed(pack(sc, law))
    assert raw["backend"] == "casadi-vm", raw["backend"]
    np.savez(out, steps=[raw["steps_taken"], raw["steps_rejected"]],
             **{k: v for k, v in raw.items() if isinstance(v, np.ndarray)})
    """
)


@pytest.fixture(scope="module")
def pi_law(tmp_path_factory):
    folder = tmp_path_factory.mktemp("pi_law")
    script = folder / "pi_law.py"
    script.write_text(PI_LAW)
    return resolve_law(str(derive_script(script, out=folder / "pi")))


@pytest.fixture(params=["fsm", "pi"])
def law(request, pi_law):
    return resolve_law("fsm") if request.param == "fsm" else pi_law


def case1(t_final: float = 2.0, **simulation):
    return fsmctl.paper_scenario("1").replace(simulation={"t_final": t_final, "output_interval": 0.1, **simulation})


def assert_same(compiled: dict, fallback: dict, rtol: float = 1e-9) -> None:
    """Every array of the raw result agrees to ``rtol`` relative to its own scale."""
    for key in ARRAYS:
        a, b = np.asarray(compiled[key]), np.asarray(fallback[key])
        assert a.shape == b.shape, (key, a.shape, b.shape)
        scale = float(np.abs(a).max()) if a.size else 0.0
        assert np.all(np.abs(a - b) <= rtol * max(scale, 1e-300)), (key, float(np.abs(a - b).max()), scale)


def test_virtual_machine_fallback_agrees_with_the_compiled_engine(law, tmp_path):
    """``FSMCTL_NO_COMPILE=1``: the serialized CasADi functions, run by the fallback's loop (2 s of Case 1)."""
    out = tmp_path / "vm.npz"
    env = {**os.environ, "FSMCTL_NO_COMPILE": "1"}
    folder = "fsm" if law.name == "fsm" else str(law.folder)
    subprocess.run(
        [sys.executable, "-W", "ignore", "-c", VM_RUN, folder, "2.0", str(out)], check=True, env=env, timeout=600
    )
    vm = dict(np.load(out))
    compiled = simulate_packed(pack(case1(2.0), law))
    assert compiled["backend"] == "compiled"
    assert_same(compiled, vm)
    assert list(vm["steps"]) == [2000, 0]
    if law.n_states:
        assert np.abs(vm["z"][-1] - vm["z"][0]).max() > 1e-3  # the law state moved


@pytest.mark.parametrize(
    "simulation",
    [
        {},
        {"control_period": 0.007},  # zero-order hold over 7 steps (not a divisor of the output interval)
        {"integrator": "dopri45", "rtol": 1e-7, "atol": 1e-9},
        {"integrator": "dopri45", "rtol": 1e-6, "atol": 1e-8, "control_period": 0.013},
    ],
    ids=["rk4", "rk4-hold", "dopri45", "dopri45-hold"],
)
def test_fallback_loop_agrees_with_the_compiled_engine(law, simulation):
    """The fallback's loops (RK4 through mapaccum; the Dormand-Prince step control ported from formation.c)."""
    p = pack(case1(2.0, **simulation), law)
    compiled, fallback = simulate_packed(p), simulate_casadi(p)
    assert fallback["backend"] == "casadi-vm"
    assert_same(compiled, fallback)
    assert (fallback["steps_taken"], fallback["steps_rejected"]) == (
        compiled["steps_taken"],
        compiled["steps_rejected"],
    )
    if p.integrator == 1:
        if p.hold_steps == 0:
            assert compiled["steps_rejected"] > 0  # the step control was exercised
        # and the adaptive run is the fixed-step one to its tolerance
        rk4 = simulate_packed(dataclasses.replace(p, integrator=0))
        for key in ("sigma", "omega", "sigma_d"):
            assert np.abs(fallback[key] - rk4[key]).max() < 1e3 * p.rtol


def test_exact_error_model_and_a_formation_without_links():
    sc = case1(1.0).replace(controller={"error_model": "exact"})
    for s in (sc, dataclasses.replace(sc, topology=dataclasses.replace(sc.topology, links=()))):
        p = pack(s)
        assert_same(simulate_packed(p), simulate_casadi(p))


def test_non_finite_command_stops_both_engines_with_one_message():
    p = pack(case1(0.5))
    x0 = p.x0.copy()
    x0[p.agent_slice(2).start + 4] = np.nan  # agent 3's omega
    for q in (dataclasses.replace(p, x0=x0), dataclasses.replace(p, x0=x0, integrator=1)):
        messages = []
        for run in (simulate_packed, simulate_casadi):
            with pytest.raises(SimulationError, match="non-finite torque command") as exc:
                run(q)
            messages.append(str(exc.value))
        assert messages[0] == messages[1]


def test_run_statistics_definition_and_chunking():
    """formation.c ``accumulate``, interval by interval, against :class:`RunStatistics` fed in chunks."""
    rng = np.random.default_rng(4)
    u_max = np.array([1.0, 0.5, 2.0])
    uu = rng.normal(size=(50, 3, 3))
    u = np.clip(uu, -u_max[None, :, None], u_max[None, :, None])
    h = rng.uniform(0.001, 0.01, size=50)
    sat, tv, top = np.zeros(3), np.zeros(3), np.zeros(3)
    for k in range(50):
        for i in range(3):
            sat[i] += h[k] if np.any(np.abs(uu[k, i]) > u_max[i]) else 0.0
            top[i] = max(top[i], np.abs(uu[k, i]).max())
            if k:
                tv[i] += np.abs(u[k, i] - u[k - 1, i]).sum()
    stats = RunStatistics(u_max)
    for a, b in ((0, 1), (1, 17), (17, 17), (17, 50)):
        stats.add(u[a:b], uu[a:b], h[a:b])
    assert np.allclose(stats.saturated_time, sat, rtol=1e-14)
    assert np.allclose(stats.u_total_variation, tv, rtol=1e-14)
    assert np.array_equal(stats.u_unsat_max, top)


def test_rk4_update_is_classical_rk4_and_step_times_use_the_midpoint_for_links():
    """One step of x' = lambda x is the 4th-order Taylor polynomial; the link weights are read at t_k + dt/2."""
    lam, dt, x = -1.3, 0.1, np.array([2.0])
    z = lam * dt
    x1 = rk4_update(lambda t, y: lam * y, x, lam * x, dt, 0.05, 0.1)
    assert np.allclose(x1, x * (1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24), rtol=1e-15)
    p = pack(case1(1.0))
    t, th, t1, tl = step_times(p, 7)
    assert (t, th, t1, tl) == (7 * p.dt, 7.5 * p.dt, 8 * p.dt, 7.5 * p.dt)


@pytest.mark.parametrize("kernels", ["batched", "scalar"])
def test_fast_switching_periodic_links_fly_as_in_the_fallback(kernels):
    """Periodic link schedules with phases, their switches off the step grid and near the ends of their periods,
    and one aperiodic link: the compiled loop skips re-evaluating the link weights while no link can switch
    (formation.c ``link_window``); the fallback evaluates every link at every step (``step_times``).  A weight held
    one step too long changes the torque by a neighbour's whole term, far above the 1e-9 agreement."""
    from fsmctl.model.topology import Link, Schedule, Topology

    base = case1(0.6).replace(simulation={"output_interval": 0.001})
    links = []
    for e, link in enumerate(base.topology.links):
        period = 0.0173 + 0.0011 * (e % 7)
        cuts = (0.0, period * (0.31 + 0.05 * (e % 5)), period * 0.999)  # the last just before the period's end
        values = (0.0, 2.8 + 0.1 * (e % 3), 5.0) if e % 2 else (5.0, 0.0, 0.6)
        links.append(Link(link.receiver, link.sender, link.k_i, Schedule(cuts, values, period), -0.0041 * e))
    links[0] = Link(links[0].receiver, links[0].sender, 1.0, Schedule((0.0, 0.2503, 0.4111), (5.0, 0.0, 2.8)))
    s = dataclasses.replace(base, topology=Topology(base.n_agents, tuple(links)))
    p = pack(s)
    compiled, fallback = simulate_packed(p, kernels=kernels), simulate_casadi(p)
    assert compiled["backend"] == "compiled"
    assert_same(compiled, fallback)
