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
# # 09 — Certify a law: a Lyapunov certificate, a counterexample flown, a re-check
#
# `fsmctl certify` ({doc}`../../guide/certify`) asks whether a Lyapunov function proves a law's closed loop stable
# at every point of a stated region, for every admissible uncertainty, and proves its answer with rigorous
# arithmetic.  This notebook certifies the documented PD example (`docs/examples/my_law.py`) with a 10 % inertia
# uncertainty, reads the certificate, re-checks it from its file, then refutes a deliberately unstable law
# (`docs/examples/pd_unstable.py`) and flies the agent from the counterexample.  `FSMCTL_FAST=1` (the tests and
# this site) keeps the same regions and a 30 s budget per candidate.

# %%
# %matplotlib inline
import json
import os
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

import fsmctl
from fsmctl.proofs import SearchSettings, StateRegion, Uncertainty, certify_law, check_certificate
from fsmctl.studies.certify_flight import fly_counterexample

ROOT = Path(fsmctl.__file__).resolve().parents[1]  # the repository checkout (the examples live in docs/examples/)
assert (ROOT / "docs" / "examples" / "my_law.py").is_file(), "run this notebook from a checkout of the repository"
os.chdir(ROOT)  # the example files by their paths relative to the repository
EXAMPLES = Path("docs") / "examples"
FAST = os.environ.get("FSMCTL_FAST") == "1"
settings = SearchSettings(max_seconds=30.0 if FAST else 60.0)
scenario = fsmctl.load_scenario(EXAMPLES / "my_law.toml")

# %% [markdown]
# ## 1. The PD example, with a 10 % inertia uncertainty
#
# The law declares $V = 2K\ln(1 + |\sigma|^2) + \tfrac12\omega^T J_0\omega$, whose derivative $-P|\omega|^2$ is only
# negative *semi*definite, and with an uncertain inertia not even that.  Certify tries it first, then the declared
# $V$ plus a cross term $\epsilon\,\sigma_e^T J_0 \omega_e$.

# %%
cert = certify_law(
    EXAMPLES / "my_law.py",
    scenario=scenario,
    region=StateRegion(0.05, 0.01),
    uncertainty=Uncertainty(inertia=0.1),
    settings=settings,
)
print("\n".join(cert.lines()))
assert cert.verdict == "certified" and cert.kind == "asymptotic"

# %% [markdown]
# ## 2. The certificate's file, and its re-check
#
# The JSON file holds the law (and the hash of its generated code), the agent, the region, the uncertainty, the
# exact $V$, the verdict with its levels, and the branch and bound's bisection tree.  The re-check rebuilds
# everything from the file alone.

# %%
with tempfile.TemporaryDirectory() as tmp:  # a folder of your own in practice: certify --out DIR
    folder = Path(tmp)
    cert.write(folder / "certificate.json", folder / "certificate.md")
    record = json.loads((folder / "certificate.json").read_text())
    print({k: record[k] for k in ("verdict", "kind", "headline")})
    print("level c =", record["outcome"]["level"], "; core:", record["outcome"]["core"]["fraction"], "x the region")
    check = check_certificate(folder / "certificate.json", arb_sample=8)
print("\n".join(check.lines))
assert check.ok

# %% [markdown]
# ## 3. A deliberately unstable law: the counterexample, flown
#
# `pd_unstable.py` applies the rate term with the wrong sign: $\dot V = +P|\omega|^2$.  Certify proves a point
# where $\dot V > 0$ (confirmed in ball arithmetic); the simulator flies the isolated agent from there.

# %%
unstable_scenario = scenario.with_law(str(EXAMPLES / "pd_unstable.py"))
refuted = certify_law(
    EXAMPLES / "pd_unstable.py",
    scenario=unstable_scenario,
    region=StateRegion(0.1, 0.02),
    uncertainty=Uncertainty(),
    settings=settings,
)
print(refuted.headline())
assert refuted.verdict == "counterexample"
flight = fly_counterexample(refuted, unstable_scenario, t_final=20.0)
print(flight.summary())
fig = flight.figure()
plt.show()
