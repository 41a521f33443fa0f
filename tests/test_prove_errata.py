"""`fsmctl prove` reports every erratum of the paper, each with its equations, in the text and in the JSON.

The oracle is ``generated/errata.json``, written by ``python -m derive`` (checked to be current by
``tests/test_derive.py``): every erratum recorded there must appear in both outputs of the full proof check.
"""

from __future__ import annotations

import contextlib
import importlib
import io
import json
import re
from pathlib import Path

import pytest

from fsmctl.cli.main import main

RECORDED = json.loads((Path(__file__).resolve().parent.parent / "generated" / "errata.json").read_text())


# Theorem 2 on the reference only: every claim of Case 1 is as expected, so the exit code is the errata's to decide
REFERENCE_ONLY = ["--region-sigma", "0", "--region-omega", "0"]


def _prove(*argv: str) -> tuple[int, str]:
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(io.StringIO()):
        code = main(["prove", *REFERENCE_ONLY, *argv])
    return code, buf.getvalue()


@pytest.fixture(scope="module")
def full_check() -> dict[str, tuple[int, str]]:
    """The full proof check through the command line, twice: text and JSON (exit code, stdout)."""
    return {"text": _prove(), "json": _prove("--json")}


def test_recorded_errata_include_the_reaudit():
    ids = [e["id"] for e in RECORDED]
    assert len(ids) == len(set(ids)) and "eq18-delta-diag" in ids and "eq9-C" in ids


def test_text_reports_every_erratum_with_its_equations(full_check):
    code, out = full_check["text"]
    assert code == 0
    section = out[out.index("errata of the printed paper") :]
    for e in RECORDED:
        rows = [line for line in section.splitlines() if re.match(rf"{re.escape(e['id'])}\s", line)]
        assert len(rows) == 1, e["id"]
        assert e["equation"] in rows[0] and "confirmed" in rows[0], rows[0]
    assert f"{len(RECORDED)} errata of the printed paper: {len(RECORDED)} confirmed" in out


def test_json_reports_every_erratum_with_its_equations(full_check):
    code, out = full_check["json"]
    assert code == 0
    doc = json.loads(out)
    assert [c["id"] for c in doc["claims"]][:2] == ["lemma1-settling-time", "lemma2-sqrt-sum"]
    errata = {e["id"]: e for e in doc["errata"]}
    assert [e["id"] for e in doc["errata"]] == [e["id"] for e in RECORDED]
    for e in RECORDED:
        assert errata[e["id"]]["equation"] == e["equation"]
        assert errata[e["id"]]["checked"] is True
        assert errata[e["id"]]["as_printed"] == e["as_printed"] and errata[e["id"]]["correct"] == e["correct"]
    # the errata a claim examines name it; the re-audit's are checked by the registry alone
    assert errata["eq9-C"]["claim"] == "lagrange-C" and errata["eq28-mu"]["claim"] == "vdot-mu"
    assert errata["eq18-delta-diag"]["claim"] is None


def test_selected_claims_check_no_errata():
    code, out = _prove("lemma2-sqrt-sum", "--json")
    assert code == 0
    doc = json.loads(out)
    assert [c["id"] for c in doc["claims"]] == ["lemma2-sqrt-sum"] and doc["errata"] is None
    code, out = _prove("lemma2-sqrt-sum")
    assert code == 0 and "errata of the printed paper" not in out


def test_an_erratum_not_confirmed_exits_1(monkeypatch):
    """A check that did not go through exits 1 (the policy of the claims), an erratum's included."""
    errata_module = importlib.import_module("fsmctl.proofs.errata")  # the attribute fsmctl.proofs.errata is errata()
    real = errata_module.all_errata

    def one_unconfirmed():
        found = real()
        return [*found[:-1], errata_module.Erratum(**{**found[-1].to_dict(), "checked": False})]

    monkeypatch.setattr(errata_module, "all_errata", one_unconfirmed)
    code, out = _prove()
    last = RECORDED[-1]["id"]
    assert code == 1
    assert f"UNCHECKED (the printed form not refuted or the correction not checked): {last}" in out
    first = out.splitlines()[0]  # the one plain line: only the unconfirmed erratum differs from the documented finding
    assert re.fullmatch(rf"1 of \d+ checks differ from the documented finding: {last} \(erratum not confirmed\)", first)
