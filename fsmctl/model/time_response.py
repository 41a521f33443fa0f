"""Formation time responses for people: one colour per agent, signals grouped, shared by every figure.

Every figure fsmctl draws (the plug-in's responses, :class:`fsmctl.SimulationResult` plots, the reproduction's
Figs 1-9) colours agent ``i`` with :func:`agent_color` ``(i)``, so an agent keeps its colour across figures.

:class:`FormationResponse` is a :class:`control.TimeResponseData` whose :meth:`~FormationResponse.plot` groups
a formation's signals: one axes per signal group (``sigma``, ``omega``, ``tau``, ``sigma_e``, ...), the agents as
colours, the components as line styles, instead of python-control's one axes per signal (54 for the paper's six
spacecraft).  The group and the agent are read from the signal names fsmctl uses (:func:`fsmctl.formation`,
:meth:`fsmctl.SimulationResult.to_time_response`): ``sc<i>_<group>[k]`` (also ``sc<i>.<group>[k]`` and
``<group>_<i>[k]``); a name without an agent (``aaem_deg``) is a formation-level signal, drawn in black.
"""

from __future__ import annotations

import operator
import re
import warnings
from collections.abc import Sequence
from dataclasses import dataclass

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

    def plot(self, groups: Sequence[str] | None = None, *, max_axes: int = 6, title: str | None = None):
        """Plot the outputs grouped: one axes per signal group, agents as colours, components as line styles.

        Agent ``i`` is drawn in :func:`agent_color` ``(i)``, component ``k`` of a vector with line style
        ``("-", "--", ":")[k]``; formation-level signals (no agent) in black, each labelled.  One legend (beside
        the axes) names the agents and the components.

        Parameters
        ----------
        groups : sequence of str, optional
            The groups to draw, in this order (names of :meth:`signal_groups`); default: all, in the order of
            the outputs, at most ``max_axes`` of them.
        max_axes : int
            Most axes drawn when ``groups`` is not given (the rest is left out with a warning).
        title : str, optional
            Figure title; default the response's ``title``.

        Returns
        -------
        control.ControlPlot
            ``lines`` (an array with one list of :class:`matplotlib.lines.Line2D` per axes), ``axes`` (shape
            ``(n_groups, 1)``), ``figure``, ``legend`` (the figure's legend).

        Raises
        ------
        fsmctl.errors.InputError
            A response with several traces or no outputs, an unknown group, or ``max_axes < 1``.

        Warns
        -----
        UserWarning
            When there are more groups than ``max_axes`` and ``groups`` is not given.

        Examples
        --------
        >>> import matplotlib
        >>> matplotlib.use("Agg")
        >>> import numpy as np
        >>> t = np.linspace(0.0, 1.0, 5)
        >>> labels = [f"sc{i}_{g}[{k}]" for i in (1, 2) for g in ("sigma", "omega") for k in range(3)]
        >>> r = FormationResponse(t, np.ones((12, 5)), output_labels=labels, issiso=False)
        >>> cplt = r.plot()
        >>> [ax.get_title() for ax in cplt.axes[:, 0]], [len(lines) for lines in cplt.lines]
        (['σ: attitude (MRP)', 'ω: body rate (rad/s)'], [6, 6])
        >>> [text.get_text() for text in cplt.legend.get_texts()]
        ['sc1', 'sc2', '[0]', '[1]', '[2]']
        >>> import matplotlib.pyplot as plt
        >>> plt.close(cplt.figure)
        """
        import matplotlib.pyplot as plt
        from matplotlib.lines import Line2D

        if self.ntraces:
            raise InputError(f"FormationResponse.plot: one trace expected, the response has {self.ntraces}")
        if not self.noutputs:
            raise InputError("FormationResponse.plot: the response has no outputs")
        available = _groups(self.output_labels)
        if groups is None:
            if isinstance(max_axes, bool) or not isinstance(max_axes, int) or max_axes < 1:
                raise InputError(f"FormationResponse.plot: max_axes must be an integer >= 1, got {max_axes!r}")
            chosen = list(available)
            if len(chosen) > max_axes:
                warnings.warn(
                    f"FormationResponse.plot: {len(chosen)} signal groups, drawing the first {max_axes}; left out: "
                    f"{', '.join(chosen[max_axes:])} (choose with plot(groups=[...]))",
                    UserWarning,
                    stacklevel=2,
                )
                chosen = chosen[:max_axes]
        else:
            if isinstance(groups, str):
                groups = [groups]
            chosen = list(groups)
            unknown = [g for g in chosen if g not in available]
            if unknown or not chosen:
                raise InputError(
                    f"FormationResponse.plot: no signal group {unknown[0] if unknown else '(none given)'!r}; "
                    f"the groups are {', '.join(available)}"
                )
        y = np.asarray(self.y, dtype=float).reshape(self.noutputs, -1)
        t = np.asarray(self.t, dtype=float)
        fig, axes = plt.subplots(
            len(chosen), 1, sharex=True, squeeze=False, figsize=(8.0, 0.6 + 1.9 * len(chosen)), layout="constrained"
        )
        lines = np.empty(len(chosen), dtype=object)
        agents: set[int] = set()
        components: set[int] = set()
        for row, group in enumerate(chosen):
            ax = axes[row, 0]
            signals = available[group]
            drawn = []
            for position, s in enumerate(signals):
                if s.agent is not None:
                    agents.add(s.agent)
                    color, label = agent_color(s.agent), s.label
                    style = _STYLES[(s.component or 0) % len(_STYLES)]
                    if s.component is not None:
                        components.add(s.component)
                else:
                    color, label = "black", s.label
                    style = _STYLES[(s.component if s.component is not None else position) % len(_STYLES)]
                (line,) = ax.plot(t, y[s.index], color=color, linestyle=style, linewidth=1.2, label=label)
                drawn.append(line)
            lines[row] = drawn
            ax.set_title(_title(group, signals), fontsize=10)
            ax.grid(True, alpha=0.3)
            if all(s.agent is None for s in signals) and len(signals) > 1:
                ax.legend(fontsize=8, loc="best")
        axes[-1, 0].set_xlabel("time (s)")
        handles = [Line2D([], [], color=agent_color(i), linestyle="-", label=f"sc{i + 1}") for i in sorted(agents)] + [
            Line2D([], [], color="black", linestyle=_STYLES[k % len(_STYLES)], label=f"[{k}]")
            for k in sorted(components)
        ]
        legend = fig.legend(handles=handles, loc="outside right upper", fontsize=8) if handles else None
        text = title if title is not None else self.title
        if text:
            fig.suptitle(text)
        return ct.ControlPlot(lines, axes, fig, legend=legend)


def formation_response(response: ct.TimeResponseData) -> FormationResponse:
    """A python-control time response as a :class:`FormationResponse` (same data, readable ``plot()``).

    Parameters
    ----------
    response : control.TimeResponseData
        For example ``ct.input_output_response(fsmctl.formation(s), ...)``; a :class:`FormationResponse` is
        returned as it is.

    Returns
    -------
    FormationResponse
        A new object sharing the response's arrays and labels.

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
    """
    if isinstance(response, FormationResponse):
        return response
    if not isinstance(response, ct.TimeResponseData):
        raise InputError(f"formation_response: expected a control.TimeResponseData, got {type(response).__name__}")
    new = FormationResponse.__new__(FormationResponse)
    new.__dict__.update(response.__dict__)
    return new
