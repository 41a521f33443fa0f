"""One law interface: where a flown law's parameters come from (issue 23).

The rule (fsmctl.model.laws.parameter_matrix): for each agent and each declared parameter, the agent's own value,
else [controller]'s, else the flown law's declared default; the presets the scenario selects fix their parameters.
Switching the law keeps the written keys the new law declares and says which it applied and ignored.
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

import fsmctl
from fsmctl.cli.main import main
from fsmctl.model import parameter_matrix, resolve_law
from fsmctl.model.laws import LawSwitchWarning
from fsmctl.model.scenario import ScenarioError, load_scenario

# A PD law whose gains carry the names of two of the paper's law's options, with defaults far from the paper
# scenario's values (epsilon = 1e-4 and boundary_layer = 0.001 there): before issue 23 the typed [controller]
# settings supplied 1e-4 and 0 to any law parameter of these names, even when the file never wrote them.
NAME_CLASH_LAW = """
from fsmctl.symbolic.law import LawBuilder


def law(error_model):
    b = LawBuilder("name_clash_pd", error_model, doc="PD whose gains are called like options of the paper's law")
    kp = b.parameter("epsilon", 40.0, unit="N m", minimum=0.0, exclusive_minimum=True, doc="attitude gain")
    kd = b.parameter("boundary_layer", 60.0, unit="N m s", minimum=0.0, exclusive_minimum=True, doc="rate gain")
    e = b.error_state()
    b.broadcast("sigma_e", e.sigma_e)
    b.torque(-kp * e.sigma_e - kd * e.omega_e)
    return b.build()
"""

RING = """
name = "ring3"
[simulation]
t_final = 2.0
dt = 0.01
output_interval = 0.1
[controller]
law = "{law}"
torque_limit = "inf"
{extra}
[reference]
sigma0 = [0.0, 0.0, 0.0]
omega = {{ amplitude = [0.0, 0.0, 0.0] }}
[topology]
kind = "ring"
k_i = 1.0
k_j = 1.0
[[agents]]
J0 = [[20.0, 0.0, 0.0], [0.0, 25.0, 0.0], [0.0, 0.0, 30.0]]
sigma0 = [0.2, -0.1, 0.05]
omega0 = [0.0, 0.01, 0.0]
{agent1}
[[agents]]
J0 = [[22.0, 0.0, 0.0], [0.0, 24.0, 0.0], [0.0, 0.0, 28.0]]
sigma0 = [-0.1, 0.1, 0.0]
omega0 = [0.01, 0.0, 0.0]
[[agents]]
J0 = [[18.0, 0.0, 0.0], [0.0, 26.0, 0.0], [0.0, 0.0, 31.0]]
sigma0 = [0.0, -0.2, 0.1]
omega0 = [0.0, 0.0, -0.01]
"""


@pytest.fixture(scope="module")
def clash_law(tmp_path_factory):
    folder = tmp_path_factory.mktemp("clash")
    script = folder / "name_clash.py"
    script.write_text(NAME_CLASH_LAW)
    return script


def ring(tmp_path, law: str, extra: str = "", agent1: str = ""):
    path = tmp_path / "ring3.toml"
    path.write_text(RING.format(law=law, extra=extra, agent1=agent1))
    return path


def test_a_law_flies_its_own_defaults_when_the_file_does_not_write_them(tmp_path, clash_law):
    scenario = load_scenario(ring(tmp_path, str(clash_law)))
    law = scenario.law
    assert parameter_matrix(law, scenario).tolist() == [[40.0, 60.0]] * 3
    # the trajectory is the one of the declared defaults, written out, and not the paper's options' values
    flown = fsmctl.simulate(scenario)
    written = fsmctl.simulate(scenario.replace(controller={"epsilon": 40.0, "boundary_layer": 60.0}))
    paper_options = fsmctl.simulate(scenario.replace(controller={"epsilon": 1e-4, "boundary_layer": 1e-9}))
    assert np.array_equal(flown.sigma, written.sigma)
    assert np.max(np.abs(flown.sigma - paper_options.sigma)) > 1e-2


def test_the_command_line_flies_the_laws_defaults_too(tmp_path, clash_law, capsys):
    path = ring(tmp_path, str(clash_law))
    code = main(["simulate", "--scenario", str(path), "--out", str(tmp_path / "out"), "--no-figures"])
    out = capsys.readouterr().out
    assert code == 0
    assert "law parameters: epsilon=40.0 boundary_layer=60.0" in out


def test_flying_another_law_applies_the_declared_keys_and_says_which(tmp_path, clash_law):
    paper = fsmctl.paper_scenario("1")
    with pytest.warns(LawSwitchWarning) as caught:
        switched = paper.replace(controller={"law": str(clash_law)})
    message = str(caught[0].message)
    assert len(message.splitlines()) == 1
    # the clash law's gains are in N m, the paper's epsilon and boundary_layer in MRP units and 1/s: not carried
    assert re.search(r"written keys applied: none; ignored .*: alpha, boundary_layer, c1, c2, delta", message)
    assert dict(switched.controller.parameters) == {}
    assert parameter_matrix(switched.law, switched)[0].tolist() == [40.0, 60.0]
    with pytest.warns(LawSwitchWarning) as caught:
        st = paper.replace(controller={"law": "super_twisting"})  # the same parameters of the paper's surface
    assert "applied: alpha = 0.7, c1 = 0.6, c2 = 0.8, epsilon = 0.0001, singularity_fix = switch" in str(
        caught[0].message
    )
    assert st.law_parameters()[0]["c1"] == 0.6
    with pytest.warns(
        LawSwitchWarning, match=r"applied: none; ignored \(not parameters of pid of the same unit and size\): alpha, "
    ):
        pid = paper.replace(controller={"law": "pid"})
    assert parameter_matrix(pid.law, pid)[0].tolist() == [p.default[0] for p in resolve_law("pid").parameters]


def test_a_key_the_files_own_law_does_not_declare_is_a_one_line_error(tmp_path, clash_law, capsys):
    path = ring(tmp_path, "pid", extra="c1 = 0.6")
    with pytest.raises(ScenarioError, match=r"controller\.c1: unknown key: the law 'pid' has no parameter 'c1' "):
        load_scenario(path)
    code = main(["simulate", "--scenario", str(path), "--out", str(tmp_path / "out"), "--no-figures"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1
    assert "its parameters: K, P, Ki, k_coupling" in err


def test_any_parameter_can_be_set_per_agent_in_toml_and_in_python(tmp_path):
    from_file = load_scenario(ring(tmp_path, "pid", extra="K = 3.0", agent1="K = 7.0\nP = 2.0"))
    rows = parameter_matrix(from_file.law, from_file)
    K, P = (resolve_law("pid").parameters[k].default[0] for k in (0, 1))
    assert rows[:, 0].tolist() == [7.0, 3.0, 3.0] and rows[:, 1].tolist() == [2.0, P, P]
    base = load_scenario(ring(tmp_path, "pid"))
    from_python = base.replace(controller={"K": 3.0}, agents=[{"K": 7.0, "P": 2.0}, {}, {}])
    assert from_python == from_file
    assert parameter_matrix(base.law, base)[:, 0].tolist() == [K] * 3
    with pytest.raises(ScenarioError, match=r"agents\[2\]\.K: must be > 0, got -1"):
        base.replace(agents=[{}, {"K": -1.0}, {}])


def test_replace_writes_a_key_as_a_toml_file_does(tmp_path):
    base = load_scenario(ring(tmp_path, "pid"))
    assert base.replace(controller={"K": 10.0}) == load_scenario(ring(tmp_path, "pid", extra="K = 10.0"))
    written = base.replace(controller={"K": 10.0})
    assert written.replace(controller={"K": None}) == base  # None removes a written key: the default applies again


def test_a_preset_fixes_its_parameters_over_the_written_ones():
    paper = fsmctl.paper_scenario("1")  # writes c1 = 0.6 and c2 = 0.8
    tsm = paper.replace(controller={"surface": "TSM"})
    lsm = paper.replace(controller={"surface": "lsm"})
    assert tsm.law_parameters()[0]["c1"] == 0.0 and tsm.law_parameters()[0]["c2"] == 0.8
    assert lsm.law_parameters()[0]["c1"] == 0.6 and lsm.law_parameters()[0]["c2"] == 0.0
    assert "surface=tsm" in tsm.describe()[1]
    with pytest.raises(ScenarioError, match=r"controller\.surface: must be one of fsm, tsm, lsm, got 'nsm'"):
        paper.replace(controller={"surface": "nsm"})


def test_a_number_for_a_vector_parameter_sets_every_component():
    paper = fsmctl.paper_scenario("1")
    assert paper.replace(controller={"delta": 0.02}).law_parameters()[3]["delta"] == (0.02, 0.02, 0.02)
    with pytest.raises(ScenarioError, match=r"controller\.delta: expected 3 numbers, got 2"):
        paper.replace(controller={"delta": [0.02, 0.02]})


def test_set_delta_flies_the_value_for_every_agent(tmp_path):
    """--set delta=[0.5,0.5,0.5] on the paper scenario flew every agent's own 0.005 while the result said 0.5."""
    out = tmp_path / "out"
    args = ["simulate", "--t-final", "0.5", "--output-interval", "0.1", "--no-figures", "--format", "csv"]
    assert main([*args, "--out", str(out), "--set", "delta=[0.5,0.5,0.5]"]) == 0
    path = next(out.glob("*.csv"))
    result = fsmctl.load_result(path)
    assert {p["delta"] for p in fsmctl.scenario_from_result(path).law_parameters()} == {(0.5, 0.5, 0.5)}
    default = fsmctl.simulate(fsmctl.paper_scenario("1").replace(simulation={"t_final": 0.5, "output_interval": 0.1}))
    assert not np.allclose(result.sigma, default.sigma, rtol=0, atol=1e-9)
    assert main([*args, "--out", str(tmp_path / "neg"), "--set", "delta=-0.5"]) == 2


def test_set_overrides_the_agents_own_values(tmp_path):
    base = load_scenario(ring(tmp_path, "pid", agent1="K = 7.0"))
    assert parameter_matrix(base.law, base.with_law(parameters={"K": 2.0}))[:, 0].tolist() == [2.0] * 3
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # same law: nothing to report
        base.with_law("pid", {"K": 2.0})


def test_prove_reads_the_flown_laws_defaults_for_a_scenario_that_writes_none(tmp_path, capsys):
    """A ring whose [controller] leaves the paper's law's parameters to their defaults: `fsmctl prove` ended in
    `internal error: TypeError` (alpha unset) or `agents[0].delta: expected 3 numbers, got 1` (delta unset)."""
    path = ring(tmp_path, "fsm")
    code = main(["prove", "--scenario", str(path), "--json", "theorem1-gains", "theorem2-delta"])
    captured = capsys.readouterr()
    assert code in (0, 1), captured.err  # 1: a claim fails for this scenario, as the paper's does
    assert "internal error" not in captured.err and "Traceback" not in captured.err
    import json

    claims = {c["id"]: c for c in json.loads(captured.out)["claims"]}
    assert set(claims) == {"theorem1-gains", "theorem2-delta"}
    assert "0.005" in json.dumps(claims["theorem2-delta"])  # the declared default delta, every agent


def test_a_preset_and_a_value_it_fixes_given_together_is_an_error(tmp_path, capsys):
    args = ["simulate", "--t-final", "0.1", "--no-figures", "--out", str(tmp_path / "o")]
    assert main([*args, "--set", "surface=tsm", "--set", "c1=0.5"]) == 2
    assert "controller.c1: fixed by surface = tsm (c1 = 0); set one of them" in capsys.readouterr().err


def test_a_parameter_of_another_unit_does_not_carry_over(tmp_path, clash_law):
    """The paper's epsilon (a band in MRP units) is not the name-clash law's epsilon (a gain in N m)."""
    from fsmctl.model.laws import carried_keys

    assert carried_keys(resolve_law("fsm"), resolve_law(str(clash_law))) == ()
    with pytest.warns(LawSwitchWarning, match=r"applied: none; ignored .*: alpha, boundary_layer, c1, c2, delta"):
        switched = fsmctl.paper_scenario("1").replace(controller={"law": str(clash_law)})
    assert parameter_matrix(switched.law, switched)[0].tolist() == [40.0, 60.0]


def test_a_changed_or_dropped_key_loses_its_documented_choice():
    paper = fsmctl.paper_scenario("1")
    assert "delta" in dict(paper.choices)
    assert "delta" not in dict(paper.replace(controller={"delta": 0.5}).choices)
    with pytest.warns(LawSwitchWarning):
        pid = paper.replace(controller={"law": "pid"})
    assert not {"alpha", "delta", "boundary_layer"} & set(dict(pid.choices))


def test_the_per_agent_line_lists_the_values_in_agent_order(tmp_path):
    s = load_scenario(ring(tmp_path, "pid", agent1="K = 0.9")).replace(agents=[{}, {"K": 0.3}, {"K": 0.6}])
    assert "per agent (1, 2, ...): K = [0.9, 0.3, 0.6]" in "\n".join(s.describe())


def test_a_file_that_extends_another_and_sets_another_law(tmp_path):
    path = tmp_path / "pd.toml"
    path.write_text('extends = "paper"\nname = "paper-pd"\n[controller]\nlaw = "pid"\nK = 10.0\n')
    with pytest.warns(LawSwitchWarning, match=r"law 'pid' flown instead of 'fsm': written keys applied: none"):
        s = load_scenario(path)
    assert dict(s.controller.parameters) == {"K": 10.0}
    path.write_text('extends = "paper"\n[controller]\nlaw = "pid"\nK = -1.0\n')
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the error alone: no warning about the switch of a file that does not load
        with pytest.raises(ScenarioError, match=r"controller\.K: must be > 0, got -1"):
            load_scenario(path)


def test_extends_drops_the_bases_own_agent_parameters_written_in_a_sub_table(tmp_path):
    base = ring(tmp_path, "fsm", agent1="parameters = { delta = 0.01 }")
    (tmp_path / "pd.toml").write_text(f'extends = "{base.name}"\n[controller]\nlaw = "pid"\n')
    with pytest.warns(LawSwitchWarning, match=r"ignored .*: agents\[1\]\.delta"):
        s = load_scenario(tmp_path / "pd.toml")
    assert all(not a.parameters for a in s.agents)
