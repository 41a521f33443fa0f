"""One "steady" and one "converged" for every command (fsmctl.policy), and ``simulate``'s one-line result.

The steady window is the last 40 % of the horizon, at most 40 s (the paper's last 40 s of 100 s, Liang, Sun & Wang
2012, Section 4); "converged" is AAEM and RAEM (eqs 42-43) staying at or below 1 deg until the end.  The oracles
recompute both from the written arrays (the result file) by their definitions: the maximum over the final window,
the last sample above the tolerance.  A short run is the case that used to be wrong: its steady window was 40 s,
that is the whole run, so a run that had converged printed its initial error as its "steady" accuracy.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import fsmctl
from fsmctl.cli.main import main
from fsmctl.studies.montecarlo import CampaignSettings, campaign_base, run_record, sample_run_scenario

UNLIMITED = fsmctl.paper_scenario("1").replace(controller={"torque_limit": float("inf")})
"""Case 1 without the torque limit: converges within 3 s (AAEM and RAEM <= 0.01 deg)"""


def _settled_from(time: np.ndarray, metric: np.ndarray, tolerance: float) -> float:
    """The time of the first sample after the last one above ``tolerance`` (the oracle of a settling time)."""
    above = np.flatnonzero(metric > tolerance)
    return float(time[above[-1] + 1])


def test_the_summary_takes_the_policy_window_of_a_short_run():
    r = fsmctl.simulate(UNLIMITED.replace(simulation={"t_final": 10.0}))
    s = r.summary()
    assert s["steady_window_s"] == pytest.approx(4.0, rel=1e-15)  # 40 % of 10 s (the whole run before)
    last = r.time >= r.time[-1] - 4.0 - 1e-9
    assert s["aaem_steady_max_deg"] == r.aaem_deg[last].max() < 0.01  # converged by 3 s
    assert s["raem_steady_max_deg"] == r.raem_deg[last].max() < 0.01
    assert s["converged"] and s["aaem_final_deg"] == r.aaem_deg[-1] and s["horizon_s"] == 10.0
    assert r.summary(steady_window=1.0)["steady_window_s"] == 1.0  # an explicit window is kept


def test_simulate_states_converged_first_then_final_and_steady_with_its_window(tmp_path, capsys):
    out = tmp_path / "run"
    argv = ["simulate", "--case", "1", "--torque-limit", "inf", "--t-final", "10", "--no-figures", "--out", str(out)]
    assert main(argv) == 0
    printed = capsys.readouterr().out.splitlines()
    with xr.open_dataset(out / "paper_case_1.nc") as ds:
        t, aaem, raem = ds["time_s"].values, ds["aaem_deg"].values, ds["raem_deg"].values
    result = next(i for i, line in enumerate(printed) if not line.startswith(" ") and "converged" in line)
    since = max(_settled_from(t, m, 1.0) for m in (aaem, raem))
    assert printed[result] == (
        f"converged: AAEM and RAEM stay <= 1 deg from {since:.2f} s on (finest: AAEM <= 0.01 deg from "
        f"{_settled_from(t, aaem, 0.01):.2f} s, RAEM <= 0.01 deg from {_settled_from(t, raem, 0.01):.2f} s)"
    )
    assert printed[result + 1] == f"  final (t = 10 s): AAEM {aaem[-1]:.4g} deg, RAEM {raem[-1]:.4g} deg"
    last = t >= 6.0 - 1e-9
    assert printed[result + 2] == (
        f"  steady: max over the last 4 s (40 % of the 10 s horizon): AAEM {aaem[last].max():.4g} deg, "
        f"RAEM {raem[last].max():.4g} deg"
    )
    summary = json.loads((out / "summary.json").read_text())
    assert summary["result"] == printed[result] and summary["summary"]["converged"] is True


def test_simulate_states_not_converged_with_the_final_values(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["simulate", "--case", "1", "--t-final", "2", "--no-figures", "--out", str(out)]) == 0
    printed = capsys.readouterr().out.splitlines()
    with xr.open_dataset(out / "paper_case_1.nc") as ds:
        aaem, raem = ds["aaem_deg"].values, ds["raem_deg"].values
    line = next(line for line in printed if line.startswith("not converged"))
    assert line.startswith(f"not converged within 2 s: AAEM {aaem[-1]:.4g} deg, RAEM {raem[-1]:.4g} deg at the end (")
    steady = next(line for line in printed if line.startswith("  steady: max over the last 0.8 s (40 % of the 2 s "))
    assert steady.endswith("(not converged: the window holds no steady state)")


def test_a_steady_window_that_starts_in_the_transient_says_so(tmp_path, capsys):
    """Unlimited Case 1 settles to 0.01 deg near 2.7 s; over 4 s the window starts at 2.4 s, before that: the line
    says the transient is included (the trial's ring: 0.29 deg "steady" against 3e-5 deg at the end)."""
    out = tmp_path / "run"
    argv = ["simulate", "--case", "1", "--torque-limit", "inf", "--t-final", "4", "--no-figures", "--out", str(out)]
    assert main(argv) == 0
    printed = capsys.readouterr().out.splitlines()
    with xr.open_dataset(out / "paper_case_1.nc") as ds:
        t, aaem, raem = ds["time_s"].values, ds["aaem_deg"].values, ds["raem_deg"].values
    settled = max(_settled_from(t, m, 0.01) for m in (aaem, raem))
    assert 2.4 < settled < 4.0  # the premise: the window [2.4 s, 4 s] starts before the run settles
    steady = next(line for line in printed if line.startswith("  steady: "))
    assert steady.endswith(
        f"(the window starts at 2.4 s, before the run settles at {settled:.2f} s: transient included)"
    )


def test_a_campaign_takes_the_policy_window_and_the_one_convergence_rule():
    settings, base = campaign_base(CampaignSettings(runs=1, t_final=1.0, torque_limit=float("inf")))
    assert CampaignSettings().steady_window is None  # the policy's, not a number of its own
    seed = np.random.SeedSequence(settings.seed).spawn(1)[0]
    scenario = sample_run_scenario(base, settings, seed)
    result = fsmctl.simulate(scenario)
    rec = run_record(scenario, settings, seed, result)
    last = result.time >= result.time[-1] - 0.4 - 1e-9  # 40 % of 1 s
    assert rec["aaem_steady_max_deg"] == result.aaem_deg[last].max()
    assert rec["raem_steady_max_deg"] == result.raem_deg[last].max()
    settled = all(m[-1] <= 1.0 for m in (result.aaem_deg, result.raem_deg))
    assert rec["converged"] == settled


def test_compare_states_its_window(capsys, tmp_path):
    from fsmctl.studies.compare import compare_laws

    comparison = compare_laws(UNLIMITED.replace(simulation={"t_final": 2.0}), ["fsm"], tolerances_deg=(1.0,))
    assert "steady statistics over the last 0.8 s (40 % of the 2 s horizon)" in comparison.to_text()
    assert "steady statistics over the last 0.8 s (40 % of the 2 s horizon)" in comparison.to_markdown()


def test_the_torque_line_says_what_each_saturation_figure_counts(tmp_path, capsys):
    """The saturated time is counted at every step, the last saturation at the output samples: the line says so, so
    "0.20 s saturated, last at 0.10 s" (a wheel at its limit between two samples) does not read as a contradiction."""
    example = Path(__file__).parents[1] / "docs" / "examples" / "wheels_and_sensors.toml"
    argv = ["simulate", "--scenario", str(example), "--t-final", "1", "--no-figures", "--out", str(tmp_path / "w")]
    assert main(argv) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("  torque: "))
    summary = json.loads((tmp_path / "w" / "summary.json").read_text())["summary"]
    sat = summary["saturated_time_s"]
    assert (
        f"saturated for {min(sat):.2f}–{max(sat):.2f} s of 1 s (from the least to the most saturated agent; any axis "
        "at its limit, checked at every step)" in line
    )
    assert line.endswith(f"last at the output sample t = {summary['last_saturation_s']:.2f} s")
