""" "Did you mean": a misspelled option, subcommand, scenario key or ``--set`` key names the closest known one.

One rule (:mod:`fsmctl.suggest`) serves every message; the command line's errors stay one line on stderr, exit 2.
The expected suggestions are written out by hand (the closest spelling a reader would pick), not computed.
"""

from __future__ import annotations

import pytest

from fsmctl import ScenarioError, load_scenario
from fsmctl.cli.main import main
from fsmctl.suggest import close_matches, did_you_mean, ranked


def test_the_rule_names_the_closest_and_nothing_far():
    assert did_you_mean("t_finall", ["dt", "t_final", "seed", "output_interval"]) == "did you mean t_final?"
    assert did_you_mean("delt", ["c1", "c2", "delta", "error_model", "law"]) == "did you mean delta?"
    assert did_you_mean("xyzzy", ["dt", "t_final"]) == ""
    assert close_matches("--lisst", ["--list", "--law", "--json"]) == ["--list"]
    assert ranked("j", ["disturbance", "J", "sc_J"]) == ["J", "sc_J", "disturbance"]


def _cli(argv, capsys) -> tuple[int, str]:
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse exits directly
        code = exc.code
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    return code, err.strip()


@pytest.mark.parametrize(
    ("argv", "line"),
    [
        (["simulate", "--t-finall", "3"], "fsmctl simulate: unknown option --t-finall (did you mean --t-final?)"),
        (["simulate", "--t-finall=3"], "fsmctl simulate: unknown option --t-finall (did you mean --t-final?)"),
        (["prove", "--lisst"], "fsmctl prove: unknown option --lisst (did you mean --list?)"),
        (["compare", "--lawz", "fsm"], "fsmctl compare: unknown option --lawz (did you mean --laws?)"),
        (["simulate", "--zzzzzz"], "fsmctl simulate: unknown option --zzzzzz"),
        (["simulat", "--case", "1"], "fsmctl: unknown command 'simulat' (did you mean simulate?)"),
        (["--quiet", "montecarol"], "fsmctl: unknown command 'montecarol' (did you mean montecarlo?)"),
        (["scenario", "shw", "paper"], "fsmctl scenario: unknown command 'shw' (did you mean show?)"),
        # an abbreviation is a misspelling, not the option it starts (argparse's allow_abbrev)
        (["simulate", "--scenari", "paper"], "fsmctl simulate: unknown option --scenari (did you mean --scenario?)"),
        (
            ["simulate", "--law", "fsmm"],
            "fsmctl simulate: error: law 'fsmm': not a built-in law (the built-in laws: fsm, fsm_wheels, adaptive_fsm, "
            "fsm_event, pid, super_twisting), a derivation script (.py) or a derived law folder; did you mean fsm or "
            "adaptive_fsm?",
        ),
    ],
)
def test_a_misspelled_option_or_command_gets_one_line_with_a_suggestion(argv, line, capsys):
    code, err = _cli(argv, capsys)
    assert (code, err) == (2, line)


def test_a_misspelled_scenario_key_names_the_right_one_first(tmp_path):
    cases = {
        "[simulation]\nt_finall = 3.0\n": "simulation: unknown key(s) ['t_finall']: did you mean t_final? (known: [",
        "simulatio = 3\n": "unknown key(s) ['simulatio']: did you mean simulation? (known: [",
        "[controller]\ndelt = 0.1\n": "controller.delt: unknown key: the law 'fsm' has no parameter 'delt': did "
        "you mean delta? (its parameters:",
        "[topology]\nkind = 'ring'\nk_ii = 8.0\n": "topology: unknown key(s) ['k_ii']: did you mean k_i? (known:",
        "[sensors]\nstar_trackr = {}\n": "sensors: unknown key(s) ['star_trackr']: did you mean star_tracker?",
    }
    for i, (text, message) in enumerate(cases.items()):
        path = tmp_path / f"s{i}.toml"
        path.write_text(f'extends = "paper"\n{text}')
        with pytest.raises(ScenarioError) as exc:
            load_scenario(path)
        assert message in str(exc.value), str(exc.value)


def test_a_misspelled_set_key_names_the_parameter(tmp_path, capsys):
    code, err = _cli(["simulate", "--set", "boundary_layr=0.1", "--out", str(tmp_path)], capsys)
    assert code == 2
    assert "has no parameter 'boundary_layr': did you mean boundary_layer? (its parameters:" in err
