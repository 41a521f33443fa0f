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
# # 01 — Derivation of the model and the control law (Liang, Sun & Wang 2012)
#
# Everything below is produced by `derive/` (SymPy): the kinematics matrix $G$ (eq 5), the
# Lagrange-like model $M\ddot\sigma_e + C\dot\sigma_e + G^{-T}E = G^{-T}u$ (eq 9), the control law
# $u = -u^F - u^D - u^C$ (eqs 16-19) and the closed loop (eq 20).  The general $M$, $C$ have
# hundreds of terms; they are shown in full for a rotation about one body axis
# ($\sigma_e = (0, 0, \sigma_3)$, $J = \mathrm{diag}(J_1, J_2, J_3)$, $\omega_d = (0, 0, \omega_{d3})$),
# which is still the output of the same functions.  The paper's misprints found on the way are
# listed at the end, as printed next to the corrected form (`fsmctl.proofs.errata`, `generated/errata.json`).

# %%
import json
import os

import sympy as sp
from IPython.display import Markdown, display

from fsmctl.model.generated_code import generated_dir
from fsmctl.proofs.errata import all_errata
from fsmctl.symbolic import (
    SingularityFix,
    closed_loop_acceleration,
    lagrange_model,
    mrp_G,
    mrp_G_inverse,
    sliding_variable,
    vector_symbols,
)

FAST = os.environ.get("FSMCTL_FAST") == "1"


def show(label: str, expr) -> None:
    """Display ``label = expr`` as LaTeX."""
    display(Markdown(f"$${label} = {sp.latex(expr)}$$"))


# %% [markdown]
# ## Kinematics: $\dot\sigma = G(\sigma)\omega$ (eqs 3, 5)

# %%
sigma = vector_symbols("sigma")
G = mrp_G(sigma)
show(r"G(\sigma)", G)
show(r"G(\sigma)^{-1}", sp.simplify(mrp_G_inverse(sigma)))
assert sp.simplify(G * mrp_G_inverse(sigma) - sp.eye(3)) == sp.zeros(3, 3)

# %% [markdown]
# ## Lagrange-like model (eq 9), single-axis case
# $M = G^{-T} J G^{-1}$, $C$ with the term the paper dropped (see the errata), $E = J\dot\omega_d + \omega_d^\times J\omega_d$.

# %%
s3, sd3, wd3, wdd3 = sp.symbols(r"sigma_3 \dot{\sigma}_3 omega_d3 \dot{\omega}_d3", real=True)
J1, J2, J3 = sp.symbols("J_1 J_2 J_3", positive=True)
model = lagrange_model(
    sp.diag(J1, J2, J3),
    sp.Matrix([0, 0, s3]),
    sp.Matrix([0, 0, sd3]),
    sp.Matrix([0, 0, wd3]),
    sp.Matrix([0, 0, wdd3]),
    require_positive_definite=False,
)
show("M", sp.simplify(model.M))
show("C", model.C.applyfunc(lambda e: sp.factor(sp.simplify(e))))
show("E", sp.simplify(model.E))

# %% [markdown]
# ## Sliding surface (eq 13) and closed loop (eq 20)
# $s = \dot\sigma_e + c_1\sigma_e + c_2\,\mathrm{sig}(\sigma_e)^\alpha$; with $u$ of eqs 16-19 the loop becomes eq 20
# (shown as printed: no Remark 6 fix, $\mathrm{sgn}$ switching).

# %%
se, sed, s_vec, coord = (vector_symbols(n) for n in ("sigma_e", r"\dot{\sigma}_e", "s", "c"))
c1, c2, alpha = sp.symbols("c_1 c_2 alpha", positive=True)
delta = sp.Matrix(sp.symbols("delta_1:4", positive=True))
show("s", sliding_variable(se, sed, c1, c2, alpha, fix=SingularityFix.NONE))
show(r"\ddot\sigma_e", closed_loop_acceleration(se, sed, s_vec, c1, c2, alpha, delta, coord, fix=SingularityFix.NONE))

# %% [markdown]
# ## Control torque $u = -u^F - u^D - u^C$ (eqs 16-19), single-axis case
# Built literally from $M$, $C$, $E$ (`fsmctl.symbolic.control_law_pieces`, i.e. `fsmctl.symbolic.controller`).

# %%
from fsmctl.symbolic import control_law_pieces

k = sp.Symbol("k_3", real=True)
pieces = control_law_pieces(
    model,
    sp.Matrix([0, 0, s3]),
    sp.Matrix([0, 0, sd3]),
    sp.Matrix([0, 0, sp.Symbol("s_3")]),
    c1,
    c2,
    alpha,
    delta,
    sp.Matrix([0, 0, k]),
    fix=SingularityFix.NONE,
)
show("u_3", sp.simplify(pieces.u[2]))

# %% [markdown]
# ## Errata: the paper as printed vs the correct form
# Each is refuted symbolically (counterexample or residual) and the correction is checked (`fsmctl.proofs.errata`;
# the re-audit of every printed equation of Sections 2-3 against the raw text: `fsmctl.proofs.seed_audit`,
# `docs/errata-audit.md`).

# %%
recorded = json.loads((generated_dir() / "errata.json").read_text())
found = all_errata() if not FAST else None  # the proofs' errata, then the re-audit's
for e in recorded:
    display(Markdown(f"**{e['id']}** (eq {e['equation']}) — checked: {e['checked']}"))
    display(Markdown(f"printed: $${e['as_printed_latex']}$$ correct: $${e['correct_latex']}$$"))
    display(Markdown(f"consequence: {e['consequence']}"))
if found is not None:
    assert {e.id for e in found} == {e["id"] for e in recorded}
    assert all(e.checked for e in found)
