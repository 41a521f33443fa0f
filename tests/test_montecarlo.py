"""Monte Carlo campaigns (fsmctl.studies.montecarlo): sampling laws, determinism, resume, failures, Dask."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest
import xarray as xr
from scipy import stats

from fsmctl.errors import InputError
from fsmctl.studies import montecarlo as mc

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
    base = mc._base_scenario(s)
    sc = mc.sample_run_scenario(base, s, np.random.SeedSequence(5))
    assert sc.n_agents == base.n_agents
    for a, b in zip(sc.agents, base.agents, strict=True):
        assert np.all(np.abs(a.omega0) <= 0.2)
        assert np.all(np.abs(a.disturbance.amplitude) <= 0.5 * np.abs(b.disturbance.amplitude) + 1e-15)
        assert a.J0 == b.J0 and a.delta == b.delta
    assert 0 < len(sc.topology.links) < len(base.topology.links)
    again = mc.sample_run_scenario(base, s, np.random.SeedSequence(5))
    assert again.agents == sc.agents and again.topology == sc.topology


def test_run_scenario_attitude_bound():
    s = mc.CampaignSettings(attitude_bound_deg=10.0)
    base = mc._base_scenario(s)
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
    with xr.open_dataset(tmp_path / "w1" / "montecarlo.nc", engine="scipy") as ds:
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
    from fsmctl.studies.parallel import WORKER_THREAD_VARIABLES

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
