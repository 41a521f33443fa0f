"""Runs flown together: the monitor hook (early stopping) of simulate/simulate_many, and batches of scenarios
packed into one compiled loop, each member bit-identical to its run alone."""

from __future__ import annotations

import numpy as np
import pytest

from fsmctl.simulation.simulator import SimulationError, simulate, simulate_many

ARRAYS = (
    "time", "sigma", "omega", "sigma_e", "omega_e", "broadcast", "z", "u", "u_unsaturated", "sigma_d",
    "saturated_time", "u_total_variation", "u_unsaturated_max",
)  # fmt: skip
HARDWARE = ("wheel_speed", "wheel_torque", "sigma_measured", "omega_measured")


def bits(a) -> bytes:
    a = np.ascontiguousarray(a)
    return a.dtype.str.encode() + repr(a.shape).encode() + a.tobytes()


def assert_identical(a, b, prefix: int | None = None):
    """Every array of two results equal bit for bit (``prefix``: ``a`` is the first rows of ``b``)."""
    for k in ARRAYS[:10] + HARDWARE:
        x, y = getattr(a, k), getattr(b, k)
        assert (x is None) == (y is None), k
        if x is None:
            continue
        if prefix is not None:
            y = y[:prefix]
        assert bits(x) == bits(y), k
    if prefix is None:
        for k in ARRAYS[10:]:
            assert bits(getattr(a, k)) == bits(getattr(b, k)), k
        assert (a.steps_taken, a.steps_rejected) == (b.steps_taken, b.steps_rejected)
        sa, sb = a.summary(), b.summary()
        sa.pop("wall_time_s"), sb.pop("wall_time_s")
        assert repr(sa) == repr(sb)


@pytest.fixture(scope="module")
def short(paper_case1):
    return paper_case1.replace(simulation={"t_final": 3.0})


# ----------------------------------------------------------------------------- monitor


@pytest.mark.parametrize("integrator", ["rk4", "dopri45"])
def test_monitor_stops_and_the_result_is_the_prefix_of_the_full_run(short, integrator):
    s = short.replace(simulation={"integrator": integrator})
    full = simulate(s)
    seen = []

    def monitor(t, partial):
        results = partial()
        assert len(results) == 1 and results[0].stopped_at is None
        assert float(results[0].time[-1]) == t
        seen.append(t)
        return t >= 1.0

    early = simulate(s, monitor=monitor, monitor_interval=0.5)
    assert seen == [0.5, 1.0]
    assert early.stopped_at == 1.0 and float(early.time[-1]) == 1.0
    assert_identical(early, full, prefix=early.time.size)
    assert full.stopped_at is None


def test_monitor_that_never_stops_changes_nothing(short):
    full = simulate(short)
    calls = []
    watched = simulate(short, monitor=lambda t, partial: calls.append(t) or False, monitor_interval=1.0)
    assert calls == [1.0, 2.0]  # not at t_final
    assert watched.stopped_at is None
    assert_identical(watched, full)


def test_stopped_rk4_statistics_are_those_of_the_shorter_run(short):
    """RK4 takes the same steps up to the stop: the run statistics equal those of a run ending there."""
    early = simulate(short, monitor=lambda t, partial: True, monitor_interval=1.2)
    assert early.stopped_at == pytest.approx(1.2)
    shorter = simulate(short.replace(simulation={"t_final": 1.2}))
    assert_identical(early, shorter)


def test_monitor_interval_is_rounded_to_the_output_grid(short):
    seen = []
    simulate(short, monitor=lambda t, partial: seen.append(t) or False, monitor_interval=0.333)
    assert seen == pytest.approx([0.33 * k for k in range(1, 10)])  # outputs every 0.01 s
    seen.clear()
    simulate(short, monitor=lambda t, partial: seen.append(t) or False)  # default: a tenth of the run
    assert seen == pytest.approx([0.3 * k for k in range(1, 10)])
    with pytest.raises(ValueError, match="monitor_interval"):
        simulate(short, monitor=lambda t, partial: False, monitor_interval=-1.0)


def test_monitor_exception_propagates(short):
    def monitor(t, partial):
        raise RuntimeError("hopeless")

    with pytest.raises(RuntimeError, match="hopeless"):
        simulate(short, monitor=monitor, monitor_interval=1.0)


@pytest.mark.filterwarnings("ignore::fsmctl.simulation.simulator.StepSizeWarning")
def test_simulate_many_errors_return_or_raise(short):
    bad = short.replace(controller={"torque_limit": float("inf"), "c1": 1e4})  # RK4 unstable: fails at t = 3.5 ms
    with pytest.raises(SimulationError):
        simulate_many([short, bad])
    out = simulate_many([short, bad, short], errors="return")
    assert isinstance(out[1], SimulationError)
    assert_identical(out[0], simulate(short))
    assert_identical(out[2], out[0])
    with pytest.raises(ValueError, match="errors"):
        simulate_many([short], errors="ignore")


# ----------------------------------------------------------------------------- batches


def ensemble(base, count: int, seed: int = 3):
    """Runs of one formation with different inertias, initial states, disturbances and topologies (Monte Carlo
    draws), gains and torque limits."""
    from fsmctl.studies.montecarlo import CampaignSettings, sample_run_scenario

    settings = CampaignSettings(runs=count, seed=seed, t_final=base.simulation.t_final)
    seeds = np.random.SeedSequence(seed).spawn(count)
    runs = [sample_run_scenario(base, settings, q) for q in seeds]
    gain = base.law.parameters[0]  # c1 (fsm, adaptive_fsm) or K (pid)

    def controller(k):
        value = gain.default[0] * (0.5 + 0.25 * k)
        change = {gain.name: value} if gain.name == "c1" else {"parameters": {gain.name: value}}
        return {**change, "torque_limit": 1.0 + k}

    return [r.replace(controller=controller(k)) for k, r in enumerate(runs)]


@pytest.mark.parametrize("law", ["fsm", "adaptive_fsm", "pid"])
def test_every_member_of_a_batch_is_its_run_alone(short, law):
    runs = ensemble(short.replace(controller={"law": law}), 5)
    alone = [simulate(s) for s in runs]
    for size in (2, 5):
        together = simulate_many(runs, batch_size=size)
        for a, b in zip(together, alone, strict=True):
            assert_identical(a, b)
            assert b.stopped_at is None and a.stopped_at is None
            assert a.sigma.flags.c_contiguous and a.u.flags.c_contiguous  # each run's outputs contiguous


def test_batch_of_the_paper_case_with_hold_and_exact_kinematics(short):
    for change in ({"simulation": {"control_period": 0.01}}, {"controller": {"error_model": "exact"}}):
        runs = [short.replace(**change).replace(controller={"c2": 0.5 + 0.1 * k}) for k in range(3)]
        for a, s in zip(simulate_many(runs), runs, strict=True):
            assert_identical(a, simulate(s))


def test_stack_is_block_diagonal_and_keys_refuse_what_cannot_fly_together(short):
    from fsmctl.model.problem import batch_key, pack, stack

    runs = ensemble(short, 3)
    ps = [pack(s) for s in runs]
    st = stack(ps)
    n = ps[0].n_agents
    assert st.n_agents == 3 * n and st.n_links == sum(p.n_links for p in ps)
    assert st.x0.size == 3 + sum(p.x0.size - 3 for p in ps)
    member = np.repeat(np.arange(3), [p.n_links for p in ps])
    assert np.array_equal(st.link_receiver // n, member) and np.array_equal(st.link_sender // n, member)
    assert np.array_equal(st.link_weights(7.3), np.concatenate([p.link_weights(7.3) for p in ps]))
    assert batch_key(pack(short.replace(simulation={"integrator": "dopri45"}))) is None
    assert batch_key(pack(short.replace(actuator={"kind": "reaction_wheels", "layout": "pyramid"}))) is None
    other = short.replace(reference={"sigma0": (0.1, 0.0, 0.0)})
    assert batch_key(pack(other)) != batch_key(ps[0])
    with pytest.raises(ValueError, match="cannot fly together"):
        stack([ps[0], pack(other)])


def test_mixed_list_keeps_the_order_and_flies_the_rest_alone(short):
    runs = [
        short,
        short.replace(simulation={"integrator": "dopri45"}),
        short.replace(controller={"c1": 0.9}),
        short.replace(simulation={"t_final": 2.0}),  # another horizon: another group
        short.replace(actuator={"kind": "reaction_wheels", "layout": "pyramid"}),
        short.replace(controller={"law": "pid"}),
        short.replace(controller={"c1": 0.3}),
    ]
    for a, s in zip(simulate_many(runs), runs, strict=True):
        assert a.scenario is s
        assert_identical(a, simulate(s))


@pytest.mark.filterwarnings("ignore::fsmctl.simulation.simulator.StepSizeWarning")
def test_a_failing_member_does_not_corrupt_the_others(short):
    runs = ensemble(short, 4)
    runs[2] = runs[2].replace(controller={"torque_limit": float("inf"), "c1": 1e4})  # fails at t = 3.5 ms
    out = simulate_many(runs, errors="return")
    with pytest.raises(SimulationError) as alone:
        simulate(runs[2])
    assert isinstance(out[2], SimulationError) and str(out[2]) == str(alone.value)
    for k in (0, 1, 3):
        assert_identical(out[k], simulate(runs[k]))
    with pytest.raises(SimulationError):
        simulate_many(runs)


def test_the_memory_check_covers_the_whole_batch(short, monkeypatch):
    """A batch whose buffers do not fit is halved until they do; a run that does not fit alone is refused."""
    from fsmctl.errors import ResourceLimitError
    from fsmctl.model.problem import pack
    from fsmctl.simulation import simulator

    runs = ensemble(short, 4)
    buffers = pack(runs[0]).output_bytes * simulator.RESULT_MEMORY_FACTOR
    room = simulator.RAEM_WORKING_BYTES + int(2.5 * buffers)  # two runs fit, four do not
    one = simulator.RAEM_WORKING_BYTES + int(0.5 * buffers)  # not even one
    sizes = []
    real = simulator.check_output_memory

    def fake(p, *, available=None):
        sizes.append(p.n_agents)
        return real(p, available=room)

    monkeypatch.setattr(simulator, "check_output_memory", fake)
    out = simulate_many(runs)
    assert sizes[0] == 4 * short.n_agents and 2 * short.n_agents in sizes and 4 * short.n_agents not in sizes[1:]
    monkeypatch.setattr(simulator, "check_output_memory", real)
    for a, s in zip(out, runs, strict=True):
        assert_identical(a, simulate(s))
    monkeypatch.setattr(simulator, "check_output_memory", lambda p, available=None: real(p, available=one))
    with pytest.raises(ResourceLimitError):
        simulate_many(runs[:2])


def test_monitor_sees_the_batch_and_stops_it(short):
    runs = ensemble(short, 3)
    full = [simulate(s) for s in runs]
    seen = []

    def monitor(t, partial):
        results = partial()
        seen.append((t, [r.scenario for r in results]))
        for r, f in zip(results, full, strict=True):
            assert_identical(r, f, prefix=r.time.size)
        return t >= 2.0

    out = simulate_many(runs, monitor=monitor, monitor_interval=1.0)
    assert [t for t, _ in seen] == [1.0, 2.0] and seen[0][1] == runs
    for r, f in zip(out, full, strict=True):
        assert r.stopped_at == 2.0
        assert_identical(r, f, prefix=r.time.size)
    watched = simulate_many(runs, monitor=lambda t, partial: False, monitor_interval=1.0)
    for r, f in zip(watched, full, strict=True):
        assert_identical(r, f)
