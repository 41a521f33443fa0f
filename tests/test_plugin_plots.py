"""``FormationResponse.plot`` takes python-control's ``time_response_plot`` keywords, and a formation's raw
response plots.

Oracles: the response's own arrays (every line's data is a row of ``outputs``/``inputs``), python-control's
layout rules (``control.timeplot``: traces in columns, ``transpose`` puts inputs first and traces in rows, the
current figure is reused when its axes count fits), and :func:`fsmctl.agent_color`.
"""

from __future__ import annotations

import control as ct
import matplotlib
import numpy as np
import pytest
from formations import with_agents

import fsmctl
from fsmctl.errors import InputError
from fsmctl.model.topology import ring

matplotlib.use("Agg")
import matplotlib.pyplot as plt

T = np.linspace(0.0, 1.0, 6)
LABELS = [f"sc{i}_{g}[{k}]" for i in (1, 2) for g in ("sigma", "omega") for k in range(3)]
INPUTS = [f"sc{i}_d[{k}]" for i in (1, 2) for k in range(3)]


@pytest.fixture(autouse=True)
def _close():
    plt.close("all")
    yield
    plt.close("all")


@pytest.fixture(scope="module")
def raw():
    """``ct.input_output_response`` of a two-agent formation, as python-control returns it."""
    paper = fsmctl.paper_scenario("1")
    s = with_agents(paper, paper.agents[:2], ring(2, 8.0, 5.0), controller={"boundary_layer": 0.05})
    return ct.input_output_response(fsmctl.formation(s), [0.0, 0.05, 0.1], 0, fsmctl.initial_state(s))


def response(traces: int = 0, inputs: bool = False, **kwargs) -> fsmctl.FormationResponse:
    rng = np.random.default_rng(7)
    shape = (len(LABELS), traces, T.size) if traces else (len(LABELS), T.size)
    u = rng.normal(size=(len(INPUTS), traces, T.size) if traces else (len(INPUTS), T.size)) if inputs else None
    return fsmctl.FormationResponse(
        T,
        rng.normal(size=shape),
        None,
        u,
        output_labels=LABELS,
        input_labels=INPUTS if inputs else None,
        issiso=False,
        multi_trace=bool(traces),
        title="synthetic",
        **kwargs,
    )


def titles(axes) -> list[str]:
    return [ax.get_title() for ax in np.ravel(axes)]


def legend_texts(legend) -> list[str]:
    return [t.get_text() for t in legend.get_texts()]


# ----------------------------------------------------------------------------- the raw response of a formation


@pytest.mark.filterwarnings("ignore:Tight layout not applied")  # python-control's 18 axes in one figure
def test_a_raw_formation_response_plots_through_formation_response(raw):
    """python-control marks the formation's empty (0, T) input array for plotting, so ``raw.plot()`` raises in
    python-control; the fsmctl response of it plots, grouped or as python-control's own figure."""
    r = fsmctl.formation_response(raw)
    assert raw.ninputs == 0 and r.plot_inputs is False
    cplt = r.plot()
    assert cplt.axes.shape == (3, 1) and [len(lines) for lines in cplt.lines[:, 0]] == [6, 6, 6]
    full = ct.time_response_plot(r)  # python-control's layout: one axes per output
    assert full.axes.shape == (raw.noutputs, 1)
    k = raw.output_labels.index("sc2_tau[1]")
    assert np.array_equal(full.lines[k, 0][0].get_ydata(), raw.outputs[k])
    with pytest.raises(InputError, match=r"plot_inputs=True, but the response has no inputs"):
        r.plot(plot_inputs=True)


# ----------------------------------------------------------------------------- python-control's keywords


def test_ax_draws_on_the_given_axes_without_a_figure_title():
    fig, axes = plt.subplots(2, 1)
    cplt = response().plot(ax=axes)
    assert cplt.figure is fig and cplt.axes[0, 0] is axes[0] and cplt.axes[1, 0] is axes[1]
    assert len(axes[0].get_lines()) == 6 and fig.get_suptitle() == ""
    cplt = response().plot(ax=axes, title="given")
    assert fig.get_suptitle() == "given" and len(axes[0].get_lines()) == 12
    fig, one = plt.subplots()
    assert response().plot(ax=one, overlay_signals=True).axes[0, 0] is one
    with pytest.raises(InputError, match=r"ax must hold 2 matplotlib Axes \(the plot's shape \(2, 1\)\), got 1"):
        response().plot(ax=one)


def test_the_current_figure_is_reused_when_its_axes_fit_as_in_python_control():
    first = response().plot(label="run A")
    second = response().plot(label="run B", color="0.5", linestyle="--")
    assert second.figure is first.figure and len(first.axes[0, 0].get_lines()) == 12
    assert all(line.get_color() == "0.5" and line.get_linestyle() == "--" for line in second.lines[0, 0])
    assert second.lines[0, 0][0].get_label() == "sc1_sigma[0], run B"
    # the figure's one legend names the agents, the components and both runs
    assert legend_texts(second.legend) == ["sc1", "sc2", "[0]", "[1]", "[2]", "run A", "run B"]
    assert len(first.figure.legends) == 1
    assert second.legend.legend_handles[-1].get_linestyle() == "--"
    plt.figure()
    assert response().plot().figure is not first.figure


def test_plot_inputs_and_plot_outputs():
    r = response(inputs=True)
    cplt = r.plot()  # python-control's default: the response's plot_inputs (True with inputs)
    assert cplt.axes.shape == (3, 1)
    assert titles(cplt.axes)[2] == "d"
    assert [line.get_label() for line in cplt.lines[2, 0]] == INPUTS
    assert np.array_equal(cplt.lines[2, 0][4].get_ydata(), r.inputs[4])
    assert cplt.lines[2, 0][4].get_color() == fsmctl.agent_color(1)
    plt.close("all")
    assert r.plot(plot_inputs=False).axes.shape == (2, 1)
    plt.close("all")
    only = r.plot(plot_outputs=False)
    assert only.axes.shape == (1, 1) and len(only.lines[0, 0]) == 6
    plt.close("all")
    assert response(inputs=True, plot_inputs=False).plot().axes.shape == (2, 1)
    with pytest.raises(InputError, match="plot_inputs='overlay' does not apply to a grouped plot"):
        r.plot(plot_inputs="overlay")
    with pytest.raises(InputError, match="plot_inputs and plot_outputs are both False"):
        r.plot(plot_inputs=False, plot_outputs=False)


def test_overlay_signals_puts_every_group_on_one_axes():
    r = response(inputs=True)
    cplt = r.plot(overlay_signals=True)
    assert cplt.axes.shape == (2, 1) and titles(cplt.axes) == ["Outputs", "Inputs"]
    grouped = [label for g in ("sigma", "omega") for label in LABELS if f"_{g}[" in label]  # groups in order
    assert [line.get_label() for line in cplt.lines[0, 0]] == grouped
    assert [line.get_color() for line in cplt.lines[0, 0]][::3] == [fsmctl.agent_color(i) for i in (0, 1, 0, 1)]


def test_transpose_puts_inputs_first_and_traces_in_rows():
    r = response(traces=2, inputs=True, trace_labels=["low", "high"])
    cplt = r.plot(transpose=True)
    assert cplt.axes.shape == (2, 3)
    assert titles(cplt.axes[0]) == ["d", "σ: attitude (MRP)", "ω: body rate (rad/s)"]
    assert [ax.get_ylabel() for ax in cplt.axes[:, 0]] == ["low", "high"]
    assert np.array_equal(cplt.lines[1, 2][0].get_ydata(), r.y[LABELS.index("sc1_omega[0]"), 1])


def test_several_traces_have_a_column_each():
    r = response(traces=3)
    cplt = r.plot(trace_labels=["a", "b", "c"])
    assert cplt.axes.shape == (2, 3) and cplt.lines.shape == (2, 3)
    assert titles(cplt.axes[0]) == [f"{name}\nσ: attitude (MRP)" for name in "abc"]
    for j in range(3):
        assert len(cplt.lines[1, j]) == 6
        for line in cplt.lines[1, j]:
            assert np.array_equal(line.get_ydata(), r.y[LABELS.index(line.get_label()), j])
    assert titles(response(traces=3).plot().axes[0])[0].startswith("Trace 0\n")
    with pytest.raises(InputError, match="overlay_traces=True does not apply to a grouped plot of 3 traces"):
        r.plot(overlay_traces=True)
    with pytest.raises(InputError, match=r"trace_labels must be a string or 3 string\(s\), one per trace"):
        r.plot(trace_labels=["a", "b"])
    plt.close("all")
    assert response().plot(overlay_traces=True).axes.shape == (2, 1)  # one trace: nothing to overlay


def test_a_format_string_and_line_properties_apply_to_every_line():
    cplt = response().plot("k:", linewidth=3.0, label="mine")
    lines = [line for row in cplt.lines.flat for line in row]
    assert {(line.get_color(), line.get_linestyle(), line.get_linewidth()) for line in lines} == {("k", ":", 3.0)}
    assert legend_texts(cplt.legend) == ["mine"]  # the agents' colours and the components' styles were replaced


def test_legend_keywords():
    assert response().plot(legend_loc=False).legend is None
    plt.close("all")
    assert response().plot(show_legend=False).legend is None
    plt.close("all")
    cplt = response().plot(legend_loc="lower left")
    assert cplt.legend._loc == 3  # matplotlib's code of "lower left"
    plt.close("all")
    cplt = response().plot(legend_map=[[None], ["upper left"]])
    assert cplt.legend[0, 0] is None and legend_texts(cplt.legend[1, 0])[:2] == ["sc1", "sc2"]
    assert not cplt.figure.legends
    with pytest.raises(InputError, match=r"legend_map has shape \(1, 1\), the axes \(2, 1\)"):
        response().plot(legend_map=[["best"]])


def test_time_label_sharing_and_rc_params():
    cplt = response().plot(time_label="t [s]", sharey=True, rcParams={"axes.facecolor": "0.9"})
    assert cplt.axes[-1, 0].get_xlabel() == "t [s]"
    assert cplt.axes[0, 0].get_shared_y_axes().joined(cplt.axes[0, 0], cplt.axes[1, 0])
    assert cplt.axes[0, 0].get_facecolor()[:3] == pytest.approx((0.9, 0.9, 0.9))


def test_add_initial_zero_for_step_traces():
    r = response(traces=1, inputs=True, trace_types=["step"])
    line = r.plot().lines[2, 0][0]
    assert line.get_xdata()[:2].tolist() == [0.0, 0.0] and line.get_ydata()[0] == 0.0
    assert np.array_equal(line.get_ydata()[1:], r.u[0, 0])
    plt.close("all")
    assert np.array_equal(r.plot(add_initial_zero=False).lines[2, 0][0].get_ydata(), r.u[0, 0])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"output_props": [{"color": "r"}]}, r"output_props= does not apply to a grouped plot: the lines are coloured"),
        ({"input_props": [{"color": "r"}]}, r"input_props= does not apply"),
        ({"trace_props": [{"linestyle": "-"}]}, r"trace_props= does not apply"),
        ({"relabel": False}, r"relabel= does not apply"),
        ({"overlay_signal": True}, r"unknown keyword 'overlay_signal'"),
        ({"color": "no-such-colour"}, r"'no-such-colour' is not a valid value for color"),
        ({"transpose": "yes"}, r"transpose must be True or False"),
        ({"label": ["a", "b"]}, r"label must be a string or 1 string\(s\)"),
        ({"legend_loc": 1.5}, r"legend_loc must be a matplotlib location"),
        ({"rcParams": {"no.such": 1}}, r"rcParams: .*no.such"),
    ],
)
def test_a_keyword_that_cannot_apply_is_one_line_naming_it(kwargs, match):
    with pytest.raises(InputError, match=match) as info:
        response().plot(**kwargs)
    assert "\n" not in str(info.value) and str(info.value).startswith("FormationResponse.plot: ")
    assert not plt.get_fignums()  # refused before drawing


def test_two_format_strings_are_refused():
    with pytest.raises(InputError, match="at most one positional argument, a matplotlib format string"):
        response().plot("k", "r")
