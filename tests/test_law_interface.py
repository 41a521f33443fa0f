"""No library module tests a law's or a parameter's name: what the tools need is declared by the law.

The check reads the syntax tree (``ast``) of every module of ``fsmctl/`` except the symbolic layer (where the
paper's law is derived) and the law scripts of ``fsmctl/studies/explain_laws/``: no comparison (``==``, ``!=``,
``in``, ``not in``) and no ``match`` case may hold a string constant that is a built-in law's name or the name of
a parameter a built-in law declares (alone, or in a tuple, list or set).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import fsmctl
from fsmctl.model import builtin_laws

PACKAGE = Path(fsmctl.__file__).resolve().parent
EXEMPT = ("symbolic", "studies/explain_laws", "_generated")
"""folders of fsmctl/ where a law is written (the paper's law is derived in the symbolic layer), and the package data"""
NAME_TESTS = (ast.Eq, ast.NotEq, ast.In, ast.NotIn)


def law_names() -> frozenset[str]:
    """Every built-in law's name and every parameter name a built-in law declares."""
    laws = builtin_laws()
    return frozenset(laws) | frozenset(p.name for law in laws.values() for p in law.parameters)


def _constants(node: ast.AST, names: frozenset[str]) -> list[str]:
    """The law or parameter names ``node`` is (a string constant) or holds (a tuple, list or set of them)."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return [node.value] if node.value in names else []
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return [n for e in node.elts for n in _constants(e, names)]
    return []


def name_tests(source: str, names: frozenset[str]) -> list[tuple[int, str]]:
    """``(line, what)`` for every comparison or match case of ``source`` against one of ``names``."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Compare):
            operands = [node.left, *node.comparators]
            for k, op in enumerate(node.ops):
                if not isinstance(op, NAME_TESTS):
                    continue
                for side in (operands[k], operands[k + 1]):
                    hit = _constants(side, names)
                    if hit:
                        found.append((node.lineno, f"{type(op).__name__} {', '.join(sorted(set(hit)))}"))
        elif isinstance(node, ast.match_case):
            for pattern in ast.walk(node.pattern):
                if isinstance(pattern, ast.MatchValue):
                    hit = _constants(pattern.value, names)
                    if hit:
                        found.append((pattern.lineno, f"case {', '.join(hit)}"))
    return sorted(set(found))


def library_modules() -> list[Path]:
    return [
        path
        for path in sorted(PACKAGE.rglob("*.py"))
        if not any(path.relative_to(PACKAGE).as_posix().startswith(f"{d}/") for d in EXEMPT)
    ]


def test_the_check_sees_every_form_of_a_name_test():
    names = frozenset({"fsm", "delta", "c1"})
    source = "\n".join(
        [
            'if law.name == "fsm": pass',  # 1
            'if "delta" != p.name: pass',  # 2
            'ok = p.name in ("c1", "other")',  # 3
            'ok = p.name not in {"delta"}',  # 4
            'ok = a < "fsm"',  # 5: not a name test
            'x = {"fsm": 1}["fsm"]',  # 6: not a comparison
            'match p.name:\n    case "c1":\n        pass',  # 7-9
            'ok = p.name == "fsm_other"',  # 10: another name
        ]
    )
    assert name_tests(source, names) == [(1, "Eq fsm"), (2, "NotEq delta"), (3, "In c1"), (4, "NotIn delta"),
                                         (8, "case c1")]  # fmt: skip


def test_the_names_are_the_built_in_laws_and_their_parameters():
    names = law_names()
    assert {"fsm", "pid", "super_twisting", "adaptive_fsm"} <= names
    assert {"c1", "c2", "alpha", "boundary_layer", "epsilon", "singularity_fix", "delta", "k1", "gamma"} <= names
    assert len(library_modules()) > 50
    assert not any("symbolic" in p.parts for p in library_modules())


@pytest.mark.parametrize("path", library_modules(), ids=lambda p: p.relative_to(PACKAGE).as_posix())
def test_no_library_module_tests_a_law_or_parameter_name(path):
    found = name_tests(path.read_text("utf-8"), law_names())
    where = [f"fsmctl/{path.relative_to(PACKAGE).as_posix()}:{line}: {what}" for line, what in found]
    assert not where, "a law's or a parameter's name is tested (declare it on the law instead):\n" + "\n".join(where)
