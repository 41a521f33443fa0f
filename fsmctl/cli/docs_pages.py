"""The command-line pages ``docs/cli/*.md``, generated from the real parser as plain Markdown.

Every subcommand of :func:`fsmctl.cli.main.build_parser` (enumerated from the parser, in ``fsmctl --help``'s order)
gets one page: its description, a link to its guide and examples (:data:`EXTRAS`, optional), the usage, every
option with its help (grouped as ``--help`` groups them) and its exit codes (the ``exit codes:`` list every
subcommand's epilog ends with, :func:`fsmctl.cli.exit_codes.epilog`); ``docs/cli/index.md`` lists the commands
with their one-line descriptions, the global options and the exit codes.  The pages are committed, so a reader
browsing the repository sees them; ``tests/test_cli_docs_pages.py`` holds them equal to this module's output::

    python -m fsmctl.cli.docs_pages            # writes docs/cli/*.md
    python -m fsmctl.cli.docs_pages --check    # exit 1 with a diff when a page is stale

Markdown that survives Sphinx and GitHub alike: options, placeholders and values (``--t-final``,
``DIR/<label>.nc``, ``--set K=2.0``) are code spans, so no renderer turns ``--`` into a dash or ``<label>`` into
an HTML tag; ``*`` and ``$`` are escaped in prose; the usage is a ``text`` block at a fixed width.
"""

from __future__ import annotations

import argparse
import difflib
import re
import sys
from pathlib import Path

from fsmctl.cli.exit_codes import epilog

__all__ = ["EXTRAS", "PAGES_DIR", "ROOT", "pages", "main"]

ROOT = Path(__file__).resolve().parents[2]
"""The repository root of this checkout."""
PAGES_DIR = Path("docs") / "cli"
"""Where the pages go, relative to the repository root."""

WIDTH = 100
"""The width of the usage blocks (a fixed width: the pages do not depend on the terminal that wrote them)."""

EXIT_HEADING = epilog().splitlines()[0]
"""The line that opens the exit codes of every epilog (``exit codes:``)."""

EXTRAS: dict[str, tuple[str, tuple[str, ...]]] = {
    "prove": (
        "[Derive and check the paper](../guide/paper.md), [Write your own law](../guide/own-law.md)",
        (
            "fsmctl prove --list",
            "fsmctl prove theorem1-gains --json",
            "fsmctl prove --law pd --json",
            "fsmctl prove --law docs/examples/my_law.py --error-model exact",
        ),
    ),
    "simulate": (
        "[Fly with wheels, sensors and links](../guide/hardware.md), [Output files](../guide/outputs.md)",
        (
            "fsmctl simulate --scenario paper --case 2 --t-final 10 --out runs/case2",
            "fsmctl simulate --law pid --set K=10 --t-final 10 --no-figures --out runs/pid",
        ),
    ),
    "reproduce": (
        "[Reproduce Section 4](../guide/reproduce.md)",
        ("fsmctl reproduce --fast --no-explain --out reproduction-fast",),
    ),
    "compare-surfaces": ("", ("fsmctl compare-surfaces --fast --no-figures --out surfaces",)),
    "compare": (
        "[Write your own law](../guide/own-law.md)",
        ("fsmctl compare --laws fsm,pid --t-final 10 --with-and-without-limit --no-figures --out comparison",),
    ),
    "montecarlo": (
        "[Monte Carlo](../guide/montecarlo.md)",
        ("fsmctl montecarlo --runs 8 --t-final 5 --workers 2 --seed 1 --out mc",),
    ),
    "tune": (
        "[Tune gains](../guide/tuning.md)",
        (
            "fsmctl tune --law pid --parameters K,P --range K=1,200 --range P=1,400 --budget 16 --t-final 20 --out tune-pid",
        ),
    ),
    "laws": ("", ("fsmctl laws", "fsmctl laws pid --json")),
    "derive": (
        "[Write your own law](../guide/own-law.md)",
        (
            "fsmctl derive docs/examples/my_law.py --out my_law",
            "fsmctl derive docs/examples/my_law.py --out my_law --check",
        ),
    ),
}
"""What a page adds to its parser: the guide pages to see (Markdown links) and example commands, by subcommand.
Optional (a subcommand without an entry gets a page without them); every key must be a subcommand and every
example must parse (``tests/test_cli_docs_pages.py``)."""

_CODE_WORD = re.compile(r"--[A-Za-z]|[<>=|`$\[{]")
"""A word that is code: an option, a placeholder, an assignment, a metavar alternative, an opening bracket (a
closing one alone ends an interval in prose: ``U(0, rho_max]``)."""
_METAVAR = re.compile(r"^[A-Z][A-Z0-9_]*(?:[|,.][A-Za-z0-9_.]+)*$")
"""A metavar after an option (``--from RESULT``, ``--scenario NAME|FILE.toml``): part of the option's code span."""


def _split_punctuation(word: str) -> tuple[str, str, str]:
    """``(leading, core, trailing)``: brackets and punctuation around a word that are prose, not code."""
    lead = re.match(r"^[(\"']*", word).group()
    core = word[len(lead) :]
    trail = re.search(r"[)\"',;:.]*$", core).group()
    core = core[: len(core) - len(trail)] if trail else core
    if core.count("(") > core.count(")") and trail.startswith(")"):  # "f(x)" keeps its own bracket
        core, trail = core + ")", trail[1:]
    if core.count("[") > core.count("]") and lead == "" and core.endswith("]") is False and "]" in trail:
        core, trail = core + "]", trail.replace("]", "", 1)
    return lead, core, trail


def _open_brackets(text: str) -> int:
    return sum(text.count(c) for c in "([{") - sum(text.count(c) for c in ")]}")


def _code(text: str) -> str:
    tick = "``" if "`" in text else "`"
    pad = " " if text.startswith("`") or text.endswith("`") else ""
    return f"{tick}{pad}{text}{pad}{tick}"


def _prose(word: str) -> str:
    return re.sub(r"([*$\\_])", lambda m: "\\" + m.group(1) if m.group(1) != "_" else "_", word)


def markdown_text(text: str) -> str:
    """One paragraph of help text as Markdown: options, placeholders and values as code spans, the rest escaped.

    Consecutive code words (an option and its value: ``--set K=2.0``) form one span; a metavar after an option
    (``--from RESULT``) joins it.
    """
    words = text.split()
    out: list[str] = []
    span: list[str] = []
    lead_of_span = ""

    def close(trail: str = "") -> None:
        nonlocal lead_of_span
        if span:
            out.append(lead_of_span + _code(" ".join(span)) + trail)
            span.clear()
            lead_of_span = ""

    for word in words:
        if span and _open_brackets(" ".join(span)) > 0:  # inside brackets written with spaces: "f(a=1, b=2)"
            span.append(word)
            if _open_brackets(" ".join(span)) <= 0:  # the span ends at the closing bracket
                last = span.pop()
                end = max(last.rfind(c) for c in ")]}") + 1
                span.append(last[:end])
                close(last[end:])
            continue
        lead, core, trail = _split_punctuation(word)
        after_option = bool(span) and span[-1].startswith("--") and not lead
        code = re.search(r"[A-Za-z0-9]", core) and _CODE_WORD.search(core)
        if code or (core and after_option and _METAVAR.match(core)):
            if span and lead:
                close()
            if not span:
                lead_of_span = lead
            if _open_brackets(core + trail) > 0:  # an open bracket: the span goes on to its closing one
                span.append(core + trail)
                continue
            span.append(core)
            if trail:
                close(trail)
            continue
        close()
        out.append(_prose(word))
    close()
    return " ".join(out)


def _paragraphs(text: str) -> list[str]:
    """An epilog or description as Markdown blocks: paragraphs, ``- `` bullets, indented lines as a text block."""
    blocks: list[str] = []
    literal = False
    for chunk in re.split(r"\n[ \t]*\n", text.strip("\n")):
        lines = chunk.splitlines()
        if all(line.startswith(" ") for line in lines):  # indented: kept as it is (a file example, a table)
            lang = "toml" if literal else "text"
            body = "\n".join(line[min(len(x) - len(x.lstrip()) for x in lines) :] for line in lines)
            blocks.append(f"```{lang}\n{body}\n```")
            literal = False
            continue
        bullets: list[str] = []
        paragraph: list[str] = []
        for line in lines:
            if line.startswith("- "):
                bullets.append(line[2:].strip())
            elif bullets and line.startswith(" "):
                bullets[-1] += " " + line.strip()
            else:
                paragraph.append(line.strip())
        if paragraph:
            text_ = " ".join(paragraph)
            literal = text_.endswith("::")
            blocks.append(markdown_text(text_[:-1] if literal else text_))
        if bullets:
            blocks.append("\n".join(f"- {markdown_text(b)}" for b in bullets))
    return blocks


def _formatter(parser: argparse.ArgumentParser) -> argparse.HelpFormatter:
    return parser.formatter_class(prog=parser.prog, width=WIDTH)


def _usage(parser: argparse.ArgumentParser) -> str:
    formatter = _formatter(parser)
    formatter.add_usage(parser.usage, parser._actions, parser._mutually_exclusive_groups)
    return formatter.format_help().strip("\n")


def _options(parser: argparse.ArgumentParser, *, heading: str = "## Options") -> list[str]:
    """The positional arguments (``## Arguments``), then the options: the untitled group first, then one
    ``###`` section per titled argument group (``--help``'s groups); one bullet per option, its invocation and help."""
    formatter = _formatter(parser)
    arguments: list[str] = []
    options: list[str] = []
    for group in parser._action_groups:
        actions = [a for a in group._group_actions if a.help is not argparse.SUPPRESS]
        if not actions:
            continue
        bullets = []
        for action in actions:
            invocation = formatter._format_action_invocation(action)
            help_text = formatter._expand_help(action) if action.help else ""
            bullets.append(f"- {_code(invocation)}" + (f": {markdown_text(help_text)}" if help_text else ""))
        if group is parser._positionals:
            arguments += ["## Arguments", "", *bullets, ""]
            continue
        if group is not parser._optionals:
            options += [f"### {markdown_text(group.title[:1].upper() + group.title[1:])}", ""]
            if group.description:
                options += [markdown_text(group.description), ""]
        options += [*bullets, ""]
    return [*arguments, heading, "", *options]


def _epilog_parts(parser: argparse.ArgumentParser) -> tuple[str, list[str]]:
    """The epilog's text before the exit codes, and the exit-code lines (``- CODE: meaning``)."""
    text = parser.epilog or ""
    before, sep, codes = text.partition(EXIT_HEADING)
    if not sep:
        return text, []
    return before, [line[2:] for line in codes.strip().splitlines() if line.startswith("- ")]


def _exit_codes(lines: list[str]) -> list[str]:
    if not lines:
        return []
    out = ["## Exit codes", ""]
    for line in lines:
        code, _, meaning = line.partition(": ")
        out.append(f"- `{code}`: {markdown_text(meaning)}")
    return [*out, ""]


def _nested(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """A command's own subcommands (``fsmctl scenario show``), by name; empty for most commands."""
    actions = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return dict(actions[0].choices) if actions else {}


def _subcommands(parser: argparse.ArgumentParser) -> tuple[argparse._SubParsersAction, dict[str, str]]:
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    summaries = {choice.dest: choice.help or "" for choice in action._choices_actions}
    return action, summaries


def command_page(name: str, parser: argparse.ArgumentParser, summary: str) -> str:
    """The page of one subcommand (Markdown).

    Parameters
    ----------
    name : str
        The subcommand.
    parser : argparse.ArgumentParser
        Its parser.
    summary : str
        Its one-line help in ``fsmctl --help``.

    Returns
    -------
    str
        The page.
    """
    see, examples = EXTRAS.get(name, ("", ()))
    out = [f"# `fsmctl {name}`", ""]
    for block in _paragraphs(parser.description or f"{summary[:1].upper()}{summary[1:]}."):
        out += [block, ""]
    if see:
        out += [f"See {see}.", ""]
    if examples:
        out += ["```bash", *examples, "```", ""]
    out += ["## Usage", "", "```text", _usage(parser), "```", "", *_options(parser)]
    details, codes = _epilog_parts(parser)
    if details.strip():
        out += ["## Details", ""]
        for block in _paragraphs(details):
            out += [block, ""]
    out += _exit_codes(codes)
    for sub_name, sub in _nested(parser).items():  # a command with its own subcommands: one section each
        out += [f"## `fsmctl {name} {sub_name}`", "", *_paragraphs(sub.description or ""), ""]
        out += ["```text", _usage(sub), "```", ""]
        out += [line.replace("## ", "### ", 1) if line.startswith("## ") else line for line in _options(sub)]
    out.append(
        f"This page is generated from the parser by `python -m fsmctl.cli.docs_pages`; `fsmctl {name} --help` "
        "prints the same."
    )
    return _tidy(out)


def index_page(parser: argparse.ArgumentParser) -> str:
    """``docs/cli/index.md``: the commands with their one-line descriptions, the global options, the exit codes.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The ``fsmctl`` parser (:func:`fsmctl.cli.main.build_parser`).

    Returns
    -------
    str
        The page.
    """
    action, summaries = _subcommands(parser)
    out = [
        "# Command line",
        "",
        markdown_text(parser.description or ""),
        "",
        "`fsmctl COMMAND --help` prints a command's options; the pages below say the same, generated from the parser.",
        "",
        "## Commands",
        "",
    ]
    out += [f"- [`fsmctl {name}`]({name}.md): {markdown_text(summaries.get(name, ''))}" for name in action.choices]
    out += ["", "## Usage", "", "```text", _usage(parser), "```", ""]
    global_options = _options(parser, heading="## Global options")
    out += global_options[global_options.index("## Global options") :]  # not COMMAND: the commands are listed above
    out += ["Global options go before the command: `fsmctl --quiet simulate ...`.", ""]
    out += [
        "## Errors",
        "",
        "An error is one line on stderr, never a traceback; `fsmctl --debug COMMAND ...` (or `FSMCTL_DEBUG=1`) shows "
        "the traceback.",
        "",
    ]
    out += _exit_codes(_epilog_parts(parser)[1])
    out += ["Each command's page gives its own wording of codes 0 and 1.", ""]
    out += ["```{toctree}", ":hidden:", "", *action.choices, "```"]
    return _tidy(out)


def _tidy(lines: list[str]) -> str:
    text = "\n".join(lines)
    return re.sub(r"\n{3,}", "\n\n", text).strip("\n") + "\n"


def pages(parser: argparse.ArgumentParser | None = None) -> dict[str, str]:
    """Every page: ``index.md`` and one ``<command>.md`` per subcommand of the parser.

    Parameters
    ----------
    parser : argparse.ArgumentParser, optional
        Default: :func:`fsmctl.cli.main.build_parser`.

    Returns
    -------
    dict
        File name -> Markdown text.

    Examples
    --------
    >>> text = pages()["tune.md"]
    >>> text.splitlines()[0], "- `--t-final S`: horizon in s (default: the scenario's)" in text
    ('# `fsmctl tune`', True)
    """
    if parser is None:
        from fsmctl.cli.main import build_parser

        parser = build_parser()
    action, summaries = _subcommands(parser)
    out = {"index.md": index_page(parser)}
    for name, sub in action.choices.items():
        out[f"{name}.md"] = command_page(name, sub, summaries.get(name, ""))
    return out


def main(argv: list[str] | None = None) -> int:
    """Write (or ``--check``) ``docs/cli/*.md``; returns an exit code.

    Parameters
    ----------
    argv : list of str, optional
        ``--check`` and ``--root DIR`` (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        0 when written or current, 1 when ``--check`` finds a stale, missing or extra page.
    """
    parser = argparse.ArgumentParser(prog="python -m fsmctl.cli.docs_pages", description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="exit 1 with a diff when a page is stale")
    parser.add_argument("--root", type=Path, default=ROOT, help="repository root (default: this checkout)")
    args = parser.parse_args(argv)
    folder = args.root / PAGES_DIR
    wanted = pages()
    stale = []
    extra = sorted(p.name for p in folder.glob("*.md") if p.name not in wanted) if folder.exists() else []
    for name, text in wanted.items():
        path = folder / name
        current = path.read_text("utf-8") if path.exists() else ""
        if current == text:
            continue
        if args.check:
            stale.append(name)
            sys.stdout.writelines(difflib.unified_diff(current.splitlines(True), text.splitlines(True), name, "new"))
        else:
            from fsmctl.outputs import write_text

            write_text(path, text)
            print(f"wrote {PAGES_DIR / name}")
    for name in extra:
        if args.check:
            stale.append(name)
        else:
            (folder / name).unlink()
            print(f"removed {PAGES_DIR / name} (no such command)")
    if stale:
        print(f"stale: {', '.join(stale)}; run `python -m fsmctl.cli.docs_pages`", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
