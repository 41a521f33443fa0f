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
# # 02 — Proof check of Section 3 (Liang, Sun & Wang 2012)
#
# The claims of Section 3 (Lemmas 1-2, eqs 13-41, Theorems 1-3, Remarks) are checked by
# `fsmctl prove`; this notebook calls the same Python API (`fsmctl.proofs`).  Verdicts:
# *proved* (symbolic), *numeric* (sampling only), *erratum* (the printed statement is false; the
# corrected one is checked), *fails for this scenario*.  Then Theorem 1's feasibility region
# (the $\eta$ interval over $(k^i, k^j)$, eq 27) and what a user changes to make an infeasible
# topology feasible.

# %%
# %matplotlib inline
import os

import numpy as np
from IPython.display import Markdown, display
from matplotlib.figure import Figure

from fsmctl import paper_scenario
from fsmctl.proofs import ProofContext, claim_ids, run_claims
from fsmctl.proofs.report import format_table
from fsmctl.proofs.theorem1 import analyze_topology, eta_interval

FAST = os.environ.get("FSMCTL_FAST") == "1"
scenario = paper_scenario("1")

# %% [markdown]
# ## `fsmctl prove` on the paper's Case 1
# In fast mode only the cheap claims run (the full list: `fsmctl prove --list`).

# %%
CHEAP = [
    "lemma1-settling-time", "lemma2-sqrt-sum", "zero-sum", "complete-square", "theorem1-gains",
    "theorem3-closed-forms", "theorem3-fsm-vs-lsm", "theorem3-fsm-vs-tsm",
]  # fmt: skip
ids = CHEAP if FAST else None
results = run_claims(ids, ProofContext(scenario, n_random=300 if FAST else 3000), workers=1 if FAST else 2)
print(format_table(results, scenario))
assert set(r.id for r in results) <= set(claim_ids())

# %%
for r in results:
    if r.latex:
        display(Markdown(f"**{r.id}** ({r.verdict}): $${r.latex}$$"))

# %% [markdown]
# ## Theorem 1: feasible $\eta$ for one ordered pair (eq 27)
# $\gamma_{ij} = \eta_{ij} - (k^j_{ij})^2 / (4(k^i_{ij} - \eta_{ij})) \ge 0$ holds for $\eta$ in an interval that is
# non-empty iff $k^i \ge k^j$.  Left: the lowest feasible $\eta$; right: the width of the interval
# (white: infeasible).  The paper's Case 1 pair $(k^i, k^j) = (8, 5)$ is marked.

# %%
n = 60 if FAST else 200
ki = np.linspace(0.0, 10.0, n)
kj = np.linspace(0.0, 10.0, n)
low = np.full((n, n), np.nan)
width = np.full((n, n), np.nan)
for a, k_i in enumerate(ki):
    for b, k_j in enumerate(kj):
        iv = eta_interval(float(k_i), float(k_j))
        if iv is not None:
            low[b, a], width[b, a] = iv[0], iv[1] - iv[0]
fig = Figure(figsize=(10, 4), layout="constrained")
axes = fig.subplots(1, 2)
for ax, data, title in ((axes[0], low, r"lowest feasible $\eta$"), (axes[1], width, r"width of the $\eta$ interval")):
    im = ax.pcolormesh(ki, kj, data, shading="auto")
    fig.colorbar(im, ax=ax)
    ax.plot([0, 10], [0, 10], "k--", lw=0.8, label=r"$k^j = k^i$")
    ax.plot([8], [5], "r*", ms=12, label="paper Case 1")
    ax.set_xlabel(r"$k^i_{ij}$")
    ax.set_ylabel(r"$k^j_{ij}$")
    ax.set_title(title)
axes[0].legend(loc="upper left", fontsize=8)
fig

# %% [markdown]
# ## The paper's topology, and an infeasible one
# Case 1 ($k^i = 8$, $k^j$ switching between 5 and 0) satisfies Theorem 1.  With $k^i = 4$ the
# same switching $k^j = 5$ violates it; the analysis says which pairs fail, when, and the
# smallest single-parameter change that restores feasibility.

# %%
ok = analyze_topology(scenario.topology, scenario.simulation.t_final)
print(f"Case 1: holds = {ok.holds}, min_t lambda_min(sym L(t)) = {ok.lambda_min:.4g}")
bad = analyze_topology(scenario.topology.scaled(k_i=4.0), scenario.simulation.t_final)
print(f"k^i = 4: holds = {bad.holds}, min_t lambda_min(sym L(t)) = {bad.lambda_min:.4g}")
for p in [p for p in bad.pairs if p.fixes][:3]:
    print(f"pair {p.label}: {p.reason}\n  when: {p.when}\n  fixes: {' | '.join(p.fixes)}")

# %%
fixed = analyze_topology(scenario.topology.scaled(k_i=5.0), scenario.simulation.t_final)
lowered = analyze_topology(scenario.topology.scaled(k_i=4.0, k_j_on=4.0), scenario.simulation.t_final)
print(f"raise k^i to 5: holds = {fixed.holds}; lower k^j to 4 (k^i = 4): holds = {lowered.holds}")
assert ok.holds and not bad.holds and fixed.holds and lowered.holds
