"""The wording of ``fsmctl certify``'s report (issue 29, a fresh user's trial): every printed bound rounded outward
(an upper bound up, a lower bound down) while the JSON keeps full values; ``z`` named only for a law with states;
one clear line for per-axis bounds of the wrong length or sign, from Python and the command line alike; a Markdown
table with column names; no zero terms; the guide's JSON table complete.

Oracles: the outcome's full-precision values (the JSON) against the printed decimals, compared as exact fractions;
hand-written counts and messages; the keys of a real certificate's JSON against the guide's table.
"""

from __future__ import annotations

import re
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from fsmctl.cli.main import main
from fsmctl.errors import InputError
from fsmctl.proofs import SearchSettings, StateRegion, Uncertainty, certify_law
from fsmctl.proofs.certificate import Certificate
from fsmctl.proofs.certify_problem import Candidate, CertifyInputError

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "docs" / "examples"
NUM = r"(-?[0-9.]+(?:e[-+][0-9]+)?|inf|nan)"


def _certificate(outcome: dict, *, kind="ultimately bounded", n_states=0, describe="the law's declared V", attempts=()):
    """A certificate record with a given outcome (the report is a function of the record alone)."""
    return Certificate(
        verdict="certified", kind=kind,
        law={"name": "my_pd", "spec": "my_law.py", "error_model": "paper", "manifest_sha256": "0" * 64},
        agent={"number": 1, "scenario": "my-law", "n_states": n_states},
        region=StateRegion(0.1, 0.02), uncertainty=Uncertainty(disturbance=0.001),
        candidate={"kind": "declared", "describe": describe, "expression": "x", "epsilon": None, "P": None},
        outcome=outcome, attempts=[*attempts, {"describe": describe, "verdict": "certified", "why": "the answer"}],
        names=["sigma_e[0]"],
    )  # fmt: skip


def _outcome(v: list[float], *, sos: bool = False) -> dict:
    """An ultimately bounded outcome whose every printed number comes from ``v`` (positive floats)."""
    level = v[0] + v[1]
    return {
        "level": level, "inner_level": v[1], "inner_target": v[2], "boundary_level": 2 * level,
        "level_extent": {"sigma_e[0]": v[3], "sigma_e[1]": v[3] / 3, "omega_e[0]": v[4], "omega_e[2]": v[4] / 7},
        "ultimate_bound": {"sigma_e_max": v[5], "omega_e_max_rad_s": v[6], "attitude_error_max_deg": v[7]},
        "decrease": v[8], "reach_time": v[9],
        "core": {"passed": True, "fraction": 0.5, "mu": v[10], "w0": v[11], "G": v[12], "r_star": v[13]},
        "boxes": 12, "seconds": 1.0, "exhausted": False,
        "volume": {"proved": v[14] / (1 + v[14]), "excluded": 1 / (1 + v[14]), "undecided": 0.0, "positive": 0.0},
        "sos": {"rate": v[15], "detail": "Putinar identity", "seconds": 2.0} if sos else None,
        "counterexample": None, "difficulty": "",
    }  # fmt: skip


def _pairs(lines: list[str], markdown: str, o: dict) -> list[tuple[str, float, str]]:
    """(printed, exact value, "up" | "down") for every bound, level, rate and time of the report."""
    text = "\n".join(lines)
    ub, core, ext = o["ultimate_bound"], o["core"], o["level_extent"]
    c_mid = 0.5 * (o["inner_level"] + o["level"])
    sig = max(v for k, v in ext.items() if k.startswith("sigma"))
    om = max(v for k, v in ext.items() if k.startswith("omega"))
    expect = [
        (rf"V_dot < 0 on \{{{NUM} <= V <= {NUM}\}}; ultimate bound \|sigma_e,k\| <= {NUM}, \|omega_e,k\| <= {NUM} ",
         [(o["inner_level"], "up"), (o["level"], "down"), (ub["sigma_e_max"], "up"), (ub["omega_e_max_rad_s"], "up")]),
        (rf"\n\{{V <= {NUM}\}} lies in \|sigma_e,k\| <= {NUM}, \|omega_e,k\| <= {NUM} rad/s",
         [(o["level"], "down"), (sig, "up"), (om, "up")]),
        (rf"on the core V_dot <= {NUM} \+ {NUM} \|y\| - {NUM} \|y\|\^2, .* outside \|y\| <= {NUM},.*\(mu = {NUM}\)",
         [(core["w0"], "up"), (core["G"], "up"), (core["mu"], "down"), (core["r_star"], "up"), (core["mu"], "down")]),
        (rf"inner set \{{V <= {NUM}\}}: the boxes where V <= {NUM} .* \|sigma_e,k\| <= {NUM} \(attitude error <= "
         rf"{NUM} deg\), \|omega_e,k\| <= {NUM} rad/s",
         [(o["inner_level"], "up"), (o["inner_target"], "up"), (ub["sigma_e_max"], "up"),
          (ub["attitude_error_max_deg"], "up"), (ub["omega_e_max_rad_s"], "up")]),
        (rf"V_dot <= -{NUM} on \{{{NUM} <= V <= {NUM}\}}: from \{{V <= {NUM}\}} the level {NUM} is reached within "
         rf"{NUM} s",
         [(o["decrease"], "down"), (c_mid, "up"), (o["level"], "down"), (o["level"], "down"), (c_mid, "up"),
          (o["reach_time"], "up")]),
    ]  # fmt: skip
    if o["sos"]:
        expect.append((
            rf"V_dot <= -{NUM} \(V - {NUM}\) wherever {NUM} <= V <= {NUM},",
            [(o["sos"]["rate"], "down"), (o["inner_level"], "up"), (o["inner_level"], "up"), (o["level"], "down")],
        ))  # fmt: skip
    else:
        v = o["volume"]
        expect.append((
            rf"proved box by box on {NUM} %, covered by the origin's argument or the inner set {NUM} %",
            [(100 * v["proved"], "down"), (100 * v["excluded"], "down")],
        ))  # fmt: skip
    out = []
    for pattern, values in expect:
        m = re.search(pattern, text)
        assert m, (pattern, text)
        out += [(p, x, d) for p, (x, d) in zip(m.groups(), values, strict=True)]
    table = [
        (rf"\| level c \| {NUM} \|", o["level"], "down"),
        (rf"\| inner level c_in \| {NUM} \|", o["inner_level"], "up"),
    ]
    for pattern, x, d in table:
        m = re.search(pattern, markdown)
        assert m, (pattern, markdown)
        out.append((m.group(1), x, d))
    return out


def _outward(printed: str, x: float, direction: str) -> bool:
    """The printed decimal, read as a double, is on the safe side of ``x`` (the exact double) and close to it."""
    p = float(printed)
    safe = p >= x if direction == "up" else p <= x
    return safe and abs(Fraction(p) - Fraction(x)) <= Fraction(1, 100) * abs(Fraction(x))  # 3 digits or more


def test_the_issue_example_rounds_outward():
    """0.15625 is printed 0.1563 as an upper bound (not 0.1562), and as a lower bound 0.1562."""
    v = [0.15625] * 16
    v[0] = 1.0  # the level: 1.15625
    c = _certificate(_outcome(v))
    head = c.headline()
    assert "|sigma_e,k| <= 0.1563, |omega_e,k| <= 0.1563 rad/s" in head and "<= V <= 1.15625}" in head
    assert "{0.15625 <= V" in head  # a level with 6 digits is exact
    assert any("V_dot <= -0.1562 on" in line for line in c.lines())  # the decrease, a lower bound
    assert c.as_dict()["outcome"]["ultimate_bound"]["sigma_e_max"] == 0.15625  # the JSON keeps the full value


@settings(max_examples=60, deadline=None, derandomize=True)
@given(
    st.lists(st.floats(1e-7, 1e4, allow_subnormal=False), min_size=16, max_size=16),
    st.booleans(),
)
def test_every_printed_bound_is_rounded_outward(v, sos):
    o = _outcome(v, sos=sos)
    c = _certificate(o)
    for printed, x, direction in _pairs(c.lines(), c.markdown(), o):
        assert _outward(printed, x, direction), (printed, x, direction)


@pytest.fixture(scope="module")
def pd_disturbed():
    """The documented PD example, ultimately bounded on a small region (about 15 s)."""
    return certify_law(
        EXAMPLES / "my_law.py", scenario=EXAMPLES / "my_law.toml", region=StateRegion(0.05, 0.01),
        uncertainty=Uncertainty(inertia=0.05, disturbance=0.001), settings=SearchSettings(max_seconds=15),
    )  # fmt: skip


def test_a_real_certificate_prints_its_bounds_outward(pd_disturbed):
    c = pd_disturbed
    assert (c.verdict, c.kind) == ("certified", "ultimately bounded")
    o = c.as_dict()["outcome"]  # the JSON's full values
    text = "\n".join(c.lines())
    pairs = [
        (re.search(rf"ultimate bound \|sigma_e,k\| <= {NUM}", text), o["ultimate_bound"]["sigma_e_max"], "up"),
        (re.search(rf"ultimate bound .* \|omega_e,k\| <= {NUM}", text), o["ultimate_bound"]["omega_e_max_rad_s"], "up"),
        (re.search(rf"V_dot < 0 on \{{{NUM} <=", text), o["inner_level"], "up"),
        (re.search(rf"<= V <= {NUM}\}}; ultimate", text), o["level"], "down"),
        (re.search(rf"attitude error <= {NUM} deg", text), o["ultimate_bound"]["attitude_error_max_deg"], "up"),
        (re.search(rf"- {NUM} \|y\|\^2", text), o["core"]["mu"], "down"),
    ]
    for m, x, direction in pairs:
        assert m, text
        assert _outward(m.group(1), x, direction), (m.group(0), x)


def test_z_is_named_only_for_a_law_with_states():
    quadratic = Candidate("quadratic", sp.Integer(0), P=((1.0,),)).describe()
    assert "x = (sigma_e, omega_e, z)" in quadratic  # the candidate's own words
    attempt = [{"describe": quadratic, "verdict": "inconclusive", "why": "not proved"}]
    stateless = _certificate(_outcome([0.1] * 16), describe=quadratic, attempts=attempt)
    report = "\n".join(stateless.lines()) + stateless.markdown()
    assert (
        "omega_e, z)" not in report and report.count("x = (sigma_e, omega_e)") == 5
    )  # V and also tried, in both; the table
    with_states = _certificate(_outcome([0.1] * 16), describe=quadratic, n_states=2)
    assert any("x = (sigma_e, omega_e, z)" in line for line in with_states.lines())


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"disturbance": (0.2, 0.24)}, "uncertainty: disturbance takes one bound or three (N m), got 2"),
        (
            {"reference_rate": [0.1, 0.1, 0.1, 0.1]},
            "uncertainty: reference_rate takes one bound or three (rad/s), got 4",
        ),
        ({"reference_acceleration": ()}, "reference_acceleration takes one bound or three (rad/s^2), got 0"),
        ({"disturbance": -0.1}, "uncertainty: disturbance must be finite and >= 0 (N m), got -0.1"),
        ({"reference_rate": (0.1, float("nan"), 0.1)}, "reference_rate must be finite and >= 0 (rad/s), got 0.1, nan"),
    ],
)
def test_a_bad_per_axis_bound_is_one_clear_line(kwargs, message):
    with pytest.raises(CertifyInputError) as info:
        Uncertainty(**kwargs)
    assert isinstance(info.value, InputError) and message in str(info.value) and "\n" not in str(info.value)
    assert "3 finite" not in str(info.value)


def test_one_or_three_bounds_are_taken():
    u = Uncertainty(disturbance=(0.2, 0.24, 0.22), reference_rate=0.01, reference_acceleration=np.array([1e-4]))
    assert (u.disturbance, u.reference_rate, u.reference_acceleration) == (
        (0.2, 0.24, 0.22), (0.01, 0.01, 0.01), (1e-4, 1e-4, 1e-4),
    )  # fmt: skip


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--disturbance", "0.2", "0.24"], "--disturbance takes one bound or three (N m), got 2"),
        (["--disturbance", "-0.1"], "--disturbance must be finite and >= 0 (N m), got -0.1"),
        (["--reference-acceleration", "0", "-1", "0"], "--reference-acceleration must be finite and >= 0 (rad/s^2)"),
    ],
)
def test_the_command_line_says_the_same_before_any_work(capsys, argv, message):
    code = main(["certify", "--law", "pid", *argv])
    err = capsys.readouterr().err
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1  # no law switched, no search


def test_markdown_table_has_column_names_and_no_zero_terms():
    v = [0.1] * 16
    o = _outcome(v)
    o["core"].update(w0=0.0)
    c = _certificate(o)
    md = c.markdown()
    assert "| | |" not in md and "| item | value |\n|---|---|" in md
    core = next(line for line in c.lines() if line.startswith("on the core"))
    assert core.startswith("on the core V_dot <= 0.1 |y| - 0.1 |y|^2, y = ")
    o["core"].update(G=0.0, r_star=0.0)
    core = next(line for line in _certificate(o).lines() if line.startswith("on the core"))
    assert core.startswith("on the core V_dot <= -0.1 |y|^2, y = (sigma_e, omega_e) divided by the region's")
    text = "\n".join(c.lines()).lower()
    for jargon in ("leaves", "leaf", "screening", "core box", "core or inner set", "scaled by", "1 boxes"):
        assert jargon not in text, jargon


def test_the_guide_names_every_json_field(pd_disturbed):
    guide = (ROOT / "docs" / "guide" / "certify.md").read_text()
    table = guide.split("The JSON file holds the same", 1)[1].split("\n\n", 2)[1]
    d = pd_disturbed.as_dict()
    named = set(re.findall(r"`([a-z_0-9.]+)`", table))
    named |= {".".join(n.split(".")[:i]) for n in named for i in (1, 2)}  # law.manifest_sha256 names law
    missing = [k for k in d if k not in named] + [f"outcome.{k}" for k in d["outcome"] if f"outcome.{k}" not in named]
    assert not missing, missing
    own = (ROOT / "docs" / "guide" / "own-law.md").read_text()
    assert "(certify.md)" in own and "fsmctl certify --law docs/examples/my_law.py" in own


def test_the_stated_sets_are_printed_inside_the_certified_ones():
    """A region's or an uncertainty's bound rounded up would describe a set larger than the one certified."""
    u = Uncertainty(inertia=0.1234567, disturbance=(0.2, 0.0123456789, 0.22), reference_rate=2 / 3)
    text = u.describe()
    assert "|theta_kl| <= 0.123456;" in text and "(0.2, 0.0123456, 0.22) N m" in text
    assert "|omega_d,k| <= 0.666666 rad/s" in text


def test_the_markdown_table_states_the_ultimate_bound_rounded_up():
    v = [0.15625] * 16
    v[0] = 1.0
    markdown = _certificate(_outcome(v)).markdown()
    row = next(line for line in markdown.splitlines() if line.startswith("| ultimate bound |"))
    assert "0.1563" in row and "rad/s" in row
