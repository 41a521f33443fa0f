"""``fsmctl reproduce`` says whether its result is the expected one: its first result line and its exit code.

The documented findings (``docs/findings.md``) are the verdicts of the paper's own scenario at its full horizon; they
live in the registries (:attr:`StudyClaim.documented`, :attr:`FigureCheck.documented_fits`).  A reproduction compares
with them only when they apply; ``--strict`` expects every claim reproduced.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from fsmctl.cli.main import main
from fsmctl.studies.claim_types import DIFFERS, IMPOSSIBLE, REPRODUCED
from fsmctl.studies.claims import CLAIMS
from fsmctl.studies.figure_checks import FIGURE_CHECKS
from fsmctl.studies.report import Reproduction
from fsmctl.studies.report_text import format_claims


def _reproduction(verdicts: dict[str, str], *, applies: bool = True, figures: dict[str, str] | None = None):
    """A Reproduction whose claims carry these verdicts (the rest of it is not read)."""
    from fsmctl.studies.claim_types import ClaimVerdict

    rows = [
        ClaimVerdict(c.id, c.title, c.text, c.figures, c.paper_value, "x", "x", verdicts[c.id], "", "", c.documented)
        for c in CLAIMS
    ]
    explanations = None
    if figures is not None:
        explanations = [_Explained(k, v) for k, v in figures.items()]
    return Reproduction(
        Path("out"), False, [], {}, [], rows, [], [], 0.0, explanations=explanations, documented_applies=applies
    )


@dataclasses.dataclass
class _Explained:
    id: str
    verdict: str
    status: str = "not explained"
    change: str = ""
    baseline: str = "peak"


DOCUMENTED = {c.id: c.documented for c in CLAIMS}


def test_the_registry_documents_the_findings_page():
    """The documented verdicts are those docs/findings.md states: 5 differ, 2 impossible, Fig 4's axis fits."""
    assert sorted(DOCUMENTED.values()).count(DIFFERS) == 5
    assert [k for k, v in DOCUMENTED.items() if v == IMPOSSIBLE] == ["settling_27s", "saturation_at_start"]
    assert [f.id for f in FIGURE_CHECKS if f.documented_fits] == ["fig4_axis"]
    summary = (Path(__file__).parents[1] / "docs" / "_includes" / "verdicts-summary.md").read_text()
    assert "*reproduced* **0**, *differs* **5**, *impossible (bound)* **2**" in summary


def test_as_documented_is_exit_zero_and_said_first():
    rep = _reproduction(
        DOCUMENTED, figures={f.id: "fits" if f.documented_fits else "does not fit" for f in FIGURE_CHECKS}
    )
    assert rep.differences() == [] and rep.as_expected() and not rep.as_expected(strict=True)
    first = format_claims(rep).splitlines()[0]
    assert first.startswith("7 claims: 0 reproduced, 5 differ, 2 impossible (bound)")
    assert first.endswith("every verdict as documented")


def test_a_changed_verdict_is_named_and_fails():
    claims = {**DOCUMENTED, "settling_27s": REPRODUCED}
    rep = _reproduction(claims, figures={"fig4_axis": "does not fit"})
    assert rep.differences() == [
        "settling_27s: reproduced (documented: impossible (bound))",
        "fig4_axis: does not fit (documented: fits)",
    ]
    assert not rep.as_expected()
    assert "2 verdicts not as documented: settling_27s: reproduced" in rep.outcome_line()


def test_no_documented_finding_for_other_runs():
    rep = _reproduction({c.id: REPRODUCED for c in CLAIMS}, applies=False)
    assert rep.differences() is None and rep.as_expected() and rep.as_expected(strict=True)
    assert "no documented finding for this run" in rep.outcome_line()


@pytest.mark.parametrize(("extra", "code"), [([], 0), (["--strict"], 1)])
def test_exit_code_of_a_fast_run(tmp_path, capsys, extra, code):
    """--fast: no documented finding applies (exit 0); --strict: the claims are not reproduced (exit 1)."""
    argv = ["reproduce", "--fast", "--no-figures", "--no-explain", "--no-progress", "--out", str(tmp_path), *extra]
    assert main(argv) == code
    out = capsys.readouterr().out
    result = out.split("\n\n")[-3] if "\n\n" in out else out
    assert "no documented finding for this run" in out and "7 claims: " in result
    # the first screen: the settings in a few lines, the choices' reasoning left to the report
    assert "choice alpha:" not in out and "    choices the paper leaves open: 6 (alpha, delta, " in out
    # the first line says what is flown: every run, not only the Case 1 whose settings follow
    assert "reproduce: 14 runs, the paper's Cases 1, 2, 3a, 3b, 3c and 9 diagnostic runs" in out


def test_only_the_unchanged_paper_scenario_is_documented(tmp_path):
    import fsmctl
    from fsmctl.studies.reproduce import documented_findings_apply

    text = (Path(fsmctl.__file__).parent / "scenarios" / "paper.toml").read_text()
    changed = tmp_path / "changed.toml"
    changed.write_text(text.replace("torque_limit = 2.0", "torque_limit = 3.0", 1))
    assert "torque_limit = 3.0" in changed.read_text()
    assert documented_findings_apply("paper") and not documented_findings_apply("paper", fast=True)
    assert not documented_findings_apply(str(changed))
