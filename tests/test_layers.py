"""Imports flow one way, and library code never imports or raises the command line's types.

The rules are the contracts of ``.importlinter`` (import-linter, ``lint-imports --config .importlinter``):

* layers, from the top: ``fsmctl.cli`` -> ``fsmctl.studies`` -> ``fsmctl.simulation | fsmctl.proofs |
  fsmctl.plugin`` (independent siblings) -> ``fsmctl.model`` -> ``fsmctl.codegen`` -> ``fsmctl.symbolic`` ->
  ``fsmctl.outputs`` -> ``fsmctl.errors``; an import may only go down (indirect chains included);
* nothing but ``fsmctl.cli`` (and the ``fsmctl.__main__`` entry point) imports ``fsmctl.cli``;
* ``fsmctl.symbolic`` is pure SymPy: it imports neither NumPy nor CasADi, even indirectly;
* the library never imports ``derive`` (the project's code generator, not installed: the built-in laws'
  derivation scripts are read as files, :func:`fsmctl.model.generated_paths.builtin_law_scripts`);
* inside ``fsmctl.simulation``, ``fsmctl.plugin``, ``fsmctl.model`` and ``fsmctl.studies`` the modules are
  layered as well (every module placed, imports only downward), so that no import cycle hides in a
  function-local import.

They are checked on the source, so a violation is found without running the code path.  A fixture copy of
the package with planted violations shows that the check can fail.  The AST checks below add what an import
graph cannot see: library code never raises or subclasses the command line's exception types.
"""

from __future__ import annotations

import ast
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "fsmctl"
CONFIG = ROOT / ".importlinter"
CONTRACTS = (
    "layers",
    "cli-only-at-the-top",
    "no-derive",
    "symbolic-is-pure-sympy",
    "simulation-modules",
    "plugin-modules",
    "model-modules",
    "studies-modules",
)
CLI_PACKAGE = "fsmctl.cli"
ENTRY_POINTS = {"fsmctl.__main__"}


def _lint(cwd: Path, *contracts: str) -> subprocess.CompletedProcess:
    """``lint-imports --config .importlinter --no-cache [--contract ID ...]`` in ``cwd``, with this interpreter."""
    pytest.importorskip("importlinter", reason="pip install import-linter (the project's test extra)")
    argv = [sys.executable, "-c", "from importlinter.cli import lint_imports_command; lint_imports_command()"]
    argv += ["--config", str(cwd / ".importlinter"), "--no-cache"]
    for c in contracts:
        argv += ["--contract", c]
    env = {**os.environ, "COLUMNS": "200", "NO_COLOR": "1", "PYTHONPATH": str(cwd)}
    return subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True, timeout=300)


def test_config_declares_the_contracts():
    text = CONFIG.read_text()
    for contract in CONTRACTS:
        assert f"[importlinter:contract:{contract}]" in text


@pytest.mark.parametrize("contract", CONTRACTS)
def test_import_contract_is_kept(contract):
    proc = _lint(ROOT, contract)
    assert proc.returncode == 0, f"import contract {contract!r} is broken:\n{proc.stdout[-6000:]}{proc.stderr[-2000:]}"
    assert "KEPT" in proc.stdout and "BROKEN" not in proc.stdout


def _copy_sources(dest: Path) -> None:
    for package in ("fsmctl", "derive"):
        for path in (ROOT / package).rglob("*.py"):
            if "__pycache__" in path.parts:
                continue
            target = dest / path.relative_to(ROOT)
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(path, target)
    shutil.copyfile(CONFIG, dest / ".importlinter")


PLANTED = {
    # module in the fixture copy -> (its source, text import-linter must print)
    "fsmctl/studies/_planted_cli.py": (
        "def run():\n    from fsmctl.cli.main import UsageError\n    raise UsageError('x')\n",
        "fsmctl.studies._planted_cli -> fsmctl.cli.main",
    ),
    "fsmctl/proofs/_planted_sibling.py": (
        "from fsmctl.simulation import metrics\n",
        "fsmctl.proofs._planted_sibling -> fsmctl.simulation.metrics",
    ),
    "fsmctl/model/_planted_up.py": (
        "from ..studies import figures\n",
        "fsmctl.model._planted_up -> fsmctl.studies.figures",
    ),
    "fsmctl/symbolic/_planted_numpy.py": (
        "import numpy as np\n",
        "fsmctl.symbolic._planted_numpy -> numpy",
    ),
    "fsmctl/proofs/_planted_derive.py": (
        "def laws():\n    from derive.laws import BUILTIN_LAWS\n    return BUILTIN_LAWS\n",
        "fsmctl.proofs._planted_derive -> derive.laws",
    ),
    # a cycle closed by a function-local import, inside each layered package
    "fsmctl/simulation/failures.py": (
        "def hint():\n    from fsmctl.simulation.simulator import simulate\n",
        "fsmctl.simulation.failures -> fsmctl.simulation.simulator",
    ),
    "fsmctl/plugin/jacobians.py": (
        "def f():\n    from fsmctl.plugin import iosys\n",
        "fsmctl.plugin.jacobians -> fsmctl.plugin.iosys",
    ),
    "fsmctl/model/generated_paths.py": (
        "def f():\n    from fsmctl.model.laws import resolve_law\n",
        "fsmctl.model.generated_paths -> fsmctl.model.laws",
    ),
    "fsmctl/studies/campaign.py": (
        "def f():\n    from fsmctl.studies.montecarlo import run\n",
        "fsmctl.studies.campaign -> fsmctl.studies.montecarlo.run",
    ),
}


def test_the_contracts_catch_planted_violations(tmp_path):
    """A copy of the sources with one violation of each kind: every contract breaks and names the import."""
    _copy_sources(tmp_path)
    for rel, (source, _) in PLANTED.items():
        (tmp_path / rel).write_text(source)
    proc = _lint(tmp_path)
    out = " ".join(proc.stdout.split())
    assert proc.returncode != 0, proc.stdout[-4000:]
    for _, needle in PLANTED.values():
        assert needle in out, (needle, proc.stdout[-6000:])
    assert out.count("BROKEN") >= len(CONTRACTS), proc.stdout[-6000:]


# ----------------------------------------------------------------------------- the command line's types (AST)


def _modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(ROOT).with_suffix("")
        yield ".".join(rel.parts).removesuffix(".__init__"), path


def _cli_types() -> set[str]:
    """Names of the classes the command-line package defines (``UsageError``, ...)."""
    names = set()
    for module, path in _modules():
        if module == CLI_PACKAGE or module.startswith(CLI_PACKAGE + "."):
            names |= {n.name for n in ast.walk(ast.parse(path.read_text())) if isinstance(n, ast.ClassDef)}
    return names


def _bindings(tree: ast.AST, module: str) -> dict[str, str]:
    """Every name an import binds anywhere in ``tree`` -> the dotted name it refers to."""
    package = module if module.endswith("__init__") else module.rsplit(".", 1)[0]
    out: dict[str, str] = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                out[(alias.asname or alias.name).split(".")[0]] = (
                    alias.name if alias.asname else alias.name.split(".")[0]
                )
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                parts = parts[: len(parts) - (node.level - 1)]
                base = ".".join(parts + ([base] if base else []))
            for alias in node.names:
                out[alias.asname or alias.name] = f"{base}.{alias.name}"
    return out


def _dotted(node: ast.AST) -> str | None:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        head = _dotted(node.value)
        return None if head is None else f"{head}.{node.attr}"
    if isinstance(node, ast.Call):
        return _dotted(node.func)
    return None


def cli_type_uses(tree: ast.AST, module: str, cli_types: set[str]) -> list[tuple[int, str, str]]:
    """``(line, what, name)`` for every ``raise`` of, or class derived from, a command-line type in ``tree``.

    A name counts when it resolves (through the module's imports) into ``fsmctl.cli``, or when it is spelled
    as one of the command line's class names without being bound to something else by an import (so
    ``from fsmctl.errors import InputError as UsageError`` is an ``InputError``).
    """
    bound = _bindings(tree, module)

    def resolve(name: str) -> str:
        head, _, rest = name.partition(".")
        target = bound.get(head, head)
        return f"{target}.{rest}" if rest else target

    def is_cli(name: str | None) -> bool:
        if name is None:
            return False
        full = resolve(name)
        if full == CLI_PACKAGE or full.startswith(CLI_PACKAGE + "."):
            return True
        return name.split(".")[0] not in bound and name.rsplit(".", 1)[-1] in cli_types

    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Raise) and node.exc is not None and is_cli(_dotted(node.exc)):
            found.append((node.lineno, "raises", _dotted(node.exc)))
        elif isinstance(node, ast.ClassDef):
            for base in node.bases:
                if is_cli(_dotted(base)):
                    found.append((node.lineno, "subclasses", _dotted(base)))
        elif isinstance(node, ast.Import):
            found += [(node.lineno, "imports", a.name) for a in node.names if is_cli(a.name)]
        elif isinstance(node, ast.ImportFrom):
            names = {n for n, t in _bindings(node, module).items() if is_cli(t)}
            found += [(node.lineno, "imports", n) for n in sorted(names)]
    return found


@pytest.mark.parametrize(("module", "path"), list(_modules()), ids=[m for m, _ in _modules()])
def test_library_code_never_imports_raises_or_subclasses_the_cli_types(module, path):
    if module == CLI_PACKAGE or module.startswith(CLI_PACKAGE + ".") or module in ENTRY_POINTS:
        return
    found = cli_type_uses(ast.parse(path.read_text()), module, _cli_types())
    assert not found, (
        f"{path.relative_to(ROOT)}: "
        + "; ".join(f"line {line}: {what} {name}" for line, what, name in found)
        + " (library code raises fsmctl.errors.InputError or a subclass; UsageError is the command line's)"
    )


def test_the_cli_defines_usage_error_as_an_input_error():
    from fsmctl.cli.main import UsageError
    from fsmctl.errors import InputError

    assert issubclass(UsageError, InputError)
    assert "UsageError" in _cli_types()


@pytest.mark.parametrize(
    ("source", "expected"),
    [
        ("def f():\n    from ..cli.main import UsageError\n    raise UsageError('x')\n", {"raises", "imports"}),
        ("from fsmctl.cli import main\nclass E(main.UsageError):\n    pass\n", {"subclasses", "imports"}),
        ("import fsmctl.cli.main\ndef f():\n    raise fsmctl.cli.main.UsageError('x')\n", {"raises", "imports"}),
        ("class E(UsageError):\n    pass\n", {"subclasses"}),
        ("from fsmctl.errors import InputError as UsageError\nraise UsageError('x')\n", set()),
        ("from fsmctl.errors import InputError\nraise InputError('x')\n", set()),
    ],
)
def test_the_ast_checker_sees_a_violation(source, expected):
    """The AST walk finds raises and subclasses in functions, through relative imports and aliases."""
    found = cli_type_uses(ast.parse(source), "fsmctl.proofs.claims", {"UsageError", "Terminated"})
    assert {what for _, what, _ in found} == expected, found


# ----------------------------------------------------------------------------- policy constants (AST)

POLICY_MODULE = "fsmctl.policy"
STUDIES_PACKAGE = "fsmctl.studies"
CONSTANT = re.compile(r"^_?[A-Z][A-Z0-9_]*$")
# constants the command line may take from a study: the study's own vocabulary (what a campaign varies, the files
# it writes), from which the command builds its options; a policy constant (a tolerance, a window, a default
# horizon, a timeout, a batch size, a worker count) lives in fsmctl.policy instead
CLI_STUDY_CONSTANTS_ALLOWED = {
    "fsmctl.studies.montecarlo.SAMPLING_RANGES": "the campaign's sampling settings: one option each",
    "fsmctl.studies.montecarlo.HARDWARE_RANGES": "the campaign's hardware settings: one option each",
    "fsmctl.studies.montecarlo.VARY": "the campaign's --vary choices",
    "fsmctl.studies.montecarlo.COMPLETE_MARKER": "the name of the file a finished campaign writes last",
}


def study_constants_used(tree: ast.AST, module: str) -> list[tuple[int, str]]:
    """``(line, dotted name)`` of every constant (an UPPER_CASE name) of ``fsmctl.studies`` that ``tree`` imports
    (``from fsmctl.studies.x import NAME``, relative or not) or reads as an attribute of an imported study module."""
    bound = _bindings(tree, module)
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            for target in _bindings(node, module).values():
                head, _, last = target.rpartition(".")
                if (head == STUDIES_PACKAGE or head.startswith(STUDIES_PACKAGE + ".")) and CONSTANT.match(last):
                    found.append((node.lineno, target))
        elif isinstance(node, ast.Attribute) and CONSTANT.match(node.attr):
            owner = _dotted(node.value)
            if owner is None:
                continue
            head, _, rest = owner.partition(".")
            full = bound.get(head, head) + (f".{rest}" if rest else "")
            if full == STUDIES_PACKAGE or full.startswith(STUDIES_PACKAGE + "."):
                found.append((node.lineno, f"{full}.{node.attr}"))
    return found


def policy_redefinitions(tree: ast.AST, policy: dict[str, object]) -> list[tuple[int, str]]:
    """``(line, what)`` for every module-level name of ``policy`` that ``tree`` defines again (an assignment or a
    ``def``), and every tuple literal equal to one of ``policy``'s tuples (a default spelled out again)."""
    found = []
    for node in getattr(tree, "body", []):
        targets = []
        if isinstance(node, ast.Assign):
            targets = [t.id for t in node.targets if isinstance(t, ast.Name)]
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            targets = [node.target.id]
        elif isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            targets = [node.name]
        found += [(node.lineno, f"defines {name}") for name in targets if name in policy]
    tuples = {value: name for name, value in policy.items() if isinstance(value, tuple)}
    for node in ast.walk(tree):
        if isinstance(node, ast.Tuple):
            try:
                value = ast.literal_eval(node)
            except ValueError:  # not a literal (a name inside)
                continue
            if all(isinstance(v, (int, float)) for v in value) and value in tuples:
                found.append((node.lineno, f"spells out {tuples[value]} = {value!r}"))
    return found


def _policy() -> dict[str, object]:
    import fsmctl.policy

    return {name: getattr(fsmctl.policy, name) for name in fsmctl.policy.__all__}


@pytest.mark.parametrize(
    ("module", "path"),
    [(m, p) for m, p in _modules() if m == CLI_PACKAGE or m.startswith(CLI_PACKAGE + ".")],
    ids=lambda v: str(v),
)
def test_the_cli_takes_no_policy_constant_from_a_study(module, path):
    """The command line reads its defaults and the numbers in its help from :mod:`fsmctl.policy`, never by importing
    a study module for a constant (the study's vocabulary in :data:`CLI_STUDY_CONSTANTS_ALLOWED` aside)."""
    used = study_constants_used(ast.parse(path.read_text()), module)
    found = [(line, name) for line, name in used if name not in CLI_STUDY_CONSTANTS_ALLOWED]
    assert not found, f"{path.relative_to(ROOT)}: " + "; ".join(f"line {n}: {name}" for n, name in found)


@pytest.mark.parametrize(
    ("module", "path"), [(m, p) for m, p in _modules() if m != POLICY_MODULE], ids=lambda v: str(v)
)
def test_every_policy_constant_has_one_home(module, path):
    """No module defines a name of :mod:`fsmctl.policy` again or spells out one of its tuples: it imports them."""
    found = policy_redefinitions(ast.parse(path.read_text()), _policy())
    assert not found, f"{path.relative_to(ROOT)}: " + "; ".join(f"line {n}: {what}" for n, what in found)


def test_the_policy_checkers_see_a_violation():
    """The two AST walks above find what they look for: the checks can fail."""
    cases = {
        "from fsmctl.studies.paper_runs import SETTLING_TOLERANCES_DEG\n": [
            "fsmctl.studies.paper_runs.SETTLING_TOLERANCES_DEG"
        ],
        "def f():\n    from ..studies.tune import BATCH\n": ["fsmctl.studies.tune.BATCH"],
        "from fsmctl.studies import campaign\nx = campaign.DASK_TIMEOUT_S\n": [
            "fsmctl.studies.campaign.DASK_TIMEOUT_S"
        ],
        "import fsmctl.studies.compare as c\nx = c.DEFAULT_TOLERANCES_DEG\n": [
            "fsmctl.studies.compare.DEFAULT_TOLERANCES_DEG"
        ],
        "from fsmctl.studies.compare import compare_laws\nfrom fsmctl.policy import FAST_T_FINAL_S\n": [],
    }
    for source, expected in cases.items():
        assert [name for _, name in study_constants_used(ast.parse(source), "fsmctl.cli.x")] == expected, source
    policy = _policy()
    planted = (
        "STEADY_WINDOW_MAX_S = 40.0\n"
        "def default_workers():\n    return 1\n"
        "def summary(tolerances_deg=(1.0, 0.1, 0.05, 0.03, 0.01)):\n    pass\n"
        "OK = (1.0, 0.1)\n"
    )
    assert [what.split(" =")[0] for _, what in policy_redefinitions(ast.parse(planted), policy)] == [
        "defines STEADY_WINDOW_MAX_S",
        "defines default_workers",
        "spells out SETTLING_TOLERANCES_DEG",
    ]
