"""The seed audit of Sections 2-3 (fsmctl.proofs.seed_audit): quotes, coverage, new errata, generated docs."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from fsmctl.proofs import seed_audit as audit
from fsmctl.proofs.errata import Erratum, errata

REPO = Path(__file__).resolve().parents[1]
SEED = Path(__file__).parents[2] / "shared/seed/liang2012_acta_astronautica.txt"
DOC = REPO / "docs" / "errata-audit.md"
NEW_VERDICTS = (audit.SILENT, audit.NEW)


def _normalise(text: str) -> str:
    return re.sub(r"\s+", " ", text).strip()


@pytest.fixture(scope="module")
def seed_sections() -> str:
    """Sections 2 and 3 of the raw extraction, whitespace-normalised (skips when the seed is absent, e.g. in CI)."""
    if not SEED.exists():
        pytest.skip(f"seed text not available at {SEED} (CI clones only the repository)")
    text = _normalise(SEED.read_text(encoding="utf-8"))
    start, end = text.find("2. Preliminaries"), text.find("4. Numerical examples")
    assert 0 <= start < end, "section headings not found in the seed"
    return text[start:end]


@pytest.fixture(scope="module")
def existing_ids() -> set[str]:
    return {e.id for e in errata()}


@pytest.fixture(scope="module")
def new_errata() -> list[Erratum]:
    return audit.audit_errata()


def test_rows_are_well_formed():
    for r in audit.AUDIT:
        assert r.verdict in audit.VERDICTS, r
        assert r.printed.strip() and r.printed_meaning.strip() and r.transcription.strip() and r.note.strip(), r
        assert r.printed == _normalise(r.printed), f"{r.equation}: excerpt not whitespace-normalised"
        assert (r.erratum is None) == (r.verdict in (audit.SAME, audit.ARTEFACT)), r
        assert "`" not in r.printed, r


def test_printed_excerpts_occur_in_the_seed(seed_sections):
    missing = [r.equation for r in audit.AUDIT if _normalise(r.printed) not in seed_sections]
    assert not missing, f"excerpts not found verbatim in Sections 2-3 of the seed: {missing}"


def test_every_numbered_equation_has_a_row(seed_sections):
    numbers = {int(n) for n in re.findall(r"ð(\d{1,2})Þ", seed_sections)} - {0}  # ð0Þ is x(0), not a label
    assert set(range(1, 29)) <= numbers, "equations 1-28 are not all labelled in the seed's Sections 2-3"
    covered = {int(m.group(1)) for r in audit.AUDIT if (m := re.match(r"eq (\d+)\b", r.equation))}
    assert numbers <= covered, f"numbered equations without a row: {sorted(numbers - covered)}"


def test_row_order_follows_the_paper(seed_sections):
    positions = [seed_sections.find(_normalise(r.printed)) for r in audit.AUDIT]
    assert positions == sorted(positions)


def test_new_errata_are_checked(new_errata):
    assert [e.id for e in new_errata] == [c.id for c in audit.AUDIT_CHECKS]
    for e in new_errata:
        assert isinstance(e, Erratum)
        assert e.checked is True, e.id
        assert e.as_printed and e.correct and e.residual and e.consequence


@pytest.mark.parametrize("check", audit.AUDIT_CHECKS, ids=lambda c: c.id)
def test_check_fails_with_the_printed_form(check):
    """Each check must be able to fail: with the printed form in place of the correction it does."""
    assert check.printed_forms
    for printed in check.printed_forms:
        assert check.check(printed).checked is False, f"{check.id} accepts the printed form {printed!r}"


def test_ids_are_unique_and_new(existing_ids, new_errata):
    ids = [e.id for e in new_errata]
    assert len(ids) == len(set(ids))
    assert not set(ids) & existing_ids, f"ids collide with fsmctl.proofs.errata: {set(ids) & existing_ids}"


def test_rows_cite_known_errata(existing_ids):
    new_ids = {c.id for c in audit.AUDIT_CHECKS}
    for r in audit.AUDIT:
        if r.verdict == audit.EXISTING:
            assert r.erratum in existing_ids, r
        elif r.verdict in NEW_VERDICTS:
            assert r.erratum in new_ids, r
    cited = {r.erratum for r in audit.AUDIT if r.verdict in NEW_VERDICTS}
    assert cited == new_ids, "every new erratum is the finding of at least one row, and vice versa"


def test_existing_errata_are_all_cited(existing_ids):
    """Each of the 8 existing errata concerns Sections 2-3 and is found again by the audit."""
    assert existing_ids <= {r.erratum for r in audit.AUDIT if r.verdict == audit.EXISTING}


def test_doc_is_generated_and_current():
    assert DOC.exists(), "run python -m fsmctl.proofs.seed_audit"
    assert DOC.read_text(encoding="utf-8") == audit.audit_markdown(), "stale: run python -m fsmctl.proofs.seed_audit"
    assert audit.main(["--check"]) == 0


def test_markdown_lists_every_row_and_erratum():
    text = audit.audit_markdown()
    for c in audit.AUDIT_CHECKS:
        assert f"`{c.id}`" in text
    table = [line for line in text.splitlines() if re.match(r"\| \d+ \|", line)]
    assert len(table) == len(audit.AUDIT)
    assert all(len(re.split(r"(?<!\\)\|", line)) == 9 for line in table), "7 cells per row (unescaped pipes)"


def test_module_is_pure_sympy():
    tree = ast.parse(Path(audit.__file__).read_text(encoding="utf-8"))
    allowed = ("sympy", "fsmctl.symbolic", "fsmctl.proofs.errata", "__future__", "collections", "dataclasses")
    for node in ast.walk(tree):
        names = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            names = [node.module or ""]
        for name in names:
            assert name.startswith(allowed) or name in ("argparse", "pathlib"), name
    assert "numpy" not in Path(audit.__file__).read_text(encoding="utf-8").replace("no NumPy", "")
