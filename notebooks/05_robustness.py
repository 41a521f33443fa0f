# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # 05 — Robustness: sensitivity of the FSM formation controller (Liang, Sun & Wang 2012)
#
# Heat maps of the steady-state AAEM (eq 42, max over the last 40 % of the run) and its settling
# time to 0.03° over pairs of parameters the paper fixes or leaves open: the exponent $\alpha$
# and switching gain $\delta$ (eqs 13, 18), the boundary layer $\phi$ (Remark 7) and the
# disturbance amplitude, the inertia uncertainty $\Delta J = s\,J_0$ (eq 29) and the topology
# density (each agent receives from its $k$ nearest neighbours, switching as Table 2).
#
# The 2 N m torque limit is removed in these sweeps: with it the Case 1 formation does not
# converge within 100 s for any of the settings (see notebook 04 and `fsmctl compare-surfaces`),
# so every cell would be "not settled".  Small grids and a 10 s horizon when `FSMCTL_FAST=1`.

# %%
# %matplotlib inline
import dataclasses
import math
import os

import numpy as np
from matplotlib.figure import Figure

from fsmctl import paper_scenario, simulate
from fsmctl.model.topology import k_nearest

FAST = os.environ.get("FSMCTL_FAST") == "1"
TOL_DEG = 0.03
base = paper_scenario("1").replace(controller={"torque_limit": math.inf})
if FAST:
    base = base.replace(simulation={"t_final": 10.0, "dt": 0.002, "output_interval": 0.02})
schedule = base.topology.links[0].k_j
k_i = base.topology.links[0].k_i


def with_delta(s, value):
    return s.replace(controller={"delta": value})  # every axis of every agent (eq 18)


def with_disturbance_scale(s, factor):
    return s.with_agents(
        [dataclasses.replace(a, disturbance=dataclasses.replace(
            a.disturbance, amplitude=tuple(factor * x for x in a.disturbance.amplitude))) for a in s.agents]
    )  # fmt: skip


def with_inertia_uncertainty(s, scale):
    return s.with_agents(
        [dataclasses.replace(a, delta_J=tuple(tuple(scale * x for x in row) for row in a.J0)) for a in s.agents]
    )


def with_neighbours(s, k):
    return s.with_topology(k_nearest(s.n_agents, k, k_i, schedule))


def metrics(s):
    r = simulate(s, progress=False)
    t = r.time
    summ = r.summary(tolerances_deg=(TOL_DEG,), steady_window=0.4 * float(t[-1]))
    return summ["aaem_steady_max_deg"], summ["aaem_settling_s"][f"{TOL_DEG:g}"]


def heat_maps(title, xname, xs, yname, ys, build):
    acc = np.full((len(ys), len(xs)), np.nan)
    settle = np.full((len(ys), len(xs)), np.nan)
    for a, x in enumerate(xs):
        for b, y in enumerate(ys):
            acc[b, a], settle[b, a] = metrics(build(x, y))
    fig = Figure(figsize=(10, 3.8), layout="constrained")
    axes = fig.subplots(1, 2)
    panels = ((np.log10(np.maximum(acc, 1e-12)), "log10 steady-state AAEM (deg)"),
              (settle, f"AAEM settling to {TOL_DEG} deg (s; blank = not settled)"))  # fmt: skip
    for ax, (data, label) in zip(axes, panels, strict=True):
        im = ax.imshow(data, origin="lower", aspect="auto")
        fig.colorbar(im, ax=ax)
        ax.set_xticks(range(len(xs)), [f"{x:g}" for x in xs])
        ax.set_yticks(range(len(ys)), [f"{y:g}" for y in ys])
        ax.set_xlabel(xname)
        ax.set_ylabel(yname)
        ax.set_title(label, fontsize=9)
        for b in range(len(ys)):
            for a in range(len(xs)):
                v = data[b, a]
                ax.text(
                    a, b, "-" if not np.isfinite(v) else f"{v:.2g}", ha="center", va="center", fontsize=7, color="w"
                )
    fig.suptitle(title)
    return fig, acc, settle


# %% [markdown]
# ## $\alpha$ and $\delta$

# %%
alphas = [0.55, 0.9] if FAST else [0.55, 0.65, 0.7, 0.8, 0.9, 0.97]
deltas = [0.002, 0.02] if FAST else [0.001, 0.002, 0.005, 0.01, 0.02, 0.05]
fig, acc, settle = heat_maps(r"$\alpha$ vs $\delta$", "alpha", alphas, "delta (1/s^2)", deltas,
                             lambda a, d: with_delta(base.replace(controller={"alpha": a}), d))  # fmt: skip
fig

# %% [markdown]
# ## Boundary layer $\phi$ and disturbance amplitude

# %%
layers = [0.0, 0.01] if FAST else [0.0, 1e-4, 1e-3, 1e-2, 1e-1]
dist = [0.5, 4.0] if FAST else [0.0, 0.5, 1.0, 2.0, 4.0]
fig, acc, settle = heat_maps("boundary layer vs disturbance", "boundary layer phi", layers, "disturbance x", dist,
                             lambda p, f: with_disturbance_scale(base.replace(controller={"boundary_layer": p}), f))  # fmt: skip
fig

# %% [markdown]
# ## Inertia uncertainty $\Delta J = s J_0$ and topology density

# %%
scales = [0.0, 0.5] if FAST else [-0.3, 0.0, 0.3, 0.6, 1.0]
neighbours = [1, 5] if FAST else [1, 2, 3, 4, 5]
fig, acc, settle = heat_maps(r"$\Delta J$ scale vs neighbours", "delta_J / J0", scales, "neighbours k", neighbours,
                             lambda s, k: with_neighbours(with_inertia_uncertainty(base, s), k))  # fmt: skip
fig
