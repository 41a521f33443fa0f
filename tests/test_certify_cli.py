"""``fsmctl certify`` from the command line: verdicts and exit codes, the files, the flight, ``--check``, bad input."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from fsmctl.cli.main import main

EXAMPLES = Path(__file__).resolve().parents[1] / "docs" / "examples"
SMALL = ["--scenario", str(EXAMPLES / "my_law.toml"), "--region-sigma", "0.05", "--region-omega", "0.01",
         "--seconds", "15", "--no-progress"]  # fmt: skip


def _run(capsys, *argv):
    code = main(["certify", *argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_certified_writes_and_rechecks(capsys, tmp_path):
    out = tmp_path / "certificate.json"
    code, text, _ = _run(capsys, "--law", str(EXAMPLES / "my_law.py"), *SMALL, "--inertia-uncertainty", "0.05",
                         "--out", str(tmp_path))  # fmt: skip
    assert code == 0, text
    assert text.splitlines()[0].startswith("certified (asymptotic)")
    d = json.loads(out.read_text())
    assert (d["verdict"], d["kind"]) == ("certified", "asymptotic")
    assert d["uncertainty"]["inertia"] == 0.05
    assert out.with_suffix(".md").read_text().startswith("# Certificate: my_pd")
    code, text, _ = _run(capsys, "--check", str(out))
    assert code == 0, text
    assert text.startswith("re-checked: every statement holds; the file certifies its law")
    assert "[ok] every leaf outside the core is proved" in text  # not "[ok] 0 leaves ... are not proved"
    assert re.search(r"\[ok\] (1 box|[02-9]\d* boxes|1\d+ boxes) of the recorded bisection", text), text


def test_counterexample_flown_exit_1(capsys, tmp_path):
    out = tmp_path / "certificate.json"
    code, text, _ = _run(capsys, "--law", str(EXAMPLES / "pd_unstable.py"), *SMALL, "--inertia-uncertainty", "0",
                         "--out", str(tmp_path), "--fly", "5")  # fmt: skip
    assert code == 1
    assert text.startswith("counterexample: V_dot =")
    assert (tmp_path / "counterexample.png").is_file()
    assert "flown from the counterexample" in out.with_suffix(".md").read_text()
    # the re-check holds (the counterexample is confirmed) but the file certifies nothing: exit 1, said first
    code, text, _ = _run(capsys, "--check", str(out))
    assert code == 1
    assert text.splitlines()[0].endswith("the file's verdict is counterexample: it certifies nothing")
    # a hand-edited verdict that does not match the file is bad input
    d = json.loads(out.read_text())
    d["outcome"]["counterexample"] = None
    bad = tmp_path / "edited.json"
    bad.write_text(json.dumps(d))
    code, _, err = _run(capsys, "--check", str(bad))
    assert code == 2 and "does not match" in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("fly", ["0.0001", "0.015"])  # below the output interval; not a multiple of it
def test_a_flight_the_scenario_cannot_fly_is_refused_before_the_search(capsys, tmp_path, fly):
    code, _, err = _run(capsys, "--law", str(EXAMPLES / "pd_unstable.py"), *SMALL, "--out", str(tmp_path),
                        "--fly", fly)  # fmt: skip
    errors = [line for line in err.splitlines() if "error:" in line]
    assert code == 2 and len(errors) == 1 and f"--fly {fly}: simulation." in errors[0]
    assert "certify pd_unstable:" not in err and not any(tmp_path.iterdir())  # no search started, nothing written


def test_json_summary(capsys, tmp_path):
    code, text, _ = _run(capsys, "--law", str(EXAMPLES / "pd_unstable.py"), *SMALL, "--inertia-uncertainty", "0",
                         "--out", str(tmp_path), "--fly", "0", "--json")  # fmt: skip
    d = json.loads(text)
    assert code == 1 and d["verdict"] == "counterexample" and "tree" not in d


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--law", "nonexistent_law"], "nonexistent_law"),
        (["--law", "pid", "--region-sigma", "1.5"], "sigma"),
        (["--law", "pid", "--region-sigma", "0.6"], "0.577"),  # the box's corners beyond |sigma_e| = 1
        (["--law", "pid", "--region-omega", "-1"], "--region-omega"),
        (["--check", "missing.json"], "missing.json"),
        (["--law", "pid", "--disturbance", "0.2", "0.24"], "--disturbance takes one bound or three"),
        (["--law", "pid", "--reference-rate", "1", "2", "3", "4"], "--reference-rate takes one bound or three"),
        ([], "--law"),
    ],
)
def test_bad_input_one_line_exit_2(capsys, argv, message):
    code, _, err = _run(capsys, *argv)
    assert code == 2
    assert message in err
    assert len(err.strip().splitlines()) == 1


def test_disturbance_per_axis_reaches_the_certificate(capsys, tmp_path):
    """Three --disturbance bounds are the three axes' (as in the paper's (0.2, 0.24, 0.22) N m)."""
    code, text, _ = _run(capsys, "--law", str(EXAMPLES / "my_law.py"), *SMALL, "--inertia-uncertainty", "0",
                         "--disturbance", "0.001", "0.002", "0.003", "--json", "--out", str(tmp_path))  # fmt: skip
    d = json.loads((tmp_path / "certificate.json").read_text())
    assert code == 0, text
    assert d["uncertainty"]["disturbance_N_m"] == [0.001, 0.002, 0.003]
