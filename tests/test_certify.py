"""``fsmctl certify`` (issue 29): rigorous Lyapunov certificates, refutations and their re-check.

Independent oracles: the analytic region of attraction of ``tests/data/laws/pd_bistable_state.py`` (``|x| < 1``);
the analytic ``V_dot`` of the unstable and wrong-candidate laws (``+P |omega|^2``, ``2K sigma^T omega - P |omega|^2``)
evaluated in NumPy at the counterexample; Euler's equations written out in NumPy for the closed loop's vector field;
dense sampling of ``V_dot`` for the soundness of a certificate.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from fsmctl.model.laws import resolve_law
from fsmctl.proofs.certificate import certify_law, check_certificate, read_certificate
from fsmctl.proofs.certify import SearchSettings
from fsmctl.proofs.certify_problem import StateRegion, Uncertainty, build_problem

ROOT = Path(__file__).resolve().parents[1]
LAWS = ROOT / "tests" / "data" / "laws"
MY_LAW, MY_SCENARIO = ROOT / "docs" / "examples" / "my_law.py", ROOT / "docs" / "examples" / "my_law.toml"
FAST = SearchSettings(max_seconds=30.0)
J0 = np.diag([20.0, 25.0, 30.0])  # my_law.toml's first agent


def _certify(law, **kw):
    kw.setdefault("scenario", MY_SCENARIO)
    kw.setdefault("settings", FAST)
    return certify_law(str(law), **kw)


def _recheck_scaled(path, tmp_path, key, factor):
    """Re-check a copy of a certificate file whose ``outcome[key]`` is multiplied by ``factor``."""
    d = json.loads(path.read_text())
    d["outcome"][key] *= factor
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(d))
    return check_certificate(bad, arb_sample=2)


def _skew(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def test_closed_loop_is_eulers_equations():
    """The vector field at random points (state and uncertainty) against Euler's equations written out in NumPy."""
    code = resolve_law(str(MY_LAW))
    region, unc = StateRegion(0.5, 0.1), Uncertainty(inertia=0.1, disturbance=0.2, reference_rate=0.01)
    p = build_problem(code, "exact", J0, np.array([4.0, 12.0, 1.0]), np.inf, region, unc)
    import casadi as ca

    f = ca.Function("f", [p.x], [p.field])
    rng = np.random.default_rng(1)
    for _ in range(20):
        x = rng.uniform(p.lo, p.hi)
        se, we, th, d, wd, wdd = x[:3], x[3:6], x[6:9], x[9:12], x[12:15], x[15:18]
        J = J0 * (1 + np.diag(th))  # diagonal J0: the three non-zero entries
        s2 = se @ se
        S = _skew(se)
        C = np.eye(3) + (8 * S @ S - 4 * (1 - s2) * S) / (1 + s2) ** 2
        w = we + C @ wd
        u = -4.0 * se - 12.0 * we  # my_pd isolated: the consensus term vanishes
        wdot = np.linalg.solve(J, u + d - np.cross(w, J @ w))
        G = 0.25 * ((1 - s2) * np.eye(3) + 2 * S + 2 * np.outer(se, se))
        expected = np.concatenate([G @ we, wdot + np.cross(we, C @ wd) - C @ wdd])
        np.testing.assert_allclose(np.array(f(x)).ravel(), expected, rtol=1e-12, atol=1e-15)


@pytest.fixture(scope="module")
def pd_certificate(tmp_path_factory):
    cert = _certify(MY_LAW, region=StateRegion(0.1, 0.02), uncertainty=Uncertainty(inertia=0.1))
    path = tmp_path_factory.mktemp("cert") / "my_pd.certificate.json"
    cert.write(path, path.with_suffix(".md"))
    return cert, path


def test_pd_example_certified_asymptotic_with_inertia_uncertainty(pd_certificate):
    cert, _ = pd_certificate
    assert (cert.verdict, cert.kind) == ("certified", "asymptotic")
    assert cert.candidate["kind"] == "declared + cross term"  # the declared V_dot = -P |omega|^2 is semidefinite
    assert cert.outcome["core"]["passed"]
    assert cert.outcome["level"] > 0


def test_certificate_is_sound_against_dense_sampling(pd_certificate):
    """V_dot < 0 at 20,000 random points of the region x uncertainty (floats: an independent spot check)."""
    cert, _ = pd_certificate
    code = resolve_law(str(MY_LAW))
    p = build_problem(code, "exact", J0, np.array([4.0, 12.0, 1.0]), np.inf, cert.region, cert.uncertainty)
    from fsmctl.proofs.certify_problem import candidate_from_record

    V = candidate_from_record(cert.candidate, 0)
    _, _, fW, _ = p.lyapunov(V)
    rng = np.random.default_rng(7)
    x = rng.uniform(p.lo, p.hi, size=(20_000, p.lo.size))
    x = x[np.linalg.norm(x[:, :6], axis=1) > 1e-6]
    vals = np.array(fW.map(x.shape[0])(x.T)).ravel()
    assert vals.max() < 0


def test_certificate_file_rechecks(pd_certificate):
    cert, path = pd_certificate
    result = check_certificate(path, arb_sample=8)
    assert result.ok, result.lines
    assert any("partition of the region" in line for line in result.lines)
    md = path.with_suffix(".md").read_text()
    assert "certified" in md
    assert r"| region | \|sigma_e,k\| <= 0.1" in md  # a table cell's | escaped
    assert cert.attempts[-1] == {"describe": cert.candidate["describe"], "verdict": "certified", "why": "the answer"}


def test_tampered_certificate_fails_recheck(pd_certificate, tmp_path):
    """A certificate whose level is raised past V's minimum on the region's boundary does not re-check."""
    _, path = pd_certificate
    result = _recheck_scaled(path, tmp_path, "level", 4)
    assert not result.ok
    assert any("FAILS" in line and "boundary" in line for line in result.lines)


def test_unstable_law_refuted_with_a_confirmed_counterexample():
    cert = _certify(MY_LAW.parent / "pd_unstable.py", region=StateRegion(0.1, 0.02), uncertainty=Uncertainty())
    assert cert.verdict == "counterexample"
    c = cert.outcome["counterexample"]
    assert c["confirmed"]
    w = np.array([c["point"][f"omega_e[{k}]"] for k in range(3)])
    # the analytic V_dot = +P |omega|^2 with my_law.toml's P = 12 (the scenario's [controller] value carries over)
    assert np.isclose(c["V_dot"], 12.0 * w @ w, rtol=1e-9)


def test_wrong_candidate_refuted():
    """With the declared V only, the wrong candidate is refuted (with "auto" fsmctl would find a V of its own)."""
    cert = _certify(
        LAWS / "pd_wrong_v.py", region=StateRegion(0.2, 0.05), uncertainty=Uncertainty(), candidates="declared"
    )
    assert cert.verdict == "counterexample"
    c = cert.outcome["counterexample"]
    s = np.array([c["point"][f"sigma_e[{k}]"] for k in range(3)])
    w = np.array([c["point"][f"omega_e[{k}]"] for k in range(3)])
    analytic = 2 * 4.0 * s @ w - 12.0 * w @ w  # V_dot of the 3x weighted candidate along the PD loop
    assert analytic > 0
    assert np.isclose(c["V_dot"], analytic, rtol=1e-9, atol=1e-15)


def test_known_region_of_attraction_certified_within_tolerance():
    """``x_dot = -x (1 - x^2)`` attracts exactly |x| < 1: the declared V is certified on |x| <= 0.9 (the analytic
    boundary within the stated tolerance 0.1); the core grows along the attitude inputs, not along x (the Hessian of
    -x^2 (1 - x^2) is negative only for |x| < 1/sqrt(6))."""
    cert = _certify(
        LAWS / "pd_bistable_state.py",
        region=StateRegion(0.02, 0.005, 0.9),
        uncertainty=Uncertainty(),
        candidates="declared",
    )
    assert (cert.verdict, cert.kind) == ("certified", "asymptotic")
    f = cert.outcome["core"]["fractions"]
    assert f[-1] * 0.9 < 1 / np.sqrt(6) and min(f[:6]) >= f[-1]


def test_known_region_of_attraction_boundary_refuted_beyond_it():
    """``x_dot = -x (1 - x^2)`` attracts exactly |x| < 1: on |x| <= 1.05 the declared V is refuted at |x| > 1."""
    cert = _certify(
        LAWS / "pd_bistable_state.py",
        region=StateRegion(0.02, 0.005, 1.05),
        uncertainty=Uncertainty(),
        candidates="declared",
    )
    assert cert.verdict == "counterexample"
    assert 1.0 < abs(cert.outcome["counterexample"]["point"]["z[0]"]) <= 1.05


def test_monotone_in_the_uncertainty():
    """What is certified for a larger inertia set is certified for a smaller one; a refutation persists."""
    small = _certify(MY_LAW, region=StateRegion(0.1, 0.02), uncertainty=Uncertainty(inertia=0.02))
    large = _certify(MY_LAW, region=StateRegion(0.1, 0.02), uncertainty=Uncertainty(inertia=0.1))
    assert large.verdict == "certified"
    assert small.verdict == "certified"
    unstable = [
        _certify(
            MY_LAW.parent / "pd_unstable.py", region=StateRegion(0.1, 0.02), uncertainty=Uncertainty(inertia=r)
        ).verdict
        for r in (0.0, 0.1)
    ]
    assert unstable == ["counterexample", "counterexample"]


@pytest.fixture(scope="module")
def ub_certificate(tmp_path_factory):
    cert = _certify(MY_LAW, region=StateRegion(0.1, 0.02), uncertainty=Uncertainty(disturbance=0.005))
    path = tmp_path_factory.mktemp("ub") / "my_pd.certificate.json"
    cert.write(path, path.with_suffix(".md"))
    return cert, path


def test_disturbance_gives_ultimate_boundedness_never_asymptotic(ub_certificate):
    """Oracle: the equilibrium under a constant disturbance d along an axis, K sigma = d (MRP PD, J = J0, small
    sigma: sigma* = d / K = 0.00125), lies inside the certified ultimate bound, which is well inside the region."""
    cert, _ = ub_certificate
    assert (cert.verdict, cert.kind) == ("certified", "ultimately bounded")
    ub = cert.outcome["ultimate_bound"]
    assert 0.005 / 4.0 < ub["sigma_e_max"] < 0.1
    assert 0 < cert.outcome["inner_level"] < cert.outcome["level"]


def test_ultimately_bounded_certificate_is_sound_and_rechecks(ub_certificate, tmp_path):
    """V_dot < 0 at random points of {c_in < V <= c} (floats), the file re-checks, and a lowered c_in does not."""
    cert, path = ub_certificate
    code = resolve_law(str(MY_LAW))
    p = build_problem(code, "exact", J0, np.array([4.0, 12.0, 1.0]), np.inf, cert.region, cert.uncertainty)
    from fsmctl.proofs.certify_problem import candidate_from_record

    fV, _, fW, _ = p.lyapunov(candidate_from_record(cert.candidate, 0))
    rng = np.random.default_rng(11)
    near = np.concatenate([np.full(3, 0.03), p.hi[3:]])  # the annulus is near sigma_e = 0: sample more there
    x = rng.uniform(np.maximum(p.lo, -near), np.minimum(p.hi, near), size=(50_000, p.lo.size))
    v = np.array(fV.map(x.shape[0])(x.T)).ravel()
    annulus = (v > cert.outcome["inner_level"]) & (v <= cert.outcome["level"])
    assert annulus.sum() > 100
    assert np.array(fW.map(int(annulus.sum()))(x[annulus].T)).max() < 0
    assert check_certificate(path, arb_sample=4).ok
    result = _recheck_scaled(path, tmp_path, "inner_level", 0.25)
    assert not result.ok
    assert any("FAILS" in line for line in result.lines)


def test_core_keeps_the_largest_box_where_the_hessian_is_negative_definite():
    """Analytic oracle: W = -(y1^2 + y2^2) + a y1^3 has the Hessian diag(-2 + 6 a y1, -2); the core test asks
    H + 2 mu I negative definite with mu = 2/16, i.e. y1 < 1.75 / (6 a): the largest of the fractions 0.25, 0.5, 1
    is 0.5 for a = 0.5 (bound 0.58) and 1 for a = 0.25 (bound 1.17)."""
    import casadi as ca

    from fsmctl.proofs.certify_core import quadratic_core

    x = ca.SX.sym("x", 2)
    for a, expected in ((0.5, 0.5), (0.25, 1.0)):
        W = -(x[0] ** 2 + x[1] ** 2) + a * x[0] ** 3
        core = quadratic_core(x, W, 2, np.array([-1.0, -1.0]), np.array([1.0, 1.0]), fractions=(0.25, 0.5, 1.0))
        assert core["passed"] and core["fraction"] == expected and core["mu"] == 0.125


def test_read_certificate_refuses_other_files(tmp_path):
    from fsmctl.proofs.certificate import CertificateError

    bad = tmp_path / "x.json"
    bad.write_text("{}")
    with pytest.raises(CertificateError, match="not a certificate"):
        read_certificate(bad)
