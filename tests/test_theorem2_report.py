"""What a reader of ``fsmctl prove theorem2-delta`` and ``fsmctl certify`` sees: the verdict first, an aligned table
of the certified requirement per agent and axis, witnesses without floating-point noise, agents counted from 1.

Oracles: the claim's own JSON data at full precision (every printed interval must enclose it, every per-axis verdict
must follow from it by the definitions of Theorem 2: met when delta > upper, missed when delta < lower); the
scenario file read with tomllib (the agent a certificate names is the one of that number in the file); exact
float comparisons for the outward rounding.
"""

from __future__ import annotations

import json
import math
import re
import tomllib
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import fsmctl
from fsmctl.cli.main import main
from fsmctl.proofs import ProofContext, run_claims
from fsmctl.proofs.report import format_table, to_json, to_markdown
from fsmctl.proofs.rounding import round_outward
from fsmctl.proofs.theorem2 import Region
from fsmctl.proofs.theorem2_bound import PROVE_BUDGET, AgentBound, AxisBound, Theorem2Bound
from fsmctl.proofs.theorem2_report import format_point, requirement_table, verdict_line

EXAMPLES = Path(__file__).resolve().parents[1] / "docs" / "examples"
ROW = re.compile(
    r"^ {2}(?P<agent>[\d, -]*?)\s+(?P<axis>\d)\s+(?P<delta>\S+)\s+\[(?P<lo>\S+), (?P<hi>\S+)\]\s+(?P<v>.+)$"
)


def _verdict(configured: float, lower: float, upper: float, proportional: bool) -> str:
    """Theorem 2's reading of one axis, written out independently of the module under test."""
    if configured > upper:
        return "met"
    if proportional and configured < lower:
        return "MISSED"
    return "open"


def _agents(label: str, previous: list[int]) -> list[int]:
    if not label:
        return previous
    if "-" in label:
        a, b = label.split("-")
        return list(range(int(a), int(b) + 1))
    return [int(x) for x in label.split(",")]


def _rows(lines: list[str]) -> list[dict]:
    """The table's rows parsed back: agents (1-based), axis, configured delta, printed interval, verdict word."""
    out, agents = [], []
    for line in lines:
        m = ROW.match(line)
        if m:
            agents = _agents(m["agent"].strip(), agents)
            out.append({"agents": agents, "axis": int(m["axis"]), "delta": float(m["delta"]), "lo": float(m["lo"]),
                        "hi": float(m["hi"]), "verdict": m["v"].split(":")[0]})  # fmt: skip
    return out


# ----------------------------------------------------------------------------------------------- formatting units


@settings(max_examples=300, deadline=None)
@given(st.floats(min_value=1e-30, max_value=1e30, allow_nan=False, allow_infinity=False))
def test_printed_bounds_are_rounded_outward_to_three_digits(x):
    down, up = round_outward(x, "down"), round_outward(x, "up")
    assert float(down) <= x <= float(up)
    for text in (down, up):
        mantissa = re.sub(r"e[+-]?\d+$", "", text).replace(".", "").lstrip("0")
        assert len(mantissa.rstrip("0")) <= 3
    assert float(up) <= float(down) * 1.0101  # tight: one unit in the third digit at most (100 -> 101)


def _synthetic() -> Theorem2Bound:
    """Agents 1-3 identical (proportional Delta_J, each axis a different verdict), agent 5 non-proportional."""
    ax = lambda k, c, lo, hi: AxisBound(k, c, hi, lo, (), False, 10, 0.1)  # noqa: E731
    groups = (
        AgentBound((1, 2, 3), 0.3, (ax(1, 0.005, 0.30032, 1.8461), ax(2, 0.005, 0.0011, 0.0042), ax(3, 0.005, 0.004, 0.006))),
        AgentBound((5,), None, (ax(1, 0.005, 0.01, 0.02), ax(2, 0.5, 0.01, 0.02), ax(3, 0.005, 0.001, math.inf))),
    )  # fmt: skip
    return Theorem2Bound(Region(), groups, None, "open", PROVE_BUDGET, 1.0)


def test_the_table_has_one_aligned_row_per_agent_and_axis_with_the_verdict_theorem2_gives():
    cert = _synthetic()
    lines = requirement_table(cert)
    rows = _rows(lines)
    assert len(rows) == 6 and len(lines) == 7  # a header and a row per group and axis
    assert {line.index("[") for line in lines[1:]} == {lines[0].index("required")}  # the interval column aligned
    assert {line.index(r["verdict"]) for line, r in zip(lines[1:], rows, strict=True)} == {lines[0].index("verdict")}
    expected = [(g.agents, a, g.kappa is not None) for g in cert.groups for a in g.axes]
    for row, (agents, a, proportional) in zip(rows, expected, strict=True):
        assert row["agents"] == list(agents) and row["axis"] == a.axis and row["delta"] == a.configured
        assert row["lo"] <= a.lower and (a.upper <= row["hi"] or math.isinf(a.upper))
        assert row["verdict"] == _verdict(a.configured, a.lower, a.upper, proportional)
    assert [r["verdict"] for r in rows] == ["MISSED", "met", "open", "open", "met", "open"]
    # one axis below its lower bound (proportional Delta_J) refutes; the count is over every agent's axes
    assert verdict_line(cert).endswith("? REFUTED: below it on 3 of 12 axes")
    only_general = Theorem2Bound(Region(), cert.groups[1:], None, "open", PROVE_BUDGET, 1.0)
    assert verdict_line(only_general).endswith("? OPEN: above on 1, below on 0, inside on 2 of 3 axes "
                                               "(inside: delta within the certified interval)")  # fmt: skip


def test_a_witness_coordinate_at_rounding_level_reads_as_zero_and_says_what_it_was():
    assert format_point([8.48e-16, -0.05, 0.05]) == ("(~0, -0.05, 0.05)", [(1, 8.48e-16)])
    assert format_point([1e-3, -0.05, 0.05])[0] == "(0.001, -0.05, 0.05)"  # small but meaningful: kept
    assert format_point([0.0, 0.1, 0.0]) == ("(0, 0.1, 0)", [])


# ----------------------------------------------------------------------------------------------- the paper's case


@pytest.fixture(scope="module")
def paper_result():
    """theorem2-delta on the paper's Case 1 over the default region (refuted), once for the module (~25 s)."""
    return run_claims(["theorem2-delta"], ProofContext(fsmctl.paper_scenario("1"), Region(), n_random=50), workers=1)


def test_the_verdict_comes_first_in_one_short_line(paper_result):
    r = paper_result[0]
    first = r.detail.splitlines()[0]
    assert first.startswith("does delta_i exceed Theorem 2's certified requirement on every axis? REFUTED")
    n = sum(3 * len(g["agents"]) for g in r.data["certified"]["groups"])
    assert first.endswith(f"below it on {n} of {n} axes") and n == 18 and len(first) <= 116
    table = format_table(paper_result)
    assert next(line for line in table.splitlines() if line.startswith("    ")) == f"    {first}"  # not wrapped


def test_every_printed_interval_encloses_the_json_and_agents_count_from_1(paper_result):
    r = paper_result[0]
    data = json.loads(to_json(paper_result))["claims"][0]["data"]
    rows = _rows(r.detail.splitlines())
    groups = data["certified"]["groups"]
    assert len(rows) == 3 * len(groups)
    for row, (group, a) in zip(rows, [(g, a) for g in groups for a in g["axes"]], strict=True):
        assert row["agents"] == group["agents"] and row["axis"] == a["axis"]
        assert row["lo"] <= a["lower"] <= a["upper"] <= row["hi"]
        proportional = group["kappa"] is not None
        assert row["verdict"] == _verdict(a["configured"], a["lower"], a["upper"], proportional) == "MISSED"
    assert sorted(x for g in groups for x in g["agents"]) == [1, 2, 3, 4, 5, 6]  # as the paper: agents 1..6
    assert [a["agent"] for a in data["agents"]] == [1, 2, 3, 4, 5, 6]
    p = data["certified"]["reaching_refuted_at"]
    assert f"reaching condition REFUTED for agent {p['agent']} " in r.detail and p["agent"] in range(1, 7)
    # the table stays aligned in the console (never wrapped) and in the Markdown report (a block)
    table = [line for line in format_table(paper_result).splitlines() if ROW.match(line[4:])]
    assert len(table) == len(rows) and len({line.index("[") for line in table}) == 1
    md = to_markdown(paper_result)
    assert "```text\nagent  axis  delta (1/s^2)" in md and "\n- agent  axis" not in md


def test_the_refuting_point_shows_no_floating_point_noise(paper_result):
    r = paper_result[0]
    p = json.loads(to_json(paper_result))["claims"][0]["data"]["certified"]["reaching_refuted_at"]["point"]
    lines = r.detail.splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("reaching condition REFUTED"))
    point = lines[at + 1 : at + 6]
    assert [line.split("=")[0].strip() for line in point] == ["sigma_e", "omega_e", "omega_d", "u_d", "omega_d_dot"]
    assert point[1].endswith("rad/s") and point[3].endswith("N m") and point[4].endswith("rad/s^2")
    shown = [c.strip() for line in point for c in line.split("(")[1].split(")")[0].split(",")]
    assert not any(re.search(r"e-(1\d|[2-9]\d)", c) for c in shown)  # no 8.48e-16
    for c, x, vector in zip(shown, p, [p[3 * (i // 3) : 3 * (i // 3) + 3] for i in range(15)], strict=True):
        if c == "~0":
            assert 0 < abs(x) < 1e-9 * max(abs(v) for v in vector)
        else:
            assert float(c) == pytest.approx(x, rel=6e-3, abs=0)
    if "~0" in shown:
        assert lines[at + 6].startswith("~0: zero up to the search's floating-point rounding")


# ----------------------------------------------------------------------------------------------- fsmctl certify


def test_a_certificate_names_its_agent_from_1_as_the_paper_and_agent_option(capsys, tmp_path):
    code = main(["certify", "--law", str(EXAMPLES / "pd_unstable.py"), "--scenario", str(EXAMPLES / "my_law.toml"),
                 "--agent", "2", "--region-sigma", "0.05", "--region-omega", "0.01", "--seconds", "15",
                 "--no-progress", "--inertia-uncertainty", "0", "--out", str(tmp_path)])  # fmt: skip
    text = capsys.readouterr().out
    assert code == 1 and "agent 2 of my-law" in text
    d = json.loads((tmp_path / "certificate.json").read_text())
    second = tomllib.loads((EXAMPLES / "my_law.toml").read_text())["agents"][1]  # the file's second [[agents]]
    assert d["agent"]["number"] == 2 and "index" not in d["agent"]
    assert d["agent"]["J0_kg_m2"] == second["J0"]
    assert "| agent | 2 of `my-law` |" in (tmp_path / "certificate.md").read_text()
