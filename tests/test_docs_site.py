"""The documentation site as a reader meets it (issue 27).

* ``docs/_ext/check_html.py``, the check ``.ci/run`` runs on the built site, finds each defect planted in a small
  page (raw ``$$`` math, raw pipe tables, options whose ``--`` became a dash, a ``<label>`` placeholder eaten as a
  tag, tables without a scroll wrapper, links out of the repository) and passes clean pages;
* a small site built with ``docs/conf.py``'s own settings (smart quotes, myst-nb's Markdown rendering, the theme, the
  fsmctl extension) passes that check: notebook outputs render their math and tables, command lines keep ``--``,
  code naming a documented object links to it (needs the ``docs`` extra; ``.ci/run`` runs this file after
  installing it);
* the site's own files: every public docstring's Returns section holds return values (not a paragraph), the API
  index lists every public module once, each gallery notebook gets its fast-mode banner and has a thumbnail, the
  committed verdicts agree with themselves and with the claim registry, the README summarizes the findings page
  (its one home) without copying it, and the build commands keep the doctrees out of the published folder and run
  the check.
"""

from __future__ import annotations

import ast
import http.server
import importlib
import inspect
import json
import re
import sys
import threading
from collections import Counter
from pathlib import Path

import pytest

import fsmctl
from fsmctl.studies import claim_ids

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
sys.path.insert(0, str(DOCS / "_ext"))
sys.path.insert(0, str(DOCS))
import check_html  # noqa: E402
import fsmctl_docs  # noqa: E402
import make_landing  # noqa: E402

# ----------------------------------------------------------------------------- the checker on planted pages

PAGE = """<!DOCTYPE html>
<html><head><title>t</title><script>var x = "$$ |---| \u2013from";</script></head>
<body><article class="bd-article">{body}</article></body></html>
"""

CLEAN = """
<h1>Reproduce</h1>
<p>Run <code class="docutils literal"><span class="pre">fsmctl simulate --from run.nc</span></code> to fly it again;
Sections 2\u20133 of the paper \u2014 the model \u2014 are checked. Prices: $5 and $6.</p>
<div class="math notranslate nohighlight">\\[\\left[\\begin{matrix}1\\end{matrix}\\right]\\]</div>
<div class="highlight-bash"><div class="highlight"><pre>fsmctl tune --budget 4
echo '$$' | grep '|---|'</pre></div></div>
<div class="pst-scrollable-table-container"><table class="table"><tr><td>a</td></tr></table></div>
<table class="indextable genindextable"><tr><td>b</td></tr></table>
<p><a href="guide/outputs.html#netcdf">outputs</a> <a href="https://numpy.org/doc/stable/">NumPy</a>
<a href="#top">top</a> <img src="_images/fig.png" alt="f"/> <label for="x" class="toggle">menu</label></p>
"""

PLANTED = {
    "raw-math": "<p>$$\\left[\\begin{matrix}1 &amp; 0\\end{matrix}\\right]$$</p>",
    "raw-table": "<p>| claim | verdict | |---|---| | settling_27s | differs |</p>",
    "dash-option": "<p>Flies it again with \u2013from RESULT.</p>",
    "raw-placeholder": "<p>writes DIR/<label>.nc</p>",
    "table-overflow": '<table class="table"><tr><td>a very wide table</td></tr></table>',
    "outside-link": '<p><a href="../../shared/seed/paper.txt">the seed</a></p>',
}


def _site(tmp_path: Path, pages: dict[str, str]) -> Path:
    for name, body in pages.items():
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(PAGE.format(body=body), encoding="utf-8")
    return tmp_path


def test_a_clean_page_passes(tmp_path):
    site = _site(tmp_path, {"index.html": CLEAN, "guide/outputs.html": '<p><a href="../index.html">up</a></p>'})
    assert check_html.check_site(site) == []
    assert check_html.main(site) == 0


@pytest.mark.parametrize("kind", sorted(PLANTED))
def test_each_planted_defect_is_found(tmp_path, kind):
    site = _site(tmp_path, {"index.html": CLEAN, "guide/page.html": CLEAN + PLANTED[kind]})
    problems = check_html.check_site(site)
    assert [(p.page, p.kind) for p in problems] == [("guide/page.html", kind)]
    assert check_html.main(site) == 1


@pytest.mark.parametrize(
    "body",
    [
        "<pre>fsmctl simulate \u2014set K=2.0</pre>",  # an em dash, in code
        '<p><a href="file:///home/me/paper.pdf">paper</a></p>',
        '<p><a href="/etc/passwd">root</a></p>',
        "<p>the raw text in <code>shared/spec/paper.md</code></p>",
        "<p>see ../shared/seed for the extraction</p>",
        '<p><img src="../../outside.png"/></p>',
    ],
)
def test_the_variants_of_a_defect_are_found(tmp_path, body):
    site = _site(tmp_path, {"guide/page.html": body})
    assert len(check_html.check_site(site)) == 1


def test_an_empty_folder_is_an_error(tmp_path):
    with pytest.raises(FileNotFoundError, match="no HTML pages"):
        check_html.check_site(tmp_path)


# ----------------------------------------------------------------------------- a site built with docs/conf.py's settings

SETTINGS = (
    "smartquotes",
    "nb_render_markdown_format",
    "myst_enable_extensions",
    "myst_dmath_double_inline",
    "html_theme",
)


def _conf_settings() -> dict:
    """The literal settings of ``docs/conf.py`` that decide how pages and notebook outputs render."""
    tree = ast.parse((DOCS / "conf.py").read_text(encoding="utf-8"))
    found = {}
    for node in tree.body:
        if isinstance(node, ast.Assign) and len(node.targets) == 1 and isinstance(node.targets[0], ast.Name):
            if node.targets[0].id in SETTINGS:
                found[node.targets[0].id] = ast.literal_eval(node.value)
    return found


NOTEBOOK_MARKDOWN = (
    "$$\\left[\\begin{matrix}1 & 0\\\\0 & 1\\end{matrix}\\right]$$\n\n| claim | verdict |\n|---|---|\n| a | b |\n"
)


def _notebook() -> dict:
    return {
        "nbformat": 4,
        "nbformat_minor": 5,
        "metadata": {"kernelspec": {"name": "python3", "display_name": "Python 3", "language": "python"}},
        "cells": [
            {"cell_type": "markdown", "id": "a", "metadata": {}, "source": "# Notebook"},
            {
                "cell_type": "code",
                "id": "b",
                "metadata": {},
                "execution_count": 1,
                "source": "display(Markdown(text))",
                "outputs": [
                    {
                        "output_type": "display_data",
                        "metadata": {},
                        "data": {"text/markdown": NOTEBOOK_MARKDOWN, "text/plain": "<Markdown>"},
                    }
                ],
            },
        ],
    }


def test_a_site_built_with_the_docs_settings_passes_the_check(tmp_path):
    pytest.importorskip("myst_nb")
    pytest.importorskip("pydata_sphinx_theme")
    from sphinx.application import Sphinx

    settings = _conf_settings()
    assert set(settings) == set(SETTINGS)
    src = tmp_path / "src"
    src.mkdir()
    (src / "conf.py").write_text(
        "\n".join(
            [
                f"import sys; sys.path.insert(0, {str(DOCS / '_ext')!r})",
                "extensions = ['sphinx.ext.autodoc', 'myst_nb', 'fsmctl_docs']",
                "nb_execution_mode = 'off'",
                *(f"{name} = {value!r}" for name, value in settings.items()),
            ]
        ),
        encoding="utf-8",
    )
    (src / "index.md").write_text(
        "# Site\n\nFly it again with --from RESULT, or --set K=2.0 --case 1.\n\n"
        "The simulator is `fsmctl.simulate()`; `not_a_name` stays code.\n\n"
        "```{toctree}\napi\nnotebook\n```\n",
        encoding="utf-8",
    )
    (src / "api.md").write_text("# API\n\n```{py:function} fsmctl.simulate(scenario)\n\nFly.\n```\n", encoding="utf-8")
    (src / "notebook.ipynb").write_text(json.dumps(_notebook()), encoding="utf-8")
    out = tmp_path / "html"
    app = Sphinx(str(src), str(src), str(out), str(tmp_path / "doctrees"), "html", status=None, warningiserror=False)
    app.build()
    assert check_html.check_site(out) == []
    index = (out / "index.html").read_text(encoding="utf-8")
    assert "--from RESULT" in index and "--set K=2.0" in index
    assert re.search(r'<a class="reference internal" href="api.html#fsmctl.simulate"[^>]*><code', index)
    assert not re.search(r"<a [^>]*><code[^>]*><span class=\"pre\">not_a_name", index)
    notebook = (out / "notebook.html").read_text(encoding="utf-8")
    assert "\\begin{matrix}" in notebook and "<table" in notebook  # rendered as math and as a table


# ----------------------------------------------------------------------------- docstrings, API index, gallery


def _public_docstrings():
    seen: set[int] = set()
    for module_name in fsmctl._PUBLIC_MODULES:
        module = importlib.import_module(module_name)
        for name in module.__all__:
            obj = getattr(module, name)
            candidates = [(f"{module_name}.{name}", obj)]
            if inspect.isclass(obj):
                for attr, value in vars(obj).items():
                    func = value.fget if isinstance(value, property) else getattr(value, "__func__", value)
                    if not attr.startswith("_") and inspect.isfunction(func):
                        candidates.append((f"{module_name}.{name}.{attr}", func))
            for full, target in candidates:
                if (inspect.isfunction(target) or inspect.isclass(target)) and id(target) not in seen:
                    seen.add(id(target))
                    yield full, inspect.getdoc(target) or ""


def _prose_entries(doc: str) -> list[str]:
    """Entries of a Returns/Yields/Raises/Warns section that are prose, not ``name : type`` plus indented text."""
    from numpydoc.docscrape import NumpyDocString

    parsed = NumpyDocString(doc)
    bad = []
    for section in ("Returns", "Yields", "Raises", "Warns"):
        items = parsed[section]
        for item in items:
            head = f"{item.name} {item.type}".strip()
            prose = (":" in head and "`" in head) or head.endswith((".", ",", ";")) or len(head.split()) > 8
            if prose or (not item.desc and len(items) > 1 and section in ("Returns", "Yields")):
                bad.append(f"{section}: {head[:80]}")
    return bad


def test_the_prose_check_finds_a_paragraph_under_returns():
    pytest.importorskip("numpydoc")
    doc = "Run it.\n\nReturns\n-------\nint\n    The count.\n\nRaises :class:`ValueError` when\nit is negative.\n"
    assert len(_prose_entries(doc)) == 2
    assert _prose_entries("Run it.\n\nReturns\n-------\nint\n    The count.\n") == []


def test_every_returns_section_lists_return_values():
    pytest.importorskip("numpydoc")
    bad = [f"{name}: {entry}" for name, doc in _public_docstrings() for entry in _prose_entries(doc)]
    assert bad == []


def test_the_api_index_lists_every_public_module_once():
    text = (DOCS / "api" / "index.md").read_text(encoding="utf-8")
    listed = re.findall(r"^modules/(\S+)$", text, flags=re.MULTILINE)
    assert sorted(listed) == sorted(fsmctl._PUBLIC_MODULES)
    assert len(listed) == len(set(listed))


def test_every_gallery_page_carries_the_fast_mode_banner(tmp_path):
    names = fsmctl_docs.copy_notebooks(tmp_path)
    assert set(fsmctl_docs.FAST_MODE) == set(names)
    for name in names:
        text = (tmp_path / f"{name}.py").read_text(encoding="utf-8")
        title = re.search(r"^# # .*$", text, flags=re.MULTILINE)
        banner = text.index("# ```{admonition} Fast mode: not the findings")
        assert title and title.end() < banner < text.index("# %%", title.end())  # under the title, same cell
        assert "{doc}`the findings page <../../findings>`" in text
        assert fsmctl_docs.FAST_MODE[name] in text


def test_a_notebook_without_a_title_is_refused():
    with pytest.raises(ValueError, match="no title line"):
        fsmctl_docs._with_banner("# %%\nx = 1\n", "03_reproduction")


def test_every_notebook_has_a_gallery_card_and_thumbnail():
    text = (DOCS / "gallery" / "index.md").read_text(encoding="utf-8")
    for path in sorted((ROOT / "notebooks").glob("*.py")):
        assert f":link: generated/{path.stem}\n" in text
        assert f":img-top: ../_static/gallery/{path.stem}.png\n" in text
        assert (DOCS / "_static" / "gallery" / f"{path.stem}.png").is_file()


# ----------------------------------------------------------------------------- the committed verdicts


def _claims(**extra) -> dict:
    rows = [
        {"id": "a", "claim": "settles | fast", "figures": "Fig 1", "paper_value": "27 s", "verdict": "differs"},
        {"id": "b", "claim": "accurate", "figures": "Fig 2", "paper_value": "< 0.03°", "verdict": "differs"},
        {"id": "c", "claim": "bounded", "figures": "Fig 4", "paper_value": "2 N m", "verdict": "impossible (bound)"},
    ]
    return {"fast": False, "verdict_kinds": ["reproduced", "differs", "impossible (bound)"], "claims": rows, **extra}


def test_the_verdict_files_count_each_verdict():
    files = make_landing.verdict_files(_claims())
    summary = files["verdicts-summary.md"]
    assert "**3 claims**" in summary
    assert "*reproduced* **0**, *differs* **2**, *impossible (bound)* **1**" in summary
    table = files["verdicts-table.md"]
    assert "| **a**: settles \\| fast | Fig 1 | 27 s | **differs** |" in table


def test_a_fast_reproduction_is_not_the_findings():
    with pytest.raises(ValueError, match="fast reproduction"):
        make_landing.verdict_files(_claims(fast=True))
    with pytest.raises(ValueError, match="no claims"):
        make_landing.verdict_files(_claims(claims=[]))


def test_the_committed_verdicts_agree():
    table = (DOCS / "_includes" / "verdicts-table.md").read_text(encoding="utf-8")
    rows = re.findall(r"^\| \*\*(\w+)\*\*: .* \| \*\*([^*]+)\*\* \|$", table, flags=re.MULTILINE)
    assert [cid for cid, _ in rows] == list(claim_ids())
    counts = Counter(verdict for _, verdict in rows)
    summary = (DOCS / "_includes" / "verdicts-summary.md").read_text(encoding="utf-8")
    stated = dict((k, int(n)) for k, n in re.findall(r"\*([a-z ()]+)\* \*\*(\d+)\*\*", summary))
    assert {k: n for k, n in stated.items() if n} == dict(counts)
    assert f"**{len(rows)} claims**" in summary
    for page in ("index.md", "findings.md"):
        assert "```{include} _includes/verdicts-summary.md" in (DOCS / page).read_text(encoding="utf-8")


def _readme_findings() -> str:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    start = readme.index("## What was found\n")
    return readme[start : readme.index("\n## ", start + 1)]


def test_the_findings_have_one_home():
    """README's "What was found" is a summary of docs/findings.md, not a second copy: a few paragraphs and the short
    verdict table, its verdicts those of the committed table (in the registry's order), every number in it also on
    the findings page, and a link to that page; nothing links to a README anchor of the findings."""
    section = _readme_findings()
    findings = (DOCS / "findings.md").read_text(encoding="utf-8")
    assert "[docs/findings.md](docs/findings.md)" in section
    assert len(section.splitlines()) <= 30 and section.count("\n|---") == 1  # one table, no errata or laws tables
    rows = [r for r in section.splitlines() if r.startswith("| ") and not r.startswith("| claim |")]
    committed = (DOCS / "_includes" / "verdicts-table.md").read_text(encoding="utf-8")
    assert [r.rsplit("| **", 1)[1].rstrip("* |") for r in rows] == re.findall(
        r"\| \*\*([^*]+)\*\* \|$", committed, re.M
    )
    missing = [
        n
        for n in re.findall(r"(?<![\w.])\d+(?:\.\d+)?", section)
        if not re.search(rf"(?<![\d.]){re.escape(n)}(?![\d])", findings)
    ]
    assert not missing, f"numbers of README's summary not on docs/findings.md: {missing}"
    linking = [
        path.relative_to(ROOT)
        for path in [ROOT / "README.md", *DOCS.rglob("*.md")]
        if "_build" not in path.parts and re.search(r"#what-was-found", path.read_text(encoding="utf-8"), re.I)
    ]
    assert not linking, f"links to README's findings anchor: {linking}"


def test_the_thumbnail_comes_from_the_first_figure(tmp_path):
    pil = pytest.importorskip("PIL.Image")
    import base64
    import io

    def png(width):
        buffer = io.BytesIO()
        pil.new("RGB", (width, width // 2), "white").save(buffer, format="PNG")
        return base64.b64encode(buffer.getvalue()).decode()

    notebook = {
        "cells": [{"outputs": [{"data": {"text/plain": "x"}}]}, {"outputs": [{"data": {"image/png": png(1000)}}]}]
    }
    first = make_landing.first_figure(notebook)
    small = pil.open(io.BytesIO(make_landing.thumbnail(first)))
    assert small.size == (make_landing.THUMBNAIL_WIDTH, make_landing.THUMBNAIL_WIDTH // 2)
    assert make_landing.first_figure({"cells": [{"cell_type": "markdown"}]}) is None
    (tmp_path / "run" / "x").mkdir(parents=True)
    (tmp_path / "run" / "x" / "nb.ipynb").write_text(json.dumps(notebook))
    (written,) = make_landing.write_thumbnails(tmp_path / "run", ["nb"], docs=tmp_path)
    assert written == tmp_path / "_static" / "gallery" / "nb.png"
    with pytest.raises(FileNotFoundError, match=r"no executed other\.ipynb"):
        make_landing.write_thumbnails(tmp_path / "run", ["other"], docs=tmp_path)


# ----------------------------------------------------------------------------- intersphinx without internet


class _Inventory(http.server.BaseHTTPRequestHandler):
    def do_GET(self):
        self.send_response(200 if self.path == "/up/objects.inv" else 404)
        self.end_headers()
        self.wfile.write(b"# Sphinx inventory version 2\n")

    def log_message(self, *args):
        pass


def test_intersphinx_maps_only_what_answers():
    server = http.server.HTTPServer(("127.0.0.1", 0), _Inventory)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        base = f"http://127.0.0.1:{server.server_port}"
        projects = {"up": f"{base}/up", "down": f"{base}/down"}
        assert fsmctl_docs.intersphinx_mapping(projects, "auto") == {"up": (f"{base}/up", None)}
        assert set(fsmctl_docs.intersphinx_mapping(projects, "on")) == {"up", "down"}
        assert fsmctl_docs.intersphinx_mapping(projects, "off") == {}
        with pytest.raises(ValueError, match="auto, on or off"):
            fsmctl_docs.intersphinx_mapping(projects, "yes")
    finally:
        server.shutdown()


# ----------------------------------------------------------------------------- the build commands


def test_the_build_keeps_doctrees_out_of_the_site_and_checks_it():
    command = "sphinx-build -W --keep-going -b html -d docs/_build/doctrees docs docs/_build/html"
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    assert command in readme and command in ci
    assert not re.search(r"sphinx-build(?!.* -d )", readme + ci)
    after = ci[ci.index(command) :]
    assert after.index("python docs/_ext/check_html.py docs/_build/html") < after.index("\n\n")
    assert "python -m pytest -p no:cacheprovider tests/test_docs_site.py" in ci
