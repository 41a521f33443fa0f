"""Build-time page generation for the fsmctl documentation site (used by ``docs/conf.py``).

One source for each generated part:

* the API reference: one page per module of :data:`fsmctl._PUBLIC_MODULES` (the list ``tests/test_api_docs.py``
  checks), each with an autosummary of that module's ``__all__``; autosummary then writes one stub page per name
  into ``docs/api/generated/``;
* the gallery: the jupytext notebooks ``notebooks/*.py``, copied into ``docs/gallery/generated/`` (Sphinx reads only
  its source folder) and executed by myst-nb;
* intersphinx: which projects' inventories the build maps (:func:`intersphinx_mapping`, offline-safe);
* links from inline code to fsmctl's own names (:func:`link_code_names`): ``fsmctl.simulate`` written as code in
  a page or docstring links to that name's API page;
* the numpydoc checks: the same codes as ``tests/test_api_docs.py`` (``FUNCTION_CHECKS`` for functions and classes,
  ``METHOD_CHECKS`` for the members of public classes; ``tests/test_docs.py`` holds them equal).

Everything written here is under gitignored folders (``docs/.gitignore``).
"""

from __future__ import annotations

import functools
import importlib
import inspect
import re
import shutil
import textwrap
from pathlib import Path

DOCS = Path(__file__).resolve().parent.parent
ROOT = DOCS.parent
NOTEBOOKS = ROOT / "notebooks"
API_MODULES_DIR = DOCS / "api" / "modules"
API_STUBS_DIR = DOCS / "api" / "generated"
GALLERY_DIR = DOCS / "gallery" / "generated"

FUNCTION_CHECKS = ("GL08", "PR01", "PR02", "RT01", "YD01", "EX01")
"""numpydoc checks of every public function and class (as ``tests/test_api_docs.py``)."""
METHOD_CHECKS = ("GL08", "PR01", "PR02")
"""numpydoc checks of the public methods and properties of public classes (as ``tests/test_api_docs.py``)."""

MEMBER_PATTERN = r"\.[A-Z][A-Za-z0-9_]*\.[A-Za-z_][A-Za-z0-9_]*$"
"""A documented name that is a member of a class (``fsmctl.Scenario.replace``): checked with METHOD_CHECKS."""


def public_modules() -> tuple[str, ...]:
    import fsmctl

    return tuple(fsmctl._PUBLIC_MODULES)


def _title(text: str, char: str = "=") -> str:
    return f"{text}\n{char * len(text)}\n"


def api_page(module_name: str, documented: dict[int, str] | None = None) -> tuple[str, list[str]]:
    """The reST source of one module's API page and the problems found (a module without ``__all__``, ...).

    ``documented`` maps ``id(obj)`` to the full name under which an object already has its page (filled in
    here): an object a later module re-exports is listed with a link to that page, not documented twice
    (the same first-listed-wins rule as ``tests/test_api_docs.py``).
    """
    documented = {} if documented is None else documented
    module = importlib.import_module(module_name)
    names = list(getattr(module, "__all__", None) or [])
    problems = [] if names else [f"{module_name} has no __all__: its API page is empty"]
    objects, links, data = [], [], []
    for name in names:
        if not hasattr(module, name):
            problems.append(f"{module_name}.__all__ lists {name!r}, which it does not have")
            continue
        obj = getattr(module, name)
        if not (inspect.isfunction(obj) or inspect.isclass(obj)):
            data.append(name)
        elif id(obj) in documented:
            links.append(documented[id(obj)])
        else:
            documented[id(obj)] = f"{module_name}.{name}"
            objects.append(name)
    lines = [
        f".. _api-{module_name}:",
        "",
        _title(f"``{module_name}``"),
        f".. automodule:: {module_name}",
        "   :no-members:",
        "",
        f".. currentmodule:: {module_name}",
        "",
    ]
    if objects:
        lines += [".. autosummary::", "   :toctree: ../generated", "   :nosignatures:", ""]
        lines += [f"   {name}" for name in objects]
        lines.append("")
    if links:
        lines += [".. rubric:: Also exported here (documented where first listed)", ""]
        lines += [".. autosummary::", "   :nosignatures:", ""]
        lines += [f"   ~{full}" for full in links]
        lines.append("")
    for name in data:
        value = getattr(module, name)
        shown = repr(value)
        lines += [f".. py:data:: {name}", ""]
        if len(shown) <= 80:
            lines += [f"   ``{shown}``", ""]
        else:
            size = len(value) if hasattr(value, "__len__") else 1
            lines += [f"   A ``{type(value).__name__}`` of {size} item(s).", ""]
    return "\n".join(lines), problems


def write_api_pages(out: Path = API_MODULES_DIR, stubs: Path | None = None) -> list[str]:
    """Write one page per public module into ``out`` (replacing what was there); return the problems found.

    ``stubs`` (the autosummary folder, ``docs/api/generated/`` for the site) is emptied too, so that no page of
    a name that left an ``__all__`` survives from an earlier build.
    """
    for folder in (out, stubs):
        if folder is not None and folder.exists():
            shutil.rmtree(folder)
    out.mkdir(parents=True)
    problems: list[str] = []
    documented: dict[int, str] = {}
    for module_name in public_modules():
        text, found = api_page(module_name, documented)
        problems += found
        (out / f"{module_name}.rst").write_text(text, encoding="utf-8")
    return problems


FAST_MODE = {
    "01_derivation": "the errata list stops at the proof check's errata (the re-audit's are in the full run)",
    "02_proof_check": "only the cheap claims, 300 random samples instead of 3000 and a 60-point feasibility grid",
    "03_reproduction": '10 s horizons instead of the paper\'s 100 s, so the verdicts below ("not within 10 s") are '
    "not the reproduction's",
    "04_theorem3": "a small grid of initial errors and 10 s full-loop runs",
    "05_robustness": "two values per parameter and 10 s horizons",
    "06_your_own_law": "40 s horizons instead of 100 s",
    "07_paper_on_hardware": "a 100 s horizon instead of 600 s and a 4-run campaign instead of 16",
    "08_event_triggered": "outputs every 0.5 s instead of 0.1 s and three threshold floors instead of five",
    "09_certify": "a 30 s branch-and-bound budget per candidate instead of 60 s (the same regions and verdicts)",
}
"""What the gallery's fast mode (``FSMCTL_FAST=1``) shortens in each notebook: the banner on its page."""


def fast_banner(name: str) -> str:
    """The MyST admonition put under a gallery page's title: what fast mode changes, where the findings are."""
    return "\n".join(
        [
            "```{admonition} Fast mode: not the findings",
            ":class: warning",
            "",
            f"This page was executed when the site was built, in the test suite's fast mode (`FSMCTL_FAST=1`): "
            f"{FAST_MODE[name]}. The full-horizon results are on {{doc}}`the findings page <../../findings>`; run "
            "the notebook without `FSMCTL_FAST` (or `fsmctl reproduce`) for them.",
            "```",
        ]
    )


def _with_banner(source: str, name: str) -> str:
    """``source`` (a jupytext py:percent notebook) with :func:`fast_banner` under its title (``# # ...``).

    Raises ``ValueError`` for a notebook without a title line.
    """
    title = re.search(r"^# # .*\n", source, flags=re.MULTILINE)
    if title is None:
        raise ValueError(f"notebook {name} has no title line ('# # ...' in its first Markdown cell)")
    banner = "#\n" + "".join(f"# {line}".rstrip() + "\n" for line in fast_banner(name).splitlines()) + "#\n"
    return source[: title.end()] + banner + source[title.end() :]


def copy_notebooks(out: Path = GALLERY_DIR) -> list[str]:
    """Copy ``notebooks/*.py`` into ``out`` (replacing what was there), each with its fast-mode banner first.

    Returns their names (stems).  Raises ``KeyError`` for a notebook without a :data:`FAST_MODE` entry.
    """
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    names = []
    for path in sorted(NOTEBOOKS.glob("*.py")):
        (out / path.name).write_text(_with_banner(path.read_text(encoding="utf-8"), path.stem), encoding="utf-8")
        names.append(path.stem)
    return names


def _raises_itself(obj) -> bool:
    try:
        source = textwrap.dedent(inspect.getsource(obj))
    except (OSError, TypeError):
        return False
    return re.search(r"^\s+raise \w", source, flags=re.MULTILINE) is not None


_CHECKED: set[str] = set()


def check_members(app, what, name, obj, options, lines) -> None:
    """``autodoc-process-docstring``: what numpydoc's own validation (functions, classes) does not cover.

    Members of public classes get ``METHOD_CHECKS``; a function whose body raises needs a Raises section
    (the rules of ``tests/test_api_docs.py``).  Problems are Sphinx warnings (errors under ``-W``).
    """
    from numpydoc.validate import validate
    from sphinx.util import logging

    logger = logging.getLogger("fsmctl_docs")
    if not name.startswith("fsmctl.") or name in _CHECKED:
        return  # autosummary's tables process a docstring again: report each name once
    _CHECKED.add(name)
    if what in ("method", "property") and re.search(MEMBER_PATTERN, name):
        try:
            errors = validate(name)["errors"]
        except Exception as exc:  # an object numpydoc cannot import by this name: report, do not crash
            logger.warning(f"{name}: numpydoc could not validate it ({exc})")
            return
        for code, message in errors:
            if code in METHOD_CHECKS:
                logger.warning(f"{name}: {code} {message}")
    elif what == "function" and _raises_itself(obj) and "Raises\n------" not in (inspect.getdoc(obj) or ""):
        logger.warning(f"{name}: Raises section missing (the function raises)")


def skip_data_members(app, what, name, obj, skip, options):
    """``autodoc-skip-member``: a class page documents its methods and properties, not its data attributes.

    The fields of a class are its numpydoc Parameters/Attributes (in the class docstring); documenting each
    field again as a member would repeat them.
    """
    if what in ("class", "exception") and not (
        inspect.isroutine(obj) or isinstance(obj, (property, functools.cached_property, classmethod, staticmethod))
    ):
        return True
    return None


def _reachable(url: str, timeout: float) -> bool:
    import urllib.request

    try:
        with urllib.request.urlopen(f"{url}/objects.inv", timeout=timeout) as response:
            return response.status == 200
    except (OSError, ValueError):
        return False


def intersphinx_mapping(projects: dict[str, str], mode: str, timeout: float = 3.0) -> dict[str, tuple[str, None]]:
    """``intersphinx_mapping`` for ``projects`` (name -> documentation URL) under ``FSMCTL_DOCS_INTERSPHINX``.

    ``on``: every project (a failed download is then Sphinx's warning); ``off``: none; ``auto``: the projects whose
    ``objects.inv`` answers within ``timeout`` seconds (probed in parallel), so that a machine without internet
    builds without those links instead of failing under ``-W``.  Anything else is an error.
    """
    if mode == "on":
        return {name: (url, None) for name, url in projects.items()}
    if mode == "off":
        return {}
    if mode != "auto":
        raise ValueError(f"FSMCTL_DOCS_INTERSPHINX must be auto, on or off, not {mode!r}")
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(max_workers=len(projects) or 1) as pool:
        up = dict(zip(projects, pool.map(lambda url: _reachable(url, timeout), projects.values()), strict=True))
    missing = [name for name, ok in up.items() if not ok]
    if missing:
        print(f"fsmctl_docs: intersphinx inventories not reachable, built without their links: {', '.join(missing)}")
    return {name: (url, None) for name, url in projects.items() if up[name]}


_CODE_NAME = re.compile(r"~?[A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)*")


def link_code_names(app, doctree, fromdocname: str) -> None:
    """``doctree-resolved``: inline code naming a documented fsmctl object links to its page.

    ``fsmctl.simulate``, ``fsmctl.simulate()`` or ``Scenario.replace`` (a name under ``fsmctl``) written as code
    in a guide page or a docstring becomes a link; code inside a link, a signature or on the object's own page is
    left alone, and so is anything that is not exactly one documented name.
    """
    from docutils import nodes
    from sphinx import addnodes

    objects = app.env.get_domain("py").objects
    for literal in list(doctree.findall(nodes.literal)):
        parent = literal.parent
        if isinstance(parent, (nodes.reference, addnodes.pending_xref, addnodes.desc_signature, nodes.title)):
            continue
        text = literal.astext().strip()
        name = text.removesuffix("()").lstrip("~")
        if not _CODE_NAME.fullmatch(name):
            continue
        full = next((c for c in (name, f"fsmctl.{name}") if c.startswith("fsmctl") and c in objects), None)
        if full is None:
            continue
        entry = objects[full]
        if entry.docname == fromdocname:
            continue
        uri = app.builder.get_relative_uri(fromdocname, entry.docname) + "#" + entry.node_id
        ref = nodes.reference("", "", internal=True, refuri=uri, reftitle=full)
        literal.replace_self(ref)
        ref.append(literal)


def setup(app):
    app.connect("autodoc-process-docstring", check_members)
    app.connect("doctree-resolved", link_code_names)
    app.connect("autodoc-skip-member", skip_data_members)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
