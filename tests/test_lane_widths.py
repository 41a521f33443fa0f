"""The lane width (``FSM_LANES`` = 4 or 8 agents per call of the batched kernels) changes the speed, never a result.

Each width is its own build of the library (``FSMCTL_LANES``, :func:`fsmctl.model.generated_code.lane_width`), so
each flies in its own process, into its own cache folder: the paper's Case 1, a Monte Carlo batch of runs sharing
the lanes (7 runs x 6 agents: partial groups at both widths), every built-in law, and the flight-hardware scenario
with the law that commands its wheels and the event-triggered law.  Every recorded array of every run is hashed
bit for bit; the two widths must give the same hashes, and the same as this process's own build (whatever width
``auto`` chose here).  A width that computed one lane differently (another operation order, an FMA, a lane
mixed up with its neighbour) changes a hash.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from fsmctl.model.generated_code import c_compiler

SCRIPT = r"""
import hashlib, json, sys
import numpy as np
import fsmctl
from fsmctl.simulation.driver import lane_width
from fsmctl.studies.montecarlo import CampaignSettings, sample_run_scenario

def digest(result):
    h = hashlib.sha256()
    for name in sorted(vars(result)):
        value = getattr(result, name)
        if isinstance(value, np.ndarray) and value.dtype.kind in "fiub":
            h.update(name.encode()); h.update(np.ascontiguousarray(value).tobytes())
    return h.hexdigest()

out = {"width": lane_width()}
short = {"t_final": 1.5, "output_interval": 0.01}
case1 = fsmctl.paper_scenario("1").replace(simulation=short)
out["case1"] = digest(fsmctl.simulate(case1))
settings = CampaignSettings(runs=7, seed=31, t_final=1.0)
runs = [sample_run_scenario(case1, settings, q) for q in np.random.SeedSequence(31).spawn(7)]
out["montecarlo"] = [digest(r) for r in fsmctl.simulate_many(runs)]
for law in ("pid", "super_twisting", "adaptive_fsm"):
    out[law] = digest(fsmctl.simulate(case1.replace(controller={"law": law})))
hw = fsmctl.load_scenario("paper-hardware").replace(simulation={"t_final": 1.0})
for law in ("fsm_wheels", "fsm_event"):
    out["hardware-" + law] = digest(fsmctl.simulate(hw.replace(controller={"law": law})))
json.dump(out, sys.stdout)
"""


def _fly(tmp_path, width: str | None) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("FSMCTL_LANES", "FSMCTL_PORTABLE")}
    if width is not None:
        env["FSMCTL_LANES"] = width
        env["FSMCTL_CACHE_DIR"] = str(tmp_path / f"cache-{width}")  # a build per width, never mixed with others
    proc = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, env=env, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout)


@pytest.mark.skipif(c_compiler() is None, reason="no C compiler: there are no lanes")
def test_every_lane_width_flies_the_same_bits(tmp_path):
    own = _fly(tmp_path, None)
    results = {w: _fly(tmp_path, w) for w in ("4", "8")}
    assert {int(w): r.pop("width") for w, r in results.items()} == {4: 4, 8: 8}
    assert own.pop("width") in (4, 8)
    assert len(set(own["montecarlo"])) == 7  # the runs differ from each other: the hashes can tell
    for name, want in own.items():
        assert results["4"][name] == want, f"{name}: 4 lanes differ from this build"
        assert results["8"][name] == want, f"{name}: 8 lanes differ from this build"


def test_a_lane_width_the_engine_has_not_is_refused(monkeypatch):
    from fsmctl.errors import EnvironmentProblem
    from fsmctl.model.generated_code import lane_width

    monkeypatch.setenv("FSMCTL_LANES", "16")
    with pytest.raises(EnvironmentProblem, match=r"FSMCTL_LANES='16': the lane width must be 4 or 8"):
        lane_width("x86_64 -march=native -mavx512f")
    monkeypatch.setenv("FSMCTL_LANES", "8")
    assert lane_width("portable") == 8
    monkeypatch.delenv("FSMCTL_LANES")
    assert lane_width("x86_64 -march=icelake-server -mavx2 -mavx512f") == 8
    assert lane_width("x86_64 -march=znver3 -mavx2 -mno-avx512f") == 4
    assert lane_width("x86_64 -target-cpu znver4 -target-feature +avx2 -target-feature +avx512f") == 8
    assert lane_width("portable") == 4
