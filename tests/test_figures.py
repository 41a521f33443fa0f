"""The figures of a run and of the reproduction (fsmctl/studies/figures.py, the report of fsmctl/studies/reproduce.py).

What is checked, each against an independent reason:

* one colour per agent: in two different figures of one simulated result (theta_ei, Figs 3/7; torques, Fig 4)
  agent i is drawn in matplotlib's ``tab10`` colour i (typed here, not read from fsmctl), its three torque
  components differ by line style only, no two agents share a colour, and the runs of an overlay use none of
  the agents' colours;
* zoomed insets hide no curve: for the analogues of the paper's Figs 1-9 built from simulated runs exactly as
  ``fsmctl reproduce`` builds them, and for curves that fill the place of the old fixed inset (upper right) or
  the whole axes, every drawn sample of the main curves and every point on the segments between them lies
  outside the inset's full bounding box (with its tick labels and title), measured in display coordinates
  after drawing;
* the report lists the figures in the paper's order, Figs 1-9 first, the diagnostic figures after.
"""

from __future__ import annotations

import math
import random
from pathlib import Path

import numpy as np
import pytest
from matplotlib.colors import to_hex

from fsmctl import paper_scenario, simulate
from fsmctl import studies as R
from fsmctl.studies import figures as F
from fsmctl.studies.figure_marks import (
    ABOVE_RANGE_GID,
    LABEL_GID,
    REFERENCE_GID,
    TAIL_GID,
    figure_caption,
    paper_marks,
)
from fsmctl.studies.paper_statements import (
    CASE2_TRACKING_ERROR,
    RELATIVE_ACCURACY,
    SETTLING_TIME,
    TORQUE_BOUND,
    TRACKING_ACCURACY,
    printed_axes,
)

TAB10 = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b")  # matplotlib's tab10, agents 1-6


@pytest.fixture(scope="module")
def case1_run():
    return simulate(paper_scenario("1").replace(simulation={"t_final": 2.0}), progress=False)


def _one_run(spec: R.RunSpec, t_final: float | None):
    scenario = R.run_scenario("paper", spec, fast=True)
    if t_final is not None:
        scenario = scenario.replace(simulation={"t_final": t_final})
    result = simulate(scenario, progress=False)
    return R.run_record(spec, scenario, result), result


@pytest.fixture(scope="module")
def plan_runs():
    """Every run of the reproduction's plan at the fast horizon (10 s), the paper cases also at 100 s."""
    out = {}
    for spec in R.run_plan():
        out[spec.key] = _one_run(spec, None)
    for spec in R.run_plan()[:2]:  # Cases 1 and 2 on the paper's horizon: Figs 1, 2, 5, 6 as printed
        out[spec.key + "@100"] = _one_run(spec, 100.0)
    return out


# ----------------------------------------------------------------------------- one colour per agent


def _agent_lines(ax) -> list:
    """The agents' lines of a torque panel (not the limit lines, not the marks)."""
    return [ln for ln in ax.lines if ln.get_label().startswith("u")]


def test_an_agent_has_one_colour_in_every_figure_of_a_result(case1_run):
    figs = F.simulation_figures(case1_run)
    theta_lines = figs["theta_e"].axes[0].lines
    assert [ln.get_label() for ln in theta_lines] == [f"θ{i}" for i in range(1, 7)]
    torque_axes = figs["torques"].axes
    assert [ax.get_ylabel() for ax in torque_axes] == [f"(u_i)_{k} (N m)" for k in (1, 2, 3)]  # one per body axis
    for ax in torque_axes:
        agents = _agent_lines(ax)
        assert [ln.get_label() for ln in agents] == [f"u{i}" for i in range(1, 7)]
        assert [to_hex(ln.get_color()) for ln in agents] == list(TAB10)  # as in the theta figure
        limits = [ln for ln in ax.lines if len(ln.get_xdata()) == 2]
        assert {to_hex(ln.get_color()) for ln in limits} == {"#000000"}
    assert [to_hex(ln.get_color()) for ln in theta_lines] == list(TAB10)
    assert len(set(TAB10)) == 6


def test_agent_colours_of_a_subset_and_of_a_large_formation():
    t = np.linspace(0.0, 1.0, 20)
    theta = np.ones((20, 40)) + np.arange(40)[None, :] * 0.0
    theta[:, 17] += 5.0  # agent 18 has the largest angle: drawn, in its own colour
    fig = F.principal_angles_figure(t, theta, agents=[3, 6])
    assert [to_hex(ln.get_color()) for ln in fig.axes[0].lines] == [TAB10[2], TAB10[5]]
    big = F.principal_angles_figure(t, theta)
    line18 = next(ln for ln in big.axes[0].lines if ln.get_label() == "θ18")
    assert to_hex(line18.get_color()) == "#c7c7c7"  # agent 18 = index 17: the 8th of tab20's light shades
    u = np.zeros((20, 40, 3))
    u[:, 17] = 1.0
    torques = F.torques_figure(t, u, 2.0)
    for panel in torques.axes:
        line18 = next(ln for ln in _agent_lines(panel) if ln.get_label() == "u18")
        assert to_hex(line18.get_color()) == "#c7c7c7"


def test_runs_of_an_overlay_do_not_take_agent_colours():
    t = np.linspace(0.0, 10.0, 50)
    curves = {f"run {k}": (t, np.exp(-t / (k + 1))) for k in range(6)}
    fig = F.overlay_figure(curves, ylabel="AAEM (deg)", title="runs")
    colours = [to_hex(ln.get_color()) for ln in fig.axes[0].lines]
    assert len(set(colours)) == 6
    assert not set(colours) & set(TAB10)


# ----------------------------------------------------------------------------- insets hide no curve


def _overlaps(fig) -> list[str]:
    """For every inset of ``fig``: the main-curve points (samples and 10 points per segment) inside its box."""
    fig.draw_without_rendering()
    found = []
    for ax in fig.axes:
        for inset in ax.child_axes:
            box = inset.get_tightbbox()
            for line in ax.lines:
                xy = np.asarray(line.get_xydata(), dtype=float)
                xy = xy[np.all(np.isfinite(xy), axis=1)]
                if len(xy) < 2:
                    continue
                s = np.linspace(0.0, 1.0, 11)[:, None, None]
                dense = (xy[:-1][None] * (1 - s) + xy[1:][None] * s).reshape(-1, 2)
                pts = ax.transData.transform(dense)
                view = ax.bbox
                in_view = (
                    (pts[:, 0] >= view.x0) & (pts[:, 0] <= view.x1) & (pts[:, 1] >= view.y0) & (pts[:, 1] <= view.y1)
                )
                hidden = (
                    in_view
                    & (pts[:, 0] >= box.x0)
                    & (pts[:, 0] <= box.x1)
                    & (pts[:, 1] >= box.y0)
                    & (pts[:, 1] <= box.y1)
                )
                if hidden.any():
                    found.append(f"{line.get_label()}: {int(hidden.sum())} points under the inset")
    return found


def _paper_figures(plan_runs, suffix: str = "") -> dict:
    """The analogues of Figs 1-9, built with the builders and arguments fsmctl reproduce uses."""
    rec1, res1 = plan_runs["case1" + suffix]
    _, res2 = plan_runs["case2" + suffix]
    title = f"Case 1 ({res1.scenario.label})"
    figs = {
        "fig01": F.metric_figure(res1.time, res1.aaem_deg, metric="AAEM", title=title, tolerances_deg=(0.03,)),
        "fig02": F.metric_figure(res1.time, res1.raem_deg, metric="RAEM", title=title, tolerances_deg=(0.01,)),
        "fig03": F.principal_angles_figure(res1.time, np.degrees(res1.theta_e)),
        "fig04": F.torques_figure(res1.time, res1.u, 2.0),
        "fig07": F.principal_angles_figure(res2.time, np.degrees(res2.theta_e)),
    }
    if not suffix:
        records = {key: rec for key, (rec, _) in plan_runs.items() if "@" not in key}
        overlays = R.overlay_figures(records)
        figs.update({name[:5]: fig for name, fig in overlays.items() if name.startswith("fig")})
    else:
        rec2 = plan_runs["case2" + suffix][0]
        for name, metric in (("fig05", "aaem_deg"), ("fig06", "raem_deg")):
            curves = {r.title: (r.time, getattr(r, metric)) for r in (rec2, rec1)}
            figs[name] = F.overlay_figure(curves, ylabel=metric, title=name, inset_start=50.0)
    return figs


@pytest.mark.parametrize("horizon", ["fast", "paper"])
def test_insets_of_the_paper_figures_hide_no_curve(plan_runs, horizon):
    figs = _paper_figures(plan_runs, "" if horizon == "fast" else "@100")
    expected = {f"fig0{k}" for k in (1, 2, 3, 4, 5, 6, 7)} | ({"fig08", "fig09"} if horizon == "fast" else set())
    assert set(figs) == expected
    zoomed = 0
    for name, fig in sorted(figs.items()):
        assert _overlaps(fig) == [], name
        insets = [inset for ax in fig.axes for inset in ax.child_axes]
        if name in ("fig03", "fig04", "fig07"):
            assert insets == [], name  # the paper's Figs 3, 4, 7 have no inset
        else:  # a zoom on the second half: an inset or a panel of its own
            zooms = insets or fig.axes[1:]
            assert len(zooms) == 1, name
            assert zooms[0].get_xlim()[1] == pytest.approx(fig.axes[0].get_xlim()[1]), name
            zoomed += 1
    assert zoomed == len(expected) - 3


def test_inset_moves_away_from_a_curve_in_the_upper_right():
    """A metric that stays high to the end (an unsettled run) fills the old fixed inset's place."""
    t = np.linspace(0.0, 100.0, 2001)
    high = 140.0 - 0.2 * t + 5.0 * np.sin(t)
    fig = F.metric_figure(t, high, metric="AAEM")
    (inset,) = fig.axes[0].child_axes
    assert _overlaps(fig) == []
    assert inset.get_position().y1 < fig.axes[0].get_position().y1 - 0.05  # below the curve, not in the corner
    settled = F.metric_figure(t, 140.0 * np.exp(-t / 5.0), metric="AAEM")  # the paper's Fig 1 shape: upper right
    box = settled.axes[0].child_axes[0].get_position()
    main = settled.axes[0].get_position()
    assert box.x1 > main.x0 + 0.8 * main.width and box.y1 > main.y0 + 0.8 * main.height
    assert _overlaps(settled) == []


def test_zoom_becomes_a_panel_when_no_region_is_free():
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 10.0, 4001)
    noise = rng.uniform(0.0, 100.0, t.size)  # the curve's segments cover the whole axes
    fig = F.metric_figure(t, noise, metric="RAEM", tolerances_deg=(0.01,))
    main, zoom = fig.axes
    assert main.child_axes == []
    assert zoom.get_xlim() == pytest.approx((5.0, 10.0))
    assert main.get_position().y0 > zoom.get_position().y1  # below the main axes
    over = F.overlay_figure({"a": (t, noise), "b": (t, noise[::-1])}, ylabel="x", title="y", inset_start=5.0)
    assert len(over.axes) == 2 and over.axes[0].child_axes == []


def test_legend_of_an_overlay_is_outside_the_axes():
    t = np.linspace(0.0, 10.0, 101)
    fig = F.overlay_figure({"Case 1": (t, 100 - t), "Case 2": (t, 100 - 2 * t)}, ylabel="x", title="y", inset_start=5)
    fig.draw_without_rendering()
    (legend,) = fig.legends
    assert fig.axes[0].get_legend() is None
    assert legend.get_window_extent().y1 <= fig.axes[0].get_tightbbox().y0 + 1.0


# ----------------------------------------------------------------------------- the report's order


def test_report_lists_figures_in_the_paper_order(case1_run, tmp_path):
    records = {s.key: R.run_record(s, case1_run.scenario, case1_run) for s in R.run_plan()}  # the report's input
    paper = [
        "fig01_aaem_case1",
        "fig02_raem_case1",
        "fig03_theta_e_case1",
        "fig04_torques_case1",
        "fig05_aaem_case2_vs_case1",
        "fig06_raem_case2_vs_case1",
        "fig07_theta_e_case2",
        "fig08_aaem_case3",
        "fig09_raem_case3",
    ]
    diagnostics = ["diag_aaem_case1_variants", "diag_torques_commanded_case1_no_torque_limit", "diag_aaem_long_horizon"]
    files = [str(tmp_path / "figures" / f"{stem}{ext}") for stem in paper + diagnostics for ext in (".png", ".svg")]
    random.Random(5).shuffle(files)
    bounds = [R.MomentumBound(i + 1, 2.0, 100.0, 100.0, 28.0, 30.0, 30.0, 0.01) for i in range(6)]
    rep = R.Reproduction(tmp_path, True, ["x"], records, bounds, R.evaluate_claims(records, bounds), [], files, 0.0)
    shown = [line for line in R.to_markdown(rep).splitlines() if line.startswith("![")]
    stems = [line[line.index("](") + 2 : -1].removeprefix("figures/").removesuffix(".png") for line in shown]
    assert sorted(stems) == sorted(paper + diagnostics)  # each figure shown once
    cited = [s for s in paper if s[3:5] not in ("03", "07")]  # by the claims (Figs 1-2, 4, 5-6, 8-9), in order
    assert stems[: len(cited)] == cited  # each with the first claim that cites it, in the claims' (the paper's) order
    assert stems[len(cited) : 9] == ["fig03_theta_e_case1", "fig07_theta_e_case2"]  # then the others, in order
    assert sorted(stems[9:]) == sorted(diagnostics)  # then every diagnostic
    assert all(f"](figures/{stem}.png)" in line for stem, line in zip(stems, shown, strict=True))


# ----------------------------------------------------------------------------- the paper's figures as reproduce draws them
# Built by the reproduction's own code paths (execute_run for Figs 1-4, overlay_figures for Figs 5-6, 8-9 and the
# diagnostics) from 1 s runs; every expected number is read from the paper's registry (paper_statements).


@pytest.fixture(scope="module")
def one_second_figures(tmp_path_factory):
    """The figures of ``fsmctl reproduce`` from the plan's runs flown for 1 s (Case 1 a little past the paper's
    settling time, so that its mark lies in the run): stem -> Figure, and the records."""
    import dataclasses

    from fsmctl.studies.paper_runs import execute_run

    out = tmp_path_factory.mktemp("reproduction")
    captured = {}
    monkeypatch = pytest.MonkeyPatch()
    monkeypatch.setattr(F, "save_figure", lambda fig, stem, **kw: captured.setdefault(Path(stem).name, fig) and [])
    records = {}
    try:
        for spec in R.run_plan():
            t_final = SETTLING_TIME.value + 3.0 if spec.key == "case1" else 1.0
            short = dataclasses.replace(spec, simulation=(*spec.simulation, ("t_final", t_final)))
            records[spec.key] = execute_run("paper", short, True, out)
    finally:
        monkeypatch.undo()
    captured.update(R.overlay_figures(records))
    return captured, records


def _zoom(fig):
    insets = [inset for ax in fig.axes for inset in ax.child_axes]
    return insets[0] if insets else fig.axes[1]


@pytest.mark.parametrize(
    ("stem", "figure"),
    [
        ("fig01_aaem_case1", 1),
        ("fig02_raem_case1", 2),
        ("fig05_aaem_case2_vs_case1", 5),
        ("fig06_raem_case2_vs_case1", 6),
        ("fig08_aaem_case3", 8),
        ("fig09_raem_case3", 9),
    ],
)
def test_the_insets_zoom_to_the_printed_inset_range_and_say_when_the_run_is_above(one_second_figures, stem, figure):
    fig = one_second_figures[0][stem]
    zoom = _zoom(fig)
    assert zoom.get_ylim() == pytest.approx(printed_axes(figure).inset_ylim)  # the paper's inset, not autoscaled
    assert zoom.get_xlim() == pytest.approx(fig.axes[0].get_xlim())  # the paper's insets span the whole run
    # the 1 s runs lie far above 0.1°: the zoom says so, with the largest value it does not show
    curves = [np.asarray(ln.get_ydata(), float) for ln in fig.axes[0].lines if ln.get_gid() is None]
    top = max(float(np.nanmax(c)) for c in curves)
    assert top > printed_axes(figure).inset_ylim[1]
    notes = [t.get_text() for t in zoom.texts if "above" in t.get_text()]
    assert len(notes) == 1 and f"max {top:.3g}°" in notes[0]
    # each run's line gives that run's own values (a note never pairs one run's max with another's min)
    runs = [ln for ln in fig.axes[0].lines if ln.get_gid() is None]
    if len(runs) > 1:
        for line in runs:
            values = np.asarray(line.get_ydata(), float)
            (own,) = [
                row for row in notes[0].splitlines() if row.startswith(f"{line.get_label().split(' (under')[0]}:")
            ]
            assert f"max {np.nanmax(values):.3g}°" in own


def test_a_run_inside_the_inset_range_gets_no_note():
    t = np.linspace(0.0, 100.0, 1001)
    marks = paper_marks(1)
    inside = F.metric_figure(t, 0.02 + 0.0 * t, metric="AAEM", marks=marks)
    assert not [t for t in _zoom(inside).texts if "above" in t.get_text()]


def _display_box(ax, y: float, line_px: float):
    """The display box of a horizontal line at data ``y`` across ``ax``."""
    from matplotlib.transforms import Bbox

    _, py = ax.transData.transform((0.0, y))
    return Bbox([[ax.bbox.x0, py - line_px], [ax.bbox.x1, py + line_px]])


def test_fig4_has_a_panel_per_body_axis_and_its_legend_off_the_torque_limit(one_second_figures):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from fsmctl.model.time_response import agent_color

    fig = one_second_figures[0]["fig04_torques_case1"]
    assert len(fig.axes) == 3
    FigureCanvasAgg(fig).draw()
    assert all(ax.get_legend() is None for ax in fig.axes)
    (legend,) = fig.legends
    box = legend.get_window_extent()
    bound = TORQUE_BOUND.value
    for ax in fig.axes:
        assert [ln.get_color() for ln in _agent_lines(ax)] == [agent_color(i) for i in range(6)]
        limits = [ln for ln in ax.lines if ln.get_gid() == "limit"]
        assert sorted(float(ln.get_ydata()[0]) for ln in limits) == [-bound, bound]
        assert all(TORQUE_BOUND.label in ln.get_label() for ln in limits)  # the paper's bound, labelled
        for y in (-bound, bound):
            assert not box.overlaps(_display_box(ax, y, 2.0)), "the legend covers a torque-limit line"
    assert TORQUE_BOUND.label in [t.get_text() for t in legend.get_texts()][-1]


def _hidden(ax, lines) -> list[str]:
    """Legend lines fully covered by a later-drawn line: same samples within (later width - own width) / 2."""
    hidden = []
    for i, line in enumerate(lines):
        pa = ax.transData.transform(np.asarray(line.get_xydata(), float))
        for later in lines[i + 1 :]:
            pb = ax.transData.transform(np.asarray(later.get_xydata(), float))
            slack = (later.get_linewidth() - line.get_linewidth()) / 2 * ax.figure.dpi / 72
            if (
                pa.shape == pb.shape
                and later.get_zorder() >= line.get_zorder()
                and np.nanmax(np.abs(pa - pb)) <= slack + 1e-9
            ):
                hidden.append(line.get_label())
    return hidden


def test_every_run_of_the_no_limit_diagnostic_is_visible(one_second_figures):
    figs, records = one_second_figures
    assert np.array_equal(records["case1_no_torque_limit"].aaem_deg, records["case3c_no_torque_limit"].aaem_deg)
    fig = figs["diag_aaem_no_torque_limit"]
    fig.draw_without_rendering()
    ax = fig.axes[0]
    runs = [ln for ln in ax.lines if ln.get_gid() is None]
    assert len(runs) == 5
    assert _hidden(ax, runs) == []
    # the legend says which runs coincide
    case1 = next(t.get_text() for t in fig.legends[0].get_texts() if t.get_text().startswith("Case 1"))
    assert records["case3c_no_torque_limit"].title in case1.split("under", 1)[1]


def _marks(ax, label: str) -> list:
    return [a for a in ax.get_children() if getattr(a, "get_label", lambda: "")() == label]


def test_the_papers_stated_values_are_marked_with_their_labels(one_second_figures):
    figs = one_second_figures[0]
    for stem, accuracy in (("fig01_aaem_case1", TRACKING_ACCURACY), ("fig02_raem_case1", RELATIVE_ACCURACY)):
        ax = figs[stem].axes[0]
        (settling,) = _marks(ax, SETTLING_TIME.label)  # the 27 s line on the main axes
        assert list(settling.get_xdata()) == [SETTLING_TIME.value] * 2
        assert SETTLING_TIME.label in [t.get_text().strip() for t in ax.texts]
        zoom = _zoom(figs[stem])
        (band,) = _marks(zoom, accuracy.label)  # the accuracy band in the zoom
        assert band.get_path().get_extents(band.get_transform()).y1 == pytest.approx(
            zoom.transData.transform((0.0, accuracy.value))[1]
        )
        assert accuracy.label in [t.get_text().strip() for t in zoom.texts]
    for stem, figure in (("fig01_aaem_case1", 1), ("fig03_theta_e_case1", 3), ("fig05_aaem_case2_vs_case1", 5),
                         ("fig07_theta_e_case2", 7), ("fig09_raem_case3", 9)):  # fmt: skip
        printed = printed_axes(figure)
        (box,) = [p for p in figs[stem].axes[0].patches if printed.text in p.get_label()]
        assert (box.get_x(), box.get_x() + box.get_width()) == printed.xlim
        assert (box.get_y(), box.get_y() + box.get_height()) == printed.ylim
    (level,) = _marks(_zoom(figs["fig05_aaem_case2_vs_case1"]), CASE2_TRACKING_ERROR.label)
    assert list(level.get_ydata()) == [CASE2_TRACKING_ERROR.value] * 2
    diag = figs["diag_aaem_no_torque_limit"].axes[0]  # log axes: the accuracy band is visible on the main axes
    assert len(_marks(diag, TRACKING_ACCURACY.label)) == 1
    commanded = figs["diag_torques_commanded_case1_no_torque_limit"].axes[0]
    assert sorted(float(ln.get_ydata()[0]) for ln in _marks(commanded, TORQUE_BOUND.label)) == [-2.0, 2.0]


def test_figures_of_surfaces_and_laws_use_no_agent_colour():
    """Surfaces and laws are runs: an agent's colour (tab10) would say "agent i" to a reader of the other figures."""
    from fsmctl.studies import Variant, compare_laws, compare_surfaces
    from fsmctl.studies.surface_figures import plot_agent_times, plot_error_metrics

    scenario = paper_scenario("1").replace(simulation={"t_final": 1.0, "output_interval": 0.1})
    surfaces = compare_surfaces(scenario, t_final=1.0, variants=[Variant(True, True, True)], scalar_check=False,
                                workers=1, progress=False)  # fmt: skip
    lines = [ln for ln in plot_error_metrics(surfaces).axes[0].lines if len(ln.get_xdata()) > 2]
    bars = [p for ax in plot_agent_times(surfaces).axes for p in ax.patches]
    laws = compare_laws(scenario, ["fsm", "pid"]).figure()
    law_lines = [ln for ln in laws.axes[0].lines if len(ln.get_xdata()) > 2]
    assert len(lines) == 3 and len(law_lines) == 2 and bars
    colours = {to_hex(ln.get_color()) for ln in lines + law_lines} | {to_hex(p.get_facecolor()) for p in bars}
    assert len({to_hex(ln.get_color()) for ln in lines}) == 3
    assert not colours & set(TAB10)


# ----------------------------------------------------------------------------- the README's python-control example


def _readme_python_example() -> list[str]:
    text = (Path(__file__).resolve().parent.parent / "README.md").read_text(encoding="utf-8")
    section = text.split("## Python (python-control)", 1)[1]
    return section.split("```python\n", 1)[1].split("```", 1)[0].splitlines()


def test_the_readme_example_saves_every_figure_it_plots(tmp_path, monkeypatch):
    """Run as a script, the example leaves its figures as files: each ``.plot()`` is saved, and its first part (the
    paper's Case 1, up to the first plot) runs here and writes the PNG it names."""
    import matplotlib.pyplot as plt

    lines = _readme_python_example()
    plots = [line for line in lines if ".plot(" in line]
    assert plots and all(".figure.savefig(" in line for line in plots), plots
    first = next(i for i, line in enumerate(lines) if ".plot(" in line)
    monkeypatch.chdir(tmp_path)
    plt.close("all")
    try:
        exec(compile("\n".join(lines[: first + 1]), "README.md", "exec"), {})  # the README's own code
    finally:
        plt.close("all")
    (name,) = [part.split('"')[1] for part in plots[0].split("savefig(")[1:]]
    assert (tmp_path / name).read_bytes()[:4] == b"\x89PNG"


# ----------------------------------------------------------------------------- what a reader of the figures sees


def test_the_inset_note_of_an_overlay_gives_each_runs_own_values():
    """Fig 5's note said "max 166°, min 57.9°": Case 1's maximum with Case 2's minimum."""
    t = np.linspace(0.0, 100.0, 1001)
    case2 = 154.0 - 96.1 * t / 100.0  # 154° down to 57.9°
    case1 = 124.5 + 41.5 * np.sin(t / 7.0)  # 83° to 166°
    fig = F.overlay_figure({"Case 2": (t, case2), "Case 1": (t, case1)}, ylabel="AAEM", title="Fig 5",
                           marks=paper_marks(5))  # fmt: skip
    (note,) = [text.get_text() for text in _zoom(fig).texts if text.get_gid() == ABOVE_RANGE_GID]
    rows = {row.split(":")[0]: row for row in note.splitlines()[1:]}
    assert set(rows) == {"Case 1", "Case 2"}
    for label, values in (("Case 1", case1), ("Case 2", case2)):
        assert f"max {values.max():.3g}°" in rows[label] and f"min {values.min():.3g}°" in rows[label]


def test_the_fig1_inset_note_covers_no_label_and_uses_the_papers_relation():
    from fsmctl.studies.claims import get_claim
    from fsmctl.studies.figure_marks import text_box

    t = np.linspace(0.0, 100.0, 1001)
    fig = F.metric_figure(t, 120.0 + 20.0 * np.sin(t / 5.0), title="AAEM, Case 1", marks=paper_marks(1))
    (zoom,) = fig.axes[0].child_axes  # an inset, as in the reproduction's Fig 1
    fig.canvas.draw()
    (note,) = [text for text in zoom.texts if text.get_gid() == ABOVE_RANGE_GID]
    labels = [text for text in zoom.texts if text.get_gid() == LABEL_GID]
    assert TRACKING_ACCURACY.label in [text.get_text() for text in labels]
    clearance = 1.0 * fig.dpi / 72.0  # at least 1 pt between the note's box and every label's
    for label in labels:
        assert not text_box(note).padded(clearance).overlaps(text_box(label)), label.get_text()
    # the band's label lies inside the band, clear of its edge (the grid line at 0.03°)
    (band,) = [text for text in labels if text.get_text() == TRACKING_ACCURACY.label]
    edge = zoom.transData.transform((0.0, TRACKING_ACCURACY.value))[1]
    assert text_box(band).y1 < edge
    # the paper's relation, as the claims state it: "< 0.03°"
    assert f"{TRACKING_ACCURACY.relation} {TRACKING_ACCURACY.text}" == get_claim("tracking_accuracy").paper_value


def test_the_accuracy_band_of_a_diagnostic_says_whose_accuracy_it_is():
    """The long-horizon figure shaded "AAEM ≤ 0.03°" over Case 2: the band is the paper's Case 1 accuracy."""
    from fsmctl.studies.figure_marks import metric_marks

    t = np.linspace(0.0, 300.0, 301)
    fig = F.overlay_figure({"Case 1": (t, 100.0 + 0 * t), "Case 2": (t, 100.0 * np.exp(-t / 30.0))}, ylabel="AAEM",
                           title="long horizon", log=True, marks=metric_marks("aaem"))  # fmt: skip
    ax = fig.axes[0]
    (band,) = [a for a in ax.patches if a.get_gid() == REFERENCE_GID]
    assert band.get_label().startswith("paper: Case 1 AAEM")
    assert band.get_label() in [text.get_text() for text in ax.texts]


def test_commanded_torques_without_a_limit_show_their_transient():
    """A 2.4e4 N m peak that decays within 3 s was a line at the start of a 100 s axis."""
    from fsmctl.studies.figure_marks import torque_marks

    t = np.linspace(0.0, 100.0, 10001)
    u = np.zeros((t.size, 2, 3))
    u[:, 0, 0] = 2.4e4 * np.exp(-t / 0.2)  # falls below 2 N m at 0.2 ln(1.2e4) = 1.88 s
    u[:, 1, 2] = -1.0 + 0.0 * t
    fig = F.torques_figure(t, u, math.inf, marks=torque_marks())
    settled = float(t[np.flatnonzero(np.abs(u).max(axis=(1, 2)) >= 2.0)[-1] + 1])
    lo, hi = fig.axes[0].get_xlim()
    assert lo == 0.0 and 2.0 * settled < hi < 10.0
    # the peak is drawn inside the y range, and the 2 N m level too (a symmetric-log axis holds both)
    assert fig.axes[0].get_ylim()[1] >= 2.4e4 and fig.axes[0].get_yscale() == "symlog"
    fig.canvas.draw()
    peak_px = fig.axes[0].transData.transform((0.0, 2.4e4))[1] - fig.axes[0].transData.transform((0.0, 2.0))[1]
    assert peak_px > 0.5 * fig.axes[0].bbox.height / 2  # the peak is not squashed onto the level
    (note,) = [text.get_text() for text in fig.axes[0].texts if text.get_gid() == TAIL_GID]
    assert f"t > {settled:.3g} s" in note and "< 2 N m" in note
    # with a finite limit the whole run is shown
    assert F.torques_figure(t, np.clip(u, -2, 2), 2.0, marks=torque_marks()).axes[0].get_xlim() == (0.0, 100.0)


def test_the_report_captions_say_what_each_figure_shows(case1_run, tmp_path):
    from fsmctl.studies.figure_marks import metric_marks

    records = {s.key: R.run_record(s, case1_run.scenario, case1_run) for s in R.run_plan()}
    t = case1_run.time
    fig1 = F.metric_figure(t, case1_run.aaem_deg, title="AAEM, Case 1", marks=paper_marks(1))
    long = F.overlay_figure({"Case 1": (t, case1_run.aaem_deg)}, ylabel="AAEM", title="long horizon", log=True,
                            marks=metric_marks("aaem"))  # fmt: skip
    files = [str(p) for p in F.save_figure(fig1, tmp_path / "figures" / "fig01_aaem_case1")]
    files += [str(p) for p in F.save_figure(long, tmp_path / "figures" / "diag_aaem_long_horizon")]
    bounds = [R.MomentumBound(i + 1, 2.0, 100.0, 100.0, 28.0, 30.0, 30.0, 0.01) for i in range(6)]
    rep = R.Reproduction(tmp_path, True, ["x"], records, bounds, R.evaluate_claims(records, bounds), [], files, 0.0)
    shown = {line[line.index("](") + 2 : -1]: line[2 : line.index("](")]
             for line in R.to_markdown(rep).splitlines() if line.startswith("![")}  # fmt: skip
    assert shown["figures/fig01_aaem_case1.png"] == f"Fig 1: {figure_caption(fig1)}"
    assert shown["figures/diag_aaem_long_horizon.png"] == f"diag_aaem_long_horizon: {figure_caption(long)}"
    caption = figure_caption(fig1)
    assert caption.startswith("AAEM, Case 1") and TRACKING_ACCURACY.label.removeprefix("paper: ") in caption
