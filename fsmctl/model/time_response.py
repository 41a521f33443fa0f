"""Formation time responses for people: one colour per agent, signals grouped, shared by every figure.

Every figure fsmctl draws (the plug-in's responses, :class:`fsmctl.SimulationResult` plots, the reproduction's
Figs 1-9) colours agent ``i`` with :func:`agent_color` ``(i)``, so an agent keeps its colour across figures.

:class:`FormationResponse` is a :class:`control.TimeResponseData` whose :meth:`~FormationResponse.plot` groups
a formation's signals: one axes per signal group (``sigma``, ``omega``, ``tau``, ``sigma_e``, ...), the agents as
colours, the components as line styles, instead of python-control's one axes per signal (54 for the paper's six
spacecraft); it takes python-control's ``time_response_plot`` keywords (``ax``, ``plot_inputs``,
``overlay_signals``, ``label``, ...) where a grouped plot can honour them and names the others in an error.  The group and the agent are read from the signal names fsmctl uses (:func:`fsmctl.formation`,
:meth:`fsmctl.SimulationResult.to_time_response`): ``sc<i>_<group>[k]`` (also ``sc<i>.<group>[k]`` and
``<group>_<i>[k]``); a name without an agent (``aaem_deg``) is a formation-level signal, drawn in black.
"""

from __future__ import annotations

import operator
import re
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import control as ct
import numpy as np

from fsmctl.errors import InputError

__all__ = ["agent_color", "FormationResponse", "formation_response"]

# matplotlib's "tab10" qualitative palette, then "tab20"'s lighter shades: 20 agents before a colour repeats
_PALETTE = (
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf",
    "#aec7e8", "#ffbb78", "#98df8a", "#ff9896", "#c5b0d5", "#c49c94", "#f7b6d2", "#c7c7c7", "#dbdb8d", "#9edae5",
)  # fmt: skip


def agent_color(i: int) -> str:
    """The colour of agent ``i`` (0-based) in every fsmctl figure.

    Parameters
    ----------
    i : int
        Agent index, 0-based (the paper's spacecraft ``i + 1``).

    Returns
    -------
    str
        A hex colour: matplotlib's ``tab10`` palette for agents 0-9, ``tab20``'s light shades for 10-19,
        repeating after 20 agents.

    Raises
    ------
    ValueError
        If ``i`` is negative or not an integer.

    Examples
    --------
    >>> agent_color(0), agent_color(3)
    ('#1f77b4', '#d62728')
    >>> agent_color(20) == agent_color(0)
    True
    """
    try:
        index = operator.index(i)
    except TypeError:
        index = -1
    if isinstance(i, bool) or index < 0:
        raise ValueError(f"agent index must be a non-negative integer, got {i!r}")
    return _PALETTE[index % len(_PALETTE)]


# ----------------------------------------------------------------------------- signal names

_METRICS = "metrics"
"""The group of the formation-level scalar signals (no agent, no component: ``aaem_deg``, ``raem_deg``)."""

_TITLES = {
    "sigma": "σ: attitude (MRP)",
    "omega": "ω: body rate (rad/s)",
    "tau": "u: torque on the body (N m)",
    "sigma_e": "σ_e: attitude error (MRP, eqs 5-6)",
    "omega_e": "ω_e: rate error (rad/s, eq 7)",
    "theta_e_deg": "θ_e: attitude error angle (deg)",
    "s": "s: sliding variable (eq 13)",
    "q": "q: Euler parameters",
    "Omega": "Ω: wheel speeds (rad/s)",
    _METRICS: "formation metrics",
}
"""Axes titles of the signal groups fsmctl writes (Liang et al. 2012's symbols); other groups show their name."""

_METRIC_TITLES = {
    ("aaem_deg", "raem_deg"): "AAEM, RAEM: attitude error metrics (deg, eqs 42-43)",
}

_STYLES = ("-", "--", ":", "-.")
"""Line style of component ``k`` (``k % 4``): the three components of a vector are solid, dashed, dotted."""

_BRACKET = r"(?:\[(?P<k>\d+)\])?"
_PATTERNS = (
    re.compile(rf"(?P<sys>[A-Za-z]+)(?P<agent>\d+)[._](?P<base>[^\[\].]+?){_BRACKET}"),  # sc1_sigma[0], sc1.sigma[0]
    re.compile(rf"(?P<base>[A-Za-z][^\[\].]*?)_(?P<agent>\d+){_BRACKET}"),  # sigma_1[0]
    re.compile(rf"(?P<base>[^\[\]]+?){_BRACKET}"),  # aaem_deg, reference_sigma_d[0]
)


@dataclass(frozen=True)
class _Signal:
    index: int  # row of the response's outputs
    label: str
    group: str
    agent: int | None  # 0-based
    component: int | None


def _parse(index: int, label: str) -> _Signal:
    """The group, agent (0-based) and component of a signal name (see the module docstring)."""
    for pattern in _PATTERNS:
        m = pattern.fullmatch(label)
        if m:
            groups = m.groupdict()
            agent = int(groups["agent"]) - 1 if groups.get("agent") else None
            if agent is not None and agent < 0:  # "sc0_..." is no fsmctl agent: keep the name whole
                continue
            k = int(groups["k"]) if groups["k"] is not None else None
            base = groups["base"]
            group = _METRICS if agent is None and k is None else base
            return _Signal(index, label, group, agent, k)
    return _Signal(index, label, label, None, None)


def _groups(labels: Sequence[str]) -> dict[str, list[_Signal]]:
    out: dict[str, list[_Signal]] = {}
    for index, label in enumerate(labels):
        signal = _parse(index, label)
        out.setdefault(signal.group, []).append(signal)
    return out


def _title(group: str, signals: list[_Signal]) -> str:
    if group == _METRICS:
        names = tuple(s.label for s in signals)
        return _METRIC_TITLES.get(names, _TITLES[_METRICS])
    return _TITLES.get(group, group)


# ----------------------------------------------------------------------------- the response


def _arranged(panels: list[_Panel], overlay_signals: bool, transpose: bool) -> list[_Panel]:
    """The panels in drawing order: all outputs on one (and all inputs on another) when overlaid; inputs first
    when transposed (python-control: inputs left of outputs)."""
    if overlay_signals:
        panels = [
            _Panel(
                kind,
                "Outputs" if kind == "output" else "Inputs",
                [s for p in panels if p.kind == kind for s in p.signals],
            )
            for kind in ("output", "input")
            if any(p.kind == kind for p in panels)
        ]
    if transpose:
        panels = [p for p in panels if p.kind == "input"] + [p for p in panels if p.kind == "output"]
    return panels


class FormationResponse(ct.TimeResponseData):
    """A formation's time response whose :meth:`plot` is readable: signals grouped, one colour per agent.

    The constructor is :class:`control.TimeResponseData`'s (same arguments); :func:`formation_response` wraps
    a response python-control returns (``ct.input_output_response(fsmctl.formation(s), ...)``), and
    :meth:`fsmctl.SimulationResult.to_time_response` returns one.  Everything else (``outputs``, ``states``,
    ``output_labels``, ``to_pandas()``, ...) is python-control's; ``ct.time_response_plot(response)`` still
    draws its one-axes-per-signal plot.

    Parameters
    ----------
    *args
        Those of :class:`control.TimeResponseData` (``time``, ``outputs``, ``states``, ``inputs``).
    **kwargs
        Those of :class:`control.TimeResponseData` (``output_labels``, ``state_labels``, ``title``, ``issiso``,
        ...).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0.0, 1.0, 5)
    >>> y = np.vstack([np.sin(t + k) for k in range(6)])
    >>> labels = [f"sc{i}_sigma[{k}]" for i in (1, 2) for k in range(3)]
    >>> r = FormationResponse(t, y, output_labels=labels, issiso=False)
    >>> r.signal_groups()
    {'sigma': ['sc1_sigma[0]', 'sc1_sigma[1]', 'sc1_sigma[2]', 'sc2_sigma[0]', 'sc2_sigma[1]', 'sc2_sigma[2]']}
    """

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        if not self.ninputs:  # python-control keeps plot_inputs=True for an empty (0, T) input array
            self.plot_inputs = False

    def signal_groups(self) -> dict[str, list[str]]:
        """The output names by signal group, in the order :meth:`plot` draws them.

        Returns
        -------
        dict of str to list of str
            Group name (``"sigma"``, ``"omega"``, ``"tau"``, ``"sigma_e"``, ..., ``"metrics"`` for the
            formation-level scalars such as ``aaem_deg``) to the output labels in it.

        Examples
        --------
        >>> import numpy as np
        >>> labels = ["sc1_tau[0]", "sigma_2[1]", "aaem_deg", "raem_deg"]
        >>> FormationResponse([0.0, 1.0], np.zeros((4, 2)), output_labels=labels, issiso=False).signal_groups()
        {'tau': ['sc1_tau[0]'], 'sigma': ['sigma_2[1]'], 'metrics': ['aaem_deg', 'raem_deg']}
        """
        return {g: [s.label for s in signals] for g, signals in _groups(self.output_labels).items()}

    def plot(
        self,
        *fmt: str,
        groups: Sequence[str] | str | None = None,
        max_axes: int = 6,
        ax=None,
        plot_inputs: bool | str | None = None,
        plot_outputs: bool = True,
        transpose: bool = False,
        overlay_traces: bool = False,
        overlay_signals: bool = False,
        add_initial_zero: bool = True,
        label: str | Sequence[str] | None = None,
        trace_labels: Sequence[str] | None = None,
        title: str | None = None,
        legend_loc: str | int | bool | None = None,
        legend_map=None,
        show_legend: bool | None = None,
        time_label: str = "time (s)",
        sharex: bool | str | None = None,
        sharey: bool | str | None = None,
        rcParams: Mapping[str, Any] | None = None,
        **kwargs: Any,
    ):
        """Plot the signals grouped: one axes per signal group, agents as colours, components as line styles.

        Agent ``i`` is drawn in :func:`agent_color` ``(i)``, component ``k`` of a vector with line style
        ``("-", "--", ":")[k]``; formation-level signals (no agent) in black, each labelled.  One legend (beside
        the axes) names the agents and the components.  The keywords are those of python-control's
        :meth:`control.TimeResponseData.plot` (:func:`control.time_response_plot`), with the same meanings,
        where they apply to a grouped plot; the others (``output_props``, ``input_props``, ``trace_props``:
        the colours are the agents'; ``relabel``; ``plot_inputs="overlay"``; ``overlay_traces`` with several
        traces: the line styles are the components') raise :class:`~fsmctl.errors.InputError` naming the
        keyword, as does any keyword that is neither one of these nor a matplotlib line property.

        As in python-control, the lines go to the current figure when it has as many axes as this plot needs
        (so that ``r1.plot(label="a"); r2.plot(label="b", linestyle="--")`` overlays two responses, the legend
        naming both), on it when it has none, else to a new figure; ``plt.figure()`` first, or ``ax=``, chooses.

        Parameters
        ----------
        *fmt : str, optional
            A matplotlib format string (``"k--"``) for every line; it replaces the agents' colours and the
            components' line styles (python-control: it replaces the line properties).
        groups : sequence of str or str, optional
            The output groups to draw, in this order (names of :meth:`signal_groups`); default: all, in the
            order of the outputs, at most ``max_axes`` of them.
        max_axes : int
            Most output groups drawn when ``groups`` is not given (the rest is left out with a warning).
        ax : matplotlib Axes or array of Axes, optional
            The axes to draw on, one per plotted panel in the plot's shape (``(n_groups, n_traces)``, transposed
            with ``transpose=True``); default: see above.
        plot_inputs : bool or None
            ``True``: the inputs too, grouped like the outputs, below them (left of them with ``transpose``);
            ``False``: not; ``None`` (default): if the response has inputs and its ``plot_inputs`` says so.  A
            formation (:func:`fsmctl.formation`) has no inputs.
        plot_outputs : bool
            ``False``: inputs only.
        transpose : bool
            Signal groups left to right (inputs first) and traces top to bottom.
        overlay_traces : bool
            Accepted for a response of one trace (nothing to overlay); with several traces each one has its
            own column.
        overlay_signals : bool
            All output groups on one axes (and all input groups on another).
        add_initial_zero : bool
            Start inputs of a ``"step"`` trace at zero, as python-control does.
        label : str or sequence of str, optional
            A name of the response (one per trace): added to its lines' labels (``"sc1_sigma[0], run A"``)
            and to the legend, drawn with the line keywords given, so overlaid responses are told apart.
        trace_labels : sequence of str, optional
            Titles of the traces' columns (default the response's ``trace_labels``, else ``"Trace <j>"``).
        title : str, optional
            Figure title; default the response's ``title`` (none when ``ax`` is given, as python-control).

        Other Parameters
        ----------------
        legend_loc : str, int or False, optional
            Where the legend goes (a matplotlib location; default ``"outside right upper"``, beside the axes);
            ``False``: no legend.
        legend_map : array of str or None, optional
            One entry per axes (the plot's shape): a location for a legend on that axes, or ``None``; replaces
            the figure's legend.
        show_legend : bool, optional
            ``False``: no legend.
        time_label : str
            Label of the time axis.
        sharex, sharey : bool or str, optional
            Axis sharing of a new figure (:func:`matplotlib.pyplot.subplots`); default python-control's
            ``config.defaults["timeplot.sharex"]`` and ``["timeplot.sharey"]``.
        rcParams : dict, optional
            matplotlib settings for this plot (:func:`matplotlib.pyplot.rc_context`).
        **kwargs
            matplotlib line properties for every line (``color``, ``linestyle``, ``linewidth``, ``alpha``,
            ...): they override the agents' colours and the components' styles, and the legend stops
            listing what they replace.

        Returns
        -------
        control.ControlPlot
            ``lines`` (an array of the axes' shape, each a list of :class:`matplotlib.lines.Line2D`), ``axes``
            (shape ``(n_panels, n_traces)``, transposed with ``transpose``), ``figure``, ``legend`` (the
            figure's legend, or the array of axes legends of ``legend_map``; ``None`` without one).

        Raises
        ------
        fsmctl.errors.InputError
            A keyword that does not apply or a bad value (see above); an unknown group; ``max_axes < 1``;
            nothing to plot (no outputs, ``plot_inputs=True`` without inputs, both ``False``); ``ax``, ``label``,
            ``trace_labels`` or ``legend_map`` of the wrong size.

        Warns
        -----
        UserWarning
            When there are more groups than ``max_axes`` and ``groups`` is not given.

        See Also
        --------
        control.time_response_plot : python-control's plot of the same response, one axes per signal.

        Examples
        --------
        >>> import matplotlib
        >>> matplotlib.use("Agg")
        >>> import matplotlib.pyplot as plt
        >>> import numpy as np
        >>> t = np.linspace(0.0, 1.0, 5)
        >>> labels = [f"sc{i}_{g}[{k}]" for i in (1, 2) for g in ("sigma", "omega") for k in range(3)]
        >>> r = FormationResponse(t, np.ones((12, 5)), output_labels=labels, issiso=False)
        >>> cplt = r.plot()
        >>> [ax.get_title() for ax in cplt.axes[:, 0]], [len(lines) for lines in cplt.lines[:, 0]]
        (['σ: attitude (MRP)', 'ω: body rate (rad/s)'], [6, 6])
        >>> [text.get_text() for text in cplt.legend.get_texts()]
        ['sc1', 'sc2', '[0]', '[1]', '[2]']

        A second response on the same axes, in grey, named in the legend:

        >>> cplt = FormationResponse(t, np.zeros((12, 5)), output_labels=labels, issiso=False).plot(
        ...     label="zero", color="0.5", linewidth=3)
        >>> [text.get_text() for text in cplt.legend.get_texts()]
        ['sc1', 'sc2', '[0]', '[1]', '[2]', 'zero']
        >>> plt.close(cplt.figure)

        One axes for everything, on axes of your own:

        >>> fig, ax = plt.subplots()
        >>> cplt = r.plot(ax=ax, overlay_signals=True, legend_loc="upper left")
        >>> cplt.axes.shape, len(cplt.lines[0, 0]), cplt.axes[0, 0] is ax
        ((1, 1), 12, True)
        >>> plt.close(fig)
        """
        import matplotlib.pyplot as plt

        where = "FormationResponse.plot"
        _check_keywords(fmt, kwargs, where)
        for name, value in (
            ("plot_outputs", plot_outputs),
            ("transpose", transpose),
            ("overlay_traces", overlay_traces),
            ("overlay_signals", overlay_signals),
            ("add_initial_zero", add_initial_zero),
        ):
            if not isinstance(value, (bool, np.bool_)):
                raise InputError(f"{where}: {name} must be True or False, got {value!r}")
        ntraces = max(1, self.ntraces)
        if overlay_traces and ntraces > 1:
            raise InputError(
                f"{where}: overlay_traces=True does not apply to a grouped plot of {ntraces} traces (colours are "
                "the agents', line styles the components'): each trace has its own column"
            )
        plot_inputs = self._inputs_shown(plot_inputs, plot_outputs, groups, where)
        panels = _arranged(
            self._panels(groups, max_axes, bool(plot_outputs), bool(plot_inputs), where), overlay_signals, transpose
        )
        names = _per_trace(trace_labels, "trace_labels", ntraces, where)
        if names is None:
            names = list(self.trace_labels) if self.trace_labels else [f"Trace {j}" for j in range(ntraces)]
        run_names = _per_trace(label, "label", ntraces, where)
        shape = (len(panels), ntraces)
        if transpose:
            shape = shape[::-1]
        legend_loc, legend_map, show = _legend_keywords(legend_loc, legend_map, show_legend, shape, where)
        if rcParams is not None and not isinstance(rcParams, Mapping):
            raise InputError(f"{where}: rcParams must be a dict of matplotlib settings, got {type(rcParams).__name__}")
        try:
            context = plt.rc_context(dict(rcParams or {}))
            context.__enter__()
        except (KeyError, ValueError) as exc:
            raise InputError(f"{where}: rcParams: {_one_line(exc)}") from None
        try:
            fig, axes = _figure_axes(ax, shape, sharex, sharey, where)
            lines, agents, components = self._draw(
                axes, panels, shape, transpose, run_names, fmt, kwargs, bool(plot_inputs), add_initial_zero
            )
            for col in range(shape[1]):
                axes[-1, col].set_xlabel(time_label)
            if ntraces > 1:
                for trace in range(ntraces):
                    if transpose:
                        axes[trace, 0].set_ylabel(names[trace])
                    else:
                        axes[0, trace].set_title(f"{names[trace]}\n{axes[0, trace].get_title()}", fontsize=10)
            legend = _legend(fig, axes, fmt, kwargs, agents, components, run_names, legend_loc, legend_map, show)
            if ax is None:
                text = self.title if title is None else title
                if text:
                    fig.suptitle(text)
            elif title is not None:
                fig.suptitle(title)
        finally:
            context.__exit__(None, None, None)
        return ct.ControlPlot(lines, axes, fig, legend=legend)

    def _inputs_shown(self, plot_inputs, plot_outputs, groups, where: str) -> bool:
        """Whether the inputs are drawn (``plot_inputs`` checked against the response and the other keywords)."""
        if plot_inputs is None:
            plot_inputs = bool(self.plot_inputs) and self.ninputs > 0
        elif isinstance(plot_inputs, str) and plot_inputs == "overlay":
            raise InputError(
                f"{where}: plot_inputs='overlay' does not apply to a grouped plot (inputs and outputs are different "
                "groups); use plot_inputs=True"
            )
        elif not isinstance(plot_inputs, (bool, np.bool_)):
            raise InputError(f"{where}: plot_inputs must be True, False, None or 'overlay', got {plot_inputs!r}")
        elif plot_inputs and not self.ninputs:
            raise InputError(f"{where}: plot_inputs=True, but the response has no inputs")
        if not plot_outputs and not plot_inputs:
            raise InputError(f"{where}: plot_inputs and plot_outputs are both False: nothing to plot")
        if plot_outputs and not self.noutputs:
            raise InputError(f"{where}: the response has no outputs")
        if not plot_outputs and groups is not None:
            raise InputError(f"{where}: groups= chooses output groups, and plot_outputs=False")
        return plot_inputs

    def _draw(self, axes, panels, shape, transpose, run_names, fmt, kwargs, plot_inputs: bool, add_initial_zero):
        """Draw every panel of every trace: the lines (an array of ``shape``), the agents and components drawn."""
        ntraces = max(1, self.ntraces)
        y = np.asarray(self.y, dtype=float).reshape(self.noutputs, ntraces, -1)
        u = np.asarray(self.u, dtype=float).reshape(self.ninputs, ntraces, -1) if plot_inputs else None
        t = np.asarray(self.t, dtype=float)
        lines = np.empty(shape, dtype=object)
        for index in np.ndindex(shape):
            lines[index] = []
        agents: set[int] = set()
        components: set[int] = set()
        for trace in range(ntraces):
            suffix = f", {run_names[trace]}" if run_names else ""
            for position, panel in enumerate(panels):
                where_ax = (trace, position) if transpose else (position, trace)
                axis = axes[where_ax]
                data = y if panel.kind == "output" else u
                step = (
                    panel.kind == "input"
                    and add_initial_zero
                    and self.trace_types is not None
                    and trace < len(self.trace_types)
                    and self.trace_types[trace] == "step"
                )
                x = np.concatenate([t[:1], t]) if step else t
                for n, sig in enumerate(panel.signals):
                    values = data[sig.index, trace]
                    if step:
                        values = np.concatenate([[0.0], values])
                    props = {} if fmt else _line_style(sig, n)
                    props.update(kwargs)
                    (line,) = axis.plot(x, values, *fmt, label=sig.label + suffix, **props)
                    lines[where_ax].append(line)
                    if sig.agent is not None:
                        agents.add(sig.agent)
                    if sig.component is not None and sig.agent is not None:
                        components.add(sig.component)
                axis.set_title(panel.title, fontsize=10)
                axis.grid(True, alpha=0.3)
                if len(panel.signals) > 1 and all(sig.agent is None for sig in panel.signals):
                    axis.legend(fontsize=8, loc="best")
        return lines, agents, components

    def _panels(self, groups, max_axes, outputs: bool, inputs: bool, where: str) -> list[_Panel]:
        """The axes' contents: the chosen output groups, then every input group."""
        panels = []
        if outputs:
            available = _groups(self.output_labels)
            if groups is None:
                if isinstance(max_axes, bool) or not isinstance(max_axes, int) or max_axes < 1:
                    raise InputError(f"{where}: max_axes must be an integer >= 1, got {max_axes!r}")
                chosen = list(available)
                if len(chosen) > max_axes:
                    warnings.warn(
                        f"{where}: {len(chosen)} signal groups, drawing the first {max_axes}; left out: "
                        f"{', '.join(chosen[max_axes:])} (choose with plot(groups=[...]))",
                        UserWarning,
                        stacklevel=3,
                    )
                    chosen = chosen[:max_axes]
            else:
                chosen = [groups] if isinstance(groups, str) else list(groups)
                unknown = [g for g in chosen if g not in available]
                if unknown or not chosen:
                    raise InputError(
                        f"{where}: no signal group {unknown[0] if unknown else '(none given)'!r}; "
                        f"the groups are {', '.join(available)}"
                    )
            panels += [_Panel("output", _title(g, available[g]), available[g]) for g in chosen]
        if inputs:
            for g, signals in _groups(self.input_labels).items():
                panels.append(_Panel("input", "inputs" if g == _METRICS else _title(g, signals), signals))
        return panels


@dataclass(frozen=True)
class _Panel:
    kind: str  # "output" or "input"
    title: str
    signals: list[_Signal]


_NOT_APPLICABLE = {
    "output_props": "the lines are coloured by agent (fsmctl.agent_color) and styled by component; pass color= or "
    "linestyle= to set every line",
    "input_props": "the lines are coloured by agent (fsmctl.agent_color) and styled by component; pass color= or "
    "linestyle= to set every line",
    "trace_props": "the traces have a column each (line styles are the components'); pass linestyle= to set every line",
    "relabel": "python-control deprecates it; the axes are always labelled",
}
"""python-control's ``time_response_plot`` keywords that a grouped plot cannot honour, and why."""


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def _check_keywords(fmt: tuple, kwargs: dict[str, Any], where: str) -> None:
    """Refuse the keywords that do not apply and anything that is not a matplotlib line property, before drawing."""
    from matplotlib import cbook
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    for key in kwargs:
        if key in _NOT_APPLICABLE:
            raise InputError(f"{where}: {key}= does not apply to a grouped plot: {_NOT_APPLICABLE[key]}")
    for key in cbook.normalize_kwargs(kwargs, Line2D):
        if not callable(getattr(Line2D, f"set_{key}", None)):
            raise InputError(
                f"{where}: unknown keyword {key!r} (neither a keyword of python-control's time_response_plot that "
                "applies here nor a matplotlib line property)"
            )
    if len(fmt) > 1 or any(not isinstance(f, str) for f in fmt):
        raise InputError(f"{where}: at most one positional argument, a matplotlib format string, got {fmt!r}")
    try:  # the values, on a figure pyplot does not track
        Figure().add_subplot().plot([0.0], [0.0], *fmt, **kwargs)
    except (AttributeError, TypeError, ValueError) as exc:
        raise InputError(f"{where}: {_one_line(exc)}") from None


def _per_trace(value, name: str, ntraces: int, where: str) -> list[str] | None:
    """``label``/``trace_labels``: ``None``, one string (every trace) or one string per trace."""
    if value is None:
        return None
    if isinstance(value, str):
        return [value] * ntraces
    values = list(value) if isinstance(value, Sequence) or isinstance(value, np.ndarray) else None
    if values is None or len(values) != ntraces or not all(isinstance(v, str) for v in values):
        raise InputError(f"{where}: {name} must be a string or {ntraces} string(s), one per trace, got {value!r}")
    return values


def _legend_keywords(legend_loc, legend_map, show_legend, shape: tuple[int, int], where: str):
    """python-control's legend keywords (``ctrlplot._process_legend_keywords``): ``(loc, map, show)``."""
    if show_legend is not None and not isinstance(show_legend, (bool, np.bool_)):
        raise InputError(f"{where}: show_legend must be True, False or None, got {show_legend!r}")
    if legend_loc is False or (legend_map is not None and legend_map is False) or show_legend is False:
        return None, None, False
    if legend_loc is not None and (isinstance(legend_loc, bool) or not isinstance(legend_loc, (int, str))):
        raise InputError(f"{where}: legend_loc must be a matplotlib location (str or int) or False, got {legend_loc!r}")
    if legend_map is not None:
        legend_map = np.atleast_2d(np.asarray(legend_map, dtype=object))
        if legend_map.shape != shape:
            raise InputError(f"{where}: legend_map has shape {legend_map.shape}, the axes {shape}")
    return legend_loc, legend_map, True


def _figure_axes(ax, shape: tuple[int, int], sharex, sharey, where: str):
    """python-control's choice of axes (``ctrlplot._process_ax_keyword``), with a new figure sized for the groups."""
    import matplotlib.pyplot as plt
    from matplotlib.axes import Axes

    count = shape[0] * shape[1]
    if ax is not None:
        given = np.asarray(ax, dtype=object)
        if given.size != count or not all(isinstance(a, Axes) for a in given.flat):
            raise InputError(
                f"{where}: ax must hold {count} matplotlib Axes (the plot's shape {shape}), got {given.size} "
                f"object(s) of shape {given.shape}"
            )
        axes = given.reshape(shape)
        return axes[0, 0].figure, axes
    sharex = ct.config.defaults["timeplot.sharex"] if sharex is None else sharex
    sharey = ct.config.defaults["timeplot.sharey"] if sharey is None else sharey
    fig = plt.gcf() if plt.get_fignums() else None
    if fig is not None and len(fig.get_axes()) == count:  # python-control: draw into the current figure
        return fig, np.asarray(fig.get_axes(), dtype=object).reshape(shape)
    if fig is not None and not fig.get_axes():
        axes = fig.subplots(*shape, sharex=sharex, sharey=sharey, squeeze=False)
        fig.set_layout_engine("constrained")
        return fig, axes
    rows, cols = shape
    size = (8.0 if cols == 1 else min(3.0 + 4.0 * cols, 24.0), 0.6 + 1.9 * rows)
    fig, axes = plt.subplots(
        rows, cols, sharex=sharex, sharey=sharey, squeeze=False, figsize=size, layout="constrained"
    )
    return fig, axes


def _line_style(signal: _Signal, position: int) -> dict[str, Any]:
    """Agent colour and component line style of a signal (black, one style per signal, for formation signals)."""
    if signal.agent is not None:
        return {
            "color": agent_color(signal.agent),
            "linestyle": _STYLES[(signal.component or 0) % len(_STYLES)],
            "linewidth": 1.2,
        }
    k = signal.component if signal.component is not None else position
    return {"color": "black", "linestyle": _STYLES[k % len(_STYLES)], "linewidth": 1.2}


def _legend(fig, axes, fmt, kwargs, agents, components, run_names, legend_loc, legend_map, show):
    """The figure's legend: agents, components and named responses of every call on this figure so far."""
    from matplotlib import cbook
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    style = cbook.normalize_kwargs(kwargs, Line2D)
    known = getattr(fig, "_fsmctl_legend", None)
    if known is None:
        known = fig._fsmctl_legend = {"agents": {}, "components": {}, "runs": {}}
    if not fmt and "color" not in style:
        for i in sorted(agents):
            known["agents"].setdefault(i, Line2D([], [], color=agent_color(i), linestyle="-", label=f"sc{i + 1}"))
    if not fmt and "linestyle" not in style:
        for k in sorted(components):
            known["components"].setdefault(
                k, Line2D([], [], color="black", linestyle=_STYLES[k % len(_STYLES)], label=f"[{k}]")
            )
    for name in dict.fromkeys(run_names or ()):
        props = {"color": "black", "linestyle": "-", **style} if not fmt else dict(style)
        (handle,) = Figure().add_subplot().plot([], [], *fmt, **props)
        handle.set_label(name)
        known["runs"][name] = handle
    handles = [
        *(known["agents"][i] for i in sorted(known["agents"])),
        *(known["components"][k] for k in sorted(known["components"])),
        *known["runs"].values(),
    ]
    previous = getattr(fig, "_fsmctl_legend_artist", None)
    if previous is not None and previous in fig.legends:
        previous.remove()
    fig._fsmctl_legend_artist = None
    if not show or not handles:
        return None
    if legend_map is not None:
        out = np.full(axes.shape, None, dtype=object)
        for index in np.ndindex(axes.shape):
            if legend_map[index] is not None:
                out[index] = axes[index].legend(handles=handles, loc=legend_map[index], fontsize=8)
        return out
    if legend_loc is None:
        engine = fig.get_layout_engine()
        legend_loc = (
            "outside right upper" if engine is not None and "Constrained" in type(engine).__name__ else "upper right"
        )
    fig._fsmctl_legend_artist = fig.legend(handles=handles, loc=legend_loc, fontsize=8)
    return fig._fsmctl_legend_artist


def formation_response(response: ct.TimeResponseData) -> FormationResponse:
    """A python-control time response as a :class:`FormationResponse` (same data, readable ``plot()``).

    The way to plot a response of a formation: ``ct.input_output_response(fsmctl.formation(s), ...).plot()``
    raises python-control's "input plotting requested but no inputs in time response data" (a formation has
    no inputs, yet python-control 0.10 stores its empty input array and marks it for plotting), and would draw
    one axes per signal (54 for the paper's six spacecraft).  The response returned here does not mark the
    missing inputs, so ``ct.time_response_plot`` of it draws too.

    Parameters
    ----------
    response : control.TimeResponseData
        For example ``ct.input_output_response(fsmctl.formation(s), ...)``; a :class:`FormationResponse` is
        returned as it is.

    Returns
    -------
    FormationResponse
        A new object sharing the response's arrays and labels (``plot_inputs`` is False when there are no
        inputs).

    Raises
    ------
    fsmctl.errors.InputError
        ``response`` is not a :class:`control.TimeResponseData`.

    Examples
    --------
    >>> import control as ct, numpy as np
    >>> import fsmctl
    >>> from fsmctl.model.time_response import formation_response
    >>> from fsmctl.plugin.iosys import initial_state
    >>> s = fsmctl.paper_scenario("1")
    >>> r = formation_response(ct.input_output_response(fsmctl.formation(s), [0.0, 0.01], 0, initial_state(s)))
    >>> list(r.signal_groups()), len(r.signal_groups()["sigma"])
    (['sigma', 'omega', 'tau'], 18)
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import matplotlib.pyplot as plt
    >>> r.plot().axes.shape
    (3, 1)
    >>> plt.close("all")
    """
    if isinstance(response, FormationResponse):
        return response
    if not isinstance(response, ct.TimeResponseData):
        raise InputError(f"formation_response: expected a control.TimeResponseData, got {type(response).__name__}")
    new = FormationResponse.__new__(FormationResponse)
    new.__dict__.update(response.__dict__)
    if not new.ninputs:  # python-control marks an empty (0, T) input array for plotting: nothing to plot there
        new.plot_inputs = False
    return new
