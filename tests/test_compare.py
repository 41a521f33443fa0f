"""Law comparisons (`fsmctl compare`, fsmctl.studies.compare) on a 10 s horizon of the paper's Case 1.

Oracles: every metric recomputed here from the recorded trajectory by its definition (settling times by scanning
the AAEM/RAEM arrays, AAEM from the attitude errors by eq 42 with theta = 4 atan|sigma|, RMS torque and effort by
the trapezoid rule of the recorded u, chattering = the engine's per-step total variation summed over agents,
which bounds the variation seen on the coarser output grid); the torque limit as a bound on the applied torque
(with the limit) and the commanded torque exceeding it (without); the law's declared parameters for bad input.
The second law is a PD law written here with the public LawBuilder API and flown from its script.
"""

from __future__ import annotations

import csv
import json
import math
import warnings

import numpy as np
import pytest

import fsmctl.cli.main as cli_main
from fsmctl.errors import InputError
from fsmctl.studies.compare import Comparison, compare_laws, metric_columns
from fsmctl.studies.compare_runs import LawRun, read_runs_file, run_scenario, with_and_without_limit

PD_LAW = """
from fsmctl.symbolic.law import LawBuilder


def law(error_model):
    b = LawBuilder("pd", error_model, doc="MRP PD with consensus on the attitude error (test law)")
    K = b.parameter("K", 1.0, unit="N m", minimum=0.0, doc="attitude gain")
    P = b.parameter("P", 10.0, unit="N m s", minimum=0.0, doc="rate gain")
    e = b.error_state()
    b.broadcast("sigma_e", e.sigma_e)
    b.torque(-K * e.sigma_e - P * e.omega_e - K * (b.k_sum * e.sigma_e - b.received))
    return b.build()
"""

UNITS = ("_s", "_deg", "_N_m", "_N_m_s", "_N_m_per_s", "_count")


@pytest.fixture(scope="module")
def short(paper_case1):
    """Case 1 (2 N m limit) over 10 s, sampled every 0.1 s."""
    return paper_case1.replace(simulation={"t_final": 10.0, "output_interval": 0.1})


@pytest.fixture(scope="module")
def pd_law(tmp_path_factory):
    path = tmp_path_factory.mktemp("laws") / "pd.py"
    path.write_text(PD_LAW)
    return path


@pytest.fixture(scope="module")
def pair(short, pd_law) -> Comparison:
    """FSM and the PD law, each with the 2 N m limit and without; the results are kept by the hook."""
    runs = with_and_without_limit([LawRun("FSM", "fsm"), LawRun("PD", str(pd_law), {"K": 2.0})], 2.0)
    return compare_laws(short, runs, workers=2, on_result=lambda run, result: result)


def _settling_by_hand(t, v, tol):
    above = [k for k in range(len(t)) if not v[k] <= tol]
    if not above:
        return t[0]
    k = above[-1]
    return t[k + 1] if k + 1 < len(t) else math.nan


def _same(a, b, rel=1e-12):
    return (math.isnan(a) and math.isnan(b)) or a == pytest.approx(b, rel=rel, abs=1e-300)


def test_metrics_against_the_trajectory(pair):
    assert [r["label"] for r in pair.table] == [
        "FSM (limit 2 N m)",
        "FSM (no limit)",
        "PD (limit 2 N m)",
        "PD (no limit)",
    ]
    kinds = set()
    for row in pair.table:
        r = pair.extras[row["label"]]
        t, n, span = r.time, r.n_agents, r.time[-1] - r.time[0]
        assert row["status"] == "ok" and row["law"] == ("fsm" if row["label"].startswith("FSM") else "pd")
        # eq 42 from the attitude errors: theta = 4 atan|sigma_e| (shadow set: |sigma_e| <= 1)
        norm = np.linalg.norm(r.sigma_e, axis=2)
        theta = 4 * np.arctan(np.minimum(norm, 1 / np.maximum(norm, 1e-300)))
        np.testing.assert_allclose(r.aaem_deg, np.degrees(np.sqrt(np.mean(theta**2, axis=1))), rtol=1e-9)
        for tol in (1.0, 0.1, 0.01):
            for metric, values in (("aaem", r.aaem_deg), ("raem", r.raem_deg)):
                expected = _settling_by_hand(t, values, tol)
                assert _same(row[f"{metric}_settling_{tol:g}deg_s"], expected), (row["label"], metric, tol)
                kinds.add(math.isfinite(expected))
        window = pair.settings["steady_window_s"]
        assert window == 4.0  # 40 % of 10 s
        last = t >= 10.0 - 4.0 - 1e-9
        assert last.sum() == 41
        for metric, values in (("aaem", r.aaem_deg), ("raem", r.raem_deg)):
            assert row[f"{metric}_steady_mean_deg"] == pytest.approx(values[last].mean(), rel=1e-12)
            assert row[f"{metric}_steady_max_deg"] == values[last].max()
        u = r.u
        assert row["peak_torque_N_m"] == np.abs(u).max()
        assert row["peak_commanded_torque_N_m"] == r.u_unsaturated_max.max() >= np.abs(r.u_unsaturated).max()
        power = np.trapezoid(np.sum(u**2, axis=(1, 2)), t)
        assert row["rms_torque_N_m"] == pytest.approx(math.sqrt(power / (n * span)), rel=1e-12)
        effort = sum(np.trapezoid(np.abs(u[:, i]).sum(axis=1), t) for i in range(n))
        assert row["control_effort_N_m_s"] == pytest.approx(effort, rel=1e-12)
        # chattering: the engine's total variation over every step, summed over agents; it bounds the variation
        # on the output grid (the triangle inequality), and per second is the engine's chattering index summed
        assert row["chattering_N_m"] == pytest.approx(r.u_total_variation.sum(), rel=1e-12)
        assert row["chattering_N_m"] >= np.abs(np.diff(u, axis=0)).sum() * (1 - 1e-12)
        assert row["chattering_N_m_per_s"] == pytest.approx(r.u_total_variation.sum() / span, rel=1e-12)
        assert row["chattering_N_m_per_s"] == pytest.approx(r.chattering_index.sum(), rel=1e-12)
        assert row["saturated_time_max_s"] == r.saturated_time.max()
        assert row["saturated_time_mean_s"] == pytest.approx(r.saturated_time.mean(), rel=1e-12)
        assert row["wall_time_s"] == r.wall_time > 0
        # the series kept for the figure: every sample (101 < 2000)
        np.testing.assert_array_equal(pair.series[row["label"]]["aaem_deg"], r.aaem_deg)
    assert kinds == {True, False}  # settled and not-settled cases both occur (the limited runs do not settle)


def test_each_run_is_one_run_record_and_the_rows_are_made_from_them(pair, short, pd_law):
    """A comparison keeps one fsmctl.studies.records.RunRecord per run (the record every study keeps of a flown
    run): the run's law, limit, engine summary and series, and the metric columns of the tables; a run that fails
    is a record with its reason and NaN metrics, and its row says so."""
    from fsmctl.studies.records import RunRecord

    assert [rec.key for rec in pair.records] == [r.label for r in pair.runs]
    for rec, row in zip(pair.records, pair.table, strict=True):
        result = pair.extras[rec.key]
        assert isinstance(rec, RunRecord) and rec.ok and rec is pair.record(row["label"])
        assert rec.metrics == {c: row[c] for c, _, _ in metric_columns()}  # the table's numbers are the record's
        assert (rec.law, rec.torque_limit) == (row["law"], row["torque_limit_N_m"])
        assert np.array_equal(rec.time, result.time) and np.array_equal(rec.aaem_deg, result.aaem_deg)
        assert rec.steady_window_s == pair.settings["steady_window_s"] == 4.0
        assert rec.settling("aaem", 1.0) == row["aaem_settling_1deg_s"] or math.isnan(row["aaem_settling_1deg_s"])
    wild = LawRun("wild", str(pd_law), {"K": 1e9}, {"torque_limit": "inf"})  # diverges (test_cli_failed_run_exits_1)
    with warnings.catch_warnings(record=True):
        failed = compare_laws(short.replace(simulation={"t_final": 1.0}), [wild])
    (rec,) = failed.records
    (row,) = failed.table
    assert not rec.ok and rec.error.startswith("simulation failed") and rec.law == "pd"
    assert row["status"] == f"failed: {rec.error}" and failed.failures == [("wild", rec.error)]
    assert row["torque_limit_N_m"] == math.inf
    assert all(math.isnan(rec.metrics[c]) for c, _, _ in metric_columns())


def test_with_and_without_the_limit(pair):
    for law in ("FSM", "PD"):
        lim, free = pair.row(f"{law} (limit 2 N m)"), pair.row(f"{law} (no limit)")
        assert lim["torque_limit_N_m"] == 2.0 and math.isinf(free["torque_limit_N_m"])
        assert lim["peak_torque_N_m"] <= 2.0
        assert free["saturated_time_max_s"] == 0.0 and free["saturated_time_mean_s"] == 0.0
        # nothing clipped: the applied peak (output samples) is at most the commanded peak (every step)
        assert free["peak_torque_N_m"] <= free["peak_commanded_torque_N_m"] < 1.01 * free["peak_torque_N_m"]
        if lim["peak_commanded_torque_N_m"] > 2.0:  # the limit was hit: it shows as saturated time
            assert lim["saturated_time_max_s"] > 0 and lim["peak_torque_N_m"] == 2.0
    fsm_lim, fsm_free = pair.row("FSM (limit 2 N m)"), pair.row("FSM (no limit)")
    assert fsm_lim["saturated_time_max_s"] > 0 and fsm_free["peak_torque_N_m"] > 2.0
    assert math.isfinite(fsm_free["aaem_settling_1deg_s"]) and math.isnan(fsm_lim["aaem_settling_1deg_s"])


def test_variants_of_one_law(short):
    """FSM, TSM and LSM are one law with three surfaces; the run's settings reach the flown scenario."""
    runs = [LawRun(s.upper(), "fsm", {"surface": s}, {"torque_limit": "inf"}) for s in ("fsm", "tsm", "lsm")]
    for r in runs:
        c = run_scenario(short, r).controller
        assert c.law == "fsm" and c.parameters["surface"] == r.label.lower() and math.isinf(c.torque_limit)
    tsm = run_scenario(short, runs[1])
    assert tsm.law_parameters()[0]["c1"] == 0.0
    s = run_scenario(short, LawRun("fast", "fsm", {"c1": 1.2, "delta": 0.01, "boundary_layer": 0.0}))
    assert all(p["c1"] == 1.2 and p["boundary_layer"] == 0.0 for p in s.law_parameters())
    assert all(p["delta"] == (0.01, 0.01, 0.01) for p in s.law_parameters())
    comp = compare_laws(short.replace(simulation={"t_final": 2.0}), runs, tolerances_deg=(1.0,))
    assert [r["law"] for r in comp.table] == ["fsm"] * 3
    assert [r["settings"] for r in comp.table] == [f"surface={s}, torque_limit=inf" for s in ("fsm", "tsm", "lsm")]
    assert len({r["control_effort_N_m_s"] for r in comp.table}) == 3  # three different loops


@pytest.mark.parametrize(
    ("laws", "message"),
    [
        (["fsm", "nope"], "run 'nope': law 'nope': not a built-in law"),
        ([LawRun("x", "fsm", {"K": 1.0})], "the law 'fsm' has no parameter 'K'"),
        ([LawRun("x", "fsm", {"c1": -1.0})], "c1"),
        ([LawRun("x", "fsm", controller={"torque_limt": 1.0})], "controller has no setting 'torque_limt'"),
        (["fsm", LawRun("fsm", "fsm", {"surface": "tsm"})], "two runs are labelled 'fsm'"),
        ([], "no law to compare"),
    ],
)
def test_bad_runs_are_input_errors(short, laws, message):
    with pytest.raises(InputError, match=None) as info:
        compare_laws(short, laws)
    assert message in str(info.value)


def test_bad_options(short, pd_law):
    with pytest.raises(InputError, match="the law 'pd' has no parameter 'surface'"):
        run_scenario(short, LawRun("pd", str(pd_law), {"surface": "tsm"}))
    with pytest.raises(InputError, match="tolerances"):
        compare_laws(short, ["fsm"], tolerances_deg=(1.0, -1.0))
    with pytest.raises(InputError, match="workers"):
        compare_laws(short, ["fsm"], workers=0)
    with pytest.raises(InputError, match="finite number > 0"):
        with_and_without_limit(["fsm"], math.inf)


def test_runs_file(tmp_path, pd_law):
    (tmp_path / "pd.py").write_text(pd_law.read_text())
    path = tmp_path / "runs.toml"
    path.write_text(
        '[[run]]\nlaw = "fsm"\n\n[[run]]\nlabel = "TSM, no limit"\nlaw = "fsm"\nparameters = { surface = "tsm" }\n'
        'controller = { torque_limit = "inf" }\n\n[[run]]\nlaw = "pd.py"\nparameters = { K = 2.0 }\n'
    )
    runs = read_runs_file(path)
    assert [r.label for r in runs] == ["fsm", "TSM, no limit", "pd"]
    assert runs[2].law == str(tmp_path / "pd.py") and runs[2].parameters == {"K": 2.0}
    assert runs[1].controller == {"torque_limit": "inf"}
    for text, message in (
        ("[[run]]\nlabel = 'x'\n", "'law' must be"),
        ("[[run]]\nlaw = 'fsm'\ngains = 1\n", "unknown key 'gains'"),
        ("run = 3\n", "expected one or more [[run]] tables"),
        ("[[run]\n", "not valid TOML"),
    ):
        path.write_text(text)
        with pytest.raises(InputError, match=None) as info:
            read_runs_file(path)
        assert message in str(info.value) and str(path) in str(info.value)


def test_saved_files(pair, tmp_path):
    paths = pair.save(tmp_path)
    assert sorted(p.name for p in paths) == sorted(
        ["comparison.csv", "comparison.json", "comparison.md", "comparison.png", "comparison.svg"]
    )
    with (tmp_path / "comparison.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    metric_names = [c for c, _, _ in metric_columns((1.0, 0.1, 0.01))]
    assert list(rows[0])[:6] == ["label", "law", "spec", "settings", "torque_limit_N_m", "status"]
    assert list(rows[0])[6:] == metric_names
    assert all(name.endswith(UNITS) for name in [*metric_names, "torque_limit_N_m"])
    assert {"aaem_settling_0.1deg_s", "peak_torque_N_m", "control_effort_N_m_s", "chattering_N_m_per_s"} <= set(rows[0])
    assert rows[1]["torque_limit_N_m"] == "inf" and rows[0]["aaem_settling_1deg_s"] == "nan"
    for row, csv_row in zip(pair.table, rows, strict=True):
        for name in metric_names:
            assert _same(float(csv_row[name]), row[name], rel=0)  # exact round trip
    data = json.loads((tmp_path / "comparison.json").read_text(), parse_constant=lambda c: pytest.fail(c))
    assert [r["label"] for r in data["table"]] == [r["label"] for r in pair.table]
    assert data["table"][0]["aaem_settling_1deg_s"] is None and data["table"][1]["torque_limit_N_m"] == "inf"
    assert {c["name"]: c["unit"] for c in data["columns"]}["control_effort_N_m_s"] == "N m s"
    md = (tmp_path / "comparison.md").read_text()
    assert "| effort int sum\\|u\\| dt | N m s |" in md and "not settled" in md
    assert (tmp_path / "comparison.png").stat().st_size > 10_000 and (
        tmp_path / "comparison.svg"
    ).stat().st_size > 10_000
    fig = pair.figure()
    assert len(fig.axes) == 6 and fig.axes[0].get_yscale() == "log" and len(fig.axes[0].lines) == 4 + 3


@pytest.fixture
def cli(monkeypatch):
    """``fsmctl compare ...`` through the real command line (its exit codes and one-line errors)."""
    if "fsmctl.cli.compare" not in cli_main.SUBCOMMAND_MODULES:  # the registry is another module's concern
        monkeypatch.setattr(cli_main, "SUBCOMMAND_MODULES", (*cli_main.SUBCOMMAND_MODULES, "fsmctl.cli.compare"))

    def run(*argv: str) -> int:
        try:
            return cli_main.main(["compare", *argv])
        except SystemExit as exc:  # argparse rejects an option value (one line, exit 2)
            return int(exc.code)

    return run


SHORT = ("--t-final", "10", "--output-interval", "0.1")


def test_cli_compares_and_writes(cli, pd_law, tmp_path, capsys):
    out = tmp_path / "cmp"
    code = cli("--laws", f"fsm,{pd_law}", "--with-and-without-limit", *SHORT, "--workers", "2", "--out", str(out))
    stdout, stderr = capsys.readouterr()
    assert code == 0, stderr
    assert "compare: paper case 1" in stdout and "fsm (limit 2 N m)" in stdout and "pd (no limit)" in stdout
    assert "not settled" in stdout and "effort int sum|u| dt" in stdout
    for name in ("comparison.csv", "comparison.json", "comparison.md", "comparison.png", "comparison.svg"):
        assert (out / name).stat().st_size > 0
    data = json.loads((out / "comparison.json").read_text())
    assert [r["label"] for r in data["table"]] == [
        "fsm (limit 2 N m)",
        "fsm (no limit)",
        "pd (limit 2 N m)",
        "pd (no limit)",
    ]
    assert data["settings"]["t_final_s"] == 10.0


def test_cli_torque_limit_and_runs_file(cli, tmp_path, capsys):
    runs = tmp_path / "runs.toml"
    runs.write_text('[[run]]\nlabel = "TSM"\nlaw = "fsm"\nparameters = { surface = "tsm" }\n')
    out = tmp_path / "cmp"
    code = cli("--laws", "fsm", "--runs-file", str(runs), "--torque-limit", "inf", "--t-final", "2", "--no-figures",
               "--tolerances", "1,0.5", "--out", str(out))  # fmt: skip
    capsys.readouterr()
    assert code == 0
    data = json.loads((out / "comparison.json").read_text())
    assert [r["label"] for r in data["table"]] == ["fsm", "TSM"]
    assert all(r["torque_limit_N_m"] == "inf" and r["saturated_time_max_s"] == 0.0 for r in data["table"])
    assert "aaem_settling_0.5deg_s" in data["table"][0] and not (out / "comparison.png").exists()


def test_cli_failed_run_exits_1(cli, pd_law, tmp_path, capsys):
    runs = tmp_path / "runs.toml"
    runs.write_text(
        f'[[run]]\nlabel = "wild PD"\nlaw = "{pd_law}"\nparameters = {{ K = 1e9 }}\n'
        'controller = { torque_limit = "inf" }\n'
    )
    out = tmp_path / "cmp"
    with warnings.catch_warnings(record=True):  # the step-size check may (rightly) warn about this law
        code = cli("--laws", "fsm", "--runs-file", str(runs), "--t-final", "1", "--no-figures", "--out", str(out))
    _, stderr = capsys.readouterr()
    assert code == 1
    assert "run 'wild PD' failed: simulation failed" in stderr and "Traceback" not in stderr
    with (out / "comparison.csv").open() as fh:
        rows = {r["label"]: r for r in csv.DictReader(fh)}
    assert rows["fsm"]["status"] == "ok" and rows["wild PD"]["status"].startswith("failed: ")
    assert rows["wild PD"]["peak_torque_N_m"] == "nan"


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (("--laws", "fsm,nope"), "law 'nope': not a built-in law"),
        (("--laws", "fsm,"), "--laws: expected comma-separated"),
        ((), "nothing to compare"),
        (("--laws", "fsm", "--torque-limit", "inf", "--with-and-without-limit"), "needs a finite torque limit"),
        (("--laws", "fsm", "--runs-file", "/nonexistent/runs.toml"), "cannot read runs file"),
        (("--laws", "fsm", "--torque-limit", "-1"), "must be > 0"),
        (("--laws", "fsm", "--tolerances", "1,x"), "expected a number"),
        (("--laws", "fsm", "--case", "9"), "no case '9'"),
    ],
)
def test_cli_bad_input_exits_2(cli, tmp_path, capsys, argv, message):
    out = tmp_path / "cmp"
    code = cli(*argv, "--t-final", "1", "--out", str(out))
    _, stderr = capsys.readouterr()
    assert code == 2
    assert message in stderr and stderr.count("\n") == 1 and "Traceback" not in stderr
    assert not out.exists()  # nothing written, no empty folder left


def test_the_result_comes_first_in_one_plain_line():
    """``fsmctl compare`` states first which runs converged (the one rule) and from when."""
    import fsmctl
    from fsmctl.studies import LawRun, compare_laws

    s = fsmctl.paper_scenario("1").replace(simulation={"t_final": 5.0, "output_interval": 0.05})
    runs = [LawRun("limited", "fsm"), LawRun("unlimited", "fsm", controller={"torque_limit": float("inf")})]
    comp = compare_laws(s, runs)
    first = comp.to_text().splitlines()[0]
    assert first.startswith("converged (AAEM, RAEM <= 1 deg to the end): ")
    limited, unlimited = comp.table
    assert f"{limited['label']}: not within 5 s" in first
    at = unlimited["converged_at_s"]
    assert 0.5 < at < 5.0 and f"{unlimited['label']} from {at:.2f} s" in first
    run = s.replace(controller={"torque_limit": float("inf")})
    result = fsmctl.simulate(run, progress=False)
    from fsmctl.simulation.metrics import settling_time

    assert at == max(settling_time(result.time, m, 1.0) for m in (result.aaem_deg, result.raem_deg))
