"""The figures of ``fsmctl compare-surfaces``: the error metrics by surface, and the per-agent times.

Both read a :class:`~fsmctl.studies.surfaces.SurfaceComparison` and are built without pyplot.  The surfaces are
drawn in the colours of runs (:data:`fsmctl.studies.figures.RUN_COLORS`), never in an agent's
(:func:`~fsmctl.model.time_response.agent_color`): in every fsmctl figure an agent's colour means that agent.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from fsmctl.studies.figures import RUN_COLORS
from fsmctl.studies.surface_measures import SURFACES

if TYPE_CHECKING:
    from fsmctl.studies.surfaces import SurfaceComparison

__all__ = ["plot_error_metrics", "plot_agent_times"]

_STYLES = ("-", "--", "-.")


def plot_error_metrics(comparison: SurfaceComparison, metric: str = "aaem_deg"):
    """AAEM (eq 42) or RAEM (eq 43) against time, one panel per variant, one line per surface.

    Parameters
    ----------
    comparison : SurfaceComparison
        The result of :func:`compare_surfaces`.
    metric : {'aaem_deg', 'raem_deg'}, optional
        The metric to plot.

    Returns
    -------
    matplotlib.figure.Figure
        Built without pyplot.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.studies import Variant, compare_surfaces
    >>> from fsmctl.studies.surface_figures import plot_error_metrics
    >>> c = compare_surfaces(fsmctl.paper_scenario("1"), t_final=1.0, variants=[Variant(True, True, True)],
    ...                      scalar_check=False, workers=1, progress=False)
    >>> fig = plot_error_metrics(c, "raem_deg")
    >>> len(fig.axes), len(fig.axes[0].lines) >= 3
    (1, True)
    """
    from matplotlib.figure import Figure

    variants = list(dict.fromkeys(v for v, _ in comparison.series))
    ncol = min(4, len(variants))
    nrow = math.ceil(len(variants) / ncol)
    fig = Figure(figsize=(3.6 * ncol, 2.8 * nrow), layout="constrained")
    axes = fig.subplots(nrow, ncol, squeeze=False, sharey=True)
    for ax, v in zip(axes.flat, variants, strict=False):
        for k, s in enumerate(SURFACES):
            ser = comparison.series[(v, s)]
            ax.semilogy(ser["time_s"], np.maximum(ser[metric], 1e-8), label=s.upper(), lw=1, color=RUN_COLORS[k],
                        ls=_STYLES[k % len(_STYLES)])  # fmt: skip
        ax.axhline(comparison.settings["metric_tolerance_deg"], color="k", lw=0.6, ls=":")
        ax.set_title(v, fontsize=9)
        ax.set_xlabel("t (s)")
        ax.grid(True, alpha=0.3)
    for ax in axes.flat[len(variants) :]:
        ax.set_visible(False)
    axes[0, 0].set_ylabel(f"{metric.split('_')[0].upper()} (deg)")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(f"{comparison.scenario_label}: {metric.split('_')[0].upper()} by sliding surface (Liang et al. 2012, eq "
                 f"{'42' if metric == 'aaem_deg' else '43'})", fontsize=10)  # fmt: skip
    return fig


def plot_agent_times(comparison: SurfaceComparison, variant: str | None = None):
    """Per agent: reaching time and sliding-phase time (measured and Theorem 3's prediction) for each surface.

    ``variant`` defaults to the first variant in which every surface settles (else the first).

    Parameters
    ----------
    comparison : SurfaceComparison
        The result of :func:`compare_surfaces`.
    variant : str or None, optional
        The variant's name (:attr:`Variant.name`).

    Returns
    -------
    matplotlib.figure.Figure
        Built without pyplot: reaching time, sliding-phase time (with Theorem 3's) and control effort per agent,
        one bar per surface.

    Examples
    --------
    >>> import fsmctl
    >>> from fsmctl.studies import Variant, compare_surfaces
    >>> from fsmctl.studies.surface_figures import plot_agent_times
    >>> c = compare_surfaces(fsmctl.paper_scenario("1"), t_final=1.0, variants=[Variant(True, True, True)],
    ...                      scalar_check=False, workers=1, progress=False)
    >>> [ax.get_ylabel().split()[0] for ax in plot_agent_times(c).axes]
    ['reaching', 'sliding-phase', 'control']
    """
    from matplotlib.figure import Figure

    if variant is None:
        names = list(dict.fromkeys(r["variant"] for r in comparison.runs))
        settled = [
            v for v in names if all(math.isfinite(comparison.run_row(v, s)["aaem_settling_s"]) for s in SURFACES)
        ]
        variant = (settled or names)[0]
    rows = [a for a in comparison.agents if a["variant"] == variant]
    n = max(a["agent"] for a in rows)
    fig = Figure(figsize=(10, 3.8), layout="constrained")
    axes = fig.subplots(1, 3)
    width = 0.27
    x = np.arange(1, n + 1)
    for k, s in enumerate(SURFACES):
        r = sorted((a for a in rows if a["surface"] == s), key=lambda a: a["agent"])
        bar = {"label": s.upper(), "color": RUN_COLORS[k]}
        axes[0].bar(x + (k - 1) * width, [a["reaching_time_s"] for a in r], width, **bar)
        axes[1].bar(x + (k - 1) * width, [a["sliding_phase_time_s"] for a in r], width, **bar)
        axes[1].plot(x + (k - 1) * width, [a["sliding_phase_theorem3_s"] for a in r], "_", color="0.5", ms=9)
        axes[2].bar(x + (k - 1) * width, [a["control_effort_N_m_s"] for a in r], width, **bar)
    axes[0].set_ylabel("reaching time (s)")
    axes[1].set_ylabel("sliding-phase time (s); - = Theorem 3")
    axes[2].set_ylabel(r"control effort $\int \sum_k |u_k| dt$ (N m s)")
    for ax in axes:
        ax.set_xlabel("agent")
        ax.set_xticks(x)
        ax.grid(True, axis="y", alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"{comparison.scenario_label}, {variant}", fontsize=10)
    return fig
