"""``fsmctl prove --law``: the law checks of :mod:`fsmctl.proofs.law_check`, and that each of them can fail.

The paper's law passes the comparison of its generated code with its SymPy form and the eq 20 closed loop;
a small PD law with a true Lyapunov claim is proved; false claims and a perturbed generated function are
caught.  The wrong laws run the symbolic checks only (no derivation or compilation), so the file stays fast.
"""

from __future__ import annotations

import json
import textwrap
import time

import pytest

from fsmctl.model.laws import LawCode, LawError, resolve_law
from fsmctl.proofs import law_check
from fsmctl.proofs.law_check import KINDS, check_law, load_law_variants

SYMBOLIC = ["closed-loop", "lyapunov"]


def _pd_script(V: str, claimed: str | None, name: str = "pd_test", state: bool = False, region: str = "None") -> str:
    """A PD law ``u = -K sigma_e - P omega_e - K (k_sum sigma_e - received)`` with a Lyapunov declaration.

    ``V`` and ``claimed`` are Python expressions in ``K``, ``P``, ``s2 = |sigma|^2``, ``w2 = |omega|^2``,
    ``wJw = omega^T J0 omega`` (and ``z2 = |z|^2`` with ``state``: a decoupled law state, ``z_dot = -z``).
    """
    claim = "None" if claimed is None else claimed
    state_lines = (
        "    z = b.state('x', 3, doc='a decoupled, decaying law state')\n"
        "    b.derivative(z, -z)\n"
        "    z2 = (z.T * z)[0]\n"
        if state
        else ""
    )
    head = textwrap.dedent(
        f"""\
        import sympy as sp
        from fsmctl.symbolic.law import LawBuilder


        def law(error_model):
            b = LawBuilder({name!r}, error_model, doc="MRP PD with consensus on the attitude error")
            K = b.parameter("K", 1.0, unit="N m", minimum=0.0, doc="attitude gain")
            P = b.parameter("P", 10.0, unit="N m s", minimum=0.0, doc="rate gain")
            e = b.error_state()
            b.broadcast("sigma_e", e.sigma_e)
        """
    )
    tail = textwrap.dedent(
        f"""\
            b.torque(-K * e.sigma_e - P * e.omega_e - K * (b.k_sum * e.sigma_e - b.received))
            s2 = (b.sigma.T * b.sigma)[0]
            w2 = (b.omega.T * b.omega)[0]
            wJw = (b.omega.T * b.J0 * b.omega)[0]
            b.lyapunov({V}, claimed_derivative={claim}, region={region}, doc="test candidate")
            return b.build()
        """
    )
    return head + state_lines + textwrap.indent(tail, "    ")


def _write(tmp_path, text: str, name: str = "law.py"):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


# ----------------------------------------------------------------------------------------------- fsm


@pytest.fixture(scope="module")
def fsm_report():
    t0 = time.perf_counter()
    report = check_law("fsm", samples=120, seed=0)
    return report, time.perf_counter() - t0


def test_fsm_generated_code_equals_its_symbolic_form(fsm_report):
    fsm_report, _ = fsm_report
    c = fsm_report.check("generated-equals-symbolic")
    assert (c.kind, c.passed) == ("checked", True), c.detail
    assert c.data["max_relative_error"] <= 1e-9
    assert c.data["compared"] >= 100  # few points fall within 1e-6 of a switching surface
    assert set(c.data["block_errors"]) >= {"constants", "broadcast", "cache", "u", "u_commanded"}


def test_fsm_closed_loop_is_derived_and_is_eq20(fsm_report):
    fsm_report, _ = fsm_report
    c = fsm_report.check("closed-loop")
    assert c.kind == "derived" and c.passed is None
    assert "sigma_e = mrp_error(sigma, 0) = sigma" in c.detail and "[--]" not in c.detail
    assert c.latex and r"\dot\sigma = G(\sigma)" in c.latex
    e = fsm_report.check("closed-loop-eq20")
    assert (e.kind, e.passed) == ("checked", True), e.detail
    assert e.data["symbolic"] is True  # the identity cancels symbolically, not just at sampled points
    assert e.data["max_relative_error"] <= 1e-9


def test_fsm_declares_no_lyapunov_and_points_to_the_paper_claims(fsm_report):
    fsm_report, elapsed = fsm_report
    c = fsm_report.check("lyapunov")
    assert c.kind == "not declared" and c.passed is None
    assert any("fsmctl prove" in n for n in fsm_report.notes)
    assert fsm_report.ok
    assert elapsed < 40


def test_fsm_report_formats(fsm_report):
    fsm_report, _ = fsm_report
    d = fsm_report.to_dict()
    json.dumps(d, allow_nan=False)
    assert d["law"] == "fsm" and d["ok"] is True
    wheel_free = [c for c in law_check.CHECK_IDS if c != "wheels-realise-torque"]  # fsm commands no wheels
    assert [c["id"] for c in d["checks"]] == wheel_free
    assert all(c["kind"] in KINDS for c in d["checks"])
    text = fsm_report.to_text()
    assert text.count("\n") > 8 and "generated-equals-symbolic" in text and "FAILS" not in text
    md = fsm_report.to_markdown()
    assert "$$" in md and "## closed-loop-eq20" in md


# --------------------------------------------------------------------------------- user laws (tmp_path)

PD_V = "2 * K * sp.log(1 + s2) + sp.Rational(1, 2) * wJw"


def test_pd_lyapunov_claim_is_proved_and_its_code_checked(tmp_path):
    spec = _write(tmp_path, _pd_script(PD_V, "-P * w2"), "pd.py")
    report = check_law(spec, samples=60)
    assert report.law == "pd_test" and report.ok, report.to_text()
    assert report.check("generated-equals-symbolic").passed is True
    ly = report.check("lyapunov")
    assert (ly.kind, ly.passed) == ("proved", True), ly.detail
    assert ly.data["identity"] and ly.data["manifestly_nonpositive"]
    assert ly.data["max_vdot"] <= 0
    json.dumps(report.to_dict(), allow_nan=False)
    # its derived folder holds no SymPy: the check needs the script
    folder = resolve_law(spec).folder
    with pytest.raises(LawError, match="derivation script"):
        load_law_variants(str(folder))


def test_false_claim_zero_derivative_is_caught(tmp_path):
    """V_dot = -P |omega|^2 <= 0, but the declared V_dot = 0 is false: not proved, reported as failing."""
    spec = _write(tmp_path, _pd_script(PD_V, "0"))
    ly = check_law(spec, samples=60, checks=SYMBOLIC).check("lyapunov")
    assert ly.kind == "fails" and ly.passed is False, ly.detail
    assert not ly.data["identity"]
    assert "claimed_derivative is not V_dot" in ly.detail


def test_wrong_candidate_fails_with_a_point(tmp_path):
    """V = |omega|^2 with the (wrong) V_dot = -2 P |omega|^2: V_dot has the indefinite term -2 K omega^T J0^-1 sigma,
    which wins for |omega| small against |sigma| (the declared region)."""
    spec = _write(tmp_path, _pd_script("w2", "-2 * P * w2", region='{"sigma": 1.0, "omega": 0.02}'))
    report = check_law(spec, samples=100, checks=SYMBOLIC)
    ly = report.check("lyapunov")
    assert ly.kind == "fails" and ly.passed is False and not report.ok, ly.detail
    assert ly.data["max_vdot"] > 0
    assert set(ly.data["counterexample"]) >= {"sigma", "omega"}


def test_law_states_enter_the_derivative(tmp_path):
    """A decoupled state z (z_dot = -z): V + |z|^2/2 is proved with V_dot = -P |omega|^2 - |z|^2; without a claim
    the same candidate only gets numeric evidence, said to be no proof."""
    V = PD_V + " + z2 / 2"
    proved = check_law(
        _write(tmp_path, _pd_script(V, "-P * w2 - z2", "pdz", state=True), "a.py"), samples=60, checks=SYMBOLIC
    )
    assert proved.check("lyapunov").kind == "proved", proved.check("lyapunov").detail
    assert r"\dot z" in proved.check("closed-loop").latex
    sampled = check_law(
        _write(tmp_path, _pd_script(V, None, "pdz2", state=True), "b.py"), samples=60, checks=SYMBOLIC
    ).check("lyapunov")
    assert sampled.kind == "evidence" and sampled.passed is None
    assert "not a proof" in sampled.detail and sampled.data["fraction_nonpositive"] == 1.0


def test_perturbed_generated_code_is_caught(monkeypatch):
    """A generated torque off by a relative 1e-6 fails the comparison (the check can fail)."""
    original = LawCode.casadi

    def perturbed(self, name):
        f = original(self, name)
        if not name.startswith("law_control_"):
            return f

        def g(*args):
            u, u_commanded, z_dot = f(*args)
            return u, u_commanded * (1 + 1e-6), z_dot

        return g

    monkeypatch.setattr(LawCode, "casadi", perturbed)
    c = check_law("fsm", samples=20, checks=["generated-equals-symbolic"]).check("generated-equals-symbolic")
    assert (c.kind, c.passed) == ("checked", False), c.detail
    assert 1e-7 < c.data["max_relative_error"] < 1e-5
    assert c.data["block_errors"]["u_commanded"] > 1e-9 and c.data["block_errors"]["broadcast"] <= 1e-9
    assert "worst_point" in c.data


# ------------------------------------------------------------------------------------------ plumbing


def test_loading_and_options(tmp_path):
    assert load_law_variants("fsm").name == "fsm"
    assert load_law_variants(str(resolve_law("fsm").folder)).name == "fsm"  # a built-in folder maps to its script
    with pytest.raises(LawError, match="not a built-in law"):
        load_law_variants("no_such_law")
    with pytest.raises(LawError, match="no such derivation script"):
        load_law_variants(str(tmp_path / "missing.py"))
    with pytest.raises(LawError, match="error model"):
        check_law("fsm", error_model="bogus")
    with pytest.raises(LawError, match="unknown law check"):
        check_law("fsm", checks=["nope"])


# ----------------------------------------------------------------------------- wheels-realise-torque

_WRONG_WHEELS = """\
from fsmctl.symbolic.controller import saturate
from fsmctl.symbolic.law import LawBuilder


def law(error_model):
    b = LawBuilder("wrong_wheels", error_model, doc="a PD law whose wheel commands are G^T u, not pinv(G) u")
    e = b.error_state()
    b.broadcast("sigma_e", e.sigma_e)
    u = -2.0 * e.sigma_e - 8.0 * e.omega_e
    b.torque(u)
    w = b.reaction_wheels(4)
    b.wheel_torques(-w.spin_axes.T * saturate(u, b.u_max))
    return b.build()
"""


def test_the_wheel_commands_of_fsm_wheels_produce_its_body_torque():
    """fsm_wheels: -G u_w = sat(u) to round-off while its null motion moves the commands by N m."""
    c = check_law("fsm_wheels", checks=["wheels-realise-torque"], samples=40).check("wheels-realise-torque")
    assert c.kind == "checked" and c.passed is True
    assert c.data["max_relative_error"] < 1e-13 and c.data["largest_null_motion"] > 0.1
    assert check_law("pid", checks=["wheels-realise-torque"], samples=5).checks == ()  # no wheels: not applicable


def test_wheel_commands_that_do_not_produce_the_torque_fail(tmp_path):
    """A planted law commanding u_w = -G^T u (the transpose, not the pseudo-inverse): G G^T u != u."""
    script = tmp_path / "wrong_wheels.py"
    script.write_text(_WRONG_WHEELS)
    report = check_law(str(script), checks=["wheels-realise-torque"], samples=20)
    c = report.check("wheels-realise-torque")
    assert c.passed is False and not report.ok
    assert c.data["max_relative_error"] > 0.1
    assert "[FAILS] max ||-G u_w - u||_inf" in c.detail and "worst point" in c.detail
