"""Scenario files: the built-in paper scenario loads, and every kind of bad file gets a clear one-line error.

Each bad file is the shipped ``paper.toml`` with one edit, loaded through :func:`fsmctl.load_scenario` (and,
when the ``simulate`` subcommand is present, through the ``fsmctl`` command line: exit code 2, one line).
"""

from __future__ import annotations

import math
import re
from importlib import resources

import numpy as np
import pytest

import fsmctl
from fsmctl import ScenarioError, load_scenario

PAPER_TOML = resources.files("fsmctl").joinpath("scenarios", "paper.toml").read_text()

J1 = "J0 = [[100.0, 1.0, 2.0], [1.0, 150.0, 1.0], [2.0, 1.0, 200.0]]"
PHASE_ROW1 = "  [nan, 0.0, 1.0, 2.8, 3.3, 4.8],"


def edited(old: str, new: str, count: int = 1) -> str:
    assert PAPER_TOML.count(old) >= 1, f"fixture text not found: {old!r}"
    return PAPER_TOML.replace(old, new, count)


# (id, toml text, regex the one-line message must match)
BAD_FILES = [
    # inertia
    (
        "J-not-symmetric",
        edited(J1, "J0 = [[100.0, 1.5, 2.0], [1.0, 150.0, 1.0], [2.0, 1.0, 200.0]]"),
        r"agents\[1\]\.J0: not symmetric",
    ),
    (
        "J-indefinite",
        edited(J1, "J0 = [[100.0, 0.0, 0.0], [0.0, -150.0, 0.0], [0.0, 0.0, 200.0]]"),
        r"agents\[1\]\.J0: not positive definite",
    ),
    ("J-shape", edited(J1, "J0 = [[100.0, 1.0], [1.0, 150.0]]"), r"agents\[1\]\.J0: expected a 3x3 matrix"),
    ("J-ragged", edited(J1, "J0 = [[100.0, 1.0, 2.0], [1.0, 150.0], [2.0, 1.0, 200.0]]"), r"agents\[1\]\.J0"),
    ("J-text", edited(J1, 'J0 = "big"'), r"agents\[1\]\.J0: expected a 3x3 matrix"),
    (
        "dJ-makes-indefinite",
        edited("delta_J = { scale = 0.3 }", "delta_J = { scale = -1.5 }"),
        r"J0 \+ delta_J: not positive definite",
    ),
    # alpha outside (0.5, 1)
    ("alpha-0.5", edited("alpha = 0.7 ", "alpha = 0.5 "), r"controller\.alpha: must be > 0\.5, got 0\.5"),
    ("alpha-1", edited("alpha = 0.7 ", "alpha = 1.0 "), r"controller\.alpha"),
    ("alpha-1.2", edited("alpha = 0.7 ", "alpha = 1.2 "), r"controller\.alpha"),
    ("alpha-text", edited("alpha = 0.7 ", 'alpha = "0.7" '), r"controller\.alpha: expected a number"),
    # non-positive gains
    ("c1-negative", edited("c1 = 0.6 ", "c1 = -0.1 "), r"controller\.c1: must be >= 0"),
    ("c2-negative", edited("c2 = 0.8 ", "c2 = -0.8 "), r"controller\.c2: must be >= 0"),
    (
        "delta-zero",
        edited("delta = [0.005, 0.005, 0.005]", "delta = [0.005, 0.0, 0.005]"),
        r"controller\.delta: must be > 0, got 0",
    ),
    ("k_i-negative", edited("k_i = 8.0", "k_i = -8.0"), r"k\^i must be finite and >= 0"),
    (
        "k_j-negative",
        edited("values = [5.0, 0.0] }\n# phi", "values = [-5.0, 0.0] }\n# phi"),
        r"weights must be finite and >= 0",
    ),
    (
        "torque-limit-zero",
        edited("torque_limit = 2.0 ", "torque_limit = 0.0 "),
        r"controller\.torque_limit: must be > 0",
    ),
    (
        "boundary-layer-negative",
        edited("boundary_layer = 0.001 ", "boundary_layer = -0.001 "),
        r"controller\.boundary_layer: must be >= 0",
    ),
    ("epsilon-zero", edited("epsilon = 1e-4 ", "epsilon = 0.0 "), r"controller\.epsilon: must be > 0"),
    ("dt-zero", edited("dt = 0.001 ", "dt = 0.0 "), r"simulation\.dt: must be > 0"),
    (
        "t_final-not-multiple",
        edited("t_final = 100.0 ", "t_final = 100.0005 "),
        r"simulation\.t_final .* multiple of dt",
    ),
    # malformed topology tables
    ("phase-table-5-rows", edited(PHASE_ROW1 + "\n", ""), r"phase_table: expected shape \(6, 6\)"),
    ("phase-table-ragged", edited(PHASE_ROW1, "  [nan, 0.0, 1.0, 2.8, 3.3],"), r"phase_table"),
    (
        "phase-table-text",
        edited(PHASE_ROW1, '  [nan, "zero", 1.0, 2.8, 3.3, 4.8],'),
        r"phase_table: expected an 6x6 array of numbers",
    ),
    (
        "phase-table-diagonal",
        edited(PHASE_ROW1, "  [0.0, 0.0, 1.0, 2.8, 3.3, 4.8],"),
        r"phase_table\[1\]\[1\]: the diagonal must be nan",
    ),
    (
        "phase-table-inf",
        edited(PHASE_ROW1, "  [nan, inf, 1.0, 2.8, 3.3, 4.8],"),
        r"phase_table\[1\]\[2\]: phase must be finite",
    ),
    (
        "schedule-not-increasing",
        edited(
            "breakpoints = [0.0, 6.5], values = [5.0, 0.0] }\n# phi",
            "breakpoints = [6.5, 0.0], values = [5.0, 0.0] }\n# phi",
        ),
        r"strictly increasing",
    ),
    (
        "schedule-lengths",
        edited(
            "breakpoints = [0.0, 6.5], values = [5.0, 0.0] }\n# phi",
            "breakpoints = [0.0, 6.5], values = [5.0] }\n# phi",
        ),
        r"2 breakpoints but 1 values",
    ),
    (
        "schedule-beyond-period",
        edited(
            "breakpoints = [0.0, 6.5], values = [5.0, 0.0] }\n# phi",
            "breakpoints = [0.0, 9.5], values = [5.0, 0.0] }\n# phi",
        ),
        r"below the period",
    ),
    (
        "topology-two-forms",
        edited("[topology]\n", '[topology]\nkind = "ring"\n'),
        r"topology: give exactly one of phase_table, links or kind",
    ),
    # wrong shapes
    (
        "sigma0-2",
        edited("sigma0 = [0.3, 0.2, -0.3]", "sigma0 = [0.3, 0.2]"),
        r"agents\[1\]\.sigma0: expected 3 numbers, got shape \(2,\)",
    ),
    (
        "omega0-4",
        edited("omega0 = [0.35, -0.13, 0.27]", "omega0 = [0.35, -0.13, 0.27, 0.0]"),
        r"agents\[1\]\.omega0: expected 3 numbers",
    ),
    (
        "reference-sigma0",
        edited("sigma0 = [-0.3, -0.4, 0.4]", "sigma0 = [-0.3, -0.4]"),
        r"reference\.sigma0: expected 3 numbers",
    ),
    (
        "disturbance-amplitude",
        edited("amplitude = [0.2, -0.24, 0.22]", "amplitude = [0.2, -0.24]"),
        r"agents\[1\]\.disturbance\.amplitude: expected 3 numbers",
    ),
    # unknown keys
    ("unknown-top", "speed_of_light = 3e8\n" + PAPER_TOML, r"unknown key\(s\) \['speed_of_light'\]"),
    # a further [controller] key is a law parameter: one the law does not declare is named with the law's list
    (
        "unknown-controller",
        edited("c1 = 0.6 ", "c3 = 1.0\nc1 = 0.6 "),
        r"controller\.c3: unknown key: the law 'fsm' has no parameter 'c3'",
    ),
    ("unknown-law", edited("c1 = 0.6 ", 'law = "no-such-law"\nc1 = 0.6 '), r"law 'no-such-law': not a built-in law"),
    (
        "law-parameter-range",
        edited("c1 = 0.6 ", 'law = "pid"\nK = -1.0\nc1 = 0.6 '),
        r"controller\.alpha: unknown key: the law 'pid' has no parameter 'alpha' \(its parameters: K, P, Ki, "
        r"k_coupling\) and \[controller\]'s own keys are law, torque_limit, error_model, enabled",
    ),
    (
        "unknown-simulation",
        edited("dt = 0.001 ", "steps = 10\ndt = 0.001 "),
        r"simulation: unknown key\(s\) \['steps'\]",
    ),
    (
        "unknown-agent",
        edited("sigma0 = [0.3, 0.2, -0.3]", "mass = 10.0\nsigma0 = [0.3, 0.2, -0.3]"),
        r"agents\[1\]\.mass: unknown key: the law 'fsm' has no parameter 'mass' .* and an agent's own keys are J0, "
        r"delta_J, sigma0, omega0, disturbance",
    ),
    ("unknown-topology", edited("k_i = 8.0", "k_i = 8.0\nk_x = 1.0"), r"topology: unknown key\(s\) \['k_x'\]"),
    (
        "enabled-not-bool",
        edited("c1 = 0.6 ", 'enabled = "no"\nc1 = 0.6 '),
        r"controller\.enabled: expected true or false",
    ),
    # syntax and structure
    ("toml-syntax", edited("c1 = 0.6 ", "c1 = "), r"not valid TOML"),
    ("toml-unclosed", edited("c2 = 0.8 ", "c2 = [0.8 "), r"not valid TOML"),
    ("missing-reference", edited("[reference]", "[reference_]"), r"reference"),
    ("no-agents", PAPER_TOML[: PAPER_TOML.index("[[agents]]")], r"agents: missing|agents: expected"),
]


@pytest.mark.parametrize(("text", "pattern"), [pytest.param(t, p, id=i) for i, t, p in BAD_FILES])
def test_bad_scenario_file_gets_a_clear_one_line_error(tmp_path, text, pattern):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    message = str(info.value)
    assert "\n" not in message, message
    assert message.startswith(str(path)), message  # says which file
    assert len(message) < 400, message
    assert re.search(pattern, message), message


def test_the_shipped_file_loads_and_matches_the_paper(tmp_path):
    (tmp_path / "ok.toml").write_text(PAPER_TOML)
    s = load_scenario(tmp_path / "ok.toml")
    assert s == fsmctl.paper_scenario("1")
    assert s.case == "1" and s.n_agents == 6 and len(s.topology.links) == 30
    assert s.law_parameters()[0]["c1"] == 0.6 and s.law_parameters()[5]["c2"] == 0.8
    assert s.controller.torque_limit == 2.0
    assert np.allclose(s.agents[1].J_true, 1.3 * np.array([[120, 1.5, 1], [1.5, 160, 1], [1, 1, 190]]))
    # Table 2: k^j_12(t) = k(t + 0), k(t) = 5 if mod(t, 8) <= 6.5 else 0
    assert s.topology.k_j_matrix(6.4)[0, 1] == 5.0 and s.topology.k_j_matrix(6.6)[0, 1] == 0.0
    assert s.topology.k_j_matrix(0.0)[5, 4] == 5.0 and s.topology.k_j_matrix(2.0)[5, 4] == 0.0  # phi_65 = 5.3
    for case in ("2", "3a", "3b", "3c"):
        assert s.with_case(case).case == case


def test_missing_file_and_unknown_case(tmp_path):
    with pytest.raises(ScenarioError, match="cannot read scenario file"):
        load_scenario(tmp_path / "nope.toml")
    with pytest.raises(ScenarioError, match=r"no case '7'"):
        load_scenario("paper", case="7")


def test_replace_validates():
    s = fsmctl.paper_scenario("1")
    with pytest.raises(ScenarioError, match="alpha"):
        s.replace(controller={"alpha": 1.0})
    with pytest.raises(ScenarioError, match=r"controller\.gain: unknown key: the law 'fsm' has no parameter 'gain'"):
        s.replace(controller={"gain": 1.0})
    with pytest.raises(ScenarioError, match="at least one agent"):
        s.replace(agents=())
    with pytest.raises(ScenarioError, match="cannot replace"):
        s.replace(section={})
    with pytest.raises(ScenarioError, match="torque_limit"):
        s.replace(controller={"torque_limit": 0.0})


def test_disabled_controller_is_a_documented_setting(tmp_path):
    path = tmp_path / "off.toml"
    path.write_text(PAPER_TOML.replace("c1 = 0.6 ", "enabled = false\nc1 = 0.6 ", 1))
    s = load_scenario(path)
    assert s.controller.enabled is False
    assert s.controller.effective_torque_limit == 0.0
    assert "enabled=False" in "\n".join(s.describe())
    assert fsmctl.paper_scenario("1").controller.effective_torque_limit == 2.0
    assert math.isinf(
        s.replace(controller={"enabled": True, "torque_limit": math.inf}).controller.effective_torque_limit
    )


# ----------------------------------------------------------------------------- command line


@pytest.mark.parametrize(
    "case_id", ["J-not-symmetric", "alpha-1.2", "phase-table-5-rows", "unknown-controller", "toml-syntax"]
)
def test_cli_reports_bad_files_in_one_line(tmp_path, capsys, case_id):
    from fsmctl.cli.main import main

    text, pattern = next((t, p) for i, t, p in BAD_FILES if i == case_id)
    path = tmp_path / "bad.toml"
    path.write_text(text)
    code = main(["simulate", "--scenario", str(path), "--out", str(tmp_path / "out"), "--no-figures"])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1, err
    assert "Traceback" not in err
    assert re.search(pattern, err), err


def test_settling_time_counts_nan_as_not_settled():
    from fsmctl.simulation.metrics import settling_time

    t = np.arange(5.0)
    assert settling_time(t, np.array([5.0, 0.5, 0.1, 0.1, 0.1]), 1.0) == 1.0
    assert settling_time(t, np.array([5.0, 0.5, np.nan, 0.1, 0.1]), 1.0) == 3.0
    assert np.isnan(settling_time(t, np.array([5.0, 0.5, 0.1, 0.1, np.nan]), 1.0))


def test_unset_fsm_keys_take_the_laws_declared_defaults():
    """c1, c2, alpha are optional: a scenario without them flies the FSM law's declared defaults (law.json),
    the one place they are written (derive/laws/fsm.py)."""
    import json

    from fsmctl.model.laws import parameter_matrix, resolve_law

    paper = fsmctl.paper_scenario("1")
    bare = paper.replace(controller={"c1": None, "c2": None, "alpha": None})
    law = resolve_law("fsm")
    declared = {p["name"]: p["default"] for p in json.loads((law.folder / "law.json").read_text())["parameters"]}
    row = parameter_matrix(law, bare)[0]
    assert list(row[:3]) == [declared["c1"], declared["c2"], declared["alpha"]]
    assert list(parameter_matrix(law, paper)[0][:3]) == [0.6, 0.8, 0.7]  # paper.toml's [controller]


def test_a_changed_key_drops_the_reasons_that_name_it():
    """[choices] explain the values flown: after `--set delta=...` the paper's reasons for delta and for the boundary
    layer (which quotes phi/delta = 0.2 s) no longer hold and are dropped; the others stay (a fresh user's report)."""
    paper = fsmctl.paper_scenario("1")
    reasons = dict(paper.choices)
    assert "delta" in reasons and "phi/delta" in reasons["boundary_layer"]
    changed = paper.with_law(None, {"delta": [0.5, 0.5, 0.5]})
    kept = dict(changed.choices)
    assert "delta" not in kept and "boundary_layer" not in kept
    assert kept == {k: v for k, v in reasons.items() if k not in ("delta", "boundary_layer")} and kept
    assert dict(paper.replace(simulation={"t_final": 5.0}).choices) == reasons  # no law key written: all kept


def test_a_file_that_extends_another_flies_none_of_its_stale_reasons(tmp_path):
    """A file that ``extends`` the paper (e.g. the best.toml of ``fsmctl tune``) and sets the boundary layer anew does
    not print the paper's reason for phi = 0.001 (a fresh user's report); a value written again unchanged keeps its
    reason, the file's own reasons are added, and so is a reason of its own for a changed key."""
    paper = dict(fsmctl.paper_scenario("1").choices)
    tuned = tmp_path / "best.toml"
    tuned.write_text('extends = "paper"\n[controller]\nc1 = 1.2\nboundary_layer = 0.01\nalpha = 0.7\n')
    s = load_scenario(tuned)
    assert s.controller.parameters["boundary_layer"] == 0.01
    assert dict(s.choices) == {k: v for k, v in paper.items() if k != "boundary_layer"}  # alpha: same value, kept
    assert not [line for line in s.describe() if line.lstrip().startswith("choice boundary_layer")]
    dt = tmp_path / "dt.toml"
    dt.write_text('extends = "paper"\n[simulation]\ndt = 0.002\n[choices]\nstep = "RK4 at 2 ms: mine"\n')
    assert dict(load_scenario(dt).choices)["step"] == "RK4 at 2 ms: mine"  # the paper's quotes dt = 1 ms: replaced
    assert dict(load_scenario(tuned.parent / "best.toml", case="2").choices) == dict(s.choices)  # a case: the same


_THREE_AGENTS = """
name = "three"
[simulation]
t_final = 1.0
[controller]
delta = [0.005, 0.005, 0.005]
[reference]
sigma0 = [0.0, 0.0, 0.0]
omega = { amplitude = [0.0, 0.0, 0.0], frequency = [0.0, 0.0, 0.0], kind = ["cos", "cos", "cos"] }
[[agents]]
J0 = [[100.0, 0.0, 0.0], [0.0, 150.0, 0.0], [0.0, 0.0, 200.0]]
sigma0 = [0.1, 0.0, 0.0]
omega0 = [0.0, 0.0, 0.0]
[[agents]]
J0 = [[100.0, 0.0, 0.0], [0.0, 150.0, 0.0], [0.0, 0.0, 200.0]]
sigma0 = [0.1, 0.0, 0.0]
omega0 = [0.0, 0.0, 0.0]
[[agents]]
J0 = [[100.0, 0.0, 0.0], [0.0, 150.0, 0.0], [0.0, 0.0, 200.0]]
sigma0 = [0.1, 0.0, 0.0]
omega0 = [0.0, 0.0, 0.0]
"""


def test_a_directed_ring_is_the_hand_written_cycle(tmp_path):
    """``kind = "ring"`` with ``directed = true`` is the three links 1 -> 2 -> 3 -> 1 written out by hand (agent i
    receives from i-1), with the table's k_i and switching schedule on each; without it, both directions."""
    schedule = "schedule = { period = 8.0, breakpoints = [0.0, 6.5], values = [5.0, 0.0] }"
    by_hand = (
        f"[topology]\nk_i = 8.0\n{schedule}\n"
        "links = [{ receiver = 2, sender = 1 }, { receiver = 3, sender = 2 }, { receiver = 1, sender = 3 }]\n"
    )
    (tmp_path / "hand.toml").write_text(_THREE_AGENTS + by_hand)
    (tmp_path / "ring.toml").write_text(
        _THREE_AGENTS + f'[topology]\nk_i = 8.0\n{schedule}\nkind = "ring"\ndirected = true\n'
    )
    hand, ring = (load_scenario(tmp_path / f"{name}.toml").topology for name in ("hand", "ring"))
    assert sorted((link.receiver, link.sender) for link in ring.links) == [(0, 2), (1, 0), (2, 1)]
    assert np.array_equal(ring.k_i_matrix(), hand.k_i_matrix())
    times = np.linspace(0.0, 20.0, 81)
    assert np.array_equal(ring.k_j_matrices(times), hand.k_j_matrices(times))
    (tmp_path / "both.toml").write_text(_THREE_AGENTS + f'[topology]\nk_i = 8.0\n{schedule}\nkind = "ring"\n')
    assert load_scenario(tmp_path / "both.toml").topology.edge_count() == 6  # undirected: every pair both ways
    (tmp_path / "bad.toml").write_text(_THREE_AGENTS + '[topology]\nk_i = 8.0\nkind = "all-to-all"\ndirected = true\n')
    with pytest.raises(ScenarioError, match=r"topology\.directed: true or false, with kind = 'ring' only"):
        load_scenario(tmp_path / "bad.toml")


@pytest.mark.parametrize(
    ("topology", "warned"),
    [
        ('kind = "ring"\n', True),  # no weight written: 0 by default, no coordination
        ('kind = "ring"\nk_i = 0.0\n', True),  # k_j still the default
        ("links = [{receiver = 1, sender = 2}, {receiver = 2, sender = 1, k_i = 0.0, k_j = 0.0}]\n", True),
        ('kind = "ring"\nk_i = 0.0\nk_j = 0.0\n', False),  # written: uncoupled on purpose (as Case 2)
        ('kind = "ring"\nk_i = 1.0\n', False),  # coordinating
        ('kind = "ring"\nk_j = 0.5\n', False),
    ],
)
def test_links_left_at_the_default_zero_weights_are_warned_about(tmp_path, topology, warned):
    import warnings

    from fsmctl.model import UncoupledTopologyWarning

    (tmp_path / "s.toml").write_text(_THREE_AGENTS + "[topology]\n" + topology)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scenario = load_scenario(tmp_path / "s.toml")
    mine = [w for w in caught if w.category is UncoupledTopologyWarning]
    assert len(mine) == int(warned)
    if warned:
        assert str(mine[0].message).startswith("topology: every link has k_i = k_j = 0: the agents do not coordinate")
        assert mine[0].filename == __file__  # points at the caller's line
        assert not scenario.topology.k_i_matrix().any() and not scenario.topology.k_j_matrix(0.0).any()


def test_the_paper_case_2_writes_its_zero_weights_and_is_not_warned_about():
    import warnings

    from fsmctl.model import UncoupledTopologyWarning

    with warnings.catch_warnings():
        warnings.simplefilter("error", UncoupledTopologyWarning)
        assert not fsmctl.paper_scenario("2").topology.k_i_matrix().any()
