"""Trust in resumed studies, result files, signals, wheels and memory (issue 25): every resume refuses a changed
problem, a killed study's journal lock does not hang the next one, SIGTERM exits 143 without a partial result, bad
input is one line (exit 2), a CSV result of a law with states re-runs, ``--from`` refuses a law that is not the one
recorded, a step that cannot resolve the wheels' friction is reported, and a campaign too large for the memory is
refused before it draws anything (its seeds drawn per chunk, the same as before).

Oracles: the seeds of a campaign are recomputed with ``numpy.random.SeedSequence(seed).spawn(runs)`` as its
documentation states; the friction criterion is checked against the physics it protects (with no motor torque,
friction can only take energy out of a wheel: a step the report flags makes it gain energy, one it accepts does not).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from formations import single_spacecraft

import fsmctl
from fsmctl.cli.main import main
from fsmctl.errors import InputError, ResourceLimitError
from fsmctl.model.laws import resolve_law
from fsmctl.simulation import step_size_report
from fsmctl.simulation.results_io import (
    LawChangedError,
    ResultFileError,
    fingerprint_change,
    load_result,
    problem_fingerprint,
    scenario_from_result,
)
from fsmctl.studies import CampaignSettings
from fsmctl.studies.montecarlo import campaign_base, check_campaign_memory, run_campaign
from fsmctl.studies.tune import TuneSettings, tune

REPO = Path(__file__).resolve().parents[1]
CLI = [sys.executable, "-m", "fsmctl"]


def _env() -> dict:
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}


def _exit(argv: list[str], capsys) -> tuple[int, str]:
    try:
        rc = main(argv)
    except SystemExit as exc:
        rc = int(exc.code)
    return rc, capsys.readouterr().err


def _scenario(tmp_path: Path, torque_limit: float) -> Path:
    path = tmp_path / "scenario.toml"
    path.write_text(
        f'extends = "paper"\n[controller]\ntorque_limit = {torque_limit}\n[simulation]\noutput_interval = 0.1\n',
        encoding="utf-8",
    )
    return path


def _tune_settings(scenario: Path, **kw) -> TuneSettings:
    base = dict(
        scenario=str(scenario),
        law="pid",
        budget=2,
        batch=2,
        seed=1,
        objectives=("peak_torque",),
        pruner="none",
        t_final=0.3,
        parameters=("K", "P"),
        ranges=(("K", 5.0, 200.0), ("P", 10.0, 400.0)),
        constraints=("converged",),
    )
    return TuneSettings(**{**base, **kw})


# ----------------------------------------------------------------------------- resumes refuse a changed problem


def test_tune_resume_refuses_a_changed_scenario_file(tmp_path, capsys):
    """Was: the study continued on torque limit 0.01 with the trials of torque limit 10."""
    scenario = _scenario(tmp_path, 10.0)
    out = tmp_path / "study"
    tune(_tune_settings(scenario), out, progress=False)
    _scenario(tmp_path, 0.01)
    with pytest.raises(InputError, match="run on another problem: the scenario changed"):
        tune(_tune_settings(scenario, budget=4), out, resume=True, progress=False)
    args = ["tune", "--scenario", str(scenario), "--law", "pid", "--budget", "4", "--batch", "2", "--seed", "1"]
    args += ["--objectives", "peak_torque", "--pruner", "none", "--t-final", "0.3", "--parameters", "K,P"]
    args += ["--range", "K=5,200", "--range", "P=10,400", "--constraints", "converged", "--out", str(out)]
    rc, err = _exit([*args, "--resume", "--no-progress"], capsys)
    assert rc == 2 and err.count("\n") == 1 and "the scenario changed" in err, err
    _scenario(tmp_path, 10.0)  # the problem as it was: the study continues
    assert len(tune(_tune_settings(scenario, budget=4), out, resume=True, progress=False).trials) == 4


def _law_copy(tmp_path: Path, name: str = "pid") -> Path:
    folder = tmp_path / f"{name}_law"
    shutil.copytree(resolve_law(name).folder, folder)
    return folder


def _edit_law_default(folder: Path, parameter: str, value: float) -> None:
    """Re-derive by hand: another default in law.json, with the manifest's sha256 of it updated (a consistent
    folder, as `fsmctl derive` writes it after a script changed)."""
    import hashlib

    law = json.loads((folder / "law.json").read_text())
    for p in law["parameters"]:
        if p["name"] == parameter:
            p["default"] = value if not isinstance(p["default"], list) else [value] * len(p["default"])
    (folder / "law.json").write_text(json.dumps(law, indent=2))
    manifest = json.loads((folder / "manifest.json").read_text())
    manifest["sha256"]["law.json"] = hashlib.sha256((folder / "law.json").read_bytes()).hexdigest()
    (folder / "manifest.json").write_text(json.dumps(manifest, indent=2))


def test_fingerprint_names_a_changed_law_and_scenario(tmp_path):
    folder = _law_copy(tmp_path)
    scenario = fsmctl.paper_scenario("1")
    before = problem_fingerprint(scenario, str(folder))
    assert fingerprint_change(before, problem_fingerprint(scenario, str(folder))) is None
    assert before["law_sha256"] == problem_fingerprint(scenario, "pid")["law_sha256"]  # content, not place
    _edit_law_default(folder, "k_coupling", 0.25)
    change = fingerprint_change(before, problem_fingerprint(scenario, str(folder)))
    assert change is not None and change.startswith("the law pid changed"), change
    limited = scenario.replace(controller={"torque_limit": 0.01})
    assert fingerprint_change(before, problem_fingerprint(limited, str(folder))).startswith("the law pid changed")
    assert fingerprint_change(problem_fingerprint(scenario), problem_fingerprint(limited)).startswith(
        "the scenario changed"
    )
    assert "law changed (fsm then, pid now)" in fingerprint_change(
        problem_fingerprint(scenario), problem_fingerprint(scenario, "pid")
    )


def _campaign(scenario: Path, **kw) -> CampaignSettings:
    return CampaignSettings(
        **{"scenario": str(scenario), "runs": 2, "chunk_size": 1, "t_final": 0.2, "steady_window": 0.1, **kw}
    )


def test_montecarlo_resume_refuses_a_changed_scenario_file(tmp_path, capsys):
    """Was: --resume accepted the campaign after its scenario file changed (campaign.json held only the name)."""
    scenario = _scenario(tmp_path, 10.0)
    out = tmp_path / "mc"
    run_campaign(_campaign(scenario), out, workers=1, progress=False, figures=False)
    stored = json.loads((out / "campaign.json").read_text())
    assert (
        stored["problem"]["scenario_sha256"]
        == problem_fingerprint(campaign_base(_campaign(scenario))[1])["scenario_sha256"]
    )
    _scenario(tmp_path, 0.01)
    with pytest.raises(InputError, match=r"holds a campaign of another problem \(the scenario changed"):
        run_campaign(_campaign(scenario), out, resume=True, workers=1, progress=False, figures=False)
    argv = ["montecarlo", "--scenario", str(scenario), "--runs", "2", "--chunk-size", "1", "--t-final", "0.2"]
    argv += ["--steady-window", "0.1", "--workers", "1", "--no-figures", "--out", str(out), "--resume"]
    rc, err = _exit(argv, capsys)
    assert rc == 2 and err.count("\n") == 1 and "the scenario changed" in err, err


# ----------------------------------------------------------------------------- the study's journal


@pytest.fixture(scope="module")
def small_study(tmp_path_factory):
    """A finished 2-trial study, copied by each test that damages it."""
    tmp = tmp_path_factory.mktemp("study")
    scenario = _scenario(tmp, 10.0)
    tune(_tune_settings(scenario), tmp / "study", progress=False)
    return scenario, tmp / "study"


def _tune_cli(scenario: Path, out: str, budget: int) -> list[str]:
    args = [*CLI, "tune", "--scenario", str(scenario), "--law", "pid", "--budget", str(budget), "--batch", "2"]
    args += ["--seed", "1", "--objectives", "peak_torque", "--pruner", "none", "--t-final", "0.3"]
    args += ["--parameters", "K,P", "--range", "K=5,200", "--range", "P=10,400", "--constraints", "converged"]
    return [*args, "--out", out, "--no-progress", "--resume"]


@pytest.mark.parametrize("relative", [True, False], ids=["relative-out", "absolute-out"])
def test_stale_optuna_lock_of_a_killed_study_is_broken(small_study, tmp_path, relative):
    """Was: Optuna's symlink lock to the relative path out/study.log (dangling: it resolves to out/out/study.log)
    left by a SIGKILL made --resume spin at 100 % CPU forever, printing nothing (31 silent s with an absolute
    --out)."""
    scenario, study = small_study
    out = tmp_path / "out"
    shutil.copytree(study, out)
    lock = out / "study.log.lock"
    os.symlink("out/study.log" if relative else str(out / "study.log"), lock)  # as Optuna's lock names it
    old = time.time() - 60
    os.utime(lock, (old, old), follow_symlinks=False)  # the study was killed a minute ago
    proc = subprocess.run(
        _tune_cli(scenario, "out" if relative else str(out), 4),
        cwd=tmp_path,
        env=_env(),
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert "removed the stale lock" in proc.stderr and str(lock) in proc.stderr, proc.stderr
    assert not os.path.lexists(lock)
    assert len(tune(_tune_settings(scenario, budget=4), out, resume=True, progress=False).trials) == 4


def test_lock_of_a_dead_process_is_broken_at_once(small_study, tmp_path):
    scenario, study = small_study
    out = tmp_path / "out"
    shutil.copytree(study, out)
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()  # reaped: its pid names no process
    (out / "study.log.lock").write_text(f"{dead.pid} {socket.gethostname()}\n")
    started = time.monotonic()
    result = tune(_tune_settings(scenario, budget=4), out, resume=True, progress=False)
    assert len(result.trials) == 4 and time.monotonic() - started < 20  # Optuna waited its 30 s grace period
    assert not (out / "study.log.lock").exists()


def test_journal_with_a_garbage_line_is_one_line(small_study, tmp_path, capsys):
    """Was: JSONDecodeError (exit 1, internal error)."""
    scenario, study = small_study
    out = tmp_path / "out"
    shutil.copytree(study, out)
    lines = (out / "study.log").read_text().splitlines(keepends=True)
    lines.insert(3, "this is not json\n")
    (out / "study.log").write_text("".join(lines))
    with pytest.raises(InputError, match=r"study.log: line 4 is not a journal record \(not JSON"):
        tune(_tune_settings(scenario, budget=4), out, resume=True, progress=False)
    argv = _tune_cli(scenario, str(out), 4)[len(CLI) :]
    rc, err = _exit(argv, capsys)
    assert rc == 2 and err.count("\n") == 1 and "line 4 is not a journal record" in err, err


def test_dask_http_address_is_a_fast_one_line_error(small_study, tmp_path, capsys):
    scenario, _ = small_study
    started = time.monotonic()
    argv = [*_tune_cli(scenario, str(tmp_path / "o"), 2)[len(CLI) : -1], "--dask", "http://127.0.0.1:8787"]
    rc, err = _exit(argv, capsys)
    assert rc == 2 and err.count("\n") == 1 and "not a scheduler address" in err, err
    assert time.monotonic() - started < 15
    assert not (tmp_path / "o").exists()


# ----------------------------------------------------------------------------- SIGTERM


@pytest.mark.parametrize(("scenario", "t_final"), [("paper", "50000"), ("paper-hardware", "2000")])
def test_sigterm_during_a_long_run_exits_143_without_a_result(tmp_path, scenario, t_final):
    """Was: exit 1, "Exception ignored on calling ctypes callback function ... Terminated" and "simulation failed:
    aborted" (the handler raised inside the ctypes callback)."""
    fsmctl.simulate(fsmctl.load_scenario(scenario).replace(simulation={"t_final": 0.2}))  # compiled: no first build
    argv = [*CLI, "simulate", "--scenario", scenario, "--t-final", t_final, "--output-interval", "10", "--progress"]
    proc = subprocess.Popen(
        [*argv, "--no-figures", "--out", "out"], cwd=tmp_path, env=_env(), stderr=subprocess.PIPE, text=False
    )
    seen = b""
    deadline = time.monotonic() + 120
    while b"step/s" not in seen and b"kstep" not in seen and time.monotonic() < deadline:
        chunk = os.read(proc.stderr.fileno(), 4096)  # the progress bar: the compiled loop is running
        if not chunk:
            break
        seen += chunk
    time.sleep(0.5)
    proc.send_signal(signal.SIGTERM)
    rest = proc.communicate(timeout=60)[1]
    err = (seen + rest).decode("utf-8", "replace")
    assert proc.returncode == 143, err[-2000:]
    assert "terminated" in err.splitlines()[-1] and "Exception ignored" not in err and "aborted" not in err
    assert not (tmp_path / "out").exists()


# ----------------------------------------------------------------------------- result files


@pytest.mark.filterwarnings("ignore:law 'pid' flown instead of 'fsm'")
def test_csv_result_of_a_law_with_states_reruns(tmp_path, capsys):
    """Was: ValueError: Variable 'law_state' (the states' coordinate written as an integer index)."""
    scenario = fsmctl.paper_scenario("1").replace(simulation={"t_final": 0.05}, controller={"law": "pid"})
    result = fsmctl.simulate(scenario)
    assert result.to_dataset()["law_state"].shape[-1] == 3
    result.save(tmp_path / "r.csv")
    result.save(tmp_path / "r.nc")
    assert load_result(tmp_path / "r.csv").identical(load_result(tmp_path / "r.nc"))
    assert scenario_from_result(tmp_path / "r.csv") == scenario
    rc, err = _exit(["simulate", "--from", str(tmp_path / "r.csv"), "--out", str(tmp_path / "again")], capsys)
    assert rc == 0, err
    with xr.open_dataset(tmp_path / "again" / "paper_case_1.nc") as again:
        np.testing.assert_array_equal(again["law_state"].values, result.to_dataset()["law_state"].values)


@pytest.mark.filterwarnings("ignore:law 'pid' flown instead of 'fsm'")
def test_from_refuses_a_law_other_than_the_recorded_one(tmp_path, capsys, monkeypatch):
    """Was: a result made with a relative law path re-ran whatever law sat at that path in the current folder."""
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    shutil.copytree(resolve_law("pid").folder, tmp_path / "a" / "law")
    shutil.copytree(resolve_law("super_twisting").folder, tmp_path / "b" / "law")
    monkeypatch.chdir(tmp_path / "a")
    base = fsmctl.paper_scenario("1").replace(simulation={"t_final": 0.05}, controller={"law": "law"})
    path = fsmctl.simulate(base).save(tmp_path / "a" / "r.nc")
    attrs = load_result(path).attrs
    assert attrs["law_path"] == str((tmp_path / "a" / "law").resolve()) and len(attrs["law_manifest_sha256"]) == 64
    monkeypatch.chdir(tmp_path / "b")  # another law sits at the relative path here: the recorded one is flown
    assert scenario_from_result(path).law.name == "pid"
    shutil.rmtree(tmp_path / "a" / "law")  # the recorded law is gone: the one found here is not it
    with pytest.raises(LawChangedError, match="is not the one this result was flown with"):
        scenario_from_result(path)
    rc, err = _exit(["simulate", "--from", str(path), "--out", str(tmp_path / "again")], capsys)
    assert rc == 2 and err.count("\n") == 1 and "is not the one this result was flown with" in err, err
    assert err.rstrip().endswith("a re-run would fly another law: restore that law, or fly the scenario afresh"), err
    shutil.copytree(resolve_law("pid").folder, tmp_path / "a" / "law")
    _edit_law_default(tmp_path / "a" / "law", "k_coupling", 0.25)  # the law at the recorded place, changed
    with pytest.raises(LawChangedError):
        scenario_from_result(path)


# ----------------------------------------------------------------------------- wheel friction


def _spinning_wheel(coulomb: float, dt: float):
    return single_spacecraft(
        J=((100.0, 0.0, 0.0), (0.0, 150.0, 0.0), (0.0, 0.0, 200.0)),
        sigma0=(0.0, 0.0, 0.0),
        omega0=(0.0, 0.0, 0.0),
        t_final=0.2,
        dt=dt,
        control_period=0.1,
        law_parameters={"bias": [0.0, 0.0, 0.0]},
        actuator={
            "kind": "reaction_wheels",
            "layout": "orthogonal",
            "spin_inertia": 0.01,
            "max_torque": 0.1,
            "coulomb_friction": coulomb,
            "coulomb_band": 0.1,
            "initial_speed": [0.0, 0.0, 0.05],  # inside the stiction band
        },
    )


def test_a_step_that_cannot_resolve_the_wheel_friction_is_reported():
    """Was: 1000 N m of Coulomb friction against 0.1 N m motors flew an energy-creating wheel with exit 0 and no word.

    Oracle: with no motor torque, friction only takes energy out of a wheel (and out of the hub it turns)."""

    def energy(r):  # kinetic energy of the spacecraft (hub and wheels), up to the constant wheel-axis terms
        return 0.5 * 0.01 * r.wheel_speed[:, 0, 2] ** 2

    bad = _spinning_wheel(1000.0, 1e-3)
    report = step_size_report(bad)
    assert report["dt"] * report["wheel_friction"] > 0.5
    assert any("cannot resolve the reaction wheels' friction" in p for p in report["problems"]), report["problems"]
    with pytest.warns(fsmctl.StepSizeWarning, match="friction"):
        r = fsmctl.simulate(bad)
    assert not np.all(np.diff(energy(r)) <= 1e-15)  # the flagged step creates energy
    dt_ok = 0.5 / report["wheel_friction"]
    fine = _spinning_wheel(1000.0, 1e-3 / 2 ** int(np.ceil(np.log2(1e-3 / dt_ok))))  # a divisor of the period
    assert not [p for p in step_size_report(fine)["problems"] if "friction" in p]
    r = fsmctl.simulate(fine)
    assert np.all(np.diff(energy(r)) <= 1e-15)
    assert not step_size_report(fsmctl.load_scenario("paper-hardware"))["problems"]


# ----------------------------------------------------------------------------- memory and seeds


def test_a_campaign_too_large_for_the_memory_is_refused_at_once(tmp_path):
    """Was: --vary noise --runs 1000000000 grew the parent by ~90 MB/s (a seed object per run, spawned up front)
    before printing anything."""
    settings, base = campaign_base(CampaignSettings(scenario="paper-hardware", vary="noise", runs=10**9))
    with pytest.raises(ResourceLimitError, match=r"1,000,000,000 runs would need ~.* TB of memory"):
        check_campaign_memory(settings, base, available=10**12)
    assert check_campaign_memory(settings, base, available=10**16) > 10**12
    code = (
        "import resource, sys; resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30)); "
        "from fsmctl.cli.main import main; sys.exit(main(sys.argv[1:]))"
    )
    argv = ["montecarlo", "--scenario", "paper-hardware", "--vary", "noise", "--runs", "1000000000000"]
    proc = subprocess.run(
        [sys.executable, "-c", code, *argv, "--out", "mc"],
        cwd=tmp_path,
        env=_env(),
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2 and "of memory but only" in proc.stderr, proc.stderr[-2000:]
    assert proc.stderr.count("\n") == 1 and proc.stdout == "", proc.stdout[-500:]
    assert not (tmp_path / "mc").exists()


def test_noise_seeds_drawn_per_chunk_are_the_documented_ones(tmp_path):
    settings = CampaignSettings(
        scenario="paper-hardware", vary="noise", runs=5, chunk_size=2, seed=11, t_final=0.2, steady_window=0.1
    )
    result = run_campaign(settings, tmp_path / "mc", workers=1, progress=False, figures=False)
    runs = np.random.SeedSequence(11).spawn(5)  # the documented seeds of the runs
    expected = [int(r.spawn(1)[0].generate_state(1, np.uint64)[0]) >> 11 for r in runs]
    assert result.dataset["noise_seed"].values.astype(np.int64).tolist() == expected


def test_from_refuses_another_fsmctls_builtin_law(tmp_path, capsys):
    """Was: a built-in law's result recorded no content hash, so `--from` on another fsmctl flew whatever its law of
    that name was.  The recorded hash is the sha256 of the law's generated manifest.json (hashlib on the file); a
    result recording another one (what another fsmctl's `fsm` gives) is refused."""
    scenario = fsmctl.paper_scenario("1").replace(simulation={"t_final": 0.05})
    path = fsmctl.simulate(scenario).save(tmp_path / "r.csv")
    attrs = load_result(path).attrs
    manifest = resolve_law("fsm").folder / "manifest.json"
    assert attrs["law_builtin"] == "true"
    assert attrs["law_manifest_sha256"] == hashlib.sha256(manifest.read_bytes()).hexdigest()
    assert scenario_from_result(path) == scenario
    other = path.read_text().replace(attrs["law_manifest_sha256"], "0" * 64)  # another fsmctl's fsm
    (tmp_path / "other.csv").write_text(other)
    with pytest.raises(LawChangedError, match="is not the one this result was flown with"):
        scenario_from_result(tmp_path / "other.csv")
    rc, err = _exit(["simulate", "--from", str(tmp_path / "other.csv"), "--out", str(tmp_path / "again")], capsys)
    assert rc == 2 and err.count("\n") == 1 and "is not the one this result was flown with" in err, err
    assert f"fly it with the fsmctl that made it (the result names fsmctl {attrs['version_fsmctl']})" in err, err


@pytest.mark.filterwarnings("ignore:law 'pid' flown instead of 'fsm'")
def test_from_names_the_recorded_path_of_a_law_that_is_gone(tmp_path, capsys, monkeypatch):
    """Was: a user law moved away from the absolute path a result records was looked for at the embedded relative
    path from the current folder, and the error named that path, which the result never recorded."""
    (tmp_path / "a").mkdir()
    (tmp_path / "elsewhere").mkdir()
    shutil.copytree(resolve_law("pid").folder, tmp_path / "a" / "law")
    monkeypatch.chdir(tmp_path / "a")
    base = fsmctl.paper_scenario("1").replace(simulation={"t_final": 0.05}, controller={"law": "law"})
    path = fsmctl.simulate(base).save(tmp_path / "a" / "r.nc")
    recorded = str((tmp_path / "a" / "law").resolve())
    shutil.move(tmp_path / "a" / "law", tmp_path / "a" / "law_moved")
    monkeypatch.chdir(tmp_path / "elsewhere")
    with pytest.raises(ResultFileError, match="is gone from") as caught:
        scenario_from_result(path)
    assert recorded in str(caught.value) and "'law' is not found from here" in str(caught.value)
    rc, err = _exit(["simulate", "--from", str(path), "--out", str(tmp_path / "again")], capsys)
    assert rc == 2 and err.count("\n") == 1 and recorded in err, err
