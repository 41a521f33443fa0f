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

import random

import numpy as np
import pytest
from matplotlib.colors import to_hex

from fsmctl import paper_scenario, simulate
from fsmctl import studies as R
from fsmctl.studies import figures as F

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


def test_an_agent_has_one_colour_in_every_figure_of_a_result(case1_run):
    figs = F.simulation_figures(case1_run)
    theta_lines = figs["theta_e"].axes[0].lines
    assert [ln.get_label() for ln in theta_lines] == [f"θ{i}" for i in range(1, 7)]
    torque_axes = figs["torques"].axes
    assert [ax.get_ylabel() for ax in torque_axes] == [f"u{i} (N m)" for i in range(1, 7)]
    for i in range(6):
        assert to_hex(theta_lines[i].get_color()) == TAB10[i]
        components = [ln for ln in torque_axes[i].lines if len(ln.get_xdata()) > 2]  # not the limit lines
        assert len(components) == 3
        assert {to_hex(ln.get_color()) for ln in components} == {TAB10[i]}  # same colour as in the theta figure
        assert len({ln.get_linestyle() for ln in components}) == 3  # the axes differ by style
        limits = [ln for ln in torque_axes[i].lines if len(ln.get_xdata()) == 2]
        assert {to_hex(ln.get_color()) for ln in limits} == {"#000000"}
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
    panel = next(ax for ax in torques.axes if ax.get_ylabel() == "u18 (N m)")
    assert {to_hex(ln.get_color()) for ln in panel.lines if len(ln.get_xdata()) > 2} == {"#c7c7c7"}


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
