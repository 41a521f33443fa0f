"""Message counts as a metric (issue 28): ``compare``'s columns, ``montecarlo``'s per-run variables and summary, the
``tune`` objective ``messages``; one definition (:func:`fsmctl.simulation.message_metrics`) read by all three.

The independent checks: periodic broadcasting sends one message per agent at every control instant, so over a
horizon T at period h the count is ``n (floor(T / h) + 1)``; a trigger whose threshold is never crossed after t0
sends exactly the first message of each agent, ``n``; continuous control has no messages to count (NaN, "n/a"),
never 0.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import fsmctl
from fsmctl.errors import InputError
from fsmctl.studies import CampaignSettings, TuneSettings, compare_laws
from fsmctl.studies import montecarlo as mc
from fsmctl.studies.compare_runs import LawRun
from fsmctl.studies.tune import tune

N_AGENTS = 6  # the paper's formation
PERIOD = 0.1
HORIZON = 2.0
INSTANTS = math.floor(HORIZON / PERIOD + 1e-9) + 1  # t = 0, 0.1, ..., 2.0: 21 control instants


def _case1(**simulation) -> fsmctl.Scenario:
    sim = {"t_final": HORIZON, "output_interval": 0.1, **simulation}
    return fsmctl.paper_scenario("1").replace(simulation=sim)


def test_compare_counts_periodic_broadcasting_and_a_silent_trigger():
    runs = [
        LawRun("periodic", "fsm"),
        LawRun("silent", "fsm_event", parameters={"threshold_floor": 1e9, "threshold_initial": 0.0}),
    ]
    cmp = compare_laws(_case1(control_period=PERIOD), runs)
    periodic, silent = cmp.row("periodic"), cmp.row("silent")
    assert periodic["messages_count"] == N_AGENTS * INSTANTS == 126
    assert periodic["messages_per_agent_per_s"] == pytest.approx(INSTANTS / HORIZON, rel=1e-12)
    assert silent["messages_count"] == N_AGENTS  # each agent's first message at t0, then never again
    assert silent["messages_per_agent_per_s"] == pytest.approx(1 / HORIZON, rel=1e-12)
    assert "messages sent, all agents" in cmp.to_text()


def test_compare_says_not_applicable_for_continuous_control(tmp_path):
    cmp = compare_laws(_case1(control_period=0.0), ["fsm"])
    row = cmp.row("fsm")
    assert math.isnan(row["messages_count"]) and math.isnan(row["messages_per_agent_per_s"])
    text = cmp.to_text()
    line = next(ln for ln in text.splitlines() if "messages sent, all agents" in ln)
    assert "n/a (continuous)" in line and " 0 " not in line, line
    cmp.to_csv(tmp_path / "c.csv")
    header, values = (tmp_path / "c.csv").read_text().splitlines()[:2]
    cells = dict(zip(header.split(","), values.split(","), strict=True))
    assert cells["messages_count"] == "nan"


def test_montecarlo_stores_the_counts_per_run(tmp_path):
    settings = CampaignSettings(runs=2, seed=3, t_final=0.5, output_interval=0.1, control_period=PERIOD)
    out = mc.run_campaign(settings, tmp_path / "mc", workers=1, progress=False, figures=False)
    ds = out.dataset
    assert list(ds.status.values) == ["ok", "ok"]
    np.testing.assert_array_equal(ds.messages_count.values, [N_AGENTS * 6, N_AGENTS * 6])  # t = 0, 0.1, ..., 0.5
    assert ds.messages_per_agent_per_s.attrs["units"] == "1/s"
    summary = json.loads((tmp_path / "mc" / "summary.json").read_text())
    assert summary["statistics"]["messages_count"]["median"] == N_AGENTS * 6 and "messages" not in summary


def test_montecarlo_says_not_applicable_for_continuous_control(tmp_path):
    settings = CampaignSettings(runs=2, seed=3, t_final=0.3, output_interval=0.1, control_period=0.0)
    mc.run_campaign(settings, tmp_path / "mc", workers=1, progress=False, figures=False)
    summary = json.loads((tmp_path / "mc" / "summary.json").read_text())
    assert summary["statistics"]["messages_count"] == {"finite": 0, "nan": 2}
    assert summary["messages"].startswith("not applicable: continuous control")


@pytest.fixture(scope="module")
def sampled(tmp_path_factory):
    """The paper's scenario at 10 Hz control with a 50 N m torque limit (where it converges; docs/findings.md)."""
    path = tmp_path_factory.mktemp("scenario") / "sampled.toml"
    text = 'extends = "paper"\n[controller]\ntorque_limit = 50.0\n[simulation]\ncontrol_period = 0.1\n'
    path.write_text(text, encoding="utf-8")
    return str(path)


def test_tune_trades_messages_against_accuracy(sampled, tmp_path):
    settings = TuneSettings(
        scenario=sampled,
        case="1",
        law="fsm_event",
        budget=3,
        batch=3,
        seed=1,
        t_final=1.0,
        objectives=("aaem_steady", "messages"),
        parameters=("threshold_floor",),
        ranges=(("threshold_floor", 0.01, 1.0),),
        constraints=(),
    )
    result = tune(settings, tmp_path / "study")
    assert len(result.trials) == 3
    for trial in result.trials:
        floor = trial["params"]["threshold_floor"]
        scenario = fsmctl.load_scenario(sampled, case="1").replace(
            simulation={"t_final": 1.0}, controller={"law": "fsm_event", "parameters": {"threshold_floor": floor}}
        )
        flown = fsmctl.simulate(scenario)
        assert trial["objectives"]["messages"] == int(flown.messages_sent.sum())
        assert N_AGENTS <= trial["objectives"]["messages"] <= N_AGENTS * 11
        count = trial["objectives"]["messages"]
        assert result.objective_text("messages", count) == f"{count:.6g}"  # a count: no unit "1" after it


def test_tune_refuses_messages_on_continuous_control(tmp_path):
    settings = TuneSettings(
        law="fsm", budget=1, t_final=1.0, objectives=("messages",), parameters=("c1",), ranges=(("c1", 0.1, 2.0),)
    )
    with pytest.raises(InputError, match=r"^tune: objective messages needs a control period") as err:
        tune(settings, tmp_path / "study")
    assert "\n" not in str(err.value)
