"""Imports flow one way, and library code never imports or raises the command line's types.

Layers, from the top: command line (``fsmctl.cli.main``, the ``add_parser``/``run`` functions of the command
modules) -> studies (reproduce, surfaces, theorem3, montecarlo) -> simulation / proofs / plug-in -> model
(scenario, topology, problem) -> symbolic (``derive``).  Checked on the source (AST), so a violation is
found without running the code path.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "fsmctl"
CLI_MODULES = {"fsmctl.cli.main", "fsmctl.__main__"}
CLI_FUNCTIONS = {"add_parser", "run", "_cli", "main", "console_main"}
MODEL = {"fsmctl.errors", "fsmctl.model.scenario", "fsmctl.model.topology", "fsmctl.outputs", "fsmctl.model.scenario_schema"}
ABOVE_MODEL = ("fsmctl.simulation.simulator", "fsmctl.plugin.iosys", "fsmctl.proofs", "fsmctl.studies.reproduce", "fsmctl.studies.surfaces",
               "fsmctl.studies.montecarlo", "fsmctl.studies.theorem3", "fsmctl.cli.main", "fsmctl.cli.commands")  # fmt: skip


def _modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(ROOT).with_suffix("")
        yield ".".join(rel.parts).removesuffix(".__init__"), path


def _imports(tree: ast.AST, module: str):
    """(imported module, enclosing function name or None, node) for every import in ``tree``."""
    package = module if module.endswith("__init__") else module.rsplit(".", 1)[0]
    stack: list[str] = []

    def visit(node):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            stack.append(node.name)
            for child in ast.iter_child_nodes(node):
                yield from visit(child)
            stack.pop()
            return
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, (stack[0] if stack else None), node
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                parts = parts[: len(parts) - (node.level - 1)]
                base = ".".join(parts + ([base] if base else []))
            for alias in node.names:
                yield base, (stack[0] if stack else None), node
                yield f"{base}.{alias.name}", (stack[0] if stack else None), node
        for child in ast.iter_child_nodes(node):
            yield from visit(child)

    yield from visit(tree)


@pytest.mark.parametrize(("module", "path"), list(_modules()), ids=[m for m, _ in _modules()])
def test_library_code_never_imports_the_cli(module, path):
    if module in CLI_MODULES:
        return
    tree = ast.parse(path.read_text())
    for name, function, node in _imports(tree, module):
        if name in ("fsmctl.cli.main", "fsmctl.cli.main.UsageError"):
            assert function in CLI_FUNCTIONS, (
                f"{path.relative_to(ROOT)}:{node.lineno} imports the command line's {name} in "
                f"{function or 'module scope'}; library code raises fsmctl.errors.InputError"
            )


def test_model_layer_imports_nothing_above_it():
    for module, path in _modules():
        if module not in MODEL:
            continue
        for name, _, node in _imports(ast.parse(path.read_text()), module):
            assert not name.startswith(ABOVE_MODEL), f"{path.relative_to(ROOT)}:{node.lineno} imports {name}"


def test_symbolic_layer_never_imports_fsmctl():
    for path in sorted((ROOT / "derive").rglob("*.py")):
        for name, _, node in _imports(ast.parse(path.read_text()), "derive." + path.stem):
            assert not name.startswith("fsmctl"), f"{path.relative_to(ROOT)}:{node.lineno} imports {name}"


def test_the_checker_sees_a_violation(tmp_path):
    """The AST walk finds imports inside functions and relative imports (a checker that cannot fail is no check)."""
    tree = ast.parse("def f():\n    from ..cli import UsageError\n    raise UsageError('x')\n")
    found = [(n, f) for n, f, _ in _imports(tree, "fsmctl.proofs.claims")]
    assert ("fsmctl.cli.main.UsageError", "f") in found
