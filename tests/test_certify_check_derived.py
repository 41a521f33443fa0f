"""``fsmctl certify --check`` re-derives every number a certificate's report prints (issue 29).

Certificates of the documented PD law (``docs/examples/my_law.py``) are written once per module: an ultimately
bounded one by sum of squares (the decrease, reach time, decay rate, extents and ultimate bound), an asymptotic one
by branch and bound (the origin's constants, the extents of ``{V <= c}``, the search's statistics) and a refutation
of ``pd_unstable.py`` (the counterexample's values).  Copies are tampered by 1 %: towards a more favourable
statement, which must fail with a line naming the field, the file's value and the recomputed one; towards a weaker
one, which passes as a weaker true statement.  Oracles: the untampered values themselves (the certify run's), the
1 % factor (far beyond the stated tolerance), and for the sum of squares' decrease and reach time the closed forms
``m = lambda (c - c_in) / 2``, ``T = (c - c_mid) / m`` from the exact ``lambda`` of the recorded identity.
"""

from __future__ import annotations

import copy
import json
from fractions import Fraction
from pathlib import Path

import pytest

from fsmctl.proofs import SearchSettings, StateRegion, Uncertainty, certify_law, check_certificate
from fsmctl.proofs.certify_check import DERIVED_TOLERANCE, HIGHER, LOWER, Derived, compare_derived
from fsmctl.proofs.certify_report import bound_up

EXAMPLES = Path(__file__).resolve().parents[1] / "docs" / "examples"
UP, DOWN = 1.01, 0.99


def _write(tmp_path_factory, name, law, **kw) -> dict:
    c = certify_law(EXAMPLES / law, scenario=EXAMPLES / "my_law.toml", **kw)
    path = tmp_path_factory.mktemp(name) / "certificate.json"
    c.write(path)
    return json.loads(path.read_text())


@pytest.fixture(scope="module")
def sos_file(tmp_path_factory):
    d = _write(
        tmp_path_factory, "sos", "my_law.py", region=StateRegion(0.2, 0.05),
        uncertainty=Uncertainty(disturbance=(0.02, 0.024, 0.022)), settings=SearchSettings(max_seconds=5),
    )  # fmt: skip
    assert (d["verdict"], d["kind"]) == ("certified", "ultimately bounded") and d["outcome"]["sos"]
    return d


@pytest.fixture(scope="module")
def asymptotic_file(tmp_path_factory):
    d = _write(
        tmp_path_factory, "asym", "my_law.py", region=StateRegion(0.1, 0.02), uncertainty=Uncertainty(inertia=0.1),
        settings=SearchSettings(max_seconds=30),
    )  # fmt: skip
    assert (d["verdict"], d["kind"]) == ("certified", "asymptotic") and d["outcome"]["core"]["passed"]
    return d


@pytest.fixture(scope="module")
def counterexample_file(tmp_path_factory):
    with pytest.warns(UserWarning):  # pd_unstable flies instead of the scenario's my_pd
        d = _write(
            tmp_path_factory, "cex", "pd_unstable.py", region=StateRegion(0.1, 0.02), uncertainty=Uncertainty(),
            settings=SearchSettings(max_seconds=30),
        )  # fmt: skip
    assert d["verdict"] == "counterexample"
    return d


def _check(d: dict, tmp_path: Path):
    path = tmp_path / "tampered.json"
    path.write_text(json.dumps(d))
    return check_certificate(path, arb_sample=2)


def _lines(result, mark: str, field: str) -> list[str]:
    return [line for line in result.lines if line.startswith(f"[{mark}] {field}:")]


def test_sos_decrease_and_reach_time_are_the_closed_forms(sos_file):
    """Oracle: lambda from the recorded identity (exact), m = lambda (c_mid - c_in), T = (c - c_mid) / m."""
    o = sos_file["outcome"]
    lam = float(Fraction(o["sos"]["lambda"]))
    c_in, c = o["inner_level"], o["level"]
    m = lam * (c - c_in) / 2
    assert o["decrease"] == pytest.approx(m, rel=1e-9)
    assert o["reach_time"] == pytest.approx((c - c_in) / 2 / m, rel=1e-9)
    assert o["sos"]["rate"] == pytest.approx(lam, rel=1e-15) and o["sos"]["rate"] <= lam


def test_more_favourable_derived_numbers_fail_by_name(sos_file, tmp_path):
    """Each number tampered by 1 % towards a stronger statement fails, naming the field, the file's value and the
    recomputed (the certify run's) one; a changed headline fails with both texts."""
    d = copy.deepcopy(sos_file)
    o, true = d["outcome"], sos_file["outcome"]
    o["decrease"] *= UP
    o["reach_time"] *= DOWN
    o["sos"]["rate"] *= UP
    o["level_extent"]["sigma_e[2]"] *= DOWN
    o["ultimate_bound"]["omega_e_max_rad_s"] *= DOWN
    o["ultimate_bound"]["attitude_error_max_deg"] *= DOWN
    o["ultimate_bound"]["sigma_e_max"] *= DOWN
    d["headline"] = d["headline"].replace("ultimate bound", "ultimate bound (tight)")
    result = _check(d, tmp_path)
    assert not result.ok
    for field, stated, found in [
        ("outcome.decrease", o["decrease"], true["decrease"]),
        ("outcome.reach_time", o["reach_time"], true["reach_time"]),
        ("outcome.sos.rate", o["sos"]["rate"], true["sos"]["rate"]),
        ("outcome.level_extent.sigma_e[2]", o["level_extent"]["sigma_e[2]"], true["level_extent"]["sigma_e[2]"]),
        ("outcome.ultimate_bound.sigma_e_max", o["ultimate_bound"]["sigma_e_max"], true["ultimate_bound"]["sigma_e_max"]),
        ("outcome.ultimate_bound.omega_e_max_rad_s", o["ultimate_bound"]["omega_e_max_rad_s"],
         true["ultimate_bound"]["omega_e_max_rad_s"]),
        ("outcome.ultimate_bound.attitude_error_max_deg", o["ultimate_bound"]["attitude_error_max_deg"],
         true["ultimate_bound"]["attitude_error_max_deg"]),
    ]:  # fmt: skip
        (line,) = _lines(result, "FAILS", field)
        assert f"the file states {stated:.9g}, re-derived {found:.9g}" in line
        assert "more favourable than proved" in line
    (line,) = [x for x in result.lines if x.startswith("[FAILS] headline:")]
    # rebuilt from the file's outcome (whose tampered numbers fail above): its text, not the file's
    assert (
        repr(d["headline"]) in line and f"<= {bound_up(o['ultimate_bound']['sigma_e_max'])}," in line.split("gives")[1]
    )
    # the untampered rest still re-checks
    assert any(line.startswith("[ok]") and "exactly" in line for line in result.lines)


def test_weaker_derived_numbers_pass_as_weaker_statements(sos_file, tmp_path):
    d = copy.deepcopy(sos_file)
    o = d["outcome"]
    o["decrease"] *= DOWN
    o["reach_time"] *= UP
    o["sos"]["rate"] *= DOWN
    o["ultimate_bound"]["sigma_e_max"] *= UP
    d["headline"] = check_headline = d["headline"].replace(
        f"{sos_file['outcome']['ultimate_bound']['sigma_e_max']:.4g}", f"{o['ultimate_bound']['sigma_e_max']:.4g}"
    )
    assert check_headline != sos_file["headline"]
    result = _check(d, tmp_path)
    assert result.certified, result.lines
    for field in ("outcome.decrease", "outcome.reach_time", "outcome.sos.rate", "outcome.ultimate_bound.sigma_e_max"):
        (line,) = _lines(result, "ok", field)
        assert "weaker than the re-derived" in line


def test_asymptotic_core_extents_and_statistics(asymptotic_file, tmp_path):
    """The origin's constants, the extents of {V <= c} and the search's statistics: a stronger mu, a smaller r*, a
    smaller extent and another volume fraction fail; a larger (weaker) G passes."""
    d = copy.deepcopy(asymptotic_file)
    o = d["outcome"]
    o["core"]["mu"] *= UP
    o["core"]["G"] = 1.0  # the file's G is 0 at an equilibrium: any positive G is a weaker bound
    o["level_extent"]["omega_e[1]"] *= DOWN
    o["volume"]["excluded"] *= DOWN
    o["boxes"] += 1
    result = _check(d, tmp_path)
    assert not result.ok
    assert "more favourable" in _lines(result, "FAILS", "outcome.core.mu")[0]
    assert "more favourable" in _lines(result, "FAILS", "outcome.level_extent.omega_e[1]")[0]
    assert "differs by more than" in _lines(result, "FAILS", "outcome.volume.excluded")[0]
    assert _lines(result, "FAILS", "outcome.boxes")
    assert "weaker" in _lines(result, "ok", "outcome.core.G")[0]
    assert not [line for line in result.lines if "FAILS" in line and "core.G" in line]


def test_asymptotic_file_may_not_claim_a_reach_time(asymptotic_file, tmp_path):
    """An asymptotic certificate proves no decrease on an annulus: a file that states one fails."""
    d = copy.deepcopy(asymptotic_file)
    d["outcome"].update(decrease=1.0, reach_time=1.0, inner_level=0.0)
    result = _check(d, tmp_path)
    assert not result.ok
    assert "no such number" in _lines(result, "FAILS", "outcome.decrease")[0]


def test_counterexample_values(counterexample_file, tmp_path):
    """A refutation's V_dot (a lower bound at its point) may not be raised; its ball and V are recomputed."""
    result = _check(counterexample_file, tmp_path)
    assert result.ok, result.lines
    d = copy.deepcopy(counterexample_file)
    d["outcome"]["counterexample"]["V_dot"] *= UP
    d["outcome"]["counterexample"]["V"] *= DOWN
    result = _check(d, tmp_path)
    assert not result.ok
    assert "more favourable" in _lines(result, "FAILS", "outcome.counterexample.V_dot")[0]
    assert "differs" in _lines(result, "FAILS", "outcome.counterexample.V")[0]
    assert [line for line in result.lines if line.startswith("[FAILS] headline:")]  # it prints V_dot


def test_compare_derived_rule():
    """The rule on its own: within the tolerance either way; beyond it, weaker passes and stronger fails."""
    t = DERIVED_TOLERANCE
    for favourable, stronger, weaker in ((LOWER, 1 - 10 * t, 1 + 10 * t), (HIGHER, 1 + 10 * t, 1 - 10 * t)):
        [(ok, line)] = compare_derived([Derived("x", 2.0 * (1 + t / 2), 2.0, favourable)])
        assert ok and "agrees" in line
        [(ok, line)] = compare_derived([Derived("x", 2.0 * stronger, 2.0, favourable)])
        assert not ok and line.startswith("x: the file states")
        [(ok, line)] = compare_derived([Derived("x", 2.0 * weaker, 2.0, favourable)])
        assert ok and "weaker" in line
    [(ok, _)] = compare_derived([Derived("x", 2.0 * (1 + 10 * t), 2.0)])
    assert not ok
    assert compare_derived([Derived("x", None, 2.0)]) == []  # not stated: nothing claimed
    [(ok, _)] = compare_derived([Derived("x", 2.0, None)])
    assert not ok
