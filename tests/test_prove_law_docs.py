"""The own-law guide's `fsmctl prove --law FILE.py --error-model exact` does what the guide says it does."""

from __future__ import annotations

import json
from pathlib import Path

from fsmctl.cli.main import main

ROOT = Path(__file__).resolve().parent.parent
COMMAND = "fsmctl prove --law docs/examples/my_law.py --error-model exact"


def test_guide_documents_the_exact_variant_check_and_it_checks_that_variant(capsys, monkeypatch):
    guide = (ROOT / "docs" / "guide" / "own-law.md").read_text(encoding="utf-8")
    assert COMMAND in guide and 'error_model = "exact"' in guide
    monkeypatch.chdir(ROOT)  # the guide's path is relative to the repository
    code = main([*COMMAND.split()[1:], "--samples", "200", "--json"])
    out = capsys.readouterr().out
    assert code == 0
    report = json.loads(out)
    assert report["error_model"] == "exact" and report["ok"] is True
    checks = {c["id"]: c for c in report["checks"]}
    assert list(checks) == ["generated-equals-symbolic", "closed-loop", "lyapunov"]
    # what the guide says: the exact variant's generated functions are the ones compared
    assert "law_local_exact and law_control_exact" in checks["generated-equals-symbolic"]["statement"]
