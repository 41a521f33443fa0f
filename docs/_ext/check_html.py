"""Check the built documentation site for what a reader must never meet.

Run on the HTML folder of a build (``.ci/run`` does, right after ``sphinx-build``)::

    python docs/_ext/check_html.py docs/_build/html

Each page (``*.html``, not ``_static/`` or ``_sources/``) is parsed with the standard library's HTML parser and
these defects are reported, one line each, as ``page:line: kind: excerpt``; the exit status is 1 when any is found:

* ``raw-math``: ``$$`` or ``\\begin{`` in the visible text (Markdown math that was not rendered), outside code and
  outside the theme's ``math`` elements (MathJax's input, delimited by ``\\[`` and ``\\(``);
* ``raw-table``: a pipe-table rule (``|---|``) in the visible text, outside code;
* ``dash-option``: an en or em dash directly before a word (``–from``, ``—set``): Sphinx's smart quotes turned an
  option's ``--`` into a dash, so the command a reader copies fails; checked in code too;
* ``raw-placeholder``: an attribute-less ``<label>`` element (a placeholder such as ``DIR/<label>.nc`` that reached
  the HTML as a tag, so the browser shows ``DIR/.nc``);
* ``table-overflow``: a content table that is not inside a horizontally scrolling wrapper (the theme's
  ``pst-scrollable-table-container`` or ``fsmctl-scroll``), so a wide table runs off the page; Sphinx's index tables
  (``indextable``) are exempt;
* ``outside-link``: a link or image that leaves the repository (``file:`` URLs, a relative path above the site's
  root), or a path outside the repository written in the text (``../shared/``, ``shared/seed/``, ``shared/spec/``,
  or a path of the machine that built the site: ``/home/...``, ``/work/...``, ``.../site-packages/...``), checked in
  code too.

Standard library only: the tests (``tests/test_docs_site.py``) plant each defect in a small page.
"""

from __future__ import annotations

import posixpath
import re
import sys
from dataclasses import dataclass
from html.parser import HTMLParser
from pathlib import Path

SCROLL_CLASSES = frozenset({"pst-scrollable-table-container", "fsmctl-scroll"})
EXEMPT_TABLE_CLASSES = frozenset({"indextable"})
VOID = frozenset({"area", "base", "br", "col", "embed", "hr", "img", "input", "link", "meta", "source", "track", "wbr"})
HIDDEN = frozenset({"script", "style", "template", "head", "title"})
CODE = frozenset({"code", "pre", "kbd", "samp", "tt"})

RAW_MATH = re.compile(r"\$\$|\\begin\{")
RAW_TABLE = re.compile(r"\|\s*:?-{3,}:?\s*\|")
DASH_OPTION = re.compile(r"(?:^|(?<=[\s(\[\"'`=]))[\u2013\u2014][A-Za-z]")
OUTSIDE_TEXT = re.compile(
    r"\.\./shared/|(?<![\w.-])shared/(?:seed|spec)/"  # the project's seed and spec live beside the repository
    r"|(?<![\w.])/(?:home|root|work|Users)/\w|site-packages/"  # a path of the machine that built the site
)


@dataclass(frozen=True)
class Problem:
    """One defect found on a page."""

    page: str
    line: int
    kind: str
    excerpt: str

    def __str__(self) -> str:
        return f"{self.page}:{self.line}: {self.kind}: {self.excerpt}"


class _PageChecker(HTMLParser):
    def __init__(self, page: str) -> None:
        super().__init__(convert_charrefs=True)
        self.page = page
        self.folder = posixpath.dirname(page) or "."  # the page's folder, relative to the site's root
        self.stack: list[tuple[str, frozenset[str]]] = []
        self.problems: list[Problem] = []

    # -- helpers
    def _add(self, kind: str, excerpt: str) -> None:
        self.problems.append(Problem(self.page, self.getpos()[0], kind, excerpt.strip()[:120]))

    def _inside(self, names: frozenset[str]) -> bool:
        return any(tag in names for tag, _ in self.stack)

    def _check_url(self, url: str) -> None:
        url = url.strip()
        if url.lower().startswith("file:"):
            self._add("outside-link", url)
            return
        if re.match(r"^[a-z][a-z0-9+.-]*:|^#|^//", url, flags=re.I):
            return  # another site, an anchor
        path = url.split("#", 1)[0].split("?", 1)[0]
        if path.startswith("/"):
            self._add("outside-link", url)
            return
        resolved = posixpath.normpath(posixpath.join(self.folder, path)) if path else "."
        if resolved == ".." or resolved.startswith("../"):
            self._add("outside-link", url)

    # -- parser callbacks
    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        classes = frozenset((dict(attrs).get("class") or "").split())
        if tag == "label" and not attrs:
            self._add("raw-placeholder", "<label>")
        for name, value in attrs:
            if name in ("href", "src") and value:
                self._check_url(value)
        if tag == "table" and not classes & EXEMPT_TABLE_CLASSES:
            if not any(c & SCROLL_CLASSES for _, c in self.stack):
                self._add("table-overflow", f"<table class={' '.join(sorted(classes))!r}> without a scroll wrapper")
        if tag not in VOID:
            self.stack.append((tag, classes))

    def handle_startendtag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        for name, value in attrs:
            if name in ("href", "src") and value:
                self._check_url(value)

    def handle_endtag(self, tag: str) -> None:
        for i in range(len(self.stack) - 1, -1, -1):
            if self.stack[i][0] == tag:
                del self.stack[i:]
                return

    def handle_data(self, data: str) -> None:
        if not data.strip() or self._inside(HIDDEN):
            return
        in_code = self._inside(CODE)
        in_math = any("math" in classes for _, classes in self.stack)  # MathJax's input: \[ \begin{matrix} ... \]
        if not in_code:
            if not in_math and (m := RAW_MATH.search(data)):
                self._add("raw-math", data[max(0, m.start() - 20) : m.end() + 40])
            if m := RAW_TABLE.search(data):
                self._add("raw-table", data[max(0, m.start() - 20) : m.end() + 40])
        if m := DASH_OPTION.search(data):
            self._add("dash-option", data[max(0, m.start() - 30) : m.end() + 30])
        if m := OUTSIDE_TEXT.search(data):
            self._add("outside-link", data[max(0, m.start() - 30) : m.end() + 40])


def check_page(path: Path, root: Path) -> list[Problem]:
    """The defects of one HTML page of the site rooted at ``root``."""
    rel = path.relative_to(root)
    checker = _PageChecker(rel.as_posix())
    checker.feed(path.read_text(encoding="utf-8"))
    checker.close()
    return checker.problems


def check_site(html_dir: Path) -> list[Problem]:
    """The defects of every page of a built site (``*.html`` outside ``_static/`` and ``_sources/``)."""
    root = Path(html_dir)
    pages = [
        p
        for p in sorted(root.rglob("*.html"))
        if not {"_static", "_sources", "_images"} & set(p.relative_to(root).parts)
    ]
    if not pages:
        raise FileNotFoundError(f"{root}: no HTML pages (build the site first)")
    return [problem for page in pages for problem in check_page(page, root)]


def main(html_dir: str | Path) -> int:
    """Print every defect of the site in ``html_dir``; return 1 if there is any, else 0."""
    problems = check_site(Path(html_dir))
    for problem in problems:
        print(problem)
    kinds = sorted({p.kind for p in problems})
    print(f"check_html: {len(problems)} problem(s) in {html_dir}" + (f" ({', '.join(kinds)})" if kinds else ""))
    return 1 if problems else 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: python docs/_ext/check_html.py HTML_DIR")
    sys.exit(main(sys.argv[1]))
