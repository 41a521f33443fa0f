"""The reproduction report as a reader meets it (issue 27): the verdicts first, no phrase that reads as a bug, no
pointer outside the repository, and the same content as one self-contained HTML page.

Oracles: the counts are recomputed from ``claims.json`` (not from the report); the HTML is read back with the
standard library's :class:`html.parser.HTMLParser` (not the renderer), the embedded figures decoded and compared
byte for byte with the PNG files the Markdown links.
"""

from __future__ import annotations

import base64
import contextlib
import io
import json
import re
from collections import Counter
from html.parser import HTMLParser
from pathlib import Path

import pytest

from fsmctl.cli.main import main
from fsmctl.policy import FAST_OUTPUT_INTERVAL_S, FAST_T_FINAL_S
from fsmctl.studies.claim_types import VERDICTS
from fsmctl.studies.explain_report import EXPLAINED, NOT_EXPLAINED, Evidence, Explanation, summary_sentence
from fsmctl.studies.wording import count, duration_phrase, value_range, verdict_count

SUMMARY_LINES = 15
"""The verdict summary (the counts and one row per claim) sits within the report's first screen."""
MAX_CELL = 120
"""A cell of the summary tables is read at a glance: tens of characters, not hundreds."""

# phrases that read as bugs: a range with equal ends, "N of the N ... are reproduced", a plural after 1
BAD_PHRASES = [
    re.compile(r"\b(\d+(?:\.\d+)?)\s*[-–]\s*\1 s\b"),
    re.compile(r"\b(\d+) of the \1 claims"),
    re.compile(r"claims not reproduced are reproduced"),
    re.compile(r"(?<![\d.])1 (claims|runs|figure checks|agents)\b"),
    re.compile(r"\b0 of the\b"),
]


@pytest.fixture(scope="module")
def reproduction(tmp_path_factory):
    out = tmp_path_factory.mktemp("reproduction")
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        rc = main(["reproduce", "--fast", "--out", str(out), "--workers", "2", "--no-progress"])
    assert rc == 0
    return out, printed.getvalue()


# ----------------------------------------------------------------------------- the phrases, by hand


@pytest.mark.parametrize(
    ("durations", "total", "expected"),
    [
        ([100.0] * 6, 100.0, "for the whole 100 s"),
        ([99.99, 100.0], 100.0, "for the whole 100 s"),  # equal as printed
        ([40.0, 40.0], 100.0, "for 40.0 s of 100 s"),
        ([31.4, 73.1], 100.0, "for 31.4–73.1 s of 100 s"),
        ([0.0] * 6, 100.0, "never"),
    ],
)
def test_duration_phrase_reads_naturally_when_the_ends_are_equal(durations, total, expected):
    assert duration_phrase(durations, total) == expected


def test_ranges_counts_and_verdicts_take_their_number():
    assert (value_range([100.0, 100.0]), value_range([12.0, 26.7])) == ("100.0", "12.0–26.7")
    assert [count(n, "claim") for n in (0, 1, 7)] == ["0 claims", "1 claim", "7 claims"]
    assert [verdict_count(n, "differs") for n in (0, 1, 5)] == ["0 differ", "1 differs", "5 differ"]
    assert verdict_count(1, "does not fit") == "1 does not fit" and verdict_count(6, "does not fit") == "6 do not fit"


def _explanation(cid: str, found: bool) -> Explanation:
    evidence = Evidence(f"explain_{cid}", "", "f.toml", ["case1"], [], ["fig4_axis"] if cid == "a" else [], True)
    if not found:
        return Explanation(cid, "claim", "differs", NOT_EXPLAINED, NOT_EXPLAINED)
    return Explanation(cid, "claim", "differs", EXPLAINED, "x >= 1", "x = 1", 0.1, evidence=evidence)


@pytest.mark.parametrize(
    ("found", "expected"),
    [
        ([True], "The one claim that did not reproduce would reproduce with this change: x = 1 (settling_27s)."),
        ([False], "The one claim that did not reproduce would not reproduce with any change in the searched ranges."),
        ([True, True], "Each of the 2 claims that did not reproduce would reproduce with one change: x = 1"),
        ([False, False], "None of the 2 claims that did not reproduce would reproduce with a change"),
        ([True, False, False], "1 of the 3 claims that did not reproduce would reproduce with this change"),
    ],
)
def test_summary_sentence_for_none_one_and_many(found, expected):
    ids = ["settling_27s", "tracking_accuracy", "relative_accuracy"]
    sentence = summary_sentence([_explanation(cid, f) for cid, f in zip(ids, found, strict=False)])
    assert sentence.startswith(expected)
    assert not any(p.search(sentence) for p in BAD_PHRASES), sentence


# ----------------------------------------------------------------------------- the report of a fast run


def test_the_verdict_summary_comes_first_and_agrees_with_claims_json(reproduction):
    out, _ = reproduction
    data = json.loads((out / "claims.json").read_text())
    lines = (out / "report.md").read_text().splitlines()
    head = lines[:SUMMARY_LINES]
    seen = Counter(c["verdict"] for c in data["claims"])
    counts = ", ".join(f"**{verdict_count(seen[v], v)}**" for v in VERDICTS)
    assert f"**{len(data['claims'])} claims:** {counts}." in next(line for line in head if "claims:**" in line)
    checks = [e for e in data["explanations"] if e["id"] not in {c["id"] for c in data["claims"]}]
    fits = sum(e["verdict"] == "fits" for e in checks)
    assert f"**{len(checks)} figure checks:** **{verdict_count(fits, 'fits')}**" in "\n".join(head)
    rows = [line for line in head if line.startswith("| [")]  # one short row per claim, with its verdict
    assert len(rows) == len(data["claims"])
    for row, claim in zip(rows, data["claims"], strict=True):
        assert f"(#{claim['id']})" in row and f"**{claim['verdict']}**" in row and claim["this_run_short"] in row


def test_summary_tables_have_short_cells(reproduction):
    out, _ = reproduction
    text = (out / "report.md").read_text()
    summary = text.split("## Evidence per claim")[0]
    cells = [c.strip() for line in summary.splitlines() if line.startswith("| ") for c in line[1:-1].split(" | ")]
    assert len(cells) > 40
    assert max(len(c) for c in cells) <= MAX_CELL, max(cells, key=len)


def test_no_phrase_reads_as_a_bug(reproduction):
    out, _ = reproduction
    for name in ("report.md", "report.html"):
        text = (out / name).read_text()
        found = [m.group(0) for p in BAD_PHRASES for m in p.finditer(text)]
        assert not found, (name, found)
    saturation = json.loads((out / "claims.json").read_text())["claims"][3]
    assert saturation["id"] == "saturation_at_start" and "for the whole 10 s" in saturation["this_run_value"]


def test_no_output_points_outside_the_repository(reproduction):
    out, printed = reproduction
    files = [p for p in out.rglob("*") if p.is_file()]
    assert len(files) > 20
    assert [p.name for p in files if b"shared/" in p.read_bytes()] == []
    assert "shared/" not in printed


class _Page(HTMLParser):
    """What a browser would see of the page: the elements, their attributes, whether they nest."""

    VOID = frozenset({"meta", "img", "br", "hr", "link", "input"})

    def __init__(self) -> None:
        super().__init__()
        self.open: list[str] = []
        self.tags: list[tuple[str, dict]] = []
        self.errors: list[str] = []

    def handle_starttag(self, tag, attrs):
        self.tags.append((tag, dict(attrs)))
        if tag not in self.VOID:
            self.open.append(tag)

    def handle_endtag(self, tag):
        if not self.open or self.open[-1] != tag:
            self.errors.append(f"</{tag}> closes <{self.open[-1] if self.open else None}>")
        else:
            self.open.pop()


def test_html_report_is_self_contained_with_the_same_content(reproduction):
    out, printed = reproduction
    page = _Page()
    page.feed((out / "report.html").read_text())
    page.close()
    assert page.errors == [] and page.open == []
    claims = json.loads((out / "claims.json").read_text())["claims"]
    details = [a for tag, a in page.tags if tag == "details"]
    assert sum(a.get("class") == "claim" for a in details) == len(claims)  # one collapsible evidence per claim
    ids = {a["id"] for _, a in page.tags if "id" in a}
    assert {c["id"] for c in claims} <= ids
    # every figure the Markdown links is embedded, byte for byte
    md = (out / "report.md").read_text()
    linked = re.findall(r"^!\[[^]]*\]\((figures/[^)]+\.png)\)$", md, flags=re.MULTILINE)
    embedded = {a["id"]: a for tag, a in page.tags if tag == "figure"}
    images = [a["src"] for tag, a in page.tags if tag == "img"]
    assert linked and sorted(Path(f).stem for f in linked) == sorted(embedded)
    assert len(images) == len(linked) and all(src.startswith("data:image/png;base64,") for src in images)
    assert sorted(base64.b64decode(src.split(",", 1)[1]) for src in images) == sorted(
        (out / f).read_bytes() for f in linked
    )
    # no reference to a missing file or anchor
    for href in (a["href"] for tag, a in page.tags if tag == "a"):
        assert href[1:] in ids if href.startswith("#") else (out / href).is_file(), href
    # the settings printed first are those flown: the fast mode's horizon (and output interval)
    settings = next(line for line in printed.splitlines() if line.strip().startswith("simulation: t_final="))
    assert f"t_final={FAST_T_FINAL_S} s" in settings and f"output_interval={FAST_OUTPUT_INTERVAL_S} s" in settings
    last = printed.rstrip().splitlines()[-1]
    assert last.startswith(f"report: {out / 'report.md'} and {out / 'report.html'}")
    # the time of the explanations is part of the whole's, and says so
    assert re.search(r", [0-9.]+ s wall time, of which explanations [0-9.]+ s\)$", last), last
