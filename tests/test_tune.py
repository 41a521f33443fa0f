"""``fsmctl tune`` (:mod:`fsmctl.studies.tune`): determinism (whatever the workers or Dask), resumption (also after a
Ctrl-C), pruning, the written design, ranges, bad settings and the command line.  The constraints are in
``tests/test_tune_constraints.py``.  Short horizons and small budgets keep the file fast; the ``pid`` law where the
test does not depend on the law."""

from __future__ import annotations

import csv
import json
import math
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import optuna
import pytest
from optuna.storages import JournalStorage
from optuna.storages.journal import JournalFileBackend
from optuna.trial import TrialState

import fsmctl.studies.tune as tune_module
from fsmctl.cli.main import main
from fsmctl.errors import InputError
from fsmctl.model.laws import LawSwitchWarning, resolve_law
from fsmctl.model.scenario import load_scenario
from fsmctl.simulation.metrics import aaem_deg, principal_angles, settling_time, steady_state_max
from fsmctl.simulation.simulator import simulate
from fsmctl.studies import campaign
from fsmctl.studies.compare import run_metrics
from fsmctl.studies.tune import TuneSettings, search_space, tune
from fsmctl.studies.tune import evaluation as tune_eval
from fsmctl.studies.tune import search as tune_search
from fsmctl.studies.tune import storage as tune_storage

PID_RANGES = (("K", 5.0, 200.0), ("P", 10.0, 400.0))


@pytest.fixture(scope="module")
def unlimited(tmp_path_factory):
    """The paper's Case 1 without the torque limit: the PD law settles to 5 deg within 40 s for most gains (outputs
    every 0.1 s, which the metrics resolve)."""
    path = tmp_path_factory.mktemp("scenario") / "unlimited.toml"
    text = 'extends = "paper"\n[controller]\ntorque_limit = "inf"\n[simulation]\noutput_interval = 0.1\n'
    path.write_text(text, encoding="utf-8")
    return str(path)


def _pid(scenario: str, **kw) -> TuneSettings:
    base = dict(
        scenario=scenario,
        law="pid",
        budget=8,
        seed=3,
        objectives=("aaem_settling", "peak_torque"),
        tolerance_deg=5.0,
        t_final=40.0,
        parameters=("K", "P"),
        ranges=PID_RANGES,
    )
    return TuneSettings(**{**base, **kw})


def _pruned_pid(scenario: str, **kw) -> TuneSettings:
    """One objective (median pruner) and gains down to K = 0.5, which never settle: pruned from the third batch."""
    kw = {"objectives": ("aaem_settling",), "budget": 16, "batch": 4, "ranges": (("K", 0.5, 200.0), PID_RANGES[1])} | kw
    return _pid(scenario, **kw)


def _rows(path) -> list[dict]:
    """The rows of trials.csv / pareto.csv (the ``#`` lines above the header say what the columns mean)."""
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def _journal(folder):
    storage = JournalStorage(JournalFileBackend(str(folder / "study.log")))
    return optuna.load_study(study_name="fsmctl-tune", storage=storage)


def test_same_seed_and_budget_give_identical_trials(unlimited, tmp_path):
    a = tune(_pid(unlimited), tmp_path / "a")
    b = tune(_pid(unlimited), tmp_path / "b")
    assert (tmp_path / "a" / "trials.csv").read_text() == (tmp_path / "b" / "trials.csv").read_text()
    assert a.pareto == b.pareto and a.best == b.best
    c = tune(_pid(unlimited, seed=4, budget=2), tmp_path / "c")
    assert [t["params"] for t in c.trials] != [t["params"] for t in a.trials[:2]]
    for name in ("trials.csv", "pareto.csv", "pareto.png", "best.toml", "tune.json"):
        assert (tmp_path / "a" / name).is_file()
    assert (tmp_path / "a" / "pareto.png").read_bytes()[:4] == b"\x89PNG"
    assert a.settings.pruner == "none" and a.settings.batch == 8  # two objectives: no pruner


def test_workers_and_dask_give_the_same_trials_as_one_process(unlimited, tmp_path):
    # pruning on, so the pruner's decisions must not depend on where the candidates were flown either
    settings = _pruned_pid(unlimited)
    one = tune(settings, tmp_path / "one", workers=1)
    two = tune(settings, tmp_path / "two", workers=2)
    assert (tmp_path / "one" / "trials.csv").read_text() == (tmp_path / "two" / "trials.csv").read_text()
    assert any(t["state"] == "pruned" for t in one.trials) and one.best == two.best
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2, processes=False, threads_per_worker=1, dashboard_address=None, protocol="tcp"
    ) as cluster:
        tune(settings, tmp_path / "dask", dask=cluster.scheduler_address)
    assert (tmp_path / "one" / "trials.csv").read_text() == (tmp_path / "dask" / "trials.csv").read_text()


def _checkpoint_values(folder) -> list[dict]:
    """Every trial's intermediate values (the pruner's checkpoints), in trial order, from the study's journal."""
    trials = sorted(_journal(folder).trials, key=lambda t: t.user_attrs["index"])
    return [tune_module.intermediate_values(t) for t in trials]


def _alone(indices, slots, most):
    return [indices[i : i + 1] for i in range(len(indices))]


def _together(indices, slots, most):
    return [indices]


def test_candidates_flown_together_score_as_each_flown_alone(unlimited, tmp_path, monkeypatch):
    # Without a pruner a task flies several candidates in one simulate_many (their agents share the SIMD lanes):
    # each trial must be what it is flown alone, failed ones too (gains up to 1e7 make some runs blow up).  With a
    # pruner the candidates fly alone; forced together here, pruned and complete ones share flights and the
    # pruner's decisions must not change either.
    real, sizes, groups = tune_eval._fly, [], tune_search.candidate_groups

    def counted(candidates, judges):
        sizes.append(len(candidates))
        return real(candidates, judges)

    monkeypatch.setattr(tune_eval, "_fly", counted)
    wild = _pid(unlimited, t_final=10.0, ranges=(("K", 5.0, 1e6), ("P", 10.0, 1e7)))
    for name, settings in (("wild", wild), ("pruned", _pruned_pid(unlimited))):
        sizes.clear()
        default = tune(settings, tmp_path / f"{name}-default", workers=1)
        assert sizes == ([8] if name == "wild" else [1] * 16)  # no pruner: the batch in one flight here
        monkeypatch.setattr(tune_search, "candidate_groups", _alone)
        tune(settings, tmp_path / f"{name}-alone", workers=1)
        monkeypatch.setattr(tune_search, "candidate_groups", _together)
        sizes.clear()
        tune(settings, tmp_path / f"{name}-together", workers=1)
        assert max(sizes) == settings.batch
        monkeypatch.setattr(tune_search, "candidate_groups", groups)
        text = (tmp_path / f"{name}-alone" / "trials.csv").read_text()
        checkpoints = _checkpoint_values(tmp_path / f"{name}-alone")
        for way in ("default", "together"):
            assert (tmp_path / f"{name}-{way}" / "trials.csv").read_text() == text, (name, way)
            assert _checkpoint_values(tmp_path / f"{name}-{way}") == checkpoints, (name, way)
        states = {t["state"] for t in default.trials}
        assert states == ({"complete", "failed"} if name == "wild" else {"complete", "pruned"}), states
    # the default split: about one task per worker, at most as many candidates as fill one simulator batch
    assert [len(g) for g in groups(range(8), slots=2, most=10)] == [4, 4]
    assert [len(g) for g in groups(range(8), slots=1, most=3)] == [3, 3, 2]


def test_resumed_study_equals_one_run(unlimited, tmp_path):
    # one objective: TPE, whose model takes over after its 10 random start-up trials; the first study stops at a
    # batch boundary (4 = one batch), the documented condition for raising the budget to continue exactly
    settings = _pid(unlimited, objectives=("aaem_settling",), budget=12, batch=4)
    tune(settings, tmp_path / "once")
    tune(TuneSettings(**{**settings.__dict__, "budget": 4}), tmp_path / "twice")
    with pytest.raises(InputError, match="--resume"):
        tune(settings, tmp_path / "twice")
    # the ranges given in another order are the same study (their order means nothing)
    reordered = TuneSettings(**{**settings.__dict__, "ranges": tuple(reversed(settings.ranges))})
    assert reordered.ranges != settings.ranges
    tune(reordered, tmp_path / "twice", resume=True)
    once, twice = _rows(tmp_path / "once" / "trials.csv"), _rows(tmp_path / "twice" / "trials.csv")
    assert len(once) == 12 and once == twice
    wider = tuple((name, low, 2 * high) for name, low, high in settings.ranges)
    for change in ({"seed": 9}, {"batch": 3}, {"pruner": "halving"}, {"quantile": 0.5}, {"ranges": wider}):
        with pytest.raises(InputError, match="other settings") as info:
            tune(TuneSettings(**{**settings.__dict__, **change}), tmp_path / "twice", resume=True)
    # the refusal says what was recorded and what is asked now
    assert 'ranges [["K",5.0,200.0],["P",10.0,400.0]], now [["K",5.0,400.0],["P",10.0,800.0]]' in str(info.value)


def test_a_trial_cut_off_by_ctrl_c_is_flown_again(unlimited, tmp_path, monkeypatch):
    settings = _pid(unlimited, budget=5, t_final=10.0)
    tune(settings, tmp_path / "once")
    real, calls = tune_eval._fly, []

    def interrupted(candidates, judges):
        calls.append(1)
        if len(calls) == 1:  # in this process the batch's five candidates fly together: cut off in flight
            raise KeyboardInterrupt
        return real(candidates, judges)

    monkeypatch.setattr(tune_eval, "_fly", interrupted)
    with pytest.raises(KeyboardInterrupt):
        tune(settings, tmp_path / "cut", workers=1)  # in this process, where _fly is patched
    assert not (tmp_path / "cut" / "trials.csv").exists()
    # the batch was proposed before it was flown: its five trials wait in the journal with their parameters
    assert [t.state for t in _journal(tmp_path / "cut").trials] == [TrialState.RUNNING] * 5
    monkeypatch.setattr(tune_eval, "_fly", real)
    tune(settings, tmp_path / "cut", resume=True)
    assert _rows(tmp_path / "cut" / "trials.csv") == _rows(tmp_path / "once" / "trials.csv")
    assert len(_journal(tmp_path / "cut").trials) == 5  # resumed as proposed, not proposed again


def test_interrupted_workers_resume_as_one_uninterrupted_run(unlimited, tmp_path, monkeypatch):
    settings = _pruned_pid(unlimited, budget=12)
    tune(settings, tmp_path / "once")
    real, calls = campaign.Runner.run, []

    def interrupted(self, tasks, **kwargs):
        calls.append(1)
        if len(calls) == 2:  # the second batch: proposed, not flown
            raise KeyboardInterrupt
        return real(self, tasks, **kwargs)

    monkeypatch.setattr(campaign.Runner, "run", interrupted)
    with pytest.raises(KeyboardInterrupt):
        tune(settings, tmp_path / "cut", workers=2)
    states = [t.state for t in _journal(tmp_path / "cut").trials]
    assert states.count(TrialState.RUNNING) == 4 and len(states) == 8
    monkeypatch.setattr(campaign.Runner, "run", real)
    tune(settings, tmp_path / "cut", resume=True, workers=2)
    assert (tmp_path / "cut" / "trials.csv").read_text() == (tmp_path / "once" / "trials.csv").read_text()


def _told(out) -> int:
    """Trials told so far in a study another process is writing (0 while its journal cannot be read yet).

    Never before the writer has created its journal: opening it would create the file, and the writer, slow to start
    on a loaded machine, would then find "study.log exists" and refuse to start."""
    if not (out / "study.log").is_file():
        return 0
    try:
        return sum(t.state in (TrialState.COMPLETE, TrialState.PRUNED) for t in _journal(out).trials)
    except Exception:
        return 0


def test_ctrl_c_exits_130_and_resume_matches(unlimited, tmp_path):
    out = tmp_path / "cli"
    args = ["tune", "--scenario", unlimited, "--law", "pid", "--objectives", "aaem_settling", "--t-final", "40"]
    args += ["--tolerance-deg", "5", "--parameters", "K,P", "--range", "K=0.5,200", "--range", "P=10,400"]
    args += ["--batch", "4", "--seed", "3", "--no-progress"]
    proc = subprocess.Popen(
        [sys.executable, "-m", "fsmctl.cli.main", *args, "--budget", "400", "--workers", "2", "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and _told(out) < 8:  # two batches told: the pool is up and running
        time.sleep(0.2)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    lines = err.strip().splitlines()
    assert "interrupted by SIGINT" in lines[-1] and "--resume" in lines[-1] and "Traceback" not in err
    assert "resume=True" in lines[-1]  # the Python argument too: the same message reaches tune()'s callers
    told = _told(out)
    assert 8 <= told < 400
    budget = (told // 4 + 1) * 4  # a whole number of batches past what was told
    assert main([*args, "--budget", str(budget), "--workers", "1", "--out", str(out), "--resume"]) == 0
    assert main([*args, "--budget", str(budget), "--workers", "1", "--out", str(tmp_path / "ref")]) == 0
    assert (out / "trials.csv").read_text() == (tmp_path / "ref" / "trials.csv").read_text()


def test_pruning_stops_hopeless_candidates_by_the_median_rule(unlimited, tmp_path, monkeypatch):
    settings = _pruned_pid(unlimited)
    real, flights = tune_eval._fly, []

    def watched(candidates, judges):
        results = real(candidates, judges)
        assert len(candidates) == 1  # with a pruner a candidate flies alone
        flights.append((judges[0].pruned_at, [r.stopped_at for r in results[0]]))
        return results

    monkeypatch.setattr(tune_eval, "_fly", watched)
    result = tune(settings, tmp_path, workers=1)  # in this process, where _fly is patched
    # a pruned candidate's run was stopped by the simulator's monitor where the pruner decided, the others ran out
    assert len(flights) == 16 and all(stopped == [pruned_at] for pruned_at, stopped in flights)
    study = _journal(tmp_path)
    trials = sorted(study.trials, key=lambda t: t.user_attrs["index"])
    pruned = [t for t in trials if t.state == TrialState.PRUNED]
    assert pruned and len(pruned) < len(trials)
    horizon, steps = 40.0, tune_module.CHECKPOINTS
    for t in trials:
        row = result.trials[t.user_attrs["index"]]
        assert row["state"] == ("pruned" if t.state == TrialState.PRUNED else "complete")
        start = (t.user_attrs["index"] // settings.batch) * settings.batch
        earlier = [u for u in trials if u.state == TrialState.COMPLETE and u.user_attrs["index"] < start]
        values = tune_module.intermediate_values(t)
        # the median rule, computed here: from step 2 on (warm-up), once 5 trials of earlier batches completed, a
        # trial is pruned at the first step where its best value so far exceeds their median at that step
        verdicts = [
            len(earlier) >= 5
            and k >= 2
            and min(values[j] for j in range(1, k + 1))
            > np.median([tune_module.intermediate_values(u)[k] for u in earlier])
            for k in sorted(values)
        ]
        if t.state == TrialState.PRUNED:
            k = max(values)
            assert verdicts[-1] and not any(verdicts[:-1]) and t.intermediate_values == values  # reported to Optuna
            assert row["pruned_at"] == pytest.approx(k * horizon / steps) and not row["feasible"]
            assert row["objectives"] == {} and "converged" not in row["constraints"]
        else:
            assert sorted(values) == list(range(1, steps)) and not any(verdicts)
    # pruned trials count in the budget and show in trials.csv
    rows = _rows(tmp_path / "trials.csv")
    assert len(rows) == 16 and {r["state"] for r in rows} == {"complete", "pruned"}
    assert all(r["pruned_at [s]"] for r in rows if r["state"] == "pruned")
    # an intermediate value, computed independently: settling within [0, t_k], else T (2 + decades above the tolerance)
    t = next(u for u in trials if u.state == TrialState.COMPLETE and u.user_attrs["index"] == 1)
    scenario = tune_eval.trial_scenario(
        load_scenario(unlimited).replace(simulation={"t_final": 40.0}), "pid", search_space(settings), t.params
    )
    run = simulate(scenario, progress=False)
    for k in (2, 5):
        n = round(k * horizon / steps / run.scenario.simulation.output_interval) + 1
        time_k, a = run.time[:n], aaem_deg(principal_angles(run.sigma_e[:n]))
        settled = settling_time(time_k, a, 5.0)
        steady = steady_state_max(time_k, a, 0.4 * time_k[-1])
        expected = settled if math.isfinite(settled) else horizon * (2 + max(0.0, math.log10(steady / 5.0)))
        assert tune_module.intermediate_values(t)[k] == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("name", ["median", "halving"])
def test_frozen_snapshot_judges_as_a_study_holding_those_trials(name):
    # the pruner sees, through the snapshot, what an Optuna study holding the told trials and the candidate shows it
    rng = np.random.default_rng(1)
    told = []  # losses that fall over the steps, at random levels; every fourth trial was pruned after step 3
    for n in range(12):
        level = rng.uniform(0.5, 2.0)
        values = {k: level * (1 + 2 / k) for k in range(1, 10)}
        state = TrialState.PRUNED if n % 4 == 3 else TrialState.COMPLETE
        if state == TrialState.PRUNED:
            values = {k: v for k, v in values.items() if k <= 3}
        told.append((n, state, values))
    candidate = [1.6 * (1 + 2 / k) for k in range(1, 10)]  # a level above the median
    pruner = tune_eval._make_pruner
    # reference: a real study through which the told trials ran one after the other, then the candidate
    study = optuna.create_study(pruner=pruner(name))
    attrs = {}
    for n, state, values in told:
        trial = study.ask()
        for k, v in values.items():
            trial.report(v, k)
            trial.should_prune()  # the pruner's bookkeeping (successive halving's rungs), as during the trial's run
        attrs[n] = dict(study._storage.get_trial(trial._trial_id).system_attrs)
        if state == TrialState.COMPLETE:
            study.tell(trial, values[max(values)])
        else:
            study.tell(trial, state=TrialState.PRUNED)
    trial = study.ask()
    expected = []
    for k, v in enumerate(candidate, 1):
        trial.report(v, k)
        expected.append(trial.should_prune())
    snapshot = tuple((n, s.name, values, attrs[n]) for n, s, values in told)
    view_pruner, frozen = pruner(name), tune_eval._frozen_trials(snapshot)
    got, own_attrs, reported = [], {}, {}
    for k, v in enumerate(candidate, 1):
        reported[k] = v
        probe = optuna.trial.FrozenTrial(
            number=-1, state=TrialState.RUNNING, value=None, datetime_start=None, datetime_complete=None, params={},
            distributions={}, user_attrs={}, system_attrs=dict(own_attrs), intermediate_values=dict(reported),
            trial_id=-1,
        )  # fmt: skip
        got.append(view_pruner.prune(tune_eval._FrozenStudy(frozen, probe), probe))
        own_attrs = dict(probe.system_attrs)
    assert got == expected and True in expected and False in expected


def test_best_scenario_file_reproduces_the_trial(unlimited, tmp_path):
    result = tune(_pid(unlimited), tmp_path)
    assert result.best is not None
    best = result.trials[result.best]
    assert best["feasible"]
    assert best["objectives"]["aaem_settling"] == min(
        t["objectives"]["aaem_settling"] for t in result.trials if t["feasible"]
    )
    assert json.loads((tmp_path / "tune.json").read_text())["best"]["scenario_file_verified"] is True
    scenario = load_scenario(tmp_path / "best.toml")
    assert scenario.controller.law == "pid" and scenario.simulation.t_final == 40.0
    assert scenario.law_parameters()[0]["K"] == best["params"]["K"]
    metrics = run_metrics(simulate(scenario, progress=False), tolerances_deg=(5.0,))
    assert metrics["aaem_settling_5deg_s"] == best["objectives"]["aaem_settling"]
    assert metrics["peak_torque_N_m"] == best["objectives"]["peak_torque"]
    pareto = _rows(tmp_path / "pareto.csv")
    assert [int(r["trial"]) for r in pareto] == result.pareto and all(r["feasible"] == "1" for r in pareto)
    assert (
        main(["simulate", "--scenario", str(tmp_path / "best.toml"), "--out", str(tmp_path / "sim"), "--no-figures"])
        == 0
    )


def test_parameters_stay_within_declared_ranges(tmp_path):
    # fsm: alpha searched over its declared open range 0.5 < alpha < 1, the others over given ranges; delta is a vector
    settings = TuneSettings(
        scenario="paper",
        law="fsm",
        budget=8,
        seed=1,
        objectives=("aaem_settling",),
        t_final=5.0,
        parameters=("c1", "alpha", "delta", "boundary_layer"),
        ranges=(("c1", 0.1, 2.0), ("delta", 1e-4, 0.05), ("boundary_layer", 0.0, 0.01)),
    )
    space = {p.name: p for p in search_space(settings)}
    assert space["delta"].log and not space["c1"].log and space["delta"].size == 3
    assert 0.5 < space["alpha"].low and space["alpha"].high < 1
    result = tune(settings, tmp_path)
    law = resolve_law("fsm")
    assert len(result.trials) == 8
    for t in result.trials:
        for name, value in t["params"].items():
            assert space[name].low <= value <= space[name].high
            assert law.parameter(name).problem(value) is None
    # every constraint that applies to the paper's law under the paper's 2 N m limit (no wheels)
    assert result.constraints == ("converged", "theorem1", "theorem2", "torque") and result.theorem1 is True


def test_coupling_factors_are_searched_for_fsm_and_written_to_best_toml(tmp_path):
    ranges = tuple((name, 0.001, 1.0) for name in ("c1", "c2", "boundary_layer", "epsilon", "delta"))
    default = {p.name: p for p in search_space(TuneSettings(law="fsm", ranges=ranges))}
    assert {"k_i_scale", "k_j_scale"} <= set(default) and default["k_i_scale"].log
    case2 = load_scenario("paper", "2")  # no coupling: nothing to scale
    assert "k_i_scale" not in {p.name for p in search_space(TuneSettings(law="fsm", ranges=ranges), case2)}
    settings = TuneSettings(
        scenario="paper",
        law="fsm",
        case="3a",
        budget=3,
        objectives=("peak_torque",),
        t_final=2.0,
        parameters=("c1", "k_i_scale", "k_j_scale"),
        ranges=(("c1", 0.1, 2.0), ("k_i_scale", 0.5, 2.0), ("k_j_scale", 0.5, 2.0)),
        constraints=("theorem1",),
    )
    result = tune(settings, tmp_path)
    assert result.best is not None
    best = result.trials[result.best]["params"]
    written = load_scenario(tmp_path / "best.toml")  # case 3a: k^i = 2, k^j = 0.6 when on, scaled
    link = written.topology.links[0]
    assert link.k_i == 2.0 * best["k_i_scale"] and link.k_j.max == best["k_j_scale"] * 0.6
    assert json.loads((tmp_path / "tune.json").read_text())["best"]["scenario_file_verified"] is True


def test_best_file_with_relative_paths_is_verified(tmp_path, monkeypatch):
    """The tuning guide's own call, with paths relative to the working folder: best.toml writes them absolute, and
    it flies the chosen design (a relative and an absolute path to one law script are one law)."""
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    monkeypatch.chdir(root)
    out = tmp_path / "tune"
    argv = ["tune", "--scenario", "docs/examples/my_law.toml", "--law", "docs/examples/my_law.py"]
    argv += ["--parameters", "K,P", "--range", "K=1,20", "--range", "P=2,60", "--objectives", "aaem_settling"]
    argv += ["--budget", "3", "--seed", "0", "--out", str(out), "--no-progress"]
    assert main(argv) == 0
    assert json.loads((out / "tune.json").read_text())["best"]["scenario_file_verified"] is True


def test_a_design_that_cannot_settle_is_infeasible(tmp_path):
    # the paper's 2 N m limit and a 5 s horizon: no gain settles, so every trial is infeasible and nothing is chosen
    result = tune(_pid("paper", t_final=5.0, budget=4, tolerance_deg=1.0), tmp_path)
    assert result.best is None and result.pareto == []
    for t in result.trials:
        assert t["state"] == "complete" and not t["feasible"]
        assert t["constraints"]["converged"] > 0
        assert t["objectives"]["aaem_settling"] >= 2 * 5.0  # never settles: at least twice the horizon
    assert not (tmp_path / "best.toml").exists()
    assert all(r["feasible"] == "0" for r in _rows(tmp_path / "trials.csv"))
    assert json.loads((tmp_path / "tune.json").read_text())["best"] is None


def test_ensemble_quantile(unlimited, tmp_path):
    settings = _pid(unlimited, ensemble=2, quantile=1.0, budget=3, t_final=10.0, objectives=("peak_torque",))
    worst = tune(settings, tmp_path / "worst")
    best = tune(TuneSettings(**{**settings.__dict__, "quantile": 0.0}), tmp_path / "best")
    for w, b in zip(worst.trials, best.trials, strict=True):
        assert w["params"] == b["params"]
        assert w["objectives"]["peak_torque"] >= b["objectives"]["peak_torque"]
    assert any(w["objectives"] != b["objectives"] for w, b in zip(worst.trials, best.trials, strict=True))


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"objectives": ("speed",)}, "unknown objective 'speed'"),
        ({"budget": 0}, "budget must be"),
        ({"quantile": 1.5}, "quantile must be in"),
        ({"parameters": ("K", "nope")}, "has no parameter 'nope'"),
        ({"law": "no-such-law"}, "not a built-in law"),
        ({"parameters": ("K",), "ranges": ()}, r"no declared range to search for K \(no upper bound"),
        ({"ranges": (("K", -1.0, 5.0), ("P", 10.0, 400.0))}, "range of K: must be > 0"),
        ({"tolerance_deg": 0.0}, "tolerance_deg must be"),
        ({"batch": 0}, "batch must be"),
        ({"pruner": "sometimes"}, "unknown pruner 'sometimes'"),
        ({"pruner": "median"}, "pruner median judges one objective"),
        ({"constraints": ("speed",)}, "unknown constraint 'speed'"),
        ({"parameters": ("k_i_scale",), "ranges": (("k_i_scale", -1.0, 2.0),)}, "range of k_i_scale: must be >= 0"),
        # a parameter that cannot be searched is named first, before the ranges that follow from it
        ({"law": "fsm", "parameters": ("singularity_fix",), "ranges": (("c1", 0.1, 2.0),)}, "named options"),
    ],
)
def test_bad_settings_are_one_line_errors(change, message):
    with pytest.raises(InputError, match=message) as info:
        _pid("paper", **change).validate()
    assert "\n" not in str(info.value)


def _exit_code(argv: list[str]) -> int:
    try:
        return main(argv)
    except SystemExit as exc:  # argparse's own errors
        return int(exc.code)


def test_cli(unlimited, tmp_path, capsys):
    for argv, message in [
        (["--objectives", "speed"], "unknown objective"),
        (["--budget", "0"], "--budget: must be >= 1"),
        (["--quantile", "1.5"], "--quantile: must be in [0, 1]"),
        (["--range", "K=5"], "expected NAME=LOW,HIGH"),
        (["--parameters", "K"], "no declared range to search for K (no upper bound"),
        (["--parameters", "K,P", "--range", "K=1,2", "--range", "P=1,2", "--workers", "0"], "--workers: must be >= 1"),
        (["--parameters", "K,P", "--batch", "0"], "--batch: must be >= 1"),
        (["--parameters", "K,P", "--pruner", "often"], "--pruner: invalid choice"),
        (["--parameters", "K,P", "--range", "K=1,2", "--range", "P=1,2", "--pruner", "median"], "judges one objective"),
        (
            ["--parameters", "K,P", "--range", "K=1,2", "--range", "P=1,2", "--constraints", "wheels"],
            "no reaction wheels",
        ),
        (["--parameters", "K,P", "--range", "K=1,2", "--range", "P=1,2", "--constraints", "theorem1"], "paper's law"),
        (["--parameters", "K,P", "--range", "K=1,2", "--range", "P=1,2", "--dask", "tcp://127.0.0.1:9"], "Dask"),
    ]:
        assert _exit_code(["tune", "--law", "pid", "--out", str(tmp_path / "bad"), *argv]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err, err
    assert not (tmp_path / "bad").exists()
    out = tmp_path / "cli"
    args = ["tune", "--scenario", unlimited, "--law", "pid", "--budget", "3", "--t-final", "40", "--tolerance-deg", "5"]
    args += ["--parameters", "K,P", "--range", "K=5,200", "--range", "P=10,400", "--out", str(out), "--no-progress"]
    assert main([*args, "--workers", "1"]) == 0
    assert "3 trials" in capsys.readouterr().out
    assert len(_rows(out / "trials.csv")) == 3
    assert main([*args, "--budget", "4", "--resume", "--workers", "1"]) == 0
    assert len(_rows(out / "trials.csv")) == 4
    assert not math.isnan(float(_rows(out / "trials.csv")[3]["K [N m]"]))
    # where the files came from: the command line and the versions, in tune.json and as comments in best.toml
    record = json.loads((out / "tune.json").read_text())
    assert record["command"].endswith("--no-progress --budget 4 --resume --workers 1"), record["command"]
    assert {"fsmctl", "casadi", "numpy", "python", "optuna"} <= set(record["versions"])
    header = (out / "best.toml").read_text().split("extends")[0]
    assert "# versions: fsmctl " in header and f"# command: {record['command']}" in header
    assert f"# run it (from where the study ran): fsmctl simulate --scenario {out / 'best.toml'}" in header
    assert record["best"]["tie"] == ""  # the trials scored differently (a tie is said here, as in the summary)
    assert load_scenario(out / "best.toml").controller.law == "pid"
    # the tuned scenario is named relative to best.toml's folder (both lie under pytest's temporary folder)
    (extends,) = [line for line in (out / "best.toml").read_text().splitlines() if line.startswith("extends = ")]
    target = extends.removeprefix("extends = ").strip('"')
    assert not Path(target).is_absolute() and (out / target).resolve() == Path(unlimited).resolve(), extends


def test_help_documents_every_option_objective_and_constraint(capsys):
    with pytest.raises(SystemExit):
        main(["tune", "--help"])
    text = capsys.readouterr().out
    for word in (
        *tune_module.OBJECTIVES,
        *tune_module.CONSTRAINTS,
        *tune_module.COUPLING,
        "--workers",
        "--dask",
        "--batch",
        "--pruner",
        "--constraints",
        "--resume",
        "MedianPruner",
        "130",
    ):
        assert word in text, word


def test_theorem1_failing_for_the_topology_makes_every_fsm_trial_infeasible(tmp_path):
    scenario = tmp_path / "weak.toml"  # k^i = 1 < k^j = 5: Theorem 1's k^i >= k^j (eq 27) fails
    scenario.write_text(
        'extends = "paper"\n[topology]\nk_i = 1.0\n'
        "schedule = { period = 8.0, breakpoints = [0.0, 6.5], values = [5.0, 0.0] }\n",
        encoding="utf-8",
    )
    settings = TuneSettings(
        scenario=str(scenario),
        law="fsm",
        budget=2,
        objectives=("peak_torque",),
        t_final=2.0,
        parameters=("c1", "c2"),
        ranges=(("c1", 0.1, 2.0), ("c2", 0.1, 2.0)),
    )
    result = tune(settings, tmp_path / "out")
    assert result.theorem1 is False and result.best is None
    # 1 + the excess of k^j over k^i (5 - 1)
    assert all(t["constraints"]["theorem1"] == 5.0 and not t["feasible"] for t in result.trials)
    assert len(result.notes) == 1 and "Theorem 1" in result.notes[0]


def test_the_journal_gains_a_batch_in_one_write(tmp_path):
    from optuna.storages import JournalStorage

    path = tmp_path / "study.log"
    journal = tune_storage.BufferedJournal(str(path))
    study = optuna.create_study(storage=JournalStorage(journal), study_name="s")
    size = path.stat().st_size
    with journal.buffered():
        trials = [study.ask() for _ in range(3)]
        for t in trials:
            t.suggest_float("x", 0.0, 1.0)
        assert path.stat().st_size == size and len(study.trials) == 3  # read back from memory, not yet written
    assert path.stat().st_size > size
    with journal.buffered():
        for t in trials:
            study.tell(t, t.params["x"])
    # the file is Optuna's own journal format
    again = optuna.load_study(study_name="s", storage=JournalStorage(JournalFileBackend(str(path))))
    assert [t.params["x"] for t in again.trials] == [t.value for t in again.trials]
    assert [t.state for t in again.trials] == [TrialState.COMPLETE] * 3


def test_every_objective_is_one_entry_whose_checkpoint_score_ends_at_its_value():
    """An objective is one :class:`Objective` of ``OBJECTIVES``: its unit, its run_metrics column, its pruning score.

    At the last output sample the pruner's estimate (``partial``) is the complete run's value (the run_metrics
    column; chattering's estimate sees the output samples only); checked on a scenario with reaction wheels, so
    that every objective applies."""
    from fsmctl.studies.tune import OBJECTIVES, Objective

    scenario = load_scenario("paper-hardware").replace(simulation={"t_final": 1.0, "output_interval": 0.05})
    result = simulate(scenario, progress=False)
    metrics = run_metrics(result, tolerances_deg=(1.0,))
    w = len(result.time)
    u = np.asarray(result.u, dtype=float)
    assert OBJECTIVES["peak_torque"].partial(result, w) == float(np.max(np.abs(u)))  # an independent oracle
    for name, objective in OBJECTIVES.items():
        assert isinstance(objective, Objective) and objective.unit, name
        if objective.partial is not None and name != "chattering":
            assert objective.partial(result, w) == pytest.approx(metrics[objective.metric], rel=1e-9), name
        elif objective.partial is not None:  # the engine's total variation counts every step, not only the samples
            assert 0 < objective.partial(result, w) and 0 < metrics[objective.metric], name
        else:
            assert objective.error in ("aaem", "raem"), name
            assert objective.metric is None or objective.metric == f"{objective.error}_steady_max_deg", name
    with pytest.raises(ValueError, match="not both"):
        Objective("1", "both", "peak_torque_N_m", error="aaem", partial=OBJECTIVES["peak_torque"].partial)


def test_the_search_is_reachable_from_the_studies_package():
    # the guide's spelling: fsmctl.studies.tune is the module (as `from fsmctl.studies import tune` gives it), and
    # fsmctl.studies.tune.tune the search (a new user found the attribute missing before it was imported)
    code = "import fsmctl.studies as s; m = s.tune; from fsmctl.studies.tune import tune; print(m.tune is tune)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "True"


def test_tuning_another_law_on_the_paper_scenario_warns_of_no_law_switch(tmp_path):
    """best.toml flies ``pid`` over the paper scenario, whose fsm parameters it ignores, as asked: checking that
    best.toml reproduces the design warned LawSwitchWarning in Python (a fresh user's report); a warning of the
    tuning itself still passes."""
    settings = TuneSettings(
        scenario="paper",
        law="pid",
        budget=2,
        t_final=2.0,
        parameters=("K", "P"),
        ranges={"K": (5.0, 200.0), "P": (10.0, 400.0)},
        objectives=("peak_torque",),
        constraints=("converged",),
        tolerance_deg=179.0,  # every trial converges within 2 s: best.toml is written and checked
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = tune(settings, tmp_path / "pid", workers=1, progress=False)
    assert result.best is not None and (tmp_path / "pid" / "best.toml").exists()
    assert [w.message for w in caught if issubclass(w.category, LawSwitchWarning)] == []
    assert json.loads((tmp_path / "pid" / "tune.json").read_text())["best"]["scenario_file_verified"] is True
