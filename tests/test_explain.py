"""``fsmctl reproduce``'s explanations (fsmctl/studies/explain.py) and the unswitched-error-MRP law variant.

Oracles: the bisected threshold is checked against independent runs just below and above it (the scenario built with
``Scenario.replace``, not through the explanation's scenario file); the evidence file is re-loaded and simulated again;
the switched twin of the variant law flies bit-identically to the built-in ``fsm`` law (so the variant differs by the
switch alone); the unswitched composition is checked against the shadow-set error of the generated code.  Everything
runs on the ``--fast`` horizon with the search restricted to one or two settings.
"""

from __future__ import annotations

import hashlib
import math
import re
import tomllib
import warnings
from importlib import resources

import numpy as np
import pytest

from fsmctl.studies import explain_report as er
from fsmctl.studies import explain_settings as es
from fsmctl.studies import figure_checks as fc
from fsmctl.studies.claim_types import DIFFERS, IMPOSSIBLE, ClaimVerdict
from fsmctl.studies.claims import get_claim
from fsmctl.studies.explain import explain
from fsmctl.studies.explain_laws import UNSWITCHED_LAW, law_script
from fsmctl.studies.paper_runs import run_plan, run_record, run_scenario

SPECS = {s.key: s for s in run_plan()}


def _claims(*ids: str, verdict: str = DIFFERS) -> list[ClaimVerdict]:
    return [ClaimVerdict(i, i, f"claim {i}", "", "", "", "", verdict, "", "") for i in ids]


def _fly(scenario):
    from fsmctl.simulation.simulator import simulate

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate(scenario, progress=False)


def _paper_digest() -> str:
    return hashlib.sha256(resources.files("fsmctl").joinpath("scenarios", "paper.toml").read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def settling(tmp_path_factory):
    """The 27 s settling claim explained by the torque limit alone (fast horizon), twice (determinism)."""
    digest = _paper_digest()
    outs = [tmp_path_factory.mktemp(f"explain{k}") for k in range(2)]
    results = [
        explain(
            "paper",
            _claims("settling_27s", verdict=IMPOSSIBLE),
            out,
            fast=True,
            settings=["torque_limit"],
            checks=["settling_27s"],
            progress=False,
        )
        for out in outs
    ]
    return results, outs, digest


# ----------------------------------------------------------------------------- the search


def test_torque_limit_threshold_matches_independent_runs(settling):
    (result, _), _, _ = settling
    (e,) = result
    assert e.status == er.EXPLAINED and e.reproduced_if.startswith("torque limit >= ")
    threshold = float(e.reproduced_if.split(">= ")[1].split()[0])
    assert 2.0 < threshold < 1e5 and 0 < e.distance < 1
    assert "bisected to 0.1 N m" in e.reproduced_if
    from fsmctl import paper_scenario

    base = paper_scenario("1")
    verdicts = {}
    for u_max in (threshold - 0.1, threshold, threshold + 0.1):
        scenario = base.replace(
            controller={"torque_limit": u_max}, simulation={"t_final": 10.0, "output_interval": 0.05}
        )
        record = run_record(SPECS["case1"], scenario, _fly(scenario))
        verdicts[round(u_max, 1)] = get_claim("settling_27s").holds({"case1": record}, 1.0)
    assert verdicts == {round(threshold - 0.1, 1): False, round(threshold, 1): True, round(threshold + 0.1, 1): True}
    assert f"{threshold - 0.1:g} N m does not" in e.reproduced_if


def test_evidence_file_reloads_and_reproduces_its_numbers(settling):
    (result, _), (out, _), _ = settling
    (e,) = result
    ev = e.evidence
    assert ev.rerun_identical and ev.scenario_file.startswith("explain/")
    path = out / ev.scenario_file
    data = tomllib.loads(path.read_text())
    threshold = float(e.reproduced_if.split(">= ")[1].split()[0])
    assert data == {"extends": "paper", "controller": {"torque_limit": threshold}}  # just the change
    scenario = run_scenario(str(path), SPECS["case1"], True)
    assert scenario.controller.torque_limit == threshold and scenario.simulation.t_final == 10.0
    # its comments say what was flown: the horizon and output grid of the run reloaded from the file
    sim = scenario.simulation
    assert f"# fsmctl reproduce --fast flew case1 for {sim.t_final:g} s, output every {sim.output_interval:g} s" in (
        path.read_text().splitlines()
    )
    record = run_record(SPECS["case1"], scenario, _fly(scenario))
    assert get_claim("settling_27s").holds({"case1": record}, 1.0)
    for metric in ("aaem", "raem"):
        assert f"{metric.upper()} {record.settling(metric, 1.0):.2f} s" in e.numbers
    # the evidence also says what its Case 1 run does to the printed figures: Fig 4's ±2 N m axes cannot hold it
    assert any(line.startswith("Fig 4") and f"{threshold:.4g} N m" in line for line in ev.figures)
    assert "fig4_axis" not in ev.figures_fit


def test_explanations_are_deterministic(settling):
    (first, second), (out1, out2), _ = settling
    assert [e.to_dict() for e in first] == [e.to_dict() for e in second]
    files = sorted(p.name for p in (out1 / "explain").iterdir())
    assert files == sorted(p.name for p in (out2 / "explain").iterdir())
    for name in files:
        assert (out1 / "explain" / name).read_bytes() == (out2 / "explain" / name).read_bytes()


def test_default_scenario_is_untouched(settling):
    _, _, digest = settling
    assert _paper_digest() == digest
    from fsmctl import paper_scenario

    c = paper_scenario("1").controller
    assert (c.torque_limit, c.error_model, str(c.law)) == (2.0, "paper", "fsm")
    assert (c.parameters["alpha"], c.parameters["boundary_layer"]) == (0.7, 0.001)


def test_no_setting_lists_the_ranges(tmp_path):
    result = explain(
        "paper",
        _claims("tracking_accuracy"),
        tmp_path,
        fast=True,
        settings=["alpha", "error_model"],
        checks=["tracking_accuracy"],
        progress=False,
        pair_budget_runs=0,
    )
    (e,) = result
    assert e.status == er.NOT_EXPLAINED and e.evidence is None
    assert any(s.startswith("alpha 0.51-0.99") and "linear grid of 10 values" in s for s in e.searched)
    assert any(s.startswith("error kinematics: exact") for s in e.searched)
    from fsmctl.studies.report_doc import plain

    items = [plain(item) for item in er.evidence_items(e)]
    assert items[0] == f"What would reproduce it: {er.NOT_EXPLAINED}"
    assert "alpha 0.51-0.99" in items[1] and "error kinematics: exact" in items[1]
    assert er.change_cell(e) == "none found"
    assert not (tmp_path / "explain").exists()  # no evidence, no file


def test_figure_axis_beyond_180_needs_the_unswitched_error_mrp(tmp_path):
    """Fig 3's 0-200° axis: in the shadow set θ <= 180°, so only the unswitched variant is flown for it."""
    result = explain(
        "paper", [], tmp_path, fast=True, checks=["fig3_axis", "fig4_axis"], progress=False, pair_budget_runs=0
    )
    fig3, fig4 = result
    assert fig4.status == er.ALREADY_REPRODUCED  # the paper's 2 N m limit is reached: Fig 4's ±2 N m axes
    assert fig3.verdict == "does not fit" and re.match(r"θ_1-4 peak 179\.9\d*° \(not in \(180, 200\]", fig3.baseline)
    assert fig3.searched[0].startswith("only with the error MRP: unswitched")
    if fig3.status == er.EXPLAINED:
        assert fig3.change == "error MRP: unswitched"


# ----------------------------------------------------------------------------- pieces


def test_setting_distance_rounding_and_grid():
    from fsmctl import paper_scenario

    settings = {s.name: s for s in es.search_settings(paper_scenario("1"))}
    assert list(settings) == [
        "torque_limit", "alpha", "delta", "boundary_layer", "error_model", "error_mrp", "integration", "tolerance",
    ]  # fmt: skip
    u = settings["torque_limit"]
    assert u.default == 2.0 and u.low == 2.0 and u.high == 1e5 and 5.0 in u.grid and 2.0 not in u.grid
    assert u.distance(2.0) == 0.0 and u.distance(1e5) == pytest.approx(1.0)
    assert u.distance(20.0) == pytest.approx(math.log(10) / math.log(5e4))
    assert u.midpoint(20.0, 50.0) == pytest.approx(31.6) and u.rounded(31.62) == 31.6
    assert u.resolved(31.6, 31.7) and not u.resolved(31.6, 31.8)
    a = settings["alpha"]
    assert a.distance(0.99) == pytest.approx(1.0) and a.distance(0.6) == pytest.approx(0.1 / 0.19)
    assert settings["error_mrp"].distance("unswitched") == 1.0
    tables = settings["error_mrp"].tables("unswitched")
    assert tables == {"controller": {"law": str(law_script(UNSWITCHED_LAW))}}
    assert settings["delta"].tables(0.05) == {"controller": {"delta": 0.05}}  # every axis of every agent
    assert paper_scenario("1").replace(**settings["delta"].tables(0.05)).law_parameters()[5]["delta"] == (0.05,) * 3
    assert settings["tolerance"].grading and settings["tolerance"].tables(0.1) == {}


def test_scenario_text_round_trips():
    settings = {s.name: s for s in es.search_settings(run_scenario("paper", SPECS["case1"], True))}
    cand = es.Candidate((("torque_limit", 47.7), ("integration", "rk4 dt = 0.005 s")))
    data = es.candidate_source("paper", cand, settings)
    text = es.scenario_text(data, ["a comment"])
    assert text.startswith('# a comment\nextends = "paper"\n')
    assert tomllib.loads(text) == data
    assert cand.key() == "explain_torque_limit_47.7__integration_rk4_dt_0.005_s"


def test_unswitched_composition_is_the_shadow_of_the_switched_error():
    from fsmctl.model.generated_code import casadi_function

    rng = np.random.default_rng(7)
    sigma = rng.uniform(-1, 1, (200, 3)) * 0.57
    sigma_d = rng.uniform(-1, 1, (200, 3)) * 0.57
    unswitched = fc._compose(sigma, -sigma_d)
    switched = np.array(
        [np.asarray(casadi_function("mrp_error")(s, d)).ravel() for s, d in zip(sigma, sigma_d, strict=True)]
    )
    n2 = np.sum(unswitched**2, axis=1)
    shadow = np.where(n2[:, None] > 1, -unswitched / n2[:, None], unswitched)
    assert np.allclose(shadow, switched, atol=1e-12)
    assert (n2 > 1).any() and (n2 < 1).any()  # both sets occur
    theta = fc._angle_deg(unswitched)
    assert np.allclose(np.where(n2 > 1, 360 - theta, theta), fc._angle_deg(switched))


# ----------------------------------------------------------------------------- the law variant


def test_switched_twin_flies_bit_identically_to_the_builtin_law(tmp_path):
    from fsmctl import paper_scenario

    text = law_script(UNSWITCHED_LAW).read_text()
    assert text.count("SHADOW_SWITCH = False") == 1
    twin = tmp_path / "fsm_shadow.py"
    twin.write_text(text.replace("SHADOW_SWITCH = False", "SHADOW_SWITCH = True"))
    diff = [(a, b) for a, b in zip(text.splitlines(), twin.read_text().splitlines(), strict=True) if a != b]
    assert diff == [("SHADOW_SWITCH = False", "SHADOW_SWITCH = True")]  # the switch is the only difference
    base = paper_scenario("1").replace(simulation={"t_final": 3.0})
    builtin = _fly(base)
    shadow = _fly(base.replace(controller={"law": str(twin)}))
    unswitched = _fly(base.replace(controller={"law": str(law_script(UNSWITCHED_LAW))}))
    assert shadow.law.name == "fsm_shadow" and unswitched.law.name == "fsm_unswitched"
    for name in ("sigma", "omega", "u", "u_unsaturated", "broadcast"):
        assert np.array_equal(getattr(shadow, name), getattr(builtin, name)), name
    assert not np.array_equal(unswitched.u_unsaturated, builtin.u_unsaturated)  # the switch matters here
    numbers = fc.figure_numbers(unswitched, unswitched=True)
    assert numbers["error_mrp"] == "unswitched" and numbers["theta_plotted_peak_deg"] > 180.0


def test_a_run_that_fails_reproduces_nothing(tmp_path, monkeypatch):
    """A candidate the simulator cannot fly counts as not reproducing the claim; the search goes on."""
    import fsmctl.simulation.simulator as sim

    real = sim.simulate

    def simulate(scenario, **kw):
        if scenario.controller.torque_limit >= 50.0:
            raise sim.SimulationError("diverged (planted)")
        return real(scenario, **kw)

    monkeypatch.setattr(sim, "simulate", simulate)
    (e,) = explain(
        "paper",
        _claims("settling_27s", verdict=IMPOSSIBLE),
        tmp_path,
        fast=True,
        settings=["torque_limit"],
        checks=["settling_27s"],
        progress=False,
    )
    assert e.status == er.NOT_EXPLAINED and e.searched[0].startswith("torque limit 2-100000 N m")


def test_a_run_whose_worker_keeps_dying_reproduces_nothing_and_the_runs_go_to_the_callers_runner(tmp_path):
    """The explanations fly on the runner they are given (``fsmctl reproduce``'s), and a run whose worker process
    keeps dying (what the campaign runner reports once its retries are spent: ``Task.failed``) is a failed run: it
    reproduces nothing, and the search goes on to the other values."""
    from fsmctl.studies.campaign import WORKER_DIED, Runner

    flown = []

    class DyingWorkers(Runner):
        """Every run of a torque limit >= 50 N m kills its worker; the others fly here."""

        def run(self, tasks, *, on_done=None):
            flown.extend(tasks)
            return [
                t.failed(WORKER_DIED) if dict(t.args[1].changes).get("torque_limit", 0.0) >= 50.0 else t()
                for t in tasks
            ]

    with DyingWorkers(workers=1, interrupts=False) as runner:
        (e,) = explain(
            "paper",
            _claims("settling_27s", verdict=IMPOSSIBLE),
            tmp_path,
            fast=True,
            settings=["torque_limit"],
            checks=["settling_27s"],
            runner=runner,
            progress=False,
        )
    assert e.status == er.NOT_EXPLAINED and e.searched[0].startswith("torque limit 2-100000 N m")
    assert any(dict(t.args[1].changes).get("torque_limit", 0.0) >= 50.0 for t in flown)  # they were tried
    # identical scenarios fly once: no two tasks of a round share a scenario
    assert len({t.key for t in flown}) == len(flown)


def test_a_candidate_that_flies_the_unswitched_law_warns_nothing():
    """The error-MRP candidate switches the law on purpose: flying and recording it emits no LawSwitchWarning (a user
    saw 79 of them on stderr from one `fsmctl reproduce --fast`)."""
    import fsmctl
    from fsmctl.model.laws import LawSwitchWarning
    from fsmctl.studies.explain_runs import simulate_candidate

    settings = {s.name: s for s in es.search_settings(fsmctl.paper_scenario("1"))}
    candidate = es.Candidate((("error_mrp", "unswitched"),))
    data = es.candidate_source("paper", candidate, settings)
    spec = next(s for s in run_plan() if s.key == "case1")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        record = simulate_candidate({**data, "simulation": {"t_final": 0.2}}, candidate, spec, fast=True)
    assert record.law == "fsm_unswitched"
    assert not [w for w in caught if issubclass(w.category, LawSwitchWarning)], [str(w.message) for w in caught]
