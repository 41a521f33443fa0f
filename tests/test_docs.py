"""The documentation site's structure (``docs/``), checked without building it.

The build itself (``sphinx-build -W``, notebooks executed) runs in ``.ci/run`` after the tests. These checks are
cheap and each can fail on its own:

* the API pages are generated from ``fsmctl._PUBLIC_MODULES`` (one page per module, every name of its
  ``__all__`` on it) and the site's numpydoc checks are ``tests/test_api_docs.py``'s;
* every subcommand of the real parser has a CLI page (generated from that parser by ``fsmctl.cli.docs_pages``) listed in
  the CLI index, and no page documents a subcommand that does not exist;
* every notebook of ``notebooks/`` is in the gallery's toctree (and copied into the build);
* every page under ``docs/`` is reachable from ``docs/index.md`` through the toctrees;
* every ``fsmctl ...`` command line written in a shell block of the docs parses with the real parser;
* every ``>>>`` example of the user guide runs (doctest), from a folder where ``docs/`` is the repository's.
"""

from __future__ import annotations

import argparse
import contextlib
import doctest
import importlib
import inspect
import io
import re
import shlex
import sys
from pathlib import Path

import pytest

import fsmctl
from fsmctl.cli.main import build_parser

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
GENERATED = ("_build", "api/modules", "api/generated", "gallery/generated", "jupyter_execute", "_includes")

sys.path.insert(0, str(DOCS / "_ext"))
import fsmctl_docs  # noqa: E402


def _pages() -> list[Path]:
    """Every source page under docs/: not the pages generated at build time, nor the snippets of docs/_includes/."""
    out = []
    for path in sorted(DOCS.rglob("*.md")):
        rel = path.relative_to(DOCS).as_posix()
        if not any(rel.startswith(g + "/") for g in GENERATED):
            out.append(path)
    return out


def _toctree_entries(page: Path) -> list[tuple[str, bool]]:
    """(entry, is_glob) of every ``{toctree}`` block of a MyST page, relative to the page's folder."""
    entries = []
    for block in re.findall(r"```\{toctree\}\n(.*?)```", page.read_text(encoding="utf-8"), flags=re.S):
        is_glob = ":glob:" in block
        for line in block.splitlines():
            line = line.strip()
            if line and not line.startswith(":"):
                entries.append((line, is_glob))
    return entries


def _subcommands() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


# ----------------------------------------------------------------------------- API reference


def test_api_pages_cover_every_public_module_and_name(tmp_path):
    problems = fsmctl_docs.write_api_pages(tmp_path)
    assert problems == []
    assert {p.stem for p in tmp_path.glob("*.rst")} == set(fsmctl._PUBLIC_MODULES)
    documented: dict[int, str] = {}  # id(obj) -> the one page that documents it (the first module listing it)
    for module_name in fsmctl._PUBLIC_MODULES:
        text = (tmp_path / f"{module_name}.rst").read_text()
        assert f".. automodule:: {module_name}" in text
        module = importlib.import_module(module_name)
        own = re.findall(r"^   (\w+)$", text, flags=re.M)  # autosummary entries documented on this page
        links = re.findall(r"^   ~([\w.]+)$", text, flags=re.M)  # re-exports: a link to where they are documented
        data = re.findall(r"^\.\. py:data:: (\w+)$", text, flags=re.M)
        for name in own:
            documented[id(getattr(module, name))] = f"{module_name}.{name}"
        for name in module.__all__:
            obj = getattr(module, name)
            if not (inspect.isfunction(obj) or inspect.isclass(obj)):
                assert name in data, f"{module_name}.{name} is not on its API page"
            elif name in own:
                assert text.count(f"\n   {name}\n") == 1
            else:
                target = documented.get(id(obj))
                assert target in links, f"{module_name}.{name} is neither documented nor linked on its API page"
        assert len(own) + len(links) + len(data) == len(module.__all__)
    # every public function and class has exactly one page
    callables = {
        id(obj)
        for m in fsmctl._PUBLIC_MODULES
        for n in importlib.import_module(m).__all__
        if inspect.isfunction(obj := getattr(importlib.import_module(m), n)) or inspect.isclass(obj)
    }
    assert set(documented) == callables and len(callables) > 60
    # the site builds these pages where the API index's toctree looks for them
    assert fsmctl_docs.API_MODULES_DIR == DOCS / "api" / "modules"
    listed = [entry for entry, _ in _toctree_entries(DOCS / "api" / "index.md")]  # grouped by topic
    assert sorted(listed) == sorted(f"modules/{m}" for m in fsmctl._PUBLIC_MODULES)


def test_api_page_generator_reports_a_module_without_all(tmp_path, monkeypatch):
    """The generator can fail: a public module without ``__all__`` is a problem (a warning, an error under -W)."""
    import fsmctl.errors

    monkeypatch.delattr(fsmctl.errors, "__all__")
    problems = fsmctl_docs.write_api_pages(tmp_path)
    assert "fsmctl.errors has no __all__: its API page is empty" in problems
    assert not re.search(r"^   \w+$", (tmp_path / "fsmctl.errors.rst").read_text(), flags=re.M)


def test_numpydoc_checks_are_the_api_tests():
    api_tests = pytest.importorskip("test_api_docs")
    assert fsmctl_docs.FUNCTION_CHECKS == api_tests.FUNCTION_CHECKS
    assert fsmctl_docs.METHOD_CHECKS == api_tests.METHOD_CHECKS
    conf = (DOCS / "conf.py").read_text()
    assert "numpydoc_validation_checks = set(fsmctl_docs.FUNCTION_CHECKS)" in conf
    # members of classes are left to check_members (METHOD_CHECKS); functions and classes are not excluded
    pattern = re.compile(fsmctl_docs.MEMBER_PATTERN)
    assert pattern.search("fsmctl.Scenario.replace") and pattern.search("fsmctl.studies.Comparison.to_csv")
    assert not pattern.search("fsmctl.load_scenario") and not pattern.search("fsmctl.model.Scenario")


# ----------------------------------------------------------------------------- CLI pages


def test_every_subcommand_has_a_cli_page():
    commands = _subcommands()
    assert len(commands) >= 9
    pages = {p.stem for p in (DOCS / "cli").glob("*.md")} - {"index"}
    assert pages == set(commands), f"missing: {set(commands) - pages}, no such command: {pages - set(commands)}"
    for name in commands:  # generated from the parser (tests/test_cli_docs_pages.py holds them current)
        text = (DOCS / "cli" / f"{name}.md").read_text()
        assert text.startswith(f"# `fsmctl {name}`\n") and "python -m fsmctl.cli.docs_pages" in text, name
    assert {entry for entry, _ in _toctree_entries(DOCS / "cli" / "index.md")} == set(commands)


def test_every_subcommand_says_what_its_exit_codes_mean():
    for name, parser in _subcommands().items():
        text = f"{parser.description or ''} {parser.epilog or ''}".lower()
        assert "exit code" in text and re.search(r"\b0\b", text) and re.search(r"\b2\b", text), name


# ----------------------------------------------------------------------------- gallery and navigation


def test_every_notebook_is_in_the_gallery(tmp_path):
    notebooks = {p.stem for p in (ROOT / "notebooks").glob("*.py")}
    assert notebooks
    entries = {entry for entry, _ in _toctree_entries(DOCS / "gallery" / "index.md")}
    assert entries == {f"generated/{name}" for name in notebooks}
    assert set(fsmctl_docs.copy_notebooks(tmp_path)) == notebooks
    assert fsmctl_docs.GALLERY_DIR == DOCS / "gallery" / "generated"


def _reachable() -> set[Path]:
    seen: set[Path] = set()
    todo = [DOCS / "index.md"]
    while todo:
        page = todo.pop()
        if page in seen:
            continue
        seen.add(page)
        for entry, is_glob in _toctree_entries(page):
            if is_glob or entry.startswith(("generated/", "modules/")):
                continue  # generated at build time: the API modules, the gallery's notebooks
            target = (page.parent / entry).with_suffix(".md")
            assert target.exists(), f"{page.relative_to(DOCS)}: toctree entry {entry} has no page"
            todo.append(target)
    return seen


def test_every_page_is_reachable_from_the_index():
    reachable = _reachable()
    unreachable = [p.relative_to(DOCS).as_posix() for p in _pages() if p not in reachable]
    assert unreachable == []
    guide = {entry for entry, _ in _toctree_entries(DOCS / "guide" / "index.md")}
    assert {p.stem for p in (DOCS / "guide").glob("*.md")} - {"index"} == guide


# ----------------------------------------------------------------------------- command lines and examples


def _shell_blocks(text: str) -> list[str]:
    return re.findall(r"```(?:bash|console|sh|shell)\n(.*?)```", text, flags=re.S)


def _command_lines(text: str) -> list[str]:
    """Every ``fsmctl ...`` line of the shell blocks (continuations joined, comments and prompts dropped)."""
    out = []
    for block in _shell_blocks(text):
        for line in block.replace("\\\n", " ").splitlines():
            line = line.strip().removeprefix("$ ")
            for part in re.split(r"\s(?:&&|\|\||;)\s", line):
                part = part.strip()
                if part.startswith("fsmctl "):
                    out.append(part)
    return out


def _parse_error(line: str) -> str | None:
    argv = shlex.split(line, comments=True)[1:]
    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            build_parser().parse_args(argv)
    except SystemExit as exc:
        return f"{line!r}: exit {exc.code}: {err.getvalue().strip()}"
    return None


def test_every_command_line_in_the_docs_parses():
    lines = [(p, line) for p in _pages() for line in _command_lines(p.read_text(encoding="utf-8"))]
    assert len(lines) > 40  # the guide, the CLI pages and the examples write many
    commands = {shlex.split(line, comments=True)[1] for _, line in lines}
    assert set(_subcommands()) <= commands  # every subcommand is shown at least once
    errors = [f"{p.relative_to(DOCS)}: {e}" for p, line in lines if (e := _parse_error(line))]
    assert errors == []


def test_the_command_line_check_can_fail():
    text = "```bash\nfsmctl simulate --no-such-option 1   # a comment\nfsmctl prove --list\n```\n"
    lines = _command_lines(text)
    assert lines == ["fsmctl simulate --no-such-option 1   # a comment", "fsmctl prove --list"]
    assert "fsmctl simulate: unknown option --no-such-option" in _parse_error(lines[0])
    assert _parse_error(lines[1]) is None
    assert "invalid choice" in _parse_error("fsmctl simulate --integrator euler")


def _doctest_pages() -> list[Path]:
    return [p for p in _pages() if ">>> " in p.read_text(encoding="utf-8")]


def test_the_guide_has_runnable_examples():
    assert {p.stem for p in _doctest_pages()} >= {"scenarios", "own-law", "hardware", "python-control", "outputs"}


@pytest.mark.parametrize("page", _doctest_pages(), ids=lambda p: p.relative_to(DOCS).as_posix())
def test_guide_examples_run(page, tmp_path, monkeypatch):
    (tmp_path / "docs").symlink_to(DOCS, target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    blocks = re.findall(r"```python\n(.*?)```", page.read_text(encoding="utf-8"), flags=re.S)
    source = "\n".join(b for b in blocks if ">>> " in b)
    test = doctest.DocTestParser().get_doctest(source, {}, page.stem, str(page), 0)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    out = io.StringIO()
    runner.run(test, out=out.write)
    assert runner.failures == 0, out.getvalue()
    assert runner.tries >= 3
