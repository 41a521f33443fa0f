"""``fsmctl scenario show``: every value of a scenario, defaults filled in, with where it came from; flies nothing.

Oracles: the origins are read off the files written here (a value written in the file, inherited from its
``extends`` base, written by the case, given by ``--set``, or written nowhere), and the law's declared defaults off
its ``law.json`` (the file the derivation wrote), not off fsmctl's resolution.
"""

from __future__ import annotations

import json

import pytest

import fsmctl
from fsmctl.cli.main import main
from fsmctl.model import resolve_law
from fsmctl.model.laws import LawSwitchWarning
from fsmctl.model.scenario import scenario_from_dict
from fsmctl.model.scenario_origin import show_scenario

PID_OVER_PAPER = 'extends = "paper"\n[simulation]\nt_final = 5.0\n[controller]\nlaw = "pid"\nK = 3.0\n'


def _declared_defaults(name: str) -> dict:
    law = resolve_law(name)
    return {p["name"]: p["default"] for p in json.loads((law.folder / "law.json").read_text())["parameters"]}


def test_every_value_has_its_origin(tmp_path):
    path = tmp_path / "pid.toml"
    path.write_text(PID_OVER_PAPER)
    with pytest.warns(LawSwitchWarning):  # the paper's fsm keys do not apply to pid: said once
        shown = show_scenario(path, "3a", parameters={"P": 9.0})
    got = {v.key: (v.value, v.origin) for v in shown.values}
    defaults = _declared_defaults("pid")
    assert got["simulation.t_final"] == (5.0, "file")
    assert got["simulation.dt"] == (0.001, "extends")  # paper.toml's
    assert got["simulation.seed"] == (0, "default")  # written nowhere
    assert got["controller.law"] == ("pid", "file")
    assert got["controller.K"] == (3.0, "file") and got["controller.P"] == (9.0, "--set")
    assert got["controller.Ki"] == (defaults["Ki"], "law default")
    assert got["controller.k_coupling"] == (defaults["k_coupling"], "law default")
    assert got["controller.torque_limit"] == (2.0, "extends")
    assert got["topology"][1] == "case 3a"  # the case writes the weights
    assert got["agents[1].sigma0"] == ([0.3, 0.2, -0.3], "extends")
    assert got["agents[1].delta_J"][1] == "extends"  # [controller] delta_J = { scale = 0.3 } of paper.toml
    with pytest.warns(LawSwitchWarning):
        assert shown.scenario == fsmctl.load_scenario(path, "3a").with_law(None, {"P": 9.0})  # the one path


def test_the_cli_shows_a_builtin_scenario_and_its_json_is_the_scenario(capsys):
    assert main(["scenario", "show", "paper", "--case", "2", "--set", "c1=0.5"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "scenario paper case 2: every value and where it came from (nothing flown)"
    assert "  controller.c1              = 0.5  (--set)" in lines
    assert "  simulation.seed            = 0  (default)" in lines
    assert main(["scenario", "show", "paper", "--case", "2", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["values"]["controller.c2"] == {"value": 0.8, "origin": "file"}
    assert scenario_from_dict(doc["file"], case="2") == fsmctl.paper_scenario("2")


def test_an_invalid_scenario_is_the_one_line_error_of_every_command(tmp_path, capsys):
    path = tmp_path / "bad.toml"
    path.write_text('extends = "paper"\n[simulation]\nt_finall = 3.0\n')
    assert main(["scenario", "show", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("fsmctl scenario: error: ") and "did you mean t_final?" in err and "\n" not in err


@pytest.mark.parametrize(
    ("case", "weights"),
    [("1", "k_i 8, k_j 0..5"), ("2", "all weights 0: no coordination"), ("3a", "k_i 2, k_j 0..0.6")],
)
def test_the_topology_line_gives_the_range_of_the_weights(case, weights, capsys):
    """The one-line topology summary differs between the cases (Case 2 zeroes every weight; it printed Case 1's
    line) and points to ``--json``, which lists every link; the ranges are checked against the JSON's links."""
    assert main(["scenario", "show", "paper", "--case", case, "--json"]) == 0
    links = json.loads(capsys.readouterr().out)["file"]["topology"]["links"]
    k_i = [link["k_i"] for link in links]
    k_j = [v for link in links for v in link["k_j"]["values"]]
    if max(map(abs, k_i + k_j)) == 0:
        assert weights == "all weights 0: no coordination"
    else:
        assert weights == f"k_i {min(k_i):g}..{max(k_i):g}".replace("8..8", "8").replace("2..2", "2") + (
            f", k_j {min(k_j):g}..{max(k_j):g}"
        )
    assert main(["scenario", "show", "paper", "--case", case]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.lstrip().startswith("topology "))
    assert f"{len(links)} directed links among 6 agents, {weights} (--json lists every link)" in line
    assert "the JSON" not in line


def test_floats_are_listed_without_binary_noise_but_every_real_difference_shows(capsys):
    """``0.45`` (stored as 0.44999999999999996 after the case arithmetic) prints as 0.45; a value 1e-14 away from
    0.45 still prints differently."""
    assert main(["scenario", "show", "paper", "--case", "1", "--set", "c1=0.45000000000001"]) == 0
    out = capsys.readouterr().out
    assert "0.44999999999999996" not in out
    assert "  agents[2].delta_J          = [[36.0, 0.45, 0.3], [0.45, 48.0, 0.3], [0.3, 0.3, 57.0]]  (file)" in out
    assert "  controller.c1              = 0.45000000000001  (--set)" in out
