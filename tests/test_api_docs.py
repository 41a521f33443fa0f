"""The API reference's contract: every public name has complete numpydoc, and every Examples section runs.

The public API is the ``__all__`` of each module in :data:`fsmctl._PUBLIC_MODULES` (the top-level package and
each layer package); the documentation site's API reference is generated from the same list
(``docs/api/``). The checks are numpydoc's own validator (``numpydoc.validate``), not a hand-written parser:

* functions and classes: a docstring (GL08), every parameter documented (PR01) and no unknown one (PR02),
  a Returns/Yields section when they return/yield something (RT01/YD01), an Examples section (EX01), and a
  Raises section when the body itself raises;
* public methods and properties defined by a public class: a docstring, and the parameters documented.

The Examples themselves run as doctests: ``pytest`` collects ``fsmctl/`` with ``--doctest-modules``
(``pyproject.toml``), each example in a fresh temporary working folder (``conftest.py`` at the root).
"""

from __future__ import annotations

import importlib
import inspect
import re
import textwrap

import pytest

import fsmctl

numpydoc_validate = pytest.importorskip("numpydoc.validate")

FUNCTION_CHECKS = ("GL08", "PR01", "PR02", "RT01", "YD01", "EX01")
METHOD_CHECKS = ("GL08", "PR01", "PR02")


def public_names() -> list[tuple[str, str]]:
    """(module, name) for every function and class in a public module's ``__all__``, defined where listed once."""
    seen: set[int] = set()
    out = []
    for module_name in fsmctl._PUBLIC_MODULES:
        module = importlib.import_module(module_name)
        for name in getattr(module, "__all__", ()):  # a missing __all__ fails the test below
            obj = getattr(module, name, None)
            if not (inspect.isfunction(obj) or inspect.isclass(obj)) or id(obj) in seen:
                continue
            seen.add(id(obj))
            out.append((module_name, name))
    return out


def public_methods() -> list[tuple[str, str, str]]:
    """(module, class, member) for every public method or property a public class defines itself."""
    out = []
    for module_name, name in public_names():
        cls = getattr(importlib.import_module(module_name), name)
        if not inspect.isclass(cls) or issubclass(cls, BaseException):
            continue
        for member, value in vars(cls).items():
            if member.startswith("_"):
                continue
            if isinstance(value, (staticmethod, classmethod)):
                value = value.__func__
            if inspect.isfunction(value) or isinstance(value, property):
                out.append((module_name, name, member))
    return out


def _errors(path: str, checks: tuple[str, ...]) -> list[str]:
    result = numpydoc_validate.validate(path)
    return [f"{code} {message}" for code, message in result["errors"] if code in checks]


def _raises_itself(obj) -> bool:
    try:
        source = textwrap.dedent(inspect.getsource(obj))
    except (OSError, TypeError):
        return False
    return re.search(r"^\s+raise \w", source, flags=re.MULTILINE) is not None


def test_every_layer_package_declares_its_public_api():
    for module_name in fsmctl._PUBLIC_MODULES:
        module = importlib.import_module(module_name)
        assert getattr(module, "__all__", None), f"{module_name} has no __all__"
        missing = [name for name in module.__all__ if not hasattr(module, name)]
        assert not missing, f"{module_name}.__all__ lists names it does not have: {missing}"


def test_the_public_api_is_not_empty():
    # a guard for the parametrisation below: an empty list would make every check pass vacuously
    assert len(public_names()) > 60
    assert len(public_methods()) > 20


@pytest.mark.parametrize(("module_name", "name"), public_names(), ids=lambda v: v)
def test_public_name_has_complete_numpydoc(module_name, name):
    obj = getattr(importlib.import_module(module_name), name)
    path = f"{obj.__module__}.{obj.__qualname__}"
    errors = _errors(path, FUNCTION_CHECKS)
    doc = inspect.getdoc(obj) or ""
    if inspect.isfunction(obj) and _raises_itself(obj) and "Raises\n------" not in doc:
        errors.append("Raises section missing (the function raises)")
    assert not errors, f"{module_name}.{name}: " + "; ".join(errors)


@pytest.mark.parametrize(("module_name", "cls", "member"), public_methods(), ids=lambda v: v)
def test_public_method_is_documented(module_name, cls, member):
    obj = getattr(importlib.import_module(module_name), cls)
    path = f"{obj.__module__}.{obj.__qualname__}.{member}"
    errors = _errors(path, METHOD_CHECKS)
    assert not errors, f"{module_name}.{cls}.{member}: " + "; ".join(errors)


def test_checker_fails_on_an_undocumented_function(tmp_path, monkeypatch):
    """The checks above can fail: a function without Examples or parameter docs is reported."""
    (tmp_path / "api_docs_probe.py").write_text(
        'def probe(x, y):\n    """Add.\n\n    Parameters\n    ----------\n    x : float\n        First.\n    """\n'
        "    if x < 0:\n        raise ValueError('x')\n    return x + y\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    errors = _errors("api_docs_probe.probe", FUNCTION_CHECKS)
    codes = {e.split()[0] for e in errors}
    assert {"PR01", "RT01", "EX01"} <= codes
    probe = importlib.import_module("api_docs_probe").probe
    assert _raises_itself(probe)
