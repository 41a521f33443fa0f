"""Conventions of the ``fsmctl`` command line, checked on the real parser (``fsmctl.cli.main.build_parser()``).

* One concept, one option: a ``dest`` that several subcommands have must have the same option strings, metavar,
  type, action and choices everywhere; an option has one spelling (0.x: no hidden former spelling such as
  ``--jobs``).
* One rule for the default of ``--workers``: every command leaves it to :func:`fsmctl.policy.default_workers`
  (resolved when the command runs, so that ``--help`` and the documentation do not show one machine's CPUs) and
  says so in the same words.
* Help without raw placeholders: no ``%(``, ``{``, ``}``, ``TODO``, ``XXX`` and no empty help in an option's,
  a subcommand's or a description's text (epilogs may show TOML braces, but no ``%(``, ``TODO``, ``XXX``).
* Every subcommand's epilog lists every exit code :func:`fsmctl.cli.main.main` can return (0, 1, 2, 130, 143),
  each with a meaning, and what ``main`` returns for a success, a bug, bad input, SIGINT and SIGTERM is the code
  whose meaning says so (a behavioural oracle, independent of how the epilog is built).
* The library's INFO records on the ``fsmctl`` logger (e.g. the first-compile notice) are one line on stderr,
  prefixed ``fsmctl: ``, without timestamps; ``--debug`` adds DEBUG, ``--quiet`` keeps warnings only.

Each checker is also run on a planted, broken parser, so that a checker that cannot fail is caught.
"""

from __future__ import annotations

import argparse
import logging
import re

import pytest

import fsmctl.cli.main as cli_main
from fsmctl.cli.exit_codes import MEANINGS
from fsmctl.cli.options import HelpFormatter
from fsmctl.cli.parallel_options import WORKERS_DEFAULT_TEXT, chosen_workers
from fsmctl.errors import InputError
from fsmctl.policy import default_workers

EXPECTED_CODES = [0, 1, 2, 130, 143]  # main(): success, failure/bug, input error, SIGINT, SIGTERM
RAW = ("%(", "{", "}", "TODO", "XXX")
MINIMAL_ARGV = {"derive": ["law.py"], "tune": ["--law", "pid"]}  # what a subcommand requires to parse


def subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    (sub,) = (a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def _signature(action: argparse.Action) -> tuple:
    return (
        tuple(action.option_strings),
        action.metavar,
        getattr(action.type, "__qualname__", action.type),
        type(action).__name__,
        tuple(action.choices) if action.choices else None,
    )


def option_conflicts(parser: argparse.ArgumentParser) -> list[str]:
    """Dests that differ in option strings, metavar, type, action or choices between subcommands."""
    seen: dict[str, dict[tuple, list[str]]] = {}
    for name, sp in subcommands(parser).items():
        for action in sp._actions:
            if isinstance(action, argparse._HelpAction):
                continue
            seen.setdefault(action.dest, {}).setdefault(_signature(action), []).append(name)
    return [
        f"{dest}: " + "; ".join(f"{sig} in {', '.join(names)}" for sig, names in variants.items())
        for dest, variants in seen.items()
        if len(variants) > 1
    ]


FORMER_SPELLINGS = ("--jobs",)  # renamed options: gone everywhere (0.x), not kept as hidden aliases


def workers_problems(parser: argparse.ArgumentParser) -> list[str]:
    """``--workers`` options whose default is not the one rule, and former spellings that are still accepted."""
    problems = []
    for name, sp in subcommands(parser).items():
        for spelling in FORMER_SPELLINGS:
            if spelling in sp._option_string_actions:
                problems.append(f"{name} {spelling}: a former spelling is still accepted")
        action = sp._option_string_actions.get("--workers")
        if action is None:
            continue
        if action.default is not None:
            problems.append(f"{name} --workers: default {action.default!r}, not the one rule (None: default_workers)")
        if not (action.help or "").endswith(f"(default: {WORKERS_DEFAULT_TEXT})"):
            problems.append(f"{name} --workers: the help does not state the one rule")
    return problems


def _texts(parser: argparse.ArgumentParser):
    """(where, text, is_epilog) for every help text of the parser and its subcommands."""
    yield "fsmctl description", parser.description, False
    yield "fsmctl epilog", parser.epilog, True
    (sub,) = (a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for choice in sub._choices_actions:
        yield f"fsmctl {choice.dest}: summary", choice.help, False
    for name, sp in [("fsmctl", parser), *subcommands(parser).items()]:
        if sp is not parser:
            yield f"{name} description", sp.description, False
            yield f"{name} epilog", sp.epilog, True
        for action in sp._actions:
            if action.help is argparse.SUPPRESS or isinstance(action, argparse._SubParsersAction):
                continue
            yield f"{name} {'/'.join(action.option_strings) or action.dest}", action.help, False


def placeholder_problems(parser: argparse.ArgumentParser) -> list[str]:
    problems = []
    for where, text, is_epilog in _texts(parser):
        if text is None or not text.strip():
            problems.append(f"{where}: empty help")
            continue
        raw = [r for r in RAW if r in text and not (is_epilog and r in "{}")]
        if raw:
            problems.append(f"{where}: raw {raw} in {text!r}")
    return problems


def epilog_codes(epilog: str | None) -> dict[int, str]:
    """The ``exit codes:`` list of an epilog, as {code: meaning}."""
    if not epilog or "exit codes:" not in epilog:
        return {}
    block = epilog.split("exit codes:", 1)[1]
    return {int(code): meaning.strip() for code, meaning in re.findall(r"^- (\d+): (.*)$", block, re.M)}


def epilog_problems(parser: argparse.ArgumentParser) -> list[str]:
    problems = []
    for name, sp in subcommands(parser).items():
        codes = epilog_codes(sp.epilog)
        if sorted(codes) != EXPECTED_CODES:
            problems.append(f"{name}: the epilog lists exit codes {sorted(codes)}, not {EXPECTED_CODES}")
        problems += [f"{name}: exit code {c} has no meaning" for c, text in codes.items() if not text]
    return problems


@pytest.fixture(scope="module")
def parser():
    return cli_main.build_parser()


def _planted() -> argparse.ArgumentParser:
    """A parser breaking every convention once."""
    p = argparse.ArgumentParser(prog="fsmctl")
    sub = p.add_subparsers(dest="command")
    a = sub.add_parser("a", help="first", description="A.", epilog="exit codes:\n\n- 0: ok\n- 2: input")
    a.add_argument("--out", metavar="DIR", help="output folder (default: %(default)s)")
    a.add_argument("--workers", type=int, default=2, help="workers (default: 2)")
    a.add_argument("--jobs", type=int, help=argparse.SUPPRESS)
    b = sub.add_parser("b", help="", description="B {x}.")
    b.add_argument("--out", metavar="FOLDER", help="TODO")
    b.add_argument("--seed", type=int, help="seed")
    c = sub.add_parser("c", help="third", description="C.", epilog="see the docs")
    c.add_argument("--seed", type=float, help="seed")
    return p


def test_the_checkers_catch_a_planted_parser():
    planted = _planted()
    assert {p.split(":")[0] for p in option_conflicts(planted)} == {"out", "seed"}
    assert sorted(p.split(":")[0] for p in workers_problems(planted)) == ["a --jobs", "a --workers", "a --workers"]
    found = placeholder_problems(planted)
    for needle in ("fsmctl b: summary: empty help", "b description: raw ['{', '}']", "a --out: raw ['%(']",
                   "b --out: raw ['TODO']"):  # fmt: skip
        assert any(needle in p for p in found), (needle, found)
    assert [p.split(":")[0] for p in epilog_problems(planted)] == ["a", "b", "c"]


def test_one_concept_one_option_across_subcommands(parser):
    assert option_conflicts(parser) == []


def test_the_shared_options_are_where_the_brief_says(parser):
    """Same dest, same option: a few that used to differ, spelled out independently of the modules."""
    sub = subcommands(parser)
    for name in ("prove", "reproduce", "compare-surfaces", "compare", "montecarlo", "tune"):
        action = sub[name]._option_string_actions["--workers"]
        assert (action.dest, action.metavar) == ("workers", "N"), name
    for name in ("simulate", "reproduce", "compare-surfaces", "compare", "montecarlo"):
        assert "--no-figures" in sub[name]._option_string_actions, name
    for name in ("simulate", "reproduce", "compare", "montecarlo", "tune"):
        assert sub[name]._option_string_actions["--no-progress"].dest == "progress", name
    for name in ("montecarlo", "tune"):
        assert {"--dask", "--dask-timeout"} <= set(sub[name]._option_string_actions), name
    for name in ("prove", "simulate", "reproduce", "compare-surfaces", "compare", "montecarlo", "tune"):
        assert sub[name]._option_string_actions["--scenario"].metavar == "NAME|FILE.toml", name


PARALLEL_COMMANDS = ("prove", "reproduce", "compare-surfaces", "compare", "montecarlo", "tune")


def test_every_workers_option_follows_the_one_rule(parser):
    assert workers_problems(parser) == []
    sub = subcommands(parser)
    assert {name for name, sp in sub.items() if "--workers" in sp._option_string_actions} == set(PARALLEL_COMMANDS)


@pytest.mark.parametrize("name", PARALLEL_COMMANDS)
def test_the_workers_a_command_starts(name, parser, monkeypatch):
    """Not given: one per CPU this process may use (the same for every command); given: that number."""
    argv = [name, *MINIMAL_ARGV.get(name, [])]
    assert chosen_workers(parser.parse_args(argv)) == default_workers()
    assert chosen_workers(parser.parse_args([*argv, "--workers", "3"])) == 3
    monkeypatch.setattr("fsmctl.cli.parallel_options.default_workers", lambda: 7)  # the rule is looked up at run time
    assert chosen_workers(parser.parse_args(argv)) == 7


@pytest.mark.parametrize("name", ["prove", "reproduce"])
def test_the_former_jobs_spelling_is_gone(name, capsys, tmp_path):
    """Exit 2, one line: ``--jobs`` is an unknown option like any other (0.x: no shim, no notice)."""
    with pytest.raises(SystemExit) as exc:
        cli_main.main([name, "--jobs", "2", "--out", str(tmp_path / "o")])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert f"fsmctl {name}: unknown option --jobs" in err and "deprecated" not in err
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_help_has_no_raw_placeholders(parser):
    assert placeholder_problems(parser) == []
    for name, sp in [("fsmctl", parser), *subcommands(parser).items()]:
        text = sp.format_help()  # argparse expands %-formats here: it must not fail
        assert "%(" not in text and "==SUPPRESS==" not in text, name


def test_help_texts_are_valid_restructuredtext(parser):
    """The documentation renders every help text, description and epilog as reStructuredText (sphinx-argparse),
    built with warnings as errors: ``|x|`` (a substitution), a stray indentation or a bare ``*emphasis`` fail it."""
    import io

    docutils_core = pytest.importorskip("docutils.core")
    problems = []
    for where, text, _ in _texts(parser):
        stream = io.StringIO()
        docutils_core.publish_doctree(text or "", settings_overrides={"warning_stream": stream, "report_level": 2})
        if stream.getvalue().strip():
            problems.append(f"{where}: {stream.getvalue().strip()}")
    assert problems == []


def test_every_subcommand_lists_every_exit_code(parser):
    assert epilog_problems(parser) == []
    for name, sp in subcommands(parser).items():
        codes = epilog_codes(sp.epilog)
        assert codes[2].startswith(("usage", "an unknown law", "the script does not derive")), name
        assert codes[130].startswith("interrupted (SIGINT"), name
        assert codes[143].startswith("terminated (SIGTERM)"), name
        assert "internal error" in codes[1], name
        assert re.search(r"^exit codes:\n\n- 0: \S", sp.format_help(), re.M), name  # a list, also in --help
    assert epilog_codes(parser.epilog).keys() == set(EXPECTED_CODES)


def test_generic_meanings_come_from_one_place(parser):
    codes = epilog_codes(subcommands(parser)["simulate"].epilog)
    assert codes[2] == MEANINGS[2] and codes[143] == MEANINGS[143]


class _Boom(Exception):
    pass


OUTCOMES = [  # what the command does -> the code main() returns -> a word its documented meaning must hold
    (lambda: 0, 0, ""),
    (lambda: (_ for _ in ()).throw(_Boom("a bug")), 1, "internal error"),
    (lambda: (_ for _ in ()).throw(InputError("bad input")), 2, "input"),
    (lambda: (_ for _ in ()).throw(KeyboardInterrupt()), 130, "interrupted"),
    (lambda: (_ for _ in ()).throw(cli_main.Terminated()), 143, "terminated"),
]


@pytest.mark.parametrize("name", sorted(subcommands(cli_main.build_parser())))
def test_what_main_returns_is_what_the_epilog_says(name, monkeypatch, capsys):
    real = cli_main.build_parser
    documented = epilog_codes(subcommands(real())[name].epilog)
    for behaviour, code, word in OUTCOMES:

        def patched(behaviour=behaviour):
            p = real()
            subcommands(p)[name].set_defaults(func=lambda args: behaviour())
            return p

        monkeypatch.setattr(cli_main, "build_parser", patched)
        got = cli_main.main([name, *MINIMAL_ARGV.get(name, [])])
        err = capsys.readouterr().err
        assert got == code, (name, code, err)
        assert word in documented[got], (name, got, documented[got])
        assert len(err.strip().splitlines()) == (0 if code == 0 else 1), err


# ----------------------------------------------------------------------------- the library's messages


def _main_logging(monkeypatch, records, *argv):
    """Run ``fsmctl [argv] laws`` with the command replaced by one that logs ``records`` on the fsmctl logger."""
    real = cli_main.build_parser

    def command(args):
        for logger, level, message in records:
            logging.getLogger(logger).log(level, message, "fsm")
        return 0

    def patched():
        p = real()
        subcommands(p)["laws"].set_defaults(func=command)
        return p

    monkeypatch.setattr(cli_main, "build_parser", patched)
    return cli_main.main([*argv, "laws"])


NOTICE = ("fsmctl.model.generated_code", logging.INFO, "compiling the generated C for law %r (first use, ~10 s)")
DETAIL = ("fsmctl.model.generated_code", logging.DEBUG, "cache key of %s:\n  abc")
WARNING = ("fsmctl.studies", logging.WARNING, "law %s: something to know")


def test_a_library_notice_is_one_line_on_stderr(monkeypatch, capsys):
    assert _main_logging(monkeypatch, [NOTICE, DETAIL]) == 0
    out, err = capsys.readouterr()
    assert err == "fsmctl: compiling the generated C for law 'fsm' (first use, ~10 s)\n"  # no time, no level name
    assert out == ""


def test_debug_shows_debug_records_and_quiet_only_warnings(monkeypatch, capsys):
    assert _main_logging(monkeypatch, [NOTICE, DETAIL, WARNING], "--debug") == 0
    assert capsys.readouterr().err.splitlines() == [
        "fsmctl: compiling the generated C for law 'fsm' (first use, ~10 s)",
        "fsmctl: cache key of fsm: abc",  # one line, even for a message with a line break
        "fsmctl: warning: law fsm: something to know",
    ]
    assert _main_logging(monkeypatch, [NOTICE, DETAIL, WARNING], "--quiet") == 0
    assert capsys.readouterr().err.splitlines() == ["fsmctl: warning: law fsm: something to know"]


def test_the_logger_is_left_as_it_was(monkeypatch, capsys):
    logger = logging.getLogger("fsmctl")
    handlers, level = list(logger.handlers), logger.level
    _main_logging(monkeypatch, [NOTICE])
    assert logger.handlers == handlers and logger.level == level
    capsys.readouterr()
    logging.getLogger(NOTICE[0]).info("after the command")  # nothing of the CLI's is left to print it
    assert "fsmctl: after the command" not in capsys.readouterr().err


# ----------------------------------------------------------------------------- the help layout


def test_help_formatter_wraps_paragraphs_and_keeps_lists():
    text = (
        "first paragraph with quite a few words in it that must be wrapped\nand joined.\n\n"
        "exit codes:\n\n- 0: a meaning long enough to wrap onto a second line of the help\n- 2: short\n\n"
        "  0    a meaning long enough to wrap onto a second line of the help\n"
        "  term  a definition\n        continued here"
    )
    lines = HelpFormatter("x", width=42)._fill_text(text, 40, "").splitlines()
    assert lines == [  # 40 columns
        "first paragraph with quite a few words",
        "in it that must be wrapped and joined.",
        "",
        "exit codes:",
        "",
        "- 0: a meaning long enough to wrap onto",
        "  a second line of the help",
        "- 2: short",
        "",
        "  0    a meaning long enough to wrap",
        "       onto a second line of the help",
        "  term  a definition continued here",
    ]


def test_a_resource_warning_during_a_command_is_not_the_users(monkeypatch, capsys):
    """An unclosed file collected during a command (pytest's or a library's) is not printed as an fsmctl warning,
    while a library's own warning still is, once, as one line."""
    import warnings

    import fsmctl.cli.laws as laws_command
    from fsmctl.cli.main import main

    def run(args):
        warnings.warn("unclosed file <_io.TextIOWrapper name=22>", ResourceWarning, stacklevel=1)
        warnings.warn("a notice for the user", UserWarning, stacklevel=1)
        return 0

    monkeypatch.setattr(laws_command, "run", run)
    assert main(["laws"]) == 0
    err = capsys.readouterr().err
    assert "ResourceWarning" not in err
    assert err.count("fsmctl: warning: UserWarning: a notice for the user") == 1
