"""``fsmctl certify`` for a new user: labelled progress, clear refusals of the output and input paths, the earlier
certificate replaced aloud, the counterexample's point in the Markdown report."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from fsmctl.cli.main import main

EXAMPLES = Path(__file__).resolve().parents[1] / "docs" / "examples"
SMALL = ["--scenario", str(EXAMPLES / "my_law.toml"), "--region-sigma", "0.05", "--region-omega", "0.01",
         "--seconds", "15"]  # fmt: skip
UNSTABLE = ["--law", str(EXAMPLES / "pd_unstable.py"), *SMALL, "--inertia-uncertainty", "0", "--no-progress"]


def _run(capsys, *argv):
    code = main(["certify", *argv])
    out, err = capsys.readouterr()
    return code, out, err


def _errors(err: str) -> list[str]:
    return [line for line in err.splitlines() if "error:" in line]


def _bar_states(err: str) -> list[str]:
    """Every state a tqdm bar was drawn in (it redraws its line after a carriage return)."""
    return [s.strip() for s in re.split(r"[\r\n]", err) if s.strip()]


def test_bars_name_each_candidate_and_the_steps_without_progress(capsys, tmp_path):
    # the documented PD example: its declared V fails at the origin, the cross term V + eps sigma_e^T J0 omega_e is
    # certified by the origin's argument alone; then the levels of {V <= c} are computed
    code, _, err = _run(capsys, "--law", str(EXAMPLES / "my_law.py"), *SMALL, "--inertia-uncertainty", "0.05",
                        "--out", str(tmp_path), "--progress")  # fmt: skip
    assert code == 0
    d = json.loads((tmp_path / "certificate.json").read_text())
    eps = d["candidate"]["epsilon"]
    states = _bar_states(err)
    declared = [s for s in states if re.match(r"candidate 1/\d: declared V:", s)]
    assert declared and any("the boundary level" in s for s in declared)
    assert any("the origin's argument" in s for s in declared)
    assert not any("sum of squares" in s for s in states)  # an asymptotic question: no sum-of-squares step
    assert any("branch and bound" in s for s in declared)
    cross = [s for s in states if re.match(rf"candidate 2/\d: declared V \+ cross term \(eps {eps:.3g}\):", s)]
    steps = [
        next(i for i, s in enumerate(cross) if what in s)
        for what in ("the boundary level", "the origin's argument", "branch and bound", "the levels")
    ]
    assert steps == sorted(steps)  # in the order they are computed
    assert any(s.startswith("choosing the candidates") for s in states)
    # the stages follow the search that was run: the certificate's attempts, in order
    assert [a["describe"] for a in d["attempts"]] == [
        "the law's declared V",
        f"the law's V + {eps:g} sigma_e^T J0 omega_e",
    ]


def test_no_bars_without_progress(capsys, tmp_path):
    code, _, err = _run(capsys, *UNSTABLE, "--out", str(tmp_path), "--fly", "0")
    assert code == 1 and "candidate 1/" not in err and "choosing" not in err


def test_out_onto_a_file_is_refused_before_the_search(capsys, tmp_path):
    target = tmp_path / "mine.json"
    target.write_text("my own file")
    code, _, err = _run(capsys, *UNSTABLE, "--out", str(target))
    errors = _errors(err)
    assert code == 2 and len(errors) == 1
    assert f"--out {target} is an existing file" in errors[0] and "folder" in errors[0]
    assert "certify pd_unstable:" not in err and target.read_text() == "my own file"
    # a new path named like a file is not made a folder
    code, _, err = _run(capsys, *UNSTABLE, "--out", str(tmp_path / "new.json"))
    assert code == 2 and len(_errors(err)) == 1 and "names a folder" in err and not (tmp_path / "new.json").exists()
    # --report onto a folder
    code, _, err = _run(capsys, *UNSTABLE, "--out", str(tmp_path / "out"), "--report", str(tmp_path))
    assert code == 2 and len(_errors(err)) == 1 and f"--report {tmp_path}: a folder" in err


def test_the_default_folder_is_replaced_aloud_and_the_counterexample_shown(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    folder = Path("certify-pd_unstable")
    code, text, _ = _run(capsys, *UNSTABLE, "--fly", "1")
    assert code == 1 and "earlier certificate" not in text and (folder / "counterexample.png").is_file()
    code, text, _ = _run(capsys, *UNSTABLE, "--fly", "0")
    said = [line for line in text.splitlines() if "earlier certificate" in line]
    assert code == 1 and len(said) == 1
    assert str(folder / "certificate.json") in said[0] and str(folder / "certificate.md") in said[0]
    # the earlier run's flight does not belong to the new certificate (not flown): removed, and said so
    assert "counterexample.png" in said[0] and not (folder / "counterexample.png").exists()

    # the Markdown report shows the counterexample's point: the JSON's values, units in the column names
    point = json.loads((folder / "certificate.json").read_text())["outcome"]["counterexample"]["point"]
    md = (folder / "certificate.md").read_text()
    rows = [line for line in md.split("## Counterexample", 1)[1].splitlines() if line.startswith("|")]
    header = [c.strip() for c in rows[0].strip("|").split("|")]
    assert header[:3] == ["k", "sigma_e (MRP)", "omega_e (rad/s)"]
    for row in rows[2:]:
        cells = [c.strip() for c in row.strip("|").split("|")]
        k = int(cells[0])
        assert float(cells[1]) == pytest.approx(point[f"sigma_e[{k}]"], rel=1e-5, abs=1e-300)
        assert float(cells[2]) == pytest.approx(point[f"omega_e[{k}]"], rel=1e-5, abs=1e-300)
    assert len(rows) == 2 + 3
    assert any(point[f"omega_e[{k}]"] != 0 for k in range(3))  # the point is not the origin: the table shows it
    # the inputs at 0 (no uncertainty here) are named, not tabulated
    assert "0 at the point: theta, d, omega_d, omega_d_dot." in md


@pytest.mark.parametrize("beside", [True, False])
def test_check_wants_a_certificate_json(capsys, tmp_path, beside):
    (tmp_path / "certificate.md").write_text("# Certificate: x\n")
    if beside:
        (tmp_path / "certificate.json").write_text("{}")
    for target in (tmp_path, tmp_path / "certificate.md"):
        code, _, err = _run(capsys, "--check", str(target))
        errors = _errors(err)
        assert code == 2 and len(err.strip().splitlines()) == 1 and len(errors) == 1
        assert "a certificate JSON file is expected" in errors[0]
        assert (str(tmp_path / "certificate.json") in errors[0]) == beside
    code, _, err = _run(capsys, "--check", str(tmp_path / "certificate.md"))
    assert "a Markdown report" in err
