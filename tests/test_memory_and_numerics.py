"""Memory bounds, the final sample, Ctrl-C and step-size warnings of the simulator (fsmctl/simulator.py,
fsmctl/metrics.py, fsmctl/figures.py).

Oracles: the relative attitude metric (eq 43) is recomputed with SciPy rotations built from the MRPs (a
route that shares no code with the generated ``mrp_error``/``mrp_principal_angle``); peak memory is read
from the kernel (``ru_maxrss`` of a fresh process); the step-size bounds are recomputed by hand from the
paper's numbers (Liang, Sun & Wang 2012, Sec. 4 and the scenario's documented choices).
"""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
import warnings
from pathlib import Path

import numpy as np
import pytest
from formations import with_agents
from scipy.spatial.transform import Rotation

import fsmctl
from fsmctl.errors import InputError, ResourceLimitError
from fsmctl.model.problem import output_buffer_bytes, pack
from fsmctl.simulation import metrics, simulator
from fsmctl.simulation import result as result_module
from fsmctl.simulation.simulator import SimulationError, StepSizeWarning, simulate, simulate_packed, step_size_report

ROOT = Path(__file__).resolve().parent.parent


def _independent_raem_deg(sigma: np.ndarray) -> np.ndarray:
    """Eq 43 from rotation matrices: theta_ij = angle of R_i R_j^T, sum over i != j, divided by n (n - 1)."""
    T, n, _ = sigma.shape
    rot = [Rotation.from_mrp(sigma[:, i, :]) for i in range(n)]
    total = np.zeros(T)
    for i in range(n):
        for j in range(n):
            if i != j:
                total += (rot[i] * rot[j].inv()).magnitude() ** 2
    return np.degrees(np.sqrt(total / (n * (n - 1))))


def _random_mrps(rng, shape) -> np.ndarray:
    """Uniformly random attitudes as MRPs of the shadow set (|sigma| <= 1, angles up to 180 deg)."""
    q = Rotation.random(int(np.prod(shape)), random_state=rng)
    return q.as_mrp().reshape(*shape, 3)


# ----------------------------------------------------------------------------- RAEM streaming (eq 43)


@pytest.mark.parametrize("working_bytes", [1, 20_000, 10**9])
def test_streamed_raem_equals_the_direct_and_an_independent_computation(working_bytes):
    rng = np.random.default_rng(3)
    sigma_e = 0.7 * _random_mrps(rng, (37, 7))  # angles below ~140 deg: no 180-deg ambiguity of a pair
    direct = metrics.raem_deg(metrics.relative_principal_angles(sigma_e))  # the former (T, n, n) route
    streamed = metrics.streamed_raem_deg(sigma_e, working_bytes=working_bytes)  # 1 byte: one sample per block
    assert np.array_equal(streamed, direct)  # same numbers to the bit, whatever the block size
    np.testing.assert_allclose(streamed, _independent_raem_deg(sigma_e), rtol=1e-12, atol=1e-10)


def test_accessors_match_the_full_array():
    rng = np.random.default_rng(4)
    sigma_e = 0.6 * _random_mrps(rng, (11, 5))
    full = metrics.relative_principal_angles(sigma_e)
    assert np.array_equal(metrics.relative_angles_at(sigma_e[4]), full[4])
    assert np.array_equal(metrics.pair_angles(sigma_e, 1, 3), full[:, 1, 3])
    assert np.array_equal(metrics.pair_angles(sigma_e, 3, 1), full[:, 3, 1])
    np.testing.assert_allclose(
        full[:, 0, 2], (Rotation.from_mrp(sigma_e[:, 0]) * Rotation.from_mrp(sigma_e[:, 2]).inv()).magnitude()
    )
    with pytest.raises(IndexError):
        metrics.pair_angles(sigma_e, 0, 5)


def test_blocked_evaluation_is_bit_identical_across_block_boundaries(monkeypatch):
    """Inputs longer than MAP_BLOCK are evaluated in blocks (padded tail): the values must not change."""
    rng = np.random.default_rng(5)
    sigma = _random_mrps(rng, (1000,))
    whole = metrics.principal_angles(sigma)
    monkeypatch.setattr(metrics, "MAP_BLOCK", 64)
    assert np.array_equal(metrics.principal_angles(sigma), whole)  # 15 full blocks and a padded tail of 40


def test_run_metrics_against_rotations_and_without_the_pairwise_array(paper_case1, monkeypatch):
    """Case 1 for 1 s: RAEM of the run equals eq 43 from the body attitudes sigma_i (the reference cancels in
    sigma_i (x) sigma_j^-1, so this also checks sigma_e), and summary()/to_dataset() never build (T, n, n)."""
    r = simulate(paper_case1.replace(simulation={"t_final": 1.0}), progress=False)

    def forbidden(*args, **kwargs):
        raise AssertionError("the (T, n, n) relative-angle array was built")

    monkeypatch.setattr(result_module, "relative_principal_angles", forbidden)
    summary = r.summary()
    ds = r.to_dataset()
    np.testing.assert_allclose(r.raem_deg, _independent_raem_deg(r.sigma), rtol=1e-10, atol=1e-9)
    assert summary["raem_initial_deg"] == pytest.approx(_independent_raem_deg(r.sigma[:1])[0], rel=1e-12)
    assert np.array_equal(ds["raem_deg"].values, r.raem_deg)
    monkeypatch.undo()
    assert np.array_equal(r.theta_relative[7], r.relative_angles_at(7))  # still available, same numbers
    assert np.array_equal(r.pair_angles(0, 5), r.theta_relative[:, 0, 5])


# ----------------------------------------------------------------------------- memory


def test_output_estimate_counts_the_buffers(paper_case1):
    p = pack(paper_case1.replace(simulation={"t_final": 2.0}))
    raw = simulate_packed(p)
    rows = p.n_outputs + 1  # what simulate_packed allocates
    arrays = ("sigma", "omega", "sigma_e", "omega_e", "broadcast", "z", "u", "u_unsat")
    allocated = sum(raw[k].base.nbytes if raw[k].base is not None else raw[k].nbytes for k in arrays)
    # six 3-vectors per agent, the paper law's broadcast s (3) and no law state
    assert allocated == 7 * rows * p.n_agents * 3 * 8
    assert output_buffer_bytes(p.n_agents, rows, p.n_broadcast, p.n_states) >= allocated + 8 * rows * 4  # + t, sigma_d
    assert p.output_bytes == output_buffer_bytes(p.n_agents, rows, 3, 0)
    assert output_buffer_bytes(p.n_agents, rows, 3, 3) == p.output_bytes + 3 * 8 * rows * p.n_agents  # law states


def test_available_memory_sources(monkeypatch):
    total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    avail = simulator.available_memory()
    assert avail is None or 0 < avail <= total
    monkeypatch.setitem(sys.modules, "psutil", None)  # import psutil -> ImportError: /proc/meminfo
    from_meminfo = simulator.available_memory()
    if Path("/proc/meminfo").is_file():
        assert from_meminfo is not None and 0 < from_meminfo <= total


def test_refused_before_allocation_with_a_one_line_message(paper_case1, monkeypatch):
    s = paper_case1.replace(simulation={"t_final": 100.0})
    monkeypatch.setattr(simulator, "available_memory", lambda: 50 * 10**6)

    def no_run(*args, **kwargs):
        raise AssertionError("the run was started")

    monkeypatch.setattr(simulator, "_CProblem", no_run)
    with pytest.raises(ResourceLimitError) as err:
        simulate(s, progress=False)
    msg = str(err.value)
    assert "\n" not in msg and isinstance(err.value, InputError)  # the command line's exit 2
    for part in ("6 agents x 10,001 output samples", "only 50 MB is available", "output_interval (now 0.01 s",
                 "t_final (now 100 s)"):  # fmt: skip
        assert part in msg, msg


def test_the_casadi_fallback_is_bounded_the_same_way(paper_case1, monkeypatch):
    import fsmctl.simulation.casadi_formation as cf

    monkeypatch.setattr(simulator, "_driver", lambda *law: None)
    monkeypatch.setattr(simulator, "available_memory", lambda: 50 * 10**6)
    monkeypatch.setattr(cf, "simulate_casadi", lambda *a, **k: pytest.fail("the fallback run was started"))
    with pytest.raises(ResourceLimitError, match="output_interval"):
        simulate(paper_case1.replace(simulation={"t_final": 100.0}), progress=False)


def test_a_huge_horizon_is_refused_on_any_machine(paper_case1):
    """--t-final 1e7 at the paper's output interval: 1e9 samples, ~1.4 TB of buffers: refused at once."""
    t0 = time.perf_counter()
    with pytest.raises(ResourceLimitError, match=r"TB of memory .* raise output_interval"):
        simulate(paper_case1.replace(simulation={"t_final": 1e7}), progress=False)
    assert time.perf_counter() - t0 < 5.0


def test_theta_relative_refuses_when_it_cannot_fit(paper_case1, monkeypatch):
    r = simulate(paper_case1.replace(simulation={"t_final": 0.5}), progress=False)
    monkeypatch.setattr(result_module, "available_memory", lambda: 1000)
    with pytest.raises(ResourceLimitError, match="relative_angles_at"):
        r.theta_relative  # noqa: B018
    assert r.relative_angles_at(-1).shape == (6, 6)  # the cheap accessors still work


def test_peak_memory_of_200_agents_in_a_fresh_process(tmp_path):
    """200 agents on a ring for 5 s (501 samples) with summary(), NetCDF and figures: the former code peaked at
    2.2 GB (its (T, n, n) relative angles and intermediates); now ~0.25 GB."""
    proc = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "memory.py"), "--child", "200", "5", str(tmp_path)],
        capture_output=True,
        text=True,
        env={**os.environ, "MPLBACKEND": "Agg"},
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    report = json.loads(proc.stdout.strip().splitlines()[-1])
    peak = max(report["peak_rss_bytes"].values())
    assert peak < 0.8e9, report  # the old code needs 2.2e9 here
    assert report["output_samples"] == 501
    from PIL import Image

    for name in ("torques", "theta_e"):
        width, height = Image.open(tmp_path / f"{name}.png").size
        assert height < 2500, (name, width, height)  # was 27 000 pixels tall for 200 agents


# ----------------------------------------------------------------------------- figures of large formations


def test_figures_cap_the_per_agent_drawing():
    from fsmctl.studies.figures import MAX_AGENTS_DRAWN, principal_angles_figure, torques_figure

    rng = np.random.default_rng(6)
    T, n = 50, 40
    t = np.linspace(0.0, 1.0, T)
    u = rng.uniform(-1.0, 1.0, (T, n, 3))
    u[:, 17] *= 2.0  # the agent with the largest RMS torque must be drawn
    fig = torques_figure(t, u, 2.0, title="run")
    assert len(fig.axes) == 3  # one panel per body axis
    for ax in fig.axes:
        labels = [line.get_label() for line in ax.lines if line.get_gid() != "limit"]
        assert len(labels) == MAX_AGENTS_DRAWN - 1 and "u18" in labels
        assert [c.get_label() for c in ax.collections] == [f"min-max of all {n}"]
    assert f"11 of {n} agents drawn" in fig._suptitle.get_text()
    assert fig.get_size_inches()[1] < 15
    theta = rng.uniform(0.0, 10.0, (T, n))
    theta[:, 3] += 50.0
    fig = principal_angles_figure(t, theta, title="run")
    ax = fig.axes[0]
    assert len(ax.lines) == MAX_AGENTS_DRAWN + 1  # 12 agents and the median
    assert "θ4" in [line.get_label() for line in ax.lines]
    assert f"12 of {n} spacecraft drawn" in ax.get_title()
    small = torques_figure(t, u[:, :5], 2.0)
    assert [len([ln for ln in ax.lines if ln.get_gid() != "limit"]) for ax in small.axes] == [5, 5, 5]
    assert all(len(ax.collections) == 0 for ax in small.axes)  # small formations: every agent drawn, no envelope


# ----------------------------------------------------------------------------- the final state


@pytest.mark.parametrize("integrator", ["rk4", "dopri45"])
def test_last_sample_is_t_final(paper_case1, integrator):
    for t_final, interval in ((0.3, 0.1), (0.7, 0.07), (1.0, 0.25)):
        s = paper_case1.replace(simulation={"t_final": t_final, "output_interval": interval, "integrator": integrator})
        r = simulate(s, progress=False)
        assert r.time[-1] == pytest.approx(t_final, rel=1e-12, abs=1e-12)
        assert r.time.size == round(t_final / interval) + 1


@pytest.mark.parametrize("backend", ["compiled", "casadi-vm"])
def test_an_output_grid_that_misses_t_final_is_an_error(paper_case1, monkeypatch, backend):
    if backend == "casadi-vm":
        monkeypatch.setattr(simulator, "_driver", lambda *law: None)
    p = dataclasses.replace(pack(paper_case1.replace(simulation={"t_final": 0.1})), output_every=30)  # 100 steps
    with pytest.raises(SimulationError, match=r"output grid misses the final state.*last 10 steps"):
        simulate_packed(p)


@pytest.mark.parametrize(
    ("backend", "integrator"), [("compiled", 0), ("compiled", 1), ("casadi-vm", 0), ("casadi-vm", 1)]
)
def test_no_backend_returns_without_the_final_state(paper_case1, monkeypatch, backend, integrator):
    """With the up-front check disabled, every backend and integrator must still return the final state or
    raise: never silently drop it."""
    if backend == "casadi-vm":
        monkeypatch.setattr(simulator, "_driver", lambda *law: None)
    monkeypatch.setattr(simulator, "_check_output_grid", lambda p: None)
    p = dataclasses.replace(
        pack(paper_case1.replace(simulation={"t_final": 0.1})), output_every=30, integrator=integrator
    )
    try:
        raw = simulate_packed(p)
    except SimulationError as exc:
        assert "not at t_final" in str(exc)
    else:
        assert raw["t"][-1] == pytest.approx(0.1, abs=1e-12)


# ----------------------------------------------------------------------------- Ctrl-C


def _warm_library():
    simulate(fsmctl.paper_scenario("1").replace(simulation={"t_final": 0.01}), progress=False)  # compiled, cached


@pytest.mark.parametrize("progress", ["--no-progress", "--progress"])
def test_sigint_during_simulate_exits_130_without_a_traceback(tmp_path, progress):
    _warm_library()
    env = {**os.environ, "PYTHONUNBUFFERED": "1", "MPLBACKEND": "Agg"}
    # 3000 s of Case 1 is ~30 s of compiled loop: the signal lands inside it
    cmd = [sys.executable, "-m", "fsmctl.cli.main", "simulate", "--scenario", "paper", "--t-final", "3000",
           "--output-interval", "1", "--no-figures", progress, "--out", str(tmp_path / "out")]  # fmt: skip
    t0 = time.monotonic()
    # a shell's background job starts with SIGINT ignored, and POSIX programs keep that: give the child the
    # default disposition, as an interactive terminal would
    proc = subprocess.Popen(
        cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )  # fmt: skip
    assert proc.stdout.readline().startswith("scenario paper")  # describe(): the run starts next
    time.sleep(2.0)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, (out, err)
    assert "Traceback" not in err and "ctypes" not in err and "Exception ignored" not in err, err
    assert err.rstrip().endswith("interrupted"), err
    assert not list((tmp_path / "out").glob("*.nc"))  # stopped, not run to the end (~30 s of loop)
    assert time.monotonic() - t0 < 20.0


def test_sigint_in_the_library_raises_keyboardinterrupt_and_restores_the_handler():
    script = textwrap.dedent(
        """
        import os, signal, threading, time, warnings
        warnings.filterwarnings("ignore", message=".*triangle.*")
        import fsmctl
        from fsmctl.simulation.simulator import simulate
        s = fsmctl.paper_scenario("1")
        simulate(s.replace(simulation={"t_final": 0.01}), progress=False)
        long_run = s.replace(simulation={"t_final": 3000.0, "output_interval": 1.0})
        calls = []
        def custom(signum, frame):
            calls.append(signum)  # a handler that does not raise: the run must still stop
        for handler in (signal.default_int_handler, custom):
            signal.signal(signal.SIGINT, handler)
            threading.Timer(1.0, os.kill, (os.getpid(), signal.SIGINT)).start()
            t0 = time.monotonic()
            try:
                simulate(long_run, progress=False)
                print("finished")
            except KeyboardInterrupt:
                print("interrupted", time.monotonic() - t0 < 15, signal.getsignal(signal.SIGINT) is handler)
        print("custom calls", len(calls))
        """
    )
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split("\n")[:3] == ["interrupted True True", "interrupted True True", "custom calls 1"]
    assert "Exception ignored" not in proc.stderr and "Traceback" not in proc.stderr, proc.stderr


# ----------------------------------------------------------------------------- step size (defect 9)


def test_step_size_bounds_by_hand(paper_case1):
    """Case 1: c1 = 0.6, c2 = 0.8, alpha = 0.7, epsilon = 1e-4, phi = 0.001, delta = 0.005, five links in, k^i = 8,
    k^j <= 5, J = 1.3 J0."""
    rep = step_size_report(paper_case1)
    r1 = (2 - 0.7) * 1e-4 ** (0.7 - 1)
    assert rep["surface"] == pytest.approx(0.6 + 0.8 * r1)  # the 'c2 r1 ~ 16 1/s' of the scenario's choices
    assert rep["layer"] == pytest.approx(0.005 / 0.001)
    assert rep["coordination"] == pytest.approx(5 * 8 + 5 * 5)
    assert rep["gain"] == pytest.approx(1 / 1.3)
    assert rep["loop"] == pytest.approx(np.sqrt(1 / 1.3) * (0.6 + 0.8 * r1 + 5 + 65))
    omega0 = max(np.linalg.norm(a.omega0) for a in paper_case1.agents)
    assert rep["omega_max"] == pytest.approx(omega0)
    assert rep["dt"] * rep["rho"] < 0.1 and rep["problems"] == []


@pytest.mark.parametrize("case", ["1", "2", "3a", "3b", "3c"])
def test_the_paper_scenario_does_not_warn(case):
    with warnings.catch_warnings():
        warnings.simplefilter("error", StepSizeWarning)
        r = simulate(fsmctl.paper_scenario(case), progress=False)  # the full 100 s at dt = 1 ms
    assert r.time[-1] == pytest.approx(100.0)


def test_a_coarse_step_warns(paper_case1):
    s = paper_case1.replace(simulation={"t_final": 10.0, "dt": 0.5, "output_interval": 0.5})
    with pytest.warns(StepSizeWarning) as record:
        try:
            simulate(s, progress=False)
        except SimulationError:
            pass
    text = " ".join(str(w.message) for w in record)
    assert "dt = 0.5 s is coarse for the loop's fastest rate" in text
    assert "rad per step" in text


def test_an_ill_conditioned_inertia_warns(paper_case1):
    """J0 = diag(100, 150, 150) but the plant's J0 + delta_J = diag(1, 150, 150) (a realizable thin rod-like body):
    the controller's torques accelerate axis 1 100 times more than it assumes (||J^-1 J0|| = 100), so the loop's
    fastest rate is ~7700 1/s and dt = 1 ms is beyond RK4's stability limit."""
    J0 = np.diag([100.0, 150.0, 150.0])
    agent = dataclasses.replace(
        paper_case1.agents[0], J0=tuple(map(tuple, J0)), delta_J=tuple(map(tuple, np.diag([-99.0, 0, 0])))
    )
    s = with_agents(paper_case1, (agent, *paper_case1.agents[1:]), simulation={"t_final": 0.2})
    assert step_size_report(s)["gain"] == pytest.approx(100.0)
    with pytest.warns(StepSizeWarning, match=r"inertia gain \|\|J\^-1 J0\|\| 100"):
        try:
            simulate(s, progress=False)
        except SimulationError:
            pass
    ok = s.replace(simulation={"dt": 2e-5, "t_final": 0.02, "output_interval": 0.01})
    with warnings.catch_warnings():
        warnings.simplefilter("error", StepSizeWarning)
        simulate(ok, progress=False)  # a step below 0.5 / rho: no warning


def test_a_spin_up_during_the_run_warns(paper_case1):
    """Open loop (controller disabled), a small but realizable inertia and the paper's ~0.2 N m disturbances:
    nothing in the scenario is fast, but the body spins up past 100 rad/s (0.1 rad per 1 ms step) within
    a few seconds; the check after the run sees it."""
    J = np.diag([0.002, 0.0025, 0.003])
    agents = [dataclasses.replace(a, J0=tuple(map(tuple, J)), delta_J=((0.0,) * 3,) * 3) for a in paper_case1.agents]
    s = with_agents(
        paper_case1, agents, controller={"enabled": False}, simulation={"t_final": 4.0, "output_interval": 0.1}
    )
    assert step_size_report(s)["problems"] == []
    with pytest.warns(StepSizeWarning, match="reached"):
        r = simulate(s, progress=False)
    assert np.max(np.linalg.norm(r.omega, axis=-1)) * 1e-3 > 0.1


def test_dopri45_is_not_judged_by_its_initial_step(paper_case1):
    s = paper_case1.replace(simulation={"t_final": 0.5, "dt": 0.5, "output_interval": 0.5, "integrator": "dopri45"})
    assert step_size_report(s)["problems"] == []
