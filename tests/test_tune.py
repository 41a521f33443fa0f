"""``fsmctl tune`` (:mod:`fsmctl.studies.tune`): determinism, resumption, the written design, ranges, constraints,
bad settings and the command line.  Short horizons and small budgets keep the file fast; the ``pid`` law where the
test does not depend on the law."""

from __future__ import annotations

import csv
import json
import math

import pytest

from fsmctl.cli.main import main
from fsmctl.errors import InputError
from fsmctl.model.laws import resolve_law
from fsmctl.model.scenario import load_scenario
from fsmctl.simulation.simulator import simulate
from fsmctl.studies.compare import run_metrics
from fsmctl.studies.tune import TuneSettings, search_space, tune

PID_RANGES = (("K", 5.0, 200.0), ("P", 10.0, 400.0))


@pytest.fixture(scope="module")
def unlimited(tmp_path_factory):
    """The paper's Case 1 without the torque limit: the PD law settles to 5 deg within 40 s for most gains."""
    path = tmp_path_factory.mktemp("scenario") / "unlimited.toml"
    path.write_text('extends = "paper"\n[controller]\ntorque_limit = "inf"\n', encoding="utf-8")
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


def _rows(path) -> list[dict]:
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def test_same_seed_and_budget_give_identical_trials(unlimited, tmp_path):
    a = tune(_pid(unlimited), tmp_path / "a")
    b = tune(_pid(unlimited), tmp_path / "b")
    assert (tmp_path / "a" / "trials.csv").read_text() == (tmp_path / "b" / "trials.csv").read_text()
    assert a.pareto == b.pareto and a.best == b.best
    c = tune(_pid(unlimited, seed=4), tmp_path / "c")
    assert [t["params"] for t in c.trials] != [t["params"] for t in a.trials]
    for name in ("trials.csv", "pareto.csv", "pareto.png", "best.toml", "tune.json"):
        assert (tmp_path / "a" / name).is_file()
    assert (tmp_path / "a" / "pareto.png").read_bytes()[:4] == b"\x89PNG"


def test_resumed_study_equals_one_run(unlimited, tmp_path):
    # one objective: TPE, whose model takes over after its 10 random start-up trials
    settings = _pid(unlimited, objectives=("aaem_settling",), budget=12)
    tune(settings, tmp_path / "once")
    tune(TuneSettings(**{**settings.__dict__, "budget": 5}), tmp_path / "twice")
    with pytest.raises(InputError, match="--resume"):
        tune(settings, tmp_path / "twice")
    tune(settings, tmp_path / "twice", resume=True)
    once, twice = _rows(tmp_path / "once" / "trials.csv"), _rows(tmp_path / "twice" / "trials.csv")
    assert len(once) == 12 and once == twice
    with pytest.raises(InputError, match="other settings"):
        tune(TuneSettings(**{**settings.__dict__, "seed": 9}), tmp_path / "twice", resume=True)


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
    assert set(result.constraints) == {"converged", "theorem1"} and result.theorem1 is True


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
        ({"parameters": ("K",), "ranges": ()}, "no declared upper bound"),
        ({"ranges": (("K", -1.0, 5.0), ("P", 10.0, 400.0))}, "range of K: must be > 0"),
        ({"tolerance_deg": 0.0}, "tolerance_deg must be"),
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
        (["--parameters", "K"], "no declared upper bound"),
    ]:
        assert _exit_code(["tune", "--law", "pid", "--out", str(tmp_path / "bad"), *argv]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err, err
    assert not (tmp_path / "bad").exists()
    out = tmp_path / "cli"
    args = ["tune", "--scenario", unlimited, "--law", "pid", "--budget", "3", "--t-final", "40", "--tolerance-deg", "5"]
    args += ["--parameters", "K,P", "--range", "K=5,200", "--range", "P=10,400", "--out", str(out), "--no-progress"]
    assert main(args) == 0
    assert "3 trials" in capsys.readouterr().out
    assert len(_rows(out / "trials.csv")) == 3
    assert main([*args, "--budget", "4", "--resume"]) == 0
    assert len(_rows(out / "trials.csv")) == 4
    assert not math.isnan(float(_rows(out / "trials.csv")[3]["K [N m]"]))


def test_a_trial_cut_off_by_ctrl_c_is_flown_again(unlimited, tmp_path, monkeypatch):
    import fsmctl.simulation.simulator as simulator

    settings = _pid(unlimited, budget=5, t_final=10.0)
    tune(settings, tmp_path / "once")
    real, calls = simulator.simulate, []

    def interrupted(scenario, **kw):
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(scenario, **kw)

    monkeypatch.setattr(simulator, "simulate", interrupted)
    with pytest.raises(KeyboardInterrupt):
        tune(settings, tmp_path / "cut")
    assert not (tmp_path / "cut" / "trials.csv").exists()
    monkeypatch.setattr(simulator, "simulate", real)
    tune(settings, tmp_path / "cut", resume=True)
    assert _rows(tmp_path / "cut" / "trials.csv") == _rows(tmp_path / "once" / "trials.csv")


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
    assert all(t["constraints"]["theorem1"] == 1.0 and not t["feasible"] for t in result.trials)
    assert len(result.notes) == 1 and "Theorem 1" in result.notes[0]
