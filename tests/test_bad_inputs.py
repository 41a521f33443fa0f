"""Bad inputs, table-driven: every way in (CLI, scenario files, the Python API, the plug-in) gets the same answer.

Each row names an input and its expected outcome: an exit code with a one-line message and no traceback
(CLI), a :class:`~fsmctl.model.scenario.ScenarioError` / :class:`~fsmctl.errors.InputError` whose one-line
message matches a pattern (Python API, files), or a correct result (normalised values run the model that
was asked for).  Faults of the environment that need their own processes (cache damage, signals, a fake
Dask endpoint) are in ``test_cache_faults.py``, ``test_montecarlo_faults.py`` and
``test_memory_and_numerics.py``; a few whole-process cases (non-UTF-8 files, a full device, the console
script) are at the end of this file.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import fsmctl
from fsmctl.cli.main import main
from fsmctl.errors import InputError
from fsmctl.model.problem import pack
from fsmctl.model.scenario import ScenarioError, load_scenario
from fsmctl.model.topology import Link, Schedule, Topology, ring

PAPER_TOML = (Path(fsmctl.__file__).parent / "scenarios" / "paper.toml").read_text()
PAPER = fsmctl.paper_scenario("1")
SHORT = {"t_final": 0.02, "output_interval": 0.01}


def one_line(message: str) -> None:
    assert "\n" not in message.strip(), message
    assert "Traceback" not in message, message
    assert len(message) < 500, message


# ----------------------------------------------------------------------------- Python API: rejected values
# (section, values, pattern of the message): replace() must raise ScenarioError naming section.key

API_REJECTED = [
    ("alpha-1", {"controller": {"alpha": 1.0}}, r"controller\.alpha: must be < 1"),
    ("alpha-half", {"controller": {"alpha": 0.5}}, r"controller\.alpha: must be > 0\.5"),
    ("alpha-bool", {"controller": {"alpha": True}}, r"controller\.alpha: expected a number, got True"),
    ("alpha-str", {"controller": {"alpha": "0.7"}}, r"controller\.alpha: expected a number, got '0\.7'"),
    ("c1-nan", {"controller": {"c1": math.nan}}, r"controller\.c1: must be finite"),
    ("c1-inf", {"controller": {"c1": math.inf}}, r"controller\.c1: must be finite"),
    ("c1-negative", {"controller": {"c1": -0.1}}, r"controller\.c1: must be >= 0, got -0\.1"),
    ("delta-size", {"controller": {"delta": [0.1, 0.1]}}, r"controller\.delta: expected 3 numbers, got 2"),
    ("agent-delta-zero", {"agents": [{"delta": [0.0, 0.005, 0.005]}] + [{}] * 5}, r"agents\[1\]\.delta: must be > 0"),
    ("agent-changes-count", {"agents": [{"delta": 0.1}]}, r"agents: 1 mappings of changes for 6 agents"),
    ("pid-key-on-fsm", {"controller": {"K": 2.0}}, r"controller\.K: unknown key: the law 'fsm' has no parameter 'K'"),
    ("c2-negative", {"controller": {"c2": -0.8}}, r"controller\.c2: must be >= 0"),
    ("phi-negative", {"controller": {"boundary_layer": -1e-3}}, r"controller\.boundary_layer: must be >= 0"),
    ("phi-inf", {"controller": {"boundary_layer": math.inf}}, r"controller\.boundary_layer: must be finite"),
    ("epsilon-zero", {"controller": {"epsilon": 0.0}}, r"controller\.epsilon: must be > 0"),
    ("torque-zero", {"controller": {"torque_limit": 0.0}}, r"controller\.torque_limit: must be > 0"),
    ("torque-nan", {"controller": {"torque_limit": math.nan}}, r"controller\.torque_limit"),
    ("torque-bool", {"controller": {"torque_limit": False}}, r"controller\.torque_limit: expected a number"),
    ("torque-word", {"controller": {"torque_limit": "lots"}}, r"controller\.torque_limit: expected a number"),
    ("fix-unknown", {"controller": {"singularity_fix": "smooth"}}, r"controller\.singularity_fix: must be one of"),
    ("model-unknown", {"controller": {"error_model": "approx"}}, r"controller\.error_model: must be one of"),
    ("surface-unknown", {"controller": {"surface": "nsm"}}, r"controller\.surface: must be one of"),
    ("surface-int", {"controller": {"surface": 1}}, r"controller\.surface: must be one of"),
    ("enabled-int", {"controller": {"enabled": 1}}, r"controller\.enabled: expected true or false"),
    ("enabled-str", {"controller": {"enabled": "yes"}}, r"controller\.enabled: expected true or false"),
    ("unknown-key", {"controller": {"gain": 1.0}}, r"controller\.gain: unknown key"),
    ("integrator-unknown", {"simulation": {"integrator": "euler"}}, r"simulation\.integrator: must be one of"),
    ("dt-zero", {"simulation": {"dt": 0.0}}, r"simulation\.dt: must be > 0"),
    ("dt-bool", {"simulation": {"dt": True}}, r"simulation\.dt: expected a number"),
    ("tfinal-inf", {"simulation": {"t_final": math.inf}}, r"simulation\.t_final: must be finite"),
    ("tfinal-str", {"simulation": {"t_final": "10"}}, r"simulation\.t_final: expected a number"),
    ("tfinal-not-multiple", {"simulation": {"t_final": 10.005}}, r"multiple of output_interval"),
    (
        "interval-not-dividing",
        {"simulation": {"t_final": 1.0, "output_interval": 0.3}},
        r"t_final = 1\.0 must be a multiple of output_interval = 0\.3",
    ),
    (
        "interval-beyond-horizon",
        {"simulation": {"t_final": 1.0, "output_interval": 2.0}},
        r"multiple of output_interval = 2\.0",
    ),
    (
        "interval-not-dt",
        {"simulation": {"output_interval": 0.0105}},
        r"output_interval = 0\.0105 must be a multiple of dt",
    ),
    ("control-period-negative", {"simulation": {"control_period": -1.0}}, r"simulation\.control_period: must be >= 0"),
    (
        "control-period-off-grid",
        {"simulation": {"control_period": 0.0015}},
        r"control_period = 0\.0015 must be a multiple",
    ),
    ("rtol-nan", {"simulation": {"rtol": math.nan}}, r"simulation\.rtol: must be finite"),
    (
        "ref-sigma-bool",
        {"reference": {"sigma0": [True, 0.0, 0.0]}},
        r"reference\.sigma0: expected 3 numbers, got the element True",
    ),
    ("ref-sigma-str", {"reference": {"sigma0": ["0.1", 0.0, 0.0]}}, r"reference\.sigma0: expected 3 numbers"),
    (
        "ref-sigma-short",
        {"reference": {"sigma0": [0.1, 0.0]}},
        r"reference\.sigma0: expected 3 numbers, got shape \(2,\)",
    ),
    ("ref-sigma-nan", {"reference": {"sigma0": [math.nan, 0.0, 0.0]}}, r"reference\.sigma0: values must be finite"),
    ("section-unknown", {"plant": {}}, r"cannot replace \['plant'\]"),
    ("section-not-mapping", {"controller": [("c1", 1.0)]}, r"replace\(controller=\.\.\.\): expected a mapping"),
    ("agents-not-sequence", {"agents": {}}, r"agents: expected a sequence of Agent"),
    ("agents-empty", {"agents": ()}, r"at least one agent"),
    ("agents-count-vs-topology", {"agents": PAPER.agents[:2]}, r"topology: describes 6 agents but the scenario has 2"),
    ("topology-not-topology", {"topology": "ring"}, r"topology: expected a fsmctl\.model\.topology\.Topology"),
]


@pytest.mark.parametrize(("changes", "pattern"), [pytest.param(c, p, id=i) for i, c, p in API_REJECTED])
def test_python_api_rejects_with_one_line(changes, pattern):
    with pytest.raises(ScenarioError) as info:
        PAPER.replace(**changes)
    one_line(str(info.value))
    assert re.search(pattern, str(info.value)), str(info.value)


# ----------------------------------------------------------------------------- Python API: normalised values run
# what was asked for (defect: "DOPRI45" ran RK4, "TSM" ran FSM, "EXACT" ran the paper model, "NONE" raised KeyError)


def _param(packed, name: str):
    """Every agent's packed value of the law parameter ``name`` (the index of a choice), ``(n,)`` or ``(n, size)``."""
    k = 0
    for q in packed.law.parameters:
        if q.name == name:
            return packed.params[:, k] if q.size == 1 else packed.params[:, k : k + q.size]
        k += q.size
    raise KeyError(name)


NORMALISED = [
    (
        "integrator-upper",
        {"simulation": {"integrator": "DOPRI45"}},
        lambda s, p: s.simulation.integrator == "dopri45" and p.integrator == 1,
    ),
    (
        "surface-upper",
        {"controller": {"surface": "TSM"}},
        lambda s, p: s.controller.parameters["surface"] == "tsm" and _param(p, "c1")[0] == 0.0,
    ),
    (
        "surface-lsm-mixed",
        {"controller": {"surface": "Lsm"}},
        lambda s, p: s.controller.parameters["surface"] == "lsm" and _param(p, "c2")[0] == 0.0,
    ),
    (
        "error-model-upper",
        {"controller": {"error_model": "EXACT"}},
        lambda s, p: s.controller.error_model == "exact" and p.error_model == 1,
    ),
    (
        "fix-upper",
        {"controller": {"singularity_fix": "NONE"}},
        lambda s, p: s.controller.parameters["singularity_fix"] == "none" and _param(p, "singularity_fix")[0] == 0,
    ),
    ("fix-clamp", {"controller": {"singularity_fix": "Clamp"}}, lambda s, p: _param(p, "singularity_fix")[0] == 2),
    (
        "torque-inf-word",
        {"controller": {"torque_limit": "INF"}},
        lambda s, p: math.isinf(s.controller.torque_limit) and np.isinf(p.u_max).all(),
    ),
    (
        "numpy-scalars",
        {"controller": {"c1": np.float32(0.5), "c2": np.int64(1)}},
        lambda s, p: s.controller.parameters["c1"] == 0.5 and type(s.controller.parameters["c2"]) is float,
    ),
    (
        "numpy-vector",
        {"reference": {"sigma0": np.array([0.1, 0.2, 0.3])}},
        lambda s, p: s.reference.sigma0 == (0.1, 0.2, 0.3) and np.allclose(p.x0[:3], [0.1, 0.2, 0.3]),
    ),
]


@pytest.mark.parametrize(("changes", "check"), [pytest.param(c, k, id=i) for i, c, k in NORMALISED])
def test_python_api_normalises_and_runs_what_was_asked(changes, check):
    s = PAPER.replace(**changes)
    assert check(s, pack(s))
    # the label printed with results is the normalised value, not the spelling that was passed
    labels = (s.simulation.integrator, s.controller.parameters["surface"], s.controller.error_model)
    assert all(v.lower() == v for v in labels)


def test_upper_case_spellings_run_the_same_model_as_lower_case():
    """The defect ran RK4 for "DOPRI45" and the paper model for "EXACT": results must equal the lower-case runs."""
    base = PAPER.replace(simulation={"t_final": 0.05, "dt": 0.001, "output_interval": 0.01})
    for section, key, upper in (("simulation", "integrator", "DOPRI45"), ("controller", "error_model", "EXACT")):
        a = fsmctl.simulate(base.replace(**{section: {key: upper}}))
        b = fsmctl.simulate(base.replace(**{section: {key: upper.lower()}}))
        default = fsmctl.simulate(base)
        assert np.array_equal(a.sigma, b.sigma) and np.array_equal(a.omega, b.omega)
        assert not np.array_equal(a.omega, default.omega)  # and it is not the default model


# ----------------------------------------------------------------------------- dataclass constructors and copies


CONSTRUCTORS = [
    ("sinusoid-inf", lambda: fsmctl.Sinusoid(amplitude=(math.inf, 0.0, 0.0)), r"amplitude: values must be finite"),
    ("sinusoid-nan-phase", lambda: fsmctl.Sinusoid(phase=(0.0, math.nan, 0.0)), r"phase: values must be finite"),
    ("sinusoid-bool", lambda: fsmctl.Sinusoid(frequency=(True, 0.0, 0.0)), r"frequency: expected 3 numbers"),
    ("sinusoid-unknown", lambda: fsmctl.Sinusoid(kind=("sin", "sin", "sin")), r"kind: unknown key"),
    (
        "agent-not-spd",
        lambda: dataclasses.replace(PAPER.agents[0], J0=((1.0, 0, 0), (0, 1.0, 0), (0, 0, -1.0))),
        r"J0: not positive definite",
    ),
    (
        "agent-asymmetric",
        lambda: dataclasses.replace(PAPER.agents[0], J0=((1.0, 0.5, 0), (0, 1.0, 0), (0, 0, 1.0))),
        r"J0: not symmetric",
    ),
    (
        "agent-perturbed-not-spd",
        lambda: dataclasses.replace(
            PAPER.agents[0], delta_J=tuple(tuple(-2 * x for x in r) for r in PAPER.agents[0].J0)
        ),
        r"J0 \+ delta_J: not positive definite",
    ),
    (
        "agent-parameter-bool",
        lambda: dataclasses.replace(PAPER.agents[0], parameters={"delta": (True, 0.005, 0.005)}),
        r"delta: a vector parameter holds numbers",
    ),
    (
        "agent-J-nan",
        lambda: dataclasses.replace(PAPER.agents[0], J0=((math.nan, 0, 0), (0, 1.0, 0), (0, 0, 1.0))),
        r"J0: values must be finite",
    ),
    (
        "agent-J-ragged",
        lambda: dataclasses.replace(PAPER.agents[0], J0=((1.0, 0), (0, 1.0, 0), (0, 0, 1.0))),
        r"J0: expected a 3x3 matrix",
    ),
    (
        "agent-J-strings",
        lambda: dataclasses.replace(PAPER.agents[0], J0=np.array([["1", "0", "0"]] * 3)),
        r"J0: expected a 3x3 matrix, got an array of dtype",
    ),
    (
        "controller-direct",
        lambda: fsmctl.ControllerSettings(parameters={"c1": 0.6, "c2": 0.8, "alpha": 1.5}),
        r"^alpha: must be < 1",
    ),
    (
        "controller-direct-unknown",
        lambda: fsmctl.ControllerSettings(law="pid", parameters={"alpha": 0.7}),
        r"^alpha: unknown key: the law 'pid' has no parameter 'alpha'",
    ),
    (
        "simulation-direct",
        lambda: fsmctl.SimulationSettings(t_final=1.0, output_interval=0.3),
        r"multiple of output_interval",
    ),
    (
        "scenario-replace-dataclasses",
        lambda: dataclasses.replace(PAPER, agents=PAPER.agents[:3]),
        r"topology: describes 6 agents",
    ),
    ("topology-self-link", lambda: Topology(2, (Link(0, 0, 1.0, Schedule.constant(1.0)),)), r"cannot link to itself"),
    (
        "topology-string-index",
        lambda: Topology(2, (Link(0, "1", 1.0, Schedule.constant(1.0)),)),
        r"receiver and sender must be integers",
    ),
    ("schedule-bool", lambda: Schedule((0.0,), (True,)), r"schedule: expected a number, got True"),
    ("schedule-negative", lambda: Schedule((0.0,), (-1.0,)), r"weights must be finite and >= 0"),
]


@pytest.mark.parametrize(("build", "pattern"), [pytest.param(b, p, id=i) for i, b, p in CONSTRUCTORS])
def test_constructors_and_copies_validate(build, pattern):
    with pytest.raises(InputError) as info:
        build()
    one_line(str(info.value))
    assert re.search(pattern, str(info.value)), str(info.value)


def test_with_agents_and_with_topology_validate_together():
    two = PAPER.replace(agents=PAPER.agents[:2], topology=ring(2, 8.0, 5.0))
    assert two.n_agents == 2 and two.topology.n_agents == 2
    with pytest.raises(ScenarioError, match="topology: describes 2 agents"):
        PAPER.with_topology(ring(2, 8.0, 5.0))


# ----------------------------------------------------------------------------- scenario files


def edited(old: str, new: str) -> str:
    assert old in PAPER_TOML, old
    return PAPER_TOML.replace(old, new, 1)


FILES = [
    (
        "array-bool",
        edited("sigma0 = [0.3, 0.2, -0.3]", "sigma0 = [true, 0.2, -0.3]"),
        r"agents\[1\]\.sigma0: expected 3 numbers, got the element True",
    ),
    (
        "array-string",
        edited("sigma0 = [0.3, 0.2, -0.3]", 'sigma0 = ["0.3", 0.2, -0.3]'),
        r"agents\[1\]\.sigma0: expected 3 numbers",
    ),
    (
        "matrix-string",
        edited("J0 = [[100.0, 1.0, 2.0]", 'J0 = [["100", 1.0, 2.0]'),
        r"agents\[1\]\.J0: expected a 3x3 matrix",
    ),
    ("scalar-string", edited("c1 = 0.6 ", 'c1 = "0.6" '), r"controller\.c1: expected a number, got '0\.6'"),
    ("scalar-bool", edited("c2 = 0.8 ", "c2 = true "), r"controller\.c2: expected a number, got True"),
    ("nan-gain", edited("c1 = 0.6 ", "c1 = nan "), r"controller\.c1: must be finite"),
    ("inf-step", edited("dt = 0.001 ", "dt = inf "), r"simulation\.dt: must be finite"),
    ("enum-upper-ok", None, None),  # placeholder replaced below: an accepted, normalised file
    (
        "interval-not-dividing",
        edited("output_interval = 0.01 ", "output_interval = 0.03 "),
        r"must be a multiple of output_interval = 0\.03",
    ),
    (
        "interval-exceeds-horizon",
        edited("output_interval = 0.01 ", "output_interval = 200.0 "),
        r"multiple of output_interval = 200\.0",
    ),
    ("unknown-section", PAPER_TOML + "\n[plant]\nmass = 1.0\n", r"unknown key\(s\) \['plant'\]"),
    (
        "unknown-agent-key",
        edited("omega0 = [0.35, -0.13, 0.27]", "omega0 = [0.35, -0.13, 0.27]\nmass = 3.0"),
        r"agents\[1\]\.mass: unknown key: the law 'fsm' has no parameter 'mass'",
    ),
    (
        "disturbance-kind",
        edited('kind = ["cos", "sin", "cos"] }\n\n[[agents]]', 'kind = ["cos", "tan", "cos"] }\n\n[[agents]]'),
        r"disturbance\.kind\[1\]: must be 'cos' or 'sin'",
    ),
    (
        "delta-J-scale-string",
        edited("delta_J = { scale = 0.3 }", 'delta_J = { scale = "0.3" }'),
        r"delta_J\.scale: expected a finite number",
    ),
    ("case-unknown-key", PAPER_TOML + '\n[cases."9"]\nplant = 1\n', None),  # only fails when case 9 is selected
    ("description-not-string", edited('name = "paper"', 'name = "paper"\n[choices]\n'), None),
]
FILES = [f for f in FILES if f[2] is not None]


@pytest.mark.parametrize(("text", "pattern"), [pytest.param(t, p, id=i) for i, t, p in FILES])
def test_scenario_file_errors_are_one_line_with_the_key(tmp_path, text, pattern):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    message = str(info.value)
    one_line(message)
    assert message.startswith(str(path)), message
    assert re.search(pattern, message), message


def test_scenario_file_option_strings_are_normalised(tmp_path):
    path = tmp_path / "upper.toml"
    path.write_text(
        edited('integrator = "rk4"', 'integrator = "RK4"').replace('error_model = "paper"', 'error_model = "Exact"')
    )
    s = load_scenario(path)
    assert (s.simulation.integrator, s.controller.error_model) == ("rk4", "exact")
    assert pack(s).error_model == 1


def test_file_and_python_api_give_the_same_rule(tmp_path):
    """One validation path: the same bad value, by file and by replace(), gets the same message (after the file name)."""
    path = tmp_path / "bad.toml"
    path.write_text(edited("alpha = 0.7 ", "alpha = 1.2 "))
    with pytest.raises(ScenarioError) as by_file:
        load_scenario(path)
    with pytest.raises(ScenarioError) as by_api:
        PAPER.replace(controller={"alpha": 1.2})
    assert str(by_file.value) == f"{path}: {by_api.value}"


# ----------------------------------------------------------------------------- command line (in process)


def run_cli(argv, capsys):
    code = main(argv)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


CLI = [
    ("simulate-missing-file", ["simulate", "--scenario", "no/such.toml"], 2, r"cannot read scenario file"),
    ("simulate-unknown-case", ["simulate", "--case", "7"], 2, r"no case '7'"),
    ("simulate-negative-dt", ["simulate", "--dt", "-1"], 2, r"simulation\.dt: must be > 0"),
    ("simulate-zero-tfinal", ["simulate", "--t-final", "0"], 2, r"simulation\.t_final: must be > 0"),
    ("simulate-nan-tfinal", ["simulate", "--t-final", "nan"], 2, r"argument --t-final: expected a finite number"),
    ("simulate-word-integrator", ["simulate", "--integrator", "euler"], 2, r"invalid choice"),
    (
        "simulate-grid-off",
        ["simulate", "--t-final", "0.015", "--output-interval", "0.01"],
        2,
        r"multiple of output_interval",
    ),
    ("simulate-torque-zero", ["simulate", "--torque-limit", "0"], 2, r"must be > 0"),
    (
        "simulate-out-under-file",
        ["simulate", "--t-final", "0.01", "--out", "/dev/null/x"],
        2,
        r"cannot write to output folder /dev/null/x",
    ),
    ("prove-unknown-claim", ["prove", "no-such-claim"], 2, r"unknown claim id"),
    ("prove-bad-region", ["prove", "--region-sigma", "2"], 2, r"region-sigma must be <= 1"),
    ("reproduce-no-jobs", ["reproduce", "--jobs", "2"], 2, r"^fsmctl reproduce: unknown option --jobs$"),
    ("reproduce-workers-zero", ["reproduce", "--workers", "0"], 2, r"argument --workers: must be >= 1"),
    ("prove-negative-seed", ["prove", "--seed", "-1"], 2, r"argument --seed: must be >= 0"),
    (
        "simulate-from-and-case",
        ["simulate", "--from", "r.nc", "--case", "2"],
        2,
        r"--from cannot be combined with --case",
    ),
    ("surfaces-bad-scenario", ["compare-surfaces", "--scenario", "no/such.toml"], 2, r"cannot read scenario file"),
    (
        "montecarlo-missing-file",
        ["montecarlo", "--scenario", "no/such.toml", "--runs", "1"],
        2,
        r"cannot read scenario file",
    ),
    ("unknown-command", ["fly"], 2, r"^fsmctl: unknown command 'fly'$"),
]


@pytest.mark.parametrize(("argv", "code", "pattern"), [pytest.param(a, c, p, id=i) for i, a, c, p in CLI])
def test_cli_input_errors_exit_2_with_one_line(argv, code, pattern, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    try:
        got = main(argv)
    except SystemExit as exc:  # argparse errors exit directly
        got = exc.code
    err = capsys.readouterr().err
    assert got == code, err
    one_line(err)
    assert re.search(pattern, err), err


def test_failed_run_leaves_no_empty_output_folder(tmp_path, capsys):
    out = tmp_path / "new" / "deeper"
    code = main(["simulate", "--t-final", "0.015", "--output-interval", "0.01", "--out", str(out)])
    assert code == 2
    assert not (tmp_path / "new").exists()


def test_simulate_ends_at_t_final_and_summary_is_strict_json(tmp_path, capsys):
    import json

    import xarray as xr

    out = tmp_path / "run"
    code = main(["simulate", "--t-final", "0.05", "--output-interval", "0.01", "--out", str(out), "--no-figures"])
    assert code == 0, capsys.readouterr().err
    text = (out / "summary.json").read_text()
    json.loads(text, parse_constant=lambda c: pytest.fail(f"non-JSON constant {c} in summary.json"))
    with xr.open_dataset(next(out.glob("*.nc"))) as ds:
        assert float(ds["time_s"][-1]) == pytest.approx(0.05, abs=1e-12)
    assert not list(out.glob(".*tmp*")), "temporary files left behind"


# ----------------------------------------------------------------------------- whole processes


def fsmctl_process(*args, **kw):
    env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    return subprocess.run(
        [sys.executable, "-m", "fsmctl", *args], capture_output=True, text=True, env=env, timeout=300, **kw
    )


def test_non_utf8_scenario_file_is_one_line(tmp_path):
    path = tmp_path / "latin1.toml"
    path.write_bytes(PAPER_TOML.replace("# Liang", "# Liang \u00e9", 1).encode("latin-1"))
    r = fsmctl_process("simulate", "--scenario", str(path), "--out", str(tmp_path / "o"))
    assert r.returncode == 2
    one_line(r.stderr)
    assert "not UTF-8" in r.stderr


def test_output_on_the_full_device_is_exit_2(tmp_path):
    """Linux's /dev/full accepts opens and fails every write with ENOSPC."""
    if not Path("/dev/full").exists():
        pytest.skip("no /dev/full on this system")
    r = fsmctl_process("prove", "lemma1-settling-time", "--report", "/dev/full")
    assert r.returncode == 2, r.stderr
    one_line(r.stderr)
    assert "No space left on device" in r.stderr
    assert Path("/dev/full").is_char_device()  # written in place, never replaced by a rename
    r = subprocess.run(
        [sys.executable, "-m", "fsmctl", "prove", "--list"],
        stdout=open("/dev/full", "w"),
        stderr=subprocess.PIPE,
        text=True,
    )
    assert r.returncode == 2
    one_line(r.stderr)


def test_debug_switch_shows_the_traceback(tmp_path):
    r = fsmctl_process("--debug", "simulate", "--scenario", str(tmp_path / "none.toml"))
    assert r.returncode != 0 and "Traceback" in r.stderr
    r = fsmctl_process("simulate", "--scenario", str(tmp_path / "none.toml"))
    assert r.returncode == 2 and "Traceback" not in r.stderr


def test_library_helpers_refuse_bad_input_with_input_error(tmp_path):
    """The library's own checks raise InputError (a ValueError), which the CLI turns into one line and exit 2."""
    from fsmctl.model.actuators import distribution_matrix
    from fsmctl.studies.explain import explain
    from fsmctl.studies.hardware import momentum_budget

    with pytest.raises(InputError, match="3 x N matrix of rank 3"):
        distribution_matrix(np.ones((3, 4)))  # rank 1: the wheels do not span the body frame
    with pytest.raises(InputError, match="no reaction wheels"):
        momentum_budget(fsmctl.paper_scenario("1"))
    with pytest.raises(InputError, match="unknown setting"):
        explain("paper", [], tmp_path / "x", settings=["no_such_setting"])


def test_workers_is_the_one_keyword_and_is_checked(tmp_path):
    """``workers=`` is the only spelling (0.x, issue 26: no ``jobs=`` shim) and a bad value is an InputError."""
    from fsmctl.proofs import ProofContext, run_claims
    from fsmctl.studies import compare_surfaces
    from fsmctl.studies.reproduce import reproduce

    ctx = ProofContext(fsmctl.paper_scenario("1"), n_random=10)
    with pytest.raises(TypeError, match="unexpected keyword argument 'jobs'"):
        run_claims(["lemma2-sqrt-sum"], ctx, jobs=1)
    with pytest.raises(InputError, match="workers must be"):
        compare_surfaces(fsmctl.paper_scenario("1"), workers=0)
    with pytest.raises(InputError, match="workers must be a whole number >= 1"):
        reproduce("paper", tmp_path / "r", workers=0)
    assert not (tmp_path / "r").exists()


def test_output_files_get_the_usual_permissions(tmp_path):
    """Files written atomically (through a private temporary file) end with the mode ``open`` would give them:
    readable by the group and others under the usual umask 022, not 0600."""
    import os

    from fsmctl.outputs import write_text

    old = os.umask(0o022)
    try:
        path = write_text(tmp_path / "a.txt", "x")
    finally:
        os.umask(old)
    assert path.stat().st_mode & 0o777 == 0o644
