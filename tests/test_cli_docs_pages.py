"""The command-line pages ``docs/cli/*.md`` (issue 27): generated from the real parser as plain Markdown, committed,
and current; every option, placeholder and value is a code span (no renderer turns ``--`` into a dash or
``<label>`` into a tag); every subcommand of the parser gets a page, with its exit codes."""

from __future__ import annotations

import argparse
import re

import pytest

from fsmctl.cli.docs_pages import EXTRAS, PAGES_DIR, ROOT, main, markdown_text, pages
from fsmctl.cli.exit_codes import MEANINGS
from fsmctl.cli.main import build_parser


@pytest.fixture(scope="module")
def parser() -> argparse.ArgumentParser:
    return build_parser()


def _subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    (sub,) = (a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def _prose(markdown: str) -> str:
    """The text a renderer typesets: without fenced blocks and code spans."""
    text = re.sub(r"```.*?```", "", markdown, flags=re.S)
    return re.sub(r"(`+)(?:(?!\1).)+?\1", "", text)


def test_the_committed_pages_are_the_generated_ones():
    assert main(["--check"]) == 0, "run `python -m fsmctl.cli.docs_pages`"
    assert sorted(p.name for p in (ROOT / PAGES_DIR).glob("*.md")) == sorted(pages())


def test_help_text_becomes_markdown_with_options_and_placeholders_as_code():
    text = "write DIR/<label>.nc (or .csv), e.g. --set K=2.0 --set delta=[0.01,0.01]; T * (2 + d), --from RESULT."
    expected = (
        r"write `DIR/<label>.nc` (or .csv), e.g. `--set K=2.0 --set delta=[0.01,0.01]`; T \* (2 + d), "
        "`--from RESULT`."
    )
    assert markdown_text(text) == expected
    assert markdown_text("median = Optuna's MedianPruner(a=5, b=2); 1 >= 0 costs $1") == (
        r"median = Optuna's `MedianPruner(a=5, b=2)`; 1 >= 0 costs `$1`"
    )


def test_every_option_of_every_command_is_on_its_page_as_code(parser):
    generated = pages(parser)
    for name, sub in _subcommands(parser).items():
        text = generated[f"{name}.md"]
        prose = _prose(text)
        assert not re.search(r"(?<![\w`])--[A-Za-z]", prose), (name, re.findall(r".{30}--[A-Za-z].{10}", prose))
        assert not re.search(r"<[A-Za-z]", prose), name
        for action in sub._actions:
            for option in action.option_strings:
                assert re.search(rf"^- `(?:[^`]*, )?{re.escape(option)}[ `,]", text, re.M), (name, option)
            if not action.option_strings:
                assert f"- `{action.metavar or action.dest}`" in text, (name, action.dest)
        assert "usage: fsmctl " + name in text
        codes = re.findall(r"^- `(\d+)`: ", text.split("## Exit codes")[1], re.M)
        assert [int(c) for c in codes] == list(MEANINGS), name


def test_every_subcommand_of_the_parser_gets_a_page_and_an_index_entry(parser):
    """Enumerated from the parser: a subcommand added to it (as `scenario show` will be) gets its page."""
    (sub,) = (a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    extra = sub.add_parser("extra", help="an extra command", description="Does --extra-thing with DIR/<x>.toml.")
    extra.add_argument("--level", metavar="N", help="how much (default: 1)")
    nested = extra.add_subparsers(dest="what", metavar="WHAT").add_parser("show", description="Shows --all of it.")
    nested.add_argument("--depth", metavar="D", help="how deep")
    generated = pages(parser)
    assert set(generated) == {"index.md", *(f"{n}.md" for n in sub.choices)}
    assert "## `fsmctl extra show`\n\nShows `--all` of it." in generated["extra.md"]
    assert "- `--depth D`: how deep" in generated["extra.md"].split("## `fsmctl extra show`")[1]
    assert "- [`fsmctl extra`](extra.md): an extra command" in generated["index.md"]
    assert "Does `--extra-thing` with `DIR/<x>.toml`." in generated["extra.md"]
    assert "- `--level N`: how much (default: 1)" in generated["extra.md"]
    assert set(EXTRAS) <= set(_subcommands(build_parser()))  # no extras for a command that does not exist


def test_the_index_lists_the_commands_and_no_developer_docstring(parser):
    text = pages(parser)["index.md"]
    for name, sub_help in (
        (a.dest, a.help)
        for a in next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))._choices_actions
    ):
        assert f"- [`fsmctl {name}`]({name}.md): {markdown_text(sub_help)}" in text
    assert "automodule" not in text and "eval-rst" not in text and "argparse" not in text
    assert "- `--quiet`: " in text and "## Exit codes" in text
    assert not re.search(r"(?<![\w`])--[A-Za-z]", _prose(text))
