"""Where the generated code and fsmctl's cache live: paths only, no CasADi (so that loading a scenario stays light).

:mod:`fsmctl.model.generated_code` compiles and loads what is here; :mod:`fsmctl.model.laws` reads the law folders.
"""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

__all__ = ["GeneratedCodeError", "generated_dir", "cache_root"]


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
