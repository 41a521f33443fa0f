"""A report as a structured document, rendered as Markdown and as one self-contained HTML file.

``fsmctl reproduce`` builds its report once, as a :class:`Document` of blocks (:class:`Heading`,
:class:`Paragraph`, :class:`Bullets`, :class:`Table`, :class:`Code`, :class:`Figures`, :class:`Details`) whose text
is a sequence of plain strings and :class:`Span` s (bold, code, a link, a verdict); :func:`render_markdown` and
:func:`render_html` write the same content in each format.  Neither renderer parses the other's output: the HTML is
generated from the blocks, every text through :func:`html.escape`, the figures embedded as ``data:`` URIs (so the
file can be shared alone), the evidence in collapsible ``<details>``.
"""

from __future__ import annotations

import base64
import html
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

__all__ = [
    "Span",
    "strong",
    "code",
    "link",
    "verdict",
    "plain",
    "Heading",
    "Paragraph",
    "Bullets",
    "Table",
    "Code",
    "Figure",
    "Figures",
    "Details",
    "Document",
    "render_markdown",
    "render_html",
]


@dataclass(frozen=True)
class Span:
    """A piece of text with a style: ``strong``, ``code``, ``link`` (to ``href``) or ``verdict``.

    Parameters
    ----------
    text : str
        The text.
    style : str
        ``"strong"``, ``"code"``, ``"link"`` or ``"verdict"`` (bold, coloured by the verdict in HTML).
    href : str
        The target of a link: a file relative to the report, or ``#anchor``.

    Examples
    --------
    >>> render_markdown(Document("T", [Paragraph(("see ", link("runs/case1.nc", "runs/case1.nc")))])).splitlines()[2]
    'see [runs/case1.nc](runs/case1.nc)'
    """

    text: str
    style: str = "strong"
    href: str = ""


Text = tuple[str | Span, ...]
"""Running text: plain strings and :class:`Span` s."""


def strong(text: str) -> Span:
    """Bold text.

    Parameters
    ----------
    text : str
        The text.

    Returns
    -------
    Span
        ``Span(text, "strong")``.
    """
    return Span(text, "strong")


def code(text: str) -> Span:
    """Code (a name, a command).

    Parameters
    ----------
    text : str
        The text.

    Returns
    -------
    Span
        ``Span(text, "code")``.
    """
    return Span(text, "code")


def link(text: str, href: str) -> Span:
    """A link to a file of the report's folder (relative path) or to an anchor (``#id``).

    Parameters
    ----------
    text : str
        The text.
    href : str
        The target.

    Returns
    -------
    Span
        ``Span(text, "link", href)``.
    """
    return Span(text, "link", href)


def verdict(text: str) -> Span:
    """A verdict (``reproduced``, ``differs``, ``impossible (bound)``, ``fits``, ``does not fit``): bold, coloured in HTML.

    Parameters
    ----------
    text : str
        The verdict.

    Returns
    -------
    Span
        ``Span(text, "verdict")``.
    """
    return Span(text, "verdict")


def plain(text: Text | str) -> str:
    """The text without its styles (what a reader sees).

    Parameters
    ----------
    text : Text or str
        Running text.

    Returns
    -------
    str
        The concatenated text.

    Examples
    --------
    >>> plain(("a ", strong("b"), " ", link("c", "#c")))
    'a b c'
    """
    if isinstance(text, str):
        return text
    return "".join(p if isinstance(p, str) else p.text for p in text)


@dataclass(frozen=True)
class Heading:
    """A section heading; ``anchor`` is its id in HTML (in Markdown the heading text gives the anchor)."""

    level: int
    text: str
    anchor: str = ""


@dataclass(frozen=True)
class Paragraph:
    """A paragraph of running text."""

    text: Text


@dataclass(frozen=True)
class Bullets:
    """A bulleted list, one running text per item."""

    items: Sequence[Text]


@dataclass(frozen=True)
class Table:
    """A table: a header of plain strings, rows of running text; ``css`` is its HTML class."""

    header: Sequence[str]
    rows: Sequence[Sequence[Text]]
    css: str = ""


@dataclass(frozen=True)
class Code:
    """Preformatted lines."""

    lines: Sequence[str]


@dataclass(frozen=True)
class Figure:
    """A figure file (a PNG, relative to the report's folder) and its caption."""

    path: str
    caption: str


@dataclass(frozen=True)
class Figures:
    """Figures shown side by side (HTML) or one after the other (Markdown)."""

    figures: Sequence[Figure]


@dataclass(frozen=True)
class Details:
    """Evidence a reader opens on demand: a ``<details>`` element in HTML, a bold lead-in and the blocks in Markdown."""

    summary: Text
    blocks: Sequence[Block]
    css: str = ""


Block = Heading | Paragraph | Bullets | Table | Code | Figures | Details


@dataclass
class Document:
    """A report: its title and blocks.

    Parameters
    ----------
    title : str
        The title (the first line).
    blocks : list of Block
        The content, in order.

    Examples
    --------
    >>> doc = Document("Report", [Paragraph(("2 claims: ", verdict("1 differs"), "."))])
    >>> render_markdown(doc)
    '# Report\\n\\n2 claims: **1 differs**.\\n'
    """

    title: str
    blocks: list[Block] = field(default_factory=list)


# ----------------------------------------------------------------------------- Markdown


def _md_inline(text: Text | str, cell: bool = False) -> str:
    out = []
    for p in (text,) if isinstance(text, str) else text:
        if isinstance(p, str):
            out.append(p)
        elif p.style == "code":
            out.append(f"`{p.text}`")
        elif p.style == "link":
            out.append(f"[{p.text}]({p.href})")
        else:
            out.append(f"**{p.text}**")
    s = "".join(out).replace("\n", " ")
    return s.replace("|", "\\|") if cell else s


def _md_block(block: Block) -> list[str]:
    if isinstance(block, Heading):
        return ["#" * block.level + " " + block.text, ""]
    if isinstance(block, Paragraph):
        return [_md_inline(block.text), ""]
    if isinstance(block, Bullets):
        return [*(f"- {_md_inline(item)}" for item in block.items), ""]
    if isinstance(block, Table):
        lines = ["| " + " | ".join(_md_inline(h, cell=True) for h in block.header) + " |"]
        lines.append("|" + "---|" * len(block.header))
        lines += ["| " + " | ".join(_md_inline(c, cell=True) for c in row) + " |" for row in block.rows]
        return [*lines, ""]
    if isinstance(block, Code):
        return ["```", *block.lines, "```", ""]
    if isinstance(block, Figures):
        return [line for f in block.figures for line in (f"![{f.caption}]({f.path})", "")]
    lines = [f"**{_md_inline(block.summary)}**", ""]
    for b in block.blocks:
        lines += _md_block(b)
    return lines


def render_markdown(doc: Document) -> str:
    """The document as Markdown (GitHub-flavoured: pipe tables, ``![...](...)`` figures linked, not embedded).

    Parameters
    ----------
    doc : Document
        The report.

    Returns
    -------
    str
        Markdown ending with one newline.

    Examples
    --------
    >>> doc = Document("R", [Table(["claim", "verdict"], [[("a|b",), (verdict("differs"),)]])])
    >>> print(render_markdown(doc))
    # R
    <BLANKLINE>
    | claim | verdict |
    |---|---|
    | a\\|b | **differs** |
    <BLANKLINE>
    """
    lines = [f"# {doc.title}", ""]
    for block in doc.blocks:
        lines += _md_block(block)
    while lines and lines[-1] == "":
        lines.pop()
    return "\n".join(lines) + "\n"


# ----------------------------------------------------------------------------- HTML

_CSS = """
body{font:16px/1.5 system-ui,-apple-system,"Segoe UI",sans-serif;color:#1d1d1f;margin:0 auto;max-width:76rem;
padding:1rem 1.5rem 4rem}
p,li,summary{max-width:52rem}
h1{font-size:1.6rem;line-height:1.25}h2{margin-top:2.2rem;border-bottom:1px solid #ddd}h3{margin-bottom:.3rem}
.scroll{overflow-x:auto;max-width:100%;margin:.6rem 0}
table{border-collapse:collapse;font-size:.92rem}
th,td{border:1px solid #d0d0d0;padding:.3rem .55rem;text-align:left;vertical-align:top}
th{background:#f3f3f3}
table.summary td{white-space:normal;min-width:6rem}
code,pre{font-family:ui-monospace,SFMono-Regular,Menlo,Consolas,monospace;font-size:.88em}
pre{background:#f6f6f6;padding:.6rem;overflow-x:auto}
details{border:1px solid #ddd;border-radius:6px;padding:.3rem .9rem;margin:.6rem 0}
summary{cursor:pointer;font-weight:600}
.figures{display:flex;flex-wrap:wrap;gap:1rem}
figure{margin:.4rem 0;flex:1 1 22rem;max-width:38rem}
figure img{width:100%;height:auto;border:1px solid #eee}
figcaption{font-size:.85rem;color:#555}
.verdict{font-weight:700;padding:0 .3em;border-radius:3px;white-space:nowrap}
.v-ok{color:#0b6e2e;background:#e3f4e8}
.v-differs{color:#8a4b00;background:#fcefd9}
.v-impossible{color:#a3001b;background:#fbe3e6}
"""


_TABLE_END = "</tbody></table></div>"

# a verdict, or a count of one ("2 differ"), -> its colour class
_VERDICT_CLASS = {
    "reproduced": "v-ok",
    "fits": "v-ok",
    "fit": "v-ok",
    "differs": "v-differs",
    "differ": "v-differs",
    "does not fit": "v-differs",
    "do not fit": "v-differs",
    "impossible (bound)": "v-impossible",
}


def _verdict_class(text: str) -> str:
    """``"impossible (bound)"`` -> ``"v-impossible"``; a count (``"2 differ"``) takes its verdict's class."""
    number, _, rest = text.partition(" ")
    return _VERDICT_CLASS.get(rest if number.isdigit() else text, "v-other")


def _html_inline(text: Text | str) -> str:
    out = []
    for p in (text,) if isinstance(text, str) else text:
        if isinstance(p, str):
            out.append(html.escape(p))
        elif p.style == "code":
            out.append(f"<code>{html.escape(p.text)}</code>")
        elif p.style == "link":
            out.append(f'<a href="{html.escape(p.href)}">{html.escape(p.text)}</a>')
        elif p.style == "verdict":
            out.append(f'<span class="verdict {_verdict_class(p.text)}">{html.escape(p.text)}</span>')
        else:
            out.append(f"<strong>{html.escape(p.text)}</strong>")
    return "".join(out)


def _data_uri(path: Path) -> str:
    kind = "image/svg+xml" if path.suffix == ".svg" else "image/png"
    return f"data:{kind};base64," + base64.b64encode(path.read_bytes()).decode("ascii")


def _html_block(block: Block, base: Path) -> list[str]:
    if isinstance(block, Heading):
        anchor = f' id="{html.escape(block.anchor)}"' if block.anchor else ""
        return [f"<h{block.level}{anchor}>{html.escape(block.text)}</h{block.level}>"]
    if isinstance(block, Paragraph):
        return [f"<p>{_html_inline(block.text)}</p>"]
    if isinstance(block, Bullets):
        return ["<ul>", *(f"<li>{_html_inline(item)}</li>" for item in block.items), "</ul>"]
    if isinstance(block, Table):
        css = f' class="{html.escape(block.css)}"' if block.css else ""
        head = "".join(f"<th>{html.escape(h)}</th>" for h in block.header)
        rows = ["<tr>" + "".join(f"<td>{_html_inline(c)}</td>" for c in row) + "</tr>" for row in block.rows]
        return [f'<div class="scroll"><table{css}>', f"<thead><tr>{head}</tr></thead>", "<tbody>", *rows, _TABLE_END]
    if isinstance(block, Code):
        return ["<pre>" + html.escape("\n".join(block.lines)) + "</pre>"]
    if isinstance(block, Figures):
        figs = [
            f'<figure id="{html.escape(Path(f.path).stem)}"><img src="{_data_uri(base / f.path)}" '
            f'alt="{html.escape(f.caption)}"><figcaption>{html.escape(f.caption)}</figcaption></figure>'
            for f in block.figures
        ]
        return ['<div class="figures">', *figs, "</div>"]
    css = f' class="{html.escape(block.css)}"' if block.css else ""
    inner = [line for b in block.blocks for line in _html_block(b, base)]
    return [f"<details{css}>", f"<summary>{_html_inline(block.summary)}</summary>", *inner, "</details>"]


def render_html(doc: Document, base: str | Path) -> str:
    """The document as one self-contained HTML page: inline CSS, figures embedded, evidence in ``<details>``.

    Parameters
    ----------
    doc : Document
        The report.
    base : str or Path
        The report's folder: figure paths are read from there (and embedded); links stay relative to it.

    Returns
    -------
    str
        The HTML page.

    Raises
    ------
    OSError
        If a figure file cannot be read.

    Examples
    --------
    >>> doc = Document("R", [Details(("claim ", verdict("differs")), [Paragraph(("why: the <limit>",))], "claim")])
    >>> page = render_html(doc, ".")
    >>> '<details class="claim">' in page, "the &lt;limit&gt;" in page, 'class="verdict v-differs"' in page
    (True, True, True)
    """
    base = Path(base)
    body = [line for block in doc.blocks for line in _html_block(block, base)]
    title = html.escape(doc.title)
    return "\n".join(
        [
            "<!DOCTYPE html>",
            '<html lang="en">',
            "<head>",
            '<meta charset="utf-8">',
            '<meta name="viewport" content="width=device-width, initial-scale=1">',
            f"<title>{title}</title>",
            f"<style>{_CSS.strip()}</style>",
            "</head>",
            "<body>",
            f"<h1>{title}</h1>",
            *body,
            "</body>",
            "</html>",
            "",
        ]
    )
