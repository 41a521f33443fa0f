"""The `fsmctl prove` command line: listing, selection, output formats, exit codes 0/1/2."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from fsmctl.cli import main
from fsmctl.proofs.claims import claim_ids

DATA = Path(__file__).parent / "data"
CHEAP = ["lemma2-sqrt-sum", "zero-sum", "complete-square", "theorem1-gains"]


def _run(capsys, *argv):
    code = main(["prove", *argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_list(capsys):
    code, out, _ = _run(capsys, "--list")
    assert code == 0
    for cid in claim_ids():
        assert cid in out


def test_selected_claims_exit_0(capsys):
    code, out, _ = _run(capsys, *CHEAP, "--jobs", "1")
    assert code == 0
    assert "scenario paper case 1" in out and "every claim as expected" in out
    assert "remark6" not in out


def test_json_one_object_per_claim(capsys):
    code, out, _ = _run(capsys, *CHEAP, "--json")
    assert code == 0
    rows = json.loads(out)
    assert [r["id"] for r in rows] == CHEAP
    for r in rows:
        assert {"id", "equations", "verdict", "detail", "seconds"} <= set(r)


def test_report_markdown_with_latex(capsys, tmp_path):
    path = tmp_path / "proof.md"
    code, _, _ = _run(capsys, "complete-square", "gamma-condition", "--report", str(path))
    assert code == 0
    text = path.read_text()
    assert "# fsmctl prove" in text and "$$" in text and r"\kappa_{ij}" in text and "erratum" in text


def test_theorem2_default_region_fails_for_paper_delta(capsys):
    code, out, _ = _run(capsys, "theorem2-delta", "--samples", "100")
    assert code == 1
    assert "fails for this scenario" in out and "INSUFFICIENT" in out


def test_theorem2_reference_only_region_is_numeric(capsys):
    code, out, _ = _run(capsys, "theorem2-delta", "--region-sigma", "0", "--region-omega", "0")
    assert code == 0 and "numeric" in out


def test_scenario_violating_theorem1_exits_1_with_explanation(capsys):
    code, out, _ = _run(capsys, "theorem1-gains", "--scenario", str(DATA / "prove_theorem1_violation.toml"))
    assert code == 1
    assert "FAILS pair 1-2" in out and "smallest fix" in out and "k^i_12 = 2 < max_t k^j_12(t) = 5" in out


def test_case_option_on_a_user_file(capsys):
    path = str(DATA / "prove_small.toml")
    assert _run(capsys, "theorem1-gains", "--scenario", path)[0] == 0
    code, out, _ = _run(capsys, "theorem1-gains", "--scenario", path, "--case", "weak")
    assert code == 1 and "case weak" in out


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["no-such-claim"], "unknown claim id(s) no-such-claim"),
        (["--scenario", str(DATA / "prove_bad_syntax.toml")], "not valid TOML"),
        (["--scenario", str(DATA / "prove_bad_alpha.toml")], "0.5 < alpha < 1"),
        (["--scenario", str(DATA / "prove_negative_delta.toml")], "delta: every component must be > 0"),
        (["--scenario", str(DATA / "missing.toml")], "cannot read scenario file"),
        (["--case", "7"], "no case '7'"),
        (["--region-omega", "nan"], "--region-omega must be a finite number"),
        (["--region-sigma", "2"], "--region-sigma must be <= 1"),
        (["--jobs", "0"], "--jobs must be >= 1"),
    ],
)
def test_input_errors_exit_2_with_one_line(capsys, argv, message):
    code, out, err = _run(capsys, *argv)
    assert code == 2
    assert message in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert out == ""


def test_console_script_exit_codes():
    """The installed entry point: no traceback, exit 2 on an unknown claim."""
    proc = subprocess.run(
        [sys.executable, "-c", "import sys; from fsmctl.cli import main; sys.exit(main())", "prove", "bogus"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2 and "Traceback" not in proc.stderr and "unknown claim" in proc.stderr
