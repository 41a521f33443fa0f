"""Monte Carlo campaigns (fsmctl.studies.montecarlo): sampling laws, determinism, resume, failures, Dask."""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
import zlib
from dataclasses import replace

import numpy as np
import pytest
import xarray as xr
from scipy import stats

import fsmctl
from fsmctl.errors import InputError
from fsmctl.studies import montecarlo as mc
from fsmctl.studies.montecarlo import runs as mc_runs
from fsmctl.studies.montecarlo import sampling as mc_sampling

SHORT = {"t_final": 0.3, "chunk_size": 2, "output_interval": 0.05}


def _settings(runs: int = 4, seed: int = 7, **kw) -> mc.CampaignSettings:
    return mc.CampaignSettings(runs=runs, seed=seed, **{**SHORT, **kw})


def _physics(ds: xr.Dataset) -> xr.Dataset:
    """The dataset without machine-dependent timings."""
    return ds.drop_vars(list(mc.TIMING_VARIABLES))


# ----------------------------------------------------------------------------- sampling laws


def test_attitudes_uniform_over_so3():
    """Haar measure: the principal angle has CDF (theta - sin theta)/pi on [0, pi]."""
    rng = np.random.default_rng(1)
    sigma = mc.sample_attitudes_mrp(rng, 20000)
    norm = np.linalg.norm(sigma, axis=1)
    assert np.all(norm <= 1 + 1e-12)  # shadow set
    theta = 4 * np.arctan(norm)
    assert stats.kstest(theta, lambda t: (t - np.sin(t)) / np.pi).pvalue > 1e-3
    # the axis is isotropic: its components are uniform on [-1, 1]
    axis = sigma / norm[:, None]
    assert stats.kstest(axis[:, 2], "uniform", args=(-1, 2)).pvalue > 1e-3
    # negative control: MRPs uniform in the unit ball are NOT uniform over SO(3), and the test sees it
    v = rng.standard_normal((20000, 3))
    ball = v / np.linalg.norm(v, axis=1, keepdims=True) * rng.uniform(0, 1, (20000, 1)) ** (1 / 3)
    wrong = 4 * np.arctan(np.linalg.norm(ball, axis=1))
    assert stats.kstest(wrong, lambda t: (t - np.sin(t)) / np.pi).pvalue < 1e-6


@pytest.mark.parametrize("bound_deg", [30.0, 1e-3])
def test_attitudes_restricted_to_a_principal_angle(bound_deg):
    """attitude_bound_deg: the Haar measure conditioned on theta <= bound, CDF (theta - sin theta) / (b - sin b)."""
    rng = np.random.default_rng(2)
    sigma = mc.sample_attitudes_mrp(rng, 20000, bound_deg)
    norm = np.linalg.norm(sigma, axis=1)
    theta, b = 4 * np.arctan(norm), np.radians(bound_deg)
    assert theta.max() <= b * (1 + 1e-12)
    # the CDF of the truncated law, with its series for small angles (t - sin t loses every digit there)
    cdf = np.vectorize(
        lambda t: float(sum((-1) ** m * t ** (2 * m + 3) / math.factorial(2 * m + 3) for m in range(12)))
    )
    assert stats.kstest(theta, lambda t: cdf(t) / cdf(b)).pvalue > 1e-3
    axis = sigma / norm[:, None]
    assert stats.kstest(axis[:, 0], "uniform", args=(-1, 2)).pvalue > 1e-3
    # 180 deg is the unrestricted law, drawn exactly as before the option existed
    a, c = np.random.default_rng(5), np.random.default_rng(5)
    assert np.array_equal(mc.sample_attitudes_mrp(a, 7), mc.sample_attitudes_mrp(c, 7, 180.0))


def test_inertia_perturbation_spd_realizable_and_bounded():
    rng = np.random.default_rng(3)
    J0 = np.array([[110.0, 1.0, 0.0], [1.0, 130.0, 0.5], [0.0, 0.5, 240.0]])
    w, V = np.linalg.eigh(J0)
    inv_sqrt = V @ np.diag(w**-0.5) @ V.T
    rhos = []
    for _ in range(300):
        dJ = mc.sample_inertia_perturbation(rng, J0, 0.3)
        assert np.allclose(dJ, dJ.T, atol=0)
        ev = np.linalg.eigvalsh(dJ)
        assert ev[0] > 0  # SPD
        assert ev[0] + ev[1] >= ev[2] * (1 - 1e-12)  # a rigid mass distribution (triangle inequality)
        second_moments = np.linalg.eigvalsh(0.5 * np.trace(dJ) * np.eye(3) - dJ)
        assert second_moments[0] >= -1e-9 * ev[2]
        rho = np.linalg.eigvalsh(inv_sqrt @ dJ @ inv_sqrt)[-1]
        assert 0 < rho <= 0.3 + 1e-12  # 0 < Delta_J <= rho J0 in the Loewner order
        assert np.linalg.eigvalsh(J0 + dJ)[0] > 0
        rhos.append(rho)
    # rho ~ U(0, 0.3]
    assert stats.kstest(np.array(rhos) / 0.3, "uniform").pvalue > 1e-3


def test_run_scenario_respects_bounds():
    s = mc.CampaignSettings(rate_bound=0.2, disturbance_scale=0.5, link_dropout=0.5)
    base = mc.campaign_base(s)[1]
    sc = mc.sample_run_scenario(base, s, np.random.SeedSequence(5))
    assert sc.n_agents == base.n_agents
    for a, b in zip(sc.agents, base.agents, strict=True):
        assert np.all(np.abs(a.omega0) <= 0.2)
        assert np.all(np.abs(a.disturbance.amplitude) <= 0.5 * np.abs(b.disturbance.amplitude) + 1e-15)
        assert a.J0 == b.J0 and a.parameters == b.parameters
    assert 0 < len(sc.topology.links) < len(base.topology.links)
    again = mc.sample_run_scenario(base, s, np.random.SeedSequence(5))
    assert again.agents == sc.agents and again.topology == sc.topology


def test_run_scenario_attitude_bound():
    s = mc.CampaignSettings(attitude_bound_deg=10.0)
    base = mc.campaign_base(s)[1]
    for k in range(5):
        sc = mc.sample_run_scenario(base, s, np.random.SeedSequence(k))
        angles = 4 * np.degrees(np.arctan(np.linalg.norm([a.sigma0 for a in sc.agents], axis=1)))
        assert angles.max() <= 10.0 + 1e-9


# ----------------------------------------------------------------------------- campaigns


def test_deterministic_across_worker_counts_and_seeds(tmp_path):
    one = mc.run_campaign(_settings(), tmp_path / "w1", workers=1, progress=False, figures=False)
    two = mc.run_campaign(_settings(), tmp_path / "w2", workers=2, progress=False, figures=False)
    assert list(one.dataset.status.values) == ["ok"] * 4
    xr.testing.assert_identical(_physics(one.dataset), _physics(two.dataset))
    # seeded reproducibility, from the file written to disk
    with xr.open_dataset(tmp_path / "w1" / "montecarlo.nc") as ds:
        xr.testing.assert_equal(_physics(ds.load()), _physics(one.dataset))
    other = mc.run_campaign(_settings(seed=8), tmp_path / "s8", workers=1, progress=False, figures=False)
    assert not np.array_equal(other.dataset.aaem_final_deg.values, one.dataset.aaem_final_deg.values)
    # a different chunking gives the same runs (seeds are per run, not per chunk)
    rechunk = mc.run_campaign(_settings(chunk_size=3), tmp_path / "c3", workers=1, progress=False, figures=False)
    xr.testing.assert_equal(_physics(rechunk.dataset), _physics(one.dataset))  # attrs name the chunking
    summary = json.loads((tmp_path / "w1" / "summary.json").read_text())
    assert summary["runs"] == 4 and summary["ok"] == 4


def test_resume_after_interruption(tmp_path):
    full = mc.run_campaign(_settings(runs=6), tmp_path / "full", workers=1, progress=False, figures=False)
    out = tmp_path / "cut"
    mc.run_campaign(_settings(runs=6), out, workers=1, progress=False, figures=False)
    # interrupted: the last chunk never written, the middle one half-written, no merged file
    (out / "chunks" / "chunk_00002.nc").unlink()
    (out / "chunks" / "chunk_00001.nc").write_bytes(b"CDF\x01 truncated")
    (out / "montecarlo.nc").unlink()
    with pytest.raises(InputError, match="--resume"):
        mc.run_campaign(_settings(runs=6), out, workers=1, progress=False, figures=False)
    with pytest.raises(InputError, match="different settings"):
        mc.run_campaign(_settings(runs=6, seed=99), out, workers=1, resume=True, progress=False, figures=False)
    resumed = mc.run_campaign(_settings(runs=6), out, workers=1, resume=True, progress=False, figures=False)
    assert resumed.resumed_chunks == 1
    xr.testing.assert_identical(_physics(resumed.dataset), _physics(full.dataset))


def test_case_defaults_to_the_first_and_resume_accepts_it_spelled_out(tmp_path):
    """--case omitted = the scenario's first case; campaign.json names it, so --case 1 resumes the same campaign."""
    assert mc.CampaignSettings().case is None
    resolved, base = mc.campaign_base(_settings())
    assert resolved.case == "1" and base.case == "1"
    first = mc.run_campaign(_settings(runs=2), tmp_path / "o", workers=1, progress=False, figures=False)
    assert first.settings.case == "1"
    assert json.loads((tmp_path / "o" / "campaign.json").read_text())["case"] == "1"
    again = mc.run_campaign(
        _settings(runs=2, case="1"), tmp_path / "o", workers=1, resume=True, progress=False, figures=False
    )
    assert again.resumed_chunks == 1


def failing_run(base, settings, index, seed):
    """Run 1 raises, run 2 kills its worker process; the rest are normal runs."""
    if index == 1:
        raise RuntimeError("injected failure")
    if index == 2:
        os._exit(3)
    return mc.run_one(base, settings, index, seed)


def test_failing_run_and_dead_worker_are_reported(tmp_path):
    res = mc.run_campaign(
        _settings(runs=4, chunk_size=1), tmp_path / "f", workers=2, progress=False, run_fn=failing_run, figures=False
    )
    status = dict(zip(res.dataset.run.values.tolist(), res.dataset.status.values.tolist(), strict=True))
    assert status == {0: "ok", 1: "failed", 2: "worker-died", 3: "ok"}
    assert "injected failure" in str(res.dataset.message.sel(run=1).values)
    assert res.failed_runs == [1, 2]
    assert res.summary["failed"] == 1 and res.summary["worker_died"] == 1
    assert math.isnan(float(res.dataset.aaem_final_deg.sel(run=1)))


def report_thread_environment(base, settings, index, seed):
    """Fails on purpose, naming the BLAS/OpenMP thread variables the worker process started with."""
    from fsmctl.parallel import WORKER_THREAD_VARIABLES

    raise RuntimeError(" ".join(f"{k}={os.environ.get(k)}" for k in WORKER_THREAD_VARIABLES))


def test_pool_workers_start_with_one_blas_thread(tmp_path, monkeypatch):
    """The local pool's workers inherit OPENBLAS/OMP = 1 (read when NumPy loads); user settings and the parent stay."""
    for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
        monkeypatch.delenv(k, raising=False)
    monkeypatch.setenv("MKL_NUM_THREADS", "3")
    res = mc.run_campaign(
        _settings(runs=2, chunk_size=1),
        tmp_path / "env",
        workers=2,
        progress=False,
        run_fn=report_thread_environment,
        figures=False,
    )
    for message in res.dataset.message.values:
        assert "OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=3" in str(message)
    assert "OPENBLAS_NUM_THREADS" not in os.environ and "OMP_NUM_THREADS" not in os.environ
    assert os.environ["MKL_NUM_THREADS"] == "3"


def test_dask_local_cluster_matches_process_pool(tmp_path):
    distributed = pytest.importorskip("distributed")
    local = mc.run_campaign(_settings(), tmp_path / "local", workers=1, progress=False, figures=False)
    with distributed.LocalCluster(
        n_workers=2, processes=False, threads_per_worker=1, dashboard_address=None, protocol="tcp"
    ) as cluster:
        with distributed.Client(cluster) as client:
            res = mc.run_campaign(_settings(), tmp_path / "dask", dask=client, progress=False, figures=False)
        # by address: the pre-flight handshake check accepts a real scheduler
        by_address = mc.run_campaign(
            _settings(), tmp_path / "addr", dask=cluster.scheduler_address, progress=False, figures=False
        )
    xr.testing.assert_identical(_physics(res.dataset), _physics(local.dataset))
    xr.testing.assert_identical(_physics(by_address.dataset), _physics(local.dataset))


def test_cli_campaign_and_bad_input(tmp_path):
    out = tmp_path / "cli"
    cmd = [sys.executable, "-m", "fsmctl.cli.main", "montecarlo", "--runs", "2", "--t-final", "0.2", "--workers", "1"]
    proc = subprocess.run([*cmd, "--out", str(out), "--no-progress"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "2 ok, 0 failed" in proc.stdout
    assert (
        (out / "montecarlo.nc").is_file() and (out / "histograms.png").is_file() and (out / "histograms.svg").is_file()
    )
    # the campaign file carries where it came from: the base scenario (re-runnable), the versions, the command line
    from fsmctl import paper_scenario, scenario_from_result

    with xr.open_dataset(out / "montecarlo.nc") as ds:
        assert ds.attrs["command"].endswith(
            "montecarlo --runs 2 --t-final 0.2 --workers 1 --out " + str(out) + " --no-progress"
        )
        assert ds.attrs["version_fsmctl"] and ds.attrs["law"] == "fsm" and ds["aaem_final_deg"].encoding["zlib"]
    # the chunk files are intermediates: NetCDF-3, cheap for the parent to write while the workers fly (compressed
    # NetCDF-4 cost the parent ~0.3 s of CPU per chunk); the merged file above is the compressed one
    chunks = sorted((out / "chunks").glob("*.nc"))
    assert chunks and all(p.read_bytes()[:3] == b"CDF" for p in chunks)
    assert (out / "montecarlo.nc").read_bytes()[:4] == b"\x89HDF"
    base = scenario_from_result(out / "montecarlo.nc")  # the campaign's base: Case 1 at the campaign's horizon
    assert base.agents == paper_scenario("1").agents and base.controller == paper_scenario("1").controller
    assert base.simulation.t_final == 0.2
    bad = subprocess.run([*cmd[:4], "0", "--out", str(tmp_path / "x")], capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1
    bad = subprocess.run([*cmd, "--rate-bound", "-1", "--out", str(tmp_path / "y")], capture_output=True, text=True)
    assert bad.returncode == 2 and "rate_bound" in bad.stderr and "Traceback" not in bad.stderr


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--out", "{file}"], "cannot create the output folder"),
        (["--out", "{dir}", "--dask", "tcp://127.0.0.1:9"], "cannot connect to a Dask scheduler"),
    ],
)
def test_cli_unusable_out_or_scheduler_is_one_line(tmp_path, capsys, extra, message):
    from fsmctl.cli.main import main

    a_file = tmp_path / "taken"
    a_file.write_text("not a folder")
    argv = [x.format(file=a_file, dir=tmp_path / "out") for x in extra]
    code = main(["montecarlo", "--runs", "1", "--t-final", "0.1", "--workers", "1", "--no-progress", *argv])
    _, err = capsys.readouterr()
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1


# ----------------------------------------------------------------------------- flight hardware (issue 13)

HARDWARE = {"scenario": "paper-hardware", "t_final": 0.2, "output_interval": 0.1, "chunk_size": 2}
needs_hardware_engine = pytest.mark.skipif(
    not hasattr(fsmctl.SimulationResult, "wheel_speed"),
    reason="the compiled engine does not fly wheels, sensors and links yet",
)


def _hw(**kw) -> mc.CampaignSettings:
    return mc.CampaignSettings(**{**HARDWARE, **kw})


@pytest.fixture(scope="module")
def hardware_base():
    return mc.campaign_base(_hw())


def _scenarios(settings, runs, campaign_seed=None):
    settings, base = mc.campaign_base(settings)
    seeds = np.random.SeedSequence(settings.seed if campaign_seed is None else campaign_seed).spawn(runs)
    return base, [mc.sample_run_scenario(base, settings, q) for q in seeds]


def test_every_run_has_its_own_reproducible_noise_seed():
    s = _settings(runs=6)
    base, runs = _scenarios(s, 6)
    seeds = [r.simulation.seed for r in runs]
    assert len(set(seeds)) == 6 and all(isinstance(x, int) and 0 <= x < 2**53 for x in seeds)
    assert base.simulation.seed not in seeds
    _, again = _scenarios(s, 6)
    assert [r.simulation.seed for r in again] == seeds and again == runs  # a fixed campaign seed: the same runs
    # a run's seed depends on the campaign seed and its index only, not on the number of runs
    _, more = _scenarios(replace(s, runs=10), 10)
    assert [r.simulation.seed for r in more[:6]] == seeds and more[:6] == runs
    assert [mc.run_noise_seed(q) for q in np.random.SeedSequence(7).spawn(6)] == seeds
    _, other = _scenarios(s, 6, campaign_seed=8)
    assert not set(seeds) & {r.simulation.seed for r in other}


def report_sampled_scenario(base, settings, index, seed):
    """Fails on purpose, naming what the worker sampled: its noise seed and a fingerprint of the scenario."""
    s = mc.sample_run_scenario(base, settings, seed)
    links = ";".join(f"{lk.receiver}<-{lk.sender}" for lk in s.topology.links)
    delays = s.links.delay_table and np.nansum(s.links.delay_table)
    raise RuntimeError(
        f"seed={s.simulation.seed} sigma0={s.agents[0].sigma0} links={zlib.crc32(links.encode())} delays={delays}"
    )


def test_noise_seeds_are_the_same_whatever_the_workers_and_chunks(tmp_path):
    """The sampled scenarios (noise seed included) are drawn in the workers from the run's seed only."""
    out = {}
    for name, workers, chunk in (("w1", 1, 2), ("w2", 2, 2), ("c3", 2, 3)):
        settings = _hw(runs=5, chunk_size=chunk, link_delay=(0.0, 0.2))
        out[name] = mc.run_campaign(settings, tmp_path / name, workers=workers, progress=False, figures=False,
                                    run_fn=report_sampled_scenario).dataset  # fmt: skip
    messages = [str(m) for m in out["w1"].message.values]
    assert all(m.startswith("RuntimeError: seed=") for m in messages)
    for name in ("w2", "c3"):
        assert [str(m) for m in out[name].message.values] == messages
        np.testing.assert_array_equal(out[name].noise_seed.values, out["w1"].noise_seed.values)
    # the dataset's noise_seed is the seed the run flew (float64 holds it exactly)
    flown = [int(m.split("seed=")[1].split()[0]) for m in messages]
    assert [int(x) for x in out["w1"].noise_seed.values] == flown and len(set(flown)) == 5


def test_vary_noise_keeps_everything_but_the_seed(hardware_base):
    settings, base = mc.campaign_base(_hw(vary="noise"))
    assert settings.vary == "noise"
    runs = [mc.sample_run_scenario(base, settings, q) for q in np.random.SeedSequence(3).spawn(4)]
    seeds = [r.simulation.seed for r in runs]
    assert len(set(seeds)) == 4
    for run, seed in zip(runs, seeds, strict=True):
        assert run == base.replace(simulation={"seed": seed})
        assert run.agents == base.agents and run.topology == base.topology and run.reference == base.reference
        assert (run.actuator, run.sensors, run.links, run.controller) == (
            base.actuator,
            base.sensors,
            base.links,
            base.controller,
        )
    # vary all draws the rest too, with the same noise seed per run
    all_runs = [mc.sample_run_scenario(*hardware_base[::-1], q) for q in np.random.SeedSequence(3).spawn(4)]
    assert [r.simulation.seed for r in all_runs] == seeds
    assert all(r.agents != base.agents for r in all_runs)
    lines = mc.describe_campaign(settings, base)
    assert any("vary noise" in line for line in lines) and not any("attitude:" in line for line in lines)
    assert any("random processes: star tracker noise, gyro noise, packet loss" in line for line in lines)


def test_default_settings_change_nothing_but_the_seed_of_a_scenario_without_hardware():
    s = mc.CampaignSettings(rate_bound=0.2)
    base = mc.campaign_base(s)[1]
    q = np.random.SeedSequence(5)
    run = mc.sample_run_scenario(base, s, q)
    assert (run.actuator, run.sensors, run.links) == (base.actuator, base.sensors, base.links)
    assert mc_sampling._sample_hardware(base, s, run.topology, q) == {}
    assert mc.random_processes(run) == []
    assert run.simulation == replace(base.simulation, seed=mc.run_noise_seed(q))


def test_hardware_ranges_are_applied(hardware_base):
    settings, base = hardware_base
    ranged = replace(settings, link_delay=(0.05, 0.2), loss_probability=(0.1, 0.3), sensor_noise_scale=(0.5, 2.0))
    seeds = np.random.SeedSequence(11).spawn(6)
    plain = [mc.sample_run_scenario(base, settings, q) for q in seeds]
    runs = [mc.sample_run_scenario(base, ranged, q) for q in seeds]
    star, gyro = base.sensors.star_tracker, base.sensors.gyro
    scales, delays = [], []
    for run, same, q in zip(runs, plain, seeds, strict=True):
        # the other draws are those of the campaign without the ranges
        assert run.agents == same.agents and run.topology == same.topology
        assert run.simulation.seed == same.simulation.seed
        delay, loss = np.array(run.links.delay_table), np.array(run.links.loss_table)
        on = np.zeros(delay.shape, bool)
        for lk in run.topology.links:
            on[lk.receiver, lk.sender] = True
        assert np.all((delay[on] >= 0.05) & (delay[on] <= 0.2)) and np.all(np.isnan(delay[~on]))
        assert np.all((loss[on] >= 0.1) & (loss[on] <= 0.3)) and np.all(np.isnan(loss[~on]))
        factor = run.sensors.star_tracker.noise_std[0] / star.noise_std[0]
        assert 0.5 <= factor <= 2.0 and factor == pytest.approx(mc.sampled_noise_scale(ranged, q), rel=1e-12)
        np.testing.assert_allclose(run.sensors.star_tracker.noise_std, factor * np.array(star.noise_std), rtol=1e-12)
        assert run.sensors.gyro.angle_random_walk == pytest.approx(factor * gyro.angle_random_walk, rel=1e-12)
        assert run.sensors.gyro.rate_random_walk == pytest.approx(factor * gyro.rate_random_walk, rel=1e-12)
        assert run.sensors.gyro.bias == gyro.bias and run.actuator == base.actuator
        rec = mc_runs._hardware_record(run, factor)
        assert rec["link_delay_max_s"] == pytest.approx(delay[on].max()) and rec["sensor_noise_scale"] == factor
        scales.append(factor)
        delays.append(delay[on].tolist())
    assert len(set(scales)) == 6 and len({tuple(d) for d in delays}) == 6
    # a link's draw does not depend on which other links the run kept
    tables = [np.array(r.links.delay_table) for r in runs]
    assert tables[0][0, 1] != tables[1][0, 1]
    # a fixed value: LOW = HIGH (the CLI's --link-delay 0.1)
    fixed = replace(settings, link_delay=0.1)
    assert fixed.link_delay == (0.1, 0.1)
    run = mc.sample_run_scenario(base, fixed, seeds[0])
    assert np.nanmax(run.links.delay_table) == np.nanmin(run.links.delay_table) == 0.1


@pytest.mark.parametrize(
    ("kw", "message"),
    [
        ({"link_delay": (0.2, 0.1)}, "link_delay must be a range (low, high) with finite, 0 <= low <= high"),
        ({"link_delay": (-0.1, 0.1)}, "link_delay must be a range"),
        ({"link_delay": (0.0, math.inf)}, "link_delay must be a range"),
        ({"loss_probability": (0.5, 1.5)}, "loss_probability must be a range (low, high) with 0 <= low <= high <= 1"),
        ({"loss_probability": "0.1"}, "loss_probability must be a range"),
        ({"sensor_noise_scale": (math.nan, 1.0)}, "sensor_noise_scale must be a range"),
        ({"vary": "seeds"}, "vary must be one of all, noise, got 'seeds'"),
        ({"vary": "noise", "rate_bound": 0.1}, "--vary noise keeps the base scenario, so rate_bound would not be used"),
        ({"vary": "noise", "link_delay": (0, 0.1)}, "so link_delay would not be used"),
        ({"control_period": 0.0015}, "control_period = 0.0015 must be a multiple of dt"),
        ({"control_period": -1.0}, "simulation.control_period: must be >= 0"),
        ({"control_period": 0.0}, "sensors: sensors and imperfect links act at the control instants"),
    ],
)
def test_bad_hardware_settings_are_one_line(kw, message):
    with pytest.raises(InputError) as info:
        settings = _hw(**kw)
        settings.validate()
        mc.campaign_base(settings)
    assert message in str(info.value) and len(str(info.value).splitlines()) == 1


@pytest.mark.parametrize(
    ("kw", "message"),
    [
        ({"link_delay": (0.0, 0.1)}, "link_delay needs a scenario with a control period"),
        ({"loss_probability": (0.0, 0.1)}, "loss_probability needs a scenario with a control period"),
        ({"control_period": 0.1, "sensor_noise_scale": (1, 2)}, "sensor_noise_scale needs a scenario with [sensors]"),
        ({"vary": "noise"}, "has no random process"),
        ({"vary": "noise", "control_period": 0.1}, "has no random process"),
    ],
)
def test_hardware_ranges_need_the_scenario_section(kw, message):
    """The paper's scenario has no control period and no sensors: the ranges that need them are refused."""
    with pytest.raises(InputError, match=re.escape(message)):
        mc.campaign_base(_settings(**kw))
    with pytest.raises(InputError, match=re.escape(message)):  # also when the base is given (fsmctl montecarlo --law)
        base = mc.campaign_base(_settings(control_period=kw.get("control_period")))[1]
        mc.sample_run_scenario(base, _settings(**kw), np.random.SeedSequence(0))
    # with a control period the link ranges are fine on the paper's scenario
    mc.campaign_base(_settings(control_period=0.05, link_delay=(0.0, 0.1), loss_probability=(0.0, 0.1)))


def quick_record(base, settings, index, seed):
    """A record without simulating (status ok): for the campaign bookkeeping."""
    mc.sample_run_scenario(base, settings, seed)
    return mc_runs.nan_record(base.n_agents)


def test_campaign_json_and_dataset_record_the_hardware_settings(tmp_path):
    settings = _hw(runs=3, link_delay=(0.0, 0.2), sensor_noise_scale=(0.5, 1.5), control_period=0.1)
    res = mc.run_campaign(settings, tmp_path / "hw", workers=1, progress=False, figures=False, run_fn=quick_record)
    meta = json.loads((tmp_path / "hw" / "campaign.json").read_text())
    assert meta["vary"] == "all" and meta["control_period"] == 0.1
    assert meta["link_delay"] == [0.0, 0.2] and meta["sensor_noise_scale"] == [0.5, 1.5]
    assert meta["loss_probability"] is None
    with xr.open_dataset(tmp_path / "hw" / "montecarlo.nc") as ds:
        attrs = dict(ds.attrs)
        seeds = ds.noise_seed.values.copy()
    assert json.loads(attrs["settings"]) == meta
    assert attrs["vary"] == "all" and "star tracker noise" in attrs["random_processes"]
    assert "hardware: link delay per link U(0, 0.2) s (--link-delay)" in attrs["campaign"]
    expected = [mc.run_noise_seed(q) for q in np.random.SeedSequence(settings.seed).spawn(3)]
    assert seeds.tolist() == [float(x) for x in expected] and [int(x) for x in seeds] == expected
    assert res.summary["settings"]["link_delay"] == [0.0, 0.2]
    # --resume checks them
    for change in ({"vary": "noise", "link_delay": None, "sensor_noise_scale": None}, {"link_delay": (0.0, 0.3)}):
        with pytest.raises(InputError, match="different settings"):
            mc.run_campaign(replace(settings, **change), tmp_path / "hw", workers=1, resume=True, progress=False,
                            figures=False, run_fn=quick_record)  # fmt: skip
    again = mc.run_campaign(settings, tmp_path / "hw", workers=1, resume=True, progress=False, figures=False,
                            run_fn=quick_record)  # fmt: skip
    assert again.resumed_chunks == 2


@needs_hardware_engine
def test_noise_campaign_on_the_hardware_scenario_runs(tmp_path):
    """``fsmctl montecarlo --scenario paper-hardware --vary noise``: the base scenario over noise seeds, simulated."""
    from fsmctl.cli.main import main

    out = tmp_path / "noise"
    code = main(["montecarlo", "--scenario", "paper-hardware", "--vary", "noise", "--runs", "2", "--t-final", "0.2",
                 "--workers", "1", "--no-progress", "--out", str(out)])  # fmt: skip
    assert code == 0
    with xr.open_dataset(out / "montecarlo.nc") as ds:
        assert list(ds.status.values) == ["ok", "ok"] and len(set(ds.noise_seed.values.tolist())) == 2
        assert ds.attrs["vary"] == "noise"
        # the base scenario's initial state in every run
        np.testing.assert_array_equal(ds.initial_rate_max_rad_per_s.values[0], ds.initial_rate_max_rad_per_s.values[1])
        assert np.all(ds.sensor_noise_scale.values == 1.0)
        np.testing.assert_allclose(ds.link_delay_max_s.values, 0.1)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--vary", "noise"], "has no random process"),
        (["--link-delay", "0,0.1"], "link_delay needs a scenario with a control period"),
        (["--control-period", "0.05", "--link-delay", "0.2,0.1"], "link_delay must be a range"),
        (["--control-period", "0.05", "--loss-probability", "0,x"], "expected a number, got 'x'"),
        (["--control-period", "0.05", "--loss-probability", "1,2,3"], "expected LOW,HIGH"),
        (["--control-period", "0.0015"], "control_period = 0.0015 must be a multiple of dt"),
        (["--control-period", "-0.1"], "simulation.control_period: must be >= 0"),
        (["--sensor-noise-scale", "1,2"], "sensor_noise_scale needs a scenario with [sensors]"),
        (["--vary", "seeds"], "invalid choice"),
    ],
)
def test_cli_hardware_options_bad_input_is_one_line(tmp_path, capsys, argv, message):
    from fsmctl.cli.main import main

    try:
        code = main(["montecarlo", "--runs", "1", "--t-final", "0.1", "--workers", "1", "--no-progress",
                     "--out", str(tmp_path / "o"), *argv])  # fmt: skip
    except SystemExit as exc:  # argparse
        code = exc.code
    _, err = capsys.readouterr()
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "o").exists()


def test_cli_control_period_reaches_the_campaign(tmp_path, capsys):
    from fsmctl.cli.main import main

    out = tmp_path / "cp"
    code = main(["montecarlo", "--runs", "1", "--t-final", "0.1", "--workers", "1", "--no-progress",
                 "--control-period", "0.05", "--link-delay", "0.05", "--out", str(out)])  # fmt: skip
    printed, err = capsys.readouterr()
    assert code == 0, err
    assert "control period 0.05 s (--control-period)" in printed
    assert "link delay per link U(0.05, 0.05) s (--link-delay)" in printed
    meta = json.loads((out / "campaign.json").read_text())
    assert meta["control_period"] == 0.05 and meta["link_delay"] == [0.05, 0.05] and meta["vary"] == "all"
    with xr.open_dataset(out / "montecarlo.nc") as ds:
        assert "control_period=0.05 s" in ds.attrs["scenario"]
        assert float(ds.link_delay_max_s[0]) == 0.05 and math.isnan(float(ds.sensor_noise_scale[0]))


@needs_hardware_engine
def test_wheel_runs_record_the_wheels_peaks(tmp_path):
    res = mc.run_campaign(_hw(runs=1, vary="noise"), tmp_path / "w", workers=1, progress=False, figures=False)
    ds = res.dataset
    assert ds.wheel_momentum_peak_N_m_s.attrs["units"] == "N m s" and ds.link_delay_max_s.attrs["units"] == "s"
    assert float(ds.wheel_momentum_peak_N_m_s[0]) > 0 and float(ds.wheel_speed_peak_rad_per_s[0]) > 0
    paper = mc.run_campaign(_settings(runs=1), tmp_path / "p", workers=1, progress=False, figures=False).dataset
    assert math.isnan(float(paper.wheel_momentum_peak_N_m_s[0])) and float(paper.link_delay_max_s[0]) == 0.0


# ----------------------------------------------------------------------------- memory of a run's record (issue 23)


def _switching_ring(path, n: int):
    """A ring of ``n`` agents whose links switch (the campaign gives every link a phase of its own)."""
    agents = "".join(
        f"[[agents]]\nJ0 = [[{100 + i % 7}.0, 0.0, 0.0], [0.0, 120.0, 0.0], [0.0, 0.0, 150.0]]\n"
        f"sigma0 = [{0.1 * math.cos(i):.4f}, {0.1 * math.sin(i):.4f}, 0.05]\nomega0 = [0.01, 0.0, -0.01]\n\n"
        for i in range(n)
    )
    path.write_text(
        'name = "switching-ring"\n[simulation]\nt_final = 0.2\ndt = 0.001\noutput_interval = 0.1\n'
        '[controller]\nlaw = "fsm"\nc1 = 0.6\nc2 = 0.8\nalpha = 0.7\ndelta = 0.005\nboundary_layer = 0.01\n'
        "torque_limit = 10.0\n[reference]\nsigma0 = [0.0, 0.0, 0.0]\n"
        "omega = { amplitude = [0.02, 0.0, 0.0], frequency = [0.05, 0.0, 0.0] }\n"
        '[topology]\nkind = "ring"\nk_i = 2.0\nk_j = { breakpoints = [0.0, 6.5], values = [1.0, 0.0], period = 8.0 }\n\n'
        + agents,
        encoding="utf-8",
    )
    return path


def test_run_record_does_not_hold_a_matrix_per_topology_configuration(tmp_path):
    """Was: 1.9 GB for a 200-agent ring (its Theorem 1 check kept every configuration's n x n matrix, 3 times).

    With a phase per link, the run's topology has about two configurations per link and period; the record's
    memory must stay below one dense n x n matrix per configuration (it was 7 times above it, now 0.2 times).
    """
    import tracemalloc

    from fsmctl.proofs.theorem1 import configurations

    n = 100
    settings, base = mc.campaign_base(mc.CampaignSettings(scenario=str(_switching_ring(tmp_path / "ring.toml", n))))
    seed = np.random.SeedSequence(3).spawn(1)[0]
    scenario = mc.sample_run_scenario(base, settings, seed)
    result = fsmctl.simulate(scenario)
    n_configurations = len(configurations(scenario.topology, scenario.simulation.t_final)[0])
    dense = n_configurations * n * n * 8  # one float64 n x n matrix per configuration
    assert n_configurations > 2 * n  # the case at issue: ~2 per link, so dense matrices would scale with n^3
    tracemalloc.start()
    try:
        record = mc.run_record(scenario, settings, seed, result)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert math.isfinite(record["theorem1_lambda_min"])
    assert peak < dense, (peak, dense)  # before: 7.2 x dense (191 MB), now 0.2 x (5 MB)


def test_cli_summary_when_no_run_settles_reads_plainly(tmp_path, capsys):
    """Runs too short to settle: the settling line counts them, with no empty median ("no finite value s")."""
    from fsmctl.cli.main import main

    code = main(
        ["montecarlo", "--runs", "2", "--t-final", "0.2", "--workers", "1", "--no-progress", "--out", str(tmp_path)]
    )
    out = capsys.readouterr().out
    assert code == 0
    line = next(x for x in out.splitlines() if "AAEM settling" in x)
    assert line.strip() == "AAEM settling: 2 of 2 runs never settled"
