"""Where the generated code and fsmctl's cache live: paths only, no CasADi (so that loading a scenario stays light).

:mod:`fsmctl.model.generated_code` compiles and loads what is here; :mod:`fsmctl.model.laws` reads the law folders.
"""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

__all__ = ["GeneratedCodeError", "generated_dir", "builtin_law_scripts", "BUILTIN_LAW_SCRIPTS_PACKAGE", "cache_root"]

BUILTIN_LAW_SCRIPTS_PACKAGE = "fsmctl._builtin_laws"
"""The package data holding the built-in laws' derivation scripts (``derive/laws/`` of the source tree,
``pyproject.toml``); outputs name a built-in law's script as ``fsm.py in fsmctl._builtin_laws``."""


class GeneratedCodeError(RuntimeError):
    """``generated/`` is missing, inconsistent with its manifest, or failed to compile.

    Regenerate it with ``python -m derive`` (``python -m derive --check`` tells whether it is stale).

    Examples
    --------
    >>> from fsmctl.model import GeneratedCodeError
    >>> issubclass(GeneratedCodeError, RuntimeError)
    True
    """


def generated_dir() -> Path:
    """The folder of generated code (``generated/`` of the source tree or the installed package data).

    Returns
    -------
    pathlib.Path
        The folder holding ``manifest.json``, ``c/``, ``casadi/`` and ``laws/``.

    Raises
    ------
    GeneratedCodeError
        The package data is not installed or has no ``manifest.json``.

    Examples
    --------
    >>> from fsmctl.model import generated_dir
    >>> (generated_dir() / "manifest.json").is_file(), (generated_dir() / "laws" / "fsm").is_dir()
    (True, True)
    """
    try:
        path = Path(str(resources.files("fsmctl._generated")))
    except ModuleNotFoundError as exc:  # pragma: no cover - broken installation
        raise GeneratedCodeError("fsmctl._generated is not installed; run `python -m derive`") from exc
    if not (path / "manifest.json").is_file():
        raise GeneratedCodeError(f"{path}/manifest.json not found; run `python -m derive` to generate code")
    return path


def builtin_law_scripts() -> Path:
    """The folder of the built-in laws' derivation scripts: ``derive/laws/`` of the source tree.

    Installed as the package data ``fsmctl._builtin_laws`` (``pyproject.toml``), as ``generated/`` is
    ``fsmctl._generated``: the library reads the scripts as files (:func:`fsmctl.codegen.laws.load_derivation_script`)
    and never imports the ``derive`` package, which is not installed.

    Returns
    -------
    pathlib.Path
        The folder holding ``fsm.py``, ``pd.py``, ... (each built-in law's ``law.json`` names its script by a path
        of the source tree; :meth:`fsmctl.model.laws.LawCode.script` says where it is, from this folder).

    Raises
    ------
    GeneratedCodeError
        Neither the package data nor a source tree's ``derive/laws/`` is there.

    Examples
    --------
    >>> from fsmctl.model.generated_paths import builtin_law_scripts
    >>> (builtin_law_scripts() / "fsm.py").is_file()
    True
    """
    try:
        return Path(str(resources.files(BUILTIN_LAW_SCRIPTS_PACKAGE)))
    except ModuleNotFoundError:  # a source tree on sys.path, not installed
        tree = Path(__file__).resolve().parents[2] / "derive" / "laws"
    if not tree.is_dir():  # pragma: no cover - broken installation
        raise GeneratedCodeError("the built-in laws' derivation scripts (fsmctl._builtin_laws) are not installed")
    return tree


def cache_root() -> Path:
    """fsmctl's cache folder: ``$FSMCTL_CACHE_DIR``, else ``$XDG_CACHE_HOME/fsmctl``, else ``~/.cache/fsmctl``.

    Returns
    -------
    pathlib.Path
        The folder (not created here).

    Examples
    --------
    >>> import os
    >>> from fsmctl.model.generated_paths import cache_root
    >>> cache_root() == __import__("pathlib").Path(os.environ["FSMCTL_CACHE_DIR"]) if "FSMCTL_CACHE_DIR" in os.environ else True
    True
    """
    if os.environ.get("FSMCTL_CACHE_DIR"):
        return Path(os.environ["FSMCTL_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "fsmctl"
