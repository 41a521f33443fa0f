"""What ``fsmctl tune`` tells its reader (issue 27): the files it counts, what it searches and why, how a run that
never settles is scored, and the figure (no one-point "front", integer trial ticks).  The search itself is in
``tests/test_tune.py``; here one short study (1 s horizons, where nothing settles) and figures of hand-made
results."""

from __future__ import annotations

import contextlib
import io
import math

import pytest
from matplotlib.ticker import MaxNLocator

from fsmctl.cli.main import main
from fsmctl.studies import TuneSettings, search_space
from fsmctl.studies.tune import SearchParameter, TuneResult, search_space_lines, unsettled_score

pd = pytest.importorskip("pandas")

HORIZON = 1.0
"""1 s: no design of the paper's Case 1 settles to the tolerance, so every settling objective is a penalty score"""


@pytest.fixture(scope="module")
def short_study(tmp_path_factory):
    """``fsmctl tune`` on 1 s of Case 1: two objectives, c1 only, Theorem 1 as the only constraint (feasible)."""
    out = tmp_path_factory.mktemp("tune") / "study"
    argv = ["tune", "--law", "fsm", "--case", "1", "--t-final", str(HORIZON), "--budget", "3", "--batch", "3"]
    argv += ["--objectives", "aaem_settling,peak_torque", "--parameters", "c1", "--range", "c1=0.1,2"]
    argv += ["--constraints", "theorem1", "--workers", "1", "--no-progress", "--out", str(out)]
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        code = main(argv)
    return code, out, stdout.getvalue(), stderr.getvalue()


def test_the_count_of_files_written_is_the_files_in_the_folder(short_study):
    code, out, _, err = short_study
    files = sorted(p.name for p in out.iterdir())
    assert code == 0 and "study.log" in files and "best.toml" in files, files
    assert f"wrote {len(files)} files to {out}" in err, err


def test_what_is_searched_is_stated_first(short_study):
    _, _, stdout, err = short_study
    lines = err.splitlines()
    assert lines[0] == "fsmctl: tune: searching 1 parameter: c1 (named by --parameters)", lines[:2]
    assert lines[1] == "fsmctl: tune: c1: 0.1 .. 2 1/s, uniform (range given)", lines[:2]
    assert stdout.splitlines()[1] == "searched 1 parameter: c1 (named by --parameters)"  # the summary's past tense


def test_the_default_search_space_says_which_parameters_were_not_asked_for():
    """The README's paper-law command names five ranges and no --parameters: alpha and the coupling factors are
    searched too, and the statement says so, with where each range comes from."""
    ranges = {
        "c1": (0.01, 2),
        "c2": (0.01, 2),
        "delta": (5e-4, 0.05),
        "boundary_layer": (5e-4, 1),
        "epsilon": (1e-5, 1e-3),
    }
    settings = TuneSettings(law="fsm", ranges=ranges)
    space = search_space(settings)
    head, *rows = search_space_lines(settings, space)
    assert head.startswith(f"searching {len(space)} parameters: c1, c2, alpha, boundary_layer, epsilon, delta ")
    assert "every tunable parameter fsm declares" in head and "--parameters not given" in head
    assert "k_i_scale, k_j_scale (factors on the coupling weights" in head
    # the finished study's summary says what was searched, without the advice given before the study ran
    done = search_space_lines(settings, space, done=True)[0]
    assert done == head.replace("searching", "searched", 1).split("; --parameters not given")[0], done
    assert [row.split(":")[0].strip() for row in rows] == [p.name for p in space]
    by_name = {row.split(":")[0].strip(): row for row in rows}
    assert by_name["alpha"].endswith("(the law's declared range)") and "uniform" in by_name["alpha"]
    assert by_name["k_i_scale"].endswith("(default range of the coupling factors)")
    assert by_name["c1"].endswith("(range given)") and "0.01 .. 2 1/s" in by_name["c1"]
    assert "one value for all 3 components" in by_name["delta"]


def test_a_run_that_never_settles_has_no_settling_time_and_its_score_is_explained(short_study):
    _, out, stdout, _ = short_study
    table = pd.read_csv(out / "trials.csv", comment="#")
    assert len(table) == 3 and table["trial"].tolist() == [0, 1, 2]
    assert table["aaem_settling [s]"].isna().all()  # 1 s is too short: no settling time, never a fake one
    scores = table["aaem_settling_score [s]"]
    assert ((scores >= 2 * HORIZON) & (scores <= 3 * HORIZON)).all(), scores.tolist()
    assert (table["peak_torque [N m]"] > 0).all()
    comments = [line for line in (out / "trials.csv").read_text().splitlines() if line.startswith("#")]
    assert f"{len(comments)} comment lines" in comments[0]
    assert any(line.startswith("# aaem_settling_score [s]: the value minimised") for line in comments)
    assert any("2 to 3 s" in line for line in comments)
    # every column is explained, the searched parameters with their ranges
    assert list(table.columns[-2:]) == ["pruned_at [s]", "error"]
    for column in table.columns:
        assert any(line.startswith(f"# {column}:") for line in comments), column
    assert "# c1 [1/s]: searched, 0.1 .. 2 1/s, uniform (range given)" in comments
    assert pd.read_csv(out / "pareto.csv", comment="#").columns.tolist() == table.columns.tolist()
    assert "aaem_settling: 3 of 3 complete trials not settled within the horizon T = 1 s" in stdout
    best = next(line for line in stdout.splitlines() if line.startswith("best: "))
    assert "aaem_settling=not settled within 1 s (scored " in best and " x horizon)" in best, best


# ----------------------------------------------------------------------------- the figure, on hand-made results


def _result(objectives: tuple[str, ...], values: list[tuple[float, ...]], pareto: list[int]) -> TuneResult:
    settings = TuneSettings(law="pid", objectives=objectives, parameters=("K",), ranges={"K": (1.0, 2.0)})
    space = [SearchParameter("K", "N m", 1.0, 2.0, False, 1)]
    trials = [
        {
            "index": i,
            "state": "complete",
            "feasible": True,
            "params": {"K": 1.5},
            "objectives": dict(zip(objectives, v, strict=True)),
            "constraints": {},
            "pruned_at": None,
            "error": "",
        }
        for i, v in enumerate(values)
    ]
    best = min(pareto, key=lambda i: values[i][0])
    return TuneResult(settings, space, (), trials, pareto, best, None, 10.0)


def _front_lines(ax) -> list:
    return [line for line in ax.get_lines() if "Pareto" in line.get_label()]


def test_one_objective_has_integer_trial_ticks_and_no_front():
    result = _result(("peak_torque",), [(3.0,), (2.0,), (2.5,)], [1])
    ax = result.figure().axes[0]
    assert ax.get_xlabel() == "trial" and isinstance(ax.xaxis.get_major_locator(), MaxNLocator)
    ticks = [t for t in ax.get_xticks() if ax.get_xlim()[0] <= t <= ax.get_xlim()[1]]
    assert len(ticks) >= 2 and all(float(t).is_integer() for t in ticks), ticks
    assert _front_lines(ax) == []
    assert "non-dominated" not in result.to_text() and "Pareto" not in result.to_text()


def test_an_objective_equal_in_every_trial_is_said_to_have_told_nothing_apart():
    """peak_torque at the same value in every complete trial (the torque limit, on a short horizon): the summary says
    this objective did not tell the designs apart; aaem_settling, which varies, gets no such line; one trial, none."""
    result = _result(("aaem_settling", "peak_torque"), [(3.0, 2.0), (4.0, 2.0), (5.0, 2.0)], [0])
    flat = [line for line in result.to_text().splitlines() if "did not tell the designs apart" in line]
    assert flat == [
        "peak_torque: 2 N m in every one of the 3 complete trials: it did not tell the designs apart (other "
        "objectives, other ranges or a longer horizon would)"
    ]
    assert "did not tell" not in _result(("peak_torque",), [(2.0,)], [0]).to_text()


def test_a_best_design_tied_with_every_feasible_trial_is_said_to_be_no_better():
    """Every feasible trial with the same value of every objective (a fresh user: peak torque at the limit in every
    design): the best line says the choice is the first of equals; one differing value, or one trial, no such words."""
    tied = _result(("peak_torque",), [(2.0,), (2.0,), (2.0,)], [0, 1, 2]).to_text().splitlines()
    best = next(x for x in tied if x.startswith("best: trial 0"))
    assert best.endswith(
        "peak_torque=2 N m (tied: all 3 feasible trials scored the same on every objective, so this one, the first "
        "feasible, is no better than the others)"
    ), best
    assert _result(("peak_torque",), [(2.0,), (2.0,), (2.0,)], [0, 1, 2]).tie().startswith("tied: all 3 feasible")
    assert "tied" not in _result(("peak_torque", "rms_torque"), [(2.0, 1.0), (2.0, 1.5)], [0]).to_text()
    assert "tied" not in _result(("peak_torque",), [(2.0,)], [0]).to_text()


def test_a_study_without_a_feasible_design_says_which_constraints_ruled_the_trials_out():
    """No feasible design: the summary counts, per constraint, the complete trials it ruled out (most often first),
    which trials.csv alone showed (a fresh user: every trial over the torque limit, and the advice to widen ranges)."""
    base = _result(("peak_torque",), [(3.0,), (2.0,), (2.5,)], [1])
    values = [{"torque": 5.0, "converged": -1.0}, {"torque": 2.0, "converged": 4.0}, {"torque": 1.0, "converged": -2.0}]
    trials = [{**t, "feasible": False, "constraints": v} for t, v in zip(base.trials, values, strict=True)]
    result = TuneResult(base.settings, base.space, ("converged", "torque"), trials, [], None, None, 10.0)
    line = next(x for x in result.to_text().splitlines() if x.startswith("no feasible design"))
    assert line.startswith("no feasible design found: of 3 complete trials, torque failed in 3, converged failed in 1 ")


def test_a_front_of_one_trial_is_a_point_not_a_line():
    result = _result(("peak_torque", "rms_torque"), [(1.0, 1.0), (2.0, 2.0), (3.0, 1.5)], [0])
    ax = result.figure().axes[0]
    assert _front_lines(ax) == []
    labels = ax.get_legend_handles_labels()[1]
    assert "the one non-dominated feasible trial" in labels, labels
    assert "one non-dominated trial" in result.to_text().splitlines()[0]
    two = _result(("peak_torque", "rms_torque"), [(1.0, 2.0), (2.0, 1.0), (3.0, 3.0)], [0, 1])
    (front,) = _front_lines(two.figure().axes[0])
    assert len(front.get_xdata()) == 2 and "2 non-dominated trials (the Pareto front)" in two.to_text()


def test_the_horizon_is_marked_where_a_settling_objective_is_a_penalty():
    unsettled = unsettled_score(10.0, 1.0, 0.1)  # a decade above the tolerance: 3 T
    result = _result(("aaem_settling",), [(4.0,), (unsettled,), (6.0,)], [0])
    ax = result.figure().axes[0]
    marks = [line for line in ax.get_lines() if line.get_label().startswith("horizon 10 s")]
    assert len(marks) == 1 and list(marks[0].get_ydata()) == [10.0, 10.0]
    assert "not settled" in ax.get_ylabel()
    assert result.settled("aaem_settling", 4.0) and not result.settled("aaem_settling", unsettled)
    assert result.settled("peak_torque", 4.0) is None
    assert math.isclose(unsettled, 30.0) and "scored 30 s = 3 x horizon" in result.objective_text("aaem_settling", 30.0)


# ----------------------------------------------------------------------------- what the lines and best.toml say


def test_every_missing_range_is_named_in_one_message():
    """A first run refused c1, then (after --range c1=...) c2, then boundary_layer: one message names them all."""
    from fsmctl.errors import InputError

    with pytest.raises(InputError) as info:
        search_space(TuneSettings(law="fsm", parameters=("c1", "alpha", "c2", "boundary_layer")))
    message = str(info.value)
    assert "\n" not in message
    for name in ("c1", "c2", "boundary_layer"):
        assert f"{name} (no upper bound" in message and f"--range {name}=LOW,HIGH" in message
    assert "alpha" not in message  # declared on both sides: searched, not missing


def _one_trial(settings: TuneSettings, space: list[SearchParameter], params: dict) -> TuneResult:
    trial = {"index": 0, "state": "complete", "feasible": True, "params": params,
             "objectives": {name: 1.0 for name in settings.objectives}, "constraints": {}, "pruned_at": None,
             "error": ""}  # fmt: skip
    return TuneResult(settings, space, (), [trial], [0], 0, None, 10.0)


def test_a_dimensionless_parameter_is_printed_without_a_unit():
    """``alpha: 0.5 .. 1 1`` and ``alpha=0.534771 1`` read like typos: unit "1" is not printed."""
    from fsmctl import paper_scenario
    from fsmctl.studies.tune import best_scenario_text

    settings = TuneSettings(law="fsm", parameters=("c1", "alpha"), ranges={"c1": (0.1, 2.0)})
    space = search_space(settings)
    assert [p.unit for p in space] == ["1/s", "1"]
    rows = search_space_lines(settings, space)[1:]
    assert rows == [
        "  c1: 0.1 .. 2 1/s, uniform (range given)",
        "  alpha: 0.5 .. 1, uniform (the law's declared range)",
    ]
    result = _one_trial(settings, space, {"c1": 0.25, "alpha": 0.534771})
    (best,) = [line for line in result.to_text().splitlines() if line.startswith("best: ")]
    assert "c1=0.25 1/s, alpha=0.534771;" in best, best
    summary = best_scenario_text(result, paper_scenario("1")).splitlines()[1]
    assert summary == "# c1 = 0.25 1/s, alpha = 0.534771", summary


def test_best_toml_names_its_scenario_and_law_relative_to_its_folder(tmp_path):
    import shutil

    from fsmctl import load_scenario
    from fsmctl.model.toml_writer import toml_value
    from fsmctl.studies.tune import best_scenario_text

    project = tmp_path / "project"
    scenario = project / "scenarios" / "base.toml"
    scenario.parent.mkdir(parents=True)
    scenario.write_text('extends = "paper"\nname = "base"\n')
    out = project / "runs" / "tuned"
    out.mkdir(parents=True)
    settings = TuneSettings(scenario=str(scenario), law="fsm", parameters=("c1",), ranges={"c1": (0.1, 2.0)})
    result = _one_trial(settings, search_space(settings), {"c1": 0.25})
    text = best_scenario_text(result, load_scenario(scenario), folder=out)
    assert 'extends = "../../scenarios/base.toml"' in text.splitlines()
    (out / "best.toml").write_text(text)
    assert (out / "../../scenarios/base.toml").resolve() == scenario.resolve()  # the same file
    assert load_scenario(out / "best.toml").controller.parameters["c1"] == 0.25
    moved = tmp_path / "moved"
    shutil.move(project, moved)  # the study's folder moves with the scenario: best.toml still flies the design
    assert load_scenario(moved / "runs" / "tuned" / "best.toml").controller.parameters["c1"] == 0.25
    # a law script is named relative to the folder too; with no common folder but the root, paths stay absolute
    script = project / "laws" / "my_law.py"
    law = TuneSettings(scenario=str(scenario), law=str(script), parameters=("K",), ranges={"K": (1.0, 2.0)})
    space = [SearchParameter("K", "N m", 1.0, 2.0, False, 1)]
    lines = best_scenario_text(_one_trial(law, space, {"K": 1.5}), load_scenario(moved / "scenarios" / "base.toml"),
                               folder=out).splitlines()  # fmt: skip
    assert 'law = "../../laws/my_law.py"' in lines
    rooted = best_scenario_text(result, load_scenario(moved / "scenarios" / "base.toml"), folder="/").splitlines()
    assert f"extends = {toml_value(str(scenario.resolve()))}" in rooted
